/* A sound screen-space error bound for the uniform tessellation of a patch, and the smallest
 * tessellation level it accepts. The iPASS rule tau = ceil(m sqrt(w_px / eps)) (docs/design.md
 * section 4) assumes the SLEFE width falls as 1/m^2 from m = 3 on, which holds only asymptotically
 * (1.2x off for cubics, more for higher degrees), and it measures the bilinear enclosure while the
 * tessellation draws triangles, whose difference from the bilinear interpolant is a quarter of
 * the cell's twist. bench_slefe's "tau check" shows both effects (up to about 3x eps).
 *
 * The bound here: with clip-space X, Y, W (polynomials) and a cell of the tau x tau grid cut into
 * two triangles, a surface point H(s, t) and the triangle point H_tri with the same barycentrics
 * in clip space (which projects onto the drawn screen triangle) differ in screen x by
 *   |X/W - X_tri/W_tri| = |dX - x_tri dW| / W,   dX = X - X_tri, dW = W - W_tri,
 * and |dX| <= (bilinear interpolation error of X) + |twist| / 4, where the bilinear error is at
 * most the SLEFE width at m = tau (the surface and the interpolant of its grid values both lie in
 * the bilinear enclosure) or, for any tau, the classical (h^2 / 8) (|X_ss| + |X_tt|) with second
 * derivatives bounded by the control points' second differences; the twist of a cell is at most
 * h^2 du dv max |mixed difference|. W is bounded below per tile, x_tri by the tile's box.
 *
 * Centred screen coordinates (issue 12). The distance is the same in any screen coordinates that
 * differ by a translation, and translating NDC by -c is linear in clip space (X' = X - c_x W,
 * Y' = Y - c_y W, W unchanged), so the bounds are formed with c the centre of the patch's
 * projected control points: |x_tri| is then about the patch's own half-extent instead of its
 * distance from the image centre. That matters where W is far from linear: for a rational patch
 * W = w(s, t) W_cam and the weight's curvature enters |x_tri| |dW| (impeller x 49: patches 30-40
 * px across, far off axis, got a bound of 130 px at tau 1 and levels 10-16).
 *
 * The rasterizer's point (issue 12, docs/status/issue-12-rational.md). The triangle point above,
 * H_tri = sum l_k H(x_k), is a point of the drawn screen triangle, but the rasterizer interpolates
 * the vertices' clip positions Q(x_k) = H(x_k) / w(x_k) (the camera's W, not the weight) with the
 * barycentrics l: its screen point is sum mu_k q_k (q_k the vertices' screen points,
 * mu_k = l_k Q_W,k / sum l_j Q_W,j), H_tri's is sum nu_k q_k with nu_k = mu_k w_k / w_bar,
 * w_bar = sum mu_j w_j. Their difference is sum mu_k (w_k - w_bar) (q_k - q_bar) / w_bar, a
 * covariance under the distribution mu over the three vertices divided by w_bar: at most
 * (w_max - w_min) (q_max - q_min) / (4 w_min) per screen axis (Cauchy-Schwarz and Popoviciu's
 * variance bound, range^2 / 4). This term is added for patches whose weights differ: per tile,
 * from the SLEFE of the weight and the tile's screen box; in the classic bound, from the
 * weight's and X's, W's derivative bounds over a cell (|x(b) - x(a)| <= (|dX| + |x| |dW|) / W
 * along the segment): it is O(h^2) like the rest, so the classic bound still falls as 1 / tau^2.
 * test_slefe_rational.c measures it; without the term the level fails there. */
#include "core/compiler.h"
#include "slefe_internal.h"

#include <string.h>

#define MAXD CRISP_SLEFE_MAX_DEGREE
#define MAXM CRISP_SLEFE_MAX_SEGMENTS
#define EUCLID_PIECES_RATIO 1.1

/* Second-difference bounds of clip coordinate r over the control net: dss, dtt (pure second
 * differences scaled by d(d-1)) and dst (mixed, scaled by du dv): bounds on |X_ss|, |X_tt|,
 * |X_st| over the patch, widened for rounding. */
static void derivative_bounds(const double *clip, int du, int dv, int r, double *dss, double *dtt,
                              double *dst)
{
    double a = 0, b = 0, c = 0, mag = 0;
    int n = du + 1;
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++) {
            double v = clip[(j * n + i) * 4 + r];
            mag = crisp__max(mag, fabs(v));
            if (i + 2 <= du)
                a = crisp__max(
                    a, fabs(v - 2 * clip[(j * n + i + 1) * 4 + r] + clip[(j * n + i + 2) * 4 + r]));
            if (j + 2 <= dv)
                b = crisp__max(b, fabs(v - 2 * clip[((j + 1) * n + i) * 4 + r] +
                                       clip[((j + 2) * n + i) * 4 + r]));
            if (i + 1 <= du && j + 1 <= dv)
                c = crisp__max(c, fabs(v - clip[(j * n + i + 1) * 4 + r] -
                                       clip[((j + 1) * n + i) * 4 + r] +
                                       clip[((j + 1) * n + i + 1) * 4 + r]));
        }
    double round = 16.0 * DBL_EPSILON * mag;
    *dss = du * (du - 1) * (a + round);
    *dtt = dv * (dv - 1) * (b + round);
    *dst = du * dv * (c + round);
}

/* derivative_bounds of the net clip through nb (formed once; nb NULL: each time). */
static void net_derivs(crisp__slefe_net_bounds *nb, const double *clip, int du, int dv, int r,
                       double *dss, double *dtt, double *dst)
{
    if (!nb) {
        derivative_bounds(clip, du, dv, r, dss, dtt, dst);
        return;
    }
    double *d = nb->d[r];
    if (!(nb->formed >> r & 1u)) {
        derivative_bounds(clip, du, dv, r, &d[0], &d[1], &d[2]);
        nb->formed |= 1u << r;
    }
    *dss = d[0], *dtt = d[1], *dst = d[2];
}

/* First-difference bounds of coordinate r over the control net: bounds on |X_s|, |X_t| over the
 * patch (the hodograph's control points), widened for rounding. */
