/* Region fit: a box that covers an f-rep part, found by interval subdivision of a search box
 * (Keeter 2012's interval classification, used here to bound the part instead of drawing it).
 *
 * The union of the octree cells (depth 6 in 3D, 8 in 2D, tape shortened per cell, octree.c) that
 * are not proven outside contains every point of the part in the search box; its bounding box is
 * the fit, and octrees over cubes around it refine the fit while the part is small in the cube (4
 * passes). A part that reaches the search box's side is flagged unbounded on that axis. A cell
 * whose interval stays NaN at the finest level (an undefined expression) counts only when one of 64
 * sample points in it is inside: a guess, counted in crisp_frep_fit.sampled. With a budget of
 * intervals, the cells left unsplit count whole: still conservative.
 * By default the search box grows, [-R, R]^3 for R = 2, 8, 32, ..., 1024: intervals over huge
 * boxes are loose (exp overflows to NaN), so a part near the origin is fitted in a small box. */
#include "frep_octree.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define FIT_SEARCH 1024.0
/* depth of the fit's octree (cells of 1/64 of the search box in 3D, 1/256 in 2D), and its
 * budget of intervals per search box */
#define FIT_DEPTH_3D 6
#define FIT_DEPTH_2D 8
#define FIT_MAX_INTERVALS 400000

typedef struct fit_ctx {
    frep_octree o;
    float *regs;
    float box[6];
    int any, unknown_used;
    size_t sampled;
} fit_ctx;

/* An undecided (NaN) cell: a 4^3 grid of points; 1 when one is inside. */
static int sample_inside(fit_ctx *c, frep_span t, const float b[6])
{
    float x[FREP_LANES], y[FREP_LANES], z[FREP_LANES];
    for (int k = 0; k < FREP_LANES; k++) {
        int q[3] = {k & 3, (k >> 2) & 3, k >> 4};
        float *p[3] = {&x[k], &y[k], &z[k]};
        for (int a = 0; a < 3; a++)
            *p[a] = b[2 * a] + (b[2 * a + 1] - b[2 * a]) * (q[a] + 0.5f) / 4;
    }
    crisp__frep_eval_lanes(t.ins, t.len, c->regs, x, y, z);
    const float *v = c->regs + (size_t)t.ins[t.len - 1].out * FREP_LANES;
    for (int k = 0; k < FREP_LANES; k++)
        if (v[k] < 0) return 1;
    return 0;
}

static int fit_visit(void *ctx, const float b[6], int depth, int cls, frep_span t)
{
    (void)depth;
    fit_ctx *c = ctx;
    if (cls == FREP_CELL_OUT) return 0;
    if (cls == FREP_CELL_UNKNOWN && !c->o.truncated) {
        c->sampled++;
        if (!sample_inside(c, t, b)) return 0; /* undefined and no inside point: a guess */
        c->unknown_used = 1;
    }
    if (!c->any) memcpy(c->box, b, sizeof c->box);
    for (int a = 0; a < 3; a++) {
        c->box[2 * a] = b[2 * a] < c->box[2 * a] ? b[2 * a] : c->box[2 * a];
        c->box[2 * a + 1] = b[2 * a + 1] > c->box[2 * a + 1] ? b[2 * a + 1] : c->box[2 * a + 1];
    }
    c->any = 1;
    return 0;
}

/* The fit within one search box s (already checked): the union of the octree's cells not proven
 * outside at depth FIT_DEPTH, then again over a cube around that union for a finer fit. */
static crisp_status fit_box(fit_ctx *c, const double s[6], int planar, crisp_frep_fit *dest)
{
    memset(dest, 0, sizeof *dest);
    float root[6];
    for (int k = 0; k < 6; k++)
        root[k] = (float)s[k];
    if (planar) root[4] = root[5] = (float)(0.5 * (s[4] + s[5]));
    int axes = planar ? 2 : 3;
    float cur[6];
    memcpy(cur, root, sizeof cur);
    size_t intervals = 0;
    float cell = 0;
    c->sampled = 0;
    for (int pass = 0; pass < 4; pass++) {
        c->any = 0, c->o.intervals = 0, c->unknown_used = 0;
        crisp__frep_octree_walk(&c->o, cur);
        intervals += c->o.intervals;
        dest->overflow |= c->o.truncated;
        if (!c->any) {
            dest->empty = 1;
            if (c->sampled)
                return crisp_error(
                    CRISP_ERR_NUMERIC,
                    "no inside point in [%g, %g] x [%g, %g] x [%g, %g]: the function "
                    "is NaN (undefined) in %zu cells and outside elsewhere",
                    cur[0], cur[1], cur[2], cur[3], cur[4], cur[5], c->sampled);
            return crisp_error(CRISP_ERR_NUMERIC,
                               "the part is empty: every point of [%g, %g] x [%g, %g] x [%g, %g] "
                               "is proven outside (f >= 0)",
                               cur[0], cur[1], cur[2], cur[3], cur[4], cur[5]);
        }
        float size = 0;
        for (int a = 0; a < axes; a++)
            size = fmaxf(size, cur[2 * a + 1] - cur[2 * a]);
        cell = size / (float)(1 << c->o.max_depth);
        if (pass == 0) {
            for (int a = 0; a < axes; a++)
                if (c->box[2 * a] <= root[2 * a] || c->box[2 * a + 1] >= root[2 * a + 1])
                    dest->unbounded |= 1u << a;
        }
        if (c->unknown_used) dest->unknown = 7;
        /* a cube around the union, inside the search box: nothing outside it is inside */
        float half = 0, mid[3];
        for (int a = 0; a < axes; a++) {
            mid[a] = 0.5f * (c->box[2 * a] + c->box[2 * a + 1]);
            half = fmaxf(half, 0.5f * (c->box[2 * a + 1] - c->box[2 * a]));
        }
        if (half * 5 > size || dest->unbounded) break; /* the cells are fine enough */
        for (int a = 0; a < axes; a++) {
            /* the union's own box is inside [mid - half, mid + half] by construction */
            cur[2 * a] = fmaxf(mid[a] - half, root[2 * a]);
            cur[2 * a + 1] = fminf(mid[a] + half, root[2 * a + 1]);
        }
    }
    for (int k = 0; k < 6; k++)
        dest->box[k] = c->box[k];
    if (planar) dest->box[4] = dest->box[5] = root[4];
    dest->cell = cell;
    dest->intervals = intervals;
    dest->sampled = c->sampled;
    for (int k = 0; k < 6; k++)
        dest->search[k] = root[k];
    return CRISP_OK;
}

