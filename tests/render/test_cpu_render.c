/* The CPU backend against the truth:
 *  - surface accuracy: on bundled models under random cameras, every drawn triangle stays within
 *    0.5 px (screen distance) of the true surface evaluated at the interpolated (u, v);
 *  - agreement with the exact renderer on every pixel away (1.5 px and more) from face
 *    boundaries, trims and silhouettes;
 *  - no cracks: closed surfaces (a sphere and a torus of rational patches) show no background
 *    pixel inside their silhouette over many views, also with the camera close enough to split.
 *  - the clip plane (a section view) discards exactly the fragments on its cut side;
 * `--backend gl`: the image checks again on the GL backend drawing the same plans (gl label). */
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_test_util.h"
#include "crisp/construct.h"
#include "crisp/io.h"
#include "crisp/render.h"
#include "crisp/trim.h"
#include "render/raster.h"
#include "render/render_internal.h"
#include "render/render_backend.h"

static uint64_t rng = 0x9e3779b97f4a7c15ull;
static double rnd(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* A random camera looking at the box from outside, at 1.2 to 4 radii. */
static crisp_camera random_camera(const double box[6], int w, int h, double near_scale)
{
    double c[3], r = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * (box[k] + box[k + 3]);
        r += 0.25 * (box[k + 3] - box[k]) * (box[k + 3] - box[k]);
    }
    r = sqrt(r);
    double d[3], n;
    do {
        for (int k = 0; k < 3; k++)
            d[k] = 2 * rnd() - 1;
        n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    } while (n < 0.1 || n > 1);
    double dist = r * (1.2 + 2.8 * rnd());
    crisp_camera cam = {.fov_deg = 20 + 40 * rnd(), .width = w, .height = h};
    for (int k = 0; k < 3; k++) {
        cam.eye[k] = c[k] + dist * d[k] / n;
        cam.target[k] = c[k] + 0.3 * r * (2 * rnd() - 1);
    }
    cam.up[0] = 0.1, cam.up[1] = 1, cam.up[2] = 0.2;
    cam.znear = dist * near_scale;
    cam.zfar = dist + 4 * r;
    return cam;
}

static void to_screen(const crisp_camera *cam, crisp_mat4 vp, const double p[3], double out[2],
                      double *w)
{
    double c[4], s[3];
    crisp_mat4_mulp(vp, p, c);
    crisp_camera_to_pixel(cam, c, s);
    out[0] = s[0];
    out[1] = s[1];
    *w = c[3];
}

/* Largest screen distance between drawn triangles and the surface at the interpolated (u, v). */
static double mesh_error(const crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cam)
{
    const crisp_raster_vertex *v;
    const crisp_raster_tri *t;
    size_t nv, nt;
    crisp__renderer_mesh(r, &v, &nv, &t, &nt);
    assert_true(nt > 0);
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    static const double bary[7][3] = {{1. / 3, 1. / 3, 1. / 3},
                                      {.5, .5, 0},
                                      {0, .5, .5},
                                      {.5, 0, .5},
                                      {.7, .2, .1},
                                      {.1, .7, .2},
                                      {.2, .1, .7}};
    double worst = 0;
    for (size_t k = 0; k < nt; k++) {
        const crisp_raster_vertex *a = &v[t[k].v[0]], *b = &v[t[k].v[1]], *c = &v[t[k].v[2]];
        if (a->clip[3] <= cam->znear || b->clip[3] <= cam->znear || c->clip[3] <= cam->znear)
            continue;
        const crisp_surface *surf = sc->faces[t[k].face].src->surface;
        for (int q = 0; q < 7; q++) {
            double cl[4], uv[2], P[3];
            for (int i = 0; i < 4; i++)
                cl[i] = bary[q][0] * a->clip[i] + bary[q][1] * b->clip[i] + bary[q][2] * c->clip[i];
            for (int i = 0; i < 2; i++)
                uv[i] = bary[q][0] * a->attr[i] + bary[q][1] * b->attr[i] + bary[q][2] * c->attr[i];
            double tri[3], sp[2], w;
            crisp_camera_to_pixel(cam, cl, tri);
            /* Only what can be seen matters for a pixel bound. */
            if (tri[0] < -2 || tri[1] < -2 || tri[0] > cam->width + 2 || tri[1] > cam->height + 2)
                continue;
            crisp_surface_eval(surf, uv[0], uv[1], P);
            to_screen(cam, m.view_proj, P, sp, &w);
            double e = fmax(fabs(sp[0] - tri[0]), fabs(sp[1] - tri[1]));
            if (e > worst) worst = e;
        }
    }
    return worst;
}

