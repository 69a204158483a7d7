/* The CPU rasterizer (see raster.h): homogeneous clipping, fixed-point setup with a top-left
 * rule, order-preserving tile binning and per-tile parallel rasterisation. */
#include "raster.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#define TILE 64
#define SUB (1 << CRISP_RASTER_SUBPIXEL_BITS)
#define CHUNKS 64          /* setup work units; fixed so the output order never depends on threads */
#define GUARD_PX 1048576.0 /* screen coordinates stay within +-2^20 px: exact int64 edge functions */
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

struct crisp_raster {
    setup_tri *tris;
    size_t tri_cap;
    size_t chunk_start[CHUNKS + 1]; /* output offsets per chunk */
    uint32_t *bin_items;
    size_t bin_cap;
    uint32_t *bin_start; /* per tile, tile_count + 1 */
    size_t bin_start_cap;
};

crisp_status crisp_raster_create(crisp_raster **dest)
{
    crisp_raster *r = calloc(1, sizeof *r);
    if (!r) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating the rasterizer");
    *dest = r;
    return CRISP_OK;
}

void crisp_raster_destroy(crisp_raster *r)
{
    if (!r) return;
    free(r->tris);
    free(r->bin_items);
    free(r->bin_start);
    free(r);
}

crisp_status crisp_raster_target_init(crisp_raster_target *t, int width, int height, int samples)
{
    if (width <= 0 || height <= 0 || width > 65536 || height > 65536)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image size %dx%d: expected 1..65536", width, height);
    if (samples != 1 && samples != 4 && samples != 16)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%d samples per pixel: expected 1, 4 or 16", samples);
    size_t n = (size_t)width * (size_t)height * (size_t)samples;
    if (t->inv_w && (size_t)t->width * t->height * t->samples == n) {
        t->width = width;
        t->height = height;
        t->samples = samples;
        return CRISP_OK;
    }
    crisp_raster_target_free(t);
    t->inv_w = crisp_malloc_array(n, sizeof *t->inv_w);
    t->attr = crisp_malloc_array(n, CRISP_RASTER_ATTRS * sizeof *t->attr);
    t->face = crisp_malloc_array(n, sizeof *t->face);
    if (!t->inv_w || !t->attr || !t->face) {
        crisp_raster_target_free(t);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a %dx%d image with %d samples",
                           width, height, samples);
    }
    t->width = width;
    t->height = height;
    t->samples = samples;
    return CRISP_OK;
}

void crisp_raster_target_free(crisp_raster_target *t)
{
    free(t->inv_w);
    free(t->attr);
    free(t->face);
    memset(t, 0, sizeof *t);
}

void crisp_raster_target_clear(crisp_raster_target *t)
{
    size_t n = (size_t)t->width * t->height * t->samples;
    memset(t->inv_w, 0, n * sizeof *t->inv_w);
    memset(t->attr, 0, n * CRISP_RASTER_ATTRS * sizeof *t->attr);
    memset(t->face, 0xff, n * sizeof *t->face);
}

