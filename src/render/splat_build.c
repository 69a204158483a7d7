/* The splat builder (issue 12, src/render/splat.h): point samples of one trimmed face such that
 * every point of the trimmed face lies within a given Euclidean radius r of a sample.
 *
 * The proof (also docs/status/issue-12-splats.md, "Builder"). The face's Bézier patches are
 * rational with positive weights (checked), so the surface over any parameter rectangle of a
 * patch lies in the convex hull H of the Euclidean control points of the patch restricted to it
 * (de Casteljau), and the surface over a block of patches in the union of their hulls.
 *   (1) For a point X, |Y - X| is convex in Y, so its largest value over a hull is taken at a
 *       control point: R_X = max_i |P_i - X| bounds |S(q) - X| for every q of the cell.
 * Cells: blocks of the face's patch grid, halved by patches while they fail, then rectangles of
 * one patch (cut into grids of about square cells while they fail). For
 * each cell, with its closed rectangle K and centre c:
 *   - Curve test: the trim pieces are halved (control-point boxes, which hold each sub-piece)
 *     until every box misses K (no curve point in K), or a sub-piece's end point b lies in K (a
 *     point of the curve in K), or 2^-44 of the piece's range is reached with a box touching K
 *     (b: that end point clamped into K, a point of K within 2^-44 of a piece of the curve).
 *   - No curve point in K: K is wholly inside or wholly outside (the parity of the crossings to
 *     the left is constant on a connected set that misses the curves); c decides
 *     (crisp_trim_exact_classify). Outside: dropped (no point of the face). Inside: its
 *     sub-cells inherit the class without a test.
 *   - The sample point x of the cell: c when c is inside, else a curve point in K (b, or one
 *     nearer c found by a pruned search: a smaller R_x). Both are points
 *     of the trimmed face (inside, or on a trim curve) and lie in K.
 *   - R_x <= r: a splat at S(x); by (1) it covers every point of the cell's surface, trimmed or
 *     not. Otherwise the cell is split and its parts are treated the same way.
 * Every inside point lies in some final cell that is not dropped (dropped cells hold none), so it
 * is within r of that cell's splat. A cell near a curve whose centre is outside gets a splat on
 * the curve even when the trimmed face only touches it: the count's price for not having to
 * refine along the curves.
 * The bounds are tested with a margin for rounding and for storing p as float offsets from the
 * origin (set->origin, the face's box centre), so the stored floats meet the radius as well.
 * set->radius is the largest R_x met plus that margin (at most the radius asked); each splat's
 * rho is its own cell's R_x plus the margin, so every point of the trimmed face lies within the
 * rho of some splat (a store can thin a set with it: splat_store.c).
 * Cells of a patch split until 2^-24 of the patch (then CRISP_ERR_NUMERIC); max_count bounds the
 * splats and (64 max_count + 2^20) the cells visited (CRISP_ERR_LIMIT).
 */
#include <float.h>
#include <immintrin.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/compiler.h"
#include "crisp/trim.h"
#include "nurbs/nurbs_internal.h"
#include "splat.h"

typedef struct cell cell;

#define SPLAT_MAX_CELL_DEPTH 24 /* a cell is at least 2^-24 of its patch's parameter sides */
/* Side of the squares a failing cell is cut into, in units of the bound B (a flat square of side
 * sqrt(2) B meets R_C = B exactly; a little less leaves room for curvature). The counts per
 * direction are rounded to the nearest (a cell a little too big is split again): on impeller.igs
 * 1-7% fewer splats than rounding up. Cells near curves are cut the same way (halving them in
 * both directions instead gave 10% more splats on impeller and 27% more on linkrods at radii of
 * d/2..d/32 per face, 12% fewer on linkrods at D/512..D/1024 of the model). */
#define SPLAT_GRID_SIDE 1.4

#define SPLAT_FIND_DEPTH 44 /* halvings of a trim piece looking for a point of it in a cell */
/* Sub-pieces looked at per piece and cell (a piece running along a cell's edge just outside it
 * could otherwise be halved everywhere): past it the answer is 2 (see curve_point). */
#define SPLAT_FIND_BUDGET 4096

typedef struct splat_ctx {
    const crisp_scene *scene;
    const crisp_scene_face *f;
    const crisp_surface *surface;
    crisp__surface_normals normals; /* crisp_surface_normal of surface, cheaper */
    const crisp_bezier_curve *pieces;
    int piece_count;
    double piece_box[4]; /* umin, umax, vmin, vmax of every piece's control points */
    double (*boxes)[4];  /* per piece */
    uint8_t *poly;       /* per piece: every weight is 1 (see sub_point) */
    /* The pieces the cell tests look at, in piece order: every piece in block_cells; in
     * patch_cells those that can meet the patch's cells (near: their box meets the patch's
     * rectangle; left: they can cross a scan line of the patch left of its points). */
    int *all, *near_list, *left_list;
    const int *near_idx, *left_idx;
    int near_count, left_count;
    uint32_t face;
    double r_in;   /* the bound every cell meets: the radius less the rounding margin */
    double margin; /* that margin */
    double got;    /* the largest bound met */
    uint32_t max_count;
    uint64_t cells, max_cells;
    crisp_splat_set *set;
    uint32_t cap;
    double *cpw, *euc; /* a cell's control points, homogeneous and Euclidean */
    double *col;       /* col_patch restricted to [col_s0, col_s1] in u */
    const crisp_bezier_patch *col_patch;
    double col_s0, col_s1;
    /* eval_rows: EVAL_CACHE entries of eval_patch's rows summed at an s (eval_s: its bits;
     * eval_ok: the entry is filled) */
    const crisp_bezier_patch *eval_patch;
    uint64_t eval_s[64];
    uint8_t eval_ok[64];
    double *eval_rows;
    size_t eval_stride;
    int avx;     /* restrict_points_avx may run */
    cell *stack; /* pending cells of a patch */
    size_t stack_count, stack_cap;
} splat_ctx;

