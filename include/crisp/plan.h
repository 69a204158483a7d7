/* crisp plan: the frame plan, a read-only product that every backend takes as input.
 *
 * Offers:
 *   crisp_planner            opaque; owns the scratch memory of planning and the plan it returns
 *   crisp_planner_plan       plan one frame of a prepared scene for one camera
 *   crisp_planner_replan_face
 *                            re-plan one face's trim (table and ribbons) after its loops changed,
 *                            keeping every other face's plan (the trim-editing case)
 *   crisp_planner_last_plan  the last plan made (also crisp_render_cpu's, planned in stages)
 *   crisp_frame_plan         flat arrays a GPU uploads as they are: leaves, faces, trim strips,
 *                            rows and crossings concatenated over faces, ribbon quads
 *   crisp_plan_trim_test     the trim test on the flat arrays (what the fragment shader does)
 *
 * What a plan says (docs/design.md "The frame plan"):
 *   - Leaves: one record per visible cell of a Bézier patch. The cell is the square
 *     [ix, ix + 1] x [iy, iy + 1] * 2^-depth of the patch's local parameters (s, t) in [0, 1]^2.
 *     tau is the inner level (both directions), edge[] the outer levels in the order
 *     t = 0, s = 1, t = 1, s = 0 (crisp_tess_levels). Every level is in 1..CRISP_PLAN_MAX_LEVEL
 *     (64, the least GL_MAX_TESS_GEN_LEVEL any GL 4 implementation has): where the crack-free
 *     edge rule would ask for more, the planner splits the leaf instead. Edge levels are
 *     crack-free: two leaves that share an edge place the same vertices on it. Every triangle of
 *     the uniform tessellation at these levels lies within eps_px of the true surface on screen
 *     (the SLEFE bound, crisp_slefe_patch_tess_level). A leaf also covers at most
 *     CRISP_PLAN_MAX_LEAF_PX pixels across on screen, so float (s, t) inside one leaf keep
 *     2^-10 px of precision at any zoom (the GL backend interpolates local (s, t) in float and
 *     adds them to the leaf's corner in double).
 *     Leaves are grouped by face, in face order: face f owns leaves
 *     faces[f].first_leaf .. + faces[f].leaf_count - 1.
 *   - Group leaves (issue 12): a leaf with group > 0 stands for a block of nu x nv patches of its
 *     face's patch grid (nu, nv from `block`), patch `patch` its lower-left one. Its local
 *     parameters (S, T) in [0, 1]^2 map to the grid position (S nu, T nv): the patch
 *     patch + floor(T nv) * grid_u + floor(S nu) (the last column/row at S or T = 1) at its local
 *     (S nu - column, T nv - row) (crisp_plan_leaf_locate). Its levels count over the whole
 *     block, and its edges are crack-free against neighbouring leaves like any leaf's. The
 *     planner makes one where every triangle with vertices on the block's surface lies within
 *     eps_px of it (the block's screen box within eps_px, or twice the group bound's coarse-quad
 *     distance crisp_slefe_group_screen(...).quad_px within eps_px).
 *   - Trim tables: per visible face, its strips; per strip, its rows; per row, its sorted
 *     u-crossings (crisp_trim_table in include/crisp/trim.h, concatenated: strip indices are
 *     global, row indices are global, row r holds crossings[row_offset[r] .. row_offset[r+1]-1]).
 *   - Ribbons: quads of 4 vertices (triangles 0 1 2 and 0 2 3) along every visible trim curve's
 *     image on the true surface, 0.7 px wide on each side, already placed in clip space. They
 *     close the sub-pixel gaps that two faces' trim tests may leave along a shared edge; a
 *     backend draws them after the surfaces, without a trim test, where they are nearer than
 *     what is drawn by more than the depth slack (the CPU backend's fill pass). A vertex with
 *     clip[3] < 0 marks a quad that must not be drawn.
 *
 * Records that go to the GPU have std430 layouts (the C structs below equal them; sizes and
 * offsets are checked at compile time in src/render/plan_layout.c).
 */
#ifndef CRISP_PLAN_H
#define CRISP_PLAN_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/core.h"
#include "crisp/render.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CRISP_PLAN_MAX_LEVEL 64       /* tessellation levels in a plan: 1..64 */
#define CRISP_PLAN_MAX_LEAF_PX 4096.0 /* screen extent of a leaf (the planner splits larger) */
#define CRISP_PLAN_MAX_DEPTH 24       /* quadtree depth of a leaf in its patch */

