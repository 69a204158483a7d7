/* The CPU backend (docs/design.md section 6): the frame plan's leaves are tessellated at their
 * levels (crack-free edges), evaluated on the true patches, and rasterised with the u-intercept
 * table's trim test per sample; samples are then resolved into colour (headlight shading, straight
 * alpha = coverage) and AOVs (depth, normal, u, v, face of the nearest covered sample). */
#include <limits.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && defined(__x86_64__) && defined(__SSE2__)
#include <immintrin.h>
#endif

#include "crisp/plan.h"
#include "crisp/tess.h"
#include "core/compiler.h"
#include "nurbs/nurbs_internal.h"
#include "occlusion.h"
#include "raster.h"
#include "render_internal.h"
#include "ribbon.h"
#include "splat_raster.h"

#define TESS_CACHE_BITS 7
#define TESS_ROW_DOUBLES (2 * (CRISP_MAX_DEGREE + 1) * 4)

#define TESS_VERT_BITS 8
#define NET5 ((CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1) * 5) /* find_empty_leaves' nets */

/* Normals at degenerate points (crisp__normal_degenerate: an apex, a pole, a collapsed side),
 * where crisp_bezier_patch_normal takes the limit from inside the patch over several evaluations
 * of its derivatives (occt_linkrods default: about 1,100 vertices a frame at 40 k instructions
 * each, 6% of its frame): kept across frames in a table of POLE_SLOTS keyed by the scene (serial),
 * the patch and the bits of (s, t): the same inputs give the same normal, bit for bit. The
 * tessellation's workers only read the table (a key's slot and its neighbour, slot ^ 1); what
 * each finds missing (up to POLE_FRESH a pass) goes in between passes (keep_pole_normals). */
#define POLE_BITS 13
#define POLE_SLOTS (1u << POLE_BITS)
#define POLE_FRESH 1024
typedef struct pole_normal {
    uint64_t serial, s, t; /* serial 0: an empty slot */
    uint32_t patch;
    double n[3];
} pole_normal;

static size_t pole_slot(uint32_t patch, uint64_t s, uint64_t t)
{
    return (size_t)(((s * 0x9E3779B97F4A7C15ull) ^ (t * 0xC2B2AE3D27D4EB4Full) ^
                     (patch * 0x165667B19E3779F9ull)) >>
                    (64 - POLE_BITS));
}

static int pole_is(const pole_normal *e, uint64_t serial, uint32_t patch, uint64_t s, uint64_t t)
{
    return e->serial == serial && e->patch == patch && e->s == s && e->t == t;
}

/* Per worker: a patch's rows evaluated at a few s values (crisp__bezier_patch_rows_s) and whole
 * vertices at a few (s, t), keyed by the patch and the bits of its local s (and t), valid for one
 * tessellation pass (generation: the same scene, patches and view). A vertex is a function of
 * these alone, so what the tables give is what evaluating again would give, bit for bit; they
 * pay where leaves of one patch meet (issue 12: a split patch's small leaves share most of their
 * vertices with their neighbours, each of which evaluated them again). */
typedef struct tess_cache {
    uint64_t gen[1 << TESS_CACHE_BITS], key[1 << TESS_CACHE_BITS];
    uint32_t patch[1 << TESS_CACHE_BITS]; /* a group leaf's vertices of one s span patches */
    double rows[(1 << TESS_CACHE_BITS) * TESS_ROW_DOUBLES];
    uint64_t vgen[1 << TESS_VERT_BITS], vs[1 << TESS_VERT_BITS], vt[1 << TESS_VERT_BITS];
    uint32_t vpatch[1 << TESS_VERT_BITS];
    crisp_raster_vertex vert[1 << TESS_VERT_BITS];
    double vp[1 << TESS_VERT_BITS][3]; /* vert's world-space positions (the kept leaves') */
    pole_normal fresh[POLE_FRESH];     /* the degenerate normals this pass computed */
    int fresh_count;
} tess_cache;

/* Leaves' world-space vertices kept across frames (issue 12, session 19). A leaf's vertices are
 * a function of the scene and of the leaf's record alone: its (s, t) grid is the generator's for
 * its levels, and each vertex's position, (u, v) and normal are its patch's at (s, t) (the face's
 * orientation and the kept degenerate normals included); only the clip position depends on the
 * camera. A leaf whose record was drawn before in the scene therefore projects its kept positions
 * (the same crisp_mat4_mulp of the same point: the same clip position) instead of evaluating its
 * patch again, bit for bit the same vertices. The table is keyed by the whole leaf record and
 * emptied for a new scene (serial); which leaves read and which fill it is decided between passes
 * (keep_decide), so the workers never write a record another reads. Bounded: KEEP_MAX_VERTS
 * vertices (64 MB) and KEEP_LEAF_SLOTS records; when full and missing more than it finds it is
 * emptied at the next pass. */
#define KEEP_LEAF_BITS 16
#define KEEP_LEAF_SLOTS (1u << KEEP_LEAF_BITS)
#define KEEP_PROBES 8
#define KEEP_MAX_VERTS ((size_t)1 << 20)
enum { KEEP_NONE = 0, KEEP_READ = 1, KEEP_FILL = 2 };
typedef struct kept_vertex {
    double p[3], attr[CRISP_RASTER_ATTRS];
} kept_vertex;
typedef struct kept_leaf {
    crisp_plan_leaf key;
    uint32_t epoch; /* the record is valid while this is the table's epoch (0: never) */
    uint32_t first; /* into the kept vertices */
    uint64_t pass;  /* the tessellation pass that filled it */
} kept_leaf;
typedef struct leaf_keep {
    kept_leaf *leaves; /* KEEP_LEAF_SLOTS (NULL: none yet) */
    kept_vertex *verts;
    size_t verts_cap, used, count; /* vertices and records in use */
    uint64_t serial;               /* the scene they are of */
    uint32_t epoch;
    int full;             /* a leaf found no room since the last emptying */
    size_t found, missed; /* leaves since the last emptying */
    uint64_t *src;        /* per leaf of the pass: first vertex << 2 | KEEP_* */
    size_t src_cap;
} leaf_keep;

struct crisp_renderer {
    crisp_render_desc desc;
    crisp_pool *pool;
    crisp_planner *planner;
    const crisp_frame_plan *plan; /* the frame being drawn */
    crisp_raster *raster;
    crisp_raster_target target;
    uint32_t *leaf_vbase, *leaf_tbase; /* per plan leaf: vertex, triangle counts, then offsets */
    size_t leaf_base_cap, leaf_tbase_cap;
    crisp_raster_vertex *verts;
    size_t vert_cap;
    crisp_raster_tri *tris;
    size_t tri_cap;
    size_t vert_count, tri_count; /* of the last frame */
    float *slack;                 /* per sample: depth slack for the ribbons (fill pass) */
    size_t slack_cap;
    crisp_raster_core *cores; /* per ribbon triangle: its quad's core (ribbon_core) */
    size_t cores_cap;
    double **st;   /* per worker: local (s, t) of one leaf's mesh */
    double **path; /* per worker: a leaf's cells' clip-space nets, depths 0.. (find_empty_leaves) */
    uint32_t **pidx; /* per worker: one leaf's triangles (leaf_pieces_hidden), 2 MAX_LEAF_VERTS */
    int workers;
    uint8_t *untested; /* per face: no trim loops, no trim test (the rasterizer's hook) */
    size_t untested_cap;
    uint8_t *leaf_skip; /* per plan leaf: 1: its screen hull holds no sample; 2: occluded */
    size_t leaf_skip_cap;
    /* Drawing some faces over an image of the others (crisp_render_cpu_plan_faces): */
    crisp_raster_target over; /* its own target, empty outside the last region */
    int over_rect[4];         /* x0, y0, x1, y1 of the region loaded last (empty: x0 >= x1) */
    double (*hull)[4];        /* per plan leaf: its screen box (lo x, lo y, hi x, hi y) */
    size_t hull_cap;
    uint32_t *ribbon_keep; /* the ribbon quads drawn (a window's, those not hidden) */
    size_t ribbon_keep_cap;
    uint8_t *ribbon_hidden; /* per ribbon quad looked at: hidden (cull_ribbons) */
    size_t ribbon_hidden_cap;
    tess_cache *cache;        /* per worker (tessellate) */
    pole_normal *poles;       /* POLE_SLOTS (NULL: none yet) */
    uint64_t tess_generation; /* of the last tessellation pass (tess_cache) */
    leaf_keep keep;           /* leaves' world-space vertices kept across frames */
    double *col;              /* the resolve's per-column view direction part (resolve_row1) */
    size_t col_cap;
    int no_vectors;  /* crisp__renderer_set_vectors */
    int resolve_cap; /* crisp__renderer_set_resolve: 1 + the fastest resolve path allowed; 0: any */
    uint32_t *order; /* the leaves drawn, batch after batch (crisp__occl_order) */
    size_t order_cap;
    crisp_occl_leaf *occl; /* per plan leaf: its blocks and nearest depth (occlusion culling) */
    size_t occl_cap;
    double *hiz; /* per 4x4 block of the target: the least 1/W drawn (crisp__raster_block_depth) */
    size_t hiz_cap;
    /* The same kept up to date by the surfaces' draws (crisp__raster_set_live_depth): hiz's
     * refreshes copy from it while live_ok (draw_plan). */
    double *hiz_live;
    size_t hiz_live_cap;
    uint8_t *seen_marks; /* per worker and face (draw_part.seen) */
    size_t seen_marks_cap;
    int32_t *seen_list; /* the faces the last image drawn with draw_part.seen shows */
    size_t seen_list_cap, seen_count;
    crisp__splat_scratch splat; /* the splat draw's (splat_raster.c) */
    struct {                    /* what the first part of a two-part draw leaves (draw_plan) */
        size_t nv, nt, occluded_leaves, occluded_tris, tris_dropped;
        crisp_raster_stats rs;
        int drawn, looked, dirty[4], live_ok;
        double t_tess, t_raster;
    } carry;
};

#define MAX_LEAF_VERTS                                                                             \
    (4 * (size_t)CRISP_PLAN_MAX_LEVEL + (CRISP_PLAN_MAX_LEVEL + 1) * (CRISP_PLAN_MAX_LEVEL + 1))

crisp_status crisp_renderer_create(const crisp_render_desc *desc, crisp_renderer **dest)
{
    crisp_renderer *r = calloc(1, sizeof *r);
    if (!r) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating the renderer");
    if (desc) r->desc = *desc;
    if (!r->desc.samples) r->desc.samples = 1;
    crisp_status st = CRISP_OK;
    if (r->desc.samples != 1 && r->desc.samples != 4 && r->desc.samples != 16)
        st = crisp_error(CRISP_ERR_INVALID_ARG, "%d samples per pixel: expected 1, 4 or 16",
                         r->desc.samples);
    if (!st) st = crisp_pool_create(r->desc.threads, &r->pool);
    if (!st)
        st = crisp_planner_create(
            &(crisp_planner_desc){.eps_px = r->desc.eps_px,
                                  .strip_count = r->desc.strip_count,
                                  .no_splats = r->desc.no_splats,
                                  .splat_build_limit = r->desc.splat_build_limit},
            r->pool, &r->planner);
    if (!st) st = crisp__raster_create(&r->raster);
    if (!st) {
        r->workers = crisp_pool_threads(r->pool);
        r->st = calloc((size_t)r->workers, sizeof *r->st);
        r->path = calloc((size_t)r->workers, sizeof *r->path);
        r->cache = calloc((size_t)r->workers, sizeof *r->cache);
        r->pidx = calloc((size_t)r->workers, sizeof *r->pidx);
        if (!r->st || !r->path || !r->cache || !r->pidx)
            st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating the renderer");
        for (int w = 0; !st && w < r->workers; w++)
            if (!(r->st[w] = crisp_malloc_array(MAX_LEAF_VERTS, 2 * sizeof(double))) ||
                !(r->path[w] = crisp_malloc_array((size_t)(CRISP_PLAN_MAX_DEPTH + 1) * NET5,
                                                  sizeof(double))) ||
                !(r->pidx[w] = crisp_malloc_array(MAX_LEAF_VERTS, 6 * sizeof(uint32_t))))
                st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating the renderer");
    }
    if (st) {
        crisp_renderer_destroy(r);
        return st;
    }
    *dest = r;
    return CRISP_OK;
}

void crisp_renderer_destroy(crisp_renderer *r)
{
    if (!r) return;
    if (r->st)
        for (int w = 0; w < r->workers; w++)
            free(r->st[w]);
    free(r->st);
    if (r->path)
        for (int w = 0; w < r->workers; w++)
            free(r->path[w]);
    free(r->path);
    if (r->pidx)
        for (int w = 0; w < r->workers; w++)
            free(r->pidx[w]);
    free(r->pidx);
    free(r->cache);
    free(r->poles);
    free(r->keep.leaves);
    free(r->keep.verts);
    free(r->keep.src);
    crisp_planner_destroy(r->planner);
    crisp_pool_destroy(r->pool);
    crisp__raster_destroy(r->raster);
    crisp__raster_target_free(&r->target);
    crisp__raster_target_free(&r->over);
    free(r->hull);
    free(r->leaf_vbase);
    free(r->leaf_tbase);
    free(r->verts);
    free(r->tris);
    free(r->slack);
    free(r->cores);
    free(r->untested);
    free(r->leaf_skip);
    free(r->ribbon_keep);
    free(r->ribbon_hidden);
    free(r->col);
    free(r->order);
    free(r->occl);
    free(r->hiz);
    free(r->hiz_live);
    free(r->seen_marks);
    free(r->seen_list);
    crisp__splat_scratch_free(&r->splat);
    free(r);
}

static void copy_plan_stats(const crisp_plan_stats *p, crisp_render_stats *s)
{
    s->patches = p->patches;
    s->visible_patches = p->visible_patches;
    s->split_patches = p->split_patches;
    s->leaves = p->leaves;
    s->visible_faces = p->visible_faces;
    s->unresolved = p->unresolved;
    s->table_rows = p->table_rows;
    s->table_bytes = p->table_bytes;
    s->ms_levels = p->ms_levels;
    s->ms_edges = p->ms_edges;
    s->ms_trim = p->ms_trim + p->ms_ribbons;
    s->hidden_faces = p->hidden_faces;
}

crisp_status crisp_renderer_plan(crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cam,
                                 crisp_render_stats *stats)
{
    const crisp_frame_plan *plan;
    crisp_status st = crisp_planner_plan(r->planner, sc, cam, &plan);
    if (!st && stats) {
        memset(stats, 0, sizeof *stats);
        copy_plan_stats(&plan->stats, stats);
    }
    return st;
}

void crisp_renderer_set_clip_plane(crisp_renderer *r, const double plane[4])
{
    for (int k = 0; k < 4; k++)
        r->desc.clip_plane[k] = plane ? plane[k] : 0;
}

crisp_planner *crisp_renderer_planner(crisp_renderer *r)
{
    return r->planner;
}

/* Extends the pixel box [lo, hi] of the plan's image by the clip-space point c (W > 0). */
static inline void box_add_clip(const crisp_frame_plan *plan, const double c[4], double lo[2],
                                double hi[2])
{
    double p[2];
    crisp__clip_px(c, plan->width, plan->height, p);
    lo[0] = fmin(lo[0], p[0]), hi[0] = fmax(hi[0], p[0]);
    lo[1] = fmin(lo[1], p[1]), hi[1] = fmax(hi[1], p[1]);
}

/* ---- tessellation -------------------------------------------------------------------------- */

static crisp_tess_levels leaf_levels(const crisp_plan_leaf *L)
{
    crisp_tess_levels lv = {{(int)L->tau, (int)L->tau}, {0}};
    for (int k = 0; k < 4; k++)
        lv.outer[k] = (int)L->edge[k];
    return lv;
}

/* One batch of leaves: list[0 .. count) (plan indices, in plan order), whose vertices and
 * triangles start at vorigin and torigin and end at vend and tend (leaf_vbase, leaf_tbase: each
 * leaf's offsets). Triangles index vertices from vorigin (the batch is drawn from there). */
typedef struct tess_ctx {
    crisp_renderer *r;
    const crisp_scene *sc;
    const uint32_t *list;
    size_t count;
    uint32_t vorigin, vend, tend;
    uint64_t generation;  /* the pass's (tess_cache) */
    const uint64_t *keep; /* per list entry: first kept vertex << 2 | KEEP_* (NULL: none kept) */
} tess_ctx;

static uint64_t leaf_hash(const crisp_plan_leaf *L)
{
    uint32_t w[sizeof *L / sizeof(uint32_t)];
    memcpy(w, L, sizeof w);
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (size_t i = 0; i < sizeof w / sizeof w[0]; i++)
        h = (h ^ w[i]) * 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    return h ^ (h >> 33);
}

/* Before a tessellation pass over list[0 .. count) (vertices up to vend): which leaves read their
 * kept vertices (KEEP_READ), which fill a new record (KEEP_FILL) and which neither (kept_leaf).
 * Returns the per-entry decisions, NULL where nothing is kept (no memory). */
static const uint64_t *keep_decide(crisp_renderer *r, const crisp_scene *sc, const uint32_t *list,
                                   size_t count, uint32_t vend, uint64_t pass)
{
    leaf_keep *kp = &r->keep;
    if (!kp->leaves && !(kp->leaves = calloc(KEEP_LEAF_SLOTS, sizeof *kp->leaves))) return NULL;
    if (kp->src_cap < count) {
        uint64_t *q = crisp_realloc_array(kp->src, count, sizeof *q);
        if (!q) return NULL;
        kp->src = q, kp->src_cap = count;
    }
    if (kp->serial != sc->serial || !kp->epoch || (kp->full && kp->missed > kp->found)) {
        /* a new scene, or full of what is no longer drawn: empty it */
        if (++kp->epoch == 0) {
            memset(kp->leaves, 0, KEEP_LEAF_SLOTS * sizeof *kp->leaves);
            kp->epoch = 1;
        }
        kp->serial = sc->serial;
        kp->used = kp->count = kp->found = kp->missed = 0;
        kp->full = 0;
    }
    const crisp_frame_plan *plan = r->plan;
    for (size_t i = 0; i < count; i++) {
        const crisp_plan_leaf *L = &plan->leaves[list[i]];
        uint32_t v0 = r->leaf_vbase[list[i]],
                 v1 = i + 1 < count ? r->leaf_vbase[list[i + 1]] : vend;
        size_t n = v1 - v0, slot = (size_t)(leaf_hash(L) >> (64 - KEEP_LEAF_BITS));
        kept_leaf *e = NULL, *room = NULL;
        kp->src[i] = KEEP_NONE;
        for (int k = 0; k < KEEP_PROBES; k++) {
            kept_leaf *x = &kp->leaves[(slot + (size_t)k) & (KEEP_LEAF_SLOTS - 1)];
            if (x->epoch != kp->epoch) {
                room = x;
                break;
            }
            if (!memcmp(&x->key, L, sizeof *L)) {
                e = x;
                break;
            }
        }
        if (e) {
            /* (a record filled in this very pass is not read: another worker may be writing it) */
            if (e->pass != pass) kp->src[i] = (uint64_t)e->first << 2 | KEEP_READ, kp->found++;
            continue;
        }
        kp->missed++;
        if (!room || kp->count >= KEEP_LEAF_SLOTS / 2 || kp->used + n > KEEP_MAX_VERTS) {
            kp->full = 1;
            continue;
        }
        if (kp->used + n > kp->verts_cap) {
            size_t cap = kp->verts_cap ? kp->verts_cap : 4096;
            while (cap < kp->used + n)
                cap *= 2;
            cap = cap < KEEP_MAX_VERTS ? cap : KEEP_MAX_VERTS;
            kept_vertex *q = crisp_realloc_array(kp->verts, cap, sizeof *q);
            if (!q) {
                kp->full = 1;
                continue;
            }
            kp->verts = q, kp->verts_cap = cap;
        }
        *room = (kept_leaf){*L, kp->epoch, (uint32_t)kp->used, pass};
        kp->src[i] = (uint64_t)kp->used << 2 | KEEP_FILL;
        kp->used += n;
        kp->count++;
    }
    return kp->src;
}

