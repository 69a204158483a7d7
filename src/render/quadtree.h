/* The frame planner's per-patch quadtrees (see quadtree.c): per patch a quadtree of cells with
 * tess levels and crack-free edge levels, and per visible face a trim plan. planner.c turns them
 * into the public flat plan (include/crisp/plan.h). */
#ifndef CRISP_RENDER_QUADTREE_H
#define CRISP_RENDER_QUADTREE_H

#include <stdatomic.h>
#include <stdint.h>

#include "crisp/plan.h"
#include "crisp/render.h"
#include "crisp/tess.h"
#include "crisp/trim.h"

typedef struct crisp__cell {
    uint32_t ix, iy; /* cell in the patch's 2^depth x 2^depth grid of local parameters; for a
                        group leaf (group > 0): the patch columns and rows of its block */
    uint8_t depth;
    uint8_t culled;   /* outside the frustum (or an unresolvable sliver at the eye plane) */
    uint8_t group;    /* 0: a cell of its patch; g > 0: a group leaf over the 2^g x 2^g block of the
                         face's patch grid whose lower-left patch is this tree's (clipped to the
                         grid: ix x iy patches), depth 0 */
    uint16_t tau;     /* inner level, 1..64 */
    uint32_t edge[4]; /* edge levels: t = 0, s = 1, t = 1, s = 0 (as crisp_tess_levels) */
} crisp__cell;

typedef struct crisp__node {
    int32_t child; /* first of four children ((0,0), (1,0), (0,1), (1,1)), or -1 for a leaf */
    int32_t leaf;  /* index into the patch's leaves when a leaf */
} crisp__node;

typedef struct crisp__patch_tree {
    crisp__node *nodes; /* in the planner's per-worker arenas, valid until the next frame */
    crisp__cell *leaves;
    uint32_t node_count, leaf_count, visible_leaves;
    uint32_t unresolved; /* leaves left at the depth limit (see crisp_plan_stats) */
} crisp__patch_tree;

typedef struct crisp__trees_desc {
    double eps_px;   /* screen tolerance of the tessellation; 0: 0.5 px */
    int strip_count; /* n_V per face; 0: the face's tess level times its patch rows, 8..256 */
    int max_depth;   /* patch splits; 0: CRISP_PLAN_MAX_DEPTH */
    int no_groups;   /* 1: no group leaves (one leaf per visible patch at least) */
    const uint8_t *skip_faces; /* per face: 1 = drawn otherwise (splats): no leaves, no trim
                                  plan (NULL: none) */
} crisp__trees_desc;

/* A cell that must be split although its own bound does not ask for it (one of its edge levels
 * would exceed CRISP_PLAN_MAX_LEVEL). Sorted by (patch, depth, iy, ix). */
typedef struct crisp__forced {
    uint32_t patch, depth, ix, iy;
} crisp__forced;

/* Patch groups (patch_groups.c): a per-face quadtree of aligned blocks of the patch grid, walked
 * once per frame to cull whole blocks or draw them as single group leaves. */
typedef struct crisp__groups crisp__groups;
enum {
    CRISP__PATCH_OPEN = 0,    /* planned by its own quadtree */
    CRISP__PATCH_CULLED = 1,  /* outside the frustum */
    CRISP__PATCH_SMALL = 2,   /* one tau-1 leaf */
    CRISP__PATCH_GROUP = 3,   /* the lower-left patch of a group leaf's block: holds the leaf */
    CRISP__PATCH_GROUPED = 4, /* another patch of a group leaf's block: no leaf of its own */
};
typedef struct crisp__patch_groups {
    uint8_t *mode;     /* per patch, written for the active patches: CRISP__PATCH_* */
    uint8_t *group_g;  /* per patch, where mode is CRISP__PATCH_GROUP: the block's g (bits 0-3)
                          and the leaf's tau as log2 (bits 4-7: 0 for tau 1); NULL: no group
                          leaves */
    uint32_t **active; /* the patches that get a tree this frame, ascending (grown as needed) */
    size_t *active_count, *active_cap;
    const uint8_t *skip_faces; /* per face: 1 = not planned this frame (drawn as splats: every
                                  patch of it gets no tree, like a culled one); NULL: none */
} crisp__patch_groups;
crisp_status crisp__groups_create(crisp__groups **dest);
void crisp__groups_destroy(crisp__groups *g);
/* The active patches (those that get a tree of their own: planned by their quadtree, one tau-1
 * leaf, or the lower-left patch of a group leaf's block) with their modes; the other patches are
 * culled or drawn by a group leaf, and nothing per patch is written for them, so the walk costs
 * what is on screen (the hierarchy is rebuilt when the scene changes). gx, gy: the widened
 * frustum's NDC half-extents; eps: pixels. */
