/* Camera navigation (nav.h): turntable orbit, pan, zoom to the cursor as a homothety, fit,
 * standard views (FreeCAD's: world +Z up, front looks along +Y, isometric from (1, -1, 1)),
 * orthographic as a narrow perspective, near/far adapted per frame. */
#include "nav.h"

#include "crisp/app.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *const app_view_names[APP_VIEW_COUNT] = {"isometric", "front", "top",   "right",
                                                    "back",      "bottom", "left"};

static const double view_dir[APP_VIEW_COUNT][3] = {
    {-1, 1, -1}, {0, 1, 0}, {0, 0, -1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, 1}, {1, 0, 0}};
static const double view_up[APP_VIEW_COUNT][3] = {
    {0, 0, 1}, {0, 0, 1}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, -1, 0}, {0, 0, 1}};

static double deg2rad(double d) { return d * M_PI / 180.0; }

/* Camera basis: forward f, right r, true up u. Returns the eye-target distance. */
static double basis(const crisp_camera *c, double f[3], double r[3], double u[3])
{
    double d[3];
    crisp_vec3_sub(c->target, c->eye, d);
    double len = crisp_vec3_norm(d);
    if (!crisp_vec3_normalize(d, f)) f[0] = 0, f[1] = 0, f[2] = -1;
    double s[3];
    crisp_vec3_cross(f, c->up, s);
    if (!crisp_vec3_normalize(s, r)) {
        /* up parallel to the view: any perpendicular will do */
        double a[3] = {fabs(f[0]) < 0.9 ? 1 : 0, fabs(f[0]) < 0.9 ? 0 : 1, 0};
        crisp_vec3_cross(f, a, s);
        crisp_vec3_normalize(s, r);
    }
    crisp_vec3_cross(r, f, u);
    return len;
}

static void box_center(const double box[6], double c[3], double *radius)
{
    double h[3];
    for (int a = 0; a < 3; a++) {
        c[a] = 0.5 * (box[a] + box[a + 3]);
        h[a] = 0.5 * (box[a + 3] - box[a]);
    }
    *radius = fmax(crisp_vec3_norm(h), 1e-12);
}

static int box_valid(const double box[6])
{
    for (int a = 0; a < 3; a++)
        if (!(box[a] <= box[a + 3]) || !isfinite(box[a]) || !isfinite(box[a + 3])) return 0;
    return 1;
}

/* Rotate v about the unit axis by angle (Rodrigues). */
static void rotate(const double v[3], const double axis[3], double angle, double dest[3])
{
    double c = cos(angle), s = sin(angle), k = crisp_vec3_dot(axis, v), x[3];
    crisp_vec3_cross(axis, v, x);
    for (int i = 0; i < 3; i++) dest[i] = v[i] * c + x[i] * s + axis[i] * k * (1 - c);
}

double app_nav_depth(const crisp_camera *cam, const double p[3])
{
    double f[3], r[3], u[3], d[3];
    basis(cam, f, r, u);
    crisp_vec3_sub(p, cam->eye, d);
    return crisp_vec3_dot(d, f);
}

/* Orthographic mode: keep the focal plane's height h, put the eye as close as the narrow angle
 * allows but at least two box radii beyond the box's centre plane. */
static void ortho_fix(app_nav *nav)
{
    if (!nav->ortho) return;
    crisp_camera *c = &nav->cam;
    double f[3], r[3], u[3], ctr[3], rad, tc[3];
    double d = basis(c, f, r, u);
    double h = 2 * d * tan(deg2rad(c->fov_deg) / 2);
    box_center(nav->box, ctr, &rad);
    crisp_vec3_sub(c->target, ctr, tc);
    double dmin = 2 * rad + fmax(0, crisp_vec3_dot(tc, f));
    double dnew = fmax(dmin, h / (2 * tan(deg2rad(APP_NAV_ORTHO_FOV) / 2)));
    c->fov_deg = 2 * atan(h / (2 * dnew)) * 180 / M_PI;
    for (int i = 0; i < 3; i++) c->eye[i] = c->target[i] - f[i] * dnew;
}

