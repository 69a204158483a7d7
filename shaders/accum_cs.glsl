// Resolve, one sample pass at a time (the CPU backend's resolve): adds the sample's headlight
// colour (crisp__shade in src/render/shade.c, in double) to the pixel's sum and count, and keeps
// the nearest sample's normal, depth, (u, v) and face (the first of equal depths).
layout(local_size_x = 8, local_size_y = 8) in;
uniform sampler2D nw_tex;
uniform sampler2D uv_tex;
uniform isampler2D face_tex;
uniform dvec3 dir0, dir_x, dir_y; // view direction at image point (x, y): dir0 + x dir_x + y dir_y
uniform dvec2 offset;             // the sample's position in its pixel (x right, y down)
layout(rgba32f, binding = 0) uniform image2D acc_rgba;
layout(rgba32f, binding = 1) uniform image2D best_nw;
layout(rg32f, binding = 2) uniform image2D best_uv;
layout(r32i, binding = 3) uniform iimage2D best_face;
layout(r32i, binding = 4) uniform iimage2DArray sample_faces; // every sample's face, for tests
uniform int keep_samples;
uniform int sample_index;

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(acc_rgba)))) return;
    int f = texelFetch(face_tex, p, 0).r;
    if (keep_samples != 0) imageStore(sample_faces, ivec3(p, sample_index), ivec4(f));
    if (f < 0) return;
    vec4 nw = texelFetch(nw_tex, p, 0);
    dvec3 n = dvec3(nw.xyz);
    dvec3 d = dir0 + (double(p.x) + offset.x) * dir_x + (double(p.y) + offset.y) * dir_y;
    double nn = length(n), vv = length(d);
    double c = nn > 0.0LF && vv > 0.0LF ? abs(dot(n, d)) / (nn * vv) : 1.0LF;
    double k = 0.25LF + 0.75LF * c;
    vec4 base = face_color[f];
    vec4 acc = imageLoad(acc_rgba, p);
    acc.rgb += vec3(float(base.r * k), float(base.g * k), float(base.b * k));
    acc.a += 1.0;
    imageStore(acc_rgba, p, acc);
    if (nw.w < imageLoad(best_nw, p).w) {
        imageStore(best_nw, p, nw);
        imageStore(best_uv, p, vec4(texelFetch(uv_tex, p, 0).xy, 0.0, 0.0));
        imageStore(best_face, p, ivec4(f));
    }
}
