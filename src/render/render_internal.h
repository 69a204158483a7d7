/* Internal helpers shared by the render module's backends. */
#ifndef CRISP_RENDER_INTERNAL_H
#define CRISP_RENDER_INTERNAL_H

#include "crisp/render.h"

/* Headlight shading: base colour times (ambient + diffuse |n . v|), two-sided; writes RGBA with
 * alpha 1. n and view (from the eye to the point) need not be unit. */
void crisp__shade(const float base[4], const double n[3], const double view[3], float rgba[4]);

/* Camera-space depth of a world point (distance along the view axis). */
double crisp__view_depth(const crisp_camera *cam, const double p[3]);

/* The last frame's triangles (CPU backend), for tests that measure them. */
struct crisp_raster_vertex;
struct crisp_raster_tri;
void crisp__renderer_mesh(const crisp_renderer *r, const struct crisp_raster_vertex **verts,
                          size_t *vert_count, const struct crisp_raster_tri **tris,
                          size_t *tri_count);

#endif
