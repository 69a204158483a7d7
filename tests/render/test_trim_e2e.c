/* Trim correctness end to end (issue 4, first "Done means"): trimmed test faces go through the
 * whole pipeline (crisp_model -> crisp_scene_prepare -> crisp_render_cpu) and every pixel's alpha
 * is compared with the exact answer (crisp_render_exact: the pixel centre's ray against the true
 * surface, then the exact classifier on the true curves). Every disagreement is measured in
 * screen space against the true boundary (the trim curves and the domain edges mapped through the
 * true surface and the camera, refined until 0.02 px): none may lie farther than 1.0 px; the
 * count inside the band is reported.
 *
 * Faces: planar (rational, non-uniform weights and spacing), bilinear saddle, curved bicubic, and
 * a bicubic B-spline of 2x2 patches with uneven knots over the domain [1, 3.5] x [-2, -1.2];
 * trims: an ellipse with a circular hole (rational quadratics), a star polygon with a square hole,
 * a cubic graph with an elliptic hole. Cameras: frontal; grazing at 80, 85 and 89 degrees from the
 * normal; zoomed until a trim curve crosses the whole image, then on to fields of view of 1e-4
 * and 1e-7 degrees; the eye just above the surface looking along it (the surface crosses the near
 * plane and the eye plane); and the eye between two parallel faces. Also with 4 samples per pixel.
 * Argument "all": larger images and every combination (slow label); `--backend gl`: the same
 * checks on the GL backend drawing the same plans (tests/render/render_backend.h, gl label). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/image.h"
#include "crisp/render.h"
#include "crisp/trim.h"
#include "render/raster.h"
#include "render/render_internal.h"
#include "render/render_backend.h"
#include "trim/trim_test_util.h"

static int full;

/* ---- faces -------------------------------------------------------------------------------------
 */

enum { PATCH_KINDS = 4, TRIM_KINDS = 3 };

/* The domain of patch kind pk: [0, 1]^2 except kind 3. */
static void domain_of(int pk, double d[4])
{
    if (pk == 3) {
        d[0] = 1.0, d[1] = 3.5, d[2] = -2.0, d[3] = -1.2;
    } else {
        d[0] = 0.0, d[1] = 1.0, d[2] = 0.0, d[3] = 1.0;
    }
}

static crisp_surface *make_surface(int pk, double zoff)
{
    crisp_surface *s = NULL;
    if (pk < 3) {
        crisp_bezier_patch p;
        double cpw[64];
        tu_patch_kind(&p, pk, cpw);
        int nu = p.du + 1, nv = p.dv + 1;
        double ku[8], kv[8], pts[48], w[16];
        for (int i = 0; i < nu; i++)
            ku[i] = 0, ku[i + nu] = 1;
        for (int i = 0; i < nv; i++)
            kv[i] = 0, kv[i + nv] = 1;
        for (int k = 0; k < nu * nv; k++) {
            w[k] = cpw[4 * k + 3];
            for (int c = 0; c < 3; c++)
                pts[3 * k + c] = cpw[4 * k + c] / w[k];
            pts[3 * k + 2] += zoff;
        }
        assert_int_equal(crisp_surface_create(p.du, p.dv, nu, nv, ku, kv, pts, w, &s), CRISP_OK);
        return s;
    }
    /* 5x5 bicubic B-spline, interior knots at 1.4 (u) and -1.75 (v): four uneven patches. */
    const double ku[9] = {1, 1, 1, 1, 1.4, 3.5, 3.5, 3.5, 3.5};
    const double kv[9] = {-2, -2, -2, -2, -1.75, -1.2, -1.2, -1.2, -1.2};
    const double xs[5] = {0.0, 0.15, 0.7, 1.4, 2.0}, ys[5] = {0.0, 0.3, 0.9, 1.6, 2.0};
    double pts[75];
    for (int j = 0; j < 5; j++)
        for (int i = 0; i < 5; i++) {
            double *q = pts + 3 * (j * 5 + i);
            q[0] = xs[i];
            q[1] = ys[j];
            q[2] = 0.15 * sin(1.3 * i + 0.7 * j) + zoff;
        }
    assert_int_equal(crisp_surface_create(3, 3, 5, 5, ku, kv, pts, NULL, &s), CRISP_OK);
    return s;
}

