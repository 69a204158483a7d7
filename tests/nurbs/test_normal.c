/* crisp_bezier_patch_normal / crisp_surface_normal (issue 13): unit normals everywhere, also at
 * singular points: a cone's apex (each generator keeps its own normal), a sphere's poles (the
 * axis), a torus's regular points (equal to the plain cross product), a cone whose apex points
 * coincide only to a file's rounding, a regular point of a stretched patch, and nothing (0) on a
 * patch collapsed to a segment or a point. Surfaces from crisp_make_cone / _sphere / _torus and
 * their Bézier patches; expected normals are analytic. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/construct.h"
#include "crisp/nurbs.h"
#include "nurbs/nurbs_internal.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static crisp_placement world(void)
{
    crisp_placement pl;
    const double o[3] = {0, 0, 0}, z[3] = {0, 0, 1}, x[3] = {1, 0, 0};
    assert_int_equal(crisp_placement_make(o, z, x, &pl), CRISP_OK);
    return pl;
}

/* Cone r = 1 at v = 0, semi-angle 30 degrees, v from -r/tan(semi) (the apex) to 0. Its outward
 * normal at angle u: (cos u cos a, sin u cos a, -sin a) (S_u x S_v for this parametrisation). */
static void test_cone_apex(void **state)
{
    (void)state;
    crisp_placement pl = world();
    double a = M_PI / 6, apex = -1 / tan(a);
    crisp_surface *s;
    assert_int_equal(crisp_make_cone(&pl, 1, a, 0, 2 * M_PI, apex, 0, &s), CRISP_OK);
    double dom[4];
    crisp_surface_domain(s, dom);
    /* the sign of S_u x S_v at a regular point fixes the orientation to compare with */
    double ref[3];
    assert_int_equal(crisp_surface_normal(s, 0.3, 0.5 * (dom[2] + dom[3]), ref), 1);
    for (int i = 0; i <= 16; i++) {
        double u = dom[0] + (dom[1] - dom[0]) * i / 16, n[3], p[3], q[3];
        /* the apex end of the generator through u, and a point in its middle: equal normals */
        assert_int_equal(crisp_surface_normal(s, u, dom[2], n), 1);
        assert_int_equal(crisp_surface_normal(s, u, 0.5 * (dom[2] + dom[3]), q), 1);
        assert_true(fabs(dot3(n, n) - 1) < 1e-12);
        assert_true(dot3(n, q) > 1 - 1e-9);
        /* and the analytic normal of that generator (its angle from the surface point) */
        crisp_surface_eval(s, u, dom[3], p);
        double ang = atan2(p[1], p[0]), want[3] = {cos(ang) * cos(a), sin(ang) * cos(a), -sin(a)};
        double sg =
            dot3(ref, (double[3]){cos(0.3) * cos(a), sin(0.3) * cos(a), -sin(a)}) > 0 ? 1 : -1;
        for (int k = 0; k < 3; k++)
            want[k] *= sg;
        assert_true(dot3(n, want) > 1 - 1e-9);
    }
    /* The plain cross product at the apex is (numerically) zero: what the old shading had. */
    double su[3], sv[3];
    crisp_surface_derivs(s, dom[0] + 0.1, dom[2], NULL, su, sv, NULL, NULL, NULL);
    assert_true(sqrt(dot3(su, su)) < 1e-12);
    /* The same through the Bézier patches the renderer draws. */
    crisp_bezier_patches bz;
    assert_int_equal(crisp_surface_to_bezier(s, &bz), CRISP_OK);
    for (int k = 0; k < bz.count; k++) {
        const crisp_bezier_patch *bp = &bz.patches[k];
        for (int i = 0; i <= 8; i++) {
            double sl = i / 8.0, n[3], q[3];
            /* the apex is at local t = 0 (v = dom[2]) */
            assert_int_equal(crisp_bezier_patch_normal(bp, sl, 0, n), 1);
            assert_int_equal(crisp_bezier_patch_normal(bp, sl, 0.5, q), 1);
            assert_true(dot3(n, q) > 1 - 1e-9);
        }
    }
    crisp_bezier_patches_free(&bz);
    crisp_surface_destroy(s);
}

