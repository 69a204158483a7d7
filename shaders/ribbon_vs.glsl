// Ribbon pass, vertex stage: quad q is vertices 4q .. 4q + 3 of the plan's ribbon array, drawn as
// triangles (0 1 2) and (0 2 3); a quad with a vertex at clip W < 0 is not drawn (all its vertices
// are clipped away). The quad's core (src/render/ribbon.h: within CRISP__RIBBON_CORE_PX = 0.35 px
// of its centre line, between its two curve points) goes to the fragment stage as affine
// functions of the screen position, interpolated without perspective: rb_core = (across / 0.35 px,
// 2 along / length - 1), in the core where both lie in [-1, 1], and rb_core_iw, the core's 1/W
// (constant across, the curve points' 1/W at its ends), as the CPU backend's ribbon_core
// (src/render/cpu.c). The quad is a rectangle on screen: corners 0, 1 at its start (its
// half-width before the first curve point), 2, 3 at its end, 0 and 3 on one side.
uniform dvec2 jitter;
uniform float zconst;
uniform dvec4 clip_plane;  // the section plane in clip space (kept where dot(clip_plane, c) >= 0)
uniform dvec2 image_size;  // pixels
out vec2 rb_uv;
out vec3 rb_normal;
flat out uint rb_face;
noperspective out vec2 rb_core;
noperspective out float rb_core_iw;

out gl_PerVertex {
    vec4 gl_Position;
    float gl_ClipDistance[3];
};

void main()
{
    const uint corner[6] = uint[6](0u, 1u, 2u, 0u, 2u, 3u);
    uint q = uint(gl_VertexID) / 6u, k = corner[uint(gl_VertexID) % 6u];
    bool dropped = false;
    dvec2 p[4];
    for (uint i = 0u; i < 4u; i++) {
        RibbonVertex R = ribbon[4u * q + i];
        if (R.clip[3] < 0.0LF) dropped = true;
        p[i] = (dvec2(R.clip[0], R.clip[1]) / R.clip[3] + 1.0LF) * 0.5LF * image_size;  // pixels
    }
    RibbonVertex V = ribbon[4u * q + k];
    dvec4 c = dvec4(V.clip[0], V.clip[1], V.clip[2], V.clip[3]);
    // The core's coordinates at this corner (no core: (2, 2), outside it everywhere).
    dvec2 pa = 0.5LF * (p[0] + p[1]), pb = 0.5LF * (p[2] + p[3]);
    double L = length(pb - pa), half_w = 0.5LF * length(p[1] - p[0]), len = L - 2.0LF * half_w;
    rb_core = vec2(2.0);
    rb_core_iw = 0.0;
    if (!dropped && len > 0.0LF && !isinf(L)) {
        dvec2 e = (pb - pa) / L, n = dvec2(-e.y, e.x), d = p[k] - (pa + half_w * e);
        double s = dot(d, e);  // along, from the first curve point
        rb_core = vec2(float(dot(d, n) / 0.35LF), float(2.0LF * s / len - 1.0LF));
        double ia = 1.0LF / ribbon[4u * q].clip[3], ib = 1.0LF / ribbon[4u * q + 2u].clip[3];
        rb_core_iw = float(ia + (ib - ia) * s / len);
    }
    gl_Position = vec4(float(c.x + c.w * jitter.x), float(-c.y + c.w * jitter.y), zconst, float(c.w));
    gl_ClipDistance[0] = dropped ? -1.0 : float(c.z + c.w);
    gl_ClipDistance[1] = dropped ? -1.0 : float(c.w - c.z);
    gl_ClipDistance[2] = dropped ? -1.0 : float(dot(clip_plane, c));
    rb_uv = vec2(V.uv[0], V.uv[1]);
    rb_normal = vec3(V.normal[0], V.normal[1], V.normal[2]);
    rb_face = V.face;
}