/* ---- small Bernstein helpers ---------------------------------------------------------------- */

/* de Casteljau split of d + 1 points of `dim` coordinates (stride dim) at t. */
static void split_points(const double *c, int d, int dim, double t, double *lo, double *hi)
{
    double tmp[(CRISP_MAX_DEGREE + 1) * 4];
    memcpy(tmp, c, sizeof(double) * (size_t)(d + 1) * (size_t)dim);
    for (int k = 0; k < dim; k++) {
        lo[k] = tmp[k];
        hi[d * dim + k] = tmp[d * dim + k];
    }
    for (int r = 1; r <= d; r++) {
        for (int i = 0; i <= d - r; i++)
            for (int k = 0; k < dim; k++)
                tmp[i * dim + k] = (1 - t) * tmp[i * dim + k] + t * tmp[(i + 1) * dim + k];
        for (int k = 0; k < dim; k++) {
            lo[r * dim + k] = tmp[k];
            hi[(d - r) * dim + k] = tmp[(d - r) * dim + k];
        }
    }
}

/* Restrict d + 1 homogeneous 4D points (stride `stride` doubles) to the local interval [a, b],
 * in place: de Casteljau's left part at b, then the right part of that at a / b. */
static void restrict_points(double *c, int d, ptrdiff_t stride, double a, double b)
{
    if (b < 1.0) {
        const double s = 1.0 - b;
        for (int r = 1; r <= d; r++)
            for (int i = d; i >= r; i--) {
                double *p = c + i * stride, *q = p - stride;
                p[0] = s * q[0] + b * p[0];
                p[1] = s * q[1] + b * p[1];
                p[2] = s * q[2] + b * p[2];
                p[3] = s * q[3] + b * p[3];
            }
    }
    if (a > 0.0) {
        const double t = b > 0.0 ? a / b : 0.0, s = 1.0 - t;
        for (int r = 1; r <= d; r++)
            for (int i = 0; i <= d - r; i++) {
                double *p = c + i * stride, *q = p + stride;
                p[0] = s * p[0] + t * q[0];
                p[1] = s * p[1] + t * q[1];
                p[2] = s * p[2] + t * q[2];
                p[3] = s * p[3] + t * q[3];
            }
    }
}

/* restrict_points with the four coordinates of a point in one AVX register: the same products
 * and sums in the same order (no fused multiply-add), so the same bits; about a third of the
 * instructions (issue 12, session 13: restriction was 18% of imp49 default's first frame). */
__attribute__((target("avx"))) static ALWAYS_INLINE void
restrict_points_avx_body(double *c, int d, ptrdiff_t stride, double a, double b)
{
    if (b < 1.0) {
        const __m256d vs = _mm256_set1_pd(1.0 - b), vb = _mm256_set1_pd(b);
        for (int r = 1; r <= d; r++)
            for (int i = d; i >= r; i--) {
                double *p = c + i * stride, *q = p - stride;
                __m256d sq = _mm256_mul_pd(vs, _mm256_loadu_pd(q));
                __m256d bp = _mm256_mul_pd(vb, _mm256_loadu_pd(p));
                _mm256_storeu_pd(p, _mm256_add_pd(sq, bp));
            }
    }
    if (a > 0.0) {
        const double t = b > 0.0 ? a / b : 0.0, s = 1.0 - t;
        const __m256d vs = _mm256_set1_pd(s), vt = _mm256_set1_pd(t);
        for (int r = 1; r <= d; r++)
            for (int i = 0; i <= d - r; i++) {
                double *p = c + i * stride, *q = p + stride;
                __m256d sp = _mm256_mul_pd(vs, _mm256_loadu_pd(p));
                __m256d tq = _mm256_mul_pd(vt, _mm256_loadu_pd(q));
                _mm256_storeu_pd(p, _mm256_add_pd(sp, tq));
            }
    }
}

/* The body for any degree, and with the degree a constant for the common ones (bicubic and
 * biquadratic patches: the loops unrolled, the same operations). */
__attribute__((target("avx"))) static void restrict_points_avx(double *c, int d, ptrdiff_t stride,
                                                               double a, double b)
{
    restrict_points_avx_body(c, d, stride, a, b);
}

__attribute__((target("avx"))) static void restrict_points_avx2(double *c, ptrdiff_t stride,
                                                                double a, double b)
{
    restrict_points_avx_body(c, 2, stride, a, b);
}

__attribute__((target("avx"))) static void restrict_points_avx3(double *c, ptrdiff_t stride,
                                                                double a, double b)
{
    restrict_points_avx_body(c, 3, stride, a, b);
}

static void restrict_any(const splat_ctx *c, double *pts, int d, ptrdiff_t stride, double a,
                         double b)
{
    if (c->avx && d == 3)
        restrict_points_avx3(pts, stride, a, b);
    else if (c->avx && d == 2)
        restrict_points_avx2(pts, stride, a, b);
    else if (c->avx)
        restrict_points_avx(pts, d, stride, a, b);
    else
        restrict_points(pts, d, stride, a, b);
}

/* max_i |P_i - x| over n Euclidean points. */
static double hull_radius(const double *e, int n, const double x[3])
{
    double m = 0.0;
    for (int i = 0; i < n; i++) {
        const double *h = e + 3 * i;
        double dx = h[0] - x[0], dy = h[1] - x[1], dz = h[2] - x[2];
        double d = dx * dx + dy * dy + dz * dz;
        if (d > m) m = d;
    }
    return sqrt(m);
}

