/* Splats (issue 12): point samples that cover a trimmed face, for faces so small on screen that
 * drawing their samples as squares of about a pixel is cheaper than planning, tessellating and
 * trimming their patches (instanced and far models: docs/status/issue-12-splats.md).
 *
 * Offers:
 *   crisp__splat_build     the samples of one face of a scene at a covering radius
 *   crisp__splat_set_free
 *
 * The guarantee a set carries: every point of the trimmed face (its surface over the (u, v)
 * that crisp_trim_exact_classify puts inside its loops; the whole domain for a face without
 * loops) lies within `radius` (Euclidean, model units) of the position of one of its splats, and
 * every splat is a point of the trimmed face (on it or on its trim curves); more finely, within
 * the rho of some splat (each splat's own cell radius). The radius is proven
 * (control-net convex hulls), not estimated; tests check it at dense samples. */
#ifndef CRISP_RENDER_SPLAT_H
#define CRISP_RENDER_SPLAT_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/plan.h"
#include "crisp/render.h"

/* One sample as the builder makes it (the store packs it into a crisp_plan_splat). */
typedef struct crisp_splat {
    float p[3];  /* position minus the set's origin (model units) */
    float n[3];  /* unit normal of the surface there (crisp_surface_normal) */
    float uv[2]; /* surface parameters of the sample */
    float rho;   /* the radius of its cell: every point of the trimmed face lies within the rho
                    of some splat of the set (at most the set's radius rounded up to a float) */
} crisp_splat;

typedef struct crisp_splat_set {
    double origin[3]; /* splats[i].p are positions minus origin (float offsets stay
                         precise for faces far from the model's origin) */
    double radius;    /* the covering radius the set is proven to meet (<= the asked) */
    uint32_t count;
    crisp_splat *splats; /* count */
} crisp_splat_set;

/* The splats of face `face` of `scene` with a covering radius at most `radius` (> 0). Fails with
 * CRISP_ERR_LIMIT (no partial set) when the radius would need more than max_count splats (0: no
 * limit), so a caller can bound memory. */
crisp_status crisp__splat_build(const crisp_scene *scene, uint32_t face, double radius,
                                uint32_t max_count, crisp_splat_set *dest);
void crisp__splat_set_free(crisp_splat_set *set);

/* The packed form of unit normal n (crisp_plan_splat.n; crisp_plan_splat_normal unpacks it). */
uint32_t crisp__splat_pack_normal(const float n[3]);

#endif
