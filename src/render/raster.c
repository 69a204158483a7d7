/* The CPU rasterizer (see raster.h): homogeneous clipping, fixed-point setup with a top-left
 * rule, order-preserving tile binning and per-tile parallel rasterisation. */
#include "raster.h"

#include "core/compiler.h"

#include <math.h>
#include <stdatomic.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && defined(__x86_64__) && defined(__SSE2__)
#include <immintrin.h>
#endif
#include <stdlib.h>
#include <string.h>
#ifdef DEBUG_BOX
#include <stdio.h>
#endif

#define TILE 64
#define SUB (1 << CRISP_RASTER_SUBPIXEL_BITS)
#define CHUNKS 64 /* setup work units; fixed so the output order never depends on threads */
#define GUARD_PX                                                                                   \
    1048576.0 /* screen coordinates stay within +-2^20 px: exact int64 edge functions */
#define MAX_POLY 12

typedef struct setup_tri {
    int64_t x[3], y[3]; /* fixed point, counter-clockwise in the (x right, y down) frame */
    int64_t bias[3];    /* 0 for edges that own their samples (top-left rule), else -1 */
    /* Edge k's function at a fixed-point sample position: E = ea px + eb py + ec (the same
     * integer as ea (px - x_a0) + eb (py - y_a0) + bias: every term stays below 2^62). */
    int64_t ea[3], eb[3], ec[3];
    /* 1/W and attribute/W as planes over the unsnapped screen position: value at (ox, oy) and
     * gradients. Snapping moves coverage by at most 1/512 px but not the interpolated values. */
    double ox, oy;
    double q0[1 + CRISP_RASTER_ATTRS], qx[1 + CRISP_RASTER_ATTRS], qy[1 + CRISP_RASTER_ATTRS];
    int x0, y0, x1, y1; /* pixel bbox, inclusive, clamped to the image */
    uint32_t face;
    /* -2: every fragment runs the test (or none); else the box test decides it for boxes of
     * (u, v) where it can (crisp__raster_set_box_test; raster_tile_s), and boxed is its answer for
     * the whole triangle, found at set-up: 1 every fragment kept, -1 not decided (a triangle whose
     * every fragment is discarded is not set up). tbox: the triangle's box of (u, v)
     * (uv_hull_box), when tbox_ok. */
    int boxed, tbox_ok;
    double tbox[4];
    const crisp_raster_core *core; /* fill mode: the triangle's core (crisp__raster_draw_fill2) */
} setup_tri;

/* A triangle's attribute planes copied out of its setup record for the tile's loops (a local
 * copy: the target's stores cannot alias it, so its values stay in registers or are loaded once).
 */
typedef struct planes {
    double q0[1 + CRISP_RASTER_ATTRS], qx[1 + CRISP_RASTER_ATTRS], qy[1 + CRISP_RASTER_ATTRS];
} planes;

/* A fragment's attributes: ((a/W at the origin + x gradient dx) + y gradient dy) * W. */
static inline void attrs_scalar(const planes *st, double dx, double dy, double w, double *a)
{
    for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
        a[k] = (st->q0[k + 1] + st->qx[k + 1] * dx + st->qy[k + 1] * dy) * w;
}

/* The same with two attributes per operation (GCC vector extensions, SSE2 on x86-64): the same
 * IEEE operations in the same order on each lane (no fused multiply-add: ISO C mode contracts
 * nothing), so the same values bit for bit (test_raster_fast compares both paths). */
#if defined(__GNUC__) && CRISP_RASTER_ATTRS == 5
#define HAVE_VECTORS 1
typedef double v2d __attribute__((vector_size(16)));
typedef double v2d_u __attribute__((vector_size(16), aligned(8))); /* unaligned loads, stores */

static inline void attrs_vector(const planes *st, double dx, double dy, double w, double *a)
{
    const v2d vdx = {dx, dx}, vdy = {dy, dy}, vw = {w, w};
    for (int k = 0; k < 4; k += 2) {
        v2d q0 = *(const v2d_u *)(st->q0 + 1 + k), qx = *(const v2d_u *)(st->qx + 1 + k),
            qy = *(const v2d_u *)(st->qy + 1 + k);
        *(v2d_u *)(a + k) = (q0 + qx * vdx + qy * vdy) * vw;
    }
    a[4] = (st->q0[5] + st->qx[5] * dx + st->qy[5] * dy) * w;
}
#else
#define HAVE_VECTORS 0
#define attrs_vector attrs_scalar
#endif

/* Input triangles set up and binned at a time. Set-up records are about 330 bytes: 2^19 of them
 * (and the chunks' spare capacity) were 330 MB of impeller x 49's 1.5 GB peak (issue 12); 2^16 keep
 * the set-up memory near 25 MB, and a batch's fixed cost (binning offsets over 64 chunks x the
 * tiles, a pass over the tiles) stays small beside 2^16 triangles' set-up. */
#define BATCH ((size_t)1 << 16)

typedef struct pvert pvert;

struct crisp_raster {
    setup_tri *chunk_tris[CHUNKS]; /* set-up triangles of the current batch, per setup chunk */
    size_t chunk_cap[CHUNKS];
    pvert *vcache; /* per vertex, screen-space form */
    size_t vcache_cap;
    /* The vertices and target vcache holds (crisp__raster_depth_slack_tris), for the next draw. */
    const crisp_raster_vertex *vcache_verts;
    size_t vcache_count;
    const crisp_raster_target *vcache_t;
    size_t batch; /* 0: BATCH (crisp__raster_set_batch, for tests) */
    const setup_tri **bin_items;
    size_t bin_cap;
    uint32_t *bin_start; /* per tile, tile_count + 1 */
    size_t bin_start_cap;
    int no_hiz;              /* hierarchical depth rejection off (crisp__raster_set_hiz) */
    int no_vectors;          /* the scalar path only (crisp__raster_set_vectors) */
    int no_avx2;             /* not the AVX2 tiles (crisp__raster_set_vectors(r, 2)) */
    int no_avx512;           /* not the AVX-512 tiles (crisp__raster_set_vectors(r, 3)) */
    const uint8_t *untested; /* per face (crisp__raster_set_untested_faces) */
    size_t untested_count;
    uint8_t *tile_mask; /* per cell (crisp__raster_depth_slack_tris) */
    size_t tile_mask_cap;
    int (*tri_boxes)[4]; /* per triangle: its pixel box (crisp__raster_depth_slack_tris) */
    size_t tri_boxes_cap;
    uint32_t *bin_counts; /* per setup chunk and tile: entries (parallel binning) */
    size_t bin_counts_cap;
    crisp_raster_box_fn box_test; /* crisp__raster_set_box_test */
    const double *occl_hiz;       /* crisp__raster_set_occlusion: per block, least 1/W drawn */
    int occl_size;
    int occl_shift; /* log2 of occl_size when a power of two, else -1 */
    int clip_on;    /* crisp__raster_set_clip */
    double clip[4]; /* keep k0 + k1 x + k2 y + k3 / W >= 0 */
    double *live;   /* crisp__raster_set_live_depth: the block depth kept by the draws */
    int live_size;
    int live_compute;   /* crisp__raster_live_compute */
    uint8_t *live_tile; /* per tile: 1 when live holds its blocks' present values */
    size_t live_tile_cap;
    int defer_clear; /* crisp__raster_set_defer_clear */
};

void crisp__raster_set_clip(crisp_raster *r, const double k[4])
{
    r->clip_on = k != NULL;
    for (int i = 0; i < 4; i++)
        r->clip[i] = k ? k[i] : 0;
}

void crisp__raster_set_box_test(crisp_raster *r, crisp_raster_box_fn fn)
{
    r->box_test = fn;
}

void crisp__raster_set_occlusion(crisp_raster *r, const double *hiz, int size)
{
    r->occl_hiz = hiz;
    r->occl_size = size > 0 ? size : 1;
    r->occl_shift = -1;
    for (int k = 0; k < 30; k++)
        if (r->occl_size == 1 << k) r->occl_shift = k;
}

void crisp__raster_set_untested_faces(crisp_raster *r, const uint8_t *untested, size_t count)
{
    r->untested = untested;
    r->untested_count = untested ? count : 0;
}

void crisp__raster_set_live_depth(crisp_raster *r, double *dest, int size)
{
    r->live = dest && size > 0 && TILE % size == 0 ? dest : NULL;
    r->live_size = size;
}

void crisp__raster_live_compute(crisp_raster *r, int on)
{
    r->live_compute = on;
}

void crisp__raster_set_defer_clear(crisp_raster *r, int on)
{
    r->defer_clear = on;
}

void crisp__raster_set_hiz(crisp_raster *r, int on)
{
    r->no_hiz = !on;
}

int crisp__raster_set_vectors(crisp_raster *r, int on)
{
    r->no_vectors = !on;
    r->no_avx2 = on == 2;
    r->no_avx512 = on == 2 || on == 3;
    return HAVE_VECTORS;
}

void crisp__raster_set_batch(crisp_raster *r, size_t triangles)
{
    r->batch = triangles;
}

crisp_status crisp__raster_create(crisp_raster **dest)
{
    crisp_raster *r = calloc(1, sizeof *r);
    if (!r) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating the rasterizer");
    *dest = r;
    return CRISP_OK;
}

void crisp__raster_destroy(crisp_raster *r)
{
    if (!r) return;
    for (int ch = 0; ch < CHUNKS; ch++)
        free(r->chunk_tris[ch]);
    free(r->vcache);
    free(r->bin_items);
    free(r->bin_start);
    free(r->tile_mask);
    free(r->tri_boxes);
    free(r->bin_counts);
    free(r->live_tile);
    free(r);
}

void *crisp__alloc_lines(size_t n, size_t size)
{
    if (size && n > (SIZE_MAX - 63) / size) return NULL;
    return aligned_alloc(64, (n * size + 63) / 64 * 64);
}

crisp_status crisp__raster_target_init(crisp_raster_target *t, int width, int height, int samples)
{
    if (width <= 0 || height <= 0 || width > 65536 || height > 65536)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image size %dx%d: expected 1..65536", width,
                           height);
    if (samples != 1 && samples != 4 && samples != 16)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%d samples per pixel: expected 1, 4 or 16",
                           samples);
    size_t n = (size_t)width * (size_t)height * (size_t)samples;
    if (t->inv_w && (size_t)t->width * t->height * t->samples == n) {
        t->width = width;
        t->height = height;
        t->samples = samples;
        return CRISP_OK;
    }
    crisp__raster_target_free(t);
    t->inv_w = crisp__alloc_lines(n, sizeof *t->inv_w);
    t->attr = crisp__alloc_lines(n, CRISP_RASTER_ATTRS * sizeof *t->attr);
    t->face = crisp__alloc_lines(n, sizeof *t->face);
    if (!t->inv_w || !t->attr || !t->face) {
        crisp__raster_target_free(t);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a %dx%d image with %d samples",
                           width, height, samples);
    }
    t->width = width;
    t->height = height;
    t->samples = samples;
    return CRISP_OK;
}

/* The whole image's size (the target is a window of it, or all of it). */
static int image_w(const crisp_raster_target *t)
{
    return t->image_width ? t->image_width : t->width;
}

static int image_h(const crisp_raster_target *t)
{
    return t->image_height ? t->image_height : t->height;
}

crisp_status crisp__raster_target_window(crisp_raster_target *t, int x0, int y0, int image_width,
                                         int image_height)
{
    if (!image_width && !image_height && !x0 && !y0) {
        t->x0 = t->y0 = t->image_width = t->image_height = 0;
        return CRISP_OK;
    }
    if (x0 < 0 || y0 < 0 || x0 % 8 || y0 % 8 || x0 + t->width > image_width ||
        y0 + t->height > image_height || image_width > 65536 || image_height > 65536)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "window %dx%d at (%d, %d) of a %dx%d image: expected a window inside "
                           "the image at a multiple of 8",
                           t->width, t->height, x0, y0, image_width, image_height);
    t->x0 = x0, t->y0 = y0, t->image_width = image_width, t->image_height = image_height;
    return CRISP_OK;
}

void crisp__raster_target_free(crisp_raster_target *t)
{
    free(t->inv_w);
    free(t->attr);
    free(t->face);
    free(t->pending);
    memset(t, 0, sizeof *t);
}

void crisp__raster_target_clear(crisp_raster_target *t)
{
    size_t n = (size_t)t->width * t->height * t->samples;
    memset(t->inv_w, 0, n * sizeof *t->inv_w);
    memset(t->attr, 0, n * CRISP_RASTER_ATTRS * sizeof *t->attr);
    memset(t->face, 0xff, n * sizeof *t->face);
    t->clear_pending = t->tiles_pending = 0;
}

typedef struct clear_ctx {
    crisp_raster_target *t;
} clear_ctx;

static void clear_rows(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    crisp_raster_target *t = ((clear_ctx *)vctx)->t;
    size_t rs = (size_t)t->width * t->samples, a = begin * rs, n = (end - begin) * rs;
    memset(t->inv_w + a, 0, n * sizeof *t->inv_w);
    memset(t->face + a, 0xff, n * sizeof *t->face);
}

void crisp__raster_target_clear_depth(crisp_raster_target *t, crisp_pool *pool)
{
    (void)pool;
    t->clear_pending = 1; /* done by the next draw, tile by tile */
    t->tiles_pending = 0;
}

/* Tile `tile` of the target (tiles_x per row) cleared as clear_depth does. */
static void clear_tile(crisp_raster_target *t, int tiles_x, size_t tile)
{
    int x0 = (int)(tile % (size_t)tiles_x) * TILE, y0 = (int)(tile / (size_t)tiles_x) * TILE;
    int x1 = x0 + TILE < t->width ? x0 + TILE : t->width;
    int y1 = y0 + TILE < t->height ? y0 + TILE : t->height;
    size_t n = (size_t)(x1 - x0) * t->samples;
    for (int j = y0; j < y1; j++) {
        size_t a = ((size_t)j * t->width + x0) * t->samples;
        memset(t->inv_w + a, 0, n * sizeof *t->inv_w);
        memset(t->face + a, 0xff, n * sizeof *t->face);
    }
}

static void flush_tiles(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    crisp_raster_target *t = vctx;
    int tiles_x = (t->width + TILE - 1) / TILE;
    for (size_t tile = begin; tile < end; tile++)
        if (t->pending[tile]) {
            clear_tile(t, tiles_x, tile);
            t->pending[tile] = 0;
        }
}

void crisp__raster_target_flush(crisp_raster_target *t, crisp_pool *pool)
{
    if (!t->tiles_pending) return;
    size_t tiles = (size_t)((t->width + TILE - 1) / TILE) * (size_t)((t->height + TILE - 1) / TILE);
    crisp_pool_parallel_for(pool, tiles, 8, flush_tiles, t);
    t->tiles_pending = 0;
}

/* The blocks of size x size pixels within b (clamp_blocks) that hold a sample of a tile whose
 * clear is pending: 0 (empty) in dest, whatever the samples hold. */
static void zero_pending_blocks(const crisp_raster_target *t, int size, const int b[4],
                                double *dest)
{
    int tiles_x = (t->width + TILE - 1) / TILE, tiles_y = (t->height + TILE - 1) / TILE;
    int bw = (t->width + size - 1) / size;
    for (int ty = 0; ty < tiles_y; ty++)
        for (int tx = 0; tx < tiles_x; tx++) {
            if (!t->pending[(size_t)ty * tiles_x + tx]) continue;
            int bx0 = tx * TILE / size, bx1 = ((tx + 1) * TILE - 1) / size;
            int by0 = ty * TILE / size, by1 = ((ty + 1) * TILE - 1) / size;
            bx0 = bx0 > b[0] ? bx0 : b[0], bx1 = bx1 < b[2] ? bx1 : b[2];
            by0 = by0 > b[1] ? by0 : b[1], by1 = by1 < b[3] ? by1 : b[3];
            for (int by = by0; by <= by1; by++)
                for (int bx = bx0; bx <= bx1; bx++)
                    dest[(size_t)by * bw + bx] = 0;
        }
}

/* A pending clear_depth of the whole target, now. */
static void clear_now(crisp_raster_target *t, crisp_pool *pool)
{
    clear_ctx c = {t};
    crisp_pool_parallel_for(pool, (size_t)t->height, 64, clear_rows, &c);
}

typedef struct block_depth_ctx {
    const crisp_raster_target *t;
    int size, bx0, by0, bx1;
    double *dest;
} block_depth_ctx;

#if defined(__GNUC__) && defined(__x86_64__) && defined(__SSE2__)
#define HAVE_AVX_DEPTH 1
/* Whole 4 x 4 blocks bx .. bxe - 1 of block row by of a one-sample target (its pixel rows up to
 * j1), two at a time with AVX where the processor has it (chosen at run time): each block's least
 * 1/W into out[bx]. A least value: the order of the compares does not matter (stored values are
 * never NaN, and their zeros are +0). Returns the first block left. */
__attribute__((target("avx"))) static int block_depth4_avx(const crisp_raster_target *t, int by,
                                                           int bx, int bxe, int j1, double *out)
{
    for (; bx + 1 < bxe; bx += 2) {
        const double *p = t->inv_w + (size_t)by * 4 * t->width + (size_t)bx * 4;
        __m256d a = _mm256_loadu_pd(p), b = _mm256_loadu_pd(p + 4);
        for (int j = by * 4 + 1; j < j1; j++) {
            p += t->width;
            a = _mm256_min_pd(a, _mm256_loadu_pd(p));
            b = _mm256_min_pd(b, _mm256_loadu_pd(p + 4));
        }
        /* a0 a1 b0 b1 against a2 a3 b2 b3, then each pair's two */
        __m256d m =
            _mm256_min_pd(_mm256_permute2f128_pd(a, b, 0x20), _mm256_permute2f128_pd(a, b, 0x31));
        m = _mm256_min_pd(m, _mm256_permute_pd(m, 5));
        out[bx] = _mm256_cvtsd_f64(m);
        out[bx + 1] = _mm_cvtsd_f64(_mm256_extractf128_pd(m, 1));
    }
    return bx;
}
#else
#define HAVE_AVX_DEPTH 0
#endif

/* Blocks bx0 .. bx1 of block row by (size n): the least 1/W of each, row by row of pixels. */
static void block_depth_row(const crisp_raster_target *t, int n, int by, int bx0, int bx1,
                            double *dest)
{
    int S = t->samples, bw = (t->width + n - 1) / n;
    double *out = dest + (size_t)by * (size_t)bw;
    for (int bx = bx0; bx <= bx1; bx++)
        out[bx] = INFINITY;
    int j1 = (by + 1) * n < t->height ? (by + 1) * n : t->height;
    int gx0 = bx0; /* the blocks left to the loop below */
#if defined(__SSE2__)
    if (S == 1 && n == 4) { /* the common case: each block's 4 x 4 values in registers */
        int bxe = bx1 < t->width / 4 ? bx1 + 1 : t->width / 4; /* whole blocks */
        int bx = bx0;
#if HAVE_AVX_DEPTH
        if (__builtin_cpu_supports("avx")) bx = block_depth4_avx(t, by, bx, bxe, j1, out);
#endif
        for (; bx < bxe; bx++) {
            const double *p = t->inv_w + (size_t)by * 4 * t->width + (size_t)bx * 4;
            __m128d m2 = _mm_min_pd(_mm_loadu_pd(p), _mm_loadu_pd(p + 2));
            for (int j = by * 4 + 1; j < j1; j++) {
                p += t->width;
                m2 = _mm_min_pd(m2, _mm_min_pd(_mm_loadu_pd(p), _mm_loadu_pd(p + 2)));
            }
            double l[2];
            _mm_storeu_pd(l, m2);
            out[bx] = l[0] < l[1] ? l[0] : l[1];
        }
        gx0 = bxe > gx0 ? bxe : gx0;
    }
#endif
    for (int j = by * n; j < j1; j++) {
        const double *row = t->inv_w + (size_t)j * t->width * S;
        for (int bx = gx0; bx <= bx1; bx++) {
            size_t a = (size_t)bx * n * S,
                   b = (size_t)(bx * n + n < t->width ? bx * n + n : t->width) * S;
            double m = out[bx];
            size_t k = a;
#if defined(__SSE2__)
            /* Two lanes at a time (a least value: the order does not matter; stored values
             * are never NaN). */
            if (k + 2 <= b) {
                __m128d m2 = _mm_set1_pd(m);
                for (; k + 2 <= b; k += 2)
                    m2 = _mm_min_pd(_mm_loadu_pd(row + k), m2);
                double l[2];
                _mm_storeu_pd(l, m2);
                m = l[0] < l[1] ? l[0] : l[1];
            }
#endif
            for (; k < b; k++)
                m = row[k] < m ? row[k] : m;
            out[bx] = m;
        }
    }
}

