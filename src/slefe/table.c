/* SLEFE tables: upper and lower piecewise-linear bounds of the anti-differences a_j^d on uniform
 * breakpoints, generated on first use (Lutterkort & Peters 2001; the construction of NOTES.md
 * A.1.4, DESIGN.md section 3). Nothing here is copied from SubLiME's or SLEEFE's published tables.
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

/* de Casteljau on n + 1 coefficients (n <= 15). */
static double decasteljau(int n, const double *coef, double t)
{
    double b[CRISP_SLEFE_MAX_DEGREE + 1];
    for (int i = 0; i <= n; i++)
        b[i] = coef[i];
    double s = 1.0 - t;
    for (int r = 1; r <= n; r++)
        for (int i = 0; i <= n - r; i++)
            b[i] = s * b[i] + t * b[i + 1];
    return b[0];
}

/* Largest gap between the chord of a (coefficients alpha, derivative coefficients dalpha) over
 * [t0, t1] and a itself. */
static double chord_gap(int d, const double *alpha, const double *dalpha, double t0, double t1)
{
    double a0 = decasteljau(d, alpha, t0), a1 = decasteljau(d, alpha, t1);
    double slope = (a1 - a0) / (t1 - t0);
    /* a' - slope goes from <= 0 to >= 0 across [t0, t1]: bisect to adjacent doubles. */
    double lo = t0, hi = t1;
    for (int it = 0; it < 200; it++) {
        double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi) break;
        if (decasteljau(d - 1, dalpha, mid) < slope)
            lo = mid;
        else
            hi = mid;
    }
    double best = 0.0;
    double cand[3] = {lo, hi, 0.5 * (lo + hi)};
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
                    gap[k] = chord_gap(d, alpha, dalpha, (double)k / m, (double)(k + 1) / m);
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
