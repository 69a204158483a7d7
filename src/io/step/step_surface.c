/* STEP surfaces (ISO 10303-42 4.4: plane, cylindrical, conical, spherical, toroidal surfaces,
 * surfaces of revolution and of linear extrusion, B-spline surfaces with knots, rational too) in
 * their own (u, v) parametrisation: evaluation, analytic point inversion, and the exact NURBS
 * surface (construct.h) over a parameter box, with the map from the file's (u, v) to the NURBS
 * (u, v). Elementary surfaces are unbounded in the file: the face's loops give the box.
 */
#include "step_internal.h"

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

void crisp__step_surface_free(step_surface *s)
{
    if (!s) return;
    crisp_surface_destroy(s->nurbs);
    crisp__step_curve_free(&s->profile);
    s->nurbs = NULL;
}

crisp_status crisp__step_knots(step_reader *r, const step_entity *e, const step_value *mults,
                               const step_value *knots, int degree, int count, double **dest);

static crisp_status bspline_surface(step_reader *r, const step_entity *e, step_surface *s)
{
    const step_part *base = crisp__step_part(r, e, "B_SPLINE_SURFACE");
    const step_part *kp = crisp__step_part(r, e, "B_SPLINE_SURFACE_WITH_KNOTS");
    int off = 0;
    if (!base) {
        base = kp ? kp : crisp__step_part(r, e, NULL);
        off = 1;
    }
    crisp_status st;
    int du, dv;
    const step_value *rows;
    if ((st = crisp__step_get_int(r, e, base, off, 1, CRISP_MAX_DEGREE, &du)) ||
        (st = crisp__step_get_int(r, e, base, off + 1, 1, CRISP_MAX_DEGREE, &dv)) ||
        (st = crisp__step_get_list(r, e, base, off + 2, &rows)))
        return st;
    int nu = (int)rows->len;
    const step_value *row0 = crisp__step_elem(r, rows, 0);
    if (!row0 || row0->kind != STEP_LIST)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                "parameter %d: expected a list of lists of points", off + 3);
    int nv = (int)row0->len;
    if (nu < du + 1 || nv < dv + 1 || (long long)nu * nv > CRISP_MAX_CONTROL_POINTS)
        return crisp__step_fail(r, e, CRISP_ERR_LIMIT,
                                "expected %d..%d control points (u) and %d.. (v), "
                                "at most %d in all; found %d x %d",
                                du + 1, CRISP_MAX_CONTROL_POINTS, dv + 1, CRISP_MAX_CONTROL_POINTS,
                                nu, nv);
    size_t n = (size_t)nu * (size_t)nv;
    double *xyz = crisp_malloc_array(n * 3, sizeof *xyz), *w = NULL, *ku = NULL, *kv = NULL;
    if (!xyz) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
    /* The file lists rows of constant u index: point (i, j) is rows[i][j]; crisp wants u fastest.
     */
    for (int i = 0; i < nu && !st; i++) {
        const step_value *row = crisp__step_elem(r, rows, (uint32_t)i);
        if (row->kind != STEP_LIST || (int)row->len != nv) {
            st = crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                  "control point row %d: expected a list of %d points", i + 1, nv);
            break;
        }
        for (int j = 0; j < nv && !st; j++) {
            const step_entity *pe;
            st = crisp__step_deref(r, e, crisp__step_elem(r, row, (uint32_t)j), &pe);
            if (!st) st = crisp__step_point(r, pe, xyz + 3 * ((size_t)j * nu + i), NULL);
        }
    }
    int ko = kp == base ? off + 7 : 0;
    const step_value *mu, *mv, *tu, *tv;
    if (!st && !kp) {
        /* UNIFORM_SURFACE, QUASI_UNIFORM_SURFACE, BEZIER_SURFACE: knots implied per direction. */
        if (!(st = crisp__step_implied_knots(r, e, du, nu, &ku)))
            st = crisp__step_implied_knots(r, e, dv, nv, &kv);
    } else if (!st && !(st = crisp__step_get_list(r, e, kp, ko, &mu)) &&
               !(st = crisp__step_get_list(r, e, kp, ko + 1, &mv)) &&
               !(st = crisp__step_get_list(r, e, kp, ko + 2, &tu)) &&
               !(st = crisp__step_get_list(r, e, kp, ko + 3, &tv)) &&
               !(st = crisp__step_knots(r, e, mu, tu, du, nu, &ku)))
        st = crisp__step_knots(r, e, mv, tv, dv, nv, &kv);
    const step_part *rp = crisp__step_part(r, e, "RATIONAL_B_SPLINE_SURFACE");
    if (!st && rp) {
        const step_value *wl;
        if (!(st = crisp__step_get_list(r, e, rp, 0, &wl))) {
            if ((int)wl->len != nu)
                st = crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                      "expected %d rows of weights, found %u", nu, wl->len);
            else if (!(w = crisp_malloc_array(n, sizeof *w)))
                st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
            for (int i = 0; !st && i < nu; i++) {
                const step_value *row = crisp__step_elem(r, wl, (uint32_t)i);
                if (row->kind != STEP_LIST || (int)row->len != nv) {
                    st = crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                          "weight row %d: expected %d weights", i + 1, nv);
                    break;
                }
                for (int j = 0; j < nv && !st; j++) {
                    double *wj = &w[(size_t)j * nu + i];
                    if (!crisp__step_value_real(r, crisp__step_elem(r, row, (uint32_t)j), wj) ||
                        !(*wj > 0))
                        st = crisp__step_fail(r, e, CRISP_ERR_NUMERIC,
                                              "weight (%d, %d): expected a positive real", i + 1,
                                              j + 1);
                }
            }
        }
    }
    if (!st) {
        st = crisp_surface_create(du, dv, nu, nv, ku, kv, xyz, w, &s->nurbs);
        if (st) crisp__step_fail(r, e, st, "invalid B-spline surface: %s", crisp_error_message());
    }
    crisp_free(xyz);
    crisp_free(w);
    crisp_free(ku);
    crisp_free(kv);
    if (st) return st;
    s->kind = STEP_SURF_BSPLINE;
    return CRISP_OK;
}

