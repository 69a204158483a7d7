/* The trim-editing demo's behaviour without its window (apps/crisp-trimedit/te_app.c, issue 11
 * "Done means" 1 and 4): a drag of one control point in the 2D view over 60 frames (each frame the
 * edited face alone is re-planned, drawn by the CPU backend and checked against the exact
 * classifier, frame_check.h), then ctrl+z, ctrl+y, save. The saved OBJ loads, holds the moved
 * control point exactly (the (u, v) under the last cursor position), `crisp info` accepts it,
 * and `crisp render` of it with the editor's camera gives the editor's image away from edges.
 * Bad edits through the keys (weight 0, deleting points down to the last ones, removing a needed
 * knot) are refused with a message and leave the face as it was; a drag in the 3D view moves the
 * point to the surface point under the cursor; the 2D view draws the table's scan lines. */
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

#include "crisp/image.h"
#include "crisp/io.h"
#include "crisp/trim.h"
#include "te_app.h"
#include "trimedit/frame_check.h"

enum { W = 400, H = 200 };

typedef struct counts {
    long lines, circles;
    double lo[2], hi[2]; /* extent of everything drawn */
} counts;

static void extend(counts *n, double x, double y, double r)
{
    if (n->lines + n->circles == 1) n->lo[0] = n->hi[0] = x, n->lo[1] = n->hi[1] = y;
    n->lo[0] = fmin(n->lo[0], x - r), n->hi[0] = fmax(n->hi[0], x + r);
    n->lo[1] = fmin(n->lo[1], y - r), n->hi[1] = fmax(n->hi[1], y + r);
}

static void count_line(void *ctx, double x0, double y0, double x1, double y1, uint32_t c, double w)
{
    (void)c, (void)w;
    counts *n = ctx;
    n->lines++;
    extend(n, x0, y0, 0);
    extend(n, x1, y1, 0);
}

static void count_circle(void *ctx, double x, double y, double r, uint32_t c, int filled)
{
    (void)c, (void)filled;
    counts *n = ctx;
    n->circles++;
    extend(n, x, y, r);
}

static void to_rgba8(const crisp_image *img, uint8_t *px)
{
    for (size_t i = 0; i < 4 * (size_t)img->width * img->height; i++) {
        float c = img->rgba[i];
        px[i] = (uint8_t)lrintf(255.0f * (c < 0 ? 0 : c > 1 ? 1 : c));
    }
}

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

static void tmp(char *dest, const char *ext)
{
    static int k;
    snprintf(dest, 256, "/tmp/crisp_trimedit_app_%ld_%d%s", (long)getpid(), k++, ext);
}

