/* The CPU backend (docs/design.md section 6): the frame plan's leaves are tessellated at their
 * levels (crack-free edges), evaluated on the true patches, and rasterised with the u-intercept
 * table's trim test per sample; samples are then resolved into colour (headlight shading, straight
 * alpha = coverage) and AOVs (depth, normal, u, v, face of the nearest covered sample). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/plan.h"
#include "crisp/tess.h"
#include "raster.h"
#include "render_internal.h"

struct crisp_renderer {
    crisp_render_desc desc;
    crisp_pool *pool;
    crisp_planner *planner;
    const crisp_frame_plan *plan; /* the frame being drawn */
    crisp_raster *raster;
    crisp_raster_target target;
    uint32_t *leaf_vbase, *leaf_tbase; /* per plan leaf (and a sentinel) */
    size_t leaf_base_cap, leaf_tbase_cap;
    crisp_raster_vertex *verts;
    size_t vert_cap;
    crisp_raster_tri *tris;
    size_t tri_cap;
    size_t vert_count, tri_count; /* of the last frame */
    float *slack;                 /* per sample: depth slack for the ribbons (fill pass) */
    size_t slack_cap;
    double **st; /* per worker: local (s, t) of one leaf's mesh */
    int workers;
    uint8_t *untested; /* per face: no trim loops, no trim test (the rasterizer's hook) */
    size_t untested_cap;
    uint8_t *leaf_skip; /* per plan leaf: its screen hull holds no sample, nothing to draw */
    size_t leaf_skip_cap;
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
            &(crisp_planner_desc){.eps_px = r->desc.eps_px, .strip_count = r->desc.strip_count},
            r->pool, &r->planner);
    if (!st) st = crisp__raster_create(&r->raster);
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
        for (int w = 0; w < r->workers; w++)
            free(r->st[w]);
    free(r->st);
    crisp_planner_destroy(r->planner);
    crisp_pool_destroy(r->pool);
    crisp__raster_destroy(r->raster);
    crisp__raster_target_free(&r->target);
    free(r->leaf_vbase);
    free(r->leaf_tbase);
    free(r->verts);
    free(r->tris);
    free(r->slack);
    free(r->untested);
    free(r->leaf_skip);
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

/* ---- tessellation -------------------------------------------------------------------------- */

static crisp_tess_levels leaf_levels(const crisp_plan_leaf *L)
{
    crisp_tess_levels lv = {{(int)L->tau, (int)L->tau}, {0}};
    for (int k = 0; k < 4; k++)
        lv.outer[k] = (int)L->edge[k];
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
    const crisp_frame_plan *plan = r->plan;
    double *st = r->st[worker];
    crisp_mat4 *m = (crisp_mat4 *)&plan->view_proj;
    for (size_t j = begin; j < end; j++) {
        if (r->leaf_skip[j]) continue;
        const crisp_plan_leaf *L = &plan->leaves[j];
        const crisp_scene_patch *sp = &c->sc->patches[L->patch];
        crisp_tess_levels lv = leaf_levels(L);
        uint32_t vbase = r->leaf_vbase[j], tbase = r->leaf_tbase[j];
        size_t nv = r->leaf_vbase[j + 1] - vbase;
        crisp_tess_mesh_generate(&lv, st, (uint32_t *)(r->tris + tbase), vbase);
        /* The generator writes index triples; the raster triangle also carries the face. */
        size_t nt = r->leaf_tbase[j + 1] - tbase;
        uint32_t *idx = (uint32_t *)(r->tris + tbase);
        for (size_t k = nt; k-- > 0;) {
            crisp_raster_tri tri = {{idx[3 * k], idx[3 * k + 1], idx[3 * k + 2]}, L->face};
            r->tris[tbase + k] = tri;
        }
        double scale = ldexp(1.0, -(int)L->depth);
        int reversed = (plan->faces[L->face].flags & CRISP_PLAN_FACE_REVERSED) != 0;
        for (size_t k = 0; k < nv; k++) {
            double s = (L->ix + st[2 * k]) * scale, t = (L->iy + st[2 * k + 1]) * scale;
            double P[3], Ps[3], Pt[3], n[3];
            crisp_bezier_patch_derivs(&sp->bez, s, t, P, Ps, Pt);
            crisp_raster_vertex *v = &r->verts[vbase + k];
            crisp_mat4_mulp(*m, P, v->clip);
            v->attr[0] = sp->bez.u0 + s * (sp->bez.u1 - sp->bez.u0);
            v->attr[1] = sp->bez.v0 + t * (sp->bez.v1 - sp->bez.v0);
            crisp_vec3_cross(Ps, Pt, n);
            /* At an apex, a pole or a collapsed side the cross product vanishes: take the limit
             * from inside the patch (each generator of a cone keeps its own normal). */
            if (crisp__normal_degenerate(Ps, Pt, n)) crisp_bezier_patch_normal(&sp->bez, s, t, n);
            if (reversed) crisp_vec3_scale(n, -1, n);
            crisp_vec3_normalize(n, v->attr + 2);
        }
    }
}

