/* Knot-vector algorithms: validation, span search, B-spline basis functions and their
 * derivatives, Boehm knot insertion and span-local Bézier extraction.
 * Piegl & Tiller, "The NURBS Book", 2nd ed.: A2.1 (FindSpan), A2.2 (BasisFuns), A2.3
 * (DersBasisFuns), A5.1 (CurveKnotIns), A5.6 (DecomposeCurve, here applied span by span so that
 * unclamped ends and any multiplicities need no special case).
 */
#include "nurbs_internal.h"

#include <math.h>
#include <string.h>

crisp_status crisp__check_degree_count(const char *what, int degree, int count)
{
    if (degree < 1 || degree > CRISP_MAX_DEGREE)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s degree %d is outside 1..%d", what, degree,
                           CRISP_MAX_DEGREE);
    if (count > CRISP_MAX_CONTROL_POINTS)
        return crisp_error(CRISP_ERR_LIMIT, "%s has %d control points, more than the limit %d",
                           what, count, CRISP_MAX_CONTROL_POINTS);
    if (count < degree + 1)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s of degree %d needs at least %d control points, got %d", what, degree,
                           degree + 1, count);
    return CRISP_OK;
}

crisp_status crisp__check_knots(const char *what, int degree, int count, const double *knots)
{
    if (!knots) return crisp_error(CRISP_ERR_INVALID_ARG, "%s has no knot vector", what);
    int n = count + degree + 1;
    for (int i = 0; i < n; i++) {
        if (!isfinite(knots[i]))
            return crisp_error(CRISP_ERR_INVALID_ARG, "%s knot %d is %g: knots must be finite",
                               what, i, knots[i]);
        if (i > 0 && knots[i] < knots[i - 1])
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "%s knot %d (%.17g) is less than knot %d (%.17g)", what, i, knots[i],
                               i - 1, knots[i - 1]);
    }
    if (!isfinite(knots[n - 1] - knots[0]))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s knots span [%g, %g]: the range overflows a double", what, knots[0],
                           knots[n - 1]);
    if (!(knots[degree] < knots[count]))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s domain is empty: knot %d (%.17g) equals knot %d (%.17g)", what,
                           degree, knots[degree], count, knots[count]);
    return CRISP_OK;
}

