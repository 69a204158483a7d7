/* crisp nurbs: rational and non-rational B-spline curves (2D, 3D) and tensor-product surfaces,
 * degree 1 to 15, clamped or unclamped knot vectors; evaluation, derivatives, knot insertion,
 * Bézier extraction into homogeneous pieces/patches, splitting Bézier pieces, control-hull boxes.
 * Follows Piegl & Tiller, "The NURBS Book" (A2.1-A2.3, A4.2, A5.1, A5.6).
 *
 * Offers:
 *   crisp_curve_create / _destroy / _copy / _domain / _eval / _derivs / _insert_knot /
 *     _remove_knot / _reverse / _trim / _to_bezier / _bbox
 *   crisp_surface_create / _destroy / _copy / _domain / _eval / _derivs / _insert_knot_u / _v /
 *     _to_bezier / _bbox
 *   crisp_bezier_curve_eval / _derivs / _split / _bbox
 *   crisp_bezier_patch_eval / _derivs / _split_u / _split_v / _bbox
 *   crisp_surface_closest_point / crisp_surface_project_curve (point inversion, 3D edge -> uv)
 *
 * Storage: control points are homogeneous, (w*x, w*y[, w*z], w), so every later stage works on
 * polynomials. Surface control points are ordered with u varying fastest: index j*count_u + i.
 */
#ifndef CRISP_NURBS_H
#define CRISP_NURBS_H

#include "crisp/core.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CRISP_MAX_DEGREE 15
/* Bounds that keep a hostile file from asking for unbounded memory. */
#define CRISP_MAX_CONTROL_POINTS (1 << 22)

/* ---- B-spline curves ------------------------------------------------------------------------- */

typedef struct crisp_curve {
    int dim;       /* 2 (trim curves in uv) or 3 */
    int degree;    /* 1..15 */
    int count;     /* control points, >= degree + 1 */
    int rational;  /* 0 when every weight is 1 */
    double *knots; /* count + degree + 1 values, non-decreasing */
    double *cpw;   /* count * (dim + 1) homogeneous coordinates */
} crisp_curve;

/* points: count * dim Euclidean coordinates; weights: count values or NULL (all 1).
 * Rejects (CRISP_ERR_INVALID_ARG, with a message naming the value) a wrong knot count, decreasing
 * knots, an empty domain, non-positive or non-finite weights, NaN coordinates, degree outside
 * 1..15, count < degree + 1. */
crisp_status crisp_curve_create(int dim, int degree, int count, const double *knots,
                                const double *points, const double *weights, crisp_curve **dest);
void crisp_curve_destroy(crisp_curve *c);
crisp_status crisp_curve_copy(const crisp_curve *c, crisp_curve **dest);
/* The valid parameter range [knots[degree], knots[count]]. */
void crisp_curve_domain(const crisp_curve *c, double *t0, double *t1);
/* Euclidean point (dim values). t is clamped to the domain. */
void crisp_curve_eval(const crisp_curve *c, double t, double *dest);
/* Point and derivatives up to order nderiv (0..2): dest holds (nderiv + 1) * dim values,
 * rational quotient rule applied. */
void crisp_curve_derivs(const crisp_curve *c, double t, int nderiv, double *dest);
/* Insert knot t (inside the domain) `times` times, in place (Boehm / A5.1). */
crisp_status crisp_curve_insert_knot(crisp_curve *c, double t, int times);
/* Remove interior knot knots[index] once, in place, when the curve allows it: inserting it back
 * must give every homogeneous control point back within tol (NURBS Book 5.4). Otherwise
 * CRISP_ERR_INVALID_ARG with a message saying how far the curve would move; c is then unchanged. */
crisp_status crisp_curve_remove_knot(crisp_curve *c, int index, double tol);
/* Reverse the direction in place; the domain [a, b] stays [a, b]. */
void crisp_curve_reverse(crisp_curve *c);
/* A new clamped curve equal to c restricted to [t0, t1] (t0 < t1 inside the domain). */
crisp_status crisp_curve_trim(const crisp_curve *c, double t0, double t1, crisp_curve **dest);
/* Axis-aligned box of the Euclidean control points (contains the curve). dest: 2 * dim values,
 * min then max. */
