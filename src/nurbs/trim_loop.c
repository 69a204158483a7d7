/* Trim loops in a face's (u, v) domain: signed area (shoelace on a dense polyline), closure gap,
 * reversal, how far a loop leaves the domain, and normalisation on load (outer loops CCW, holes
 * CW, small gaps closed by moving curve end points), as Wu & Peters 2015 and docs/design.md section
 * 5 assume of the trim test's input.
 */
#include "crisp/model.h"

#include "nurbs_internal.h"

#include <math.h>
#include <string.h>

/* Polyline samples per non-empty knot span: enough that the shoelace area of a loop of conics
 * and cubics has the right sign whenever the loop is not degenerate. */
static int samples_per_span(int degree)
{
    return 8 * degree + 8;
}

double crisp_trim_loop_signed_area(const crisp_trim_loop *loop)
{
    double area = 0.0, first[2] = {0, 0}, prev[2] = {0, 0};
    int have = 0;
    for (int c = 0; c < loop->curve_count; c++) {
        const crisp_curve *cv = loop->curves[c];
        const int p = cv->degree;
        for (int k = p; k < cv->count; k++) {
            double a = cv->knots[k], b = cv->knots[k + 1];
            if (!(a < b)) continue;
            int n = samples_per_span(p);
            for (int i = 0; i < n; i++) {
                double q[3];
                crisp_curve_eval(cv, a + (b - a) * i / n, q);
                if (have)
                    area += prev[0] * q[1] - q[0] * prev[1];
                else {
                    first[0] = q[0];
                    first[1] = q[1];
                    have = 1;
                }
                prev[0] = q[0];
                prev[1] = q[1];
            }
        }
        /* the curve's end point (the next curve starts there, up to the closure gap) */
        double t0, t1, q[3];
        crisp_curve_domain(cv, &t0, &t1);
        crisp_curve_eval(cv, t1, q);
        area += prev[0] * q[1] - q[0] * prev[1];
        prev[0] = q[0];
        prev[1] = q[1];
    }
    if (have) area += prev[0] * first[1] - first[0] * prev[1];
    return 0.5 * area;
}

static void curve_start(const crisp_curve *c, double *dest)
{
    double t0, t1;
    crisp_curve_domain(c, &t0, &t1);
    crisp_curve_eval(c, t0, dest);
}

static void curve_end(const crisp_curve *c, double *dest)
{
    double t0, t1;
    crisp_curve_domain(c, &t0, &t1);
    crisp_curve_eval(c, t1, dest);
}

static double dist2d(const double *a, const double *b)
{
    return hypot(a[0] - b[0], a[1] - b[1]);
}

double crisp_trim_loop_closure_gap(const crisp_trim_loop *loop)
{
    double gap = 0.0;
    for (int c = 0; c < loop->curve_count; c++) {
        double e[3], s[3];
        curve_end(loop->curves[c], e);
        curve_start(loop->curves[(c + 1) % loop->curve_count], s);
        double d = dist2d(e, s);
        if (d > gap || isnan(d)) gap = d;
    }
    return gap;
}

void crisp_trim_loop_reverse(crisp_trim_loop *loop)
{
    for (int i = 0, j = loop->curve_count - 1; i < j; i++, j--) {
        crisp_curve *tmp = loop->curves[i];
        loop->curves[i] = loop->curves[j];
        loop->curves[j] = tmp;
    }
    for (int i = 0; i < loop->curve_count; i++)
        crisp_curve_reverse(loop->curves[i]);
}

double crisp_trim_loop_domain_excess(const crisp_trim_loop *loop, const double domain[4])
{
    double excess = 0.0;
    for (int c = 0; c < loop->curve_count; c++) {
        const crisp_curve *cv = loop->curves[c];
        const int nc = cv->dim + 1;
        for (int i = 0; i < cv->count; i++) {
            const double *q = cv->cpw + (size_t)i * nc;
            double u = q[0] / q[cv->dim], v = q[1] / q[cv->dim];
            double e = fmax(fmax(domain[0] - u, u - domain[1]), fmax(domain[2] - v, v - domain[3]));
            if (e > excess) excess = e;
        }
    }
    return excess;
}

/* Make the curve's start (end = 0) or end (end = 1) a control point, replacing an unclamped
 * curve by its clamped restriction to the same domain. */
static crisp_status clamp_end(crisp_curve **cp, int end)
{
    crisp_curve *c = *cp;
    const int p = c->degree;
    int clamped =
        end ? c->knots[c->count + p - 1] == c->knots[c->count] : c->knots[1] == c->knots[p];
    if (clamped) return CRISP_OK;
    double t0, t1;
    crisp_curve_domain(c, &t0, &t1);
    crisp_curve *n;
    crisp_status st = crisp_curve_trim(c, t0, t1, &n);
    if (st) return st;
    crisp_curve_destroy(c);
    *cp = n;
    return CRISP_OK;
}

static void set_control_point(crisp_curve *c, int i, const double *pt)
{
    const int nc = c->dim + 1;
    double *q = c->cpw + (size_t)i * nc;
    q[0] = pt[0] * q[c->dim];
    q[1] = pt[1] * q[c->dim];
}

crisp_status crisp_face_normalize_loops(crisp_face *face, double tol)
{
    for (int l = 0; l < face->loop_count; l++) {
        crisp_trim_loop *loop = &face->loops[l];
        if (loop->curve_count <= 0)
            return crisp_error(CRISP_ERR_INVALID_ARG, "face %d: trim loop %d has no curves",
                               face->source_id, l);
        for (int c = 0; c < loop->curve_count; c++) {
            if (loop->curves[c]->dim != 2)
                return crisp_error(CRISP_ERR_INVALID_ARG,
                                   "face %d: trim loop %d curve %d has dimension %d, expected 2",
                                   face->source_id, l, c, loop->curves[c]->dim);
        }
        for (int c = 0; c < loop->curve_count; c++) {
            int next = (c + 1) % loop->curve_count;
            double e[3], s[3];
            curve_end(loop->curves[c], e);
            curve_start(loop->curves[next], s);
            double gap = dist2d(e, s);
            if (!(gap <= tol))
                return crisp_error(CRISP_ERR_INVALID_ARG,
                                   "face %d: trim loop %d is open: curve %d ends at (%.9g, %.9g), "
                                   "%.3g away from the start (%.9g, %.9g) of curve %d; tolerance "
                                   "%.3g",
                                   face->source_id, l, c, e[0], e[1], gap, s[0], s[1], next, tol);
            if (gap == 0.0) continue;
            double mid[2] = {0.5 * (e[0] + s[0]), 0.5 * (e[1] + s[1])};
            crisp_status st;
            if ((st = clamp_end(&loop->curves[c], 1)) || (st = clamp_end(&loop->curves[next], 0)))
                return st;
            set_control_point(loop->curves[c], loop->curves[c]->count - 1, mid);
            set_control_point(loop->curves[next], 0, mid);
        }
        double area = crisp_trim_loop_signed_area(loop);
        if ((loop->is_outer && area < 0.0) || (!loop->is_outer && area > 0.0))
            crisp_trim_loop_reverse(loop);
    }
    return CRISP_OK;
}
