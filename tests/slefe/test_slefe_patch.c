/* Property tests for tensor-product and screen-space SLEFEs: on random polynomial and rational
 * patches (bicubic and degree (5, 6)) and random perspective cameras, the enclosures contain the
 * true surface at dense samples; the specialised bicubic path equals the general two-pass
 * construction; tables built concurrently on first use agree. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <pthread.h>
#include <string.h>

#include "crisp/slefe.h"
#include "slefe/slefe_test_util.h"

#define MAXN ((CRISP_SLEFE_MAX_DEGREE + 1) * (CRISP_SLEFE_MAX_DEGREE + 1) * 4)
#define GRID4 (CRISP_SLEFE_GRID(CRISP_SLEFE_MAX_SEGMENTS) * 4)
#define TILES3 (CRISP_SLEFE_MAX_SEGMENTS * CRISP_SLEFE_MAX_SEGMENTS * 3)

static void *table_thread(void *arg)
{
    crisp_slefe_table *t = arg;
    for (int d = 2; d <= CRISP_SLEFE_MAX_DEGREE; d++)
        if (crisp_slefe_table_get(d, 5, &t[d]) != CRISP_OK) return arg;
    return NULL;
}

/* First use from several threads at once: every thread sees the same, complete tables. */
static void test_tables_concurrent_first_use(void **state)
{
    (void)state;
    enum { N = 4 };
    pthread_t th[N];
    static crisp_slefe_table t[N][CRISP_SLEFE_MAX_DEGREE + 1];
    for (int i = 0; i < N; i++)
        assert_int_equal(pthread_create(&th[i], NULL, table_thread, t[i]), 0);
    for (int i = 0; i < N; i++) {
        void *ret;
        assert_int_equal(pthread_join(th[i], &ret), 0);
        assert_null(ret);
    }
    for (int d = 2; d <= CRISP_SLEFE_MAX_DEGREE; d++)
        for (int i = 1; i < N; i++) {
            assert_ptr_equal(t[i][d].lower, t[0][d].lower);
            assert_true(t[i][d].lower[0] < 0.0);
        }
}

/* Bilinear interpolant of grid values v[(kv * (m + 1) + ku) * 4 + c] at (s, t). */
static long double bilinear(const double *v, int c, int m, long double s, long double t)
{
    int ku = (int)(s * m), kv = (int)(t * m);
    if (ku >= m) ku = m - 1;
    if (kv >= m) kv = m - 1;
    long double fu = s * m - ku, fv = t * m - kv;
    int n = m + 1;
    long double a = v[(kv * n + ku) * 4 + c], b = v[(kv * n + ku + 1) * 4 + c];
    long double d = v[((kv + 1) * n + ku) * 4 + c], e = v[((kv + 1) * n + ku + 1) * 4 + c];
    return (1 - fv) * ((1 - fu) * a + fu * b) + fv * ((1 - fu) * d + fu * e);
}

/* Sample parameters: a dense regular grid (hitting breakpoints and tile edges) plus random ones. */
static void sample_st(rng *r, int i, int n, long double *s, long double *t)
{
    if (i < 21 * 21) {
        *s = (long double)(i % 21) / 20;
        *t = (long double)(i / 21) / 20;
    } else {
        *s = rng_uniform(r, 0, 1);
        *t = rng_uniform(r, 0, 1);
    }
    (void)n;
}