static void test_drag_undo_redo_save(void **state)
{
    (void)state;
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    /* The untrimmed face's exact (u, v) for the per-frame check (the 3D view's camera). */
    crisp_model *bare;
    crisp_scene *bare_sc;
    assert_int_equal(crisp_trimedit_example(&bare), CRISP_OK);
    for (int l = 0; l < bare->faces[0].loop_count; l++)
        crisp_trim_loop_free(&bare->faces[0].loops[l]);
    bare->faces[0].loop_count = 0;
    assert_int_equal(crisp_scene_prepare(bare, &bare_sc), CRISP_OK);
    crisp_image ref, img;
    assert_int_equal(fc_exact_uv(bare_sc, &app.cam, &ref), CRISP_OK);
    assert_int_equal(crisp_image_init(&img, app.cam.width, app.cam.height), CRISP_OK);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(NULL, &r), CRISP_OK);
    uint8_t *drawn = malloc((size_t)app.cam.width * app.cam.height);

    crisp_trimedit_ref pt = {0, 0, 3};
    double uv0[2], px0[2];
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv0, NULL), CRISP_OK);
    te_app_uv_to_px(&app, uv0, px0);
    te_app_cursor(&app, px0[0], px0[1]);
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0);
    assert_int_equal(app.drag, TE_DRAG_POINT);
    const int frames = 60;
    long replans0 = app.replans, disagree = 0;
    double worst = 0, cur[2] = {0, 0};
    for (int k = 1; k <= frames; k++) {
        cur[0] = px0[0] - 0.8 * k; /* 48 px left and 24 px up over the drag */
        cur[1] = px0[1] - 0.4 * k;
        te_app_cursor(&app, cur[0], cur[1]);
        assert_int_equal(te_app_update(&app), CRISP_OK);
        assert_int_equal(crisp_render_cpu_plan(r, app.scene, app.plan, &app.cam, &img, NULL),
                         CRISP_OK);
        for (size_t p = 0; p < (size_t)img.width * img.height; p++)
            drawn[p] = img.face[p] == 0;
        const crisp_scene_face *sf = &app.scene->faces[0];
        fc_result res;
        fc_compare(&ref, bare_sc, &app.cam, 0, app.scene->pieces + sf->first_piece,
                   (int)sf->piece_count, drawn, 1.0, &res);
        assert_int_equal(res.beyond, 0);
        assert_true(res.pixels > 1000);
        disagree += res.disagree;
        worst = fmax(worst, res.worst_px);
    }
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0);
    /* Each frame re-planned the face alone (no whole plan). */
    assert_int_equal(app.replans - replans0, frames);
    assert_true(app.ms_face_plan > 0);
    print_message("drag: %d frames checked, %ld disagreements, all within 1 px (worst %.3f px)\n",
                  frames, disagree, worst);
    double moved[2], expect[2], got[2];
    te_app_px_to_uv(&app, cur, expect);
    assert_int_equal(crisp_trimedit_point(app.ed, pt, moved, NULL), CRISP_OK);
    assert_true(moved[0] == expect[0] && moved[1] == expect[1]);

    /* Undo (one step for the whole drag), redo. */
    te_app_key(&app, GLFW_KEY_Z, GLFW_PRESS, GLFW_MOD_CONTROL);
    assert_int_equal(crisp_trimedit_point(app.ed, pt, got, NULL), CRISP_OK);
    assert_true(got[0] == uv0[0] && got[1] == uv0[1]);
    te_app_key(&app, GLFW_KEY_Y, GLFW_PRESS, GLFW_MOD_CONTROL);
    assert_int_equal(crisp_trimedit_point(app.ed, pt, got, NULL), CRISP_OK);
    assert_true(got[0] == expect[0] && got[1] == expect[1]);
    assert_int_equal(te_app_update(&app), CRISP_OK);

    /* The editor's screenshot (the 3D view through the CPU backend) and the save. */
    char png[256], obj[256], png2[256], cmd[2048];
    tmp(png, ".png");
    tmp(obj, ".obj");
    tmp(png2, ".png");
    assert_int_equal(crisp_render_cpu_plan(r, app.scene, app.plan, &app.cam, &img, NULL), CRISP_OK);
    uint8_t *shot = malloc(4 * (size_t)img.width * img.height);
    to_rgba8(&img, shot);
    assert_int_equal(crisp_write_png_rgba(png, img.width, img.height, shot), CRISP_OK);
    snprintf(app.save_path, sizeof app.save_path, "%s", obj);
    te_app_key(&app, GLFW_KEY_S, GLFW_PRESS, GLFW_MOD_CONTROL);
    assert_false(app.message_error);

    /* The saved file: loads, holds the moved point exactly. */
    crisp_model *back;
    assert_int_equal(crisp_model_load(obj, NULL, &back), CRISP_OK);
    assert_int_equal(back->face_count, 1);
    const crisp_curve *cv = back->faces[0].loops[0].curves[0];
    const double *q = cv->cpw + 3 * 3;
    assert_true(q[0] / q[2] == expect[0] && q[1] / q[2] == expect[1]);
    crisp_model_destroy(back);
    snprintf(cmd, sizeof cmd, "%s/crisp info %s > /dev/null", CRISP_BIN_DIR, obj);
    assert_int_equal(system(cmd), 0);
    const crisp_camera *c = &app.cam;
    snprintf(
        cmd, sizeof cmd,
        "%s/crisp render %s -o %s --size %dx%d --eye %.17g,%.17g,%.17g --target %.17g,%.17g,%.17g "
        "--up %.17g,%.17g,%.17g --fov %.17g --near %.17g --far %.17g > /dev/null",
        CRISP_BIN_DIR, obj, png2, c->width, c->height, c->eye[0], c->eye[1], c->eye[2],
        c->target[0], c->target[1], c->target[2], c->up[0], c->up[1], c->up[2], c->fov_deg,
        c->znear, c->zfar);
    assert_int_equal(system(cmd), 0);
    int w2, h2, w1, h1;
    uint8_t *a = read_png(png, &w1, &h1), *b = read_png(png2, &w2, &h2);
    assert_non_null(a);
    assert_non_null(b);
    assert_int_equal(w1, w2);
    assert_int_equal(h1, h2);
    /* Away from edges (2 px from any pixel whose coverage differs from a neighbour's in either
     * image), the images agree within 2 of 255 per channel. */
    long compared = 0, differ = 0;
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
            compared++;
            size_t p = 4 * ((size_t)y * w1 + x);
            for (int k = 0; k < 4; k++)
                if (abs(a[p + k] - b[p + k]) > 2) {
                    differ++;
                    break;
                }
        }
    print_message("saved OBJ rendered by crisp render: %ld of %ld pixels away from edges differ\n",
                  differ, compared);
    assert_true(compared > (long)w1 * h1 / 8);
    assert_int_equal(differ, 0);
    remove(png);
    remove(png2);
    remove(obj);
    free(a);
    free(b);
    free(shot);
    free(drawn);
    crisp_renderer_destroy(r);
    crisp_image_free(&img);
    crisp_image_free(&ref);
    crisp_scene_destroy(bare_sc);
    crisp_model_destroy(bare);
    te_app_close(&app);
}

