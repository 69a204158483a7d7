/* crisp slefe: subdividable linear efficient function enclosures (Lutterkort & Peters 2001) of
 * Bézier functions, curve pieces and tensor-product patches, in object space and, for rational
 * patches, in screen space through a perspective camera (homogeneous SLEFE + interval division).
 * The tables are generated in code on first use (docs/design.md section 3); no published table is
 * copied.
 *
 * Offers:
 *   crisp_slefe_table_get          upper/lower tables of the anti-differences a_j^d on m segments
 *   crisp_slefe_bezier             univariate Bézier function -> lo[m+1], up[m+1]
 *   crisp_slefe_curve              per-component enclosure of a (homogeneous) Bézier curve piece
 *   crisp_slefe_curve_boxes        per-segment Euclidean boxes of a curve piece (rational: divided)
 *   crisp_slefe_patch              two-pass tensor-product enclosure: (m+1)^2 grid of [lo, up] per
 *                                  homogeneous coordinate
 *   crisp_slefe_patch_tiles        per-tile Euclidean boxes of a patch (rational: divided)
 *   crisp_slefe_patch_points       per-grid-point Euclidean boxes (the iPASS "slefe boxes")
 *   crisp_slefe_patch_screen       view-projected patch: per-tile NDC boxes and the screen width
 *                                  w_px of the enclosure, for tau = ceil(m * sqrt(w_px / eps))
 *   crisp_slefe_boxes_screen_width screen width of object-space boxes seen through a camera
 *   crisp_slefe_tess_level         tau = ceil(m * sqrt(w_px / eps)) (the iPASS rule: a guess)
 *   crisp_slefe_patch_screen_error sound pixel bound on patch-versus-triangles distance at tau
 *   crisp_slefe_patch_tess_level   a tau (from the iPASS guess up) that bound accepts: the level
 *                                  to draw a patch within eps pixels
 *   crisp_slefe_group_bound        distance between a B-spline surface and its control net over a
 *                                  rectangle of knot spans (second differences of the net, no
 *                                  Bézier extraction; group_bound.c has the derivation)
 *   crisp_slefe_group_screen       the same in pixels through a camera: the surface versus its net,
 *                                  the net's triangles, and one coarse quad for the whole group
 *
 * Enclosure semantics. For a polynomial p of degree d on [0, 1] and breakpoints t_k = k/m, the
 * piecewise-linear interpolants of lo[k] and up[k] satisfy lo(t) <= p(t) <= up(t) for all t,
 * including floating-point rounding (the tables carry a safety margin and every result is widened
 * by a bound on its own rounding error). For a patch the same holds for the bilinear interpolants
 * of the grid values on each tile [ku/m, (ku+1)/m] x [kv/m, (kv+1)/m]. A triangulation of a tile
 * is not bilinear; the tile boxes (min of the four lower corners, max of the four upper corners)
 * enclose the patch over the tile, and crisp_slefe_patch_screen_error adds the triangle-versus-
 * bilinear twist term to bound the distance between a patch and its triangles on screen.
 *
 * Rational geometry is enclosed in homogeneous form (w*P, w): each homogeneous coordinate is a
 * polynomial and gets its own SLEFE; Euclidean (or NDC) coordinates are then bounded per segment
 * or tile by interval division, which needs the lower bound of W to be positive. Where it is not,
 * the functions return CRISP_ERR_NUMERIC and the caller splits (or culls) the piece.
 *
 * Hot paths (everything except the first table access) allocate nothing; outputs are caller-owned
 * arrays whose sizes are given by the macros below.
 */
#ifndef CRISP_SLEFE_H
#define CRISP_SLEFE_H

#include "crisp/core.h"
#include "crisp/nurbs.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CRISP_SLEFE_MIN_DEGREE 1 /* degree 1 is its own chord: width 0, no table needed */
#define CRISP_SLEFE_MAX_DEGREE 15
#define CRISP_SLEFE_MAX_SEGMENTS 16
/* Number of grid points of a patch enclosure on m segments per direction. */
#define CRISP_SLEFE_GRID(m) (((m) + 1) * ((m) + 1))

