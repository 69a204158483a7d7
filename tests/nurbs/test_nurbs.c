/* Tests for the NURBS kernel (src/nurbs: curve.c, surface.c, knots.c, extract.c, bezier.c):
 * exact conics, evaluation against an independent de Boor evaluator, derivatives against
 * central differences, Bézier extraction, knot insertion, splitting, boxes, reversal, trimming
 * and rejection of invalid definitions.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "crisp/nurbs.h"
#include "nurbs/test_util.h"

/* ---- independent reference: de Boor's algorithm (The NURBS Book A3.1 alternative) ---------- */

static int ref_span(const double *knots, int degree, int count, double t)
{
    if (t >= knots[count]) return ref_last_span(knots, degree, count);
    int k = degree;
    while (!(knots[k] <= t && t < knots[k + 1]))
        k++;
    return k;
}

/* Homogeneous point on span k at t; cp points at control point k - p (nc doubles, stride st). */
static void deboor(const double *knots, int p, int k, double t, const double *cp, size_t st, int nc,
                   double *dest)
{
    double d[16][4];
    for (int j = 0; j <= p; j++)
        for (int c = 0; c < nc; c++)
            d[j][c] = cp[(size_t)j * st + c];
    for (int r = 1; r <= p; r++)
        for (int j = p; j >= r; j--) {
            double a = (t - knots[j + k - p]) / (knots[j + 1 + k - r] - knots[j + k - p]);
            for (int c = 0; c < nc; c++)
                d[j][c] = (1 - a) * d[j - 1][c] + a * d[j][c];
        }
    for (int c = 0; c < nc; c++)
        dest[c] = d[p][c];
}

static void ref_curve(const crisp_curve *c, double t, double *dest)
{
    double h[4];
    int k = ref_span(c->knots, c->degree, c->count, t);
    deboor(c->knots, c->degree, k, t, c->cpw + (size_t)(k - c->degree) * (c->dim + 1),
           (size_t)c->dim + 1, c->dim + 1, h);
    for (int d = 0; d < c->dim; d++)
        dest[d] = h[d] / h[c->dim];
}

static void ref_surface(const crisp_surface *s, double u, double v, double *dest)
{
    double col[16 * 4], h[4];
    int ku = ref_span(s->knots_u, s->degree_u, s->count_u, u);
    int kv = ref_span(s->knots_v, s->degree_v, s->count_v, v);
    for (int l = 0; l <= s->degree_v; l++) {
        const double *row =
            s->cpw + ((size_t)(kv - s->degree_v + l) * s->count_u + (size_t)(ku - s->degree_u)) * 4;
        deboor(s->knots_u, s->degree_u, ku, u, row, 4, 4, col + l * 4);
    }
    deboor(s->knots_v, s->degree_v, kv, v, col, 4, 4, h);
    for (int d = 0; d < 3; d++)
        dest[d] = h[d] / h[3];
}

static double curve_scale(const crisp_curve *c)
{
    double b[6], m = 1.0;
    crisp_curve_bbox(c, b);
    for (int d = 0; d < 2 * c->dim; d++)
        m = fmax(m, fabs(b[d]));
    return m;
}

/* ---- exact conics ------------------------------------------------------------------------- */

static const double circle_knots[12] = {0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1};
static const double circle_pts[18] = {1, 0, 1, 1, 0, 1, -1, 1, -1, 0, -1, -1, 0, -1, 1, -1, 1, 0};

static void circle_weights(double *w)
{
    for (int i = 0; i < 9; i++)
        w[i] = (i % 2) ? sqrt(0.5) : 1.0;
}

static void test_circle_exact(void **state)
{
    (void)state;
    double w[9];
    circle_weights(w);
    crisp_curve *c;
    assert_int_equal(crisp_curve_create(2, 2, 9, circle_knots, circle_pts, w, &c), CRISP_OK);
    assert_true(c->rational);
    double worst = 0.0, p[2];
    for (int i = 0; i <= 10000; i++) {
        crisp_curve_eval(c, i / 10000.0, p);
        worst = fmax(worst, fabs(hypot(p[0], p[1]) - 1.0));
    }
    assert_true(worst < 1e-12);
    crisp_curve_eval(c, 0.125, p); /* the parameter midpoint of the first quarter is at 45 deg */
    assert_true(fabs(p[0] - p[1]) < 1e-15);
    crisp_curve_destroy(c);
}

