/* Patch groups (issue 12): per face, a quadtree of aligned 2^g x 2^g blocks over its grid of
 * Bézier patches, each block with an object-space box that contains its patches (the union of
 * the scene's patch boxes). Per frame the planner walks it from the top and stops where a whole
 * block is outside the frustum (every patch culled) or can be drawn as one group leaf (every
 * triangle with vertices on its surface within eps on screen: its projected box within eps, or
 * a bound from its patches' control points against the block's corners, see group_leaf_ok). Only
 * the patches of the blocks left open get their own quadtree, SLEFE levels and frustum tests, so a
 * plan's cost follows what is on screen.
 * The hierarchy is built once per scene (view-independent) and kept by the planner. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "quadtree.h"
#include "rational_bound.h"

typedef struct group {
    uint32_t iu0, iv0, nu, nv; /* patch grid block: columns iu0.., rows iv0.. (clipped) */
    uint32_t g;                /* the block is 2^g x 2^g patches before clipping */
    int32_t child[4];          /* -1: none (outside the grid, or a single patch) */
    double box[6];
    double dev[4];   /* per homogeneous object coordinate: the largest distance between a control
                        point of the block and the bilinear through the block's corners there */
    double devq[3];  /* rational blocks: crisp__rational_block_deviation (x, y, z) */
    double wlo, whi; /* the least and largest weight of the block's patches */
    int rational;    /* the weights vary over the block (whi > wlo) */
} group;

struct crisp__groups {
    const crisp_scene *scene;
    uint64_t key; /* the serial of the scene the hierarchy was built from */
    uint32_t patch_count, face_count;
    group *nodes;
    size_t node_count, node_cap;
    uint32_t *face_root; /* per face: its top group, UINT32_MAX when the face has no patches */
    uint8_t *face_small; /* per face, this frame: the whole (untrimmed) face within FACE_SMALL_PX */
    uint32_t group_leaves; /* this frame */
    uint32_t *counts;      /* per face: group leaves this frame */
    float *face_px;        /* per face, this frame: screen extent of its box (INFINITY: unknown) */
    uint64_t generation;   /* bumped whenever the hierarchy is rebuilt (a new scene) */
    /* This frame's decisions per block (node): what owns its patches. Only the blocks the walk
     * reached are written; node_frame says which are current. */
    uint8_t *node_kind;     /* NODE_* */
    uint32_t *node_frame;   /* the classify call that wrote node_kind */
    uint32_t frame;         /* classify calls so far */
    uint32_t **face_active; /* per face: this frame's active patches (see crisp__groups_classify) */
    uint32_t *face_active_count;
    size_t *face_active_cap;
    int oom; /* a walk ran out of memory */
};

/* A face whose box spans at most this many pixels in x and in y on screen: any two of its points,
 * in particular a pixel's point and any point of its trim curves, are at most sqrt(2) times that
 * (< 1 px) apart, so every trim decision on it is within the 1 px guarantee of
 * include/crisp/trim.h (crisp__groups_face_small). */
#define FACE_SMALL_PX 0.7

enum { NODE_OPEN = 0, NODE_CULLED = 1, NODE_GROUP = 2, NODE_OWN = 3 }; /* OWN: patches own trees */

/* n->dev (see group): view-independent, so a frame bounds the block's deviation in clip space
 * from its corners alone (|M d| <= |M| |d| per coordinate). */