static void test_surface_accuracy(void **state)
{
    (void)state;
    if (rb_kind != RENDER_CPU) skip(); /* measures the CPU backend's triangles */
    const char *models[] = {"gpucast_teapot.igs", "occt_bearing.iges", "occt_hammer.iges"};
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
    for (int mi = 0; mi < 3; mi++) {
        crisp_model *m;
        crisp_scene *sc = rt_load_scene(models[mi], &m);
        double worst = 0;
        for (int view = 0; view < 8; view++) {
            crisp_camera cam = random_camera(sc->box, 320, 240, 0.05);
            crisp_image img;
            crisp_image_init(&img, cam.width, cam.height);
            crisp_render_stats st;
            assert_int_equal(crisp_render_cpu(r, sc, &cam, &img, &st), CRISP_OK);
            double e = mesh_error(r, sc, &cam);
            if (e > worst) worst = e;
            crisp_image_free(&img);
        }
        printf("%s: largest triangle-to-surface distance %.4f px over 8 views\n", models[mi],
               worst);
        assert_true(worst <= 0.5);
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
    }
    crisp_renderer_destroy(r);
}

/* Pixels whose 5x5 neighbourhood in the exact image all shows the same face (or background):
 * at least 2 px from a face boundary, trim or silhouette. */
static int interior(const crisp_image *ex, int i, int j)
{
    int f = ex->face[j * ex->width + i];
    for (int dj = -2; dj <= 2; dj++)
        for (int di = -2; di <= 2; di++) {
            int x = i + di, y = j + dj;
            if (x < 0 || y < 0 || x >= ex->width || y >= ex->height) return 0;
            if (ex->face[y * ex->width + x] != f) return 0;
        }
    return 1;
}

static int exact_classify(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)ctx;
    const crisp_scene_face *f = &sc->faces[face];
    if (!f->piece_count) return 1;
    return crisp_trim_exact_classify(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
}

