/* IGES surface entities into exact NURBS: 128 rational B-spline surface (with its parameter
 * range), 114 parametric spline surface (bicubic power basis -> Bézier form with triple interior
 * knots), 118 ruled surface, 120 surface of revolution, 122 tabulated cylinder, and the frame of a
 * 108 plane (sized later from its trims). Also the map from the file's (u, v) to crisp's: the
 * analytic surfaces take their parameters from their defining curves (an arc's angle, a line's
 * [0, 1]), which construct.h's NURBS reach through crisp_angle_to_param. IGES 5.3
 * sections 4.6-4.24. The analytic surfaces of B-rep files (192 right circular cylinder, 194 cone,
 * 196 sphere, 198 torus; IGES 5.3 sections 4.145-4.148) are read as a frame and radii here, and
 * built over the region their face's model-space curves reach (iges_faces.c), as a 108 plane is
 * sized from its trims; their parameter spaces (degrees, swapped and mirrored for the torus) are
 * not needed: their trims are projected from the model-space curves. 140 offset surfaces
 * (section 4.23) are crisp_surface_offset of their base surface (the same (u, v)), or an exact
 * shifted plane.
 */
#include "iges_internal.h"

#include <math.h>
#include <string.h>

#include "crisp/construct.h"

int crisp__iges_is_surface_type(int type)
{
    return type == 108 || type == 114 || type == 118 || type == 120 || type == 122 || type == 128 ||
           type == 140 || type == 190 || type == 192 || type == 194 || type == 196 || type == 198;
}

void crisp__iges_surface_free(iges_surface *s)
{
    crisp_surface_destroy(s->surface);
    s->surface = NULL;
}

static crisp_status kernel_fail(const iges_file *f, int e, crisp_status st)
{
    crisp_error_prefix("%s: DE %d (entity %d %s, line %d)", f->name, iges_de(e), f->ents[e].type,
                       crisp__iges_type_name(f->ents[e].type), f->ents[e].p_line);
    return st;
}

void crisp__iges_xform_surface(crisp_surface *s, const iges_xform *x)
{
    int n = s->count_u * s->count_v;
    for (int i = 0; i < n; i++) {
        double *p = s->cpw + 4 * i, w = p[3], r[3];
        for (int k = 0; k < 3; k++)
            r[k] = x->m[k][0] * p[0] + x->m[k][1] * p[1] + x->m[k][2] * p[2] + x->m[k][3] * w;
        memcpy(p, r, sizeof r);
    }
}

/* ---- 128 ------------------------------------------------------------------------------------ */

