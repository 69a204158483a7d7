/* The CPU backend's splat draw (issue 12; splat_raster.h, docs/status/issue-12-splats.md
 * "Planner and CPU draw"). A splat is a screen-aligned square of half-size h pixels at its own
 * depth: the planner draws a face so only when every point of it that a pixel centre sees lies
 * within h - margin px (x and y) of a splat's projection (splat_store.c), so every such pixel
 * centre is covered and shows a true point of the face within h px.
 *
 * Two passes: each range's screen box and nearest depth (its splats projected), and those of its
 * chunks (runs of SPLAT_CHUNK splats), and the bands of rows it meets, range by range in parallel
 * (at a distance a frame holds one small range per face: imp49 far's 13,573, whose serial
 * bookkeeping had cost as much as a third of the draw's parallel work); then bands of rows in
 * parallel, each band drawing every range that reaches it in plan order (the splats of its chunks
 * that reach the band projected again), so a sample's writes come in the same order whatever the
 * thread count. The planner orders the ranges nearest first; a band skips a range, and then a
 * chunk, whose largest 1/W is below that of every sample its squares may cover there (drawn by
 * the surfaces and the nearer ranges): most splats of a frame like imp49's lose the depth test
 * (65 splats per covered pixel at imp49 far3). Skipping changes nothing drawn. (Session 11 kept
 * a block depth per band, lowered after each range; the samples themselves are cheaper to test
 * and exact.) */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef __SSE2__
#include <immintrin.h>
#endif

#include "occlusion.h"
#include "splat_raster.h"

#define BAND_ROWS 16
/* Splats per chunk: each chunk of a range (consecutive splats of its set, which the builder makes
 * cell by cell, so near each other) has its own screen box and nearest depth, so that a band
 * skips the chunks that miss its rows or that the depth drawn hides. 8 and 32 cost 1.10x and
 * 1.03x the instructions of 16 at imp49 far3. */
#define SPLAT_CHUNK 16

void crisp__splat_scratch_free(crisp__splat_scratch *s)
{
    free(s->list);
    free(s->box);
    free(s->band_start);
    free(s->band_list);
    free(s->band_fill);
    free(s->span);
    free(s->chunk_first);
    free(s->chunk_box);
    memset(s, 0, sizeof *s);
}

/* Splat sp's pixel position (whole image) and 1 / W by the plan's rule (clip position in float);
 * 0 when it is not drawn (W <= 0, beyond the near or far plane, or not finite). */
static inline int project(const crisp_frame_plan *plan, const float *o, const crisp_plan_splat *sp,
                          double sx, double sy, double *x, double *y, double *iw)
{
    const float *m = plan->view_proj_f;
    float cl[4];
#ifdef __SSE2__
    /* the same float operations in the same order, four lanes at once */
    __m128 c = _mm_add_ps(_mm_loadu_ps(o), _mm_mul_ps(_mm_loadu_ps(m), _mm_set1_ps(sp->p[0])));
    c = _mm_add_ps(c, _mm_mul_ps(_mm_loadu_ps(m + 4), _mm_set1_ps(sp->p[1])));
    c = _mm_add_ps(c, _mm_mul_ps(_mm_loadu_ps(m + 8), _mm_set1_ps(sp->p[2])));
    _mm_storeu_ps(cl, c);
#else
    for (int q = 0; q < 4; q++)
        cl[q] = o[q] + m[q] * sp->p[0] + m[q + 4] * sp->p[1] + m[q + 8] * sp->p[2];
#endif
    double w = cl[3];
    if (!(w > 0) || !(cl[2] >= -w) || !(cl[2] <= w) || !isfinite(cl[0] + cl[1])) return 0;
    *x = ((double)cl[0] / w + 1) * sx, *y = (1 - (double)cl[1] / w) * sy, *iw = 1.0 / w;
    return 1;
}

