/* The two-level u-intercept table of Wu & Peters 2015 (section 4, eq. 11) in CSR form: level 1 is
 * the face's uniform v-strips, level 2 the mu_i scan lines of each strip; each row holds the sorted
 * u of every crossing of the trim polylines with its scan line. Rows live in one array with row
 * offsets, so no row can overflow (the paper used a fixed 32 columns). The build is two passes over
 * the segments (count, then fill into exact places), then a sort of each (short) row.
 */
#include "trim_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Strip boundary nu_i; one expression used everywhere so that builder and test agree. */
static double strip_nu(double v0, double v1, int n, int i)
{
    return i >= n ? v1 : v0 + (v1 - v0) * ((double)i / n);
}

/* Scan line of row j of a strip [a, b) with mu rows: the centre of the row's interval. */
static double scan_v(double a, double b, uint32_t mu, uint32_t j)
{
    return a + (b - a) * ((j + 0.5) / mu);
}

void crisp_trim_rows_from_density(const double *rho_v, const double *vis_v, int strip_count,
                                  double v0, double v1, uint32_t *mu, int *clamped)
{
    double cap = floor((double)CRISP_TRIM_MAX_ROWS / strip_count);
    int clamp = 0;
    for (int i = 0; i < strip_count; i++) {
        double h = vis_v ? vis_v[2 * i + 1] - vis_v[2 * i]
                         : strip_nu(v0, v1, strip_count, i + 1) - strip_nu(v0, v1, strip_count, i);
        double m = rho_v[i] > 0.0 ? ceil(h * rho_v[i]) : 0.0;
        if (rho_v[i] > 0.0 && !(m >= 1.0)) m = 1.0;
        if (!(m <= cap)) { /* also infinity */
            m = cap;
            clamp = 1;
        }
        mu[i] = (uint32_t)m;
    }
    if (clamped) *clamped = clamp;
}

/* Rows j of a strip [a, b) with mu rows whose scan line lies in (lo, hi]. Returns 0 if none. */
static int row_range(double a, double b, uint32_t mu, double lo, double hi, uint32_t *j0,
                     uint32_t *j1)
{
    double h = (b - a) / mu;
    double fs = (lo - a) / h - 0.5, fe = (hi - a) / h - 0.5;
    /* fmin(fmax(x, -1), mu) without the library calls: NaN gives -1 as fmax's rule; only
     * floor's integer is used, the same for a zero of either sign */
    fs = fs > -1.0 ? fs : -1.0, fe = fe > -1.0 ? fe : -1.0;
    fs = fs < (double)mu ? fs : (double)mu, fe = fe < (double)mu ? fe : (double)mu;
    long s = (long)floor(fs) + 1, e = (long)floor(fe);
    if (s < 0) s = 0;
    if (e > (long)mu - 1) e = (long)mu - 1;
    /* Settle the ends on the exact scan-line values (the half-open rule depends on them). */
    while (s > 0 && scan_v(a, b, mu, (uint32_t)(s - 1)) > lo)
        s--;
    while (s < (long)mu && scan_v(a, b, mu, (uint32_t)s) <= lo)
        s++;
    if (e < s - 1) e = s - 1;
    while (e + 1 < (long)mu && scan_v(a, b, mu, (uint32_t)(e + 1)) <= hi)
        e++;
    while (e >= s && scan_v(a, b, mu, (uint32_t)e) > hi)
        e--;
    if (e < s) return 0;
    *j0 = (uint32_t)s;
    *j1 = (uint32_t)e;
    return 1;
}

/* Visit the crossings of segment (ua, va) - (ub, vb) with the table's scan lines. fill == 0 counts
 * into row_offset as differences (row r's count is the sum of row_offset[1..r + 1]), fill == 1
 * writes u at row_offset[r + 1]++. */