/* Block rows by0 + [begin, end), blocks bx0 .. bx1 of each. */
static void block_depth_rows(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const block_depth_ctx *c = vctx;
    for (int by = c->by0 + (int)begin; by < c->by0 + (int)end; by++)
        block_depth_row(c->t, c->size, by, c->bx0, c->bx1, c->dest);
}

/* b: the block rectangle blocks (x0, y0, x1, y1; NULL: all) of size x size blocks clamped to
 * the target; 0 when it is empty. */
static int clamp_blocks(const crisp_raster_target *t, int size, const int *blocks, int b[4])
{
    int bw = (t->width + size - 1) / size, bh = (t->height + size - 1) / size;
    b[0] = b[1] = 0;
    b[2] = bw - 1;
    b[3] = bh - 1;
    if (blocks)
        for (int k = 0; k < 4; k++) {
            int lim = k % 2 ? bh - 1 : bw - 1;
            b[k] = blocks[k] < 0 ? 0 : blocks[k] > lim ? lim : blocks[k];
        }
    return b[0] <= b[2] && b[1] <= b[3];
}

void crisp__raster_block_depth(const crisp_raster_target *t, crisp_pool *pool, int size,
                               const int *blocks, double *dest)
{
    int bw = (t->width + size - 1) / size, b[4];
    if (!clamp_blocks(t, size, blocks, b)) return;
    if (t->clear_pending) {
        for (int by = b[1]; by <= b[3]; by++)
            for (int bx = b[0]; bx <= b[2]; bx++)
                dest[(size_t)by * bw + bx] = 0;
        return;
    }
    block_depth_ctx c = {t, size, b[0], b[1], b[2], dest};
    crisp_pool_parallel_for(pool, (size_t)(b[3] - b[1] + 1), 4, block_depth_rows, &c);
    if (t->tiles_pending) zero_pending_blocks(t, size, b, dest);
}

/* The live block depth of one tile (crisp__raster_set_live_depth): its blocks, from its samples,
 * or 0 when it is just cleared (empty). */
static void live_tile(const crisp_raster *r, const crisp_raster_target *t, int tiles_x, size_t tile,
                      int empty)
{
    int n = r->live_size, bw = (t->width + n - 1) / n;
    int x0 = (int)(tile % (size_t)tiles_x) * TILE, y0 = (int)(tile / (size_t)tiles_x) * TILE;
    int x1 = x0 + TILE < t->width ? x0 + TILE : t->width;
    int y1 = y0 + TILE < t->height ? y0 + TILE : t->height;
    for (int by = y0 / n; by <= (y1 - 1) / n; by++)
        if (empty)
            memset(r->live + (size_t)by * bw + x0 / n, 0,
                   (size_t)((x1 - 1) / n - x0 / n + 1) * sizeof *r->live);
        else
            block_depth_row(t, n, by, x0 / n, (x1 - 1) / n, r->live);
}

typedef struct live_ctx {
    crisp_raster *r;
    const crisp_raster_target *t;
    int tiles_x, tx0, tx1, ty0;
} live_ctx;

/* Tile rows ty0 + [begin, end) of tiles tx0 .. tx1: those live does not hold, from their samples.
 */
static void live_rows(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const live_ctx *c = vctx;
    for (int ty = c->ty0 + (int)begin; ty < c->ty0 + (int)end; ty++)
        for (int tx = c->tx0; tx <= c->tx1; tx++) {
            size_t tile = (size_t)ty * c->tiles_x + tx;
            if (c->r->live_tile[tile]) continue;
            live_tile(c->r, c->t, c->tiles_x, tile, c->t->tiles_pending && c->t->pending[tile]);
            c->r->live_tile[tile] = 1;
        }
}

void crisp__raster_block_depth_live(crisp_raster *r, const crisp_raster_target *t, crisp_pool *pool,
                                    const int *blocks, double *dest)
{
    int size = r->live_size;
    size_t tiles = (size_t)((t->width + TILE - 1) / TILE) * (size_t)((t->height + TILE - 1) / TILE);
    if (!r->live || t->clear_pending || r->live_tile_cap < tiles) { /* nothing held */
        crisp__raster_block_depth(t, pool, size, blocks, dest);
        return;
    }
    int bw = (t->width + size - 1) / size, b[4];
    if (!clamp_blocks(t, size, blocks, b)) return;
    int per = TILE / size;
    live_ctx c = {r, t, (t->width + TILE - 1) / TILE, b[0] / per, b[2] / per, b[1] / per};
    crisp_pool_parallel_for(pool, (size_t)(b[3] / per - c.ty0 + 1), 1, live_rows, &c);
    for (int by = b[1]; by <= b[3]; by++) {
        size_t a = (size_t)by * bw + (size_t)b[0];
        memcpy(dest + a, r->live + a, (size_t)(b[2] - b[0] + 1) * sizeof *dest);
    }
}

void crisp__raster_sample_offset(int samples, int s, double dest[2])
{
    /* 4: rotated grid; 16: a regular 4x4 grid. */
    static const double rot4[4][2] = {
        {0.375, 0.125}, {0.875, 0.375}, {0.125, 0.625}, {0.625, 0.875}};
    if (samples == 4) {
        dest[0] = rot4[s][0];
        dest[1] = rot4[s][1];
    } else if (samples == 16) {
        dest[0] = (s % 4 + 0.5) / 4.0;
        dest[1] = (s / 4 + 0.5) / 4.0;
    } else {
        dest[0] = dest[1] = 0.5;
    }
}

/* ---- clipping ----------------------------------------------------------------------------------
 */

typedef struct {
    double p[4 + CRISP_RASTER_ATTRS]; /* clip position then attributes */
} cvert;

/* Signed distances to the six clip planes (inside >= 0). */
static void plane_dists(const double *c, double gx, double gy, double d[6])
{
    d[0] = c[2] + c[3];      /* near */
    d[1] = c[3] - c[2];      /* far */
    d[2] = gx * c[3] - c[0]; /* guard band */
    d[3] = gx * c[3] + c[0];
    d[4] = gy * c[3] - c[1];
    d[5] = gy * c[3] + c[1];
}

static int clip_polygon(cvert *poly, int n, double gx, double gy)
{
    cvert tmp[MAX_POLY];
    for (int pl = 0; pl < 6 && n > 0; pl++) {
        int m = 0;
        for (int i = 0; i < n; i++) {
            const cvert *a = &poly[i], *b = &poly[(i + 1) % n];
            double da[6], db[6];
            plane_dists(a->p, gx, gy, da);
            plane_dists(b->p, gx, gy, db);
            int ina = da[pl] >= 0, inb = db[pl] >= 0;
            if (ina && m < MAX_POLY) tmp[m++] = *a;
            if (ina != inb && m < MAX_POLY) {
                double t = da[pl] / (da[pl] - db[pl]);
                for (int k = 0; k < 4 + CRISP_RASTER_ATTRS; k++)
                    tmp[m].p[k] = a->p[k] + t * (b->p[k] - a->p[k]);
                m++;
            }
        }
        memcpy(poly, tmp, (size_t)m * sizeof *poly);
        n = m;
    }
    return n;
}

/* ---- setup -------------------------------------------------------------------------------------
 */

/* A vertex in screen space: position, snapped position, and 1/W and attribute/W. Computed once
 * per vertex for vertices inside every clip plane (most of them), per use for clipped ones; the
 * arithmetic is the same either way. */
typedef struct pvert {
    double sx, sy;
    int64_t fx, fy;
    double val[1 + CRISP_RASTER_ATTRS];
    int ok; /* inside every clip plane, finite, W > 0 (cache only) */
} pvert;

/* llround for |x| < 2^52 (the guard band keeps screen positions far inside): the same value as
 * the libm call (halves round away from zero), inline. x - trunc(x) is exact there. */
static inline int64_t round_half_away(double x)
{
    double t = (double)(int64_t)x, f = x - t;
    return (int64_t)t + (f >= 0.5) - (f <= -0.5);
}

/* 0 when the vertex cannot be set up (W <= 0, beyond the guard band or not finite); else its
 * screen position and 1/W (val[0]), without the attributes. */
static ALWAYS_INLINE int project_depth(const double *p, const crisp_raster_target *t, pvert *out)
{
    double w = p[3];
    if (!(w > 0)) return 0;
    out->sx = (p[0] / w + 1.0) * 0.5 * image_w(t);
    out->sy = (1.0 - p[1] / w) * 0.5 * image_h(t);
    if (!(fabs(out->sx) <= 2 * GUARD_PX && fabs(out->sy) <= 2 * GUARD_PX)) return 0;
    out->fx = round_half_away(out->sx * SUB);
    out->fy = round_half_away(out->sy * SUB);
    out->val[0] = 1.0 / w;
    return 1;
}

/* project_depth and the attributes over W. */
static int project2(const double *p, const double *attr, const crisp_raster_target *t, pvert *out)
{
    if (!project_depth(p, t, out)) return 0;
    double iw = out->val[0];
    for (int q = 1; q <= CRISP_RASTER_ATTRS; q++)
        out->val[q] = attr[q - 1] * iw;
    return 1;
}

/* p: clip position then attributes (a clipped vertex). */
static int project(const double *p, const crisp_raster_target *t, pvert *out)
{
    return project2(p, p + 4, t, out);
}

typedef struct {
    crisp_raster *r;
    const crisp_raster_target *t;
    const crisp_raster_vertex *verts;
    size_t vert_count;
    const crisp_raster_tri *tris;
    size_t first, count; /* the batch */
    double gx, gy;
    crisp_raster_test_fn test;
    void *test_ctx;
    const crisp_raster_core *cores; /* per triangle (crisp__raster_draw_fill2), NULL: none */
    size_t counts[CHUNKS];
    crisp_status status[CHUNKS];
} setup_ctx;

/* 1 when the block depth of crisp__raster_set_occlusion shows that no sample of the triangle a, b,
 * d (projected vertices) in pixels [x0, x1] x [y0, y1] of the whole image (inside the target) can
 * pass the depth test: the largest 1/W its fragments can compute is below the least 1/W stored in
 * every block of that rectangle. Covered samples lie in the snapped triangle, where the affine
 * 1/W plane setup_one computes (the same expressions) is largest at a snapped vertex; the slop
 * covers the rounding of its evaluation at a sample (as the tiles' own depth bound). In fill mode
 * a fragment passes only where it is empty (0 in the block depth) or where its 1/W, or its core's
 * (core_pass: the core's plane, also largest at a snapped vertex), is above the stored one, so
 * the same bound holds with the core's plane included. */
static double core_bound(const crisp_raster_core *core, const pvert *const v[3], int x0, int y0,
                         int x1, int y1)
{
    double cbest = -INFINITY;
    for (int k = 0; k < 3; k++) {
        double px = (double)v[k]->fx / SUB, py = (double)v[k]->fy / SUB;
        double wc = core->iw[0] + core->iw[1] * px + core->iw[2] * py;
        cbest = wc > cbest ? wc : cbest;
    }
    double X = fabs((double)x0) > fabs(x1 + 1.0) ? fabs((double)x0) : fabs(x1 + 1.0);
    double Y = fabs((double)y0) > fabs(y1 + 1.0) ? fabs((double)y0) : fabs(y1 + 1.0);
    return cbest + 1e-12 * (fabs(core->iw[0]) + fabs(core->iw[1]) * X + fabs(core->iw[2]) * Y);
}

/* tri_hidden, and when it is hidden the least block value of its box in *least (NULL: not
 * wanted). */
static int tri_hidden_least(const crisp_raster *r, const crisp_raster_target *t, const pvert *a,
                            const pvert *b, const pvert *d, const crisp_raster_core *core, int x0,
                            int y0, int x1, int y1, double *least);

static int tri_hidden(const crisp_raster *r, const crisp_raster_target *t, const pvert *a,
                      const pvert *b, const pvert *d, const crisp_raster_core *core, int x0, int y0,
                      int x1, int y1)
{
    return tri_hidden_least(r, t, a, b, d, core, x0, y0, x1, y1, NULL);
}

static int tri_hidden_least(const crisp_raster *r, const crisp_raster_target *t, const pvert *a,
                            const pvert *b, const pvert *d, const crisp_raster_core *core, int x0,
                            int y0, int x1, int y1, double *least)
{
    const double *hz = r->occl_hiz;
    if (!hz) return 0;
    /* The box lies in the target (tri_pixel_box): its offsets are >= 0, so a shift divides them
     * by a power-of-two block size (no integer divisions on this path). */
    int n = r->occl_size, sh = r->occl_shift, bw, bx0, bx1, by0, by1;
    if (sh >= 0) {
        bw = (t->width + n - 1) >> sh;
        bx0 = (x0 - t->x0) >> sh, bx1 = (x1 - t->x0) >> sh;
        by0 = (y0 - t->y0) >> sh, by1 = (y1 - t->y0) >> sh;
    } else {
        bw = (t->width + n - 1) / n;
        bx0 = (x0 - t->x0) / n, bx1 = (x1 - t->x0) / n;
        by0 = (y0 - t->y0) / n, by1 = (y1 - t->y0) / n;
    }
    /* The first block: most visible triangles stop here. */
    double first = hz[(size_t)by0 * bw + bx0];
    if (!(first > 0)) return 0;
    /* For the set-up (least not wanted): a vertex's 1/W at or above the first block's value, the
     * triangle is taken as not hidden before its plane is worked out (most visible triangles
     * stop here). Not hidden is always a safe answer: the triangle is then drawn, and its
     * fragments' own depth tests decide (a hidden triangle's write nothing). */
    if (!least) {
        double va = a->val[0], vb = b->val[0], vd = d->val[0];
        double vm = va > vb ? va : vb;
        vm = vd > vm ? vd : vm;
        if (vm >= first) return 0;
    }
    double det = (b->sx - a->sx) * (d->sy - a->sy) - (b->sy - a->sy) * (d->sx - a->sx);
    if (!(fabs(det) > 0)) return 0;
    double d1 = b->val[0] - a->val[0], d2 = d->val[0] - a->val[0];
    double qx = (d1 * (d->sy - a->sy) - d2 * (b->sy - a->sy)) / det;
    double qy = (d2 * (b->sx - a->sx) - d1 * (d->sx - a->sx)) / det;
    const pvert *v[3] = {a, b, d};
    double best = -INFINITY;
    for (int k = 0; k < 3; k++) {
        double px = (double)v[k]->fx / SUB, py = (double)v[k]->fy / SUB;
        double w = a->val[0] + qx * (px - a->sx) + qy * (py - a->sy);
        best = w > best ? w : best;
    }
    double mx = fabs(x0 - a->sx) > fabs(x1 + 1 - a->sx) ? fabs(x0 - a->sx) : fabs(x1 + 1 - a->sx);
    double my = fabs(y0 - a->sy) > fabs(y1 + 1 - a->sy) ? fabs(y0 - a->sy) : fabs(y1 + 1 - a->sy);
    best += 1e-12 * (fabs(a->val[0]) + fabs(qx) * mx + fabs(qy) * my);
    if (core) {
        double cbest = core_bound(core, v, x0, y0, x1, y1);
        best = cbest > best ? cbest : best;
    }
    if (!(best < first)) return 0; /* also NaN */
    double low = first;
#if defined(__SSE2__)
    /* Two blocks at a time: the same compares; the least of values all above best (no NaN
     * among them), in any order. */
    const __m128d vbest = _mm_set1_pd(best);
    __m128d vlow = _mm_set1_pd(first);
    for (int by = by0; by <= by1; by++) {
        const double *row = hz + (size_t)by * bw;
        int bx = bx0;
        for (; bx + 1 <= bx1; bx += 2) {
            __m128d v = _mm_loadu_pd(row + bx);
            if (_mm_movemask_pd(_mm_cmplt_pd(vbest, v)) != 3) return 0;
            vlow = _mm_min_pd(vlow, v);
        }
        if (bx <= bx1) {
            __m128d v = _mm_load_sd(row + bx);
            if (!(_mm_movemask_pd(_mm_cmplt_sd(vbest, v)) & 1)) return 0;
            vlow = _mm_min_sd(vlow, v);
        }
    }
    vlow = _mm_min_sd(vlow, _mm_unpackhi_pd(vlow, vlow));
    low = _mm_cvtsd_f64(vlow);
#else
    for (int by = by0; by <= by1; by++) {
        const double *row = hz + (size_t)by * bw;
        for (int bx = bx0; bx <= bx1; bx++) {
            if (!(best < row[bx])) return 0;
            low = row[bx] < low ? row[bx] : low;
        }
    }
#endif
    if (least) *least = low;
    return 1;
}

/* The pixels box[0] .. box[2] (x), box[1] .. box[3] (y) (whole-image pixels, clamped to the
 * target) whose samples the triangle with fixed-point vertices a, b, d can cover: samples sit at
 * i + offset with offset in [0, 1), so pixels floor(min) - 1 .. floor(max) (floor of a
 * fixed-point value: an arithmetic shift). 0 when none lies in the target. setup_one, tri_dropped
 * and tri_boxes take the same box. */
static inline int tri_pixel_box(const crisp_raster_target *t, const pvert *a, const pvert *b,
                                const pvert *d, int box[4])
{
    int64_t minx = a->fx < b->fx ? a->fx : b->fx, maxx = a->fx > b->fx ? a->fx : b->fx;
    int64_t miny = a->fy < b->fy ? a->fy : b->fy, maxy = a->fy > b->fy ? a->fy : b->fy;
    minx = d->fx < minx ? d->fx : minx, maxx = d->fx > maxx ? d->fx : maxx;
    miny = d->fy < miny ? d->fy : miny, maxy = d->fy > maxy ? d->fy : maxy;
    int64_t x0 = (minx >> CRISP_RASTER_SUBPIXEL_BITS) - 1,
            y0 = (miny >> CRISP_RASTER_SUBPIXEL_BITS) - 1;
    int64_t x1 = maxx >> CRISP_RASTER_SUBPIXEL_BITS, y1 = maxy >> CRISP_RASTER_SUBPIXEL_BITS;
    int64_t ex = t->x0 + t->width - 1, ey = t->y0 + t->height - 1;
    box[0] = (int)(x0 > t->x0 ? x0 : t->x0), box[1] = (int)(y0 > t->y0 ? y0 : t->y0);
    box[2] = (int)(x1 < ex ? x1 : ex), box[3] = (int)(y1 < ey ? y1 : ey);
    return box[0] <= box[2] && box[1] <= box[3];
}

/* 1 when triangle a, b, d (projected, every vertex inside the clip planes) writes no sample in a
 * draw with the block depth set: setup_one would drop it (no sample area, or tri_hidden on its
 * pixel box, the same expressions). *least: the least block value of that box when hidden there
 * (INFINITY when it covers no sample area), box[4]: the box. */
