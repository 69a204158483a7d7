/* IGES curve entities into exact NURBS: 100 circular arc, 102 composite curve, 104 conic arc,
 * 106 copious data (polylines, forms 11, 12, 63), 110 line, 112 parametric spline curve (cubic
 * power basis -> Bézier form with triple interior knots), 126 rational B-spline curve; and 124
 * transformation matrices composed down their chains. IGES 5.3 sections 4.3-4.23.
 */
#include "iges_internal.h"

#include <math.h>
#include <string.h>

#include "crisp/construct.h"

/* ---- transforms ----------------------------------------------------------------------------- */

void crisp__iges_xform_identity(iges_xform *dest)
{
    memset(dest, 0, sizeof *dest);
    dest->m[0][0] = dest->m[1][1] = dest->m[2][2] = 1;
}

void crisp__iges_xform_mul(const iges_xform *a, const iges_xform *b, iges_xform *dest)
{
    iges_xform r;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 4; j++) {
            double s = j == 3 ? a->m[i][3] : 0;
            for (int k = 0; k < 3; k++)
                s += a->m[i][k] * b->m[k][j];
            r.m[i][j] = s;
        }
    }
    *dest = r;
}

void crisp__iges_xform_point(const iges_xform *x, const double p[3], double dest[3])
{
    double r[3];
    for (int i = 0; i < 3; i++)
        r[i] = x->m[i][0] * p[0] + x->m[i][1] * p[1] + x->m[i][2] * p[2] + x->m[i][3];
    memcpy(dest, r, sizeof r);
}

crisp_status crisp__iges_entity_xform(iges_file *f, int e, int depth, iges_xform *dest)
{
    crisp__iges_xform_identity(dest);
    int de = f->ents[e].transform;
    if (de == 0) return CRISP_OK;
    if (depth > IGES_MAX_DEPTH)
        return crisp__iges_fail(
            f, e, CRISP_ERR_LIMIT,
            "transformation matrices nested deeper than %d (expected a chain of "
            "entity 124 ending in 0)",
            IGES_MAX_DEPTH);
    int t = crisp__iges_index(f, de < 0 ? -de : de);
    if (t < 0 || f->ents[t].type != 124)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "transformation matrix pointer %d: expected a DE of entity 124",
                                de);
    if (f->ents[t].visiting)
        return crisp__iges_fail(f, t, CRISP_ERR_PARSE, "transformation matrix chain is a cycle");
    crisp_status st = crisp__iges_need(f, t, 12, "a transformation matrix");
    if (st) return st;
    iges_xform m;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++)
            if ((st = crisp__iges_real(f, t, 4 * i + j + 1, &m.m[i][j]))) return st;
    f->ents[t].used = 1;
    f->ents[t].visiting = 1;
    iges_xform up;
    st = crisp__iges_entity_xform(f, t, depth + 1, &up);
    f->ents[t].visiting = 0;
    if (st) return st;
    crisp__iges_xform_mul(&up, &m, dest);
    return CRISP_OK;
}

/* ---- curve lists ---------------------------------------------------------------------------- */

void crisp__iges_curves_free(iges_curves *c)
{
    for (int i = 0; i < c->count; i++)
        crisp_curve_destroy(c->items[i]);
    crisp_free(c->items);
    memset(c, 0, sizeof *c);
}

crisp_status crisp__iges_curves_push(iges_curves *c, crisp_curve *curve)
{
    size_t cap = (size_t)c->cap;
    if (crisp_grow((void **)&c->items, &cap, (size_t)c->count + 1, sizeof *c->items)) {
        crisp_curve_destroy(curve);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    }
    c->cap = (int)cap;
    c->items[c->count++] = curve;
    return CRISP_OK;
}

int crisp__iges_is_curve_type(int type)
{
    return type == 100 || type == 102 || type == 104 || type == 106 || type == 110 || type == 112 ||
           type == 126;
}

/* A kernel failure, with the entity named in front of the kernel's message. */
static crisp_status kernel_fail(const iges_file *f, int e, crisp_status st)
{
    crisp_error_prefix("%s: DE %d (entity %d %s, line %d)", f->name, iges_de(e), f->ents[e].type,
                       crisp__iges_type_name(f->ents[e].type), f->ents[e].p_line);
    return st;
}

/* Transform a 3D curve in place (homogeneous control points), then push it as dim 3, or as a 2D
 * curve with z dropped. Takes ownership of c. */
