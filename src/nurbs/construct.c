/* Exact NURBS for analytic curves and surfaces: lines, circular and elliptic arcs, conic arcs,
 * planes, cylinders, cones, spheres, tori, surfaces of revolution, extrusions and ruled surfaces,
 * and the closed-form map between an arc's angle and its NURBS parameter.
 * Follows Piegl & Tiller, "The NURBS Book", A7.1 (circle), A7.3 (conic arc), A8.1 (revolution),
 * sections 8.3-8.4 (extruded and ruled surfaces), 5.5 (degree elevation, done here per Bézier
 * piece).
 *
 * Arcs: n = ceil(sweep / 90 degrees) rational quadratic segments of equal sweep 2 phi, weights
 * (1, cos phi, 1), knots doubled at the segment ends with knot value = angle there. In a segment
 * with local parameter s in [0, 1] the angle theta from the segment's middle satisfies
 *     tan(theta / 2) = (2 s - 1) tan(phi / 2),
 * because the half-angle substitution tau = tan(theta / 2) makes the circle the rational quadratic
 * ((1 - tau^2), 2 tau) / (1 + tau^2); a linear map tau(s) keeps it rational quadratic in s, and the
 * one with tau(0) = -tan(phi/2), tau(1) = tan(phi/2) has equal end weights (1 + tau^2 equal at both
 * ends), which is the unique standard form: the segment above. */
#include "crisp/construct.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---- placement ---------------------------------------------------------------------------------
 */

crisp_status crisp_placement_make(const double origin[3], const double axis[3], const double *ref,
                                  crisp_placement *dest)
{
    if (!origin || !axis || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_placement_make: NULL argument");
    double z[3];
    if (!crisp_vec3_normalize(axis, z) || !isfinite(z[0] + z[1] + z[2]))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_placement_make: axis (%g, %g, %g) has no direction", axis[0],
                           axis[1], axis[2]);
    double r[3];
    if (ref) {
        double d = crisp_vec3_dot(ref, z);
        for (int k = 0; k < 3; k++)
            r[k] = ref[k] - d * z[k];
        double n = crisp_vec3_norm(r), nr = crisp_vec3_norm(ref);
        if (!(nr > 0) || !(n > 1e-12 * nr))
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "crisp_placement_make: reference direction (%g, %g, %g) is zero or "
                               "parallel to the axis",
                               ref[0], ref[1], ref[2]);
    } else {
        /* The world axis least aligned with z, made orthogonal. */
        int m = 0;
        for (int k = 1; k < 3; k++)
            if (fabs(z[k]) < fabs(z[m])) m = k;
        double e[3] = {0, 0, 0};
        e[m] = 1;
        double d = z[m];
        for (int k = 0; k < 3; k++)
            r[k] = e[k] - d * z[k];
    }
    double x[3], y[3];
    crisp_vec3_normalize(r, x);
    crisp_vec3_cross(z, x, y);
    for (int k = 0; k < 3; k++) {
        dest->origin[k] = origin[k];
        dest->x[k] = x[k];
        dest->y[k] = y[k];
        dest->z[k] = z[k];
    }
    return CRISP_OK;
}

/* ---- angle <-> parameter ----------------------------------------------------------------------
 */

/* Segments of an arc over [a0, a1]: equal sweeps of at most 90 degrees (a hair of slack so that
 * exactly 90 degrees is one segment). */
static int arc_segments(double a0, double a1)
{
    double sweep = a1 - a0;
    if (!(sweep > 0)) return 1;
    double q = sweep / (0.5 * M_PI);
    if (!(q < 4 * 64)) return 4 * 64; /* huge or infinite sweeps: never convert them to int */
    int n = (int)ceil(q - 1e-9);
    if (n < 1) n = 1;
    if (n > 4 * 64) n = 4 * 64; /* callers reject sweeps this large; keep the int sane */
    return n;
}

double crisp_angle_to_param(double a0, double a1, double angle)
{
    if (!(a1 > a0)) return angle;
    int n = arc_segments(a0, a1);
    double delta = (a1 - a0) / n, phi = 0.5 * delta;
    /* Clamp in double before converting: an angle far outside [a0, a1] (or NaN) must not
     * overflow the int. */
    double kf = floor((angle - a0) / delta);
    int k = kf >= 1 ? (kf <= n - 1 ? (int)kf : n - 1) : 0;
    double start = a0 + k * delta;
    double theta = angle - start - phi; /* from the segment's middle */
    double s = 0.5 * (tan(0.5 * theta) / tan(0.5 * phi) + 1.0);
    return start + s * delta;
}

