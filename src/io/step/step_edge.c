/* STEP edge uses and loops in the file's own (u, v) (ISO 10303-42 5.4: edge_loop, oriented_edge,
 * edge_curve, vertex_point; 4.4: pcurve, surface_curve, seam_curve): each edge's 3D curve and
 * parameter range from its vertices, its pcurves on the face's surface located on their own
 * parameter and checked against the 3D edge, samples along each loop (angles unwrapped, seams
 * chosen by continuity), the box the face's NURBS surface must cover, and bands: two loops that
 * wind around a periodic surface joined along the seam.
 */
#include "step_face.h"

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define MAX_LOOPS 4096
#define MAX_EDGES 65536

static void edge_free(edge_use *e)
{
    crisp__step_curve_free(&e->c3);
    for (int k = 0; k < e->npc; k++)
        crisp__step_curve_free(&e->pc[k]);
    crisp_free(e->ts);
    crisp_free(e->uv);
}

void crisp__step_work_free(face_work *w)
{
    for (int i = 0; i < w->nloops; i++) {
        for (int k = 0; k < w->loops[i].count; k++)
            edge_free(&w->loops[i].edges[k]);
        crisp_free(w->loops[i].edges);
    }
    crisp_free(w->loops);
    crisp__step_surface_free(&w->s);
}

/* Curve parameter t of an edge, wrapped back into a closed B-spline's domain. */
double crisp__step_curve_wrap(const step_curve *c, double t)
{
    if (c->kind == STEP_CURVE_BSPLINE && c->periodic && t > c->t1) t -= c->period;
    return t;
}