void app_nav_fit(app_nav *nav)
{
    crisp_camera *c = &nav->cam;
    double f[3], r[3], u[3], ctr[3], rad;
    basis(c, f, r, u);
    box_center(nav->box, ctr, &rad);
    double fov = nav->ortho ? APP_NAV_ORTHO_FOV : APP_NAV_PERSP_FOV;
    double ty = tan(deg2rad(fov) / 2), tx = ty * c->width / c->height, m = 0.95;
    double d = 0;
    for (int k = 0; k < 8; k++) {
        double p[3] = {nav->box[k & 1 ? 3 : 0] - ctr[0], nav->box[k & 2 ? 4 : 1] - ctr[1],
                       nav->box[k & 4 ? 5 : 2] - ctr[2]};
        double x = crisp_vec3_dot(p, r), y = crisp_vec3_dot(p, u), z = crisp_vec3_dot(p, f);
        d = fmax(d, fabs(x) / (tx * m) - z);
        d = fmax(d, fabs(y) / (ty * m) - z);
        d = fmax(d, 1.001 * -z);
    }
    d = fmax(d, 1e-9 * rad);
    c->fov_deg = fov;
    memcpy(c->target, ctr, sizeof ctr);
    for (int i = 0; i < 3; i++) c->eye[i] = ctr[i] - f[i] * d;
    memcpy(c->up, u, sizeof u);
    nav->depth_hint = 0;
    ortho_fix(nav);
}

void app_nav_fit_points(app_nav *nav, const double *points, size_t count)
{
    crisp_camera *c = &nav->cam, fit;
    double f[3], r[3], u[3], dir[3];
    basis(c, f, r, u);
    crisp_vec3_scale(f, -1, dir);
    crisp_camera_fit_desc fd = {.width = c->width, .height = c->height,
                                .fov_deg = nav->ortho ? APP_NAV_ORTHO_FOV : APP_NAV_PERSP_FOV};
    if (!points || !count || crisp_camera_fit_points(points, count, dir, u, &fd, &fit)) {
        app_nav_fit(nav);
        return;
    }
    fit.width = c->width;
    fit.height = c->height;
    *c = fit;
    nav->depth_hint = 0;
    ortho_fix(nav);
}

void app_nav_view(app_nav *nav, int view)
{
    if (view < 0 || view >= APP_VIEW_COUNT) return;
    crisp_camera *c = &nav->cam;
    double f[3];
    crisp_vec3_normalize(view_dir[view], f);
    for (int i = 0; i < 3; i++) c->eye[i] = c->target[i] - f[i];
    memcpy(c->up, view_up[view], sizeof c->up);
    app_nav_fit(nav);
}

void app_nav_init(app_nav *nav, const double box[6], int width, int height)
{
    memset(nav, 0, sizeof *nav);
    if (box_valid(box)) {
        memcpy(nav->box, box, sizeof nav->box);
    } else {
        for (int a = 0; a < 3; a++) nav->box[a] = -1, nav->box[a + 3] = 1;
    }
    nav->cam.width = width > 0 ? width : 1;
    nav->cam.height = height > 0 ? height : 1;
    nav->cam.fov_deg = APP_NAV_PERSP_FOV;
    nav->cam.znear = 0.1;
    nav->cam.zfar = 10;
    app_nav_view(nav, APP_VIEW_ISO);
    app_nav_update_clip(nav);
}

