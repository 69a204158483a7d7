/* Extracting a sub-patch of a Bézier patch by de Casteljau splits (shared by the planner and the
 * scene boxes). */
#include <string.h>

#include "render_internal.h"

/* Split *a at local parameter `at` along u or v and keep the lower or upper part, whose control
 * points end up in tmp (a->cpw = tmp); storage holds 2 n doubles of scratch. */
static void cut(crisp_bezier_patch *a, double at, int along_u, int keep_upper, size_t n,
                double *storage, double *tmp)
{
    crisp_bezier_patch lo = *a, hi = *a;
    lo.cpw = storage;
    hi.cpw = storage + n;
    if (along_u)
        crisp_bezier_patch_split_u(a, at, &lo, &hi);
    else
        crisp_bezier_patch_split_v(a, at, &lo, &hi);
    *a = keep_upper ? hi : lo;
    memcpy(tmp, a->cpw, n * sizeof *tmp);
    a->cpw = tmp;
}

/* The sub-patch [s0, s1] x [t0, t1] of p (local parameters) into storage. */
void crisp__subpatch(const crisp_bezier_patch *p, double s0, double s1, double t0, double t1,
                     double *storage, double *tmp, crisp_bezier_patch *dest)
{
    crisp_bezier_patch a = *p;
    size_t n = (size_t)(p->du + 1) * (p->dv + 1) * 4;
    if (s0 > 0) {
        cut(&a, s0, 1, 1, n, storage, tmp);
        s1 = (s1 - s0) / (1 - s0);
    }
    if (s1 < 1) cut(&a, s1, 1, 0, n, storage, tmp);
    if (t0 > 0) {
        cut(&a, t0, 0, 1, n, storage, tmp);
        t1 = (t1 - t0) / (1 - t0);
    }
    if (t1 < 1) cut(&a, t1, 0, 0, n, storage, tmp);
    memcpy(storage, a.cpw, n * sizeof *storage);
    *dest = a;
    dest->cpw = storage;
}
