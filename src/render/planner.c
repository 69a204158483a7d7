/* The public frame planner (include/crisp/plan.h): runs the per-patch quadtrees and trim plans
 * (quadtree.c) and the ribbons (ribbon.c), then lays their results out as the flat, read-only
 * arrays every backend takes: visible leaves grouped by face, a record per face, the faces' trim
 * tables concatenated (strips, rows, crossings), the ribbon quads. Buffers are kept from frame to
 * frame; each array's version is bumped only when its bytes changed, so a GPU backend uploads only
 * what changed (a trim edit with a still camera uploads one table, not the leaves). The CPU
 * backend's frames are planned in stages (crisp__planner_plan_near / _next, render_internal.h):
 * the faces that the depth drawn by the earlier stages hides whole are not planned at all. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/plan.h"
#include "quadtree.h"
#include "render_internal.h"
#include "ribbon.h"
#include "occlusion.h"
#include "splat_store.h"

struct crisp_planner {
    crisp_planner_desc desc;
    crisp_pool *pool;
    crisp__trees *trees;
    crisp__ribbons *ribbons;
    crisp_frame_plan out;
    crisp_plan_leaf *leaves;
    size_t leaf_cap;
    crisp_plan_face *faces;
    size_t face_cap;
    crisp_plan_strip *strips;
    size_t strip_cap;
    uint32_t *row_offset;
    size_t row_cap;
    double *crossings;
    size_t crossing_cap;
    crisp_plan_ribbon_vertex *ribbon_verts, *face_ribbon; /* all; one face's (replan) */
    size_t ribbon_cap, face_ribbon_cap;
    uint32_t *ribbon_first, *ribbon_quads; /* per face */
    size_t ribbon_first_cap, ribbon_quads_cap;
    int *strips_used; /* per face: the strip count of its last trim plan (replan keeps it) */
    size_t strips_used_cap;
    uint64_t hash[4]; /* leaves, faces, table, ribbons of the last plan */
    crisp__splat_store *splats;
    uint8_t *splat_face; /* per face: drawn as splats this frame */
    size_t splat_face_cap;
    crisp_camera cam; /* of the last plan (a re-plan of a splatted face plans it again) */
    const crisp_scene *scene;
    int planned;
    /* Plans in stages (crisp__planner_plan_near / _next): */
    uint8_t *stage; /* per face: its stage (splat faces 0), STAGE_HIDDEN when found hidden */
    uint8_t *later; /* per face: planned by the current stage (in the final plan: drawn last) */
    uint8_t *skip;  /* per face: not planned by this trees build */
    size_t stage_cap, later_cap, skip_cap;
    int staged; /* 0: the last plan was made in one stage; 1: in stages (final); 2: a stage's */
    int stage_at, stage_count;
    uint32_t hidden;              /* faces found hidden so far this frame */
    crisp_plan_leaf *kept_leaves; /* the stages' leaves, stage after stage */
    size_t kept_leaf_cap, kept_leaf_count;
    crisp_plan_ribbon_vertex *kept_ribbons; /* the stages' ribbon quads, stage after stage */
    size_t kept_ribbon_cap, kept_quads;
    uint32_t *kept; /* per face: first leaf, leaf count, first quad, quad count, tau in kept */
    float *kept_rows;
    size_t kept_cap, kept_rows_cap;
    crisp_plan_stats kept_stats; /* the stages' plan stats, summed */
    uint8_t *seen; /* per face: it had a sample in the last frame drawn in stages (the first
                      stage's faces next time: an order, not a decision) */
    size_t seen_cap;
    uint64_t seen_serial; /* the scene the marks are of (0: none) */
    /* Whether stages pay (crisp__planner_plan_near): after a frame in stages of scene pays_serial
     * that hid too little, frames are planned in one stage, and every STAGE_PROBE-th one in
     * stages again. */
    uint64_t pays_serial;
    int pays;
    uint32_t quiet;   /* frames in one stage since */
    int always;       /* crisp__planner_always_stages */
    double *face_box; /* per face: the union of its patches' boxes (of face_box_serial) */
    size_t face_box_cap;
    uint8_t *patch_in; /* per patch: its parameter box meets its face's trim pieces' box */
    size_t patch_in_cap;
    uint64_t face_box_serial, face_box_trim;
};

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
    free(p->stage);
    free(p->later);
    free(p->skip);
    free(p->kept_leaves);
    free(p->kept_ribbons);
    free(p->kept);
    free(p->kept_rows);
    free(p->seen);
    free(p->face_box);
    free(p->patch_in);
    free(p);
}

