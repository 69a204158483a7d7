/* Private helpers of the slefe module: table access without checks, the univariate enclosure
 * kernel shared by curves and patches, and outward-rounded interval division. */
#ifndef CRISP_SLEFE_INTERNAL_H
#define CRISP_SLEFE_INTERNAL_H

#include "crisp/slefe.h"

#include <float.h>
#include <math.h>

/* min and max without the NaN rules of fmin/fmax (which are library calls at -O2); inputs are
 * checked finite at the entry points. */
static inline double crisp__min(double a, double b)
{
    return a < b ? a : b;
}
static inline double crisp__max(double a, double b)
{
    return a > b ? a : b;
}

/* Builds the tables once (pthread_once); cheap after the first call. */
void crisp__slefe_tables_init(void);
/* Table of (degree, segments) after crisp__slefe_tables_init; degree 1 gives NULL tables. */
crisp_slefe_table crisp__slefe_table(int degree, int segments);
/* Largest accepted input magnitude: second differences and table products of such values stay
 * far from overflow. */
#define CRISP_SLEFE_MAX_MAGNITUDE 1e300
/* Nonzero when the n values v[i * stride] are all finite and at most CRISP_SLEFE_MAX_MAGNITUDE in
 * magnitude (NaN fails the comparison). */
int crisp__slefe_all_finite(const double *v, int n, int stride);
/* Degree and segment count in range, else an error naming fn. */
crisp_status crisp__slefe_check(const char *fn, int degree, int segments);

/* The second differences of b split into their positive and negative parts (pos[j - 1], neg[j - 1]
 * for j = 1..d-1); returns the largest |b_i| (the scale of the rounding margin). */
static inline double crisp__slefe_second_differences(int d, const double *b, int stride,
                                                     double *pos, double *neg)
{
    double bmax = fabs(b[0]) > fabs(b[d * stride]) ? fabs(b[0]) : fabs(b[d * stride]);
    for (int j = 1; j < d; j++) {
        double bj = b[j * stride];
        double dd = b[(j - 1) * stride] - 2.0 * bj + b[(j + 1) * stride];
        pos[j - 1] = dd > 0.0 ? dd : 0.0;
        neg[j - 1] = dd < 0.0 ? dd : 0.0;
        if (fabs(bj) > bmax) bmax = fabs(bj);
    }
    return bmax;
}

/* Enclosure of sum_i b[i * stride] B_i^d on m segments with table t (d >= 1; t.upper may be NULL
 * for d == 1), at k = k0..k1 only: lo[(k - k0) * lstride], up[(k - k0) * ustride] (each k's value
 * the same whichever range it is formed in). No checks. */
static inline void crisp__slefe_kernel_range(int d, const double *b, int stride,
                                             const crisp_slefe_table *t, int m, int k0, int k1,
                                             double *lo, int lstride, double *up, int ustride)
{
    double pos[CRISP_SLEFE_MAX_DEGREE], neg[CRISP_SLEFE_MAX_DEGREE];
    double b0 = b[0], bd = b[d * stride];
    double bmax = crisp__slefe_second_differences(d, b, stride, pos, neg);
    double margin = t->guard * bmax;
    double inv_m = 1.0 / m;
    for (int k = k0; k <= k1; k++) {
        double tk = k * inv_m;
        double line = (1.0 - tk) * b0 + tk * bd;
        double u = line, l = line;
        for (int j = 1; j < d; j++) {
            double uj = t->upper[(j - 1) * (m + 1) + k], lj = t->lower[(j - 1) * (m + 1) + k];
            u += pos[j - 1] * uj + neg[j - 1] * lj;
            l += pos[j - 1] * lj + neg[j - 1] * uj;
        }
        up[(k - k0) * ustride] = u + margin;
        lo[(k - k0) * lstride] = l - margin;
    }
}

/* crisp__slefe_kernel_range over every k = 0..m: lo[k * lstride], up[k * ustride]. */
static inline void crisp__slefe_kernel(int d, const double *b, int stride,
                                       const crisp_slefe_table *t, int m, double *lo, int lstride,
                                       double *up, int ustride)
{
    crisp__slefe_kernel_range(d, b, stride, t, m, 0, m, lo, lstride, up, ustride);
}

/* Validates a patch (degrees, finite control points) for the public entry point fn. */
crisp_status crisp__slefe_check_patch(const char *fn, const crisp_bezier_patch *p, int segments);
/* Two-pass enclosure of the first ncomp homogeneous coordinates of p into the (m + 1)^2 * 4
 * layout of crisp_slefe_patch (other coordinates untouched). Tables must be initialised. */
void crisp__slefe_patch_nocheck(const crisp_bezier_patch *p, int m, int ncomp, double *lo,
                                double *up);
/* The same for homogeneous coordinate c only. */
void crisp__slefe_patch_coordinate(const crisp_bezier_patch *p, int m, int c, double *lo,
                                   double *up);