static void speed_bounds(const double *c, int du, int dv, int r, double *ds, double *dt)
{
    double a = 0, b = 0, mag = 0;
    int n = du + 1;
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++) {
            double v = c[(j * n + i) * 4 + r];
            mag = crisp__max(mag, fabs(v));
            if (i + 1 <= du) a = crisp__max(a, fabs(c[(j * n + i + 1) * 4 + r] - v));
            if (j + 1 <= dv) b = crisp__max(b, fabs(c[((j + 1) * n + i) * 4 + r] - v));
        }
    double round = 8.0 * DBL_EPSILON * mag;
    *ds = du * (a + round);
    *dt = dv * (b + round);
}

/* speed_bounds through nb, slot k (the clip net's coordinate r = k, or k = 2: the weights',
 * coordinate 3 of c). */
static void net_speeds(crisp__slefe_net_bounds *nb, int k, const double *c, int du, int dv, int r,
                       double *ds, double *dt)
{
    if (!nb) {
        speed_bounds(c, du, dv, r, ds, dt);
        return;
    }
    double *d = nb->s[k];
    if (!(nb->formed >> (4 + k) & 1u)) {
        speed_bounds(c, du, dv, r, &d[0], &d[1]);
        nb->formed |= 1u << (4 + k);
    }
    *ds = d[0], *dt = d[1];
}

/* The weights of a (sub-)patch: its homogeneous control points (coordinate 3 is the weight) and
 * their range; cpw is NULL when the weights are all equal (no redistribution term, see the top
 * comment). */
typedef struct weights {
    const double *cpw;
    double lo, hi;
    /* the difference bounds of the clip-space net these weights go with and of the weights,
     * kept as they are formed (NULL: formed at each use) */
    crisp__slefe_net_bounds *nb;
} weights;

static weights weights_of(const crisp_bezier_patch *p, const double *cpw)
{
    weights w = {NULL, 1.0, 1.0, NULL};
    if (!p->rational) return w;
    int n = (p->du + 1) * (p->dv + 1);
    w.lo = w.hi = cpw[3];
    for (int i = 1; i < n; i++) {
        w.lo = crisp__min(w.lo, cpw[i * 4 + 3]);
        w.hi = crisp__max(w.hi, cpw[i * 4 + 3]);
    }
    if (w.hi != w.lo) w.cpw = cpw;
    return w;
}

/* view with NDC translated by -c, c the centre of p's projected control points (those in front
 * of the eye; c = 0 when none is): the bounds are formed in these coordinates (top comment). */
static void centred_view(const crisp_bezier_patch *p, const crisp_slefe_view *view,
                         crisp_slefe_view *dest)
{
    *dest = *view;
    const double(*m)[4] = (const double(*)[4])view->view_proj;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    int n = (p->du + 1) * (p->dv + 1);
    for (int i = 0; i < n; i++) {
        const double *v = p->cpw + i * 4;
        double h[4];
        for (int r = 0; r < 4; r++)
            h[r] = m[0][r] * v[0] + m[1][r] * v[1] + m[2][r] * v[2] + m[3][r] * v[3];
        if (!(h[3] > 0.0)) continue;
        for (int a = 0; a < 2; a++) {
            lo[a] = crisp__min(lo[a], h[a] / h[3]);
            hi[a] = crisp__max(hi[a], h[a] / h[3]);
        }
    }
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1])) return;
    /* within [-2, 2] (beyond, the patch is mostly off screen): the rounding of the translated
     * rows then stays of the order of view_proj's own */
    double c[2] = {crisp__max(-2.0, crisp__min(2.0, 0.5 * (lo[0] + hi[0]))),
                   crisp__max(-2.0, crisp__min(2.0, 0.5 * (lo[1] + hi[1])))};
    for (int col = 0; col < 4; col++)
        for (int a = 0; a < 2; a++)
            dest->view_proj[col][a] = m[col][a] - c[a] * m[col][3];
}

/* Largest |q| over q in [xl, xu] / [wl, wu], wl > 0. */
static double max_abs_ratio(double xl, double xu, double wl, double wu)
{
    double ql, qu;
    crisp__slefe_divide(xl, xu, wl, wu, &ql, &qu);
    return crisp__max(fabs(ql), fabs(qu));
}

/* The bound from derivative bounds alone (any tau), over the whole patch. */
/* The bound from derivative bounds alone, for tu x tv segments, over the whole patch. */
static crisp_status error_classic2(const char *fn, const crisp_bezier_patch *p, const weights *wt,
                                   const crisp_slefe_view *view, const double *clip,
                                   const double *hl, const double *hh, int tu, int tv, double *dest)
{
    if (!(hl[3] > 0.0))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "%s: clip-space W of the control points reaches %g (the patch may "
                           "reach the eye plane: split or cull it)",
                           fn, hl[3]);
    double hu = 1.0 / tu, hv = 1.0 / tv, e[4];
    for (int r = 0; r < 4; r += r == 1 ? 2 : 1) { /* X, Y, W */
        double dss, dtt, dst;
        net_derivs(wt->nb, clip, p->du, p->dv, r, &dss, &dtt, &dst);
        e[r] = hu * hu * dss / 8.0 + hv * hv * dtt / 8.0 + hu * hv * dst / 4.0;
    }
    double ax = max_abs_ratio(hl[0], hh[0], hl[3], hh[3]);
    double ay = max_abs_ratio(hl[1], hh[1], hl[3], hh[3]);
    double ex = (e[0] + ax * e[3]) / hl[3], ey = (e[1] + ay * e[3]) / hl[3];
    if (wt->cpw) {
        /* The rasterizer's point: over a cell the weight varies by at most hu |w_s| + hv |w_t|
         * and the screen x by at most (hu |X_s| + hv |X_t| + |x| (hu |W_s| + hv |W_t|)) / W;
         * their product over 4 w_min. */
        if (!(wt->lo > 0.0)) {
            *dest = INFINITY;
            return CRISP_OK;
        }
        double ws, wtt, xs, xt, ys, yt, cs, ct;
        net_speeds(wt->nb, 2, wt->cpw, p->du, p->dv, 3, &ws, &wtt);
        net_speeds(wt->nb, 0, clip, p->du, p->dv, 0, &xs, &xt);
        net_speeds(wt->nb, 1, clip, p->du, p->dv, 1, &ys, &yt);
        net_speeds(wt->nb, 3, clip, p->du, p->dv, 3, &cs, &ct);
        double q = (hu * ws + hv * wtt) / (4.0 * wt->lo) * (1.0 + 1e-12), wd = hu * cs + hv * ct;
        ex += q * (hu * xs + hv * xt + ax * wd) / hl[3];
        ey += q * (hu * ys + hv * yt + ay * wd) / hl[3];
    }
    *dest = crisp__max(ex * 0.5 * view->width, ey * 0.5 * view->height) * (1.0 + 1e-12);
    return CRISP_OK;
}

