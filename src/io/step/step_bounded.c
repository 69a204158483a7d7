/* STEP surfaces bounded by curves rather than by topology (ISO 10303-42 4.4: curve_bounded_surface,
 * boundary_curve, outer_boundary_curve, composite_curve_segment, pcurve, surface_curve; and bare
 * bounded surfaces in geometric sets: b_spline_surface, rectangular_trimmed_surface). These come
 * from AP203/AP214 "geometrically bounded surface" models (GEOMETRIC_SET in a
 * GEOMETRICALLY_BOUNDED_SURFACE_SHAPE_REPRESENTATION), which carry no edges or vertices.
 *
 * Each composite curve segment becomes one edge use of the face's loop, so that the rest of the
 * face conversion (step_face.c: seams, bands, fitting, projection, orientation) is shared:
 *  - a PCURVE on the basis surface, or a SURFACE_CURVE with one: the 2D curve over its bounded
 *    range (the 3D curve, when there is one, only counts samples);
 *  - a 3D curve without one (SURFACE_CURVE with .CURVE_3D., or a bounded curve): projected.
 */
#include "step_face.h"

#include <math.h>
#include <string.h>

#define MAX_BOUNDARIES 4096
#define MAX_SEGMENTS 65536

static crisp_status curve_copy(const step_curve *c, step_curve *d)
{
    *d = *c;
    d->nurbs = NULL;
    return c->nurbs ? crisp_curve_copy(c->nurbs, &d->nurbs) : CRISP_OK;
}

/* One COMPOSITE_CURVE_SEGMENT (transition, same_sense, parent_curve) as an edge use. */
static crisp_status segment_use(face_work *w, const step_entity *be, const step_entity *se,
                                edge_use *eu)
{
    step_reader *r = w->r;
    const step_part *p = crisp__step_part(r, se, "COMPOSITE_CURVE_SEGMENT");
    if (!p) p = crisp__step_part(r, se, "REPARAMETRISED_COMPOSITE_CURVE_SEGMENT");
    if (!p)
        return crisp__step_fail(r, be, CRISP_ERR_PARSE,
                                "segment #%d: expected a COMPOSITE_CURVE_SEGMENT", se->id);
    const step_entity *ce;
    int same;
    crisp_status st;
    if ((st = crisp__step_get_bool(r, se, p, 1, &same)) ||
        (st = crisp__step_get_ref(r, se, p, 2, &ce)))
        return st;
    eu->id = se->id;
    const step_part *pp = crisp__step_part(r, ce, "PCURVE");
    if (pp) {
        /* A pcurve alone: it is its own "3D" curve for the sampling counts. */
        const step_entity *basis;
        if ((st = crisp__step_get_ref(r, ce, pp, 1, &basis))) return st;
        if (basis->id != w->s.id)
            return crisp__step_fail(r, ce, CRISP_ERR_UNSUPPORTED,
                                    "pcurve on surface #%d, not on the bounded surface #%d",
                                    basis->id, w->s.id);
        if ((st = crisp__step_pcurve_curve(r, ce, &w->s, &eu->pc[0]))) return st;
        eu->npc = 1;
        if ((st = curve_copy(&eu->pc[0], &eu->c3))) return st;
    } else {
        if ((st = crisp__step_curve(r, ce, &eu->c3))) return st;
        if (eu->c3.dim != 3)
            return crisp__step_fail(r, ce, CRISP_ERR_PARSE, "expected a 3D curve or a pcurve");
        if (crisp__step_is(r, ce, "SURFACE_CURVE") || crisp__step_is(r, ce, "SEAM_CURVE") ||
            crisp__step_is(r, ce, "BOUNDED_SURFACE_CURVE"))
            if ((st = crisp__step_find_pcurves(r, ce, &w->s, eu))) return st;
        if (eu->npc > 1) { /* a seam: the first pcurve; continuity is not known here */
            crisp__step_curve_free(&eu->pc[1]);
            eu->npc = 1;
        }
    }
    const step_curve *c = eu->npc ? &eu->pc[0] : &eu->c3;
    if (!isfinite(c->t0) || !isfinite(c->t1) || !(c->t1 > c->t0))
        return crisp__step_fail(r, ce, CRISP_ERR_UNSUPPORTED,
                                "boundary segment on an unbounded curve (expected a "
                                "trimmed or B-spline curve)");
    eu->lo = eu->c3.t0;
    eu->hi = eu->c3.t1;
    if (!isfinite(eu->lo) || !isfinite(eu->hi)) eu->lo = c->t0, eu->hi = c->t1;
    eu->increasing = same ^ c->reversed;
    if (eu->npc) {
        eu->pt0[0] = c->t0;
        eu->pt1[0] = c->t1;
        /* A pcurve that does not follow its 3D curve is dropped: the 3D curve is projected. */
        if (eu->c3.dim == 3) {
            double a[2], b[2], pa[3], pb[3], qa[3], qb[3];
            crisp__step_curve_eval(c, c->t0, a);
            crisp__step_curve_eval(c, c->t1, b);
            crisp__step_surface_eval(&w->s, a[0], a[1], pa);
            crisp__step_surface_eval(&w->s, b[0], b[1], pb);
            crisp__step_curve_eval(&eu->c3, eu->c3.reversed == c->reversed ? eu->lo : eu->hi, qa);
            crisp__step_curve_eval(&eu->c3, eu->c3.reversed == c->reversed ? eu->hi : eu->lo, qb);
            if (crisp__step_dist3(pa, qa) > 10 * r->tol ||
                crisp__step_dist3(pb, qb) > 10 * r->tol) {
                crisp__step_curve_free(&eu->pc[0]);
                eu->npc = 0;
                eu->increasing = same ^ eu->c3.reversed;
                r->stats->rejected_pcurves++;
            }
        }
    }
    return CRISP_OK;
}