static void block_deviation(const crisp_scene *sc, const crisp_scene_face *f, group *n)
{
    uint32_t base = f->first_patch + n->iv0 * f->grid_u + n->iu0;
    const crisp_bezier_patch *p00 = &sc->patches[base].bez,
                             *p10 = &sc->patches[base + n->nu - 1].bez,
                             *p01 = &sc->patches[base + (n->nv - 1) * f->grid_u].bez,
                             *p11 = &sc->patches[base + (n->nv - 1) * f->grid_u + n->nu - 1].bez;
    const double *C[4] = {p00->cpw, p10->cpw + 4 * p10->du, p01->cpw + 4 * (p01->du + 1) * p01->dv,
                          p11->cpw + 4 * ((p11->du + 1) * p11->dv + p11->du)};
    for (int a = 0; a < 4; a++)
        n->dev[a] = 0;
    for (uint32_t jv = 0; jv < n->nv; jv++)
        for (uint32_t iu = 0; iu < n->nu; iu++) {
            const crisp_bezier_patch *b = &sc->patches[base + jv * f->grid_u + iu].bez;
            for (int j = 0; j <= b->dv; j++) {
                double t = (jv + (double)j / b->dv) / n->nv;
                for (int i = 0; i <= b->du; i++) {
                    double u = (iu + (double)i / b->du) / n->nu;
                    const double *q = b->cpw + 4 * (j * (b->du + 1) + i);
                    for (int a = 0; a < 4; a++) {
                        double bl = (1 - t) * ((1 - u) * C[0][a] + u * C[1][a]) +
                                    t * ((1 - u) * C[2][a] + u * C[3][a]);
                        n->dev[a] =
                            fmax(n->dev[a], fabs(q[a] - bl) + 1e-12 * (fabs(q[a]) + fabs(bl)));
                    }
                }
            }
        }
}

/* The aligned block (g, bu, bv) of face f's grid: patches [bu 2^g, (bu + 1) 2^g) x
 * [bv 2^g, (bv + 1) 2^g) clipped to the grid. Blocks of one face nest like a quadtree, so two
 * blocks' sides either contain one another or meet in at most a point (the crack-free edge rule
 * relies on it). */
static crisp_status build_group(crisp__groups *g, const crisp_scene *sc, const crisp_scene_face *f,
                                uint32_t lv, uint32_t bu, uint32_t bv, int32_t *dest)
{
    crisp_status st =
        crisp_grow((void **)&g->nodes, &g->node_cap, g->node_count + 1, sizeof *g->nodes);
    if (st) return st;
    int32_t me = (int32_t)g->node_count++;
    uint32_t iu0 = bu << lv, iv0 = bv << lv, size = 1u << lv;
    group n = {iu0,
               iv0,
               f->grid_u - iu0 < size ? f->grid_u - iu0 : size,
               f->grid_v - iv0 < size ? f->grid_v - iv0 : size,
               lv,
               {-1, -1, -1, -1},
               {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY},
               {0, 0, 0, 0},
               {0, 0, 0},
               INFINITY,
               -INFINITY,
               0};
    if (lv == 0) {
        const double *b = sc->patches[f->first_patch + iv0 * f->grid_u + iu0].box;
        memcpy(n.box, b, sizeof n.box);
    } else {
        for (int k = 0; k < 4; k++) {
            uint32_t cu = 2 * bu + (k & 1), cv = 2 * bv + (k >> 1);
            if ((cu << (lv - 1)) >= f->grid_u || (cv << (lv - 1)) >= f->grid_v) continue;
            int32_t c;
            if ((st = build_group(g, sc, f, lv - 1, cu, cv, &c))) return st;
            n.child[k] = c;
            for (int a = 0; a < 3; a++) {
                n.box[a] = fmin(n.box[a], g->nodes[c].box[a]);
                n.box[3 + a] = fmax(n.box[3 + a], g->nodes[c].box[3 + a]);
            }
        }
    }
    if (lv == 0)
        crisp__rational_weight_range(&sc->patches[f->first_patch + iv0 * f->grid_u + iu0].bez,
                                     &n.wlo, &n.whi);
    else
        for (int k = 0; k < 4; k++)
            if (n.child[k] >= 0) {
                n.wlo = fmin(n.wlo, g->nodes[n.child[k]].wlo);
                n.whi = fmax(n.whi, g->nodes[n.child[k]].whi);
            }
    n.rational = n.whi > n.wlo;
    if (n.nu * n.nv > 1) block_deviation(sc, f, &n);
    if (n.nu * n.nv > 1 && n.rational)
        crisp__rational_block_deviation(&sc->patches[f->first_patch + iv0 * f->grid_u + iu0],
                                        f->grid_u, n.nu, n.nv, n.devq);
    g->nodes[me] = n;
    *dest = me;
    return CRISP_OK;
}