static void tessellate(void *vctx, size_t begin, size_t end, int worker)
{
    tess_ctx *c = vctx;
    crisp_renderer *r = c->r;
    const crisp_frame_plan *plan = r->plan;
    double *st = r->st[worker];
    crisp_mat4 *m = (crisp_mat4 *)&plan->view_proj;
    for (size_t i = begin; i < end; i++) {
        size_t j = c->list[i];
        const crisp_plan_leaf *L = &plan->leaves[j];
        crisp_tess_levels lv = leaf_levels(L);
        uint32_t vbase = r->leaf_vbase[j], tbase = r->leaf_tbase[j];
        uint32_t vnext = i + 1 < c->count ? r->leaf_vbase[c->list[i + 1]] : c->vend,
                 tnext = i + 1 < c->count ? r->leaf_tbase[c->list[i + 1]] : c->tend;
        size_t nv = vnext - vbase;
        crisp_tess_mesh_generate(&lv, st, (uint32_t *)(r->tris + tbase), vbase - c->vorigin);
        /* The generator writes index triples; the raster triangle also carries the face. */
        size_t nt = tnext - tbase;
        uint32_t *idx = (uint32_t *)(r->tris + tbase);
        for (size_t k = nt; k-- > 0;) {
            crisp_raster_tri tri = {{idx[3 * k], idx[3 * k + 1], idx[3 * k + 2]}, L->face};
            r->tris[tbase + k] = tri;
        }
        int mode = c->keep ? (int)(c->keep[i] & 3) : KEEP_NONE;
        kept_vertex *kv = mode ? r->keep.verts + (c->keep[i] >> 2) : NULL;
        if (mode == KEEP_READ) {
            for (size_t k = 0; k < nv; k++) {
                crisp_raster_vertex *v = &r->verts[vbase + k];
                crisp_mat4_mulp(*m, kv[k].p, v->clip);
                memcpy(v->attr, kv[k].attr, sizeof v->attr);
            }
            continue;
        }
        int reversed = (plan->faces[L->face].flags & CRISP_PLAN_FACE_REVERSED) != 0;
        /* Vertices that share s (a column of the inner grid, a side of the boundary) share the
         * first half of the evaluation: the patch's rows at s, kept in a small table keyed by the
         * patch and s (the same s: the same rows, the same values); vertices met before in the
         * pass (a corner or side shared with a neighbouring leaf of the patch) are copied. */
        tess_cache *tc = &r->cache[worker];
        for (size_t k = 0; k < nv; k++) {
            double s, t; /* the vertex's patch (a group leaf spans several) and its local (s, t) */
            uint32_t pi = crisp_plan_leaf_locate(plan, L, st[2 * k], st[2 * k + 1], &s, &t);
            const crisp_scene_patch *sp = &c->sc->patches[pi];
            crisp_raster_vertex *v = &r->verts[vbase + k];
            uint64_t sbits, tbits;
            memcpy(&sbits, &s, sizeof sbits);
            memcpy(&tbits, &t, sizeof tbits);
            size_t vslot =
                (size_t)(((sbits * 0x9E3779B97F4A7C15ull) ^ (tbits * 0xC2B2AE3D27D4EB4Full) ^
                          (pi * 0x165667B19E3779F9ull)) >>
                         (64 - TESS_VERT_BITS));
            /* Only a vertex on the leaf's boundary can be another leaf's. */
            int side = st[2 * k] == 0 || st[2 * k] == 1 || st[2 * k + 1] == 0 || st[2 * k + 1] == 1;
            if (side && tc->vgen[vslot] == c->generation && tc->vs[vslot] == sbits &&
                tc->vt[vslot] == tbits && tc->vpatch[vslot] == pi) {
                *v = tc->vert[vslot];
                if (kv) {
                    memcpy(kv[k].p, tc->vp[vslot], sizeof kv[k].p);
                    memcpy(kv[k].attr, v->attr, sizeof kv[k].attr);
                }
                continue;
            }
            double P[3], Ps[3], Pt[3], n[3];
            size_t slot =
                (size_t)(((sbits * 0x9E3779B97F4A7C15ull) ^ (pi * 0x165667B19E3779F9ull)) >>
                         (64 - TESS_CACHE_BITS));
            double *rows = tc->rows + slot * TESS_ROW_DOUBLES;
            if (tc->gen[slot] != c->generation || tc->key[slot] != sbits || tc->patch[slot] != pi) {
                crisp__bezier_patch_rows_s(&sp->bez, s, rows);
                tc->gen[slot] = c->generation;
                tc->key[slot] = sbits;
                tc->patch[slot] = pi;
            }
            crisp__bezier_patch_derivs_rows(&sp->bez, rows, t, P, Ps, Pt);
            crisp_mat4_mulp(*m, P, v->clip);
            v->attr[0] = sp->bez.u0 + s * (sp->bez.u1 - sp->bez.u0);
            v->attr[1] = sp->bez.v0 + t * (sp->bez.v1 - sp->bez.v0);
            crisp_vec3_cross(Ps, Pt, n);
            /* At an apex, a pole or a collapsed side the cross product vanishes: take the limit
             * from inside the patch (each generator of a cone keeps its own normal). */
            if (crisp__normal_degenerate(Ps, Pt, n)) {
                size_t ps = pole_slot(pi, sbits, tbits);
                const pole_normal *e = r->poles ? &r->poles[ps] : NULL;
                if (e && !pole_is(e, c->sc->serial, pi, sbits, tbits)) e = &r->poles[ps ^ 1];
                if (e && pole_is(e, c->sc->serial, pi, sbits, tbits)) {
                    memcpy(n, e->n, sizeof e->n);
                } else {
                    crisp_bezier_patch_normal(&sp->bez, s, t, n);
                    if (tc->fresh_count < POLE_FRESH)
                        tc->fresh[tc->fresh_count++] =
                            (pole_normal){c->sc->serial, sbits, tbits, pi, {n[0], n[1], n[2]}};
                }
            }
            if (reversed) crisp_vec3_scale(n, -1, n);
            crisp_vec3_normalize(n, v->attr + 2);
            if (kv) {
                memcpy(kv[k].p, P, sizeof kv[k].p);
                memcpy(kv[k].attr, v->attr, sizeof kv[k].attr);
            }
            if (!side) continue;
            tc->vgen[vslot] = c->generation;
            tc->vs[vslot] = sbits;
            tc->vt[vslot] = tbits;
            tc->vpatch[vslot] = pi;
            tc->vert[vslot] = *v;
            memcpy(tc->vp[vslot], P, sizeof P);
        }
    }
}

/* The degenerate normals the workers computed in the last pass, into the table (which is made
 * on first use; without memory they are not kept). */
static void keep_pole_normals(crisp_renderer *r)
{
    for (int w = 0; w < r->workers; w++) {
        tess_cache *tc = &r->cache[w];
        if (tc->fresh_count && !r->poles) r->poles = calloc(POLE_SLOTS, sizeof *r->poles);
        for (int i = 0; r->poles && i < tc->fresh_count; i++) {
            const pole_normal *e = &tc->fresh[i];
            /* Two slots a key: the second when the first holds another key of this scene. */
            size_t ps = pole_slot(e->patch, e->s, e->t);
            if (r->poles[ps].serial == e->serial &&
                !pole_is(&r->poles[ps], e->serial, e->patch, e->s, e->t))
                ps ^= 1;
            r->poles[ps] = *e;
        }
        tc->fresh_count = 0;
    }
}

/* Leaves that cannot cover a sample (issue 12). A leaf's triangles lie in the screen hull of its
 * sub-patch's control points (their vertices are surface points; W > 0 over the hull), and
 * snapping moves them by at most 1/512 px; when that box, so widened, holds no sample position
 * of the image, the leaf draws nothing and is not tessellated. The image is unchanged: far away,
 * where many patches share a pixel, most leaves fall between the samples. The same pass counts
 * each drawn leaf's vertices and triangles (in parallel; the caller turns them into offsets) and
 * keeps, for occlusion culling, the 4x4 blocks of the target its samples can lie in and the
 * largest 1/W of its hull (crisp_occl_leaf). */
typedef struct skip_ctx {
    crisp_renderer *r;
    const crisp_scene *sc;
    double off[16][2];
    int samples;
    const uint8_t *only;   /* per face: draw it (NULL: every face) */
    double (*hull)[4];     /* NULL, or receives each drawn leaf's screen box */
    int win[4];            /* the pixels drawn: x0, y0, width, height */
    crisp_occl_leaf *occl; /* NULL, or receives each drawn leaf's occlusion record */
    const uint8_t *later;  /* per face: 0 = drawn by the first part (NULL: draw every face) */
} skip_ctx;

static int holds_sample(const skip_ctx *c, const double lo[2], const double hi[2])
{
    const int *w = c->win;
    for (int s = 0; s < c->samples; s++) {
        double i0 = fmax(ceil(lo[0] - c->off[s][0]), w[0]),
               i1 = fmin(floor(hi[0] - c->off[s][0]), w[0] + w[2] - 1);
        double j0 = fmax(ceil(lo[1] - c->off[s][1]), w[1]),
               j1 = fmin(floor(hi[1] - c->off[s][1]), w[1] + w[3] - 1);
        if (i0 <= i1 && j0 <= j1) return 1;
    }
    return 0;
}

/* 1 when the box of group leaf L's patches' boxes, projected and widened as below, holds no sample
 * (not tried above 16 patches); with c->occl, also sets leaf j's occlusion record from them (iw
 * INFINITY above 64 patches). */
static int group_empty(const skip_ctx *c, size_t j, const crisp_plan_leaf *L)
{
    const crisp_frame_plan *plan = c->r->plan;
    crisp_mat4 *m = (crisp_mat4 *)&plan->view_proj;
    uint32_t nu = L->block & 0xffffu, nv = L->block >> 16, gu = plan->faces[L->face].grid_u;
    double whole_lo[2] = {-INFINITY, -INFINITY}, whole_hi[2] = {INFINITY, INFINITY};
    if (nu * nv > (c->occl ? 64u : 16u)) { /* not worth reading every patch box: draw it */
        if (c->occl) crisp__occl_set(&c->occl[j], c->win, whole_lo, whole_hi, INFINITY);
        return 0;
    }
    /* The union of the patches' boxes, then its 8 corners projected (issue 12: projecting the
     * 8 corners of each of up to 64 patch boxes was a sixth of impeller x 49's far frame). The
     * union holds every patch box, so the screen box and 1/W bound below still hold the block's
     * triangles. */
    double b[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (uint32_t iv = 0; iv < nv; iv++)
        for (uint32_t iu = 0; iu < nu; iu++) {
            const double *pb = c->sc->patches[L->patch + iv * gu + iu].box;
            for (int k = 0; k < 3; k++) {
                b[k] = pb[k] < b[k] ? pb[k] : b[k];
                b[k + 3] = pb[k + 3] > b[k + 3] ? pb[k + 3] : b[k + 3];
            }
        }
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY}, iw = 0;
    for (int k = 0; k < 8; k++) {
        double p[3] = {b[(k & 1) ? 3 : 0], b[(k & 2) ? 4 : 1], b[(k & 4) ? 5 : 2]}, h[4];
        for (int q = 0; q < 4; q++)
            h[q] = (*m)[0][q] * p[0] + (*m)[1][q] * p[1] + (*m)[2][q] * p[2] + (*m)[3][q];
        if (!(h[3] > 0) || !isfinite(h[0] + h[1] + h[3])) {
            if (c->occl) crisp__occl_set(&c->occl[j], c->win, whole_lo, whole_hi, INFINITY);
            return 0;
        }
        box_add_clip(plan, h, lo, hi);
        /* In front of the near plane (clip z > -W) or never culled. */
        iw = h[2] + h[3] > 0 ? fmax(iw, 1 / h[3]) : INFINITY;
    }
    double pad = 1.0 / 128 + 1e-9 * (fabs(lo[0]) + fabs(hi[0]) + fabs(lo[1]) + fabs(hi[1]));
    lo[0] -= pad, lo[1] -= pad, hi[0] += pad, hi[1] += pad;
    if (c->occl) crisp__occl_set(&c->occl[j], c->win, lo, hi, iw);
    /* The empty test as without culling (the same leaves drawn when culling is off). */
    return nu * nv <= 16 && !holds_sample(c, lo, hi);
}

/* Leaf j's vertex and triangle counts (UINT32_MAX: levels refused, the caller reports it); none
 * when it is skipped. */
static void leaf_counts(crisp_renderer *r, size_t j, const crisp_plan_leaf *L)
{
    crisp_tess_levels lv = leaf_levels(L);
    size_t v = 0, t = 0;
    if (!r->leaf_skip[j] && crisp_tess_mesh_counts(&lv, &v, &t)) v = t = UINT32_MAX;
    r->leaf_vbase[j] = (uint32_t)v;
    r->leaf_tbase[j] = (uint32_t)t;
}

/* A leaf's control net in clip space, 5 numbers per control point: X, Y, W, Z + W and the weight
 * (view_proj applied to the homogeneous point, which is linear, so restricting the projected net
 * gives the projected restricted net). The cells of one patch down to a leaf's are halved one
 * level at a time: a split patch's leaves come in quadtree order, so a leaf's parent is usually
 * the one already made for its sibling, and each leaf costs one halving in u and v of a net
 * projected once per patch (issue 12: re-extracting every leaf's cell from its patch with four
 * general cuts, then projecting it, was 454 + ~150 M of imp49's 772 M here). The nets are the
 * exact cells' to rounding, which the hull's padding (1/128 px) covers many times: a sound hull,
 * as before. */
typedef struct cell_path {
    uint32_t patch; /* whose cells are kept (UINT32_MAX: none) */
    int have;       /* cells kept: depths 0 .. have */
    uint32_t ix[CRISP_PLAN_MAX_DEPTH + 1], iy[CRISP_PLAN_MAX_DEPTH + 1];
    double *nets; /* the worker's path buffer: depth k's net at k NET5 */
} cell_path;

/* One line of n + 1 points of 5 numbers (stride apart) restricted in place to its half `upper`. */
static void halve_line5(double *q, ptrdiff_t stride, int n, int upper)
{
    if (upper) {
        for (int r = 1; r <= n; r++)
            for (int i = 0; i <= n - r; i++) {
                double *a = q + i * stride, *b = a + stride;
                for (int c = 0; c < 5; c++)
                    a[c] = (a[c] + b[c]) * 0.5;
            }
    } else {
        for (int r = 1; r <= n; r++)
            for (int i = n; i >= r; i--) {
                double *b = q + i * stride, *a = b - stride;
                for (int c = 0; c < 5; c++)
                    b[c] = (a[c] + b[c]) * 0.5;
            }
    }
}

/* Leaf L's clip-space net (bez: its patch, numbered `patch`). */
static const double *path_cell(cell_path *cp, const crisp_bezier_patch *bez, uint32_t patch,
                               const crisp_plan_leaf *L, const crisp_mat4 *m)
{
    int d = (int)L->depth;
    const int nu = bez->du + 1, n = nu * (bez->dv + 1);
    if (cp->patch != patch) {
        cp->patch = patch, cp->have = 0;
        for (int k = 0; k < n; k++) {
            const double *h = bez->cpw + 4 * k;
            double c[4], *o = cp->nets + 5 * k;
            for (int q = 0; q < 4; q++)
                c[q] =
                    (*m)[0][q] * h[0] + (*m)[1][q] * h[1] + (*m)[2][q] * h[2] + (*m)[3][q] * h[3];
            o[0] = c[0], o[1] = c[1], o[2] = c[3], o[3] = c[2] + c[3], o[4] = h[3];
        }
    }
    int k = cp->have < d ? cp->have : d; /* the deepest kept ancestor (or the leaf itself) */
    while (k > 0 && (cp->ix[k] != L->ix >> (d - k) || cp->iy[k] != L->iy >> (d - k)))
        k--;
    for (; k < d; k++) {
        uint32_t ix = L->ix >> (d - k - 1), iy = L->iy >> (d - k - 1);
        double *dst = cp->nets + (size_t)(k + 1) * NET5;
        memcpy(dst, cp->nets + (size_t)k * NET5, (size_t)n * 5 * sizeof *dst);
        for (int j = 0; j <= bez->dv; j++)
            halve_line5(dst + (size_t)j * nu * 5, 5, bez->du, (int)(ix & 1));
        for (int i = 0; i < nu; i++)
            halve_line5(dst + (size_t)i * 5, (ptrdiff_t)nu * 5, bez->dv, (int)(iy & 1));
        cp->ix[k + 1] = ix, cp->iy[k + 1] = iy;
    }
    cp->have = d;
    return cp->nets + (size_t)d * NET5;
}

