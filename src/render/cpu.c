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
    struct ribbon_job *ribbon_jobs;
    size_t ribbon_cap;
    crisp_arena **ribbon_arena; /* per worker, reset every frame */
    crisp_status *wstatus;      /* per worker */
    crisp_raster_vertex *verts;
    size_t vert_cap;
    crisp_raster_tri *tris;
    size_t tri_cap;
    size_t vert_count, tri_count; /* of the last frame */
    float *slack;                 /* per sample: depth slack for the ribbons (fill pass) */
    size_t slack_cap;
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
        r->wstatus = calloc((size_t)r->workers, sizeof *r->wstatus);
        if (!r->st || !r->wstatus) st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating the renderer");
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
    free(r->wstatus);
    crisp_pool_destroy(r->pool);
    crisp_plan_destroy(r->plan);
    crisp_raster_destroy(r->raster);
    crisp_raster_target_free(&r->target);
    free(r->jobs);
    free(r->ribbon_jobs);
    if (r->ribbon_arena)
        for (int w = 0; w < r->workers; w++) crisp_arena_destroy(r->ribbon_arena[w]);
    free(r->ribbon_arena);
    free(r->verts);
    free(r->tris);
    free(r->slack);
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

static crisp_status ensure_ribbon_arenas(crisp_renderer *r)
{
    if (!r->ribbon_arena) {
        r->ribbon_arena = calloc((size_t)r->workers, sizeof *r->ribbon_arena);
        if (!r->ribbon_arena) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim ribbons");
        for (int w = 0; w < r->workers; w++)
            if (crisp_arena_create(1 << 16, &r->ribbon_arena[w]))
                return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim ribbons");
    }
    for (int w = 0; w < r->workers; w++) crisp_arena_reset(r->ribbon_arena[w]);
    return CRISP_OK;
}

static int trim_test(void *ctx, uint32_t face, double u, double v)
{
    const crisp_plan *plan = ctx;
    if (face & CRISP_RASTER_FACE_FLAG) return 1; /* a ribbon: drawn where it lands */
    return crisp_trim_table_test(&plan->trims[face].table, u, v);
}

/* ---- trim-boundary ribbons ---------------------------------------------------------------------
 * Where two trimmed faces meet, each face's trim test may be wrong within its 1 px band, so the
 * shared edge can open a sub-pixel gap. Like Wu & Peters (who draw x(gamma(t))), each face's trim
 * boundary is also drawn as its surface image: a screen-space ribbon of half-width RIBBON_PX
 * along the trim polyline mapped onto the true surface, sampled until consecutive samples are at
 * most RIBBON_STEP_PX apart on screen (so the straight ribbon pieces follow the curved image).
 * The polyline is within 0.25 px of the true curve, so a ribbon reaches at most about
 * RIBBON_PX + 0.25 < 1 px beyond the true boundary: inside the band where the trim decision may
 * go either way. Samples outside the widened frustum are dropped. */
#define RIBBON_PX 0.7
#define RIBBON_STEP_PX 2.0
#define RIBBON_MAX_DEPTH 20

typedef struct ribbon_job {
    uint32_t face, piece;
    crisp_raster_vertex *pts; /* samples (per-worker arena, valid this frame) */
    uint32_t count;           /* samples; a sample with clip[3] < 0 breaks the ribbon */
    uint32_t vbase, tbase;
} ribbon_job;

typedef struct ribbon_ctx {
    crisp_renderer *r;
    const crisp_scene *sc;
    crisp_status *status;
} ribbon_ctx;

static void ribbon_vertex(const crisp_surface *surf, int reversed, crisp_mat4 m, double u, double v,
                          crisp_raster_vertex *out)
{
    double P[3], Su[3], Sv[3], n[3];
    crisp_surface_derivs(surf, u, v, P, Su, Sv, NULL, NULL, NULL);
    crisp_mat4_mulp(m, P, out->clip);
    out->attr[0] = u;
    out->attr[1] = v;
    crisp_vec3_cross(Su, Sv, n);
    if (reversed) crisp_vec3_scale(n, -1, n);
    crisp_vec3_normalize(n, out->attr + 2);
}

static int in_view(const crisp_raster_vertex *a, double gx, double gy)
{
    const double *c = a->clip;
    return c[3] > 0 && c[2] >= -c[3] && c[2] <= c[3] && fabs(c[0]) <= gx * c[3] && fabs(c[1]) <= gy * c[3];
}