typedef struct project_ctx {
    crisp__splat_scratch *s;
    const crisp__splat_draw_desc *d;
    const crisp_frame_plan *plan;
    const crisp_raster_target *t;
    int bw;       /* the hiz's blocks per row */
    size_t bands; /* bands of BAND_ROWS rows of t */
    /* per worker: the union of the boxes of the ranges not hidden (lo x, lo y, hi x, hi y) and
     * the count of those hidden, a cache line each */
    struct project_sums {
        _Alignas(64) double un[4];
        size_t hidden;
    } * sums;
} project_ctx;

/* ceil(a), a clamped to +-1e9 first (pixel positions), without a libm call. */
static inline int ceil_px(double a)
{
    a = a < -1e9 ? -1e9 : a > 1e9 ? 1e9 : a;
    int i = (int)a; /* towards zero: ceil for a <= 0, floor for a > 0 */
    return i < a ? i + 1 : i;
}

/* floor(a), a clamped to +-1e9 first, without a libm call. */
static inline int floor_px(double a)
{
    a = a < -1e9 ? -1e9 : a > 1e9 ? 1e9 : a;
    int i = (int)a; /* towards zero: floor for a >= 0, ceil for a < 0 */
    return i > a ? i - 1 : i;
}

/* Whether draw_bands draws anything of a range or chunk of box b in band `band` of t (window
 * win): its box meets the band's rows and the target's columns. */
static inline int band_meets(const crisp_raster_target *t, const int win[4], const double *b,
                             size_t band)
{
    const int x0 = win[0], y0 = win[1];
    int r0 = y0 + (int)band * BAND_ROWS, r1 = r0 + BAND_ROWS;
    if (r1 > y0 + t->height) r1 = y0 + t->height;
    return !(b[3] < r0 || b[1] >= r1 || b[2] < x0 || b[0] >= x0 + t->width);
}

/* Chunks of fewer splats than this get their box from their splats' projections (as chunks that
 * may reach W <= 0 do) rather than chunk_box: a projection costs about a third of chunk_box's
 * work, and imp49 far's ranges hold 5 splats on average (8,800 of 13,573 at most 4). */
#define CHUNK_BOX_MIN 4

/* Range i of the list: the box of its squares and its largest 1/W, and the same for each chunk
 * of SPLAT_CHUNK splats of it (the positions themselves are computed again where they are drawn:
 * storing them cost 24 bytes per splat drawn). A chunk with no splat drawn gets an empty box
 * (lo > hi) and 1/W 0. */
/* A box (lo x, lo y, hi x, hi y, largest 1/W) that holds the pixel positions, and a 1/W at least
 * those, that project gives the splats sp[0 .. n - 1] (clip origin o), from the box of their
 * positions: the float clip coordinates of a position p in the box [plo, phi] lie within the
 * exact o + M p over the box widened by 4e-7 (|o| + sum |M_j| max |p_j|) (four float roundings
 * of at most 2^-24 of that sum each, and the double sums here), and x / W, y / W are monotone in
 * each over a box of W > 0, where correctly rounded operations keep the order. 0 when W may
 * reach 0 (then the caller projects the splats). */
static int chunk_box(const crisp_frame_plan *plan, const float *o, const crisp_plan_splat *sp,
                     uint32_t n, double sx, double sy, double box[5])
{
    float x0 = sp[0].p[0], x1 = x0, y0 = sp[0].p[1], y1 = y0, z0 = sp[0].p[2], z1 = z0;
    for (uint32_t k = 1; k < n; k++) {
        float x = sp[k].p[0], y = sp[k].p[1], z = sp[k].p[2];
        x0 = x < x0 ? x : x0, x1 = x > x1 ? x : x1;
        y0 = y < y0 ? y : y0, y1 = y > y1 ? y : y1;
        z0 = z < z0 ? z : z0, z1 = z > z1 ? z : z1;
    }
    const float plo[3] = {x0, y0, z0}, phi[3] = {x1, y1, z1};
    const float *m = plan->view_proj_f;
    double lo[4], hi[4];
    for (int q = 0; q < 4; q += q == 1 ? 2 : 1) { /* x, y and W */
        double l = o[q], h = o[q], mag = fabs((double)o[q]);
        for (int j = 0; j < 3; j++) {
            double u = (double)m[q + 4 * j] * plo[j], v = (double)m[q + 4 * j] * phi[j];
            l += u < v ? u : v, h += u < v ? v : u;
            mag += fabs(u) > fabs(v) ? fabs(u) : fabs(v);
        }
        lo[q] = l - 4e-7 * mag, hi[q] = h + 4e-7 * mag;
    }
    if (!(lo[3] > 0) || !isfinite(hi[3]) || !isfinite(lo[0] + hi[0] + lo[1] + hi[1])) return 0;
    double a0 = lo[0] / lo[3], a1 = lo[0] / hi[3], b0 = hi[0] / lo[3], b1 = hi[0] / hi[3];
    double c0 = lo[1] / lo[3], c1 = lo[1] / hi[3], d0 = hi[1] / lo[3], d1 = hi[1] / hi[3];
    box[0] = ((a0 < a1 ? a0 : a1) + 1) * sx, box[2] = ((b0 > b1 ? b0 : b1) + 1) * sx;
    box[1] = (1 - (d0 > d1 ? d0 : d1)) * sy, box[3] = (1 - (c0 < c1 ? c0 : c1)) * sy;
    box[4] = 1.0 / lo[3];
    return isfinite(box[0] + box[1] + box[2] + box[3] + box[4]);
}

