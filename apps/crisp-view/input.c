/* crisp-view's input: GLFW callbacks (the replay calls the same functions), mouse navigation
 * (left drag orbits about the point under the cursor, right or middle drag or shift + left drag
 * pans, the wheel zooms to the cursor), clicks (select a face, measure between two points) and
 * keys (README.md, "crisp-view"). Picking casts the exact ray through the pixel (crisp_exact_ray
 * with the exact trim classifier), so a picked point lies on the true trimmed surface. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/io.h"
#include "crisp/trim.h"
#include "ui.h"
#include "view.h"

static view *of(GLFWwindow *w)
{
    return glfwGetWindowUserPointer(w);
}

static int classify_exact(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)ctx;
    const crisp_scene_face *f = &sc->faces[face];
    if (f->piece_count == 0) return 1;
    return crisp_trim_exact_classify(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
}

int view_pick(view *v, double x, double y, view_hit *h)
{
    memset(h, 0, sizeof *h);
    h->face = -1;
    if (!v->doc || v->rdoc.scene->patch_count == 0) return 0;
    double o[3], d[3];
    crisp_camera_ray(&v->nav.cam, x, y, o, d);
    crisp_exact_desc desc = {.threads = 1, .classify = classify_exact};
    double t, t0 = 0, t1 = INFINITY, pl[4];
    uint32_t face;
    if (view_section_plane(v, pl)) { /* only what the section keeps */
        double ne = pl[0] * o[0] + pl[1] * o[1] + pl[2] * o[2] + pl[3],
               nd = pl[0] * d[0] + pl[1] * d[1] + pl[2] * d[2];
        double tp = nd != 0 ? -ne / nd : INFINITY;
        if (ne < 0 && !(nd > 0)) return 0; /* on the cut side, looking away */
        if (ne < 0) t0 = tp;
        if (ne >= 0 && nd < 0) t1 = tp;
    }
    if (!crisp_exact_ray(v->rdoc.scene, &desc, o, d, t0, t1, &t, &face, h->uv, h->normal)) return 0;
    h->hit = 1;
    h->face = view_doc_face(v, (int32_t)face);
    for (int i = 0; i < 3; i++)
        h->point[i] = o[i] + t * d[i];
    h->depth = app_nav_depth(&v->nav.cam, h->point);
    return 1;
}

/* Area of a trimmed face: midpoint rule on a 96 x 96 grid over its loops' uv box, each cell
 * centre classified against the true trim curves. */
static double face_area(const crisp_scene *sc, uint32_t fi)
{
    const crisp_scene_face *f = &sc->faces[fi];
    double box[4] = {f->domain[0], f->domain[1], f->domain[2], f->domain[3]};
    if (f->piece_count) {
        box[0] = box[2] = INFINITY;
        box[1] = box[3] = -INFINITY;
        for (uint32_t p = 0; p < f->piece_count; p++) {
            const crisp_bezier_curve *c = &sc->pieces[f->first_piece + p];
            for (int k = 0; k <= c->degree; k++) {
                const double *q = c->cpw + 3 * k; /* homogeneous (w u, w v, w) */
                double u = q[0] / q[2], vv = q[1] / q[2];
                box[0] = fmin(box[0], u);
                box[1] = fmax(box[1], u);
                box[2] = fmin(box[2], vv);
                box[3] = fmax(box[3], vv);
            }
        }
    }
    enum { N = 96 };
    double du = (box[1] - box[0]) / N, dv = (box[3] - box[2]) / N, area = 0;
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            double u = box[0] + (i + 0.5) * du, vv = box[2] + (j + 0.5) * dv;
            if (!classify_exact(NULL, sc, fi, u, vv)) continue;
            double su[3], sv[3], n[3];
            crisp_surface_derivs(f->src->surface, u, vv, NULL, su, sv, NULL, NULL, NULL);
            crisp_vec3_cross(su, sv, n);
            area += crisp_vec3_norm(n) * du * dv;
        }
    return area;
}

