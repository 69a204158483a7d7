/* The f-rep renderer: 2D images and 3D heightmaps by interval subdivision with per-cell tape
 * shortening (Keeter 2012's recursive subdivision with branch caching and z-culled heightmaps;
 * the tile sizes follow Fidget's VM renderer: 2D [128, 32, 8], 3D [64, 32, 16, 8]).
 *
 * A serial pre-pass subdivides the region as a quadtree down to the task tile size, filling or
 * skipping whole tiles and shortening the tape on the way; then the task tiles are handed out
 * dynamically to the pool's workers, each recursing depth-first with its own scratch (allocated
 * once at creation). Leaves (8x8 pixels) evaluate their short tape on 64 points at once. */
#include "frep_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define LEAF 8
/* 2D: quadtree down to 32 px cells, then 8x8 point batches on the 32 px cell's tape (measured on
 * prospero: an interval per 8 px cell costs more than the points it saves). */
#define MIN_INTERVAL_2D 32
/* Tape buffers per worker: one per level below the task tile (2D 128 -> 64 -> 32, 3D 64 -> 32 ->
 * 16 -> 8 use at most 4). */
#define MAX_DEPTH 5
/* A child's tape is pruned (no register reallocation) when its cell decided at most one min/max
 * per PRUNE_RATIO instructions, else shortened (bear 512^3 and prospero 1024^2 measured best
 * between 16 and 64: bear decides few, prospero many) */
#define PRUNE_RATIO 32
#ifndef SUB_MIN_VOXELS
#define SUB_MIN_VOXELS 64
#endif

typedef struct frep_worker {
    frep_ins *tapes; /* MAX_DEPTH tapes of the full length */
    uint32_t *ssas;  /* and their SSA operands */
    frep_shorten_scratch sc;
    uint8_t *choices;
    uint8_t *lane_choices; /* 3D: MAX_DEPTH x 8 children x tape length */
    size_t task_len;       /* 3D: length of the current task's tape (for normals) */
    float *lo, *hi, *regs, *gregs;
    uint8_t *live;
    crisp_frep_render_stats st;
    char pad[128]; /* keeps one worker's counters off the next worker's cache lines */
} frep_worker;

typedef struct frep_task {
    int i0, j0;
    frep_span tape;
} frep_task;

struct crisp_frep_renderer {
    const crisp_frep_tape *tape;
    crisp_frep_render_desc desc;
    crisp_frep_image img;
    float *xs, *ys, *zs;
    uint8_t *deferred; /* 3D: per pixel, 1 while its normal waits for its tile's batch */
    crisp_pool *pool;
    int threads, task_size;
    frep_worker *workers;
    crisp_arena *arena; /* pre-pass tapes, reset per run */
    frep_task *tasks;
    size_t ntasks, task_cap;
    crisp_frep_render_stats st;
};

/* ---- set-up ---------------------------------------------------------------------------------- */

static void free_worker(frep_worker *w)
{
    crisp_free(w->tapes);
    crisp_free(w->ssas);
    crisp__frep_scratch_free(&w->sc);
    crisp_free(w->choices);
    crisp_free(w->lane_choices);
    crisp_free(w->lo);
    crisp_free(w->regs);
    crisp_free(w->gregs);
    crisp_free(w->live);
}

void crisp_frep_renderer_destroy(crisp_frep_renderer *r)
{
    if (!r) return;
    if (r->workers)
        for (int i = 0; i < r->threads; i++)
            free_worker(&r->workers[i]);
    crisp_free(r->workers);
    crisp_pool_destroy(r->pool);
    crisp_arena_destroy(r->arena);
    crisp_free(r->tasks);
    crisp_free(r->xs);
    crisp_free(r->ys);
    crisp_free(r->zs);
    crisp_free(r->deferred);
    crisp_free(r->img.inside);
    crisp_free(r->img.heights);
    crisp_free(r->img.z);
    crisp_free(r->img.normal);
    free(r);
}