crisp_status crisp__groups_classify(crisp__groups *g, const crisp_scene *sc, crisp_mat4 view_proj,
                                    int width, int height, double gx, double gy, double eps,
                                    crisp_pool *pool, crisp__patch_groups *out);
/* 1 when the last classify found face's whole untrimmed surface within 0.7 px in x and y on
 * screen: every point of it is then within a pixel of its trim curves, so any trim decision is
 * allowed there and the face is planned without trim loops (drawn whole, no table, no ribbons).
 */
int crisp__groups_face_small(const crisp__groups *g, uint32_t face);
/* The screen extent in pixels (largest of x and y) of face's box in the last classify; INFINITY
 * when it reaches the eye plane or is unknown. */
double crisp__groups_face_px(const crisp__groups *g, uint32_t face);
/* For a patch that is not active in the last classify: the lower-left patch of the group leaf's
 * block that draws it, or q itself when it is culled. (Active patches: q.) One array read for
 * a patch on the perimeter of a group leaf's block (every patch the edge rule asks about), else
 * O(depth). */
uint32_t crisp__groups_owner(const crisp__groups *g, const crisp_scene *sc, uint32_t q);
/* The patch's crisp__rational_sigmas, formed with the hierarchy of scene sc (view-independent,
 * kept until the scene changes), or NULL when they were not formed (no hierarchy for its face, or
 * the hierarchy is of another scene): the caller then forms them. */
const double *crisp__groups_patch_sigmas(const crisp__groups *g, const crisp_scene *sc,
                                         uint32_t patch);
/* The crisp__rational_sigmas of quarter `quarter` (ix + 2 iy: [ix / 2, (ix + 1) / 2] x ..) of
 * scene patch `patch`, whose control points are q (build_cell's depth-1 cell: always the same
 * numbers for the same patch): formed from q the first time, then kept until the scene changes.
 * NULL where the patch's weights do not vary or the hierarchy is of another scene. A patch's
 * quarters are asked for by the one worker that plans it (no lock). */
const double *crisp__groups_quarter_sigmas(crisp__groups *g, const crisp_scene *sc, uint32_t patch,
                                           int quarter, const crisp_bezier_patch *q);
/* Bumped whenever classify rebuilt the hierarchy for a new scene (1 after the first): what is
 * built per face from the scene's patches is rebuilt when it changes. */
uint64_t crisp__groups_generation(const crisp__groups *g);
/* Test hook (tests/render/test_group_leaves.c): for every block of more than one patch in the
 * hierarchy of sc (built if needed), under the affine map m, per clip coordinate x, y, w: the
 * ranges group_leaf_ok's O(1) bound takes for the deviations of the block's Euclidean control
 * points from the bilinear through its corners ([lo, hi]: the coordinate box and the
 * principal-axes box together; box: the coordinate box alone; w: the witnesses), and their
 * range over the control points computed directly (exact). rational: the block's weights vary. */
typedef struct crisp__groups_dev_sample {
    double lo[3], hi[3], box_lo[3], box_hi[3], wlo[3], whi[3], exact_lo[3], exact_hi[3];
    uint32_t face, patches;
    int rational;
} crisp__groups_dev_sample;
crisp_status crisp__groups_test_deviations(crisp__groups *g, const crisp_scene *sc, crisp_mat4 m,
                                           void (*visit)(void *ctx,
                                                         const crisp__groups_dev_sample *s),
                                           void *ctx);

/* Test hook (tests/render/test_group_leaves.c): patch_groups.c's quarter cells of patch p (its
 * weights equal) under view_proj: 1 when each quarter ([0, 1/2]^2 .. of its parameters) passes as
 * a cell of a group leaf (every triangle with vertices on the quarter within eps on screen and
 * eps pixels' world size along the view); 0 otherwise or when p is not tried. */
int crisp__groups_test_quarters(const crisp_bezier_patch *p, crisp_mat4 view_proj, int width,
                                int height, double eps);

