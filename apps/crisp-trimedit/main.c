/* crisp-trimedit: the trim-editing demo (issue 11). A window with two linked views, the trimmed
 * face in 3D (left) and its (u, v) domain in 2D (right), on the apps' shared infrastructure
 * (apps/common: GLFW window, Dear ImGui, event replay, camera navigation). Every frame after an
 * edit only the edited face is re-planned (te_app.c) and the 3D view is drawn from the plan by
 * the GL backend, or by the CPU backend (--cpu, or where crisp is built without GL), which during
 * a drag draws only the edited face over an image of the other faces. README.md "crisp-trimedit".
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/image.h"
#include "crisp/io.h"
#include "events.h"
#include "nav.h"
#include "te_app.h"
#include "ui.h"
#include "window.h"
#ifdef CRISP_TRIMEDIT_GL
#include "crisp/gl.h"
#endif

static const char usage[] =
    "usage: crisp-trimedit [MODEL --face N] [--size WxH] [--replay EVENTS] [--screenshot OUT.png]\n"
    "                      [--save OUT.obj] [--exit-after-replay] [--no-vsync] [--cpu]\n"
    "  MODEL --face N: edit face N of a model crisp reads (IGES, STEP, OBJ); without MODEL the\n"
    "                  built-in example (a bicubic surface with an outer loop and two holes)\n"
    "  --replay EVENTS: play a replay file (the format of crisp-view, README.md)\n"
    "  --screenshot OUT.png: after the replay, write the 3D view rendered off-screen\n"
    "  --save OUT.obj: after the replay, save the model (OBJ free-form); ctrl+s saves there too\n"
    "  --exit-after-replay: quit once the replay, screenshot and save are done\n"
    "  --cpu: draw the 3D view with the CPU backend (during a drag only the edited face is drawn,\n"
    "         over an image of the other faces); the GL backend otherwise, where it is built\n"
    "  Keys: F1 for the list.\n";

static const char help[] =
    "2D view: drag a control point (g: snap to the domain edge); shift-drag moves a loop,\n"
    "ctrl-drag rotates it, alt-drag scales it; right-drag pans, wheel zooms.\n"
    "3D view: drag a control point on the surface; shift-, ctrl-, alt-drag near a loop moves,\n"
    "rotates, scales it on the surface; right-drag orbits, middle-drag pans, wheel zooms; o opens\n"
    "the face under the cursor.\n"
    "w: weight field of the selected point (type, enter sets, escape closes); n: polygon hole by\n"
    "clicks in the 2D view (enter or the first corner closes, backspace, escape cancels).\n"
    "i insert knot, k remove knot, x delete point, = / - weight, 0 weight 0 (refused),\n"
    "b snap point to the edge, c / r / p add a circle / rectangle / hexagon hole, d delete hole,\n"
    "ctrl+z undo, ctrl+y redo, ctrl+s save, s strips, l scan lines, f fit, F1 help.";

typedef struct te_window {
    GLFWwindow *win;
    int fb_w, fb_h;
    te_app app;
    app_nav nav;
    int nav_drag; /* 0 none, 1 orbit, 2 pan (3D view) */
    double last_x, last_y, pivot[3];
    app_player player;
    int replaying, exit_after_replay, quit, exit_code, show_help;
#ifdef CRISP_TRIMEDIT_GL
    crisp_gl *gl;
#endif
    int use_cpu; /* the CPU backend draws the 3D view (--cpu, or crisp built without GL) */
    crisp_renderer *renderer;
    crisp_image img;
    app_image_view iv;
    uint8_t *rgba;
    double ms_draw;
} te_window;

static void set_camera_from_nav(te_window *w)
{
    app_nav_update_clip(&w->nav);
    te_app_set_camera(&w->app, &w->nav.cam);
}

/* ---- input: the window's events and the replay take this path ---------------------------------
 */

static int over_3d(te_window *w)
{
    const te_rect *r = &w->app.view3d;
    return w->app.cursor[0] >= r->x && w->app.cursor[0] < r->x + r->w && w->app.cursor[1] >= r->y &&
           w->app.cursor[1] < r->y + r->h;
}

