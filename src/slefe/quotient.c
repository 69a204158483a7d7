/* Second-derivative bounds of the coordinates of a rational Bézier patch, f = g / w with g and w
 * polynomial patches (issue 12, session 7): what the interpolation error of flat triangles drawn
 * with clip-space barycentrics needs (screen_error.c's bound for patches whose weights vary, and
 * src/render/depth_bound.c's bound along the view, which share this code).
 *
 * A triangle of a cell (hu x hv in parameters) with vertices x_j and clip-space barycentrics l_j
 * gives the point sum l_j f(x_j), and the rasterizer pairs it with the parameters x = sum l_j x_j.
 * Taylor at x: |sum l_j f(x_j) - f(x)| <= 1/2 sum l_j (A a_j^2 + B b_j^2 + 2 C |a_j b_j|)
 * <= (A hu^2 + B hv^2 + 2 C hu hv) / 8, a_j, b_j the offsets of x_j from x (a variance of values
 * within a range hu: at most hu^2 / 4; Cauchy-Schwarz for the mixed sum), A, B, C bounds on
 * |f_ss|, |f_tt|, |f_st|. With q = f - l (l linear in s, t: its second derivatives are 0),
 * g - l w = q w; differentiating,
 *   q_s = (h_s - q w_s) / w,  q_ss = (h_ss - 2 q_s w_s - q w_ss) / w,
 *   q_st = (h_st - q_s w_t - q_t w_s - q w_st) / w,   h = g - l w,
 * bounded with the Bézier coefficients' first and second differences, |q| <= max |h_k / w_k|
 * (h and w in the same degree) and the least weight. Two choices of l are tried, the smaller
 * bound kept: the middle of the control points' values (no degree raise) and, where the weights
 * vary, l fitted to the values' mean slopes (h then has degrees one higher): its quotient terms
 * shrink with |f - l|. Over 2 x 2 and 4 x 4 pieces (a piece's second derivatives in the patch's
 * parameters are k^2 its own) the bound converges to the true maximum, where the whole patch's
 * coefficients can be several times it (weights far from 1, high degrees). For a polynomial patch
 * (w = 1) the bound is the classical second-difference one. */
#include "slefe_internal.h"

#include <string.h>

#define QN (CRISP_SLEFE_MAX_DEGREE + 2) /* coefficients per side after one degree raise */

/* piece_sums and what it calls, and split_half, are inlined into copies for the common degrees
 * (piece_sums, split_half), so that their loops have constant trip counts; the same operations
 * in the same order. */
#if defined(__GNUC__)
#define INLINE_BODY inline __attribute__((always_inline))
#else
#define INLINE_BODY inline
#endif
/* Their loops of constant trip count peeled whole (GCC's -fpeel-loops, on for these two only:
 * #pragma GCC unroll also unrolled the generic copy's loops at run time, 68 KB of code). */
#if defined(__GNUC__) && !defined(__clang__)
#define PEEL_LOOPS __attribute__((optimize("peel-loops")))
#else
#define PEEL_LOOPS
#endif

/* Bounds on |x_s|, |x_t| (d1) and |x_ss|, |x_tt|, |x_st| (d2) of the Bézier patch with scalar
 * coefficients x (du + 1 per row), widened for rounding. */
static INLINE_BODY void diff_bounds(const double *x, int du, int dv, double d1[2], double d2[3])
{
    /* row by row, each difference in its own loop (no branches in the inner loops; the maxima do
     * not depend on the order they are taken in) */
    double a = 0, b = 0, c = 0, e = 0, f = 0, mag = 0;
    int n = du + 1;
    for (int j = 0; j <= dv; j++) {
        const double *r = x + j * n;
        for (int i = 0; i <= du; i++)
            mag = crisp__max(mag, fabs(r[i]));
        for (int i = 0; i < du; i++)
            e = crisp__max(e, fabs(r[i + 1] - r[i]));
        for (int i = 0; i + 2 <= du; i++)
            a = crisp__max(a, fabs(r[i] - 2 * r[i + 1] + r[i + 2]));
        if (j == dv) continue;
        const double *q = r + n;
        for (int i = 0; i <= du; i++)
            f = crisp__max(f, fabs(q[i] - r[i]));
        for (int i = 0; i < du; i++)
            c = crisp__max(c, fabs(r[i] - r[i + 1] - q[i] + q[i + 1]));
        if (j + 2 > dv) continue;
        const double *o = q + n;
        for (int i = 0; i <= du; i++)
            b = crisp__max(b, fabs(r[i] - 2 * q[i] + o[i]));
    }
    double round = 16.0 * DBL_EPSILON * mag;
    d1[0] = du * (e + round), d1[1] = dv * (f + round);
    d2[0] = du * (du - 1) * (a + round), d2[1] = dv * (dv - 1) * (b + round);
    d2[2] = du * dv * (c + round);
}