static void segment_crossings(crisp_trim_table *t, double ua, double va, double ub, double vb,
                              int fill)
{
    if (va == vb || !(isfinite(va) && isfinite(vb))) return;
    /* fmin and fmax without the library calls: va and vb are finite and differ */
    double lo = va < vb ? va : vb, hi = va < vb ? vb : va;
    if (hi < t->v0 || lo > t->v1) return;
    int n = t->strip_count;
    double span = t->v1 - t->v0;
    double fs = floor((lo - t->v0) / span * n), fe = floor((hi - t->v0) / span * n);
    int is = fs < 0 ? 0 : fs > n - 1 ? n - 1 : (int)fs;
    int ie = fe < 0 ? 0 : fe > n - 1 ? n - 1 : (int)fe;
    /* Neighbouring strips too: the floor above may be off by one at a boundary. */
    if (is > 0) is--;
    if (ie < n - 1) ie++;
    double slope = (ub - ua) / (vb - va);
    double umin = fmin(ua, ub), umax = fmax(ua, ub);
    for (int i = is; i <= ie; i++) {
        uint32_t mu = t->row_base[i + 1] - t->row_base[i];
        if (!mu) continue;
        double a = t->row_v[2 * i], b = t->row_v[2 * i + 1];
        uint32_t j0, j1;
        if (!row_range(a, b, mu, lo, hi, &j0, &j1)) continue;
        if (!fill) {
            /* rows j0..j1 each one more: as differences, summed after the pass */
            uint32_t r0 = t->row_base[i] + j0, r1 = t->row_base[i] + j1;
            t->row_offset[r0 + 1]++;
            if (r1 + 2 <= t->row_count) t->row_offset[r1 + 2]--;
            continue;
        }
        for (uint32_t j = j0; j <= j1; j++) {
            uint32_t r = t->row_base[i] + j;
            double u = ua + (scan_v(a, b, mu, j) - va) * slope;
            /* (strictly inside: the clamp below would return u itself) */
            if (!(u > umin && u < umax)) u = fmin(fmax(u, umin), umax);
            t->u[t->row_offset[r + 1]++] = u;
        }
    }
}

static void for_each_segment(crisp_trim_table *t, const crisp_trim_polyline *pl, int fill)
{
    for (int k = 0; k < pl->piece_count; k++)
        for (int q = pl->first[k]; q + 1 < pl->first[k + 1]; q++)
            segment_crossings(t, pl->uv[2 * q], pl->uv[2 * q + 1], pl->uv[2 * q + 2],
                              pl->uv[2 * q + 3], fill);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void sort_row(double *u, uint32_t n)
{
    if (n > 24) {
        qsort(u, n, sizeof *u, cmp_double);
        return;
    }
    for (uint32_t i = 1; i < n; i++) {
        double x = u[i];
        uint32_t j = i;
        while (j > 0 && u[j - 1] > x) {
            u[j] = u[j - 1];
            j--;
        }
        u[j] = x;
    }
}

crisp_status crisp_trim_table_build(const crisp_trim_table_desc *desc, crisp_trim_table *dest)
{
    if (!desc || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_trim_table_build: NULL argument");
    if (desc->strip_count < 1 || desc->strip_count > (1 << 20) || !desc->mu)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_table_build: strip_count %d, expected 1..1048576 with mu",
                           desc->strip_count);
    if (!(desc->v1 > desc->v0) || !isfinite(desc->v0) || !isfinite(desc->v1))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_table_build: v-range [%g, %g] is empty or not finite",
                           desc->v0, desc->v1);
    crisp_trim_table *t = dest;
    int n = desc->strip_count;
    uint64_t rows = 0;
    for (int i = 0; i < n; i++)
        rows += desc->mu[i];
    if (rows > CRISP_TRIM_MAX_ROWS)
        return crisp_error(CRISP_ERR_LIMIT,
                           "crisp_trim_table_build: %llu scan lines, at most %u allowed",
                           (unsigned long long)rows, CRISP_TRIM_MAX_ROWS);
    if (crisp_grow((void **)&t->row_base, &t->cap_strips, (size_t)n + 1, sizeof *t->row_base) ||
        crisp_grow((void **)&t->row_v, &t->cap_row_v, 2 * (size_t)n, sizeof *t->row_v) ||
        crisp_grow((void **)&t->row_scale, &t->cap_row_scale, (size_t)n, sizeof *t->row_scale) ||
        crisp_grow((void **)&t->row_offset, &t->cap_rows, (size_t)rows + 1, sizeof *t->row_offset))
        return crisp_error(CRISP_ERR_NO_MEMORY,
                           "crisp_trim_table_build: out of memory for %llu rows",
                           (unsigned long long)rows);
    t->v0 = desc->v0;
    t->v1 = desc->v1;
    t->strip_count = n;
    t->row_count = (uint32_t)rows;
    t->strip_scale = n / (desc->v1 - desc->v0);
    for (int i = 0; i < n; i++) {
        double a = strip_nu(t->v0, t->v1, n, i), b = strip_nu(t->v0, t->v1, n, i + 1);
        if (desc->row_v) {
            /* Inside the strip and not empty, else the whole strip. */
            double lo = fmax(desc->row_v[2 * i], a), hi = fmin(desc->row_v[2 * i + 1], b);
            if (hi > lo) a = lo, b = hi;
        }
        t->row_v[2 * i] = a;
        t->row_v[2 * i + 1] = b;
        t->row_scale[i] = desc->mu[i] / (b - a);
    }
    t->row_base[0] = 0;
    for (int i = 0; i < n; i++)
        t->row_base[i + 1] = t->row_base[i] + desc->mu[i];
    memset(t->row_offset, 0, sizeof *t->row_offset * ((size_t)rows + 1));
    const crisp_trim_polyline *pl = desc->polyline;
    t->all_inside = !pl || pl->piece_count == 0;
    if (t->all_inside) return CRISP_OK;

    /* Pass 1: count per row into row_offset[r + 1], guarding the 32-bit total. */
    for_each_segment(t, pl, 0);
    uint64_t total = 0;
    uint32_t run = 0; /* the differences' running sum (mod 2^32, as the counts were) */
    for (uint32_t r = 0; r < t->row_count; r++) {
        uint32_t c = run += t->row_offset[r + 1];
        t->row_offset[r + 1] = (uint32_t)total; /* start of row r; pass 2 advances it to the end */
        total += c;
    }
    if (total > UINT32_MAX / 2)
        return crisp_error(CRISP_ERR_LIMIT, "crisp_trim_table_build: %llu crossings, too many",
                           (unsigned long long)total);
    if (crisp_grow((void **)&t->u, &t->cap_u, total ? (size_t)total : 1, sizeof *t->u))
        return crisp_error(CRISP_ERR_NO_MEMORY,
                           "crisp_trim_table_build: out of memory for %llu crossings",
                           (unsigned long long)total);
    /* Pass 2: the same segments write their crossings. */
    for_each_segment(t, pl, 1);
    for (uint32_t r = 0; r < t->row_count; r++)
        sort_row(t->u + t->row_offset[r], t->row_offset[r + 1] - t->row_offset[r]);
    return CRISP_OK;
}

