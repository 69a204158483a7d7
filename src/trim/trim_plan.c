/* One face's trimming work for one frame (Wu & Peters 2015, section 4): density bound per strip,
 * scan lines per strip, trim polylines, u-intercept table, reusing the caller's buffers so that a
 * steady camera and image size allocate nothing after the first frame. The strips and the bound
 * cover only the part of the face the loops can enclose (see crisp_trim_plan_face in trim.h).
 */
#include "trim_internal.h"

#include <math.h>
#include <string.h>

/* The control-point box of piece b: u in [box[0], box[1]], v in [box[2], box[3]]. */
static void piece_box(const crisp_bezier_curve *b, double box[4])
{
    box[0] = box[2] = HUGE_VAL;
    box[1] = box[3] = -HUGE_VAL;
    for (int i = 0; i <= b->degree; i++) {
        double u = b->cpw[3 * i] / b->cpw[3 * i + 2], v = b->cpw[3 * i + 1] / b->cpw[3 * i + 2];
        box[0] = crisp__trim_min(box[0], u);
        box[1] = crisp__trim_max(box[1], u);
        box[2] = crisp__trim_min(box[2], v);
        box[3] = crisp__trim_max(box[3], v);
    }
}

/* The strips' v-range [p->v0, p->v1]: the face's, narrowed to the pieces' control points; and per
 * strip the u-range of the pieces whose control points reach it (empty: ulo > uhi). Every point
 * inside the loops lies in these ranges (the boundary is in the pieces' convex hulls). */
static void trim_extent(const crisp_trim_plan_desc *desc, crisp_trim_plan *p, int n)
{
    double tv0 = HUGE_VAL, tv1 = -HUGE_VAL, box[4];
    for (int k = 0; k < desc->piece_count; k++) {
        piece_box(&desc->pieces[k], box);
        tv0 = crisp__trim_min(tv0, box[2]);
        tv1 = crisp__trim_max(tv1, box[3]);
    }
    p->v0 = crisp__trim_max(desc->v0, tv0);
    p->v1 = crisp__trim_min(desc->v1, tv1);
    int none = !(p->v1 > p->v0); /* no loops, or loops without area inside the domain */
    if (none) p->v0 = desc->v0, p->v1 = desc->v1;
    for (int i = 0; i < n; i++) {
        p->strip_u[2 * i] = desc->piece_count ? HUGE_VAL : -HUGE_VAL;
        p->strip_u[2 * i + 1] = desc->piece_count ? -HUGE_VAL : HUGE_VAL;
    }
    if (none) return;
    double h = (p->v1 - p->v0) / n;
    for (int k = 0; k < desc->piece_count; k++) {
        piece_box(&desc->pieces[k], box);
        if (box[3] < p->v0 || box[2] > p->v1) continue;
        /* One strip more on each side: rounding of the strip index must not lose a strip. */
        double f0 = floor((box[2] - p->v0) / h) - 1, f1 = floor((box[3] - p->v0) / h) + 1;
        int i0 = f0 < 0 ? 0 : f0 > n - 1 ? n - 1 : (int)f0;
        int i1 = f1 < 0 ? 0 : f1 > n - 1 ? n - 1 : (int)f1;
        for (int i = i0; i <= i1; i++) {
            p->strip_u[2 * i] = crisp__trim_min(p->strip_u[2 * i], box[0]);
            p->strip_u[2 * i + 1] = crisp__trim_max(p->strip_u[2 * i + 1], box[1]);
        }
    }
}

/* trim_extent from a view-independent level set's box: the strips' v-range as there, every strip's
 * u-range the whole box (a superset of the pieces' boxes that reach it: the bound covers more,
 * and stays a bound). */
