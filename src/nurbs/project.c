/* Point inversion on NURBS surfaces and projection of 3D curves into a surface's (u, v) domain.
 * Follows Piegl & Tiller, "The NURBS Book", section 6.1 (point inversion: a coarse global search
 * for the start, then Newton on (S - P).S_u = 0, (S - P).S_v = 0 with the domain clamped), made
 * robust with Gauss-Newton / Levenberg-Marquardt damping so that poles (S_u = 0) and collapsed
 * edges give a finite answer instead of a singular system.
 *
 * Projection: sample the 3D curve, invert the samples in order (each seeded from the previous
 * (u, v), so the path stays continuous), unwrap across the seam of surfaces closed in u or v (the
 * u0 and u1 boundary curves coincide) by choosing the representative nearest the previous one,
 * take u from the neighbours where it is undefined (a pole), then fit a cubic in (u, v) with the
 * adaptive fitter, whose error is measured in 3D: |S(fitted uv) - C(t)|. The uv curve of a seam
 * crossing is continuous and so leaves [u0, u1] by up to a period; evaluate S at u wrapped into
 * the domain. */
#include "fit_internal.h"
#include "nurbs_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define GRID_MAX 24 /* global search grid per direction */
#define NEWTON_ITERS 40

typedef struct surf_info {
    const crisp_surface *s;
    double dom[4];
    int closed[2];    /* closed in u, in v */
    double period[2]; /* domain widths */
    double scale;     /* bounding box diagonal */
} surf_info;

static double dist3(const double *a, const double *b)
{
    double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
    return sqrt(x * x + y * y + z * z);
}

/* A parameter of a closed direction wrapped into the domain, others clamped. */
static double wrap(const surf_info *si, int dir, double x)
{
    double lo = si->dom[2 * dir], hi = si->dom[2 * dir + 1];
    if (si->closed[dir]) {
        if (x < lo || x > hi) {
            double p = si->period[dir];
            x = lo + fmod(x - lo, p);
            if (x < lo) x += p;
            if (x > hi) x = hi;
        }
        return x;
    }
    return x < lo ? lo : x > hi ? hi : x;
}

static void eval_wrapped(const surf_info *si, const double uv[2], double *p, double *su, double *sv)
{
    crisp_surface_derivs(si->s, wrap(si, 0, uv[0]), wrap(si, 1, uv[1]), p, su, sv, NULL, NULL,
                         NULL);
}

static void surf_info_init(const crisp_surface *s, surf_info *si)
{
    si->s = s;
    crisp_surface_domain(s, si->dom);
    double box[6];
    crisp_surface_bbox(s, box);
    si->scale = sqrt((box[3] - box[0]) * (box[3] - box[0]) + (box[4] - box[1]) * (box[4] - box[1]) +
                     (box[5] - box[2]) * (box[5] - box[2]));
    if (!(si->scale > 0)) si->scale = 1;
    for (int dir = 0; dir < 2; dir++) {
        si->period[dir] = si->dom[2 * dir + 1] - si->dom[2 * dir];
        si->closed[dir] = 0;
    }
    /* Closed in u when the boundary curves S(u0, v) and S(u1, v) coincide (likewise in v) and
     * are not one point (a collapsed boundary pair is not a seam). (The spread is measured along
     * the boundary curve itself: its two ends coincide on a surface closed in both directions,
     * a torus, which is closed in each.) */
    for (int dir = 0; dir < 2; dir++) {
        double worst = 0, spread = 0, first[3];
        for (int k = 0; k <= 4; k++) {
            double o = si->dom[2 * (1 - dir)] + si->period[1 - dir] * k / 4.0, a[3], b[3];
            if (dir == 0) {
                crisp_surface_eval(s, si->dom[0], o, a);
                crisp_surface_eval(s, si->dom[1], o, b);
            } else {
                crisp_surface_eval(s, o, si->dom[2], a);
                crisp_surface_eval(s, o, si->dom[3], b);
            }
            double d = dist3(a, b);
            if (!(d <= worst)) worst = d;
            if (k == 0) memcpy(first, a, sizeof first);
            d = dist3(a, first);
            if (d > spread) spread = d;
        }
        si->closed[dir] = worst <= 1e-7 * si->scale && spread > 1e-7 * si->scale;
    }
}

/* Damped Gauss-Newton from uv (in place, unwrapped in closed directions, clamped otherwise):
 * minimises |S(u, v) - P|^2. Returns the distance reached; norms (may be NULL) gets |S_u|, |S_v|
 * there. */
static double newton_core(const surf_info *si, const double p[3], double uv[2], double norms[2]);

/* Whether x lies on an interior knot of multiplicity >= degree (a crease: the surface is only C0
 * there). */
static int on_crease(const double *knots, int degree, int count, double x)
{
    int lo = degree + 1, hi = count - 1; /* interior knots: knots[degree + 1 .. count - 1] */
    double span = knots[count] - knots[degree], eps = 1e-12 * (span > 0 ? span : 1);
    for (int i = lo; i <= hi;) {
        int m = 1;
        while (i + m <= hi && knots[i + m] == knots[i])
            m++;
        if (m >= degree && fabs(x - knots[i]) <= eps) return 1;
        i += m;
    }
    return 0;
}

