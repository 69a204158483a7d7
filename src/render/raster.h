/* The CPU rasterizer: triangles in clip space -> depth, perspective-correct attributes and face
 * ids per sample, with a per-fragment test (the trim test) before the depth test.
 *
 * Tile-binned and multithreaded: triangles are clipped (near plane, far plane, a guard band) and
 * set up once, binned to 64x64-pixel tiles in submission order, and the tiles are rasterised in
 * parallel, each by one worker, so no two threads write the same pixel and the result does not
 * depend on the thread count. Vertices snap to 1/256 px and edge functions are exact 64-bit
 * integers with a top-left rule, so triangles that share an edge cover every sample on it
 * exactly once (watertight). Within a tile, 8x8 blocks that a triangle cannot reach in depth are
 * skipped whole, rows are walked as exact runs of covered pixels, and hidden fragments do no
 * attribute or fragment-test work (raster.c). */
#ifndef CRISP_RENDER_RASTER_H
#define CRISP_RENDER_RASTER_H

#include <stdint.h>

#include "crisp/core.h"

#define CRISP_RASTER_ATTRS 5 /* u, v, nx, ny, nz */
#define CRISP_RASTER_SUBPIXEL_BITS 8

typedef struct crisp_raster_vertex {
    double clip[4];                  /* clip-space X, Y, Z, W */
    double attr[CRISP_RASTER_ATTRS]; /* interpolated perspective-correctly */
} crisp_raster_vertex;

/* Bit 31 of a triangle's face is handed to the fragment test but not stored in the target: the
 * CPU backend marks its trim-boundary ribbons with it. */
#define CRISP_RASTER_FACE_FLAG 0x80000000u
/* Bit 30: the fragment test is not run for this triangle's fragments (they are kept), nor stored.
 * The hook for the trim test, per triangle: a backend sets it on triangles of a leaf whose every
 * point lies inside the trim (trim strips fully inside); per face, see
 * crisp__raster_set_untested_faces. */
#define CRISP_RASTER_FACE_NO_TEST 0x40000000u

typedef struct crisp_raster_tri {
    uint32_t v[3];
    uint32_t face;
} crisp_raster_tri;

/* Keep (1) or discard (0) a fragment of `face` at surface parameters (u, v). */
typedef int (*crisp_raster_test_fn)(void *ctx, uint32_t face, double u, double v);

/* Per-sample results; sample s of pixel (i, j) is at index (j * width + i) * samples + s. */
typedef struct crisp_raster_target {
    int width, height, samples;
    /* A window of a larger image (issue 15, image tiles): the target's pixel (0, 0) is pixel
     * (x0, y0) of an image_width x image_height image whose clip space the vertices are in; 0, 0,
     * 0, 0: the target is the whole image. Set by crisp__raster_target_window after init. */
    int x0, y0, image_width, image_height;
    double *inv_w;     /* 1 / W of the visible fragment, 0 where nothing was drawn */
    float *attr;       /* CRISP_RASTER_ATTRS per sample */
    int32_t *face;     /* -1 where nothing was drawn */
    int clear_pending; /* crisp__raster_target_clear_depth waits for the next draw */
    /* A draw with crisp__raster_set_defer_clear on leaves the pending clear of the tiles it
     * draws nothing in: tiles_pending set, pending[tile] != 0 for those (each read as empty by
     * the block depths; the next draw that draws in one clears it first). */
    int tiles_pending;
    uint8_t *pending;
    size_t pending_cap;
} crisp_raster_target;

typedef struct crisp_raster crisp_raster; /* reusable scratch (setup, bins) */

/* n elements of size bytes starting on a cache line (64 bytes), for free(); NULL when out of
 * memory or n * size overflows. The target's buffers and the image's planes: a block row's eight
 * 1/W then fill one line, and the tiles' and the resolve's 64-byte vector loads and stores do
 * not straddle two (malloc's large blocks start 16 bytes past a page). */
void *crisp__alloc_lines(size_t n, size_t size);

crisp_status crisp__raster_create(crisp_raster **dest);
void crisp__raster_destroy(crisp_raster *r);

/* samples: 1, 4 or 16. Reuses the target's buffers when the size is unchanged. */
crisp_status crisp__raster_target_init(crisp_raster_target *t, int width, int height, int samples);
void crisp__raster_target_free(crisp_raster_target *t);
/* Make the target the window (x0, y0, its width x height) of an image_width x image_height image
 * (x0, y0 multiples of 8, the rasterizer's block size, so that every pixel is drawn with the same
 * arithmetic as in the whole image); (0, 0, 0, 0): the whole image. */