static void test_cylinder_exact(void **state)
{
    (void)state;
    double pts[9 * 2 * 3], w[18], wc[9], kv[4] = {0, 0, 2, 2};
    circle_weights(wc);
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 9; i++) {
            pts[(j * 9 + i) * 3 + 0] = 3.0 * circle_pts[i * 2];
            pts[(j * 9 + i) * 3 + 1] = 3.0 * circle_pts[i * 2 + 1];
            pts[(j * 9 + i) * 3 + 2] = 5.0 * j;
            w[j * 9 + i] = wc[i];
        }
    crisp_surface *s;
    assert_int_equal(crisp_surface_create(2, 1, 9, 2, circle_knots, kv, pts, w, &s), CRISP_OK);
    double worst = 0.0, zerr = 0.0, p[3];
    rng_seed(7);
    for (int i = 0; i < 10000; i++) {
        double u = rng_uniform(), v = 2.0 * rng_uniform();
        crisp_surface_eval(s, u, v, p);
        worst = fmax(worst, fabs(hypot(p[0], p[1]) - 3.0));
        zerr = fmax(zerr, fabs(p[2] - 2.5 * v));
    }
    assert_true(worst < 1e-12 * 3.0);
    assert_true(zerr < 1e-12);
    crisp_surface_destroy(s);
}

/* ---- evaluation against de Boor ---------------------------------------------------------- */

static void test_curve_eval_reference(void **state)
{
    (void)state;
    rng_seed(11);
    double worst = 0.0;
    for (int it = 0; it < 300; it++) {
        int degree = rng_int(1, 15), dim = rng_int(2, 3);
        crisp_curve *c =
            random_curve(dim, degree, degree + 1 + rng_int(0, 12), it % 2, it % 3 != 0);
        assert_non_null(c);
        double t0, t1, a[3], b[3];
        crisp_curve_domain(c, &t0, &t1);
        for (int i = 0; i <= 20; i++) {
            double t = i == 20 ? t1 : t0 + (t1 - t0) * rng_uniform();
            if (i == 0) t = t0;
            crisp_curve_eval(c, t, a);
            ref_curve(c, t, b);
            worst = fmax(worst, dist_n(a, b, dim) / curve_scale(c));
        }
        crisp_curve_destroy(c);
    }
    assert_true(worst < 1e-12);
}

/* ---- derivatives against central differences --------------------------------------------- */

/* Richardson-extrapolated central difference of f at t (error O(h^4)). */
#define CENTRAL(fn, t, h, out, n)                                                                  \
    do {                                                                                           \
        double fp1[3], fm1[3], fp2[3], fm2[3];                                                     \
        fn((t) + (h), fp1);                                                                        \
        fn((t) - (h), fm1);                                                                        \
        fn((t) + (h) / 2, fp2);                                                                    \
        fn((t) - (h) / 2, fm2);                                                                    \
        for (int q = 0; q < (n); q++) {                                                            \
            double d1 = (fp1[q] - fm1[q]) / (2 * (h)), d2 = (fp2[q] - fm2[q]) / (h);               \
            (out)[q] = (4 * d2 - d1) / 3;                                                          \
        }                                                                                          \
    } while (0)

static const crisp_curve *fd_curve;
static void fd_point(double t, double *d)
{
    crisp_curve_eval(fd_curve, t, d);
}
static void fd_first(double t, double *d)
{
    double all[6];
    crisp_curve_derivs(fd_curve, t, 1, all);
    memcpy(d, all + fd_curve->dim, (size_t)fd_curve->dim * sizeof *d);
}