static int tri_dropped(const crisp_raster *r, const crisp_raster_target *t, const pvert *a,
                       const pvert *b, const pvert *d, double *least, int box[4])
{
    *least = INFINITY;
    int64_t area = (b->fx - a->fx) * (d->fy - a->fy) - (b->fy - a->fy) * (d->fx - a->fx);
    if (area == 0) return 1;
    if (!tri_pixel_box(t, a, b, d, box)) return 1;
    return tri_hidden_least(r, t, a, b, d, NULL, box[0], box[1], box[2], box[3], least);
}

int crisp__raster_quad_hidden(const crisp_raster *r, const crisp_raster_target *t,
                              const double *const clip[4],
                              void (*core_fn)(const void *ctx, crisp_raster_core *core),
                              const void *core_ctx)
{
    if (!r->occl_hiz) return 0;
    double gx = GUARD_PX / image_w(t), gy = GUARD_PX / image_h(t);
    pvert v[4];                   /* only positions and 1/W are read (tri_dropped, core_bound) */
    for (int k = 0; k < 4; k++) { /* as project_vertices: only corners needing no clipping */
        double d[6];
        plane_dists(clip[k], gx, gy, d);
        for (int q = 0; q < 6; q++)
            if (!(d[q] >= 0 && isfinite(d[q]))) return 0;
        if (!project_depth(clip[k], t, &v[k])) return 0;
    }
    /* Without the core first: a quad that is not hidden stops here, before its core is worked
     * out; a hidden one is with the core when the core's bound (tri_hidden's, on the same
     * triangle and box) is also below the least block value of the box. */
    double least[2];
    int box[2][4] = {{0}};
    if (!tri_dropped(r, t, &v[0], &v[1], &v[2], &least[0], box[0]) ||
        !tri_dropped(r, t, &v[0], &v[2], &v[3], &least[1], box[1]))
        return 0;
    if (!core_fn) return 1;
    crisp_raster_core core;
    core_fn(core_ctx, &core);
    const pvert *t0[3] = {&v[0], &v[1], &v[2]}, *t1[3] = {&v[0], &v[2], &v[3]};
    for (int k = 0; k < 2; k++) {
        if (least[k] == INFINITY) continue; /* no sample area: nothing drawn with any core */
        const int *b = box[k];
        if (!(core_bound(&core, k ? t1 : t0, b[0], b[1], b[2], b[3]) < least[k])) return 0;
    }
    return 1;
}

static int uv_hull_box(const setup_tri *st, const double *hx, const double *hy, int n,
                       double box[4]);

/* The box test's answer for all of triangle st's fragments (its covered samples lie in its snapped
 * triangle): the box goes to tbox (valid when the answer is not -2), -2 when there is none. */
static int tri_decision(const crisp_raster *r, void *test_ctx, const setup_tri *st, double tbox[4])
{
    double hx[3], hy[3];
    for (int k = 0; k < 3; k++)
        hx[k] = (double)st->x[k] / SUB, hy[k] = (double)st->y[k] / SUB;
    if (!uv_hull_box(st, hx, hy, 3, tbox)) return -2;
    double lo[2] = {tbox[0], tbox[2]}, hi[2] = {tbox[1], tbox[3]};
    return r->box_test(test_ctx, st->face, lo, hi);
}

/* Sets up one triangle into *out; returns 0 when it covers no sample area (degenerate or off
 * the image), when the block depth hides it (tri_hidden) or when the box test discards every
 * fragment of it (issue 12: a close-up's nearest leaves are mostly trimmed away; their triangles
 * were binned and walked up to their first fragment, in every tile they reach, before the same
 * decision dropped them). */
static int setup_one(const setup_ctx *c, const pvert *a, const pvert *b, const pvert *d,
                     uint32_t face, const crisp_raster_core *core, setup_tri *out)
{
    const pvert *v[3] = {a, b, d};
    const crisp_raster_target *t = c->t;
    int64_t area = (b->fx - a->fx) * (d->fy - a->fy) - (b->fy - a->fy) * (d->fx - a->fx);
    if (area == 0) return 0;
    int order[3] = {0, 1, 2};
    if (area < 0) {
        order[1] = 2;
        order[2] = 1;
    }
    for (int k = 0; k < 3; k++) {
        out->x[k] = v[order[k]]->fx;
        out->y[k] = v[order[k]]->fy;
    }
    int box[4];
    if (!tri_pixel_box(t, a, b, d, box)) return 0;
    out->x0 = box[0], out->y0 = box[1], out->x1 = box[2], out->y1 = box[3];
    if (tri_hidden(c->r, t, a, b, d, core, out->x0, out->y0, out->x1, out->y1)) return 0;
    double sx[3] = {a->sx, b->sx, d->sx}, sy[3] = {a->sy, b->sy, d->sy};
    double det = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sy[1] - sy[0]) * (sx[2] - sx[0]);
    if (!(fabs(det) > 0)) return 0;
    out->ox = sx[0];
    out->oy = sy[0];
    for (int q = 0; q <= CRISP_RASTER_ATTRS; q++) {
        double d1 = b->val[q] - a->val[q], d2 = d->val[q] - a->val[q];
        out->q0[q] = a->val[q];
        out->qx[q] = (d1 * (sy[2] - sy[0]) - d2 * (sy[1] - sy[0])) / det;
        out->qy[q] = (d2 * (sx[1] - sx[0]) - d1 * (sx[2] - sx[0])) / det;
    }
    /* Edge k runs from vertex k+1 to vertex k+2 (the one opposite vertex k). With area > 0 in
     * this frame the inside is E >= 0. A sample exactly on an edge belongs to it when the edge's
     * direction lies in a half-open half-circle; the opposite edge of a neighbour then does not
     * own it, so shared edges are covered once. */
    UNROLL(3)
    for (int k = 0; k < 3; k++) {
        int a0 = (k + 1) % 3, a1 = (k + 2) % 3;
        int64_t dx = out->x[a1] - out->x[a0], dy = out->y[a1] - out->y[a0];
        out->bias[k] = (dy < 0 || (dy == 0 && dx > 0)) ? 0 : -1;
        out->ea[k] = -dy;
        out->eb[k] = dx;
        out->ec[k] = -(out->ea[k] * out->x[a0] + out->eb[k] * out->y[a0]) + out->bias[k];
    }
    out->face = face;
    out->core = core;
    /* With a box test, the tiles decide the test for boxes of (u, v) (raster_tile_s). */
    const crisp_raster *r = c->r;
    uint32_t fid = face & ~(CRISP_RASTER_FACE_FLAG | CRISP_RASTER_FACE_NO_TEST);
    out->boxed = -2, out->tbox_ok = 0;
    if (r->box_test && c->test && !(face & CRISP_RASTER_FACE_NO_TEST) &&
        !(fid < r->untested_count && r->untested[fid])) {
        int dec = tri_decision(r, c->test_ctx, out, out->tbox);
        if (dec == 0) return 0; /* it writes no sample */
        out->tbox_ok = dec != -2;
        out->boxed = dec == 1 ? 1 : -1;
    }
    return 1;
}

static void project_vertices(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    setup_ctx *c = vctx;
    pvert *cache = c->r->vcache;
    for (size_t ch = begin; ch < end; ch++) {
        size_t lo = c->vert_count * ch / CHUNKS, hi = c->vert_count * (ch + 1) / CHUNKS;
        for (size_t i = lo; i < hi; i++) {
            const double *p = c->verts[i].clip;
            double d[6];
            plane_dists(p, c->gx, c->gy, d);
            int inside = 1;
            for (int q = 0; q < 6; q++)
                inside &= d[q] >= 0 && isfinite(d[q]);
            cache[i].ok = inside && project2(p, c->verts[i].attr, c->t, &cache[i]);
        }
    }
}

/* One pass per chunk of the batch: set up into the chunk's own array (grown as needed). */
static void setup_chunk(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    setup_ctx *c = vctx;
    crisp_raster *r = c->r;
    const pvert *cache = r->vcache;
    for (size_t ch = begin; ch < end; ch++) {
        size_t lo = c->first + c->count * ch / CHUNKS, hi = c->first + c->count * (ch + 1) / CHUNKS;
        size_t n = 0;
        c->status[ch] = CRISP_OK;
        for (size_t i = lo; i < hi; i++) {
            const crisp_raster_tri *tri = &c->tris[i];
            /* Room for the most triangles one input can clip into. */
            if (n + MAX_POLY > r->chunk_cap[ch] &&
                (c->status[ch] = crisp_grow((void **)&r->chunk_tris[ch], &r->chunk_cap[ch],
                                            n + MAX_POLY, sizeof(setup_tri))))
                break;
            setup_tri *out = r->chunk_tris[ch];
            const pvert *a = &cache[tri->v[0]], *b = &cache[tri->v[1]], *d = &cache[tri->v[2]];
            const crisp_raster_core *core = c->cores ? &c->cores[i] : NULL;
            if (a->ok && b->ok && d->ok) {
                n += (size_t)setup_one(c, a, b, d, tri->face, core, &out[n]);
                continue;
            }
            cvert poly[MAX_POLY];
            for (int k = 0; k < 3; k++) {
                const crisp_raster_vertex *sv = &c->verts[tri->v[k]];
                memcpy(poly[k].p, sv->clip, 4 * sizeof(double));
                memcpy(poly[k].p + 4, sv->attr, CRISP_RASTER_ATTRS * sizeof(double));
            }
            int m = clip_polygon(poly, 3, c->gx, c->gy);
            pvert pv[MAX_POLY];
            int ok[MAX_POLY];
            for (int k = 0; k < m; k++)
                ok[k] = project(poly[k].p, c->t, &pv[k]);
            for (int k = 1; k + 1 < m; k++)
                if (ok[0] && ok[k] && ok[k + 1])
                    n += (size_t)setup_one(c, &pv[0], &pv[k], &pv[k + 1], tri->face, core, &out[n]);
        }
        c->counts[ch] = n;
    }
}

/* ---- rasterisation -----------------------------------------------------------------------------
 * Per triangle and tile, the tile is walked in BLOCK x BLOCK pixel blocks. A block whose samples
 * are all covered by nearer surfaces than the triangle's nearest point over the block is skipped
 * whole (hierarchical depth: per block a lower bound of the stored 1/W, recomputed from the
 * samples after a block's worth of writes). Inside a block, each row and sample tests the exact
 * integer edge functions of its (at most 8) pixels and computes their 1/W in branch-free loops the
 * compiler vectorises (coverage is bit for bit that of the per-pixel test: watertight as before);
 * only the fragments nearer than what is stored interpolate attributes and run the fragment test.
 */

#define BLOCK 8
#define BLOCKS (TILE / BLOCK)
#define HIZ_MIN_PX 16 /* a triangle covering fewer pixels of a block does not consult its bound */

typedef struct {
    crisp_raster *r;
    crisp_raster_target *t;
    int tiles_x;
    crisp_raster_test_fn test;
    void *test_ctx;
    int64_t off_fx[16], off_fy[16];
    int64_t off_fmin[2], off_fmax[2]; /* least and greatest of off_fx (0) and off_fy (1) */
    double off_x[16], off_y[16];
    double off_xmin, off_xmax, off_ymin, off_ymax; /* least and greatest of off_x, off_y */
    const float *slack;  /* fill mode (crisp__raster_draw_fill) when not NULL */
    const float *slack2; /* the cores' slack (crisp__raster_draw_fill2) */
    int hiz;             /* hierarchical depth rejection on */
    int vectors;         /* the vector path (crisp__raster_set_vectors) */
    /* Per tile: its clear_depth still pending (NULL: none); a tile does it first when it draws
     * something, or whatever it draws when not defer (crisp__raster_set_defer_clear). */
    uint8_t *pending;
    int defer;
    int avx; /* one-sample tiles through raster_tile1_avx (1), _avx2 (2) or _avx512 (3) */
    atomic_size_t tested, discarded, untested, blocks_skipped, boxed;
    crisp_raster_share share; /* the tiles, one home range per worker (raster_tiles) */
    /* The live block depth at size live_size (crisp__raster_set_live_depth): a tile that the draw
     * does not clear and whose blocks it holds (live_tile) starts its 8x8 block bounds from it
     * (exact) instead of a pass over a block's samples at its first triangle. NULL: none. */
    const double *live;
    int live_size;
} raster_ctx;

/* Least 1/W over the block's samples (0 when one is empty). */
static double block_min(const crisp_raster_target *t, const double *inv_w, int bx0, int by0,
                        int bx1, int by1)
{
    int S = t->samples;
    double m = INFINITY;
    size_t n = (size_t)(bx1 - bx0 + 1) * S;
#if defined(__SSE2__)
    /* Two lanes at a time (a bound: the order of the comparisons does not matter, and stored
     * values are never NaN). */
    __m128d m2 = _mm_set1_pd(INFINITY);
#endif
    for (int j = by0; j <= by1; j++) {
        const double *row = inv_w + ((size_t)(j - t->y0) * t->width + (bx0 - t->x0)) * S;
        size_t k = 0;
#if defined(__SSE2__)
        for (; k + 2 <= n; k += 2)
            m2 = _mm_min_pd(_mm_loadu_pd(row + k), m2);
#endif
        for (; k < n; k++)
            m = row[k] < m ? row[k] : m;
    }
#if defined(__SSE2__)
    double l[2];
    _mm_storeu_pd(l, m2);
    m = l[0] < m ? l[0] : m;
    m = l[1] < m ? l[1] : m;
#endif
    return m;
}

/* A box of (u, v) holding what the per-fragment path computes (attributes 0 and 1 of attrs_*,
 * rounding and all) at every sample whose position lies in the convex hull of the n points
 * (hx[i], hy[i]) (pixels of the whole image, exact doubles); 0 when no bound is found (1/W not
 * safely positive there, or values not finite).
 *
 * Why it holds. A fragment at dx, dy from (ox, oy) computes D = (q0 + qx dx) + qy dy (1/W; the
 * same three terms in another order), N = (p0 + px dx) + py dy, w = 1 / D and a = N * w, each
 * rounded; dx and dy are themselves rounded differences within a few pixels of the hull's, so
 * |dx| < mx and |dy| < my with 16 px to spare. With u = 2^-53, |computed - exact| <= 8 u (|q0| +
 * |qx| mx + |qy| my) =: E for N and D alike (the position's rounding included, generously). The
 * exact N / D of an affine pair is monotone along lines where D > 0, so over the hull it lies
 * between its values at the hull's points; those are computed here with the same rounding, and
 * |N / D| <= B there. Then every computed N' / D' is within (E_N + B E_D) / (D_min - E_D) of the
 * exact ratio at its point, and w, a add two roundings (2 u B): the corner values' and the
 * fragments' errors together are below W = 4 (E_N + B E_D) / (min D' - 2 E_D) + 8 u B (twice
 * what the sum needs). The result: [least corner value - W, greatest + W]. */
static int uv_hull_box(const setup_tri *st, const double *hx, const double *hy, int n,
                       double box[4])
{
    const double u = 0x1p-53;
    double dx[4], dy[4], mx = 0, my = 0;
    for (int i = 0; i < n; i++) {
        dx[i] = hx[i] - st->ox, dy[i] = hy[i] - st->oy;
        mx = fabs(dx[i]) > mx ? fabs(dx[i]) : mx;
        my = fabs(dy[i]) > my ? fabs(dy[i]) : my;
    }
    mx += 16, my += 16;
    double e[3];
    for (int k = 0; k < 3; k++)
        e[k] = 8 * u * (fabs(st->q0[k]) + fabs(st->qx[k]) * mx + fabs(st->qy[k]) * my);
    double dmin = INFINITY, lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    double nmax[2] = {0, 0};
    for (int i = 0; i < n; i++) {
        double d = st->q0[0] + st->qx[0] * dx[i] + st->qy[0] * dy[i];
        dmin = d < dmin ? d : dmin;
        for (int q = 0; q < 2; q++) {
            double a = st->q0[q + 1] + st->qx[q + 1] * dx[i] + st->qy[q + 1] * dy[i];
            double r = a / d;
            lo[q] = r < lo[q] ? r : lo[q];
            hi[q] = r > hi[q] ? r : hi[q];
            /* |N / D| at this point, from above: (|N'| + E_N) / (D' - E_D). */
            double b = (fabs(a) + e[q + 1]) / (d - e[0]);
            nmax[q] = b > nmax[q] ? b : nmax[q];
        }
    }
    double dlow = dmin - 2 * e[0];
    if (!(dlow > 0)) return 0; /* also NaN */
    for (int q = 0; q < 2; q++) {
        double B = nmax[q] * (1 + 16 * u);
        double W = 4 * (e[q + 1] + B * e[0]) / dlow + 8 * u * B + 0x1p-1000;
        box[2 * q] = lo[q] - W;
        box[2 * q + 1] = hi[q] + W;
        if (!(isfinite(box[2 * q]) && isfinite(box[2 * q + 1]) && isfinite(W))) return 0;
    }
    return 1;
}

/* The box test's answer for the fragments of triangle st whose samples lie in pixels
 * [x0, x1] x [y0, y1] (sample offsets c->off_*): from uv_hull_box on the rectangle of their
 * sample positions, intersected with tbox (NULL: none; a box from the triangle itself). 1:
 * every such fragment keeps, 0: every one is discarded, -1: not decided. */
static int rect_decision(const raster_ctx *c, const setup_tri *st, int x0, int y0, int x1, int y1,
                         const double *tbox)
{
    double ax = x0 + c->off_xmin, bx = x1 + c->off_xmax, ay = y0 + c->off_ymin,
           by = y1 + c->off_ymax;
    double hx[4] = {ax, bx, ax, bx}, hy[4] = {ay, ay, by, by}, box[4];
    if (!uv_hull_box(st, hx, hy, 4, box)) return -1;
    if (tbox)
        for (int q = 0; q < 2; q++) {
            box[2 * q] = tbox[2 * q] > box[2 * q] ? tbox[2 * q] : box[2 * q];
            box[2 * q + 1] = tbox[2 * q + 1] < box[2 * q + 1] ? tbox[2 * q + 1] : box[2 * q + 1];
        }
    double lo[2] = {box[0], box[2]}, hi[2] = {box[1], box[3]};
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1])) return -1;
    int res = c->r->box_test(c->test_ctx, st->face, lo, hi);
    return res;
}

#if defined(__SSE2__)
/* The edge half of row_mask and row_mask_avx: bit q set where lane q is outside an edge (the
 * exact edge values e at lane 0 plus lane_step, the sign bits of their OR), two lanes at a time. */
static inline unsigned edge_neg_sse2(const int64_t e[3], __m128i lane_step[3][BLOCK / 2])
{
    unsigned neg = 0;
    const __m128i e0 = _mm_set1_epi64x(e[0]), e1 = _mm_set1_epi64x(e[1]),
                  e2 = _mm_set1_epi64x(e[2]);
    UNROLL(4)
    for (int h = 0; h < BLOCK / 2; h++) {
        __m128i o = _mm_or_si128(
            _mm_or_si128(_mm_add_epi64(e0, lane_step[0][h]), _mm_add_epi64(e1, lane_step[1][h])),
            _mm_add_epi64(e2, lane_step[2][h]));
        neg |= (unsigned)_mm_movemask_pd(_mm_castsi128_pd(o)) << (2 * h);
    }
    return neg;
}

/* A block row of a one-sample target, BLOCK lanes from its first pixel, two at a time: bit q
 * set where lane q is covered (full: every lane; else the exact edge values e at lane 0 plus
 * lane_step, sign bits of their OR) and its 1/W, base + gx (dx0 + q) (stored in iwv), is above
 * the stored one. The scalar loops' tests, operation for operation, on each lane. */
