/* The trim-editing demo without its window (te_app.h): state, input, per-frame re-planning of
 * the edited face, and the 2D domain view's drawing. Wu & Peters 2015: the u-intercept table is
 * rebuilt every frame instead of a modeller recomputing triangles, so a dragged trim curve is
 * exact to the pixel at every frame.
 */
#include "te_app.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "crisp/io.h"

#define PICK_PX 8.0 /* pick radius in pixels */

static void say(te_app *app, int error, const char *fmt, const char *arg)
{
    snprintf(app->message, sizeof app->message, fmt, arg);
    app->message_error = error;
    if (error) fprintf(stderr, "crisp-trimedit: %s\n", app->message);
}

/* Report an edit's status: refused edits show their reason. */
static void edit_done(te_app *app, crisp_status st, const char *what)
{
    if (st)
        say(app, 1, "refused: %s", crisp_error_message());
    else
        say(app, 0, "%s", what);
}

/* The untrimmed copy of the edited face (its scene gives the surface point under the cursor). */
static crisp_status make_bare(te_app *app)
{
    crisp_scene_destroy(app->bare_scene);
    crisp_model_destroy(app->bare);
    app->bare_scene = NULL;
    app->bare = NULL;
    crisp_status st = crisp_model_create(&app->bare);
    if (st) return st;
    crisp_face f;
    if ((st = crisp_face_copy(&app->model->faces[app->face], &f))) return st;
    for (int l = 0; l < f.loop_count; l++)
        crisp_trim_loop_free(&f.loops[l]);
    f.loop_count = 0;
    if ((st = crisp_model_add_face(app->bare, &f))) {
        crisp_face_free(&f);
        return st;
    }
    return crisp_scene_prepare(app->bare, &app->bare_scene);
}

static void frame_face(te_app *app)
{
    double box[6];
    crisp_surface_bbox(app->model->faces[app->face].surface, box);
    int w = app->view3d.w > 0 ? (int)app->view3d.w : 768,
        h = app->view3d.h > 0 ? (int)app->view3d.h : 720;
    crisp_camera_frame_box(box, w, h, &app->cam);
    app->cam_changed = 1;
}

static crisp_status open_face(te_app *app, int face)
{
    app->others_plan = -1;
    crisp_trimedit_destroy(app->ed);
    app->ed = NULL;
    app->face = face;
    crisp_status st = crisp_trimedit_create(app->model, face, NULL, &app->ed);
    if (st) return st;
    /* The editor may have added a loop (a face without loops) or clamped curves. */
    if ((st = crisp_scene_update_trim(app->scene, (uint32_t)face))) return st;
    if ((st = make_bare(app))) return st;
    app->planned_version = 0;
    app->cam_changed = 1;
    app->drag = TE_DRAG_NONE;
    app->has_sel = app->entry = app->poly = 0;
    te_app_fit_2d(app);
    return CRISP_OK;
}

crisp_status te_app_open(te_app *app, crisp_model *model, int face, int width, int height)
{
    memset(app, 0, sizeof *app);
    app->show_strips = app->show_scanlines = 1;
    crisp_status st;
    if (!model) {
        if ((st = crisp_trimedit_example(&model))) return st;
        face = 0;
    }
    app->model = model;
    if (face < 0 || face >= model->face_count) {
        st = crisp_error(CRISP_ERR_INVALID_ARG, "face %d: the model has %d faces (0..%d)", face,
                         model->face_count, model->face_count - 1);
        goto fail;
    }
    if ((st = crisp_scene_prepare(model, &app->scene))) goto fail;
    if ((st = crisp_planner_create(NULL, NULL, &app->planner))) goto fail;
    app->face_mask = calloc((size_t)model->face_count, 1);
    app->others_mask = calloc((size_t)model->face_count, 1);
    if (!app->face_mask || !app->others_mask) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for %d faces", model->face_count);
        goto fail;
    }
    te_app_layout(app, width, height);
    if ((st = open_face(app, face))) goto fail;
    frame_face(app);
    return CRISP_OK;
fail:
    te_app_close(app);
    return st;
}

void te_app_close(te_app *app)
{
    crisp_trimedit_destroy(app->ed);
    crisp_planner_destroy(app->planner);
    crisp_scene_destroy(app->scene);
    crisp_scene_destroy(app->bare_scene);
    crisp_model_destroy(app->bare);
    crisp_model_destroy(app->model);
    crisp_image_free(&app->others);
    free(app->face_mask);
    free(app->others_mask);
    memset(app, 0, sizeof *app);
}

void te_app_layout(te_app *app, int width, int height)
{
    int w3 = (int)(0.6 * width);
    app->view3d = (te_rect){0, 0, w3, height};
    app->view2d = (te_rect){w3, 0, width - w3, height};
    if (app->cam.width != w3 || app->cam.height != height) {
        app->cam.width = w3 > 0 ? w3 : 1;
        app->cam.height = height > 0 ? height : 1;
        app->cam_changed = 1;
    }
}

