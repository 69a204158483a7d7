/* Compile-time checks that the plan's GPU records (include/crisp/plan.h) have the std430 layouts
 * the shaders declare: 32-bit and 64-bit members at their natural alignment, no padding the
 * shader would not see, array strides equal to the C sizes. */
#include <stddef.h>

#include "crisp/plan.h"

_Static_assert(sizeof(crisp_plan_leaf) == 48, "crisp_plan_leaf: std430 uvec4[3]");
_Static_assert(offsetof(crisp_plan_leaf, patch) == 0, "leaf.patch");
_Static_assert(offsetof(crisp_plan_leaf, face) == 4, "leaf.face");
_Static_assert(offsetof(crisp_plan_leaf, depth) == 8, "leaf.depth");
_Static_assert(offsetof(crisp_plan_leaf, tau) == 12, "leaf.tau");
_Static_assert(offsetof(crisp_plan_leaf, ix) == 16, "leaf.ix");
_Static_assert(offsetof(crisp_plan_leaf, iy) == 20, "leaf.iy");
_Static_assert(offsetof(crisp_plan_leaf, group) == 24, "leaf.group");
_Static_assert(offsetof(crisp_plan_leaf, block) == 28, "leaf.block");
_Static_assert(offsetof(crisp_plan_leaf, edge) == 32, "leaf.edge");

_Static_assert(sizeof(crisp_plan_face) == 64, "crisp_plan_face: 3 doubles + 8 uints, std430");
_Static_assert(offsetof(crisp_plan_face, v0) == 0, "face.v0");
_Static_assert(offsetof(crisp_plan_face, v1) == 8, "face.v1");
_Static_assert(offsetof(crisp_plan_face, strip_scale) == 16, "face.strip_scale");
_Static_assert(offsetof(crisp_plan_face, first_strip) == 24, "face.first_strip");
_Static_assert(offsetof(crisp_plan_face, strip_count) == 28, "face.strip_count");
_Static_assert(offsetof(crisp_plan_face, first_leaf) == 32, "face.first_leaf");
_Static_assert(offsetof(crisp_plan_face, leaf_count) == 36, "face.leaf_count");
_Static_assert(offsetof(crisp_plan_face, flags) == 40, "face.flags");
_Static_assert(offsetof(crisp_plan_face, tau_max) == 44, "face.tau_max");
_Static_assert(offsetof(crisp_plan_face, first_ribbon) == 48, "face.first_ribbon");
_Static_assert(offsetof(crisp_plan_face, ribbon_count) == 52, "face.ribbon_count");
_Static_assert(offsetof(crisp_plan_face, grid_u) == 56, "face.grid_u");
_Static_assert(offsetof(crisp_plan_face, grid_v) == 60, "face.grid_v");

_Static_assert(sizeof(crisp_plan_strip) == 24, "crisp_plan_strip: 2 doubles + 2 uints");
_Static_assert(offsetof(crisp_plan_strip, a) == 0, "strip.a");
_Static_assert(offsetof(crisp_plan_strip, row_scale) == 8, "strip.row_scale");
_Static_assert(offsetof(crisp_plan_strip, first_row) == 16, "strip.first_row");
_Static_assert(offsetof(crisp_plan_strip, row_count) == 20, "strip.row_count");

_Static_assert(sizeof(crisp_plan_ribbon_vertex) == 56,
               "crisp_plan_ribbon_vertex: dvec4 + 6 x 32-bit");
_Static_assert(offsetof(crisp_plan_ribbon_vertex, clip) == 0, "ribbon.clip");
_Static_assert(offsetof(crisp_plan_ribbon_vertex, uv) == 32, "ribbon.uv");
_Static_assert(offsetof(crisp_plan_ribbon_vertex, normal) == 40, "ribbon.normal");
_Static_assert(offsetof(crisp_plan_ribbon_vertex, face) == 52, "ribbon.face");

_Static_assert(sizeof(crisp_scene_patch_record) == 48,
               "crisp_scene_patch_record: 4 uints + 4 doubles");
_Static_assert(offsetof(crisp_scene_patch_record, first_cp) == 0, "patch.first_cp");
_Static_assert(offsetof(crisp_scene_patch_record, face) == 12, "patch.face");
_Static_assert(offsetof(crisp_scene_patch_record, u0) == 16, "patch.u0");
_Static_assert(offsetof(crisp_scene_patch_record, v1) == 40, "patch.v1");

_Static_assert(sizeof(crisp_plan_splat) == 24, "crisp_plan_splat: 6 x 32-bit, std430 scalars");
_Static_assert(offsetof(crisp_plan_splat, n) == 12, "splat.n");
_Static_assert(offsetof(crisp_plan_splat, uv) == 16, "splat.uv");
_Static_assert(sizeof(crisp_plan_splat_range) == 12, "crisp_plan_splat_range: 3 uints");

/* Not empty as a translation unit. */
size_t crisp__plan_layout_leaf_size(void);
size_t crisp__plan_layout_leaf_size(void)
{
    return sizeof(crisp_plan_leaf);
}
