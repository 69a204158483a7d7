/* IGES faces: 144 trimmed surfaces (142 curves on a surface as outer and inner boundaries), 143
 * bounded surfaces (141 boundaries), 108 bounded planes and independent untrimmed surfaces; the
 * shared steps of every face: parameter-space curves mapped into crisp's (u, v), model-space
 * curves projected (or, on a plane, expressed exactly in the plane's frame), each loop's curves
 * oriented head to tail, colour, and the loop normalisation of model.h. IGES 5.3
 * sections 4.31-4.34.
 */
#include "iges_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/construct.h"

/* ---- colour --------------------------------------------------------------------------------- */

int crisp__iges_entity_color(iges_file *f, int e, float rgba[4])
{
    static const float std[9][3] = {{0, 0, 0}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1},
                                    {1, 1, 0}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};
    int c = f->ents[e].color;
    rgba[3] = 1;
    if (c >= 1 && c <= 8) {
        memcpy(rgba, std[c], 3 * sizeof(float));
        return 1;
    }
    if (c < 0) {
        int d = crisp__iges_index(f, -c);
        if (d < 0 || f->ents[d].type != 314 || crisp__iges_nparams(f, d) < 3) return 0;
        double v[3];
        for (int i = 0; i < 3; i++)
            if (crisp__iges_real(f, d, 1 + i, &v[i])) {
                crisp_error_clear();
                return 0;
            }
        f->ents[d].used = 1;
        for (int i = 0; i < 3; i++) {
            double x = v[i] / 100;
            rgba[i] = (float)(x < 0 ? 0 : x > 1 ? 1 : x);
        }
        return 1;
    }
    return 0;
}

/* ---- loops ---------------------------------------------------------------------------------- */

static void curve_ends(const crisp_curve *c, double *a, double *b)
{
    double t0, t1;
    crisp_curve_domain(c, &t0, &t1);
    crisp_curve_eval(c, t0, a);
    crisp_curve_eval(c, t1, b);
}

static double dist2(const double *a, const double *b)
{
    return hypot(a[0] - b[0], a[1] - b[1]);
}

/* Orient each curve so that it starts where the previous one ends (files list the pieces of a
 * boundary in order but not always in one direction). */
static void orient_chain(iges_curves *l)
{
    if (l->count < 2) return;
    double s0[2], e0[2], s1[2], e1[2];
    curve_ends(l->items[0], s0, e0);
    curve_ends(l->items[1], s1, e1);
    double keep = fmin(dist2(e0, s1), dist2(e0, e1)), flip = fmin(dist2(s0, s1), dist2(s0, e1));
    if (flip < keep) crisp_curve_reverse(l->items[0]);
    for (int k = 1; k < l->count; k++) {
        double prev_s[2], prev_e[2], a[2], b[2];
        curve_ends(l->items[k - 1], prev_s, prev_e);
        curve_ends(l->items[k], a, b);
        if (dist2(prev_e, b) < dist2(prev_e, a)) crisp_curve_reverse(l->items[k]);
    }
}

static void surface_domain_size(const crisp_surface *s, double dom[4], double *size)
{
    crisp_surface_domain(s, dom);
    *size = fmax(dom[1] - dom[0], dom[3] - dom[2]);
}

/* The model's bounding-box diagonal, from every surface a face uses (first call only). */
static crisp_status ensure_tol3d(iges_file *f)
{
    if (f->tol3d > 0) return CRISP_OK;
    double box[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < f->entity_count; i++) {
        int t = f->ents[i].type;
        int analytic = t >= 192 && t <= 198 && t % 2 == 0;
        if (t != 128 && t != 114 && t != 118 && t != 120 && t != 122 && !analytic) continue;
        iges_surface s;
        int used = f->ents[i].used;
        if (crisp__iges_surface_convert(f, i, 0, &s)) {
            crisp_error_clear();
            continue;
        }
        f->ents[i].used = used;
        double b[6];
        if (analytic) { /* unbounded: the ball of its radii around its location */
            double r = s.radius + s.radius2;
            for (int k = 0; k < 3; k++)
                b[k] = s.origin[k] - r, b[3 + k] = s.origin[k] + r;
        } else {
            crisp_surface_bbox(s.surface, b);
        }
        for (int k = 0; k < 3; k++) {
            box[k] = fmin(box[k], b[k]);
            box[3 + k] = fmax(box[3 + k], b[3 + k]);
        }
        crisp__iges_surface_free(&s);
    }
    double d = box[3] > box[0] ? sqrt((box[3] - box[0]) * (box[3] - box[0]) +
                                      (box[4] - box[1]) * (box[4] - box[1]) +
                                      (box[5] - box[2]) * (box[5] - box[2]))
                               : 1;
    f->tol3d = f->projection_fraction * (d > 0 ? d : 1);
    return CRISP_OK;
}

