/* The trim editor's edit model (include/crisp/trimedit.h): every edit builds the face's new
 * loops on a copy, keeps the invariants the renderer and the OBJ writer rely on (closed loops of
 * well-formed curves inside the domain, outer loops counter-clockwise, holes clockwise), and
 * only then swaps the copy in, pushing the old loops on the undo stack. Curve operations follow
 * The NURBS Book: knot insertion (A5.1), knot removal (5.4), circles (7.5).
 */
#include "crisp/trimedit.h"

#include "crisp/construct.h"
#include "trimedit_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- loops: copy, free ----------------------------------------------------------------------- */

void crisp__trimedit_loops_free(crisp_trim_loop *loops, int n)
{
    if (!loops) return;
    for (int l = 0; l < n; l++)
        crisp_trim_loop_free(&loops[l]);
    free(loops);
}

crisp_status crisp__trimedit_loops_copy(const crisp_trim_loop *src, int n, crisp_trim_loop **dest)
{
    *dest = NULL;
    crisp_trim_loop *d = calloc((size_t)(n > 0 ? n : 1), sizeof *d);
    if (!d) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory copying trim loops");
    for (int l = 0; l < n; l++) {
        d[l].is_outer = src[l].is_outer;
        d[l].curves = calloc((size_t)(src[l].curve_count > 0 ? src[l].curve_count : 1),
                             sizeof(crisp_curve *));
        if (!d[l].curves) {
            crisp__trimedit_loops_free(d, n);
            return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory copying trim loops");
        }
        for (int c = 0; c < src[l].curve_count; c++) {
            crisp_status st = crisp_curve_copy(src[l].curves[c], &d[l].curves[c]);
            if (st) {
                crisp__trimedit_loops_free(d, n);
                return st;
            }
            d[l].curve_count = c + 1;
        }
    }
    *dest = d;
    return CRISP_OK;
}

/* ---- control points -------------------------------------------------------------------------- */

static void get_point(const crisp_curve *c, int i, double uv[2], double *w)
{
    const double *q = c->cpw + (size_t)i * 3;
    uv[0] = q[0] / q[2];
    uv[1] = q[1] / q[2];
    if (w) *w = q[2];
}

static void set_point(crisp_curve *c, int i, const double uv[2])
{
    double *q = c->cpw + (size_t)i * 3;
    q[0] = uv[0] * q[2];
    q[1] = uv[1] * q[2];
}

static void update_rational(crisp_curve *c)
{
    c->rational = 0;
    for (int i = 0; i < c->count; i++)
        if (c->cpw[3 * i + 2] != 1.0) c->rational = 1;
}

/* Set point i of curve c of loop and the joint it shares with the neighbouring curve. */
static void set_joint_point(crisp_trim_loop *loop, int c, int i, const double uv[2])
{
    crisp_curve *cv = loop->curves[c];
    const int m = loop->curve_count;
    set_point(cv, i, uv);
    if (i == 0) {
        crisp_curve *prev = loop->curves[(c + m - 1) % m];
        set_point(prev, prev->count - 1, uv);
    }
    if (i == cv->count - 1) {
        crisp_curve *next = loop->curves[(c + 1) % m];
        set_point(next, 0, uv);
    }
}

static int is_clamped(const crisp_curve *c)
{
    const int p = c->degree, n = c->count;
    for (int k = 1; k <= p; k++)
        if (c->knots[k] != c->knots[0] || c->knots[n + k - 1] != c->knots[n + p]) return 0;
    return 1;
}

/* ---- the editor ------------------------------------------------------------------------------ */

static crisp_face *face_of(const crisp_trimedit *ed)
{
    return &ed->model->faces[ed->face];
}

static double domain_size(const crisp_trimedit *ed)
{
    return fmax(ed->domain[1] - ed->domain[0], ed->domain[3] - ed->domain[2]);
}

static crisp_status check_ref(const crisp_trim_loop *loops, int n, crisp_trimedit_ref r)
{
    if (r.loop < 0 || r.loop >= n)
        return crisp_error(CRISP_ERR_INVALID_ARG, "loop %d: the face has %d loops", r.loop, n);
    const crisp_trim_loop *l = &loops[r.loop];
    if (r.curve < 0 || r.curve >= l->curve_count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "curve %d: loop %d has %d curves", r.curve,
                           r.loop, l->curve_count);
    if (r.index < 0 || r.index >= l->curves[r.curve]->count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "control point %d: curve %d of loop %d has %d",
                           r.index, r.curve, r.loop, l->curves[r.curve]->count);
    return CRISP_OK;
}