/* Euclidean points of n homogeneous ones. */
static void euclid(const double *cpw, int n, double *e)
{
    for (int i = 0; i < n; i++)
        for (int q = 0; q < 3; q++)
            e[3 * i + q] = cpw[4 * i + q] / cpw[4 * i + 3];
}

/* euclid with a point's four coordinates divided at once (the same quotients); writes e[3 n]
 * too (the last point's w / w: the arrays have room). */
__attribute__((target("avx"))) static void euclid_avx(const double *cpw, int n, double *e)
{
    for (int i = 0; i < n; i++)
        _mm256_storeu_pd(
            e + 3 * i, _mm256_div_pd(_mm256_loadu_pd(cpw + 4 * i), _mm256_set1_pd(cpw[4 * i + 3])));
}

static void euclid_any(const splat_ctx *c, const double *cpw, int n, double *e)
{
    if (c->avx)
        euclid_avx(cpw, n, e);
    else
        euclid(cpw, n, e);
}

/* crisp_bezier_patch_eval(p, s, t, x) with p's rows summed at the last 64 values of s kept (the
 * cells of a column share s; other cells' subtrees come in between): the same bits. */
#define EVAL_CACHE 64
static void patch_point(splat_ctx *c, const crisp_bezier_patch *p, double s, double t, double x[3])
{
    uint64_t bits;
    memcpy(&bits, &s, sizeof bits);
    if (c->eval_patch != p) {
        memset(c->eval_ok, 0, sizeof c->eval_ok);
        c->eval_patch = p;
    }
    size_t e = (size_t)((bits * 0x9E3779B97F4A7C15ull) >> 58); /* 6 bits: EVAL_CACHE */
    double *rows = c->eval_rows + e * c->eval_stride;
    if (!c->eval_ok[e] || c->eval_s[e] != bits) {
        crisp__bezier_patch_eval_rows_s(p, s, rows);
        c->eval_ok[e] = 1;
        c->eval_s[e] = bits;
    }
    crisp__bezier_patch_eval_rows(p, rows, t, x);
}

/* ---- emitting -------------------------------------------------------------------------------- */

/* A splat at S(u, v) = x for a cell whose surface lies within rc of x (R_X of the cell). */
static crisp_status emit(splat_ctx *c, double u, double v, const double x[3], double rc)
{
    crisp_splat_set *set = c->set;
    if (c->max_count && set->count >= c->max_count)
        return crisp_error(CRISP_ERR_LIMIT, "face %u: more than %u splats at radius %g", c->face,
                           c->max_count, c->r_in);
    if (set->count == c->cap) {
        uint32_t cap = c->cap ? 2 * c->cap : 64;
        crisp_splat *n = crisp_realloc_array(set->splats, cap, sizeof *n);
        if (!n) return crisp_error(CRISP_ERR_NO_MEMORY, "splats of face %u", c->face);
        set->splats = n;
        c->cap = cap;
    }
    crisp_splat *sp = &set->splats[set->count++];
    double nrm[3];
    crisp__surface_normals_at(&c->normals, u, v, nrm);
    for (int k = 0; k < 3; k++) {
        sp->p[k] = (float)(x[k] - set->origin[k]);
        sp->n[k] = (float)nrm[k];
    }
    sp->uv[0] = (float)u;
    sp->uv[1] = (float)v;
    /* its cell's radius with the margin (as set->radius), rounded up to a float */
    double rho = rc + c->margin;
    float fr = (float)rho;
    if ((double)fr < rho) fr = nextafterf(fr, INFINITY);
    sp->rho = fr;
    return CRISP_OK;
}

/* ---- cell-curve test --------------------------------------------------------------------------
 */

/* The searches below read a sub-curve of degree d as d + 1 points at stride st: a rational
 * piece's homogeneous (u w, v w, w) (rational = 1), or a polynomial piece's (u, v) alone (every
 * weight 1: the halvings keep every weight exactly 1, 0.5 * 1 + 0.5 * 1, and u = x / 1 = x, so
 * the two take the same steps on the same numbers, the polynomial one without divisions). */
static inline void sub_point(const double *c, ptrdiff_t st, int rational, int i, double x[2])
{
    const double *q = c + st * i;
    if (rational)
        x[0] = q[0] / q[2], x[1] = q[1] / q[2];
    else
        x[0] = q[0], x[1] = q[1];
}

/* The (u, v) box of a sub-curve's points. */
static void sub_box(const double *c, ptrdiff_t st, int rational, int d, double lo[2], double hi[2])
{
    lo[0] = lo[1] = HUGE_VAL, hi[0] = hi[1] = -HUGE_VAL;
    for (int i = 0; i <= d; i++) {
        double x[2];
        sub_point(c, st, rational, i, x);
        for (int q = 0; q < 2; q++) {
            lo[q] = x[q] < lo[q] ? x[q] : lo[q];
            hi[q] = x[q] > hi[q] ? x[q] : hi[q];
        }
    }
}

