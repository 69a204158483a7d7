/* Occlusion culling for the CPU backend (issue 12; see occlusion.h). The classic hierarchical
 * depth test (Greene, Kass & Miller, "Hierarchical Z-buffer visibility", SIGGRAPH 1993) at one
 * level, applied to a leaf's conservative bounds before it is tessellated: the leaves are drawn in
 * a few batches, nearest first, and before a batch is tessellated each of its leaves is compared
 * with the farthest depth drawn so far in every 4x4 block its samples can reach
 * (crisp__raster_block_depth; a block counts only where every sample has been written). A leaf's
 * triangles are surface points' triangles: inside its projected control hull (positive weights),
 * so their 1/W is at most the hull's largest 1/W, and their samples lie in its screen box widened
 * by the snapping. A leaf whose largest 1/W is below every one of its blocks' least 1/W has no
 * fragment that passes the depth test (nearer = larger 1/W wins, and later draws only raise the
 * stored values), so dropping it leaves every sample as it was. Trimmed-away and clipped
 * fragments write nothing, so only written samples count; the ribbons are drawn after the
 * surfaces from the same target, so they see the same depth. */
#include "occlusion.h"

#include <math.h>
#include <string.h>

#define KEYS 4096      /* depth buckets of the batch split */
#define MIN_BATCH 8192 /* triangles */

/* Where the batches end: cumulative shares of the triangles, nearest first. */
static const double batch_end[CRISP_OCCL_BATCHES - 1] = {0.03, 0.08, 0.18, 0.35, 0.6};

/* floor(x) without the libm call (it was most of crisp__occl_set, which the splat draw calls
 * for every range in every band: 13,573 ranges at imp49 far): truncation corrected below zero
 * where the integer conversion is exact, the library elsewhere (infinite or huge boxes). */
static inline double floor_fast(double x)
{
    if (!(x > -4.0e15 && x < 4.0e15)) return floor(x);
    double t = (double)(int64_t)x;
    return t > x ? t - 1 : t;
}

void crisp__occl_set(crisp_occl_leaf *o, const int win[4], const double lo[2], const double hi[2],
                     double iw)
{
    double b[4];
    for (int q = 0; q < 2; q++) {
        double n = win[2 + q] - 1;
        double x0 = floor_fast(lo[q]) - 1 - win[q], x1 = floor_fast(hi[q]) - win[q];
        b[q] = x0 > 0 ? (x0 < n ? x0 : n) : 0;
        b[2 + q] = x1 > 0 ? (x1 < n ? x1 : n) : 0;
    }
    o->bx0 = (uint16_t)((int)b[0] / CRISP_OCCL_BLOCK),
    o->by0 = (uint16_t)((int)b[1] / CRISP_OCCL_BLOCK);
    o->bx1 = (uint16_t)((int)b[2] / CRISP_OCCL_BLOCK),
    o->by1 = (uint16_t)((int)b[3] / CRISP_OCCL_BLOCK);
    /* Rounded up to a float, with a relative margin of 2^-10: a covered sample may lie up to
     * 1/512 px outside its triangle's unsnapped position while its 1/W comes from the unsnapped
     * plane, which moves it beyond the vertices' range by about 3e-6 / sin(angle between the
     * view ray and the triangle) relative at 1080p; the margin covers triangles more than about
     * 0.2 degrees from edge-on, and rounding. */
    double m = iw * (1.0 + 1.0 / 1024);
    if (!(m > 0 && m < 3.0e38)) {
        o->iw = INFINITY;
        return;
    }
    float f = (float)m; /* positive, below FLT_MAX: the next float up is its bits plus one */
    if ((double)f < m) {
        uint32_t bits;
        memcpy(&bits, &f, sizeof bits);
        bits++;
        memcpy(&f, &bits, sizeof f);
    }
    o->iw = f;
}

int crisp__occl_point_seen(const double *hiz, int blocks_x, int blocks_y, double x, double y,
                           double iw)
{
    if (!(x >= 0 && y >= 0 && x < (double)blocks_x * CRISP_OCCL_BLOCK &&
          y < (double)blocks_y * CRISP_OCCL_BLOCK))
        return 0;
    int bx = (int)x / CRISP_OCCL_BLOCK, by = (int)y / CRISP_OCCL_BLOCK;
    return iw >= hiz[(size_t)by * blocks_x + bx];
}

