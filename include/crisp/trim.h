/* crisp trim: correct-resolution trimming after Wu & Peters, "Correct resolution rendering of
 * trimmed spline surfaces" (CAD 2015), with the per-frame density computed as a guaranteed bound
 * instead of read back from the previous frame (docs/design.md section 5).
 *
 * Offers:
 *   crisp_trim_pieces_check          validate a face's trim pieces (2D homogeneous Bézier)
 *   crisp_trim_scan_density          per strip, a guaranteed upper bound of the v- and u-scan
 *                                    densities (pixels per unit parameter) over the visible part
 *   crisp_trim_rows_from_density     mu_i = ceil((b_i - a_i) rho_i) scan lines per strip
 *   crisp_trim_tessellate            trim pieces -> polylines within a quarter scan line (v) and a
 *                                    quarter pixel's worth of u of the true curves
 *   crisp_trim_polyline_chains       pieces' polylines -> chains of fewer chords within tolerances
 *   crisp_trim_lod_build / _free     view-independent coarse polylines of a face's loops
 *   crisp_trim_table_build / _test / _bytes / _free
 *                                    the two-level u-intercept table (CSR) and the trim test
 *   crisp_trim_plan_face / crisp_trim_plan_free
 *                                    all of the above for one face and one frame, reusing buffers
 *   crisp_trim_exact_classify / crisp_trim_exact_distance
 *                                    reference decision and distance on the true rational curves
 *
 * Conventions.
 *   Pieces are crisp_bezier_curve with dim 2 and homogeneous control points (w u, w v, w), w > 0,
 *   local parameter [0, 1]. They come from the face's loops (crisp_curve_to_bezier); together they
 *   form closed loops. Inside/outside is decided by parity (even-odd), so loop orientation does not
 *   matter as long as loops do not cross (outer CCW, holes CW as normalised on load).
 *   Scan lines are horizontal (constant v); a crossing is counted with the half-open rule: an edge
 *   from v_a to v_b crosses scan line v_s iff min(v_a, v_b) < v_s <= max(v_a, v_b) (bottom open,
 * top closed), so a vertex lying on a scan line gives 0 or 2 crossings, never 1. A point (u, v) is
 *   inside iff the number of crossings of its scan line strictly left of u (u_c < u) is odd.
 *   Strips: the face's v-range [v0, v1] is cut into strip_count uniform strips
 *   nu_i = v0 + i (v1 - v0) / strip_count; strip i owns [nu_i, nu_{i+1}) and the last strip also
 *   owns v1. Strip i has mu_i rows spread over the strip's row range [a_i, b_i], the part of the
 *   strip that the density bound found visible (the whole strip when not given); row j covers v
 *   in [a_i + j h_i, a_i + (j + 1) h_i) with h_i = (b_i - a_i) / mu_i, and its scan line sits at
 *   the centre of that interval, so a pixel's v is never more than h_i / 2 from the scan line
 *   that decides it. Restricting rows to the visible part keeps the table small at any zoom
 *   (eq. 11 of Wu & Peters with nu_i, nu_{i+1} replaced by a_i, b_i).
 *   The screen is the viewport of width x height pixels, pixel (i, j) with j = 0 the top row
 *   (docs/design.md section 6): x~ = (X/W + 1) width / 2, y~ = (1 - Y/W) height / 2 from OpenGL
 * clip coordinates (X, Y, Z, W) = view_proj * (homogeneous point).
 *
 * The guarantee (why the constants are what they are): with rho_v bounding the Euclidean screen
 * length of d(x~, y~)/dv and rho_u that of d(x~, y~)/du over the visible part of a strip, a pixel
 * is decided by a scan line at most h/2 away in v (<= 0.5 px on screen), and the polyline deviates
 * from the true curve by at most h/4 in v (<= 0.25 px) and 1/(4 rho_u) in u (<= 0.25 px). So the
 * table disagrees with the true curves only where the true curve passes within 1.0 px (Euclidean)
 * of the pixel's surface point. The paths behind these distances stay where the bounds hold: the
 * side planes are widened by 2 px, and the bounds also cover NDC depth 1 beyond the near and far
 * planes and the depth speed (src/trim/scan_density.c says why that closes the near plane).
 */
#ifndef CRISP_TRIM_H
#define CRISP_TRIM_H