/* Everything the renderer and the writer assume of the loops (include/crisp/model.h). */
static crisp_status validate(const crisp_trimedit *ed, const crisp_trim_loop *loops, int n)
{
    const double *d = ed->domain, size = domain_size(ed), slack = ed->slack;
    if (n <= 0) return crisp_error(CRISP_ERR_INVALID_ARG, "the face would have no trim loop");
    int outer = 0;
    for (int l = 0; l < n; l++) {
        const crisp_trim_loop *lp = &loops[l];
        outer += lp->is_outer != 0;
        if (lp->curve_count <= 0)
            return crisp_error(CRISP_ERR_INVALID_ARG, "loop %d would have no curves", l);
        int points = 0;
        for (int c = 0; c < lp->curve_count; c++) {
            const crisp_curve *cv = lp->curves[c];
            const int p = cv->degree, k = cv->count;
            if (cv->dim != 2 || p < 1 || p > CRISP_MAX_DEGREE || k < p + 1)
                return crisp_error(CRISP_ERR_INVALID_ARG,
                                   "loop %d, curve %d: degree %d with %d control points", l, c, p,
                                   k);
            for (int i = 0; i < k + p + 1; i++)
                if (!isfinite(cv->knots[i]) || (i && cv->knots[i] < cv->knots[i - 1]))
                    return crisp_error(
                        CRISP_ERR_INVALID_ARG,
                        "loop %d, curve %d: knot %d (%.17g) is not finite or decreases", l, c, i,
                        cv->knots[i]);
            if (!(cv->knots[p] < cv->knots[k]))
                return crisp_error(CRISP_ERR_INVALID_ARG, "loop %d, curve %d: empty domain", l, c);
            if (!is_clamped(cv))
                return crisp_error(CRISP_ERR_INVALID_ARG, "loop %d, curve %d: not clamped", l, c);
            for (int i = 0; i < k; i++) {
                double uv[2], w;
                get_point(cv, i, uv, &w);
                if (!(w > 0) || !isfinite(w))
                    return crisp_error(CRISP_ERR_INVALID_ARG,
                                       "loop %d, curve %d, point %d: weight %g (expected > 0)", l,
                                       c, i, w);
                if (!isfinite(uv[0]) || !isfinite(uv[1]) || uv[0] < d[0] - slack ||
                    uv[0] > d[1] + slack || uv[1] < d[2] - slack || uv[1] > d[3] + slack)
                    return crisp_error(CRISP_ERR_INVALID_ARG,
                                       "loop %d, curve %d, point %d at (%g, %g) would leave the "
                                       "domain [%g, %g] x [%g, %g]",
                                       l, c, i, uv[0], uv[1], d[0], d[1], d[2], d[3]);
            }
            points += k - 1;
        }
        if (points < 3)
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "loop %d would have %d control points (at least 3)", l, points);
        double gap = crisp_trim_loop_closure_gap(lp);
        if (!(gap <= 1e-9 * size))
            return crisp_error(CRISP_ERR_INVALID_ARG, "loop %d would not be closed (gap %g)", l,
                               gap);
    }
    if (!outer) return crisp_error(CRISP_ERR_INVALID_ARG, "the face would have no outer loop");
    return CRISP_OK;
}

/* Outer loops CCW, holes CW: reverse the loops that are not, and keep ref on its point. */
static void orient(crisp_trim_loop *loops, int n, crisp_trimedit_ref *ref)
{
    for (int l = 0; l < n; l++) {
        double a = crisp_trim_loop_signed_area(&loops[l]);
        if (!(loops[l].is_outer ? a < 0 : a > 0)) continue;
        crisp_trim_loop_reverse(&loops[l]);
        if (ref && ref->loop == l) {
            ref->curve = loops[l].curve_count - 1 - ref->curve;
            ref->index = loops[l].curves[ref->curve]->count - 1 - ref->index;
        }
    }
}

static void clear_stack(crisp__trimedit_snapshot *s, int *count)
{
    for (int i = 0; i < *count; i++)
        crisp__trimedit_loops_free(s[i].loops, s[i].loop_count);
    *count = 0;
}