double crisp__step_dist3(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
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

/* Pcurve coordinates that are angles (u on cylinders, cones and surfaces of revolution, both on
 * spheres and tori) are in the file's plane angle unit (ISO 10303-42 4.4: parameters of the
 * elementary surfaces; Pro/ENGINEER writes degrees): scaled to radians. A circle in such a
 * (u, v) would become an ellipse; it is left as it is (the pcurve check rejects it if wrong). */
static void pcurve_to_radians(const step_reader *r, const step_surface *s, step_curve *c)
{
    double k[2] = {1, 1};
    if (r->angle_unit == 1 || !(r->angle_unit > 0)) return;
    switch (s->kind) {
    case STEP_SURF_CYLINDER:
    case STEP_SURF_CONE:
    case STEP_SURF_REVOLUTION:
        k[0] = r->angle_unit;
        break;
    case STEP_SURF_SPHERE:
    case STEP_SURF_TORUS:
        k[0] = k[1] = r->angle_unit;
        break;
    case STEP_SURF_EXTRUSION:
        if (s->profile.kind == STEP_CURVE_CONIC) k[0] = r->angle_unit;
        break;
    default:
        return;
    }
    if (c->kind == STEP_CURVE_LINE) {
        /* A line along an angle coordinate is the pcurve of a circle, whose parameter is that
         * angle: the parameter becomes radians with it (only the origin scales). Any other line
         * keeps its parameter (a seam's is a length along the 3D line). */
        /* (A trimmed line's bounds are in its own parameter: it scales whole.) */
        int unbounded = !isfinite(c->t0) && !isfinite(c->t1);
        int along_u = unbounded && fabs(c->d[1]) <= 1e-12 * fabs(c->d[0]);
        int along_v = unbounded && fabs(c->d[0]) <= 1e-12 * fabs(c->d[1]);
        for (int j = 0; j < 2; j++) {
            c->p[j] *= k[j];
            if (!((j == 0 && along_u) || (j == 1 && along_v))) c->d[j] *= k[j];
        }
    } else if (c->kind == STEP_CURVE_BSPLINE && c->nurbs && c->nurbs->dim == 2) {
        for (int i = 0; i < c->nurbs->count; i++)
            for (int j = 0; j < 2; j++)
                c->nurbs->cpw[3 * i + j] *= k[j];
    }
}

crisp_status crisp__step_pcurve_curve(step_reader *r, const step_entity *pe, const step_surface *s,
                                      step_curve *dest)
{
    const step_part *pp = crisp__step_part(r, pe, "PCURVE");
    const step_entity *de, *ce;
    const step_value *items;
    crisp_status st;
    memset(dest, 0, sizeof *dest);
    if ((st = crisp__step_get_ref(r, pe, pp, 2, &de))) return st;
    /* DEFINITIONAL_REPRESENTATION(name, items, context), or the complex instance
     * (DEFINITIONAL_REPRESENTATION() REPRESENTATION(name, items, context) SHAPE_REPRESENTATION()).
     */
    const step_part *dp = crisp__step_part(r, de, "DEFINITIONAL_REPRESENTATION");
    if (!dp)
        return crisp__step_fail(r, de, CRISP_ERR_PARSE, "expected a DEFINITIONAL_REPRESENTATION");
    if (de->part_count > 1 && crisp__step_part(r, de, "REPRESENTATION"))
        dp = crisp__step_part(r, de, "REPRESENTATION");
    if ((st = crisp__step_get_list(r, de, dp, 1, &items))) return st;
    if (items->len < 1)
        return crisp__step_fail(r, de, CRISP_ERR_PARSE, "expected a 2D curve in the items");
    if ((st = crisp__step_deref(r, de, crisp__step_elem(r, items, 0), &ce))) return st;
    if ((st = crisp__step_curve(r, ce, dest))) return st;
    if (dest->dim != 2) {
        crisp__step_curve_free(dest);
        return crisp__step_fail(r, ce, CRISP_ERR_PARSE, "expected a 2D curve for a pcurve");
    }
    if (s) pcurve_to_radians(r, s, dest);
    return CRISP_OK;
}

/* The pcurves of a SURFACE_CURVE / SEAM_CURVE that lie on surface entity sid. */
crisp_status crisp__step_find_pcurves(step_reader *r, const step_entity *ge,
                                      const step_surface *surf, edge_use *eu)
{
    int off;
    const step_part *p = crisp__step_surface_curve_part(r, ge, &off);
    const step_value *assoc = crisp__step_param(r, p, off + 1);
    if (!assoc || assoc->kind != STEP_LIST) return CRISP_OK;
    for (uint32_t i = 0; i < assoc->len && eu->npc < 2; i++) {
        const step_entity *pe, *se;
        crisp_status st = crisp__step_deref(r, ge, crisp__step_elem(r, assoc, i), &pe);
        if (st) return st;
        const step_part *pp = crisp__step_part(r, pe, "PCURVE");
        if (!pp) continue;
        if ((st = crisp__step_get_ref(r, pe, pp, 1, &se))) return st;
        if (se->id != surf->id) continue;
        if ((st = crisp__step_pcurve_curve(r, pe, surf, &eu->pc[eu->npc]))) return st;
        eu->npc++;
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
    double t = eu->increasing ? eu->pt0[k] + s * (eu->pt1[k] - eu->pt0[k])
                              : eu->pt1[k] - s * (eu->pt1[k] - eu->pt0[k]);
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
    return (p[0] - v[0]) * (p[0] - v[0]) + (p[1] - v[1]) * (p[1] - v[1]) +
           (p[2] - v[2]) * (p[2] - v[2]);
}

/* The pcurve parameter whose surface point is nearest v, searched around guess. Writers do not
 * always keep the pcurve's parameter equal to the 3D curve's (OCCT's rational pcurves of circles
 * agree only at the knots), so the vertices are located on the pcurve itself. */
static double pc_locate(const face_work *w, const edge_use *eu, int k, double guess, double delta,
                        const double v[3])
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
        if (d < bd * (1 - 1e-9) ||
            (d <= bd * (1 + 1e-9) + 1e-30 && fabs(t - guess) < fabs(best - guess)))
            bd = d, best = t;
    }
    double lo = best - (b - a) / n, hi = best + (b - a) / n;
    if (lo < a) lo = a;
    if (hi > b) hi = b;
    const double g = 0.6180339887498949;
    double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    double f1 = pc_dist2(w, eu, k, x1, v), f2 = pc_dist2(w, eu, k, x2, v);
    for (int it = 0; it < 90 && hi - lo > 1e-15 * (1 + fabs(lo)); it++) {
        if (f1 < f2)
            hi = x2, x2 = x1, f2 = f1, x1 = hi - g * (hi - lo), f1 = pc_dist2(w, eu, k, x1, v);
        else
            lo = x1, x1 = x2, f1 = f2, x2 = lo + g * (hi - lo), f2 = pc_dist2(w, eu, k, x2, v);
    }
    double t = 0.5 * (lo + hi);
    if (pc_dist2(w, eu, k, a, v) <= pc_dist2(w, eu, k, t, v)) t = a;
    if (pc_dist2(w, eu, k, b, v) < pc_dist2(w, eu, k, t, v)) t = b;
    return t;
}

