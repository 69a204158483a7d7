// Splat pass, fragment stage: the plan's coverage rule on the sample this pass draws (at image
// position (i, j) + offset): covered when cx - h <= x < cx + h and cy - h <= y < cy + h, in
// double. GL rasterizes the point as a square of side point_size = 2 h + a margin around its
// centre (llvmpipe snaps the centre and the size to 1/256 px first: docs/status/issue-12-splats.md
// "GL draw"), a square that holds every sample the rule covers; this test drops the rest, so the
// coverage is the rule's exactly whatever the rasterizer's rounding. Depth: the splat's own,
// constant over the square (its clip W in float); normal, (u, v) and face as the surface pass
// writes them. The section plane (clip_plane, clip space) is tested at the sample's point of the
// square: the sample's position on the image at the splat's clip z and W, as the CPU backend
// tests it per sample.
flat in dvec2 sp_centre;
flat in vec2 sp_zw;
flat in vec3 sp_normal;
flat in vec2 sp_uv;
flat in uint sp_face;
flat in float sp_w;
uniform dvec2 offset;
uniform double half_px;
uniform dvec2 image_size;
uniform dvec4 clip_plane; // kept where dot(clip_plane, clip position) >= 0; 0: none
uniform int raw; // tests (crisp__gl_splat_raw): GL's point coverage alone, without this test
layout(location = 0) out vec4 o_nw; // world normal, camera-space depth W
layout(location = 1) out vec2 o_uv;
layout(location = 2) out int o_face;

void main()
{
    dvec2 x = dvec2(gl_FragCoord.xy) - 0.5LF + offset;
    if (raw == 0 && !(all(lessThanEqual(sp_centre - half_px, x)) && all(lessThan(x, sp_centre + half_px))))
        discard;
    double w = double(sp_zw.y);
    dvec4 c = dvec4((2.0LF * x.x / image_size.x - 1.0LF) * w, (1.0LF - 2.0LF * x.y / image_size.y) * w,
                    double(sp_zw.x), w);
    if (dot(clip_plane, c) < 0.0LF) discard;
    o_nw = vec4(sp_normal, sp_w);
    o_uv = sp_uv;
    o_face = int(sp_face);
}
