/* trim module internals: Bernstein-form helpers shared by the density bound, the tessellator and
 * the exact classifier (de Casteljau restriction, products of Bernstein forms, evaluation). */
#ifndef CRISP_TRIM_INTERNAL_H
#define CRISP_TRIM_INTERNAL_H

#include "crisp/trim.h"

/* min and max of finite values without the library calls (fmin and fmax are calls that handle
 * NaN; the trim pieces' coordinates are checked finite). */
static inline double crisp__trim_min(double a, double b)
{
    return a < b ? a : b;
}
static inline double crisp__trim_max(double a, double b)
{
    return a > b ? a : b;
}

/* Binomial coefficient C(n, k) for 0 <= k <= n <= 2 * CRISP_MAX_DEGREE + 1, as a double. */
double crisp__trim_binom(int n, int k);

/* Restrict a univariate Bernstein polynomial of degree d (coefficients c[0], c[stride], ...) to the
 * local interval [a, b] of [0, 1], in place. */
void crisp__trim_restrict(double *c, int d, int stride, double a, double b);

/* de Casteljau split at t: lo and hi get degree + 1 coefficients each (stride 1). c is untouched.
 */
void crisp__trim_split(const double *c, int d, int stride, double t, double *lo, double *hi);

/* Value of a univariate Bernstein polynomial at t (de Casteljau on a copy). */
double crisp__trim_eval(const double *c, int d, int stride, double t);

/* Tensor-product Bernstein product: a has degrees (am, an), b (bm, bn), both stored j * (m + 1) + i
 * (i along u); dest gets degrees (am + bm, an + bn). */
void crisp__trim_product2(const double *a, int am, int an, const double *b, int bm, int bn,
                          double *dest);

/* Value and first derivative of a univariate Bernstein polynomial at t. */
void crisp__trim_eval_d(const double *c, int d, int stride, double t, double *val, double *der);

/* For tests (scan_density.c): the bounds bv, bu (per unit of the face's v and u) that
 * crisp_trim_scan_density takes from block b of desc->tree's boxes, and the ones it takes from
 * patch p's own coefficients before any refinement. Return 1 with the bounds, 0 when W is not
 * provably positive, -1 when nothing of it lies in the widened frustum. */
int crisp__trim_block_bound(const crisp_trim_density_desc *desc, const crisp_trim_density_block *b,
                            double *bv, double *bu);
int crisp__trim_patch_bound(const crisp_trim_density_desc *desc, const crisp_bezier_patch *p,
                            double *bv, double *bu);
/* crisp_trim_tessellate for pieces that have passed crisp_trim_pieces_check (crisp_trim_plan_face
 * checks them once per face and frame). */
crisp_status crisp__trim_tessellate_checked(const crisp_trim_tess_desc *desc,
                                            crisp_trim_polyline *dest);
#endif