static void test_curve_derivs_fd(void **state)
{
    (void)state;
    rng_seed(23);
    for (int it = 0; it < 200; it++) {
        int degree = rng_int(1, 8), dim = 2 + it % 2;
        crisp_curve *c =
            random_curve(dim, degree, degree + 1 + rng_int(0, 6), it % 4 < 2, it % 3 != 0);
        assert_non_null(c);
        fd_curve = c;
        for (int k = degree; k < c->count; k++) {
            double a = c->knots[k], b = c->knots[k + 1];
            if (!(a < b)) continue;
            double t = a + (b - a) * (0.1 + 0.8 * rng_uniform()), h = 1e-3 * (b - a);
            double d[9], e1[3], e2[3];
            crisp_curve_derivs(c, t, 2, d);
            double p[3];
            crisp_curve_eval(c, t, p);
            assert_true(dist_n(p, d, dim) <= 1e-13 * curve_scale(c));
            CENTRAL(fd_point, t, h, e1, dim);
            CENTRAL(fd_first, t, h, e2, dim);
            double m1 = 1.0 + sqrt(d[dim] * d[dim] + d[dim + 1] * d[dim + 1]);
            double m2 = 1.0 + sqrt(d[2 * dim] * d[2 * dim] + d[2 * dim + 1] * d[2 * dim + 1]);
            for (int q = 0; q < dim; q++) {
                assert_true(fabs(e1[q] - d[dim + q]) <= 1e-6 * m1);
                assert_true(fabs(e2[q] - d[2 * dim + q]) <= 1e-6 * m2);
            }
        }
        crisp_curve_destroy(c);
    }
}

static void test_surface_derivs_fd(void **state)
{
    (void)state;
    rng_seed(29);
    for (int it = 0; it < 60; it++) {
        int du = rng_int(1, 6), dv = rng_int(1, 6);
        crisp_surface *s = random_surface(du, dv, du + 1 + rng_int(0, 4), dv + 1 + rng_int(0, 4),
                                          it % 2, it % 3 != 0);
        assert_non_null(s);
        int ku = du, kv = dv; /* first spans with length */
        while (!(s->knots_u[ku] < s->knots_u[ku + 1]))
            ku++;
        while (!(s->knots_v[kv] < s->knots_v[kv + 1]))
            kv++;
        double ua = s->knots_u[ku], ub = s->knots_u[ku + 1];
        double va = s->knots_v[kv], vb = s->knots_v[kv + 1];
        double u = ua + (ub - ua) * (0.1 + 0.8 * rng_uniform());
        double v = va + (vb - va) * (0.1 + 0.8 * rng_uniform());
        double hu = 1e-3 * (ub - ua), hv = 1e-3 * (vb - va);
        double p[3], su[3], sv[3], suu[3], suv[3], svv[3], q[3];
        crisp_surface_derivs(s, u, v, p, su, sv, suu, suv, svv);
        crisp_surface_eval(s, u, v, q);
        assert_true(dist_n(p, q, 3) < 1e-13 * 10);
        /* first partials from points, second partials from the first partials */
        double f[4][3], g[4][3], e[3];
        double mag = 1.0;
        for (int d = 0; d < 3; d++)
            mag = fmax(mag, fmax(fmax(fabs(su[d]), fabs(sv[d])),
                                 fmax(fmax(fabs(suu[d]), fabs(suv[d])), fabs(svv[d]))));
        const double steps[2] = {1.0, 0.5};
        for (int dir = 0; dir < 2; dir++) {
            double est1[2][3], est2[2][3], est3[2][3];
            for (int sidx = 0; sidx < 2; sidx++) {
                double h = (dir ? hv : hu) * steps[sidx];
                double up = u + (dir ? 0 : h), um = u - (dir ? 0 : h);
                double vp = v + (dir ? h : 0), vm = v - (dir ? h : 0);
                crisp_surface_derivs(s, up, vp, f[0], g[0], g[1], NULL, NULL, NULL);
                crisp_surface_derivs(s, um, vm, f[1], g[2], g[3], NULL, NULL, NULL);
                for (int d = 0; d < 3; d++) {
                    est1[sidx][d] = (f[0][d] - f[1][d]) / (2 * h);
                    est2[sidx][d] = (g[0][d] - g[2][d]) / (2 * h); /* d su / d dir */
                    est3[sidx][d] = (g[1][d] - g[3][d]) / (2 * h); /* d sv / d dir */
                }
            }
            for (int d = 0; d < 3; d++) {
                e[d] = (4 * est1[1][d] - est1[0][d]) / 3;
                double x2 = (4 * est2[1][d] - est2[0][d]) / 3;
                double x3 = (4 * est3[1][d] - est3[0][d]) / 3;
                if (dir == 0) {
                    assert_true(fabs(e[d] - su[d]) <= 1e-6 * mag);
                    assert_true(fabs(x2 - suu[d]) <= 1e-6 * mag);
                    assert_true(fabs(x3 - suv[d]) <= 1e-6 * mag);
                } else {
                    assert_true(fabs(e[d] - sv[d]) <= 1e-6 * mag);
                    assert_true(fabs(x2 - suv[d]) <= 1e-6 * mag);
                    assert_true(fabs(x3 - svv[d]) <= 1e-6 * mag);
                }
            }
        }
        crisp_surface_destroy(s);
    }
}

