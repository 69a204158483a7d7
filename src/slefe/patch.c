/* Tensor-product SLEFEs of Bézier patches by the two-pass construction (Lutterkort & Peters 2001;
 * docs/design.md section 3): v-SLEFE every control row, then u-SLEFE the upper results keeping the
 * upper side and the lower results keeping the lower side. Valid because the Bernstein polynomials
 * in u and the hat functions in v are non-negative. Each homogeneous coordinate separately;
 * per-tile boxes (rational: divided by W) for tessellators that do not interpolate bilinearly. */
#include "slefe_internal.h"

#include <string.h>

#define MAXD CRISP_SLEFE_MAX_DEGREE
#define MAXM CRISP_SLEFE_MAX_SEGMENTS

crisp_status crisp__slefe_check_patch(const char *fn, const crisp_bezier_patch *p, int segments)
{
    if (!p || !p->cpw) return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL patch", fn);
    crisp_status s = crisp__slefe_check(fn, p->du, segments);
    if (!s) s = crisp__slefe_check(fn, p->dv, segments);
    if (s) return s;
    if (!crisp__slefe_all_finite(p->cpw, (p->du + 1) * (p->dv + 1) * 4, 1))
        return crisp_error(CRISP_ERR_NUMERIC, "%s: non-finite or huge (above 1e300) control point",
                           fn);
    return CRISP_OK;
}

/* Bicubic on 3 segments, the iPASS case: tables read once, the loops fully unrolled by the
 * compiler (all trip counts are constants). */
static void bicubic3(const double *cpw, int c, const crisp_slefe_table *t, double *lo, double *up)
{
    const double *U = t->upper, *L = t->lower;
    double g = t->guard;
    double rl[4][4], ru[4][4]; /* [i][kv] */
    for (int i = 0; i < 4; i++) {
        const double *b = cpw + i * 4 + c;
        crisp__slefe_side(3, b, 16, g, U, L, 1.0, 3, ru[i], 1);
        crisp__slefe_side(3, b, 16, g, L, U, -1.0, 3, rl[i], 1);
    }
    for (int kv = 0; kv < 4; kv++) {
        double cu[4] = {ru[0][kv], ru[1][kv], ru[2][kv], ru[3][kv]};
        double cl[4] = {rl[0][kv], rl[1][kv], rl[2][kv], rl[3][kv]};
        crisp__slefe_side(3, cu, 1, g, U, L, 1.0, 3, up + (kv * 4) * 4 + c, 4);
        crisp__slefe_side(3, cl, 1, g, L, U, -1.0, 3, lo + (kv * 4) * 4 + c, 4);
    }
}

#if defined(__GNUC__)
#define INLINE_BODY inline __attribute__((always_inline))
#else
#define INLINE_BODY inline
#endif

/* Coordinate c of a general patch of degrees du x dv (general: constants for the common ones). */
static INLINE_BODY void general_body(const crisp_bezier_patch *p, int du, int dv, int c, int m,
                                     const crisp_slefe_table *tu, const crisp_slefe_table *tv,
                                     double *lo, double *up)
{
    int n = m + 1;
    double rl[(MAXD + 1) * (MAXM + 1)], ru[(MAXD + 1) * (MAXM + 1)]; /* [i * n + kv] */
    for (int i = 0; i <= du; i++) {
        const double *b = p->cpw + i * 4 + c;
        int stride = (du + 1) * 4;
        if (dv >= 2) {
            crisp__slefe_side(dv, b, stride, tv->guard, tv->upper, tv->lower, 1.0, m, ru + i * n,
                              1);
            crisp__slefe_side(dv, b, stride, tv->guard, tv->lower, tv->upper, -1.0, m, rl + i * n,
                              1);
        } else {
            crisp__slefe_kernel(dv, b, stride, tv, m, rl + i * n, 1, ru + i * n, 1);
        }
    }
    for (int kv = 0; kv < n; kv++) {
        double *ou = up + kv * n * 4 + c, *ol = lo + kv * n * 4 + c;
        if (du >= 2) {
            crisp__slefe_side(du, ru + kv, n, tu->guard, tu->upper, tu->lower, 1.0, m, ou, 4);
            crisp__slefe_side(du, rl + kv, n, tu->guard, tu->lower, tu->upper, -1.0, m, ol, 4);
        } else {
            double scratch[MAXM + 1];
            crisp__slefe_kernel(du, ru + kv, n, tu, m, scratch, 1, ou, 4);
            crisp__slefe_kernel(du, rl + kv, n, tu, m, ol, 4, scratch, 1);
        }
    }
}

/* general_body with constant degrees for the common cases (cubic by quadratic: impeller.igs;
 * quintic: Ventilator.stp; 6 x 10: occt_linkrods.step; quadratic by linear or quadratic): the
 * same operations in the same order. */
static void general(const crisp_bezier_patch *p, int c, int m, const crisp_slefe_table *tu,
                    const crisp_slefe_table *tv, double *lo, double *up)
{
    int du = p->du, dv = p->dv;
    if (du == 3 && dv == 2)
        general_body(p, 3, 2, c, m, tu, tv, lo, up);
    else if (du == 2 && dv == 3)
        general_body(p, 2, 3, c, m, tu, tv, lo, up);
    else if (du == 2 && dv == 1)
        general_body(p, 2, 1, c, m, tu, tv, lo, up);
    else if (du == 2 && dv == 2)
        general_body(p, 2, 2, c, m, tu, tv, lo, up);
    else if (du == 5 && dv == 5)
        general_body(p, 5, 5, c, m, tu, tv, lo, up);
    else if (du == 6 && dv == 10)
        general_body(p, 6, 10, c, m, tu, tv, lo, up);
    else
        general_body(p, du, dv, c, m, tu, tv, lo, up);
}

