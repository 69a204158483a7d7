/* crisp-view's debugging views of the frame plan (include/crisp/plan.h), as the paper's figures
 * show them: the wireframe of the current tessellation (each leaf's grid at its inner level tau,
 * its borders at the crack-free edge levels; hidden segments dropped against the frame's depth)
 * and, for the selected face, the trim table's scan lines in (u, v) (the inside spans between
 * crossing pairs of every row, the strip boundaries, the true trim loops over them). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/plan.h"
#include "ui.h"
#include "view.h"

#define WIRE_MAX_SEGMENTS 400000

typedef struct wire_ctx {
    const crisp_camera *cam;
    crisp_camera_matrices m;
    const crisp_image *img;
    int scale;
    double f[3];
} wire_ctx;

/* Screen point and camera depth of a surface point; 0 when behind the eye. */
static int to_screen(const wire_ctx *c, const double p[3], double px[3])
{
    double clip[4], d[3];
    crisp_mat4 vp;
    memcpy(vp, c->m.view_proj, sizeof vp);
    crisp_mat4_mulp(vp, p, clip);
    if (!(clip[3] > 0)) return 0;
    crisp_camera_to_pixel(c->cam, clip, px);
    crisp_vec3_sub(p, c->cam->eye, d);
    px[2] = crisp_vec3_dot(d, c->f);
    return 1;
}

/* A segment is drawn where its middle falls on a pixel of its own face (so trimmed-away parts of
 * the patch and hidden parts do not show) no deeper than what the frame drew there (with a slack
 * for the tessellation and the float depth). */
static int visible(const wire_ctx *c, const double a[3], const double b[3], uint32_t face)
{
    if (!c->img) return 1;
    double x = 0.5 * (a[0] + b[0]) / c->scale, y = 0.5 * (a[1] + b[1]) / c->scale;
    int i = (int)floor(x), j = (int)floor(y);
    if (i < 0 || j < 0 || i >= c->img->width || j >= c->img->height) return 0;
    double z = 0.5 * (a[2] + b[2]);
    size_t k = (size_t)j * c->img->width + i;
    if (c->img->face[k] != (int32_t)face) return 0;
    return z <= c->img->depth[k] * (1 + 2e-3) + 1e-9;
}

static void add_segment(view *v, const wire_ctx *c, const double a[3], const double b[3],
                        uint32_t face)
{
    if (v->wire_count >= WIRE_MAX_SEGMENTS || !visible(c, a, b, face)) return;
    if (v->wire_count == v->wire_cap) {
        size_t cap = v->wire_cap ? 2 * v->wire_cap : 4096;
        float *w = realloc(v->wire, cap * 4 * sizeof *w);
        if (!w) return;
        v->wire = w;
        v->wire_cap = cap;
    }
    float *w = v->wire + 4 * v->wire_count++;
    w[0] = (float)a[0], w[1] = (float)a[1], w[2] = (float)b[0], w[3] = (float)b[1];
}

