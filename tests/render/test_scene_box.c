/* The scene box that frames the default camera covers what the faces can show: a large plane
 * trimmed to a small square frames the square (within the clipped patches' boxes), an untrimmed
 * face frames all of itself, and a patch that no loop reaches adds nothing. Also: the sub-patch
 * extraction behind the scene boxes, the planner's cells and the CPU backend's leaf hulls gives
 * the bits of cutting by crisp_bezier_patch_split_u/_v. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/model.h"
#include "crisp/render.h"
#include "render/render_internal.h"

/* The plane z = 0 over [0, 10]^2 as a bilinear patch with (u, v) = (x, y), split by a knot at
 * u = 5 into two Bézier patches; trimmed (when `trim`) to the square [1, 2] x [6, 7]. */
static void add_plane(crisp_model *m, int trim, double z)
{
    double ku[5] = {0, 0, 5, 10, 10}, kv[4] = {0, 0, 10, 10};
    double pts[3 * 2 * 3];
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 3; i++) {
            double *p = pts + 3 * (j * 3 + i);
            p[0] = 5.0 * i, p[1] = 10.0 * j, p[2] = z;
        }
    crisp_face face = {0};
    assert_int_equal(crisp_surface_create(1, 1, 3, 2, ku, kv, pts, NULL, &face.surface), CRISP_OK);
    if (trim) {
        face.loop_count = 1;
        face.loops = crisp_calloc_array(1, sizeof *face.loops);
        face.loops[0].is_outer = 1;
        face.loops[0].curve_count = 4;
        face.loops[0].curves = crisp_calloc_array(4, sizeof(crisp_curve *));
        double c[5][2] = {{1, 6}, {2, 6}, {2, 7}, {1, 7}, {1, 6}}, k[4] = {0, 0, 1, 1};
        for (int e = 0; e < 4; e++) {
            double q[4] = {c[e][0], c[e][1], c[e + 1][0], c[e + 1][1]};
            assert_int_equal(crisp_curve_create(2, 1, 2, k, q, NULL, &face.loops[0].curves[e]),
                             CRISP_OK);
        }
    }
    assert_int_equal(crisp_model_add_face(m, &face), CRISP_OK);
}

static void test_trimmed_box(void **state)
{
    (void)state;
    crisp_model *m = NULL;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    add_plane(m, 1, 0);
    crisp_scene *sc = NULL;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    double want[6] = {1, 6, 0, 2, 7, 0};
    for (int k = 0; k < 6; k++)
        assert_true(fabs(sc->box[k] - want[k]) < 1e-9);
    crisp_scene_destroy(sc);
    /* an untrimmed face beside it frames all of itself */
    add_plane(m, 0, 3);
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    double want2[6] = {0, 0, 0, 10, 10, 3};
    for (int k = 0; k < 6; k++)
        assert_true(fabs(sc->box[k] - want2[k]) < 1e-9);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* The reference: split, keep a part, as crisp__subpatch did before it cut in place. */
static void ref_cut(crisp_bezier_patch *a, double at, int along_u, int keep_upper, double *buf)
{
    size_t n = (size_t)(a->du + 1) * (a->dv + 1) * 4;
    crisp_bezier_patch lo = *a, hi = *a;
    lo.cpw = buf, hi.cpw = buf + n;
    if (along_u)
        crisp_bezier_patch_split_u(a, at, &lo, &hi);
    else
        crisp_bezier_patch_split_v(a, at, &lo, &hi);
    double *keep = a->cpw;
    memcpy(keep, (keep_upper ? hi : lo).cpw, n * sizeof *keep);
    *a = keep_upper ? hi : lo;
    a->cpw = keep;
}

/* Random patches (degrees 1..CRISP_MAX_DEGREE, rational) and sub-rectangles, dyadic ones as the
 * leaves use and arbitrary ones: crisp__subpatch's control points and parameter box equal the
 * reference's bit for bit (the planner's levels and the leaf hulls stay what they were). */
static void test_subpatch_bits(void **state)
{
    (void)state;
    srand(12);
    double cp[CRISP__PATCH_DOUBLES], ref[CRISP__PATCH_DOUBLES], buf[2 * CRISP__PATCH_DOUBLES];
    double storage[2 * CRISP__PATCH_DOUBLES], tmp[CRISP__PATCH_DOUBLES];
    for (int trial = 0; trial < 2000; trial++) {
        crisp_bezier_patch p = {.du = 1 + rand() % CRISP_MAX_DEGREE,
                                .dv = 1 + rand() % CRISP_MAX_DEGREE,
                                .rational = 1,
                                .u0 = -1.5,
                                .u1 = 2.25,
                                .v0 = 0.125,
                                .v1 = 7.0 / 3,
                                .cpw = cp};
        int n = (p.du + 1) * (p.dv + 1);
        for (int k = 0; k < n; k++) {
            double w = 0.3 + 2.7 * rand() / RAND_MAX;
            for (int c = 0; c < 3; c++)
                cp[4 * k + c] = w * (20.0 * rand() / RAND_MAX - 10);
            cp[4 * k + 3] = w;
        }
        double r[4];
        if (trial % 2) { /* a dyadic cell, as a leaf (depth, ix, iy) */
            int depth = rand() % 7;
            double sz = ldexp(1.0, -depth);
            int ix = rand() % (1 << depth), iy = rand() % (1 << depth);
            r[0] = ix * sz, r[1] = (ix + 1) * sz, r[2] = iy * sz, r[3] = (iy + 1) * sz;
        } else {
            for (int k = 0; k < 4; k++)
                r[k] = (double)rand() / RAND_MAX;
            if (trial % 6 == 0) r[0] = 0, r[3] = 1; /* some sides kept */
            if (r[0] > r[1]) {
                double t = r[0];
                r[0] = r[1], r[1] = t;
            }
            if (r[2] > r[3]) {
                double t = r[2];
                r[2] = r[3], r[3] = t;
            }
            if (r[1] == r[0] || r[3] == r[2]) continue;
        }
        crisp_bezier_patch a = p, sub;
        memcpy(ref, cp, (size_t)n * 4 * sizeof *ref);
        a.cpw = ref;
        double s1 = r[1], t1 = r[3];
        if (r[0] > 0) {
            ref_cut(&a, r[0], 1, 1, buf);
            s1 = (s1 - r[0]) / (1 - r[0]);
        }
        if (s1 < 1) ref_cut(&a, s1, 1, 0, buf);
        if (r[2] > 0) {
            ref_cut(&a, r[2], 0, 1, buf);
            t1 = (t1 - r[2]) / (1 - r[2]);
        }
        if (t1 < 1) ref_cut(&a, t1, 0, 0, buf);
        crisp__subpatch(&p, r[0], r[1], r[2], r[3], storage, tmp, &sub);
        assert_ptr_equal(sub.cpw, storage);
        assert_int_equal(sub.du, p.du);
        assert_int_equal(sub.dv, p.dv);
        assert_memory_equal(&sub.u0, &a.u0, sizeof a.u0);
        assert_memory_equal(&sub.u1, &a.u1, sizeof a.u1);
        assert_memory_equal(&sub.v0, &a.v0, sizeof a.v0);
        assert_memory_equal(&sub.v1, &a.v1, sizeof a.v1);
        assert_memory_equal(sub.cpw, ref, (size_t)n * 4 * sizeof *ref);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_trimmed_box),
                                       cmocka_unit_test(test_subpatch_bits)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