static void find_empty_leaves(void *vctx, size_t begin, size_t end, int worker)
{
    skip_ctx *c = vctx;
    crisp_renderer *r = c->r;
    const crisp_frame_plan *plan = r->plan;
    const crisp_mat4 *m = (const crisp_mat4 *)&plan->view_proj;
    cell_path path = {.patch = UINT32_MAX, .nets = r->path[worker]};
    for (size_t j = begin; j < end; j++) {
        const crisp_plan_leaf *L = &plan->leaves[j];
        if ((c->only && !c->only[L->face]) || (c->later && !c->later[L->face])) {
            r->leaf_skip[j] = 1;
            r->leaf_vbase[j] = r->leaf_tbase[j] = 0; /* no vertices, no triangles */
            continue;
        }
        if (L->group) {
            /* A group leaf: its triangles lie in its patches' boxes. */
            r->leaf_skip[j] = group_empty(c, j, L);
            if (c->hull) { /* its screen box is not worked out: anywhere */
                double *b = c->hull[j];
                b[0] = b[1] = -INFINITY, b[2] = b[3] = INFINITY;
            }
            leaf_counts(r, j, L);
            continue;
        }
        const crisp_bezier_patch *bez = &c->sc->patches[L->patch].bez;
        const double *net = path_cell(&path, bez, L->patch, L, m);
        int n = (bez->du + 1) * (bez->dv + 1), front = 1;
        double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY}, iw = 0;
        for (int k = 0; k < n; k++) {
            const double *h = net + 5 * k; /* X, Y, W, Z + W, weight */
            if (!(h[2] > 0) || !isfinite(h[0] + h[1] + h[2])) {
                front = 0;
                break;
            }
            double x = (h[0] / h[2] + 1) * 0.5 * plan->width,
                   y = (1 - h[1] / h[2]) * 0.5 * plan->height;
            lo[0] = fmin(lo[0], x), hi[0] = fmax(hi[0], x);
            lo[1] = fmin(lo[1], y), hi[1] = fmax(hi[1], y);
            /* The control point's depth is W / weight: the surface's points are convex
             * combinations of the control points (positive weights), so their 1/W is at most the
             * largest of these. A hull reaching the near plane (clip z > -W fails) or a weight
             * that is not positive: never culled. */
            iw = h[4] > 0 && h[3] > 0 ? fmax(iw, h[4] / h[2]) : INFINITY;
        }
        /* Widen by the snapping (1/512 px) and rounding, generously. */
        double pad = 1.0 / 128 + 1e-9 * (fabs(lo[0]) + fabs(hi[0]) + fabs(lo[1]) + fabs(hi[1]));
        lo[0] -= pad, lo[1] -= pad, hi[0] += pad, hi[1] += pad;
        r->leaf_skip[j] = front && !holds_sample(c, lo, hi);
        if (c->hull) {
            double *b = c->hull[j];
            b[0] = front ? lo[0] : -INFINITY, b[1] = front ? lo[1] : -INFINITY;
            b[2] = front ? hi[0] : INFINITY, b[3] = front ? hi[1] : INFINITY;
        }
        if (c->occl) {
            double wlo[2] = {-INFINITY, -INFINITY}, whi[2] = {INFINITY, INFINITY};
            if (front)
                crisp__occl_set(&c->occl[j], c->win, lo, hi, iw);
            else
                crisp__occl_set(&c->occl[j], c->win, wlo, whi, INFINITY);
        }
        leaf_counts(r, j, L);
    }
}

/* Large leaves that no sample of theirs can reach after all, seen piece by piece (issue 12): a
 * leaf's control hull can cover much of the screen where its surface does not (a quarter of a
 * cylinder seen along its axis: the hull spans the hole that the screen lies in) or lie in front
 * of drawn depth only at a corner. The leaf's (s, t) square is cut into PIECES x PIECES pieces,
 * each piece's control hull (crisp__subpatch) projected as find_empty_leaves projects a leaf's. A
 * triangle lies in the convex hull of its vertices, surface points of the pieces they are in, so
 * its screen box lies in the box of those pieces' boxes and its 1/W is at most their largest.
 * When every triangle's vertices lie in some 2 x 2 window of pieces (checked on the leaf's own
 * mesh) and every window's box holds no sample or is hidden by the block depth (crisp__occl_set,
 * crisp__occl_hidden, as a leaf), no triangle of the leaf writes a sample: it is dropped. */
#define PIECES 8
#define PIECE_MIN_TRIS 1024 /* smaller leaves: not worth PIECES^2 sub-patches */

typedef struct piece_ctx {
    const skip_ctx *skc;
    const uint32_t *list;
    const double *hiz; /* the block depth (NULL: not looked at yet) */
    int blocks_x;
} piece_ctx;

/* Piece (pi, pj) of leaf L's (s, t) square: the screen box of its control hull (widened as in
 * find_empty_leaves) and the largest 1/W of its points; 0 when they are not known (a control
 * point behind the eye or at the near plane, not finite, or a weight not positive). */
static int piece_bound(const skip_ctx *c, const crisp_plan_leaf *L, int pi, int pj, double *storage,
                       double b[4], double *iwp)
{
    const crisp_frame_plan *plan = c->r->plan;
    const crisp_bezier_patch *bez = &c->sc->patches[L->patch].bez;
    crisp_mat4 *m = (crisp_mat4 *)&plan->view_proj;
    double s0, s1, t0, t1;
    crisp_plan_leaf_locate(plan, L, (double)pi / PIECES, (double)pj / PIECES, &s0, &t0);
    crisp_plan_leaf_locate(plan, L, (double)(pi + 1) / PIECES, (double)(pj + 1) / PIECES, &s1, &t1);
    crisp_bezier_patch sub;
    crisp__subpatch(bez, s0, s1, t0, t1, storage, storage + 2 * CRISP__PATCH_DOUBLES, &sub);
    int n = (sub.du + 1) * (sub.dv + 1);
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY}, iw = 0;
    for (int k = 0; k < n; k++) {
        const double *cp = sub.cpw + 4 * k;
        double h[4];
        for (int q = 0; q < 4; q++)
            h[q] =
                (*m)[0][q] * cp[0] + (*m)[1][q] * cp[1] + (*m)[2][q] * cp[2] + (*m)[3][q] * cp[3];
        if (!(h[3] > 0) || !isfinite(h[0] + h[1] + h[3]) || !(cp[3] > 0) || !(h[2] + h[3] > 0))
            return 0;
        box_add_clip(plan, h, lo, hi);
        iw = fmax(iw, cp[3] / h[3]);
    }
    double pad = 1.0 / 128 + 1e-9 * (fabs(lo[0]) + fabs(hi[0]) + fabs(lo[1]) + fabs(hi[1]));
    b[0] = lo[0] - pad, b[1] = lo[1] - pad, b[2] = hi[0] + pad, b[3] = hi[1] + pad;
    *iwp = iw;
    return 1;
}

static int leaf_pieces_hidden(const piece_ctx *pc, uint32_t j, int worker)
{
    const skip_ctx *c = pc->skc;
    crisp_renderer *r = c->r;
    const crisp_frame_plan *plan = r->plan;
    const crisp_plan_leaf *L = &plan->leaves[j];
    if (L->group || r->leaf_tbase[j] < PIECE_MIN_TRIS || r->leaf_tbase[j] > 2 * MAX_LEAF_VERTS)
        return 0;
    double *storage = r->st[worker];
    double box[PIECES][PIECES][4], iwp[PIECES][PIECES];
    uint8_t known[PIECES][PIECES] = {{0}}; /* pieces projected so far (on demand: a leaf on the
                                              screen usually fails at its first window) */
    for (int wj = 0; wj + 1 < PIECES; wj++)
        for (int wi = 0; wi + 1 < PIECES; wi++) {
            double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY}, iw = 0;
            for (int k = 0; k < 4; k++) {
                int pj = wj + k / 2, pi = wi + k % 2;
                if (!known[pj][pi]) {
                    if (!piece_bound(c, L, pi, pj, storage, box[pj][pi], &iwp[pj][pi])) return 0;
                    known[pj][pi] = 1;
                }
                const double *b = box[pj][pi];
                lo[0] = fmin(lo[0], b[0]), lo[1] = fmin(lo[1], b[1]);
                hi[0] = fmax(hi[0], b[2]), hi[1] = fmax(hi[1], b[3]);
                iw = fmax(iw, iwp[pj][pi]);
            }
            if (!holds_sample(c, lo, hi)) continue;
            if (!pc->hiz) return 0;
            crisp_occl_leaf o;
            crisp__occl_set(&o, c->win, lo, hi, iw);
            if (!crisp__occl_hidden(&o, pc->hiz, pc->blocks_x)) return 0;
        }
    /* Every window is dead: the leaf is, when each triangle lies in a window. */
    crisp_tess_levels lv = leaf_levels(L);
    double *st = r->st[worker];
    uint32_t *idx = r->pidx[worker];
    crisp_tess_mesh_generate(&lv, st, idx, 0);
    for (uint32_t k = 0; k < r->leaf_tbase[j]; k++) {
        int i0 = PIECES, i1 = -1, j0 = PIECES, j1 = -1;
        for (int v = 0; v < 3; v++) {
            const double *p = st + 2 * idx[3 * k + v];
            int pi = (int)(p[0] * PIECES), pj = (int)(p[1] * PIECES);
            pi = pi < 0 ? 0 : pi > PIECES - 1 ? PIECES - 1 : pi;
            pj = pj < 0 ? 0 : pj > PIECES - 1 ? PIECES - 1 : pj;
            i0 = pi < i0 ? pi : i0, i1 = pi > i1 ? pi : i1;
            j0 = pj < j0 ? pj : j0, j1 = pj > j1 ? pj : j1;
        }
        if (i1 - i0 > 1 || j1 - j0 > 1) return 0;
    }
    return 1;
}

static void pieces_range(void *vctx, size_t begin, size_t end, int worker)
{
    const piece_ctx *pc = vctx;
    for (size_t i = begin; i < end; i++) {
        uint32_t j = pc->list[i];
        if (!pc->skc->r->leaf_skip[j] && leaf_pieces_hidden(pc, j, worker))
            pc->skc->r->leaf_skip[j] = 2;
    }
}

/* ---- trim test and resolve ------------------------------------------------------------------- */

/* The fragment and box tests' context: the plan, and the draw's number for the box test's cache
 * (a renderer's plan buffers are reused frame after frame). */
typedef struct trim_ctx {
    const crisp_frame_plan *plan;
    uint64_t generation;
} trim_ctx;

static atomic_uint_fast64_t trim_generation;

static int trim_test(void *ctx, uint32_t face, double u, double v)
{
    const crisp_frame_plan *plan = ((const trim_ctx *)ctx)->plan;
    if (face & CRISP_RASTER_FACE_FLAG) return 1; /* a ribbon: drawn where it lands */
    return crisp_plan_trim_test(plan, face, u, v);
}

/* Crossings of table row r strictly left of u (crisp_plan_trim_test's count). */
static uint32_t crossings_left(const crisp_frame_plan *plan, uint32_t r, double u)
{
    uint32_t lo = plan->row_offset[r], hi = plan->row_offset[r + 1], first = lo;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (plan->crossings[mid] < u)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo - first;
}

/* crisp_plan_trim_test's strip and row of v (v in the face's range), as it computes them. */
static uint32_t strip_of(const crisp_plan_face *f, double v)
{
    double fi = (v - f->v0) * f->strip_scale;
    return fi < (double)f->strip_count ? (uint32_t)fi : f->strip_count - 1;
}

static uint32_t row_of(const crisp_plan_strip *s, double v)
{
    double fj = (v - s->a) * s->row_scale;
    return fj > 0.0 ? (fj < (double)s->row_count ? (uint32_t)fj : s->row_count - 1) : 0;
}

#define BOX_MAX_ROWS 256 /* a box over more table rows is left to the per-fragment test */

/* The trim test for a box of (u, v) (the rasterizer's box test): 1 when crisp_plan_trim_test
 * keeps every (u, v) of [lo, hi], 0 when it discards every one, -1 otherwise. Exact: every
 * step of the lookup is monotone in v (a difference and a product, rounded, then floor and
 * clamps), so the strips and rows the box's v can reach lie between those of lo[1] and hi[1]
 * (each strip's rows taken with its own parameters); in one row the count of crossings left of
 * u is monotone in u, so equal counts at lo[0] and hi[0] hold for every u between. */
int crisp__plan_trim_box(const crisp_frame_plan *plan, uint32_t face, const double lo[2],
                         const double hi[2])
{
    if (face & CRISP_RASTER_FACE_FLAG) return 1; /* a ribbon: drawn where it lands */
    face &= ~CRISP_RASTER_FACE_NO_TEST;
    if (face >= plan->face_count) return -1;
    const crisp_plan_face *f = &plan->faces[face];
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1])) return -1; /* NaN or empty */
    if (hi[1] < f->v0 || lo[1] > f->v1) return 0;       /* every v outside the table */
    if (!(lo[1] >= f->v0 && hi[1] <= f->v1)) return -1;
    if (f->flags & CRISP_PLAN_FACE_ALL_INSIDE) return 1;
    if (!f->strip_count) return 0;
    uint32_t i0 = strip_of(f, lo[1]), i1 = strip_of(f, hi[1]);
    if (i1 - i0 >= BOX_MAX_ROWS) return -1;
    int result = -2, rows = 0; /* -2: nothing seen yet */
    for (uint32_t i = i0; i <= i1; i++) {
        const crisp_plan_strip *s = &plan->strips[f->first_strip + i];
        int here;
        if (!s->row_count) {
            here = 0;
            if (result == -2) result = here;
            if (result != here) return -1;
            continue;
        }
        uint32_t j0 = row_of(s, lo[1]), j1 = row_of(s, hi[1]);
        rows += (int)(j1 - j0 + 1);
        if (rows > BOX_MAX_ROWS) return -1;
        for (uint32_t j = j0; j <= j1; j++) {
            uint32_t r = s->first_row + j;
            /* Equal counts at lo[0] and hi[0] (sorted crossings): none in [lo[0], hi[0]). */
            uint32_t a = crossings_left(plan, r, lo[0]), at = plan->row_offset[r] + a;
            if (at < plan->row_offset[r + 1] && !(plan->crossings[at] >= hi[0])) return -1;
            here = (int)(a & 1u);
            if (result == -2) result = here;
            if (result != here) return -1;
        }
    }
    return result == -2 ? -1 : result;
}

/* Row r's gap around [u0, u1]: 1 when no crossing of the row lies in [u0, u1) and the count
 * left of u0 has the parity `want` (-1: either; then *want is set); the gap (ua, ub] is
 * intersected into *ua, *ub (every u there has that count). */
static int row_gap(const crisp_frame_plan *plan, uint32_t r, double u0, double u1, int *want,
                   double *ua, double *ub)
{
    uint32_t first = plan->row_offset[r], end = plan->row_offset[r + 1];
    uint32_t a = crossings_left(plan, r, u0), at = first + a;
    if (at < end && !(plan->crossings[at] >= u1)) return 0;
    if (*want < 0) *want = (int)(a & 1u);
    if ((int)(a & 1u) != *want) return 0;
    if (at > first && plan->crossings[at - 1] > *ua) *ua = plan->crossings[at - 1];
    if (at < end && plan->crossings[at] < *ub) *ub = plan->crossings[at];
    return 1;
}

/* The box test with a memory of decided row ranges (issue 12: a close-up's triangles decide
 * their boxes one by one, each a binary search in each of tens of table rows, ~1,700
 * instructions; a triangle's neighbours fall in the same rows and the same gap between
 * crossings). An entry says: strips ia .. ib of face `face` all have rows, stored one after the
 * other, and in their rows ra .. rb (global row indices) the count of crossings left of u is the
 * same for every u with ua < u <= ub, with the parity `answer`. crisp__plan_trim_box walks, for
 * a box whose v lie in those strips, rows between row_of(lo[1]) of its first strip and
 * row_of(hi[1]) of its last (both monotone in v); when those lie in ra .. rb and its u in
 * (ua, ub], it would find equal counts of that parity in every row it walks: the answer, without
 * a search. Entries are made from boxes decided by walking every row between those two (so also
 * rows the search might leave out), then widened by rows above and below while they keep the
 * parity and the box's u in their gap. The answer can be 0 or 1 where crisp__plan_trim_box would
 * say -1 (its row limit, rows it does not walk); it is exact either way. */
int crisp__plan_trim_box_cached(crisp_trim_box_cache *c, const crisp_frame_plan *plan,
                                uint32_t face, const double lo[2], const double hi[2])
{
    uint32_t fid = face & ~CRISP_RASTER_FACE_NO_TEST;
    if ((face & CRISP_RASTER_FACE_FLAG) || fid >= plan->face_count)
        return crisp__plan_trim_box(plan, face, lo, hi);
    const crisp_plan_face *f = &plan->faces[fid];
    /* The cases crisp__plan_trim_box answers before its row walk. */
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1]) || !(lo[1] >= f->v0 && hi[1] <= f->v1) ||
        (f->flags & CRISP_PLAN_FACE_ALL_INSIDE) || !f->strip_count)
        return crisp__plan_trim_box(plan, face, lo, hi);
    uint32_t i0 = strip_of(f, lo[1]), i1 = strip_of(f, hi[1]);
    if (i1 - i0 >= BOX_MAX_ROWS) return crisp__plan_trim_box(plan, face, lo, hi);
    const crisp_plan_strip *st = plan->strips + f->first_strip;
    if (!st[i0].row_count || !st[i1].row_count) return crisp__plan_trim_box(plan, face, lo, hi);
    uint32_t r0 = st[i0].first_row + row_of(&st[i0], lo[1]),
             r1 = st[i1].first_row + row_of(&st[i1], hi[1]);
    /* A set of CRISP_TRIM_BOX_WAYS entries per face and strip: a zoomed face lies in one strip,
     * and the row ranges and gaps of its boxes on both sides of a trim curve, or in rows far
     * apart on screen, would otherwise replace one another. */
    crisp_trim_box_entry *set =
        &c->entry[((fid * 31u + i0) * CRISP_TRIM_BOX_WAYS) & (CRISP_TRIM_BOX_CACHE - 1)];
    for (int w = 0; w < CRISP_TRIM_BOX_WAYS; w++) {
        const crisp_trim_box_entry *e = &set[w];
        if (e->generation == c->generation && e->face == fid && e->ia <= i0 && i1 <= e->ib &&
            e->ra <= r0 && r1 <= e->rb && lo[0] > e->ua && hi[0] <= e->ub)
            return e->answer;
    }
    /* Every strip between with rows, stored one after the other: rows r0 .. r1 hold every row
     * the search walks. */
    for (uint32_t i = i0; i < i1; i++)
        if (!st[i + 1].row_count || st[i + 1].first_row != st[i].first_row + st[i].row_count)
            return crisp__plan_trim_box(plan, face, lo, hi);
    if (r1 < r0 || r1 - r0 >= BOX_MAX_ROWS) return crisp__plan_trim_box(plan, face, lo, hi);
    int res = -1;
    double ua = -INFINITY, ub = INFINITY;
    for (uint32_t r = r0; r <= r1; r++)
        if (!row_gap(plan, r, lo[0], hi[0], &res, &ua, &ub))
            return crisp__plan_trim_box(plan, face, lo, hi);
    /* Widen by up to as many rows again below and above, across strip boundaries as above. */
    uint32_t span = r1 - r0 + 1, ia = i0, ib = i1, ra = r0, rb = r1;
    for (uint32_t k = 0; k < span; k++) {
        if (ra == st[ia].first_row) {
            if (ia == 0 || !st[ia - 1].row_count ||
                st[ia - 1].first_row + st[ia - 1].row_count != ra)
                break;
            ia--;
        }
        if (!row_gap(plan, ra - 1, lo[0], hi[0], &res, &ua, &ub)) break;
        ra--;
    }
    if (ra >= st[ia].first_row + st[ia].row_count) ia++; /* a strip stepped into, row refused */
    for (uint32_t k = 0; k < span; k++) {
        if (rb + 1 == st[ib].first_row + st[ib].row_count) {
            if (ib + 1 >= f->strip_count || !st[ib + 1].row_count || st[ib + 1].first_row != rb + 1)
                break;
            ib++;
        }
        if (!row_gap(plan, rb + 1, lo[0], hi[0], &res, &ua, &ub)) break;
        rb++;
    }
    if (rb < st[ib].first_row) ib--;
    /* Replace the set's oldest entry (or one from an earlier draw). */
    int victim = 0;
    for (int w = 0; w < CRISP_TRIM_BOX_WAYS; w++) {
        if (set[w].generation != c->generation) {
            victim = w;
            break;
        }
        if (set[w].stamp < set[victim].stamp) victim = w;
    }
    set[victim] =
        (crisp_trim_box_entry){c->generation, ua, ub, fid, ia, ib, ra, rb, res, ++c->stamp};
    return res;
}