crisp_status crisp_frep_renderer_create(const crisp_frep_tape *tape,
                                        const crisp_frep_render_desc *desc,
                                        crisp_frep_renderer **dest)
{
    if (!tape || !desc || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_renderer_create: NULL argument");
    if (desc->width < 1 || desc->height < 1 || desc->depth < 0 || desc->width > 65536 ||
        desc->height > 65536 || desc->depth > 65536)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_frep_renderer_create: size %dx%dx%d is outside 1..65536",
                           desc->width, desc->height, desc->depth);
    crisp_frep_renderer *r = calloc(1, sizeof *r);
    if (!r) return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_renderer_create: out of memory");
    r->tape = tape;
    r->desc = *desc;
    double *g = r->desc.region;
    if (!g[0] && !g[1] && !g[2] && !g[3] && !g[4] && !g[5]) {
        g[0] = g[2] = g[4] = -1;
        g[1] = g[3] = g[5] = 1;
    }
    crisp_status s = CRISP_OK;
    for (int a = 0; a < 3; a++)
        if (!(g[2 * a] < g[2 * a + 1]) || !isfinite(g[2 * a]) || !isfinite(g[2 * a + 1]))
            if (a < 2 || desc->depth > 0) {
                s = crisp_error(CRISP_ERR_INVALID_ARG,
                                "crisp_frep_renderer_create: region axis %d [%g, %g] is empty", a,
                                g[2 * a], g[2 * a + 1]);
                goto fail;
            }
    int W = desc->width, H = desc->height, D = desc->depth;
    /* a window of the image (issue 15): its pixels sample their whole-image coordinates */
    const int *win = desc->window;
    int wx = 0, wy = 0, WF = W, HF = H;
    if (win[0] || win[1] || win[2] || win[3]) {
        if (win[0] < 0 || win[1] < 0 || win[2] < 1 || win[3] < 1 || win[0] > W - win[2] ||
            win[1] > H - win[3]) {
            s = crisp_error(CRISP_ERR_INVALID_ARG,
                            "crisp_frep_renderer_create: window %dx%d at (%d, %d) is not inside "
                            "the %dx%d image",
                            win[2], win[3], win[0], win[1], W, H);
            goto fail;
        }
        wx = win[0], wy = win[1], W = win[2], H = win[3];
    }
    size_t npix = (size_t)W * (size_t)H;
    r->img.width = W;
    r->img.height = H;
    r->img.depth = D;
    r->xs = crisp_malloc_array((size_t)W, sizeof *r->xs);
    r->ys = crisp_malloc_array((size_t)H, sizeof *r->ys);
    r->zs = crisp_malloc_array(D > 0 ? (size_t)D : 1, sizeof *r->zs);
    r->img.inside = crisp_malloc_array(npix, 1);
    if (D > 0) {
        r->img.heights = crisp_malloc_array(npix, sizeof *r->img.heights);
        r->img.z = crisp_malloc_array(npix, sizeof *r->img.z);
        r->img.normal = crisp_malloc_array(npix, 3 * sizeof *r->img.normal);
        r->deferred = crisp_calloc_array(npix, 1);
    }
    if (!r->xs || !r->ys || !r->zs || !r->img.inside ||
        (D > 0 && (!r->img.heights || !r->img.z || !r->img.normal || !r->deferred)))
        goto oom;
    for (int i = 0; i < W; i++)
        r->xs[i] = (float)(g[0] + (wx + i + 0.5) * (g[1] - g[0]) / WF);
    for (int j = 0; j < H; j++)
        r->ys[j] = (float)(g[3] - (wy + j + 0.5) * (g[3] - g[2]) / HF);
    r->zs[0] = (float)(0.5 * (g[4] + g[5]));
    for (int k = 0; k < D; k++)
        r->zs[k] = (float)(g[4] + (k + 0.5) * (g[5] - g[4]) / D);

    if ((s = crisp_pool_create(desc->threads, &r->pool))) goto fail;
    r->threads = crisp_pool_threads(r->pool);
    /* task tiles: as large as Fidget's top level, small enough for 16 tasks per thread */
    int t = D > 0 ? 64 : 128;
    while (t > 2 * LEAF &&
           (size_t)((W + t - 1) / t) * (size_t)((H + t - 1) / t) < 16u * (unsigned)r->threads)
        t /= 2;
    r->task_size = t;
    if ((s = crisp_arena_create(1 << 20, &r->arena))) goto fail;
    r->workers = crisp_calloc_array((size_t)r->threads, sizeof *r->workers);
    if (!r->workers) goto oom;
    size_t len = tape->length, nr = (size_t)tape->registers;
    for (int i = 0; i < r->threads; i++) {
        frep_worker *w = &r->workers[i];
        w->tapes = crisp_malloc_array(len * MAX_DEPTH, sizeof *w->tapes);
        w->ssas = crisp_malloc_array(len * 2 * MAX_DEPTH, sizeof *w->ssas);
        if ((s = crisp__frep_scratch_init(&w->sc, len, tape->registers))) goto fail;
        w->choices = crisp_calloc_array(len, 1);
        w->lane_choices = D > 0 ? crisp_calloc_array(len * 8 * MAX_DEPTH, 1) : NULL;
        w->lo = crisp_calloc_array(nr * 2, sizeof *w->lo);
        w->hi = w->lo ? w->lo + nr : NULL;
        w->regs = crisp_calloc_array(nr * FREP_LANES, sizeof *w->regs);
        /* gradients in 3D; the batched intervals' registers in 2D and 3D */
        w->gregs = crisp_calloc_array(nr * 4 * FREP_LANES, sizeof *w->gregs);
        w->live = crisp_calloc_array(nr, 1);
        if (!w->tapes || !w->ssas || !w->choices || !w->lo || !w->regs || !w->live || !w->gregs ||
            (D > 0 && !w->lane_choices))
            goto oom;
    }
    *dest = r;
    return CRISP_OK;
oom:
    s = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_renderer_create: out of memory for %dx%dx%d",
                    desc->width, desc->height, desc->depth);
fail:
    crisp_frep_renderer_destroy(r);
    return s;
}

const crisp_frep_image *crisp_frep_renderer_image(const crisp_frep_renderer *r)
{
    return r ? &r->img : NULL;
}

void crisp_frep_shade(const crisp_frep_image *img, uint8_t *dest)
{
    const float l[3] = {-0.40824829f, 0.40824829f, 0.81649658f};
    size_t npix = (size_t)img->width * (size_t)img->height;
    for (size_t p = 0; p < npix; p++) {
        const float *nrm = img->normal ? img->normal + 3 * p : l;
        float d = nrm[0] * l[0] + nrm[1] * l[1] + nrm[2] * l[2];
        dest[p] = img->inside[p] ? (uint8_t)(40 + 215 * (d > 0 ? d : 0)) : 0;
    }
}

crisp_frep_render_stats crisp_frep_renderer_stats(const crisp_frep_renderer *r)
{
    crisp_frep_render_stats s = {0};
    return r ? r->st : s;
}

/* ---- shared cell helpers --------------------------------------------------------------------- */