double crisp_param_to_angle(double a0, double a1, double t)
{
    if (!(a1 > a0)) return t;
    int n = arc_segments(a0, a1);
    double delta = (a1 - a0) / n, phi = 0.5 * delta;
    /* Clamp in double before converting: an angle far outside [a0, a1] (or NaN) must not
     * overflow the int. */
    double kf = floor((t - a0) / delta);
    int k = kf >= 1 ? (kf <= n - 1 ? (int)kf : n - 1) : 0;
    double start = a0 + k * delta;
    double s = (t - start) / delta;
    double theta = 2.0 * atan((2.0 * s - 1.0) * tan(0.5 * phi));
    return start + phi + theta;
}

/* ---- helpers -----------------------------------------------------------------------------------
 */

static int finite_n(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

/* Unit-circle arc over [a0, a1]: 2n + 1 control points (c, s) and weights, 2n + 4 knots. */
static void unit_arc(double a0, double a1, int n, double *cs, double *w, double *knots)
{
    double delta = (a1 - a0) / n, phi = 0.5 * delta, cphi = cos(phi);
    for (int k = 0; k <= n; k++) {
        double a = (k == n) ? a1 : a0 + k * delta;
        cs[4 * k] = cos(a);
        cs[4 * k + 1] = sin(a);
        w[2 * k] = 1.0;
        if (k < n) {
            double m = a0 + k * delta + phi;
            cs[4 * k + 2] = cos(m) / cphi;
            cs[4 * k + 3] = sin(m) / cphi;
            w[2 * k + 1] = cphi;
        }
    }
    knots[0] = knots[1] = knots[2] = a0;
    for (int k = 1; k < n; k++)
        knots[1 + 2 * k] = knots[2 + 2 * k] = a0 + k * delta;
    knots[2 * n + 1] = knots[2 * n + 2] = knots[2 * n + 3] = a1;
}

#define ARC_MAX_SEG 8 /* sweeps up to 2 pi (+ slack) need at most 4 */
#define ARC_MAX_PTS (2 * ARC_MAX_SEG + 1)

static crisp_status check_sweep(const char *fn, double a0, double a1)
{
    if (!isfinite(a0) || !isfinite(a1) || !(a1 > a0) || a1 - a0 > 2 * M_PI * (1 + 1e-9))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: angle range [%g, %g] must have 0 < a1 - a0 <= 2 pi", fn, a0, a1);
    return CRISP_OK;
}

/* ---- curves ------------------------------------------------------------------------------------
 */

crisp_status crisp_make_line(int dim, const double *p0, const double *p1, double t0, double t1,
                             crisp_curve **dest)
{
    if (!p0 || !p1 || !dest || (dim != 2 && dim != 3))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_make_line: dim %d (expected 2 or 3) or "
                           "NULL argument",
                           dim);
    if (!isfinite(t0) || !isfinite(t1) || !(t1 > t0))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_make_line: parameter range [%g, %g] is empty", t0, t1);
    double pts[6], knots[4] = {t0, t0, t1, t1};
    memcpy(pts, p0, dim * sizeof *pts);
    memcpy(pts + dim, p1, dim * sizeof *pts);
    return crisp_curve_create(dim, 1, 2, knots, pts, NULL, dest);
}

crisp_status crisp_make_arc(int dim, const double *center, const double *x, const double *y,
                            double rx, double ry, double a0, double a1, crisp_curve **dest)
{
    if (!center || !x || !y || !dest || (dim != 2 && dim != 3))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_make_arc: dim %d (expected 2 or 3) or NULL argument", dim);
    crisp_status st = check_sweep("crisp_make_arc", a0, a1);
    if (st) return st;
    if (!isfinite(rx) || !isfinite(ry) || !(rx > 0) || !(ry > 0) || !finite_n(center, dim) ||
        !finite_n(x, dim) || !finite_n(y, dim))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_make_arc: radii (%g, %g) must be positive and the placement "
                           "finite",
                           rx, ry);
    int n = arc_segments(a0, a1);
    double cs[2 * ARC_MAX_PTS], w[ARC_MAX_PTS], knots[ARC_MAX_PTS + 3], pts[3 * ARC_MAX_PTS];
    unit_arc(a0, a1, n, cs, w, knots);
    for (int i = 0; i < 2 * n + 1; i++)
        for (int k = 0; k < dim; k++)
            pts[dim * i + k] = center[k] + rx * cs[2 * i] * x[k] + ry * cs[2 * i + 1] * y[k];
    return crisp_curve_create(dim, 2, 2 * n + 1, knots, pts, w, dest);
}