void view_describe_face(view *v, int32_t fi, char *buf, size_t size)
{
    const crisp_scene *sc = v->doc->scene;
    if (fi < 0 || (uint32_t)fi >= sc->face_count) {
        snprintf(buf, size, "face %d", fi);
        return;
    }
    const crisp_face *f = sc->faces[fi].src;
    const crisp_surface *s = f->surface;
    int outer = 0, holes = 0, curves = 0;
    for (int l = 0; l < f->loop_count; l++) {
        if (f->loops[l].is_outer)
            outer++;
        else
            holes++;
        curves += f->loops[l].curve_count;
    }
    const char *fmt = v->doc->scene->model->format;
    const char *src = !strcmp(fmt, "IGES") ? "IGES DE " : !strcmp(fmt, "STEP") ? "STEP #" : "line ";
    snprintf(buf, size,
             "face %d source %s%d surface %s degree %dx%d control points %dx%d loops %d outer "
             "%d holes %d trim curves area %.9g%s",
             fi, src, f->source_id, s->rational ? "rational-B-spline" : "B-spline", s->degree_u,
             s->degree_v, s->count_u, s->count_v, outer, holes, curves, face_area(sc, (uint32_t)fi),
             f->reversed ? " reversed" : "");
}

/* Snap a hit to the nearest vertex of its face within 8 px of the cursor: the start point of a
 * trim curve (or a corner of an untrimmed face's domain) mapped through the surface, exactly. */
static int snap_vertex(view *v, view_hit *h, double x, double y)
{
    if (!h->hit || h->face < 0) return 0;
    const crisp_face *f = v->doc->scene->faces[h->face].src;
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(&v->nav.cam, &m);
    double best = 8, bp[3], buv[2];
    int found = 0;
    int n = 0;
    for (int l = 0; l < f->loop_count; l++)
        n += f->loops[l].curve_count;
    double dom[4];
    crisp_surface_domain(f->surface, dom);
    for (int k = 0; k < (n ? n : 4); k++) {
        double uv[2];
        if (n) {
            const crisp_curve *c = NULL;
            int kk = k;
            for (int l = 0; l < f->loop_count && !c; l++) {
                if (kk < f->loops[l].curve_count)
                    c = f->loops[l].curves[kk];
                else
                    kk -= f->loops[l].curve_count;
            }
            double t0, t1;
            crisp_curve_domain(c, &t0, &t1);
            crisp_curve_eval(c, t0, uv);
        } else {
            uv[0] = dom[k & 1];
            uv[1] = dom[2 + (k >> 1)];
        }
        double p[3], clip[4], px[3];
        crisp_surface_eval(f->surface, uv[0], uv[1], p);
        crisp_mat4_mulp(m.view_proj, p, clip);
        if (!(clip[3] > 0)) continue;
        crisp_camera_to_pixel(&v->nav.cam, clip, px);
        double d = hypot(px[0] - x, px[1] - y);
        if (d < best) {
            best = d;
            memcpy(bp, p, sizeof bp);
            memcpy(buv, uv, sizeof buv);
            found = 1;
        }
    }
    if (!found) return 0;
    memcpy(h->point, bp, sizeof bp);
    memcpy(h->uv, buv, sizeof buv);
    h->depth = app_nav_depth(&v->nav.cam, h->point);
    return 1;
}

void view_set_standard(view *v, int which)
{
    app_nav_view(&v->nav, which);
    app_nav_fit_points(&v->nav, v->doc ? v->doc->doc->points : NULL,
                       v->doc ? v->doc->doc->point_count : 0);
    v->dirty = 1;
    printf("view: %s\n", app_view_names[which]);
}

