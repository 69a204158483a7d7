/* Default cameras: named views (front, back, left, right, top, bottom, iso) and a perspective
 * camera fitted tightly to a box along a given direction. Conventions as docs/design.md, camera
 * section (gluLookAt / gluPerspective, vertical fov); the named views take +Z as up, as CAD
 * files mostly do (the bundled IGES and STEP models stand on the XY plane).
 *
 * The fit: in the camera's frame (x right, y up, z forward) a corner p is on screen with margin
 * when |p_x - e_x| <= t_x (p_z - e_z) and the same in y, with t_x = (1 - margin) tan(fov_x / 2).
 * Per axis these are two families of lines in (e_x, e_z); the largest e_z (the nearest eye) they
 * allow is (A + B) / 2 at e_x = t_x (B - A) / 2, where A = min (p_z - p_x / t_x) and
 * B = min (p_z + p_x / t_x). The eye takes the smaller of the two axes' e_z, and the middle of
 * each axis's allowed interval, which is that same e_x at every e_z. */
#include <math.h>
#include <string.h>

#include "crisp/app.h"

static const struct {
    const char *name;
    double dir[3], up[3];
} views[] = {
    [CRISP_VIEW_DEFAULT] = {"iso", {1, -1, 1}, {0, 0, 1}},
    [CRISP_VIEW_ISO] = {"iso", {1, -1, 1}, {0, 0, 1}},
    [CRISP_VIEW_FRONT] = {"front", {0, -1, 0}, {0, 0, 1}},
    [CRISP_VIEW_BACK] = {"back", {0, 1, 0}, {0, 0, 1}},
    [CRISP_VIEW_LEFT] = {"left", {-1, 0, 0}, {0, 0, 1}},
    [CRISP_VIEW_RIGHT] = {"right", {1, 0, 0}, {0, 0, 1}},
    [CRISP_VIEW_TOP] = {"top", {0, 0, 1}, {0, 1, 0}},
    [CRISP_VIEW_BOTTOM] = {"bottom", {0, 0, -1}, {0, -1, 0}},
};

int crisp_view_parse(const char *name, crisp_view *dest)
{
    for (int v = CRISP_VIEW_ISO; v <= CRISP_VIEW_BOTTOM; v++)
        if (name && !strcmp(name, views[v].name)) {
            *dest = (crisp_view)v;
            return 1;
        }
    return 0;
}

const char *crisp_view_name(crisp_view view)
{
    return view >= CRISP_VIEW_DEFAULT && view <= CRISP_VIEW_BOTTOM ? views[view].name : "?";
}

void crisp_view_direction(crisp_view view, double dir[3], double up[3])
{
    if (view < CRISP_VIEW_DEFAULT || view > CRISP_VIEW_BOTTOM) view = CRISP_VIEW_ISO;
    crisp_vec3_normalize(views[view].dir, dir);
    memcpy(up, views[view].up, 3 * sizeof(double));
}

crisp_status crisp_camera_fit(const double box[6], const double dir[3], const double up[3],
                              const crisp_camera_fit_desc *desc, crisp_camera *dest)
{
    for (int i = 0; i < 6; i++)
        if (!isfinite(box[i]) || (i < 3 && box[i] > box[i + 3]))
            return crisp_error(CRISP_ERR_NUMERIC, "cannot frame an empty or non-finite box");
    /* A box of no size in some direction (a planar model seen edge on, a single point) still
     * gets a frame: pad it by a small part of its largest extent (or 1). */
    double b[6], ext = 0, corners[24];
    memcpy(b, box, sizeof b);
    for (int a = 0; a < 3; a++)
        ext = fmax(ext, b[a + 3] - b[a]);
    double pad = ext > 0 ? 1e-6 * ext : 0.5;
    for (int a = 0; a < 3; a++)
        if (b[a + 3] - b[a] < 2 * pad) b[a] -= pad, b[a + 3] += pad;
    for (int c = 0; c < 8; c++)
        for (int a = 0; a < 3; a++)
            corners[3 * c + a] = b[(c >> a & 1) ? a + 3 : a];
    return crisp_camera_fit_points(corners, 8, dir, up, desc, dest);
}

