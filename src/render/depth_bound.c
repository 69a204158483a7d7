/* A bound on the tessellation's error along the view (issue 13), for the planner's level choice
 * (quadtree.c build_cell) beside the screen bound (crisp_slefe_patch_tess_level, flat_bound).
 *
 * The rasterizer draws flat triangles whose vertices lie on the surface and writes, per pixel,
 * the triangle's camera-space depth, which for a perspective view_proj is clip W. With
 * f(s, t) = W(S(s, t)) the depth of the surface point at the patch's parameters, a triangle
 * point T = sum l_j S(x_j) (clip-space barycentrics l_j; the rasterizer interpolates the
 * parameters as sum l_j x_j) has depth sum l_j f(x_j), so its depth error is the linear
 * interpolation error of f. By Taylor at x = sum l_j x_j,
 *   |sum l_j f(x_j) - f(x)| <= 1/2 sum l_j (A a_j^2 + B b_j^2 + 2 C |a_j b_j|)
 *                           <= (A + B + 2 C) h^2 / 8,
 * a_j, b_j the parameter offsets of vertex j from x, A, B, C bounds on |f_ss|, |f_tt|, |f_st|,
 * h = 1 / tau the cell size (sum l_j a_j^2 is a variance of values within a range h: at most
 * h^2 / 4; Cauchy-Schwarz for the mixed sum). For a polynomial patch f is the Bezier patch of
 * the control points' depths and A, B, C come from their second differences (the classical
 * bound that screen_error.c uses per clip coordinate, there with the twist term 2 C h^2 / 8).
 * For a rational patch, f - c = g / w with g = W_h - c w (W_h the clip W of the homogeneous
 * control points, w the weight patch, c the middle of the control points' depths so that
 * |f - c| <= Q, half their range); differentiating g = (f - c) w gives
 *   q_s = (g_s - q w_s) / w,  q_ss = (g_ss - 2 q_s w_s - q w_ss) / w,
 *   q_st = (g_st - q_s w_t - q_t w_s - q w_st) / w,
 * bounded with the Bezier coefficients' differences and the least weight. The depth error is
 * also at most the control points' depth range (triangle and surface points are convex
 * combinations of points within it). The allowance is eps pixels' world size at the patch's
 * least depth: eps * W * crisp__depth_px_scale. */
#include "depth_bound.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "slefe/slefe_internal.h"

#define MAXN 16 /* degrees up to 15 (CRISP_SLEFE_MAX_DEGREE) */

int crisp__depth_clip_coefficients(const crisp_bezier_patch *p, crisp_mat4 m, double *c)
{
    if (p->du < 1 && p->dv < 1) return 0;
    if (p->du < 0 || p->dv < 0 || p->du >= MAXN || p->dv >= MAXN) return 0;
    int n = (p->du + 1) * (p->dv + 1);
    for (int i = 0; i < n; i++) {
        const double *q = p->cpw + 4 * i;
        double w = p->rational ? q[3] : 1;
        c[2 * i] = m[0][3] * q[0] + m[1][3] * q[1] + m[2][3] * q[2] + m[3][3] * w;
        c[2 * i + 1] = w;
    }
    return 1;
}

/* The least bound on A + B + 2 C over the whole patch from the patch itself and from its k x k
 * pieces (k = 2, 4; a piece's second derivatives in the patch's parameters are k^2 its own; the
 * bound over the pieces converges to the true maximum, where the one from the whole patch's
 * coefficients can be several times it, most for rational patches), tried only while the bound
 * asks for more than `enough`; the control points' depth range into dmin, dmax. The bounds are
 * src/slefe/quotient.c's (shared with the screen bound): f - l over the quotient's derivatives,
 * l the middle of the depths or, for varying weights, fitted to their slopes. INFINITY when a
 * weight or a depth is not positive. kw (or NULL): the same bounds where the screen bound's level
 * search formed them (crisp__slefe_level_info; NAN where not), taken instead of forming them.
 * allow > 0: the caller only asks whether level tau is enough along the view with allowance allow
 * (ceil(sqrt(K / (8 allow))) <= tau); -1 where the cheaper bounds of quotient.c already show it
 * (crisp__slefe_quotient_curvature_mid, never below the full ones: where it names tau, so would
 * the full bound, and every later step only lowers K), tried first over the whole patch where the
 * weights vary (over the pieces it saved less than it cost on occt_linkrods.step). */