static void project_ranges(void *vctx, size_t begin, size_t end, int worker)
{
    project_ctx *c = vctx;
    const crisp_frame_plan *plan = c->plan;
    double h = plan->splat_half_px, sx = 0.5 * plan->width, sy = 0.5 * plan->height;
    struct project_sums *sum = &c->sums[worker];
    double u[4] = {sum->un[0], sum->un[1], sum->un[2], sum->un[3]};
    size_t hidden_ranges = 0;
    for (size_t i = begin; i < end; i++) {
        const crisp_plan_splat_range *rg = &plan->splat_ranges[c->s->list[i]];
        const float *o = plan->splat_clip_origin + 4 * (size_t)rg->face;
        double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY}, iwmax = 0;
        double *cb = c->s->chunk_box + 5 * (size_t)c->s->chunk_first[i];
        for (uint32_t k0 = 0; k0 < rg->count; k0 += SPLAT_CHUNK, cb += 5) {
            uint32_t k1 = rg->count - k0 < SPLAT_CHUNK ? rg->count : k0 + SPLAT_CHUNK;
            double clo[2] = {INFINITY, INFINITY}, chi[2] = {-INFINITY, -INFINITY}, ciw = 0;
            double bx[5];
            if (k1 - k0 >= CHUNK_BOX_MIN &&
                chunk_box(plan, o, &plan->splats[rg->first + k0], k1 - k0, sx, sy, bx)) {
                clo[0] = bx[0], clo[1] = bx[1], chi[0] = bx[2], chi[1] = bx[3], ciw = bx[4];
            } else
                for (uint32_t k = k0; k < k1; k++) {
                    double x, y, iw;
                    if (!project(plan, o, &plan->splats[rg->first + k], sx, sy, &x, &y, &iw))
                        continue;
                    clo[0] = x < clo[0] ? x : clo[0], clo[1] = y < clo[1] ? y : clo[1];
                    chi[0] = x > chi[0] ? x : chi[0], chi[1] = y > chi[1] ? y : chi[1];
                    ciw = iw > ciw ? iw : ciw;
                }
            cb[0] = clo[0] - h, cb[1] = clo[1] - h, cb[2] = chi[0] + h, cb[3] = chi[1] + h;
            cb[4] = ciw;
            lo[0] = clo[0] < lo[0] ? clo[0] : lo[0], lo[1] = clo[1] < lo[1] ? clo[1] : lo[1];
            hi[0] = chi[0] > hi[0] ? chi[0] : hi[0], hi[1] = chi[1] > hi[1] ? chi[1] : hi[1];
            iwmax = ciw > iwmax ? ciw : iwmax;
        }
        double *b = c->s->box + 5 * i;
        b[0] = lo[0] - h, b[1] = lo[1] - h, b[2] = hi[0] + h, b[3] = hi[1] + h, b[4] = iwmax;
        /* hidden whole: no splat in front of the eye, or behind the surfaces' depth (hiz) */
        uint8_t hidden = !(b[4] > 0);
        if (!hidden && c->d->hiz) {
            crisp_occl_leaf ol;
            crisp__occl_set(&ol, c->d->win, b, b + 2, b[4]);
            hidden = (uint8_t)crisp__occl_hidden(&ol, c->d->hiz, c->bw);
        }
        c->s->span[i][0] = 1, c->s->span[i][1] = 0;
        if (hidden) {
            hidden_ranges++;
            continue;
        }
        /* finite: some splat of the range was projected */
        u[0] = b[0] < u[0] ? b[0] : u[0], u[1] = b[1] < u[1] ? b[1] : u[1];
        u[2] = b[2] > u[2] ? b[2] : u[2], u[3] = b[3] > u[3] ? b[3] : u[3];
        /* The bands band_meets accepts, an interval of them (the box's rows are one): from
         * those of the box's rows, one more each side for the rounding, trimmed by it. */
        const crisp_raster_target *t = c->t;
        const int *win = c->d->win;
        long b0 = (long)floor_px((b[1] - win[1]) * (1.0 / BAND_ROWS)) - 1,
             b1 = (long)floor_px((b[3] - win[1]) * (1.0 / BAND_ROWS)) + 1;
        if (b0 < 0) b0 = 0;
        if (b1 > (long)c->bands - 1) b1 = (long)c->bands - 1;
        while (b0 <= b1 && !band_meets(t, win, b, (size_t)b0))
            b0++;
        while (b1 > b0 && !band_meets(t, win, b, (size_t)b1))
            b1--;
        if (b0 > b1) continue;
        c->s->span[i][0] = (uint32_t)b0, c->s->span[i][1] = (uint32_t)b1;
    }
    for (int k = 0; k < 4; k++)
        sum->un[k] = u[k];
    sum->hidden += hidden_ranges;
}