/* Sphere: at both poles the normal is the axis (outward: +z at the north pole), whatever u. */
static void test_sphere_poles(void **state)
{
    (void)state;
    crisp_placement pl = world();
    crisp_surface *s;
    assert_int_equal(crisp_make_sphere(&pl, 2, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &s), CRISP_OK);
    double dom[4];
    crisp_surface_domain(s, dom);
    double ref[3], p[3];
    assert_int_equal(crisp_surface_normal(s, 0.4, 0.2, ref), 1);
    crisp_surface_eval(s, 0.4, 0.2, p);
    double sg = dot3(ref, p) > 0 ? 1 : -1; /* S_u x S_v outward or inward */
    for (int i = 0; i <= 12; i++) {
        double u = dom[0] + (dom[1] - dom[0]) * i / 12, n[3];
        assert_int_equal(crisp_surface_normal(s, u, dom[3], n), 1);
        assert_true(sg * n[2] > 1 - 1e-6);
        assert_int_equal(crisp_surface_normal(s, u, dom[2], n), 1);
        assert_true(-sg * n[2] > 1 - 1e-6);
    }
    crisp_surface_destroy(s);
}

/* Regular points: exactly the normalised cross product. */
static void test_regular_points(void **state)
{
    (void)state;
    crisp_placement pl = world();
    crisp_surface *s;
    assert_int_equal(crisp_make_torus(&pl, 3, 1, 0, 2 * M_PI, 0, 2 * M_PI, &s), CRISP_OK);
    for (int i = 0; i < 50; i++) {
        double u = 0.1 + 0.12 * i, v = 0.05 + 0.123 * i, su[3], sv[3], c[3], n[3];
        crisp_surface_derivs(s, u, v, NULL, su, sv, NULL, NULL, NULL);
        c[0] = su[1] * sv[2] - su[2] * sv[1];
        c[1] = su[2] * sv[0] - su[0] * sv[2];
        c[2] = su[0] * sv[1] - su[1] * sv[0];
        double l = sqrt(dot3(c, c));
        assert_int_equal(crisp_surface_normal(s, u, v, n), 1);
        for (int k = 0; k < 3; k++)
            assert_true(fabs(n[k] - c[k] / l) < 1e-14);
    }
    crisp_surface_destroy(s);
}

/* A cone whose apex control points coincide only to 1e-8 .. 1e-6 (a written file's rounding):
 * the cross product at the apex is regular but made of that noise; the normal there is still
 * each generator's (within 1.5 degrees: the limit is taken where the noise is 1/100 of the
 * partial), on the surface and on its Bézier patches. */
static void test_rounded_apex(void **state)
{
    (void)state;
    crisp_placement pl = world();
    double a = M_PI / 6, apex = -1 / tan(a);
    for (double noise = 1e-8; noise < 2e-6; noise *= 10) {
        crisp_surface *s;
        assert_int_equal(crisp_make_cone(&pl, 1, a, 0, 2 * M_PI, apex, 0, &s), CRISP_OK);
        unsigned seed = 5;
        for (int i = 0; i < s->count_u; i++) /* row v = v0: the apex */
            for (int k = 0; k < 3; k++) {
                seed = seed * 1103515245u + 12345u;
                s->cpw[4 * i + k] +=
                    noise * s->cpw[4 * i + 3] * (((seed >> 8) & 0xffff) / 32768.0 - 1);
            }
        double dom[4];
        crisp_surface_domain(s, dom);
        double worst = 1;
        for (int i = 0; i <= 16; i++) {
            double u = dom[0] + (dom[1] - dom[0]) * (i + 0.25) / 17, n[3], q[3];
            assert_int_equal(crisp_surface_normal(s, u, dom[2], n), 1);
            assert_int_equal(crisp_surface_normal(s, u, 0.5 * (dom[2] + dom[3]), q), 1);
            worst = fmin(worst, dot3(n, q));
        }
        crisp_bezier_patches bz;
        assert_int_equal(crisp_surface_to_bezier(s, &bz), CRISP_OK);
        for (int k = 0; k < bz.count; k++)
            for (int i = 0; i <= 8; i++) {
                double n[3], q[3];
                assert_int_equal(crisp_bezier_patch_normal(&bz.patches[k], i / 8.0, 0, n), 1);
                assert_int_equal(crisp_bezier_patch_normal(&bz.patches[k], i / 8.0, 0.5, q), 1);
                worst = fmin(worst, dot3(n, q));
            }
        printf("apex points %g apart: largest angle to the generator's normal %.3g deg\n", noise,
               acos(fmin(1, worst)) * 180 / M_PI);
        assert_true(worst > cos(1.5 * M_PI / 180));
        crisp_bezier_patches_free(&bz);
        crisp_surface_destroy(s);
    }
}

/* A regular point of a patch stretched 1e6 : 1 (its quality is below CRISP_NORMAL_TAU there and
 * everywhere near it): the plain normalised cross product, not 0. */