/* A + B + 2 C of q = h / w from the coefficients of h (degrees n x m) and the bounds w1, w2 of
 * w's derivatives (diff_bounds), |q| <= Q, the least weight wlo. */
static INLINE_BODY double quotient_sum(const double *h, const double w1[2], const double w2[3],
                                       int n, int m, double Q, double wlo)
{
    double h1[2], h2[3];
    diff_bounds(h, n, m, h1, h2);
    double qs = (h1[0] + Q * w1[0]) / wlo, qt = (h1[1] + Q * w1[1]) / wlo;
    double A = (h2[0] + 2 * qs * w1[0] + Q * w2[0]) / wlo;
    double B = (h2[1] + 2 * qt * w1[1] + Q * w2[1]) / wlo;
    double C = (h2[2] + qs * w1[1] + qt * w1[0] + Q * w2[2]) / wlo;
    return (A + B + 2 * C) * (1 + 1e-9);
}

/* dest = x + l y in degrees (du + 1) x (dv + 1): x raised by one degree in s and t, plus the
 * product of the degree (1, 1) patch l (corners l00, l10, l01, l11) and y (y NULL: x alone).
 * Each coefficient of x and y is spread onto the four it reaches. */
static INLINE_BODY void raise_plus(const double *x, const double l[4], const double *y, int du,
                                   int dv, double *dest)
{
    static const double none[4] = {0, 0, 0, 0};
    if (!y) l = none;
    int n = du + 1, m = dv + 1;
    double cs[2][QN + 1], ct[2][QN + 1];
    for (int i = 0; i <= n; i++)
        cs[0][i] = (double)(n - i) / n, cs[1][i] = (double)i / n;
    for (int k = 0; k <= m; k++)
        ct[0][k] = (double)(m - k) / m, ct[1][k] = (double)k / m;
    memset(dest, 0, sizeof(double) * (size_t)((n + 1) * (m + 1)));
    for (int kk = 0; kk <= dv; kk++)
        for (int ii = 0; ii <= du; ii++) {
            double v = x[kk * n + ii], yv = y ? y[kk * n + ii] : 0;
            double *d0 = dest + kk * (n + 1) + ii, *d1 = d0 + (n + 1);
            double a0 = cs[0][ii], a1 = cs[1][ii + 1], b0 = ct[0][kk], b1 = ct[1][kk + 1];
            d0[0] += a0 * b0 * (v + l[0] * yv);
            d0[1] += a1 * b0 * (v + l[1] * yv);
            d1[0] += a0 * b1 * (v + l[2] * yv);
            d1[1] += a1 * b1 * (v + l[3] * yv);
        }
}

/* A + B + 2 C of each coordinate r < nc of the patch with interleaved coefficients c (nc + 1
 * values per control point, the weight last), in its own parameters, into K; INFINITY when a
 * weight is not positive. mid_only: l the middle of the values alone (the fitted l is not tried:
 * a bound never below the full one, for about a third of its cost). */