crisp_status crisp__iges_project_curves(iges_file *f, int e, const iges_surface *s,
                                        const iges_curves *model, iges_curves *uv)
{
    crisp_status st = CRISP_OK;
    for (int i = 0; i < model->count && !st; i++) {
        const crisp_curve *c = model->items[i];
        crisp_curve *out = NULL;
        if (s->analytic && !s->surface) {
            /* kept in 3D: the surface is built over the region the loops reach (finish_analytic) */
            st = crisp_curve_copy(c, &out);
        } else if (s->is_plane) {
            /* exact: an affine map of the homogeneous control points into the plane's frame */
            int n = c->count;
            double *pts = crisp_malloc_array((size_t)n, 2 * sizeof(double));
            double *w = crisp_malloc_array((size_t)n, sizeof(double));
            if (!pts || !w) st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
            for (int k = 0; k < n && !st; k++) {
                const double *p = c->cpw + 4 * k;
                double q[3] = {p[0] / p[3] - s->origin[0], p[1] / p[3] - s->origin[1],
                               p[2] / p[3] - s->origin[2]};
                pts[2 * k] = crisp_vec3_dot(q, s->x) / crisp_vec3_dot(s->x, s->x);
                pts[2 * k + 1] = crisp_vec3_dot(q, s->y) / crisp_vec3_dot(s->y, s->y);
                w[k] = p[3];
            }
            if (!st)
                st = crisp_curve_create(2, c->degree, n, c->knots, pts, c->rational ? w : NULL,
                                        &out);
            crisp_free(pts);
            crisp_free(w);
        } else {
            if ((st = ensure_tol3d(f))) break;
            double t0, t1;
            crisp_curve_domain(c, &t0, &t1);
            st = crisp_surface_project_curve(s->surface, c, t0, t1, f->tol3d, &out);
        }
        if (st) {
            crisp_error_prefix("%s: DE %d (entity %d %s)", f->name, iges_de(e), f->ents[e].type,
                               crisp__iges_type_name(f->ents[e].type));
            break;
        }
        st = crisp__iges_curves_push(uv, out);
    }
    return st;
}

/* A 142 curve on a surface: its parameter-space curve B mapped into crisp's (u, v) when present,
 * else its model-space curve C projected onto the surface. */
static crisp_status curve_on_surface(iges_file *f, int e, const iges_surface *s, double tol_uv,
                                     iges_curves *uv)
{
    int sp, bp, cp;
    crisp_status st = crisp__iges_need(f, e, 4, "a curve on a parametric surface");
    if (!st) st = crisp__iges_ptr(f, e, 2, 1, &sp);
    if (!st) st = crisp__iges_ptr(f, e, 3, 1, &bp);
    if (!st) st = crisp__iges_ptr(f, e, 4, 1, &cp);
    if (st) return st;
    f->ents[e].used = 1;
    if (bp >= 0 && !crisp__iges_is_curve_type(f->ents[bp].type) && f->ents[bp].type != 130)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter 3: DE %d is entity %d, expected a "
                                "curve",
                                iges_de(bp), f->ents[bp].type);
    if (cp >= 0 && !crisp__iges_is_curve_type(f->ents[cp].type) && f->ents[cp].type != 130)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter 4: DE %d is entity %d, expected a "
                                "curve",
                                iges_de(cp), f->ents[cp].type);
    if (bp >= 0 && !s->is_plane && !s->analytic) {
        int first = uv->count;
        st = crisp__iges_curve_convert(f, bp, 2, NULL, 1, uv);
        if (st == CRISP_ERR_UNSUPPORTED && cp >= 0) {
            /* a parameter-space curve crisp cannot read: fall back to projecting C */
            crisp_error_clear();
            while (uv->count > first)
                crisp_curve_destroy(uv->items[--uv->count]);
        } else {
            if (st) return st;
            if (cp >= 0) crisp__iges_mark_used(f, cp, 0);
            for (int i = first; i < uv->count && !st; i++) {
                st = crisp__iges_surface_map_curve(s, tol_uv, &uv->items[i]);
                if (st) crisp_error_prefix("%s: DE %d (entity 142)", f->name, iges_de(e));
            }
            return st;
        }
    }
    if (cp < 0)
        return s->is_plane || s->analytic
                   ? crisp__iges_fail(
                         f, e, CRISP_ERR_UNSUPPORTED,
                         "a curve on a plane or an analytic surface without its model-space "
                         "curve (parameter 4)")
                   : crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                      "neither a parameter-space nor a model-space curve");
    if (bp >= 0) crisp__iges_mark_used(f, bp, 0);
    iges_curves model = {0};
    st = crisp__iges_curve_convert(f, cp, 3, NULL, 1, &model);
    if (!st) st = crisp__iges_project_curves(f, e, s, &model, uv);
    crisp__iges_curves_free(&model);
    return st;
}