static crisp_status bspline_128(iges_file *f, int e, iges_surface *out)
{
    int k1, k2, m1, m2;
    crisp_status st = crisp__iges_int_range(f, e, 1, 1, CRISP_MAX_CONTROL_POINTS - 1, &k1);
    if (!st) st = crisp__iges_int_range(f, e, 2, 1, CRISP_MAX_CONTROL_POINTS - 1, &k2);
    if (!st) st = crisp__iges_int_range(f, e, 3, 1, CRISP_MAX_DEGREE, &m1);
    if (!st) st = crisp__iges_int_range(f, e, 4, 1, CRISP_MAX_DEGREE, &m2);
    if (st) return st;
    int nu = k1 + 1, nv = k2 + 1;
    if (nu < m1 + 1 || nv < m2 + 1)
        return crisp__iges_fail(
            f, e, CRISP_ERR_PARSE,
            "%d x %d control points for degrees (%d, %d): expected at least %d x %d", nu, nv, m1,
            m2, m1 + 1, m2 + 1);
    if ((long long)nu * nv > CRISP_MAX_CONTROL_POINTS)
        return crisp__iges_fail(f, e, CRISP_ERR_LIMIT, "%d x %d control points: more than %d", nu,
                                nv, CRISP_MAX_CONTROL_POINTS);
    int n = nu * nv, nk1 = nu + m1 + 1, nk2 = nv + m2 + 1;
    int ku = 10, kv = ku + nk1, kw = kv + nk2, kp = kw + n, kr = kp + 3 * n;
    if ((st = crisp__iges_need(f, e, kr - 1, "a rational B-spline surface"))) return st;
    double *knu = crisp_malloc_array((size_t)nk1, sizeof(double));
    double *knv = crisp_malloc_array((size_t)nk2, sizeof(double));
    double *w = crisp_malloc_array((size_t)n, sizeof(double));
    double *pts = crisp_malloc_array((size_t)n, 3 * sizeof(double));
    if (!knu || !knv || !w || !pts) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    for (int i = 0; i < nk1 && !st; i++)
        st = crisp__iges_real(f, e, ku + i, &knu[i]);
    for (int i = 0; i < nk2 && !st; i++)
        st = crisp__iges_real(f, e, kv + i, &knv[i]);
    for (int i = 0; i < n && !st; i++)
        st = crisp__iges_real(f, e, kw + i, &w[i]);
    for (int i = 0; i < 3 * n && !st; i++)
        st = crisp__iges_real(f, e, kp + i, &pts[i]);
    if (st) goto done;
    int rational = 0;
    for (int i = 0; i < n; i++)
        if (w[i] != 1) rational = 1;
    st = crisp_surface_create(m1, m2, nu, nv, knu, knv, pts, rational ? w : NULL, &out->surface);
    if (st) {
        st = kernel_fail(f, e, st);
        goto done;
    }
    /* The parameter range U0 U1 V0 V1: crisp keeps the knot domain (trims are given in the same
     * parameters); a narrower range bounds the face like an outer loop (crisp__iges_domain_loop).
     */
    double dom[4], r[4];
    crisp_surface_domain(out->surface, dom);
    for (int i = 0; i < 4 && !st; i++)
        st = crisp__iges_real_def(f, e, kr + i, dom[i], &r[i]);
    if (st) goto done;
    for (int i = 0; i < 4; i++)
        r[i] = fmin(fmax(r[i], dom[i & 2]), dom[(i & 2) + 1]);
    double eu = 1e-9 * (dom[1] - dom[0]), ev = 1e-9 * (dom[3] - dom[2]);
    if (r[1] - r[0] > eu && r[3] - r[2] > ev &&
        (r[0] > dom[0] + eu || r[1] < dom[1] - eu || r[2] > dom[2] + ev || r[3] < dom[3] - ev)) {
        out->narrowed = 1;
        memcpy(out->range, r, sizeof r);
    }
done:
    crisp_free(knu);
    crisp_free(knv);
    crisp_free(w);
    crisp_free(pts);
    return st;
}

/* ---- 114 ------------------------------------------------------------------------------------ */

/* Power coefficients c[0..3] of a cubic on [0, 1] -> its Bézier ordinates. */
static void power_to_bezier(const double c[4], double b[4])
{
    b[0] = c[0];
    b[1] = c[0] + c[1] / 3;
    b[2] = c[0] + 2 * c[1] / 3 + c[2] / 3;
    b[3] = c[0] + c[1] + c[2] + c[3];
}