/* One visible leaf. std430: 48 bytes, as uvec4[3]. */
typedef struct crisp_plan_leaf {
    uint32_t patch;   /* index into crisp_scene.patches and crisp_scene.patch_records */
    uint32_t face;    /* the patch's face */
    uint32_t depth;   /* 0..CRISP_PLAN_MAX_DEPTH */
    uint32_t tau;     /* inner level, 1..CRISP_PLAN_MAX_LEVEL */
    uint32_t ix, iy;  /* cell in the patch's 2^depth x 2^depth grid */
    uint32_t group;   /* 0: the cell above. g > 0: a group leaf (depth 0, ix = iy = 0) covering the
                         block of 2^g x 2^g patches of the face's patch grid whose lower-left patch
                         is `patch`, clipped to the grid (see `block`) */
    uint32_t block;   /* group leaves: patch columns | patch rows << 16 the block covers after
                         clipping (1..2^g each); 0 for cells */
    uint32_t edge[4]; /* outer levels: t = 0, s = 1, t = 1, s = 0; 1..CRISP_PLAN_MAX_LEVEL */
} crisp_plan_leaf;

/* Face flags. */
#define CRISP_PLAN_FACE_VISIBLE 1u    /* has leaves and a trim plan this frame */
#define CRISP_PLAN_FACE_ALL_INSIDE 2u /* no trim loops: every (u, v) in [v0, v1] is inside */
#define CRISP_PLAN_FACE_REVERSED 4u   /* normals point the other way (crisp_face.reversed) */
#define CRISP_PLAN_FACE_SPLATS 8u     /* drawn as splats this frame: no leaves, strips or ribbons */

/* One face of the scene (every face has a record, visible or not). std430: 64 bytes. */
typedef struct crisp_plan_face {
    double v0, v1;        /* the table's v-range (a v outside it is trimmed away) */
    double strip_scale;   /* strips per unit v: strip = floor((v - v0) * strip_scale) */
    uint32_t first_strip; /* into strips[] */
    uint32_t strip_count; /* 0 when the face is invisible */
    uint32_t first_leaf;  /* into leaves[] */
    uint32_t leaf_count;
    uint32_t flags;        /* CRISP_PLAN_FACE_* */
    uint32_t tau_max;      /* largest inner level among its leaves (0: invisible) */
    uint32_t first_ribbon; /* into ribbon quads (4 vertices each) */
    uint32_t ribbon_count;
    uint32_t grid_u; /* patch columns of the face's grid (the row stride of its patches) */
    uint32_t grid_v; /* patch rows */
} crisp_plan_face;

/* One strip of a face's table. std430: 24 bytes. */
typedef struct crisp_plan_strip {
    double a;           /* v of the bottom of the strip's first row */
    double row_scale;   /* rows per unit v: row = clamp(floor((v - a) * row_scale), 0, rows - 1) */
    uint32_t first_row; /* into row_offset[] (global row index) */
    uint32_t row_count; /* 0: the strip is invisible, every point of it is trimmed away */
} crisp_plan_strip;

/* One ribbon vertex. std430: 56 bytes (alignment 8). */
typedef struct crisp_plan_ribbon_vertex {
    double clip[4];  /* clip-space position; clip[3] < 0: the quad is not drawn */
    float uv[2];     /* surface parameters of the curve point */
    float normal[3]; /* unit world normal of the surface there */
    uint32_t face;
} crisp_plan_ribbon_vertex;

/* One splat (issue 12): a point sample of a trimmed face, from a set whose samples cover the face
 * (src/render/splat.h: every point of the trimmed face lies within the set's radius of a sample).
 * std430: 24 bytes, scalars only (a shader declares float arrays, not vec3). Its face is its
 * range's (every set is one face's). */
typedef struct crisp_plan_splat {
    float p[3];  /* position minus the face's splat origin (model units) */
    uint32_t n;  /* unit normal of the surface there as crisp_surface_normal gives it (not flipped
                    for reversed faces: backends flip it as they do for leaves), octahedral, two
                    16-bit integers: crisp_plan_splat_normal */
    float uv[2]; /* surface parameters of the sample */
} crisp_plan_splat;

