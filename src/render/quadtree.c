/* The frame planner (docs/design.md sections 2 and 4; Wu & Peters 2015): for one camera, which
 * patches are visible, the tess level of each from its screen-space SLEFE, crack-free edge levels,
 * and each visible face's trim plan (v-scan density bound, trim polylines, u-intercept table).
 *
 * Per patch, a quadtree of sub-patches ("leaves"): a patch (or sub-patch) is split in four while
 * its screen SLEFE cannot be formed (it reaches the eye plane, W <= 0) or its level exceeds 64.
 * The level is the smallest tau whose sound screen-space error bound (SLEFE of the clip-space
 * patch plus the triangle twist term, crisp_slefe_patch_tess_level) is within eps. Sub-patches
 * whose homogeneous control points all lie outside one frustum plane are culled (convex hull
 * property in clip space).
 *
 * Edge levels. Leaves meet leaves of the same patch and, along patch boundaries, leaves of the
 * neighbouring patches of the same face. Of two leaves that share an edge the coarser one owns
 * the edge: it places its edge vertices uniformly at the finest density any leaf touching the edge
 * asks for, with a count that is a multiple of 2^(depth difference), so every finer leaf along the
 * edge takes an equal share of those vertices. Both sides then place the same vertices. */
#include "quadtree.h"
#include "depth_bound.h"
#include "rational_bound.h"
#include "render_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/slefe.h"
#include "slefe/slefe_internal.h"

#define CRISP__NB_CAP 256 /* leaves across one side examined by the edge rule */

/* ---- sub-patches --------------------------------------------------------------------------- */

/* 1 when every control point lies outside one plane of the frustum, widened by margin. */
static int outside_frustum(const crisp_bezier_patch *p, crisp_mat4 m, double gx, double gy)
{
    int n = (p->du + 1) * (p->dv + 1);
    int out[6] = {1, 1, 1, 1, 1, 1};
    for (int i = 0; i < n; i++) {
        const double *c = p->cpw + 4 * i;
        double x = m[0][0] * c[0] + m[1][0] * c[1] + m[2][0] * c[2] + m[3][0] * c[3];
        double y = m[0][1] * c[0] + m[1][1] * c[1] + m[2][1] * c[2] + m[3][1] * c[3];
        double z = m[0][2] * c[0] + m[1][2] * c[1] + m[2][2] * c[2] + m[3][2] * c[3];
        double w = m[0][3] * c[0] + m[1][3] * c[1] + m[2][3] * c[2] + m[3][3] * c[3];
        out[0] &= x > gx * w;
        out[1] &= x < -gx * w;
        out[2] &= y > gy * w;
        out[3] &= y < -gy * w;
        out[4] &= z < -w; /* in front of the near plane */
        out[5] &= z > w;  /* beyond the far plane */
        if (!(out[0] | out[1] | out[2] | out[3] | out[4] | out[5])) return 0;
    }
    return 1;
}

/* ---- pass 1: per-patch quadtrees ------------------------------------------------------------ */

typedef struct tree_ctx {
    crisp__trees *plan;
    const crisp_scene *sc;
    const uint32_t *redo;   /* NULL: the active patches; else the patches to rebuild */
    const uint32_t *active; /* the active patches (patch groups) */
    const uint8_t *mode;    /* per active patch (patch groups), used when redo is NULL */
    size_t count;           /* items: active patches, or the redo list's length */
    crisp_slefe_view view;
    double eps, gx, gy;
    double depth_scale; /* crisp__depth_px_scale: a pixel's world size per unit of clip W */
} tree_ctx;

typedef struct build_state {
    const tree_ctx *c;
    crisp__patch_tree *pp;
    const crisp_bezier_patch *root;
    uint32_t patch;
    crisp_arena *arena;
    double storage[2][(CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1) * 4 * 2];
    double child[2][(CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1) * 4 * 2]; /* children_cost */
    /* The patch's four quarters (depth-1 cells), made once per patch when first needed: one split
     * in u and two in v, the same numbers crisp__subpatch gives each of them from the patch with
     * two cuts (its cuts at 1/2 are these splits), for 3 splits instead of 8. */
    double quarter[4][(CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1) * 4];
    crisp_bezier_patch quarter_patch[4];
    int have_quarters;
    crisp__slefe_search search; /* build_cell's level search, between its two steps */
    size_t node_cap, leaf_cap;
    const crisp__forced *forced; /* this patch's forced splits */
    size_t forced_count;
    struct crisp__sub_keep **keep; /* the patch's kept sub-patches (cell_patch) */
    crisp_status st;
} build_state;

/* De Casteljau at 1/2 of the n + 1 homogeneous points src[i * st] (4 doubles each) into the
 * halves' points left[i * st], right[i * st]: the arithmetic of crisp_bezier_patch_split_u / _v at
 * 1/2 (s q_i + t q_(i+1), s = 1 - t = t = 1/2), so the same bits, without their copies. */
static void halve_points(const double *src, ptrdiff_t st, int n, double *left, double *right)
{
    double q[(CRISP_MAX_DEGREE + 1) * 4];
    const double t = 0.5, s = 1.0 - t;
    for (int i = 0; i <= n; i++)
        for (int c = 0; c < 4; c++)
            q[4 * i + c] = src[i * st + c];
    for (int c = 0; c < 4; c++)
        left[c] = q[c], right[n * st + c] = q[4 * n + c];
    for (int r = 1; r <= n; r++) {
        for (int i = 0; i <= n - r; i++)
            for (int c = 0; c < 4; c++)
                q[4 * i + c] = s * q[4 * i + c] + t * q[4 * (i + 1) + c];
        for (int c = 0; c < 4; c++)
            left[r * st + c] = q[c], right[(n - r) * st + c] = q[4 * (n - r) + c];
    }
}

/* Sub-patches kept across frames (issue 12, session 18): a cell's sub-patch depends on the
 * scene patch and (depth, ix, iy) only, not on the camera, and de Casteljau's cuts of a
 * high-degree patch cost thousands of instructions (occt_linkrods.step default: 1,250 a warm
 * frame, about 21 M instructions, each cell cut once for children_cost and again for its own
 * build_cell). Per scene patch a block of KEEP_SUBS entries, carved on first need from one
 * allocation made when the scene changes (no allocation in a later frame): an entry holds the key,
 * the build that last used it, the parameter box and the control points, copied out bit for bit
 * as crisp__subpatch made them. A full block replaces an entry the current build has not used;
 * when every one was used, the sub-patch is not kept. Only the worker that plans a patch reads or
 * writes its block (a patch is planned by one worker per pass; passes are joined). */
#define KEEP_SUBS 64
#define KEEP_BYTES_MAX ((size_t)48 << 20) /* one scene's kept sub-patches at most */
/* Only patches of this degree or more in u or v (lower degrees' cuts cost little more than the
 * copy: no change on impeller.igs close). */
#define KEEP_DEGREE 4
typedef struct crisp__sub_keep {
    uint32_t count, doubles; /* entries used; control-point doubles an entry */
    uint64_t key[KEEP_SUBS];
    uint32_t used[KEEP_SUBS];
    double data[]; /* per entry: u0, u1, v0, v1, then the control points */
} crisp__sub_keep;

static uint64_t sub_key(int depth, int ix, int iy)
{
    return (uint64_t)depth << 56 | (uint64_t)(uint32_t)ix << 28 | (uint64_t)(uint32_t)iy;
}

static int keeps_subs(const crisp_bezier_patch *p)
{
    return p->du >= KEEP_DEGREE || p->dv >= KEEP_DEGREE;
}

static size_t keep_block_bytes(const crisp_bezier_patch *p)
{
    size_t n = (size_t)(p->du + 1) * (size_t)(p->dv + 1) * 4;
    return (sizeof(crisp__sub_keep) + KEEP_SUBS * (4 + n) * sizeof(double) + 63) & ~(size_t)63;
}

/* The kept entry of (depth, ix, iy) (marked used), or where to keep it (-(slot + 1)), or
 * -(KEEP_SUBS + 1) when it cannot be kept. */
static int keep_find(build_state *b, uint64_t key, crisp__sub_keep **blockp)
{
    crisp__trees *plan = b->c->plan;
    crisp__sub_keep *k = *b->keep;
    if (!k) {
        size_t bytes = keep_block_bytes(b->root);
        if (atomic_load_explicit(&plan->keep_used, memory_order_relaxed) >= plan->keep_bytes)
            return -(KEEP_SUBS + 1); /* (every block carved) */
        size_t at = atomic_fetch_add_explicit(&plan->keep_used, bytes, memory_order_relaxed);
        if (at + bytes > plan->keep_bytes) return -(KEEP_SUBS + 1);
        k = (crisp__sub_keep *)(plan->keep + at);
        k->count = 0;
        k->doubles = (uint32_t)((size_t)(b->root->du + 1) * (size_t)(b->root->dv + 1) * 4);
        *b->keep = k;
    }
    *blockp = k;
    int free_slot = k->count < KEEP_SUBS ? (int)k->count : -1;
    for (uint32_t e = 0; e < k->count; e++) {
        if (k->key[e] == key) {
            k->used[e] = plan->frame;
            return (int)e;
        }
        if (free_slot < 0 && k->used[e] != plan->frame) free_slot = (int)e;
    }
    return free_slot < 0 ? -(KEEP_SUBS + 1) : -(free_slot + 1);
}