/* Screen distance in pixels (infinite when either point is behind the eye). */
static double screen_dist(const crisp_raster_vertex *a, const crisp_raster_vertex *b, double w, double h)
{
    if (!(a->clip[3] > 0 && b->clip[3] > 0)) return INFINITY;
    double dx = (a->clip[0] / a->clip[3] - b->clip[0] / b->clip[3]) * 0.5 * w;
    double dy = (a->clip[1] / a->clip[3] - b->clip[1] / b->clip[3]) * 0.5 * h;
    return hypot(dx, dy);
}

/* Conservatively: can the ribbon piece between a and b (surface points) show on screen? Both in
 * front of the eye, and the screen box of the chord, widened by the chord's length (the surface
 * image between two samples bulges by less than that), meets the viewport. */
static int segment_may_show(const crisp_raster_vertex *a, const crisp_raster_vertex *b, double w,
                            double h)
{
    if (!(a->clip[3] > 0) || !(b->clip[3] > 0)) return 1; /* let refine() split it */
    double ax = (a->clip[0] / a->clip[3] + 1) * 0.5 * w, ay = (1 - a->clip[1] / a->clip[3]) * 0.5 * h;
    double bx = (b->clip[0] / b->clip[3] + 1) * 0.5 * w, by = (1 - b->clip[1] / b->clip[3]) * 0.5 * h;
    double len = hypot(bx - ax, by - ay) + 2;
    if (!isfinite(len)) return 1;
    return fmax(ax, bx) + len >= 0 && fmin(ax, bx) - len <= w && fmax(ay, by) + len >= 0 &&
           fmin(ay, by) - len <= h;
}

typedef struct sampler {
    crisp_arena *arena;
    crisp_raster_vertex *pts;
    uint32_t count, cap;
    const crisp_surface *surf;
    int reversed;
    crisp_mat4 *m;
    double w, h, gx, gy;
    int failed;
} sampler;

static void emit(sampler *s, const crisp_raster_vertex *v)
{
    if (s->count == s->cap) {
        uint32_t cap = s->cap ? 2 * s->cap : 64;
        crisp_raster_vertex *n = crisp_arena_alloc(s->arena, cap, sizeof *n);
        if (!n) {
            s->failed = 1;
            return;
        }
        if (s->count) memcpy(n, s->pts, s->count * sizeof *n);
        s->pts = n;
        s->cap = cap;
    }
    s->pts[s->count++] = *v;
}

/* Samples strictly after a up to and including b, along the uv segment. */
static void refine(sampler *s, const crisp_raster_vertex *a, const crisp_raster_vertex *b, int depth)
{
    if (s->failed) return;
    int va = in_view(a, s->gx, s->gy), vb = in_view(b, s->gx, s->gy);
    double d = screen_dist(a, b, s->w, s->h);
    if (depth < RIBBON_MAX_DEPTH && d > RIBBON_STEP_PX && (va || vb || d < INFINITY ? 1 : 0)) {
        crisp_raster_vertex mid;
        ribbon_vertex(s->surf, s->reversed, *s->m, 0.5 * (a->attr[0] + b->attr[0]),
                      0.5 * (a->attr[1] + b->attr[1]), &mid);
        /* Both ends and the middle outside the view and the piece small enough not to cross it
         * from one side to the other: nothing of it shows. */
        if (!va && !vb && !in_view(&mid, s->gx, s->gy) && depth > 8) {
            crisp_raster_vertex brk = *b;
            brk.clip[3] = -1;
            emit(s, &brk);
            emit(s, b);
            return;
        }
        refine(s, a, &mid, depth + 1);
        refine(s, &mid, b, depth + 1);
        return;
    }
    if (d > RIBBON_STEP_PX) {
        /* Not resolved (behind the eye or at the depth limit): break the ribbon here. */
        crisp_raster_vertex brk = *b;
        brk.clip[3] = -1;
        emit(s, &brk);
    }
    emit(s, b);
}