int crisp__find_span(const double *knots, int degree, int count, double t)
{
    if (t >= knots[count]) {
        int k = count - 1;
        while (k > degree && knots[k] == knots[k + 1])
            k--;
        return k;
    }
    if (t <= knots[degree]) {
        int k = degree;
        while (k < count - 1 && knots[k] == knots[k + 1])
            k++;
        return k;
    }
    int lo = degree, hi = count; /* knots[lo] <= t < knots[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (t < knots[mid])
            hi = mid;
        else
            lo = mid;
    }
    return lo;
}

void crisp__basis_funs(const double *knots, int degree, int k, double t, double *dest)
{
    double left[CRISP_MAX_DEGREE + 1], right[CRISP_MAX_DEGREE + 1];
    dest[0] = 1.0;
    for (int j = 1; j <= degree; j++) {
        left[j] = t - knots[k + 1 - j];
        right[j] = knots[k + j] - t;
        double saved = 0.0;
        for (int r = 0; r < j; r++) {
            double tmp = dest[r] / (right[r + 1] + left[j - r]);
            dest[r] = saved + right[r + 1] * tmp;
            saved = left[j - r] * tmp;
        }
        dest[j] = saved;
    }
}

void crisp__basis_ders(const double *knots, int degree, int k, double t, int nd, double *dest)
{
    const int p = degree;
    double ndu[CRISP_MAX_DEGREE + 1][CRISP_MAX_DEGREE + 1];
    double a[2][CRISP_MAX_DEGREE + 1];
    double left[CRISP_MAX_DEGREE + 1], right[CRISP_MAX_DEGREE + 1];
    if (nd > CRISP__MAX_DERIV) nd = CRISP__MAX_DERIV;
    int n = nd < p ? nd : p;

    ndu[0][0] = 1.0;
    for (int j = 1; j <= p; j++) {
        left[j] = t - knots[k + 1 - j];
        right[j] = knots[k + j] - t;
        double saved = 0.0;
        for (int r = 0; r < j; r++) {
            ndu[j][r] = right[r + 1] + left[j - r]; /* lower triangle: knot differences */
            double tmp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * tmp;
            saved = left[j - r] * tmp;
        }
        ndu[j][j] = saved;
    }
    for (int j = 0; j <= p; j++)
        dest[j] = ndu[j][p];

    for (int r = 0; r <= p; r++) {
        int s1 = 0, s2 = 1;
        a[0][0] = 1.0;
        for (int kk = 1; kk <= n; kk++) {
            double d = 0.0;
            int rk = r - kk, pk = p - kk;
            if (r >= kk) {
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk];
                d = a[s2][0] * ndu[rk][pk];
            }
            int j1 = rk >= -1 ? 1 : -rk;
            int j2 = (r - 1 <= pk) ? kk - 1 : p - r;
            for (int j = j1; j <= j2; j++) {
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][rk + j];
                d += a[s2][j] * ndu[rk + j][pk];
            }
            if (r <= pk) {
                a[s2][kk] = -a[s1][kk - 1] / ndu[pk + 1][r];
                d += a[s2][kk] * ndu[r][pk];
            }
            dest[kk * (p + 1) + r] = d;
            int tmp = s1;
            s1 = s2;
            s2 = tmp;
        }
    }
    double f = p;
    for (int kk = 1; kk <= n; kk++) {
        for (int j = 0; j <= p; j++)
            dest[kk * (p + 1) + j] *= f;
        f *= p - kk;
    }
    for (int kk = n + 1; kk <= nd; kk++)
        for (int j = 0; j <= p; j++)
            dest[kk * (p + 1) + j] = 0.0;
}

int crisp__count_spans(const double *knots, int degree, int count)
{
    int n = 0;
    for (int k = degree; k < count; k++)
        if (knots[k] < knots[k + 1]) n++;
    return n;
}

int crisp__surface_span_kept(const double *knots, int degree, int count, int k)
{
    /* A surface span narrower than this fraction of the domain is knot noise from the exporter:
     * its Bézier patch is a curve, and knot insertion between nearly equal knots turns its control
     * net into garbage (huge boxes, huge tess levels). It is left out; its neighbours meet across
     * it within the same fraction. Curves keep every span (a trim loop must stay closed). */
    double w = knots[k + 1] - knots[k];
    return w > 0 && w > 1e-10 * (knots[count] - knots[degree]);
}

int crisp__count_surface_spans(const double *knots, int degree, int count)
{
    int n = 0;
    for (int k = degree; k < count; k++)
        n += crisp__surface_span_kept(knots, degree, count, k);
    return n;
}

int crisp__multiplicity(const double *knots, int n, double t)
{
    int m = 0;
    for (int i = 0; i < n; i++)
        if (knots[i] == t) m++;
    return m;
}