/* Interval of the tape over pixels [i0,i1) x [j0,j1) x voxels [k0,k1). */
static size_t cell_interval(const crisp_frep_renderer *r, frep_worker *w, const frep_ins *ins,
                            size_t len, int i0, int i1, int j0, int j1, int k0, int k1, float *lo,
                            float *hi)
{
    float x[2] = {r->xs[i0], r->xs[i1 - 1]}, y[2] = {r->ys[j1 - 1], r->ys[j0]};
    float z[2] = {r->zs[k0], r->zs[k1 - 1]};
    size_t d = crisp__frep_interval(ins, len, w->lo, w->hi, x, y, z, w->choices);
    uint16_t res = ins[len - 1].out;
    *lo = w->lo[res];
    *hi = w->hi[res];
    w->st.intervals++;
    return d;
}

/* The tape for the children of a cell: shortened into dest, or the cell's own when nothing was
 * decided (or pruning is off). */
static frep_span child_tape(const crisp_frep_renderer *r, frep_worker *w, frep_span t,
                            const uint8_t *choices, size_t decided, int depth)
{
    if (!decided || (r->desc.flags & CRISP_FREP_NO_PRUNE) || depth >= MAX_DEPTH) return t;
    size_t d = (size_t)depth;
    frep_span out;
    frep_ins *di = w->tapes + d * r->tape->length;
    uint32_t *ds = w->ssas + 2 * d * r->tape->length;
    /* few decisions: prune (cheaper, leaves a copy per decision); many: shorten, which also
     * reallocates registers and renames earlier copies away */
    if (decided * PRUNE_RATIO <= t.len) {
        crisp__frep_prune(t, choices, &w->sc, di, ds, &out);
        return out;
    }
    if (crisp__frep_shorten(t, choices, &w->sc, di, ds, &out))
        return t; /* would need more registers than the scratch holds: keep the longer tape */
    return out;
}

static void fill_inside(crisp_frep_renderer *r, int i0, int i1, int j0, int j1, uint8_t v)
{
    for (int j = j0; j < j1; j++)
        memset(r->img.inside + (size_t)j * r->img.width + i0, v, (size_t)(i1 - i0));
}

/* ---- 2D -------------------------------------------------------------------------------------- */

static void leaf_2d(crisp_frep_renderer *r, frep_worker *w, const frep_ins *ins, size_t len, int i0,
                    int i1, int j0, int j1)
{
    float x[FREP_LANES], y[FREP_LANES], z[FREP_LANES];
    float zc = r->zs[0];
    const float *xs = r->xs, *ys = r->ys;
    for (int k = 0; k < FREP_LANES; k++) {
        int i = i0 + (k & (LEAF - 1)), j = j0 + k / LEAF;
        x[k] = xs[i < i1 ? i : i1 - 1];
        y[k] = ys[j < j1 ? j : j1 - 1];
        z[k] = zc;
    }
    const float *v;
    float one[FREP_LANES];
    if (r->desc.flags & CRISP_FREP_NO_BATCH) {
        for (int k = 0; k < FREP_LANES; k++)
            one[k] = crisp__frep_eval_scalar(ins, len, ins[len - 1].out, w->regs, x[k], y[k], z[k]);
        v = one;
    } else {
        crisp__frep_eval_lanes(ins, len, w->regs, x, y, z);
        v = w->regs + (size_t)ins[len - 1].out * FREP_LANES;
    }
    int wi = i1 - i0;
    for (int j = j0; j < j1; j++) {
        uint8_t *row = r->img.inside + (size_t)j * r->img.width + i0;
        const float *vr = v + (j - j0) * LEAF;
        for (int i = 0; i < wi; i++)
            row[i] = vr[i] < 0 ? 255 : 0;
    }
    w->st.leaves++;
    w->st.points += (size_t)wi * (size_t)(j1 - j0);
    w->st.tape_sum += len;
}

/* The LEAF x LEAF blocks of a cell [i0,i1) x [j0,j1) (at most 16 of them), decided by one batched
 * interval pass on the cell's tape: filled, or evaluated point by point. */
static void leaves_2d(crisp_frep_renderer *r, frep_worker *w, frep_span t, int i0, int i1, int j0,
                      int j1)
{
    float bx[6][FREP_LANES] = {{0}};
    int bi[16], bj[16], n = 0;
    for (int j = j0; j < j1; j += LEAF)
        for (int i = i0; i < i1 && n < 16; i += LEAF) {
            int ib = i + LEAF < i1 ? i + LEAF - 1 : i1 - 1,
                jb = j + LEAF < j1 ? j + LEAF - 1 : j1 - 1;
            bx[0][n] = r->xs[i], bx[1][n] = r->xs[ib];
            bx[2][n] = r->ys[jb], bx[3][n] = r->ys[j];
            bx[4][n] = bx[5][n] = r->zs[0];
            bi[n] = i, bj[n++] = j;
        }
    for (int k = n; k < 16; k++)
        for (int a = 0; a < 6; a++)
            bx[a][k] = bx[a][0];
    const float *box[6] = {bx[0], bx[1], bx[2], bx[3], bx[4], bx[5]};
    float *lo = w->gregs, *hi = w->gregs + (size_t)r->tape->registers * FREP_LANES;
    crisp__frep_interval_lanes(t.ins, t.len, 16, lo, hi, box, NULL, NULL);
    const float *l = lo + (size_t)t.ins[t.len - 1].out * FREP_LANES;
    const float *h = hi + (size_t)t.ins[t.len - 1].out * FREP_LANES;
    w->st.intervals += (size_t)n;
    for (int q = 0; q < n; q++) {
        int ie = bi[q] + LEAF < i1 ? bi[q] + LEAF : i1, je = bj[q] + LEAF < j1 ? bj[q] + LEAF : j1;
        if (l[q] >= 0 || h[q] < 0) {
            fill_inside(r, bi[q], ie, bj[q], je, h[q] < 0 ? 255 : 0);
            w->st.filled++;
        } else {
            leaf_2d(r, w, t.ins, t.len, bi[q], ie, bj[q], je);
        }
    }
}

