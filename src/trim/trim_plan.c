/* One face's trimming work for one frame (Wu & Peters 2015, section 4): density bound per strip,
 * scan lines per strip, trim polylines, u-intercept table, reusing the caller's buffers so that a
 * steady camera and image size allocate nothing after the first frame.
 */
#include "trim_internal.h"

#include <string.h>

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
        if (!rv || !ru || !mu || !vv)
            return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_trim_plan_face: out of memory");
        p->cap_strips = n;
    }
    if (!p->scratch) {
        crisp_status st = crisp_arena_create(0, &p->scratch);
        if (st) return st;
    }
    crisp_arena_reset(p->scratch);
    p->strip_count = n;
    crisp_status st =
        crisp_trim_scan_density(&(crisp_trim_density_desc){.patches = desc->patches,
                                                           .patch_count = desc->patch_count,
                                                           .view_proj = desc->view_proj,
                                                           .width = desc->width,
                                                           .height = desc->height,
                                                           .v0 = desc->v0,
                                                           .v1 = desc->v1,
                                                           .strip_count = n,
                                                           .scratch = p->scratch},
                                p->rho_v, p->rho_u, p->vis_v, &p->density_stats);
    if (st) return st;
    crisp_trim_rows_from_density(p->rho_v, p->vis_v, n, desc->v0, desc->v1, p->mu, &p->clamped);
    const crisp_trim_polyline *pl = NULL;
    if (desc->piece_count > 0) {
        st = crisp_trim_tessellate(&(crisp_trim_tess_desc){.pieces = desc->pieces,
                                                           .piece_count = desc->piece_count,
                                                           .v0 = desc->v0,
                                                           .v1 = desc->v1,
                                                           .strip_count = n,
                                                           .mu = p->mu,
                                                           .row_v = p->vis_v,
                                                           .rho_u = p->rho_u},
                                   &p->polyline);
        if (st) return st;
        pl = &p->polyline;
    }
    return crisp_trim_table_build(&(crisp_trim_table_desc){.polyline = pl,
                                                           .v0 = desc->v0,
                                                           .v1 = desc->v1,
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
    crisp_trim_polyline_free(&plan->polyline);
    crisp_trim_table_free(&plan->table);
    crisp_arena_destroy(plan->scratch);
    memset(plan, 0, sizeof *plan);
}
