/* Patch groups (issue 12): per face, a binary hierarchy over its grid of Bézier patches, each
 * group with an object-space box that contains its patches (the union of the scene's patch
 * boxes). Per frame the planner walks it from the top and stops where a whole group is outside
 * the frustum (every patch culled) or small on screen (its projected box within eps pixels: each
 * of its patches is drawn within eps by a single tau-1 leaf, since the patch and any triangles
 * with vertices on it lie inside the box). Only the patches of the groups left open get their
 * own quadtree, SLEFE levels and frustum tests, so a plan's cost follows what is on screen.
 * The hierarchy is built once per scene (view-independent) and kept by the planner. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "quadtree.h"

typedef struct group {
    uint32_t iu0, iu1, iv0, iv1; /* patch grid range, inclusive */
    int32_t child[2];            /* -1 for a single patch */
    double box[6];
} group;

struct crisp__groups {
    const crisp_scene *scene;
    uint64_t key; /* checksum of the patch boxes and face grids the hierarchy was built from */
    uint32_t patch_count, face_count;
    group *nodes;
    size_t node_count, node_cap;
    uint32_t *face_root; /* per face: its top group, UINT32_MAX when the face has no patches */
    uint8_t *face_small; /* per face, this frame: the whole (untrimmed) face within eps on screen */
};

