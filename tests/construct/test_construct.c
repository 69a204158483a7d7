/* Tests for the analytic constructions (src/nurbs/construct.c): every curve and surface lies on
 * its analytic shape, the angle parametrisation maps exactly, conic arcs pass through their
 * defining points, ruled/extruded/revolved surfaces equal their definitions. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "crisp/construct.h"
#include "construct/test_util.h"

#define EXACT 1e-12

static void test_angle_param_inverse(void **state)
{
    (void)state;
    /* Angles and sweeps far outside any arc (or NaN) are clamped, never converted to an int out
     * of range (UBSan in the sanitizer build catches that). */
    assert_true(isfinite(crisp_angle_to_param(0, 1, 1e300)));
    assert_true(isfinite(crisp_angle_to_param(0, 1, -1e300)));
    assert_true(isfinite(crisp_param_to_angle(0, 1, 1e300)));
    assert_true(isnan(crisp_angle_to_param(0, 1, NAN)));
    assert_true(isfinite(crisp_angle_to_param(0, 1e300, 2.0)));
    const double a0s[] = {0, -1.0, 2.5, -M_PI};
    const double sweeps[] = {0.3, M_PI / 2, 1.7, M_PI, 1.5 * M_PI, 2 * M_PI, 0.5 * M_PI + 1e-3};
    for (size_t i = 0; i < sizeof a0s / sizeof *a0s; i++)
        for (size_t j = 0; j < sizeof sweeps / sizeof *sweeps; j++) {
            double a0 = a0s[i], a1 = a0 + sweeps[j];
            int n = (int)ceil(sweeps[j] / (M_PI / 2) - 1e-9);
            /* Knots: parameter == angle at every segment end. */
            for (int k = 0; k <= n; k++) {
                double a = a0 + (a1 - a0) * k / n;
                assert_true(fabs(crisp_angle_to_param(a0, a1, a) - a) < 1e-14 * (1 + fabs(a)));
                assert_true(fabs(crisp_param_to_angle(a0, a1, a) - a) < 1e-14 * (1 + fabs(a)));
            }
            double prev = -INFINITY;
            for (int k = 0; k <= 1000; k++) {
                double a = a0 + (a1 - a0) * k / 1000.0;
                double t = crisp_angle_to_param(a0, a1, a);
                assert_true(t >= a0 - 1e-14 && t <= a1 + 1e-14);
                assert_true(t > prev); /* strictly increasing */
                prev = t;
                assert_true(fabs(crisp_param_to_angle(a0, a1, t) - a) < 1e-13);
                double tt = a0 + (a1 - a0) * (k + 0.37) / 1000.5;
                assert_true(fabs(crisp_angle_to_param(a0, a1, crisp_param_to_angle(a0, a1, tt)) -
                                 tt) < 1e-13);
            }
        }
}

/* A random right-handed placement. */
static crisp_placement random_placement(void)
{
    double o[3], ax[3], ref[3];
    for (int k = 0; k < 3; k++) {
        o[k] = rnd(-5, 5);
        ax[k] = rnd(-1, 1);
        ref[k] = rnd(-1, 1);
    }
    crisp_placement pl;
    assert_int_equal(crisp_placement_make(o, ax, ref, &pl), CRISP_OK);
    return pl;
}

static void test_placement(void **state)
{
    (void)state;
    for (int it = 0; it < 20; it++) {
        crisp_placement pl = random_placement();
        double c[3];
        crisp_vec3_cross(pl.x, pl.y, c);
        for (int k = 0; k < 3; k++)
            assert_true(fabs(c[k] - pl.z[k]) < 1e-14);
        assert_true(fabs(crisp_vec3_norm(pl.x) - 1) < 1e-14);
        assert_true(fabs(crisp_vec3_dot(pl.x, pl.y)) < 1e-14);
    }
    double o[3] = {0, 0, 0}, z[3] = {0, 0, 2}, zero[3] = {0, 0, 0}, par[3] = {0, 0, -1};
    crisp_placement pl;
    assert_int_equal(crisp_placement_make(o, z, NULL, &pl), CRISP_OK);
    assert_true(fabs(pl.z[2] - 1) < 1e-15 && fabs(crisp_vec3_dot(pl.x, pl.z)) < 1e-15);
    assert_int_equal(crisp_placement_make(o, zero, NULL, &pl), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_placement_make(o, z, par, &pl), CRISP_ERR_INVALID_ARG);
}

