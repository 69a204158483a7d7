/* Camera navigation for the window apps, on crisp_camera (DESIGN.md section 6 conventions):
 * turntable orbit about a picked point (world +Z up), pan that keeps the grabbed point under the
 * cursor, zoom to the cursor as a homothety about the point under it (that point stays on the
 * same pixel exactly), fit the box, standard views, perspective and orthographic, and near/far
 * planes adapted every frame so that zooming into a detail never clips it.
 *
 * Orthographic is a perspective camera with a very narrow field of view far from the model
 * (crisp_camera has no orthographic projection): the focal plane through the target keeps its
 * size on screen, and the eye is kept at least two box radii away so it never enters the model;
 * the angle shrinks as the user zooms in, so the image tends to a true orthographic one.
 *
 * Offers:
 *   app_nav                  the camera plus the mode and the box it navigates
 *   app_nav_init             isometric view fitted to a box
 *   app_nav_view             standard views (APP_VIEW_*), fitted
 *   app_nav_fit              fit the box keeping the direction
 *   app_nav_fit_points       fit points of the true geometry keeping the direction (tight)
 *   app_nav_orbit/_pan/_zoom the mouse operations
 *   app_nav_set_ortho        switch projection keeping the focal plane's size on screen
 *   app_nav_update_clip      near and far for this frame
 *   app_nav_focus_point      the point of the focal plane under a pixel (where nothing is hit)
 *   app_nav_format/_parse    the camera as `crisp render` options and back
 */
#ifndef APP_NAV_H
#define APP_NAV_H

#include "crisp/render.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
    APP_VIEW_ISO = 0,
    APP_VIEW_FRONT, /* looking along +Y */
    APP_VIEW_TOP,   /* looking along -Z */
    APP_VIEW_RIGHT, /* looking along -X */
    APP_VIEW_BACK,  /* looking along -Y */
    APP_VIEW_BOTTOM,/* looking along +Z */
    APP_VIEW_LEFT,  /* looking along +X */
    APP_VIEW_COUNT
};

#define APP_NAV_PERSP_FOV 30.0 /* degrees */
#define APP_NAV_ORTHO_FOV 0.1  /* degrees, the widest angle of the orthographic mode */

typedef struct app_nav {
    crisp_camera cam;
    int ortho;
    double box[6];      /* what fit frames and near/far enclose */
    double depth_hint;  /* least camera-space depth seen in the last frame (0: none) */
} app_nav;

extern const char *const app_view_names[APP_VIEW_COUNT];

void app_nav_init(app_nav *nav, const double box[6], int width, int height);
void app_nav_view(app_nav *nav, int view);
void app_nav_fit(app_nav *nav);
/* Every point on screen with crisp_camera_fit_points's margin, the direction kept; the box fit
 * when there are no points. */
void app_nav_fit_points(app_nav *nav, const double *points, size_t count);
/* Turntable: dx pixels turn about world +Z through pivot, dy about the camera's right axis. */
void app_nav_orbit(app_nav *nav, const double pivot[3], double dx, double dy);
/* Move eye and target so that a point at camera-space depth `depth` follows the cursor by
 * (dx, dy) pixels (y down). */
void app_nav_pan(app_nav *nav, double depth, double dx, double dy);
/* Scale eye and target about p by factor (< 1 zooms in): p keeps its pixel exactly. */
void app_nav_zoom(app_nav *nav, const double p[3], double factor);
void app_nav_set_ortho(app_nav *nav, int ortho);
void app_nav_resize(app_nav *nav, int width, int height);
/* Near and far from the box and the depth hint; call before rendering a frame. */
void app_nav_update_clip(app_nav *nav);
/* The point of the plane through the target facing the camera, under pixel point (x, y). */
void app_nav_focus_point(const app_nav *nav, double x, double y, double dest[3]);
/* Camera-space depth of a world point. */
double app_nav_depth(const crisp_camera *cam, const double p[3]);
/* "--size WxH --eye x,y,z --target x,y,z --up x,y,z --fov F --near N --far F" with %.17g. */
void app_nav_format(const crisp_camera *cam, char *buf, size_t size);
/* The same options (any order, --size optional) into cam; 0 and a message in err on bad text. */
int app_nav_parse(const char *text, crisp_camera *cam, char *err, size_t err_size);

#ifdef __cplusplus
}
#endif
#endif
