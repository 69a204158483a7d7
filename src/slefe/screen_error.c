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
 * h^2 du dv max |mixed difference|. W is bounded below per tile, x_tri by the tile's box. */
#include "slefe_internal.h"

#include <string.h>

#define MAXD CRISP_SLEFE_MAX_DEGREE
#define MAXM CRISP_SLEFE_MAX_SEGMENTS

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

/* Largest |q| over q in [xl, xu] / [wl, wu], wl > 0. */
static double max_abs_ratio(double xl, double xu, double wl, double wu)
{
    double ql, qu;
    crisp__slefe_divide(xl, xu, wl, wu, &ql, &qu);
    return crisp__max(fabs(ql), fabs(qu));
}

/* The bound from derivative bounds alone (any tau), over the whole patch. */
/* The bound from derivative bounds alone, for tu x tv segments, over the whole patch. */
static crisp_status error_classic2(const char *fn, const crisp_bezier_patch *p,
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
        derivative_bounds(clip, p->du, p->dv, r, &dss, &dtt, &dst);
        e[r] = hu * hu * dss / 8.0 + hv * hv * dtt / 8.0 + hu * hv * dst / 4.0;
    }
    double ax = max_abs_ratio(hl[0], hh[0], hl[3], hh[3]);
    double ay = max_abs_ratio(hl[1], hh[1], hl[3], hh[3]);
    double ex = (e[0] + ax * e[3]) / hl[3] * 0.5 * view->width;
    double ey = (e[1] + ay * e[3]) / hl[3] * 0.5 * view->height;
    *dest = crisp__max(ex, ey) * (1.0 + 1e-12);
    return CRISP_OK;
}

static crisp_status error_classic(const char *fn, const crisp_bezier_patch *p,
                                  const crisp_slefe_view *view, const double *clip,
                                  const double *hl, const double *hh, int tau, double *dest)
{
    return error_classic2(fn, p, view, clip, hl, hh, tau, tau, dest);
}

/* The bound from the SLEFE at m = tau (tau <= 16), per tile. */
static crisp_status error_slefe(const char *fn, const crisp_bezier_patch *p,
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
    for (int g = 0; g < n * n; g++)
        for (int r = 0; r < 4; r += r == 1 ? 2 : 1) {
            lo[g * 4 + r] -= err[r];
            up[g * 4 + r] += err[r];
        }
    double h2 = 1.0 / ((double)tau * tau), twist[4] = {0, 0, 0, 0};
    for (int r = 0; r < 4; r += r == 1 ? 2 : 1) {
        double dss, dtt, dst;
        derivative_bounds(clip, p->du, p->dv, r, &dss, &dtt, &dst);
        twist[r] = h2 * dst / 4.0;
    }
    double best = 0.0;
    for (int kv = 0; kv < m; kv++)
        for (int ku = 0; ku < m; ku++) {
            int g[4] = {kv * n + ku, kv * n + ku + 1, (kv + 1) * n + ku, (kv + 1) * n + ku + 1};
            double cl[4], cu[4], w[4];
            for (int r = 0; r < 4; r += r == 1 ? 2 : 1) {
                cl[r] = INFINITY;
                cu[r] = -INFINITY;
                w[r] = 0.0;
                for (int c = 0; c < 4; c++) {
                    cl[r] = crisp__min(cl[r], lo[g[c] * 4 + r]);
                    cu[r] = crisp__max(cu[r], up[g[c] * 4 + r]);
                    w[r] = crisp__max(w[r], up[g[c] * 4 + r] - lo[g[c] * 4 + r]);
                }
                cl[r] = crisp__max(cl[r], hl[r]);
                cu[r] = crisp__min(cu[r], hh[r]);
            }
            if (!(cl[3] > 0.0))
                return crisp_error(CRISP_ERR_NUMERIC,
                                   "%s: lower bound %g of clip-space W on tile (%d, %d) of %d is "
                                   "not positive (split or cull the patch)",
                                   fn, cl[3], ku, kv, m);
            /* |x| <= max(|X|) / W_lo over the tile; one division per tile (the final factor
             * 1 + 1e-12 covers the roundings of the reciprocal) */
            double ew = w[3] + twist[3], inv = 1.0 / cl[3];
            double ax = crisp__max(fabs(cl[0]), fabs(cu[0])) * inv;
            double ay = crisp__max(fabs(cl[1]), fabs(cu[1])) * inv;
            double ex = (w[0] + twist[0] + ax * ew) * inv;
            double ey = (w[1] + twist[1] + ay * ew) * inv;
            best = crisp__max(best, crisp__max(ex * 0.5 * view->width, ey * 0.5 * view->height));
        }
    *dest = best * (1.0 + 1e-12);
    return CRISP_OK;
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
                                       const crisp_slefe_view *view, const double *clip,
                                       const double *err, const double *hl, const double *hh,
                                       int tau, double accept, double *dest);

/* tau > 16: split the tau x tau cells into k x k blocks (k = ceil(tau / 16), block sizes differ
 * by at most one); the tessellation restricted to a block is the uniform tessellation of the
 * sub-patch over that block, so the bound is the largest of the sub-patches' bounds (SLEFE and
 * classic for square blocks, classic only for the others). */