crisp_status crisp__step_surface(step_reader *r, const step_entity *e, step_surface *s)
{
    memset(s, 0, sizeof *s);
    s->id = e->id;
    if (++r->depth > STEP_MAX_DEPTH) {
        r->depth--;
        return crisp__step_fail(r, e, CRISP_ERR_LIMIT,
                                "surface references nested too deeply (a reference cycle?)");
    }
    crisp_status st = CRISP_OK;
    const step_part *p = crisp__step_part(r, e, NULL);
    const step_entity *ae, *ce;
    static const struct {
        const char *name;
        step_surface_kind kind;
        int reals;
    } elementary[] = {{"PLANE", STEP_SURF_PLANE, 0},
                      {"CYLINDRICAL_SURFACE", STEP_SURF_CYLINDER, 1},
                      {"CONICAL_SURFACE", STEP_SURF_CONE, 2},
                      {"SPHERICAL_SURFACE", STEP_SURF_SPHERE, 1},
                      {"TOROIDAL_SURFACE", STEP_SURF_TORUS, 2},
                      {"DEGENERATE_TOROIDAL_SURFACE", STEP_SURF_TORUS, 2}};
    int done = 0;
    for (size_t k = 0; k < sizeof elementary / sizeof *elementary && !done; k++) {
        if (!(p = crisp__step_part(r, e, elementary[k].name))) continue;
        done = 1;
        s->kind = elementary[k].kind;
        double v[2] = {0, 0};
        if ((st = crisp__step_get_ref(r, e, p, 1, &ae)) ||
            (st = crisp__step_placement(r, ae, &s->pl)))
            break;
        for (int i = 0; i < elementary[k].reals && !st; i++)
            st = crisp__step_get_real(r, e, p, 2 + i, &v[i]);
        if (st) break;
        s->r = v[0];
        if (s->kind == STEP_SURF_TORUS) s->r2 = v[1];
        if (s->kind == STEP_SURF_CONE) s->semi = v[1] * r->angle_unit;
        if (s->kind != STEP_SURF_PLANE && !(s->r > 0) && !(s->kind == STEP_SURF_CONE && s->r == 0))
            st = crisp__step_fail(r, e, CRISP_ERR_NUMERIC, "expected a positive radius, found %g",
                                  s->r);
        else if (s->kind == STEP_SURF_TORUS && !(s->r2 > 0))
            st = crisp__step_fail(r, e, CRISP_ERR_NUMERIC,
                                  "expected a positive minor radius, found %g", s->r2);
        else if (s->kind == STEP_SURF_CONE && !(fabs(s->semi) < M_PI / 2 - 1e-9 && s->semi != 0))
            st = crisp__step_fail(r, e, CRISP_ERR_NUMERIC,
                                  "expected a semi-angle in (0, pi/2), found %g", s->semi);
        s->u_periodic = s->kind != STEP_SURF_PLANE;
        s->v_periodic = s->kind == STEP_SURF_TORUS;
    }
    if (done) {
    } else if ((p = crisp__step_part(r, e, "SURFACE_OF_REVOLUTION"))) {
        crisp_placement ax;
        s->kind = STEP_SURF_REVOLUTION;
        if (!(st = crisp__step_get_ref(r, e, p, 1, &ce)) &&
            !(st = crisp__step_get_ref(r, e, p, 2, &ae)) &&
            !(st = crisp__step_placement(r, ae, &ax)) &&
            !(st = crisp__step_curve(r, ce, &s->profile))) {
            memcpy(s->axis_p, ax.origin, sizeof s->axis_p);
            memcpy(s->axis_d, ax.z, sizeof s->axis_d);
            s->u_periodic = 1;
            if (s->profile.dim != 3)
                st = crisp__step_fail(r, e, CRISP_ERR_PARSE, "expected a 3D swept curve");
        }
    } else if ((p = crisp__step_part(r, e, "SURFACE_OF_LINEAR_EXTRUSION"))) {
        s->kind = STEP_SURF_EXTRUSION;
        if (!(st = crisp__step_get_ref(r, e, p, 1, &ce)) &&
            !(st = crisp__step_get_ref(r, e, p, 2, &ae)) &&
            !(st = crisp__step_vector(r, ae, s->axis_d)) &&
            !(st = crisp__step_curve(r, ce, &s->profile))) {
            if (s->profile.dim != 3)
                st = crisp__step_fail(r, e, CRISP_ERR_PARSE, "expected a 3D swept curve");
            s->u_periodic = s->profile.kind == STEP_CURVE_CONIC;
        }
    } else if ((p = crisp__step_part(r, e, "RECTANGULAR_TRIMMED_SURFACE"))) {
        /* The face's loops bound it; the basis surface carries the geometry. Pcurves refer to
         * this entity, so it keeps its id. */
        const step_entity *be;
        if (!(st = crisp__step_get_ref(r, e, p, 1, &be))) {
            st = crisp__step_surface(r, be, s);
            s->id = e->id;
        }
    } else if (crisp__step_is(r, e, "B_SPLINE_SURFACE_WITH_KNOTS") ||
               crisp__step_is(r, e, "B_SPLINE_SURFACE") ||
               crisp__step_is(r, e, "QUASI_UNIFORM_SURFACE") ||
               crisp__step_is(r, e, "UNIFORM_SURFACE") || crisp__step_is(r, e, "BEZIER_SURFACE")) {
        st = bspline_surface(r, e, s);
    } else {
        char type[64];
        st = crisp__step_fail(r, e, CRISP_ERR_UNSUPPORTED, "unsupported surface type %s",
                              crisp__step_type(r, e, type, sizeof type));
    }
    if (!st && (s->kind == STEP_SURF_REVOLUTION || s->kind == STEP_SURF_EXTRUSION) &&
        (s->profile.kind == STEP_CURVE_HYPERBOLA || s->profile.kind == STEP_CURVE_PARABOLA) &&
        !(isfinite(s->profile.t0) && isfinite(s->profile.t1)))
        st = crisp__step_fail(r, e, CRISP_ERR_UNSUPPORTED,
                              "swept curve: an unbounded hyperbola or parabola");
    r->depth--;
    if (st) crisp__step_surface_free(s);
    return st;
}

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Rotate q about the unit axis a by angle t (Rodrigues). */
static void rotate(const double q[3], const double a[3], double t, double dest[3])
{
    double c = cos(t), s = sin(t), d = dot3(q, a);
    double x[3] = {a[1] * q[2] - a[2] * q[1], a[2] * q[0] - a[0] * q[2], a[0] * q[1] - a[1] * q[0]};
    for (int k = 0; k < 3; k++)
        dest[k] = q[k] * c + x[k] * s + a[k] * d * (1 - c);
}