crisp_status crisp__groups_create(crisp__groups **dest)
{
    crisp__groups *g = calloc(1, sizeof *g);
    if (!g) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating patch groups");
    *dest = g;
    return CRISP_OK;
}

static void free_frame_state(crisp__groups *g)
{
    if (g->face_active)
        for (uint32_t f = 0; f < g->face_count; f++)
            free(g->face_active[f]);
    free(g->face_active);
    free(g->face_active_count);
    free(g->face_active_cap);
    free(g->node_kind);
    free(g->node_frame);
    g->face_active = NULL;
    g->face_active_count = NULL;
    g->face_active_cap = NULL;
    g->node_kind = NULL;
    g->node_frame = NULL;
}

void crisp__groups_destroy(crisp__groups *g)
{
    if (!g) return;
    free_frame_state(g);
    free(g->nodes);
    free(g->face_root);
    free(g->face_small);
    free(g->counts);
    free(g->face_px);
    free(g);
}

static crisp_status ensure_built(crisp__groups *g, const crisp_scene *sc)
{
    /* A scene destroyed and another prepared at the same address must not reuse the hierarchy:
     * scenes have serial numbers. */
    if (g->scene == sc && g->key == sc->serial && g->patch_count == sc->patch_count &&
        g->face_count == sc->face_count)
        return CRISP_OK;
    g->key = sc->serial;
    free_frame_state(g);
    g->scene = NULL;
    g->face_count = 0;
    g->node_count = 0;
    free(g->face_root);
    free(g->face_small);
    free(g->counts);
    free(g->face_px);
    g->face_px = malloc((sc->face_count ? sc->face_count : 1) * sizeof *g->face_px);
    g->face_root = malloc((sc->face_count ? sc->face_count : 1) * sizeof *g->face_root);
    g->face_small = calloc(sc->face_count ? sc->face_count : 1, 1);
    g->counts = calloc(sc->face_count ? sc->face_count : 1, sizeof *g->counts);
    if (!g->face_root || !g->face_small || !g->counts || !g->face_px)
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
    for (uint32_t f = 0; f < sc->face_count; f++) {
        const crisp_scene_face *sf = &sc->faces[f];
        g->face_root[f] = UINT32_MAX;
        if (!sf->patch_count || sf->grid_u * sf->grid_v != sf->patch_count) continue;
        uint32_t lv = 0;
        while ((1u << lv) < sf->grid_u || (1u << lv) < sf->grid_v)
            lv++;
        int32_t root;
        crisp_status st = build_group(g, sc, sf, lv, 0, 0, &root);
        if (st) return st;
        g->face_root[f] = (uint32_t)root;
    }
    size_t nf = sc->face_count ? sc->face_count : 1, nn = g->node_count ? g->node_count : 1;
    g->face_active = calloc(nf, sizeof *g->face_active);
    g->face_active_count = calloc(nf, sizeof *g->face_active_count);
    g->face_active_cap = calloc(nf, sizeof *g->face_active_cap);
    g->node_kind = calloc(nn, sizeof *g->node_kind);
    g->node_frame = calloc(nn, sizeof *g->node_frame);
    g->face_count = sc->face_count;
    if (!g->face_active || !g->face_active_count || !g->face_active_cap || !g->node_kind ||
        !g->node_frame)
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
    g->scene = sc;
    g->generation++;
    g->patch_count = sc->patch_count;
    return CRISP_OK;
}

/* 1: the box is outside one (widened) frustum plane; 2: in front of the eye and within eps
 * pixels on screen; 0: neither (*extent: its screen extent in pixels, INFINITY when it reaches
 * the eye plane). */
