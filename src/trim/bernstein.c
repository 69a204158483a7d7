/* Bernstein-form arithmetic for the trim module: restriction to a sub-interval by de Casteljau,
 * splitting, evaluation and products of tensor-product Bernstein polynomials (the product of
 * B_i^m B_k^n is C(m,i) C(n,k) / C(m+n,i+k) B_{i+k}^{m+n}; Farouki & Rajan 1988). */
#include "trim_internal.h"

#include <pthread.h>
#include <string.h>

#define BINOM_N (4 * CRISP_MAX_DEGREE + 2)

static double binom_table[BINOM_N][BINOM_N];
static pthread_once_t binom_once = PTHREAD_ONCE_INIT;

static void binom_init(void)
{
    for (int n = 0; n < BINOM_N; n++) {
        binom_table[n][0] = binom_table[n][n] = 1.0;
        for (int k = 1; k < n; k++)
            binom_table[n][k] = binom_table[n - 1][k - 1] + binom_table[n - 1][k];
    }
}

double crisp__trim_binom(int n, int k)
{
    /* Pascal's triangle, exact in doubles for n < 62. */
    if (k < 0 || k > n || n >= BINOM_N) return 0.0;
    pthread_once(&binom_once, binom_init);
    return binom_table[n][k];
}

void crisp__trim_split(const double *c, int d, int stride, double t, double *lo, double *hi)
{
    double w[CRISP_MAX_DEGREE * 2 + 2];
    if (d < 0 || d > 2 * CRISP_MAX_DEGREE + 1) return;
    for (int i = 0; i <= d; i++)
        w[i] = c[i * stride];
    lo[0] = w[0];
    hi[d] = w[d];
    for (int r = 1; r <= d; r++) {
        for (int i = 0; i <= d - r; i++)
            w[i] = w[i] + t * (w[i + 1] - w[i]);
        lo[r] = w[0];
        hi[d - r] = w[d - r];
    }
}

void crisp__trim_restrict(double *c, int d, int stride, double a, double b)
{
    if (a == 0.0 && b == 1.0) return;
    double lo[CRISP_MAX_DEGREE * 2 + 2], hi[CRISP_MAX_DEGREE * 2 + 2];
    /* Keep [0, b], then [a / b, 1] of that. */
    crisp__trim_split(c, d, stride, b, lo, hi);
    if (a > 0.0) {
        double s = b > 0.0 ? a / b : 0.0;
        double tmp[CRISP_MAX_DEGREE * 2 + 2];
        crisp__trim_split(lo, d, 1, s, tmp, hi);
        for (int i = 0; i <= d; i++)
            c[i * stride] = hi[i];
    } else {
        for (int i = 0; i <= d; i++)
            c[i * stride] = lo[i];
    }
}

double crisp__trim_eval(const double *c, int d, int stride, double t)
{
    double w[CRISP_MAX_DEGREE * 2 + 2];
    for (int i = 0; i <= d; i++)
        w[i] = c[i * stride];
    for (int r = 1; r <= d; r++)
        for (int i = 0; i <= d - r; i++)
            w[i] = w[i] + t * (w[i + 1] - w[i]);
    return w[0];
}

void crisp__trim_product2(const double *a, int am, int an, const double *b, int bm, int bn,
                          double *dest)
{
    int m = am + bm, n = an + bn;
    double ca[CRISP_MAX_DEGREE * 2 + 2], cb[CRISP_MAX_DEGREE * 2 + 2];
    double cm[CRISP_MAX_DEGREE * 4 + 2];
    double da[CRISP_MAX_DEGREE * 2 + 2], db[CRISP_MAX_DEGREE * 2 + 2];
    double dn[CRISP_MAX_DEGREE * 4 + 2];
    for (int i = 0; i <= am; i++)
        ca[i] = crisp__trim_binom(am, i);
    for (int i = 0; i <= bm; i++)
        cb[i] = crisp__trim_binom(bm, i);
    for (int i = 0; i <= m; i++)
        cm[i] = 1.0 / crisp__trim_binom(m, i);
    for (int j = 0; j <= an; j++)
        da[j] = crisp__trim_binom(an, j);
    for (int j = 0; j <= bn; j++)
        db[j] = crisp__trim_binom(bn, j);
    for (int j = 0; j <= n; j++)
        dn[j] = 1.0 / crisp__trim_binom(n, j);
    memset(dest, 0, sizeof *dest * (size_t)((m + 1) * (n + 1)));
    for (int j1 = 0; j1 <= an; j1++) {
        for (int j2 = 0; j2 <= bn; j2++) {
            double cj = da[j1] * db[j2] * dn[j1 + j2];
            double *row = dest + (j1 + j2) * (m + 1);
            const double *arow = a + j1 * (am + 1);
            const double *brow = b + j2 * (bm + 1);
            for (int i1 = 0; i1 <= am; i1++) {
                double ai = arow[i1] * cj * ca[i1];
                if (ai == 0.0) continue;
                for (int i2 = 0; i2 <= bm; i2++)
                    row[i1 + i2] += ai * brow[i2] * cb[i2] * cm[i1 + i2];
            }
        }
    }
}

void crisp__trim_eval_d(const double *c, int d, int stride, double t, double *val, double *der)
{
    double w[CRISP_MAX_DEGREE * 2 + 2];
    for (int i = 0; i <= d; i++)
        w[i] = c[i * stride];
    if (d == 0) {
        *val = w[0];
        *der = 0.0;
        return;
    }
    for (int r = 1; r < d; r++)
        for (int i = 0; i <= d - r; i++)
            w[i] = w[i] + t * (w[i + 1] - w[i]);
    *val = w[0] + t * (w[1] - w[0]);
    *der = d * (w[1] - w[0]);
}
