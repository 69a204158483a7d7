/* B-spline and NURBS curves (2D, 3D) in homogeneous form: creation with validation, evaluation,
 * derivatives by the rational quotient rule, knot insertion, reversal, trimming, control box.
 * Piegl & Tiller, "The NURBS Book": A2.2/A2.3 basis functions, A3.1/A4.1 evaluation, A4.2
 * rational derivatives, A5.1 knot insertion.
 */
#include "nurbs_internal.h"

#include <math.h>
#include <string.h>

static crisp_status curve_alloc(int dim, int degree, int count, crisp_curve **dest)
{
    crisp_curve *c = crisp_calloc_array(1, sizeof *c);
    if (!c) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory allocating a curve");
    c->dim = dim;
    c->degree = degree;
    c->count = count;
    c->knots = crisp_malloc_array((size_t)count + (size_t)degree + 1, sizeof *c->knots);
    c->cpw = crisp_malloc_array((size_t)count * (size_t)(dim + 1), sizeof *c->cpw);
    if (!c->knots || !c->cpw) {
        crisp_curve_destroy(c);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a curve of %d control points",
                           count);
    }
    *dest = c;
    return CRISP_OK;
}

crisp_status crisp_curve_create(int dim, int degree, int count, const double *knots,
                                const double *points, const double *weights, crisp_curve **dest)
{
    *dest = NULL;
    if (dim != 2 && dim != 3)
        return crisp_error(CRISP_ERR_INVALID_ARG, "curve dimension %d: expected 2 or 3", dim);
    crisp_status st = crisp__check_degree_count("curve", degree, count);
    if (st) return st;
    st = crisp__check_knots("curve", degree, count, knots);
    if (st) return st;
    if (!points) return crisp_error(CRISP_ERR_INVALID_ARG, "curve has no control points");
    for (int i = 0; i < count; i++) {
        if (weights && !(isfinite(weights[i]) && weights[i] > 0.0))
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "curve weight %d is %g: weights must be positive", i, weights[i]);
        for (int d = 0; d < dim; d++)
            if (!isfinite(points[i * dim + d]) ||
                (weights && !isfinite(points[i * dim + d] * weights[i])))
                return crisp_error(
                    CRISP_ERR_INVALID_ARG,
                    "curve control point %d coordinate %d is %g: expected a finite number "
                    "(also once multiplied by its weight)",
                    i, d, points[i * dim + d]);
    }
    crisp_curve *c;
    st = curve_alloc(dim, degree, count, &c);
    if (st) return st;
    memcpy(c->knots, knots, (size_t)(count + degree + 1) * sizeof *knots);
    c->rational = 0;
    for (int i = 0; i < count; i++) {
        double w = weights ? weights[i] : 1.0;
        if (w != 1.0) c->rational = 1;
        for (int d = 0; d < dim; d++)
            c->cpw[i * (dim + 1) + d] = w * points[i * dim + d];
        c->cpw[i * (dim + 1) + dim] = w;
    }
    *dest = c;
    return CRISP_OK;
}

void crisp_curve_destroy(crisp_curve *c)
{
    if (!c) return;
    crisp_free(c->knots);
    crisp_free(c->cpw);
    crisp_free(c);
}

crisp_status crisp_curve_copy(const crisp_curve *c, crisp_curve **dest)
{
    *dest = NULL;
    crisp_curve *n = NULL;
    crisp_status st = curve_alloc(c->dim, c->degree, c->count, &n);
    if (st) return st;
    n->rational = c->rational;
    memcpy(n->knots, c->knots, (size_t)(c->count + c->degree + 1) * sizeof *n->knots);
    memcpy(n->cpw, c->cpw, (size_t)c->count * (size_t)(c->dim + 1) * sizeof *n->cpw);
    *dest = n;
    return CRISP_OK;
}

void crisp_curve_domain(const crisp_curve *c, double *t0, double *t1)
{
    *t0 = c->knots[c->degree];
    *t1 = c->knots[c->count];
}

static double clamp_domain(const double *knots, int degree, int count, double t)
{
    if (t < knots[degree]) return knots[degree];
    if (t > knots[count]) return knots[count];
    return t;
}