/* A run of splats drawn this frame: splats[first .. first + count - 1], all of face `face`. */
typedef struct crisp_plan_splat_range {
    uint32_t first, count;
    uint32_t face;
} crisp_plan_splat_range;

typedef struct crisp_plan_stats {
    uint32_t patches, visible_patches, split_patches, leaves, visible_faces;
    uint32_t unresolved;   /* leaves where the bound could not be reached at the depth limit */
    uint32_t rows_clamped; /* faces whose table hit CRISP_TRIM_MAX_ROWS */
    uint32_t level_splits; /* leaves split because an edge level would exceed 64 */
    uint32_t group_leaves, grouped_patches; /* group leaves and the patches they stand for */
    uint64_t table_rows, table_bytes, ribbon_quads;
    uint64_t triangles;     /* of the leaves at their levels (crisp_tess_mesh_counts) */
    uint32_t splat_faces;   /* faces drawn as splats */
    uint64_t splats_drawn;  /* splats in splat_ranges */
    uint64_t splat_bytes;   /* of the planner's splat store */
    uint32_t splat_pending; /* faces that want a splat set not built yet (drawn as patches this
                               frame; crisp_planner_desc.splat_build_limit): plan again */
    uint32_t hidden_faces;  /* faces the CPU backend's two-stage frame found hidden by the nearer
                               faces before planning them (crisp_render_cpu; 0 otherwise) */
    double ms_levels, ms_edges, ms_trim, ms_ribbons;
} crisp_plan_stats;

/* A frame plan. Read-only for backends; valid until the planner plans again or is destroyed. */
typedef struct crisp_frame_plan {
    crisp_mat4 view_proj;  /* projection * view, column-major, OpenGL clip space */
    float view_proj_f[16]; /* the same in float, column-major */
    double eye[3];         /* camera position (for shading and depth) */
    int width, height;
    double eps_px; /* the tessellation tolerance the levels meet */

    const crisp_plan_leaf *leaves;
    uint32_t leaf_count;
    const crisp_plan_face *faces;
    uint32_t face_count; /* = the scene's face count */
    const crisp_plan_strip *strips;
    uint32_t strip_count;       /* total over faces */
    const uint32_t *row_offset; /* row_count + 1 */
    uint32_t row_count;
    const double *crossings;
    uint32_t crossing_count;
    const crisp_plan_ribbon_vertex *ribbon_vertices; /* 4 per quad */
    uint32_t ribbon_quad_count;

    /* Splats (issue 12, docs/status/issue-12-splats.md). A face with CRISP_PLAN_FACE_SPLATS is
     * drawn as its splat ranges: each splat a screen-aligned square of half-size splat_half_px
     * (x and y) centred on its projection, at the splat's own depth (1/W constant over the
     * square), with its normal and (u, v), under the usual depth test. A sample at (x, y) (pixels,
     * y down) is covered when cx - h <= x < cx + h and cy - h <= y < cy + h. The planner draws a
     * face so only when its set's radius projects, at the face's nearest point, to at most
     * splat_half_px less a margin, so every pixel centre whose ray meets the face is covered.
     * A splat's clip position, in float: splat_clip_origin[4 face + k] + sum over j of
     * view_proj_f[k + 4 j] p[j] (the face's origin is projected in double by the planner). */
    const crisp_plan_splat *splats; /* the planner's store: every face set built so far */
    uint32_t splat_count;
    const crisp_plan_splat_range *splat_ranges; /* the runs drawn this frame, nearest first (the
                                                   least W of the face's box) */
    uint32_t splat_range_count;
    const float *splat_clip_origin; /* 4 per face (face_count); set for faces drawn as splats */
    double splat_half_px;

    /* Bumped when the array's content changed since the previous plan of this planner (a backend
     * uploads only what changed). splats_version: splats[] (grown or rebuilt). */
    uint64_t leaves_version, faces_version, table_version, ribbons_version, splats_version;

    crisp_plan_stats stats;
} crisp_frame_plan;