static void check_patch_enclosure(rng *r, int du, int dv, int rational, int m, int samples)
{
    double cpw[MAXN], lo[GRID4], up[GRID4], bl[TILES3], bh[TILES3];
    crisp_bezier_patch p;
    random_patch(r, du, dv, rational, cpw, &p);
    assert_int_equal(crisp_slefe_patch(&p, m, lo, up), CRISP_OK);
    /* grid-point boxes contain the surface point at each breakpoint */
    double pl[GRID4], ph[GRID4];
    if (crisp_slefe_patch_points(m, lo, up, pl, ph) == CRISP_OK) {
        for (int kv = 0; kv <= m; kv++)
            for (int ku = 0; ku <= m; ku++) {
                long double s = (long double)ku / m, t = (long double)kv / m;
                long double w = ref_patch(&p, 3, s, t);
                for (int c = 0; c < 3; c++) {
                    long double e = ref_patch(&p, c, s, t) / w;
                    int g = (kv * (m + 1) + ku) * 3 + c;
                    assert_true(pl[g] <= e && e <= ph[g]);
                }
            }
    } else {
        assert_true(rational);
    }
    crisp_status ts = crisp_slefe_patch_tiles(m, lo, up, bl, bh);
    if (!rational) assert_int_equal(ts, CRISP_OK);
    for (int i = 0; i < samples; i++) {
        long double s, t, h[4];
        sample_st(r, i, samples, &s, &t);
        for (int c = 0; c < 4; c++) {
            h[c] = ref_patch(&p, c, s, t);
            long double l = bilinear(lo, c, m, s, t), u = bilinear(up, c, m, s, t);
            if (!(l <= h[c] && h[c] <= u))
                fail_msg("(%d,%d) rational %d m %d coordinate %d at (%Lg, %Lg): %Lg <= %Lg <= %Lg",
                         du, dv, rational, m, c, s, t, l, h[c], u);
        }
        if (ts != CRISP_OK) continue;
        int ku = (int)(s * m), kv = (int)(t * m);
        if (ku >= m) ku = m - 1;
        if (kv >= m) kv = m - 1;
        for (int c = 0; c < 3; c++) {
            long double e = h[c] / h[3];
            int b = (kv * m + ku) * 3 + c;
            if (!(bl[b] <= e && e <= bh[b]))
                fail_msg("tile box (%d,%d) coordinate %d: %g <= %Lg <= %g", ku, kv, c, bl[b], e,
                         bh[b]);
        }
    }
}

/* Random bicubic and (5, 6) patches, polynomial and rational, on several m (m = 3 takes the
 * specialised bicubic path): every homogeneous coordinate lies between the bilinear interpolants
 * and the Euclidean point in its tile box. */
static void test_patch_enclosure(void **state)
{
    (void)state;
    rng r = {2024};
    int ms[] = {1, 2, 3, 4, 7, 16};
    for (int rational = 0; rational <= 1; rational++)
        for (int mi = 0; mi < 6; mi++)
            for (int trial = 0; trial < 10; trial++) {
                check_patch_enclosure(&r, 3, 3, rational, ms[mi], 600);
                check_patch_enclosure(&r, 5, 6, rational, ms[mi], 600);
            }
    /* mixed and extreme degrees, including degree 1 in one direction */
    int degs[][2] = {{1, 1}, {1, 4}, {4, 1}, {2, 2}, {15, 15}, {10, 8}, {3, 15}};
    for (int i = 0; i < 7; i++)
        for (int trial = 0; trial < 4; trial++)
            check_patch_enclosure(&r, degs[i][0], degs[i][1], trial % 2, 1 + trial * 3, 500);
}

/* The specialised bicubic m = 3 path equals the two-pass construction written with the public
 * univariate function. */
static void test_bicubic_matches_two_pass(void **state)
{
    (void)state;
    rng r = {5};
    for (int trial = 0; trial < 50; trial++) {
        double cpw[64], lo[64], up[64];
        crisp_bezier_patch p;
        random_patch(&r, 3, 3, 1, cpw, &p);
        assert_int_equal(crisp_slefe_patch(&p, 3, lo, up), CRISP_OK);
        for (int c = 0; c < 4; c++) {
            double rl[4][4], ru[4][4];
            for (int i = 0; i < 4; i++)
                assert_int_equal(crisp_slefe_bezier(3, cpw + i * 4 + c, 16, 3, rl[i], ru[i]),
                                 CRISP_OK);
            for (int kv = 0; kv < 4; kv++) {
                double cu[4], cl[4], l1[4], u1[4], l2[4], u2[4];
                for (int i = 0; i < 4; i++) {
                    cu[i] = ru[i][kv];
                    cl[i] = rl[i][kv];
                }
                assert_int_equal(crisp_slefe_bezier(3, cu, 1, 3, l1, u1), CRISP_OK);
                assert_int_equal(crisp_slefe_bezier(3, cl, 1, 3, l2, u2), CRISP_OK);
                for (int ku = 0; ku < 4; ku++) {
                    assert_true(fabs(up[(kv * 4 + ku) * 4 + c] - u1[ku]) <=
                                1e-15 * (1 + fabs(u1[ku])));
                    assert_true(fabs(lo[(kv * 4 + ku) * 4 + c] - l2[ku]) <=
                                1e-15 * (1 + fabs(l2[ku])));
                }
            }
        }
    }
}