static crisp_status emit(iges_file *f, int e, crisp_curve *c, int dim, const iges_xform *x,
                         iges_curves *out)
{
    for (int i = 0; i < c->count; i++) {
        double *p = c->cpw + 4 * i, w = p[3], r[3];
        for (int k = 0; k < 3; k++)
            r[k] = x->m[k][0] * p[0] + x->m[k][1] * p[1] + x->m[k][2] * p[2] + x->m[k][3] * w;
        memcpy(p, r, sizeof r);
    }
    if (dim == 3) return crisp__iges_curves_push(out, c);
    double *pts = crisp_malloc_array((size_t)c->count, 2 * sizeof(double));
    double *wts = crisp_malloc_array((size_t)c->count, sizeof(double));
    crisp_status st = CRISP_OK;
    crisp_curve *c2 = NULL;
    if (!pts || !wts) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    } else {
        for (int i = 0; i < c->count; i++) {
            const double *p = c->cpw + 4 * i;
            pts[2 * i] = p[0] / p[3];
            pts[2 * i + 1] = p[1] / p[3];
            wts[i] = p[3];
        }
        st = crisp_curve_create(2, c->degree, c->count, c->knots, pts, c->rational ? wts : NULL,
                                &c2);
        if (st) st = kernel_fail(f, e, st);
    }
    crisp_free(pts);
    crisp_free(wts);
    crisp_curve_destroy(c);
    if (st) return st;
    return crisp__iges_curves_push(out, c2);
}

static crisp_status make_3d(iges_file *f, int e, int degree, int count, const double *knots,
                            const double *pts, const double *w, crisp_curve **dest)
{
    crisp_status st = crisp_curve_create(3, degree, count, knots, pts, w, dest);
    return st ? kernel_fail(f, e, st) : CRISP_OK;
}

static crisp_status read_reals(iges_file *f, int e, int k0, int n, double *dest)
{
    for (int i = 0; i < n; i++) {
        crisp_status st = crisp__iges_real(f, e, k0 + i, &dest[i]);
        if (st) return st;
    }
    return CRISP_OK;
}

/* ---- entities ------------------------------------------------------------------------------- */

static crisp_status arc_angles(double cx, double cy, const double s[2], const double t[2],
                               double *a0, double *a1)
{
    *a0 = atan2(s[1] - cy, s[0] - cx);
    *a1 = atan2(t[1] - cy, t[0] - cx);
    double r = hypot(s[0] - cx, s[1] - cy);
    if (hypot(s[0] - t[0], s[1] - t[1]) <= 1e-12 * (r > 0 ? r : 1)) *a1 = *a0 + 2 * M_PI;
    while (*a1 <= *a0)
        *a1 += 2 * M_PI;
    return CRISP_OK;
}

static crisp_status arc_100(iges_file *f, int e, crisp_curve **dest)
{
    double v[7];
    crisp_status st = crisp__iges_need(f, e, 7, "a circular arc");
    if (!st) st = read_reals(f, e, 1, 7, v);
    if (st) return st;
    double r = hypot(v[3] - v[1], v[4] - v[2]);
    if (!(r > 0))
        return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC,
                                "radius is zero: expected a start point away "
                                "from the centre");
    double a0, a1;
    arc_angles(v[1], v[2], v + 3, v + 5, &a0, &a1);
    double c[3] = {v[1], v[2], v[0]}, x[3] = {1, 0, 0}, y[3] = {0, 1, 0};
    st = crisp_make_arc(3, c, x, y, r, r, a0, a1, dest);
    return st ? kernel_fail(f, e, st) : CRISP_OK;
}

static double conic_q(const double *k, double x, double y)
{
    return k[0] * x * x + k[1] * x * y + k[2] * y * y + k[3] * x + k[4] * y + k[5];
}

