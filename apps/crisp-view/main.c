/* crisp-view: the CAD model viewer (issue 10). Arguments, the frame loop (load results, file
 * watching, the replay, frames that render fewer pixels while the camera moves and refine to the
 * full image when it stops), screenshots and the replay's commands. README.md "crisp-view". */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/image.h"
#include "ui.h"
#include "view.h"

static const char usage[] =
    "usage: crisp-view [MODEL] [--size WxH] [--replay EVENTS] [--screenshot OUT.png]\n"
    "                  [--screenshot-size WxH] [--aov OUT.exr] [--exit-after-replay]\n"
    "                  [--camera \"crisp render camera options\"] [--threads N] [--no-vsync]\n"
    "                  [--no-lowres] [--no-aa] [--backend cpu|gl]\n"
    "  MODEL: IGES, STEP, OBJ, .vm / math-string f-rep part, or .scene file\n"
    "  --replay EVENTS: play a replay file (README.md, \"crisp-view\") through the input path\n"
    "  --screenshot OUT.png: after the replay (or the first load), write the view rendered\n"
    "                  off-screen at the window size (or --screenshot-size, not scaled)\n"
    "  --exit-after-replay: quit once the replay and the screenshot are done\n"
    "  Keys: H or F1 for the list.\n";

void view_set_error(view *v, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(v->error, sizeof v->error, fmt, ap);
    va_end(ap);
    v->error_time = crisp_time_now();
    printf("error: %s\n", v->error);
}

void view_open(view *v, const char *path, int keep_camera)
{
    if (path != v->doc_path) {
        char *p = strdup(path);
        if (!p) return;
        free(v->doc_path);
        v->doc_path = p;
    }
    app_loader_request(v->loader, v->doc_path, keep_camera);
    printf("loading: %s\n", v->doc_path);
}

/* The camera of a screenshot: the view's, at the requested size (same vertical angle). */
static crisp_camera shot_camera(view *v, int w, int h)
{
    crisp_camera c = v->nav.cam;
    if (w > 0 && h > 0) c.width = w, c.height = h;
    return c;
}

void view_print_camera(view *v)
{
    app_nav_update_clip(&v->nav);
    crisp_camera c = shot_camera(v, v->shot_w, v->shot_h);
    app_nav_format(&c, v->camera_text, sizeof v->camera_text);
    size_t n = strlen(v->camera_text);
    snprintf(v->camera_text + n, sizeof v->camera_text - n, " --samples %d%s", v->ov.samples,
             strcmp(v->backend.name, "gl") ? "" : " --backend gl");
    printf("camera: %s\n", v->camera_text);
}

static crisp_status write_images(const crisp_image *img, const char *png, const char *exr)
{
    crisp_status st = png ? crisp_image_write_png(img, png) : CRISP_OK;
    if (!st && exr) st = crisp_image_write_exr(img, exr);
    return st;
}

crisp_status view_screenshot(view *v, const char *png, const char *exr, int w, int h)
{
    if (!v->doc) return crisp_error(CRISP_ERR_INVALID_ARG, "screenshot: no model is open");
    if ((w > 0 || h > 0) && (w < v->nav.cam.width || h < v->nav.cam.height))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "screenshot size %dx%d: at least the window's %dx%d", w, h,
                           v->nav.cam.width, v->nav.cam.height);
    if ((long long)(w > 0 ? w : v->nav.cam.width) * (h > 0 ? h : v->nav.cam.height) > (1ll << 26))
        return crisp_error(CRISP_ERR_LIMIT, "screenshot size %dx%d: at most 2^26 pixels", w, h);
    app_nav_update_clip(&v->nav);
    view_sync_section(v);
    crisp_camera c = shot_camera(v, w, h);
    crisp_image img = {0};
    crisp_status st = crisp_image_init(&img, c.width, c.height);
    if (!st) st = v->backend.offscreen(v->backend.self, &v->rdoc, &c, v->ov.samples, &img);
    if (!st) st = write_images(&img, png, exr);
    crisp_image_free(&img);
    if (v->show_wire || v->show_scan) v->dirty = 1; /* the off-screen render replaced the plan */
    if (!st) {
        char cam[512];
        app_nav_format(&c, cam, sizeof cam);
        printf("screenshot: %s camera: %s --samples %d%s\n", png ? png : exr, cam, v->ov.samples,
               strcmp(v->backend.name, "gl") ? "" : " --backend gl");
    }
    return st;
}