void te_app_set_camera(te_app *app, const crisp_camera *cam)
{
    app->cam = *cam;
    app->cam.width = (int)app->view3d.w;
    app->cam.height = (int)app->view3d.h;
    app->cam_changed = 1;
}

void te_app_fit_2d(te_app *app)
{
    if (!app->ed) return;
    double d[4];
    crisp_trimedit_domain(app->ed, d);
    app->uv_center[0] = 0.5 * (d[0] + d[1]);
    app->uv_center[1] = 0.5 * (d[2] + d[3]);
    double su = 0.85 * app->view2d.w / (d[1] - d[0]), sv = 0.85 * app->view2d.h / (d[3] - d[2]);
    app->uv_scale = fmin(su, sv);
    if (!(app->uv_scale > 0) || !isfinite(app->uv_scale)) app->uv_scale = 1;
}

void te_app_uv_to_px(const te_app *app, const double uv[2], double px[2])
{
    px[0] = app->view2d.x + 0.5 * app->view2d.w + (uv[0] - app->uv_center[0]) * app->uv_scale;
    px[1] = app->view2d.y + 0.5 * app->view2d.h - (uv[1] - app->uv_center[1]) * app->uv_scale;
}

void te_app_px_to_uv(const te_app *app, const double px[2], double uv[2])
{
    uv[0] = app->uv_center[0] + (px[0] - app->view2d.x - 0.5 * app->view2d.w) / app->uv_scale;
    uv[1] = app->uv_center[1] - (px[1] - app->view2d.y - 0.5 * app->view2d.h) / app->uv_scale;
}

int te_app_uv_to_px3d(const te_app *app, const double uv[2], double px[2])
{
    double P[3], c[4], s[3];
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(&app->cam, &m);
    crisp_surface_eval(app->model->faces[app->face].surface, uv[0], uv[1], P);
    crisp_mat4_mulp(m.view_proj, P, c);
    if (!(c[3] > 0)) return 0;
    crisp_camera_to_pixel(&app->cam, c, s);
    px[0] = app->view3d.x + s[0];
    px[1] = app->view3d.y + s[1];
    return 1;
}

crisp_status te_app_update(te_app *app)
{
    crisp_status st = CRISP_OK;
    uint64_t v = crisp_trimedit_version(app->ed);
    if (!app->plan || app->cam_changed) {
        if (v != app->planned_version &&
            (st = crisp_scene_update_trim(app->scene, (uint32_t)app->face)))
            return st;
        double t = crisp_time_now();
        if ((st = crisp_planner_plan(app->planner, app->scene, &app->cam, &app->plan))) return st;
        app->ms_plan = 1e3 * (crisp_time_now() - t);
        app->whole_plans++;
        app->cam_changed = 0;
        app->planned_version = v;
    } else if (v != app->planned_version) {
        double t = crisp_time_now();
        if ((st = crisp_scene_update_trim(app->scene, (uint32_t)app->face))) return st;
        if ((st = crisp_planner_replan_face(app->planner, app->scene, (uint32_t)app->face,
                                            &app->plan)))
            return st;
        app->ms_face_plan = 1e3 * (crisp_time_now() - t);
        app->planned_version = v;
        app->replans++;
    }
    return st;
}

int te_app_editing(const te_app *app)
{
    return app->drag != TE_DRAG_NONE && app->drag != TE_DRAG_PAN;
}

static void copy_image(const crisp_image *src, crisp_image *dst)
{
    size_t n = (size_t)src->width * src->height;
    memcpy(dst->rgba, src->rgba, 4 * n * sizeof *dst->rgba);
    memcpy(dst->depth, src->depth, n * sizeof *dst->depth);
    memcpy(dst->normal, src->normal, 3 * n * sizeof *dst->normal);
    memcpy(dst->uv, src->uv, 2 * n * sizeof *dst->uv);
    memcpy(dst->face, src->face, n * sizeof *dst->face);
}

crisp_status te_app_draw_cpu(te_app *app, crisp_renderer *r, crisp_image *img)
{
    double t = crisp_time_now();
    crisp_status st;
    app->last_partial = 0;
    if (!app->plan) return crisp_error(CRISP_ERR_INVALID_ARG, "draw: nothing planned yet");
    if (!te_app_editing(app)) {
        app->over = NULL;
        st = crisp_render_cpu_plan(r, app->scene, app->plan, &app->cam, img, NULL);
        app->ms_draw = 1e3 * (crisp_time_now() - t);
        return st;
    }
    if (app->others_plan != app->whole_plans || app->others_face != app->face ||
        app->others.width != img->width || app->others.height != img->height) {
        if (app->others.width != img->width || app->others.height != img->height) {
            crisp_image_free(&app->others);
            if ((st = crisp_image_init(&app->others, img->width, img->height))) return st;
        }
        for (int f = 0; f < app->model->face_count; f++) {
            app->face_mask[f] = f == app->face;
            app->others_mask[f] = f != app->face;
        }
        if ((st = crisp_render_cpu_plan_faces(r, app->scene, app->plan, &app->cam, app->others_mask,
                                              NULL, &app->others, NULL)))
            return st;
        app->others_plan = app->whole_plans;
        app->others_face = app->face;
        app->over = NULL;
    }
    if (app->over != img) copy_image(&app->others, img);
    st = crisp_render_cpu_plan_faces(r, app->scene, app->plan, &app->cam, app->face_mask,
                                     &app->others, img, NULL);
    app->over = st ? NULL : img;
    app->last_partial = !st;
    app->ms_draw = 1e3 * (crisp_time_now() - t);
    return st;
}