/* The curvature sums (quotient.c) of the Euclidean clip coordinates X', Y', W over the whole
 * patch (k = 1) and its 2 x 2 and 4 x 4 pieces, formed once per level search: the search asks for
 * them in turn (the whole patch first, the pieces while the bound is above its target), and the
 * depth bound along the view (depth_bound.c) needs W's (crisp__slefe_level_info). */
typedef crisp__slefe_euclid_sums euclid_sums;

/* For a patch whose weights vary: the bound at tau = 1 from the curvature of the Euclidean clip
 * coordinates (quotient.c), the "joint" bound of the top comment's two terms. The rasterizer draws
 * T = sum l_k Q(x_k), Q = H / w the clip point of the surface point (the camera's W), for the
 * parameters x = sum l_k x_k, so with S = Q(x): x_T - x_S = ((T_x - S_x) - x_S (T_w - S_w)) / T_w,
 * |T_r - S_r| <= K_r h^2 / 8 (quotient.c), T_w >= the least W of the patch, which is at least
 * min_k H_w,k / w_k, and |x_S| <= max_k |H_x,k / H_w,k| (the projected patch lies in the hull of
 * its projected control points where every H_w,k > 0). The bound at tau is c1 / tau^2 exactly.
 * INFINITY where a weight or a control point's W is not positive. sums: what earlier calls for
 * the same patch formed (read and extended). */
static double euclid_c1(const crisp_bezier_patch *p, const weights *wt,
                        const crisp_slefe_view *view, const double *clip, const double *err,
                        double target, euclid_sums *sums)
{
    int n = (p->du + 1) * (p->dv + 1);
    double c[(MAXD + 1) * (MAXD + 1) * 4], wlo = INFINITY, ax = 0, ay = 0, w1 = 0;
    for (int i = 0; i < n; i++) {
        const double *h = clip + 4 * i;
        double w = wt->cpw[4 * i + 3];
        if (!(w > 0.0) || !(h[3] > err[3])) return INFINITY;
        c[4 * i] = h[0], c[4 * i + 1] = h[1], c[4 * i + 2] = h[3], c[4 * i + 3] = w;
        wlo = crisp__min(wlo, (h[3] - err[3]) / w);
        ax = crisp__max(ax, (fabs(h[0]) + err[0]) / (h[3] - err[3]));
        ay = crisp__max(ay, (fabs(h[1]) + err[1]) / (h[3] - err[3]));
        w1 = crisp__max(w1, w);
    }
    if (!(wlo > 0.0)) return INFINITY;
    /* The clip transform's rounding (err per coordinate, on every coefficient): a perturbation
     * e / w of f whose second derivatives are at most (du + dv)^2 4 e / w_lo times the weight's
     * relative variation (at most w_hi / w_lo per derivative order), generously. */
    double d = p->du + p->dv, rel = w1 / wt->lo, round[3];
    for (int r = 0; r < 3; r++)
        round[r] = 16.0 * d * d * err[r == 2 ? 3 : r] / wt->lo * (1 + 2 * rel + rel * rel);
    /* The whole patch's coefficients, then (while above target) its 2 x 2 and 4 x 4 pieces. */
    double best = INFINITY;
    for (int i = 0; i < 3 && (i == 0 || best > target); i++) {
        if (i >= sums->formed) {
            crisp__slefe_quotient_curvature(c, 3, p->du, p->dv, 1 << i, sums->K[i]);
            sums->formed = i + 1;
        }
        double K[3];
        for (int r = 0; r < 3; r++)
            K[r] = sums->K[i][r] + round[r];
        double ex = (K[0] + ax * K[2]) / (8.0 * wlo), ey = (K[1] + ay * K[2]) / (8.0 * wlo);
        double e = crisp__max(ex * 0.5 * view->width, ey * 0.5 * view->height) * (1.0 + 1e-9);
        best = crisp__min(best, e);
    }
    return best;
}

static crisp_status error_classic(const char *fn, const crisp_bezier_patch *p, const weights *wt,
                                  const crisp_slefe_view *view, const double *clip,
                                  const double *hl, const double *hh, int tau, double *dest)
{
    return error_classic2(fn, p, wt, view, clip, hl, hh, tau, tau, dest);
}

/* error_slefe's twist terms at level tau (X, Y, W as r = 0, 1, 3). */
static void slefe_twist(const crisp_bezier_patch *p, const weights *wt, const double *clip, int tau,
                        double twist[4])
{
    double h2 = 1.0 / ((double)tau * tau);
    twist[0] = twist[1] = twist[2] = twist[3] = 0.0;
    for (int r = 0; r < 4; r += r == 1 ? 2 : 1) {
        double dss, dtt, dst;
        net_derivs(wt->nb, clip, p->du, p->dv, r, &dss, &dtt, &dst);
        twist[r] = h2 * dst / 4.0;
    }
}

/* error_slefe's term of the tile with grid points g[4] of the enclosures lo, up (X, Y, W, widened
 * by the rounding) and wlo, wup (the weight's, read where the weights vary), into *term (INFINITY
 * where the weight's lower bound is not positive). 0 where the tile's least W, *cl3, is not
 * positive (error_slefe fails there). */
