/* Tests for Bézier pieces and patches (src/nurbs/bezier.c) and for curve reversal, trimming and
 * control boxes (src/nurbs/curve.c, surface.c): split halves reproduce the piece, boxes contain
 * dense samples, Bézier derivatives agree with the B-spline derivatives (chain rule), reversed
 * and trimmed curves reproduce the curve.
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
#include "nurbs/nurbs_internal.h"
#include "nurbs/test_util.h"

static int inside_box(const double *p, const double *box, int dim, double tol)
{
    for (int d = 0; d < dim; d++)
        if (p[d] < box[d] - tol || p[d] > box[dim + d] + tol) return 0;
    return 1;
}

static void test_bezier_curve_split_bbox_derivs(void **state)
{
    (void)state;
    rng_seed(101);
    for (int it = 0; it < 200; it++) {
        int degree = rng_int(1, 15), dim = rng_int(2, 3);
        crisp_curve *c = random_curve(dim, degree, degree + 1 + rng_int(0, 8), it % 2, it % 3 != 0);
        assert_non_null(c);
        crisp_bezier_curve *b;
        int n;
        assert_int_equal(crisp_curve_to_bezier(c, &b, &n), CRISP_OK);
        for (int k = 0; k < n; k++) {
            const crisp_bezier_curve *piece = &b[k];
            double t = 0.05 + 0.9 * rng_uniform();
            crisp_bezier_curve lo, hi;
            crisp_bezier_curve_split(piece, t, &lo, &hi);
            assert_true(lo.t0 == piece->t0 && hi.t1 == piece->t1 && lo.t1 == hi.t0);
            assert_true(fabs(lo.t1 - (piece->t0 + t * (piece->t1 - piece->t0))) < 1e-14);
            double box[6], lbox[6], hbox[6];
            crisp_bezier_curve_bbox(piece, box);
            crisp_bezier_curve_bbox(&lo, lbox);
            crisp_bezier_curve_bbox(&hi, hbox);
            for (int i = 0; i <= 20; i++) {
                double s = i / 20.0, p[3], q[3], r[3];
                crisp_bezier_curve_eval(piece, s * t, p);
                crisp_bezier_curve_eval(&lo, s, q);
                assert_true(dist_n(p, q, dim) < 1e-12 * (1 + fabs(p[0]) + fabs(p[1])));
                crisp_bezier_curve_eval(piece, t + s * (1 - t), p);
                crisp_bezier_curve_eval(&hi, s, r);
                assert_true(dist_n(p, r, dim) < 1e-12 * (1 + fabs(p[0]) + fabs(p[1])));
                assert_true(inside_box(p, box, dim, 1e-12));
                assert_true(inside_box(q, lbox, dim, 1e-12));
                assert_true(inside_box(r, hbox, dim, 1e-12));
            }
            /* derivatives in local t are the B-spline derivatives times the span length */
            double s = rng_uniform(), len = piece->t1 - piece->t0;
            double bd[9], cd[9];
            crisp_bezier_curve_derivs(piece, s, 2, bd);
            crisp_curve_derivs(c, piece->t0 + s * len, 2, cd);
            for (int d = 0; d < dim; d++) {
                double m1 = 1 + fabs(cd[dim + d]) * len, m2 = 1 + fabs(cd[2 * dim + d]) * len * len;
                assert_true(fabs(bd[d] - cd[d]) < 1e-11 * (1 + fabs(cd[d])));
                assert_true(fabs(bd[dim + d] - cd[dim + d] * len) < 1e-9 * m1);
                assert_true(fabs(bd[2 * dim + d] - cd[2 * dim + d] * len * len) < 1e-8 * m2);
            }
        }
        double cbox[6], t0, t1, p[3];
        crisp_curve_bbox(c, cbox);
        crisp_curve_domain(c, &t0, &t1);
        for (int i = 0; i <= 200; i++) {
            crisp_curve_eval(c, t0 + (t1 - t0) * i / 200.0, p);
            assert_true(inside_box(p, cbox, dim, 1e-12));
        }
        crisp_free(b);
        crisp_curve_destroy(c);
    }
}