static crisp_status spline_114(iges_file *f, int e, crisp_surface **dest)
{
    int ctype, ptype, m, n;
    crisp_status st = crisp__iges_int(f, e, 1, &ctype);
    if (!st) st = crisp__iges_int(f, e, 2, &ptype);
    if (!st) st = crisp__iges_int_range(f, e, 3, 1, 4096, &m);
    if (!st) st = crisp__iges_int_range(f, e, 4, 1, 4096, &n);
    if (st) return st;
    if ((long long)(3 * m + 1) * (3 * n + 1) > CRISP_MAX_CONTROL_POINTS)
        return crisp__iges_fail(f, e, CRISP_ERR_LIMIT, "%d x %d patches: too many", m, n);
    int kt = 5, kc = kt + (m + 1) + (n + 1);
    /* patches (i, j) in order i outer, j inner, N + 1 per row (the last of a row is a dummy) */
    if ((st = crisp__iges_need(f, e, kc - 1 + 48 * ((m - 1) * (n + 1) + n),
                               "the coefficients of a parametric spline surface")))
        return st;
    int nu = 3 * m + 1, nv = 3 * n + 1;
    double *tu = crisp_malloc_array((size_t)m + 1, sizeof(double));
    double *tv = crisp_malloc_array((size_t)n + 1, sizeof(double));
    double *knu = crisp_malloc_array((size_t)nu + 4, sizeof(double));
    double *knv = crisp_malloc_array((size_t)nv + 4, sizeof(double));
    double *pts = crisp_calloc_array((size_t)nu * nv, 3 * sizeof(double));
    if (!tu || !tv || !knu || !knv || !pts) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    for (int i = 0; i <= m && !st; i++)
        st = crisp__iges_real(f, e, kt + i, &tu[i]);
    for (int j = 0; j <= n && !st; j++)
        st = crisp__iges_real(f, e, kt + m + 1 + j, &tv[j]);
    if (st) goto done;
    for (int i = 0; i < m; i++)
        if (!(tu[i + 1] > tu[i])) {
            st = crisp__iges_fail(f, e, CRISP_ERR_PARSE, "u break points are not increasing");
            goto done;
        }
    for (int j = 0; j < n; j++)
        if (!(tv[j + 1] > tv[j])) {
            st = crisp__iges_fail(f, e, CRISP_ERR_PARSE, "v break points are not increasing");
            goto done;
        }
    for (int i = 0; i < m && !st; i++) {
        double hu = tu[i + 1] - tu[i];
        for (int j = 0; j < n && !st; j++) {
            double hv = tv[j + 1] - tv[j], co[48];
            int k0 = kc + 48 * (i * (n + 1) + j);
            for (int q = 0; q < 48 && !st; q++)
                st = crisp__iges_real(f, e, k0 + q, &co[q]);
            if (st) break;
            for (int c = 0; c < 3; c++) {
                /* X(s, t) = sum a[p + 4 q] s^p t^q, scaled to local [0, 1]^2 */
                double a[16], tmp[16], b[16];
                for (int q = 0; q < 4; q++)
                    for (int p = 0; p < 4; p++)
                        a[p + 4 * q] = co[16 * c + p + 4 * q] * pow(hu, p) * pow(hv, q);
                for (int q = 0; q < 4; q++)
                    power_to_bezier(a + 4 * q, tmp + 4 * q);
                for (int p = 0; p < 4; p++) {
                    double col[4] = {tmp[p], tmp[p + 4], tmp[p + 8], tmp[p + 12]}, r[4];
                    power_to_bezier(col, r);
                    for (int q = 0; q < 4; q++)
                        b[p + 4 * q] = r[q];
                }
                for (int q = 0; q < 4; q++)
                    for (int p = 0; p < 4; p++)
                        pts[3 * ((3 * j + q) * nu + 3 * i + p) + c] = b[p + 4 * q];
            }
        }
    }
    if (st) goto done;
    for (int k = 0; k < 4; k++) {
        knu[k] = tu[0], knu[nu + k] = tu[m];
        knv[k] = tv[0], knv[nv + k] = tv[n];
    }
    for (int i = 1; i < m; i++)
        for (int k = 0; k < 3; k++)
            knu[1 + 3 * i + k] = tu[i];
    for (int j = 1; j < n; j++)
        for (int k = 0; k < 3; k++)
            knv[1 + 3 * j + k] = tv[j];
    st = crisp_surface_create(3, 3, nu, nv, knu, knv, pts, NULL, dest);
    if (st) st = kernel_fail(f, e, st);
done:
    crisp_free(tu);
    crisp_free(tv);
    crisp_free(knu);
    crisp_free(knv);
    crisp_free(pts);
    return st;
}