static inline int tile_term(const double *lo, const double *up, const double *wlo,
                            const double *wup, const int g[4], const double *hl, const double *hh,
                            const double twist[4], const weights *wt, const crisp_slefe_view *view,
                            double *term, double *cl3)
{
    double cl[4], cu[4], w[4];
    /* (X, Y, W as r = 0, 1, 3: a loop the compiler unrolls) */
    UNROLL(3)
    for (int ri = 0; ri < 3; ri++) {
        const int r = ri == 2 ? 3 : ri;
        cl[r] = INFINITY;
        cu[r] = -INFINITY;
        w[r] = 0.0;
        UNROLL(4)
        for (int c = 0; c < 4; c++) {
            cl[r] = crisp__min(cl[r], lo[g[c] * 4 + r]);
            cu[r] = crisp__max(cu[r], up[g[c] * 4 + r]);
            w[r] = crisp__max(w[r], up[g[c] * 4 + r] - lo[g[c] * 4 + r]);
        }
        cl[r] = crisp__max(cl[r], hl[r]);
        cu[r] = crisp__min(cu[r], hh[r]);
    }
    *cl3 = cl[3];
    if (!(cl[3] > 0.0)) return 0;
    /* |x| <= max(|X|) / W_lo over the tile; one division per tile (the final factor
     * 1 + 1e-12 covers the roundings of the reciprocal) */
    double ew = w[3] + twist[3], inv = 1.0 / cl[3];
    double ax = crisp__max(fabs(cl[0]), fabs(cu[0])) * inv;
    double ay = crisp__max(fabs(cl[1]), fabs(cu[1])) * inv;
    double ex = (w[0] + twist[0] + ax * ew) * inv;
    double ey = (w[1] + twist[1] + ay * ew) * inv;
    if (wt->cpw) {
        /* (w_max - w_min) / (4 w_min) times the tile's screen extent */
        double a = INFINITY, b = -INFINITY, xl, xu, yl, yu;
        for (int c = 0; c < 4; c++) {
            a = crisp__min(a, wlo[g[c] * 4 + 3]);
            b = crisp__max(b, wup[g[c] * 4 + 3]);
        }
        a = crisp__max(a, wt->lo), b = crisp__min(b, wt->hi);
        if (!(a > 0.0)) {
            *term = INFINITY;
            return 1;
        }
        double q = (b - a) / (4.0 * a) * (1.0 + 1e-12);
        crisp__slefe_divide(cl[0], cu[0], cl[3], cu[3], &xl, &xu);
        crisp__slefe_divide(cl[1], cu[1], cl[3], cu[3], &yl, &yu);
        ex += q * (xu - xl);
        ey += q * (yu - yl);
    }
    *term = crisp__max(ex * 0.5 * view->width, ey * 0.5 * view->height);
    return 1;
}

/* The enclosures of points (X, Y, W of each of count grid points, 4 doubles a point) widened by
 * the clip net's error err (X, Y, W at 0, 1, 3). */
static inline void widen_xyw(double *lo, double *up, const double *err, int count)
{
    for (int g = 0; g < count; g++) {
        UNROLL(3)
        for (int ri = 0; ri < 3; ri++) {
            const int r = ri == 2 ? 3 : ri;
            lo[g * 4 + r] -= err[r];
            up[g * 4 + r] += err[r];
        }
    }
}

/* The bound from the SLEFE at m = tau (tau <= 16), per tile. */
static crisp_status error_slefe(const char *fn, const crisp_bezier_patch *p, const weights *wt,
                                const crisp_slefe_view *view, const double *clip, const double *err,
                                const double *hl, const double *hh, int tau, double *dest)
{
    crisp_bezier_patch q = *p;
    q.cpw = (double *)clip;
    q.rational = 1;
    int m = tau, n = m + 1;
    double lo[CRISP_SLEFE_GRID(MAXM) * 4], up[CRISP_SLEFE_GRID(MAXM) * 4];
    for (int r = 0; r < 4; r += r == 1 ? 2 : 1) /* X, Y, W: Z plays no part */
        crisp__slefe_patch_coordinate(&q, m, r, lo, up);
    widen_xyw(lo, up, err, n * n);
    double twist[4];
    slefe_twist(p, wt, clip, tau, twist);
    /* The weight's SLEFE (the rasterizer's point, see the top comment). */
    double wlo[CRISP_SLEFE_GRID(MAXM) * 4], wup[CRISP_SLEFE_GRID(MAXM) * 4];
    if (wt->cpw) {
        crisp_bezier_patch o = *p;
        o.cpw = (double *)wt->cpw;
        crisp__slefe_patch_coordinate(&o, m, 3, wlo, wup);
    }
    double best = 0.0;
    for (int kv = 0; kv < m; kv++)
        for (int ku = 0; ku < m; ku++) {
            int g[4] = {kv * n + ku, kv * n + ku + 1, (kv + 1) * n + ku, (kv + 1) * n + ku + 1};
            double term, cl3;
            if (!tile_term(lo, up, wlo, wup, g, hl, hh, twist, wt, view, &term, &cl3))
                return crisp_error(CRISP_ERR_NUMERIC,
                                   "%s: lower bound %g of clip-space W on tile (%d, %d) of %d is "
                                   "not positive (split or cull the patch)",
                                   fn, cl3, ku, kv, m);
            best = crisp__max(best, term);
        }
    *dest = best * (1.0 + 1e-12);
    return CRISP_OK;
}

/* crisp__slefe_patch_coordinate's enclosure of coordinate c at the four grid points of tile
 * (ku, kv) of m x m alone, into lo, up [(j * 2 + i) * 4 + c] for the point (ku + i, kv + j): the
 * same operations in the same order, so bit for bit its values (its two passes, the first at the
 * tile's two rows only, the second at its two columns only). */
#if defined(__GNUC__)
#define INLINE_BODY inline __attribute__((always_inline))
#else
#define INLINE_BODY inline
#endif
static INLINE_BODY void coordinate_tile_body(const crisp_bezier_patch *p, int du, int dv, int m,
                                             int c, int ku, int kv, double *lo, double *up)
{
    crisp_slefe_table tu = crisp__slefe_table(du, m), tv = crisp__slefe_table(dv, m);
    int stride = (du + 1) * 4;
    double rl[(MAXD + 1) * 2], ru[(MAXD + 1) * 2]; /* [i * 2 + j] */
    for (int i = 0; i <= du; i++) {
        const double *b = p->cpw + i * 4 + c;
        if (dv >= 2) {
            crisp__slefe_side_range(dv, b, stride, tv.guard, tv.upper, tv.lower, 1.0, m, kv, kv + 1,
                                    ru + i * 2, 1);
            crisp__slefe_side_range(dv, b, stride, tv.guard, tv.lower, tv.upper, -1.0, m, kv,
                                    kv + 1, rl + i * 2, 1);
        } else {
            crisp__slefe_kernel_range(dv, b, stride, &tv, m, kv, kv + 1, rl + i * 2, 1, ru + i * 2,
                                      1);
        }
    }
    for (int j = 0; j < 2; j++) {
        double *ou = up + j * 2 * 4 + c, *ol = lo + j * 2 * 4 + c;
        if (du >= 2) {
            crisp__slefe_side_range(du, ru + j, 2, tu.guard, tu.upper, tu.lower, 1.0, m, ku, ku + 1,
                                    ou, 4);
            crisp__slefe_side_range(du, rl + j, 2, tu.guard, tu.lower, tu.upper, -1.0, m, ku,
                                    ku + 1, ol, 4);
        } else {
            double scratch[2];
            crisp__slefe_kernel_range(du, ru + j, 2, &tu, m, ku, ku + 1, scratch, 1, ou, 4);
            crisp__slefe_kernel_range(du, rl + j, 2, &tu, m, ku, ku + 1, ol, 4, scratch, 1);
        }
    }
}