/* Newton, then, when it stops off the surface exactly on a crease (a C0 knot line), again from a
 * hair to either side of it: there the derivatives of one side can be orthogonal to the residual
 * while the other side leads on (trj6_k1-al-214.stp: a polyline profile extruded, the edge
 * starting at a corner of the profile and running along the next segment; every seeded inversion
 * stayed at the corner, 5 units from the edge, and the fit took that for the edge lying off the
 * surface). */
static double newton(const surf_info *si, const double p[3], double uv[2], double norms[2])
{
    double d = newton_core(si, p, uv, norms);
    if (!(d > 1e-10 * si->scale)) return d;
    const crisp_surface *s = si->s;
    for (int dir = 0; dir < 2; dir++) {
        const double *kn = dir ? s->knots_v : s->knots_u;
        int deg = dir ? s->degree_v : s->degree_u, cnt = dir ? s->count_v : s->count_u;
        double x = si->closed[dir] ? wrap(si, dir, uv[dir]) : uv[dir];
        if (!on_crease(kn, deg, cnt, x)) continue;
        double best[2] = {uv[0], uv[1]}, bn[2] = {0, 0}, bd = d;
        for (int side = -1; side <= 1; side += 2) {
            double t[2] = {uv[0], uv[1]}, tn[2];
            t[dir] += side * 1e-9 * si->period[dir];
            double e = newton_core(si, p, t, tn);
            if (e < bd * (1 - 1e-6)) {
                bd = e;
                best[0] = t[0], best[1] = t[1];
                bn[0] = tn[0], bn[1] = tn[1];
            }
        }
        if (bd < d) {
            d = bd;
            uv[0] = best[0], uv[1] = best[1];
            if (norms) norms[0] = bn[0], norms[1] = bn[1];
        }
    }
    return d;
}

