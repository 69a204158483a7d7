/* The level choice's shortcuts (issue 12, session 8): what the planner's tree pass (quadtree.c
 * build_cell) skips or reuses must give the levels the full computations give, on random
 * rational and polynomial patches (degrees 1-6, weights 0.5..2 or within 3% of each other, as
 * occt_linkrods.step's) under random cameras:
 * - the W curvature the screen bound's level search formed (crisp__slefe_level_info) is, bit for
 *   bit, the bound depth_bound.c forms from the same patch, and the depth level with it equals
 *   the depth level without it;
 * - the cheaper curvature bound the depth check tries first (crisp__slefe_quotient_curvature_mid)
 *   is never below the full one, and the depth level is the one the full bounds over 1, 2 x 2
 *   and 4 x 4 pieces name (computed here the way depth_bound.c did before the shortcut);
 * - crisp__slefe_patch_tess_level gives crisp_slefe_patch_tess_level's level;
 * - the range crisp__slefe_search_begin names before the search's loop holds the level the loop
 *   names (build_cell's children's rule splits from the range alone where every level in it
 *   would make the rule split). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "crisp/render.h"
#include "crisp/slefe.h"
#include "render/depth_bound.h"
#include "render/render_test_util.h"
#include "slefe/slefe_internal.h"

static uint64_t rng = 0x2545f4914f6cdd1dull;
static double rnd(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* A random patch of degrees du x dv over about [-s, s]^2 with bumps of height h; weights: 0 all
 * 1, 1 log-uniform in [0.5, 2], 2 within [1, 1.03]. */
static void random_patch(crisp_bezier_patch *p, double *cpw, int du, int dv, double size, double h,
                         int weights)
{
    *p = (crisp_bezier_patch){
        .du = du, .dv = dv, .rational = weights > 0, .u1 = 1, .v1 = 1, .cpw = cpw};
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++) {
            double *q = cpw + 4 * (j * (du + 1) + i);
            double w = weights == 1   ? exp(log(0.5) + rnd() * log(4.0))
                       : weights == 2 ? 1 + 0.03 * rnd()
                                      : 1;
            double x = size * (-1 + 2.0 * i / du + 0.3 * (rnd() - 0.5));
            double y = size * (-1 + 2.0 * j / dv + 0.3 * (rnd() - 0.5));
            double z = h * (rnd() - 0.5);
            q[0] = w * x, q[1] = w * y, q[2] = w * z, q[3] = w;
        }
}

/* A camera at distance dist looking at the origin from up to 80 degrees off the patch's normal,
 * target moved off the centre; fov 10-70 degrees. */
static void random_view(double dist, crisp_slefe_view *v)
{
    crisp_camera c;
    crisp_camera_matrices m;
    rt_random_camera(rnd, dist, 1, 1.4, 0.4, 0.001, &c, &m);
    crisp_mat4_copy(m.view_proj, v->view_proj);
    v->width = c.width, v->height = c.height;
}

/* The depth level as depth_bound.c formed it before the shortcuts: the full bound over the whole
 * patch, then its 2 x 2 and 4 x 4 pieces while it asks for more than tau. */
static int reference_depth_level(const crisp_bezier_patch *p, const crisp_slefe_view *v, double eps,
                                 int tau, int max_level)
{
    double c[2 * 16 * 16], lo = INFINITY, hi = -INFINITY;
    crisp__depth_clip_coefficients(p, (double(*)[4])v->view_proj, c);
    int n = (p->du + 1) * (p->dv + 1);
    for (int i = 0; i < n; i++) {
        double d = c[2 * i] / c[2 * i + 1];
        if (!(d > 0) || !isfinite(d)) return tau;
        lo = fmin(lo, d), hi = fmax(hi, d);
    }
    double allow =
        eps * crisp__depth_px_scale((double(*)[4])v->view_proj, (int)v->width, (int)v->height) * lo;
    if (!(allow > 0) || hi - lo <= allow) return tau;
    double K = INFINITY, enough = 8 * allow * tau * tau;
    for (int k = 1; k <= 4 && (k == 1 || K > enough); k *= 2) {
        double Kk;
        crisp__slefe_quotient_curvature(c, 1, p->du, p->dv, k, &Kk);
        K = fmin(K, Kk);
    }
    if (!isfinite(K)) return tau;
    double need = ceil(sqrt(K / (8 * allow)));
    if (!(need <= max_level)) return max_level + 1;
    return (int)need > tau ? (int)need : tau;
}

