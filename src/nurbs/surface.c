/* Tensor-product B-spline and NURBS surfaces in homogeneous form: creation with validation,
 * evaluation, first and second partial derivatives by the rational quotient rule, knot insertion
 * in u or v, control box. Piegl & Tiller, "The NURBS Book": A3.5 (SurfacePoint), A3.6/A4.4
 * (surface derivatives, rational), A5.3 (SurfaceKnotIns, done row by row with A5.1).
 */
#include "nurbs_internal.h"

#include <math.h>
#include <string.h>

static crisp_status surface_alloc(int du, int dv, int nu, int nv, crisp_surface **dest)
{
    crisp_surface *s = crisp_calloc_array(1, sizeof *s);
    if (!s) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory allocating a surface");
    s->degree_u = du;
    s->degree_v = dv;
    s->count_u = nu;
    s->count_v = nv;
    s->knots_u = crisp_malloc_array((size_t)nu + (size_t)du + 1, sizeof *s->knots_u);
    s->knots_v = crisp_malloc_array((size_t)nv + (size_t)dv + 1, sizeof *s->knots_v);
    s->cpw = crisp_malloc_array((size_t)nu * (size_t)nv * 4, sizeof *s->cpw);
    if (!s->knots_u || !s->knots_v || !s->cpw) {
        crisp_surface_destroy(s);
        return crisp_error(CRISP_ERR_NO_MEMORY,
                           "out of memory for a surface of %d x %d control points", nu, nv);
    }
    *dest = s;
    return CRISP_OK;
}

crisp_status crisp_surface_create(int degree_u, int degree_v, int count_u, int count_v,
                                  const double *knots_u, const double *knots_v,
                                  const double *points, const double *weights, crisp_surface **dest)
{
    *dest = NULL;
    crisp_status st;
    if ((st = crisp__check_degree_count("surface u", degree_u, count_u)) ||
        (st = crisp__check_degree_count("surface v", degree_v, count_v)))
        return st;
    if ((long long)count_u * count_v > CRISP_MAX_CONTROL_POINTS)
        return crisp_error(CRISP_ERR_LIMIT,
                           "surface has %d x %d control points, more than the limit %d", count_u,
                           count_v, CRISP_MAX_CONTROL_POINTS);
    if ((st = crisp__check_knots("surface u", degree_u, count_u, knots_u)) ||
        (st = crisp__check_knots("surface v", degree_v, count_v, knots_v)))
        return st;
    if (!points) return crisp_error(CRISP_ERR_INVALID_ARG, "surface has no control points");
    int n = count_u * count_v;
    for (int i = 0; i < n; i++) {
        if (weights && !(isfinite(weights[i]) && weights[i] > 0.0))
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "surface weight %d (u %d, v %d) is %g: weights must be positive", i,
                               i % count_u, i / count_u, weights[i]);
        for (int d = 0; d < 3; d++)
            if (!isfinite(points[i * 3 + d]) ||
                (weights && !isfinite(points[i * 3 + d] * weights[i])))
                return crisp_error(CRISP_ERR_INVALID_ARG,
                                   "surface control point %d (u %d, v %d) coordinate %d is %g: "
                                   "expected a finite number (also once multiplied by its weight)",
                                   i, i % count_u, i / count_u, d, points[i * 3 + d]);
    }
    crisp_surface *s;
    st = surface_alloc(degree_u, degree_v, count_u, count_v, &s);
    if (st) return st;
    memcpy(s->knots_u, knots_u, (size_t)(count_u + degree_u + 1) * sizeof *knots_u);
    memcpy(s->knots_v, knots_v, (size_t)(count_v + degree_v + 1) * sizeof *knots_v);
    for (int i = 0; i < n; i++) {
        double w = weights ? weights[i] : 1.0;
        if (w != 1.0) s->rational = 1;
        for (int d = 0; d < 3; d++)
            s->cpw[i * 4 + d] = w * points[i * 3 + d];
        s->cpw[i * 4 + 3] = w;
    }
    *dest = s;
    return CRISP_OK;
}

void crisp_surface_destroy(crisp_surface *s)
{
    if (!s) return;
    crisp_free(s->knots_u);
    crisp_free(s->knots_v);
    crisp_free(s->cpw);
    crisp_free(s);
}

