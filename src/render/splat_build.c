/* The splat builder (issue 12, src/render/splat.h): point samples of one trimmed face such that
 * every point of the trimmed face lies within a given Euclidean radius r of a sample.
 *
 * The proof (docs/status/issue-12-splats.md, "Builder"). The face's Bézier patches are rational
 * with positive weights, so the surface over any parameter rectangle R of a patch lies in the
 * convex hull H of the Euclidean control points of the patch restricted to R (de Casteljau).
 *   (1) For a point X, the distance |Y - X| is convex in Y, so its largest value over H is taken
 *       at a control point: R_X = max_i |P_i - X| bounds |S(q) - X| for every q in R.
 *   (2) Any two points of H are at most 2 R_X apart (both within R_X of X).
 * Cells are rectangles of a quadtree per patch; c is the cell's centre, R_C = R_{S(c)}.
 *   - A cell whose closed rectangle meets no trim curve (control-point boxes of the curve pieces,
 *     subdivided, are disjoint from it) is wholly inside or wholly outside: the parity of the
 *     crossings to the left is constant on a connected set that misses the curves. Its centre's
 *     class (crisp_trim_exact_classify) decides; its sub-cells inherit it.
 *   - A cell with its centre inside gets a splat at S(c) when R_C <= r: by (1) every point of the
 *     cell's surface is within r of it. Otherwise it is split.
 *   - A cell whose centre is outside but which may meet a curve is dropped when 2 R_C + s <= r and
 *     split otherwise. Why dropping is sound: an inside point q of the cell is joined to c by the
 *     segment [q, c], which lies in the (convex) cell; its ends have different classes, so it
 *     meets a trim curve at some b in the cell (in the face's domain). By (2) |S(q) - S(b)| <=
 *     2 R_C, and the curve samples below put a splat within s of S(b).
 *   - Curve samples: each Bézier trim piece is halved in t until, for its sub-piece with uv box B
 *     (control points: it contains the sub-piece), the surface over B (clipped to the domain) lies
 *     within s of the surface point at the sub-piece's middle point m: (1) on each patch's part of
 *     B. Every curve point in the domain then is within s of S(m), a splat on the trim curve.
 *   - A cell with its centre outside and no curve point in it has no inside point (the same
 *     segment argument): those dropped cells cost nothing.
 * The sample points are points of the trimmed face: cell centres classified inside, or points of
 * the trim curves (clamped into the domain: a curve leaving the domain is not part of the face).
 * The bounds are tested with a margin for rounding and for storing p as float offsets from the
 * origin (set->origin, the face's box centre), so the stored floats meet the radius as well.
 * set->radius is the largest bound met (r_in for the centre cells, 2 R_C + s for the others).
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/trim.h"
#include "splat.h"

#define SPLAT_MAX_CELL_DEPTH 24  /* levels of a patch's quadtree */
#define SPLAT_MAX_CURVE_DEPTH 40 /* halvings of a trim piece */
#define SPLAT_NEAR_DEPTH 30      /* halvings of a trim piece in the cell-curve test */
/* Share of the radius the curve samples meet (s = SPLAT_CURVE_SHARE r): cells whose centre lies
 * outside near a curve then need 2 R_C <= (1 - share) r. */
#define SPLAT_CURVE_SHARE 0.5

