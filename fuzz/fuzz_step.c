/* libFuzzer target for the STEP reader (ISO 10303-21 parser and the geometry/topology
 * conversion): any input must either load or fail with a message, without crashes, leaks, hangs
 * or unbounded allocation. Loaded models are also summarised as crisp info would. */
#include <stddef.h>
#include <stdint.h>

#include "crisp/io.h"
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    crisp_model *m = NULL;
    /* Read first: the order in which arguments are evaluated is unspecified. */
    crisp_status st = crisp_read_step_mem("fuzz.stp", (const char *)data, size, NULL, &m);
    fuzz_use_model(st, m);
    return 0;
}
