/* libFuzzer target for the IGES reader (records, global section, directory, parameter records,
 * every entity converter and the loop normalisation): any input must either load or fail with a
 * message, without crashes, leaks, hangs or unbounded allocation. Loaded models are summarised
 * (stats, box) as crisp info would. Seeds: fuzz/corpus/iges/ (small hand-written files, one per
 * entity family, and the first patch of gpucast_teapot.igs). */
#include <stddef.h>
#include <stdint.h>

#include "crisp/io.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    crisp_model *m = NULL;
    if (crisp_read_iges_mem("fuzz.igs", (const char *)data, size, NULL, &m) == CRISP_OK) {
        crisp_model_stats stats;
        double box[6];
        (void)crisp_model_stats_compute(m, &stats);
        crisp_model_bbox(m, box);
        crisp_model_destroy(m);
    }
    return 0;
}
