/* The frame planner's data (see plan.c): per patch a quadtree of leaves with tess levels and
 * crack-free edge levels, per visible face a trim plan. Shared by the CPU backend, the benchmarks
 * and the tests; the GL backend will read the same plan. */
#ifndef CRISP_RENDER_PLAN_H
#define CRISP_RENDER_PLAN_H

#include <stdint.h>

#include "crisp/render.h"
#include "crisp/tess.h"
#include "crisp/trim.h"

#define CRISP_PLAN_MAX_DEPTH 24

typedef struct crisp_plan_leaf {
    uint32_t ix, iy;  /* cell in the patch's 2^depth x 2^depth grid of local parameters */
    uint8_t depth;
    uint8_t culled;   /* outside the frustum (or an unresolvable sliver at the eye plane) */
    uint16_t tau;     /* inner level, 1..64 */
    uint32_t edge[4]; /* edge levels: t = 0, s = 1, t = 1, s = 0 (as crisp_tess_levels) */
} crisp_plan_leaf;

typedef struct crisp_plan_node {
    int32_t child; /* first of four children ((0,0), (1,0), (0,1), (1,1)), or -1 for a leaf */
    int32_t leaf;  /* index into the patch's leaves when a leaf */
} crisp_plan_node;

typedef struct crisp_patch_plan {
    crisp_plan_node *nodes; /* in the planner's per-worker arenas, valid until the next frame */
    crisp_plan_leaf *leaves;
    uint32_t node_count, leaf_count, visible_leaves;
    uint32_t unresolved; /* leaves left at the depth limit (see crisp_plan_stats) */
} crisp_patch_plan;

typedef struct crisp_plan_desc {
    double eps_px;   /* screen tolerance of the tessellation; 0: 0.5 px */
    int strip_count; /* n_V per face; 0: the face's tess level times its patch rows, 8..256 */
    int max_depth;   /* patch splits; 0: CRISP_PLAN_MAX_DEPTH */
} crisp_plan_desc;

typedef struct crisp_plan_stats {
    uint32_t patches, visible_patches, split_patches, leaves, visible_faces;
    uint32_t unresolved;  /* leaves where the 0.5 px bound could not be reached at the depth limit */
    uint32_t rows_clamped; /* faces whose table hit CRISP_TRIM_MAX_ROWS */
    uint64_t table_rows, table_bytes;
    double ms_levels, ms_edges, ms_trim;
} crisp_plan_stats;

typedef struct crisp_plan {
    crisp_mat4 view_proj;
    int width, height, max_depth;
    crisp_patch_plan *patches;
    size_t patch_cap;
    crisp_trim_plan *trims; /* per face */
    uint32_t *face_tau;     /* per face: largest visible tau, 0 when the face is not visible */
    uint32_t face_cap;
    crisp_arena **arenas;
    void **build_state;
    crisp_status *worker_status;
    int worker_cap;
    crisp_plan_stats stats;
} crisp_plan;

crisp_status crisp_plan_create(crisp_plan **dest);
void crisp_plan_destroy(crisp_plan *plan);
/* Plan one frame. pool may be NULL. Reuses every buffer: the same scene and image size plan
 * again without allocating (unless the scene needs more leaves or rows than before). */
crisp_status crisp_plan_frame(crisp_plan *plan, const crisp_scene *scene, const crisp_camera *cam,
                              const crisp_plan_desc *desc, crisp_pool *pool);

#endif
