/* Tests for the group bound (src/slefe/group_bound.c): on random B-spline surfaces (degrees 1..5,
 * uniform and non-uniform knots with repeated knots, polynomial and rational) and random groups of
 * knot spans, the distance between the surface and its control net at dense samples stays within
 * crisp_slefe_group_bound in every homogeneous coordinate; through random perspective cameras the
 * projected surface stays within net_px of the projected net, triangles_px of the net's triangles
 * (either diagonal) and quad_px of the group's coarse quad; the bound is sharp on a uniform cubic
 * parabola. Prints the measured tightness (sampled / bound). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/nurbs.h"
#include "crisp/slefe.h"
#include "slefe/slefe_test_util.h"

#define MAXC 24

typedef struct surf {
    crisp_surface *s;
    int spans_u, spans_v;
} surf;

/* Clamped knots with n - p - 1 interior knots, uniform or random (some repeated up to p times). */
static void make_knots(rng *r, int p, int n, int uniform, double *t)
{
    for (int i = 0; i <= p; i++)
        t[i] = 0, t[n + i] = 1;
    int m = n - p - 1;
    for (int k = 0; k < m; k++)
        t[p + 1 + k] = uniform ? (k + 1.0) / (m + 1) : rng_uniform(r, 0.02, 0.98);
    if (!uniform) {
        /* sort, then repeat a few knots (multiplicity <= p keeps the Greville abscissae apart) */
        for (int a = 0; a < m; a++)
            for (int b = a + 1; b < m; b++)
                if (t[p + 1 + b] < t[p + 1 + a]) {
                    double x = t[p + 1 + a];
                    t[p + 1 + a] = t[p + 1 + b];
                    t[p + 1 + b] = x;
                }
        int run = 1;
        for (int k = 1; k < m; k++) {
            if (run < p && rng_uniform(r, 0, 1) < 0.2) {
                t[p + 1 + k] = t[p + k];
                run++;
            } else {
                run = 1;
            }
        }
    }
}

static int count_spans(const double *t, int p, int n)
{
    int c = 0;
    for (int k = p; k < n; k++)
        c += t[k] < t[k + 1];
    return c;
}

static void random_surface(rng *r, surf *dest, int *rational_out)
{
    int p = rng_int(r, 1, 5), q = rng_int(r, 1, 5);
    int nu = rng_int(r, p + 1, p + 9), nv = rng_int(r, q + 1, q + 9);
    double tu[MAXC + 8], tv[MAXC + 8];
    make_knots(r, p, nu, rng_int(r, 0, 1), tu);
    make_knots(r, q, nv, rng_int(r, 0, 1), tv);
    int rational = rng_int(r, 0, 2) == 0;
    double amp = pow(10, rng_uniform(r, -3, 0));
    double pts[MAXC * MAXC * 3], w[MAXC * MAXC];
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            double *pt = pts + 3 * (j * nu + i);
            pt[0] = (double)i / (nu - 1) + amp * rng_uniform(r, -1, 1);
            pt[1] = (double)j / (nv - 1) + amp * rng_uniform(r, -1, 1);
            pt[2] = amp * rng_uniform(r, -1, 1);
            w[j * nu + i] = rational ? rng_uniform(r, 0.7, 1.4) : 1;
        }
    assert_int_equal(crisp_surface_create(p, q, nu, nv, tu, tv, pts, rational ? w : NULL, &dest->s),
                     CRISP_OK);
    dest->spans_u = count_spans(tu, p, nu);
    dest->spans_v = count_spans(tv, q, nv);
    *rational_out = rational;
}

/* B-spline basis values N_{k-p..k}(t) for t in span k (Cox-de Boor, long double). */
static void basis(const double *t, int p, int k, long double x, long double *N)
{
    long double left[16], right[16];
    N[0] = 1;
    for (int j = 1; j <= p; j++) {
        left[j] = x - t[k + 1 - j];
        right[j] = t[k + j] - x;
        long double saved = 0;
        for (int r = 0; r < j; r++) {
            long double tmp = N[r] / (right[r + 1] + left[j - r]);
            N[r] = saved + right[r + 1] * tmp;
            saved = left[j - r] * tmp;
        }
        N[j] = saved;
    }
}

