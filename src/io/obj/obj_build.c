/* obj_data -> crisp faces. Free-form elements (Wavefront OBJ 3.0 specification): `cstype [rat]
 * bspline|bezier`; B-spline parm lists are knot vectors (N + deg + 1 values), Bézier parm lists
 * are breakpoints (deg * segments + 1 points; each interior breakpoint becomes a knot of
 * multiplicity deg). A surf's range [s0, s1] x [t0, t1] restricts the surface (knot insertion
 * when it is smaller than the knot domain). `trim`/`hole` statements concatenate pieces
 * (u0, u1, curv2) into one loop each; the keyword, not the winding, says outer or hole.
 * Polygon faces become Catmull-Clark limit patches through the OpenSubdiv shim. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "obj/obj_internal.h"
#ifdef CRISP_HAVE_OSD
#include "crisp/osd.h"
#endif

/* Knot vector of one direction from the parm values; *count_out gets the control-point count
 * the knots imply. knots has room for count + degree + 1 values (caller frees). */
static crisp_status make_knots(const obj_data *d, int type, int degree, obj_span parm,
                               const char *what, int line, double **knots, int *count_out)
{
    *knots = NULL;
    if (parm.off < 0)
        return crisp_error(CRISP_ERR_PARSE,
                           "%s:%d: %s has no 'parm' values (expected a parm "
                           "statement before 'end')",
                           d->name, line, what);
    const double *p = d->reals + parm.off;
    int n = parm.count;
    if (type == OBJ_BEZIER) {
        if (n < 2)
            return crisp_error(CRISP_ERR_PARSE,
                               "%s:%d: %s: Bézier parm needs at least 2 "
                               "breakpoints, found %d",
                               d->name, line, what, n);
        long count = (long)degree * (n - 1) + 1;
        if (count > CRISP_MAX_CONTROL_POINTS)
            return crisp_error(CRISP_ERR_LIMIT, "%s:%d: %s: too many segments", d->name, line,
                               what);
        double *k = crisp_malloc_array((size_t)count + (size_t)degree + 1, sizeof(double));
        if (!k) return crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", d->name, line);
        int m = 0;
        for (int i = 0; i < n; i++) {
            if (i > 0 && !(p[i] > p[i - 1])) {
                crisp_free(k);
                return crisp_error(CRISP_ERR_PARSE,
                                   "%s:%d: %s: Bézier breakpoints must increase "
                                   "(%g after %g)",
                                   d->name, line, what, p[i], p[i - 1]);
            }
            int mult = (i == 0 || i == n - 1) ? degree + 1 : degree;
            for (int r = 0; r < mult; r++)
                k[m++] = p[i];
        }
        *knots = k;
        *count_out = (int)count;
        return CRISP_OK;
    }
    int count = n - degree - 1;
    if (count < degree + 1)
        return crisp_error(CRISP_ERR_PARSE,
                           "%s:%d: %s: %d knots for degree %d (expected at least "
                           "%d)",
                           d->name, line, what, n, degree, 2 * degree + 2);
    for (int i = 1; i < n; i++)
        if (p[i] < p[i - 1])
            return crisp_error(CRISP_ERR_PARSE,
                               "%s:%d: %s: knots must not decrease (%g after %g "
                               "at position %d)",
                               d->name, line, what, p[i], p[i - 1], i + 1);
    double *k = crisp_malloc_array((size_t)n, sizeof(double));
    if (!k) return crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", d->name, line);
    memcpy(k, p, sizeof(double) * (size_t)n);
    *knots = k;
    *count_out = count;
    return CRISP_OK;
}

/* Replace the kernel's w * x (double) by the product formed in long double and rounded once, so
 * the extended-precision Euclidean values crisp_write_obj writes for rational points give back the
 * homogeneous doubles exactly. cpw holds dim coordinates and the weight. */
static void homogenize(const long double *ext, int dim, double *cpw)
{
    long double w = cpw[dim];
    for (int c = 0; c < dim; c++) {
        double y = (double)(ext[c] * w);
        if (isfinite(y)) cpw[c] = y;
    }
}

