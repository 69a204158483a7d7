/* crisp-trimedit in its window under Xvfb (issue 11 "Done means" 1 and 2, label gl): a replayed
 * drag of one control point in the 2D view over 60 frames with a screenshot of the 3D view at
 * every frame, then ctrl+z, ctrl+y and --save. Each of the app's own screenshots (its GL
 * backend, off-screen) is compared with the exact classifier on the curve of that frame
 * (frame_check.h; the curve follows from the cursor positions through the app's own 2D view
 * mapping, te_app): no disagreement beyond 1 px. Run at the default view and at a view zoomed in
 * (set-camera) until the dragged trim curve crosses the window. The saved OBJ loads, holds the
 * moved point exactly, `crisp info` accepts it, and `crisp render` of it with the screenshot's
 * camera gives the app's last screenshot away from edges. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>
#include <png.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "crisp/io.h"
#include "crisp/trim.h"
#include "crisp/trimedit.h"
#include "te_app.h"
#include "trimedit/frame_check.h"

/* The window; the 3D view is its left 60% (te_app_layout), and screenshots without a size read
 * back the frame the window drew. */
enum { WIN_W = 500, WIN_H = 250, SHOT_W = 300, SHOT_H = 250, FRAMES = 60 };

static uint8_t *read_png(const char *path, int *w, int *h)
{
    png_image im;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&im, path)) return NULL;
    im.format = PNG_FORMAT_RGBA;
    uint8_t *buf = malloc(PNG_IMAGE_SIZE(im));
    if (!buf || !png_image_finish_read(&im, NULL, buf, 0, NULL)) {
        free(buf);
        return NULL;
    }
    *w = (int)im.width;
    *h = (int)im.height;
    return buf;
}

/* The camera the app printed for its first screenshot. */
static int parse_camera(const char *log, crisp_camera *c)
{
    FILE *f = fopen(log, "r");
    if (!f) return 0;
    char line[2048];
    int ok = 0;
    while (!ok && fgets(line, sizeof line, f)) {
        const char *p = strstr(line, "camera: --size");
        if (!p) continue;
        ok = sscanf(p,
                    "camera: --size %dx%d --eye %lf,%lf,%lf --target %lf,%lf,%lf --up %lf,%lf,%lf "
                    "--fov %lf "
                    "--near %lf --far %lf",
                    &c->width, &c->height, &c->eye[0], &c->eye[1], &c->eye[2], &c->target[0],
                    &c->target[1], &c->target[2], &c->up[0], &c->up[1], &c->up[2], &c->fov_deg,
                    &c->znear, &c->zfar) == 14;
    }
    fclose(f);
    return ok;
}

/* Pieces of the example with point ref moved to uv (NULL: as built). */
static void example_pieces(crisp_trimedit_ref ref, const double *uv, crisp_scene **sc,
                           crisp_model **m)
{
    crisp_trimedit *ed;
    assert_int_equal(crisp_trimedit_example(m), CRISP_OK);
    assert_int_equal(crisp_trimedit_create(*m, 0, NULL, &ed), CRISP_OK);
    if (uv) assert_int_equal(crisp_trimedit_move_point(ed, &ref, uv, 0), CRISP_OK);
    crisp_trimedit_destroy(ed);
    assert_int_equal(crisp_scene_prepare(*m, sc), CRISP_OK);
}

/* Returns the share of pixels the face covers in the screenshot. */
static double check_shot(const char *png, const crisp_image *ref, const crisp_scene *bare,
                         const crisp_camera *cam, crisp_trimedit_ref pt, const double *uv,
                         fc_result *out)
{
    long cover = 0;
    int w, h;
    uint8_t *px = read_png(png, &w, &h);
    assert_non_null(px);
    assert_int_equal(w, ref->width);
    assert_int_equal(h, ref->height);
    uint8_t *drawn = malloc((size_t)w * h);
    for (size_t p = 0; p < (size_t)w * h; p++)
        cover += drawn[p] = px[4 * p + 3] > 127;
    crisp_model *m;
    crisp_scene *sc;
    example_pieces(pt, uv, &sc, &m);
    fc_compare(ref, bare, cam, 0, sc->pieces + sc->faces[0].first_piece,
               (int)sc->faces[0].piece_count, drawn, 1.0, out);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
    free(drawn);
    free(px);
    return (double)cover / ((double)w * h);
}