#include "crisp/core.h"
#include "crisp/nurbs.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Limits that keep a hostile camera or model from asking for unbounded memory. */
#define CRISP_TRIM_MAX_ROWS (1u << 24)          /* scan lines in one face's table */
#define CRISP_TRIM_MAX_SEGMENTS_PER_PIECE 65536 /* polyline segments of one Bézier piece */

/* Checks what every function below assumes of pieces: dim 2, degree 1..15, finite coordinates,
 * positive weights. The message names the piece index and what was expected. */
crisp_status crisp_trim_pieces_check(const crisp_bezier_curve *pieces, int piece_count);

/* ---- v-scan and u-scan density --------------------------------------------------------------- */

/* A view-independent hierarchy over a face's grid of Bézier patches that lets
 * crisp_trim_scan_density bound whole blocks of patches at once (issue 12): aligned 2^g x 2^g
 * blocks of the grid (g >= 1, clipped to the grid), each with boxes of its patches' homogeneous
 * control points and of their degree-elevated first-derivative coefficients per unit of the
 * face's u and v. Built once per face (crisp_trim_density_tree_build) and reused every frame. */
typedef struct crisp_trim_density_block {
    uint32_t iu0, iv0, nu, nv; /* patches: columns iu0 .. iu0 + nu - 1, rows iv0 .. iv0 + nv - 1 */
    int32_t child[4];          /* sub-blocks; all -1: the block's patches are walked one by one */
    double u0, u1, v0, v1;     /* the block's parameter box on the face */
    double h[8];               /* lo[4], hi[4]: box of the homogeneous control points */
    double du[8], dv[8];       /* lo[4], hi[4]: box of the derivative coefficients in u, v */
} crisp_trim_density_block;

typedef struct crisp_trim_density_tree {
    int grid_u, grid_v; /* patch p = iv * grid_u + iu */
    int max_du, max_dv; /* the patches' largest degrees (checked when the tree was built) */
    int32_t root;       /* -1: no blocks (a single patch) */
    crisp_trim_density_block *blocks;
    size_t count, cap;
} crisp_trim_density_tree;

/* patches: grid_u * grid_v patches of one face, u fastest, patch (iu, iv) covering the parameter
 * box [u0, u1] x [v0, v1] of column iu and row iv. Reuses dest's buffer (zero-initialise before
 * first use). */
crisp_status crisp_trim_density_tree_build(const crisp_bezier_patch *patches, int grid_u,
                                           int grid_v, crisp_trim_density_tree *dest);
void crisp_trim_density_tree_free(crisp_trim_density_tree *t);

typedef struct crisp_trim_density_desc {
    const crisp_bezier_patch *patches; /* the face's Bézier patches (homogeneous, object space) */
    int patch_count;
    crisp_mat4 *view_proj; /* projection * view, column-major, OpenGL clip space */
    int width, height;     /* viewport in pixels */
    double v0, v1;         /* the face's v-range, cut into strip_count strips */
    int strip_count;
    int max_depth;    /* levels of 2x2 subdivision per patch and strip; 0 means 16 */
    double slack;     /* refine while the bound exceeds slack times the sampled value; 0 means 2 */
    double margin_px; /* the frustum is widened by this many pixels on each side; 0 means 2 */
    crisp_arena *scratch; /* reset by the caller between frames; NULL: an internal one is made */
    /* NULL, or 2 values per strip: the only u-range of the strip whose points need the bound
     * (sub-patches wholly outside it are dropped; see crisp_trim_plan_face for why that is sound
     * for the table). */
    const double *strip_u;
    /* NULL, or the hierarchy built from patches (crisp_trim_density_tree_build; patch_count must
     * be its grid_u * grid_v): whole blocks are culled or bounded from their boxes, and only
     * blocks whose box bound asks for many more rows than their sampled speeds are refined to
     * sub-blocks and, below the smallest blocks, to the per-patch bound. The patches are then
     * not checked again (the tree's build checked them): O(1) per face for a face far away. */
    const crisp_trim_density_tree *tree;
    /* NULL, or 2 values per strip written by crisp_trim_scan_density: a u-interval that holds
     * every point of the strip inside the widened frustum with u in the strip's u-range (empty,
     * lo > hi, when there is none): what the strip's part of the surface outside it is, is off
     * screen (the trim ribbons skip it). */
    double *vis_u;
} crisp_trim_density_desc;

typedef struct crisp_trim_density_stats {
    long subpatches; /* sub-patches examined */
    long culled;     /* sub-patches dropped as outside the (widened) frustum */
    int unbounded;   /* strips whose bound could not be made finite (W not provably > 0 at the
                        depth limit); their rho is set to HUGE_VAL */
} crisp_trim_density_stats;