static void test_shared_w_curvature(void **state)
{
    (void)state;
    double cpw[7 * 7 * 4];
    int formed = 0, pieces = 0, levels = 0, raised = 0;
    for (int trial = 0; trial < 1500; trial++) {
        int du = 1 + (int)(6 * rnd()), dv = 1 + (int)(6 * rnd());
        crisp_bezier_patch p;
        double size = exp(log(0.01) + rnd() * log(100.0));
        random_patch(&p, cpw, du, dv, size, size * 2 * rnd(), 1 + trial % 2);
        crisp_slefe_view v;
        random_view(3 + 3 * rnd(), &v);
        crisp__slefe_level_info info;
        int tau = 0, tau_pub = 0;
        crisp_status st = crisp__slefe_patch_tess_level(&p, &v, 0.5, 64, &tau, &info);
        crisp_status st_pub = crisp_slefe_patch_tess_level(&p, &v, 0.5, 64, &tau_pub);
        assert_int_equal(st, st_pub);
        if (!st) assert_int_equal(tau, tau_pub);
        double c[2 * 7 * 7];
        crisp__depth_clip_coefficients(&p, (double(*)[4])v.view_proj, c);
        for (int i = 0; i < 3; i++) {
            if (isnan(info.kw[i])) continue;
            double K;
            crisp__slefe_quotient_curvature(c, 1, du, dv, 1 << i, &K);
            if (!(K == info.kw[i]))
                fail_msg("trial %d (%d x %d): W curvature over %d x %d pieces %.17g, the search "
                         "formed %.17g",
                         trial, du, dv, 1 << i, 1 << i, K, info.kw[i]);
            formed += i == 0, pieces += i > 0;
        }
        int from[2] = {1, st || tau > 64 ? 1 : tau};
        for (int k = 0; k < 2; k++) {
            int shared = crisp__depth_tess_level_kw(&p, v.view_proj, (int)v.width, (int)v.height,
                                                    0.5, from[k], 64, info.kw);
            int own = crisp__depth_tess_level(&p, v.view_proj, (int)v.width, (int)v.height, 0.5,
                                              from[k], 64);
            int ref = reference_depth_level(&p, &v, 0.5, from[k], 64);
            if (shared != own || own != ref)
                fail_msg("trial %d (%d x %d) from level %d: depth level %d with the shared "
                         "curvature, %d without, %d formed in full",
                         trial, du, dv, from[k], shared, own, ref);
            levels++;
            raised += ref > from[k];
        }
    }
    printf("shared W curvature: formed by the screen search on %d patches (%d piece bounds), "
           "equal bit for bit; %d depth levels equal with and without it and to the full "
           "computation (%d raised)\n",
           formed, pieces, levels, raised);
    assert_true(formed > 500);
    assert_true(pieces > 20);
    assert_true(raised > 50);
}