static void push(crisp__trimedit_snapshot *s, int *count, int cap, crisp_trim_loop *loops, int n)
{
    if (*count == cap) { /* drop the oldest */
        crisp__trimedit_loops_free(s[0].loops, s[0].loop_count);
        memmove(s, s + 1, (size_t)(cap - 1) * sizeof *s);
        (*count)--;
    }
    s[*count].loops = loops;
    s[*count].loop_count = n;
    (*count)++;
}

/* Orient, validate, and swap the new loops in (or free them and fail). */
static crisp_status commit(crisp_trimedit *ed, crisp_trim_loop *loops, int n,
                           crisp_trimedit_ref *ref)
{
    crisp_trimedit_ref r = ref ? *ref : (crisp_trimedit_ref){-1, -1, -1};
    orient(loops, n, &r);
    crisp_status st = validate(ed, loops, n);
    if (st) {
        crisp__trimedit_loops_free(loops, n);
        return st;
    }
    crisp_face *f = face_of(ed);
    if (!ed->group_open || !ed->group_pushed) {
        push(ed->undo, &ed->undo_count, ed->history, f->loops, f->loop_count);
        if (ed->group_open) ed->group_pushed = 1;
    } else {
        crisp__trimedit_loops_free(f->loops, f->loop_count);
    }
    clear_stack(ed->redo, &ed->redo_count);
    f->loops = loops;
    f->loop_count = n;
    ed->version++;
    if (ref) *ref = r;
    return CRISP_OK;
}

/* A working copy of the face's loops. */
static crisp_status working_copy(const crisp_trimedit *ed, crisp_trim_loop **dest, int *n)
{
    const crisp_face *f = face_of(ed);
    *n = f->loop_count;
    return crisp__trimedit_loops_copy(f->loops, f->loop_count, dest);
}

/* The loop along the domain boundary (CCW polygon). */
static crisp_status polygon_curve(int n, const double *uv, crisp_curve **dest)
{
    double *knots = malloc((size_t)(n + 3) * sizeof *knots);
    double *pts = malloc((size_t)(n + 1) * 2 * sizeof *pts);
    if (!knots || !pts) {
        free(knots);
        free(pts);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a polygon");
    }
    knots[0] = 0;
    for (int i = 0; i <= n; i++)
        knots[i + 1] = i;
    knots[n + 2] = n;
    memcpy(pts, uv, (size_t)n * 2 * sizeof *pts);
    pts[2 * n] = uv[0];
    pts[2 * n + 1] = uv[1];
    crisp_status st = crisp_curve_create(2, 1, n + 1, knots, pts, NULL, dest);
    free(knots);
    free(pts);
    return st;
}