static crisp_status conic_104(iges_file *f, int e, crisp_curve **dest)
{
    double v[11];
    crisp_status st = crisp__iges_need(f, e, 11, "a conic arc");
    if (!st) st = read_reals(f, e, 1, 11, v);
    if (st) return st;
    const double *k = v; /* A B C D E F */
    double zt = v[6], s[2] = {v[7], v[8]}, t[2] = {v[9], v[10]};
    double disc = k[1] * k[1] - 4 * k[0] * k[2];
    double scale = fabs(k[0]) + fabs(k[1]) + fabs(k[2]);
    if (!(scale > 0))
        return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC, "A, B and C are zero: not a conic");
    if (disc < -1e-12 * scale * scale) {
        /* ellipse: centre, principal axes, semi-axes */
        double det = 4 * k[0] * k[2] - k[1] * k[1];
        double cx = (k[1] * k[4] - 2 * k[2] * k[3]) / det;
        double cy = (k[1] * k[3] - 2 * k[0] * k[4]) / det;
        double fc = conic_q(k, cx, cy);
        double th = 0.5 * atan2(k[1], k[0] - k[2]);
        double ux[2] = {cos(th), sin(th)}, uy[2] = {-sin(th), cos(th)};
        double l1 = k[0] * ux[0] * ux[0] + k[1] * ux[0] * ux[1] + k[2] * ux[1] * ux[1];
        double l2 = k[0] * uy[0] * uy[0] + k[1] * uy[0] * uy[1] + k[2] * uy[1] * uy[1];
        double ra = sqrt(-fc / l1), rb = sqrt(-fc / l2);
        if (!(ra > 0) || !(rb > 0) || !isfinite(ra) || !isfinite(rb))
            return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC, "degenerate ellipse (no real points)");
        double ls[2] = {((s[0] - cx) * ux[0] + (s[1] - cy) * ux[1]) / ra,
                        ((s[0] - cx) * uy[0] + (s[1] - cy) * uy[1]) / rb};
        double lt[2] = {((t[0] - cx) * ux[0] + (t[1] - cy) * ux[1]) / ra,
                        ((t[0] - cx) * uy[0] + (t[1] - cy) * uy[1]) / rb};
        double a0, a1;
        arc_angles(0, 0, ls, lt, &a0, &a1);
        double c[3] = {cx, cy, zt}, x[3] = {ux[0], ux[1], 0}, y[3] = {uy[0], uy[1], 0};
        st = crisp_make_arc(3, c, x, y, ra, rb, a0, a1, dest);
        return st ? kernel_fail(f, e, st) : CRISP_OK;
    }
    /* parabola or hyperbola: one rational quadratic through the end points, tangent there */
    double gs[2] = {2 * k[0] * s[0] + k[1] * s[1] + k[3], k[1] * s[0] + 2 * k[2] * s[1] + k[4]};
    double gt[2] = {2 * k[0] * t[0] + k[1] * t[1] + k[3], k[1] * t[0] + 2 * k[2] * t[1] + k[4]};
    double ts[3] = {-gs[1], gs[0], 0}, tt[3] = {-gt[1], gt[0], 0};
    double den = ts[0] * tt[1] - ts[1] * tt[0];
    if (!(fabs(den) > 1e-300))
        return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC,
                                "end tangents are parallel: cannot build the "
                                "conic arc");
    double u = ((t[0] - s[0]) * tt[1] - (t[1] - s[1]) * tt[0]) / den;
    double p1[2] = {s[0] + u * ts[0], s[1] + u * ts[1]};
    double m[2] = {0.5 * (s[0] + t[0]), 0.5 * (s[1] + t[1])};
    double q0 = conic_q(k, m[0], m[1]), q1 = conic_q(k, p1[0], p1[1]);
    double qh = conic_q(k, 0.5 * (m[0] + p1[0]), 0.5 * (m[1] + p1[1]));
    double qa = 2 * q0 - 4 * qh + 2 * q1, qb = -3 * q0 + 4 * qh - q1, root = -1;
    if (fabs(qa) < 1e-300)
        root = qb != 0 ? -q0 / qb : -1;
    else {
        double d = qb * qb - 4 * qa * q0;
        if (d >= 0) {
            double r1 = (-qb - sqrt(d)) / (2 * qa), r2 = (-qb + sqrt(d)) / (2 * qa);
            root = r1 >= 0 && r1 <= 1 ? r1 : r2;
        }
    }
    if (!(root >= 0 && root <= 1))
        return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC, "end points are not on the conic");
    double p0[3] = {s[0], s[1], zt}, p2[3] = {t[0], t[1], zt};
    double pm[3] = {m[0] + root * (p1[0] - m[0]), m[1] + root * (p1[1] - m[1]), zt};
    st = crisp_make_conic_arc(3, p0, ts, p2, tt, pm, dest);
    return st ? kernel_fail(f, e, st) : CRISP_OK;
}

