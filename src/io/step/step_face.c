/* STEP topology to crisp faces (ISO 10303-42 5.4: advanced_face, face_bound / face_outer_bound,
 * edge_loop, oriented_edge, edge_curve, vertex_point; 4.4: pcurve, surface_curve, seam_curve).
 *
 * A face becomes its surface as a NURBS (elementary surfaces over the (u, v) box of the loops,
 * with a margin) and one trim curve per edge use, in loop order:
 *  - from the edge's PCURVE on this face's surface when there is one (a seam edge has two: the
 *    one that continues the loop is taken), mapped from the file's (u, v) onto the NURBS (u, v):
 *    unchanged when the map is affine, exactly for iso-parametric lines, else fitted
 *    (crisp_fit_curve) within the tolerance;
 *  - else projected from the 3D edge: analytic inversion on elementary surfaces (angles unwrapped
 *    along the loop, so a loop may cross the seam) then fitted, crisp_surface_project_curve on
 *    B-spline surfaces.
 * Edge vertices bound the curve range (their parameters on the 3D curve). Junctions of
 * consecutive trim curves are snapped together when they are within the tolerance, then
 * crisp_face_normalize_loops orients the loops and checks closure.
 */
#include "step_internal.h"

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define MAX_LOOPS 4096
#define MAX_EDGES 65536

typedef struct edge_use {
    step_curve c3;   /* 3D curve in the file's parametrisation */
    double lo, hi;   /* curve parameter range, lo < hi (hi may pass the end of a closed B-spline) */
    int increasing;  /* the loop runs along increasing curve parameter */
    int npc;         /* pcurve candidates on this face's surface */
    step_curve pc[2];
    int chosen;
    double pt0[2], pt1[2]; /* pcurve parameter range of each candidate */
    double shift[2]; /* multiple of the period added to the chosen pcurve (file uv) */
    int ns;          /* samples in loop order: curve parameter and file (u, v) */
    double *ts, *uv;
    int id;          /* ORIENTED_EDGE for messages */
} edge_use;

typedef struct loop_work {
    int outer_flag; /* FACE_OUTER_BOUND */
    int count;
    edge_use *edges;
    double box[4];
} loop_work;

typedef struct face_work {
    step_reader *r;
    const step_entity *fe;
    step_surface s;
    int nloops;
    loop_work *loops;
    double period[2]; /* 2 pi for angle coordinates, else 0 */
    double box[4];    /* file (u, v) box the NURBS covers */
    double nbox[4];   /* NURBS domain */
    double tol_uv;
    int band_a, band_b, band_rev; /* two winding loops joined along the seam (band_b follows a) */
    int ncap;                     /* VERTEX_LOOP points (a cone's apex, a sphere's pole) */
    double cap_pt[2][3];
    int cap_k;                    /* band_a closed at the degenerate line (coordinate 1 - cap_k) = cap_v */
    double cap_v;
} face_work;

static void edge_free(edge_use *e)
{
    crisp__step_curve_free(&e->c3);
    for (int k = 0; k < e->npc; k++) crisp__step_curve_free(&e->pc[k]);
    crisp_free(e->ts);
    crisp_free(e->uv);
}

static void work_free(face_work *w)
{
    for (int i = 0; i < w->nloops; i++) {
        for (int k = 0; k < w->loops[i].count; k++) edge_free(&w->loops[i].edges[k]);
        crisp_free(w->loops[i].edges);
    }
    crisp_free(w->loops);
    crisp__step_surface_free(&w->s);
}

/* Curve parameter t of an edge, wrapped back into a closed B-spline's domain. */
static double wrap_t(const step_curve *c, double t)
{
    if (c->kind == STEP_CURVE_BSPLINE && c->periodic && t > c->t1) t -= c->period;
    return t;
}