static inline unsigned row_mask(const int64_t e[3], __m128i lane_step[3][BLOCK / 2], int full,
                                double base, double gx, double dx0, const double *stored,
                                double *iwv)
{
    static const double lane[BLOCK] = {0, 1, 2, 3, 4, 5, 6, 7};
    unsigned m = 0;
    const __m128d vb = _mm_set1_pd(base), vg = _mm_set1_pd(gx), vd = _mm_set1_pd(dx0);
    UNROLL(4)
    for (int h = 0; h < BLOCK / 2; h++) {
        __m128d q = _mm_loadu_pd(lane + 2 * h);
        __m128d iw = _mm_add_pd(vb, _mm_mul_pd(vg, _mm_add_pd(vd, q)));
        _mm_storeu_pd(iwv + 2 * h, iw);
        m |= (unsigned)_mm_movemask_pd(_mm_cmpgt_pd(iw, _mm_loadu_pd(stored + 2 * h))) << (2 * h);
    }
    return full ? m : m & ~edge_neg_sse2(e, lane_step);
}
#endif

#if defined(__SSE2__)
/* The fragments of lanes m of a block row of a one-sample target whose trim decision is "keep"
 * (or that have no test): attributes and stores, two lanes at a time where both are in m. The
 * per-fragment path's values bit for bit: w = 1 / iw and ((p0 + px dx) + py dy) * w on each lane,
 * with dx = dx0 + lane and py dy the same product as there (computed once per row); the
 * conversions to float are correctly rounded either way. idx0: the row's first sample. */
typedef struct pair_planes {
    __m128d q0[CRISP_RASTER_ATTRS], qx[CRISP_RASTER_ATTRS]; /* attribute k's, on both lanes */
} pair_planes;

static inline unsigned store_row1(const planes *pl, const pair_planes *pp, double dx0, double dy,
                                  const double *iwv, unsigned m, size_t idx0,
                                  double *restrict inv_w, int32_t *restrict fbuf,
                                  float *restrict abuf, int32_t face_id)
{
    const __m128d *q0 = pp->q0, *qx = pp->qx;
    __m128d qyd[CRISP_RASTER_ATTRS];
    for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
        qyd[k] = _mm_set1_pd(pl->qy[k + 1] * dy);
    const __m128d one = _mm_set1_pd(1.0), vd = _mm_set1_pd(dx0);
    unsigned stored = 0;
    for (int h = 0; h < BLOCK / 2; h++) {
        unsigned bits = (m >> (2 * h)) & 3u;
        if (!bits) continue;
        stored += 1 + (bits == 3u);
        if (bits != 3u) { /* one lane: the per-fragment arithmetic */
            int q = 2 * h + (bits == 2u);
            size_t idx = idx0 + (size_t)q;
            double iw = iwv[q], dx = dx0 + q, w = 1.0 / iw, a[CRISP_RASTER_ATTRS];
            attrs_vector(pl, dx, dy, w, a);
            inv_w[idx] = iw;
            fbuf[idx] = face_id;
            float *dst = abuf + idx * CRISP_RASTER_ATTRS;
            dst[0] = (float)a[0], dst[1] = (float)a[1], dst[2] = (float)a[2];
            dst[3] = (float)a[3], dst[4] = (float)a[4];
            continue;
        }
        size_t idx = idx0 + (size_t)(2 * h);
        __m128d iw = _mm_loadu_pd(iwv + 2 * h);
        __m128d w = _mm_div_pd(one, iw);
        __m128d dx = _mm_add_pd(vd, _mm_set_pd(2 * h + 1, 2 * h));
        __m128 f[CRISP_RASTER_ATTRS];
        for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
            f[k] = _mm_cvtpd_ps(
                _mm_mul_pd(_mm_add_pd(_mm_add_pd(q0[k], _mm_mul_pd(qx[k], dx)), qyd[k]), w));
        /* lane 0: a0 a1 a2 a3 | a4, lane 1: a0 a1 a2 a3 | a4, five floats per sample. */
        __m128 t01 = _mm_unpacklo_ps(f[0], f[1]); /* a0 a1 of lane 0, a0 a1 of lane 1 */
        __m128 t23 = _mm_unpacklo_ps(f[2], f[3]);
        float *dst = abuf + idx * CRISP_RASTER_ATTRS;
        _mm_storeu_ps(dst, _mm_movelh_ps(t01, t23));
        _mm_store_ss(dst + 4, f[4]);
        _mm_storeu_ps(dst + 5, _mm_movehl_ps(t23, t01));
        _mm_store_ss(dst + 9, _mm_shuffle_ps(f[4], f[4], 1));
        _mm_storeu_pd(inv_w + idx, iw);
        fbuf[idx] = face_id, fbuf[idx + 1] = face_id;
    }
    return stored;
}
#endif

#if defined(__GNUC__) && defined(__x86_64__) && defined(__SSE2__)
#define HAVE_AVX_TILES 1
/* store_row1 four lanes at a time with AVX (raster_tile compiled for AVX, chosen at run time):
 * every quarter-row with a lane in m is computed on all four lanes and stored on those in m
 * (masked stores; the other lanes' values, whatever they are, are never written; their 1 / iw
 * may raise the divide-by-zero flag, which nothing reads, with floating-point traps off as
 * always). The same IEEE
 * operations per lane as store_row1 and the per-fragment path (dx = dx0 + lane, ((p0 + px dx) +
 * py dy) * w, w = 1 / iw; no fused multiply-add), so the same values bit for bit. */
typedef double v4d __attribute__((vector_size(32))); /* __m256d's type */
typedef struct quad_planes {
    v4d q0[CRISP_RASTER_ATTRS], qx[CRISP_RASTER_ATTRS], qy[CRISP_RASTER_ATTRS]; /* attribute k's */
    const planes *pl; /* the triangle's, broadcast into the above at its first store (ok) */
    int ok;
} quad_planes;

/* The terms of a block's rows that depend on the column only, each the same product or sum as
 * the row's own expression computed (so the rows' values are those bit for bit): the 1/W plane's
 * gx (dx0 + lane) for each quarter row (iwx; block_planes_avx), and attribute k's q0 + qx (dx0 +
 * lane) (ax) for the quarters whose bit is set in ax_ok, each worked out when a row first stores
 * in that quarter (store_row1_avx). */
typedef struct block_planes {
    v4d iwx[BLOCK / 4];
    v4d ax[BLOCK / 4][CRISP_RASTER_ATTRS];
    double dx0;
    unsigned ax_ok;
} block_planes;

static const double lane_x[BLOCK] = {0, 1, 2, 3, 4, 5, 6, 7};

__attribute__((target("avx"))) static inline void block_planes_avx(block_planes *bp, double gx,
                                                                   double dx0)
{
    const __m256d vg = _mm256_set1_pd(gx), vd = _mm256_set1_pd(dx0);
    UNROLL(2)
    for (int h = 0; h < BLOCK / 4; h++)
        bp->iwx[h] = _mm256_mul_pd(vg, _mm256_add_pd(vd, _mm256_loadu_pd(lane_x + 4 * h)));
    bp->dx0 = dx0;
    bp->ax_ok = 0;
}

/* The depth half of row_mask_avx and row_mask_avx2: 1/W of the row's eight lanes into iwv and
 * the lanes where it is above the stored 1/W (base + gx (dx0 + q), the column term from the
 * block's bp; the compare ordered and signalling, as _mm_cmpgt_pd). */
__attribute__((target("avx"))) static inline unsigned
depth_mask_avx(double base, const block_planes *bp, const double *stored, double *iwv)
{
    unsigned m = 0;
    const __m256d vb = _mm256_set1_pd(base);
    UNROLL(2)
    for (int h = 0; h < BLOCK / 4; h++) {
        __m256d iw = _mm256_add_pd(vb, bp->iwx[h]);
        _mm256_storeu_pd(iwv + 4 * h, iw);
        m |= (unsigned)_mm256_movemask_pd(
                 _mm256_cmp_pd(iw, _mm256_loadu_pd(stored + 4 * h), _CMP_GT_OS))
             << (4 * h);
    }
    return m;
}

/* row_mask with the 1/W and depth test four lanes at a time (depth_mask_avx: the same IEEE
 * operations per lane). */
__attribute__((target("avx"))) static inline unsigned
row_mask_avx(const int64_t e[3], __m128i lane_step[3][BLOCK / 2], int full, double base,
             const block_planes *bp, const double *stored, double *iwv)
{
    unsigned m = depth_mask_avx(base, bp, stored, iwv);
    return full ? m : m & ~edge_neg_sse2(e, lane_step);
}

/* row_mask_avx with the edge tests four lanes at a time too (AVX2's 64-bit integer lanes; the
 * same exact sums, their sign bits ORed). */
__attribute__((target("avx2"))) static inline unsigned
row_mask_avx2(const int64_t e[3], __m128i lane_step[3][BLOCK / 2], int full, double base,
              const block_planes *bp, const double *stored, double *iwv)
{
    unsigned m = depth_mask_avx(base, bp, stored, iwv), neg = 0;
    if (!full) {
        const __m256i e0 = _mm256_set1_epi64x(e[0]), e1 = _mm256_set1_epi64x(e[1]),
                      e2 = _mm256_set1_epi64x(e[2]);
        UNROLL(2)
        for (int h = 0; h < BLOCK / 4; h++) { /* lanes 4h .. 4h + 3: two lane_step pairs */
            __m256i l0 = _mm256_loadu_si256((const __m256i *)&lane_step[0][2 * h]),
                    l1 = _mm256_loadu_si256((const __m256i *)&lane_step[1][2 * h]),
                    l2 = _mm256_loadu_si256((const __m256i *)&lane_step[2][2 * h]);
            __m256i o =
                _mm256_or_si256(_mm256_or_si256(_mm256_add_epi64(e0, l0), _mm256_add_epi64(e1, l1)),
                                _mm256_add_epi64(e2, l2));
            neg |= (unsigned)_mm256_movemask_pd(_mm256_castsi256_pd(o)) << (4 * h);
        }
    }
    return m & ~neg;
}

/* Lane q of a quarter row is stored where bit q of its bits is set: all ones in its 32-bit
 * (sel32) and 64-bit (sel64) element (integer constants: no floating-point compare, whose
 * answer for the bits as doubles would depend on the denormals-are-zero mode). */
#define SEL_L(b, q) (((b) >> (q)&1) ? -1 : 0)
#define SEL_ROW(b)                                                                                 \
    {                                                                                              \
        SEL_L(b, 0), SEL_L(b, 1), SEL_L(b, 2), SEL_L(b, 3)                                         \
    }
#define SEL_ALL                                                                                    \
    {                                                                                              \
        SEL_ROW(0), SEL_ROW(1), SEL_ROW(2), SEL_ROW(3), SEL_ROW(4), SEL_ROW(5), SEL_ROW(6),        \
            SEL_ROW(7), SEL_ROW(8), SEL_ROW(9), SEL_ROW(10), SEL_ROW(11), SEL_ROW(12),             \
            SEL_ROW(13), SEL_ROW(14), SEL_ROW(15)                                                  \
    }
static const int32_t sel32[16][4] __attribute__((aligned(16))) = SEL_ALL;
static const int64_t sel64[16][4] __attribute__((aligned(32))) = SEL_ALL;
#undef SEL_ALL
#undef SEL_ROW
#undef SEL_L

/* Float q of v to dst (a float: memcpy keeps the types apart; one extract-and-store). */
__attribute__((target("avx"))) static inline void store_lane(float *dst, __m128 v, const int q)
{
    int bits;
    switch (q) {
    case 0:
        bits = _mm_extract_ps(v, 0);
        break;
    case 1:
        bits = _mm_extract_ps(v, 1);
        break;
    case 2:
        bits = _mm_extract_ps(v, 2);
        break;
    default:
        bits = _mm_extract_ps(v, 3);
        break;
    }
    memcpy(dst, &bits, sizeof bits);
}

__attribute__((target("avx"))) static unsigned
store_row1_avx(quad_planes *qp, block_planes *bp, double dy, const double *iwv, unsigned m,
               size_t idx0, double *restrict inv_w, int32_t *restrict fbuf, float *restrict abuf,
               int32_t face_id)
{
    if (!qp->ok) {
        UNROLL(5)
        for (int k = 0; k < CRISP_RASTER_ATTRS; k++) {
            qp->q0[k] = _mm256_set1_pd(qp->pl->q0[k + 1]);
            qp->qx[k] = _mm256_set1_pd(qp->pl->qx[k + 1]);
            qp->qy[k] = _mm256_set1_pd(qp->pl->qy[k + 1]);
        }
        qp->ok = 1;
    }
    const __m256d vdy = _mm256_set1_pd(dy);
    __m256d qyd[CRISP_RASTER_ATTRS];
    UNROLL(5)
    for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
        qyd[k] = _mm256_mul_pd(qp->qy[k], vdy);
    const __m256d one = _mm256_set1_pd(1.0);
    const __m128 face = _mm_castsi128_ps(_mm_set1_epi32(face_id));
    UNROLL(2)
    for (int h = 0; h < BLOCK / 4; h++) {
        unsigned bits = (m >> (4 * h)) & 15u;
        if (!bits) continue;
        if (!(bp->ax_ok >> h & 1u)) {
            const __m256d dx =
                _mm256_add_pd(_mm256_set1_pd(bp->dx0), _mm256_loadu_pd(lane_x + 4 * h));
            UNROLL(5)
            for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
                bp->ax[h][k] = _mm256_add_pd(qp->q0[k], _mm256_mul_pd(qp->qx[k], dx));
            bp->ax_ok |= 1u << h;
        }
        size_t idx = idx0 + (size_t)(4 * h);
        __m256d iw = _mm256_loadu_pd(iwv + 4 * h);
        __m256d w = _mm256_div_pd(one, iw);
        __m128 f[CRISP_RASTER_ATTRS];
        UNROLL(5)
        for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
            f[k] = _mm256_cvtpd_ps(_mm256_mul_pd(_mm256_add_pd(bp->ax[h][k], qyd[k]), w));
        _MM_TRANSPOSE4_PS(f[0], f[1], f[2], f[3]); /* f[q]: lane q's attributes 0..3 */
        float *dst = abuf + idx * CRISP_RASTER_ATTRS;
        if (bits == 15u) {
            _mm_storeu_ps(dst, f[0]);
            _mm_store_ss(dst + 4, f[4]);
            _mm_storeu_ps(dst + 5, f[1]);
            store_lane(dst + 9, f[4], 1);
            _mm_storeu_ps(dst + 10, f[2]);
            store_lane(dst + 14, f[4], 2);
            _mm_storeu_ps(dst + 15, f[3]);
            store_lane(dst + 19, f[4], 3);
            _mm256_storeu_pd(inv_w + idx, iw);
            _mm_storeu_ps((float *)(fbuf + idx), face);
            continue;
        }
        if (bits & 1u) _mm_storeu_ps(dst, f[0]), _mm_store_ss(dst + 4, f[4]);
        if (bits & 2u) _mm_storeu_ps(dst + 5, f[1]), store_lane(dst + 9, f[4], 1);
        if (bits & 4u) _mm_storeu_ps(dst + 10, f[2]), store_lane(dst + 14, f[4], 2);
        if (bits & 8u) _mm_storeu_ps(dst + 15, f[3]), store_lane(dst + 19, f[4], 3);
        _mm256_maskstore_pd(inv_w + idx, _mm256_load_si256((const __m256i *)sel64[bits]), iw);
        _mm_maskstore_ps((float *)(fbuf + idx), _mm_load_si128((const __m128i *)sel32[bits]), face);
    }
    return (unsigned)__builtin_popcount(m);
}

/* A block's rows on the one-sample AVX2 path when every fragment that passes the depth test is
 * kept (no clip plane, the triangle's fragment test decided "keep" for all of it): what
 * raster_tile_s's row loop does for such a block (the empty row skip, row_mask_avx2,
 * store_row1_avx), the same expressions in the same order, in a loop of its own with few live
 * values (the general loop kept the edge values and most of its state on the stack). The rows
 * that cover no sample are a run at each end of the block: for each edge a row's greatest value
 * over its first (e + rmax) changes by the same step from row to row, so the rows where it is
 * >= 0 are a prefix or a suffix of the block's rows, and the rows where all three are a run
 * (none, all, or between); the loop leaves the block at the run's end rather than testing the
 * rows after it. Returns the fragments stored. */
typedef struct block_rows {
    int64_t e[3];     /* edge values at the block's first pixel */
    int64_t bstep[3]; /* per row */
    int64_t rmax[3];  /* an edge's greatest value along a row over its first */
    int full, n;      /* every sample covered; lanes in a row */
    int j0, j1;       /* pixel rows (whole image) */
    double q0, qy, off_y, oy;
    size_t idx0, stride; /* the first row's first sample; samples a row */
} block_rows;

__attribute__((target("avx2"))) static inline unsigned
block_rows_avx2(const block_rows *b, __m128i lane_step[3][BLOCK / 2], quad_planes *qp,
                block_planes *bp, double *restrict inv_w, int32_t *restrict fbuf,
                float *restrict abuf, int32_t face_id)
{
    int64_t e0 = b->e[0], e1 = b->e[1], e2 = b->e[2];
    const int64_t s0 = b->bstep[0], s1 = b->bstep[1], s2 = b->bstep[2];
    const int64_t r0 = b->rmax[0], r1 = b->rmax[1], r2 = b->rmax[2];
    const int full = b->full;
    const unsigned lanes = (1u << b->n) - 1;
    unsigned wrote = 0;
    size_t idx0 = b->idx0;
    int j = b->j0;
    if (!full) /* the leading rows that cover no sample */
        for (; j <= b->j1; j++, idx0 += b->stride, e0 += s0, e1 += s1, e2 += s2)
            if (((e0 + r0) | (e1 + r1) | (e2 + r2)) >= 0) break;
    for (; j <= b->j1; j++, idx0 += b->stride, e0 += s0, e1 += s1, e2 += s2) {
        if (!full && ((e0 + r0) | (e1 + r1) | (e2 + r2)) < 0) break; /* the run's end */
        double dy = j + b->off_y - b->oy;
        double base = b->q0 + b->qy * dy;
        const int64_t e[3] = {e0, e1, e2};
        double iwv[BLOCK];
        unsigned m = row_mask_avx2(e, lane_step, full, base, bp, inv_w + idx0, iwv) & lanes;
        if (m) wrote += store_row1_avx(qp, bp, dy, iwv, m, idx0, inv_w, fbuf, abuf, face_id);
    }
    return wrote;
}

/* The AVX-512 block walk (processors with AVX-512 F, DQ, VL and BW and BMI2, chosen at run time
 * as cpu.c's resolve is): block_rows_avx2 with a block row's eight lanes as one vector: the
 * three edges' values of the row's lanes kept as 8 x 64-bit vectors stepped by rows (the same
 * exact sums as e + lane_step), their sign bits and the depth test as k-masks, 1/W and the five
 * attributes one vector each, and the stores masked by the lanes that pass (no per-lane
 * branches). The same IEEE operations per lane as block_rows_avx2 (1/W: base + gx (dx0 + lane);
 * attribute k: ((q0 + qx (dx0 + lane)) + qy dy) * (1 / iw), converted to float; no fused
 * multiply-add: the file is ISO C, compiled without contraction), so the same values bit for bit
 * (test_raster_fast runs every path against the scalar one). A 4 x 4 pixel square would also be
 * 16 lanes, but 1/W and the attributes are doubles (8 to a vector either way) and the target's
 * rows are contiguous: a block row is one load and one store per array. */
#define AVX512_TILES "avx2,bmi2,avx512f,avx512dq,avx512vl,avx512bw"
#define HAVE_AVX512_TILES 1

/* Where float i of a row's 40 (pixel i / 5's attribute i % 5) comes from: attributes 0..3 of
 * the eight pixels as two 16-float vectors a01 (0 and 1) and a23 (2 and 3), attribute 4 as a4.
 * perm_ab[v][l]: float 16 v + l's index in a01 : a23 (32 floats; attribute 4's lanes 0, replaced
 * after), perm_c[v][l]: its pixel in a4. */