static INLINE_BODY void piece_sums_body(const double *c, int nc, int du, int dv, int mid_only,
                                        double *K)
{
    int n = (du + 1) * (dv + 1), st = nc + 1, ne = (du + 2) * (dv + 2);
    double w[QN * QN], we[QN * QN], wlo = INFINITY, whi = -INFINITY;
    for (int r = 0; r < nc; r++)
        K[r] = INFINITY;
    if (n < 1 || n > QN * QN) return;
    for (int i = 0; i < n; i++) {
        w[i] = c[st * i + nc];
        if (!(w[i] > 0)) return;
        wlo = crisp__min(wlo, w[i]), whi = crisp__max(whi, w[i]);
    }
    if (!(whi > wlo)) {
        /* equal weights: f = g / w, the classical bound of g's second differences */
        for (int r = 0; r < nc; r++) {
            double g[QN * QN], d1[2], d2[3];
            for (int i = 0; i < n; i++)
                g[i] = c[st * i + r];
            diff_bounds(g, du, dv, d1, d2);
            K[r] = (d2[0] + d2[1] + 2 * d2[2]) / wlo * (1 + 1e-9);
        }
        return;
    }
    double w1[2], w2[3], we1[2] = {0, 0}, we2[3] = {0, 0, 0}; /* we: only with fit */
    diff_bounds(w, du, dv, w1, w2);
    int fit = !mid_only && du + 1 < QN && dv + 1 < QN;
    if (fit) {
        raise_plus(w, NULL, NULL, du, dv, we);
        diff_bounds(we, du + 1, dv + 1, we1, we2);
    }
    for (int r = 0; r < nc; r++) {
        double g[QN * QN], d[QN * QN], lo = INFINITY, hi = -INFINITY;
        int ok = 1;
        for (int i = 0; i < n; i++) {
            g[i] = c[st * i + r];
            d[i] = g[i] / w[i];
            ok &= isfinite(d[i]);
            lo = crisp__min(lo, d[i]), hi = crisp__max(hi, d[i]);
        }
        if (!ok) continue;
        double mid = 0.5 * (lo + hi), mag = crisp__max(fabs(lo), fabs(hi));
        for (int i = 0; i < n; i++)
            g[i] -= mid * w[i];
        /* |q| <= half the range (convex combination), widened for the roundings of d and g */
        double Q0 = 0.5 * (hi - lo) * (1 + 1e-12) + 8 * DBL_EPSILON * mag;
        K[r] = quotient_sum(g, w1, w2, du, dv, Q0, wlo);
        if (!fit) continue;
        /* l = a + b s + c t: b, c the mean slopes of the values across the net, a centring it. */
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
        /* h = g - l w in degrees one higher: the raised g minus the product l w */
        double l[4] = {-mean, -(mean + bs), -(mean + ct), -(mean + bs + ct)};
        double he[QN * QN], Q = 0, gmax = 0, wmax = 0, lmax = 0;
        for (int i = 0; i < n; i++) {
            g[i] = c[st * i + r];
            gmax = crisp__max(gmax, fabs(g[i])), wmax = crisp__max(wmax, w[i]);
        }
        for (int q = 0; q < 4; q++)
            lmax = crisp__max(lmax, fabs(l[q]));
        raise_plus(g, l, w, du, dv, he);
        for (int i = 0; i < ne; i++)
            Q = crisp__max(Q, fabs(he[i] / we[i]));
        double emag = gmax + lmax * wmax; /* bounds every term above (convex combinations) */
        /* the products and sums above round by a few ulps of their magnitude */
        Q = Q * (1 + 1e-12) + 16 * DBL_EPSILON * emag / wlo;
        K[r] = crisp__min(K[r], quotient_sum(he, we1, we2, du + 1, dv + 1, Q, wlo));
    }
}

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#define QUOTIENT_AVX2 1
#include <immintrin.h>

/* piece_sums_body for three coordinates (screen_error.c's X, Y, W with the weight fourth: nc = 3,
 * one control point = one 4-lane load), the coordinates as lanes: every lane does the scalar
 * body's operations in its order (no contraction: -std=c11; _mm256_max_pd(a, b) is a > b ? a : b
 * and _mm256_min_pd(a, b) is a < b ? a : b, crisp__max's and crisp__min's rules), so each K[r] is
 * the scalar body's bit for bit (tests/slefe/test_slefe_rational.c, test_quotient_lanes). The
 * weight's own parts (w, we and their bounds) are the scalar body's, shared. Lane 3 (the weight
 * divided by itself) is computed and dropped. */
#define V __m256d
#define VSET(x) _mm256_set1_pd(x)
#define VABS(x) _mm256_andnot_pd(_mm256_set1_pd(-0.0), (x))

