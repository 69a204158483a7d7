/* The screen error bound and level (crisp_slefe_patch_screen_error, crisp_slefe_patch_tess_level;
 * src/slefe/screen_error.c) on rational patches with weights 0.3..3, measured the way the
 * rasterizer draws (issue 12): the triangle point is the clip-space barycentric combination of
 * its vertices' clip positions Q(x_k) = view_proj (P(x_k), 1) (the camera's W, not the weight),
 * compared with the surface point at the same parameters. Random patches (degrees 1..4, some
 * cylinder strips like impeller.igs's: degree 1 x 2 quarter arcs, weights 1, 0.707, 1) under
 * random cameras (patches 3-600 px across, anywhere on the screen, a quarter seen from close to
 * the eye plane, where W varies most and some patches reach it: the functions refuse those),
 * the uniform tau x tau tessellation along both diagonals, 10-15 samples per triangle.
 * Prints the tightness (sampled / bound) and how many more triangles the level draws than the
 * smallest level whose samples are within eps. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/render.h"
#include "crisp/slefe.h"
#include "slefe/slefe_internal.h"
#include "slefe/slefe_test_util.h"

#define MAXN ((CRISP_SLEFE_MAX_DEGREE + 1) * (CRISP_SLEFE_MAX_DEGREE + 1) * 4)

/* A weight in [0.3, 3], log-uniform. */
static double weight(rng *r)
{
    return exp(log(0.3) + rng_uniform(r, 0, 1) * log(10.0));
}

/* A random rational patch over about [-1, 1]^2 with bumps of height h, or (kind 1) a strip of a
 * cylinder of radius 1 and length 2: degree 1 x 2, a quarter arc in t. */
static void rational_patch(rng *r, int kind, double *cpw, crisp_bezier_patch *p)
{
    if (kind == 1) {
        *p = (crisp_bezier_patch){.du = 1, .dv = 2, .rational = 1, .u1 = 1, .v1 = 1, .cpw = cpw};
        double a0 = rng_uniform(r, 0, 6.283), len = rng_uniform(r, 0.2, 2);
        const double ang[3] = {a0, a0 + M_PI / 4, a0 + M_PI / 2};
        const double rad[3] = {1, sqrt(2.0), 1}, w[3] = {1, sqrt(0.5), 1};
        for (int j = 0; j < 3; j++)
            for (int i = 0; i < 2; i++) {
                double *q = cpw + 4 * (j * 2 + i);
                double x = rad[j] * cos(ang[j]) - 0.5, y = rad[j] * sin(ang[j]) - 0.5;
                double z = (i - 0.5) * len;
                q[0] = w[j] * x, q[1] = w[j] * y, q[2] = w[j] * z, q[3] = w[j];
            }
        return;
    }
    int du = rng_int(r, 1, 4), dv = rng_int(r, 1, 4);
    double h = rng_uniform(r, 0, 0.8);
    *p = (crisp_bezier_patch){.du = du, .dv = dv, .rational = 1, .u1 = 1, .v1 = 1, .cpw = cpw};
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++) {
            double *q = cpw + 4 * (j * (du + 1) + i), w = weight(r);
            double x = -1 + 2.0 * i / du + 0.3 * (rng_uniform(r, 0, 1) - 0.5);
            double y = -1 + 2.0 * j / dv + 0.3 * (rng_uniform(r, 0, 1) - 0.5);
            double z = h * (rng_uniform(r, 0, 1) - 0.5);
            q[0] = w * x, q[1] = w * y, q[2] = w * z, q[3] = w;
        }
}

/* A camera at distance dist from a random point near the patch, from a random direction, aimed
 * so the patch lands anywhere on the screen (up to its border). near: the eye close to the
 * surface (a few tenths of the patch's size). */
