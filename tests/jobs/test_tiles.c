/* Image tiles (issue 15): crisp_document_render with a window draws, for every pixel of the
 * window, bit for bit the rgba, depth, normal, uv and face of the same pixel of the whole image
 * (cpu backend, 1 and 4 samples), for a bundled IGES model (the ribbons' depth slack reads
 * neighbouring pixels) and the scene with f-rep parts (their 32x32 tiles are z-culled against
 * the depth already drawn). Windows at odd offsets and sizes, at the image's edges, 1x1. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "crisp/app.h"
#include "crisp/frep.h"

static void check_windows(const char *path, int width, int height, int samples)
{
    crisp_document *doc = NULL;
    assert_int_equal(crisp_document_open(path, NULL, &doc), CRISP_OK);
    crisp_camera cam;
    assert_int_equal(
        crisp_document_camera(doc, &(crisp_camera_desc){.width = width, .height = height}, &cam),
        CRISP_OK);
    crisp_image full = {0};
    assert_int_equal(crisp_image_init(&full, width, height), CRISP_OK);
    crisp_document_render_desc d = {.samples = samples, .threads = 2};
    assert_int_equal(crisp_document_render(doc, &cam, &d, &full, NULL), CRISP_OK);
    size_t covered = 0;
    for (int p = 0; p < width * height; p++)
        covered += full.face[p] != -1;
    assert_true(covered > (size_t)(width * height) / 20); /* something to compare */
    /* x0, y0, w, h: inside, at the edges, unaligned, one pixel, the whole image */
    const int wins[][4] = {{0, 0, width, height},
                           {0, 0, 64, 64},
                           {37, 11, 101, 77},
                           {width - 45, height - 33, 45, 33},
                           {width / 2, 0, width - width / 2, height / 3},
                           {96, 64, 32, 32},
                           {width / 2 + 3, height / 2 + 5, 1, 1},
                           {0, height / 2, width, 7}};
    for (size_t k = 0; k < sizeof wins / sizeof wins[0]; k++) {
        const int *w = wins[k];
        crisp_image tile = {0};
        assert_int_equal(crisp_image_init(&tile, w[2], w[3]), CRISP_OK);
        d.window[0] = w[0], d.window[1] = w[1], d.window[2] = w[2], d.window[3] = w[3];
        d.threads = 1 + (int)(k % 2); /* the result does not depend on the threads either */
        assert_int_equal(crisp_document_render(doc, &cam, &d, &tile, NULL), CRISP_OK);
        size_t bad = 0;
        for (int j = 0; j < w[3]; j++) {
            size_t s = (size_t)(j + w[1]) * width + w[0], t = (size_t)j * w[2], n = (size_t)w[2];
            bad += memcmp(tile.rgba + 4 * t, full.rgba + 4 * s, 4 * n * sizeof(float)) != 0;
            bad += memcmp(tile.depth + t, full.depth + s, n * sizeof(float)) != 0;
            bad += memcmp(tile.normal + 3 * t, full.normal + 3 * s, 3 * n * sizeof(float)) != 0;
            bad += memcmp(tile.uv + 2 * t, full.uv + 2 * s, 2 * n * sizeof(float)) != 0;
            bad += memcmp(tile.face + t, full.face + s, n * sizeof(int32_t)) != 0;
        }
        if (bad)
            fprintf(stderr, "%s: window %dx%d at (%d, %d), %d samples: %zu rows differ\n", path,
                    w[2], w[3], w[0], w[1], samples, bad);
        assert_int_equal(bad, 0);
        crisp_image_free(&tile);
    }
    d.window[0] = 0, d.window[1] = 0, d.window[2] = width + 1, d.window[3] = 1;
    crisp_image one = {0};
    assert_int_equal(crisp_image_init(&one, width + 1, 1), CRISP_OK);
    assert_int_equal(crisp_document_render(doc, &cam, &d, &one, NULL), CRISP_ERR_INVALID_ARG);
    crisp_image_free(&one);
    crisp_image_free(&full);
    crisp_document_destroy(doc);
}

