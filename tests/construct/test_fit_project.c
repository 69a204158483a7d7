/* Tests for curve fitting (src/nurbs/fit.c) and point inversion / curve projection onto surfaces
 * (src/nurbs/project.c): fits stay within tolerance on hard functions, the span bound is an
 * error, closest points recover the (u, v) of random surface points (rational, near a pole, on a
 * seam), projected curves stay within tolerance in 3D and are continuous across seams. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "crisp/construct.h"
#include "construct/test_util.h"

/* ---- fitting ----------------------------------------------------------------------------------
 */

static void fn_spiral(void *ctx, double t, double *d)
{
    (void)ctx;
    d[0] = cos(50 * t) * (1 + t);
    d[1] = sin(50 * t) * (1 + t);
}

/* A hyperbola-like corner: curvature 1/eps at t = 0 (near-cusp). */
static void fn_corner(void *ctx, double t, double *d)
{
    double eps = *(const double *)ctx;
    d[0] = t;
    d[1] = sqrt(t * t + eps * eps);
    d[2] = 0.3 * t * t;
}

/* A genuine cusp of the function: sqrt(|t|) has unbounded derivative at 0. */
static void fn_sqrt(void *ctx, double t, double *d)
{
    (void)ctx;
    d[0] = t;
    d[1] = sqrt(fabs(t));
}

static double max_fit_error(const crisp_curve *c, int dim, crisp_curve_fn f, void *ctx, double t0,
                            double t1, int n)
{
    double worst = 0;
    for (int i = 0; i <= n; i++) {
        double t = t0 + (t1 - t0) * i / n, a[3], b[3], e = 0;
        crisp_curve_eval(c, t, a);
        f(ctx, t, b);
        for (int k = 0; k < dim; k++)
            e += (a[k] - b[k]) * (a[k] - b[k]);
        if (sqrt(e) > worst) worst = sqrt(e);
    }
    return worst;
}

static void check_fit(int dim, crisp_curve_fn f, void *ctx, double t0, double t1, double tol)
{
    crisp_curve *c;
    assert_int_equal(crisp_fit_curve(dim, f, ctx, t0, t1, tol, 100000, &c), CRISP_OK);
    assert_int_equal(c->degree, 3);
    assert_int_equal(c->rational, 0);
    double a, b, p[3], q[3];
    crisp_curve_domain(c, &a, &b);
    assert_true(a == t0 && b == t1);
    /* Ends interpolated exactly. */
    crisp_curve_eval(c, t0, p);
    f(ctx, t0, q);
    for (int k = 0; k < dim; k++)
        assert_true(p[k] == q[k]);
    crisp_curve_eval(c, t1, p);
    f(ctx, t1, q);
    for (int k = 0; k < dim; k++)
        assert_true(p[k] == q[k]);
    /* Within tol on a dense sample unrelated to the fitter's own check points (a little slack:
     * the fitter samples each span at twelfths, not everywhere). */
    double e = max_fit_error(c, dim, f, ctx, t0, t1, 20011);
    assert_true(e <= tol);
    crisp_curve_destroy(c);
}

static void test_fit_hard_functions(void **state)
{
    (void)state;
    check_fit(2, fn_spiral, NULL, 0, 1, 1e-6);
    check_fit(2, fn_spiral, NULL, -0.3, 0.7, 1e-9);
    double eps = 1e-4;
    check_fit(3, fn_corner, &eps, -1, 1, 1e-7);
    eps = 1e-8;
    check_fit(3, fn_corner, &eps, -1, 1, 1e-6);
    check_fit(2, fn_sqrt, NULL, -1, 1, 1e-5);
}

static void test_fit_span_bound(void **state)
{
    (void)state;
    crisp_curve *c = NULL;
    crisp_error_clear();
    assert_int_equal(crisp_fit_curve(2, fn_spiral, NULL, 0, 1, 1e-9, 10, &c), CRISP_ERR_LIMIT);
    assert_null(c);
    assert_non_null(strstr(crisp_error_message(), "max_spans"));
    /* The same fit with room succeeds, using more than 10 spans. */
    assert_int_equal(crisp_fit_curve(2, fn_spiral, NULL, 0, 1, 1e-9, 100000, &c), CRISP_OK);
    assert_true(c->count > 3 * 10 + 1);
    crisp_curve_destroy(c);
    c = NULL;
    assert_int_equal(crisp_fit_curve(2, fn_spiral, NULL, 1, 1, 1e-6, 10, &c),
                     CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_fit_curve(2, fn_spiral, NULL, 0, 1, 0, 10, &c), CRISP_ERR_INVALID_ARG);
    assert_null(c);
}

