/* The planner's splat store (issue 12; splat_store.h, docs/status/issue-12-splats.md "Planner and
 * CPU draw"). Per face, splat sets at radii s_k = s_0 2^(-k/2) (s_0: the diagonal of the face's
 * box) are built when a frame first needs them (crisp__splat_build, in parallel) and kept, all in
 * one growing array of crisp_plan_splat that the plan hands to backends as it is; a level whose set
 * would exceed the face's budget (CRISP_SPLAT_PER_PATCH patches + CRISP_SPLAT_PER_FACE) is
 * refused once and never tried again (finer levels hold more splats). Sets are dropped when the
 * scene changes (crisp_scene.serial) and, per face, when its trim pieces change (checked by a
 * hash of the pieces when crisp_scene.trim_serial moves).
 *
 * The choice per frame: a face whose box lies wholly between the near and far planes and meets
 * the frustum, with P_px = the pixels per model unit at the box's nearest point, is drawn as
 * the set at the coarsest level whose radius r has r P_px <= h - margin. P_px bounds the screen
 * distance of two points of the face at most a model unit apart where one of them shows at a
 * pixel: for points p, s of the face with d = p - s, x_p - x_s = (X_d - ndc_x(p) W_d) / W_s in
 * NDC (X_d, W_d: the linear part of view_proj's x and w rows applied to d), and ndc_x(p) lies in
 * N_x = the box's NDC x range met with [-1, 1] for a p that a pixel centre sees, W_s >= the box's
 * least W; so |x_p - x_s| = |(row x - ndc_x(p) row w) . d| / W_s <= (width / 2) max over n in N_x
 * of |row x - n row w| |d| / W_min pixels (the max of a convex function of n: at an end of N_x;
 * session 9 bounded it by |row x| + max |n| |row w|, up to 1.4x more at the image's sides), and y
 * alike. Every
 * point p of the face that a pixel centre sees is within r of a splat s, so s projects within
 * h - margin px of the pixel centre in x and in y and its square (half-size h) covers it. */
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define CHOICE_LANES 1 /* choose_faces4 */
#endif
#ifdef __GLIBC__ /* (defined by the headers above) */
#include <malloc.h>
#endif

#include "face_tree.h"
#include "splat.h"
#include "splat_store.h"

/* What every frame reads of a face (the choice and publish): one cache line per face, so that a
 * frame of many faces a few pixels across reads 64 bytes of each (session 15: the sets' ranges
 * and radii of all 40 levels beside them made it 700, and the faces' lines were read from memory
 * three times a plan). A built level's radius is the level's (level_radius: build_range stores a
 * set at R_k, store_set takes no other), so it is not kept. The lines (and the faces' boxes) are
 * stored in the faces' tree order (slot[f]: the face's place in tree.order; the faces outside
 * the tree after them), the order in which the choice walks them: it reads them as two streams
 * (session 17: in face order, a face's line and box were two or three scattered reads, the
 * choice's largest stall). */
typedef struct face_sets {
    double s0;        /* radius of level 0: the face box's diagonal (0: never splatted) */
    double log_s0;    /* 2 log2 s0 (the choice per group of faces) */
    uint64_t built;   /* bit k: level k is in the store */
    double origin[3]; /* the face's splat origin (its first set's): p are offsets from it */
    uint32_t draw_first, draw_count; /* the set of level draw_level: its splats in the store */
    int8_t draw_level;               /* -1: none (face_levels holds every built level's) */
    uint8_t refused; /* levels >= refused are over the budget (CRISP_SPLAT_LEVELS: none) */
    uint8_t has_origin;
    uint8_t pad[5];
} face_sets;

/* The draw key of a face not drawn (above every drawn face's: near_key's bits are a positive
 * float's). */
#define DRAW_NONE UINT64_MAX

/* The rest of a face's sets, read when a face changes level or its sets change. */
typedef struct face_levels {
    uint32_t first[CRISP_SPLAT_LEVELS], count[CRISP_SPLAT_LEVELS];
    uint64_t trim_hash; /* of the face's trim pieces when its sets were built */
} face_levels;

struct crisp__splat_store {
    uint64_t serial, trim_serial; /* the scene the store was built from (0: none) */
    uint32_t face_count;
    face_sets *faces; /* per slot, 64-byte aligned */
    uint32_t *slot;   /* per face: its place in faces and box */
    face_levels *levels;
    double *box;                 /* 6 per slot: the union of the face's patches' boxes */
    crisp__face_tree tree;       /* of the faces with s0 > 0 (their boxes) */
    uint64_t (*chunk_counts)[3]; /* per chunk of the tree, the last choose's choice_counts */
    uint64_t counts[3];          /* crisp__splat_store_choice_counts */
    crisp_plan_splat *splats;
    size_t count, cap, dead; /* splats stored, allocated, and belonging to dropped sets */
    int8_t *want;            /* per face this frame: the level drawn, -1: not splatted */
    double *near;         /* per face this frame whose level is to be built: its box's least W (the
                             draw order; the faces drawn at once keep it in their key) */
    uint32_t (*range)[2]; /* per face with a key: first and count of its set */
    uint64_t *key;  /* per face: its draw key when its level is built and chosen (near as a float
                       rounded up, its bits, then the face: the draw order), else DRAW_NONE (the
                       faces with a key: the choice found their level built, set their clip
                       origin and range) */
    uint32_t keyed; /* the faces with a key */
    int all_near;   /* (test_want) near for every face with want >= 0 */
    uint32_t (*chunk_todo)[2]; /* per chunk of the tree: its faces whose wanted level is not
                                  built, and those drawn (keyed) */
    uint32_t *todo;            /* faces whose wanted level is built this frame */
    size_t todo_cap;
    crisp_splat_set *sets; /* per todo entry */
    crisp_status *status;
    uint32_t *made;   /* per todo entry: splats the builder made (before thinning; a refused
                         build: its cap) */
    uint32_t pending; /* faces of the last choose whose set was left for later frames */
    size_t sets_cap;
    crisp_plan_splat_range *ranges;
    size_t range_cap;
    uint32_t ranges_drawn; /* the last publish's ranges (its draw order; 0: none, a new scene) */
    uint64_t *order;       /* publish's sort: keys, then the same count of scratch */
    size_t order_cap;
    float *clip_origin;
    size_t clip_cap;
    crisp_mat4 view_proj;
    uint64_t choice_work; /* the last choice's work (choose_levels; UINT64_MAX: none yet) */
    int changed;          /* the splats array changed since the last publish */
    int clip_fresh;       /* a new scene: its clip origins are to be zeroed */
};

crisp_status crisp__splat_store_create(crisp__splat_store **dest)
{
    crisp__splat_store *s = calloc(1, sizeof *s);
    if (!s) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the splat store");
    s->choice_work = UINT64_MAX;
    *dest = s;
    return CRISP_OK;
}

static void clear_scene(crisp__splat_store *s)
{
    free(s->faces);
    free(s->levels);
    free(s->range);
    free(s->key);
    free(s->chunk_todo);
    s->levels = NULL, s->range = NULL, s->key = NULL, s->chunk_todo = NULL;
    free(s->box);
    free(s->want);
    free(s->near);
    free(s->slot);
    free(s->chunk_counts);
    crisp__face_tree_free(&s->tree);
    s->faces = NULL, s->box = NULL, s->want = NULL, s->near = NULL, s->slot = NULL;
    s->chunk_counts = NULL;
    s->face_count = 0;
    s->keyed = 0;
    s->count = s->dead = 0;
    s->ranges_drawn = 0;
    s->serial = s->trim_serial = 0;
    s->changed = 1;
    s->choice_work = UINT64_MAX;
}

void crisp__splat_store_destroy(crisp__splat_store *s)
{
    if (!s) return;
    clear_scene(s);
    free(s->splats);
    free(s->todo);
    free(s->sets);
    free(s->status);
    free(s->made);
    free(s->ranges);
    free(s->order);
    free(s->clip_origin);
    free(s);
}

/* Octahedral packing (crisp_plan_splat_normal): n / (|x| + |y| + |z|), the lower half folded
 * over, each coordinate rounded to a multiple of 2^-15 in [-1, 1 - 2^-15]. */
static inline float sign1(float a)
{
    return a < 0 ? -1.0f : 1.0f;
}

uint32_t crisp__splat_pack_normal(const float n[3])
{
    float l1 = fabsf(n[0]) + fabsf(n[1]) + fabsf(n[2]);
    float x = l1 > 0 ? n[0] / l1 : 0, y = l1 > 0 ? n[1] / l1 : 0;
    if (l1 > 0 && n[2] < 0) {
        float fx = (1 - fabsf(y)) * sign1(x), fy = (1 - fabsf(x)) * sign1(y);
        x = fx, y = fy;
    }
    long q[2] = {lrintf(x * 32768.0f), lrintf(y * 32768.0f)};
    for (int a = 0; a < 2; a++)
        q[a] = q[a] < -32768 ? -32768 : q[a] > 32767 ? 32767 : q[a];
    return (uint32_t)(uint16_t)(int16_t)q[0] | (uint32_t)(uint16_t)(int16_t)q[1] << 16;
}

void crisp_plan_splat_normal(uint32_t n, float dest[3])
{
    float x = (float)(int16_t)(uint16_t)(n & 0xffffu) * (1.0f / 32768.0f);
    float y = (float)(int16_t)(uint16_t)(n >> 16) * (1.0f / 32768.0f);
    float z = 1.0f - fabsf(x) - fabsf(y);
    if (z < 0) {
        float fx = (1.0f - fabsf(y)) * sign1(x), fy = (1.0f - fabsf(x)) * sign1(y);
        x = fx, y = fy;
    }
    float len = sqrtf(x * x + y * y + z * z);
    dest[0] = x / len, dest[1] = y / len, dest[2] = z / len;
}

