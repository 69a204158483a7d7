// crisp GL backend: declarations shared by every shader (prepended after the #version line by
// src/gl/backend.c). The storage buffers hold the frame plan's arrays exactly as
// include/crisp/plan.h lays them out in C (std430; the C structs' sizes are checked at compile
// time in src/gl/backend.c and by the layout test in tests/gl).
//
// Precision (docs/status/issue-09.md): everything that decides a pixel's trim classification is
// in double: the patch evaluation (rational Bezier from the control points), the clip
// coordinates (computed relative to nothing, then cast to float for the rasterizer), the leaf's
// corner, (u, v), the strip and row lookups and the crossings. Only the leaf-local (s, t) in
// [0, 1] travel from the evaluation shader to the fragment shader in float; a leaf covers at
// most CRISP_PLAN_MAX_LEAF_PX = 4096 px, so float (s, t) keep 4096 * 2^-24 = 2^-12 px, far below
// the 1 px trim guarantee, at any zoom (tested at fov 1e-4 and 1e-6 degree).

#define FACE_ALL_INSIDE 2u
#define FACE_REVERSED 4u

struct Face {
    double v0, v1, strip_scale;
    uint first_strip, strip_count, first_leaf, leaf_count;
    uint flags, tau_max, first_ribbon, ribbon_count;
    uint grid_u, grid_v;
};
struct Strip {
    double a, row_scale;
    uint first_row, row_count;
};
struct RibbonVertex {
    double clip[4];
    float uv[2];
    float normal[3];
    uint face;
};
struct PatchRecord {
    uint first_cp, du, dv, face;
    double u0, u1, v0, v1;
};

layout(std430, binding = 0) readonly buffer Leaves { uvec4 leaves[]; };        // 3 per leaf
layout(std430, binding = 1) readonly buffer Faces { Face faces[]; };
layout(std430, binding = 2) readonly buffer Strips { Strip strips[]; };
layout(std430, binding = 3) readonly buffer Rows { uint row_offset[]; };
layout(std430, binding = 4) readonly buffer Crossings { double crossings[]; };
layout(std430, binding = 5) readonly buffer Ribbons { RibbonVertex ribbon[]; };
layout(std430, binding = 6) readonly buffer Patches { PatchRecord patches[]; };
layout(std430, binding = 7) readonly buffer ControlPoints { dvec4 cps[]; };
layout(std430, binding = 8) readonly buffer FaceColors { vec4 face_color[]; };

// The trim test of include/crisp/plan.h (crisp_plan_trim_test, which is crisp_trim_table_test
// on the face's table), the same arithmetic in double: 1 inside, 0 trimmed away.
bool trim_test(uint f, double u, double v)
{
    Face F = faces[f];
    if (!(v >= F.v0 && v <= F.v1)) return false;
    if ((F.flags & FACE_ALL_INSIDE) != 0u) return true;
    uint n = F.strip_count;
    if (n == 0u) return false;
    double fi = (v - F.v0) * F.strip_scale; // >= 0 here
    uint i = fi < double(n) ? uint(fi) : n - 1u;
    Strip S = strips[F.first_strip + i];
    uint mu = S.row_count;
    if (mu == 0u) return false;
    double fj = (v - S.a) * S.row_scale;
    uint j = fj > 0.0LF ? (fj < double(mu) ? uint(fj) : mu - 1u) : 0u; // clamped to the rows
    uint r = S.first_row + j;
    uint lo = row_offset[r], hi = row_offset[r + 1u], first = lo;
    while (lo < hi) { // crossings strictly left of u
        uint mid = lo + (hi - lo) / 2u;
        if (crossings[mid] < u)
            lo = mid + 1u;
        else
            hi = mid;
    }
    return ((lo - first) & 1u) != 0u;
}

