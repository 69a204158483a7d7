/* Private to the nurbs module: the adaptive cubic fitting behind crisp_fit_curve, with a
 * caller-supplied error measure so that crisp_surface_project_curve can check its uv fit in 3D. */
#ifndef CRISP_FIT_INTERNAL_H
#define CRISP_FIT_INTERNAL_H

#include "crisp/construct.h"

/* Error of the fitted value `fitted` (dim values) at parameter t, compared with tol by the
 * fitter; a negative or non-finite return is treated as "cannot be met here". */
typedef double (*crisp__fit_error_fn)(void *ctx, double t, const double *fitted);

typedef struct crisp__fit_desc {
    int dim;          /* 2 or 3 */
    crisp_curve_fn f; /* the function, evaluated at the interpolation nodes */
    void *ctx;
    crisp__fit_error_fn error; /* NULL: |fitted - f(t)| */
    void *error_ctx;
    double t0, t1, tol;
    int max_spans;
    const double *breaks; /* optional initial span ends inside (t0, t1), increasing */
    int break_count;
} crisp__fit_desc;

crisp_status crisp__fit_adaptive(const crisp__fit_desc *desc, crisp_curve **dest);

#endif