/* FNV-1a over the used part of face f's trim pieces. */
static uint64_t trim_hash(const crisp_scene *sc, uint32_t f)
{
    const crisp_scene_face *sf = &sc->faces[f];
    uint64_t h = 1469598103934665603ull ^ sf->piece_count;
    for (uint32_t i = 0; i < sf->piece_count; i++) {
        const crisp_bezier_curve *c = &sc->pieces[sf->first_piece + i];
        size_t n = (size_t)(c->degree + 1) * (size_t)(c->dim + 1);
        if (n > sizeof c->cpw / sizeof c->cpw[0]) n = sizeof c->cpw / sizeof c->cpw[0];
        const unsigned char *b = (const unsigned char *)c->cpw;
        for (size_t k = 0; k < n * sizeof(double); k++)
            h = (h ^ b[k]) * 1099511628211ull;
        h = (h ^ (uint64_t)(c->degree | c->dim << 8 | c->rational << 16)) * 1099511628211ull;
    }
    return h;
}

void crisp__splat_store_drop_face(crisp__splat_store *s, uint32_t f)
{
    if (!s->faces || f >= s->face_count) return;
    face_sets *fs = &s->faces[s->slot[f]];
    for (int k = 0; k < CRISP_SPLAT_LEVELS; k++)
        if (fs->built >> k & 1u) s->dead += s->levels[f].count[k];
    double s0 = fs->s0, log_s0 = fs->log_s0;
    memset(fs, 0, sizeof *fs);
    memset(&s->levels[f], 0, sizeof s->levels[f]);
    fs->s0 = s0, fs->log_s0 = log_s0;
    fs->refused = CRISP_SPLAT_LEVELS;
    fs->draw_level = -1;
    if (s->key[f] != DRAW_NONE) s->keyed--;
    s->key[f] = DRAW_NONE;
    s->changed = 1;
}

/* The faces' lines and boxes (in face order, as ensure_scene makes them) moved to their slots:
 * the tree's order, then the faces outside the tree in face order. */
static crisp_status slots_in_tree_order(crisp__splat_store *s, uint32_t face_count)
{
    size_t n = face_count ? face_count : 1;
    face_sets *faces = aligned_alloc(64, n * sizeof *faces);
    double *box = crisp_malloc_array(n, 6 * sizeof *box);
    if (!faces || !box) {
        free(faces), free(box);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the splat store");
    }
    uint32_t in_tree = s->tree.node_count ? s->tree.nodes[0].count : 0, at = in_tree;
    for (uint32_t f = 0; f < face_count; f++)
        s->slot[f] = UINT32_MAX;
    for (uint32_t j = 0; j < in_tree; j++)
        s->slot[s->tree.order[j]] = j;
    for (uint32_t f = 0; f < face_count; f++) {
        if (s->slot[f] == UINT32_MAX) s->slot[f] = at++;
        faces[s->slot[f]] = s->faces[f];
        memcpy(box + 6 * (size_t)s->slot[f], s->box + 6 * (size_t)f, 6 * sizeof *box);
    }
    free(s->faces), free(s->box);
    s->faces = faces, s->box = box;
    return CRISP_OK;
}

/* The store for scene sc: rebuilt for a new scene, faces with changed trims dropped, dropped
 * sets compacted away once they are most of the array. */
static crisp_status ensure_scene(crisp__splat_store *s, const crisp_scene *sc)
{
    if (s->serial != sc->serial || s->face_count != sc->face_count) {
        clear_scene(s);
        size_t n = sc->face_count ? sc->face_count : 1;
        _Static_assert(sizeof(face_sets) == 64, "face_sets: one cache line");
        s->faces = n <= SIZE_MAX / 64 ? aligned_alloc(64, n * sizeof *s->faces) : NULL;
        if (s->faces) memset(s->faces, 0, n * sizeof *s->faces);
        s->levels = calloc(n, sizeof *s->levels);
        s->box = crisp_malloc_array(n, 6 * sizeof *s->box);
        s->want = crisp_malloc_array(n, sizeof *s->want);
        s->near = crisp_malloc_array(n, sizeof *s->near);
        s->slot = crisp_malloc_array(n, sizeof *s->slot);
        s->range = crisp_malloc_array(n, sizeof *s->range);
        s->key = crisp_malloc_array(n, sizeof *s->key);
        s->clip_fresh = 1; /* (grow_clip's new room: zeroed by choose) */
        if (!s->faces || !s->levels || !s->box || !s->want || !s->near || !s->slot || !s->range ||
            !s->key) {
            clear_scene(s);
            return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the splat store");
        }
        for (uint32_t f = 0; f < sc->face_count; f++) {
            const crisp_scene_face *sf = &sc->faces[f];
            double *b = s->box + 6 * (size_t)f;
            b[0] = b[1] = b[2] = INFINITY, b[3] = b[4] = b[5] = -INFINITY;
            for (uint32_t p = 0; p < sf->patch_count; p++) {
                const double *pb = sc->patches[sf->first_patch + p].box;
                for (int k = 0; k < 3; k++) {
                    b[k] = fmin(b[k], pb[k]);
                    b[k + 3] = fmax(b[k + 3], pb[k + 3]);
                }
            }
            double d = 0;
            for (int k = 0; k < 3; k++)
                d += (b[k + 3] - b[k]) * (b[k + 3] - b[k]);
            d = sqrt(d);
            s->faces[f].s0 = sf->patch_count && isfinite(d) && d > 0 ? d : 0;
            s->faces[f].refused = CRISP_SPLAT_LEVELS;
            s->faces[f].draw_level = -1;
            s->faces[f].log_s0 = s->faces[f].s0 > 0 ? 2 * log2(s->faces[f].s0) : 0;
            s->want[f] = s->faces[f].s0 > 0; /* (the tree's faces) */
            s->key[f] = DRAW_NONE;           /* (faces outside the tree are never drawn) */
        }
        crisp_status st =
            crisp__face_tree_build(s->box, (const uint8_t *)s->want, sc->face_count, &s->tree);
        if (!st) st = slots_in_tree_order(s, sc->face_count);
        size_t nc = s->tree.chunk_count ? s->tree.chunk_count : 1;
        if (!st && (!(s->chunk_counts = crisp_malloc_array(nc, sizeof *s->chunk_counts)) ||
                    !(s->chunk_todo = crisp_malloc_array(nc, sizeof *s->chunk_todo))))
            st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the splat store");
        if (st) {
            clear_scene(s);
            return st;
        }
        s->face_count = sc->face_count;
        s->serial = sc->serial;
        s->trim_serial = sc->trim_serial;
    }
    if (s->trim_serial != sc->trim_serial) {
        for (uint32_t f = 0; f < sc->face_count; f++)
            if (s->faces[s->slot[f]].built && trim_hash(sc, f) != s->levels[f].trim_hash)
                crisp__splat_store_drop_face(s, f);
        s->trim_serial = sc->trim_serial;
    }
    if (s->dead > 4096 && 2 * s->dead > s->count) { /* compact: live sets moved down */
        size_t at = 0;
        for (uint32_t f = 0; f < s->face_count; f++) {
            face_sets *fs = &s->faces[s->slot[f]];
            face_levels *fl = &s->levels[f];
            fs->draw_level = -1;
            for (int k = 0; k < CRISP_SPLAT_LEVELS; k++) {
                if (!(fs->built >> k & 1u)) continue;
                memmove(s->splats + at, s->splats + fl->first[k], fl->count[k] * sizeof *s->splats);
                fl->first[k] = (uint32_t)at;
                at += fl->count[k];
            }
        }
        s->count = at;
        s->dead = 0;
        s->changed = 1;
    }
    return CRISP_OK;
}

/* The radius of level k of a face whose level 0 is s0: s0 2^(-k/2), as ldexp(s0, -(k / 2)) times
 * 1 / sqrt 2 for odd k. The choice computes it for every face a frame: ldexp's call (about 50
 * instructions) is a product with the power of two, exact and so the same bits, unless the product
 * is subnormal, zero or not finite (then ldexp itself). */
static inline double level_radius(double s0, int k)
{
    uint64_t bits = (uint64_t)(1023 - k / 2) << 52; /* 2^-(k/2), 0 <= k < CRISP_SPLAT_LEVELS */
    double p;
    memcpy(&p, &bits, sizeof p);
    double r = s0 * p;
    if (!(fabs(r) >= DBL_MIN && fabs(r) <= DBL_MAX)) r = ldexp(s0, -(k / 2));
    return r * (k & 1 ? 0.70710678118654752440 : 1.0);
}

static uint32_t budget(const crisp_scene *sc, uint32_t f)
{
    uint64_t b = (uint64_t)CRISP_SPLAT_PER_PATCH * sc->faces[f].patch_count + CRISP_SPLAT_PER_FACE;
    return b > CRISP_SPLAT_MAX_FACE ? CRISP_SPLAT_MAX_FACE : (uint32_t)b;
}

typedef struct choose_ctx {
    crisp__splat_store *s;
    const crisp_scene *sc;
    int width, height;
    double row[3][3]; /* rows x, y and w of view_proj's linear part */
    double w[4];      /* view_proj's W row: W = w[0] x + w[1] y + w[2] z + w[3] */
    uint8_t *splat;   /* NULL, or per face: set to 1 for the faces whose level is built */
    int wlow[3];      /* per axis, the box coordinate (0 .. 5) at which W is least (face_wmin) */
    int all_near;     /* near for every face with want >= 0 (the drawn faces' too) */
} choose_ctx;

/* The level the face at slot j wants this frame (-1: planned as patches); its box's least W in
 * *near. */
