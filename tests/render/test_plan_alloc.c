/* "Planning a frame allocates nothing when the model and image size have not changed": after a
 * warm-up frame, planning (and rendering) the same scene again from another camera of the same
 * image size makes no call to malloc, calloc or realloc. The test binary is linked with
 * --wrap=malloc,calloc,realloc, so every allocation in crisp's code goes through the counters. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>

#include "render/render_test_util.h"
#include "crisp/io.h"
#include "crisp/render.h"

void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t s);
void *__real_realloc(void *p, size_t n);
static int counting;
static long allocations;
static double bytes; /* requested, not live: an upper bound of what a frame holds */

void *__wrap_malloc(size_t n)
{
    if (counting) allocations++, bytes += (double)n;
    return __real_malloc(n);
}

void *__wrap_calloc(size_t n, size_t s)
{
    if (counting) allocations++, bytes += (double)n * (double)s;
    return __real_calloc(n, s);
}

void *__wrap_realloc(void *p, size_t n)
{
    if (counting) allocations++, bytes += (double)n;
    return __real_realloc(p, n);
}

static void test_steady_state(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_scene *sc = rt_load_scene("occt_bearing.iges", &m);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
    crisp_camera cam;
    assert_int_equal(crisp_camera_frame_box(sc->box, 320, 240, &cam), CRISP_OK);
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, 320, 240), CRISP_OK);
    /* Warm up on a few views so every buffer reaches its size. */
    for (int k = 0; k < 3; k++) {
        cam.eye[0] += 0.01 * k;
        assert_int_equal(crisp_render_cpu(r, sc, &cam, &img, NULL), CRISP_OK);
    }
    counting = 1;
    allocations = 0;
    assert_int_equal(crisp_renderer_plan(r, sc, &cam, NULL), CRISP_OK);
    long plan_allocs = allocations;
    cam.eye[0] -= 0.005; /* another camera, same image size */
    assert_int_equal(crisp_renderer_plan(r, sc, &cam, NULL), CRISP_OK);
    long plan2_allocs = allocations - plan_allocs;
    counting = 0;
    printf("allocations: plan %ld, plan from another camera %ld\n", plan_allocs, plan2_allocs);
    assert_int_equal(plan_allocs, 0);
    assert_int_equal(plan2_allocs, 0);
    /* The counters do see crisp's allocations: a fresh renderer's first plan allocates. */
    crisp_renderer *fresh;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &fresh), CRISP_OK);
    counting = 1;
    allocations = 0;
    assert_int_equal(crisp_renderer_plan(fresh, sc, &cam, NULL), CRISP_OK);
    counting = 0;
    assert_true(allocations > 0);
    crisp_renderer_destroy(fresh);
    crisp_image_free(&img);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* Zooming in by factors of 100 down to a field of view of 1e-8 degrees (a 1e-12 model-unit wide
 * window onto the bearing) keeps a frame's memory bounded: trim polylines refine only where their
 * strips are visible and ribbons only where they can show. */
static void test_extreme_zoom_memory(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_scene *sc = rt_load_scene("occt_bearing.iges", &m);
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, 160, 120), CRISP_OK);
    for (double fov = 1; fov >= 1e-8; fov *= 0.01) {
        crisp_camera cam = {.eye = {0.1, 0.12, 0.15},
                            .target = {0.02, 0.03, 0.01},
                            .up = {0, 1, 0},
                            .fov_deg = fov,
                            .znear = 1e-4,
                            .zfar = 1,
                            .width = 160,
                            .height = 120};
        crisp_renderer *r;
        assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
        counting = 1;
        bytes = 0;
        assert_int_equal(crisp_render_cpu(r, sc, &cam, &img, NULL), CRISP_OK);
        counting = 0;
        printf("fov %g: %.1f MB requested\n", fov, bytes / 1048576.0);
        assert_true(bytes < 256.0 * 1048576.0);
        crisp_renderer_destroy(r);
    }
    crisp_image_free(&img);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_steady_state),
                                       cmocka_unit_test(test_extreme_zoom_memory)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
