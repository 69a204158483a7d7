/* The frame planner's state (planner.c) and the steps of a plan that the plan in stages
 * (stages.c) shares with the one-stage plan. Private to src/render: the public API is
 * include/crisp/plan.h, the staged calls the CPU backend makes are in render_internal.h. */
#ifndef CRISP_RENDER_PLANNER_H
#define CRISP_RENDER_PLANNER_H

#include <stdint.h>

#include "crisp/plan.h"
#include "quadtree.h"
#include "ribbon.h"
#include "splat_store.h"

/* What the plan in stages keeps (stages.c): per frame the faces' stages and the stages' results,
 * from frame to frame the faces seen, whether stages pay and the faces' boxes. */
typedef struct crisp__stages {
    uint8_t *stage; /* per face: its stage (splat faces 0), STAGE_HIDDEN when found hidden */
    uint8_t *later; /* per face: planned by the current stage (in the final plan: drawn last) */
    uint8_t *skip;  /* per face: not planned by this trees build */
    size_t stage_cap, later_cap, skip_cap;
    int stage_at, stage_count;
    uint32_t hidden;              /* faces found hidden so far this frame */
    crisp_plan_leaf *kept_leaves; /* the stages' leaves, stage after stage */
    size_t kept_leaf_cap, kept_leaf_count;
    crisp_plan_ribbon_vertex *kept_ribbons; /* the stages' ribbon quads, stage after stage */
    size_t kept_ribbon_cap, kept_quads;
    uint32_t *kept; /* per face: first leaf, leaf count, first quad, quad count, tau in kept */
    float *kept_rows;
    size_t kept_cap, kept_rows_cap;
    crisp_plan_stats kept_stats; /* the stages' plan stats, summed */
    uint8_t *seen; /* per face: it had a sample in the last frame drawn in stages (the first
                      stage's faces next time: an order, not a decision) */
    size_t seen_cap;
    uint64_t seen_serial; /* the scene the marks are of (0: none) */
    /* Whether stages pay (crisp__planner_plan_near): after a frame in stages of scene pays_serial
     * that hid too little, frames are planned in one stage, and every STAGE_PROBE-th one in
     * stages again. */
    uint64_t pays_serial;
    int pays;
    uint32_t quiet;   /* frames in one stage since */
    int always;       /* crisp__planner_always_stages */
    double *face_box; /* per face: the union of its patches' boxes (of face_box_serial) */
    size_t face_box_cap;
    uint8_t *patch_in; /* per patch: its parameter box meets its face's trim pieces' box */
    size_t patch_in_cap;
    uint64_t face_box_serial, face_box_trim;
    _Atomic uint32_t *piece_mask; /* per patch: its hidden pieces in a later stage (stages.c) */
    size_t piece_mask_cap;
    double *depth_cells; /* a later stage's coarse block depth (stages.c) */
    size_t depth_cells_cap;
} crisp__stages;

/* What a face's plan record takes from the scene (planner.c: per scene, not per frame). */
typedef struct crisp__face_fixed {
    uint32_t grid_u, grid_v, flags; /* flags: CRISP_PLAN_FACE_REVERSED or 0 */
} crisp__face_fixed;

struct crisp_planner {
    crisp_planner_desc desc;
    crisp_pool *pool;
    crisp__trees *trees;
    crisp__ribbons *ribbons;
    crisp_frame_plan out;
    crisp_plan_leaf *leaves;
    size_t leaf_cap;
    crisp_plan_face *faces;
    size_t face_cap;
    crisp_plan_strip *strips;
    size_t strip_cap;
    uint32_t *row_offset;
    size_t row_cap;
    double *crossings;
    size_t crossing_cap;
    crisp_plan_ribbon_vertex *ribbon_verts, *face_ribbon; /* all; one face's (replan) */
    size_t ribbon_cap, face_ribbon_cap;
    uint32_t *ribbon_first, *ribbon_quads; /* per face */
    size_t ribbon_first_cap, ribbon_quads_cap;
    int *strips_used; /* per face: the strip count of its last trim plan (replan keeps it) */
    size_t strips_used_cap;
    uint64_t hash[4]; /* leaves, faces, table, ribbons of the last plan */
    crisp__splat_store *splats;
    uint8_t *splat_face; /* per face: drawn as splats this frame */
    size_t splat_face_cap;
    crisp__face_fixed *face_fixed; /* per face of the scene fixed_serial (fixed_count faces) */
    size_t face_fixed_cap;
    uint64_t fixed_serial;
    uint32_t fixed_count;
    /* The faces' array holds every face's plain record (no leaves, table or ribbons) with the
     * splat flag of plain_splat (lay_out_faces), hashed plain_hash; 0 once anything else wrote
     * the array. */
    int plain;
    uint8_t *plain_splat;
    size_t plain_splat_cap;
    uint64_t plain_hash;
    crisp_camera cam; /* of the last plan (a re-plan of a splatted face plans it again) */
    const crisp_scene *scene;
    int planned;
    int finished; /* the last plan was made whole (crisp_planner_last_plan) */
    int staged;   /* 0: the last plan was made in one stage; 1: in stages (final); 2: a stage's */
    crisp__stages stages;
};

