/* The public frame planner (include/crisp/plan.h): runs the per-patch quadtrees and trim plans
 * (quadtree.c) and the ribbons (ribbon.c), then lays their results out as the flat, read-only
 * arrays every backend takes: visible leaves grouped by face, a record per face, the faces' trim
 * tables concatenated (strips, rows, crossings), the ribbon quads. Buffers are kept from frame to
 * frame; each array's version is bumped only when its bytes changed, so a GPU backend uploads only
 * what changed (a trim edit with a still camera uploads one table, not the leaves). The CPU
 * backend's frames are planned in stages (stages.c) from the steps here (planner.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/plan.h"
#include "planner.h"
#include "render_internal.h"

crisp_status crisp_planner_create(const crisp_planner_desc *desc, crisp_pool *pool,
                                  crisp_planner **dest)
{
    if (desc && (desc->eps_px < 0 || !(desc->eps_px == desc->eps_px)))
        return crisp_error(CRISP_ERR_INVALID_ARG, "planner eps_px %g: expected > 0 (or 0 for 0.5)",
                           desc->eps_px);
    if (desc && (desc->strip_count < 0 || desc->strip_count > 65536))
        return crisp_error(CRISP_ERR_INVALID_ARG, "planner strip_count %d: expected 0..65536",
                           desc->strip_count);
    crisp_planner *p = calloc(1, sizeof *p);
    if (!p) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating a planner");
    if (desc) p->desc = *desc;
    p->pool = pool ? pool : crisp_pool_shared();
    crisp_status st = crisp__trees_create(&p->trees);
    if (!st) st = crisp__ribbons_create(crisp_pool_threads(p->pool), &p->ribbons);
    if (!st) st = crisp__splat_store_create(&p->splats);
    if (st) {
        crisp_planner_destroy(p);
        return st;
    }
    *dest = p;
    return CRISP_OK;
}

void crisp_planner_destroy(crisp_planner *p)
{
    if (!p) return;
    crisp__trees_destroy(p->trees);
    crisp__ribbons_destroy(p->ribbons);
    crisp__splat_store_destroy(p->splats);
    free(p->splat_face);
    free(p->leaves);
    free(p->faces);
    free(p->strips);
    free(p->row_offset);
    free(p->crossings);
    free(p->ribbon_verts);
    free(p->face_ribbon);
    free(p->ribbon_first);
    free(p->ribbon_quads);
    free(p->strips_used);
    free(p->face_fixed);
    free(p->plain_splat);
    crisp__stages_free(&p->stages);
    free(p);
}

/* FNV-1a over 64-bit words (the arrays are multiples of 8 bytes, or padded by the caller), in
 * four lanes of every fourth word, joined at the end: each lane's chain of multiplies is
 * independent, so the processor runs them side by side (one chain over the plan's faces, 870 KB at
 * imp49 far, took ~0.15 ms). Each step is one-to-one in the word, so a change in one word changes
 * its lane's value and the joined value. hash4_step takes 32 bytes: a caller that writes an array
 * in blocks of 32 bytes hashes each as it writes it (lay_out_faces), the same value as hash_bytes
 * over the array. */
#define HASH_PRIME 1099511628211ull
typedef struct hash4 {
    uint64_t lane[4];
} hash4;

static inline hash4 hash4_start(void)
{
    return (hash4){{1469598103934665603ull, 1469598103934665603ull ^ 1, 1469598103934665603ull ^ 2,
                    1469598103934665603ull ^ 3}};
}

static inline void hash4_step(hash4 *h, const void *block)
{
    uint64_t w[4];
    memcpy(w, block, 32);
    h->lane[0] = (h->lane[0] ^ w[0]) * HASH_PRIME, h->lane[1] = (h->lane[1] ^ w[1]) * HASH_PRIME;
    h->lane[2] = (h->lane[2] ^ w[2]) * HASH_PRIME, h->lane[3] = (h->lane[3] ^ w[3]) * HASH_PRIME;
}

/* The lanes joined, then the last bytes (fewer than 32). (h4 by value: a lane state whose address
 * escapes stays in memory, 20 instructions more a step.) */