/* coordinate_tile_body with constant degrees for the common cases (patch.c's general has them). */
static void coordinate_tile(const crisp_bezier_patch *p, int m, int c, int ku, int kv, double *lo,
                            double *up)
{
    int du = p->du, dv = p->dv;
    if (du == 3 && dv == 2)
        coordinate_tile_body(p, 3, 2, m, c, ku, kv, lo, up);
    else if (du == 2 && dv == 3)
        coordinate_tile_body(p, 2, 3, m, c, ku, kv, lo, up);
    else if (du == 2 && dv == 1)
        coordinate_tile_body(p, 2, 1, m, c, ku, kv, lo, up);
    else if (du == 2 && dv == 2)
        coordinate_tile_body(p, 2, 2, m, c, ku, kv, lo, up);
    else if (du == 3 && dv == 3)
        coordinate_tile_body(p, 3, 3, m, c, ku, kv, lo, up);
    else if (du == 5 && dv == 5)
        coordinate_tile_body(p, 5, 5, m, c, ku, kv, lo, up);
    else if (du == 6 && dv == 10)
        coordinate_tile_body(p, 6, 10, m, c, ku, kv, lo, up);
    else
        coordinate_tile_body(p, du, dv, m, c, ku, kv, lo, up);
}

void crisp__slefe_coordinate_tile(const crisp_bezier_patch *p, int m, int c, int ku, int kv,
                                  double *lo, double *up)
{
    coordinate_tile(p, m, c, ku, kv, lo, up);
}

int crisp__slefe_quick_off;

/* error_slefe's term of tile (ku, kv) at level tau alone, times its final factor: a lower bound on
 * error_slefe's value where that succeeds, formed for a few percent of its cost. 0 where the
 * tile's W is not positive. */
static int slefe_tile_lower(const crisp_bezier_patch *p, const weights *wt,
                            const crisp_slefe_view *view, const double *clip, const double *err,
                            const double *hl, const double *hh, int tau, int ku, int kv,
                            double *dest)
{
    crisp_bezier_patch q = *p;
    q.cpw = (double *)clip;
    q.rational = 1;
    double lo[4 * 4], up[4 * 4], wlo[4 * 4], wup[4 * 4];
    for (int r = 0; r < 4; r += r == 1 ? 2 : 1)
        coordinate_tile(&q, tau, r, ku, kv, lo, up);
    widen_xyw(lo, up, err, 4);
    double twist[4];
    slefe_twist(p, wt, clip, tau, twist);
    if (wt->cpw) {
        crisp_bezier_patch o = *p;
        o.cpw = (double *)wt->cpw;
        coordinate_tile(&o, tau, 3, ku, kv, wlo, wup);
    }
    static const int g[4] = {0, 1, 2, 3};
    double term, cl3;
    if (!tile_term(lo, up, wlo, wup, g, hl, hh, twist, wt, view, &term, &cl3)) return 0;
    *dest = term * (1.0 + 1e-12);
    return 1;
}

/* Restrict coefficients c[i * stride] (i = 0..d, 4 interleaved coordinates) to [t0, t1] in place
 * by two de Casteljau splits. */
static void restrict_range(double *c, int d, int stride, double t0, double t1)
{
    /* left part [0, t1] */
    if (t1 < 1.0)
        for (int r = 1; r <= d; r++)
            for (int i = d; i >= r; i--)
                for (int k = 0; k < 4; k++)
                    c[i * stride + k] = (1 - t1) * c[(i - 1) * stride + k] + t1 * c[i * stride + k];
    /* right part [t0 / t1, 1] of that */
    double s = t0 / t1;
    if (s > 0.0)
        for (int r = 1; r <= d; r++)
            for (int i = 0; i <= d - r; i++)
                for (int k = 0; k < 4; k++)
                    c[i * stride + k] = (1 - s) * c[i * stride + k] + s * c[(i + 1) * stride + k];
}

static crisp_status screen_error_whole(const char *fn, const crisp_bezier_patch *p,
                                       const weights *wt, const crisp_slefe_view *view,
                                       const double *clip, const double *err, const double *hl,
                                       const double *hh, int tau, double accept, double *dest);

/* tau > 16: split the tau x tau cells into k x k blocks (k = ceil(tau / 16), block sizes differ
 * by at most one); the tessellation restricted to a block is the uniform tessellation of the
 * sub-patch over that block, so the bound is the largest of the sub-patches' bounds (SLEFE and
 * classic for square blocks, classic only for the others). */