static crisp_status get_curv2(obj_data *d, int idx, const crisp_curve **dest)
{
    obj_curv2 *c = &d->curv2[idx];
    if (c->curve) {
        *dest = c->curve;
        return CRISP_OK;
    }
    if (c->type == 0)
        return crisp_error(CRISP_ERR_UNSUPPORTED, "%s:%d: curv2 %d has an unsupported cstype",
                           d->name, c->line, idx + 1);
    double *knots = NULL;
    int count = 0;
    crisp_status st = make_knots(d, c->type, c->degree, c->knots, "curv2", c->line, &knots, &count);
    if (st != CRISP_OK) return st;
    if (count != c->refs.count) {
        crisp_free(knots);
        return crisp_error(CRISP_ERR_PARSE,
                           "%s:%d: curv2 has %d control points but its parm u "
                           "values imply %d (degree %d)",
                           d->name, c->line, c->refs.count, count, c->degree);
    }
    double *pts = crisp_malloc_array((size_t)count, 2 * sizeof(double));
    double *w = crisp_malloc_array((size_t)count, sizeof(double));
    if (!pts || !w) {
        crisp_free(knots);
        crisp_free(pts);
        crisp_free(w);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", d->name, c->line);
    }
    for (int i = 0; i < count; i++) {
        const double *vp = d->vp[d->refs[c->refs.off + i]].x;
        pts[2 * i] = vp[0];
        pts[2 * i + 1] = vp[1];
        w[i] = c->rational ? vp[2] : 1.0;
    }
    st = crisp_curve_create(2, c->degree, count, knots, pts, c->rational ? w : NULL, &c->curve);
    if (st == CRISP_OK && c->curve->rational)
        for (int i = 0; i < count; i++)
            homogenize(d->vp[d->refs[c->refs.off + i]].ext, 2, c->curve->cpw + 3 * (size_t)i);
    crisp_free(knots);
    crisp_free(pts);
    crisp_free(w);
    if (st != CRISP_OK) {
        crisp_error_prefix("%s:%d: curv2", d->name, c->line);
        return st;
    }
    *dest = c->curve;
    return CRISP_OK;
}

static void set_color(const obj_data *d, int material, crisp_face *face)
{
    if (material < 0 || material >= d->material_count || !d->materials[material].has_color) return;
    face->has_color = 1;
    memcpy(face->color, d->materials[material].rgba, sizeof face->color);
}

/* ---- restricting a surface to the surf range ------------------------------------------------- */

/* Keep the part of s over [a, b] in one direction (dir 0: u, 1: v), in place, by inserting a and
 * b up to multiplicity degree and dropping the control points outside. */
static crisp_status restrict_dir(crisp_surface *s, int dir, double a, double b)
{
    double dom[4];
    crisp_surface_domain(s, dom);
    double d0 = dom[2 * dir], d1 = dom[2 * dir + 1];
    int cut_lo = a > d0, cut_hi = b < d1;
    if (!cut_lo && !cut_hi) return CRISP_OK;
    int p = dir ? s->degree_v : s->degree_u;
    for (int side = 0; side < 2; side++) {
        if (!(side ? cut_hi : cut_lo)) continue;
        double t = side ? b : a;
        const double *k = dir ? s->knots_v : s->knots_u;
        int n = dir ? s->count_v : s->count_u;
        int mult = 0;
        for (int i = 0; i < n + p + 1; i++)
            mult += k[i] == t;
        if (mult < p) {
            crisp_status st = dir ? crisp_surface_insert_knot_v(s, t, p - mult)
                                  : crisp_surface_insert_knot_u(s, t, p - mult);
            if (st != CRISP_OK) return st;
        }
    }
    double *k = dir ? s->knots_v : s->knots_u;
    int n = dir ? s->count_v : s->count_u;
    /* la: last index of knot a (or p when not cut); fb: first index of b (or n) */
    int la = p, fb = n;
    if (cut_lo)
        for (int i = 0; i < n + p + 1; i++)
            if (k[i] == a) la = i;
    if (cut_hi)
        for (int i = n + p; i >= 0; i--)
            if (k[i] == b) fb = i;
    int first = la - p, count = fb - la + p;
    if (first < 0 || count < p + 1 || first + count > n)
        return crisp_error(CRISP_ERR_INTERNAL, "obj: restricting a surface went wrong");
    /* knots: prefix (p + 1), interior k[la + 1 .. fb - 1], suffix (p + 1) */
    double *nk = crisp_malloc_array((size_t)count + (size_t)p + 1, sizeof(double));
    if (!nk) return crisp_error(CRISP_ERR_NO_MEMORY, "obj: out of memory");
    int m = 0;
    for (int i = 0; i <= p; i++)
        nk[m++] = cut_lo ? a : k[i];
    for (int i = la + 1; i < fb; i++)
        nk[m++] = k[i];
    for (int i = 0; i <= p; i++)
        nk[m++] = cut_hi ? b : k[n + i];
    memcpy(k, nk, sizeof(double) * (size_t)m);
    crisp_free(nk);
    /* control points, compacted in place (new indices never exceed old ones) */
    int cu = s->count_u, cv = s->count_v;
    int nu = dir ? cu : count, nv = dir ? count : cv;
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            int oi = dir ? i : i + first, oj = dir ? j + first : j;
            memmove(s->cpw + ((size_t)j * nu + i) * 4, s->cpw + ((size_t)oj * cu + oi) * 4,
                    4 * sizeof(double));
        }
    s->count_u = nu;
    s->count_v = nv;
    return CRISP_OK;
}