#define P5(i) ((i) % 5 == 4 || (i) >= 40 ? 0 : ((i) % 5) / 2 * 16 + ((i) % 5) % 2 * 8 + (i) / 5)
#define P5ROW(v)                                                                                   \
    {                                                                                              \
        P5(16 * (v) + 0), P5(16 * (v) + 1), P5(16 * (v) + 2), P5(16 * (v) + 3), P5(16 * (v) + 4),  \
            P5(16 * (v) + 5), P5(16 * (v) + 6), P5(16 * (v) + 7), P5(16 * (v) + 8),                \
            P5(16 * (v) + 9), P5(16 * (v) + 10), P5(16 * (v) + 11), P5(16 * (v) + 12),             \
            P5(16 * (v) + 13), P5(16 * (v) + 14), P5(16 * (v) + 15)                                \
    }
static const int32_t perm_ab[3][16] __attribute__((aligned(64))) = {P5ROW(0), P5ROW(1), P5ROW(2)};
#undef P5
#undef P5ROW
#define C5(i) ((i) / 5 < 8 ? (i) / 5 : 0)
#define C5ROW(v)                                                                                   \
    {                                                                                              \
        C5(16 * (v) + 0), C5(16 * (v) + 1), C5(16 * (v) + 2), C5(16 * (v) + 3), C5(16 * (v) + 4),  \
            C5(16 * (v) + 5), C5(16 * (v) + 6), C5(16 * (v) + 7), C5(16 * (v) + 8),                \
            C5(16 * (v) + 9), C5(16 * (v) + 10), C5(16 * (v) + 11), C5(16 * (v) + 12),             \
            C5(16 * (v) + 13), C5(16 * (v) + 14), C5(16 * (v) + 15)                                \
    }
static const int32_t perm_c[3][16] __attribute__((aligned(64))) = {C5ROW(0), C5ROW(1), C5ROW(2)};
#undef C5
#undef C5ROW
/* Floats 16 v + l with l % 5 == 4 (attribute 4), per vector v: 0x8421 shifted by v's phase. */
#define A4_LANES(v) ((__mmask16)((0x4210842108421ull << 4 >> (16 * (v))) & 0xffffu))

/* The lanes m of a block row stored: 1/W iw, the face, and attribute k's ((ax[k] + qy dy) * w
 * with w = 1 / iw (ax[k] = q0 + qx (dx0 + lane), the column's part), the 40 floats interleaved by
 * permutes and stored masked, or plainly when all eight lanes are stored. */
__attribute__((target(AVX512_TILES))) static inline void
store_row8_avx512(const __m512d ax[CRISP_RASTER_ATTRS], const planes *pl, double dy, __m512d iw,
                  __mmask8 m, size_t idx0, double *restrict inv_w, int32_t *restrict fbuf,
                  float *restrict abuf, int32_t face_id)
{
    const __m512d vdy = _mm512_set1_pd(dy);
    const __m512d w = _mm512_div_pd(_mm512_set1_pd(1.0), iw);
    __m256 f[CRISP_RASTER_ATTRS];
    UNROLL(5)
    for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
        f[k] = _mm512_cvtpd_ps(_mm512_mul_pd(
            _mm512_add_pd(ax[k], _mm512_mul_pd(_mm512_set1_pd(pl->qy[k + 1]), vdy)), w));
    const __m512 a01 = _mm512_insertf32x8(_mm512_castps256_ps512(f[0]), f[1], 1),
                 a23 = _mm512_insertf32x8(_mm512_castps256_ps512(f[2]), f[3], 1),
                 a4 = _mm512_castps256_ps512(f[4]);
    /* Pixel q's five floats stored where bit q of m is set (bits 5 q .. 5 q + 4). */
    const uint64_t fm = _pdep_u64(m, 0x0842108421ull) * 0x1fu;
    float *dst = abuf + idx0 * CRISP_RASTER_ATTRS;
    if (m == 0xff) { /* plain stores: masked ones took 1-1.5% more of impeller close's frame CPU */
        UNROLL(3)
        for (int v = 0; v < 3; v++) {
            __m512 o = _mm512_permutex2var_ps(a01, _mm512_load_si512(perm_ab[v]), a23);
            o = _mm512_mask_permutexvar_ps(o, A4_LANES(v), _mm512_load_si512(perm_c[v]), a4);
            if (v < 2)
                _mm512_storeu_ps(dst + 16 * v, o);
            else
                _mm256_storeu_ps(dst + 32, _mm512_castps512_ps256(o));
        }
        _mm512_storeu_pd(inv_w + idx0, iw);
        _mm256_storeu_si256((__m256i *)(fbuf + idx0), _mm256_set1_epi32(face_id));
        return;
    }
    UNROLL(3)
    for (int v = 0; v < 3; v++) {
        __m512 o = _mm512_permutex2var_ps(a01, _mm512_load_si512(perm_ab[v]), a23);
        o = _mm512_mask_permutexvar_ps(o, A4_LANES(v), _mm512_load_si512(perm_c[v]), a4);
        _mm512_mask_storeu_ps(dst + 16 * v, (__mmask16)(fm >> (16 * v)), o);
    }
    _mm512_mask_storeu_pd(inv_w + idx0, m, iw);
    _mm256_mask_storeu_epi32(fbuf + idx0, m, _mm256_set1_epi32(face_id));
}

/* The column parts of a block's attributes: q0 + qx dx for each attribute (dx = dx0 + lane). */
__attribute__((target(AVX512_TILES))) static inline void
block_ax_avx512(const planes *pl, __m512d dx, __m512d ax[CRISP_RASTER_ATTRS])
{
    UNROLL(5)
    for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
        ax[k] = _mm512_add_pd(_mm512_set1_pd(pl->q0[k + 1]),
                              _mm512_mul_pd(_mm512_set1_pd(pl->qx[k + 1]), dx));
}

__attribute__((target(AVX512_TILES))) static inline unsigned
block_rows_avx512(const block_rows *b, __m128i lane_step[3][BLOCK / 2], const planes *pl,
                  double *restrict inv_w, int32_t *restrict fbuf, float *restrict abuf,
                  int32_t face_id, double gx, double dx0)
{
    int64_t e0 = b->e[0], e1 = b->e[1], e2 = b->e[2];
    const int64_t s0 = b->bstep[0], s1 = b->bstep[1], s2 = b->bstep[2];
    const int64_t r0 = b->rmax[0], r1 = b->rmax[1], r2 = b->rmax[2];
    const int full = b->full;
    const __mmask8 lanes = (__mmask8)((1u << b->n) - 1);
    unsigned wrote = 0;
    size_t idx0 = b->idx0;
    int j = b->j0;
    if (!full) /* the leading rows that cover no sample */
        for (; j <= b->j1; j++, idx0 += b->stride, e0 += s0, e1 += s1, e2 += s2)
            if (((e0 + r0) | (e1 + r1) | (e2 + r2)) >= 0) break;
    /* The lanes' edge values (e + lane_step: lane q's q steps as a sum of steps, exact) */
    __m512i v0 = _mm512_add_epi64(_mm512_set1_epi64(e0), _mm512_loadu_si512(lane_step[0])),
            v1 = _mm512_add_epi64(_mm512_set1_epi64(e1), _mm512_loadu_si512(lane_step[1])),
            v2 = _mm512_add_epi64(_mm512_set1_epi64(e2), _mm512_loadu_si512(lane_step[2]));
    const __m512i vs0 = _mm512_set1_epi64(s0), vs1 = _mm512_set1_epi64(s1),
                  vs2 = _mm512_set1_epi64(s2);
    const __m512d dx = _mm512_add_pd(_mm512_set1_pd(dx0), _mm512_loadu_pd(lane_x));
    const __m512d iwx = _mm512_mul_pd(_mm512_set1_pd(gx), dx);
    __m512d ax[CRISP_RASTER_ATTRS]; /* at the block's first store */
    int ax_ok = 0;
    for (; j <= b->j1; j++, idx0 += b->stride, e0 += s0, e1 += s1, e2 += s2,
                       v0 = _mm512_add_epi64(v0, vs0), v1 = _mm512_add_epi64(v1, vs1),
                       v2 = _mm512_add_epi64(v2, vs2)) {
        if (!full && ((e0 + r0) | (e1 + r1) | (e2 + r2)) < 0) break; /* the run's end */
        double dy = j + b->off_y - b->oy;
        double base = b->q0 + b->qy * dy;
        __m512d iw = _mm512_add_pd(_mm512_set1_pd(base), iwx);
        __mmask8 m = _mm512_mask_cmp_pd_mask(lanes, iw, _mm512_loadu_pd(inv_w + idx0), _CMP_GT_OS);
        if (!full) /* lanes outside an edge: the sign bit of the OR of the three values */
            m &= (__mmask8)~_mm512_movepi64_mask(_mm512_ternarylogic_epi64(v0, v1, v2, 0xfe));
        if (!m) continue;
        if (!ax_ok) block_ax_avx512(pl, dx, ax), ax_ok = 1;
        store_row8_avx512(ax, pl, dy, iw, m, idx0, inv_w, fbuf, abuf, face_id);
        wrote += (unsigned)__builtin_popcount(m);
    }
    return wrote;
}

/* row_mask_avx2 with a block row's eight lanes as one vector (raster_tile_s's general rows on
 * the AVX-512 tiles): 1/W base + bp's column term into iwv, the lanes above the stored 1/W and,
 * unless full, inside the three edges. */
__attribute__((target(AVX512_TILES))) static inline unsigned
row_mask_avx512(const int64_t e[3], __m128i lane_step[3][BLOCK / 2], int full, double base,
                const block_planes *bp, const double *stored, double *iwv)
{
    __m512d iw = _mm512_add_pd(_mm512_set1_pd(base), _mm512_loadu_pd((const double *)bp->iwx));
    _mm512_storeu_pd(iwv, iw);
    __mmask8 m = _mm512_cmp_pd_mask(iw, _mm512_loadu_pd(stored), _CMP_GT_OS);
    if (!full) {
        __m512i o = _mm512_ternarylogic_epi64(
            _mm512_add_epi64(_mm512_set1_epi64(e[0]), _mm512_loadu_si512(lane_step[0])),
            _mm512_add_epi64(_mm512_set1_epi64(e[1]), _mm512_loadu_si512(lane_step[1])),
            _mm512_add_epi64(_mm512_set1_epi64(e[2]), _mm512_loadu_si512(lane_step[2])), 0xfe);
        m &= (__mmask8)~_mm512_movepi64_mask(o);
    }
    return m;
}

/* store_row1_avx on the AVX-512 tiles: the row's lanes m (1/W in iwv) stored at once. */
__attribute__((target(AVX512_TILES))) static inline unsigned
store_row1_avx512(const planes *pl, const block_planes *bp, double dy, const double *iwv,
                  unsigned m, size_t idx0, double *restrict inv_w, int32_t *restrict fbuf,
                  float *restrict abuf, int32_t face_id)
{
    __m512d ax[CRISP_RASTER_ATTRS];
    block_ax_avx512(pl, _mm512_add_pd(_mm512_set1_pd(bp->dx0), _mm512_loadu_pd(lane_x)), ax);
    store_row8_avx512(ax, pl, dy, _mm512_loadu_pd(iwv), (__mmask8)m, idx0, inv_w, fbuf, abuf,
                      face_id);
    return (unsigned)__builtin_popcount(m);
}
#undef A4_LANES

/* 1 when the processor (and the OS, for the zmm state) has what block_rows_avx512 needs. */
static int avx512_tiles(void)
{
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("bmi2");
}
#else
#define HAVE_AVX_TILES 0
#define HAVE_AVX512_TILES 0
#endif

#if defined(__SSE2__)
/* Bit q set where lane q of a block row is inside all three edges (row_mask's coverage). */
static inline unsigned row_cover(const int64_t e[3], __m128i lane_step[3][BLOCK / 2])
{
    unsigned neg = 0;
    const __m128i e0 = _mm_set1_epi64x(e[0]), e1 = _mm_set1_epi64x(e[1]),
                  e2 = _mm_set1_epi64x(e[2]);
    UNROLL(4)
    for (int h = 0; h < BLOCK / 2; h++) {
        __m128i o = _mm_or_si128(
            _mm_or_si128(_mm_add_epi64(e0, lane_step[0][h]), _mm_add_epi64(e1, lane_step[1][h])),
            _mm_add_epi64(e2, lane_step[2][h]));
        neg |= (unsigned)_mm_movemask_pd(_mm_castsi128_pd(o)) << (2 * h);
    }
    return ~neg & 0xffu;
}
#endif

/* Fill mode: a fragment at (x, y) (pixels of the whole image) that the slack test refused, tested
 * in the triangle's core k (crisp_raster_core) against the stored 1/W cur (> 0) and the core's
 * slack s2: 1 and *iw = the core's 1/W there when it lies in the core and is nearer than cur by
 * more than s2 in W. */
static inline int core_pass(const crisp_raster_core *k, double x, double y, double cur, float s2,
                            double *iw)
{
    double a = k->a[0] + k->a[1] * x + k->a[2] * y, b = k->b[0] + k->b[1] * x + k->b[2] * y;
    if (!(fabs(a) <= 1 && fabs(b) <= 1)) return 0;
    double iwc = k->iw[0] + k->iw[1] * x + k->iw[2] * y;
    if (!(iwc > 0 && 1.0 / iwc < 1.0 / cur - s2)) return 0;
    *iw = iwc;
    return 1;
}

/* The blocks of triangle st in the band of pixel rows [by0, by1] that can hold a covered sample:
 * narrows [*bxs, *bxe] (the triangle's pixel columns in the tile) to the columns of those blocks;
 * 0 when there are none. The block walk's edge test (raster_tile_s) rejects a block when, for one
 * edge k, the greatest E_k over the rectangle of its sample positions is negative; in a band that
 * greatest value is A_k sx1 + K (A_k > 0, sx1 the rectangle's right end) or A_k sx0 + K (A_k < 0),
 * monotone along the band, so the rejected blocks of an edge are a prefix or a suffix of the
 * band. Their limits are found here in doubles (a few roundings, relative error below 2^-50 of
 * a column within 2^21 px where it matters) with a pixel to spare on each side; a block left in
 * is still tested exactly, so the walk covers exactly the samples it covered without this. */
static inline int band_span(const setup_tri *st, const raster_ctx *c, int by0, int by1, int *bxs,
                            int *bxe)
{
    const int64_t sy0 = (int64_t)by0 * SUB + c->off_fmin[1],
                  sy1 = (int64_t)by1 * SUB + c->off_fmax[1];
    double lo = *bxs, hi = *bxe;
    UNROLL(3)
    for (int k = 0; k < 3; k++) {
        int64_t a = st->ea[k], b = st->eb[k];
        if (a == 0) continue;
        int64_t ey0 = b * sy0, ey1 = b * sy1;
        /* E_k at column 0 and the band's row that maximises it (an edge value of the image's
         * range: exact in int64; as a double, relative error 2^-53) */
        double K = (double)((ey0 > ey1 ? ey0 : ey1) + st->ec[k]);
        if (a > 0) { /* kept: x1 SUB + off_fmax >= -K / a, x1 the block's last column */
            double x = ((-K / (double)a) - (double)c->off_fmax[0]) / SUB - 1;
            lo = x > lo ? x : lo;
        } else { /* kept: x0 SUB + off_fmin <= K / -a, x0 the block's first column */
            double x = ((K / (double)-a) - (double)c->off_fmin[0]) / SUB + 1;
            hi = x < hi ? x : hi;
        }
    }
    if (!(lo <= hi)) return 0;
    /* The block holding column floor(lo) and every block after it up to column hi. */
    int s = (int)lo, e = (int)hi; /* in [*bxs, *bxe]: truncation is floor there */
    s = s / BLOCK * BLOCK;
    *bxs = s > *bxs ? s : *bxs;
    *bxe = e;
    return 1;
}

/* One tile, with S the target's samples per pixel: always inlined into raster_tile with S a
 * constant for the common one-sample target (the compiler then folds the sample loops and
 * strides), else with S as a variable. The same code either way. */