static void test_stretched_patch(void **state)
{
    (void)state;
    double cpw[2 * 2 * 4] = {0, 0, 0, 1, 1e6, 0, 0, 1, 0, 1, 0, 1, 1e6, 1, 0.3, 1};
    crisp_bezier_patch p = {
        .du = 1, .dv = 1, .rational = 0, .u0 = 0, .u1 = 1, .v0 = 0, .v1 = 1, .cpw = cpw};
    double P[3], Ps[3], Pt[3], c[3], n[3];
    crisp_bezier_patch_derivs(&p, 0.3, 0.6, P, Ps, Pt);
    c[0] = Ps[1] * Pt[2] - Ps[2] * Pt[1];
    c[1] = Ps[2] * Pt[0] - Ps[0] * Pt[2];
    c[2] = Ps[0] * Pt[1] - Ps[1] * Pt[0];
    double l = sqrt(dot3(c, c));
    assert_int_equal(crisp_bezier_patch_normal(&p, 0.3, 0.6, n), 1);
    for (int k = 0; k < 3; k++)
        assert_true(fabs(n[k] - c[k] / l) < 1e-12);
}

/* A patch collapsed to a segment (its two rows 1e-18 apart: rounding) has no normal either:
 * 0, not the direction of that rounding. */
static void test_curve_patch(void **state)
{
    (void)state;
    double cpw[2 * 2 * 4] = {0, 0, 0, 1, 1, 0, 0, 1, 0, 1e-18, 0, 1, 1, 1e-18, 0, 1};
    crisp_bezier_patch p = {
        .du = 1, .dv = 1, .rational = 0, .u0 = 0, .u1 = 1, .v0 = 0, .v1 = 1, .cpw = cpw};
    double n[3] = {7, 7, 7};
    assert_int_equal(crisp_bezier_patch_normal(&p, 0.4, 0.3, n), 0);
    assert_true(n[0] == 0 && n[1] == 0 && n[2] == 0);
}

/* A patch that is one point has no normal: 0 and a zero vector, no NaN. */
static void test_point_patch(void **state)
{
    (void)state;
    double cpw[3 * 3 * 4];
    for (int i = 0; i < 9; i++)
        cpw[4 * i] = 1, cpw[4 * i + 1] = 2, cpw[4 * i + 2] = 3, cpw[4 * i + 3] = 1;
    crisp_bezier_patch p = {
        .du = 2, .dv = 2, .rational = 0, .u0 = 0, .u1 = 1, .v0 = 0, .v1 = 1, .cpw = cpw};
    double n[3] = {7, 7, 7};
    assert_int_equal(crisp_bezier_patch_normal(&p, 0.5, 0.5, n), 0);
    assert_true(n[0] == 0 && n[1] == 0 && n[2] == 0);
}

/* crisp__surface_normals (the splat builder's normals, nurbs_internal.h) against
 * crisp_surface_normal, bit for bit: random B-spline surfaces (degrees 1..15, clamped and
 * unclamped knot vectors with repeated knots, rational and not, some with a collapsed side so
 * that the robust path runs), at parameters visited as the builder does (grids column by column:
 * the basis cache's hits), at random points, at knots, outside the domain (clamped) and at more
 * distinct values than the cache holds; both the AVX and the scalar sums. */
static uint64_t rng_state = 0x243F6A8885A308D3ull;

static double rnd(void) /* [0, 1) */
{
    rng_state ^= rng_state << 13, rng_state ^= rng_state >> 7, rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) * 0x1p-53;
}

static crisp_surface *random_surface(int collapse)
{
    for (;;) {
        int deg[2], cnt[2];
        double *kn[2];
        for (int d = 0; d < 2; d++) {
            deg[d] = rnd() < 0.1 ? 7 + (int)(rnd() * 9) : 1 + (int)(rnd() * 5);
            cnt[d] = deg[d] + 1 + (int)(rnd() * 6);
            int n = cnt[d] + deg[d] + 1, clamped = rnd() < 0.6;
            kn[d] = malloc((size_t)n * sizeof(double));
            double t = rnd() * 4 - 2;
            for (int i = 0; i < n; i++) {
                if (!(clamped && (i <= deg[d] || i >= cnt[d])) && !(i && rnd() < 0.25))
                    t += 0.05 + rnd();
                kn[d][i] = t;
            }
            if (clamped) /* the ends: degree + 1 equal knots */
                for (int i = cnt[d]; i < n; i++)
                    kn[d][i] = kn[d][cnt[d]];
        }
        int np = cnt[0] * cnt[1], rational = rnd() < 0.6;
        double *pts = malloc((size_t)np * 3 * sizeof(double)),
               *w = malloc((size_t)np * sizeof(double));
        for (int i = 0; i < np; i++) {
            for (int k = 0; k < 3; k++)
                pts[3 * i + k] = collapse && i < cnt[0] ? 0.25 : 2 * rnd() - 1;
            w[i] = 0.3 + 2.7 * rnd();
        }
        crisp_surface *s = NULL;
        crisp_status st = crisp_surface_create(deg[0], deg[1], cnt[0], cnt[1], kn[0], kn[1], pts,
                                               rational ? w : NULL, &s);
        free(kn[0]), free(kn[1]), free(pts), free(w);
        if (!st) return s;
    }
}