static void on_cursor(te_window *w, double x, double y)
{
    double dx = x - w->last_x, dy = y - w->last_y;
    w->last_x = x;
    w->last_y = y;
    te_app_cursor(&w->app, x, y);
    if (w->nav_drag == 1) {
        app_nav_orbit(&w->nav, w->pivot, dx, dy);
        set_camera_from_nav(w);
    } else if (w->nav_drag == 2) {
        app_nav_pan(&w->nav, app_nav_depth(&w->nav.cam, w->pivot), dx, dy);
        set_camera_from_nav(w);
    }
}

static void on_button(te_window *w, int button, int action, int mods)
{
    if (action == GLFW_RELEASE) w->nav_drag = 0;
    if (action == GLFW_PRESS && over_3d(w) && button != GLFW_MOUSE_BUTTON_LEFT) {
        w->nav_drag = button == GLFW_MOUSE_BUTTON_RIGHT ? 1 : 2;
        memcpy(w->pivot, w->nav.cam.target, sizeof w->pivot);
        return;
    }
    te_app_button(&w->app, button, action, mods);
}

static void on_scroll(te_window *w, double dy)
{
    if (over_3d(w)) {
        double p[3];
        app_nav_focus_point(&w->nav, w->app.cursor[0] - w->app.view3d.x,
                            w->app.cursor[1] - w->app.view3d.y, p);
        app_nav_zoom(&w->nav, p, pow(0.85, dy));
        set_camera_from_nav(w);
    } else {
        te_app_scroll(&w->app, dy);
    }
}

static void on_key(te_window *w, int key, int action, int mods)
{
    if (action == GLFW_PRESS && key == GLFW_KEY_F1) {
        w->show_help = !w->show_help;
        return;
    }
    /* Escape closes the weight field or cancels a polygon before it quits. */
    if (action == GLFW_PRESS && key == GLFW_KEY_ESCAPE && !w->app.entry && !w->app.poly) {
        w->quit = 1;
        return;
    }
    te_app_key(&w->app, key, action, mods);
}

static te_window *of(GLFWwindow *g)
{
    return glfwGetWindowUserPointer(g);
}

static void cb_cursor(GLFWwindow *g, double x, double y)
{
    on_cursor(of(g), x, y);
}

static void cb_button(GLFWwindow *g, int b, int a, int m)
{
    app_ui_on_button(g, b, a, m);
    if (a == GLFW_PRESS && app_ui_wants_mouse()) return;
    on_button(of(g), b, a, m);
}

static void cb_scroll(GLFWwindow *g, double dx, double dy)
{
    app_ui_on_scroll(g, dx, dy);
    if (!app_ui_wants_mouse()) on_scroll(of(g), dy);
}

static void cb_key(GLFWwindow *g, int k, int sc, int a, int m)
{
    app_ui_on_key(g, k, sc, a, m);
    if (!app_ui_wants_keyboard()) on_key(of(g), k, a, m);
}

static void cb_char(GLFWwindow *g, unsigned int c)
{
    app_ui_on_char(g, c);
}

static void sink_cursor(void *ctx, double x, double y)
{
    te_window *w = ctx;
    glfwSetCursorPos(w->win, x, y);
    on_cursor(w, x, y);
}

static void sink_button(void *ctx, int b, int a, int m)
{
    on_button(ctx, b, a, m);
}

static void sink_scroll(void *ctx, double dy)
{
    on_scroll(ctx, dy);
}

static void sink_key(void *ctx, int k, int a, int m)
{
    on_key(ctx, k, a, m);
}

static void sink_close(void *ctx)
{
    ((te_window *)ctx)->quit = 1;
}

static int sink_idle(void *ctx)
{
    (void)ctx;
    return 1;
}

/* ---- drawing -----------------------------------------------------------------------------------
 */

