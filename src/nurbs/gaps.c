/* Gaps between faces (issue 13): where the boundary of one face runs near another face's
 * boundary but farther from it than the file's tolerance, the model has a crack that the file
 * put there (the renderer draws what the file says). crisp info reports such places instead of
 * hiding them.
 *
 * Method: every trim curve is sampled (32 points, mapped through its surface) into a polyline;
 * the segments go into a uniform grid. For each sample, the nearest segment of another face
 * within `limit` is found; when it is farther than tol, the distance is refined against that
 * face's true boundary curve (golden-section search on the curve parameter around the segment)
 * so that chord error does not count as a gap. A boundary sample with no other face within
 * `limit` is a free edge (an open shell's rim, a face alone), not a gap, nor is one whose nearest
 * other boundary lies ahead along its own (two free edges leaving one vertex). Samples in a gap are
 * grouped per pair of faces; each group reports its largest gap and where. */
#include "crisp/model.h"

#include "nurbs_internal.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define GAP_SAMPLES 32
#define GAP_MAX_SEGMENTS (1 << 22)

typedef struct bseg {
    double a[3], b[3];
    int face, loop, curve;
    double t0, t1; /* curve parameters of a and b */
} bseg;

/* A hashed uniform grid: only the cells that hold segments are stored (open addressing on the
 * cell's packed coordinates), so cells can be much finer than the model's box allows for a dense
 * array. Each slot holds its cell's range in items (CSR). */
#define GAP_EMPTY UINT64_MAX

typedef struct grid {
    double lo[3], h;
    int n[3];
    size_t mask;      /* slots - 1 (a power of two) */
    uint64_t *keys;   /* packed cell coordinates, GAP_EMPTY when free */
    int *start, *cnt; /* per slot: first item and count */
    int *items;       /* segment indices */
} grid;

static uint64_t cell_key(int x, int y, int z)
{
    return ((uint64_t)x << 42) | ((uint64_t)y << 21) | (uint64_t)z;
}

/* The slot of a cell: its own when present (or, with insert, a free one now taken), else -1. */
static long long cell_slot(grid *g, uint64_t key, int insert)
{
    uint64_t h = key * 0x9E3779B97F4A7C15ull;
    size_t i = (size_t)(h >> 20) & g->mask;
    for (;;) {
        if (g->keys[i] == key) return (long long)i;
        if (g->keys[i] == GAP_EMPTY) {
            if (!insert) return -1;
            g->keys[i] = key;
            return (long long)i;
        }
        i = (i + 1) & g->mask;
    }
}

static void seg_box_cells(const grid *g, const bseg *s, int c0[3], int c1[3])
{
    for (int k = 0; k < 3; k++) {
        double lo = fmin(s->a[k], s->b[k]), hi = fmax(s->a[k], s->b[k]);
        c0[k] = (int)floor((lo - g->lo[k]) / g->h);
        c1[k] = (int)floor((hi - g->lo[k]) / g->h);
        if (c0[k] < 0) c0[k] = 0;
        if (c1[k] >= g->n[k]) c1[k] = g->n[k] - 1;
        if (c0[k] > c1[k]) c0[k] = c1[k];
    }
}

static double seg_dist(const double p[3], const bseg *s, double *w)
{
    double d[3], q[3], len2 = 0, t = 0;
    for (int k = 0; k < 3; k++)
        d[k] = s->b[k] - s->a[k], len2 += d[k] * d[k];
    if (len2 > 0)
        t = ((p[0] - s->a[0]) * d[0] + (p[1] - s->a[1]) * d[1] + (p[2] - s->a[2]) * d[2]) / len2;
    if (t < 0) t = 0;
    if (t > 1) t = 1;
    for (int k = 0; k < 3; k++)
        q[k] = s->a[k] + t * d[k] - p[k];
    if (w) *w = t;
    return sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
}

static void boundary_point(const crisp_model *m, int face, int loop, int curve, double t,
                           double p[3])
{
    const crisp_face *f = &m->faces[face];
    double uv[2];
    crisp_curve_eval(f->loops[loop].curves[curve], t, uv);
    crisp_surface_eval(f->surface, uv[0], uv[1], p);
}

static double dist3(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}

/* Distance from p to the true boundary curve near segment s (parameters widened by a segment
 * each way, golden-section search). */