static void test_bezier_patch_split_bbox_derivs(void **state)
{
    (void)state;
    rng_seed(103);
    for (int it = 0; it < 60; it++) {
        int du = rng_int(1, 15), dv = rng_int(1, 15);
        crisp_surface *s = random_surface(du, dv, du + 1 + rng_int(0, 3), dv + 1 + rng_int(0, 3),
                                          it % 2, it % 3 != 0);
        assert_non_null(s);
        crisp_bezier_patches bp;
        assert_int_equal(crisp_surface_to_bezier(s, &bp), CRISP_OK);
        double sbox[6];
        crisp_surface_bbox(s, sbox);
        const crisp_bezier_patch *p = &bp.patches[rng_int(0, bp.count - 1)];
        size_t nd = (size_t)(du + 1) * (dv + 1) * 4;
        double *store = malloc(4 * nd * sizeof *store);
        crisp_bezier_patch lo = {.cpw = store}, hi = {.cpw = store + nd};
        crisp_bezier_patch lo2 = {.cpw = store + 2 * nd}, hi2 = {.cpw = store + 3 * nd};
        double a = 0.1 + 0.8 * rng_uniform(), b = 0.1 + 0.8 * rng_uniform();
        crisp_bezier_patch_split_u(p, a, &lo, &hi);
        assert_ptr_equal(lo.cpw, store);
        assert_true(lo.u0 == p->u0 && hi.u1 == p->u1 && lo.u1 == hi.u0 && lo.v0 == p->v0);
        crisp_bezier_patch_split_v(&hi, b, &lo2, &hi2);
        assert_true(lo2.v0 == p->v0 && hi2.v1 == p->v1 && lo2.v1 == hi2.v0 && hi2.u0 == hi.u0);
        double box[6], b1[6], b2[6];
        crisp_bezier_patch_bbox(p, box);
        crisp_bezier_patch_bbox(&lo, b1);
        crisp_bezier_patch_bbox(&hi2, b2);
        double len_u = p->u1 - p->u0, len_v = p->v1 - p->v0;
        for (int i = 0; i < 50; i++) {
            double x = rng_uniform(), y = rng_uniform(), q[3], r[3];
            crisp_bezier_patch_eval(p, x * a, y, q);
            crisp_bezier_patch_eval(&lo, x, y, r);
            assert_true(dist_n(q, r, 3) < 1e-12 * 4);
            assert_true(inside_box(r, b1, 3, 1e-12));
            assert_true(inside_box(q, box, 3, 1e-12));
            assert_true(inside_box(q, sbox, 3, 1e-12));
            crisp_bezier_patch_eval(p, a + x * (1 - a), b + y * (1 - b), q);
            crisp_bezier_patch_eval(&hi2, x, y, r);
            assert_true(dist_n(q, r, 3) < 1e-12 * 4);
            assert_true(inside_box(r, b2, 3, 1e-12));
            /* patch derivatives in local (s, t) = surface partials times the span lengths */
            double pt[3], ds[3], dt[3], sp[3], su[3], sv[3];
            crisp_bezier_patch_derivs(p, x, y, pt, ds, dt);
            crisp_surface_derivs(s, p->u0 + x * len_u, p->v0 + y * len_v, sp, su, sv, NULL, NULL,
                                 NULL);
            for (int d = 0; d < 3; d++) {
                assert_true(fabs(pt[d] - sp[d]) < 1e-11 * 4);
                assert_true(fabs(ds[d] - su[d] * len_u) < 1e-9 * (1 + fabs(su[d] * len_u)));
                assert_true(fabs(dt[d] - sv[d] * len_v) < 1e-9 * (1 + fabs(sv[d] * len_v)));
            }
        }
        /* splitting in place (halves over the source storage) is allowed */
        memcpy(store, p->cpw, nd * sizeof *store);
        crisp_bezier_patch self = *p;
        self.cpw = store;
        crisp_bezier_patch other = {.cpw = store + nd};
        crisp_bezier_patch_split_v(&self, 0.5, &self, &other);
        double q[3], r[3];
        crisp_bezier_patch_eval(p, 0.3, 0.25, q);
        crisp_bezier_patch_eval(&self, 0.3, 0.5, r);
        assert_true(dist_n(q, r, 3) < 1e-12 * 4);
        free(store);
        crisp_bezier_patches_free(&bp);
        crisp_surface_destroy(s);
    }
}