static void any_view(rng *r, int near, crisp_slefe_view *v)
{
    double dist = near ? rng_uniform(r, 0.3, 2.0) : exp(rng_uniform(r, log(3.0), log(400.0)));
    double th = rng_uniform(r, 0, 1.3), ph = rng_uniform(r, 0, 6.283);
    crisp_camera c = {.fov_deg = 40, .width = 1920, .height = 1080};
    c.znear = 1e-3, c.zfar = 1e4;
    double look[3] = {rng_uniform(r, -0.5, 0.5), rng_uniform(r, -0.5, 0.5), 0};
    c.eye[0] = look[0] + dist * sin(th) * cos(ph);
    c.eye[1] = look[1] + dist * sin(th) * sin(ph);
    c.eye[2] = dist * cos(th);
    /* aim off the patch by up to the half field of view, so it may sit at the screen's edge */
    double off = dist * tan(20 * M_PI / 180) * rng_uniform(r, 0, 1.6);
    double a = rng_uniform(r, 0, 6.283);
    c.target[0] = look[0] + off * cos(a), c.target[1] = look[1] + off * sin(a);
    c.target[2] = 0;
    c.up[1] = 1;
    if (fabs(sin(th) * sin(ph)) > 0.95) c.up[1] = 0, c.up[2] = 1;
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(&c, &m);
    crisp_mat4_copy(m.view_proj, v->view_proj);
    v->width = c.width, v->height = c.height;
}

/* Clip position (X, Y, W) of the Euclidean surface point at (s, t), long double. */
static int clip_at(const crisp_bezier_patch *p, const crisp_slefe_view *v, long double s,
                   long double t, long double dest[3])
{
    long double h[4];
    for (int c = 0; c < 4; c++)
        h[c] = ref_patch(p, c, s, t);
    if (!(h[3] > 0)) return 0;
    long double P[4] = {h[0] / h[3], h[1] / h[3], h[2] / h[3], 1};
    for (int r = 0; r < 3; r++) {
        int k = r == 2 ? 3 : r;
        dest[r] = 0;
        for (int c = 0; c < 4; c++)
            dest[r] += (long double)v->view_proj[c][k] * P[c];
    }
    return dest[2] > 0;
}

/* Largest sampled pixel distance (max of x and y) between the surface and its tau x tau
 * tessellation (cells cut along 00-11 for diag 0, 10-01 for diag 1): each triangle point, the
 * clip-space barycentric combination of its vertices' clip positions, against the surface point
 * at the same parameters. -1 when a sample is not in front of the eye. */