/* ---- analytic surfaces from curves ---------------------------------------------------------- */

/* The single curve of entity `ptr` (parameter k of e), in model space with its own transform. */
static crisp_status one_curve(iges_file *f, int e, int k, int depth, crisp_curve **dest,
                              iges_param_map *map)
{
    int c;
    crisp_status st = crisp__iges_ptr(f, e, k, 0, &c);
    if (st) return st;
    if (!crisp__iges_is_curve_type(f->ents[c].type) && f->ents[c].type != 130)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter %d: DE %d is entity %d, expected a "
                                "curve",
                                k, iges_de(c), f->ents[c].type);
    if (map && (st = crisp__iges_curve_param_map(f, c, map))) return st;
    iges_curves out = {0};
    if ((st = crisp__iges_curve_convert(f, c, 3, NULL, depth + 1, &out))) {
        crisp__iges_curves_free(&out);
        return st;
    }
    if (out.count != 1) {
        crisp__iges_curves_free(&out);
        return crisp__iges_fail(
            f, e, CRISP_ERR_UNSUPPORTED,
            "parameter %d: a defining curve made of %d pieces (expected one curve)", k, out.count);
    }
    *dest = out.items[0];
    out.count = 0;
    crisp__iges_curves_free(&out);
    return CRISP_OK;
}

/* file parameter in [0, 1] along a curve whose own parameter runs over [t0, t1] */
static void normalised_map(iges_param_map *m, const crisp_curve *c)
{
    double t0, t1;
    if (m->angular) {
        t0 = m->a0;
        t1 = m->a1;
    } else {
        crisp_curve_domain(c, &t0, &t1);
    }
    m->scale = t1 - t0;
    m->offset = t0;
}

static crisp_status revolution_120(iges_file *f, int e, int depth, iges_surface *dest)
{
    crisp_curve *axis = NULL, *gen = NULL;
    double sa, ta;
    crisp_status st = crisp__iges_need(f, e, 4, "a surface of revolution");
    if (!st) st = crisp__iges_real(f, e, 3, &sa);
    if (!st) st = crisp__iges_real(f, e, 4, &ta);
    if (st) return st;
    if (!(ta > sa) || ta - sa > 2 * M_PI + 1e-9)
        return crisp__iges_fail(
            f, e, CRISP_ERR_PARSE,
            "angles %g to %g: expected a start below the end, at most 2 pi apart", sa, ta);
    if (ta - sa > 2 * M_PI) ta = sa + 2 * M_PI;
    if ((st = one_curve(f, e, 1, depth, &axis, NULL))) return st;
    if ((st = one_curve(f, e, 2, depth, &gen, &dest->map_u))) goto done;
    double p0[3], p1[3], t0, t1, dir[3];
    crisp_curve_domain(axis, &t0, &t1);
    crisp_curve_eval(axis, t0, p0);
    crisp_curve_eval(axis, t1, p1);
    crisp_vec3_sub(p1, p0, dir);
    if (!crisp_vec3_normalize(dir, dir)) {
        st = crisp__iges_fail(f, e, CRISP_ERR_NUMERIC, "the axis line has zero length");
        goto done;
    }
    st = crisp_make_revolution(gen, p0, dir, sa, ta, &dest->surface);
    if (st) {
        st = kernel_fail(f, e, st);
        goto done;
    }
    dest->map_v = (iges_param_map){.angular = 1, .a0 = sa, .a1 = ta, .scale = 1};
done:
    crisp_curve_destroy(axis);
    crisp_curve_destroy(gen);
    return st;
}