static void fn_nan(void *ctx, double t, double *d)
{
    (void)ctx;
    d[0] = t;
    d[1] = t > 0.5 ? NAN : t;
}

static void test_fit_bad_function(void **state)
{
    (void)state;
    crisp_curve *c = NULL;
    assert_int_equal(crisp_fit_curve(2, fn_nan, NULL, 0, 1, 1e-6, 1000, &c), CRISP_ERR_NUMERIC);
    assert_null(c);
}

/* ---- point inversion --------------------------------------------------------------------------
 */

/* A random non-rational or rational height-field-like surface (so points have one preimage). */
static crisp_surface *random_surface(int du, int dv, int nu, int nv, int rational)
{
    double ku[40], kv[40], pts[3 * 400], w[400];
    for (int i = 0; i <= du; i++) {
        ku[i] = 0;
        ku[nu + i] = 1;
    }
    for (int i = du + 1; i < nu; i++)
        ku[i] = (i - du + rnd(-0.3, 0.3)) / (nu - du);
    for (int i = 0; i <= dv; i++) {
        kv[i] = -1;
        kv[nv + i] = 2;
    }
    for (int i = dv + 1; i < nv; i++)
        kv[i] = -1 + 3 * (i - dv + rnd(-0.3, 0.3)) / (nv - dv);
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            double *p = pts + 3 * (j * nu + i);
            p[0] = 4.0 * i / (nu - 1) + rnd(-0.2, 0.2);
            p[1] = 3.0 * j / (nv - 1) + rnd(-0.2, 0.2);
            p[2] = rnd(-1, 1);
            w[j * nu + i] = rational ? rnd(0.5, 2) : 1;
        }
    crisp_surface *s = NULL;
    assert_int_equal(crisp_surface_create(du, dv, nu, nv, ku, kv, pts, rational ? w : NULL, &s),
                     CRISP_OK);
    return s;
}

static double dist3(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}

static void test_closest_point_random_surfaces(void **state)
{
    (void)state;
    for (int it = 0; it < 8; it++) {
        crisp_surface *s = random_surface(1 + it % 4, 1 + (it / 2) % 3, 6, 5, it % 2);
        for (int k = 0; k < 100; k++) {
            double u = rnd(0, 1), v = rnd(-1, 2), p[3], uv[2], dist, q[3];
            crisp_surface_eval(s, u, v, p);
            assert_int_equal(crisp_surface_closest_point(s, p, uv, &dist), CRISP_OK);
            crisp_surface_eval(s, uv[0], uv[1], q);
            assert_true(dist < 1e-9);
            assert_true(dist3(p, q) < 1e-9);
            assert_true(fabs(uv[0] - u) < 1e-6 && fabs(uv[1] - v) < 1e-6);
        }
        /* Off the surface along the normal: the foot is recovered, dist is the offset. */
        for (int k = 0; k < 50; k++) {
            double u = rnd(0.05, 0.95), v = rnd(-0.9, 1.9), p[3], su[3], sv[3], n[3], uv[2], d;
            crisp_surface_derivs(s, u, v, p, su, sv, NULL, NULL, NULL);
            crisp_vec3_cross(su, sv, n);
            if (!crisp_vec3_normalize(n, n)) continue;
            double off = 1e-3;
            for (int m = 0; m < 3; m++)
                p[m] += off * n[m];
            assert_int_equal(crisp_surface_closest_point(s, p, uv, &d), CRISP_OK);
            assert_true(fabs(d - off) < 1e-9);
            assert_true(fabs(uv[0] - u) < 1e-5 && fabs(uv[1] - v) < 1e-5);
        }
        crisp_surface_destroy(s);
    }
}