static int classify(const double *box, crisp_mat4 m, double gx, double gy, int width, int height,
                    double eps, double *extent)
{
    *extent = INFINITY;
    int out[6] = {1, 1, 1, 1, 1, 1}, front = 1;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int k = 0; k < 8; k++) {
        double p[3] = {box[(k & 1) ? 3 : 0], box[(k & 2) ? 4 : 1], box[(k & 4) ? 5 : 2]};
        double x = m[0][0] * p[0] + m[1][0] * p[1] + m[2][0] * p[2] + m[3][0];
        double y = m[0][1] * p[0] + m[1][1] * p[1] + m[2][1] * p[2] + m[3][1];
        double z = m[0][2] * p[0] + m[1][2] * p[1] + m[2][2] * p[2] + m[3][2];
        double w = m[0][3] * p[0] + m[1][3] * p[1] + m[2][3] * p[2] + m[3][3];
        out[0] &= x > gx * w;
        out[1] &= x < -gx * w;
        out[2] &= y > gy * w;
        out[3] &= y < -gy * w;
        out[4] &= z < -w;
        out[5] &= z > w;
        if (!(w > 0)) {
            front = 0;
            continue;
        }
        lo[0] = fmin(lo[0], x / w), hi[0] = fmax(hi[0], x / w);
        lo[1] = fmin(lo[1], y / w), hi[1] = fmax(hi[1], y / w);
    }
    if (out[0] | out[1] | out[2] | out[3] | out[4] | out[5]) return 1;
    if (!front) return 0;
    double e = fmax((hi[0] - lo[0]) * 0.5 * width, (hi[1] - lo[1]) * 0.5 * height);
    *extent = e * (1 + 1e-9) + 1e-9;
    return *extent <= eps ? 2 : 0;
}

typedef struct walk_ctx {
    crisp__groups *g;
    const crisp_scene *sc;
    crisp_mat4 m;
    double gx, gy, eps;
    int width, height;
    crisp__patch_groups *out;
    uint32_t *counts; /* group leaves per face */
} walk_ctx;

/* Patches of face fi that get a tree of their own this frame, with their mode. */
static void activate(walk_ctx *c, uint32_t fi, uint32_t p, uint8_t mode)
{
    crisp__groups *g = c->g;
    uint32_t n = g->face_active_count[fi];
    if (crisp_grow((void **)&g->face_active[fi], &g->face_active_cap[fi], (size_t)n + 1,
                   sizeof **g->face_active)) {
        g->oom = 1;
        return;
    }
    g->face_active[fi][n] = p;
    g->face_active_count[fi] = n + 1;
    c->out->mode[p] = mode;
}

static void activate_block(walk_ctx *c, uint32_t fi, const crisp_scene_face *f, const group *n,
                           uint8_t mode)
{
    for (uint32_t iv = n->iv0; iv < n->iv0 + n->nv; iv++)
        for (uint32_t iu = n->iu0; iu < n->iu0 + n->nu; iu++)
            activate(c, fi, f->first_patch + iv * f->grid_u + iu, mode);
}