static double refine(const crisp_model *m, const bseg *s, const double p[3])
{
    const crisp_curve *c = m->faces[s->face].loops[s->loop].curves[s->curve];
    double d0, d1;
    crisp_curve_domain(c, &d0, &d1);
    double w = s->t1 - s->t0, lo = fmax(d0, s->t0 - w), hi = fmin(d1, s->t1 + w);
    const double g = 0.6180339887498949;
    double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo), q[3], f1, f2;
    boundary_point(m, s->face, s->loop, s->curve, x1, q);
    f1 = dist3(p, q);
    boundary_point(m, s->face, s->loop, s->curve, x2, q);
    f2 = dist3(p, q);
    for (int it = 0; it < 50; it++) {
        if (f1 < f2) {
            hi = x2, x2 = x1, f2 = f1, x1 = hi - g * (hi - lo);
            boundary_point(m, s->face, s->loop, s->curve, x1, q);
            f1 = dist3(p, q);
        } else {
            lo = x1, x1 = x2, f1 = f2, x2 = lo + g * (hi - lo);
            boundary_point(m, s->face, s->loop, s->curve, x2, q);
            f2 = dist3(p, q);
        }
    }
    return fmin(f1, f2);
}

static int cmp_gap(const void *a, const void *b)
{
    double x = ((const crisp_gap *)a)->gap, y = ((const crisp_gap *)b)->gap;
    return (x < y) - (x > y);
}