void te_app_frame_done(te_app *app, double ms_frame)
{
    app->ms_frame = ms_frame;
}

static int in_rect(const te_rect *r, const double p[2])
{
    return p[0] >= r->x && p[0] < r->x + r->w && p[1] >= r->y && p[1] < r->y + r->h;
}

/* The control point whose surface point is nearest the cursor in the 3D view. */
static int pick_point_3d(te_app *app, crisp_trimedit_ref *dest)
{
    const crisp_face *f = crisp_trimedit_face(app->ed);
    double best = PICK_PX;
    int found = 0;
    for (int l = 0; l < f->loop_count; l++)
        for (int c = 0; c < f->loops[l].curve_count; c++)
            for (int i = 0; i < f->loops[l].curves[c]->count; i++) {
                crisp_trimedit_ref r = {l, c, i};
                double uv[2], px[2];
                crisp_trimedit_point(app->ed, r, uv, NULL);
                if (!te_app_uv_to_px3d(app, uv, px)) continue;
                double d = hypot(px[0] - app->cursor[0], px[1] - app->cursor[1]);
                if (d <= best) {
                    best = d;
                    *dest = r;
                    found = 1;
                }
            }
    return found;
}

/* (u, v) of the untrimmed edited surface under the cursor in the 3D view. */
static int uv_under_cursor_3d(te_app *app, double uv[2])
{
    double o[3], dir[3], t;
    uint32_t face;
    crisp_camera_ray(&app->cam, app->cursor[0] - app->view3d.x, app->cursor[1] - app->view3d.y, o,
                     dir);
    crisp_exact_desc d = {.threads = 1};
    return crisp_exact_ray(app->bare_scene, &d, o, dir, 0.0, INFINITY, &t, &face, uv, NULL);
}

static void move_dragged(te_app *app, const double uv[2])
{
    double snap = app->snap ? PICK_PX / app->uv_scale : 0.0;
    crisp_status st = crisp_trimedit_move_point(app->ed, &app->drag_ref, uv, snap);
    if (st) edit_done(app, st, "");
}

void te_app_cursor(te_app *app, double x, double y)
{
    double prev[2] = {app->cursor[0], app->cursor[1]};
    app->cursor[0] = x;
    app->cursor[1] = y;
    double uv[2];
    te_app_px_to_uv(app, app->cursor, uv);
    /* A loop transform from the 3D view follows the surface point under the cursor. */
    if (app->drag_3d &&
        (app->drag == TE_DRAG_MOVE || app->drag == TE_DRAG_ROTATE || app->drag == TE_DRAG_SCALE) &&
        !uv_under_cursor_3d(app, uv))
        return;
    switch (app->drag) {
    case TE_DRAG_POINT:
        move_dragged(app, uv);
        break;
    case TE_DRAG_POINT_3D: {
        double suv[2];
        if (uv_under_cursor_3d(app, suv)) move_dragged(app, suv);
        break;
    }
    case TE_DRAG_MOVE: {
        const double m[2][3] = {{1, 0, uv[0] - app->drag_last[0]},
                                {0, 1, uv[1] - app->drag_last[1]}};
        crisp_status st = crisp_trimedit_transform_loop(app->ed, app->drag_loop, m);
        if (!st)
            memcpy(app->drag_last, uv, sizeof uv);
        else
            edit_done(app, st, "");
        break;
    }
    case TE_DRAG_ROTATE:
    case TE_DRAG_SCALE: {
        const double *c = app->drag_pivot;
        double a0 = atan2(app->drag_last[1] - c[1], app->drag_last[0] - c[0]);
        double a1 = atan2(uv[1] - c[1], uv[0] - c[0]);
        double r0 = hypot(app->drag_last[0] - c[0], app->drag_last[1] - c[1]);
        double r1 = hypot(uv[0] - c[0], uv[1] - c[1]);
        double s = app->drag == TE_DRAG_SCALE ? (r0 > 0 ? r1 / r0 : 1) : 1;
        double a = app->drag == TE_DRAG_ROTATE ? a1 - a0 : 0;
        double ca = s * cos(a), sa = s * sin(a);
        const double m[2][3] = {{ca, -sa, c[0] - ca * c[0] + sa * c[1]},
                                {sa, ca, c[1] - sa * c[0] - ca * c[1]}};
        crisp_status st = crisp_trimedit_transform_loop(app->ed, app->drag_loop, m);
        if (!st)
            memcpy(app->drag_last, uv, sizeof uv);
        else
            edit_done(app, st, "");
        break;
    }
    case TE_DRAG_PAN:
        app->uv_center[0] -= (x - prev[0]) / app->uv_scale;
        app->uv_center[1] += (y - prev[1]) / app->uv_scale;
        break;
    default:
        break;
    }
}