static void expect_same(crisp__surface_normals *c, double u, double v, long *fast)
{
    double a[3] = {7, 7, 7}, b[3] = {8, 8, 8};
    int ra = crisp_surface_normal(c->s, u, v, a), rb = crisp__surface_normals_at(c, u, v, b);
    if (ra != rb || memcmp(a, b, sizeof a)) {
        printf("u %.17g v %.17g: %d (%.17g %.17g %.17g) vs %d (%.17g %.17g %.17g)\n", u, v, ra,
               a[0], a[1], a[2], rb, b[0], b[1], b[2]);
        fail();
    }
    *fast += ra;
}

static void test_many_normals(void **state)
{
    (void)state;
    long checked = 0, fast = 0;
    for (int si = 0; si < 400; si++) {
        crisp_surface *s = random_surface(si % 8 == 7);
        double dom[4];
        crisp_surface_domain(s, dom);
        for (int avx = 0; avx < 2; avx++) {
            crisp__surface_normals c;
            assert_int_equal(crisp__surface_normals_init(&c, s), CRISP_OK);
            if (!avx) c.avx = 0;
            double du = dom[1] - dom[0], dv = dom[3] - dom[2];
            /* grids of cells' centres, column by column, last column first (the builder's
             * stack) */
            for (int g = 0; g < 3; g++) {
                int nu = 1 + (int)(rnd() * 70), nv = 1 + (int)(rnd() * 70);
                double s0 = rnd() * 0.5, s1 = s0 + rnd() * 0.5;
                for (int i = nu - 1; i >= 0; i--)
                    for (int j = nv - 1; j >= 0; j--) {
                        double a0 = s0 + (s1 - s0) * i / nu, a1 = s0 + (s1 - s0) * (i + 1) / nu;
                        double b0 = (double)j / nv, b1 = (double)(j + 1) / nv;
                        expect_same(&c, dom[0] + 0.5 * (a0 + a1) * du,
                                    dom[2] + 0.5 * (b0 + b1) * dv, &fast);
                        checked++;
                    }
            }
            /* random points, the domain's corners and sides, beyond it, the knots */
            for (int k = 0; k < 300; k++) {
                double u = dom[0] + (rnd() * 1.2 - 0.1) * du, v = dom[2] + (rnd() * 1.2 - 0.1) * dv;
                if (k % 5 == 1) u = dom[rnd() < 0.5 ? 0 : 1];
                if (k % 5 == 2) v = dom[rnd() < 0.5 ? 2 : 3];
                if (k % 5 == 3) u = s->knots_u[(int)(rnd() * (s->count_u + s->degree_u + 1))];
                if (k % 5 == 4) v = s->knots_v[(int)(rnd() * (s->count_v + s->degree_v + 1))];
                expect_same(&c, u, v, &fast);
                checked++;
            }
            crisp__surface_normals_free(&c);
        }
        crisp_surface_destroy(s);
    }
    /* surfaces with poles and an apex (rational, the robust path at their sides) */
    crisp_placement pl = world();
    crisp_surface *sph, *cone;
    assert_int_equal(crisp_make_sphere(&pl, 2, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sph), CRISP_OK);
    assert_int_equal(crisp_make_cone(&pl, 1, M_PI / 6, 0, 2 * M_PI, -1 / tan(M_PI / 6), 0, &cone),
                     CRISP_OK);
    crisp_surface *both[2] = {sph, cone};
    for (int k = 0; k < 2; k++) {
        crisp__surface_normals c;
        assert_int_equal(crisp__surface_normals_init(&c, both[k]), CRISP_OK);
        double dom[4];
        crisp_surface_domain(both[k], dom);
        for (int i = 0; i <= 40; i++)
            for (int j = 0; j <= 40; j++) {
                expect_same(&c, dom[0] + (dom[1] - dom[0]) * i / 40,
                            dom[2] + (dom[3] - dom[2]) * j / 40, &fast);
                checked++;
            }
        crisp__surface_normals_free(&c);
        crisp_surface_destroy(both[k]);
    }
    printf("many normals: %ld points, %ld with a normal\n", checked, fast);
    assert_true(fast > checked / 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cone_apex),       cmocka_unit_test(test_sphere_poles),
        cmocka_unit_test(test_regular_points),  cmocka_unit_test(test_rounded_apex),
        cmocka_unit_test(test_stretched_patch), cmocka_unit_test(test_curve_patch),
        cmocka_unit_test(test_point_patch),     cmocka_unit_test(test_many_normals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