static crisp_status restrict_surface(const obj_data *d, const obj_surf *os, crisp_surface *s)
{
    double dom[4];
    crisp_surface_domain(s, dom);
    double r[4];
    memcpy(r, os->range, sizeof r);
    for (int dir = 0; dir < 2; dir++) {
        double d0 = dom[2 * dir], d1 = dom[2 * dir + 1], eps = 1e-9 * (d1 - d0);
        double *a = &r[2 * dir], *b = &r[2 * dir + 1];
        if (!(*a < *b) || *a < d0 - eps || *b > d1 + eps)
            return crisp_error(CRISP_ERR_PARSE,
                               "%s:%d: surf range %c in [%g, %g] is not an "
                               "interval inside the knot domain [%g, %g]",
                               d->name, os->line, dir ? 't' : 's', *a, *b, d0, d1);
        if (*a < d0 + eps) *a = d0;
        if (*b > d1 - eps) *b = d1;
        crisp_status st = restrict_dir(s, dir, *a, *b);
        if (st != CRISP_OK) {
            crisp_error_prefix("%s:%d: surf", d->name, os->line);
            return st;
        }
    }
    return CRISP_OK;
}

/* ---- surfaces and trims ---------------------------------------------------------------------- */

static crisp_status make_loop(obj_data *d, const obj_loop *ol, crisp_trim_loop *loop)
{
    loop->is_outer = ol->is_outer;
    loop->curve_count = 0;
    loop->curves = crisp_calloc_array((size_t)ol->triples.count, sizeof(crisp_curve *));
    if (!loop->curves) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", d->name);
    for (int i = 0; i < ol->triples.count; i++) {
        const double *t = d->reals + ol->triples.off + 3 * i;
        const crisp_curve *c = NULL;
        crisp_status st = get_curv2(d, (int)t[2], &c);
        if (st != CRISP_OK) return st;
        double c0, c1;
        crisp_curve_domain(c, &c0, &c1);
        double lo = fmin(t[0], t[1]), hi = fmax(t[0], t[1]), eps = 1e-9 * (c1 - c0);
        if (lo < c0 - eps || hi > c1 + eps || !(hi - lo > eps))
            return crisp_error(CRISP_ERR_PARSE,
                               "%s:%d: trim piece %d uses [%g, %g] of curv2 %d "
                               "(expected a non-empty range inside its domain [%g, %g])",
                               d->name, ol->line, i + 1, t[0], t[1], (int)t[2] + 1, c0, c1);
        lo = fmax(lo, c0);
        hi = fmin(hi, c1);
        /* many trims may reuse one long curv2: bound the total, not just each statement */
        d->trim_points += c->count;
        if (d->trim_points > CRISP_MAX_CONTROL_POINTS)
            return crisp_error(CRISP_ERR_LIMIT,
                               "%s:%d: trim loops use more than %d control "
                               "points in all",
                               d->name, ol->line, CRISP_MAX_CONTROL_POINTS);
        crisp_curve *piece = NULL;
        /* the whole curve is copied, not trimmed, so unclamped knots survive a round trip */
        st = (lo == c0 && hi == c1) ? crisp_curve_copy(c, &piece)
                                    : crisp_curve_trim(c, lo, hi, &piece);
        if (st != CRISP_OK) {
            crisp_error_prefix("%s:%d: trim piece %d", d->name, ol->line, i + 1);
            return st;
        }
        if (t[0] > t[1]) crisp_curve_reverse(piece);
        loop->curves[loop->curve_count++] = piece;
    }
    return CRISP_OK;
}

/* Loops that are closed to within rounding and oriented as their keyword says are kept exactly as
 * written: normalising would move rational end points by an ulp and break bit-exact round trips
 * of models that crisp itself wrote. */