static double newton_core(const surf_info *si, const double p[3], double uv[2], double norms[2])
{
    double s[3], su[3], sv[3];
    for (int dir = 0; dir < 2; dir++)
        if (!si->closed[dir]) uv[dir] = wrap(si, dir, uv[dir]);
    eval_wrapped(si, uv, s, su, sv);
    double r[3] = {s[0] - p[0], s[1] - p[1], s[2] - p[2]};
    double d2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    double lam = 0;
    double tiny = 1e-300;
    int nudges = 0, valley = 0;
    for (int it = 0; it < NEWTON_ITERS && d2 > 0; it++) {
        double a = crisp_vec3_dot(su, su), b = crisp_vec3_dot(su, sv), c = crisp_vec3_dot(sv, sv);
        double gu = crisp_vec3_dot(r, su), gv = crisp_vec3_dot(r, sv);
        double tr = a + c;
        if (!(tr > tiny)) break; /* S_u = S_v = 0: nothing to follow */
        /* Marquardt scaling (damp each direction by its own size); a direction whose derivative
         * vanishes (pole, collapsed edge) is left alone and the other solved in 1D. */
        double du, dv, a2 = a * (1 + lam), c2 = c * (1 + lam);
        int u_dead = !(a > 1e-28 * tr), v_dead = !(c > 1e-28 * tr);
        if (u_dead || v_dead) {
            du = u_dead ? 0 : -gu / a2;
            dv = v_dead ? 0 : -gv / c2;
        } else {
            double det = a2 * c2 - b * b;
            if (!(det > 1e-15 * a2 * c2)) {
                lam = lam > 0 ? lam * 10 : 1e-6;
                if (lam > 1e12) break;
                continue;
            }
            du = -(c2 * gu - b * gv) / det;
            dv = -(a2 * gv - b * gu) / det;
        }
        /* A parameter held at its bound (the foot point lies beyond the patch's edge) that the
         * step would push out: the other is solved alone along the edge. Without this the
         * clamped step is not the 1D Newton step, and Newton stalls short of the closest point
         * on the edge (bm2_ec_exhaust-A.stp: edges 6e-5 off a patch along its side; two
         * inversions of one point stopped 5e-6 apart, more than the fit's tolerance). */
        if (!si->closed[0] &&
            ((uv[0] <= si->dom[0] && du < 0) || (uv[0] >= si->dom[1] && du > 0))) {
            du = 0;
            dv = v_dead ? 0 : -gv / c2;
        } else if (!si->closed[1] &&
                   ((uv[1] <= si->dom[2] && dv < 0) || (uv[1] >= si->dom[3] && dv > 0))) {
            dv = 0;
            du = u_dead ? 0 : -gu / a2;
        }
        if (!isfinite(du) || !isfinite(dv)) break;
        double cand[2] = {uv[0] + du, uv[1] + dv};
        for (int dir = 0; dir < 2; dir++)
            if (!si->closed[dir]) cand[dir] = wrap(si, dir, cand[dir]);
        double step = fabs(cand[0] - uv[0]) / si->period[0] + fabs(cand[1] - uv[1]) / si->period[1];
        double s2[3], su2[3], sv2[3];
        eval_wrapped(si, cand, s2, su2, sv2);
        double r2[3] = {s2[0] - p[0], s2[1] - p[1], s2[2] - p[2]};
        double e2 = r2[0] * r2[0] + r2[1] * r2[1] + r2[2] * r2[2];
        if (e2 <= d2) {
            uv[0] = cand[0];
            uv[1] = cand[1];
            memcpy(s, s2, sizeof s);
            memcpy(su, su2, sizeof su);
            memcpy(sv, sv2, sizeof sv);
            memcpy(r, r2, sizeof r);
            double sc2 = si->scale * si->scale;
            int converged =
                step < 1e-15 || d2 - e2 <= 1e-30 * sc2 + 1e-15 * d2 || e2 <= 1e-26 * sc2;
            d2 = e2;
            lam *= 0.25;
            if (lam < 1e-12) lam = 0;
            if (converged) break;
        } else {
            /* The step left a narrow curved valley of the distance (a patch far longer in one
             * direction of space than the others: the edges of trj6_b1-ec-214.stp #6387 lie
             * on a level curve of a coordinate that changes 10^5 times faster across it than
             * along it). The damping that shortens the step also turns it across the valley, so
             * Levenberg-Marquardt creeps along it; instead the undamped step is followed by
             * Gauss-Newton corrections back onto the valley floor, kept when they end nearer.
             * Once per inversion, after 8 iterations (Newton is done by then everywhere else)
             * while the damping is light; each evaluation counts as an iteration. On inputs
             * where Newton gets nowhere (fuzzed files) the extra evaluations cost up to ~10%. */
            if (it >= 8 && !valley && lam < 1e-2) {
                double pc[2], ps[3], psu[3], psv[3], pr[3], pe = INFINITY;
                int ok = 0;
                valley = 1;
                double a0 = a, c0 = c, det0 = a0 * c0 - b * b;
                if (det0 > 1e-15 * a0 * c0 && !u_dead && !v_dead) {
                    pc[0] = uv[0] - (c0 * gu - b * gv) / det0;
                    pc[1] = uv[1] - (a0 * gv - b * gu) / det0;
                    ok = 1;
                }
                for (int k = 0; k < 3 && ok; k++) {
                    for (int dir = 0; dir < 2; dir++)
                        if (!si->closed[dir]) pc[dir] = wrap(si, dir, pc[dir]);
                    eval_wrapped(si, pc, ps, psu, psv);
                    it++; /* the evaluations count against the iterations */
                    for (int q = 0; q < 3; q++)
                        pr[q] = ps[q] - p[q];
                    pe = crisp_vec3_dot(pr, pr);
                    if (!(pe == pe)) ok = 0;
                    if (pe < d2 || !ok) break;
                    double ka = crisp_vec3_dot(psu, psu), kb = crisp_vec3_dot(psu, psv),
                           kc = crisp_vec3_dot(psv, psv), kg = crisp_vec3_dot(pr, psu),
                           kh = crisp_vec3_dot(pr, psv), kd = ka * kc - kb * kb;
                    if (!(kd > 1e-15 * ka * kc)) break;
                    pc[0] -= (kc * kg - kb * kh) / kd;
                    pc[1] -= (ka * kh - kb * kg) / kd;
                }
                if (ok && pe < d2) {
                    uv[0] = pc[0], uv[1] = pc[1];
                    memcpy(s, ps, sizeof s);
                    memcpy(su, psu, sizeof su);
                    memcpy(sv, psv, sizeof sv);
                    memcpy(r, pr, sizeof r);
                    d2 = pe;
                    continue; /* (lam kept: a Newton that gets nowhere still stops early) */
                }
            }
            if (lam > 1e2 && nudges < 4 && step > 0) {
                /* Stalled: typically on a crease (a C0 knot line) with the derivatives of the
                 * side we came from. Step across by a hair and take the other side's. */
                double h = 1e-9 / step;
                double hair[2] = {uv[0] + h * (cand[0] - uv[0]), uv[1] + h * (cand[1] - uv[1])};
                double s3[3], su3[3], sv3[3];
                eval_wrapped(si, hair, s3, su3, sv3);
                double r3[3] = {s3[0] - p[0], s3[1] - p[1], s3[2] - p[2]};
                double e3 = r3[0] * r3[0] + r3[1] * r3[1] + r3[2] * r3[2];
                nudges++;
                if (e3 <= d2 * (1 + 1e-9)) {
                    uv[0] = hair[0];
                    uv[1] = hair[1];
                    memcpy(s, s3, sizeof s);
                    memcpy(su, su3, sizeof su);
                    memcpy(sv, sv3, sizeof sv);
                    memcpy(r, r3, sizeof r);
                    d2 = e3;
                    lam = 0;
                    continue;
                }
            }
            if (step < 1e-15) break;
            lam = lam > 0 ? lam * 8 : 1e-4;
            if (lam > 1e12) break;
        }
    }
    if (norms) {
        norms[0] = crisp_vec3_norm(su);
        norms[1] = crisp_vec3_norm(sv);
    }
    return sqrt(d2);
}