typedef struct crisp_planner_desc {
    double eps_px;   /* screen tolerance of the tessellation; 0: 0.5 px */
    int strip_count; /* n_V per face; 0: the face's tess level times its patch rows, 8..256 */
    int max_depth;   /* patch splits; 0: CRISP_PLAN_MAX_DEPTH */
    int no_ribbons;  /* 1: no ribbon quads (for measuring them) */
    int no_groups;   /* 1: no group leaves: at least one leaf per visible patch (for measuring) */
    int no_splats;   /* 1: no face is drawn as splats (for measuring and comparing) */
    /* Splat sets built per frame (issue 12, session 13): about this many splats at most (the
     * faces whose sets are not built yet are drawn as patches this frame, with their own
     * guarantee, and stats.splat_pending counts them; the next plans build more). A viewer's
     * first frame of a large model then costs its patches instead of every splat set (imp49
     * default: 12,907 sets). Once nothing is pending a plan is the same as without a limit. 0: no
     * limit (every set the frame wants is built by it: one-shot renders, benchmarks). */
    uint64_t splat_build_limit;
} crisp_planner_desc;

typedef struct crisp_planner crisp_planner;

/* desc may be NULL (defaults). pool may be NULL: the planner then uses crisp_pool_shared(). */
crisp_status crisp_planner_create(const crisp_planner_desc *desc, crisp_pool *pool,
                                  crisp_planner **dest);
void crisp_planner_destroy(crisp_planner *planner);

/* Plan one frame. The scene must outlive the plan. Planning the same scene at the same image size
 * again allocates nothing unless the scene needs more leaves or rows than before. */
crisp_status crisp_planner_plan(crisp_planner *planner, const crisp_scene *scene,
                                const crisp_camera *cam, const crisp_frame_plan **dest);

/* The planner's last plan (crisp_planner_plan's, crisp_planner_replan_face's, or the final plan
 * of a frame that crisp_render_cpu planned in stages with its renderer's planner), NULL when it
 * has none or its last plan did not finish. Valid until the planner plans again. A frame planned
 * in stages leaves out the faces it found hidden (stats.hidden_faces: no leaves, table or
 * ribbons, not CRISP_PLAN_FACE_VISIBLE; they would draw no sample); every other face's leaves,
 * record (but its ribbon range), table and ribbon quads are those crisp_planner_plan gives it,
 * but that a face of a later stage lacks the quads the depth drawn by the earlier stages hides
 * (they too would draw no sample). */
const crisp_frame_plan *crisp_planner_last_plan(const crisp_planner *planner);

/* After face `face`'s trim pieces changed in the scene (crisp_scene_update_trim), re-plan only
 * that face's trim table and ribbons for the same camera as the last crisp_planner_plan; every
 * other face's table is kept and leaves are unchanged (leaves_version stays). */
crisp_status crisp_planner_replan_face(crisp_planner *planner, const crisp_scene *scene,
                                       uint32_t face, const crisp_frame_plan **dest);

/* The patch and its local (s, t) of leaf L at the leaf's local (S, T) in [0, 1]^2: for a cell,
 * the patch L->patch at ((ix + S), (iy + T)) * 2^-depth; for a group leaf, the patch of the
 * block under (S nu, T nv) (include above). The shaders do the same arithmetic. */
uint32_t crisp_plan_leaf_locate(const crisp_frame_plan *plan, const crisp_plan_leaf *L, double S,
                                double T, double *s, double *t);

/* The trim test on the plan's arrays: 1 when (u, v) of face `face` is inside its trim. Exactly
 * crisp_trim_table_test on the face's table (the shaders do the same arithmetic in double). */
int crisp_plan_trim_test(const crisp_frame_plan *plan, uint32_t face, double u, double v);

/* A splat's normal from its packed form (crisp_plan_splat.n): the octahedral point (x, y) =
 * (low, high 16 bits as signed integers) * 2^-15, z = 1 - |x| - |y|, folded where z < 0 ((x, y) =
 * ((1 - |y|) sign x, (1 - |x|) sign y), sign 0 = +1), divided by its length; in float, in that
 * order (the shaders do the same arithmetic). Within 1e-4 of the normal packed. */
void crisp_plan_splat_normal(uint32_t n, float dest[3]);

/* Bytes of the arrays a GPU backend uploads: leaves, faces, strips, rows, crossings, ribbons. */
size_t crisp_plan_bytes(const crisp_frame_plan *plan);

#ifdef __cplusplus
}
#endif
#endif