static double dist3(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

static crisp_status vertex_point(step_reader *r, const step_entity *ve, double p[3])
{
    const step_part *vp = crisp__step_part(r, ve, "VERTEX_POINT");
    if (!vp) return crisp__step_fail(r, ve, CRISP_ERR_PARSE, "expected a VERTEX_POINT");
    const step_entity *pe;
    crisp_status st = crisp__step_get_ref(r, ve, vp, 1, &pe);
    if (!st) st = crisp__step_point(r, pe, p, NULL);
    return st;
}

/* The pcurves of a SURFACE_CURVE / SEAM_CURVE that lie on surface entity sid. */
static crisp_status find_pcurves(step_reader *r, const step_entity *ge, int sid, edge_use *eu)
{
    const step_part *p = crisp__step_part(r, ge, NULL);
    const step_value *assoc = crisp__step_param(r, p, 2);
    if (!assoc || assoc->kind != STEP_LIST) return CRISP_OK;
    for (uint32_t i = 0; i < assoc->len && eu->npc < 2; i++) {
        const step_entity *pe, *se, *de, *ce;
        const step_value *items;
        crisp_status st = crisp__step_deref(r, ge, crisp__step_elem(r, assoc, i), &pe);
        if (st) return st;
        const step_part *pp = crisp__step_part(r, pe, "PCURVE");
        if (!pp) continue;
        if ((st = crisp__step_get_ref(r, pe, pp, 1, &se))) return st;
        if (se->id != sid) continue;
        if ((st = crisp__step_get_ref(r, pe, pp, 2, &de))) return st;
        const step_part *dp = crisp__step_part(r, de, "DEFINITIONAL_REPRESENTATION");
        if (!dp) return crisp__step_fail(r, de, CRISP_ERR_PARSE, "expected a DEFINITIONAL_REPRESENTATION");
        if ((st = crisp__step_get_list(r, de, dp, 1, &items))) return st;
        if (items->len < 1) return crisp__step_fail(r, de, CRISP_ERR_PARSE, "expected a 2D curve in the items");
        if ((st = crisp__step_deref(r, de, crisp__step_elem(r, items, 0), &ce))) return st;
        step_curve c;
        if ((st = crisp__step_curve(r, ce, &c))) return st;
        if (c.dim != 2) {
            crisp__step_curve_free(&c);
            return crisp__step_fail(r, ce, CRISP_ERR_PARSE, "expected a 2D curve for a pcurve");
        }
        eu->pc[eu->npc++] = c;
    }
    return CRISP_OK;
}

/* Evaluate pcurve k of an edge at its own parameter t (file uv, before the shift). */
static void pc_eval(const edge_use *eu, int k, double t, double uv[2])
{
    crisp__step_curve_eval(&eu->pc[k], t, uv);
}

/* Pcurve k at loop fraction s. */
static void pc_at(const edge_use *eu, int k, double s, double uv[2])
{
    double t = eu->increasing ? eu->pt0[k] + s * (eu->pt1[k] - eu->pt0[k]) : eu->pt1[k] - s * (eu->pt1[k] - eu->pt0[k]);
    pc_eval(eu, k, t, uv);
}

static int edge_samples(const edge_use *eu)
{
    int n = 24;
    if (eu->c3.kind == STEP_CURVE_BSPLINE) n = 4 * (eu->c3.nurbs->count - eu->c3.nurbs->degree + 1);
    if (n < 24) n = 24;
    if (n > 512) n = 512;
    return n + 1;
}

static double pc_dist2(const face_work *w, const edge_use *eu, int k, double t, const double v[3])
{
    double uv[2], p[3];
    pc_eval(eu, k, t, uv);
    crisp__step_surface_eval(&w->s, uv[0], uv[1], p);
    return (p[0] - v[0]) * (p[0] - v[0]) + (p[1] - v[1]) * (p[1] - v[1]) + (p[2] - v[2]) * (p[2] - v[2]);
}

/* The pcurve parameter whose surface point is nearest v, searched around guess. Writers do not
 * always keep the pcurve's parameter equal to the 3D curve's (OCCT's rational pcurves of circles
 * agree only at the knots), so the vertices are located on the pcurve itself. */
static double pc_locate(const face_work *w, const edge_use *eu, int k, double guess, double delta, const double v[3])
{
    const step_curve *pc = &eu->pc[k];
    double a = guess - delta, b = guess + delta;
    int n = 32;
    if (isfinite(pc->t0) && isfinite(pc->t1)) {
        /* A bounded pcurve is searched whole: its parameter may be far from the 3D curve's. */
        a = pc->t0, b = pc->t1;
        n = 64;
        if (pc->kind == STEP_CURVE_BSPLINE && 4 * pc->nurbs->count > n) n = 4 * pc->nurbs->count;
        if (n > 4096) n = 4096;
    }
    if (!(b > a)) return guess < a ? a : guess > b ? b : guess;
    double best = a, bd = INFINITY;
    for (int i = 0; i <= n; i++) {
        double t = a + (b - a) * i / n, d = pc_dist2(w, eu, k, t, v);
        /* Ties (the ends of a closed pcurve) go to the parameter nearest the guess. */
        if (d < bd * (1 - 1e-9) || (d <= bd * (1 + 1e-9) + 1e-30 && fabs(t - guess) < fabs(best - guess)))
            bd = d, best = t;
    }
    double lo = best - (b - a) / n, hi = best + (b - a) / n;
    if (lo < a) lo = a;
    if (hi > b) hi = b;
    const double g = 0.6180339887498949;
    double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    double f1 = pc_dist2(w, eu, k, x1, v), f2 = pc_dist2(w, eu, k, x2, v);
    for (int it = 0; it < 90 && hi - lo > 1e-15 * (1 + fabs(lo)); it++) {
        if (f1 < f2) hi = x2, x2 = x1, f2 = f1, x1 = hi - g * (hi - lo), f1 = pc_dist2(w, eu, k, x1, v);
        else lo = x1, x1 = x2, f1 = f2, x2 = lo + g * (hi - lo), f2 = pc_dist2(w, eu, k, x2, v);
    }
    double t = 0.5 * (lo + hi);
    if (pc_dist2(w, eu, k, a, v) <= pc_dist2(w, eu, k, t, v)) t = a;
    if (pc_dist2(w, eu, k, b, v) < pc_dist2(w, eu, k, t, v)) t = b;
    return t;
}

/* Locate the edge's ends on pcurve k and check that its image follows the 3D curve. */
static int pcurve_agrees(face_work *w, edge_use *eu, int k, const double first[3], const double second[3])
{
    if (w->s.kind == STEP_SURF_BSPLINE && !w->s.nurbs) return 0;
    double delta = 0.25 * (eu->hi - eu->lo);
    eu->pt0[k] = pc_locate(w, eu, k, eu->lo, delta, first);
    eu->pt1[k] = pc_locate(w, eu, k, eu->hi, delta, second);
    if (!(eu->pt1[k] > eu->pt0[k])) return 0;
    if (pc_dist2(w, eu, k, eu->pt0[k], first) > w->r->tol * w->r->tol ||
        pc_dist2(w, eu, k, eu->pt1[k], second) > w->r->tol * w->r->tol)
        return 0;
    const step_curve *c = &eu->c3;
    double lo = c->kind == STEP_CURVE_BSPLINE ? c->t0 : eu->lo, hi = c->kind == STEP_CURVE_BSPLINE ? c->t1 : eu->hi;
    for (int i = 0; i <= 8; i++) {
        double t = eu->pt0[k] + (eu->pt1[k] - eu->pt0[k]) * i / 8, uv[2], a[3], b[3];
        pc_eval(eu, k, t, uv);
        crisp__step_surface_eval(&w->s, uv[0], uv[1], a);
        crisp__step_curve_eval(c, crisp__step_curve_invert(c, a, lo, hi), b);
        if (dist3(a, b) > w->r->tol) return 0;
    }
    return 1;
}

/* One ORIENTED_EDGE of a loop: its 3D curve, parameter range, direction and pcurves. */
static crisp_status edge_setup(face_work *w, const step_entity *oe, edge_use *eu)
{
    step_reader *r = w->r;
    crisp_status st;
    int orient = 1;
    const step_entity *ee = oe;
    eu->id = oe->id;
    /* Oriented edges may wrap oriented edges; each flips the sense once more. */
    for (int depth = 0; crisp__step_is(r, ee, "ORIENTED_EDGE"); depth++) {
        const step_part *p = crisp__step_part(r, ee, "ORIENTED_EDGE");
        int o;
        if (depth > 8) return crisp__step_fail(r, oe, CRISP_ERR_LIMIT, "oriented edges nested too deeply");
        if ((st = crisp__step_get_bool(r, ee, p, 4, &o)) || (st = crisp__step_get_ref(r, ee, p, 3, &ee))) return st;
        orient = orient == o;
    }
    const step_part *ep = crisp__step_part(r, ee, "EDGE_CURVE");
    if (!ep) return crisp__step_fail(r, ee, CRISP_ERR_UNSUPPORTED, "expected an EDGE_CURVE");
    const step_entity *vs, *ve, *ge;
    int same;
    double ps[3], pe[3];
    if ((st = crisp__step_get_ref(r, ee, ep, 1, &vs)) || (st = crisp__step_get_ref(r, ee, ep, 2, &ve)) ||
        (st = crisp__step_get_ref(r, ee, ep, 3, &ge)) || (st = crisp__step_get_bool(r, ee, ep, 4, &same)) ||
        (st = vertex_point(r, vs, ps)) || (st = vertex_point(r, ve, pe)))
        return st;
    if (crisp__step_is(r, ge, "PCURVE"))
        return crisp__step_fail(r, ge, CRISP_ERR_UNSUPPORTED, "edge geometry given only as a pcurve");
    if ((st = crisp__step_curve(r, ge, &eu->c3))) return st;
    step_curve *c = &eu->c3;
    if (c->dim != 3) return crisp__step_fail(r, ge, CRISP_ERR_PARSE, "expected a 3D curve as edge geometry");
    if (crisp__step_is(r, ge, "SURFACE_CURVE") || crisp__step_is(r, ge, "SEAM_CURVE"))
        if ((st = find_pcurves(r, ge, w->s.id, eu))) return st;
    /* Against a reversed trimmed curve, the edge's sense is against the basis curve's. */
    same ^= c->reversed;
    const double *first = same ? ps : pe, *second = same ? pe : ps;
    int closed = vs == ve || dist3(ps, pe) <= r->tol;
    double lo = crisp__step_curve_invert(c, first, c->t0, c->t1);
    double hi = crisp__step_curve_invert(c, second, c->t0, c->t1);
    if (c->periodic) {
        double eps = 1e-12 * c->period;
        if (c->kind == STEP_CURVE_CONIC) {
            if (isfinite(c->t0)) { /* trimmed arc: both in [t0, t0 + 2 pi) */
                if (!(hi > lo + eps)) hi += c->period;
            } else {
                while (hi <= lo + eps) hi += c->period;
                while (hi > lo + c->period + eps) hi -= c->period;
                if (closed) hi = lo + c->period;
            }
        } else if (closed) {
            if (lo >= c->t1 - eps) lo = c->t0;
            hi = lo + c->period;
        } else if (!(hi > lo + eps)) {
            if (lo >= c->t1 - eps) lo = c->t0;
            else if (hi <= c->t0 + eps) hi = c->t1;
            else hi += c->period;
        }
    }
    if (!(hi > lo)) {
        return crisp__step_fail(r, ee, CRISP_ERR_NUMERIC,
                                "edge vertices at curve parameters %g and %g: expected an increasing range "
                                "along #%d (same_sense %s)", lo, hi, ge->id, same ? ".T." : ".F.");
    }
    eu->lo = lo;
    eu->hi = hi;
    eu->increasing = same == orient;
    /* On a periodic curve the pcurve may use another turn of the parameter: move the range into
     * the pcurve's domain. */
    if (eu->npc && c->periodic && c->kind == STEP_CURVE_CONIC && isfinite(eu->pc[0].t0) && isfinite(eu->pc[0].t1)) {
        double k = floor((eu->pc[0].t0 - eu->lo) / c->period + 0.5);
        if (eu->lo + k * c->period < eu->pc[0].t0 - 1e-9 * c->period) k += 1;
        eu->lo += k * c->period;
        eu->hi += k * c->period;
    }
    /* A pcurve is used only when it follows the 3D curve's parametrisation on this surface;
     * otherwise the edge is projected. */
    for (int k = 0; k < eu->npc; k++) {
        if (pcurve_agrees(w, eu, k, first, second)) continue;
        crisp__step_curve_free(&eu->pc[k]);
        eu->pc[k] = eu->pc[eu->npc - 1];
        eu->pt0[k] = eu->pt0[eu->npc - 1];
        eu->pt1[k] = eu->pt1[eu->npc - 1];
        memset(&eu->pc[eu->npc - 1], 0, sizeof eu->pc[0]);
        eu->npc--;
        k--;
        r->stats->rejected_pcurves++;
    }
    return CRISP_OK;
}

static double loop_t(const edge_use *eu, double s)
{
    return eu->increasing ? eu->lo + s * (eu->hi - eu->lo) : eu->hi - s * (eu->hi - eu->lo);
}

static crisp_status alloc_samples(face_work *w, edge_use *eu)
{
    eu->ns = edge_samples(eu);
    eu->ts = crisp_malloc_array((size_t)eu->ns, sizeof *eu->ts);
    eu->uv = crisp_malloc_array((size_t)eu->ns * 2, sizeof *eu->uv);
    if (!eu->ts || !eu->uv) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", w->r->f->name);
    for (int i = 0; i < eu->ns; i++) eu->ts[i] = loop_t(eu, (double)i / (eu->ns - 1));
    return CRISP_OK;
}

/* Shift of uv (per periodic coordinate) that brings it nearest to ref. */
static void period_shift(const face_work *w, const double uv[2], const double ref[2], double shift[2])
{
    for (int k = 0; k < 2; k++) {
        shift[k] = 0;
        if (w->period[k] > 0) shift[k] = w->period[k] * floor((ref[k] - uv[k]) / w->period[k] + 0.5);
    }
}

/* File-uv samples of every edge of a loop, continuous along the loop. */
static crisp_status loop_samples(face_work *w, loop_work *lw)
{
    int n = lw->count;
    /* Start at an edge with at most one pcurve, so that seams are chosen by continuity. */
    int start = 0;
    while (start < n && lw->edges[start].npc == 2) start++;
    if (start == n) start = 0;
    double prev[2] = {0, 0};
    int have_prev = 0;
    for (int m = 0; m < n; m++) {
        edge_use *eu = &lw->edges[(start + m) % n];
        crisp_status st = alloc_samples(w, eu);
        if (st) return st;
        if (eu->npc) {
            eu->chosen = 0;
            if (eu->npc == 2 && have_prev) {
                double a[2], b[2];
                pc_at(eu, 0, 0, a);
                pc_at(eu, 1, 0, b);
                double da = hypot(a[0] - prev[0], a[1] - prev[1]), db = hypot(b[0] - prev[0], b[1] - prev[1]);
                eu->chosen = db < da;
            }
            double uv0[2];
            pc_at(eu, eu->chosen, 0, uv0);
            if (have_prev) period_shift(w, uv0, prev, eu->shift);
            for (int i = 0; i < eu->ns; i++) {
                pc_at(eu, eu->chosen, (double)i / (eu->ns - 1), eu->uv + 2 * i);
                eu->uv[2 * i] += eu->shift[0];
                eu->uv[2 * i + 1] += eu->shift[1];
            }
        } else if (w->s.kind == STEP_SURF_BSPLINE) {
            /* Projected later by crisp_surface_project_curve; the domain is fixed. */
            eu->ns = 0;
            have_prev = 0;
            continue;
        } else {
            for (int i = 0; i < eu->ns; i++) {
                double p[3];
                crisp__step_curve_eval(&eu->c3, wrap_t(&eu->c3, eu->ts[i]), p);
                crisp__step_surface_invert(&w->s, p, have_prev || i ? prev : NULL, eu->uv + 2 * i);
                prev[0] = eu->uv[2 * i], prev[1] = eu->uv[2 * i + 1];
                have_prev = 1;
            }
        }
        prev[0] = eu->uv[2 * eu->ns - 2];
        prev[1] = eu->uv[2 * eu->ns - 1];
        have_prev = 1;
    }
    lw->box[0] = lw->box[2] = INFINITY;
    lw->box[1] = lw->box[3] = -INFINITY;
    for (int m = 0; m < n; m++) {
        const edge_use *eu = &lw->edges[m];
        for (int i = 0; i < eu->ns; i++)
            for (int k = 0; k < 2; k++) {
                double x = eu->uv[2 * i + k];
                if (x < lw->box[2 * k]) lw->box[2 * k] = x;
                if (x > lw->box[2 * k + 1]) lw->box[2 * k + 1] = x;
            }
    }
    return CRISP_OK;
}

static void shift_loop(loop_work *lw, const double shift[2])
{
    for (int m = 0; m < lw->count; m++) {
        edge_use *eu = &lw->edges[m];
        for (int i = 0; i < eu->ns; i++) eu->uv[2 * i] += shift[0], eu->uv[2 * i + 1] += shift[1];
        eu->shift[0] += shift[0];
        eu->shift[1] += shift[1];
    }
    lw->box[0] += shift[0], lw->box[1] += shift[0];
    lw->box[2] += shift[1], lw->box[3] += shift[1];
}

/* The file-uv box the NURBS surface covers: the loops' box with a margin, angles kept within one
 * turn, spheres within the poles and cones on one side of the apex. */
static void choose_box(face_work *w, int outer)
{
    double *b = w->box;
    const loop_work *o = &w->loops[outer];
    for (int k = 0; k < 4; k++) b[k] = o->box[k];
    for (int i = 0; i < w->nloops; i++)
        for (int k = 0; k < 2; k++) {
            if (w->loops[i].box[2 * k] < b[2 * k]) b[2 * k] = w->loops[i].box[2 * k];
            if (w->loops[i].box[2 * k + 1] > b[2 * k + 1]) b[2 * k + 1] = w->loops[i].box[2 * k + 1];
        }
    for (int k = 0; k < 2; k++) {
        double lo = b[2 * k], hi = b[2 * k + 1], span = hi - lo;
        double m = 0.01 * span + 1e-9 * (fabs(lo) + fabs(hi)) + 1e-12;
        if (w->period[k] > 0) {
            if (span >= w->period[k] - 1e-9) {
                b[2 * k + 1] = lo + w->period[k];
                continue;
            }
            if (m > 0.5 * (w->period[k] - span)) m = 0.5 * (w->period[k] - span);
        }
        b[2 * k] = lo - m;
        b[2 * k + 1] = hi + m;
    }
    if (w->s.kind == STEP_SURF_SPHERE) {
        if (b[2] < -M_PI / 2) b[2] = -M_PI / 2;
        if (b[3] > M_PI / 2) b[3] = M_PI / 2;
    }
    if (w->s.kind == STEP_SURF_CONE) {
        double apex = -w->s.r / tan(w->s.semi);
        if (o->box[2] >= apex && b[2] < apex) b[2] = apex;
        if (o->box[3] <= apex && b[3] > apex) b[3] = apex;
    }
}

/* ---- bands: two loops that wind around a periodic direction ----------------------------------
 * A face bounded by two circles on a full cylinder has two loops, each going once around; in
 * (u, v) neither closes. They become one outer loop: loop A, a seam segment up, loop B from the
 * seam back to the seam, a seam segment down. B is cut where it crosses A's start on the seam,
 * so that both run over the same turn. */

static double winding(const face_work *w, const loop_work *lw, int k)
{
    const edge_use *a = &lw->edges[0], *b = &lw->edges[lw->count - 1];
    if (w->period[k] <= 0 || !a->ns || !b->ns) return 0;
    return b->uv[2 * b->ns - 2 + k] - a->uv[k];
}

static crisp_status curve_dup(const step_curve *c, step_curve *d)
{
    *d = *c;
    d->nurbs = NULL;
    return c->nurbs ? crisp_curve_copy(c->nurbs, &d->nurbs) : CRISP_OK;
}

static void file_uv(face_work *w, edge_use *eu, double s, double uv[2]);
static crisp_status loop_samples(face_work *w, loop_work *lw);

/* Cut the loop where coordinate k crosses target (mod the period) and start it there. */
static crisp_status cut_loop(face_work *w, loop_work *lw, int k, double target)
{
    double P = w->period[k];
    int e = -1;
    double s0 = 0, s1 = 0, tgt = 0;
    for (int m = 0; m < lw->count && e < 0; m++) {
        const edge_use *eu = &lw->edges[m];
        for (int i = 0; i + 1 < eu->ns && e < 0; i++) {
            double x0 = eu->uv[2 * i + k], x1 = eu->uv[2 * i + 2 + k];
            double t = target + P * floor((x0 - target) / P + 0.5);
            for (int q = -1; q <= 1 && e < 0; q++) {
                double tt = t + q * P;
                if ((x0 - tt) * (x1 - tt) <= 0 && x0 != x1) e = m, s0 = (double)i / (eu->ns - 1), s1 = (double)(i + 1) / (eu->ns - 1), tgt = tt;
            }
        }
    }
    if (e < 0) return crisp__step_fail(w->r, w->fe, CRISP_ERR_NUMERIC, "cannot find where a winding loop crosses the seam");
    edge_use *eu = &lw->edges[e];
    double x0 = eu->uv[2 * (int)lround(s0 * (eu->ns - 1)) + k];
    for (int it = 0; it < 60; it++) {
        double sm = 0.5 * (s0 + s1), uv[2];
        file_uv(w, eu, sm, uv);
        if ((uv[k] - tgt) * (x0 - tgt) > 0) s0 = sm;
        else s1 = sm;
    }
    double sc = 0.5 * (s0 + s1);
    int n = lw->count, first = e, split = sc > 1e-9 && sc < 1 - 1e-9;
    if (!split && sc >= 0.5) first = (e + 1) % n;
    edge_use *ne = crisp_calloc_array((size_t)n + 1, sizeof *ne);
    if (!ne) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", w->r->f->name);
    int c = 0;
    crisp_status st = CRISP_OK;
    if (split) {
        /* e becomes two edge uses: e2 (from the cut to its end) first, e1 (start to cut) last. */
        edge_use e1 = *eu, e2 = *eu;
        e1.ts = e1.uv = e2.ts = e2.uv = NULL;
        memset(&e2.c3, 0, sizeof e2.c3);
        st = curve_dup(&eu->c3, &e2.c3);
        for (int q = 0; q < eu->npc && !st; q++) st = curve_dup(&eu->pc[q], &e2.pc[q]);
        if (st) {
            crisp_free(ne);
            return st;
        }
        double t = eu->increasing ? eu->lo + sc * (eu->hi - eu->lo) : eu->hi - sc * (eu->hi - eu->lo);
        if (eu->increasing) e1.hi = t, e2.lo = t;
        else e1.lo = t, e2.hi = t;
        for (int q = 0; q < eu->npc; q++) {
            double pt = eu->increasing ? eu->pt0[q] + sc * (eu->pt1[q] - eu->pt0[q]) : eu->pt1[q] - sc * (eu->pt1[q] - eu->pt0[q]);
            if (eu->increasing) e1.pt1[q] = pt, e2.pt0[q] = pt;
            else e1.pt0[q] = pt, e2.pt1[q] = pt;
        }
        crisp_free(eu->ts);
        crisp_free(eu->uv);
        ne[c++] = e2;
        for (int m = 1; m < n; m++) ne[c++] = lw->edges[(e + m) % n];
        ne[c++] = e1;
    } else {
        for (int m = 0; m < n; m++) ne[c++] = lw->edges[(first + m) % n];
    }
    crisp_free(lw->edges);
    lw->edges = ne;
    lw->count = c;
    for (int m = 0; m < c; m++) {
        crisp_free(ne[m].ts);
        crisp_free(ne[m].uv);
        ne[m].ts = ne[m].uv = NULL;
        ne[m].shift[0] = ne[m].shift[1] = 0;
    }
    return loop_samples(w, lw);
}

/* Join winding loops a and b (coordinate k) as described above. */
static crisp_status make_band(face_work *w, int a, int b, int k)
{
    loop_work *A = &w->loops[a], *B = &w->loops[b];
    double ua = A->edges[0].uv[k], da = winding(w, A, k) > 0 ? 1 : -1;
    crisp_status st = cut_loop(w, B, k, ua);
    if (st) return st;
    double db = winding(w, B, k) > 0 ? 1 : -1;
    w->band_rev = da == db;
    /* B traversed (reversed when it runs like A) must start at A's end and end at A's start. */
    double want = w->band_rev ? ua : ua + da * w->period[k];
    double sh[2] = {0, 0};
    sh[k] = want - B->edges[0].uv[k];
    shift_loop(B, sh);
    w->band_a = a;
    w->band_b = b;
    return CRISP_OK;
}

/* ---- trim curves in NURBS (u, v) --------------------------------------------------------------- */

typedef struct fit_ctx {
    face_work *w;
    edge_use *eu;
} fit_ctx;

/* File uv at loop fraction s by the chosen pcurve or by inversion near the sampled polyline. */
static void file_uv(face_work *w, edge_use *eu, double s, double uv[2])
{
    double x = s * (eu->ns - 1);
    int i = (int)floor(x);
    if (i < 0) i = 0;
    if (i > eu->ns - 2) i = eu->ns - 2;
    double f = x - i;
    if (f <= 0) {
        uv[0] = eu->uv[2 * i], uv[1] = eu->uv[2 * i + 1];
        return;
    }
    if (f >= 1) {
        uv[0] = eu->uv[2 * i + 2], uv[1] = eu->uv[2 * i + 3];
        return;
    }
    double t = loop_t(eu, s);
    if (eu->npc) {
        pc_at(eu, eu->chosen, s, uv);
        uv[0] += eu->shift[0], uv[1] += eu->shift[1];
        return;
    }
    double ref[2] = {eu->uv[2 * i] * (1 - f) + eu->uv[2 * i + 2] * f, eu->uv[2 * i + 1] * (1 - f) + eu->uv[2 * i + 3] * f};
    double p[3];
    crisp__step_curve_eval(&eu->c3, wrap_t(&eu->c3, t), p);
    crisp__step_surface_invert(&w->s, p, ref, uv);
}

static void fit_fn(void *ctx, double s, double *dest)
{
    fit_ctx *fc = ctx;
    double uv[2];
    file_uv(fc->w, fc->eu, s, uv);
    crisp__step_surface_map(&fc->w->s, fc->w->box, uv, dest);
}

/* Append c to out (taking ownership). */
static crisp_status push_curve(face_work *w, crisp_curve *c, crisp_curve ***out, int *n, size_t *cap)
{
    if ((size_t)*n == *cap && crisp_grow((void **)out, cap, (size_t)*n + 1, sizeof **out) != CRISP_OK) {
        crisp_curve_destroy(c);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", w->r->f->name);
    }
    (*out)[(*n)++] = c;
    return CRISP_OK;
}

/* Translate (and swap) a 2D curve's control points in place. */
static void affine2(crisp_curve *c, const double shift[2], int swap)
{
    for (int i = 0; i < c->count; i++) {
        double *q = c->cpw + 3 * i, wt = q[2];
        double x = q[0] + wt * shift[0], y = q[1] + wt * shift[1];
        q[0] = swap ? y : x;
        q[1] = swap ? x : y;
    }
}

/* Largest distance between the images S(uv(s)) of curves first..n-1 and the edge's 3D curve. */
static void verify_edge(face_work *w, const crisp_surface *s, const edge_use *eu, crisp_curve **curves, int first,
                        int n)
{
    const step_curve *c = &eu->c3;
    double lo = eu->lo, hi = eu->hi;
    if (c->kind == STEP_CURVE_BSPLINE) lo = c->t0, hi = c->t1;
    for (int k = first; k < n; k++) {
        double a, b;
        crisp_curve_domain(curves[k], &a, &b);
        for (int i = 0; i <= 16; i++) {
            double uv[2], p[3], q[3];
            crisp_curve_eval(curves[k], a + (b - a) * i / 16, uv);
            crisp_surface_eval(s, uv[0], uv[1], p);
            crisp__step_curve_eval(c, crisp__step_curve_invert(c, p, lo, hi), q);
            /* The edge itself may lie off the surface by the file's own gap: compare the trim's
             * image with the edge point's projection onto the surface, and record the gap. */
            double quv[2], sq[3];
            if (w->s.kind == STEP_SURF_BSPLINE) {
                double dd;
                if (crisp_surface_closest_point(s, q, quv, &dd) != CRISP_OK) continue;
                crisp_surface_eval(s, quv[0], quv[1], sq);
            } else {
                crisp__step_surface_invert(&w->s, q, NULL, quv);
                crisp__step_surface_eval(&w->s, quv[0], quv[1], sq);
            }
            double gap = dist3(q, sq);
            if (gap > w->r->stats->max_edge_gap) w->r->stats->max_edge_gap = gap;
            double d = dist3(p, sq);
            if (d > w->r->stats->max_edge_dev) w->r->stats->max_edge_dev = d;
        }
    }
}

static crisp_status edge_trims_any(face_work *w, edge_use *eu, crisp_curve ***out, int *n, size_t *cap);

static crisp_status edge_trims(face_work *w, const crisp_surface *s, edge_use *eu, crisp_curve ***out, int *n,
                               size_t *cap)
{
    int first = *n;
    crisp_status st = edge_trims_any(w, eu, out, n, cap);
    if (!st && w->r->stats->verify) verify_edge(w, s, eu, *out, first, *n);
    return st;
}

static crisp_status edge_trims_any(face_work *w, edge_use *eu, crisp_curve ***out, int *n, size_t *cap)
{
    step_reader *r = w->r;
    crisp_status st = CRISP_OK;
    crisp_curve *c = NULL;
    const step_surface *s = &w->s;
    if (eu->npc) {
        r->stats->pcurve_edges++;
        const step_curve *pc = &eu->pc[eu->chosen];
        int lin = crisp__step_surface_map_linear(s, 0) && crisp__step_surface_map_linear(s, 1);
        if (lin) {
            if ((st = crisp__step_curve_nurbs(pc, eu->pt0[eu->chosen], eu->pt1[eu->chosen], &c))) return st;
            affine2(c, eu->shift, crisp__step_surface_swaps(s));
            if (!eu->increasing) crisp_curve_reverse(c);
            return push_curve(w, c, out, n, cap);
        }
        if (pc->kind == STEP_CURVE_LINE && (fabs(pc->d[0]) <= 1e-12 * fabs(pc->d[1]) || fabs(pc->d[1]) <= 1e-12 * fabs(pc->d[0]))) {
            double a[2], b[2];
            crisp__step_surface_map(s, w->box, eu->uv, a);
            crisp__step_surface_map(s, w->box, eu->uv + 2 * eu->ns - 2, b);
            if ((st = crisp_make_line(2, a, b, 0, 1, &c))) return st;
            return push_curve(w, c, out, n, cap);
        }
    } else {
        r->stats->projected_edges++;
    }
    if (s->kind == STEP_SURF_PLANE && !eu->npc) {
        /* Orthogonal projection onto a plane is affine: map the 3D control points exactly. */
        double cut[3] = {eu->lo, eu->hi, eu->hi};
        int pieces = 1;
        if (eu->c3.kind == STEP_CURVE_BSPLINE && eu->hi > eu->c3.t1) {
            cut[1] = eu->c3.t1;
            pieces = 2;
        }
        crisp_curve *tmp[2] = {NULL, NULL};
        for (int k = 0; k < pieces && !st; k++) {
            double a = k ? eu->c3.t0 : cut[0], b = k ? eu->hi - eu->c3.period : cut[1];
            crisp_curve *c3 = NULL;
            if ((st = crisp__step_curve_nurbs(&eu->c3, a, b, &c3))) break;
            double *pts = crisp_malloc_array((size_t)c3->count * 2, sizeof *pts);
            double *wts = crisp_malloc_array((size_t)c3->count, sizeof *wts);
            if (!pts || !wts) st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
            for (int i = 0; !st && i < c3->count; i++) {
                const double *q = c3->cpw + 4 * i;
                double x[3] = {q[0] / q[3] - s->pl.origin[0], q[1] / q[3] - s->pl.origin[1], q[2] / q[3] - s->pl.origin[2]};
                pts[2 * i] = x[0] * s->pl.x[0] + x[1] * s->pl.x[1] + x[2] * s->pl.x[2];
                pts[2 * i + 1] = x[0] * s->pl.y[0] + x[1] * s->pl.y[1] + x[2] * s->pl.y[2];
                wts[i] = q[3];
            }
            if (!st) st = crisp_curve_create(2, c3->degree, c3->count, c3->knots, pts, c3->rational ? wts : NULL, &tmp[k]);
            crisp_free(pts);
            crisp_free(wts);
            crisp_curve_destroy(c3);
            if (!st && !eu->increasing) crisp_curve_reverse(tmp[k]);
        }
        for (int k = 0; k < pieces && !st; k++) {
            int idx = eu->increasing ? k : pieces - 1 - k;
            st = push_curve(w, tmp[idx], out, n, cap);
            tmp[idx] = NULL;
        }
        crisp_curve_destroy(tmp[0]);
        crisp_curve_destroy(tmp[1]);
        return st;
    }
    if (s->kind == STEP_SURF_BSPLINE && !eu->npc) {
        /* Point inversion on the B-spline surface, piece by piece of the 3D curve. */
        double cut[3] = {eu->lo, eu->hi, eu->hi};
        int pieces = 1;
        if (eu->c3.kind == STEP_CURVE_BSPLINE && eu->hi > eu->c3.t1) {
            cut[1] = eu->c3.t1;
            pieces = 2;
        }
        crisp_curve *tmp[2] = {NULL, NULL};
        for (int k = 0; k < pieces; k++) {
            double a = k ? eu->c3.t0 : cut[0], b = k ? eu->hi - eu->c3.period : cut[1];
            crisp_curve *c3 = NULL;
            if ((st = crisp__step_curve_nurbs(&eu->c3, a, b, &c3))) goto fail_bs;
            double d0, d1;
            crisp_curve_domain(c3, &d0, &d1);
            st = crisp_surface_project_curve(s->nurbs, c3, d0, d1, r->tol, &tmp[k]);
            crisp_curve_destroy(c3);
            if (st) {
                crisp_error_prefix("%s: #%d: projecting edge #%d onto surface #%d", r->f->name, w->fe->id, eu->id, s->id);
                goto fail_bs;
            }
            if (!eu->increasing) crisp_curve_reverse(tmp[k]);
        }
        for (int k = 0; k < pieces; k++) {
            int idx = eu->increasing ? k : pieces - 1 - k;
            st = push_curve(w, tmp[idx], out, n, cap);
            tmp[idx] = NULL;
            if (st) goto fail_bs;
        }
        return CRISP_OK;
    fail_bs:
        crisp_curve_destroy(tmp[0]);
        crisp_curve_destroy(tmp[1]);
        return st;
    }
    fit_ctx fc = {w, eu};
    st = crisp_fit_curve(2, fit_fn, &fc, 0, 1, w->tol_uv, 1024, &c);
    if (st) {
        crisp_error_prefix("%s: #%d: fitting the trim of edge #%d on surface #%d", r->f->name, w->fe->id, eu->id, s->id);
        return st;
    }
    return push_curve(w, c, out, n, cap);
}

/* Largest parametric speed of the NURBS surface (|S_u|, |S_v|) on a grid: 3D tolerance / speed is
 * a uv tolerance. */
static double surface_speed(const crisp_surface *s, const double d[4])
{
    double m = 0;
    for (int i = 0; i <= 8; i++)
        for (int j = 0; j <= 8; j++) {
            double su[3], sv[3];
            crisp_surface_derivs(s, d[0] + (d[1] - d[0]) * i / 8, d[2] + (d[3] - d[2]) * j / 8, NULL, su, sv, NULL,
                                 NULL, NULL);
            double a = sqrt(su[0] * su[0] + su[1] * su[1] + su[2] * su[2]);
            double b = sqrt(sv[0] * sv[0] + sv[1] * sv[1] + sv[2] * sv[2]);
            if (a > m) m = a;
            if (b > m) m = b;
        }
    return m;
}

static void curve_end(const crisp_curve *c, int last, double p[2])
{
    double t0, t1;
    crisp_curve_domain(c, &t0, &t1);
    crisp_curve_eval(c, last ? t1 : t0, p);
}

/* Move the first or last control point so the (clamped) curve ends at p. */
static void set_end(crisp_curve *c, int last, const double p[2])
{
    double *q = c->cpw + 3 * (last ? c->count - 1 : 0);
    q[0] = q[2] * p[0];
    q[1] = q[2] * p[1];
}

static int clamped(const crisp_curve *c)
{
    const double *k = c->knots;
    int d = c->degree, n = c->count;
    return k[0] == k[d] && k[n] == k[n + d];
}

static void snap_junctions(crisp_trim_loop *lp, double snap)
{
    for (int i = 0; i < lp->curve_count; i++) {
        crisp_curve *a = lp->curves[i], *b = lp->curves[(i + 1) % lp->curve_count];
        double pa[2], pb[2];
        curve_end(a, 1, pa);
        curve_end(b, 0, pb);
        double gap = hypot(pa[0] - pb[0], pa[1] - pb[1]);
        if (gap == 0 || gap > snap || !clamped(a) || !clamped(b)) continue;
        double m[2] = {0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])};
        set_end(a, 1, m);
        set_end(b, 0, m);
    }
}