static void test_arcs_and_ellipses(void **state)
{
    (void)state;
    const double sweeps[] = {0.2, M_PI / 2, 2.0, M_PI, 4.0, 2 * M_PI};
    for (int it = 0; it < 24; it++) {
        crisp_placement pl = random_placement();
        double rx = rnd(0.1, 4), ry = (it % 2) ? rx : rnd(0.1, 4);
        double a0 = rnd(-3, 3), a1 = a0 + sweeps[it % 6];
        int dim = (it % 3 == 2) ? 2 : 3;
        crisp_curve *c;
        assert_int_equal(crisp_make_arc(dim, pl.origin, pl.x, pl.y, rx, ry, a0, a1, &c), CRISP_OK);
        double t0, t1;
        crisp_curve_domain(c, &t0, &t1);
        assert_true(t0 == a0 && t1 == a1);
        int n = (int)ceil(sweeps[it % 6] / (M_PI / 2) - 1e-9);
        assert_int_equal(c->count, 2 * n + 1);
        assert_int_equal(c->degree, 2);
        for (int k = 0; k <= 200; k++) {
            double a = a0 + (a1 - a0) * k / 200.0, p[3], q[3];
            crisp_curve_eval(c, crisp_angle_to_param(a0, a1, a), p);
            for (int m = 0; m < dim; m++)
                q[m] = pl.origin[m] + rx * cos(a) * pl.x[m] + ry * sin(a) * pl.y[m];
            for (int m = 0; m < dim; m++)
                assert_true(fabs(p[m] - q[m]) < EXACT * 10);
        }
        crisp_curve_destroy(c);
    }
    double c0[3] = {0, 0, 0}, x[3] = {1, 0, 0}, y[3] = {0, 1, 0};
    crisp_curve *c = NULL;
    assert_int_equal(crisp_make_arc(3, c0, x, y, 1, 1, 1, 1, &c), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_make_arc(3, c0, x, y, 1, 1, 0, 7, &c), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_make_arc(3, c0, x, y, -1, 1, 0, 1, &c), CRISP_ERR_INVALID_ARG);
    assert_null(c);
}

static void test_line(void **state)
{
    (void)state;
    double p0[3] = {1, 2, 3}, p1[3] = {-1, 0, 5}, p[3];
    crisp_curve *c;
    assert_int_equal(crisp_make_line(3, p0, p1, 2, 4, &c), CRISP_OK);
    crisp_curve_eval(c, 3, p);
    for (int k = 0; k < 3; k++)
        assert_true(fabs(p[k] - 0.5 * (p0[k] + p1[k])) < EXACT);
    crisp_curve_destroy(c);
    assert_int_equal(crisp_make_line(3, p0, p1, 4, 4, &c), CRISP_ERR_INVALID_ARG);
}

/* Conic arcs: through the end points and the shoulder point, on the implicit conic. */
static void check_conic(const double *p0, const double *t0, const double *p2, const double *t2,
                        const double *p, double (*implicit)(const double *))
{
    crisp_curve *c;
    assert_int_equal(crisp_make_conic_arc(2, p0, t0, p2, t2, p, &c), CRISP_OK);
    double q[2], best = INFINITY;
    crisp_curve_eval(c, 0, q);
    assert_true(fabs(q[0] - p0[0]) < EXACT && fabs(q[1] - p0[1]) < EXACT);
    crisp_curve_eval(c, 1, q);
    assert_true(fabs(q[0] - p2[0]) < EXACT && fabs(q[1] - p2[1]) < EXACT);
    for (int k = 0; k <= 2000; k++) {
        crisp_curve_eval(c, k / 2000.0, q);
        assert_true(fabs(implicit(q)) < 1e-11);
        double d = hypot(q[0] - p[0], q[1] - p[1]);
        if (d < best) best = d;
    }
    assert_true(best < 2e-3); /* the sample passes near p; exactly: */
    /* find the parameter by bisection on the distance's minimum (golden section) */
    double a = 0, b = 1;
    for (int it = 0; it < 200; it++) {
        double m1 = a + (b - a) * 0.381966, m2 = a + (b - a) * 0.618034, q1[2], q2[2];
        crisp_curve_eval(c, m1, q1);
        crisp_curve_eval(c, m2, q2);
        if (hypot(q1[0] - p[0], q1[1] - p[1]) < hypot(q2[0] - p[0], q2[1] - p[1]))
            b = m2;
        else
            a = m1;
    }
    crisp_curve_eval(c, 0.5 * (a + b), q);
    assert_true(hypot(q[0] - p[0], q[1] - p[1]) < 1e-9);
    crisp_curve_destroy(c);
}