static void cell_2d(crisp_frep_renderer *r, frep_worker *w, frep_span t, int i0, int j0, int size,
                    int depth)
{
    const frep_ins *ins = t.ins;
    size_t len = t.len;
    int i1 = i0 + size < r->img.width ? i0 + size : r->img.width;
    int j1 = j0 + size < r->img.height ? j0 + size : r->img.height;
    if (i0 >= i1 || j0 >= j1) return;
    if (r->desc.flags & CRISP_FREP_BRUTE) {
        if (size > LEAF) {
            for (int j = j0; j < j1; j += LEAF)
                for (int i = i0; i < i1; i += LEAF)
                    cell_2d(r, w, t, i, j, LEAF, depth);
        } else {
            leaf_2d(r, w, ins, len, i0, i1, j0, j1);
        }
        return;
    }
    if (size < MIN_INTERVAL_2D) {
        /* below the smallest interval cell: batches of 8x8 points on the parent's tape */
        for (int j = j0; j < j1; j += LEAF)
            for (int i = i0; i < i1; i += LEAF)
                leaf_2d(r, w, ins, len, i, i + LEAF < i1 ? i + LEAF : i1, j,
                        j + LEAF < j1 ? j + LEAF : j1);
        return;
    }
    float lo, hi;
    size_t d = cell_interval(r, w, ins, len, i0, i1, j0, j1, 0, 1, &lo, &hi);
    if (hi < 0 || lo >= 0) {
        fill_inside(r, i0, i1, j0, j1, hi < 0 ? 255 : 0);
        w->st.filled++;
        return;
    }
    frep_span ct = child_tape(r, w, t, w->choices, d, depth);
    int c = size / 2;
    if (c < MIN_INTERVAL_2D && !(r->desc.flags & CRISP_FREP_NO_SUBCELLS)) {
        leaves_2d(r, w, ct, i0, i1, j0, j1);
        return;
    }
    for (int j = j0; j < j1; j += c)
        for (int i = i0; i < i1; i += c)
            cell_2d(r, w, ct, i, j, c, depth + 1);
}

/* ---- 3D heightmap ---------------------------------------------------------------------------- */

/* Normals for pixels [npts] at the given points, through the gradient of the tape. */
static void set_normals(crisp_frep_renderer *r, frep_worker *w, const frep_ins *ins, size_t len,
                        const int *pix, int npts, const float *x, const float *y, const float *z)
{
    crisp__frep_grad_lanes(ins, len, w->gregs, x, y, z);
    const float *g = w->gregs + (size_t)ins[len - 1].out * 4 * FREP_LANES;
    for (int k = 0; k < npts; k++) {
        float gx = g[FREP_LANES + k], gy = g[2 * FREP_LANES + k], gz = g[3 * FREP_LANES + k];
        float n2 = gx * gx + gy * gy + gz * gz;
        float *nrm = r->img.normal + 3 * (size_t)pix[k];
        if (n2 > 0 && isfinite(n2)) {
            float s = 1 / sqrtf(n2);
            nrm[0] = gx * s, nrm[1] = gy * s, nrm[2] = gz * s;
        } else {
            nrm[0] = 0, nrm[1] = 0, nrm[2] = 1;
        }
    }
}

/* Normals of hit pixels pix[0, n) at voxels hk: now on the cell's tape ins[0, len) when that
 * costs less than their share of a full batch on the task's tape, else deferred to the task
 * tile's batches (tile_normals). Smooth blends (bear) keep long tapes down to the leaves and
 * defer; min/max-heavy models (colonnade) shorten to a few instructions and compute now. */
static void hit_normals(crisp_frep_renderer *r, frep_worker *w, const frep_ins *ins, size_t len,
                        const int *pix, const int *hk, int n)
{
    if (!n) return;
    if (len * FREP_LANES >= w->task_len * (size_t)n) {
        for (int q = 0; q < n; q++)
            r->deferred[pix[q]] = 1;
        return;
    }
    float x[FREP_LANES], y[FREP_LANES], z[FREP_LANES];
    int W = r->img.width;
    for (int m = 0; m < FREP_LANES; m++) {
        int q = m < n ? m : 0;
        x[m] = r->xs[pix[q] % W], y[m] = r->ys[pix[q] / W], z[m] = r->zs[hk[q]];
    }
    set_normals(r, w, ins, len, pix, n, x, y, z);
}

/* Raise pixels below voxel k to k (the cell is all inside at its top layer k). */
static void fill_top(crisp_frep_renderer *r, frep_worker *w, const frep_ins *ins, size_t len,
                     int i0, int i1, int j0, int j1, int k)
{
    int pix[FREP_LANES], hk[FREP_LANES], n = 0;
    for (int j = j0; j < j1; j++)
        for (int i = i0; i < i1; i++) {
            size_t p = (size_t)j * r->img.width + i;
            if (r->img.heights[p] >= k) continue;
            r->img.heights[p] = k;
            pix[n] = (int)p, hk[n] = k;
            if (++n == FREP_LANES) {
                hit_normals(r, w, ins, len, pix, hk, n);
                n = 0;
            }
        }
    hit_normals(r, w, ins, len, pix, hk, n);
}

/* The deferred normals of a task tile [i0,i1) x [j0,j1), once its column is done, on the task's
 * tape (valid for the whole column) in full batches. */
