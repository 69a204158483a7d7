/* Homogeneous Bézier pieces and patches: evaluation, derivatives, subdivision and control boxes
 * by de Casteljau's algorithm (The NURBS Book A1.5 and section 5.3; Farin, "Curves and Surfaces
 * for CAGD", ch. 4). Parameters are local, in [0, 1]; derivatives are with respect to them.
 */
#include "nurbs_internal.h"

#include <math.h>
#include <string.h>

/* de Casteljau on n + 1 points of nc doubles (packed), in place: leaves the point at t in q[0]. */
#if defined(__GNUC__)
#define INLINE_BODY inline __attribute__((always_inline))
#else
#define INLINE_BODY inline
#endif
static INLINE_BODY void decasteljau_body(double *q, int n, int nc, double t)
{
    const double s = 1.0 - t;
    for (int r = 1; r <= n; r++)
        for (int i = 0; i <= n - r; i++)
            for (int c = 0; c < nc; c++)
                q[i * nc + c] = s * q[i * nc + c] + t * q[(i + 1) * nc + c];
}

static void decasteljau(double *q, int n, int nc, double t)
{
    decasteljau_body(q, n, nc, t);
}

/* All Bernstein polynomials of degree n at t (The NURBS Book A1.3): positive weights, so the
 * sum over them is as stable as de Casteljau at O(n^2) for the basis and O(n) per point. */
static void all_bernstein(int n, double t, double *dest)
{
    const double s = 1.0 - t;
    dest[0] = 1.0;
    for (int j = 1; j <= n; j++) {
        double saved = 0.0;
        for (int k = 0; k < j; k++) {
            double tmp = dest[k];
            dest[k] = saved + s * tmp;
            saved = t * tmp;
        }
        dest[j] = saved;
    }
}

void crisp_bezier_curve_eval(const crisp_bezier_curve *b, double t, double *dest)
{
    const int nc = b->dim + 1;
    double bern[CRISP_MAX_DEGREE + 1], h[4] = {0, 0, 0, 0};
    all_bernstein(b->degree, t, bern);
    for (int i = 0; i <= b->degree; i++)
        for (int c = 0; c < nc; c++)
            h[c] += bern[i] * b->cpw[i * nc + c];
    for (int d = 0; d < b->dim; d++)
        dest[d] = h[d] / h[b->dim];
}

/* Homogeneous derivatives h[r] (r = 0..nd) of a Bézier polynomial of degree n at t: de Casteljau
 * down to m + 1 points (m = min(nd, n)), then r-th differences of those, reduced to one point,
 * times n! / (n - r)!. */
static void homogeneous_derivs(const double *cpw, int n, int nc, double t, int nd, double *h)
{
    double q[(CRISP_MAX_DEGREE + 1) * 4];
    double e[(CRISP__MAX_DERIV + 1) * 4];
    int m = nd < n ? nd : n;
    const double s = 1.0 - t;
    memcpy(q, cpw, (size_t)(n + 1) * nc * sizeof *q);
    for (int r = 1; r <= n - m; r++)
        for (int i = 0; i <= n - r; i++)
            for (int c = 0; c < nc; c++)
                q[i * nc + c] = s * q[i * nc + c] + t * q[(i + 1) * nc + c];
    double f = 1.0;
    for (int r = 0; r <= nd; r++) {
        if (r > m) {
            for (int c = 0; c < nc; c++)
                h[r * nc + c] = 0.0;
            continue;
        }
        memcpy(e, q, (size_t)(m + 1) * nc * sizeof *e);
        for (int k = 1; k <= r; k++) /* r-th forward difference */
            for (int i = 0; i <= m - k; i++)
                for (int c = 0; c < nc; c++)
                    e[i * nc + c] = e[(i + 1) * nc + c] - e[i * nc + c];
        decasteljau(e, m - r, nc, t);
        for (int c = 0; c < nc; c++)
            h[r * nc + c] = f * e[c];
        f *= n - r;
    }
}