crisp_status crisp_make_conic_arc(int dim, const double *p0, const double *t0, const double *p2,
                                  const double *t2, const double *p, crisp_curve **dest)
{
    if (!p0 || !t0 || !p2 || !t2 || !p || !dest || (dim != 2 && dim != 3))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_make_conic_arc: dim %d (expected 2 or 3) or NULL argument", dim);
    if (!finite_n(p0, dim) || !finite_n(t0, dim) || !finite_n(p2, dim) || !finite_n(t2, dim) ||
        !finite_n(p, dim))
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_make_conic_arc: non-finite input");
    /* P1: where the end tangent lines meet (least squares in 3D: closest points of two lines). */
    double a = 0, b = 0, c = 0, d = 0, e = 0, scale = 0;
    double r[3] = {0, 0, 0};
    for (int k = 0; k < dim; k++) {
        r[k] = p2[k] - p0[k];
        a += t0[k] * t0[k];
        b += t0[k] * t2[k];
        c += t2[k] * t2[k];
        d += t0[k] * r[k];
        e += t2[k] * r[k];
        scale += r[k] * r[k];
    }
    /* minimise |p0 + al t0 - p2 - be t2|^2: [a -b; b -c] [al; be] = [d; e] */
    double det = -a * c + b * b;
    if (!(scale > 0) || !(fabs(det) > 1e-14 * a * c))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "crisp_make_conic_arc: end points coincide or end tangents are "
                           "parallel (a single rational quadratic arc cannot span it)");
    double al = (-c * d + b * e) / det, be = (a * e - b * d) / det;
    double p1[3], q[3];
    for (int k = 0; k < dim; k++)
        p1[k] = 0.5 * (p0[k] + al * t0[k] + p2[k] + be * t2[k]);
    /* The line from P1 through P meets the chord P0 P2 at Q = (1 - s) P0 + s P2. */
    double m[3], a11 = 0, a12 = 0, a22 = 0, b1 = 0, b2 = 0;
    for (int k = 0; k < dim; k++) {
        m[k] = p[k] - p1[k];
        a11 += m[k] * m[k];
        a12 -= m[k] * r[k];
        a22 += r[k] * r[k];
        b1 += m[k] * (p0[k] - p1[k]);
        b2 -= r[k] * (p0[k] - p1[k]);
    }
    /* p1 + lam m = p0 + s r  -> minimise |lam m - s r - (p0 - p1)|^2 */
    double det2 = a11 * a22 - a12 * a12;
    if (!(fabs(det2) > 1e-14 * a11 * a22))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "crisp_make_conic_arc: the shoulder point lies on a line through the "
                           "tangent intersection parallel to the chord");
    double s = (a11 * b2 - a12 * b1) / det2;
    if (!(s > 1e-12 && s < 1 - 1e-12))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "crisp_make_conic_arc: the point is not between the end points "
                           "(chord fraction %g)",
                           s);
    double ratio = sqrt(s / (1 - s)), u = ratio / (1 + ratio);
    double num = 0, den = 0;
    for (int k = 0; k < dim; k++) {
        q[k] = (1 - u) * (1 - u) * (p0[k] - p[k]) + u * u * (p2[k] - p[k]);
        num += q[k] * (p[k] - p1[k]);
        den += (p[k] - p1[k]) * (p[k] - p1[k]);
    }
    double w1 = num / (2 * u * (1 - u) * den);
    if (!isfinite(w1) || !(w1 > 0))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "crisp_make_conic_arc: the point gives middle weight %g (expected > 0: "
                           "the point must lie inside the triangle of the end tangents)",
                           w1);
    double pts[9], w[3] = {1, w1, 1}, knots[6] = {0, 0, 0, 1, 1, 1};
    memcpy(pts, p0, dim * sizeof *pts);
    memcpy(pts + dim, p1, dim * sizeof *pts);
    memcpy(pts + 2 * dim, p2, dim * sizeof *pts);
    return crisp_curve_create(dim, 2, 3, knots, pts, w, dest);
}

/* ---- surfaces ----------------------------------------------------------------------------------
 */