crisp_status crisp_trimedit_create(crisp_model *model, int face, const crisp_trimedit_desc *desc,
                                   crisp_trimedit **dest)
{
    *dest = NULL;
    if (!model || face < 0 || face >= model->face_count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "face %d: the model has %d faces", face,
                           model ? model->face_count : 0);
    crisp_trimedit *ed = calloc(1, sizeof *ed);
    if (!ed) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the trim editor");
    ed->model = model;
    ed->face = face;
    ed->history = desc && desc->history > 0 ? desc->history : 256;
    ed->remove_tol = desc && desc->remove_tol > 0 ? desc->remove_tol : 1e-9;
    crisp_surface_domain(model->faces[face].surface, ed->domain);
    ed->undo = calloc((size_t)ed->history, sizeof *ed->undo);
    ed->redo = calloc((size_t)ed->history, sizeof *ed->redo);
    crisp_status st = CRISP_OK;
    if (!ed->undo || !ed->redo) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the trim editor");
        goto fail;
    }
    crisp_trim_loop *loops = NULL;
    int n = 0;
    crisp_face *f = &model->faces[face];
    if (f->loop_count == 0) {
        const double *d = ed->domain;
        const double box[8] = {d[0], d[2], d[1], d[2], d[1], d[3], d[0], d[3]};
        loops = calloc(1, sizeof *loops);
        if (!loops) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a loop");
            goto fail;
        }
        n = 1;
        loops[0].is_outer = 1;
        loops[0].curves = calloc(1, sizeof(crisp_curve *));
        if (!loops[0].curves || (st = polygon_curve(4, box, &loops[0].curves[0]))) {
            crisp__trimedit_loops_free(loops, n);
            if (!st) st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a loop");
            goto fail;
        }
        loops[0].curve_count = 1;
    } else {
        if ((st = working_copy(ed, &loops, &n))) goto fail;
        for (int l = 0; l < n && !st; l++) {
            crisp_trim_loop *lp = &loops[l];
            for (int c = 0; c < lp->curve_count && !st; c++) {
                crisp_curve *cv = lp->curves[c];
                if (cv->dim != 2) {
                    st = crisp_error(CRISP_ERR_INVALID_ARG, "loop %d, curve %d: dimension %d", l, c,
                                     cv->dim);
                    break;
                }
                if (is_clamped(cv)) continue;
                double t0, t1;
                crisp_curve *clamped;
                crisp_curve_domain(cv, &t0, &t1);
                if ((st = crisp_curve_trim(cv, t0, t1, &clamped))) break;
                crisp_curve_destroy(cv);
                lp->curves[c] = clamped;
            }
            /* Close the joints exactly (the model closes them within its tolerance). */
            for (int c = 0; c < lp->curve_count && !st; c++) {
                crisp_curve *cv = lp->curves[c], *next = lp->curves[(c + 1) % lp->curve_count];
                double uv[2];
                get_point(cv, cv->count - 1, uv, NULL);
                set_point(next, 0, uv);
            }
        }
        if (st) {
            crisp__trimedit_loops_free(loops, n);
            crisp_error_prefix("face %d", face);
            goto fail;
        }
    }
    /* Files may place control points a little outside the domain (within their tolerance):
     * that much is kept; edits clamp into the domain itself. */
    ed->slack = 1e-12 * domain_size(ed);
    for (int l = 0; l < n; l++)
        ed->slack =
            fmax(ed->slack, 1.000001 * crisp_trim_loop_domain_excess(&loops[l], ed->domain));
    orient(loops, n, NULL);
    if ((st = validate(ed, loops, n))) {
        crisp__trimedit_loops_free(loops, n);
        crisp_error_prefix("face %d cannot be edited", face);
        goto fail;
    }
    crisp__trimedit_loops_free(f->loops, f->loop_count);
    f->loops = loops;
    f->loop_count = n;
    ed->version = 1;
    *dest = ed;
    return CRISP_OK;
fail:
    crisp_trimedit_destroy(ed);
    return st;
}

void crisp_trimedit_destroy(crisp_trimedit *ed)
{
    if (!ed) return;
    if (ed->undo) clear_stack(ed->undo, &ed->undo_count);
    if (ed->redo) clear_stack(ed->redo, &ed->redo_count);
    free(ed->undo);
    free(ed->redo);
    free(ed->check_seg);
    free(ed);
}

const crisp_face *crisp_trimedit_face(const crisp_trimedit *ed)
{
    return face_of(ed);
}

int crisp_trimedit_face_index(const crisp_trimedit *ed)
{
    return ed->face;
}

void crisp_trimedit_domain(const crisp_trimedit *ed, double dest[4])
{
    memcpy(dest, ed->domain, 4 * sizeof *dest);
}

uint64_t crisp_trimedit_version(const crisp_trimedit *ed)
{
    return ed->version;
}

crisp_status crisp_trimedit_point(const crisp_trimedit *ed, crisp_trimedit_ref ref, double uv[2],
                                  double *weight)
{
    const crisp_face *f = face_of(ed);
    crisp_status st = check_ref(f->loops, f->loop_count, ref);
    if (st) return st;
    get_point(f->loops[ref.loop].curves[ref.curve], ref.index, uv, weight);
    return CRISP_OK;
}

/* ---- edits ----------------------------------------------------------------------------------- */

static void clamp_to_domain(const crisp_trimedit *ed, double uv[2], double snap)
{
    const double *d = ed->domain;
    for (int k = 0; k < 2; k++) {
        double lo = d[2 * k], hi = d[2 * k + 1];
        if (uv[k] < lo + snap) uv[k] = lo;
        if (uv[k] > hi - snap) uv[k] = hi;
    }
}

