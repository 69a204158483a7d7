/* libFuzzer target for the IGES reader (records, global section, directory, parameter records,
 * every entity converter and the loop normalisation): any input must either load or fail with a
 * message, without crashes, leaks, hangs or unbounded allocation. Loaded models are summarised
 * (stats, box) as crisp info would. Seeds: fuzz/corpus/iges/ (small hand-written files, one per
 * entity family, and the first patch of gpucast_teapot.igs). */
#include <stddef.h>
#include <stdint.h>

#include "crisp/io.h"
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    crisp_model *m = NULL;
    /* Read first: the order in which arguments are evaluated is unspecified. */
    crisp_status st = crisp_read_iges_mem("fuzz.igs", (const char *)data, size, NULL, &m);
    fuzz_use_model(st, m);
    return 0;
}