__attribute__((target("avx2"))) static INLINE_BODY void diff_bounds4(const V *x, int du, int dv,
                                                                     V d1[2], V d2[3])
{
    V a = VSET(0), b = a, c = a, e = a, f = a, mag = a, two = VSET(2);
    int n = du + 1;
    for (int j = 0; j <= dv; j++) {
        const V *r = x + j * n;
        for (int i = 0; i <= du; i++)
            mag = _mm256_max_pd(mag, VABS(r[i]));
        for (int i = 0; i < du; i++)
            e = _mm256_max_pd(e, VABS(_mm256_sub_pd(r[i + 1], r[i])));
        for (int i = 0; i + 2 <= du; i++)
            a = _mm256_max_pd(a, VABS(_mm256_add_pd(
                                     _mm256_sub_pd(r[i], _mm256_mul_pd(two, r[i + 1])), r[i + 2])));
        if (j == dv) continue;
        const V *q = r + n;
        for (int i = 0; i <= du; i++)
            f = _mm256_max_pd(f, VABS(_mm256_sub_pd(q[i], r[i])));
        for (int i = 0; i < du; i++)
            c = _mm256_max_pd(
                c,
                VABS(_mm256_add_pd(_mm256_sub_pd(_mm256_sub_pd(r[i], r[i + 1]), q[i]), q[i + 1])));
        if (j + 2 > dv) continue;
        const V *o = q + n;
        for (int i = 0; i <= du; i++)
            b = _mm256_max_pd(
                b, VABS(_mm256_add_pd(_mm256_sub_pd(r[i], _mm256_mul_pd(two, q[i])), o[i])));
    }
    V round = _mm256_mul_pd(VSET(16.0 * DBL_EPSILON), mag);
    d1[0] = _mm256_mul_pd(VSET(du), _mm256_add_pd(e, round));
    d1[1] = _mm256_mul_pd(VSET(dv), _mm256_add_pd(f, round));
    d2[0] = _mm256_mul_pd(VSET(du * (du - 1)), _mm256_add_pd(a, round));
    d2[1] = _mm256_mul_pd(VSET(dv * (dv - 1)), _mm256_add_pd(b, round));
    d2[2] = _mm256_mul_pd(VSET(du * dv), _mm256_add_pd(c, round));
}

/* quotient_sum with h's coefficients as lanes (w1, w2, wlo the weight's, shared). */
__attribute__((target("avx2"))) static INLINE_BODY V quotient_sum4(const V *h, const double w1[2],
                                                                   const double w2[3], int n, int m,
                                                                   V Q, double wlo)
{
    V h1[2], h2[3], two = VSET(2), vlo = VSET(wlo);
    diff_bounds4(h, n, m, h1, h2);
    V qs = _mm256_div_pd(_mm256_add_pd(h1[0], _mm256_mul_pd(Q, VSET(w1[0]))), vlo);
    V qt = _mm256_div_pd(_mm256_add_pd(h1[1], _mm256_mul_pd(Q, VSET(w1[1]))), vlo);
    V A = _mm256_div_pd(
        _mm256_add_pd(_mm256_add_pd(h2[0], _mm256_mul_pd(_mm256_mul_pd(two, qs), VSET(w1[0]))),
                      _mm256_mul_pd(Q, VSET(w2[0]))),
        vlo);
    V B = _mm256_div_pd(
        _mm256_add_pd(_mm256_add_pd(h2[1], _mm256_mul_pd(_mm256_mul_pd(two, qt), VSET(w1[1]))),
                      _mm256_mul_pd(Q, VSET(w2[1]))),
        vlo);
    V C = _mm256_div_pd(
        _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(h2[2], _mm256_mul_pd(qs, VSET(w1[1]))),
                                    _mm256_mul_pd(qt, VSET(w1[0]))),
                      _mm256_mul_pd(Q, VSET(w2[2]))),
        vlo);
    return _mm256_mul_pd(_mm256_add_pd(_mm256_add_pd(A, B), _mm256_mul_pd(two, C)), VSET(1 + 1e-9));
}