crisp_status crisp_trimedit_move_point(crisp_trimedit *ed, crisp_trimedit_ref *ref,
                                       const double uv[2], double snap)
{
    const crisp_face *f = face_of(ed);
    crisp_status st = check_ref(f->loops, f->loop_count, *ref);
    if (st) return st;
    if (!isfinite(uv[0]) || !isfinite(uv[1]))
        return crisp_error(CRISP_ERR_INVALID_ARG, "point (%g, %g) is not finite", uv[0], uv[1]);
    double p[2] = {uv[0], uv[1]};
    clamp_to_domain(ed, p, snap > 0 ? snap : 0.0);
    double cur[2];
    get_point(f->loops[ref->loop].curves[ref->curve], ref->index, cur, NULL);
    if (cur[0] == p[0] && cur[1] == p[1]) return CRISP_OK; /* nothing moves: no new version */
    crisp_trim_loop *loops;
    int n;
    if ((st = working_copy(ed, &loops, &n))) return st;
    set_joint_point(&loops[ref->loop], ref->curve, ref->index, p);
    return commit(ed, loops, n, ref);
}

crisp_status crisp_trimedit_snap_point(crisp_trimedit *ed, crisp_trimedit_ref *ref)
{
    double uv[2];
    crisp_status st = crisp_trimedit_point(ed, *ref, uv, NULL);
    if (st) return st;
    const double *d = ed->domain;
    double dist[4] = {uv[0] - d[0], d[1] - uv[0], uv[1] - d[2], d[3] - uv[1]};
    int best = 0;
    for (int k = 1; k < 4; k++)
        if (dist[k] < dist[best]) best = k;
    uv[best / 2] = d[best];
    return crisp_trimedit_move_point(ed, ref, uv, 0.0);
}

crisp_status crisp_trimedit_set_weight(crisp_trimedit *ed, crisp_trimedit_ref ref, double weight)
{
    const crisp_face *f = face_of(ed);
    crisp_status st = check_ref(f->loops, f->loop_count, ref);
    if (st) return st;
    if (!(weight > 0) || !isfinite(weight) || weight > 1e12)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "weight %g: a weight must be finite and greater than 0", weight);
    crisp_trim_loop *loops;
    int n;
    if ((st = working_copy(ed, &loops, &n))) return st;
    crisp_curve *cv = loops[ref.loop].curves[ref.curve];
    double uv[2];
    get_point(cv, ref.index, uv, NULL);
    double *q = cv->cpw + (size_t)ref.index * 3;
    q[0] = uv[0] * weight;
    q[1] = uv[1] * weight;
    q[2] = weight;
    update_rational(cv);
    return commit(ed, loops, n, &ref);
}

static crisp_status check_curve(const crisp_trimedit *ed, int loop, int curve)
{
    const crisp_face *f = face_of(ed);
    return check_ref(f->loops, f->loop_count, (crisp_trimedit_ref){loop, curve, 0});
}

crisp_status crisp_trimedit_insert_knot(crisp_trimedit *ed, int loop, int curve, double t)
{
    crisp_status st = check_curve(ed, loop, curve);
    if (st) return st;
    const crisp_curve *cv = face_of(ed)->loops[loop].curves[curve];
    double t0, t1;
    crisp_curve_domain(cv, &t0, &t1);
    if (!(t > t0 && t < t1))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "knot %.17g: expected inside the curve's domain (%.17g, %.17g)", t, t0,
                           t1);
    crisp_trim_loop *loops;
    int n;
    if ((st = working_copy(ed, &loops, &n))) return st;
    if ((st = crisp_curve_insert_knot(loops[loop].curves[curve], t, 1))) {
        crisp__trimedit_loops_free(loops, n);
        return st;
    }
    return commit(ed, loops, n, NULL);
}

crisp_status crisp_trimedit_remove_knot(crisp_trimedit *ed, int loop, int curve, int knot)
{
    crisp_status st = check_curve(ed, loop, curve);
    if (st) return st;
    crisp_trim_loop *loops;
    int n;
    if ((st = working_copy(ed, &loops, &n))) return st;
    crisp_curve *cv = loops[loop].curves[curve];
    /* The tolerance on homogeneous coordinates: a fraction of the domain times the largest
     * weight. */
    double wmax = 0;
    for (int i = 0; i < cv->count; i++)
        wmax = fmax(wmax, cv->cpw[3 * i + 2]);
    if ((st = crisp_curve_remove_knot(cv, knot,
                                      ed->remove_tol * domain_size(ed) * fmax(wmax, 1.0)))) {
        crisp__trimedit_loops_free(loops, n);
        crisp_error_prefix("loop %d, curve %d", loop, curve);
        return st;
    }
    return commit(ed, loops, n, NULL);
}