/* ---- Bézier extraction -------------------------------------------------------------------- */

static int find_piece(const crisp_bezier_curve *b, int n, double t)
{
    int i = 0;
    while (i < n - 1 && t >= b[i].t1)
        i++;
    return i;
}

static void test_curve_to_bezier(void **state)
{
    (void)state;
    rng_seed(31);
    double worst = 0.0;
    int samples = 0;
    for (int it = 0; it < 500; it++) {
        int degree = it < 30 ? 15 - it % 3 : rng_int(1, 15), dim = rng_int(2, 3);
        crisp_curve *c =
            random_curve(dim, degree, degree + 1 + rng_int(0, 14), it % 2, it % 3 != 0);
        assert_non_null(c);
        crisp_bezier_curve *b;
        int n;
        assert_int_equal(crisp_curve_to_bezier(c, &b, &n), CRISP_OK);
        int spans = 0;
        for (int k = degree; k < c->count; k++)
            spans += c->knots[k] < c->knots[k + 1];
        assert_int_equal(n, spans);
        double t0, t1;
        crisp_curve_domain(c, &t0, &t1);
        assert_true(b[0].t0 == t0 && b[n - 1].t1 == t1);
        for (int i = 1; i < n; i++)
            assert_true(b[i].t0 == b[i - 1].t1);
        for (int i = 0; i < 20; i++, samples++) {
            double t = t0 + (t1 - t0) * rng_uniform(), p[3], q[3];
            int k = find_piece(b, n, t);
            assert_int_equal(b[k].degree, degree);
            crisp_bezier_curve_eval(&b[k], (t - b[k].t0) / (b[k].t1 - b[k].t0), q);
            crisp_curve_eval(c, t, p);
            worst = fmax(worst, dist_n(p, q, dim) / curve_scale(c));
            ref_curve(c, t, p);
            worst = fmax(worst, dist_n(p, q, dim) / curve_scale(c));
        }
        crisp_free(b);
        crisp_curve_destroy(c);
    }
    assert_true(samples >= 10000);
    assert_true(worst < 1e-12);
}

static double surface_scale(const crisp_surface *s)
{
    double b[6], m = 1.0;
    crisp_surface_bbox(s, b);
    for (int d = 0; d < 6; d++)
        m = fmax(m, fabs(b[d]));
    return m;
}