static crisp_status line_110(iges_file *f, int e, crisp_curve **dest)
{
    double v[6], knots[4] = {0, 0, 1, 1};
    crisp_status st = crisp__iges_need(f, e, 6, "a line");
    if (!st) st = read_reals(f, e, 1, 6, v);
    if (st) return st;
    return make_3d(f, e, 1, 2, knots, v, NULL, dest);
}

static crisp_status copious_106(iges_file *f, int e, crisp_curve **dest)
{
    int form = f->ents[e].form, ip, n;
    if (form != 11 && form != 12 && form != 63)
        return crisp__iges_fail(
            f, e, CRISP_ERR_UNSUPPORTED,
            "copious data form %d is not a curve crisp reads (forms 11, 12, 63)", form);
    crisp_status st = crisp__iges_int_range(f, e, 1, 1, 3, &ip);
    if (!st) st = crisp__iges_int_range(f, e, 2, 2, CRISP_MAX_CONTROL_POINTS, &n);
    if (st) return st;
    int per = ip == 1 ? 2 : ip == 2 ? 3 : 6, k0 = ip == 1 ? 4 : 3;
    if ((st = crisp__iges_need(f, e, k0 - 1 + n * per, "the points of a copious data entity")))
        return st;
    double zt = 0;
    if (ip == 1 && (st = crisp__iges_real(f, e, 3, &zt))) return st;
    double *pts = crisp_malloc_array((size_t)n, 3 * sizeof(double));
    double *knots = crisp_malloc_array((size_t)n + 2, sizeof(double));
    if (!pts || !knots) {
        crisp_free(pts);
        crisp_free(knots);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    }
    for (int i = 0; i < n && !st; i++) {
        for (int c = 0; c < 3 && !st; c++) {
            if (ip == 1 && c == 2)
                pts[3 * i + 2] = zt;
            else
                st = crisp__iges_real(f, e, k0 + i * per + c, &pts[3 * i + c]);
        }
    }
    /* chord-length-free uniform parameter: the copious data has none of its own */
    knots[0] = 0;
    for (int i = 0; i < n; i++)
        knots[i + 1] = i;
    knots[n + 1] = n - 1;
    if (!st) st = make_3d(f, e, 1, n, knots, pts, NULL, dest);
    crisp_free(pts);
    crisp_free(knots);
    return st;
}

static crisp_status spline_112(iges_file *f, int e, crisp_curve **dest)
{
    int ctype, h, ndim, n;
    crisp_status st = crisp__iges_int(f, e, 1, &ctype);
    if (!st) st = crisp__iges_int(f, e, 2, &h);
    if (!st) st = crisp__iges_int_range(f, e, 3, 2, 3, &ndim);
    if (!st) st = crisp__iges_int_range(f, e, 4, 1, CRISP_MAX_CONTROL_POINTS / 3, &n);
    if (!st)
        st = crisp__iges_need(f, e, 4 + (n + 1) + 12 * n, "the segments of a parametric spline");
    if (st) return st;
    int count = 3 * n + 1;
    double *t = crisp_malloc_array((size_t)n + 1, sizeof(double));
    double *knots = crisp_malloc_array((size_t)count + 4, sizeof(double));
    double *pts = crisp_calloc_array((size_t)count, 3 * sizeof(double));
    if (!t || !knots || !pts) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    if ((st = read_reals(f, e, 5, n + 1, t))) goto done;
    for (int i = 0; i < n; i++) {
        if (!(t[i + 1] > t[i])) {
            st = crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                  "break points %d and %d are not increasing", i + 1, i + 2);
            goto done;
        }
    }
    /* Segment i: X(s) = a + b s + c s^2 + d s^3, s = t - T(i) in [0, h]. In local u = s / h the
     * power coefficients are a, b h, c h^2, d h^3, whose Bézier points are below. */
    for (int i = 0; i < n; i++) {
        double hh = t[i + 1] - t[i], co[12];
        if ((st = read_reals(f, e, 5 + (n + 1) + 12 * i, 12, co))) goto done;
        for (int c = 0; c < 3; c++) {
            double a = co[4 * c], b = co[4 * c + 1] * hh, cc = co[4 * c + 2] * hh * hh;
            double d = co[4 * c + 3] * hh * hh * hh;
            if (c == 2 && ndim == 2) a = b = cc = d = 0;
            double *p = pts + 3 * (3 * i) + c;
            p[0] = a;
            p[3] = a + b / 3;
            p[6] = a + 2 * b / 3 + cc / 3;
            p[9] = a + b + cc + d;
        }
    }
    for (int k = 0; k < 4; k++)
        knots[k] = t[0], knots[count + k] = t[n];
    for (int i = 1; i < n; i++)
        for (int k = 0; k < 3; k++)
            knots[1 + 3 * i + k] = t[i];
    (void)ctype;
    (void)h;
    st = make_3d(f, e, 3, count, knots, pts, NULL, dest);