static crisp_status screen_error_split(const char *fn, const crisp_bezier_patch *p,
                                       const weights *wt, const crisp_slefe_view *view,
                                       const double *clip, const double *err, int tau,
                                       double accept, double *dest)
{
    int k = (tau + MAXM - 1) / MAXM;
    int du = p->du, dv = p->dv, n = (du + 1) * (dv + 1);
    double mag = 0.0;
    for (int i = 0; i < n * 4; i++)
        mag = crisp__max(mag, fabs(clip[i]));
    double sub[(MAXD + 1) * (MAXD + 1) * 4], serr[4], hl[4], hh[4], best = 0.0;
    for (int r = 0; r < 4; r++)
        serr[r] = err[r] + 8.0 * (du + dv + 2) * DBL_EPSILON * mag;
    crisp_bezier_patch q = *p;
    q.cpw = sub;
    double osub[(MAXD + 1) * (MAXD + 1) * 4]; /* the weights over the block */
    for (int b = 0; b < k; b++)
        for (int a = 0; a < k; a++) {
            /* cells [ca0, ca1) x [cb0, cb1) of the tau x tau grid */
            int ca0 = a * tau / k, ca1 = (a + 1) * tau / k;
            int cb0 = b * tau / k, cb1 = (b + 1) * tau / k;
            memcpy(sub, clip, sizeof(double) * n * 4);
            for (int j = 0; j <= dv; j++)
                restrict_range(sub + j * (du + 1) * 4, du, 4, (double)ca0 / tau, (double)ca1 / tau);
            for (int i = 0; i <= du; i++)
                restrict_range(sub + i * 4, dv, (du + 1) * 4, (double)cb0 / tau, (double)cb1 / tau);
            weights sw = *wt;
            sw.nb = NULL; /* another net */
            if (wt->cpw) {
                /* the block's weights: restricted the same way (de Casteljau keeps them within
                 * the patch's range, which the bounds use as the least weight) */
                memcpy(osub, wt->cpw, sizeof(double) * n * 4);
                for (int j = 0; j <= dv; j++)
                    restrict_range(osub + j * (du + 1) * 4, du, 4, (double)ca0 / tau,
                                   (double)ca1 / tau);
                for (int i = 0; i <= du; i++)
                    restrict_range(osub + i * 4, dv, (du + 1) * 4, (double)cb0 / tau,
                                   (double)cb1 / tau);
                sw.cpw = osub;
            }
            for (int r = 0; r < 4; r++) {
                hl[r] = INFINITY;
                hh[r] = -INFINITY;
                for (int i = 0; i < n; i++) {
                    hl[r] = crisp__min(hl[r], sub[i * 4 + r]);
                    hh[r] = crisp__max(hh[r], sub[i * 4 + r]);
                }
                hl[r] -= serr[r];
                hh[r] += serr[r];
            }
            double e;
            crisp_status s;
            if (ca1 - ca0 == cb1 - cb0)
                s = screen_error_whole(fn, &q, &sw, view, sub, serr, hl, hh, ca1 - ca0, accept, &e);
            else /* unequal counts (tau not a multiple of k): the classic bound only */
                s = error_classic2(fn, &q, &sw, view, sub, hl, hh, ca1 - ca0, cb1 - cb0, &e);
            if (s) return s;
            best = crisp__max(best, e);
            if (accept > 0.0 && best > accept) {
                /* tau is rejected; the caller only needs a value above accept */
                *dest = best;
                return CRISP_OK;
            }
        }
    *dest = best;
    return CRISP_OK;
}

static crisp_status screen_error(const char *fn, const crisp_bezier_patch *p, const weights *wt,
                                 const crisp_slefe_view *view, const double *clip,
                                 const double *err, const double *hl, const double *hh, int tau,
                                 double accept, double *dest)
{
    if (tau <= MAXM)
        return screen_error_whole(fn, p, wt, view, clip, err, hl, hh, tau, accept, dest);
    /* the whole-patch classic bound is cheap: try it first */
    double classic;
    if (error_classic(fn, p, wt, view, clip, hl, hh, tau, &classic) == CRISP_OK &&
        classic <= accept) {
        *dest = classic;
        return CRISP_OK;
    }
    return screen_error_split(fn, p, wt, view, clip, err, tau, accept, dest);
}

/* Both bounds where they apply; the smaller is returned (each is sound on its own). With
 * accept > 0 the SLEFE bound is skipped when the classic one is already <= accept, and a result
 * above accept may be a partial maximum (enough to reject tau, not a bound). accept = 0: the
 * full bound. */
static crisp_status screen_error_whole(const char *fn, const crisp_bezier_patch *p,
                                       const weights *wt, const crisp_slefe_view *view,
                                       const double *clip, const double *err, const double *hl,
                                       const double *hh, int tau, double accept, double *dest)
{
    double classic = INFINITY, slefe = INFINITY;
    crisp_status s1 = error_classic(fn, p, wt, view, clip, hl, hh, tau, &classic);
    if (s1 == CRISP_OK && classic <= accept) {
        *dest = classic;
        return CRISP_OK;
    }
    if (tau <= MAXM) {
        crisp_status s2 = error_slefe(fn, p, wt, view, clip, err, hl, hh, tau, &slefe);
        if (s2 == CRISP_OK) {
            *dest = crisp__min(classic, slefe);
            return CRISP_OK;
        }
        if (s1 != CRISP_OK) return s2;
    }
    if (s1 != CRISP_OK) return s1;
    *dest = classic;
    return CRISP_OK;
}

crisp_status crisp_slefe_patch_screen_error(const crisp_bezier_patch *p, int tau,
                                            const crisp_slefe_view *view, double *err_px)
{
    const char *fn = "crisp_slefe_patch_screen_error";
    crisp_status s = crisp__slefe_check_patch(fn, p, 1);
    if (!s) s = crisp__slefe_check_view(fn, view);
    if (s) return s;
    if (tau < 1 || tau > CRISP_SLEFE_MAX_TESS_LEVEL)
        return crisp_error(CRISP_ERR_LIMIT, "%s: tau %d outside 1..%d", fn, tau,
                           CRISP_SLEFE_MAX_TESS_LEVEL);
    if (!err_px) return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL output", fn);
    crisp__slefe_tables_init();
    double clip[(MAXD + 1) * (MAXD + 1) * 4], err[4], hl[4], hh[4];
    crisp_slefe_view cv;
    centred_view(p, view, &cv);
    s = crisp__slefe_to_clip(fn, p, &cv, clip, err, hl, hh);
    if (s) return s;
    weights wt = weights_of(p, p->cpw);
    s = screen_error(fn, p, &wt, &cv, clip, err, hl, hh, tau, 0.0, err_px);
    if (wt.cpw) {
        /* the Euclidean bound (euclid_c1) is sound on its own: the smaller is kept */
        euclid_sums sums = {.formed = 0};
        double e = euclid_c1(p, &wt, &cv, clip, err, 0.0, &sums) / ((double)tau * tau);
        if (s == CRISP_OK && e < *err_px) *err_px = e;
        if (s != CRISP_OK && isfinite(e)) {
            *err_px = e;
            s = CRISP_OK;
        }
    }
    return s;
}

/* The least level <= t_max at which c1 / tau^2 <= eps, else t_max. */
static int euclid_level(double c1, double eps, int t_max)
{
    double te = ceil(sqrt(c1 / eps));
    if (!(te < t_max)) return t_max;
    int t = te < 1.0 ? 1 : (int)te;
    while (t < t_max && c1 / ((double)t * t) > eps) /* rounding of the square root */
        t++;
    return t;
}