/* Leaves that cannot cover a sample (issue 12). A leaf's triangles lie in the screen hull of its
 * sub-patch's control points (their vertices are surface points; W > 0 over the hull), and
 * snapping moves them by at most 1/512 px; when that box, so widened, holds no sample position
 * of the image, the leaf draws nothing and is not tessellated. The image is unchanged: far away,
 * where many patches share a pixel, most leaves fall between the samples. */
typedef struct skip_ctx {
    crisp_renderer *r;
    const crisp_scene *sc;
    double off[16][2];
    int samples;
} skip_ctx;

static int holds_sample(const skip_ctx *c, const double lo[2], const double hi[2], int width,
                        int height)
{
    for (int s = 0; s < c->samples; s++) {
        double i0 = fmax(ceil(lo[0] - c->off[s][0]), 0),
               i1 = fmin(floor(hi[0] - c->off[s][0]), width - 1);
        double j0 = fmax(ceil(lo[1] - c->off[s][1]), 0),
               j1 = fmin(floor(hi[1] - c->off[s][1]), height - 1);
        if (i0 <= i1 && j0 <= j1) return 1;
    }
    return 0;
}

static void find_empty_leaves(void *vctx, size_t begin, size_t end, int worker)
{
    skip_ctx *c = vctx;
    crisp_renderer *r = c->r;
    const crisp_frame_plan *plan = r->plan;
    double *storage = r->st[worker];
    crisp_mat4 *m = (crisp_mat4 *)&plan->view_proj;
    for (size_t j = begin; j < end; j++) {
        const crisp_plan_leaf *L = &plan->leaves[j];
        const crisp_bezier_patch *bez = &c->sc->patches[L->patch].bez;
        crisp_bezier_patch sub = *bez;
        if (L->depth) {
            double sz = ldexp(1.0, -(int)L->depth);
            crisp__subpatch(bez, L->ix * sz, (L->ix + 1) * sz, L->iy * sz, (L->iy + 1) * sz,
                            storage, storage + 2 * CRISP__PATCH_DOUBLES, &sub);
        }
        int n = (sub.du + 1) * (sub.dv + 1), front = 1;
        double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
        for (int k = 0; k < n && front; k++) {
            const double *cp = sub.cpw + 4 * k;
            double h[4];
            for (int q = 0; q < 4; q++)
                h[q] = (*m)[0][q] * cp[0] + (*m)[1][q] * cp[1] + (*m)[2][q] * cp[2] +
                       (*m)[3][q] * cp[3];
            if (!(h[3] > 0) || !isfinite(h[0] + h[1] + h[3])) {
                front = 0;
                break;
            }
            double x = (h[0] / h[3] + 1) * 0.5 * plan->width,
                   y = (1 - h[1] / h[3]) * 0.5 * plan->height;
            lo[0] = fmin(lo[0], x), hi[0] = fmax(hi[0], x), lo[1] = fmin(lo[1], y),
            hi[1] = fmax(hi[1], y);
        }
        /* Widen by the snapping (1/512 px) and rounding, generously. */
        double pad = 1.0 / 128 + 1e-9 * (fabs(lo[0]) + fabs(hi[0]) + fabs(lo[1]) + fabs(hi[1]));
        lo[0] -= pad, lo[1] -= pad, hi[0] += pad, hi[1] += pad;
        r->leaf_skip[j] = front && !holds_sample(c, lo, hi, plan->width, plan->height);
    }
}

/* ---- trim test and resolve ------------------------------------------------------------------- */

static int trim_test(void *ctx, uint32_t face, double u, double v)
{
    const crisp_frame_plan *plan = ctx;
    if (face & CRISP_RASTER_FACE_FLAG) return 1; /* a ribbon: drawn where it lands */
    return crisp_plan_trim_test(plan, face, u, v);
}

/* The plan's ribbon quads as raster vertices and triangles (0 1 2, 0 2 3), after the surfaces'. */
typedef struct ribbon_ctx {
    crisp_renderer *r;
    const crisp_frame_plan *plan;
    size_t vbase, tbase;
} ribbon_ctx;

