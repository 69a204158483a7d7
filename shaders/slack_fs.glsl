// Depth slack of the ribbons' fill pass (crisp_raster_depth_slack) before its scale, which the
// ribbon pass applies (ribbon_fs.glsl: 1.5 for the quads, 0.95 for their cores): the largest change
// of W between the sample and the same sample of its four neighbouring pixels where they show
// the same face seen from the same side (the sign of the normal against the view ray through the
// pixel centre, as the CPU backend: a face seen through a crack at its own seam shows its inside
// beside its outside, and that jump must not widen the slack); 0 for empty samples.
uniform sampler2D nw_tex;
uniform isampler2D face_tex;
uniform dvec3 dir0, dir_x, dir_y; // view direction at image point (x, y): dir0 + x dir_x + y dir_y
layout(location = 0) out float o_slack;

bool faces_eye(ivec2 q, vec3 n)
{
    dvec3 d = dir0 + (double(q.x) + 0.5LF) * dir_x + (double(q.y) + 0.5LF) * dir_y;
    return dot(dvec3(n), d) < 0.0LF;
}

void main()
{
    ivec2 p = ivec2(gl_FragCoord.xy), size = textureSize(face_tex, 0);
    int f = texelFetch(face_tex, p, 0).r;
    float d = 0.0;
    if (f >= 0) {
        vec4 nw = texelFetch(nw_tex, p, 0);
        float W = nw.w;
        bool side = faces_eye(p, nw.xyz);
        const ivec2 nb[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
        for (int k = 0; k < 4; k++) {
            ivec2 q = p + nb[k];
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            if (texelFetch(face_tex, q, 0).r != f) continue;
            vec4 nq = texelFetch(nw_tex, q, 0);
            if (faces_eye(q, nq.xyz) != side) continue;
            d = max(d, abs(nq.w - W));
        }
    }
    o_slack = d;
}