/* Sample positions of one direction: per knot span (degree + 1) samples inside it (a seed on a
 * knot of a C0 surface may lead Newton into the wrong span) plus the domain ends, when they fit
 * in GRID_MAX, else GRID_MAX uniform samples. Returns the count. */
static int grid_params(const double *knots, int degree, int count, double lo, double hi,
                       double *dest)
{
    int spans = 0;
    for (int i = degree; i < count; i++)
        if (knots[i + 1] > knots[i]) spans++;
    int per = degree + 1;
    if (spans >= 1 && spans * per + 1 <= GRID_MAX) {
        int n = 0;
        for (int i = degree; i < count; i++) {
            if (!(knots[i + 1] > knots[i])) continue;
            for (int k = 0; k < per; k++)
                dest[n++] = knots[i] + (knots[i + 1] - knots[i]) * (k + 0.5) / per;
        }
        dest[n++] = lo;
        dest[n++] = hi;
        return n;
    }
    for (int k = 0; k < GRID_MAX; k++)
        dest[k] = lo + (hi - lo) * k / (GRID_MAX - 1);
    return GRID_MAX;
}

/* Does grid line `index` (a row of constant v when dir = 0, a column of constant u when dir = 1)
 * collapse to one point? */
static int line_collapsed(double (*pts)[3], int nu, int nv, int dir, int index, double scale)
{
    int n = dir == 0 ? nu : nv;
    const double *first = pts[dir == 0 ? index * nu : index];
    for (int k = 1; k < n; k++)
        if (dist3(first, pts[dir == 0 ? index * nu + k : k * nu + index]) > 1e-12 * scale) return 0;
    return 1;
}

/* order[k]: index of the k-th smallest of g[0 .. n) (insertion sort; n is small). */
static void order_params(const double *g, int n, int *order)
{
    for (int i = 0; i < n; i++) {
        int k = i;
        while (k > 0 && g[order[k - 1]] > g[i]) {
            order[k] = order[k - 1];
            k--;
        }
        order[k] = i;
    }
}

/* Basis functions of the grid parameters in one direction: span index and degree + 1 values. */
static void grid_basis(const double *knots, int degree, int count, const double *g, int n,
                       int *span, double *basis)
{
    for (int i = 0; i < n; i++) {
        span[i] = crisp__find_span(knots, degree, count, g[i]);
        crisp__basis_funs(knots, degree, span[i], g[i], basis + i * (CRISP_MAX_DEGREE + 1));
    }
}

/* Global search: the surface on a grid (basis functions computed once per grid line, so a grid
 * point costs one tensor sum), the best few grid points refined by Newton; the closest wins. */
static double invert_global(const surf_info *si, const double p[3], double uv[2])
{
    const crisp_surface *s = si->s;
    enum { NB = CRISP_MAX_DEGREE + 1, KEEP = 3 };
    double gu[GRID_MAX + 2], gv[GRID_MAX + 2], bu[(GRID_MAX + 2) * NB], bv[(GRID_MAX + 2) * NB];
    int ku[GRID_MAX + 2], kv[GRID_MAX + 2];
    int nu = grid_params(s->knots_u, s->degree_u, s->count_u, si->dom[0], si->dom[1], gu);
    int nv = grid_params(s->knots_v, s->degree_v, s->count_v, si->dom[2], si->dom[3], gv);
    grid_basis(s->knots_u, s->degree_u, s->count_u, gu, nu, ku, bu);
    grid_basis(s->knots_v, s->degree_v, s->count_v, gv, nv, kv, bv);
    double dist[(GRID_MAX + 2) * (GRID_MAX + 2)], pts[(GRID_MAX + 2) * (GRID_MAX + 2)][3];
    int du = s->degree_u, dv = s->degree_v;
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            double h[4] = {0, 0, 0, 0};
            for (int b = 0; b <= dv; b++) {
                const double *row =
                    s->cpw + 4 * ((size_t)(kv[j] - dv + b) * s->count_u + (size_t)(ku[i] - du));
                double nb = bv[j * NB + b], r[4] = {0, 0, 0, 0};
                for (int a = 0; a <= du; a++) {
                    double na = bu[i * NB + a];
                    for (int m = 0; m < 4; m++)
                        r[m] += na * row[4 * a + m];
                }
                for (int m = 0; m < 4; m++)
                    h[m] += nb * r[m];
            }
            double *q = pts[j * nu + i];
            for (int m = 0; m < 3; m++)
                q[m] = h[m] / h[3];
            double d = dist3(q, p);
            dist[j * nu + i] = d == d ? d : INFINITY;
        }
    /* Seeds: the KEEP best grid points. Grid neighbours are found by parameter order (the
     * domain ends come last in gu, gv). */
    int ou[GRID_MAX + 2], ov[GRID_MAX + 2];
    order_params(gu, nu, ou);
    order_params(gv, nv, ov);
    double best_d[KEEP], best_uv[KEEP][2];
    int kept = 0;
    for (int jj = 0; jj < nv; jj++)
        for (int ii = 0; ii < nu; ii++) {
            int i = ou[ii], j = ov[jj];
            double d = dist[j * nu + i];
            if (!(d < INFINITY)) continue;
            if (kept == KEEP && !(d < best_d[KEEP - 1])) continue;
            /* On a collapsed grid line (a pole: every point of the row equal) the other
             * parameter is arbitrary and Newton can stall at the pole; seed from the best point
             * of the neighbouring line instead. */
            if (line_collapsed(pts, nu, nv, 0, j, si->scale)) {
                int j2 = ov[jj > 0 ? jj - 1 : jj + 1 < nv ? jj + 1 : jj];
                for (int i2 = 0; i2 < nu; i2++)
                    if (dist[j2 * nu + i2] < dist[j2 * nu + i] || i2 == 0) i = i2;
                j = j2;
            } else if (line_collapsed(pts, nu, nv, 1, i, si->scale)) {
                int i2 = ou[ii > 0 ? ii - 1 : ii + 1 < nu ? ii + 1 : ii];
                int jb = 0;
                for (int j3 = 0; j3 < nv; j3++)
                    if (dist[j3 * nu + i2] < dist[jb * nu + i2]) jb = j3;
                i = i2;
                j = jb;
            }
            int dup = 0;
            for (int m = 0; m < kept; m++)
                if (best_uv[m][0] == gu[i] && best_uv[m][1] == gv[j]) dup = 1;
            if (dup) continue;
            int at = kept < KEEP ? kept++ : KEEP;
            if (at == KEEP) {
                if (!(d < best_d[KEEP - 1])) continue;
                at = KEEP - 1;
            }
            while (at > 0 && best_d[at - 1] > d) {
                best_d[at] = best_d[at - 1];
                best_uv[at][0] = best_uv[at - 1][0];
                best_uv[at][1] = best_uv[at - 1][1];
                at--;
            }
            best_d[at] = d;
            best_uv[at][0] = gu[i];
            best_uv[at][1] = gv[j];
        }
    double bd = INFINITY;
    uv[0] = si->dom[0];
    uv[1] = si->dom[2];
    for (int k = 0; k < kept; k++) {
        double t[2] = {best_uv[k][0], best_uv[k][1]};
        double d = newton(si, p, t, NULL);
        if (d < bd) {
            bd = d;
            uv[0] = t[0];
            uv[1] = t[1];
        }
        if (bd <= 1e-12 * si->scale) break;
    }
    return bd;
}