static int span_of(const double *t, int p, int n, double x)
{
    int k = p;
    while (k < n - 1 && !(x < t[k + 1]))
        k++;
    while (!(t[k] < t[k + 1]))
        k--;
    return k;
}

static void eval_h(const crisp_surface *s, double u, double v, long double out[4])
{
    int p = s->degree_u, q = s->degree_v;
    int ku = span_of(s->knots_u, p, s->count_u, u), kv = span_of(s->knots_v, q, s->count_v, v);
    long double Nu[16], Nv[16];
    basis(s->knots_u, p, ku, u, Nu);
    basis(s->knots_v, q, kv, v, Nv);
    for (int c = 0; c < 4; c++)
        out[c] = 0;
    for (int b = 0; b <= q; b++)
        for (int a = 0; a <= p; a++) {
            const double *cp = s->cpw + 4 * ((size_t)(kv - q + b) * s->count_u + (ku - p + a));
            for (int c = 0; c < 4; c++)
                out[c] += Nu[a] * Nv[b] * cp[c];
        }
}

static void greville(const double *t, int p, int n, double *xi)
{
    for (int i = 0; i < n; i++) {
        double sum = 0;
        for (int r = 1; r <= p; r++)
            sum += t[i + r];
        xi[i] = sum / p;
    }
}

/* Cell of the Greville grid and local coordinates. */
static void cell(const double *xi, int n, double x, int *i, long double *a)
{
    int k = 0;
    while (k < n - 2 && x > xi[k + 1])
        k++;
    *i = k;
    *a = (x - xi[k]) / (long double)(xi[k + 1] - xi[k]);
}

static void mapped(const crisp_surface *s, crisp_mat4 *m, int i, int j, long double out[4])
{
    const double *c = s->cpw + 4 * ((size_t)j * s->count_u + i);
    for (int r = 0; r < 4; r++) {
        out[r] = 0;
        for (int k = 0; k < 4; k++)
            out[r] += (m ? (long double)(*m)[k][r] : (long double)(k == r)) * c[k];
    }
}

/* Net value at (u, v): mode 0 bilinear, 1 triangles along the (00, 11) diagonal, 2 along (10, 01).
 */
static void net_at(const crisp_surface *s, crisp_mat4 *m, const double *xi, const double *eta,
                   double u, double v, int mode, long double out[4])
{
    int i, j;
    long double a, b;
    cell(xi, s->count_u, u, &i, &a);
    cell(eta, s->count_v, v, &j, &b);
    long double c00[4], c10[4], c01[4], c11[4];
    mapped(s, m, i, j, c00);
    mapped(s, m, i + 1, j, c10);
    mapped(s, m, i, j + 1, c01);
    mapped(s, m, i + 1, j + 1, c11);
    for (int c = 0; c < 4; c++) {
        if (mode == 0)
            out[c] =
                (1 - b) * ((1 - a) * c00[c] + a * c10[c]) + b * ((1 - a) * c01[c] + a * c11[c]);
        else if (mode == 1)
            out[c] = a >= b ? c00[c] + a * (c10[c] - c00[c]) + b * (c11[c] - c10[c])
                            : c00[c] + a * (c11[c] - c01[c]) + b * (c01[c] - c00[c]);
        else
            out[c] = a + b <= 1
                         ? c00[c] + a * (c10[c] - c00[c]) + b * (c01[c] - c00[c])
                         : c11[c] + (1 - a) * (c01[c] - c11[c]) + (1 - b) * (c10[c] - c11[c]);
    }
}