/* Per thread (the rasterizer's workers call the box test): its cache, valid for one draw. */
static _Thread_local crisp_trim_box_cache box_cache;

static int trim_box(void *ctx, uint32_t face, const double lo[2], const double hi[2])
{
    const trim_ctx *t = ctx;
    if (box_cache.generation != t->generation) box_cache.generation = t->generation;
    return crisp__plan_trim_box_cached(&box_cache, t->plan, face, lo, hi);
}

/* The plan's ribbon quads as raster vertices and triangles (0 1 2, 0 2 3), after the surfaces',
 * and per triangle its quad's core (ribbon_core; cores[t - torigin] for triangle t). */
typedef struct ribbon_ctx {
    crisp_renderer *r;
    const crisp_frame_plan *plan;
    size_t vbase, tbase;
    size_t first;         /* the plan's quad copied to the first place */
    const uint32_t *keep; /* the plan's quads drawn (NULL: all) */
    size_t vorigin;       /* the ribbons' first vertex: triangles index from it */
    size_t torigin;       /* the ribbons' first triangle: cores index from it */
} ribbon_ctx;

static void ribbon_quad(const crisp_plan_ribbon_vertex *src, crisp_raster_vertex *v)
{
    for (int k = 0; k < 4; k++) {
        memcpy(v[k].clip, src[k].clip, sizeof v[k].clip);
        v[k].attr[0] = src[k].uv[0];
        v[k].attr[1] = src[k].uv[1];
        for (int a = 0; a < 3; a++)
            v[k].attr[2 + a] = src[k].normal[a];
    }
}

/* The core of ribbon quad q (src/render/ribbon.h: the part within CRISP__RIBBON_CORE_PX of its
 * centre line and between its two curve points) for the fill pass's second test
 * (crisp_raster_core), in pixels of the plan's width x height image. The quad is a rectangle on
 * screen: corners 0, 1 at its start (its half-width before the first curve point), 2, 3 at its
 * end, 0 and 3 on one side; W is the first curve point's at corners 0, 1 and the second's at 2, 3.
 * The core's 1/W is affine along the centre line between the curve points' (as the core drawn as
 * its own quad: constant across, 1 / W at each curve point). A quad with a vertex behind the eye,
 * or not longer than its width, has no core. */
static void ribbon_core(const crisp_plan_ribbon_vertex *q, double width, double height,
                        crisp_raster_core *k)
{
    static const crisp_raster_core none = {{2, 0, 0}, {2, 0, 0}, {0, 0, 0}};
    double p[4][2];
    for (int c = 0; c < 4; c++) {
        if (!(q[c].clip[3] > 0)) {
            *k = none;
            return;
        }
        crisp__clip_px(q[c].clip, width, height, p[c]);
    }
    double pa[2] = {0.5 * (p[0][0] + p[1][0]), 0.5 * (p[0][1] + p[1][1])};
    double pb[2] = {0.5 * (p[2][0] + p[3][0]), 0.5 * (p[2][1] + p[3][1])};
    double L = hypot(pb[0] - pa[0], pb[1] - pa[1]),
           half = 0.5 * hypot(p[1][0] - p[0][0], p[1][1] - p[0][1]);
    double len = L - 2 * half; /* between the curve points */
    if (!(len > 0) || !isfinite(L)) {
        *k = none;
        return;
    }
    double e[2] = {(pb[0] - pa[0]) / L, (pb[1] - pa[1]) / L}, n[2] = {-e[1], e[0]};
    double A[2] = {pa[0] + half * e[0], pa[1] + half * e[1]}; /* the first curve point */
    /* across: n . (P - A) / core px; along: 2 e . (P - A) / len - 1; both in [-1, 1] */
    double ga = 1 / CRISP__RIBBON_CORE_PX, gb = 2 / len;
    k->a[1] = ga * n[0], k->a[2] = ga * n[1], k->a[0] = -(k->a[1] * A[0] + k->a[2] * A[1]);
    k->b[1] = gb * e[0], k->b[2] = gb * e[1], k->b[0] = -(k->b[1] * A[0] + k->b[2] * A[1]) - 1;
    double ia = 1 / q[0].clip[3], ib = 1 / q[2].clip[3], gi = (ib - ia) / len;
    k->iw[1] = gi * e[0], k->iw[2] = gi * e[1], k->iw[0] = ia - (k->iw[1] * A[0] + k->iw[2] * A[1]);
}

static void copy_ribbons(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    ribbon_ctx *c = vctx;
    for (size_t q = begin; q < end; q++) {
        size_t pq = c->keep ? c->keep[q] : c->first + q;
        const crisp_plan_ribbon_vertex *src = c->plan->ribbon_vertices + 4 * pq;
        ribbon_quad(src, c->r->verts + c->vbase + 4 * q);
        size_t t = c->tbase + 2 * q;
        crisp_raster_core *k = c->r->cores + (t - c->torigin);
        ribbon_core(src, c->plan->width, c->plan->height, k);
        k[1] = k[0];
        /* Indices relative to the ribbons' first vertex (drawn with verts + vorigin). */
        /* The trim test keeps every ribbon fragment (trim_test): not run at all. */
        uint32_t base = (uint32_t)(c->vbase - c->vorigin + 4 * q),
                 face = src[0].face | CRISP_RASTER_FACE_FLAG | CRISP_RASTER_FACE_NO_TEST;
        c->r->tris[t] = (crisp_raster_tri){{base, base + 1, base + 2}, face};
        c->r->tris[t + 1] = (crisp_raster_tri){{base, base + 2, base + 3}, face};
    }
}

/* Ribbon quads that the surfaces drawn hide (issue 12): a close-up's ribbons lie mostly behind
 * nearer faces. A quad whose two triangles the fill draw's set-up would drop (no sample area, or
 * hidden by the block depth: crisp__raster_quad_hidden with the quad's core, as the fill draw
 * sets them up) writes no sample; it is not copied, projected, nor given slack cells. The image
 * is the same: the cells its triangles reached were those of kept triangles too (hidden triangles
 * reach none), and its triangles were dropped at set-up. */
typedef struct ribbon_cull_ctx {
    crisp_renderer *r;
    const crisp_raster_target *t;
    const uint32_t *keep;   /* the plan's quads looked at (NULL: all) */
    uint8_t *hidden;        /* per quad looked at */
    int win[2];             /* the target's origin in the image */
    int blocks_x, blocks_y; /* of r->hiz */
} ribbon_cull_ctx;

typedef struct core_src {
    const crisp_plan_ribbon_vertex *q;
    double width, height;
} core_src;

static void quad_core(const void *ctx, crisp_raster_core *k)
{
    const core_src *c = ctx;
    ribbon_core(c->q, c->width, c->height, k);
}

static void cull_ribbons(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const ribbon_cull_ctx *c = vctx;
    const crisp_frame_plan *plan = c->r->plan;
    for (size_t q = begin; q < end; q++) {
        size_t pq = c->keep ? c->keep[q] : q;
        const crisp_plan_ribbon_vertex *src = plan->ribbon_vertices + 4 * pq;
        /* A quad with a corner at or in front of its block's depth is not hidden (most quads
         * lie on visible edges): kept without the full test's projection and block scans. */
        int seen = 0;
        for (int k = 0; k < 4 && !seen; k++) {
            const double *cl = src[k].clip;
            if (!(cl[3] > 0)) continue;
            double p[2];
            crisp__clip_px(cl, plan->width, plan->height, p);
            seen = crisp__occl_point_seen(c->r->hiz, c->blocks_x, c->blocks_y, p[0] - c->win[0],
                                          p[1] - c->win[1], 1 / cl[3]);
        }
        if (seen) {
            c->hidden[q] = 0;
            continue;
        }
        const double *clip[4] = {src[0].clip, src[1].clip, src[2].clip, src[3].clip};
        core_src cs = {src, plan->width, plan->height};
        c->hidden[q] = (uint8_t)crisp__raster_quad_hidden(c->r->raster, c->t, clip, quad_core, &cs);
    }
}

/* The camera's view directions per pixel for the rasterizer (as crisp_camera_ray, unnormalised). */
static void raster_view(const crisp_camera *cam, crisp_raster_view *v)
{
    double d0[3];
    crisp_vec3_sub(cam->target, cam->eye, d0);
    crisp_vec3_normalize(d0, v->f);
    crisp_vec3_cross(v->f, cam->up, d0);
    crisp_vec3_normalize(d0, v->r);
    crisp_vec3_cross(v->r, v->f, v->u);
    v->kx = v->ky = 2.0 * tan(cam->fov_deg * (M_PI / 360.0)) / cam->height;
}

typedef struct resolve_ctx {
    crisp_renderer *r;
    const crisp_scene *sc;
    const crisp_camera *cam;
    crisp_raster_view view; /* the camera's view directions (raster_view) */
    crisp_image *img;
    const crisp_raster_target *target; /* the samples resolved */
    /* Rows y0 + [begin, end) and columns [x0, x1) are resolved; with base, a pixel whose sample
     * is not of a drawn face (only) takes base's values (one sample per pixel). */
    int x0, x1, y0;
    const uint8_t *only;
    const crisp_image *base;
    const double *col;        /* f + nx r per column of the target: x, y, z planes; NULL: none */
    int path;                 /* RESOLVE_SCALAR, ... (draw_plan: resolve_path) */
    size_t rows;              /* rows [0, rows) of the region */
    crisp_raster_share share; /* groups of RESOLVE_ROWS rows, one home range per worker */
    /* Per worker, per face: 1 where a resolved pixel shows it (the planner's seen faces, marked
     * while the rows are in the cache); NULL: not wanted. */
    uint8_t *seen;
} resolve_ctx;

#define RESOLVE_ROWS 8 /* rows a worker takes at a time */

/* The resolve's paths, slowest first: resolve_rows_s for any target; resolve_row1 (SSE2),
 * resolve_row1_avx, resolve_row1_avx512 for one-sample targets without a base image. */
enum { RESOLVE_SCALAR, RESOLVE_ROW1, RESOLVE_AVX, RESOLVE_AVX512 };

static void copy_pixel(const crisp_image *src, crisp_image *dst, size_t px)
{
    memcpy(dst->rgba + 4 * px, src->rgba + 4 * px, 4 * sizeof *dst->rgba);
    memcpy(dst->normal + 3 * px, src->normal + 3 * px, 3 * sizeof *dst->normal);
    memcpy(dst->uv + 2 * px, src->uv + 2 * px, 2 * sizeof *dst->uv);
    dst->depth[px] = src->depth[px];
    dst->face[px] = src->face[px];
}

/* Rows y0 + [begin, end), columns [x0, x1) of the image, every pixel there written (the
 * background where no sample is covered, as crisp__image_clear leaves it, or base's pixel), so
 * the image needs no clearing first. */
/* With S the target's samples per pixel: inlined with S = 1 a constant for one-sample targets
 * (the sample loop and the averages fold away), else with S a variable; the same code. */
static ALWAYS_INLINE void resolve_rows_s(resolve_ctx *c, size_t begin, size_t end, const int S)
{
    const crisp_raster_target *t = c->target;
    crisp_image *img = c->img;
    /* The view direction of a sample (unnormalised: shading normalises): the camera ray's
     * f + ndc_x r + ndc_y u, the basis computed once per frame (raster_view). */
    const crisp_camera *cam = c->cam;
    const double *f = c->view.f, *r = c->view.r, *u = c->view.u, kx = c->view.kx, ky = c->view.ky;
    double off[16][2];
    for (int s = 0; s < S; s++)
        crisp__raster_sample_offset(S, s, off[s]);
    const crisp_scene_face *faces = c->sc->faces;
    for (size_t j = begin + (size_t)c->y0; j < end + (size_t)c->y0; j++) {
        int gj = t->y0 + (int)j; /* the row in the whole image */
        double ny_row[16];       /* per sample: ny of this row */
        for (int s = 0; s < S; s++)
            ny_row[s] = (0.5 * cam->height - gj - off[s][1]) * ky;
        for (int i = c->x0; i < c->x1; i++) {
            size_t px = j * (size_t)t->width + (size_t)i;
            if (c->base && (t->face[px] < 0 || !c->only[t->face[px]])) {
                copy_pixel(c->base, img, px);
                continue;
            }
            int gi = t->x0 + i; /* the pixel's column in the whole image */
            float acc[4] = {0, 0, 0, 0};
            int covered = 0, best = -1;
            double best_iw = 0;
            for (int s = 0; s < S; s++) {
                size_t idx = px * S + s;
                int32_t fc = t->face[idx];
                if (fc < 0) continue;
                covered++;
                if (t->inv_w[idx] > best_iw) best_iw = t->inv_w[idx], best = s;
                double d[3], n[3];
                double nx = (gi + off[s][0] - 0.5 * cam->width) * kx, ny = ny_row[s];
                for (int k = 0; k < 3; k++)
                    d[k] = f[k] + nx * r[k] + ny * u[k];
                const float *a = t->attr + idx * CRISP_RASTER_ATTRS;
                n[0] = a[2], n[1] = a[3], n[2] = a[4];
                float rgba[4];
                crisp__shade_inline(faces[fc].color, n, d, rgba);
                for (int k = 0; k < 3; k++)
                    acc[k] += rgba[k];
            }
            if (!covered) {
                for (int k = 0; k < 4; k++)
                    img->rgba[4 * px + k] = 0;
                img->face[px] = -1;
                img->depth[px] = INFINITY;
                img->uv[2 * px] = img->uv[2 * px + 1] = 0;
                for (int k = 0; k < 3; k++)
                    img->normal[3 * px + k] = 0;
                continue;
            }
            for (int k = 0; k < 3; k++)
                img->rgba[4 * px + k] = acc[k] / (float)covered;
            img->rgba[4 * px + 3] = (float)covered / (float)S;
            size_t idx = px * S + (size_t)best;
            const float *a = t->attr + idx * CRISP_RASTER_ATTRS;
            img->face[px] = t->face[idx];
            img->depth[px] = (float)(1.0 / t->inv_w[idx]);
            img->uv[2 * px] = a[0];
            img->uv[2 * px + 1] = a[1];
            for (int k = 0; k < 3; k++)
                img->normal[3 * px + k] = a[2 + k];
        }
    }
}

/* Pixel i of row p0 / width of a one-sample target without a base image: resolve_rows_s's
 * values bit for bit (the same operations in the same order: d = (f + nx r) + ny u with
 * f + nx r per column from c->col, crisp__shade_inline's arithmetic, the colour as
 * 0 + shade / 1). */
static ALWAYS_INLINE void resolve_pixel1(const resolve_ctx *c, const crisp_raster_target *t,
                                         const crisp_image *img, size_t p0, int i, double ru0,
                                         double ru1, double ru2)
{
    size_t px = p0 + (size_t)i;
    int32_t fc = t->face[px];
    if (fc < 0) {
        img->rgba[4 * px] = img->rgba[4 * px + 1] = img->rgba[4 * px + 2] = 0;
        img->rgba[4 * px + 3] = 0;
        img->face[px] = -1;
        img->depth[px] = INFINITY;
        img->uv[2 * px] = img->uv[2 * px + 1] = 0;
        img->normal[3 * px] = img->normal[3 * px + 1] = img->normal[3 * px + 2] = 0;
        return;
    }
    const float *a = t->attr + px * CRISP_RASTER_ATTRS;
    const double *col = c->col;
    size_t w = (size_t)t->width;
    double d0 = col[i] + ru0, d1 = col[w + i] + ru1, d2 = col[2 * w + i] + ru2;
    double n0 = a[2], n1 = a[3], n2 = a[4];
    double nn = sqrt(n0 * n0 + n1 * n1 + n2 * n2);
    double vv = sqrt(d0 * d0 + d1 * d1 + d2 * d2);
    double cs = nn > 0 && vv > 0 ? fabs(n0 * d0 + n1 * d1 + n2 * d2) / (nn * vv) : 1;
    double k = 0.25 + 0.75 * cs;
    const float *base = c->sc->faces[fc].color;
    img->rgba[4 * px] = 0.0f + (float)(base[0] * k);
    img->rgba[4 * px + 1] = 0.0f + (float)(base[1] * k);
    img->rgba[4 * px + 2] = 0.0f + (float)(base[2] * k);
    img->rgba[4 * px + 3] = 1.0f;
    img->face[px] = fc;
    img->depth[px] = (float)(1.0 / t->inv_w[px]);
    img->uv[2 * px] = a[0], img->uv[2 * px + 1] = a[1];
    img->normal[3 * px] = a[2], img->normal[3 * px + 1] = a[3], img->normal[3 * px + 2] = a[4];
}

