/* Screen-space SLEFEs: a patch (polynomial or rational) seen through a perspective camera. The
 * homogeneous control points (w*P, w) are mapped to clip space, where X, Y, Z, W are polynomial
 * patches; each gets a SLEFE and X/W, Y/W, Z/W are bounded by interval division (docs/design.md
 * section 3). Also the iPASS screen width of object-space boxes (docs/design.md section 4) and tau
 * from it. */
#include "slefe_internal.h"

#define MAXD CRISP_SLEFE_MAX_DEGREE
#define MAXM CRISP_SLEFE_MAX_SEGMENTS

static crisp_status check_view(const char *fn, const crisp_slefe_view *view)
{
    if (!view) return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL view", fn);
    if (!(view->width > 0.0 && view->height > 0.0 && view->width < 1e9 && view->height < 1e9))
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: viewport %g x %g, expected positive sizes",
                           fn, view->width, view->height);
    if (!crisp__slefe_all_finite(&view->view_proj[0][0], 16, 1))
        return crisp_error(CRISP_ERR_NUMERIC, "%s: non-finite or huge view-projection matrix", fn);
    return CRISP_OK;
}

crisp_status crisp__slefe_check_view(const char *fn, const crisp_slefe_view *view)
{
    return check_view(fn, view);
}

crisp_status crisp__slefe_to_clip(const char *fn, const crisp_bezier_patch *p,
                                  const crisp_slefe_view *view, double *clip, double *err,
                                  double *hl, double *hh)
{
    /* err[r] bounds the rounding of coordinate r of any control point, so the exact clip-space
     * patch is within err of the computed one (the Bernstein basis sums to 1). */
    int count = (p->du + 1) * (p->dv + 1);
    for (int r = 0; r < 4; r++) {
        err[r] = 0.0;
        hl[r] = INFINITY;
        hh[r] = -INFINITY;
    }
    for (int i = 0; i < count; i++) {
        const double *v = p->cpw + i * 4;
        for (int r = 0; r < 4; r++) {
            double x = 0.0, a = 0.0;
            for (int c = 0; c < 4; c++) {
                double t = view->view_proj[c][r] * v[c];
                x += t;
                a += fabs(t);
            }
            clip[i * 4 + r] = x;
            if (a > err[r]) err[r] = a;
            hl[r] = crisp__min(hl[r], x);
            hh[r] = crisp__max(hh[r], x);
        }
    }
    for (int r = 0; r < 4; r++) {
        if (!(err[r] <= CRISP_SLEFE_MAX_MAGNITUDE))
            return crisp_error(CRISP_ERR_NUMERIC,
                               "%s: clip-space coordinates overflow (view-projection or control "
                               "points too large)",
                               fn);
        err[r] *= 4.0 * DBL_EPSILON;
        hl[r] -= err[r];
        hh[r] += err[r];
    }
    return CRISP_OK;
}

/* The grid bounds lo, up (4 coordinates per grid point, n points) widened by the transform's
 * rounding err[r] for each clip coordinate r in mask (bit r), the W > 0 check, and when w_px is
 * not NULL the iPASS width: the widest x or y extent in pixels over the grid points, each bound
 * clamped to the control points' range hl, hh (convex hull) before the division by W. */
crisp_status crisp__slefe_grid_width(const char *fn, const crisp_slefe_view *view, int n,
                                     unsigned mask, double *lo, double *up, const double *err,
                                     const double *hl, const double *hh, double *w_px)
{
    double wmin = INFINITY;
    for (int g = 0; g < n; g++) {
        for (int r = 0; r < 4; r++)
            if (mask >> r & 1u) {
                lo[g * 4 + r] -= err[r];
                up[g * 4 + r] += err[r];
            }
        wmin = crisp__min(wmin, crisp__max(lo[g * 4 + 3], hl[3]));
    }
    if (!(wmin > 0.0))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "%s: lower bound %g of clip-space W is not positive (the patch reaches "
                           "the eye plane: split or cull it)",
                           fn, wmin);
    if (!w_px) return CRISP_OK;
    double best = 0.0;
    for (int g = 0; g < n; g++) {
        double l[4], u[4], xl, xu, yl, yu;
        for (int r = 0; r < 4; r += r == 1 ? 2 : 1) {
            l[r] = crisp__max(lo[g * 4 + r], hl[r]);
            u[r] = crisp__min(up[g * 4 + r], hh[r]);
        }
        crisp__slefe_divide(l[0], u[0], l[3], u[3], &xl, &xu);
        crisp__slefe_divide(l[1], u[1], l[3], u[3], &yl, &yu);
        double wx = 0.5 * (xu - xl) * view->width, wy = 0.5 * (yu - yl) * view->height;
        if (wx > best) best = wx;
        if (wy > best) best = wy;
    }
    *w_px = best;
    return CRISP_OK;
}