static crisp_status check_placement(const char *fn, const crisp_placement *pl)
{
    if (!pl) return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL placement", fn);
    if (!finite_n(pl->origin, 3) || !finite_n(pl->x, 3) || !finite_n(pl->y, 3) ||
        !finite_n(pl->z, 3))
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: non-finite placement", fn);
    return CRISP_OK;
}

crisp_status crisp_make_plane(const crisp_placement *pl, double u0, double u1, double v0, double v1,
                              crisp_surface **dest)
{
    crisp_status st = check_placement("crisp_make_plane", pl);
    if (st) return st;
    if (!dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_make_plane: NULL dest");
    if (!isfinite(u0) || !isfinite(u1) || !isfinite(v0) || !isfinite(v1) || !(u1 > u0) ||
        !(v1 > v0))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_make_plane: range [%g, %g] x [%g, %g] is empty", u0, u1, v0, v1);
    double ku[4] = {u0, u0, u1, u1}, kv[4] = {v0, v0, v1, v1}, pts[12];
    double uu[2] = {u0, u1}, vv[2] = {v0, v1};
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++)
            for (int k = 0; k < 3; k++)
                pts[3 * (2 * j + i) + k] = pl->origin[k] + uu[i] * pl->x[k] + vv[j] * pl->y[k];
    return crisp_surface_create(1, 1, 2, 2, ku, kv, pts, NULL, dest);
}

/* Revolve a profile given by homogeneous 3D control points about the axis (origin, unit z) over
 * the angles [a0, a1]. The circle swept by a point P is O + cos a (P - O) + sin a z x (P - O)
 * with O its foot on the axis: affine in P, so applying the arc's control structure to each
 * profile control point (weights multiplied) gives the revolved surface exactly (A8.1).
 * angle_in_u: the angle runs in u (then the profile in v), else in v. */
static crisp_status revolve(const char *fn, int pdeg, int pcount, const double *pknots,
                            const double *pcpw, const double origin[3], const double z[3],
                            double a0, double a1, int angle_in_u, crisp_surface **dest)
{
    crisp_status st = check_sweep(fn, a0, a1);
    if (st) return st;
    int n = arc_segments(a0, a1), na = 2 * n + 1;
    double cs[2 * ARC_MAX_PTS], aw[ARC_MAX_PTS], aknots[ARC_MAX_PTS + 3];
    unit_arc(a0, a1, n, cs, aw, aknots);
    size_t total = (size_t)na * (size_t)pcount;
    if (pcount > CRISP_MAX_CONTROL_POINTS / na)
        return crisp_error(CRISP_ERR_LIMIT,
                           "%s: %d profile points x %d arc points exceed the "
                           "control point limit",
                           fn, pcount, na);
    double *pts = crisp_malloc_array(total, 3 * sizeof(double));
    double *w = crisp_malloc_array(total, sizeof(double));
    if (!pts || !w) {
        crisp_free(pts);
        crisp_free(w);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
    }
    for (int j = 0; j < pcount; j++) {
        const double *h = pcpw + 4 * j;
        double pw = h[3], p[3] = {h[0] / pw, h[1] / pw, h[2] / pw}, foot[3], rx[3], ry[3];
        double t = 0;
        for (int k = 0; k < 3; k++)
            t += (p[k] - origin[k]) * z[k];
        for (int k = 0; k < 3; k++) {
            foot[k] = origin[k] + t * z[k];
            rx[k] = p[k] - foot[k];
        }
        crisp_vec3_cross(z, rx, ry);
        for (int i = 0; i < na; i++) {
            size_t idx = angle_in_u ? (size_t)j * na + i : (size_t)i * pcount + j;
            for (int k = 0; k < 3; k++)
                pts[3 * idx + k] = foot[k] + cs[2 * i] * rx[k] + cs[2 * i + 1] * ry[k];
            w[idx] = pw * aw[i];
        }
    }
    if (angle_in_u)
        st = crisp_surface_create(2, pdeg, na, pcount, aknots, pknots, pts, w, dest);
    else
        st = crisp_surface_create(pdeg, 2, pcount, na, pknots, aknots, pts, w, dest);
    crisp_free(pts);
    crisp_free(w);
    if (st) crisp_error_prefix("%s", fn);
    return st;
}

/* A straight profile segment from p to q over [v0, v1], homogeneous. */
static void line_profile(const double p[3], const double q[3], double v0, double v1,
                         double knots[4], double cpw[8])
{
    knots[0] = knots[1] = v0;
    knots[2] = knots[3] = v1;
    for (int k = 0; k < 3; k++) {
        cpw[k] = p[k];
        cpw[4 + k] = q[k];
    }
    cpw[3] = cpw[7] = 1;
}