static void test_refused_edits(void **state)
{
    (void)state;
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    uint64_t v = crisp_trimedit_version(app.ed);
    double uv[2], px[2];
    /* Weight 0 on a control point of the outer loop. */
    assert_int_equal(crisp_trimedit_point(app.ed, (crisp_trimedit_ref){0, 0, 5}, uv, NULL),
                     CRISP_OK);
    te_app_uv_to_px(&app, uv, px);
    te_app_cursor(&app, px[0], px[1]);
    te_app_key(&app, GLFW_KEY_0, GLFW_PRESS, 0);
    assert_true(app.message_error);
    assert_non_null(strstr(app.message, "weight"));
    assert_true(crisp_trimedit_version(app.ed) == v);
    /* A knot the curve needs. */
    te_app_key(&app, GLFW_KEY_K, GLFW_PRESS, 0);
    assert_true(app.message_error);
    assert_non_null(strstr(app.message, "cannot be removed"));
    assert_true(crisp_trimedit_version(app.ed) == v);
    /* Weight up works; the 2D view draws bigger. */
    te_app_key(&app, GLFW_KEY_EQUAL, GLFW_PRESS, 0);
    assert_false(app.message_error);
    double w;
    assert_int_equal(crisp_trimedit_point(app.ed, (crisp_trimedit_ref){0, 0, 5}, uv, &w), CRISP_OK);
    assert_true(w == 1.25);
    /* Deleting the rectangle's points down to the last three. */
    assert_int_equal(crisp_trimedit_point(app.ed, (crisp_trimedit_ref){2, 0, 2}, uv, NULL),
                     CRISP_OK);
    te_app_uv_to_px(&app, uv, px);
    te_app_cursor(&app, px[0], px[1]);
    te_app_key(&app, GLFW_KEY_X, GLFW_PRESS, 0);
    assert_false(app.message_error);
    assert_int_equal(crisp_trimedit_point(app.ed, (crisp_trimedit_ref){2, 0, 1}, uv, NULL),
                     CRISP_OK);
    te_app_uv_to_px(&app, uv, px);
    te_app_cursor(&app, px[0], px[1]);
    v = crisp_trimedit_version(app.ed);
    te_app_key(&app, GLFW_KEY_X, GLFW_PRESS, 0);
    assert_true(app.message_error);
    assert_non_null(strstr(app.message, "fewer than 3"));
    assert_true(crisp_trimedit_version(app.ed) == v);
    /* The outer loop cannot be deleted; a new circle hole can, and undo brings it back. */
    assert_int_equal(crisp_trimedit_point(app.ed, (crisp_trimedit_ref){0, 0, 4}, uv, NULL),
                     CRISP_OK);
    te_app_uv_to_px(&app, uv, px);
    te_app_cursor(&app, px[0], px[1]);
    te_app_key(&app, GLFW_KEY_D, GLFW_PRESS, 0);
    assert_true(app.message_error);
    assert_non_null(strstr(app.message, "outer"));
    const double at[2] = {0.5, 0.2};
    te_app_uv_to_px(&app, at, px);
    te_app_cursor(&app, px[0], px[1]);
    te_app_key(&app, GLFW_KEY_C, GLFW_PRESS, 0);
    assert_false(app.message_error);
    assert_int_equal(crisp_trimedit_face(app.ed)->loop_count, 4);
    double on[2] = {0.5 + 0.05, 0.2};
    te_app_uv_to_px(&app, on, px);
    te_app_cursor(&app, px[0], px[1]);
    te_app_key(&app, GLFW_KEY_D, GLFW_PRESS, 0);
    assert_false(app.message_error);
    assert_int_equal(crisp_trimedit_face(app.ed)->loop_count, 3);
    te_app_key(&app, GLFW_KEY_Z, GLFW_PRESS, GLFW_MOD_CONTROL);
    assert_int_equal(crisp_trimedit_face(app.ed)->loop_count, 4);
    /* Every state renders. */
    assert_int_equal(te_app_update(&app), CRISP_OK);
    /* The 2D view: scan lines of the table, at least one per strip that has rows. */
    counts n = {0, 0, {0, 0}, {0, 0}};
    te_draw d = {.ctx = &n, .line = count_line, .circle = count_circle};
    long scan = te_app_draw_2d(&app, &d);
    const crisp_plan_face *pf = &app.plan->faces[0];
    assert_true(pf->strip_count > 0);
    assert_true(scan >= (long)pf->strip_count / 2);
    assert_true(n.lines > scan && n.circles > 20);
    /* Zoomed in 20x at the centre of the 2D view: everything drawn stays inside the view. */
    const double mid[2] = {app.view2d.x + 0.5 * app.view2d.w, app.view2d.y + 0.5 * app.view2d.h};
    te_app_cursor(&app, mid[0], mid[1]);
    te_app_scroll(&app, 16.4);
    counts z = {0, 0, {0, 0}, {0, 0}};
    d.ctx = &z;
    (void)te_app_draw_2d(&app, &d);
    assert_true(z.lines > 0);
    assert_true(z.lo[0] >= app.view2d.x - 1e-9 && z.hi[0] <= app.view2d.x + app.view2d.w + 1e-9);
    assert_true(z.lo[1] >= app.view2d.y - 1e-9 && z.hi[1] <= app.view2d.y + app.view2d.h + 1e-9);
    te_app_close(&app);
}

static void test_drag_in_3d(void **state)
{
    (void)state;
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    crisp_trimedit_ref pt = {1, 0, 0};
    double uv[2], px[2], got[2];
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, NULL), CRISP_OK);
    assert_true(te_app_uv_to_px3d(&app, uv, px));
    te_app_cursor(&app, px[0], px[1]);
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0);
    assert_int_equal(app.drag, TE_DRAG_POINT_3D);
    const double target[2] = {uv[0] - 0.05, uv[1] + 0.03};
    double tp[2];
    assert_true(te_app_uv_to_px3d(&app, target, tp));
    te_app_cursor(&app, tp[0], tp[1]);
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0);
    assert_int_equal(crisp_trimedit_point(app.ed, pt, got, NULL), CRISP_OK);
    /* The ray through the pixel position of S(target) hits the surface at target. */
    assert_true(fabs(got[0] - target[0]) < 1e-6 && fabs(got[1] - target[1]) < 1e-6);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    te_app_close(&app);
}

/* A face of a real model: other faces keep their plan while the edited one is re-planned; 'o'
 * over the 3D view opens the face under the cursor. */