/* Size a plane from its loops (with a small margin) and build its NURBS. */
static crisp_status finish_plane(iges_file *f, int e, iges_surface *s, iges_curves *loops,
                                 int loop_count)
{
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int l = 0; l < loop_count; l++)
        for (int i = 0; i < loops[l].count; i++) {
            double b[4];
            crisp_curve_bbox(loops[l].items[i], b);
            lo[0] = fmin(lo[0], b[0]);
            lo[1] = fmin(lo[1], b[1]);
            hi[0] = fmax(hi[0], b[2]);
            hi[1] = fmax(hi[1], b[3]);
        }
    if (!(hi[0] > lo[0]) || !(hi[1] > lo[1]))
        return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC, "plane bounded by a degenerate loop");
    double m0 = 0.01 * (hi[0] - lo[0]), m1 = 0.01 * (hi[1] - lo[1]);
    crisp_placement pl;
    memcpy(pl.origin, s->origin, sizeof pl.origin);
    memcpy(pl.x, s->x, sizeof pl.x);
    memcpy(pl.y, s->y, sizeof pl.y);
    crisp_vec3_cross(pl.x, pl.y, pl.z);
    crisp_status st =
        crisp_make_plane(&pl, lo[0] - m0, hi[0] + m0, lo[1] - m1, hi[1] + m1, &s->surface);
    if (st) crisp_error_prefix("%s: DE %d (entity %d)", f->name, iges_de(e), f->ents[e].type);
    return st;
}

static crisp_status pull_into_domain(iges_file *f, int e, crisp_face *face, const double dom[4],
                                     double size);

static void note_dropped(iges_file *f, int e, const char *why)
{
    crisp_model_note_dropped(f->model, "DE %d entity %d %s: %s", iges_de(e), f->ents[e].type,
                             crisp__iges_type_name(f->ents[e].type), why);
}

/* Length of a trim curve's control polygon (Euclidean points). */
static double polygon_length(const crisp_curve *c)
{
    double len = 0;
    for (int k = 0; k + 1 < c->count; k++) {
        const double *a = c->cpw + 3 * k, *b = c->cpw + 3 * (k + 1);
        len += hypot(b[0] / b[2] - a[0] / a[2], b[1] / b[2] - a[1] / a[2]);
    }
    return len;
}

/* Exporters leave small gaps between the trims of a loop (OCCT's bug8363_f45.igs: 7e-4 and 1.6e-3
 * of the domain, 15x and 33x the closure tolerance): a gap between tol and max_gap (1e-2 of the
 * domain size) is bridged by a straight (u, v) segment, as CAD healing tools do, and noted.
 * Larger gaps are bridged too when each is real in 3D (its ends more than 10x the projection
 * tolerance apart on the surface) and the bridges make up less than half of the loop, the STEP
 * reader's rule for loops the file leaves open (bug22566_test_Bad.igs DE 351: a quarter sphere
 * whose pcurves give three sides of its (u, v) rectangle; Open CASCADE closes it the same way);
 * else the face is dropped. */
static crisp_status bridge_gaps(iges_file *f, int e, crisp_face *face, double tol, double max_gap)
{
    int bridged = 0, large = 0;
    for (int l = 0; l < face->loop_count; l++) {
        crisp_trim_loop *t = &face->loops[l];
        /* Gaps beyond max_gap: all real in 3D and under half the loop, or none bridged. */
        double total = 0, over = 0, limit = max_gap;
        int real = 1, n_over = 0;
        for (int c = 0; c < t->curve_count; c++) {
            double a[2], b[2], junk[2], pa[3], pb[3], d3[3];
            total += polygon_length(t->curves[c]);
            curve_ends(t->curves[c], junk, a);
            curve_ends(t->curves[(c + 1) % t->curve_count], b, junk);
            double gap = dist2(a, b);
            if (!(gap > max_gap)) continue;
            n_over++;
            over += gap;
            crisp_surface_eval(face->surface, a[0], a[1], pa);
            crisp_surface_eval(face->surface, b[0], b[1], pb);
            crisp_vec3_sub(pa, pb, d3);
            if (!(crisp_vec3_norm(d3) > 10 * f->tol3d)) real = 0;
        }
        if (n_over && real && over < 0.5 * (total + over)) limit = INFINITY, large++;
        for (int c = 0; c < t->curve_count; c++) {
            double a[2], b[2], junk[2];
            curve_ends(t->curves[c], junk, a);
            curve_ends(t->curves[(c + 1) % t->curve_count], b, junk);
            double gap = dist2(a, b);
            if (!(gap > tol) || !(gap <= limit)) continue;
            double pts[4] = {a[0], a[1], b[0], b[1]}, knots[4] = {0, 0, 1, 1};
            crisp_curve *line = NULL;
            crisp_status st = crisp_curve_create(2, 1, 2, knots, pts, NULL, &line);
            crisp_curve **grown =
                st ? NULL
                   : crisp_realloc_array(t->curves, (size_t)t->curve_count + 1, sizeof *grown);
            if (!grown) {
                crisp_curve_destroy(line);
                return st ? st : crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
            }
            t->curves = grown;
            memmove(&t->curves[c + 2], &t->curves[c + 1],
                    (size_t)(t->curve_count - c - 1) * sizeof *t->curves);
            t->curves[c + 1] = line;
            t->curve_count++;
            c++;
            bridged++;
        }
    }
    if (large) /* kept: a note, not a dropped face */
        crisp_model_note_skipf(f->model,
                               "DE %d entity %d %s: trim loop left open by the file (a gap of "
                               "more than 1/100 of its domain): closed by straight (u, v) segments",
                               iges_de(e), f->ents[e].type, crisp__iges_type_name(f->ents[e].type));
    else if (bridged)
        crisp_model_note_skipf(
            f->model, "DE %d entity %d %s: gaps in its trim loops bridged by straight segments",
            iges_de(e), f->ents[e].type, crisp__iges_type_name(f->ents[e].type));
    return CRISP_OK;
}