crisp_status crisp__slefe_euclid_screen_error(const crisp_bezier_patch *p, int tau,
                                              const crisp_slefe_view *view, double *err_px)
{
    const char *fn = "crisp__slefe_euclid_screen_error";
    crisp_status s = crisp__slefe_check_patch(fn, p, 1);
    if (!s) s = crisp__slefe_check_view(fn, view);
    if (s) return s;
    if (tau < 1 || !err_px)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: tau %d (expected >= 1) or NULL output", fn,
                           tau);
    double clip[(MAXD + 1) * (MAXD + 1) * 4], err[4], hl[4], hh[4];
    crisp_slefe_view cv;
    centred_view(p, view, &cv);
    s = crisp__slefe_to_clip(fn, p, &cv, clip, err, hl, hh);
    if (s) return s;
    if (!p->rational)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: the patch is not rational", fn);
    weights wt = weights_of(p, p->cpw);
    wt.cpw = p->cpw; /* equal weights too (then it is the classical bound of the clip patch) */
    euclid_sums sums = {.formed = 0};
    double c1 = euclid_c1(p, &wt, &cv, clip, err, 0.0, &sums);
    if (!isfinite(c1))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "%s: a weight or a control point's clip W is not positive", fn);
    *err_px = c1 / ((double)tau * tau);
    return CRISP_OK;
}

/* The iPASS width (crisp_slefe_patch_screen's w_px at 3 segments) from the clip-space control
 * points the level search formed: the SLEFEs of X, Y and W (Z plays no part in the width). */
static crisp_status ipass_w_px(const char *fn, const crisp_bezier_patch *p,
                               const crisp_slefe_view *view, const double *clip, const double *err,
                               const double *hl, const double *hh, double *w_px)
{
    crisp_bezier_patch q = *p;
    q.cpw = (double *)clip;
    q.rational = 1;
    enum { M = 3, N = CRISP_SLEFE_GRID(M) };
    double lo[N * 4], up[N * 4];
    for (int r = 0; r < 4; r += r == 1 ? 2 : 1)
        crisp__slefe_patch_coordinate(&q, M, r, lo, up);
    /* X, Y and W only: Z plays no part in the width. */
    return crisp__slefe_grid_width(fn, view, N, 0xbu, lo, up, err, hl, hh, w_px);
}

/* crisp_slefe_patch_tess_level's search up to its loop: *tau > 0 where it is decided there, else
 * 0 and [*lo, *hi] holds the level the loop (search_finish) names, or it names max_level + 1. */
static crisp_status search_begin(const char *fn, crisp__slefe_search *sr,
                                 const crisp_bezier_patch *p, const crisp_slefe_view *view,
                                 double eps, int max_level, int *tau, int *lo, int *hi)
{
    sr->sums.formed = 0;
    if (tau) *tau = 0;
    crisp_status s = crisp__slefe_check_patch(fn, p, 1);
    if (!s) s = crisp__slefe_check_view(fn, view);
    if (s) return s;
    if (!(eps > 0.0) || max_level < 1 || max_level > CRISP_SLEFE_MAX_TESS_LEVEL || !tau)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: eps %g (expected > 0), max_level %d (expected 1..%d) or NULL tau",
                           fn, eps, max_level, CRISP_SLEFE_MAX_TESS_LEVEL);
    crisp__slefe_tables_init();
    double *clip = sr->clip, *err = sr->err, *hl = sr->hl, *hh = sr->hh;
    centred_view(p, view, &sr->view);
    view = &sr->view;
    s = crisp__slefe_to_clip(fn, p, view, clip, err, hl, hh);
    if (s) return s;
    weights wt = weights_of(p, p->cpw);
    sr->nb.formed = 0;
    wt.nb = &sr->nb;
    sr->wcpw = wt.cpw, sr->wlo = wt.lo, sr->whi = wt.hi;
    sr->eps = eps, sr->max_level = max_level;
    /* The classic bound falls exactly as 1 / tau^2, so it names a sound level at once: the answer
     * lies between the iPASS guess (below) and that level, and only levels below it need the
     * (costlier) SLEFE bound. */
    int t_classic = max_level + 1;
    double c1;
    if (error_classic(fn, p, &wt, view, clip, hl, hh, 1, &c1) == CRISP_OK) {
        double tc = ceil(sqrt(c1 / eps));
        if (tc < 1.0) tc = 1.0;
        if (tc <= max_level) {
            t_classic = (int)tc;
            /* rounding of c1 / t^2: confirm, and step up in the rare case it fails */
            double e;
            while (t_classic <= max_level &&
                   error_classic(fn, p, &wt, view, clip, hl, hh, t_classic, &e) == CRISP_OK &&
                   e > eps)
                t_classic++;
        }
    }
    /* For a patch whose weights vary the Euclidean bound (euclid_c1, c1 / tau^2) names a sound
     * level at once too: from the whole patch's coefficients here, from its pieces only where
     * the level found would otherwise be above the guess (below). */
    if (wt.cpw)
        t_classic =
            euclid_level(euclid_c1(p, &wt, view, clip, err, INFINITY, &sr->sums), eps, t_classic);
    if (t_classic <= 2) {
        /* level 1 or 2: the bound at 1 decides, no guess needed (these are most sub-patches) */
        double e;
        if (t_classic == 2 && screen_error(fn, p, &wt, view, clip, err, hl, hh, 1, eps, &e) == 0 &&
            e <= eps)
            t_classic = 1;
        *tau = t_classic;
        return CRISP_OK;
    }
    /* Start from the iPASS guess, then raise tau until the sound bound accepts it. */
    double w_px = 0.0;
    s = ipass_w_px(fn, p, view, clip, err, hl, hh, &w_px);
    if (s) return s;
    int t = crisp_slefe_tess_level(w_px, 3, eps);
    if (t > max_level) {
        /* the sound level is at least the guess here (the search only goes up): split */
        *tau = max_level + 1;
        return CRISP_OK;
    }
    if (t_classic <= t) {
        *tau = t_classic; /* sound, and no more than the guess */
        return CRISP_OK;
    }
    sr->t = t, sr->t_classic = t_classic;
    /* The loop (search_finish) names a level it tested (from the guess up, each below
     * t_classic), t_classic or max_level + 1; or, where it may form the Euclidean bound over the
     * pieces, that bound's level, which may lie below the guess. */
    *lo = wt.cpw && wt.hi > EUCLID_PIECES_RATIO * wt.lo ? 1 : t;
    *hi = t_classic;
    return CRISP_OK;
}