void crisp_raster_sample_offset(int samples, int s, double dest[2])
{
    /* 4: rotated grid; 16: a regular 4x4 grid. */
    static const double rot4[4][2] = {{0.375, 0.125}, {0.875, 0.375}, {0.125, 0.625}, {0.625, 0.875}};
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

/* ---- clipping ---------------------------------------------------------------------------------- */

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

/* ---- setup ------------------------------------------------------------------------------------- */

typedef struct {
    crisp_raster *r;
    const crisp_raster_target *t;
    const crisp_raster_vertex *verts;
    const crisp_raster_tri *tris;
    size_t tri_count;
    double gx, gy;
    int write; /* 0: count outputs per chunk; 1: write them */
    size_t counts[CHUNKS];
} setup_ctx;

/* Sets up one clipped triangle into *out; returns 0 when it covers no sample area (degenerate,
 * not finite or off the image). */
static int setup_one(const setup_ctx *c, const cvert *a, const cvert *b, const cvert *d,
                     uint32_t face, setup_tri *out)
{
    const cvert *v[3] = {a, b, d};
    const crisp_raster_target *t = c->t;
    double sx[3], sy[3];
    int64_t fx[3], fy[3];
    for (int i = 0; i < 3; i++) {
        double w = v[i]->p[3];
        if (!(w > 0)) return 0;
        sx[i] = (v[i]->p[0] / w + 1.0) * 0.5 * t->width;
        sy[i] = (1.0 - v[i]->p[1] / w) * 0.5 * t->height;
        if (!(fabs(sx[i]) <= 2 * GUARD_PX && fabs(sy[i]) <= 2 * GUARD_PX)) return 0;
        fx[i] = llround(sx[i] * SUB);
        fy[i] = llround(sy[i] * SUB);
    }
    int64_t area = (fx[1] - fx[0]) * (fy[2] - fy[0]) - (fy[1] - fy[0]) * (fx[2] - fx[0]);
    if (area == 0) return 0;
    int order[3] = {0, 1, 2};
    if (area < 0) {
        order[1] = 2;
        order[2] = 1;
        area = -area;
    }
    double det = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sy[1] - sy[0]) * (sx[2] - sx[0]);
    if (!(fabs(det) > 0)) return 0;
    out->ox = sx[0];
    out->oy = sy[0];
    for (int q = 0; q <= CRISP_RASTER_ATTRS; q++) {
        double val[3];
        for (int i = 0; i < 3; i++) {
            double iw = 1.0 / v[i]->p[3];
            val[i] = q == 0 ? iw : v[i]->p[3 + q] * iw;
        }
        double d1 = val[1] - val[0], d2 = val[2] - val[0];
        out->q0[q] = val[0];
        out->qx[q] = (d1 * (sy[2] - sy[0]) - d2 * (sy[1] - sy[0])) / det;
        out->qy[q] = (d2 * (sx[1] - sx[0]) - d1 * (sx[2] - sx[0])) / det;
    }
    double minx = 1e300, miny = 1e300, maxx = -1e300, maxy = -1e300;
    for (int k = 0; k < 3; k++) {
        int i = order[k];
        out->x[k] = fx[i];
        out->y[k] = fy[i];
        minx = fmin(minx, (double)fx[i] / SUB);
        maxx = fmax(maxx, (double)fx[i] / SUB);
        miny = fmin(miny, (double)fy[i] / SUB);
        maxy = fmax(maxy, (double)fy[i] / SUB);
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
    /* Samples sit at i + offset with offset in [0, 1): pixels floor(min) - 1 .. floor(max). */
    out->x0 = (int)fmax(0, floor(minx) - 1);
    out->y0 = (int)fmax(0, floor(miny) - 1);
    out->x1 = (int)fmin(t->width - 1, floor(maxx));
    out->y1 = (int)fmin(t->height - 1, floor(maxy));
    out->face = face;
    return out->x0 <= out->x1 && out->y0 <= out->y1;
}

static void setup_chunk(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    setup_ctx *c = vctx;
    for (size_t ch = begin; ch < end; ch++) {
        size_t lo = c->tri_count * ch / CHUNKS, hi = c->tri_count * (ch + 1) / CHUNKS;
        size_t n = 0;
        setup_tri *out = c->write ? c->r->tris + c->r->chunk_start[ch] : NULL;
        for (size_t i = lo; i < hi; i++) {
            const crisp_raster_tri *tri = &c->tris[i];
            cvert poly[MAX_POLY];
            int inside = 1;
            for (int k = 0; k < 3; k++) {
                const crisp_raster_vertex *sv = &c->verts[tri->v[k]];
                memcpy(poly[k].p, sv->clip, 4 * sizeof(double));
                memcpy(poly[k].p + 4, sv->attr, CRISP_RASTER_ATTRS * sizeof(double));
                double d[6];
                plane_dists(sv->clip, c->gx, c->gy, d);
                for (int q = 0; q < 6; q++) inside &= d[q] >= 0 && isfinite(d[q]);
            }
            int m = 3;
            if (!inside) m = clip_polygon(poly, 3, c->gx, c->gy);
            /* Set up into a local record and keep it only when accepted: a rejected last
             * triangle must not write past this chunk into the next one (another worker's). */
            for (int k = 1; k + 1 < m; k++) {
                setup_tri rec;
                if (setup_one(c, &poly[0], &poly[k], &poly[k + 1], tri->face, &rec)) {
                    if (out) out[n] = rec;
                    n++;
                }
            }
        }
        c->counts[ch] = n;
    }
}

/* ---- rasterisation ----------------------------------------------------------------------------- */

typedef struct {
    crisp_raster *r;
    crisp_raster_target *t;
    int tiles_x;
    crisp_raster_test_fn test;
    void *test_ctx;
    int64_t off_fx[16], off_fy[16];
    double off_x[16], off_y[16];
    const float *slack; /* fill mode (crisp_raster_draw_fill) when not NULL */
    atomic_size_t tested, discarded;
} raster_ctx;

static void raster_tile(raster_ctx *c, size_t tile, int worker)
{
    crisp_raster *r = c->r;
    crisp_raster_target *t = c->t;
    int tx = (int)(tile % (size_t)c->tiles_x), ty = (int)(tile / (size_t)c->tiles_x);
    int px0 = tx * TILE, py0 = ty * TILE;
    int px1 = px0 + TILE - 1 < t->width - 1 ? px0 + TILE - 1 : t->width - 1;
    int py1 = py0 + TILE - 1 < t->height - 1 ? py0 + TILE - 1 : t->height - 1;
    int S = t->samples;
    size_t tested = 0, discarded = 0;
    for (uint32_t bi = r->bin_start[tile]; bi < r->bin_start[tile + 1]; bi++) {
        const setup_tri *st = &r->tris[r->bin_items[bi]];
        int x0 = st->x0 > px0 ? st->x0 : px0, x1 = st->x1 < px1 ? st->x1 : px1;
        int y0 = st->y0 > py0 ? st->y0 : py0, y1 = st->y1 < py1 ? st->y1 : py1;
        /* Edge k: E = A (px - x_a0) + B (py - y_a0), stepped by A * SUB per pixel. */
        int64_t A[3], B[3];
        for (int k = 0; k < 3; k++) {
            int a0 = (k + 1) % 3, a1 = (k + 2) % 3;
            A[k] = -(st->y[a1] - st->y[a0]);
            B[k] = st->x[a1] - st->x[a0];
        }
        for (int j = y0; j <= y1; j++) {
            int64_t e[16][3];
            for (int s = 0; s < S; s++) {
                int64_t px = (int64_t)x0 * SUB + c->off_fx[s], py = (int64_t)j * SUB + c->off_fy[s];
                for (int k = 0; k < 3; k++) {
                    int a0 = (k + 1) % 3;
                    e[s][k] = A[k] * (px - st->x[a0]) + B[k] * (py - st->y[a0]) + st->bias[k];
                }
            }
            for (int i = x0; i <= x1; i++) {
                for (int s = 0; s < S; s++) {
                    int in = (e[s][0] | e[s][1] | e[s][2]) >= 0;
                    e[s][0] += A[0] * SUB;
                    e[s][1] += A[1] * SUB;
                    e[s][2] += A[2] * SUB;
                    if (!in) continue;
                    double dx = i + c->off_x[s] - st->ox, dy = j + c->off_y[s] - st->oy;
                    double iw = st->q0[0] + st->qx[0] * dx + st->qy[0] * dy;
                    size_t idx = ((size_t)j * t->width + i) * S + s;
                    double cur = t->inv_w[idx];
                    if (c->slack) {
                        if (cur > 0 && !(1.0 / iw < 1.0 / cur - c->slack[idx])) continue;
                    } else if (!(iw > cur)) {
                        continue;
                    }
                    double a[CRISP_RASTER_ATTRS];
                    double w = 1.0 / iw;
                    for (int q = 0; q < CRISP_RASTER_ATTRS; q++)
                        a[q] = (st->q0[q + 1] + st->qx[q + 1] * dx + st->qy[q + 1] * dy) * w;
                    if (c->test) {
                        tested++;
                        if (!c->test(c->test_ctx, st->face, a[0], a[1])) {
                            discarded++;
                            continue;
                        }
                    }
                    t->inv_w[idx] = iw;
                    t->face[idx] = (int32_t)(st->face & ~CRISP_RASTER_FACE_FLAG);
                    float *dst = t->attr + idx * CRISP_RASTER_ATTRS;
                    for (int q = 0; q < CRISP_RASTER_ATTRS; q++) dst[q] = (float)a[q];
                }
            }
        }
    }
    (void)worker;
    atomic_fetch_add(&c->tested, tested);
    atomic_fetch_add(&c->discarded, discarded);
}

static void raster_tiles(void *vctx, size_t begin, size_t end, int worker)
{
    for (size_t tile = begin; tile < end; tile++) raster_tile(vctx, tile, worker);
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
    for (int k = 0; k < 3; k++) dot += a[2 + k] * (v->f[k] + x * v->r[k] + y * v->u[k]);
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
    for (size_t i = begin * rs; i < end * rs; i++) slack[i] = 0;
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
                    seen_side(c->view, w, h, i + 1, j, t->attr + (idx + S) * CRISP_RASTER_ATTRS) == side) {
                    float d = (float)(c->scale * fabs(1.0 / t->inv_w[idx + S] - W));
                    if (d > slack[idx]) slack[idx] = d;
                    if (d > slack[idx + S]) slack[idx + S] = d;
                }
                if (j + 1 < h && t->face[idx + rs] == f &&
                    seen_side(c->view, w, h, i, j + 1, t->attr + (idx + rs) * CRISP_RASTER_ATTRS) == side) {
                    float d = (float)(c->scale * fabs(1.0 / t->inv_w[idx + rs] - W));
                    if (own_j && d > slack[idx]) slack[idx] = d;
                    if (own_below && d > slack[idx + rs]) slack[idx + rs] = d;
                }
            }
    }
}