typedef struct band_ctx {
    crisp__splat_scratch *s;
    const crisp__splat_draw_desc *d;
    crisp_raster_target *t;
    size_t count; /* ranges in the list */
    int occlude;  /* skip the ranges and chunks that the depth drawn hides */
    double off[16][2];
    double omin[2], omax[2];                  /* the least and largest sample offsets in x and y */
    size_t *written, *culled, *chunks_culled; /* per worker */
} band_ctx;

/* The splats [q0, q1) of range rg (its face's clip origin org, normal sign sg) drawn into the
 * rows [r0, r1) of t; S: the target's samples (a constant where inlined). Returns the samples
 * written. */
static inline __attribute__((always_inline)) size_t
draw_splats(const band_ctx *c, const crisp_plan_splat_range *rg, uint32_t q0, uint32_t q1,
            const float *org, float sg, int r0, int r1, const int S)
{
    const crisp_frame_plan *plan = c->d->plan;
    crisp_raster_target *t = c->t;
    const int x0 = c->d->win[0], y0 = c->d->win[1];
    const double h = plan->splat_half_px, sx = 0.5 * plan->width, sy = 0.5 * plan->height;
    const double *k = c->d->clip;
    const uint32_t face = rg->face;
    size_t written = 0;
    for (uint32_t q = q0; q < q1; q++) {
        const crisp_plan_splat *sp = &plan->splats[rg->first + q];
        double cx, cy, iw;
        if (!project(plan, org, sp, sx, sy, &cx, &cy, &iw)) continue;
        if (cy + h < r0 || cy - h >= r1) continue;
        float attr[CRISP_RASTER_ATTRS] = {0};
        int have_attr = 0;
        for (int s = 0; s < S; s++) {
            const double ox = c->off[s][0], oy = c->off[s][1];
            /* samples gi + ox with cx - h <= gi + ox < cx + h */
            int fi0 = ceil_px(cx - h - ox), fi1 = ceil_px(cx + h - ox) - 1;
            int fj0 = ceil_px(cy - h - oy), fj1 = ceil_px(cy + h - oy) - 1;
            if (fi0 < x0) fi0 = x0;
            if (fi1 > x0 + t->width - 1) fi1 = x0 + t->width - 1;
            if (fj0 < r0) fj0 = r0;
            if (fj1 > r1 - 1) fj1 = r1 - 1;
            for (int gj = fj0; gj <= fj1; gj++)
                for (int gi = fi0; gi <= fi1; gi++) {
                    size_t idx =
                        ((size_t)(gj - y0) * (size_t)t->width + (size_t)(gi - x0)) * (size_t)S +
                        (size_t)s;
                    if (!(iw > t->inv_w[idx])) continue;
                    if (k && k[0] + k[1] * (gi + ox) + k[2] * (gj + oy) + k[3] * iw < 0) continue;
                    if (!have_attr) {
                        float n[3];
                        crisp_plan_splat_normal(sp->n, n);
                        attr[0] = sp->uv[0], attr[1] = sp->uv[1];
                        attr[2] = sg * n[0], attr[3] = sg * n[1], attr[4] = sg * n[2];
                        have_attr = 1;
                    }
                    t->inv_w[idx] = iw;
                    memcpy(t->attr + idx * CRISP_RASTER_ATTRS, attr, sizeof attr);
                    t->face[idx] = (int32_t)face;
                    written++;
                }
        }
    }
    return written;
}