crisp_status crisp_slefe_patch_screen(const crisp_bezier_patch *p, int segments,
                                      const crisp_slefe_view *view, double *ndc_lo, double *ndc_hi,
                                      double *w_px)
{
    const char *fn = "crisp_slefe_patch_screen";
    crisp_status s = crisp__slefe_check_patch(fn, p, segments);
    if (!s) s = check_view(fn, view);
    if (s) return s;
    crisp__slefe_tables_init();

    double clip[(MAXD + 1) * (MAXD + 1) * 4], err[4], hl[4], hh[4];
    s = crisp__slefe_to_clip(fn, p, view, clip, err, hl, hh);
    if (s) return s;
    crisp_bezier_patch q = *p;
    q.cpw = clip;
    q.rational = 1;

    int m = segments, n = CRISP_SLEFE_GRID(m);
    double lo[CRISP_SLEFE_GRID(MAXM) * 4], up[CRISP_SLEFE_GRID(MAXM) * 4];
    crisp__slefe_patch_nocheck(&q, m, 4, lo, up);
    /* Grid bounds widened by the transform's rounding; at the grid points (not in between) they
     * may also be clipped to the control points' range (convex hull). */
    s = crisp__slefe_grid_width(fn, view, n, 0xfu, lo, up, err, hl, hh, w_px);
    if (s) return s;
    if (ndc_lo && ndc_hi) return crisp__slefe_tiles(fn, m, lo, up, hl, hh, ndc_lo, ndc_hi);
    return CRISP_OK;
}

crisp_status crisp_slefe_boxes_screen_width(const crisp_slefe_view *view, int count,
                                            const double *lo, const double *hi, int stride,
                                            double *w_px)
{
    const char *fn = "crisp_slefe_boxes_screen_width";
    crisp_status s = check_view(fn, view);
    if (s) return s;
    if (count < 0 || stride < 3 || (count > 0 && (!lo || !hi)) || !w_px)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: count %d, stride %d (expected >= 3) or NULL "
                           "argument",
                           fn, count, stride);
    double best = 0.0;
    for (int b = 0; b < count; b++) {
        const double *l = lo + (size_t)b * stride, *h = hi + (size_t)b * stride;
        /* x/W is linear-fractional: over a box where W > 0 its extremes are at corners. */
        double xl = INFINITY, xu = -INFINITY, yl = INFINITY, yu = -INFINITY;
        for (int corner = 0; corner < 8; corner++) {
            double v[3] = {corner & 1 ? h[0] : l[0], corner & 2 ? h[1] : l[1],
                           corner & 4 ? h[2] : l[2]};
            double q[4];
            for (int k = 0; k < 4; k++)
                q[k] = view->view_proj[0][k] * v[0] + view->view_proj[1][k] * v[1] +
                       view->view_proj[2][k] * v[2] + view->view_proj[3][k];
            if (!(q[3] > 0.0))
                return crisp_error(CRISP_ERR_NUMERIC,
                                   "%s: box %d reaches the eye plane (W = %g at a corner)", fn, b,
                                   q[3]);
            double x = q[0] / q[3], y = q[1] / q[3];
            xl = crisp__min(xl, x);
            xu = crisp__max(xu, x);
            yl = crisp__min(yl, y);
            yu = crisp__max(yu, y);
        }
        double wx = 0.5 * (xu - xl) * view->width, wy = 0.5 * (yu - yl) * view->height;
        if (wx > best) best = wx;
        if (wy > best) best = wy;
    }
    *w_px = best;
    return CRISP_OK;
}