void crisp_raster_depth_slack(const crisp_raster_target *t, crisp_pool *pool, double scale,
                              const crisp_raster_view *view, float *slack)
{
    slack_ctx c = {t, view, scale, slack};
    crisp_pool_parallel_for(pool, (size_t)t->height, 16, slack_rows, &c);
}

static crisp_status draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                         const crisp_raster_vertex *verts, size_t vert_count, const crisp_raster_tri *tris,
                         size_t tri_count, crisp_raster_test_fn test, void *test_ctx, const float *slack,
                         crisp_raster_stats *stats);

crisp_status crisp_raster_draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                               const crisp_raster_vertex *verts, size_t vert_count,
                               const crisp_raster_tri *tris, size_t tri_count,
                               crisp_raster_test_fn test, void *test_ctx,
                               crisp_raster_stats *stats)
{
    return draw(r, t, pool, verts, vert_count, tris, tri_count, test, test_ctx, NULL, stats);
}

crisp_status crisp_raster_draw_fill(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                                    const crisp_raster_vertex *verts, size_t vert_count,
                                    const crisp_raster_tri *tris, size_t tri_count,
                                    crisp_raster_test_fn test, void *test_ctx, const float *slack,
                                    crisp_raster_stats *stats)
{
    return draw(r, t, pool, verts, vert_count, tris, tri_count, test, test_ctx, slack, stats);
}