static void test_model_face(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_model_load(CRISP_DATA_DIR "/nurbs/occt_hammer.iges", NULL, &m),
                     CRISP_OK);
    int face = -1;
    for (int f = 0; f < m->face_count && face < 0; f++)
        if (m->faces[f].loop_count > 1) face = f;
    assert_true(face >= 0);
    te_app app;
    assert_int_equal(te_app_open(&app, m, face, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    /* Look at the whole model so other faces are visible. */
    crisp_camera cam;
    assert_int_equal(
        crisp_camera_frame_box(app.scene->box, (int)app.view3d.w, (int)app.view3d.h, &cam),
        CRISP_OK);
    te_app_set_camera(&app, &cam);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    uint64_t leaves = app.plan->leaves_version;
    /* Crossings of every other visible face before the edit. */
    uint32_t other = UINT32_MAX;
    for (uint32_t f = 0; f < app.plan->face_count && other == UINT32_MAX; f++)
        if ((int)f != face && app.plan->faces[f].strip_count > 0 &&
            !(app.plan->faces[f].flags & CRISP_PLAN_FACE_ALL_INSIDE))
            other = f;
    assert_true(other != UINT32_MAX);
    double probe[64];
    const crisp_scene_face *of = &app.scene->faces[other];
    double d[4];
    memcpy(d, of->domain, sizeof d);
    for (int k = 0; k < 64; k++)
        probe[k] = crisp_plan_trim_test(app.plan, other, d[0] + (d[1] - d[0]) * (k % 8 + 0.5) / 8,
                                        d[2] + (d[3] - d[2]) * (k / 8 + 0.5) / 8);
    /* Move a point of the face's first hole a little (through the edit model). */
    crisp_trimedit_ref r = {1, 0, 0};
    double uv[2];
    assert_int_equal(crisp_trimedit_point(app.ed, r, uv, NULL), CRISP_OK);
    double dom[4];
    crisp_trimedit_domain(app.ed, dom);
    uv[0] += 0.01 * (dom[1] - dom[0]);
    assert_int_equal(crisp_trimedit_move_point(app.ed, &r, uv, 0), CRISP_OK);
    long before = app.replans;
    assert_int_equal(te_app_update(&app), CRISP_OK);
    assert_int_equal(app.replans, before + 1);
    assert_true(app.plan->leaves_version == leaves);
    for (int k = 0; k < 64; k++)
        assert_true(probe[k] == crisp_plan_trim_test(app.plan, other,
                                                     d[0] + (d[1] - d[0]) * (k % 8 + 0.5) / 8,
                                                     d[2] + (d[3] - d[2]) * (k / 8 + 0.5) / 8));
    /* 'o' on a pixel of another face opens it. */
    crisp_image img;
    crisp_renderer *rr;
    assert_int_equal(crisp_image_init(&img, app.cam.width, app.cam.height), CRISP_OK);
    assert_int_equal(crisp_renderer_create(NULL, &rr), CRISP_OK);
    assert_int_equal(crisp_render_cpu_plan(rr, app.scene, app.plan, &app.cam, &img, NULL),
                     CRISP_OK);
    int px = -1;
    for (int y = 2; y < img.height - 2 && px < 0; y += 3)
        for (int x = 2; x < img.width - 2; x += 3) {
            int32_t f = img.face[(size_t)y * img.width + x];
            int same = 1;
            for (int dy = -2; dy <= 2; dy++)
                for (int dx = -2; dx <= 2; dx++)
                    same &= img.face[(size_t)(y + dy) * img.width + x + dx] == f;
            if (f >= 0 && f != face && same) {
                px = y * img.width + x;
                break;
            }
        }
    assert_true(px >= 0);
    int want = img.face[px];
    te_app_cursor(&app, app.view3d.x + px % img.width + 0.5, app.view3d.y + px / img.width + 0.5);
    te_app_key(&app, GLFW_KEY_O, GLFW_PRESS, 0);
    assert_false(app.message_error);
    assert_int_equal(app.face, want);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    crisp_renderer_destroy(rr);
    crisp_image_free(&img);
    te_app_close(&app);
}

/* Pixels of b that differ from a (colour, depth, face, (u, v), normal, bit for bit), counted
 * apart where the edited face has an edge within 2 px (a pixel of the 5 x 5 square around it is
 * the face's and another is not, in either image). */
static void compare_frames(const crisp_image *a, const crisp_image *b, int face, long *compared,
                           long *differ, long *differ_at_edges)
{
    int w = a->width, h = a->height;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            int in = 0, out = 0;
            for (int dy = -2; dy <= 2; dy++)
                for (int dx = -2; dx <= 2; dx++) {
                    int xx = x + dx, yy = y + dy;
                    if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
                    size_t q = (size_t)yy * w + xx;
                    in |= a->face[q] == face || b->face[q] == face;
                    out |= a->face[q] != face || b->face[q] != face;
                }
            int same = !memcmp(a->rgba + 4 * p, b->rgba + 4 * p, 4 * sizeof(float)) &&
                       !memcmp(a->normal + 3 * p, b->normal + 3 * p, 3 * sizeof(float)) &&
                       !memcmp(a->uv + 2 * p, b->uv + 2 * p, 2 * sizeof(float)) &&
                       !memcmp(a->depth + p, b->depth + p, sizeof(float)) &&
                       a->face[p] == b->face[p];
            if (in && out) {
                *differ_at_edges += !same;
                continue;
            }
            ++*compared;
            *differ += !same;
        }
}

/* Every frame of a replayed drag (60 frames of cursor events in the 2D view), te_app_draw_cpu
 * (the edited face alone drawn over the other faces' image) equals a full render of the same
 * plan away from the edited face's edges; releasing the button draws the whole again. */
static void partial_vs_full(te_app *app, crisp_trimedit_ref pt, double amp_px, const char *name)
{
    crisp_renderer *r1, *r2;
    assert_int_equal(crisp_renderer_create(NULL, &r1), CRISP_OK);
    assert_int_equal(crisp_renderer_create(NULL, &r2), CRISP_OK);
    crisp_image img, whole;
    assert_int_equal(crisp_image_init(&img, app->cam.width, app->cam.height), CRISP_OK);
    assert_int_equal(crisp_image_init(&whole, app->cam.width, app->cam.height), CRISP_OK);
    double uv0[2], px0[2];
    assert_int_equal(crisp_trimedit_point(app->ed, pt, uv0, NULL), CRISP_OK);
    te_app_uv_to_px(app, uv0, px0);
    te_app_cursor(app, px0[0], px0[1]);
    te_app_button(app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0);
    assert_true(te_app_editing(app));
    long compared = 0, differ = 0, at_edges = 0, face_min = -1, face_max = 0;
    for (int k = 1; k <= 60; k++) {
        double a = 2 * M_PI * k / 60;
        te_app_cursor(app, px0[0] + amp_px * sin(a), px0[1] - amp_px * (1 - cos(a)));
        assert_int_equal(te_app_update(app), CRISP_OK);
        assert_int_equal(te_app_draw_cpu(app, r1, &img), CRISP_OK);
        assert_true(app->last_partial);
        assert_int_equal(crisp_render_cpu_plan(r2, app->scene, app->plan, &app->cam, &whole, NULL),
                         CRISP_OK);
        compare_frames(&whole, &img, app->face, &compared, &differ, &at_edges);
        long n = 0;
        for (size_t p = 0; p < (size_t)whole.width * whole.height; p++)
            n += whole.face[p] == app->face;
        face_min = face_min < 0 || n < face_min ? n : face_min;
        face_max = n > face_max ? n : face_max;
    }
    print_message("%s: 60 frames drawn as the edited face over the others: %ld pixels away from "
                  "its edges compared with a full render, %ld differ; %ld differ within 2 px of "
                  "its edges; the face covers %ld..%ld pixels\n",
                  name, compared, differ, at_edges, face_min, face_max);
    assert_int_equal(differ, 0);
    assert_true(face_min > 200 && face_max > face_min); /* seen, and the drag changed it */
    /* The end of the drag draws the whole plan again: equal everywhere. */
    te_app_button(app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0);
    assert_int_equal(te_app_update(app), CRISP_OK);
    assert_int_equal(te_app_draw_cpu(app, r1, &img), CRISP_OK);
    assert_false(app->last_partial);
    assert_int_equal(crisp_render_cpu_plan(r2, app->scene, app->plan, &app->cam, &whole, NULL),
                     CRISP_OK);
    long c2 = 0, d2 = 0, e2 = 0;
    compare_frames(&whole, &img, app->face, &c2, &d2, &e2);
    assert_int_equal(d2 + e2, 0);
    crisp_image_free(&img);
    crisp_image_free(&whole);
    crisp_renderer_destroy(r1);
    crisp_renderer_destroy(r2);
}

