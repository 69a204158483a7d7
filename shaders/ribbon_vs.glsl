// Ribbon pass, vertex stage: quad q is vertices 4q .. 4q + 3 of the plan's ribbon array, drawn as
// triangles (0 1 2) and (0 2 3); a quad with a vertex at clip W < 0 is not drawn (all its vertices
// are clipped away).
uniform dvec2 jitter;
uniform float zconst;
uniform dvec4 clip_plane;  // the section plane in clip space (kept where dot(clip_plane, c) >= 0)
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
    uint q = uint(gl_VertexID) / 6u;
    bool dropped = false;
    for (uint k = 0u; k < 4u; k++)
        if (ribbon[4u * q + k].clip[3] < 0.0LF) dropped = true;
    RibbonVertex V = ribbon[4u * q + corner[uint(gl_VertexID) % 6u]];
    dvec4 c = dvec4(V.clip[0], V.clip[1], V.clip[2], V.clip[3]);
    gl_Position = vec4(float(c.x + c.w * jitter.x), float(-c.y + c.w * jitter.y), zconst, float(c.w));
    gl_ClipDistance[0] = dropped ? -1.0 : float(c.z + c.w);
    gl_ClipDistance[1] = dropped ? -1.0 : float(c.w - c.z);
    gl_ClipDistance[2] = dropped ? -1.0 : float(dot(clip_plane, c));
    rb_uv = vec2(V.uv[0], V.uv[1]);
    rb_normal = vec3(V.normal[0], V.normal[1], V.normal[2]);
    rb_face = V.face;
}
