/* Camera and pixel conventions (docs/design.md section 6): gluLookAt / gluPerspective, right-handed
 * world, vertical fov, pixel (i, j) with j = 0 the top row and its centre at (i + 0.5, j + 0.5). */
#include "crisp/render.h"

#include <math.h>

static int finite3(const double *v)
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

crisp_status crisp_camera_check(const crisp_camera *c)
{
    if (c->width <= 0 || c->height <= 0 || c->width > 65536 || c->height > 65536)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "image size %dx%d: expected 1..65536 in each direction", c->width,
                           c->height);
    if (!finite3(c->eye) || !finite3(c->target) || !finite3(c->up))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "camera eye, target and up must be finite numbers");
    if (!(c->fov_deg > 0 && c->fov_deg < 180))
        return crisp_error(CRISP_ERR_INVALID_ARG, "fov %g degrees: expected a value in (0, 180)",
                           c->fov_deg);
    if (!(c->znear > 0 && c->zfar > c->znear && isfinite(c->zfar)))
        return crisp_error(CRISP_ERR_INVALID_ARG, "near %g, far %g: expected 0 < near < far",
                           c->znear, c->zfar);
    crisp_vec3 d, f;
    crisp_vec3_sub(c->target, c->eye, d);
    if (!crisp_vec3_normalize(d, f))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "camera: eye (%g,%g,%g) equals target: no view direction", c->eye[0],
                           c->eye[1], c->eye[2]);
    crisp_mat4 m;
    if (!crisp_mat4_lookat(c->eye, c->target, c->up, m))
        return crisp_error(
            CRISP_ERR_INVALID_ARG,
            "camera: up (%g,%g,%g) is zero or parallel to the view direction (%g,%g,%g): "
            "expected an up vector that is not",
            c->up[0], c->up[1], c->up[2], f[0], f[1], f[2]);
    return CRISP_OK;
}

void crisp_camera_matrices_compute(const crisp_camera *c, crisp_camera_matrices *dest)
{
    crisp_mat4_lookat(c->eye, c->target, c->up, dest->view);
    crisp_mat4_perspective(c->fov_deg, (double)c->width / c->height, c->znear, c->zfar, dest->proj);
    crisp_mat4_mul(dest->proj, dest->view, dest->view_proj);
}

void crisp_camera_ray(const crisp_camera *c, double x, double y, double origin[3], double dir[3])
{
    crisp_vec3 f, r, u, d;
    crisp_vec3_sub(c->target, c->eye, d);
    crisp_vec3_normalize(d, f);
    crisp_vec3_cross(f, c->up, d);
    crisp_vec3_normalize(d, r);
    crisp_vec3_cross(r, f, u);
    double t = tan(c->fov_deg * (M_PI / 360.0));
    double nx = (2.0 * x / c->width - 1.0) * t * c->width / c->height;
    double ny = (1.0 - 2.0 * y / c->height) * t;
    for (int i = 0; i < 3; i++) {
        origin[i] = c->eye[i];
        d[i] = f[i] + nx * r[i] + ny * u[i];
    }
    crisp_vec3_normalize(d, dir);
}

void crisp_camera_to_pixel(const crisp_camera *c, const double clip[4], double dest[3])
{
    double iw = 1.0 / clip[3];
    dest[0] = (clip[0] * iw + 1.0) * 0.5 * c->width;
    dest[1] = (1.0 - clip[1] * iw) * 0.5 * c->height;
    dest[2] = clip[2] * iw;
}

crisp_status crisp_camera_frame_box(const double box[6], int width, int height, crisp_camera *dest)
{
    for (int i = 0; i < 6; i++)
        if (!isfinite(box[i]))
            return crisp_error(CRISP_ERR_NUMERIC,
                               "cannot frame a bounding box with non-finite coordinates");
    if (width <= 0 || height <= 0)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image size %dx%d: expected positive", width,
                           height);
    double c[3], r = 0;
    for (int i = 0; i < 3; i++) {
        c[i] = 0.5 * (box[i] + box[i + 3]);
        double h = 0.5 * (box[i + 3] - box[i]);
        r += h * h;
    }
    r = sqrt(r);
    if (!(r > 0)) r = 1;
    const double fov = 30.0;
    double half_v = fov * (M_PI / 360.0);
    double half_h = atan(tan(half_v) * width / height);
    double half = half_v < half_h ? half_v : half_h;
    double d = 1.05 * r / sin(half);
    *dest = (crisp_camera){
        .eye = {c[0], c[1], c[2] + d},
        .target = {c[0], c[1], c[2]},
        .up = {0, 1, 0},
        .fov_deg = fov,
        .znear = fmax(0.5 * (d - r), 1e-4 * d),
        .zfar = 2.0 * (d + r),
        .width = width,
        .height = height,
    };
    return CRISP_OK;
}