void view_sync_section(view *v)
{
    double plane[4];
    int on = view_section_plane(v, plane);
    v->backend.set_section(v->backend.self, on, plane, v->doc ? v->doc->box : plane);
    v->backend.set_transparent(v->backend.self, v->trans_faces && v->trans_scene ? &v->tdoc : NULL);
}

int view_idle(view *v)
{
    char p[8];
    double s;
    if (app_loader_status(v->loader, p, sizeof p, &s)) return 0;
    if (!v->doc) return 1;
    return v->refined && !v->dirty;
}

/* ---- the replay's sink: the same callbacks as the window's real events ---------------------- */

static void sink_cursor(void *ctx, double x, double y)
{
    view *v = ctx;
    glfwSetCursorPos(v->win, x, y);
    view_on_cursor(v->win, x, y);
}
static void sink_button(void *ctx, int b, int a, int m)
{
    view_on_button(((view *)ctx)->win, b, a, m);
}
static void sink_scroll(void *ctx, double dy)
{
    view_on_scroll(((view *)ctx)->win, 0, dy);
}
static void sink_key(void *ctx, int k, int a, int m)
{
    view_on_key(((view *)ctx)->win, k, 0, a, m);
}
static void sink_drop(void *ctx, const char *path)
{
    view_on_drop(((view *)ctx)->win, 1, &path);
}
static void sink_close(void *ctx)
{
    view *v = ctx;
    glfwSetWindowShouldClose(v->win, GLFW_TRUE);
    view_on_close(v->win);
}
static int sink_idle(void *ctx)
{
    return view_idle(ctx);
}

static int parse_size(const char *s, int *w, int *h)
{
    char extra;
    return sscanf(s, "%dx%d%c", w, h, &extra) == 2 && *w >= 1 && *h >= 1 && *w <= 16384 &&
           *h <= 16384;
}

static void sink_command(void *ctx, const char *name, const char *arg, int line)
{
    view *v = ctx;
    if (!strcmp(name, "camera")) {
        view_print_camera(v);
    } else if (!strcmp(name, "mark")) {
        printf("mark: %s time %.6f frames %ld refined %d scale %d frame_ms %.3f\n", arg,
               crisp_time_now(), v->frames, v->refined, v->last.scale, v->last.ms);
    } else if (!strcmp(name, "window")) {
        /* what the window shows (the frame, moving or refined, without the panels) after this
         * step's frame (commands take no frame: the next input event's) */
        snprintf(v->window_shot, sizeof v->window_shot, "%s", arg);

    } else if (!strcmp(name, "occurrence")) {
        /* occurrence N on|off: show or hide an assembly occurrence (1-based, as printed) */
        int k = 0;
        char what[8] = "";
        if (!v->doc || sscanf(arg, "%d %7s", &k, what) != 2 ||
            (strcmp(what, "on") && strcmp(what, "off")) || k < 1 ||
            k > v->doc->scene->model->occurrence_count) {
            view_set_error(v,
                           "replay line %d: expected 'occurrence N on|off' naming an assembly "
                           "occurrence of the model",
                           line);
            return;
        }
        view_occurrence_show(v, k - 1, !strcmp(what, "on"));
    } else if (!strcmp(name, "body")) {
        /* body N on|off: show or hide a body's faces (the Parts panel's checkbox) */
        int b = 0;
        char what[8] = "";
        if (!v->doc || sscanf(arg, "%d %7s", &b, what) != 2 ||
            (strcmp(what, "on") && strcmp(what, "off")) || !view_body_faces(v, b, NULL)) {
            view_set_error(v, "replay line %d: expected 'body N on|off' naming a body of the model",
                           line);
            return;
        }
        view_body_show(v, b, !strcmp(what, "on"));
    } else if (!strcmp(name, "section")) {
        /* section off | section x|y|z POSITION [flip] */
        char ax[8] = "", fl[8] = "";
        double pos = 0;
        int n = sscanf(arg, "%7s %lf %7s", ax, &pos, fl);
        if (n >= 1 && !strcmp(ax, "off")) {
            v->section = 0;
        } else if (n >= 2 && ax[1] == '\0' && ax[0] >= 'x' && ax[0] <= 'z' &&
                   (n == 2 || !strcmp(fl, "flip"))) {
            v->section = 1;
            v->section_axis = ax[0] - 'x';
            v->section_pos = pos;
            v->section_flip = n == 3;
        } else {
            view_set_error(v,
                           "replay line %d: expected 'section off' or 'section x|y|z POSITION "
                           "[flip]'",
                           line);
            return;
        }
        view_print_section(v);
        v->dirty = 1;
    } else if (!strcmp(name, "set-camera")) {
        char err[256];
        crisp_camera c = v->nav.cam;
        if (!app_nav_parse(arg, &c, err, sizeof err)) {
            view_set_error(v, "replay line %d: %s", line, err);
            return;
        }
        c.width = v->nav.cam.width;
        c.height = v->nav.cam.height;
        v->nav.cam = c;
        v->nav.depth_hint = 0;
        v->dirty = 1;
    } else { /* screenshot / aov PATH [WxH] */
        char path[1024];
        int w = 0, h = 0;
        snprintf(path, sizeof path, "%s", arg);
        char *sp = strrchr(path, ' ');
        if (sp && parse_size(sp + 1, &w, &h)) *sp = '\0';
        int png = !strcmp(name, "screenshot");
        if (view_screenshot(v, png ? path : NULL, png ? NULL : path, w, h)) {
            view_set_error(v, "replay line %d: %s", line, crisp_error_message());
            v->exit_code = 1;
        }
    }
}