void crisp_bezier_curve_derivs(const crisp_bezier_curve *b, double t, int nderiv, double *dest)
{
    static const double binom[CRISP__MAX_DERIV + 1][CRISP__MAX_DERIV + 1] = {
        {1, 0, 0, 0, 0}, {1, 1, 0, 0, 0}, {1, 2, 1, 0, 0}, {1, 3, 3, 1, 0}, {1, 4, 6, 4, 1}};
    const int dim = b->dim, nc = dim + 1;
    double h[(CRISP__MAX_DERIV + 1) * 4];
    if (nderiv < 0) nderiv = 0;
    if (nderiv > CRISP__MAX_DERIV) nderiv = CRISP__MAX_DERIV;
    homogeneous_derivs(b->cpw, b->degree, nc, t, nderiv, h);
    double w = h[dim];
    for (int r = 0; r <= nderiv; r++)
        for (int d = 0; d < dim; d++) {
            double v = h[r * nc + d];
            for (int i = 1; i <= r; i++)
                v -= binom[r][i] * h[i * nc + dim] * dest[(r - i) * dim + d];
            dest[r * dim + d] = v / w;
        }
}

/* Split n + 1 points at t: left gets the first point of every level, right the last. */
static void split_points(const double *src, ptrdiff_t src_stride, int n, int nc, double t,
                         double *left, double *right, ptrdiff_t dst_stride)
{
    double q[(CRISP_MAX_DEGREE + 1) * 4];
    const double s = 1.0 - t;
    for (int i = 0; i <= n; i++)
        memcpy(q + i * nc, src + i * src_stride, (size_t)nc * sizeof *q);
    memcpy(left, q, (size_t)nc * sizeof *q);
    memcpy(right + n * dst_stride, q + n * nc, (size_t)nc * sizeof *q);
    for (int r = 1; r <= n; r++) {
        for (int i = 0; i <= n - r; i++)
            for (int c = 0; c < nc; c++)
                q[i * nc + c] = s * q[i * nc + c] + t * q[(i + 1) * nc + c];
        memcpy(left + r * dst_stride, q, (size_t)nc * sizeof *q);
        memcpy(right + (n - r) * dst_stride, q + (n - r) * nc, (size_t)nc * sizeof *q);
    }
}

void crisp_bezier_curve_split(const crisp_bezier_curve *b, double t, crisp_bezier_curve *left,
                              crisp_bezier_curve *right)
{
    crisp_bezier_curve l = *b, r = *b;
    const int nc = b->dim + 1;
    split_points(b->cpw, nc, b->degree, nc, t, l.cpw, r.cpw, nc);
    double tm = b->t0 + t * (b->t1 - b->t0);
    l.t1 = tm;
    r.t0 = tm;
    *left = l;
    *right = r;
}

void crisp_bezier_curve_bbox(const crisp_bezier_curve *b, double *dest)
{
    const int dim = b->dim, nc = dim + 1;
    for (int d = 0; d < dim; d++) {
        dest[d] = INFINITY;
        dest[dim + d] = -INFINITY;
    }
    for (int i = 0; i <= b->degree; i++)
        for (int d = 0; d < dim; d++) {
            double x = b->cpw[i * nc + d] / b->cpw[i * nc + dim];
            if (x < dest[d]) dest[d] = x;
            if (x > dest[dim + d]) dest[dim + d] = x;
        }
}

void crisp_bezier_patch_eval(const crisp_bezier_patch *p, double s, double t, double *dest)
{
    double bs[CRISP_MAX_DEGREE + 1], bt[CRISP_MAX_DEGREE + 1], h[4] = {0, 0, 0, 0};
    const int nu = p->du + 1;
    all_bernstein(p->du, s, bs);
    all_bernstein(p->dv, t, bt);
    for (int j = 0; j <= p->dv; j++) {
        const double *row = p->cpw + (size_t)j * nu * 4;
        double r[4] = {0, 0, 0, 0};
        for (int i = 0; i < nu; i++)
            for (int c = 0; c < 4; c++)
                r[c] += bs[i] * row[i * 4 + c];
        for (int c = 0; c < 4; c++)
            h[c] += bt[j] * r[c];
    }
    for (int d = 0; d < 3; d++)
        dest[d] = h[d] / h[3];
}