/* Locate the edge's ends on pcurve k and check that its image follows the 3D curve. */
static int pcurve_agrees(face_work *w, edge_use *eu, int k, const double first[3],
                         const double second[3])
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
    double lo = c->kind == STEP_CURVE_BSPLINE ? c->t0 : eu->lo,
           hi = c->kind == STEP_CURVE_BSPLINE ? c->t1 : eu->hi;
    for (int i = 0; i <= 8; i++) {
        double t = eu->pt0[k] + (eu->pt1[k] - eu->pt0[k]) * i / 8, uv[2], a[3], b[3];
        pc_eval(eu, k, t, uv);
        crisp__step_surface_eval(&w->s, uv[0], uv[1], a);
        crisp__step_curve_eval(c, crisp__step_curve_invert(c, a, lo, hi), b);
        if (crisp__step_dist3(a, b) > w->r->tol) return 0;
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
        if (depth > 8)
            return crisp__step_fail(r, oe, CRISP_ERR_LIMIT, "oriented edges nested too deeply");
        if ((st = crisp__step_get_bool(r, ee, p, 4, &o)) ||
            (st = crisp__step_get_ref(r, ee, p, 3, &ee)))
            return st;
        orient = orient == o;
    }
    const step_part *ep = crisp__step_part(r, ee, "EDGE_CURVE");
    if (!ep) return crisp__step_fail(r, ee, CRISP_ERR_UNSUPPORTED, "expected an EDGE_CURVE");
    eu->edge_id = ee->id;
    const step_entity *vs, *ve, *ge;
    int same;
    double ps[3], pe[3];
    if ((st = crisp__step_get_ref(r, ee, ep, 1, &vs)) ||
        (st = crisp__step_get_ref(r, ee, ep, 2, &ve)) ||
        (st = crisp__step_get_ref(r, ee, ep, 3, &ge)) ||
        (st = crisp__step_get_bool(r, ee, ep, 4, &same)) || (st = vertex_point(r, vs, ps)) ||
        (st = vertex_point(r, ve, pe)))
        return st;
    if (crisp__step_is(r, ge, "PCURVE"))
        return crisp__step_fail(r, ge, CRISP_ERR_UNSUPPORTED,
                                "edge geometry given only as a pcurve");
    if ((st = crisp__step_curve(r, ge, &eu->c3))) return st;
    step_curve *c = &eu->c3;
    if (c->dim != 3)
        return crisp__step_fail(r, ge, CRISP_ERR_PARSE, "expected a 3D curve as edge geometry");
    if (crisp__step_is(r, ge, "SURFACE_CURVE") || crisp__step_is(r, ge, "SEAM_CURVE"))
        if ((st = crisp__step_find_pcurves(r, ge, &w->s, eu))) return st;
    /* Against a reversed trimmed curve, the edge's sense is against the basis curve's. */
    same ^= c->reversed;
    const double *first = same ? ps : pe, *second = same ? pe : ps;
    /* Two vertex entities at one point also close an edge; two merely within the tolerance do
     * not: on a model whose tolerance is coarse for its small features (trj6_b1-ec-214.stp:
     * 0.3 beside arcs a few units long) short arcs would become full circles. */
    int closed = vs == ve || crisp__step_dist3(ps, pe) <= 1e-3 * r->tol;
    double lo = crisp__step_curve_invert(c, first, c->t0, c->t1);
    double hi = crisp__step_curve_invert(c, second, c->t0, c->t1);
    if (c->periodic) {
        double eps = 1e-12 * c->period;
        if (c->kind == STEP_CURVE_CONIC) {
            if (isfinite(c->t0)) { /* trimmed arc: both in [t0, t0 + 2 pi) */
                if (!(hi > lo + eps)) hi += c->period;
            } else {
                while (hi <= lo + eps)
                    hi += c->period;
                while (hi > lo + c->period + eps)
                    hi -= c->period;
                if (closed) hi = lo + c->period;
            }
        } else if (closed) {
            if (lo >= c->t1 - eps) lo = c->t0;
            hi = lo + c->period;
        } else if (!(hi > lo + eps)) {
            if (lo >= c->t1 - eps)
                lo = c->t0;
            else if (hi <= c->t0 + eps)
                hi = c->t1;
            else
                hi += c->period;
        }
    }
    if (!(hi > lo) && !c->periodic && closed && c->kind == STEP_CURVE_BSPLINE) {
        /* One vertex at both ends of an open curve (trj3_s1-al-214.stp): the edge is the whole
         * curve; the closure check of the loop judges the gap. */
        lo = c->t0, hi = c->t1;
    } else if (hi < lo && !c->periodic) {
        /* The curve runs against the edge's sense although same_sense says it agrees (a LINE whose
         * direction points from the end vertex to the start, trj9_ap209-mp.stp): the vertices
         * are what the loop joins, so the sense is turned round. */
        double t = lo;
        lo = hi, hi = t;
        same ^= 1;
        const double *v = first;
        first = second, second = v;
        r->stats->flipped_segments++;
    }
    if (!(hi > lo)) {
        return crisp__step_fail(
            r, ee, CRISP_ERR_NUMERIC,
            "edge vertices at curve parameters %g and %g: expected an increasing range "
            "along #%d (same_sense %s)",
            lo, hi, ge->id, same ? ".T." : ".F.");
    }
    eu->lo = lo;
    eu->hi = hi;
    eu->increasing = same == orient;
    /* On a periodic curve the pcurve may use another turn of the parameter: move the range into
     * the pcurve's domain. */
    if (eu->npc && c->periodic && c->kind == STEP_CURVE_CONIC && isfinite(eu->pc[0].t0) &&
        isfinite(eu->pc[0].t1)) {
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
    if (!eu->ts || !eu->uv)
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", w->r->f->name);
    for (int i = 0; i < eu->ns; i++)
        eu->ts[i] = loop_t(eu, (double)i / (eu->ns - 1));
    return CRISP_OK;
}

