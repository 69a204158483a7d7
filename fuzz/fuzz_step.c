/* libFuzzer target for the STEP reader (ISO 10303-21 parser and the geometry/topology
 * conversion): any input must either load or fail with a message, without crashes, leaks, hangs
 * or unbounded allocation. Loaded models are also summarised as crisp info would. */
#include <stddef.h>
#include <stdint.h>

#include "crisp/io.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    crisp_model *m = NULL;
    if (crisp_read_step_mem("fuzz.stp", (const char *)data, size, NULL, &m) == CRISP_OK) {
        crisp_model_stats stats;
        double box[6];
        (void)crisp_model_stats_compute(m, &stats);
        crisp_model_bbox(m, box);
        crisp_model_destroy(m);
    }
    return 0;
}
