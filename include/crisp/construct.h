/* crisp construct: exact NURBS for analytic curves and surfaces (lines, circular and elliptic
 * arcs, conics, planes, cylinders, cones, spheres, tori, surfaces of revolution, extrusions, ruled
 * surfaces), the maps between an analytic parametrisation (angle, length) and the NURBS one, and
 * fitting a 2D B-spline curve to a function within a tolerance (used for pcurves given in an
 * analytic parametrisation and for trims projected from 3D edges).
 * Follows Piegl & Tiller, "The NURBS Book", chapters 7 and 8.
 *
 * Angles are in radians. A placement is an origin and two orthonormal axes x, y (z = x cross y).
 * Every surface built here is parametrised as documented beside it, so a reader can map the
 * file's (u, v) onto the NURBS (u, v) with crisp_angle_to_param.
 */
#ifndef CRISP_CONSTRUCT_H
#define CRISP_CONSTRUCT_H

#include "crisp/nurbs.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct crisp_placement {
    double origin[3];
    double x[3]; /* unit */
    double y[3]; /* unit, orthogonal to x */
    double z[3]; /* x cross y */
} crisp_placement;

/* From origin, axis (z) and reference direction (projected to be orthogonal to z); a NULL ref
 * picks one. Fails on a zero axis or a ref parallel to the axis. */
crisp_status crisp_placement_make(const double origin[3], const double axis[3], const double *ref,
                                  crisp_placement *dest);

/* ---- angle <-> NURBS parameter --------------------------------------------------------------
 * Circular arcs over [a0, a1] are built from rational quadratic segments of equal sweep
 * (at most 90 degrees each) with knots at the segment ends, and the NURBS parameter is chosen to
 * equal the angle at every knot: the curve's domain is [a0, a1]. Inside a segment the parameter
 * is not the angle; these two functions convert exactly (closed form). */
double crisp_angle_to_param(double a0, double a1, double angle);
double crisp_param_to_angle(double a0, double a1, double t);

/* ---- curves (dim 2 or 3; points have dim values) ----------------------------------------------
 */

crisp_status crisp_make_line(int dim, const double *p0, const double *p1, double t0, double t1,
                             crisp_curve **dest);
/* Ellipse arc center + rx*cos(a)*x + ry*sin(a)*y, a in [a0, a1] (a1 > a0, a1 - a0 <= 2 pi);
 * domain [a0, a1] with crisp_angle_to_param for the parameter of angle a. For dim 2 only the
 * first two coordinates of center, x, y are used. */
crisp_status crisp_make_arc(int dim, const double *center, const double *x, const double *y,
                            double rx, double ry, double a0, double a1, crisp_curve **dest);
/* A conic arc (one rational quadratic segment) from p0 to p2 with end tangents t0, t2 through
 * point p (NURBS Book A7.3); domain [0, 1]. Parabolas and hyperbolas of IGES 104 come here. */
crisp_status crisp_make_conic_arc(int dim, const double *p0, const double *t0, const double *p2,
                                  const double *t2, const double *p, crisp_curve **dest);

/* ---- surfaces ---------------------------------------------------------------------------------
 */

/* S(u, v) = origin + u * x + v * y over [u0, u1] x [v0, v1] (bilinear). */
crisp_status crisp_make_plane(const crisp_placement *pl, double u0, double u1, double v0, double v1,
                              crisp_surface **dest);
/* Cylinder: S(u, v) = origin + r (cos u x + sin u y) + v z; u in [a0, a1] (angle), v in [v0, v1].
 */
crisp_status crisp_make_cylinder(const crisp_placement *pl, double r, double a0, double a1,
                                 double v0, double v1, crisp_surface **dest);
/* Cone (STEP convention): S(u, v) = origin + (r + v tan(semi)) (cos u x + sin u y) + v z. */
crisp_status crisp_make_cone(const crisp_placement *pl, double r, double semi_angle, double a0,
                             double a1, double v0, double v1, crisp_surface **dest);
/* Sphere: S(u, v) = origin + r cos v (cos u x + sin u y) + r sin v z; u, v angles
 * (v in [-pi/2, pi/2]). */
crisp_status crisp_make_sphere(const crisp_placement *pl, double r, double a0, double a1, double v0,
                               double v1, crisp_surface **dest);
/* Torus: S(u, v) = origin + (R + r cos v)(cos u x + sin u y) + r sin v z; u, v angles. */
crisp_status crisp_make_torus(const crisp_placement *pl, double major, double minor, double a0,
                              double a1, double v0, double v1, crisp_surface **dest);
/* Revolve a 3D profile curve about the axis through `point` along unit `axis` from angle a0 to
 * a1: u is the profile parameter (its own domain), v the angle (crisp_angle_to_param applies). */
crisp_status crisp_make_revolution(const crisp_curve *profile, const double point[3],
                                   const double axis[3], double a0, double a1,
                                   crisp_surface **dest);
/* S(u, v) = C(u) + v * dir, u the curve's domain, v in [v0, v1]. */
crisp_status crisp_make_extrusion(const crisp_curve *c, const double dir[3], double v0, double v1,
                                  crisp_surface **dest);
/* Ruled surface between two 3D curves: S(u, v) = (1 - v) C0(u) + v C1(u), v in [0, 1], u over
 * [0, 1] (both curves reparametrised linearly and made compatible by degree elevation and knot
 * merging). */
crisp_status crisp_make_ruled(const crisp_curve *c0, const crisp_curve *c1, crisp_surface **dest);

/* ---- fitting ----------------------------------------------------------------------------------
 */

/* f(ctx, t, dest) writes dim values of the function to approximate at t. */
typedef void (*crisp_curve_fn)(void *ctx, double t, double *dest);
/* A non-rational cubic B-spline (dim 2 or 3) over [t0, t1] within tol of f everywhere (checked
 * on a dense sample between knots, refined until it holds or max_spans is reached, which is an
 * error). The end points are interpolated exactly. */
crisp_status crisp_fit_curve(int dim, crisp_curve_fn f, void *ctx, double t0, double t1, double tol,
                             int max_spans, crisp_curve **dest);

#ifdef __cplusplus
}
#endif
#endif
