/* SLEFE tables: upper and lower piecewise-linear bounds of the anti-differences a_j^d on uniform
 * breakpoints, generated on first use (Lutterkort & Peters 2001; the construction of
 * docs/design.md section 3). Nothing here is copied from SubLiME's or SLEEFE's published tables.
 *
 * a_j^d (j = 1..d-1) has Bernstein coefficients alpha_i = -i(d-j)/d for i <= j, -j(d-i)/d for
 * i >= j. It is convex, so its interpolant on t_k = k/m is the best upper bound. For the lower
 * bound, e_k = max over segment k of (chord_k - a_j) is reached where a_j' equals the chord slope
 * (a_j' is increasing: one root, found by bisection to the last bit), and
 * L_j[k] = a_j(t_k) - max(e_{k-1}, e_k) - margin, the margin covering the rounding of the
 * evaluation of a_j (de Casteljau: a convex combination, error below a few ulps of max |alpha|).
 */
#include "slefe_internal.h"

#include <float.h>
#include <math.h>
#include <pthread.h>

/* Entries per degree d and segment count m: (d - 1) * (m + 1); over d = 2..15, m = 1..16. */
#define TABLE_TOTAL (105 * 152)

static double table_upper[TABLE_TOTAL];
static double table_lower[TABLE_TOTAL];
static double table_guard[CRISP_SLEFE_MAX_DEGREE + 1];
static int table_offset[CRISP_SLEFE_MAX_DEGREE + 1][CRISP_SLEFE_MAX_SEGMENTS + 1];
static pthread_once_t table_once = PTHREAD_ONCE_INIT;

/* sum_i coef[i] B_i^n(t), n <= 15, with B_i^n = C(n, i) t^i (1 - t)^(n - i) formed from powers:
 * O(n) per call (the tables take ~10^6 calls). Every term is a product of at most 2n + 1 rounded
 * factors and the basis sums to 1, so the error is below (2n + 2) ulps of max |coef|, inside the
 * table margin. Exact at t = 0 and t = 1. */
static double decasteljau(int n, const double *coef, double t)
{
    static const double binom[CRISP_SLEFE_MAX_DEGREE + 1][CRISP_SLEFE_MAX_DEGREE + 1] = {
        {1},
        {1, 1},
        {1, 2, 1},
        {1, 3, 3, 1},
        {1, 4, 6, 4, 1},
        {1, 5, 10, 10, 5, 1},
        {1, 6, 15, 20, 15, 6, 1},
        {1, 7, 21, 35, 35, 21, 7, 1},
        {1, 8, 28, 56, 70, 56, 28, 8, 1},
        {1, 9, 36, 84, 126, 126, 84, 36, 9, 1},
        {1, 10, 45, 120, 210, 252, 210, 120, 45, 10, 1},
        {1, 11, 55, 165, 330, 462, 462, 330, 165, 55, 11, 1},
        {1, 12, 66, 220, 495, 792, 924, 792, 495, 220, 66, 12, 1},
        {1, 13, 78, 286, 715, 1287, 1716, 1716, 1287, 715, 286, 78, 13, 1},
        {1, 14, 91, 364, 1001, 2002, 3003, 3432, 3003, 2002, 1001, 364, 91, 14, 1},
        {1, 15, 105, 455, 1365, 3003, 5005, 6435, 6435, 5005, 3003, 1365, 455, 105, 15, 1},
    };
    double tp[CRISP_SLEFE_MAX_DEGREE + 1], sp[CRISP_SLEFE_MAX_DEGREE + 1], s = 1.0 - t;
    tp[0] = sp[0] = 1.0;
    for (int i = 1; i <= n; i++) {
        tp[i] = tp[i - 1] * t;
        sp[i] = sp[i - 1] * s;
    }
    double v = 0.0;
    for (int i = 0; i <= n; i++)
        v += coef[i] * (binom[n][i] * tp[i] * sp[n - i]);
    return v;
}

/* Largest gap between the chord of a (coefficients alpha, derivative coefficients dalpha) over
 * [t0, t1] and a itself. */