/* Shift of uv (per periodic coordinate) that brings it nearest to ref. */
void crisp__step_period_shift(const face_work *w, const double uv[2], const double ref[2],
                              double shift[2])
{
    for (int k = 0; k < 2; k++) {
        shift[k] = 0;
        if (w->period[k] > 0)
            shift[k] = w->period[k] * floor((ref[k] - uv[k]) / w->period[k] + 0.5);
    }
}

/* Whether the surface collapses to one point along periodic coordinate k at file uv (a cone's
 * apex, a sphere's pole): there the coordinate is undefined. */
static int collapsed_at(const face_work *w, const double uv[2], int k)
{
    double p[3], q[3], x[2] = {uv[0], uv[1]};
    crisp__step_surface_eval(&w->s, uv[0], uv[1], p);
    for (int i = 1; i <= 3; i++) {
        x[k] = uv[k] + w->period[k] * i / 4;
        crisp__step_surface_eval(&w->s, x[0], x[1], q);
        if (!(crisp__step_dist3(p, q) <= w->r->tol)) return 0;
    }
    return 1;
}

/* A loop that passes through an apex or a pole (a half cone bounded by an arc and two generators
 * meeting at the apex, a lune of a sphere) crosses the collapsed line there, where the periodic
 * coordinate is undefined: the jump it makes there is free, and continuity alone may pick the
 * wrong turn (the generators of a half cone lie half a turn apart, either way round). Such a loop
 * does not wind around the surface: the part after the first collapsed vertex moves by whole turns
 * so that the loop closes (PRO10363.stp: 2 half cones), and the loop is marked (`collapse`) so that
 * it is not taken for one that winds (bug29241.stp: cone sectors of more than half a turn that
 * start at the apex). */
static void unwind_at_collapse(face_work *w, loop_work *lw)
{
    for (int k = 0; k < 2; k++) {
        if (!(w->period[k] > 0) || lw->count < 2) continue;
        /* An edge's end at the collapsed point takes the coordinate of its own next sample (a
         * generator's apex end lies on the generator), not the previous edge's: the jump
         * happens between edges, where the trims are bridged along the collapsed line. */
        for (int m = 0; m < lw->count; m++) {
            edge_use *eu = &lw->edges[m];
            if (eu->npc || eu->ns < 3) continue;
            if (collapsed_at(w, eu->uv, k) && !collapsed_at(w, eu->uv + 2, k))
                eu->uv[k] = eu->uv[2 + k];
            double *last = eu->uv + 2 * eu->ns - 2;
            if (collapsed_at(w, last, k) && !collapsed_at(w, last - 2, k)) last[k] = last[k - 2];
        }
        for (int m = 0; m < lw->count; m++)
            if (lw->edges[m].ns && collapsed_at(w, lw->edges[m].uv, k)) lw->collapse = 1;
        /* (A loop that starts at the collapsed point closes there by whatever jump: a sector of
         * a cone of any angle. One that passes it later must come back to its start.) */
        double turns = round(crisp__step_winding(w, lw, k) / w->period[k]);
        if (turns == 0) continue;
        for (int m = 1; m < lw->count; m++) {
            const edge_use *eu = &lw->edges[m];
            if (!eu->ns || !collapsed_at(w, eu->uv, k)) continue;
            double sh[2] = {0, 0};
            sh[k] = -turns * w->period[k];
            for (int j = m; j < lw->count; j++) {
                edge_use *e = &lw->edges[j];
                for (int i = 0; i < e->ns; i++)
                    e->uv[2 * i + k] += sh[k];
                e->shift[k] += sh[k];
            }
            break;
        }
    }
}