/* raise_plus(x, l, y) with x and l as lanes, y shared (y non-NULL). */
__attribute__((target("avx2"))) static INLINE_BODY void
raise_plus4(const V *x, const V l[4], const double *y, int du, int dv, V *dest)
{
    int n = du + 1, m = dv + 1;
    double cs[2][QN + 1], ct[2][QN + 1];
    for (int i = 0; i <= n; i++)
        cs[0][i] = (double)(n - i) / n, cs[1][i] = (double)i / n;
    for (int k = 0; k <= m; k++)
        ct[0][k] = (double)(m - k) / m, ct[1][k] = (double)k / m;
    for (int i = 0; i < (n + 1) * (m + 1); i++)
        dest[i] = VSET(0);
    for (int kk = 0; kk <= dv; kk++)
        for (int ii = 0; ii <= du; ii++) {
            V v = x[kk * n + ii], yv = VSET(y[kk * n + ii]);
            V *d0 = dest + kk * (n + 1) + ii, *d1 = d0 + (n + 1);
            double a0 = cs[0][ii], a1 = cs[1][ii + 1], b0 = ct[0][kk], b1 = ct[1][kk + 1];
            d0[0] = _mm256_add_pd(
                d0[0], _mm256_mul_pd(VSET(a0 * b0), _mm256_add_pd(v, _mm256_mul_pd(l[0], yv))));
            d0[1] = _mm256_add_pd(
                d0[1], _mm256_mul_pd(VSET(a1 * b0), _mm256_add_pd(v, _mm256_mul_pd(l[1], yv))));
            d1[0] = _mm256_add_pd(
                d1[0], _mm256_mul_pd(VSET(a0 * b1), _mm256_add_pd(v, _mm256_mul_pd(l[2], yv))));
            d1[1] = _mm256_add_pd(
                d1[1], _mm256_mul_pd(VSET(a1 * b1), _mm256_add_pd(v, _mm256_mul_pd(l[3], yv))));
        }
}

/* piece_sums_body(c, 3, du, dv, 0, K) with the coordinates as lanes; returns 0 (K untouched) where
 * the scalar body is to run instead: a weight not positive, or all the weights equal. */
__attribute__((target("avx2"))) static INLINE_BODY int piece_sums3_body(const double *c, int du,
                                                                        int dv, double *K)
{
    int n = (du + 1) * (dv + 1), ne = (du + 2) * (dv + 2);
    double w[QN * QN], we[QN * QN], wlo = INFINITY, whi = -INFINITY;
    if (n < 1 || n > QN * QN) return 0;
    for (int i = 0; i < n; i++) {
        w[i] = c[4 * i + 3];
        if (!(w[i] > 0)) return 0;
        wlo = crisp__min(wlo, w[i]), whi = crisp__max(whi, w[i]);
    }
    if (!(whi > wlo)) return 0;
    double w1[2], w2[3], we1[2] = {0, 0}, we2[3] = {0, 0, 0};
    diff_bounds(w, du, dv, w1, w2);
    int fit = du + 1 < QN && dv + 1 < QN;
    if (fit) {
        raise_plus(w, NULL, NULL, du, dv, we);
        diff_bounds(we, du + 1, dv + 1, we1, we2);
    }
    V g[QN * QN], d[QN * QN], lo = VSET(INFINITY), hi = VSET(-INFINITY), big = VSET(INFINITY);
    V ok = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    for (int i = 0; i < n; i++) {
        g[i] = _mm256_loadu_pd(c + 4 * i);
        d[i] = _mm256_div_pd(g[i], VSET(w[i]));
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(VABS(d[i]), big, _CMP_LT_OQ));
        lo = _mm256_min_pd(lo, d[i]), hi = _mm256_max_pd(hi, d[i]);
    }
    V half = VSET(0.5);
    V mid = _mm256_mul_pd(half, _mm256_add_pd(lo, hi));
    V mag = _mm256_max_pd(VABS(lo), VABS(hi));
    for (int i = 0; i < n; i++)
        g[i] = _mm256_sub_pd(g[i], _mm256_mul_pd(mid, VSET(w[i])));
    V Q0 = _mm256_add_pd(_mm256_mul_pd(_mm256_mul_pd(half, _mm256_sub_pd(hi, lo)), VSET(1 + 1e-12)),
                         _mm256_mul_pd(VSET(8 * DBL_EPSILON), mag));
    V k = quotient_sum4(g, w1, w2, du, dv, Q0, wlo);
    if (fit) {
        V bs = VSET(0), ct = VSET(0), mean = VSET(0);
        for (int j = 0; j <= dv; j++)
            bs = _mm256_add_pd(bs, _mm256_sub_pd(d[j * (du + 1) + du], d[j * (du + 1)]));
        for (int i = 0; i <= du; i++)
            ct = _mm256_add_pd(ct, _mm256_sub_pd(d[dv * (du + 1) + i], d[i]));
        bs = _mm256_div_pd(bs, VSET(dv + 1)), ct = _mm256_div_pd(ct, VSET(du + 1));
        for (int j = 0; j <= dv; j++)
            for (int i = 0; i <= du; i++)
                mean = _mm256_add_pd(
                    mean,
                    _mm256_sub_pd(_mm256_sub_pd(d[j * (du + 1) + i],
                                                _mm256_mul_pd(bs, VSET(du ? (double)i / du : 0))),
                                  _mm256_mul_pd(ct, VSET(dv ? (double)j / dv : 0))));
        mean = _mm256_div_pd(mean, VSET(n));
        V zero = VSET(-0.0); /* -x as the scalar's negation: the sign bit flipped */
        V l[4] = {_mm256_xor_pd(mean, zero), _mm256_xor_pd(_mm256_add_pd(mean, bs), zero),
                  _mm256_xor_pd(_mm256_add_pd(mean, ct), zero),
                  _mm256_xor_pd(_mm256_add_pd(_mm256_add_pd(mean, bs), ct), zero)};
        V he[QN * QN], Q = VSET(0), gmax = VSET(0), lmax = VSET(0);
        double wmax = 0;
        for (int i = 0; i < n; i++) {
            g[i] = _mm256_loadu_pd(c + 4 * i);
            gmax = _mm256_max_pd(gmax, VABS(g[i])), wmax = crisp__max(wmax, w[i]);
        }
        for (int q = 0; q < 4; q++)
            lmax = _mm256_max_pd(lmax, VABS(l[q]));
        raise_plus4(g, l, w, du, dv, he);
        for (int i = 0; i < ne; i++)
            Q = _mm256_max_pd(Q, VABS(_mm256_div_pd(he[i], VSET(we[i]))));
        V emag = _mm256_add_pd(gmax, _mm256_mul_pd(lmax, VSET(wmax)));
        Q = _mm256_add_pd(_mm256_mul_pd(Q, VSET(1 + 1e-12)),
                          _mm256_div_pd(_mm256_mul_pd(VSET(16 * DBL_EPSILON), emag), VSET(wlo)));
        k = _mm256_min_pd(k, quotient_sum4(he, we1, we2, du + 1, dv + 1, Q, wlo));
    }
    /* a lane whose values are not all finite keeps INFINITY, as the scalar body's continue */
    double out[4];
    _mm256_storeu_pd(out, _mm256_blendv_pd(big, k, ok));
    K[0] = out[0], K[1] = out[1], K[2] = out[2];
    return 1;
}