static double sampled_error(const crisp_bezier_patch *p, const crisp_slefe_view *v, int tau,
                            int diag, int per_tri, rng *r)
{
    static long double grid[65 * 65][3];
    for (int j = 0; j <= tau; j++)
        for (int i = 0; i <= tau; i++)
            if (!clip_at(p, v, (long double)i / tau, (long double)j / tau, grid[j * (tau + 1) + i]))
                return -1;
    double worst = 0;
    for (int j = 0; j < tau; j++)
        for (int i = 0; i < tau; i++)
            for (int half = 0; half < 2; half++) {
                /* the triangle's corners in cell units and grid indices */
                int c[3][2];
                if (diag == 0) {
                    int a[2][3][2] = {{{0, 0}, {1, 0}, {1, 1}}, {{0, 0}, {1, 1}, {0, 1}}};
                    for (int k = 0; k < 3; k++)
                        c[k][0] = a[half][k][0], c[k][1] = a[half][k][1];
                } else {
                    int a[2][3][2] = {{{0, 0}, {1, 0}, {0, 1}}, {{1, 0}, {1, 1}, {0, 1}}};
                    for (int k = 0; k < 3; k++)
                        c[k][0] = a[half][k][0], c[k][1] = a[half][k][1];
                }
                for (int q = 0; q < per_tri; q++) {
                    long double l[3];
                    if (q < 3) { /* edge midpoints */
                        l[q] = 0, l[(q + 1) % 3] = 0.5L, l[(q + 2) % 3] = 0.5L;
                    } else if (q == 3) {
                        l[0] = l[1] = l[2] = 1.0L / 3;
                    } else {
                        long double a = rng_uniform(r, 0, 1), b = rng_uniform(r, 0, 1);
                        if (a + b > 1) a = 1 - a, b = 1 - b;
                        l[0] = a, l[1] = b, l[2] = 1 - a - b;
                    }
                    long double tri[3] = {0, 0, 0}, s = 0, t = 0, h[3];
                    for (int k = 0; k < 3; k++) {
                        const long double *g = grid[(j + c[k][1]) * (tau + 1) + i + c[k][0]];
                        for (int x = 0; x < 3; x++)
                            tri[x] += l[k] * g[x];
                        s += l[k] * (i + c[k][0]), t += l[k] * (j + c[k][1]);
                    }
                    if (!clip_at(p, v, s / tau, t / tau, h)) return -1;
                    long double ex = fabsl(h[0] / h[2] - tri[0] / tri[2]) * 0.5L * v->width;
                    long double ey = fabsl(h[1] / h[2] - tri[1] / tri[2]) * 0.5L * v->height;
                    worst = fmax(worst, (double)fmaxl(ex, ey));
                }
            }
    return worst;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static void test_rational_screen_error(void **state)
{
    (void)state;
    enum { TRIALS = 240 };
    rng r = {20261202};
    static double tight[3 * TRIALS], extra[TRIALS];
    int n = 0, ne = 0, refused = 0, near_checked = 0;
    for (int trial = 0; trial < TRIALS; trial++) {
        double cpw[MAXN];
        crisp_bezier_patch p;
        rational_patch(&r, trial % 4 == 1, cpw, &p);
        crisp_slefe_view v;
        int near = trial % 4 == 3;
        any_view(&r, near, &v);
        int taus[3] = {1, rng_int(&r, 2, 16), rng_int(&r, 17, 40)};
        for (int k = 0; k < 3; k++) {
            double bound;
            crisp_status st = crisp_slefe_patch_screen_error(&p, taus[k], &v, &bound);
            if (st) {
                assert_int_equal(st, CRISP_ERR_NUMERIC); /* reaches the eye plane */
                refused += k == 0;
                break;
            }
            double e = sampled_error(&p, &v, taus[k], (trial + k) % 2, k == 2 ? 5 : 12, &r);
            assert_true(e >= 0); /* a bound was given: the patch is in front of the eye */
            if (!(e <= bound))
                fail_msg("trial %d (%d x %d%s) tau %d: sampled %g px > bound %g px", trial, p.du,
                         p.dv, near ? ", near" : "", taus[k], e, bound);
            near_checked += near && k == 0;
            if (bound > 0.05) tight[n++] = e / bound;
        }
        int tau;
        crisp_status st = crisp_slefe_patch_tess_level(&p, &v, 0.5, 64, &tau);
        if (st || tau > 64) continue;
        double e = sampled_error(&p, &v, tau, trial % 2, 12, &r);
        if (!(e >= 0 && e <= 0.5))
            fail_msg("trial %d: level %d leaves %g px (eps 0.5)", trial, tau, e);
        /* the smallest level whose samples (both diagonals) are within eps (bisection: the
         * sampled error falls with the level) */
        int lo = 0, hi = tau;
        while (hi - lo > 1) {
            int mid = (lo + hi) / 2;
            if (sampled_error(&p, &v, mid, 0, 6, &r) <= 0.5 &&
                sampled_error(&p, &v, mid, 1, 6, &r) <= 0.5)
                hi = mid;
            else
                lo = mid;
        }
        extra[ne++] = (double)tau * tau / ((double)hi * hi);
    }
    qsort(tight, (size_t)n, sizeof *tight, cmp_double);
    qsort(extra, (size_t)ne, sizeof *extra, cmp_double);
    printf("rational patches (weights 0.3..3), %d bounds (%d patches refused at the eye plane, %d "
           "near-plane ones checked): tightness (sampled / bound) median %.2f, 90%% %.2f, max "
           "%.2f; level's triangles / the sampled-minimal level's: median %.2f, 90%% %.2f, max "
           "%.2f (%d levels)\n",
           n, refused, near_checked, tight[n / 2], tight[n * 9 / 10], tight[n - 1], extra[ne / 2],
           extra[ne * 9 / 10], extra[ne - 1], ne);
    assert_true(n > TRIALS);
    assert_true(near_checked > 10);
    assert_true(tight[n - 1] > 0.2); /* not vacuous */
}

/* The Euclidean bound alone (issue 12, session 7: screen_error.c euclid_c1, quotient.c), which
 * crisp_slefe_patch_screen_error takes where it is the smaller: on the same kinds of patches and
 * cameras, every level's samples within it; prints its tightness and, against the bound of
 * crisp_slefe_patch_screen_error before it (the homogeneous SLEFE plus the rasterizer's-point
 * term, which it replaces where smaller), how often and by how much it is the smaller. */
static void test_euclid_bound(void **state)
{
    (void)state;
    enum { TRIALS = 200 };
    rng r = {20261203};
    static double tight[3 * TRIALS];
    int n = 0, refused = 0, smaller = 0, cyl = 0, cyl_smaller = 0;
    for (int trial = 0; trial < TRIALS; trial++) {
        double cpw[MAXN];
        crisp_bezier_patch p;
        int kind = trial % 3 == 1;
        rational_patch(&r, kind, cpw, &p);
        crisp_slefe_view v;
        int near = trial % 4 == 3;
        any_view(&r, near, &v);
        int taus[3] = {1, rng_int(&r, 2, 16), rng_int(&r, 17, 40)};
        for (int k = 0; k < 3; k++) {
            double bound;
            crisp_status st = crisp__slefe_euclid_screen_error(&p, taus[k], &v, &bound);
            if (st) {
                assert_int_equal(st, CRISP_ERR_NUMERIC); /* reaches the eye plane */
                refused += k == 0;
                break;
            }
            double e = sampled_error(&p, &v, taus[k], (trial + k) % 2, k == 2 ? 5 : 12, &r);
            assert_true(e >= 0);
            if (!(e <= bound))
                fail_msg("trial %d (%d x %d%s) tau %d: sampled %g px > Euclidean bound %g px",
                         trial, p.du, p.dv, near ? ", near" : "", taus[k], e, bound);
            if (bound > 0.05) tight[n++] = e / bound;
            if (k == 0) {
                /* the combined bound is the smaller of the two */
                double both;
                assert_int_equal(crisp_slefe_patch_screen_error(&p, 1, &v, &both), CRISP_OK);
                assert_true(both <= bound);
                smaller += both == bound;
                cyl += kind;
                cyl_smaller += kind && both == bound;
            }
        }
    }
    qsort(tight, (size_t)n, sizeof *tight, cmp_double);
    printf("Euclidean bound on rational patches: %d bounds (%d patches refused): tightness median "
           "%.2f, 90%% %.2f, max %.2f; the smaller of the two bounds at level 1 on %d of %d "
           "patches (%d of %d cylinder strips)\n",
           n, refused, tight[n / 2], tight[n * 9 / 10], tight[n - 1], smaller, TRIALS - refused,
           cyl_smaller, cyl);
    assert_true(n > TRIALS);
    assert_true(tight[n - 1] > 0.2); /* not vacuous */
}

/* The level search's one-tile enclosure (session 20: screen_error.c rejects a level from one
 * corner tile of its SLEFE bound): crisp__slefe_coordinate_tile's values at every tile of every
 * grid equal crisp__slefe_patch_coordinate's, bit for bit, for degrees 1..6 in each direction
 * (the constant-degree copies and the degree-1 kernel included) and 1..16 segments. */
static void test_coordinate_tile(void **state)
{
    (void)state;
    rng r = {20261204};
    enum { G = CRISP_SLEFE_GRID(CRISP_SLEFE_MAX_SEGMENTS) * 4 };
    static double lo[G], up[G];
    int checked = 0;
    crisp__slefe_tables_init();
    for (int trial = 0; trial < 120; trial++) {
        double cpw[MAXN];
        int du = 1 + trial % 6, dv = 1 + trial / 6 % 6, m = rng_int(&r, 1, 16);
        if (trial % 5 == 0) du = 3, dv = 2;
        if (trial % 7 == 0) du = dv = m = 3; /* patch.c's bicubic3 */
        crisp_bezier_patch p = {.du = du, .dv = dv, .rational = 1, .u1 = 1, .v1 = 1, .cpw = cpw};
        for (int i = 0; i < (du + 1) * (dv + 1) * 4; i++)
            cpw[i] = rng_uniform(&r, -3, 3) + (i % 4 == 3 ? 4 : 0);
        for (int c = 0; c < 4; c++) {
            crisp__slefe_patch_coordinate(&p, m, c, lo, up);
            for (int kv = 0; kv < m; kv++)
                for (int ku = 0; ku < m; ku++) {
                    double tl[16], tu[16];
                    crisp__slefe_coordinate_tile(&p, m, c, ku, kv, tl, tu);
                    for (int j = 0; j < 2; j++)
                        for (int i = 0; i < 2; i++) {
                            int g = ((kv + j) * (m + 1) + ku + i) * 4 + c, t = (j * 2 + i) * 4 + c;
                            if (memcmp(&lo[g], &tl[t], sizeof(double)) ||
                                memcmp(&up[g], &tu[t], sizeof(double)))
                                fail_msg("%d x %d, m %d, coordinate %d, tile (%d, %d) point (%d, "
                                         "%d): [%.17g, %.17g] against [%.17g, %.17g]",
                                         du, dv, m, c, ku, kv, i, j, tl[t], tu[t], lo[g], up[g]);
                            checked++;
                        }
                }
        }
    }
    assert_true(checked > 10000);
}

/* The level search with the one-tile rejection names the same level, and forms the same
 * curvature sums for the depth bound, as the search that forms every bound whole
 * (crisp__slefe_quick_off), on rational patches of degrees 1..4 and cylinder strips from any
 * camera, for tolerances 0.1..2 px and level limits 8..64: the rejection must be sound (the
 * level the search names, not only a sound level). */
static void test_quick_reject_same_level(void **state)
{
    (void)state;
    rng r = {20261205};
    int searched = 0, above1 = 0;
    for (int trial = 0; trial < 1500; trial++) {
        double cpw[MAXN];
        crisp_bezier_patch p;
        rational_patch(&r, trial % 3 == 1, cpw, &p);
        crisp_slefe_view v;
        any_view(&r, trial % 4 == 3, &v);
        double eps = exp(rng_uniform(&r, log(0.1), log(2.0)));
        int max_level = trial % 5 == 0 ? 8 : 64;
        int tq = 0, tf = 0;
        crisp__slefe_level_info iq, iff;
        crisp__slefe_quick_off = 0;
        crisp_status sq = crisp__slefe_patch_tess_level(&p, &v, eps, max_level, &tq, &iq);
        crisp__slefe_quick_off = 1;
        crisp_status sf = crisp__slefe_patch_tess_level(&p, &v, eps, max_level, &tf, &iff);
        crisp__slefe_quick_off = 0;
        assert_int_equal(sq, sf);
        if (sq) continue;
        if (tq != tf)
            fail_msg("trial %d (%d x %d, eps %g): level %d with the one-tile rejection, %d without",
                     trial, p.du, p.dv, eps, tq, tf);
        for (int i = 0; i < 3; i++)
            assert_true((isnan(iq.kw[i]) && isnan(iff.kw[i])) || iq.kw[i] == iff.kw[i]);
        searched++;
        above1 += tq > 2;
    }
    printf("one-tile rejection: %d searches, %d with a level above 2, the same levels\n", searched,
           above1);
    assert_true(above1 > 300);
}

/* quotient.c's lanes path (three coordinates as AVX2 lanes) against its scalar body: the bounds
 * crisp__slefe_quotient_curvature forms (whole patch, 2 x 2 and 4 x 4 pieces) equal bit for bit
 * for degrees 1..6 x 1..6, 6 x 10 and 15 x 15 (no degree raise above 15), coefficients of any
 * scale, weights varying, equal, not positive, and values whose quotient overflows (that lane's
 * bound INFINITY, the others finite). */
static void test_quotient_lanes(void **state)
{
    (void)state;
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    if (!__builtin_cpu_supports("avx2")) {
        printf("test_quotient_lanes: no AVX2, skipped\n");
        return;
    }
#else
    return;
#endif
    rng r = {0x5eed10};
    int compared = 0, infinite = 0;
    static double c[MAXN];
    for (int trial = 0; trial < 6000; trial++) {
        int du, dv;
        if (trial % 10 == 9)
            du = rng_int(&r, 0, 1) ? 6 : 15, dv = du == 6 ? 10 : 15;
        else
            du = rng_int(&r, 1, 6), dv = rng_int(&r, 1, 6);
        int n = (du + 1) * (dv + 1), kind = rng_int(&r, 0, 9);
        double scale = exp(rng_uniform(&r, -20, 20));
        for (int i = 0; i < n; i++) {
            for (int q = 0; q < 3; q++)
                c[4 * i + q] = scale * rng_uniform(&r, -1, 1);
            c[4 * i + 3] = kind == 0 ? 1.25 : weight(&r);
        }
        if (kind == 1) c[4 * rng_int(&r, 0, n - 1) + 3] = rng_int(&r, 0, 1) ? 0.0 : -0.5;
        if (kind == 2) { /* one coordinate's quotient overflows */
            int i = rng_int(&r, 0, n - 1);
            c[4 * i + rng_int(&r, 0, 2)] = 1e300, c[4 * i + 3] = 1e-10;
        }
        if (kind == 4) /* a weight the same everywhere and huge: halves copy it, never sum it */
            for (int i = 0; i < n; i++)
                c[4 * i + 3] = 1e308;
        if (kind == 3) /* a coordinate constant */
            for (int i = 0; i < n; i++)
                c[4 * i + 1] = 0.5 * c[3];
        int k = 1 << rng_int(&r, 0, 2);
        double Ks[3], Kv[3];
        crisp__slefe_quotient_lanes = 0;
        crisp__slefe_quotient_curvature(c, 3, du, dv, k, Ks);
        crisp__slefe_quotient_lanes = 1;
        crisp__slefe_quotient_curvature(c, 3, du, dv, k, Kv);
        if (memcmp(Ks, Kv, sizeof Ks)) {
            printf("trial %d (%d x %d, k %d, kind %d): scalar %.17g %.17g %.17g, lanes %.17g %.17g "
                   "%.17g\n",
                   trial, du, dv, k, kind, Ks[0], Ks[1], Ks[2], Kv[0], Kv[1], Kv[2]);
            fail();
        }
        compared++;
        infinite += kind == 2 && isinf(Ks[0]) + isinf(Ks[1]) + isinf(Ks[2]) == 1;
    }
    crisp__slefe_quotient_lanes = -1;
    printf("test_quotient_lanes: %d compared, %d with one lane infinite\n", compared, infinite);
    assert_true(infinite > 100);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rational_screen_error),
        cmocka_unit_test(test_euclid_bound),
        cmocka_unit_test(test_coordinate_tile),
        cmocka_unit_test(test_quick_reject_same_level),
        cmocka_unit_test(test_quotient_lanes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