crisp_status crisp_surface_copy(const crisp_surface *s, crisp_surface **dest)
{
    *dest = NULL;
    crisp_surface *n;
    crisp_status st = surface_alloc(s->degree_u, s->degree_v, s->count_u, s->count_v, &n);
    if (st) return st;
    n->rational = s->rational;
    memcpy(n->knots_u, s->knots_u, (size_t)(s->count_u + s->degree_u + 1) * sizeof *n->knots_u);
    memcpy(n->knots_v, s->knots_v, (size_t)(s->count_v + s->degree_v + 1) * sizeof *n->knots_v);
    memcpy(n->cpw, s->cpw, (size_t)s->count_u * (size_t)s->count_v * 4 * sizeof *n->cpw);
    *dest = n;
    return CRISP_OK;
}

void crisp_surface_domain(const crisp_surface *s, double *dest)
{
    dest[0] = s->knots_u[s->degree_u];
    dest[1] = s->knots_u[s->count_u];
    dest[2] = s->knots_v[s->degree_v];
    dest[3] = s->knots_v[s->count_v];
}

static double clampd(double t, double lo, double hi)
{
    return t < lo ? lo : t > hi ? hi : t;
}

void crisp_surface_eval(const crisp_surface *s, double u, double v, double *dest)
{
    const int pu = s->degree_u, pv = s->degree_v;
    double nu[CRISP_MAX_DEGREE + 1], nv[CRISP_MAX_DEGREE + 1];
    u = clampd(u, s->knots_u[pu], s->knots_u[s->count_u]);
    v = clampd(v, s->knots_v[pv], s->knots_v[s->count_v]);
    int ku = crisp__find_span(s->knots_u, pu, s->count_u, u);
    int kv = crisp__find_span(s->knots_v, pv, s->count_v, v);
    crisp__basis_funs(s->knots_u, pu, ku, u, nu);
    crisp__basis_funs(s->knots_v, pv, kv, v, nv);
    double h[4] = {0, 0, 0, 0};
    for (int l = 0; l <= pv; l++) {
        const double *row = s->cpw + ((size_t)(kv - pv + l) * s->count_u + (size_t)(ku - pu)) * 4;
        double t[4] = {0, 0, 0, 0};
        for (int i = 0; i <= pu; i++)
            for (int d = 0; d < 4; d++)
                t[d] += nu[i] * row[i * 4 + d];
        for (int d = 0; d < 4; d++)
            h[d] += nv[l] * t[d];
    }
    for (int d = 0; d < 3; d++)
        dest[d] = h[d] / h[3];
}

void crisp_surface_derivs(const crisp_surface *s, double u, double v, double *p, double *su,
                          double *sv, double *suu, double *suv, double *svv)
{
    const int pu = s->degree_u, pv = s->degree_v;
    int nd = (suu || suv || svv) ? 2 : (su || sv) ? 1 : 0;
    double du[3 * (CRISP_MAX_DEGREE + 1)], dv[3 * (CRISP_MAX_DEGREE + 1)];
    u = clampd(u, s->knots_u[pu], s->knots_u[s->count_u]);
    v = clampd(v, s->knots_v[pv], s->knots_v[s->count_v]);
    int ku = crisp__find_span(s->knots_u, pu, s->count_u, u);
    int kv = crisp__find_span(s->knots_v, pv, s->count_v, v);
    crisp__basis_ders(s->knots_u, pu, ku, u, nd, du);
    crisp__basis_ders(s->knots_v, pv, kv, v, nd, dv);

    /* a[k][l]: homogeneous derivative d^(k+l) / du^k dv^l, k + l <= nd. */
    double a[3][3][4];
    memset(a, 0, sizeof a);
    for (int l = 0; l <= pv; l++) {
        const double *row = s->cpw + ((size_t)(kv - pv + l) * s->count_u + (size_t)(ku - pu)) * 4;
        double t[3][4]; /* t[k] = sum_i N_i^(k)(u) row[i] */
        for (int k = 0; k <= nd; k++) {
            for (int d = 0; d < 4; d++)
                t[k][d] = 0.0;
            for (int i = 0; i <= pu; i++) {
                double b = du[k * (pu + 1) + i];
                for (int d = 0; d < 4; d++)
                    t[k][d] += b * row[i * 4 + d];
            }
        }
        for (int k = 0; k <= nd; k++)
            for (int m = 0; m <= nd - k; m++) {
                double b = dv[m * (pv + 1) + l];
                for (int d = 0; d < 4; d++)
                    a[k][m][d] += b * t[k][d];
            }
    }
    /* A4.4 quotient rule: S_kl = (A_kl - sum binom(k,i) binom(l,j) w_ij S_(k-i)(l-j)) / w,
     * over (i, j) != (0, 0). */
    static const double binom[3][3] = {{1, 0, 0}, {1, 1, 0}, {1, 2, 1}};
    double sk[3][3][3];
    double w = a[0][0][3];
    for (int k = 0; k <= nd; k++)
        for (int l = 0; l <= nd - k; l++)
            for (int d = 0; d < 3; d++) {
                double val = a[k][l][d];
                for (int i = 0; i <= k; i++)
                    for (int j = 0; j <= l; j++) {
                        if (i == 0 && j == 0) continue;
                        val -= binom[k][i] * binom[l][j] * a[i][j][3] * sk[k - i][l - j][d];
                    }
                sk[k][l][d] = val / w;
            }
    for (int d = 0; d < 3; d++) {
        if (p) p[d] = sk[0][0][d];
        if (su) su[d] = sk[1][0][d];
        if (sv) sv[d] = sk[0][1][d];
        if (suu) suu[d] = sk[2][0][d];
        if (suv) suv[d] = sk[1][1][d];
        if (svv) svv[d] = sk[0][2][d];
    }
}