static void copy_ribbons(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    ribbon_ctx *c = vctx;
    for (size_t q = begin; q < end; q++) {
        const crisp_plan_ribbon_vertex *src = c->plan->ribbon_vertices + 4 * q;
        crisp_raster_vertex *v = c->r->verts + c->vbase + 4 * q;
        for (int k = 0; k < 4; k++) {
            memcpy(v[k].clip, src[k].clip, sizeof v[k].clip);
            v[k].attr[0] = src[k].uv[0];
            v[k].attr[1] = src[k].uv[1];
            for (int a = 0; a < 3; a++)
                v[k].attr[2 + a] = src[k].normal[a];
        }
        uint32_t base = (uint32_t)(c->vbase + 4 * q), face = src[0].face | CRISP_RASTER_FACE_FLAG;
        c->r->tris[c->tbase + 2 * q] = (crisp_raster_tri){{base, base + 1, base + 2}, face};
        c->r->tris[c->tbase + 2 * q + 1] = (crisp_raster_tri){{base, base + 2, base + 3}, face};
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
} resolve_ctx;

static void resolve_rows(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    resolve_ctx *c = vctx;
    const crisp_raster_target *t = &c->r->target;
    crisp_image *img = c->img;
    int S = t->samples;
    /* The view direction of a sample (unnormalised: shading normalises): the camera ray's
     * f + ndc_x r + ndc_y u, the basis computed once per frame (raster_view). */
    const crisp_camera *cam = c->cam;
    const double *f = c->view.f, *r = c->view.r, *u = c->view.u, kx = c->view.kx, ky = c->view.ky;
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
                crisp__raster_sample_offset(S, s, off);
                double nx = (i + off[0] - 0.5 * cam->width) * kx,
                       ny = (0.5 * cam->height - j - off[1]) * ky;
                for (int k = 0; k < 3; k++)
                    d[k] = f[k] + nx * r[k] + ny * u[k];
                const float *a = t->attr + idx * CRISP_RASTER_ATTRS;
                n[0] = a[2], n[1] = a[3], n[2] = a[4];
                float rgba[4];
                crisp__shade(c->sc->faces[t->face[idx]].color, n, d, rgba);
                for (int k = 0; k < 3; k++)
                    acc[k] += rgba[k];
            }
            if (!covered) continue;
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

crisp_status crisp_render_cpu_plan(crisp_renderer *r, const crisp_scene *sc,
                                   const crisp_frame_plan *plan, const crisp_camera *cam,
                                   crisp_image *img, crisp_render_stats *stats)
{
    if (img->width != plan->width || img->height != plan->height || cam->width != plan->width ||
        cam->height != plan->height)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "image %dx%d and camera %dx%d do not match the plan's %dx%d", img->width,
                           img->height, cam->width, cam->height, plan->width, plan->height);
    if (plan->face_count != sc->face_count)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "the plan has %u faces, the scene %u: not the scene's plan",
                           plan->face_count, sc->face_count);
    crisp_render_stats local;
    if (!stats) stats = &local;
    crisp_status st;
    r->plan = plan;
    double t0 = crisp_time_now();
    /* Vertex and triangle offsets per leaf (and a sentinel). */
    size_t jobs = plan->leaf_count, nv = 0, nt = 0;
    if ((st = crisp_grow((void **)&r->leaf_vbase, &r->leaf_base_cap, jobs + 1,
                         sizeof *r->leaf_vbase)) ||
        (st = crisp_grow((void **)&r->leaf_tbase, &r->leaf_tbase_cap, jobs + 1,
                         sizeof *r->leaf_tbase)))
        return st;
    if ((st = crisp_grow((void **)&r->leaf_skip, &r->leaf_skip_cap, jobs ? jobs : 1,
                         sizeof *r->leaf_skip)))
        return st;
    skip_ctx skc = {.r = r, .sc = sc, .samples = r->desc.samples};
    for (int s = 0; s < r->desc.samples; s++)
        crisp__raster_sample_offset(r->desc.samples, s, skc.off[s]);
    crisp_pool_parallel_for(r->pool, jobs, 64, find_empty_leaves, &skc);
    for (size_t j = 0; j < jobs; j++) {
        crisp_tess_levels lv = leaf_levels(&plan->leaves[j]);
        size_t v = 0, t = 0;
        if (!r->leaf_skip[j] && (st = crisp_tess_mesh_counts(&lv, &v, &t))) return st;
        r->leaf_vbase[j] = (uint32_t)nv;
        r->leaf_tbase[j] = (uint32_t)nt;
        nv += v;
        nt += t;
        if (nv > UINT32_MAX / 2 || nt > UINT32_MAX / 2)
            return crisp_error(CRISP_ERR_LIMIT,
                               "more than 2^31 vertices or triangles in one frame");
    }
    r->leaf_vbase[jobs] = (uint32_t)nv;
    r->leaf_tbase[jobs] = (uint32_t)nt;
    /* Ribbons after the surfaces: at equal depth the surface's own fragment stays. */
    size_t surface_v = nv, surface_t = nt, quads = plan->ribbon_quad_count;
    nv += 4 * quads;
    nt += 2 * quads;
    if (nv > UINT32_MAX / 2 || nt > UINT32_MAX / 2)
        return crisp_error(CRISP_ERR_LIMIT, "more than 2^31 vertices or triangles in one frame");
    if ((st = crisp_grow((void **)&r->verts, &r->vert_cap, nv ? nv : 1, sizeof *r->verts)))
        return st;
    /* A triangle record is at least as large as the generator's three indices. */
    if ((st = crisp_grow((void **)&r->tris, &r->tri_cap, nt ? nt : 1, sizeof *r->tris))) return st;
    r->vert_count = surface_v; /* the surface mesh, without the ribbons */
    r->tri_count = surface_t;
    tess_ctx tc = {r, sc};
    crisp_pool_parallel_for(r->pool, jobs, 8, tessellate, &tc);
    ribbon_ctx rbc = {r, plan, surface_v, surface_t};
    crisp_pool_parallel_for(r->pool, quads, 256, copy_ribbons, &rbc);
    double t1 = crisp_time_now();

    crisp_raster_view view; /* for the ribbons' depth slack and the resolve's shading */
    raster_view(cam, &view);
    if ((st = crisp__raster_target_init(&r->target, cam->width, cam->height, r->desc.samples)))
        return st;
    crisp__raster_target_clear(&r->target);
    crisp_raster_stats rs;
    /* Surfaces first; then the ribbons fill gaps: a ribbon sample replaces a surface sample only
     * when nearer by more than that surface's depth change over 1.5 px, so a ribbon along an
     * edge that another face hides at nearly the same depth (seen at a grazing angle) does not
     * show through it. */
    void *ctx = (void *)plan;
    if ((st = crisp_grow((void **)&r->untested, &r->untested_cap,
                         plan->face_count ? plan->face_count : 1, sizeof *r->untested)))
        return st;
    for (uint32_t f = 0; f < plan->face_count; f++)
        r->untested[f] = (plan->faces[f].flags & CRISP_PLAN_FACE_ALL_INSIDE) != 0;
    crisp__raster_set_untested_faces(r->raster, r->untested, plan->face_count);
    /* The clip plane n . P + d >= 0 with P = eye + W (f + (x - w/2) kx r + (h/2 - y) ky u) on a
     * sample's ray at depth W, divided by W: affine in the sample's (x, y) and 1/W. */
    const double *cp = r->desc.clip_plane;
    if (cp[0] != 0 || cp[1] != 0 || cp[2] != 0) {
        double nf = crisp_vec3_dot(cp, view.f), nr = crisp_vec3_dot(cp, view.r),
               nu = crisp_vec3_dot(cp, view.u);
        double k[4] = {nf - 0.5 * cam->width * view.kx * nr + 0.5 * cam->height * view.ky * nu,
                       view.kx * nr, -view.ky * nu, crisp_vec3_dot(cp, cam->eye) + cp[3]};
        crisp__raster_set_clip(r->raster, k);
    } else {
        crisp__raster_set_clip(r->raster, NULL);
    }
    st = crisp__raster_draw(r->raster, &r->target, r->pool, r->verts, nv, r->tris, surface_t,
                            trim_test, ctx, &rs);
    if (st) return st;
    if (nt > surface_t) {
        size_t ns = (size_t)cam->width * cam->height * r->desc.samples;
        if ((st = crisp_grow((void **)&r->slack, &r->slack_cap, ns, sizeof *r->slack))) return st;
        crisp__raster_depth_slack(&r->target, r->pool, 1.5, &view, r->slack);
        crisp_raster_stats rs2;
        st = crisp__raster_draw_fill(r->raster, &r->target, r->pool, r->verts, nv,
                                     r->tris + surface_t, nt - surface_t, trim_test, ctx, r->slack,
                                     &rs2);
        if (st) return st;
        rs.fragments_tested += rs2.fragments_tested;
        rs.fragments_discarded += rs2.fragments_discarded;
    }
    double t2 = crisp_time_now();
    crisp__image_clear(img);
    resolve_ctx rc = {r, sc, cam, view, img};
    crisp_pool_parallel_for(r->pool, (size_t)cam->height, 8, resolve_rows, &rc);
    double t3 = crisp_time_now();
    copy_plan_stats(&plan->stats, stats);
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

crisp_status crisp_render_cpu(crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cam,
                              crisp_image *img, crisp_render_stats *stats)
{
    if (img->width != cam->width || img->height != cam->height)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image %dx%d does not match the camera's %dx%d",
                           img->width, img->height, cam->width, cam->height);
    const crisp_frame_plan *plan;
    crisp_status st = crisp_planner_plan(r->planner, sc, cam, &plan);
    if (st) return st;
    return crisp_render_cpu_plan(r, sc, plan, cam, img, stats);
}