static double parabola(const double *q)
{
    return q[1] - q[0] * q[0];
}
static double hyperbola(const double *q)
{
    return q[0] * q[1] - 1;
}
static double ellipse23(const double *q)
{
    return q[0] * q[0] / 4 + q[1] * q[1] / 9 - 1;
}

static void test_conic_arcs(void **state)
{
    (void)state;
    double p0[2] = {-1, 1}, t0[2] = {1, -2}, p2[2] = {2, 4}, t2[2] = {1, 4}, p[2] = {0.5, 0.25};
    check_conic(p0, t0, p2, t2, p, parabola);
    double h0[2] = {0.5, 2}, ht0[2] = {1, -4}, h2[2] = {4, 0.25}, ht2[2] = {1, -1.0 / 16},
           hp[2] = {1.5, 1 / 1.5};
    check_conic(h0, ht0, h2, ht2, hp, hyperbola);
    double e0[2] = {2 * cos(0.3), 3 * sin(0.3)}, et0[2] = {-2 * sin(0.3), 3 * cos(0.3)};
    double e2[2] = {2 * cos(2.0), 3 * sin(2.0)}, et2[2] = {-2 * sin(2.0), 3 * cos(2.0)};
    double ep[2] = {2 * cos(1.1), 3 * sin(1.1)};
    check_conic(e0, et0, e2, et2, ep, ellipse23);
    /* Parallel tangents: no single arc; a point off the tangent triangle: negative weight. */
    double par[2] = {1, -2};
    crisp_curve *c = NULL;
    assert_int_not_equal(crisp_make_conic_arc(2, p0, t0, p2, par, p, &c), CRISP_OK);
    double out[2] = {0.5, 10};
    assert_int_not_equal(crisp_make_conic_arc(2, p0, t0, p2, t2, out, &c), CRISP_OK);
    assert_null(c);
    assert_true(strlen(crisp_error_message()) > 0);
}

/* Analytic surfaces: S(angle_to_param(u), v) equals the formula. */
typedef void (*analytic_fn)(const crisp_placement *pl, const double *prm, double u, double v,
                            double *dest);

static void cyl_fn(const crisp_placement *pl, const double *prm, double u, double v, double *d)
{
    for (int k = 0; k < 3; k++)
        d[k] = pl->origin[k] + prm[0] * (cos(u) * pl->x[k] + sin(u) * pl->y[k]) + v * pl->z[k];
}
static void cone_fn(const crisp_placement *pl, const double *prm, double u, double v, double *d)
{
    double r = prm[0] + v * tan(prm[1]);
    for (int k = 0; k < 3; k++)
        d[k] = pl->origin[k] + r * (cos(u) * pl->x[k] + sin(u) * pl->y[k]) + v * pl->z[k];
}
static void sphere_fn(const crisp_placement *pl, const double *prm, double u, double v, double *d)
{
    for (int k = 0; k < 3; k++)
        d[k] = pl->origin[k] + prm[0] * cos(v) * (cos(u) * pl->x[k] + sin(u) * pl->y[k]) +
               prm[0] * sin(v) * pl->z[k];
}
static void torus_fn(const crisp_placement *pl, const double *prm, double u, double v, double *d)
{
    for (int k = 0; k < 3; k++)
        d[k] = pl->origin[k] +
               (prm[0] + prm[1] * cos(v)) * (cos(u) * pl->x[k] + sin(u) * pl->y[k]) +
               prm[1] * sin(v) * pl->z[k];
}

