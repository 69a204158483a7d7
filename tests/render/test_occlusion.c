/* Occlusion culling in the CPU backend (issue 12, src/render/occlusion.c): leaves hidden behind
 * depth already drawn are not tessellated, and that must not change a sample. A scene of layers:
 * a wavy front plate with three round holes (trimmed away: nothing is written there, so what is
 * behind shows through), a small sheet in front of it, three wavy sheets behind (one rational),
 * a sphere at the back, a tilted sheet that passes through all the layers and a sphere through
 * the plate. Cameras: frontal
 * views (the plate hides most of the layers: culling is expected), random cameras all around and
 * between the layers, and cameras just above a sheet looking along it (the sheet crosses the near
 * plane). Each frame is drawn with culling on and off (crisp_render_desc.no_occlusion) on the same
 * plan, with 1 and 4 samples per pixel (16 in two frontal views), as a whole frame, as a window of
 * it (crisp__render_cpu_window, the image tiles' path) and with only some faces
 * (crisp_render_cpu_plan_faces): every sample of the target (face, 1/W, attributes) and every pixel
 * of the image must be the same bit for bit; the leaves culled are counted and must be many in the
 * frontal views. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/construct.h"
#include "crisp/model.h"
#include "crisp/plan.h"
#include "crisp/render.h"
#include "render/occlusion.h"
#include "render/planner.h"
#include "render/raster.h"
#include "render/render_internal.h"
#include "render/render_test_util.h"

#define W 128
#define H 96
/* Finer than the default 0.5 px: more triangles per frame, so that the frames are drawn in
 * several batches (each holds at least 8,192 triangles). */
#define EPS 0.15