static uint64_t hash4_end(hash4 h4, const unsigned char *b, size_t bytes)
{
    uint64_t h = h4.lane[0];
    for (int l = 1; l < 4; l++)
        h = (h ^ h4.lane[l]) * HASH_PRIME;
    size_t k = 0;
    for (; k + 8 <= bytes; k += 8) {
        uint64_t w;
        memcpy(&w, b + k, 8);
        h = (h ^ w) * HASH_PRIME;
    }
    for (; k < bytes; k++)
        h = (h ^ b[k]) * HASH_PRIME;
    return h;
}

static uint64_t hash_bytes(const void *data, size_t bytes)
{
    const unsigned char *b = data;
    hash4 h = hash4_start();
    size_t k = 0;
    for (; k + 32 <= bytes; k += 32)
        hash4_step(&h, b + k);
    return hash4_end(h, b + k, bytes - k);
}

/* Triangles of a leaf at its levels (0 when refused: the draw reports it). */
static uint64_t leaf_triangles(const crisp_plan_leaf *L)
{
    crisp_tess_levels lv = {{(int)L->tau, (int)L->tau},
                            {(int)L->edge[0], (int)L->edge[1], (int)L->edge[2], (int)L->edge[3]}};
    size_t nv, nt;
    return crisp_tess_mesh_counts(&lv, &nv, &nt) ? 0 : nt;
}

/* Where the lay-out of the faces has got to: leaves written, the next active patch, triangles;
 * strips, rows and crossings of the tables written. */
typedef struct lay_out_at {
    size_t leaf, next;
    uint64_t triangles;
    size_t strip, row, crossing;
} lay_out_at;

/* The leaves' room for this frame (kept: as crisp__planner_lay_out_leaves); *count: the leaves. */
static crisp_status grow_leaves(crisp_planner *p, const crisp_scene *sc, const uint8_t *kept,
                                size_t *count)
{
    const crisp__trees *t = p->trees;
    size_t n = 0;
    for (size_t i = 0; i < t->active_count; i++)
        n += t->patches[t->active[i]].visible_leaves;
    if (kept)
        for (uint32_t f = 0; f < sc->face_count; f++)
            if (kept[f]) n += p->stages.kept[5 * (size_t)f + 1];
    if (n > UINT32_MAX / 2)
        return crisp_error(CRISP_ERR_LIMIT, "%zu leaves in one frame: too many", n);
    *count = n;
    return crisp_grow((void **)&p->leaves, &p->leaf_cap, n ? n : 1, sizeof *p->leaves);
}

/* Face f's visible leaves appended at at->leaf (the active patches ascend: face after face), its
 * leaf range and level in pf. */
static inline void lay_out_face_leaves(crisp_planner *p, const crisp_scene *sc, const uint8_t *kept,
                                       uint32_t f, crisp_plan_face *pf, lay_out_at *at)
{
    const crisp__trees *t = p->trees;
    pf->first_leaf = (uint32_t)at->leaf;
    pf->tau_max = t->face_tau[f];
    if (kept && kept[f]) {
        const uint32_t *k = p->stages.kept + 5 * (size_t)f;
        for (uint32_t l = 0; l < k[1]; l++) {
            p->leaves[at->leaf] = p->stages.kept_leaves[k[0] + l];
            at->triangles += leaf_triangles(&p->leaves[at->leaf++]);
        }
        pf->leaf_count = k[1];
        return;
    }
    for (; at->next < t->active_count &&
           t->active[at->next] < sc->faces[f].first_patch + sc->faces[f].patch_count;
         at->next++) {
        uint32_t q = t->active[at->next];
        const crisp__patch_tree *pt = &t->patches[q];
        if (!pt->visible_leaves) continue;
        for (uint32_t l = 0; l < pt->leaf_count; l++) {
            const crisp__cell *c = &pt->leaves[l];
            if (c->culled) continue;
            crisp_plan_leaf *L = &p->leaves[at->leaf++];
            *L = (crisp_plan_leaf){.patch = q, .face = f, .depth = c->depth, .tau = c->tau};
            if (c->group) {
                L->group = c->group;
                L->block = c->ix | c->iy << 16;
            } else {
                L->ix = c->ix;
                L->iy = c->iy;
            }
            for (int k = 0; k < 4; k++)
                L->edge[k] = c->edge[k];
            at->triangles += leaf_triangles(L);
        }
    }
    pf->leaf_count = (uint32_t)at->leaf - pf->first_leaf;
}

/* The visible leaves, face after face (patches are stored face after face), and the faces' leaf
 * ranges and levels. kept (NULL: none): per face, its leaves are the earlier stages' (kept_leaves)
 * instead of the trees'. */