void view_wire_update(view *v)
{
    v->wire_count = 0;
    v->wire_truncated = 0;
    const crisp_frame_plan *plan = v->backend.plan ? v->backend.plan(v->backend.self) : NULL;
    if (!plan || !v->doc) return;
    const crisp_scene *sc = v->rdoc.scene;
    wire_ctx c = {.cam = &v->nav.cam,
                  .img = v->backend.image ? v->backend.image(v->backend.self) : NULL,
                  .scale = v->last.scale > 0 ? v->last.scale : 1};
    crisp_camera_matrices_compute(&v->nav.cam, &c.m);
    double d[3];
    crisp_vec3_sub(v->nav.cam.target, v->nav.cam.eye, d);
    crisp_vec3_normalize(d, c.f);
    double *pts = NULL;
    size_t pts_cap = 0;
    for (uint32_t li = 0; li < plan->leaf_count; li++) {
        const crisp_plan_leaf *L = &plan->leaves[li];
        const crisp_scene_patch *P = &sc->patches[L->patch];
        const crisp_surface *S = sc->faces[P->face].src->surface;
        double cell = ldexp(1.0, -(int)L->depth);
        int n = (int)L->tau;
        size_t need = (size_t)(n + 1) * (n + 1) * 4;
        if (need > pts_cap) {
            double *q = realloc(pts, need * sizeof *q);
            if (!q) break;
            pts = q;
            pts_cap = need;
        }
        /* the leaf's grid at tau: screen x, y, depth and a valid flag */
        for (int j = 0; j <= n; j++)
            for (int i = 0; i <= n; i++) {
                double s = (L->ix + (double)i / n) * cell, t = (L->iy + (double)j / n) * cell;
                double u = P->bez.u0 + s * (P->bez.u1 - P->bez.u0);
                double w = P->bez.v0 + t * (P->bez.v1 - P->bez.v0);
                double p[3];
                crisp_surface_eval(S, u, w, p);
                double *q = pts + 4 * ((size_t)j * (n + 1) + i);
                q[3] = to_screen(&c, p, q);
            }
        for (int j = 0; j <= n; j++)
            for (int i = 0; i <= n; i++) {
                const double *q = pts + 4 * ((size_t)j * (n + 1) + i);
                /* inner lines only: the borders follow the edge levels below */
                if (i < n && j > 0 && j < n && q[3] && q[7]) add_segment(v, &c, q, q + 4, P->face);
                const double *r = pts + 4 * ((size_t)(j + 1) * (n + 1) + i);
                if (j < n && i > 0 && i < n && q[3] && r[3]) add_segment(v, &c, q, r, P->face);
            }
        /* borders at the edge levels: t = 0, s = 1, t = 1, s = 0 */
        for (int e = 0; e < 4; e++) {
            int m = (int)L->edge[e];
            double prev[4] = {0};
            for (int k = 0; k <= m; k++) {
                double a = (double)k / m, s, t;
                if (e == 0) s = a, t = 0;
                else if (e == 1) s = 1, t = a;
                else if (e == 2) s = a, t = 1;
                else s = 0, t = a;
                s = (L->ix + s) * cell;
                t = (L->iy + t) * cell;
                double p[3], q[4];
                crisp_surface_eval(S, P->bez.u0 + s * (P->bez.u1 - P->bez.u0),
                                   P->bez.v0 + t * (P->bez.v1 - P->bez.v0), p);
                q[3] = to_screen(&c, p, q);
                if (k > 0 && q[3] && prev[3]) add_segment(v, &c, prev, q, P->face);
                memcpy(prev, q, sizeof prev);
            }
        }
    }
    free(pts);
    v->wire_truncated = v->wire_count >= WIRE_MAX_SEGMENTS;
    v->wire_leaves = plan->leaf_count;
}

void view_wire_draw(view *v)
{
    for (size_t k = 0; k < v->wire_count; k++) {
        const float *w = v->wire + 4 * k;
        app_ui_bline(w[0], w[1], w[2], w[3], 0xb0202020u, 1.0f);
    }
}

/* A rational Bézier trim piece in (u, v) at parameter t (de Casteljau on the homogeneous
 * points). */
static void piece_eval(const crisp_bezier_curve *c, double t, double uv[2])
{
    double q[(CRISP_MAX_DEGREE + 1) * 3];
    memcpy(q, c->cpw, (size_t)(c->degree + 1) * 3 * sizeof *q);
    for (int r = 1; r <= c->degree; r++)
        for (int k = 0; k <= c->degree - r; k++)
            for (int a = 0; a < 3; a++) q[3 * k + a] = (1 - t) * q[3 * k + a] + t * q[3 * (k + 1) + a];
    uv[0] = q[0] / q[2];
    uv[1] = q[1] / q[2];
}

