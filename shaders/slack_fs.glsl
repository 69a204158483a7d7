// Depth slack of the ribbons' fill pass (crisp_raster_depth_slack): 1.5 times the largest change
// of W between the sample and the same sample of its four neighbouring pixels where they show
// the same face; 0 for empty samples.
uniform sampler2D nw_tex;
uniform isampler2D face_tex;
layout(location = 0) out float o_slack;

void main()
{
    ivec2 p = ivec2(gl_FragCoord.xy), size = textureSize(face_tex, 0);
    int f = texelFetch(face_tex, p, 0).r;
    float d = 0.0;
    if (f >= 0) {
        float W = texelFetch(nw_tex, p, 0).w;
        const ivec2 nb[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
        for (int k = 0; k < 4; k++) {
            ivec2 q = p + nb[k];
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            if (texelFetch(face_tex, q, 0).r != f) continue;
            d = max(d, abs(texelFetch(nw_tex, q, 0).w - W));
        }
    }
    o_slack = 1.5 * d;
}