static int want_level(const choose_ctx *c, uint32_t j, double *near)
{
    const crisp__splat_store *s = c->s;
    const face_sets *fs = &s->faces[j];
    if (!(fs->s0 > 0) || !fs->refused) return -1;
    const double *b = s->box + 6 * (size_t)j;
    crisp_mat4 *m = (crisp_mat4 *)&s->view_proj;
    int out[4] = {1, 1, 1, 1};
    double wmin = INFINITY, nlo[2] = {INFINITY, INFINITY}, nhi[2] = {-INFINITY, -INFINITY};
    for (int k = 0; k < 8; k++) {
        double p[3] = {b[(k & 1) ? 3 : 0], b[(k & 2) ? 4 : 1], b[(k & 4) ? 5 : 2]}, h[4];
        for (int q = 0; q < 4; q++)
            h[q] = (*m)[0][q] * p[0] + (*m)[1][q] * p[1] + (*m)[2][q] * p[2] + (*m)[3][q];
        /* wholly between the near and far planes (W > 0 follows) */
        if (!(h[2] > -h[3]) || !(h[2] < h[3]) || !(h[3] > 0)) return -1;
        out[0] &= h[0] > h[3], out[1] &= h[0] < -h[3];
        out[2] &= h[1] > h[3], out[3] &= h[1] < -h[3];
        wmin = fmin(wmin, h[3]);
        for (int a = 0; a < 2; a++) {
            nlo[a] = fmin(nlo[a], h[a] / h[3]);
            nhi[a] = fmax(nhi[a], h[a] / h[3]);
        }
    }
    if (out[0] | out[1] | out[2] | out[3]) return -1; /* off screen: culled as patches */
    *near = wmin;
    /* the largest |row_a - n row_w| over n in the box's NDC range met with [-1, 1] (convex in n:
     * at an end) */
    double g[2] = {0, 0};
    for (int a = 0; a < 2; a++)
        for (int e = 0; e < 2; e++) {
            double n = fmax(-1, fmin(1, e ? nhi[a] : nlo[a])), q = 0;
            for (int j = 0; j < 3; j++) {
                double v = c->row[a][j] - n * c->row[2][j];
                q += v * v;
            }
            g[a] = fmax(g[a], sqrt(q));
        }
    double ppu = fmax(0.5 * c->width * g[0], 0.5 * c->height * g[1]) / wmin * (1 + 1e-9);
    double rt = (CRISP_SPLAT_HALF_PX - CRISP_SPLAT_MARGIN_PX) / ppu;
    if (!(rt > 0)) return -1;
    double lk = ceil(2 * log2(fs->s0 / rt));
    int k = lk < 0 ? 0 : lk >= CRISP_SPLAT_LEVELS ? CRISP_SPLAT_LEVELS : (int)lk;
    /* The level's radius may round above rt: one level finer then. */
    while (k < CRISP_SPLAT_LEVELS && level_radius(fs->s0, k) > rt)
        k++;
    if (k >= CRISP_SPLAT_LEVELS || k >= fs->refused) return -1;
    /* A coarser set already built whose proven radius is small enough. */
    if (k > 0 && (fs->built >> (k - 1) & 1u) && level_radius(fs->s0, k - 1) <= rt) k--;
    if ((fs->built >> k & 1u) && !(level_radius(fs->s0, k) <= rt)) return -1;
    return k;
}

/* ---- the choice per group of faces ----------------------------------------------------------
 *
 * want_level's work per face (the box's 8 corners projected, its NDC range, square roots and a
 * logarithm: about 1,800 instructions) made imp49 far's choice (13,573 faces of a pixel or less)
 * cost more than the frame's whole plan at imp far10 (255 faces): a choice that follows the
 * faces, not the screen. The faces' tree (face_tree.h) decides groups at once instead, with the
 * same answers as want_level (tested: test_splats' test_group_choice):
 * - a node whose box lies beyond one plane of the frustum (outside one side of the screen, in
 *   front of the near plane, beyond the far plane, behind the eye) by more than the rounding: each
 *   of its faces has a corner beyond that plane or all corners out on that side, so want_level
 *   returns -1 for each; none of them is visited.
 * - a node whose box lies within the frustum by more than the rounding: no face of it is refused
 *   for the planes or the screen, and its box bounds every face's quantities: the least W of a
 *   face box lies in [wlo, whi] (the node's least and largest corner W) and g_a (the largest
 *   |row_a - n row_w| over the face's NDC range, met with [-1, 1]) in [min, max] of the same
 *   convex function over the node's NDC range. So each face's rt (want_level's radius bound) lies
 *   in [rt_lo, rt_hi], and its 2 log2 (s0 / rt) in [log_s0 + a_lo, log_s0 + a_hi] with a = -2
 *   log2 rt. Where that interval, widened by GROUP_DELTA for the rounding of both computations,
 *   holds no integer (or lies below 0, or above the last level), the face's level is its ceiling
 *   (want_level's ceil, and its loop does not move it: the level's radius is below rt by more
 *   than the rounding), decided with a few additions; else want_level decides the face. The
 *   face's least W (the draw order) is computed exactly as want_level does (face_wmin). */

/* A choice whose last run had less work than this (a face culled with its node: 1/8, decided by
 * its node's bound: 1, one by one by want_level: 32) runs on the calling thread. At
 * imp49 far (13,573 faces decided by their nodes' bounds, about 0.09 ms on one thread) the pool's
 * hand-off and the outputs' cache lines moving to the thread that publishes them made the choice
 * on this 2-core machine's two threads slower than on one: the plan 0.15-0.18 ms against 0.12-0.13
 * (session 22). The outputs do not depend on the threads. */
#define CHOICE_SERIAL_WORK 32768

/* The rounding allowance in 2 log2 (s0 / rt): the two computations' errors are about 1e-13. */
#define GROUP_DELTA 1e-9
/* A node within the frustum is decided as a group when its interval's width times its faces is
 * at most this (about the faces that want_level would then decide one by one); else its
 * children are tried (each costs about one face's want_level). */
#define GROUP_SPREAD 2.0

/* The least W over a face's box b, bit for bit as want_level's least of its 8 corners (w:
 * choose_ctx's W row, wlow its corner): the computed W is monotone in each coordinate (products
 * and sums round monotonically), so the corner with each coordinate at the end that lowers W gives
 * the least computed value. */
static inline double face_wmin(const double w[4], const int wlow[3], const double *b)
{
    return w[0] * b[wlow[0]] + w[1] * b[wlow[1]] + w[2] * b[wlow[2]] + w[3];
}

/* ceil(a) for the choice's 2 log2 (s0 / rt) bounds (a few tens), without a libm call: exact for
 * |a| < 2^31 (ceil's value, -0 as +0: the callers compare it and convert it to an int); the
 * library's beyond. */
static inline double ceil_level(double a)
{
    if (!(fabs(a) < 2147483648.0)) return ceil(a);
    double t = (double)(int32_t)a; /* towards zero: ceil for a <= 0, floor for a > 0 */
    return t + (double)(t < a);    /* (no branch: whether t < a changes from face to face) */
}

typedef struct group_view {
    int culled;          /* every face of the node: want_level returns -1 */
    int inside;          /* the node lies within the frustum; then: */
    double a_lo, a_hi;   /* 2 log2 (s0 / rt) - log_s0 of each face lies in [a_lo, a_hi] */
    double rt_lo, rt_hi; /* each face's rt lies in [rt_lo, rt_hi] */
} group_view;

/* min and max over n in [lo, hi] of |r - n w| (convex in n), widened for the rounding of the
 * face's computation (relative 1e-12; the minimiser's rounding moves the value by at most |w|
 * times it). */
static void row_range(const double r[3], const double w[3], double lo, double hi, double *gmin,
                      double *gmax)
{
    double rw = 0, ww = 0, ga = 0, gb = 0, gm = 0;
    for (int j = 0; j < 3; j++) {
        rw += r[j] * w[j], ww += w[j] * w[j];
        ga += (r[j] - lo * w[j]) * (r[j] - lo * w[j]);
        gb += (r[j] - hi * w[j]) * (r[j] - hi * w[j]);
    }
    double n = ww > 0 ? rw / ww : lo;
    n = n < lo ? lo : n > hi ? hi : n;
    for (int j = 0; j < 3; j++)
        gm += (r[j] - n * w[j]) * (r[j] - n * w[j]);
    *gmax = fmax(sqrt(ga), sqrt(gb)) * (1 + 1e-12);
    *gmin = (sqrt(gm) - 1e-12 * sqrt(ww) * (1 + fabs(n))) * (1 - 1e-12);
}

static void view_group(const choose_ctx *c, const double *b, group_view *v)
{
    const crisp_mat4 *m = (const crisp_mat4 *)&c->s->view_proj;
    /* e[q]: far more than the rounding of row q's sum of four products at any point of the box
     * (a few ulps of the sum of the terms' magnitudes) */
    double e[4];
    for (int q = 0; q < 4; q++) {
        double sum = fabs((*m)[3][q]);
        for (int j = 0; j < 3; j++)
            sum += fabs((*m)[j][q]) * fmax(fabs(b[j]), fabs(b[j + 3]));
        e[q] = 1e-12 * sum;
    }
    double ex = 2 * (e[0] + e[3]), ey = 2 * (e[1] + e[3]), ez = 2 * (e[2] + e[3]), ew = 2 * e[3];
    int in = 1, out[7] = {1, 1, 1, 1, 1, 1, 1};
    double wlo = INFINITY, whi = -INFINITY, nlo[2] = {INFINITY, INFINITY},
           nhi[2] = {-INFINITY, -INFINITY};
    for (int k = 0; k < 8; k++) {
        double p[3] = {b[(k & 1) ? 3 : 0], b[(k & 2) ? 4 : 1], b[(k & 4) ? 5 : 2]}, h[4];
        for (int q = 0; q < 4; q++)
            h[q] = (*m)[0][q] * p[0] + (*m)[1][q] * p[1] + (*m)[2][q] * p[2] + (*m)[3][q];
        in &= h[3] > ew && h[2] + h[3] > ez && h[3] - h[2] > ez && h[3] - h[0] > ex &&
              h[3] + h[0] > ex && h[3] - h[1] > ey && h[3] + h[1] > ey;
        out[0] &= h[0] - h[3] > ex;
        out[1] &= h[0] + h[3] < -ex;
        out[2] &= h[1] - h[3] > ey;
        out[3] &= h[1] + h[3] < -ey;
        out[4] &= h[2] + h[3] < -ez; /* in front of the near plane */
        out[5] &= h[2] - h[3] > ez;  /* beyond the far plane */
        out[6] &= h[3] < -ew;        /* behind the eye */
        if (!in) continue;
        wlo = fmin(wlo, h[3]), whi = fmax(whi, h[3]);
        for (int a = 0; a < 2; a++) {
            nlo[a] = fmin(nlo[a], h[a] / h[3]);
            nhi[a] = fmax(nhi[a], h[a] / h[3]);
        }
    }
    v->culled = out[0] | out[1] | out[2] | out[3] | out[4] | out[5] | out[6];
    v->inside = in;
    if (!in) return;
    wlo -= e[3], whi += e[3];
    double glo[2], ghi[2];
    for (int a = 0; a < 2; a++)
        row_range(c->row[a], c->row[2], fmax(-1, nlo[a] - 1e-9), fmin(1, nhi[a] + 1e-9), &glo[a],
                  &ghi[a]);
    double Glo = fmax(0.5 * c->width * glo[0], 0.5 * c->height * glo[1]);
    double Ghi = fmax(0.5 * c->width * ghi[0], 0.5 * c->height * ghi[1]);
    double h = CRISP_SPLAT_HALF_PX - CRISP_SPLAT_MARGIN_PX;
    v->rt_lo = h * wlo / (Ghi * (1 + 1e-9)) * (1 - 1e-12);
    v->rt_hi = h * whi / (Glo * (1 + 1e-9)) * (1 + 1e-12);
    /* (a zero or odd bound: not decided as a group) */
    if (!(wlo > 0) || !(Glo > 0) || !(v->rt_lo > 0) || !(v->rt_hi < INFINITY)) v->inside = 0;
    v->a_lo = -2 * log2(v->rt_hi);
    v->a_hi = -2 * log2(v->rt_lo);
}