/* Row j of a one-sample target without a base image, as resolve_pixel1 on each pixel. */
static void resolve_row1(const resolve_ctx *c, size_t j)
{
    const crisp_raster_target *t = c->target;
    const crisp_image *img = c->img;
    size_t p0 = j * (size_t)t->width;
    const int32_t *restrict face = t->face + p0;
    const double *restrict inv_w = t->inv_w + p0;
    const float *restrict attr = t->attr + p0 * CRISP_RASTER_ATTRS;
    float *restrict rgba = img->rgba + 4 * p0, *restrict depth = img->depth + p0;
    float *restrict normal = img->normal + 3 * p0, *restrict uv = img->uv + 2 * p0;
    int32_t *restrict oface = img->face + p0;
    const double *restrict colx = c->col, *restrict coly = colx + t->width,
                           *restrict colz = coly + t->width;
    const crisp_scene_face *faces = c->sc->faces;
    int gj = t->y0 + (int)j;
    double ny = (0.5 * c->cam->height - gj - 0.5) * c->view.ky;
    const double ru0 = ny * c->view.u[0], ru1 = ny * c->view.u[1], ru2 = ny * c->view.u[2];
    int i = c->x0;
#if defined(__SSE2__)
    /* Two covered pixels at a time: the same IEEE operations on each lane (sqrt, division and
     * the conversions to float are correctly rounded in both forms; fabs clears the sign bit). */
    const __m128d vr0 = _mm_set1_pd(ru0), vr1 = _mm_set1_pd(ru1), vr2 = _mm_set1_pd(ru2);
    const __m128d zero = _mm_setzero_pd(), one = _mm_set1_pd(1.0), sign = _mm_set1_pd(-0.0);
    const __m128d k0 = _mm_set1_pd(0.25), k1 = _mm_set1_pd(0.75);
    for (; i + 1 < c->x1; i += 2) {
        int32_t fa = face[i], fb = face[i + 1];
        if ((fa & fb) < 0) { /* two background pixels */
            __m128 z = _mm_setzero_ps();
            _mm_storeu_ps(rgba + 4 * (size_t)i, z);
            _mm_storeu_ps(rgba + 4 * (size_t)i + 4, z);
            _mm_storeu_ps(normal + 3 * (size_t)i, z);
            _mm_storel_pi((__m64 *)(normal + 3 * (size_t)i + 4), z);
            _mm_storeu_ps(uv + 2 * (size_t)i, z);
            oface[i] = oface[i + 1] = -1;
            depth[i] = depth[i + 1] = INFINITY;
            continue;
        }
        if ((fa | fb) < 0) { /* one background pixel: both one at a time */
            resolve_pixel1(c, t, img, p0, i, ru0, ru1, ru2);
            resolve_pixel1(c, t, img, p0, i + 1, ru0, ru1, ru2);
            continue;
        }
        const float *a = attr + (size_t)i * CRISP_RASTER_ATTRS, *b = a + CRISP_RASTER_ATTRS;
        __m128d d0 = _mm_add_pd(_mm_loadu_pd(colx + i), vr0);
        __m128d d1 = _mm_add_pd(_mm_loadu_pd(coly + i), vr1);
        __m128d d2 = _mm_add_pd(_mm_loadu_pd(colz + i), vr2);
        /* The two samples' attributes: a0..a3, a1..a4, b0..b3, b1..b4 (inside the pair). */
        __m128 fa0 = _mm_loadu_ps(a), fa1 = _mm_loadu_ps(a + 1), fb0 = _mm_loadu_ps(b),
               fb1 = _mm_loadu_ps(b + 1);
        __m128 lo = _mm_unpacklo_ps(fa1, fb1), hi = _mm_unpackhi_ps(fa1, fb1); /* a1 b1 a2 b2 */
        __m128d n0 = _mm_cvtps_pd(_mm_movehl_ps(lo, lo)), n1 = _mm_cvtps_pd(hi),
                n2 = _mm_cvtps_pd(_mm_movehl_ps(hi, hi)); /* exact conversions */
        __m128d nn = _mm_sqrt_pd(
            _mm_add_pd(_mm_add_pd(_mm_mul_pd(n0, n0), _mm_mul_pd(n1, n1)), _mm_mul_pd(n2, n2)));
        __m128d vv = _mm_sqrt_pd(
            _mm_add_pd(_mm_add_pd(_mm_mul_pd(d0, d0), _mm_mul_pd(d1, d1)), _mm_mul_pd(d2, d2)));
        __m128d dot =
            _mm_add_pd(_mm_add_pd(_mm_mul_pd(n0, d0), _mm_mul_pd(n1, d1)), _mm_mul_pd(n2, d2));
        __m128d cs = _mm_div_pd(_mm_andnot_pd(sign, dot), _mm_mul_pd(nn, vv));
        __m128d ok = _mm_and_pd(_mm_cmpgt_pd(nn, zero), _mm_cmpgt_pd(vv, zero));
        cs = _mm_or_pd(_mm_and_pd(ok, cs), _mm_andnot_pd(ok, one));
        __m128d k = _mm_add_pd(k0, _mm_mul_pd(k1, cs));
        const float *ca = faces[fa].color, *cb = faces[fb].color;
        __m128 zf = _mm_setzero_ps();
        __m128 cr = _mm_add_ps(zf, _mm_cvtpd_ps(_mm_mul_pd(_mm_set_pd(cb[0], ca[0]), k)));
        __m128 cg = _mm_add_ps(zf, _mm_cvtpd_ps(_mm_mul_pd(_mm_set_pd(cb[1], ca[1]), k)));
        __m128 cbl = _mm_add_ps(zf, _mm_cvtpd_ps(_mm_mul_pd(_mm_set_pd(cb[2], ca[2]), k)));
        __m128 rg = _mm_unpacklo_ps(cr, cg);                        /* ra ga rb gb */
        __m128 b1 = _mm_unpacklo_ps(cbl, _mm_set1_ps(1.0f));        /* ba 1 bb 1 */
        _mm_storeu_ps(rgba + 4 * (size_t)i, _mm_movelh_ps(rg, b1)); /* ra ga ba 1 */
        _mm_storeu_ps(rgba + 4 * (size_t)i + 4, _mm_movehl_ps(b1, rg));
        __m128 dp = _mm_cvtpd_ps(_mm_div_pd(one, _mm_loadu_pd(inv_w + i)));
        _mm_storel_pi((__m64 *)(depth + i), dp);
        oface[i] = fa, oface[i + 1] = fb;
        _mm_storeu_ps(uv + 2 * (size_t)i, _mm_movelh_ps(fa0, fb0)); /* a0 a1 b0 b1 */
        /* a2 a3 a4 (a4), then a4 b2 b3 b4 over the last two: the pair's six floats. */
        __m128 t4 = _mm_shuffle_ps(fa1, fb1, _MM_SHUFFLE(1, 1, 3, 3)); /* a4 a4 b2 b2 */
        _mm_storeu_ps(normal + 3 * (size_t)i, _mm_shuffle_ps(fa1, fa1, _MM_SHUFFLE(3, 3, 2, 1)));
        _mm_storeu_ps(normal + 3 * (size_t)i + 2, _mm_shuffle_ps(t4, fb1, _MM_SHUFFLE(3, 2, 2, 0)));
    }
#endif
    for (; i < c->x1; i++)
        resolve_pixel1(c, t, img, p0, i, ru0, ru1, ru2);
}

/* Marks in seen (fc faces) each face of pixels face[i0 .. i1) that differs from the pixel before
 * it (last: the face of the pixel before i0); returns the face of pixel i1 - 1 (last if none). */
static inline int32_t mark_faces(const int32_t *face, int i0, int i1, int32_t last, uint8_t *seen,
                                 uint32_t fc)
{
    for (int i = i0; i < i1; i++)
        if (face[i] != last) {
            last = face[i];
            if (last >= 0 && (uint32_t)last < fc) seen[last] = 1;
        }
    return last;
}

#if defined(__GNUC__) && defined(__x86_64__) && defined(__SSE2__)
#define HAVE_AVX_RESOLVE 1
/* The pixels [i0, i1) of row p0 / width one at a time (resolve_pixel1), their faces marked in
 * seen (NULL: not wanted) by mark_faces. */
static ALWAYS_INLINE void resolve_pixels1(const resolve_ctx *c, const crisp_raster_target *t,
                                          const crisp_image *img, size_t p0, int i0, int i1,
                                          double ru0, double ru1, double ru2, uint8_t *seen,
                                          uint32_t fc)
{
    for (int i = i0; i < i1; i++)
        resolve_pixel1(c, t, img, p0, i, ru0, ru1, ru2);
    if (seen) mark_faces(t->face + p0, i0, i1, -1, seen, fc);
}

/* resolve_row1 four covered pixels at a time with AVX where the processor has it (chosen at run
 * time): the same IEEE operations on each lane as resolve_pixel1 (sqrt, division and the
 * conversions to float are correctly rounded in every form; no fused multiply-add), so the same
 * values bit for bit (test_resolve compares it with the scalar resolve). Groups of four with a
 * background pixel: all background stored at once, mixed ones pixel by pixel. The faces'
 * colours are kept from the last group while its four pixels show the same face. Marks in seen
 * (NULL: not wanted) the faces the row shows, as mark_faces would: a group of the kept face marks
 * nothing new. */
__attribute__((target("avx"))) static void resolve_row1_avx(const resolve_ctx *c, size_t j,
                                                            uint8_t *seen, uint32_t fc)
{
    const crisp_raster_target *t = c->target;
    const crisp_image *img = c->img;
    size_t p0 = j * (size_t)t->width;
    const int32_t *restrict face = t->face + p0;
    const double *restrict inv_w = t->inv_w + p0;
    const float *restrict attr = t->attr + p0 * CRISP_RASTER_ATTRS;
    float *restrict rgba = img->rgba + 4 * p0, *restrict depth = img->depth + p0;
    float *restrict normal = img->normal + 3 * p0, *restrict uv = img->uv + 2 * p0;
    int32_t *restrict oface = img->face + p0;
    const double *restrict colx = c->col, *restrict coly = colx + t->width,
                           *restrict colz = coly + t->width;
    const crisp_scene_face *faces = c->sc->faces;
    int gj = t->y0 + (int)j;
    double ny = (0.5 * c->cam->height - gj - 0.5) * c->view.ky;
    const double ru0 = ny * c->view.u[0], ru1 = ny * c->view.u[1], ru2 = ny * c->view.u[2];
    const __m256d vr0 = _mm256_set1_pd(ru0), vr1 = _mm256_set1_pd(ru1), vr2 = _mm256_set1_pd(ru2);
    const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0),
                  sign = _mm256_set1_pd(-0.0);
    const __m256d k0 = _mm256_set1_pd(0.25), k1 = _mm256_set1_pd(0.75);
    int32_t kept = -1; /* the face whose colours base holds (-1: none) */
    __m128i kept4 = _mm_set1_epi32(-1);
    __m256d base[3] = {zero, zero, zero};
    int i = c->x0;
    const int x1 = c->x1;
    for (; i + 3 < x1; i += 4) {
        const __m128i fv = _mm_loadu_si128((const __m128i *)(face + i));
        int neg = _mm_movemask_ps(_mm_castsi128_ps(fv));
        if (neg == 0xf) { /* four background pixels */
            __m128 z = _mm_setzero_ps();
            for (int q = 0; q < 4; q++)
                _mm_storeu_ps(rgba + 4 * (size_t)(i + q), z);
            for (int q = 0; q < 3; q++)
                _mm_storeu_ps(normal + 3 * (size_t)i + 4 * q, z);
            _mm_storeu_ps(uv + 2 * (size_t)i, z);
            _mm_storeu_ps(uv + 2 * (size_t)i + 4, z);
            _mm_storeu_si128((__m128i *)(oface + i), _mm_set1_epi32(-1));
            _mm_storeu_ps(depth + i, _mm_set1_ps(INFINITY));
            continue;
        }
        if (neg) {
            resolve_pixels1(c, t, img, p0, i, i + 4, ru0, ru1, ru2, seen, fc);
            continue;
        }
        const float *a = attr + (size_t)i * CRISP_RASTER_ATTRS; /* pixel q's at a + 5 q */
        __m256d d0 = _mm256_add_pd(_mm256_loadu_pd(colx + i), vr0);
        __m256d d1 = _mm256_add_pd(_mm256_loadu_pd(coly + i), vr1);
        __m256d d2 = _mm256_add_pd(_mm256_loadu_pd(colz + i), vr2);
        /* The four normals: attributes 1..4 of each pixel (inside its own five), transposed,
         * then widened (exact conversions). */
        __m128 r0 = _mm_loadu_ps(a + 1), r1 = _mm_loadu_ps(a + 6), r2 = _mm_loadu_ps(a + 11),
               r3 = _mm_loadu_ps(a + 16);
        _MM_TRANSPOSE4_PS(r0, r1, r2, r3); /* r1, r2, r3: the pixels' nx, ny, nz */
        __m256d n0 = _mm256_cvtps_pd(r1), n1 = _mm256_cvtps_pd(r2), n2 = _mm256_cvtps_pd(r3);
        __m256d nn = _mm256_sqrt_pd(_mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(n0, n0), _mm256_mul_pd(n1, n1)), _mm256_mul_pd(n2, n2)));
        __m256d vv = _mm256_sqrt_pd(_mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(d0, d0), _mm256_mul_pd(d1, d1)), _mm256_mul_pd(d2, d2)));
        __m256d dot = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(n0, d0), _mm256_mul_pd(n1, d1)),
                                    _mm256_mul_pd(n2, d2));
        __m256d cs = _mm256_div_pd(_mm256_andnot_pd(sign, dot), _mm256_mul_pd(nn, vv));
        __m256d ok =
            _mm256_and_pd(_mm256_cmp_pd(nn, zero, _CMP_GT_OQ), _mm256_cmp_pd(vv, zero, _CMP_GT_OQ));
        cs = _mm256_or_pd(_mm256_and_pd(ok, cs), _mm256_andnot_pd(ok, one));
        __m256d k = _mm256_add_pd(k0, _mm256_mul_pd(k1, cs));
        /* The faces' colours per lane: the kept ones, one face's broadcast, or one by one. */
        if (_mm_movemask_epi8(_mm_cmpeq_epi32(fv, kept4)) != 0xffff) {
            int32_t f0 = face[i], f1 = face[i + 1], f2 = face[i + 2], f3 = face[i + 3];
            const float *c0 = faces[f0].color;
            if (f0 == f1 && f0 == f2 && f0 == f3) {
                for (int q = 0; q < 3; q++)
                    base[q] = _mm256_set1_pd(c0[q]);
                kept = f0;
                if (seen && (uint32_t)f0 < fc) seen[f0] = 1;
            } else {
                const float *c1 = faces[f1].color, *c2 = faces[f2].color, *c3 = faces[f3].color;
                for (int q = 0; q < 3; q++)
                    base[q] = _mm256_set_pd(c3[q], c2[q], c1[q], c0[q]);
                kept = -1;
                if (seen) mark_faces(face, i, i + 4, -1, seen, fc);
            }
            kept4 = _mm_set1_epi32(kept);
        }
        __m128 zf = _mm_setzero_ps();
        __m128 cr = _mm_add_ps(zf, _mm256_cvtpd_ps(_mm256_mul_pd(base[0], k)));
        __m128 cg = _mm_add_ps(zf, _mm256_cvtpd_ps(_mm256_mul_pd(base[1], k)));
        __m128 cb = _mm_add_ps(zf, _mm256_cvtpd_ps(_mm256_mul_pd(base[2], k)));
        __m128 co = _mm_set1_ps(1.0f);
        _MM_TRANSPOSE4_PS(cr, cg, cb, co); /* pixel q's r g b 1 */
        _mm_storeu_ps(rgba + 4 * (size_t)i, cr);
        _mm_storeu_ps(rgba + 4 * (size_t)i + 4, cg);
        _mm_storeu_ps(rgba + 4 * (size_t)i + 8, cb);
        _mm_storeu_ps(rgba + 4 * (size_t)i + 12, co);
        _mm_storeu_ps(depth + i, _mm256_cvtpd_ps(_mm256_div_pd(one, _mm256_loadu_pd(inv_w + i))));
        _mm_storeu_si128((__m128i *)(oface + i), fv);
        for (int h = 0; h < 4; h += 2) { /* a pair's (u, v) and normals, as resolve_row1 */
            const float *pa = a + 5 * h, *pb = pa + CRISP_RASTER_ATTRS;
            size_t ii = (size_t)(i + h);
            __m128 fa0 = _mm_loadu_ps(pa), fa1 = _mm_loadu_ps(pa + 1), fb0 = _mm_loadu_ps(pb),
                   fb1 = _mm_loadu_ps(pb + 1);
            _mm_storeu_ps(uv + 2 * ii, _mm_movelh_ps(fa0, fb0));
            __m128 t4 = _mm_shuffle_ps(fa1, fb1, _MM_SHUFFLE(1, 1, 3, 3));
            _mm_storeu_ps(normal + 3 * ii, _mm_shuffle_ps(fa1, fa1, _MM_SHUFFLE(3, 3, 2, 1)));
            _mm_storeu_ps(normal + 3 * ii + 2, _mm_shuffle_ps(t4, fb1, _MM_SHUFFLE(3, 2, 2, 0)));
        }
    }
    resolve_pixels1(c, t, img, p0, i, x1, ru0, ru1, ru2, seen, fc);
}
#if defined(__GNUC__) && (defined(__clang__) || __GNUC__ >= 7)
#define HAVE_AVX512_RESOLVE 1
/* resolve_row1 eight covered pixels at a time with AVX-512 (F, DQ, VL; chosen at run time):
 * the same IEEE operations on each lane as resolve_pixel1, as resolve_row1_avx (no fused
 * multiply-add: the library is built as ISO C, -ffp-contract=off, and test_resolve compares
 * every path with the scalar one). The pixels' attributes (five floats each) are transposed by
 * permutes; the faces' colours are kept from the last group while its eight pixels show the
 * same face (the usual case on a close view). Groups of eight with a background pixel: all
 * background stored at once, mixed ones pixel by pixel, as the row's last pixels. Marks in seen
 * (NULL: not wanted) the faces the row shows, as mark_faces would: a group of the kept face
 * marks nothing new. */