/* split_points at 0.5 of a polynomial sub-curve's (u, v) (stride st) into lo, hi (stride 2). */
static void halve_uv(const double *c, ptrdiff_t st, int d, double *lo, double *hi)
{
    const double t = 0.5;
    double tmp[2 * (CRISP_MAX_DEGREE + 1)];
    for (int i = 0; i <= d; i++)
        tmp[2 * i] = c[st * i], tmp[2 * i + 1] = c[st * i + 1];
    lo[0] = tmp[0], lo[1] = tmp[1];
    hi[2 * d] = tmp[2 * d], hi[2 * d + 1] = tmp[2 * d + 1];
    for (int r = 1; r <= d; r++) {
        for (int i = 0; i <= d - r; i++) {
            tmp[2 * i] = (1 - t) * tmp[2 * i] + t * tmp[2 * i + 2];
            tmp[2 * i + 1] = (1 - t) * tmp[2 * i + 1] + t * tmp[2 * i + 3];
        }
        lo[2 * r] = tmp[0], lo[2 * r + 1] = tmp[1];
        hi[2 * (d - r)] = tmp[2 * (d - r)], hi[2 * (d - r) + 1] = tmp[2 * (d - r) + 1];
    }
}

/* A sub-curve halved at 0.5 into lo and hi (room for 3 (d + 1) doubles each); returns their
 * stride. A rational sub-curve's points are contiguous (st = 3). */
static ptrdiff_t halve(const double *c, ptrdiff_t st, int rational, int d, double *lo, double *hi)
{
    if (rational) {
        split_points(c, d, 3, 0.5, lo, hi);
        return 3;
    }
    halve_uv(c, st, d, lo, hi);
    return 2;
}

/* Whether the sub-curve meets the closed rectangle rect (u0, u1, v0, v1): 0 when it provably does
 * not (its control-point box, which holds it, misses the rectangle at every level), 1 with a
 * point of the curve in the rectangle in pt (an end point of a sub-curve), 2 when the halvings ran
 * out (2^-SPLAT_FIND_DEPTH of the piece's parameter range, or SPLAT_FIND_BUDGET sub-pieces) with a
 * sub-curve's box still touching the rectangle: pt is that sub-curve's end point clamped into the
 * rectangle, within the box's size of the curve. The cell then counts as near a curve: its sample
 * still covers it (any point of the cell does, by (1)); only its being on the curve is
 * approximate. */
static int curve_point(const double *c, ptrdiff_t st, int rational, int d, const double rect[4],
                       int depth, int *budget, double pt[2])
{
    double lo[2], hi[2];
    sub_box(c, st, rational, d, lo, hi);
    if (hi[0] < rect[0] || lo[0] > rect[1] || hi[1] < rect[2] || lo[1] > rect[3]) return 0;
    for (int e = 0; e <= d; e += d) {
        double x[2];
        sub_point(c, st, rational, e, x);
        if (x[0] >= rect[0] && x[0] <= rect[1] && x[1] >= rect[2] && x[1] <= rect[3]) {
            pt[0] = x[0], pt[1] = x[1];
            return 1;
        }
    }
    if (depth >= SPLAT_FIND_DEPTH || --*budget < 0) {
        double x[2];
        sub_point(c, st, rational, 0, x);
        pt[0] = fmin(fmax(x[0], rect[0]), rect[1]);
        pt[1] = fmin(fmax(x[1], rect[2]), rect[3]);
        return 2;
    }
    double l[3 * (CRISP_MAX_DEGREE + 1)], r[3 * (CRISP_MAX_DEGREE + 1)];
    ptrdiff_t hs = halve(c, st, rational, d, l, r);
    /* The middle point first: a curve crossing the rectangle is found at the first levels. */
    int got = curve_point(l, hs, rational, d, rect, depth + 1, budget, pt);
    if (got == 1) return 1;
    double p2[2];
    int got2 = curve_point(r, hs, rational, d, rect, depth + 1, budget, p2);
    if (got2 == 1 || (got2 && !got)) {
        pt[0] = p2[0], pt[1] = p2[1];
        return got2;
    }
    return got;
}

/* The trim curves against a cell's closed rectangle (curve_point's answer over every piece). */
static int cell_curve_point(const splat_ctx *c, const double rect[4], double pt[2])
{
    int got = 0;
    double q[2];
    for (int i = 0; i < c->near_count; i++) {
        const int k = c->near_idx[i];
        const double *b = c->boxes[k];
        if (b[1] < rect[0] || b[0] > rect[1] || b[3] < rect[2] || b[2] > rect[3]) continue;
        int budget = SPLAT_FIND_BUDGET;
        const crisp_bezier_curve *p = &c->pieces[k];
        int g = curve_point(p->cpw, 3, !c->poly[k], p->degree, rect, 0, &budget, q);
        if (g == 1) {
            pt[0] = q[0], pt[1] = q[1];
            return 1;
        }
        if (g && !got) {
            pt[0] = q[0], pt[1] = q[1];
            got = g;
        }
    }
    return got;
}

/* A point of the sub-curve in the closed rectangle near its centre m (a sample point there has a
 * smaller hull radius than one at the rectangle's edge): the sub-curves' end points in the
 * rectangle, searched nearer half first and pruned by box distance, down to sub-curves of a
 * sixteenth of the rectangle. best: squared uv distance of pt to m so far. */