void crisp__bezier_patch_eval_rows_s(const crisp_bezier_patch *p, double s, double *rows)
{
    double bs[CRISP_MAX_DEGREE + 1];
    const int nu = p->du + 1;
    all_bernstein(p->du, s, bs);
    for (int j = 0; j <= p->dv; j++) {
        const double *row = p->cpw + (size_t)j * nu * 4;
        double *r = rows + 4 * j;
        for (int c = 0; c < 4; c++)
            r[c] = 0;
        for (int i = 0; i < nu; i++)
            for (int c = 0; c < 4; c++)
                r[c] += bs[i] * row[i * 4 + c];
    }
}

void crisp__bezier_patch_eval_rows(const crisp_bezier_patch *p, const double *rows, double t,
                                   double *dest)
{
    double bt[CRISP_MAX_DEGREE + 1], h[4] = {0, 0, 0, 0};
    all_bernstein(p->dv, t, bt);
    for (int j = 0; j <= p->dv; j++)
        for (int c = 0; c < 4; c++)
            h[c] += bt[j] * rows[4 * j + c];
    for (int d = 0; d < 3; d++)
        dest[d] = h[d] / h[3];
}

/* homogeneous_derivs(cpw, n, 4, t, 1, h) for 4 components and the first derivative, the same
 * operations in the same order (so the same values bit for bit), with the component count fixed
 * so that the compiler can unroll and vectorise it: the hot path of tessellation. */
static INLINE_BODY void homogeneous_derivs1_4_body(const double *cpw, int n, double t, double *h)
{
    if (n == 0) {
        for (int c = 0; c < 4; c++)
            h[c] = cpw[c], h[4 + c] = 0.0;
        return;
    }
    double q[(CRISP_MAX_DEGREE + 1) * 4];
    const double s = 1.0 - t;
    memcpy(q, cpw, (size_t)(n + 1) * 4 * sizeof *q);
    for (int r = 1; r <= n - 1; r++)
        for (int i = 0; i <= n - r; i++)
            for (int c = 0; c < 4; c++)
                q[i * 4 + c] = s * q[i * 4 + c] + t * q[(i + 1) * 4 + c];
    const double f = (double)n;
    for (int c = 0; c < 4; c++) {
        h[c] = s * q[c] + t * q[4 + c];
        h[4 + c] = f * (q[4 + c] - q[c]);
    }
}

/* homogeneous_derivs1_4_body with the degree a constant where it is common (quadratic and
 * cubic rows: impeller.igs; quintic: Ventilator.stp; sextic: occt_linkrods.step), so that its
 * loops unroll. */
static void homogeneous_derivs1_4(const double *cpw, int n, double t, double *h)
{
    switch (n) {
    case 2:
        homogeneous_derivs1_4_body(cpw, 2, t, h);
        break;
    case 3:
        homogeneous_derivs1_4_body(cpw, 3, t, h);
        break;
    case 5:
        homogeneous_derivs1_4_body(cpw, 5, t, h);
        break;
    case 6:
        homogeneous_derivs1_4_body(cpw, 6, t, h);
        break;
    default:
        homogeneous_derivs1_4_body(cpw, n, t, h);
    }
}

void crisp__bezier_patch_rows_s(const crisp_bezier_patch *p, double s, double *rows)
{
    const int nu = p->du + 1;
    double h[2 * 4];
    for (int j = 0; j <= p->dv; j++) {
        homogeneous_derivs1_4(p->cpw + (size_t)j * nu * 4, p->du, s, h);
        memcpy(rows + j * 4, h, 4 * sizeof *rows);
        memcpy(rows + (p->dv + 1 + j) * 4, h + 4, 4 * sizeof *rows);
    }
}