static crisp_status draw(crisp_raster *r, crisp_raster_target *t, crisp_pool *pool,
                         const crisp_raster_vertex *verts, size_t vert_count, const crisp_raster_tri *tris,
                         size_t tri_count, crisp_raster_test_fn test, void *test_ctx, const float *slack,
                         crisp_raster_stats *stats)
{
    for (size_t i = 0; i < tri_count; i++)
        for (int k = 0; k < 3; k++)
            if (tris[i].v[k] >= vert_count)
                return crisp_error(CRISP_ERR_INVALID_ARG, "triangle %zu uses vertex %u of %zu", i,
                                   tris[i].v[k], vert_count);
    setup_ctx sc = {.r = r, .t = t, .verts = verts, .tris = tris, .tri_count = tri_count,
                    .gx = GUARD_PX / t->width, .gy = GUARD_PX / t->height};
    /* Count, then write each chunk's triangles at its offset: one allocation, input order kept. */
    crisp_pool_parallel_for(pool, CHUNKS, 1, setup_chunk, &sc);
    size_t total = 0;
    for (int ch = 0; ch < CHUNKS; ch++) {
        r->chunk_start[ch] = total;
        total += sc.counts[ch];
    }
    r->chunk_start[CHUNKS] = total;
    if (total > UINT32_MAX)
        return crisp_error(CRISP_ERR_LIMIT, "%zu triangles after clipping: the limit is 2^32", total);
    crisp_status st = crisp_grow((void **)&r->tris, &r->tri_cap, total, sizeof *r->tris);
    if (st) return st;
    sc.write = 1;
    crisp_pool_parallel_for(pool, CHUNKS, 1, setup_chunk, &sc);

    /* Bin in submission order: count per tile, prefix sums, fill. */
    int tiles_x = (t->width + TILE - 1) / TILE, tiles_y = (t->height + TILE - 1) / TILE;
    size_t tiles = (size_t)tiles_x * tiles_y;
    if ((st = crisp_grow((void **)&r->bin_start, &r->bin_start_cap, tiles + 1, sizeof *r->bin_start)))
        return st;
    memset(r->bin_start, 0, (tiles + 1) * sizeof *r->bin_start);
    size_t items = 0;
    for (size_t i = 0; i < total; i++) {
        const setup_tri *s = &r->tris[i];
        for (int ty = s->y0 / TILE; ty <= s->y1 / TILE; ty++)
            for (int tx = s->x0 / TILE; tx <= s->x1 / TILE; tx++) r->bin_start[(size_t)ty * tiles_x + tx + 1]++;
        items += (size_t)(s->y1 / TILE - s->y0 / TILE + 1) * (size_t)(s->x1 / TILE - s->x0 / TILE + 1);
    }
    if (items > UINT32_MAX) return crisp_error(CRISP_ERR_LIMIT, "%zu tile entries: the limit is 2^32", items);
    for (size_t k = 0; k < tiles; k++) r->bin_start[k + 1] += r->bin_start[k];
    if ((st = crisp_grow((void **)&r->bin_items, &r->bin_cap, items ? items : 1, sizeof *r->bin_items)))
        return st;
    for (size_t i = 0; i < total; i++) {
        const setup_tri *s = &r->tris[i];
        for (int ty = s->y0 / TILE; ty <= s->y1 / TILE; ty++)
            for (int tx = s->x0 / TILE; tx <= s->x1 / TILE; tx++)
                r->bin_items[r->bin_start[(size_t)ty * tiles_x + tx]++] = (uint32_t)i;
    }
    for (size_t k = tiles; k > 0; k--) r->bin_start[k] = r->bin_start[k - 1];
    r->bin_start[0] = 0;

    raster_ctx rc = {.r = r, .t = t, .tiles_x = tiles_x, .test = test, .test_ctx = test_ctx, .slack = slack};
    for (int s = 0; s < t->samples; s++) {
        double off[2];
        crisp_raster_sample_offset(t->samples, s, off);
        rc.off_x[s] = off[0];
        rc.off_y[s] = off[1];
        rc.off_fx[s] = llround(off[0] * SUB);
        rc.off_fy[s] = llround(off[1] * SUB);
    }
    crisp_pool_parallel_for(pool, tiles, 1, raster_tiles, &rc);
    if (stats) {
        *stats = (crisp_raster_stats){.triangles_in = tri_count,
                                      .triangles_setup = total,
                                      .fragments_tested = atomic_load(&rc.tested),
                                      .fragments_discarded = atomic_load(&rc.discarded)};
    }
    return CRISP_OK;
}