static void test_mid_bound(void **state)
{
    (void)state;
    double cpw[7 * 7 * 4];
    int checked = 0, looser = 0, levels = 0, raised = 0;
    for (int trial = 0; trial < 2000; trial++) {
        int du = 1 + (int)(6 * rnd()), dv = 1 + (int)(6 * rnd());
        crisp_bezier_patch p;
        double size = exp(log(0.01) + rnd() * log(100.0));
        random_patch(&p, cpw, du, dv, size, size * 2 * rnd(), trial % 3);
        crisp_slefe_view v;
        random_view(3 + 3 * rnd(), &v);
        /* X, Y, W of the Euclidean clip point (quotient.c's layout: values, then the weight) */
        double c[4 * 7 * 7];
        int n = (du + 1) * (dv + 1);
        for (int i = 0; i < n; i++) {
            const double *q = cpw + 4 * i;
            for (int r = 0; r < 3; r++) {
                int row = r == 2 ? 3 : r;
                c[4 * i + r] = v.view_proj[0][row] * q[0] + v.view_proj[1][row] * q[1] +
                               v.view_proj[2][row] * q[2] + v.view_proj[3][row] * q[3];
            }
            c[4 * i + 3] = q[3];
        }
        double full[3], mid[3];
        crisp__slefe_quotient_curvature(c, 3, du, dv, 1, full);
        crisp__slefe_quotient_curvature_mid(c, 3, du, dv, 1, mid);
        for (int r = 0; r < 3; r++) {
            if (!(mid[r] >= full[r]))
                fail_msg("trial %d (%d x %d) coordinate %d: mid-only bound %.17g below the full "
                         "%.17g",
                         trial, du, dv, r, mid[r], full[r]);
            checked++;
            looser += mid[r] > full[r];
        }
        for (int tau = 1; tau <= 8; tau *= 2) {
            int got =
                crisp__depth_tess_level(&p, v.view_proj, (int)v.width, (int)v.height, 0.5, tau, 64);
            int ref = reference_depth_level(&p, &v, 0.5, tau, 64);
            if (got != ref)
                fail_msg("trial %d (%d x %d) from level %d: depth level %d, %d formed in full",
                         trial, du, dv, tau, got, ref);
            levels++;
            raised += ref > tau;
        }
    }
    printf("mid-only curvature bound: never below the full one (%d coordinates, looser on %d); "
           "%d depth levels equal to the full computation's (%d raised)\n",
           checked, looser, levels, raised);
    assert_true(looser > 100);
    assert_true(raised > 100);
}

static void test_search_range(void **state)
{
    (void)state;
    double cpw[16 * 16 * 4];
    int ranges = 0, narrow = 0, decided = 0;
    for (int trial = 0; trial < 1500; trial++) {
        int du = 1 + (int)(10 * rnd()), dv = 1 + (int)(10 * rnd());
        crisp_bezier_patch p;
        double size = exp(log(0.01) + rnd() * log(100.0));
        random_patch(&p, cpw, du, dv, size, size * 2 * rnd(), trial % 3);
        crisp_slefe_view v;
        random_view(2 + 4 * rnd(), &v);
        crisp__slefe_search sr;
        int tau = -1, lo = 0, hi = 0, full = -1;
        crisp_status st = crisp__slefe_search_begin(&sr, &p, &v, 0.5, 64, &tau, &lo, &hi, NULL);
        crisp_status st_full = crisp_slefe_patch_tess_level(&p, &v, 0.5, 64, &full);
        if (st || tau) {
            assert_int_equal(st, st_full);
            if (!st) assert_int_equal(tau, full);
            decided += !st;
            continue;
        }
        int got = -1;
        assert_int_equal(crisp__slefe_search_finish(&sr, &p, &got, NULL), st_full);
        if (st_full) continue;
        assert_int_equal(got, full);
        if (!(full == 65 || (lo <= full && full <= hi)))
            fail_msg("trial %d (%d x %d, weights %d): level %d outside the range [%d, %d]", trial,
                     du, dv, trial % 3, full, lo, hi);
        ranges++;
        narrow += lo > 1;
    }
    printf("search range: %d levels decided before the loop, %d inside the range named before "
           "it (%d with a lower end above 1)\n",
           decided, ranges, narrow);
    assert_true(ranges > 100);
    assert_true(narrow > 50);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shared_w_curvature),
        cmocka_unit_test(test_mid_bound),
        cmocka_unit_test(test_search_range),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
