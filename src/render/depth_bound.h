/* A bound on the tessellation's depth error along the view (issue 13): the level choice bounds
 * the drawn triangles' distance to the surface on screen (eps pixels) but not along the view, so
 * a large triangle facing the eye could lie a pixel's world size or more behind a bulging
 * surface while every point of it projects within eps. depth_bound.c has the derivation. */
#ifndef CRISP_RENDER_DEPTH_BOUND_H
#define CRISP_RENDER_DEPTH_BOUND_H

#include "crisp/core.h"
#include "crisp/nurbs.h"

/* The clip W and weight coefficients of p's control points, interleaved (c holds 2 per point);
 * 0 when the degrees are out of range (1..15, not both 0). */
int crisp__depth_clip_coefficients(const crisp_bezier_patch *p, crisp_mat4 m, double *c);
/* A bound on |depth(T) - depth(S)| over the uniform tessellation of p at tau segments per
 * direction (triangles spanning at most a cell in s and in t), for every triangle point T against
 * the surface point S at the same parameters (clip-space barycentrics, as the rasterizer
 * interpolates), in clip W (the camera-space depth of a perspective view_proj), and the least
 * W of the patch (wmin). Returns INFINITY when a control point reaches the eye plane. */
double crisp__depth_error_bound(const crisp_bezier_patch *p, crisp_mat4 view_proj, int tau,
                                double *wmin);

/* The world size of one pixel per unit of clip W along the view: a pixel at depth W is
 * W * crisp__depth_px_scale(...) clip-W units wide (the smaller of its width and height). */
double crisp__depth_px_scale(crisp_mat4 view_proj, int width, int height);

/* The least level >= tau at which the tessellation of p lies within eps pixels' world size of the
 * surface along the view at its depth (crisp__depth_error_bound <= eps * scale * wmin);
 * max_level + 1 when no level up to max_level does (split); tau itself when a control point
 * reaches the eye plane (no depth bound there: the screen bound splits such patches). */
int crisp__depth_tess_level(const crisp_bezier_patch *p, crisp_mat4 view_proj, int width,
                            int height, double eps, int tau, int max_level);
/* The same, with the curvature bounds of p's Euclidean clip W that the screen bound's level search
 * formed for p with the same view_proj (crisp__slefe_level_info.kw; NULL or NAN entries: formed
 * here): the same level, without forming them twice. */
int crisp__depth_tess_level_kw(const crisp_bezier_patch *p, crisp_mat4 view_proj, int width,
                               int height, double eps, int tau, int max_level, const double *kw);

#endif