__attribute__((target("avx512f,avx512dq,avx512vl"))) static void
resolve_row1_avx512(const resolve_ctx *c, size_t j, uint8_t *seen, uint32_t fc)
{
    const crisp_raster_target *t = c->target;
    const crisp_image *img = c->img;
    size_t p0 = j * (size_t)t->width;
    const int32_t *restrict face = t->face + p0;
    const double *restrict inv_w = t->inv_w + p0;
    const float *restrict attr = t->attr + p0 * CRISP_RASTER_ATTRS;
    float *restrict rgba = img->rgba + 4 * p0, *restrict depth = img->depth + p0;
    float *restrict normal = img->normal + 3 * p0, *restrict uv = img->uv + 2 * p0;
    int32_t *restrict oface = img->face + p0;
    const double *restrict colx = c->col, *restrict coly = colx + t->width,
                           *restrict colz = coly + t->width;
    const crisp_scene_face *faces = c->sc->faces;
    int gj = t->y0 + (int)j;
    double ny = (0.5 * c->cam->height - gj - 0.5) * c->view.ky;
    const double ru0 = ny * c->view.u[0], ru1 = ny * c->view.u[1], ru2 = ny * c->view.u[2];
    const __m512d vr0 = _mm512_set1_pd(ru0), vr1 = _mm512_set1_pd(ru1), vr2 = _mm512_set1_pd(ru2);
    const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0),
                  sign = _mm512_set1_pd(-0.0);
    const __m512d k0 = _mm512_set1_pd(0.25), k1 = _mm512_set1_pd(0.75);
    /* Attribute a of pixel q is float 5 q + a of the group's 40: A0 holds floats 0-15, A1 16-31,
     * A2 24-39. (u, v) of the eight pixels from A0, A1 (floats 35, 36 from A2); the normals'
     * first 16 floats from A0, A1, their last 8 from A2; then each normal component's eight. */
    const __m512i i_uv =
        _mm512_setr_epi32(0, 1, 5, 6, 10, 11, 15, 16, 20, 21, 25, 26, 30, 31, 0, 0);
    const __m512i i_uv2 = _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 11, 12);
    const __m512i i_n0 =
        _mm512_setr_epi32(2, 3, 4, 7, 8, 9, 12, 13, 14, 17, 18, 19, 22, 23, 24, 27);
    const __m512i i_n1 = _mm512_setr_epi32(4, 5, 8, 9, 10, 13, 14, 15, 0, 0, 0, 0, 0, 0, 0, 0);
    const __m512i i_nx = _mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 0, 0, 0, 0, 0, 0, 0, 0);
    const __m512i i_ny = _mm512_setr_epi32(1, 4, 7, 10, 13, 16, 19, 22, 0, 0, 0, 0, 0, 0, 0, 0);
    const __m512i i_nz = _mm512_setr_epi32(2, 5, 8, 11, 14, 17, 20, 23, 0, 0, 0, 0, 0, 0, 0, 0);
    /* r g b 1 of pixels 0-3 from [r0..r7 g0..g7] and [b0..b7 1 ... 1]; pixels 4-7: + 4. */
    const __m512i i_c0 =
        _mm512_setr_epi32(0, 8, 16, 24, 1, 9, 17, 25, 2, 10, 18, 26, 3, 11, 19, 27);
    const __m512i i_c1 = _mm512_add_epi32(i_c0, _mm512_set1_epi32(4));
    const __m512 ones = _mm512_set1_ps(1.0f);
    const __m256 zf = _mm256_setzero_ps();
    /* The colour stride in floats (the scene's faces are an array of structs): a gather's
     * indices; kept only while the face count keeps them in 32 bits. */
    const int stride = (int)(sizeof *faces / sizeof(float));
    const int gather =
        sizeof *faces % sizeof(float) == 0 && c->sc->face_count <= (uint32_t)(INT32_MAX / stride);
    int32_t kept = -1; /* the face whose colours base holds (-1: none) */
    __m512d base0 = zero, base1 = zero, base2 = zero;
    int i = c->x0;
    const int x1 = c->x1;
    for (; i + 7 < x1; i += 8) {
        const __m256i fv = _mm256_loadu_si256((const __m256i *)(face + i));
        int neg = _mm256_movemask_ps(_mm256_castsi256_ps(fv));
        if (neg == 0xff) { /* eight background pixels */
            const __m512 z = _mm512_setzero_ps();
            _mm512_storeu_ps(rgba + 4 * (size_t)i, z);
            _mm512_storeu_ps(rgba + 4 * (size_t)i + 16, z);
            _mm512_storeu_ps(normal + 3 * (size_t)i, z);
            _mm256_storeu_ps(normal + 3 * (size_t)i + 16, _mm256_setzero_ps());
            _mm512_storeu_ps(uv + 2 * (size_t)i, z);
            _mm256_storeu_si256((__m256i *)(oface + i), _mm256_set1_epi32(-1));
            _mm256_storeu_ps(depth + i, _mm256_set1_ps(INFINITY));
            continue;
        }
        if (neg) {
            resolve_pixels1(c, t, img, p0, i, i + 8, ru0, ru1, ru2, seen, fc);
            continue;
        }
        const float *a = attr + (size_t)i * CRISP_RASTER_ATTRS;
        const __m512 A0 = _mm512_loadu_ps(a), A1 = _mm512_loadu_ps(a + 16),
                     A2 = _mm512_loadu_ps(a + 24);
        __m512 uvs = _mm512_permutex2var_ps(A0, i_uv, A1);
        uvs = _mm512_mask_permutexvar_ps(uvs, 0xc000, i_uv2, A2);
        const __m512 N0 = _mm512_permutex2var_ps(A0, i_n0, A1);
        const __m512 N1 = _mm512_permutexvar_ps(i_n1, A2);
        __m512d n0 = _mm512_cvtps_pd(_mm512_castps512_ps256(_mm512_permutex2var_ps(N0, i_nx, N1)));
        __m512d n1 = _mm512_cvtps_pd(_mm512_castps512_ps256(_mm512_permutex2var_ps(N0, i_ny, N1)));
        __m512d n2 = _mm512_cvtps_pd(_mm512_castps512_ps256(_mm512_permutex2var_ps(N0, i_nz, N1)));
        __m512d d0 = _mm512_add_pd(_mm512_loadu_pd(colx + i), vr0);
        __m512d d1 = _mm512_add_pd(_mm512_loadu_pd(coly + i), vr1);
        __m512d d2 = _mm512_add_pd(_mm512_loadu_pd(colz + i), vr2);
        __m512d nn = _mm512_sqrt_pd(_mm512_add_pd(
            _mm512_add_pd(_mm512_mul_pd(n0, n0), _mm512_mul_pd(n1, n1)), _mm512_mul_pd(n2, n2)));
        __m512d vv = _mm512_sqrt_pd(_mm512_add_pd(
            _mm512_add_pd(_mm512_mul_pd(d0, d0), _mm512_mul_pd(d1, d1)), _mm512_mul_pd(d2, d2)));
        __m512d dot = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(n0, d0), _mm512_mul_pd(n1, d1)),
                                    _mm512_mul_pd(n2, d2));
        __m512d cs = _mm512_div_pd(_mm512_andnot_pd(sign, dot), _mm512_mul_pd(nn, vv));
        __mmask8 ok =
            _mm512_mask_cmp_pd_mask(_mm512_cmp_pd_mask(nn, zero, _CMP_GT_OQ), vv, zero, _CMP_GT_OQ);
        cs = _mm512_mask_blend_pd(ok, one, cs);
        __m512d k = _mm512_add_pd(k0, _mm512_mul_pd(k1, cs));
        /* The faces' colours per lane: the kept ones, one face's broadcast, or gathered. */
        if (_mm256_cmpeq_epi32_mask(fv, _mm256_set1_epi32(kept)) != 0xff) {
            int32_t f0 = face[i];
            if (_mm256_cmpeq_epi32_mask(fv, _mm256_set1_epi32(f0)) == 0xff) {
                const float *c0 = faces[f0].color;
                base0 = _mm512_set1_pd(c0[0]);
                base1 = _mm512_set1_pd(c0[1]);
                base2 = _mm512_set1_pd(c0[2]);
                kept = f0;
                if (seen && (uint32_t)f0 < fc) seen[f0] = 1;
            } else {
                if (gather) {
                    __m256i ix = _mm256_mullo_epi32(fv, _mm256_set1_epi32(stride));
                    base0 = _mm512_cvtps_pd(_mm256_i32gather_ps(faces->color, ix, 4));
                    base1 = _mm512_cvtps_pd(_mm256_i32gather_ps(faces->color + 1, ix, 4));
                    base2 = _mm512_cvtps_pd(_mm256_i32gather_ps(faces->color + 2, ix, 4));
                } else {
                    double b[3][8];
                    for (int l = 0; l < 8; l++)
                        for (int q = 0; q < 3; q++)
                            b[q][l] = faces[face[i + l]].color[q];
                    base0 = _mm512_loadu_pd(b[0]);
                    base1 = _mm512_loadu_pd(b[1]);
                    base2 = _mm512_loadu_pd(b[2]);
                }
                kept = -1;
                if (seen) mark_faces(face, i, i + 8, -1, seen, fc);
            }
        }
        __m256 cr = _mm256_add_ps(zf, _mm512_cvtpd_ps(_mm512_mul_pd(base0, k)));
        __m256 cg = _mm256_add_ps(zf, _mm512_cvtpd_ps(_mm512_mul_pd(base1, k)));
        __m256 cb = _mm256_add_ps(zf, _mm512_cvtpd_ps(_mm512_mul_pd(base2, k)));
        __m512 rg = _mm512_insertf32x8(_mm512_castps256_ps512(cr), cg, 1);
        __m512 b1 = _mm512_insertf32x8(ones, cb, 0);
        _mm512_storeu_ps(rgba + 4 * (size_t)i, _mm512_permutex2var_ps(rg, i_c0, b1));
        _mm512_storeu_ps(rgba + 4 * (size_t)i + 16, _mm512_permutex2var_ps(rg, i_c1, b1));
        _mm256_storeu_ps(depth + i,
                         _mm512_cvtpd_ps(_mm512_div_pd(one, _mm512_loadu_pd(inv_w + i))));
        _mm256_storeu_si256((__m256i *)(oface + i), fv);
        _mm512_storeu_ps(uv + 2 * (size_t)i, uvs);
        _mm512_storeu_ps(normal + 3 * (size_t)i, N0);
        _mm256_storeu_ps(normal + 3 * (size_t)i + 16, _mm512_castps512_ps256(N1));
    }
    resolve_pixels1(c, t, img, p0, i, x1, ru0, ru1, ru2, seen, fc);
}
#else
#define HAVE_AVX512_RESOLVE 0
#endif
#else
#define HAVE_AVX_RESOLVE 0
#define HAVE_AVX512_RESOLVE 0
#endif

/* Rows y0 + [begin, end) by the context's path; returns 1 when it marked the faces the rows show
 * in seen (fc faces; NULL: not wanted) itself, else 0. */
static int resolve_rows(resolve_ctx *c, size_t begin, size_t end, uint8_t *seen, uint32_t fc)
{
    (void)seen, (void)fc;
    size_t y0 = (size_t)c->y0;
    switch (c->path) {
#if HAVE_AVX512_RESOLVE
    case RESOLVE_AVX512:
        for (size_t j = begin + y0; j < end + y0; j++)
            resolve_row1_avx512(c, j, seen, fc);
        return 1;
#endif
#if HAVE_AVX_RESOLVE
    case RESOLVE_AVX:
        for (size_t j = begin + y0; j < end + y0; j++)
            resolve_row1_avx(c, j, seen, fc);
        return 1;
#endif
    case RESOLVE_ROW1:
        for (size_t j = begin + y0; j < end + y0; j++)
            resolve_row1(c, j);
        return 0;
    default:
        if (c->target->samples == 1)
            resolve_rows_s(c, begin, end, 1);
        else
            resolve_rows_s(c, begin, end, c->target->samples);
        return 0;
    }
}

/* The fastest one-sample resolve path the processor has. */
static int resolve_best(void)
{
    int path = RESOLVE_ROW1;
#if HAVE_AVX_RESOLVE
    if (__builtin_cpu_supports("avx")) path = RESOLVE_AVX;
#endif
#if HAVE_AVX512_RESOLVE
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
        __builtin_cpu_supports("avx512vl"))
        path = RESOLVE_AVX512;
#endif
    return path;
}

/* The resolve path for target t (over base: NULL for none): the fastest the processor has that
 * crisp__renderer_set_resolve allows. */
static int resolve_path(const crisp_renderer *r, const crisp_raster_target *t,
                        const crisp_image *base)
{
    if (r->no_vectors || t->samples != 1 || base) return RESOLVE_SCALAR;
    int path = resolve_best();
    return r->resolve_cap && path > r->resolve_cap - 1 ? r->resolve_cap - 1 : path;
}

int crisp__renderer_set_resolve(crisp_renderer *r, int path)
{
    r->resolve_cap = path < 0 ? 0 : path + 1;
    return resolve_best();
}

/* The rows in groups shared out as the rasterizer's tiles (crisp_raster_share): a worker resolves
 * the band of rows whose tiles it mostly drew, their samples still in its caches, and two workers
 * seldom read and write neighbouring rows at once. */
static void resolve_groups(void *vctx, size_t begin, size_t end, int worker)
{
    (void)begin, (void)end;
    resolve_ctx *c = vctx;
    int k = 0;
    size_t g;
    uint32_t fc = c->sc->face_count;
    uint8_t *seen = c->seen ? c->seen + (size_t)worker * fc : NULL;
    while (crisp__raster_share_next(&c->share, worker, &k, &g)) {
        size_t j0 = g * RESOLVE_ROWS,
               j1 = j0 + RESOLVE_ROWS < c->rows ? j0 + RESOLVE_ROWS : c->rows;
        if (resolve_rows(c, j0, j1, seen, fc)) continue; /* (the seen faces marked) */
        for (size_t j = j0 + (size_t)c->y0; seen && j < j1 + (size_t)c->y0; j++) {
            const int32_t *face = c->img->face + j * (size_t)c->img->width;
            int32_t last = -1; /* neighbouring pixels mostly show the same face */
            int i = c->x0;
#if defined(__SSE2__)
            for (; i + 7 < c->x1; i += 8) { /* eight pixels of the last face: nothing to mark */
                const __m128i l4 = _mm_set1_epi32(last);
                __m128i e = _mm_and_si128(
                    _mm_cmpeq_epi32(_mm_loadu_si128((const __m128i *)(face + i)), l4),
                    _mm_cmpeq_epi32(_mm_loadu_si128((const __m128i *)(face + i + 4)), l4));
                if (_mm_movemask_epi8(e) != 0xffff)
                    last = mark_faces(face, i, i + 8, last, seen, fc);
            }
#endif
            mark_faces(face, i, c->x1, last, seen, fc); /* (the row's last pixels) */
        }
    }
}

/* Resolves the rectangle rect (x0, y0, x1, y1) of target tg into img by the given path (with a
 * base image: only the faces of only drawn, base's pixels elsewhere); with seen, lists the faces
 * the resolved pixels show in r->seen_list (r->seen_count 0 without). */
static crisp_status resolve_image(crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cam,
                                  const crisp_raster_view *view, const crisp_raster_target *tg,
                                  const int rect[4], const uint8_t *only, const crisp_image *base,
                                  int seen, int path, crisp_image *img)
{
    crisp_status st;
    resolve_ctx rc = {.r = r,
                      .sc = sc,
                      .cam = cam,
                      .view = *view,
                      .img = img,
                      .target = tg,
                      .x0 = rect[0],
                      .x1 = rect[2],
                      .y0 = rect[1],
                      .only = only,
                      .base = base,
                      .path = path};
    /* The view direction's column part, f + nx r, once per column (resolve_row1). */
    if ((st = crisp_grow((void **)&r->col, &r->col_cap, 3 * (size_t)tg->width, sizeof *r->col)))
        return st;
    for (int i = 0; i < tg->width; i++) {
        double nx = (tg->x0 + i + 0.5 - 0.5 * cam->width) * view->kx;
        for (int k = 0; k < 3; k++)
            r->col[(size_t)k * tg->width + i] = view->f[k] + nx * view->r[k];
    }
    rc.col = r->col;
    rc.rows = (size_t)(rect[3] - rect[1]);
    uint32_t fc = sc->face_count;
    r->seen_count = 0;
    if (seen) {
        if ((st = crisp_grow((void **)&r->seen_marks, &r->seen_marks_cap,
                             (size_t)r->workers * (fc ? fc : 1), 1)) ||
            (st = crisp_grow((void **)&r->seen_list, &r->seen_list_cap, fc ? fc : 1,
                             sizeof *r->seen_list)))
            return st;
        memset(r->seen_marks, 0, (size_t)r->workers * fc);
        rc.seen = r->seen_marks;
    }
    crisp__raster_share_init(&rc.share, (rc.rows + RESOLVE_ROWS - 1) / RESOLVE_ROWS, r->workers);
    crisp_pool_parallel_for(r->pool, (size_t)rc.share.ranges, 1, resolve_groups, &rc);
    if (seen) {
        size_t n = 0;
        for (uint32_t f = 0; f < fc; f++) {
            uint8_t any = 0;
            for (int w = 0; w < r->workers; w++)
                any |= r->seen_marks[(size_t)w * fc + f];
            if (any) r->seen_list[n++] = (int32_t)f;
        }
        r->seen_count = n;
    }
    return CRISP_OK;
}

crisp_status crisp__renderer_resolve(crisp_renderer *r, const crisp_scene *sc,
                                     const crisp_camera *cam, const crisp_raster_target *t,
                                     const int rect[4], int path, int seen, crisp_image *img)
{
    crisp_raster_view view;
    raster_view(cam, &view);
    if (path < 0 || path > resolve_best()) path = resolve_best();
    if (t->samples != 1) path = RESOLVE_SCALAR;
    return resolve_image(r, sc, cam, &view, t, rect, NULL, NULL, seen, path, img);
}

void crisp__renderer_mesh(const crisp_renderer *r, const crisp_raster_vertex **verts,
                          size_t *vert_count, const crisp_raster_tri **tris, size_t *tri_count)
{
    *verts = r->verts;
    *tris = r->tris;
    *vert_count = r->vert_count;
    *tri_count = r->tri_count;
}

void crisp__renderer_seen(const crisp_renderer *r, const int32_t **faces, size_t *count)
{
    *faces = r->seen_list;
    *count = r->seen_count;
}

const crisp_raster_target *crisp__renderer_target(const crisp_renderer *r)
{
    return &r->target;
}

void crisp__renderer_set_vectors(crisp_renderer *r, int on)
{
    r->no_vectors = !on;
    crisp__raster_set_vectors(r->raster, on);
}

/* A screen box widened by 2 px, clipped to the image: x0, y0, x1, y1 (empty: all 0). */
static void box_rect(const double lo[2], const double hi[2], int width, int height, int dest[4])
{
    double x0 = floor(lo[0]) - 2, y0 = floor(lo[1]) - 2, x1 = ceil(hi[0]) + 3, y1 = ceil(hi[1]) + 3;
    dest[0] = x0 > 0 ? (x0 < width ? (int)x0 : width) : 0;
    dest[1] = y0 > 0 ? (y0 < height ? (int)y0 : height) : 0;
    dest[2] = x1 > 0 ? (x1 < width ? (int)x1 : width) : 0;
    dest[3] = y1 > 0 ? (y1 < height ? (int)y1 : height) : 0;
    if (dest[0] >= dest[2] || dest[1] >= dest[3]) dest[0] = dest[2] = dest[1] = dest[3] = 0;
}