/* The window's framebuffer (as presented, before the panels) to the PNG v->window_shot. */
static void write_window(view *v)
{
    crisp_image img = {0};
    uint8_t *px = malloc((size_t)v->fb_w * v->fb_h * 4);
    crisp_status st = px ? crisp_image_init(&img, v->fb_w, v->fb_h)
                         : crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    if (!st) {
        glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
        glPixelStorei(GL_PACK_ALIGNMENT, 1);
        glReadPixels(0, 0, v->fb_w, v->fb_h, GL_RGBA, GL_UNSIGNED_BYTE, px);
        for (int j = 0; j < v->fb_h; j++)
            for (int i = 0; i < v->fb_w; i++)
                for (int k = 0; k < 4; k++)
                    img.rgba[4 * ((size_t)j * v->fb_w + i) + k] =
                        px[4 * ((size_t)(v->fb_h - 1 - j) * v->fb_w + i) + k] / 255.0f;
        st = crisp_image_write_png(&img, v->window_shot);
    }
    if (st)
        view_set_error(v, "window %s: %s", v->window_shot, crisp_error_message());
    else
        printf("window: %s refined %d scale %d\n", v->window_shot, v->refined, v->last.scale);
    crisp_image_free(&img);
    free(px);
    v->window_shot[0] = '\0';
}

/* ---- frames ------------------------------------------------------------------------------------
 */

static void install_doc(view *v, app_doc *doc, int keep_camera)
{
    int keep = keep_camera && v->have_camera;
    view_visible_free(v);
    app_doc_destroy(v->doc);
    v->doc = doc;
    view_visible_reset(v);
    v->backend.set_doc(v->backend.self, &v->rdoc);
    if (keep) {
        memcpy(v->nav.box, doc->box, sizeof v->nav.box);
    } else {
        app_nav_init(&v->nav, doc->box, v->fb_w, v->fb_h);
        /* as `crisp render` frames it: the scene file's camera line, else isometric fitted to
         * points of the true trimmed geometry */
        crisp_camera c;
        if (!crisp_document_camera(doc->doc,
                                   &(crisp_camera_desc){.width = v->fb_w, .height = v->fb_h}, &c))
            v->nav.cam = c;
        if (v->initial_camera) {
            char err[256];
            crisp_camera c = v->nav.cam;
            if (app_nav_parse(v->initial_camera, &c, err, sizeof err)) {
                c.width = v->nav.cam.width;
                c.height = v->nav.cam.height;
                v->nav.cam = c;
            } else {
                view_set_error(v, "--camera: %s", err);
            }
            free(v->initial_camera);
            v->initial_camera = NULL;
        }
        v->have_camera = 1;
    }
    if (!keep) v->section_set = 0; /* a new model: the plane goes back to its middle (X) */
    v->sel.hit = 0;
    v->ov.selected_face = -1;
    v->meas_count = 0;
    v->face_info[0] = '\0';
    v->error[0] = '\0';
    v->dirty = 1;
    v->refined = 0;
    v->scale = 0;
    app_watch_set(&v->watch, doc->watch, doc->watch_count);
    char title[1200];
    snprintf(title, sizeof title, "crisp-view - %s", doc->path);
    glfwSetWindowTitle(v->win, title);
    const crisp_model *dm = doc->scene->model;
    for (int k = 0; dm && k < dm->occurrence_count; k++)
        printf("occurrence: %d %s parent %d\n", k + 1, dm->occurrences[k].name,
               dm->occurrences[k].parent + 1);
    printf("loaded: %s: %s, %u faces, %u patches, %zu f-rep parts, box %g %g %g %g %g %g "
           "(read %.1f ms, prepare %.1f ms)\n",
           doc->path, doc->kind, doc->scene->face_count, doc->scene->patch_count, doc->part_count,
           doc->box[0], doc->box[1], doc->box[2], doc->box[3], doc->box[4], doc->box[5],
           doc->ms_read, doc->ms_prepare);
}

