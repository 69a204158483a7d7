/* Unit tests for src/trim: Bernstein products, the exact classifier against analytic shapes, the
 * u-intercept table against the exact parity of its own scan lines (including vertices lying
 * exactly on scan lines), the tessellation deviation bound, the density bound against sampled
 * screen derivatives on random patches and cameras (some crossing the near plane), reuse of
 * buffers across frames, and bad input. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>
#include <stdio.h>
#include <stdlib.h>

#include "trim/trim_internal.h"
#include "trim/trim_test_util.h"

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static double rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}
static double rnd_in(double a, double b)
{
    return a + (b - a) * rnd();
}

static void test_product(void **state)
{
    (void)state;
    for (int trial = 0; trial < 50; trial++) {
        int am = 1 + trial % 3, an = 1 + trial % 4, bm = 1 + trial % 2, bn = trial % 3;
        double a[64], b[64], p[256];
        for (int k = 0; k < (am + 1) * (an + 1); k++)
            a[k] = rnd_in(-1, 1);
        for (int k = 0; k < (bm + 1) * (bn + 1); k++)
            b[k] = rnd_in(-1, 1);
        crisp__trim_product2(a, am, an, b, bm, bn, p);
        for (int q = 0; q < 10; q++) {
            double s = rnd(), t = rnd(), va = 0, vb = 0, vp = 0;
            for (int j = 0; j <= an; j++)
                for (int i = 0; i <= am; i++)
                    va += a[j * (am + 1) + i] * tu_bern(am, i, s) * tu_bern(an, j, t);
            for (int j = 0; j <= bn; j++)
                for (int i = 0; i <= bm; i++)
                    vb += b[j * (bm + 1) + i] * tu_bern(bm, i, s) * tu_bern(bn, j, t);
            for (int j = 0; j <= an + bn; j++)
                for (int i = 0; i <= am + bm; i++)
                    vp +=
                        p[j * (am + bm + 1) + i] * tu_bern(am + bm, i, s) * tu_bern(an + bn, j, t);
            assert_true(fabs(vp - va * vb) < 1e-12);
        }
    }
}

/* Outer ellipse with an inner circular hole: analytic implicit functions. */
static double ell_f(double u, double v)
{
    double r = 0.3, x = u - 0.5, y = v - 0.5;
    double xr = cos(r) * x + sin(r) * y, yr = -sin(r) * x + cos(r) * y;
    return (xr * xr) / (0.4 * 0.4) + (yr * yr) / (0.3 * 0.3) - 1.0;
}
static double hole_f(double u, double v)
{
    return hypot(u - 0.45, v - 0.5) - 0.1;
}

static void test_exact_classifier(void **state)
{
    (void)state;
    crisp_bezier_curve pc[8];
    int n = tu_ellipse(pc, 0.5, 0.5, 0.4, 0.3, 0.3, 1);
    n += tu_ellipse(pc + n, 0.45, 0.5, 0.1, 0.1, 0.0, 0);
    assert_int_equal(crisp_trim_pieces_check(pc, n), CRISP_OK);
    int checked = 0;
    for (int q = 0; q < 20000; q++) {
        double u = rnd_in(-0.1, 1.1), v = rnd_in(-0.1, 1.1);
        double fe = ell_f(u, v), fh = hole_f(u, v);
        if (fabs(fe) < 1e-9 || fabs(fh) < 1e-9) continue;
        int want = fe < 0 && fh > 0;
        assert_int_equal(crisp_trim_exact_classify(pc, n, u, v), want);
        checked++;
    }
    assert_true(checked > 19000);
    /* Points extremely close to the circle: still right (no tolerance of its own). */
    for (int q = 0; q < 2000; q++) {
        double a = rnd_in(0, 2 * M_PI), eps = (q % 2 ? 1 : -1) * 1e-11;
        double u = 0.45 + (0.1 + eps) * cos(a), v = 0.5 + (0.1 + eps) * sin(a);
        assert_int_equal(crisp_trim_exact_classify(pc, n, u, v), eps > 0);
    }
    /* Distance to the hole circle alone. */
    for (int q = 0; q < 200; q++) {
        double u = rnd_in(0, 1), v = rnd_in(0, 1);
        double d = crisp_trim_exact_distance(pc + 4, 4, u, v);
        double want = fabs(hypot(u - 0.45, v - 0.5) - 0.1);
        assert_true(fabs(d - want) <= 1e-8 * want + 1e-11);
    }
}

/* The same expressions as the library, to hit its scan lines bit for bit. */
static double t_nu(double v0, double v1, int n, int i)
{
    return i >= n ? v1 : v0 + (v1 - v0) * ((double)i / n);
}
static double t_scan(double a, double b, uint32_t mu, uint32_t j)
{
    return a + (b - a) * ((j + 0.5) / mu);
}

static void test_table_polygon(void **state)
{
    (void)state;
    const uint32_t mu[4] = {3, 0, 5, 7};
    double s0 = t_scan(t_nu(0, 1, 4, 0), t_nu(0, 1, 4, 1), 3, 1);
    double s2 = t_scan(t_nu(0, 1, 4, 2), t_nu(0, 1, 4, 3), 5, 2);
    double s3 = t_scan(t_nu(0, 1, 4, 3), t_nu(0, 1, 4, 4), 7, 4);
    /* A non-convex polygon with a pass-through vertex, a peak and a valley on scan lines. */
    double poly[] = {0.1, 0.02, 0.5, s0,  0.9,  0.05, 0.95, s2,   0.7, s3,  0.6,
                     s2,  0.5,  s3,  0.4, 0.97, 0.2,  s3,   0.05, s2,  0.3, s0};
    int np = (int)(sizeof poly / sizeof poly[0]) / 2;
    crisp_bezier_curve pc[16];
    int n = tu_polygon(pc, np, poly);
    /* The polyline of degree-1 pieces is the polygon itself. */
    crisp_trim_polyline pl = {0};
    const double rho_u[4] = {1, 1, 1, 1};
    assert_int_equal(crisp_trim_tessellate(&(crisp_trim_tess_desc){.pieces = pc,
                                                                   .piece_count = n,
                                                                   .v0 = 0,
                                                                   .v1 = 1,
                                                                   .strip_count = 4,
                                                                   .mu = mu,
                                                                   .rho_u = rho_u},
                                           &pl),
                     CRISP_OK);
    assert_int_equal(pl.first[n], 2 * n);
    crisp_trim_table t = {0};
    assert_int_equal(
        crisp_trim_table_build(
            &(crisp_trim_table_desc){.polyline = &pl, .v0 = 0, .v1 = 1, .strip_count = 4, .mu = mu},
            &t),
        CRISP_OK);
    assert_int_equal(t.row_count, 15);
    for (uint32_t r = 0; r < t.row_count; r++) {
        uint32_t c = t.row_offset[r + 1] - t.row_offset[r];
        assert_int_equal(c % 2, 0); /* closed loop: even on every scan line */
        for (uint32_t k = t.row_offset[r] + 1; k < t.row_offset[r + 1]; k++)
            assert_true(t.u[k - 1] <= t.u[k]);
    }
    for (int q = 0; q < 20000; q++) {
        double u = rnd_in(-0.1, 1.1), v = rnd_in(-0.05, 1.05);
        int got = crisp_trim_table_test(&t, u, v);
        if (v < 0 || v > 1 || (v >= 0.25 && v < 0.5)) {
            assert_int_equal(got, 0);
            continue;
        }
        int i = v >= 1 ? 3 : (int)floor(v * 4);
        double a = t_nu(0, 1, 4, i), b = t_nu(0, 1, 4, i + 1);
        uint32_t j = (uint32_t)floor((v - a) / (b - a) * mu[i]);
        if (j >= mu[i]) j = mu[i] - 1;
        double vs = t_scan(a, b, mu[i], j);
        assert_int_equal(got, crisp_trim_exact_classify(pc, n, u, vs));
    }
    /* Rows through the special vertices: the pass-through gives 1 crossing there (the polygon
     * still has an even count), peaks and valleys 0 or 2. */
    for (int q = 0; q < 200; q++) {
        double u = rnd_in(0, 1);
        assert_int_equal(crisp_trim_table_test(&t, u, s0), crisp_trim_exact_classify(pc, n, u, s0));
        assert_int_equal(crisp_trim_table_test(&t, u, s2), crisp_trim_exact_classify(pc, n, u, s2));
        assert_int_equal(crisp_trim_table_test(&t, u, s3), crisp_trim_exact_classify(pc, n, u, s3));
    }
    /* A face without loops is inside everywhere in its v-range. */
    crisp_trim_table e = {0};
    assert_int_equal(crisp_trim_table_build(
                         &(crisp_trim_table_desc){
                             .polyline = NULL, .v0 = 0, .v1 = 1, .strip_count = 4, .mu = mu},
                         &e),
                     CRISP_OK);
    assert_int_equal(crisp_trim_table_test(&e, 0.3, 0.3), 1);
    assert_int_equal(crisp_trim_table_test(&e, 0.3, 1.3), 0);
    crisp_trim_table_free(&e);
    crisp_trim_table_free(&t);
    crisp_trim_polyline_free(&pl);
}

