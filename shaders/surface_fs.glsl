// Surface pass, fragment stage (one sample per pass): (u, v) in double from the leaf's corner and
// the interpolated local (s, t), the plan's trim test in double, then the sample's normal, depth
// W, (u, v) and face.
in float te_s;
in float te_t;
in vec3 te_normal;
flat in uint te_leaf;
layout(location = 0) out vec4 o_nw;  // world normal, camera-space depth W
layout(location = 1) out vec2 o_uv;
layout(location = 2) out int o_face;

void main()
{
    // The sample lies in its triangle, so its true leaf-local (s, t) are in [0, 1]; the float
    // interpolation may overshoot by a rounding at the leaf's edge, and where that edge is the
    // face's v0 or v1 (the wrap seam of a closed face, where no ribbon is drawn) the trim test's
    // range check then discarded a sample the other side of the seam did not cover (one pixel of
    // the torus's far side, test_cracks' test_torus_seam on GL).
    dvec2 uv = leaf_uv(te_leaf, clamp(double(te_s), 0.0LF, 1.0LF), clamp(double(te_t), 0.0LF, 1.0LF));
    uint f = leaves[3u * te_leaf].y;
    if (!trim_test(f, uv.x, uv.y)) discard;
    o_nw = vec4(te_normal, 1.0 / gl_FragCoord.w);
    o_uv = vec2(uv);
    o_face = int(f);
}