static void click(view *v, double x, double y, int mods)
{
    /* the axis widget first: a tip sets the view looking at the model from that axis */
    float c[2], tips[6][2];
    view_axis_widget(v, c, tips);
    static const int from_axis[6] = {APP_VIEW_RIGHT, APP_VIEW_BACK,  APP_VIEW_TOP,
                                     APP_VIEW_LEFT,  APP_VIEW_FRONT, APP_VIEW_BOTTOM};
    for (int a = 0; a < 6; a++)
        if (hypot(x - tips[a][0], y - tips[a][1]) < 9) {
            view_set_standard(v, from_axis[a]);
            return;
        }
    view_hit h;
    view_pick(v, x, y, &h);
    int snapped = v->snap && snap_vertex(v, &h, x, y);
    if (mods & GLFW_MOD_SHIFT) {
        if (!h.hit) return;
        if (v->meas_count == 0) {
            v->meas_a = h;
            v->meas_count = 1;
        } else {
            v->meas_b = h;
            v->meas_count = 2;
            double d[3];
            crisp_vec3_sub(v->meas_b.point, v->meas_a.point, d);
            double dot = crisp_vec3_dot(v->meas_a.normal, v->meas_b.normal);
            double ang = acos(dot > 1 ? 1 : dot < -1 ? -1 : dot) * 180 / M_PI;
            const double *a = v->meas_a.point, *b = v->meas_b.point;
            printf("measure: distance %.17g angle %.9g deg between faces %d and %d from "
                   "%.17g,%.17g,%.17g to %.17g,%.17g,%.17g%s\n",
                   crisp_vec3_norm(d), ang, v->meas_a.face, v->meas_b.face, a[0], a[1], a[2], b[0],
                   b[1], b[2], snapped ? " (to a vertex)" : "");
        }
        return;
    }
    v->sel = h;
    v->ov.selected_face = h.hit ? view_drawn_face(v, h.face) : -1;
    v->dirty = 1;
    v->meas_a = h;
    v->meas_count = h.hit ? 1 : 0;
    if (!h.hit) {
        v->face_info[0] = '\0';
        printf("pick: %.2f %.2f: nothing\n", x, y);
        return;
    }
    view_describe_face(v, h.face, v->face_info, sizeof v->face_info);
    printf("pick: %.2f %.2f: %s point %.17g,%.17g,%.17g normal %.9g,%.9g,%.9g uv %.17g,%.17g%s\n",
           x, y, v->face_info, h.point[0], h.point[1], h.point[2], h.normal[0], h.normal[1],
           h.normal[2], h.uv[0], h.uv[1], snapped ? " vertex" : "");
}

void view_on_cursor(GLFWwindow *w, double x, double y)
{
    view *v = of(w);
    double dx = x - v->mx, dy = y - v->my;
    v->mx = x;
    v->my = y;
    if (v->drag_button < 0 || !v->doc) return;
    if (!v->dragged && hypot(x - v->press_x, y - v->press_y) < 3) return;
    v->dragged = 1;
    int pan = v->drag_button != GLFW_MOUSE_BUTTON_LEFT || (v->drag_mods & GLFW_MOD_SHIFT);
    if (pan)
        app_nav_pan(&v->nav, v->drag_depth, dx, dy);
    else
        app_nav_orbit(&v->nav, v->pivot, dx, dy);
    v->dirty = 1;
    v->moving = 1;
}

void view_on_button(GLFWwindow *w, int button, int action, int mods)
{
    view *v = of(w);
    app_ui_on_button(w, button, action, mods);
    if (action == GLFW_PRESS) {
        if (app_ui_wants_mouse() || v->drag_button >= 0) return;
        v->drag_button = button;
        v->drag_mods = mods;
        v->dragged = 0;
        v->press_x = v->mx;
        v->press_y = v->my;
        view_hit h;
        if (v->doc && view_pick(v, v->mx, v->my, &h)) {
            memcpy(v->pivot, h.point, sizeof v->pivot);
            v->drag_depth = h.depth;
        } else {
            memcpy(v->pivot, v->nav.cam.target, sizeof v->pivot);
            v->drag_depth = app_nav_depth(&v->nav.cam, v->nav.cam.target);
        }
    } else if (action == GLFW_RELEASE && button == v->drag_button) {
        v->drag_button = -1;
        if (!v->dragged && button == GLFW_MOUSE_BUTTON_LEFT && v->doc) click(v, v->mx, v->my, mods);
        v->dragged = 0;
    }
}