/* ---- tables ---------------------------------------------------------------------------------- */

/* Tables of a_j^d (j = 1..d-1) on the breakpoints k/m: entry (j - 1) * (m + 1) + k. upper is the
 * interpolant a_j(k/m); lower is a valid lower piecewise-linear bound (L_j[k] = a_j(k/m) -
 * max(e_{k-1}, e_k), e_k the largest gap between a_j and its chord on segment k, plus a margin
 * that covers rounding). guard: relative rounding margin applied to results (times max |b_i|). */
typedef struct crisp_slefe_table {
    int degree, segments;
    const double *upper;
    const double *lower;
    double guard;
} crisp_slefe_table;

/* degree 2..15, segments 1..16. Thread-safe; the first call builds every table (~1 ms). */
crisp_status crisp_slefe_table_get(int degree, int segments, crisp_slefe_table *dest);

/* ---- univariate ------------------------------------------------------------------------------ */

/* Enclose p(t) = sum_i coef[i * stride] B_i^degree(t) on [0, 1] with m = segments pieces.
 * degree 1..15, segments 1..16, stride >= 1. lo, up: segments + 1 values each. Non-finite
 * coefficients give CRISP_ERR_NUMERIC. */
crisp_status crisp_slefe_bezier(int degree, const double *coef, int stride, int segments,
                                double *lo, double *up);

/* ---- curve pieces ---------------------------------------------------------------------------- */

/* Number of components crisp_slefe_curve writes per breakpoint: dim for a polynomial piece,
 * dim + 1 (homogeneous, w last) for a rational one. */
#define CRISP_SLEFE_CURVE_COMPONENTS(c) ((c)->dim + ((c)->rational ? 1 : 0))

/* Per-component enclosure of a Bézier curve piece: polynomial pieces in Euclidean coordinates,
 * rational ones in homogeneous coordinates (w*x, w*y[, w*z], w). lo, up: (segments + 1) *
 * CRISP_SLEFE_CURVE_COMPONENTS(c) values, breakpoint k component i at [k * ncomp + i]. */
crisp_status crisp_slefe_curve(const crisp_bezier_curve *c, int segments, double *lo, double *up);

/* Per-segment Euclidean boxes that contain the curve over [k/m, (k+1)/m] (SLEFE bounds of the
 * segment intersected with the control points' range): box_lo, box_hi get
 * segments * dim values ([k * dim + i]). Rational pieces: homogeneous SLEFE then interval division;
 * CRISP_ERR_NUMERIC when the lower bound of w is not positive on some segment. */
crisp_status crisp_slefe_curve_boxes(const crisp_bezier_curve *c, int segments, double *box_lo,
                                     double *box_hi);

/* ---- tensor-product patches ------------------------------------------------------------------ */

/* Two-pass enclosure (docs/design.md section 3) of each homogeneous coordinate X, Y, Z, W of a
 * patch (degrees 1..15 each). lo, up: CRISP_SLEFE_GRID(segments) * 4 values, grid point (ku, kv) (u
 * fastest) coordinate i at [(kv * (segments + 1) + ku) * 4 + i]. For a polynomial patch
 * (rational == 0) X, Y, Z are the Euclidean coordinates and W is exactly [1, 1]. */
crisp_status crisp_slefe_patch(const crisp_bezier_patch *p, int segments, double *lo, double *up);

/* Per-tile Euclidean boxes from a crisp_slefe_patch result: tile (ku, kv), coordinate i at
 * [(kv * segments + ku) * 3 + i] of box_lo, box_hi (segments^2 * 3 values each). A polynomial
 * result (W exactly 1) is taken as is; otherwise X/W etc. by interval division, and
 * CRISP_ERR_NUMERIC when the lower bound of W on a tile is not positive. */