crisp_status crisp__planner_lay_out_leaves(crisp_planner *p, const crisp_scene *sc,
                                           const uint8_t *kept)
{
    size_t leaves;
    crisp_status st = grow_leaves(p, sc, kept, &leaves);
    if (st) return st;
    p->plain = 0;
    lay_out_at at = {0};
    for (uint32_t f = 0; f < sc->face_count; f++)
        lay_out_face_leaves(p, sc, kept, f, &p->faces[f], &at);
    p->out.leaf_count = (uint32_t)at.leaf;
    p->out.stats.triangles = at.triangles;
    return CRISP_OK;
}

/* The tables' room: the visible faces' strips, rows and crossings. listed: the faces with
 * face_tau > 0 are the trees' visible list (a plan in stages sets the kept faces' face_tau
 * without listing them: then every face is looked at). */
static crisp_status grow_tables(crisp_planner *p, const crisp_scene *sc, int listed)
{
    const crisp__trees *t = p->trees;
    size_t strips = 0, rows = 0, crossings = 0;
    size_t n = listed ? t->visible_count : sc->face_count;
    for (size_t i = 0; i < n; i++) {
        uint32_t f = listed ? t->visible[i] : (uint32_t)i;
        if (!t->face_tau[f]) continue;
        const crisp_trim_table *tb = &t->trims[f].table;
        if (tb->all_inside) continue;
        strips += (size_t)tb->strip_count;
        rows += tb->row_count;
        crossings += tb->row_count ? tb->row_offset[tb->row_count] : 0;
    }
    if (rows >= UINT32_MAX || crossings >= UINT32_MAX || strips >= UINT32_MAX)
        return crisp_error(CRISP_ERR_LIMIT, "trim tables of %zu rows and %zu crossings: too large",
                           rows, crossings);
    crisp_status st;
    if ((st = crisp_grow((void **)&p->strips, &p->strip_cap, strips ? strips : 1,
                         sizeof *p->strips)) ||
        (st = crisp_grow((void **)&p->row_offset, &p->row_cap, rows + 1, sizeof *p->row_offset)) ||
        (st = crisp_grow((void **)&p->crossings, &p->crossing_cap, crossings ? crossings : 1,
                         sizeof *p->crossings)))
        return st;
    p->row_offset[0] = 0;
    return CRISP_OK;
}

/* What the plan's face records take from the scene's faces (the patch grid, the orientation),
 * kept per scene: a face's record is then written from the planner's own arrays (imp49 far: the
 * scene face's line and its model face's line, another for `reversed`, read for 13,573 faces a
 * plan). */
static crisp_status ensure_face_fixed(crisp_planner *p, const crisp_scene *sc)
{
    if (p->fixed_serial == sc->serial && p->fixed_count == sc->face_count) return CRISP_OK;
    crisp_status st = crisp_grow((void **)&p->face_fixed, &p->face_fixed_cap,
                                 sc->face_count ? sc->face_count : 1, sizeof *p->face_fixed);
    if (st) return st;
    for (uint32_t f = 0; f < sc->face_count; f++) {
        const crisp_scene_face *sf = &sc->faces[f];
        p->face_fixed[f] = (crisp__face_fixed){sf->grid_u, sf->grid_v,
                                               sf->src->reversed ? CRISP_PLAN_FACE_REVERSED : 0};
    }
    p->fixed_serial = sc->serial;
    p->fixed_count = sc->face_count;
    p->plain = 0;
    return CRISP_OK;
}

/* Face f's trim table appended at at's strips, rows and crossings; its table fields and flags
 * (no CRISP_PLAN_FACE_SPLATS) in pf. */
