/* Every frame of a drag is trimmed correctly (issue 11, "Done means" 2, through the library
 * without a window): the built-in example's outer loop has one control point dragged over 60
 * frames; per frame only the edited face is re-planned (crisp_scene_update_trim +
 * crisp_planner_replan_face, as the app does), the CPU backend draws the plan, and every pixel is
 * compared with the exact classifier on that frame's curves (frame_check.h): a disagreement
 * farther than 1 px from the true curve fails. Two cameras: the default view of the face, and a
 * view zoomed in until the dragged trim curve crosses the window. Also checks that the re-planned
 * face's table equals the one a whole new plan makes. Argument "all": 240 frames, larger images
 * (slow label). */
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "crisp/plan.h"
#include "crisp/render.h"
#include "crisp/trimedit.h"
#include "trimedit/frame_check.h"

static int full;

/* A camera looking down the surface normal at S(u, v) from `dist`, fov in degrees. */
static void camera_at(const crisp_surface *s, double u, double v, double dist, double fov, int w,
                      int h, crisp_camera *cam)
{
    double P[3], Su[3], Sv[3], N[3];
    crisp_surface_derivs(s, u, v, P, Su, Sv, NULL, NULL, NULL);
    crisp_vec3_cross(Su, Sv, N);
    crisp_vec3_normalize(N, N);
    *cam = (crisp_camera){
        .fov_deg = fov, .znear = dist * 0.01, .zfar = dist * 100, .width = w, .height = h};
    for (int k = 0; k < 3; k++) {
        cam->target[k] = P[k];
        cam->eye[k] = P[k] + dist * N[k];
    }
    cam->up[0] = 0, cam->up[1] = 1, cam->up[2] = 0;
}

/* Drag point `ref` of the example: along a small circle of radius amp (to == NULL), or along the
 * line to `to`; check every frame at camera cam. Returns the number of frames whose loops were
 * flagged as crossing (drawn by the even-odd rule). */