/* Parameter range of non-empty spans s0..s1. */
static void span_range(const double *t, int p, int n, int s0, int s1, double *lo, double *hi)
{
    int c = 0;
    for (int k = p; k < n; k++)
        if (t[k] < t[k + 1]) {
            if (c == s0) *lo = t[k];
            if (c == s1) *hi = t[k + 1];
            c++;
        }
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

#define SURFACES 400

static void test_group_bound_holds(void **state)
{
    (void)state;
    rng r = {20261201};
    static double tight[SURFACES * 3];
    int nt = 0;
    for (int it = 0; it < SURFACES; it++) {
        surf S;
        int rational;
        random_surface(&r, &S, &rational);
        const crisp_surface *s = S.s;
        double xi[MAXC], eta[MAXC];
        greville(s->knots_u, s->degree_u, s->count_u, xi);
        greville(s->knots_v, s->degree_v, s->count_v, eta);
        for (int g = 0; g < 3; g++) {
            int iu0 = rng_int(&r, 0, S.spans_u - 1), iu1 = rng_int(&r, iu0, S.spans_u - 1);
            int iv0 = rng_int(&r, 0, S.spans_v - 1), iv1 = rng_int(&r, iv0, S.spans_v - 1);
            double e[4];
            assert_int_equal(crisp_slefe_group_bound(s, iu0, iu1, iv0, iv1, e), CRISP_OK);
            double u0 = 0, u1 = 1, v0 = 0, v1 = 1;
            span_range(s->knots_u, s->degree_u, s->count_u, iu0, iu1, &u0, &u1);
            span_range(s->knots_v, s->degree_v, s->count_v, iv0, iv1, &v0, &v1);
            double worst = 0;
            for (int b = 0; b <= 40; b++)
                for (int a = 0; a <= 40; a++) {
                    double u = u0 + (u1 - u0) * a / 40, v = v0 + (v1 - v0) * b / 40;
                    long double S4[4], L4[4];
                    eval_h(s, u, v, S4);
                    net_at(s, NULL, xi, eta, u, v, 0, L4);
                    for (int c = 0; c < 4; c++) {
                        double d = (double)fabsl(S4[c] - L4[c]);
                        if (d > e[c]) {
                            fprintf(stderr,
                                    "surface %d group %d: coordinate %d off by %g, bound %g\n", it,
                                    g, c, d, e[c]);
                            fail();
                        }
                        if (e[c] > 1e-9) worst = fmax(worst, d / e[c]);
                    }
                }
            tight[nt++] = worst;
        }
        crisp_surface_destroy(S.s);
    }
    qsort(tight, (size_t)nt, sizeof *tight, cmp_double);
    printf("group bound, %d groups: sampled / bound median %.3f, 90%% %.3f, max %.3f\n", nt,
           tight[nt / 2], tight[nt * 9 / 10], tight[nt - 1]);
}

static double px_dist(const long double a[4], const long double b[4], const crisp_slefe_view *v)
{
    double dx = (double)fabsl(a[0] / a[3] - b[0] / b[3]) * 0.5 * v->width;
    double dy = (double)fabsl(a[1] / a[3] - b[1] / b[3]) * 0.5 * v->height;
    return fmax(dx, dy);
}

static void test_group_screen_holds(void **state)
{
    (void)state;
    rng r = {777};
    static double tight[SURFACES * 2], tight_q[SURFACES * 2];
    int nt = 0, numeric = 0;
    for (int it = 0; it < SURFACES; it++) {
        surf S;
        int rational;
        random_surface(&r, &S, &rational);
        const crisp_surface *s = S.s;
        double xi[MAXC], eta[MAXC];
        greville(s->knots_u, s->degree_u, s->count_u, xi);
        greville(s->knots_v, s->degree_v, s->count_v, eta);
        for (int g = 0; g < 2; g++) {
            crisp_slefe_view view;
            random_slefe_view(&r, 2.0, 20.0, (const double[3]){0.5, 0.5, 0}, 5, 90, &view);
            int iu0 = rng_int(&r, 0, S.spans_u - 1), iu1 = rng_int(&r, iu0, S.spans_u - 1);
            int iv0 = rng_int(&r, 0, S.spans_v - 1), iv1 = rng_int(&r, iv0, S.spans_v - 1);
            crisp_slefe_group_screen_bound b;
            crisp_status st = crisp_slefe_group_screen(s, iu0, iu1, iv0, iv1, &view, &b);
            if (st == CRISP_ERR_NUMERIC) {
                numeric++;
                continue;
            }
            assert_int_equal(st, CRISP_OK);
            assert_true(b.net_px <= b.triangles_px);
            double u0 = 0, u1 = 1, v0 = 0, v1 = 1;
            span_range(s->knots_u, s->degree_u, s->count_u, iu0, iu1, &u0, &u1);
            span_range(s->knots_v, s->degree_v, s->count_v, iv0, iv1, &v0, &v1);
            /* The group's corner net points and normalised Greville coordinates for the quad. */
            int i0 = 0, i1 = 0, j0 = 0, j1 = 0, c = 0;
            for (int k = s->degree_u; k < s->count_u; k++)
                if (s->knots_u[k] < s->knots_u[k + 1]) {
                    if (c == iu0) i0 = k - s->degree_u;
                    if (c == iu1) i1 = k;
                    c++;
                }
            c = 0;
            for (int k = s->degree_v; k < s->count_v; k++)
                if (s->knots_v[k] < s->knots_v[k + 1]) {
                    if (c == iv0) j0 = k - s->degree_v;
                    if (c == iv1) j1 = k;
                    c++;
                }
            long double q00[4], q10[4], q01[4], q11[4];
            mapped(s, &view.view_proj, i0, j0, q00);
            mapped(s, &view.view_proj, i1, j0, q10);
            mapped(s, &view.view_proj, i0, j1, q01);
            mapped(s, &view.view_proj, i1, j1, q11);
            double worst = 0, worst_q = 0;
            for (int bb = 0; bb <= 30; bb++)
                for (int aa = 0; aa <= 30; aa++) {
                    double u = u0 + (u1 - u0) * aa / 30, v = v0 + (v1 - v0) * bb / 30;
                    long double S4[4], P[4], L[4];
                    eval_h(s, u, v, S4);
                    for (int k = 0; k < 4; k++) {
                        P[k] = 0;
                        for (int m = 0; m < 4; m++)
                            P[k] += (long double)view.view_proj[m][k] * S4[m];
                    }
                    assert_true(P[3] > 0);
                    for (int mode = 0; mode < 3; mode++) {
                        net_at(s, &view.view_proj, xi, eta, u, v, mode, L);
                        double d = px_dist(P, L, &view);
                        assert_true(d <= (mode ? b.triangles_px : b.net_px));
                        if (!mode && b.net_px > 1e-6) worst = fmax(worst, d / b.net_px);
                    }
                    /* The coarse quad, both diagonals. */
                    long double su = (u <= xi[i0]   ? 0
                                      : u >= xi[i1] ? 1
                                                    : (u - xi[i0]) / (xi[i1] - xi[i0]));
                    long double sv = (v <= eta[j0]   ? 0
                                      : v >= eta[j1] ? 1
                                                     : (v - eta[j0]) / (eta[j1] - eta[j0]));
                    for (int mode = 1; mode < 3; mode++) {
                        for (int k = 0; k < 4; k++) {
                            long double a = su, bq = sv;
                            if (mode == 1)
                                L[k] =
                                    a >= bq
                                        ? q00[k] + a * (q10[k] - q00[k]) + bq * (q11[k] - q10[k])
                                        : q00[k] + a * (q11[k] - q01[k]) + bq * (q01[k] - q00[k]);
                            else
                                L[k] = a + bq <= 1
                                           ? q00[k] + a * (q10[k] - q00[k]) + bq * (q01[k] - q00[k])
                                           : q11[k] + (1 - a) * (q01[k] - q11[k]) +
                                                 (1 - bq) * (q10[k] - q11[k]);
                        }
                        double d = px_dist(P, L, &view);
                        assert_true(d <= b.quad_px);
                        if (b.quad_px > 1e-6) worst_q = fmax(worst_q, d / b.quad_px);
                    }
                    /* The box. */
                    double x = (double)((P[0] / P[3] + 1) * 0.5 * view.width);
                    double y = (double)((1 - P[1] / P[3]) * 0.5 * view.height);
                    assert_true(x >= b.box_px[0] - 1e-6 && x <= b.box_px[2] + 1e-6);
                    assert_true(y >= b.box_px[1] - 1e-6 && y <= b.box_px[3] + 1e-6);
                }
            tight[nt] = worst;
            tight_q[nt++] = worst_q;
        }
        crisp_surface_destroy(S.s);
    }
    assert_true(nt > SURFACES); /* most groups are in front of the eye */
    qsort(tight, (size_t)nt, sizeof *tight, cmp_double);
    qsort(tight_q, (size_t)nt, sizeof *tight_q, cmp_double);
    printf("group screen bound, %d groups (%d at the eye plane): net sampled / bound median %.3f, "
           "90%% %.3f, "
           "max %.3f; coarse quad median %.3f, max %.3f\n",
           nt, numeric, tight[nt / 2], tight[nt * 9 / 10], tight[nt - 1], tight_q[nt / 2],
           tight_q[nt - 1]);
}

/* A uniform cubic B-spline whose net samples z = x^2 at the Greville abscissae: S - L is the
 * constant max |Delta^2 z| / 6 inside, so the bound must be attained (within rounding). */
static void test_group_bound_sharp(void **state)
{
    (void)state;
    enum { N = 12 };
    double t[N + 4], pts[N * 4 * 3];
    for (int i = 0; i < N + 4; i++)
        t[i] = i < 4 ? 0 : i >= N ? 1 : (i - 3.0) / (N - 3);
    double tv[8] = {0, 0, 0, 0, 1, 1, 1, 1};
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < N; i++) {
            double x = (t[i + 1] + t[i + 2] + t[i + 3]) / 3;
            double *p = pts + 3 * (j * N + i);
            p[0] = x, p[1] = j / 3.0, p[2] = x * x;
        }
    crisp_surface *s;
    assert_int_equal(crisp_surface_create(3, 3, N, 4, t, tv, pts, NULL, &s), CRISP_OK);
    double e[4];
    /* Interior spans (the clamped ends have uneven Greville spacing). */
    assert_int_equal(crisp_slefe_group_bound(s, 3, 5, 0, 0, e), CRISP_OK);
    double h = 1.0 / (N - 3), d2 = 2 * h * h; /* Delta^2 of x^2 at spacing h */
    printf("sharp: bound %.17g, max Delta^2 / 6 = %.17g (%g %g %g)\n", e[2], d2 / 6, e[0], e[1],
           e[3]);
    assert_true(fabs(e[2] - d2 / 6) < 1e-9 * d2);
    assert_true(e[0] < 1e-9 && e[1] < 1e-9 && e[3] < 1e-9);
    crisp_surface_destroy(s);
}