void crisp__step_surface_eval(const step_surface *s, double u, double v, double p[3])
{
    const crisp_placement *pl = &s->pl;
    double rad = 0, h = 0;
    switch (s->kind) {
    case STEP_SURF_PLANE:
        for (int k = 0; k < 3; k++)
            p[k] = pl->origin[k] + u * pl->x[k] + v * pl->y[k];
        return;
    case STEP_SURF_CYLINDER:
        rad = s->r, h = v;
        break;
    case STEP_SURF_CONE:
        rad = s->r + v * tan(s->semi), h = v;
        break;
    case STEP_SURF_SPHERE:
        rad = s->r * cos(v), h = s->r * sin(v);
        break;
    case STEP_SURF_TORUS:
        rad = s->r + s->r2 * cos(v), h = s->r2 * sin(v);
        break;
    case STEP_SURF_REVOLUTION: {
        double c[3], q[3];
        crisp__step_curve_eval(&s->profile, v, c);
        for (int k = 0; k < 3; k++)
            q[k] = c[k] - s->axis_p[k];
        rotate(q, s->axis_d, u, p);
        for (int k = 0; k < 3; k++)
            p[k] += s->axis_p[k];
        return;
    }
    case STEP_SURF_EXTRUSION:
        crisp__step_curve_eval(&s->profile, u, p);
        for (int k = 0; k < 3; k++)
            p[k] += v * s->axis_d[k];
        return;
    case STEP_SURF_BSPLINE:
        crisp_surface_eval(s->nurbs, u, v, p);
        return;
    }
    for (int k = 0; k < 3; k++)
        p[k] = pl->origin[k] + rad * (cos(u) * pl->x[k] + sin(u) * pl->y[k]) + h * pl->z[k];
}