#define UNDECIDED (-2)

/* want_level's answer for the face fs of a node inside the frustum whose group_view has a_lo and
 * a_hi, or UNDECIDED. */
static inline int want_level_grouped(const face_sets *fs, double a_lo, double a_hi)
{
    if (!(fs->s0 > 0) || !fs->refused) return -1;
    double lo = fs->log_s0 + a_lo - GROUP_DELTA, hi = fs->log_s0 + a_hi + 2 * GROUP_DELTA;
    if (lo > CRISP_SPLAT_LEVELS - 1) return -1; /* want_level's k at CRISP_SPLAT_LEVELS or more */
    double kk = ceil_level(hi);
    int k;
    if (kk <= 0)
        k = 0;
    else if (lo > kk - 1)
        k = (int)kk;
    else
        return UNDECIDED;
    if (k >= CRISP_SPLAT_LEVELS || k >= fs->refused) return -1;
    /* want_level's two checks of built levels' radii against rt are decided by the interval
     * too, so they are not made (session 18, inst5: two level_radius a face, about a quarter of
     * the choice's instructions at imp49 far). With R_k = s0 2^(-k/2), a face's 2 log2 (s0 / rt)
     * in [lo, hi] (widened by GROUP_DELTA beyond the rounding of log_s0, a_lo and a_hi, ~1e-13):
     * - k > 0 (so lo > k - 1): 2 log2 (s0 / rt_hi) > k - 1 + GROUP_DELTA, so R_(k-1) > rt_hi
     *   2^(GROUP_DELTA / 2): level k - 1 is never taken for k (want_level: R_(k-1) > rt);
     * - hi <= k - 2 GROUP_DELTA: 2 log2 (s0 / rt_lo) <= k - 2 GROUP_DELTA, so R_k <= rt_lo
     *   2^(-GROUP_DELTA) (level_radius's rounding is 1e-16 relative): a built level k is proven
     *   (R_k <= rt).
     * test_splats' test_group_choice compares every face's level with want_level's. */
    return k;
}

/* view_proj's rows as the clip origins take them (origin_rows_load: once per chunk of faces). */
typedef struct origin_rows {
#ifdef __SSE2__
    __m128d r[4][2]; /* row i's entries 0, 1 and 2, 3 */
#else
    double r[4][4];
#endif
} origin_rows;

static inline void origin_rows_load(crisp_mat4 m, origin_rows *o)
{
    for (int i = 0; i < 4; i++) {
#ifdef __SSE2__
        o->r[i][0] = _mm_loadu_pd(&m[i][0]), o->r[i][1] = _mm_loadu_pd(&m[i][2]);
#else
        memcpy(o->r[i], m[i], sizeof o->r[i]);
#endif
    }
}

/* The clip position of a face's splat origin (4 floats at co). */
static inline void clip_origin_of(const origin_rows *o, const double origin[3], float *co)
{
#ifdef __SSE2__
    /* two rows a vector: the same products and sums in the same order per row, so the same bits
     * as the loop below (about half its instructions: a face's clip origin was 30 of them) */
    __m128d o0 = _mm_set1_pd(origin[0]), o1 = _mm_set1_pd(origin[1]), o2 = _mm_set1_pd(origin[2]);
    for (int q = 0; q < 2; q++) {
        __m128d h = _mm_add_pd(
            _mm_add_pd(_mm_add_pd(_mm_mul_pd(o->r[0][q], o0), _mm_mul_pd(o->r[1][q], o1)),
                       _mm_mul_pd(o->r[2][q], o2)),
            o->r[3][q]);
        _mm_storel_pi((__m64 *)(co + 2 * q), _mm_cvtpd_ps(h));
    }
#else
    for (int q = 0; q < 4; q++)
        co[q] = (float)(o->r[0][q] * origin[0] + o->r[1][q] * origin[1] + o->r[2][q] * origin[2] +
                        o->r[3][q]);
#endif
}

/* The draw order's key of a face whose box's least W is w > 0: w as a float rounded up (its bits
 * order as the values; the next float up is the bits plus one, as nextafterf gives). */
static inline uint32_t near_key(double w)
{
    float fw = (float)w;
    uint32_t bits;
    memcpy(&bits, &fw, sizeof bits);
    return bits + (uint32_t)((double)fw < w);
}

/* The face's line (fs) caches its built level k's set (from its sets fl): the range drawn. */
static inline void draw_level_set(face_sets *fs, const face_levels *fl, int k)
{
    fs->draw_first = fl->first[k];
    fs->draw_count = fl->count[k];
    fs->draw_level = (int8_t)k;
}

/* Face f (at fs, its sets fl, its box's least W near) drawn at built level k: its set's range (at
 * range, through the face's cached level), its splat origin's clip position (4 floats at co), its
 * draw key (at key). */
static inline void draw_face(face_sets *fs, const face_levels *fl, const origin_rows *rows,
                             uint32_t f, int k, double near, uint32_t *range, float *co,
                             uint64_t *key)
{
    if (fs->draw_level != k) draw_level_set(fs, fl, k);
    range[0] = fs->draw_first, range[1] = fs->draw_count;
    clip_origin_of(rows, fs->origin, co);
    *key = (uint64_t)near_key(near) << 32 | f;
}

/* A face not drawn (yet): no draw key (at key), its clip origin 0 (4 floats at co). */
static inline void not_drawn_at(float *co, uint64_t *key)
{
    co[0] = co[1] = co[2] = co[3] = 0;
    *key = DRAW_NONE;
}

/* Face f not drawn (yet). */
static inline void not_drawn(crisp__splat_store *s, uint32_t f)
{
    not_drawn_at(s->clip_origin + 4 * (size_t)f, &s->key[f]);
}

/* What choose_chunk counts (see there). */
typedef struct chunk_tally {
    uint64_t counts[3];
    uint32_t todo, keyed;
} chunk_tally;

/* The faces at slots first .. end - 1, of nodes not culled: inside the frustum (a_lo, a_hi: per
 * face, from first, its node's group_view's a_lo and a_hi) or not (a_lo NULL). Each face's level
 * by its node's interval (want_level_grouped) when the node lies inside the frustum and the
 * interval decides it, else by want_level; its want, and its range, clip origin and key when its
 * level is built (else its near). The store's arrays and the view are held in locals: want and
 * splat are byte arrays, whose stores the compiler must take to change any memory, so with the
 * arrays read through s and c it reloaded every pointer and the W row after each of them. */
static void choose_faces(const choose_ctx *c, const double *a_lo, const double *a_hi,
                         uint32_t first, uint32_t end, const origin_rows *rows, chunk_tally *tl)
{
    crisp__splat_store *s = c->s;
    face_sets *faces = s->faces;
    const face_levels *levels = s->levels;
    const double *box = s->box;
    const uint32_t *order = s->tree.order;
    int8_t *restrict want = s->want;
    uint8_t *restrict splat = c->splat;
    double *restrict nearv = s->near;
    uint32_t(*restrict range)[2] = s->range;
    uint64_t *restrict key = s->key;
    float *restrict clip = s->clip_origin;
    const double w[4] = {c->w[0], c->w[1], c->w[2], c->w[3]};
    const int wlow[3] = {c->wlow[0], c->wlow[1], c->wlow[2]};
    const int all_near = c->all_near;
    chunk_tally t = *tl;
    for (uint32_t j = first; j < end; j++) {
        uint32_t f = order[j]; /* (at slot j) */
        face_sets *fs = &faces[j];
        double near = 0;
        int k = a_lo ? want_level_grouped(fs, a_lo[j - first], a_hi[j - first]) : UNDECIDED;
        if (k == UNDECIDED) {
            k = want_level(c, j, &near);
            t.counts[2]++;
        } else {
            if (k >= 0) near = face_wmin(w, wlow, box + 6 * (size_t)j);
            t.counts[1]++;
        }
        want[f] = (int8_t)k;
        if (k >= 0 && fs->built >> k & 1u) {
            draw_face(fs, &levels[f], rows, f, k, near, range[f], clip + 4 * (size_t)f, &key[f]);
            t.keyed++;
            if (splat) splat[f] = 1;
            if (all_near) nearv[f] = near;
        } else {
            not_drawn_at(clip + 4 * (size_t)f, &key[f]);
            if (k >= 0) nearv[f] = near, t.todo++;
        }
    }
    *tl = t;
}

int crisp__splat_choice_lanes = -1;
unsigned long long crisp__splat_lane_faces;

#ifdef CHOICE_LANES
/* choose_faces for four faces a lane (a_lo, a_hi from first as there; inside the frustum), from
 * slot j, as long as all four of a group are decided by their intervals at a level that is built;
 * returns the slot of the first group that is not (then nothing of it was written) or of the
 * fewer than four faces left. The same IEEE operations per lane as the scalar code
 * (want_level_grouped, face_wmin, near_key, clip_origin_of), so the same bits (test_splats'
 * test_choice_lanes). The faces' lines are four 64-byte rows, read as two 4 x 4 blocks of 8-byte
 * fields and transposed: s0, log_s0, built, origin x (the first), origin y, z, the range (first |
 * count << 32), draw_level | refused << 8 (the second). A face drawn at another level before gets
 * its line's range from its levels, as draw_face does. At imp49 far the scalar code took about 150
 * instructions a face, this about 50 (session 22). */