static void test_closest_point_sphere_and_seam(void **state)
{
    (void)state;
    double o[3] = {1, -2, 0.5}, ax[3] = {0.2, 0.1, 1};
    crisp_placement pl;
    assert_int_equal(crisp_placement_make(o, ax, NULL, &pl), CRISP_OK);
    crisp_surface *sph, *cyl;
    assert_int_equal(crisp_make_sphere(&pl, 2, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sph), CRISP_OK);
    assert_int_equal(crisp_make_cylinder(&pl, 1.5, 0, 2 * M_PI, -1, 3, &cyl), CRISP_OK);
    for (int k = 0; k < 200; k++) {
        /* Rational sphere, including points within 1e-7 of a pole and the poles themselves. */
        double u = rnd(0, 2 * M_PI), v = rnd(-M_PI / 2, M_PI / 2);
        if (k % 4 == 1) v = M_PI / 2 - rnd(0, 1e-7);
        if (k % 4 == 2) v = -M_PI / 2 + rnd(0, 1e-7);
        if (k == 3) v = M_PI / 2;
        double p[3], q[3], uv[2], d;
        crisp_surface_eval(sph, u, v, p);
        assert_int_equal(crisp_surface_closest_point(sph, p, uv, &d), CRISP_OK);
        assert_true(isfinite(uv[0]) && isfinite(uv[1]));
        crisp_surface_eval(sph, uv[0], uv[1], q);
        assert_true(dist3(p, q) < 1e-9 && d < 1e-9);
        if (k % 4 == 0) assert_true(fabs(uv[1] - v) < 1e-6 && fabs(uv[0] - u) < 1e-6);
        /* Cylinder, points on the seam (u = 0 = 2 pi) and next to it from both sides. */
        double cu = (k % 3 == 0) ? 0 : (k % 3 == 1) ? 2 * M_PI - rnd(0, 1e-6) : rnd(0, 1e-6);
        double cv = rnd(-1, 3);
        crisp_surface_eval(cyl, cu, cv, p);
        assert_int_equal(crisp_surface_closest_point(cyl, p, uv, &d), CRISP_OK);
        crisp_surface_eval(cyl, uv[0], uv[1], q);
        assert_true(dist3(p, q) < 1e-9 && d < 1e-9);
        assert_true(uv[0] >= 0 && uv[0] <= 2 * M_PI);
        assert_true(fabs(uv[1] - cv) < 1e-9);
    }
    /* The sphere's centre: every point is closest; the answer must be finite. */
    double uv[2], d;
    assert_int_equal(crisp_surface_closest_point(sph, o, uv, &d), CRISP_OK);
    assert_true(isfinite(uv[0]) && isfinite(uv[1]) && fabs(d - 2) < 1e-9);
    double bad[3] = {NAN, 0, 0};
    assert_int_equal(crisp_surface_closest_point(sph, bad, uv, &d), CRISP_ERR_INVALID_ARG);
    crisp_surface_destroy(sph);
    crisp_surface_destroy(cyl);
}

/* ---- curve projection -------------------------------------------------------------------------
 */

typedef struct helix {
    const crisp_placement *pl;
    double r, pitch;
} helix;

static void fn_helix(void *ctx, double t, double *d)
{
    const helix *h = ctx;
    for (int k = 0; k < 3; k++)
        d[k] = h->pl->origin[k] + h->r * (cos(t) * h->pl->x[k] + sin(t) * h->pl->y[k]) +
               h->pitch * t * h->pl->z[k];
}

/* Image of the uv curve (u wrapped into the surface's domain where the surface is closed, which
 * is what the evaluation clamps otherwise) against the 3D curve on a dense sample; also returns
 * the largest jump of the uv curve between consecutive samples. */
static double image_error(const crisp_surface *s, const crisp_curve *uvc, const crisp_curve *c,
                          double t0, double t1, double period_u, double *max_jump)
{
    double dom[4], worst = 0, prev[2] = {0, 0};
    crisp_surface_domain(s, dom);
    *max_jump = 0;
    for (int i = 0; i <= 4000; i++) {
        double t = t0 + (t1 - t0) * i / 4000.0, uv[2], p[3], q[3];
        crisp_curve_eval(uvc, t, uv);
        if (i > 0) {
            double j = hypot(uv[0] - prev[0], uv[1] - prev[1]);
            if (j > *max_jump) *max_jump = j;
        }
        prev[0] = uv[0];
        prev[1] = uv[1];
        double u = uv[0];
        if (period_u > 0) {
            u = dom[0] + fmod(u - dom[0], period_u);
            if (u < dom[0]) u += period_u;
        }
        crisp_surface_eval(s, u, uv[1], p);
        crisp_curve_eval(c, t, q);
        double e = dist3(p, q);
        if (e > worst) worst = e;
    }
    return worst;
}