static void lod_extent(const crisp_trim_plan_desc *desc, const crisp_trim_lod *lod,
                       crisp_trim_plan *p, int n)
{
    p->v0 = crisp__trim_max(desc->v0, lod->box[2]);
    p->v1 = crisp__trim_min(desc->v1, lod->box[3]);
    if (!(p->v1 > p->v0)) p->v0 = desc->v0, p->v1 = desc->v1;
    for (int i = 0; i < n; i++) {
        p->strip_u[2 * i] = lod->box[0];
        p->strip_u[2 * i + 1] = lod->box[1];
    }
}

crisp_status crisp_trim_plan_face(const crisp_trim_plan_desc *desc, crisp_trim_plan *dest)
{
    if (!desc || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_trim_plan_face: NULL argument");
    int n = desc->strip_count > 0 ? desc->strip_count : 16;
    if (n > (1 << 20))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_plan_face: strip_count %d, expected at most 1048576", n);
    crisp_trim_plan *p = dest;
    if (n > p->cap_strips) {
        double *rv = crisp_realloc_array(p->rho_v, (size_t)n, sizeof *rv);
        if (rv) p->rho_v = rv;
        double *ru = crisp_realloc_array(p->rho_u, (size_t)n, sizeof *ru);
        if (ru) p->rho_u = ru;
        uint32_t *mu = crisp_realloc_array(p->mu, (size_t)n, sizeof *mu);
        if (mu) p->mu = mu;
        double *vv = crisp_realloc_array(p->vis_v, 2 * (size_t)n, sizeof *vv);
        if (vv) p->vis_v = vv;
        double *su = crisp_realloc_array(p->strip_u, 2 * (size_t)n, sizeof *su);
        if (su) p->strip_u = su;
        double *vu = crisp_realloc_array(p->vis_u, 2 * (size_t)n, sizeof *vu);
        if (vu) p->vis_u = vu;
        if (!rv || !ru || !mu || !vv || !su || !vu)
            return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_trim_plan_face: out of memory");
        p->cap_strips = n;
    }
    crisp_arena *scratch = desc->scratch;
    if (!scratch) {
        if (!p->scratch) {
            crisp_status st = crisp_arena_create(0, &p->scratch);
            if (st) return st;
        }
        scratch = p->scratch;
    }
    crisp_arena_reset(scratch);
    p->strip_count = n;
    if (desc->piece_count < 0 || (desc->piece_count > 0 && !desc->pieces))
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_trim_plan_face: %d pieces at %p",
                           desc->piece_count, (const void *)desc->pieces);
    const crisp_trim_lod *lod =
        desc->lod && desc->lod->levels > 0 && desc->piece_count > 0 ? desc->lod : NULL;
    crisp_status st = lod ? CRISP_OK : crisp_trim_pieces_check(desc->pieces, desc->piece_count);
    if (st) return st;
    if (lod)
        lod_extent(desc, lod, p, n);
    else
        trim_extent(desc, p, n);
    st = crisp_trim_scan_density(&(crisp_trim_density_desc){.patches = desc->patches,
                                                            .patch_count = desc->patch_count,
                                                            .view_proj = desc->view_proj,
                                                            .width = desc->width,
                                                            .height = desc->height,
                                                            .v0 = p->v0,
                                                            .v1 = p->v1,
                                                            .strip_count = n,
                                                            .scratch = scratch,
                                                            .strip_u = p->strip_u,
                                                            .tree = desc->tree,
                                                            .vis_u = p->vis_u},
                                 p->rho_v, p->rho_u, p->vis_v, &p->density_stats);
    if (st) return st;
    crisp_trim_rows_from_density(p->rho_v, p->vis_v, n, p->v0, p->v1, p->mu, &p->clamped);
    const crisp_trim_polyline *pl = NULL;
    p->chains = 0;
    /* The tolerances the polyline needs (crisp_trim_tessellate's defaults over the finest visible
     * strip) and the coarsest view-independent level within them. */
    double h = HUGE_VAL, rho_u = 0.0;
    for (int i = 0; i < n; i++) {
        if (!p->mu[i]) continue;
        h = fmin(h, (p->vis_v[2 * i + 1] - p->vis_v[2 * i]) / p->mu[i]);
        if (isfinite(p->rho_u[i])) rho_u = fmax(rho_u, p->rho_u[i]);
    }
    /* The coarsest level within half of them, then chains with what is left (at least the other
     * half): a level's factor 2 steps would otherwise waste up to half the allowance. */
    int level = -1;
    for (int k = 0; lod && k < lod->levels && level < 0; k++)
        if (lod->tol_v[k] <= 0.125 * h && lod->tol_u[k] * rho_u <= 0.125) level = k;
    if (level >= 0) {
        const crisp_trim_polyline *src = &lod->level[level];
        size_t pts = (size_t)src->first[src->piece_count];
        crisp_trim_polyline *d = &p->polyline;
        if (crisp_grow((void **)&d->first, &d->cap_first, (size_t)src->piece_count + 1,
                       sizeof *d->first) ||
            crisp_grow((void **)&d->uv, &d->cap_uv, 2 * (pts ? pts : 1), sizeof *d->uv) ||
            crisp_grow((void **)&d->t, &d->cap_t, pts ? pts : 1, sizeof *d->t))
            return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_trim_plan_face: out of memory");
        d->piece_count = src->piece_count;
        d->capped = 0;
        memcpy(d->first, src->first, ((size_t)src->piece_count + 1) * sizeof *d->first);
        memcpy(d->uv, src->uv, 2 * pts * sizeof *d->uv);
        memcpy(d->t, src->t, pts * sizeof *d->t);
        if (isfinite(h)) {
            double left_u = rho_u > 0.0 ? 0.25 / rho_u - lod->tol_u[level] : HUGE_VAL;
            double left_v = 0.25 * h - lod->tol_v[level];
            if (left_u > 0.0 && left_v > 0.0 &&
                (st = crisp_trim_polyline_chains(d, left_u, left_v)))
                return st;
        }
        p->chains = 1;
        pl = d;
    } else if (desc->piece_count > 0) {
        /* With chains, half of each tolerance for the pieces' polylines and half for the chains'
         * chords (the chords' halves over the finest visible strip: then every strip keeps
         * h_i / 4 and 1 / (4 rho_u) in all). */
        double f = desc->chains ? 0.125 : 0.25;
        st =
            crisp__trim_tessellate_checked(&(crisp_trim_tess_desc){.pieces = desc->pieces,
                                                                   .piece_count = desc->piece_count,
                                                                   .v0 = p->v0,
                                                                   .v1 = p->v1,
                                                                   .strip_count = n,
                                                                   .mu = p->mu,
                                                                   .row_v = p->vis_v,
                                                                   .rho_u = p->rho_u,
                                                                   .tol_u = f,
                                                                   .tol_v = f},
                                           &p->polyline);
        if (st) return st;
        if (desc->chains) {
            if (h > 0.0 && isfinite(h)) {
                st = crisp_trim_polyline_chains(&p->polyline, rho_u > 0.0 ? f / rho_u : HUGE_VAL,
                                                f * h);
                if (st) return st;
                p->chains = 1;
            }
        }
        pl = &p->polyline;
    }
    return crisp_trim_table_build(&(crisp_trim_table_desc){.polyline = pl,
                                                           .v0 = p->v0,
                                                           .v1 = p->v1,
                                                           .strip_count = n,
                                                           .mu = p->mu,
                                                           .row_v = p->vis_v},
                                  &p->table);
}

void crisp_trim_plan_free(crisp_trim_plan *plan)
{
    if (!plan) return;
    crisp_free(plan->rho_v);
    crisp_free(plan->rho_u);
    crisp_free(plan->mu);
    crisp_free(plan->vis_v);
    crisp_free(plan->strip_u);
    crisp_free(plan->vis_u);
    crisp_trim_polyline_free(&plan->polyline);
    crisp_trim_table_free(&plan->table);
    crisp_arena_destroy(plan->scratch);
    memset(plan, 0, sizeof *plan);
}