done:
    crisp_free(t);
    crisp_free(knots);
    crisp_free(pts);
    return st;
}

static crisp_status bspline_126(iges_file *f, int e, crisp_curve **dest)
{
    int k, m, prop[4];
    crisp_status st = crisp__iges_int_range(f, e, 1, 1, CRISP_MAX_CONTROL_POINTS - 1, &k);
    if (!st) st = crisp__iges_int_range(f, e, 2, 1, CRISP_MAX_DEGREE, &m);
    if (st) return st;
    for (int i = 0; i < 4 && !st; i++)
        st = crisp__iges_int_def(f, e, 3 + i, 0, &prop[i]);
    if (st) return st;
    int count = k + 1, nk = k + m + 2;
    if (count < m + 1)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "%d control points for degree %d: expected at "
                                "least %d",
                                count, m, m + 1);
    int kw = 7 + nk, kp = kw + count, kr = kp + 3 * count;
    if ((st = crisp__iges_need(f, e, kr + 1, "a rational B-spline curve"))) return st;
    double *knots = crisp_malloc_array((size_t)nk, sizeof(double));
    double *w = crisp_malloc_array((size_t)count, sizeof(double));
    double *pts = crisp_malloc_array((size_t)count, 3 * sizeof(double));
    crisp_curve *c = NULL;
    if (!knots || !w || !pts) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    if ((st = read_reals(f, e, 7, nk, knots)) || (st = read_reals(f, e, kw, count, w)) ||
        (st = read_reals(f, e, kp, 3 * count, pts)))
        goto done;
    int rational = 0;
    for (int i = 0; i < count; i++)
        if (w[i] != w[0]) rational = 1;
    if (!rational && w[0] != 1) {
        if (!(w[0] > 0)) rational = 1; /* let the kernel reject it */
    }
    if ((st = make_3d(f, e, m, count, knots, pts, rational ? w : NULL, &c))) goto done;
    double v0, v1, t0, t1;
    if ((st = crisp__iges_real_def(f, e, kr, knots[m], &v0)) ||
        (st = crisp__iges_real_def(f, e, kr + 1, knots[count], &v1)))
        goto done;
    crisp_curve_domain(c, &t0, &t1);
    double eps = 1e-9 * (t1 - t0);
    /* Writers leave garbage here (occ22470.igs: [0, 0] on the knot domain [-1, 0]): a range that
     * is empty once clamped to the knot domain means the whole curve, as other readers take it. */
    if (v0 < t0) v0 = t0;
    if (v1 > t1) v1 = t1;
    if (!(v1 > v0 + eps)) v0 = t0, v1 = t1;
    if (v0 > t0 + eps || v1 < t1 - eps) {
        crisp_curve *trimmed = NULL;
        if ((st = crisp_curve_trim(c, v0, v1, &trimmed))) {
            st = kernel_fail(f, e, st);
            goto done;
        }
        crisp_curve_destroy(c);
        c = trimmed;
    }
    *dest = c;
    c = NULL;
done:
    crisp_curve_destroy(c);
    crisp_free(knots);
    crisp_free(w);
    crisp_free(pts);
    return st;
}

/* ---- dispatch ------------------------------------------------------------------------------- */

