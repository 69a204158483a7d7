// Surface pass, tessellation evaluation: the rational Bezier patch at the vertex, in double
// (Bernstein bases of degree <= 15 and their derivatives), its clip position (double, then float)
// and its normal (the derivatives' cross product, turned round for reversed faces). Hands the
// leaf-local (s, t) on in float (see the precision note in common.glsl).
layout(quads, equal_spacing, ccw) in;
patch in uint tc_leaf;
patch in uvec4 tc_patch;
patch in dvec2 tc_corner;
patch in double tc_scale;
patch in uvec4 tc_group;
uniform dmat4 view_proj;
uniform dvec2 jitter;  // the sample's offset from the pixel centre, in NDC
uniform float zconst;  // the constant clip z: window depth = zconst / W (larger = nearer)
uniform dvec4 clip_plane;  // the section plane: kept where dot(clip_plane, (x, 1)) >= 0; 0: none
out float te_s;
out float te_t;
out vec3 te_normal;
flat out uint te_leaf;

out gl_PerVertex {
    vec4 gl_Position;
    float gl_ClipDistance[3];
};

// A vertex on an outer edge of level n lies at leaf-local k / n along it. The tessellator's float
// coordinate is k / n rounded (Mesa's to 2^-16), and a leaf beside the edge of another size
// places the same point at (k' / n' + offset) / 2, rounded differently: the two leaves' vertices
// differed by up to 2^-17 of the leaf, and a sample on their shared edge could fall between them
// (trim_e2e_full_gl: one pixel of a plane seen from 0.01 above it). The plan's crack-free levels
// put both leaves' vertices on one grid of n 2^depth per patch, so the patch-local parameter is
// taken as the exact rational (i n + k) / (n 2^depth) (i: the cell's index), rounded once: the
// same double from either side. Elsewhere the tessellator's coordinate is used as it is.
// Returns the patch-local parameter of a cell; *local is the leaf-local coordinate.
double cell_param(double corner, double scale, float c, float level, bool on_edge, out double local)
{
    local = double(c);
    if (!on_edge) return corner + local * scale;
    double n = double(round(level)), k = double(round(c * level));
    local = k / n;
    return ((corner / scale) * n + k) / (n / scale);
}

// The same for a group leaf of `count` patches along the axis: the patch under the vertex (its
// column or row, *cell) and the local parameter in it, exactly (k count - cell n) / n on an edge.
double group_param(uint count, float c, float level, bool on_edge, out double cell, out double local)
{
    double m = double(count);
    local = double(c);
    if (!on_edge) {
        double g = local * m;
        cell = clamp(floor(g), 0.0LF, m - 1.0LF);
        return g - cell;
    }
    double n = double(round(level)), k = double(round(c * level));
    local = k / n;
    cell = min(floor(k * m / n), m - 1.0LF);
    return (k * m - cell * n) / n;
}

void main()
{
    // Quad domain: outer level 0 is the edge u = 0, 1 v = 0, 2 u = 1, 3 v = 1.
    bool xe = gl_TessCoord.y == 0.0 || gl_TessCoord.y == 1.0; // x runs along an outer edge
    bool ye = gl_TessCoord.x == 0.0 || gl_TessCoord.x == 1.0;
    float xl = gl_TessCoord.y == 0.0 ? gl_TessLevelOuter[1] : gl_TessLevelOuter[3];
    float yl = gl_TessCoord.x == 0.0 ? gl_TessLevelOuter[0] : gl_TessLevelOuter[2];
    double ex, ey;
    dvec3 n;
    dvec3 x;
    if (tc_group.y == 0u) {
        double s = cell_param(tc_corner.x, tc_scale, gl_TessCoord.x, xl, xe, ex);
        double t = cell_param(tc_corner.y, tc_scale, gl_TessCoord.y, yl, ye, ey);
        x = eval_patch(tc_patch.x, tc_patch.y, tc_patch.z, s, t, n);
    } else {
        // A group leaf: the patch of its block under the vertex (leaf_locate in common.glsl).
        double cx, cy;
        double s = group_param(tc_group.y, gl_TessCoord.x, xl, xe, cx, ex);
        double t = group_param(tc_group.z, gl_TessCoord.y, yl, ye, cy, ey);
        PatchRecord p = patches[tc_group.x + uint(cy) * tc_group.w + uint(cx)];
        x = eval_patch(p.first_cp, p.du, p.dv, s, t, n);
    }
    if (tc_patch.w != 0u) n = -n;
    double nn = length(n);
    te_normal = nn > 0.0LF ? vec3(n / nn) : vec3(0.0);
    dvec4 c = view_proj * dvec4(x, 1.0LF);
    // Image rows run top-down in the framebuffer (y flipped), shifted by the sample's offset.
    gl_Position = vec4(float(c.x + c.w * jitter.x), float(-c.y + c.w * jitter.y), zconst, float(c.w));
    gl_ClipDistance[0] = float(c.z + c.w); // near plane
    gl_ClipDistance[1] = float(c.w - c.z); // far plane
    gl_ClipDistance[2] = float(dot(clip_plane, dvec4(x, 1.0LF)));
    te_s = float(ex);
    te_t = float(ey);
    te_leaf = tc_leaf;
}