/* Rows restricted to part of each strip (the visible v-range): the scan lines sit inside it, and
 * v outside it but inside the strip uses the nearest row. */
static void test_table_row_ranges(void **state)
{
    (void)state;
    crisp_bezier_curve pc[8];
    int n = tu_ellipse(pc, 0.5, 0.5, 0.4, 0.3, 0.3, 1);
    const uint32_t mu[2] = {7, 4};
    const double row_v[4] = {0.1, 0.3, 0.5, 0.55};
    const double rho_u[2] = {100, 100};
    crisp_trim_polyline pl = {0};
    assert_int_equal(crisp_trim_tessellate(&(crisp_trim_tess_desc){.pieces = pc,
                                                                   .piece_count = n,
                                                                   .v0 = 0,
                                                                   .v1 = 1,
                                                                   .strip_count = 2,
                                                                   .mu = mu,
                                                                   .row_v = row_v,
                                                                   .rho_u = rho_u},
                                           &pl),
                     CRISP_OK);
    crisp_trim_table t = {0};
    assert_int_equal(
        crisp_trim_table_build(
            &(crisp_trim_table_desc){
                .polyline = &pl, .v0 = 0, .v1 = 1, .strip_count = 2, .mu = mu, .row_v = row_v},
            &t),
        CRISP_OK);
    crisp_bezier_curve *poly = calloc((size_t)pl.first[pl.piece_count], sizeof *poly);
    assert_non_null(poly);
    int np = 0;
    for (int k = 0; k < pl.piece_count; k++)
        for (int q = pl.first[k]; q + 1 < pl.first[k + 1]; q++, np++)
            tu_line(&poly[np], pl.uv[2 * q], pl.uv[2 * q + 1], pl.uv[2 * q + 2], pl.uv[2 * q + 3]);
    for (int q = 0; q < 5000; q++) {
        double u = rnd_in(0, 1), v = rnd();
        int i = v < 0.5 ? 0 : 1;
        double a = row_v[2 * i], b = row_v[2 * i + 1];
        double fj = floor((v - a) / (b - a) * mu[i]);
        uint32_t j = fj < 0 ? 0 : fj > mu[i] - 1 ? mu[i] - 1 : (uint32_t)fj;
        double vs = t_scan(a, b, mu[i], j);
        /* the table is exact parity of its polyline on the scan line */
        assert_int_equal(crisp_trim_table_test(&t, u, v),
                         crisp_trim_exact_classify(poly, np, u, vs));
    }
    assert_true(crisp_trim_table_bytes(&t) > 0);
    free(poly);
    crisp_trim_table_free(&t);
    crisp_trim_polyline_free(&pl);
}

static void random_piece(crisp_bezier_curve *b, int degree)
{
    memset(b, 0, sizeof *b);
    b->dim = 2;
    b->degree = degree;
    b->rational = 1;
    b->t1 = 1;
    for (int i = 0; i <= degree; i++) {
        double w = rnd_in(0.3, 3.0);
        b->cpw[3 * i] = w * rnd_in(0, 1);
        b->cpw[3 * i + 1] = w * rnd_in(0, 1);
        b->cpw[3 * i + 2] = w;
    }
}

static void test_tessellation_bound(void **state)
{
    (void)state;
    double worst = 0.0;
    for (int trial = 0; trial < 60; trial++) {
        crisp_bezier_curve pc[3];
        for (int k = 0; k < 3; k++)
            random_piece(&pc[k], 2 + (trial + k) % 5);
        uint32_t mu[1] = {(uint32_t)(20 + trial * 37)};
        double rho_u[1] = {rnd_in(10, 3000)};
        crisp_trim_polyline pl = {0};
        assert_int_equal(crisp_trim_tessellate(&(crisp_trim_tess_desc){.pieces = pc,
                                                                       .piece_count = 3,
                                                                       .v0 = -1,
                                                                       .v1 = 2,
                                                                       .strip_count = 1,
                                                                       .mu = mu,
                                                                       .rho_u = rho_u},
                                               &pl),
                         CRISP_OK);
        double tol_v = 0.25 * 3.0 / mu[0], tol_u = 0.25 / rho_u[0];
        for (int k = 0; k < 3; k++) {
            const crisp_bezier_curve *b = &pc[k];
            int ns = pl.first[k + 1] - pl.first[k] - 1;
            for (int s = 0; s < ns; s++) {
                /* Segments need not be uniform in t (sub-pieces over visible strips are finer). */
                double ta = pl.t[pl.first[k] + s], tb = pl.t[pl.first[k] + s + 1];
                assert_true(tb > ta);
                double ha[3] = {0}, hb[3] = {0};
                for (int i = 0; i <= b->degree; i++)
                    for (int c = 0; c < 3; c++) {
                        ha[c] += tu_bern(b->degree, i, ta) * b->cpw[3 * i + c];
                        hb[c] += tu_bern(b->degree, i, tb) * b->cpw[3 * i + c];
                    }
                const double *pa = pl.uv + 2 * (pl.first[k] + s);
                /* The polyline vertices are the curve points. */
                assert_true(fabs(pa[0] - ha[0] / ha[2]) < 1e-12 &&
                            fabs(pa[1] - ha[1] / ha[2]) < 1e-12);
                for (int q = 1; q < 8; q++) {
                    double l = q / 8.0, t = ta + (tb - ta) * l, h[3] = {0};
                    for (int i = 0; i <= b->degree; i++)
                        for (int c = 0; c < 3; c++)
                            h[c] += tu_bern(b->degree, i, t) * b->cpw[3 * i + c];
                    double lh[3];
                    for (int c = 0; c < 3; c++)
                        lh[c] = (1 - l) * ha[c] + l * hb[c];
                    double du = fabs(h[0] / h[2] - lh[0] / lh[2]);
                    double dv = fabs(h[1] / h[2] - lh[1] / lh[2]);
                    assert_true(du <= tol_u * (1 + 1e-9));
                    assert_true(dv <= tol_v * (1 + 1e-9));
                    worst = fmax(worst, fmax(du / tol_u, dv / tol_v));
                }
            }
        }
        crisp_trim_polyline_free(&pl);
    }
    print_message("tessellation: largest sampled deviation / tolerance = %.3f\n", worst);
    assert_true(worst > 0.02); /* not absurdly fine either */
}