crisp_status crisp_trimedit_delete_point(crisp_trimedit *ed, crisp_trimedit_ref ref)
{
    const crisp_face *f = face_of(ed);
    crisp_status st = check_ref(f->loops, f->loop_count, ref);
    if (st) return st;
    const crisp_trim_loop *lp = &f->loops[ref.loop];
    const crisp_curve *cv = lp->curves[ref.curve];
    const int p = cv->degree, k = cv->count, i = ref.index;
    if (i == 0 || i == k - 1)
        return crisp_error(
            CRISP_ERR_INVALID_ARG,
            "control point %d of curve %d of loop %d joins two curves: only interior "
            "points can be deleted",
            i, ref.curve, ref.loop);
    if (k - 1 < p + 1)
        return crisp_error(
            CRISP_ERR_INVALID_ARG,
            "curve %d of loop %d has %d control points, the fewest a degree %d curve "
            "can have: the point cannot be deleted",
            ref.curve, ref.loop, k, p);
    int points = 0;
    for (int c = 0; c < lp->curve_count; c++)
        points += lp->curves[c]->count - 1;
    if (points - 1 < 3)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "loop %d has %d control points: deleting one would leave fewer than 3",
                           ref.loop, points);
    /* One interior knot in the point's support [knots[i], knots[i + p + 1]]: the middle one. */
    int j = i + (p + 1) / 2;
    if (j < p + 1) j = p + 1;
    if (j > k - 1) j = k - 1;
    crisp_trim_loop *loops;
    int n;
    if ((st = working_copy(ed, &loops, &n))) return st;
    crisp_curve *c = loops[ref.loop].curves[ref.curve];
    memmove(c->cpw + (size_t)i * 3, c->cpw + (size_t)(i + 1) * 3,
            (size_t)(k - 1 - i) * 3 * sizeof *c->cpw);
    memmove(c->knots + j, c->knots + j + 1, (size_t)(k + p - j) * sizeof *c->knots);
    c->count = k - 1;
    update_rational(c);
    return commit(ed, loops, n, NULL);
}

crisp_status crisp_trimedit_transform_loop(crisp_trimedit *ed, int loop, const double m[2][3])
{
    const crisp_face *f = face_of(ed);
    if (loop < 0 || loop >= f->loop_count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "loop %d: the face has %d loops", loop,
                           f->loop_count);
    for (int r = 0; r < 2; r++)
        for (int c = 0; c < 3; c++)
            if (!isfinite(m[r][c]))
                return crisp_error(CRISP_ERR_INVALID_ARG,
                                   "loop transform: entry (%d, %d) is not finite", r, c);
    double det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    if (!(fabs(det) >= 1e-12))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "loop transform with determinant %g refused: the loop would collapse",
                           det);
    crisp_trim_loop *loops;
    int n;
    crisp_status st = working_copy(ed, &loops, &n);
    if (st) return st;
    for (int c = 0; c < loops[loop].curve_count; c++) {
        crisp_curve *cv = loops[loop].curves[c];
        for (int i = 0; i < cv->count; i++) {
            double *q = cv->cpw + (size_t)i * 3;
            double u = q[0], v = q[1], w = q[2];
            q[0] = m[0][0] * u + m[0][1] * v + m[0][2] * w;
            q[1] = m[1][0] * u + m[1][1] * v + m[1][2] * w;
        }
    }
    /* Joints: recompute exactly from the previous curve's end (the map rounds both alike unless
     * the weights differ). */
    crisp_trim_loop *lp = &loops[loop];
    for (int c = 0; c < lp->curve_count; c++) {
        crisp_curve *cv = lp->curves[c], *next = lp->curves[(c + 1) % lp->curve_count];
        double uv[2];
        get_point(cv, cv->count - 1, uv, NULL);
        set_point(next, 0, uv);
    }
    return commit(ed, loops, n, NULL);
}

void crisp_trimedit_loop_center(const crisp_trimedit *ed, int loop, double dest[2])
{
    const crisp_face *f = face_of(ed);
    dest[0] = dest[1] = 0;
    if (loop < 0 || loop >= f->loop_count) return;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int c = 0; c < f->loops[loop].curve_count; c++) {
        const crisp_curve *cv = f->loops[loop].curves[c];
        for (int i = 0; i < cv->count; i++) {
            double uv[2];
            get_point(cv, i, uv, NULL);
            for (int k = 0; k < 2; k++) {
                lo[k] = fmin(lo[k], uv[k]);
                hi[k] = fmax(hi[k], uv[k]);
            }
        }
    }
    dest[0] = 0.5 * (lo[0] + hi[0]);
    dest[1] = 0.5 * (lo[1] + hi[1]);
}