void view_scan_panel(view *v)
{
    const crisp_frame_plan *plan = v->backend.plan ? v->backend.plan(v->backend.self) : NULL;
    int32_t fi = v->ov.selected_face; /* in the drawn scene */
    if (!app_ui_begin("Trim table scan lines (T)", 10, 140, 0, 0)) {
        app_ui_end();
        return;
    }
    if (!v->doc || fi < 0 || (uint32_t)fi >= v->rdoc.scene->face_count) {
        app_ui_text("Click a face to see its trim table.");
        app_ui_end();
        return;
    }
    if (!plan) {
        app_ui_text("No plan for this frame yet.");
        app_ui_end();
        return;
    }
    const crisp_scene *sc = v->rdoc.scene;
    const crisp_scene_face *F = &sc->faces[fi];
    const crisp_plan_face *pf = &plan->faces[fi];
    /* the region shown: the loops' box, else the table's v-range over the domain's u */
    double box[4] = {F->domain[0], F->domain[1], pf->v0, pf->v1};
    if (F->piece_count) {
        box[0] = box[2] = INFINITY;
        box[1] = box[3] = -INFINITY;
        for (uint32_t k = 0; k < F->piece_count; k++)
            for (int i = 0; i <= 16; i++) {
                double uv[2];
                piece_eval(&sc->pieces[F->first_piece + k], i / 16.0, uv);
                box[0] = fmin(box[0], uv[0]);
                box[1] = fmax(box[1], uv[0]);
                box[2] = fmin(box[2], uv[1]);
                box[3] = fmax(box[3], uv[1]);
            }
    }
    uint64_t rows = 0, crossings = 0;
    for (uint32_t s = 0; s < pf->strip_count; s++) {
        const crisp_plan_strip *st = &plan->strips[pf->first_strip + s];
        rows += st->row_count;
        if (st->row_count)
            crossings += plan->row_offset[st->first_row + st->row_count] - plan->row_offset[st->first_row];
    }
    app_ui_text("face %d: %u strips, %llu rows, %llu crossings%s", fi, pf->strip_count,
                (unsigned long long)rows, (unsigned long long)crossings,
                pf->flags & CRISP_PLAN_FACE_VISIBLE ? "" : " (not visible)");
    const float W = 420, H = 320;
    float o[2];
    app_ui_canvas(W, H, o);
    double su = (box[1] - box[0]) > 0 ? (W - 8) / (box[1] - box[0]) : 1;
    double sv = (box[3] - box[2]) > 0 ? (H - 8) / (box[3] - box[2]) : 1;
#define PX(u) (o[0] + 4 + (float)(((u) - box[0]) * su))
#define PY(w) (o[1] + H - 4 - (float)(((w) - box[2]) * sv))
    app_ui_wrect(o[0], o[1], o[0] + W, o[1] + H, 0xff202020u);
    /* strips and their rows' inside spans; at most about one drawn row per canvas pixel */
    for (uint32_t s = 0; s < pf->strip_count; s++) {
        const crisp_plan_strip *st = &plan->strips[pf->first_strip + s];
        double v0 = pf->v0 + s / pf->strip_scale;
        app_ui_wline(o[0], PY(v0), o[0] + W, PY(v0), 0x60ffa040u, 1);
        uint32_t step = 1;
        if (st->row_count > 0) {
            double px_per_row = sv / st->row_scale;
            if (px_per_row < 1) step = (uint32_t)ceil(1 / px_per_row);
        }
        for (uint32_t r = 0; r < st->row_count; r += step) {
            uint32_t g = st->first_row + r;
            double w = st->a + (r + 0.5) / st->row_scale;
            for (uint32_t k = plan->row_offset[g]; k + 1 < plan->row_offset[g + 1]; k += 2)
                app_ui_wline(PX(plan->crossings[k]), PY(w), PX(plan->crossings[k + 1]), PY(w),
                             0xff40c040u, 1);
        }
    }
    /* the true loops */
    for (uint32_t k = 0; k < F->piece_count; k++) {
        double a[2], b[2];
        piece_eval(&sc->pieces[F->first_piece + k], 0, a);
        for (int i = 1; i <= 32; i++) {
            piece_eval(&sc->pieces[F->first_piece + k], i / 32.0, b);
            app_ui_wline(PX(a[0]), PY(a[1]), PX(b[0]), PY(b[1]), 0xffffffffu, 1.5f);
            memcpy(a, b, sizeof a);
        }
    }
#undef PX
#undef PY
    app_ui_text("green: rows' inside spans (one row per pixel at most), orange: strip bottoms,");
    app_ui_text("white: the true trim loops");
    app_ui_end();
}