static void sample_ribbons(void *vctx, size_t begin, size_t end, int worker)
{
    ribbon_ctx *c = vctx;
    crisp_renderer *r = c->r;
    const crisp_plan *plan = r->plan;
    for (size_t j = begin; j < end; j++) {
        ribbon_job *job = &r->ribbon_jobs[j];
        const crisp_scene_face *f = &c->sc->faces[job->face];
        const crisp_trim_polyline *pl = &plan->trims[job->face].polyline;
        int p0 = pl->first[job->piece], p1 = pl->first[job->piece + 1];
        sampler s = {.arena = r->ribbon_arena[worker], .surf = f->src->surface,
                     .reversed = f->src->reversed, .m = &r->plan->view_proj, .w = plan->width,
                     .h = plan->height, .gx = 1 + 4.0 / plan->width, .gy = 1 + 4.0 / plan->height};
        crisp_raster_vertex a, b;
        ribbon_vertex(s.surf, s.reversed, *s.m, pl->uv[2 * p0], pl->uv[2 * p0 + 1], &a);
        int open = 0; /* the ribbon so far ends at a */
        for (int k = p0; k + 1 < p1; k++) {
            ribbon_vertex(s.surf, s.reversed, *s.m, pl->uv[2 * k + 2], pl->uv[2 * k + 3], &b);
            /* Segments that cannot reach the view are left out without a sample (at extreme zoom
             * almost all of a polyline is off screen). */
            if (!segment_may_show(&a, &b, s.w, s.h)) {
                if (open) {
                    crisp_raster_vertex brk = a;
                    brk.clip[3] = -1;
                    emit(&s, &brk);
                    open = 0;
                }
            } else {
                if (!open) emit(&s, &a);
                refine(&s, &a, &b, 0);
                open = 1;
            }
            a = b;
        }
        if (s.failed) c->status[worker] = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim ribbons");
        job->pts = s.pts;
        job->count = s.count;
    }
}