/* Append a hole made of one curve (owned by the call). */
static crisp_status add_hole(crisp_trimedit *ed, crisp_curve *curve)
{
    crisp_trim_loop *loops;
    int n;
    crisp_status st = working_copy(ed, &loops, &n);
    if (st) {
        crisp_curve_destroy(curve);
        return st;
    }
    crisp_trim_loop *grown = realloc(loops, (size_t)(n + 1) * sizeof *grown);
    crisp_curve **curves = calloc(1, sizeof *curves);
    if (!grown || !curves) {
        free(curves);
        crisp_curve_destroy(curve);
        crisp__trimedit_loops_free(grown ? grown : loops, n);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory adding a hole");
    }
    loops = grown;
    curves[0] = curve;
    loops[n] = (crisp_trim_loop){.is_outer = 0, .curve_count = 1, .curves = curves};
    return commit(ed, loops, n + 1, NULL);
}

crisp_status crisp_trimedit_add_circle(crisp_trimedit *ed, const double center[2], double radius)
{
    if (!(radius > 0) || !isfinite(radius) || !isfinite(center[0]) || !isfinite(center[1]))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "circle at (%g, %g) radius %g: expected a finite "
                           "centre and a radius > 0",
                           center[0], center[1], radius);
    crisp_curve *c;
    const double x[2] = {1, 0}, y[2] = {0, 1};
    crisp_status st = crisp_make_arc(2, center, x, y, radius, radius, 0.0, 2 * M_PI, &c);
    if (st) return st;
    return add_hole(ed, c);
}

crisp_status crisp_trimedit_add_rectangle(crisp_trimedit *ed, const double lo[2],
                                          const double hi[2])
{
    const double pts[8] = {lo[0], lo[1], hi[0], lo[1], hi[0], hi[1], lo[0], hi[1]};
    if (!(fabs(hi[0] - lo[0]) > 0) || !(fabs(hi[1] - lo[1]) > 0))
        return crisp_error(CRISP_ERR_INVALID_ARG, "rectangle (%g, %g) - (%g, %g) is empty", lo[0],
                           lo[1], hi[0], hi[1]);
    return crisp_trimedit_add_polygon(ed, 4, pts);
}

crisp_status crisp_trimedit_add_polygon(crisp_trimedit *ed, int n, const double *uv)
{
    if (n < 3 || n > 100000)
        return crisp_error(CRISP_ERR_INVALID_ARG, "polygon of %d corners: expected 3 to 100000", n);
    double area = 0;
    for (int i = 0; i < n; i++) {
        const double *a = uv + 2 * i, *b = uv + 2 * ((i + 1) % n);
        if (!isfinite(a[0]) || !isfinite(a[1]))
            return crisp_error(CRISP_ERR_INVALID_ARG, "polygon corner %d is not finite", i);
        area += a[0] * b[1] - b[0] * a[1];
    }
    if (!(fabs(area) > 1e-14 * domain_size(ed) * domain_size(ed)))
        return crisp_error(CRISP_ERR_INVALID_ARG, "polygon of %d corners has no area", n);
    crisp_curve *c;
    crisp_status st = polygon_curve(n, uv, &c);
    if (st) return st;
    return add_hole(ed, c);
}

crisp_status crisp_trimedit_delete_loop(crisp_trimedit *ed, int loop)
{
    const crisp_face *f = face_of(ed);
    if (loop < 0 || loop >= f->loop_count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "loop %d: the face has %d loops", loop,
                           f->loop_count);
    if (f->loops[loop].is_outer)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "loop %d is the face's outer boundary: only holes can be deleted", loop);
    crisp_trim_loop *loops;
    int n;
    crisp_status st = working_copy(ed, &loops, &n);
    if (st) return st;
    crisp_trim_loop_free(&loops[loop]);
    memmove(loops + loop, loops + loop + 1, (size_t)(n - 1 - loop) * sizeof *loops);
    return commit(ed, loops, n - 1, NULL);
}