static void random_patch(crisp_bezier_patch *p, double *cpw, int du, int dv)
{
    tu_patch_init(p, du, dv, cpw);
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++)
            tu_set(p, i, j, (double)i / du + rnd_in(-0.2, 0.2), (double)j / dv + rnd_in(-0.2, 0.2),
                   rnd_in(-0.3, 0.3), rnd_in(0.5, 2.0));
}

static int cmp_dbl(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void test_density_bound(void **state)
{
    (void)state;
    enum { STRIPS = 8 };
    double ratios[64 * STRIPS];
    int nratio = 0, near_cases = 0;
    crisp_arena *scratch = NULL;
    assert_int_equal(crisp_arena_create(0, &scratch), CRISP_OK);
    for (int trial = 0; trial < 40; trial++) {
        double cpw[4 * 16];
        crisp_bezier_patch p;
        random_patch(&p, cpw, 1 + trial % 3, 1 + (trial / 3) % 3);
        int W = 200 + trial * 7, H = 150 + trial * 3;
        double eye[3], target[3] = {rnd_in(0.3, 0.7), rnd_in(0.3, 0.7), 0};
        double a = rnd_in(0, 2 * M_PI), el = rnd_in(0.1, 1.4);
        /* Every fourth camera sits close, so the surface crosses the near plane. */
        double dist = trial % 4 == 0 ? rnd_in(0.2, 0.5) : rnd_in(1.5, 4);
        eye[0] = target[0] + dist * cos(el) * cos(a);
        eye[1] = target[1] + dist * cos(el) * sin(a);
        eye[2] = target[2] + dist * sin(el);
        if (trial % 4 == 0) {
            /* look along the surface from just above it */
            eye[0] = 0.5 + 0.1 * cos(a);
            eye[1] = 0.5 + 0.1 * sin(a);
            eye[2] = 0.35;
            target[0] = 0.5 - cos(a);
            target[1] = 0.5 - sin(a);
            target[2] = -0.2;
        }
        crisp_mat4 vp;
        tu_camera(eye, target, 50.0, 0.1, 100.0, W, H, vp);
        double rho_v[STRIPS], rho_u[STRIPS], vis_v[2 * STRIPS];
        crisp_arena_reset(scratch);
        crisp_trim_density_stats st;
        assert_int_equal(crisp_trim_scan_density(&(crisp_trim_density_desc){.patches = &p,
                                                                            .patch_count = 1,
                                                                            .view_proj = &vp,
                                                                            .width = W,
                                                                            .height = H,
                                                                            .v0 = 0,
                                                                            .v1 = 1,
                                                                            .strip_count = STRIPS,
                                                                            .scratch = scratch},
                                                 rho_v, rho_u, vis_v, &st),
                         CRISP_OK);
        assert_int_equal(st.unbounded, 0);
        double seen_v[STRIPS] = {0}, seen_u[STRIPS] = {0};
        int behind = 0;
        for (int q = 0; q < 6000; q++) {
            double s = rnd(), t = rnd(), xy[2], ds[2], dt[2];
            int vis;
            double w = tu_screen(&p, vp, W, H, s, t, xy, ds, dt, &vis);
            if (w < 0.1) behind++;
            if (!vis) continue;
            int i = t >= 1 ? STRIPS - 1 : (int)(t * STRIPS);
            double sv = hypot(dt[0], dt[1]), su = hypot(ds[0], ds[1]);
            assert_true(sv <= rho_v[i] * (1 + 1e-9));
            assert_true(t >= vis_v[2 * i] &&
                        t <= vis_v[2 * i + 1]); /* inside the strip's row range */
            assert_true(su <= rho_u[i] * (1 + 1e-9));
            seen_v[i] = fmax(seen_v[i], sv);
            seen_u[i] = fmax(seen_u[i], su);
        }
        if (behind) near_cases++;
        for (int i = 0; i < STRIPS; i++)
            if (seen_v[i] > 0 && nratio < 64 * STRIPS) ratios[nratio++] = rho_v[i] / seen_v[i];
    }
    crisp_arena_destroy(scratch);
    assert_true(near_cases >= 5);
    assert_true(nratio > 40);
    qsort(ratios, (size_t)nratio, sizeof *ratios, cmp_dbl);
    print_message("density: bound / sampled max over %d visible strips: median %.3f, 90%% %.3f, "
                  "max %.3f (%d cameras with the surface behind the near plane)\n",
                  nratio, ratios[nratio / 2], ratios[nratio * 9 / 10], ratios[nratio - 1],
                  near_cases);
    assert_true(ratios[nratio / 2] < 3.0); /* not absurdly loose */
}

/* The 1 px guarantee's paths near the near plane. A pixel's point p = (s, t) is decided by the
 * scan line of its row, q = (s, t_s) with |t - t_s| <= h / 2, and the trim polylines stand within
 * h_min / 4 in v and 1 / (4 rho_u) in u of the true curves (h_min, rho_u: the strictest of the
 * strip and its neighbours). The guarantee needs q within 0.5 px of p on screen, and every point
 * of the deviation box around q within 1.0 px, also when p lies just in front of the near plane
 * and the surface runs towards (or under) the eye, where a step in v can carry the point behind
 * the near plane or the eye. Cameras: a narrow ribbon and curved patches running under an eye
 * 1e-4 to 0.05 above them, near planes nearer and farther than that height. */
static void test_near_plane_paths(void **state)
{
    (void)state;
    enum { STRIPS = 8, W = 320, H = 240 };
    long checked = 0, near_points = 0, worst_at = 0, behind = 0;
    double worst_drop = 0.0;
    double worst_q = 0.0, worst_box = 0.0;
    crisp_arena *scratch = NULL;
    assert_int_equal(crisp_arena_create(0, &scratch), CRISP_OK);
    for (int trial = 0; trial < 96; trial++) {
        double cpw[4 * 25];
        crisp_bezier_patch p;
        double half = trial % 3 == 0 ? 1e-4 : trial % 3 == 1 ? 0.01 : 0.5;
        if (trial % 2 == 0) { /* a ribbon along +y, non-uniform in v, under the eye */
            tu_patch_init(&p, 1, 3, cpw);
            const double ys[4] = {-1.0, -0.2, 0.3, 4.0};
            for (int j = 0; j < 4; j++)
                for (int i = 0; i < 2; i++)
                    tu_set(&p, i, j, i ? half : -half, ys[j], 0.0, j == 1 ? 1.7 : 1.0);
        } else { /* a curved patch stretched along +y */
            random_patch(&p, cpw, 2 + trial % 3, 3);
            for (int k = 0; k < (p.du + 1) * (p.dv + 1); k++) {
                double *h = p.cpw + 4 * k;
                h[0] = (h[0] - 0.5 * h[3]) * 2 * half;
                h[1] = (h[1] * 5.0 - 1.0 * h[3]);
                h[2] *= 0.2;
            }
        }
        double height = trial % 4 == 0   ? 1e-5
                        : trial % 4 == 1 ? 1e-3
                        : trial % 4 == 2 ? 1e-2
                                         : 0.05;
        double s0 = rnd_in(0.2, 0.8), pt[4], ps[4], pv[4];
        tu_patch_eval_h(&p, s0, 0.3, pt, ps, pv);
        double eye[3] = {pt[0] / pt[3], pt[1] / pt[3], pt[2] / pt[3] + height};
        double target[3] = {eye[0] + rnd_in(-0.3, 0.3) * (trial & 4 ? 1 : 0), eye[1] + 3.0,
                            eye[2] - rnd_in(0.0, 0.8) * (trial & 8 ? 1 : 0.01)};
        int zk = (trial / 12) % 4;
        double znear = zk == 0 ? 0.01 : zk == 1 ? 0.1 : zk == 2 ? 0.3 : 1.0;
        crisp_mat4 vp;
        tu_camera(eye, target, rnd_in(50, 100), znear, 50.0, W, H, vp);
        double rho_v[STRIPS], rho_u[STRIPS], vis_v[2 * STRIPS];
        uint32_t mu[STRIPS];
        crisp_arena_reset(scratch);
        assert_int_equal(crisp_trim_scan_density(&(crisp_trim_density_desc){.patches = &p,
                                                                            .patch_count = 1,
                                                                            .view_proj = &vp,
                                                                            .width = W,
                                                                            .height = H,
                                                                            .v0 = 0,
                                                                            .v1 = 1,
                                                                            .strip_count = STRIPS,
                                                                            .scratch = scratch},
                                                 rho_v, rho_u, vis_v, NULL),
                         CRISP_OK);
        int clamped = 0;
        crisp_trim_rows_from_density(rho_v, vis_v, STRIPS, 0, 1, mu, &clamped);
        assert_int_equal(clamped, 0);
        for (int q = 0; q < 4000; q++) {
            double s = rnd(), t = q < 2000 ? rnd() : rnd_in(0.1, 0.5), xy[2], ds[2], dt[2];
            int vis;
            double wp = tu_screen(&p, vp, W, H, s, t, xy, ds, dt, &vis);
            if (!vis) continue;
            if (wp < 2 * znear) near_points++;
            int i = t >= 1 ? STRIPS - 1 : (int)(t * STRIPS);
            assert_true(mu[i] > 0);
            double a = vis_v[2 * i], b = vis_v[2 * i + 1], h = (b - a) / mu[i];
            double fj = floor((t - a) / h);
            uint32_t j = fj < 0 ? 0 : fj > mu[i] - 1 ? mu[i] - 1 : (uint32_t)fj;
            double ts = a + (j + 0.5) * h, xq[2];
            double wq = tu_screen(&p, vp, W, H, s, ts, xq, ds, dt, NULL);
            assert_true(wq > 0.0);
            if (wq < znear) behind++;
            worst_drop = fmax(worst_drop, (wp - wq) / znear);
            double dq = hypot(xq[0] - xy[0], xq[1] - xy[1]);
            assert_true(dq <= 0.5 * (1 + 1e-6));
            if (dq > worst_q) worst_q = dq, worst_at = trial;
            /* the polyline's deviation box around q, with the strictest neighbouring tolerances */
            double hmin = HUGE_VAL, ru = 0.0;
            for (int k = i > 0 ? i - 1 : 0; k <= (i < STRIPS - 1 ? i + 1 : i); k++) {
                if (!mu[k]) continue;
                hmin = fmin(hmin, (vis_v[2 * k + 1] - vis_v[2 * k]) / mu[k]);
                ru = fmax(ru, rho_u[k]);
            }
            for (int c = 0; c < 4; c++) {
                double sc = s + (c & 1 ? 1 : -1) * 0.25 / ru,
                       tc = ts + (c & 2 ? 1 : -1) * 0.25 * hmin;
                if (sc < 0 || sc > 1 || tc < 0 || tc > 1) continue;
                double xc[2];
                assert_true(tu_screen(&p, vp, W, H, sc, tc, xc, ds, dt, NULL) > 0.0);
                double dc = hypot(xc[0] - xy[0], xc[1] - xy[1]);
                assert_true(dc <= 1.0 * (1 + 1e-6));
                worst_box = fmax(worst_box, dc);
            }
            checked++;
        }
    }
    crisp_arena_destroy(scratch);
    print_message("near plane paths: %ld visible points (%ld within 2 znear of the eye, %ld whose "
                  "scan line point is behind the near plane, largest depth drop p-q %.3f znear), "
                  "largest p-q %.3f px (trial %ld), largest p-box %.3f px\n",
                  checked, near_points, behind, worst_drop, worst_q, worst_at, worst_box);
    assert_true(near_points > 1000);
}

/* A face of several patches with a non-unit parameter box: the bound is per unit of the face's
 * (u, v), over strips that do not line up with the patch boundaries. */
static void test_density_multi_patch(void **state)
{
    (void)state;
    enum { STRIPS = 7 };
    for (int trial = 0; trial < 6; trial++) {
        double cpw[4 * 16], parts[4][4 * 16], half[2][4 * 16];
        crisp_bezier_patch p, a, b, q[4];
        random_patch(&p, cpw, 2 + trial % 2, 2);
        p.u0 = 10, p.u1 = 30, p.v0 = -2, p.v1 = 6;
        a.cpw = half[0];
        b.cpw = half[1];
        crisp_bezier_patch_split_u(&p, 0.3, &a, &b);
        for (int k = 0; k < 4; k++)
            q[k].cpw = parts[k];
        crisp_bezier_patch_split_v(&a, 0.6, &q[0], &q[1]);
        crisp_bezier_patch_split_v(&b, 0.6, &q[2], &q[3]);
        crisp_mat4 vp;
        double eye[3] = {0.5 + rnd_in(-1, 1), 0.5 + rnd_in(-1, 1), rnd_in(1.5, 3)};
        tu_camera(eye, (double[3]){0.5, 0.5, 0}, 50, 0.1, 100, 240, 200, vp);
        double rv[STRIPS], ru[STRIPS], vis[2 * STRIPS];
        assert_int_equal(crisp_trim_scan_density(&(crisp_trim_density_desc){.patches = q,
                                                                            .patch_count = 4,
                                                                            .view_proj = &vp,
                                                                            .width = 240,
                                                                            .height = 200,
                                                                            .v0 = -2,
                                                                            .v1 = 6,
                                                                            .strip_count = STRIPS},
                                                 rv, ru, vis, NULL),
                         CRISP_OK);
        int seen = 0;
        for (int k = 0; k < 4000; k++) {
            double s = rnd(), t = rnd(), xy[2], ds[2], dt[2];
            int visible;
            tu_screen(&p, vp, 240, 200, s, t, xy, ds, dt, &visible);
            if (!visible) continue;
            double v = -2 + 8 * t;
            int i = (int)((v + 2) / 8 * STRIPS);
            if (i > STRIPS - 1) i = STRIPS - 1;
            assert_true(hypot(dt[0], dt[1]) / 8 <= rv[i] * (1 + 1e-9));
            assert_true(hypot(ds[0], ds[1]) / 20 <= ru[i] * (1 + 1e-9));
            assert_true(v >= vis[2 * i] && v <= vis[2 * i + 1]);
            seen++;
        }
        assert_true(seen > 100);
    }
}

/* Issue 12: the density bound per block of patches (crisp_trim_density_tree). On random grids of
 * rational and polynomial patches (degrees 1..3, non-unit parameter boxes) seen by random
 * cameras, some with the surface crossing the near plane: every block's box bound is at least the
 * per-patch bound of each of its patches (before refinement) and at least the screen speed
 * sampled on its patches; a block found outside the frustum has no visible sample; and
 * crisp_trim_scan_density walking the blocks bounds every strip's sampled speed. Reports the
 * block bound's tightness against the largest per-patch bound and the largest sampled speed. */
static void test_density_blocks(void **state)
{
    (void)state;
    enum { STRIPS = 9, MAXG = 9, W = 320, H = 240 };
    static double cpw[MAXG * MAXG][4 * 16];
    crisp_bezier_patch pt[MAXG * MAXG];
    static double over_patch[4096], over_sample[4096];
    int n_patch = 0, n_sample = 0, blocks_seen = 0, blocks_culled = 0;
    crisp_trim_density_tree tree = {0};
    for (int trial = 0; trial < 48; trial++) {
        int gu = 1 + trial % MAXG, gv = 1 + (trial * 5 + 3) % MAXG;
        int d = 1 + trial % 3, rational = trial % 3 == 0;
        double amp = rnd_in(0.05, 0.4), fx = rnd_in(1, 6), fy = rnd_in(1, 6);
        for (int iv = 0; iv < gv; iv++)
            for (int iu = 0; iu < gu; iu++) {
                crisp_bezier_patch *p = &pt[iv * gu + iu];
                tu_patch_init(p, d, d, cpw[iv * gu + iu]);
                p->u0 = 10 + 2.0 * iu, p->u1 = p->u0 + 2;
                p->v0 = -3 + 0.5 * iv, p->v1 = p->v0 + 0.5;
                for (int j = 0; j <= d; j++)
                    for (int i = 0; i <= d; i++) {
                        double x = (iu + (double)i / d) / gu, y = (iv + (double)j / d) / gv;
                        tu_set(p, i, j, x + rnd_in(-0.1, 0.1) / gu, y + rnd_in(-0.1, 0.1) / gv,
                               amp * sin(fx * x) * cos(fy * y) + rnd_in(-0.02, 0.02),
                               rational ? rnd_in(0.7, 1.4) : 1.0);
                    }
            }
        double eye[3], target[3] = {rnd_in(0.3, 0.7), rnd_in(0.3, 0.7), 0};
        double a = rnd_in(0, 2 * M_PI), el = rnd_in(0.1, 1.4);
        double dist = trial % 4 == 0 ? rnd_in(0.2, 0.5) : rnd_in(1.0, 4);
        eye[0] = target[0] + dist * cos(el) * cos(a);
        eye[1] = target[1] + dist * cos(el) * sin(a);
        eye[2] = target[2] + dist * sin(el);
        crisp_mat4 vp;
        tu_camera(eye, target, trial % 5 == 0 ? 10.0 : 50.0, 0.1, 100.0, W, H, vp);
        assert_int_equal(crisp_trim_density_tree_build(pt, gu, gv, &tree), CRISP_OK);
        assert_int_equal(tree.root >= 0, gu * gv > 1);
        crisp_trim_density_desc desc = {.patches = pt,
                                        .patch_count = gu * gv,
                                        .view_proj = &vp,
                                        .width = W,
                                        .height = H,
                                        .v0 = -3,
                                        .v1 = -3 + 0.5 * gv,
                                        .strip_count = STRIPS,
                                        .tree = &tree};
        for (size_t bi = 0; bi < tree.count; bi++) {
            const crisp_trim_density_block *b = &tree.blocks[bi];
            double bv = 0, bu = 0, pv_max = 0, sv_max = 0;
            int k = crisp__trim_block_bound(&desc, b, &bv, &bu), any = 0;
            blocks_seen++;
            blocks_culled += k < 0;
            for (uint32_t iv = b->iv0; iv < b->iv0 + b->nv; iv++)
                for (uint32_t iu = b->iu0; iu < b->iu0 + b->nu; iu++) {
                    const crisp_bezier_patch *p = &pt[iv * gu + iu];
                    double pv, pu;
                    int kp = crisp__trim_patch_bound(&desc, p, &pv, &pu);
                    if (k > 0 && kp > 0) {
                        assert_true(bv >= pv * (1 - 1e-9));
                        assert_true(bu >= pu * (1 - 1e-9));
                        pv_max = fmax(pv_max, pv);
                        any = 1;
                    }
                    for (int q = 0; q < 60; q++) {
                        double s = rnd(), t = rnd(), xy[2], ds[2], dt[2];
                        int vis;
                        tu_screen(p, vp, W, H, s, t, xy, ds, dt, &vis);
                        if (!vis) continue;
                        assert_true(k >= 0); /* a culled block shows nothing */
                        if (k == 0) continue;
                        double sv = hypot(dt[0], dt[1]) / (p->v1 - p->v0);
                        double su = hypot(ds[0], ds[1]) / (p->u1 - p->u0);
                        assert_true(sv <= bv * (1 + 1e-9));
                        assert_true(su <= bu * (1 + 1e-9));
                        sv_max = fmax(sv_max, sv);
                    }
                }
            if (any && pv_max > 0 && n_patch < 4096) over_patch[n_patch++] = bv / pv_max;
            if (sv_max > 0 && n_sample < 4096) over_sample[n_sample++] = bv / sv_max;
        }
        /* The walk over the blocks bounds every strip. */
        double rv[STRIPS], ru[STRIPS], vis[2 * STRIPS];
        assert_int_equal(crisp_trim_scan_density(&desc, rv, ru, vis, NULL), CRISP_OK);
        for (int q = 0; q < 3000; q++) {
            int iu = (int)(rnd() * gu), iv = (int)(rnd() * gv);
            iu = iu < gu ? iu : gu - 1, iv = iv < gv ? iv : gv - 1;
            const crisp_bezier_patch *p = &pt[iv * gu + iu];
            double s = rnd(), t = rnd(), xy[2], ds[2], dt[2];
            int visible;
            tu_screen(p, vp, W, H, s, t, xy, ds, dt, &visible);
            if (!visible) continue;
            double v = p->v0 + t * (p->v1 - p->v0);
            int i = (int)((v - desc.v0) / (desc.v1 - desc.v0) * STRIPS);
            if (i > STRIPS - 1) i = STRIPS - 1;
            assert_true(hypot(dt[0], dt[1]) / (p->v1 - p->v0) <= rv[i] * (1 + 1e-9));
            assert_true(hypot(ds[0], ds[1]) / (p->u1 - p->u0) <= ru[i] * (1 + 1e-9));
            assert_true(v >= vis[2 * i] && v <= vis[2 * i + 1]);
        }
    }
    crisp_trim_density_tree_free(&tree);
    assert_true(n_patch > 100 && n_sample > 100 && blocks_culled > 0);
    qsort(over_patch, (size_t)n_patch, sizeof *over_patch, cmp_dbl);
    qsort(over_sample, (size_t)n_sample, sizeof *over_sample, cmp_dbl);
    print_message("density blocks: %d blocks (%d culled); block bound / largest per-patch bound: "
                  "median %.2f, 90%% %.2f, max %.2f (%d); / largest sampled speed: median %.2f, "
                  "90%% %.2f, max %.2f (%d)\n",
                  blocks_seen, blocks_culled, over_patch[n_patch / 2], over_patch[n_patch * 9 / 10],
                  over_patch[n_patch - 1], n_patch, over_sample[n_sample / 2],
                  over_sample[n_sample * 9 / 10], over_sample[n_sample - 1], n_sample);
    assert_true(over_patch[n_patch / 2] < 4.0); /* not absurdly loose */
}

static void test_plan_reuses_buffers(void **state)
{
    (void)state;
    double cpw[64];
    crisp_bezier_patch p;
    tu_patch_kind(&p, 2, cpw);
    crisp_bezier_curve pc[8];
    int n = tu_ellipse(pc, 1.0, 1.0, 0.6, 0.4, 0.2, 1);
    crisp_mat4 vp;
    tu_camera((double[3]){1, -1.5, 2}, (double[3]){1, 1, 0}, 45, 0.1, 50, 128, 96, vp);
    crisp_trim_plan plan = {0};
    crisp_trim_plan_desc d = {.patches = &p,
                              .patch_count = 1,
                              .pieces = pc,
                              .piece_count = n,
                              .view_proj = &vp,
                              .width = 128,
                              .height = 96,
                              .v0 = 0,
                              .v1 = 1,
                              .strip_count = 8};
    /* tu_ellipse works in the surface's image coordinates; scale into the [0,1] domain. */
    for (int k = 0; k < n; k++)
        for (int i = 0; i <= pc[k].degree; i++) {
            pc[k].cpw[3 * i] *= 0.5;
            pc[k].cpw[3 * i + 1] *= 0.5;
        }
    assert_int_equal(crisp_trim_plan_face(&d, &plan), CRISP_OK);
    void *a = plan.rho_v, *b = plan.table.u, *c = plan.polyline.uv, *e = plan.table.row_offset;
    size_t res = crisp_arena_reserved(plan.scratch);
    size_t bytes = crisp_trim_table_bytes(&plan.table);
    assert_true(plan.table.row_count > 0);
    assert_int_equal(crisp_trim_plan_face(&d, &plan), CRISP_OK);
    assert_ptr_equal(a, plan.rho_v);
    assert_ptr_equal(b, plan.table.u);
    assert_ptr_equal(c, plan.polyline.uv);
    assert_ptr_equal(e, plan.table.row_offset);
    assert_int_equal(res, crisp_arena_reserved(plan.scratch));
    assert_int_equal(bytes, crisp_trim_table_bytes(&plan.table));
    crisp_trim_plan_free(&plan);
}

/* ---- chains (crisp_trim_polyline_chains) ------------------------------------------------------
 */

/* Parity of the crossings of (u, v)'s scan line strictly left of u (the table's half-open rule),
 * over every segment of the polyline. */
static int polyline_parity(const crisp_trim_polyline *pl, double u, double v)
{
    int odd = 0;
    for (int k = 0; k < pl->piece_count; k++)
        for (int q = pl->first[k]; q + 1 < pl->first[k + 1]; q++) {
            const double *a = pl->uv + 2 * q, *b = a + 2;
            if (!(fmin(a[1], b[1]) < v && v <= fmax(a[1], b[1]))) continue;
            double uc = a[0] + (v - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            odd ^= uc < u;
        }
    return odd;
}

/* min over the segment a-b of max(|du| / tu, |dv| / tv) from (u, v): convex along the segment,
 * so a ternary search finds it. */
static double box_dist_seg(const double *a, const double *b, double u, double v, double tu,
                           double tv)
{
    double lo = 0, hi = 1;
    for (int it = 0; it < 100; it++) {
        double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
        double f1 = fmax(fabs(a[0] + m1 * (b[0] - a[0]) - u) / tu,
                         fabs(a[1] + m1 * (b[1] - a[1]) - v) / tv);
        double f2 = fmax(fabs(a[0] + m2 * (b[0] - a[0]) - u) / tu,
                         fabs(a[1] + m2 * (b[1] - a[1]) - v) / tv);
        if (f1 < f2)
            hi = m2;
        else
            lo = m1;
    }
    double t = 0.5 * (lo + hi);
    return fmax(fabs(a[0] + t * (b[0] - a[0]) - u) / tu, fabs(a[1] + t * (b[1] - a[1]) - v) / tv);
}

static double box_dist(const crisp_trim_polyline *pl, double u, double v, double tu, double tv)
{
    double best = HUGE_VAL;
    for (int k = 0; k < pl->piece_count; k++)
        for (int q = pl->first[k]; q < pl->first[k + 1]; q++) {
            const double *a = pl->uv + 2 * q;
            const double *b = q + 1 < pl->first[k + 1] ? a + 2 : a;
            best = fmin(best, box_dist_seg(a, b, u, v, tu, tv));
        }
    return best;
}

/* The loops test_polyline_chains and test_trim_lod chain: a polygon of 30 to 200 points around a
 * random centre (radius jittered by the fraction jitter), an ellipse on odd trials and a cubic
 * graph on every third; pc holds up to 260 pieces. Returns the pieces written. */
static int random_loops(int trial, double jitter, crisp_bezier_curve *pc)
{
    int n = 0, nv = 30 + (int)(rnd() * 170);
    double poly[2 * 200];
    double cu = rnd_in(0.3, 0.7), cv = rnd_in(0.3, 0.7), r0 = rnd_in(0.1, 0.25);
    for (int i = 0; i < nv; i++) {
        double a = 2 * M_PI * i / nv, r = r0 * (1 + jitter * rnd_in(-1, 1));
        poly[2 * i] = cu + r * cos(a);
        poly[2 * i + 1] = cv + 0.7 * r * sin(a);
    }
    n += tu_polygon(pc + n, nv, poly);
    if (trial % 2)
        n += tu_ellipse(pc + n, rnd_in(0.4, 0.6), rnd_in(0.4, 0.6), 0.45, 0.3, rnd_in(0, 3), 1);
    if (trial % 3 == 0) {
        double g[4] = {0.9, rnd_in(0.8, 1.2), rnd_in(0.6, 1.0), 0.95};
        n += tu_cubic_graph(pc + n, 0.05, 0.95, g, 0.02);
    }
    return n;
}

/* Random loops (a wobbly polygon of 30..200 short lines, as trim loops of imported faces a few
 * pixels across have; an ellipse of rational quadratics; a cubic graph), tessellated finely, then
 * joined into chains with random tolerances: (u, v) points that the chains classify otherwise than
 * the pieces' polyline lie within the tolerances of that polyline (per coordinate), every point of
 * the old polyline lies within them of the chains, the chains' ends are old points, and closed
 * loops stay closed. The tolerances are met, not wasted: the largest deviation found is more than
 * half of them, and the polygons lose most of their points. */
static void test_polyline_chains(void **state)
{
    (void)state;
    double worst_flip = 0, worst_point = 0;
    long flips = 0, samples = 0, before = 0, after = 0;
    for (int trial = 0; trial < 40; trial++) {
        crisp_bezier_curve pc[260];
        int n = random_loops(trial, 0.1, pc);
        uint32_t mu[1] = {4000};
        double rho_u[1] = {4000};
        crisp_trim_polyline pl = {0}, old = {0};
        assert_int_equal(crisp_trim_tessellate(&(crisp_trim_tess_desc){.pieces = pc,
                                                                       .piece_count = n,
                                                                       .v0 = -0.5,
                                                                       .v1 = 1.5,
                                                                       .strip_count = 1,
                                                                       .mu = mu,
                                                                       .rho_u = rho_u},
                                               &pl),
                         CRISP_OK);
        int npts = pl.first[n];
        old.piece_count = n;
        old.first = malloc((size_t)(n + 1) * sizeof *old.first);
        old.uv = malloc(2 * (size_t)npts * sizeof *old.uv);
        assert_non_null(old.first);
        assert_non_null(old.uv);
        memcpy(old.first, pl.first, (size_t)(n + 1) * sizeof *old.first);
        memcpy(old.uv, pl.uv, 2 * (size_t)npts * sizeof *old.uv);
        double tu = pow(10, rnd_in(-3.5, -1.5)), tv = pow(10, rnd_in(-3.5, -1.5));
        if (trial == 5) tu = HUGE_VAL; /* no limit in u */
        assert_int_equal(crisp_trim_polyline_chains(&pl, tu, tv), CRISP_OK);
        double stu = isfinite(tu) ? tu : 1e300;
        /* Chains: at most one per piece, each from an old point to an old point; one loop each
         * here, closed as the loops are. */
        assert_true(pl.piece_count >= 1 && pl.piece_count <= n);
        int loops = 1 + (trial % 2) + (trial % 3 == 0);
        assert_int_equal(pl.piece_count, loops);
        for (int c = 0; c < pl.piece_count; c++) {
            const double *a = pl.uv + 2 * pl.first[c], *b = pl.uv + 2 * (pl.first[c + 1] - 1);
            assert_true(pl.first[c + 1] - pl.first[c] >= 2);
            assert_true(a[0] == b[0] && a[1] == b[1]);
        }
        for (int q = 0; q < pl.first[pl.piece_count]; q++) {
            int found = 0;
            for (int o = 0; o < npts && !found; o++)
                found = pl.uv[2 * q] == old.uv[2 * o] && pl.uv[2 * q + 1] == old.uv[2 * o + 1];
            assert_true(found);
        }
        before += npts;
        after += pl.first[pl.piece_count];
        /* Every old point within the tolerances of the chains. */
        for (int o = 0; o < npts; o++) {
            double d = box_dist(&pl, old.uv[2 * o], old.uv[2 * o + 1], stu, tv);
            assert_true(d <= 1 + 1e-9);
            worst_point = fmax(worst_point, d);
        }
        /* Points near the chords (where they leave the old polyline), classified both ways. */
        for (int k = 0; k < 3000; k++) {
            int q = (int)(rnd() * (pl.first[pl.piece_count] - 1));
            const double *a = pl.uv + 2 * q;
            double l = rnd(), u = a[0] + l * (a[2] - a[0]), v = a[1] + l * (a[3] - a[1]);
            u += rnd_in(-2, 2) * fmin(stu, 0.05);
            v += rnd_in(-2, 2) * tv;
            samples++;
            if (polyline_parity(&pl, u, v) == polyline_parity(&old, u, v)) continue;
            flips++;
            double d = box_dist(&old, u, v, stu, tv);
            if (d > 1 + 1e-9)
                print_message("trial %d: (%.9g, %.9g) flips at %.6f tolerances from the old "
                              "polyline\n",
                              trial, u, v, d);
            assert_true(d <= 1 + 1e-9);
            worst_flip = fmax(worst_flip, d);
        }
        free(old.first);
        free(old.uv);
        crisp_trim_polyline_free(&pl);
    }
    print_message(
        "chains: %ld -> %ld points; %ld of %ld samples classified otherwise, at most "
        "%.3f tolerances from the old polyline; old points at most %.3f from the chains\n",
        before, after, flips, samples, worst_flip, worst_point);
    assert_true(after < before / 2);
    assert_true(flips > 100);
    assert_true(worst_flip > 0.5 && worst_point > 0.5);
}

/* crisp_trim_lod_build: on random loops (as test_polyline_chains builds them, the polygon here
 * of 30..200 short lines with wider wobble), every level classifies points like the true curves
 * (crisp_trim_exact_classify) except within its tolerances of them (measured against a dense
 * polyline of the curves, 1% of the finest level's tolerances off at most), the levels halve, and
 * the coarsest has few points. */
static void test_trim_lod(void **state)
{
    (void)state;
    double worst = 0;
    long flips = 0, pts0 = 0, pieces = 0;
    for (int trial = 0; trial < 8; trial++) {
        crisp_bezier_curve pc[260];
        int n = random_loops(trial, 0.3, pc);
        crisp_trim_lod lod = {0};
        assert_int_equal(crisp_trim_lod_build(pc, n, &lod), CRISP_OK);
        assert_int_equal(lod.levels, CRISP_TRIM_LOD_LEVELS);
        pieces += n;
        pts0 += lod.level[0].first[lod.level[0].piece_count];
        /* The true curves, densely (1% of the finest level's tolerances). */
        const int last = CRISP_TRIM_LOD_LEVELS - 1;
        uint32_t mu[1] = {(uint32_t)ceil((lod.box[3] - lod.box[2]) / (4e-2 * lod.tol_v[last]))};
        double rho_u[1] = {0.25 / (1e-2 * lod.tol_u[last])};
        crisp_trim_polyline dense = {0};
        assert_int_equal(crisp_trim_tessellate(&(crisp_trim_tess_desc){.pieces = pc,
                                                                       .piece_count = n,
                                                                       .v0 = lod.box[2],
                                                                       .v1 = lod.box[3],
                                                                       .strip_count = 1,
                                                                       .mu = mu,
                                                                       .rho_u = rho_u},
                                               &dense),
                         CRISP_OK);
        for (int k = 0; k < lod.levels; k++) {
            if (k) {
                assert_true(fabs(lod.tol_u[k] - 0.5 * lod.tol_u[k - 1]) <= 1e-15);
                assert_true(fabs(lod.tol_v[k] - 0.5 * lod.tol_v[k - 1]) <= 1e-15);
            }
            const crisp_trim_polyline *pl = &lod.level[k];
            double tu = lod.tol_u[k], tv = lod.tol_v[k];
            int np = pl->first[pl->piece_count];
            for (int q = 0; q < 400; q++) {
                int i = (int)(rnd() * (np - 1));
                const double *a = pl->uv + 2 * i;
                double l = rnd(), u = a[0] + l * (a[2] - a[0]), v = a[1] + l * (a[3] - a[1]);
                u += rnd_in(-1.5, 1.5) * tu;
                v += rnd_in(-1.5, 1.5) * tv;
                if (polyline_parity(pl, u, v) == crisp_trim_exact_classify(pc, n, u, v)) continue;
                flips++;
                double d = box_dist(&dense, u, v, tu, tv);
                worst = fmax(worst, d);
                assert_true(d <= 1 + 0.02 * lod.tol_u[last] / tu);
            }
        }
        crisp_trim_polyline_free(&dense);
        crisp_trim_lod_free(&lod);
    }
    print_message("trim levels: %ld pieces -> %ld points at level 0; %ld points classified "
                  "otherwise than the curves, at most %.3f tolerances from them\n",
                  pieces, pts0, flips, worst);
    assert_true(pts0 < pieces * 2 / 3);
    assert_true(flips > 100 && worst > 0.25);
}

static void test_bad_input(void **state)
{
    (void)state;
    crisp_bezier_curve pc[3];
    tu_line(&pc[0], 0, 0, 1, 0);
    tu_line(&pc[1], 1, 0, 0, 1);
    pc[1].cpw[5] = 0.0; /* zero weight */
    assert_int_equal(crisp_trim_pieces_check(pc, 2), CRISP_ERR_INVALID_ARG);
    assert_non_null(strstr(crisp_error_message(), "trim piece 1"));
    pc[1].cpw[5] = 1.0;
    pc[1].cpw[0] = NAN;
    assert_int_equal(crisp_trim_pieces_check(pc, 2), CRISP_ERR_INVALID_ARG);
    pc[1].cpw[0] = 1.0;
    pc[1].degree = 16;
    assert_int_equal(crisp_trim_pieces_check(pc, 2), CRISP_ERR_INVALID_ARG);
    assert_non_null(strstr(crisp_error_message(), "degree 16"));
    double rv[1], ru[1];
    crisp_mat4 vp;
    crisp_mat4_identity(vp);
    assert_int_equal(crisp_trim_scan_density(
                         &(crisp_trim_density_desc){
                             .view_proj = &vp, .width = 10, .height = 10, .v0 = 0, .v1 = 1},
                         rv, ru, NULL, NULL),
                     CRISP_ERR_INVALID_ARG);
    uint32_t mu[2] = {CRISP_TRIM_MAX_ROWS, 5};
    crisp_trim_table t = {0};
    assert_int_equal(
        crisp_trim_table_build(
            &(crisp_trim_table_desc){.v0 = 0, .v1 = 1, .strip_count = 2, .mu = mu}, &t),
        CRISP_ERR_LIMIT);
    crisp_trim_table_free(&t);
    /* Huge densities are clamped to the row limit, never overflow. */
    double rho[3] = {HUGE_VAL, 1e30, 0.0};
    uint32_t m3[3];
    int clamped = 0;
    crisp_trim_rows_from_density(rho, NULL, 3, 0, 1, m3, &clamped);
    assert_int_equal(clamped, 1);
    assert_true((uint64_t)m3[0] + m3[1] <= CRISP_TRIM_MAX_ROWS);
    assert_int_equal(m3[2], 0);
}

static int cmp_u(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Every row of crisp_trim_table_build's table against the crossings found row by row, segment by
 * segment (the scan line in (min v, max v] of a segment, u on the segment clamped to its u-range),
 * bit for bit: random closed polylines with points on scan lines and level segments, strips
 * with 0..40 rows, row ranges part of a strip, one table reused across builds (the counting
 * pass's differences, the fill's clamp skipped strictly inside, issue 12 session 21). */
static void test_table_rows_brute(void **state)
{
    (void)state;
    crisp_trim_table t = {0};
    int rows_checked = 0, crossings = 0;
    for (int trial = 0; trial < 400; trial++) {
        int strips = 1 + (int)(rnd() * 8), npts = 3 + (int)(rnd() * 40);
        double v0 = rnd_in(-1, 0.2), v1 = v0 + rnd_in(0.2, 2);
        uint32_t mu[8];
        double row_v[16];
        for (int i = 0; i < strips; i++) {
            mu[i] = rnd() < 0.1 ? 0 : (uint32_t)(rnd() * 40);
            double a = v0 + (v1 - v0) * ((double)i / strips),
                   b = v0 + (v1 - v0) * ((double)(i + 1) / strips);
            double x = rnd_in(a, b), y = rnd_in(a, b);
            row_v[2 * i] = x < y ? x : y, row_v[2 * i + 1] = x < y ? y : x;
        }
        int use_row_v = trial % 3 == 0;
        /* the table's scan lines, to put polyline points on them */
        double uv[2 * 48];
        int first[2] = {0, npts + 1};
        for (int k = 0; k < npts; k++) {
            uv[2 * k] = rnd_in(-0.5, 1.5);
            uv[2 * k + 1] = rnd_in(v0 - 0.2, v1 + 0.2);
            if (k && rnd() < 0.15) uv[2 * k + 1] = uv[2 * k - 1]; /* level */
        }
        uv[2 * npts] = uv[0], uv[2 * npts + 1] = uv[1];
        crisp_trim_polyline pl = {.piece_count = 1, .first = first, .uv = uv};
        crisp_trim_table_desc d = {.polyline = &pl,
                                   .v0 = v0,
                                   .v1 = v1,
                                   .strip_count = strips,
                                   .mu = mu,
                                   .row_v = use_row_v ? row_v : NULL};
        assert_int_equal(crisp_trim_table_build(&d, &t), CRISP_OK);
        /* points on scan lines: rebuild with some points moved onto the first build's lines */
        for (int k = 0; k < npts && t.row_count; k++)
            if (rnd() < 0.3) {
                uint32_t r = (uint32_t)(rnd() * t.row_count);
                int i = 0;
                while (t.row_base[i + 1] <= r)
                    i++;
                uint32_t j = r - t.row_base[i], m = t.row_base[i + 1] - t.row_base[i];
                double a = t.row_v[2 * i], b = t.row_v[2 * i + 1];
                uv[2 * k + 1] = a + (b - a) * ((j + 0.5) / m);
            }
        uv[2 * npts] = uv[0], uv[2 * npts + 1] = uv[1];
        assert_int_equal(crisp_trim_table_build(&d, &t), CRISP_OK);
        for (int i = 0; i < strips; i++)
            for (uint32_t j = 0; j < mu[i]; j++) {
                uint32_t r = t.row_base[i] + j;
                double a = t.row_v[2 * i], b = t.row_v[2 * i + 1];
                double v = a + (b - a) * ((j + 0.5) / mu[i]), want[64];
                int n = 0;
                for (int k = 0; k < npts; k++) {
                    double ua = uv[2 * k], va = uv[2 * k + 1], ub = uv[2 * k + 2],
                           vb = uv[2 * k + 3];
                    double lo = va < vb ? va : vb, hi = va < vb ? vb : va;
                    if (va == vb || !(v > lo && v <= hi)) continue;
                    double u = ua + (v - va) * ((ub - ua) / (vb - va));
                    want[n++] = fmin(fmax(u, fmin(ua, ub)), fmax(ua, ub));
                }
                qsort(want, (size_t)n, sizeof *want, cmp_u);
                uint32_t got = t.row_offset[r + 1] - t.row_offset[r];
                if (got != (uint32_t)n || memcmp(want, t.u + t.row_offset[r], n * sizeof *want)) {
                    printf("trial %d strip %d row %u: %u crossings, want %d\n", trial, i, j, got,
                           n);
                    fail();
                }
                rows_checked++;
                crossings += n;
            }
    }
    crisp_trim_table_free(&t);
    printf("table rows: %d rows, %d crossings equal\n", rows_checked, crossings);
    assert_true(crossings > 10000);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_product),
        cmocka_unit_test(test_exact_classifier),
        cmocka_unit_test(test_table_polygon),
        cmocka_unit_test(test_table_row_ranges),
        cmocka_unit_test(test_tessellation_bound),
        cmocka_unit_test(test_polyline_chains),
        cmocka_unit_test(test_trim_lod),
        cmocka_unit_test(test_density_bound),
        cmocka_unit_test(test_density_multi_patch),
        cmocka_unit_test(test_density_blocks),
        cmocka_unit_test(test_near_plane_paths),
        cmocka_unit_test(test_plan_reuses_buffers),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_table_rows_brute),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