void crisp_curve_bbox(const crisp_curve *c, double *dest);

/* ---- tensor-product B-spline surfaces -------------------------------------------------------- */

typedef struct crisp_surface {
    int degree_u, degree_v; /* 1..15 */
    int count_u, count_v;   /* control points per direction */
    int rational;
    double *knots_u; /* count_u + degree_u + 1 */
    double *knots_v; /* count_v + degree_v + 1 */
    double *cpw;     /* count_u * count_v * 4, index (j * count_u + i) * 4 */
} crisp_surface;

/* points: count_u * count_v * 3 (u fastest); weights: count_u * count_v or NULL. Validated as for
 * curves. */
crisp_status crisp_surface_create(int degree_u, int degree_v, int count_u, int count_v,
                                  const double *knots_u, const double *knots_v,
                                  const double *points, const double *weights,
                                  crisp_surface **dest);
void crisp_surface_destroy(crisp_surface *s);
crisp_status crisp_surface_copy(const crisp_surface *s, crisp_surface **dest);
/* dest: u0, u1, v0, v1. */
void crisp_surface_domain(const crisp_surface *s, double *dest);
void crisp_surface_eval(const crisp_surface *s, double u, double v, double *dest);
/* Any output may be NULL: point, first and second partial derivatives (3 values each). */
void crisp_surface_derivs(const crisp_surface *s, double u, double v, double *p, double *su,
                          double *sv, double *suu, double *suv, double *svv);
crisp_status crisp_surface_insert_knot_u(crisp_surface *s, double u, int times);
crisp_status crisp_surface_insert_knot_v(crisp_surface *s, double v, int times);
void crisp_surface_bbox(const crisp_surface *s, double *dest); /* 6 values */

/* ---- Bézier pieces and patches (homogeneous) ------------------------------------------------- */

typedef struct crisp_bezier_curve {
    int dim, degree, rational;
    double t0, t1;                          /* parameter interval of the source curve */
    double cpw[(CRISP_MAX_DEGREE + 1) * 4]; /* (degree + 1) * (dim + 1) used */
} crisp_bezier_curve;

typedef struct crisp_bezier_patch {
    int du, dv, rational;
    double u0, u1, v0, v1; /* parameter box of the source surface */
    double *cpw;           /* (du + 1) * (dv + 1) * 4, index (j * (du + 1) + i) * 4; owned by
                              the crisp_bezier_patches that holds the patch */
} crisp_bezier_patch;

typedef struct crisp_bezier_patches {
    int count;
    crisp_bezier_patch *patches;
    double *storage; /* all control points */
} crisp_bezier_patches;

/* Bézier extraction by knot insertion: one piece per non-empty knot span, in parameter order.
 * *dest is allocated (free with crisp_free). */
crisp_status crisp_curve_to_bezier(const crisp_curve *c, crisp_bezier_curve **dest, int *count);
/* One patch per non-empty span pair, u fastest. */
crisp_status crisp_surface_to_bezier(const crisp_surface *s, crisp_bezier_patches *dest);
void crisp_bezier_patches_free(crisp_bezier_patches *p);

/* Local parameter t in [0, 1] (not the source interval). */
void crisp_bezier_curve_eval(const crisp_bezier_curve *b, double t, double *dest);
/* As crisp_curve_derivs, with derivatives in the local t (divide the r-th by (t1 - t0)^r for the
 * source parameter). */
void crisp_bezier_curve_derivs(const crisp_bezier_curve *b, double t, int nderiv, double *dest);
/* de Casteljau split at local t; left/right get the source intervals split accordingly. */
void crisp_bezier_curve_split(const crisp_bezier_curve *b, double t, crisp_bezier_curve *left,
                              crisp_bezier_curve *right);
void crisp_bezier_curve_bbox(const crisp_bezier_curve *b, double *dest);

/* Local parameters (s, t) in [0, 1]^2. */
void crisp_bezier_patch_eval(const crisp_bezier_patch *p, double s, double t, double *dest);
/* Euclidean point and first partials in local s and t (any output may be NULL). */
void crisp_bezier_patch_derivs(const crisp_bezier_patch *p, double s, double t, double *point,
                               double *d_s, double *d_t);