/* The representative of angle a nearest to ref. */
static double near_angle(double a, double ref)
{
    return a + 2 * M_PI * floor((ref - a) / (2 * M_PI) + 0.5);
}

/* Nearest parameter of a profile curve, measuring distance in the (radius, height) half plane of
 * an axis (revolution) or in the plane orthogonal to a direction (extrusion). */
typedef struct profile_metric {
    const step_surface *s;
    const double *p;
} profile_metric;

static void rh(const step_surface *s, const double x[3], double out[2])
{
    double q[3];
    for (int k = 0; k < 3; k++)
        q[k] = x[k] - s->axis_p[k];
    double h = dot3(q, s->axis_d);
    double r2 = dot3(q, q) - h * h;
    out[0] = sqrt(r2 > 0 ? r2 : 0);
    out[1] = h;
}

static double profile_dist(const step_surface *s, const double *p, double t)
{
    double c[3];
    crisp__step_curve_eval(&s->profile, t, c);
    if (s->kind == STEP_SURF_REVOLUTION) {
        double a[2], b[2];
        rh(s, c, a);
        rh(s, p, b);
        return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]);
    }
    double d[3], dd = dot3(s->axis_d, s->axis_d);
    for (int k = 0; k < 3; k++)
        d[k] = p[k] - c[k];
    double h = dot3(d, s->axis_d);
    return dot3(d, d) - h * h / dd;
}