static void test_partial_redraw(void **state)
{
    (void)state;
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    partial_vs_full(&app, (crisp_trimedit_ref){0, 0, 3}, 30, "built-in example");
    te_app_close(&app);
    /* A face of a real model among its neighbours: the hammer's first face with a hole, the
     * whole model in view. */
    crisp_model *m;
    assert_int_equal(crisp_model_load(CRISP_DATA_DIR "/nurbs/occt_hammer.iges", NULL, &m),
                     CRISP_OK);
    int face = -1;
    for (int f = 0; f < m->face_count && face < 0; f++)
        if (m->faces[f].loop_count > 1) face = f;
    assert_true(face >= 0);
    assert_int_equal(te_app_open(&app, m, face, 2 * W, H), CRISP_OK);
    crisp_camera cam;
    assert_int_equal(
        crisp_camera_frame_box(app.scene->box, (int)app.view3d.w, (int)app.view3d.h, &cam),
        CRISP_OK);
    te_app_set_camera(&app, &cam);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    /* Of the faces with a hole, the one that covers the most pixels with its surface's box
     * framed (the face and its neighbours in view). */
    crisp_renderer *r;
    crisp_image img;
    assert_int_equal(crisp_renderer_create(NULL, &r), CRISP_OK);
    assert_int_equal(crisp_image_init(&img, app.cam.width, app.cam.height), CRISP_OK);
    long best = -1;
    crisp_camera best_cam = app.cam;
    for (int f = 0; f < m->face_count; f++) {
        if (m->faces[f].loop_count < 2) continue;
        double box[6];
        crisp_surface_bbox(m->faces[f].surface, box);
        assert_int_equal(crisp_camera_frame_box(box, img.width, img.height, &cam), CRISP_OK);
        assert_int_equal(crisp_render_cpu(r, app.scene, &cam, &img, NULL), CRISP_OK);
        long n = 0;
        for (size_t p = 0; p < (size_t)img.width * img.height; p++)
            n += img.face[p] == f;
        if (n > best) best = n, face = f, best_cam = cam;
    }
    crisp_image_free(&img);
    crisp_renderer_destroy(r);
    assert_int_equal(te_app_open_face(&app, face), CRISP_OK);
    te_app_set_camera(&app, &best_cam);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    char name[64];
    snprintf(name, sizeof name, "hammer face %d", face);
    partial_vs_full(&app, (crisp_trimedit_ref){1, 0, 0}, 20, name);
    te_app_close(&app);
}

static void key(te_app *app, int k)
{
    te_app_key(app, k, GLFW_PRESS, 0);
    te_app_key(app, k, GLFW_RELEASE, 0);
}

static void click_uv(te_app *app, const double uv[2])
{
    double px[2];
    te_app_uv_to_px(app, uv, px);
    te_app_cursor(app, px[0], px[1]);
    te_app_button(app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0);
    te_app_button(app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0);
}

/* The weight field: a pressed control point is selected, w opens the field, typed keys make
 * the weight, enter sets it exactly; a weight of 0, a negative one or text that is no number is
 * refused with a message and changes nothing; while the field is open the keys do not edit. */
static void test_weight_field(void **state)
{
    (void)state;
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    const crisp_trimedit_ref pt = {1, 0, 1}; /* a point of the circle hole (rational) */
    double uv[2], w0, w;
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, &w0), CRISP_OK);
    assert_true(crisp_trimedit_face(app.ed)->loops[1].curves[0]->rational);
    click_uv(&app, uv);
    assert_true(te_app_selected(&app, NULL, NULL));
    assert_memory_equal(&app.sel, &pt, sizeof pt);
    te_app_cursor(&app, app.view2d.x + 2, app.view2d.y + 2); /* away: the selection is used */
    key(&app, GLFW_KEY_W);
    assert_true(app.entry);
    int count = crisp_trimedit_face(app.ed)->loops[1].curves[0]->count;
    static const int k25[] = {GLFW_KEY_2, GLFW_KEY_PERIOD, GLFW_KEY_5, GLFW_KEY_X, GLFW_KEY_ENTER};
    for (int i = 0; i < 5; i++)
        key(&app, k25[i]); /* x is no part of a number and deletes nothing here */
    assert_false(app.entry);
    assert_false(app.message_error);
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, &w), CRISP_OK);
    assert_true(w == 2.5);
    assert_int_equal(crisp_trimedit_face(app.ed)->loops[1].curves[0]->count, count);
    /* Refused: 0, -1, "e" (no number); the field stays open with the message. */
    static const int bad[3][3] = {{GLFW_KEY_0, GLFW_KEY_ENTER, 0},
                                  {GLFW_KEY_MINUS, GLFW_KEY_1, GLFW_KEY_ENTER},
                                  {GLFW_KEY_E, GLFW_KEY_ENTER, 0}};
    for (int b = 0; b < 3; b++) {
        uint64_t v = crisp_trimedit_version(app.ed);
        key(&app, GLFW_KEY_W);
        for (int i = 0; i < 3 && bad[b][i]; i++)
            key(&app, bad[b][i]);
        assert_true(app.message_error);
        assert_non_null(strstr(app.message, "refused"));
        assert_non_null(strstr(app.message, "weight"));
        assert_true(app.entry);
        assert_true(crisp_trimedit_version(app.ed) == v);
        key(&app, GLFW_KEY_ESCAPE);
        assert_false(app.entry);
    }
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, &w), CRISP_OK);
    assert_true(w == 2.5);
    /* Backspace edits the text: "31", backspace, enter sets 3. */
    key(&app, GLFW_KEY_W);
    key(&app, GLFW_KEY_3);
    key(&app, GLFW_KEY_1);
    key(&app, GLFW_KEY_BACKSPACE);
    key(&app, GLFW_KEY_ENTER);
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, &w), CRISP_OK);
    assert_true(w == 3.0);
    /* Undo twice: the weight as it was. */
    te_app_key(&app, GLFW_KEY_Z, GLFW_PRESS, GLFW_MOD_CONTROL);
    te_app_key(&app, GLFW_KEY_Z, GLFW_PRESS, GLFW_MOD_CONTROL);
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, &w), CRISP_OK);
    assert_true(w == w0);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    te_app_close(&app);
}