static void compare_with_exact(const char *name, int views, int w, int h)
{
    crisp_model *m;
    crisp_scene *sc = rt_load_scene(name, &m);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
    long compared = 0, differ = 0;
    for (int view = 0; view < views; view++) {
        crisp_camera cam = random_camera(sc->box, w, h, 0.05);
        crisp_image cpu, ex;
        crisp_image_init(&cpu, w, h);
        crisp_image_init(&ex, w, h);
        assert_int_equal(render_backend(rb_kind, r, 1, sc, &cam, &cpu, NULL), CRISP_OK);
        crisp_exact_desc d = {.threads = 2, .classify = exact_classify};
        assert_int_equal(crisp_render_exact(sc, &cam, &d, &ex), CRISP_OK);
        for (int j = 0; j < h; j++)
            for (int i = 0; i < w; i++) {
                if (!interior(&ex, i, j)) continue;
                compared++;
                int px = j * w + i;
                if (cpu.face[px] != ex.face[px]) {
                    differ++;
                    fprintf(stderr, "%s view %d pixel (%d, %d): cpu face %d, exact face %d\n", name,
                            view, i, j, cpu.face[px], ex.face[px]);
                }
            }
        crisp_image_free(&cpu);
        crisp_image_free(&ex);
    }
    printf("%s: %ld interior pixels compared over %d views, %ld differ\n", name, compared, views,
           differ);
    assert_true(compared > (long)views * w * h / 4);
    assert_int_equal(differ, 0);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

static void test_against_exact(void **state)
{
    (void)state;
    compare_with_exact("occt_bearing.iges", 3, 200, 150);
    compare_with_exact("gpucast_part.igs", 2, 200, 150);
}

/* Closed surfaces: every pixel inside the exact silhouette (its 3x3 neighbourhood all covered) is
 * covered by the CPU backend. */
static void check_closed(crisp_model *m, int views, double near_scale)
{
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
    long inside = 0;
    for (int view = 0; view < views; view++) {
        crisp_camera cam = random_camera(sc->box, 160, 120, near_scale);
        crisp_image cpu, ex;
        crisp_image_init(&cpu, cam.width, cam.height);
        crisp_image_init(&ex, cam.width, cam.height);
        assert_int_equal(render_backend(rb_kind, r, 1, sc, &cam, &cpu, NULL), CRISP_OK);
        crisp_exact_desc ed = {.threads = 2, .classify = exact_classify};
        assert_int_equal(crisp_render_exact(sc, &cam, &ed, &ex), CRISP_OK);
        for (int j = 1; j < cam.height - 1; j++)
            for (int i = 1; i < cam.width - 1; i++) {
                int all = 1;
                for (int dj = -1; dj <= 1; dj++)
                    for (int di = -1; di <= 1; di++)
                        all &= ex.face[(j + dj) * cam.width + i + di] >= 0;
                if (!all) continue;
                inside++;
                if (cpu.face[j * cam.width + i] < 0)
                    fprintf(stderr, "crack at view %d pixel (%d, %d)\n", view, i, j);
                assert_true(cpu.face[j * cam.width + i] >= 0);
            }
        crisp_image_free(&cpu);
        crisp_image_free(&ex);
    }
    printf(
        "closed model: %ld pixels inside the silhouette over %d views, no background among them\n",
        inside, views);
    assert_true(inside > views * 200);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
}

static crisp_model *single_surface_model(crisp_surface *s)
{
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    crisp_face f = {.surface = s};
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
    return m;
}

static void test_no_cracks(void **state)
{
    (void)state;
    crisp_placement pl;
    double o[3] = {0.3, -0.2, 0.1}, axis[3] = {0.2, 1, 0.3};
    assert_int_equal(crisp_placement_make(o, axis, NULL, &pl), CRISP_OK);
    crisp_surface *sphere, *torus;
    assert_int_equal(crisp_make_sphere(&pl, 1.3, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sphere),
                     CRISP_OK);
    assert_int_equal(crisp_make_torus(&pl, 2, 0.6, 0, 2 * M_PI, 0, 2 * M_PI, &torus), CRISP_OK);
    crisp_model *ms = single_surface_model(sphere), *mt = single_surface_model(torus);
    check_closed(ms, 12, 0.05);
    check_closed(mt, 12, 0.05);
    crisp_model_destroy(ms);
    crisp_model_destroy(mt);
    /* A closed solid of trimmed faces meeting along shared edges (STEP): the trim ribbons close
     * the sub-pixel gaps that both faces' 1 px bands can leave. */
    crisp_model *rods = rt_load_model("occt_linkrods.step");
    check_closed(rods, 10, 0.05);
    crisp_model_destroy(rods);
}

/* Cameras inside a closed sphere and right at a torus's surface (patches cross the near plane
 * and the eye plane, so the planner must split them): no background inside the exact
 * silhouette, and the same face and nearly the same depth everywhere away from edges. */
static void check_close(crisp_model *m, const crisp_camera *cam)
{
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
    crisp_image cpu, ex;
    crisp_image_init(&cpu, cam->width, cam->height);
    crisp_image_init(&ex, cam->width, cam->height);
    crisp_render_stats st;
    assert_int_equal(render_backend(rb_kind, r, 1, sc, cam, &cpu, &st), CRISP_OK);
    assert_int_equal(crisp_render_exact(sc, cam, &(crisp_exact_desc){.threads = 2}, &ex), CRISP_OK);
    long covered = 0, missing = 0;
    for (int j = 1; j < cam->height - 1; j++)
        for (int i = 1; i < cam->width - 1; i++) {
            int all = 1;
            for (int dj = -1; dj <= 1; dj++)
                for (int di = -1; di <= 1; di++)
                    all &= ex.face[(j + dj) * cam->width + i + di] >= 0;
            if (!all) continue;
            covered++;
            if (cpu.face[j * cam->width + i] < 0) {
                if (missing < 5) fprintf(stderr, "  missing pixel (%d, %d)\n", i, j);
                missing++;
            }
            assert_false(isnan(cpu.rgba[4 * (j * cam->width + i)]));
        }
    printf(
        "close camera: %ld pixels inside the silhouette, %ld missing, %u patches split, %u leaves, "
        "%u unresolved, %llu triangles\n",
        covered, missing, st.split_patches, st.leaves, st.unresolved,
        (unsigned long long)st.triangles);
    assert_int_equal(missing, 0);
    if (rb_kind == RENDER_CPU) { /* the CPU backend's triangles */
        double err = mesh_error(r, sc, cam);
        printf("close camera: largest triangle-to-surface distance %.4f px\n", err);
        assert_true(err <= 0.5);
    }
    assert_true(covered > cam->width * cam->height / 4);
    crisp_image_free(&cpu);
    crisp_image_free(&ex);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
}

static void test_close_cameras(void **state)
{
    (void)state;
    crisp_placement pl;
    double o[3] = {0, 0, 0}, axis[3] = {0, 0, 1};
    assert_int_equal(crisp_placement_make(o, axis, NULL, &pl), CRISP_OK);
    crisp_surface *sphere, *torus;
    assert_int_equal(crisp_make_sphere(&pl, 1.0, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sphere),
                     CRISP_OK);
    assert_int_equal(crisp_make_torus(&pl, 2, 0.5, 0, 2 * M_PI, 0, 2 * M_PI, &torus), CRISP_OK);
    crisp_model *ms = single_surface_model(sphere), *mt = single_surface_model(torus);
    /* Inside the sphere, near its wall, looking across it. */
    crisp_camera in = {.eye = {0.2, -0.9, 0.1},
                       .target = {0, 1, 0},
                       .up = {0, 0, 1},
                       .fov_deg = 90,
                       .znear = 0.001,
                       .zfar = 10,
                       .width = 160,
                       .height = 120};
    check_close(ms, &in);
    /* 0.01 above the torus's outer equator, looking along the surface (grazing). */
    crisp_camera graze = {.eye = {2.51, 0, 0.01},
                          .target = {2.5, 1, 0},
                          .up = {0, 0, 1},
                          .fov_deg = 60,
                          .znear = 0.0005,
                          .zfar = 20,
                          .width = 160,
                          .height = 120};
    check_close(mt, &graze);
    crisp_model_destroy(ms);
    crisp_model_destroy(mt);
}

/* Degenerate input: a surface collapsed to a point, one collapsed to a line, a face whose trim
 * loop has no area, loops that touch, and a camera looking at all of it from inside: no crash and
 * no NaN anywhere in the image. */
static void test_degenerate(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    double k[4] = {0, 0, 1, 1};
    double point[12] = {1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1};
    double line[12] = {0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0};
    double quad[12] = {-2, -2, -1, 2, -2, -1, -2, 2, -1, 2, 2, -1};
    crisp_surface *s0, *s1, *s2;
    assert_int_equal(crisp_surface_create(1, 1, 2, 2, k, k, point, NULL, &s0), CRISP_OK);
    assert_int_equal(crisp_surface_create(1, 1, 2, 2, k, k, line, NULL, &s1), CRISP_OK);
    assert_int_equal(crisp_surface_create(1, 1, 2, 2, k, k, quad, NULL, &s2), CRISP_OK);
    crisp_face f0 = {.surface = s0}, f1 = {.surface = s1};
    assert_int_equal(crisp_model_add_face(m, &f0), CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &f1), CRISP_OK);
    /* Face 2: an outer loop of no area (a segment there and back) and two triangles touching at a
     * vertex. */
    crisp_face f2 = {.surface = s2, .loop_count = 3};
    f2.loops = calloc(3, sizeof *f2.loops);
    double segs[3][4][2] = {{{0.1, 0.5}, {0.9, 0.5}, {0.1, 0.5}, {0.1, 0.5}},
                            {{0.2, 0.2}, {0.5, 0.2}, {0.5, 0.5}, {0.2, 0.2}},
                            {{0.5, 0.5}, {0.8, 0.8}, {0.5, 0.8}, {0.5, 0.5}}};
    for (int l = 0; l < 3; l++) {
        f2.loops[l].is_outer = 1;
        f2.loops[l].curve_count = 3;
        f2.loops[l].curves = calloc(3, sizeof(crisp_curve *));
        for (int c = 0; c < 3; c++) {
            double pts[4] = {segs[l][c][0], segs[l][c][1], segs[l][c + 1][0], segs[l][c + 1][1]};
            assert_int_equal(crisp_curve_create(2, 1, 2, k, pts, NULL, &f2.loops[l].curves[c]),
                             CRISP_OK);
        }
    }
    assert_int_equal(crisp_model_add_face(m, &f2), CRISP_OK);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_camera cams[2] = {
        {.eye = {0.3, 0.2, 3},
         .target = {0, 0, -1},
         .up = {0, 1, 0},
         .fov_deg = 60,
         .znear = 0.01,
         .zfar = 10,
         .width = 64,
         .height = 48},
        {.eye = {1, 1, 1},
         .target = {0, 0, -1},
         .up = {0, 1, 0},
         .fov_deg = 120,
         .znear = 1e-6,
         .zfar = 10,
         .width = 64,
         .height = 48},
    };
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.samples = 4}, &r), CRISP_OK);
    for (int c = 0; c < 2; c++) {
        crisp_image a, b;
        crisp_image_init(&a, 64, 48);
        crisp_image_init(&b, 64, 48);
        assert_int_equal(render_backend(rb_kind, r, 4, sc, &cams[c], &a, NULL), CRISP_OK);
        crisp_exact_desc d = {.classify = exact_classify};
        assert_int_equal(crisp_render_exact(sc, &cams[c], &d, &b), CRISP_OK);
        for (int i = 0; i < 64 * 48 * 4; i++) {
            assert_false(isnan(a.rgba[i]));
            assert_false(isnan(b.rgba[i]));
        }
        for (int i = 0; i < 64 * 48; i++)
            assert_false(isnan(a.depth[i]) || isnan(b.depth[i]));
        crisp_image_free(&a);
        crisp_image_free(&b);
    }
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* The clip plane (crisp_render_desc.clip_plane, crisp_gl_desc.clip_plane with --backend gl; a
 * section view): a closed sphere cut by a plane
 * through it. Every drawn pixel's point (its ray at its depth) lies on the kept side; pixels
 * whose unclipped point was kept are unchanged (same face, same depth); and the cut opens the
 * solid: its inside (back faces, normal along the view) shows where the front was cut away. */