static void curve_point_near(const double *c, ptrdiff_t st, int rational, int d,
                             const double rect[4], const double m[2], double tiny, int depth,
                             double pt[2], double *best)
{
    double lo[2], hi[2];
    sub_box(c, st, rational, d, lo, hi);
    if (hi[0] < rect[0] || lo[0] > rect[1] || hi[1] < rect[2] || lo[1] > rect[3]) return;
    double ex = fmax(fmax(lo[0] - m[0], m[0] - hi[0]), 0.0);
    double ey = fmax(fmax(lo[1] - m[1], m[1] - hi[1]), 0.0);
    if (ex * ex + ey * ey >= *best) return;
    for (int e = 0; e <= d; e += d) {
        double x[2];
        sub_point(c, st, rational, e, x);
        double dd = (x[0] - m[0]) * (x[0] - m[0]) + (x[1] - m[1]) * (x[1] - m[1]);
        if (x[0] >= rect[0] && x[0] <= rect[1] && x[1] >= rect[2] && x[1] <= rect[3] &&
            dd < *best) {
            *best = dd;
            pt[0] = x[0], pt[1] = x[1];
        }
    }
    if (depth >= SPLAT_FIND_DEPTH || fmax(hi[0] - lo[0], hi[1] - lo[1]) <= tiny) return;
    double l[3 * (CRISP_MAX_DEGREE + 1)], r[3 * (CRISP_MAX_DEGREE + 1)];
    ptrdiff_t hs = halve(c, st, rational, d, l, r);
    curve_point_near(l, hs, rational, d, rect, m, tiny, depth + 1, pt, best);
    curve_point_near(r, hs, rational, d, rect, m, tiny, depth + 1, pt, best);
}

/* pt: a point of the curves in the rectangle (cell_curve_point's); moved to one nearer the
 * centre when the search finds one. */
static void cell_curve_point_near(const splat_ctx *c, const double rect[4], double pt[2])
{
    double m[2] = {0.5 * (rect[0] + rect[1]), 0.5 * (rect[2] + rect[3])};
    double best = (pt[0] - m[0]) * (pt[0] - m[0]) + (pt[1] - m[1]) * (pt[1] - m[1]);
    double tiny = 0.0625 * fmax(rect[1] - rect[0], rect[3] - rect[2]);
    for (int i = 0; i < c->near_count; i++) {
        const int k = c->near_idx[i];
        const double *b = c->boxes[k];
        if (b[1] < rect[0] || b[0] > rect[1] || b[3] < rect[2] || b[2] > rect[3]) continue;
        const crisp_bezier_curve *p = &c->pieces[k];
        curve_point_near(p->cpw, 3, !c->poly[k], p->degree, rect, m, tiny, 0, pt, &best);
    }
}

/* crisp_trim_exact_classify over the pieces that can cross (u, v)'s scan line left of u: its
 * parity is the exclusive or of the pieces' own, and a piece whose control points all have
 * v >= v_s, or all v < v_s, or all u >= u (the same quotients as the classifier's) adds 0. */
static int classify(const splat_ctx *c, double u, double v)
{
    int parity = 0;
    for (int i = 0; i < c->left_count; i++) {
        const int k = c->left_idx[i];
        const double *b = c->boxes[k];
        if (b[2] < v && b[3] >= v && b[0] < u)
            parity ^= crisp_trim_exact_classify(c->pieces + k, 1, u, v);
    }
    return parity;
}

/* ---- cells ------------------------------------------------------------------------------------
 */

/* One patch's cells, depth first; each cell's control points are restricted from the patch. */
typedef struct cell {
    double s0, s1, t0, t1; /* local parameters in the top patch */
    int known;             /* 1: no curve meets the cell and it is inside */
} cell;

static crisp_status push_cell(splat_ctx *c, cell k)
{
    if (c->stack_count == c->stack_cap) {
        size_t cap = c->stack_cap ? 2 * c->stack_cap : 256;
        cell *n = crisp_realloc_array(c->stack, cap, sizeof *n);
        if (!n) return crisp_error(CRISP_ERR_NO_MEMORY, "splat cells of face %u", c->face);
        c->stack = n;
        c->stack_cap = cap;
    }
    c->stack[c->stack_count++] = k;
    return CRISP_OK;
}

/* Lengths of the Euclidean control net along u and v (the longest row and column): how long the
 * cell is in model units, for choosing how to split it (only a guide; the bounds are checked). */
static void net_lengths(const double *e, int du, int dv, double *lu, double *lv)
{
    const int nu = du + 1;
    double mu = 0.0, mv = 0.0;
    for (int j = 0; j <= dv; j++) {
        double l = 0.0;
        for (int i = 0; i < du; i++) {
            const double *a = e + 3 * (j * nu + i), *b = a + 3;
            l += sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) +
                      (b[2] - a[2]) * (b[2] - a[2]));
        }
        mu = fmax(mu, l);
    }
    for (int i = 0; i <= du; i++) {
        double l = 0.0;
        for (int j = 0; j < dv; j++) {
            const double *a = e + 3 * (j * nu + i), *b = a + 3 * nu;
            l += sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) +
                      (b[2] - a[2]) * (b[2] - a[2]));
        }
        mv = fmax(mv, l);
    }
    *lu = mu;
    *lv = mv;
}

/* The pieces the cells of patch top look at (splat_ctx.near_idx, left_idx): the tests skip the
 * others for every cell of the patch (its cells' rectangles and centres lie in the patch's
 * rectangle, up to the rounding of top->u0 + s du: widened by far more), so the same answers in
 * the same piece order. */
static void patch_pieces(splat_ctx *c, const crisp_bezier_patch *top)
{
    double mu = 1e-9 * (fabs(top->u0) + fabs(top->u1)), mv = 1e-9 * (fabs(top->v0) + fabs(top->v1));
    double u0 = top->u0 - mu, u1 = top->u1 + mu, v0 = top->v0 - mv, v1 = top->v1 + mv;
    int nn = 0, nl = 0;
    for (int k = 0; k < c->piece_count; k++) {
        const double *b = c->boxes[k];
        if (!(b[1] < u0 || b[0] > u1 || b[3] < v0 || b[2] > v1)) c->near_list[nn++] = k;
        if (b[2] < v1 && b[3] >= v0 && b[0] < u1) c->left_list[nl++] = k;
    }
    c->near_idx = c->near_list, c->near_count = nn;
    c->left_idx = c->left_list, c->left_count = nl;
}