/* A polygon hole drawn by clicks in the 2D view: n, four corners, a click on the first one
 * closes it; a hole with its corners exactly at the clicked (u, v), clockwise. Fewer than 3
 * corners are refused; backspace removes a corner; escape cancels. */
static void test_polygon_clicks(void **state)
{
    (void)state;
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    int loops = crisp_trimedit_face(app.ed)->loop_count;
    const double c[4][2] = {{0.55, 0.62}, {0.7, 0.6}, {0.72, 0.75}, {0.56, 0.72}};
    double want[4][2], px[2];
    key(&app, GLFW_KEY_N);
    assert_true(app.poly);
    click_uv(&app, c[0]);
    click_uv(&app, c[2]); /* a wrong corner, taken back */
    key(&app, GLFW_KEY_BACKSPACE);
    for (int k = 1; k < 4; k++)
        click_uv(&app, c[k]);
    assert_int_equal(app.poly_n, 4);
    for (int k = 0; k < 4; k++) {
        te_app_uv_to_px(&app, c[k], px);
        te_app_px_to_uv(&app, px, want[k]);
    }
    te_app_uv_to_px(&app, want[0], px);
    te_app_cursor(&app, px[0] + 2, px[1] - 1); /* near the first corner: closes */
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0);
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0);
    assert_false(app.poly);
    assert_false(app.message_error);
    const crisp_face *f = crisp_trimedit_face(app.ed);
    assert_int_equal(f->loop_count, loops + 1);
    const crisp_trim_loop *L = &f->loops[loops];
    assert_false(L->is_outer);
    int corners = 0, found[4] = {0, 0, 0, 0};
    double area = 0;
    for (int cv = 0; cv < L->curve_count; cv++) {
        assert_int_equal(L->curves[cv]->degree, 1);
        for (int i = 0; i + 1 < L->curves[cv]->count; i++) {
            double q[2], q2[2];
            assert_int_equal(
                crisp_trimedit_point(app.ed, (crisp_trimedit_ref){loops, cv, i}, q, NULL),
                CRISP_OK);
            assert_int_equal(
                crisp_trimedit_point(app.ed, (crisp_trimedit_ref){loops, cv, i + 1}, q2, NULL),
                CRISP_OK);
            area += q[0] * q2[1] - q2[0] * q[1];
            corners++;
            for (int k = 0; k < 4; k++)
                found[k] |= q[0] == want[k][0] && q[1] == want[k][1];
        }
    }
    assert_int_equal(corners, 4);
    assert_true(found[0] && found[1] && found[2] && found[3]);
    assert_true(area < 0); /* a hole: clockwise */
    /* Two corners and enter: refused. One corner and escape: nothing. */
    key(&app, GLFW_KEY_N);
    click_uv(&app, c[0]);
    click_uv(&app, c[1]);
    key(&app, GLFW_KEY_ENTER);
    assert_true(app.message_error);
    assert_non_null(strstr(app.message, "3 corners"));
    key(&app, GLFW_KEY_N);
    click_uv(&app, c[0]);
    key(&app, GLFW_KEY_ESCAPE);
    assert_false(app.poly);
    assert_int_equal(crisp_trimedit_face(app.ed)->loop_count, loops + 1);
    /* A polygon leaving the domain is refused and changes nothing. */
    const double out[3][2] = {{0.9, 0.4}, {1.05, 0.5}, {0.9, 0.6}};
    key(&app, GLFW_KEY_N);
    for (int k = 0; k < 3; k++)
        click_uv(&app, out[k]);
    assert_int_equal(app.poly_n, 3);
    key(&app, GLFW_KEY_ENTER);
    assert_true(app.message_error);
    assert_int_equal(crisp_trimedit_face(app.ed)->loop_count, loops + 1);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    te_app_close(&app);
}

/* Loop transforms from the 3D view: shift-drag near the circle hole's image moves the loop by
 * the (u, v) between the surface points under the cursor; ctrl-drag rotates it about its centre
 * (distances to the centre kept); alt-drag scales it (all by one factor). */
