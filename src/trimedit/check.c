/* Loop validity for the trim editor: does a loop cross itself or another loop? Each loop's
 * Bézier pieces are sampled into a polyline (8 segments per degree and piece, halved pieces where
 * the control polygon bends a lot) and the segments are swept in u with box tests (Shamos-Hoey
 * style pruning, then exact orientation tests on each candidate pair). Touching (a shared end,
 * collinear overlap) is not counted: a crossing means the sides change on both segments (a
 * zero side counts as positive).
 * The result is a flag for the user; the renderer draws any loops by the even-odd rule.
 */
#include "crisp/trimedit.h"

#include "trimedit_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_umin(const void *a, const void *b)
{
    const crisp__trimedit_seg *x = a, *y = b;
    return (x->umin > y->umin) - (x->umin < y->umin);
}

static double orient2(const double a[2], const double b[2], const double c[2])
{
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/* Crossing with a symbolic perturbation (a zero orientation counts as positive), so a curve
 * through a polyline vertex counts once, at one of the two segments that share it. */
static int crosses(const crisp__trimedit_seg *s, const crisp__trimedit_seg *t, double at[2])
{
    double d1 = orient2(s->a, s->b, t->a), d2 = orient2(s->a, s->b, t->b);
    double d3 = orient2(t->a, t->b, s->a), d4 = orient2(t->a, t->b, s->b);
    if ((d1 >= 0) == (d2 >= 0) || (d3 >= 0) == (d4 >= 0)) return 0;
    if (d1 == 0 && d2 == 0) return 0; /* collinear: touching, not crossing */
    double k = d3 - d4 != 0 ? d3 / (d3 - d4) : 0.5;
    at[0] = s->a[0] + k * (s->b[0] - s->a[0]);
    at[1] = s->a[1] + k * (s->b[1] - s->a[1]);
    return 1;
}

static int adjacent(const crisp__trimedit_seg *s, const crisp__trimedit_seg *t)
{
    if (s->loop != t->loop) return 0;
    int d = abs(s->seq - t->seq);
    return d <= 1 || d == s->loop_len - 1;
}

static crisp_status add_seg(crisp_trimedit *ed, size_t *n, const double a[2], const double b[2],
                            int loop, int seq)
{
    crisp_status st =
        crisp_grow((void **)&ed->check_seg, &ed->check_cap, *n + 1, sizeof *ed->check_seg);
    if (st) return st;
    crisp__trimedit_seg *s = &ed->check_seg[(*n)++];
    memcpy(s->a, a, sizeof s->a);
    memcpy(s->b, b, sizeof s->b);
    s->umin = fmin(a[0], b[0]);
    s->umax = fmax(a[0], b[0]);
    s->vmin = fmin(a[1], b[1]);
    s->vmax = fmax(a[1], b[1]);
    s->loop = loop;
    s->seq = seq;
    return CRISP_OK;
}

const crisp_trimedit_report *crisp_trimedit_check(crisp_trimedit *ed)
{
    if (ed->report_version == ed->version) return &ed->report;
    crisp_trimedit_report *r = &ed->report;
    memset(r, 0, sizeof *r);
    const crisp_face *f = crisp_trimedit_face(ed);
    r->loop_count = f->loop_count;
    size_t n = 0;
    crisp_status st = CRISP_OK;
    for (int l = 0; l < f->loop_count && !st; l++) {
        size_t first = n;
        int seq = 0;
        for (int c = 0; c < f->loops[l].curve_count && !st; c++) {
            crisp_bezier_curve *pieces = NULL;
            int count = 0;
            if ((st = crisp_curve_to_bezier(f->loops[l].curves[c], &pieces, &count))) break;
            for (int k = 0; k < count && !st; k++) {
                const crisp_bezier_curve *b = &pieces[k];
                /* More segments where the control polygon turns: its length over its chord. */
                double poly = 0, p0[2], p1[2];
                for (int i = 0; i < b->degree; i++) {
                    const double *q = b->cpw + 3 * i, *q1 = q + 3;
                    poly += hypot(q1[0] / q1[2] - q[0] / q[2], q1[1] / q1[2] - q[1] / q[2]);
                }
                const double *e = b->cpw + 3 * b->degree;
                double chord =
                    hypot(e[0] / e[2] - b->cpw[0] / b->cpw[2], e[1] / e[2] - b->cpw[1] / b->cpw[2]);
                int segs = 8 * b->degree;
                if (b->degree > 1 && poly > 1.5 * chord) segs *= 2;
                if (b->rational) segs *= 2;
                crisp_bezier_curve_eval(b, 0.0, p0);
                for (int i = 1; i <= segs && !st; i++) {
                    crisp_bezier_curve_eval(b, (double)i / segs, p1);
                    st = add_seg(ed, &n, p0, p1, l, seq++);
                    p0[0] = p1[0];
                    p0[1] = p1[1];
                }
            }
            crisp_free(pieces);
        }
        for (size_t i = first; i < n; i++)
            ed->check_seg[i].loop_len = seq;
    }
    ed->report_version = ed->version;
    if (st) { /* out of memory: report nothing rather than a wrong flag */
        r->valid = 1;
        snprintf(r->message, sizeof r->message, "crossing check skipped: %s",
                 crisp_error_message());
        return r;
    }
    crisp__trimedit_seg *s = ed->check_seg;
    qsort(s, n, sizeof *s, cmp_umin);
    int found = 0;
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n && s[j].umin <= s[i].umax; j++) {
            if (s[j].vmin > s[i].vmax || s[j].vmax < s[i].vmin || adjacent(&s[i], &s[j])) continue;
            double at[2];
            if (!crosses(&s[i], &s[j], at)) continue;
            int a = s[i].loop, b = s[j].loop;
            unsigned flag = a == b ? CRISP_TRIMEDIT_SELF_CROSSING : CRISP_TRIMEDIT_CROSSES_OTHER;
            if (a < 64) r->flags[a] |= flag;
            if (b < 64) r->flags[b] |= flag;
            if (!found) {
                found = 1;
                r->where[0] = at[0];
                r->where[1] = at[1];
                if (a == b)
                    snprintf(r->message, sizeof r->message,
                             "loop %d crosses itself near (%.4g, %.4g)", a, at[0], at[1]);
                else
                    snprintf(r->message, sizeof r->message,
                             "loop %d crosses loop %d near (%.4g, %.4g)", a < b ? a : b,
                             a < b ? b : a, at[0], at[1]);
            }
        }
    r->valid = !found;
    return r;
}