/* The loop whose image in the 3D view passes nearest the cursor (within 4 pick radii): its
 * index and the (u, v) of that curve point. */
static int pick_loop_3d(te_app *app, int *loop, double uv[2])
{
    const crisp_face *f = crisp_trimedit_face(app->ed);
    double best = 4 * PICK_PX;
    int found = 0;
    for (int l = 0; l < f->loop_count; l++)
        for (int c = 0; c < f->loops[l].curve_count; c++) {
            const crisp_curve *cv = f->loops[l].curves[c];
            for (int k = cv->degree; k < cv->count; k++) {
                double a = cv->knots[k], b = cv->knots[k + 1];
                if (!(a < b)) continue;
                for (int i = 0; i <= 32; i++) {
                    double q[2], px[2];
                    crisp_curve_eval(cv, a + (b - a) * i / 32, q);
                    if (!te_app_uv_to_px3d(app, q, px)) continue;
                    double d = hypot(px[0] - app->cursor[0], px[1] - app->cursor[1]);
                    if (d <= best) {
                        best = d;
                        *loop = l;
                        memcpy(uv, q, sizeof q);
                        found = 1;
                    }
                }
            }
        }
    return found;
}

static void start_loop_drag(te_app *app, int loop, const double uv[2], int mods, int in_3d)
{
    app->drag_loop = loop;
    app->drag = mods & GLFW_MOD_SHIFT     ? TE_DRAG_MOVE
                : mods & GLFW_MOD_CONTROL ? TE_DRAG_ROTATE
                                          : TE_DRAG_SCALE;
    app->drag_3d = in_3d;
    memcpy(app->drag_last, uv, 2 * sizeof *uv);
    crisp_trimedit_loop_center(app->ed, loop, app->drag_pivot);
    crisp_trimedit_group_begin(app->ed);
}

static void poly_finish(te_app *app)
{
    app->poly = 0;
    if (app->poly_n < 3) {
        say(app, 1, "%s", "refused: a polygon hole needs 3 corners or more");
        return;
    }
    edit_done(app, crisp_trimedit_add_polygon(app->ed, app->poly_n, app->poly_uv),
              "polygon hole added");
}

/* A left click in the 2D view while a polygon is drawn: a corner, or the first one again. */
static void poly_click(te_app *app)
{
    double first[2];
    if (app->poly_n >= 3) {
        te_app_uv_to_px(app, app->poly_uv, first);
        if (hypot(first[0] - app->cursor[0], first[1] - app->cursor[1]) <= PICK_PX) {
            poly_finish(app);
            return;
        }
    }
    if (app->poly_n >= 64) {
        say(app, 1, "%s", "a polygon hole has at most 64 corners: enter closes it");
        return;
    }
    te_app_px_to_uv(app, app->cursor, app->poly_uv + 2 * app->poly_n);
    app->poly_n++;
}

void te_app_button(te_app *app, int button, int action, int mods)
{
    if (action == GLFW_RELEASE) {
        if (app->drag != TE_DRAG_NONE && app->drag != TE_DRAG_PAN)
            crisp_trimedit_group_end(app->ed);
        if (app->drag == TE_DRAG_POINT || app->drag == TE_DRAG_POINT_3D) app->sel = app->drag_ref;
        app->drag = TE_DRAG_NONE;
        app->drag_3d = 0;
        return;
    }
    if (action != GLFW_PRESS) return;
    double uv[2];
    te_app_px_to_uv(app, app->cursor, uv);
    double radius = PICK_PX / app->uv_scale;
    if (in_rect(&app->view2d, app->cursor)) {
        if (button == GLFW_MOUSE_BUTTON_RIGHT || button == GLFW_MOUSE_BUTTON_MIDDLE) {
            app->drag = TE_DRAG_PAN;
            return;
        }
        if (button != GLFW_MOUSE_BUTTON_LEFT) return;
        if (app->poly) {
            poly_click(app);
            return;
        }
        if (mods & (GLFW_MOD_SHIFT | GLFW_MOD_CONTROL | GLFW_MOD_ALT)) {
            int l, c;
            double t;
            if (!crisp_trimedit_pick_curve(app->ed, uv, 4 * radius, &l, &c, &t)) return;
            start_loop_drag(app, l, uv, mods, 0);
            return;
        }
        if (crisp_trimedit_pick_point(app->ed, uv, radius, &app->drag_ref)) {
            app->drag = TE_DRAG_POINT;
            app->has_sel = 1;
            app->sel = app->drag_ref;
            memcpy(app->drag_start, uv, sizeof uv);
            crisp_trimedit_group_begin(app->ed);
        }
    } else if (in_rect(&app->view3d, app->cursor) && button == GLFW_MOUSE_BUTTON_LEFT) {
        if (mods & (GLFW_MOD_SHIFT | GLFW_MOD_CONTROL | GLFW_MOD_ALT)) {
            int l;
            double on[2], suv[2];
            if (!pick_loop_3d(app, &l, on)) return;
            /* From the surface point under the cursor (the curve point when the ray misses). */
            start_loop_drag(app, l, uv_under_cursor_3d(app, suv) ? suv : on, mods, 1);
            return;
        }
        if (!mods && pick_point_3d(app, &app->drag_ref)) {
            app->drag = TE_DRAG_POINT_3D;
            app->has_sel = 1;
            app->sel = app->drag_ref;
            crisp_trimedit_group_begin(app->ed);
        }
    }
}