/* ---- 192-198 analytic surfaces, built over the region their loops reach -----------------------
 */

/* (angle, height) of p on analytic surface s (see construct.h's conventions). */
static void analytic_coords(const iges_surface *s, const double p[3], double uv[2])
{
    double q[3], z[3];
    crisp_vec3_sub(p, s->origin, q);
    crisp_vec3_cross(s->x, s->y, z);
    double X = crisp_vec3_dot(q, s->x), Y = crisp_vec3_dot(q, s->y), Z = crisp_vec3_dot(q, z);
    double rho = hypot(X, Y);
    uv[0] = atan2(Y, X);
    switch (s->analytic) {
    case 192:
        uv[1] = Z;
        break;
    case 194: { /* foot of the perpendicular on the generating line */
        double c = cos(s->semi), sn = sin(s->semi);
        uv[1] = (rho - s->radius) * sn * c + Z * c * c;
        break;
    }
    case 196:
        uv[1] = atan2(Z, rho);
        break;
    default:
        uv[1] = atan2(Z, rho - s->radius);
        break;
    }
}

static int cmp_angle(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The window [lo, lo + span] of the circle that holds every angle in a[0 .. n-1]: the complement
 * of the largest gap between them (sorted in place), with a margin. */
static void angle_window(double *a, int n, double w[2])
{
    qsort(a, (size_t)n, sizeof *a, cmp_angle);
    double gap = a[0] + 2 * M_PI - a[n - 1], start = a[0];
    for (int i = 1; i < n; i++)
        if (a[i] - a[i - 1] > gap) gap = a[i] - a[i - 1], start = a[i];
    double span = 2 * M_PI - gap;
    double m = fmin(0.01 * span + 1e-9, 0.5 * gap);
    if (gap < 1e-6) { /* the loops go all the way round */
        w[0] = start, w[1] = start + 2 * M_PI;
        return;
    }
    w[0] = start - m, w[1] = start + span + m;
}

#define ANALYTIC_SAMPLES 64

static crisp_status finish_analytic(iges_file *f, int e, iges_surface *s, iges_curves *loops,
                                    int loop_count)
{
    int total = 0;
    for (int l = 0; l < loop_count; l++)
        total += loops[l].count;
    if (total == 0)
        return crisp__iges_fail(f, e, CRISP_ERR_NUMERIC, "analytic surface without trim curves");
    size_t n = (size_t)total * (ANALYTIC_SAMPLES + 1);
    double *us = crisp_malloc_array(n, sizeof *us), *vs = crisp_malloc_array(n, sizeof *vs);
    if (!us || !vs) {
        crisp_free(us);
        crisp_free(vs);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    }
    size_t k = 0;
    double vlo = INFINITY, vhi = -INFINITY;
    for (int l = 0; l < loop_count; l++)
        for (int i = 0; i < loops[l].count; i++) {
            const crisp_curve *c = loops[l].items[i];
            double t0, t1;
            crisp_curve_domain(c, &t0, &t1);
            for (int j = 0; j <= ANALYTIC_SAMPLES; j++) {
                double p[3], uv[2];
                crisp_curve_eval(c, t0 + (t1 - t0) * j / ANALYTIC_SAMPLES, p);
                analytic_coords(s, p, uv);
                us[k] = uv[0];
                vs[k++] = uv[1];
                vlo = fmin(vlo, uv[1]);
                vhi = fmax(vhi, uv[1]);
            }
        }
    double uw[2], vw[2];
    angle_window(us, (int)k, uw);
    if (s->analytic == 198) {
        angle_window(vs, (int)k, vw);
    } else {
        double m = 0.01 * (vhi - vlo) + 1e-9 * (fabs(vlo) + fabs(vhi) + s->radius);
        vw[0] = vlo - m, vw[1] = vhi + m;
        if (s->analytic == 196) vw[0] = fmax(vw[0], -M_PI / 2), vw[1] = fmin(vw[1], M_PI / 2);
        if (s->analytic == 194) {
            double apex = -s->radius / tan(s->semi);
            if (vlo >= apex - 1e-9 * (fabs(apex) + 1)) vw[0] = fmax(vw[0], apex);
        }
    }
    crisp_free(us);
    crisp_free(vs);
    crisp_placement pl;
    memcpy(pl.origin, s->origin, sizeof pl.origin);
    memcpy(pl.x, s->x, sizeof pl.x);
    memcpy(pl.y, s->y, sizeof pl.y);
    crisp_vec3_cross(pl.x, pl.y, pl.z);
    crisp_status st;
    switch (s->analytic) {
    case 192:
        st = crisp_make_cylinder(&pl, s->radius, uw[0], uw[1], vw[0], vw[1], &s->surface);
        break;
    case 194:
        st = crisp_make_cone(&pl, s->radius, s->semi, uw[0], uw[1], vw[0], vw[1], &s->surface);
        break;
    case 196:
        st = crisp_make_sphere(&pl, s->radius, uw[0], uw[1], vw[0], vw[1], &s->surface);
        break;
    default:
        st = crisp_make_torus(&pl, s->radius, s->radius2, uw[0], uw[1], vw[0], vw[1], &s->surface);
        break;
    }
    if (st) {
        crisp_error_prefix("%s: DE %d (entity %d)", f->name, iges_de(e), f->ents[e].type);
        return st;
    }
    /* The loops' 3D curves onto the surface now built (pieces where the projection jumps: a
     * curve through a cone's apex or a sphere's pole). */
    if ((st = ensure_tol3d(f))) return st;
    for (int l = 0; l < loop_count; l++) {
        iges_curves uv = {0};
        for (int i = 0; i < loops[l].count && !st; i++) {
            const crisp_curve *c = loops[l].items[i];
            double t0, t1;
            crisp_curve_domain(c, &t0, &t1);
            crisp_curve *pieces[8];
            int np = 0;
            st =
                crisp_surface_project_curve_pieces(s->surface, c, t0, t1, f->tol3d, 8, pieces, &np);
            for (int q = 0; q < np; q++) {
                if (!st)
                    st = crisp__iges_curves_push(&uv, pieces[q]);
                else
                    crisp_curve_destroy(pieces[q]);
            }
        }
        if (st) {
            crisp__iges_curves_free(&uv);
            crisp_error_prefix("%s: DE %d (entity %d %s)", f->name, iges_de(e), f->ents[e].type,
                               crisp__iges_type_name(f->ents[e].type));
            return st;
        }
        crisp__iges_curves_free(&loops[l]);
        loops[l] = uv;
    }
    return CRISP_OK;
}

crisp_status crisp__iges_finish_face(iges_file *f, int e, int surf_e, iges_surface *s,
                                     iges_curves *loops, const int *is_outer, int loop_count,
                                     int reversed)
{
    crisp_status st = CRISP_OK;
    if (s->is_plane && !s->surface && (st = finish_plane(f, e, s, loops, loop_count))) return st;
    if (s->analytic && !s->surface && (st = finish_analytic(f, e, s, loops, loop_count))) return st;
    crisp_face face = {0};
    face.source_id = iges_de(e);
    face.reversed = reversed;
    face.has_color = crisp__iges_entity_color(f, e, face.color);
    if (!face.has_color && surf_e >= 0)
        face.has_color = crisp__iges_entity_color(f, surf_e, face.color);
    int n = 0;
    for (int l = 0; l < loop_count; l++)
        if (loops[l].count > 0) n++;
    if (n > 0) {
        face.loops = crisp_calloc_array((size_t)n, sizeof *face.loops);
        if (!face.loops) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    }
    for (int l = 0; l < loop_count; l++) {
        if (loops[l].count == 0) continue;
        orient_chain(&loops[l]);
        crisp_trim_loop *t = &face.loops[face.loop_count++];
        t->is_outer = is_outer[l];
        t->curve_count = loops[l].count;
        t->curves = loops[l].items;
        loops[l].items = NULL;
        loops[l].count = loops[l].cap = 0;
    }
    face.surface = s->surface;
    s->surface = NULL;
    double dom[4], size;
    surface_domain_size(face.surface, dom, &size);
    double tol = f->closure_fraction * size;
    if ((st = ensure_tol3d(f))) {
        crisp_face_free(&face);
        return st;
    }
    /* Files close loops in model space: a (u, v) gap whose two ends map to points closer than
     * 10x the projection tolerance (1e-4 of the bounding-box diagonal by default) is closed too.
     * Real files need it: impeller.igs (SolidWorks) leaves gaps of up to 6 um on a 210 mm part,
     * 1e-4 of the (u, v) domain, where its pcurves meet. */
    for (int l = 0; l < face.loop_count; l++) {
        const crisp_trim_loop *t = &face.loops[l];
        for (int c = 0; c < t->curve_count; c++) {
            double a[2], b[2], junk[2], pa[3], pb[3];
            curve_ends(t->curves[c], junk, a);
            curve_ends(t->curves[(c + 1) % t->curve_count], b, junk);
            double gap = dist2(a, b);
            if (!(gap > tol)) continue;
            crisp_surface_eval(face.surface, a[0], a[1], pa);
            crisp_surface_eval(face.surface, b[0], b[1], pb);
            double d3[3];
            crisp_vec3_sub(pa, pb, d3);
            if (crisp_vec3_norm(d3) <= 10 * f->tol3d) tol = gap * (1 + 1e-9);
        }
    }
    if ((st = bridge_gaps(f, e, &face, tol, 1e-2 * size))) {
        crisp_face_free(&face);
        return st;
    }
    if ((st = pull_into_domain(f, e, &face, dom, size))) {
        crisp_face_free(&face);
        return st;
    }
    st = crisp_face_normalize_loops(&face, tol);
    if (st) {
        /* A loop that cannot be made valid drops the face, with a note naming it. */
        note_dropped(f, e,
                     st == CRISP_ERR_NUMERIC ? "degenerate trim loop" : "trim loop not closed");
        crisp_error_clear();
        crisp_face_free(&face);
        return CRISP_OK;
    }
    face.body = f->body; /* its solid or shell (crisp_model_gaps compares within one) */
    return crisp_model_add_face(f->model, &face);
}

static double polygon_excess(const crisp_curve *c, const double dom[4])
{
    double worst = 0;
    for (int i = 0; i < c->count; i++) {
        const double *q = c->cpw + 3 * i;
        double u = q[0] / q[2], v = q[1] / q[2];
        worst = fmax(worst, fmax(fmax(dom[0] - u, u - dom[1]), fmax(dom[2] - v, v - dom[3])));
    }
    return worst;
}

/* model.h wants every loop's control polygons inside the domain. A trim whose polygon leaves the
 * domain while the curve stays inside (occt_bearing.iges: 2% of the domain) is refined by knot
 * insertion, which keeps the curve and pulls the polygon onto it; control points then left
 * outside by at most 1e-4 of the domain size (the curve itself dips that far: occt_hammer.iges)
 * are moved onto the domain's edge. */
static crisp_status pull_into_domain(iges_file *f, int e, crisp_face *face, const double dom[4],
                                     double size)
{
    double eps = 1e-4 * size;
    for (int l = 0; l < face->loop_count; l++) {
        const crisp_trim_loop *t = &face->loops[l];
        for (int c = 0; c < t->curve_count; c++) {
            crisp_curve *cv = t->curves[c];
            for (int round = 0; round < 6 && polygon_excess(cv, dom) > eps; round++) {
                if (cv->count > 4096) break;
                int spans = cv->count - cv->degree;
                double *mid = crisp_malloc_array((size_t)spans, sizeof *mid);
                if (!mid) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
                int n = 0;
                for (int k = cv->degree; k < cv->count; k++) {
                    if (!(cv->knots[k + 1] > cv->knots[k])) continue;
                    /* only spans whose control points (k - p .. k) leave the domain */
                    int out = 0;
                    for (int i = k - cv->degree; i <= k && !out; i++) {
                        const double *q = cv->cpw + 3 * i;
                        double u = q[0] / q[2], v = q[1] / q[2];
                        out =
                            fmax(fmax(dom[0] - u, u - dom[1]), fmax(dom[2] - v, v - dom[3])) > eps;
                    }
                    if (out) mid[n++] = 0.5 * (cv->knots[k] + cv->knots[k + 1]);
                }
                crisp_status st = CRISP_OK;
                for (int k = 0; k < n && !st; k++)
                    st = crisp_curve_insert_knot(cv, mid[k], 1);
                crisp_free(mid);
                if (st) {
                    crisp_error_prefix("%s: DE %d", f->name, iges_de(e));
                    return st;
                }
            }
            for (int i = 0; i < cv->count; i++) {
                double *q = cv->cpw + 3 * i;
                for (int k = 0; k < 2; k++) {
                    double x = q[k] / q[2], lo = dom[2 * k], hi = dom[2 * k + 1];
                    if (x < lo && x >= lo - eps)
                        q[k] = lo * q[2];
                    else if (x > hi && x <= hi + eps)
                        q[k] = hi * q[2];
                }
            }
        }
    }
    return CRISP_OK;
}

static double uv_tolerance(const iges_surface *s)
{
    double dom[4], size;
    surface_domain_size(s->surface, dom, &size);
    return 1e-6 * size;
}

crisp_status crisp__iges_domain_loop(const iges_surface *s, iges_curves *out)
{
    double d[4], c[5][2];
    if (!s->surface)
        return crisp_error(CRISP_ERR_UNSUPPORTED,
                           "an unbounded plane or analytic surface without an outer boundary");
    if (s->narrowed)
        memcpy(d, s->range, sizeof d);
    else
        crisp_surface_domain(s->surface, d);
    double xs[5] = {d[0], d[1], d[1], d[0], d[0]}, ys[5] = {d[2], d[2], d[3], d[3], d[2]};
    for (int i = 0; i < 5; i++)
        c[i][0] = xs[i], c[i][1] = ys[i];
    for (int i = 0; i < 4; i++) {
        double pts[4] = {c[i][0], c[i][1], c[i + 1][0], c[i + 1][1]}, knots[4] = {0, 0, 1, 1};
        crisp_curve *cv = NULL;
        crisp_status st = crisp_curve_create(2, 1, 2, knots, pts, NULL, &cv);
        if (!st) st = crisp__iges_curves_push(out, cv);
        if (st) return st;
    }
    return CRISP_OK;
}

/* ---- 144 trimmed surface -------------------------------------------------------------------- */

crisp_status crisp__iges_face_trimmed(iges_file *f, int e)
{
    int sp, n1, n2, pto;
    crisp_status st = crisp__iges_need(f, e, 4, "a trimmed surface");
    if (!st) st = crisp__iges_ptr(f, e, 1, 0, &sp);
    if (!st) st = crisp__iges_int_range(f, e, 2, 0, 1, &n1);
    if (!st) st = crisp__iges_int_range(f, e, 3, 0, crisp__iges_nparams(f, e) - 4, &n2);
    if (!st) st = crisp__iges_ptr(f, e, 4, 1, &pto);
    if (st) return st;
    f->ents[e].used = 1;
    if (!crisp__iges_is_surface_type(f->ents[sp].type)) {
        int t = f->ents[sp].type;
        if (t == 140 || t == 143 || (t >= 192 && t <= 198)) {
            char why[80];
            snprintf(why, sizeof why, "its surface (entity %d %s) is not supported", t,
                     crisp__iges_type_name(t));
            note_dropped(f, e, why);
            return CRISP_OK;
        }
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter 1: DE %d is entity %d, expected a "
                                "surface",
                                iges_de(sp), f->ents[sp].type);
    }
    iges_surface s;
    if ((st = crisp__iges_surface_convert(f, sp, 1, &s))) {
        if (st == CRISP_ERR_UNSUPPORTED) {
            note_dropped(f, e, "its surface uses unsupported geometry");
            crisp_error_clear();
            return CRISP_OK;
        }
        return st;
    }
    int nl = 1 + n2;
    iges_curves *loops = crisp_calloc_array((size_t)nl, sizeof *loops);
    int *outer = crisp_calloc_array((size_t)nl, sizeof *outer);
    if (!loops || !outer) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    double tol_uv = s.surface ? uv_tolerance(&s) : 0;
    outer[0] = 1;
    if (n1 == 1 && pto >= 0) {
        if (f->ents[pto].type != 142) {
            st = crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                  "parameter 4: DE %d is entity %d, expected 142", iges_de(pto),
                                  f->ents[pto].type);
            goto done;
        }
        st = curve_on_surface(f, pto, &s, tol_uv, &loops[0]);
    } else if (s.is_plane || s.analytic) {
        note_dropped(f, e,
                     s.is_plane ? "unbounded plane"
                                : "unbounded analytic surface (no outer boundary)");
        goto done;
    } else if (n2 > 0 || s.narrowed) {
        st = crisp__iges_domain_loop(&s, &loops[0]);
    }
    for (int i = 0; i < n2 && !st; i++) {
        int b;
        if ((st = crisp__iges_ptr(f, e, 5 + i, 0, &b))) break;
        if (f->ents[b].type != 142) {
            st = crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                  "parameter %d: DE %d is entity %d, expected 142", 5 + i,
                                  iges_de(b), f->ents[b].type);
            break;
        }
        st = curve_on_surface(f, b, &s, tol_uv, &loops[1 + i]);
    }
    if (st == CRISP_ERR_UNSUPPORTED) {
        note_dropped(f, e, "a trim curve uses unsupported geometry");
        crisp_error_clear();
        st = CRISP_OK;
        goto done;
    }
    if (!st) st = crisp__iges_finish_face(f, e, sp, &s, loops, outer, nl, 0);
