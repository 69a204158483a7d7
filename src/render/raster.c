/* The CPU rasterizer (see raster.h): homogeneous clipping, fixed-point setup with a top-left
 * rule, order-preserving tile binning and per-tile parallel rasterisation. */
#include "raster.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#define TILE 64
#define SUB (1 << CRISP_RASTER_SUBPIXEL_BITS)
#define CHUNKS 64 /* setup work units; fixed so the output order never depends on threads */
#define GUARD_PX                                                                                   \
    1048576.0 /* screen coordinates stay within +-2^20 px: exact int64 edge functions */
#define MAX_POLY 12

typedef struct setup_tri {
    int64_t x[3], y[3]; /* fixed point, counter-clockwise in the (x right, y down) frame */
    int64_t bias[3];    /* 0 for edges that own their samples (top-left rule), else -1 */
    /* 1/W and attribute/W as planes over the unsnapped screen position: value at (ox, oy) and
     * gradients. Snapping moves coverage by at most 1/512 px but not the interpolated values. */
    double ox, oy;
    double q0[1 + CRISP_RASTER_ATTRS], qx[1 + CRISP_RASTER_ATTRS], qy[1 + CRISP_RASTER_ATTRS];
    int x0, y0, x1, y1; /* pixel bbox, inclusive, clamped to the image */
    uint32_t face;
} setup_tri;

#define BATCH ((size_t)1 << 19) /* input triangles set up and binned at a time */

typedef struct pvert pvert;

struct crisp_raster {
    setup_tri *chunk_tris[CHUNKS]; /* set-up triangles of the current batch, per setup chunk */
    size_t chunk_cap[CHUNKS];
    pvert *vcache; /* per vertex, screen-space form */
    size_t vcache_cap;
    size_t batch; /* 0: BATCH (crisp__raster_set_batch, for tests) */
    const setup_tri **bin_items;
    size_t bin_cap;
    uint32_t *bin_start; /* per tile, tile_count + 1 */
    size_t bin_start_cap;
    int no_hiz;              /* hierarchical depth rejection off (crisp__raster_set_hiz) */
    const uint8_t *untested; /* per face (crisp__raster_set_untested_faces) */
    size_t untested_count;
    int clip_on;    /* crisp__raster_set_clip */
    double clip[4]; /* keep k0 + k1 x + k2 y + k3 / W >= 0 */
};

void crisp__raster_set_clip(crisp_raster *r, const double k[4])
{
    r->clip_on = k != NULL;
    for (int i = 0; i < 4; i++)
        r->clip[i] = k ? k[i] : 0;
}

void crisp__raster_set_untested_faces(crisp_raster *r, const uint8_t *untested, size_t count)
{
    r->untested = untested;
    r->untested_count = untested ? count : 0;
}