/* Where consecutive trims leave a gap in (u, v) that the surface collapses to one point (a pole of
 * a sphere, a cone's apex, a degenerate side of a B-spline patch), the loop runs along the
 * degenerate boundary: a straight uv segment is inserted. STEP writers leave such degenerate
 * edges out. Returns the number of segments inserted, or -1 when out of memory. */
static int bridge_degenerate(const crisp_surface *s, crisp_trim_loop *lp, double tol, double snap)
{
    int added = 0;
    for (int i = 0; i < lp->curve_count; i++) {
        crisp_curve *a = lp->curves[i], *b = lp->curves[(i + 1) % lp->curve_count];
        double pa[2], pb[2];
        curve_end(a, 1, pa);
        curve_end(b, 0, pb);
        if (hypot(pa[0] - pb[0], pa[1] - pb[1]) <= snap) continue;
        double p0[3], q[3];
        crisp_surface_eval(s, pa[0], pa[1], p0);
        int collapsed = 1;
        for (int k = 1; k <= 16 && collapsed; k++) {
            double x = k / 16.0;
            crisp_surface_eval(s, pa[0] + x * (pb[0] - pa[0]), pa[1] + x * (pb[1] - pa[1]), q);
            collapsed = dist3(p0, q) <= tol;
        }
        if (!collapsed) continue;
        crisp_curve *line;
        if (crisp_make_line(2, pa, pb, 0, 1, &line) != CRISP_OK) return -1;
        crisp_curve **nc = crisp_realloc_array(lp->curves, (size_t)lp->curve_count + 1, sizeof *nc);
        if (!nc) {
            crisp_curve_destroy(line);
            return -1;
        }
        lp->curves = nc;
        memmove(nc + i + 2, nc + i + 1, (size_t)(lp->curve_count - i - 1) * sizeof *nc);
        nc[i + 1] = line;
        lp->curve_count++;
        added++;
        i++;
    }
    return added;
}