/* Renders occt_bearing.iges with the three renderers at its default view, closer (the model
 * fills the image) and a window of win_h rows of the close frame, and checks the three images
 * and AOVs are equal bit for bit. With garbage, the images start as 0x55 bytes, so a pixel
 * left out keeps it. */
static void assert_three_equal(crisp_renderer *r[3], crisp_scene *sc, int win_h, bool garbage)
{
    crisp_camera cam;
    assert_int_equal(crisp_camera_frame_box(sc->box, 333, 190, &cam), CRISP_OK);
    for (int view = 0; view < 3; view++) {
        if (view == 1) cam.fov_deg = 8;   /* closer: the model fills the image */
        int win[4] = {8, 16, 200, win_h}; /* view 2: a window of the close frame */
        int w = view == 2 ? win[2] : cam.width, h = view == 2 ? win[3] : cam.height;
        size_t n = (size_t)w * h, covered = 0;
        crisp_image img[3];
        for (int k = 0; k < 3; k++) {
            assert_int_equal(crisp_image_init(&img[k], w, h), CRISP_OK);
            if (garbage) {
                memset(img[k].rgba, 0x55, 4 * n * sizeof(float));
                memset(img[k].depth, 0x55, n * sizeof(float));
                memset(img[k].face, 0x55, n * sizeof(int32_t));
            }
            const crisp_frame_plan *plan;
            assert_int_equal(crisp_planner_plan(crisp_renderer_planner(r[k]), sc, &cam, &plan),
                             CRISP_OK);
            if (view == 2)
                assert_int_equal(crisp__render_cpu_window(r[k], sc, plan, &cam, win, &img[k], NULL),
                                 CRISP_OK);
            else
                assert_int_equal(crisp_render_cpu_plan(r[k], sc, plan, &cam, &img[k], NULL),
                                 CRISP_OK);
        }
        for (size_t p = 0; p < n; p++)
            covered += img[0].face[p] >= 0;
        assert_true(covered > n / 20 && covered < n); /* some of each kind of pixel */
        for (int k = 1; k < 3; k++) {
            assert_memory_equal(img[0].rgba, img[k].rgba, 4 * n * sizeof(float));
            assert_memory_equal(img[0].depth, img[k].depth, n * sizeof(float));
            assert_memory_equal(img[0].normal, img[k].normal, 3 * n * sizeof(float));
            assert_memory_equal(img[0].uv, img[k].uv, 2 * n * sizeof(float));
            assert_memory_equal(img[0].face, img[k].face, n * sizeof(int32_t));
        }
        for (int k = 0; k < 3; k++)
            crisp_image_free(&img[k]);
    }
}