static void test_project_helix_on_cylinder(void **state)
{
    (void)state;
    double o[3] = {0.5, 0.25, -1}, ax[3] = {0.3, -0.2, 1};
    crisp_placement pl;
    assert_int_equal(crisp_placement_make(o, ax, NULL, &pl), CRISP_OK);
    crisp_surface *cyl;
    assert_int_equal(crisp_make_cylinder(&pl, 2, 0, 2 * M_PI, -5, 10, &cyl), CRISP_OK);
    helix h = {&pl, 2, 0.3};
    crisp_curve *c, *uvc;
    /* The helix from angle 4 to 14: crosses the seam twice. A tight 3D fit keeps it on the
     * cylinder within 1e-10. */
    assert_int_equal(crisp_fit_curve(3, fn_helix, &h, 4, 14, 1e-10, 100000, &c), CRISP_OK);
    double tol = 1e-6;
    assert_int_equal(crisp_surface_project_curve(cyl, c, 4, 14, tol, &uvc), CRISP_OK);
    assert_int_equal(uvc->dim, 2);
    double jump, e = image_error(cyl, uvc, c, 4, 14, 2 * M_PI, &jump);
    assert_true(e <= tol);
    assert_true(jump < 0.05); /* continuous: no 2 pi jumps at the seam */
    /* u follows the angle (up to the seam's multiples of 2 pi), v the height. */
    double uv0[2], uv1[2];
    crisp_curve_eval(uvc, 4, uv0);
    crisp_curve_eval(uvc, 14, uv1);
    double du = uv1[0] - uv0[0];
    double expect = crisp_angle_to_param(0, 2 * M_PI, fmod(14, 2 * M_PI)) + 4 * M_PI -
                    crisp_angle_to_param(0, 2 * M_PI, 4);
    assert_true(fabs(fabs(du) - expect) < 1e-5);
    assert_true(fabs(uv1[1] - uv0[1] - 0.3 * 10) < 1e-5);
    crisp_curve_destroy(uvc);
    crisp_curve_destroy(c);
    crisp_surface_destroy(cyl);
}

static void test_project_circle_on_sphere(void **state)
{
    (void)state;
    double o[3] = {0, 0, 0}, ax[3] = {0, 0, 1};
    crisp_placement pl;
    assert_int_equal(crisp_placement_make(o, ax, NULL, &pl), CRISP_OK);
    crisp_surface *sph;
    double R = 3;
    assert_int_equal(crisp_make_sphere(&pl, R, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sph), CRISP_OK);
    /* Tilted small circles: the plane through h * n cuts the sphere in a circle of radius
     * sqrt(R^2 - h^2); the full circle crosses the seam. One passes close to the pole. */
    const double tilts[3] = {0.4, 1.2, 0.05};
    for (int it = 0; it < 3; it++) {
        double n[3] = {sin(tilts[it]), 0.1, cos(tilts[it])}, h = 1.1, nn[3];
        crisp_vec3_normalize(n, nn);
        crisp_placement cp;
        double ctr[3] = {h * nn[0], h * nn[1], h * nn[2]};
        assert_int_equal(crisp_placement_make(ctr, nn, NULL, &cp), CRISP_OK);
        double rr = sqrt(R * R - h * h);
        crisp_curve *c, *uvc;
        assert_int_equal(crisp_make_arc(3, cp.origin, cp.x, cp.y, rr, rr, 0, 2 * M_PI, &c),
                         CRISP_OK);
        double tol = 1e-7;
        assert_int_equal(crisp_surface_project_curve(sph, c, 0, 2 * M_PI, tol, &uvc), CRISP_OK);
        double jump, e = image_error(sph, uvc, c, 0, 2 * M_PI, 2 * M_PI, &jump);
        assert_true(e <= tol);
        assert_true(jump < 1); /* fast near the pole, but no 2 pi seam jump */
        crisp_curve_destroy(uvc);
        crisp_curve_destroy(c);
    }
    crisp_surface_destroy(sph);
}

/* A meridian from pole to pole (a sphere's seam edge): u is undefined at both ends and the curve
 * runs along the seam; and helices 1e-4, 8e-7 and 6e-7 off a cylinder, projected with tol 1e-6
 * (the image is compared with the curve's own projection, not the curve). */