static double profile_search(const step_surface *s, const double *p, double lo, double hi,
                             double ref);

/* Nearest profile parameter: a local search around the reference first (points along an edge
 * move little between calls), the whole range when the local minimum is on the window's edge. */
/* Newton's method on the extrusion distance for a B-spline profile, from ref; NAN when it does
 * not converge inside [lo, hi]. */
static double extrusion_newton(const step_surface *s, const double *p, double lo, double hi,
                               double ref)
{
    const crisp_curve *c = s->profile.nurbs;
    double dd = dot3(s->axis_d, s->axis_d), t = ref;
    for (int it = 0; it < 16; it++) {
        double d[9], q[3][3];
        crisp_curve_derivs(c, t, 2, d);
        double x[3] = {d[0] - p[0], d[1] - p[1], d[2] - p[2]};
        const double *vec[3] = {x, d + 3, d + 6};
        for (int k = 0; k < 3; k++) { /* remove the extrusion component */
            double h = dot3(vec[k], s->axis_d) / dd;
            for (int j = 0; j < 3; j++)
                q[k][j] = vec[k][j] - h * s->axis_d[j];
        }
        double f = dot3(q[0], q[1]), df = dot3(q[1], q[1]) + dot3(q[0], q[2]);
        if (!(df > 0)) return NAN;
        double step = f / df;
        t -= step;
        if (t < lo || t > hi) return NAN;
        if (fabs(step) <= 1e-14 * (hi - lo)) return t;
    }
    return NAN;
}

static double profile_invert(const step_surface *s, const double *p, double lo, double hi,
                             double ref)
{
    if (isfinite(ref) && ref >= lo && ref <= hi && s->kind == STEP_SURF_EXTRUSION &&
        s->profile.kind == STEP_CURVE_BSPLINE) {
        double t = extrusion_newton(s, p, lo, hi, ref);
        if (isfinite(t) && fabs(t - ref) <= 0.02 * (hi - lo)) return t;
    }
    if (isfinite(ref) && ref >= lo && ref <= hi) {
        double d = 0.02 * (hi - lo), a = ref - d, b = ref + d;
        if (a < lo) a = lo;
        if (b > hi) b = hi;
        const double g = 0.6180339887498949;
        double x1 = b - g * (b - a), x2 = a + g * (b - a);
        double f1 = profile_dist(s, p, x1), f2 = profile_dist(s, p, x2);
        double a0 = a, b0 = b;
        for (int it = 0; it < 90 && b - a > 1e-15 * (1 + fabs(a)); it++) {
            if (f1 < f2)
                b = x2, x2 = x1, f2 = f1, x1 = b - g * (b - a), f1 = profile_dist(s, p, x1);
            else
                a = x1, x1 = x2, f1 = f2, x2 = a + g * (b - a), f2 = profile_dist(s, p, x2);
        }
        double t = 0.5 * (a + b), eps = 1e-9 * (b0 - a0);
        if ((t > a0 + eps || a0 == lo) && (t < b0 - eps || b0 == hi)) return t;
    }
    return profile_search(s, p, lo, hi, ref);
}

