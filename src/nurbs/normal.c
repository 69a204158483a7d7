/* Unit normals that stay right at singular points (issue 13): cone apexes, sphere poles and other
 * collapsed patch sides, where S_u x S_v vanishes and a plain normalisation gives zero, NaN or a
 * direction made of rounding noise (the "starburst" at a cone's apex).
 *
 * Where the cross product is degenerate (one partial derivative vanishes, or both are parallel),
 * the normal is taken as its limit from inside the parameter domain, along the direction that
 * leaves the degenerate side: for a side that collapses in s the limit along t, and so on. The
 * limit is estimated from normals at two nearby interior points (h and 2h away, Richardson
 * extrapolation 2 n(h) - n(2h), exact for a cone, whose normal is constant along a generator, and
 * O(h^2) for a sphere's pole); h grows (1e-7, 1e-5, 1e-3 of the parameter range) until the
 * nearby normals are regular. This is the directional limit the shading of a mesh vertex at the
 * singular point needs: around a cone's apex each generator keeps its own normal. */
#include "crisp/nurbs.h"

#include "nurbs_internal.h"

#include <math.h>

typedef void (*derivs_fn)(const void *surf, double a, double b, double *p, double *da, double *db);

static double norm3(const double *a)
{
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}

static void cross3(const double *a, const double *b, double *d)
{
    d[0] = a[1] * b[2] - a[2] * b[1];
    d[1] = a[2] * b[0] - a[0] * b[2];
    d[2] = a[0] * b[1] - a[1] * b[0];
}

/* The cross product at (a, b) when it is regular (not degenerate by `scale`), else 0. */
static int regular_cross(derivs_fn f, const void *surf, double a, double b, double scale,
                         double n[3])
{
    double p[3], da[3], db[3];
    f(surf, a, b, p, da, db);
    cross3(da, db, n);
    double la = norm3(da), lb = norm3(db), ln = norm3(n);
    if (!(la > 1e-9 * scale) || !(lb > 1e-9 * scale) || !(ln > 1e-9 * la * lb)) return 0;
    for (int k = 0; k < 3; k++)
        n[k] /= ln;
    return 1;
}

/* dom: a0, a1, b0, b1; scale: a length of the surface (for "vanishing"). */
static int robust_normal(derivs_fn f, const void *surf, const double dom[4], double a, double b,
                         double scale, double dest[3])
{
    if (regular_cross(f, surf, a, b, scale, dest)) return 1;
    double p[3], da[3], db[3];
    f(surf, a, b, p, da, db);
    double la = norm3(da), lb = norm3(db), ra = dom[1] - dom[0], rb = dom[3] - dom[2];
    /* Which way leaves the degenerate side: along b when S_a vanishes (the side b = const
     * collapses), along a when S_b does, diagonally otherwise; always towards the domain's
     * middle. */
    double sa = a < 0.5 * (dom[0] + dom[1]) ? 1 : -1, sb = b < 0.5 * (dom[2] + dom[3]) ? 1 : -1;
    double dir[2] = {sa, sb};
    if (!(la > 1e-9 * scale) && lb > 1e-9 * scale)
        dir[0] = 0;
    else if (!(lb > 1e-9 * scale) && la > 1e-9 * scale)
        dir[1] = 0;
    for (double h = 1e-7; h < 2e-3; h *= 100) {
        double n1[3], n2[3];
        if (!regular_cross(f, surf, a + dir[0] * h * ra, b + dir[1] * h * rb, scale, n1) ||
            !regular_cross(f, surf, a + 2 * dir[0] * h * ra, b + 2 * dir[1] * h * rb, scale, n2))
            continue;
        double n[3];
        for (int k = 0; k < 3; k++)
            n[k] = 2 * n1[k] - n2[k];
        double ln = norm3(n);
        if (!(ln > 0.5)) continue; /* the normal turns fast here: keep the nearer one */
        for (int k = 0; k < 3; k++)
            dest[k] = n[k] / ln;
        return 1;
    }
    dest[0] = dest[1] = dest[2] = 0;
    return 0;
}

static void bezier_derivs(const void *surf, double a, double b, double *p, double *da, double *db)
{
    crisp_bezier_patch_derivs(surf, a, b, p, da, db);
}

static void surface_derivs(const void *surf, double a, double b, double *p, double *da, double *db)
{
    crisp_surface_derivs(surf, a, b, p, da, db, NULL, NULL, NULL);
}

int crisp_bezier_patch_normal(const crisp_bezier_patch *p, double s, double t, double dest[3])
{
    double box[6];
    crisp_bezier_patch_bbox(p, box);
    double scale = hypot(hypot(box[3] - box[0], box[4] - box[1]), box[5] - box[2]);
    const double dom[4] = {0, 1, 0, 1};
    return robust_normal(bezier_derivs, p, dom, s, t, scale, dest);
}

int crisp_surface_normal(const crisp_surface *s, double u, double v, double dest[3])
{
    double box[6], dom[4];
    crisp_surface_bbox(s, box);
    crisp_surface_domain(s, dom);
    double scale = hypot(hypot(box[3] - box[0], box[4] - box[1]), box[5] - box[2]);
    /* per unit of the larger parameter range, as for a patch's [0, 1] */
    scale /= fmax(dom[1] - dom[0], dom[3] - dom[2]);
    return robust_normal(surface_derivs, s, dom, u, v, scale, dest);
}