crisp_status crisp_frep_fit_region(const crisp_frep_tape *t, const crisp_frep_fit_desc *desc,
                                   crisp_frep_fit *dest)
{
    if (!t || !desc || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_fit_region: NULL argument");
    memset(dest, 0, sizeof *dest);
    int zero = 1, axes = desc->planar ? 2 : 3;
    for (int k = 0; k < 6; k++)
        zero &= desc->search[k] == 0;
    for (int a = 0; !zero && a < axes; a++) {
        const double *s = desc->search;
        if (!(s[2 * a] < s[2 * a + 1]) || !isfinite(s[2 * a]) || !isfinite(s[2 * a + 1]) ||
            fabs(s[2 * a]) > 1e30 || fabs(s[2 * a + 1]) > 1e30)
            return crisp_error(
                CRISP_ERR_INVALID_ARG,
                "crisp_frep_fit_region: search box axis %d [%g, %g] is empty or not finite", a,
                s[2 * a], s[2 * a + 1]);
    }
    fit_ctx c = {0};
    crisp_status st = crisp__frep_octree_init(&c.o, t, desc->planar ? FIT_DEPTH_2D : FIT_DEPTH_3D);
    if (st) return st;
    c.o.planar = desc->planar;
    c.o.max_intervals = desc->max_intervals ? desc->max_intervals : FIT_MAX_INTERVALS;
    c.o.visit = fit_visit;
    c.o.ctx = &c;
    c.regs = crisp_malloc_array((size_t)t->registers * FREP_LANES, sizeof *c.regs);
    if (!c.regs) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_fit_region: out of memory");
        goto done;
    }
    if (!zero) {
        st = fit_box(&c, desc->search, desc->planar, dest);
        goto done;
    }
    /* the default: growing cubes [-R, R]^3, R = 2, 8, ..., 1024; the first whose fit is bounded
     * (on the axes not in free_axes) and complete is taken. Intervals over huge boxes are loose
     * (exp overflows, NaN), so a part near the origin is fitted in a small box first. */
    size_t total = 0;
    unsigned free_axes = desc->free_axes | (desc->planar ? 4u : 0u);
    for (double R = 2;; R *= 4) {
        if (R > FIT_SEARCH) R = FIT_SEARCH;
        double s[6] = {-R, R, -R, R, -R, R};
        if (desc->planar) s[4] = s[5] = 0;
        st = fit_box(&c, s, desc->planar, dest);
        total += dest->intervals;
        if (st) {
            if (!dest->empty || R >= FIT_SEARCH) break;
            crisp_error_clear(); /* empty near the origin: look further */
            st = CRISP_OK;
        } else if ((!(dest->unbounded & ~free_axes) && !dest->overflow) || R >= FIT_SEARCH) {
            break;
        }
    }
    dest->intervals = total;
done:
    crisp__frep_octree_free(&c.o);
    crisp_free(c.regs);
    return st;
}

crisp_status crisp_frep_fit_check(const crisp_frep_fit *fit, unsigned allowed_unbounded)
{
    static const char axis[3] = {'x', 'y', 'z'};
    for (int a = 0; a < 3; a++) {
        if (!(fit->unbounded & (1u << a)) || (allowed_unbounded & (1u << a))) continue;
        if (fit->unknown & (1u << a))
            return crisp_error(CRISP_ERR_NUMERIC,
                               "the part's function is NaN (undefined) out to the search box in %c "
                               "(%g .. %g): check the expression, or give a region",
                               axis[a], fit->box[2 * a], fit->box[2 * a + 1]);
        return crisp_error(
            CRISP_ERR_NUMERIC,
            "the part is unbounded in %c: it reaches the search box's side (%g .. %g of "
            "[%g, %g]); give a region",
            axis[a], fit->box[2 * a], fit->box[2 * a + 1], fit->search[2 * a],
            fit->search[2 * a + 1]);
    }
    return CRISP_OK;
}