/* The divisor of the window size for moving frames: aim at 25 ms of rendering per moving frame
 * (30 frames per second with the rest), adapted as frames come (render_frame). */
static int moving_scale(view *v)
{
    if (v->scale < 1) v->scale = (int)ceil(sqrt(fmax(v->last_full_ms, 1) / 25.0));
    if (v->scale > 8) v->scale = 8;
    return v->scale;
}

static void render_frame(view *v)
{
    if (!v->doc) return;
    int full = !v->moving || v->no_lowres;
    if (!v->dirty && v->refined) {
        /* idle with the refined image on screen: plan now what the next motion will reuse */
        if (!v->motion_ready && !v->no_lowres && v->backend.prepare_motion) {
            app_nav_update_clip(&v->nav);
            /* the first guess of the moving scale (not the last motion's, adapted to it) */
            int guess = (int)ceil(sqrt(fmax(v->last_full_ms, 1) / 25.0)), more = 0;
            if (v->backend.prepare_motion(v->backend.self, &v->rdoc, &v->nav.cam,
                                          guess < 1   ? 1
                                          : guess > 8 ? 8
                                                      : guess,
                                          &more))
                view_set_error(v, "render: %s", crisp_error_message());
            v->motion_ready = !more; /* else the next idle frame builds more of its splat sets */
        }
        return;
    }
    if (!v->dirty && !v->refined) full = 1;
    int scale = full ? 1 : moving_scale(v);
    app_nav_update_clip(&v->nav);
    view_frame_stats fs = {0};
    view_sync_section(v);
    view_overlay ov = v->ov;
    if (v->moving) ov.samples = 1; /* moving frames: one sample per pixel, even at full size */
    ov.moving = !full;
    ov.no_aovs = !v->show_wire && !v->show_scan && !v->rdoc.part_count;
    crisp_status st = v->backend.frame(v->backend.self, &v->rdoc, &v->nav.cam, scale, &ov, &fs);
    if (st) {
        view_set_error(v, "render: %s", crisp_error_message());
        v->dirty = 0;
        v->refined = 1;
        return;
    }
    v->last = fs;
    v->motion_ready = 0;
    /* the least depth drawn bounds the near plane of the next frames (the navigation scales it
     * as it moves the camera) */
    if (isfinite(fs.min_depth) && fs.min_depth > 0) v->nav.depth_hint = fs.min_depth;
    if (v->show_wire) view_wire_update(v);
    double now = crisp_time_now();
    if (!ov.moving) {
        v->last_full_ms = fs.ms;
    } else {
        /* aim at 30 frames per second on screen: the render time, and the whole frame's wall
         * time (present, panels, swap) since the last moving frame; GPU moving frames
         * (proxy.c) cost little per pixel, so come down fast */
        double wall = v->last_moving_t > 0 ? 1e3 * (now - v->last_moving_t) : fs.ms;
        if ((fs.ms > 25 || wall > 40) && v->scale < 8)
            v->scale++;
        else if (fs.ms < 12 && wall < 22 && v->scale > 1) {
            /* down only when the frame would still fit if its cost grew with the pixels */
            int s1 = v->scale * 7 / 10 > 1 ? v->scale * 7 / 10 : 1;
            double grow = (double)v->scale * v->scale / ((double)s1 * s1);
            if (fs.ms * grow < 20) v->scale = s1;
        }
    }
    v->last_moving_t = ov.moving ? now : 0;
    v->dirty = 0;
    v->refined = scale == 1 && !v->moving;
    /* splat sets still being built (a large model's first frames): draw again */
    if (full && fs.pending) v->dirty = 1, v->refined = 0;
}

