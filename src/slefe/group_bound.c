/* Group bounds: how far a B-spline surface lies from its control net over a rectangle of knot
 * spans, from the net's second differences, without extracting a Bézier patch (issue 12).
 *
 * Follows the idea of Nairn, Peters & Lutterkort ("Sharp, quantitative bounds on the distance
 * between a polynomial piece and its Bézier control polygon", CAGD 16, 1999) and Reif ("Best
 * bounds on the approximation of polynomials and splines by their control structure", CAGD 17,
 * 2000): the distance is a sum of second differences times nonnegative kernels. The derivation
 * used here (written out so it can be checked; no code or table is taken from those papers):
 *
 * Curve case, degree p, knots t, coefficients c_i, Greville abscissae xi_i = (t_{i+1} + ... +
 * t_{i+p}) / p, control polygon l = the piecewise-linear interpolant of (xi_i, c_i), slope changes
 * delta_j = (c_{j+1} - c_j) / (xi_{j+1} - xi_j) - (c_j - c_{j-1}) / (xi_j - xi_{j-1}).
 * B-splines reproduce linear functions with the Greville abscissae (sum N_i = 1, sum xi_i N_i =
 * t), so for t in span k (N_{k-p} .. N_k the nonzero ones) and ANY slope g
 *     s(t) - l(t) = sum_i N_i(t) (c_i - l(t) - g (xi_i - t)).
 * Take g = the slope of the polygon piece [xi_m, xi_{m+1}] that contains t. Then c_i - l(t) -
 * g (xi_i - t) = l(xi_i) - (the line of that piece at xi_i) = sum over the breakpoints xi_j
 * between the piece and xi_i of delta_j (xi_i - xi_j) (signs folded), so with N_i >= 0
 *     |s(t) - l(t)| <= sum_i N_i(t) w_i,   w_i = sum_{j beyond the piece toward xi_i} |delta_j|
 * |xi_i - xi_j|. The right side is a spline on span k; its Bézier coefficients there are sum_i w_i
 * beta_{i,l} (beta: the Bézier coefficients of N_i on span k, blossoms of N_i at t_k^(p-l)
 * t_{k+1}^l, by de Boor's algorithm), so it is at most max_l sum_i w_i beta_{i,l} (convex hull).
 * The bound is the max of that over the pieces meeting the span. For uniform cubics it is max
 * |Delta^2 c| / 6, which is attained (a parabola), so the bound is sharp there.
 *
 * Surface case, S = sum c_ij N_i(u) M_j(v), net L = the piecewise-bilinear interpolant of c_ij at
 * (xi_i, eta_j) (hat functions H_i, G_j):
 *     S - L = sum_j M_j(v) [sum_i c_ij (N_i(u) - H_i(u))] + sum_i H_i(u) [sum_j c_ij (M_j(v) -
 * G_j(v))]. For fixed v the first bracket is a curve error in u whose coefficients are convex
 * combinations of the rows the v-spans touch, so its delta_j is at most the largest |delta^u| of
 * those rows; the second is a convex combination of column curve errors in v over the columns whose
 * hats reach the u-range. So |S - L| <= (u bound with |delta^u| maxed over those rows) + (v bound
 * with |delta^v| maxed over those columns), per homogeneous coordinate. A rational surface is
 * bounded in homogeneous coordinates; after a linear map (view_proj) the same holds for the
 * mapped net, so the screen bound maps the net and divides by a guaranteed lower bound of W.
 *
 * Drawing the net as triangles (each net quad cut along a diagonal) adds, per coordinate, a
 * quarter of the quad's twist |c00 - c10 - c01 + c11| (bilinear versus linear on a triangle).
 * A coarser piece (one bilinear quad through the group's four corner net points) adds the
 * largest distance from the net's vertices to that quad (the difference of a piecewise-bilinear
 * and a bilinear function takes its extremes at the net's vertices) plus that quad's twist.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/slefe.h"

#define MAXP (CRISP_SLEFE_MAX_DEGREE + 1)

/* Knot index of the `span`-th non-empty span (t_k < t_{k+1}, p <= k < n), or -1. */
static int span_knot(const double *t, int p, int n, int span)
{
    for (int k = p; k < n; k++)
        if (t[k] < t[k + 1] && span-- == 0) return k;
    return -1;
}

/* beta[i - (k - p)][l]: Bézier coefficients of N_i (i = k-p..k) on [x0, x1] inside span k: the
 * blossom of N_i at (x0^(p-l), x1^l), by de Boor's algorithm on all p + 1 unit vectors at once. */