size_t crisp__occl_order(const crisp_occl_leaf *occl, const uint8_t *skip, const uint32_t *tris,
                         size_t count, uint32_t *order, uint32_t bstart[CRISP_OCCL_BATCHES + 1])
{
    size_t bad = SIZE_MAX;
    if (!occl) {
        size_t n = 0;
        for (size_t j = 0; j < count; j++) {
            if (skip[j]) continue;
            if (tris[j] == UINT32_MAX && bad == SIZE_MAX) bad = j;
            order[n++] = (uint32_t)j;
        }
        bstart[0] = 0;
        for (int b = 1; b <= CRISP_OCCL_BATCHES; b++)
            bstart[b] = (uint32_t)n;
        return bad;
    }
    /* The range of the finite 1/W bounds; then the triangles per bucket of it (linear in 1/W:
     * finer where it is near), nearest bucket last; leaves never culled go first. */
    float lo = INFINITY, hi = 0;
    for (size_t j = 0; j < count; j++) {
        if (skip[j]) continue;
        if (tris[j] == UINT32_MAX && bad == SIZE_MAX) bad = j;
        float iw = occl[j].iw;
        if (iw < INFINITY) lo = iw < lo ? iw : lo, hi = iw > hi ? iw : hi;
    }
    if (bad != SIZE_MAX) return bad;
    double scale = hi > lo ? (KEYS - 2) / ((double)hi - lo) : 0;
#define KEY(j)                                                                                     \
    (occl[j].iw < INFINITY ? (size_t)(((double)occl[j].iw - lo) * scale) : (size_t)(KEYS - 1))
    uint64_t hist[KEYS] = {0}, total = 0;
    for (size_t j = 0; j < count; j++) {
        if (skip[j]) continue;
        hist[KEY(j)] += tris[j];
        total += tris[j];
    }
    /* A batch ends where the triangles seen reach its share, and holds at least MIN_BATCH of
     * them (a draw has a fixed cost: small scenes are drawn in fewer batches, or one). */
    uint8_t batch_of[KEYS];
    uint64_t seen = 0, since = 0;
    int b = 0;
    for (size_t k = KEYS; k-- > 0;) {
        batch_of[k] = (uint8_t)b;
        seen += hist[k];
        since += hist[k];
        if (b < CRISP_OCCL_BATCHES - 1 && since >= MIN_BATCH &&
            (double)seen >= batch_end[b] * (double)total) {
            while (b < CRISP_OCCL_BATCHES - 1 && (double)seen >= batch_end[b] * (double)total)
                b++;
            since = 0;
        }
    }
    size_t start[CRISP_OCCL_BATCHES] = {0};
    for (size_t j = 0; j < count; j++)
        if (!skip[j]) start[batch_of[KEY(j)]]++;
    size_t at = 0;
    for (b = 0; b < CRISP_OCCL_BATCHES; b++) {
        size_t n = start[b];
        bstart[b] = (uint32_t)at;
        start[b] = at;
        at += n;
    }
    bstart[CRISP_OCCL_BATCHES] = (uint32_t)at;
    for (size_t j = 0; j < count; j++)
        if (!skip[j]) order[start[batch_of[KEY(j)]]++] = (uint32_t)j;
#undef KEY
    return SIZE_MAX;
}

int crisp__occl_hidden(const crisp_occl_leaf *o, const double *hiz, int blocks_x)
{
    double iw = o->iw;
    if (!(iw < INFINITY)) return 0;
    for (int by = o->by0; by <= o->by1; by++) {
        const double *row = hiz + (size_t)by * (size_t)blocks_x;
        for (int bx = o->bx0; bx <= o->bx1; bx++)
            if (!(iw < row[bx])) return 0;
    }
    return 1;
}

typedef struct cull_ctx {
    const crisp_occl_leaf *occl;
    const uint32_t *list;
    const double *hiz;
    int blocks_x;
    uint8_t *skip;
} cull_ctx;

static void cull_range(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const cull_ctx *c = vctx;
    for (size_t i = begin; i < end; i++) {
        uint32_t j = c->list[i];
        if (crisp__occl_hidden(&c->occl[j], c->hiz, c->blocks_x)) c->skip[j] = 2;
    }
}

void crisp__occl_cull(crisp_pool *pool, const crisp_occl_leaf *occl, const uint32_t *list,
                      size_t count, const double *hiz, int blocks_x, uint8_t *skip)
{
    cull_ctx c = {occl, list, hiz, blocks_x, skip};
    crisp_pool_parallel_for(pool, count, 256, cull_range, &c);
}