static crisp_status screen_error_split(const char *fn, const crisp_bezier_patch *p,
                                       const crisp_slefe_view *view, const double *clip,
                                       const double *err, int tau, double accept, double *dest)
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
                s = screen_error_whole(fn, &q, view, sub, serr, hl, hh, ca1 - ca0, accept, &e);
            else /* unequal counts (tau not a multiple of k): the classic bound only */
                s = error_classic2(fn, &q, view, sub, hl, hh, ca1 - ca0, cb1 - cb0, &e);
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

static crisp_status screen_error(const char *fn, const crisp_bezier_patch *p,
                                 const crisp_slefe_view *view, const double *clip,
                                 const double *err, const double *hl, const double *hh, int tau,
                                 double accept, double *dest)
{
    if (tau <= MAXM) return screen_error_whole(fn, p, view, clip, err, hl, hh, tau, accept, dest);
    /* the whole-patch classic bound is cheap: try it first */
    double classic;
    if (error_classic(fn, p, view, clip, hl, hh, tau, &classic) == CRISP_OK && classic <= accept) {
        *dest = classic;
        return CRISP_OK;
    }
    return screen_error_split(fn, p, view, clip, err, tau, accept, dest);
}

/* Both bounds where they apply; the smaller is returned (each is sound on its own). With
 * accept > 0 the SLEFE bound is skipped when the classic one is already <= accept, and a result
 * above accept may be a partial maximum (enough to reject tau, not a bound). accept = 0: the
 * full bound. */
static crisp_status screen_error_whole(const char *fn, const crisp_bezier_patch *p,
                                       const crisp_slefe_view *view, const double *clip,
                                       const double *err, const double *hl, const double *hh,
                                       int tau, double accept, double *dest)
{
    double classic = INFINITY, slefe = INFINITY;
    crisp_status s1 = error_classic(fn, p, view, clip, hl, hh, tau, &classic);
    if (s1 == CRISP_OK && classic <= accept) {
        *dest = classic;
        return CRISP_OK;
    }
    if (tau <= MAXM) {
        crisp_status s2 = error_slefe(fn, p, view, clip, err, hl, hh, tau, &slefe);
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
    s = crisp__slefe_to_clip(fn, p, view, clip, err, hl, hh);
    if (s) return s;
    return screen_error(fn, p, view, clip, err, hl, hh, tau, 0.0, err_px);
}

crisp_status crisp_slefe_patch_tess_level(const crisp_bezier_patch *p, const crisp_slefe_view *view,
                                          double eps, int max_level, int *tau)
{
    const char *fn = "crisp_slefe_patch_tess_level";
    crisp_status s = crisp__slefe_check_patch(fn, p, 1);
    if (!s) s = crisp__slefe_check_view(fn, view);
    if (s) return s;
    if (!(eps > 0.0) || max_level < 1 || max_level > CRISP_SLEFE_MAX_TESS_LEVEL || !tau)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: eps %g (expected > 0), max_level %d (expected 1..%d) or NULL tau",
                           fn, eps, max_level, CRISP_SLEFE_MAX_TESS_LEVEL);
    crisp__slefe_tables_init();
    double clip[(MAXD + 1) * (MAXD + 1) * 4], err[4], hl[4], hh[4];
    s = crisp__slefe_to_clip(fn, p, view, clip, err, hl, hh);
    if (s) return s;
    /* Start from the iPASS guess, then raise tau until the sound bound accepts it. */
    double w_px;
    s = crisp_slefe_patch_screen(p, 3, view, NULL, NULL, &w_px);
    if (s) return s;
    int t = crisp_slefe_tess_level(w_px, 3, eps);
    if (t > max_level) {
        /* the sound level is at least the guess here (the search only goes up): split */
        *tau = max_level + 1;
        return CRISP_OK;
    }
    /* The classic bound falls exactly as 1 / tau^2, so it names a sound level at once: the answer
     * lies between the guess and that level, and only levels below it need the (costlier) SLEFE
     * bound. */
    int t_classic = max_level + 1;
    double c1;
    if (error_classic(fn, p, view, clip, hl, hh, 1, &c1) == CRISP_OK) {
        double tc = ceil(sqrt(c1 / eps));
        if (tc < 1.0) tc = 1.0;
        if (tc <= max_level) {
            t_classic = (int)tc;
            /* rounding of c1 / t^2: confirm, and step up in the rare case it fails */
            double e;
            while (t_classic <= max_level &&
                   error_classic(fn, p, view, clip, hl, hh, t_classic, &e) == CRISP_OK && e > eps)
                t_classic++;
        }
    }
    if (t_classic <= t) {
        *tau = t;
        return CRISP_OK;
    }
    for (;;) {
        double e;
        s = screen_error(fn, p, view, clip, err, hl, hh, t, eps, &e);
        if (s) return s;
        if (e <= eps) {
            *tau = t;
            return CRISP_OK;
        }
        if (t >= max_level) {
            *tau = max_level + 1;
            return CRISP_OK;
        }
        double next = ceil(t * sqrt(e / eps));
        int nt = next > max_level ? max_level : (int)next;
        nt = nt > t ? nt : t + 1;
        if (nt >= t_classic) {
            *tau = t_classic; /* max_level + 1 (split) when the classic level is out of range */
            return CRISP_OK;
        }
        /* Above 16 the bound works on k x k blocks of cells, k = ceil(tau / 16): a multiple of
         * k gives square blocks, where the (tighter) SLEFE bound applies. */
        int k = (nt + MAXM - 1) / MAXM;
        if (k > 1) {
            int rounded = (nt + k - 1) / k * k;
            nt = rounded <= max_level ? rounded : max_level;
        }
        t = nt;
    }
}