/* A camera looking at the origin from distance 3.5..8 in a random direction. */

/* Random patches (polynomial and rational, bicubic and (5, 6)) through random perspective cameras:
 * the projected surface (NDC x, y, z) lies in the NDC box of its tile at dense samples, and w_px
 * is positive and no larger than the screen size of the patch's tile boxes. */
static void test_screen_enclosure(void **state)
{
    (void)state;
    rng r = {77};
    int ms[] = {3, 1, 2, 5, 8};
    for (int trial = 0; trial < 160; trial++) {
        int du = trial % 2 ? 5 : 3, dv = trial % 2 ? 6 : 3, rational = (trial / 2) % 2;
        int m = ms[(trial / 4) % 5];
        double cpw[MAXN], bl[TILES3], bh[TILES3], w_px = -1;
        crisp_bezier_patch p;
        random_patch(&r, du, dv, rational, cpw, &p);
        crisp_slefe_view v;
        random_slefe_view(&r, 3.5, 8.0, (const double[3]){0, 0, 0}, 20, 90, &v);
        /* every control point is in front of the camera, so W > 0 by the hull even at m = 1 */
        assert_int_equal(crisp_slefe_patch_screen(&p, m, &v, bl, bh, &w_px), CRISP_OK);
        assert_true(w_px > 0.0 && isfinite(w_px));
        for (int i = 0; i < 600; i++) {
            long double s, t, h[4], clip[4];
            sample_st(&r, i, 600, &s, &t);
            for (int c = 0; c < 4; c++)
                h[c] = ref_patch(&p, c, s, t);
            for (int k = 0; k < 4; k++) {
                clip[k] = 0;
                for (int c = 0; c < 4; c++)
                    clip[k] += (long double)v.view_proj[c][k] * h[c];
            }
            int ku = (int)(s * m), kv = (int)(t * m);
            if (ku >= m) ku = m - 1;
            if (kv >= m) kv = m - 1;
            for (int c = 0; c < 3; c++) {
                long double e = clip[c] / clip[3];
                int b = (kv * m + ku) * 3 + c;
                if (!(bl[b] <= e && e <= bh[b]))
                    fail_msg("trial %d (%d,%d) m %d tile (%d,%d) ndc %d: %.17g <= %.17Lg <= %.17g",
                             trial, du, dv, m, ku, kv, c, bl[b], e, bh[b]);
            }
        }
    }
}

/* Widths under a camera shrink as m grows (roughly 1/m^2 for bicubics). */
static void test_screen_width_shrinks(void **state)
{
    (void)state;
    rng r = {3};
    for (int trial = 0; trial < 40; trial++) {
        double cpw[64], w3, w6;
        crisp_bezier_patch p;
        random_patch(&r, 3, 3, trial % 2, cpw, &p);
        crisp_slefe_view v;
        random_slefe_view(&r, 3.5, 8.0, (const double[3]){0, 0, 0}, 20, 90, &v);
        assert_int_equal(crisp_slefe_patch_screen(&p, 3, &v, NULL, NULL, &w3), CRISP_OK);
        assert_int_equal(crisp_slefe_patch_screen(&p, 6, &v, NULL, NULL, &w6), CRISP_OK);
        assert_true(w6 < 0.5 * w3);
    }
}

static double patch_width(const crisp_bezier_patch *p, int m)
{
    double lo[GRID4], up[GRID4], w = 0;
    assert_int_equal(crisp_slefe_patch(p, m, lo, up), CRISP_OK);
    for (int g = 0; g < CRISP_SLEFE_GRID(m); g++)
        for (int c = 0; c < 3; c++)
            w = fmax(w, up[g * 4 + c] - lo[g * 4 + c]);
    return w;
}

/* Object space: doubling m shrinks the largest width of random bicubic patches to at most 0.3
 * (m = 2, 4, 8), and of degree (5, 6) patches to at most 0.3 from m = 8 and 0.35 from m = 4: a
 * patch whose second differences excite a single a_j of degree 6 can reach the univariate table
 * ratio 0.322 there (see test_doubling_shrinks in test_slefe.c). */