void crisp__raster_set_hiz(crisp_raster *r, int on)
{
    r->no_hiz = !on;
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
    free(r);
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
    t->inv_w = crisp_malloc_array(n, sizeof *t->inv_w);
    t->attr = crisp_malloc_array(n, CRISP_RASTER_ATTRS * sizeof *t->attr);
    t->face = crisp_malloc_array(n, sizeof *t->face);
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

void crisp__raster_target_free(crisp_raster_target *t)
{
    free(t->inv_w);
    free(t->attr);
    free(t->face);
    memset(t, 0, sizeof *t);
}

void crisp__raster_target_clear(crisp_raster_target *t)
{
    size_t n = (size_t)t->width * t->height * t->samples;
    memset(t->inv_w, 0, n * sizeof *t->inv_w);
    memset(t->attr, 0, n * CRISP_RASTER_ATTRS * sizeof *t->attr);
    memset(t->face, 0xff, n * sizeof *t->face);
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

/* 0 when the vertex cannot be set up (W <= 0, beyond the guard band or not finite). */
static int project(const double *p, const crisp_raster_target *t, pvert *out)
{
    double w = p[3];
    if (!(w > 0)) return 0;
    out->sx = (p[0] / w + 1.0) * 0.5 * t->width;
    out->sy = (1.0 - p[1] / w) * 0.5 * t->height;
    if (!(fabs(out->sx) <= 2 * GUARD_PX && fabs(out->sy) <= 2 * GUARD_PX)) return 0;
    out->fx = llround(out->sx * SUB);
    out->fy = llround(out->sy * SUB);
    double iw = 1.0 / w;
    out->val[0] = iw;
    for (int q = 1; q <= CRISP_RASTER_ATTRS; q++)
        out->val[q] = p[3 + q] * iw;
    return 1;
}

typedef struct {
    crisp_raster *r;
    const crisp_raster_target *t;
    const crisp_raster_vertex *verts;
    size_t vert_count;
    const crisp_raster_tri *tris;
    size_t first, count; /* the batch */
    double gx, gy;
    size_t counts[CHUNKS];
    crisp_status status[CHUNKS];
} setup_ctx;

/* Sets up one triangle into *out; returns 0 when it covers no sample area (degenerate or off
 * the image). */
static int setup_one(const setup_ctx *c, const pvert *a, const pvert *b, const pvert *d,
                     uint32_t face, setup_tri *out)
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
    double minx = 1e300, miny = 1e300, maxx = -1e300, maxy = -1e300;
    for (int k = 0; k < 3; k++) {
        int i = order[k];
        out->x[k] = v[i]->fx;
        out->y[k] = v[i]->fy;
        minx = fmin(minx, (double)v[i]->fx / SUB);
        maxx = fmax(maxx, (double)v[i]->fx / SUB);
        miny = fmin(miny, (double)v[i]->fy / SUB);
        maxy = fmax(maxy, (double)v[i]->fy / SUB);
    }
    /* Samples sit at i + offset with offset in [0, 1): pixels floor(min) - 1 .. floor(max). */
    out->x0 = (int)fmax(0, floor(minx) - 1);
    out->y0 = (int)fmax(0, floor(miny) - 1);
    out->x1 = (int)fmin(t->width - 1, floor(maxx));
    out->y1 = (int)fmin(t->height - 1, floor(maxy));
    if (!(out->x0 <= out->x1 && out->y0 <= out->y1)) return 0;
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
    for (int k = 0; k < 3; k++) {
        int a0 = (k + 1) % 3, a1 = (k + 2) % 3;
        int64_t dx = out->x[a1] - out->x[a0], dy = out->y[a1] - out->y[a0];
        out->bias[k] = (dy < 0 || (dy == 0 && dx > 0)) ? 0 : -1;
    }
    out->face = face;
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
            double full[4 + CRISP_RASTER_ATTRS];
            memcpy(full, p, 4 * sizeof(double));
            memcpy(full + 4, c->verts[i].attr, CRISP_RASTER_ATTRS * sizeof(double));
            cache[i].ok = inside && project(full, c->t, &cache[i]);
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
            if (a->ok && b->ok && d->ok) {
                n += (size_t)setup_one(c, a, b, d, tri->face, &out[n]);
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
                    n += (size_t)setup_one(c, &pv[0], &pv[k], &pv[k + 1], tri->face, &out[n]);
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
    double off_x[16], off_y[16];
    const float *slack; /* fill mode (crisp__raster_draw_fill) when not NULL */
    int hiz;            /* hierarchical depth rejection on */
    atomic_size_t tested, discarded, untested, blocks_skipped;
} raster_ctx;

/* Least 1/W over the block's samples (0 when one is empty). */
static double block_min(const crisp_raster_target *t, int bx0, int by0, int bx1, int by1)
{
    int S = t->samples;
    double m = INFINITY;
    for (int j = by0; j <= by1; j++) {
        const double *row = t->inv_w + ((size_t)j * t->width + bx0) * S;
        size_t n = (size_t)(bx1 - bx0 + 1) * S;
        for (size_t k = 0; k < n; k++)
            m = row[k] < m ? row[k] : m;
    }
    return m;
}

static void raster_tile(raster_ctx *c, size_t tile, int worker)
{
    crisp_raster *r = c->r;
    crisp_raster_target *t = c->t;
    int tx = (int)(tile % (size_t)c->tiles_x), ty = (int)(tile / (size_t)c->tiles_x);
    int px0 = tx * TILE, py0 = ty * TILE;
    int px1 = px0 + TILE - 1 < t->width - 1 ? px0 + TILE - 1 : t->width - 1;
    int py1 = py0 + TILE - 1 < t->height - 1 ? py0 + TILE - 1 : t->height - 1;
    int S = t->samples;
    size_t tested = 0, discarded = 0, untested = 0, skipped = 0;
    /* Per block: a lower bound of its least 1/W. Writes only raise stored 1/W (outside fill mode,
     * which does not use it), so a bound stays valid; it is recomputed from the samples once as
     * many writes as the block has samples happened since (amortised: one scan per block's worth
     * of writes). */
    double hiz[BLOCKS * BLOCKS];
    uint32_t writes[BLOCKS * BLOCKS];
    uint32_t block_samples = (uint32_t)(BLOCK * BLOCK * S);
    for (int k = 0; k < BLOCKS * BLOCKS; k++)
        hiz[k] = 0, writes[k] = block_samples;
    int use_hiz = c->hiz && !c->slack;
    for (uint32_t bi = r->bin_start[tile]; bi < r->bin_start[tile + 1]; bi++) {
        const setup_tri *st = r->bin_items[bi];
        int x0 = st->x0 > px0 ? st->x0 : px0, x1 = st->x1 < px1 ? st->x1 : px1;
        int y0 = st->y0 > py0 ? st->y0 : py0, y1 = st->y1 < py1 ? st->y1 : py1;
        int32_t face_id =
            (int32_t)(st->face & ~(CRISP_RASTER_FACE_FLAG | CRISP_RASTER_FACE_NO_TEST));
        int run_test = c->test && !(st->face & CRISP_RASTER_FACE_NO_TEST) &&
                       !((size_t)face_id < r->untested_count && r->untested[face_id]);
        /* Edge k: E = A (px - x_a0) + B (py - y_a0), stepped by A * SUB per pixel. */
        int64_t A[3], B[3], step[3];
        for (int k = 0; k < 3; k++) {
            int a0 = (k + 1) % 3, a1 = (k + 2) % 3;
            A[k] = -(st->y[a1] - st->y[a0]);
            B[k] = st->x[a1] - st->x[a0];
            step[k] = A[k] * SUB;
        }
        /* Rounding allowance of the 1/W plane evaluated at a block corner (see the hi-z test). */
        double slop = 1e-12 * (fabs(st->q0[0]) +
                               fabs(st->qx[0]) * (fabs(x0 - st->ox) + fabs(x1 + 1 - st->ox)) +
                               fabs(st->qy[0]) * (fabs(y0 - st->oy) + fabs(y1 + 1 - st->oy)));
        for (int by0 = y0; by0 <= y1; by0 = (by0 / BLOCK + 1) * BLOCK) {
            int by1 = (by0 / BLOCK + 1) * BLOCK - 1 < y1 ? (by0 / BLOCK + 1) * BLOCK - 1 : y1;
            for (int bx0 = x0; bx0 <= x1; bx0 = (bx0 / BLOCK + 1) * BLOCK) {
                int bx1 = (bx0 / BLOCK + 1) * BLOCK - 1 < x1 ? (bx0 / BLOCK + 1) * BLOCK - 1 : x1;
                int blk = ((by0 - py0) / BLOCK) * BLOCKS + (bx0 - px0) / BLOCK;
                if (use_hiz && (bx1 - bx0 + 1) * (by1 - by0 + 1) >= HIZ_MIN_PX) {
                    if (writes[blk] >= block_samples) {
                        int gx = px0 + (bx0 - px0) / BLOCK * BLOCK,
                            gy = py0 + (by0 - py0) / BLOCK * BLOCK;
                        int gx1 = gx + BLOCK - 1 < px1 ? gx + BLOCK - 1 : px1;
                        int gy1 = gy + BLOCK - 1 < py1 ? gy + BLOCK - 1 : py1;
                        hiz[blk] = block_min(t, gx, gy, gx1, gy1);
                        writes[blk] = 0;
                    }
                    /* The triangle's largest 1/W over the block's rectangle (an affine function:
                     * at a corner). No sample of it can pass the depth test when that is not
                     * above every stored value. */
                    double best = -INFINITY;
                    for (int cy = 0; cy < 2; cy++)
                        for (int cx = 0; cx < 2; cx++) {
                            double dx = (cx ? bx1 + 1 : bx0) - st->ox,
                                   dy = (cy ? by1 + 1 : by0) - st->oy;
                            double v = st->q0[0] + st->qx[0] * dx + st->qy[0] * dy;
                            best = v > best ? v : best;
                        }
                    if (best + slop < hiz[blk]) {
                        skipped++;
                        continue;
                    }
                }
                uint32_t wrote = 0;
                /* Edge values at the block's first pixel of each sample, stepped by rows. */
                int64_t er[16][3];
                for (int s = 0; s < S; s++) {
                    int64_t px = (int64_t)bx0 * SUB + c->off_fx[s],
                            py = (int64_t)by0 * SUB + c->off_fy[s];
                    for (int k = 0; k < 3; k++) {
                        int a0 = (k + 1) % 3;
                        er[s][k] = A[k] * (px - st->x[a0]) + B[k] * (py - st->y[a0]) + st->bias[k];
                    }
                }
                for (int j = by0; j <= by1; j++)
                    for (int s = 0; s < S; s++) {
                        /* Coverage, 1/W and the depth test of the block's row for this sample,
                         * in loops over at most BLOCK lanes without branches (vectorisable). */
                        int64_t e[3] = {er[s][0], er[s][1], er[s][2]};
                        for (int k = 0; k < 3; k++)
                            er[s][k] += B[k] * SUB;
                        int n = bx1 - bx0 + 1;
                        double dy = j + c->off_y[s] - st->oy;
                        double base = st->q0[0] + st->qy[0] * dy, gx = st->qx[0];
                        double dx0 = (double)bx0 + c->off_x[s] - st->ox;
                        size_t idx0 = ((size_t)j * t->width + (size_t)bx0) * S + s;
                        double iwv[BLOCK];
                        int cov[BLOCK], pass[BLOCK], np = 0, any = 0;
                        for (int q = 0; q < n; q++) {
                            cov[q] = (e[0] | e[1] | e[2]) >= 0;
                            any |= cov[q];
                            e[0] += step[0], e[1] += step[1], e[2] += step[2];
                        }
                        if (!any) continue;
                        for (int q = 0; q < n; q++)
                            iwv[q] = base + gx * (dx0 + q);
                        if (c->slack) {
                            for (int q = 0; q < n; q++) {
                                double cur = t->inv_w[idx0 + (size_t)q * S];
                                if (cov[q] &&
                                    (!(cur > 0) ||
                                     1.0 / iwv[q] < 1.0 / cur - c->slack[idx0 + (size_t)q * S]))
                                    pass[np++] = q;
                            }
                        } else {
                            for (int q = 0; q < n; q++)
                                if (cov[q] && iwv[q] > t->inv_w[idx0 + (size_t)q * S])
                                    pass[np++] = q;
                        }
                        for (int pi = 0; pi < np; pi++) {
                            int q = pass[pi];
                            size_t idx = idx0 + (size_t)q * S;
                            double iw = iwv[q], dx = dx0 + q;
                            if (r->clip_on && r->clip[0] + r->clip[1] * (dx + st->ox) +
                                                      r->clip[2] * (dy + st->oy) + r->clip[3] * iw <
                                                  0)
                                continue; /* on the clipped side of the plane */
                            double a[CRISP_RASTER_ATTRS];
                            double w = 1.0 / iw;
                            for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
                                a[k] =
                                    (st->q0[k + 1] + st->qx[k + 1] * dx + st->qy[k + 1] * dy) * w;
                            if (run_test) {
                                tested++;
                                if (!c->test(c->test_ctx, st->face, a[0], a[1])) {
                                    discarded++;
                                    continue;
                                }
                            } else if (c->test) {
                                untested++;
                            }
                            t->inv_w[idx] = iw;
                            t->face[idx] = face_id;
                            float *dst = t->attr + idx * CRISP_RASTER_ATTRS;
                            for (int k = 0; k < CRISP_RASTER_ATTRS; k++)
                                dst[k] = (float)a[k];
                            wrote++;
                        }
                    }
                writes[blk] += wrote;
            }
        }
    }
    (void)worker;
    atomic_fetch_add(&c->tested, tested);
    atomic_fetch_add(&c->discarded, discarded);
    atomic_fetch_add(&c->untested, untested);
    atomic_fetch_add(&c->blocks_skipped, skipped);
}

static void raster_tiles(void *vctx, size_t begin, size_t end, int worker)
{
    for (size_t tile = begin; tile < end; tile++)
        raster_tile(vctx, tile, worker);
}

typedef struct slack_ctx {
    const crisp_raster_target *t;
    const crisp_raster_view *view;
    double scale;
    float *slack;
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
    int S = t->samples, w = t->width, h = t->height;
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
                int side = seen_side(c->view, w, h, i, j, t->attr + idx * CRISP_RASTER_ATTRS);
                if (own_j && i + 1 < w && t->face[idx + S] == f &&
                    seen_side(c->view, w, h, i + 1, j, t->attr + (idx + S) * CRISP_RASTER_ATTRS) ==
                        side) {
                    float d = (float)(c->scale * fabs(1.0 / t->inv_w[idx + S] - W));
                    if (d > slack[idx]) slack[idx] = d;
                    if (d > slack[idx + S]) slack[idx + S] = d;
                }
                if (j + 1 < h && t->face[idx + rs] == f &&
                    seen_side(c->view, w, h, i, j + 1, t->attr + (idx + rs) * CRISP_RASTER_ATTRS) ==
                        side) {
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
    slack_ctx c = {t, view, scale, slack};
    crisp_pool_parallel_for(pool, (size_t)t->height, 16, slack_rows, &c);
}

static crisp_status draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                         const crisp_raster_vertex *verts, size_t vert_count,
                         const crisp_raster_tri *tris, size_t tri_count, crisp_raster_test_fn test,
                         void *test_ctx, const float *slack, crisp_raster_stats *stats);

crisp_status crisp__raster_draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                                const crisp_raster_vertex *verts, size_t vert_count,
                                const crisp_raster_tri *tris, size_t tri_count,
                                crisp_raster_test_fn test, void *test_ctx,
                                crisp_raster_stats *stats)
{
    return draw(r, t, pool, verts, vert_count, tris, tri_count, test, test_ctx, NULL, stats);
}

crisp_status crisp__raster_draw_fill(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                                     const crisp_raster_vertex *verts, size_t vert_count,
                                     const crisp_raster_tri *tris, size_t tri_count,
                                     crisp_raster_test_fn test, void *test_ctx, const float *slack,
                                     crisp_raster_stats *stats)
{
    return draw(r, t, pool, verts, vert_count, tris, tri_count, test, test_ctx, slack, stats);
}

static crisp_status draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                         const crisp_raster_vertex *verts, size_t vert_count,
                         const crisp_raster_tri *tris, size_t tri_count, crisp_raster_test_fn test,
                         void *test_ctx, const float *slack, crisp_raster_stats *stats)
{
    for (size_t i = 0; i < tri_count; i++)
        for (int k = 0; k < 3; k++)
            if (tris[i].v[k] >= vert_count)
                return crisp_error(CRISP_ERR_INVALID_ARG, "triangle %zu uses vertex %u of %zu", i,
                                   tris[i].v[k], vert_count);
    setup_ctx sc = {.r = r,
                    .t = t,
                    .verts = verts,
                    .vert_count = vert_count,
                    .tris = tris,
                    .gx = GUARD_PX / t->width,
                    .gy = GUARD_PX / t->height};
    crisp_status st = crisp_grow((void **)&r->vcache, &r->vcache_cap, vert_count ? vert_count : 1,
                                 sizeof *r->vcache);
    if (st) return st;
    crisp_pool_parallel_for(pool, CHUNKS, 1, project_vertices, &sc);

    int tiles_x = (t->width + TILE - 1) / TILE, tiles_y = (t->height + TILE - 1) / TILE;
    size_t tiles = (size_t)tiles_x * tiles_y;
    if ((st = crisp_grow((void **)&r->bin_start, &r->bin_start_cap, tiles + 1,
                         sizeof *r->bin_start)))
        return st;
    raster_ctx rc = {.r = r,
                     .t = t,
                     .tiles_x = tiles_x,
                     .test = test,
                     .test_ctx = test_ctx,
                     .slack = slack,
                     .hiz = !r->no_hiz};
    for (int s = 0; s < t->samples; s++) {
        double off[2];
        crisp__raster_sample_offset(t->samples, s, off);
        rc.off_x[s] = off[0];
        rc.off_y[s] = off[1];
        rc.off_fx[s] = llround(off[0] * SUB);
        rc.off_fy[s] = llround(off[1] * SUB);
    }
    /* Batches of triangles, one after the other (submission order is kept): set-up records and
     * bins hold one batch, so the rasterizer's memory is bounded whatever the triangle count. */
    size_t total = 0, batch = r->batch ? r->batch : BATCH;
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
        /* Bin in submission order: count per tile, prefix sums, fill. */
        memset(r->bin_start, 0, (tiles + 1) * sizeof *r->bin_start);
        size_t items = 0;
        for (int ch = 0; ch < CHUNKS; ch++)
            for (size_t i = 0; i < sc.counts[ch]; i++) {
                const setup_tri *s = &r->chunk_tris[ch][i];
                for (int ty = s->y0 / TILE; ty <= s->y1 / TILE; ty++)
                    for (int tx = s->x0 / TILE; tx <= s->x1 / TILE; tx++)
                        r->bin_start[(size_t)ty * tiles_x + tx + 1]++;
                items += (size_t)(s->y1 / TILE - s->y0 / TILE + 1) *
                         (size_t)(s->x1 / TILE - s->x0 / TILE + 1);
            }
        if (items > UINT32_MAX)
            return crisp_error(CRISP_ERR_LIMIT, "%zu tile entries: the limit is 2^32", items);
        for (size_t k = 0; k < tiles; k++)
            r->bin_start[k + 1] += r->bin_start[k];
        if ((st = crisp_grow((void **)&r->bin_items, &r->bin_cap, items ? items : 1,
                             sizeof *r->bin_items)))
            return st;
        for (int ch = 0; ch < CHUNKS; ch++)
            for (size_t i = 0; i < sc.counts[ch]; i++) {
                const setup_tri *s = &r->chunk_tris[ch][i];
                for (int ty = s->y0 / TILE; ty <= s->y1 / TILE; ty++)
                    for (int tx = s->x0 / TILE; tx <= s->x1 / TILE; tx++)
                        r->bin_items[r->bin_start[(size_t)ty * tiles_x + tx]++] = s;
            }
        for (size_t k = tiles; k > 0; k--)
            r->bin_start[k] = r->bin_start[k - 1];
        r->bin_start[0] = 0;
        crisp_pool_parallel_for(pool, tiles, 1, raster_tiles, &rc);
    }
    if (stats) {
        *stats = (crisp_raster_stats){.triangles_in = tri_count,
                                      .triangles_setup = total,
                                      .fragments_tested = atomic_load(&rc.tested),
                                      .fragments_discarded = atomic_load(&rc.discarded),
                                      .fragments_untested = atomic_load(&rc.untested),
                                      .blocks_skipped = atomic_load(&rc.blocks_skipped)};
    }
    return CRISP_OK;
}
