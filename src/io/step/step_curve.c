/* STEP curves (ISO 10303-42 4.4: line, circle, ellipse, B-spline curves with knots, rational and
 * the uniform / quasi-uniform / Bezier variants, polyline, trimmed curve, surface and seam curve)
 * in their own parametrisation, with evaluation, point inversion and conversion to NURBS over a
 * parameter range. Circles and ellipses become exact rational arcs (construct.h).
 */
#include "step_internal.h"

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

void crisp__step_curve_free(step_curve *c)
{
    if (!c) return;
    crisp_curve_destroy(c->nurbs);
    c->nurbs = NULL;
}

/* ---- B-spline curves ----------------------------------------------------------------------------
 */

/* Expand (multiplicities, knots) into a full knot vector of count + degree + 1 values. */
crisp_status crisp__step_knots(step_reader *r, const step_entity *e, const step_value *mults,
                               const step_value *knots, int degree, int count, double **dest)
{
    if (mults->len != knots->len || mults->len < 2)
        return crisp__step_fail(
            r, e, CRISP_ERR_PARSE,
            "expected as many knot multiplicities as knots (at least 2), found %u and %u",
            mults->len, knots->len);
    long long total = 0;
    for (uint32_t k = 0; k < mults->len; k++) {
        const step_value *m = crisp__step_elem(r, mults, k);
        if (m->kind != STEP_INT || m->num < 1 || m->num > degree + 1)
            return crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                    "knot multiplicity %u: expected an integer in 1..%d", k + 1,
                                    degree + 1);
        total += (long long)m->num;
    }
    if (total != (long long)count + degree + 1)
        return crisp__step_fail(
            r, e, CRISP_ERR_PARSE,
            "knot multiplicities sum to %lld, expected %d (control points + degree + 1)", total,
            count + degree + 1);
    double *kv = crisp_malloc_array((size_t)total, sizeof *kv);
    if (!kv) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
    int n = 0;
    for (uint32_t k = 0; k < knots->len; k++) {
        double t;
        if (!crisp__step_value_real(r, crisp__step_elem(r, knots, k), &t)) {
            crisp_free(kv);
            return crisp__step_fail(r, e, CRISP_ERR_PARSE, "knot %u: expected a finite real",
                                    k + 1);
        }
        if (k > 0 && !(t > kv[n - 1])) {
            crisp_free(kv);
            return crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                    "knot %u: expected knots in increasing order", k + 1);
        }
        for (int m = 0; m < (int)crisp__step_elem(r, mults, k)->num; m++)
            kv[n++] = t;
    }
    *dest = kv;
    return CRISP_OK;
}

/* Knots implied by the B-spline forms without a knot list (ISO 10303-42 4.4.6-4.4.9 and its
 * default_b_spline_knots / default_b_spline_knot_mult functions): integer knots 0, 1, 2, ... with
 * multiplicity 1 (uniform: the domain is [0, count - degree], knots start at -degree), degree + 1
 * at the ends (quasi-uniform), or degree inside and degree + 1 at the ends (Bezier: one segment
 * per degree control points, so count - 1 must be a multiple of the degree). `form` is the entity
 * name (UNIFORM_*, QUASI_UNIFORM_*, BEZIER_*); *dest is NULL when the form is not one of these. */
crisp_status crisp__step_implied_knots(step_reader *r, const step_entity *e, int degree, int count,
                                       double **dest)
{
    *dest = NULL;
    int form =
        crisp__step_is(r, e, "QUASI_UNIFORM_CURVE") || crisp__step_is(r, e, "QUASI_UNIFORM_SURFACE")
            ? 1
        : crisp__step_is(r, e, "BEZIER_CURVE") || crisp__step_is(r, e, "BEZIER_SURFACE")   ? 2
        : crisp__step_is(r, e, "UNIFORM_CURVE") || crisp__step_is(r, e, "UNIFORM_SURFACE") ? 0
                                                                                           : -1;
    if (form < 0) return crisp__step_fail(r, e, CRISP_ERR_UNSUPPORTED, "B-spline without knots");
    if (form == 2 && (count - 1) % degree != 0)
        return crisp__step_fail(
            r, e, CRISP_ERR_PARSE,
            "Bezier form of degree %d: expected 1 + a multiple of %d control points, found %d",
            degree, degree, count);
    int n = count + degree + 1;
    double *kv = crisp_malloc_array((size_t)n, sizeof *kv);
    if (!kv) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
    for (int i = 0; i < n; i++) {
        if (form == 0) {
            kv[i] = i - degree;
        } else if (form == 1) {
            int k = i - degree;
            kv[i] = k < 0 ? 0 : k > count - degree ? count - degree : k;
        } else {
            /* degree + 1 zeros, then each segment end `degree` times, the last once more. */
            int k = i < degree + 1 ? 0 : (i - 1) / degree;
            int segs = (count - 1) / degree;
            kv[i] = k > segs ? segs : k;
        }
    }
    *dest = kv;
    return CRISP_OK;
}

