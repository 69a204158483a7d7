/* libFuzzer target for the f-rep .vm reader: any input must either load or fail with a
 * message, without crashes, leaks, hangs or unbounded allocation. Loaded expressions are also
 * flattened to a tape, evaluated at a point, over a box, and rendered small in 2D and 3D, so odd
 * constants (NaN, inf) and ops reach every evaluator. */
#include <stddef.h>
#include <stdint.h>

#include "crisp/frep.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    crisp_frep *f = NULL;
    if (crisp_frep_read_vm_mem("fuzz.vm", (const char *)data, size, &f) != CRISP_OK) return 0;
    crisp_frep_tape *t = NULL;
    if (crisp_frep_tape_create(f, &t) == CRISP_OK) {
        float x[2] = {-1, 0.5f}, y[2] = {-0.25f, 1}, z[2] = {0, 0}, iv[2];
        (void)crisp_frep_eval_point(t, 0.1f, 0.2f, 0.3f);
        crisp_frep_eval_interval(t, x, y, z, iv);
        for (int depth = 0; depth <= 8; depth += 8) {
            crisp_frep_render_desc d = {.width = 16, .height = 12, .depth = depth, .threads = 1};
            crisp_frep_renderer *r = NULL;
            if (crisp_frep_renderer_create(t, &d, &r) == CRISP_OK) (void)crisp_frep_renderer_run(r);
            crisp_frep_renderer_destroy(r);
        }
        crisp_frep_tape_destroy(t);
    }
    crisp_frep_destroy(f);
    return 0;
}
