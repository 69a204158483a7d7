/* crisp render: camera and pixel conventions (DESIGN.md section 6), and (to come) the scene, the
 * frame planner and the CPU backend.
 *
 * Offers:
 *   crisp_camera            eye, target, up, vertical fov, near, far, image size
 *   crisp_camera_check      validate with a message naming the bad value
 *   crisp_camera_matrices   view, projection and view-projection (gluLookAt / gluPerspective)
 *   crisp_camera_ray        the ray through a point of the image (pixel centre = (i+0.5, j+0.5))
 *   crisp_camera_frame_box  the default camera that frames a box (looking along -Z, +Y up, fov 30)
 *   crisp_camera_to_pixel   clip-space point -> pixel coordinates
 */
#ifndef CRISP_RENDER_H
#define CRISP_RENDER_H

#include "crisp/core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct crisp_camera {
    double eye[3], target[3], up[3];
    double fov_deg;     /* vertical field of view in degrees, in (0, 180) */
    double znear, zfar; /* 0 < znear < zfar */
    int width, height;  /* image size in pixels */
} crisp_camera;

typedef struct crisp_camera_matrices {
    crisp_mat4 view, proj, view_proj;
} crisp_camera_matrices;

crisp_status crisp_camera_check(const crisp_camera *cam);
void crisp_camera_matrices_compute(const crisp_camera *cam, crisp_camera_matrices *dest);
/* Ray through image point (x, y) in pixels, y down (a pixel centre is (i + 0.5, j + 0.5)):
 * origin = eye, dir unit length. */
void crisp_camera_ray(const crisp_camera *cam, double x, double y, double origin[3],
                      double dir[3]);
/* Clip-space (X, Y, Z, W) with W > 0 -> pixel coordinates (x right, y down) and NDC depth. */
void crisp_camera_to_pixel(const crisp_camera *cam, const double clip[4], double dest[3]);
/* A camera looking along -Z with +Y up and a 30 degree fov that shows the whole box
 * (xmin, ymin, zmin, xmax, ymax, zmax) with a small margin; near and far enclose it. */
crisp_status crisp_camera_frame_box(const double box[6], int width, int height,
                                    crisp_camera *dest);

#ifdef __cplusplus
}
#endif
#endif