static crisp_status draw_3d(te_window *w)
{
    double t = crisp_time_now();
    crisp_status st;
#ifdef CRISP_TRIMEDIT_GL
    if (!w->use_cpu) {
        if ((st = crisp_gl_draw(w->gl, w->app.plan, NULL))) return st;
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glViewport(0, 0, w->fb_w, w->fb_h);
        glClearColor(0.12f, 0.13f, 0.15f, 1);
        glClear(GL_COLOR_BUFFER_BIT);
        st = crisp_gl_blit(w->gl, 0, 0, 0, (int)w->app.view3d.w, (int)w->app.view3d.h);
        w->ms_draw = 1e3 * (crisp_time_now() - t);
        return st;
    }
#endif
    /* The CPU backend: during an edit drag only the edited face is drawn, over the other faces'
     * image (te_app_draw_cpu). */
    const crisp_camera *c = &w->app.cam;
    if (w->img.width != c->width || w->img.height != c->height) {
        crisp_image_free(&w->img);
        if ((st = crisp_image_init(&w->img, c->width, c->height))) return st;
    }
    if ((st = te_app_draw_cpu(&w->app, w->renderer, &w->img))) return st;
    /* The whole window as one image: the 3D view on the left, the 2D view's background right. */
    uint8_t *px = realloc(w->rgba, 4 * (size_t)w->fb_w * w->fb_h);
    if (!px) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the window image");
    w->rgba = px;
    for (int y = 0; y < w->fb_h; y++)
        for (int x = 0; x < w->fb_w; x++) {
            uint8_t *d = px + 4 * ((size_t)y * w->fb_w + x);
            if (x < c->width && y < c->height) {
                const float *s = w->img.rgba + 4 * ((size_t)y * c->width + x);
                float a = s[3];
                for (int k = 0; k < 3; k++) {
                    float v = s[k] * a + 0.14f * (1 - a);
                    d[k] = (uint8_t)lrintf(255.0f * (v < 0 ? 0 : v > 1 ? 1 : v));
                }
            } else {
                d[0] = d[1] = d[2] = 24;
            }
            d[3] = 255;
        }
    app_image_view_upload(&w->iv, w->fb_w, w->fb_h, px);
    glViewport(0, 0, w->fb_w, w->fb_h);
    app_image_view_draw(&w->iv, w->fb_w, w->fb_h);
    st = CRISP_OK;
    w->ms_draw = 1e3 * (crisp_time_now() - t);
    return st;
}

static void ui_line(void *ctx, double x0, double y0, double x1, double y1, uint32_t c, double width)
{
    (void)ctx;
    app_ui_line((float)x0, (float)y0, (float)x1, (float)y1, c, (float)width);
}

static void ui_circle(void *ctx, double x, double y, double r, uint32_t c, int filled)
{
    (void)ctx;
    app_ui_circle((float)x, (float)y, (float)r, c, filled);
}

static void draw_ui(te_window *w)
{
    te_app *a = &w->app;
    te_draw d = {.ctx = w, .line = ui_line, .circle = ui_circle};
    long scan = te_app_draw_2d(a, &d);
    app_ui_begin("crisp-trimedit", 10, 10, 330, APP_UI_AUTO);
    app_ui_text("face %d of %d", a->face, a->model->face_count);
    app_ui_text("plan of the edited face: %.3f ms", a->ms_face_plan);
    app_ui_text("whole plan (camera): %.2f ms", a->ms_plan);
    app_ui_text("draw: %.2f ms   frame: %.2f ms", w->ms_draw, a->ms_frame);
    if (a->plan) {
        const crisp_plan_face *pf = &a->plan->faces[a->face];
        uint32_t rows = 0;
        for (uint32_t s = 0; s < pf->strip_count; s++)
            rows += a->plan->strips[pf->first_strip + s].row_count;
        app_ui_text("strips %u, scan lines %u (%ld drawn)", pf->strip_count, rows, scan);
    }
    const crisp_trimedit_report *rep = crisp_trimedit_check(a->ed);
    if (!rep->valid)
        app_ui_text_color(1.0f, 0.35f, 0.3f, "invalid (drawn even-odd): %s", rep->message);
    if (a->message[0]) {
        if (a->message_error)
            app_ui_text_color(1.0f, 0.35f, 0.3f, "%s", a->message);
        else
            app_ui_text("%s", a->message);
    }
    double suv[2], sw;
    if (te_app_selected(a, suv, &sw)) {
        const crisp_face *f = crisp_trimedit_face(a->ed);
        int rational = f->loops[a->sel.loop].curves[a->sel.curve]->rational;
        app_ui_text("point %d of curve %d of loop %d: (%.6g, %.6g)", a->sel.index, a->sel.curve,
                    a->sel.loop, suv[0], suv[1]);
        if (a->entry)
            app_ui_text_color(1.0f, 0.9f, 0.3f, "weight: %s_   (enter sets, escape closes)",
                              a->entry_text);
        else
            app_ui_text("weight %.6g%s   (w: edit)", sw, rational ? "" : " (polynomial curve)");
        if (!a->entry && app_ui_button("edit weight (w)")) {
            a->entry = 1;
            a->entry_text[0] = '\0';
        }
    }
    if (a->poly) app_ui_text("polygon hole: %d corners (enter closes)", a->poly_n);
    app_ui_checkbox("snap to the domain edge (g)", &a->snap);
    if (app_ui_button("undo")) te_app_key(a, GLFW_KEY_Z, GLFW_PRESS, GLFW_MOD_CONTROL);
    app_ui_same_line();
    if (app_ui_button("redo")) te_app_key(a, GLFW_KEY_Y, GLFW_PRESS, GLFW_MOD_CONTROL);
    app_ui_same_line();
    if (app_ui_button("save")) te_app_key(a, GLFW_KEY_S, GLFW_PRESS, GLFW_MOD_CONTROL);
    if (w->show_help) {
        app_ui_separator();
        app_ui_wrapped("%s", help);
    }
    app_ui_end();
}