/* The image does not depend on the thread count: the tiles and the resolve's rows are shared out
 * in one home range per worker (crisp_raster_share); with 1, 3 and 8 threads (more workers than
 * some ranges have rows of a small window) every pixel is resolved, and the same. The images start
 * as garbage: a row left out keeps it. */
static void test_threads_equal(void **state)
{
    (void)state;
    if (rb_kind != RENDER_CPU) skip();
    crisp_model *m;
    crisp_scene *sc = rt_load_scene("occt_bearing.iges", &m);
    static const int threads[3] = {1, 3, 8};
    crisp_renderer *r[3];
    for (int k = 0; k < 3; k++)
        assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = threads[k]}, &r[k]),
                         CRISP_OK);
    assert_three_equal(r, sc, 20, true); /* 20 rows: fewer than some workers' ranges */
    for (int k = 0; k < 3; k++)
        crisp_renderer_destroy(r[k]);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* The SIMD paths (rasterizer and resolve) give the scalar code's image and AOVs bit for bit: a
 * trimmed model at its default view and closer (partly covered blocks, background pixels, an odd
 * width for the resolve's last pixel), whole frames and a window. */
static void test_vectors_equal_scalar(void **state)
{
    (void)state;
    if (rb_kind != RENDER_CPU) skip();
    crisp_model *m;
    crisp_scene *sc = rt_load_scene("occt_bearing.iges", &m);
    /* A colour of its own per face: the resolve's lanes of different faces must not mix. */
    for (uint32_t f = 0; f < sc->face_count; f++) {
        sc->faces[f].color[0] = (float)(f % 7) / 7.0f;
        sc->faces[f].color[1] = (float)(f % 5) / 5.0f;
        sc->faces[f].color[2] = (float)(f % 3) / 3.0f;
    }
    crisp_renderer *r[3]; /* scalar, every vector path, not the AVX2 tiles */
    for (int k = 0; k < 3; k++) {
        assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r[k]),
                         CRISP_OK);
        crisp__renderer_set_vectors(r[k], k);
    }
    assert_three_equal(r, sc, 120, false);
    for (int k = 0; k < 3; k++)
        crisp_renderer_destroy(r[k]);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