static crisp_status ruled_118(iges_file *f, int e, int depth, iges_surface *dest)
{
    crisp_curve *c0 = NULL, *c1 = NULL;
    int dirflg;
    crisp_status st = crisp__iges_need(f, e, 3, "a ruled surface");
    if (!st) st = crisp__iges_int_def(f, e, 3, 0, &dirflg);
    if (!st) st = one_curve(f, e, 1, depth, &c0, NULL);
    if (!st) st = one_curve(f, e, 2, depth, &c1, NULL);
    if (!st) {
        if (dirflg == 1) crisp_curve_reverse(c1);
        /* Both IGES and crisp parametrise u over [0, 1] linearly in each curve's own parameter;
         * for form 0 (equal relative arc length) this is the parametric reading. */
        st = crisp_make_ruled(c0, c1, &dest->surface);
        if (st) st = kernel_fail(f, e, st);
    }
    crisp_curve_destroy(c0);
    crisp_curve_destroy(c1);
    return st;
}

static crisp_status tabulated_122(iges_file *f, int e, int depth, iges_surface *dest)
{
    crisp_curve *c = NULL;
    double l[3];
    crisp_status st = crisp__iges_need(f, e, 4, "a tabulated cylinder");
    for (int i = 0; i < 3 && !st; i++)
        st = crisp__iges_real(f, e, 2 + i, &l[i]);
    if (!st) st = one_curve(f, e, 1, depth, &c, &dest->map_u);
    if (st) return st;
    /* the generatrix runs from the directrix start to L (both in the entity's own space: the
     * directrix was transformed by its own matrix only) */
    double t0, t1, p0[3], dir[3];
    crisp_curve_domain(c, &t0, &t1);
    crisp_curve_eval(c, t0, p0);
    crisp_vec3_sub(l, p0, dir);
    normalised_map(&dest->map_u, c);
    st = crisp_make_extrusion(c, dir, 0, 1, &dest->surface);
    if (st) st = kernel_fail(f, e, st);
    crisp_curve_destroy(c);
    return st;
}

/* A plane through o with normal `axis` (x along ref when given): the frame a plane face is
 * sized in from its loops. */
static crisp_status plane_frame(const iges_file *f, int e, const double o[3], const double axis[3],
                                const double *ref, iges_surface *dest)
{
    crisp_placement pl;
    crisp_status st = crisp_placement_make(o, axis, ref, &pl);
    if (st) return kernel_fail(f, e, st);
    dest->is_plane = 1;
    memcpy(dest->origin, pl.origin, sizeof pl.origin);
    memcpy(dest->x, pl.x, sizeof pl.x);
    memcpy(dest->y, pl.y, sizeof pl.y);
    return CRISP_OK;
}

static crisp_status plane_108(iges_file *f, int e, iges_surface *dest)
{
    double n[4];
    crisp_status st = crisp__iges_need(f, e, 4, "a plane");
    for (int i = 0; i < 4 && !st; i++)
        st = crisp__iges_real(f, e, 1 + i, &n[i]);
    if (st) return st;
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0)) return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC, "normal (A, B, C) is zero");
    double axis[3] = {n[0] / len, n[1] / len, n[2] / len}, o[3];
    crisp_vec3_scale(axis, n[3] / len, o);
    return plane_frame(f, e, o, axis, NULL, dest);
}

/* Entity k of e points at a 116 point (want_dir 0) or a 123 direction (want_dir 1); its value in
 * the entity's own frame (its matrix applied: all of it to a point, the rotation to a direction).
 */
static crisp_status point_or_direction(iges_file *f, int e, int k, int want_dir, int depth,
                                       double dest[3])
{
    int p, type = want_dir ? 123 : 116;
    crisp_status st = crisp__iges_ptr(f, e, k, 0, &p);
    if (st) return st;
    if (f->ents[p].type != type)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter %d: DE %d is entity %d, expected %d", k, iges_de(p),
                                f->ents[p].type, type);
    double v[3];
    for (int i = 0; i < 3 && !st; i++)
        st = crisp__iges_real(f, p, 1 + i, &v[i]);
    iges_xform own;
    if (!st) st = crisp__iges_entity_xform(f, p, depth + 1, &own);
    if (st) return st;
    f->ents[p].used = 1;
    if (want_dir) own.m[0][3] = own.m[1][3] = own.m[2][3] = 0;
    crisp__iges_xform_point(&own, v, dest);
    return CRISP_OK;
}

