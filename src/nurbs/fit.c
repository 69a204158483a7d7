/* Adaptive fitting of a non-rational cubic B-spline to a function within a tolerance
 * (crisp_fit_curve), also used for uv trim curves projected from 3D edges.
 *
 * Each span [a, b] gets the cubic interpolating f at a, a + h/3, a + 2h/3, b (Lagrange on equally
 * spaced nodes, written in Bézier form); the error is measured at nine further points of the span
 * and a span that misses the tolerance is halved. Spans are independent (the spline is C0 at the
 * knots: triple interior knots), so refining one span never worsens another: the refinement is
 * monotone and ends either within tolerance or at max_spans / a span too short to split, both
 * reported as errors. Bézier extraction of the result costs the same as for a C2 spline with as
 * many spans, which is what the renderer consumes. */
#include "fit_internal.h"

#include <math.h>
#include <string.h>

/* Spans are accepted at this fraction of tol: margin for the error between the check points. */
#define ACCEPT 0.8

typedef struct span {
    double a, b;
    double fa[3], fb[3];
} span;

/* Error sample positions: twelfths of the span other than the nodes 0, 1/3, 2/3, 1. */
static const double check_s[9] = {1.0 / 12, 2.0 / 12, 3.0 / 12,  5.0 / 12, 6.0 / 12,
                                  7.0 / 12, 9.0 / 12, 10.0 / 12, 11.0 / 12};

static int finite_dim(const double *v, int dim)
{
    for (int k = 0; k < dim; k++)
        if (!isfinite(v[k])) return 0;
    return 1;
}

static void bezier3(const double *b, int dim, double s, double *dest)
{
    double r = 1 - s, c0 = r * r * r, c1 = 3 * r * r * s, c2 = 3 * r * s * s, c3 = s * s * s;
    for (int k = 0; k < dim; k++)
        dest[k] = c0 * b[k] + c1 * b[dim + k] + c2 * b[2 * dim + k] + c3 * b[3 * dim + k];
}

static crisp_status eval_f(const crisp__fit_desc *d, double t, double *dest)
{
    d->f(d->ctx, t, dest);
    if (!finite_dim(dest, d->dim))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "crisp_fit_curve: the function is not finite at "
                           "t = %.17g",
                           t);
    return CRISP_OK;
}

/* Fit one span: Bézier points (4 * dim) and the largest sampled error (< 0: unmeasurable). */
static crisp_status fit_span(const crisp__fit_desc *d, const span *sp, double *bez, double *err)
{
    int dim = d->dim;
    double h = sp->b - sp->a, f1[3], f2[3];
    crisp_status st = eval_f(d, sp->a + h / 3, f1);
    if (!st) st = eval_f(d, sp->a + 2 * h / 3, f2);
    if (st) return st;
    for (int k = 0; k < dim; k++) {
        double f0 = sp->fa[k], f3 = sp->fb[k];
        bez[k] = f0;
        bez[dim + k] = (-5 * f0 + 18 * f1[k] - 9 * f2[k] + 2 * f3) / 6;
        bez[2 * dim + k] = (2 * f0 - 9 * f1[k] + 18 * f2[k] - 5 * f3) / 6;
        bez[3 * dim + k] = f3;
    }
    double worst = 0;
    for (int i = 0; i < 9; i++) {
        double t = sp->a + check_s[i] * h, fit[3], e;
        bezier3(bez, dim, check_s[i], fit);
        if (d->error) {
            e = d->error(d->error_ctx, t, fit);
        } else {
            double ft[3];
            if ((st = eval_f(d, t, ft))) return st;
            e = 0;
            for (int k = 0; k < dim; k++)
                e += (fit[k] - ft[k]) * (fit[k] - ft[k]);
            e = sqrt(e);
        }
        if (!(e >= 0) || !isfinite(e)) {
            worst = -1;
            break;
        }
        if (e > worst) worst = e;
    }
    *err = worst;
    return CRISP_OK;
}

