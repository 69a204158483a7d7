// Surface pass, tessellation evaluation: the rational Bezier patch at the vertex, in double
// (Bernstein bases of degree <= 15 and their derivatives), its clip position (double, then float)
// and its normal (the derivatives' cross product, turned round for reversed faces). Hands the
// leaf-local (s, t) on in float (see the precision note in common.glsl).
layout(quads, equal_spacing, ccw) in;
patch in uint tc_leaf;
uniform dmat4 view_proj;
uniform dvec2 jitter;  // the sample's offset from the pixel centre, in NDC
uniform float zconst;  // the constant clip z: window depth = zconst / W (larger = nearer)
out float te_s;
out float te_t;
out vec3 te_normal;
flat out uint te_leaf;

out gl_PerVertex {
    vec4 gl_Position;
    float gl_ClipDistance[2];
};

// Bernstein basis of degree n at x and its derivative.
void bernstein(uint n, double x, out double B[16], out double D[16])
{
    double y = 1.0LF - x;
    B[0] = 1.0LF;
    for (uint k = 1u; k < n; k++) { // degree n - 1
        double saved = 0.0LF;
        for (uint i = 0u; i < k; i++) {
            double tmp = B[i];
            B[i] = saved + y * tmp;
            saved = x * tmp;
        }
        B[k] = saved;
    }
    D[0] = -double(n) * B[0];
    for (uint i = 1u; i < n; i++) D[i] = double(n) * (B[i - 1u] - B[i]);
    D[n] = double(n) * B[n - 1u];
    double saved = 0.0LF;
    for (uint i = 0u; i < n; i++) {
        double tmp = B[i];
        B[i] = saved + y * tmp;
        saved = x * tmp;
    }
    B[n] = saved;
}

void main()
{
    uint L = tc_leaf;
    uvec4 a = leaves[3u * L], b = leaves[3u * L + 1u];
    PatchRecord p = patches[a.x];
    double scale = ldexp(1.0LF, -int(a.z));
    double s = (double(b.x) + double(gl_TessCoord.x)) * scale;
    double t = (double(b.y) + double(gl_TessCoord.y)) * scale;
    double bu[16], du[16], bv[16], dv[16];
    bernstein(p.du, s, bu, du);
    bernstein(p.dv, t, bv, dv);
    dvec4 P = dvec4(0.0LF), Ps = dvec4(0.0LF), Pt = dvec4(0.0LF);
    for (uint j = 0u; j <= p.dv; j++) {
        dvec4 row = dvec4(0.0LF), rowd = dvec4(0.0LF);
        uint base = p.first_cp + j * (p.du + 1u);
        for (uint i = 0u; i <= p.du; i++) {
            dvec4 c = cps[base + i];
            row += bu[i] * c;
            rowd += du[i] * c;
        }
        P += bv[j] * row;
        Ps += bv[j] * rowd;
        Pt += dv[j] * row;
    }
    dvec3 x = P.xyz / P.w;
    dvec3 xs = (Ps.xyz - x * Ps.w) / P.w, xt = (Pt.xyz - x * Pt.w) / P.w;
    dvec3 n = cross(xs, xt);
    if ((faces[a.y].flags & FACE_REVERSED) != 0u) n = -n;
    double nn = length(n);
    te_normal = nn > 0.0LF ? vec3(n / nn) : vec3(0.0);
    dvec4 c = view_proj * dvec4(x, 1.0LF);
    // Image rows run top-down in the framebuffer (y flipped), shifted by the sample's offset.
    gl_Position = vec4(float(c.x + c.w * jitter.x), float(-c.y + c.w * jitter.y), zconst, float(c.w));
    gl_ClipDistance[0] = float(c.z + c.w); // near plane
    gl_ClipDistance[1] = float(c.w - c.z); // far plane
    te_s = gl_TessCoord.x;
    te_t = gl_TessCoord.y;
    te_leaf = L;
}