/* 1 when the block can be one group leaf: every triangle with vertices on its surface lies
 * within eps on screen, whatever its levels. Either its box is within eps, or this bound is: let
 * B be the bilinear function through the block's four corners in homogeneous clip coordinates
 * (the corner control points of its corner patches: Bézier patches interpolate their corners),
 * and D the largest distance, per coordinate, between a control point of a patch of the block
 * and B at that control point's parameters (the patch's sub-rectangle of the block, uniformly
 * spaced: B restricted to it and raised to the patch's degrees has exactly those values as
 * control points). By the convex hull property |S(x) - B(x)| <= D for every parameter x of the
 * block. A triangle of the leaf has vertices S(p_k) and points T(x) = sum l_k S(p_k) at
 * x = sum l_k p_k (homogeneously; the drawn triangle is the same set for any positive scaling of
 * its vertices), so |T(x) - B(x)| <= |sum l_k (S(p_k) - B(p_k))| + |sum l_k B(p_k) - B(x)| <=
 * D + twist(B) / 4 (a bilinear function departs from its linear interpolant on a triangle of
 * its square by at most a quarter of its twist). Both are measured against B(x), whose W is at
 * least the corners' least W, so on screen |S(x) - T(x)| <= px(D) + px(D + twist / 4)
 * (screen_px). This needs no B-spline form of the face, only its grid of Bézier patches. The
 * B-spline net bound (crisp_slefe_group_screen's quad_px) was tried first: on wavy bicubic
 * sheets it exceeded the block's own screen extent (tests/render/test_group_leaves.c). The leaf
 * must also stay within CRISP_PLAN_MAX_LEAF_PX (float local parameters on a GPU). D is bounded
 * first from the block's view-independent deviation (group.dev, mapped by |view_proj|): O(1) per
 * block, so a face far away is decided at its root without reading its patches; where that is not
 * enough, blocks of at most 64 patches and GROUP_TRY_PX pixels read their control points (cost
 * only: larger blocks rarely pass). */
#define GROUP_TRY_PX 64.0
static int group_leaf_ok(const walk_ctx *c, const crisp_scene_face *f, const group *n,
                         double extent)
{
    if (extent <= c->eps) return 1;
    if (!isfinite(extent) || extent > CRISP_PLAN_MAX_LEAF_PX) return 0;
    const crisp_scene *sc = c->sc;
    uint32_t base = f->first_patch + n->iv0 * f->grid_u + n->iu0;
    const crisp_bezier_patch *p00 = &sc->patches[base].bez,
                             *p10 = &sc->patches[base + n->nu - 1].bez,
                             *p01 = &sc->patches[base + (n->nv - 1) * f->grid_u].bez,
                             *p11 = &sc->patches[base + (n->nv - 1) * f->grid_u + n->nu - 1].bez;
    const double *cw[4] = {p00->cpw, p10->cpw + 4 * p10->du, p01->cpw + 4 * (p01->du + 1) * p01->dv,
                           p11->cpw + 4 * ((p11->du + 1) * p11->dv + p11->du)};
    double C[4][3], wmin = INFINITY, xmax = 0, ymax = 0;
    for (int k = 0; k < 4; k++) {
        const double *q = cw[k];
        for (int a = 0; a < 3; a++) {
            int r = a == 2 ? 3 : a; /* x, y, w rows of view_proj */
            C[k][a] = c->m[0][r] * q[0] + c->m[1][r] * q[1] + c->m[2][r] * q[2] + c->m[3][r] * q[3];
        }
        if (!(C[k][2] > 0)) return 0;
        wmin = fmin(wmin, C[k][2]);
        xmax = fmax(xmax, fabs(C[k][0] / C[k][2]));
        ymax = fmax(ymax, fabs(C[k][1] / C[k][2]));
    }
    /* First from the block's view-independent deviation (O(1)); the control points themselves
     * only for blocks of at most 64 patches where that was not enough. */
    double D[3];
    for (int a = 0; a < 3; a++) {
        int r = a == 2 ? 3 : a;
        D[a] = (fabs(c->m[0][r]) * n->dev[0] + fabs(c->m[1][r]) * n->dev[1] +
                fabs(c->m[2][r]) * n->dev[2] + fabs(c->m[3][r]) * n->dev[3]) *
               (1 + 1e-12);
    }
    double E0[3];
    for (int a = 0; a < 3; a++)
        E0[a] = D[a] + 0.25 * fabs(C[0][a] - C[1][a] - C[2][a] + C[3][a]);
    if (!n->rational && crisp__clip_screen_px(D, wmin, xmax, ymax, c->width, c->height) +
                                crisp__clip_screen_px(E0, wmin, xmax, ymax, c->width, c->height) <=
                            c->eps)
        return 1;
    /* Blocks whose weights vary: the same bound without dividing by the weights, measured at the
     * parameters the rasterizer interpolates (rational_bound.c; the homogeneous one bounds
     * another point of the same triangle there). */
    double(*m)[4] = (double(*)[4])c->m, fast = INFINITY;
    if (n->rational &&
        (fast = crisp__rational_block_px_fast(&sc->patches[base], f->grid_u, n->nu, n->nv, n->devq,
                                              m, c->width, c->height)) <= c->eps)
        return 1;
    if (n->nu * n->nv > 64 || extent > GROUP_TRY_PX) return 0;
    /* the per-control-point bound is rarely below a quarter of the O(1) one */
    if (n->rational && fast <= 4 * c->eps &&
        crisp__rational_block_px(&sc->patches[base], f->grid_u, n->nu, n->nv, m, c->width,
                                 c->height, c->eps) <= c->eps)
        return 1;
    if (n->rational) return 0;
    D[0] = D[1] = D[2] = 0;
    for (uint32_t jv = 0; jv < n->nv; jv++)
        for (uint32_t iu = 0; iu < n->nu; iu++) {
            const crisp_bezier_patch *b = &sc->patches[base + jv * f->grid_u + iu].bez;
            for (int j = 0; j <= b->dv; j++) {
                double t = (jv + (double)j / b->dv) / n->nv;
                for (int i = 0; i <= b->du; i++) {
                    double s = (iu + (double)i / b->du) / n->nu;
                    const double *q = b->cpw + 4 * (j * (b->du + 1) + i);
                    for (int a = 0; a < 3; a++) {
                        int r = a == 2 ? 3 : a;
                        double x = c->m[0][r] * q[0] + c->m[1][r] * q[1] + c->m[2][r] * q[2] +
                                   c->m[3][r] * q[3];
                        double bl = (1 - t) * ((1 - s) * C[0][a] + s * C[1][a]) +
                                    t * ((1 - s) * C[2][a] + s * C[3][a]);
                        /* A relative allowance for the rounding of both sides. */
                        D[a] = fmax(D[a], fabs(x - bl) + 1e-12 * (fabs(x) + fabs(bl)));
                    }
                }
            }
            if (2 * crisp__clip_screen_px(D, wmin, xmax, ymax, c->width, c->height) > c->eps)
                return 0;
        }
    double E[3];
    for (int a = 0; a < 3; a++)
        E[a] = D[a] + 0.25 * fabs(C[0][a] - C[1][a] - C[2][a] + C[3][a]);
    return crisp__clip_screen_px(D, wmin, xmax, ymax, c->width, c->height) +
               crisp__clip_screen_px(E, wmin, xmax, ymax, c->width, c->height) <=
           c->eps;
}