/* Whether every sample of t that a square of box b (lo x, lo y, hi x, hi y, largest 1/W) may
 * cover within the rows [r0, r1) holds a larger 1/W than b's: then none of its squares wins a
 * sample there. The samples are gi + ox with b[0] <= fl(cx - h) and fl(fl(cx - h) - ox) >=
 * fl(b[0] - omax) (rounding keeps the order), so gi >= ceil(fl(b[0] - omax)); and gi <=
 * ceil(fl(b[2] - omin)) - 1 alike (draw_splats' rule); rows the same with oy. */
static int box_hidden(const band_ctx *c, const double *b, int r0, int r1)
{
    const crisp_raster_target *t = c->t;
    const int x0 = c->d->win[0], y0 = c->d->win[1];
    if (!(b[4] > 0)) return 1;
    int i0 = ceil_px(b[0] - c->omax[0]), i1 = ceil_px(b[2] - c->omin[0]) - 1;
    int j0 = ceil_px(b[1] - c->omax[1]), j1 = ceil_px(b[3] - c->omin[1]) - 1;
    if (i0 < x0) i0 = x0;
    if (i1 > x0 + t->width - 1) i1 = x0 + t->width - 1;
    if (j0 < r0) j0 = r0;
    if (j1 > r1 - 1) j1 = r1 - 1;
    const int S = t->samples;
    for (int j = j0; j <= j1; j++) {
        const double *row =
            t->inv_w + ((size_t)(j - y0) * (size_t)t->width + (size_t)(i0 - x0)) * S;
        for (int k = 0; k < (i1 - i0 + 1) * S; k++)
            if (!(b[4] < row[k])) return 0;
    }
    return 1;
}

static void draw_bands(void *vctx, size_t begin, size_t end, int worker)
{
    band_ctx *c = vctx;
    const crisp_frame_plan *plan = c->d->plan;
    crisp_raster_target *t = c->t;
    const int y0 = c->d->win[1];
    size_t written = 0, culled = 0, chunks_culled = 0;
    for (size_t band = begin; band < end; band++) {
        /* rows [r0, r1) of the whole image */
        int r0 = y0 + (int)band * BAND_ROWS, r1 = r0 + BAND_ROWS;
        if (r1 > y0 + t->height) r1 = y0 + t->height;
        for (uint32_t e = c->s->band_start[band]; e < c->s->band_start[band + 1]; e++) {
            size_t i = c->s->band_list[e];
            const double *b = c->s->box + 5 * i; /* not hidden, meets the band (its span) */
            /* behind every sample the range's squares may cover in the band (what the surfaces
             * and the nearer ranges drew: the ranges come nearest first, splat_store.c) */
            if (c->occlude && box_hidden(c, b, r0, r1)) {
                culled++;
                continue;
            }
            const crisp_plan_splat_range *rg = &plan->splat_ranges[c->s->list[i]];
            const float *org = plan->splat_clip_origin + 4 * (size_t)rg->face;
            const float sg =
                (plan->faces[rg->face].flags & CRISP_PLAN_FACE_REVERSED) ? -1.0f : 1.0f;
            const double *cb = c->s->chunk_box + 5 * (size_t)c->s->chunk_first[i];
            for (uint32_t q0 = 0; q0 < rg->count; q0 += SPLAT_CHUNK, cb += 5) {
                if (!band_meets(t, c->d->win, cb, band)) continue;
                if (c->occlude && box_hidden(c, cb, r0, r1)) {
                    chunks_culled++;
                    continue;
                }
                uint32_t q1 = rg->count - q0 < SPLAT_CHUNK ? rg->count : q0 + SPLAT_CHUNK;
                written += t->samples == 1
                               ? draw_splats(c, rg, q0, q1, org, sg, r0, r1, 1)
                               : draw_splats(c, rg, q0, q1, org, sg, r0, r1, t->samples);
            }
        }
    }
    c->written[worker] += written;
    c->culled[worker] += culled;
    c->chunks_culled[worker] += chunks_culled;
}

