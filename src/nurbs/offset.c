/* Offset surfaces (issue 13; IGES 140): O(u, v) = S(u, v) + d N(u, v), N the unit normal
 * (crisp_surface_normal: also at poles and collapsed sides), approximated by a bicubic B-spline
 * over S's own domain and parametrisation (so trim curves in S's (u, v) trim O unchanged).
 *
 * Method: a tensor grid of cells starting at S's knot lines (where S and so O may lose smoothness);
 * each cell gets the bicubic Hermite patch of O's values, first partials and twist at its corners
 * (derivatives by second-order one-sided differences taken inside the cell, so two cells sharing an
 * edge build the same edge curve: the result is C0 everywhere and watertight); cells whose patch
 * misses O by more than tol at a 4 x 4 grid of test points split their column and row in two, until
 * every cell passes or the grid reaches max_cells per direction (and max_cells^2 / 4 cells in all:
 * the work is bounded). The patches are then one B-spline
 * with triple interior knots. The offset of a plane is reproduced up to the rounding of the
 * difference quotients (1e-9 of its size); elsewhere the error is the measured one (a bound at
 * the test points, not a proof between them). IGES readers use exact forms where they exist
 * (shifted planes, analytic surfaces with grown radii). */
#include "crisp/nurbs.h"

#include "nurbs_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct off_ctx {
    const crisp_surface *s;
    double d;
} off_ctx;

static void off_eval(const off_ctx *c, double u, double v, double out[3])
{
    double p[3], n[3];
    crisp_surface_eval(c->s, u, v, p);
    crisp_surface_normal(c->s, u, v, n);
    for (int k = 0; k < 3; k++)
        out[k] = p[k] + c->d * n[k];
}

/* Value, d/du, d/dv and twist at corner (u, v) of a cell; su, sv: +-1 into the cell; hu, hv the
 * difference steps. Second-order one-sided differences: f' = (-3 f0 + 4 f1 - f2) / 2h. */