/* Whether screen_error's value at tau (<= 16) with accept = eps is shown above eps without
 * forming it: the classic bound is above eps and so is the SLEFE bound's term of the tile at one
 * of two corners, (0, 0) then (tau - 1, tau - 1) (impeller.igs close's levels are rejected by
 * (0, 0) in 97% of the searches, by one of the two in 99%; the other two corners rejected 1-5% of
 * them on the rows measured, not worth a third and fourth try). Then *e_lo is a lower bound on
 * that value: min(classic, the tile's term) (the value is min(classic, SLEFE) where the SLEFE
 * succeeds, else the classic bound). */
static int quick_reject(const char *fn, const crisp_bezier_patch *p, const weights *wt,
                        const crisp_slefe_view *view, const double *clip, const double *err,
                        const double *hl, const double *hh, int tau, double eps, double *e_lo)
{
    double classic;
    if (crisp__slefe_quick_off || tau > MAXM ||
        error_classic(fn, p, wt, view, clip, hl, hh, tau, &classic) != CRISP_OK || !(classic > eps))
        return 0;
    static const int corner[2][2] = {{0, 0}, {1, 1}};
    for (int c = 0; c < 2; c++) {
        double lb;
        if (!slefe_tile_lower(p, wt, view, clip, err, hl, hh, tau, corner[c][0] * (tau - 1),
                              corner[c][1] * (tau - 1), &lb))
            return 0;
        if (lb > eps) {
            *e_lo = crisp__min(classic, lb);
            return 1;
        }
    }
    return 0;
}

/* The search's loop, from where search_begin left it. */
static crisp_status search_finish(const char *fn, crisp__slefe_search *sr,
                                  const crisp_bezier_patch *p, int *tau)
{
    const crisp_slefe_view *view = &sr->view;
    const double *clip = sr->clip, *err = sr->err, *hl = sr->hl, *hh = sr->hh;
    weights wt = {sr->wcpw, sr->wlo, sr->whi, &sr->nb};
    double eps = sr->eps;
    int max_level = sr->max_level, t = sr->t, t_classic = sr->t_classic;
    crisp_status s;
    int first = 1;
    for (;;) {
        double e;
        /* The guess's bound is most often rejected by one corner tile of its SLEFE (quick_reject:
         * then e is a lower bound on the bound), and its exact value is then formed only where
         * the next level depends on it (below). */
        int exact = !quick_reject(fn, p, &wt, view, clip, err, hl, hh, t, eps, &e);
        if (exact) {
            s = screen_error(fn, p, &wt, view, clip, err, hl, hh, t, eps, &e);
            if (s) return s;
            if (e <= eps) {
                *tau = t;
                return CRISP_OK;
            }
        }
        if (first && wt.cpw && t_classic > t + 1 && wt.hi > EUCLID_PIECES_RATIO * wt.lo) {
            /* above the guess: the Euclidean bound over the pieces, until it names t + 1 */
            double target = eps * (t + 1.0) * (t + 1.0);
            t_classic =
                euclid_level(euclid_c1(p, &wt, view, clip, err, target, &sr->sums), eps, t_classic);
        }
        first = 0;
        if (t >= max_level) {
            *tau = max_level + 1;
            return CRISP_OK;
        }
        double next = ceil(t * sqrt(e / eps));
        int nt = next > max_level ? max_level : (int)next;
        nt = nt > t ? nt : t + 1;
        if (nt >= t_classic) {
            /* (from a lower bound e: the exact next level is no lower) */
            *tau = t_classic; /* max_level + 1 (split) when the classic level is out of range */
            return CRISP_OK;
        }
        if (!exact) {
            /* the next level depends on the exact value (above eps, as the lower bound is) */
            s = screen_error(fn, p, &wt, view, clip, err, hl, hh, t, eps, &e);
            if (s) return s;
            next = ceil(t * sqrt(e / eps));
            nt = next > max_level ? max_level : (int)next;
            nt = nt > t ? nt : t + 1;
            if (nt >= t_classic) {
                *tau = t_classic;
                return CRISP_OK;
            }
        }
        /* Above 16 the bound works on k x k blocks of cells, k = ceil(tau / 16): a multiple of
         * k gives square blocks, where the (tighter) SLEFE bound applies. */
        int k = (nt + MAXM - 1) / MAXM;
        if (k > 1) {
            int rounded = (nt + k - 1) / k * k;
            nt = rounded <= max_level ? rounded : max_level;
            if (nt >= t_classic) {
                /* (the rounding reached the classic level, which is sound: until session 8 the
                 * search went on at the rounded level and could name one above it) */
                *tau = t_classic;
                return CRISP_OK;
            }
        }
        t = nt;
    }
}

static void search_info(const crisp__slefe_search *sr, crisp__slefe_level_info *info)
{
    for (int i = 0; i < 3; i++)
        info->kw[i] = i < sr->sums.formed ? sr->sums.K[i][2] : NAN;
}

crisp_status crisp__slefe_search_begin(crisp__slefe_search *sr, const crisp_bezier_patch *p,
                                       const crisp_slefe_view *view, double eps, int max_level,
                                       int *tau, int *lo, int *hi, crisp__slefe_level_info *info)
{
    crisp_status s =
        search_begin("crisp_slefe_patch_tess_level", sr, p, view, eps, max_level, tau, lo, hi);
    if (info) search_info(sr, info);
    return s;
}

crisp_status crisp__slefe_search_finish(crisp__slefe_search *sr, const crisp_bezier_patch *p,
                                        int *tau, crisp__slefe_level_info *info)
{
    crisp_status s = search_finish("crisp_slefe_patch_tess_level", sr, p, tau);
    if (info) search_info(sr, info);
    return s;
}

crisp_status crisp_slefe_patch_tess_level(const crisp_bezier_patch *p, const crisp_slefe_view *view,
                                          double eps, int max_level, int *tau)
{
    return crisp__slefe_patch_tess_level(p, view, eps, max_level, tau, NULL);
}

crisp_status crisp__slefe_patch_tess_level(const crisp_bezier_patch *p,
                                           const crisp_slefe_view *view, double eps, int max_level,
                                           int *tau, crisp__slefe_level_info *info)
{
    crisp__slefe_search sr;
    int lo, hi;
    crisp_status s = crisp__slefe_search_begin(&sr, p, view, eps, max_level, tau, &lo, &hi, info);
    if (s || *tau) return s;
    return crisp__slefe_search_finish(&sr, p, tau, info);
}