static void test_project_pole_and_offset(void **state)
{
    (void)state;
    double o[3] = {0, 0, 0}, ax[3] = {0, 0, 1};
    crisp_placement pl;
    assert_int_equal(crisp_placement_make(o, ax, NULL, &pl), CRISP_OK);
    crisp_surface *sph, *cyl;
    assert_int_equal(crisp_make_sphere(&pl, 2, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sph), CRISP_OK);
    const double mer[2] = {0, 1.3}; /* on the seam, and elsewhere */
    for (int k = 0; k < 2; k++) {
        double mx[3] = {cos(mer[k]), sin(mer[k]), 0};
        crisp_curve *c, *uvc;
        assert_int_equal(crisp_make_arc(3, o, mx, pl.z, 2, 2, -M_PI / 2, M_PI / 2, &c), CRISP_OK);
        double tol = 1e-7;
        assert_int_equal(crisp_surface_project_curve(sph, c, -M_PI / 2, M_PI / 2, tol, &uvc),
                         CRISP_OK);
        double jump, e = image_error(sph, uvc, c, -M_PI / 2, M_PI / 2, 2 * M_PI, &jump);
        assert_true(e <= tol);
        /* u is constant along the meridian, poles included (taken from the neighbours). */
        for (int m = 0; m <= 50; m++) {
            double uv[2], u_exp = crisp_angle_to_param(0, 2 * M_PI, mer[k]);
            crisp_curve_eval(uvc, -M_PI / 2 + M_PI * m / 50, uv);
            double du = fmod(fabs(uv[0] - u_exp), 2 * M_PI);
            assert_true(du < 1e-6 || 2 * M_PI - du < 1e-6);
        }
        crisp_curve_destroy(uvc);
        crisp_curve_destroy(c);
    }
    assert_int_equal(crisp_make_cylinder(&pl, 2, 0, 2 * M_PI, -5, 10, &cyl), CRISP_OK);
    /* far off (100 tol), and just under the tolerance (0.8 tol, where the plain distance to the
     * curve could never pass the fit's acceptance: OCCT's bug22869_Spring.igs) */
    const double offsets[3] = {1e-4, 0.8e-6, 0.6e-6};
    for (int k = 0; k < 3; k++) {
        helix h = {&pl, 2 + offsets[k], 0.3};
        crisp_curve *c, *uvc;
        assert_int_equal(crisp_fit_curve(3, fn_helix, &h, 1, 8, 1e-10, 100000, &c), CRISP_OK);
        double tol = 1e-6;
        assert_int_equal(crisp_surface_project_curve(cyl, c, 1, 8, tol, &uvc), CRISP_OK);
        for (int m = 0; m <= 2000; m++) {
            double t = 1 + 7 * m / 2000.0, uv[2], p[3], q[3];
            crisp_curve_eval(uvc, t, uv);
            double u = fmod(uv[0], 2 * M_PI);
            if (u < 0) u += 2 * M_PI;
            crisp_surface_eval(cyl, u, uv[1], p);
            crisp_curve_eval(c, t, q);
            /* The foot of q on the cylinder: radial projection. */
            double r = hypot(q[0], q[1]), f[3] = {2 * q[0] / r, 2 * q[1] / r, q[2]};
            assert_true(dist3(p, f) <= tol);
        }
        crisp_curve_destroy(uvc);
        crisp_curve_destroy(c);
    }
    crisp_surface_destroy(sph);
    crisp_surface_destroy(cyl);
}

typedef struct iso {
    const crisp_surface *s;
    double u;
} iso;

static void fn_iso(void *ctx, double t, double *d)
{
    const iso *is = ctx;
    crisp_surface_eval(is->s, is->u, t, d);
}

static void test_project_iso_curves(void **state)
{
    (void)state;
    for (int it = 0; it < 4; it++) {
        crisp_surface *s = random_surface(3, 2 + it % 2, 7, 6, it % 2);
        for (int k = 0; k < 4; k++) {
            iso is = {s, rnd(0.05, 0.95)};
            crisp_curve *c, *uvc;
            assert_int_equal(crisp_fit_curve(3, fn_iso, &is, -1, 2, 1e-11, 100000, &c), CRISP_OK);
            double tol = 1e-6;
            assert_int_equal(crisp_surface_project_curve(s, c, -0.5, 1.5, tol, &uvc), CRISP_OK);
            double jump, e = image_error(s, uvc, c, -0.5, 1.5, 0, &jump);
            assert_true(e <= tol);
            for (int m = 0; m <= 100; m++) {
                double t = -0.5 + 2 * m / 100.0, uv[2];
                crisp_curve_eval(uvc, t, uv);
                assert_true(fabs(uv[0] - is.u) < 1e-5 && fabs(uv[1] - t) < 1e-5);
            }
            crisp_curve_destroy(uvc);
            crisp_curve_destroy(c);
        }
        crisp_surface_destroy(s);
    }
}