#define TREE_CHUNKS 64 /* fixed work ranges of the tree pass, one arena each */

typedef struct crisp__trees {
    crisp_mat4 view_proj;
    int width, height, max_depth;
    crisp__patch_tree *patches;
    size_t patch_cap;
    crisp_trim_plan *trims;           /* per face */
    crisp_trim_density_tree *density; /* per face: blocks for the trim density bound */
    uint64_t *density_gen;            /* per face: groups generation it was built at (0: none) */
    crisp_trim_lod *lod; /* per face: coarse trim polylines of faces a few pixels across */
    uint64_t *lod_key;   /* per face: the scene's trim_serial it was built from (0: none) */
    uint32_t *lod_face;  /* per face: the face whose lod it uses (the first with its pieces) */
    uint64_t lod_map;    /* the trim_serial lod_face was made for (0: none) */
    uint32_t *lod_todo;  /* faces whose lod this build makes */
    size_t lod_todo_cap;
    uint32_t *face_tau; /* per face: largest visible tau, 0 when the face is not visible */
    float *face_rows;   /* per visible face: largest tessellation rows per patch row of a leaf
                           (tau; a group leaf's tau over the patch rows of its block) */
    uint32_t face_cap;
    uint32_t *visible; /* the faces with face_tau > 0 as crisp__trees_build set it, ascending (its
                          per-face passes go over these, not every face: issue 12's far views draw
                          most faces as splats) */
    size_t visible_count, visible_cap;
    crisp_arena **arenas;
    void **build_state;
    crisp_status *worker_status;
    int worker_cap;
    size_t *trim_used;   /* per worker: the most trim scratch (arenas) one face took this build */
    size_t trim_scratch; /* the most any face took so far: reserved in every worker's arena */
    crisp__forced *forced;
    size_t forced_count, forced_cap;
    uint32_t *redo; /* patches to rebuild with forced splits */
    size_t redo_cap;
    crisp__groups *groups;                  /* patch groups of the last scene */
    crisp_arena *chunk_arenas[TREE_CHUNKS]; /* nodes and leaves of the tree pass's ranges */
    uint8_t *patch_mode;                    /* per active patch this frame: CRISP__PATCH_* */
    size_t mode_cap;
    uint32_t *active; /* the patches with a tree this frame (patches[p] valid), ascending */
    size_t active_count, active_cap;
    uint32_t *tree_frame; /* per patch: the build that wrote patches[p] */
    size_t tree_frame_cap;
    uint32_t frame;   /* builds so far */
    uint8_t *group_g; /* per patch this frame (group leaves' lower-left patches): the block's g */
    size_t group_g_cap;
    int no_groups; /* 1: no group leaves (crisp__trees_desc.no_groups) */
    /* Sub-patches kept across frames (quadtree.c, cell_patch): per scene patch its block in keep
     * (NULL: none yet), the blocks carved from keep (keep_bytes, made once per scene) at
     * keep_used; keep_serial: the scene they are of (0: none). */
    struct crisp__sub_keep **keep_of;
    size_t keep_of_cap;
    unsigned char *keep;
    size_t keep_bytes;
    _Atomic size_t keep_used;
    uint64_t keep_serial;
    int keep_off; /* 1: no sub-patch kept or read (crisp__trees_keep_subpatches) */
    crisp_plan_stats stats;
} crisp__trees;

crisp_status crisp__trees_create(crisp__trees **dest);
void crisp__trees_destroy(crisp__trees *plan);
/* Plan one frame. pool may be NULL. Reuses every buffer: the same scene and image size plan
 * again without allocating (unless the scene needs more leaves or rows than before). */
crisp_status crisp__trees_build(crisp__trees *plan, const crisp_scene *scene,
                                const crisp_camera *cam, const crisp__trees_desc *desc,
                                crisp_pool *pool);
/* Test hook (tests/render/test_plan.c): on 0, the builds neither keep nor read sub-patches across
 * frames (every cell's sub-patch cut afresh, as before session 18); on 1 (the default), they do. */
void crisp__trees_keep_subpatches(crisp__trees *plan, int on);
/* Re-plan face f's trim for the camera of the last build (its strips' count is kept). */
crisp_status crisp__trees_replan_trim(crisp__trees *plan, const crisp_scene *scene, uint32_t f,
                                      int strip_count);

#endif