// The patch of leaf L under its leaf-local (S, T), and the patch-local (s, t) there
// (crisp_plan_leaf_locate): a cell is [ix, ix + 1] x [iy, iy + 1] * 2^-depth of its patch's
// local parameters; a group leaf (group > 0) spans nu x nv patches of its face's grid, its
// lower-left patch first, (S, T) mapping to the grid position (S nu, T nv).
uint leaf_locate(uvec4 a, uvec4 b, double S, double T, out double s, out double t)
{
    if (b.z == 0u) {
        double scale = ldexp(1.0LF, -int(a.z));
        s = (double(b.x) + S) * scale;
        t = (double(b.y) + T) * scale;
        return a.x;
    }
    uint nu = b.w & 0xffffu, nv = b.w >> 16;
    double x = S * double(nu), y = T * double(nv);
    double cx = clamp(floor(x), 0.0LF, double(nu - 1u)), cy = clamp(floor(y), 0.0LF, double(nv - 1u));
    s = x - cx;
    t = y - cy;
    return a.x + uint(cy) * faces[a.y].grid_u + uint(cx);
}

// (u, v) of a point of leaf L at leaf-local (s, t): the patch maps its local parameters onto
// [u0, u1] x [v0, v1].
dvec2 leaf_uv(uint L, double s, double t)
{
    uvec4 a = leaves[3u * L], b = leaves[3u * L + 1u];
    double ps, pt;
    PatchRecord p = patches[leaf_locate(a, b, s, t, ps, pt)];
    return dvec2(p.u0 + ps * (p.u1 - p.u0), p.v0 + pt * (p.v1 - p.v0));
}

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

// Homogeneous point and partials of the rational Bezier patch of degrees (du, dv) whose control
// points start at first_cp, at its local (s, t), in double.
void patch_derivs(uint first_cp, uint du_, uint dv_, double s, double t, out dvec4 P, out dvec4 Ps,
                  out dvec4 Pt)
{
    double bu[16], du[16], bv[16], dv[16];
    bernstein(du_, s, bu, du);
    bernstein(dv_, t, bv, dv);
    P = dvec4(0.0LF), Ps = dvec4(0.0LF), Pt = dvec4(0.0LF);
    for (uint j = 0u; j <= dv_; j++) {
        dvec4 row = dvec4(0.0LF), rowd = dvec4(0.0LF);
        uint base = first_cp + j * (du_ + 1u);
        for (uint i = 0u; i <= du_; i++) {
            dvec4 c = cps[base + i];
            row += bu[i] * c;
            rowd += du[i] * c;
        }
        P += bv[j] * row;
        Ps += bv[j] * rowd;
        Pt += dv[j] * row;
    }
}

// Point of the patch at its local (s, t), and the derivatives' cross product (not unit, not
// turned round for reversed faces), in double.
dvec3 eval_patch(uint first_cp, uint du_, uint dv_, double s, double t, out dvec3 n)
{
    dvec4 P, Ps, Pt;
    patch_derivs(first_cp, du_, dv_, s, t, P, Ps, Pt);
    dvec3 x = P.xyz / P.w;
    dvec3 xs = (Ps.xyz - x * Ps.w) / P.w, xt = (Pt.xyz - x * Pt.w) / P.w;
    n = cross(xs, xt);
    // At an apex, a pole or a collapsed side one partial vanishes (rounding leaves it ~1e-16 of
    // the other, pointing anywhere) or the two are parallel: there the normal is the limit from
    // inside the patch, the cross product one millionth of the way towards the patch's middle
    // (each generator of a cone keeps its own normal), as the CPU backend does
    // (crisp__normal_degenerate, crisp_bezier_patch_normal).
    double aa = dot(xs, xs), bb = dot(xt, xt), nn = dot(n, n);
    if (!(aa > 1e-18LF * bb) || !(bb > 1e-18LF * aa) || !(nn > 1e-18LF * aa * bb)) {
        patch_derivs(first_cp, du_, dv_, s + 1e-6LF * (0.5LF - s), t + 1e-6LF * (0.5LF - t), P, Ps, Pt);
        dvec3 y = P.xyz / P.w;
        n = cross((Ps.xyz - y * Ps.w) / P.w, (Pt.xyz - y * Pt.w) / P.w);
    }
    return x;
}

// The same for patch record `patch_index`.
dvec3 patch_point(uint patch_index, double s, double t, out dvec3 n)
{
    PatchRecord p = patches[patch_index];
    return eval_patch(p.first_cp, p.du, p.dv, s, t, n);
}