/* Twice the signed (u, v) area of a loop's samples (closed by straight segments). */
static double loop_area2(const loop_work *lw)
{
    double a = 0, first[2] = {0, 0}, prev[2] = {0, 0};
    int have = 0;
    for (int m = 0; m < lw->count; m++) {
        const edge_use *eu = &lw->edges[m];
        for (int i = 0; i < eu->ns; i++) {
            const double *p = eu->uv + 2 * i;
            if (have)
                a += prev[0] * p[1] - p[0] * prev[1];
            else
                first[0] = p[0], first[1] = p[1];
            prev[0] = p[0], prev[1] = p[1];
            have = 1;
        }
    }
    if (have) a += prev[0] * first[1] - first[0] * prev[1];
    return a;
}

static void shift_range(loop_work *lw, int from, int to, int k, double d)
{
    for (int j = from; j < to; j++) {
        edge_use *e = &lw->edges[j];
        for (int i = 0; i < e->ns; i++)
            e->uv[2 * i + k] += d;
        e->shift[k] += d;
    }
}

/* A lone loop through an apex or a pole that does not wind (a lune of a sphere) bounds either of
 * the two regions between its edges: the file says which by the loop's sense (ISO 10303-42: the
 * face lies on the left of its bounds seen against the face normal; (u, v, S_u x S_v) is right
 * handed, so the outer loop runs counter-clockwise in (u, v) when the face normal is the
 * surface's and the bound's orientation .T.). A loop unwound the wrong way round moves its part
 * between two collapsed vertices by a turn, to the other region (pro10363.stp's sphere of two
 * lunes: both were read as the same half). A loop that passes one collapsed vertex only (a half
 * cone: an arc and two generators) has no other region: it is left as it is. */
static void orient_at_collapse(face_work *w, loop_work *lw)
{
    double want = (lw->sense ? -1 : 1) * (w->same ? 1 : -1);
    if (!lw->collapse || loop_area2(lw) * want >= 0) return;
    for (int k = 0; k < 2; k++) {
        if (!(w->period[k] > 0)) continue;
        int at[3], n = 0;
        for (int m = 0; m < lw->count && n < 3; m++)
            if (lw->edges[m].ns && collapsed_at(w, lw->edges[m].uv, k)) at[n++] = m;
        int from, to;
        if (n >= 2 && at[0] == 0)
            from = at[1], to = lw->count;
        else if (n >= 2)
            from = at[0], to = at[1];
        else
            continue;
        double best = 0, best_a = INFINITY;
        for (int s = -1; s <= 1; s += 2) {
            shift_range(lw, from, to, k, s * w->period[k]);
            double a = loop_area2(lw) * want;
            if (a > 0 && a < best_a) best_a = a, best = s * w->period[k];
            shift_range(lw, from, to, k, -s * w->period[k]);
        }
        if (best != 0) {
            shift_range(lw, from, to, k, best);
            return;
        }
    }
}