__attribute__((target("avx2"))) static uint32_t
choose_faces4(const choose_ctx *c, const double *a_lo, const double *a_hi, uint32_t first,
              uint32_t j, uint32_t end, chunk_tally *tl)
{
    _Static_assert(offsetof(face_sets, draw_first) == 48 && offsetof(face_sets, draw_level) == 56 &&
                       offsetof(face_sets, refused) == 57 && offsetof(face_sets, origin) == 24,
                   "face_sets: the fields choose_faces4 reads by position");
    crisp__splat_store *s = c->s;
    face_sets *faces = s->faces;
    const double *lines = (const double *)faces;
    const face_levels *levels = s->levels;
    const double *box = s->box;
    const uint32_t *order = s->tree.order;
    int8_t *restrict want = s->want;
    uint8_t *restrict splat = c->splat;
    uint32_t(*restrict range)[2] = s->range;
    uint64_t *restrict key = s->key;
    float *restrict clip = s->clip_origin;
    __m256d mr[4][4]; /* view_proj's entries [i][r] */
    for (int i = 0; i < 4; i++)
        for (int r = 0; r < 4; r++)
            mr[i][r] = _mm256_set1_pd(s->view_proj[i][r]);
    const __m256d d1 = _mm256_set1_pd(GROUP_DELTA), d2 = _mm256_set1_pd(2 * GROUP_DELTA);
    const __m256d last = _mm256_set1_pd(CRISP_SPLAT_LEVELS - 1), big = _mm256_set1_pd(2147483648.0);
    const __m256d one = _mm256_set1_pd(1.0), zero = _mm256_setzero_pd();
    const __m256d sign = _mm256_set1_pd(-0.0);
    const __m256i levels_n = _mm256_set1_epi64x(CRISP_SPLAT_LEVELS);
    const __m256i byte = _mm256_set1_epi64x(0xff), bit = _mm256_set1_epi64x(1);
    const __m256d w0 = _mm256_set1_pd(c->w[0]), w1 = _mm256_set1_pd(c->w[1]),
                  w2 = _mm256_set1_pd(c->w[2]), w3 = _mm256_set1_pd(c->w[3]);
    const __m128i six = _mm_setr_epi32(0, 6, 12, 18);
    const __m128i wl0 = _mm_set1_epi32(c->wlow[0]), wl1 = _mm_set1_epi32(c->wlow[1]),
                  wl2 = _mm_set1_epi32(c->wlow[2]);
    uint32_t taken = 0;
    for (; end - j >= 4; j += 4) {
        const double *l = lines + 8 * (size_t)j;
        __m256d a0 = _mm256_loadu_pd(l), a1 = _mm256_loadu_pd(l + 8), a2 = _mm256_loadu_pd(l + 16),
                a3 = _mm256_loadu_pd(l + 24);
        __m256d lo01 = _mm256_unpacklo_pd(a0, a1), hi01 = _mm256_unpackhi_pd(a0, a1),
                lo23 = _mm256_unpacklo_pd(a2, a3), hi23 = _mm256_unpackhi_pd(a2, a3);
        __m256d s0 = _mm256_permute2f128_pd(lo01, lo23, 0x20);
        __m256d log_s0 = _mm256_permute2f128_pd(hi01, hi23, 0x20);
        __m256i built = _mm256_castpd_si256(_mm256_permute2f128_pd(lo01, lo23, 0x31));
        __m256d ox = _mm256_permute2f128_pd(hi01, hi23, 0x31);
        /* want_level_grouped: s0 > 0, lo <= the last level, |hi| < 2^31 (ceil_level without
         * the library) and the level decided; a NaN fails each compare (the scalar code then) */
        __m256d lo = _mm256_sub_pd(_mm256_add_pd(log_s0, _mm256_loadu_pd(a_lo + (j - first))), d1);
        __m256d hi = _mm256_add_pd(_mm256_add_pd(log_s0, _mm256_loadu_pd(a_hi + (j - first))), d2);
        __m256d t = _mm256_round_pd(hi, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
        __m256d kk = _mm256_add_pd(t, _mm256_and_pd(_mm256_cmp_pd(t, hi, _CMP_LT_OQ), one));
        __m256d pos = _mm256_cmp_pd(kk, zero, _CMP_GT_OQ);
        __m256d ok =
            _mm256_and_pd(_mm256_cmp_pd(s0, zero, _CMP_GT_OQ), _mm256_cmp_pd(lo, last, _CMP_LE_OQ));
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(_mm256_andnot_pd(sign, hi), big, _CMP_LT_OQ));
        ok = _mm256_and_pd(ok, _mm256_or_pd(_mm256_cmp_pd(kk, zero, _CMP_LE_OQ),
                                            _mm256_cmp_pd(lo, _mm256_sub_pd(kk, one), _CMP_GT_OQ)));
        if (_mm256_movemask_pd(ok) != 0xf) break;
        __m256i k = _mm256_cvtepi32_epi64(_mm256_cvttpd_epi32(_mm256_and_pd(kk, pos)));
        __m256d b0 = _mm256_loadu_pd(l + 4), b1 = _mm256_loadu_pd(l + 12),
                b2 = _mm256_loadu_pd(l + 20), b3 = _mm256_loadu_pd(l + 28);
        __m256d plo01 = _mm256_unpacklo_pd(b0, b1), phi01 = _mm256_unpackhi_pd(b0, b1),
                plo23 = _mm256_unpacklo_pd(b2, b3), phi23 = _mm256_unpackhi_pd(b2, b3);
        __m256d oy = _mm256_permute2f128_pd(plo01, plo23, 0x20);
        __m256d oz = _mm256_permute2f128_pd(phi01, phi23, 0x20);
        __m256i rng = _mm256_castpd_si256(_mm256_permute2f128_pd(plo01, plo23, 0x31));
        __m256i misc = _mm256_castpd_si256(_mm256_permute2f128_pd(phi01, phi23, 0x31));
        /* k < CRISP_SPLAT_LEVELS, k < refused, level k built */
        __m256i refused = _mm256_and_si256(_mm256_srli_epi64(misc, 8), byte);
        __m256i good =
            _mm256_and_si256(_mm256_cmpgt_epi64(levels_n, k), _mm256_cmpgt_epi64(refused, k));
        good = _mm256_and_si256(
            good, _mm256_cmpeq_epi64(_mm256_and_si256(_mm256_srlv_epi64(built, k), bit), bit));
        if (_mm256_movemask_pd(_mm256_castsi256_pd(good)) != 0xf) break;
        int moved = 0xf & ~_mm256_movemask_pd(_mm256_castsi256_pd(
                              _mm256_cmpeq_epi64(_mm256_and_si256(misc, byte), k)));
        /* near (face_wmin): the box's coordinates at wlow */
        __m128i at = _mm_add_epi32(six, _mm_set1_epi32((int)(6 * j)));
        __m256d bx = _mm256_i32gather_pd(box, _mm_add_epi32(at, wl0), 8);
        __m256d by = _mm256_i32gather_pd(box, _mm_add_epi32(at, wl1), 8);
        __m256d bz = _mm256_i32gather_pd(box, _mm_add_epi32(at, wl2), 8);
        __m256d near =
            _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(w0, bx), _mm256_mul_pd(w1, by)),
                                        _mm256_mul_pd(w2, bz)),
                          w3);
        /* near_key: the float rounded up */
        __m128 fw = _mm256_cvtpd_ps(near);
        __m256i up = _mm256_castpd_si256(_mm256_cmp_pd(_mm256_cvtps_pd(fw), near, _CMP_LT_OQ));
        __m128i f4 = _mm_loadu_si128((const __m128i *)(order + j));
        __m256i keys = _mm256_or_si256(
            _mm256_slli_epi64(_mm256_sub_epi64(_mm256_cvtepu32_epi64(_mm_castps_si128(fw)), up),
                              32),
            _mm256_cvtepu32_epi64(f4));
        /* the clip origins (clip_origin_of per lane), then one face's four floats a vector */
        __m128 q[4];
        for (int r = 0; r < 4; r++)
            q[r] = _mm256_cvtpd_ps(
                _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(mr[0][r], ox),
                                                          _mm256_mul_pd(mr[1][r], oy)),
                                            _mm256_mul_pd(mr[2][r], oz)),
                              mr[3][r]));
        _MM_TRANSPOSE4_PS(q[0], q[1], q[2], q[3]);
        uint32_t f[4];
        uint64_t kv[4], rv[4];
        int64_t lv[4];
        _mm_storeu_si128((__m128i *)f, f4);
        _mm256_storeu_si256((__m256i *)kv, keys);
        _mm256_storeu_si256((__m256i *)rv, rng);
        _mm256_storeu_si256((__m256i *)lv, k);
        for (int i = 0; i < 4; i++) {
            if (moved >> i & 1) { /* (draw_face's change of level) */
                face_sets *fs = &faces[j + (uint32_t)i];
                draw_level_set(fs, &levels[f[i]], (int)lv[i]);
                rv[i] = (uint64_t)fs->draw_first | (uint64_t)fs->draw_count << 32;
            }
            want[f[i]] = (int8_t)lv[i];
            memcpy(range[f[i]], &rv[i], sizeof rv[i]);
            _mm_storeu_ps(clip + 4 * (size_t)f[i], q[i]);
            key[f[i]] = kv[i];
            splat[f[i]] = 1;
        }
        taken += 4;
    }
    tl->counts[1] += taken;
    tl->keyed += taken;
    if (taken) __atomic_fetch_add(&crisp__splat_lane_faces, taken, __ATOMIC_RELAXED);
    return j;
}
#endif

/* choose_faces for a run of faces inside the frustum (a_lo, a_hi as there), four at a time
 * (choose_faces4) where it can. */