/* ---- screenshots
 * --------------------------------------------------------------------------------- */

/* The 3D view as the window last drew it (its size: the frame of the re-planned face, read
 * back), or rendered off-screen at w x h from a whole new plan of the current loops. */
static crisp_status screenshot(te_window *w, const char *path, int sw, int sh)
{
    crisp_camera c = w->app.cam;
    int live = sw <= 0 || sh <= 0 || (sw == c.width && sh == c.height);
    if (!live) c.width = sw, c.height = sh;
    crisp_image img = {0};
    crisp_planner *pl = NULL;
    const crisp_frame_plan *plan;
    crisp_status st = crisp_image_init(&img, c.width, c.height);
    if (live && !w->app.plan)
        st = crisp_error(CRISP_ERR_INVALID_ARG, "screenshot: nothing drawn yet");
    if (!st && !live) {
        st = crisp_planner_create(NULL, NULL, &pl);
        if (!st) st = crisp_scene_update_trim(w->app.scene, (uint32_t)w->app.face);
        if (!st) st = crisp_planner_plan(pl, w->app.scene, &c, &plan);
    }
#ifdef CRISP_TRIMEDIT_GL
    if (!w->use_cpu && !st && live) st = crisp_gl_read(w->gl, &img, NULL);
    if (!w->use_cpu && !st && !live) {
        st = crisp_gl_render(w->gl, w->app.scene, plan, &img, NULL);
        crisp_gl_forget_plan(w->gl);
    }
#endif
    /* CPU: the window's own image of the frame (what was shown), or a new render. */
    if (w->use_cpu && !st && live && w->img.width == c.width && w->img.height == c.height)
        memcpy(img.rgba, w->img.rgba, 4 * sizeof(float) * (size_t)c.width * c.height);
    else if (w->use_cpu && !st && live)
        st = crisp_render_cpu_plan(w->renderer, w->app.scene, w->app.plan, &c, &img, NULL);
    if (w->use_cpu && !st && !live)
        st = crisp_render_cpu_plan(w->renderer, w->app.scene, plan, &c, &img, NULL);
    uint8_t *px = st ? NULL : malloc(4 * (size_t)c.width * c.height);
    if (!st && !px) st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the screenshot");
    if (!st) {
        for (size_t i = 0; i < 4 * (size_t)c.width * c.height; i++) {
            float v = img.rgba[i];
            px[i] = (uint8_t)lrintf(255.0f * (v < 0 ? 0 : v > 1 ? 1 : v));
        }
        st = crisp_write_png_rgba(path, c.width, c.height, px);
    }
    free(px);
    crisp_planner_destroy(pl);
    crisp_image_free(&img);
    if (!st) {
        char cam[512];
        app_nav_format(&c, cam, sizeof cam);
        printf("screenshot: %s camera: %s\n", path, cam);
    }
    return st;
}

static int parse_size(const char *s, int *w, int *h)
{
    char extra;
    return sscanf(s, "%dx%d%c", w, h, &extra) == 2 && *w >= 1 && *h >= 1 && *w <= 16384 &&
           *h <= 16384;
}