static crisp_status bspline_curve(step_reader *r, const step_entity *e, step_curve *c)
{
    const step_part *bp = crisp__step_part(r, e, "B_SPLINE_CURVE_WITH_KNOTS");
    const step_part *base = crisp__step_part(r, e, "B_SPLINE_CURVE");
    const step_part *kp = bp;
    int off = 0; /* parameters of B_SPLINE_CURVE inside a simple instance start after the name */
    if (!base) {
        base = bp ? bp : crisp__step_part(r, e, NULL);
        off = 1;
    }
    crisp_status st;
    int degree, dim = 0;
    const step_value *pts;
    if ((st = crisp__step_get_int(r, e, base, off, 1, CRISP_MAX_DEGREE, &degree)) ||
        (st = crisp__step_get_list(r, e, base, off + 1, &pts)))
        return st;
    int count = (int)pts->len;
    if (count < degree + 1 || count > CRISP_MAX_CONTROL_POINTS)
        return crisp__step_fail(r, e, CRISP_ERR_LIMIT, "expected %d to %d control points, found %d",
                                degree + 1, CRISP_MAX_CONTROL_POINTS, count);
    double *xyz = crisp_malloc_array((size_t)count * 3, sizeof *xyz);
    double *w = NULL, *kv = NULL;
    if (!xyz) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
    for (int i = 0; i < count && !st; i++) {
        const step_entity *pe;
        int d;
        st = crisp__step_deref(r, e, crisp__step_elem(r, pts, (uint32_t)i), &pe);
        if (!st) st = crisp__step_point(r, pe, xyz + 3 * i, &d);
        if (!st && i == 0) dim = d < 2 ? 2 : d;
    }
    if (!st && kp) {
        int o = kp == base ? off + 5 : 0;
        const step_value *mults, *knots;
        if (!(st = crisp__step_get_list(r, e, kp, o, &mults)) &&
            !(st = crisp__step_get_list(r, e, kp, o + 1, &knots)))
            st = crisp__step_knots(r, e, mults, knots, degree, count, &kv);
    } else if (!st) {
        st = crisp__step_implied_knots(r, e, degree, count, &kv);
    }
    const step_part *rp = crisp__step_part(r, e, "RATIONAL_B_SPLINE_CURVE");
    if (!st && rp) {
        const step_value *wl;
        if (!(st = crisp__step_get_list(r, e, rp, 0, &wl))) {
            if ((int)wl->len != count)
                st = crisp__step_fail(r, e, CRISP_ERR_PARSE, "expected %d weights, found %u", count,
                                      wl->len);
            else if (!(w = crisp_malloc_array((size_t)count, sizeof *w)))
                st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
            for (int i = 0; !st && i < count; i++)
                if (!crisp__step_value_real(r, crisp__step_elem(r, wl, (uint32_t)i), &w[i]) ||
                    !(w[i] > 0))
                    st = crisp__step_fail(r, e, CRISP_ERR_NUMERIC,
                                          "weight %d: expected a positive real", i + 1);
        }
    }
    if (!st && dim == 2)
        for (int i = 0; i < count; i++)
            xyz[2 * i] = xyz[3 * i], xyz[2 * i + 1] = xyz[3 * i + 1];
    if (!st) {
        st = crisp_curve_create(dim, degree, count, kv, xyz, w, &c->nurbs);
        if (st) crisp__step_fail(r, e, st, "invalid B-spline curve: %s", crisp_error_message());
    }
    crisp_free(xyz);
    crisp_free(w);
    crisp_free(kv);
    if (st) return st;
    c->kind = STEP_CURVE_BSPLINE;
    c->dim = dim;
    crisp_curve_domain(c->nurbs, &c->t0, &c->t1);
    /* A closed clamped curve (first point = last point) behaves like a periodic one for edges. */
    double a[3], b[3];
    crisp_curve_eval(c->nurbs, c->t0, a);
    crisp_curve_eval(c->nurbs, c->t1, b);
    double bb[6], diag = 0, gap = 0;
    crisp_curve_bbox(c->nurbs, bb);
    for (int k = 0; k < dim; k++) {
        diag += (bb[dim + k] - bb[k]) * (bb[dim + k] - bb[k]);
        gap += (a[k] - b[k]) * (a[k] - b[k]);
    }
    if (sqrt(gap) <= 1e-9 * sqrt(diag) + 1e-12) {
        c->periodic = 1;
        c->period = c->t1 - c->t0;
    }
    return CRISP_OK;
}