void te_app_scroll(te_app *app, double dy)
{
    if (!in_rect(&app->view2d, app->cursor)) return;
    double before[2], after[2];
    te_app_px_to_uv(app, app->cursor, before);
    app->uv_scale *= pow(1.2, dy);
    te_app_px_to_uv(app, app->cursor, after);
    app->uv_center[0] += before[0] - after[0];
    app->uv_center[1] += before[1] - after[1];
}

/* The (u, v) the keys act at: the cursor in the 2D view, or the surface point under it in 3D. */
static int key_uv(te_app *app, double uv[2])
{
    if (in_rect(&app->view2d, app->cursor)) {
        te_app_px_to_uv(app, app->cursor, uv);
        return 1;
    }
    return in_rect(&app->view3d, app->cursor) && uv_under_cursor_3d(app, uv);
}

static double key_radius(const te_app *app)
{
    return PICK_PX / app->uv_scale;
}

static void weight_key(te_app *app, double factor, int zero)
{
    double uv[2], w;
    crisp_trimedit_ref r;
    if (!key_uv(app, uv) || !crisp_trimedit_pick_point(app->ed, uv, key_radius(app), &r)) {
        say(app, 1, "%s", "no control point under the cursor");
        return;
    }
    crisp_trimedit_point(app->ed, r, uv, &w);
    edit_done(app, crisp_trimedit_set_weight(app->ed, r, zero ? 0.0 : w * factor),
              "weight changed");
}

int te_app_selected(te_app *app, double uv[2], double *weight)
{
    double q[2], w;
    if (!app->has_sel || crisp_trimedit_point(app->ed, app->sel, q, &w)) {
        app->has_sel = 0;
        return 0;
    }
    if (uv) memcpy(uv, q, sizeof q);
    if (weight) *weight = w;
    return 1;
}

crisp_status te_app_set_weight_text(te_app *app, const char *text)
{
    crisp_status st;
    if (!te_app_selected(app, NULL, NULL)) {
        st = crisp_error(CRISP_ERR_INVALID_ARG, "no control point selected");
    } else {
        char *end;
        double w = strtod(text, &end);
        while (*end == ' ')
            end++;
        if (end == text || *end)
            st = crisp_error(CRISP_ERR_INVALID_ARG, "weight '%s': expected a number", text);
        else
            st = crisp_trimedit_set_weight(app->ed, app->sel, w);
    }
    edit_done(app, st, "weight set");
    return st;
}

/* The weight field's keys: typing, backspace, enter (set), escape (close). */
static void entry_key(te_app *app, int key)
{
    size_t n = strlen(app->entry_text);
    char c = 0;
    if (key >= GLFW_KEY_0 && key <= GLFW_KEY_9) c = (char)('0' + key - GLFW_KEY_0);
    if (key >= GLFW_KEY_KP_0 && key <= GLFW_KEY_KP_9) c = (char)('0' + key - GLFW_KEY_KP_0);
    if (key == GLFW_KEY_PERIOD || key == GLFW_KEY_KP_DECIMAL) c = '.';
    if (key == GLFW_KEY_MINUS || key == GLFW_KEY_KP_SUBTRACT) c = '-';
    if (key == GLFW_KEY_KP_ADD) c = '+';
    if (key == GLFW_KEY_E) c = 'e';
    if (c && n + 1 < sizeof app->entry_text) {
        app->entry_text[n] = c;
        app->entry_text[n + 1] = '\0';
    } else if (key == GLFW_KEY_BACKSPACE && n > 0) {
        app->entry_text[n - 1] = '\0';
    } else if (key == GLFW_KEY_ENTER || key == GLFW_KEY_KP_ENTER) {
        if (!te_app_set_weight_text(app, app->entry_text)) app->entry = 0;
    } else if (key == GLFW_KEY_ESCAPE) {
        app->entry = 0;
    }
}

/* w: the weight field of the point under the cursor (selecting it) or of the selected one. */
static void open_entry(te_app *app, int have, const double uv[2], double radius)
{
    crisp_trimedit_ref r;
    if (have && crisp_trimedit_pick_point(app->ed, uv, radius, &r)) {
        app->has_sel = 1;
        app->sel = r;
    }
    double w;
    if (!te_app_selected(app, NULL, &w)) {
        say(app, 1, "%s", "no control point selected (press one, or point at one)");
        return;
    }
    app->entry = 1;
    app->entry_text[0] = '\0';
    say(app, 0, "%s", "weight: type it, enter sets it, escape closes");
}