static double profile_search(const step_surface *s, const double *p, double lo, double hi,
                             double ref)
{
    int n = 64;
    if (s->profile.kind == STEP_CURVE_BSPLINE) n = 8 * (s->profile.nurbs->count + 1);
    if (n > 2048) n = 2048;
    double best = lo, bd = INFINITY;
    /* (squared distances: ties within rounding of the point's size count as ties: at a closed
     * profile's closure point both ends are at distance ~1e-30, trj7_k1-sd-214.stp) */
    double tie = 1e-24 * (1 + p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    for (int i = 0; i <= n; i++) {
        double t = lo + (hi - lo) * i / n;
        double d = profile_dist(s, p, t);
        /* Ties (a closed profile's ends) go to the parameter nearest the reference. */
        if (d < bd * (1 - 1e-12) - tie ||
            (d <= bd * (1 + 1e-12) + tie && isfinite(ref) && fabs(t - ref) < fabs(best - ref)))
            bd = d, best = t;
    }
    double a = best - (hi - lo) / n, b = best + (hi - lo) / n;
    /* (A full turn of a conic is periodic: the bracket may pass its ends. Clamped, a point just
     * short of lo + 2 pi whose grid neighbour is lo was taken for lo: trj3_s1-tc-214.stp, an
     * arc at the end of the range checked against the wrong end, 0.15 off.) */
    int turn = s->profile.kind == STEP_CURVE_CONIC && hi - lo >= 2 * M_PI * (1 - 1e-12);
    if (a < lo && !turn) a = lo;
    if (b > hi && !turn) b = hi;
    const double g = 0.6180339887498949;
    double x1 = b - g * (b - a), x2 = a + g * (b - a);
    double f1 = profile_dist(s, p, x1), f2 = profile_dist(s, p, x2);
    for (int it = 0; it < 90 && b - a > 1e-15 * (1 + fabs(a)); it++) {
        if (f1 < f2)
            b = x2, x2 = x1, f2 = f1, x1 = b - g * (b - a), f1 = profile_dist(s, p, x1);
        else
            a = x1, x1 = x2, f1 = f2, x2 = a + g * (b - a), f2 = profile_dist(s, p, x2);
    }
    return 0.5 * (a + b);
}

void crisp__step_surface_invert(const step_surface *s, const double p[3], const double *ref,
                                double uv[2])
{
    const crisp_placement *pl = &s->pl;
    double q[3];
    for (int k = 0; k < 3; k++)
        q[k] = p[k] - pl->origin[k];
    double x = dot3(q, pl->x), y = dot3(q, pl->y), z = dot3(q, pl->z);
    double rho = sqrt(x * x + y * y);
    double u = 0, v = 0;
    int have_u = 1;
    switch (s->kind) {
    case STEP_SURF_PLANE:
        uv[0] = x, uv[1] = y;
        return;
    case STEP_SURF_CYLINDER:
    case STEP_SURF_CONE:
        u = atan2(y, x);
        v = z;
        if (s->kind == STEP_SURF_CONE) {
            /* Foot of the perpendicular onto the generating line in the (rho, z) half plane. The
             * cone of ISO 10303-42 has both nappes: beyond the apex (R + v tan a < 0) the circle
             * of v lies at u + pi (screw.step); the branch nearer p is taken. */
            double c = cos(s->semi), sn = sin(s->semi);
            v = (rho - s->r) * sn * c + z * c * c;
            double vb = (-rho - s->r) * sn * c + z * c * c, t = tan(s->semi);
            double ea = hypot(rho - (s->r + v * t), z - v),
                   eb = hypot(-rho - (s->r + vb * t), z - vb);
            if (eb < ea) u += M_PI, v = vb;
        }
        have_u = rho > 1e-12 * (s->r + fabs(v) + 1);
        break;
    case STEP_SURF_SPHERE:
        u = atan2(y, x);
        v = atan2(z, rho);
        have_u = rho > 1e-12 * s->r;
        break;
    case STEP_SURF_TORUS:
        u = atan2(y, x);
        v = atan2(z, rho - s->r);
        if (s->r2 > s->r) {
            /* A spindle torus (minor radius above the major, screw.step): where R + r cos v < 0
             * the circle of v lies on the far side of the axis, at u + pi. The branch that
             * reproduces p is taken (both near the axis, where they meet: the one nearer ref). */
            double ub = u + M_PI, vb = atan2(z, -rho - s->r), pa[3], pb[3];
            crisp__step_surface_eval(s, u, v, pa);
            crisp__step_surface_eval(s, ub, vb, pb);
            double ea = hypot(hypot(pa[0] - p[0], pa[1] - p[1]), pa[2] - p[2]);
            double eb = hypot(hypot(pb[0] - p[0], pb[1] - p[1]), pb[2] - p[2]),
                   tiny = 1e-9 * (s->r + s->r2);
            int use_b = eb < ea;
            if (ref && ea <= tiny && eb <= tiny) {
                double da =
                    fabs(near_angle(u, ref[0]) - ref[0]) + fabs(near_angle(v, ref[1]) - ref[1]);
                double db =
                    fabs(near_angle(ub, ref[0]) - ref[0]) + fabs(near_angle(vb, ref[1]) - ref[1]);
                use_b = db < da;
            }
            if (use_b) u = ub, v = vb;
        }
        if (ref) v = near_angle(v, ref[1]);
        have_u = rho > 1e-12 * s->r;
        break;
    case STEP_SURF_REVOLUTION: {
        const step_curve *c = &s->profile;
        double lo = c->t0, hi = c->t1;
        if (!isfinite(lo) || !isfinite(hi)) {
            /* An unbounded line or a full conic as profile: search near the reference. */
            double span = c->kind == STEP_CURVE_CONIC ? M_PI : 1e3;
            double mid = ref ? ref[1] : 0;
            lo = mid - span, hi = mid + span;
        }
        v = profile_invert(s, p, lo, hi, ref ? ref[1] : NAN);
        if (c->kind == STEP_CURVE_CONIC && !isfinite(c->t0) && !ref) v = atan2(sin(v), cos(v));
        double cp[3], a[3], b[3];
        crisp__step_curve_eval(c, v, cp);
        for (int k = 0; k < 3; k++)
            a[k] = cp[k] - s->axis_p[k], b[k] = p[k] - s->axis_p[k];
        double ha = dot3(a, s->axis_d), hb = dot3(b, s->axis_d);
        for (int k = 0; k < 3; k++)
            a[k] -= ha * s->axis_d[k], b[k] -= hb * s->axis_d[k];
        double axb[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]};
        u = atan2(dot3(axb, s->axis_d), dot3(a, b));
        have_u = sqrt(dot3(a, a)) * sqrt(dot3(b, b)) > 1e-24;
        break;
    }
    case STEP_SURF_EXTRUSION: {
        const step_curve *c = &s->profile;
        double lo = c->t0, hi = c->t1;
        if (c->kind == STEP_CURVE_CONIC) {
            double mid = ref ? ref[0] : 0;
            lo = mid - M_PI, hi = mid + M_PI;
        } else if (!isfinite(lo) || !isfinite(hi)) {
            double mid = ref ? ref[0] : 0;
            lo = mid - 1e6, hi = mid + 1e6;
            if (c->kind == STEP_CURVE_LINE)
                lo = hi = crisp__step_curve_invert(c, p, -INFINITY, INFINITY);
        }
        uv[0] = lo == hi ? lo : profile_invert(s, p, lo, hi, ref ? ref[0] : NAN);
        double cp[3], d[3];
        crisp__step_curve_eval(c, uv[0], cp);
        for (int k = 0; k < 3; k++)
            d[k] = p[k] - cp[k];
        uv[1] = dot3(d, s->axis_d) / dot3(s->axis_d, s->axis_d);
        if (c->kind == STEP_CURVE_CONIC)
            uv[0] = ref ? near_angle(uv[0], ref[0]) : atan2(sin(uv[0]), cos(uv[0]));
        return;
    }
    case STEP_SURF_BSPLINE: {
        double d;
        if (crisp_surface_closest_point(s->nurbs, p, uv, &d) != CRISP_OK) uv[0] = uv[1] = 0;
        return;
    }
    }
    if (!have_u)
        u = ref ? ref[0] : 0;
    else if (ref)
        u = near_angle(u, ref[0]);
    uv[0] = u;
    uv[1] = v;
}

