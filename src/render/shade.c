/* Shading shared by the backends: a headlight, so every visible surface is lit and the image
 * reads like a CAD viewer's default. */
#include "render_internal.h"

#include <math.h>

void crisp__shade(const float base[4], const double n[3], const double view[3], float rgba[4])
{
    crisp__shade_inline(base, n, view, rgba);
}

double crisp__view_depth(const crisp_camera *cam, const double p[3])
{
    double f[3], d[3];
    crisp_vec3_sub(cam->target, cam->eye, d);
    crisp_vec3_normalize(d, f);
    crisp_vec3_sub(p, cam->eye, d);
    return crisp_vec3_dot(d, f);
}