static inline void lay_out_face_table(crisp_planner *p, uint32_t f, crisp_plan_face *pf,
                                      lay_out_at *at)
{
    const crisp__trees *t = p->trees;
    pf->first_strip = (uint32_t)at->strip;
    pf->strip_count = 0;
    pf->v0 = pf->v1 = pf->strip_scale = 0;
    pf->flags = p->face_fixed[f].flags;
    if (!t->face_tau[f]) return;
    const crisp_trim_table *tb = &t->trims[f].table;
    pf->flags |= CRISP_PLAN_FACE_VISIBLE;
    pf->v0 = tb->v0;
    pf->v1 = tb->v1;
    pf->strip_scale = tb->strip_scale;
    if (tb->all_inside) {
        pf->flags |= CRISP_PLAN_FACE_ALL_INSIDE;
        return;
    }
    pf->strip_count = (uint32_t)tb->strip_count;
    for (int i = 0; i < tb->strip_count; i++) {
        crisp_plan_strip *ps = &p->strips[at->strip++];
        ps->a = tb->row_v[2 * i];
        ps->row_scale = tb->row_scale[i];
        ps->first_row = (uint32_t)at->row + tb->row_base[i];
        ps->row_count = tb->row_base[i + 1] - tb->row_base[i];
    }
    uint32_t nc = tb->row_count ? tb->row_offset[tb->row_count] : 0;
    for (uint32_t r = 0; r < tb->row_count; r++)
        p->row_offset[at->row + r + 1] = (uint32_t)at->crossing + tb->row_offset[r + 1];
    if (nc) memcpy(p->crossings + at->crossing, tb->u, nc * sizeof(double));
    at->row += tb->row_count;
    at->crossing += nc;
}

static void tables_counted(crisp_planner *p, const lay_out_at *at)
{
    p->out.strip_count = (uint32_t)at->strip;
    p->out.row_count = (uint32_t)at->row;
    p->out.crossing_count = (uint32_t)at->crossing;
}

/* Every visible face's trim table, concatenated: strips, rows (global offsets), crossings. */
crisp_status crisp__planner_lay_out_tables(crisp_planner *p, const crisp_scene *sc)
{
    crisp_status st;
    if ((st = ensure_face_fixed(p, sc)) || (st = grow_tables(p, sc, 0))) return st;
    p->plain = 0;
    lay_out_at at = {0};
    for (uint32_t f = 0; f < sc->face_count; f++)
        lay_out_face_table(p, f, &p->faces[f], &at);
    tables_counted(p, &at);
    return CRISP_OK;
}

crisp_status crisp__planner_ensure_faces(crisp_planner *p, uint32_t faces)
{
    crisp_status st;
    size_t n = faces ? faces : 1;
    if ((st = crisp_grow((void **)&p->faces, &p->face_cap, n, sizeof *p->faces)) ||
        (st = crisp_grow((void **)&p->ribbon_first, &p->ribbon_first_cap, n,
                         sizeof *p->ribbon_first)) ||
        (st = crisp_grow((void **)&p->ribbon_quads, &p->ribbon_quads_cap, n,
                         sizeof *p->ribbon_quads)) ||
        (st = crisp_grow((void **)&p->strips_used, &p->strips_used_cap, n,
                         sizeof *p->strips_used)) ||
        (st = crisp_grow((void **)&p->splat_face, &p->splat_face_cap, n, sizeof *p->splat_face)))
        return st;
    return CRISP_OK;
}

/* Face f's ribbon range and patch grid in pf (ensure_face_fixed done). */
static inline void point_out_face(const crisp_planner *p, uint32_t f, crisp_plan_face *pf)
{
    pf->first_ribbon = p->ribbon_first[f];
    pf->ribbon_count = p->trees->face_tau[f] ? p->ribbon_quads[f] : 0;
    pf->grid_u = p->face_fixed[f].grid_u;
    pf->grid_v = p->face_fixed[f].grid_v;
}

static void point_out_arrays(crisp_planner *p, const crisp_scene *sc)
{
    crisp_frame_plan *o = &p->out;
    o->leaves = p->leaves;
    o->faces = p->faces;
    o->face_count = sc->face_count;
    o->strips = p->strips;
    o->row_offset = p->row_offset;
    o->crossings = p->crossings;
    o->ribbon_vertices = p->ribbon_verts;
}

/* The faces' ribbon ranges and patch grids, and the public plan pointed at the arrays (after
 * crisp__planner_lay_out_tables, which keeps the grids). */
void crisp__planner_point_out(crisp_planner *p, const crisp_scene *sc)
{
    p->plain = 0;
    for (uint32_t f = 0; f < sc->face_count; f++)
        point_out_face(p, f, &p->faces[f]);
    point_out_arrays(p, sc);
}

/* The 8 bytes of two uint32_t fields in a row, lo first in memory (whatever the byte order). */
static inline uint64_t word_pair(uint32_t lo, uint32_t hi)
{
    uint32_t v[2] = {lo, hi};
    uint64_t w;
    memcpy(&w, v, sizeof w);
    return w;
}