static crisp_status build_group(crisp__groups *g, const crisp_scene *sc, const crisp_scene_face *f,
                                uint32_t iu0, uint32_t iu1, uint32_t iv0, uint32_t iv1,
                                int32_t *dest)
{
    crisp_status st =
        crisp_grow((void **)&g->nodes, &g->node_cap, g->node_count + 1, sizeof *g->nodes);
    if (st) return st;
    int32_t me = (int32_t)g->node_count++;
    group n = {iu0, iu1,      iv0,
               iv1, {-1, -1}, {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY}};
    if (iu0 == iu1 && iv0 == iv1) {
        const double *b = sc->patches[f->first_patch + iv0 * f->grid_u + iu0].box;
        memcpy(n.box, b, sizeof n.box);
    } else {
        /* Halve the longer side. */
        int32_t c0, c1;
        if (iu1 - iu0 >= iv1 - iv0) {
            uint32_t mid = iu0 + (iu1 - iu0) / 2;
            if ((st = build_group(g, sc, f, iu0, mid, iv0, iv1, &c0)) ||
                (st = build_group(g, sc, f, mid + 1, iu1, iv0, iv1, &c1)))
                return st;
        } else {
            uint32_t mid = iv0 + (iv1 - iv0) / 2;
            if ((st = build_group(g, sc, f, iu0, iu1, iv0, mid, &c0)) ||
                (st = build_group(g, sc, f, iu0, iu1, mid + 1, iv1, &c1)))
                return st;
        }
        n.child[0] = c0, n.child[1] = c1;
        for (int k = 0; k < 3; k++) {
            n.box[k] = fmin(g->nodes[c0].box[k], g->nodes[c1].box[k]);
            n.box[3 + k] = fmax(g->nodes[c0].box[3 + k], g->nodes[c1].box[3 + k]);
        }
    }
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

void crisp__groups_destroy(crisp__groups *g)
{
    if (!g) return;
    free(g->nodes);
    free(g->face_root);
    free(g->face_small);
    free(g);
}

/* A scene destroyed and another prepared at the same address must not reuse the hierarchy: the
 * key covers every patch box and face grid (about a microsecond per 100 patches). */
static uint64_t scene_key(const crisp_scene *sc)
{
    uint64_t h = 1469598103934665603ull ^ sc->patch_count ^ ((uint64_t)sc->face_count << 32);
    for (uint32_t p = 0; p < sc->patch_count; p++)
        for (int k = 0; k < 6; k++) {
            uint64_t w;
            memcpy(&w, &sc->patches[p].box[k], 8);
            h = (h ^ w) * 1099511628211ull;
        }
    for (uint32_t f = 0; f < sc->face_count; f++)
        h = (h ^ ((uint64_t)sc->faces[f].grid_u << 32 ^ sc->faces[f].grid_v ^
                  (uint64_t)sc->faces[f].first_patch << 16)) *
            1099511628211ull;
    return h;
}

static crisp_status ensure_built(crisp__groups *g, const crisp_scene *sc)
{
    uint64_t key = scene_key(sc);
    if (g->scene == sc && g->key == key && g->patch_count == sc->patch_count &&
        g->face_count == sc->face_count)
        return CRISP_OK;
    g->key = key;
    g->scene = NULL;
    g->node_count = 0;
    free(g->face_root);
    free(g->face_small);
    g->face_root = malloc((sc->face_count ? sc->face_count : 1) * sizeof *g->face_root);
    g->face_small = calloc(sc->face_count ? sc->face_count : 1, 1);
    if (!g->face_root || !g->face_small)
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
    for (uint32_t f = 0; f < sc->face_count; f++) {
        const crisp_scene_face *sf = &sc->faces[f];
        g->face_root[f] = UINT32_MAX;
        if (!sf->patch_count || sf->grid_u * sf->grid_v != sf->patch_count) continue;
        int32_t root;
        crisp_status st = build_group(g, sc, sf, 0, sf->grid_u - 1, 0, sf->grid_v - 1, &root);
        if (st) return st;
        g->face_root[f] = (uint32_t)root;
    }
    g->scene = sc;
    g->patch_count = sc->patch_count;
    g->face_count = sc->face_count;
    return CRISP_OK;
}

/* 1: the box is outside one (widened) frustum plane; 2: in front of the eye and within eps
 * pixels on screen; 0: neither. */
static int classify(const double *box, crisp_mat4 m, double gx, double gy, int width, int height,
                    double eps)
{
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
    return e * (1 + 1e-9) + 1e-9 <= eps ? 2 : 0;
}

typedef struct walk_ctx {
    crisp__groups *g;
    const crisp_scene *sc;
    crisp_mat4 m;
    double gx, gy, eps;
    int width, height;
    uint8_t *mode;
} walk_ctx;

static void set_mode(const crisp_scene_face *f, const group *n, uint8_t mode, uint8_t *dest)
{
    for (uint32_t iv = n->iv0; iv <= n->iv1; iv++)
        for (uint32_t iu = n->iu0; iu <= n->iu1; iu++)
            dest[f->first_patch + iv * f->grid_u + iu] = mode;
}

static void walk_faces(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    walk_ctx *c = vctx;
    for (size_t fi = begin; fi < end; fi++) {
        const crisp_scene_face *f = &c->sc->faces[fi];
        uint32_t root = c->g->face_root[fi];
        c->g->face_small[fi] = 0;
        if (root == UINT32_MAX) {
            for (uint32_t p = 0; p < f->patch_count; p++)
                c->mode[f->first_patch + p] = CRISP__PATCH_OPEN;
            continue;
        }
        int32_t stack[64];
        int top = 0;
        stack[top++] = (int32_t)root;
        while (top > 0) {
            int32_t at = stack[--top];
            const group *n = &c->g->nodes[at];
            int k = classify(n->box, c->m, c->gx, c->gy, c->width, c->height, c->eps);
            if ((uint32_t)at == root && k == 2) c->g->face_small[fi] = 1;
            if (k == 1)
                set_mode(f, n, CRISP__PATCH_CULLED, c->mode);
            else if (k == 2)
                set_mode(f, n, CRISP__PATCH_SMALL, c->mode);
            else if (n->child[0] < 0 || top + 2 > 64)
                set_mode(f, n, CRISP__PATCH_OPEN, c->mode);
            else
                stack[top++] = n->child[1], stack[top++] = n->child[0];
        }
    }
}

crisp_status crisp__groups_classify(crisp__groups *g, const crisp_scene *sc, crisp_mat4 view_proj,
                                    int width, int height, double gx, double gy, double eps,
                                    crisp_pool *pool, uint8_t *mode)
{
    crisp_status st = ensure_built(g, sc);
    if (st) return st;
    walk_ctx c = {.g = g,
                  .sc = sc,
                  .gx = gx,
                  .gy = gy,
                  .eps = eps,
                  .width = width,
                  .height = height,
                  .mode = mode};
    crisp_mat4_copy(view_proj, c.m);
    crisp_pool_parallel_for(pool, sc->face_count, 4, walk_faces, &c);
    return CRISP_OK;
}

int crisp__groups_face_small(const crisp__groups *g, uint32_t face)
{
    return g && g->face_small && face < g->face_count && g->face_small[face];
}