static void tile_normals(crisp_frep_renderer *r, frep_worker *w, frep_span t, int i0, int i1,
                         int j0, int j1)
{
    int pix[FREP_LANES], n = 0;
    float x[FREP_LANES], y[FREP_LANES], z[FREP_LANES];
    for (int j = j0; j < j1; j++)
        for (int i = i0; i < i1; i++) {
            size_t p = (size_t)j * r->img.width + i;
            if (!r->deferred[p]) continue;
            r->deferred[p] = 0;
            pix[n] = (int)p, x[n] = r->xs[i], y[n] = r->ys[j], z[n] = r->zs[r->img.heights[p]];
            if (++n == FREP_LANES) {
                set_normals(r, w, t.ins, t.len, pix, n, x, y, z);
                n = 0;
            }
        }
    if (n) {
        for (int k = n; k < FREP_LANES; k++)
            x[k] = x[0], y[k] = y[0], z[k] = z[0];
        set_normals(r, w, t.ins, t.len, pix, n, x, y, z);
    }
}

/* Sub-cell states of a leaf (sub_states). */
enum { SUB_OPEN = 0, SUB_OUT = 1, SUB_IN = 2 };

/* Lane `lane` of bx: the box of pixels [ia, ib] x [ja, jb] and voxels [kb, kt] (inclusive). */
static void sub_box(const crisp_frep_renderer *r, float bx[6][FREP_LANES], int lane, int ia, int ib,
                    int ja, int jb, int kb, int kt)
{
    bx[0][lane] = r->xs[ia], bx[1][lane] = r->xs[ib];
    bx[2][lane] = r->ys[jb], bx[3][lane] = r->ys[ja]; /* y falls as j grows */
    bx[4][lane] = r->zs[kb], bx[5][lane] = r->zs[kt];
}

/* Batched intervals of the boxes in bx[..][0, n) on the leaf's tape into state[0, n). The
 * interval registers borrow the gradient scratch. */
static void sub_eval(crisp_frep_renderer *r, frep_worker *w, const frep_ins *ins, size_t len,
                     float bx[6][FREP_LANES], int n, uint8_t *state)
{
    int lanes = (n + 15) & ~15;
    for (int k = n; k < lanes; k++)
        for (int c = 0; c < 6; c++)
            bx[c][k] = bx[c][0];
    const float *box[6] = {bx[0], bx[1], bx[2], bx[3], bx[4], bx[5]};
    float *lo = w->gregs, *hi = w->gregs + (size_t)r->tape->registers * FREP_LANES;
    crisp__frep_interval_lanes(ins, len, lanes, lo, hi, box, NULL, NULL);
    const float *l = lo + (size_t)ins[len - 1].out * FREP_LANES;
    const float *h = hi + (size_t)ins[len - 1].out * FREP_LANES;
    for (int k = 0; k < n; k++)
        state[k] = l[k] >= 0 ? SUB_OUT : h[k] < 0 ? SUB_IN : SUB_OPEN; /* NaN: open */
    w->st.intervals += (size_t)n;
}

/* The 2x2x2-voxel sub-cells of a leaf (at most 4x4x4 = FREP_LANES; index (t * 4 + sj) * 4 + si,
 * layer t counted from the top), each outside, inside or open, by one batched interval pass on
 * the leaf's tape over the sub-cells that some pixel still needs (above the lowest height of
 * their 2x2 pixels; the others are marked outside and never read). Returns 0 without a pass
 * when the pixels need at most SUB_MIN_VOXELS voxels: points are cheaper then. (Two passes, the
 * 4x4x4 octants first and then the 2x2x2 cells of the open ones, evaluate fewer boxes but took
 * 4% more time on bear: a pass costs about the same for any number of lanes up to 64.) */
static int sub_states(crisp_frep_renderer *r, frep_worker *w, const frep_ins *ins, size_t len,
                      int i0, int i1, int j0, int j1, int k0, int k1, uint8_t *state)
{
    float bx[6][FREP_LANES];
    int idx[FREP_LANES], n = 0, need = 0, W = r->img.width;
    int ni = (i1 - i0 + 1) / 2, nj = (j1 - j0 + 1) / 2, nk = (k1 - k0 + 1) / 2;
    int colmin[16];
    for (int c = 0; c < 16; c++)
        colmin[c] = INT32_MAX;
    for (int j = j0; j < j1; j++)
        for (int i = i0; i < i1; i++) {
            int h = r->img.heights[(size_t)j * W + i], c = ((j - j0) / 2) * 4 + (i - i0) / 2;
            colmin[c] = h < colmin[c] ? h : colmin[c];
            need += h < k0 ? k1 - k0 : h < k1 ? k1 - 1 - h : 0;
        }
    if (need <= SUB_MIN_VOXELS) return 0;
    for (int lane = 0; lane < FREP_LANES; lane++) {
        int si = lane & 3, sj = (lane >> 2) & 3, t = lane >> 4;
        int kt = k1 - 1 - 2 * t;
        state[lane] = SUB_OUT;
        if (si >= ni || sj >= nj || t >= nk || kt <= colmin[sj * 4 + si]) continue;
        int ia = i0 + 2 * si, ib = ia + 1 < i1 ? ia + 1 : ia;
        int ja = j0 + 2 * sj, jb = ja + 1 < j1 ? ja + 1 : ja;
        int kb = kt - 1 >= k0 ? kt - 1 : kt;
        sub_box(r, bx, n, ia, ib, ja, jb, kb, kt);
        idx[n++] = lane;
    }
    uint8_t st[FREP_LANES];
    sub_eval(r, w, ins, len, bx, n, st);
    for (int q = 0; q < n; q++)
        state[idx[q]] = st[q];
    return 1;
}

