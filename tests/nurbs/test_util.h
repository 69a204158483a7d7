/* Shared helpers of the nurbs tests: a deterministic random generator, random B-spline curves
 * and surfaces (degrees 1..15, clamped or unclamped, knot multiplicities, rational), and an
 * independent reference evaluator (Cox-de Boor recursion, not the code under test).
 */
#ifndef CRISP_TEST_NURBS_UTIL_H
#define CRISP_TEST_NURBS_UTIL_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "crisp/nurbs.h"

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;

static inline void rng_seed(uint64_t s)
{
    rng_state = s * 0x9e3779b97f4a7c15ull + 1;
}

static inline double rng_uniform(void) /* [0, 1) */
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

static inline int rng_int(int lo, int hi) /* [lo, hi] */
{
    return lo + (int)(rng_uniform() * (hi - lo + 1));
}

/* A random knot vector of count + degree + 1 values. Interior knots get multiplicity 1..degree;
 * clamped vectors have degree + 1 equal end knots, unclamped ones distinct end knots. */
static inline void random_knots(int degree, int count, int clamped, double *knots)
{
    int n = count + degree + 1;
    for (int attempt = 0;; attempt++) {
        int i = 0, stop = clamped ? n - (degree + 1) : n;
        double t = rng_uniform() * 4.0 - 2.0;
        if (clamped)
            for (; i <= degree; i++)
                knots[i] = t;
        while (i < stop) {
            t += 0.25 + rng_uniform();
            int mult = (attempt < 5 && rng_uniform() < 0.3) ? rng_int(1, degree) : 1;
            for (int m = 0; m < mult && i < stop; m++)
                knots[i++] = t;
        }
        if (clamped) {
            t += 0.25 + rng_uniform();
            for (; i < n; i++)
                knots[i] = t;
        }
        if (knots[degree] < knots[count]) return;
    }
}

/* Cox-de Boor recursion (The NURBS Book eq. 2.5), for reference only. */
static inline double ref_basis(const double *knots, int i, int p, double t, int last_span)
{
    if (p == 0) {
        if (knots[i] <= t && t < knots[i + 1]) return 1.0;
        /* the domain end belongs to the last non-empty span */
        if (i == last_span && t == knots[i + 1]) return 1.0;
        return 0.0;
    }
    double a = 0.0, b = 0.0;
    if (knots[i + p] > knots[i])
        a = (t - knots[i]) / (knots[i + p] - knots[i]) * ref_basis(knots, i, p - 1, t, last_span);
    if (knots[i + p + 1] > knots[i + 1])
        b = (knots[i + p + 1] - t) / (knots[i + p + 1] - knots[i + 1]) *
            ref_basis(knots, i + 1, p - 1, t, last_span);
    return a + b;
}

static inline int ref_last_span(const double *knots, int degree, int count)
{
    int k = count - 1;
    while (k > degree && knots[k] == knots[k + 1])
        k--;
    return k;
}

static inline void ref_curve_eval(const crisp_curve *c, double t, double *dest)
{
    const int nc = c->dim + 1;
    double h[4] = {0, 0, 0, 0};
    int last = ref_last_span(c->knots, c->degree, c->count);
    for (int i = 0; i < c->count; i++) {
        double b = ref_basis(c->knots, i, c->degree, t, last);
        for (int d = 0; d < nc; d++)
            h[d] += b * c->cpw[i * nc + d];
    }
    for (int d = 0; d < c->dim; d++)
        dest[d] = h[d] / h[c->dim];
}

static inline crisp_curve *random_curve(int dim, int degree, int count, int clamped, int rational)
{
    double knots[CRISP_MAX_DEGREE + 64], pts[64 * 3], w[64];
    random_knots(degree, count, clamped, knots);
    for (int i = 0; i < count * dim; i++)
        pts[i] = rng_uniform() * 2.0 - 1.0;
    for (int i = 0; i < count; i++)
        w[i] = 0.5 + 1.5 * rng_uniform();
    crisp_curve *c = NULL;
    if (crisp_curve_create(dim, degree, count, knots, pts, rational ? w : NULL, &c)) return NULL;
    return c;
}

static inline crisp_surface *random_surface(int du, int dv, int nu, int nv, int clamped,
                                            int rational)
{
    double ku[CRISP_MAX_DEGREE + 64], kv[CRISP_MAX_DEGREE + 64];
    double *pts = malloc((size_t)nu * nv * 3 * sizeof *pts);
    double *w = malloc((size_t)nu * nv * sizeof *w);
    random_knots(du, nu, clamped, ku);
    random_knots(dv, nv, clamped, kv);
    for (int i = 0; i < nu * nv * 3; i++)
        pts[i] = rng_uniform() * 2.0 - 1.0;
    for (int i = 0; i < nu * nv; i++)
        w[i] = 0.5 + 1.5 * rng_uniform();
    crisp_surface *s = NULL;
    crisp_status st = crisp_surface_create(du, dv, nu, nv, ku, kv, pts, rational ? w : NULL, &s);
    free(pts);
    free(w);
    return st ? NULL : s;
}

static inline double dist_n(const double *a, const double *b, int n)
{
    double s = 0.0;
    for (int i = 0; i < n; i++)
        s += (a[i] - b[i]) * (a[i] - b[i]);
    return sqrt(s);
}

#endif