done:
    for (int i = 0; loops && i < nl; i++)
        crisp__iges_curves_free(&loops[i]);
    crisp_free(loops);
    crisp_free(outer);
    crisp__iges_surface_free(&s);
    return st;
}

/* ---- 143 bounded surface (141 boundaries) --------------------------------------------------- */

/* One 141 boundary into a chain of (u, v) curves: parameter-space curves when the boundary has
 * them (type 1), else its model-space curves projected, each oriented by its sense flag. */
static crisp_status boundary_141(iges_file *f, int e, const iges_surface *s, double tol_uv,
                                 iges_curves *uv)
{
    int type, pref, sp, n;
    crisp_status st = crisp__iges_need(f, e, 4, "a boundary");
    if (!st) st = crisp__iges_int_range(f, e, 1, 0, 1, &type);
    if (!st) st = crisp__iges_int_def(f, e, 2, 0, &pref);
    if (!st) st = crisp__iges_ptr(f, e, 3, 0, &sp);
    if (!st) st = crisp__iges_int_range(f, e, 4, 1, crisp__iges_nparams(f, e), &n);
    if (st) return st;
    f->ents[e].used = 1;
    int k = 5;
    for (int i = 0; i < n && !st; i++) {
        int cp, sense, np;
        if ((st = crisp__iges_ptr(f, e, k, 0, &cp)) ||
            (st = crisp__iges_int_range(f, e, k + 1, 1, 2, &sense)) ||
            (st = crisp__iges_int_range(f, e, k + 2, 0, crisp__iges_nparams(f, e) - k - 2, &np)))
            break;
        int first = uv->count;
        if (type == 1 && np > 0 && !s->is_plane && !s->analytic) {
            for (int j = 0; j < np && !st; j++) {
                int pc;
                if ((st = crisp__iges_ptr(f, e, k + 3 + j, 0, &pc))) break;
                st = crisp__iges_curve_convert(f, pc, 2, NULL, 1, uv);
            }
            for (int j = first; j < uv->count && !st; j++)
                st = crisp__iges_surface_map_curve(s, tol_uv, &uv->items[j]);
        } else {
            iges_curves model = {0};
            st = crisp__iges_curve_convert(f, cp, 3, NULL, 1, &model);
            if (!st) st = crisp__iges_project_curves(f, e, s, &model, uv);
            crisp__iges_curves_free(&model);
        }
        if (!st && sense == 2) {
            /* reversed: reverse the order of this curve's pieces and each piece */
            for (int a = first, b = uv->count - 1; a < b; a++, b--) {
                crisp_curve *t = uv->items[a];
                uv->items[a] = uv->items[b];
                uv->items[b] = t;
            }
            for (int j = first; j < uv->count; j++)
                crisp_curve_reverse(uv->items[j]);
        }
        k += 3 + np;
    }
    (void)pref;
    return st;
}