static crisp_status polyline(step_reader *r, const step_entity *e, step_curve *c)
{
    const step_part *p = crisp__step_part(r, e, "POLYLINE");
    const step_value *pts;
    crisp_status st = crisp__step_get_list(r, e, p, 1, &pts);
    if (st) return st;
    int count = (int)pts->len, dim = 3;
    if (count < 2 || count > CRISP_MAX_CONTROL_POINTS)
        return crisp__step_fail(r, e, CRISP_ERR_LIMIT, "expected 2 to %d points, found %d",
                                CRISP_MAX_CONTROL_POINTS, count);
    double *xyz = crisp_malloc_array((size_t)count * 3, sizeof *xyz);
    double *kv = crisp_malloc_array((size_t)count + 2, sizeof *kv);
    if (!xyz || !kv) st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
    for (int i = 0; !st && i < count; i++) {
        const step_entity *pe;
        int d;
        st = crisp__step_deref(r, e, crisp__step_elem(r, pts, (uint32_t)i), &pe);
        if (!st) st = crisp__step_point(r, pe, xyz + 3 * i, &d);
        if (!st && i == 0) dim = d < 2 ? 2 : d;
    }
    if (!st) {
        kv[0] = 0;
        for (int i = 0; i < count; i++)
            kv[i + 1] = i;
        kv[count + 1] = count - 1;
        if (dim == 2)
            for (int i = 0; i < count; i++)
                xyz[2 * i] = xyz[3 * i], xyz[2 * i + 1] = xyz[3 * i + 1];
        st = crisp_curve_create(dim, 1, count, kv, xyz, NULL, &c->nurbs);
        if (st) crisp__step_fail(r, e, st, "invalid polyline: %s", crisp_error_message());
    }
    crisp_free(xyz);
    crisp_free(kv);
    if (st) return st;
    c->kind = STEP_CURVE_BSPLINE;
    c->dim = dim;
    crisp_curve_domain(c->nurbs, &c->t0, &c->t1);
    return CRISP_OK;
}

/* ---- analytic curves ----------------------------------------------------------------------------
 */

static crisp_status line(step_reader *r, const step_entity *e, step_curve *c)
{
    const step_part *p = crisp__step_part(r, e, "LINE");
    const step_entity *pe, *ve;
    crisp_status st;
    if ((st = crisp__step_get_ref(r, e, p, 1, &pe)) ||
        (st = crisp__step_point(r, pe, c->p, &c->dim)) ||
        (st = crisp__step_get_ref(r, e, p, 2, &ve)) || (st = crisp__step_vector(r, ve, c->d)))
        return st;
    if (c->dim < 2) c->dim = 2;
    if (!(c->d[0] * c->d[0] + c->d[1] * c->d[1] + c->d[2] * c->d[2] > 0))
        return crisp__step_fail(r, e, CRISP_ERR_NUMERIC, "line with a zero direction vector");
    c->kind = STEP_CURVE_LINE;
    c->t0 = -INFINITY;
    c->t1 = INFINITY;
    return CRISP_OK;
}

/* The placement and axes shared by the conics: name(label, position, a[, b]) with b read when
 * two_axes (else b = a); both positive and finite. */
