/* The CPU backend's resolve (samples to colour and AOVs) gives the same bits by every path: the
 * two-, four- and eight-pixel vector paths (SSE2, AVX, AVX-512, each where the processor has it)
 * against the scalar code, on targets filled at random (runs of faces with background between
 * them, faces of other colours side by side, zero, tiny and NaN normals, odd widths, windows and
 * rectangles that start and end off the eight-pixel groups) and on rendered images; and each
 * path lists the faces its pixels show (the planner's seen faces). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/plan.h"
#include "crisp/render.h"
#include "render/raster.h"
#include "render/render_internal.h"
#include "render/render_test_util.h"

static uint64_t rng_state = 0x9E3779B97F4A7C15ull;
static double rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}

static int rnd_int(int n)
{
    return (int)(rnd() * n);
}

/* A normal component: mostly ordinary, sometimes zero, tiny (subnormal), large or NaN. */
static float normal_part(int kind)
{
    switch (kind) {
    case 0:
        return 0.0f;
    case 1:
        return 1e-41f * (float)(rnd() - 0.5);
    case 2:
        return 3e37f * (float)(rnd() - 0.5);
    case 3:
        return NAN;
    default:
        return (float)(2 * rnd() - 1);
    }
}

/* Fills target t's samples: runs of one face (1-40 pixels) of background (-1 or another
 * negative id), of a random face or of face 0; inside a run pixels sometimes take another
 * face. */
static void fill_target(crisp_raster_target *t, uint32_t faces)
{
    size_t n = (size_t)t->width * t->height;
    int32_t f = -1;
    int left = 0;
    for (size_t p = 0; p < n; p++) {
        if (!left) {
            left = 1 + rnd_int(40);
            double x = rnd();
            f = x < 0.2 ? -1 : x < 0.25 ? -1 - rnd_int(1000) : x < 0.35 ? 0 : rnd_int((int)faces);
        }
        left--;
        int32_t fp = rnd() < 0.05 ? rnd_int((int)faces) : f;
        t->face[p] = fp;
        /* A drawn sample's 1 / W is positive (the depth test keeps the largest, from 0). */
        double x = rnd();
        t->inv_w[p] = fp < 0 ? 0 : x < 0.02 ? 1e-300 : x < 0.04 ? 1e300 : 0.01 + 10 * rnd();
        float *a = t->attr + p * CRISP_RASTER_ATTRS;
        a[0] = (float)rnd(), a[1] = (float)(rnd() - 0.5);
        int kind = rnd() < 0.1 ? rnd_int(4) : 4; /* the whole normal special, or one part */
        for (int k = 2; k < 5; k++)
            a[k] = normal_part(kind == 4 && rnd() < 0.03 ? rnd_int(4) : kind);
    }
}

static void fill_garbage(crisp_image *img)
{
    size_t n = (size_t)img->width * img->height;
    memset(img->rgba, 0x55, 4 * n * sizeof(float));
    memset(img->depth, 0x66, n * sizeof(float));
    memset(img->normal, 0x77, 3 * n * sizeof(float));
    memset(img->uv, 0x11, 2 * n * sizeof(float));
    memset(img->face, 0x22, n * sizeof(int32_t));
}

static void assert_images_equal(const crisp_image *a, const crisp_image *b)
{
    size_t n = (size_t)a->width * a->height;
    assert_memory_equal(a->rgba, b->rgba, 4 * n * sizeof(float));
    assert_memory_equal(a->depth, b->depth, n * sizeof(float));
    assert_memory_equal(a->normal, b->normal, 3 * n * sizeof(float));
    assert_memory_equal(a->uv, b->uv, 2 * n * sizeof(float));
    assert_memory_equal(a->face, b->face, n * sizeof(int32_t));
}

/* The faces of t's pixels in rect, ascending, are the renderer's seen list. */
static void assert_seen(const crisp_renderer *r, const crisp_raster_target *t, const int rect[4],
                        uint32_t faces)
{
    uint8_t *shown = calloc(faces, 1);
    assert_non_null(shown);
    for (int j = rect[1]; j < rect[3]; j++)
        for (int i = rect[0]; i < rect[2]; i++) {
            int32_t f = t->face[(size_t)j * t->width + i];
            if (f >= 0) shown[f] = 1;
        }
    const int32_t *seen;
    size_t count, listed = 0;
    crisp__renderer_seen(r, &seen, &count);
    for (uint32_t f = 0; f < faces; f++)
        if (shown[f]) {
            assert_true(listed < count);
            assert_int_equal(seen[listed++], (int32_t)f);
        }
    assert_int_equal(listed, count);
    free(shown);
}

/* Random targets of many widths (as windows of a larger image and whole), resolved by each path
 * the processor has into images filled with garbage: every bit of every pixel the same as the
 * scalar path's (the pixels outside the rectangle untouched by both), and the same seen faces. */