crisp_status crisp_model_gaps(const crisp_model *m, double tol, double limit,
                              crisp_gap_report *dest)
{
    memset(dest, 0, sizeof *dest);
    dest->tolerance = tol;
    dest->limit = limit;
    if (!(limit > tol) || !(tol >= 0)) return CRISP_OK;
    /* Boundary polylines whose chords stay within tol / 4 of their curves (bisection, from
     * GAP_SAMPLES segments per curve, at most 2^12 times finer), so that a distance between
     * polylines is one between boundaries. */
    size_t nseg = 0, cap = 0;
    bseg *segs = NULL;
    crisp_status st = CRISP_OK;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    enum { DEPTH = 12 };
    for (int f = 0; f < m->face_count && !st; f++)
        for (int l = 0; l < m->faces[f].loop_count && !st; l++)
            for (int c = 0; c < m->faces[f].loops[l].curve_count && !st; c++) {
                double t0, t1;
                crisp_curve_domain(m->faces[f].loops[l].curves[c], &t0, &t1);
                for (int i = 1; i <= GAP_SAMPLES && !st; i++) {
                    /* depth-first bisection of [ta, tb] */
                    double stack_t[2 * (DEPTH + 2)][2];
                    int depth[2 * (DEPTH + 2)], sp = 0;
                    stack_t[sp][0] = t0 + (t1 - t0) * (i - 1) / GAP_SAMPLES;
                    stack_t[sp][1] = t0 + (t1 - t0) * i / GAP_SAMPLES;
                    depth[sp++] = 0;
                    while (sp > 0 && !st) {
                        sp--;
                        double ta = stack_t[sp][0], tb = stack_t[sp][1], pa[3], pb[3], pm[3];
                        int dp = depth[sp];
                        boundary_point(m, f, l, c, ta, pa);
                        boundary_point(m, f, l, c, tb, pb);
                        boundary_point(m, f, l, c, 0.5 * (ta + tb), pm);
                        double mid[3] = {0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]),
                                         0.5 * (pa[2] + pb[2])};
                        if (dp < DEPTH && dist3(mid, pm) > 0.25 * tol) {
                            /* right half first on the stack: the left comes out first */
                            stack_t[sp][0] = 0.5 * (ta + tb), stack_t[sp][1] = tb,
                            depth[sp++] = dp + 1;
                            stack_t[sp][0] = ta, stack_t[sp][1] = 0.5 * (ta + tb),
                            depth[sp++] = dp + 1;
                            continue;
                        }
                        if (nseg >= GAP_MAX_SEGMENTS) {
                            dest->incomplete = 1;
                            goto out0;
                        }
                        if (nseg == cap &&
                            crisp_grow((void **)&segs, &cap, nseg + 1, sizeof *segs)) {
                            st =
                                crisp_error(CRISP_ERR_NO_MEMORY, "crisp_model_gaps: out of memory");
                            break;
                        }
                        bseg *s = &segs[nseg++];
                        s->face = f, s->loop = l, s->curve = c, s->t0 = ta, s->t1 = tb;
                        memcpy(s->a, pa, sizeof pa);
                        memcpy(s->b, pb, sizeof pb);
                        for (int q = 0; q < 3; q++) {
                            if (!isfinite(pa[q]) || !isfinite(pb[q])) continue;
                            lo[q] = fmin(lo[q], fmin(pa[q], pb[q]));
                            hi[q] = fmax(hi[q], fmax(pa[q], pb[q]));
                        }
                    }
                }
            }
    if (st || nseg == 0) goto out0;
    /* Cells a sixteenth of the limit wide (at least the tolerance): a sample's partner on a
     * shared edge is found among few segments. (A dense array of cells as wide as the limit,
     * at most 160 a side, held hundreds: 6 s for a 2,000-face assembly.) */
    grid g = {.h = fmax(limit / 16, tol)};
    if (!(g.h > 0)) g.h = limit;
    for (int q = 0; q < 3; q++) {
        double ext = isfinite(hi[q] - lo[q]) ? hi[q] - lo[q] : 0;
        /* packed keys hold 2^21 cells a side: h grows for a fine limit on a huge box */
        if (ext / g.h > (1 << 20)) g.h = ext / (1 << 20);
    }
    /* (segment, cell) pairs bound the number of cells: the table gets twice as many slots. Long
     * segments over fine cells (bug25837_S.igs: 16,537 segments) would cover too many: the
     * cells grow until the pairs stay within 32 per segment (and a few million). */
    size_t pairs = 0, most = 32 * nseg + ((size_t)1 << 22);
    for (int grow = 0; grow < 64; grow++, g.h *= 2) {
        for (int q = 0; q < 3; q++) {
            double ext = isfinite(hi[q] - lo[q]) ? hi[q] - lo[q] : 0;
            g.lo[q] = isfinite(lo[q]) ? lo[q] : 0;
            g.n[q] = (int)(ext / g.h) + 1;
        }
        pairs = 0;
        for (size_t i = 0; i < nseg && pairs <= most; i++) {
            int c0[3], c1[3];
            seg_box_cells(&g, &segs[i], c0, c1);
            pairs += (size_t)(c1[0] - c0[0] + 1) * (size_t)(c1[1] - c0[1] + 1) *
                     (size_t)(c1[2] - c0[2] + 1);
        }
        if (pairs <= most) break;
    }
    if (pairs > most) { /* (not reached in practice: reported as not measured) */
        dest->incomplete = 1;
        goto out;
    }
    size_t slots = 1024;
    while (slots < 2 * pairs)
        slots *= 2;
    g.mask = slots - 1;
    g.keys = crisp_malloc_array(slots, sizeof *g.keys);
    g.start = crisp_calloc_array(slots, sizeof *g.start);
    g.cnt = crisp_calloc_array(slots, sizeof *g.cnt);
    g.items = crisp_malloc_array(pairs + 1, sizeof *g.items);
    if (!g.keys || !g.start || !g.cnt || !g.items) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_model_gaps: out of memory");
        goto out;
    }
    for (size_t i = 0; i < slots; i++)
        g.keys[i] = GAP_EMPTY;
    for (int pass = 0; pass < 2; pass++) {
        for (size_t i = 0; i < nseg; i++) {
            int c0[3], c1[3];
            seg_box_cells(&g, &segs[i], c0, c1);
            for (int z = c0[2]; z <= c1[2]; z++)
                for (int y = c0[1]; y <= c1[1]; y++)
                    for (int x = c0[0]; x <= c1[0]; x++) {
                        long long k = cell_slot(&g, cell_key(x, y, z), 1);
                        if (pass == 0)
                            g.cnt[k]++;
                        else
                            g.items[g.start[k] + g.cnt[k]++] = (int)i;
                    }
        }
        if (pass == 0) {
            int run = 0;
            for (size_t k = 0; k < slots; k++) {
                g.start[k] = run;
                run += g.cnt[k];
                g.cnt[k] = 0;
            }
        }
    }
    if (st) goto out;
    /* Each segment's curve midpoint is a sample (never a curve's end, which other curves of the
     * same loop share). */
    for (size_t i = 0; i < nseg; i++) {
        const bseg *s = &segs[i];
        double p[3];
        boundary_point(m, s->face, s->loop, s->curve, 0.5 * (s->t0 + s->t1), p);
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) continue;
        int c[3];
        for (int q = 0; q < 3; q++)
            c[q] = (int)floor((p[q] - g.lo[q]) / g.h);
        double best = INFINITY;
        int bi = -1, seam = 0;
        /* Rings of cells around the sample's own, nearest first: after ring r every segment not
         * yet seen lies farther than (r - 1) h. Most samples have a partner within tol in the
         * first ring (a shared edge) and stop there; the others look as far as limit. */
        int rmax = (int)ceil(limit / g.h) + 1;
        for (int r = 0; r <= rmax; r++) {
            if (r >= 1 && best <= tol) break;
            if (r >= 2 && (seam || !(best > (r - 1) * g.h))) break;
            for (int z = c[2] - r; z <= c[2] + r; z++) {
                if (z < 0 || z >= g.n[2]) continue;
                for (int y = c[1] - r; y <= c[1] + r; y++) {
                    if (y < 0 || y >= g.n[1]) continue;
                    for (int x = c[0] - r; x <= c[0] + r; x++) {
                        if (x < 0 || x >= g.n[0]) continue;
                        /* only the ring's shell: inner cells were scanned before */
                        if (abs(x - c[0]) < r && abs(y - c[1]) < r && abs(z - c[2]) < r) continue;
                        long long cell = cell_slot(&g, cell_key(x, y, z), 0);
                        if (cell < 0) continue;
                        for (int j = g.start[cell]; j < g.start[cell] + g.cnt[cell]; j++) {
                            const bseg *o = &segs[g.items[j]];
                            int b1 = m->faces[o->face].body, b0 = m->faces[s->face].body;
                            if (b0 && b1 && b0 != b1) continue; /* another part */
                            if (o->face == s->face) {
                                /* the face's own other boundary through here: a seam, or a
                                 * collapsed side: no other face is meant to be there */
                                if (r <= 1 && (o->loop != s->loop || o->curve != s->curve) &&
                                    seg_dist(p, o, NULL) <= tol)
                                    seam = 1;
                                continue;
                            }
                            double d = seg_dist(p, o, NULL);
                            if (d < best) best = d, bi = g.items[j];
                        }
                    }
                }
            }
        }
        if (seam || bi < 0 || !(best < limit)) continue; /* a seam, or a free edge */
        dest->samples++;
        if (best <= tol) continue;
        /* Across, not along: near a vertex where two faces' free edges start, the other face's
         * boundary lies ahead along this one (the direction to it runs along the tangent); a
         * crack lies across it. */
        double w, q[3], dq[3], tg[3];
        seg_dist(p, &segs[bi], &w);
        for (int k2 = 0; k2 < 3; k2++) {
            q[k2] = segs[bi].a[k2] + w * (segs[bi].b[k2] - segs[bi].a[k2]);
            dq[k2] = q[k2] - p[k2];
            tg[k2] = s->b[k2] - s->a[k2];
        }
        double ldq = sqrt(dq[0] * dq[0] + dq[1] * dq[1] + dq[2] * dq[2]),
               ltg = sqrt(tg[0] * tg[0] + tg[1] * tg[1] + tg[2] * tg[2]);
        if (ldq > 0 && ltg > 0 &&
            fabs(dq[0] * tg[0] + dq[1] * tg[1] + dq[2] * tg[2]) > 0.7 * ldq * ltg)
            continue;
        double d = refine(m, &segs[bi], p);
        if (d <= tol || d >= limit) continue;
        dest->gap_samples++;
        int fa = s->face < segs[bi].face ? s->face : segs[bi].face,
            fb = s->face ^ segs[bi].face ^ fa;
        /* group by face pair */
        int found = -1;
        for (int q = 0; q < dest->count && found < 0; q++)
            if (dest->gaps[q].face[0] == fa && dest->gaps[q].face[1] == fb) found = q;
        if (found < 0) {
            if (dest->count == dest->cap) {
                int nc = dest->cap ? 2 * dest->cap : 16;
                crisp_gap *ng = crisp_realloc_array(dest->gaps, (size_t)nc, sizeof *ng);
                if (!ng) {
                    st = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_model_gaps: out of memory");
                    goto out;
                }
                dest->gaps = ng;
                dest->cap = nc;
            }
            found = dest->count++;
            dest->gaps[found] = (crisp_gap){.face = {fa, fb}, .gap = 0};
        }
        crisp_gap *gp = &dest->gaps[found];
        if (d > gp->gap) {
            gp->gap = d;
            memcpy(gp->at, p, sizeof gp->at);
        }
    }
    if (dest->count > 1) qsort(dest->gaps, (size_t)dest->count, sizeof *dest->gaps, cmp_gap);
out:
    crisp_free(g.keys);
    crisp_free(g.start);
    crisp_free(g.cnt);
    crisp_free(g.items);
out0:
    crisp_free(segs);
    if (st) crisp_gap_report_free(dest);
    return st;
}

void crisp_gap_report_free(crisp_gap_report *r)
{
    crisp_free(r->gaps);
    r->gaps = NULL;
    r->count = r->cap = 0;
}