/* Sub-patch (depth, ix, iy) of the patch into storage (or the kept quarter at depth 1). */
static void cell_patch(build_state *b, int depth, int ix, int iy, double *storage, double *tmp,
                       crisp_bezier_patch *dest)
{
    if (depth == 1) {
        if (!b->have_quarters) {
            /* split in u, then each half in v (crisp_bezier_patch_split_u / _v's numbers) */
            const crisp_bezier_patch *p = b->root;
            crisp_bezier_patch *q = b->quarter_patch;
            int nu = p->du + 1;
            ptrdiff_t row = 4 * (ptrdiff_t)nu;
            for (int j = 0; j <= p->dv; j++)
                halve_points(p->cpw + j * row, 4, p->du, storage + j * row, tmp + j * row);
            for (int k = 0; k < 4; k++) {
                q[k] = *p;
                q[k].cpw = b->quarter[k];
            }
            for (int i = 0; i < nu; i++) {
                halve_points(storage + 4 * i, row, p->dv, q[0].cpw + 4 * i, q[2].cpw + 4 * i);
                halve_points(tmp + 4 * i, row, p->dv, q[1].cpw + 4 * i, q[3].cpw + 4 * i);
            }
            double um = p->u0 + 0.5 * (p->u1 - p->u0), vm = p->v0 + 0.5 * (p->v1 - p->v0);
            q[0].u1 = q[2].u1 = um, q[1].u0 = q[3].u0 = um;
            q[0].v1 = q[1].v1 = vm, q[2].v0 = q[3].v0 = vm;
            b->have_quarters = 1;
        }
        *dest = b->quarter_patch[ix + 2 * iy];
        return;
    }
    crisp__sub_keep *k = NULL;
    uint64_t key = sub_key(depth, ix, iy);
    int e = b->keep ? keep_find(b, key, &k) : -(KEEP_SUBS + 1);
    if (e >= 0) {
        const double *d = k->data + (size_t)e * (4 + k->doubles);
        *dest = *b->root;
        dest->u0 = d[0], dest->u1 = d[1], dest->v0 = d[2], dest->v1 = d[3];
        memcpy(storage, d + 4, k->doubles * sizeof *storage);
        dest->cpw = storage;
        return;
    }
    double sz = ldexp(1.0, -depth);
    crisp__subpatch(b->root, ix * sz, (ix + 1) * sz, iy * sz, (iy + 1) * sz, storage, tmp, dest);
    if (e > -(KEEP_SUBS + 1)) {
        int slot = -e - 1;
        double *d = k->data + (size_t)slot * (4 + k->doubles);
        d[0] = dest->u0, d[1] = dest->u1, d[2] = dest->v0, d[3] = dest->v1;
        memcpy(d + 4, dest->cpw, k->doubles * sizeof *d);
        k->key[slot] = key;
        k->used[slot] = b->c->plan->frame;
        if ((uint32_t)slot == k->count) k->count++;
    }
}

static int32_t push_node(build_state *b)
{
    crisp__patch_tree *pp = b->pp;
    if (pp->node_count == b->node_cap) {
        size_t cap = b->node_cap ? 2 * b->node_cap : 8;
        crisp__node *n = crisp_arena_alloc(b->arena, cap, sizeof *n);
        if (!n) return -1;
        if (pp->node_count) memcpy(n, pp->nodes, pp->node_count * sizeof *n);
        pp->nodes = n;
        b->node_cap = cap;
    }
    pp->nodes[pp->node_count] = (crisp__node){-1, -1};
    return (int32_t)pp->node_count++;
}

static int32_t push_leaf(build_state *b, const crisp__cell *leaf)
{
    crisp__patch_tree *pp = b->pp;
    if (pp->leaf_count == b->leaf_cap) {
        size_t cap = b->leaf_cap ? 2 * b->leaf_cap : 4;
        crisp__cell *n = crisp_arena_alloc(b->arena, cap, sizeof *n);
        if (!n) return -1;
        if (pp->leaf_count) memcpy(n, pp->leaves, pp->leaf_count * sizeof *n);
        pp->leaves = n;
        b->leaf_cap = cap;
    }
    pp->leaves[pp->leaf_count] = *leaf;
    return (int32_t)pp->leaf_count++;
}

/* 1 when the sub-patch's control hull, wholly in front of the eye, spans more than
 * CRISP_PLAN_MAX_LEAF_PX on screen in x or y: the leaf is split so that float local parameters
 * inside one leaf keep sub-pixel precision on a GPU (include/crisp/plan.h). */
static int too_large_on_screen(const crisp_bezier_patch *p, crisp_mat4 m, int width, int height)
{
    int n = (p->du + 1) * (p->dv + 1);
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < n; i++) {
        const double *c = p->cpw + 4 * i;
        double x = m[0][0] * c[0] + m[1][0] * c[1] + m[2][0] * c[2] + m[3][0] * c[3];
        double y = m[0][1] * c[0] + m[1][1] * c[1] + m[2][1] * c[2] + m[3][1] * c[3];
        double w = m[0][3] * c[0] + m[1][3] * c[1] + m[2][3] * c[2] + m[3][3] * c[3];
        if (!(w > 0)) return 0;
        lo[0] = fmin(lo[0], x / w), hi[0] = fmax(hi[0], x / w);
        lo[1] = fmin(lo[1], y / w), hi[1] = fmax(hi[1], y / w);
    }
    return (hi[0] - lo[0]) * 0.5 * width > CRISP_PLAN_MAX_LEAF_PX ||
           (hi[1] - lo[1]) * 0.5 * height > CRISP_PLAN_MAX_LEAF_PX;
}

/* fmin / fmax of an accumulator that is never NaN (it starts at +-INFINITY) and a value: the same
 * result (a NaN value leaves the accumulator), without the library call. */
static inline double least(double acc, double v)
{
    return v < acc ? v : acc;
}
static inline double most(double acc, double v)
{
    return v > acc ? v : acc;
}

/* Largest screen extent in pixels (max of the x and y extents) of the sub-patch's projected
 * control hull; INFINITY when the hull reaches W <= 0. The sub-patch and every triangle with its
 * vertices on it lie inside the hull (convex hull property; W > 0 over the hull), so a hull at
 * most eps pixels across is drawn within eps by any tessellation: tau = 1 suffices. */
static double hull_extent_px(const crisp_bezier_patch *p, crisp_mat4 m, int width, int height)
{
    int n = (p->du + 1) * (p->dv + 1);
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < n; i++) {
        const double *c = p->cpw + 4 * i;
        double x = m[0][0] * c[0] + m[1][0] * c[1] + m[2][0] * c[2] + m[3][0] * c[3];
        double y = m[0][1] * c[0] + m[1][1] * c[1] + m[2][1] * c[2] + m[3][1] * c[3];
        double w = m[0][3] * c[0] + m[1][3] * c[1] + m[2][3] * c[2] + m[3][3] * c[3];
        if (!(w > 0)) return INFINITY;
        double sx = x / w, sy = y / w;
        lo[0] = least(lo[0], sx), hi[0] = most(hi[0], sx);
        lo[1] = least(lo[1], sy), hi[1] = most(hi[1], sy);
    }
    /* A relative allowance for the rounding of the projection. */
    double e = fmax((hi[0] - lo[0]) * 0.5 * width, (hi[1] - lo[1]) * 0.5 * height);
    return e * (1 + 1e-9) + 1e-9;
}

/* A bound (pixels) on the screen distance between the sub-patch and any triangles with vertices
 * on it (whatever the tessellation), from its control points' distance D to the bilinear
 * function B through its corners in homogeneous clip coordinates: px(D) + px(D + twist(B) / 4)
 * (patch_groups.c, group_leaf_ok, has the argument; a single patch is a block of one). INFINITY
 * when W is not bounded away from 0. Tight for small, nearly flat pieces, where the SLEFE bound
 * of a rational patch seen off axis can be tens of times too large. */
static double flat_px(const crisp_bezier_patch *p, crisp_mat4 m, int width, int height)
{
    int du = p->du, dv = p->dv;
    const double *cw[4] = {p->cpw, p->cpw + 4 * du, p->cpw + 4 * (du + 1) * dv,
                           p->cpw + 4 * ((du + 1) * dv + du)};
    double C[4][3], wmin = INFINITY, xmax = 0, ymax = 0;
    for (int k = 0; k < 4; k++) {
        const double *q = cw[k];
        for (int a = 0; a < 3; a++) {
            int r = a == 2 ? 3 : a;
            C[k][a] = m[0][r] * q[0] + m[1][r] * q[1] + m[2][r] * q[2] + m[3][r] * q[3];
        }
        if (!(C[k][2] > 0)) return INFINITY;
        wmin = fmin(wmin, C[k][2]);
        xmax = fmax(xmax, fabs(C[k][0] / C[k][2]));
        ymax = fmax(ymax, fabs(C[k][1] / C[k][2]));
    }
    double D[3] = {0, 0, 0};
    for (int j = 0; j <= dv; j++) {
        double t = (double)j / dv;
        for (int i = 0; i <= du; i++) {
            double s = (double)i / du;
            const double *q = p->cpw + 4 * (j * (du + 1) + i);
            for (int a = 0; a < 3; a++) {
                int r = a == 2 ? 3 : a;
                double x = m[0][r] * q[0] + m[1][r] * q[1] + m[2][r] * q[2] + m[3][r] * q[3];
                double bl = (1 - t) * ((1 - s) * C[0][a] + s * C[1][a]) +
                            t * ((1 - s) * C[2][a] + s * C[3][a]);
                D[a] = fmax(D[a], fabs(x - bl) + 1e-12 * (fabs(x) + fabs(bl)));
            }
        }
    }
    double px = 0;
    for (int pass = 0; pass < 2; pass++) {
        double e[3];
        for (int a = 0; a < 3; a++)
            e[a] = D[a] + (pass ? 0.25 * fabs(C[0][a] - C[1][a] - C[2][a] + C[3][a]) : 0);
        double den = wmin - e[2];
        if (!(den > 0)) return INFINITY;
        double dx = (e[0] + xmax * e[2]) / den, dy = (e[1] + ymax * e[2]) / den;
        px += fmax(dx * 0.5 * width, dy * 0.5 * height) * (1 + 1e-9) + 1e-12;
    }
    return px;
}

/* flat_px, or where the patch's weights vary the bound of rational_bound.c: it does not divide
 * by the weight, so it stays tight there, and it measures the triangle point at the parameters
 * the rasterizer interpolates (flat_px's homogeneous argument bounds another point of the same
 * triangle when the weights differ at its vertices). Equal weights: the two are the same.
 * depth: the W part of rational_bound.c's bound (crisp__rational_block_px_depth; INFINITY, 0
 * where it was not formed). */
