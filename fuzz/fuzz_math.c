/* libFuzzer target for the f-rep math-string reader: any input must either load or fail with a
 * message, without crashes, leaks, hangs or unbounded allocation. Loaded expressions are also
 * flattened to a tape, evaluated at a point, over a box, and rendered small in 2D and 3D, so odd
 * constants (NaN, inf) and ops reach every evaluator. */
#include <stddef.h>
#include <stdint.h>

#include "crisp/frep.h"
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    crisp_frep *f = NULL;
    /* Read first: the order in which arguments are evaluated is unspecified. */
    crisp_status st = crisp_frep_read_math_mem("fuzz.math", (const char *)data, size, &f);
    fuzz_use_frep(st, f);
    return 0;
}