static crisp_status conic_axes(step_reader *r, const step_entity *e, const char *name, int two_axes,
                               step_curve *c)
{
    const step_part *p = crisp__step_part(r, e, name);
    const step_entity *ae;
    crisp_status st;
    if ((st = crisp__step_get_ref(r, e, p, 1, &ae)) ||
        (st = crisp__step_placement(r, ae, &c->pl)) ||
        (st = crisp__step_get_real(r, e, p, 2, &c->rx)))
        return st;
    c->ry = c->rx;
    if (two_axes && (st = crisp__step_get_real(r, e, p, 3, &c->ry))) return st;
    if (!(c->rx > 0) || !(c->ry > 0) || !isfinite(c->rx) || !isfinite(c->ry))
        return crisp__step_fail(r, e, CRISP_ERR_NUMERIC, "expected positive finite axes");
    c->dim = crisp__step_is(r, ae, "AXIS2_PLACEMENT_2D") ? 2 : 3;
    return CRISP_OK;
}

static crisp_status conic(step_reader *r, const step_entity *e, step_curve *c, int ellipse)
{
    crisp_status st = conic_axes(r, e, ellipse ? "ELLIPSE" : "CIRCLE", ellipse, c);
    if (st) return st;
    c->kind = STEP_CURVE_CONIC;
    c->periodic = 1;
    c->period = 2 * M_PI;
    c->t0 = -INFINITY;
    c->t1 = INFINITY;
    return CRISP_OK;
}

/* HYPERBOLA(name, position, semi_axis, semi_imag_axis) and PARABOLA(name, position, focal_dist)
 * (ISO 10303-42 4.4.13-14): unbounded like lines; edges and trims bound them. */
static crisp_status open_conic(step_reader *r, const step_entity *e, step_curve *c, int hyperbola)
{
    crisp_status st = conic_axes(r, e, hyperbola ? "HYPERBOLA" : "PARABOLA", hyperbola, c);
    if (st) return st;
    c->kind = hyperbola ? STEP_CURVE_HYPERBOLA : STEP_CURVE_PARABOLA;
    c->t0 = -INFINITY;
    c->t1 = INFINITY;
    return CRISP_OK;
}

/* Local coordinates (along x, y of the placement) of the point at t, and their derivative. */
static void open_conic_local(const step_curve *c, double t, double xy[2], double dxy[2])
{
    if (c->kind == STEP_CURVE_HYPERBOLA) {
        xy[0] = c->rx * cosh(t), xy[1] = c->ry * sinh(t);
        dxy[0] = c->rx * sinh(t), dxy[1] = c->ry * cosh(t);
    } else {
        xy[0] = c->rx * t * t, xy[1] = 2 * c->rx * t;
        dxy[0] = 2 * c->rx * t, dxy[1] = 2 * c->rx;
    }
}

void crisp__step_curve_eval(const step_curve *c, double t, double *dest)
{
    double x[3];
    switch (c->kind) {
    case STEP_CURVE_LINE:
        for (int k = 0; k < 3; k++)
            x[k] = c->p[k] + t * c->d[k];
        break;
    case STEP_CURVE_CONIC: {
        double a = c->rx * cos(t), b = c->ry * sin(t);
        for (int k = 0; k < 3; k++)
            x[k] = c->pl.origin[k] + a * c->pl.x[k] + b * c->pl.y[k];
        break;
    }
    case STEP_CURVE_HYPERBOLA:
    case STEP_CURVE_PARABOLA: {
        double xy[2], dxy[2];
        open_conic_local(c, t, xy, dxy);
        for (int k = 0; k < 3; k++)
            x[k] = c->pl.origin[k] + xy[0] * c->pl.x[k] + xy[1] * c->pl.y[k];
        break;
    }
    default:
        x[2] = 0;
        crisp_curve_eval(c->nurbs, t, x);
        break;
    }
    for (int k = 0; k < c->dim; k++)
        dest[k] = x[k];
}

static double dist2(const double *a, const double *b, int dim)
{
    double s = 0;
    for (int k = 0; k < dim; k++)
        s += (a[k] - b[k]) * (a[k] - b[k]);
    return s;
}

