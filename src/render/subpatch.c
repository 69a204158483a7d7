/* Extracting a sub-patch of a Bézier patch by de Casteljau (shared by the planner, the scene boxes
 * and the CPU backend's leaf hulls). */
#include <string.h>

#include "render_internal.h"

/* One line of n + 1 homogeneous points (stride doubles apart) restricted in place to [at, 1]
 * (keep_upper) or [0, at] of its parameter. The points are de Casteljau's b_i^r, computed as
 * crisp_bezier_patch_split_u/_v compute them (s b_i^{r-1} + t b_{i+1}^{r-1}, s = 1 - t), so the
 * result is bit for bit the part a split keeps: the upper part b_i^{n-i} is what an ascending
 * pass leaves in place, the lower part b_0^i what a descending pass leaves (issue 12: the
 * splits' copies and both halves were most of the CPU backend's leaf hulls). */
static void cut_line(double *q, ptrdiff_t stride, int n, double t, int keep_upper)
{
    const double s = 1.0 - t;
    if (keep_upper) {
        for (int r = 1; r <= n; r++)
            for (int i = 0; i <= n - r; i++) {
                double *a = q + i * stride, *b = a + stride;
                for (int c = 0; c < 4; c++)
                    a[c] = s * a[c] + t * b[c];
            }
    } else {
        for (int r = 1; r <= n; r++)
            for (int i = n; i >= r; i--) {
                double *b = q + i * stride, *a = b - stride;
                for (int c = 0; c < 4; c++)
                    b[c] = s * a[c] + t * b[c];
            }
    }
}

/* Cuts *a (control points in place) at local parameter `at` along u or v, keeping the lower or
 * upper part; its parameter interval as crisp_bezier_patch_split_u/_v set it. */
static void cut(crisp_bezier_patch *a, double at, int along_u, int keep_upper)
{
    const int nu = a->du + 1;
    if (along_u) {
        for (int j = 0; j <= a->dv; j++)
            cut_line(a->cpw + (size_t)j * nu * 4, 4, a->du, at, keep_upper);
        double um = a->u0 + at * (a->u1 - a->u0);
        if (keep_upper)
            a->u0 = um;
        else
            a->u1 = um;
    } else {
        for (int i = 0; i < nu; i++)
            cut_line(a->cpw + (size_t)i * 4, (ptrdiff_t)nu * 4, a->dv, at, keep_upper);
        double vm = a->v0 + at * (a->v1 - a->v0);
        if (keep_upper)
            a->v0 = vm;
        else
            a->v1 = vm;
    }
}

/* The sub-patch [s0, s1] x [t0, t1] of p (local parameters) into storage (tmp is not used: kept in
 * the interface for its callers' scratch). */
void crisp__subpatch(const crisp_bezier_patch *p, double s0, double s1, double t0, double t1,
                     double *storage, double *tmp, crisp_bezier_patch *dest)
{
    (void)tmp;
    crisp_bezier_patch a = *p;
    size_t n = (size_t)(p->du + 1) * (p->dv + 1) * 4;
    memmove(storage, p->cpw, n * sizeof *storage);
    a.cpw = storage;
    if (s0 > 0) {
        cut(&a, s0, 1, 1);
        s1 = (s1 - s0) / (1 - s0);
    }
    if (s1 < 1) cut(&a, s1, 1, 0);
    if (t0 > 0) {
        cut(&a, t0, 0, 1);
        t1 = (t1 - t0) / (1 - t0);
    }
    if (t1 < 1) cut(&a, t1, 0, 0);
    *dest = a;
}