/* The three above and the splat faces' flag in one pass over the faces, each face's record
 * written once and hashed as it is written (*face_hash: hash_bytes of the faces' array): at imp49
 * far (13,573 faces, all drawn as splats) the four passes and the hash read and wrote the 870 KB
 * array five times a plan. */
static crisp_status lay_out_faces(crisp_planner *p, const crisp_scene *sc, const uint8_t *kept,
                                  uint64_t *face_hash)
{
    crisp_status st;
    size_t leaves;
    if ((st = ensure_face_fixed(p, sc)) || (st = grow_leaves(p, sc, kept, &leaves)) ||
        (st = grow_tables(p, sc, !kept)))
        return st;
    _Static_assert(sizeof(crisp_plan_face) == 64, "a face record: two hash4 blocks");
    const crisp__trees *t = p->trees;
    lay_out_at at = {0};
    /* No face planned as patches (a far view): every record is its face's plain one (no leaves,
     * no table, no ribbons, all at 0), which differs from face to face only by its splat flag.
     * When the array holds the plain records already (p->plain, the last lay-out's) with the
     * same splat faces, it is left as it is: a far view whose splat faces stay the same writes
     * no record (imp49 far: 13,573 records, 870 KB, a plan). */
    int plain = !kept && !t->visible_count && !leaves;
    size_t nf = sc->face_count ? sc->face_count : 1;
    if (plain && p->plain && !memcmp(p->plain_splat, p->splat_face, sc->face_count)) {
        *face_hash = p->plain_hash;
        p->out.leaf_count = 0;
        p->out.stats.triangles = 0;
        tables_counted(p, &at);
        point_out_arrays(p, sc);
        return CRISP_OK;
    }
    p->plain = 0;
    if (plain && (st = crisp_grow((void **)&p->plain_splat, &p->plain_splat_cap, nf, 1))) return st;
    hash4 h = hash4_start();
    for (uint32_t f = 0; f < sc->face_count; f++) {
        crisp_plan_face *pf = &p->faces[f];
        uint32_t splat = p->splat_face[f] ? CRISP_PLAN_FACE_SPLATS : 0;
        if (t->face_tau[f] || (kept && kept[f]) ||
            (at.next < t->active_count &&
             t->active[at.next] < sc->faces[f].first_patch + sc->faces[f].patch_count)) {
            lay_out_face_leaves(p, sc, kept, f, pf, &at);
            lay_out_face_table(p, f, pf, &at);
            point_out_face(p, f, pf);
            pf->flags |= splat;
            hash4_step(&h, pf);
            hash4_step(&h, (const unsigned char *)pf + 32);
            continue;
        }
        /* A face without leaves or a table (most faces of a far view: splats or culled): what
         * the three steps write, as the record's eight words (plan_layout.c's offsets; v0, v1
         * and strip_scale 0.0) built in registers. */
        const crisp__face_fixed *fx = &p->face_fixed[f];
        uint64_t w[8] = {0,
                         0,
                         0,
                         word_pair((uint32_t)at.strip, 0),
                         word_pair((uint32_t)at.leaf, 0),
                         word_pair(fx->flags | splat, 0),
                         word_pair(p->ribbon_first[f], 0),
                         word_pair(fx->grid_u, fx->grid_v)};
        memcpy(pf, w, sizeof w);
        hash4_step(&h, w);
        hash4_step(&h, w + 4);
    }
    p->out.leaf_count = (uint32_t)at.leaf;
    p->out.stats.triangles = at.triangles;
    tables_counted(p, &at);
    point_out_arrays(p, sc);
    *face_hash = hash4_end(h, NULL, 0);
    if (plain) {
        memcpy(p->plain_splat, p->splat_face, sc->face_count);
        p->plain_hash = *face_hash;
        p->plain = 1;
    }
    return CRISP_OK;
}

/* Bump what changed. After a re-plan of one face (one_face) the leaves are known unchanged and
 * the tables and ribbons known changed: hashing them (megabytes of ribbons on a large model) would
 * cost more than the re-plan, so their versions move without it and their hashes are forgotten
 * (the next full plan bumps them once more, which only re-sends them). face_hash: the faces'
 * hash when the caller has it (lay_out_faces), else NULL. */