static void test_patch_doubling_shrinks(void **state)
{
    (void)state;
    rng r = {17};
    double worst3 = 0, worst56 = 0;
    for (int trial = 0; trial < 60; trial++) {
        double cpw[MAXN];
        crisp_bezier_patch p;
        int high = trial % 2;
        random_patch(&r, high ? 5 : 3, high ? 6 : 3, 0, cpw, &p);
        for (int m = high ? 4 : 2; m <= 8; m *= 2) {
            double ratio = patch_width(&p, 2 * m) / patch_width(&p, m);
            double limit = !high || m == 8 ? 0.3 : 0.35;
            if (high)
                worst56 = fmax(worst56, ratio);
            else
                worst3 = fmax(worst3, ratio);
            if (!(ratio <= limit))
                fail_msg("trial %d degree %s m %d -> %d: ratio %g", trial, high ? "(5,6)" : "3", m,
                         2 * m, ratio);
        }
    }
    print_message("worst width ratio under doubling m: bicubic %.3f, (5,6) %.3f\n", worst3,
                  worst56);
}

/* A patch around the eye: W is not positive everywhere, so the caller must split. */
static void test_screen_eye_plane(void **state)
{
    (void)state;
    /* the plane z = 2u - 1 through the eye */
    double cpw[64];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            double *q = cpw + (j * 4 + i) * 4;
            q[0] = i / 3.0;
            q[1] = j / 3.0;
            q[2] = 2 * i / 3.0 - 1;
            q[3] = 1;
        }
    crisp_bezier_patch p = {.du = 3, .dv = 3, .cpw = cpw};
    crisp_slefe_view v = {.width = 640, .height = 480};
    crisp_mat4 view, proj;
    double eye[3] = {0, 0, 0}, target[3] = {0, 0, -1}, upv[3] = {0, 1, 0};
    assert_true(crisp_mat4_lookat(eye, target, upv, view));
    crisp_mat4_perspective(60, 640.0 / 480.0, 0.1, 100, proj);
    crisp_mat4_mul(proj, view, v.view_proj);
    double w;
    assert_int_equal(crisp_slefe_patch_screen(&p, 3, &v, NULL, NULL, &w), CRISP_ERR_NUMERIC);
    assert_non_null(strstr(crisp_error_message(), "eye plane"));
    double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    assert_int_equal(crisp_slefe_boxes_screen_width(&v, 1, lo, hi, 3, &w), CRISP_ERR_NUMERIC);
    /* huge coordinates: an error, not infinities */
    cpw[5] = 1e300;
    v.view_proj[0][0] = 1e100;
    assert_int_equal(crisp_slefe_patch_screen(&p, 3, &v, NULL, NULL, &w), CRISP_ERR_NUMERIC);
}

/* The iPASS measure on a hand-computed case: identity view-projection, so NDC = object x, y. */
static void test_boxes_screen_width(void **state)
{
    (void)state;
    crisp_slefe_view v = {.width = 100, .height = 200};
    crisp_mat4_identity(v.view_proj);
    double lo[6] = {0, 0, 0, 0.1, 0.1, 0.1}, hi[6] = {0.5, 0.25, 0.1, 0.2, 0.2, 0.2};
    double w;
    assert_int_equal(crisp_slefe_boxes_screen_width(&v, 2, lo, hi, 3, &w), CRISP_OK);
    assert_true(fabs(w - 25.0) < 1e-12); /* max(0.5 * 50, 0.25 * 100) */
    assert_int_equal(crisp_slefe_boxes_screen_width(&v, 1, lo + 3, hi + 3, 3, &w), CRISP_OK);
    assert_true(fabs(w - 10.0) < 1e-12);
    v.width = 0;
    assert_int_equal(crisp_slefe_boxes_screen_width(&v, 1, lo, hi, 3, &w), CRISP_ERR_INVALID_ARG);
}

/* Clip-space X, Y, W of a patch point, long double. */
static void clip_point(const crisp_bezier_patch *p, const crisp_slefe_view *v, long double s,
                       long double t, long double *dest)
{
    long double h[4];
    for (int c = 0; c < 4; c++)
        h[c] = ref_patch(p, c, s, t);
    for (int r = 0; r < 3; r++) {
        int k = r == 2 ? 3 : r;
        dest[r] = 0;
        for (int c = 0; c < 4; c++)
            dest[r] += (long double)v->view_proj[c][k] * h[c];
    }
}