/* For each strip i: rho_v[i] >= max(sup |d(x~, y~)/dv|, sup |dz~/dv|) (Euclidean, pixels per unit
 * v; z~ = Z / W the NDC depth) and rho_u[i] likewise in u, over the points of the strip's part of
 * the face that lie in the widened frustum (sides margin_px out, NDC depth in [-2, 2]) and, with
 * strip_u, have u in the strip's u-range; both 0 when no such point exists (the strip is
 * invisible). The bound comes from coefficient ratios of the degree-elevated derivatives over W's
 * coefficients with X / W confined to its rational convex hull (src/trim/scan_density.c), on
 * sub-patches refined where W is not provably positive or the bound is loose. rho_v, rho_u:
 * strip_count values each. vis_v (may be NULL): 2 values per strip, the v-interval covered by the
 * sub-patches not culled (every point of the strip inside the widened frustum lies in it; the
 * strip's bounds when invisible). stats may be NULL. */
crisp_status crisp_trim_scan_density(const crisp_trim_density_desc *desc, double *rho_v,
                                     double *rho_u, double *vis_v, crisp_trim_density_stats *stats);

/* mu[i] = ceil((b_i - a_i) rho_v[i]) for visible strips (at least 1), 0 for rho_v[i] == 0, with
 * [a_i, b_i] = vis_v[2i], vis_v[2i + 1] (vis_v NULL: the whole strip). Each strip is capped at
 * CRISP_TRIM_MAX_ROWS / strip_count rows, which a visible strip with a finite bound never needs;
 * *clamped, if not NULL, is set to 1 when a cap was hit (that strip loses the 1 px guarantee,
 * the others keep it). */
void crisp_trim_rows_from_density(const double *rho_v, const double *vis_v, int strip_count,
                                  double v0, double v1, uint32_t *mu, int *clamped);

/* ---- trim curve tessellation ----------------------------------------------------------------- */

/* Caller-owned and reused across frames: buffers grow, never shrink (free with
 * crisp_trim_polyline_free). Piece k's polyline is points first[k] .. first[k + 1] - 1 (uv pairs in
 * uv), its segments join consecutive points. */
typedef struct crisp_trim_polyline {
    int piece_count;
    int *first; /* piece_count + 1 */
    double *uv; /* 2 * first[piece_count] */
    double *t;  /* first[piece_count]: each point's parameter on its piece (in [0, 1]) */
    int capped; /* pieces that needed more than CRISP_TRIM_MAX_SEGMENTS_PER_PIECE */
    size_t cap_first, cap_uv, cap_t;
} crisp_trim_polyline;

typedef struct crisp_trim_tess_desc {
    const crisp_bezier_curve *pieces;
    int piece_count;
    double v0, v1; /* strips as for the density */
    int strip_count;
    const uint32_t *mu;  /* rows per strip */
    const double *row_v; /* 2 per strip: the v-range its rows cover; NULL: whole strips */
    const double *rho_u; /* u-density per strip */
    /* Tolerances as fractions: v within tol_v * h_i, u within tol_u / rho_u; 0 means 0.25. */
    double tol_v, tol_u;
} crisp_trim_tess_desc;

/* Each piece (or, where one piece would need many, each of its dyadic sub-pieces: only the parts
 * over visible strips are refined) gets n uniform segments in t, n the smallest count for which the
 * Filip et al. bound (max deviation of a degree-d polynomial from its chords <= d (d - 1) max|Δ²b|
 * / (8 n²)), applied to the homogeneous form and divided by the smallest weight, keeps the polyline
 * within the tolerances of every visible strip the piece's control polygon overlaps. Pieces over
 * invisible strips only get one segment. */
crisp_status crisp_trim_tessellate(const crisp_trim_tess_desc *desc, crisp_trim_polyline *dest);
void crisp_trim_polyline_free(crisp_trim_polyline *p);