static ALWAYS_INLINE void raster_tile_s(raster_ctx *c, size_t tile, const int S, int fresh,
                                        const int avx)
{
    crisp_raster *r = c->r;
    crisp_raster_target *t = c->t;
    int tx = (int)(tile % (size_t)c->tiles_x), ty = (int)(tile / (size_t)c->tiles_x);
    int px0 = t->x0 + tx * TILE, py0 = t->y0 + ty * TILE; /* pixels of the whole image */
    int ex = t->x0 + t->width - 1, ey = t->y0 + t->height - 1;
    int px1 = px0 + TILE - 1 < ex ? px0 + TILE - 1 : ex;
    int py1 = py0 + TILE - 1 < ey ? py0 + TILE - 1 : ey;
    size_t tested = 0, discarded = 0, untested = 0, skipped = 0, boxed = 0;
    /* Per block: a lower bound of its least 1/W. Writes only raise stored 1/W (outside fill mode,
     * which does not use it), so a bound stays valid; it is recomputed from the samples once as
     * many writes as the block has samples happened since (amortised: one scan per block's worth
     * of writes). */
    double hiz[BLOCKS * BLOCKS];
    uint32_t writes[BLOCKS * BLOCKS];
    uint32_t block_samples = (uint32_t)(BLOCK * BLOCK * S);
    /* A tile just cleared has 0 everywhere: the bound is exact until its first writes. */
    for (int k = 0; k < BLOCKS * BLOCKS; k++)
        hiz[k] = 0, writes[k] = fresh ? 0 : block_samples;
    if (!fresh && c->live && r->live_tile[tile] && r->bin_start[tile] != r->bin_start[tile + 1]) {
        /* Each block's least 1/W: the least of the live blocks it holds (within the target). */
        int n = c->live_size, lw = (t->width + n - 1) / n;
        int x0t = tx * TILE, y0t = ty * TILE;
        for (int bj = 0; bj < BLOCKS && y0t + bj * BLOCK < t->height; bj++)
            for (int bi = 0; bi < BLOCKS && x0t + bi * BLOCK < t->width; bi++) {
                int gx = x0t + bi * BLOCK, gy = y0t + bj * BLOCK;
                int lx1 = (gx + BLOCK - 1 < t->width ? gx + BLOCK - 1 : t->width - 1) / n;
                int ly1 = (gy + BLOCK - 1 < t->height ? gy + BLOCK - 1 : t->height - 1) / n;
                double m = INFINITY;
                for (int ly = gy / n; ly <= ly1; ly++)
                    for (int lx = gx / n; lx <= lx1; lx++) {
                        double l = c->live[(size_t)ly * lw + lx];
                        m = l < m ? l : m;
                    }
                hiz[bj * BLOCKS + bi] = m, writes[bj * BLOCKS + bi] = 0;
            }
    }
    int use_hiz = c->hiz && !c->slack, vectors = c->vectors, clip_on = r->clip_on;
    /* The target's buffers, written only through these (no store can alias a triangle's data). */
    double *restrict inv_w = t->inv_w;
    int32_t *restrict fbuf = t->face;
    float *restrict abuf = t->attr;
    const size_t tw = (size_t)t->width;
    const int tx0 = t->x0, ty0 = t->y0;
    const float *slack = c->slack, *slack2 = c->slack2;
#if HAVE_AVX_TILES
    block_planes bp = {0}; /* the block's (block_planes_avx), on the AVX path */
    quad_planes qp = {0};  /* the triangle's, on the AVX path */
#endif
    for (uint32_t bi = r->bin_start[tile]; bi < r->bin_start[tile + 1]; bi++) {
        const setup_tri *st = r->bin_items[bi];
        planes pl;
        memcpy(pl.q0, st->q0, sizeof pl.q0);
        memcpy(pl.qx, st->qx, sizeof pl.qx);
        memcpy(pl.qy, st->qy, sizeof pl.qy);
        const double sox = st->ox, soy = st->oy;
        int x0 = st->x0 > px0 ? st->x0 : px0, x1 = st->x1 < px1 ? st->x1 : px1;
        int y0 = st->y0 > py0 ? st->y0 : py0, y1 = st->y1 < py1 ? st->y1 : py1;
        int32_t face_id =
            (int32_t)(st->face & ~(CRISP_RASTER_FACE_FLAG | CRISP_RASTER_FACE_NO_TEST));
        const crisp_raster_core *core = slack2 ? st->core : NULL; /* fill mode's second test */
        int run_test = c->test && !(st->face & CRISP_RASTER_FACE_NO_TEST) &&
                       !((size_t)face_id < r->untested_count && r->untested[face_id]);
        /* The fragment test decided for a box of (u, v) that holds every fragment's (u, v)
         * (uv_hull_box): for the whole triangle at set-up (tdec), then, found when a block first
         * has a fragment that passes the depth test, for its part in this tile (xdec, when the
         * triangle reaches beyond the tile), then the block (bdec, when the part spans several
         * blocks). 1: kept, 0: discarded, -1: not decided (each fragment is tested), -3: not
         * looked at yet. Without a test every fragment is kept. */
        int box_on = run_test && st->boxed != -2;
        int tdec = !run_test ? 1 : box_on ? st->boxed : -1, xdec = -3;
        const double *tbox = box_on && st->tbox_ok ? st->tbox : NULL;
        int part_blocks = x0 / BLOCK != x1 / BLOCK || y0 / BLOCK != y1 / BLOCK;
        /* band_span pays where a band has blocks to drop: not in a part one block wide (its
         * block's own edge test costs less than the search) */
        const int wide = x0 / BLOCK != x1 / BLOCK;
        int beyond = st->x0 < px0 || st->x1 > px1 || st->y0 < py0 || st->y1 > py1;
        /* Edge k: E = A (px - x_a0) + B (py - y_a0), stepped by A * SUB per pixel. */
        const int64_t *A = st->ea, *B = st->eb;
        int64_t step[3] = {A[0] * SUB, A[1] * SUB, A[2] * SUB};
        const int64_t bstep0 = B[0] * SUB, bstep1 = B[1] * SUB, bstep2 = B[2] * SUB;
        /* rmax (below) of a block BLOCK pixels wide */
        int64_t rmax8[3];
        UNROLL(3)
        for (int k = 0; k < 3; k++)
            rmax8[k] = step[k] > 0 ? step[k] * (BLOCK - 1) : 0;
#if defined(__SSE2__)
        /* Lanes 2h, 2h + 1 of a block row: edge k's steps from its first pixel (row_mask). */
        __m128i lane_step[3][BLOCK / 2];
        UNROLL(3)
        for (int k = 0; k < 3; k++) { /* q step as sums of steps (exact integers) */
            const __m128i two = _mm_set1_epi64x(2 * step[k]);
            lane_step[k][0] = _mm_set_epi64x(step[k], 0);
            UNROLL(3)
            for (int h = 1; h < BLOCK / 2; h++)
                lane_step[k][h] = _mm_add_epi64(lane_step[k][h - 1], two);
        }
        pair_planes pp;
        if (!avx)
            for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
                pp.q0[k] = _mm_set1_pd(pl.q0[k + 1]), pp.qx[k] = _mm_set1_pd(pl.qx[k + 1]);
#if HAVE_AVX_TILES
        qp.pl = &pl, qp.ok = 0;
#endif
#else
        vectors = 0;
#endif
        /* Rounding allowance of the 1/W plane evaluated at a block corner (see the hi-z test),
         * and the corner where the plane is largest. */
        const int hi_x = st->qx[0] > 0, hi_y = st->qy[0] > 0;
        double slop = 1e-12 * (fabs(st->q0[0]) +
                               fabs(st->qx[0]) * (fabs(x0 - st->ox) + fabs(x1 + 1 - st->ox)) +
                               fabs(st->qy[0]) * (fabs(y0 - st->oy) + fabs(y1 + 1 - st->oy)));
        for (int by0 = y0; by0 <= y1; by0 = (by0 / BLOCK + 1) * BLOCK) {
            int by1 = (by0 / BLOCK + 1) * BLOCK - 1 < y1 ? (by0 / BLOCK + 1) * BLOCK - 1 : y1;
            int bxs = x0, bxe = x1; /* the band's blocks that may be non-empty (band_span) */
            if (wide && !band_span(st, c, by0, by1, &bxs, &bxe)) continue;
            /* The edge test's row part over the band (exact integers, so the sums below are
             * those of the whole expression): least and greatest of B sy + C; and each sample's
             * B py + C at the band's first row (the blocks' first edge values, below). */
            int64_t eyl[3], eyh[3], eyr[16][3];
            for (int s = 0; s < S; s++) {
                int64_t py = (int64_t)by0 * SUB + c->off_fy[s];
                UNROLL(3)
                for (int k = 0; k < 3; k++)
                    eyr[s][k] = B[k] * py + st->ec[k];
            }
            {
                int64_t sy0 = (int64_t)by0 * SUB + c->off_fmin[1],
                        sy1 = (int64_t)by1 * SUB + c->off_fmax[1];
                UNROLL(3)
                for (int k = 0; k < 3; k++) {
                    int64_t ey0 = B[k] * sy0, ey1 = B[k] * sy1;
                    eyl[k] = (ey0 < ey1 ? ey0 : ey1) + st->ec[k];
                    eyh[k] = (ey0 > ey1 ? ey0 : ey1) + st->ec[k];
                }
            }
            /* Pixels are >= 0 (a window lies inside the image): a block's last column is
             * bx0 | (BLOCK - 1), its index in the tile a shift. */
            const int brow = (by0 - py0) / BLOCK * BLOCKS;
            for (int bx0 = bxs; bx0 <= bxe; bx0 = (bx0 | (BLOCK - 1)) + 1) {
                int bx1 = (bx0 | (BLOCK - 1)) < x1 ? (bx0 | (BLOCK - 1)) : x1;
                int blk = brow + (int)((unsigned)(bx0 - px0) / BLOCK);
                if (tdec == 0 || xdec == 0) goto triangle_done; /* every fragment discarded */
                /* Each edge function over the block's samples (inside the rectangle of sample
                 * positions; affine, so extreme at its corners): a block outside an edge has no
                 * covered sample and is skipped; one inside all three is covered everywhere and
                 * its rows skip the per-pixel edge tests. Exact integers, as the tests. */
                int full = 1, empty = 0;
                {
                    int64_t sx0 = (int64_t)bx0 * SUB + c->off_fmin[0],
                            sx1 = (int64_t)bx1 * SUB + c->off_fmax[0];
                    UNROLL(3)
                    for (int k = 0; k < 3; k++) {
                        int64_t ex0 = A[k] * sx0, ex1 = A[k] * sx1;
                        int64_t lo = (ex0 < ex1 ? ex0 : ex1) + eyl[k];
                        int64_t hi = (ex0 > ex1 ? ex0 : ex1) + eyh[k];
                        empty |= hi < 0;
                        full &= lo >= 0;
                    }
                }
                if (empty) continue;
                if (use_hiz && (bx1 - bx0 + 1) * (by1 - by0 + 1) >= HIZ_MIN_PX) {
                    if (writes[blk] >= block_samples) {
                        int gx = px0 + (bx0 - px0) / BLOCK * BLOCK,
                            gy = py0 + (by0 - py0) / BLOCK * BLOCK;
                        int gx1 = gx + BLOCK - 1 < px1 ? gx + BLOCK - 1 : px1;
                        int gy1 = gy + BLOCK - 1 < py1 ? gy + BLOCK - 1 : py1;
                        hiz[blk] = block_min(t, inv_w, gx, gy, gx1, gy1);
                        writes[blk] = 0;
                    }
                    /* The triangle's largest 1/W over the block's rectangle: an affine function,
                     * largest at the corner its gradient's signs pick (hi_x, hi_y; either corner
                     * of a zero gradient); evaluated there, within slop of every sample's
                     * computed 1/W bound (the exact value at the corner bounds the exact value
                     * at every sample; slop covers the two evaluations' rounding). No sample
                     * can pass the depth test when it is not above every stored value. NaN
                     * planes skip nothing. */
                    double best = st->q0[0] + st->qx[0] * ((hi_x ? bx1 + 1 : bx0) - st->ox) +
                                  st->qy[0] * ((hi_y ? by1 + 1 : by0) - st->oy);
                    if (best + slop < hiz[blk]) {
                        skipped++;
                        continue;
                    }
                }
                uint32_t wrote = 0;
                int bdec = -3; /* the block's decision (-3: not yet) */
                /* Edge values at the block's first pixel of each sample, stepped by rows. */
                int64_t er[16][3];
                for (int s = 0; s < S; s++) {
                    int64_t px = (int64_t)bx0 * SUB + c->off_fx[s];
                    for (int k = 0; k < 3; k++)
                        er[s][k] = A[k] * px + eyr[s][k];
                }
                /* Edge k's greatest value along a row over its first: a row whose greatest
                 * value is negative for one edge has no covered lane (a thin triangle's block has
                 * many such rows) and is skipped before any per-lane work. */
                const int n = bx1 - bx0 + 1;
                int64_t rmax[3] = {rmax8[0], rmax8[1], rmax8[2]};
                if (n != BLOCK) {
                    UNROLL(3)
                    for (int k = 0; k < 3; k++)
                        rmax[k] = step[k] > 0 ? step[k] * (n - 1) : 0;
                }
                /* The block's own per-row values: each sample's column offset from the planes'
                 * origin, the first row's first sample, whether its rows are whole BLOCK lanes
                 * inside the image (the vector paths). */
                double dx0s[16];
                for (int s = 0; s < S; s++)
                    dx0s[s] = (double)bx0 + c->off_x[s] - st->ox;
                const int in_row = bx0 - tx0 + BLOCK <= (int)tw;
#if HAVE_AVX_TILES
                if (avx && S == 1 && !slack && vectors && in_row) {
                    if (avx != 3 || clip_on || tdec != 1) block_planes_avx(&bp, st->qx[0], dx0s[0]);
                    if (avx >= 2 && !clip_on && tdec == 1) {
                        block_rows br = {{er[0][0], er[0][1], er[0][2]},
                                         {bstep0, bstep1, bstep2},
                                         {rmax[0], rmax[1], rmax[2]},
                                         full,
                                         n,
                                         by0,
                                         by1,
                                         st->q0[0],
                                         st->qy[0],
                                         c->off_y[0],
                                         st->oy,
                                         ((size_t)(by0 - ty0) * tw + (size_t)(bx0 - tx0)),
                                         tw};
                        uint32_t k;
#if HAVE_AVX512_TILES
                        if (avx == 3)
                            k = block_rows_avx512(&br, lane_step, &pl, inv_w, fbuf, abuf, face_id,
                                                  st->qx[0], dx0s[0]);
                        else
#endif
                            k = block_rows_avx2(&br, lane_step, &qp, &bp, inv_w, fbuf, abuf,
                                                face_id);
                        if (run_test)
                            boxed += k;
                        else if (c->test)
                            untested += k;
                        writes[blk] += k;
                        continue;
                    }
                }
#endif
                size_t row0 = ((size_t)(by0 - ty0) * tw + (size_t)(bx0 - tx0)) * S;
                for (int j = by0; j <= by1; j++, row0 += tw * S)
                    for (int s = 0; s < S; s++) {
                        /* Coverage, 1/W and the depth test of the block's row for this sample,
                         * in loops over at most BLOCK lanes without branches (vectorisable). */
                        int64_t e[3] = {er[s][0], er[s][1], er[s][2]};
                        er[s][0] += bstep0, er[s][1] += bstep1, er[s][2] += bstep2;
                        if (!full && ((e[0] + rmax[0]) | (e[1] + rmax[1]) | (e[2] + rmax[2])) < 0)
                            continue;
                        double dy = j + c->off_y[s] - st->oy;
                        double base = st->q0[0] + st->qy[0] * dy, gx = st->qx[0];
                        double dx0 = dx0s[s];
                        size_t idx0 = row0 + (size_t)s;
                        /* iwv: 1/W stored; fill mode: iwa, the triangle's own 1/W (for the
                         * attributes) where a core's differs */
                        double iwv[BLOCK], iwa[BLOCK];
                        int cov[BLOCK], pass[BLOCK], np = 0, any = 0;
#if defined(__SSE2__)
                        unsigned m = 0;
#endif
                        if (!slack && S == 1 && vectors && in_row) {
#if defined(__SSE2__)
                            /* The same tests on 8 lanes, two at a time (the row's stored 1/W
                             * is read at 8 lanes: inside the image's row). */
#if HAVE_AVX_TILES
#if HAVE_AVX512_TILES
                            if (avx == 3)
                                m = row_mask_avx512(e, lane_step, full, base, &bp, inv_w + idx0,
                                                    iwv);
                            else
#endif
                                if (avx >= 2)
                                m = row_mask_avx2(e, lane_step, full, base, &bp, inv_w + idx0, iwv);
                            else if (avx)
                                m = row_mask_avx(e, lane_step, full, base, &bp, inv_w + idx0, iwv);
                            else
#endif
                                m = row_mask(e, lane_step, full, base, gx, dx0, inv_w + idx0, iwv);
                            m &= (1u << n) - 1;
                            np = m != 0;
#endif
                        } else if (!slack) {
                            /* Coverage, 1/W and the depth test in one branch-free loop (the
                             * stored 1/W is read at every lane of the row: inside the image). */
                            const double *stored = inv_w + idx0;
                            if (full)
                                for (int q = 0; q < n; q++) {
                                    double iwq = base + gx * (dx0 + q);
                                    iwv[q] = iwq;
                                    pass[np] = q;
                                    np += iwq > stored[(size_t)q * S];
                                }
                            else
                                for (int q = 0; q < n; q++) {
                                    int cv = (e[0] | e[1] | e[2]) >= 0;
                                    e[0] += step[0], e[1] += step[1], e[2] += step[2];
                                    double iwq = base + gx * (dx0 + q);
                                    iwv[q] = iwq;
                                    pass[np] = q;
                                    np += cv & (iwq > stored[(size_t)q * S]);
                                }
                        } else if (S == 1 && vectors && in_row) {
#if defined(__SSE2__)
                            /* Fill mode, one sample, the lanes' coverage two at a time (most
                             * rows of a ribbon's blocks have none), then the loop below on the
                             * covered lanes. */
                            unsigned cm =
                                (full ? 0xffu : row_cover(e, lane_step)) & ((1u << n) - 1);
                            for (; cm; cm &= cm - 1) {
                                int q = __builtin_ctz(cm);
                                double iwq = base + gx * (dx0 + q), cur = inv_w[idx0 + (size_t)q];
                                iwv[q] = iwa[q] = iwq;
                                if (!(cur > 0) || 1.0 / iwq < 1.0 / cur - slack[idx0 + (size_t)q] ||
                                    (core && core_pass(core, (double)(bx0 + q) + c->off_x[s],
                                                       j + c->off_y[s], cur,
                                                       slack2[idx0 + (size_t)q], &iwv[q])))
                                    pass[np++] = q;
                            }
#endif
                        } else {
                            /* Fill mode: coverage first, then the slack's depth test. */
                            if (full) {
                                for (int q = 0; q < n; q++)
                                    cov[q] = 1;
                                any = 1;
                            } else {
                                for (int q = 0; q < n; q++) {
                                    cov[q] = (e[0] | e[1] | e[2]) >= 0;
                                    any |= cov[q];
                                    e[0] += step[0], e[1] += step[1], e[2] += step[2];
                                }
                            }
                            if (!any) continue;
                            for (int q = 0; q < n; q++)
                                iwv[q] = iwa[q] = base + gx * (dx0 + q);
                            for (int q = 0; q < n; q++) {
                                double cur = inv_w[idx0 + (size_t)q * S];
                                if (cov[q] &&
                                    (!(cur > 0) ||
                                     1.0 / iwv[q] < 1.0 / cur - slack[idx0 + (size_t)q * S] ||
                                     (core && core_pass(core, (double)(bx0 + q) + c->off_x[s],
                                                        j + c->off_y[s], cur,
                                                        slack2[idx0 + (size_t)q * S], &iwv[q]))))
                                    pass[np++] = q;
                            }
                        }
                        if (!np) continue;
                        if (bdec == -3) { /* the first fragment that needs the decision */
                            bdec = tdec;
                            if (bdec == -1 && box_on && beyond && part_blocks) {
                                if (xdec == -3) xdec = rect_decision(c, st, x0, y0, x1, y1, tbox);
                                bdec = xdec;
                            }
                            if (bdec == -1 && box_on && part_blocks)
                                bdec = rect_decision(c, st, bx0, by0, bx1, by1, tbox);
                            if (bdec == 0) { /* every fragment of the block is discarded */
#if defined(__SSE2__)
                                boxed += m ? (size_t)__builtin_popcount(m) : (size_t)np;
#else
                                boxed += (size_t)np;
#endif
                                goto block_done;
                            }
                        }
#if defined(__SSE2__)
                        if (bdec == 1 && !clip_on && m && (avx || (m & (m >> 1) & 0x55u))) {
                            /* Every fragment of the row is kept (with SSE2 only, two neighbours
                             * among them): no per-fragment work but the attributes and the
                             * stores, two (AVX: four) lanes at a time. */
                            unsigned k;
#if HAVE_AVX512_TILES
                            if (avx == 3)
                                k = store_row1_avx512(&pl, &bp, dy, iwv, m, idx0, inv_w, fbuf, abuf,
                                                      face_id);
                            else
#endif
#if HAVE_AVX_TILES
                                if (avx)
                                k = store_row1_avx(&qp, &bp, dy, iwv, m, idx0, inv_w, fbuf, abuf,
                                                   face_id);
                            else
#endif
                                k = store_row1(&pl, &pp, dx0, dy, iwv, m, idx0, inv_w, fbuf, abuf,
                                               face_id);
                            if (run_test)
                                boxed += k;
                            else if (c->test)
                                untested += k;
                            wrote += k;
                            continue;
                        }
                        if (m) /* the vector path's lanes */
                            for (np = 0; m; m &= m - 1)
                                pass[np++] = __builtin_ctz(m);
#endif
                        for (int pi = 0; pi < np; pi++) {
                            int q = pass[pi];
                            size_t idx = idx0 + (size_t)q * S;
                            double iw = iwv[q], dx = dx0 + q;
                            if (clip_on && r->clip[0] + r->clip[1] * (dx + sox) +
                                                   r->clip[2] * (dy + soy) + r->clip[3] * iw <
                                               0)
                                continue; /* on the clipped side of the plane */
                            double a[CRISP_RASTER_ATTRS];
                            double w = 1.0 / (slack ? iwa[q] : iw);
                            if (vectors)
                                attrs_vector(&pl, dx, dy, w, a);
                            else
                                attrs_scalar(&pl, dx, dy, w, a);
                            if (bdec == -1) {
                                tested++;
                                if (!c->test(c->test_ctx, st->face, a[0], a[1])) {
                                    discarded++;
                                    continue;
                                }
                            } else if (run_test) {
                                boxed++;
#ifdef DEBUG_BOX
                                if (!c->test(c->test_ctx, st->face, a[0], a[1])) {
                                    double tb2[4];
                                    int td = tri_decision(r, c->test_ctx, st, tb2);
                                    fprintf(stderr,
                                            "MISMATCH face %u u %.17g v %.17g bdec %d tdec %d xdec "
                                            "%d tbox %.17g %.17g %.17g %.17g blk %d %d %d %d part "
                                            "%d %d %d %d\n",
                                            st->face, a[0], a[1], bdec, td, xdec, tb2[0], tb2[1],
                                            tb2[2], tb2[3], bx0, by0, bx1, by1, x0, y0, x1, y1);
                                }
#endif
                            } else if (c->test) {
                                untested++;
                            }
                            inv_w[idx] = iw;
                            fbuf[idx] = face_id;
                            float *dst = abuf + idx * CRISP_RASTER_ATTRS;
                            dst[0] = (float)a[0], dst[1] = (float)a[1], dst[2] = (float)a[2];
                            dst[3] = (float)a[3], dst[4] = (float)a[4];
                            wrote++;
                        }
                    }
            block_done:
                writes[blk] += wrote;
            }
        }
    triangle_done:;
    }
    atomic_fetch_add(&c->tested, tested);
    atomic_fetch_add(&c->discarded, discarded);
    atomic_fetch_add(&c->untested, untested);
    atomic_fetch_add(&c->blocks_skipped, skipped);
    atomic_fetch_add(&c->boxed, boxed);
}