/* Trim pieces in [0, 1]^2 (as the trim tests build them), loop by loop. */
static int make_loops(int tk, crisp_bezier_curve *pc, int *loop_len)
{
    if (tk == 0) {
        loop_len[0] = tu_ellipse(pc, 0.5, 0.5, 0.4, 0.3, 0.3, 1);
        loop_len[1] = tu_ellipse(pc + 4, 0.45, 0.5, 0.1, 0.1, 0.0, 0);
    } else if (tk == 1) {
        const double star[] = {0.1,  0.1, 0.5, 0.25, 0.9,  0.05, 0.8, 0.5,
                               0.95, 0.9, 0.5, 0.7,  0.15, 0.95, 0.3, 0.5};
        loop_len[0] = tu_polygon(pc, 8, star);
        const double hole[] = {0.45, 0.4, 0.45, 0.55, 0.6, 0.55, 0.6, 0.4};
        loop_len[1] = tu_polygon(pc + 8, 4, hole);
    } else {
        const double g[4] = {0.5, 0.95, 0.2, 0.7};
        loop_len[0] = tu_cubic_graph(pc, 0.1, 0.9, g, 0.08);
        loop_len[1] = tu_ellipse(pc + 4, 0.5, 0.25, 0.12, 0.06, 0.5, 0);
    }
    return 2;
}