static void span_extraction(const double *t, int p, int k, double x0, double x1,
                            double beta[MAXP][MAXP])
{
    for (int l = 0; l <= p; l++) {
        double x[MAXP];
        for (int r = 0; r < p; r++)
            x[r] = r < p - l ? x0 : x1;
        double d[MAXP][MAXP];
        for (int i = 0; i <= p; i++)
            for (int c = 0; c <= p; c++)
                d[i][c] = i == c;
        for (int r = 1; r <= p; r++)
            for (int i = p; i >= r; i--) {
                int gi = k - p + i;
                double den = t[gi + p + 1 - r] - t[gi];
                double a = den > 0 ? (x[r - 1] - t[gi]) / den : 0;
                for (int c = 0; c <= p; c++)
                    d[i][c] = (1 - a) * d[i - 1][c] + a * d[i][c];
            }
        for (int c = 0; c <= p; c++)
            beta[c][l] = d[p][c];
    }
}

static double direction_bound(const double *t, int p, int n, const double *xi, const double *adelta,
                              int span0, int span1)
{
    double worst = 0;
    int k = span_knot(t, p, n, span0);
    for (int s = span0; s <= span1; s++) {
        if (k < 0) return -1;
        /* Polygon pieces [xi_m, xi_{m+1}] that overlap [t_k, t_{k+1}]; on each overlap the
         * piece's slope serves as g (the overlaps cover the span; at a shared end either
         * one-sided slope is valid). */
        for (int m = 0; m + 1 < n; m++) {
            double a = xi[m], b = xi[m + 1];
            double x0 = fmax(a, t[k]), x1 = fmin(b, t[k + 1]);
            if (!(x0 < x1)) continue;
            double beta[MAXP][MAXP];
            span_extraction(t, p, k, x0, x1, beta);
            double w[MAXP];
            for (int ii = 0; ii <= p; ii++) {
                int i = k - p + ii;
                double sum = 0;
                if (xi[i] > b)
                    for (int j = m + 1; j < n - 1 && xi[j] < xi[i]; j++)
                        sum += adelta[j] * (xi[i] - xi[j]);
                else if (xi[i] < a)
                    for (int j = m; j > 0 && xi[j] > xi[i]; j--)
                        sum += adelta[j] * (xi[j] - xi[i]);
                w[ii] = sum;
            }
            for (int l = 0; l <= p; l++) {
                double sum = 0;
                for (int ii = 0; ii <= p; ii++)
                    sum += w[ii] * fmax(beta[ii][l], 0);
                if (sum > worst) worst = sum;
            }
        }
        for (k++; k < n && !(t[k] < t[k + 1]); k++) {
        }
        if (k >= n) k = -1;
    }
    return worst;
}

static void greville(const double *t, int p, int n, double *xi)
{
    for (int i = 0; i < n; i++) {
        double s = 0;
        for (int r = 1; r <= p; r++)
            s += t[i + r];
        xi[i] = s / p;
    }
}

/* The control point (homogeneous) of the net, possibly mapped. */
typedef struct net {
    const crisp_surface *s;
    const crisp_mat4 *m; /* NULL: as is */
} net;

static void net_point(const net *nt, int i, int j, double dest[4])
{
    const double *c = nt->s->cpw + 4 * ((size_t)j * nt->s->count_u + i);
    if (!nt->m) {
        memcpy(dest, c, 4 * sizeof(double));
        return;
    }
    const crisp_mat4 *M = nt->m; /* column-major: (*M)[column][row] */
    for (int r = 0; r < 4; r++)
        dest[r] = (*M)[0][r] * c[0] + (*M)[1][r] * c[1] + (*M)[2][r] * c[2] + (*M)[3][r] * c[3];
}

typedef struct range {
    int ku0, ku1, kv0, kv1; /* knot indices of the first and last spans */
    int i0, i1, j0, j1;     /* net columns and rows that reach the group */
} range;

static crisp_status group_range(const crisp_surface *s, int iu0, int iu1, int iv0, int iv1,
                                range *g)
{
    if (!s || iu0 < 0 || iv0 < 0 || iu1 < iu0 || iv1 < iv0)
        return crisp_error(CRISP_ERR_INVALID_ARG, "group bound: span range u %d..%d, v %d..%d", iu0,
                           iu1, iv0, iv1);
    g->ku0 = span_knot(s->knots_u, s->degree_u, s->count_u, iu0);
    g->ku1 = span_knot(s->knots_u, s->degree_u, s->count_u, iu1);
    g->kv0 = span_knot(s->knots_v, s->degree_v, s->count_v, iv0);
    g->kv1 = span_knot(s->knots_v, s->degree_v, s->count_v, iv1);
    if (g->ku0 < 0 || g->ku1 < 0 || g->kv0 < 0 || g->kv1 < 0)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "group bound: span range u %d..%d, v %d..%d is outside the surface", iu0,
                           iu1, iv0, iv1);
    g->i0 = g->ku0 - s->degree_u, g->i1 = g->ku1;
    g->j0 = g->kv0 - s->degree_v, g->j1 = g->kv1;
    return CRISP_OK;
}