void view_on_scroll(GLFWwindow *w, double dx, double dy)
{
    view *v = of(w);
    app_ui_on_scroll(w, dx, dy);
    if (app_ui_wants_mouse() || !v->doc || dy == 0) return;
    view_hit h;
    double p[3];
    if (view_pick(v, v->mx, v->my, &h))
        memcpy(p, h.point, sizeof p);
    else
        app_nav_focus_point(&v->nav, v->mx, v->my, p);
    app_nav_zoom(&v->nav, p, pow(0.8, dy));
    /* the point under the cursor is in view: the near plane must stay in front of it */
    double dp = app_nav_depth(&v->nav.cam, p);
    if (h.hit && dp > 0 && (v->nav.depth_hint <= 0 || dp < v->nav.depth_hint))
        v->nav.depth_hint = dp;
    v->dirty = 1;
    v->moving = 1;
}

static void camera_file(view *v, int save)
{
    const char *path = "crisp-view.camera";
    if (save) {
        view_print_camera(v);
        FILE *f = fopen(path, "w");
        if (!f || fprintf(f, "%s\n", v->camera_text) < 0 || fclose(f)) {
            view_set_error(v, "%s: cannot write the camera", path);
            return;
        }
        printf("camera saved: %s\n", path);
        return;
    }
    char *data = NULL;
    size_t size = 0;
    char err[256];
    crisp_camera c = v->nav.cam;
    if (crisp_read_file(path, &data, &size)) {
        view_set_error(v, "%s", crisp_error_message());
        return;
    }
    int ok = app_nav_parse(data, &c, err, sizeof err);
    crisp_free(data);
    if (!ok) {
        view_set_error(v, "%s: %s", path, err);
        return;
    }
    c.width = v->nav.cam.width;
    c.height = v->nav.cam.height;
    v->nav.cam = c;
    v->nav.depth_hint = 0;
    v->dirty = 1;
    printf("camera loaded: %s\n", path);
}