static void all_pieces(splat_ctx *c)
{
    c->near_idx = c->left_idx = c->all;
    c->near_count = c->left_count = c->piece_count;
}

static crisp_status patch_cells_in(splat_ctx *c, const crisp_bezier_patch *top, int known);

static crisp_status patch_cells(splat_ctx *c, const crisp_bezier_patch *top, int known)
{
    patch_pieces(c, top);
    crisp_status st = patch_cells_in(c, top, known);
    all_pieces(c);
    return st;
}

static crisp_status patch_cells_in(splat_ctx *c, const crisp_bezier_patch *top, int known)
{
    const int n = (top->du + 1) * (top->dv + 1);
    const double du = top->u1 - top->u0, dv = top->v1 - top->v0;
    const double min_size = ldexp(1.0, -SPLAT_MAX_CELL_DEPTH);
    crisp_status st;
    c->stack_count = 0;
    if ((st = push_cell(c, (cell){0.0, 1.0, 0.0, 1.0, known}))) return st;
    while (c->stack_count > 0) {
        cell k = c->stack[--c->stack_count];
        double *cpw = c->cpw, *e = c->euc;
        if (++c->cells > c->max_cells)
            return crisp_error(CRISP_ERR_LIMIT, "face %u: more than %llu cells at radius %g",
                               c->face, (unsigned long long)c->max_cells, c->r_in);
        double rect[4] = {top->u0 + k.s0 * du, top->u0 + k.s1 * du, top->v0 + k.t0 * dv,
                          top->v0 + k.t1 * dv};
        double sc = 0.5 * (k.s0 + k.s1), tc = 0.5 * (k.t0 + k.t1);
        double uc = top->u0 + sc * du, vc = top->v0 + tc * dv;
        int inside, near = 0;
        double pt[2] = {uc, vc};
        if (k.known)
            inside = 1;
        else {
            near = cell_curve_point(c, rect, pt);
            inside = classify(c, uc, vc);
            if (!near && !inside) continue; /* wholly outside */
            if (inside)
                pt[0] = uc, pt[1] = vc;
            else
                cell_curve_point_near(c, rect, pt);
        }
        /* The u-restriction of the last cell's column is kept: cells of a grid come column by
         * column. */
        const int nu_ = top->du + 1, nv_ = top->dv + 1;
        if (c->col_patch != top || c->col_s0 != k.s0 || c->col_s1 != k.s1) {
            memcpy(c->col, top->cpw, sizeof(double) * 4 * (size_t)n);
            if (k.s0 > 0.0 || k.s1 < 1.0)
                for (int j = 0; j < nv_; j++)
                    restrict_any(c, c->col + 4 * j * nu_, top->du, 4, k.s0, k.s1);
            c->col_patch = top, c->col_s0 = k.s0, c->col_s1 = k.s1;
        }
        memcpy(cpw, c->col, sizeof(double) * 4 * (size_t)n);
        if (k.t0 > 0.0 || k.t1 < 1.0)
            for (int i = 0; i < nu_; i++)
                restrict_any(c, cpw + 4 * i, top->dv, 4 * (ptrdiff_t)nu_, k.t0, k.t1);
        euclid_any(c, cpw, n, e);
        double x[3];
        patch_point(c, top, (pt[0] - top->u0) / du, (pt[1] - top->v0) / dv, x);
        double rc = hull_radius(e, n, x), bound = c->r_in;
        if (rc <= bound) {
            if (rc > c->got) c->got = rc;
            if ((st = emit(c, pt[0], pt[1], x, rc))) return st;
            continue;
        }
        /* Split into a grid of about square cells of the size the bound allows (a flat square of
         * side sqrt(2) B has R_C = B), from the control net's lengths; a cell only a little too
         * big is halved along its longer side. The parts of a cell near a curve are classified
         * again; the others inherit "inside". */
        double lu, lv;
        net_lengths(e, top->du, top->dv, &lu, &lv);
        int known = inside && !near;
        double side = SPLAT_GRID_SIDE * bound;
        int nu = (int)fmax(fmin(round(lu / side), 64.0), 1.0);
        int nv = (int)fmax(fmin(round(lv / side), 64.0), 1.0);
        if (nu * nv == 1) { /* a little too big: halve the longer side */
            if (lu >= lv)
                nu = 2;
            else
                nv = 2;
        }
        if ((k.s1 - k.s0) / nu < min_size) nu = 1;
        if ((k.t1 - k.t0) / nv < min_size) nv = 1;
        if (nu * nv == 1)
            return crisp_error(CRISP_ERR_NUMERIC,
                               "face %u: a cell 2^-%d of its patch still spans %g (radius %g)",
                               c->face, SPLAT_MAX_CELL_DEPTH, rc, c->r_in);
        /* Column by column: cells popped one after the other share their u-restriction. */
        for (int i = 0; i < nu; i++)
            for (int j = 0; j < nv; j++) {
                double s0 = k.s0 + (k.s1 - k.s0) * i / nu, s1 = k.s0 + (k.s1 - k.s0) * (i + 1) / nu;
                double t0 = k.t0 + (k.t1 - k.t0) * j / nv, t1 = k.t0 + (k.t1 - k.t0) * (j + 1) / nv;
                if (i == nu - 1) s1 = k.s1;
                if (j == nv - 1) t1 = k.t1;
                if ((st = push_cell(c, (cell){s0, s1, t0, t1, known}))) return st;
            }
    }
    return CRISP_OK;
}

/* ---- blocks of patches ------------------------------------------------------------------------
 */