/* File-uv samples of every edge of a loop, continuous along the loop. */
crisp_status crisp__step_loop_samples(face_work *w, loop_work *lw)
{
    int n = lw->count;
    /* Start at an edge with at most one pcurve, so that seams are chosen by continuity. */
    int start = 0;
    while (start < n && lw->edges[start].npc == 2)
        start++;
    if (start == n) start = 0;
    double prev[2] = {0, 0}, seed[2] = {0, 0};
    int have_prev = 0, have_seed = 0;
    /* On an extrusion of a closed B-spline profile, a loop that starts at the profile's closure
     * point could take either end of the profile's range for its first sample, and the loop
     * cannot run on past an end (trj7_k1-sd-214.stp: started at the end 62.89 of [3.32, 62.89],
     * a loop over [3.32, 33.10] stuck there, its trims 20 units off). The end nearer an edge
     * midpoint of the loop that is not at the closure is taken. */
    if (w->s.kind == STEP_SURF_EXTRUSION && w->s.profile.kind == STEP_CURVE_BSPLINE &&
        w->s.profile.periodic) {
        double t0 = w->s.profile.t0, t1 = w->s.profile.t1, eps = 1e-6 * (t1 - t0);
        for (int m = 0; m < n && !have_seed; m++) {
            const edge_use *eu = &lw->edges[(start + m) % n];
            double p[3], uv[2];
            crisp__step_curve_eval(&eu->c3,
                                   crisp__step_curve_wrap(&eu->c3, 0.5 * (eu->lo + eu->hi)), p);
            crisp__step_surface_invert(&w->s, p, NULL, uv);
            if (fabs(uv[0] - t0) > eps && fabs(uv[0] - t1) > eps && isfinite(uv[0]))
                seed[0] = uv[0], seed[1] = uv[1], have_seed = 1;
        }
    }
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
                double da = hypot(a[0] - prev[0], a[1] - prev[1]),
                       db = hypot(b[0] - prev[0], b[1] - prev[1]);
                eu->chosen = db < da;
            }
            /* A seam edge used twice in the loop runs along both of its pcurves, in the same
             * turn. Where the loop passes from one use to the other at a pole or apex,
             * continuity cannot tell them apart (trj4_s1-ec-214.stp, hemispheres bounded by the
             * equator and a seam): there the second use takes the pcurve the first did not.
             * (Elsewhere continuity decides: some writers give a seam two equal pcurves.) */
            const edge_use *twin = NULL;
            int at_collapse = 0;
            for (int k = 0; k < 2 && have_prev; k++)
                if (w->period[k] > 0 && w->s.kind != STEP_SURF_BSPLINE)
                    at_collapse |= collapsed_at(w, prev, k);
            for (int q = 0; q < m && !twin && at_collapse; q++) {
                const edge_use *o = &lw->edges[(start + q) % n];
                if (o->edge_id == eu->edge_id && o->npc == 2 && eu->npc == 2) twin = o;
            }
            double uv0[2];
            if (twin) {
                eu->chosen = 1 - twin->chosen;
                eu->shift[0] = twin->shift[0], eu->shift[1] = twin->shift[1];
            }
            pc_at(eu, eu->chosen, 0, uv0);
            if (have_prev && !twin) crisp__step_period_shift(w, uv0, prev, eu->shift);
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
                crisp__step_curve_eval(&eu->c3, crisp__step_curve_wrap(&eu->c3, eu->ts[i]), p);
                crisp__step_surface_invert(&w->s, p,
                                           have_prev || i ? prev
                                           : have_seed    ? seed
                                                          : NULL,
                                           eu->uv + 2 * i);
                prev[0] = eu->uv[2 * i], prev[1] = eu->uv[2 * i + 1];
                have_prev = 1;
            }
        }
        prev[0] = eu->uv[2 * eu->ns - 2];
        prev[1] = eu->uv[2 * eu->ns - 1];
        have_prev = 1;
    }
    if (w->s.kind != STEP_SURF_BSPLINE) unwind_at_collapse(w, lw);
    if (w->s.kind != STEP_SURF_BSPLINE && w->nloops == 1 && w->ncap == 0) orient_at_collapse(w, lw);
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

void crisp__step_shift_loop(loop_work *lw, const double shift[2])
{
    for (int m = 0; m < lw->count; m++) {
        edge_use *eu = &lw->edges[m];
        for (int i = 0; i < eu->ns; i++)
            eu->uv[2 * i] += shift[0], eu->uv[2 * i + 1] += shift[1];
        eu->shift[0] += shift[0];
        eu->shift[1] += shift[1];
    }
    lw->box[0] += shift[0], lw->box[1] += shift[0];
    lw->box[2] += shift[1], lw->box[3] += shift[1];
}

/* The file-uv box the NURBS surface covers: the loops' box with a margin, angles kept within one
 * turn, spheres within the poles and cones on one side of the apex. */