/* A leaf column block: pixels [i0,i1) x [j0,j1) (at most LEAF x LEAF), voxels [k0,k1) (at most
 * LEAF). Each pixel still below the block's top gets its candidate voxels, top down: with
 * sub-cell states, the voxels of its open sub-cells above the first inside one (whose top voxel
 * is then its height unless a candidate hits); without, every voxel. The 64 lanes of a batch are
 * shared among the pixels still open, several candidates each when few are open. */
static void leaf_3d(crisp_frep_renderer *r, frep_worker *w, const frep_ins *ins, size_t len, int i0,
                    int i1, int j0, int j1, int k0, int k1, const uint8_t *state)
{
    float x[FREP_LANES], y[FREP_LANES], z[FREP_LANES];
    int lane_pix[FREP_LANES], lane_k[FREP_LANES];
    int cand[FREP_LANES][LEAF], nc[FREP_LANES], pos[FREP_LANES], fb[FREP_LANES];
    int hitp[FREP_LANES], hitk[FREP_LANES], nhit = 0, npix = 0, open = 0;
    size_t p[FREP_LANES];
    float px[FREP_LANES], py[FREP_LANES];
    for (int j = j0; j < j1; j++)
        for (int i = i0; i < i1; i++) {
            size_t q = (size_t)j * r->img.width + i;
            int h = r->img.heights[q];
            if (h >= k1 - 1) continue; /* already at or above this block */
            int n = 0, f = -1;
            if (state) {
                const uint8_t *col = state + ((j - j0) / 2) * 4 + (i - i0) / 2;
                for (int t = 0; 2 * t < k1 - k0; t++) {
                    int kt = k1 - 1 - 2 * t;
                    if (kt <= h) break;
                    uint8_t st = col[16 * t];
                    if (st == SUB_OUT) continue;
                    if (st == SUB_IN) {
                        f = kt;
                        break;
                    }
                    cand[npix][n++] = kt;
                    if (kt - 1 >= k0 && kt - 1 > h) cand[npix][n++] = kt - 1;
                }
            } else {
                for (int k = k1 - 1; k >= k0 && k > h; k--)
                    cand[npix][n++] = k;
            }
            if (!n && f < 0) continue;
            p[npix] = q;
            px[npix] = r->xs[i];
            py[npix] = r->ys[j];
            nc[npix] = n;
            pos[npix] = 0;
            fb[npix] = f;
            open += n > 0;
            npix++;
        }
    uint16_t res = ins[len - 1].out;
    while (open > 0) {
        /* share the lanes: each open pixel takes up to `each` of its next candidates */
        int each = FREP_LANES / open, n = 0;
        for (int q = 0; q < npix; q++)
            for (int d = pos[q]; d < nc[q] && d < pos[q] + each; d++) {
                lane_pix[n] = q;
                lane_k[n] = cand[q][d];
                x[n] = px[q], y[n] = py[q], z[n] = r->zs[cand[q][d]];
                n++;
            }
        for (int k = n; k < FREP_LANES; k++)
            x[k] = x[0], y[k] = y[0], z[k] = z[0];
        const float *v;
        float one[FREP_LANES];
        if (r->desc.flags & CRISP_FREP_NO_BATCH) {
            for (int k = 0; k < n; k++)
                one[k] = crisp__frep_eval_scalar(ins, len, res, w->regs, x[k], y[k], z[k]);
            v = one;
        } else {
            crisp__frep_eval_lanes(ins, len, w->regs, x, y, z);
            v = w->regs + (size_t)res * FREP_LANES;
        }
        w->st.points += (size_t)n;
        /* lanes of one pixel are consecutive, highest first: the first inside one wins */
        for (int k = 0; k < n; k++) {
            int q = lane_pix[k];
            if (pos[q] >= nc[q]) continue; /* decided by an earlier lane of this batch */
            if (v[k] < 0) {
                r->img.heights[p[q]] = lane_k[k];
                hitp[nhit] = (int)p[q];
                hitk[nhit++] = lane_k[k];
                pos[q] = nc[q] + 1;
                fb[q] = -1;
                open--;
            } else if (++pos[q] == nc[q]) {
                open--;
            }
        }
    }
    /* no candidate hit: the top of the first inside sub-cell */
    for (int q = 0; q < npix; q++)
        if (fb[q] >= 0) {
            r->img.heights[p[q]] = fb[q];
            hitp[nhit] = (int)p[q];
            hitk[nhit++] = fb[q];
        }
    w->st.leaves++;
    w->st.tape_sum += len;
    hit_normals(r, w, ins, len, hitp, hitk, nhit);
}

static int min_height(const crisp_frep_renderer *r, int i0, int i1, int j0, int j1)
{
    int m = INT32_MAX;
    for (int j = j0; j < j1; j++) {
        const int32_t *row = r->img.heights + (size_t)j * r->img.width;
        for (int i = i0; i < i1; i++)
            m = row[i] < m ? row[i] : m;
    }
    return m;
}

static void children_3d(crisp_frep_renderer *r, frep_worker *w, frep_span t, int i0, int j0, int k0,
                        int size, int depth);

/* A cell [i0,i1) x [j0,j1) x [kk0,k1) (of nominal size `size` from k0) whose interval [lo, hi]
 * is known, with its tape ct (already shortened for it). */
static void cell_3d_decided(crisp_frep_renderer *r, frep_worker *w, frep_span ct, int i0, int i1,
                            int j0, int j1, int k0, int kk0, int k1, int size, int depth, float lo,
                            float hi)
{
    if (lo >= 0) {
        w->st.filled++;
        return;
    }
    if (hi < 0) {
        fill_top(r, w, ct.ins, ct.len, i0, i1, j0, j1, k1 - 1);
        w->st.filled++;
        return;
    }
    if (size <= LEAF) {
        uint8_t state[FREP_LANES];
        int sub = !(r->desc.flags & CRISP_FREP_NO_SUBCELLS);
        if (sub) sub = sub_states(r, w, ct.ins, ct.len, i0, i1, j0, j1, kk0, k1, state);
        leaf_3d(r, w, ct.ins, ct.len, i0, i1, j0, j1, kk0, k1, sub ? state : NULL);
        return;
    }
    children_3d(r, w, ct, i0, j0, k0, size, depth + 1);
}

