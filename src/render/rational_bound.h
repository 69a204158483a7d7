/* Screen-space flatness bounds for rational patches and blocks of patches that do not divide
 * by the homogeneous weight (rational_bound.c has the derivation). Used by the planner next to
 * the homogeneous bounds (quadtree.c flat_px, patch_groups.c group_leaf_ok); the smaller of the
 * two is sound. */
#ifndef CRISP_RENDER_RATIONAL_BOUND_H
#define CRISP_RENDER_RATIONAL_BOUND_H

#include <stdint.h>

#include "crisp/core.h"
#include "crisp/nurbs.h"
#include "crisp/render.h"

/* Reparametrisation bounds of a rational Bézier patch of degrees n x m with weights w_ij > 0
 * (view-independent): with the convex weights r_ij(s, t) = w_ij B_i(s) B_j(t) / sum w B,
 *   sigma[0] >= |sum r_ij i/n - s|, sigma[1] >= |sum r_ij j/m - t|,
 *   sigma[2] >= |sum r_ij (i/n - s)(j/m - t)|   for all (s, t) in [0, 1]^2.
 * All 0 for a polynomial patch or equal weights; INFINITY when a weight is not positive. */
/* Screen distance bound (pixels, max of x and y) for homogeneous clip points within e[] (x, y, w)
 * of a reference point whose W is at least wmin and whose |x/W|, |y/W| are at most xmax, ymax:
 * |X/W - X_R/W_R| <= (e_X + |x_R| e_W) / (W_R - e_W). INFINITY when W is not bounded away from 0.
 * (Also the group-leaf bound's, patch_groups.c.) */
double crisp__clip_screen_px(const double e[3], double wmin, double xmax, double ymax, int width,
                             int height);

void crisp__rational_reparam(const crisp_bezier_patch *p, double sigma[3]);

/* Both sigma triples crisp__rational_block_px forms per patch (view-independent: the weights
 * only): dest[0..2] without halvings (its coarse first try), dest[3..5] crisp__rational_reparam's.
 * The planner keeps them per scene patch (patch_groups.c) so that no frame forms them again. */
#define CRISP__SIGMA_STRIDE 6
void crisp__rational_sigmas(const crisp_bezier_patch *p, double dest[CRISP__SIGMA_STRIDE]);

/* The least and largest weight of p (1, 1 for a polynomial patch). Where they differ, the
 * homogeneous bounds (flat_px, group_leaf_ok's, the SLEFE's) bound the distance to the triangle
 * point sum l_k w(x_k) clip(x_k) / ..., a point of the same triangle but not the one at the
 * parameters sum l_k x_k that the rasterizer interpolates (docs/status/issue-12-rational.md):
 * the planner then uses the bounds here for tau 1 and group leaves. */
void crisp__rational_weight_range(const crisp_bezier_patch *p, double *lo, double *hi);

/* A bound (pixels, max of the x and y distances) on the screen distance between the nu x nv
 * block of patches (first[jv * stride + iu].bez, each the rectangle [iu, iu + 1] x [jv, jv + 1]
 * of the block's parameters scaled to [0, 1]^2; a single patch is a block of one) and any triangles
 * with vertices on it, each triangle point compared with the surface point at the same parameters
 * (clip-space barycentrics, as the rasterizer interpolates). INFINITY when the corners reach the
 * eye plane or W is not bounded away from 0. accept > 0: the scan over the block's patches stops
 * (returning INFINITY) as soon as the bound must exceed accept. */
double crisp__rational_block_px(const crisp_scene_patch *first, uint32_t stride, uint32_t nu,
                                uint32_t nv, crisp_mat4 m, int width, int height, double accept);
/* The same bound (the same number) with each patch's crisp__rational_sigmas read from sigmas
 * (CRISP__SIGMA_STRIDE doubles per patch, laid out like first: patch (iu, jv) at
 * sigmas + CRISP__SIGMA_STRIDE * (jv * stride + iu)) instead of formed; NULL: formed. */
double crisp__rational_block_px_sigmas(const crisp_scene_patch *first, const double *sigmas,
                                       uint32_t stride, uint32_t nu, uint32_t nv, crisp_mat4 m,
                                       int width, int height, double accept);

/* crisp__rational_block_px_sigmas, and the W part of the same bound (the direct form of its
 * finish, W coordinate, as patch_groups.c's patch_flat_ok takes it): every triangle point's clip W
 * (the depth the rasterizer writes) is within depth[0] of the surface point's at the same
 * parameters, and the surface's clip W is at least depth[1]; INFINITY and 0 where the bound is
 * not finite. */
double crisp__rational_block_px_depth(const crisp_scene_patch *first, const double *sigmas,
                                      uint32_t stride, uint32_t nu, uint32_t nv, crisp_mat4 m,
                                      int width, int height, double accept, double depth[2]);

/* The block bound's last step on its own (patch_groups.c keeps the deviations per block): C the
 * block's Euclidean corners in clip coordinates x, y, w; every control point's deviation from the
 * bilinear through them, per coordinate, in [lo, hi] (lo <= 0 <= hi); the reparametrisation term
 * at most r. INFINITY when W is not bounded away from 0. */
double crisp__rational_block_finish_px(const double C[4][3], const double lo[3], const double hi[3],
                                       const double r[3], int width, int height);

/* A bound (pixels) on the distance between patch p and its leaf mesh (crisp_tess_mesh_generate)
 * at inner level tau in both directions, with every edge level >= tau, each triangle point
 * against the surface at the same parameters: the largest any-triangle bound over the parameter
 * windows that hold the mesh's triangles (rational_bound.c). tau = 1: any mesh. accept > 0: stops
 * at the first window above accept (the result is then only known to exceed it). */
double crisp__rational_level_px(const crisp_bezier_patch *p, int tau, crisp_mat4 m, int width,
                                int height, double accept);

/* For a rational patch whose homogeneous level is `below`: a level t < below whose
 * crisp__rational_level_px is within eps (a few levels tried from the prediction of flat, the
 * patch's any-triangle bound), or `below`. */
int crisp__rational_tess_level(const crisp_bezier_patch *p, int below, double flat, crisp_mat4 m,
                               int width, int height, double eps);

#endif