/* Largest sampled pixel distance (per axis) between the surface and its tau x tau tessellation,
 * cells cut along the diagonal given by diag (0: 00-11, 1: 10-01): the surface point at (s, t)
 * against the triangle point with the same barycentrics in clip space. */
static double sampled_tess_error(const crisp_bezier_patch *p, const crisp_slefe_view *v, int tau,
                                 int diag, rng *r)
{
    static long double grid[65 * 65][3];
    for (int j = 0; j <= tau; j++)
        for (int i = 0; i <= tau; i++)
            clip_point(p, v, (long double)i / tau, (long double)j / tau, grid[j * (tau + 1) + i]);
    double worst = 0;
    for (int j = 0; j < tau; j++)
        for (int i = 0; i < tau; i++)
            for (int q = 0; q < 6; q++) {
                long double fu = rng_uniform(r, 0, 1), fv = rng_uniform(r, 0, 1);
                if (q == 0) fu = fv = 0.5L;
                long double *g00 = grid[j * (tau + 1) + i], *g10 = grid[j * (tau + 1) + i + 1];
                long double *g01 = grid[(j + 1) * (tau + 1) + i];
                long double *g11 = grid[(j + 1) * (tau + 1) + i + 1];
                long double tri[3], h[3];
                for (int c = 0; c < 3; c++) {
                    if (diag == 0)
                        tri[c] = fv <= fu
                                     ? g00[c] + fu * (g10[c] - g00[c]) + fv * (g11[c] - g10[c])
                                     : g00[c] + fv * (g01[c] - g00[c]) + fu * (g11[c] - g01[c]);
                    else
                        tri[c] = fu + fv <= 1
                                     ? g00[c] + fu * (g10[c] - g00[c]) + fv * (g01[c] - g00[c])
                                     : g11[c] + (1 - fu) * (g01[c] - g11[c]) +
                                           (1 - fv) * (g10[c] - g11[c]);
                }
                clip_point(p, v, (i + fu) / tau, (j + fv) / tau, h);
                long double ex = fabsl(h[0] / h[2] - tri[0] / tri[2]) * 0.5L * v->width;
                long double ey = fabsl(h[1] / h[2] - tri[1] / tri[2]) * 0.5L * v->height;
                worst = fmax(worst, (double)fmaxl(ex, ey));
            }
    return worst;
}

/* crisp_slefe_patch_screen_error bounds the sampled distance between random patches (bicubic,
 * (5, 6), rational too) and their triangles, for tau on both sides of 16 (where it switches to
 * sub-patches) and both diagonals; the level from crisp_slefe_patch_tess_level meets eps. */
static void test_screen_error_bound(void **state)
{
    (void)state;
    rng r = {31};
    double worst_ratio = 0;
    for (int trial = 0; trial < 24; trial++) {
        int du = trial % 2 ? 5 : 3, dv = trial % 2 ? 6 : 3, rational = (trial / 2) % 2;
        double cpw[MAXN];
        crisp_bezier_patch p;
        random_patch(&r, du, dv, rational, cpw, &p);
        crisp_slefe_view v;
        random_slefe_view(&r, 3.5, 8.0, (const double[3]){0, 0, 0}, 20, 90, &v);
        int taus[3] = {rng_int(&r, 1, 16), rng_int(&r, 17, 40), 36};
        for (int k = 0; k < 3; k++) {
            double bound;
            assert_int_equal(crisp_slefe_patch_screen_error(&p, taus[k], &v, &bound), CRISP_OK);
            double e = sampled_tess_error(&p, &v, taus[k], trial % 2, &r);
            if (!(e <= bound))
                fail_msg("trial %d tau %d: sampled %g > bound %g", trial, taus[k], e, bound);
            worst_ratio = fmax(worst_ratio, e / bound);
        }
        int tau;
        assert_int_equal(crisp_slefe_patch_tess_level(&p, &v, 0.5, 64, &tau), CRISP_OK);
        if (tau <= 64) {
            double e = sampled_tess_error(&p, &v, tau, 0, &r);
            if (!(e <= 0.5)) fail_msg("trial %d: level %d leaves %g px", trial, tau, e);
        }
    }
    print_message("largest sampled error / bound: %.3f\n", worst_ratio);
    /* large and prime levels stay cheap (k = ceil(tau / 16) blocks) and the bound keeps falling
     * like 1 / tau^2 */
    double cpw[64], e64, e1021, e2048;
    crisp_bezier_patch p;
    random_patch(&r, 3, 3, 1, cpw, &p);
    crisp_slefe_view v;
    random_slefe_view(&r, 3.5, 8.0, (const double[3]){0, 0, 0}, 20, 90, &v);
    assert_int_equal(crisp_slefe_patch_screen_error(&p, 64, &v, &e64), CRISP_OK);
    assert_int_equal(crisp_slefe_patch_screen_error(&p, 1021, &v, &e1021), CRISP_OK);
    assert_int_equal(crisp_slefe_patch_screen_error(&p, 2048, &v, &e2048), CRISP_OK);
    assert_true(e1021 < e64 * (64.0 / 1021) * (64.0 / 1021) * 4);
    assert_true(e2048 < e1021 * (1021.0 / 2048) * (1021.0 / 2048) * 4);
}