crisp_status crisp__iges_face_bounded(iges_file *f, int e)
{
    int type, sp, n;
    crisp_status st = crisp__iges_need(f, e, 3, "a bounded surface");
    if (!st) st = crisp__iges_int_range(f, e, 1, 0, 1, &type);
    if (!st) st = crisp__iges_ptr(f, e, 2, 0, &sp);
    if (!st) st = crisp__iges_int_range(f, e, 3, 1, crisp__iges_nparams(f, e) - 3, &n);
    if (st) return st;
    f->ents[e].used = 1;
    if (!crisp__iges_is_surface_type(f->ents[sp].type))
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter 2: DE %d is entity %d, expected a "
                                "surface",
                                iges_de(sp), f->ents[sp].type);
    iges_surface s;
    if ((st = crisp__iges_surface_convert(f, sp, 1, &s))) {
        if (st == CRISP_ERR_UNSUPPORTED) {
            note_dropped(f, e, "its surface uses unsupported geometry");
            crisp_error_clear();
            return CRISP_OK;
        }
        return st;
    }
    iges_curves *loops = crisp_calloc_array((size_t)n, sizeof *loops);
    int *outer = crisp_calloc_array((size_t)n, sizeof *outer);
    if (!loops || !outer) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    double tol_uv = s.surface ? uv_tolerance(&s) : 0;
    for (int i = 0; i < n && !st; i++) {
        int b;
        if ((st = crisp__iges_ptr(f, e, 4 + i, 0, &b))) break;
        if (f->ents[b].type != 141) {
            st = crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                  "parameter %d: DE %d is entity %d, expected 141", 4 + i,
                                  iges_de(b), f->ents[b].type);
            break;
        }
        st = boundary_141(f, b, &s, tol_uv, &loops[i]);
        outer[i] = i == 0; /* the first boundary is the outer one (IGES 5.3, 4.33) */
    }
    if (st == CRISP_ERR_UNSUPPORTED) {
        note_dropped(f, e, "a boundary curve uses unsupported geometry");
        crisp_error_clear();
        st = CRISP_OK;
        goto done;
    }
    if (!st) st = crisp__iges_finish_face(f, e, sp, &s, loops, outer, n, 0);
