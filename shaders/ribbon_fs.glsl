// Ribbon pass, fragment stage: no trim test. The depth written is zconst / (W + slack), so with
// the GREATER depth test a ribbon fragment replaces a surface sample only when nearer by more than
// the sample's slack, and fills empty samples (cleared to 0) always: the CPU backend's fill pass
// (crisp__raster_draw_fill2). The slack is slack_scale (CRISP__RIBBON_SLACK) times the surface's
// depth change to its neighbours (slack_fs.glsl); in the quad's core (ribbon_vs.glsl) the
// fragment may also pass at the core's own depth with core_scale (CRISP__RIBBON_CORE_SLACK) times
// it (src/render/ribbon.h): the nearer of the two depths is written.
in vec2 rb_uv;
in vec3 rb_normal;
flat in uint rb_face;
noperspective in vec2 rb_core;
noperspective in float rb_core_iw;
uniform float zconst;
uniform sampler2D slack_tex;
uniform float slack_scale, core_scale;
layout(location = 0) out vec4 o_nw;
layout(location = 1) out vec2 o_uv;
layout(location = 2) out int o_face;

void main()
{
    float W = 1.0 / gl_FragCoord.w;
    float s = texelFetch(slack_tex, ivec2(gl_FragCoord.xy), 0).r;
    float depth = zconst / (W + slack_scale * s);
    if (abs(rb_core.x) <= 1.0 && abs(rb_core.y) <= 1.0 && rb_core_iw > 0.0) {
        float Wc = 1.0 / rb_core_iw, dc = zconst / (Wc + core_scale * s);
        if (dc > depth) depth = dc, W = Wc;
    }
    gl_FragDepth = depth;
    o_nw = vec4(rb_normal, W);
    o_uv = rb_uv;
    o_face = int(rb_face);
}