static void test_patch_bad_input(void **state)
{
    (void)state;
    double cpw[64] = {0}, lo[GRID4], up[GRID4];
    crisp_bezier_patch p = {.du = 3, .dv = 3, .cpw = cpw};
    assert_int_equal(crisp_slefe_patch(&p, 0, lo, up), CRISP_ERR_LIMIT);
    assert_int_equal(crisp_slefe_patch(&p, 17, lo, up), CRISP_ERR_LIMIT);
    assert_int_equal(crisp_slefe_patch(NULL, 3, lo, up), CRISP_ERR_INVALID_ARG);
    p.du = 16;
    assert_int_equal(crisp_slefe_patch(&p, 3, lo, up), CRISP_ERR_LIMIT);
    p.du = 3;
    cpw[17] = NAN;
    assert_int_equal(crisp_slefe_patch(&p, 3, lo, up), CRISP_ERR_NUMERIC);
    cpw[17] = 0;
    assert_int_equal(crisp_slefe_patch(&p, 3, lo, up), CRISP_OK);
    /* W = 0 everywhere (all-zero control points): no Euclidean tile boxes */
    p.rational = 1;
    assert_int_equal(crisp_slefe_patch(&p, 3, lo, up), CRISP_OK);
    double bl[27], bh[27];
    assert_int_equal(crisp_slefe_patch_tiles(3, lo, up, bl, bh), CRISP_ERR_NUMERIC);
    crisp_slefe_view v = {.width = 100, .height = 100};
    crisp_mat4_identity(v.view_proj);
    double e;
    int tau;
    p.rational = 0;
    for (int i = 0; i < 16; i++)
        cpw[i * 4 + 3] = 1.0;
    assert_int_equal(crisp_slefe_patch_screen_error(&p, 0, &v, &e), CRISP_ERR_LIMIT);
    assert_int_equal(crisp_slefe_patch_screen_error(&p, 5000, &v, &e), CRISP_ERR_LIMIT);
    assert_int_equal(crisp_slefe_patch_tess_level(&p, &v, 0.0, 64, &tau), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_slefe_patch_tess_level(&p, &v, 0.5, 0, &tau), CRISP_ERR_INVALID_ARG);
    /* a flat patch seen straight on (identity camera): no error at all, level 1 */
    assert_int_equal(crisp_slefe_patch_tess_level(&p, &v, 0.5, 64, &tau), CRISP_OK);
    assert_int_equal(tau, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tables_concurrent_first_use),
        cmocka_unit_test(test_patch_enclosure),
        cmocka_unit_test(test_bicubic_matches_two_pass),
        cmocka_unit_test(test_screen_enclosure),
        cmocka_unit_test(test_screen_width_shrinks),
        cmocka_unit_test(test_patch_doubling_shrinks),
        cmocka_unit_test(test_screen_eye_plane),
        cmocka_unit_test(test_boxes_screen_width),
        cmocka_unit_test(test_screen_error_bound),
        cmocka_unit_test(test_patch_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