static void test_surface_to_bezier(void **state)
{
    (void)state;
    rng_seed(37);
    double worst = 0.0;
    int samples = 0;
    for (int it = 0; it < 200; it++) {
        int du = it < 10 ? 15 : rng_int(1, 15), dv = it < 10 ? 14 - it % 3 : rng_int(1, 15);
        crisp_surface *s = random_surface(du, dv, du + 1 + rng_int(0, 5), dv + 1 + rng_int(0, 5),
                                          it % 2, it % 3 != 0);
        assert_non_null(s);
        crisp_bezier_patches bp;
        assert_int_equal(crisp_surface_to_bezier(s, &bp), CRISP_OK);
        int su = 0, sv = 0;
        for (int k = du; k < s->count_u; k++)
            su += s->knots_u[k] < s->knots_u[k + 1];
        for (int k = dv; k < s->count_v; k++)
            sv += s->knots_v[k] < s->knots_v[k + 1];
        assert_int_equal(bp.count, su * sv);
        double dom[4];
        crisp_surface_domain(s, dom);
        for (int i = 0; i < 50; i++, samples++) {
            double u = dom[0] + (dom[1] - dom[0]) * rng_uniform();
            double v = dom[2] + (dom[3] - dom[2]) * rng_uniform();
            int a = 0, b = 0;
            while (a < su - 1 && u >= bp.patches[a].u1)
                a++;
            while (b < sv - 1 && v >= bp.patches[b * su].v1)
                b++;
            const crisp_bezier_patch *p = &bp.patches[b * su + a];
            assert_true(p->u0 <= u && u <= p->u1 && p->v0 <= v && v <= p->v1);
            double x[3], y[3], z[3];
            crisp_bezier_patch_eval(p, (u - p->u0) / (p->u1 - p->u0), (v - p->v0) / (p->v1 - p->v0),
                                    x);
            crisp_surface_eval(s, u, v, y);
            ref_surface(s, u, v, z);
            double sc = surface_scale(s);
            worst = fmax(worst, fmax(dist_n(x, y, 3), dist_n(x, z, 3)) / sc);
        }
        crisp_bezier_patches_free(&bp);
        assert_null(bp.patches);
        crisp_surface_destroy(s);
    }
    assert_true(samples >= 10000);
    assert_true(worst < 1e-12);
}

/* ---- knot insertion ------------------------------------------------------------------------ */

static void test_curve_insert_knot(void **state)
{
    (void)state;
    rng_seed(41);
    for (int it = 0; it < 200; it++) {
        int degree = rng_int(1, 15), dim = rng_int(2, 3);
        crisp_curve *c =
            random_curve(dim, degree, degree + 1 + rng_int(0, 10), it % 2, it % 3 != 0);
        crisp_curve *d;
        assert_int_equal(crisp_curve_copy(c, &d), CRISP_OK);
        double t0, t1;
        crisp_curve_domain(c, &t0, &t1);
        /* an existing interior knot half the time, else a random parameter */
        double t = t0 + (t1 - t0) * rng_uniform();
        if (it % 2 && c->count > degree + 1) t = c->knots[rng_int(degree + 1, c->count - 1)];
        if (it % 7 == 0) t = t0; /* domain ends of unclamped vectors */
        int s = 0;
        for (int i = 0; i < c->count + degree + 1; i++)
            s += c->knots[i] == t;
        int times = s >= degree ? 0 : rng_int(1, degree - s);
        assert_int_equal(crisp_curve_insert_knot(d, t, times), CRISP_OK);
        assert_int_equal(d->count, c->count + times);
        double u0, u1;
        crisp_curve_domain(d, &u0, &u1);
        assert_true(u0 == t0 && u1 == t1);
        for (int i = 0; i < 50; i++) {
            double x = t0 + (t1 - t0) * i / 49.0, p[3], q[3];
            crisp_curve_eval(c, x, p);
            crisp_curve_eval(d, x, q);
            assert_true(dist_n(p, q, dim) < 1e-12 * curve_scale(c));
        }
        /* beyond the degree is refused */
        assert_int_equal(crisp_curve_insert_knot(d, t, degree + 1), CRISP_ERR_INVALID_ARG);
        assert_int_equal(crisp_curve_insert_knot(d, t1 + 1.0, 1), CRISP_ERR_INVALID_ARG);
        crisp_curve_destroy(c);
        crisp_curve_destroy(d);
    }
}

