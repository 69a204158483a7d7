/* STEP faces to crisp faces (ISO 10303-42 5.4 advanced_face): the face's surface as a NURBS
 * (elementary surfaces over the (u, v) box of the loops, with a margin) and one trim curve per edge
 * use, in loop order (the loops themselves come from step_edge.c):
 *  - from the edge's PCURVE on this face's surface when there is one, mapped from the file's
 *    (u, v) onto the NURBS (u, v): unchanged when the map is affine, exactly for iso-parametric
 *    lines, else fitted (crisp_fit_curve) within the tolerance;
 *  - else projected from the 3D edge: exactly on planes (an affine map of the control points),
 *    analytic inversion then fitting on the other elementary surfaces, crisp_surface_project_curve
 *    on B-spline surfaces.
 * Junctions of consecutive trims are snapped together within the tolerance; gaps the surface
 * collapses (poles, apexes, degenerate patch sides) get a segment along the collapsed boundary;
 * bands and capped loops get their seam segments; crisp_face_normalize_loops then orients the
 * loops and checks closure.
 */
#include "step_face.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---- trim curves in NURBS (u, v) ---------------------------------------------------------------
 */

typedef struct fit_ctx {
    face_work *w;
    edge_use *eu;
} fit_ctx;

static void fit_fn(void *ctx, double s, double *dest)
{
    fit_ctx *fc = ctx;
    double uv[2];
    crisp__step_file_uv(fc->w, fc->eu, s, uv);
    crisp__step_surface_map(&fc->w->s, fc->w->box, uv, dest);
}

/* Append c to out (taking ownership). */
static crisp_status push_curve(face_work *w, crisp_curve *c, crisp_curve ***out, int *n,
                               size_t *cap)
{
    if ((size_t)*n == *cap &&
        crisp_grow((void **)out, cap, (size_t)*n + 1, sizeof **out) != CRISP_OK) {
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
static double verify_edge(face_work *w, const crisp_surface *s, const edge_use *eu,
                          crisp_curve **curves, int first, int n)
{
    const step_curve *c = &eu->c3;
    double worst = 0;
    if (c->dim != 3) return 0; /* a boundary segment given only as a pcurve */
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
            double gap = crisp__step_dist3(q, sq);
            double d = crisp__step_dist3(p, sq);
            if (d > worst) worst = d;
            if (!w->r->stats->verify) continue;
            if (gap > w->r->stats->max_edge_gap) w->r->stats->max_edge_gap = gap;
            if (d > w->r->stats->max_edge_dev) w->r->stats->max_edge_dev = d;
        }
    }
    return worst;
}

static crisp_status edge_trims_any(face_work *w, edge_use *eu, crisp_curve ***out, int *n,
                                   size_t *cap);

/* An edge whose (u, v) image jumps: it passes through a pole or apex, where u is undefined and
 * changes by up to pi at once (trj4_k1_geo-tu-214.stp: an arc over a sphere's pole), or along a
 * collapsed side of a B-spline patch. No single curve fits it. The jumps are found on a dense
 * sample and located by bisection; each piece between them is fitted on its own, and the gaps,
 * which the surface collapses to a point, are bridged later (bridge_degenerate). */
#define JUMP_SAMPLES 1024
#define MAX_JUMPS 8

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static crisp_status fit_in_pieces(face_work *w, edge_use *eu, crisp_curve ***out, int *n,
                                  size_t *cap)
{
    fit_ctx fc = {w, eu};
    double prev[2], cur[2], steps[JUMP_SAMPLES], cuts[MAX_JUMPS + 2], cut_lo[MAX_JUMPS + 2],
        cut_hi[MAX_JUMPS + 2];
    int ncut = 0;
    fit_fn(&fc, 0, prev);
    for (int i = 1; i <= JUMP_SAMPLES; i++) {
        fit_fn(&fc, (double)i / JUMP_SAMPLES, cur);
        steps[i - 1] = hypot(cur[0] - prev[0], cur[1] - prev[1]);
        prev[0] = cur[0], prev[1] = cur[1];
    }
    /* A jump: a step far above the typical (median-like) step of the edge. */
    double sorted[JUMP_SAMPLES];
    memcpy(sorted, steps, sizeof sorted);
    qsort(sorted, JUMP_SAMPLES, sizeof *sorted, cmp_double);
    double typical = sorted[JUMP_SAMPLES / 2], limit = fmax(50 * typical, 100 * w->tol_uv);
    cut_lo[ncut] = cut_hi[ncut] = 0;
    cuts[ncut++] = 0;
    for (int i = 0; i < JUMP_SAMPLES; i++) {
        if (!(steps[i] > limit)) continue;
        if (ncut > MAX_JUMPS)
            return crisp_error(CRISP_ERR_NUMERIC,
                               "%s: #%d: edge #%d jumps in (u, v) more than %d times",
                               w->r->f->name, w->fe->id, eu->id, MAX_JUMPS);
        double a = (double)i / JUMP_SAMPLES, b = (double)(i + 1) / JUMP_SAMPLES, pa[2], pm[2],
               pb[2];
        fit_fn(&fc, a, pa);
        fit_fn(&fc, b, pb);
        for (int it = 0; it < 60; it++) {
            /* Once both ends are one point on the surface (within the tolerance), the (u, v)
             * between them is a turn about a pole the edge passes within the tolerance
             * (trj3_s1-md-214.stp: great circles 1e-10 off a sphere's poles): a jump there. */
            double fa[2], fb[2], qa[3], qb[3];
            crisp__step_file_uv(w, eu, a, fa);
            crisp__step_file_uv(w, eu, b, fb);
            crisp__step_surface_eval(&w->s, fa[0], fa[1], qa);
            crisp__step_surface_eval(&w->s, fb[0], fb[1], qb);
            if (crisp__step_dist3(qa, qb) <= 0.5 * w->r->tol) break;
            double m = 0.5 * (a + b);
            fit_fn(&fc, m, pm);
            if (hypot(pm[0] - pa[0], pm[1] - pa[1]) < hypot(pb[0] - pm[0], pb[1] - pm[1]))
                a = m, pa[0] = pm[0], pa[1] = pm[1];
            else
                b = m, pb[0] = pm[0], pb[1] = pm[1];
        }
        /* A true jump stays a jump however small the bracket; a fast but continuous turn (an
         * edge passing near a pole, trj6_b1-ec-214.stp) shrinks away: not cut, unless it lies
         * within the tolerance of the pole (above). */
        if (!(hypot(pb[0] - pa[0], pb[1] - pa[1]) > 0.5 * limit)) continue;
        /* the pieces end at the bracket's ends: between them the (u, v) only turns */
        cut_lo[ncut] = a, cut_hi[ncut] = b;
        cuts[ncut++] = 0.5 * (a + b);
    }
    cut_lo[ncut] = cut_hi[ncut] = 1;
    cuts[ncut++] = 1;
    if (ncut == 2)
        return crisp_error(CRISP_ERR_NUMERIC, "%s: #%d: edge #%d: no fit within the tolerance",
                           w->r->f->name, w->fe->id, eu->id);
    for (int k = 0; k + 1 < ncut; k++) {
        double a = cut_hi[k], b = cut_lo[k + 1], eps = 1e-9;
        if (k > 0 && !(cut_hi[k] > cuts[k])) a += eps;
        if (k + 2 < ncut && !(cut_lo[k + 1] < cuts[k + 1])) b -= eps;
        if (!(b > a)) continue;
        crisp_curve *c;
        crisp_status st = crisp_fit_curve(2, fit_fn, &fc, a, b, w->tol_uv, 1024, &c);
        if (!st) st = push_curve(w, c, out, n, cap);
        if (st) return st;
    }
    return CRISP_OK;
}