__attribute__((target("avx2"))) PEEL_LOOPS static int piece_sums3(const double *c, int du, int dv,
                                                                  double *K)
{
    if (du == 3 && dv == 2) return piece_sums3_body(c, 3, 2, K);
    if (du == 3 && dv == 3) return piece_sums3_body(c, 3, 3, K);
    if (du == 1 && dv == 2) return piece_sums3_body(c, 1, 2, K);
    if (du == 6 && dv == 10) return piece_sums3_body(c, 6, 10, K);
    return piece_sums3_body(c, du, dv, K);
}
#undef V
#undef VSET
#undef VABS
#else
#define QUOTIENT_AVX2 0
#endif

/* 1: piece_sums takes the lanes path (piece_sums3) where it applies and the processor has AVX2;
 * 0: the scalar body always (a test hook). Set once. */
int crisp__slefe_quotient_lanes = -1;

static int use_lanes(void)
{
#if QUOTIENT_AVX2
    if (crisp__slefe_quotient_lanes < 0)
        crisp__slefe_quotient_lanes = __builtin_cpu_supports("avx2") ? 1 : 0;
    return crisp__slefe_quotient_lanes;
#else
    return 0;
#endif
}

/* piece_sums_body with constant degrees where they are common: cubic by quadratic rational
 * patches (impeller.igs), bicubic, linear by quadratic and 6 x 10 (occt_linkrods.step). */