static void corner(const off_ctx *c, double u, double v, double su, double sv, double hu, double hv,
                   double o[4][3])
{
    double f[3][3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            off_eval(c, u + su * i * hu, v + sv * j * hv, f[i][j]);
    static const double w[3] = {-1.5, 2, -0.5};
    for (int k = 0; k < 3; k++) {
        double du = 0, dv = 0, duv = 0;
        for (int i = 0; i < 3; i++) {
            du += w[i] * f[i][0][k];
            dv += w[i] * f[0][i][k];
            for (int j = 0; j < 3; j++)
                duv += w[i] * w[j] * f[i][j][k];
        }
        o[0][k] = f[0][0][k];
        o[1][k] = su * du / hu;
        o[2][k] = sv * dv / hv;
        o[3][k] = su * sv * duv / (hu * hv);
    }
}

/* The 16 Bézier points (j * 4 + i, i along u) of the cell [ua, ub] x [va, vb]. */
static void cell_patch(const off_ctx *c, double ua, double ub, double va, double vb,
                       double b[16][3])
{
    double du = ub - ua, dv = vb - va, hu = 1e-4 * du, hv = 1e-4 * dv;
    for (int cj = 0; cj < 2; cj++)
        for (int ci = 0; ci < 2; ci++) {
            double o[4][3], su = ci ? -1 : 1, sv = cj ? -1 : 1;
            corner(c, ci ? ub : ua, cj ? vb : va, su, sv, hu, hv, o);
            int i0 = ci ? 3 : 0, j0 = cj ? 3 : 0, i1 = ci ? 2 : 1, j1 = cj ? 2 : 1;
            for (int k = 0; k < 3; k++) {
                double a = o[1][k] * du / 3 * su, e = o[2][k] * dv / 3 * sv,
                       t = o[3][k] * du * dv / 9 * su * sv;
                b[j0 * 4 + i0][k] = o[0][k];
                b[j0 * 4 + i1][k] = o[0][k] + a;
                b[j1 * 4 + i0][k] = o[0][k] + e;
                b[j1 * 4 + i1][k] = o[0][k] + a + e + t;
            }
        }
}

static void bern3(double t, double b[4])
{
    double s = 1 - t;
    b[0] = s * s * s, b[1] = 3 * s * s * t, b[2] = 3 * s * t * t, b[3] = t * t * t;
}

static double cell_error(const off_ctx *c, double ua, double ub, double va, double vb,
                         double b[16][3])
{
    double worst = 0;
    for (int q = 0; q < 4; q++)
        for (int r = 0; r < 4; r++) {
            double s = (2 * q + 1) / 8.0, t = (2 * r + 1) / 8.0, bu[4], bv[4], p[3] = {0, 0, 0},
                   o[3];
            bern3(s, bu);
            bern3(t, bv);
            for (int j = 0; j < 4; j++)
                for (int i = 0; i < 4; i++)
                    for (int k = 0; k < 3; k++)
                        p[k] += bu[i] * bv[j] * b[j * 4 + i][k];
            off_eval(c, ua + s * (ub - ua), va + t * (vb - va), o);
            double e = sqrt((p[0] - o[0]) * (p[0] - o[0]) + (p[1] - o[1]) * (p[1] - o[1]) +
                            (p[2] - o[2]) * (p[2] - o[2]));
            if (!(e <= worst)) worst = e; /* NaN counts as worst */
        }
    return worst;
}

/* Distinct knot values of a knot vector inside [lo, hi] (ends included), at most cap. */
static int breaks_of(const double *k, int nk, double lo, double hi, double *out, int cap)
{
    int n = 0;
    out[n++] = lo;
    for (int i = 0; i < nk && n < cap - 1; i++)
        if (k[i] > out[n - 1] && k[i] < hi) out[n++] = k[i];
    out[n++] = hi;
    return n;
}

crisp_status crisp_surface_offset(const crisp_surface *s, double d, double tol, int max_cells,
                                  crisp_surface **dest)
{
    const char *fn = "crisp_surface_offset";
    if (!s || !dest || !isfinite(d) || !(tol > 0) || max_cells < 1)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: NULL argument, non-finite distance or tol <= 0", fn);
    *dest = NULL;
    off_ctx c = {s, d};
    double dom[4];
    crisp_surface_domain(s, dom);
    int cap = max_cells + 1;
    double *U = crisp_malloc_array((size_t)cap, sizeof *U),
           *V = crisp_malloc_array((size_t)cap, sizeof *V);
    double *U2 = crisp_malloc_array((size_t)cap, sizeof *U2),
           *V2 = crisp_malloc_array((size_t)cap, sizeof *V2);
    unsigned char *su = crisp_malloc_array((size_t)cap, 1),
                  *sv = crisp_malloc_array((size_t)cap, 1);
    double *pts = NULL, *ku = NULL, *kv = NULL;
    crisp_status st = CRISP_OK;
    if (!U || !V || !U2 || !V2 || !su || !sv) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
        goto out;
    }
    int nu = breaks_of(s->knots_u, s->count_u + s->degree_u + 1, dom[0], dom[1], U, cap) - 1;
    int nv = breaks_of(s->knots_v, s->count_v + s->degree_v + 1, dom[2], dom[3], V, cap) - 1;
    if (!(dom[1] > dom[0]) || !(dom[3] > dom[2])) {
        st = crisp_error(CRISP_ERR_INVALID_ARG, "%s: empty domain", fn);
        goto out;
    }
    if (nu > max_cells || nv > max_cells ||
        (long long)nu * nv > (long long)max_cells * max_cells / 4) {
        st = crisp_error(CRISP_ERR_LIMIT, "%s: %d x %d knot spans (at most %d cells)", fn, nu, nv,
                         max_cells * max_cells / 4);
        goto out;
    }
    double worst = 0;
    for (int round = 0;; round++) {
        memset(su, 0, (size_t)nu);
        memset(sv, 0, (size_t)nv);
        int fails = 0;
        worst = 0;
        for (int j = 0; j < nv; j++)
            for (int i = 0; i < nu; i++) {
                double b[16][3];
                cell_patch(&c, U[i], U[i + 1], V[j], V[j + 1], b);
                double e = cell_error(&c, U[i], U[i + 1], V[j], V[j + 1], b);
                if (!(e <= worst)) worst = e;
                if (!(e <= tol)) su[i] = sv[j] = 1, fails++;
            }
        if (!fails) break;
        int mu = nu, mv = nv;
        for (int i = 0; i < nu; i++)
            mu += su[i];
        for (int j = 0; j < nv; j++)
            mv += sv[j];
        if (mu > max_cells || mv > max_cells ||
            (long long)mu * mv > (long long)max_cells * max_cells / 4 || round > 40) {
            st = crisp_error(CRISP_ERR_LIMIT,
                             "%s: offset %g not within %g (worst %g) with %d x %d cells", fn, d,
                             tol, worst, nu, nv);
            goto out;
        }
        int n2 = 0;
        for (int i = 0; i < nu; i++) {
            U2[n2++] = U[i];
            if (su[i]) U2[n2++] = 0.5 * (U[i] + U[i + 1]);
        }
        U2[n2] = U[nu];
        memcpy(U, U2, (size_t)(n2 + 1) * sizeof *U);
        nu = n2;
        n2 = 0;
        for (int j = 0; j < nv; j++) {
            V2[n2++] = V[j];
            if (sv[j]) V2[n2++] = 0.5 * (V[j] + V[j + 1]);
        }
        V2[n2] = V[nv];
        memcpy(V, V2, (size_t)(n2 + 1) * sizeof *V);
        nv = n2;
    }
    int cu = 3 * nu + 1, cv = 3 * nv + 1;
    if ((long long)cu * cv > CRISP_MAX_CONTROL_POINTS) {
        st = crisp_error(CRISP_ERR_LIMIT, "%s: %d x %d control points", fn, cu, cv);
        goto out;
    }
    pts = crisp_malloc_array((size_t)cu * (size_t)cv, 3 * sizeof *pts);
    ku = crisp_malloc_array((size_t)cu + 4, sizeof *ku);
    kv = crisp_malloc_array((size_t)cv + 4, sizeof *kv);
    if (!pts || !ku || !kv) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
        goto out;
    }
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            double b[16][3];
            cell_patch(&c, U[i], U[i + 1], V[j], V[j + 1], b);
            for (int q = 0; q < 4; q++)
                for (int p = 0; p < 4; p++)
                    memcpy(pts + 3 * ((size_t)(3 * j + q) * cu + 3 * i + p), b[q * 4 + p],
                           3 * sizeof(double));
        }
    int n = 0;
    for (int r = 0; r < 4; r++)
        ku[n++] = U[0];
    for (int i = 1; i < nu; i++)
        for (int r = 0; r < 3; r++)
            ku[n++] = U[i];
    for (int r = 0; r < 4; r++)
        ku[n++] = U[nu];
    n = 0;
    for (int r = 0; r < 4; r++)
        kv[n++] = V[0];
    for (int j = 1; j < nv; j++)
        for (int r = 0; r < 3; r++)
            kv[n++] = V[j];
    for (int r = 0; r < 4; r++)
        kv[n++] = V[nv];
    st = crisp_surface_create(3, 3, cu, cv, ku, kv, pts, NULL, dest);
out:
    crisp_free(U);
    crisp_free(V);
    crisp_free(U2);
    crisp_free(V2);
    crisp_free(su);
    crisp_free(sv);
    crisp_free(pts);
    crisp_free(ku);
    crisp_free(kv);
    return st;
}