/* Split at local s (or t): the halves' cpw must point to caller storage of
 * (du + 1) * (dv + 1) * 4 doubles each. */
void crisp_bezier_patch_split_u(const crisp_bezier_patch *p, double s, crisp_bezier_patch *lo,
                                crisp_bezier_patch *hi);
void crisp_bezier_patch_split_v(const crisp_bezier_patch *p, double t, crisp_bezier_patch *lo,
                                crisp_bezier_patch *hi);
void crisp_bezier_patch_bbox(const crisp_bezier_patch *p, double *dest); /* 6 values */

/* ---- normals ----------------------------------------------------------------------------------
 */

/* A cross product S_s x S_t is trusted as a normal when the smaller partial is more than this
 * fraction of the larger and the sine of their angle is more than it too; below, the side is
 * collapsed (exactly, or as a file's rounding leaves it: apex points 1e-9..1e-6 apart) or the
 * partials are parallel. The renderers use the same threshold (crisp__normal_degenerate, and the
 * GL backend's shaders/common.glsl). */
#define CRISP_NORMAL_TAU 1e-5

/* The unit normal S_s x S_t / |S_s x S_t| of the patch at local (s, t), also where the cross
 * product vanishes or is not to be trusted (CRISP_NORMAL_TAU: a cone's apex, a sphere's pole, a
 * collapsed side, parallel partials): there the limit of the normal from inside the patch along
 * the direction that leaves the degenerate side (around an apex each generator keeps its own
 * normal). Returns 1, or 0 with dest = 0 when the patch has no normal near (s, t) at all (it is a
 * point or a curve there). */
int crisp_bezier_patch_normal(const crisp_bezier_patch *p, double s, double t, double dest[3]);
/* The same for a NURBS surface at (u, v) of its domain. */
int crisp_surface_normal(const crisp_surface *s, double u, double v, double dest[3]);

/* The offset surface S + d N (N = crisp_surface_normal) as a bicubic B-spline over S's domain and
 * parametrisation (C0 at its knots, watertight), within tol of the true offset at 16 test points
 * per cell; cells split until they pass, up to max_cells per direction and max_cells^2 / 4 in all
 * (else CRISP_ERR_LIMIT). */
crisp_status crisp_surface_offset(const crisp_surface *s, double d, double tol, int max_cells,
                                  crisp_surface **dest);

/* ---- projection onto surfaces ---------------------------------------------------------------- */

/* Point inversion: the (u, v) of the point of s closest to p (global search on a sample grid,
 * then Newton, clamped to the domain). dist (may be NULL) gets the 3D distance. */
crisp_status crisp_surface_closest_point(const crisp_surface *s, const double p[3], double uv[2],
                                         double *dist);
/* A 2D B-spline curve in s's (u, v) domain whose image lies within tol (3D distance) of the
 * model-space curve c over [t0, t1]; continuity across u/v seams of closed surfaces is kept.
 * The result is a cubic over [t0, t1] (C0 at its knots). On a surface closed in u (or v) a
 * curve crossing the seam stays continuous and so leaves [u0, u1] by up to one period: evaluate
 * S at u wrapped into the domain; of the shifted copies the one whose u-range middle lies in
 * [u0, u1) is returned (a curve on the seam itself gets u0). Where u is undefined (a pole) it
 * is taken from the neighbouring points. */
crisp_status crisp_surface_project_curve(const crisp_surface *s, const crisp_curve *c, double t0,
                                         double t1, double tol, crisp_curve **dest);
/* crisp_surface_project_curve, and where that fails because the projection jumps (the curve
 * passes a collapsed patch side or a pole reached from both ends of the domain, or runs between
 * two sheets of the surface), the curve cut at the jumps into up to max_pieces pieces, each
 * projected on its own (dest[0 .. *count - 1], in curve order). The gaps between pieces are the
 * caller's to bridge (they lie where the surface collapses, or they are real). */
crisp_status crisp_surface_project_curve_pieces(const crisp_surface *s, const crisp_curve *c,
                                                double t0, double t1, double tol, int max_pieces,
                                                crisp_curve **dest, int *count);

#ifdef __cplusplus
}
#endif
#endif