/* Issue 13: projections through a collapsed point. A double cone (apex to apex at the origin,
 * degree (2, 1), the middle row of control points collapsed) and the line from (1, 0, -1) through
 * the apex to (-1, 0, 1): below the apex it runs along u = 0, above along u = 1/2.
 * crisp_surface_project_curve_pieces returns pieces (one, when the fit can pass along the
 * collapsed row; else cut at the apex) whose images lie on the line within tol, in curve order,
 * covering [0, 1]. */
static void test_project_pieces_through_apex(void **state)
{
    (void)state;
    const double h = sqrt(0.5);
    double ku[] = {0, 0, 0, .25, .25, .5, .5, .75, .75, 1, 1, 1}, kv[] = {0, 0, 0.5, 1, 1};
    double cx[9] = {1, 1, 0, -1, -1, -1, 0, 1, 1}, cy[9] = {0, 1, 1, 1, 0, -1, -1, -1, 0};
    double w9[9] = {1, h, 1, h, 1, h, 1, h, 1}, pts[27 * 3], wts[27];
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 9; i++) {
            double r = j == 1 ? 0 : 1, *q = pts + 3 * (j * 9 + i);
            q[0] = r * cx[i], q[1] = r * cy[i], q[2] = j - 1.0;
            wts[j * 9 + i] = w9[i];
        }
    crisp_surface *s;
    assert_int_equal(crisp_surface_create(2, 1, 9, 3, ku, kv, pts, wts, &s), CRISP_OK);
    const double a[3] = {1, 0, -1}, b[3] = {-1, 0, 1}, a2[3] = {0, 0, 0};
    const double *ends[2][2] = {{a, b}, {a2, b}};
    for (int e = 0; e < 2; e++) {
        crisp_curve *c;
        assert_int_equal(crisp_make_line(3, ends[e][0], ends[e][1], 0, 1, &c), CRISP_OK);
        double tol = 1e-6, prev = 0;
        crisp_curve *pieces[4] = {NULL};
        int n = 0;
        assert_int_equal(crisp_surface_project_curve_pieces(s, c, 0, 1, tol, 4, pieces, &n),
                         CRISP_OK);
        assert_true(n >= 1 && n <= 4);
        for (int k = 0; k < n; k++) {
            double t0, t1, jump;
            crisp_curve_domain(pieces[k], &t0, &t1);
            assert_true(t0 >= prev - 1e-12 && t1 > t0);
            prev = t1;
            assert_true(image_error(s, pieces[k], c, t0, t1, 0, &jump) <= 2 * tol);
            crisp_curve_destroy(pieces[k]);
        }
        assert_true(fabs(prev - 1) < 1e-12);
        crisp_curve_destroy(c);
    }
    crisp_curve *one = NULL;
    int n1 = 0;
    assert_int_equal(crisp_surface_project_curve_pieces(s, NULL, 0, 1, 1e-6, 0, &one, &n1),
                     CRISP_ERR_INVALID_ARG);
    crisp_surface_destroy(s);
}

/* A polyline profile extruded (degree 1: C0 creases at its corners) and an edge that starts at a
 * corner and runs along the next segment (the profile of trj6_k1-al-214.stp's face #791, 19
 * segments, in the file's units): inversions seeded at the corner (the global search lands there
 * from the grid points of the segment before it) must not stay there with that segment's
 * derivatives, which are orthogonal to the edge. Both orders of the profile. */
