/* crisp-view's moving frames on the GPU (proxy.c): the motion plan tessellated once into a
 * world-space mesh with its trim tables, drawn by the window's OpenGL context while the camera
 * moves. */
#ifndef VIEW_PROXY_H
#define VIEW_PROXY_H

#include <stdint.h>

#include "crisp/plan.h"
#include "window.h"

typedef struct view_proxy {
    GLuint program, edge_program, vao, edge_vao, vbo, ibo, ssbo[4];
    GLint u_mvp, u_eye, u_clip, u_selected, u_cap, u_hatch_u, u_hatch_off;
    GLuint fbo, depth, face_tex, color_tex;
    int w, h;
    double centre[3]; /* vertices are stored relative to it (float precision) */
    size_t index_count, triangles;
    int ready;
} view_proxy;

typedef struct view_proxy_style {
    int edges;        /* face borders, trims and silhouettes from the face ids */
    int32_t selected; /* tinted; -1 none */
    int clip;         /* discard where clip_plane . (x, y, z, 1) < 0 */
    double clip_plane[4];
    double hatch_u[3]; /* the cap's hatch (view_section_hatch) */
} view_proxy_style;

crisp_status view_proxy_init(view_proxy *px);
void view_proxy_free(view_proxy *px);
/* Tessellate plan's leaves (of scene sc) and upload them with its trim tables. */
crisp_status view_proxy_build(view_proxy *px, const crisp_scene *sc, const crisp_frame_plan *plan,
                              const double box[6]);
/* Draw for cam (its size) into color_tex (RGBA8, row 0 = the image's top row). */
crisp_status view_proxy_draw(view_proxy *px, const crisp_camera *cam, GLuint color_tex,
                             const view_proxy_style *style);

#endif