static double chord_gap(int d, int j, const double *alpha, const double *dalpha, double t0,
                        double t1)
{
    double a0 = decasteljau(d, alpha, t0), a1 = decasteljau(d, alpha, t1);
    double slope = (a1 - a0) / (t1 - t0);
    /* a' - slope goes from <= 0 to >= 0 across [t0, t1]: safeguarded Newton (a'' =
     * d(d-1) B_{j-1}^{d-2} >= 0) inside a bracket that also shrinks like bisection when Newton
     * leaves it, to adjacent doubles or a step below 1e-17. Where the root lands only changes the
     * gap at second order; soundness comes from evaluating the gap at the points found. */
    double unit[CRISP_SLEFE_MAX_DEGREE + 1] = {0};
    unit[j - 1] = d * (d - 1.0);
    double lo = t0, hi = t1, t = 0.5 * (t0 + t1);
    for (int it = 0; it < 200; it++) {
        double g = decasteljau(d - 1, dalpha, t) - slope;
        if (g < 0)
            lo = t;
        else
            hi = t;
        double gp = decasteljau(d - 2, unit, t);
        double next = gp > 0 ? t - g / gp : 0.5 * (lo + hi);
        if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
        if (next <= lo || next >= hi || fabs(next - t) < 1e-17) break;
        t = next;
    }
    double best = 0.0;
    double cand[3] = {lo, hi, t};
    for (int c = 0; c < 3; c++) {
        double t = cand[c];
        double gap = a0 + (t - t0) * slope - decasteljau(d, alpha, t);
        if (gap > best) best = gap;
    }
    return best;
}

static void build_tables(void)
{
    int off = 0;
    for (int d = 2; d <= CRISP_SLEFE_MAX_DEGREE; d++) {
        double lsum = 0.0; /* sum over j of max_k |L_j[k]|, over every m: for the result guard */
        for (int m = 1; m <= CRISP_SLEFE_MAX_SEGMENTS; m++) {
            table_offset[d][m] = off;
            double lsum_m = 0.0;
            for (int j = 1; j < d; j++) {
                double alpha[CRISP_SLEFE_MAX_DEGREE + 1], dalpha[CRISP_SLEFE_MAX_DEGREE];
                double amax = 0.0;
                for (int i = 0; i <= d; i++) {
                    alpha[i] = i <= j ? -(double)(i * (d - j)) / d : -(double)(j * (d - i)) / d;
                    if (-alpha[i] > amax) amax = -alpha[i];
                }
                for (int i = 0; i < d; i++)
                    dalpha[i] = d * (alpha[i + 1] - alpha[i]);
                double margin = 8.0 * (d + 1) * DBL_EPSILON * amax;
                double *up = table_upper + off + (j - 1) * (m + 1);
                double *lo = table_lower + off + (j - 1) * (m + 1);
                double gap[CRISP_SLEFE_MAX_SEGMENTS];
                for (int k = 0; k < m; k++)
                    gap[k] = chord_gap(d, j, alpha, dalpha, (double)k / m, (double)(k + 1) / m);
                double lmax = 0.0;
                for (int k = 0; k <= m; k++) {
                    up[k] = decasteljau(d, alpha, (double)k / m);
                    double e = 0.0;
                    if (k > 0 && gap[k - 1] > e) e = gap[k - 1];
                    if (k < m && gap[k] > e) e = gap[k];
                    lo[k] = up[k] - e - margin;
                    if (-lo[k] > lmax) lmax = -lo[k];
                }
                lsum_m += lmax;
            }
            if (lsum_m > lsum) lsum = lsum_m;
            off += (d - 1) * (m + 1);
        }
        /* |l(t_k)| <= max|b|, |second difference| <= 4 max|b|, |U|, |L| <= max_k |L|: every
         * term of up[k] and lo[k] is bounded by max|b| (1 + 4 lsum); a sum of d such products
         * (plus the rounding of the tables and differences) errs by less than this. */
        table_guard[d] = 16.0 * (d + 1) * DBL_EPSILON * (1.0 + 4.0 * lsum);
    }
    table_guard[1] = 8.0 * DBL_EPSILON;
    table_guard[0] = 8.0 * DBL_EPSILON;
}

void crisp__slefe_tables_init(void)
{
    pthread_once(&table_once, build_tables);
}

crisp_slefe_table crisp__slefe_table(int degree, int segments)
{
    crisp_slefe_table t = {degree, segments, NULL, NULL, table_guard[degree]};
    if (degree >= 2) {
        t.upper = table_upper + table_offset[degree][segments];
        t.lower = table_lower + table_offset[degree][segments];
    }
    return t;
}

crisp_status crisp_slefe_table_get(int degree, int segments, crisp_slefe_table *dest)
{
    if (!dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_slefe_table_get: dest is NULL");
    if (degree < 2 || degree > CRISP_SLEFE_MAX_DEGREE)
        return crisp_error(CRISP_ERR_LIMIT, "crisp_slefe_table_get: degree %d outside 2..%d",
                           degree, CRISP_SLEFE_MAX_DEGREE);
    if (segments < 1 || segments > CRISP_SLEFE_MAX_SEGMENTS)
        return crisp_error(CRISP_ERR_LIMIT, "crisp_slefe_table_get: segments %d outside 1..%d",
                           segments, CRISP_SLEFE_MAX_SEGMENTS);
    crisp__slefe_tables_init();
    *dest = crisp__slefe_table(degree, segments);
    return CRISP_OK;
}