void te_app_key(te_app *app, int key, int action, int mods)
{
    if (action != GLFW_PRESS && action != GLFW_REPEAT) return;
    if (app->entry && !(mods & ~GLFW_MOD_SHIFT)) {
        entry_key(app, key);
        return;
    }
    if (app->poly && (key == GLFW_KEY_ENTER || key == GLFW_KEY_KP_ENTER)) {
        poly_finish(app);
        return;
    }
    if (app->poly && key == GLFW_KEY_BACKSPACE) {
        if (app->poly_n > 0) app->poly_n--;
        return;
    }
    if (app->poly && key == GLFW_KEY_ESCAPE) {
        app->poly = 0;
        say(app, 0, "%s", "polygon cancelled");
        return;
    }
    double uv[2];
    int have = key_uv(app, uv);
    double radius = key_radius(app);
    crisp_trimedit_ref r;
    int l, c;
    double t;
    if (mods & GLFW_MOD_CONTROL) {
        if (key == GLFW_KEY_Z && !(mods & GLFW_MOD_SHIFT))
            edit_done(app, crisp_trimedit_undo(app->ed), "undone");
        else if (key == GLFW_KEY_Y || key == GLFW_KEY_Z)
            edit_done(app, crisp_trimedit_redo(app->ed), "redone");
        else if (key == GLFW_KEY_S)
            edit_done(app, te_app_save(app, app->save_path[0] ? app->save_path : "trimedit.obj"),
                      "saved");
        return;
    }
    switch (key) {
    case GLFW_KEY_I:
        if (have && crisp_trimedit_pick_curve(app->ed, uv, radius, &l, &c, &t))
            edit_done(app, crisp_trimedit_insert_knot(app->ed, l, c, t), "knot inserted");
        else
            say(app, 1, "%s", "no trim curve under the cursor");
        break;
    case GLFW_KEY_K:
        if (have && crisp_trimedit_pick_curve(app->ed, uv, radius, &l, &c, &t)) {
            const crisp_curve *cv = crisp_trimedit_face(app->ed)->loops[l].curves[c];
            int best = -1;
            for (int k = cv->degree + 1; k < cv->count; k++)
                if (best < 0 || fabs(cv->knots[k] - t) < fabs(cv->knots[best] - t)) best = k;
            if (best < 0)
                say(app, 1, "%s", "refused: the curve has no interior knot");
            else
                edit_done(app, crisp_trimedit_remove_knot(app->ed, l, c, best), "knot removed");
        } else {
            say(app, 1, "%s", "no trim curve under the cursor");
        }
        break;
    case GLFW_KEY_X:
    case GLFW_KEY_DELETE:
        if (have && crisp_trimedit_pick_point(app->ed, uv, radius, &r))
            edit_done(app, crisp_trimedit_delete_point(app->ed, r), "control point deleted");
        else
            say(app, 1, "%s", "no control point under the cursor");
        break;
    case GLFW_KEY_EQUAL:
        weight_key(app, 1.25, 0);
        break;
    case GLFW_KEY_MINUS:
        weight_key(app, 1 / 1.25, 0);
        break;
    case GLFW_KEY_0:
        weight_key(app, 0, 1);
        break;
    case GLFW_KEY_B:
        if (have && crisp_trimedit_pick_point(app->ed, uv, radius, &r))
            edit_done(app, crisp_trimedit_snap_point(app->ed, &r), "snapped to the domain edge");
        break;
    case GLFW_KEY_G:
        app->snap = !app->snap;
        say(app, 0, "%s", app->snap ? "snap on" : "snap off");
        break;
    case GLFW_KEY_C:
    case GLFW_KEY_R:
    case GLFW_KEY_P: {
        if (!have) break;
        double d[4];
        crisp_trimedit_domain(app->ed, d);
        double s = 0.05 * fmin(d[1] - d[0], d[3] - d[2]);
        if (key == GLFW_KEY_C) {
            edit_done(app, crisp_trimedit_add_circle(app->ed, uv, s), "circle hole added");
        } else if (key == GLFW_KEY_R) {
            const double lo[2] = {uv[0] - s, uv[1] - 0.6 * s}, hi[2] = {uv[0] + s, uv[1] + 0.6 * s};
            edit_done(app, crisp_trimedit_add_rectangle(app->ed, lo, hi), "rectangle hole added");
        } else {
            double hex[12];
            for (int k = 0; k < 6; k++) {
                hex[2 * k] = uv[0] + s * cos(k * M_PI / 3);
                hex[2 * k + 1] = uv[1] + s * sin(k * M_PI / 3);
            }
            edit_done(app, crisp_trimedit_add_polygon(app->ed, 6, hex), "polygon hole added");
        }
        break;
    }
    case GLFW_KEY_D:
        if (have && crisp_trimedit_pick_curve(app->ed, uv, 2 * radius, &l, &c, &t))
            edit_done(app, crisp_trimedit_delete_loop(app->ed, l), "hole deleted");
        else
            say(app, 1, "%s", "no trim loop under the cursor");
        break;
    case GLFW_KEY_W:
        open_entry(app, have, uv, radius);
        break;
    case GLFW_KEY_N:
        app->poly = 1;
        app->poly_n = 0;
        say(app, 0, "%s",
            "polygon hole: click its corners in the 2D view; enter or the first corner closes "
            "it");
        break;
    case GLFW_KEY_S:
        app->show_strips = !app->show_strips;
        break;
    case GLFW_KEY_L:
        app->show_scanlines = !app->show_scanlines;
        break;
    case GLFW_KEY_F:
        te_app_fit_2d(app);
        break;
    case GLFW_KEY_O: {
        int f = te_app_pick_face(app);
        char buf[64];
        snprintf(buf, sizeof buf, "face %d opened", f);
        if (f < 0)
            say(app, 1, "%s", "no face under the cursor");
        else
            edit_done(app, te_app_open_face(app, f), buf);
        break;
    }
    default:
        break;
    }
}