static void publish(crisp_planner *p, const crisp_scene *sc, int one_face,
                    const uint64_t *face_hash)
{
    crisp_frame_plan *o = &p->out;
    uint64_t *version[4] = {&o->leaves_version, &o->faces_version, &o->table_version,
                            &o->ribbons_version};
    uint64_t hf = face_hash ? *face_hash : hash_bytes(p->faces, sc->face_count * sizeof *p->faces);
    if (one_face) {
        if (hf != p->hash[1]) o->faces_version++, p->hash[1] = hf;
        o->table_version++;
        o->ribbons_version++;
        p->hash[2] = p->hash[3] = 0;
    } else {
        uint64_t h[4] = {
            hash_bytes(p->leaves, o->leaf_count * sizeof *p->leaves), hf,
            hash_bytes(p->strips, o->strip_count * sizeof *p->strips) ^
                3 * hash_bytes(p->row_offset, (o->row_count + 1) * sizeof *p->row_offset) ^
                7 * hash_bytes(p->crossings, o->crossing_count * sizeof *p->crossings),
            hash_bytes(p->ribbon_verts,
                       4 * (size_t)o->ribbon_quad_count * sizeof *p->ribbon_verts)};
        for (int k = 0; k < 4; k++)
            if (!p->planned || h[k] != p->hash[k]) {
                (*version[k])++;
                p->hash[k] = h[k];
            }
    }
    o->stats.table_bytes = crisp_plan_bytes(o) - (size_t)o->leaf_count * sizeof *p->leaves -
                           (size_t)sc->face_count * sizeof *p->faces -
                           4 * (size_t)o->ribbon_quad_count * sizeof *p->ribbon_verts;
    o->stats.table_rows = o->row_count;
    o->stats.ribbon_quads = o->ribbon_quad_count;
}

/* Which faces are drawn as splats this frame (p->splat_face; none when no_splats). */
crisp_status crisp__planner_choose_splats(crisp_planner *p, const crisp_scene *sc,
                                          const crisp_camera *cam)
{
    if (p->desc.no_splats) {
        memset(p->splat_face, 0, sc->face_count ? sc->face_count : 1);
        return CRISP_OK;
    }
    crisp_camera_matrices cm;
    crisp_camera_matrices_compute(cam, &cm);
    return crisp__splat_store_choose(p->splats, sc, cm.view_proj, cam->width, cam->height,
                                     p->desc.splat_build_limit, p->pool, p->splat_face);
}

/* The trees, leaves, tables and ribbons of the faces not in skip (NULL: the splat faces only),
 * and the plan's view fields and stats. The splat choice is made first unless splats_chosen. */
crisp_status crisp__planner_plan_faces(crisp_planner *p, const crisp_scene *sc,
                                       const crisp_camera *cam, const uint8_t *skip,
                                       int splats_chosen)
{
    crisp_status st;
    /* Faces drawn as splats (issue 12, splat_store.c) are chosen first: they get no leaves, trim
     * table or ribbons. */
    double ts = crisp_time_now();
    if (!splats_chosen && (st = crisp__planner_choose_splats(p, sc, cam))) return st;
    double ms_splats = 1e3 * (crisp_time_now() - ts);
    crisp__trees_desc td = {.eps_px = p->desc.eps_px,
                            .strip_count = p->desc.strip_count,
                            .max_depth = p->desc.max_depth,
                            .no_groups = p->desc.no_groups,
                            .skip_faces = skip ? skip : p->splat_face};
    if ((st = crisp__trees_build(p->trees, sc, cam, &td, p->pool))) return st;
    double t0 = crisp_time_now();
    crisp_frame_plan *o = &p->out;
    o->ribbon_quad_count = 0;
    memset(p->ribbon_quads, 0, sc->face_count * sizeof *p->ribbon_quads);
    memset(p->ribbon_first, 0, sc->face_count * sizeof *p->ribbon_first);
    /* No face planned as patches (a far view of splats): no ribbon, every face's range empty at
     * 0, as the build would lay them out, without its passes over the faces. */
    int none = !p->trees->visible_count && p->ribbon_verts;
    if (!p->desc.no_ribbons && sc->face_count && !none &&
        (st = crisp__ribbons_build(p->ribbons, p->trees, sc, UINT32_MAX, p->pool, &p->ribbon_verts,
                                   &p->ribbon_cap, p->ribbon_first, p->ribbon_quads,
                                   &o->ribbon_quad_count)))
        return st;
    double t1 = crisp_time_now();
    crisp_mat4_copy(p->trees->view_proj, o->view_proj);
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 4; r++)
            o->view_proj_f[4 * c + r] = (float)o->view_proj[c][r];
    memcpy(o->eye, cam->eye, sizeof o->eye);
    o->width = cam->width;
    o->height = cam->height;
    o->eps_px = p->desc.eps_px > 0 ? p->desc.eps_px : 0.5;
    o->stats = p->trees->stats;
    o->stats.ms_ribbons = 1e3 * (t1 - t0);
    o->stats.ms_levels += ms_splats; /* the splat choice counts as level choice */
    return CRISP_OK;
}