/* The eight children of an undecided cell (tape t), their intervals and min/max choices in one
 * batched pass, then each in turn, upper half first so that the first hit of a pixel is its
 * highest; each child's tape is shortened just before it is visited. */
static void children_3d(crisp_frep_renderer *r, frep_worker *w, frep_span t, int i0, int j0, int k0,
                        int size, int depth)
{
    int c = size / 2, W = r->img.width, H = r->img.height, D = r->img.depth;
    int ci0[8], ci1[8], cj0[8], cj1[8], ck0[8], ckk0[8], ck1[8], valid[8], n = 0;
    float bx[6][FREP_LANES];
    for (int q = 0; q < 8; q++) {
        int kz = 1 - (q >> 2), jy = (q >> 1) & 1, ix = q & 1;
        ci0[q] = i0 + ix * c, cj0[q] = j0 + jy * c, ck0[q] = k0 + kz * c;
        ci1[q] = ci0[q] + c < W ? ci0[q] + c : W;
        cj1[q] = cj0[q] + c < H ? cj0[q] + c : H;
        ck1[q] = ck0[q] + c < D ? ck0[q] + c : D;
        ckk0[q] = ck0[q] < 0 ? 0 : ck0[q];
        valid[q] = ci0[q] < ci1[q] && cj0[q] < cj1[q] && ckk0[q] < ck1[q];
        n += valid[q];
    }
    for (int q = 0; q < 8; q++) {
        int s = valid[q] ? q : 0;
        while (!valid[s])
            s++; /* lanes of empty children repeat a valid one */
        sub_box(r, bx, q, ci0[s], ci1[s] - 1, cj0[s], cj1[s] - 1, ckk0[s], ck1[s] - 1);
    }
    for (int k = 8; k < 16; k++)
        for (int a = 0; a < 6; a++)
            bx[a][k] = bx[a][0];
    const float *box[6] = {bx[0], bx[1], bx[2], bx[3], bx[4], bx[5]};
    size_t len = t.len, decided[16] = {0};
    uint8_t *choices =
        w->lane_choices + (size_t)(depth < MAX_DEPTH ? depth : MAX_DEPTH - 1) * 8 * r->tape->length;
    float *lo = w->gregs, *hi = w->gregs + (size_t)r->tape->registers * FREP_LANES;
    crisp__frep_interval_lanes(t.ins, len, 16, lo, hi, box, choices, decided);
    uint16_t res = t.ins[len - 1].out;
    float clo[8], chi[8];
    for (int q = 0; q < 8; q++)
        clo[q] = lo[(size_t)res * FREP_LANES + q], chi[q] = hi[(size_t)res * FREP_LANES + q];
    w->st.intervals += (size_t)n;
    for (int q = 0; q < 8; q++) {
        if (!valid[q]) continue;
        /* z-culling: every pixel already at or above this child's top */
        if (min_height(r, ci0[q], ci1[q], cj0[q], cj1[q]) >= ck1[q] - 1) {
            w->st.culled++;
            continue;
        }
        /* a leaf keeps its parent's tape when it decided few min/max: on bear (smooth blends)
         * pruning for a leaf cost more than the shorter tape saved (7%) */
        int keep = clo[q] >= 0 || (c <= LEAF && decided[q] * PRUNE_RATIO <= len);
        frep_span ct = keep ? t : child_tape(r, w, t, choices + (size_t)q * len, decided[q], depth);
        cell_3d_decided(r, w, ct, ci0[q], ci1[q], cj0[q], cj1[q], ck0[q], ckk0[q], ck1[q], c, depth,
                        clo[q], chi[q]);
    }
}

/* A task's cube (tape t): culled, decided by one interval, or split. */
static void cell_3d(crisp_frep_renderer *r, frep_worker *w, frep_span t, int i0, int j0, int k0,
                    int size, int depth)
{
    const frep_ins *ins = t.ins;
    size_t len = t.len;
    int i1 = i0 + size < r->img.width ? i0 + size : r->img.width;
    int j1 = j0 + size < r->img.height ? j0 + size : r->img.height;
    int k1 = k0 + size < r->img.depth ? k0 + size : r->img.depth;
    int kk0 = k0 < 0 ? 0 : k0; /* the bottom cube of a column may reach below the grid */
    if (i0 >= i1 || j0 >= j1 || kk0 >= k1) return;
    /* z-culling: every pixel already at or above this cell's top */
    if (min_height(r, i0, i1, j0, j1) >= k1 - 1) {
        w->st.culled++;
        return;
    }
    if (r->desc.flags & CRISP_FREP_BRUTE) {
        if (size > LEAF) {
            for (int k = k1 - LEAF; k > kk0 - LEAF; k -= LEAF)
                for (int j = j0; j < j1; j += LEAF)
                    for (int i = i0; i < i1; i += LEAF)
                        cell_3d(r, w, t, i, j, k, LEAF, depth);
        } else {
            leaf_3d(r, w, ins, len, i0, i1, j0, j1, kk0, k1, NULL);
        }
        return;
    }
    float lo, hi;
    size_t d = cell_interval(r, w, ins, len, i0, i1, j0, j1, kk0, k1, &lo, &hi);
    frep_span ct = lo >= 0 ? t : child_tape(r, w, t, w->choices, d, depth);
    cell_3d_decided(r, w, ct, i0, i1, j0, j1, k0, kk0, k1, size, depth, lo, hi);
}