/* The bound per coordinate (4) of the net nt over the group. CRISP_ERR_NUMERIC on coincident
 * Greville abscissae (a knot of multiplicity p + 1 inside: the net has a jump there). */
static crisp_status bound_net(const net *nt, const range *g, double dest[4])
{
    const crisp_surface *s = nt->s;
    int p = s->degree_u, q = s->degree_v, nu = s->count_u, nv = s->count_v;
    /* Scratch on the stack for nets of up to 512 x 512 points (the planner calls this per
     * frame and allocates nothing in a steady state). */
    double local[2048];
    size_t need = (size_t)(2 * (nu + nv));
    double *xi = need <= 2048 ? local : malloc(sizeof(double) * need);
    if (!xi) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a group bound");
    double *eta = xi + nu, *adu = eta + nv, *adv = adu + nu;
    greville(s->knots_u, p, nu, xi);
    greville(s->knots_v, q, nv, eta);
    for (int i = 0; i + 1 < nu; i++)
        if (!(xi[i + 1] > xi[i])) {
            if (xi != local) free(xi);
            return crisp_error(CRISP_ERR_NUMERIC,
                               "group bound: coincident Greville abscissae in u at %d", i);
        }
    for (int j = 0; j + 1 < nv; j++)
        if (!(eta[j + 1] > eta[j])) {
            if (xi != local) free(xi);
            return crisp_error(CRISP_ERR_NUMERIC,
                               "group bound: coincident Greville abscissae in v at %d", j);
        }
    /* The u pieces of a group reach columns whose Greville abscissae bracket [t_ku0, t_ku1+1]:
     * widen i0..i1 by the pieces that meet the range (all inside ku0-p..ku1, kept as is). */
    for (int c = 0; c < 4; c++) {
        for (int i = 0; i < nu; i++)
            adu[i] = 0;
        for (int j = 0; j < nv; j++)
            adv[j] = 0;
        /* u: slope changes at interior columns, maxed over the rows j0..j1. */
        for (int j = g->j0; j <= g->j1; j++)
            for (int i = 1; i + 1 < nu; i++) {
                double a[4], b[4], d[4];
                net_point(nt, i - 1, j, a);
                net_point(nt, i, j, b);
                net_point(nt, i + 1, j, d);
                double dl =
                    (d[c] - b[c]) / (xi[i + 1] - xi[i]) - (b[c] - a[c]) / (xi[i] - xi[i - 1]);
                adu[i] = fmax(adu[i], fabs(dl));
            }
        for (int i = g->i0; i <= g->i1; i++)
            for (int j = 1; j + 1 < nv; j++) {
                double a[4], b[4], d[4];
                net_point(nt, i, j - 1, a);
                net_point(nt, i, j, b);
                net_point(nt, i, j + 1, d);
                double dl =
                    (d[c] - b[c]) / (eta[j + 1] - eta[j]) - (b[c] - a[c]) / (eta[j] - eta[j - 1]);
                adv[j] = fmax(adv[j], fabs(dl));
            }
        int su0 = 0, sv0 = 0;
        for (int k = p; k < g->ku0; k++)
            su0 += s->knots_u[k] < s->knots_u[k + 1];
        for (int k = q; k < g->kv0; k++)
            sv0 += s->knots_v[k] < s->knots_v[k + 1];
        int su1 = su0, sv1 = sv0;
        for (int k = g->ku0 + 1; k <= g->ku1; k++)
            su1 += s->knots_u[k] < s->knots_u[k + 1];
        for (int k = g->kv0 + 1; k <= g->kv1; k++)
            sv1 += s->knots_v[k] < s->knots_v[k + 1];
        double bu = direction_bound(s->knots_u, p, nu, xi, adu, su0, su1);
        double bv = direction_bound(s->knots_v, q, nv, eta, adv, sv0, sv1);
        /* Rounding: the differences and sums above carry relative errors of a few ulps of the
         * coordinates involved; 1e-12 of the largest coordinate covers them. */
        double big = 0;
        for (int j = g->j0; j <= g->j1; j++)
            for (int i = g->i0; i <= g->i1; i++) {
                double a[4];
                net_point(nt, i, j, a);
                big = fmax(big, fabs(a[c]));
            }
        dest[c] = (bu + bv) * (1 + 1e-12) + 1e-12 * big;
    }
    if (xi != local) free(xi);
    return CRISP_OK;
}

crisp_status crisp_slefe_group_bound(const crisp_surface *s, int iu0, int iu1, int iv0, int iv1,
                                     double dest[4])
{
    range g;
    crisp_status st = group_range(s, iu0, iu1, iv0, iv1, &g);
    if (st) return st;
    net nt = {s, NULL};
    return bound_net(&nt, &g, dest);
}

