// Splat pass, vertex stage (issue 12, include/crisp/plan.h): one GL point per splat of the plan's
// store, fetched by gl_VertexID (glMultiDrawArrays over the frame's splat ranges: gl_VertexID is
// the splat's index in the store; a store above the storage block limit is bound a chunk at a
// time, splat_base its first splat). The splat's clip position in float, exactly the plan's rule:
// splat_clip_origin[face] + sum over j of view_proj_f column j times p[j], summed in that order
// (`precise`: no fused multiply-add). Its centre on the image (pixels, y down) in double from
// that float position goes flat to the fragment stage, which keeps exactly the samples the rule
// covers (cx - h <= x < cx + h, cy - h <= y < cy + h): the point is drawn a little larger than
// 2 h (splat_fs.glsl). The point is placed in an enlarged viewport (`view`: the image's window
// grown by a margin of more than h on each side), so a splat whose centre is just outside the
// image, which GL clips away as a point, still covers the image's border pixels. As the CPU
// backend (src/render/splat_raster.c): a splat is not drawn where W <= 0, its clip z is outside
// [-W, W] (near and far planes) or its clip x + y is not finite; the section plane is tested per
// sample in the fragment stage.
struct Splat {
    float p[3];
    uint n; // octahedral normal (crisp_plan_splat_normal)
    float uv[2];
};
layout(std430, binding = 11) readonly buffer Splats { Splat splats[]; };
layout(std430, binding = 12) readonly buffer SplatOrigins { vec4 splat_clip_origin[]; };
// The frame's ranges as (first, face), sorted by first: a splat's face is its run's.
layout(std430, binding = 13) readonly buffer SplatRuns { uvec2 runs[]; };
uniform uint run_count;
uniform uint splat_base;   // the first splat of the bound range of the store (a chunk of it)
uniform mat4 view_proj_f;
uniform dvec2 offset;      // the sample's position in its pixel (x right, y down)
uniform dvec2 image_size;  // pixels
uniform dvec4 view;        // the enlarged viewport in the pass's window: x0, y0, width, height
uniform float point_size;  // 2 h and the margin
uniform float zconst;
flat out dvec2 sp_centre;  // image pixels, y down
flat out vec2 sp_zw;       // clip z and W
flat out vec3 sp_normal;
flat out vec2 sp_uv;
flat out uint sp_face;
flat out float sp_w;

out gl_PerVertex {
    vec4 gl_Position;
    float gl_PointSize;
    float gl_ClipDistance[3];
};

// The face of splat i of the store: the last run whose first is at most i.
uint splat_face(uint i)
{
    uint lo = 0u, hi = run_count;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (runs[mid].x <= i) lo = mid; else hi = mid;
    }
    return runs[lo].y;
}

// crisp_plan_splat_normal: the same float arithmetic in the same order.
vec3 splat_normal(uint n)
{
    precise float x = float(int(n << 16) >> 16) * (1.0 / 32768.0);
    precise float y = float(int(n) >> 16) * (1.0 / 32768.0);
    precise float z = 1.0 - abs(x) - abs(y);
    if (z < 0.0) {
        precise float fx = (1.0 - abs(y)) * (x < 0.0 ? -1.0 : 1.0);
        precise float fy = (1.0 - abs(x)) * (y < 0.0 ? -1.0 : 1.0);
        x = fx;
        y = fy;
    }
    precise float len = sqrt(x * x + y * y + z * z);
    return vec3(x / len, y / len, z / len);
}

void main()
{
    Splat s = splats[uint(gl_VertexID) - splat_base];
    uint face = splat_face(uint(gl_VertexID));
    precise vec4 c = splat_clip_origin[face];
    c += view_proj_f[0] * s.p[0];
    c += view_proj_f[1] * s.p[1];
    c += view_proj_f[2] * s.p[2];
    double w = double(c.w);
    dvec2 centre = dvec2((double(c.x) / w + 1.0LF) * 0.5LF * image_size.x,
                         (1.0LF - double(c.y) / w) * 0.5LF * image_size.y);
    // The sample at (i + offset) lands on the pass's pixel centre (i + 0.5).
    dvec2 win = centre + 0.5LF - offset;
    dvec2 ndc = 2.0LF * (win - view.xy) / view.zw - 1.0LF;
    bool drawn = c.w > 0.0 && c.z >= -c.w && c.z <= c.w && !isinf(c.x + c.y) && !isnan(c.x + c.y);
    // not drawn: outside the clip volume, and clipped by the (enabled) clip distances too
    gl_Position = drawn ? vec4(vec2(ndc), zconst / c.w, 1.0) : vec4(2.0, 2.0, 0.5, 1.0);
    gl_PointSize = point_size;
    for (int k = 0; k < 3; k++) gl_ClipDistance[k] = drawn ? 1.0 : -1.0;
    vec3 n = splat_normal(s.n);
    sp_normal = (faces[face].flags & FACE_REVERSED) != 0u ? -n : n;
    sp_centre = centre;
    sp_zw = c.zw;
    sp_uv = vec2(s.uv[0], s.uv[1]);
    sp_face = face;
    sp_w = c.w;
}