static void test_surface_insert_knot(void **state)
{
    (void)state;
    rng_seed(43);
    for (int it = 0; it < 60; it++) {
        int du = rng_int(1, 9), dv = rng_int(1, 9);
        crisp_surface *s = random_surface(du, dv, du + 1 + rng_int(0, 5), dv + 1 + rng_int(0, 5),
                                          it % 2, it % 3 != 0);
        crisp_surface *d;
        assert_int_equal(crisp_surface_copy(s, &d), CRISP_OK);
        double dom[4];
        crisp_surface_domain(s, dom);
        double u = dom[0] + (dom[1] - dom[0]) * rng_uniform();
        double v = dom[2] + (dom[3] - dom[2]) * rng_uniform();
        assert_int_equal(crisp_surface_insert_knot_u(d, u, rng_int(1, du)), CRISP_OK);
        assert_int_equal(crisp_surface_insert_knot_v(d, v, rng_int(1, dv)), CRISP_OK);
        assert_int_equal(crisp_surface_insert_knot_v(d, dom[2] + 0.5 * (dom[3] - dom[2]), 1),
                         CRISP_OK);
        for (int i = 0; i < 100; i++) {
            double x = dom[0] + (dom[1] - dom[0]) * rng_uniform();
            double y = dom[2] + (dom[3] - dom[2]) * rng_uniform();
            double p[3], q[3];
            crisp_surface_eval(s, x, y, p);
            crisp_surface_eval(d, x, y, q);
            assert_true(dist_n(p, q, 3) < 1e-12 * surface_scale(s));
        }
        crisp_surface_destroy(s);
        crisp_surface_destroy(d);
    }
}

/* ---- invalid definitions ------------------------------------------------------------------ */

static void expect_curve_error(int dim, int degree, int count, const double *k, const double *p,
                               const double *w, crisp_status want, const char *needle)
{
    crisp_curve *c = (crisp_curve *)&c; /* must be reset to NULL */
    crisp_error_clear();
    assert_int_equal(crisp_curve_create(dim, degree, count, k, p, w, &c), want);
    assert_null(c);
    if (!strstr(crisp_error_message(), needle))
        fail_msg("message '%s' lacks '%s'", crisp_error_message(), needle);
}