crisp_status crisp_camera_fit_points(const double *points, size_t count, const double dir[3],
                                     const double up[3], const crisp_camera_fit_desc *desc,
                                     crisp_camera *dest)
{
    crisp_camera_fit_desc d = desc ? *desc : (crisp_camera_fit_desc){0};
    if (!d.width && !d.height) d.width = 1280, d.height = 720;
    if (d.fov_deg == 0) d.fov_deg = 30;
    if (d.margin == 0) d.margin = 0.04;
    if (d.width <= 0 || d.height <= 0)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image size %dx%d: expected positive", d.width,
                           d.height);
    if (!(d.fov_deg > 0 && d.fov_deg < 180))
        return crisp_error(CRISP_ERR_INVALID_ARG, "fov %g degrees: expected in (0, 180)",
                           d.fov_deg);
    if (!(d.margin >= 0 && d.margin < 1))
        return crisp_error(CRISP_ERR_INVALID_ARG, "margin %g: expected in [0, 1)", d.margin);
    if (!points || count == 0) return crisp_error(CRISP_ERR_INVALID_ARG, "no points to frame");
    for (size_t i = 0; i < 3 * count; i++)
        if (!isfinite(points[i]))
            return crisp_error(CRISP_ERR_NUMERIC, "cannot frame a non-finite point");
    /* camera frame: f forward (towards the target), r right, u up */
    double f[3], back[3], r[3], u[3];
    if (!crisp_vec3_normalize(dir, back))
        return crisp_error(CRISP_ERR_INVALID_ARG, "view direction (%g, %g, %g) has no length",
                           dir[0], dir[1], dir[2]);
    crisp_vec3_scale(back, -1, f);
    crisp_vec3_cross(f, up, r);
    if (!crisp_vec3_normalize(r, r))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "up (%g, %g, %g) is parallel to the view direction", up[0], up[1],
                           up[2]);
    crisp_vec3_cross(r, f, u);
    double tan_y = tan(d.fov_deg * (M_PI / 360.0));
    double tan_x = tan_y * d.width / d.height;
    double tx = (1 - d.margin) * tan_x, ty = (1 - d.margin) * tan_y;
    double A = INFINITY, B = INFINITY, C = INFINITY, D = INFINITY;
    double zmin = INFINITY, zmax = -INFINITY, zc = 0;
    for (size_t c = 0; c < count; c++) {
        const double *p = points + 3 * c;
        double px = crisp_vec3_dot(p, r), py = crisp_vec3_dot(p, u), pz = crisp_vec3_dot(p, f);
        A = fmin(A, pz - px / tx);
        B = fmin(B, pz + px / tx);
        C = fmin(C, pz - py / ty);
        D = fmin(D, pz + py / ty);
        zmin = fmin(zmin, pz);
        zmax = fmax(zmax, pz);
        zc += pz / (double)count;
    }
    double ex = tx * (B - A) / 2, ey = ty * (D - C) / 2, ez = fmin((A + B) / 2, (C + D) / 2);
    /* Points all in one plane seen edge on, or one point: no depth range to place the eye by;
     * back off by the points' extent (or 1). */
    double span = 0;
    for (size_t c = 0; c < count; c++)
        for (int a = 0; a < 3; a++)
            span = fmax(span, fabs(points[3 * c + a] - points[a]));
    if (!(zmin - ez > 1e-9 * fmax(span, 1))) ez = zmin - fmax(span, 1);
    double dist = zc - ez; /* the target: on the axis at the depth of the points' mean */
    crisp_camera cam = {.fov_deg = d.fov_deg, .width = d.width, .height = d.height};
    for (int k = 0; k < 3; k++) {
        cam.eye[k] = ex * r[k] + ey * u[k] + ez * f[k];
        cam.target[k] = cam.eye[k] + dist * f[k];
        cam.up[k] = u[k];
    }
    double near_d = zmin - ez, far_d = zmax - ez;
    cam.zfar = 1.01 * far_d;
    cam.znear = fmax(0.99 * near_d, 1e-4 * cam.zfar);
    if (!(cam.znear > 0 && cam.zfar > cam.znear && dist > 0))
        return crisp_error(CRISP_ERR_NUMERIC, "cannot fit %zu points on screen", count);
    *dest = cam;
    return crisp_camera_check(dest);
}

/* Without an up vector: +Z (the CAD convention, as the named views), or +Y looking straight down
 * and -Y looking straight up (the top and bottom views' up). */