static uint64_t rng = 0x2545f4914f6cdd1dull;
static double rnd(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* A bicubic sheet of n x n spans over [x0, x1] x [y0, y1] at height z with waves of amplitude a
 * ((u, v) in [0, 1]^2); rational: weights in [0.75, 1.25] varying over the net. */
static crisp_surface *sheet(int n, double x0, double x1, double y0, double y1, double z, double a,
                            int rational)
{
    int m = n + 3;
    double k[64];
    for (int i = 0; i < m + 4; i++)
        k[i] = i < 4 ? 0 : i >= m ? 1 : (double)(i - 3) / n;
    double pts[3 * 40 * 40], w[40 * 40];
    for (int j = 0; j < m; j++)
        for (int i = 0; i < m; i++) {
            double *p = pts + 3 * (j * m + i);
            p[0] = x0 + (x1 - x0) * i / (m - 1);
            p[1] = y0 + (y1 - y0) * j / (m - 1);
            p[2] = z + a * sin(1.7 * p[0] + 0.3) * cos(1.3 * p[1] - 0.2);
            w[j * m + i] = 1 + 0.25 * sin(0.9 * i + 0.6 * j);
        }
    crisp_surface *s;
    assert_int_equal(crisp_surface_create(3, 3, m, m, k, k, pts, rational ? w : NULL, &s),
                     CRISP_OK);
    return s;
}

static crisp_curve *line2(double x0, double y0, double x1, double y1)
{
    crisp_curve *c;
    double p0[2] = {x0, y0}, p1[2] = {x1, y1};
    assert_int_equal(crisp_make_line(2, p0, p1, 0, 1, &c), CRISP_OK);
    return c;
}

/* The front plate: an outer rectangle inside the domain and three round holes. */
static void add_plate(crisp_model *m)
{
    crisp_face f = {.surface = sheet(12, -2, 2, -1.6, 1.6, 0, 0.08, 0), .loop_count = 4};
    f.loops = calloc(4, sizeof *f.loops);
    assert_non_null(f.loops);
    f.loops[0].is_outer = 1;
    f.loops[0].curve_count = 4;
    f.loops[0].curves = calloc(4, sizeof(crisp_curve *));
    assert_non_null(f.loops[0].curves);
    f.loops[0].curves[0] = line2(0.02, 0.02, 0.98, 0.02);
    f.loops[0].curves[1] = line2(0.98, 0.02, 0.98, 0.98);
    f.loops[0].curves[2] = line2(0.98, 0.98, 0.02, 0.98);
    f.loops[0].curves[3] = line2(0.02, 0.98, 0.02, 0.02);
    const double holes[3][3] = {{0.3, 0.32, 0.13}, {0.68, 0.4, 0.09}, {0.52, 0.74, 0.16}};
    for (int h = 0; h < 3; h++) {
        crisp_trim_loop *l = &f.loops[1 + h];
        l->is_outer = 0;
        l->curve_count = 1;
        l->curves = calloc(1, sizeof(crisp_curve *));
        assert_non_null(l->curves);
        double c[2] = {holes[h][0], holes[h][1]}, x[2] = {1, 0}, y[2] = {0, -1};
        assert_int_equal(
            crisp_make_arc(2, c, x, y, holes[h][2], holes[h][2], 0, 2 * M_PI, &l->curves[0]),
            CRISP_OK);
    }
    assert_int_equal(crisp_face_normalize_loops(&f, 1e-9), CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
}

static crisp_model *layers(void)
{
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    add_plate(m);
    crisp_face f[5] = {{.surface = sheet(4, -0.8, 0.2, -0.5, 0.4, 0.7, 0.05, 0)},
                       {.surface = sheet(16, -3, 3, -2.4, 2.4, -0.6, 0.15, 0)},
                       {.surface = sheet(16, -3.2, 2.8, -2.2, 2.6, -1.3, 0.2, 1)},
                       {.surface = sheet(10, -3, 3, -2.5, 2.5, -2.2, 0.3, 0)}};
    crisp_placement pl;
    double o[3] = {0.4, 0.2, -3.6}, z[3] = {0.2, 1, 0.3};
    assert_int_equal(crisp_placement_make(o, z, NULL, &pl), CRISP_OK);
    assert_int_equal(crisp_make_sphere(&pl, 1.1, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &f[4].surface),
                     CRISP_OK);
    for (int k = 0; k < 5; k++)
        assert_int_equal(crisp_model_add_face(m, &f[k]), CRISP_OK);
    /* A tilted sheet through every layer (from z = 1.2 down to -3): its leaves lie partly in
     * front of and partly behind the plate and the sheets, so only its nearest depth may decide. */
    crisp_surface *t = sheet(3, -2.5, 2.5, -0.6, 0.6, 0, 0.1, 0);
    crisp_face tf = {.surface = t};
    for (int k = 0; k < t->count_u * t->count_v; k++) {
        double *p = t->cpw + 4 * k;
        double x = p[0], y = p[1];
        p[0] = 0.8 * x + 0.3 * y, p[1] = 0.4 * x + y, p[2] += -0.9 - 0.84 * x;
    }
    assert_int_equal(crisp_model_add_face(m, &tf), CRISP_OK);
    /* A sphere through the plate near its second hole, half in front of it. */
    double o2[3] = {0.9, -0.2, 0.05};
    assert_int_equal(crisp_placement_make(o2, z, NULL, &pl), CRISP_OK);
    crisp_face sf = {0};
    assert_int_equal(crisp_make_sphere(&pl, 0.5, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sf.surface),
                     CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &sf), CRISP_OK);
    return m;
}

static crisp_camera camera(const double eye[3], const double target[3], double fov)
{
    crisp_camera c = {.eye = {eye[0], eye[1], eye[2]},
                      .target = {target[0], target[1], target[2]},
                      .up = {0.1 * rnd(), 1, 0.1 * rnd()},
                      .fov_deg = fov,
                      .znear = 0.05,
                      .zfar = 60,
                      .width = W,
                      .height = H};
    return c;
}

/* Every sample of the two targets and every pixel of the two images agree bit for bit (the
 * attributes of empty samples are not read by anything and may hold stale values). */
static void assert_same(const crisp_renderer *a, const crisp_renderer *b, const crisp_image *ia,
                        const crisp_image *ib, const char *what)
{
    const crisp_raster_target *ta = crisp__renderer_target(a), *tb = crisp__renderer_target(b);
    size_t n = (size_t)ta->width * ta->height * ta->samples, diff = 0;
    assert_int_equal(n, (size_t)tb->width * tb->height * tb->samples);
    for (size_t k = 0; k < n; k++) {
        int bad = ta->face[k] != tb->face[k] || memcmp(&ta->inv_w[k], &tb->inv_w[k], 8) ||
                  (ta->face[k] >= 0 &&
                   memcmp(ta->attr + k * CRISP_RASTER_ATTRS, tb->attr + k * CRISP_RASTER_ATTRS,
                          CRISP_RASTER_ATTRS * sizeof(float)));
        diff += bad;
    }
    size_t px = (size_t)ia->width * ia->height;
    int img_diff = memcmp(ia->rgba, ib->rgba, 16 * px) || memcmp(ia->depth, ib->depth, 4 * px) ||
                   memcmp(ia->normal, ib->normal, 12 * px) || memcmp(ia->uv, ib->uv, 8 * px) ||
                   memcmp(ia->face, ib->face, 4 * px);
    if (diff || img_diff)
        printf("  %s: %zu samples differ, image differs %d\n", what, diff, img_diff);
    assert_int_equal(diff, 0);
    assert_int_equal(img_diff, 0);
}

typedef struct totals {
    size_t frames, culled_frames, leaves, culled, tris, culled_tris;
} totals;

/* One camera: the whole frame, a window and a subset of faces, culling on and off. Returns the
 * leaves culled in the whole frame. */
static uint64_t check_camera(const crisp_scene *sc, const crisp_camera *cam, int samples,
                             totals *tot)
{
    crisp_renderer *on, *off;
    assert_int_equal(
        crisp_renderer_create(&(crisp_render_desc){.samples = samples, .threads = 2, .eps_px = EPS},
                              &on),
        CRISP_OK);
    assert_int_equal(crisp_renderer_create(
                         &(crisp_render_desc){
                             .samples = samples, .threads = 2, .eps_px = EPS, .no_occlusion = 1},
                         &off),
                     CRISP_OK);
    const crisp_frame_plan *plan;
    assert_int_equal(crisp_planner_plan(crisp_renderer_planner(on), sc, cam, &plan), CRISP_OK);
    crisp_image ia, ib;
    assert_int_equal(crisp_image_init(&ia, W, H), CRISP_OK);
    assert_int_equal(crisp_image_init(&ib, W, H), CRISP_OK);
    crisp_render_stats sa, sb;
    assert_int_equal(crisp_render_cpu_plan(on, sc, plan, cam, &ia, &sa), CRISP_OK);
    assert_int_equal(crisp_render_cpu_plan(off, sc, plan, cam, &ib, &sb), CRISP_OK);
    assert_same(on, off, &ia, &ib, "frame");
    assert_int_equal(sb.occluded_leaves, 0);
    assert_int_equal(sa.triangles + sa.occluded_triangles, sb.triangles);
    tot->frames++;
    tot->leaves += plan->leaf_count;
    tot->culled += sa.occluded_leaves;
    tot->culled_tris += sa.occluded_triangles;
    tot->tris += sb.triangles;
    tot->culled_frames += sa.occluded_leaves > 0;
    uint64_t culled = sa.occluded_leaves;
    /* A window of the frame (x0, y0 multiples of 8). */
    int win[4] = {24, 16, 72, 56};
    crisp_image wa, wb;
    assert_int_equal(crisp_image_init(&wa, win[2], win[3]), CRISP_OK);
    assert_int_equal(crisp_image_init(&wb, win[2], win[3]), CRISP_OK);
    assert_int_equal(crisp__render_cpu_window(on, sc, plan, cam, win, &wa, &sa), CRISP_OK);
    assert_int_equal(crisp__render_cpu_window(off, sc, plan, cam, win, &wb, &sb), CRISP_OK);
    assert_same(on, off, &wa, &wb, "window");
    /* Every face but the front plate. */
    uint8_t faces[8];
    for (uint32_t f = 0; f < plan->face_count; f++)
        faces[f] = f != 0;
    assert_int_equal(crisp_render_cpu_plan_faces(on, sc, plan, cam, faces, NULL, &ia, &sa),
                     CRISP_OK);
    assert_int_equal(crisp_render_cpu_plan_faces(off, sc, plan, cam, faces, NULL, &ib, &sb),
                     CRISP_OK);
    assert_same(on, off, &ia, &ib, "faces");
    crisp_image_free(&wa);
    crisp_image_free(&wb);
    crisp_image_free(&ia);
    crisp_image_free(&ib);
    crisp_renderer_destroy(on);
    crisp_renderer_destroy(off);
    return culled;
}

static void report(const char *what, int samples, const totals *t)
{
    printf("%s, %d sample(s): %zu frames, culling in %zu; leaves culled %zu of %zu, triangles "
           "%zu of %zu (%.0f%%)\n",
           what, samples, t->frames, t->culled_frames, t->culled, t->leaves, t->culled_tris,
           t->tris, t->tris ? 100.0 * t->culled_tris / t->tris : 0.0);
}

/* Frontal views: the plate and the small sheet in front hide most of the layers; the holes show
 * them in places. Culling must happen in every frame. */
static void test_frontal(void **state)
{
    (void)state;
    crisp_model *m = layers();
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    for (int samples = 1; samples <= 16; samples *= 4) {
        totals t = {0};
        for (int k = 0; k < (samples == 16 ? 2 : 6); k++) {
            double eye[3] = {0.6 * (rnd() - 0.5), 0.6 * (rnd() - 0.5), 3.5 + 2 * rnd()};
            double target[3] = {0.4 * (rnd() - 0.5), 0.4 * (rnd() - 0.5), -1};
            crisp_camera cam = camera(eye, target, 30 + 15 * rnd());
            assert_true(check_camera(sc, &cam, samples, &t) > 0);
        }
        report("frontal", samples, &t);
        assert_true(t.culled_tris > t.tris / 10);
    }
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* Random cameras around and inside the layers (eyes between sheets, close to them, wide and narrow
 * fields of view), and eyes just above a sheet looking along it: its leaves cross the near plane
 * and are never culled. */
static void test_random(void **state)
{
    (void)state;
    crisp_model *m = layers();
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    for (int samples = 1; samples <= 4; samples += 3) {
        totals t = {0};
        for (int k = 0; k < 16; k++) {
            double eye[3] = {6 * (rnd() - 0.5), 6 * (rnd() - 0.5), -4.5 + 10 * rnd()};
            double target[3] = {4 * (rnd() - 0.5), 4 * (rnd() - 0.5), -3 + 3.5 * rnd()};
            crisp_camera cam = camera(eye, target, 15 + 85 * rnd());
            check_camera(sc, &cam, samples, &t);
        }
        for (int k = 0; k < 4; k++) {
            /* Just above sheet 2 (z about -0.6), looking along it towards the sphere's side. */
            double eye[3] = {-2 + rnd(), -1 + 2 * rnd(), -0.6 + 0.03 * rnd()};
            double target[3] = {2, 2 * (rnd() - 0.5), -1.4 - rnd()};
            crisp_camera cam = camera(eye, target, 40 + 40 * rnd());
            check_camera(sc, &cam, samples, &t);
        }
        report("random", samples, &t);
    }
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* A sheet and a short cylinder band in front of it, around the view axis: seen along the axis
 * with a narrow field of view the band lies outside the screen, while each quarter's control
 * hull spans the screen (the hole); seen from the side or at an angle it is on screen. Large
 * leaves are then tested piece by piece (cpu.c, leaf_pieces_hidden): along the axis they must be
 * dropped (triangles culled with nothing drawn in front of the band's hole but the sheet), and
 * every frame must stay as without culling. */
static void test_pieces(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    crisp_face f[2] = {{.surface = sheet(6, -4, 4, -4, 4, -2, 0.1, 0)}};
    crisp_placement pl;
    double o[3] = {0, 0, -1}, z[3] = {0, 0, 1};
    assert_int_equal(crisp_placement_make(o, z, NULL, &pl), CRISP_OK);
    assert_int_equal(crisp_make_cylinder(&pl, 3, 0, 2 * M_PI, 0, 0.3, &f[1].surface), CRISP_OK);
    for (int k = 0; k < 2; k++)
        assert_int_equal(crisp_model_add_face(m, &f[k]), CRISP_OK);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    totals t = {0};
    for (int k = 0; k < 4; k++) { /* along the axis: the band off the screen */
        double eye[3] = {0.05 * (rnd() - 0.5), 0.05 * (rnd() - 0.5), 1.5 + rnd()};
        double target[3] = {0.1 * (rnd() - 0.5), 0.1 * (rnd() - 0.5), -2};
        crisp_camera cam = camera(eye, target, 20 + 10 * rnd());
        size_t before = t.culled_tris;
        check_camera(sc, &cam, 1, &t);
        assert_true(t.culled_tris > before);
    }
    report("pieces, along the axis", 1, &t);
    for (int k = 0; k < 8; k++) { /* the band on the screen, partly or whole */
        double eye[3] = {4 * (rnd() - 0.5), 4 * (rnd() - 0.5), 1 + 4 * rnd()};
        double target[3] = {2 * (rnd() - 0.5), 2 * (rnd() - 0.5), -1.5};
        crisp_camera cam = camera(eye, target, 30 + 60 * rnd());
        check_camera(sc, &cam, k % 2 ? 4 : 1, &t);
    }
    report("pieces", 1, &t);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* A wall (a wavy sheet without holes) with sheets, a sphere and a tilted sheet behind it, some
 * reaching out past its edges, a small sheet in front, and a sheet through the wall (its box's
 * nearest point behind the wall's, its waves showing through the wall's troughs). */
static crisp_model *wall(void)
{
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    crisp_face through = {.surface = sheet(2, -1.2, 1.1, -1.0, 0.8, -0.08, 0, 0)};
    for (int k = 0; k < through.surface->count_u * through.surface->count_v; k++) {
        double *p = through.surface->cpw + 4 * k;
        p[2] += 0.14 * cos(2.3 * p[0] + 1.1 * p[1]);
    }
    assert_int_equal(crisp_model_add_face(m, &through), CRISP_OK);
    crisp_face f[7] = {{.surface = sheet(10, -2.2, 2.2, -1.8, 1.8, 0, 0.1, 0)},
                       {.surface = sheet(4, -0.6, 0.3, -0.4, 0.5, 0.8, 0.05, 1)},
                       {.surface = sheet(6, -1.5, 1.0, -1.2, 0.9, -0.7, 0.2, 0)},
                       {.surface = sheet(8, -1.0, 2.9, -0.8, 1.2, -1.4, 0.25, 1)},
                       {.surface = sheet(5, -1.9, -0.2, -1.7, 0.1, -0.3, 0.1, 0)}};
    crisp_placement pl;
    double o[3] = {-0.3, 0.4, -2.5}, z[3] = {0.2, 1, 0.3};
    assert_int_equal(crisp_placement_make(o, z, NULL, &pl), CRISP_OK);
    assert_int_equal(crisp_make_sphere(&pl, 0.9, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &f[5].surface),
                     CRISP_OK);
    crisp_surface *t = sheet(3, -1.5, 1.5, -0.5, 0.5, 0, 0.1, 0);
    for (int k = 0; k < t->count_u * t->count_v; k++) {
        double *p = t->cpw + 4 * k;
        double x = p[0], y = p[1];
        p[0] = 0.8 * x + 0.3 * y, p[1] = 0.4 * x + y, p[2] += -1.2 - 0.5 * x;
    }
    f[6].surface = t;
    for (int k = 0; k < 7; k++)
        assert_int_equal(crisp_model_add_face(m, &f[k]), CRISP_OK);
    return m;
}

/* 1 when ribbon quad v has every corner in front of the eye (ribbon.c gives a quad that is not
 * drawn, as at a break of the ribbon, W = -1). */
static int quad_drawn(const crisp_plan_ribbon_vertex *v)
{
    for (int k = 0; k < 4; k++)
        if (!(v[k].clip[3] > 0)) return 0;
    return 1;
}

/* Ribbon quads of the one-stage plans that the staged plans left out (a later stage's pieces
 * hidden by the depth drawn), over the calls of assert_plans_agree. */
static long quads_left_out;

/* The final plan of a frame in stages (pa: crisp_planner_last_plan after crisp_render_cpu)
 * against crisp_planner_plan's (pb) for the same camera: every face pa shows has the same record
 * (but its ranges' starts and ribbon counts), leaves, trim table bit for bit, and its drawn
 * ribbon quads are pb's drawn quads of the face bit for bit, in order, but those a later stage
 * left out where the depth drawn by the earlier stages hides them (stages.c: check_stages finds
 * the images the same); the faces pb shows and pa does not are at most the hidden ones
 * (stats.hidden_faces, which pa reports). */
static void assert_plans_agree(const crisp_frame_plan *pa, const crisp_frame_plan *pb,
                               uint32_t hidden)
{
    assert_int_equal(pa->face_count, pb->face_count);
    assert_int_equal(pa->stats.hidden_faces, hidden);
    uint32_t dropped = 0;
    for (uint32_t f = 0; f < pa->face_count; f++) {
        const crisp_plan_face *a = &pa->faces[f], *b = &pb->faces[f];
        if (!(a->flags & CRISP_PLAN_FACE_VISIBLE) && (b->flags & CRISP_PLAN_FACE_VISIBLE)) {
            assert_int_equal(a->leaf_count + a->strip_count + a->ribbon_count, 0);
            dropped++;
            continue;
        }
        assert_int_equal(a->flags, b->flags);
        assert_int_equal(a->leaf_count, b->leaf_count);
        assert_int_equal(a->tau_max, b->tau_max);
        assert_int_equal(a->strip_count, b->strip_count);
        assert_int_equal(a->grid_u, b->grid_u);
        assert_int_equal(a->grid_v, b->grid_v);
        assert_memory_equal(&a->v0, &b->v0, sizeof a->v0);
        assert_memory_equal(&a->v1, &b->v1, sizeof a->v1);
        assert_memory_equal(&a->strip_scale, &b->strip_scale, sizeof a->strip_scale);
        if (a->leaf_count)
            assert_memory_equal(pa->leaves + a->first_leaf, pb->leaves + b->first_leaf,
                                a->leaf_count * sizeof *pa->leaves);
        if (a->ribbon_count == b->ribbon_count && a->ribbon_count)
            assert_memory_equal(pa->ribbon_vertices + 4 * (size_t)a->first_ribbon,
                                pb->ribbon_vertices + 4 * (size_t)b->first_ribbon,
                                4 * (size_t)a->ribbon_count * sizeof *pa->ribbon_vertices);
        if (a->ribbon_count != b->ribbon_count) {
            uint32_t at = 0, drawn = 0; /* pa's drawn quads found in pb's, in order */
            for (uint32_t q = 0; q < a->ribbon_count; q++) {
                const crisp_plan_ribbon_vertex *va =
                    pa->ribbon_vertices + 4 * (size_t)(a->first_ribbon + q);
                if (!quad_drawn(va)) continue;
                while (at < b->ribbon_count &&
                       memcmp(va, pb->ribbon_vertices + 4 * (size_t)(b->first_ribbon + at),
                              4 * sizeof *va))
                    at++;
                assert_true(at < b->ribbon_count);
                at++;
                drawn++;
            }
            for (uint32_t q = 0; q < b->ribbon_count; q++)
                quads_left_out +=
                    quad_drawn(pb->ribbon_vertices + 4 * (size_t)(b->first_ribbon + q));
            quads_left_out -= drawn;
        }
        for (uint32_t s = 0; s < a->strip_count; s++) {
            const crisp_plan_strip *x = &pa->strips[a->first_strip + s],
                                   *y = &pb->strips[b->first_strip + s];
            assert_memory_equal(&x->a, &y->a, sizeof x->a);
            assert_memory_equal(&x->row_scale, &y->row_scale, sizeof x->row_scale);
            assert_int_equal(x->row_count, y->row_count);
            for (uint32_t r = 0; r < x->row_count; r++) {
                const uint32_t *ox = pa->row_offset + x->first_row + r,
                               *oy = pb->row_offset + y->first_row + r;
                assert_int_equal(ox[1] - ox[0], oy[1] - oy[0]);
                if (ox[1] > ox[0])
                    assert_memory_equal(pa->crossings + ox[0], pb->crossings + oy[0],
                                        (ox[1] - ox[0]) * sizeof *pa->crossings);
            }
        }
    }
    assert_true(dropped <= hidden);
}

/* crisp_render_cpu's stages (the faces that the depth drawn by the earlier stages hides whole are
 * not planned) on renderer a, planning in stages every frame, against crisp_planner_plan +
 * crisp_render_cpu_plan on renderer b: every sample and pixel the same bit for bit, in two frames
 * of the camera (the second's first stage is the faces the first showed; a's first frame of a
 * camera starts from the faces the last camera showed). The final plan a hands back
 * (crisp_planner_last_plan: what crisp-view keeps) agrees with b's (assert_plans_agree) and,
 * drawn again by crisp_render_cpu_plan, draws b's samples and image. Returns the faces found
 * hidden. */
static uint32_t check_stages(crisp_renderer *a, crisp_renderer *b, const crisp_scene *sc,
                             const crisp_camera *cam)
{
    crisp_image ia, ib;
    assert_int_equal(crisp_image_init(&ia, W, H), CRISP_OK);
    assert_int_equal(crisp_image_init(&ib, W, H), CRISP_OK);
    crisp_render_stats sa, sb;
    const crisp_frame_plan *plan;
    uint32_t hidden = 0;
    for (int rep = 0; rep < 2; rep++) {
        assert_int_equal(crisp_render_cpu(a, sc, cam, &ia, &sa), CRISP_OK);
        /* The faces the resolve listed for the next first stage: those the image shows. */
        rt_assert_seen_faces(a, sc, &ia);
        assert_int_equal(crisp_planner_plan(crisp_renderer_planner(b), sc, cam, &plan), CRISP_OK);
        assert_int_equal(crisp_render_cpu_plan(b, sc, plan, cam, &ib, &sb), CRISP_OK);
        assert_same(a, b, &ia, &ib, "stages");
        assert_int_equal(sb.hidden_faces, 0);
        assert_true(sa.visible_faces <= sb.visible_faces);
        const crisp_frame_plan *pa = crisp_planner_last_plan(crisp_renderer_planner(a));
        assert_non_null(pa);
        assert_ptr_equal(crisp_planner_last_plan(crisp_renderer_planner(b)), plan);
        assert_plans_agree(pa, plan, sa.hidden_faces);
        assert_int_equal(crisp_render_cpu_plan(a, sc, pa, cam, &ia, NULL), CRISP_OK);
        assert_same(a, b, &ia, &ib, "the staged plan drawn again");
        hidden += pa->stats.hidden_faces;
    }
    crisp_image_free(&ia);
    crisp_image_free(&ib);
    return hidden;
}

static void test_hidden_faces(void **state)
{
    (void)state;
    crisp_model *models[2] = {wall(), layers()};
    for (int s = 0; s < 2; s++) {
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(models[s], &sc), CRISP_OK);
        uint32_t frontal = 0, other = 0;
        for (int samples = 1; samples <= 4; samples += 3) {
            crisp_renderer *a, *b;
            crisp_render_desc d = {.samples = samples, .threads = 2, .eps_px = EPS};
            assert_int_equal(crisp_renderer_create(&d, &a), CRISP_OK);
            assert_int_equal(crisp_renderer_create(&d, &b), CRISP_OK);
            crisp__planner_always_stages(crisp_renderer_planner(a), 1);
            for (int k = 0; k < (samples == 1 ? 8 : 2); k++) {
                /* frontal: the wall hides most of what is behind */
                double eye[3] = {0.8 * (rnd() - 0.5), 0.8 * (rnd() - 0.5), 2.5 + 3 * rnd()};
                double target[3] = {0.6 * (rnd() - 0.5), 0.6 * (rnd() - 0.5), -1};
                crisp_camera cam = camera(eye, target, 20 + 40 * rnd());
                frontal += check_stages(a, b, sc, &cam);
            }
            for (int k = 0; k < (samples == 1 ? 16 : 4); k++) {
                /* all around, between the layers, wide and narrow */
                double eye[3] = {6 * (rnd() - 0.5), 6 * (rnd() - 0.5), -4.5 + 10 * rnd()};
                double target[3] = {4 * (rnd() - 0.5), 4 * (rnd() - 0.5), -3 + 3.5 * rnd()};
                crisp_camera cam = camera(eye, target, 10 + 90 * rnd());
                other += check_stages(a, b, sc, &cam);
            }
            for (int k = 0; k < (samples == 1 ? 4 : 1); k++) {
                /* grazing: just in front of the wall, along it */
                double eye[3] = {-2.5 + rnd(), 2 * (rnd() - 0.5), 0.05 + 0.1 * rnd()};
                double target[3] = {2, 2 * (rnd() - 0.5), -0.3 - rnd()};
                crisp_camera cam = camera(eye, target, 30 + 50 * rnd());
                other += check_stages(a, b, sc, &cam);
            }
            crisp_renderer_destroy(a);
            crisp_renderer_destroy(b);
        }
        printf("%s: faces hidden before planning %u in the frontal views, %u in the others; "
               "ribbon quads left out as hidden %ld\n",
               s ? "layers" : "wall", frontal, other, quads_left_out);
        quads_left_out = 0;
        if (s == 0) assert_true(frontal >= 16); /* the wall hides something in every view */
        crisp_scene_destroy(sc);
        crisp_model_destroy(models[s]);
    }
}

/* crisp__planner_seen's marks (the next frame's first stage) are exactly the faces listed:
 * face id arrays of every length up to 99 and runs of 1..40 of one id, with the background (-1),
 * f-rep ids (< -1) and ids past the scene's faces (not marked). */
static void test_seen_marks(void **state)
{
    (void)state;
    crisp_model *m = wall();
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_planner *p;
    assert_int_equal(crisp_planner_create(NULL, NULL, &p), CRISP_OK);
    int32_t face[4096];
    uint32_t n = sc->face_count, arrays = 0;
    for (int k = 0; k < 3000; k++) {
        size_t count = k < 100 ? (size_t)k : (size_t)(rnd() * 4096);
        for (size_t i = 0; i < count;) {
            int32_t f = (int32_t)(rnd() * (n + 4)) - 2;
            size_t run = 1 + (size_t)(rnd() * (rnd() < 0.5 ? 40 : 4));
            for (; run-- && i < count; i++)
                face[i] = f;
        }
        assert_int_equal(crisp__planner_seen(p, sc, face, count), CRISP_OK);
        for (uint32_t f = 0; f < n; f++) {
            int want = 0;
            for (size_t i = 0; i < count && !want; i++)
                want = face[i] == (int32_t)f;
            assert_int_equal(p->stages.seen[f], want);
        }
        arrays++;
    }
    printf("seen marks: %u arrays as the faces they hold\n", arrays);
    crisp_planner_destroy(p);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* crisp__occl_set's record against the same arithmetic with libm's floor and nextafterf (its own
 * floor and next float up avoid the calls): boxes near integers, at zero and -0, negative, far
 * off the window, huge, infinite and NaN; 1/W near 0, near the float limit, and not positive. */
static void test_occl_set(void **state)
{
    (void)state;
    const int win[4] = {8, 16, 200, 120};
    long same = 0;
    for (int k = 0; k < 200000; k++) {
        double lo[2], hi[2], iw;
        for (int q = 0; q < 2; q++) {
            double r = rnd(), a;
            if (r < 0.4)
                a = 300 * rnd() - 50;
            else if (r < 0.6)
                a = floor(300 * rnd() - 50) + (rnd() < 0.5 ? 0 : rnd() < 0.5 ? 1e-12 : -1e-12);
            else if (r < 0.7)
                a = rnd() < 0.5 ? 0.0 : -0.0;
            else if (r < 0.8)
                a = (rnd() < 0.5 ? -1 : 1) * pow(10, 20 * rnd());
            else if (r < 0.85)
                a = (rnd() < 0.5 ? -1 : 1) * INFINITY;
            else if (r < 0.88)
                a = NAN;
            else
                a = (rnd() - 0.5) * 4e15 * 2;
            lo[q] = a;
            hi[q] = rnd() < 0.1 ? a : a + 30 * rnd();
        }
        double r = rnd();
        iw = r < 0.5    ? rnd()
             : r < 0.7  ? pow(10, -40 * rnd())
             : r < 0.8  ? 3.0e38 * (0.99 + 0.02 * rnd())
             : r < 0.9  ? -rnd()
             : r < 0.95 ? 0.0
                        : INFINITY;
        crisp_occl_leaf o;
        crisp__occl_set(&o, win, lo, hi, iw);
        /* the reference: occlusion.c's arithmetic with the library calls */
        double b[4];
        for (int q = 0; q < 2; q++) {
            double n = win[2 + q] - 1;
            double x0 = floor(lo[q]) - 1 - win[q], x1 = floor(hi[q]) - win[q];
            b[q] = x0 > 0 ? (x0 < n ? x0 : n) : 0;
            b[2 + q] = x1 > 0 ? (x1 < n ? x1 : n) : 0;
        }
        double m = iw * (1.0 + 1.0 / 1024);
        float f = (float)m;
        if ((double)f < m) f = nextafterf(f, INFINITY);
        float ref = m > 0 && m < 3.0e38 ? f : INFINITY;
        assert_int_equal(o.bx0, (int)b[0] / CRISP_OCCL_BLOCK);
        assert_int_equal(o.by0, (int)b[1] / CRISP_OCCL_BLOCK);
        assert_int_equal(o.bx1, (int)b[2] / CRISP_OCCL_BLOCK);
        assert_int_equal(o.by1, (int)b[3] / CRISP_OCCL_BLOCK);
        assert_memory_equal(&o.iw, &ref, sizeof ref);
        same++;
    }
    printf("occl_set: %ld records as the library's arithmetic\n", same);
}

/* A random rational Bezier patch into z (degrees 1-4 each way, weights 0.3-3, its points within
 * 0.65 of the origin in each coordinate; its control points in cpw, room for 25; box NULL or its
 * points' box, least x, y, z then largest) and a random camera looking at it from all around. */
static crisp_camera random_patch_view(crisp_bezier_patch *z, double cpw[25 * 4], double box[6])
{
    *z = (crisp_bezier_patch){.du = 1 + (int)(4 * rnd()), .rational = 1, .u1 = 1, .v1 = 1};
    z->dv = 1 + (int)(4 * rnd());
    z->cpw = cpw;
    if (box)
        for (int a = 0; a < 3; a++)
            box[a] = INFINITY, box[a + 3] = -INFINITY;
    for (int j = 0; j <= z->dv; j++)
        for (int i = 0; i <= z->du; i++) {
            double *c = cpw + 4 * (j * (z->du + 1) + i), w = 0.3 + 2.7 * rnd();
            double x = (double)i / z->du - 0.5 + 0.3 * (rnd() - 0.5),
                   y = (double)j / z->dv - 0.5 + 0.3 * (rnd() - 0.5), zz = rnd() - 0.5;
            double p[3] = {x, y, zz};
            for (int a = 0; a < 3; a++) {
                c[a] = p[a] * w;
                if (box) box[a] = fmin(box[a], p[a]), box[a + 3] = fmax(box[a + 3], p[a]);
            }
            c[3] = w;
        }
    double a = 2 * M_PI * rnd(), e = M_PI * (rnd() - 0.5), dist = 1.5 + 3 * rnd();
    double eye[3] = {dist * cos(e) * cos(a), dist * cos(e) * sin(a), dist * sin(e)};
    double target[3] = {0.4 * (rnd() - 0.5), 0.4 * (rnd() - 0.5), 0.4 * (rnd() - 0.5)};
    return camera(eye, target, 30 + 60 * rnd());
}

/* The bound of the later stages' face test (crisp__stages_hull_piece): every point of a patch
 * piece lies on screen inside the box of its control net's hull and at a W no less than its least
 * W. Random rational patches (degrees 1..4, weights 0.3..3), cameras all around them; the piece's
 * points on a 13 x 13 grid of its parameter rectangle, for every piece of 0..4 halvings (u, v in
 * turn). The box must also be tight enough to matter: its area within 4x of the points' box on
 * average for the whole patch. A W bound without the weights, or halves swapped, fails it. */
static void test_hull_bound(void **state)
{
    (void)state;
    long points = 0, boxes = 0;
    double ratio = 0;
    int ratios = 0;
    for (int k = 0; k < 300; k++) {
        crisp_bezier_patch z;
        double cpw[25 * 4];
        crisp_camera cam = random_patch_view(&z, cpw, NULL);
        crisp_camera_matrices cm;
        crisp_camera_matrices_compute(&cam, &cm);
        for (int splits = 0; splits <= 4; splits++)
            for (unsigned piece = 0; piece < 1u << splits; piece++) {
                double lo[2], hi[2], w0;
                if (!crisp__stages_hull_piece(&z, cm.view_proj, W, H, splits, piece, lo, hi, &w0))
                    continue;
                boxes++;
                double s0 = 0, s1 = 1, t0 = 0, t1 = 1; /* the piece's parameter rectangle */
                for (int l = 0; l < splits; l++) {
                    int upper = (piece >> l) & 1;
                    if (l % 2 == 0) {
                        double m = 0.5 * (s0 + s1);
                        if (upper)
                            s0 = m;
                        else
                            s1 = m;
                    } else {
                        double m = 0.5 * (t0 + t1);
                        if (upper)
                            t0 = m;
                        else
                            t1 = m;
                    }
                }
                double plo[2] = {INFINITY, INFINITY}, phi[2] = {-INFINITY, -INFINITY};
                for (int j = 0; j <= 12; j++)
                    for (int i = 0; i <= 12; i++) {
                        double p[3], (*m)[4] = cm.view_proj;
                        crisp_bezier_patch_eval(&z, s0 + (s1 - s0) * i / 12,
                                                t0 + (t1 - t0) * j / 12, p);
                        double x = m[0][0] * p[0] + m[1][0] * p[1] + m[2][0] * p[2] + m[3][0];
                        double y = m[0][1] * p[0] + m[1][1] * p[1] + m[2][1] * p[2] + m[3][1];
                        double w = m[0][3] * p[0] + m[1][3] * p[1] + m[2][3] * p[2] + m[3][3];
                        double px = (x / w + 1) * 0.5 * W, py = (1 - y / w) * 0.5 * H;
                        double tol = 1e-9 * (1 + fabs(px) + fabs(py));
                        assert_true(w >= w0 * (1 - 1e-12));
                        assert_true(px >= lo[0] - tol && px <= hi[0] + tol);
                        assert_true(py >= lo[1] - tol && py <= hi[1] + tol);
                        plo[0] = fmin(plo[0], px), phi[0] = fmax(phi[0], px);
                        plo[1] = fmin(plo[1], py), phi[1] = fmax(phi[1], py);
                        points++;
                    }
                if (splits == 0 && phi[0] > plo[0] && phi[1] > plo[1]) {
                    ratio +=
                        (hi[0] - lo[0]) * (hi[1] - lo[1]) / ((phi[0] - plo[0]) * (phi[1] - plo[1]));
                    ratios++;
                }
            }
    }
    printf("hull bound: %ld points in %ld piece boxes, box area / points' box %.2f on average\n",
           points, boxes, ratio / ratios);
    assert_true(boxes > 3000);
    assert_true(ratio / ratios < 4);
}

/* crisp__stages_patch_pieces (the later stages' ribbon test, stages.c): 300 random rational
 * patches (degrees 1-4, weights 0.3-3) under cameras all around, each against a block depth of
 * random blocks near or beyond the patch's 1/W range; every piece found hidden has its 13 x 13
 * points of its (s, t) cell in front of the eye and nearer than no block within 1 px of them (a
 * ribbon's reach from its curve point) inside the image: each such block holds a larger 1/W. Some
 * pieces of some patches are found hidden and others not. */
static void test_piece_bound(void **state)
{
    (void)state;
    enum {
        BX = (W + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK,
        BY = (H + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK
    };
    const int n = CRISP__RIBBON_PIECES, win[4] = {0, 0, W, H};
    long points = 0, hidden = 0, pieces = 0;
    for (int k = 0; k < 300; k++) {
        crisp_bezier_patch z;
        double cpw[25 * 4], box[6];
        crisp_camera cam = random_patch_view(&z, cpw, box);
        crisp_camera_matrices cm;
        crisp_camera_matrices_compute(&cam, &cm);
        double(*m)[4] = cm.view_proj;
        /* The patch's 1/W range; the blocks on one side of a random line hide all of it (but a
         * few), on the other side a random part of it. */
        double iw0 = INFINITY, iw1 = 0;
        for (int j = 0; j <= 8; j++)
            for (int i = 0; i <= 8; i++) {
                double p[3];
                crisp_bezier_patch_eval(&z, i / 8.0, j / 8.0, p);
                double w = m[0][3] * p[0] + m[1][3] * p[1] + m[2][3] * p[2] + m[3][3];
                iw0 = fmin(iw0, 1 / w), iw1 = fmax(iw1, 1 / w);
            }
        double hiz[BX * BY], dir = 2 * M_PI * rnd(), ox = BX * rnd(), oy = BY * rnd();
        for (int b = 0; b < BX * BY; b++) {
            int side = cos(dir) * (b % BX - ox) + sin(dir) * (b / BX - oy) > 0;
            hiz[b] = side && rnd() < 0.95 ? 2 * iw1 : iw0 + (iw1 - iw0) * rnd();
        }
        uint32_t mask = crisp__stages_patch_pieces(&z, box, m, W, H, win, hiz);
        pieces += n * n;
        for (int r = 0; r < n; r++)
            for (int c = 0; c < n; c++) {
                if (!(mask >> (n * r + c) & 1)) continue;
                hidden++;
                for (int j = 0; j <= 12; j++)
                    for (int i = 0; i <= 12; i++) {
                        double p[3];
                        crisp_bezier_patch_eval(&z, (c + i / 12.0) / n, (r + j / 12.0) / n, p);
                        double x = m[0][0] * p[0] + m[1][0] * p[1] + m[2][0] * p[2] + m[3][0];
                        double y = m[0][1] * p[0] + m[1][1] * p[1] + m[2][1] * p[2] + m[3][1];
                        double w = m[0][3] * p[0] + m[1][3] * p[1] + m[2][3] * p[2] + m[3][3];
                        assert_true(w > 0);
                        double px = (x / w + 1) * 0.5 * W, py = (1 - y / w) * 0.5 * H;
                        for (int by = 0; by < BY; by++)
                            for (int bx = 0; bx < BX; bx++) {
                                double x0 = bx * CRISP_OCCL_BLOCK, y0 = by * CRISP_OCCL_BLOCK;
                                if (px + 1 < x0 || px - 1 > x0 + CRISP_OCCL_BLOCK || py + 1 < y0 ||
                                    py - 1 > y0 + CRISP_OCCL_BLOCK)
                                    continue;
                                assert_true(hiz[by * BX + bx] > 1 / w);
                            }
                        points++;
                    }
            }
    }
    printf("piece bound: %ld of %ld pieces hidden, %ld points\n", hidden, pieces, points);
    assert_true(hidden > pieces / 20 && hidden < pieces - pieces / 20);
}

/* A random quad like a ribbon's (up to 6 px long, 1.4 px wide, 1/W up to 30% apart between its
 * ends, some across the image's edge): its vertices v (clip x, y, W), their pixels px and 1/W
 * iw; and block depths hiz (n blocks) near its 1/W, a fifth of them empty (0). */
static void random_ribbon_quad(crisp_plan_ribbon_vertex v[4], double px[4][2], double iw[4],
                               double *hiz, int n)
{
    double cx = -4 + (W + 8) * rnd(), cy = -4 + (H + 8) * rnd(), a = 2 * M_PI * rnd();
    double len = 6 * rnd(), e[2] = {cos(a), sin(a)}, nrm[2] = {-e[1], e[0]};
    double iw0 = 0.2 + rnd(), iw1 = iw0 * (0.7 + 0.6 * rnd());
    for (int c = 0; c < 4; c++) {
        double along = c < 2 ? -0.7 : len + 0.7, side = (c == 0 || c == 3) ? -0.7 : 0.7;
        px[c][0] = cx + along * e[0] + side * nrm[0];
        px[c][1] = cy + along * e[1] + side * nrm[1];
        iw[c] = c < 2 ? iw0 : iw1;
        double w = 1 / iw[c];
        v[c] = (crisp_plan_ribbon_vertex){0};
        v[c].clip[0] = (px[c][0] / W * 2 - 1) * w;
        v[c].clip[1] = (1 - px[c][1] / H * 2) * w;
        v[c].clip[3] = w;
    }
    for (int b = 0; b < n; b++)
        hiz[b] = rnd() < 0.2 ? 0 : fmax(iw0, iw1) * (0.95 + 0.1 * rnd());
}

/* crisp__stages_quad_unseen (a later stage's kept ribbon quads): 20,000 random quads like a
 * ribbon's (up to 6 px long, 1.4 px wide, 1/W up to 30% apart between its ends, some across the
 * image's edge) against block depths of random blocks near their 1/W: every point of a quad
 * found unseen (13 x 13 of each of its two triangles, 1/W affine on screen as the rasterizer
 * interpolates it) lies outside the image or in a block holding a larger 1/W; a quad with a
 * corner behind the eye is unseen only when all are. Some quads are found unseen and others
 * not. */
static void test_quad_unseen(void **state)
{
    (void)state;
    enum {
        BX = (W + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK,
        BY = (H + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK
    };
    const int win[4] = {0, 0, W, H};
    long unseen = 0, quads = 0, points = 0;
    for (int k = 0; k < 20000; k++) {
        crisp_plan_ribbon_vertex v[4];
        double px[4][2], iw[4], hiz[BX * BY];
        random_ribbon_quad(v, px, iw, hiz, BX * BY);
        if (k % 10 == 0) { /* corners behind the eye */
            int behind = 0;
            for (int c = 0; c < 4; c++)
                if (rnd() < 0.6) v[c].clip[3] = -1, behind++;
            if (behind) {
                assert_int_equal(crisp__stages_quad_unseen(v, W, H, win, hiz), behind == 4);
                continue;
            }
        }
        quads++;
        if (!crisp__stages_quad_unseen(v, W, H, win, hiz)) continue;
        unseen++;
        static const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
        for (int t = 0; t < 2; t++)
            for (int j = 0; j <= 12; j++)
                for (int i = 0; i <= 12 - j; i++) {
                    double l[3] = {i / 12.0, j / 12.0, 1 - i / 12.0 - j / 12.0}, p[2] = {0, 0},
                           q = 0;
                    for (int c = 0; c < 3; c++) {
                        p[0] += l[c] * px[tri[t][c]][0], p[1] += l[c] * px[tri[t][c]][1];
                        q += l[c] * iw[tri[t][c]];
                    }
                    points++;
                    if (p[0] < 0 || p[1] < 0 || p[0] >= W || p[1] >= H) continue;
                    int b = (int)(p[1] / CRISP_OCCL_BLOCK) * BX + (int)(p[0] / CRISP_OCCL_BLOCK);
                    assert_true(hiz[b] > q);
                }
    }
    printf("quad unseen: %ld of %ld quads, %ld points\n", unseen, quads, points);
    assert_true(unseen > quads / 20 && unseen < quads - quads / 20);
}

/* crisp__occl_point_seen, the draw's ribbon cull's pre-test (cpu.c: a quad with a corner seen is
 * kept without crisp__raster_quad_hidden): over 20,000 random ribbon quads and block depths, no
 * quad that crisp__raster_quad_hidden hides has a corner seen (but corners within 0.01 px of a
 * block's side, where the rasterizer's snapping may put them in the next block), and most quads
 * it does not hide have one (the pre-test decides most quads). Fails with the comparison
 * reversed, x and y swapped, or the point's block a row off. */
static void test_point_seen(void **state)
{
    (void)state;
    enum {
        BX = (W + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK,
        BY = (H + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK
    };
    crisp_raster *r;
    crisp_raster_target t = {0};
    assert_int_equal(crisp__raster_create(&r), CRISP_OK);
    assert_int_equal(crisp__raster_target_init(&t, W, H, 1), CRISP_OK);
    long hidden = 0, kept = 0, seen_kept = 0;
    for (int k = 0; k < 20000; k++) {
        crisp_plan_ribbon_vertex v[4];
        double px[4][2], iw[4], hiz[BX * BY];
        random_ribbon_quad(v, px, iw, hiz, BX * BY);
        crisp__raster_set_occlusion(r, hiz, CRISP_OCCL_BLOCK);
        const double *clip[4] = {v[0].clip, v[1].clip, v[2].clip, v[3].clip};
        int quad_hidden = crisp__raster_quad_hidden(r, &t, clip, NULL, NULL), seen = 0;
        for (int c = 0; c < 4; c++) {
            double fx = px[c][0] / CRISP_OCCL_BLOCK, fy = px[c][1] / CRISP_OCCL_BLOCK;
            int near_side = fabs(fx - round(fx)) * CRISP_OCCL_BLOCK < 0.01 ||
                            fabs(fy - round(fy)) * CRISP_OCCL_BLOCK < 0.01;
            int s = crisp__occl_point_seen(hiz, BX, BY, px[c][0], px[c][1], iw[c]);
            if (quad_hidden && !near_side) assert_false(s);
            seen |= s;
        }
        hidden += quad_hidden;
        kept += !quad_hidden;
        seen_kept += !quad_hidden && seen;
    }
    crisp__raster_set_occlusion(r, NULL, 0);
    crisp__raster_target_free(&t);
    crisp__raster_destroy(r);
    printf("point seen: %ld quads hidden, %ld of %ld others with a corner seen\n", hidden,
           seen_kept, kept);
    assert_true(hidden > 1000 && seen_kept > kept / 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frontal),     cmocka_unit_test(test_random),
        cmocka_unit_test(test_pieces),      cmocka_unit_test(test_hidden_faces),
        cmocka_unit_test(test_occl_set),    cmocka_unit_test(test_seen_marks),
        cmocka_unit_test(test_hull_bound),  cmocka_unit_test(test_piece_bound),
        cmocka_unit_test(test_quad_unseen), cmocka_unit_test(test_point_seen),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