/* Joins pl's pieces into chains and drops points, in place (issue 12: a face a few pixels across
 * has tens of trim pieces of one segment each, and every segment costs the table and a ribbon
 * quad). A chain is a maximal run of consecutive pieces where each piece starts exactly (bit for
 * bit) where the one before ends; the shared point is kept once. Along a chain, a point is dropped
 * when the chord that then replaces it and its neighbours stays close: there is a monotone
 * correspondence (each dropped point to a point of the chord, in order) under which every
 * dropped point lies within tol_u in u and tol_v in v of its chord point. Points matched linearly
 * in between, the old and the new polyline then differ by at most (tol_u, tol_v) per coordinate
 * at corresponding points, and the linear homotopy between them sweeps only over points that
 * close to the old polyline: any (u, v) the two classify differently lies within (tol_u, tol_v)
 * of the old polyline (the argument of crisp_trim_tessellate). First and last points of every
 * chain are kept. Afterwards pl->piece_count is the number of chains, first[] their ranges, and t
 * each kept point's parameter on its own piece. tol_u or tol_v may be HUGE_VAL (no limit in that
 * coordinate); both must be > 0. */
crisp_status crisp_trim_polyline_chains(crisp_trim_polyline *pl, double tol_u, double tol_v);

/* View-independent coarse polylines of a face's trim loops (issue 12): a face a few pixels across
 * needs its loops only to a few percent of their extent, so a frame can take one of these instead
 * of working through every piece. Level k is within tol_u[k] in u and tol_v[k] in v of the true
 * curves (in the sense of crisp_trim_polyline_chains: a linear homotopy between them sweeps only
 * over points that close to the curves): the pieces tessellated within half of that (Filip bound)
 * and joined into chains with the other half. Level 0 is the coarsest (1/16 of the pieces'
 * control-point extent in each coordinate), each next level twice as fine. */
#define CRISP_TRIM_LOD_LEVELS 6
typedef struct crisp_trim_lod {
    int levels;    /* 0: none (no pieces, or pieces without extent in u or v) */
    double box[4]; /* u0, u1, v0, v1: the pieces' control points */
    double tol_u[CRISP_TRIM_LOD_LEVELS], tol_v[CRISP_TRIM_LOD_LEVELS];
    crisp_trim_polyline level[CRISP_TRIM_LOD_LEVELS];
} crisp_trim_lod;

/* Checks the pieces (crisp_trim_pieces_check) and builds the levels; reuses dest's buffers
 * (zero-initialise before first use). */
crisp_status crisp_trim_lod_build(const crisp_bezier_curve *pieces, int piece_count,
                                  crisp_trim_lod *dest);
void crisp_trim_lod_free(crisp_trim_lod *lod);

/* ---- the two-level u-intercept table --------------------------------------------------------- */

typedef struct crisp_trim_table {
    double v0, v1;
    int strip_count;
    int all_inside;       /* 1: the face has no trim loops, every (u, v) in the v-range is inside */
    uint32_t row_count;   /* sum of mu */
    uint32_t *row_base;   /* strip_count + 1: strip i owns rows row_base[i] .. row_base[i+1] - 1 */
    uint32_t *row_offset; /* row_count + 1: row r holds u[row_offset[r] .. row_offset[r+1] - 1] */
    double *u;            /* crossings, sorted within each row */
    double *row_v;        /* 2 per strip: the v-range [a_i, b_i] its rows cover */
    double *row_scale;    /* per strip: mu_i / (b_i - a_i), rows per unit v */
    double strip_scale;   /* strip_count / (v1 - v0) */
    size_t cap_strips, cap_rows, cap_u, cap_row_v, cap_row_scale;
} crisp_trim_table;

typedef struct crisp_trim_table_desc {
    const crisp_trim_polyline *polyline; /* NULL or no pieces: a face without loops */
    double v0, v1;
    int strip_count;
    const uint32_t *mu;  /* rows per strip */
    const double *row_v; /* 2 per strip: the v-range its rows cover; NULL: whole strips */
} crisp_trim_table_desc;

/* Builds the table in O(segments + crossings) with a counting pass and a filling pass; rows are
 * then sorted. Reuses dest's buffers (growing only). */
crisp_status crisp_trim_table_build(const crisp_trim_table_desc *desc, crisp_trim_table *dest);
/* 1 when (u, v) is inside the trimmed face. v outside [v0, v1], in a strip with no rows
 * (invisible) or NaN: 0. v exactly on a strip boundary belongs to the strip above it (the
 * boundary is the strip's bottom), v1 to the last strip; v in a strip but outside its row range
 * (a part the density bound found invisible) uses the nearest row; u equal to a crossing counts
 * that crossing as not left of u. */
int crisp_trim_table_test(const crisp_trim_table *t, double u, double v);
/* Bytes of the table's content: per strip a row base and a row range (4 + 16 bytes), per row an
 * offset (4 bytes), per crossing 8 bytes. */