double crisp__step_curve_invert(const step_curve *c, const double *p, double lo, double hi)
{
    if (c->kind == STEP_CURVE_LINE) {
        double dd = 0, dp = 0;
        for (int k = 0; k < c->dim; k++) {
            dd += c->d[k] * c->d[k];
            dp += (p[k] - c->p[k]) * c->d[k];
        }
        double t = dp / dd;
        return t < lo ? lo : t > hi ? hi : t;
    }
    if (c->kind == STEP_CURVE_CONIC) {
        double q[3] = {0, 0, 0}, a = 0, b = 0;
        for (int k = 0; k < c->dim; k++)
            q[k] = p[k] - c->pl.origin[k];
        for (int k = 0; k < 3; k++)
            a += q[k] * c->pl.x[k], b += q[k] * c->pl.y[k];
        double t = atan2(b / c->ry, a / c->rx);
        if (c->rx !=
            c->ry) { /* refine: nearest point on an ellipse is not at the eccentric angle */
            for (int it = 0; it < 20; it++) {
                double ct = cos(t), s = sin(t);
                double f =
                    (c->ry * c->ry - c->rx * c->rx) * ct * s + a * c->rx * s - b * c->ry * ct;
                double df = (c->ry * c->ry - c->rx * c->rx) * (ct * ct - s * s) + a * c->rx * ct +
                            b * c->ry * s;
                if (df == 0) break;
                double dt = f / df;
                if (fabs(dt) > 0.5) dt = dt > 0 ? 0.5 : -0.5;
                t -= dt;
                if (fabs(dt) < 1e-15) break;
            }
        }
        /* Bring t into [lo, lo + 2 pi) when the range is finite. */
        if (isfinite(lo)) {
            double k = floor((t - lo) / (2 * M_PI));
            t -= k * 2 * M_PI;
        }
        return t;
    }
    if (c->kind == STEP_CURVE_HYPERBOLA || c->kind == STEP_CURVE_PARABOLA) {
        /* From the point's local y (exact on the curve), then Newton on the squared distance. */
        double q[3] = {0, 0, 0}, a = 0, b = 0;
        for (int k = 0; k < c->dim; k++)
            q[k] = p[k] - c->pl.origin[k];
        for (int k = 0; k < 3; k++)
            a += q[k] * c->pl.x[k], b += q[k] * c->pl.y[k];
        double t = c->kind == STEP_CURVE_HYPERBOLA ? asinh(b / c->ry) : b / (2 * c->rx);
        for (int it = 0; it < 20 && isfinite(t); it++) {
            double xy[2], d1[2], d2[2], h = 1e-6 * (1 + fabs(t));
            open_conic_local(c, t, xy, d1);
            double e[2] = {xy[0] - a, xy[1] - b};
            double f = e[0] * d1[0] + e[1] * d1[1];
            double xp[2], dp[2];
            open_conic_local(c, t + h, xp, dp);
            d2[0] = (dp[0] - d1[0]) / h, d2[1] = (dp[1] - d1[1]) / h;
            double df = d1[0] * d1[0] + d1[1] * d1[1] + e[0] * d2[0] + e[1] * d2[1];
            if (!(df > 0)) break;
            double step = f / df;
            if (fabs(step) > 1) step = step > 0 ? 1 : -1;
            t -= step;
            if (fabs(step) < 1e-15 * (1 + fabs(t))) break;
        }
        if (!isfinite(t)) t = 0;
        return t < lo ? lo : t > hi ? hi : t;
    }
    /* B-spline: sample, then golden-section search around the best sample. */
    if (!isfinite(lo)) lo = c->t0;
    if (!isfinite(hi)) hi = c->t1;
    int n = 8 * (c->nurbs->count - c->nurbs->degree + 1);
    if (n < 32) n = 32;
    if (n > 4096) n = 4096;
    double best = lo, bd = INFINITY, x[3];
    for (int i = 0; i <= n; i++) {
        double t = lo + (hi - lo) * i / n;
        crisp__step_curve_eval(c, t, x);
        double d = dist2(x, p, c->dim);
        if (d < bd) bd = d, best = t;
    }
    double a = best - (hi - lo) / n, b = best + (hi - lo) / n;
    if (a < lo) a = lo;
    if (b > hi) b = hi;
    const double g = 0.6180339887498949;
    double x1 = b - g * (b - a), x2 = a + g * (b - a), f1, f2;
    crisp__step_curve_eval(c, x1, x);
    f1 = dist2(x, p, c->dim);
    crisp__step_curve_eval(c, x2, x);
    f2 = dist2(x, p, c->dim);
    for (int it = 0; it < 80 && b - a > 1e-15 * (1 + fabs(a)); it++) {
        if (f1 < f2) {
            b = x2, x2 = x1, f2 = f1;
            x1 = b - g * (b - a);
            crisp__step_curve_eval(c, x1, x);
            f1 = dist2(x, p, c->dim);
        } else {
            a = x1, x1 = x2, f1 = f2;
            x2 = a + g * (b - a);
            crisp__step_curve_eval(c, x2, x);
            f2 = dist2(x, p, c->dim);
        }
    }
    double t = 0.5 * (a + b);
    /* End points are exact candidates (a vertex at the end of the curve). */
    crisp__step_curve_eval(c, t, x);
    double dt = dist2(x, p, c->dim);
    crisp__step_curve_eval(c, lo, x);
    if (dist2(x, p, c->dim) <= dt) t = lo, dt = dist2(x, p, c->dim);
    crisp__step_curve_eval(c, hi, x);
    if (dist2(x, p, c->dim) < dt) t = hi;
    return t;
}