static void test_invalid_curves(void **state)
{
    (void)state;
    const double k[9] = {0, 0, 0, 0.5, 0.5, 0.2, 1, 1, 1};
    const double good_k[9] = {0, 0, 0, 0.2, 0.5, 0.5, 1, 1, 1};
    const double p[12] = {0, 0, 1, 0, 1, 1, 0, 1, 2, 2, 3, 3};
    const double w[6] = {1, 1, 1, -1, 1, 1};
    expect_curve_error(2, 2, 6, k, p, NULL, CRISP_ERR_INVALID_ARG, "knot 5 (0.2");
    expect_curve_error(2, 2, 6, good_k, p, w, CRISP_ERR_INVALID_ARG, "weight 3 is -1");
    double nanp[12];
    memcpy(nanp, p, sizeof nanp);
    nanp[5] = NAN;
    expect_curve_error(2, 2, 6, good_k, nanp, NULL, CRISP_ERR_INVALID_ARG, "control point 2");
    nanp[5] = INFINITY;
    expect_curve_error(2, 2, 6, good_k, nanp, NULL, CRISP_ERR_INVALID_ARG, "control point 2");
    double infk[9];
    memcpy(infk, good_k, sizeof infk);
    infk[4] = NAN;
    expect_curve_error(2, 2, 6, infk, p, NULL, CRISP_ERR_INVALID_ARG, "knot 4");
    const double w0[6] = {1, 1, 1, 1, 0, 1};
    expect_curve_error(2, 2, 6, good_k, p, w0, CRISP_ERR_INVALID_ARG, "weight 4");
    expect_curve_error(2, 0, 6, good_k, p, NULL, CRISP_ERR_INVALID_ARG, "degree 0");
    expect_curve_error(2, 16, 20, good_k, p, NULL, CRISP_ERR_INVALID_ARG, "degree 16");
    expect_curve_error(2, 5, 3, good_k, p, NULL, CRISP_ERR_INVALID_ARG,
                       "at least 6 control points");
    expect_curve_error(4, 2, 6, good_k, p, NULL, CRISP_ERR_INVALID_ARG, "dimension 4");
    expect_curve_error(2, 2, CRISP_MAX_CONTROL_POINTS + 1, good_k, p, NULL, CRISP_ERR_LIMIT,
                       "limit");
    const double empty_k[5] = {1, 1, 1, 1, 1};
    expect_curve_error(2, 2, 2, empty_k, p, NULL, CRISP_ERR_INVALID_ARG, "at least 3");
    double huge[12];
    memcpy(huge, p, sizeof huge);
    huge[6] = 1.5e308; /* finite, but w * x overflows with weight 2 */
    const double w2[6] = {1, 1, 1, 2, 1, 1};
    expect_curve_error(2, 2, 6, good_k, huge, w2, CRISP_ERR_INVALID_ARG, "control point 3");
    const double wide_k[9] = {-1.5e308, 0, 0, 0.2, 0.5, 0.5, 1, 1, 1.5e308};
    expect_curve_error(2, 2, 6, wide_k, p, NULL, CRISP_ERR_INVALID_ARG, "overflows");
    const double flat_k[6] = {0, 1, 1, 1, 1, 2};
    expect_curve_error(2, 2, 3, flat_k, p, NULL, CRISP_ERR_INVALID_ARG, "domain is empty");

    /* surfaces */
    crisp_surface *s = NULL;
    const double ku[4] = {0, 0, 1, 1}, bad[4] = {0, 1, 0.5, 1};
    const double sp[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
    const double sw[4] = {1, 1, 1, -2};
    assert_int_equal(crisp_surface_create(1, 1, 2, 2, ku, bad, sp, NULL, &s),
                     CRISP_ERR_INVALID_ARG);
    assert_non_null(strstr(crisp_error_message(), "surface v knot 2"));
    assert_int_equal(crisp_surface_create(1, 1, 2, 2, ku, ku, sp, sw, &s), CRISP_ERR_INVALID_ARG);
    assert_non_null(strstr(crisp_error_message(), "weight 3"));
    assert_int_equal(crisp_surface_create(1, 17, 2, 2, ku, ku, sp, NULL, &s),
                     CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_surface_create(1, 1, 1 << 12, 1 << 12, ku, ku, sp, NULL, &s),
                     CRISP_ERR_LIMIT);
    assert_null(s);
    const double okw[4] = {1, 2, 1, 1};
    assert_int_equal(crisp_surface_create(1, 1, 2, 2, ku, ku, sp, okw, &s), CRISP_OK);
    assert_true(s->rational);
    crisp_surface_destroy(s);
    crisp_surface_destroy(NULL);
    crisp_curve_destroy(NULL);
}

/* ---- knot vectors beyond the usual: multiplicity degree + 1 inside, degree + 2 at an end ---- */

static void test_extreme_multiplicities(void **state)
{
    (void)state;
    /* degree 2, start knot 0 four times (an empty first span), interior 2 three times (a
     * break), domain [0, 3] */
    const double k[11] = {0, 0, 0, 0, 1, 2, 2, 2, 3, 3, 3};
    const double p[16] = {0, 0, 1, 0, 1, 1, 2, 1, 2, 2, 3, 5, 4, 4, 5, 3};
    const double w[8] = {1, 2, 1, 0.5, 1, 3, 1, 1};
    crisp_curve *c;
    assert_int_equal(crisp_curve_create(2, 2, 8, k, p, w, &c), CRISP_OK);
    crisp_bezier_curve *b;
    int n;
    assert_int_equal(crisp_curve_to_bezier(c, &b, &n), CRISP_OK);
    assert_int_equal(n, 3);
    double q[2], r[2], e[2];
    crisp_curve_eval(c, 0.0, q);
    crisp_bezier_curve_eval(&b[0], 0.0, r);
    assert_true(dist_n(q, r, 2) < 1e-14);
    rng_seed(3);
    for (int i = 0; i < 1000; i++) {
        double t = 3.0 * rng_uniform();
        int m = find_piece(b, n, t);
        crisp_curve_eval(c, t, q);
        crisp_bezier_curve_eval(&b[m], (t - b[m].t0) / (b[m].t1 - b[m].t0), r);
        ref_curve(c, t, e);
        assert_true(dist_n(q, r, 2) < 1e-13 && dist_n(q, e, 2) < 1e-13);
    }
    crisp_free(b);
    /* trimming across the break keeps both sides */
    crisp_curve *t;
    assert_int_equal(crisp_curve_trim(c, 0.5, 2.5, &t), CRISP_OK);
    for (int i = 0; i <= 40; i++) {
        double x = 0.5 + 2.0 * i / 40.0;
        if (x == 2.0) continue; /* the break: either side's value is right */
        crisp_curve_eval(c, x, q);
        crisp_curve_eval(t, x, r);
        assert_true(dist_n(q, r, 2) < 1e-13);
    }
    crisp_curve_destroy(t);
    crisp_curve_destroy(c);
}

/* Random, mostly invalid definitions: every call returns an error or a curve that evaluates to
 * finite points; nothing crashes (run under the sanitizers). */
static void test_hostile_definitions(void **state)
{
    (void)state;
    rng_seed(59);
    static const double pool[] = {0,      1,   -1,       0.5,       1e300, -1e300,
                                  1e-300, NAN, INFINITY, -INFINITY, 2};
    int accepted = 0;
    for (int it = 0; it < 5000; it++) {
        int degree = rng_int(-2, 17), count = rng_int(-1, 20), dim = rng_int(1, 4);
        double k[64], pts[64 * 4], w[64];
        double t = 0.0;
        for (int i = 0; i < 64; i++) {
            t += rng_uniform() < 0.3 ? 0.0 : rng_uniform();
            k[i] = rng_uniform() < 0.02 ? pool[rng_int(0, 10)] : t;
        }
        for (int i = 0; i < 64 * 4; i++)
            pts[i] = rng_uniform() < 0.01 ? pool[rng_int(0, 10)] : rng_uniform();
        for (int i = 0; i < 64; i++)
            w[i] = rng_uniform() < 0.02 ? pool[rng_int(0, 10)] : 1 + rng_uniform();
        crisp_curve *c = NULL;
        crisp_status st = crisp_curve_create(dim, degree, count, k, pts, w, &c);
        if (st != CRISP_OK) {
            assert_null(c);
            assert_true(strlen(crisp_error_message()) > 0);
            continue;
        }
        accepted++;
        double t0, t1, x[3];
        crisp_curve_domain(c, &t0, &t1);
        for (int i = 0; i <= 10; i++) {
            crisp_curve_eval(c, t0 + (t1 - t0) * i / 10.0, x);
            for (int d = 0; d < dim; d++)
                assert_true(isfinite(x[d]));
        }
        crisp_curve_eval(c, NAN, x); /* no crash; value unspecified */
        crisp_bezier_curve *b;
        int n;
        assert_int_equal(crisp_curve_to_bezier(c, &b, &n), CRISP_OK);
        crisp_free(b);
        crisp_curve_destroy(c);
    }
    assert_true(accepted > 100);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_circle_exact),           cmocka_unit_test(test_cylinder_exact),
        cmocka_unit_test(test_curve_eval_reference),   cmocka_unit_test(test_curve_derivs_fd),
        cmocka_unit_test(test_surface_derivs_fd),      cmocka_unit_test(test_curve_to_bezier),
        cmocka_unit_test(test_surface_to_bezier),      cmocka_unit_test(test_curve_insert_knot),
        cmocka_unit_test(test_surface_insert_knot),    cmocka_unit_test(test_invalid_curves),
        cmocka_unit_test(test_extreme_multiplicities), cmocka_unit_test(test_hostile_definitions),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