int crisp_trim_table_test(const crisp_trim_table *t, double u, double v)
{
    if (!(v >= t->v0 && v <= t->v1)) return 0;
    if (t->all_inside) return 1;
    int n = t->strip_count;
    int i = (int)((v - t->v0) * t->strip_scale); /* >= 0 here, so truncation is floor */
    if (i > n - 1) i = n - 1;
    uint32_t mu = t->row_base[i + 1] - t->row_base[i];
    if (!mu) return 0;
    double fj = (v - t->row_v[2 * i]) * t->row_scale[i];
    uint32_t j = fj > 0.0 ? (uint32_t)fj : 0; /* below the row range: the first row */
    if (j > mu - 1) j = mu - 1;
    uint32_t r = t->row_base[i] + j;
    /* Number of crossings strictly left of u: first index with t->u[k] >= u. */
    uint32_t lo = t->row_offset[r], hi = t->row_offset[r + 1];
    uint32_t first = lo;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (t->u[mid] < u)
            lo = mid + 1;
        else
            hi = mid;
    }
    return (int)((lo - first) & 1u);
}

size_t crisp_trim_table_bytes(const crisp_trim_table *t)
{
    size_t crossings = t->row_count ? t->row_offset[t->row_count] : 0;
    if (t->all_inside) crossings = 0;
    return sizeof(uint32_t) * ((size_t)t->strip_count + 1) +
           2 * sizeof(double) * (size_t)t->strip_count +
           sizeof(uint32_t) * ((size_t)t->row_count + 1) + sizeof(double) * crossings;
}

void crisp_trim_table_free(crisp_trim_table *t)
{
    if (!t) return;
    crisp_free(t->row_base);
    crisp_free(t->row_offset);
    crisp_free(t->u);
    crisp_free(t->row_v);
    crisp_free(t->row_scale);
    memset(t, 0, sizeof *t);
}