/* Knot insertion in one direction: every row (dir 0, along u) or column (dir 1, along v) is a
 * curve that gets the same Boehm insertion. */
static crisp_status surface_insert(crisp_surface *s, int dir, double t, int times)
{
    const int p = dir ? s->degree_v : s->degree_u;
    const int cnt = dir ? s->count_v : s->count_u;
    const int other = dir ? s->count_u : s->count_v;
    double *kn = dir ? s->knots_v : s->knots_u;
    const char *name = dir ? "v" : "u";
    if (!(t >= kn[p] && t <= kn[cnt]))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s knot %.17g to insert is outside the surface domain [%.17g, %.17g]",
                           name, t, kn[p], kn[cnt]);
    if (times < 0)
        return crisp_error(CRISP_ERR_INVALID_ARG, "knot insertion count %d is negative", times);
    if (times == 0) return CRISP_OK;
    int n = cnt + p + 1;
    int sm = crisp__multiplicity(kn, n, t);
    if (sm + times > p)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s knot %.17g has multiplicity %d: inserting it %d more times exceeds "
                           "the degree %d",
                           name, t, sm, times, p);
    if ((long long)(cnt + times) * other > CRISP_MAX_CONTROL_POINTS)
        return crisp_error(CRISP_ERR_LIMIT, "knot insertion would exceed %d control points",
                           CRISP_MAX_CONTROL_POINTS);
    int k = crisp__insert_index(kn, p, cnt, t);
    double *knots = crisp_malloc_array((size_t)(n + times), sizeof *knots);
    double *cpw = crisp_malloc_array((size_t)(cnt + times) * (size_t)other * 4, sizeof *cpw);
    if (!knots || !cpw) {
        crisp_free(knots);
        crisp_free(cpw);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory inserting a knot");
    }
    int new_nu = dir ? s->count_u : s->count_u + times;
    for (int o = 0; o < other; o++) {
        if (dir == 0)
            crisp__insert_seq(kn, p, cnt, k, sm, times, t, 4, s->cpw + (size_t)o * cnt * 4, 4,
                              cpw + (size_t)o * new_nu * 4, 4);
        else
            crisp__insert_seq(kn, p, cnt, k, sm, times, t, 4, s->cpw + (size_t)o * 4,
                              (ptrdiff_t)s->count_u * 4, cpw + (size_t)o * 4,
                              (ptrdiff_t)new_nu * 4);
    }
    crisp__insert_knots(kn, p, cnt, k, times, t, knots);
    crisp_free(kn);
    crisp_free(s->cpw);
    s->cpw = cpw;
    if (dir) {
        s->knots_v = knots;
        s->count_v += times;
    } else {
        s->knots_u = knots;
        s->count_u += times;
    }
    return CRISP_OK;
}

crisp_status crisp_surface_insert_knot_u(crisp_surface *s, double u, int times)
{
    return surface_insert(s, 0, u, times);
}

crisp_status crisp_surface_insert_knot_v(crisp_surface *s, double v, int times)
{
    return surface_insert(s, 1, v, times);
}

void crisp_surface_bbox(const crisp_surface *s, double *dest)
{
    for (int d = 0; d < 3; d++) {
        dest[d] = INFINITY;
        dest[3 + d] = -INFINITY;
    }
    size_t n = (size_t)s->count_u * (size_t)s->count_v;
    for (size_t i = 0; i < n; i++) {
        const double *q = s->cpw + i * 4;
        for (int d = 0; d < 3; d++) {
            double x = q[d] / q[3];
            if (x < dest[d]) dest[d] = x;
            if (x > dest[3 + d]) dest[3 + d] = x;
        }
    }
}
