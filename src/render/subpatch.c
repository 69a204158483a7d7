/* Extracting a sub-patch of a Bézier patch by de Casteljau splits (shared by the planner and the
 * scene boxes). */
#include <string.h>

#include "render_internal.h"

/* The sub-patch [s0, s1] x [t0, t1] of p (local parameters) into storage. */
void crisp__subpatch(const crisp_bezier_patch *p, double s0, double s1, double t0, double t1,
                     double *storage, double *tmp, crisp_bezier_patch *dest)
{
    crisp_bezier_patch a = *p, lo, hi;
    size_t n = (size_t)(p->du + 1) * (p->dv + 1) * 4;
    lo.cpw = tmp;
    hi.cpw = storage;
    if (s0 > 0) {
        crisp_bezier_patch_split_u(&a, s0, &lo, &hi);
        a = hi;
        memcpy(tmp, storage, n * sizeof *tmp);
        a.cpw = tmp;
        s1 = (s1 - s0) / (1 - s0);
    }
    if (s1 < 1) {
        lo.cpw = storage;
        hi.cpw = storage + n;
        crisp_bezier_patch_split_u(&a, s1, &lo, &hi);
        a = lo;
        memcpy(tmp, storage, n * sizeof *tmp);
        a.cpw = tmp;
    }
    if (t0 > 0) {
        lo.cpw = storage + n;
        hi.cpw = storage;
        crisp_bezier_patch_split_v(&a, t0, &lo, &hi);
        a = hi;
        memcpy(tmp, storage, n * sizeof *tmp);
        a.cpw = tmp;
        t1 = (t1 - t0) / (1 - t0);
    }
    if (t1 < 1) {
        lo.cpw = storage;
        hi.cpw = storage + n;
        crisp_bezier_patch_split_v(&a, t1, &lo, &hi);
        a = lo;
        memcpy(tmp, storage, n * sizeof *tmp);
        a.cpw = tmp;
    }
    memcpy(storage, a.cpw, n * sizeof *storage);
    *dest = a;
    dest->cpw = storage;
}