/* Forget the edge's pcurves: its file-uv samples become the inversions of its 3D points (near
 * the pcurve's, which keeps the turn of periodic coordinates). */
static void reproject_samples(face_work *w, edge_use *eu)
{
    eu->npc = 0;
    eu->shift[0] = eu->shift[1] = 0;
    if (w->s.kind == STEP_SURF_BSPLINE) return; /* projected from the 3D curve directly */
    for (int i = 0; i < eu->ns; i++) {
        double p[3], ref[2] = {eu->uv[2 * i], eu->uv[2 * i + 1]};
        crisp__step_curve_eval(&eu->c3, crisp__step_curve_wrap(&eu->c3, eu->ts[i]), p);
        crisp__step_surface_invert(&w->s, p, ref, eu->uv + 2 * i);
    }
}

static crisp_status edge_trims(face_work *w, const crisp_surface *s, edge_use *eu,
                               crisp_curve ***out, int *n, size_t *cap)
{
    int first = *n;
    w->repaired = 0;
    crisp_status st = edge_trims_any(w, eu, out, n, cap);
    /* Trims that needed a repair (fitted piecewise, projected at a looser tolerance), and all
     * trims on elementary surfaces (where the check is cheap: analytic inversion), are checked
     * against their edge: a face is better dropped with a note than drawn wrong (real files have
     * pcurves and senses that disagree with their edges in ways the reader cannot untangle). */
    int check = w->repaired || w->s.kind != STEP_SURF_BSPLINE;
    if (!st && (w->r->stats->verify || check)) {
        double dev = verify_edge(w, s, eu, *out, first, *n);
        if (check && dev > 20 * w->r->tol && eu->npc) {
            /* The file's pcurve lies off its edge (screw.step: 3 to 10 units on a torus; real
             * files have pcurves off by several mm): the trim is projected from the 3D edge
             * instead, as if there were no pcurve, and checked again. */
            double pdev = dev;
            for (int k = first; k < *n; k++)
                crisp_curve_destroy((*out)[k]);
            *n = first;
            reproject_samples(w, eu);
            w->repaired = 1;
            st = edge_trims_any(w, eu, out, n, cap);
            if (!st) dev = verify_edge(w, s, eu, *out, first, *n);
            if (!st && dev <= 20 * w->r->tol)
                crisp_model_note_skipf(
                    w->r->model,
                    "STEP face #%d: the pcurve of edge #%d lies %.3g from its edge "
                    "(tolerance %.3g): trim projected from the 3D edge instead",
                    w->fe->id, eu->id, pdev, w->r->tol);
        }
        if (!st && check && dev > 20 * w->r->tol)
            st = crisp_error(
                CRISP_ERR_NUMERIC,
                "%s: #%d: the trim of edge #%d lies %.3g from the edge (tolerance %.3g)",
                w->r->f->name, w->fe->id, eu->id, dev, w->r->tol);
    }
    return st;
}