static int classify_plan(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)sc;
    return crisp_plan_trim_test((const crisp_frame_plan *)ctx, face, u, v);
}

int te_app_pick_face(te_app *app)
{
    if (!app->plan || !in_rect(&app->view3d, app->cursor)) return -1;
    double o[3], dir[3], t, uv[2];
    uint32_t face;
    crisp_camera_ray(&app->cam, app->cursor[0] - app->view3d.x, app->cursor[1] - app->view3d.y, o,
                     dir);
    crisp_exact_desc d = {
        .threads = 1, .classify = classify_plan, .classify_ctx = (void *)app->plan};
    if (!crisp_exact_ray(app->scene, &d, o, dir, 0.0, INFINITY, &t, &face, uv, NULL)) return -1;
    return (int)face;
}

crisp_status te_app_open_face(te_app *app, int face)
{
    if (face < 0 || face >= app->model->face_count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "face %d: the model has %d faces", face,
                           app->model->face_count);
    if (face == app->face) return CRISP_OK;
    int old = app->face;
    crisp_status st = open_face(app, face);
    if (st) {
        /* Back to the face that was open (its loops are as the editor left them). */
        crisp_status st2 = open_face(app, old);
        (void)st2;
    }
    return st;
}

crisp_status te_app_save(te_app *app, const char *path)
{
    crisp_status st = crisp_write_obj(app->model, path);
    if (!st) say(app, 0, "saved %s", path);
    return st;
}

/* ---- the 2D view ----------------------------------------------------------------------------- */

/* Clip the segment p-q to the 2D view (Liang-Barsky); 0 when nothing is left. */
static int clip_to_view(const te_rect *r, double p[2], double q[2])
{
    double t0 = 0, t1 = 1, dx = q[0] - p[0], dy = q[1] - p[1];
    const double pk[4] = {-dx, dx, -dy, dy};
    const double qk[4] = {p[0] - r->x, r->x + r->w - p[0], p[1] - r->y, r->y + r->h - p[1]};
    for (int k = 0; k < 4; k++) {
        if (pk[k] == 0) {
            if (qk[k] < 0) return 0;
            continue;
        }
        double t = qk[k] / pk[k];
        if (pk[k] < 0) {
            if (t > t1) return 0;
            if (t > t0) t0 = t;
        } else {
            if (t < t0) return 0;
            if (t < t1) t1 = t;
        }
    }
    double a[2] = {p[0] + t0 * dx, p[1] + t0 * dy}, b[2] = {p[0] + t1 * dx, p[1] + t1 * dy};
    p[0] = a[0], p[1] = a[1], q[0] = b[0], q[1] = b[1];
    return 1;
}

static void line_uv(te_app *app, const te_draw *d, const double a[2], const double b[2],
                    uint32_t color, double width)
{
    double p[2], q[2];
    te_app_uv_to_px(app, a, p);
    te_app_uv_to_px(app, b, q);
    if (clip_to_view(&app->view2d, p, q)) d->line(d->ctx, p[0], p[1], q[0], q[1], color, width);
}

static void circle_px(te_app *app, const te_draw *d, const double px[2], double r, uint32_t color,
                      int filled)
{
    const te_rect *v = &app->view2d;
    if (px[0] - r >= v->x && px[0] + r <= v->x + v->w && px[1] - r >= v->y &&
        px[1] + r <= v->y + v->h)
        d->circle(d->ctx, px[0], px[1], r, color, filled);
}