/* ---- history --------------------------------------------------------------------------------- */

static crisp_status swap_from(crisp_trimedit *ed, crisp__trimedit_snapshot *from, int *from_count,
                              crisp__trimedit_snapshot *to, int *to_count, const char *what)
{
    ed->group_open = 0;
    if (*from_count == 0) return crisp_error(CRISP_ERR_INVALID_ARG, "nothing to %s", what);
    crisp_face *f = face_of(ed);
    crisp__trimedit_snapshot s = from[--*from_count];
    push(to, to_count, ed->history, f->loops, f->loop_count);
    f->loops = s.loops;
    f->loop_count = s.loop_count;
    ed->version++;
    return CRISP_OK;
}

crisp_status crisp_trimedit_undo(crisp_trimedit *ed)
{
    return swap_from(ed, ed->undo, &ed->undo_count, ed->redo, &ed->redo_count, "undo");
}

crisp_status crisp_trimedit_redo(crisp_trimedit *ed)
{
    return swap_from(ed, ed->redo, &ed->redo_count, ed->undo, &ed->undo_count, "redo");
}

int crisp_trimedit_can_undo(const crisp_trimedit *ed)
{
    return ed->undo_count > 0;
}

int crisp_trimedit_can_redo(const crisp_trimedit *ed)
{
    return ed->redo_count > 0;
}

void crisp_trimedit_group_begin(crisp_trimedit *ed)
{
    ed->group_open = 1;
    ed->group_pushed = 0;
}

void crisp_trimedit_group_end(crisp_trimedit *ed)
{
    ed->group_open = 0;
    ed->group_pushed = 0;
}

/* ---- picking --------------------------------------------------------------------------------- */

int crisp_trimedit_pick_point(const crisp_trimedit *ed, const double uv[2], double radius,
                              crisp_trimedit_ref *dest)
{
    const crisp_face *f = face_of(ed);
    double best = radius;
    int found = 0;
    for (int l = 0; l < f->loop_count; l++)
        for (int c = 0; c < f->loops[l].curve_count; c++) {
            const crisp_curve *cv = f->loops[l].curves[c];
            for (int i = 0; i < cv->count; i++) {
                double q[2];
                get_point(cv, i, q, NULL);
                double d = hypot(q[0] - uv[0], q[1] - uv[1]);
                if (d <= best) {
                    best = d;
                    *dest = (crisp_trimedit_ref){l, c, i};
                    found = 1;
                }
            }
        }
    return found;
}

static double dist_at(const crisp_curve *cv, double t, const double uv[2])
{
    double q[2];
    crisp_curve_eval(cv, t, q);
    return hypot(q[0] - uv[0], q[1] - uv[1]);
}

int crisp_trimedit_pick_curve(const crisp_trimedit *ed, const double uv[2], double radius,
                              int *loop, int *curve, double *t)
{
    const crisp_face *f = face_of(ed);
    double best = radius;
    int found = 0;
    for (int l = 0; l < f->loop_count; l++)
        for (int c = 0; c < f->loops[l].curve_count; c++) {
            const crisp_curve *cv = f->loops[l].curves[c];
            const int p = cv->degree;
            for (int k = p; k < cv->count; k++) {
                double a = cv->knots[k], b = cv->knots[k + 1];
                if (!(a < b)) continue;
                enum { N = 32 };
                int bi = 0;
                double bd = INFINITY;
                for (int i = 0; i <= N; i++) {
                    double d = dist_at(cv, a + (b - a) * i / N, uv);
                    if (d < bd) bd = d, bi = i;
                }
                /* Golden-section refinement between the neighbouring samples. */
                double lo = a + (b - a) * (bi > 0 ? bi - 1 : 0) / N;
                double hi = a + (b - a) * (bi < N ? bi + 1 : N) / N;
                for (int it = 0; it < 60; it++) {
                    double m1 = lo + 0.382 * (hi - lo), m2 = hi - 0.382 * (hi - lo);
                    if (dist_at(cv, m1, uv) < dist_at(cv, m2, uv))
                        hi = m2;
                    else
                        lo = m1;
                }
                double tt = 0.5 * (lo + hi), d = dist_at(cv, tt, uv);
                if (d <= best) {
                    best = d;
                    *loop = l;
                    *curve = c;
                    *t = tt;
                    found = 1;
                }
            }
        }
    return found;
}