void app_nav_orbit(app_nav *nav, const double pivot[3], double dx, double dy)
{
    crisp_camera *c = &nav->cam;
    double k = M_PI / c->height;
    static const double z[3] = {0, 0, 1};
    double f[3], r[3], u[3];
    /* yaw about world Z through the pivot, then pitch about the new right axis */
    for (int pass = 0; pass < 2; pass++) {
        basis(c, f, r, u);
        const double *axis = pass == 0 ? z : r;
        double angle = pass == 0 ? -dx * k : -dy * k;
        if (angle == 0) continue;
        double e[3], t[3];
        crisp_vec3_sub(c->eye, pivot, e);
        crisp_vec3_sub(c->target, pivot, t);
        rotate(e, axis, angle, e);
        rotate(t, axis, angle, t);
        rotate(u, axis, angle, c->up);
        crisp_vec3_add(e, pivot, c->eye);
        crisp_vec3_add(t, pivot, c->target);
    }
}

void app_nav_pan(app_nav *nav, double depth, double dx, double dy)
{
    crisp_camera *c = &nav->cam;
    double f[3], r[3], u[3];
    basis(c, f, r, u);
    double s = 2 * depth * tan(deg2rad(c->fov_deg) / 2) / c->height;
    for (int i = 0; i < 3; i++) {
        double m = -dx * s * r[i] + dy * s * u[i];
        c->eye[i] += m;
        c->target[i] += m;
    }
}

void app_nav_zoom(app_nav *nav, const double p[3], double factor)
{
    crisp_camera *c = &nav->cam;
    if (!(factor > 0) || !isfinite(factor)) return;
    for (int i = 0; i < 3; i++) {
        c->eye[i] = p[i] + (c->eye[i] - p[i]) * factor;
        c->target[i] = p[i] + (c->target[i] - p[i]) * factor;
    }
    nav->depth_hint *= factor;
    if (nav->ortho) {
        /* the focal plane through p, so that the orthographic fix keeps p's pixel */
        double f[3], r[3], u[3];
        basis(c, f, r, u);
        double dp = app_nav_depth(c, p);
        if (dp > 0)
            for (int i = 0; i < 3; i++) c->target[i] = c->eye[i] + f[i] * dp;
        ortho_fix(nav);
    }
}

void app_nav_set_ortho(app_nav *nav, int ortho)
{
    crisp_camera *c = &nav->cam;
    if (!!ortho == nav->ortho) return;
    double f[3], r[3], u[3];
    double d = basis(c, f, r, u);
    double h = 2 * d * tan(deg2rad(c->fov_deg) / 2);
    nav->ortho = !!ortho;
    if (nav->ortho) {
        ortho_fix(nav);
    } else {
        c->fov_deg = APP_NAV_PERSP_FOV;
        double dn = h / (2 * tan(deg2rad(APP_NAV_PERSP_FOV) / 2));
        for (int i = 0; i < 3; i++) c->eye[i] = c->target[i] - f[i] * dn;
    }
    nav->depth_hint = 0;
}

void app_nav_resize(app_nav *nav, int width, int height)
{
    if (width > 0) nav->cam.width = width;
    if (height > 0) nav->cam.height = height;
}

void app_nav_update_clip(app_nav *nav)
{
    crisp_camera *c = &nav->cam;
    double zmin = INFINITY, zmax = -INFINITY;
    for (int k = 0; k < 8; k++) {
        double p[3] = {nav->box[k & 1 ? 3 : 0], nav->box[k & 2 ? 4 : 1], nav->box[k & 4 ? 5 : 2]};
        double z = app_nav_depth(c, p);
        zmin = fmin(zmin, z);
        zmax = fmax(zmax, z);
    }
    double ctr[3], rad;
    box_center(nav->box, ctr, &rad);
    double zfar = zmax > 0 ? zmax * 1.01 + 1e-9 * rad : 2 * rad;
    double znear;
    if (zmin > 0) {
        znear = zmin * 0.99;
    } else {
        /* the eye is inside the box: half of the least depth seen in the last frame */
        znear = nav->depth_hint > 0 ? 0.5 * nav->depth_hint : 1e-3 * zfar;
    }
    znear = fmax(znear, 1e-7 * zfar);
    if (!(zfar > znear)) zfar = 2 * znear;
    c->znear = znear;
    c->zfar = zfar;
}