/* Pull control points that leave the domain back onto its boundary. A fitted or projected trim
 * that runs along the boundary can overshoot it by a little (its curve does not, its control
 * polygon may); clamping keeps the curve inside its convex hull and moves it by at most that
 * overshoot. */
static void clamp_loop(crisp_trim_loop *lp, const double d[4])
{
    for (int i = 0; i < lp->curve_count; i++) {
        crisp_curve *c = lp->curves[i];
        for (int k = 0; k < c->count; k++) {
            double *q = c->cpw + 3 * k;
            for (int j = 0; j < 2; j++) {
                double x = q[j] / q[2];
                if (x < d[2 * j]) q[j] = d[2 * j] * q[2];
                if (x > d[2 * j + 1]) q[j] = d[2 * j + 1] * q[2];
            }
        }
    }
}

/* Loop A's curves are in lp: add the seam segment, loop B (reversed when needed), the seam back. */
static crisp_status append_band(face_work *w, const crisp_surface *s, crisp_trim_loop *lp, size_t *cap)
{
    if (w->band_b < 0) {
        /* Closed at a collapsed line: seam up to it, along it, seam down. */
        const loop_work *A = &w->loops[w->band_a];
        const edge_use *e0 = &A->edges[0], *e1 = &A->edges[A->count - 1];
        double f0[2] = {e0->uv[0], e0->uv[1]}, f1[2] = {e1->uv[2 * e1->ns - 2], e1->uv[2 * e1->ns - 1]};
        f0[1 - w->cap_k] = w->cap_v;
        f1[1 - w->cap_k] = w->cap_v;
        double p[4][2];
        curve_end(lp->curves[lp->curve_count - 1], 1, p[0]);
        crisp__step_surface_map(&w->s, w->box, f1, p[1]);
        crisp__step_surface_map(&w->s, w->box, f0, p[2]);
        curve_end(lp->curves[0], 0, p[3]);
        for (int k = 0; k < 3; k++) {
            crisp_curve *c;
            crisp_status st = crisp_make_line(2, p[k], p[k + 1], 0, 1, &c);
            if (!st) st = push_curve(w, c, &lp->curves, &lp->curve_count, cap);
            if (st) return st;
        }
        return CRISP_OK;
    }
    crisp_trim_loop b = {0};
    size_t bcap = 0;
    crisp_status st = CRISP_OK;
    loop_work *B = &w->loops[w->band_b];
    for (int k = 0; k < B->count && !st; k++) st = edge_trims(w, s, &B->edges[k], &b.curves, &b.curve_count, &bcap);
    if (!st && w->band_rev) crisp_trim_loop_reverse(&b);
    double a0[2], a1[2], b0[2], b1[2];
    if (!st && lp->curve_count && b.curve_count) {
        curve_end(lp->curves[0], 0, a0);
        curve_end(lp->curves[lp->curve_count - 1], 1, a1);
        curve_end(b.curves[0], 0, b0);
        curve_end(b.curves[b.curve_count - 1], 1, b1);
        crisp_curve *up = NULL, *down = NULL;
        st = crisp_make_line(2, a1, b0, 0, 1, &up);
        if (!st) st = push_curve(w, up, &lp->curves, &lp->curve_count, cap);
        for (int k = 0; k < b.curve_count && !st; k++) {
            st = push_curve(w, b.curves[k], &lp->curves, &lp->curve_count, cap);
            b.curves[k] = NULL;
        }
        if (!st) st = crisp_make_line(2, b1, a0, 0, 1, &down);
        if (!st) st = push_curve(w, down, &lp->curves, &lp->curve_count, cap);
    }
    crisp_trim_loop_free(&b);
    return st;
}