int crisp__step_surface_swaps(const step_surface *s)
{
    return s->kind == STEP_SURF_REVOLUTION;
}

int crisp__step_surface_map_linear(const step_surface *s, int coord)
{
    switch (s->kind) {
    case STEP_SURF_PLANE:
    case STEP_SURF_BSPLINE:
        return 1;
    case STEP_SURF_CYLINDER:
    case STEP_SURF_CONE:
        return coord == 1;
    case STEP_SURF_SPHERE:
    case STEP_SURF_TORUS:
        return 0;
    case STEP_SURF_REVOLUTION:
        return coord == 1 && s->profile.kind != STEP_CURVE_CONIC;
    case STEP_SURF_EXTRUSION:
        return coord == 1 || s->profile.kind != STEP_CURVE_CONIC;
    }
    return 0;
}

static double profile_param(const step_curve *c, double a0, double a1, double t)
{
    return c->kind == STEP_CURVE_CONIC ? crisp_angle_to_param(a0, a1, t) : t;
}

void crisp__step_surface_map(const step_surface *s, const double box[4], const double uv[2],
                             double dest[2])
{
    double u = uv[0], v = uv[1];
    switch (s->kind) {
    case STEP_SURF_PLANE:
    case STEP_SURF_BSPLINE:
        dest[0] = u, dest[1] = v;
        return;
    case STEP_SURF_CYLINDER:
    case STEP_SURF_CONE:
        dest[0] = crisp_angle_to_param(box[0], box[1], u), dest[1] = v;
        return;
    case STEP_SURF_SPHERE:
    case STEP_SURF_TORUS:
        dest[0] = crisp_angle_to_param(box[0], box[1], u);
        dest[1] = crisp_angle_to_param(box[2], box[3], v);
        return;
    case STEP_SURF_REVOLUTION:
        dest[0] = profile_param(&s->profile, box[2], box[3], v);
        dest[1] = crisp_angle_to_param(box[0], box[1], u);
        return;
    case STEP_SURF_EXTRUSION:
        dest[0] = profile_param(&s->profile, box[0], box[1], u);
        dest[1] = v;
        return;
    }
}