PEEL_LOOPS static void piece_sums(const double *c, int nc, int du, int dv, int mid_only, double *K)
{
    if (du == 3 && dv == 2)
        piece_sums_body(c, nc, 3, 2, mid_only, K);
    else if (du == 3 && dv == 3)
        piece_sums_body(c, nc, 3, 3, mid_only, K);
    else if (du == 1 && dv == 2)
        piece_sums_body(c, nc, 1, 2, mid_only, K);
    else if (du == 6 && dv == 10)
        piece_sums_body(c, nc, 6, 10, mid_only, K);
    else
        piece_sums_body(c, nc, du, dv, mid_only, K);
}

/* Split the interleaved coefficients c (st values per control point, degrees du x dv) at the
 * middle of direction dir (0: s, 1: t) into lo and hi (de Casteljau at 1/2). Coordinates from
 * `from` on are copied unchanged (a weight that is the same everywhere stays so). */
static INLINE_BODY void split_half_body(const double *c, int st, int from, int du, int dv, int dir,
                                        double *lo, double *hi)
{
    int d = dir ? dv : du, rows = dir ? du + 1 : dv + 1;
    int stride = dir ? st * (du + 1) : st, row_step = dir ? st : st * (du + 1);
    double tmp[QN];
    for (int row = 0; row < rows; row++)
        for (int q = 0; q < st; q++) {
            const double *x = c + row * row_step + q;
            double *L = lo + row * row_step + q, *H = hi + row * row_step + q;
            if (q >= from) {
                for (int i = 0; i <= d; i++)
                    L[i * stride] = H[i * stride] = x[i * stride];
                continue;
            }
            for (int i = 0; i <= d; i++)
                tmp[i] = x[i * stride];
            L[0] = tmp[0], H[d * stride] = tmp[d];
            for (int r = 1; r <= d; r++) {
                for (int i = 0; i <= d - r; i++)
                    tmp[i] = 0.5 * (tmp[i] + tmp[i + 1]);
                L[r * stride] = tmp[0], H[(d - r) * stride] = tmp[d - r];
            }
        }
}

/* split_half_body with the degrees of piece_sums' constant cases. */
PEEL_LOOPS static void split_half(const double *c, int st, int from, int du, int dv, int dir,
                                  double *lo, double *hi)
{
    if (du == 3 && dv == 2 && dir)
        split_half_body(c, st, from, 3, 2, 1, lo, hi);
    else if (du == 3 && dv == 2)
        split_half_body(c, st, from, 3, 2, 0, lo, hi);
    else if (du == 3 && dv == 3)
        split_half_body(c, st, from, 3, 3, dir, lo, hi);
    else
        split_half_body(c, st, from, du, dv, dir, lo, hi);
}

#if QUOTIENT_AVX2
/* split_half_body for four values a control point (st = 4), the four as lanes: the same
 * 0.5 * (a + b) per lane; coordinates from `from` on are then the source's, as the scalar body
 * copies them (a blend, so that no value of theirs goes through the sums). */
__attribute__((target("avx2"))) static INLINE_BODY void
split_half4_body(const double *c, int from, int du, int dv, int dir, double *lo, double *hi)
{
    int d = dir ? dv : du, rows = dir ? du + 1 : dv + 1;
    int stride = dir ? 4 * (du + 1) : 4, row_step = dir ? 4 : 4 * (du + 1);
    __m256d tmp[QN], half = _mm256_set1_pd(0.5);
    /* lanes q >= from: all ones (take the source) */
    __m256d keep = _mm256_castsi256_pd(
        _mm256_cmpgt_epi64(_mm256_set_epi64x(3, 2, 1, 0), _mm256_set1_epi64x(from - 1)));
    for (int row = 0; row < rows; row++) {
        const double *x = c + row * row_step;
        double *L = lo + row * row_step, *H = hi + row * row_step;
        for (int i = 0; i <= d; i++)
            tmp[i] = _mm256_loadu_pd(x + i * stride);
        _mm256_storeu_pd(L, tmp[0]);
        _mm256_storeu_pd(H + d * stride, tmp[d]);
        for (int r = 1; r <= d; r++) {
            for (int i = 0; i <= d - r; i++)
                tmp[i] = _mm256_mul_pd(half, _mm256_add_pd(tmp[i], tmp[i + 1]));
            _mm256_storeu_pd(L + r * stride,
                             _mm256_blendv_pd(tmp[0], _mm256_loadu_pd(x + r * stride), keep));
            _mm256_storeu_pd(
                H + (d - r) * stride,
                _mm256_blendv_pd(tmp[d - r], _mm256_loadu_pd(x + (d - r) * stride), keep));
        }
    }
}