static void check_surface(const crisp_surface *s, const crisp_placement *pl, const double *prm,
                          analytic_fn fn, double a0, double a1, double v0, double v1, int v_angle)
{
    double dom[4];
    crisp_surface_domain(s, dom);
    assert_true(dom[0] == a0 && dom[1] == a1 && dom[2] == v0 && dom[3] == v1);
    double scale = 1 + fabs(pl->origin[0]) + fabs(pl->origin[1]) + fabs(pl->origin[2]) + prm[0];
    for (int j = 0; j <= 23; j++)
        for (int i = 0; i <= 29; i++) {
            double u = a0 + (a1 - a0) * i / 29.0, v = v0 + (v1 - v0) * j / 23.0, p[3], q[3];
            double tu = crisp_angle_to_param(a0, a1, u);
            double tv = v_angle ? crisp_angle_to_param(v0, v1, v) : v;
            crisp_surface_eval(s, tu, tv, p);
            fn(pl, prm, u, v, q);
            for (int k = 0; k < 3; k++)
                assert_true(fabs(p[k] - q[k]) < EXACT * scale);
        }
}

static void test_quadrics(void **state)
{
    (void)state;
    const double sweeps[] = {2 * M_PI, 1.0, M_PI, 5.0};
    for (int it = 0; it < 16; it++) {
        crisp_placement pl = random_placement();
        double a0 = rnd(-3, 3), a1 = a0 + sweeps[it % 4];
        double prm[2] = {rnd(0.5, 3), rnd(-1.2, 1.2)};
        crisp_surface *s;
        double v0 = rnd(-2, 0), v1 = v0 + rnd(0.5, 3);
        assert_int_equal(crisp_make_cylinder(&pl, prm[0], a0, a1, v0, v1, &s), CRISP_OK);
        check_surface(s, &pl, prm, cyl_fn, a0, a1, v0, v1, 0);
        crisp_surface_destroy(s);
        assert_int_equal(crisp_make_cone(&pl, prm[0], prm[1], a0, a1, v0, v1, &s), CRISP_OK);
        check_surface(s, &pl, prm, cone_fn, a0, a1, v0, v1, 0);
        crisp_surface_destroy(s);
        double lat0 = (it % 2) ? -M_PI / 2 : rnd(-1.5, 0), lat1 = (it % 2) ? M_PI / 2 : rnd(0, 1.5);
        assert_int_equal(crisp_make_sphere(&pl, prm[0], a0, a1, lat0, lat1, &s), CRISP_OK);
        check_surface(s, &pl, prm, sphere_fn, a0, a1, lat0, lat1, 1);
        crisp_surface_destroy(s);
        double tor[2] = {prm[0] + 1, rnd(0.2, 1.4)};
        double w0 = rnd(-3, 3), w1 = w0 + sweeps[(it + 1) % 4];
        assert_int_equal(crisp_make_torus(&pl, tor[0], tor[1], a0, a1, w0, w1, &s), CRISP_OK);
        check_surface(s, &pl, tor, torus_fn, a0, a1, w0, w1, 1);
        crisp_surface_destroy(s);
    }
    crisp_placement pl = random_placement();
    crisp_surface *s = NULL;
    assert_int_equal(crisp_make_sphere(&pl, 1, 0, 1, -2, 0, &s), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_make_cylinder(&pl, 0, 0, 1, 0, 1, &s), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_make_cone(&pl, 1, M_PI / 2, 0, 1, 0, 1, &s), CRISP_ERR_INVALID_ARG);
    assert_null(s);
}

static void test_plane(void **state)
{
    (void)state;
    crisp_placement pl = random_placement();
    crisp_surface *s;
    assert_int_equal(crisp_make_plane(&pl, -1, 2, 3, 5, &s), CRISP_OK);
    for (int i = 0; i < 50; i++) {
        double u = rnd(-1, 2), v = rnd(3, 5), p[3];
        crisp_surface_eval(s, u, v, p);
        for (int k = 0; k < 3; k++)
            assert_true(fabs(p[k] - (pl.origin[k] + u * pl.x[k] + v * pl.y[k])) < EXACT * 10);
    }
    crisp_surface_destroy(s);
}

/* Rotation of p about the axis (point, unit axis) by angle a (Rodrigues). */
static void rotate(const double *p, const double *point, const double *axis, double a, double *d)
{
    double r[3] = {p[0] - point[0], p[1] - point[1], p[2] - point[2]}, c[3];
    crisp_vec3_cross(axis, r, c);
    double dot = crisp_vec3_dot(axis, r);
    for (int k = 0; k < 3; k++)
        d[k] = point[k] + r[k] * cos(a) + c[k] * sin(a) + axis[k] * dot * (1 - cos(a));
}