static void walk_faces(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    walk_ctx *c = vctx;
    crisp__groups *g = c->g;
    for (size_t fi = begin; fi < end; fi++) {
        const crisp_scene_face *f = &c->sc->faces[fi];
        uint32_t root = g->face_root[fi];
        g->face_small[fi] = 0;
        g->face_px[fi] = INFINITY;
        g->face_active_count[fi] = 0;
        c->counts[fi] = 0;
        if (root == UINT32_MAX) {
            for (uint32_t p = 0; p < f->patch_count; p++)
                activate(c, (uint32_t)fi, f->first_patch + p, CRISP__PATCH_OPEN);
            continue;
        }
        int32_t stack[4 * 64];
        int top = 0;
        stack[top++] = (int32_t)root;
        while (top > 0) {
            int32_t at = stack[--top];
            const group *n = &g->nodes[at];
            double extent;
            int k = classify(n->box, c->m, c->gx, c->gy, c->width, c->height, c->eps, &extent);
            if ((uint32_t)at == root && k != 1 && extent <= FACE_SMALL_PX) g->face_small[fi] = 1;
            if ((uint32_t)at == root) g->face_px[fi] = (float)extent;
            g->node_frame[at] = g->frame;
            g->node_kind[at] = NODE_OWN;
            if (k == 1) {
                g->node_kind[at] = NODE_CULLED; /* its patches: no tree (crisp__groups_owner) */
            } else if (n->nu * n->nv == 1) {
                activate(c, (uint32_t)fi, f->first_patch + n->iv0 * f->grid_u + n->iu0,
                         k == 2 ? CRISP__PATCH_SMALL : CRISP__PATCH_OPEN);
            } else if (c->out->group_g && group_leaf_ok(c, f, n, extent)) {
                uint32_t origin = f->first_patch + n->iv0 * f->grid_u + n->iu0;
                g->node_kind[at] = NODE_GROUP;
                activate(c, (uint32_t)fi, origin, CRISP__PATCH_GROUP);
                c->out->group_g[origin] = (uint8_t)n->g;
                c->counts[fi]++;
            } else if (k == 2) {
                activate_block(c, (uint32_t)fi, f, n, CRISP__PATCH_SMALL);
            } else {
                g->node_kind[at] = NODE_OPEN;
                for (int q = 3; q >= 0; q--)
                    if (n->child[q] >= 0) stack[top++] = n->child[q];
            }
        }
    }
}