crisp_status crisp__step_curve_nurbs(const step_curve *c, double t0, double t1, crisp_curve **dest)
{
    if (!(t1 > t0))
        return crisp_error(CRISP_ERR_NUMERIC, "curve #%d: empty parameter range [%g, %g]", c->id,
                           t0, t1);
    crisp_status st;
    if (c->kind == STEP_CURVE_LINE) {
        double a[3], b[3];
        crisp__step_curve_eval(c, t0, a);
        crisp__step_curve_eval(c, t1, b);
        st = crisp_make_line(c->dim, a, b, t0, t1, dest);
    } else if (c->kind == STEP_CURVE_CONIC) {
        if (t1 - t0 > 2 * M_PI * (1 + 1e-12))
            return crisp_error(CRISP_ERR_NUMERIC, "curve #%d: arc of more than a full turn", c->id);
        if (t1 - t0 > 2 * M_PI) t1 = t0 + 2 * M_PI;
        st = crisp_make_arc(c->dim, c->pl.origin, c->pl.x, c->pl.y, c->rx, c->ry, t0, t1, dest);
    } else if (c->kind == STEP_CURVE_HYPERBOLA || c->kind == STEP_CURVE_PARABOLA) {
        /* Rational (hyperbola) or polynomial (parabola) quadratic Bezier pieces of at most 0.25 in
         * the parameter, joined at double knots: each piece's end points, the intersection of its
         * end tangents and, for the hyperbola, the middle weight cosh of half the piece's span (as
         * cos of the half angle for an ellipse). Short pieces keep the control polygon close to
         * the curve (trims are clamped to a box around the curve). */
        if (!isfinite(t0) || !isfinite(t1) || t1 - t0 > 40)
            return crisp_error(CRISP_ERR_NUMERIC,
                               "curve #%d: hyperbola or parabola range [%g, %g] too long", c->id,
                               t0, t1);
        int n = (int)ceil((t1 - t0) / 0.25);
        if (n < 1) n = 1;
        int count = 2 * n + 1;
        double *pts = crisp_malloc_array((size_t)count * 3, sizeof *pts),
               *w = crisp_malloc_array((size_t)count, sizeof *w);
        double *knots = crisp_malloc_array((size_t)count + 3, sizeof *knots);
        if (!pts || !w || !knots) {
            crisp_free(pts), crisp_free(w), crisp_free(knots);
            return crisp_error(CRISP_ERR_NO_MEMORY, "curve #%d: out of memory", c->id);
        }
        for (int i = 0; i <= 2 * n; i++) {
            double loc[2], d[2];
            int j = i / 2;
            double a = t0 + (t1 - t0) * j / n, b = t0 + (t1 - t0) * (j + 1) / n;
            w[i] = 1;
            if (i % 2 == 0) {
                open_conic_local(c, a, loc, d);
            } else if (c->kind == STEP_CURVE_HYPERBOLA) {
                double m = 0.5 * (a + b), h = 0.5 * (b - a);
                loc[0] = c->rx * cosh(m) / cosh(h), loc[1] = c->ry * sinh(m) / cosh(h);
                w[i] = cosh(h);
            } else {
                loc[0] = c->rx * a * b, loc[1] = c->rx * (a + b);
            }
            for (int k = 0; k < c->dim; k++)
                pts[c->dim * i + k] = c->pl.origin[k] + loc[0] * c->pl.x[k] + loc[1] * c->pl.y[k];
        }
        knots[0] = knots[1] = knots[2] = t0;
        for (int j = 1; j < n; j++)
            knots[2 * j + 1] = knots[2 * j + 2] = t0 + (t1 - t0) * j / n;
        knots[2 * n + 1] = knots[2 * n + 2] = knots[2 * n + 3] = t1;
        st = crisp_curve_create(c->dim, 2, count, knots, pts,
                                c->kind == STEP_CURVE_HYPERBOLA ? w : NULL, dest);
        crisp_free(pts), crisp_free(w), crisp_free(knots);
    } else {
        double a, b;
        crisp_curve_domain(c->nurbs, &a, &b);
        if (t0 <= a && t1 >= b)
            st = crisp_curve_copy(c->nurbs, dest);
        else
            st = crisp_curve_trim(c->nurbs, t0 < a ? a : t0, t1 > b ? b : t1, dest);
    }
    if (st) crisp_error_prefix("curve #%d", c->id);
    return st;
}

