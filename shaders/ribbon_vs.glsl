// Ribbon pass, vertex stage: quad q is vertices 4q .. 4q + 3 of the plan's ribbon array, drawn as
// triangles (0 1 2) and (0 2 3); a quad with a vertex at clip W < 0 is not drawn (all its vertices
// are clipped away). With core = 1 the quad's core instead: its corners CRISP__RIBBON_CORE_PX
// (0.35 px) either side of its centre line at its two curve points, the arithmetic of
// crisp__ribbon_core (src/render/ribbon.c; the quad is a rectangle on screen, its corners 0.7 px
// across and along from the curve points).
uniform dvec2 jitter;
uniform float zconst;
uniform dvec4 clip_plane;  // the section plane in clip space (kept where dot(clip_plane, c) >= 0)
uniform int core;
uniform dvec2 image_size;  // pixels
out vec2 rb_uv;
out vec3 rb_normal;
flat out uint rb_face;

out gl_PerVertex {
    vec4 gl_Position;
    float gl_ClipDistance[3];
};

void main()
{
    const uint corner[6] = uint[6](0u, 1u, 2u, 0u, 2u, 3u);
    uint q = uint(gl_VertexID) / 6u, k = corner[uint(gl_VertexID) % 6u];
    bool dropped = false;
    dvec2 n[4];
    for (uint i = 0u; i < 4u; i++) {
        RibbonVertex R = ribbon[4u * q + i];
        if (R.clip[3] < 0.0LF) dropped = true;
        n[i] = dvec2(R.clip[0], R.clip[1]) / R.clip[3];
    }
    RibbonVertex V = ribbon[4u * q + k];
    dvec4 c = dvec4(V.clip[0], V.clip[1], V.clip[2], V.clip[3]);
    if (core != 0) {
        dvec2 pa = 0.5LF * (n[0] + n[1]), pb = 0.5LF * (n[2] + n[3]);
        double len = length((pb - pa) * 0.5LF * image_size);
        if (dropped || !(len > 1.4LF) || isinf(len)) {
            dropped = true;
        } else {
            bool end = k >= 2u;
            double side = (k == 1u || k == 2u) ? 1.0LF : -1.0LF;
            double f = 0.7LF / len, t = end ? 1.0LF - f : f, g = 0.35LF / 0.7LF;
            dvec2 half_across = 0.5LF * (end ? n[2] - n[3] : n[1] - n[0]);
            dvec2 p = pa + t * (pb - pa);
            c.xy = (p + side * g * half_across) * c.w;
        }
    }
    gl_Position = vec4(float(c.x + c.w * jitter.x), float(-c.y + c.w * jitter.y), zconst, float(c.w));
    gl_ClipDistance[0] = dropped ? -1.0 : float(c.z + c.w);
    gl_ClipDistance[1] = dropped ? -1.0 : float(c.w - c.z);
    gl_ClipDistance[2] = dropped ? -1.0 : float(dot(clip_plane, c));
    rb_uv = vec2(V.uv[0], V.uv[1]);
    rb_normal = vec3(V.normal[0], V.normal[1], V.normal[2]);
    rb_face = V.face;
}