static void run_drag(const char *set_camera, double amp, const char *name)
{
    char dir[256], replay[300], log[300], obj[300], cmd[4096];
    snprintf(dir, sizeof dir, "/tmp/crisp_trimedit_gl_%ld_%s", (long)getpid(),
             set_camera ? "zoom" : "default");
    snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
    assert_int_equal(system(cmd), 0);
    snprintf(replay, sizeof replay, "%s/drag.replay", dir);
    snprintf(log, sizeof log, "%s/log.txt", dir);
    snprintf(obj, sizeof obj, "%s/saved.obj", dir);
    /* The app's layout and 2D mapping at this window size (the same code as the window's). */
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, WIN_W, WIN_H), CRISP_OK);
    crisp_trimedit_ref pt = {0, 0, 3};
    double uv0[2], px0[2], cur[FRAMES + 1][2], uvk[FRAMES + 1][2];
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv0, NULL), CRISP_OK);
    te_app_uv_to_px(&app, uv0, px0);
    FILE *f = fopen(replay, "w");
    assert_non_null(f);
    fprintf(f, "wait 2\n");
    if (set_camera) fprintf(f, "set-camera %s\n", set_camera);
    fprintf(f, "move %.17g %.17g\ndown left\n", px0[0], px0[1]);
    for (int k = 1; k <= FRAMES; k++) {
        /* amp px left and amp / 2 down, and back half way, over the drag */
        double s = k <= 40 ? k / 40.0 : 1 - 0.5 * (k - 40) / 20.0;
        cur[k][0] = px0[0] - amp * s;
        cur[k][1] = px0[1] + 0.5 * amp * s;
        te_app_px_to_uv(&app, cur[k], uvk[k]);
        fprintf(f, "move %.17g %.17g\nscreenshot %s/f%02d.png %dx%d\n", cur[k][0], cur[k][1], dir,
                k, SHOT_W, SHOT_H);
    }
    fprintf(f,
            "up left\nkey ctrl+z\nscreenshot %s/undo.png %dx%d\nkey ctrl+y\nscreenshot "
            "%s/final.png %dx%d\n",
            dir, SHOT_W, SHOT_H, dir, SHOT_W, SHOT_H);
    /* A bad edit: weight 0 on control point 5 (refused with a message; the saved file keeps 1). */
    double uv5[2], px5[2];
    assert_int_equal(crisp_trimedit_point(app.ed, (crisp_trimedit_ref){0, 0, 5}, uv5, NULL),
                     CRISP_OK);
    te_app_uv_to_px(&app, uv5, px5);
    fprintf(f, "move %.17g %.17g\nkey 0\n", px5[0], px5[1]);
    fclose(f);
    te_app_close(&app);
    snprintf(cmd, sizeof cmd,
             "xvfb-run -a %s/crisp-trimedit --size %dx%d --replay %s --save %s --exit-after-replay "
             "--no-vsync > %s "
             "2>&1",
             CRISP_BIN_DIR, WIN_W, WIN_H, replay, obj, log);
    int rc = system(cmd);
    if (rc) {
        snprintf(cmd, sizeof cmd, "tail -n 20 %s", log);
        (void)system(cmd);
    }
    assert_int_equal(rc, 0);
    crisp_camera cam;
    assert_true(parse_camera(log, &cam));
    {
        FILE *lf = fopen(log, "r");
        char line[1024];
        int refused = 0;
        while (lf && fgets(line, sizeof line, lf))
            refused |= strstr(line, "refused: weight 0") != NULL;
        if (lf) fclose(lf);
        assert_true(refused);
    }
    assert_int_equal(cam.width, SHOT_W);

    /* The untrimmed face's exact (u, v) at the screenshot camera. */
    crisp_model *bare;
    crisp_scene *bare_sc;
    assert_int_equal(crisp_trimedit_example(&bare), CRISP_OK);
    for (int l = 0; l < bare->faces[0].loop_count; l++)
        crisp_trim_loop_free(&bare->faces[0].loops[l]);
    bare->faces[0].loop_count = 0;
    assert_int_equal(crisp_scene_prepare(bare, &bare_sc), CRISP_OK);
    crisp_image ref;
    assert_int_equal(fc_exact_uv(bare_sc, &cam, &ref), CRISP_OK);
    long disagree = 0, compared = 0;
    double worst = 0, cover_min = 1, cover_max = 0;
    for (int k = 1; k <= FRAMES; k++) {
        char png[400];
        snprintf(png, sizeof png, "%s/f%02d.png", dir, k);
        fc_result r;
        double cover = check_shot(png, &ref, bare_sc, &cam, pt, uvk[k], &r);
        cover_min = fmin(cover_min, cover);
        cover_max = fmax(cover_max, cover);
        if (r.beyond)
            print_message("%s frame %d: %ld disagreements beyond 1 px (worst %.3f)\n", name, k,
                          r.beyond, r.worst_px);
        assert_int_equal(r.beyond, 0);
        assert_true(r.pixels > SHOT_W * SHOT_H / 10);
        disagree += r.disagree;
        compared += r.pixels;
        worst = fmax(worst, r.worst_px);
    }
    /* The trim crosses the window at every frame, and the drag changed the image. */
    assert_true(cover_min > 0.02 && cover_max < 0.98 && cover_max > cover_min);
    char png[400];
    fc_result r;
    snprintf(png, sizeof png, "%s/undo.png", dir);
    check_shot(png, &ref, bare_sc, &cam, pt, NULL, &r);
    assert_int_equal(r.beyond, 0);
    snprintf(png, sizeof png, "%s/final.png", dir);
    check_shot(png, &ref, bare_sc, &cam, pt, uvk[FRAMES], &r);
    assert_int_equal(r.beyond, 0);
    print_message(
        "%s: %d screenshots of the app, %ld pixels compared, %ld disagreements, all within 1 px "
        "(worst %.3f px)\n",
        name, FRAMES + 2, compared, disagree, worst);

    /* The saved file. */
    crisp_model *back;
    assert_int_equal(crisp_model_load(obj, NULL, &back), CRISP_OK);
    const double *q = back->faces[0].loops[0].curves[0]->cpw + 3 * 3;
    assert_true(q[0] / q[2] == uvk[FRAMES][0] && q[1] / q[2] == uvk[FRAMES][1]);
    assert_true(back->faces[0].loops[0].curves[0]->cpw[3 * 5 + 2] == 1.0);
    crisp_model_destroy(back);
    snprintf(cmd, sizeof cmd, "%s/crisp info %s > /dev/null", CRISP_BIN_DIR, obj);
    assert_int_equal(system(cmd), 0);
    char png2[400];
    snprintf(png2, sizeof png2, "%s/crisp_render.png", dir);
    snprintf(
        cmd, sizeof cmd,
        "%s/crisp render %s -o %s --size %dx%d --eye %.17g,%.17g,%.17g --target %.17g,%.17g,%.17g "
        "--up %.17g,%.17g,%.17g --fov %.17g --near %.17g --far %.17g > /dev/null",
        CRISP_BIN_DIR, obj, png2, cam.width, cam.height, cam.eye[0], cam.eye[1], cam.eye[2],
        cam.target[0], cam.target[1], cam.target[2], cam.up[0], cam.up[1], cam.up[2], cam.fov_deg,
        cam.znear, cam.zfar);
    assert_int_equal(system(cmd), 0);
    int w1, h1, w2, h2;
    uint8_t *a = read_png(png, &w1, &h1), *b = read_png(png2, &w2, &h2);
    assert_non_null(a);
    assert_non_null(b);
    assert_int_equal(w1, w2);
    assert_int_equal(h1, h2);
    long same_px = 0, differ = 0, maxd = 0;
    for (int y = 2; y < h1 - 2; y++)
        for (int x = 2; x < w1 - 2; x++) {
            int edge = 0;
            for (int dy = -2; dy <= 2 && !edge; dy++)
                for (int dx = -2; dx <= 2; dx++) {
                    size_t n = 4 * ((size_t)(y + dy) * w1 + x + dx), p = 4 * ((size_t)y * w1 + x);
                    if (a[n + 3] != a[p + 3] || b[n + 3] != b[p + 3] || a[n + 3] != b[n + 3]) {
                        edge = 1;
                        break;
                    }
                }
            if (edge) continue;
            same_px++;
            size_t p = 4 * ((size_t)y * w1 + x);
            int bad = 0;
            for (int k = 0; k < 4; k++) {
                long d = labs((long)a[p + k] - b[p + k]);
                if (d > maxd) maxd = d;
                if (d > 3) bad = 1;
            }
            differ += bad;
        }
    print_message(
        "%s: crisp render of the saved OBJ vs the app's screenshot: %ld of %ld pixels away from "
        "edges differ by more than 3/255 (largest difference %ld)\n",
        name, differ, same_px, maxd);
    assert_true(same_px > (long)w1 * h1 / 10);
    assert_int_equal(differ, 0);
    free(a);
    free(b);
    crisp_image_free(&ref);
    crisp_scene_destroy(bare_sc);
    crisp_model_destroy(bare);
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    (void)system(cmd);
}

