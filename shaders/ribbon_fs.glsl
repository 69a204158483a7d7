// Ribbon pass, fragment stage: no trim test. The depth written is zconst / (W + slack), so with
// the GREATER depth test a ribbon fragment replaces a surface sample only when nearer by more than
// the sample's slack, and fills empty samples (cleared to 0) always: the CPU backend's fill pass
// (crisp_raster_draw_fill). The slack is slack_scale times the surface's depth change to its
// neighbours (slack_fs.glsl): CRISP__RIBBON_SLACK for the quads, CRISP__RIBBON_CORE_SLACK for
// their cores (src/render/ribbon.h).
in vec2 rb_uv;
in vec3 rb_normal;
flat in uint rb_face;
uniform float zconst;
uniform sampler2D slack_tex;
uniform float slack_scale;
layout(location = 0) out vec4 o_nw;
layout(location = 1) out vec2 o_uv;
layout(location = 2) out int o_face;

void main()
{
    float W = 1.0 / gl_FragCoord.w;
    float slack = slack_scale * texelFetch(slack_tex, ivec2(gl_FragCoord.xy), 0).r;
    gl_FragDepth = zconst / (W + slack);
    o_nw = vec4(rb_normal, W);
    o_uv = rb_uv;
    o_face = int(rb_face);
}