static const crisp_bezier_patch *patch_at(const splat_ctx *c, uint32_t iu, uint32_t iv)
{
    return &c->scene->patches[c->f->first_patch + iv * c->f->grid_u + iu].bez;
}

/* The block of patches iu0 <= iu < iu1, iv0 <= iv < iv1 of the face's grid as one cell: the
 * surface over it lies in the union of its patches' hulls, so R_X is the largest distance from X
 * to any of their control points. A block that fails is halved (by patches); a single patch is
 * cut into cells (patch_cells). known: as for cells. */
static crisp_status block_cells(splat_ctx *c, uint32_t iu0, uint32_t iu1, uint32_t iv0,
                                uint32_t iv1, int known)
{
    double rect[4] = {patch_at(c, iu0, iv0)->u0, patch_at(c, iu1 - 1, iv0)->u1,
                      patch_at(c, iu0, iv0)->v0, patch_at(c, iu0, iv1 - 1)->v1};
    /* Outside the loops' box there is no inside point (an inside point has curve points to its
     * left and right on its scan line). */
    if (c->piece_count && (rect[1] < c->piece_box[0] || rect[0] > c->piece_box[1] ||
                           rect[3] < c->piece_box[2] || rect[2] > c->piece_box[3]))
        return CRISP_OK;
    if (iu1 - iu0 == 1 && iv1 - iv0 == 1) return patch_cells(c, patch_at(c, iu0, iv0), known);
    double uc = 0.5 * (rect[0] + rect[1]), vc = 0.5 * (rect[2] + rect[3]), pt[2] = {uc, vc};
    int near = 0, inside = 1;
    if (!known) {
        near = cell_curve_point(c, rect, pt);
        inside = classify(c, uc, vc);
        if (!near && !inside) return CRISP_OK;
        if (inside)
            pt[0] = uc, pt[1] = vc;
        else
            cell_curve_point_near(c, rect, pt);
    }
    /* The patch that holds the point, and the point. */
    uint32_t ju = iu0, jv = iv0;
    while (ju + 1 < iu1 && patch_at(c, ju, iv0)->u1 < pt[0])
        ju++;
    while (jv + 1 < iv1 && patch_at(c, iu0, jv)->v1 < pt[1])
        jv++;
    const crisp_bezier_patch *p = patch_at(c, ju, jv);
    double x[3];
    crisp_bezier_patch_eval(p, (pt[0] - p->u0) / (p->u1 - p->u0), (pt[1] - p->v0) / (p->v1 - p->v0),
                            x);
    double rc = 0.0;
    for (uint32_t iv = iv0; iv < iv1 && rc <= c->r_in; iv++)
        for (uint32_t iu = iu0; iu < iu1 && rc <= c->r_in; iu++) {
            const crisp_bezier_patch *q = patch_at(c, iu, iv);
            int n = (q->du + 1) * (q->dv + 1);
            euclid_any(c, q->cpw, n, c->euc);
            rc = fmax(rc, hull_radius(c->euc, n, x));
        }
    if (rc <= c->r_in) {
        if (rc > c->got) c->got = rc;
        return emit(c, pt[0], pt[1], x, rc);
    }
    int kn = inside && !near;
    uint32_t mu = iu1 - iu0 > 1 ? iu0 + (iu1 - iu0) / 2 : iu1;
    uint32_t mv = iv1 - iv0 > 1 ? iv0 + (iv1 - iv0) / 2 : iv1;
    crisp_status st = block_cells(c, iu0, mu, iv0, mv, kn);
    if (!st && mu < iu1) st = block_cells(c, mu, iu1, iv0, mv, kn);
    if (!st && mv < iv1) st = block_cells(c, iu0, mu, mv, iv1, kn);
    if (!st && mu < iu1 && mv < iv1) st = block_cells(c, mu, iu1, mv, iv1, kn);
    return st;
}

/* ---- the builder ------------------------------------------------------------------------------
 */

void crisp__splat_set_free(crisp_splat_set *set)
{
    if (!set) return;
    crisp_free(set->splats);
    memset(set, 0, sizeof *set);
}