long te_app_draw_2d(te_app *app, const te_draw *d)
{
    double dom[4];
    crisp_trimedit_domain(app->ed, dom);
    const double c00[2] = {dom[0], dom[2]}, c10[2] = {dom[1], dom[2]}, c11[2] = {dom[1], dom[3]},
                 c01[2] = {dom[0], dom[3]};
    const uint32_t grey = 0xff808080u;
    line_uv(app, d, c00, c10, grey, 1);
    line_uv(app, d, c10, c11, grey, 1);
    line_uv(app, d, c11, c01, grey, 1);
    line_uv(app, d, c01, c00, grey, 1);
    long scan_lines = 0;
    const crisp_frame_plan *plan = app->plan;
    if (plan && (uint32_t)app->face < plan->face_count) {
        const crisp_plan_face *pf = &plan->faces[app->face];
        for (uint32_t s = 0; s < pf->strip_count; s++) {
            const crisp_plan_strip *st = &plan->strips[pf->first_strip + s];
            double v = pf->v0 + s / pf->strip_scale;
            if (app->show_strips) {
                const double a[2] = {dom[0], v}, b[2] = {dom[1], v};
                line_uv(app, d, a, b, 0xc0c08040u, 1.5);
            }
            if (!app->show_scanlines || !st->row_count) continue;
            double spacing = app->uv_scale / st->row_scale; /* pixels between scan lines */
            uint32_t every = spacing >= 3 ? 1 : (uint32_t)ceil(3 / spacing);
            for (uint32_t j = 0; j < st->row_count; j += every) {
                double vs = st->a + (j + 0.5) / st->row_scale;
                const double a[2] = {dom[0], vs}, b[2] = {dom[1], vs};
                line_uv(app, d, a, b, 0x40a0a0a0u, 1);
                scan_lines++;
            }
        }
        if (app->show_strips && pf->strip_count) {
            const double a[2] = {dom[0], pf->v1}, b[2] = {dom[1], pf->v1};
            line_uv(app, d, a, b, 0xc0c08040u, 1.5);
        }
    }
    const crisp_trimedit_report *rep = crisp_trimedit_check(app->ed);
    const crisp_face *f = crisp_trimedit_face(app->ed);
    for (int l = 0; l < f->loop_count; l++) {
        int bad = l < 64 && rep->flags[l];
        uint32_t color = bad ? 0xff3030ffu : f->loops[l].is_outer ? 0xff40e0ffu : 0xffffd040u;
        for (int c = 0; c < f->loops[l].curve_count; c++) {
            const crisp_curve *cv = f->loops[l].curves[c];
            const int p = cv->degree;
            /* The curve, span by span, and its knots. */
            for (int k = p; k < cv->count; k++) {
                double a = cv->knots[k], b = cv->knots[k + 1];
                if (!(a < b)) continue;
                int n = 12 * p;
                double q0[2], q1[2], px[2];
                crisp_curve_eval(cv, a, q0);
                te_app_uv_to_px(app, q0, px);
                circle_px(app, d, px, 2.0, 0xff2080ffu, 1);
                for (int i = 1; i <= n; i++) {
                    crisp_curve_eval(cv, a + (b - a) * i / n, q1);
                    line_uv(app, d, q0, q1, color, 2);
                    q0[0] = q1[0];
                    q0[1] = q1[1];
                }
            }
            /* Control polygon and points (radius grows with the weight). */
            for (int i = 0; i < cv->count; i++) {
                double uv[2], w, px[2];
                crisp_trimedit_point(app->ed, (crisp_trimedit_ref){l, c, i}, uv, &w);
                if (i + 1 < cv->count) {
                    double uv2[2];
                    crisp_trimedit_point(app->ed, (crisp_trimedit_ref){l, c, i + 1}, uv2, NULL);
                    line_uv(app, d, uv, uv2, 0x80c0c0c0u, 1);
                }
                te_app_uv_to_px(app, uv, px);
                int active = (app->drag == TE_DRAG_POINT && app->drag_ref.loop == l &&
                              app->drag_ref.curve == c && app->drag_ref.index == i) ||
                             (app->drag == TE_DRAG_NONE && app->has_sel && app->sel.loop == l &&
                              app->sel.curve == c && app->sel.index == i);
                double rad = fmin(9.0, fmax(2.5, 3.5 * sqrt(w)));
                circle_px(app, d, px, rad, active ? 0xff00ffffu : 0xffffffffu, active);
            }
        }
    }
    if (app->poly) {
        /* The polygon being drawn, and the edge to the cursor. */
        for (int k = 0; k < app->poly_n; k++) {
            double px[2];
            te_app_uv_to_px(app, app->poly_uv + 2 * k, px);
            circle_px(app, d, px, 3.5, 0xff40ff40u, 1);
            if (k + 1 < app->poly_n)
                line_uv(app, d, app->poly_uv + 2 * k, app->poly_uv + 2 * k + 2, 0xff40ff40u, 1.5);
        }
        if (app->poly_n > 0) {
            double cur[2];
            te_app_px_to_uv(app, app->cursor, cur);
            line_uv(app, d, app->poly_uv + 2 * (app->poly_n - 1), cur, 0x8040ff40u, 1);
        }
    }
    return scan_lines;
}