crisp_status crisp__raster_target_window(crisp_raster_target *t, int x0, int y0, int image_width,
                                         int image_height);
void crisp__raster_target_clear(crisp_raster_target *t);
/* Clear now the tiles whose clear_depth a deferring draw left pending (before anything but a draw
 * or the block depths reads the target's samples). */
void crisp__raster_target_flush(crisp_raster_target *t, crisp_pool *pool);
/* Clears 1/W and the face ids only: the attributes of empty samples keep stale values, which
 * nothing reads (a sample is drawn iff its face is >= 0). Deferred: the next draw clears each
 * tile just before drawing into it (one pass over memory fewer), or the whole target when it
 * has no triangles; read the target only after a draw. */
void crisp__raster_target_clear_depth(crisp_raster_target *t, crisp_pool *pool);

/* The target's depth per size x size pixel block (size a divisor of 8, so that blocks of the
 * target, whose corner x0, y0 is a multiple of 8, are blocks of the image):
 * dest[by * ((width + size - 1) / size) + bx] = the least 1/W over the block's samples inside
 * the target, 0 when one of them is empty (nothing drawn there) or a clear is pending; written
 * for the blocks bx0 <= bx <= bx1, by0 <= by <= by1 of blocks[4] = bx0, by0, bx1, by1 (clamped
 * to the target; NULL: all), the others left as they are. Later draws only raise stored 1/W
 * (outside fill mode), so a fragment whose 1/W is below it anywhere in the block cannot be drawn
 * there. pool may be NULL. */
void crisp__raster_block_depth(const crisp_raster_target *t, crisp_pool *pool, int size,
                               const int *blocks, double *dest);
/* The live block depth (issue 12): while dest is set (NULL: off; size divides the 64-pixel
 * tile), each draw that computes it (crisp__raster_live_compute) also writes the block depth at
 * size (crisp__raster_block_depth's values) of every tile it clears or draws a triangle in into
 * dest, tile by tile just after the tile's triangles while its samples are still in the cache;
 * a draw that does not marks those tiles as not held. crisp__raster_block_depth_live then gives
 * crisp__raster_block_depth's values for blocks[4] from dest, reading the samples only of the
 * tiles dest does not hold (a close-up's frame took four to five passes over most of the screen
 * for its block depth). dest holds a tile from the draw that clears it, for as long as only
 * draws with dest set write the target; the tiles' depth bounds start from it. */
void crisp__raster_set_live_depth(crisp_raster *r, double *dest, int size);
/* On (1): a draw into a target whose clear_depth is pending clears only the tiles it draws
 * something in, each just before it draws there (its samples then stay in the cache for the
 * draw; a close-up's first draw cleared 25 MB that the next draws read back from memory); the
 * others stay pending (crisp_raster_target.tiles_pending) until a later draw draws there or
 * crisp__raster_target_flush, which must come before anything but a draw or the block depths
 * reads the samples. Off (0, the default): every tile is cleared by the first draw. */
void crisp__raster_set_defer_clear(crisp_raster *r, int on);
void crisp__raster_live_compute(crisp_raster *r, int on);
void crisp__raster_block_depth_live(crisp_raster *r, const crisp_raster_target *t, crisp_pool *pool,
                                    const int *blocks, double *dest);

/* Offsets of the samples inside a pixel, in [0, 1)^2 (x right, y down). */
void crisp__raster_sample_offset(int samples, int s, double dest[2]);

typedef struct crisp_raster_stats {
    size_t triangles_in, triangles_setup, fragments_tested, fragments_discarded;
    size_t fragments_untested; /* kept without the test (CRISP_RASTER_FACE_NO_TEST) */
    size_t blocks_skipped;     /* 8x8 blocks of a triangle rejected whole by the depth bound */
    size_t fragments_boxed;    /* decided by a box (crisp__raster_set_box_test; of a block
                                  found all discarded, only the fragments of its first row) */
} crisp_raster_stats;

/* Whole triangles hidden by a block depth (occlusion culling, src/render/occlusion.c): hiz[by *
 * bw + bx] (bw = ceil(target width / size)) at most the least 1/W stored in block (bx, by) of
 * size x size pixels of the target (0 where a sample is empty: crisp__raster_block_depth), valid
 * for the draws that follow (stored 1/W only rises). A triangle whose fragments' 1/W (in fill
 * mode also its core's) is below it in every block its samples can reach is dropped at set-up:
 * it could not write a sample. Read by later draws until set again; NULL: none. */
void crisp__raster_set_occlusion(crisp_raster *r, const double *hiz, int size);
/* Hierarchical depth rejection (on by default; off only to measure it or to check that the
 * result does not depend on it). */