static void test_group_bound_bad_input(void **state)
{
    (void)state;
    double t[8] = {0, 0, 0, 0, 1, 1, 1, 1}, pts[16 * 3] = {0};
    for (int k = 0; k < 16; k++)
        pts[3 * k] = k % 4, pts[3 * k + 1] = k / 4;
    crisp_surface *s;
    assert_int_equal(crisp_surface_create(3, 3, 4, 4, t, t, pts, NULL, &s), CRISP_OK);
    double e[4];
    assert_int_equal(crisp_slefe_group_bound(s, 0, 1, 0, 0, e), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_slefe_group_bound(s, 0, 0, 1, 0, e), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_slefe_group_bound(NULL, 0, 0, 0, 0, e), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_slefe_group_bound(s, 0, 0, 0, 0, e), CRISP_OK);
    /* The eye inside the group's hull: no bound. */
    crisp_slefe_view v = {.width = 100, .height = 100};
    crisp_mat4 view, proj;
    double eye[3] = {1.5, 1.5, 0}, target[3] = {1.5, 1.5, -1}, up[3] = {0, 1, 0};
    assert_true(crisp_mat4_lookat(eye, target, up, view));
    crisp_mat4_perspective(60, 1, 0.01, 100, proj);
    crisp_mat4_mul(proj, view, v.view_proj);
    crisp_slefe_group_screen_bound b;
    assert_int_equal(crisp_slefe_group_screen(s, 0, 0, 0, 0, &v, &b), CRISP_ERR_NUMERIC);
    crisp_surface_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_group_bound_sharp),
        cmocka_unit_test(test_group_bound_holds),
        cmocka_unit_test(test_group_screen_holds),
        cmocka_unit_test(test_group_bound_bad_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