static void sink_command(void *ctx, const char *name, const char *arg, int line)
{
    te_window *w = ctx;
    if (!strcmp(name, "screenshot")) {
        char path[1024];
        int sw = 0, sh = 0;
        snprintf(path, sizeof path, "%s", arg ? arg : "");
        char *sp = strrchr(path, ' ');
        if (sp && parse_size(sp + 1, &sw, &sh)) *sp = '\0';
        if (screenshot(w, path, sw, sh)) {
            fprintf(stderr, "crisp-trimedit: replay line %d: %s\n", line, crisp_error_message());
            w->exit_code = 1;
        }
    } else if (!strcmp(name, "camera")) {
        char cam[512];
        app_nav_format(&w->app.cam, cam, sizeof cam);
        printf("camera: %s\n", cam);
    } else if (!strcmp(name, "set-camera")) {
        char err[256];
        crisp_camera c = w->nav.cam;
        if (!app_nav_parse(arg, &c, err, sizeof err)) {
            fprintf(stderr, "crisp-trimedit: replay line %d: %s\n", line, err);
            w->exit_code = 1;
            return;
        }
        c.width = w->nav.cam.width;
        c.height = w->nav.cam.height;
        w->nav.cam = c;
        set_camera_from_nav(w);
    } else {
        fprintf(stderr, "crisp-trimedit: replay line %d: '%s' is not a command of crisp-trimedit\n",
                line, name);
        w->exit_code = 1;
    }
}

int main(int argc, char **argv)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    const char *model_path = NULL, *replay = NULL, *shot = NULL, *save = NULL;
    int face = -1, width = 1280, height = 720, no_vsync = 0;
    static te_window tw;
    te_window *w = &tw;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int more = i + 1 < argc;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return 0;
        } else if (!strcmp(a, "--exit-after-replay")) {
            w->exit_after_replay = 1;
        } else if (!strcmp(a, "--no-vsync")) {
            no_vsync = 1;
        } else if (!strcmp(a, "--cpu")) {
            w->use_cpu = 1;
        } else if (a[0] == '-' && a[1] == '-' && !more) {
            fprintf(stderr, "crisp-trimedit: option %s needs a value\n", a);
            return 2;
        } else if (!strcmp(a, "--face")) {
            char *end;
            long f = strtol(argv[++i], &end, 10);
            if (*end || f < 0 || f > 100000000) {
                fprintf(stderr, "crisp-trimedit: --face '%s': expected a face index >= 0\n",
                        argv[i]);
                return 2;
            }
            face = (int)f;
        } else if (!strcmp(a, "--size")) {
            if (!parse_size(argv[++i], &width, &height)) {
                fprintf(stderr, "crisp-trimedit: --size '%s': expected WxH, each 1..16384\n",
                        argv[i]);
                return 2;
            }
        } else if (!strcmp(a, "--replay")) {
            replay = argv[++i];
        } else if (!strcmp(a, "--screenshot")) {
            shot = argv[++i];
        } else if (!strcmp(a, "--save")) {
            save = argv[++i];
        } else if (a[0] == '-') {
            fprintf(stderr, "crisp-trimedit: unknown option '%s'\n%s", a, usage);
            return 2;
        } else if (!model_path) {
            model_path = a;
        } else {
            fprintf(stderr, "crisp-trimedit: more than one model given ('%s', '%s')\n", model_path,
                    a);
            return 2;
        }
    }
    if (model_path && face < 0) face = 0;
    if (!model_path && face >= 0) {
        fprintf(stderr, "crisp-trimedit: --face needs a MODEL\n");
        return 2;
    }
    crisp_model *model = NULL;
    if (model_path && crisp_model_load(model_path, NULL, &model)) {
        fprintf(stderr, "crisp-trimedit: %s\n", crisp_error_message());
        return 1;
    }
    if (replay) {
        char err[512];
        if (!app_player_load(&w->player, replay, err, sizeof err)) {
            fprintf(stderr, "crisp-trimedit: --replay: %s\n", err);
            crisp_model_destroy(model);
            return 2;
        }
    }
    char err[512];
    w->win = app_window_create(
        &(app_window_desc){
            .title = "crisp-trimedit", .width = width, .height = height, .no_vsync = no_vsync},
        err, sizeof err);
    if (!w->win) {
        fprintf(stderr, "crisp-trimedit: %s\n", err);
        crisp_model_destroy(model);
        app_player_free(&w->player);
        return 1;
    }
    glfwSetWindowUserPointer(w->win, w);
    glfwGetFramebufferSize(w->win, &w->fb_w, &w->fb_h);
    int rc = 0;
    if (te_app_open(&w->app, model, model ? face : -1, w->fb_w, w->fb_h)) {
        fprintf(stderr, "crisp-trimedit: %s\n", crisp_error_message());
        rc = 1;
        goto out;
    }
    if (save) snprintf(w->app.save_path, sizeof w->app.save_path, "%s", save);
    if (!app_ui_init(w->win)) {
        fprintf(stderr, "crisp-trimedit: cannot start Dear ImGui\n");
        rc = 1;
        goto out;
    }