static int u32_cmp(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

crisp_status crisp__groups_classify(crisp__groups *g, const crisp_scene *sc, crisp_mat4 view_proj,
                                    int width, int height, double gx, double gy, double eps,
                                    crisp_pool *pool, crisp__patch_groups *out)
{
    crisp_status st = ensure_built(g, sc);
    if (st) return st;
    uint32_t *counts = g->counts;
    g->frame++;
    g->oom = 0;
    walk_ctx c = {.g = g,
                  .sc = sc,
                  .gx = gx,
                  .gy = gy,
                  .eps = eps,
                  .width = width,
                  .height = height,
                  .out = out,
                  .counts = counts};
    crisp_mat4_copy(view_proj, c.m);
    crisp_pool_parallel_for(pool, sc->face_count, 4, walk_faces, &c);
    if (g->oom) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
    g->group_leaves = 0;
    size_t total = 0;
    for (uint32_t f = 0; f < sc->face_count; f++) {
        g->group_leaves += counts[f];
        total += g->face_active_count[f];
    }
    if ((st = crisp_grow((void **)out->active, out->active_cap, total ? total : 1,
                         sizeof **out->active)))
        return st;
    size_t at = 0;
    for (uint32_t f = 0; f < sc->face_count; f++) {
        uint32_t n = g->face_active_count[f];
        if (!n) continue;
        memcpy(*out->active + at, g->face_active[f], n * sizeof **out->active);
        qsort(*out->active + at, n, sizeof **out->active, u32_cmp);
        at += n;
    }
    *out->active_count = at;
    return CRISP_OK;
}

uint32_t crisp__groups_owner(const crisp__groups *g, const crisp_scene *sc, uint32_t q)
{
    const crisp_scene_patch *sp = &sc->patches[q];
    const crisp_scene_face *f = &sc->faces[sp->face];
    uint32_t at = g->face_root[sp->face];
    while (at != UINT32_MAX && g->node_frame[at] == g->frame) {
        const group *n = &g->nodes[at];
        switch (g->node_kind[at]) {
        case NODE_GROUP:
            return f->first_patch + n->iv0 * f->grid_u + n->iu0;
        case NODE_OPEN: {
            uint32_t h = n->g - 1;
            int k = (int)((sp->iu >> h) & 1) | (int)(((sp->iv >> h) & 1) << 1);
            at = n->child[k] >= 0 ? (uint32_t)n->child[k] : UINT32_MAX;
            break;
        }
        default:
            return q;
        }
    }
    return q;
}

double crisp__groups_face_px(const crisp__groups *g, uint32_t face)
{
    return g && g->face_px && face < g->face_count ? g->face_px[face] : INFINITY;
}

int crisp__groups_face_small(const crisp__groups *g, uint32_t face)
{
    return g && g->face_small && face < g->face_count && g->face_small[face];
}

uint64_t crisp__groups_generation(const crisp__groups *g)
{
    return g ? g->generation : 0;
}
