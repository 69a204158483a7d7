/* crisp-view's panels (Dear ImGui through ui.h): the HUD (frame time, triangles, table bytes,
 * refined or not), the help overlay, the model panel (file, box, units, face info, measure
 * results, camera), load progress, errors, measure markers and the axis widget (click a tip to
 * look from that axis). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ui.h"
#include "view.h"

static const char *const help_lines[][2] = {
    {"left drag", "orbit about the point under the cursor"},
    {"right / middle drag, shift+left", "pan"},
    {"wheel", "zoom to the cursor"},
    {"left click", "select a face (info panel); first measure point"},
    {"shift+left click", "measure: distance and angle to the first point"},
    {"V", "clicks snap to the face's vertices (within 8 px) on / off"},
    {"F", "fit all"},
    {"Delete / U", "hide the selected face / show every face"},
    {"0 1 2 3 4 5 6", "isometric, front, top, right, back, bottom, left"},
    {"axis widget", "click a tip: look from that axis"},
    {"O", "orthographic / perspective"},
    {"A", "anti-aliasing: 4 or 1 samples per pixel (refined frames, screenshots)"},
    {"E", "edges (face borders, trims, silhouettes) on / off"},
    {"W", "wireframe of the current tessellation (the plan's leaves)"},
    {"T", "the selected face's trim table: scan lines in (u, v)"},
    {"G / shift+G", "the selected face transparent / every face opaque again"},
    {"X", "section plane on / off (capped, hatched cut)"},
    {"N / shift+N", "section plane: next axis (x, y, z) / flip the kept side"},
    {"- / =", "move the section plane along its axis (1/50 of the box)"},
    {"R", "reload the file (keeps the camera)"},
    {"drop a file", "open it"},
    {"Esc", "cancel a load; clear the selection"},
    {"C", "print the camera as `crisp render` options"},
    {"ctrl+S / ctrl+L", "save / load the camera (crisp-view.camera)"},
    {"F12", "screenshot (crisp-view-NNN.png, rendered off-screen)"},
    {"I / P", "HUD / panels on / off"},
    {"H or F1", "this help"},
    {"ctrl+Q", "quit"},
};

static void basis(const crisp_camera *c, double r[3], double u[3])
{
    double d[3], f[3], s[3];
    crisp_vec3_sub(c->target, c->eye, d);
    crisp_vec3_normalize(d, f);
    crisp_vec3_cross(f, c->up, s);
    crisp_vec3_normalize(s, r);
    crisp_vec3_cross(r, f, u);
}

void view_axis_widget(const view *v, float centre[2], float tips[6][2])
{
    double r[3], u[3];
    basis(&v->nav.cam, r, u);
    centre[0] = 56;
    centre[1] = (float)v->fb_h - 56;
    const float len = 38;
    for (int a = 0; a < 3; a++) {
        double x = r[a], y = -u[a];
        tips[a][0] = centre[0] + len * (float)x;
        tips[a][1] = centre[1] + len * (float)y;
        tips[a + 3][0] = centre[0] - len * (float)x;
        tips[a + 3][1] = centre[1] - len * (float)y;
    }
}

static void draw_axes(const view *v)
{
    float c[2], t[6][2];
    view_axis_widget(v, c, t);
    static const uint32_t col[3] = {0xff4040ffu, 0xff40d040u, 0xffff8040u};
    static const char *names[3] = {"X", "Y", "Z"};
    app_ui_circle(c[0], c[1], 48, 0x50000000u, 1);
    for (int a = 0; a < 3; a++) {
        app_ui_line(c[0], c[1], t[a][0], t[a][1], col[a], 2.5f);
        app_ui_circle(t[a][0], t[a][1], 8, col[a], 1);
        app_ui_label(t[a][0] - 3.5f, t[a][1] - 7, 0xff000000u, names[a]);
        app_ui_circle(t[a + 3][0], t[a + 3][1], 6, col[a], 0);
    }
}

/* Screen position of a world point in the current camera; 0 when behind the eye. */
static int project(const view *v, const double p[3], float *x, float *y)
{
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(&v->nav.cam, &m);
    double clip[4], px[3];
    crisp_mat4_mulp(m.view_proj, p, clip);
    if (!(clip[3] > 0)) return 0;
    crisp_camera_to_pixel(&v->nav.cam, clip, px);
    *x = (float)px[0];
    *y = (float)px[1];
    return 1;
}

static void draw_measure(const view *v)
{
    float xa, ya, xb, yb;
    if (v->meas_count >= 1 && project(v, v->meas_a.point, &xa, &ya))
        app_ui_circle(xa, ya, 4, 0xff00ffffu, 1);
    if (v->meas_count == 2 && project(v, v->meas_b.point, &xb, &yb)) {
        app_ui_circle(xb, yb, 4, 0xff00ffffu, 1);
        if (project(v, v->meas_a.point, &xa, &ya)) app_ui_line(xa, ya, xb, yb, 0xff00ffffu, 1.5f);
    }
}