/* 190 plane surface: a point and a normal (form 1 adds the reference direction of its u axis).
 * Like a 108 it is sized from its loops; IGES 5.3 section 4.144. */
static crisp_status plane_190(iges_file *f, int e, int depth, iges_surface *dest)
{
    double o[3], n[3], ref[3];
    crisp_status st = crisp__iges_need(f, e, 2, "a plane surface");
    if (!st) st = point_or_direction(f, e, 1, 0, depth, o);
    if (!st) st = point_or_direction(f, e, 2, 1, depth, n);
    int has_ref = f->ents[e].form == 1 && crisp__iges_nparams(f, e) >= 3;
    if (!st && has_ref) st = point_or_direction(f, e, 3, 1, depth, ref);
    if (st) return st;
    return plane_frame(f, e, o, n, has_ref ? ref : NULL, dest);
}

/* 192-198: location (116), axis (123), radii (and a semi-angle in degrees), form 1 a reference
 * direction (123); the sphere's radius comes before its axis. */
static crisp_status analytic_19x(iges_file *f, int e, int depth, iges_surface *dest)
{
    int type = f->ents[e].type, k = 1;
    double o[3], axis[3], ref[3];
    crisp_status st =
        crisp__iges_need(f, e, type == 192 || type == 196 ? 3 : 4, "an analytic surface");
    if (!st) st = point_or_direction(f, e, k++, 0, depth, o);
    if (!st && type == 196) st = crisp__iges_real(f, e, k++, &dest->radius);
    if (!st) st = point_or_direction(f, e, k++, 1, depth, axis);
    if (!st && type != 196) st = crisp__iges_real(f, e, k++, &dest->radius);
    if (!st && type == 194) st = crisp__iges_real(f, e, k++, &dest->semi);
    if (!st && type == 198) st = crisp__iges_real(f, e, k++, &dest->radius2);
    int has_ref = f->ents[e].form == 1 && crisp__iges_nparams(f, e) >= k;
    if (!st && has_ref) st = point_or_direction(f, e, k, 1, depth, ref);
    if (st) return st;
    if (type == 194) {
        dest->semi *= M_PI / 180;
        if (!(dest->semi > 0 && dest->semi < M_PI / 2) || !(dest->radius >= 0))
            return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                    "cone: semi-angle %g degrees, radius %g: expected an angle in "
                                    "(0, 90) and a radius >= 0",
                                    dest->semi * 180 / M_PI, dest->radius);
    } else if (!(dest->radius > 0) || (type == 198 && !(dest->radius2 > 0))) {
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE, "radius %g%s: expected > 0", dest->radius,
                                type == 198 ? " (or the minor radius)" : "");
    }
    crisp_placement pl;
    st = crisp_placement_make(o, axis, has_ref ? ref : NULL, &pl);
    if (st) return kernel_fail(f, e, st);
    dest->analytic = type;
    memcpy(dest->origin, pl.origin, sizeof pl.origin);
    memcpy(dest->x, pl.x, sizeof pl.x);
    memcpy(dest->y, pl.y, sizeof pl.y);
    return CRISP_OK;
}

/* 140 offset surface: offset indicator (3 reals: not needed, as in Open CASCADE's reader: the
 * offset follows the base surface's normal), distance, base surface. */