void crisp__step_choose_box(face_work *w, int outer)
{
    double *b = w->box;
    const loop_work *o = &w->loops[outer];
    for (int k = 0; k < 4; k++)
        b[k] = o->box[k];
    for (int i = 0; i < w->nloops; i++)
        for (int k = 0; k < 2; k++) {
            if (w->loops[i].box[2 * k] < b[2 * k]) b[2 * k] = w->loops[i].box[2 * k];
            if (w->loops[i].box[2 * k + 1] > b[2 * k + 1])
                b[2 * k + 1] = w->loops[i].box[2 * k + 1];
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

double crisp__step_winding(const face_work *w, const loop_work *lw, int k)
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

void crisp__step_file_uv(face_work *w, edge_use *eu, double s, double uv[2]);
crisp_status crisp__step_loop_samples(face_work *w, loop_work *lw);

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
                if ((x0 - tt) * (x1 - tt) <= 0 && x0 != x1)
                    e = m, s0 = (double)i / (eu->ns - 1), s1 = (double)(i + 1) / (eu->ns - 1),
                    tgt = tt;
            }
        }
    }
    if (e < 0)
        return crisp__step_fail(w->r, w->fe, CRISP_ERR_NUMERIC,
                                "cannot find where a crisp__step_winding loop crosses the seam");
    edge_use *eu = &lw->edges[e];
    double x0 = eu->uv[2 * (int)lround(s0 * (eu->ns - 1)) + k];
    for (int it = 0; it < 60; it++) {
        double sm = 0.5 * (s0 + s1), uv[2];
        crisp__step_file_uv(w, eu, sm, uv);
        if ((uv[k] - tgt) * (x0 - tgt) > 0)
            s0 = sm;
        else
            s1 = sm;
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
        for (int q = 0; q < eu->npc && !st; q++)
            st = curve_dup(&eu->pc[q], &e2.pc[q]);
        if (st) {
            crisp_free(ne);
            return st;
        }
        double t =
            eu->increasing ? eu->lo + sc * (eu->hi - eu->lo) : eu->hi - sc * (eu->hi - eu->lo);
        if (eu->increasing)
            e1.hi = t, e2.lo = t;
        else
            e1.lo = t, e2.hi = t;
        for (int q = 0; q < eu->npc; q++) {
            double pt = eu->increasing ? eu->pt0[q] + sc * (eu->pt1[q] - eu->pt0[q])
                                       : eu->pt1[q] - sc * (eu->pt1[q] - eu->pt0[q]);
            if (eu->increasing)
                e1.pt1[q] = pt, e2.pt0[q] = pt;
            else
                e1.pt0[q] = pt, e2.pt1[q] = pt;
        }
        crisp_free(eu->ts);
        crisp_free(eu->uv);
        ne[c++] = e2;
        for (int m = 1; m < n; m++)
            ne[c++] = lw->edges[(e + m) % n];
        ne[c++] = e1;
    } else {
        for (int m = 0; m < n; m++)
            ne[c++] = lw->edges[(first + m) % n];
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
    return crisp__step_loop_samples(w, lw);
}

/* 1 when x lies in [lo, hi] widened by m, modulo the period P. */
static int in_turn(double x, double lo, double hi, double m, double P)
{
    double d = fmod(x - (lo - m), P);
    if (d < 0) d += P;
    return d <= hi - lo + 2 * m;
}

/* Where the band's seam runs (coordinate k): at A's start unless that passes through one of the
 * face's other loops (a hole), else in the middle of the widest stretch of the turn that no hole
 * covers (trj5_k1-sh-203.stp #1446: a band on a cylinder whose end circle starts at the angle
 * where a hole straddles the band; the seam through the hole cut it in two, and half of it lay
 * beyond the band's turn). NAN: keep A's start (no hole in the way, or no free stretch). */
static double band_seam(const face_work *w, int a, int b, int k, double ua)
{
    double P = w->period[k], m = 1e-3 * P;
    int hit = 0;
    for (int i = 0; i < w->nloops; i++)
        if (i != a && i != b && w->loops[i].count &&
            in_turn(ua, w->loops[i].box[2 * k], w->loops[i].box[2 * k + 1], m, P))
            hit = 1;
    if (!hit) return NAN;
    /* The free stretches start where a hole ends and run to the nearest start of a hole. */
    double best = -1, at = NAN;
    for (int i = 0; i < w->nloops; i++) {
        if (i == a || i == b || !w->loops[i].count) continue;
        const double *bi = w->loops[i].box;
        if (bi[2 * k + 1] - bi[2 * k] >= P) return NAN;
        double g0 = bi[2 * k + 1], len = P;
        int inside = 0;
        for (int j = 0; j < w->nloops; j++) {
            if (j == a || j == b || !w->loops[j].count) continue;
            const double *bj = w->loops[j].box;
            if (j != i && in_turn(g0, bj[2 * k], bj[2 * k + 1], 0, P)) inside = 1;
            double d = fmod(bj[2 * k] - g0, P);
            if (d < 0) d += P;
            if (d < len) len = d;
        }
        if (!inside && len > best) best = len, at = g0 + 0.5 * len;
    }
    return best > 2 * m ? at : NAN;
}