static int already_normal(const crisp_face *face, const double dom[4])
{
    double scale =
        fmax(1.0, fmax(fmax(fabs(dom[0]), fabs(dom[1])), fmax(fabs(dom[2]), fabs(dom[3]))));
    for (int i = 0; i < face->loop_count; i++) {
        const crisp_trim_loop *l = &face->loops[i];
        if (crisp_trim_loop_closure_gap(l) > 64 * DBL_EPSILON * scale) return 0;
        double area = crisp_trim_loop_signed_area(l);
        if (l->is_outer ? !(area > 0) : !(area < 0)) return 0;
    }
    return 1;
}

static crisp_status note_dropped(crisp_model *m, const obj_data *d, int line, const char *why)
{
    (void)d;
    return crisp_model_note_dropped(m, "OBJ surf at line %d: %s", line, why);
}

static crisp_status build_surf(obj_data *d, const obj_surf *os, double closure_frac, crisp_model *m)
{
    double *ku = NULL, *kv = NULL, *pts = NULL, *w = NULL;
    int nu = 0, nv = 0;
    crisp_face face = {0};
    face.source_id = os->line;
    set_color(d, os->material, &face);
    crisp_status st =
        make_knots(d, os->type, os->degree_u, os->knots_u, "surf (parm u)", os->line, &ku, &nu);
    if (st == CRISP_OK)
        st =
            make_knots(d, os->type, os->degree_v, os->knots_v, "surf (parm v)", os->line, &kv, &nv);
    if (st != CRISP_OK) goto done;
    if ((long)nu * nv != os->refs.count) {
        st = crisp_error(CRISP_ERR_PARSE,
                         "%s:%d: surf has %d control points but its parm u/v "
                         "values imply %d x %d",
                         d->name, os->line, os->refs.count, nu, nv);
        goto done;
    }
    pts = crisp_malloc_array((size_t)os->refs.count, 3 * sizeof(double));
    w = crisp_malloc_array((size_t)os->refs.count, sizeof(double));
    if (!pts || !w) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", d->name, os->line);
        goto done;
    }
    for (int i = 0; i < os->refs.count; i++) {
        const double *v = d->v[d->refs[os->refs.off + i]].x;
        memcpy(pts + 3 * i, v, 3 * sizeof(double));
        w[i] = os->rational ? v[3] : 1.0;
    }
    st = crisp_surface_create(os->degree_u, os->degree_v, nu, nv, ku, kv, pts,
                              os->rational ? w : NULL, &face.surface);
    if (st == CRISP_OK && face.surface->rational)
        for (int i = 0; i < os->refs.count; i++)
            homogenize(d->v[d->refs[os->refs.off + i]].ext, 3, face.surface->cpw + 4 * (size_t)i);
    if (st != CRISP_OK) {
        crisp_error_prefix("%s:%d: surf", d->name, os->line);
        goto done;
    }
    if ((st = restrict_surface(d, os, face.surface)) != CRISP_OK) goto done;

    if (os->loops.count > 0) {
        face.loops = crisp_calloc_array((size_t)os->loops.count, sizeof(crisp_trim_loop));
        if (!face.loops) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", d->name, os->line);
            goto done;
        }
        for (int i = 0; i < os->loops.count; i++) {
            face.loop_count = i + 1;
            st = make_loop(d, &d->loops[os->loops.off + i], &face.loops[i]);
            if (st == CRISP_ERR_UNSUPPORTED) {
                /* a trim made of curves crisp cannot read (cardinal, taylor, bmatrix) */
                st = note_dropped(m, d, os->line, "trim uses an unsupported curv2 cstype");
                goto done;
            }
            if (st != CRISP_OK) goto done;
        }
        double dom[4];
        crisp_surface_domain(face.surface, dom);
        double tol = closure_frac * fmax(dom[1] - dom[0], dom[3] - dom[2]);
        if (!already_normal(&face, dom) && crisp_face_normalize_loops(&face, tol) != CRISP_OK) {
            st = note_dropped(m, d, os->line, "trim loop not closed");
            goto done;
        }
        for (int i = 0; i < face.loop_count; i++)
            if (crisp_trim_loop_domain_excess(&face.loops[i], dom) > tol) {
                st = note_dropped(m, d, os->line, "trim loop leaves the domain");
                goto done;
            }
    }
    st = crisp_model_add_face(m, &face);
    if (st == CRISP_OK) memset(&face, 0, sizeof face);