/* The region of the image that the drawn faces can reach: the union of their leaves' screen
 * boxes (the control-point hulls find_empty_leaves took) and of their ribbon quads, widened by
 * 2 px and clipped to the image (x0, y0, x1, y1; empty when x0 >= x1); and the ribbons' part of
 * it (where the ribbons' depth slack is needed). */
static void faces_region(const crisp_renderer *r, const crisp_frame_plan *plan, const uint8_t *only,
                         int dest[4], int ribbons[4])
{
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    double rlo[2] = {INFINITY, INFINITY}, rhi[2] = {-INFINITY, -INFINITY};
    for (uint32_t f = 0; f < plan->face_count; f++) {
        if (!only[f]) continue;
        const crisp_plan_face *pf = &plan->faces[f];
        for (uint32_t j = pf->first_leaf; j < pf->first_leaf + pf->leaf_count; j++) {
            const double *b = r->hull[j];
            lo[0] = fmin(lo[0], b[0]), lo[1] = fmin(lo[1], b[1]);
            hi[0] = fmax(hi[0], b[2]), hi[1] = fmax(hi[1], b[3]);
        }
        for (uint32_t q = pf->first_ribbon; q < pf->first_ribbon + pf->ribbon_count; q++) {
            const crisp_plan_ribbon_vertex *v = plan->ribbon_vertices + 4 * (size_t)q;
            if (v[0].clip[3] < 0 || v[1].clip[3] < 0 || v[2].clip[3] < 0 || v[3].clip[3] < 0)
                continue; /* a quad not drawn */
            for (int k = 0; k < 4; k++) {
                double px[2];
                crisp__clip_px(v[k].clip, plan->width, plan->height, px);
                double x = px[0], y = px[1];
                if (!(v[k].clip[3] > 0) || !isfinite(x) || !isfinite(y)) {
                    x = -INFINITY, y = -INFINITY; /* through the eye plane: anywhere */
                    rhi[0] = rhi[1] = INFINITY;
                }
                rlo[0] = fmin(rlo[0], x), rlo[1] = fmin(rlo[1], y);
                rhi[0] = fmax(rhi[0], x), rhi[1] = fmax(rhi[1], y);
            }
        }
    }
    /* Faces drawn as splats: their squares (the plan's rule in float, as the draw). */
    for (uint32_t q = 0; q < plan->splat_range_count; q++) {
        const crisp_plan_splat_range *rg = &plan->splat_ranges[q];
        if (!rg->count || !only[rg->face]) continue;
        for (uint32_t k = 0; k < rg->count; k++) {
            const crisp_plan_splat *sp = &plan->splats[rg->first + k];
            const float *o = plan->splat_clip_origin + 4 * (size_t)rg->face, *m = plan->view_proj_f;
            float c[4];
            for (int a = 0; a < 4; a++)
                c[a] = o[a] + m[a] * sp->p[0] + m[a + 4] * sp->p[1] + m[a + 8] * sp->p[2];
            if (!(c[3] > 0)) continue;
            double h = plan->splat_half_px, x = ((double)c[0] / c[3] + 1) * 0.5 * plan->width,
                   y = (1 - (double)c[1] / c[3]) * 0.5 * plan->height;
            lo[0] = fmin(lo[0], x - h), lo[1] = fmin(lo[1], y - h);
            hi[0] = fmax(hi[0], x + h), hi[1] = fmax(hi[1], y + h);
        }
    }
    int leaves[4];
    box_rect(lo, hi, plan->width, plan->height, leaves);
    box_rect(rlo, rhi, plan->width, plan->height, ribbons);
    if (leaves[0] >= leaves[2]) {
        memcpy(dest, ribbons, 4 * sizeof *dest);
    } else if (ribbons[0] >= ribbons[2]) {
        memcpy(dest, leaves, 4 * sizeof *dest);
    } else {
        for (int k = 0; k < 2; k++) {
            dest[k] = leaves[k] < ribbons[k] ? leaves[k] : ribbons[k];
            dest[k + 2] = leaves[k + 2] > ribbons[k + 2] ? leaves[k + 2] : ribbons[k + 2];
        }
    }
}

/* Set the target over rectangle rc (x0, y0, x1, y1) from the image's pixels (one sample each):
 * 1/W from the depth, (u, v) and normal as attributes, the face; or empty (base NULL). */
static void load_rect(crisp_raster_target *t, const crisp_image *base, const int rc[4])
{
    for (int j = rc[1]; j < rc[3]; j++)
        for (int i = rc[0]; i < rc[2]; i++) {
            size_t px = (size_t)j * t->width + (size_t)i;
            float *a = t->attr + px * CRISP_RASTER_ATTRS;
            if (!base || base->face[px] < 0 || !(base->depth[px] > 0)) {
                t->inv_w[px] = 0;
                t->face[px] = -1;
                memset(a, 0, CRISP_RASTER_ATTRS * sizeof *a);
                continue;
            }
            t->inv_w[px] = 1.0 / base->depth[px];
            t->face[px] = base->face[px];
            a[0] = base->uv[2 * px], a[1] = base->uv[2 * px + 1];
            memcpy(a + 2, base->normal + 3 * px, 3 * sizeof *a);
        }
}

/* Triangles of a later batch index from its first vertex; the frame's mesh from vertex 0. */
typedef struct rebase_ctx {
    crisp_raster_tri *tris;
    uint32_t by;
} rebase_ctx;

static void rebase_tris(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const rebase_ctx *c = vctx;
    for (size_t i = begin; i < end; i++)
        for (int k = 0; k < 3; k++)
            c->tris[i].v[k] += c->by;
}

/* A draw in parts (crisp_render_cpu, the plan's stages): part 1 starts the target and draws a
 * plan's surfaces, part 3 draws another plan's surfaces over them, each keeping the target, the
 * mesh and the block depth of what was drawn (r->hiz, up to date); part 2 draws the leaves of the
 * faces with later[f] != 0 of the final plan over them, then the splats, the ribbons of every face
 * and the resolve. */
typedef struct draw_part {
    int part; /* 0: the whole draw in one; 1, 3, 2 */
    const uint8_t *later;
    /* 1: the faces the image shows are listed in r->seen_list (seen_count of them), the
     * planner's seen faces (crisp__planner_seen), found by the resolve. */
    int seen;
} draw_part;

/* The block depth of the blocks dirty[] into r->hiz (crisp__raster_block_depth): from the live
 * block depth the surfaces' draws keep when live_ok (the same values), else read from the
 * samples. */
static void refresh_depth(crisp_renderer *r, const crisp_raster_target *tg, int live_ok,
                          const int dirty[4])
{
    if (live_ok) {
        crisp__raster_set_live_depth(r->raster, r->hiz_live, CRISP_OCCL_BLOCK);
        crisp__raster_block_depth_live(r->raster, tg, r->pool, dirty, r->hiz);
        crisp__raster_set_live_depth(r->raster, NULL, 0);
    } else {
        crisp__raster_block_depth(tg, r->pool, CRISP_OCCL_BLOCK, dirty, r->hiz);
    }
}

/* crisp_render_cpu_plan (only, base and window NULL), crisp_render_cpu_plan_faces (a subset of
 * the faces, over a base image), crisp__render_cpu_window (a window of the frame) and
 * crisp_render_cpu's two parts (part; NULL: one). */
