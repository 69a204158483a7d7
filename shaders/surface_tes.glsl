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

void main()
{
    double s = tc_corner.x + double(gl_TessCoord.x) * tc_scale;
    double t = tc_corner.y + double(gl_TessCoord.y) * tc_scale;
    dvec3 n;
    dvec3 x;
    if (tc_group.y == 0u) {
        x = eval_patch(tc_patch.x, tc_patch.y, tc_patch.z, s, t, n);
    } else {
        // A group leaf: the patch of its block under the vertex (leaf_locate in common.glsl).
        double gx = double(gl_TessCoord.x) * double(tc_group.y);
        double gy = double(gl_TessCoord.y) * double(tc_group.z);
        double cx = clamp(floor(gx), 0.0LF, double(tc_group.y - 1u));
        double cy = clamp(floor(gy), 0.0LF, double(tc_group.z - 1u));
        PatchRecord p = patches[tc_group.x + uint(cy) * tc_group.w + uint(cx)];
        x = eval_patch(p.first_cp, p.du, p.dv, gx - cx, gy - cy, n);
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
    te_s = gl_TessCoord.x;
    te_t = gl_TessCoord.y;
    te_leaf = tc_leaf;
}