static void choose_run(const choose_ctx *c, const double *a_lo, const double *a_hi, uint32_t first,
                       uint32_t end, const origin_rows *rows, chunk_tally *tl)
{
    uint32_t j = first;
#ifdef CHOICE_LANES
    if (crisp__splat_choice_lanes && c->splat && !c->all_near &&
        c->s->face_count < (1u << 28)) /* (choose_faces4's box indices in 32 bits) */
        while (end - j >= 4) {
            j = choose_faces4(c, a_lo, a_hi, first, j, end, tl);
            if (end - j < 4) break;
            /* (a group the lanes do not take) */
            choose_faces(c, a_lo + (j - first), a_hi + (j - first), j, j + 4, rows, tl);
            j += 4;
        }
#endif
    choose_faces(c, a_lo + (j - first), a_hi + (j - first), j, end, rows, tl);
}

/* Chunk i of the faces' tree: its faces' want (-1 for every face on entry), and for those whose
 * level is built, their range, clip origin and key (drawn), for the others near (with all_near:
 * every face's with want >= 0); counts: faces decided [0] culled with their node, [1] by their
 * node's bound, [2] one by one; chunk_todo: faces whose level is not built, faces drawn. The faces
 * of nodes inside the frustum are gathered in runs of neighbouring slots (the nodes a walk decides
 * one after another hold neighbouring ranges of slots), each face with its node's interval, so
 * that the four lanes take faces of nodes of fewer than four faces too. */
static void choose_chunk(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    choose_ctx *c = vctx;
    crisp__splat_store *s = c->s;
    const crisp__face_tree *t = &s->tree;
    origin_rows rows;
    origin_rows_load(s->view_proj, &rows);
    enum { RUN = 256 };
    double a_lo[RUN], a_hi[RUN];
    for (size_t i = begin; i < end; i++) {
        /* counted here and stored once: neighbouring chunks' counts share a cache line, which two
         * threads writing per face passed back and forth */
        chunk_tally tl = {{0, 0, 0}, 0, 0};
        uint32_t stack[64], run_first = 0, run_end = 0;
        int top = 0;
        stack[top++] = t->chunks[i];
        while (top > 0) {
            const crisp__face_node *n = &t->nodes[stack[--top]];
            group_view v = {0};
            view_group(c, n->box, &v);
            if (v.culled) {
                tl.counts[0] += n->count;
                for (uint32_t j = n->first; j < n->first + n->count; j++)
                    not_drawn(s, t->order[j]);
                continue;
            }
            int leaf = n->child[0] < 0;
            if (!leaf && (!v.inside || (v.a_hi - v.a_lo) * n->count > GROUP_SPREAD) &&
                top + 2 <= 64) {
                stack[top++] = (uint32_t)n->child[1];
                stack[top++] = (uint32_t)n->child[0];
                continue;
            }
            if (!v.inside) {
                choose_faces(c, NULL, NULL, n->first, n->first + n->count, &rows, &tl);
                continue;
            }
            for (uint32_t j = n->first, e = n->first + n->count; j < e;) {
                if (j != run_end || run_end - run_first == RUN) {
                    choose_run(c, a_lo, a_hi, run_first, run_end, &rows, &tl);
                    run_first = run_end = j;
                }
                uint32_t at = run_end - run_first, m = e - j < RUN - at ? e - j : RUN - at;
                for (uint32_t q = at; q < at + m; q++)
                    a_lo[q] = v.a_lo, a_hi[q] = v.a_hi;
                run_end += m, j += m;
            }
        }
        choose_run(c, a_lo, a_hi, run_first, run_end, &rows, &tl);
        memcpy(s->chunk_counts[i], tl.counts, sizeof tl.counts);
        s->chunk_todo[i][0] = tl.todo, s->chunk_todo[i][1] = tl.keyed;
    }
}

void crisp__splat_store_choice_counts(const crisp__splat_store *s, uint64_t dest[3])
{
    memcpy(dest, s->counts, sizeof s->counts);
}

/* want and near of every face for view_proj (the store's sets as they are): by the faces' tree
 * (grouped; then also the keys, ranges and clip origins: choose_chunk) or face by face. Returns the
 * faces whose level is wanted and not built (grouped; face by face: the face count, an upper
 * bound). */
static size_t choose_levels(crisp__splat_store *s, const crisp_scene *sc, crisp_mat4 view_proj,
                            int width, int height, crisp_pool *pool, int grouped, uint8_t *splat)
{
    crisp_mat4_copy(view_proj, s->view_proj);
    choose_ctx c = {.s = s,
                    .sc = sc,
                    .width = width,
                    .height = height,
                    .splat = splat,
                    .all_near = s->all_near};
    for (int a = 0; a < 3; a++)
        for (int q = 0; q < 3; q++)
            c.row[q][a] = view_proj[a][q == 2 ? 3 : q];
    for (int j = 0; j < 4; j++)
        c.w[j] = view_proj[j][3];
    for (int j = 0; j < 3; j++)
        c.wlow[j] = view_proj[j][3] >= 0 ? j : j + 3;
    memset(s->counts, 0, sizeof s->counts);
    if (!grouped) {
        for (uint32_t f = 0; f < sc->face_count; f++) {
            s->want[f] = (int8_t)want_level(&c, s->slot[f], &s->near[f]);
            s->key[f] = DRAW_NONE; /* (nothing is drawn from this choice) */
        }
        s->keyed = 0;
        return sc->face_count;
    }
    memset(s->want, -1, sc->face_count);
#ifdef CHOICE_LANES
    if (crisp__splat_choice_lanes < 0)
        crisp__splat_choice_lanes = __builtin_cpu_supports("avx2") ? 1 : 0;
#else
    crisp__splat_choice_lanes = 0;
#endif
    /* runs of neighbouring chunks per item: neighbours (one instance's halves at imp49 far) hold
     * faces of interleaved indices, whose per-face outputs share cache lines */
    size_t grain = s->tree.chunk_count / 16 > 1 ? s->tree.chunk_count / 16 : 1;
    if (s->choice_work < CHOICE_SERIAL_WORK) grain = s->tree.chunk_count; /* (one item) */
    crisp_pool_parallel_for(pool, s->tree.chunk_count, grain, choose_chunk, &c);
    size_t todo = 0;
    s->keyed = 0; /* (every face of the tree was drawn or not; the others have no key) */
    for (uint32_t i = 0; i < s->tree.chunk_count; i++) {
        for (int k = 0; k < 3; k++)
            s->counts[k] += s->chunk_counts[i][k];
        todo += s->chunk_todo[i][0];
        s->keyed += s->chunk_todo[i][1];
    }
    s->choice_work = s->counts[0] / 8 + s->counts[1] + 32 * s->counts[2];
    return todo;
}

/* The clip origins' array for the scene's faces (choose_chunk writes them). */
static crisp_status grow_clip(crisp__splat_store *s, const crisp_scene *sc)
{
    size_t nf = sc->face_count ? sc->face_count : 1;
    return crisp_grow((void **)&s->clip_origin, &s->clip_cap, 4 * nf, sizeof *s->clip_origin);
}

crisp_status crisp__splat_store_test_want(crisp__splat_store *s, const crisp_scene *sc,
                                          crisp_mat4 view_proj, int width, int height, int grouped,
                                          int8_t *want, double *near)
{
    crisp_status st = ensure_scene(s, sc);
    if (st || (st = grow_clip(s, sc))) return st;
    s->all_near = 1;
    choose_levels(s, sc, view_proj, width, height, NULL, grouped, NULL);
    s->all_near = 0;
    memcpy(want, s->want, sc->face_count * sizeof *want);
    memcpy(near, s->near, sc->face_count * sizeof *near);
    return CRISP_OK;
}

/* Thinning (the levels' counts): the builder's sets hold at least a splat or so per patch at
 * any radius (cells per patch), and the cells it halves are smaller than the radius needs. Level
 * k (radius R_k = s0 2^(-k/2)) is the builder's set at R_k thinned with each splat's own cell
 * radius rho_i (splat.h: every point of the face is within the rho_i of some splat i): splat i
 * is dropped when a kept splat j lies within d_i = R_k - rho_i of it (Euclidean), so every point
 * within rho_i of i is within R_k of j; every kept splat is one of the builder's (a point of the
 * trimmed face). Splats are taken largest rho first (they can be dropped least; ties in the set's
 * order) and the kept ones keep the set's order (the draw's chunks are runs of it:
 * splat_raster.c). Keys of a grid of side max d_i find the kept splats near a splat (its cell
 * and those of the 26 around it that lie within its d_i). Session 11 built at 0.7 R_k and thinned
 * with the set's radius instead (one d for all): 1.7-1.9x the splats on impeller.igs at radii of
 * d/16 .. d/64 of each face. Returns the count kept (moved to the front); n when there is no memory
 * (nothing dropped). */
static uint64_t cell_hash(const int64_t k[3])
{
    uint64_t h = ((uint64_t)k[0] * 0x9E3779B97F4A7C15ull) ^
                 ((uint64_t)k[1] * 0xC2B2AE3D27D4EB4Full) ^
                 ((uint64_t)k[2] * 0x165667B19E3779F9ull);
    return h ^ h >> 29;
}

/* Sorts n keys ascending by their upper 32 bits, equal ones kept in their order (LSD radix,
 * stable; every digit's counts in one pass; tmp: n more). publish's and crisp__splat_thin's keys
 * hold their face or index in the lower bits and come in that order, so that is their full order
 * (ties in face or index order) with half the passes. Digits of 8 bits (4 passes) for a few keys,
 * of 11 bits (3 passes: 2,048 counts each) from RADIX_WIDE keys on; each pass moves the keys
 * between key and tmp (copied back once at the end when they end in tmp), a digit that every key
 * shares moves nothing. */
#define RADIX_WIDE 4096
/* One digit's pass: keys from -> to by digit d (counts c, `size` of them, the first 0). Returns 0
 * when every key has the same digit (nothing moved). */
static inline int radix_pass(const uint64_t *from, uint64_t *to, uint32_t n, uint32_t *c,
                             uint32_t size, int shift, uint32_t mask)
{
    for (uint32_t v = 1; v < size; v++)
        if (c[v] == n) return 0;
    for (uint32_t v = 0; v + 1 < size; v++)
        c[v + 1] += c[v];
    for (uint32_t i = 0; i < n; i++)
        to[c[from[i] >> shift & mask]++] = from[i];
    return 1;
}