static int drag_and_check(const crisp_camera *cam, crisp_trimedit_ref ref, double amp,
                          const double *to_end, int frames, double limit_px, const char *name)
{
    crisp_model *m, *bare;
    crisp_trimedit *ed;
    assert_int_equal(crisp_trimedit_example(&m), CRISP_OK);
    assert_int_equal(crisp_trimedit_create(m, 0, NULL, &ed), CRISP_OK);
    /* The untrimmed face for the reference (u, v). */
    assert_int_equal(crisp_trimedit_example(&bare), CRISP_OK);
    for (int l = 0; l < bare->faces[0].loop_count; l++)
        crisp_trim_loop_free(&bare->faces[0].loops[l]);
    bare->faces[0].loop_count = 0;
    crisp_scene *sc, *sc_bare;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    assert_int_equal(crisp_scene_prepare(bare, &sc_bare), CRISP_OK);
    crisp_image ref_img, img;
    double t_ref = crisp_time_now();
    assert_int_equal(fc_exact_uv(sc_bare, cam, &ref_img), CRISP_OK);
    t_ref = crisp_time_now() - t_ref;
    double t_render = 0, t_check = 0;
    assert_int_equal(crisp_image_init(&img, cam->width, cam->height), CRISP_OK);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(NULL, &r), CRISP_OK);
    crisp_planner *pl;
    assert_int_equal(crisp_planner_create(NULL, NULL, &pl), CRISP_OK);
    const crisp_frame_plan *plan;
    assert_int_equal(crisp_planner_plan(pl, sc, cam, &plan), CRISP_OK);
    uint8_t *drawn = malloc((size_t)cam->width * cam->height);
    assert_non_null(drawn);
    double p0[2];
    assert_int_equal(crisp_trimedit_point(ed, ref, p0, NULL), CRISP_OK);
    crisp_trimedit_group_begin(ed);
    long total = 0, disagree = 0, trimmed_px_min = LONG_MAX, trimmed_px_max = 0;
    double worst = 0;
    int crossing = 0;
    for (int k = 0; k < frames; k++) {
        double a = 2 * M_PI * k / frames, s = (k + 1.0) / frames;
        double to[2] = {p0[0] + amp * sin(a), p0[1] + amp * (1 - cos(a))};
        if (to_end)
            to[0] = p0[0] + s * (to_end[0] - p0[0]), to[1] = p0[1] + s * (to_end[1] - p0[1]);
        assert_int_equal(crisp_trimedit_move_point(ed, &ref, to, 0), CRISP_OK);
        crossing += !crisp_trimedit_check(ed)->valid;
        assert_int_equal(crisp_scene_update_trim(sc, 0), CRISP_OK);
        assert_int_equal(crisp_planner_replan_face(pl, sc, 0, &plan), CRISP_OK);
        double t0 = crisp_time_now();
        assert_int_equal(crisp_render_cpu_plan(r, sc, plan, cam, &img, NULL), CRISP_OK);
        double t1 = crisp_time_now();
        t_render += t1 - t0;
        long drawn_px = 0;
        for (size_t p = 0; p < (size_t)cam->width * cam->height; p++) {
            drawn[p] = img.face[p] == 0;
            drawn_px += drawn[p];
        }
        const crisp_scene_face *sf = &sc->faces[0];
        fc_result res;
        fc_compare(&ref_img, sc_bare, cam, 0, sc->pieces + sf->first_piece, (int)sf->piece_count,
                   drawn, limit_px, &res);
        t_check += crisp_time_now() - t1;
        if (res.beyond)
            print_message("%s frame %d: %ld of %ld disagreements beyond %g px (worst %.3f px)\n",
                          name, k, res.beyond, res.disagree, limit_px, res.worst_px);
        assert_int_equal(res.beyond, 0);
        assert_true(res.pixels > cam->width * cam->height / 8);
        total += res.pixels;
        disagree += res.disagree;
        worst = fmax(worst, res.worst_px);
        trimmed_px_min = drawn_px < trimmed_px_min ? drawn_px : trimmed_px_min;
        trimmed_px_max = drawn_px > trimmed_px_max ? drawn_px : trimmed_px_max;
    }
    crisp_trimedit_group_end(ed);
    /* The drag changed the image (the curve moved across pixels). */
    assert_true(trimmed_px_max > trimmed_px_min);
    /* The re-planned table equals a whole new plan's. */
    crisp_planner *pl2;
    const crisp_frame_plan *fresh;
    assert_int_equal(crisp_planner_create(NULL, NULL, &pl2), CRISP_OK);
    assert_int_equal(crisp_planner_plan(pl2, sc, cam, &fresh), CRISP_OK);
    assert_int_equal(fresh->row_count, plan->row_count);
    assert_int_equal(fresh->crossing_count, plan->crossing_count);
    assert_memory_equal(fresh->crossings, plan->crossings, plan->crossing_count * sizeof(double));
    crisp_planner_destroy(pl2);
    print_message("%s: exact reference %.2f s, renders %.2f s, checks %.2f s\n", name, t_ref,
                  t_render, t_check);
    print_message("%s: face drawn on %ld..%ld of %d pixels\n", name, trimmed_px_min, trimmed_px_max,
                  cam->width * cam->height);
    print_message("%s: %d frames, %ld pixels compared, %ld disagreements (all within %g px; "
                  "worst %.3f px)\n",
                  name, frames, total, disagree, limit_px, worst);
    free(drawn);
    crisp_planner_destroy(pl);
    crisp_renderer_destroy(r);
    crisp_image_free(&img);
    crisp_image_free(&ref_img);
    crisp_scene_destroy(sc);
    crisp_scene_destroy(sc_bare);
    crisp_trimedit_destroy(ed);
    crisp_model_destroy(m);
    crisp_model_destroy(bare);
    return crossing;
}

static void test_default_view(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_scene *sc;
    assert_int_equal(crisp_trimedit_example(&m), CRISP_OK);
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_camera cam;
    int w = full ? 640 : 240, h = full ? 480 : 180;
    assert_int_equal(crisp_camera_frame_box(sc->box, w, h, &cam), CRISP_OK);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
    drag_and_check(&cam, (crisp_trimedit_ref){0, 0, 3}, 0.08, NULL, full ? 240 : 60, 1.0,
                   "default view");
}

/* A loop pushed across another mid-drag is flagged, not refused, and drawn by the even-odd
 * rule: the rectangle hole's corner dragged out across the outer loop, every frame against the
 * exact (parity) classifier. Limit 1.5 px: the dragged corner becomes an acute apex, and just
 * beyond an apex the table's row (whose crossings hold for the row's height) can keep a pixel
 * inside that is 1.3 px from the true curves (seen once in 30 frames, at the apex). */
static void test_crossing_drag(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_scene *sc;
    assert_int_equal(crisp_trimedit_example(&m), CRISP_OK);
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_camera cam;
    int w = full ? 640 : 240, h = full ? 480 : 180;
    assert_int_equal(crisp_camera_frame_box(sc->box, w, h, &cam), CRISP_OK);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
    const double out[2] = {0.99, 0.3};
    int crossing = drag_and_check(&cam, (crisp_trimedit_ref){2, 0, 1}, 0, out, full ? 120 : 30, 1.5,
                                  "crossing drag");
    print_message("crossing drag: %d frames with crossing loops\n", crossing);
    assert_true(crossing >= 3);
}