typedef struct splat_ctx {
    const crisp_scene *scene;
    const crisp_scene_face *f;
    const crisp_surface *surface;
    const crisp_bezier_curve *pieces;
    int piece_count;
    double piece_box[4]; /* umin, umax, vmin, vmax of every piece's control points */
    double (*boxes)[4];  /* per piece */
    double *cu, *cv;     /* patch column / row boundaries of the face's grid */
    uint32_t face;
    double r_in;  /* bound for cells with their centre inside (r less the margin) */
    double r_out; /* bound for R_C of cells with the centre outside: (r_in - s) / 2 */
    double s;     /* bound for the curve samples */
    double got_in, got_out, got_s; /* largest bounds met */
    uint32_t max_count;
    uint64_t cells, max_cells;
    crisp_splat_set *set;
    uint32_t cap;
    double *cpw; /* a cell's control points */
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

/* Restrict d + 1 homogeneous 4D points (stride `stride` doubles) to the local interval [a, b]. */
static void restrict_points(double *c, int d, ptrdiff_t stride, double a, double b)
{
    double p[(CRISP_MAX_DEGREE + 1) * 4], lo[(CRISP_MAX_DEGREE + 1) * 4],
        hi[(CRISP_MAX_DEGREE + 1) * 4];
    for (int i = 0; i <= d; i++)
        memcpy(p + 4 * i, c + i * stride, sizeof(double) * 4);
    if (b < 1.0) {
        split_points(p, d, 4, b, lo, hi);
        memcpy(p, lo, sizeof(double) * 4 * (size_t)(d + 1));
    }
    if (a > 0.0) {
        split_points(p, d, 4, b > 0.0 ? a / b : 0.0, lo, hi);
        memcpy(p, hi, sizeof(double) * 4 * (size_t)(d + 1));
    }
    for (int i = 0; i <= d; i++)
        memcpy(c + i * stride, p + 4 * i, sizeof(double) * 4);
}

/* The control points of patch p restricted to local [s0, s1] x [t0, t1] into dest. */
static void restrict_patch(const crisp_bezier_patch *p, double s0, double s1, double t0, double t1,
                           double *dest)
{
    const int nu = p->du + 1, nv = p->dv + 1;
    memcpy(dest, p->cpw, sizeof(double) * 4 * (size_t)(nu * nv));
    if (s0 > 0.0 || s1 < 1.0)
        for (int j = 0; j < nv; j++)
            restrict_points(dest + 4 * j * nu, p->du, 4, s0, s1);
    if (t0 > 0.0 || t1 < 1.0)
        for (int i = 0; i < nu; i++)
            restrict_points(dest + 4 * i, p->dv, 4 * (ptrdiff_t)nu, t0, t1);
}

/* max_i |P_i - x| over n homogeneous points. */
static double hull_radius(const double *cpw, int n, const double x[3])
{
    double m = 0.0;
    for (int i = 0; i < n; i++) {
        const double *h = cpw + 4 * i;
        double dx = h[0] / h[3] - x[0], dy = h[1] / h[3] - x[1], dz = h[2] / h[3] - x[2];
        double d = dx * dx + dy * dy + dz * dz;
        if (d > m) m = d;
    }
    return sqrt(m);
}

/* ---- emitting -------------------------------------------------------------------------------- */

static crisp_status emit(splat_ctx *c, double u, double v, const double x[3])
{
    crisp_splat_set *set = c->set;
    if (c->max_count && set->count >= c->max_count)
        return crisp_error(CRISP_ERR_LIMIT, "face %u: more than %u splats at radius %g", c->face,
                           c->max_count, c->r_in);
    if (set->count == c->cap) {
        uint32_t cap = c->cap ? 2 * c->cap : 64;
        crisp_plan_splat *n = crisp_realloc_array(set->splats, cap, sizeof *n);
        if (!n) return crisp_error(CRISP_ERR_NO_MEMORY, "splats of face %u", c->face);
        set->splats = n;
        c->cap = cap;
    }
    crisp_plan_splat *sp = &set->splats[set->count++];
    double nrm[3];
    crisp_surface_normal(c->surface, u, v, nrm);
    for (int k = 0; k < 3; k++) {
        sp->p[k] = (float)(x[k] - set->origin[k]);
        sp->n[k] = (float)nrm[k];
    }
    sp->uv[0] = (float)u;
    sp->uv[1] = (float)v;
    sp->face = c->face;
    return CRISP_OK;
}

/* ---- cell-curve test --------------------------------------------------------------------------
 */

/* 1 when the sub-curve (homogeneous uv points, degree d) may meet the closed rectangle rect
 * (u0, u1, v0, v1); 0 when it provably does not. */
static int curve_near(const double *cpw, int d, const double rect[4], double tiny, int depth)
{
    double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
    for (int i = 0; i <= d; i++)
        for (int q = 0; q < 2; q++) {
            double x = cpw[3 * i + q] / cpw[3 * i + 2];
            lo[q] = x < lo[q] ? x : lo[q];
            hi[q] = x > hi[q] ? x : hi[q];
        }
    if (hi[0] < rect[0] || lo[0] > rect[1] || hi[1] < rect[2] || lo[1] > rect[3]) return 0;
    for (int e = 0; e <= d; e += d) { /* an end point in the rectangle: it meets it */
        double u = cpw[3 * e] / cpw[3 * e + 2], v = cpw[3 * e + 1] / cpw[3 * e + 2];
        if (u >= rect[0] && u <= rect[1] && v >= rect[2] && v <= rect[3]) return 1;
    }
    if (depth >= SPLAT_NEAR_DEPTH || (hi[0] - lo[0] <= tiny && hi[1] - lo[1] <= tiny)) return 1;
    double l[3 * (CRISP_MAX_DEGREE + 1)], r[3 * (CRISP_MAX_DEGREE + 1)];
    split_points(cpw, d, 3, 0.5, l, r);
    return curve_near(l, d, rect, tiny, depth + 1) || curve_near(r, d, rect, tiny, depth + 1);
}

static int cell_near(const splat_ctx *c, const double rect[4])
{
    double tiny = 0.0625 * fmax(rect[1] - rect[0], rect[3] - rect[2]);
    for (int k = 0; k < c->piece_count; k++) {
        const double *b = c->boxes[k];
        if (b[1] < rect[0] || b[0] > rect[1] || b[3] < rect[2] || b[2] > rect[3]) continue;
        if (curve_near(c->pieces[k].cpw, c->pieces[k].degree, rect, tiny, 0)) return 1;
    }
    return 0;
}

/* ---- cells ------------------------------------------------------------------------------------
 */

/* One patch's quadtree, depth first; each cell's control points are restricted from the patch. */
typedef struct cell {
    double s0, s1, t0, t1; /* local parameters in the top patch */
    int depth;
    int known; /* 1: no curve meets the cell and it is inside */
} cell;

static crisp_status patch_cells(splat_ctx *c, const crisp_bezier_patch *top)
{
    const int n = (top->du + 1) * (top->dv + 1);
    cell st[4 * SPLAT_MAX_CELL_DEPTH + 8];
    int sp = 0;
    st[sp++] = (cell){0.0, 1.0, 0.0, 1.0, 0, c->piece_count == 0};
    const double du = top->u1 - top->u0, dv = top->v1 - top->v0;
    while (sp > 0) {
        cell k = st[--sp];
        double *cpw = c->cpw;
        if (++c->cells > c->max_cells)
            return crisp_error(CRISP_ERR_LIMIT, "face %u: more than %llu cells at radius %g",
                               c->face, (unsigned long long)c->max_cells, c->r_in);
        double rect[4] = {top->u0 + k.s0 * du, top->u0 + k.s1 * du, top->v0 + k.t0 * dv,
                          top->v0 + k.t1 * dv};
        double sc = 0.5 * (k.s0 + k.s1), tc = 0.5 * (k.t0 + k.t1);
        double uc = top->u0 + sc * du, vc = top->v0 + tc * dv;
        int inside, near = 0;
        if (k.known)
            inside = 1;
        else {
            near = cell_near(c, rect);
            inside = crisp_trim_exact_classify(c->pieces, c->piece_count, uc, vc);
            if (!near && !inside) continue; /* wholly outside */
        }
        restrict_patch(top, k.s0, k.s1, k.t0, k.t1, cpw);
        double x[3];
        crisp_bezier_patch_eval(top, sc, tc, x);
        double rc = hull_radius(cpw, n, x);
        if (inside) {
            if (rc <= c->r_in) {
                if (rc > c->got_in) c->got_in = rc;
                crisp_status s = emit(c, uc, vc, x);
                if (s) return s;
                continue;
            }
        } else if (rc <= c->r_out) {
            if (rc > c->got_out) c->got_out = rc;
            continue;
        }
        if (k.depth >= SPLAT_MAX_CELL_DEPTH)
            return crisp_error(CRISP_ERR_NUMERIC,
                               "face %u: a cell %d levels deep still spans %g (radius %g)", c->face,
                               k.depth, rc, c->r_in);
        int kn = inside && !near;
        st[sp++] = (cell){k.s0, sc, k.t0, tc, k.depth + 1, kn};
        st[sp++] = (cell){sc, k.s1, k.t0, tc, k.depth + 1, kn};
        st[sp++] = (cell){k.s0, sc, tc, k.t1, k.depth + 1, kn};
        st[sp++] = (cell){sc, k.s1, tc, k.t1, k.depth + 1, kn};
    }
    return CRISP_OK;
}

/* ---- curve samples ----------------------------------------------------------------------------
 */

/* First index i with a[i + 1] > x among the n cells of boundaries a[0 .. n] (clamped). */
static uint32_t find_cell(const double *a, uint32_t n, double x)
{
    uint32_t lo = 0, hi = n - 1;
    while (lo < hi) {
        uint32_t mid = (lo + hi) / 2;
        if (a[mid + 1] < x)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

static const crisp_bezier_patch *patch_at(const splat_ctx *c, uint32_t iu, uint32_t iv)
{
    return &c->scene->patches[c->f->first_patch + iv * c->f->grid_u + iu].bez;
}

static crisp_status curve_piece(splat_ctx *c, const double *cpw, int d, int depth)
{
    const crisp_scene_face *f = c->f;
    double box[4] = {HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL};
    for (int i = 0; i <= d; i++) {
        double u = cpw[3 * i] / cpw[3 * i + 2], v = cpw[3 * i + 1] / cpw[3 * i + 2];
        box[0] = fmin(box[0], u), box[1] = fmax(box[1], u);
        box[2] = fmin(box[2], v), box[3] = fmax(box[3], v);
    }
    /* Only the curve's points in the domain belong to the face. */
    box[0] = fmax(box[0], f->domain[0]), box[1] = fmin(box[1], f->domain[1]);
    box[2] = fmax(box[2], f->domain[2]), box[3] = fmin(box[3], f->domain[3]);
    if (box[0] > box[1] || box[2] > box[3]) return CRISP_OK;
    /* The sample: the sub-piece's middle point, or an end point when the middle lies outside
     * the domain; when all three do, the halves decide (at the depth limit: the middle clamped
     * into the domain, within 2^-40 of the piece's parameter range of the curve). */
    double l[3 * (CRISP_MAX_DEGREE + 1)], r[3 * (CRISP_MAX_DEGREE + 1)];
    split_points(cpw, d, 3, 0.5, l, r);
    const double *cand[3] = {r, cpw, cpw + 3 * d}, *pick = NULL;
    for (int i = 0; i < 3 && !pick; i++) {
        double u = cand[i][0] / cand[i][2], v = cand[i][1] / cand[i][2];
        if (u >= f->domain[0] && u <= f->domain[1] && v >= f->domain[2] && v <= f->domain[3])
            pick = cand[i];
    }
    if (!pick && depth < SPLAT_MAX_CURVE_DEPTH) {
        crisp_status s = curve_piece(c, l, d, depth + 1);
        return s ? s : curve_piece(c, r, d, depth + 1);
    }
    if (!pick) pick = r;
    double um = pick[0] / pick[2], vm = pick[1] / pick[2];
    um = fmin(fmax(um, f->domain[0]), f->domain[1]);
    vm = fmin(fmax(vm, f->domain[2]), f->domain[3]);
    uint32_t iu = find_cell(c->cu, f->grid_u, um), iv = find_cell(c->cv, f->grid_v, vm);
    const crisp_bezier_patch *pm = patch_at(c, iu, iv);
    double x[3];
    crisp_bezier_patch_eval(pm, (um - pm->u0) / (pm->u1 - pm->u0),
                            (vm - pm->v0) / (pm->v1 - pm->v0), x);
    /* The surface over the box, patch by patch. */
    uint32_t iu0 = find_cell(c->cu, f->grid_u, box[0]), iu1 = find_cell(c->cu, f->grid_u, box[1]);
    uint32_t iv0 = find_cell(c->cv, f->grid_v, box[2]), iv1 = find_cell(c->cv, f->grid_v, box[3]);
    /* A box edge on a patch boundary also touches the patch before it. */
    if (iu0 > 0 && box[0] <= c->cu[iu0]) iu0--;
    if (iv0 > 0 && box[2] <= c->cv[iv0]) iv0--;
    double rad = 0.0;
    double buf[(CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1) * 4];
    for (uint32_t jv = iv0; jv <= iv1 && rad <= c->s; jv++)
        for (uint32_t ju = iu0; ju <= iu1 && rad <= c->s; ju++) {
            const crisp_bezier_patch *p = patch_at(c, ju, jv);
            double a0 = fmax(box[0], p->u0), a1 = fmin(box[1], p->u1);
            double b0 = fmax(box[2], p->v0), b1 = fmin(box[3], p->v1);
            if (a0 > a1 || b0 > b1) continue;
            double wu = p->u1 - p->u0, wv = p->v1 - p->v0;
            double s0 = fmax((a0 - p->u0) / wu, 0.0), s1 = fmin((a1 - p->u0) / wu, 1.0);
            double t0 = fmax((b0 - p->v0) / wv, 0.0), t1 = fmin((b1 - p->v0) / wv, 1.0);
            restrict_patch(p, s0, s1, t0, t1, buf);
            rad = fmax(rad, hull_radius(buf, (p->du + 1) * (p->dv + 1), x));
        }
    if (rad <= c->s) {
        if (rad > c->got_s) c->got_s = rad;
        return emit(c, um, vm, x);
    }
    if (depth >= SPLAT_MAX_CURVE_DEPTH)
        return crisp_error(CRISP_ERR_NUMERIC,
                           "face %u: a trim piece halved %d times still spans %g (radius %g)",
                           c->face, depth, rad, c->s);
    crisp_status s = curve_piece(c, l, d, depth + 1);
    if (s) return s;
    return curve_piece(c, r, d, depth + 1);
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
                   .set = dest};
    if (!f->patch_count) return CRISP_OK;
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
    if (!(c.r_in > 0.5 * radius))
        return crisp_error(CRISP_ERR_LIMIT,
                           "face %u: radius %g is below the float precision of the face (%g)", face,
                           radius, margin);
    c.s = SPLAT_CURVE_SHARE * c.r_in;
    c.r_out = 0.5 * (c.r_in - c.s);
    c.max_cells = max_count ? 64ull * max_count + (1ull << 20) : UINT64_MAX;
    /* Patch grid boundaries (for the curve samples). */
    c.cu = crisp_malloc_array(f->grid_u + 1, sizeof(double));
    c.cv = crisp_malloc_array(f->grid_v + 1, sizeof(double));
    c.boxes = crisp_malloc_array(f->piece_count ? f->piece_count : 1, sizeof *c.boxes);
    size_t ncp = (size_t)(maxd + 1) * (size_t)(maxd + 1) * 4;
    c.cpw = crisp_malloc_array(ncp, sizeof(double));
    crisp_status st = CRISP_OK;
    if (!c.cu || !c.cv || !c.boxes || !c.cpw) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "splat build of face %u", face);
        goto done;
    }
    for (uint32_t i = 0; i < f->grid_u; i++)
        c.cu[i] = patch_at(&c, i, 0)->u0;
    c.cu[f->grid_u] = patch_at(&c, f->grid_u - 1, 0)->u1;
    for (uint32_t j = 0; j < f->grid_v; j++)
        c.cv[j] = patch_at(&c, 0, j)->v0;
    c.cv[f->grid_v] = patch_at(&c, 0, f->grid_v - 1)->v1;
    c.piece_box[0] = c.piece_box[2] = HUGE_VAL;
    c.piece_box[1] = c.piece_box[3] = -HUGE_VAL;
    for (int k = 0; k < c.piece_count; k++) {
        const crisp_bezier_curve *b = &c.pieces[k];
        double *bb = c.boxes[k];
        bb[0] = bb[2] = HUGE_VAL;
        bb[1] = bb[3] = -HUGE_VAL;
        for (int i = 0; i <= b->degree; i++) {
            double u = b->cpw[3 * i] / b->cpw[3 * i + 2], v = b->cpw[3 * i + 1] / b->cpw[3 * i + 2];
            bb[0] = fmin(bb[0], u), bb[1] = fmax(bb[1], u);
            bb[2] = fmin(bb[2], v), bb[3] = fmax(bb[3], v);
        }
        c.piece_box[0] = fmin(c.piece_box[0], bb[0]), c.piece_box[1] = fmax(c.piece_box[1], bb[1]);
        c.piece_box[2] = fmin(c.piece_box[2], bb[2]), c.piece_box[3] = fmax(c.piece_box[3], bb[3]);
    }
    /* Cells, patch by patch (a patch outside the loops' box has no inside point: an inside point
     * has curve points left and right of it on its scan line). */
    for (uint32_t k = 0; k < f->patch_count && !st; k++) {
        const crisp_bezier_patch *p = &scene->patches[f->first_patch + k].bez;
        if (c.piece_count && (p->u1 < c.piece_box[0] || p->u0 > c.piece_box[1] ||
                              p->v1 < c.piece_box[2] || p->v0 > c.piece_box[3]))
            continue;
        st = patch_cells(&c, p);
    }
    /* Curve samples. */
    for (int k = 0; k < c.piece_count && !st; k++)
        st = curve_piece(&c, c.pieces[k].cpw, c.pieces[k].degree, 0);
done:
    crisp_free(c.cu);
    crisp_free(c.cv);
    crisp_free(c.boxes);
    crisp_free(c.cpw);
    if (st) {
        crisp__splat_set_free(dest);
        return st;
    }
    double got = c.got_in;
    if (c.piece_count) got = fmax(got, 2.0 * c.got_out + c.got_s);
    dest->radius = dest->count ? fmin(radius, got + margin) : radius;
    return CRISP_OK;
}