/* crisp__bezier_patch_derivs_rows for v-degree dv (a constant in its common cases). */
static INLINE_BODY void derivs_rows_body(int dv, const double *rows, double t, double *point,
                                         double *d_s, double *d_t)
{
    double dsv[(CRISP_MAX_DEGREE + 1) * 4];
    memcpy(dsv, rows + (dv + 1) * 4, (size_t)(dv + 1) * 4 * sizeof *dsv);
    double a[2 * 4], as[4];
    homogeneous_derivs1_4_body(rows, dv, t, a); /* a: A, A_t */
    decasteljau_body(dsv, dv, 4, t);
    memcpy(as, dsv, sizeof as);
    double w = a[3], x[3];
    for (int d = 0; d < 3; d++)
        x[d] = a[d] / w;
    for (int d = 0; d < 3; d++) {
        if (point) point[d] = x[d];
        if (d_s) d_s[d] = (as[d] - as[3] * x[d]) / w;
        if (d_t) d_t[d] = (a[4 + d] - a[7] * x[d]) / w;
    }
}

void crisp__bezier_patch_derivs_rows(const crisp_bezier_patch *p, const double *rows, double t,
                                     double *point, double *d_s, double *d_t)
{
    switch (p->dv) {
    case 2:
        derivs_rows_body(2, rows, t, point, d_s, d_t);
        break;
    case 3:
        derivs_rows_body(3, rows, t, point, d_s, d_t);
        break;
    case 5:
        derivs_rows_body(5, rows, t, point, d_s, d_t);
        break;
    case 10:
        derivs_rows_body(10, rows, t, point, d_s, d_t);
        break;
    default:
        derivs_rows_body(p->dv, rows, t, point, d_s, d_t);
    }
}

void crisp_bezier_patch_derivs(const crisp_bezier_patch *p, double s, double t, double *point,
                               double *d_s, double *d_t)
{
    double rows[2 * (CRISP_MAX_DEGREE + 1) * 4];
    crisp__bezier_patch_rows_s(p, s, rows);
    crisp__bezier_patch_derivs_rows(p, rows, t, point, d_s, d_t);
}

void crisp_bezier_patch_split_u(const crisp_bezier_patch *p, double s, crisp_bezier_patch *lo,
                                crisp_bezier_patch *hi)
{
    crisp_bezier_patch l = *p, h = *p;
    l.cpw = lo->cpw;
    h.cpw = hi->cpw;
    const int nu = p->du + 1;
    for (int j = 0; j <= p->dv; j++)
        split_points(p->cpw + (size_t)j * nu * 4, 4, p->du, 4, s, l.cpw + (size_t)j * nu * 4,
                     h.cpw + (size_t)j * nu * 4, 4);
    double um = p->u0 + s * (p->u1 - p->u0);
    l.u1 = um;
    h.u0 = um;
    *lo = l;
    *hi = h;
}

void crisp_bezier_patch_split_v(const crisp_bezier_patch *p, double t, crisp_bezier_patch *lo,
                                crisp_bezier_patch *hi)
{
    crisp_bezier_patch l = *p, h = *p;
    l.cpw = lo->cpw;
    h.cpw = hi->cpw;
    const int nu = p->du + 1;
    for (int i = 0; i < nu; i++)
        split_points(p->cpw + (size_t)i * 4, (ptrdiff_t)nu * 4, p->dv, 4, t, l.cpw + (size_t)i * 4,
                     h.cpw + (size_t)i * 4, (ptrdiff_t)nu * 4);
    double vm = p->v0 + t * (p->v1 - p->v0);
    l.v1 = vm;
    h.v0 = vm;
    *lo = l;
    *hi = h;
}

void crisp_bezier_patch_bbox(const crisp_bezier_patch *p, double *dest)
{
    for (int d = 0; d < 3; d++) {
        dest[d] = INFINITY;
        dest[3 + d] = -INFINITY;
    }
    size_t n = (size_t)(p->du + 1) * (size_t)(p->dv + 1);
    for (size_t i = 0; i < n; i++) {
        const double *q = p->cpw + i * 4;
        for (int d = 0; d < 3; d++) {
            double x = q[d] / q[3];
            if (x < dest[d]) dest[d] = x;
            if (x > dest[3 + d]) dest[3 + d] = x;
        }
    }
}
