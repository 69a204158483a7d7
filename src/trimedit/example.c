/* The trim editor's built-in example (issue 11): a bicubic B-spline surface (4 x 4 Bézier
 * patches over [0, 1]^2, a smooth bump) with an outer loop (one closed cubic B-spline) and two
 * holes, a circle (exact rational quadratic, The NURBS Book 7.5) and a rectangle (degree 1).
 */
#include "crisp/trimedit.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

crisp_status crisp_trimedit_example(crisp_model **dest)
{
    *dest = NULL;
    enum { N = 7 };
    const double knots[N + 4] = {0, 0, 0, 0, 0.25, 0.5, 0.75, 1, 1, 1, 1};
    double pts[N * N * 3];
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            double x = i / (N - 1.0), y = j / (N - 1.0), *q = pts + 3 * (j * N + i);
            q[0] = x;
            q[1] = y;
            q[2] = 0.35 * sin(M_PI * x) * sin(M_PI * y) + 0.06 * cos(3 * x + 2 * y);
        }
    /* The outer loop: a clamped cubic whose ends meet at (0.5, 0.06), counter-clockwise. */
    const double outer[] = {0.5,  0.06, 0.85, 0.08, 0.95, 0.3, 0.93, 0.7,  0.8, 0.94,
                            0.45, 0.95, 0.12, 0.86, 0.05, 0.5, 0.15, 0.07, 0.5, 0.06};
    const int on = (int)(sizeof outer / sizeof outer[0]) / 2;
    double ok[16];
    for (int i = 0; i < 4; i++)
        ok[i] = 0, ok[on + i] = 1;
    for (int i = 4; i < on; i++)
        ok[i] = (i - 3.0) / (on - 3.0);
    crisp_model *m = NULL;
    crisp_face f = {0};
    crisp_trimedit *ed = NULL;
    crisp_status st = crisp_model_create(&m);
    if (st) return st;
    f.loops = calloc(1, sizeof *f.loops);
    if (!f.loops) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the example");
        goto fail;
    }
    f.loop_count = 1;
    f.loops[0].is_outer = 1;
    f.loops[0].curves = calloc(1, sizeof(crisp_curve *));
    if (!f.loops[0].curves) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the example");
        goto fail;
    }
    if ((st = crisp_curve_create(2, 3, on, ok, outer, NULL, &f.loops[0].curves[0]))) goto fail;
    f.loops[0].curve_count = 1;
    if ((st = crisp_surface_create(3, 3, N, N, knots, knots, pts, NULL, &f.surface))) goto fail;
    f.has_color = 1;
    f.color[0] = 0.85f, f.color[1] = 0.62f, f.color[2] = 0.35f, f.color[3] = 1.0f;
    if ((st = crisp_model_add_face(m, &f))) goto fail;
    f = (crisp_face){0};
    if ((st = crisp_trimedit_create(m, 0, NULL, &ed))) goto fail;
    const double c[2] = {0.33, 0.6}, lo[2] = {0.56, 0.28}, hi[2] = {0.76, 0.46};
    if ((st = crisp_trimedit_add_circle(ed, c, 0.12)) ||
        (st = crisp_trimedit_add_rectangle(ed, lo, hi)))
        goto fail;
    crisp_trimedit_destroy(ed);
    snprintf(m->format, sizeof m->format, "%s", "example");
    *dest = m;
    return CRISP_OK;
fail:
    crisp_trimedit_destroy(ed);
    crisp_face_free(&f);
    crisp_model_destroy(m);
    return st;
}