static void radix_sort(uint64_t *key, uint64_t *tmp, uint32_t n)
{
    uint64_t *from = key, *to = tmp, *t;
    if (n >= RADIX_WIDE) {
        uint32_t count[3][2049] = {{0}}; /* (24 KB of stack) */
        for (uint32_t i = 0; i < n; i++) {
            uint32_t hi = (uint32_t)(key[i] >> 32);
            count[0][(hi & 0x7ffu) + 1]++, count[1][(hi >> 11 & 0x7ffu) + 1]++;
            count[2][(hi >> 22) + 1]++;
        }
        for (int d = 0; d < 3; d++)
            if (radix_pass(from, to, n, count[d], 2049, 32 + 11 * d, 0x7ffu))
                t = from, from = to, to = t;
    } else {
        uint32_t count[4][257] = {{0}};
        for (uint32_t i = 0; i < n; i++) {
            uint32_t hi = (uint32_t)(key[i] >> 32);
            count[0][(hi & 0xffu) + 1]++, count[1][(hi >> 8 & 0xffu) + 1]++;
            count[2][(hi >> 16 & 0xffu) + 1]++, count[3][(hi >> 24) + 1]++;
        }
        for (int d = 0; d < 4; d++)
            if (radix_pass(from, to, n, count[d], 257, 32 + 8 * d, 0xffu))
                t = from, from = to, to = t;
    }
    if (from != key) memcpy(key, from, n * sizeof *key);
}

uint32_t crisp__splat_thin(crisp_splat *sp, uint32_t n, double radius)
{
    if (n < 2) return n;
    float rmin = sp[0].rho;
    for (uint32_t i = 1; i < n; i++)
        rmin = sp[i].rho < rmin ? sp[i].rho : rmin;
    double d = radius - (double)rmin; /* the largest d_i */
    if (!(d > 0)) return n;
    size_t cap = 16;
    while (cap < 2 * (size_t)n)
        cap *= 2;
    uint32_t *slot = calloc(cap, sizeof *slot); /* kept index + 1, 0: empty */
    int64_t(*key)[3] = malloc(cap * sizeof *key);
    uint64_t *order = malloc(2 * (size_t)n * sizeof *order); /* keys, then radix scratch */
    uint8_t *keep = malloc(n);
    if (!slot || !key || !order || !keep) {
        free(slot), free(key), free(order), free(keep);
        return n;
    }
    /* key: ~rho's bits (rho > 0: its bits order as its values), then the index */
    for (uint32_t i = 0; i < n; i++) {
        uint32_t bits;
        memcpy(&bits, &sp[i].rho, sizeof bits);
        order[i] = (uint64_t)~bits << 32 | i;
    }
    radix_sort(order, order + n, n); /* keys are unique: the same order as a full sort */
    for (uint32_t q = 0; q < n; q++) {
        uint32_t i = (uint32_t)order[q];
        const float *p = sp[i].p;
        double di = radius - (double)sp[i].rho;
        double dd = di * di * (1 - 1e-6); /* float offsets: keep a hair inside d_i */
        /* The kept splats within d_i <= d lie in the grid cells next to p's (per axis: its own,
         * and a neighbour only when p is within d_i of that side, with a margin far above the
         * rounding of the cell keys): 1-8 cells instead of all 27, the same splats found. */
        int64_t c[3];
        int lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            double t = (double)p[a] / d, fl = floor(t), reach = di / d * (1 + 1e-6) + 1e-6;
            c[a] = (int64_t)fl;
            lo[a] = t - fl <= reach ? -1 : 0;
            hi[a] = fl + 1 - t <= reach ? 1 : 0;
        }
        int near = 0;
        for (int o2 = lo[2]; o2 <= hi[2] && !near && di > 0; o2++)
            for (int o1 = lo[1]; o1 <= hi[1] && !near; o1++)
                for (int o0 = lo[0]; o0 <= hi[0] && !near; o0++) {
                    int64_t k[3] = {c[0] + o0, c[1] + o1, c[2] + o2};
                    for (size_t at = cell_hash(k) & (cap - 1); slot[at];
                         at = (at + 1) & (cap - 1)) {
                        if (key[at][0] != k[0] || key[at][1] != k[1] || key[at][2] != k[2])
                            continue;
                        const float *o = sp[slot[at] - 1].p;
                        double dx = (double)o[0] - p[0], dy = (double)o[1] - p[1],
                               dz = (double)o[2] - p[2];
                        if (dx * dx + dy * dy + dz * dz <= dd) {
                            near = 1;
                            break;
                        }
                    }
                }
        keep[i] = (uint8_t)!near;
        if (near) continue;
        size_t at = cell_hash(c) & (cap - 1);
        while (slot[at])
            at = (at + 1) & (cap - 1);
        slot[at] = i + 1;
        memcpy(key[at], c, sizeof c);
    }
    uint32_t kept = 0;
    for (uint32_t i = 0; i < n; i++)
        if (keep[i]) sp[kept++] = sp[i];
    free(slot), free(key), free(order), free(keep);
    return kept;
}

typedef struct build_ctx {
    crisp__splat_store *s;
    const crisp_scene *sc;
    size_t first; /* todo[first + i] is built into sets[i] */
} build_ctx;

/* Faces whose sets are built at a time (each chunk's sets are held until stored); with a build
 * limit (crisp_planner_desc.splat_build_limit) fewer, so that a frame stops near its limit (the
 * chunks are the same on any number of threads: which faces a frame builds does not depend on
 * them). */
#define BUILD_CHUNK 512
#define BUILD_CHUNK_LIMITED 32
/* A frame that built at least this many splats trims malloc's free memory afterwards. */
#define TRIM_SPLATS (1u << 20)

static void build_range(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    build_ctx *c = vctx;
    crisp__splat_store *s = c->s;
    for (size_t i = begin; i < end; i++) {
        uint32_t f = s->todo[c->first + i];
        int k = s->want[f];
        /* the set at R_k, thinned (crisp__splat_thin); up to 2x the budget before thinning
         * (thinning keeps 0.8-0.9 of a set on impeller.igs: more would be built to be refused) */
        double rk = level_radius(s->faces[s->slot[f]].s0, k);
        uint64_t cap = 2 * (uint64_t)budget(c->sc, f);
        crisp_splat_set *set = &s->sets[i];
        cap = cap > UINT32_MAX / 2 ? UINT32_MAX / 2 : cap;
        s->status[i] = crisp__splat_build(c->sc, f, rk, (uint32_t)cap, set);
        s->made[i] = s->status[i] == CRISP_ERR_LIMIT ? (uint32_t)cap : set->count;
        if (!s->status[i]) {
            uint32_t n = crisp__splat_thin(set->splats, set->count, rk);
            /* the level's radius, not the builder's (smaller when nothing was dropped): a
             * coarser level's proven radius then never stands in for a finer one (want_level),
             * so a view draws the same sets whatever views came before (test_view compares the
             * viewer's screenshot with one `crisp render`) */
            set->radius = rk;
            if (n < set->count) {
                set->count = n;
                /* every face's set is held until they are stored: give the dropped ones back
                 * now (imp49 default: the frame's peak 1,040 MB with the unthinned arrays, 16x
                 * cap) */
                crisp_splat *fit = crisp_realloc_array(set->splats, n ? n : 1, sizeof *fit);
                if (fit) set->splats = fit;
            }
        }
    }
}

/* Append set i (face f, level k) to the store. */
static crisp_status store_set(crisp__splat_store *s, const crisp_scene *sc, uint32_t f, int k,
                              crisp_splat_set *set)
{
    face_sets *fs = &s->faces[s->slot[f]];
    if (s->count + set->count > UINT32_MAX / 2)
        return crisp_error(CRISP_ERR_LIMIT, "more than 2^31 splats in the store");
    crisp_status st =
        crisp_grow((void **)&s->splats, &s->cap, s->count + set->count + 1, sizeof *s->splats);
    if (st) return st;
    if (!fs->has_origin) {
        memcpy(fs->origin, set->origin, sizeof fs->origin);
        fs->has_origin = 1;
        s->levels[f].trim_hash = trim_hash(sc, f);
    }
    double d[3];
    for (int a = 0; a < 3; a++)
        d[a] = set->origin[a] - fs->origin[a];
    crisp_plan_splat *dst = s->splats + s->count;
    for (uint32_t i = 0; i < set->count; i++) {
        const crisp_splat *src = &set->splats[i];
        for (int a = 0; a < 3; a++)
            dst[i].p[a] =
                d[0] != 0 || d[1] != 0 || d[2] != 0 ? (float)((double)src->p[a] + d[a]) : src->p[a];
        dst[i].n = crisp__splat_pack_normal(src->n);
        dst[i].uv[0] = src->uv[0], dst[i].uv[1] = src->uv[1];
    }
    s->levels[f].first[k] = (uint32_t)s->count;
    s->levels[f].count[k] = set->count;
    fs->built |= (uint64_t)1 << k; /* (its radius is level_radius's: the caller checked) */
    s->count += set->count;
    s->changed = 1;
    return CRISP_OK;
}

/* With a build limit, the order in which the wanted sets are built: the faces whose patches cost
 * the most for the splats they need first, so that the frames in between draw the cheapest faces
 * as patches (their plan, ribbons and triangles, whose buffers the planner and the renderer keep:
 * imp49 default with the viewer's 500,000 splats a frame, 7,365 faces drawn as patches in the
 * first frame instead of 12,037, its peak 928 -> 873 MB). A face's patches cost about their count
 * (each one planned, or a group leaf at least, its trims' ribbons); the splats of level k about
 * 2^k (radius s0 2^(-k/2), about a splat per r^2 of the face). Ties in face order: the same order
 * on any number of threads. Once nothing is pending the sets and the image are those of a planner
 * without a limit (the store's layout differs, not its sets). */
static crisp_status order_todo(crisp__splat_store *s, const crisp_scene *sc, size_t n)
{
    crisp_status st = crisp_grow((void **)&s->order, &s->order_cap, 2 * n, sizeof *s->order);
    if (st) return st;
    for (size_t i = 0; i < n; i++) {
        uint32_t f = s->todo[i], bits;
        float key = (float)ldexp((double)sc->faces[f].patch_count, -s->want[f]);
        memcpy(&bits, &key, sizeof bits); /* key >= 0: its bits order as its values */
        s->order[i] = (uint64_t)~bits << 32 | i;
    }
    radix_sort(s->order, s->order + n, (uint32_t)n);
    for (size_t i = 0; i < n; i++) /* the scratch half: the faces in the new order */
        s->order[n + i] = s->todo[(uint32_t)s->order[i]];
    for (size_t i = 0; i < n; i++)
        s->todo[i] = (uint32_t)s->order[n + i];
    return CRISP_OK;
}