crisp_status crisp_surface_closest_point(const crisp_surface *s, const double p[3], double uv[2],
                                         double *dist)
{
    if (!s || !p || !uv)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_surface_closest_point: NULL argument");
    if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_surface_closest_point: point (%g, %g, %g) is not finite", p[0],
                           p[1], p[2]);
    surf_info si;
    surf_info_init(s, &si);
    double d = invert_global(&si, p, uv);
    uv[0] = wrap(&si, 0, uv[0]);
    uv[1] = wrap(&si, 1, uv[1]);
    if (!isfinite(d) || !isfinite(uv[0]) || !isfinite(uv[1]))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "crisp_surface_closest_point: no finite closest point for (%g, %g, %g)",
                           p[0], p[1], p[2]);
    if (dist) *dist = d;
    return CRISP_OK;
}

/* ---- curve projection --------------------------------------------------------------------------
 */

typedef struct proj_ctx {
    surf_info si;
    const crisp_curve *c;
    double t0, t1, tol;
    int n;       /* samples */
    double *st;  /* sample parameters */
    double *suv; /* sample (u, v), continuous */
    double *sd;  /* sample distances to the surface */
} proj_ctx;

/* The representative of x (in a closed direction) nearest ref. */
static double unwrap_near(const surf_info *si, int dir, double x, double ref)
{
    if (!si->closed[dir]) return x;
    double p = si->period[dir];
    return x - p * floor((x - ref) / p + 0.5);
}

/* Is direction dir degenerate (S_u or S_v vanishing: a pole or collapsed edge), given the
 * derivative norms there? */
static int dead_dir(const surf_info *si, const double norms[2], int dir)
{
    return !(norms[dir] * si->period[dir] > 1e-7 * si->scale);
}

/* Invert C(t) seeded from seed, whose own distance was seed_dist; falls back to the global search
 * when the local answer is much farther than the seed was (a curve lying off the surface by more
 * than tol does not trigger it everywhere). dead gets which parameters are undefined at the
 * answer. Returns the distance. */
static double invert_seeded(const proj_ctx *pc, double t, const double seed[2], double seed_dist,
                            double uv[2], int dead[2])
{
    double p[3], norms[2];
    crisp_curve_eval(pc->c, t, p);
    uv[0] = seed[0];
    uv[1] = seed[1];
    double d = newton(&pc->si, p, uv, norms);
    if (d > 2 * seed_dist + pc->tol) {
        double g[2];
        double dg = invert_global(&pc->si, p, g);
        if (dg < 0.5 * d) {
            d = dg;
            uv[0] = g[0];
            uv[1] = g[1];
            double su[3], sv[3];
            eval_wrapped(&pc->si, uv, NULL, su, sv);
            norms[0] = crisp_vec3_norm(su);
            norms[1] = crisp_vec3_norm(sv);
        }
    }
    uv[0] = unwrap_near(&pc->si, 0, uv[0], seed[0]);
    uv[1] = unwrap_near(&pc->si, 1, uv[1], seed[1]);
    dead[0] = dead_dir(&pc->si, norms, 0);
    dead[1] = dead_dir(&pc->si, norms, 1);
    return d;
}