crisp_status crisp__splat_build(const crisp_scene *scene, uint32_t face, double radius,
                                uint32_t max_count, crisp_splat_set *dest)
{
    if (!dest) return crisp_error(CRISP_ERR_INVALID_ARG, "splat build: dest is NULL");
    memset(dest, 0, sizeof *dest);
    if (!scene) return crisp_error(CRISP_ERR_INVALID_ARG, "splat build: scene is NULL");
    if (face >= scene->face_count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "splat build: face %u of %u", face,
                           scene->face_count);
    if (!(radius > 0.0) || !isfinite(radius))
        return crisp_error(CRISP_ERR_INVALID_ARG, "splat build: radius %g (must be > 0)", radius);
    const crisp_scene_face *f = &scene->faces[face];
    splat_ctx c = {.scene = scene,
                   .f = f,
                   .surface = f->src->surface,
                   .pieces = scene->pieces + f->first_piece,
                   .piece_count = (int)f->piece_count,
                   .face = face,
                   .max_count = max_count,
                   .avx = __builtin_cpu_supports("avx"),
                   .set = dest};
    if (!f->patch_count) return CRISP_OK;
    if (c.piece_count) {
        crisp_status ps = crisp_trim_pieces_check(c.pieces, c.piece_count);
        if (ps) {
            crisp_error_prefix("splat build of face %u", face);
            return ps;
        }
    }
    /* The face's box (origin) and its largest coordinate (rounding margin); weights positive. */
    double box[6] = {HUGE_VAL, HUGE_VAL, HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL}, big = 0.0;
    int maxd = 0;
    for (uint32_t k = 0; k < f->patch_count; k++) {
        const crisp_bezier_patch *p = &scene->patches[f->first_patch + k].bez;
        int n = (p->du + 1) * (p->dv + 1);
        maxd = p->du > maxd ? p->du : maxd;
        maxd = p->dv > maxd ? p->dv : maxd;
        for (int i = 0; i < n; i++) {
            const double *h = p->cpw + 4 * i;
            if (!(h[3] > 0.0) || !isfinite(h[3]))
                return crisp_error(CRISP_ERR_NUMERIC, "face %u patch %u: weight %g", face, k, h[3]);
            for (int q = 0; q < 3; q++) {
                double x = h[q] / h[3];
                if (!isfinite(x))
                    return crisp_error(CRISP_ERR_NUMERIC, "face %u patch %u: coordinate %g", face,
                                       k, x);
                box[q] = fmin(box[q], x);
                box[q + 3] = fmax(box[q + 3], x);
                big = fmax(big, fabs(x));
            }
        }
    }
    double half = 0.0;
    for (int q = 0; q < 3; q++) {
        dest->origin[q] = 0.5 * (box[q] + box[q + 3]);
        half += 0.25 * (box[q + 3] - box[q]) * (box[q + 3] - box[q]);
    }
    half = sqrt(half);
    /* Margin: floats of p (relative 2^-24 of |p| <= half per coordinate, so sqrt(3) 2^-24 half
     * in all) and the doubles' rounding in the hulls and evaluations (a generous 1e-12 of the
     * largest coordinate). */
    double margin = 1.1e-7 * half + 1e-12 * big;
    c.r_in = radius - margin;
    c.margin = margin;
    if (!(c.r_in > 0.5 * radius))
        return crisp_error(CRISP_ERR_LIMIT,
                           "face %u: radius %g is below the float precision of the face (%g)", face,
                           radius, margin);
    c.max_cells = max_count ? 64ull * max_count + (1ull << 20) : UINT64_MAX;
    c.boxes = crisp_malloc_array(f->piece_count ? f->piece_count : 1, sizeof *c.boxes);
    c.all = crisp_malloc_array(3 * (size_t)(f->piece_count ? f->piece_count : 1), sizeof(int));
    c.poly = crisp_malloc_array(f->piece_count ? f->piece_count : 1, 1);
    size_t ncp = (size_t)(maxd + 1) * (size_t)(maxd + 1) * 4;
    c.cpw = crisp_malloc_array(ncp, sizeof(double));
    c.euc = crisp_malloc_array(ncp, sizeof(double));
    c.col = crisp_malloc_array(ncp, sizeof(double));
    c.eval_stride = (size_t)(maxd + 1) * 4;
    c.eval_rows = crisp_malloc_array(EVAL_CACHE * c.eval_stride, sizeof(double));
    crisp_status st = crisp__surface_normals_init(&c.normals, c.surface);
    if (!st && (!c.boxes || !c.all || !c.poly || !c.cpw || !c.euc || !c.col || !c.eval_rows))
        st = crisp_error(CRISP_ERR_NO_MEMORY, "splat build of face %u", face);
    if (st) goto done;
    c.near_list = c.all + c.piece_count, c.left_list = c.all + 2 * c.piece_count;
    for (int k = 0; k < c.piece_count; k++)
        c.all[k] = k;
    all_pieces(&c);
    c.piece_box[0] = c.piece_box[2] = HUGE_VAL;
    c.piece_box[1] = c.piece_box[3] = -HUGE_VAL;
    for (int k = 0; k < c.piece_count; k++) {
        const crisp_bezier_curve *b = &c.pieces[k];
        double *bb = c.boxes[k];
        bb[0] = bb[2] = HUGE_VAL;
        bb[1] = bb[3] = -HUGE_VAL;
        c.poly[k] = 1;
        for (int i = 0; i <= b->degree; i++) {
            c.poly[k] &= b->cpw[3 * i + 2] == 1.0;
            double u = b->cpw[3 * i] / b->cpw[3 * i + 2], v = b->cpw[3 * i + 1] / b->cpw[3 * i + 2];
            bb[0] = fmin(bb[0], u), bb[1] = fmax(bb[1], u);
            bb[2] = fmin(bb[2], v), bb[3] = fmax(bb[3], v);
        }
        c.piece_box[0] = fmin(c.piece_box[0], bb[0]), c.piece_box[1] = fmax(c.piece_box[1], bb[1]);
        c.piece_box[2] = fmin(c.piece_box[2], bb[2]), c.piece_box[3] = fmax(c.piece_box[3], bb[3]);
    }
    if (f->grid_u * f->grid_v == f->patch_count)
        st = block_cells(&c, 0, f->grid_u, 0, f->grid_v, c.piece_count == 0);
    else /* not a grid: patch by patch */
        for (uint32_t k = 0; k < f->patch_count && !st; k++)
            st = patch_cells(&c, &scene->patches[f->first_patch + k].bez, c.piece_count == 0);
done:
    crisp__surface_normals_free(&c.normals);
    crisp_free(c.boxes);
    crisp_free(c.all);
    crisp_free(c.poly);
    crisp_free(c.cpw);
    crisp_free(c.euc);
    crisp_free(c.col);
    crisp_free(c.eval_rows);
    crisp_free(c.stack);
    if (st) {
        crisp__splat_set_free(dest);
        return st;
    }
    if (dest->count && dest->count < c.cap) { /* give back the growth's slack */
        crisp_splat *fit = crisp_realloc_array(dest->splats, dest->count, sizeof *fit);
        if (fit) dest->splats = fit;
    }
    dest->radius = dest->count ? fmin(radius, c.got + margin) : radius;
    return CRISP_OK;
}