/* FNV-1a over 64-bit words (the arrays are multiples of 8 bytes, or padded by the caller). */
static uint64_t hash_bytes(const void *data, size_t bytes)
{
    const unsigned char *b = data;
    uint64_t h = 1469598103934665603ull;
    size_t k = 0;
    for (; k + 8 <= bytes; k += 8) {
        uint64_t w;
        memcpy(&w, b + k, 8);
        h = (h ^ w) * 1099511628211ull;
    }
    for (; k < bytes; k++)
        h = (h ^ b[k]) * 1099511628211ull;
    return h;
}

/* Triangles of a leaf at its levels (0 when refused: the draw reports it). */
static uint64_t leaf_triangles(const crisp_plan_leaf *L)
{
    crisp_tess_levels lv = {{(int)L->tau, (int)L->tau},
                            {(int)L->edge[0], (int)L->edge[1], (int)L->edge[2], (int)L->edge[3]}};
    size_t nv, nt;
    return crisp_tess_mesh_counts(&lv, &nv, &nt) ? 0 : nt;
}

/* The visible leaves, face after face (patches are stored face after face), and the faces' leaf
 * ranges and levels. kept (NULL: none): per face, its leaves are the earlier stages' (kept_leaves)
 * instead of the trees'. */
static crisp_status lay_out_leaves(crisp_planner *p, const crisp_scene *sc, const uint8_t *kept)
{
    const crisp__trees *t = p->trees;
    size_t n = 0;
    for (size_t i = 0; i < t->active_count; i++)
        n += t->patches[t->active[i]].visible_leaves;
    if (kept)
        for (uint32_t f = 0; f < sc->face_count; f++)
            if (kept[f]) n += p->kept[5 * (size_t)f + 1];
    if (n > UINT32_MAX / 2)
        return crisp_error(CRISP_ERR_LIMIT, "%zu leaves in one frame: too many", n);
    crisp_status st = crisp_grow((void **)&p->leaves, &p->leaf_cap, n ? n : 1, sizeof *p->leaves);
    if (st) return st;
    uint64_t triangles = 0;
    size_t at = 0, next = 0; /* the active patches are ascending: face after face */
    for (uint32_t f = 0; f < sc->face_count; f++) {
        const crisp_scene_face *sf = &sc->faces[f];
        crisp_plan_face *pf = &p->faces[f];
        pf->first_leaf = (uint32_t)at;
        if (kept && kept[f]) {
            const uint32_t *k = p->kept + 5 * (size_t)f;
            for (uint32_t l = 0; l < k[1]; l++) {
                p->leaves[at] = p->kept_leaves[k[0] + l];
                triangles += leaf_triangles(&p->leaves[at++]);
            }
            pf->leaf_count = k[1];
            pf->tau_max = t->face_tau[f];
            continue;
        }
        for (; next < t->active_count && t->active[next] < sf->first_patch + sf->patch_count;
             next++) {
            uint32_t q = t->active[next];
            const crisp__patch_tree *pt = &t->patches[q];
            if (!pt->visible_leaves) continue;
            for (uint32_t l = 0; l < pt->leaf_count; l++) {
                const crisp__cell *c = &pt->leaves[l];
                if (c->culled) continue;
                crisp_plan_leaf *L = &p->leaves[at++];
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
                triangles += leaf_triangles(L);
            }
        }
        pf->leaf_count = (uint32_t)at - pf->first_leaf;
        pf->tau_max = t->face_tau[f];
    }
    p->out.leaf_count = (uint32_t)at;
    p->out.stats.triangles = triangles;
    return CRISP_OK;
}