static void test_zoomed_view(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_trimedit_example(&m), CRISP_OK);
    /* Look at the outer curve near its control point 3 from close, 1.6 degrees: the window spans
     * about 0.03 of the domain, the curve crosses it. */
    const crisp_curve *cv = m->faces[0].loops[0].curves[0];
    double t0, t1, q[2];
    crisp_curve_domain(cv, &t0, &t1);
    crisp_curve_eval(cv, t0 + 0.37 * (t1 - t0), q);
    crisp_camera cam;
    int w = full ? 640 : 240, h = full ? 480 : 180;
    camera_at(m->faces[0].surface, q[0], q[1], 1.0, 1.6, w, h, &cam);
    crisp_model_destroy(m);
    drag_and_check(&cam, (crisp_trimedit_ref){0, 0, 3}, 0.01, NULL, full ? 240 : 60, 1.0,
                   "zoomed view");
}

/* crisp_render_cpu_plan_faces' contract (the partial frame of the editor): over an image of
 * nothing, the face drawn alone equals the full render bit for bit (the other faces are none);
 * drawing no face afterwards puts the last region back to the base; bad calls are refused. */
static void test_faces_over_base(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_scene *sc;
    assert_int_equal(crisp_trimedit_example(&m), CRISP_OK);
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_camera cam;
    assert_int_equal(crisp_camera_frame_box(sc->box, 160, 120, &cam), CRISP_OK);
    crisp_renderer *r, *r4;
    crisp_planner *pl;
    const crisp_frame_plan *plan;
    assert_int_equal(crisp_renderer_create(NULL, &r), CRISP_OK);
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.samples = 4}, &r4), CRISP_OK);
    assert_int_equal(crisp_planner_create(NULL, NULL, &pl), CRISP_OK);
    assert_int_equal(crisp_planner_plan(pl, sc, &cam, &plan), CRISP_OK);
    crisp_image base, img, whole, small;
    assert_int_equal(crisp_image_init(&base, 160, 120), CRISP_OK); /* cleared: no other face */
    assert_int_equal(crisp_image_init(&img, 160, 120), CRISP_OK);
    assert_int_equal(crisp_image_init(&whole, 160, 120), CRISP_OK);
    assert_int_equal(crisp_image_init(&small, 80, 60), CRISP_OK);
    const uint8_t one = 1, none = 0;
    assert_int_equal(crisp_render_cpu_plan_faces(r, sc, plan, &cam, &one, &base, &img, NULL),
                     CRISP_OK);
    assert_int_equal(crisp_render_cpu_plan(r, sc, plan, &cam, &whole, NULL), CRISP_OK);
    size_t n = (size_t)160 * 120;
    long drawn = 0;
    for (size_t p = 0; p < n; p++)
        drawn += img.face[p] == 0;
    assert_true(drawn > 1000);
    assert_memory_equal(img.rgba, whole.rgba, 4 * n * sizeof(float));
    assert_memory_equal(img.depth, whole.depth, n * sizeof(float));
    assert_memory_equal(img.face, whole.face, n * sizeof(int32_t));
    assert_memory_equal(img.normal, whole.normal, 3 * n * sizeof(float));
    /* No face: the region is empty and the last one is base's again. */
    assert_int_equal(crisp_render_cpu_plan_faces(r, sc, plan, &cam, &none, &base, &img, NULL),
                     CRISP_OK);
    assert_memory_equal(img.rgba, base.rgba, 4 * n * sizeof(float));
    assert_memory_equal(img.face, base.face, n * sizeof(int32_t));
    /* Refused: 4 samples over a base, the base drawn into, no face list, a base of another
     * size. */
    assert_int_equal(crisp_render_cpu_plan_faces(r4, sc, plan, &cam, &one, &base, &img, NULL),
                     CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_render_cpu_plan_faces(r, sc, plan, &cam, &one, &img, &img, NULL),
                     CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_render_cpu_plan_faces(r, sc, plan, &cam, NULL, &base, &img, NULL),
                     CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_render_cpu_plan_faces(r, sc, plan, &cam, &one, &small, &img, NULL),
                     CRISP_ERR_INVALID_ARG);
    /* Without a base, the face alone into a cleared image (the others' image of the editor). */
    assert_int_equal(crisp_render_cpu_plan_faces(r4, sc, plan, &cam, &none, NULL, &img, NULL),
                     CRISP_OK);
    for (size_t p = 0; p < n; p++)
        assert_int_equal(img.face[p], -1);
    crisp_image_free(&base);
    crisp_image_free(&img);
    crisp_image_free(&whole);
    crisp_image_free(&small);
    crisp_planner_destroy(pl);
    crisp_renderer_destroy(r);
    crisp_renderer_destroy(r4);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

int main(int argc, char **argv)
{
    full = argc > 1 && strcmp(argv[1], "all") == 0;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_view),
        cmocka_unit_test(test_zoomed_view),
        cmocka_unit_test(test_crossing_drag),
        cmocka_unit_test(test_faces_over_base),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