/* Leaves and tables laid out (kept: as lay_out_leaves), the splats and the versions published. */
crisp_status crisp__planner_finish_plan(crisp_planner *p, const crisp_scene *sc,
                                        const crisp_camera *cam, const uint8_t *kept)
{
    crisp_status st;
    crisp_frame_plan *o = &p->out;
    crisp_plan_stats stats = o->stats;
    uint64_t face_hash;
    if ((st = lay_out_faces(p, sc, kept, &face_hash))) return st;
    stats.triangles = o->stats.triangles;
    o->stats = stats;
    /* (the faces planned this frame: the others' trim plans, and so their counts, are as before;
     * a face without a plan is not re-planned) */
    for (size_t i = 0; i < p->trees->visible_count; i++) {
        uint32_t f = p->trees->visible[i];
        p->strips_used[f] = p->trees->trims[f].strip_count;
    }
    /* (the splat faces' flags are lay_out_faces') */
    if ((st = crisp__splat_store_publish(p->splats, sc, p->splat_face, NULL, o))) return st;
    publish(p, sc, 0, &face_hash);
    p->cam = *cam;
    p->scene = sc;
    p->planned = 1;
    p->finished = 1;
    return CRISP_OK;
}

crisp_status crisp_planner_plan(crisp_planner *p, const crisp_scene *sc, const crisp_camera *cam,
                                const crisp_frame_plan **dest)
{
    crisp_status st = crisp_camera_check(cam);
    if (st) return st;
    if ((st = crisp__planner_ensure_faces(p, sc->face_count))) return st;
    p->staged = 0;
    p->finished = 0;
    if ((st = crisp__planner_plan_faces(p, sc, cam, NULL, 0)) ||
        (st = crisp__planner_finish_plan(p, sc, cam, NULL)))
        return st;
    *dest = &p->out;
    return CRISP_OK;
}

const crisp_frame_plan *crisp_planner_last_plan(const crisp_planner *p)
{
    return p->finished ? &p->out : NULL;
}

crisp_status crisp_planner_replan_face(crisp_planner *p, const crisp_scene *sc, uint32_t face,
                                       const crisp_frame_plan **dest)
{
    if (!p->planned || p->scene != sc)
        return crisp_error(
            CRISP_ERR_INVALID_ARG,
            "re-planning face %u: plan the whole scene with crisp_planner_plan first", face);
    if (face >= sc->face_count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "face %u: the scene has %u faces", face,
                           sc->face_count);
    /* Splats: the face's sets are of its old trim. A face drawn as splats is planned again
     * whole (its new set may be over its budget: then it needs leaves). */
    crisp__splat_store_drop_face(p->splats, face);
    /* After a plan in stages the trees hold the last stage's faces only: plan again whole. */
    if (p->splat_face[face] || p->staged) return crisp_planner_plan(p, sc, &p->cam, dest);
    double t0 = crisp_time_now();
    p->finished = 0;
    crisp_status st = crisp__trees_replan_trim(p->trees, sc, face, p->strips_used[face]);
    if (st) return st;
    if ((st = crisp__planner_lay_out_tables(p, sc))) return st;
    if ((st = crisp__splat_store_publish(p->splats, sc, p->splat_face, p->faces, &p->out)))
        return st;
    double t1 = crisp_time_now();
    crisp_frame_plan *o = &p->out;
    if (!p->desc.no_ribbons && p->trees->face_tau[face]) {
        uint32_t first = 0, quads = 0, total = 0;
        if ((st = crisp__ribbons_build(p->ribbons, p->trees, sc, face, p->pool, &p->face_ribbon,
                                       &p->face_ribbon_cap, &first, &quads, &total)))
            return st;
        /* Splice the face's new quads in place of its old ones. */
        uint32_t old_first = p->ribbon_first[face], old_count = p->ribbon_quads[face];
        size_t after = o->ribbon_quad_count - (old_first + old_count);
        size_t n = (size_t)o->ribbon_quad_count - old_count + total;
        if ((st = crisp_grow((void **)&p->ribbon_verts, &p->ribbon_cap, 4 * (n ? n : 1),
                             sizeof *p->ribbon_verts)))
            return st;
        memmove(p->ribbon_verts + 4 * ((size_t)old_first + total),
                p->ribbon_verts + 4 * ((size_t)old_first + old_count),
                4 * after * sizeof *p->ribbon_verts);
        memcpy(p->ribbon_verts + 4 * (size_t)old_first, p->face_ribbon,
               4 * (size_t)total * sizeof *p->face_ribbon);
        for (uint32_t f = 0; f < sc->face_count; f++)
            if (p->ribbon_first[f] > old_first)
                p->ribbon_first[f] = p->ribbon_first[f] - old_count + total;
        p->ribbon_quads[face] = total;
        o->ribbon_quad_count = (uint32_t)n;
    }
    double t2 = crisp_time_now();
    /* Stats: the re-planned face's table replaces its old one in the counters. */
    o->stats.ms_levels = o->stats.ms_edges = 0;
    o->stats.ms_trim = 1e3 * (t1 - t0);
    o->stats.ms_ribbons = 1e3 * (t2 - t1);
    crisp__planner_point_out(p, sc);
    publish(p, sc, 1, NULL);
    p->finished = 1;
    *dest = o;
    return CRISP_OK;
}