static void test_loop_3d(void **state)
{
    (void)state;
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    const int l = 1;
    const crisp_curve *cv = crisp_trimedit_face(app.ed)->loops[l].curves[0];
    int n = cv->count;
    double before[64][2], after[64][2], on[2], t0, t1, px[2];
    assert_true(n <= 64);
    for (int i = 0; i < n; i++)
        crisp_trimedit_point(app.ed, (crisp_trimedit_ref){l, 0, i}, before[i], NULL);
    crisp_curve_domain(cv, &t0, &t1);
    crisp_curve_eval(cv, t0 + 0.3 * (t1 - t0), on);
    assert_true(te_app_uv_to_px3d(&app, on, px));
    /* Move: press on the curve's image, release 15 px to the right. */
    te_app_cursor(&app, px[0], px[1]);
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, GLFW_MOD_SHIFT);
    assert_int_equal(app.drag, TE_DRAG_MOVE);
    double start[2] = {app.drag_last[0], app.drag_last[1]};
    assert_true(fabs(start[0] - on[0]) < 1e-3 && fabs(start[1] - on[1]) < 1e-3);
    for (int k = 1; k <= 15; k++)
        te_app_cursor(&app, px[0] + k, px[1]);
    double end[2] = {app.drag_last[0], app.drag_last[1]};
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, GLFW_MOD_SHIFT);
    assert_true(hypot(end[0] - start[0], end[1] - start[1]) > 1e-3);
    cv = crisp_trimedit_face(app.ed)->loops[l].curves[0];
    for (int i = 0; i < n; i++) {
        crisp_trimedit_point(app.ed, (crisp_trimedit_ref){l, 0, i}, after[i], NULL);
        assert_true(fabs(after[i][0] - before[i][0] - (end[0] - start[0])) < 1e-9);
        assert_true(fabs(after[i][1] - before[i][1] - (end[1] - start[1])) < 1e-9);
    }
    /* Rotate and scale about the loop's centre. */
    for (int mode = 0; mode < 2; mode++) {
        double c[2], pre[64][2];
        crisp_trimedit_loop_center(app.ed, l, c);
        for (int i = 0; i < n; i++)
            crisp_trimedit_point(app.ed, (crisp_trimedit_ref){l, 0, i}, pre[i], NULL);
        cv = crisp_trimedit_face(app.ed)->loops[l].curves[0];
        crisp_curve_eval(cv, t0 + 0.3 * (t1 - t0), on);
        assert_true(te_app_uv_to_px3d(&app, on, px));
        int mods = mode ? GLFW_MOD_ALT : GLFW_MOD_CONTROL;
        te_app_cursor(&app, px[0], px[1]);
        te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, mods);
        assert_int_equal(app.drag, mode ? TE_DRAG_SCALE : TE_DRAG_ROTATE);
        for (int k = 1; k <= 10; k++)
            te_app_cursor(&app, px[0] + 0.6 * k, px[1] + 0.9 * k);
        te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, mods);
        double ratio = -1, moved = 0;
        for (int i = 0; i < n; i++) {
            double q[2];
            crisp_trimedit_point(app.ed, (crisp_trimedit_ref){l, 0, i}, q, NULL);
            double r0 = hypot(pre[i][0] - c[0], pre[i][1] - c[1]),
                   r1 = hypot(q[0] - c[0], q[1] - c[1]);
            if (ratio < 0) ratio = r1 / r0;
            assert_true(fabs(r1 / r0 - ratio) < 1e-9);
            moved = fmax(moved, hypot(q[0] - pre[i][0], q[1] - pre[i][1]));
        }
        assert_true(moved > 1e-3);
        if (!mode)
            assert_true(fabs(ratio - 1) < 1e-9); /* rotation keeps distances */
        else
            assert_true(fabs(ratio - 1) > 1e-3);
    }
    /* Three steps of history: undo them all. */
    for (int k = 0; k < 3; k++)
        te_app_key(&app, GLFW_KEY_Z, GLFW_PRESS, GLFW_MOD_CONTROL);
    for (int i = 0; i < n; i++) {
        double q[2];
        crisp_trimedit_point(app.ed, (crisp_trimedit_ref){l, 0, i}, q, NULL);
        assert_true(q[0] == before[i][0] && q[1] == before[i][1]);
    }
    assert_int_equal(te_app_update(&app), CRISP_OK);
    te_app_close(&app);
}

/* Loop transforms in the 2D view (shift-drag moves the loop by exactly the (u, v) between the
 * cursor positions, ctrl-drag rotates and alt-drag scales it about its centre), snap while
 * dragging (g: a point dragged near the domain edge lands on it), and the panel's figures (the
 * edited face's plan time) after a re-plan. */