crisp_status crisp__fit_adaptive(const crisp__fit_desc *d, crisp_curve **dest)
{
    int dim = d->dim;
    span *stack = NULL;
    double *bez = NULL, *knots = NULL;
    size_t stack_cap = 0, bez_cap = 0;
    int top = 0, done = 0;
    crisp_status st = CRISP_OK;
    double minh = (d->t1 - d->t0) * 1e-12;

    /* Initial spans, pushed right to left so the leftmost is processed first. */
    int nb = d->break_count > 0 ? d->break_count : 0;
    if (nb + 1 > d->max_spans) nb = 0;
    if ((st = crisp_grow((void **)&stack, &stack_cap, (size_t)nb + 1 + 64, sizeof *stack)))
        goto fail_mem;
    {
        double b = d->t1, fb[3];
        if ((st = eval_f(d, b, fb))) goto out;
        for (int i = nb; i >= 0; i--) {
            double a = i > 0 ? d->breaks[i - 1] : d->t0;
            if (i > 0 && !(a > d->t0 && a < b)) continue; /* out of order: skip */
            span *sp = &stack[top++];
            sp->a = a;
            sp->b = b;
            memcpy(sp->fb, fb, sizeof fb);
            if ((st = eval_f(d, a, sp->fa))) goto out;
            memcpy(fb, sp->fa, sizeof fb);
            b = a;
        }
    }
    while (top > 0) {
        span sp = stack[--top];
        double piece[12], err;
        if ((st = fit_span(d, &sp, piece, &err))) goto out;
        if (err >= 0 && err <= ACCEPT * d->tol) {
            if ((st = crisp_grow((void **)&bez, &bez_cap, (size_t)(done + 1) * 4 * dim,
                                 sizeof *bez)))
                goto fail_mem;
            memcpy(bez + (size_t)done * 4 * dim, piece, 4 * dim * sizeof *piece);
            if (!knots && !(knots = crisp_malloc_array((size_t)d->max_spans + 1, sizeof *knots)))
                goto fail_mem;
            knots[done] = sp.a;
            knots[done + 1] = sp.b;
            done++;
            continue;
        }
        double h = sp.b - sp.a, m = sp.a + 0.5 * h;
        if (done + top + 2 > d->max_spans || !(h > 2 * minh) || !(m > sp.a && m < sp.b)) {
            st = crisp_error(CRISP_ERR_LIMIT,
                             "crisp_fit_curve: tolerance %g not reached on [%.17g, %.17g] "
                             "(error %g) within max_spans %d",
                             d->tol, sp.a, sp.b, err, d->max_spans);
            goto out;
        }
        if ((st = crisp_grow((void **)&stack, &stack_cap, (size_t)top + 2, sizeof *stack)))
            goto fail_mem;
        span left = sp, right = sp;
        left.b = right.a = m;
        if ((st = eval_f(d, m, left.fb))) goto out;
        memcpy(right.fa, left.fb, sizeof left.fb);
        stack[top++] = right;
        stack[top++] = left;
    }
    {
        /* C0 cubic: 3 n + 1 control points, end knots fourfold, interior knots threefold. */
        int count = 3 * done + 1;
        double *kv = crisp_malloc_array((size_t)count + 4, sizeof *kv);
        double *pts = crisp_malloc_array((size_t)count, dim * sizeof *pts);
        if (!kv || !pts) {
            crisp_free(kv);
            crisp_free(pts);
            goto fail_mem;
        }
        for (int i = 0; i < 4; i++) {
            kv[i] = d->t0;
            kv[count + i] = d->t1;
        }
        for (int s = 1; s < done; s++)
            for (int i = 0; i < 3; i++)
                kv[1 + 3 * s + i] = knots[s];
        for (int s = 0; s < done; s++)
            memcpy(pts + (size_t)3 * s * dim, bez + (size_t)4 * s * dim, 4 * dim * sizeof *pts);
        st = crisp_curve_create(dim, 3, count, kv, pts, NULL, dest);
        crisp_free(kv);
        crisp_free(pts);
    }
    goto out;
fail_mem:
    st = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_fit_curve: out of memory");
out:
    crisp_free(stack);
    crisp_free(bez);
    crisp_free(knots);
    return st;
}

crisp_status crisp_fit_curve(int dim, crisp_curve_fn f, void *ctx, double t0, double t1, double tol,
                             int max_spans, crisp_curve **dest)
{
    if (!f || !dest || (dim != 2 && dim != 3))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_fit_curve: dim %d (expected 2 or 3) or NULL argument", dim);
    if (!isfinite(t0) || !isfinite(t1) || !(t1 > t0))
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_fit_curve: range [%g, %g] is empty", t0,
                           t1);
    if (!isfinite(tol) || !(tol > 0) || max_spans < 1 || max_spans > CRISP_MAX_CONTROL_POINTS / 3)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_fit_curve: tol %g must be positive and max_spans %d in 1..%d",
                           tol, max_spans, CRISP_MAX_CONTROL_POINTS / 3);
    crisp__fit_desc d = {
        .dim = dim, .f = f, .ctx = ctx, .t0 = t0, .t1 = t1, .tol = tol, .max_spans = max_spans};
    return crisp__fit_adaptive(&d, dest);
}