static void test_clip_plane(void **state)
{
    (void)state;
    crisp_placement pl;
    double o[3] = {0.3, -0.2, 0.1}, axis[3] = {0.2, 1, 0.3};
    assert_int_equal(crisp_placement_make(o, axis, NULL, &pl), CRISP_OK);
    crisp_surface *sphere;
    assert_int_equal(crisp_make_sphere(&pl, 1.3, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sphere),
                     CRISP_OK);
    crisp_model *m = single_surface_model(sphere);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    double n[3] = {-0.36, -0.48, -0.8}; /* unit; the eye is on the cut side */
    double plane[4] = {n[0], n[1], n[2], -(n[0] * o[0] + n[1] * o[1] + n[2] * o[2]) + 0.3};
    crisp_renderer *r0, *r1;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r0), CRISP_OK);
    crisp_render_desc d1 = {.threads = 2};
    memcpy(d1.clip_plane, plane, sizeof plane);
    assert_int_equal(crisp_renderer_create(&d1, &r1), CRISP_OK);
    crisp_camera cam = {.eye = {4, -3, 5},
                        .up = {0, 0, 1},
                        .fov_deg = 30,
                        .znear = 1,
                        .zfar = 20,
                        .width = 160,
                        .height = 120};
    memcpy(cam.target, o, sizeof o);
    crisp_image a, b;
    crisp_image_init(&a, cam.width, cam.height);
    crisp_image_init(&b, cam.width, cam.height);
    assert_int_equal(render_backend(rb_kind, r0, 1, sc, &cam, &a, NULL), CRISP_OK);
#ifdef CRISP_HAVE_GL
    crisp_gl *gl = NULL;
    if (rb_kind == RENDER_GL) { /* the GL backend's clip distance in its shaders */
        assert_int_equal(rb_gl_for(1, &gl), CRISP_OK);
        crisp_gl_set_clip_plane(gl, plane);
    }
#endif
    assert_int_equal(render_backend(rb_kind, r1, 1, sc, &cam, &b, NULL), CRISP_OK);
#ifdef CRISP_HAVE_GL
    if (gl) crisp_gl_set_clip_plane(gl, NULL);
#endif
    long kept = 0, inside = 0, removed = 0;
    for (int j = 0; j < cam.height; j++)
        for (int i = 0; i < cam.width; i++) {
            size_t k = (size_t)j * cam.width + i;
            double org[3], dir[3], f[3];
            crisp_camera_ray(&cam, i + 0.5, j + 0.5, org, dir);
            crisp_vec3_sub(cam.target, cam.eye, f);
            crisp_vec3_normalize(f, f);
            double t = 1.0 / crisp_vec3_dot(dir, f); /* ray length per unit depth */
            if (b.face[k] >= 0) {
                double P[3], dist;
                for (int q = 0; q < 3; q++)
                    P[q] = org[q] + dir[q] * b.depth[k] * t;
                dist = crisp_vec3_dot(n, P) + plane[3];
                if (dist < -1e-4) fail_msg("pixel (%d, %d) drawn %g on the cut side", i, j, dist);
                float nd = b.normal[3 * k] * (float)dir[0] + b.normal[3 * k + 1] * (float)dir[1] +
                           b.normal[3 * k + 2] * (float)dir[2];
                inside += nd > 0.2f;
            }
            if (a.face[k] >= 0) {
                double P[3];
                for (int q = 0; q < 3; q++)
                    P[q] = org[q] + dir[q] * a.depth[k] * t;
                double dist = crisp_vec3_dot(n, P) + plane[3];
                if (dist > 1e-3) {
                    kept++;
                    assert_int_equal(b.face[k], a.face[k]);
                    assert_float_equal(b.depth[k], a.depth[k], 1e-6 * a.depth[k]); /* GL clips */
                } else if (dist < -1e-3) {
                    removed++;
                }
            }
        }
    printf("clip plane: %ld pixels kept unchanged, %ld cut away, %ld show the inside\n", kept,
           removed, inside);
    assert_true(kept > 500 && removed > 500 && inside > 500);
    crisp_image_free(&a);
    crisp_image_free(&b);
    crisp_renderer_destroy(r0);
    crisp_renderer_destroy(r1);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* The apex normals kept across frames (cpu.c's pole normals, keyed by the scene, the patch and
 * (s, t)): one renderer draws two cones by turns, the second the first turned a quarter about z
 * with its camera (the same patches, parameters and leaves, other normals; each generator has its
 * own normal at the apex, which the camera looks at), and every frame's image, normals included,
 * is bit for bit a new renderer's first frame of that scene. Fails with the scene or the patch
 * left out of the key. */