static double flat_bound(const crisp_bezier_patch *p, const double *sigmas, crisp_mat4 m, int width,
                         int height, double eps, double depth[2])
{
    double wlo, whi;
    depth[0] = INFINITY, depth[1] = 0;
    crisp__rational_weight_range(p, &wlo, &whi);
    if (!(whi > wlo)) return flat_px(p, m, width, height);
    crisp_scene_patch one = {.bez = *p};
    return crisp__rational_block_px_depth(&one, sigmas, 1, 1, 1, m, width, height, eps, depth);
}

static int forced_cmp(const crisp__forced *a, const crisp__forced *b)
{
    if (a->patch != b->patch) return a->patch < b->patch ? -1 : 1;
    if (a->depth != b->depth) return a->depth < b->depth ? -1 : 1;
    if (a->iy != b->iy) return a->iy < b->iy ? -1 : 1;
    if (a->ix != b->ix) return a->ix < b->ix ? -1 : 1;
    return 0;
}

static int forced_qsort_cmp(const void *a, const void *b)
{
    return forced_cmp(a, b);
}

/* First forced split of `patch` or later (binary search). */
static size_t forced_lower(const crisp__forced *f, size_t n, const crisp__forced *key)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (forced_cmp(&f[mid], key) < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

static int is_forced(const build_state *b, uint32_t patch, int depth, int ix, int iy)
{
    if (!b->forced_count) return 0;
    crisp__forced key = {patch, (uint32_t)depth, (uint32_t)ix, (uint32_t)iy};
    size_t k = forced_lower(b->forced, b->forced_count, &key);
    return k < b->forced_count && !forced_cmp(&b->forced[k], &key);
}

/* A rational sub-patch within 4 eps and at least this many pixels across keeps a level of 2. */
#define MIN_T2_PX 4.0
/* Levels at or above this, of patches of at least this degree in u or v, try the four children's
 * levels (children_cost). */
#define CHILD_TRY_TAU 16
#define CHILD_TRY_DEGREE 4
/* A leaf's cost to the planner and the backend beyond its triangles, in triangles. */
#define LEAF_COST 8.0

/* What the four children of cell (depth, ix, iy) would draw, in triangles plus LEAF_COST per
 * visible leaf, at the levels they would get as leaves (hull within eps: 1, else their SLEFE
 * level); INFINITY where a child cannot get a level here (W <= 0, above 64). Stops once the sum
 * reaches limit. Issue 12: the SLEFE bound of a whole patch of high degree can be far looser than
 * its halves' (occt_linkrods.step's 6 x 10 patches: 977 px at level 1 for 15 px sampled; a
 * 216 px patch took level 49 where its quarters take 7 to 10), and the level's search cannot see
 * that; the children's levels can. */
typedef struct child_memo {
    int done;       /* children formed so far, in order */
    double term[4]; /* each one's cost: 0 when culled, INFINITY when it cannot get a level here */
    int taus[4];    /* its level, 0 when culled or within eps (a tau-1 leaf decided by its hull) */
    crisp__slefe_level_info infos[4]; /* what its level search formed */
} child_memo;

static double children_cost(build_state *b, int depth, int ix, int iy, double limit, child_memo *m)
{
    const tree_ctx *c = b->c;
    double cost = 0;
    for (int k = 0; k < 4 && cost < limit; k++) {
        if (k == m->done) {
            int cx = 2 * ix + (k & 1), cy = 2 * iy + (k >> 1), tau = 1;
            crisp_bezier_patch ch;
            cell_patch(b, depth + 1, cx, cy, b->child[0], b->child[1], &ch);
            m->done++;
            m->term[k] = 0;
            m->taus[k] = 0;
            m->infos[k] = (crisp__slefe_level_info){{NAN, NAN, NAN}};
            if (outside_frustum(&ch, c->plan->view_proj, c->gx, c->gy)) continue; /* culled */
            double hull = hull_extent_px(&ch, c->plan->view_proj, c->plan->width, c->plan->height);
            m->term[k] = INFINITY;
            if (!isfinite(hull)) return INFINITY;
            if (hull > c->eps &&
                (crisp__slefe_patch_tess_level(&ch, &c->view, c->eps, CRISP_TESS_MAX_LEVEL, &tau,
                                               &m->infos[k]) ||
                 tau > CRISP_TESS_MAX_LEVEL))
                return INFINITY;
            m->taus[k] = hull > c->eps ? tau : 0;
            m->term[k] = 2.0 * tau * tau + LEAF_COST;
        }
        if (!isfinite(m->term[k])) return INFINITY;
        cost += m->term[k];
    }
    return cost;
}

/* Classify cell (depth, ix, iy) of the patch; node is its tree node. box: an ancestor chose to
 * split until the pieces' hulls are within eps (no SLEFE is formed below it). known > 0: the
 * cell's SLEFE level, found by its parent's children_cost (the same sub-patch, so the same
 * level), with what that search formed (known_info; NULL: nothing). */
static void build_cell(build_state *b, int32_t node, int depth, int ix, int iy, int box, int known,
                       const crisp__slefe_level_info *known_info)
{
    if (b->st) return;
    const tree_ctx *c = b->c;
    crisp_bezier_patch sub;
    cell_patch(b, depth, ix, iy, b->storage[0], b->storage[1], &sub);
    crisp__cell leaf = {
        .ix = (uint32_t)ix, .iy = (uint32_t)iy, .depth = (uint8_t)depth, .tau = 1, .culled = 1};
    int split = 0, have_child_tau = 0;
    /* what the level searches of this cell and of its children formed (the depth bound reuses
     * the W curvature) */
    crisp__slefe_level_info info = {{NAN, NAN, NAN}};
    child_memo kids; /* formed by children_cost, in order */
    kids.done = 0;
    if (known_info) info = *known_info;
    if (!outside_frustum(&sub, c->plan->view_proj, c->gx, c->gy)) {
        int tau = 0;
        /* Small on screen (issue 12): a hull within eps needs no SLEFE (tau 1, see
         * hull_extent_px). */
        double hull = hull_extent_px(&sub, c->plan->view_proj, c->plan->width, c->plan->height);
        /* (too_large_on_screen's extents are the hull's before its allowance: within this, the
         * leaf is not too large) */
        int fits = hull <= CRISP_PLAN_MAX_LEAF_PX;
        /* Flat enough on screen for any tessellation (flat_bound): tau 1, like a small hull. */
        /* (the sigma's of the whole patch and of its quarters depend on the weights only: they
         * are kept with the patch groups, formed once per scene) */
        const double *sigmas =
            hull > c->eps && !known && sub.rational
                ? depth == 0   ? crisp__groups_patch_sigmas(c->plan->groups, c->sc, b->patch)
                  : depth == 1 ? crisp__groups_quarter_sigmas(c->plan->groups, c->sc, b->patch,
                                                              ix + 2 * iy, &sub)
                               : NULL
                : NULL;
        double depth_dev[2] = {INFINITY, 0};
        double flat = hull > c->eps && !known
                          ? flat_bound(&sub, sigmas, c->plan->view_proj, c->plan->width,
                                       c->plan->height, c->eps, depth_dev)
                      : hull > c->eps ? INFINITY
                                      : 0;
        /* Level 1 is then enough along the view too where the same bound's W part is within
         * eps pixels' world size at the surface's least W (as patch_groups.c's patch_flat_ok
         * takes it): the depth bound below is not needed. */
        int depth_ok = 0;
        if (hull > c->eps && flat <= c->eps) {
            hull = 0;
            depth_ok = depth_dev[0] <= c->eps * c->depth_scale * depth_dev[1];
        }
        int box_split = box && hull > c->eps && depth < c->plan->max_depth;
        /* A rational sub-patch whose flat bound is within 4 eps: one split is predicted to give
         * four tau-1 leaves (8 triangles, no more than any level above 1 draws), so split without
         * forming the SLEFE level. */
        if (!box_split && sub.rational && hull > c->eps && flat <= 4 * c->eps && isfinite(hull) &&
            depth < c->plan->max_depth) {
            /* (Unless it is a few pixels across and its SLEFE level is 2: one leaf of the same 8
             * triangles. Smaller ones are split: the backend draws no leaf whose hull holds no
             * sample, and most children of a 1-2 px sub-patch hold none; imp far10: 9.2 k
             * triangles split, 13.7 k as one leaf.) */
            int t2 = 0;
            if (!known && hull >= MIN_T2_PX &&
                crisp__slefe_patch_tess_level(&sub, &c->view, c->eps, 2, &t2, &info) == CRISP_OK &&
                t2 <= 2)
                known = t2;
            else
                box_split = box = 1;
        }
        crisp_status st = CRISP_OK;
        int early = 0; /* split by the children's rule from the level's range alone (below) */
        if (!(hull <= c->eps || box_split || known)) {
            int lo = 0, hi = 0;
            st = crisp__slefe_search_begin(&b->search, &sub, &c->view, c->eps, CRISP_TESS_MAX_LEVEL,
                                           &tau, &lo, &hi, &info);
            if (!st && !tau) {
                /* The search's loop (the SLEFE at high levels: most of a high-degree patch's
                 * search) is not needed where the children's rule below splits whatever level in
                 * [lo, hi] it names: every such level is one the rule applies to (at least
                 * CHILD_TRY_TAU, at most 64, none that the hull's rule splits first), and the
                 * children draw less than 3/4 of the least of them. The children's levels are
                 * kept (kids) for the rule below where this does not decide. */
                int kh = isfinite(hull) ? (int)ceil(log2(hull / c->eps)) : 0;
                if (lo >= CHILD_TRY_TAU && hi <= CRISP_TESS_MAX_LEVEL &&
                    depth < c->plan->max_depth && isfinite(hull) &&
                    (sub.du >= CHILD_TRY_DEGREE || sub.dv >= CHILD_TRY_DEGREE) &&
                    !(kh < 6 && 4.0 * ldexp(1.0, 2 * kh) < (double)hi * hi)) {
                    double least = 2.0 * lo * lo + LEAF_COST;
                    if (children_cost(b, depth, ix, iy, 0.75 * least, &kids) < 0.75 * least)
                        early = have_child_tau = 1, st = CRISP_ERR_NUMERIC;
                }
                if (!early) st = crisp__slefe_search_finish(&b->search, &sub, &tau, &info);
            }
        }
        if (known && !box_split) tau = known;
        if (hull <= c->eps) tau = 1;
        /* A rational sub-patch where the homogeneous bound reaches W <= 0: a level from the
         * bound that does not divide by the weights (rational_bound.c), if one is in reach. */
        if (sub.rational && !box_split && !early && isfinite(flat) && st == CRISP_ERR_NUMERIC &&
            isfinite(hull)) {
            int t =
                crisp__rational_tess_level(&sub, CRISP_TESS_MAX_LEVEL + 1, flat, c->plan->view_proj,
                                           c->plan->width, c->plan->height, c->eps);
            if (t <= CRISP_TESS_MAX_LEVEL) st = CRISP_OK, tau = t;
        }
        if (box_split) {
            st = CRISP_ERR_NUMERIC; /* split again (below) */
        } else if (!st && tau > 1 && tau <= CRISP_TESS_MAX_LEVEL && depth < c->plan->max_depth &&
                   isfinite(hull)) {
            /* Where the SLEFE bound asks for many more triangles than splitting until the
             * pieces' hulls are within eps would give (4^k leaves of 2 triangles for k halvings:
             * the hull shrinks about 2x per halving; a leaf costs the planner and the backend
             * about as much as a few triangles, hence 4 * 4^k < tau^2), split instead; the
             * children are decided by their hulls alone. Loose screen bounds of small rational
             * patches seen off axis made 1-2 px patches ask for tau 10-24 (impeller x 49). */
            int k = (int)ceil(log2(hull / c->eps));
            /* (Predicting fewer halvings from the flat bound, which falls about 4x per halving,
             * was tried: on occt_linkrods.step's default view it set off split cascades, plan
             * 8 -> 57 ms for a third fewer triangles; not kept.) */
            if (k < 6 && 4.0 * ldexp(1.0, 2 * k) < (double)tau * tau) {
                st = CRISP_ERR_NUMERIC;
                box = 1;
            } else if (tau >= CHILD_TRY_TAU &&
                       (sub.du >= CHILD_TRY_DEGREE || sub.dv >= CHILD_TRY_DEGREE)) {
                /* A high level of a high degree: split where the four children draw less than
                 * 3/4 of it (each child is then planned as any cell, so this can repeat below it
                 * while it pays). (On every degree it also took impeller.igs default from 146 k
                 * to 129 k triangles, but opened a one-pixel GL-only crack at the seam of
                 * test_cracks' quarter torus, degree 2, view 9: left for the GL stitching.) */
                double mine = 2.0 * tau * tau + LEAF_COST;
                if (children_cost(b, depth, ix, iy, 0.75 * mine, &kids) < 0.75 * mine) {
                    st = CRISP_ERR_NUMERIC;
                    have_child_tau = 1;
                }
            }
        }
        /* (Not searched here for every rational sub-patch whose SLEFE level is above 2: the
         * windows of crisp__rational_tess_level cost about as much as splitting into tau^2
         * pieces, more than the triangles they save; impeller.igs default view: 200 k -> 165 k
         * triangles for 739 M -> 949 M planner instructions per plan.) */
        if (st == CRISP_ERR_NUMERIC) {
            /* The sub-patch reaches the eye plane: split, and at the depth limit drop what is
             * left (a sliver of 2^-max_depth of the patch at the eye). */
            if (depth < c->plan->max_depth)
                split = 1;
            else
                b->pp->unresolved++;
        } else if (st) {
            b->st = st;
            return;
        } else {
            /* Within eps along the view too (issue 13, depth_bound.c). */
            if (!(depth_ok && tau == 1))
                tau = crisp__depth_tess_level_kw(&sub, c->plan->view_proj, c->plan->width,
                                                 c->plan->height, c->eps, tau, CRISP_TESS_MAX_LEVEL,
                                                 info.kw);
            if (tau > CRISP_TESS_MAX_LEVEL && depth < c->plan->max_depth) {
                split = 1;
            } else {
                if (tau > CRISP_TESS_MAX_LEVEL) {
                    tau = CRISP_TESS_MAX_LEVEL;
                    b->pp->unresolved++;
                }
                leaf.tau = (uint16_t)tau;
                leaf.culled = 0;
                if (depth < c->plan->max_depth &&
                    ((!fits && too_large_on_screen(&sub, c->plan->view_proj, c->plan->width,
                                                   c->plan->height)) ||
                     is_forced(b, b->patch, depth, ix, iy)))
                    split = 1;
            }
        }
    }
    if (!split) {
        int32_t li = push_leaf(b, &leaf);
        if (li < 0) {
            b->st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory planning patch leaves");
            return;
        }
        b->pp->nodes[node].leaf = li;
        return;
    }
    int32_t first = -1;
    for (int k = 0; k < 4; k++) {
        int32_t ch = push_node(b);
        if (ch < 0) {
            b->st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory planning patch leaves");
            return;
        }
        if (k == 0) first = ch;
    }
    b->pp->nodes[node].child = first;
    for (int k = 0; k < 4; k++)
        build_cell(b, first + k, depth + 1, 2 * ix + (k & 1), 2 * iy + (k >> 1), box,
                   have_child_tau ? kids.taus[k] : 0, have_child_tau ? &kids.infos[k] : NULL);
}

/* Items [begin, end) of the patch list (every patch, or the redo list), nodes and leaves in
 * arena. */
static void build_range(tree_ctx *c, size_t begin, size_t end, int worker, crisp_arena *arena)
{
    crisp__trees *plan = c->plan;
    build_state *b = plan->build_state[worker];
    for (size_t i = begin; i < end; i++) {
        size_t p = c->redo ? c->redo[i] : c->active[i];
        crisp__patch_tree *pp = &plan->patches[p];
        *pp = (crisp__patch_tree){0};
        plan->tree_frame[p] = plan->frame;
        b->c = c;
        b->pp = pp;
        b->root = &c->sc->patches[p].bez;
        b->patch = (uint32_t)p;
        b->forced = NULL;
        b->forced_count = 0;
        if (plan->forced_count) {
            crisp__forced key = {(uint32_t)p, 0, 0, 0}, end_key = {(uint32_t)p + 1, 0, 0, 0};
            size_t k0 = forced_lower(plan->forced, plan->forced_count, &key);
            size_t k1 = forced_lower(plan->forced, plan->forced_count, &end_key);
            b->forced = plan->forced + k0;
            b->forced_count = k1 - k0;
        }
        b->arena = arena;
        b->keep = plan->keep && !plan->keep_off && keeps_subs(b->root) ? &plan->keep_of[p] : NULL;
        b->node_cap = b->leaf_cap = 0;
        b->have_quarters = 0;
        b->st = CRISP_OK;
        uint8_t mode = !c->redo && c->mode ? c->mode[p] : CRISP__PATCH_OPEN;
        if (mode == CRISP__PATCH_GROUPED) continue; /* no tree: its group leaf stands for it */
        int32_t root = push_node(b);
        if (root < 0) {
            b->st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory planning patch leaves");
        } else if (mode == CRISP__PATCH_GROUP) {
            /* The lower-left patch of a group leaf's block holds the leaf (patch_groups.c). */
            const crisp_scene_patch *sp = &c->sc->patches[p];
            const crisp_scene_face *f = &c->sc->faces[sp->face];
            uint32_t g = plan->group_g[p] & 15u, size = 1u << g;
            crisp__cell leaf = {.tau = (uint16_t)(1u << (plan->group_g[p] >> 4)),
                                .group = (uint8_t)g,
                                .ix = f->grid_u - sp->iu < size ? f->grid_u - sp->iu : size,
                                .iy = f->grid_v - sp->iv < size ? f->grid_v - sp->iv : size};
            int32_t li = push_leaf(b, &leaf);
            if (li < 0)
                b->st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory planning patch leaves");
            else
                pp->nodes[root].leaf = li;
        } else if (mode != CRISP__PATCH_OPEN) {
            /* Decided by its group: outside the frustum, within eps on screen (tau 1), or drawn
             * by its block's group leaf. */
            crisp__cell leaf = {.tau = 1, .culled = mode != CRISP__PATCH_SMALL};
            int32_t li = push_leaf(b, &leaf);
            if (li < 0)
                b->st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory planning patch leaves");
            else
                pp->nodes[root].leaf = li;
        } else {
            build_cell(b, root, 0, 0, 0, 0, 0, NULL);
        }
        if (b->st) plan->worker_status[worker] = b->st;
        for (uint32_t l = 0; l < pp->leaf_count; l++)
            pp->visible_leaves += !pp->leaves[l].culled;
    }
}

/* A fixed split of the list into TREE_CHUNKS ranges, each with its own arena: what each arena
 * holds does not depend on which thread ran which range, so a frame that needs no more memory
 * than an earlier one allocates nothing (with per-thread arenas it did, depending on the
 * dynamic work split). */
static void build_chunks(void *vctx, size_t begin, size_t end, int worker)
{
    tree_ctx *c = vctx;
    for (size_t ch = begin; ch < end; ch++)
        build_range(c, c->count * ch / TREE_CHUNKS, c->count * (ch + 1) / TREE_CHUNKS, worker,
                    c->plan->chunk_arenas[ch]);
}

/* ---- pass 2: edge levels --------------------------------------------------------------------- */

/* Leaves of `pp` inside cell (depth, ix, iy) touching the cell's side `side` (0: t = 0, 1: s = 1,
 * 2: t = 1, 3: s = 0), or the single coarser-or-equal leaf containing the cell. Returns the count
 * written (at most cap; more are counted in *total). */
static int leaves_at(const crisp__patch_tree *pp, int depth, uint32_t ix, uint32_t iy, int side,
                     const crisp__cell **out, int cap, int *total)
{
    *total = 0;
    if (!pp->node_count) return 0;
    int32_t node = 0;
    for (int d = 0; d < depth; d++) {
        if (pp->nodes[node].child < 0) break;
        int shift = depth - d - 1;
        int k = (int)((ix >> shift) & 1) | (int)(((iy >> shift) & 1) << 1);
        node = pp->nodes[node].child + k;
    }
    if (pp->nodes[node].child < 0) {
        out[0] = &pp->leaves[pp->nodes[node].leaf];
        *total = 1;
        return 1;
    }
    /* The cell is subdivided: walk its subtree, keeping children on the side. */
    int32_t stack[64];
    int top = 0, n = 0;
    stack[top++] = node;
    while (top > 0) {
        int32_t nd = stack[--top];
        if (pp->nodes[nd].child < 0) {
            if (n < cap) out[n++] = &pp->leaves[pp->nodes[nd].leaf];
            (*total)++;
            continue;
        }
        for (int k = 0; k < 4; k++) {
            int kx = k & 1, ky = k >> 1;
            int on = side == 0 ? ky == 0 : side == 1 ? kx == 1 : side == 2 ? ky == 1 : kx == 0;
            if (on && top < 64) stack[top++] = pp->nodes[nd].child + k;
        }
    }
    return n;
}

/* The patch whose leaves stand for patch q: q itself when it has a tree this frame, else the
 * lower-left patch of its group leaf's block, or q when it is culled (its tree: culled_tree). */
static uint32_t owner_patch(const crisp__trees *plan, const crisp_scene *sc, uint32_t q)
{
    if (plan->tree_frame[q] == plan->frame) return q;
    return crisp__groups_owner(plan->groups, sc, q);
}

/* A culled patch without a tree of its own reads as one culled leaf over the whole patch. */
static const crisp__node culled_node = {-1, 0};
static const crisp__cell culled_cell = {.tau = 1, .culled = 1};
static const crisp__patch_tree culled_tree = {
    .nodes = (crisp__node *)&culled_node, .leaves = (crisp__cell *)&culled_cell, 1, 1, 0, 0};

static const crisp__patch_tree *tree_of(const crisp__trees *plan, uint32_t q)
{
    return plan->tree_frame[q] == plan->frame ? &plan->patches[q] : &culled_tree;
}

/* Length of side `side` of a leaf in units of 2^-CRISP_PLAN_MAX_DEPTH of a patch. */
static uint64_t side_length(const crisp__cell *L, int side)
{
    if (L->group) return (uint64_t)((side & 1) ? L->iy : L->ix) << CRISP_PLAN_MAX_DEPTH;
    return 1ull << (CRISP_PLAN_MAX_DEPTH - L->depth);
}

/* The leaves across side `side` of group leaf L (lower-left patch p): per patch along the side,
 * outside the block, its leaves touching the side (a group leaf once). */
static int across_group(const crisp__trees *plan, const crisp_scene *sc, uint32_t p,
                        const crisp__cell *L, int side, const crisp__cell **out, int cap,
                        int *total)
{
    const crisp_scene_patch *sp = &sc->patches[p];
    const crisp_scene_face *f = &sc->faces[sp->face];
    int64_t iu0 = sp->iu, iv0 = sp->iv, nu = L->ix, nv = L->iy;
    int64_t fixed = side == 0 ? iv0 - 1 : side == 1 ? iu0 + nu : side == 2 ? iv0 + nv : iu0 - 1;
    int64_t grid_fixed = (side & 1) ? f->grid_u : f->grid_v;
    int closed = (side & 1) ? f->closed_u : f->closed_v;
    *total = 0;
    if (closed) fixed = (fixed + grid_fixed) % grid_fixed;
    if (fixed < 0 || fixed >= grid_fixed) return 0;
    int64_t a0 = (side & 1) ? iv0 : iu0, a1 = a0 + ((side & 1) ? nv : nu);
    int n = 0, nside = (side + 2) % 4;
    const crisp__cell *last = NULL;
    for (int64_t a = a0; a < a1; a++) {
        int64_t iu = (side & 1) ? fixed : a, iv = (side & 1) ? a : fixed;
        uint32_t q = owner_patch(plan, sc, f->first_patch + (uint32_t)(iv * f->grid_u + iu));
        const crisp__cell *got[CRISP__NB_CAP];
        int t, m = leaves_at(tree_of(plan, q), 0, 0, 0, nside, got, CRISP__NB_CAP, &t);
        if (m == 1 && t == 1 && got[0] == last) continue; /* the same group leaf again */
        for (int k = 0; k < m; k++) {
            if (n < cap) out[n++] = got[k];
            last = got[k];
        }
        *total += t;
        if (m == 1 && got[0]->group) {
            /* The rest of that group leaf's block along this side is the same leaf. */
            const crisp_scene_patch *o = &sc->patches[q];
            int64_t end = (side & 1) ? (int64_t)o->iv + got[0]->iy : (int64_t)o->iu + got[0]->ix;
            if (end - 1 > a) a = end - 1;
        }
    }
    return n;
}

/* The leaves across side `side` of leaf L of patch p (same patch or the face's neighbour patch,
 * or the group leaf standing for it). */
static int across(const crisp__trees *plan, const crisp_scene *sc, uint32_t p, const crisp__cell *L,
                  int side, const crisp__cell **out, int cap, int *total)
{
    if (L->group) return across_group(plan, sc, p, L, side, out, cap, total);
    int d = L->depth;
    uint32_t n = 1u << d;
    int64_t nx = (int64_t)L->ix + (side == 1) - (side == 3);
    int64_t ny = (int64_t)L->iy + (side == 2) - (side == 0);
    uint32_t q = p;
    if (nx < 0 || ny < 0 || nx >= n || ny >= n) {
        const crisp_scene_patch *sp = &sc->patches[p];
        const crisp_scene_face *f = &sc->faces[sp->face];
        int64_t iu = (int64_t)sp->iu + (nx >= n) - (nx < 0),
                iv = (int64_t)sp->iv + (ny >= n) - (ny < 0);
        if (f->closed_u) iu = (iu + f->grid_u) % f->grid_u;
        if (f->closed_v) iv = (iv + f->grid_v) % f->grid_v;
        if (iu < 0 || iv < 0 || iu >= f->grid_u || iv >= f->grid_v) {
            *total = 0;
            return 0;
        }
        q = owner_patch(plan, sc, f->first_patch + (uint32_t)(iv * f->grid_u + iu));
        nx = (nx + n) % n;
        ny = (ny + n) % n;
    }
    return leaves_at(tree_of(plan, q), d, (uint32_t)nx, (uint32_t)ny, (side + 2) % 4, out, cap,
                     total);
}

/* Level of the edge `side` of leaf L when L owns it (every leaf across is at most as long on the
 * side). With lengths in units of u, the greatest common divisor of the lengths, the edge
 * places m vertices per u, m the largest tau_k u / len_k rounded up over L and the leaves
 * across: L's level is m len_L / u and every leaf across takes m len_k / u of those vertices, an
 * integer, at the same places. */
static uint64_t gcd64(uint64_t a, uint64_t b)
{
    while (b) {
        uint64_t t = a % b;
        a = b;
        b = t;
    }
    return a;
}

static uint32_t owner_level(const crisp__cell *L, int side, const crisp__cell *const *nb, int count)
{
    uint64_t lenL = side_length(L, side), u = lenL;
    for (int k = 0; k < count; k++)
        u = gcd64(u, side_length(nb[k], side));
    uint64_t m = ((uint64_t)L->tau * u + lenL - 1) / lenL;
    for (int k = 0; k < count; k++) {
        uint64_t len = side_length(nb[k], side), mk = ((uint64_t)nb[k]->tau * u + len - 1) / len;
        m = mk > m ? mk : m;
    }
    if (m < 1) m = 1;
    uint64_t level = m * (lenL / u);
    return (uint32_t)(level > CRISP_TESS_MAX_EDGE_LEVEL ? CRISP_TESS_MAX_EDGE_LEVEL : level);
}

typedef struct edge_ctx {
    crisp__trees *plan;
    const crisp_scene *sc;
} edge_ctx;

static void edge_levels(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    edge_ctx *c = vctx;
    enum { CAP = CRISP__NB_CAP };
    const crisp__cell *nb[CAP], *back[CAP];
    for (size_t i = begin; i < end; i++) {
        size_t p = c->plan->active[i];
        crisp__patch_tree *pp = &c->plan->patches[p];
        for (uint32_t l = 0; l < pp->leaf_count; l++) {
            crisp__cell *L = &pp->leaves[l];
            if (L->culled) continue;
            for (int side = 0; side < 4; side++) {
                int total, n = across(c->plan, c->sc, (uint32_t)p, L, side, nb, CAP, &total);
                uint64_t lenL = side_length(L, side);
                if (total == 1 && n == 1 && side_length(nb[0], side) > lenL) {
                    /* A longer neighbour owns the edge: take this leaf's share of its level. */
                    const crisp__cell *N = nb[0];
                    int bt, bn = 0;
                    /* N lies in p, or stands for the neighbour patch across `side`. */
                    uint32_t q = (uint32_t)p;
                    uint32_t nside = (uint32_t)((side + 2) % 4);
                    const crisp_scene_patch *sp = &c->sc->patches[p];
                    uint32_t cells = 1u << L->depth;
                    int leaves_patch = L->group || (side == 1 && L->ix + 1 == cells) ||
                                       (side == 3 && L->ix == 0) ||
                                       (side == 2 && L->iy + 1 == cells) ||
                                       (side == 0 && L->iy == 0);
                    if (leaves_patch) {
                        const crisp_scene_face *f = &c->sc->faces[sp->face];
                        int64_t iu = (int64_t)sp->iu, iv = (int64_t)sp->iv;
                        if (L->group) {
                            iu += side == 1 ? (int64_t)L->ix : -(side == 3);
                            iv += side == 2 ? (int64_t)L->iy : -(side == 0);
                        } else {
                            iu += (side == 1) - (side == 3);
                            iv += (side == 2) - (side == 0);
                        }
                        if (f->closed_u) iu = (iu + f->grid_u) % f->grid_u;
                        if (f->closed_v) iv = (iv + f->grid_v) % f->grid_v;
                        q = owner_patch(c->plan, c->sc,
                                        f->first_patch + (uint32_t)(iv * f->grid_u + iu));
                    }
                    bn = across(c->plan, c->sc, q, N, (int)nside, back, CAP, &bt);
                    uint64_t lv = owner_level(N, (int)nside, back, bn);
                    uint64_t share = lv * lenL / side_length(N, side);
                    L->edge[side] = share ? (uint32_t)share : 1;
                } else {
                    L->edge[side] = owner_level(L, side, nb, n);
                }
            }
        }
    }
}

/* ---- levels above the GL limit ------------------------------------------------------------
 * The crack-free rule can give a coarse leaf next to much finer ones an edge level above
 * CRISP_PLAN_MAX_LEVEL (64, GL's guaranteed tessellation limit). Such a leaf is split instead of
 * clamped: its children's edges are half as long, so they need half the level. The split cells
 * are recorded as forced, their patches' trees rebuilt, and the edge levels recomputed, until no
 * level is above the limit (or the depth limit stops the splitting: then the level is clamped and
 * the leaf counted as unresolved). */
static int u32_cmp(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

static crisp_status split_high_levels(crisp__trees *plan, const crisp_scene *sc, tree_ctx *tc,
                                      crisp_pool *pool, uint32_t *splits)
{
    plan->forced_count = 0;
    for (int round = 0; round < 2 * CRISP_PLAN_MAX_DEPTH; round++) {
        size_t added = 0, redo = 0;
        for (size_t i = 0; i < plan->active_count; i++) {
            uint32_t p = plan->active[i];
            const crisp__patch_tree *pp = &plan->patches[p];
            int marked = 0;
            for (uint32_t l = 0; l < pp->leaf_count; l++) {
                const crisp__cell *L = &pp->leaves[l];
                if (L->culled || L->depth >= plan->max_depth) continue;
                /* A group leaf above level 1 is bounded cell by cell (patch_groups.c
                 * cells_flat_ok): every edge level must be a multiple of its tau. */
                int cells = 1;
                if (L->group && L->tau > 1)
                    for (int k = 0; k < 4; k++)
                        cells &= L->edge[k] % L->tau == 0;
                if (cells && L->edge[0] <= CRISP_PLAN_MAX_LEVEL &&
                    L->edge[1] <= CRISP_PLAN_MAX_LEVEL && L->edge[2] <= CRISP_PLAN_MAX_LEVEL &&
                    L->edge[3] <= CRISP_PLAN_MAX_LEVEL)
                    continue;
                crisp_status st;
                if (L->group) {
                    /* A group leaf is not split: its block's patches are planned one by one
                     * (their own quadtrees) instead (a level above the limit, or one that is not
                     * a multiple of its tau). */
                    const crisp_scene_patch *sp = &sc->patches[p];
                    const crisp_scene_face *f = &sc->faces[sp->face];
                    uint32_t nu = L->ix, nv = L->iy;
                    if ((st = crisp_grow((void **)&plan->redo, &plan->redo_cap,
                                         redo + (size_t)nu * nv, sizeof *plan->redo)))
                        return st;
                    for (uint32_t iv = sp->iv; iv < sp->iv + nv; iv++)
                        for (uint32_t iu = sp->iu; iu < sp->iu + nu; iu++) {
                            uint32_t q = f->first_patch + iv * f->grid_u + iu;
                            plan->patch_mode[q] = CRISP__PATCH_OPEN;
                            plan->redo[redo++] = q;
                        }
                    added++;
                    break;
                }
                st = crisp_grow((void **)&plan->forced, &plan->forced_cap, plan->forced_count + 1,
                                sizeof *plan->forced);
                if (st) return st;
                plan->forced[plan->forced_count++] = (crisp__forced){p, L->depth, L->ix, L->iy};
                added++;
                if (!marked) {
                    if ((st = crisp_grow((void **)&plan->redo, &plan->redo_cap, redo + 1,
                                         sizeof *plan->redo)))
                        return st;
                    plan->redo[redo++] = p;
                    marked = 1;
                }
            }
        }
        if (!added) break;
        *splits += (uint32_t)added;
        /* Ungrouped blocks' patches may come after later patches in the list; those without a
         * tree of their own so far join the active patches. */
        if (redo) qsort(plan->redo, redo, sizeof *plan->redo, u32_cmp);
        size_t join = 0;
        for (size_t k = 0; k < redo; k++)
            join += plan->tree_frame[plan->redo[k]] != plan->frame;
        if (join) {
            crisp_status st = crisp_grow((void **)&plan->active, &plan->active_cap,
                                         plan->active_count + join, sizeof *plan->active);
            if (st) return st;
            for (size_t k = 0; k < redo; k++)
                if (plan->tree_frame[plan->redo[k]] != plan->frame)
                    plan->active[plan->active_count++] = plan->redo[k];
            qsort(plan->active, plan->active_count, sizeof *plan->active, u32_cmp);
            tc->active = plan->active;
        }
        if (plan->forced_count) /* forced is NULL until a leaf is forced (qsort takes no NULL) */
            qsort(plan->forced, plan->forced_count, sizeof *plan->forced, forced_qsort_cmp);
        tc->redo = plan->redo;
        tc->count = redo;
        crisp_pool_parallel_for(pool, TREE_CHUNKS, 1, build_chunks, tc);
        tc->redo = NULL;
        for (int w = 0; w < plan->worker_cap; w++)
            if (plan->worker_status[w]) return plan->worker_status[w];
        edge_ctx ec = {plan, sc};
        crisp_pool_parallel_for(pool, plan->active_count, 16, edge_levels, &ec);
    }
    /* What is left above the limit sits at the depth limit. */
    for (size_t i = 0; i < plan->active_count; i++) {
        crisp__patch_tree *pp = &plan->patches[plan->active[i]];
        for (uint32_t l = 0; l < pp->leaf_count; l++)
            for (int k = 0; k < 4; k++)
                if (pp->leaves[l].edge[k] > CRISP_PLAN_MAX_LEVEL) {
                    pp->leaves[l].edge[k] = CRISP_PLAN_MAX_LEVEL;
                    pp->unresolved++;
                }
    }
    return CRISP_OK;
}

/* ---- the plan ----------------------------------------------------------------------------------
 */

crisp_status crisp__trees_create(crisp__trees **dest)
{
    crisp__trees *p = calloc(1, sizeof *p);
    if (!p) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating a frame plan");
    crisp_status st = crisp__groups_create(&p->groups);
    for (int k = 0; !st && k < TREE_CHUNKS; k++)
        st = crisp_arena_create(1 << 16, &p->chunk_arenas[k]);
    if (st) {
        crisp__trees_destroy(p);
        return st;
    }
    *dest = p;
    return CRISP_OK;
}

void crisp__trees_destroy(crisp__trees *p)
{
    if (!p) return;
    for (int w = 0; w < p->worker_cap; w++) {
        crisp_arena_destroy(p->arenas[w]);
        free(p->build_state[w]);
    }
    free(p->arenas);
    free(p->build_state);
    free(p->worker_status);
    free(p->trim_used);
    free(p->patches);
    free(p->forced);
    free(p->redo);
    crisp__groups_destroy(p->groups);
    free(p->patch_mode);
    free(p->active);
    free(p->tree_frame);
    free(p->group_g);
    free(p->keep_of);
    free(p->keep);
    for (int k = 0; k < TREE_CHUNKS; k++)
        crisp_arena_destroy(p->chunk_arenas[k]);
    for (uint32_t f = 0; f < p->face_cap; f++) {
        crisp_trim_plan_free(&p->trims[f]);
        crisp_trim_density_tree_free(&p->density[f]);
        crisp_trim_lod_free(&p->lod[f]);
    }
    free(p->lod);
    free(p->lod_key);
    free(p->lod_face);
    free(p->lod_todo);
    free(p->trims);
    free(p->density);
    free(p->density_gen);
    free(p->face_tau);
    free(p->face_rows);
    free(p->visible);
    free(p);
}

static crisp_status ensure_workers(crisp__trees *p, int workers)
{
    if (workers <= p->worker_cap) return CRISP_OK;
    crisp_arena **a = realloc(p->arenas, (size_t)workers * sizeof *a);
    if (!a) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for planner workers");
    p->arenas = a;
    void **b = realloc(p->build_state, (size_t)workers * sizeof *b);
    if (!b) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for planner workers");
    p->build_state = b;
    crisp_status *s = realloc(p->worker_status, (size_t)workers * sizeof *s);
    if (!s) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for planner workers");
    p->worker_status = s;
    size_t *u = realloc(p->trim_used, (size_t)workers * sizeof *u);
    if (!u) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for planner workers");
    p->trim_used = u;
    for (int w = p->worker_cap; w < workers; w++) {
        p->arenas[w] = NULL;
        p->build_state[w] = NULL;
    }
    for (int w = p->worker_cap; w < workers; w++) {
        crisp_status st = crisp_arena_create(1 << 16, &p->arenas[w]);
        p->build_state[w] = malloc(sizeof(build_state));
        if (st || !p->build_state[w]) {
            p->worker_cap = w + 1;
            return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for planner workers");
        }
    }
    p->worker_cap = workers;
    return CRISP_OK;
}

typedef struct trim_ctx {
    crisp__trees *plan;
    const crisp_scene *sc;
    const uint32_t *faces; /* the faces planned: faces[begin .. end) of the parallel_for */
    int strip_count;
    crisp_status *status;
    size_t *scratch_used; /* per worker: the most scratch one face took */
} trim_ctx;

/* Faces at most this many pixels across (their box) get chains (crisp_trim_plan_desc.chains).
 * 64 until session 7: 256 takes impeller x 49 at the default view from 185 k to 147 k ribbon quads
 * (faces of 64-256 px kept a quad per trim piece at least); at close-ups faces are larger, and
 * chains there cost the ribbons' middle probes (impeller close-up +5% plan instructions with every
 * face on chains). */
#define CHAIN_FACE_PX 256.0

/* 1 when visible face f gets chains and a coarse polyline this frame (a face a few pixels
 * across, not drawn whole). */
static int wants_lod(const crisp__trees *plan, uint32_t f)
{
    return crisp__groups_face_px(plan->groups, f) <= CHAIN_FACE_PX;
}

typedef struct lod_ctx {
    crisp__trees *plan;
    const crisp_scene *sc;
    crisp_status *status;
} lod_ctx;

static void build_lods(void *vctx, size_t begin, size_t end, int worker)
{
    lod_ctx *c = vctx;
    for (size_t i = begin; i < end; i++) {
        uint32_t f = c->plan->lod_todo[i];
        const crisp_scene_face *sf = &c->sc->faces[f];
        crisp_status st = crisp_trim_lod_build(c->sc->pieces + sf->first_piece,
                                               (int)sf->piece_count, &c->plan->lod[f]);
        if (st) {
            crisp_error_prefix("face %u (source entity %d)", f, sf->src->source_id);
            c->status[worker] = st;
            c->plan->lod_key[f] = 0;
        }
    }
}

/* The coarse trim polylines (crisp_trim_lod) that faces faces[0 .. n - 1] want this frame and
 * that are not built yet, built in parallel before the trim plans read them. They are
 * view-independent and kept per range of pieces: faces with the same pieces (the scene shares their
 * range, one part instanced many times) share one (impeller x 49: 13,573 builds and 107 MB -> 277
 * builds). */
static crisp_status make_lods(crisp__trees *plan, const crisp_scene *sc, const uint32_t *faces,
                              size_t count, crisp_pool *pool)
{
    if (plan->lod_map != sc->trim_serial) {
        /* Which face's lod each face uses: the first face with its range of pieces. */
        uint32_t *first = crisp_malloc_array(sc->piece_count ? sc->piece_count : 1, sizeof *first);
        if (!first) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim plans");
        memset(first, 0xff, (sc->piece_count ? sc->piece_count : 1) * sizeof *first);
        for (uint32_t f = 0; f < sc->face_count; f++) {
            const crisp_scene_face *sf = &sc->faces[f];
            plan->lod_face[f] = f;
            if (!sf->piece_count) continue;
            if (first[sf->first_piece] == UINT32_MAX) first[sf->first_piece] = f;
            plan->lod_face[f] = first[sf->first_piece];
            if (plan->lod_face[f] != f) { /* a copy's lod from an older mapping: not needed */
                crisp_trim_lod_free(&plan->lod[f]);
                plan->lod_key[f] = 0;
            }
        }
        free(first);
        plan->lod_map = sc->trim_serial;
    }
    size_t n = 0;
    for (size_t i = 0; i < count; i++) {
        uint32_t f = faces[i];
        if (!plan->face_tau[f] || !sc->faces[f].piece_count ||
            crisp__groups_face_small(plan->groups, f) || !wants_lod(plan, f))
            continue;
        uint32_t o = plan->lod_face[f];
        if (plan->lod_key[o] == sc->trim_serial) continue;
        crisp_status st = crisp_grow((void **)&plan->lod_todo, &plan->lod_todo_cap, n + 1,
                                     sizeof *plan->lod_todo);
        if (st) return st;
        plan->lod_todo[n++] = o;
        plan->lod_key[o] = sc->trim_serial; /* claimed: listed once */
    }
    if (!n) return CRISP_OK;
    int workers = crisp_pool_threads(pool);
    for (int w = 0; w < workers; w++)
        plan->worker_status[w] = CRISP_OK;
    lod_ctx c = {plan, sc, plan->worker_status};
    crisp_pool_parallel_for(pool, n, 1, build_lods, &c);
    for (int w = 0; w < workers; w++)
        if (plan->worker_status[w]) return plan->worker_status[w];
    return CRISP_OK;
}

/* Faces at most this many pixels across (their box) get one trim strip (session 8: impeller x 49
 * far, 1.1% fewer frame instructions, 7% more table rows). */
#define TINY_FACE_PX 8.0

static void plan_trims(void *vctx, size_t begin, size_t end, int worker)
{
    trim_ctx *c = vctx;
    for (size_t i = begin; i < end; i++) {
        size_t f = c->faces[i];
        if (!c->plan->face_tau[f]) continue;
        const crisp_scene_face *sf = &c->sc->faces[f];
        int strips = c->strip_count;
        if (strips <= 0) {
            /* n_V: the face's tess level over its patch rows (Wu & Peters' default). A group
             * leaf's rows are its tau over its block's patch rows (session 9: with its tau
             * alone, gen100's 4 x 4 blocks at level 2 asked for twice gen50's strips for the same
             * surface and triangles, and the trim polylines, whose tolerance is a quarter strip,
             * gave 23% more ribbon quads). */
            double s = ceil(c->plan->face_rows[f] * (sf->grid_v ? sf->grid_v : 1) - 1e-9);
            strips = (int)(s < 8 ? 8 : s > 256 ? 256 : s);
            /* No more strips than the face is pixels across on screen (issue 12: a face a few
             * pixels tall kept up to 256 strips; one strip for a face within a pixel). Strips only
             * localise the density bound: the rows of any strip count keep the 1 px guarantee. */
            double px = crisp__groups_face_px(c->plan->groups, (uint32_t)f);
            if (px < strips) strips = px < 1 ? 1 : (int)ceil(px);
            /* One strip for a face at most TINY_FACE_PX across (issue 12): its rows are few
             * either way, and each strip costs the density walk a bound per patch it reaches. */
            if (px <= TINY_FACE_PX) strips = 1;
        }
        /* A face within 0.7 px on screen: every point of it is within a pixel of its trims, so
         * every decision is within the pixel band: an all-inside table, no density bound, no
         * polyline, no ribbons. */
        int small = crisp__groups_face_small(c->plan->groups, (uint32_t)f);
        if (small) {
            crisp_trim_plan *tp = &c->plan->trims[f];
            static const uint32_t no_rows = 0;
            tp->strip_count = 1;
            tp->clamped = 0;
            tp->polyline.piece_count = 0;
            tp->chains = 0;
            tp->v0 = sf->domain[2];
            tp->v1 = sf->domain[3];
            crisp_status st = crisp_trim_table_build(&(crisp_trim_table_desc){.polyline = NULL,
                                                                              .v0 = sf->domain[2],
                                                                              .v1 = sf->domain[3],
                                                                              .strip_count = 1,
                                                                              .mu = &no_rows},
                                                     &tp->table);
            if (st) c->status[worker] = st;
            continue;
        }
        /* The face's blocks for the density bound (issue 12), built once per scene. */
        const crisp_trim_density_tree *tree = NULL;
        uint64_t gen = crisp__groups_generation(c->plan->groups);
        if (sf->grid_u * sf->grid_v == sf->patch_count && sf->patch_count > 1) {
            if (c->plan->density_gen[f] != gen) {
                crisp_status st =
                    crisp_trim_density_tree_build(c->sc->face_patches[f].patches, (int)sf->grid_u,
                                                  (int)sf->grid_v, &c->plan->density[f]);
                if (st) {
                    c->status[worker] = st;
                    continue;
                }
                c->plan->density_gen[f] = gen;
            }
            tree = &c->plan->density[f];
        }
        /* Scratch of the density bound: the worker's arena (one per face kept about 600 MB
         * for impeller x 49 far away); its largest need is kept reserved in every worker's
         * arena (trim_scratch), so which worker plans which face allocates nothing new. */
        crisp_arena *scratch = c->plan->arenas[worker];
        /* A face a few pixels across: its trim pieces joined into chains of few chords
         * (crisp_trim_polyline_chains), for the table and the ribbons alike, or one of its
         * view-independent coarse polylines (built once per face and trim edit). */
        int chains = wants_lod(c->plan, (uint32_t)f);
        const crisp_trim_lod *lod = NULL;
        if (chains && sf->piece_count) {
            /* Made by make_lods before this pass (shared by the faces with the same pieces). */
            uint32_t o = c->plan->lod_face[f];
            if (c->plan->lod_key[o] == c->sc->trim_serial) lod = &c->plan->lod[o];
        }
        crisp_trim_plan_desc d = {
            .tree = tree,
            .scratch = scratch,
            .chains = chains,
            .lod = lod,
            .patches = c->sc->face_patches[f].patches,
            .patch_count = c->sc->face_patches[f].count,
            .pieces = sf->piece_count && !small ? c->sc->pieces + sf->first_piece : NULL,
            .piece_count = small ? 0 : (int)sf->piece_count,
            .view_proj = &c->plan->view_proj,
            .width = c->plan->width,
            .height = c->plan->height,
            .v0 = sf->domain[2],
            .v1 = sf->domain[3],
            .strip_count = strips,
        };
        crisp_status st = crisp_trim_plan_face(&d, &c->plan->trims[f]);
        size_t used = crisp_arena_used(scratch);
        if (used > c->scratch_used[worker]) c->scratch_used[worker] = used;
        if (st) {
            crisp_error_prefix("face %zu (source entity %d)", f, sf->src->source_id);
            c->status[worker] = st;
        }
    }
}

/* The kept sub-patches (cell_patch) emptied for a new scene: the blocks' room made once per scene
 * (KEEP_SUBS entries for each patch of KEEP_DEGREE, up to KEEP_BYTES_MAX; kept when large enough),
 * carved by the patches that split below their quarters first. */
static crisp_status keep_for_scene(crisp__trees *plan, const crisp_scene *sc)
{
    if (plan->keep_serial == sc->serial && plan->keep) return CRISP_OK;
    size_t np = sc->patch_count ? sc->patch_count : 1, bytes = 0;
    crisp_status st =
        crisp_grow((void **)&plan->keep_of, &plan->keep_of_cap, np, sizeof *plan->keep_of);
    if (st) return st;
    memset(plan->keep_of, 0, np * sizeof *plan->keep_of);
    for (uint32_t p = 0; p < sc->patch_count && bytes < KEEP_BYTES_MAX; p++)
        if (keeps_subs(&sc->patches[p].bez)) bytes += keep_block_bytes(&sc->patches[p].bez);
    if (bytes > KEEP_BYTES_MAX) bytes = KEEP_BYTES_MAX;
    if (bytes > plan->keep_bytes || !plan->keep) {
        free(plan->keep);
        plan->keep_bytes = 0;
        plan->keep = malloc(bytes ? bytes : 64);
        if (!plan->keep) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for sub-patches");
        plan->keep_bytes = bytes;
    }
    atomic_store_explicit(&plan->keep_used, 0, memory_order_relaxed);
    plan->keep_serial = sc->serial;
    return CRISP_OK;
}

crisp_status crisp__trees_build(crisp__trees *plan, const crisp_scene *sc, const crisp_camera *cam,
                                const crisp__trees_desc *desc, crisp_pool *pool)
{
    crisp_status st = crisp_camera_check(cam);
    if (st) return st;
    double t0 = crisp_time_now();
    int workers = crisp_pool_threads(pool);
    if ((st = ensure_workers(plan, workers))) return st;
    for (int w = 0; w < workers; w++) {
        crisp_arena_reset(plan->arenas[w]);
        for (int k = 0; k < TREE_CHUNKS; k++)
            crisp_arena_reset(plan->chunk_arenas[k]);
        plan->worker_status[w] = CRISP_OK;
    }
    if ((st = crisp_grow((void **)&plan->patches, &plan->patch_cap,
                         sc->patch_count ? sc->patch_count : 1, sizeof *plan->patches)))
        return st;
    if (sc->face_count > plan->face_cap) {
        crisp_trim_plan *t = realloc(plan->trims, sc->face_count * sizeof *t);
        if (!t) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim plans");
        memset(t + plan->face_cap, 0, (sc->face_count - plan->face_cap) * sizeof *t);
        plan->trims = t;
        uint32_t *ft = realloc(plan->face_tau, sc->face_count * sizeof *ft);
        if (!ft) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim plans");
        plan->face_tau = ft;
        float *fr = realloc(plan->face_rows, sc->face_count * sizeof *fr);
        if (!fr) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim plans");
        plan->face_rows = fr;
        crisp_trim_density_tree *dt = realloc(plan->density, sc->face_count * sizeof *dt);
        if (!dt) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim plans");
        memset(dt + plan->face_cap, 0, (sc->face_count - plan->face_cap) * sizeof *dt);
        plan->density = dt;
        uint64_t *dg = realloc(plan->density_gen, sc->face_count * sizeof *dg);
        if (!dg) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim plans");
        memset(dg + plan->face_cap, 0, (sc->face_count - plan->face_cap) * sizeof *dg);
        plan->density_gen = dg;
        crisp_trim_lod *lod = realloc(plan->lod, sc->face_count * sizeof *lod);
        if (!lod) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim plans");
        memset(lod + plan->face_cap, 0, (sc->face_count - plan->face_cap) * sizeof *lod);
        plan->lod = lod;
        uint64_t *lk = realloc(plan->lod_key, sc->face_count * sizeof *lk);
        if (!lk) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim plans");
        memset(lk + plan->face_cap, 0, (sc->face_count - plan->face_cap) * sizeof *lk);
        plan->lod_key = lk;
        uint32_t *lf = realloc(plan->lod_face, sc->face_count * sizeof *lf);
        if (!lf) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim plans");
        plan->lod_face = lf;
        plan->lod_map = 0;
        plan->face_cap = sc->face_count;
    }
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    crisp_mat4_copy(m.view_proj, plan->view_proj);
    plan->width = cam->width;
    plan->height = cam->height;
    plan->max_depth = desc && desc->max_depth > 0 ? desc->max_depth : CRISP_PLAN_MAX_DEPTH;
    plan->forced_count = 0;
    if (plan->max_depth > CRISP_PLAN_MAX_DEPTH) plan->max_depth = CRISP_PLAN_MAX_DEPTH;
    double eps = desc && desc->eps_px > 0 ? desc->eps_px : 0.5;

    tree_ctx tc = {.plan = plan, .sc = sc, .eps = eps};
    crisp_mat4_copy(m.view_proj, tc.view.view_proj);
    tc.view.width = cam->width;
    tc.view.height = cam->height;
    /* Cull against the frustum widened by 2 px so patches touching the border keep their edges. */
    tc.gx = 1 + 4.0 / cam->width;
    tc.gy = 1 + 4.0 / cam->height;
    tc.depth_scale = crisp__depth_px_scale(m.view_proj, cam->width, cam->height);
    size_t np = sc->patch_count ? sc->patch_count : 1;
    plan->no_groups = desc && desc->no_groups;
    size_t old_cap = plan->tree_frame_cap;
    if ((st = crisp_grow((void **)&plan->patch_mode, &plan->mode_cap, np,
                         sizeof *plan->patch_mode)) ||
        (st = crisp_grow((void **)&plan->tree_frame, &plan->tree_frame_cap, np,
                         sizeof *plan->tree_frame)) ||
        (st = crisp_grow((void **)&plan->group_g, &plan->group_g_cap, np, sizeof *plan->group_g)))
        return st;
    if (plan->tree_frame_cap > old_cap)
        memset(plan->tree_frame + old_cap, 0,
               (plan->tree_frame_cap - old_cap) * sizeof *plan->tree_frame);
    /* A new frame: no patch has a tree yet (stamps of 0 never match; after 2^32 builds every
     * stamp is cleared once, and the kept sub-patches with them). */
    if (++plan->frame == 0) {
        memset(plan->tree_frame, 0, plan->tree_frame_cap * sizeof *plan->tree_frame);
        plan->frame = 1;
        plan->keep_serial = 0;
    }
    if ((st = keep_for_scene(plan, sc))) return st;
    crisp__patch_groups pg = {plan->patch_mode,  plan->group_g,
                              &plan->active,     &plan->active_count,
                              &plan->active_cap, desc ? desc->skip_faces : NULL};
    if (plan->no_groups) pg.group_g = NULL;
    if ((st = crisp__groups_classify(plan->groups, sc, plan->view_proj, cam->width, cam->height,
                                     tc.gx, tc.gy, eps, pool, &pg)))
        return st;
    tc.mode = plan->patch_mode;
    tc.active = plan->active;
    tc.count = plan->active_count;
    /* (no patch to plan, as when every face is drawn as splats: no job for the workers) */
    if (tc.count) crisp_pool_parallel_for(pool, TREE_CHUNKS, 1, build_chunks, &tc);
    for (int w = 0; w < workers; w++)
        if (plan->worker_status[w]) return plan->worker_status[w];
    double t1 = crisp_time_now();

    edge_ctx ec = {plan, sc};
    crisp_pool_parallel_for(pool, plan->active_count, 16, edge_levels, &ec);
    uint32_t level_splits = 0;
    if ((st = split_high_levels(plan, sc, &tc, pool, &level_splits))) return st;
    double t2 = crisp_time_now();

    /* Faces with a visible leaf get a trim plan. */
    memset(plan->face_tau, 0, sc->face_count * sizeof *plan->face_tau);
    memset(plan->face_rows, 0, sc->face_count * sizeof *plan->face_rows);
    crisp_plan_stats *s = &plan->stats;
    *s = (crisp_plan_stats){.patches = sc->patch_count, .level_splits = level_splits};
    plan->visible_count = 0;
    for (size_t i = 0; i < plan->active_count; i++) {
        uint32_t p = plan->active[i];
        const crisp__patch_tree *pp = &plan->patches[p];
        s->leaves += pp->leaf_count;
        s->unresolved += pp->unresolved;
        if (!pp->visible_leaves) continue;
        s->visible_patches++;
        s->split_patches += pp->leaf_count > 1;
        uint32_t f = sc->patches[p].face;
        if (pp->leaf_count == 1 && pp->leaves[0].group) {
            s->group_leaves++;
            s->grouped_patches += pp->leaves[0].ix * pp->leaves[0].iy;
        }
        for (uint32_t l = 0; l < pp->leaf_count; l++) {
            const crisp__cell *L = &pp->leaves[l];
            if (L->culled) continue;
            if (L->tau > plan->face_tau[f]) {
                if (!plan->face_tau[f]) {
                    /* (active patches ascend, face after face: so do the faces listed) */
                    if ((st = crisp_grow((void **)&plan->visible, &plan->visible_cap,
                                         plan->visible_count + 1, sizeof *plan->visible)))
                        return st;
                    plan->visible[plan->visible_count++] = f;
                }
                plan->face_tau[f] = L->tau;
            }
            float rows = L->group ? (float)L->tau / (float)L->iy : (float)L->tau;
            if (rows > plan->face_rows[f]) plan->face_rows[f] = rows;
        }
    }
    if ((st = make_lods(plan, sc, plan->visible, plan->visible_count, pool))) return st;
    size_t *scratch_used = plan->trim_used;
    for (int w = 0; w < workers; w++) {
        plan->worker_status[w] = CRISP_OK;
        scratch_used[w] = 0;
        if ((st = crisp_arena_reserve(plan->arenas[w], plan->trim_scratch))) return st;
    }
    trim_ctx trc = {
        plan, sc, plan->visible, desc ? desc->strip_count : 0, plan->worker_status, scratch_used};
    crisp_pool_parallel_for(pool, plan->visible_count, 1, plan_trims, &trc);
    for (int w = 0; w < workers; w++) {
        if (plan->worker_status[w]) return plan->worker_status[w];
        if (scratch_used[w] > plan->trim_scratch) plan->trim_scratch = scratch_used[w];
    }
    for (size_t i = 0; i < plan->visible_count; i++) {
        uint32_t f = plan->visible[i];
        s->visible_faces++;
        s->table_rows += plan->trims[f].table.row_count;
        s->table_bytes += crisp_trim_table_bytes(&plan->trims[f].table);
        s->rows_clamped += plan->trims[f].clamped;
    }
    double t3 = crisp_time_now();
    s->ms_levels = 1e3 * (t1 - t0);
    s->ms_edges = 1e3 * (t2 - t1);
    s->ms_trim = 1e3 * (t3 - t2);
    return CRISP_OK;
}

void crisp__trees_keep_subpatches(crisp__trees *plan, int on)
{
    plan->keep_off = !on;
}

crisp_status crisp__trees_replan_trim(crisp__trees *plan, const crisp_scene *sc, uint32_t f,
                                      int strip_count)
{
    if (f >= sc->face_count || f >= plan->face_cap)
        return crisp_error(CRISP_ERR_INVALID_ARG, "face %u: the scene has %u faces", f,
                           sc->face_count);
    if (!plan->face_tau[f]) return CRISP_OK; /* not visible: nothing to plan */
    crisp_status status = make_lods(plan, sc, &f, 1, NULL);
    if (status) return status;
    size_t used = 0;
    trim_ctx trc = {plan, sc, &f, strip_count, &status, &used};
    plan_trims(&trc, 0, 1, 0);
    return status;
}