/* Where a parameter is undefined (pole), take it from the nearest defined neighbours. */
static void fill_poles(proj_ctx *pc, const unsigned char *bad, int dir)
{
    int n = pc->n;
    for (int i = 0; i < n; i++) {
        if (!bad[i]) continue;
        int lo = i - 1, hi = i + 1;
        while (lo >= 0 && bad[lo])
            lo--;
        while (hi < n && bad[hi])
            hi++;
        double x;
        if (lo >= 0 && hi < n) {
            double w = (pc->st[i] - pc->st[lo]) / (pc->st[hi] - pc->st[lo]);
            x = (1 - w) * pc->suv[2 * lo + dir] + w * pc->suv[2 * hi + dir];
        } else if (lo >= 0) {
            x = pc->suv[2 * lo + dir];
        } else if (hi < n) {
            x = pc->suv[2 * hi + dir];
        } else {
            continue;
        }
        pc->suv[2 * i + dir] = x;
    }
}

/* The sample nearest t (samples are sorted by parameter). */
static int nearest_sample(const proj_ctx *pc, double t)
{
    int lo = 0, hi = pc->n - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (pc->st[mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    return fabs(pc->st[hi] - t) < fabs(t - pc->st[lo]) ? hi : lo;
}

static void proj_fn(void *ctx, double t, double *dest)
{
    const proj_ctx *pc = ctx;
    int k = nearest_sample(pc, t);
    const double *seed = pc->suv + 2 * k;
    int dead[2];
    invert_seeded(pc, t, seed, pc->sd[k], dest, dead);
    for (int dir = 0; dir < 2; dir++)
        if (dead[dir]) {
            /* u undefined here: interpolate the neighbouring samples' value. */
            int lo = k, hi = k;
            if (pc->st[k] <= t && k + 1 < pc->n)
                hi = k + 1;
            else if (k > 0)
                lo = k - 1;
            double w = hi > lo ? (t - pc->st[lo]) / (pc->st[hi] - pc->st[lo]) : 0;
            dest[dir] = (1 - w) * pc->suv[2 * lo + dir] + w * pc->suv[2 * hi + dir];
        }
}

static double proj_error(void *ctx, double t, const double *fitted)
{
    const proj_ctx *pc = ctx;
    double p[3], q[3];
    crisp_curve_eval(pc->c, t, p);
    eval_wrapped(&pc->si, fitted, q, NULL, NULL);
    double e = dist3(p, q);
    if (e <= 0.5 * pc->tol) return e;
    /* The curve may lie off the surface (files give edges up to their tolerance away from the
     * faces: OCCT's bug22869_Spring.igs by 0.8 of the projection tolerance, which no fit could
     * then reach): compare with the image of its own projection. */
    double uv[2] = {fitted[0], fitted[1]};
    double d = newton(&pc->si, p, uv, NULL);
    if (d <= 0.25 * pc->tol) return e;
    double r[3];
    eval_wrapped(&pc->si, uv, r, NULL, NULL);
    return dist3(q, r);
}

/* The projection over [t0, t1]; the first sample starts from seed (when not NULL) instead of
 * the global search. */
static crisp_status project_range(const crisp_surface *s, const crisp_curve *c, double t0,
                                  double t1, double tol, const double *seed, crisp_curve **dest)
{
    const char *fn = "crisp_surface_project_curve";
    if (!s || !c || !dest || c->dim != 3)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL argument or curve not 3D", fn);
    if (!isfinite(t0) || !isfinite(t1) || !(t1 > t0) || !isfinite(tol) || !(tol > 0))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: range [%g, %g] must be non-empty and tol %g positive", fn, t0, t1,
                           tol);
    proj_ctx pc = {.c = c, .t0 = t0, .t1 = t1, .tol = tol};
    surf_info_init(s, &pc.si);
    /* The curve's kinks (interior knots of multiplicity >= degree) in (t0, t1) start the fit's
     * spans; smooth knots are left to the adaptive refinement. */
    int nk = 0, spans = 1;
    double *breaks = crisp_malloc_array((size_t)c->count + 1, sizeof *breaks);
    if (!breaks) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
    for (int i = c->degree + 1; i < c->count;) {
        int m = 1;
        while (i + m < c->count && c->knots[i + m] == c->knots[i])
            m++;
        double k = c->knots[i];
        if (k > t0 && k < t1) {
            spans++;
            if (m >= c->degree) breaks[nk++] = k;
        }
        i += m;
    }
    /* Samples (seeds for the fit, and the continuous path across seams): 4 per span of the
     * curve, 17 at least, bounded. */
    int n = spans * 4 + 1;
    if (n < 17) n = 17;
    if (n > 4097) n = 4097;
    pc.n = n;
    pc.st = crisp_malloc_array((size_t)n, sizeof *pc.st);
    pc.suv = crisp_malloc_array((size_t)n, 2 * sizeof *pc.suv);
    pc.sd = crisp_malloc_array((size_t)n, sizeof *pc.sd);
    unsigned char *bad = crisp_malloc_array((size_t)n, 2);
    crisp_status st = CRISP_OK;
    if (!pc.st || !pc.suv || !pc.sd || !bad) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
        goto out;
    }
    {
        int any_bad[2] = {0, 0};
        double ref[2] = {0, 0}; /* last reliable (u, v) for unwrapping */
        for (int i = 0; i < n; i++) {
            double t = t0 + (t1 - t0) * i / (n - 1), *uv = pc.suv + 2 * i;
            int dead[2];
            pc.st[i] = t;
            if (i == 0) {
                double first[2], p[3];
                crisp_curve_eval(c, t, p);
                double d0;
                if (seed) {
                    first[0] = seed[0], first[1] = seed[1];
                    d0 = newton(&pc.si, p, first, NULL);
                } else {
                    d0 = invert_global(&pc.si, p, first);
                }
                pc.sd[i] = invert_seeded(&pc, t, first, d0, uv, dead);
            } else {
                pc.sd[i] = invert_seeded(&pc, t, pc.suv + 2 * (i - 1), pc.sd[i - 1], uv, dead);
                uv[0] = unwrap_near(&pc.si, 0, uv[0], ref[0]);
                uv[1] = unwrap_near(&pc.si, 1, uv[1], ref[1]);
            }
            for (int dir = 0; dir < 2; dir++) {
                bad[2 * i + dir] = (unsigned char)dead[dir];
                any_bad[dir] |= bad[2 * i + dir];
                if (!bad[2 * i + dir] || i == 0) ref[dir] = uv[dir];
            }
        }
        for (int dir = 0; dir < 2; dir++) {
            if (!any_bad[dir]) continue;
            unsigned char *b1 = crisp_malloc_array((size_t)n, 1);
            if (!b1) {
                st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
                goto out;
            }
            for (int i = 0; i < n; i++)
                b1[i] = bad[2 * i + dir];
            fill_poles(&pc, b1, dir);
            crisp_free(b1);
        }
    }
    /* Of the continuous path's representatives (shifts by a period in closed directions), take
     * the one whose middle lies in [lo, hi): deterministic, and inside the domain when it fits. */
    for (int dir = 0; dir < 2; dir++) {
        if (!pc.si.closed[dir]) continue;
        double lo = INFINITY, hi = -INFINITY;
        for (int i = 0; i < n; i++) {
            double x = pc.suv[2 * i + dir];
            if (x < lo) lo = x;
            if (x > hi) hi = x;
        }
        double per = pc.si.period[dir], mid = 0.5 * (lo + hi);
        double k = floor((mid - pc.si.dom[2 * dir]) / per);
        /* a path on the seam itself (mid == hi end) goes to the low side */
        if (fabs(mid - (pc.si.dom[2 * dir] + (k + 1) * per)) <= 1e-12 * per) k += 1;
        if (k != 0)
            for (int i = 0; i < n; i++)
                pc.suv[2 * i + dir] -= k * per;
    }
    {
        crisp__fit_desc d = {.dim = 2,
                             .f = proj_fn,
                             .ctx = &pc,
                             .error = proj_error,
                             .error_ctx = &pc,
                             .t0 = t0,
                             .t1 = t1,
                             .tol = tol,
                             .max_spans = 4096 + nk,
                             .breaks = breaks,
                             .break_count = nk};
        st = crisp__fit_adaptive(&d, dest);
        if (st) crisp_error_prefix("%s", fn);
    }
out:
    crisp_free(breaks);
    crisp_free(pc.st);
    crisp_free(pc.suv);
    crisp_free(pc.sd);
    crisp_free(bad);
    return st;
}