uint32_t crisp_plan_leaf_locate(const crisp_frame_plan *plan, const crisp_plan_leaf *L, double S,
                                double T, double *s, double *t)
{
    if (!L->group) {
        double scale = ldexp(1.0, -(int)L->depth);
        *s = (L->ix + S) * scale;
        *t = (L->iy + T) * scale;
        return L->patch;
    }
    uint32_t nu = L->block & 0xffffu, nv = L->block >> 16;
    double x = S * nu, y = T * nv;
    double cx = floor(x), cy = floor(y);
    if (cx > nu - 1) cx = nu - 1;
    if (cy > nv - 1) cy = nv - 1;
    if (cx < 0) cx = 0;
    if (cy < 0) cy = 0;
    *s = x - cx;
    *t = y - cy;
    return L->patch + (uint32_t)cy * plan->faces[L->face].grid_u + (uint32_t)cx;
}

int crisp_plan_trim_test(const crisp_frame_plan *plan, uint32_t face, double u, double v)
{
    const crisp_plan_face *f = &plan->faces[face];
    if (!(v >= f->v0 && v <= f->v1)) return 0;
    if (f->flags & CRISP_PLAN_FACE_ALL_INSIDE) return 1;
    uint32_t n = f->strip_count;
    if (!n) return 0;
    double fi = (v - f->v0) * f->strip_scale; /* >= 0 here */
    uint32_t i = fi < (double)n ? (uint32_t)fi : n - 1;
    const crisp_plan_strip *s = &plan->strips[f->first_strip + i];
    uint32_t mu = s->row_count;
    if (!mu) return 0;
    double fj = (v - s->a) * s->row_scale;
    uint32_t j = fj > 0.0 ? (fj < (double)mu ? (uint32_t)fj : mu - 1) : 0; /* clamped to the rows */
    uint32_t r = s->first_row + j;
    /* Crossings strictly left of u: the first index with crossing >= u. */
    uint32_t lo = plan->row_offset[r], hi = plan->row_offset[r + 1], first = lo;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (plan->crossings[mid] < u)
            lo = mid + 1;
        else
            hi = mid;
    }
    return (int)((lo - first) & 1u);
}

size_t crisp_plan_bytes(const crisp_frame_plan *plan)
{
    return (size_t)plan->leaf_count * sizeof(crisp_plan_leaf) +
           (size_t)plan->face_count * sizeof(crisp_plan_face) +
           (size_t)plan->strip_count * sizeof(crisp_plan_strip) +
           ((size_t)plan->row_count + 1) * sizeof(uint32_t) +
           (size_t)plan->crossing_count * sizeof(double) +
           4 * (size_t)plan->ribbon_quad_count * sizeof(crisp_plan_ribbon_vertex);
}

const crisp_trim_table *crisp__planner_table(const crisp_planner *p, uint32_t f)
{
    return &p->trees->trims[f].table;
}