/* ---- the face ----------------------------------------------------------------------------------- */

static crisp_status read_loops(face_work *w)
{
    step_reader *r = w->r;
    const step_entity *fe = w->fe;
    const step_part *fp = crisp__step_part(r, fe, NULL);
    const step_value *bounds;
    crisp_status st = crisp__step_get_list(r, fe, fp, 1, &bounds);
    if (st) return st;
    if (bounds->len > MAX_LOOPS) return crisp__step_fail(r, fe, CRISP_ERR_LIMIT, "more than %d bounds", MAX_LOOPS);
    w->loops = crisp_calloc_array(bounds->len ? bounds->len : 1, sizeof *w->loops);
    if (!w->loops) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
    for (uint32_t i = 0; i < bounds->len; i++) {
        const step_entity *be, *le;
        if ((st = crisp__step_deref(r, fe, crisp__step_elem(r, bounds, i), &be))) return st;
        const step_part *bp = crisp__step_part(r, be, "FACE_OUTER_BOUND");
        int outer = bp != NULL;
        if (!bp) bp = crisp__step_part(r, be, "FACE_BOUND");
        if (!bp) return crisp__step_fail(r, be, CRISP_ERR_PARSE, "expected a FACE_BOUND or FACE_OUTER_BOUND");
        if ((st = crisp__step_get_ref(r, be, bp, 1, &le))) return st;
        if (crisp__step_is(r, le, "VERTEX_LOOP")) {
            /* A bound of one vertex (apex, pole) adds no trim; it may close a winding loop. */
            const step_entity *ve;
            if ((st = crisp__step_get_ref(r, le, crisp__step_part(r, le, "VERTEX_LOOP"), 1, &ve))) return st;
            if (w->ncap < 2 && (st = vertex_point(r, ve, w->cap_pt[w->ncap++]))) return st;
            continue;
        }
        const step_part *lp = crisp__step_part(r, le, "EDGE_LOOP");
        if (!lp) return crisp__step_fail(r, le, CRISP_ERR_UNSUPPORTED, "expected an EDGE_LOOP");
        const step_value *edges;
        if ((st = crisp__step_get_list(r, le, lp, 1, &edges))) return st;
        if (edges->len < 1 || edges->len > MAX_EDGES)
            return crisp__step_fail(r, le, CRISP_ERR_LIMIT, "expected 1 to %d edges, found %u", MAX_EDGES, edges->len);
        loop_work *lw = &w->loops[w->nloops++];
        lw->outer_flag = outer;
        lw->edges = crisp_calloc_array(edges->len, sizeof *lw->edges);
        if (!lw->edges) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
        for (uint32_t k = 0; k < edges->len; k++) {
            const step_entity *oe;
            if ((st = crisp__step_deref(r, le, crisp__step_elem(r, edges, k), &oe))) return st;
            lw->count++;
            if ((st = edge_setup(w, oe, &lw->edges[k]))) return st;
        }
    }
    return CRISP_OK;
}