crisp_status crisp__step_surface_build(step_reader *r, const step_surface *s, const double box[4],
                                       crisp_surface **dest, double nbox[4])
{
    (void)r;
    crisp_status st = CRISP_OK;
    double u0 = box[0], u1 = box[1], v0 = box[2], v1 = box[3];
    crisp_curve *prof = NULL;
    switch (s->kind) {
    case STEP_SURF_PLANE:
        st = crisp_make_plane(&s->pl, u0, u1, v0, v1, dest);
        break;
    case STEP_SURF_CYLINDER:
        st = crisp_make_cylinder(&s->pl, s->r, u0, u1, v0, v1, dest);
        break;
    case STEP_SURF_CONE:
        st = crisp_make_cone(&s->pl, s->r, s->semi, u0, u1, v0, v1, dest);
        break;
    case STEP_SURF_SPHERE:
        st = crisp_make_sphere(&s->pl, s->r, u0, u1, v0, v1, dest);
        break;
    case STEP_SURF_TORUS:
        st = crisp_make_torus(&s->pl, s->r, s->r2, u0, u1, v0, v1, dest);
        break;
    case STEP_SURF_REVOLUTION:
        st = crisp__step_curve_nurbs(&s->profile, v0, v1, &prof);
        if (!st) st = crisp_make_revolution(prof, s->axis_p, s->axis_d, u0, u1, dest);
        break;
    case STEP_SURF_EXTRUSION:
        st = crisp__step_curve_nurbs(&s->profile, u0, u1, &prof);
        if (!st) st = crisp_make_extrusion(prof, s->axis_d, v0, v1, dest);
        break;
    case STEP_SURF_BSPLINE:
        st = crisp_surface_copy(s->nurbs, dest);
        break;
    }
    crisp_curve_destroy(prof);
    if (st) {
        crisp_error_prefix("surface #%d", s->id);
        return st;
    }
    crisp_surface_domain(*dest, nbox);
    return CRISP_OK;
}