static void build_ribbons(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    ribbon_ctx *c = vctx;
    crisp_renderer *r = c->r;
    double sx = 2.0 / r->plan->width, sy = 2.0 / r->plan->height;
    for (size_t j = begin; j < end; j++) {
        const ribbon_job *job = &r->ribbon_jobs[j];
        for (uint32_t q = 0; q + 1 < job->count; q++) {
            const crisp_raster_vertex *a = &job->pts[q], *b = &job->pts[q + 1];
            crisp_raster_vertex *v = r->verts + job->vbase + 4 * q;
            crisp_raster_tri *t = r->tris + job->tbase + 2 * q;
            double dx = 0, dy = 0;
            int ok = a->clip[3] > 0 && b->clip[3] > 0;
            if (ok) {
                dx = (b->clip[0] / b->clip[3] - a->clip[0] / a->clip[3]) / sx;
                dy = -(b->clip[1] / b->clip[3] - a->clip[1] / a->clip[3]) / sy;
                double len = hypot(dx, dy);
                ok = len > 0 && isfinite(len);
                if (ok) dx /= len, dy /= len;
            }
            for (int corner = 0; corner < 4; corner++) {
                crisp_raster_vertex *o = &v[corner];
                *o = corner < 2 ? *a : *b;
                if (!ok) {
                    o->clip[3] = -1; /* the rasterizer clips these triangles away */
                    continue;
                }
                double along = corner < 2 ? -RIBBON_PX : RIBBON_PX;
                double side = (corner == 0 || corner == 3) ? -RIBBON_PX : RIBBON_PX;
                double ox = along * dx - side * dy, oy = along * dy + side * dx; /* pixels, y down */
                o->clip[0] += ox * sx * o->clip[3];
                o->clip[1] -= oy * sy * o->clip[3];
            }
            uint32_t base = job->vbase + 4 * q, face = job->face | CRISP_RASTER_FACE_FLAG;
            t[0] = (crisp_raster_tri){{base, base + 1, base + 2}, face};
            t[1] = (crisp_raster_tri){{base, base + 2, base + 3}, face};
        }
    }
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
    /* The view direction of a sample (unnormalised: shading normalises): the camera ray's
     * f + ndc_x r + ndc_y u without recomputing the basis per sample. */
    const crisp_camera *cam = c->cam;
    double f[3], r[3], u[3], d0[3];
    crisp_vec3_sub(cam->target, cam->eye, d0);
    crisp_vec3_normalize(d0, f);
    crisp_vec3_cross(f, cam->up, d0);
    crisp_vec3_normalize(d0, r);
    crisp_vec3_cross(r, f, u);
    double th = tan(cam->fov_deg * (M_PI / 360.0));
    double kx = 2.0 * th / cam->height, ky = 2.0 * th / cam->height; /* per pixel */
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
                double off[2], d[3], n[3];
                crisp_raster_sample_offset(S, s, off);
                double nx = (i + off[0] - 0.5 * cam->width) * kx, ny = (0.5 * cam->height - j - off[1]) * ky;
                for (int k = 0; k < 3; k++) d[k] = f[k] + nx * r[k] + ny * u[k];
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

const crisp_raster_target *crisp__renderer_target(const crisp_renderer *r)
{
    return &r->target;
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
    /* Ribbons after the surfaces: at equal depth the surface's own fragment stays. Sampled
     * first (their size depends on the view), then laid out after the surface triangles. */
    size_t rjobs = 0, surface_v = nv, surface_t = nt;
    for (uint32_t f = 0; f < sc->face_count; f++) {
        if (!r->plan->face_tau[f]) continue;
        const crisp_trim_polyline *pl = &r->plan->trims[f].polyline;
        for (int k = 0; k < pl->piece_count; k++) {
            if (pl->first[k + 1] - pl->first[k] < 2) continue;
            if ((st = crisp_grow((void **)&r->ribbon_jobs, &r->ribbon_cap, rjobs + 1, sizeof *r->ribbon_jobs)))
                return st;
            r->ribbon_jobs[rjobs++] = (ribbon_job){.face = f, .piece = (uint32_t)k};
        }
    }
    if ((st = ensure_ribbon_arenas(r))) return st;
    for (int w = 0; w < r->workers; w++) r->wstatus[w] = CRISP_OK;
    ribbon_ctx rbc = {r, sc, r->wstatus};
    crisp_pool_parallel_for(r->pool, rjobs, 4, sample_ribbons, &rbc);
    for (int w = 0; w < r->workers; w++)
        if (r->wstatus[w]) return r->wstatus[w];
    for (size_t j = 0; j < rjobs; j++) {
        ribbon_job *job = &r->ribbon_jobs[j];
        size_t segs = job->count ? job->count - 1 : 0;
        job->vbase = (uint32_t)nv;
        job->tbase = (uint32_t)nt;
        nv += 4 * segs;
        nt += 2 * segs;
        if (nv > UINT32_MAX / 2 || nt > UINT32_MAX / 2)
            return crisp_error(CRISP_ERR_LIMIT, "more than 2^31 vertices or triangles in one frame");
    }
    if ((st = crisp_grow((void **)&r->verts, &r->vert_cap, nv ? nv : 1, sizeof *r->verts))) return st;
    /* A triangle record is at least as large as the generator's three indices. */
    if ((st = crisp_grow((void **)&r->tris, &r->tri_cap, nt ? nt : 1, sizeof *r->tris))) return st;
    r->vert_count = surface_v; /* the surface mesh, without the ribbons */
    r->tri_count = surface_t;
    tess_ctx tc = {r, sc};
    crisp_pool_parallel_for(r->pool, jobs, 8, tessellate, &tc);
    crisp_pool_parallel_for(r->pool, rjobs, 16, build_ribbons, &rbc);
    double t1 = crisp_time_now();

    if ((st = crisp_raster_target_init(&r->target, cam->width, cam->height, r->desc.samples))) return st;
    crisp_raster_target_clear(&r->target);
    crisp_raster_stats rs;
    /* Surfaces first; then the ribbons fill gaps: a ribbon sample replaces a surface sample only
     * when nearer by more than that surface's depth change over 1.5 px, so a ribbon along an
     * edge that another face hides at nearly the same depth (seen at a grazing angle) does not
     * show through it. */
    st = crisp_raster_draw(r->raster, &r->target, r->pool, r->verts, nv, r->tris, surface_t, trim_test, r->plan, &rs);
    if (st) return st;
    if (nt > surface_t) {
        size_t ns = (size_t)cam->width * cam->height * r->desc.samples;
        if ((st = crisp_grow((void **)&r->slack, &r->slack_cap, ns, sizeof *r->slack))) return st;
        crisp_raster_depth_slack(&r->target, r->pool, 1.5, r->slack);
        crisp_raster_stats rs2;
        st = crisp_raster_draw_fill(r->raster, &r->target, r->pool, r->verts, nv, r->tris + surface_t,
                                    nt - surface_t, trim_test, r->plan, r->slack, &rs2);
        if (st) return st;
        rs.fragments_tested += rs2.fragments_tested;
        rs.fragments_discarded += rs2.fragments_discarded;
    }
    double t2 = crisp_time_now();
    crisp__image_clear(img);
    resolve_ctx rc = {r, sc, cam, img};
    crisp_pool_parallel_for(r->pool, (size_t)cam->height, 8, resolve_rows, &rc);
    double t3 = crisp_time_now();
    stats->vertices = surface_v;
    stats->triangles = surface_t;
    stats->ribbon_triangles = nt - surface_t;
    stats->fragments_tested = rs.fragments_tested;
    stats->fragments_trimmed = rs.fragments_discarded;
    stats->ms_tess = 1e3 * (t1 - t0);
    stats->ms_raster = 1e3 * (t2 - t1);
    stats->ms_resolve = 1e3 * (t3 - t2);
    return CRISP_OK;
}