static void poll_loader(view *v)
{
    app_doc *doc = NULL;
    int tag = 0;
    char err[1024];
    int r = app_loader_poll(v->loader, &doc, &tag, err, sizeof err);
    if (r == APP_LOAD_DONE)
        install_doc(v, doc, tag);
    else if (r == APP_LOAD_FAILED)
        view_set_error(v, "%s", err);
}

int main(int argc, char **argv)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    const char *model = NULL, *replay = NULL, *aov = NULL;
    int width = 1280, height = 720, no_vsync = 0, use_gl = 0;
    static view vv;
    view *v = &vv;
    v->drag_button = -1;
    v->ov.selected_face = -1;
    v->show_hud = 1;
    v->show_panels = 1;
    v->ov.edges = 1;
    v->ov.samples = 4;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int more = i + 1 < argc;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(usage, stdout);
            return 0;
        } else if (!strcmp(a, "--exit-after-replay")) {
            v->exit_after_replay = 1;
        } else if (!strcmp(a, "--no-vsync")) {
            no_vsync = 1;
        } else if (!strcmp(a, "--no-lowres")) {
            v->no_lowres = 1;
        } else if (!strcmp(a, "--no-aa")) {
            v->ov.samples = 1;
        } else if (a[0] == '-' && a[1] == '-' && !more) {
            fprintf(stderr, "crisp-view: option %s needs a value\n", a);
            return 2;
        } else if (!strcmp(a, "--size")) {
            if (!parse_size(argv[++i], &width, &height)) {
                fprintf(stderr, "crisp-view: --size '%s': expected WxH, each 1..16384\n", argv[i]);
                return 2;
            }
        } else if (!strcmp(a, "--screenshot-size")) {
            if (!parse_size(argv[++i], &v->shot_w, &v->shot_h)) {
                fprintf(stderr, "crisp-view: --screenshot-size '%s': expected WxH\n", argv[i]);
                return 2;
            }
        } else if (!strcmp(a, "--backend")) {
            const char *b = argv[++i];
            if (strcmp(b, "cpu") && strcmp(b, "gl")) {
                fprintf(stderr, "crisp-view: --backend '%s': expected cpu or gl\n", b);
                return 2;
            }
            use_gl = !strcmp(b, "gl");
        } else if (!strcmp(a, "--replay")) {
            replay = argv[++i];
        } else if (!strcmp(a, "--screenshot")) {
            v->screenshot_path = argv[++i];
        } else if (!strcmp(a, "--aov")) {
            aov = argv[++i];
        } else if (!strcmp(a, "--camera")) {
            v->initial_camera = strdup(argv[++i]);
        } else if (!strcmp(a, "--threads")) {
            char *end;
            long t = strtol(argv[++i], &end, 10);
            if (*end || t < 1 || t > 1024) {
                fprintf(stderr, "crisp-view: --threads '%s': expected 1..1024\n", argv[i]);
                return 2;
            }
            v->threads = (int)t;
        } else if (a[0] == '-' && a[1] == '-') {
            fprintf(stderr, "crisp-view: unknown option '%s'\n%s", a, usage);
            return 2;
        } else if (!model) {
            model = a;
        } else {
            fprintf(stderr, "crisp-view: more than one model given ('%s', '%s')\n", model, a);
            return 2;
        }
    }
    if (v->initial_camera) {
        char err[256];
        crisp_camera c = {.fov_deg = 30,
                          .znear = 1,
                          .zfar = 2,
                          .width = 1,
                          .height = 1,
                          .eye = {0, 0, 1},
                          .up = {0, 1, 0}};
        if (!app_nav_parse(v->initial_camera, &c, err, sizeof err)) {
            fprintf(stderr, "crisp-view: --camera: %s\n", err);
            return 2;
        }
    }
    if (replay) {
        char err[512];
        if (!app_player_load(&v->player, replay, err, sizeof err)) {
            fprintf(stderr, "crisp-view: --replay: %s\n", err);
            return 2;
        }
    }
    v->replaying = 1; /* an empty replay ends at once */

    char err[512];
    v->win = app_window_create(
        &(app_window_desc){
            .title = "crisp-view", .width = width, .height = height, .no_vsync = no_vsync},
        err, sizeof err);
    if (!v->win) {
        fprintf(stderr, "crisp-view: %s\n", err);
        app_player_free(&v->player);
        return 1;
    }
    glfwSetWindowUserPointer(v->win, v);
    glfwGetFramebufferSize(v->win, &v->fb_w, &v->fb_h);
    v->show_panels = v->fb_w >= 900; /* small windows start with the view alone (P shows them) */
    int rc = 0;
    if (!app_ui_init(v->win)) {
        fprintf(stderr, "crisp-view: cannot start Dear ImGui\n");
        rc = 1;
    } else if (view_backend_create(v->threads, use_gl, &v->backend)) {
        fprintf(stderr, "crisp-view: %s\n", crisp_error_message());
        rc = 1;
    } else if (!app_loader_create(&v->loader)) {
        fprintf(stderr, "crisp-view: cannot start the loader thread\n");
        rc = 1;
    }
    if (rc) goto out;
    view_install_callbacks(v);
    app_nav_init(&v->nav, (double[6]){-1, -1, -1, 1, 1, 1}, v->fb_w, v->fb_h);
    if (model) view_open(v, model, 0);

    app_input_sink sink = {.ctx = v,
                           .cursor = sink_cursor,
                           .button = sink_button,
                           .scroll = sink_scroll,
                           .key = sink_key,
                           .drop = sink_drop,
                           .close = sink_close,
                           .idle = sink_idle,
                           .command = sink_command};
    int shot_pending = v->screenshot_path || aov;
    while (!v->quit && !glfwWindowShouldClose(v->win)) {
        char lp[8];
        double ls;
        int busy = app_loader_status(v->loader, lp, sizeof lp, &ls);
        if (v->replaying || shot_pending || v->dirty || !v->refined || busy || v->drag_button >= 0)
            glfwPollEvents();
        else
            glfwWaitEventsTimeout(0.25);
        int fw, fh;
        glfwGetFramebufferSize(v->win, &fw, &fh);
        if (fw > 0 && fh > 0 && (fw != v->fb_w || fh != v->fb_h)) {
            v->fb_w = fw;
            v->fb_h = fh;
            app_nav_resize(&v->nav, fw, fh);
            v->dirty = 1;
        }
        poll_loader(v);
        if (v->doc && app_watch_poll(&v->watch, crisp_time_now())) {
            printf("changed on disk: %s\n", v->doc->path);
            view_open(v, v->doc->path, 1);
        }
        if (v->replaying && !app_player_step(&v->player, &sink)) v->replaying = 0;
        if (!v->replaying && shot_pending && view_idle(v)) {
            shot_pending = 0;
            if (view_screenshot(v, v->screenshot_path, aov, v->shot_w, v->shot_h)) {
                view_set_error(v, "%s", crisp_error_message());
                v->exit_code = 1;
            }
        }
        if (!v->replaying && !shot_pending && v->exit_after_replay) break;

        render_frame(v);
        v->moving = 0;
        v->backend.present(v->backend.self, v->fb_w, v->fb_h);
        if (v->window_shot[0]) write_window(v);
        app_ui_frame_begin();
        view_draw_panels(v);
        app_ui_frame_end();
        glfwSwapBuffers(v->win);
        v->frames++;
    }
    rc = v->exit_code;
out:
    app_loader_destroy(v->loader); /* waits for a running load */
    view_visible_free(v);
    free(v->face_hidden);
    free(v->part_hidden);
    app_doc_destroy(v->doc);
    app_watch_clear(&v->watch);
    if (v->backend.destroy) v->backend.destroy(v->backend.self);
    app_ui_shutdown();
    app_window_destroy(v->win);
    app_player_free(&v->player);
    free(v->doc_path);
    free(v->initial_camera);
    free(v->wire);
    free(v->body_ids);
    /* forget every pointer: what was not freed above becomes a leak LeakSanitizer reports */
    memset(v, 0, sizeof *v);
    printf("exit: %d\n", rc);
    return rc;
}