#if HAVE_AVX_TILES
/* raster_tile_s for one-sample targets compiled for AVX (store_row1_avx). */
__attribute__((target("avx"), flatten)) static void raster_tile1_avx(raster_ctx *c, size_t tile,
                                                                     int fresh)
{
    raster_tile_s(c, tile, 1, fresh, 1);
}

/* The same compiled for AVX2 (row_mask_avx2; the compiler's own integer code may use it too). */
__attribute__((target("avx2"), flatten)) static void raster_tile1_avx2(raster_ctx *c, size_t tile,
                                                                       int fresh)
{
    raster_tile_s(c, tile, 1, fresh, 2);
}
#endif
#if HAVE_AVX512_TILES
/* The same compiled for AVX-512 (block_rows_avx512). */
__attribute__((target(AVX512_TILES), flatten)) static void
raster_tile1_avx512(raster_ctx *c, size_t tile, int fresh)
{
    raster_tile_s(c, tile, 1, fresh, 3);
}
#endif
#if !HAVE_AVX_TILES
#define raster_tile1_avx(c, tile, fresh) raster_tile_s(c, tile, 1, fresh, 0)
#define raster_tile1_avx2(c, tile, fresh) raster_tile_s(c, tile, 1, fresh, 0)
#endif

static void raster_tile(raster_ctx *c, size_t tile)
{
    const crisp_raster *r = c->r;
    int drawn = r->bin_start[tile] != r->bin_start[tile + 1];
    /* The pending clear_depth of this tile, while it is about to be used (deferred: while the
     * tile has nothing to draw, it stays pending and reads as empty). */
    int pending = c->pending && c->pending[tile], fresh = pending && (drawn || !c->defer);
    if (fresh) {
        clear_tile(c->t, c->tiles_x, tile);
        c->pending[tile] = 0;
    }
#if HAVE_AVX512_TILES
    if (c->t->samples == 1 && c->avx == 3)
        raster_tile1_avx512(c, tile, fresh);
    else
#endif
        if (c->t->samples == 1 && c->avx == 2)
        raster_tile1_avx2(c, tile, fresh);
    else if (c->t->samples == 1 && c->avx)
        raster_tile1_avx(c, tile, fresh);
    else if (c->t->samples == 1)
        raster_tile_s(c, tile, 1, fresh, 0);
    else
        raster_tile_s(c, tile, c->t->samples, fresh, 0);
    if (r->live && (pending || drawn)) {
        if (r->live_compute) live_tile(r, c->t, c->tiles_x, tile, !drawn);
        r->live_tile[tile] = (uint8_t)(r->live_compute != 0);
    }
}

/* The tiles, shared out so that two workers seldom draw tiles next to each other at the same
 * time, and a tile goes to the same worker draw after draw while the work stays alike: each
 * worker first takes the tiles of its home range (a band of tile rows) from the front, then those
 * left in the others' from their back. On a two-core machine, tiles handed out one by one in
 * row order put the two workers on horizontally adjacent tiles all the time, and the tiles took
 * 2.3x the CPU time of one worker (a close-up of large triangles, little work per pixel; with
 * tiles far apart 1.3x: measured, docs/status/issue-12-tiles.md; the cores contend for the lines
 * of the rows the two tiles share, and each tile's lines sit in the other core's caches from the
 * draw before). Any worker may take any tile: the balance stays dynamic, and the picture does not
 * depend on who draws a tile. */
static void raster_tiles(void *vctx, size_t begin, size_t end, int worker)
{
    (void)begin, (void)end;
    raster_ctx *c = vctx;
    int k = 0;
    size_t tile;
    while (crisp__raster_share_next(&c->share, worker, &k, &tile))
        raster_tile(c, tile);
}

void crisp__raster_share_init(crisp_raster_share *s, size_t count, int workers)
{
    s->ranges = workers < 1                        ? 1
                : workers < CRISP_RASTER_SHARE_MAX ? workers
                                                   : CRISP_RASTER_SHARE_MAX;
    for (int g = 0; g < s->ranges; g++) {
        uint64_t lo = count * (size_t)g / (size_t)s->ranges,
                 hi = count * (size_t)(g + 1) / (size_t)s->ranges;
        atomic_store(&s->range[g].ends, hi << 32 | lo);
    }
}

int crisp__raster_share_next(crisp_raster_share *s, int worker, int *k, size_t *item)
{
    for (; *k < s->ranges; ++*k) {
        _Atomic uint64_t *ends = &s->range[(worker % s->ranges + *k) % s->ranges].ends;
        int back = *k != 0; /* another worker's range: from its back */
        uint64_t e = atomic_load_explicit(ends, memory_order_relaxed);
        for (;;) {
            uint32_t lo = (uint32_t)e, hi = (uint32_t)(e >> 32);
            if (lo >= hi) break;
            uint64_t n = back ? (uint64_t)(hi - 1) << 32 | lo : (uint64_t)hi << 32 | (lo + 1);
            if (atomic_compare_exchange_weak(ends, &e, n)) {
                *item = back ? hi - 1 : lo;
                return 1;
            }
        }
    }
    return 0;
}

typedef struct slack_ctx {
    const crisp_raster_target *t;
    const crisp_raster_view *view;
    double scale;
    float *slack;
    double scale2; /* slack_tiles: a second slack at another scale, when slack2 is not NULL */
    float *slack2;
} slack_ctx;

/* The side a sample's surface is seen from: the sign of its normal (attributes 2..4) against the
 * view direction through its pixel. A face seen through a crack at its own seam (a quarter sphere
 * shows its inside beyond the crack, beside its outside) puts samples of its two sides next to
 * each other; their depth difference is not the surface's depth change and must not widen the
 * slack, or the ribbon that closes the crack is refused. */
static int seen_side(const crisp_raster_view *v, int w, int h, int i, int j, const float *a)
{
    if (!v) return 0;
    double x = (i + 0.5 - 0.5 * w) * v->kx, y = (0.5 * h - j - 0.5) * v->ky, dot = 0;
    for (int k = 0; k < 3; k++)
        dot += a[2 + k] * (v->f[k] + x * v->r[k] + y * v->u[k]);
    return dot < 0;
}

/* seen_side's test with the view direction's column part f + x r (c0, c1, c2) and row part y u
 * (yu) each computed once (slack_tiles, slack_cell_avx2): the same sums in the same order. */
static inline int side_at(const float *a, double c0, double c1, double c2, const double yu[3])
{
    double dot = 0;
    dot += a[2] * (c0 + yu[0]);
    dot += a[3] * (c1 + yu[1]);
    dot += a[4] * (c2 + yu[2]);
    return dot < 0;
}

/* Rows [begin, end): each pair of horizontally or vertically adjacent samples of one face (and
 * one side of it) is looked at once, from its left or upper member, and raises both members'
 * slack. A worker writes
 * only its own rows: the vertical pair across a chunk boundary is looked at by both chunks (the
 * lower chunk starts one row early), each raising its own member. */
static void slack_rows(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const slack_ctx *c = vctx;
    const crisp_raster_target *t = c->t;
    float *slack = c->slack;
    int S = t->samples, w = t->width, h = t->height, iw = image_w(t), ih = image_h(t);
    int ox = t->x0, oy = t->y0;
    size_t rs = (size_t)w * S;
    for (size_t i = begin * rs; i < end * rs; i++)
        slack[i] = 0;
    for (int j = (int)begin - (begin > 0); j < (int)end; j++) {
        int own_j = j >= (int)begin, own_below = j + 1 < (int)end;
        for (int i = 0; i < w; i++)
            for (int s = 0; s < S; s++) {
                size_t idx = ((size_t)j * w + i) * S + s;
                int32_t f = t->face[idx];
                if (f < 0) continue;
                double W = 1.0 / t->inv_w[idx];
                int side =
                    seen_side(c->view, iw, ih, ox + i, oy + j, t->attr + idx * CRISP_RASTER_ATTRS);
                if (own_j && i + 1 < w && t->face[idx + S] == f &&
                    seen_side(c->view, iw, ih, ox + i + 1, oy + j,
                              t->attr + (idx + S) * CRISP_RASTER_ATTRS) == side) {
                    float d = (float)(c->scale * fabs(1.0 / t->inv_w[idx + S] - W));
                    if (d > slack[idx]) slack[idx] = d;
                    if (d > slack[idx + S]) slack[idx + S] = d;
                }
                if (j + 1 < h && t->face[idx + rs] == f &&
                    seen_side(c->view, iw, ih, ox + i, oy + j + 1,
                              t->attr + (idx + rs) * CRISP_RASTER_ATTRS) == side) {
                    float d = (float)(c->scale * fabs(1.0 / t->inv_w[idx + rs] - W));
                    if (own_j && d > slack[idx]) slack[idx] = d;
                    if (own_below && d > slack[idx + rs]) slack[idx + rs] = d;
                }
            }
    }
}

void crisp__raster_depth_slack(const crisp_raster_target *t, crisp_pool *pool, double scale,
                               const crisp_raster_view *view, float *slack)
{
    slack_ctx c = {t, view, scale, slack, 0, NULL};
    crisp_pool_parallel_for(pool, (size_t)t->height, 16, slack_rows, &c);
}

#define CELL 16 /* the slack is computed for CELL x CELL pixel cells that triangles reach */

/* The slack of one cell's samples, each from its own four neighbours (the same pairs and the
 * same arithmetic as slack_rows, gathered at each member instead of scattered from the left or
 * upper one: |a - b| = |b - a| exactly, so the values are the same bit for bit). */
typedef struct slack_tiles_ctx {
    const slack_ctx *c;
    const uint8_t *mask;
    int cells_x;
    int avx2; /* one-sample cells CELL pixels wide through slack_cell_avx2 */
} slack_tiles_ctx;

#if HAVE_AVX_TILES
/* slack_tiles' work for one cell CELL pixels wide of a one-sample target, four pixels at a time
 * (AVX2): the same values bit for bit. Per sample of the cell and its border: its face and side
 * as one key (2 f + side; -1: none or outside the image; two samples pair up exactly when their
 * keys are equal and not -1) and W = 1 / inv_w (also computed for empty samples, whose W no pair
 * reads); the side's dot product is slack_tiles' (0 + a2 c0, then + a3 c1, + a4 c2, the same
 * IEEE operations on each lane; no fused multiply-add). Then each sample's largest |W_n - W|
 * over its paired neighbours n in the same order (left, right, up, down): max_pd(d, m) is d > m
 * ? d : m, slack_tiles' step, with d = 0 for an unpaired neighbour (never above m >= 0). */
__attribute__((target("avx2"))) static void slack_cell_avx2(const slack_ctx *c, int px0, int py0,
                                                            int py1, const double colp[3][CELL + 2])
{
    enum { L = CELL + 2 };
    const crisp_raster_target *t = c->t;
    const crisp_raster_view *v = c->view;
    int w = t->width, h = t->height, ih = image_h(t);
    int64_t key[L * L] __attribute__((aligned(32)));
    double wl[L * L] __attribute__((aligned(32)));
    const __m128i lane5 = _mm_setr_epi32(0, 5, 10, 15);
    for (int j = py0 - 1; j <= py1; j++) {
        int64_t *krow = key + (j - py0 + 1) * L;
        double *wrow = wl + (j - py0 + 1) * L;
        if (j < 0 || j >= h) {
            for (int l = 0; l < L; l++)
                krow[l] = -1, wrow[l] = 0;
            continue;
        }
        double y = v ? (0.5 * ih - (t->y0 + j) - 0.5) * v->ky : 0;
        double yus[3] = {v ? y * v->u[0] : 0, v ? y * v->u[1] : 0, v ? y * v->u[2] : 0};
        __m256d yu[3];
        for (int k = 0; k < 3; k++)
            yu[k] = _mm256_set1_pd(yus[k]);
        /* the border columns, as slack_tiles */
        for (int e = 0; e < 2; e++) {
            int i = e ? px0 + CELL : px0 - 1, l = e ? L - 1 : 0;
            krow[l] = -1, wrow[l] = 0;
            if (i < 0 || i >= w) continue;
            size_t idx = (size_t)j * w + i;
            int32_t f = t->face[idx];
            if (f < 0) continue;
            int side = v ? side_at(t->attr + idx * CRISP_RASTER_ATTRS, colp[0][l], colp[1][l],
                                   colp[2][l], yus)
                         : 0;
            krow[l] = 2 * (int64_t)f + side;
            wrow[l] = 1.0 / t->inv_w[idx];
        }
        UNROLL(4)
        for (int q = 0; q < CELL / 4; q++) {
            size_t idx = (size_t)j * w + px0 + 4 * q;
            __m256i f = _mm256_cvtepi32_epi64(_mm_loadu_si128((const __m128i *)(t->face + idx)));
            __m256i k2 = _mm256_add_epi64(f, f);
            if (v) {
                const float *a = t->attr + idx * CRISP_RASTER_ATTRS;
                __m256d dot = _mm256_setzero_pd();
                for (int k = 0; k < 3; k++) {
                    __m256d ak = _mm256_cvtps_pd(_mm_i32gather_ps(a + 2 + k, lane5, 4));
                    __m256d ck = _mm256_add_pd(_mm256_loadu_pd(&colp[k][1 + 4 * q]), yu[k]);
                    dot = _mm256_add_pd(dot, _mm256_mul_pd(ak, ck));
                }
                __m256i side = _mm256_castpd_si256(
                    _mm256_cmp_pd(dot, _mm256_setzero_pd(), _CMP_LT_OQ)); /* -1 where < 0 */
                k2 = _mm256_sub_epi64(k2, side);
            }
            /* -1 where the face is negative */
            __m256i none = _mm256_cmpgt_epi64(_mm256_setzero_si256(), f);
            _mm256_storeu_si256((__m256i *)(krow + 1 + 4 * q), _mm256_or_si256(k2, none));
            _mm256_storeu_pd(wrow + 1 + 4 * q,
                             _mm256_div_pd(_mm256_set1_pd(1.0), _mm256_loadu_pd(t->inv_w + idx)));
        }
    }
    const __m256d scale = _mm256_set1_pd(c->scale), scale2 = _mm256_set1_pd(c->scale2);
    const __m256d sign = _mm256_set1_pd(-0.0);
    for (int j = py0; j < py1; j++) {
        UNROLL(4)
        for (int q = 0; q < CELL / 4; q++) {
            int l = (j - py0 + 1) * L + 1 + 4 * q;
            __m256i kl = _mm256_loadu_si256((const __m256i *)(key + l));
            __m256d W = _mm256_loadu_pd(wl + l), m = _mm256_setzero_pd();
            const int nb[4] = {l - 1, l + 1, l - L, l + L}; /* left right up down */
            UNROLL(4)
            for (int k = 0; k < 4; k++) {
                __m256d same = _mm256_castsi256_pd(
                    _mm256_cmpeq_epi64(_mm256_loadu_si256((const __m256i *)(key + nb[k])), kl));
                __m256d d = _mm256_andnot_pd(sign, _mm256_sub_pd(_mm256_loadu_pd(wl + nb[k]), W));
                m = _mm256_max_pd(_mm256_and_pd(same, d), m);
            }
            /* 0 where the sample itself is empty */
            m = _mm256_andnot_pd(
                _mm256_castsi256_pd(_mm256_cmpgt_epi64(_mm256_setzero_si256(), kl)), m);
            size_t out = (size_t)j * w + px0 + 4 * q;
            _mm_storeu_ps(c->slack + out, _mm256_cvtpd_ps(_mm256_mul_pd(scale, m)));
            if (c->slack2)
                _mm_storeu_ps(c->slack2 + out, _mm256_cvtpd_ps(_mm256_mul_pd(scale2, m)));
        }
    }
}
#endif

static void slack_tiles(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const slack_tiles_ctx *tc = vctx;
    const slack_ctx *c = tc->c;
    const crisp_raster_target *t = c->t;
    const crisp_raster_view *v = c->view;
    int S = t->samples, w = t->width, h = t->height, iw = image_w(t), ih = image_h(t);
    enum { L = CELL + 2 }; /* the cell and its one-pixel border */
    /* Per sample of the cell and its border: face (-1: none or outside the image), the side it
     * is seen from (seen_side's arithmetic, with the view direction's column part f + x r once
     * per column), W. The slack of each sample of the cell then compares it with its four
     * neighbours there, as slack_rows does (a neighbour outside the image has face -1). */
    int32_t fl[L * L];
    int8_t side[L * L];
    double wl[L * L], colp[3][L];
    for (size_t tile = begin; tile < end; tile++) {
        if (!tc->mask[tile]) continue;
        int px0 = (int)(tile % (size_t)tc->cells_x) * CELL,
            py0 = (int)(tile / (size_t)tc->cells_x) * CELL;
        int px1 = px0 + CELL < w ? px0 + CELL : w, py1 = py0 + CELL < h ? py0 + CELL : h;
        if (v)
            for (int i = px0 - 1; i <= px1; i++) {
                double x = (t->x0 + i + 0.5 - 0.5 * iw) * v->kx;
                for (int k = 0; k < 3; k++)
                    colp[k][i - px0 + 1] = v->f[k] + x * v->r[k];
            }
#if HAVE_AVX_TILES
        if (tc->avx2 && S == 1 && px1 - px0 == CELL) {
            slack_cell_avx2(c, px0, py0, py1, (const double(*)[L])colp);
            continue;
        }
#endif
        for (int s = 0; s < S; s++) {
            for (int j = py0 - 1; j <= py1; j++) {
                double y = v ? (0.5 * ih - (t->y0 + j) - 0.5) * v->ky : 0;
                double yu[3] = {v ? y * v->u[0] : 0, v ? y * v->u[1] : 0, v ? y * v->u[2] : 0};
                for (int i = px0 - 1; i <= px1; i++) {
                    int l = (j - py0 + 1) * L + (i - px0 + 1);
                    fl[l] = -1, side[l] = -1;
                    if (i < 0 || j < 0 || i >= w || j >= h) continue;
                    size_t idx = ((size_t)j * w + i) * S + s;
                    int32_t f = t->face[idx];
                    if (f < 0) continue;
                    fl[l] = f;
                    wl[l] = 1.0 / t->inv_w[idx];
                    int ii = i - px0 + 1;
                    side[l] = (int8_t)(v ? side_at(t->attr + idx * CRISP_RASTER_ATTRS, colp[0][ii],
                                                   colp[1][ii], colp[2][ii], yu)
                                         : 0);
                }
            }
            for (int j = py0; j < py1; j++)
                for (int i = px0; i < px1; i++) {
                    int l = (j - py0 + 1) * L + (i - px0 + 1);
                    int32_t f = fl[l];
                    double m = 0; /* rounding is monotone: the largest rounded = the largest's */
                    if (f >= 0) {
                        double W = wl[l];
                        const int nb[4] = {l - 1, l + 1, l - L, l + L}; /* left right up down */
                        UNROLL(4)
                        for (int k = 0; k < 4; k++) {
                            int n = nb[k];
                            if (fl[n] != f || side[n] != side[l]) continue;
                            double d = fabs(wl[n] - W);
                            if (d > m) m = d;
                        }
                    }
                    size_t out = ((size_t)j * w + i) * S + s;
                    c->slack[out] = (float)(c->scale * m);
                    if (c->slack2) c->slack2[out] = (float)(c->scale2 * m);
                }
        }
    }
}