static void test_pole_normals(void **state)
{
    (void)state;
    enum { PW = 96, PH = 72 };
    crisp_scene *sc[2];
    crisp_model *m[2];
    crisp_camera cam[2];
    const double o[3] = {0.1, -0.2, 0.3}, axis[3] = {0.2, 1, 0.3}, xdir[3] = {1, -0.2, 0},
                 eye[3] = {1.2, -0.9, 1.1}; /* eye: from the apex */
    for (int k = 0; k < 2; k++) {
        /* k = 1: (x, y, z) -> (-y, x, z), exact in floating point */
#define TURN(v)                                                                                    \
    {                                                                                              \
        k ? -(v)[1] : (v)[0], k ? (v)[0] : (v)[1], (v)[2]                                          \
    }
        double ok[3] = TURN(o), ak[3] = TURN(axis), rk[3] = TURN(xdir), ek[3] = TURN(eye);
        double up[3] = {k ? -1 : 0, k ? 0 : 1, 0};
#undef TURN
        crisp_placement pl;
        assert_int_equal(crisp_placement_make(ok, ak, rk, &pl), CRISP_OK);
        crisp_surface *cone;
        assert_int_equal(crisp_make_cone(&pl, 1, M_PI / 4, 0, 2 * M_PI, -1, 0.5, &cone), CRISP_OK);
        m[k] = single_surface_model(cone);
        assert_int_equal(crisp_scene_prepare(m[k], &sc[k]), CRISP_OK);
        double n = sqrt(ak[0] * ak[0] + ak[1] * ak[1] + ak[2] * ak[2]);
        double apex[3] = {ok[0] - ak[0] / n, ok[1] - ak[1] / n, ok[2] - ak[2] / n};
        cam[k] = (crisp_camera){.eye = {apex[0] + ek[0], apex[1] + ek[1], apex[2] + ek[2]},
                                .target = {apex[0], apex[1], apex[2]},
                                .up = {up[0], up[1], up[2]},
                                .fov_deg = 40,
                                .znear = 0.01,
                                .zfar = 20,
                                .width = PW,
                                .height = PH};
    }
    crisp_image ref[2], img;
    for (int k = 0; k < 2; k++) {
        crisp_renderer *r0;
        assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.samples = 1}, &r0), CRISP_OK);
        crisp_image_init(&ref[k], PW, PH);
        assert_int_equal(crisp_render_cpu(r0, sc[k], &cam[k], &ref[k], NULL), CRISP_OK);
        crisp_renderer_destroy(r0);
    }
    crisp_image_init(&img, PW, PH);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.samples = 1}, &r), CRISP_OK);
    int covered = 0;
    for (int f = 0; f < 6; f++) {
        int k = (f / 2) % 2; /* A, A, B, B, A, A */
        assert_int_equal(crisp_render_cpu(r, sc[k], &cam[k], &img, NULL), CRISP_OK);
        for (int i = 0; i < PW * PH; i++) {
            covered += img.face[i] >= 0;
            assert_int_equal(img.face[i], ref[k].face[i]);
            assert_true(memcmp(&img.normal[3 * i], &ref[k].normal[3 * i], 3 * sizeof(float)) == 0);
            assert_true(memcmp(&img.rgba[4 * i], &ref[k].rgba[4 * i], 4 * sizeof(float)) == 0);
        }
    }
    printf("pole normals: %d of %d pixels covered\n", covered, 6 * PW * PH);
    assert_true(covered > 6 * PW * PH / 10);
    crisp_renderer_destroy(r);
    crisp_image_free(&img);
    for (int k = 0; k < 2; k++) {
        crisp_image_free(&ref[k]);
        crisp_scene_destroy(sc[k]);
        crisp_model_destroy(m[k]);
    }
}