int crisp__insert_index(const double *knots, int degree, int count, double t)
{
    int n = count + degree + 1;
    int lo = 0, hi = n; /* last index with knots[i] <= t, found by bisection */
    if (t < knots[0]) return degree;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (knots[mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    if (lo < degree) lo = degree;
    return lo;
}

void crisp__insert_knots(const double *knots, int degree, int count, int k, int r, double t,
                         double *dest)
{
    int n = count + degree + 1;
    memcpy(dest, knots, (size_t)(k + 1) * sizeof *dest);
    for (int i = 1; i <= r; i++)
        dest[k + i] = t;
    memcpy(dest + k + 1 + r, knots + k + 1, (size_t)(n - k - 1) * sizeof *dest);
}

void crisp__insert_seq(const double *knots, int degree, int count, int k, int s, int r, double t,
                       int ncomp, const double *src, ptrdiff_t src_stride, double *dst,
                       ptrdiff_t dst_stride)
{
    const int p = degree;
    double rw[(CRISP_MAX_DEGREE + 1) * 4];
    for (int i = 0; i <= k - p; i++)
        memcpy(dst + i * dst_stride, src + i * src_stride, (size_t)ncomp * sizeof *dst);
    for (int i = k - s; i < count; i++)
        memcpy(dst + (i + r) * dst_stride, src + i * src_stride, (size_t)ncomp * sizeof *dst);
    if (r <= 0) return;
    for (int i = 0; i <= p - s; i++)
        memcpy(rw + i * ncomp, src + (k - p + i) * src_stride, (size_t)ncomp * sizeof *rw);
    int L = k - p;
    for (int j = 1; j <= r; j++) {
        L = k - p + j;
        for (int i = 0; i <= p - j - s; i++) {
            double alpha = (t - knots[L + i]) / (knots[i + k + 1] - knots[L + i]);
            for (int c = 0; c < ncomp; c++)
                rw[i * ncomp + c] =
                    alpha * rw[(i + 1) * ncomp + c] + (1.0 - alpha) * rw[i * ncomp + c];
        }
        memcpy(dst + L * dst_stride, rw, (size_t)ncomp * sizeof *dst);
        memcpy(dst + (k + r - j - s) * dst_stride, rw + (p - j - s) * ncomp,
               (size_t)ncomp * sizeof *dst);
    }
    for (int i = L + 1; i < k - s; i++)
        memcpy(dst + i * dst_stride, rw + (i - L) * ncomp, (size_t)ncomp * sizeof *dst);
}

void crisp__span_to_bezier(int degree, const double *lk, int ncomp, const double *ctrl,
                           ptrdiff_t stride, double *dest)
{
    const int p = degree;
    double kn[2 * CRISP_MAX_DEGREE];
    double *d = dest;
    memcpy(kn, lk, (size_t)(2 * p) * sizeof *kn);
    for (int j = 0; j <= p; j++)
        memcpy(d + j * ncomp, ctrl + j * stride, (size_t)ncomp * sizeof *d);
    const double a = kn[p - 1], b = kn[p];

    /* Left end: insert a until the p knots left of the span all equal a. Each insertion keeps
     * the p + 1 polar points f(kn[j .. j + p - 1]) of the shifted local knot vector. */
    int ma = 0;
    while (ma < p && kn[p - 1 - ma] == a)
        ma++;
    for (int step = ma; step < p; step++) {
        for (int j = 1; j <= p; j++) {
            double den = kn[j + p - 1] - kn[j - 1];
            double w1 = (a - kn[j - 1]) / den, w0 = 1.0 - w1;
            for (int c = 0; c < ncomp; c++)
                d[(j - 1) * ncomp + c] = w0 * d[(j - 1) * ncomp + c] + w1 * d[j * ncomp + c];
        }
        memmove(kn, kn + 1, (size_t)(p - 1) * sizeof *kn);
        kn[p - 1] = a;
    }
    /* Right end: insert b until the p knots right of the span all equal b. */
    int mb = 0;
    while (mb < p && kn[p + mb] == b)
        mb++;
    for (int step = mb; step < p; step++) {
        for (int j = p; j >= 1; j--) {
            double den = kn[j + p - 1] - kn[j - 1];
            double w1 = (b - kn[j - 1]) / den, w0 = 1.0 - w1;
            for (int c = 0; c < ncomp; c++)
                d[j * ncomp + c] = w0 * d[(j - 1) * ncomp + c] + w1 * d[j * ncomp + c];
        }
        memmove(kn + p + 1, kn + p, (size_t)(p - 1) * sizeof *kn);
        kn[p] = b;
    }
}
