/* Private helpers of the nurbs module: knot-vector algorithms shared by curves, surfaces,
 * Bézier extraction and the model statistics. Piegl & Tiller, "The NURBS Book" A2.1-A2.3, A5.1.
 */
#ifndef CRISP_NURBS_INTERNAL_H
#define CRISP_NURBS_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/nurbs.h"

/* Highest derivative order the basis routines compute. */
#define CRISP__MAX_DERIV 4

/* Check a knot vector of count + degree + 1 values for a B-spline of `count` control points:
 * finite, non-decreasing, non-empty domain. `what` names the vector in messages ("curve",
 * "surface u"). Returns CRISP_ERR_INVALID_ARG with a message naming the bad knot. */
crisp_status crisp__check_knots(const char *what, int degree, int count, const double *knots);
/* Check degree and count against 1..CRISP_MAX_DEGREE and CRISP_MAX_CONTROL_POINTS. */
crisp_status crisp__check_degree_count(const char *what, int degree, int count);

/* The span k in [degree, count - 1] with knots[k] <= t < knots[k + 1] and the span non-empty;
 * t at or beyond the domain end gives the last non-empty span, t before the start the first
 * (A2.1, extended to unclamped knot vectors and empty end spans). */
int crisp__find_span(const double *knots, int degree, int count, double t);
/* The degree + 1 non-zero basis functions at t in span k (A2.2). */
void crisp__basis_funs(const double *knots, int degree, int k, double t, double *dest);
/* Basis functions and derivatives up to order nd (<= CRISP__MAX_DERIV) at t in span k (A2.3):
 * dest[r * (degree + 1) + j] is the r-th derivative of N_{k-degree+j}. Orders above the degree
 * are zero. */
void crisp__basis_ders(const double *knots, int degree, int k, double t, int nd, double *dest);

/* crisp_bezier_patch_derivs in two halves, for many points that share s: rows_s evaluates the
 * patch's rows of control points at s (rows: 2 * (dv + 1) * 4 doubles), derivs_rows finishes
 * at t. Together they give crisp_bezier_patch_derivs(p, s, t, ...) bit for bit. */
void crisp__bezier_patch_rows_s(const crisp_bezier_patch *p, double s, double *rows);
void crisp__bezier_patch_derivs_rows(const crisp_bezier_patch *p, const double *rows, double t,
                                     double *point, double *d_s, double *d_t);

/* crisp_bezier_patch_eval in two halves, for many points that share s (a column of cells):
 * eval_rows_s sums the patch's rows at s (rows: (dv + 1) * 4 doubles), eval_rows finishes at t.
 * Together they give crisp_bezier_patch_eval(p, s, t, dest) bit for bit. */
void crisp__bezier_patch_eval_rows_s(const crisp_bezier_patch *p, double s, double *rows);
void crisp__bezier_patch_eval_rows(const crisp_bezier_patch *p, const double *rows, double t,
                                   double *dest);

/* crisp_surface_normal at many points of one surface, bit for bit the same normals, cheaper
 * (issue 12, session 14: the splat builder's normals were a quarter of a large model's first
 * frame). The basis functions and derivatives of the last CRISP__BASIS_CACHE parameter values
 * asked in each direction are kept (a splat set's cells of a grid share their column's u and
 * their row's v), keyed by the clamped value's bits: crisp__find_span and crisp__basis_ders are
 * functions of it alone. The partials' tensor sums run with the four homogeneous coordinates of
 * a control point in one AVX register where the CPU has it: the same products and sums in the
 * same order (no fused multiply-add), so the same bits. A point whose cross product is not
 * trusted (robust_normal's quality test) takes crisp_surface_normal itself. */
#define CRISP__BASIS_CACHE 64
typedef struct crisp__surface_normals {
    const crisp_surface *s;
    int avx;
    double *basis[2]; /* per direction, CRISP__BASIS_CACHE entries of 2 (degree + 1) values */
    uint64_t *key[2]; /* the clamped parameter's bits per entry */
    int *span[2];     /* its knot span; -1: the entry is empty */
} crisp__surface_normals;

crisp_status crisp__surface_normals_init(crisp__surface_normals *c, const crisp_surface *s);
void crisp__surface_normals_free(crisp__surface_normals *c);
/* crisp_surface_normal(c->s, u, v, dest), bit for bit. */
int crisp__surface_normals_at(crisp__surface_normals *c, double u, double v, double dest[3]);

/* Number of non-empty knot spans inside the domain: the Bézier pieces of the spline. */
int crisp__count_spans(const double *knots, int degree, int count);
/* Surface spans that Bézier extraction keeps (non-empty and not negligibly narrow). */
int crisp__surface_span_kept(const double *knots, int degree, int count, int k);
int crisp__count_surface_spans(const double *knots, int degree, int count);
/* Multiplicity of value t in knots[0 .. n). */
int crisp__multiplicity(const double *knots, int n, double t);

/* Boehm insertion (A5.1) of t, r times, into one sequence of `count` control points of ncomp
 * doubles at stride src_stride (in doubles), written as count + r points at dst_stride.
 * k: index with knots[k] <= t < knots[k + 1] (or the last index of t's value); s: t's
 * multiplicity. Requires r + s <= degree + 1 ... see crisp__insert_index. */
void crisp__insert_seq(const double *knots, int degree, int count, int k, int s, int r, double t,
                       int ncomp, const double *src, ptrdiff_t src_stride, double *dst,
                       ptrdiff_t dst_stride);
/* The knot vector after inserting t r times at index k (dest: count + degree + 1 + r values). */
void crisp__insert_knots(const double *knots, int degree, int count, int k, int r, double t,
                         double *dest);
/* Index k for inserting t: the last index whose knot is <= t, limited to [degree, count + r]
 * so that A5.1's index ranges stay inside the arrays. */
int crisp__insert_index(const double *knots, int degree, int count, double t);

/* Bézier points of one knot span by local knot insertion (A5.6 done span by span, which also
 * clamps unclamped ends): local knots lk[0 .. 2 * degree) = knots[k - degree + 1 .. k + degree],
 * span [lk[degree - 1], lk[degree]]; ctrl holds degree + 1 points of ncomp doubles at stride
 * `stride`; dest gets degree + 1 points, packed (ncomp apart). */
void crisp__span_to_bezier(int degree, const double *lk, int ncomp, const double *ctrl,
                           ptrdiff_t stride, double *dest);

#endif