crisp_status crisp__step_face(step_reader *r, const step_entity *fe, crisp_face *dest)
{
    memset(dest, 0, sizeof *dest);
    face_work w = {.r = r, .fe = fe, .band_a = -1, .band_b = -1};
    const step_part *fp = crisp__step_part(r, fe, NULL);
    const step_entity *se;
    int same;
    crisp_status st;
    if ((st = crisp__step_get_ref(r, fe, fp, 2, &se)) || (st = crisp__step_get_bool(r, fe, fp, 3, &same)))
        return st;
    if ((st = crisp__step_surface(r, se, &w.s))) return st;
    w.period[0] = w.s.u_periodic ? 2 * M_PI : 0;
    w.period[1] = w.s.v_periodic ? 2 * M_PI : 0;
    if (w.s.kind == STEP_SURF_EXTRUSION && w.s.profile.kind != STEP_CURVE_CONIC) w.period[0] = 0;
    if ((st = read_loops(&w))) goto done;
    if (w.nloops == 0 && w.s.kind != STEP_SURF_BSPLINE) {
        st = crisp__step_fail(r, fe, CRISP_ERR_UNSUPPORTED, "face on an unbounded surface without edge loops");
        goto done;
    }
    int outer = 0;
    for (int i = 0; i < w.nloops; i++)
        if ((st = loop_samples(&w, &w.loops[i]))) goto done;
    if (w.s.kind != STEP_SURF_BSPLINE) {
        double best = -1;
        for (int i = 0; i < w.nloops; i++) {
            const double *b = w.loops[i].box;
            double area = (b[1] - b[0]) * (b[3] - b[2]);
            if (w.loops[i].outer_flag) area = INFINITY;
            if (area > best) best = area, outer = i;
        }
        /* Loops that wind around a periodic direction do not close in (u, v): two of them bound
         * a band and are joined along the seam; any other winding loop is not supported. */
        int wl[2], nw = 0, wk = -1;
        for (int i = 0; i < w.nloops; i++)
            for (int k = 0; k < 2; k++)
                if (fabs(winding(&w, &w.loops[i], k)) > 0.5 * w.period[k] && w.period[k] > 0) {
                    if (nw == 2 || (wk >= 0 && wk != k)) {
                        st = crisp__step_fail(r, fe, CRISP_ERR_UNSUPPORTED,
                                              "loop %d winds around the %c direction of surface #%d and is not one "
                                              "of two loops bounding a band", i + 1, "uv"[k], w.s.id);
                        goto done;
                    }
                    wl[nw++] = i;
                    wk = k;
                }
        if (nw == 1 && w.ncap == 1) {
            /* One winding loop and a vertex loop: the face is closed at the apex or pole, where the
             * surface collapses; the loop runs up the seam, along the collapsed line, down. */
            double uv[2];
            const edge_use *e0 = &w.loops[wl[0]].edges[0];
            crisp__step_surface_invert(&w.s, w.cap_pt[0], e0->uv, uv);
            w.band_a = wl[0];
            w.cap_k = wk;
            w.cap_v = uv[1 - wk];
            double *bx = w.loops[wl[0]].box;
            if (w.cap_v < bx[2 * (1 - wk)]) bx[2 * (1 - wk)] = w.cap_v;
            if (w.cap_v > bx[2 * (1 - wk) + 1]) bx[2 * (1 - wk) + 1] = w.cap_v;
            outer = wl[0];
            nw = 0;
        }
        if (nw == 1) {
            st = crisp__step_fail(r, fe, CRISP_ERR_UNSUPPORTED,
                                  "loop %d winds around the %c direction of surface #%d without a seam edge", wl[0] + 1,
                                  "uv"[wk], w.s.id);
            goto done;
        }
        if (nw == 2) {
            if ((st = make_band(&w, wl[0], wl[1], wk))) goto done;
            outer = wl[0];
        }
        /* Holes on periodic coordinates go to the turn of the outer loop. */
        for (int i = 0; i < w.nloops; i++) {
            if (i == outer || i == w.band_b) continue;
            double c[2] = {0.5 * (w.loops[i].box[0] + w.loops[i].box[1]), 0.5 * (w.loops[i].box[2] + w.loops[i].box[3])};
            double oc[2] = {0.5 * (w.loops[outer].box[0] + w.loops[outer].box[1]),
                            0.5 * (w.loops[outer].box[2] + w.loops[outer].box[3])}, sh[2];
            period_shift(&w, c, oc, sh);
            if (sh[0] != 0 || sh[1] != 0) shift_loop(&w.loops[i], sh);
        }
        choose_box(&w, outer);
    }
    if ((st = crisp__step_surface_build(r, &w.s, w.box, &dest->surface, w.nbox))) goto done;
    double speed = surface_speed(dest->surface, w.nbox);
    w.tol_uv = speed > 0 ? r->tol / speed : 1e-9;
    double dsize = fmax(w.nbox[1] - w.nbox[0], w.nbox[3] - w.nbox[2]);
    if (w.tol_uv > 1e-3 * dsize) w.tol_uv = 1e-3 * dsize;
    dest->loops = crisp_calloc_array((size_t)(w.nloops ? w.nloops : 1), sizeof *dest->loops);
    if (!dest->loops) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
        goto done;
    }
    for (int i = 0; i < w.nloops; i++) {
        if (i == w.band_b) continue;
        crisp_trim_loop *lp = &dest->loops[dest->loop_count++];
        size_t cap = 0;
        lp->is_outer = i == outer;
        for (int k = 0; k < w.loops[i].count; k++)
            if ((st = edge_trims(&w, dest->surface, &w.loops[i].edges[k], &lp->curves, &lp->curve_count, &cap)))
                goto done;
        if (i == w.band_a && (st = append_band(&w, dest->surface, lp, &cap))) goto done;
        snap_junctions(lp, 100 * w.tol_uv);
        int added = bridge_degenerate(dest->surface, lp, r->tol, 100 * w.tol_uv);
        if (added < 0) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
            goto done;
        }
        r->stats->degenerate_edges += added;
        clamp_loop(lp, w.nbox);
    }
    if (w.s.kind == STEP_SURF_BSPLINE) {
        /* The outer loop: the flagged one, else the one with the largest box of its curves. */
        double best = -1;
        for (int i = 0; i < dest->loop_count; i++) {
            double b[4] = {INFINITY, -INFINITY, INFINITY, -INFINITY}, cb[4];
            for (int k = 0; k < dest->loops[i].curve_count; k++) {
                crisp_curve_bbox(dest->loops[i].curves[k], cb);
                b[0] = fmin(b[0], cb[0]), b[1] = fmax(b[1], cb[2]);
                b[2] = fmin(b[2], cb[1]), b[3] = fmax(b[3], cb[3]);
            }
            double area = w.loops[i].outer_flag ? INFINITY : (b[1] - b[0]) * (b[3] - b[2]);
            if (area > best) best = area, outer = i;
        }
        for (int i = 0; i < dest->loop_count; i++) dest->loops[i].is_outer = i == outer;
    }
    dest->source_id = fe->id;
    dest->reversed = (!same) ^ crisp__step_surface_swaps(&w.s);
    st = crisp_face_normalize_loops(dest, r->close_rel * dsize);
    if (st) crisp_error_prefix("%s: #%d (line %d) ADVANCED_FACE", r->f->name, fe->id, fe->line);
done:
    work_free(&w);
    if (st) {
        crisp_face_free(dest);
        memset(dest, 0, sizeof *dest);
    }
    return st;
}