static crisp_status draw_plan(crisp_renderer *r, const crisp_scene *sc,
                              const crisp_frame_plan *plan, const crisp_camera *cam,
                              const uint8_t *only, const crisp_image *base, const int window[4],
                              crisp_image *img, crisp_render_stats *stats, const draw_part *part)
{
    int stage = part ? part->part : 0;
    if (stage && (only || base || window))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "a frame drawn in two parts is drawn whole, without a base image");
    int win[4] = {0, 0, plan->width, plan->height};
    if (window) memcpy(win, window, sizeof win);
    if (window && (only || base))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "a window of the frame is drawn with every face and no base image");
    if (img->width != win[2] || img->height != win[3] || cam->width != plan->width ||
        cam->height != plan->height)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "image %dx%d and camera %dx%d do not match the plan's %dx%d", img->width,
                           img->height, cam->width, cam->height, plan->width, plan->height);
    if (win[0] < 0 || win[1] < 0 || win[2] < 1 || win[3] < 1 || win[0] + win[2] > plan->width ||
        win[1] + win[3] > plan->height || win[0] % 8 || win[1] % 8)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "window %dx%d at (%d, %d) of the %dx%d frame: expected a window inside "
                           "the frame at a multiple of 8",
                           win[2], win[3], win[0], win[1], plan->width, plan->height);
    if (plan->face_count != sc->face_count)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "the plan has %u faces, the scene %u: not the scene's plan",
                           plan->face_count, sc->face_count);
    if (base && (base->width != plan->width || base->height != plan->height || base == img))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "base image %dx%d: expected the plan's size %dx%d and not the image "
                           "drawn into",
                           base->width, base->height, plan->width, plan->height);
    if (base && r->desc.samples != 1)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "drawing over a base image needs 1 sample per pixel (the renderer has "
                           "%d): the image holds one",
                           r->desc.samples);
    crisp_render_stats local;
    if (!stats) stats = &local;
    crisp_status st;
    r->plan = plan;
    double t0 = crisp_time_now(), t_tess = 0, t_raster = 0;
    size_t jobs = plan->leaf_count;
    int occlusion = !r->desc.no_occlusion;
    if ((st = crisp_grow((void **)&r->leaf_vbase, &r->leaf_base_cap, jobs ? jobs : 1,
                         sizeof *r->leaf_vbase)) ||
        (st = crisp_grow((void **)&r->leaf_tbase, &r->leaf_tbase_cap, jobs ? jobs : 1,
                         sizeof *r->leaf_tbase)) ||
        (st = crisp_grow((void **)&r->leaf_skip, &r->leaf_skip_cap, jobs ? jobs : 1,
                         sizeof *r->leaf_skip)) ||
        (st = crisp_grow((void **)&r->order, &r->order_cap, jobs ? jobs : 1, sizeof *r->order)))
        return st;
    if (base &&
        (st = crisp_grow((void **)&r->hull, &r->hull_cap, jobs ? jobs : 1, sizeof *r->hull)))
        return st;
    if (occlusion &&
        (st = crisp_grow((void **)&r->occl, &r->occl_cap, jobs ? jobs : 1, sizeof *r->occl)))
        return st;
    skip_ctx skc = {.r = r,
                    .sc = sc,
                    .samples = r->desc.samples,
                    .only = only,
                    .hull = base ? r->hull : NULL,
                    .win = {win[0], win[1], win[2], win[3]},
                    .occl = occlusion ? r->occl : NULL,
                    .later = stage == 2 ? part->later : NULL};
    for (int s = 0; s < r->desc.samples; s++)
        crisp__raster_sample_offset(r->desc.samples, s, skc.off[s]);
    crisp_pool_parallel_for(r->pool, jobs, 64, find_empty_leaves, &skc);
    /* The leaves to draw, in batches (nearest first with occlusion culling). */
    uint32_t bstart[CRISP_OCCL_BATCHES + 1];
    size_t bad = crisp__occl_order(occlusion ? r->occl : NULL, r->leaf_skip, r->leaf_tbase, jobs,
                                   r->order, bstart);
    if (bad != SIZE_MAX) {
        size_t v, t;
        crisp_tess_levels lv = leaf_levels(&plan->leaves[bad]);
        if ((st = crisp_tess_mesh_counts(&lv, &v, &t))) return st;
    }
    /* Ribbons after the surfaces: at equal depth the surface's own fragment stays. A window of
     * the frame (issue 15: tiles of a poster have a millionth of its ribbons each) keeps the
     * quads whose screen box, widened by 2 px, meets it, in their order; the others cover no
     * sample of it. */
    size_t quads = plan->ribbon_quad_count;
    const uint32_t *keep = NULL;
    if (only) {
        quads = 0;
        for (uint32_t f = 0; f < plan->face_count; f++)
            if (only[f]) quads += plan->faces[f].ribbon_count;
    } else if (window && (win[2] != plan->width || win[3] != plan->height)) {
        if ((st = crisp_grow((void **)&r->ribbon_keep, &r->ribbon_keep_cap, quads ? quads : 1,
                             sizeof *r->ribbon_keep)))
            return st;
        size_t kept = 0;
        for (size_t q = 0; q < quads; q++) {
            const crisp_plan_ribbon_vertex *v = plan->ribbon_vertices + 4 * q;
            double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
            int far = 0;
            for (int k = 0; k < 4 && !far; k++) {
                const double *c = v[k].clip;
                if (!(c[3] > 0) || !isfinite(c[0] + c[1] + c[3])) {
                    far = 1; /* behind the eye: kept (clipped by the rasterizer) */
                    break;
                }
                box_add_clip(plan, c, lo, hi);
            }
            if (far || (hi[0] >= win[0] - 2 && lo[0] <= win[0] + win[2] + 2 &&
                        hi[1] >= win[1] - 2 && lo[1] <= win[1] + win[3] + 2))
                r->ribbon_keep[kept++] = (uint32_t)q;
        }
        quads = kept;
        keep = r->ribbon_keep;
    }

    crisp_raster_view view; /* for the ribbons' depth slack and the resolve's shading */
    raster_view(cam, &view);
    /* Over a base image: the faces' region of the renderer's own target is loaded from it (the
     * rest of that target is kept empty, so the rasterizer's depth bounds stay valid there);
     * otherwise the whole target starts empty. */
    crisp_raster_target *tg = base ? &r->over : &r->target;
    int rect[4] = {0, 0, win[2], win[3]}, rib[4] = {0, 0, 0, 0};
    if (base) {
        int fresh = !r->over.inv_w || r->over.width != cam->width || r->over.height != cam->height;
        if ((st = crisp__raster_target_init(&r->over, cam->width, cam->height, 1)) ||
            (st = crisp__raster_target_window(&r->over, 0, 0, 0, 0)))
            return st;
        if (fresh) {
            crisp__raster_target_clear(&r->over);
            memset(r->over_rect, 0, sizeof r->over_rect);
        }
        faces_region(r, plan, only, rect, rib);
        if (memcmp(rect, r->over_rect, sizeof rect)) {
            /* The last region's pixels outside this one go back to base (in img too: it holds
             * base's pixels outside the region by contract, whichever image it is). */
            const int *o = r->over_rect;
            for (int j = o[1]; j < o[3]; j++)
                for (int i = o[0]; i < o[2]; i++)
                    if (i < rect[0] || i >= rect[2] || j < rect[1] || j >= rect[3])
                        copy_pixel(base, img, (size_t)j * cam->width + (size_t)i);
            load_rect(&r->over, NULL, r->over_rect);
        }
        load_rect(&r->over, base, rect);
        memcpy(r->over_rect, rect, sizeof rect);
    } else if (stage < 2) {
        if ((st = crisp__raster_target_init(&r->target, win[2], win[3], r->desc.samples)) ||
            (st = window ? crisp__raster_target_window(&r->target, win[0], win[1], cam->width,
                                                       cam->height)
                         : crisp__raster_target_window(&r->target, 0, 0, 0, 0)))
            return st;
        crisp__raster_target_clear_depth(&r->target, r->pool);
    }
    /* Surfaces first; then the ribbons fill gaps: a ribbon sample replaces a surface sample only
     * when nearer by more than that surface's depth change over 1.5 px, so a ribbon along an
     * edge that another face hides at nearly the same depth (seen at a grazing angle) does not
     * show through it. */
    trim_ctx tctx = {plan, atomic_fetch_add(&trim_generation, 1) + 1};
    void *ctx = &tctx;
    if ((st = crisp_grow((void **)&r->untested, &r->untested_cap,
                         plan->face_count ? plan->face_count : 1, sizeof *r->untested)))
        return st;
    for (uint32_t f = 0; f < plan->face_count; f++)
        r->untested[f] = (plan->faces[f].flags & CRISP_PLAN_FACE_ALL_INSIDE) != 0;
    crisp__raster_set_untested_faces(r->raster, r->untested, plan->face_count);
    /* The clip plane n . P + d >= 0 with P = eye + W (f + (x - w/2) kx r + (h/2 - y) ky u) on a
     * sample's ray at depth W, divided by W: affine in the sample's (x, y) and 1/W. */
    const double *cp = r->desc.clip_plane;
    double clip_k[4] = {0, 0, 0, 0};
    int clip_on = cp[0] != 0 || cp[1] != 0 || cp[2] != 0;
    if (clip_on) {
        double nf = crisp_vec3_dot(cp, view.f), nr = crisp_vec3_dot(cp, view.r),
               nu = crisp_vec3_dot(cp, view.u);
        double k[4] = {nf - 0.5 * cam->width * view.kx * nr + 0.5 * cam->height * view.ky * nu,
                       view.kx * nr, -view.ky * nu, crisp_vec3_dot(cp, cam->eye) + cp[3]};
        memcpy(clip_k, k, sizeof k);
        crisp__raster_set_clip(r->raster, k);
    } else {
        crisp__raster_set_clip(r->raster, NULL);
    }
    crisp__raster_set_box_test(r->raster, trim_box);

    /* The surfaces, batch after batch (nearest first, occlusion.c): each batch's leaves that the
     * depth drawn so far hides are dropped, the others tessellated and drawn. */
    size_t nv = 0, nt = 0, occluded_leaves = 0, occluded_tris = 0;
    size_t tris_dropped = 0; /* not set up: hidden by the block depth or covering no sample */
    crisp_raster_stats rs = {0};
    /* The blocks the batches drawn since the last look at the depth can have reached. */
    int drawn = 0, looked = 0, dirty[4] = {INT_MAX, INT_MAX, -1, -1};
    /* The surfaces' draws keep the live block depth (every write to the target since its clear
     * goes through them until the splats are drawn): the refreshes copy it. */
    int live_ok = 0;
    if (stage >= 2) { /* over the earlier parts' surfaces */
        nv = r->carry.nv, nt = r->carry.nt;
        occluded_leaves = r->carry.occluded_leaves, occluded_tris = r->carry.occluded_tris;
        tris_dropped = r->carry.tris_dropped;
        rs = r->carry.rs;
        drawn = r->carry.drawn, looked = r->carry.looked;
        memcpy(dirty, r->carry.dirty, sizeof dirty);
        t_tess = r->carry.t_tess, t_raster = r->carry.t_raster;
        live_ok = r->carry.live_ok;
    } else if (occlusion) {
        size_t blocks = (size_t)((win[2] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK) *
                        (size_t)((win[3] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK);
        if ((st = crisp_grow((void **)&r->hiz, &r->hiz_cap, blocks, sizeof *r->hiz)) ||
            (st = crisp_grow((void **)&r->hiz_live, &r->hiz_live_cap, blocks, sizeof *r->hiz_live)))
            return st;
        memset(r->hiz, 0, blocks * sizeof *r->hiz); /* nothing drawn: no block hides anything */
        live_ok = !base && tg->clear_pending;       /* the first draw clears every tile */
    }
    double t1 = crisp_time_now();
    t_tess += t1 - t0;
    /* The surfaces' draws clear a tile of the target when they first draw there (flushed below,
     * before the splats, ribbons and resolve read the samples). */
    crisp__raster_set_defer_clear(r->raster, !base);
    for (int b = 0; b < CRISP_OCCL_BATCHES; b++) {
        uint32_t *list = r->order + bstart[b];
        size_t n = bstart[b + 1] - bstart[b];
        if (!n) continue;
        double ta = crisp_time_now();
        if (drawn && nt) {
            /* Refreshing the block depth costs a pass over the samples of the blocks drawn since
             * the last refresh (the others keep their values); a triangle not drawn saves its
             * evaluation, setup and rasterisation (some hundred ns): worth it when the batch has
             * at least a triangle per 128 such samples. Without a refresh the last one is still
             * a valid bound (stored depth only gets nearer). */
            if (dirty[0] <= dirty[2]) {
                size_t tris = 0, area = (size_t)(dirty[2] - dirty[0] + 1) *
                                        (size_t)(dirty[3] - dirty[1] + 1) * CRISP_OCCL_BLOCK *
                                        CRISP_OCCL_BLOCK * r->desc.samples;
                for (size_t i = 0; i < n; i++)
                    tris += r->leaf_tbase[list[i]];
                if (128 * tris >= area) {
                    refresh_depth(r, tg, live_ok, dirty);
                    dirty[0] = dirty[1] = INT_MAX, dirty[2] = dirty[3] = -1;
                    looked = 1;
                }
            }
            if (looked)
                crisp__occl_cull(r->pool, r->occl, list, n, r->hiz,
                                 (win[2] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK, r->leaf_skip);
        }
        if (occlusion) { /* large leaves, piece by piece */
            piece_ctx pc = {&skc, list, looked ? r->hiz : NULL,
                            (win[2] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK};
            crisp_pool_parallel_for(r->pool, n, 1, pieces_range, &pc);
        }
        /* Offsets of the batch's drawn leaves (in plan order), the list compacted to them. */
        size_t kept = 0, vb0 = nv, tb0 = nt;
        for (size_t i = 0; i < n; i++) {
            uint32_t j = list[i];
            if (r->leaf_skip[j]) {
                occluded_leaves++;
                occluded_tris += r->leaf_tbase[j];
                continue;
            }
            if (occlusion) {
                const crisp_occl_leaf *o = &r->occl[j];
                dirty[0] = o->bx0 < dirty[0] ? o->bx0 : dirty[0];
                dirty[1] = o->by0 < dirty[1] ? o->by0 : dirty[1];
                dirty[2] = o->bx1 > dirty[2] ? o->bx1 : dirty[2];
                dirty[3] = o->by1 > dirty[3] ? o->by1 : dirty[3];
            }
            size_t v = r->leaf_vbase[j], t = r->leaf_tbase[j];
            r->leaf_vbase[j] = (uint32_t)nv;
            r->leaf_tbase[j] = (uint32_t)nt;
            nv += v;
            nt += t;
            list[kept++] = j;
            if (nv > UINT32_MAX / 2 || nt > UINT32_MAX / 2)
                return crisp_error(CRISP_ERR_LIMIT,
                                   "more than 2^31 vertices or triangles in one frame");
        }
        /* A triangle record is at least as large as the generator's three indices. */
        if ((st = crisp_grow((void **)&r->verts, &r->vert_cap, nv ? nv : 1, sizeof *r->verts)) ||
            (st = crisp_grow((void **)&r->tris, &r->tri_cap, nt ? nt : 1, sizeof *r->tris)))
            return st;
        tess_ctx tc = {
            r,   sc, list, kept, (uint32_t)vb0, (uint32_t)nv, (uint32_t)nt, ++r->tess_generation,
            NULL};
        tc.keep = keep_decide(r, sc, list, kept, (uint32_t)nv, tc.generation);
        crisp_pool_parallel_for(r->pool, kept, 8, tessellate, &tc);
        keep_pole_normals(r);
        double tb = crisp_time_now();
        /* Each pass projects only its own vertices: the batch's, later the ribbons'. The block
         * depth also drops the kept leaves' hidden triangles at set-up. */
        crisp__raster_set_occlusion(r->raster, looked ? r->hiz : NULL, CRISP_OCCL_BLOCK);
        /* The live block depth computed by this draw's tiles when the block depth is refreshed
         * before the next draw (the rule above on the next batch; after the last batch, the
         * stage's end, the splats' or the ribbons' refresh): the tiles not computed are read at
         * the refresh, so any answer gives the same values. */
        int follows = 1;
        for (int b2 = b + 1; b2 < CRISP_OCCL_BATCHES; b2++) {
            if (bstart[b2 + 1] == bstart[b2]) continue;
            follows = 0;
            if (nt && dirty[0] <= dirty[2]) {
                size_t tris = 0, area = (size_t)(dirty[2] - dirty[0] + 1) *
                                        (size_t)(dirty[3] - dirty[1] + 1) * CRISP_OCCL_BLOCK *
                                        CRISP_OCCL_BLOCK * r->desc.samples;
                for (uint32_t i = bstart[b2]; i < bstart[b2 + 1]; i++)
                    tris += r->leaf_tbase[r->order[i]];
                follows = 128 * tris >= area;
            }
            break;
        }
        crisp__raster_set_live_depth(r->raster, live_ok ? r->hiz_live : NULL, CRISP_OCCL_BLOCK);
        crisp__raster_live_compute(r->raster, follows);
        crisp_raster_stats rsb;
        st = crisp__raster_draw(r->raster, tg, r->pool, r->verts + vb0, nv - vb0, r->tris + tb0,
                                nt - tb0, trim_test, ctx, &rsb);
        crisp__raster_set_live_depth(r->raster, NULL, 0);
        if (st) return st;
        drawn = 1;
        tris_dropped += rsb.triangles_in - rsb.triangles_setup;
        rs.fragments_tested += rsb.fragments_tested;
        rs.fragments_discarded += rsb.fragments_discarded;
        if (vb0) { /* the frame's mesh indexes from its first vertex (crisp__renderer_mesh) */
            rebase_ctx rb = {r->tris + tb0, (uint32_t)vb0};
            crisp_pool_parallel_for(r->pool, nt - tb0, 4096, rebase_tris, &rb);
        }
        double tc2 = crisp_time_now();
        t_tess += tb - ta;
        t_raster += tc2 - tb;
    }
    if (stage == 1 || stage == 3) {
        /* The block depth of everything drawn, for the planner's next stage. */
        if (occlusion && drawn && nt && dirty[0] <= dirty[2]) {
            refresh_depth(r, tg, live_ok, dirty);
            dirty[0] = dirty[1] = INT_MAX, dirty[2] = dirty[3] = -1;
            looked = 1;
        }
        r->carry.nv = nv, r->carry.nt = nt;
        r->carry.occluded_leaves = occluded_leaves, r->carry.occluded_tris = occluded_tris;
        r->carry.tris_dropped = tris_dropped;
        r->carry.rs = rs;
        r->carry.drawn = drawn, r->carry.looked = looked;
        memcpy(r->carry.dirty, dirty, sizeof dirty);
        r->carry.live_ok = live_ok;
        r->carry.t_tess = t_tess, r->carry.t_raster = t_raster;
        return CRISP_OK;
    }
    if (!drawn) { /* nothing to draw: the draw still does the target's pending clear */
        double ta = crisp_time_now();
        if ((st = crisp_grow((void **)&r->verts, &r->vert_cap, 1, sizeof *r->verts)) ||
            (st = crisp_grow((void **)&r->tris, &r->tri_cap, 1, sizeof *r->tris)))
            return st;
        if ((st = crisp__raster_draw(r->raster, tg, r->pool, r->verts, 0, r->tris, 0, trim_test,
                                     ctx, &rs)))
            return st;
        t_raster += crisp_time_now() - ta;
    }
    crisp__raster_set_defer_clear(r->raster, 0);
    crisp__raster_target_flush(tg, r->pool);
    /* The faces drawn as splats (issue 12, splat_raster.c), with the surfaces: before the
     * ribbons' depth slack is taken. A face whose squares the depth drawn so far hides whole is
     * skipped (the block depth refreshed first where the surfaces were drawn). */
    crisp__splat_draw_stats sds = {0};
    if (plan->splat_range_count) {
        double ta = crisp_time_now();
        if (occlusion && drawn && nt && dirty[0] <= dirty[2]) {
            refresh_depth(r, tg, live_ok, dirty);
            dirty[0] = dirty[1] = INT_MAX, dirty[2] = dirty[3] = -1;
            looked = 1;
        }
        crisp__splat_draw_desc sd = {.plan = plan,
                                     .only = only,
                                     .clip = clip_on ? clip_k : NULL,
                                     .hiz = occlusion && looked ? r->hiz : NULL,
                                     .win = {win[0], win[1], win[2], win[3]},
                                     .occlude = occlusion};
        if ((st = crisp__splat_draw(&r->splat, tg, r->pool, &sd, &sds))) return st;
        live_ok = 0; /* the splats' samples are not in it */
        if (sds.box[0] <= sds.box[2]) {
            dirty[0] = sds.box[0] < dirty[0] ? sds.box[0] : dirty[0];
            dirty[1] = sds.box[1] < dirty[1] ? sds.box[1] : dirty[1];
            dirty[2] = sds.box[2] > dirty[2] ? sds.box[2] : dirty[2];
            dirty[3] = sds.box[3] > dirty[3] ? sds.box[3] : dirty[3];
            drawn = 1;
        }
        t_raster += crisp_time_now() - ta;
    }
    size_t surface_v = nv, surface_t = nt;
    r->vert_count = surface_v; /* the surface mesh, without the ribbons */
    r->tri_count = surface_t;

    double t2a = crisp_time_now();
    /* The block depth of the surfaces drawn, for the quads hidden behind them (no sample of
     * theirs could pass the fill pass's depth test): whole quads dropped here, the other hidden
     * triangles at the fill draw's set-up. */
    if (occlusion && drawn && quads) {
        refresh_depth(r, tg, live_ok, dirty);
        dirty[0] = dirty[1] = INT_MAX, dirty[2] = dirty[3] = -1;
        looked = 1;
    }
    crisp__raster_set_occlusion(r->raster, looked ? r->hiz : NULL, CRISP_OCCL_BLOCK);
    /* Worth it where the surfaces' own triangles were found hidden (depth complexity): in a
     * view of the outside of a model the ribbons lie on the faces drawn and few are hidden. */
    if (looked && quads && !only && 10 * (occluded_tris + tris_dropped) >= nt + occluded_tris) {
        if ((st = crisp_grow((void **)&r->ribbon_keep, &r->ribbon_keep_cap, quads,
                             sizeof *r->ribbon_keep)) ||
            (st = crisp_grow((void **)&r->ribbon_hidden, &r->ribbon_hidden_cap, quads,
                             sizeof *r->ribbon_hidden)))
            return st;
        ribbon_cull_ctx cc = {r,
                              tg,
                              keep,
                              r->ribbon_hidden,
                              {win[0], win[1]},
                              (win[2] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK,
                              (win[3] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK};
        crisp_pool_parallel_for(r->pool, quads, 256, cull_ribbons, &cc);
        size_t kept = 0; /* in order; in place when keep is already the list */
        for (size_t q = 0; q < quads; q++)
            if (!r->ribbon_hidden[q]) r->ribbon_keep[kept++] = keep ? keep[q] : (uint32_t)q;
        quads = kept;
        keep = r->ribbon_keep;
    }
    nv += 4 * quads;
    nt += 2 * quads;
    if (nv > UINT32_MAX / 2 || nt > UINT32_MAX / 2)
        return crisp_error(CRISP_ERR_LIMIT, "more than 2^31 vertices or triangles in one frame");
    if ((st = crisp_grow((void **)&r->verts, &r->vert_cap, nv ? nv : 1, sizeof *r->verts)) ||
        (st = crisp_grow((void **)&r->tris, &r->tri_cap, nt ? nt : 1, sizeof *r->tris)) ||
        (st = crisp_grow((void **)&r->cores, &r->cores_cap, quads ? 2 * quads : 1,
                         sizeof *r->cores)))
        return st;
    if (!only) {
        ribbon_ctx rbc = {r, plan, surface_v, surface_t, 0, keep, surface_v, surface_t};
        crisp_pool_parallel_for(r->pool, quads, 256, copy_ribbons, &rbc);
    } else {
        size_t done = 0; /* the drawn faces' quads, face after face */
        for (uint32_t f = 0; f < plan->face_count; f++) {
            if (!only[f] || !plan->faces[f].ribbon_count) continue;
            ribbon_ctx rbc = {r,
                              plan,
                              surface_v + 4 * done,
                              surface_t + 2 * done,
                              plan->faces[f].first_ribbon,
                              NULL,
                              surface_v,
                              surface_t};
            crisp_pool_parallel_for(r->pool, plan->faces[f].ribbon_count, 256, copy_ribbons, &rbc);
            done += plan->faces[f].ribbon_count;
        }
    }
    double t2b = crisp_time_now();
    t_tess += t2b - t2a;
    if (nt > surface_t) {
        /* The quads with their slack, in their cores the cores' (ribbon.h), in one fill pass;
         * both slacks from the surfaces alone, only where the quads can land (the fill pass
         * reads nothing else). */
        size_t ns = (size_t)win[2] * win[3] * r->desc.samples;
        if ((st = crisp_grow((void **)&r->slack, &r->slack_cap, 2 * ns, sizeof *r->slack)))
            return st;
        if ((st = crisp__raster_depth_slack2_tris(
                 r->raster, tg, r->pool, CRISP__RIBBON_SLACK, CRISP__RIBBON_CORE_SLACK, &view,
                 r->verts + surface_v, 4 * quads, r->tris + surface_t, 2 * quads, r->cores,
                 r->slack, r->slack + ns)))
            return st;
        crisp_raster_stats rs2;
        if ((st = crisp__raster_draw_fill2(r->raster, tg, r->pool, r->verts + surface_v, 4 * quads,
                                           r->tris + surface_t, 2 * quads, trim_test, ctx, r->slack,
                                           r->cores, r->slack + ns, &rs2)))
            return st;
        rs.fragments_tested += rs2.fragments_tested;
        rs.fragments_discarded += rs2.fragments_discarded;
    }
    crisp__raster_set_occlusion(r->raster, NULL, 0);
    double t2 = crisp_time_now();
    t_raster += t2 - t2b;
    if ((st = resolve_image(r, sc, cam, &view, tg, rect, only, base, part && part->seen,
                            resolve_path(r, tg, base), img)))
        return st;
    double t3 = crisp_time_now();
    copy_plan_stats(&plan->stats, stats);
    stats->vertices = surface_v;
    stats->triangles = surface_t;
    stats->ribbon_triangles = nt - surface_t;
    stats->occluded_leaves = occluded_leaves;
    stats->occluded_triangles = occluded_tris;
    stats->splat_faces = (uint32_t)(sds.ranges - sds.hidden_ranges);
    stats->splats = sds.splats;
    stats->fragments_tested = rs.fragments_tested;
    stats->fragments_trimmed = rs.fragments_discarded;
    stats->ms_tess = 1e3 * t_tess;
    stats->ms_raster = 1e3 * t_raster;
    stats->ms_resolve = 1e3 * (t3 - t2);
    return CRISP_OK;
}

crisp_status crisp_render_cpu_plan(crisp_renderer *r, const crisp_scene *sc,
                                   const crisp_frame_plan *plan, const crisp_camera *cam,
                                   crisp_image *img, crisp_render_stats *stats)
{
    return draw_plan(r, sc, plan, cam, NULL, NULL, NULL, img, stats, NULL);
}

crisp_status crisp__render_cpu_window(crisp_renderer *r, const crisp_scene *sc,
                                      const crisp_frame_plan *plan, const crisp_camera *cam,
                                      const int window[4], crisp_image *img,
                                      crisp_render_stats *stats)
{
    return draw_plan(r, sc, plan, cam, NULL, NULL, window, img, stats, NULL);
}

crisp_status crisp_render_cpu_plan_faces(crisp_renderer *r, const crisp_scene *sc,
                                         const crisp_frame_plan *plan, const crisp_camera *cam,
                                         const uint8_t *faces, const crisp_image *base,
                                         crisp_image *img, crisp_render_stats *stats)
{
    if (base && !faces)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "drawing over a base image: say which faces to draw (faces is NULL)");
    return draw_plan(r, sc, plan, cam, faces, base, NULL, img, stats, NULL);
}

crisp_status crisp_render_cpu(crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cam,
                              crisp_image *img, crisp_render_stats *stats)
{
    if (img->width != cam->width || img->height != cam->height)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image %dx%d does not match the camera's %dx%d",
                           img->width, img->height, cam->width, cam->height);
    const crisp_frame_plan *plan;
    crisp_status st;
    if (r->desc.no_occlusion) {
        if ((st = crisp_planner_plan(r->planner, sc, cam, &plan))) return st;
        return crisp_render_cpu_plan(r, sc, plan, cam, img, stats);
    }
    /* In stages (issue 12): the nearest faces planned and their surfaces drawn; then the planner
     * drops the faces of the next stage that this depth hides whole (they would draw no sample)
     * and plans the others, drawn over them; and so on. */
    const uint8_t *later;
    if ((st = crisp__planner_plan_near(r->planner, sc, cam, &plan, &later))) return st;
    if (!later) {
        /* The faces on screen (the next frame's first stage) when the planner wants them. */
        int seen = crisp__planner_seen_wanted(r->planner, sc);
        if ((st = draw_plan(r, sc, plan, cam, NULL, NULL, NULL, img, stats,
                            &(draw_part){0, NULL, seen})))
            return st;
        return seen ? crisp__planner_seen(r->planner, sc, r->seen_list, r->seen_count) : CRISP_OK;
    }
    if ((st = draw_plan(r, sc, plan, cam, NULL, NULL, NULL, img, stats, &(draw_part){1, NULL, 0})))
        return st;
    int win[4] = {0, 0, cam->width, cam->height};
    for (;;) {
        int last;
        if ((st = crisp__planner_plan_next(r->planner, sc, r->hiz, win, &plan, &last))) return st;
        if (last) {
            if ((st = draw_plan(r, sc, plan, cam, NULL, NULL, NULL, img, stats,
                                &(draw_part){2, later, 1})))
                return st;
            /* The faces on screen: the next frame's first stage. */
            return crisp__planner_seen(r->planner, sc, r->seen_list, r->seen_count);
        }
        if ((st = draw_plan(r, sc, plan, cam, NULL, NULL, NULL, img, stats,
                            &(draw_part){3, NULL, 0})))
            return st;
    }
}