/* The 3D point where an edge use starts (end = 0) or ends (end = 1) along the loop. */
static void use_end(const face_work *w, const edge_use *eu, int end, double p[3])
{
    int at_hi = eu->increasing == end;
    if (eu->npc) {
        double uv[2];
        crisp__step_curve_eval(&eu->pc[0], at_hi ? eu->pt1[0] : eu->pt0[0], uv);
        crisp__step_surface_eval(&w->s, uv[0], uv[1], p);
    } else {
        crisp__step_curve_eval(&eu->c3, at_hi ? eu->hi : eu->lo, p);
    }
}

/* Composite curve segments are chained end to start. Some writers give segments the wrong
 * same_sense (bm2_pe_t4-B.stp, Pro/ENGINEER 1997, writes .F. on every segment of loops that only
 * chain with .T.). When the senses as given leave junctions open, the first segment is tried both
 * ways and each following one is turned to meet its predecessor; the senses that close most
 * junctions are kept (the given ones on a tie). */
static int chain_try(face_work *w, loop_work *lw, const int *given, int first, int *out)
{
    double tol = 10 * w->r->tol;
    int open = 0;
    out[0] = first;
    for (int k = 0; k < lw->count; k++) {
        lw->edges[k].increasing = k ? given[k] : first;
        if (k == 0) continue;
        double prev[3], a[3], b[3];
        use_end(w, &lw->edges[k - 1], 1, prev);
        use_end(w, &lw->edges[k], 0, a);
        use_end(w, &lw->edges[k], 1, b);
        if (crisp__step_dist3(prev, a) > tol) {
            if (crisp__step_dist3(prev, b) <= tol)
                lw->edges[k].increasing ^= 1;
            else
                open++;
        }
        out[k] = lw->edges[k].increasing;
    }
    double last[3], start[3];
    use_end(w, &lw->edges[lw->count - 1], 1, last);
    use_end(w, &lw->edges[0], 0, start);
    return open + (crisp__step_dist3(last, start) > tol);
}

static crisp_status chain_segments(face_work *w, loop_work *lw)
{
    int n = lw->count;
    int *given = crisp_malloc_array((size_t)n * 3, sizeof *given);
    if (!given) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", w->r->f->name);
    int *as_given = given + n, *turned = given + 2 * n;
    for (int k = 0; k < n; k++)
        given[k] = lw->edges[k].increasing;
    int open_given = chain_try(w, lw, given, given[0], as_given);
    int open_turned = open_given ? chain_try(w, lw, given, !given[0], turned) : 1 << 30;
    const int *best = open_turned < open_given ? turned : as_given;
    for (int k = 0; k < n; k++) {
        w->r->stats->flipped_segments += best[k] != given[k];
        lw->edges[k].increasing = best[k];
    }
    crisp_free(given);
    return CRISP_OK;
}