/* Every visible face's trim table, concatenated: strips, rows (global offsets), crossings. */
static crisp_status lay_out_tables(crisp_planner *p, const crisp_scene *sc)
{
    const crisp__trees *t = p->trees;
    size_t strips = 0, rows = 0, crossings = 0;
    for (uint32_t f = 0; f < sc->face_count; f++) {
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
    size_t s_at = 0, r_at = 0, c_at = 0;
    p->row_offset[0] = 0;
    for (uint32_t f = 0; f < sc->face_count; f++) {
        crisp_plan_face *pf = &p->faces[f];
        pf->first_strip = (uint32_t)s_at;
        pf->strip_count = 0;
        pf->v0 = pf->v1 = pf->strip_scale = 0;
        pf->flags = sc->faces[f].src->reversed ? CRISP_PLAN_FACE_REVERSED : 0;
        if (!t->face_tau[f]) continue;
        const crisp_trim_table *tb = &t->trims[f].table;
        pf->flags |= CRISP_PLAN_FACE_VISIBLE;
        pf->v0 = tb->v0;
        pf->v1 = tb->v1;
        pf->strip_scale = tb->strip_scale;
        if (tb->all_inside) {
            pf->flags |= CRISP_PLAN_FACE_ALL_INSIDE;
            continue;
        }
        pf->strip_count = (uint32_t)tb->strip_count;
        for (int i = 0; i < tb->strip_count; i++) {
            crisp_plan_strip *ps = &p->strips[s_at++];
            ps->a = tb->row_v[2 * i];
            ps->row_scale = tb->row_scale[i];
            ps->first_row = (uint32_t)r_at + tb->row_base[i];
            ps->row_count = tb->row_base[i + 1] - tb->row_base[i];
        }
        uint32_t nc = tb->row_count ? tb->row_offset[tb->row_count] : 0;
        for (uint32_t r = 0; r < tb->row_count; r++)
            p->row_offset[r_at + r + 1] = (uint32_t)c_at + tb->row_offset[r + 1];
        if (nc) memcpy(p->crossings + c_at, tb->u, nc * sizeof(double));
        r_at += tb->row_count;
        c_at += nc;
    }
    p->out.strip_count = (uint32_t)s_at;
    p->out.row_count = (uint32_t)r_at;
    p->out.crossing_count = (uint32_t)c_at;
    return CRISP_OK;
}

static crisp_status ensure_faces(crisp_planner *p, uint32_t faces)
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

/* Point the public plan at the arrays, set the ribbon ranges, and bump what changed. After a
 * re-plan of one face (one_face) the leaves are known unchanged and the tables and ribbons known
 * changed: hashing them (megabytes of ribbons on a large model) would cost more than the re-plan,
 * so their versions move without it and their hashes are forgotten (the next full plan bumps
 * them once more, which only re-sends them). */
/* The faces' ribbon ranges and patch grids. */
static void face_ribbons_grids(crisp_planner *p, const crisp_scene *sc)
{
    for (uint32_t f = 0; f < sc->face_count; f++) {
        p->faces[f].first_ribbon = p->ribbon_first[f];
        p->faces[f].ribbon_count = p->trees->face_tau[f] ? p->ribbon_quads[f] : 0;
        p->faces[f].grid_u = sc->faces[f].grid_u;
        p->faces[f].grid_v = sc->faces[f].grid_v;
    }
}

static void publish(crisp_planner *p, const crisp_scene *sc, int one_face)
{
    crisp_frame_plan *o = &p->out;
    face_ribbons_grids(p, sc);
    o->leaves = p->leaves;
    o->faces = p->faces;
    o->face_count = sc->face_count;
    o->strips = p->strips;
    o->row_offset = p->row_offset;
    o->crossings = p->crossings;
    o->ribbon_vertices = p->ribbon_verts;
    uint64_t *version[4] = {&o->leaves_version, &o->faces_version, &o->table_version,
                            &o->ribbons_version};
    if (one_face) {
        uint64_t hf = hash_bytes(p->faces, sc->face_count * sizeof *p->faces);
        if (hf != p->hash[1]) o->faces_version++, p->hash[1] = hf;
        o->table_version++;
        o->ribbons_version++;
        p->hash[2] = p->hash[3] = 0;
    } else {
        uint64_t h[4] = {
            hash_bytes(p->leaves, o->leaf_count * sizeof *p->leaves),
            hash_bytes(p->faces, sc->face_count * sizeof *p->faces),
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
static crisp_status choose_splats(crisp_planner *p, const crisp_scene *sc, const crisp_camera *cam)
{
    memset(p->splat_face, 0, sc->face_count ? sc->face_count : 1);
    if (p->desc.no_splats) return CRISP_OK;
    crisp_camera_matrices cm;
    crisp_camera_matrices_compute(cam, &cm);
    return crisp__splat_store_choose(p->splats, sc, cm.view_proj, cam->width, cam->height,
                                     p->desc.splat_build_limit, p->pool, p->splat_face);
}

/* The trees, leaves, tables and ribbons of the faces not in skip (NULL: the splat faces only),
 * and the plan's view fields and stats. The splat choice is made first unless splats_chosen. */
static crisp_status plan_faces(crisp_planner *p, const crisp_scene *sc, const crisp_camera *cam,
                               const uint8_t *skip, int splats_chosen)
{
    crisp_status st;
    /* Faces drawn as splats (issue 12, splat_store.c) are chosen first: they get no leaves, trim
     * table or ribbons. */
    double ts = crisp_time_now();
    if (!splats_chosen && (st = choose_splats(p, sc, cam))) return st;
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
    if (!p->desc.no_ribbons && sc->face_count &&
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
static crisp_status finish_plan(crisp_planner *p, const crisp_scene *sc, const crisp_camera *cam,
                                const uint8_t *kept)
{
    crisp_status st;
    crisp_frame_plan *o = &p->out;
    crisp_plan_stats stats = o->stats;
    if ((st = lay_out_leaves(p, sc, kept))) return st;
    stats.triangles = o->stats.triangles;
    o->stats = stats;
    if ((st = lay_out_tables(p, sc))) return st;
    for (uint32_t f = 0; f < sc->face_count; f++)
        p->strips_used[f] = p->trees->trims[f].strip_count;
    if ((st = crisp__splat_store_publish(p->splats, sc, p->splat_face, p->faces, o))) return st;
    publish(p, sc, 0);
    p->cam = *cam;
    p->scene = sc;
    p->planned = 1;
    return CRISP_OK;
}

crisp_status crisp_planner_plan(crisp_planner *p, const crisp_scene *sc, const crisp_camera *cam,
                                const crisp_frame_plan **dest)
{
    crisp_status st = crisp_camera_check(cam);
    if (st) return st;
    if ((st = ensure_faces(p, sc->face_count))) return st;
    p->staged = 0;
    if ((st = plan_faces(p, sc, cam, NULL, 0)) || (st = finish_plan(p, sc, cam, NULL))) return st;
    *dest = &p->out;
    return CRISP_OK;
}

/* ---- stages: the nearest faces drawn first, then the others their depth does not hide -------- */

/* Per face, the union of its patches' boxes; per patch, whether its parameter box meets the box
 * of its face's trim pieces' control points (kept while the scene and its trims are the same). A
 * point of the face that the trim table keeps lies in that box: the table keeps only v in the
 * pieces' v-range, and u between two crossings of its row with the trim polylines, whose vertices
 * are points of the pieces (crisp_trim_tessellate; chains and levels of detail join such
 * vertices), so in their control points' convex hulls; the ribbons' curve points too. A face
 * without pieces keeps every patch. */
static crisp_status face_boxes(crisp_planner *p, const crisp_scene *sc)
{
    if (p->face_box && p->face_box_serial == sc->serial && p->face_box_trim == sc->trim_serial)
        return CRISP_OK;
    crisp_status st;
    if ((st = crisp_grow((void **)&p->face_box, &p->face_box_cap,
                         6 * (size_t)(sc->face_count ? sc->face_count : 1), sizeof(double))) ||
        (st = crisp_grow((void **)&p->patch_in, &p->patch_in_cap,
                         sc->patch_count ? sc->patch_count : 1, 1)))
        return st;
    for (uint32_t f = 0; f < sc->face_count; f++) {
        double *b = p->face_box + 6 * (size_t)f;
        for (int a = 0; a < 3; a++)
            b[a] = INFINITY, b[a + 3] = -INFINITY;
        const crisp_scene_face *sf = &sc->faces[f];
        double t[4] = {INFINITY, -INFINITY, INFINITY, -INFINITY}; /* u0, u1, v0, v1 */
        for (uint32_t k = sf->first_piece; k < sf->first_piece + sf->piece_count; k++) {
            const crisp_bezier_curve *c = &sc->pieces[k];
            for (int i = 0; i <= c->degree; i++) {
                double u = c->cpw[3 * i] / c->cpw[3 * i + 2],
                       v = c->cpw[3 * i + 1] / c->cpw[3 * i + 2];
                t[0] = fmin(t[0], u), t[1] = fmax(t[1], u);
                t[2] = fmin(t[2], v), t[3] = fmax(t[3], v);
                if (!(c->cpw[3 * i + 2] > 0) || !isfinite(u + v)) /* not a hull: keep all */
                    t[0] = t[2] = -INFINITY, t[1] = t[3] = INFINITY;
            }
        }
        for (uint32_t q = sf->first_patch; q < sf->first_patch + sf->patch_count; q++) {
            const crisp_bezier_patch *z = &sc->patches[q].bez;
            p->patch_in[q] =
                !sf->piece_count || !(z->u1 < t[0] || z->u0 > t[1] || z->v1 < t[2] || z->v0 > t[3]);
            for (int a = 0; a < 3; a++) {
                b[a] = fmin(b[a], sc->patches[q].box[a]);
                b[a + 3] = fmax(b[a + 3], sc->patches[q].box[a + 3]);
            }
        }
    }
    p->face_box_serial = sc->serial;
    p->face_box_trim = sc->trim_serial;
    return CRISP_OK;
}

/* The box's corners in clip space: screen box lo, hi (pixels, y down) and the W range. Returns 0
 * when a corner is not in front of the eye (W <= 0 or not finite): then nothing is set but w0. */
static int box_screen(const double box[6], crisp_mat4 m, int width, int height, double lo[2],
                      double hi[2], double *w0, double *w1)
{
    lo[0] = lo[1] = INFINITY, hi[0] = hi[1] = -INFINITY;
    *w0 = INFINITY, *w1 = -INFINITY;
    for (int k = 0; k < 8; k++) {
        double c[3] = {box[(k & 1) ? 3 : 0], box[(k & 2) ? 4 : 1], box[(k & 4) ? 5 : 2]};
        double x = m[0][0] * c[0] + m[1][0] * c[1] + m[2][0] * c[2] + m[3][0];
        double y = m[0][1] * c[0] + m[1][1] * c[1] + m[2][1] * c[2] + m[3][1];
        double w = m[0][3] * c[0] + m[1][3] * c[1] + m[2][3] * c[2] + m[3][3];
        if (!(w > 0) || !isfinite(x + y + w)) {
            *w0 = -INFINITY;
            return 0;
        }
        double px = (x / w + 1) * 0.5 * width, py = (1 - y / w) * 0.5 * height;
        lo[0] = fmin(lo[0], px), hi[0] = fmax(hi[0], px);
        lo[1] = fmin(lo[1], py), hi[1] = fmax(hi[1], py);
        *w0 = fmin(*w0, w), *w1 = fmax(*w1, w);
    }
    return 1;
}

typedef struct near_key {
    double w;
    uint32_t face;
} near_key;

static int near_key_cmp(const void *a, const void *b)
{
    const near_key *x = a, *y = b;
    if (x->w != y->w) return x->w < y->w ? -1 : 1;
    return x->face < y->face ? -1 : x->face > y->face;
}

#define STAGE_HIDDEN 255
/* Frames in stages go on while the hidden faces' patches are at least STAGE_PAYS_MIN and
 * STAGE_PAYS of those and the patches planned (a frame in stages costs a second trees build, a
 * block depth pass, the tests, and the draw's leaves batched by depth per stage rather than over
 * the frame); after one that hid less, every STAGE_PROBE-th frame tries again. */
#define STAGE_PAYS 0.125
#define STAGE_PAYS_MIN 64
#define STAGE_PROBE 16
/* Where the stages end: the screens the faces' boxes (clipped to the image) cover together, the
 * faces taken nearest first; the faces beyond the last are the last stage's. */
static const double stage_screens[] = {1, 4, 16};
#define STAGES ((int)(sizeof stage_screens / sizeof *stage_screens) + 1)

/* p->stage: each face's stage. The faces seen in the last frame drawn in stages (of this scene)
 * are the first stage: a camera that moved a little sees most of them again, and their depth hides
 * most of the others. The other faces are taken nearest first (the least W of their box) and a
 * stage ends where their screen boxes, clipped to the image, add up to stage_screens images (the
 * first stage's included); faces that reach the eye plane are in the first stage, as are the
 * splat faces. Which stage a face is in changes the cost only : a face is dropped only when the
 * depth drawn hides it. Returns the count of faces not in the first stage. */
static crisp_status choose_stages(crisp_planner *p, const crisp_scene *sc, const crisp_camera *cam,
                                  uint32_t *deferred)
{
    crisp_status st;
    *deferred = 0;
    if ((st = face_boxes(p, sc))) return st;
    uint32_t n = sc->face_count;
    near_key *key = crisp_malloc_array(n ? n : 1, sizeof *key);
    double *area = crisp_malloc_array(n ? n : 1, sizeof *area);
    if (!key || !area) {
        free(key);
        free(area);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory ordering %u faces", n);
    }
    crisp_camera_matrices cm;
    crisp_camera_matrices_compute(cam, &cm);
    uint32_t m = 0;
    double screen = (double)cam->width * cam->height, covered = 0;
    int seen = p->seen && p->seen_serial == sc->serial;
    for (uint32_t f = 0; f < n; f++) {
        p->stage[f] = 0;
        if (p->splat_face[f] || !sc->faces[f].patch_count) continue;
        if (seen && p->seen[f]) {
            covered = screen; /* the other faces come after it */
            continue;
        }
        double lo[2], hi[2], w0, w1;
        const double *b = p->face_box + 6 * (size_t)f;
        if (!box_screen(b, cm.view_proj, cam->width, cam->height, lo, hi, &w0, &w1)) {
            area[f] = screen;
            key[m++] = (near_key){-INFINITY, f};
            continue;
        }
        double x0 = fmax(lo[0], 0), x1 = fmin(hi[0], cam->width);
        double y0 = fmax(lo[1], 0), y1 = fmin(hi[1], cam->height);
        area[f] = x1 > x0 && y1 > y0 ? (x1 - x0) * (y1 - y0) : 0;
        key[m++] = (near_key){w0, f};
    }
    qsort(key, m, sizeof *key, near_key_cmp);
    int at = 0;
    for (uint32_t i = 0; i < m; i++) {
        uint32_t f = key[i].face;
        /* After the seen faces, one stage: their depth is most of the frame's. */
        int end = seen ? 1 : STAGES - 1;
        while (at < end && covered >= stage_screens[at] * screen && key[i].w > -INFINITY)
            at++;
        p->stage[f] = (uint8_t)at;
        *deferred += at > 0;
        covered += area[f];
    }
    p->stage_count = at + 1;
    free(key);
    free(area);
    return CRISP_OK;
}

/* The current stage's faces (later) kept: their leaves (laid out), ribbons, levels and stats. */
static crisp_status keep_stage(crisp_planner *p, const crisp_scene *sc)
{
    crisp_status st;
    const crisp_frame_plan *o = &p->out;
    size_t leaves = p->kept_leaf_count + o->leaf_count,
           quads = p->kept_quads + o->ribbon_quad_count;
    if ((st = crisp_grow((void **)&p->kept_leaves, &p->kept_leaf_cap, leaves ? leaves : 1,
                         sizeof *p->kept_leaves)) ||
        (st = crisp_grow((void **)&p->kept_ribbons, &p->kept_ribbon_cap, 4 * (quads ? quads : 1),
                         sizeof *p->kept_ribbons)))
        return st;
    for (uint32_t f = 0; f < sc->face_count; f++) {
        if (!p->later[f]) continue;
        uint32_t *k = p->kept + 5 * (size_t)f;
        const crisp_plan_face *pf = &p->faces[f];
        k[0] = (uint32_t)p->kept_leaf_count;
        k[1] = pf->leaf_count;
        memcpy(p->kept_leaves + p->kept_leaf_count, p->leaves + pf->first_leaf,
               pf->leaf_count * sizeof *p->leaves);
        p->kept_leaf_count += pf->leaf_count;
        k[2] = (uint32_t)p->kept_quads;
        k[3] = p->trees->face_tau[f] ? p->ribbon_quads[f] : 0;
        memcpy(p->kept_ribbons + 4 * p->kept_quads,
               p->ribbon_verts + 4 * (size_t)p->ribbon_first[f],
               4 * (size_t)k[3] * sizeof *p->ribbon_verts);
        p->kept_quads += k[3];
        k[4] = p->trees->face_tau[f];
        p->kept_rows[f] = p->trees->face_rows[f];
    }
    crisp_plan_stats *s = &p->kept_stats;
    const crisp_plan_stats *a = &o->stats;
    s->patches = a->patches;
    s->visible_patches += a->visible_patches;
    s->split_patches += a->split_patches;
    s->leaves += a->leaves;
    s->visible_faces += a->visible_faces;
    s->unresolved += a->unresolved;
    s->rows_clamped += a->rows_clamped;
    s->level_splits += a->level_splits;
    s->group_leaves += a->group_leaves;
    s->grouped_patches += a->grouped_patches;
    s->ms_levels += a->ms_levels;
    s->ms_edges += a->ms_edges;
    s->ms_trim += a->ms_trim;
    s->ms_ribbons += a->ms_ribbons;
    return CRISP_OK;
}

/* Plan the faces of the current stage (later), laid out to be drawn; kept for the final plan. */
static crisp_status plan_stage(crisp_planner *p, const crisp_scene *sc, const crisp_camera *cam)
{
    crisp_status st;
    for (uint32_t f = 0; f < sc->face_count; f++)
        p->skip[f] = p->splat_face[f] || !p->later[f];
    if ((st = plan_faces(p, sc, cam, p->skip, 1)) || (st = lay_out_leaves(p, sc, NULL)) ||
        (st = lay_out_tables(p, sc)))
        return st;
    face_ribbons_grids(p, sc);
    crisp_frame_plan *o = &p->out;
    o->leaves = p->leaves;
    o->faces = p->faces;
    o->face_count = sc->face_count;
    o->strips = p->strips;
    o->row_offset = p->row_offset;
    o->crossings = p->crossings;
    o->ribbon_vertices = p->ribbon_verts;
    o->splat_range_count = 0;
    return keep_stage(p, sc);
}

crisp_status crisp__planner_plan_near(crisp_planner *p, const crisp_scene *sc,
                                      const crisp_camera *cam, const crisp_frame_plan **dest,
                                      const uint8_t **later)
{
    crisp_status st = crisp_camera_check(cam);
    if (st) return st;
    if ((st = ensure_faces(p, sc->face_count))) return st;
    size_t nf = sc->face_count ? sc->face_count : 1;
    if ((st = crisp_grow((void **)&p->stage, &p->stage_cap, nf, 1)) ||
        (st = crisp_grow((void **)&p->later, &p->later_cap, nf, 1)) ||
        (st = crisp_grow((void **)&p->skip, &p->skip_cap, nf, 1)) ||
        (st = crisp_grow((void **)&p->kept, &p->kept_cap, 5 * nf, sizeof *p->kept)) ||
        (st = crisp_grow((void **)&p->kept_rows, &p->kept_rows_cap, nf, sizeof *p->kept_rows)))
        return st;
    /* The splat choice first (a splat face is drawn as splats whichever stage). */
    double ts = crisp_time_now();
    if ((st = choose_splats(p, sc, cam))) return st;
    double ms_splats = 1e3 * (crisp_time_now() - ts);
    uint32_t deferred = 0;
    *later = NULL;
    int probe =
        p->always || p->pays_serial != sc->serial || p->pays || ++p->quiet % STAGE_PROBE == 0;
    if (probe && (st = choose_stages(p, sc, cam, &deferred))) return st;
    if (!deferred) { /* one stage: the whole plan */
        p->staged = 0;
        if ((st = plan_faces(p, sc, cam, NULL, 1)) || (st = finish_plan(p, sc, cam, NULL)))
            return st;
        p->out.stats.ms_levels += ms_splats;
        *dest = &p->out;
        return CRISP_OK;
    }
    memset(p->kept, 0, 5 * nf * sizeof *p->kept);
    memset(p->kept_rows, 0, nf * sizeof *p->kept_rows);
    p->kept_leaf_count = p->kept_quads = 0;
    p->kept_stats = (crisp_plan_stats){.ms_levels = ms_splats};
    p->hidden = 0;
    p->stage_at = 0;
    for (uint32_t f = 0; f < sc->face_count; f++)
        p->later[f] = p->stage[f] == 0;
    if ((st = plan_stage(p, sc, cam))) return st;
    p->staged = 2;
    p->cam = *cam;
    p->scene = sc;
    *later = p->later;
    *dest = &p->out;
    return CRISP_OK;
}

/* 1 when every sample that face f's surface or ribbons could reach holds a nearer depth in hiz:
 * each of its patches' boxes (which hold the surface and so the curve points of its ribbons) is
 * outside the widened frustum, or in front of the eye with its screen box widened by 2 px (the
 * ribbons reach 1 px from their curve points) hidden (crisp__occl_hidden at the box's least W). */
static int face_hidden(const crisp_planner *p, const crisp_scene *sc, uint32_t f, crisp_mat4 m,
                       int width, int height, const int win[4], const double *hiz, int blocks_x)
{
    const crisp_scene_face *sf = &sc->faces[f];
    double gx = 1 + 4.0 / width, gy = 1 + 4.0 / height;
    /* A face within FACE_SMALL_PX (patch_groups.c) on screen is drawn untrimmed: all patches. */
    double flo[2], fhi[2], fw0, fw1;
    int all = !box_screen(p->face_box + 6 * (size_t)f, m, width, height, flo, fhi, &fw0, &fw1) ||
              (fhi[0] - flo[0] <= 2 && fhi[1] - flo[1] <= 2);
    for (uint32_t q = sf->first_patch; q < sf->first_patch + sf->patch_count; q++) {
        if (!all && !p->patch_in[q]) continue; /* trimmed away whole */
        const double *box = sc->patches[q].box;
        double lo[2], hi[2], w0, w1;
        int front = box_screen(box, m, width, height, lo, hi, &w0, &w1);
        if (!front) {
            /* Behind the eye in part: hidden only when wholly outside one side plane. */
            int out[4] = {1, 1, 1, 1};
            for (int k = 0; k < 8; k++) {
                double c[3] = {box[(k & 1) ? 3 : 0], box[(k & 2) ? 4 : 1], box[(k & 4) ? 5 : 2]};
                double x = m[0][0] * c[0] + m[1][0] * c[1] + m[2][0] * c[2] + m[3][0];
                double y = m[0][1] * c[0] + m[1][1] * c[1] + m[2][1] * c[2] + m[3][1];
                double w = m[0][3] * c[0] + m[1][3] * c[1] + m[2][3] * c[2] + m[3][3];
                out[0] &= x > gx * w, out[1] &= x < -gx * w;
                out[2] &= y > gy * w, out[3] &= y < -gy * w;
            }
            if (out[0] | out[1] | out[2] | out[3]) continue;
            return 0;
        }
        lo[0] -= 2, lo[1] -= 2, hi[0] += 2, hi[1] += 2;
        if (hi[0] < win[0] || hi[1] < win[1] || lo[0] > win[0] + win[2] || lo[1] > win[1] + win[3])
            continue; /* no sample of the window */
        crisp_occl_leaf o;
        crisp__occl_set(&o, win, lo, hi, 1.0 / w0);
        if (!crisp__occl_hidden(&o, hiz, blocks_x)) return 0;
    }
    return 1;
}

crisp_status crisp__planner_plan_next(crisp_planner *p, const crisp_scene *sc, const double *hiz,
                                      const int win[4], const crisp_frame_plan **dest, int *last)
{
    if (p->staged != 2 || p->scene != sc)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "planning a later stage: plan the first stage of this scene first");
    crisp_status st;
    const crisp_camera *cam = &p->cam;
    crisp_frame_plan *o = &p->out;
    uint32_t n = sc->face_count;
    /* The later stages' faces that the depth drawn hides get nothing. */
    int next = STAGES;
    for (uint32_t f = 0; f < n; f++) {
        if (p->stage[f] <= p->stage_at || p->stage[f] == STAGE_HIDDEN) continue;
        if (hiz && face_hidden(p, sc, f, p->trees->view_proj, cam->width, cam->height, win, hiz,
                               (win[2] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK)) {
            p->stage[f] = STAGE_HIDDEN;
            p->hidden++;
        } else if (p->stage[f] < next) {
            next = p->stage[f];
        }
    }
    /* The next stage with faces left, planned; the last one's faces drawn over the final plan. */
    int more = 0;
    for (uint32_t f = 0; f < n; f++) {
        p->later[f] = p->stage[f] == next;
        more |= p->stage[f] > next && p->stage[f] != STAGE_HIDDEN;
    }
    p->stage_at = next;
    if (next < STAGES && (st = plan_stage(p, sc, cam))) return st;
    *last = !more;
    *dest = o;
    if (more) return CRISP_OK;
    /* The final plan: every stage's leaves, levels and ribbons, face after face. */
    size_t nf = n ? n : 1;
    for (uint32_t f = 0; f < n; f++) {
        p->trees->face_tau[f] = p->kept[5 * (size_t)f + 4];
        p->trees->face_rows[f] = p->kept_rows[f];
        p->skip[f] = 1;
    }
    if ((st = crisp_grow((void **)&p->ribbon_verts, &p->ribbon_cap,
                         4 * (p->kept_quads ? p->kept_quads : 1), sizeof *p->ribbon_verts)))
        return st;
    size_t at = 0;
    for (uint32_t f = 0; f < n; f++) {
        const uint32_t *k = p->kept + 5 * (size_t)f;
        if (k[3])
            memcpy(p->ribbon_verts + 4 * at, p->kept_ribbons + 4 * (size_t)k[2],
                   4 * (size_t)k[3] * sizeof *p->ribbon_verts);
        p->ribbon_first[f] = (uint32_t)at;
        p->ribbon_quads[f] = k[3];
        at += k[3];
    }
    (void)nf;
    o->ribbon_quad_count = (uint32_t)at;
    o->stats = p->kept_stats;
    o->stats.hidden_faces = p->hidden;
    /* Whether they paid: at least STAGE_PAYS_MIN hidden faces' patches, and STAGE_PAYS of those
     * and the patches planned with visible leaves. */
    uint64_t hidden_patches = 0;
    for (uint32_t f = 0; f < n; f++)
        if (p->stage[f] == STAGE_HIDDEN) hidden_patches += sc->faces[f].patch_count;
    p->pays = hidden_patches >= STAGE_PAYS_MIN &&
              (double)hidden_patches >=
                  STAGE_PAYS * (double)(hidden_patches + p->kept_stats.visible_patches);
    p->pays_serial = sc->serial;
    p->quiet = 0;
    if ((st = finish_plan(p, sc, cam, p->skip))) return st;
    p->staged = 1;
    return CRISP_OK;
}

crisp_status crisp__planner_seen(crisp_planner *p, const crisp_scene *sc, const int32_t *face,
                                 size_t count)
{
    crisp_status st =
        crisp_grow((void **)&p->seen, &p->seen_cap, sc->face_count ? sc->face_count : 1, 1);
    if (st) return st;
    memset(p->seen, 0, sc->face_count);
    int32_t last = -1; /* neighbouring pixels mostly show the same face */
    for (size_t i = 0; i < count; i++)
        if (face[i] != last) {
            last = face[i];
            if (last >= 0 && (uint32_t)last < sc->face_count) p->seen[last] = 1;
        }
    p->seen_serial = sc->serial;
    return CRISP_OK;
}

void crisp__planner_always_stages(crisp_planner *p, int on)
{
    p->always = on;
}

int crisp__planner_seen_wanted(const crisp_planner *p, const crisp_scene *sc)
{
    return p->always || p->pays_serial != sc->serial || p->pays ||
           (p->quiet + 1) % STAGE_PROBE == 0;
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
    crisp_status st = crisp__trees_replan_trim(p->trees, sc, face, p->strips_used[face]);
    if (st) return st;
    if ((st = lay_out_tables(p, sc))) return st;
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
    publish(p, sc, 1);
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