static void test_default_view(void **state)
{
    (void)state;
    run_drag(NULL, 30, "default view");
}

static void test_zoomed_view(void **state)
{
    (void)state;
    /* Looking down at the outer curve near control point 3 from close, 1.6 degrees: the window
     * spans about 0.03 of the domain and the dragged curve crosses it. */
    crisp_model *m;
    assert_int_equal(crisp_trimedit_example(&m), CRISP_OK);
    const crisp_curve *cv = m->faces[0].loops[0].curves[0];
    double t0, t1, q[2], P[3], Su[3], Sv[3], N[3];
    crisp_curve_domain(cv, &t0, &t1);
    crisp_curve_eval(cv, t0 + 0.37 * (t1 - t0), q);
    crisp_surface_derivs(m->faces[0].surface, q[0], q[1], P, Su, Sv, NULL, NULL, NULL);
    crisp_vec3_cross(Su, Sv, N);
    crisp_vec3_normalize(N, N);
    char opts[1024];
    snprintf(opts, sizeof opts,
             "--eye %.17g,%.17g,%.17g --target %.17g,%.17g,%.17g --up 0,1,0 --fov 1.6 --near 0.5 "
             "--far 2",
             P[0] + N[0], P[1] + N[1], P[2] + N[2], P[0], P[1], P[2]);
    crisp_model_destroy(m);
    run_drag(opts, 4, "zoomed view");
}