static double curvature_sum(const double *c, int du, int dv, double enough, const double *kw,
                            double allow, int tau, double *dmin, double *dmax)
{
    int n = (du + 1) * (dv + 1), vary = 0;
    for (int i = 1; i < n; i++)
        vary |= c[2 * i + 1] != c[1];
    if (vary && allow > 0 && !(kw && !isnan(kw[0]))) {
        /* (a weight that is not positive makes it INFINITY: the loop below then returns that) */
        double km;
        crisp__slefe_quotient_curvature_mid(c, 1, du, dv, 1, &km);
        if (ceil(sqrt(km / (8 * allow))) <= tau) return -1;
    }
    double lo = INFINITY, hi = -INFINITY;
    for (int i = 0; i < n; i++) {
        double w = c[2 * i + 1], d = c[2 * i] / w;
        if (!(w > 0) || !(d > 0) || !isfinite(d)) return INFINITY;
        lo = crisp__min(lo, d), hi = crisp__max(hi, d);
    }
    *dmin = lo, *dmax = hi;
    double K = INFINITY;
    for (int i = 0; i < 3 && (i == 0 || K > enough); i++) {
        double Kk;
        if (kw && !isnan(kw[i]))
            Kk = kw[i];
        else
            crisp__slefe_quotient_curvature(c, 1, du, dv, 1 << i, &Kk);
        K = fmin(K, Kk);
    }
    return K;
}

double crisp__depth_error_bound(const crisp_bezier_patch *p, crisp_mat4 view_proj, int tau,
                                double *wmin)
{
    double lo = 0, hi = 0, c[2 * MAXN * MAXN];
    if (wmin) *wmin = 0;
    if (!crisp__depth_clip_coefficients(p, view_proj, c)) return 0;
    double k = curvature_sum(c, p->du, p->dv, 0, NULL, 0, 0, &lo, &hi);
    if (wmin) *wmin = lo;
    if (!isfinite(k)) return INFINITY;
    double h = 1.0 / (tau < 1 ? 1 : tau);
    return fmin(hi - lo, k * h * h / 8);
}

double crisp__depth_px_scale(crisp_mat4 m, int width, int height)
{
    double r[3] = {0, 0, 0};
    for (int a = 0; a < 3; a++) {
        int row = a == 2 ? 3 : a;
        r[a] = sqrt(m[0][row] * m[0][row] + m[1][row] * m[1][row] + m[2][row] * m[2][row]);
    }
    if (!(r[0] > 0) || !(r[1] > 0) || width < 1 || height < 1) return 0;
    return r[2] * fmin(2.0 / (width * r[0]), 2.0 / (height * r[1]));
}

int crisp__depth_tess_level(const crisp_bezier_patch *p, crisp_mat4 view_proj, int width,
                            int height, double eps, int tau, int max_level)
{
    return crisp__depth_tess_level_kw(p, view_proj, width, height, eps, tau, max_level, NULL);
}

int crisp__depth_tess_level_kw(const crisp_bezier_patch *p, crisp_mat4 view_proj, int width,
                               int height, double eps, int tau, int max_level, const double *kw)
{
    double lo = INFINITY, hi = -INFINITY, c[2 * MAXN * MAXN];
    if (!crisp__depth_clip_coefficients(p, view_proj, c)) return tau;
    int n = (p->du + 1) * (p->dv + 1);
    for (int i = 0; i < n; i++) {
        double d = c[2 * i] / c[2 * i + 1];
        if (!(d > 0) || !isfinite(d)) return tau;
        lo = crisp__min(lo, d), hi = crisp__max(hi, d);
    }
    double allow = eps * crisp__depth_px_scale(view_proj, width, height) * lo;
    if (!(allow > 0) || hi - lo <= allow) return tau;
    /* Level tau is enough while K / (8 tau^2) <= allow. */
    double k = curvature_sum(c, p->du, p->dv, 8 * allow * tau * tau, kw, allow, tau, &lo, &hi);
    if (!isfinite(k) || k < 0) return tau;
    double need = ceil(sqrt(k / (8 * allow)));
    if (!(need <= max_level)) return max_level + 1;
    return (int)need > tau ? (int)need : tau;
}