/* ---- run ------------------------------------------------------------------------------------- */

/* Serial pre-pass: quadtree (2D) down to the task size, collecting undecided task tiles. */
static crisp_status prepass(crisp_frep_renderer *r, frep_span t, int i0, int j0, int size)
{
    const frep_ins *ins = t.ins;
    size_t len = t.len;
    int W = r->img.width, H = r->img.height;
    if (i0 >= W || j0 >= H) return CRISP_OK;
    if (size > r->task_size && (r->desc.flags & CRISP_FREP_BRUTE)) {
        for (int q = 0; q < 4; q++) {
            crisp_status s =
                prepass(r, t, i0 + (q & 1) * size / 2, j0 + (q >> 1) * size / 2, size / 2);
            if (s) return s;
        }
        return CRISP_OK;
    }
    if (size > r->task_size) {
        int i1 = i0 + size < W ? i0 + size : W, j1 = j0 + size < H ? j0 + size : H;
        frep_worker *w = &r->workers[0];
        float lo, hi;
        int is3 = r->img.depth > 0;
        size_t d =
            cell_interval(r, w, ins, len, i0, i1, j0, j1, 0, is3 ? r->img.depth : 1, &lo, &hi);
        if (lo >= 0) {
            if (!is3) fill_inside(r, i0, i1, j0, j1, 0);
            return CRISP_OK;
        }
        if (hi < 0 && !is3) {
            fill_inside(r, i0, i1, j0, j1, 255);
            return CRISP_OK;
        }
        if (d && !(r->desc.flags & CRISP_FREP_NO_PRUNE)) {
            frep_ins *ti = crisp_arena_alloc(r->arena, len, sizeof *ti);
            uint32_t *ts = crisp_arena_alloc(r->arena, 2 * len, sizeof *ts);
            if (!ti || !ts)
                return crisp_error(CRISP_ERR_NO_MEMORY, "frep render: out of memory for tapes");
            frep_span out;
            if (!crisp__frep_shorten(t, w->choices, &w->sc, ti, ts, &out)) t = out;
        }
        int c = size / 2;
        for (int q = 0; q < 4; q++) {
            crisp_status s = prepass(r, t, i0 + (q & 1) * c, j0 + (q >> 1) * c, c);
            if (s) return s;
        }
        return CRISP_OK;
    }
    if (crisp_grow((void **)&r->tasks, &r->task_cap, r->ntasks + 1, sizeof *r->tasks))
        return crisp_error(CRISP_ERR_NO_MEMORY, "frep render: out of memory for tasks");
    r->tasks[r->ntasks++] = (frep_task){i0, j0, t};
    return CRISP_OK;
}

static void run_tasks(void *ctx, size_t begin, size_t end, int worker)
{
    crisp_frep_renderer *r = ctx;
    frep_worker *w = &r->workers[worker];
    int t = r->task_size;
    for (size_t n = begin; n < end; n++) {
        const frep_task *tk = &r->tasks[n];
        if (r->img.depth == 0) {
            cell_2d(r, w, tk->tape, tk->i0, tk->j0, t, 0);
        } else {
            /* a column of cubes, top down */
            w->task_len = tk->tape.len;
            for (int k0 = r->img.depth - t; k0 > -t; k0 -= t)
                cell_3d(r, w, tk->tape, tk->i0, tk->j0, k0, t, 0);
            int i1 = tk->i0 + t < r->img.width ? tk->i0 + t : r->img.width;
            int j1 = tk->j0 + t < r->img.height ? tk->j0 + t : r->img.height;
            tile_normals(r, w, tk->tape, tk->i0, i1, tk->j0, j1);
        }
    }
}

crisp_status crisp_frep_renderer_run(crisp_frep_renderer *r)
{
    if (!r) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_renderer_run: NULL renderer");
    int W = r->img.width, H = r->img.height, D = r->img.depth;
    size_t npix = (size_t)W * (size_t)H;
    if (D > 0) {
        for (size_t p = 0; p < npix; p++)
            r->img.heights[p] = -1;
    }
    for (int i = 0; i < r->threads; i++)
        memset(&r->workers[i].st, 0, sizeof r->workers[i].st);
    crisp_arena_reset(r->arena);
    r->ntasks = 0;
    int root = r->task_size;
    while (root < W || root < H)
        root *= 2;
    const crisp_frep_tape *tp = r->tape;
    crisp_status s =
        prepass(r, (frep_span){tp->ins, tp->ssa, tp->length, tp->registers}, 0, 0, root);
    if (s) return s;
    crisp_pool_parallel_for(r->pool, r->ntasks, 1, run_tasks, r);
    memset(&r->st, 0, sizeof r->st);
    for (int i = 0; i < r->threads; i++) {
        const crisp_frep_render_stats *a = &r->workers[i].st;
        r->st.intervals += a->intervals;
        r->st.filled += a->filled;
        r->st.leaves += a->leaves;
        r->st.points += a->points;
        r->st.culled += a->culled;
        r->st.tape_sum += a->tape_sum;
    }
    if (D > 0) {
        for (size_t p = 0; p < npix; p++) {
            int h = r->img.heights[p];
            r->img.inside[p] = h >= 0 ? 255 : 0;
            r->img.z[p] = h >= 0 ? r->zs[h] : -INFINITY;
            if (h < 0)
                r->img.normal[3 * p] = r->img.normal[3 * p + 1] = r->img.normal[3 * p + 2] = 0;
        }
    }
    return CRISP_OK;
}