static void test_loop_2d_and_snap(void **state)
{
    (void)state;
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    const int l = 2; /* the rectangle hole */
    const crisp_curve *cv = crisp_trimedit_face(app.ed)->loops[l].curves[0];
    int n = cv->count;
    double before[16][2], on[2], t0, t1, px[2], a[2], b[2];
    assert_true(n <= 16);
    for (int i = 0; i < n; i++)
        crisp_trimedit_point(app.ed, (crisp_trimedit_ref){l, 0, i}, before[i], NULL);
    crisp_curve_domain(cv, &t0, &t1);
    crisp_curve_eval(cv, t0 + 0.1 * (t1 - t0), on);
    te_app_uv_to_px(&app, on, px);
    te_app_cursor(&app, px[0], px[1]);
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, GLFW_MOD_SHIFT);
    assert_int_equal(app.drag, TE_DRAG_MOVE);
    for (int k = 1; k <= 12; k++)
        te_app_cursor(&app, px[0] - k, px[1] + 0.5 * k);
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, GLFW_MOD_SHIFT);
    te_app_px_to_uv(&app, px, a);
    te_app_px_to_uv(&app, (double[2]){px[0] - 12, px[1] + 6}, b);
    for (int i = 0; i < n; i++) {
        double q[2];
        crisp_trimedit_point(app.ed, (crisp_trimedit_ref){l, 0, i}, q, NULL);
        assert_true(fabs(q[0] - before[i][0] - (b[0] - a[0])) < 1e-12);
        assert_true(fabs(q[1] - before[i][1] - (b[1] - a[1])) < 1e-12);
    }
    for (int mode = 0; mode < 2; mode++) {
        double c[2], pre[16][2];
        crisp_trimedit_loop_center(app.ed, l, c);
        for (int i = 0; i < n; i++)
            crisp_trimedit_point(app.ed, (crisp_trimedit_ref){l, 0, i}, pre[i], NULL);
        cv = crisp_trimedit_face(app.ed)->loops[l].curves[0];
        crisp_curve_eval(cv, t0 + 0.1 * (t1 - t0), on);
        te_app_uv_to_px(&app, on, px);
        int mods = mode ? GLFW_MOD_ALT : GLFW_MOD_CONTROL;
        te_app_cursor(&app, px[0], px[1]);
        te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, mods);
        assert_int_equal(app.drag, mode ? TE_DRAG_SCALE : TE_DRAG_ROTATE);
        for (int k = 1; k <= 8; k++)
            te_app_cursor(&app, px[0] + 0.7 * k, px[1] + 0.4 * k);
        te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, mods);
        double ratio = -1, moved = 0;
        for (int i = 0; i < n; i++) {
            double q[2];
            crisp_trimedit_point(app.ed, (crisp_trimedit_ref){l, 0, i}, q, NULL);
            double r0 = hypot(pre[i][0] - c[0], pre[i][1] - c[1]),
                   r1 = hypot(q[0] - c[0], q[1] - c[1]);
            if (ratio < 0) ratio = r1 / r0;
            assert_true(fabs(r1 / r0 - ratio) < 1e-9);
            moved = fmax(moved, hypot(q[0] - pre[i][0], q[1] - pre[i][1]));
        }
        assert_true(moved > 1e-3);
        if (!mode)
            assert_true(fabs(ratio - 1) < 1e-9);
        else
            assert_true(fabs(ratio - 1) > 1e-3);
    }
    /* Snap while dragging: the outer loop's point 3 dragged to 3 px inside the u = 1 edge. */
    key(&app, GLFW_KEY_G);
    assert_true(app.snap);
    const crisp_trimedit_ref pt = {0, 0, 3};
    double uv[2];
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, NULL), CRISP_OK);
    te_app_uv_to_px(&app, uv, px);
    te_app_cursor(&app, px[0], px[1]);
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_PRESS, 0);
    double edge[2] = {1.0, uv[1]};
    te_app_uv_to_px(&app, edge, px);
    te_app_cursor(&app, px[0] - 3, px[1]);
    te_app_button(&app, GLFW_MOUSE_BUTTON_LEFT, GLFW_RELEASE, 0);
    assert_int_equal(crisp_trimedit_point(app.ed, pt, uv, NULL), CRISP_OK);
    assert_true(uv[0] == 1.0);
    /* The re-plan of the edited face is timed (the panel shows it). */
    long replans = app.replans;
    assert_int_equal(te_app_update(&app), CRISP_OK);
    assert_int_equal(app.replans, replans + 1);
    assert_true(app.ms_face_plan > 0);
    te_app_close(&app);
}

static double rnd(unsigned *s)
{
    *s = *s * 1103515245u + 12345u;
    return (double)((*s >> 8) & 0xffffff) / 16777216.0;
}

/* Random input never leaves a face the planner or the writer rejects. */
static void test_random_input(void **state)
{
    (void)state;
    te_app app;
    assert_int_equal(te_app_open(&app, NULL, -1, 2 * W, H), CRISP_OK);
    assert_int_equal(te_app_update(&app), CRISP_OK);
    static const int keys[] = {GLFW_KEY_I, GLFW_KEY_K, GLFW_KEY_X, GLFW_KEY_EQUAL, GLFW_KEY_MINUS,
                               GLFW_KEY_0, GLFW_KEY_B, GLFW_KEY_G, GLFW_KEY_C,     GLFW_KEY_R,
                               GLFW_KEY_P, GLFW_KEY_D, GLFW_KEY_S, GLFW_KEY_L,     GLFW_KEY_F,
                               GLFW_KEY_Z, GLFW_KEY_Y};
    static const int mods[] = {0, GLFW_MOD_SHIFT, GLFW_MOD_CONTROL, GLFW_MOD_ALT,
                               GLFW_MOD_CONTROL | GLFW_MOD_SHIFT};
    unsigned seed = 7;
    counts n = {0, 0, {0, 0}, {0, 0}};
    te_draw d = {.ctx = &n, .line = count_line, .circle = count_circle};
    for (int it = 0; it < 3000; it++) {
        double a = rnd(&seed);
        double x = rnd(&seed) * 2 * W, y = rnd(&seed) * H;
        if (a < 0.5) {
            te_app_cursor(&app, x, y);
        } else if (a < 0.7) {
            int b = rnd(&seed) < 0.8 ? GLFW_MOUSE_BUTTON_LEFT : GLFW_MOUSE_BUTTON_RIGHT;
            te_app_button(&app, b, rnd(&seed) < 0.5 ? GLFW_PRESS : GLFW_RELEASE,
                          mods[(int)(rnd(&seed) * 4)]);
        } else if (a < 0.75) {
            te_app_scroll(&app, rnd(&seed) * 4 - 2);
        } else {
            te_app_key(&app, keys[(int)(rnd(&seed) * 17)], GLFW_PRESS, mods[(int)(rnd(&seed) * 5)]);
        }
        if (it % 10 == 0) {
            assert_int_equal(te_app_update(&app), CRISP_OK);
            (void)te_app_draw_2d(&app, &d);
        }
    }
    char obj[256];
    tmp(obj, ".obj");
    assert_int_equal(te_app_save(&app, obj), CRISP_OK);
    crisp_model *back;
    assert_int_equal(crisp_model_load(obj, NULL, &back), CRISP_OK);
    crisp_model_destroy(back);
    remove(obj);
    te_app_close(&app);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_drag_undo_redo_save),
        cmocka_unit_test(test_refused_edits),
        cmocka_unit_test(test_drag_in_3d),
        cmocka_unit_test(test_model_face),
        cmocka_unit_test(test_random_input),
        cmocka_unit_test(test_partial_redraw),
        cmocka_unit_test(test_weight_field),
        cmocka_unit_test(test_polygon_clicks),
        cmocka_unit_test(test_loop_3d),
        cmocka_unit_test(test_loop_2d_and_snap),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