void view_draw_panels(view *v)
{
    char path[1024];
    double secs;
    if (app_loader_status(v->loader, path, sizeof path, &secs)) {
        if (app_ui_begin("Loading", -10, 10, 360, 0)) {
            app_ui_wrapped("%s", path);
            /* a reader that reports its share fills the bar; else it runs in circles */
            double frac = app_loader_progress(v->loader);
            char o[64];
            if (frac >= 0)
                snprintf(o, sizeof o, "%.0f%%, %.1f s", 100 * frac, secs);
            else
                snprintf(o, sizeof o, "reading, %.1f s", secs);
            app_ui_progress(frac >= 0 ? (float)frac : (float)fmod(secs, 1.0), o);
            if (app_ui_button("Cancel (Esc)")) app_loader_cancel(v->loader);
        }
        app_ui_end();
    }
    if (v->error[0]) {
        if (app_ui_begin("Error", -10, -10, 460, 0)) {
            app_ui_text_color(1, 0.45f, 0.4f, "Could not open or show:");
            app_ui_wrapped("%s", v->error);
            if (app_ui_button("Dismiss")) v->error[0] = '\0';
        }
        app_ui_end();
    }
    if (v->show_hud && v->doc) {
        if (app_ui_begin("##hud", 10, 10, 0, APP_UI_OVERLAY)) {
            app_ui_text("%.1f ms (%s, %dx%d%s)", v->last.ms, v->backend.name,
                        v->nav.cam.width / (v->last.scale > 0 ? v->last.scale : 1),
                        v->nav.cam.height / (v->last.scale > 0 ? v->last.scale : 1),
                        v->last.scale > 1 ? ", moving" : "");
            app_ui_text("triangles %llu", (unsigned long long)v->last.triangles);
            app_ui_text("table bytes %llu", (unsigned long long)v->last.table_bytes);
            if (v->refined)
                app_ui_text_color(0.5f, 1, 0.5f, "refined (%d samples)", v->ov.samples);
            else
                app_ui_text_color(1, 0.8f, 0.3f, "not refined (1/%d)", v->last.scale);
            app_ui_text("%s", v->nav.ortho ? "orthographic" : "perspective");
            if (v->section)
                app_ui_text("section %c = %g%s", 'x' + v->section_axis, v->section_pos,
                            v->section_flip ? " (flipped)" : "");
            if (v->show_wire)
                app_ui_text("wireframe: %u leaves, %zu segments%s", v->wire_leaves, v->wire_count,
                            v->wire_truncated ? " (truncated)" : "");
        }
        app_ui_end();
    }
    if (v->show_help) {
        if (app_ui_begin("Keys and mouse (H)", 180, 40, 0, 0)) {
            for (size_t i = 0; i < sizeof help_lines / sizeof help_lines[0]; i++)
                app_ui_text("%-32s %s", help_lines[i][0], help_lines[i][1]);
        }
        app_ui_end();
    }
    if (v->show_panels && v->doc) {
        const app_doc *d = v->doc;
        if (app_ui_begin("Model", -10, 120, 340, 0)) {
            app_ui_wrapped("%s", d->path);
            app_ui_text("%s: %u faces, %u patches, %zu f-rep parts", d->kind, d->scene->face_count,
                        d->scene->patch_count, d->part_count);
            double mm = d->scene->model->unit_to_mm;
            app_ui_text("box %.4g..%.4g  %.4g..%.4g  %.4g..%.4g", d->box[0], d->box[3], d->box[1],
                        d->box[4], d->box[2], d->box[5]);
            app_ui_text("units: %g mm%s", mm, mm == 1 ? " (or unknown)" : "");
            if (v->face_info[0]) {
                app_ui_separator();
                app_ui_text("Selected");
                app_ui_wrapped("%s", v->face_info);
            }
            if (v->meas_count == 2) {
                double dd[3];
                crisp_vec3_sub(v->meas_b.point, v->meas_a.point, dd);
                double dot = crisp_vec3_dot(v->meas_a.normal, v->meas_b.normal);
                app_ui_separator();
                app_ui_text("Measure");
                app_ui_text("distance %.9g", crisp_vec3_norm(dd));
                app_ui_text("angle between faces %.4f deg", acos(dot > 1    ? 1
                                                                 : dot < -1 ? -1
                                                                            : dot) *
                                                                180 / M_PI);
            } else if (v->meas_count == 1) {
                app_ui_separator();
                app_ui_text("Measure: shift+click a second point");
            }
            if (v->camera_text[0]) {
                app_ui_separator();
                app_ui_text("Camera (C) as crisp render options:");
                app_ui_wrapped("%s", v->camera_text);
            }
        }
        app_ui_end();
    }
    if (v->show_scan) view_scan_panel(v);
    if (v->show_panels) view_parts_panel(v);
    if (v->doc) {
        if (v->show_wire) view_wire_draw(v);
        draw_axes(v);
        draw_measure(v);
    }
}