void crisp__slefe_patch_coordinate(const crisp_bezier_patch *p, int m, int c, double *lo,
                                   double *up)
{
    crisp_slefe_table tu = crisp__slefe_table(p->du, m), tv = crisp__slefe_table(p->dv, m);
    if (p->du == 3 && p->dv == 3 && m == 3)
        bicubic3(p->cpw, c, &tu, lo, up);
    else
        general(p, c, m, &tu, &tv, lo, up);
}

void crisp__slefe_patch_nocheck(const crisp_bezier_patch *p, int m, int ncomp, double *lo,
                                double *up)
{
    crisp_slefe_table tu = crisp__slefe_table(p->du, m), tv = crisp__slefe_table(p->dv, m);
    if (p->du == 3 && p->dv == 3 && m == 3) {
        for (int c = 0; c < ncomp; c++)
            bicubic3(p->cpw, c, &tu, lo, up);
    } else {
        for (int c = 0; c < ncomp; c++)
            general(p, c, m, &tu, &tv, lo, up);
    }
}

crisp_status crisp_slefe_patch(const crisp_bezier_patch *p, int segments, double *lo, double *up)
{
    crisp_status s = crisp__slefe_check_patch("crisp_slefe_patch", p, segments);
    if (s) return s;
    if (!lo || !up) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_slefe_patch: NULL output");
    crisp__slefe_tables_init();
    int ncomp = p->rational ? 4 : 3;
    crisp__slefe_patch_nocheck(p, segments, ncomp, lo, up);
    if (!p->rational) {
        int n = CRISP_SLEFE_GRID(segments);
        for (int g = 0; g < n; g++)
            lo[g * 4 + 3] = up[g * 4 + 3] = 1.0;
    }
    return CRISP_OK;
}

crisp_status crisp__slefe_tiles(const char *fn, int m, const double *lo, const double *up,
                                const double *hull_lo, const double *hull_hi, double *box_lo,
                                double *box_hi)
{
    int n = m + 1;
    for (int kv = 0; kv < m; kv++) {
        for (int ku = 0; ku < m; ku++) {
            int g[4] = {kv * n + ku, kv * n + ku + 1, (kv + 1) * n + ku, (kv + 1) * n + ku + 1};
            double cl[4], cu[4];
            for (int i = 0; i < 4; i++) {
                cl[i] = crisp__min(crisp__min(lo[g[0] * 4 + i], lo[g[1] * 4 + i]),
                                   crisp__min(lo[g[2] * 4 + i], lo[g[3] * 4 + i]));
                cu[i] = crisp__max(crisp__max(up[g[0] * 4 + i], up[g[1] * 4 + i]),
                                   crisp__max(up[g[2] * 4 + i], up[g[3] * 4 + i]));
                if (hull_lo) {
                    /* convex hull property: constant bounds valid over the whole patch */
                    cl[i] = crisp__max(cl[i], hull_lo[i]);
                    cu[i] = crisp__min(cu[i], hull_hi[i]);
                }
            }
            double *bl = box_lo + (kv * m + ku) * 3, *bh = box_hi + (kv * m + ku) * 3;
            if (cl[3] == 1.0 && cu[3] == 1.0) {
                memcpy(bl, cl, 3 * sizeof *bl);
                memcpy(bh, cu, 3 * sizeof *bh);
                continue;
            }
            if (!(cl[3] > 0.0))
                return crisp_error(CRISP_ERR_NUMERIC,
                                   "%s: lower bound %g of W on tile (%d, %d) is not positive (the "
                                   "patch reaches the eye plane: split or cull it)",
                                   fn, cl[3], ku, kv);
            for (int i = 0; i < 3; i++)
                crisp__slefe_divide(cl[i], cu[i], cl[3], cu[3], bl + i, bh + i);
        }
    }
    return CRISP_OK;
}

crisp_status crisp_slefe_patch_tiles(int segments, const double *lo, const double *up,
                                     double *box_lo, double *box_hi)
{
    const char *fn = "crisp_slefe_patch_tiles";
    if (segments < 1 || segments > MAXM)
        return crisp_error(CRISP_ERR_LIMIT, "%s: segments %d outside 1..%d", fn, segments, MAXM);
    if (!lo || !up || !box_lo || !box_hi)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL argument", fn);
    return crisp__slefe_tiles(fn, segments, lo, up, NULL, NULL, box_lo, box_hi);
}

crisp_status crisp_slefe_patch_points(int segments, const double *lo, const double *up,
                                      double *box_lo, double *box_hi)
{
    const char *fn = "crisp_slefe_patch_points";
    if (segments < 1 || segments > MAXM)
        return crisp_error(CRISP_ERR_LIMIT, "%s: segments %d outside 1..%d", fn, segments, MAXM);
    if (!lo || !up || !box_lo || !box_hi)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL argument", fn);
    int n = CRISP_SLEFE_GRID(segments);
    for (int g = 0; g < n; g++) {
        const double *l = lo + g * 4, *u = up + g * 4;
        double *bl = box_lo + g * 3, *bh = box_hi + g * 3;
        if (l[3] == 1.0 && u[3] == 1.0) {
            memcpy(bl, l, 3 * sizeof *bl);
            memcpy(bh, u, 3 * sizeof *bh);
            continue;
        }
        if (!(l[3] > 0.0))
            return crisp_error(CRISP_ERR_NUMERIC,
                               "%s: lower bound %g of W at grid point (%d, %d) is not positive", fn,
                               l[3], g % (segments + 1), g / (segments + 1));
        for (int i = 0; i < 3; i++)
            crisp__slefe_divide(l[i], u[i], l[3], u[3], bl + i, bh + i);
    }
    return CRISP_OK;
}