crisp_status crisp_slefe_group_screen(const crisp_surface *s, int iu0, int iu1, int iv0, int iv1,
                                      const crisp_slefe_view *view,
                                      crisp_slefe_group_screen_bound *dest)
{
    range g;
    crisp_status st = group_range(s, iu0, iu1, iv0, iv1, &g);
    if (st) return st;
    net nt = {s, &view->view_proj};
    double e[4];
    if ((st = bound_net(&nt, &g, e))) return st;
    /* The mapped net over the group: W range, NDC extent, twists, the corner quad's deviation. */
    double wmin = INFINITY, xmax = 0, ymax = 0, lo[2] = {INFINITY, INFINITY},
           hi[2] = {-INFINITY, -INFINITY};
    double twist[4] = {0, 0, 0, 0}, quad[4] = {0, 0, 0, 0};
    double c00[4], c10[4], c01[4], c11[4];
    net_point(&nt, g.i0, g.j0, c00);
    net_point(&nt, g.i1, g.j0, c10);
    net_point(&nt, g.i0, g.j1, c01);
    net_point(&nt, g.i1, g.j1, c11);
    double local[1024];
    size_t need = (size_t)(s->count_u + s->count_v);
    double *xi = need <= 1024 ? local : malloc(sizeof(double) * need);
    if (!xi) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a group bound");
    double *eta = xi + s->count_u;
    greville(s->knots_u, s->degree_u, s->count_u, xi);
    greville(s->knots_v, s->degree_v, s->count_v, eta);
    for (int j = g.j0; j <= g.j1; j++)
        for (int i = g.i0; i <= g.i1; i++) {
            double a[4];
            net_point(&nt, i, j, a);
            wmin = fmin(wmin, a[3]);
            if (!(a[3] > 0)) continue;
            double x = a[0] / a[3], y = a[1] / a[3];
            xmax = fmax(xmax, fabs(x)), ymax = fmax(ymax, fabs(y));
            lo[0] = fmin(lo[0], x), hi[0] = fmax(hi[0], x), lo[1] = fmin(lo[1], y),
            hi[1] = fmax(hi[1], y);
            double su = (xi[i] - xi[g.i0]) / (xi[g.i1] - xi[g.i0]),
                   sv = (eta[j] - eta[g.j0]) / (eta[g.j1] - eta[g.j0]);
            for (int c = 0; c < 4; c++) {
                double b = (1 - sv) * ((1 - su) * c00[c] + su * c10[c]) +
                           sv * ((1 - su) * c01[c] + su * c11[c]);
                quad[c] = fmax(quad[c], fabs(a[c] - b));
            }
            if (i < g.i1 && j < g.j1) {
                double b10[4], b01[4], b11[4];
                net_point(&nt, i + 1, j, b10);
                net_point(&nt, i, j + 1, b01);
                net_point(&nt, i + 1, j + 1, b11);
                for (int c = 0; c < 4; c++)
                    twist[c] = fmax(twist[c], 0.25 * fabs(a[c] - b10[c] - b01[c] + b11[c]));
            }
        }
    if (xi != local) free(xi);
    for (int c = 0; c < 4; c++)
        quad[c] += 0.25 * fabs(c00[c] - c10[c] - c01[c] + c11[c]);
    /* |X/W - X_L/W_L| <= (eX + |x_L| eW) / (W_L - eW), x_L in the hull of the net's x. */
    double ex[3] = {e[0] + twist[0], e[0] + quad[0], e[0]};
    double ey[3] = {e[1] + twist[1], e[1] + quad[1], e[1]};
    double ew[3] = {e[3] + twist[3], e[3] + quad[3], e[3]};
    double px[3];
    for (int k = 0; k < 3; k++) {
        double den = wmin - ew[k];
        if (!(den > 0) || !isfinite(den))
            return crisp_error(CRISP_ERR_NUMERIC,
                               "group bound: W of the group is not bounded away from 0 (%g)", den);
        double dx = (ex[k] + xmax * ew[k]) / den, dy = (ey[k] + ymax * ew[k]) / den;
        px[k] = fmax(dx * 0.5 * view->width, dy * 0.5 * view->height) * (1 + 1e-9);
    }
    dest->net_px = px[2];
    dest->triangles_px = px[0];
    dest->quad_px = px[1];
    /* Screen box of the surface over the group: the group's spans lie in the convex hull of the
     * net points i0..i1 x j0..j1 (local support), and W > 0 there. */
    dest->box_px[0] = (lo[0] + 1) * 0.5 * view->width;
    dest->box_px[1] = (1 - hi[1]) * 0.5 * view->height;
    dest->box_px[2] = (hi[0] + 1) * 0.5 * view->width;
    dest->box_px[3] = (1 - lo[1]) * 0.5 * view->height;
    return CRISP_OK;
}