crisp_status crisp__step_read_boundaries(face_work *w)
{
    step_reader *r = w->r;
    const step_entity *fe = w->fe;
    const step_part *fp = crisp__step_part(r, fe, "CURVE_BOUNDED_SURFACE");
    const step_value *bounds;
    int implicit_outer;
    crisp_status st;
    if ((st = crisp__step_get_list(r, fe, fp, 2, &bounds)) ||
        (st = crisp__step_get_bool(r, fe, fp, 3, &implicit_outer)))
        return st;
    if (implicit_outer)
        return crisp__step_fail(r, fe, CRISP_ERR_UNSUPPORTED,
                                "implicit outer boundary (the basis surface's own "
                                "boundary) is not supported");
    if (bounds->len > MAX_BOUNDARIES)
        return crisp__step_fail(r, fe, CRISP_ERR_LIMIT, "more than %d boundaries", MAX_BOUNDARIES);
    w->loops = crisp_calloc_array(bounds->len ? bounds->len : 1, sizeof *w->loops);
    if (!w->loops) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
    for (uint32_t i = 0; i < bounds->len; i++) {
        const step_entity *be;
        const step_value *segs;
        if ((st = crisp__step_deref(r, fe, crisp__step_elem(r, bounds, i), &be))) return st;
        const step_part *bp = crisp__step_part(r, be, "OUTER_BOUNDARY_CURVE");
        int outer = bp != NULL;
        if (!bp) bp = crisp__step_part(r, be, "BOUNDARY_CURVE");
        if (!bp) bp = crisp__step_part(r, be, "COMPOSITE_CURVE_ON_SURFACE");
        if (!bp) bp = crisp__step_part(r, be, "COMPOSITE_CURVE");
        if (!bp)
            return crisp__step_fail(r, be, CRISP_ERR_PARSE,
                                    "expected a BOUNDARY_CURVE or OUTER_BOUNDARY_CURVE");
        /* In a complex instance the segments are the first parameter of COMPOSITE_CURVE. */
        int idx = be->part_count > 1 ? 0 : 1;
        const step_part *cp = be->part_count > 1 ? crisp__step_part(r, be, "COMPOSITE_CURVE") : bp;
        if (!cp || (st = crisp__step_get_list(r, be, cp, idx, &segs)))
            return cp ? st
                      : crisp__step_fail(r, be, CRISP_ERR_PARSE,
                                         "expected COMPOSITE_CURVE segments");
        if (segs->len < 1 || segs->len > MAX_SEGMENTS)
            return crisp__step_fail(r, be, CRISP_ERR_LIMIT, "expected 1 to %d segments, found %u",
                                    MAX_SEGMENTS, segs->len);
        loop_work *lw = &w->loops[w->nloops++];
        lw->outer_flag = outer;
        lw->edges = crisp_calloc_array(segs->len, sizeof *lw->edges);
        if (!lw->edges) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
        for (uint32_t k = 0; k < segs->len; k++) {
            const step_entity *se;
            if ((st = crisp__step_deref(r, be, crisp__step_elem(r, segs, k), &se))) return st;
            lw->count++;
            if ((st = segment_use(w, be, se, &lw->edges[k]))) return st;
        }
        if ((st = chain_segments(w, lw))) return st;
    }
    return CRISP_OK;
}

crisp_status crisp__step_bounded_face(step_reader *r, const step_entity *e, crisp_face *dest)
{
    memset(dest, 0, sizeof *dest);
    const step_part *p = crisp__step_part(r, e, "CURVE_BOUNDED_SURFACE");
    const step_entity *se;
    face_work w;
    crisp_status st = crisp__step_get_ref(r, e, p, 1, &se);
    if (st) return st;
    if (!(st = crisp__step_work_init(&w, r, e, se)) && !(st = crisp__step_read_boundaries(&w)))
        st = crisp__step_face_finish(&w, 1, dest);
    crisp__step_work_free(&w);
    return st;
}

/* A bare surface in a geometric set: a B-spline surface is the whole of its domain; a
 * RECTANGULAR_TRIMMED_SURFACE(name, basis, u1, u2, v1, v2, usense, vsense) is its basis over the
 * box; an elementary surface alone is unbounded and has nothing to draw. */