__attribute__((target("avx2"))) PEEL_LOOPS static void
split_half4(const double *c, int from, int du, int dv, int dir, double *lo, double *hi)
{
    if (du == 3 && dv == 2 && dir)
        split_half4_body(c, from, 3, 2, 1, lo, hi);
    else if (du == 3 && dv == 2)
        split_half4_body(c, from, 3, 2, 0, lo, hi);
    else if (du == 3 && dv == 3)
        split_half4_body(c, from, 3, 3, dir, lo, hi);
    else
        split_half4_body(c, from, du, dv, dir, lo, hi);
}
#endif

/* The largest piece_sums over the pieces of c halved su times in s and sv times in t, into K
 * (the caller's maxima so far). */
static void halves(const double *c, int nc, int from, int du, int dv, int su, int sv, int mid_only,
                   double *K)
{
    if (!su && !sv) {
        double Kp[4];
        piece_sums(c, nc, du, dv, mid_only, Kp);
        for (int r = 0; r < nc; r++)
            K[r] = crisp__max(K[r], Kp[r]);
        return;
    }
    double lo[4 * QN * QN], hi[4 * QN * QN];
    int dir = su ? 0 : 1;
    split_half(c, nc + 1, from, du, dv, dir, lo, hi);
    halves(lo, nc, from, du, dv, su - !dir, sv - dir, mid_only, K);
    halves(hi, nc, from, du, dv, su - !dir, sv - dir, mid_only, K);
}

#if QUOTIENT_AVX2
/* halves for three coordinates with the lanes paths (piece_sums3, split_half4; the scalar body
 * where piece_sums3 declines): the same pieces, the same maxima. A copy, so that halves and
 * piece_sums for the other callers (depth_bound.c, one coordinate) stay as they were. */
static void halves3(const double *c, int from, int du, int dv, int su, int sv, double *K)
{
    if (!su && !sv) {
        double Kp[4];
        if (!piece_sums3(c, du, dv, Kp)) piece_sums(c, 3, du, dv, 0, Kp);
        for (int r = 0; r < 3; r++)
            K[r] = crisp__max(K[r], Kp[r]);
        return;
    }
    double lo[4 * QN * QN], hi[4 * QN * QN];
    int dir = su ? 0 : 1;
    split_half4(c, from, du, dv, dir, lo, hi);
    halves3(lo, from, du, dv, su - !dir, sv - dir, K);
    halves3(hi, from, du, dv, su - !dir, sv - dir, K);
}
#endif

static void curvature(const double *c, int nc, int du, int dv, int k, int mid_only, double *K)
{
#if QUOTIENT_AVX2
    int lanes = nc == 3 && !mid_only && use_lanes();
#else
    int lanes = 0;
    (void)lanes;
#endif
    int st = nc + 1, n = (du + 1) * (dv + 1);
    if (k <= 1 || du >= QN - 1 || dv >= QN - 1) {
#if QUOTIENT_AVX2
        if (lanes && piece_sums3(c, du, dv, K)) return;
#endif
        piece_sums(c, nc, du, dv, mid_only, K);
        return;
    }
    /* The halves' coefficients differ from exact ones by a few ulps of their magnitude, which
     * diff_bounds' rounding term covers. A weight the same everywhere is not split. */
    int from = nc;
    for (int i = 1; i < n && from == nc; i++)
        if (c[st * i + nc] != c[nc]) from = nc + 1;
    int levels = k >= 4 ? 2 : 1;
    for (int r = 0; r < nc; r++)
        K[r] = 0;
#if QUOTIENT_AVX2
    if (lanes)
        halves3(c, from, du, dv, levels, levels, K);
    else
#endif
        halves(c, nc, from, du, dv, levels, levels, mid_only, K);
    for (int r = 0; r < nc; r++)
        K[r] *= (double)k * k * (1 + 1e-9);
}

void crisp__slefe_quotient_curvature(const double *c, int nc, int du, int dv, int k, double *K)
{
    curvature(c, nc, du, dv, k, 0, K);
}

void crisp__slefe_quotient_curvature_mid(const double *c, int nc, int du, int dv, int k, double *K)
{
    curvature(c, nc, du, dv, k, 1, K);
}