size_t crisp_trim_table_bytes(const crisp_trim_table *t);
void crisp_trim_table_free(crisp_trim_table *t);

/* ---- per-face, per-frame plan ---------------------------------------------------------------- */

/* Everything one face needs per frame, kept across frames: planning the same face at the same
 * image size again allocates nothing unless the densities grow. Zero-initialise before first use.
 */
typedef struct crisp_trim_plan {
    int strip_count;
    double *rho_v, *rho_u;
    double *vis_v;   /* 2 per strip */
    double *vis_u;   /* 2 per strip (crisp_trim_density_desc.vis_u) */
    double *strip_u; /* 2 per strip: the u-range the trim loops can reach in the strip */
    double v0, v1;   /* the strips' v-range: the face's, narrowed to the loops' (the table's) */
    uint32_t *mu;
    int clamped; /* some strip hit its row cap (crisp_trim_rows_from_density) */
    int chains;  /* the polyline holds chains (crisp_trim_plan_desc.chains), not pieces */
    crisp_trim_density_stats density_stats;
    crisp_trim_polyline polyline;
    crisp_trim_table table;
    crisp_arena *scratch;
    int cap_strips;
} crisp_trim_plan;

typedef struct crisp_trim_plan_desc {
    const crisp_bezier_patch *patches;
    int patch_count;
    const crisp_bezier_curve *pieces; /* may be NULL with piece_count 0: no trimming */
    int piece_count;
    crisp_mat4 *view_proj;
    int width, height;
    double v0, v1;                       /* the face's v-range */
    int strip_count;                     /* n_V; 0 means 16 */
    const crisp_trim_density_tree *tree; /* NULL, or as crisp_trim_density_desc.tree */
    /* NULL, or an arena for the density bound's scratch, reset by crisp_trim_plan_face (and free
     * to be reused for another face afterwards): a planner of many faces keeps one per thread
     * instead of one per face (issue 12: 13,573 small faces kept about 600 MB of scratch). */
    crisp_arena *scratch;
    /* 1: the polyline is crisp_trim_polyline_chains of one within half the tolerances, with the
     * other half: chains instead of pieces (for faces a few pixels across, issue 12). The table's
     * guarantee is the same. */
    int chains;
    /* NULL, or crisp_trim_lod_build of the same pieces: the strips' u-ranges are taken from its
     * box and, where one of its levels is within the polyline tolerances this frame needs, the
     * polyline is that level (no piece is looked at: the pieces were checked when it was built).
     * Else the pieces as without it. */
    const crisp_trim_lod *lod;
} crisp_trim_plan_desc;

/* Only points inside the loops can be inside the face, so the strips cover the face's v-range
 * narrowed to the v-range of the loops' control points, and in each strip the density bound is
 * taken over the u-range of the control points of the pieces that reach the strip (a point inside
 * the loops has boundary points to its left and right on its own scan line). Outside that part
 * the table answers "outside" whatever the row spacing: no row's crossing lies outside the
 * strip's u-range and every row has an even number of crossings. This keeps real faces whose
 * surface is wild where the trim has cut it away (knot noise in exported files) from asking for
 * millions of rows. */
crisp_status crisp_trim_plan_face(const crisp_trim_plan_desc *desc, crisp_trim_plan *dest);
void crisp_trim_plan_free(crisp_trim_plan *plan);

/* ---- exact reference ------------------------------------------------------------------------- */

/* 1 when (u, v) is inside by parity against the true rational curves, with the same half-open
 * rule as the table (a crossing at v(t) = v counts where the curve passes from v(t) < v to
 * v(t) >= v or back) and counting crossings with u(t) < u. Roots are isolated by de Casteljau
 * subdivision with the convex hull property down to the precision of doubles; no tolerance of its
 * own. Pieces must pass crisp_trim_pieces_check. Slow; for tests and the exact renderer. */
int crisp_trim_exact_classify(const crisp_bezier_curve *pieces, int piece_count, double u,
                              double v);
/* Euclidean uv distance from (u, v) to the nearest point of the true curves, within a relative
 * 1e-9 or 1e-12 times the curves' coordinate extent, whichever is larger (branch and bound on
 * control-point boxes). */
double crisp_trim_exact_distance(const crisp_bezier_curve *pieces, int piece_count, double u,
                                 double v);

#ifdef __cplusplus
}
#endif
#endif