done:
    crisp_face_free(&face);
    crisp_free(ku);
    crisp_free(kv);
    crisp_free(pts);
    crisp_free(w);
    return st;
}

/* ---- polygon faces -> Catmull-Clark patches -------------------------------------------------- */

static crisp_status build_polygons(obj_data *d, crisp_model *m)
{
    if (d->poly_count == 0) return CRISP_OK;
#ifndef CRISP_HAVE_OSD
    for (int i = 0; i < d->poly_count; i++) {
        crisp_status st = crisp_model_note_skip(m, "OBJ f: polygon faces need OpenSubdiv "
                                                   "(crisp built without CRISP_OSD)");
        if (st != CRISP_OK) return st;
    }
    return CRISP_OK;
#else
    crisp_status st = CRISP_OK;
    int *map = crisp_malloc_array((size_t)d->v_count, sizeof(int));
    int *sizes = crisp_malloc_array((size_t)d->poly_count, sizeof(int));
    int *fv = crisp_malloc_array((size_t)d->ref_count + 1, sizeof(int));
    int *lines = crisp_malloc_array((size_t)d->poly_count, sizeof(int));
    int *mats = crisp_malloc_array((size_t)d->poly_count, sizeof(int));
    double *pos = crisp_malloc_array((size_t)d->v_count, 3 * sizeof(double));
    crisp_osd_mesh *mesh = NULL;
    if (!map || !sizes || !fv || !lines || !mats || !pos) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", d->name);
        goto done;
    }
    for (int i = 0; i < d->v_count; i++)
        map[i] = -1;
    int nf = 0, nc = 0, nv = 0;
    for (int f = 0; f < d->poly_count; f++) {
        const obj_polygon *p = &d->polys[f];
        const int *r = d->refs + p->refs.off;
        int ok = p->refs.count >= 3 && p->refs.count <= 64;
        for (int a = 0; ok && a < p->refs.count; a++)
            for (int b = 0; b < a; b++)
                if (r[a] == r[b]) ok = 0;
        if (!ok) {
            st = crisp_model_note_skip(m, "OBJ f: degenerate polygon (fewer than 3 or repeated "
                                          "vertices, or more than 64)");
            if (st != CRISP_OK) goto done;
            continue;
        }
        for (int a = 0; a < p->refs.count; a++) {
            if (map[r[a]] < 0) {
                map[r[a]] = nv;
                memcpy(pos + 3 * (size_t)nv, d->v[r[a]].x, 3 * sizeof(double));
                nv++;
            }
            fv[nc++] = map[r[a]];
        }
        lines[nf] = p->line;
        mats[nf] = p->material;
        sizes[nf++] = p->refs.count;
    }
    if (nf == 0) goto done;
    crisp_osd_desc desc = {.vertex_count = nv,
                           .positions = pos,
                           .face_count = nf,
                           .face_sizes = sizes,
                           .face_vertices = fv};
    st = crisp_osd_mesh_create(&desc, &mesh);
    if (st != CRISP_OK) {
        crisp_error_prefix("%s: polygon mesh (f statements from line %d)", d->name, lines[0]);
        goto done;
    }
    for (int p = 0; p < crisp_osd_mesh_patch_count(mesh); p++) {
        crisp_face face = {0};
        int base = 0;
        crisp_osd_mesh_patch_info(mesh, p, &base, NULL, NULL);
        face.source_id = base >= 0 && base < nf ? lines[base] : 0;
        if (base >= 0 && base < nf) set_color(d, mats[base], &face);
        if ((st = crisp_osd_mesh_patch_surface(mesh, p, &face.surface)) != CRISP_OK) goto done;
        if ((st = crisp_model_add_face(m, &face)) != CRISP_OK) {
            crisp_face_free(&face);
            goto done;
        }
    }
done:
    crisp_osd_mesh_destroy(mesh);
    crisp_free(map);
    crisp_free(sizes);
    crisp_free(fv);
    crisp_free(lines);
    crisp_free(mats);
    crisp_free(pos);
    return st;
#endif
}

crisp_status crisp__obj_build(obj_data *d, const crisp_read_options *options, crisp_model *m)
{
    double closure = options && options->closure_tolerance > 0 ? options->closure_tolerance : 1e-6;
    for (int i = 0; i < d->surf_count; i++) {
        crisp_status st = build_surf(d, &d->surfs[i], closure, m);
        if (st != CRISP_OK) return st;
    }
    return build_polygons(d, m);
}
