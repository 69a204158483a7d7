/* The CPU backend's splat draw (issue 12, splat_raster.c): the plan's splat ranges
 * (include/crisp/plan.h) drawn into the rasterizer's target as screen-aligned squares. */
#ifndef CRISP_RENDER_SPLAT_RASTER_H
#define CRISP_RENDER_SPLAT_RASTER_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/plan.h"
#include "raster.h"

/* Scratch kept from frame to frame (zero-initialised; crisp__splat_scratch_free). */
typedef struct crisp__splat_scratch {
    uint32_t *list; /* the ranges drawn (plan indices) */
    double *box;    /* per range drawn: lo x, lo y, hi x, hi y of its squares, then its largest
                       1 / W */
    size_t list_cap;
    uint32_t *band_start, *band_list, *band_fill; /* per band of rows: its ranges (list indices) */
    size_t band_start_cap, band_list_cap, band_fill_cap;
    /* per range drawn: the first and last band it meets (first > last: none, or hidden whole) */
    uint32_t (*span)[2];
    size_t span_cap;
    uint32_t *chunk_first; /* per range drawn: its first chunk (chunks of SPLAT_CHUNK splats) */
    double *chunk_box;     /* per chunk: its box and largest 1 / W, as box */
    size_t chunk_first_cap, chunk_box_cap;
} crisp__splat_scratch;

void crisp__splat_scratch_free(crisp__splat_scratch *s);

typedef struct crisp__splat_draw_desc {
    const crisp_frame_plan *plan;
    const uint8_t *only; /* per face: draw its ranges (NULL: all) */
    const double *clip;  /* the rasterizer's clip plane k (crisp__raster_set_clip), NULL: none */
    const double *hiz;   /* block depth (crisp__raster_block_depth at CRISP_OCCL_BLOCK), NULL */
    int win[4];          /* the target's window of the plan's image: x0, y0, width, height */
    int occlude; /* 1: skip ranges and chunks that the depth drawn hides (per band of rows) */
} crisp__splat_draw_desc;

typedef struct crisp__splat_draw_stats {
    size_t ranges, splats, hidden_ranges, samples_written;
    size_t culled;        /* a range skipped in a band of rows whose block depth hides it there */
    size_t chunks_culled; /* a chunk of a range (splat_raster.c) skipped so */
    int box[4];           /* the target's 4x4 blocks the drawn squares can reach: bx0, by0, bx1, by1
                             (bx0 > bx1: none) */
} crisp__splat_draw_stats;

/* Draw the plan's splat ranges into t (its pending clear done: after a crisp__raster_draw):
 * each splat's clip position by the plan's rule (in float), skipped where W <= 0 or outside the
 * near or far plane; a sample at (x, y) (pixels of the whole image) is covered when
 * cx - h <= x < cx + h and cy - h <= y < cy + h (h = plan->splat_half_px); 1 / W constant over
 * the square; the depth test as the rasterizer's (a larger 1 / W wins, ties keep what was drawn
 * first: the surfaces, then the ranges in plan order, each in its order); writes 1 / W, the
 * attributes (u, v, normal, flipped for reversed faces) and the face. Rows of the target are
 * split in bands, each drawn by one worker: the result does not depend on the thread count.
 * A range whose squares the block depth hides whole (hiz) is skipped; with occlude, so is a range,
 * or a chunk of one, in a band of rows where every sample its squares may cover holds a larger
 * 1 / W (drawn before it). pool may be NULL. */
crisp_status crisp__splat_draw(crisp__splat_scratch *s, crisp_raster_target *t, crisp_pool *pool,
                               const crisp__splat_draw_desc *desc, crisp__splat_draw_stats *stats);

#endif
