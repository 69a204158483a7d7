// Surface pass, tessellation control: the leaf's levels from the plan (the leaf index comes from
// the vertex stage). GL's quad domain orders its
// outer levels u = 0, v = 0, u = 1, v = 1; the plan's are t = 0, s = 1, t = 1, s = 0 (s = u,
// t = v). The plan keeps every level in 1..64 (GL_MAX_TESS_GEN_LEVEL is at least 64), so nothing
// is clamped here.
layout(vertices = 1) out;
in uint vs_leaf[];
patch out uint tc_leaf;

void main()
{
    uint L = vs_leaf[0];
    uvec4 a = leaves[3u * L], e = leaves[3u * L + 2u];
    gl_TessLevelInner[0] = float(a.w);
    gl_TessLevelInner[1] = float(a.w);
    gl_TessLevelOuter[0] = float(e.w);
    gl_TessLevelOuter[1] = float(e.x);
    gl_TessLevelOuter[2] = float(e.y);
    gl_TessLevelOuter[3] = float(e.z);
    tc_leaf = L;
}