void crisp_curve_eval(const crisp_curve *c, double t, double *dest)
{
    const int p = c->degree, nc = c->dim + 1;
    double n[CRISP_MAX_DEGREE + 1];
    t = clamp_domain(c->knots, p, c->count, t);
    int k = crisp__find_span(c->knots, p, c->count, t);
    crisp__basis_funs(c->knots, p, k, t, n);
    double h[4] = {0, 0, 0, 0};
    const double *cp = c->cpw + (size_t)(k - p) * nc;
    for (int j = 0; j <= p; j++)
        for (int d = 0; d < nc; d++)
            h[d] += n[j] * cp[j * nc + d];
    for (int d = 0; d < c->dim; d++)
        dest[d] = h[d] / h[c->dim];
}

void crisp_curve_derivs(const crisp_curve *c, double t, int nderiv, double *dest)
{
    const int p = c->degree, nc = c->dim + 1, dim = c->dim;
    double ders[(CRISP__MAX_DERIV + 1) * (CRISP_MAX_DEGREE + 1)];
    double h[CRISP__MAX_DERIV + 1][4];
    if (nderiv < 0) nderiv = 0;
    if (nderiv > CRISP__MAX_DERIV) nderiv = CRISP__MAX_DERIV;
    t = clamp_domain(c->knots, p, c->count, t);
    int k = crisp__find_span(c->knots, p, c->count, t);
    crisp__basis_ders(c->knots, p, k, t, nderiv, ders);
    const double *cp = c->cpw + (size_t)(k - p) * nc;
    for (int r = 0; r <= nderiv; r++) {
        for (int d = 0; d < nc; d++)
            h[r][d] = 0.0;
        for (int j = 0; j <= p; j++)
            for (int d = 0; d < nc; d++)
                h[r][d] += ders[r * (p + 1) + j] * cp[j * nc + d];
    }
    /* A4.2: C^(r) = (A^(r) - sum_{i=1..r} binom(r, i) w^(i) C^(r-i)) / w. */
    static const double binom[CRISP__MAX_DERIV + 1][CRISP__MAX_DERIV + 1] = {
        {1, 0, 0, 0, 0}, {1, 1, 0, 0, 0}, {1, 2, 1, 0, 0}, {1, 3, 3, 1, 0}, {1, 4, 6, 4, 1}};
    double w = h[0][dim];
    for (int r = 0; r <= nderiv; r++) {
        for (int d = 0; d < dim; d++) {
            double v = h[r][d];
            for (int i = 1; i <= r; i++)
                v -= binom[r][i] * h[i][dim] * dest[(r - i) * dim + d];
            dest[r * dim + d] = v / w;
        }
    }
}

crisp_status crisp_curve_insert_knot(crisp_curve *c, double t, int times)
{
    const int p = c->degree, nc = c->dim + 1;
    double t0 = c->knots[p], t1 = c->knots[c->count];
    if (!(t >= t0 && t <= t1))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "knot %.17g to insert is outside the curve domain [%.17g, %.17g]", t, t0,
                           t1);
    if (times < 0)
        return crisp_error(CRISP_ERR_INVALID_ARG, "knot insertion count %d is negative", times);
    if (times == 0) return CRISP_OK;
    int n = c->count + p + 1;
    int s = crisp__multiplicity(c->knots, n, t);
    if (s + times > p)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "knot %.17g has multiplicity %d: inserting it %d more times exceeds the "
                           "degree %d",
                           t, s, times, p);
    if ((long)c->count + times > CRISP_MAX_CONTROL_POINTS)
        return crisp_error(CRISP_ERR_LIMIT, "knot insertion would exceed %d control points",
                           CRISP_MAX_CONTROL_POINTS);
    int k = crisp__insert_index(c->knots, p, c->count, t);
    double *knots = crisp_malloc_array((size_t)(n + times), sizeof *knots);
    double *cpw = crisp_malloc_array((size_t)(c->count + times) * (size_t)nc, sizeof *cpw);
    if (!knots || !cpw) {
        crisp_free(knots);
        crisp_free(cpw);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory inserting a knot");
    }
    crisp__insert_seq(c->knots, p, c->count, k, s, times, t, nc, c->cpw, nc, cpw, nc);
    crisp__insert_knots(c->knots, p, c->count, k, times, t, knots);
    crisp_free(c->knots);
    crisp_free(c->cpw);
    c->knots = knots;
    c->cpw = cpw;
    c->count += times;
    return CRISP_OK;
}

