/* Occlusion culling for the CPU backend (issue 12, occlusion.c): leaves drawn nearest first in a
 * few batches, and a leaf of a later batch dropped before tessellation when the depth already
 * drawn hides its whole screen box. */
#ifndef CRISP_RENDER_OCCLUSION_H
#define CRISP_RENDER_OCCLUSION_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/core.h"

#define CRISP_OCCL_BATCHES 6
/* Pixels per side of the blocks whose depth is tested (crisp__raster_block_depth). */
#ifndef CRISP_OCCL_BLOCK
#define CRISP_OCCL_BLOCK 4
#endif

/* Per leaf: the CRISP_OCCL_BLOCK-pixel blocks of the target its samples can lie in (inclusive) and
 * an upper bound of its fragments' 1/W (INFINITY: never culled). */
typedef struct crisp_occl_leaf {
    uint16_t bx0, by0, bx1, by1;
    float iw;
} crisp_occl_leaf;

/* The record of a leaf whose samples lie in the screen box [lo, hi] (pixels of the whole image;
 * samples at pixel + offset, offset in [0, 1)) and whose points have 1/W <= iw (INFINITY: not
 * known, or the leaf reaches the near plane), for a target that is the window win (x0, y0,
 * width, height; x0, y0 multiples of 8) of the image. */
void crisp__occl_set(crisp_occl_leaf *o, const int win[4], const double lo[2], const double hi[2],
                     double iw);

/* The leaves to draw (skip[j] == 0) into order, batch after batch: batch b is order[bstart[b]
 * .. bstart[b + 1]), in plan order within it. With occl, the batches split the leaves by their
 * nearest depth (largest 1/W first; leaves never culled in the first), each holding about a
 * share of the triangles (tris[j] per leaf) and at least 8,192 of them (fewer batches in small
 * scenes; the last ones empty); occl NULL: one batch. Returns the first leaf with
 * tris[j] == UINT32_MAX (its levels refused), or SIZE_MAX. */
size_t crisp__occl_order(const crisp_occl_leaf *occl, const uint8_t *skip, const uint32_t *tris,
                         size_t count, uint32_t *order, uint32_t bstart[CRISP_OCCL_BATCHES + 1]);

/* 1 when every block of the leaf holds depth nearer than all of it: hiz[by * blocks_x + bx] the
 * least 1/W drawn in block (bx, by) (0 where a sample is empty; crisp__raster_block_depth). */
int crisp__occl_hidden(const crisp_occl_leaf *o, const double *hiz, int blocks_x);

/* 1 when the point (x, y) (pixels of the target) with 1/W iw is in a block of hiz (blocks_x x
 * blocks_y) whose least 1/W is at most iw: then no triangle with the point among its vertices is
 * hidden by hiz (the hidden tests need a bound of its 1/W, so at least iw, below every block its
 * box covers). 0 outside the blocks, or at a NaN block or iw. */
int crisp__occl_point_seen(const double *hiz, int blocks_x, int blocks_y, double x, double y,
                           double iw);

/* skip[list[i]] = 2 for each hidden leaf of the list (the others are left as they are). */
void crisp__occl_cull(crisp_pool *pool, const crisp_occl_leaf *occl, const uint32_t *list,
                      size_t count, const double *hiz, int blocks_x, uint8_t *skip);

#endif