void app_nav_focus_point(const app_nav *nav, double x, double y, double dest[3])
{
    const crisp_camera *c = &nav->cam;
    double o[3], d[3], f[3], r[3], u[3], tc[3];
    basis(c, f, r, u);
    crisp_camera_ray(c, x, y, o, d);
    crisp_vec3_sub(c->target, c->eye, tc);
    double den = crisp_vec3_dot(d, f);
    double t = den > 1e-12 ? crisp_vec3_dot(tc, f) / den : crisp_vec3_norm(tc);
    for (int i = 0; i < 3; i++) dest[i] = o[i] + t * d[i];
}

void app_nav_format(const crisp_camera *c, char *buf, size_t size)
{
    snprintf(buf, size,
             "--size %dx%d --eye %.17g,%.17g,%.17g --target %.17g,%.17g,%.17g "
             "--up %.17g,%.17g,%.17g --fov %.17g --near %.17g --far %.17g",
             c->width, c->height, c->eye[0], c->eye[1], c->eye[2], c->target[0], c->target[1],
             c->target[2], c->up[0], c->up[1], c->up[2], c->fov_deg, c->znear, c->zfar);
}

static int parse_vec(const char *s, double v[3])
{
    char *end;
    for (int i = 0; i < 3; i++) {
        v[i] = strtod(s, &end);
        if (end == s || !isfinite(v[i])) return 0;
        if (i < 2) {
            if (*end != ',') return 0;
            s = end + 1;
        }
    }
    return *end == '\0';
}

int app_nav_parse(const char *text, crisp_camera *cam, char *err, size_t err_size)
{
    crisp_camera c = *cam;
    char *copy = strdup(text ? text : "");
    if (!copy) {
        snprintf(err, err_size, "out of memory");
        return 0;
    }
    int ok = 1, seen = 0;
    char *save = NULL;
    for (char *tok = strtok_r(copy, " \t\r\n", &save); tok && ok;
         tok = strtok_r(NULL, " \t\r\n", &save)) {
        char *val = strtok_r(NULL, " \t\r\n", &save);
        if (!val) {
            snprintf(err, err_size, "camera option %s needs a value", tok);
            ok = 0;
            break;
        }
        char *end = NULL;
        char extra;
        if (!strcmp(tok, "--size")) {
            ok = sscanf(val, "%dx%d%c", &c.width, &c.height, &extra) == 2 && c.width > 0 &&
                 c.height > 0;
        } else if (!strcmp(tok, "--eye")) {
            ok = parse_vec(val, c.eye);
        } else if (!strcmp(tok, "--target")) {
            ok = parse_vec(val, c.target);
        } else if (!strcmp(tok, "--up")) {
            ok = parse_vec(val, c.up);
        } else if (!strcmp(tok, "--fov") || !strcmp(tok, "--near") || !strcmp(tok, "--far")) {
            double x = strtod(val, &end);
            ok = end != val && *end == '\0' && isfinite(x);
            if (tok[2] == 'f' && tok[3] == 'o') c.fov_deg = x;
            else if (tok[2] == 'n') c.znear = x;
            else c.zfar = x;
        } else {
            snprintf(err, err_size, "unknown camera option '%s' (expected --size --eye --target --up "
                                    "--fov --near --far)", tok);
            ok = 0;
            break;
        }
        if (!ok) snprintf(err, err_size, "camera option %s '%s': bad value", tok, val);
        seen++;
    }
    free(copy);
    if (ok && !seen) {
        snprintf(err, err_size, "no camera options found");
        ok = 0;
    }
    if (ok && crisp_camera_check(&c)) {
        snprintf(err, err_size, "%s", crisp_error_message());
        ok = 0;
    }
    if (ok) *cam = c;
    return ok;
}