static void assert_images_equal(const crisp_image *a, const crisp_image *b)
{
    size_t n = (size_t)a->width * (size_t)a->height;
    assert_true(memcmp(a->rgba, b->rgba, 4 * n * sizeof(float)) == 0);
    assert_true(memcmp(a->depth, b->depth, n * sizeof(float)) == 0);
    assert_true(memcmp(a->normal, b->normal, 3 * n * sizeof(float)) == 0);
    assert_true(memcmp(a->uv, b->uv, 2 * n * sizeof(float)) == 0);
    assert_true(memcmp(a->face, b->face, n * sizeof(int32_t)) == 0);
}

/* The leaves' world-space vertices kept across frames (cpu.c, kept_leaf) and the ribbon samples'
 * (ribbon.c, ribbon_point_kept): one renderer draws the linkrods from cameras that move a little
 * (most leaves keep their cells, many change levels) and back, then the bearing (another scene),
 * then the linkrods again; every image, all its
 * channels, is bit for bit a new renderer's first frame of that scene and camera (a first frame
 * reads no kept vertex). Fails (each tried) with the levels or the cell left out of the leaves'
 * key, and with the face left out of the ribbon points' key; the tables not emptied for a new
 * scene (leaves) or the scene left out of the key (ribbon points) fail test_pole_normals (the
 * same leaf records and (u, v) there), the latter this test too. */
static void test_kept_vertices(void **state)
{
    (void)state;
    if (rb_kind != RENDER_CPU) skip(); /* the CPU backend's tessellation */
    enum { KW = 320, KH = 240, NC = 4 };
    crisp_model *m[2];
    crisp_scene *sc[2] = {rt_load_scene("occt_linkrods.step", &m[0]),
                          rt_load_scene("occt_bearing.iges", &m[1])};
    crisp_camera cam[2][NC];
    rng = 0x2545f4914f6cdd1dull; /* the same cameras whatever the tests before drew */
    for (int k = 0; k < 2; k++) {
        cam[k][0] = random_camera(sc[k]->box, KW, KH, 0.05);
        for (int c = 1; c < NC; c++) { /* the eye 6%, 12%, 18% nearer, and a little aside */
            cam[k][c] = cam[k][0];
            for (int a = 0; a < 3; a++)
                cam[k][c].eye[a] -=
                    (0.06 * c + (a == 1 ? 0.01 : 0.0)) * (cam[k][0].eye[a] - cam[k][0].target[a]);
        }
    }
    crisp_image ref[2][NC], img;
    for (int k = 0; k < 2; k++)
        for (int c = 0; c < NC; c++) {
            crisp_renderer *r0;
            assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.samples = 1}, &r0),
                             CRISP_OK);
            crisp_image_init(&ref[k][c], KW, KH);
            assert_int_equal(crisp_render_cpu(r0, sc[k], &cam[k][c], &ref[k][c], NULL), CRISP_OK);
            crisp_renderer_destroy(r0);
        }
    crisp_image_init(&img, KW, KH);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.samples = 1}, &r), CRISP_OK);
    static const int seq[][2] = {{0, 0}, {0, 0}, {0, 1}, {0, 2}, {0, 0}, {0, 3}, {0, 3},
                                 {1, 0}, {1, 1}, {1, 1}, {1, 3}, {0, 1}, {0, 0}};
    long covered = 0;
    for (size_t f = 0; f < sizeof seq / sizeof seq[0]; f++) {
        int k = seq[f][0], c = seq[f][1];
        assert_int_equal(crisp_render_cpu(r, sc[k], &cam[k][c], &img, NULL), CRISP_OK);
        for (int i = 0; i < KW * KH; i++)
            covered += img.face[i] >= 0;
        assert_images_equal(&img, &ref[k][c]);
    }
    printf("kept vertices: %ld covered pixels over %zu frames\n", covered,
           sizeof seq / sizeof seq[0]);
    assert_true(covered > (long)(sizeof seq / sizeof seq[0]) * KW * KH / 20);
    crisp_renderer_destroy(r);
    crisp_image_free(&img);
    for (int k = 0; k < 2; k++) {
        for (int c = 0; c < NC; c++)
            crisp_image_free(&ref[k][c]);
        crisp_scene_destroy(sc[k]);
        crisp_model_destroy(m[k]);
    }
}

int main(int argc, char **argv)
{
    rb_parse_args(argc, argv);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_surface_accuracy),     cmocka_unit_test(test_no_cracks),
        cmocka_unit_test(test_close_cameras),        cmocka_unit_test(test_degenerate),
        cmocka_unit_test(test_against_exact),        cmocka_unit_test(test_clip_plane),
        cmocka_unit_test(test_vectors_equal_scalar), cmocka_unit_test(test_threads_equal),
        cmocka_unit_test(test_pole_normals),         cmocka_unit_test(test_kept_vertices),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