void view_on_key(GLFWwindow *w, int key, int scancode, int action, int mods)
{
    view *v = of(w);
    app_ui_on_key(w, key, scancode, action, mods);
    if (action == GLFW_RELEASE || app_ui_wants_keyboard()) return;
    if (key >= GLFW_KEY_0 && key <= GLFW_KEY_6) {
        view_set_standard(v, key - GLFW_KEY_0);
        return;
    }
    switch (key) {
    case GLFW_KEY_H:
    case GLFW_KEY_F1:
        v->show_help = !v->show_help;
        break;
    case GLFW_KEY_F:
        app_nav_fit_points(&v->nav, v->doc ? v->doc->doc->points : NULL,
                           v->doc ? v->doc->doc->point_count : 0);
        v->dirty = 1;
        printf("view: fit\n");
        break;
    case GLFW_KEY_O:
        app_nav_set_ortho(&v->nav, !v->nav.ortho);
        v->dirty = 1;
        printf("view: %s\n", v->nav.ortho ? "orthographic" : "perspective");
        break;
    case GLFW_KEY_R:
        if (v->doc_path) view_open(v, v->doc_path, 1);
        break;
    case GLFW_KEY_ESCAPE: {
        char p[8];
        double s;
        if (app_loader_status(v->loader, p, sizeof p, &s)) {
            app_loader_cancel(v->loader);
            printf("load cancelled\n");
        } else {
            v->sel.hit = 0;
            v->ov.selected_face = -1;
            v->meas_count = 0;
            v->face_info[0] = '\0';
            v->error[0] = '\0';
            v->dirty = 1;
        }
        break;
    }
    case GLFW_KEY_I:
        v->show_hud = !v->show_hud;
        break;
    case GLFW_KEY_P:
        v->show_panels = !v->show_panels;
        break;
    case GLFW_KEY_X:
    case GLFW_KEY_N:
    case GLFW_KEY_MINUS:
    case GLFW_KEY_EQUAL:
        view_section_key(v, key, mods);
        break;
    case GLFW_KEY_E:
        v->ov.edges = !v->ov.edges;
        v->dirty = 1;
        break;
    case GLFW_KEY_C:
        view_print_camera(v);
        break;
    case GLFW_KEY_W:
        v->show_wire = !v->show_wire;
        v->dirty = 1;
        break;
    case GLFW_KEY_T:
        v->show_scan = !v->show_scan;
        break;
    case GLFW_KEY_V:
        v->snap = !v->snap;
        printf("snap to vertices: %s\n", v->snap ? "on" : "off");
        break;
    case GLFW_KEY_DELETE:
        if (v->doc && v->sel.hit && v->sel.face >= 0 && v->face_hidden) {
            v->face_hidden[v->sel.face] = 1;
            printf("hidden: face %d\n", v->sel.face);
            v->sel.hit = 0;
            v->meas_count = 0;
            v->face_info[0] = '\0';
            view_visible_update(v);
        }
        break;
    case GLFW_KEY_G: /* transparency: the selected face; shift: every face opaque again */
        if (v->doc && v->face_hidden && (mods & GLFW_MOD_SHIFT)) {
            for (uint32_t f = 0; f < v->doc->scene->face_count; f++)
                if (v->face_hidden[f] == 2) v->face_hidden[f] = 0;
            printf("transparent: none\n");
            view_visible_update(v);
        } else if (v->doc && v->sel.hit && v->sel.face >= 0 && v->face_hidden) {
            v->face_hidden[v->sel.face] = 2;
            printf("transparent: face %d\n", v->sel.face);
            v->sel.hit = 0;
            v->ov.selected_face = -1;
            view_visible_update(v);
        }
        break;
    case GLFW_KEY_U:
        if (v->doc && v->face_hidden && (v->hidden_faces || v->trans_faces)) {
            memset(v->face_hidden, 0, v->doc->scene->face_count);
            view_visible_update(v);
        }
        break;
    case GLFW_KEY_A:
        v->ov.samples = v->ov.samples == 4 ? 1 : 4;
        v->dirty = 1;
        printf("anti-aliasing: %d samples per pixel\n", v->ov.samples);
        break;
    case GLFW_KEY_S:
        if (mods & GLFW_MOD_CONTROL) camera_file(v, 1);
        break;
    case GLFW_KEY_L:
        if (mods & GLFW_MOD_CONTROL) camera_file(v, 0);
        break;
    case GLFW_KEY_F12: {
        static int n;
        char path[64];
        snprintf(path, sizeof path, "crisp-view-%03d.png", n++);
        if (view_screenshot(v, path, NULL, 0, 0)) view_set_error(v, "%s", crisp_error_message());
        break;
    }
    case GLFW_KEY_Q:
        if (mods & GLFW_MOD_CONTROL) glfwSetWindowShouldClose(w, GLFW_TRUE);
        break;
    default:
        break;
    }
}

void view_on_char(GLFWwindow *w, unsigned int c)
{
    app_ui_on_char(w, c);
}

void view_on_drop(GLFWwindow *w, int count, const char **paths)
{
    view *v = of(w);
    if (count < 1) return;
    printf("dropped: %s\n", paths[0]);
    view_open(v, paths[0], 0);
}

void view_on_close(GLFWwindow *w)
{
    view *v = of(w);
    char p[8];
    double s;
    if (app_loader_status(v->loader, p, sizeof p, &s)) printf("closing during a load\n");
}

static void cb_close(GLFWwindow *w)
{
    view_on_close(w);
}

void view_install_callbacks(view *v)
{
    glfwSetCursorPosCallback(v->win, view_on_cursor);
    glfwSetMouseButtonCallback(v->win, view_on_button);
    glfwSetScrollCallback(v->win, view_on_scroll);
    glfwSetKeyCallback(v->win, view_on_key);
    glfwSetCharCallback(v->win, view_on_char);
    glfwSetDropCallback(v->win, view_on_drop);
    glfwSetWindowCloseCallback(v->win, cb_close);
}