/* Per-tile boxes of a grid result (layout of crisp_slefe_patch); hull_lo/hull_hi (4 values each,
 * or NULL) are bounds of each homogeneous coordinate over the whole patch (its control points'
 * range), intersected with the tile bounds. Divides by W unless W is exactly [1, 1]. */
crisp_status crisp__slefe_tiles(const char *fn, int m, const double *lo, const double *up,
                                const double *hull_lo, const double *hull_hi, double *box_lo,
                                double *box_hi);

/* View validation shared by the screen-space entry points. */
crisp_status crisp__slefe_check_view(const char *fn, const crisp_slefe_view *view);
/* Clip-space control points of p (same layout as p->cpw); err[4]: bound on their rounding per
 * coordinate; hl, hh [4]: range of each clip coordinate over the control points, widened by err
 * (bounds over the whole patch by the convex hull). CRISP_ERR_NUMERIC on overflow. */
/* Widen grid bounds by the transform's rounding (clip coordinates in mask), check W > 0, and the
 * iPASS width in pixels (w_px may be NULL): src/slefe/screen.c. */
crisp_status crisp__slefe_grid_width(const char *fn, const crisp_slefe_view *view, int n,
                                     unsigned mask, double *lo, double *up, const double *err,
                                     const double *hl, const double *hh, double *w_px);
crisp_status crisp__slefe_to_clip(const char *fn, const crisp_bezier_patch *p,
                                  const crisp_slefe_view *view, double *clip, double *err,
                                  double *hl, double *hh);

/* Bounds K[r] on |f_ss| + |f_tt| + 2 |f_st| over the patch of f_r = c_r / w, r < nc (nc <= 3),
 * for the patch of degrees du x dv with coefficients c (nc + 1 values per control point, the
 * weight w last), from its k x k pieces (k = 1: the whole patch; the bound over k = 2, 4 pieces is
 * tighter; quotient.c has the argument). INFINITY where a weight is not positive. */
void crisp__slefe_quotient_curvature(const double *c, int nc, int du, int dv, int k, double *K);
/* A cheaper bound of the same kind, never below crisp__slefe_quotient_curvature(c, nc, du, dv, k,
 * K) (per piece bit for bit its first candidate: l the middle of the values, without the fitted
 * l's degree raise): enough where a caller only needs K below some threshold and this one is. */
void crisp__slefe_quotient_curvature_mid(const double *c, int nc, int du, int dv, int k, double *K);

/* What crisp__slefe_patch_tess_level formed on the way that another bound of the same patch can
 * reuse: kw[i], the curvature sum K of the Euclidean clip W = H_w / w over the patch's 2^i x 2^i
 * pieces (crisp__slefe_quotient_curvature(c, 1, du, dv, 2^i, &K) with c the clip W and weight of
 * each control point: the same numbers, bit for bit), NAN where the search did not form it (it
 * forms them only for patches whose weights vary). src/render/depth_bound.c's bound along the
 * view needs exactly these. */
typedef struct crisp__slefe_level_info {
    double kw[3];
} crisp__slefe_level_info;

/* The Euclidean bound's curvature sums (screen_error.c euclid_c1) formed so far by a level search:
 * K[i] over the 2^i x 2^i pieces, for X', Y', W. */
typedef struct crisp__slefe_euclid_sums {
    double K[3][3];
    int formed; /* piece levels formed */
} crisp__slefe_euclid_sums;

/* crisp_slefe_patch_tess_level's search in two steps (screen_error.c), for a caller that can
 * decide from the level's range alone (src/render/quadtree.c, the children's rule). begin: what
 * comes before the search's loop; *tau > 0 where the level is decided there, else *tau = 0 and the
 * level finish names lies in [*lo, *hi] or is max_level + 1. finish (only after a begin that left
 * *tau = 0, with the same p): the loop. info: as crisp__slefe_patch_tess_level's. */
/* The control-net difference bounds of a search's clip-space net (screen_error.c's
 * derivative_bounds and speed_bounds), formed once per search: it asks for them at every level it
 * tries, with the same net. formed: bit r for the derivative bounds of coordinate r, bit 4 + r for
 * its speed bounds (r = 2: the weights'). */
typedef struct crisp__slefe_net_bounds {
    unsigned formed;
    double d[4][3], s[4][2];
} crisp__slefe_net_bounds;

typedef struct crisp__slefe_search {
    crisp_slefe_view view; /* the view centred on the patch */
    double clip[(CRISP_SLEFE_MAX_DEGREE + 1) * (CRISP_SLEFE_MAX_DEGREE + 1) * 4];
    double err[4], hl[4], hh[4], eps;
    const double *wcpw; /* the weights (p's control points) when they vary, else NULL */
    double wlo, whi;
    crisp__slefe_euclid_sums sums;
    crisp__slefe_net_bounds nb;
    int max_level, t, t_classic;
} crisp__slefe_search;
crisp_status crisp__slefe_search_begin(crisp__slefe_search *s, const crisp_bezier_patch *p,
                                       const crisp_slefe_view *view, double eps, int max_level,
                                       int *tau, int *lo, int *hi, crisp__slefe_level_info *info);