/* a + b - x, exact at the domain ends. */
static double mirror(double a, double b, double x)
{
    if (x == a) return b;
    if (x == b) return a;
    return a + b - x;
}

void crisp_curve_reverse(crisp_curve *c)
{
    const int nc = c->dim + 1;
    int n = c->count + c->degree + 1;
    double a = c->knots[c->degree], b = c->knots[c->count];
    for (int i = 0, j = n - 1; i < j; i++, j--) {
        double ki = c->knots[i], kj = c->knots[j];
        c->knots[i] = mirror(a, b, kj);
        c->knots[j] = mirror(a, b, ki);
    }
    if (n % 2) c->knots[n / 2] = mirror(a, b, c->knots[n / 2]);
    /* Rounding in a + b - x may break monotonicity by an ulp or leave [a, b]; repair both. */
    for (int i = c->degree + 1; i < c->count; i++) {
        if (c->knots[i] < a) c->knots[i] = a;
        if (c->knots[i] > b) c->knots[i] = b;
    }
    for (int i = 1; i < n; i++)
        if (c->knots[i] < c->knots[i - 1]) c->knots[i] = c->knots[i - 1];
    for (int i = 0, j = c->count - 1; i < j; i++, j--) {
        for (int d = 0; d < nc; d++) {
            double tmp = c->cpw[i * nc + d];
            c->cpw[i * nc + d] = c->cpw[j * nc + d];
            c->cpw[j * nc + d] = tmp;
        }
    }
}

/* Insert t until its multiplicity is at least the degree. */
static crisp_status raise_to_degree(crisp_curve *c, double t)
{
    int s = crisp__multiplicity(c->knots, c->count + c->degree + 1, t);
    if (s >= c->degree) return CRISP_OK;
    return crisp_curve_insert_knot(c, t, c->degree - s);
}

crisp_status crisp_curve_trim(const crisp_curve *c, double t0, double t1, crisp_curve **dest)
{
    *dest = NULL;
    const int p = c->degree, nc = c->dim + 1;
    double a = c->knots[p], b = c->knots[c->count];
    if (!(t0 < t1 && t0 >= a && t1 <= b))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "trim interval [%.17g, %.17g] is not an increasing interval inside the "
                           "curve domain [%.17g, %.17g]",
                           t0, t1, a, b);
    crisp_curve *w;
    crisp_status st = crisp_curve_copy(c, &w);
    if (st) return st;
    if ((st = raise_to_degree(w, t0)) || (st = raise_to_degree(w, t1))) {
        crisp_curve_destroy(w);
        return st;
    }
    int n = w->count + p + 1;
    int l0 = n - 1, f1 = 0; /* last index of t0, first index of t1 */
    while (w->knots[l0] != t0)
        l0--;
    while (w->knots[f1] != t1)
        f1++;
    int j0 = l0 - p, j1 = f1 - 1; /* control points f(t0^p) and f(t1^p) */
    int m = j1 - j0 + 1;
    crisp_curve *r;
    st = curve_alloc(c->dim, p, m, &r);
    if (st) {
        crisp_curve_destroy(w);
        return st;
    }
    for (int i = 0; i <= p; i++) {
        r->knots[i] = t0;
        r->knots[m + i] = t1;
    }
    memcpy(r->knots + p + 1, w->knots + l0 + 1, (size_t)(f1 - 1 - l0) * sizeof *r->knots);
    memcpy(r->cpw, w->cpw + (size_t)j0 * nc, (size_t)m * nc * sizeof *r->cpw);
    r->rational = c->rational;
    crisp_curve_destroy(w);
    *dest = r;
    return CRISP_OK;
}

void crisp_curve_bbox(const crisp_curve *c, double *dest)
{
    const int dim = c->dim, nc = dim + 1;
    for (int d = 0; d < dim; d++) {
        dest[d] = INFINITY;
        dest[dim + d] = -INFINITY;
    }
    for (int i = 0; i < c->count; i++) {
        const double *q = c->cpw + (size_t)i * nc;
        for (int d = 0; d < dim; d++) {
            double x = q[d] / q[dim];
            if (x < dest[d]) dest[d] = x;
            if (x > dest[dim + d]) dest[dim + d] = x;
        }
    }
}