/* Per triangle, the pixels its samples can lie in (x0, y0, x1, y1; x0 > x1: none), from the
 * vertices setup would use (inside every clip plane: as they are; else the clipped polygon's,
 * as setup_chunk clips it): floor(min) - 1 .. floor(max) of their snapped positions (1/512 px
 * from the unsnapped ones); 2 px of margin cover both. */
typedef struct box_ctx {
    const crisp_raster *r;
    const crisp_raster_core *cores; /* per triangle, NULL: none (as the fill draw's) */
    const crisp_raster_target *t;
    const pvert *cache; /* the vertices projected (project_vertices) */
    const crisp_raster_vertex *verts;
    size_t vert_count;
    const crisp_raster_tri *tris;
    size_t tri_count;
    int (*boxes)[4];
} box_ctx;

static void tri_boxes(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const box_ctx *c = vctx;
    const crisp_raster_target *t = c->t;
    double gx = GUARD_PX / image_w(t), gy = GUARD_PX / image_h(t);
    for (size_t ch = begin; ch < end; ch++) {
        size_t lo_i = c->tri_count * ch / CHUNKS, hi_i = c->tri_count * (ch + 1) / CHUNKS;
        for (size_t i = lo_i; i < hi_i; i++) {
            int *out = c->boxes[i];
            out[0] = out[1] = 1, out[2] = out[3] = 0; /* none */
            const crisp_raster_tri *tri = &c->tris[i];
            if (tri->v[0] >= c->vert_count || tri->v[1] >= c->vert_count ||
                tri->v[2] >= c->vert_count)
                continue; /* draw refuses it */
            double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
            int inside = 1;
            for (int k = 0; k < 3 && inside; k++) { /* the common case: no clipping */
                const pvert *pv = &c->cache[tri->v[k]];
                inside &= pv->ok;
                lo[0] = pv->sx < lo[0] ? pv->sx : lo[0], hi[0] = pv->sx > hi[0] ? pv->sx : hi[0];
                lo[1] = pv->sy < lo[1] ? pv->sy : lo[1], hi[1] = pv->sy > hi[1] ? pv->sy : hi[1];
            }
            if (inside) {
                /* Hidden (tri_hidden, on setup_one's pixel box): setup_one drops it too. */
                const pvert *a = &c->cache[tri->v[0]], *b = &c->cache[tri->v[1]],
                            *d = &c->cache[tri->v[2]];
                int bb[4];
                if (tri_pixel_box(t, a, b, d, bb) &&
                    tri_hidden(c->r, t, a, b, d, c->cores ? &c->cores[i] : NULL, bb[0], bb[1],
                               bb[2], bb[3]))
                    continue;
            } else {
                cvert poly[MAX_POLY];
                for (int k = 0; k < 3; k++) {
                    const crisp_raster_vertex *sv = &c->verts[tri->v[k]];
                    memcpy(poly[k].p, sv->clip, 4 * sizeof(double));
                    memcpy(poly[k].p + 4, sv->attr, CRISP_RASTER_ATTRS * sizeof(double));
                }
                int m = clip_polygon(poly, 3, gx, gy);
                lo[0] = lo[1] = INFINITY, hi[0] = hi[1] = -INFINITY;
                for (int k = 0; k < m; k++) {
                    pvert pv;
                    if (!project(poly[k].p, t, &pv)) continue;
                    lo[0] = pv.sx < lo[0] ? pv.sx : lo[0], hi[0] = pv.sx > hi[0] ? pv.sx : hi[0];
                    lo[1] = pv.sy < lo[1] ? pv.sy : lo[1], hi[1] = pv.sy > hi[1] ? pv.sy : hi[1];
                }
            }
            if (!(lo[0] <= hi[0] && lo[1] <= hi[1])) continue;
            /* pixels of the target (the image's, less the window's corner) */
            int x0 = (int)floor(lo[0]) - 2 - t->x0, x1 = (int)floor(hi[0]) + 2 - t->x0;
            int y0 = (int)floor(lo[1]) - 2 - t->y0, y1 = (int)floor(hi[1]) + 2 - t->y0;
            out[0] = x0 > 0 ? x0 : 0, out[1] = y0 > 0 ? y0 : 0;
            out[2] = x1 < t->width - 1 ? x1 : t->width - 1;
            out[3] = y1 < t->height - 1 ? y1 : t->height - 1;
        }
    }
}

crisp_status crisp__raster_depth_slack_tris(crisp_raster *r, const crisp_raster_target *t,
                                            crisp_pool *pool, double scale,
                                            const crisp_raster_view *view,
                                            const crisp_raster_vertex *verts, size_t vert_count,
                                            const crisp_raster_tri *tris, size_t tri_count,
                                            float *slack)
{
    return crisp__raster_depth_slack2_tris(r, t, pool, scale, 0, view, verts, vert_count, tris,
                                           tri_count, NULL, slack, NULL);
}

crisp_status crisp__raster_depth_slack2_tris(crisp_raster *r, const crisp_raster_target *t,
                                             crisp_pool *pool, double scale, double scale2,
                                             const crisp_raster_view *view,
                                             const crisp_raster_vertex *verts, size_t vert_count,
                                             const crisp_raster_tri *tris, size_t tri_count,
                                             const crisp_raster_core *cores, float *slack,
                                             float *slack2)
{
    int tiles_x = (t->width + CELL - 1) / CELL, tiles_y = (t->height + CELL - 1) / CELL;
    size_t tiles = (size_t)tiles_x * tiles_y;
    crisp_status st = crisp_grow((void **)&r->tile_mask, &r->tile_mask_cap, tiles, 1);
    if (st) return st;
    memset(r->tile_mask, 0, tiles);
    if ((st = crisp_grow((void **)&r->tri_boxes, &r->tri_boxes_cap, tri_count ? tri_count : 1,
                         sizeof *r->tri_boxes)))
        return st;
    /* Each vertex projected once (as a draw does; kept for the draw that follows). */
    if ((st = crisp_grow((void **)&r->vcache, &r->vcache_cap, vert_count ? vert_count : 1,
                         sizeof *r->vcache)))
        return st;
    setup_ctx sc = {.r = r,
                    .t = t,
                    .verts = verts,
                    .vert_count = vert_count,
                    .gx = GUARD_PX / image_w(t),
                    .gy = GUARD_PX / image_h(t)};
    crisp_pool_parallel_for(pool, CHUNKS, 1, project_vertices, &sc);
    r->vcache_verts = verts, r->vcache_count = vert_count, r->vcache_t = t;
    box_ctx bc = {r, cores, t, r->vcache, verts, vert_count, tris, tri_count, r->tri_boxes};
    crisp_pool_parallel_for(pool, CHUNKS, 1, tri_boxes, &bc);
    for (size_t i = 0; i < tri_count; i++) {
        const int *b = r->tri_boxes[i];
        for (int ty = b[1] / CELL; ty <= b[3] / CELL && b[1] <= b[3]; ty++)
            for (int tx = b[0] / CELL; tx <= b[2] / CELL && b[0] <= b[2]; tx++)
                r->tile_mask[(size_t)ty * tiles_x + tx] = 1;
    }
    slack_ctx c = {t, view, scale, slack, scale2, slack2};
    slack_tiles_ctx tc = {&c, r->tile_mask, tiles_x, 0};
#if HAVE_AVX_TILES
    tc.avx2 = !r->no_vectors && !r->no_avx2 && __builtin_cpu_supports("avx2");
#endif
    crisp_pool_parallel_for(pool, tiles, 16, slack_tiles, &tc);
    return CRISP_OK;
}

static crisp_status draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                         const crisp_raster_vertex *verts, size_t vert_count,
                         const crisp_raster_tri *tris, size_t tri_count, crisp_raster_test_fn test,
                         void *test_ctx, const float *slack, const crisp_raster_core *cores,
                         const float *slack2, crisp_raster_stats *stats);

crisp_status crisp__raster_draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                                const crisp_raster_vertex *verts, size_t vert_count,
                                const crisp_raster_tri *tris, size_t tri_count,
                                crisp_raster_test_fn test, void *test_ctx,
                                crisp_raster_stats *stats)
{
    return draw(r, t, pool, verts, vert_count, tris, tri_count, test, test_ctx, NULL, NULL, NULL,
                stats);
}

crisp_status crisp__raster_draw_fill(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                                     const crisp_raster_vertex *verts, size_t vert_count,
                                     const crisp_raster_tri *tris, size_t tri_count,
                                     crisp_raster_test_fn test, void *test_ctx, const float *slack,
                                     crisp_raster_stats *stats)
{
    return draw(r, t, pool, verts, vert_count, tris, tri_count, test, test_ctx, slack, NULL, NULL,
                stats);
}

crisp_status crisp__raster_draw_fill2(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                                      const crisp_raster_vertex *verts, size_t vert_count,
                                      const crisp_raster_tri *tris, size_t tri_count,
                                      crisp_raster_test_fn test, void *test_ctx, const float *slack,
                                      const crisp_raster_core *cores, const float *slack2,
                                      crisp_raster_stats *stats)
{
    return draw(r, t, pool, verts, vert_count, tris, tri_count, test, test_ctx, slack, cores,
                slack2, stats);
}

typedef struct bin_ctx {
    crisp_raster *r;
    const setup_ctx *sc;
    int tiles_x;
    size_t tiles;
} bin_ctx;

static void bin_count(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const bin_ctx *b = vctx;
    const crisp_raster_target *t = b->sc->t;
    for (size_t ch = begin; ch < end; ch++) {
        uint32_t *cnt = b->r->bin_counts + ch * b->tiles;
        memset(cnt, 0, b->tiles * sizeof *cnt);
        for (size_t i = 0; i < b->sc->counts[ch]; i++) {
            const setup_tri *s = &b->r->chunk_tris[ch][i];
            /* tiles of the target (whose pixel 0, 0 is the image's x0, y0) */
            int tx0 = (s->x0 - t->x0) / TILE, tx1 = (s->x1 - t->x0) / TILE;
            for (int ty = (s->y0 - t->y0) / TILE; ty <= (s->y1 - t->y0) / TILE; ty++)
                for (int tx = tx0; tx <= tx1; tx++)
                    cnt[(size_t)ty * b->tiles_x + tx]++;
        }
    }
}

static void bin_fill(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const bin_ctx *b = vctx;
    const crisp_raster_target *t = b->sc->t;
    for (size_t ch = begin; ch < end; ch++) {
        uint32_t *next = b->r->bin_counts + ch * b->tiles; /* the chunk's offset in each tile */
        for (size_t i = 0; i < b->sc->counts[ch]; i++) {
            const setup_tri *s = &b->r->chunk_tris[ch][i];
            int tx0 = (s->x0 - t->x0) / TILE, tx1 = (s->x1 - t->x0) / TILE;
            for (int ty = (s->y0 - t->y0) / TILE; ty <= (s->y1 - t->y0) / TILE; ty++)
                for (int tx = tx0; tx <= tx1; tx++)
                    b->r->bin_items[next[(size_t)ty * b->tiles_x + tx]++] = s;
        }
    }
}

/* The first triangle of each chunk with a vertex index out of range (SIZE_MAX: none). */
typedef struct check_ctx {
    const crisp_raster_tri *tris;
    size_t tri_count, vert_count;
    size_t bad[CHUNKS];
} check_ctx;

static void check_chunk(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    check_ctx *c = vctx;
    for (size_t ch = begin; ch < end; ch++) {
        size_t lo = c->tri_count * ch / CHUNKS, hi = c->tri_count * (ch + 1) / CHUNKS;
        c->bad[ch] = SIZE_MAX;
        for (size_t i = lo; i < hi && c->bad[ch] == SIZE_MAX; i++)
            for (int k = 0; k < 3; k++)
                if (c->tris[i].v[k] >= c->vert_count) c->bad[ch] = i;
    }
}

static crisp_status draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                         const crisp_raster_vertex *verts, size_t vert_count,
                         const crisp_raster_tri *tris, size_t tri_count, crisp_raster_test_fn test,
                         void *test_ctx, const float *slack, const crisp_raster_core *cores,
                         const float *slack2, crisp_raster_stats *stats)
{
    check_ctx cc = {tris, tri_count, vert_count, {0}};
    crisp_pool_parallel_for(pool, CHUNKS, 1, check_chunk, &cc);
    for (int ch = 0; ch < CHUNKS; ch++)
        if (cc.bad[ch] != SIZE_MAX) {
            size_t i = cc.bad[ch];
            uint32_t v = tris[i].v[0] >= vert_count   ? tris[i].v[0]
                         : tris[i].v[1] >= vert_count ? tris[i].v[1]
                                                      : tris[i].v[2];
            return crisp_error(CRISP_ERR_INVALID_ARG, "triangle %zu uses vertex %u of %zu", i, v,
                               vert_count);
        }
    setup_ctx sc = {.r = r,
                    .t = t,
                    .verts = verts,
                    .vert_count = vert_count,
                    .tris = tris,
                    .test = test,
                    .test_ctx = test_ctx,
                    .cores = slack && slack2 ? cores : NULL,
                    .gx = GUARD_PX / image_w(t),
                    .gy = GUARD_PX / image_h(t)};
    crisp_status st = crisp_grow((void **)&r->vcache, &r->vcache_cap, vert_count ? vert_count : 1,
                                 sizeof *r->vcache);
    if (st) return st;
    if (!(r->vcache_verts == verts && r->vcache_count == vert_count && r->vcache_t == t))
        crisp_pool_parallel_for(pool, CHUNKS, 1, project_vertices, &sc);
    r->vcache_verts = NULL; /* kept for one draw only */

    int tiles_x = (t->width + TILE - 1) / TILE, tiles_y = (t->height + TILE - 1) / TILE;
    size_t tiles = (size_t)tiles_x * tiles_y; /* below 2^32: the target is at most 65536^2 */
    if ((st = crisp_grow((void **)&r->bin_start, &r->bin_start_cap, tiles + 1,
                         sizeof *r->bin_start)))
        return st;
    raster_ctx rc = {.r = r,
                     .t = t,
                     .tiles_x = tiles_x,
                     .test = test,
                     .test_ctx = test_ctx,
                     .slack = slack,
                     .slack2 = slack && cores ? slack2 : NULL,
                     .hiz = !r->no_hiz,
                     .vectors = !r->no_vectors};
#if HAVE_AVX_TILES
    rc.avx = !r->no_vectors && __builtin_cpu_supports("avx")
                 ? (!r->no_avx2 && __builtin_cpu_supports("avx2") ? 2 : 1)
                 : 0;
#endif
#if HAVE_AVX512_TILES
    if (rc.avx == 2 && !r->no_avx512 && avx512_tiles()) rc.avx = 3;
#endif
    for (int s = 0; s < t->samples; s++) {
        double off[2];
        crisp__raster_sample_offset(t->samples, s, off);
        rc.off_x[s] = off[0];
        rc.off_y[s] = off[1];
        rc.off_xmin = s == 0 || off[0] < rc.off_xmin ? off[0] : rc.off_xmin;
        rc.off_xmax = s == 0 || off[0] > rc.off_xmax ? off[0] : rc.off_xmax;
        rc.off_ymin = s == 0 || off[1] < rc.off_ymin ? off[1] : rc.off_ymin;
        rc.off_ymax = s == 0 || off[1] > rc.off_ymax ? off[1] : rc.off_ymax;
        rc.off_fx[s] = llround(off[0] * SUB);
        rc.off_fy[s] = llround(off[1] * SUB);
        for (int q = 0; q < 2; q++) {
            int64_t o = q ? rc.off_fy[s] : rc.off_fx[s];
            rc.off_fmin[q] = s == 0 || o < rc.off_fmin[q] ? o : rc.off_fmin[q];
            rc.off_fmax[q] = s == 0 || o > rc.off_fmax[q] ? o : rc.off_fmax[q];
        }
    }
    /* Batches of triangles, one after the other (submission order is kept): set-up records and
     * bins hold one batch, so the rasterizer's memory is bounded whatever the triangle count. */
    size_t total = 0, batch = r->batch ? r->batch : BATCH;
    if (r->live) {
        if ((st = crisp_grow((void **)&r->live_tile, &r->live_tile_cap, tiles, 1))) return st;
        if (t->clear_pending) memset(r->live_tile, 0, tiles); /* each set as its tile clears */
        if (BLOCK % r->live_size == 0) rc.live = r->live, rc.live_size = r->live_size;
    }
    if (t->clear_pending && tri_count) { /* each tile clears itself (the first batch's) */
        if ((st = crisp_grow((void **)&t->pending, &t->pending_cap, tiles, 1))) return st;
        memset(t->pending, 1, tiles);
        t->clear_pending = 0, t->tiles_pending = 1;
    }
    rc.pending = t->tiles_pending ? t->pending : NULL;
    rc.defer = r->defer_clear;
    for (size_t first = 0; first < tri_count; first += batch) {
        sc.first = first;
        sc.count = tri_count - first < batch ? tri_count - first : batch;
        crisp_pool_parallel_for(pool, CHUNKS, 1, setup_chunk, &sc);
        size_t n = 0;
        for (int ch = 0; ch < CHUNKS; ch++) {
            if (sc.status[ch]) return sc.status[ch];
            n += sc.counts[ch];
        }
        total += n;
        /* Bin in submission order: entries per setup chunk and tile (in parallel), offsets per
         * tile in chunk order, fill (in parallel): each tile lists its triangles as the input
         * did. */
        if ((st = crisp_grow((void **)&r->bin_counts, &r->bin_counts_cap, CHUNKS * tiles,
                             sizeof *r->bin_counts)))
            return st;
        bin_ctx bc = {r, &sc, tiles_x, tiles};
        crisp_pool_parallel_for(pool, CHUNKS, 1, bin_count, &bc);
        size_t items = 0;
        for (size_t k = 0; k < tiles; k++) {
            r->bin_start[k] = (uint32_t)items;
            for (int ch = 0; ch < CHUNKS; ch++) {
                uint32_t n_ch = r->bin_counts[(size_t)ch * tiles + k];
                r->bin_counts[(size_t)ch * tiles + k] = (uint32_t)items;
                items += n_ch;
            }
            if (items > UINT32_MAX)
                return crisp_error(CRISP_ERR_LIMIT, "%zu tile entries: the limit is 2^32", items);
        }
        r->bin_start[tiles] = (uint32_t)items;
        if ((st = crisp_grow((void **)&r->bin_items, &r->bin_cap, items ? items : 1,
                             sizeof *r->bin_items)))
            return st;
        crisp_pool_parallel_for(pool, CHUNKS, 1, bin_fill, &bc);
        crisp__raster_share_init(&rc.share, tiles, crisp_pool_threads(pool));
        crisp_pool_parallel_for(pool, (size_t)rc.share.ranges, 1, raster_tiles, &rc);
    }
    if (rc.pending) { /* the tiles left pending (deferred ones only) */
        t->tiles_pending = 0;
        for (size_t k = 0; k < tiles && !t->tiles_pending; k++)
            t->tiles_pending = t->pending[k];
    }
    if (t->clear_pending) { /* no triangles: clear anyway */
        clear_now(t, pool);
        t->clear_pending = 0;
        if (r->live && r->live_compute) { /* every block empty */
            size_t blocks = (size_t)((t->width + r->live_size - 1) / r->live_size) *
                            (size_t)((t->height + r->live_size - 1) / r->live_size);
            memset(r->live, 0, blocks * sizeof *r->live);
            memset(r->live_tile, 1, tiles);
        }
    }
    if (stats) {
        *stats = (crisp_raster_stats){.triangles_in = tri_count,
                                      .triangles_setup = total,
                                      .fragments_tested = atomic_load(&rc.tested),
                                      .fragments_discarded = atomic_load(&rc.discarded),
                                      .fragments_untested = atomic_load(&rc.untested),
                                      .blocks_skipped = atomic_load(&rc.blocks_skipped),
                                      .fragments_boxed = atomic_load(&rc.boxed)};
    }
    return CRISP_OK;
}
