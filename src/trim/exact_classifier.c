/* The exact reference trim classifier and point-to-curve distance on the true rational Bézier
 * pieces (docs/design.md section 5, "Exact reference"). Crossings of the scan line v(t) = v0 are
 * isolated by de Casteljau subdivision of the homogeneous polynomials V - v0 w and U - u0 w, using
 * the convex hull property (a Bernstein polynomial with coefficients of one sign has that sign),
 * down to the precision of doubles. No tolerance of its own: it only stops subdividing where the
 * sub-curve's hull lies wholly on one side of the scan line or of u0, or where the interval can no
 * longer be split.
 */
#include "trim_internal.h"

#include <float.h>
#include <math.h>

#define EXACT_MAX_DEPTH 90

/* g: V - v0 w, f: U - u0 w (degree d, stride 1). Returns the parity of the transitions of
 * [g >= 0] along the sub-curve that happen where f < 0 (u(t) < u0). */
static int crossings(const double *g, const double *f, int d, int depth)
{
    int gpos = 0, gneg = 0, fneg = 0;
    for (int i = 0; i <= d; i++) {
        gpos += g[i] >= 0.0;
        gneg += g[i] < 0.0;
        fneg += f[i] < 0.0;
    }
    if (gpos == d + 1 || gneg == d + 1) return 0; /* [g >= 0] is constant */
    if (fneg == 0) return 0;                      /* u(t) >= u0 throughout */
    int ends = (g[0] >= 0.0) != (g[d] >= 0.0);
    if (fneg == d + 1) return ends; /* every transition is left of u0: parity from the ends */
    if (depth >= EXACT_MAX_DEPTH) return ends && (f[0] + f[d] < 0.0);
    double gl[CRISP_MAX_DEGREE + 1], gr[CRISP_MAX_DEGREE + 1];
    double fl[CRISP_MAX_DEGREE + 1], fr[CRISP_MAX_DEGREE + 1];
    crisp__trim_split(g, d, 1, 0.5, gl, gr);
    crisp__trim_split(f, d, 1, 0.5, fl, fr);
    /* The halves share the middle value exactly, so the transitions split without loss. */
    return crossings(gl, fl, d, depth + 1) ^ crossings(gr, fr, d, depth + 1);
}

int crisp_trim_exact_classify(const crisp_bezier_curve *pieces, int piece_count, double u, double v)
{
    if (!isfinite(u) || !isfinite(v)) return 0;
    int parity = 0;
    for (int k = 0; k < piece_count; k++) {
        const crisp_bezier_curve *b = &pieces[k];
        double g[CRISP_MAX_DEGREE + 1], f[CRISP_MAX_DEGREE + 1];
        for (int i = 0; i <= b->degree; i++) {
            const double *h = b->cpw + 3 * i;
            /* Signs of V/w - v0 and U/w - u0 at the control points' own precision: dividing
             * keeps the end values identical to the polyline's vertices. */
            g[i] = h[1] / h[2] - v;
            f[i] = h[0] / h[2] - u;
            g[i] *= h[2];
            f[i] *= h[2];
        }
        parity ^= crossings(g, f, b->degree, 0);
    }
    return parity;
}

typedef struct dist_ctx {
    double u, v, best, tol;
} dist_ctx;

static void update_point(dist_ctx *c, const double *h)
{
    double du = h[0] / h[2] - c->u, dv = h[1] / h[2] - c->v;
    double dd = sqrt(du * du + dv * dv);
    if (dd < c->best) c->best = dd;
}

/* cpw: 3 * (d + 1) homogeneous coefficients. Branch and bound on control-point boxes, which
 * contain the sub-curve (positive weights). */
static void dist_rec(dist_ctx *c, const double *cpw, int d, int depth)
{
    double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
    for (int i = 0; i <= d; i++)
        for (int q = 0; q < 2; q++) {
            double x = cpw[3 * i + q] / cpw[3 * i + 2];
            lo[q] = fmin(lo[q], x);
            hi[q] = fmax(hi[q], x);
        }
    double ex = fmax(fmax(lo[0] - c->u, c->u - hi[0]), 0.0);
    double ey = fmax(fmax(lo[1] - c->v, c->v - hi[1]), 0.0);
    /* Prune within a relative 1e-9: points equidistant from a whole arc (a circle's centre)
     * would otherwise be subdivided down to the absolute tolerance everywhere. */
    if (sqrt(ex * ex + ey * ey) >= c->best * (1.0 - 1e-9)) return;
    update_point(c, cpw);
    update_point(c, cpw + 3 * d);
    double size = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    if (size <= c->tol || depth >= 70) return;
    double l[3 * (CRISP_MAX_DEGREE + 1)], r[3 * (CRISP_MAX_DEGREE + 1)];
    for (int q = 0; q < 3; q++) {
        double a[CRISP_MAX_DEGREE + 1], b[CRISP_MAX_DEGREE + 1];
        crisp__trim_split(cpw + q, d, 3, 0.5, a, b);
        for (int i = 0; i <= d; i++) {
            l[3 * i + q] = a[i];
            r[3 * i + q] = b[i];
        }
    }
    dist_rec(c, l, d, depth + 1);
    dist_rec(c, r, d, depth + 1);
}

double crisp_trim_exact_distance(const crisp_bezier_curve *pieces, int piece_count, double u,
                                 double v)
{
    dist_ctx c = {u, v, HUGE_VAL, 0.0};
    double ext = 0.0;
    for (int k = 0; k < piece_count; k++)
        for (int i = 0; i <= pieces[k].degree; i++) {
            const double *h = pieces[k].cpw + 3 * i;
            ext = fmax(ext, fmax(fabs(h[0] / h[2]), fabs(h[1] / h[2])));
        }
    c.tol = 1e-12 * fmax(ext, 1.0);
    for (int k = 0; k < piece_count; k++)
        dist_rec(&c, pieces[k].cpw, pieces[k].degree, 0);
    return c.best;
}