crisp_status crisp__step_bare_face(step_reader *r, const step_entity *e, crisp_face *dest)
{
    memset(dest, 0, sizeof *dest);
    step_surface s;
    crisp_status st = crisp__step_surface(r, e, &s);
    if (st) return st;
    const step_part *tp = crisp__step_part(r, e, "RECTANGULAR_TRIMMED_SURFACE");
    double box[4], nbox[4];
    int usense = 1, vsense = 1;
    for (int k = 0; tp && k < 4 && !st; k++)
        st = crisp__step_get_real(r, e, tp, 2 + k, &box[k]);
    if (!st && tp && (st = crisp__step_get_bool(r, e, tp, 6, &usense)) == CRISP_OK)
        st = crisp__step_get_bool(r, e, tp, 7, &vsense);
    if (st) goto fail;
    if (!tp && s.kind != STEP_SURF_BSPLINE) {
        st = crisp__step_fail(r, e, CRISP_ERR_UNSUPPORTED,
                              "unbounded surface outside a face (nothing to draw)");
        goto fail;
    }
    if (tp) {
        int per[2] = {s.u_periodic, s.v_periodic};
        if (s.kind == STEP_SURF_SPHERE) per[1] = 1; /* latitude: an angle, not periodic */
        if (s.kind == STEP_SURF_EXTRUSION && s.profile.kind != STEP_CURVE_CONIC) per[0] = 0;
        for (int k = 0; k < 2; k++) {
            if (per[k]) box[2 * k] *= r->angle_unit, box[2 * k + 1] *= r->angle_unit;
            if (box[2 * k + 1] < box[2 * k]) {
                double t = box[2 * k];
                box[2 * k] = box[2 * k + 1], box[2 * k + 1] = t;
            }
            if (!(box[2 * k + 1] > box[2 * k]) || !isfinite(box[2 * k]) ||
                !isfinite(box[2 * k + 1])) {
                st = crisp__step_fail(r, e, CRISP_ERR_NUMERIC, "empty or invalid parameter box");
                goto fail;
            }
        }
    }
    if ((st = crisp__step_surface_build(r, &s, tp ? box : (const double[4]){0, 0, 0, 0},
                                        &dest->surface, nbox)))
        goto fail;
    if (tp && s.kind == STEP_SURF_BSPLINE) {
        /* The box within the B-spline's domain, as one rectangular loop when it is smaller. */
        double b[4] = {fmax(box[0], nbox[0]), fmin(box[1], nbox[1]), fmax(box[2], nbox[2]),
                       fmin(box[3], nbox[3])};
        double eps = 1e-12 * (nbox[1] - nbox[0] + nbox[3] - nbox[2]);
        if (!(b[1] > b[0]) || !(b[3] > b[2])) {
            st = crisp__step_fail(r, e, CRISP_ERR_NUMERIC,
                                  "parameter box outside the basis surface's domain");
            goto fail;
        }
        if (b[0] > nbox[0] + eps || b[1] < nbox[1] - eps || b[2] > nbox[2] + eps ||
            b[3] < nbox[3] - eps) {
            dest->loops = crisp_calloc_array(1, sizeof *dest->loops);
            crisp_trim_loop *lp = dest->loops;
            if (!lp || !(lp->curves = crisp_calloc_array(4, sizeof *lp->curves))) {
                st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
                goto fail;
            }
            dest->loop_count = 1;
            lp->is_outer = 1;
            double c[5][2] = {{b[0], b[2]}, {b[1], b[2]}, {b[1], b[3]}, {b[0], b[3]}, {b[0], b[2]}};
            for (int k = 0; k < 4; k++) {
                if ((st = crisp_make_line(2, c[k], c[k + 1], 0, 1, &lp->curves[k]))) goto fail;
                lp->curve_count++;
            }
        }
    }
    dest->source_id = e->id;
    dest->reversed = (!usense) ^ (!vsense) ^ crisp__step_surface_swaps(&s);
    crisp__step_surface_free(&s);
    return CRISP_OK;
fail:
    crisp__step_surface_free(&s);
    crisp_face_free(dest);
    memset(dest, 0, sizeof *dest);
    return st;
}
