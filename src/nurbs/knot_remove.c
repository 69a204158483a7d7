/* Knot removal from a B-spline curve (the inverse of Boehm insertion), for the trim editor's
 * "delete knot where the curve allows". The NURBS Book, section 5.4 (Piegl & Tiller): the new
 * control points follow from the insertion equations solved from both ends; the curve allows the
 * removal when inserting the knot back reproduces every old control point within the tolerance.
 * Written from the equations; verified by re-insertion rather than by the book's single check.
 */
#include "crisp/nurbs.h"

#include "nurbs_internal.h"

#include <math.h>
#include <string.h>

crisp_status crisp_curve_remove_knot(crisp_curve *c, int index, double tol)
{
    const int p = c->degree, n = c->count, nc = c->dim + 1;
    if (index <= p || index >= n)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "knot %d: only interior knots (indices %d..%d) can be removed", index,
                           p + 1, n - 1);
    if (n - 1 < p + 1)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "the curve has %d control points, the fewest a degree %d curve can have",
                           n, p);
    const double u = c->knots[index];
    int r = index; /* last index of u */
    while (r + 1 < n + p + 1 && c->knots[r + 1] == u)
        r++;
    const int s = crisp__multiplicity(c->knots, n + p + 1, u);
    if (r >= n || s > p)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "knot %.17g (multiplicity %d) cannot be removed from a degree %d curve",
                           u, s, p);
    double *knots = crisp_malloc_array((size_t)(n + p), sizeof *knots);
    double *cpw = crisp_malloc_array((size_t)(n - 1) * (size_t)nc, sizeof *cpw);
    if (!knots || !cpw) {
        crisp_free(knots);
        crisp_free(cpw);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory removing a knot");
    }
    /* New knots: the old ones without U[r]. */
    memcpy(knots, c->knots, (size_t)r * sizeof *knots);
    memcpy(knots + r, c->knots + r + 1, (size_t)(n + p - r) * sizeof *knots);
    /* Insertion of u into the new curve Q gives P:
     *   P[i] = Q[i] (i < r - p), P[i] = Q[i - 1] (i > r - s),
     *   P[i] = a_i Q[i] + (1 - a_i) Q[i - 1] (r - p <= i <= r - s),
     *   a_i = (u - K[i]) / (K[i + p] - K[i]) on the new knots K, 0 < a_i < 1 there. */
    const double *P = c->cpw;
    for (int i = 0; i < r - p; i++)
        memcpy(cpw + (size_t)i * nc, P + (size_t)i * nc, (size_t)nc * sizeof *cpw);
    for (int i = r - s + 1; i < n; i++)
        memcpy(cpw + (size_t)(i - 1) * nc, P + (size_t)i * nc, (size_t)nc * sizeof *cpw);
    /* Unknowns Q[r - p .. r - s - 1]: the first half from the left, the rest from the right. */
    const int lo = r - p, hi = r - s - 1;
    const int mid = lo + (hi - lo + 1) / 2; /* left sweep fills lo .. mid - 1 */
    for (int i = lo; i < mid; i++) {
        double a = (u - knots[i]) / (knots[i + p] - knots[i]);
        for (int k = 0; k < nc; k++)
            cpw[(size_t)i * nc + k] =
                (P[(size_t)i * nc + k] - (1 - a) * cpw[(size_t)(i - 1) * nc + k]) / a;
    }
    for (int i = r - s; i > mid; i--) { /* equation i gives Q[i - 1] from Q[i] */
        double a = (u - knots[i]) / (knots[i + p] - knots[i]);
        for (int k = 0; k < nc; k++)
            cpw[(size_t)(i - 1) * nc + k] =
                (P[(size_t)i * nc + k] - a * cpw[(size_t)i * nc + k]) / (1 - a);
    }
    /* Check: insert u back and compare every control point (homogeneous). */
    crisp_curve q = {.dim = c->dim,
                     .degree = p,
                     .count = n - 1,
                     .rational = c->rational,
                     .knots = knots,
                     .cpw = cpw};
    crisp_curve *back = NULL;
    crisp_status st = crisp_curve_copy(&q, &back);
    if (!st) st = crisp_curve_insert_knot(back, u, 1);
    double dev = 0.0;
    int bad_weight = 0;
    if (!st) {
        for (int i = 0; i < n * nc; i++) {
            double d = fabs(back->cpw[i] - P[i]);
            if (!(d <= dev)) dev = d; /* NaN propagates */
        }
        for (int i = 0; i < n - 1; i++)
            if (!(cpw[(size_t)i * nc + c->dim] > 0) || !isfinite(cpw[(size_t)i * nc + c->dim]))
                bad_weight = 1;
    }
    crisp_curve_destroy(back);
    if (!st && (!(dev <= tol) || bad_weight))
        st = crisp_error(CRISP_ERR_INVALID_ARG,
                         "knot %.17g cannot be removed without changing the curve (it would move "
                         "by %.3g, tolerance %.3g)%s",
                         u, dev, tol, bad_weight ? " or a weight would not stay positive" : "");
    if (st) {
        crisp_free(knots);
        crisp_free(cpw);
        return st;
    }
    crisp_free(c->knots);
    crisp_free(c->cpw);
    c->knots = knots;
    c->cpw = cpw;
    c->count = n - 1;
    return CRISP_OK;
}