static crisp_status offset_140(iges_file *f, int e, int depth, iges_surface *dest)
{
    double dist;
    int b;
    crisp_status st = crisp__iges_need(f, e, 5, "an offset surface");
    if (!st) st = crisp__iges_real(f, e, 4, &dist);
    if (!st) st = crisp__iges_ptr(f, e, 5, 0, &b);
    if (st) return st;
    if (!crisp__iges_is_surface_type(f->ents[b].type))
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter 5: DE %d is entity %d, expected a surface", iges_de(b),
                                f->ents[b].type);
    double ind[3];
    for (int k = 0; k < 3 && !st; k++)
        st = crisp__iges_real(f, e, 1 + k, &ind[k]);
    if (!st) st = crisp__iges_surface_convert(f, b, depth + 1, dest);
    if (st) return st;
    /* The indicator points to the offset side at the base's first parameters
     * (bug23171_tube_surf.igs: its two tube halves offset outwards, against one of their normals);
     * a zero one leaves the normal's side, as Open CASCADE's reader always does. */
    if (dest->surface && crisp_vec3_norm(ind) > 0) {
        double d0[4], n0[3];
        crisp_surface_domain(dest->surface, d0);
        if (crisp_surface_normal(dest->surface, d0[0], d0[2], n0) && crisp_vec3_dot(n0, ind) < 0)
            dist = -dist;
    }
    if (dest->analytic) {
        /* exact, outwards: the radius grows by the distance (the torus's minor radius); a
         * cone's offset is the cone of the same axis and angle whose radius at the location grows
         * by d / cos(semi-angle) */
        if (dest->analytic == 198)
            dest->radius2 += dist;
        else if (dest->analytic == 194)
            dest->radius += dist / cos(dest->semi);
        else
            dest->radius += dist;
        if (!(dest->radius >= 0) || (dest->analytic == 198 && !(dest->radius2 > 0)))
            return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC,
                                    "offset %g turns the surface inside out", dist);
        return CRISP_OK;
    }
    if (dest->is_plane) { /* exact: the frame moves along the plane's normal */
        double z[3], len;
        crisp_vec3_cross(dest->x, dest->y, z);
        len = crisp_vec3_norm(z);
        for (int k = 0; k < 3; k++)
            dest->origin[k] += dist * z[k] / len;
        return CRISP_OK;
    }
    double box[6];
    crisp_surface_bbox(dest->surface, box);
    double diag =
        sqrt((box[3] - box[0]) * (box[3] - box[0]) + (box[4] - box[1]) * (box[4] - box[1]) +
             (box[5] - box[2]) * (box[5] - box[2]));
    crisp_surface *off = NULL;
    st = crisp_surface_offset(dest->surface, dist, f->projection_fraction * (diag + fabs(dist)), 64,
                              &off);
    if (st) return kernel_fail(f, e, st);
    crisp_surface_destroy(dest->surface);
    dest->surface = off;
    return CRISP_OK;
}