/* Join crisp__step_winding loops a and b (coordinate k) as described above. */
crisp_status crisp__step_make_band(face_work *w, int a, int b, int k)
{
    loop_work *A = &w->loops[a], *B = &w->loops[b];
    crisp_status st;
    double seam = band_seam(w, a, b, k, A->edges[0].uv[k]);
    if (!isnan(seam) && (st = cut_loop(w, A, k, seam))) return st;
    double ua = A->edges[0].uv[k], da = crisp__step_winding(w, A, k) > 0 ? 1 : -1;
    st = cut_loop(w, B, k, ua);
    if (st) return st;
    double db = crisp__step_winding(w, B, k) > 0 ? 1 : -1;
    w->band_rev = da == db;
    /* B traversed (reversed when it runs like A) must start at A's end and end at A's start. */
    double want = w->band_rev ? ua : ua + da * w->period[k];
    double sh[2] = {0, 0};
    sh[k] = want - B->edges[0].uv[k];
    crisp__step_shift_loop(B, sh);
    w->band_a = a;
    w->band_b = b;
    return CRISP_OK;
}

/* File uv at loop fraction s by the chosen pcurve or by inversion near the sampled polyline. */
void crisp__step_file_uv(face_work *w, edge_use *eu, double s, double uv[2])
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
    double ref[2] = {eu->uv[2 * i] * (1 - f) + eu->uv[2 * i + 2] * f,
                     eu->uv[2 * i + 1] * (1 - f) + eu->uv[2 * i + 3] * f};
    double p[3];
    crisp__step_curve_eval(&eu->c3, crisp__step_curve_wrap(&eu->c3, t), p);
    crisp__step_surface_invert(&w->s, p, ref, uv);
}

crisp_status crisp__step_read_loops(face_work *w)
{
    step_reader *r = w->r;
    const step_entity *fe = w->fe;
    const step_part *fp = crisp__step_part(r, fe, NULL);
    const step_value *bounds;
    crisp_status st = crisp__step_get_list(r, fe, fp, 1, &bounds);
    if (st) return st;
    if (bounds->len > MAX_LOOPS)
        return crisp__step_fail(r, fe, CRISP_ERR_LIMIT, "more than %d bounds", MAX_LOOPS);
    w->loops = crisp_calloc_array(bounds->len ? bounds->len : 1, sizeof *w->loops);
    if (!w->loops) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
    for (uint32_t i = 0; i < bounds->len; i++) {
        const step_entity *be, *le;
        if ((st = crisp__step_deref(r, fe, crisp__step_elem(r, bounds, i), &be))) return st;
        const step_part *bp = crisp__step_part(r, be, "FACE_OUTER_BOUND");
        int outer = bp != NULL;
        if (!bp) bp = crisp__step_part(r, be, "FACE_BOUND");
        if (!bp)
            return crisp__step_fail(r, be, CRISP_ERR_PARSE,
                                    "expected a FACE_BOUND or FACE_OUTER_BOUND");
        if ((st = crisp__step_get_ref(r, be, bp, 1, &le))) return st;
        if (crisp__step_is(r, le, "VERTEX_LOOP")) {
            /* A bound of one vertex (apex, pole) adds no trim; it may close a crisp__step_winding
             * loop. */
            const step_entity *ve;
            if ((st = crisp__step_get_ref(r, le, crisp__step_part(r, le, "VERTEX_LOOP"), 1, &ve)))
                return st;
            if (w->ncap < 2 && (st = vertex_point(r, ve, w->cap_pt[w->ncap++]))) return st;
            continue;
        }
        const step_part *lp = crisp__step_part(r, le, "EDGE_LOOP");
        if (!lp) return crisp__step_fail(r, le, CRISP_ERR_UNSUPPORTED, "expected an EDGE_LOOP");
        const step_value *edges;
        if ((st = crisp__step_get_list(r, le, lp, 1, &edges))) return st;
        if (edges->len < 1 || edges->len > MAX_EDGES)
            return crisp__step_fail(r, le, CRISP_ERR_LIMIT, "expected 1 to %d edges, found %u",
                                    MAX_EDGES, edges->len);
        loop_work *lw = &w->loops[w->nloops++];
        lw->outer_flag = outer;
        int orient = 1;
        if (crisp__step_get_bool(r, be, bp, 2, &orient) != CRISP_OK) {
            crisp_error_clear();
            orient = 1;
        }
        lw->sense = !orient;
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