crisp_status crisp_slefe_patch_tiles(int segments, const double *lo, const double *up,
                                     double *box_lo, double *box_hi);

/* Per-grid-point Euclidean boxes from a crisp_slefe_patch result: the surface point at (ku/m,
 * kv/m) lies in box (ku, kv), coordinate i at [(kv * (segments + 1) + ku) * 3 + i] of box_lo,
 * box_hi (CRISP_SLEFE_GRID(segments) * 3 values each); rational results divided by W. These are
 * the boxes whose projected size iPASS turns into the tessellation level: pass them to
 * crisp_slefe_boxes_screen_width with stride 3. CRISP_ERR_NUMERIC when W's lower bound at a grid
 * point is not positive. */
crisp_status crisp_slefe_patch_points(int segments, const double *lo, const double *up,
                                      double *box_lo, double *box_hi);

/* A camera for screen-space enclosures: view_proj maps model coordinates to OpenGL clip space
 * (column-major, as crisp_mat4_perspective * crisp_mat4_lookat); width, height: viewport in
 * pixels. NDC x in [-1, 1] spans width pixels. */
typedef struct crisp_slefe_view {
    crisp_mat4 view_proj;
    double width, height;
} crisp_slefe_view;

/* Screen-space enclosure of a patch (polynomial or rational): the homogeneous control points
 * (w*P, w) are mapped by view_proj, each of the clip coordinates X, Y, Z, W gets a SLEFE, and
 * per tile X/W, Y/W, Z/W are bounded by interval division.
 *   ndc_lo, ndc_hi: segments^2 * 3 values (tile (ku, kv) at [(kv * segments + ku) * 3 + i]), NDC
 *                   boxes that contain the projected patch over each tile; either may be NULL.
 *   w_px: the largest screen extent in pixels (max of the x and y extents) over the grid points of
 *         the divided enclosure boxes [X]/[W], [Y]/[W]: the width the tessellator turns into
 *         tau = ceil(m * sqrt(w_px / eps)). May be NULL.
 * Returns CRISP_ERR_NUMERIC when the lower bound of W is not positive somewhere (the patch
 * reaches the eye plane: split or cull); the outputs are then unspecified. */
crisp_status crisp_slefe_patch_screen(const crisp_bezier_patch *p, int segments,
                                      const crisp_slefe_view *view, double *ndc_lo, double *ndc_hi,
                                      double *w_px);

/* The iPASS measure for object-space boxes (e.g. cached crisp_slefe_patch results of polynomial
 * patches with stride 4, or crisp_slefe_patch_tiles boxes with stride 3): box b is
 * [lo + b * stride, hi + b * stride] (3 coordinates); it is mapped by view_proj, divided by W, and
 * its NDC extent converted to pixels; *w_px gets the largest x or y extent. CRISP_ERR_NUMERIC when
 * some box reaches W <= 0. */
crisp_status crisp_slefe_boxes_screen_width(const crisp_slefe_view *view, int count,
                                            const double *lo, const double *hi, int stride,
                                            double *w_px);

/* tau = ceil(segments * sqrt(w_px / eps)), at least 1 (not clamped above: a value over the
 * tessellator's limit tells it to split). This is the iPASS rule; it is a guess, not a bound: the
 * 1/m^2 law it relies on is only asymptotic, and it ignores the twist between the bilinear
 * enclosure and triangles (bench_slefe "tau check": up to about 3x eps on random patches). Use
 * crisp_slefe_patch_tess_level for a guaranteed level. */
int crisp_slefe_tess_level(double w_px, int segments, double eps);

#define CRISP_SLEFE_MAX_TESS_LEVEL 4096

