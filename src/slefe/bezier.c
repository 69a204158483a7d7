/* SLEFEs of univariate Bézier functions and of Bézier curve pieces (per component; rational
 * pieces in homogeneous form, then interval division per segment). Lutterkort & Peters 2001,
 * docs/design.md section 3: p(t) = l(t) + sum_j second_difference_{j-1} a_j(t). */
#include "slefe_internal.h"

int crisp__slefe_all_finite(const double *v, int n, int stride)
{
    int ok = 1;
    for (int i = 0; i < n; i++)
        ok &= fabs(v[i * stride]) <= CRISP_SLEFE_MAX_MAGNITUDE;
    return ok;
}

crisp_status crisp__slefe_check(const char *fn, int degree, int segments)
{
    if (degree < CRISP_SLEFE_MIN_DEGREE || degree > CRISP_SLEFE_MAX_DEGREE)
        return crisp_error(CRISP_ERR_LIMIT, "%s: degree %d outside %d..%d", fn, degree,
                           CRISP_SLEFE_MIN_DEGREE, CRISP_SLEFE_MAX_DEGREE);
    if (segments < 1 || segments > CRISP_SLEFE_MAX_SEGMENTS)
        return crisp_error(CRISP_ERR_LIMIT, "%s: segments %d outside 1..%d", fn, segments,
                           CRISP_SLEFE_MAX_SEGMENTS);
    return CRISP_OK;
}

crisp_status crisp_slefe_bezier(int degree, const double *coef, int stride, int segments,
                                double *lo, double *up)
{
    crisp_status s = crisp__slefe_check("crisp_slefe_bezier", degree, segments);
    if (s) return s;
    if (!coef || !lo || !up)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_slefe_bezier: NULL coefficients or output");
    if (stride < 1)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_slefe_bezier: stride %d < 1", stride);
    if (!crisp__slefe_all_finite(coef, degree + 1, stride))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "crisp_slefe_bezier: non-finite or huge (above 1e300) coefficient");
    crisp__slefe_tables_init();
    crisp_slefe_table t = crisp__slefe_table(degree, segments);
    crisp__slefe_kernel(degree, coef, stride, &t, segments, lo, 1, up, 1);
    return CRISP_OK;
}

static crisp_status check_curve(const char *fn, const crisp_bezier_curve *c, int segments,
                                const void *out1, const void *out2)
{
    if (!c || !out1 || !out2)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL curve or output", fn);
    if (c->dim != 2 && c->dim != 3)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: curve dimension %d, expected 2 or 3", fn,
                           c->dim);
    crisp_status s = crisp__slefe_check(fn, c->degree, segments);
    if (s) return s;
    if (!crisp__slefe_all_finite(c->cpw, (c->degree + 1) * (c->dim + 1), 1))
        return crisp_error(CRISP_ERR_NUMERIC, "%s: non-finite or huge (above 1e300) control point",
                           fn);
    return CRISP_OK;
}

crisp_status crisp_slefe_curve(const crisp_bezier_curve *c, int segments, double *lo, double *up)
{
    crisp_status s = check_curve("crisp_slefe_curve", c, segments, lo, up);
    if (s) return s;
    crisp__slefe_tables_init();
    crisp_slefe_table t = crisp__slefe_table(c->degree, segments);
    int ncomp = CRISP_SLEFE_CURVE_COMPONENTS(c);
    for (int i = 0; i < ncomp; i++)
        crisp__slefe_kernel(c->degree, c->cpw + i, c->dim + 1, &t, segments, lo + i, ncomp, up + i,
                            ncomp);
    return CRISP_OK;
}

crisp_status crisp_slefe_curve_boxes(const crisp_bezier_curve *c, int segments, double *box_lo,
                                     double *box_hi)
{
    crisp_status s = check_curve("crisp_slefe_curve_boxes", c, segments, box_lo, box_hi);
    if (s) return s;
    crisp__slefe_tables_init();
    crisp_slefe_table t = crisp__slefe_table(c->degree, segments);
    int dim = c->dim, ncomp = CRISP_SLEFE_CURVE_COMPONENTS(c), m = segments;
    double lo[(CRISP_SLEFE_MAX_SEGMENTS + 1) * 4], up[(CRISP_SLEFE_MAX_SEGMENTS + 1) * 4];
    for (int i = 0; i < ncomp; i++)
        crisp__slefe_kernel(c->degree, c->cpw + i, dim + 1, &t, m, lo + i, ncomp, up + i, ncomp);
    /* Convex hull: each component lies within its control values over the whole piece. */
    double hl[4] = {INFINITY, INFINITY, INFINITY, INFINITY};
    double hh[4] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int j = 0; j <= c->degree; j++)
        for (int i = 0; i < ncomp; i++) {
            hl[i] = crisp__min(hl[i], c->cpw[j * (dim + 1) + i]);
            hh[i] = crisp__max(hh[i], c->cpw[j * (dim + 1) + i]);
        }
    for (int k = 0; k < m; k++) {
        /* The piecewise-linear bounds on segment k lie between their end values. */
        double cl[4] = {0, 0, 0, 0}, cu[4] = {0, 0, 0, 0};
        for (int i = 0; i < ncomp; i++) {
            cl[i] = crisp__max(crisp__min(lo[k * ncomp + i], lo[(k + 1) * ncomp + i]), hl[i]);
            cu[i] = crisp__min(crisp__max(up[k * ncomp + i], up[(k + 1) * ncomp + i]), hh[i]);
        }
        if (c->rational && !(cl[dim] > 0.0))
            return crisp_error(CRISP_ERR_NUMERIC,
                               "crisp_slefe_curve_boxes: lower bound %g of w on segment %d of "
                               "%d is not positive",
                               cl[dim], k, m);
        for (int i = 0; i < dim; i++) {
            if (c->rational)
                crisp__slefe_divide(cl[i], cu[i], cl[dim], cu[dim], &box_lo[k * dim + i],
                                    &box_hi[k * dim + i]);
            else {
                box_lo[k * dim + i] = cl[i];
                box_hi[k * dim + i] = cu[i];
            }
        }
    }
    return CRISP_OK;
}

int crisp_slefe_tess_level(double w_px, int segments, double eps)
{
    if (!(w_px > 0.0) || !(eps > 0.0) || segments < 1) return 1;
    double tau = ceil(segments * sqrt(w_px / eps));
    if (!(tau < 1e9)) return 1000000000;
    return tau < 1.0 ? 1 : (int)tau;
}
