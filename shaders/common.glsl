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

// The quality of a cross product n = a x b from |a|, |b|, |n| (src/nurbs/normal.c): the smaller
// partial against the larger and the sine of their angle, the smaller of the two; 0 when a
// partial is 0. Below CRISP_NORMAL_TAU (include/crisp/nurbs.h) the cross product is not trusted.
#define NORMAL_TAU 1e-5LF
double cross_quality(double la, double lb, double ln)
{
    double lo = min(la, lb), hi = max(la, lb);
    return lo > 0.0LF ? min(lo / hi, ln / (la * lb)) : 0.0LF;
}

// The Euclidean partials' cross product of the patch at (s, t), its partials' lengths and its
// quality; the point in *x.
double cross_at(uint first_cp, uint du_, uint dv_, double s, double t, out dvec3 x, out dvec3 n,
                out double la, out double lb)
{
    dvec4 P, Ps, Pt;
    patch_derivs(first_cp, du_, dv_, s, t, P, Ps, Pt);
    x = P.xyz / P.w;
    dvec3 xs = (Ps.xyz - x * Ps.w) / P.w, xt = (Pt.xyz - x * Pt.w) / P.w;
    n = cross(xs, xt);
    la = length(xs);
    lb = length(xt);
    return cross_quality(la, lb, length(n));
}

// At an apex, a pole or a collapsed side one partial vanishes next to the other (rounding, or the
// file's rounding of the apex points, leaves it 1e-16..1e-6 of the other, pointing anywhere), or
// the two are parallel: there the normal is the limit from inside the patch, as the CPU backend
// takes it (crisp__normal_degenerate, crisp_bezier_patch_normal; the rule is src/nurbs/normal.c's,
// step for step): along the direction that leaves the degenerate side, towards the patch's
// middle, Richardson 2 n(h) - n(2h) at the first h of 1e-6, 1e-5, ..., 1e-2 whose two points have
// 100 times the quality q0 of (s, t); else the cross product n0 at (s, t) itself (if q0 > 1e-9).
// Not unit.
dvec3 limit_normal(uint first_cp, uint du_, uint dv_, double s, double t, dvec3 n0, double q0,
                   double la, double lb)
{
    dvec2 dir = dvec2(s < 0.5LF ? 1.0LF : -1.0LF, t < 0.5LF ? 1.0LF : -1.0LF);
    if (la < NORMAL_TAU * lb)
        dir.x = 0.0LF;
    else if (lb < NORMAL_TAU * la)
        dir.y = 0.0LF;
    for (double h = 1e-6LF; h < 2e-2LF; h *= 10.0LF) {
        dvec3 x, n1, n2;
        double a, b;
        if (!(cross_at(first_cp, du_, dv_, s + dir.x * h, t + dir.y * h, x, n1, a, b) > 100.0LF * q0))
            continue;
        if (!(cross_at(first_cp, du_, dv_, s + 2.0LF * dir.x * h, t + 2.0LF * dir.y * h, x, n2, a, b) >
              100.0LF * q0))
            continue;
        dvec3 n = 2.0LF * (n1 / length(n1)) - n2 / length(n2);
        double ln = length(n);
        if (ln > 0.5LF) return n / ln; // else the normal turns fast here: keep the nearer one
    }
    // No point nearby is better: a stretched but regular point keeps its own normal; below 1e-9
    // the cross product is rounding (the patch is a curve or a point there): no normal.
    return q0 > 1e-9LF ? n0 : dvec3(0.0LF);
}

// Point of the patch at its local (s, t), and its normal (the derivatives' cross product, or
// limit_normal's where that is not to be trusted: crisp__normal_degenerate's test, squared as
// there; not unit, not turned round for reversed faces), in double.
dvec3 eval_patch(uint first_cp, uint du_, uint dv_, double s, double t, out dvec3 n)
{
    dvec4 P, Ps, Pt;
    patch_derivs(first_cp, du_, dv_, s, t, P, Ps, Pt);
    dvec3 x = P.xyz / P.w;
    dvec3 xs = (Ps.xyz - x * Ps.w) / P.w, xt = (Pt.xyz - x * Pt.w) / P.w;
    n = cross(xs, xt);
    double aa = dot(xs, xs), bb = dot(xt, xt), nn = dot(n, n), t2 = NORMAL_TAU * NORMAL_TAU;
    if (!(aa > t2 * bb) || !(bb > t2 * aa) || !(nn > t2 * aa * bb)) {
        double la = sqrt(aa), lb = sqrt(bb);
        n = limit_normal(first_cp, du_, dv_, s, t, n, cross_quality(la, lb, sqrt(nn)), la, lb);
    }
    return x;
}

// The same for patch record `patch_index`.
dvec3 patch_point(uint patch_index, double s, double t, out dvec3 n)
{
    PatchRecord p = patches[patch_index];
    return eval_patch(p.first_cp, p.du, p.dv, s, t, n);
}