static crisp_status check_range(const char *fn, double v0, double v1)
{
    if (!isfinite(v0) || !isfinite(v1) || !(v1 > v0))
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: range [%g, %g] is empty", fn, v0, v1);
    return CRISP_OK;
}

crisp_status crisp_make_cylinder(const crisp_placement *pl, double r, double a0, double a1,
                                 double v0, double v1, crisp_surface **dest)
{
    const char *fn = "crisp_make_cylinder";
    crisp_status st = check_placement(fn, pl);
    if (!st) st = check_range(fn, v0, v1);
    if (st) return st;
    if (!dest || !isfinite(r) || !(r > 0))
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: radius %g must be positive", fn, r);
    double p[3], q[3], knots[4], cpw[8];
    for (int k = 0; k < 3; k++) {
        p[k] = pl->origin[k] + r * pl->x[k] + v0 * pl->z[k];
        q[k] = pl->origin[k] + r * pl->x[k] + v1 * pl->z[k];
    }
    line_profile(p, q, v0, v1, knots, cpw);
    return revolve(fn, 1, 2, knots, cpw, pl->origin, pl->z, a0, a1, 1, dest);
}

crisp_status crisp_make_cone(const crisp_placement *pl, double r, double semi_angle, double a0,
                             double a1, double v0, double v1, crisp_surface **dest)
{
    const char *fn = "crisp_make_cone";
    crisp_status st = check_placement(fn, pl);
    if (!st) st = check_range(fn, v0, v1);
    if (st) return st;
    if (!dest || !isfinite(r) || !isfinite(semi_angle) || !(fabs(semi_angle) < 0.5 * M_PI))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: radius %g and semi-angle %g (expected |semi| < pi/2)", fn, r,
                           semi_angle);
    double ta = tan(semi_angle), p[3], q[3], knots[4], cpw[8];
    for (int k = 0; k < 3; k++) {
        p[k] = pl->origin[k] + (r + v0 * ta) * pl->x[k] + v0 * pl->z[k];
        q[k] = pl->origin[k] + (r + v1 * ta) * pl->x[k] + v1 * pl->z[k];
    }
    line_profile(p, q, v0, v1, knots, cpw);
    return revolve(fn, 1, 2, knots, cpw, pl->origin, pl->z, a0, a1, 1, dest);
}

/* The profile arc center + rad (cos v x + sin v z) over [v0, v1], homogeneous. */
static int arc_profile(const double center[3], const double x[3], const double z[3], double rad,
                       double v0, double v1, double *knots, double *cpw)
{
    int n = arc_segments(v0, v1);
    double cs[2 * ARC_MAX_PTS], w[ARC_MAX_PTS];
    unit_arc(v0, v1, n, cs, w, knots);
    for (int i = 0; i < 2 * n + 1; i++) {
        for (int k = 0; k < 3; k++)
            cpw[4 * i + k] =
                w[i] * (center[k] + rad * cs[2 * i] * x[k] + rad * cs[2 * i + 1] * z[k]);
        cpw[4 * i + 3] = w[i];
    }
    return 2 * n + 1;
}

crisp_status crisp_make_sphere(const crisp_placement *pl, double r, double a0, double a1, double v0,
                               double v1, crisp_surface **dest)
{
    const char *fn = "crisp_make_sphere";
    crisp_status st = check_placement(fn, pl);
    if (st) return st;
    if (!dest || !isfinite(r) || !(r > 0))
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: radius %g must be positive", fn, r);
    double lim = 0.5 * M_PI * (1 + 1e-12);
    if (!isfinite(v0) || !isfinite(v1) || !(v1 > v0) || v0 < -lim || v1 > lim)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: latitude range [%g, %g] must be non-empty within [-pi/2, pi/2]", fn,
                           v0, v1);
    double knots[ARC_MAX_PTS + 3], cpw[4 * ARC_MAX_PTS];
    int count = arc_profile(pl->origin, pl->x, pl->z, r, v0, v1, knots, cpw);
    return revolve(fn, 2, count, knots, cpw, pl->origin, pl->z, a0, a1, 1, dest);
}