crisp_status crisp__iges_curve_convert(iges_file *f, int e, int dim, const iges_xform *parent,
                                       int depth, iges_curves *out)
{
    iges_entity *x = &f->ents[e];
    if (depth > IGES_MAX_DEPTH)
        return crisp__iges_fail(f, e, CRISP_ERR_LIMIT, "curves nested deeper than %d",
                                IGES_MAX_DEPTH);
    if (x->visiting)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "reference cycle: the entity contains itself");
    x->used = 1;
    iges_xform own, total;
    crisp_status st = crisp__iges_entity_xform(f, e, depth + 1, &own);
    if (st) return st;
    if (parent)
        crisp__iges_xform_mul(parent, &own, &total);
    else
        total = own;
    crisp_curve *c = NULL;
    switch (x->type) {
    case 100:
        st = arc_100(f, e, &c);
        break;
    case 104:
        st = conic_104(f, e, &c);
        break;
    case 106:
        st = copious_106(f, e, &c);
        break;
    case 110:
        st = line_110(f, e, &c);
        break;
    case 112:
        st = spline_112(f, e, &c);
        break;
    case 126:
        st = bspline_126(f, e, &c);
        break;
    case 102: {
        int n;
        if ((st = crisp__iges_int_range(f, e, 1, 0, crisp__iges_nparams(f, e) - 1, &n))) return st;
        x->visiting = 1;
        for (int i = 0; i < n && !st; i++) {
            int ch;
            if ((st = crisp__iges_ptr(f, e, 2 + i, 0, &ch))) break;
            int type = f->ents[ch].type;
            if (type == 116) { /* a point in a composite curve contributes nothing */
                f->ents[ch].used = 1;
                continue;
            }
            if (!crisp__iges_is_curve_type(type) && type != 130) {
                st = crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                      "parameter %d: DE %d is entity %d, expected a curve", 2 + i,
                                      iges_de(ch), type);
                break;
            }
            st = crisp__iges_curve_convert(f, ch, dim, &total, depth + 1, out);
        }
        x->visiting = 0;
        return st;
    }
    default:
        return crisp__iges_fail(f, e, CRISP_ERR_UNSUPPORTED, "not a curve type crisp reads");
    }
    if (st) return st;
    return emit(f, e, c, dim, &total, out);
}

static void mark_param(iges_file *f, int e, int k, int depth)
{
    int c;
    if (k > crisp__iges_nparams(f, e)) return;
    if (crisp__iges_ptr(f, e, k, 0, &c)) {
        crisp_error_clear();
        return;
    }
    crisp__iges_mark_used(f, c, depth + 1);
}

void crisp__iges_mark_used(iges_file *f, int e, int depth)
{
    if (depth > IGES_MAX_DEPTH || f->ents[e].used) return;
    f->ents[e].used = 1;
    int n = crisp__iges_nparams(f, e), t = f->ents[e].type;
    if (t == 102)
        for (int k = 2; k <= n; k++)
            mark_param(f, e, k, depth);
    else if (t == 142)
        for (int k = 2; k <= 4; k++)
            mark_param(f, e, k, depth);
    else if (t == 144 || t == 143) { /* surface and boundaries */
        for (int k = 1; k <= n; k++)
            if (k == (t == 144 ? 1 : 2) || k >= 4) mark_param(f, e, k, depth);
    } else if (t == 120 || t == 118)
        for (int k = 1; k <= 2; k++)
            mark_param(f, e, k, depth);
    else if (t == 122)
        mark_param(f, e, 1, depth);
}

/* ---- parameter maps ------------------------------------------------------------------------- */

double crisp__iges_param_map_apply(const iges_param_map *m, double t)
{
    double y = m->scale * t + m->offset;
    if (!m->angular) return y;
    /* A file's angle may stray a little outside [a0, a1]; one far outside (a hostile file) is
     * clamped so the conversion's segment index stays small. */
    double span = m->a1 - m->a0;
    if (!(y >= m->a0 - 2 * span)) y = m->a0 - 2 * span;
    if (!(y <= m->a1 + 2 * span)) y = m->a1 + 2 * span;
    return crisp_angle_to_param(m->a0, m->a1, y);
}

int crisp__iges_param_map_is_identity(const iges_param_map *m)
{
    return !m->angular && m->scale == 1 && m->offset == 0;
}

crisp_status crisp__iges_curve_param_map(iges_file *f, int e, iges_param_map *dest)
{
    *dest = (iges_param_map){.scale = 1};
    if (f->ents[e].type == 100) {
        double v[7];
        crisp_status st = crisp__iges_need(f, e, 7, "a circular arc");
        if (!st) st = read_reals(f, e, 1, 7, v);
        if (st) return st;
        dest->angular = 1;
        arc_angles(v[1], v[2], v + 3, v + 5, &dest->a0, &dest->a1);
    } else if (f->ents[e].type == 102) {
        return crisp__iges_fail(f, e, CRISP_ERR_UNSUPPORTED,
                                "a composite curve as a surface's defining curve");
    }
    return CRISP_OK;
}