void crisp__raster_set_hiz(crisp_raster *r, int on);
/* The vector path for per-fragment arithmetic (on by default where the compiler has vector
 * extensions; it gives the scalar path's values bit for bit): on 0 the scalar path, 1 every
 * vector path the processor has, 2 not the AVX2 tiles (tests: the AVX ones where AVX2 is there
 * too), 3 not the AVX-512 tiles (the AVX2 ones where the processor has AVX-512 too). Returns 1
 * when the build has it. */
int crisp__raster_set_vectors(crisp_raster *r, int on);
/* Faces whose fragments skip the fragment test (kept as if it said 1): untested[f] != 0 for face
 * f < count (a face without trim loops: CRISP_PLAN_FACE_ALL_INSIDE). The array is read by later
 * draws until it is set again; NULL: every face is tested. */
void crisp__raster_set_untested_faces(crisp_raster *r, const uint8_t *untested, size_t count);
/* A clip plane in the fragment stage: a sample at pixel position (x, y) (x right, y down, in
 * pixels) with 1/W = iw is discarded where k0 + k1 x + k2 y + k3 iw < 0 (a world plane
 * n . P + d, P on the sample's ray at depth W, times 1/W: the CPU backend's crisp_render_desc
 * clip_plane). NULL: none. Read by later draws until set again. */
void crisp__raster_set_clip(crisp_raster *r, const double k[4]);
/* The fragment test decided for a box of (u, v) at once: 1 when test(ctx, face, u, v) keeps
 * every (u, v) with lo <= (u, v) <= hi, 0 when it discards every one, -1 when it cannot tell
 * (or would rather not). It must agree with the test at every point of the box. */
typedef int (*crisp_raster_box_fn)(void *ctx, uint32_t face, const double lo[2],
                                   const double hi[2]);
/* With a box test, the test is decided for a box of (u, v) that holds every computed (u, v) of
 * a triangle's fragments (rounding included) at set-up (a triangle so discarded is not set up),
 * else, when that part first has a fragment passing the depth test, of its part in a tile, else
 * of an 8x8 block: kept (no test), discarded (the block skipped) or undecided (each fragment
 * runs the test). The same answers as the test, as
 * the box test agrees with it in the box. Used by later draws with their test_ctx; NULL: off. */
void crisp__raster_set_box_test(crisp_raster *r, crisp_raster_box_fn fn);
/* Triangles set up and binned at a time (0: the default, 2^19); small values are for tests. */
void crisp__raster_set_batch(crisp_raster *r, size_t triangles);

/* Draw triangles into the target (depth test: nearer = larger 1/W wins; ties keep the earlier
 * triangle). test may be NULL (keep all). pool may be NULL (one thread). */
crisp_status crisp__raster_draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                                const crisp_raster_vertex *verts, size_t vert_count,
                                const crisp_raster_tri *tris, size_t tri_count,
                                crisp_raster_test_fn test, void *test_ctx,
                                crisp_raster_stats *stats);

/* As crisp__raster_draw, but a fragment replaces a drawn sample only when it is nearer by more
 * than slack[sample] in W (camera depth); empty samples take any fragment. For gap fillers (the
 * CPU backend's trim ribbons) that must not show through surfaces near their own depth. */
crisp_status crisp__raster_draw_fill(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                                     const crisp_raster_vertex *verts, size_t vert_count,
                                     const crisp_raster_tri *tris, size_t tri_count,
                                     crisp_raster_test_fn test, void *test_ctx, const float *slack,
                                     crisp_raster_stats *stats);

/* A second depth test for part of a fill-pass triangle (its core): a sample at (x, y) (pixels of
 * the whole image, x right, y down, as the vertices' screen positions) with |a[0] + a[1] x +
 * a[2] y| <= 1 and |b[0] + b[1] x + b[2] y| <= 1 lies in the core. There a fragment that the
 * slack test refuses is tested again with 1/W = iw[0] + iw[1] x + iw[2] y against slack2, and
 * when that passes it is drawn with that 1/W (its attributes as the triangle's). The CPU
 * backend's ribbon quads (src/render/ribbon.h): their cores take the smaller slack in the one fill
 * pass. An absent core: a = {2, 0, 0}. */
typedef struct crisp_raster_core {
    double a[3], b[3], iw[3];
} crisp_raster_core;

/* 1 when no sample of the quad with clip-space corners clip[0..3] (triangles 0 1 2 and 0 2 3,
 * as a fill draw sets them up with the core core_fn(core_ctx, &core) gives for both, asked only
 * when needed; core_fn NULL: none) could be written into t:
 * every corner is inside the clip planes and each triangle covers no sample area or is hidden by
 * the block depth set with crisp__raster_set_occlusion (the test a draw's set-up applies); 0
 * otherwise, and always without a block depth. Only reads: callable from several threads. For
 * the CPU backend's ribbon quads, culled before they are copied. */