crisp_status crisp_make_torus(const crisp_placement *pl, double major, double minor, double a0,
                              double a1, double v0, double v1, crisp_surface **dest)
{
    const char *fn = "crisp_make_torus";
    crisp_status st = check_placement(fn, pl);
    if (!st) st = check_sweep(fn, v0, v1);
    if (st) return st;
    if (!dest || !isfinite(major) || !isfinite(minor) || !(minor > 0) || !(major > 0))
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: radii major %g, minor %g must be positive",
                           fn, major, minor);
    double c[3], knots[ARC_MAX_PTS + 3], cpw[4 * ARC_MAX_PTS];
    for (int k = 0; k < 3; k++)
        c[k] = pl->origin[k] + major * pl->x[k];
    int count = arc_profile(c, pl->x, pl->z, minor, v0, v1, knots, cpw);
    return revolve(fn, 2, count, knots, cpw, pl->origin, pl->z, a0, a1, 1, dest);
}

static crisp_status check_curve(const char *fn, const crisp_curve *c)
{
    if (!c || !c->knots || !c->cpw || (c->dim != 2 && c->dim != 3) || c->degree < 1 ||
        c->degree > CRISP_MAX_DEGREE || c->count < c->degree + 1 ||
        c->count > CRISP_MAX_CONTROL_POINTS)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: invalid or NULL curve", fn);
    return CRISP_OK;
}

/* The curve's homogeneous control points as 4 values each (z = 0 for 2D curves). */
static double *cpw4(const crisp_curve *c)
{
    double *h = crisp_malloc_array((size_t)c->count, 4 * sizeof(double));
    if (!h) return NULL;
    int s = c->dim + 1;
    for (int i = 0; i < c->count; i++) {
        const double *src = c->cpw + (size_t)s * i;
        h[4 * i] = src[0];
        h[4 * i + 1] = src[1];
        h[4 * i + 2] = c->dim == 3 ? src[2] : 0.0;
        h[4 * i + 3] = src[c->dim];
    }
    return h;
}

crisp_status crisp_make_revolution(const crisp_curve *profile, const double point[3],
                                   const double axis[3], double a0, double a1, crisp_surface **dest)
{
    const char *fn = "crisp_make_revolution";
    crisp_status st = check_curve(fn, profile);
    if (st) return st;
    double z[3];
    if (!point || !axis || !dest || !finite_n(point, 3) || !crisp_vec3_normalize(axis, z) ||
        !finite_n(z, 3))
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL argument or zero axis", fn);
    double *h = cpw4(profile);
    if (!h) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
    st = revolve(fn, profile->degree, profile->count, profile->knots, h, point, z, a0, a1, 0, dest);
    crisp_free(h);
    return st;
}

crisp_status crisp_make_extrusion(const crisp_curve *c, const double dir[3], double v0, double v1,
                                  crisp_surface **dest)
{
    const char *fn = "crisp_make_extrusion";
    crisp_status st = check_curve(fn, c);
    if (!st) st = check_range(fn, v0, v1);
    if (st) return st;
    if (!dir || !dest || !finite_n(dir, 3))
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL or non-finite direction", fn);
    int n = c->count;
    double *pts = crisp_malloc_array((size_t)n * 2, 3 * sizeof(double));
    double *w = crisp_malloc_array((size_t)n * 2, sizeof(double));
    double *h = cpw4(c);
    if (!pts || !w || !h) {
        crisp_free(pts);
        crisp_free(w);
        crisp_free(h);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
    }
    double vv[2] = {v0, v1};
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < n; i++) {
            double hw = h[4 * i + 3];
            for (int k = 0; k < 3; k++)
                pts[3 * (j * n + i) + k] = h[4 * i + k] / hw + vv[j] * dir[k];
            w[j * n + i] = hw;
        }
    double kv[4] = {v0, v0, v1, v1};
    st = crisp_surface_create(c->degree, 1, n, 2, c->knots, kv, pts, c->rational ? w : NULL, dest);
    crisp_free(pts);
    crisp_free(w);
    crisp_free(h);
    if (st) crisp_error_prefix("%s", fn);
    return st;
}

/* ---- ruled surfaces ----------------------------------------------------------------------------
 */

/* Bernstein coefficients of the product of f (degree a) and g (degree b), 4-vectors times
 * scalars: dest[k] = sum_{i+j=k} C(a,i) C(b,j) / C(a+b,k) f_i g_j. */
static double binom(int n, int k)
{
    double r = 1;
    for (int i = 1; i <= k; i++)
        r = r * (n - k + i) / i;
    return r;
}

/* Raise a Bézier polynomial of 4-vectors from degree p to degree q >= p (repeated elevation by
 * one: b'_i = i/(p+1) b_{i-1} + (1 - i/(p+1)) b_i). */
