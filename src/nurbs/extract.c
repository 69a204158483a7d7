/* Bézier extraction: a B-spline curve becomes one homogeneous Bézier piece per non-empty knot
 * span, a surface one patch per non-empty span pair. Each span's Bézier points come from local
 * knot insertion (The NURBS Book A5.6, applied span by span), so unclamped knot vectors and any
 * knot multiplicities need no separate clamping pass. Surfaces take one pass along u (every row)
 * and one along v (every column of the result).
 */
#include "nurbs_internal.h"

#include <string.h>

/* Upper bound on the control points a surface may extract to (2 GiB of doubles). */
#define MAX_PATCH_POINTS ((size_t)1 << 26)

crisp_status crisp_curve_to_bezier(const crisp_curve *c, crisp_bezier_curve **dest, int *count)
{
    *dest = NULL;
    *count = 0;
    const int p = c->degree, nc = c->dim + 1;
    int n = crisp__count_spans(c->knots, p, c->count);
    crisp_bezier_curve *b = crisp_calloc_array((size_t)n, sizeof *b);
    if (!b) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for %d Bézier pieces", n);
    int m = 0;
    for (int k = p; k < c->count; k++) {
        if (!(c->knots[k] < c->knots[k + 1])) continue;
        crisp_bezier_curve *piece = &b[m++];
        piece->dim = c->dim;
        piece->degree = p;
        piece->rational = c->rational;
        piece->t0 = c->knots[k];
        piece->t1 = c->knots[k + 1];
        crisp__span_to_bezier(p, c->knots + k - p + 1, nc, c->cpw + (size_t)(k - p) * nc, nc,
                              piece->cpw);
    }
    *dest = b;
    *count = m;
    return CRISP_OK;
}

crisp_status crisp_surface_to_bezier(const crisp_surface *s, crisp_bezier_patches *dest)
{
    memset(dest, 0, sizeof *dest);
    const int pu = s->degree_u, pv = s->degree_v, nu = s->count_u, nv = s->count_v;
    const int su = crisp__count_surface_spans(s->knots_u, pu, nu);
    const int sv = crisp__count_surface_spans(s->knots_v, pv, nv);
    const size_t npatch = (size_t)su * (size_t)sv;
    const size_t per = (size_t)(pu + 1) * (size_t)(pv + 1);
    if (npatch * per > MAX_PATCH_POINTS)
        return crisp_error(CRISP_ERR_LIMIT,
                           "surface of %d x %d spans and degree (%d, %d) would extract to more "
                           "than %zu Bézier control points",
                           su, sv, pu, pv, MAX_PATCH_POINTS);
    const size_t width = (size_t)su * (size_t)(pu + 1); /* columns after the u pass */
    double *grid = crisp_malloc_array(width * (size_t)nv * 4, sizeof *grid);
    double *storage = crisp_malloc_array(npatch * per * 4, sizeof *storage);
    crisp_bezier_patch *patches = crisp_calloc_array(npatch, sizeof *patches);
    if (!grid || !storage || !patches) {
        crisp_free(grid);
        crisp_free(storage);
        crisp_free(patches);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for %zu Bézier patches", npatch);
    }

    /* u pass: every control row becomes su Bézier rows of pu + 1 points. */
    for (int j = 0; j < nv; j++) {
        size_t a = 0;
        for (int k = pu; k < nu; k++) {
            if (!crisp__surface_span_kept(s->knots_u, pu, nu, k)) continue;
            crisp__span_to_bezier(pu, s->knots_u + k - pu + 1, 4,
                                  s->cpw + ((size_t)j * nu + (size_t)(k - pu)) * 4, 4,
                                  grid + ((size_t)j * width + a * (size_t)(pu + 1)) * 4);
            a++;
        }
    }
    /* v pass: every column of the grid becomes sv Bézier columns of pv + 1 points. */
    double tmp[(CRISP_MAX_DEGREE + 1) * 4];
    size_t b = 0;
    for (int k = pv; k < nv; k++) {
        if (!crisp__surface_span_kept(s->knots_v, pv, nv, k)) continue;
        for (size_t col = 0; col < width; col++) {
            crisp__span_to_bezier(pv, s->knots_v + k - pv + 1, 4,
                                  grid + ((size_t)(k - pv) * width + col) * 4, (ptrdiff_t)width * 4,
                                  tmp);
            size_t a = col / (size_t)(pu + 1), i = col % (size_t)(pu + 1);
            double *out = storage + (b * (size_t)su + a) * per * 4;
            for (int l = 0; l <= pv; l++)
                memcpy(out + ((size_t)l * (size_t)(pu + 1) + i) * 4, tmp + l * 4, 4 * sizeof *out);
        }
        b++;
    }
    /* Patch records, u fastest, with their parameter boxes. */
    size_t idx = 0;
    for (int kv = pv; kv < nv; kv++) {
        if (!crisp__surface_span_kept(s->knots_v, pv, nv, kv)) continue;
        for (int ku = pu; ku < nu; ku++) {
            if (!crisp__surface_span_kept(s->knots_u, pu, nu, ku)) continue;
            crisp_bezier_patch *p = &patches[idx];
            p->du = pu;
            p->dv = pv;
            p->rational = s->rational;
            p->u0 = s->knots_u[ku];
            p->u1 = s->knots_u[ku + 1];
            p->v0 = s->knots_v[kv];
            p->v1 = s->knots_v[kv + 1];
            p->cpw = storage + idx * per * 4;
            idx++;
        }
    }
    crisp_free(grid);
    dest->count = (int)npatch;
    dest->patches = patches;
    dest->storage = storage;
    return CRISP_OK;
}

void crisp_bezier_patches_free(crisp_bezier_patches *p)
{
    if (!p) return;
    crisp_free(p->patches);
    crisp_free(p->storage);
    memset(p, 0, sizeof *p);
}