/* The UI's edits through the window's replay (weight field, polygon hole by clicks, a loop
 * moved in the 3D view): the window saves the same OBJ, byte for byte, as te_app given the same
 * events (the window forwards its events to te_app), and that OBJ holds the edits. The window
 * draws with the CPU backend here (--cpu: the edited face alone over the others during the
 * drag). */
typedef struct replay_out {
    FILE *f;
    te_app *app;
} replay_out;

static void r_move(replay_out *o, double x, double y)
{
    fprintf(o->f, "move %.17g %.17g\n", x, y);
    te_app_cursor(o->app, x, y);
}

static void r_button(replay_out *o, int down, const char *mods_name, int mods)
{
    fprintf(o->f, "%s left%s%s\n", down ? "down" : "up", mods_name[0] ? " " : "", mods_name);
    te_app_button(o->app, GLFW_MOUSE_BUTTON_LEFT, down ? GLFW_PRESS : GLFW_RELEASE, mods);
}

static void r_click(replay_out *o, double x, double y)
{
    r_move(o, x, y);
    r_button(o, 1, "", 0);
    r_button(o, 0, "", 0);
}

static void r_key(replay_out *o, const char *name, int key)
{
    fprintf(o->f, "key %s\n", name);
    te_app_key(o->app, key, GLFW_PRESS, 0);
    te_app_key(o->app, key, GLFW_RELEASE, 0);
}