static void bezier_elevate(double *b, int p, int q)
{
    double tmp[4 * (CRISP_MAX_DEGREE + 1)];
    for (; p < q; p++) {
        for (int i = 0; i <= p + 1; i++) {
            double a = (double)i / (p + 1);
            for (int k = 0; k < 4; k++) {
                double lo = i > 0 ? b[4 * (i - 1) + k] : 0, hi = i <= p ? b[4 * i + k] : 0;
                tmp[4 * i + k] = a * lo + (1 - a) * hi;
            }
        }
        memcpy(b, tmp, 4 * (p + 2) * sizeof *b);
    }
}

/* X * w: homogeneous piece x (degree a, 4-vectors) times the scalar polynomial w (degree b). */
static void bezier_times_weight(const double *x, int a, const double *w, int b, double *dest)
{
    for (int k = 0; k <= a + b; k++) {
        double acc[4] = {0, 0, 0, 0};
        for (int i = (k - b > 0 ? k - b : 0); i <= a && i <= k; i++) {
            int j = k - i;
            double f = binom(a, i) * binom(b, j) / binom(a + b, k) * w[j];
            for (int m = 0; m < 4; m++)
                acc[m] += f * x[4 * i + m];
        }
        memcpy(dest + 4 * k, acc, sizeof acc);
    }
}

/* Bézier pieces of c reparametrised to [0, 1], split further at every break in `breaks`
 * (sorted, in (0, 1)); each piece becomes degree + 1 homogeneous 4-vectors. */
static crisp_status pieces_at(const crisp_curve *c, const double *breaks, int nb, double *out)
{
    crisp_bezier_curve *bz = NULL;
    int count = 0;
    crisp_status st = crisp_curve_to_bezier(c, &bz, &count);
    if (st) return st;
    double t0, t1;
    crisp_curve_domain(c, &t0, &t1);
    int p = c->degree, piece = 0;
    double lo = 0; /* where the current output piece starts, in [0, 1] */
    for (int b = 0; b <= nb; b++) {
        double hi = b < nb ? breaks[b] : 1.0;
        /* Find the source piece holding (lo + hi) / 2 and cut [lo, hi] out of it. */
        double mid = t0 + 0.5 * (lo + hi) * (t1 - t0);
        int k = 0;
        while (k < count - 1 && bz[k].t1 <= mid)
            k++;
        crisp_bezier_curve cur = bz[k], left, right;
        double s0 = bz[k].t0, s1 = bz[k].t1;
        double a = (t0 + lo * (t1 - t0) - s0) / (s1 - s0);
        double e = (t0 + hi * (t1 - t0) - s0) / (s1 - s0);
        if (a > 1e-15) {
            crisp_bezier_curve_split(&cur, a, &left, &right);
            cur = right;
            e = (e - a) / (1 - a);
        }
        if (e < 1 - 1e-15) {
            crisp_bezier_curve_split(&cur, e, &left, &right);
            cur = left;
        }
        double *dst = out + (size_t)4 * (p + 1) * piece;
        int s = c->dim + 1;
        for (int i = 0; i <= p; i++) {
            const double *src = cur.cpw + s * i;
            dst[4 * i] = src[0];
            dst[4 * i + 1] = src[1];
            dst[4 * i + 2] = c->dim == 3 ? src[2] : 0.0;
            dst[4 * i + 3] = src[c->dim];
        }
        piece++;
        lo = hi;
    }
    crisp_free(bz);
    return CRISP_OK;
}