static crisp_status edge_trims_any(face_work *w, edge_use *eu, crisp_curve ***out, int *n,
                                   size_t *cap)
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
            if ((st = crisp__step_curve_nurbs(pc, eu->pt0[eu->chosen], eu->pt1[eu->chosen], &c)))
                return st;
            affine2(c, eu->shift, crisp__step_surface_swaps(s));
            if (!eu->increasing) crisp_curve_reverse(c);
            return push_curve(w, c, out, n, cap);
        }
        if (pc->kind == STEP_CURVE_LINE && (fabs(pc->d[0]) <= 1e-12 * fabs(pc->d[1]) ||
                                            fabs(pc->d[1]) <= 1e-12 * fabs(pc->d[0]))) {
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
            if (!pts || !wts)
                st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
            for (int i = 0; !st && i < c3->count; i++) {
                const double *q = c3->cpw + 4 * i;
                double x[3] = {q[0] / q[3] - s->pl.origin[0], q[1] / q[3] - s->pl.origin[1],
                               q[2] / q[3] - s->pl.origin[2]};
                pts[2 * i] = x[0] * s->pl.x[0] + x[1] * s->pl.x[1] + x[2] * s->pl.x[2];
                pts[2 * i + 1] = x[0] * s->pl.y[0] + x[1] * s->pl.y[1] + x[2] * s->pl.y[2];
                wts[i] = q[3];
            }
            if (!st)
                st = crisp_curve_create(2, c3->degree, c3->count, c3->knots, pts,
                                        c3->rational ? wts : NULL, &tmp[k]);
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
        enum { MAXP = 9 };
        crisp_curve *tmp[2][MAXP] = {{NULL}};
        int ntmp[2] = {0, 0};
        for (int k = 0; k < pieces; k++) {
            double a = k ? eu->c3.t0 : cut[0], b = k ? eu->hi - eu->c3.period : cut[1];
            crisp_curve *c3 = NULL;
            if ((st = crisp__step_curve_nurbs(&eu->c3, a, b, &c3))) goto fail_bs;
            double d0, d1;
            crisp_curve_domain(c3, &d0, &d1);
            /* The projection's fit can stall on a span where point inversion is ill-conditioned
             * (trj8_b1-ec-214.stp); a tighter tolerance changes the spans and often gets past. */
            st = crisp_surface_project_curve(s->nurbs, c3, d0, d1, r->tol, &tmp[k][0]);
            for (double f = 0.25; st == CRISP_ERR_LIMIT && f > 0.01; f *= 0.25) {
                crisp_error_clear();
                w->repaired = 1;
                st = crisp_surface_project_curve(s->nurbs, c3, d0, d1, f * r->tol, &tmp[k][0]);
            }
            /* Last, a looser one (up to 16 times): a face whose trim is off by 1.6e-4 of the
             * model is better than no face. It is counted and noted. */
            for (double f = 4; st == CRISP_ERR_LIMIT && f < 20; f *= 4) {
                crisp_error_clear();
                st = crisp_surface_project_curve(s->nurbs, c3, d0, d1, f * r->tol, &tmp[k][0]);
                if (!st) {
                    w->repaired = 1;
                    r->stats->loose_projections++;
                    crisp_model_note_skip(
                        r->model,
                        "STEP edge trim projected within 4-16x the tolerance (tighter failed)");
                }
            }
            if (!st) ntmp[k] = 1;
            /* The projection jumps (the edge passes a collapsed side or a pole of the patch,
             * pr1db.stp): cut at the jumps, each piece projected on its own; the gaps lie where the
             * surface collapses and are bridged there (bridge_degenerate), or the closure check
             * refuses them. */
            if (st == CRISP_ERR_LIMIT) {
                crisp_error_clear();
                w->repaired = 1;
                st = crisp_surface_project_curve_pieces(s->nurbs, c3, d0, d1, r->tol, MAXP, tmp[k],
                                                        &ntmp[k]);
            }
            crisp_curve_destroy(c3);
            if (st) {
                crisp_error_prefix("%s: #%d: projecting edge #%d onto surface #%d", r->f->name,
                                   w->fe->id, eu->id, s->id);
                goto fail_bs;
            }
            if (!eu->increasing) {
                for (int q = 0; q < ntmp[k]; q++)
                    crisp_curve_reverse(tmp[k][q]);
                for (int q = 0; q < ntmp[k] / 2; q++) {
                    crisp_curve *x = tmp[k][q];
                    tmp[k][q] = tmp[k][ntmp[k] - 1 - q];
                    tmp[k][ntmp[k] - 1 - q] = x;
                }
            }
        }
        for (int k = 0; k < pieces; k++) {
            int idx = eu->increasing ? k : pieces - 1 - k;
            for (int q = 0; q < ntmp[idx]; q++) {
                st = push_curve(w, tmp[idx][q], out, n, cap);
                tmp[idx][q] = NULL;
                if (st) goto fail_bs;
            }
        }
        return CRISP_OK;
    fail_bs:
        for (int k = 0; k < 2; k++)
            for (int q = 0; q < MAXP; q++)
                crisp_curve_destroy(tmp[k][q]);
        return st;
    }
    fit_ctx fc = {w, eu};
    st = crisp_fit_curve(2, fit_fn, &fc, 0, 1, w->tol_uv, 1024, &c);
    if (st == CRISP_ERR_LIMIT) {
        crisp_error_clear();
        w->repaired = 1;
        if ((st = fit_in_pieces(w, eu, out, n, cap)) == CRISP_OK) return CRISP_OK;
    }
    if (st) {
        crisp_error_prefix("%s: #%d: fitting the trim of edge #%d on surface #%d", r->f->name,
                           w->fe->id, eu->id, s->id);
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
            crisp_surface_derivs(s, d[0] + (d[1] - d[0]) * i / 8, d[2] + (d[3] - d[2]) * j / 8,
                                 NULL, su, sv, NULL, NULL, NULL);
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

/* On a B-spline surface that closes on itself in u (or v), a trim projected from a seam edge can
 * land on either side of the domain, u0 or u1: both are the same points. A seam edge used twice in
 * one loop needs one use on each side (trj2_io1-id-203.stp: a closed cylinder bounded by two
 * circles and a seam line). Each trim lying wholly on one side moves to the other when that closes
 * the loop better. */
static int side_closed(const crisp_surface *s, const double d[4], int k, double tol)
{
    for (int i = 0; i <= 8; i++) {
        double t = d[2 * (1 - k)] + (d[2 * (1 - k) + 1] - d[2 * (1 - k)]) * i / 8, a[3], b[3];
        if (k == 0)
            crisp_surface_eval(s, d[0], t, a), crisp_surface_eval(s, d[1], t, b);
        else
            crisp_surface_eval(s, t, d[2], a), crisp_surface_eval(s, t, d[3], b);
        if (crisp__step_dist3(a, b) > tol) return 0;
    }
    return 1;
}

/* Whether the surface maps the straight (u, v) segment pa-pb to one point (within tol): a gap
 * there lies along a pole, an apex or a collapsed side, and is bridged (bridge_degenerate). */
static int collapsed_segment(const crisp_surface *s, const double pa[2], const double pb[2],
                             double tol)
{
    double p0[3], q[3];
    crisp_surface_eval(s, pa[0], pa[1], p0);
    for (int k = 1; k <= 16; k++) {
        double x = k / 16.0;
        crisp_surface_eval(s, pa[0] + x * (pb[0] - pa[0]), pa[1] + x * (pb[1] - pa[1]), q);
        if (!(crisp__step_dist3(p0, q) <= tol)) return 0;
    }
    return 1;
}

/* The (u, v) gaps at both ends of trim i, a gap along a collapsed line counting as none. */
static double junction_gaps(const crisp_surface *s, const crisp_trim_loop *lp, int i, double tol)
{
    int n = lp->curve_count;
    double a[2], b[2], c[2], d[2];
    curve_end(lp->curves[(i + n - 1) % n], 1, a);
    curve_end(lp->curves[i], 0, b);
    curve_end(lp->curves[i], 1, c);
    curve_end(lp->curves[(i + 1) % n], 0, d);
    double g0 = hypot(a[0] - b[0], a[1] - b[1]), g1 = hypot(c[0] - d[0], c[1] - d[1]);
    if (g0 > 0 && collapsed_segment(s, a, b, tol)) g0 = 0;
    if (g1 > 0 && collapsed_segment(s, c, d, tol)) g1 = 0;
    return g0 + g1;
}

/* (A seam used twice on a surface of revolution that closes at an apex, trj3_s1-id-203.stp: both
 * uses projected onto u0; moving one to u1 leaves its other end's gap along the apex, which
 * counts as closed.) */
static void seam_sides(const crisp_surface *s, const double d[4], crisp_trim_loop *lp, double tol,
                       double snap)
{
    if (lp->curve_count < 2) return;
    for (int k = 0; k < 2; k++) {
        if (!side_closed(s, d, k, tol)) continue;
        double lo = d[2 * k], hi = d[2 * k + 1];
        for (int i = 0; i < lp->curve_count; i++) {
            crisp_curve *c = lp->curves[i];
            int at_lo = 1, at_hi = 1;
            for (int j = 0; j < c->count; j++) {
                double x = c->cpw[3 * j + k] / c->cpw[3 * j + 2];
                at_lo &= fabs(x - lo) <= snap;
                at_hi &= fabs(x - hi) <= snap;
            }
            if (at_lo == at_hi) continue;
            double before = junction_gaps(s, lp, i, tol), shift = at_lo ? hi - lo : lo - hi;
            for (int j = 0; j < c->count; j++)
                c->cpw[3 * j + k] += shift * c->cpw[3 * j + 2];
            if (junction_gaps(s, lp, i, tol) >= before)
                for (int j = 0; j < c->count; j++)
                    c->cpw[3 * j + k] -= shift * c->cpw[3 * j + 2];
        }
    }
}

/* On a B-spline surface closed in u (or v), a trim projected continuously across the seam leaves
 * the domain by up to a period (the projection keeps its path continuous); clamping it would
 * squash it onto the seam. It is cut where it crosses the seam and the part beyond is moved back
 * by the period (trj3_s1-md-214.stp #934: a band on a revolved B-spline bounded by two circles,
 * one of them projected from v = 0.5 down to -0.5). A loop that winds around the surface then
 * jumps across the seam once inside; it is turned to start after the jump, so that it winds
 * from end to start as join_bspline_band expects. Returns -1 when out of memory. */
#define SEAM_SAMPLES 64

static double curve_coord(const crisp_curve *c, double t, int k)
{
    double p[2];
    crisp_curve_eval(c, t, p);
    return p[k];
}

static void shift_curve(crisp_curve *c, const double sh[2]);

/* Whether a trim's image is one point (within tol): it runs along a pole or a collapsed side,
 * where its (u, v) mean nothing (ec_turbine-A.stp: short edges at a collapsed side projected
 * over a fourth of the v range). Coordinates beyond the domain are wrapped by its widths. */
static int image_collapsed(const crisp_surface *s, const double d[4], const crisp_curve *c,
                           double tol)
{
    double t0, t1, first[3];
    crisp_curve_domain(c, &t0, &t1);
    for (int j = 0; j <= 16; j++) {
        double uv[2], p[3];
        crisp_curve_eval(c, t0 + (t1 - t0) * j / 16, uv);
        for (int k = 0; k < 2; k++) {
            double w = d[2 * k + 1] - d[2 * k];
            if (w > 0 && (uv[k] < d[2 * k] || uv[k] > d[2 * k + 1]))
                uv[k] -= w * floor((uv[k] - d[2 * k]) / w);
        }
        crisp_surface_eval(s, uv[0], uv[1], p);
        if (j == 0)
            memcpy(first, p, sizeof first);
        else if (crisp__step_dist3(first, p) > tol)
            return 0;
    }
    return 1;
}

static int split_at_seams(const crisp_surface *s, const double d[4], crisp_trim_loop *lp,
                          double tol, double snap)
{
    for (int k = 0; k < 2; k++) {
        if (!side_closed(s, d, k, tol)) continue;
        double lo = d[2 * k], hi = d[2 * k + 1], per = hi - lo;
        for (int i = 0; i < lp->curve_count && lp->curve_count < 4096; i++) {
            crisp_curve *c = lp->curves[i];
            double t0, t1, cross = NAN, seam = 0;
            crisp_curve_domain(c, &t0, &t1);
            if (image_collapsed(s, d, c, tol)) continue; /* along a pole or collapsed side */
            /* (A trim over more than a turn runs along a near-collapsed side, where its (u, v)
             * wander: ec_turbine-A.stp, -23 to 94 on a turn of 93. Left to the clamp.) */
            double cb[4];
            crisp_curve_bbox(c, cb);
            if (cb[2 + k] - cb[k] > per + snap) continue;
            double prev = curve_coord(c, t0, k), tp = t0;
            for (int j = 1; j <= SEAM_SAMPLES && isnan(cross); j++) {
                double t = t0 + (t1 - t0) * j / SEAM_SAMPLES, x = curve_coord(c, t, k);
                for (int e = 0; e < 2 && isnan(cross); e++) {
                    double sv = e ? hi : lo;
                    if ((prev - sv) * (x - sv) < 0) cross = tp, seam = sv;
                }
                if (isnan(cross)) prev = x, tp = t;
            }
            /* (A trim wholly beyond a side is left to the clamp, as before: it starts on the
             * seam and runs out along a near-collapsed side in ec_turbine-A.stp.) */
            if (isnan(cross)) continue;
            /* the crossing is in [cross, cross + step]: bisect it */
            double a = cross, b = fmin(t1, cross + (t1 - t0) / SEAM_SAMPLES);
            double fa = curve_coord(c, a, k) - seam;
            for (int it = 0; it < 80; it++) {
                double m = 0.5 * (a + b), fm = curve_coord(c, m, k) - seam;
                if ((fa < 0) == (fm < 0))
                    a = m, fa = fm;
                else
                    b = m;
            }
            double tc = 0.5 * (a + b);
            /* Only a real crossing is cut: both pieces reach farther than the snap from the
             * seam (a trim running along the seam may graze it; one starting on the seam and
             * running out, ec_turbine-A.stp, is left to the clamp). */
            double ex0 = 0, ex1 = 0, rc0 = 0, rc1 = 0;
            for (int j = 0; j <= SEAM_SAMPLES; j++) {
                double t = t0 + (t1 - t0) * j / SEAM_SAMPLES, x = curve_coord(c, t, k);
                double o = fmax(x - hi, lo - x);
                if (t < tc) ex0 = fmax(ex0, o), rc0 = fmax(rc0, fabs(x - seam));
                if (t > tc) ex1 = fmax(ex1, o), rc1 = fmax(rc1, fabs(x - seam));
            }
            if (!(fmax(ex0, ex1) > snap) || !(fmin(rc0, rc1) > snap) || !(tc > t0) || !(tc < t1))
                continue;
            crisp_curve *p0 = NULL, *p1 = NULL;
            if (crisp_curve_trim(c, t0, tc, &p0) || crisp_curve_trim(c, tc, t1, &p1)) {
                crisp_curve_destroy(p0);
                crisp_error_clear();
                continue;
            }
            crisp_curve **nc =
                crisp_realloc_array(lp->curves, (size_t)lp->curve_count + 1, sizeof *nc);
            if (!nc) {
                crisp_curve_destroy(p0);
                crisp_curve_destroy(p1);
                return -1;
            }
            lp->curves = nc;
            double sh[2] = {0, 0};
            sh[k] = seam == hi ? -per : per;
            shift_curve(ex0 > ex1 ? p0 : p1, sh);
            /* the cut point lies exactly on the seam of both pieces */
            double e0[2], e1[2];
            curve_end(p0, 1, e0);
            curve_end(p1, 0, e1);
            e0[k] = ex0 > ex1 ? seam + sh[k] : seam;
            e1[k] = ex0 > ex1 ? seam : seam + sh[k];
            set_end(p0, 1, e0);
            set_end(p1, 0, e1);
            crisp_curve_destroy(c);
            memmove(nc + i + 2, nc + i + 1, (size_t)(lp->curve_count - i - 1) * sizeof *nc);
            nc[i] = p0;
            nc[i + 1] = p1;
            lp->curve_count++;
            i--; /* the pieces may cross again */
        }
    }
    /* One jump across a seam inside the loop, none at its closing junction: start after it. */
    int n = lp->curve_count, jump = -1, jumps = 0;
    for (int i = 0; i < n; i++) {
        double a[2], b[2];
        curve_end(lp->curves[i], 1, a);
        curve_end(lp->curves[(i + 1) % n], 0, b);
        for (int k = 0; k < 2; k++) {
            double per = d[2 * k + 1] - d[2 * k];
            if (fabs(fabs(b[k] - a[k]) - per) <= snap && fabs(b[1 - k] - a[1 - k]) <= snap &&
                side_closed(s, d, k, tol))
                jump = i, jumps++;
        }
    }
    if (jumps == 1 && jump != n - 1) {
        crisp_curve **tmp = crisp_malloc_array((size_t)n, sizeof *tmp);
        if (!tmp) return -1;
        for (int i = 0; i < n; i++)
            tmp[i] = lp->curves[(jump + 1 + i) % n];
        memcpy(lp->curves, tmp, (size_t)n * sizeof *tmp);
        crisp_free(tmp);
    }
    return 0;
}

/* A loop that crosses the seam of a closed B-spline surface twice (a strip running around most
 * of a turn, through the seam: trj5_k1-sh-203.stp #1485) jumps across the domain twice: no loop
 * inside one turn of (u, v) bounds it. It becomes two loops, each closed along the seam side it
 * reaches (the face covers the seam between the two crossings), both with the loop's role.
 * Returns 1 when a loop was cut, 0 when none, -1 when out of memory. */
static int jump_at(const crisp_surface *s, const double d[4], const crisp_trim_loop *lp, int i,
                   double tol, double snap)
{
    int n = lp->curve_count;
    double a[2], b[2];
    curve_end(lp->curves[i], 1, a);
    curve_end(lp->curves[(i + 1) % n], 0, b);
    for (int k = 0; k < 2; k++) {
        double per = d[2 * k + 1] - d[2 * k];
        if (fabs(fabs(b[k] - a[k]) - per) <= snap && fabs(b[1 - k] - a[1 - k]) <= snap &&
            side_closed(s, d, k, tol))
            return k + 1;
    }
    return 0;
}

static int cut_at_seam_jumps(const crisp_surface *s, const double d[4], crisp_face *face,
                             double tol, double snap)
{
    for (int l = 0; l < face->loop_count; l++) {
        crisp_trim_loop *lp = &face->loops[l];
        int n = lp->curve_count, j[3], nj = 0, kind[3];
        for (int i = 0; i < n && nj < 3; i++) {
            int k = jump_at(s, d, lp, i, tol, snap);
            if (k) kind[nj] = k, j[nj++] = i;
        }
        if (nj != 2 || kind[0] != kind[1]) continue;
        /* the two sub-loops: after the first jump up to the second, and after it round to the
         * first; each must start and end on one seam side */
        int k = kind[0] - 1, na = j[1] - j[0], nb = n - na;
        double a0[2], a1[2], b0[2], b1[2];
        curve_end(lp->curves[j[0] + 1], 0, a0);
        curve_end(lp->curves[j[1]], 1, a1);
        curve_end(lp->curves[(j[1] + 1) % n], 0, b0);
        curve_end(lp->curves[j[0]], 1, b1);
        if (fabs(a0[k] - a1[k]) > snap || fabs(b0[k] - b1[k]) > snap) continue;
        crisp_trim_loop *nl =
            crisp_realloc_array(face->loops, (size_t)face->loop_count + 1, sizeof *nl);
        if (!nl) return -1;
        face->loops = nl;
        lp = &face->loops[l];
        crisp_curve **ca = crisp_malloc_array((size_t)na + 1, sizeof *ca);
        crisp_curve **cb = crisp_malloc_array((size_t)nb + 1, sizeof *cb);
        crisp_curve *sa = NULL, *sb = NULL;
        if (!ca || !cb || crisp_make_line(2, a1, a0, 0, 1, &sa) ||
            crisp_make_line(2, b1, b0, 0, 1, &sb)) {
            crisp_free(ca);
            crisp_free(cb);
            crisp_curve_destroy(sa);
            return -1;
        }
        for (int i = 0; i < na; i++)
            ca[i] = lp->curves[j[0] + 1 + i];
        ca[na] = sa;
        for (int i = 0; i < nb; i++)
            cb[i] = lp->curves[(j[1] + 1 + i) % n];
        cb[nb] = sb;
        crisp_free(lp->curves);
        lp->curves = ca;
        lp->curve_count = na + 1;
        crisp_trim_loop *other = &face->loops[face->loop_count++];
        memset(other, 0, sizeof *other);
        other->curves = cb;
        other->curve_count = nb + 1;
        other->is_outer = lp->is_outer;
        return 1;
    }
    return 0;
}

/* Two loops that each wind once around a closed B-spline surface (two circles bounding a band on a
 * cylinder-like patch, trj4_k1_geo-tu-214.stp) do not close in (u, v): they become one loop, A,
 * the seam side from A's end to B's start, B (reversed so that it runs back), the seam side from
 * B's end to A's start, as append_band does for elementary surfaces. Returns the index of the
 * joined loop, -1 when there is nothing to join, -2 when out of memory. */
static int join_bspline_band(const crisp_surface *s, const double d[4], crisp_face *face,
                             double tol, double snap)
{
    for (int k = 0; k < 2; k++) {
        if (!side_closed(s, d, k, tol)) continue;
        double width = d[2 * k + 1] - d[2 * k];
        int wl[2], nw = 0;
        double dir[2] = {0, 0};
        for (int i = 0; i < face->loop_count; i++) {
            crisp_trim_loop *lp = &face->loops[i];
            if (!lp->curve_count) continue;
            double a[2], b[2];
            curve_end(lp->curves[0], 0, a);
            curve_end(lp->curves[lp->curve_count - 1], 1, b);
            if (fabs(fabs(b[k] - a[k]) - width) > snap || fabs(b[1 - k] - a[1 - k]) > snap)
                continue;
            if (nw == 2) return -1;
            dir[nw] = b[k] - a[k];
            wl[nw++] = i;
        }
        if (nw != 2) continue;
        crisp_trim_loop *A = &face->loops[wl[0]], *B = &face->loops[wl[1]];
        if ((dir[0] > 0) == (dir[1] > 0)) crisp_trim_loop_reverse(B);
        double a0[2], a1[2], b0[2], b1[2];
        curve_end(A->curves[0], 0, a0);
        curve_end(A->curves[A->curve_count - 1], 1, a1);
        curve_end(B->curves[0], 0, b0);
        curve_end(B->curves[B->curve_count - 1], 1, b1);
        /* The seam sides run at A's end and start: B's ends sit on the same sides. */
        b0[k] = a1[k];
        b1[k] = a0[k];
        crisp_curve *up = NULL, *down = NULL;
        crisp_curve **nc = crisp_realloc_array(
            A->curves, (size_t)(A->curve_count + B->curve_count + 2), sizeof *nc);
        if (!nc) return -2;
        A->curves = nc;
        if (crisp_make_line(2, a1, b0, 0, 1, &up) || crisp_make_line(2, b1, a0, 0, 1, &down)) {
            crisp_curve_destroy(up);
            return -2;
        }
        nc[A->curve_count++] = up;
        for (int i = 0; i < B->curve_count; i++)
            nc[A->curve_count++] = B->curves[i];
        nc[A->curve_count++] = down;
        crisp_free(B->curves);
        B->curves = NULL;
        B->curve_count = 0;
        int keep = wl[0] > wl[1] ? wl[0] - 1 : wl[0];
        memmove(B, B + 1, (size_t)(face->loop_count - wl[1] - 1) * sizeof *B);
        face->loop_count--;
        return keep;
    }
    return -1;
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
        if (!collapsed_segment(s, pa, pb, tol)) continue;
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

/* Length of a 2D curve's control polygon (a bound on its length). */
static double polygon_length(const crisp_curve *c)
{
    double len = 0;
    for (int i = 1; i < c->count; i++) {
        const double *a = c->cpw + 3 * (i - 1), *b = c->cpw + 3 * i;
        len += hypot(b[0] / b[2] - a[0] / a[2], b[1] / b[2] - a[1] / a[2]);
    }
    return len;
}

/* Sum of the (u, v) gaps between consecutive trims of a loop, gaps along collapsed lines
 * counting as none. */
static double loop_gaps(const crisp_surface *s, const crisp_trim_loop *lp, double tol)
{
    double g = 0;
    for (int i = 0; i < lp->curve_count; i++) {
        double a[2], b[2];
        curve_end(lp->curves[(i + lp->curve_count - 1) % lp->curve_count], 1, a);
        curve_end(lp->curves[i], 0, b);
        double d = hypot(a[0] - b[0], a[1] - b[1]);
        if (d > 0 && !collapsed_segment(s, a, b, tol)) g += d;
    }
    return g;
}

static void shift_curve(crisp_curve *c, const double sh[2])
{
    for (int j = 0; j < c->count; j++)
        for (int k = 0; k < 2; k++)
            c->cpw[3 * j + k] += sh[k] * c->cpw[3 * j + 2];
}

/* On a B-spline surface closed in both directions (a torus-like patch), a loop that crosses both
 * seams lands its projected trims on either side of each: seam_sides moves one trim at a time and
 * cannot move a run of them (trj5_k1-id-214.stp #1321: a band bounded by two circles and a seam
 * edge, the far circle and the short pieces beside it projected on v = 0 instead of v = 1). The
 * loop is unwound instead: from its longest trim on, each trim moves by whole periods to start
 * where the one before ends. Kept when that closes the loop better and every trim stays in the
 * domain. */
static int unwrap_closed(const crisp_surface *s, const double d[4], crisp_trim_loop *lp, double tol,
                         double snap)
{
    int n = lp->curve_count;
    double per[2];
    for (int k = 0; k < 2; k++)
        per[k] = side_closed(s, d, k, tol) ? d[2 * k + 1] - d[2 * k] : 0;
    if (n < 2 || (!(per[0] > 0) && !(per[1] > 0))) return 0;
    double before = loop_gaps(s, lp, tol);
    if (before <= snap) return 0;
    double(*sh)[2] = crisp_calloc_array((size_t)n, sizeof *sh);
    if (!sh) return -1;
    int start = 0;
    double best = -1;
    for (int i = 0; i < n; i++) {
        double len = polygon_length(lp->curves[i]);
        if (len > best) best = len, start = i;
    }
    for (int m = 1; m < n; m++) {
        int i = (start + m) % n;
        double a[2], b[2];
        curve_end(lp->curves[(i + n - 1) % n], 1, a);
        curve_end(lp->curves[i], 0, b);
        for (int k = 0; k < 2; k++)
            if (per[k] > 0) sh[i][k] = per[k] * round((a[k] - b[k]) / per[k]);
        shift_curve(lp->curves[i], sh[i]);
    }
    int inside = 1;
    for (int i = 0; i < n && inside; i++) {
        const crisp_curve *c = lp->curves[i];
        for (int j = 0; j < c->count && inside; j++)
            for (int k = 0; k < 2; k++) {
                double x = c->cpw[3 * j + k] / c->cpw[3 * j + 2];
                if (x < d[2 * k] - snap || x > d[2 * k + 1] + snap) inside = 0;
            }
    }
    int keep = inside && loop_gaps(s, lp, tol) < before;
    if (!keep)
        for (int i = 0; i < n; i++) {
            double back[2] = {-sh[i][0], -sh[i][1]};
            shift_curve(lp->curves[i], back);
        }
    crisp_free(sh);
    return keep;
}

/* A loop the file leaves open: consecutive edges whose 3D ends do not meet (trj3_s1-al-214.stp:
 * a half-cylinder strip bounded by its two arcs only, the straight edges along the cylinder left
 * out; OCCT's ShapeFix adds them). Where the gap is real in 3D as well (the two ends lie more
 * than the tolerance apart on the surface), it is bridged by a straight (u, v) segment, as
 * healing tools do, when the bridges make up less than half of the loop. Gaps whose two ends
 * are one point in 3D (a seam, a jump across a closed surface) are left to the closure check:
 * a segment across the domain would be wrong there. Returns the number of bridges, -1 when out
 * of memory. */
static int bridge_open(const crisp_surface *s, crisp_trim_loop *lp, double tol, double snap)
{
    int n = lp->curve_count, gaps = 0;
    if (n == 0) return 0;
    double total = 0, bridged = 0;
    for (int i = 0; i < n; i++)
        total += polygon_length(lp->curves[i]);
    for (int i = 0; i < n; i++) {
        double pa[2], pb[2], qa[3], qb[3];
        curve_end(lp->curves[i], 1, pa);
        curve_end(lp->curves[(i + 1) % n], 0, pb);
        double g = hypot(pa[0] - pb[0], pa[1] - pb[1]);
        if (!(g > snap)) continue;
        crisp_surface_eval(s, pa[0], pa[1], qa);
        crisp_surface_eval(s, pb[0], pb[1], qb);
        if (!(crisp__step_dist3(qa, qb) > tol)) return 0;
        bridged += g;
        gaps++;
    }
    if (!gaps || !(bridged < 0.5 * (total + bridged))) return 0;
    int added = 0;
    for (int i = 0; i < lp->curve_count; i++) {
        double pa[2], pb[2];
        curve_end(lp->curves[i], 1, pa);
        curve_end(lp->curves[(i + 1) % lp->curve_count], 0, pb);
        if (!(hypot(pa[0] - pb[0], pa[1] - pb[1]) > snap)) continue;
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
static crisp_status append_band(face_work *w, const crisp_surface *s, crisp_trim_loop *lp,
                                size_t *cap)
{
    if (w->band_b < 0) {
        /* Closed at a collapsed line: seam up to it, along it, seam down. */
        const loop_work *A = &w->loops[w->band_a];
        const edge_use *e0 = &A->edges[0], *e1 = &A->edges[A->count - 1];
        double f0[2] = {e0->uv[0], e0->uv[1]},
               f1[2] = {e1->uv[2 * e1->ns - 2], e1->uv[2 * e1->ns - 1]};
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
    for (int k = 0; k < B->count && !st; k++)
        st = edge_trims(w, s, &B->edges[k], &b.curves, &b.curve_count, &bcap);
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

/* ---- the face -----------------------------------------------------------------------------------
 */

crisp_status crisp__step_work_init(face_work *w, step_reader *r, const step_entity *fe,
                                   const step_entity *se)
{
    memset(w, 0, sizeof *w);
    *w = (face_work){.r = r, .fe = fe, .band_a = -1, .band_b = -1};
    crisp_status st = crisp__step_surface(r, se, &w->s);
    if (st) return st;
    w->period[0] = w->s.u_periodic ? 2 * M_PI : 0;
    w->period[1] = w->s.v_periodic ? 2 * M_PI : 0;
    if (w->s.kind == STEP_SURF_EXTRUSION && w->s.profile.kind != STEP_CURVE_CONIC) w->period[0] = 0;
    return CRISP_OK;
}

crisp_status crisp__step_face(step_reader *r, const step_entity *fe, crisp_face *dest)
{
    memset(dest, 0, sizeof *dest);
    face_work w;
    const step_part *fp = crisp__step_part(r, fe, NULL);
    const step_entity *se;
    int same;
    crisp_status st;
    if ((st = crisp__step_get_ref(r, fe, fp, 2, &se)) ||
        (st = crisp__step_get_bool(r, fe, fp, 3, &same)))
        return st;
    if (!(st = crisp__step_work_init(&w, r, fe, se)) && !(st = crisp__step_read_loops(&w)))
        st = crisp__step_face_finish(&w, same, dest);
    crisp__step_work_free(&w);
    return st;
}

/* A face on a surface that closes on itself in both directions (sphere, torus) without edge loops
 * (or with vertex loops only) is the whole surface. */
static int whole_closed_surface(face_work *w)
{
    if (w->s.kind == STEP_SURF_SPHERE) {
        w->box[0] = 0, w->box[1] = 2 * M_PI, w->box[2] = -M_PI / 2, w->box[3] = M_PI / 2;
        return 1;
    }
    if (w->s.kind == STEP_SURF_TORUS) {
        w->box[0] = 0, w->box[1] = 2 * M_PI, w->box[2] = 0, w->box[3] = 2 * M_PI;
        return 1;
    }
    return 0;
}

crisp_status crisp__step_face_finish(face_work *wp, int same, crisp_face *dest)
{
    face_work w = *wp; /* the caller frees *wp: loops and surface are shared, not copied */
    step_reader *r = w.r;
    const step_entity *fe = w.fe;
    crisp_status st = CRISP_OK;
    memset(dest, 0, sizeof *dest);
    w.same = same;
    int whole = 0;
    if (w.nloops == 0 && w.s.kind != STEP_SURF_BSPLINE && !(whole = whole_closed_surface(&w))) {
        st = crisp__step_fail(r, fe, CRISP_ERR_UNSUPPORTED,
                              "face on an unbounded surface without edge loops");
        goto done;
    }
    int outer = 0;
    for (int i = 0; i < w.nloops; i++)
        if ((st = crisp__step_loop_samples(&w, &w.loops[i]))) goto done;
    /* Latitudes written a turn away (bm2_pe_t4-A.stp #355: an octant's pcurves at latitudes 270
     * to 360 degrees, which the sphere's parametrisation takes as -90 to 0) go back by whole
     * turns into [-90, 90] degrees, where the loop fits there. */
    for (int i = 0; i < w.nloops && w.s.kind == STEP_SURF_SPHERE; i++) {
        loop_work *lw = &w.loops[i];
        double k = round(0.5 * (lw->box[2] + lw->box[3]) / (2 * M_PI)), eps = 1e-9;
        double sh[2] = {0, -2 * M_PI * k};
        if (k != 0 && lw->box[2] + sh[1] >= -M_PI / 2 - eps && lw->box[3] + sh[1] <= M_PI / 2 + eps)
            crisp__step_shift_loop(lw, sh);
    }
    if (w.s.kind != STEP_SURF_BSPLINE && !whole) {
        double best = -1;
        for (int i = 0; i < w.nloops; i++) {
            const double *b = w.loops[i].box;
            double area = (b[1] - b[0]) * (b[3] - b[2]);
            if (w.loops[i].outer_flag) area = INFINITY;
            if (area > best) best = area, outer = i;
        }
        /* Loops that wind around a periodic direction do not close in (u, v): two of them bound
         * a band and are joined along the seam; any other crisp__step_winding loop is not
         * supported. */
        int wl[2], nw = 0, wk = -1;
        for (int i = 0; i < w.nloops; i++)
            for (int k = 0; k < 2; k++)
                if (fabs(crisp__step_winding(&w, &w.loops[i], k)) > 0.5 * w.period[k] &&
                    w.period[k] > 0 && !w.loops[i].collapse) {
                    if (nw == 2 || (wk >= 0 && wk != k)) {
                        st = crisp__step_fail(
                            r, fe, CRISP_ERR_UNSUPPORTED,
                            "loop %d winds around the %c direction of surface #%d and is not one "
                            "of two loops bounding a band",
                            i + 1, "uv"[k], w.s.id);
                        goto done;
                    }
                    wl[nw++] = i;
                    wk = k;
                }
        if (nw == 1 && w.ncap == 1) {
            /* One crisp__step_winding loop and a vertex loop: the face is closed at the apex or
             * pole, where the surface collapses; the loop runs up the seam, along the collapsed
             * line, down. */
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
        /* (Only for loops that keep away from the poles or pass exactly through one, where the
         * trims are cut and bridged along the pole: one that passes near a pole turns fast in u
         * and can seem to wind; it is refused below.) */
        double vmax = 0;
        for (int k = 0; nw == 1 && k < w.loops[wl[0]].count; k++) {
            const edge_use *eu = &w.loops[wl[0]].edges[k];
            for (int i = 0; i < eu->ns; i++)
                vmax = fmax(vmax, fabs(eu->uv[2 * i + 1]));
        }
        if (nw == 1 && w.ncap == 0 && w.s.kind == STEP_SURF_SPHERE && wk == 0 &&
            (vmax < M_PI / 2 - 0.05 || vmax > M_PI / 2 - 1e-9) &&
            w.loops[wl[0]].box[1] - w.loops[wl[0]].box[0] <= 2 * M_PI * (1 + 1e-9)) {
            /* (And only when the loop spans at most one turn: one surface of one turn holds it.) */
            /* One loop around a sphere and no vertex loop (a cap bounded by a circle): the face
             * holds the pole on its left, seen along the face normal. (u, v, outward normal) is
             * right handed, so a loop running towards +u has the north pole on its left. */
            double wind = crisp__step_winding(&w, &w.loops[wl[0]], 0);
            int north = (wind > 0) == (w.loops[wl[0]].sense != same);
            w.band_a = wl[0];
            w.cap_k = 0;
            w.cap_v = north ? M_PI / 2 : -M_PI / 2;
            double *bx = w.loops[wl[0]].box;
            if (w.cap_v < bx[2]) bx[2] = w.cap_v;
            if (w.cap_v > bx[3]) bx[3] = w.cap_v;
            outer = wl[0];
            nw = 0;
        }
        if (nw == 1) {
            st = crisp__step_fail(
                r, fe, CRISP_ERR_UNSUPPORTED,
                "loop %d winds around the %c direction of surface #%d without a seam edge",
                wl[0] + 1, "uv"[wk], w.s.id);
            goto done;
        }
        if (nw == 2) {
            if ((st = crisp__step_make_band(&w, wl[0], wl[1], wk))) goto done;
            outer = wl[0];
        }
        /* Holes on periodic coordinates go to the turn of the outer loop. */
        for (int i = 0; i < w.nloops; i++) {
            if (i == outer || i == w.band_b) continue;
            double c[2] = {0.5 * (w.loops[i].box[0] + w.loops[i].box[1]),
                           0.5 * (w.loops[i].box[2] + w.loops[i].box[3])};
            double oc[2] = {0.5 * (w.loops[outer].box[0] + w.loops[outer].box[1]),
                            0.5 * (w.loops[outer].box[2] + w.loops[outer].box[3])},
                   sh[2];
            crisp__step_period_shift(&w, c, oc, sh);
            if (sh[0] != 0 || sh[1] != 0) crisp__step_shift_loop(&w.loops[i], sh);
        }
        crisp__step_choose_box(&w, outer);
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
            if ((st = edge_trims(&w, dest->surface, &w.loops[i].edges[k], &lp->curves,
                                 &lp->curve_count, &cap)))
                goto done;
        if (i == w.band_a && (st = append_band(&w, dest->surface, lp, &cap))) goto done;
        if (w.s.kind == STEP_SURF_BSPLINE) {
            if (split_at_seams(dest->surface, w.nbox, lp, r->tol, 100 * w.tol_uv) < 0) {
                st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
                goto done;
            }
            seam_sides(dest->surface, w.nbox, lp, r->tol, 100 * w.tol_uv);
            if (unwrap_closed(dest->surface, w.nbox, lp, r->tol, 100 * w.tol_uv) < 0) {
                st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
                goto done;
            }
        }
        snap_junctions(lp, 100 * w.tol_uv);
        int added = bridge_degenerate(dest->surface, lp, r->tol, 100 * w.tol_uv);
        if (added < 0) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
            goto done;
        }
        r->stats->degenerate_edges += added;
        /* (A plane is grown instead, below: its trims' control polygons may leave the box of
         * the curves by far, e.g. a half circle as one rational cubic, whose middle control
         * points lie twice as far out as the arc: clamping them squashed the arc to half its
         * radius, occt_as1_ec.stp's bolt heads.) */
        if (w.s.kind != STEP_SURF_PLANE) clamp_loop(lp, w.nbox);
    }
    if (w.s.kind == STEP_SURF_PLANE) {
        /* The plane's (u, v) are the file's: rebuilt over a box that holds every control point. */
        double b[4] = {w.nbox[0], w.nbox[1], w.nbox[2], w.nbox[3]};
        int grow = 0;
        for (int i = 0; i < dest->loop_count; i++)
            for (int k = 0; k < dest->loops[i].curve_count; k++) {
                const crisp_curve *c = dest->loops[i].curves[k];
                for (int j = 0; j < c->count; j++)
                    for (int q = 0; q < 2; q++) {
                        double x = c->cpw[3 * j + q] / c->cpw[3 * j + 2];
                        if (!isfinite(x)) continue;
                        if (x < b[2 * q]) b[2 * q] = x, grow = 1;
                        if (x > b[2 * q + 1]) b[2 * q + 1] = x, grow = 1;
                    }
            }
        if (grow) {
            crisp_surface *big = NULL;
            if ((st = crisp__step_surface_build(r, &w.s, b, &big, w.nbox))) goto done;
            crisp_surface_destroy(dest->surface);
            dest->surface = big;
        }
    }
    int band = -1;
    if (w.s.kind == STEP_SURF_BSPLINE && dest->loop_count >= 2 &&
        (band = join_bspline_band(dest->surface, w.nbox, dest, r->tol, 100 * w.tol_uv)) == -2) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
        goto done;
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
            /* (After a band join, loop indices no longer match w.loops: the band is the outer.) */
            double area = band >= 0               ? (i == band ? INFINITY : 0)
                          : w.loops[i].outer_flag ? INFINITY
                                                  : (b[1] - b[0]) * (b[3] - b[2]);
            if (area > best) best = area, outer = i;
        }
        for (int i = 0; i < dest->loop_count; i++)
            dest->loops[i].is_outer = i == outer;
    }
    for (int cut = 0; w.s.kind == STEP_SURF_BSPLINE && cut < 8; cut++) {
        int c = cut_at_seam_jumps(dest->surface, w.nbox, dest, r->tol, 100 * w.tol_uv);
        if (c < 0) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
            goto done;
        }
        if (!c) break;
    }
    for (int i = 0; i < dest->loop_count; i++) {
        int added = bridge_open(dest->surface, &dest->loops[i], r->tol, 100 * w.tol_uv);
        if (added < 0) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
            goto done;
        }
        if (added)
            crisp_model_note_skipf(
                r->model,
                "STEP face #%d: loop %d left open by the file (%d gaps between its edges' "
                "ends): closed by straight (u, v) segments",
                fe->id, i + 1, added);
    }
    dest->source_id = fe->id;
    dest->reversed = (!same) ^ crisp__step_surface_swaps(&w.s);
    st = crisp_face_normalize_loops(dest, r->close_rel * dsize);
    if (st) {
        char type[64];
        crisp_error_prefix("%s: #%d (line %d) %s", r->f->name, fe->id, fe->line,
                           crisp__step_type(r, fe, type, sizeof type));
    }
done:
    /* Sampling and band joining may have replaced the loops' arrays: hand them back to be freed. */
    wp->loops = w.loops;
    wp->nloops = w.nloops;
    if (st) {
        crisp_face_free(dest);
        memset(dest, 0, sizeof *dest);
    }
    return st;
}