crisp_status crisp_surface_project_curve(const crisp_surface *s, const crisp_curve *c, double t0,
                                         double t1, double tol, crisp_curve **dest)
{
    return project_range(s, c, t0, t1, tol, NULL, dest);
}

/* ---- projections that jump ----------------------------------------------------------------
 * Where the curve passes a point at which the surface's parameters jump (a collapsed side of a
 * patch or a pole whose neighbourhood the surface reaches from both ends of the domain, or a
 * curve lying between two sheets), no single continuous (u, v) curve follows it: the path of
 * seeded inversions is cut at the jumps (located by bisection, each side continued from its
 * own neighbour) and each piece is projected on its own, started from its side's (u, v). */

#define PIECE_SAMPLES 512

static double uv_step(const double a[2], const double b[2])
{
    return hypot(a[0] - b[0], a[1] - b[1]);
}

static int cmp_dbl(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

crisp_status crisp_surface_project_curve_pieces(const crisp_surface *s, const crisp_curve *c,
                                                double t0, double t1, double tol, int max_pieces,
                                                crisp_curve **dest, int *count)
{
    const char *fn = "crisp_surface_project_curve_pieces";
    if (!dest || !count || max_pieces < 1)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL argument", fn);
    *count = 0;
    crisp_status st = project_range(s, c, t0, t1, tol, NULL, &dest[0]);
    if (st != CRISP_ERR_LIMIT) {
        if (!st) *count = 1;
        return st;
    }
    if (max_pieces < 2) return st;
    char first_error[1024];
    snprintf(first_error, sizeof first_error, "%s", crisp_error_message());
    crisp_error_clear();
    proj_ctx pc = {.c = c, .t0 = t0, .t1 = t1, .tol = tol};
    surf_info_init(s, &pc.si);
    enum { N = PIECE_SAMPLES + 1 };
    double *ts = crisp_malloc_array(N, sizeof *ts), *uv = crisp_malloc_array(N, 2 * sizeof *uv);
    double *dist = crisp_malloc_array(N, sizeof *dist),
           *steps = crisp_malloc_array(N, sizeof *steps);
    double *cut = crisp_malloc_array((size_t)max_pieces + 1, sizeof *cut);
    double *cut_uv = crisp_malloc_array((size_t)max_pieces + 1, 2 * sizeof *cut_uv);
    if (!ts || !uv || !dist || !steps || !cut || !cut_uv) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
        goto out;
    }
    /* The path of seeded inversions. */
    for (int i = 0; i < N; i++) {
        int dead[2];
        ts[i] = t0 + (t1 - t0) * i / (N - 1);
        if (i == 0) {
            double p[3];
            crisp_curve_eval(c, ts[0], p);
            dist[0] = invert_global(&pc.si, p, uv);
        } else {
            dist[i] = invert_seeded(&pc, ts[i], uv + 2 * (i - 1), dist[i - 1], uv + 2 * i, dead);
        }
    }
    for (int i = 0; i + 1 < N; i++)
        steps[i] = uv_step(uv + 2 * i, uv + 2 * i + 2);
    double sorted[N];
    memcpy(sorted, steps, (N - 1) * sizeof *sorted);
    qsort(sorted, N - 1, sizeof *sorted, cmp_dbl);
    double size = fmax(pc.si.dom[1] - pc.si.dom[0], pc.si.dom[3] - pc.si.dom[2]);
    double limit = fmax(50 * sorted[(N - 1) / 2], 1e-3 * size);
    int ncut = 0;
    for (int i = 0; i + 1 < N && ncut + 1 < max_pieces; i++) {
        if (!(steps[i] > limit)) continue;
        double a = ts[i], b = ts[i + 1], ua[2] = {uv[2 * i], uv[2 * i + 1]},
               ub[2] = {uv[2 * i + 2], uv[2 * i + 3]};
        double da = dist[i];
        for (int it = 0; it < 60; it++) {
            double m = 0.5 * (a + b), um[2];
            int dead[2];
            double dm = invert_seeded(&pc, m, ua, da, um, dead);
            if (uv_step(um, ua) <= uv_step(um, ub))
                a = m, ua[0] = um[0], ua[1] = um[1], da = dm;
            else
                b = m, ub[0] = um[0], ub[1] = um[1];
        }
        /* A true jump stays a jump however small the bracket (a fast continuous turn does not). */
        if (!(uv_step(ua, ub) > 0.5 * limit)) continue;
        cut[ncut] = 0.5 * (a + b);
        cut_uv[2 * ncut] = ub[0], cut_uv[2 * ncut + 1] = ub[1];
        ncut++;
    }
    if (ncut == 0) {
        st = crisp_error(CRISP_ERR_LIMIT, "%s", first_error);
        goto out;
    }
    double eps = 1e-9 * (t1 - t0);
    st = CRISP_OK;
    for (int k = 0; k <= ncut && !st; k++) {
        double a = k ? cut[k - 1] + eps : t0, b = k < ncut ? cut[k] - eps : t1;
        if (!(b > a)) continue;
        /* A piece that is a point (the curve starting at a collapsed corner) is left out: the
         * gap it leaves lies where the surface collapses. */
        double pa[3], pb[3], pm[3];
        crisp_curve_eval(c, a, pa);
        crisp_curve_eval(c, b, pb);
        crisp_curve_eval(c, 0.5 * (a + b), pm);
        if (dist3(pa, pb) <= tol && dist3(pa, pm) <= tol && (ncut > 0)) continue;
        st = project_range(s, c, a, b, tol, k ? cut_uv + 2 * (k - 1) : NULL, &dest[*count]);
        if (!st) (*count)++;
    }
    if (!st && *count == 0)
        st = crisp_error(CRISP_ERR_NUMERIC, "%s: the curve projects to a point", fn);
    if (st) {
        for (int k = 0; k < *count; k++) {
            crisp_curve_destroy(dest[k]);
            dest[k] = NULL; /* the caller may destroy its array too (fuzz_step found it) */
        }
        *count = 0;
        crisp_error_prefix("%s: %d jumps cut", fn, ncut);
    }
out:
    crisp_free(ts);
    crisp_free(uv);
    crisp_free(dist);
    crisp_free(steps);
    crisp_free(cut);
    crisp_free(cut_uv);
    return st;
}