/* Distinct interior knots of c mapped to [0, 1], appended to list (size n, grows). */
static int curve_breaks(const crisp_curve *c, double *list, int n)
{
    double t0, t1;
    crisp_curve_domain(c, &t0, &t1);
    for (int i = c->degree + 1; i < c->count; i++) {
        double x = (c->knots[i] - t0) / (t1 - t0);
        if (x > 1e-12 && x < 1 - 1e-12) list[n++] = x;
    }
    return n;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

crisp_status crisp_make_ruled(const crisp_curve *c0, const crisp_curve *c1, crisp_surface **dest)
{
    const char *fn = "crisp_make_ruled";
    crisp_status st = check_curve(fn, c0);
    if (!st) st = check_curve(fn, c1);
    if (st) return st;
    if (!dest) return crisp_error(CRISP_ERR_INVALID_ARG, "%s: NULL dest", fn);
    int p0 = c0->degree, p1 = c1->degree;
    int d0 = p0 + (c1->rational ? p1 : 0), d1 = p1 + (c0->rational ? p0 : 0);
    int deg = d0 > d1 ? d0 : d1;
    if (deg > CRISP_MAX_DEGREE)
        return crisp_error(CRISP_ERR_LIMIT,
                           "%s: rational curves of degrees %d and %d give degree %d > %d", fn, p0,
                           p1, deg, CRISP_MAX_DEGREE);
    /* Common breakpoints: the union of both curves' interior knots on [0, 1]. */
    int nmax = c0->count + c1->count;
    double *breaks = crisp_malloc_array((size_t)nmax, sizeof(double));
    if (!breaks) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
    int nb = curve_breaks(c0, breaks, 0);
    nb = curve_breaks(c1, breaks, nb);
    qsort(breaks, nb, sizeof *breaks, cmp_double);
    int m = 0;
    for (int i = 0; i < nb; i++)
        if (m == 0 || breaks[i] - breaks[m - 1] > 1e-12) breaks[m++] = breaks[i];
    nb = m;
    int pieces = nb + 1;
    size_t cu = (size_t)pieces * deg + 1;
    double *b0 = crisp_malloc_array((size_t)pieces * (p0 + 1), 4 * sizeof(double));
    double *b1 = crisp_malloc_array((size_t)pieces * (p1 + 1), 4 * sizeof(double));
    double *pts = crisp_malloc_array(cu * 2, 3 * sizeof(double));
    double *w = crisp_malloc_array(cu * 2, sizeof(double));
    double *ku = crisp_malloc_array(cu + deg + 1, sizeof(double));
    if (!b0 || !b1 || !pts || !w || !ku || cu * 2 > CRISP_MAX_CONTROL_POINTS) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", fn);
        goto done;
    }
    st = pieces_at(c0, breaks, nb, b0);
    if (!st) st = pieces_at(c1, breaks, nb, b1);
    if (st) {
        crisp_error_prefix("%s", fn);
        goto done;
    }
    for (int k = 0; k < pieces; k++) {
        double r0[4 * (CRISP_MAX_DEGREE + 1)], r1[4 * (CRISP_MAX_DEGREE + 1)];
        double w0[CRISP_MAX_DEGREE + 1], w1[CRISP_MAX_DEGREE + 1];
        const double *x0 = b0 + (size_t)4 * (p0 + 1) * k, *x1 = b1 + (size_t)4 * (p1 + 1) * k;
        for (int i = 0; i <= p0; i++)
            w0[i] = x0[4 * i + 3];
        for (int i = 0; i <= p1; i++)
            w1[i] = x1[4 * i + 3];
        /* (1 - v) X0/w0 + v X1/w1 = ((1 - v) X0 w1 + v X1 w0) / (w0 w1): both rows share the
         * weight w0 w1, so the rulings are parametrised as the header promises. */
        double one = 1.0;
        bezier_times_weight(x0, p0, c1->rational ? w1 : &one, c1->rational ? p1 : 0, r0);
        bezier_times_weight(x1, p1, c0->rational ? w0 : &one, c0->rational ? p0 : 0, r1);
        bezier_elevate(r0, d0, deg);
        bezier_elevate(r1, d1, deg);
        for (int i = (k == 0 ? 0 : 1); i <= deg; i++) {
            size_t idx = (size_t)k * deg + i;
            double *rows[2] = {r0, r1};
            for (int j = 0; j < 2; j++) {
                double hw = rows[j][4 * i + 3];
                for (int q = 0; q < 3; q++)
                    pts[3 * (j * cu + idx) + q] = rows[j][4 * i + q] / hw;
                w[j * cu + idx] = hw;
            }
        }
    }
    for (int i = 0; i <= deg; i++) {
        ku[i] = 0;
        ku[cu + i] = 1;
    }
    for (int b = 0; b < nb; b++)
        for (int i = 0; i < deg; i++)
            ku[deg + 1 + b * deg + i] = breaks[b];
    {
        double kv[4] = {0, 0, 1, 1};
        int rat = c0->rational || c1->rational;
        st = crisp_surface_create(deg, 1, (int)cu, 2, ku, kv, pts, rat ? w : NULL, dest);
        if (st) crisp_error_prefix("%s", fn);
    }
done:
    crisp_free(breaks);
    crisp_free(b0);
    crisp_free(b1);
    crisp_free(pts);
    crisp_free(w);
    crisp_free(ku);
    return st;
}