done:
    for (int i = 0; loops && i < n; i++)
        crisp__iges_curves_free(&loops[i]);
    crisp_free(loops);
    crisp_free(outer);
    crisp__iges_surface_free(&s);
    return st;
}

/* ---- planes and untrimmed surfaces ---------------------------------------------------------- */

crisp_status crisp__iges_face_plane(iges_file *f, int e)
{
    int ptr;
    crisp_status st = crisp__iges_ptr(f, e, 5, 1, &ptr);
    if (st) return st;
    if (ptr < 0) {
        note_dropped(f, e, "unbounded plane");
        return CRISP_OK;
    }
    iges_surface s;
    if ((st = crisp__iges_surface_convert(f, e, 0, &s))) return st;
    iges_curves model = {0}, loop = {0};
    int outer = 1;
    st = crisp__iges_curve_convert(f, ptr, 3, NULL, 1, &model);
    if (!st) st = crisp__iges_project_curves(f, e, &s, &model, &loop);
    if (!st) st = crisp__iges_finish_face(f, e, e, &s, &loop, &outer, 1, 0);
    crisp__iges_curves_free(&model);
    crisp__iges_curves_free(&loop);
    crisp__iges_surface_free(&s);
    return st;
}

crisp_status crisp__iges_face_untrimmed(iges_file *f, int e)
{
    iges_surface s;
    crisp_status st = crisp__iges_surface_convert(f, e, 0, &s);
    if (st) return st;
    if (s.narrowed) {
        /* a free 128 whose parameter range is narrower than its knots: bound it by the range */
        iges_curves loop = {0};
        int outer = 1;
        st = crisp__iges_domain_loop(&s, &loop);
        if (!st) st = crisp__iges_finish_face(f, e, e, &s, &loop, &outer, 1, 0);
        crisp__iges_curves_free(&loop);
        crisp__iges_surface_free(&s);
        return st;
    }
    crisp_face face = {0};
    face.source_id = iges_de(e);
    face.has_color = crisp__iges_entity_color(f, e, face.color);
    face.surface = s.surface;
    return crisp_model_add_face(f->model, &face);
}
