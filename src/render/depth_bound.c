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

#define MAXN 16 /* degrees up to 15 (CRISP_SLEFE_MAX_DEGREE) */

/* Bounds on |x_s|, |x_t| (first), |x_ss|, |x_tt|, |x_st| (second) of the Bezier patch with
 * coefficients x (du + 1 per row), widened for rounding. */
static void diff_bounds(const double *x, int du, int dv, double d1[2], double d2[3])
{
    double a = 0, b = 0, c = 0, e = 0, f = 0, mag = 0;
    int n = du + 1;
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++) {
            double v = x[j * n + i];
            mag = fmax(mag, fabs(v));
            if (i + 1 <= du) e = fmax(e, fabs(x[j * n + i + 1] - v));
            if (j + 1 <= dv) f = fmax(f, fabs(x[(j + 1) * n + i] - v));
            if (i + 2 <= du) a = fmax(a, fabs(v - 2 * x[j * n + i + 1] + x[j * n + i + 2]));
            if (j + 2 <= dv) b = fmax(b, fabs(v - 2 * x[(j + 1) * n + i] + x[(j + 2) * n + i]));
            if (i + 1 <= du && j + 1 <= dv)
                c = fmax(c,
                         fabs(v - x[j * n + i + 1] - x[(j + 1) * n + i] + x[(j + 1) * n + i + 1]));
        }
    double round = 16.0 * DBL_EPSILON * mag;
    d1[0] = du * (e + round), d1[1] = dv * (f + round);
    d2[0] = du * (du - 1) * (a + round), d2[1] = dv * (dv - 1) * (b + round);
    d2[2] = du * dv * (c + round);
}

/* Restrict the two interleaved scalar patches (W_h, w) of degrees du x dv, coefficients
 * c[2 * (j * (du + 1) + i) + q], to [s0, s1] x [t0, t1] in place (de Casteljau). */
static void restrict_piece(double *c, int du, int dv, double s0, double s1, double t0, double t1)
{
    for (int dir = 0; dir < 2; dir++) {
        int d = dir ? dv : du, rows = dir ? du + 1 : dv + 1;
        int stride = dir ? 2 * (du + 1) : 2, row_step = dir ? 2 : 2 * (du + 1);
        double a = dir ? t0 : s0, b = dir ? t1 : s1, r0 = a / b;
        for (int row = 0; row < rows; row++) {
            double *x = c + row * row_step;
            if (b < 1.0)
                for (int r = 1; r <= d; r++)
                    for (int i = d; i >= r; i--)
                        for (int q = 0; q < 2; q++)
                            x[i * stride + q] =
                                (1 - b) * x[(i - 1) * stride + q] + b * x[i * stride + q];
            if (r0 > 0.0)
                for (int r = 1; r <= d; r++)
                    for (int i = 0; i <= d - r; i++)
                        for (int q = 0; q < 2; q++)
                            x[i * stride + q] =
                                (1 - r0) * x[i * stride + q] + r0 * x[(i + 1) * stride + q];
        }
    }
}

/* A + B + 2 C (above) from the Bezier coefficients of g = W_h - l w and of w (n x m degrees,
 * row-major, (n + 1) per row), where |q| = |g / w| <= Q. */
static double quotient_sum(const double *g, const double *w, int n, int m, double Q)
{
    double wlo = INFINITY;
    for (int i = 0; i < (n + 1) * (m + 1); i++)
        wlo = fmin(wlo, w[i]);
    double g1[2], g2[3], w1[2], w2[3];
    diff_bounds(g, n, m, g1, g2);
    diff_bounds(w, n, m, w1, w2);
    double qs = (g1[0] + Q * w1[0]) / wlo, qt = (g1[1] + Q * w1[1]) / wlo;
    double A = (g2[0] + 2 * qs * w1[0] + Q * w2[0]) / wlo;
    double B = (g2[1] + 2 * qt * w1[1] + Q * w2[1]) / wlo;
    double C = (g2[2] + qs * w1[1] + qt * w1[0] + Q * w2[2]) / wlo;
    return (A + B + 2 * C) * (1 + 1e-9);
}

/* The product of the degree (1, 1) Bezier patch l (corners l00, l10, l01, l11) and x (degrees
 * du x dv), in degrees (du + 1) x (dv + 1). */
static void times_bilinear(const double l[4], const double *x, int du, int dv, double *dest)
{
    int n = du + 1, m = dv + 1;
    for (int k = 0; k <= m; k++)
        for (int i = 0; i <= n; i++) {
            double sum = 0;
            for (int b = 0; b < 2; b++)
                for (int a = 0; a < 2; a++) {
                    int ii = i - a, kk = k - b;
                    if (ii < 0 || ii > du || kk < 0 || kk > dv) continue;
                    double cs = a ? (double)i / n : (double)(n - i) / n;
                    double ct = b ? (double)k / m : (double)(m - k) / m;
                    sum += l[b * 2 + a] * cs * ct * x[kk * (du + 1) + ii];
                }
            dest[k * (n + 1) + i] = sum;
        }
}

/* A + B + 2 C of the patch with interleaved coefficients c (W_h, w), in its own parameters, and
 * its control points' depth range; INFINITY when a weight or a depth is not positive. Two
 * bounds, the smaller kept: f - mid (mid the middle of the depths) and, for varying weights,
 * f - l with l linear in (s, t) fitted to the depths: l's interpolation error is 0, and the
 * quotient terms, which add absolute values where the true derivatives cancel, shrink with
 * |f - l| (a cylinder's quarter seen obliquely: its depth changes along the axis at the same
 * rate all round, f_st = 0, but f - mid bounds f_st by that rate). g = W_h - l w has degrees one
 * higher; |g / w| <= max |g_k / w_k| in that basis. */
