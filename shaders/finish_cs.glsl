// Resolve, after the last sample pass: colour = mean of the covered samples' colours, alpha =
// covered / samples (straight alpha = coverage).
layout(local_size_x = 8, local_size_y = 8) in;
uniform float samples;
layout(rgba32f, binding = 0) uniform image2D acc_rgba;

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(acc_rgba)))) return;
    vec4 acc = imageLoad(acc_rgba, p);
    if (acc.a > 0.0) imageStore(acc_rgba, p, vec4(acc.rgb / acc.a, acc.a / samples));
}