static void default_up(const double eye[3], const double target[3], double up[3])
{
    double dv[3], f[3], s[3];
    up[0] = 0, up[1] = 0, up[2] = 1;
    crisp_vec3_sub(target, eye, dv);
    if (!crisp_vec3_normalize(dv, f)) return;
    crisp_vec3_cross(f, up, s);
    if (crisp_vec3_norm(s) > 1e-6) return;
    up[2] = 0;
    up[1] = f[2] < 0 ? 1 : -1;
}

crisp_status crisp_document_camera(const crisp_document *doc, const crisp_camera_desc *desc,
                                   crisp_camera *dest)
{
    crisp_camera_desc d = desc ? *desc : (crisp_camera_desc){0};
    if (!d.width && !d.height) d.width = 1280, d.height = 720;
    double eye[3], target[3], up[3], fov = d.fov_deg;
    int have_eye = 0, have_target = 0, have_up = 0;
    if (d.eye) {
        memcpy(eye, d.eye, sizeof eye);
        have_eye = 1;
    } else if (d.view == CRISP_VIEW_DEFAULT && doc->has_camera) {
        memcpy(eye, doc->eye, sizeof eye);
        have_eye = 1;
        if (doc->has_target) memcpy(target, doc->target, sizeof target), have_target = 1;
        if (doc->has_up) memcpy(up, doc->up, sizeof up), have_up = 1;
        if (fov == 0) fov = doc->fov_deg;
    }
    if (d.target) memcpy(target, d.target, sizeof target), have_target = 1;
    if (d.up) memcpy(up, d.up, sizeof up), have_up = 1;
    if (fov == 0) fov = 30;
    const double *box = doc->box;
    crisp_camera cam;
    crisp_status st;
    if (!have_eye || d.fit) {
        double dir[3], vup[3];
        if (have_eye) {
            if (!have_target)
                for (int k = 0; k < 3; k++)
                    target[k] = 0.5 * (box[k] + box[k + 3]);
            crisp_vec3_sub(eye, target, dir);
            if (!have_up) default_up(eye, target, up);
            memcpy(vup, up, sizeof vup);
        } else {
            crisp_view_direction(d.view, dir, vup);
            if (have_up) memcpy(vup, up, sizeof vup);
        }
        crisp_camera_fit_desc fd = {
            .width = d.width, .height = d.height, .fov_deg = fov, .margin = d.margin};
        st = doc->point_count
                 ? crisp_camera_fit_points(doc->points, doc->point_count, dir, vup, &fd, &cam)
                 : crisp_camera_fit(box, dir, vup, &fd, &cam);
        if (st) return st;
    } else {
        cam = (crisp_camera){.fov_deg = fov, .width = d.width, .height = d.height};
        memcpy(cam.eye, eye, sizeof eye);
        for (int k = 0; k < 3; k++)
            cam.target[k] = have_target ? target[k] : 0.5 * (box[k] + box[k + 3]);
        if (have_up)
            memcpy(cam.up, up, sizeof up);
        else
            default_up(cam.eye, cam.target, cam.up);
        /* near and far enclose the box seen from the eye */
        double far_d = 0;
        for (int c = 0; c < 8; c++) {
            double p[3] = {box[(c & 1) ? 3 : 0], box[(c & 2) ? 4 : 1], box[(c & 4) ? 5 : 2]}, v[3];
            crisp_vec3_sub(p, eye, v);
            far_d = fmax(far_d, crisp_vec3_norm(v));
        }
        cam.znear = fmax(1e-4 * far_d, 1e-12);
        cam.zfar = fmax(2 * far_d, 2 * cam.znear);
    }
    /* Planes given: the other default keeps near < far. */
    if (d.znear != 0) cam.znear = d.znear;
    if (d.zfar != 0) cam.zfar = d.zfar;
    if (d.znear > 0 && d.zfar == 0 && !(cam.zfar > cam.znear)) cam.zfar = 2 * cam.znear;
    if (d.zfar > 0 && d.znear == 0 && !(cam.znear < cam.zfar)) cam.znear = 1e-4 * cam.zfar;
    if ((st = crisp_camera_check(&cam))) return st;
    *dest = cam;
    return CRISP_OK;
}