crisp_status crisp__iges_surface_convert(iges_file *f, int e, int depth, iges_surface *dest)
{
    memset(dest, 0, sizeof *dest);
    dest->map_u.scale = dest->map_v.scale = 1;
    iges_entity *x = &f->ents[e];
    if (depth > IGES_MAX_DEPTH)
        return crisp__iges_fail(f, e, CRISP_ERR_LIMIT, "surfaces nested deeper than %d",
                                IGES_MAX_DEPTH);
    if (x->visiting) return crisp__iges_fail(f, e, CRISP_ERR_PARSE, "reference cycle");
    x->used = 1;
    iges_xform own;
    crisp_status st = crisp__iges_entity_xform(f, e, depth + 1, &own);
    if (st) return st;
    x->visiting = 1;
    switch (x->type) {
    case 128:
        st = bspline_128(f, e, dest);
        break;
    case 114:
        st = spline_114(f, e, &dest->surface);
        break;
    case 118:
        st = ruled_118(f, e, depth, dest);
        break;
    case 120:
        st = revolution_120(f, e, depth, dest);
        break;
    case 122:
        st = tabulated_122(f, e, depth, dest);
        break;
    case 108:
        st = plane_108(f, e, dest);
        break;
    case 190:
        st = plane_190(f, e, depth, dest);
        break;
    case 192:
    case 194:
    case 196:
    case 198:
        st = analytic_19x(f, e, depth, dest);
        break;
    case 140:
        st = offset_140(f, e, depth, dest);
        break;
    default:
        st = crisp__iges_fail(f, e, CRISP_ERR_UNSUPPORTED, "not a surface type crisp reads");
        break;
    }
    x->visiting = 0;
    if (st) {
        crisp__iges_surface_free(dest);
        return st;
    }
    if (dest->surface) crisp__iges_xform_surface(dest->surface, &own);
    if (dest->is_plane || dest->analytic) {
        double o[3], ex[3], ey[3], z[3] = {0, 0, 0};
        crisp__iges_xform_point(&own, dest->origin, o);
        double px[3], py[3];
        crisp_vec3_add(dest->origin, dest->x, px);
        crisp_vec3_add(dest->origin, dest->y, py);
        crisp__iges_xform_point(&own, px, ex);
        crisp__iges_xform_point(&own, py, ey);
        crisp_vec3_sub(ex, o, ex);
        crisp_vec3_sub(ey, o, ey);
        (void)z;
        memcpy(dest->origin, o, sizeof o);
        memcpy(dest->x, ex, sizeof ex);
        memcpy(dest->y, ey, sizeof ey);
        if (dest->analytic) {
            /* a scaling matrix scales the radii; the frame stays unit */
            double sc = crisp_vec3_norm(dest->x);
            if (!(sc > 0))
                return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC,
                                        "its transformation matrix is singular");
            crisp_vec3_scale(dest->x, 1 / sc, dest->x);
            crisp_vec3_scale(dest->y, 1 / crisp_vec3_norm(dest->y), dest->y);
            dest->radius *= sc;
            dest->radius2 *= sc;
        }
    }
    return CRISP_OK;
}

/* ---- parameter-space curves into crisp's (u, v) --------------------------------------------- */

typedef struct map_ctx {
    const crisp_curve *c;
    const iges_surface *s;
} map_ctx;

static void mapped_eval(void *ctx, double t, double *dest)
{
    const map_ctx *m = ctx;
    double p[2];
    crisp_curve_eval(m->c, t, p);
    dest[0] = crisp__iges_param_map_apply(&m->s->map_u, p[0]);
    dest[1] = crisp__iges_param_map_apply(&m->s->map_v, p[1]);
}

crisp_status crisp__iges_surface_map_curve(const iges_surface *s, double tol_uv, crisp_curve **c)
{
    const iges_param_map *mu = &s->map_u, *mv = &s->map_v;
    if (crisp__iges_param_map_is_identity(mu) && crisp__iges_param_map_is_identity(mv))
        return CRISP_OK;
    crisp_curve *cv = *c;
    int n = cv->count;
    /* Exact cases: affine maps act on control points; an angular coordinate that is constant
     * maps as a constant; a straight line along one angular direction stays a line. */
    int const_u = 1, const_v = 1;
    for (int i = 1; i < n; i++) {
        const double *a = cv->cpw, *b = cv->cpw + 3 * i;
        if (a[0] / a[2] != b[0] / b[2]) const_u = 0;
        if (a[1] / a[2] != b[1] / b[2]) const_v = 0;
    }
    int exact = (!mu->angular || const_u) && (!mv->angular || const_v);
    int line = cv->degree == 1 && n == 2 && (const_u || const_v);
    if (exact || line) {
        for (int i = 0; i < n; i++) {
            double *p = cv->cpw + 3 * i, w = p[2];
            p[0] = crisp__iges_param_map_apply(mu, p[0] / w) * w;
            p[1] = crisp__iges_param_map_apply(mv, p[1] / w) * w;
        }
        return CRISP_OK;
    }
    map_ctx ctx = {cv, s};
    double t0, t1;
    crisp_curve_domain(cv, &t0, &t1);
    crisp_curve *fit = NULL;
    crisp_status st = crisp_fit_curve(2, mapped_eval, &ctx, t0, t1, tol_uv, 4096, &fit);
    if (st) return st;
    crisp_curve_destroy(cv);
    *c = fit;
    return CRISP_OK;
}
