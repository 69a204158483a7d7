// Surface pass, tessellation control: the leaf's levels from the plan (the leaf index comes from
// the vertex stage), and what the evaluation stage needs of the leaf, read once per leaf here
// rather than once per vertex there. GL's quad domain orders its outer levels u = 0, v = 0,
// u = 1, v = 1; the plan's are t = 0, s = 1, t = 1, s = 0 (s = u, t = v). The plan keeps every
// level in 1..64 (GL_MAX_TESS_GEN_LEVEL is at least 64), so nothing is clamped here.
layout(vertices = 1) out;
in uint vs_leaf[];
patch out uint tc_leaf;
patch out uvec4 tc_patch;   // first control point, du, dv, reversed (1) or not (0)
patch out dvec2 tc_corner;  // (ix, iy) * 2^-depth
patch out double tc_scale;  // 2^-depth
patch out uvec4 tc_group;   // group leaves: lower-left patch, nu, nv, the face's grid_u; 0 else

void main()
{
    uint L = vs_leaf[0];
    uvec4 a = leaves[3u * L], b = leaves[3u * L + 1u], e = leaves[3u * L + 2u];
    gl_TessLevelInner[0] = float(a.w);
    gl_TessLevelInner[1] = float(a.w);
    gl_TessLevelOuter[0] = float(e.w);
    gl_TessLevelOuter[1] = float(e.x);
    gl_TessLevelOuter[2] = float(e.y);
    gl_TessLevelOuter[3] = float(e.z);
    tc_leaf = L;
    PatchRecord p = patches[a.x];
    tc_patch = uvec4(p.first_cp, p.du, p.dv, (faces[a.y].flags & FACE_REVERSED) != 0u ? 1u : 0u);
    double scale = ldexp(1.0LF, -int(a.z));
    tc_scale = scale;
    tc_corner = dvec2(double(b.x) * scale, double(b.y) * scale);
    tc_group = b.z == 0u ? uvec4(0u) : uvec4(a.x, b.w & 0xffffu, b.w >> 16, faces[a.y].grid_u);
}