/* planner.c: the steps of a plan. */

/* The per-face arrays for faces faces. */
crisp_status crisp__planner_ensure_faces(crisp_planner *p, uint32_t faces);
/* Which faces are drawn as splats this frame (p->splat_face; none when no_splats). */
crisp_status crisp__planner_choose_splats(crisp_planner *p, const crisp_scene *sc,
                                          const crisp_camera *cam);
/* The trees, leaves, tables and ribbons of the faces not in skip (NULL: the splat faces only),
 * and the plan's view fields and stats. The splat choice is made first unless splats_chosen. */
crisp_status crisp__planner_plan_faces(crisp_planner *p, const crisp_scene *sc,
                                       const crisp_camera *cam, const uint8_t *skip,
                                       int splats_chosen);
/* The visible leaves, face after face, and the faces' leaf ranges and levels. kept (NULL: none):
 * per face, its leaves are the earlier stages' (p->stages.kept_leaves) instead of the trees'. */
crisp_status crisp__planner_lay_out_leaves(crisp_planner *p, const crisp_scene *sc,
                                           const uint8_t *kept);
/* Every visible face's trim table, concatenated: strips, rows (global offsets), crossings. */
crisp_status crisp__planner_lay_out_tables(crisp_planner *p, const crisp_scene *sc);
/* The faces' ribbon ranges and patch grids, and the public plan pointed at the arrays (after
 * crisp__planner_lay_out_tables). */
void crisp__planner_point_out(crisp_planner *p, const crisp_scene *sc);
/* Leaves and tables laid out (kept: as crisp__planner_lay_out_leaves), the splats and the
 * versions published. */
crisp_status crisp__planner_finish_plan(crisp_planner *p, const crisp_scene *sc,
                                        const crisp_camera *cam, const uint8_t *kept);

/* stages.c: the stages' arrays freed (crisp_planner_destroy). */
void crisp__stages_free(crisp__stages *s);
/* The bound the later stages' face test (stages.c) takes for a piece of patch z: the screen box
 * lo, hi (pixels of a width x height image, y down) and the least W of the convex hull of the
 * piece's control points projected by m (clip space), the piece found by halving the patch splits
 * times (0..4; halving k in u when k is even, in v when odd, its upper half when bit k of piece
 * is set). 0 when a control point is not in front of the eye. For tests. */
int crisp__stages_hull_piece(const crisp_bezier_patch *z, crisp_mat4 m, int width, int height,
                             int splits, unsigned piece, double lo[2], double hi[2], double *w0);
/* The pieces (crisp__ribbons_set_hidden) of patch z (box: a box that holds it) that the later
 * stages' ribbon test finds hidden by hiz (crisp__occl_hidden's block depth of the window win of
 * a width x height image) under m, as a mask: all when the box's screen box, widened by 2 px, is
 * hidden at its least W; else each piece whose control-net hull, or those of its halvings (as
 * crisp__stages_hull_piece makes them, up to 4), is so hidden. */
uint32_t crisp__stages_patch_pieces(const crisp_bezier_patch *z, const double box[6], crisp_mat4 m,
                                    int width, int height, const int win[4], const double *hiz);
/* 1 when a later stage leaves ribbon quad v out of its kept ribbons (stages.c's quad_unseen):
 * every corner behind the eye, or its corners' screen box (pixels of a width x height image)
 * outside the window win or hidden by hiz (crisp__occl_hidden's block depth of win) at their
 * largest 1/W. For tests. */
int crisp__stages_quad_unseen(const crisp_plan_ribbon_vertex v[4], int width, int height,
                              const int win[4], const double *hiz);

#endif