static void test_project_along_crease(void **state)
{
    (void)state;
    static const double xy[20][2] = {
        {104.14, 0},      {104.14, -5.08},  {101.6, -5.08},  {101.6, -22.86}, {104.14, -22.86},
        {104.14, -15.24}, {106.68, -15.24}, {106.68, -25.4}, {109.22, -25.4}, {109.22, -15.24},
        {111.76, -15.24}, {111.76, -25.4},  {114.3, -25.4},  {114.3, -15.24}, {116.84, -15.24},
        {116.84, -22.86}, {119.38, -22.86}, {119.38, -5.08}, {116.84, -5.08}, {116.84, 0}};
    double knots[22];
    for (int i = 0; i < 22; i++)
        knots[i] = i == 0 ? 0 : i == 21 ? 19 : i - 1;
    for (int rev = 0; rev < 2; rev++) {
        double q[60];
        for (int i = 0; i < 20; i++) {
            const double *p = xy[rev ? 19 - i : i];
            q[3 * i] = p[0], q[3 * i + 1] = p[1], q[3 * i + 2] = 10.16;
        }
        crisp_curve *profile, *c, *uvc;
        crisp_surface *s;
        assert_int_equal(crisp_curve_create(3, 1, 20, knots, q, NULL, &profile), CRISP_OK);
        const double dir[3] = {0, 0, -1};
        assert_int_equal(crisp_make_extrusion(profile, dir, 0, 25.4, &s), CRISP_OK);
        const double a[3] = {106.68, -15.24, 1.27}, b[3] = {106.68, -25.4, 1.27};
        for (int flip = 0; flip < 2; flip++) {
            assert_int_equal(crisp_make_line(3, flip ? b : a, flip ? a : b, 0, 1, &c), CRISP_OK);
            double tol = 1e-5, jump, uv[2];
            assert_int_equal(crisp_surface_project_curve(s, c, 0, 1, tol, &uvc), CRISP_OK);
            assert_true(image_error(s, uvc, c, 0, 1, 0, &jump) <= tol);
            crisp_curve_eval(uvc, 0.5, uv);
            assert_true(fabs(uv[0] - (rev ? 12.5 : 6.5)) < 1e-6); /* the segment's middle */
            crisp_curve_destroy(uvc);
            crisp_curve_destroy(c);
        }
        crisp_surface_destroy(s);
        crisp_curve_destroy(profile);
    }
}

/* A point beyond a side of a skewed patch (S_u . S_v != 0) is nearest a point of that side; with
 * the beyond-the-side parameter clamped, the other must be solved alone (bm2_ec_exhaust-A.stp:
 * edges running 6e-5 outside a patch's side). The closest point and a projected curve along
 * the side are compared with the exact foot on the side. */
static void test_project_beyond_side(void **state)
{
    (void)state;
    const double p0[3] = {0, 0, 0}, p1[3] = {1, 0, 0}, q0[3] = {0.7, 1, 0}, q1[3] = {1.7, 1, 0};
    crisp_curve *c0, *c1, *c, *uvc;
    crisp_surface *s;
    assert_int_equal(crisp_make_line(3, p0, p1, 0, 1, &c0), CRISP_OK);
    assert_int_equal(crisp_make_line(3, q0, q1, 0, 1, &c1), CRISP_OK);
    assert_int_equal(crisp_make_ruled(c0, c1, &s), CRISP_OK);
    /* S(u, v) = u (1, 0, 0) + v (0.7, 1, 0): the side u = 0 runs along (0.7, 1, 0). Points
     * beyond it: x smaller than 0.7 y, lifted off the plane. */
    double dom[4];
    crisp_surface_domain(s, dom);
    assert_true(dom[0] == 0 && dom[1] == 1 && dom[2] == 0 && dom[3] == 1);
    const double side[3] = {0.7 / sqrt(1.49), 1 / sqrt(1.49), 0};
    for (int i = 0; i < 5; i++) {
        double y = 0.2 + 0.15 * i, p[3] = {0.7 * y - 0.01, y, 0.003}, uv[2], d;
        assert_int_equal(crisp_surface_closest_point(s, p, uv, &d), CRISP_OK);
        double foot_v = (p[0] * side[0] + p[1] * side[1]) / sqrt(1.49);
        assert_true(fabs(uv[0]) < 1e-12);
        assert_true(fabs(uv[1] - foot_v) < 1e-9);
    }
    const double a[3] = {0.7 * 0.1 - 0.01, 0.1, 0.003}, b[3] = {0.7 * 0.9 - 0.01, 0.9, 0.003};
    assert_int_equal(crisp_make_line(3, a, b, 0, 1, &c), CRISP_OK);
    assert_int_equal(crisp_surface_project_curve(s, c, 0, 1, 1e-7, &uvc), CRISP_OK);
    for (int i = 0; i <= 100; i++) {
        double t = i / 100.0, uv[2], p[3];
        crisp_curve_eval(uvc, t, uv);
        crisp_curve_eval(c, t, p);
        double foot_v = (p[0] * side[0] + p[1] * side[1]) / sqrt(1.49);
        assert_true(fabs(uv[0]) < 1e-9);
        assert_true(fabs(uv[1] - foot_v) < 1e-6);
    }
    crisp_curve_destroy(uvc);
    crisp_curve_destroy(c);
    crisp_curve_destroy(c0);
    crisp_curve_destroy(c1);
    crisp_surface_destroy(s);
}