static void test_ui_replay(void **state)
{
    (void)state;
    char dir[256], replay[300], log[300], obj[300], obj2[300], cmd[4096];
    snprintf(dir, sizeof dir, "/tmp/crisp_trimedit_gl_%ld_ui", (long)getpid());
    /* The same file name in two folders (the OBJ names its material file after itself). */
    snprintf(cmd, sizeof cmd, "mkdir -p %s/window %s/te_app", dir, dir);
    assert_int_equal(system(cmd), 0);
    snprintf(replay, sizeof replay, "%s/ui.replay", dir);
    snprintf(log, sizeof log, "%s/log.txt", dir);
    snprintf(obj, sizeof obj, "%s/window/saved.obj", dir);
    snprintf(obj2, sizeof obj2, "%s/te_app/saved.obj", dir);
    const char *cam_opts =
        "--eye 0.5,0.5,3 --target 0.5,0.5,0 --up 0,1,0 --fov 30 --near 0.5 --far 10";
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, WIN_W, WIN_H), CRISP_OK);
    crisp_camera cam = app.cam;
    cam.eye[0] = 0.5, cam.eye[1] = 0.5, cam.eye[2] = 3;
    cam.target[0] = 0.5, cam.target[1] = 0.5, cam.target[2] = 0;
    cam.up[0] = 0, cam.up[1] = 1, cam.up[2] = 0;
    cam.fov_deg = 30, cam.znear = 0.5, cam.zfar = 10;
    te_app_set_camera(&app, &cam);
    replay_out o = {fopen(replay, "w"), &app};
    assert_non_null(o.f);
    fprintf(o.f, "wait 2\nset-camera %s\nwait 1\n", cam_opts);
    /* Select a point of the circle hole, weight 3; a weight of 0 refused. */
    const crisp_trimedit_ref pt = {1, 0, 1};
    double uv[2], px[2];
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, NULL), CRISP_OK);
    te_app_uv_to_px(&app, uv, px);
    r_click(&o, px[0], px[1]);
    r_key(&o, "w", GLFW_KEY_W);
    r_key(&o, "3", GLFW_KEY_3);
    r_key(&o, "enter", GLFW_KEY_ENTER);
    r_key(&o, "w", GLFW_KEY_W);
    r_key(&o, "0", GLFW_KEY_0);
    r_key(&o, "enter", GLFW_KEY_ENTER);
    r_key(&o, "escape", GLFW_KEY_ESCAPE);
    /* A polygon hole by clicks, closed on its first corner. */
    const double c[4][2] = {{0.55, 0.62}, {0.7, 0.6}, {0.72, 0.75}, {0.56, 0.72}};
    r_key(&o, "n", GLFW_KEY_N);
    for (int k = 0; k < 5; k++) {
        te_app_uv_to_px(&app, c[k % 4], px);
        r_click(&o, px[0], px[1]);
    }
    /* The rectangle hole moved with a shift-drag on its image in the 3D view. */
    const crisp_curve *rc = crisp_trimedit_face(app.ed)->loops[2].curves[0];
    double t0, t1, on[2];
    crisp_curve_domain(rc, &t0, &t1);
    crisp_curve_eval(rc, t0 + 0.1 * (t1 - t0), on);
    assert_true(te_app_uv_to_px3d(&app, on, px));
    double before[2];
    assert_int_equal(crisp_trimedit_point(app.ed, (crisp_trimedit_ref){2, 0, 0}, before, NULL),
                     CRISP_OK);
    r_move(&o, px[0], px[1]);
    r_button(&o, 1, "shift", GLFW_MOD_SHIFT);
    for (int k = 1; k <= 10; k++)
        r_move(&o, px[0] - k, px[1] + 0.5 * k);
    r_button(&o, 0, "shift", GLFW_MOD_SHIFT);
    fclose(o.f);
    assert_int_equal(te_app_save(&app, obj2), CRISP_OK);
    /* te_app's result: weight 3, a fifth loop (the polygon), the rectangle moved. */
    double w, after[2];
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, &w), CRISP_OK);
    assert_true(w == 3.0);
    assert_int_equal(crisp_trimedit_face(app.ed)->loop_count, 4);
    assert_int_equal(crisp_trimedit_point(app.ed, (crisp_trimedit_ref){2, 0, 0}, after, NULL),
                     CRISP_OK);
    assert_true(hypot(after[0] - before[0], after[1] - before[1]) > 1e-3);
    te_app_close(&app);
    snprintf(cmd, sizeof cmd,
             "xvfb-run -a %s/crisp-trimedit --cpu --size %dx%d --replay %s --save %s "
             "--exit-after-replay --no-vsync > %s 2>&1",
             CRISP_BIN_DIR, WIN_W, WIN_H, replay, obj, log);
    int rc2 = system(cmd);
    if (rc2) {
        snprintf(cmd, sizeof cmd, "tail -n 20 %s", log);
        (void)system(cmd);
    }
    assert_int_equal(rc2, 0);
    int refused = 0;
    FILE *lf = fopen(log, "r");
    char line[1024];
    while (lf && fgets(line, sizeof line, lf))
        refused |= strstr(line, "refused: weight 0") != NULL;
    if (lf) fclose(lf);
    assert_true(refused);
    snprintf(cmd, sizeof cmd, "cmp -s %s %s", obj, obj2);
    assert_int_equal(system(cmd), 0);
    crisp_model *back;
    assert_int_equal(crisp_model_load(obj, NULL, &back), CRISP_OK);
    assert_int_equal(back->faces[0].loop_count, 4);
    crisp_model_destroy(back);
    print_message("weight field, polygon by clicks, loop moved in 3D: the window's saved OBJ "
                  "equals te_app's for the same events\n");
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    (void)system(cmd);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_view),
        cmocka_unit_test(test_zoomed_view),
        cmocka_unit_test(test_ui_replay),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