static void test_model_tiles(void **state)
{
    (void)state;
    check_windows(CRISP_DATA_DIR "/nurbs/occt_bearing.iges", 317, 203, 4);
    check_windows(CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs", 260, 190, 1);
}

static void test_scene_tiles(void **state)
{
    (void)state;
    check_windows(CRISP_DATA_DIR "/scenes/teapot_frep.scene", 300, 170, 4);
}

/* crisp frep render's windows: 2D images and 3D heightmaps, every output (inside, heights, z,
 * normals) bit for bit. */
static void check_frep_windows(const char *path, int width, int height, int depth)
{
    crisp_frep *f = NULL;
    crisp_frep_tape *tape = NULL;
    assert_int_equal(crisp_frep_read_vm(path, &f), CRISP_OK);
    assert_int_equal(crisp_frep_tape_create(f, &tape), CRISP_OK);
    crisp_frep_render_desc d = {.width = width, .height = height, .depth = depth, .threads = 2};
    crisp_frep_renderer *r = NULL;
    assert_int_equal(crisp_frep_renderer_create(tape, &d, &r), CRISP_OK);
    assert_int_equal(crisp_frep_renderer_run(r), CRISP_OK);
    const crisp_frep_image *full = crisp_frep_renderer_image(r);
    size_t inside = 0;
    for (int p = 0; p < width * height; p++)
        inside += full->inside[p] != 0;
    assert_true(inside > (size_t)(width * height) / 50);
    const int wins[][4] = {{0, 0, 64, 64},
                           {37, 11, 101, 77},
                           {width - 45, height - 33, 45, 33},
                           {width / 2, 0, width - width / 2, height / 3},
                           {width / 2 + 3, height / 2 + 5, 1, 1},
                           {0, height / 2, width, 7}};
    for (size_t k = 0; k < sizeof wins / sizeof wins[0]; k++) {
        const int *w = wins[k];
        crisp_frep_render_desc dw = d;
        memcpy(dw.window, w, sizeof dw.window);
        dw.threads = 1 + (int)(k % 2);
        crisp_frep_renderer *rw = NULL;
        assert_int_equal(crisp_frep_renderer_create(tape, &dw, &rw), CRISP_OK);
        assert_int_equal(crisp_frep_renderer_run(rw), CRISP_OK);
        const crisp_frep_image *t = crisp_frep_renderer_image(rw);
        assert_int_equal(t->width, w[2]);
        assert_int_equal(t->height, w[3]);
        size_t bad = 0;
        for (int j = 0; j < w[3]; j++) {
            size_t s = (size_t)(j + w[1]) * width + w[0], o = (size_t)j * w[2], n = (size_t)w[2];
            bad += memcmp(t->inside + o, full->inside + s, n) != 0;
            if (depth) {
                bad += memcmp(t->heights + o, full->heights + s, n * sizeof(int32_t)) != 0;
                bad += memcmp(t->z + o, full->z + s, n * sizeof(float)) != 0;
                bad += memcmp(t->normal + 3 * o, full->normal + 3 * s, 3 * n * sizeof(float)) != 0;
            }
        }
        if (bad)
            fprintf(stderr, "%s: window %dx%d at (%d, %d), depth %d: %zu rows differ\n", path, w[2],
                    w[3], w[0], w[1], depth, bad);
        assert_int_equal(bad, 0);
        crisp_frep_renderer_destroy(rw);
    }
    crisp_frep_render_desc bad = d;
    bad.window[0] = width - 3, bad.window[2] = 4, bad.window[3] = 1;
    crisp_frep_renderer *rb = NULL;
    assert_int_equal(crisp_frep_renderer_create(tape, &bad, &rb), CRISP_ERR_INVALID_ARG);
    crisp_frep_renderer_destroy(r);
    crisp_frep_tape_destroy(tape);
    crisp_frep_destroy(f);
}

static void test_frep_tiles(void **state)
{
    (void)state;
    check_frep_windows(CRISP_DATA_DIR "/frep/prospero.vm", 517, 389, 0);
    check_frep_windows(CRISP_DATA_DIR "/frep/quarter.vm", 300, 300, 0);
    check_frep_windows(CRISP_DATA_DIR "/frep/tanglecube.vm", 256, 200, 256);
    check_frep_windows(CRISP_DATA_DIR "/frep/bear.vm", 200, 230, 160);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_model_tiles),
                                       cmocka_unit_test(test_scene_tiles),
                                       cmocka_unit_test(test_frep_tiles)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