/* A face: surface pk with trim tk mapped affinely from [0, 1]^2 onto the surface's domain. */
static void add_face(crisp_model *m, int pk, int tk, double zoff)
{
    crisp_bezier_curve pc[16];
    int len[2];
    int loops = make_loops(tk, pc, len);
    double d[4];
    domain_of(pk, d);
    crisp_face f = {.surface = make_surface(pk, zoff), .loop_count = loops};
    f.loops = calloc((size_t)loops, sizeof *f.loops);
    assert_non_null(f.loops);
    int first = 0;
    for (int l = 0; l < loops; l++) {
        f.loops[l].is_outer = l == 0;
        f.loops[l].curve_count = len[l];
        f.loops[l].curves = calloc((size_t)len[l], sizeof(crisp_curve *));
        assert_non_null(f.loops[l].curves);
        for (int c = 0; c < len[l]; c++) {
            const crisp_bezier_curve *b = &pc[first + c];
            int n = b->degree + 1;
            double knots[8], pts[8], w[4];
            for (int i = 0; i < n; i++)
                knots[i] = 0, knots[i + n] = 1;
            for (int i = 0; i < n; i++) {
                w[i] = b->cpw[3 * i + 2];
                pts[2 * i] = d[0] + (d[1] - d[0]) * b->cpw[3 * i] / w[i];
                pts[2 * i + 1] = d[2] + (d[3] - d[2]) * b->cpw[3 * i + 1] / w[i];
            }
            assert_int_equal(crisp_curve_create(2, b->degree, n, knots, pts, b->rational ? w : NULL,
                                                &f.loops[l].curves[c]),
                             CRISP_OK);
        }
        first += len[l];
    }
    assert_int_equal(crisp_face_normalize_loops(&f, 1e-9), CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
}

/* ---- the true boundary on screen ----------------------------------------------------------------
 */

typedef struct segs {
    double *xy; /* 4 per segment */
    size_t n, cap;
} segs;

typedef struct view {
    const crisp_scene *sc;
    crisp_camera cam;
    crisp_mat4 vp;
} view;

/* Screen position of the surface point of face f at (u, v); 0 when not in front of the eye. */
static int screen_of(const view *vw, uint32_t f, double u, double v, double xy[2])
{
    double P[3], c[4], s[3];
    crisp_mat4 vp;
    memcpy(vp, vw->vp, sizeof vp);
    crisp_surface_eval(vw->sc->faces[f].src->surface, u, v, P);
    crisp_mat4_mulp(vp, P, c);
    if (!(c[3] > 0)) return 0;
    crisp_camera_to_pixel(&vw->cam, c, s);
    xy[0] = s[0];
    xy[1] = s[1];
    return 1;
}

static void add_seg(segs *sg, const double a[2], const double b[2])
{
    if (sg->n == sg->cap) {
        sg->cap = sg->cap ? 2 * sg->cap : 1024;
        sg->xy = realloc(sg->xy, sg->cap * 4 * sizeof(double));
        assert_non_null(sg->xy);
    }
    double *d = sg->xy + 4 * sg->n++;
    d[0] = a[0], d[1] = a[1], d[2] = b[0], d[3] = b[1];
}

/* uv of a boundary curve: a Bézier trim piece, or (piece == NULL) a domain edge from a to b. */
typedef struct bcurve {
    const crisp_bezier_curve *piece;
    double a[2], b[2];
} bcurve;

static void bcurve_uv(const bcurve *c, double t, double uv[2])
{
    if (c->piece) {
        crisp_bezier_curve_eval(c->piece, t, uv); /* local parameter */
    } else {
        uv[0] = c->a[0] + t * (c->b[0] - c->a[0]);
        uv[1] = c->a[1] + t * (c->b[1] - c->a[1]);
    }
}

/* Refine [t0, t1] until screen segments are 0.02 px long, dropping parts far from the image and
 * parts behind the eye. */
static void project(const view *vw, uint32_t f, const bcurve *c, segs *sg, double t0, double t1,
                    const double p0[2], int ok0, const double p1[2], int ok1, int depth)
{
    int w = vw->cam.width, h = vw->cam.height;
    if (ok0 && ok1) {
        double len = hypot(p1[0] - p0[0], p1[1] - p0[1]);
        double fx = fmax(fmax(-fmax(p0[0], p1[0]), fmin(p0[0], p1[0]) - w), 0.0);
        double fy = fmax(fmax(-fmax(p0[1], p1[1]), fmin(p0[1], p1[1]) - h), 0.0);
        if (hypot(fx, fy) > len + 4.0 && depth > 8) return;
        if (len <= 0.02 || depth >= 70) {
            add_seg(sg, p0, p1);
            return;
        }
    } else if (depth >= 70 || (!ok0 && !ok1 && depth >= 12)) {
        return;
    }
    double tm = 0.5 * (t0 + t1), pm[2], uv[2];
    bcurve_uv(c, tm, uv);
    int okm = screen_of(vw, f, uv[0], uv[1], pm);
    project(vw, f, c, sg, t0, tm, p0, ok0, pm, okm, depth + 1);
    project(vw, f, c, sg, tm, t1, pm, okm, p1, ok1, depth + 1);
}

static void boundary_segments(const view *vw, segs *sg)
{
    for (uint32_t f = 0; f < vw->sc->face_count; f++) {
        const crisp_scene_face *sf = &vw->sc->faces[f];
        const double *d = sf->domain;
        bcurve cs[4 + 64];
        int n = 0;
        const double corners[5][2] = {
            {d[0], d[2]}, {d[1], d[2]}, {d[1], d[3]}, {d[0], d[3]}, {d[0], d[2]}};
        for (int k = 0; k < 4; k++) {
            cs[n] = (bcurve){
                NULL, {corners[k][0], corners[k][1]}, {corners[k + 1][0], corners[k + 1][1]}};
            n++;
        }
        for (uint32_t k = 0; k < sf->piece_count && n < 68; k++)
            cs[n++] = (bcurve){.piece = &vw->sc->pieces[sf->first_piece + k]};
        for (int k = 0; k < n; k++) {
            double uv[2], p0[2], p1[2];
            bcurve_uv(&cs[k], 0, uv);
            int ok0 = screen_of(vw, f, uv[0], uv[1], p0);
            bcurve_uv(&cs[k], 1, uv);
            int ok1 = screen_of(vw, f, uv[0], uv[1], p1);
            project(vw, f, &cs[k], sg, 0, 1, p0, ok0, p1, ok1, 0);
        }
    }
}

static double seg_dist(const double *s, double x, double y)
{
    double dx = s[2] - s[0], dy = s[3] - s[1], l2 = dx * dx + dy * dy;
    double u = l2 > 0 ? ((x - s[0]) * dx + (y - s[1]) * dy) / l2 : 0.0;
    u = fmin(fmax(u, 0.0), 1.0);
    return hypot(s[0] + u * dx - x, s[1] + u * dy - y);
}

/* ---- silhouettes
 * ---------------------------------------------------------------------------------- */

/* Surface layers the ray through screen point (x, y) crosses between the near and far planes (at
 * most 8), trims ignored. */
static int layers(const crisp_scene *sc, const crisp_camera *cam, const double fwd[3], double x,
                  double y)
{
    double o[3], dir[3], t;
    crisp_camera_ray(cam, x, y, o, dir);
    double c = crisp_vec3_dot(dir, fwd), t0 = cam->znear / c, t1 = cam->zfar / c;
    int n = 0;
    crisp_exact_desc none = {0};
    while (n < 8 && crisp_exact_ray(sc, &none, o, dir, t0, t1, &t, NULL, NULL, NULL)) {
        n++;
        t0 = t + 1e-9 * (t + 1);
    }
    return n;
}

/* 1 when a silhouette of the surface (or the near plane's cut through it) passes within 1 px of
 * (x, y): the number of surface layers along the ray changes somewhere on rings of radius 0.5 and
 * 1 px around it. There the image follows the surface accuracy bound (triangles within 0.5 px of
 * the surface), not the trim test. */
static int near_silhouette(const crisp_scene *sc, const crisp_camera *cam, const double fwd[3],
                           double x, double y)
{
    int n0 = layers(sc, cam, fwd, x, y);
    for (int r = 1; r <= 2; r++)
        for (int k = 0; k < 16; k++) {
            double a = 2 * M_PI * k / 16;
            if (layers(sc, cam, fwd, x + 0.5 * r * cos(a), y + 0.5 * r * sin(a)) != n0) return 1;
        }
    return 0;
}

/* ---- one view
 * ------------------------------------------------------------------------------------- */

typedef struct tally {
    long pixels, covered, inside, disagree, in_band, out_band, silhouette;
    double worst, worst_in;
} tally;

static int exact_classify(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)ctx;
    const crisp_scene_face *f = &sc->faces[face];
    if (!f->piece_count) return 1;
    return crisp_trim_exact_classify(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
}

/* Render with the backend under test (samples 1 or 4) and compare every sample with the exact
 * answer. */
static void check_view(const crisp_scene *sc, crisp_renderer *r, int samples,
                       const crisp_camera *cam, const char *what, tally *all)
{
    int w = cam->width, h = cam->height;
    crisp_image cpu, ex;
    assert_int_equal(crisp_image_init(&cpu, w, h), CRISP_OK);
    assert_int_equal(crisp_image_init(&ex, w, h), CRISP_OK);
    crisp_render_stats st;
    crisp_status s = render_backend(rb_kind, r, samples, sc, cam, &cpu, &st);
    if (s) fprintf(stderr, "%s: %s\n", what, crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    if (getenv("DUMP") && strstr(what, getenv("DUMP"))) {
        char fn[200];
        snprintf(fn, sizeof fn, "/tmp/dump_%s.png", rb_name());
        uint8_t *px8 = malloc((size_t)w * h * 4);
        for (size_t k = 0; k < (size_t)w * h * 4; k++)
            px8[k] = (uint8_t)(255 * fminf(1, cpu.rgba[k]));
        for (size_t k = 0; k < (size_t)w * h; k++)
            px8[4 * k + 3] = 255, px8[4 * k] = cpu.face[k] >= 0 ? px8[4 * k] : 255;
        crisp_write_png_rgba(fn, w, h, px8);
        free(px8);
    }
    crisp_exact_desc d = {.threads = 2, .classify = exact_classify};
    view vw = {.sc = sc, .cam = *cam};
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    crisp_mat4_copy(m.view_proj, vw.vp);
    segs sg = {0};
    int have_segs = 0;
    tally t = {0};
    /* Every sample of the backend (the per-sample faces) against the exact
     * answer for the ray through that sample (for one sample per pixel: the exact image). */
    const int32_t *sample_face = rb_sample_faces();
    if (samples == 1) assert_int_equal(crisp_render_exact(sc, cam, &d, &ex), CRISP_OK);
    double fwd[3];
    crisp_vec3_sub(cam->target, cam->eye, fwd);
    crisp_vec3_normalize(fwd, fwd);
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            size_t px = (size_t)j * w + i;
            assert_true(isfinite(cpu.rgba[4 * px + 3]));
            for (int q = 0; q < samples; q++) {
                double off[2];
                crisp__raster_sample_offset(samples, q, off);
                int want;
                if (samples == 1) {
                    want = ex.face[px] >= 0;
                } else {
                    double o[3], dir[3];
                    crisp_camera_ray(cam, i + off[0], j + off[1], o, dir);
                    double c = crisp_vec3_dot(dir, fwd);
                    want = crisp_exact_ray(sc, &d, o, dir, cam->znear / c, cam->zfar / c, NULL,
                                           NULL, NULL, NULL);
                }
                int got = sample_face[px * samples + q] >= 0;
                t.pixels++;
                t.inside += want;
                if (got == want) continue;
                t.disagree++;
                if (!have_segs) {
                    boundary_segments(&vw, &sg);
                    have_segs = 1;
                }
                double dist = HUGE_VAL;
                for (size_t k = 0; k < sg.n; k++)
                    dist = fmin(dist, seg_dist(sg.xy + 4 * k, i + off[0], j + off[1]));
                if (dist <= 1.0 + 0.02) {
                    t.worst_in = fmax(t.worst_in, dist);
                    t.in_band++;
                } else if (near_silhouette(sc, cam, fwd, i + off[0], j + off[1])) {
                    t.silhouette++;
                } else {
                    t.out_band++;
                    if (t.out_band <= 3)
                        fprintf(
                            stderr,
                            "  %s: sample (%g, %g): %s %d, exact %d, %.3f px from the boundary\n",
                            what, i + off[0], j + off[1], rb_name(), got, want, dist);
                }
            }
        }
    for (size_t px = 0; px < (size_t)w * h; px++)
        t.covered += cpu.face[px] >= 0;
    printf("  %-44s %6ld px, %6ld inside, %4ld disagree (%4ld within 1 px, %ld at a silhouette, "
           "%ld beyond), "
           "%llu rows%s\n",
           what, t.pixels, t.inside, t.disagree, t.in_band, t.silhouette, t.out_band,
           (unsigned long long)st.table_rows, st.unresolved ? " (unresolved leaves)" : "");
    all->pixels += t.pixels;
    all->inside += t.inside;
    all->disagree += t.disagree;
    all->in_band += t.in_band;
    all->out_band += t.out_band;
    all->silhouette += t.silhouette;
    all->worst = fmax(all->worst, t.in_band ? t.worst_in : 0.0);
    free(sg.xy);
    crisp_image_free(&cpu);
    crisp_image_free(&ex);
}

/* ---- cameras ------------------------------------------------------------------------------------
 */

enum {
    CAM_FRONTAL,
    CAM_GRAZE80,
    CAM_GRAZE85,
    CAM_GRAZE89,
    CAM_ZOOM,
    CAM_ZOOM_1E4,
    CAM_ZOOM_1E7,
    CAM_SKIM,
    CAMS
};
static const char *const cam_names[CAMS] = {
    "frontal",        "grazing 80 deg", "grazing 85 deg",    "grazing 89 deg", "zoom: curve across",
    "zoom: fov 1e-4", "zoom: fov 1e-7", "eye on the surface"};

/* Surface point and unit normal (towards +z) of face 0 at the domain point mapped from (a, b). */
static void surface_frame(const crisp_scene *sc, double a, double b, double p[3], double n[3])
{
    const crisp_scene_face *f = &sc->faces[0];
    double u = f->domain[0] + a * (f->domain[1] - f->domain[0]);
    double v = f->domain[2] + b * (f->domain[3] - f->domain[2]);
    double d[18];
    crisp_surface_derivs(f->src->surface, u, v, p, d, d + 3, NULL, NULL, NULL);
    crisp_vec3_cross(d, d + 3, n);
    crisp_vec3_normalize(n, n);
    if (n[2] < 0) crisp_vec3_scale(n, -1, n);
}

static crisp_camera make_camera(const crisp_scene *sc, int cam, int size)
{
    crisp_camera c = {
        .up = {0, 0, 1}, .fov_deg = 45, .znear = 0.05, .zfar = 50, .width = size, .height = size};
    if (cam == CAM_FRONTAL) {
        double e[3] = {1, 1, 3.5}, t[3] = {1, 1, 0};
        memcpy(c.eye, e, sizeof e), memcpy(c.target, t, sizeof t);
        c.up[1] = 1, c.up[2] = 0;
    } else if (cam <= CAM_GRAZE89) {
        double el = (cam == CAM_GRAZE80 ? 10 : cam == CAM_GRAZE85 ? 5 : 1) * M_PI / 180;
        double p[3], n[3];
        surface_frame(sc, 0.5, 0.45, p, n);
        for (int k = 0; k < 3; k++)
            c.target[k] = p[k];
        c.eye[0] = p[0] - 3 * cos(el) * 0.8, c.eye[1] = p[1] - 3 * cos(el) * 0.6,
        c.eye[2] = p[2] + 3 * sin(el);
        c.fov_deg = cam == CAM_GRAZE89 ? 3 : 20;
    } else if (cam <= CAM_ZOOM_1E7) {
        /* Straight at a point of the outer trim curve from 0.004 above, slightly oblique. */
        const crisp_scene_face *f = &sc->faces[0];
        double uv[2], p[3], d[18], n[3];
        crisp_bezier_curve_eval(&sc->pieces[f->first_piece], 0.37, uv);
        crisp_surface_derivs(f->src->surface, uv[0], uv[1], p, d, d + 3, NULL, NULL, NULL);
        crisp_vec3_cross(d, d + 3, n);
        crisp_vec3_normalize(n, n);
        if (n[2] < 0) crisp_vec3_scale(n, -1, n);
        for (int k = 0; k < 3; k++) {
            c.target[k] = p[k];
            c.eye[k] = p[k] + 0.004 * n[k] + (k == 0 ? 0.002 : 0.0);
        }
        c.fov_deg = cam == CAM_ZOOM ? 20 : cam == CAM_ZOOM_1E4 ? 1e-4 : 1e-7;
        c.znear = 0.0005;
    } else {
        /* 0.002 above the surface at (0.75, 0.5) of the domain, looking along it: the surface
         * passes under the eye, through the near plane and behind the eye. */
        double p[3], n[3];
        surface_frame(sc, 0.75, 0.5, p, n);
        for (int k = 0; k < 3; k++)
            c.eye[k] = p[k] + 0.002 * n[k];
        c.target[0] = p[0] - 1.0, c.target[1] = p[1] + 0.15, c.target[2] = p[2] - 0.1;
        c.fov_deg = 80;
        c.znear = 1e-4;
    }
    return c;
}

static void run(int pk, int tk, int cam, int samples, int size, tally *all)
{
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    add_face(m, pk, tk, 0);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_renderer *r;
    assert_int_equal(
        crisp_renderer_create(&(crisp_render_desc){.threads = 2, .samples = samples}, &r),
        CRISP_OK);
    crisp_camera c = make_camera(sc, cam, size);
    char what[96];
    snprintf(what, sizeof what, "patch %d trim %d %s%s", pk, tk, cam_names[cam],
             samples == 4 ? " x4" : "");
    check_view(sc, r, samples, &c, what, all);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

static void report(const char *name, const tally *t)
{
    printf("%s: %ld samples, %ld inside, %ld disagree with the exact answer: %ld within 1 px of "
           "the true "
           "trim boundary (farthest %.3f px), %ld within 1 px of a silhouette, %ld beyond\n",
           name, t->pixels, t->inside, t->disagree, t->in_band, t->worst, t->silhouette,
           t->out_band);
}

static void camera_group(int cam0, int cam1, const char *name)
{
    tally all = {0};
    int size = full ? 192 : 64;
    for (int cam = cam0; cam <= cam1; cam++)
        for (int pk = 0; pk < PATCH_KINDS; pk++)
            for (int tk = 0; tk < TRIM_KINDS; tk++) {
                if (!full && (pk + tk + cam) % 2)
                    continue; /* half the combinations in the fast suite */
                run(pk, tk, cam, 1, size, &all);
            }
    report(name, &all);
    assert_true(all.inside > all.pixels / 10);
    assert_true(all.inside < all.pixels - all.pixels / 10);
    assert_int_equal(all.out_band, 0);
}

static void test_frontal(void **state)
{
    (void)state;
    camera_group(CAM_FRONTAL, CAM_FRONTAL, "frontal");
}

static void test_grazing(void **state)
{
    (void)state;
    camera_group(CAM_GRAZE80, CAM_GRAZE89, "grazing");
}

static void test_zoom(void **state)
{
    (void)state;
    camera_group(CAM_ZOOM, CAM_ZOOM_1E7, "zoomed");
}

static void test_eye_on_surface(void **state)
{
    (void)state;
    camera_group(CAM_SKIM, CAM_SKIM, "eye on the surface");
}

/* Two parallel trimmed faces 0.02 apart (patch kind pk, trims tk and the next) with the eye
 * between them, looking along them: both cross the near plane and the eye plane. */
static void between_faces(int pk, int tk, int size, tally *all)
{
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    add_face(m, pk, tk, 0);
    add_face(m, pk, (tk + 1) % TRIM_KINDS, 0.02);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
    double p[3], n[3];
    surface_frame(sc, 0.8, 0.55, p, n);
    crisp_camera c = {
        .up = {0, 0, 1}, .fov_deg = 90, .znear = 1e-4, .zfar = 50, .width = size, .height = size};
    for (int k = 0; k < 3; k++)
        c.eye[k] = p[k] + 0.01 * n[k];
    c.target[0] = c.eye[0] - 1, c.target[1] = c.eye[1] - 0.2, c.target[2] = c.eye[2] + 0.001;
    char what[64];
    snprintf(what, sizeof what, "patch %d trims %d/%d eye between faces", pk, tk,
             (tk + 1) % TRIM_KINDS);
    check_view(sc, r, 1, &c, what, all);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

static void test_between_faces(void **state)
{
    (void)state;
    tally all = {0};
    int size = full ? 160 : 64;
    for (int pk = 0; pk < PATCH_KINDS; pk++) {
        if (pk == 2 || pk == 3) continue; /* the curved ones intersect each other at 0.02 apart */
        for (int tk = 0; tk < TRIM_KINDS; tk++)
            between_faces(pk, tk, size, &all);
    }
    report("eye between two faces", &all);
    assert_true(all.inside > all.pixels / 10);
    assert_int_equal(all.out_band, 0);
}

/* One view of test_between_faces' full run (160 x 160) where the GL backend left one sample
 * 5.5 px inside the plane uncovered: leaves of different sizes placed their shared edge's
 * vertices at the tessellator's float coordinates, rounded differently on either side
 * (shaders/surface_tes.glsl now takes k / n exactly on outer edges). */
static void test_between_faces_edge(void **state)
{
    (void)state;
    tally all = {0};
    between_faces(0, 0, 160, &all);
    assert_int_equal(all.out_band, 0);
}

/* Faces a few pixels across (issue 12: one strip per pixel, trim loops as chains of few chords):
 * every face kind and trim seen obliquely from 2, 4 and 9 times the frontal distance (about 20, 9
 * and 4 px across). */
static void test_tiny_faces(void **state)
{
    (void)state;
    tally all = {0};
    static const double far[3] = {2, 4, 9};
    for (int k = 0; k < 3; k++)
        for (int pk = 0; pk < PATCH_KINDS; pk++)
            for (int tk = 0; tk < TRIM_KINDS; tk++) {
                crisp_model *m;
                assert_int_equal(crisp_model_create(&m), CRISP_OK);
                add_face(m, pk, tk, 0);
                crisp_scene *sc;
                assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
                crisp_renderer *r;
                assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r),
                                 CRISP_OK);
                crisp_camera c = make_camera(sc, CAM_FRONTAL, 64);
                const double dir[3] = {0.9, -0.7, 3.2};
                for (int q = 0; q < 3; q++)
                    c.eye[q] = c.target[q] + far[k] * dir[q];
                c.zfar = 4 * far[k] * 3.5;
                char what[64];
                snprintf(what, sizeof what, "patch %d trim %d from %gx as far", pk, tk, far[k]);
                check_view(sc, r, 1, &c, what, &all);
                crisp_renderer_destroy(r);
                crisp_scene_destroy(sc);
                crisp_model_destroy(m);
            }
    report("tiny faces", &all);
    assert_true(all.inside > 300);
    assert_int_equal(all.out_band, 0);
}

/* Four samples per pixel: every sample agrees with the exact answer for its own ray, or lies
 * within 1 px of the true boundary. */
static void test_four_samples(void **state)
{
    (void)state;
    tally all = {0};
    int size = full ? 96 : 40;
    static const int cams[] = {CAM_FRONTAL, CAM_GRAZE85, CAM_ZOOM_1E7, CAM_SKIM};
    for (int k = 0; k < 4; k++)
        for (int pk = 0; pk < PATCH_KINDS; pk++) {
            if (!full && (pk + k) % 2) continue;
            run(pk, (pk + k) % TRIM_KINDS, cams[k], 4, size, &all);
        }
    report("4 samples", &all);
    assert_int_equal(all.out_band, 0);
}

int main(int argc, char **argv)
{
    argc = rb_parse_args(argc, argv);
    full = argc > 1 && !strcmp(argv[1], "all");
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frontal),
        cmocka_unit_test(test_grazing),
        cmocka_unit_test(test_zoom),
        cmocka_unit_test(test_eye_on_surface),
        cmocka_unit_test(test_between_faces),
        cmocka_unit_test(test_four_samples),
        cmocka_unit_test(test_between_faces_edge),
        cmocka_unit_test(test_tiny_faces),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