crisp_status crisp__splat_draw(crisp__splat_scratch *s, crisp_raster_target *t, crisp_pool *pool,
                               const crisp__splat_draw_desc *d, crisp__splat_draw_stats *stats)
{
    const crisp_frame_plan *plan = d->plan;
    crisp__splat_draw_stats local;
    if (!stats) stats = &local;
    memset(stats, 0, sizeof *stats);
    stats->box[0] = stats->box[1] = 1, stats->box[2] = stats->box[3] = 0;
    if (!plan->splat_range_count || t->clear_pending) return CRISP_OK;
    size_t n = plan->splat_range_count;
    crisp_status st;
    if ((st = crisp_grow((void **)&s->list, &s->list_cap, n, sizeof *s->list))) return st;
    size_t cap = s->list_cap;
    double *box = realloc(s->box, cap * 5 * sizeof *box);
    if (!box) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for splats");
    s->box = box;
    /* The ranges drawn and each one's first chunk. */
    if ((st = crisp_grow((void **)&s->chunk_first, &s->chunk_first_cap, n + 1,
                         sizeof *s->chunk_first)))
        return st;
    size_t count = 0, splats = 0, chunks = 0;
    for (size_t r = 0; r < n; r++) {
        const crisp_plan_splat_range *rg = &plan->splat_ranges[r];
        if (!rg->count) continue;
        if (d->only && !d->only[rg->face]) continue;
        s->list[count] = (uint32_t)r;
        s->chunk_first[count] = (uint32_t)chunks;
        count++;
        splats += rg->count;
        chunks += (rg->count + SPLAT_CHUNK - 1) / SPLAT_CHUNK;
    }
    if (!count) return CRISP_OK;
    if (chunks > UINT32_MAX)
        return crisp_error(CRISP_ERR_LIMIT, "%zu splat chunks in a frame", chunks);
    s->chunk_first[count] = (uint32_t)chunks;
    size_t bands = (size_t)(t->height + BAND_ROWS - 1) / BAND_ROWS;
    if ((st = crisp_grow((void **)&s->chunk_box, &s->chunk_box_cap, 5 * (chunks ? chunks : 1),
                         sizeof *s->chunk_box)) ||
        (st = crisp_grow((void **)&s->band_start, &s->band_start_cap, bands + 1,
                         sizeof *s->band_start)) ||
        (st = crisp_grow((void **)&s->span, &s->span_cap, count, sizeof *s->span)))
        return st;
    /* The ranges' boxes, those hidden whole by the depth drawn, and the bands each of the others
     * meets (project_ranges); the union of their boxes per worker. */
    enum { MAX_WORKERS = 64 };
    if (crisp_pool_threads(pool) > MAX_WORKERS) pool = NULL;
    struct project_sums sums[MAX_WORKERS];
    for (int w = 0; w < MAX_WORKERS; w++) {
        sums[w].un[0] = sums[w].un[1] = INFINITY, sums[w].un[2] = sums[w].un[3] = -INFINITY;
        sums[w].hidden = 0;
    }
    project_ctx pc = {s,     d,   plan, t, (d->win[2] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK,
                      bands, sums};
    crisp_pool_parallel_for(pool, count, 16, project_ranges, &pc);
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int w = 0; w < MAX_WORKERS; w++) {
        const double *u = sums[w].un;
        stats->hidden_ranges += sums[w].hidden;
        lo[0] = u[0] < lo[0] ? u[0] : lo[0], lo[1] = u[1] < lo[1] ? u[1] : lo[1];
        hi[0] = u[2] > hi[0] ? u[2] : hi[0], hi[1] = u[3] > hi[1] ? u[3] : hi[1];
    }
    if (lo[0] <= hi[0]) {
        double bx0 = floor((lo[0] - d->win[0] - 1) / CRISP_OCCL_BLOCK),
               by0 = floor((lo[1] - d->win[1] - 1) / CRISP_OCCL_BLOCK),
               bx1 = floor((hi[0] - d->win[0] + 1) / CRISP_OCCL_BLOCK),
               by1 = floor((hi[1] - d->win[1] + 1) / CRISP_OCCL_BLOCK);
        double mx = (d->win[2] - 1) / CRISP_OCCL_BLOCK, my = (d->win[3] - 1) / CRISP_OCCL_BLOCK;
        stats->box[0] = (int)fmax(0, fmin(bx0, mx)), stats->box[1] = (int)fmax(0, fmin(by0, my));
        stats->box[2] = (int)fmax(0, fmin(bx1, mx)), stats->box[3] = (int)fmax(0, fmin(by1, my));
    }
    size_t written[MAX_WORKERS] = {0}, culled[MAX_WORKERS] = {0}, chunks_culled[MAX_WORKERS] = {0};
    band_ctx bc = {.s = s,
                   .d = d,
                   .t = t,
                   .count = count,
                   .occlude = d->occlude,
                   .written = written,
                   .culled = culled,
                   .chunks_culled = chunks_culled};
    bc.omin[0] = bc.omin[1] = 1, bc.omax[0] = bc.omax[1] = 0;
    for (int q = 0; q < t->samples; q++) {
        crisp__raster_sample_offset(t->samples, q, bc.off[q]);
        for (int a = 0; a < 2; a++) {
            bc.omin[a] = bc.off[q][a] < bc.omin[a] ? bc.off[q][a] : bc.omin[a];
            bc.omax[a] = bc.off[q][a] > bc.omax[a] ? bc.off[q][a] : bc.omax[a];
        }
    }
    /* Each band's ranges, in list order: those that draw_bands draws something of there (the
     * spans project_ranges found). */
    memset(s->band_start, 0, (bands + 1) * sizeof *s->band_start);
    for (int pass = 0; pass < 2; pass++) {
        size_t total = 0;
        for (size_t i = 0; i < count; i++) {
            size_t b0 = s->span[i][0], b1 = s->span[i][1];
            if (b0 > b1) continue;
            for (size_t k = b0; k <= b1; k++) {
                if (pass == 0)
                    s->band_start[k + 1]++;
                else
                    s->band_list[s->band_fill[k]++] = (uint32_t)i;
            }
            total += b1 - b0 + 1;
        }
        if (pass == 0) {
            for (size_t k = 0; k < bands; k++)
                s->band_start[k + 1] += s->band_start[k];
            if ((st = crisp_grow((void **)&s->band_list, &s->band_list_cap, total ? total : 1,
                                 sizeof *s->band_list)) ||
                (st = crisp_grow((void **)&s->band_fill, &s->band_fill_cap, bands,
                                 sizeof *s->band_fill)))
                return st;
            memcpy(s->band_fill, s->band_start, bands * sizeof *s->band_fill);
        }
    }
    crisp_pool_parallel_for(pool, bands, 1, draw_bands, &bc);
    stats->ranges = count;
    stats->splats = splats;
    for (int w = 0; w < MAX_WORKERS; w++) {
        stats->samples_written += written[w];
        stats->culled += culled[w];
        stats->chunks_culled += chunks_culled[w];
    }
    return CRISP_OK;
}