static void test_random_targets(void **state)
{
    (void)state;
    crisp_scene sc;
    memset(&sc, 0, sizeof sc);
    enum { FACES = 37 };
    crisp_scene_face faces[FACES];
    memset(faces, 0, sizeof faces);
    for (int f = 0; f < FACES; f++)
        for (int q = 0; q < 3; q++)
            faces[f].color[q] = (float)rnd();
    faces[3].color[0] = -0.0f; /* 0 + (-0 k) is +0 */
    faces[4].color[1] = NAN;
    faces[5].color[2] = 3e38f;
    faces[6].color[0] = 1e-40f;
    sc.faces = faces;
    sc.face_count = FACES;
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
    int best = crisp__renderer_set_resolve(r, -1);
    if (best < 3) fprintf(stderr, "test_resolve: no AVX-512 here: paths 0-%d compared\n", best);
    static const int widths[] = {1, 3, 7, 8, 9, 15, 16, 17, 23, 24, 25, 31, 33, 64, 71, 200, 333};
    int runs = 0;
    for (size_t w = 0; w < sizeof widths / sizeof *widths; w++)
        for (int shape = 0; shape < 3; shape++) {
            int width = widths[w], height = 3 + rnd_int(5);
            crisp_raster_target t;
            memset(&t, 0, sizeof t);
            assert_int_equal(crisp__raster_target_init(&t, width, height, 1), CRISP_OK);
            /* shape 0: the whole image; 1: a window of a larger one; 2: a window and a rectangle
             * inside it. */
            crisp_camera cam = {.eye = {3, -4, 2},
                                .target = {0.1, 0.2, -0.3},
                                .up = {0, 0, 1},
                                .fov_deg = 20 + 40 * rnd(),
                                .znear = 0.1,
                                .zfar = 100,
                                .width = width,
                                .height = height};
            if (shape > 0) {
                int x0 = 8 * (1 + rnd_int(4)), y0 = 8 * rnd_int(3);
                cam.width = x0 + width + rnd_int(20);
                cam.height = y0 + height + rnd_int(20);
                assert_int_equal(crisp__raster_target_window(&t, x0, y0, cam.width, cam.height),
                                 CRISP_OK);
            }
            int rect[4] = {0, 0, width, height};
            if (shape == 2) {
                rect[0] = rnd_int(width < 9 ? 1 : 9);
                rect[1] = rnd_int(2);
                rect[2] = width - rnd_int(width - rect[0] < 9 ? 1 : 9);
                rect[3] = height - rnd_int(2);
            }
            fill_target(&t, FACES);
            crisp_image img[4];
            for (int p = 0; p <= best; p++) {
                assert_int_equal(crisp_image_init(&img[p], width, height), CRISP_OK);
                fill_garbage(&img[p]);
                assert_int_equal(crisp__renderer_resolve(r, &sc, &cam, &t, rect, p, 1, &img[p]),
                                 CRISP_OK);
                assert_seen(r, &t, rect, FACES);
                if (p) assert_images_equal(&img[0], &img[p]);
            }
            /* The scalar path's pixels themselves: background where the face is negative, the
             * face and (u, v) copied elsewhere; garbage outside the rectangle. */
            for (int j = 0; j < height; j++)
                for (int i = 0; i < width; i++) {
                    size_t px = (size_t)j * width + i;
                    int in = i >= rect[0] && i < rect[2] && j >= rect[1] && j < rect[3];
                    int32_t f = t.face[px];
                    int32_t want = !in ? 0x22222222 : f < 0 ? -1 : f;
                    assert_int_equal(img[0].face[px], want);
                    if (in && f >= 0) assert_memory_equal(&img[0].uv[2 * px], t.attr + 5 * px, 8);
                    if (in && f < 0) assert_true(img[0].depth[px] == INFINITY);
                }
            for (int p = 0; p <= best; p++)
                crisp_image_free(&img[p]);
            crisp__raster_target_free(&t);
            runs++;
        }
    assert_int_equal(runs, 3 * (int)(sizeof widths / sizeof *widths));
    crisp_renderer_destroy(r);
}

/* Rendered frames (a model of many faces, each its own colour) at odd sizes, framed and close,
 * with the resolve held to each path: the same image and AOVs bit for bit, and the same seen
 * faces (those of the image's pixels). */
static void test_rendered(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_scene *sc = rt_load_scene("occt_bearing.iges", &m);
    for (uint32_t f = 0; f < sc->face_count; f++) {
        sc->faces[f].color[0] = (float)(f % 7) / 7.0f;
        sc->faces[f].color[1] = (float)(f % 5) / 5.0f;
        sc->faces[f].color[2] = (float)(f % 3) / 3.0f;
    }
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
    int best = crisp__renderer_set_resolve(r, -1);
    crisp__planner_always_stages(crisp_renderer_planner(r), 1); /* (the seen faces wanted) */
    static const int sizes[][2] = {{333, 190}, {97, 61}, {250, 141}};
    for (int s = 0; s < 3; s++)
        for (int view = 0; view < 2; view++) {
            crisp_camera cam;
            assert_int_equal(crisp_camera_frame_box(sc->box, sizes[s][0], sizes[s][1], &cam),
                             CRISP_OK);
            if (view) cam.fov_deg /= 5; /* closer: the model fills the image */
            crisp_image img[4];
            size_t n = (size_t)cam.width * cam.height, covered = 0;
            for (int p = 0; p <= best; p++) {
                crisp__renderer_set_resolve(r, p);
                assert_int_equal(crisp_image_init(&img[p], cam.width, cam.height), CRISP_OK);
                fill_garbage(&img[p]);
                assert_int_equal(crisp_render_cpu(r, sc, &cam, &img[p], NULL), CRISP_OK);
                assert_true(rt_assert_seen_faces(r, sc, &img[p]) > 1);
                if (p) assert_images_equal(&img[0], &img[p]);
            }
            for (size_t px = 0; px < n; px++)
                covered += img[0].face[px] >= 0;
            assert_true(covered > n / 20 && (view || covered < n));
            for (int p = 0; p <= best; p++)
                crisp_image_free(&img[p]);
        }
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_targets),
        cmocka_unit_test(test_rendered),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