static void test_revolution(void **state)
{
    (void)state;
    for (int it = 0; it < 8; it++) {
        crisp_curve *prof = random_curve(3, 1 + it % 4, 4 + it, it % 2);
        double point[3] = {rnd(-1, 1), rnd(-1, 1), rnd(-1, 1)}, ax[3] = {rnd(-1, 1), rnd(-1, 1), 1};
        double axis[3];
        crisp_vec3_normalize(ax, axis);
        double a0 = rnd(-2, 2), a1 = a0 + (it % 2 ? 2 * M_PI : rnd(0.3, 5));
        crisp_surface *s;
        assert_int_equal(crisp_make_revolution(prof, point, ax, a0, a1, &s), CRISP_OK);
        double t0, t1, dom[4];
        crisp_curve_domain(prof, &t0, &t1);
        crisp_surface_domain(s, dom);
        assert_true(dom[0] == t0 && dom[1] == t1 && dom[2] == a0 && dom[3] == a1);
        for (int k = 0; k < 300; k++) {
            double t = rnd(t0, t1), a = rnd(a0, a1), c[3], q[3], p[3];
            crisp_curve_eval(prof, t, c);
            rotate(c, point, axis, a, q);
            crisp_surface_eval(s, t, crisp_angle_to_param(a0, a1, a), p);
            for (int m = 0; m < 3; m++)
                assert_true(fabs(p[m] - q[m]) < 1e-11);
        }
        crisp_surface_destroy(s);
        crisp_curve_destroy(prof);
    }
}

static void test_extrusion(void **state)
{
    (void)state;
    for (int it = 0; it < 6; it++) {
        crisp_curve *c = random_curve(it % 2 ? 3 : 2, 1 + it % 3, 5, it % 2);
        double dir[3] = {rnd(-1, 1), rnd(-1, 1), rnd(-1, 1)}, t0, t1;
        crisp_surface *s;
        assert_int_equal(crisp_make_extrusion(c, dir, -1, 2, &s), CRISP_OK);
        crisp_curve_domain(c, &t0, &t1);
        for (int k = 0; k < 200; k++) {
            double t = rnd(t0, t1), v = rnd(-1, 2), q[3] = {0, 0, 0}, p[3];
            crisp_curve_eval(c, t, q);
            crisp_surface_eval(s, t, v, p);
            for (int m = 0; m < 3; m++)
                assert_true(fabs(p[m] - (q[m] + v * dir[m])) < 1e-12);
        }
        crisp_surface_destroy(s);
        crisp_curve_destroy(c);
    }
}

static void test_ruled(void **state)
{
    (void)state;
    for (int it = 0; it < 12; it++) {
        int r0 = it % 2, r1 = (it / 2) % 2;
        crisp_curve *c0 = random_curve(3, 1 + it % 3, 4 + it % 5, r0);
        crisp_curve *c1 = random_curve(3, 1 + (it / 3) % 4, 4 + (it * 7) % 6, r1);
        crisp_surface *s;
        assert_int_equal(crisp_make_ruled(c0, c1, &s), CRISP_OK);
        double a0, a1, b0, b1, dom[4];
        crisp_curve_domain(c0, &a0, &a1);
        crisp_curve_domain(c1, &b0, &b1);
        crisp_surface_domain(s, dom);
        assert_true(dom[0] == 0 && dom[1] == 1 && dom[2] == 0 && dom[3] == 1);
        for (int k = 0; k < 300; k++) {
            double u = k < 2 ? k : rnd(0, 1), v = rnd(0, 1), p0[3], p1[3], p[3];
            crisp_curve_eval(c0, a0 + u * (a1 - a0), p0);
            crisp_curve_eval(c1, b0 + u * (b1 - b0), p1);
            crisp_surface_eval(s, u, v, p);
            for (int m = 0; m < 3; m++)
                assert_true(fabs(p[m] - ((1 - v) * p0[m] + v * p1[m])) < 1e-11);
        }
        crisp_surface_destroy(s);
        crisp_curve_destroy(c0);
        crisp_curve_destroy(c1);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_angle_param_inverse),
        cmocka_unit_test(test_placement),
        cmocka_unit_test(test_arcs_and_ellipses),
        cmocka_unit_test(test_line),
        cmocka_unit_test(test_conic_arcs),
        cmocka_unit_test(test_quadrics),
        cmocka_unit_test(test_plane),
        cmocka_unit_test(test_revolution),
        cmocka_unit_test(test_extrusion),
        cmocka_unit_test(test_ruled),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