const step_part *crisp__step_surface_curve_part(const step_reader *r, const step_entity *e,
                                                int *off)
{
    static const char *const names[] = {"SURFACE_CURVE", "SEAM_CURVE", "INTERSECTION_CURVE",
                                        "BOUNDED_SURFACE_CURVE"};
    /* In a complex instance the name is REPRESENTATION_ITEM's: the partial entity starts with
     * curve_3d. */
    *off = e->part_count > 1 ? 0 : 1;
    for (size_t k = 0; k < sizeof names / sizeof *names; k++) {
        const step_part *p = crisp__step_part(r, e, names[k]);
        if (p) return p;
    }
    return crisp__step_part(r, e, NULL);
}

/* ---- dispatch -----------------------------------------------------------------------------------
 */

static crisp_status trimmed(step_reader *r, const step_entity *e, step_curve *c);

crisp_status crisp__step_curve(step_reader *r, const step_entity *e, step_curve *dest)
{
    memset(dest, 0, sizeof *dest);
    dest->id = e->id;
    if (++r->depth > STEP_MAX_DEPTH) {
        r->depth--;
        return crisp__step_fail(r, e, CRISP_ERR_LIMIT,
                                "curve references nested too deeply (a reference cycle?)");
    }
    crisp_status st;
    if (crisp__step_is(r, e, "LINE"))
        st = line(r, e, dest);
    else if (crisp__step_is(r, e, "CIRCLE"))
        st = conic(r, e, dest, 0);
    else if (crisp__step_is(r, e, "ELLIPSE"))
        st = conic(r, e, dest, 1);
    else if (crisp__step_is(r, e, "HYPERBOLA"))
        st = open_conic(r, e, dest, 1);
    else if (crisp__step_is(r, e, "PARABOLA"))
        st = open_conic(r, e, dest, 0);
    else if (crisp__step_is(r, e, "B_SPLINE_CURVE_WITH_KNOTS") ||
             crisp__step_is(r, e, "B_SPLINE_CURVE") ||
             crisp__step_is(r, e, "QUASI_UNIFORM_CURVE") || crisp__step_is(r, e, "UNIFORM_CURVE") ||
             crisp__step_is(r, e, "BEZIER_CURVE"))
        st = bspline_curve(r, e, dest);
    else if (crisp__step_is(r, e, "POLYLINE"))
        st = polyline(r, e, dest);
    else if (crisp__step_is(r, e, "TRIMMED_CURVE"))
        st = trimmed(r, e, dest);
    else if (crisp__step_is(r, e, "SURFACE_CURVE") || crisp__step_is(r, e, "SEAM_CURVE") ||
             crisp__step_is(r, e, "INTERSECTION_CURVE") ||
             crisp__step_is(r, e, "BOUNDED_SURFACE_CURVE")) {
        const step_entity *ce;
        int off;
        const step_part *p = crisp__step_surface_curve_part(r, e, &off);
        st = crisp__step_get_ref(r, e, p, off, &ce);
        if (!st) st = crisp__step_curve(r, ce, dest);
    } else {
        char type[64];
        st = crisp__step_fail(r, e, CRISP_ERR_UNSUPPORTED, "unsupported curve type %s",
                              crisp__step_type(r, e, type, sizeof type));
    }
    r->depth--;
    if (st) crisp__step_curve_free(dest);
    return st;
}