/* Guaranteed bound, in pixels (max of the x and y distances), on the distance between the
 * projected patch and its uniform tessellation at tau segments per direction (tau x tau cells,
 * each cut into two triangles along either diagonal, vertices on the surface, rasterised with
 * clip-space interpolation): every surface point is within *err_px of the drawn triangles and
 * every triangle point within *err_px of the surface. Combines the SLEFE of the clip-space
 * patch at m = tau (tau <= 16) with the classical second-difference bound (any tau) and adds the
 * triangle-versus-bilinear twist term (see screen_error.c). tau 1..CRISP_SLEFE_MAX_TESS_LEVEL.
 * CRISP_ERR_NUMERIC when W is not bounded away from 0 (split or cull). */
crisp_status crisp_slefe_patch_screen_error(const crisp_bezier_patch *p, int tau,
                                            const crisp_slefe_view *view, double *err_px);

/* A tessellation level that draws p with an error of at most eps pixels: a tau at least the iPASS
 * guess (m = 3) whose screen error bound (as crisp_slefe_patch_screen_error, but evaluated only as
 * far as needed) is <= eps, found by raising the guess in steps predicted from the 1/tau^2 decay
 * and capped by the level at which the classic second-difference bound alone suffices; so it is
 * guaranteed but not always the smallest such tau (bench_slefe: worst errors 0.69-0.93 eps).
 * *tau = max_level + 1 when no tau <= max_level (1..CRISP_SLEFE_MAX_TESS_LEVEL) qualifies, or the
 * guess already exceeds max_level: split the patch. CRISP_ERR_NUMERIC as above. Costs about
 * 10 us for a 50-100 px rational bicubic patch (bench/RESULTS.md). */
crisp_status crisp_slefe_patch_tess_level(const crisp_bezier_patch *p, const crisp_slefe_view *view,
                                          double eps, int max_level, int *tau);

/* ---- groups of patches of one B-spline surface ------------------------------------------------
 */

/* A bound, per homogeneous coordinate (w x, w y, w z, w), on |S(u, v) - L(u, v)| for (u, v) in the
 * knot spans iu0..iu1 x iv0..iv1 (indices of non-empty spans, as crisp_scene_patch.iu, .iv), where
 * S is the surface in homogeneous form and L the piecewise-bilinear interpolant of its control
 * points at their Greville abscissae (the control net). Computed from the net's second divided
 * differences over the rows and columns that reach the group (src/slefe/group_bound.c), in
 * O(net points of the group + spans x degree^3) without extracting Bézier patches; sharp for
 * uniform cubics (max |Delta^2| / 6). CRISP_ERR_NUMERIC when two Greville abscissae coincide (a
 * knot of full multiplicity inside the surface). */
crisp_status crisp_slefe_group_bound(const crisp_surface *s, int iu0, int iu1, int iv0, int iv1,
                                     double dest[4]);

typedef struct crisp_slefe_group_screen_bound {
    double net_px; /* surface versus the net (bilinear over its Greville grid), on screen */
    double
        triangles_px; /* surface versus the net drawn as triangles (each quad along a diagonal) */
    double quad_px;   /* surface versus one bilinear quad through the group's four corner net
                         points, drawn as two triangles: "one coarse piece" for the group */
    double box_px[4]; /* xmin, ymin, xmax, ymax in pixels (y down) of the surface over the group */
} crisp_slefe_group_screen_bound;

/* Screen-space bounds (pixels, max of the x and y distances, as crisp_slefe_patch_screen_error)
 * of the group iu0..iu1 x iv0..iv1 seen through view: the net is mapped by view_proj, bounded as
 * crisp_slefe_group_bound, and divided by a guaranteed lower bound of W. A group with quad_px <=
 * 0.5 can be drawn as one coarse piece within 0.5 px. CRISP_ERR_NUMERIC when W is not bounded away
 * from 0 over the group (it reaches the eye plane: split it). */
crisp_status crisp_slefe_group_screen(const crisp_surface *s, int iu0, int iu1, int iv0, int iv1,
                                      const crisp_slefe_view *view,
                                      crisp_slefe_group_screen_bound *dest);

#ifdef __cplusplus
}
#endif
#endif