crisp_status crisp__splat_store_choose(crisp__splat_store *s, const crisp_scene *sc,
                                       crisp_mat4 view_proj, int width, int height,
                                       uint64_t build_limit, crisp_pool *pool, uint8_t *splat)
{
    crisp_status st = ensure_scene(s, sc);
    if (st || (st = grow_clip(s, sc))) return st;
    if (s->clip_fresh) { /* (the faces outside the faces' tree are never written again) */
        memset(s->clip_origin, 0, 4 * (size_t)sc->face_count * sizeof *s->clip_origin);
        s->clip_fresh = 0;
    }
    /* (the faces whose level is built are marked by the choice: when none is to be built, those
     * are the faces drawn) */
    memset(splat, 0, sc->face_count);
    size_t unbuilt = choose_levels(s, sc, view_proj, width, height, pool, 1, splat);
    if (!unbuilt) {
        s->pending = 0;
        return CRISP_OK;
    }
    /* The sets wanted and not built yet: built in parallel, stored in face order. */
    size_t n = 0;
    for (uint32_t f = 0; f < sc->face_count && unbuilt; f++)
        if (s->want[f] >= 0 && s->key[f] == DRAW_NONE) {
            if ((st = crisp_grow((void **)&s->todo, &s->todo_cap, n + 1, sizeof *s->todo)))
                return st;
            s->todo[n++] = f;
        }
    /* With a build limit the frame stops after the chunk that reaches it; the faces left keep
     * want -1 (planned as patches, with their own guarantee) and are built by later frames. */
    if (build_limit && n > 1 && (st = order_todo(s, sc, n))) return st;
    size_t chunk = build_limit ? BUILD_CHUNK_LIMITED : BUILD_CHUNK, c0 = 0;
    uint64_t made = 0;
    for (; c0 < n && !(build_limit && made >= build_limit); c0 += chunk) {
        size_t m = n - c0 < chunk ? n - c0 : chunk;
        if ((st = crisp_grow((void **)&s->sets, &s->sets_cap, m, sizeof *s->sets))) return st;
        crisp_status *stt = realloc(s->status, s->sets_cap * sizeof *stt);
        if (!stt) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the splat store");
        s->status = stt;
        uint32_t *mt = realloc(s->made, s->sets_cap * sizeof *mt);
        if (!mt) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the splat store");
        s->made = mt;
        memset(s->sets, 0, m * sizeof *s->sets);
        build_ctx bc = {s, sc, c0};
        crisp_pool_parallel_for(pool, m, 1, build_range, &bc);
        crisp_status first_error = CRISP_OK;
        for (size_t i = 0; i < m; i++) {
            uint32_t f = s->todo[c0 + i];
            int k = s->want[f];
            crisp_status bs = s->status[i];
            made += s->made[i];
            if (!bs && s->sets[i].count <= budget(sc, f) &&
                s->sets[i].radius <= level_radius(s->faces[s->slot[f]].s0, k)) {
                bs = store_set(s, sc, f, k, &s->sets[i]);
                if (bs && !first_error) first_error = bs;
            } else if (bs == CRISP_ERR_NO_MEMORY) {
                if (!first_error) first_error = bs;
            } else {
                /* Over the budget (or a face the builder cannot sample): this level and every
                 * finer one are planned as patches. */
                face_sets *fs = &s->faces[s->slot[f]];
                if (k < fs->refused) fs->refused = (uint8_t)k;
                s->want[f] = -1;
            }
            crisp__splat_set_free(&s->sets[i]);
        }
        if (first_error) return first_error;
        crisp_error_clear();
    }
#ifdef __GLIBC__
    /* The builder's arrays (growing sets, thinning's grids, the sets held until stored) leave
     * their memory free in malloc's arenas but resident: give it back to the system after a frame
     * that built many splats (imp49 default's first frame, 3.8 M: 37 MB in about 30 ms, its peak
     * 571 -> 537 MB), or its build limit's worth (the frames catching up with a limit: imp49
     * default with 500,000 a frame, peak 785 -> 753 MB). A trim costs its time even when it
     * returns nothing (10 ms at imp49 far's 68,000 splats; a frame that builds a few sets as the
     * camera moves does not trim), and the scene's own garbage is trimmed when it is prepared
     * (scene.c). */
    if (made >= TRIM_SPLATS || (build_limit && made >= build_limit)) malloc_trim(0);
#endif
    s->pending = c0 < n ? (uint32_t)(n - c0) : 0;
    for (; c0 < n; c0++)
        s->want[s->todo[c0]] = -1;
    /* the faces built now: drawn as those the choice found built */
    origin_rows rows;
    origin_rows_load(s->view_proj, &rows);
    for (size_t i = 0; i < n; i++) {
        uint32_t f = s->todo[i];
        if (s->want[f] >= 0) {
            draw_face(&s->faces[s->slot[f]], &s->levels[f], &rows, f, s->want[f], s->near[f],
                      s->range[f], s->clip_origin + 4 * (size_t)f, &s->key[f]);
            s->keyed++;
            splat[f] = 1;
        }
    }
    return CRISP_OK;
}

/* The draw keys of the faces in the last publish's order when they are this frame's drawn faces
 * (nr of them: each of the last ranges' faces has a key and is in splat) and sorting them moves
 * few (at most 2 nr steps of an insertion sort): then sorted into dest (nr), 1. Else 0 (dest
 * holds some keys): publish sorts the keys gathered in face order. The same order either way:
 * the keys are distinct (their face below their W), and the radix sort's order, stable on the W
 * from face order, is the keys' order. A view that moves a little keeps most of its draw order,
 * a view that stays keeps all of it: imp49 far's radix sort was 0.56 M instructions a plan of
 * 4.5 M (session 17). */
static int sorted_as_before(const crisp__splat_store *s, const uint8_t *splat, uint32_t nr,
                            uint64_t *dest)
{
    if (nr != s->ranges_drawn) return 0;
    uint64_t budget = 2 * (uint64_t)nr, last = 0;
    uint32_t i = 0;
    for (; i < nr; i++) { /* (in order so far) */
        uint32_t f = s->ranges[i].face;
        uint64_t key = s->key[f];
        if (key == DRAW_NONE || !splat[f]) return 0;
        if (key < last) break;
        dest[i] = last = key;
    }
    for (; i < nr; i++) { /* (an insertion sort from the first key out of order) */
        uint32_t f = s->ranges[i].face, j = i;
        uint64_t key = s->key[f];
        if (key == DRAW_NONE || !splat[f]) return 0;
        for (; j > 0 && dest[j - 1] > key; j--) {
            if (!budget--) return 0;
            dest[j] = dest[j - 1];
        }
        dest[j] = key;
    }
    return 1;
}

crisp_status crisp__splat_store_publish(crisp__splat_store *s, const crisp_scene *sc,
                                        const uint8_t *splat, crisp_plan_face *faces,
                                        crisp_frame_plan *out)
{
    size_t nf = sc->face_count ? sc->face_count : 1;
    crisp_status st;
    if ((st = crisp_grow((void **)&s->ranges, &s->range_cap, nf, sizeof *s->ranges)) ||
        (st = grow_clip(s, sc)) ||
        (st = crisp_grow((void **)&s->order, &s->order_cap, 2 * nf, sizeof *s->order)))
        return st;
    uint32_t nr = 0;
    uint64_t drawn = 0;
    const uint64_t *sorted = s->order;
    int fresh = !s->faces || s->face_count != sc->face_count; /* (no choice for this scene) */
    /* Nearest first (the least W of the faces' boxes; ties in face order: the keys' face below
     * their W, and the sort is stable on the W): a backend that keeps the depth drawn skips the
     * ranges hidden by nearer ones (splat_raster.c). When the last publish's faces are the faces
     * with a key (as many, each of them keyed and in splat: then every face with a key is in
     * splat), their keys are taken in the last order, without a pass over every face (session
     * 18, inst5). */
    if (!fresh && s->keyed > 1 && s->keyed <= nf &&
        sorted_as_before(s, splat, s->keyed, s->order + s->keyed)) {
        nr = s->keyed;
        sorted = s->order + nr;
    } else if (fresh) {
        memset(s->clip_origin, 0, 4 * nf * sizeof *s->clip_origin);
    } else {
        /* The drawn faces' keys (the choice's), in face order; a face chosen but left out of
         * splat loses its clip origin as the faces not chosen have. */
        for (uint32_t f = 0; f < sc->face_count; f++) {
            uint64_t key = s->key[f];
            if (key == DRAW_NONE) continue;
            if (splat[f])
                s->order[nr++] = key;
            else
                memset(s->clip_origin + 4 * (size_t)f, 0, 4 * sizeof *s->clip_origin);
        }
        if (nr > 1) radix_sort(s->order, s->order + nr, nr);
    }
    for (uint32_t i = 0; i < nr; i++) {
        uint32_t f = (uint32_t)sorted[i];
        s->ranges[i] = (crisp_plan_splat_range){s->range[f][0], s->range[f][1], f};
        drawn += s->range[f][1];
        if (faces) faces[f].flags |= CRISP_PLAN_FACE_SPLATS;
    }
    out->splats = s->splats;
    out->splat_count = (uint32_t)s->count;
    out->splat_ranges = s->ranges;
    out->splat_range_count = nr;
    s->ranges_drawn = nr;
    out->splat_clip_origin = s->clip_origin;
    out->splat_half_px = CRISP_SPLAT_HALF_PX;
    if (s->changed) out->splats_version++;
    s->changed = 0;
    out->stats.splat_faces = nr;
    out->stats.splat_pending = s->pending;
    out->stats.splats_drawn = drawn;
    out->stats.splat_bytes =
        s->cap * sizeof *s->splats +
        (size_t)s->face_count * (sizeof *s->faces + sizeof *s->levels + 6 * sizeof(double) + 1);
    return CRISP_OK;
}