/* TRIMMED_CURVE(name, basis, trim_1, trim_2, sense, master): the basis curve bounded by points or
 * parameters. A trimmed curve against the basis sense is not supported (no bundled file has one;
 * edges give their own bounds). */
static crisp_status trimmed(step_reader *r, const step_entity *e, step_curve *c)
{
    const step_part *p = crisp__step_part(r, e, "TRIMMED_CURVE");
    const step_entity *be;
    int sense;
    crisp_status st = crisp__step_get_ref(r, e, p, 1, &be);
    if (!st) st = crisp__step_get_bool(r, e, p, 4, &sense);
    if (!st) st = crisp__step_curve(r, be, c);
    if (st) return st;
    c->id = e->id;
    double t[2] = {c->t0, c->t1};
    int have[2] = {0, 0};
    for (int k = 0; k < 2; k++) {
        const step_value *sel;
        if ((st = crisp__step_get_list(r, e, p, 2 + k, &sel))) goto fail;
        for (uint32_t i = 0; i < sel->len && !have[k]; i++) {
            const step_value *v = crisp__step_elem(r, sel, i);
            /* PARAMETER_VALUE(t), or a bare number as some writers put it. */
            if ((v->kind == STEP_TYPED || v->kind == STEP_REAL || v->kind == STEP_INT) &&
                crisp__step_value_real(r, v, &t[k])) {
                /* A conic's parameter is an angle, in the file's plane angle unit. */
                if (c->kind == STEP_CURVE_CONIC) t[k] *= r->angle_unit;
                have[k] = 1;
            }
        }
        for (uint32_t i = 0; i < sel->len && !have[k]; i++) {
            const step_value *v = crisp__step_elem(r, sel, i);
            const step_entity *pe;
            double x[3];
            if (v->kind != STEP_REF) continue;
            if ((st = crisp__step_deref(r, e, v, &pe)) || (st = crisp__step_point(r, pe, x, NULL)))
                goto fail;
            t[k] = crisp__step_curve_invert(c, x, c->t0, c->t1);
            have[k] = 1;
        }
        if (!have[k]) {
            st = crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                  "trim %d: expected a point or a parameter value", k + 1);
            goto fail;
        }
    }
    if (!sense) {
        double s = t[0];
        t[0] = t[1];
        t[1] = s;
        c->reversed ^= 1;
    }
    if (c->periodic && c->kind == STEP_CURVE_CONIC) {
        /* Angles far beyond a few turns are not a trim anyone meant (and stepping a turn at a time
         * towards 1e16 never ends: found by fuzz_step). */
        if (!(fabs(t[0]) < 1e6 * c->period) || !(fabs(t[1]) < 1e6 * c->period)) {
            st = crisp__step_fail(r, e, CRISP_ERR_NUMERIC,
                                  "trim parameters %g and %g: expected angles within a "
                                  "million turns",
                                  t[0], t[1]);
            goto fail;
        }
        if (t[1] <= t[0]) t[1] += c->period * ceil((t[0] - t[1]) / c->period);
        while (t[1] <= t[0])
            t[1] += c->period;
    }
    if (!(t[1] > t[0])) {
        st = crisp__step_fail(r, e, CRISP_ERR_NUMERIC, "empty trimmed range [%g, %g]", t[0], t[1]);
        goto fail;
    }
    c->t0 = t[0];
    c->t1 = t[1];
    if (c->kind == STEP_CURVE_CONIC && t[1] - t[0] < c->period * (1 - 1e-12)) c->periodic = 0;
    return CRISP_OK;
fail:
    crisp__step_curve_free(c);
    return st;
}