#ifdef CRISP_TRIMEDIT_GL
    if (!w->use_cpu && (crisp_gl_create((crisp_gl_getproc_fn)glfwGetProcAddress, NULL, &w->gl) ||
                        crisp_gl_set_scene(w->gl, w->app.scene))) {
        fprintf(stderr, "crisp-trimedit: %s\n", crisp_error_message());
        rc = 1;
        goto out;
    }
#else
    w->use_cpu = 1;
#endif
    if (w->use_cpu) {
        err[0] = '\0';
        if (crisp_renderer_create(NULL, &w->renderer) ||
            !app_image_view_init(&w->iv, err, sizeof err)) {
            fprintf(stderr, "crisp-trimedit: cannot start the CPU display: %s%s\n", err,
                    err[0] ? "" : crisp_error_message());
            rc = 1;
            goto out;
        }
    }
    /* The 3D camera: navigation on the face's box, starting from the isometric view of it. */
    {
        double box[6];
        crisp_surface_bbox(w->app.model->faces[w->app.face].surface, box);
        app_nav_init(&w->nav, box, (int)w->app.view3d.w, (int)w->app.view3d.h);
        set_camera_from_nav(w);
    }
    glfwSetCursorPosCallback(w->win, cb_cursor);
    glfwSetMouseButtonCallback(w->win, cb_button);
    glfwSetScrollCallback(w->win, cb_scroll);
    glfwSetKeyCallback(w->win, cb_key);
    glfwSetCharCallback(w->win, cb_char);
    app_input_sink sink = {.ctx = w,
                           .cursor = sink_cursor,
                           .button = sink_button,
                           .scroll = sink_scroll,
                           .key = sink_key,
                           .close = sink_close,
                           .idle = sink_idle,
                           .command = sink_command};
    w->replaying = 1; /* an empty replay ends at once */
    int finish_pending = 1;
    while (!w->quit && !glfwWindowShouldClose(w->win)) {
        double t0 = crisp_time_now();
        glfwPollEvents();
        int fw, fh;
        glfwGetFramebufferSize(w->win, &fw, &fh);
        if (fw > 0 && fh > 0 && (fw != w->fb_w || fh != w->fb_h)) {
            w->fb_w = fw;
            w->fb_h = fh;
            te_app_layout(&w->app, fw, fh);
            app_nav_resize(&w->nav, (int)w->app.view3d.w, (int)w->app.view3d.h);
            set_camera_from_nav(w);
        }
        if (w->replaying && !app_player_step(&w->player, &sink)) w->replaying = 0;
        if (te_app_update(&w->app)) {
            fprintf(stderr, "crisp-trimedit: plan: %s\n", crisp_error_message());
            rc = 1;
            break;
        }
        if (draw_3d(w)) {
            fprintf(stderr, "crisp-trimedit: draw: %s\n", crisp_error_message());
            rc = 1;
            break;
        }
        app_ui_frame_begin();
        draw_ui(w);
        app_ui_frame_end();
        glfwSwapBuffers(w->win);
        te_app_frame_done(&w->app, 1e3 * (crisp_time_now() - t0));
        if (!w->replaying && finish_pending) {
            finish_pending = 0;
            if (shot && screenshot(w, shot, 0, 0)) {
                fprintf(stderr, "crisp-trimedit: --screenshot: %s\n", crisp_error_message());
                w->exit_code = 1;
            }
            if (save) {
                if (te_app_save(&w->app, save)) {
                    fprintf(stderr, "crisp-trimedit: --save: %s\n", crisp_error_message());
                    w->exit_code = 1;
                } else {
                    printf("saved: %s\n", save);
                }
            }
            if (w->exit_after_replay) break;
        }
    }
    if (!rc) rc = w->exit_code;
out:
#ifdef CRISP_TRIMEDIT_GL
    crisp_gl_destroy(w->gl);
#endif
    crisp_renderer_destroy(w->renderer);
    crisp_image_free(&w->img);
    if (w->iv.program) app_image_view_free(&w->iv);
    free(w->rgba);
    te_app_close(&w->app);
    app_ui_shutdown();
    app_window_destroy(w->win);
    app_player_free(&w->player);
    printf("exit: %d\n", rc);
    return rc;
}