int crisp__raster_quad_hidden(const crisp_raster *r, const crisp_raster_target *t,
                              const double *const clip[4],
                              void (*core_fn)(const void *ctx, crisp_raster_core *core),
                              const void *core_ctx);

/* crisp__raster_draw_fill with a core per triangle (cores[i] for tris[i]; NULL: none) and its
 * slack slack2 (per sample, as slack). */
crisp_status crisp__raster_draw_fill2(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                                      const crisp_raster_vertex *verts, size_t vert_count,
                                      const crisp_raster_tri *tris, size_t tri_count,
                                      crisp_raster_test_fn test, void *test_ctx, const float *slack,
                                      const crisp_raster_core *cores, const float *slack2,
                                      crisp_raster_stats *stats);

/* The view direction (unnormalised) through pixel (i, j): f + (i + 0.5 - width / 2) kx r +
 * (height / 2 - j - 0.5) ky u. */
typedef struct crisp_raster_view {
    double f[3], r[3], u[3];
    double kx, ky;
} crisp_raster_view;

/* slack[sample] = scale times the largest change of W (camera depth) between the sample and the
 * same sample of the four neighbouring pixels where they show the same face, seen from the same
 * side (the sign of normal . view direction; view may be NULL: not compared) (0 for empty
 * samples): how far a surface's depth moves over one pixel at that sample. pool may be NULL. */
void crisp__raster_depth_slack(const crisp_raster_target *t, crisp_pool *pool, double scale,
                               const crisp_raster_view *view, float *slack);
/* The same slack, computed only in the 16x16-pixel cells that the given triangles can cover (the
 * samples a draw_fill of them reads; other samples of slack are left as they were): the values
 * there equal crisp__raster_depth_slack's bit for bit. The fill pass's gap fillers cover few
 * tiles of a close-up. The vertices' screen positions are kept for the next draw of the same
 * vertices into the same target (it does not compute them again), so they must not change in
 * between. */
crisp_status crisp__raster_depth_slack_tris(crisp_raster *r, const crisp_raster_target *t,
                                            crisp_pool *pool, double scale,
                                            const crisp_raster_view *view,
                                            const crisp_raster_vertex *verts, size_t vert_count,
                                            const crisp_raster_tri *tris, size_t tri_count,
                                            float *slack);
/* The same with a second slack at scale2 into slack2 (NULL: none), in the same cells: the CPU
 * backend's ribbon quads and their cores' (crisp__raster_draw_fill2; src/render/ribbon.h). With
 * a block depth set (crisp__raster_set_occlusion), the triangles it hides reach no cell (the fill
 * draw that follows, with the same cores (NULL: none), the same vertices and the same block depth,
 * drops them); they must be the same for that draw. */
crisp_status crisp__raster_depth_slack2_tris(crisp_raster *r, const crisp_raster_target *t,
                                             crisp_pool *pool, double scale, double scale2,
                                             const crisp_raster_view *view,
                                             const crisp_raster_vertex *verts, size_t vert_count,
                                             const crisp_raster_tri *tris, size_t tri_count,
                                             const crisp_raster_core *cores, float *slack,
                                             float *slack2);

/* Work items [0, count) shared out among the workers of a pool (crisp__raster_draw's tiles, the
 * CPU backend's resolve): one home range of consecutive items per worker, which it takes from
 * the front; a worker done with its own takes the items left in the others' from their back.
 * Two workers then seldom work on neighbouring items at once, and item i goes to the same worker
 * call after call while the work stays alike (its data still in that core's caches); the balance
 * is still dynamic. Use: init with the pool's thread count, then a parallel_for over `ranges`
 * items whose function takes items with share_next (k = 0 first) until it returns 0. */
#define CRISP_RASTER_SHARE_MAX 64
typedef struct crisp_raster_share {
    int ranges; /* one per worker, at most CRISP_RASTER_SHARE_MAX */
    struct {
        _Alignas(64) _Atomic uint64_t ends; /* [lo, hi) in bits 0-31, 32-63; a line each */
    } range[CRISP_RASTER_SHARE_MAX];
} crisp_raster_share;

/* count below 2^32. */
void crisp__raster_share_init(crisp_raster_share *s, size_t count, int workers);
/* The next item for worker (its index in the pool) into *item; 0 when none is left. */
int crisp__raster_share_next(crisp_raster_share *s, int worker, int *k, size_t *item);

#endif