static void test_curve_reverse_trim(void **state)
{
    (void)state;
    rng_seed(107);
    for (int it = 0; it < 300; it++) {
        int degree = rng_int(1, 15), dim = rng_int(2, 3);
        crisp_curve *c =
            random_curve(dim, degree, degree + 1 + rng_int(0, 10), it % 2, it % 3 != 0);
        assert_non_null(c);
        double t0, t1;
        crisp_curve_domain(c, &t0, &t1);
        double sc = 1.0;
        for (int i = 0; i < c->count * (dim + 1); i++)
            sc = fmax(sc, fabs(c->cpw[i]) * 4);

        crisp_curve *r;
        assert_int_equal(crisp_curve_copy(c, &r), CRISP_OK);
        crisp_curve_reverse(r);
        double r0, r1;
        crisp_curve_domain(r, &r0, &r1);
        assert_true(r0 == t0 && r1 == t1);
        for (int i = 1; i < r->count + degree + 1; i++)
            assert_true(r->knots[i] >= r->knots[i - 1]);
        for (int i = 0; i <= 50; i++) {
            double t = t0 + (t1 - t0) * i / 50.0, p[3], q[3];
            crisp_curve_eval(c, t, p);
            crisp_curve_eval(r, t0 + t1 - t, q);
            assert_true(dist_n(p, q, dim) < 1e-12 * sc);
        }
        crisp_curve_reverse(r);
        for (int i = 0; i < c->count * (dim + 1); i++)
            assert_true(fabs(r->cpw[i] - c->cpw[i]) == 0.0);
        crisp_curve_destroy(r);

        /* trimmed sub-curve: clamped, same points on its interval */
        double a = t0 + (t1 - t0) * 0.4 * rng_uniform(), b = t1 - (t1 - t0) * 0.4 * rng_uniform();
        if (it % 5 == 0) a = t0;
        if (it % 7 == 0) b = t1;
        if (it % 11 == 0 && c->count > degree + 1) a = c->knots[degree + 1];
        if (!(a < b)) a = t0;
        crisp_curve *tr;
        assert_int_equal(crisp_curve_trim(c, a, b, &tr), CRISP_OK);
        double u0, u1;
        crisp_curve_domain(tr, &u0, &u1);
        assert_true(u0 == a && u1 == b);
        for (int i = 0; i <= degree; i++) {
            assert_true(tr->knots[i] == a);
            assert_true(tr->knots[tr->count + i] == b);
        }
        for (int i = 0; i <= 50; i++) {
            double t = a + (b - a) * i / 50.0, p[3], q[3];
            crisp_curve_eval(c, t, p);
            crisp_curve_eval(tr, t, q);
            assert_true(dist_n(p, q, dim) < 1e-12 * sc);
        }
        /* the end control points are the curve's end points */
        double pa[3], pb[3];
        crisp_curve_eval(c, a, pa);
        crisp_curve_eval(c, b, pb);
        const double *e0 = tr->cpw, *e1 = tr->cpw + (size_t)(tr->count - 1) * (dim + 1);
        for (int d = 0; d < dim; d++) {
            assert_true(fabs(e0[d] / e0[dim] - pa[d]) < 1e-12 * sc);
            assert_true(fabs(e1[d] / e1[dim] - pb[d]) < 1e-12 * sc);
        }
        crisp_curve *bad;
        assert_int_equal(crisp_curve_trim(c, b, a, &bad), CRISP_ERR_INVALID_ARG);
        assert_null(bad);
        assert_int_equal(crisp_curve_trim(c, t0 - 1.0, b, &bad), CRISP_ERR_INVALID_ARG);
        crisp_curve_destroy(tr);
        crisp_curve_destroy(c);
    }
}

/* crisp__bezier_patch_eval_rows_s + _eval_rows (the splat builder's cells of a column) against
 * crisp_bezier_patch_eval, bit for bit: random rational and polynomial patches of degrees 1..15,
 * several t per s, parameters inside [0, 1], at its ends and beyond. */
static void test_patch_eval_rows(void **state)
{
    (void)state;
    uint64_t x = 0x9E3779B97F4A7C15ull;
    double cpw[(CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1) * 4],
        rows[(CRISP_MAX_DEGREE + 1) * 4];
    long checked = 0;
    for (int k = 0; k < 3000; k++) {
        double r[64];
        for (int q = 0; q < 64; q++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            r[q] = (double)(x >> 11) * 0x1p-53;
        }
        int du = 1 + (int)(r[0] * 15), dv = 1 + (int)(r[1] * 15), rational = r[2] < 0.6;
        if (k % 3) du = 1 + (int)(r[0] * 5), dv = 1 + (int)(r[1] * 5);
        crisp_bezier_patch p = {.du = du,
                                .dv = dv,
                                .rational = rational,
                                .u0 = 0,
                                .u1 = 1,
                                .v0 = 0,
                                .v1 = 1,
                                .cpw = cpw};
        for (int i = 0; i < (du + 1) * (dv + 1); i++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            double w = rational ? 0.3 + 2.7 * (double)(x >> 11) * 0x1p-53 : 1.0;
            for (int c = 0; c < 3; c++) {
                x ^= x << 13, x ^= x >> 7, x ^= x << 17;
                cpw[4 * i + c] = w * (4 * (double)(x >> 11) * 0x1p-53 - 2);
            }
            cpw[4 * i + 3] = w;
        }
        double s = k % 7 == 0 ? 0.0 : k % 7 == 1 ? 1.0 : 1.2 * r[3] - 0.1;
        crisp__bezier_patch_eval_rows_s(&p, s, rows);
        for (int j = 0; j < 20; j++) {
            double t = j == 0 ? 0.0 : j == 1 ? 1.0 : 1.2 * r[4 + j] - 0.1, a[3], b[3];
            crisp_bezier_patch_eval(&p, s, t, a);
            crisp__bezier_patch_eval_rows(&p, rows, t, b);
            assert_memory_equal(a, b, sizeof a);
            checked++;
        }
    }
    printf("patch eval rows: %ld points bit for bit\n", checked);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bezier_curve_split_bbox_derivs),
        cmocka_unit_test(test_patch_eval_rows),
        cmocka_unit_test(test_bezier_patch_split_bbox_derivs),
        cmocka_unit_test(test_curve_reverse_trim),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
