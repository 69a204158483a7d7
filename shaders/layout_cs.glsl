// Layout test (tests/gl): reads the plan's buffers as the drawing shaders do and writes back, per
// query, the trim test at (u, v) of a face, the (u, v) of a leaf-local point and the leaf's levels,
// for comparison with crisp_plan_trim_test and the C structs.
layout(local_size_x = 64) in;
struct Query {
    double u, v, s, t;
    uint face, leaf, pad0, pad1;
};
struct Result {
    double u, v;
    uint inside, tau, patch_, depth;
    uint edge[4];
    double x, y, z; // the leaf's patch at the leaf-local (s, t)
};
layout(std430, binding = 9) readonly buffer Queries { Query queries[]; };
layout(std430, binding = 10) writeonly buffer Results { Result results[]; };
uniform uint count;

void main()
{
    uint k = gl_GlobalInvocationID.x;
    if (k >= count) return;
    Query q = queries[k];
    Result r;
    r.inside = trim_test(q.face, q.u, q.v) ? 1u : 0u;
    dvec2 uv = leaf_uv(q.leaf, q.s, q.t);
    r.u = uv.x;
    r.v = uv.y;
    uvec4 a = leaves[3u * q.leaf], e = leaves[3u * q.leaf + 2u];
    r.patch_ = a.x;
    r.depth = a.z;
    r.tau = a.w;
    r.edge[0] = e.x;
    r.edge[1] = e.y;
    r.edge[2] = e.z;
    r.edge[3] = e.w;
    uvec4 b = leaves[3u * q.leaf + 1u];
    double ps, pt;
    uint pi = leaf_locate(a, b, q.s, q.t, ps, pt);
    dvec3 n;
    dvec3 x = patch_point(pi, ps, pt, n);
    r.x = x.x;
    r.y = x.y;
    r.z = x.z;
    results[k] = r;
}