static double piece_sum(const double *c, int du, int dv, double *dmin, double *dmax)
{
    int n = (du + 1) * (dv + 1);
    double g[MAXN * MAXN], w[MAXN * MAXN], d[MAXN * MAXN], lo = INFINITY, hi = -INFINITY;
    double wlo = INFINITY, whi = -INFINITY;
    if (n < 1 || n > MAXN * MAXN) return INFINITY;
    for (int i = 0; i < n; i++) {
        g[i] = c[2 * i], w[i] = c[2 * i + 1];
        if (!(w[i] > 0)) return INFINITY;
        d[i] = g[i] / w[i];
        if (!(d[i] > 0) || !isfinite(d[i])) return INFINITY;
        lo = fmin(lo, d[i]), hi = fmax(hi, d[i]), wlo = fmin(wlo, w[i]), whi = fmax(whi, w[i]);
    }
    *dmin = lo, *dmax = hi;
    double mid = 0.5 * (lo + hi);
    for (int i = 0; i < n; i++)
        g[i] -= mid * w[i];
    double K = quotient_sum(g, w, du, dv, 0.5 * (hi - lo) * (1 + 1e-12));
    if (!(whi > wlo) || du + 1 >= MAXN || dv + 1 >= MAXN) return K;
    /* l = a + b s + c t: b, c the mean slopes of the depths across the net, a centring it. */
    double bs = 0, ct = 0, mean = 0;
    for (int j = 0; j <= dv; j++)
        bs += d[j * (du + 1) + du] - d[j * (du + 1)];
    for (int i = 0; i <= du; i++)
        ct += d[dv * (du + 1) + i] - d[i];
    bs /= dv + 1, ct /= du + 1;
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++)
            mean += d[j * (du + 1) + i] - bs * (du ? (double)i / du : 0) -
                    ct * (dv ? (double)j / dv : 0);
    mean /= n;
    double one[4] = {1, 1, 1, 1}, l[4] = {mean, mean + bs, mean + ct, mean + bs + ct};
    double ge[MAXN * MAXN], we[MAXN * MAXN], lw[MAXN * MAXN];
    for (int i = 0; i < n; i++)
        g[i] = c[2 * i];
    times_bilinear(one, g, du, dv, ge);
    times_bilinear(one, w, du, dv, we);
    times_bilinear(l, w, du, dv, lw);
    double Q = 0;
    int ne = (du + 2) * (dv + 2);
    for (int i = 0; i < ne; i++) {
        ge[i] -= lw[i];
        Q = fmax(Q, fabs(ge[i] / we[i]));
    }
    return fmin(K, quotient_sum(ge, we, du + 1, dv + 1, Q * (1 + 1e-12)));
}

/* The clip W and weight coefficients of p, interleaved; 0 when the degrees are out of range. */
static int clip_depths(const crisp_bezier_patch *p, crisp_mat4 m, double *c)
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
 * coefficients can be several times it, most for rational patches), tried only while the
 * bound asks for more than `enough`. INFINITY as piece_sum. */
static double curvature_sum(const double *c, int du, int dv, double enough, double *dmin,
                            double *dmax)
{
    double K = piece_sum(c, du, dv, dmin, dmax);
    if (!isfinite(K)) return K;
    double piece[2 * MAXN * MAXN];
    int n = 2 * (du + 1) * (dv + 1);
    for (int k = 2; k <= 4 && K > enough; k *= 2) {
        double worst = 0, lo, hi;
        for (int j = 0; j < k && worst < K; j++)
            for (int i = 0; i < k && worst < K; i++) {
                memcpy(piece, c, sizeof(double) * (size_t)n);
                restrict_piece(piece, du, dv, (double)i / k, (double)(i + 1) / k, (double)j / k,
                               (double)(j + 1) / k);
                worst = fmax(worst, (double)k * k * piece_sum(piece, du, dv, &lo, &hi));
            }
        K = fmin(K, worst * (1 + 1e-9));
    }
    return K;
}

double crisp__depth_error_bound(const crisp_bezier_patch *p, crisp_mat4 view_proj, int tau,
                                double *wmin)
{
    double lo = 0, hi = 0, c[2 * MAXN * MAXN];
    if (wmin) *wmin = 0;
    if (!clip_depths(p, view_proj, c)) return 0;
    double k = curvature_sum(c, p->du, p->dv, 0, &lo, &hi);
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
    double lo = INFINITY, hi = -INFINITY, c[2 * MAXN * MAXN];
    if (!clip_depths(p, view_proj, c)) return tau;
    int n = (p->du + 1) * (p->dv + 1);
    for (int i = 0; i < n; i++) {
        double d = c[2 * i] / c[2 * i + 1];
        if (!(d > 0) || !isfinite(d)) return tau;
        lo = fmin(lo, d), hi = fmax(hi, d);
    }
    double allow = eps * crisp__depth_px_scale(view_proj, width, height) * lo;
    if (!(allow > 0) || hi - lo <= allow) return tau;
    /* Level tau is enough while K / (8 tau^2) <= allow. */
    double k = curvature_sum(c, p->du, p->dv, 8 * allow * tau * tau, &lo, &hi);
    if (!isfinite(k)) return tau;
    double need = ceil(sqrt(k / (8 * allow)));
    if (!(need <= max_level)) return max_level + 1;
    return (int)need > tau ? (int)need : tau;
}