crisp_status crisp__slefe_search_finish(crisp__slefe_search *s, const crisp_bezier_patch *p,
                                        int *tau, crisp__slefe_level_info *info);

/* crisp__slefe_patch_coordinate's lo, up of coordinate c at the four grid points of tile (ku, kv)
 * of m x m alone, bit for bit its values: lo[(j * 2 + i) * 4 + c] for the point (ku + i, kv + j)
 * (screen_error.c: the level search rejects a level from one tile's term of its bound). */
void crisp__slefe_coordinate_tile(const crisp_bezier_patch *p, int m, int c, int ku, int kv,
                                  double *lo, double *up);
/* Test hook: nonzero makes the level search form every level's bound whole (no rejection from
 * one tile), as before session 20. */
extern int crisp__slefe_quick_off;
/* Test hook (quotient.c): 0 makes the piece bounds of three coordinates take the scalar body,
 * 1 the lanes one (AVX2 processors only), -1 (the start) chooses by the processor. */
extern int crisp__slefe_quotient_lanes;

/* crisp_slefe_patch_tess_level, and (info not NULL) what it formed on the way. */
crisp_status crisp__slefe_patch_tess_level(const crisp_bezier_patch *p,
                                           const crisp_slefe_view *view, double eps, int max_level,
                                           int *tau, crisp__slefe_level_info *info);

/* The Euclidean screen bound alone (screen_error.c, euclid_c1) of the uniform tessellation of a
 * rational patch at level tau, in pixels: for tests. CRISP_ERR_NUMERIC where a weight or a
 * control point's clip W is not positive. */
crisp_status crisp__slefe_euclid_screen_error(const crisp_bezier_patch *p, int tau,
                                              const crisp_slefe_view *view, double *err_px);

/* One side of the enclosure, at k = k0..k1 only (out[(k - k0) * ostride]): with (first, second) =
 * (upper, lower) tables and sign = +1 this is up[k]; with (lower, upper) and sign = -1 it is lo[k].
 * Each k's value is the same whichever range it is formed in (a level search forms one tile's,
 * screen_error.c). */
static inline void crisp__slefe_side_range(int d, const double *b, int stride, double guard,
                                           const double *first, const double *second, double sign,
                                           int m, int k0, int k1, double *out, int ostride)
{
    double pos[CRISP_SLEFE_MAX_DEGREE], neg[CRISP_SLEFE_MAX_DEGREE];
    double b0 = b[0], bd = b[d * stride];
    double bmax = crisp__slefe_second_differences(d, b, stride, pos, neg);
    double margin = sign * guard * bmax;
    double inv_m = 1.0 / m;
    for (int k = k0; k <= k1; k++) {
        double tk = k * inv_m;
        double v = (1.0 - tk) * b0 + tk * bd;
        for (int j = 1; j < d; j++)
            v += pos[j - 1] * first[(j - 1) * (m + 1) + k] +
                 neg[j - 1] * second[(j - 1) * (m + 1) + k];
        out[(k - k0) * ostride] = v + margin;
    }
}

/* crisp__slefe_side_range over every k = 0..m, written out (as a call of the range form it made
 * patch.c's copies a few percent dearer: gpucast_teapot.igs close's plan +0.4%). */
static inline void crisp__slefe_side(int d, const double *b, int stride, double guard,
                                     const double *first, const double *second, double sign, int m,
                                     double *out, int ostride)
{
    double pos[CRISP_SLEFE_MAX_DEGREE], neg[CRISP_SLEFE_MAX_DEGREE];
    double b0 = b[0], bd = b[d * stride];
    double bmax = crisp__slefe_second_differences(d, b, stride, pos, neg);
    double margin = sign * guard * bmax;
    double inv_m = 1.0 / m;
    for (int k = 0; k <= m; k++) {
        double tk = k * inv_m;
        double v = (1.0 - tk) * b0 + tk * bd;
        for (int j = 1; j < d; j++)
            v += pos[j - 1] * first[(j - 1) * (m + 1) + k] +
                 neg[j - 1] * second[(j - 1) * (m + 1) + k];
        out[k * ostride] = v + margin;
    }
}

/* Outward-rounded [xl, xu] / [wl, wu] for wl > 0. */
static inline void crisp__slefe_divide(double xl, double xu, double wl, double wu, double *ql,
                                       double *qu)
{
    /* x / w is monotone in x and, for fixed sign of x, in w: the extremes are at corners. */
    double a = xl / (xl >= 0.0 ? wu : wl);
    double b = xu / (xu >= 0.0 ? wl : wu);
    *ql = a - fabs(a) * DBL_EPSILON;
    *qu = b + fabs(b) * DBL_EPSILON;
}

#endif
