/* What the libFuzzer targets do with what a reader accepted, shared so that every model reader
 * (IGES, STEP, OBJ) and every f-rep reader (.vm, math strings) is exercised the same way. */
#ifndef CRISP_FUZZ_COMMON_H
#define CRISP_FUZZ_COMMON_H

#include "crisp/frep.h"
#include "crisp/model.h"

/* A loaded model is summarised as `crisp info` would (stats, box), then freed. */
static inline void fuzz_use_model(crisp_status st, crisp_model *m)
{
    if (st != CRISP_OK) return;
    crisp_model_stats stats;
    double box[6];
    (void)crisp_model_stats_compute(m, &stats);
    crisp_model_bbox(m, box);
    crisp_model_destroy(m);
}

/* A loaded expression is flattened to a tape, evaluated at a point and over a box, and rendered
 * small in 2D and 3D, so odd constants (NaN, inf) and ops reach every evaluator; then freed. */
static inline void fuzz_use_frep(crisp_status st, crisp_frep *f)
{
    if (st != CRISP_OK) return;
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
}

#endif