/* A torus closed in both directions: each direction is a seam (both boundary curves of one are
 * one closed curve, not a point; their ends coincide because of the other direction). A minor
 * circle across the v seam and a major circle across the u seam project continuously (pr1db.stp: a
 * B-spline torus whose trims were stuck at the seam). */
static void test_project_across_torus_seams(void **state)
{
    (void)state;
    double o[3] = {0, 0, 0}, ax[3] = {0, 0, 1};
    crisp_placement pl;
    assert_int_equal(crisp_placement_make(o, ax, NULL, &pl), CRISP_OK);
    crisp_surface *s;
    double R = 5, r = 1.5;
    assert_int_equal(crisp_make_torus(&pl, R, r, 0, 2 * M_PI, 0, 2 * M_PI, &s), CRISP_OK);
    double dom[4];
    crisp_surface_domain(s, dom);
    for (int which = 0; which < 2; which++) {
        crisp_curve *c, *uvc;
        double ang = 0.7, ctr[3], x[3], y[3], rad, a0 = -1; /* from an angle of -1 rad on */
        if (which == 0) { /* minor circle at u = 0.7, across the outer equator (v = 0) */
            for (int k = 0; k < 3; k++) {
                double radial = cos(ang) * pl.x[k] + sin(ang) * pl.y[k];
                ctr[k] = R * radial, x[k] = radial, y[k] = pl.z[k];
            }
            rad = r;
        } else { /* major circle on the top (v = pi / 2), across u = 0 */
            for (int k = 0; k < 3; k++)
                ctr[k] = r * pl.z[k], x[k] = pl.x[k], y[k] = pl.y[k];
            rad = R;
        }
        assert_int_equal(crisp_make_arc(3, ctr, x, y, rad, rad, a0, a0 + 2 * M_PI, &c), CRISP_OK);
        double t0, t1, tol = 1e-6, worst = 0, prev[2] = {0, 0}, jump = 0;
        crisp_curve_domain(c, &t0, &t1);
        assert_int_equal(crisp_surface_project_curve(s, c, t0, t1, tol, &uvc), CRISP_OK);
        for (int i = 0; i <= 2000; i++) {
            double t = t0 + (t1 - t0) * i / 2000.0, uv[2], p[3], q[3];
            crisp_curve_eval(uvc, t, uv);
            if (i > 0) jump = fmax(jump, hypot(uv[0] - prev[0], uv[1] - prev[1]));
            prev[0] = uv[0], prev[1] = uv[1];
            for (int k = 0; k < 2; k++) {
                double w = dom[2 * k + 1] - dom[2 * k];
                uv[k] = dom[2 * k] + fmod(uv[k] - dom[2 * k], w);
                if (uv[k] < dom[2 * k]) uv[k] += w;
            }
            crisp_surface_eval(s, uv[0], uv[1], p);
            crisp_curve_eval(c, t, q);
            worst = fmax(worst, dist3(p, q));
        }
        assert_true(worst <= tol);
        assert_true(jump < 0.05 * (dom[1] - dom[0] + dom[3] - dom[2]));
        crisp_curve_destroy(uvc);
        crisp_curve_destroy(c);
    }
    crisp_surface_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fit_hard_functions),
        cmocka_unit_test(test_fit_span_bound),
        cmocka_unit_test(test_fit_bad_function),
        cmocka_unit_test(test_closest_point_random_surfaces),
        cmocka_unit_test(test_closest_point_sphere_and_seam),
        cmocka_unit_test(test_project_helix_on_cylinder),
        cmocka_unit_test(test_project_circle_on_sphere),
        cmocka_unit_test(test_project_iso_curves),
        cmocka_unit_test(test_project_pole_and_offset),
        cmocka_unit_test(test_project_pieces_through_apex),
        cmocka_unit_test(test_project_along_crease),
        cmocka_unit_test(test_project_beyond_side),
        cmocka_unit_test(test_project_across_torus_seams),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
