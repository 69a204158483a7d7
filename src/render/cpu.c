/* The CPU backend (DESIGN.md section 6): the frame plan's leaves are tessellated at their levels
 * (crack-free edges), evaluated on the true patches, and rasterised with the u-intercept table's
 * trim test per sample; samples are then resolved into colour (headlight shading, straight alpha
 * = coverage) and AOVs (depth, normal, u, v, face of the nearest covered sample). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "plan.h"
#include "raster.h"
#include "render_internal.h"

typedef struct leaf_job {
    uint32_t patch, leaf;
    uint32_t vbase, tbase;
} leaf_job;

struct crisp_renderer {
    crisp_render_desc desc;
    crisp_pool *pool;
    crisp_plan *plan;
    crisp_raster *raster;
    crisp_raster_target target;
    leaf_job *jobs;
    size_t job_cap;
    crisp_raster_vertex *verts;
    size_t vert_cap;
    crisp_raster_tri *tris;
    size_t tri_cap;
    size_t vert_count, tri_count; /* of the last frame */
    double **st; /* per worker: local (s, t) of one leaf's mesh */
    int workers;
};

#define MAX_LEAF_VERTS (4 * (size_t)CRISP_TESS_MAX_EDGE_LEVEL + 64 * 64)

crisp_status crisp_renderer_create(const crisp_render_desc *desc, crisp_renderer **dest)
{
    crisp_renderer *r = calloc(1, sizeof *r);
    if (!r) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating the renderer");
    if (desc) r->desc = *desc;
    if (!r->desc.samples) r->desc.samples = 1;
    crisp_status st = CRISP_OK;
    if (r->desc.samples != 1 && r->desc.samples != 4 && r->desc.samples != 16)
        st = crisp_error(CRISP_ERR_INVALID_ARG, "%d samples per pixel: expected 1, 4 or 16", r->desc.samples);
    if (!st) st = crisp_pool_create(r->desc.threads, &r->pool);
    if (!st) st = crisp_plan_create(&r->plan);
    if (!st) st = crisp_raster_create(&r->raster);
    if (!st) {
        r->workers = crisp_pool_threads(r->pool);
        r->st = calloc((size_t)r->workers, sizeof *r->st);
        if (!r->st) st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating the renderer");
        for (int w = 0; !st && w < r->workers; w++)
            if (!(r->st[w] = crisp_malloc_array(MAX_LEAF_VERTS, 2 * sizeof(double))))
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
        for (int w = 0; w < r->workers; w++) free(r->st[w]);
    free(r->st);
    crisp_pool_destroy(r->pool);
    crisp_plan_destroy(r->plan);
    crisp_raster_destroy(r->raster);
    crisp_raster_target_free(&r->target);
    free(r->jobs);
    free(r->verts);
    free(r->tris);
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
    s->ms_trim = p->ms_trim;
}

crisp_status crisp_renderer_plan(crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cam,
                                 crisp_render_stats *stats)
{
    crisp_plan_desc pd = {.eps_px = r->desc.eps_px, .strip_count = r->desc.strip_count};
    crisp_status st = crisp_plan_frame(r->plan, sc, cam, &pd, r->pool);
    if (!st && stats) {
        memset(stats, 0, sizeof *stats);
        copy_plan_stats(&r->plan->stats, stats);
    }
    return st;
}

/* ---- tessellation -------------------------------------------------------------------------- */

static crisp_tess_levels leaf_levels(const crisp_plan_leaf *L)
{
    crisp_tess_levels lv = {{L->tau, L->tau}, {0}};
    for (int k = 0; k < 4; k++) lv.outer[k] = (int)L->edge[k];
    return lv;
}

typedef struct tess_ctx {
    crisp_renderer *r;
    const crisp_scene *sc;
} tess_ctx;

static void tessellate(void *vctx, size_t begin, size_t end, int worker)
{
    tess_ctx *c = vctx;
    crisp_renderer *r = c->r;
    double *st = r->st[worker];
    crisp_mat4 *m = &r->plan->view_proj;
    for (size_t j = begin; j < end; j++) {
        const leaf_job *job = &r->jobs[j];
        const crisp_scene_patch *sp = &c->sc->patches[job->patch];
        const crisp_plan_leaf *L = &r->plan->patches[job->patch].leaves[job->leaf];
        crisp_tess_levels lv = leaf_levels(L);
        size_t nv = r->jobs[j + 1].vbase - job->vbase;
        crisp_tess_mesh_generate(&lv, st, (uint32_t *)(r->tris + job->tbase), job->vbase);
        /* The generator writes index triples; the raster triangle also carries the face. */
        size_t nt = r->jobs[j + 1].tbase - job->tbase;
        uint32_t *idx = (uint32_t *)(r->tris + job->tbase);
        for (size_t k = nt; k-- > 0;) {
            crisp_raster_tri tri = {{idx[3 * k], idx[3 * k + 1], idx[3 * k + 2]}, sp->face};
            r->tris[job->tbase + k] = tri;
        }
        double scale = ldexp(1.0, -L->depth);
        int reversed = c->sc->faces[sp->face].src->reversed;
        for (size_t k = 0; k < nv; k++) {
            double s = (L->ix + st[2 * k]) * scale, t = (L->iy + st[2 * k + 1]) * scale;
            double P[3], Ps[3], Pt[3], n[3];
            crisp_bezier_patch_derivs(&sp->bez, s, t, P, Ps, Pt);
            crisp_raster_vertex *v = &r->verts[job->vbase + k];
            crisp_mat4_mulp(*m, P, v->clip);
            v->attr[0] = sp->bez.u0 + s * (sp->bez.u1 - sp->bez.u0);
            v->attr[1] = sp->bez.v0 + t * (sp->bez.v1 - sp->bez.v0);
            crisp_vec3_cross(Ps, Pt, n);
            if (reversed) crisp_vec3_scale(n, -1, n);
            crisp_vec3_normalize(n, v->attr + 2);
        }
    }
}

/* ---- trim test and resolve ------------------------------------------------------------------- */

static int trim_test(void *ctx, uint32_t face, double u, double v)
{
    const crisp_plan *plan = ctx;
    return crisp_trim_table_test(&plan->trims[face].table, u, v);
}

typedef struct resolve_ctx {
    crisp_renderer *r;
    const crisp_scene *sc;
    const crisp_camera *cam;
    crisp_image *img;
} resolve_ctx;

static void resolve_rows(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    resolve_ctx *c = vctx;
    const crisp_raster_target *t = &c->r->target;
    crisp_image *img = c->img;
    int S = t->samples;
    for (size_t j = begin; j < end; j++)
        for (int i = 0; i < t->width; i++) {
            size_t px = j * (size_t)t->width + (size_t)i;
            float acc[4] = {0, 0, 0, 0};
            int covered = 0, best = -1;
            double best_iw = 0;
            for (int s = 0; s < S; s++) {
                size_t idx = px * S + s;
                if (t->face[idx] < 0) continue;
                covered++;
                if (t->inv_w[idx] > best_iw) best_iw = t->inv_w[idx], best = s;
                double off[2], o[3], d[3], n[3];
                crisp_raster_sample_offset(S, s, off);
                crisp_camera_ray(c->cam, i + off[0], (double)j + off[1], o, d);
                const float *a = t->attr + idx * CRISP_RASTER_ATTRS;
                n[0] = a[2], n[1] = a[3], n[2] = a[4];
                float rgba[4];
                crisp__shade(c->sc->faces[t->face[idx]].color, n, d, rgba);
                for (int k = 0; k < 3; k++) acc[k] += rgba[k];
            }
            if (!covered) continue;
            for (int k = 0; k < 3; k++) img->rgba[4 * px + k] = acc[k] / (float)covered;
            img->rgba[4 * px + 3] = (float)covered / (float)S;
            size_t idx = px * S + (size_t)best;
            const float *a = t->attr + idx * CRISP_RASTER_ATTRS;
            img->face[px] = t->face[idx];
            img->depth[px] = (float)(1.0 / t->inv_w[idx]);
            img->uv[2 * px] = a[0];
            img->uv[2 * px + 1] = a[1];
            for (int k = 0; k < 3; k++) img->normal[3 * px + k] = a[2 + k];
        }
}

void crisp__renderer_mesh(const crisp_renderer *r, const crisp_raster_vertex **verts,
                          size_t *vert_count, const crisp_raster_tri **tris, size_t *tri_count)
{
    *verts = r->verts;
    *tris = r->tris;
    *vert_count = r->vert_count;
    *tri_count = r->tri_count;
}

crisp_status crisp_render_cpu(crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cam,
                              crisp_image *img, crisp_render_stats *stats)
{
    if (img->width != cam->width || img->height != cam->height)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image %dx%d does not match the camera's %dx%d",
                           img->width, img->height, cam->width, cam->height);
    crisp_render_stats local;
    if (!stats) stats = &local;
    crisp_status st = crisp_renderer_plan(r, sc, cam, stats);
    if (st) return st;
    double t0 = crisp_time_now();
    /* Jobs: one per visible leaf, with vertex and triangle offsets (and a sentinel). */
    size_t jobs = 0, nv = 0, nt = 0;
    for (uint32_t p = 0; p < sc->patch_count; p++) {
        const crisp_patch_plan *pp = &r->plan->patches[p];
        for (uint32_t l = 0; l < pp->leaf_count && pp->visible_leaves; l++) {
            if (pp->leaves[l].culled) continue;
            if ((st = crisp_grow((void **)&r->jobs, &r->job_cap, jobs + 2, sizeof *r->jobs))) return st;
            crisp_tess_levels lv = leaf_levels(&pp->leaves[l]);
            size_t v, t;
            if ((st = crisp_tess_mesh_counts(&lv, &v, &t))) return st;
            r->jobs[jobs++] = (leaf_job){p, l, (uint32_t)nv, (uint32_t)nt};
            nv += v;
            nt += t;
            if (nv > UINT32_MAX / 2 || nt > UINT32_MAX / 2)
                return crisp_error(CRISP_ERR_LIMIT, "more than 2^31 vertices or triangles in one frame");
        }
    }
    if (!jobs && (st = crisp_grow((void **)&r->jobs, &r->job_cap, 1, sizeof *r->jobs))) return st;
    r->jobs[jobs] = (leaf_job){0, 0, (uint32_t)nv, (uint32_t)nt};
    if ((st = crisp_grow((void **)&r->verts, &r->vert_cap, nv ? nv : 1, sizeof *r->verts))) return st;
    /* A triangle record is at least as large as the generator's three indices. */
    if ((st = crisp_grow((void **)&r->tris, &r->tri_cap, nt ? nt : 1, sizeof *r->tris))) return st;
    r->vert_count = nv;
    r->tri_count = nt;
    tess_ctx tc = {r, sc};
    crisp_pool_parallel_for(r->pool, jobs, 8, tessellate, &tc);
    double t1 = crisp_time_now();

    if ((st = crisp_raster_target_init(&r->target, cam->width, cam->height, r->desc.samples))) return st;
    crisp_raster_target_clear(&r->target);
    crisp_raster_stats rs;
    st = crisp_raster_draw(r->raster, &r->target, r->pool, r->verts, nv, r->tris, nt, trim_test, r->plan, &rs);
    if (st) return st;
    double t2 = crisp_time_now();
    resolve_ctx rc = {r, sc, cam, img};
    crisp_pool_parallel_for(r->pool, (size_t)cam->height, 8, resolve_rows, &rc);
    double t3 = crisp_time_now();
    stats->vertices = nv;
    stats->triangles = nt;
    stats->fragments_tested = rs.fragments_tested;
    stats->fragments_trimmed = rs.fragments_discarded;
    stats->ms_tess = 1e3 * (t1 - t0);
    stats->ms_raster = 1e3 * (t2 - t1);
    stats->ms_resolve = 1e3 * (t3 - t2);
    return CRISP_OK;
}
