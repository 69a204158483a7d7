/* Shading shared by the backends: a headlight, so every visible surface is lit and the image
 * reads like a CAD viewer's default. */
#include "render_internal.h"

#include <math.h>

void crisp__shade(const float base[4], const double n[3], const double view[3], float rgba[4])
{
    double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    double vv = sqrt(view[0] * view[0] + view[1] * view[1] + view[2] * view[2]);
    double c =
        nn > 0 && vv > 0 ? fabs(n[0] * view[0] + n[1] * view[1] + n[2] * view[2]) / (nn * vv) : 1;
    double k = 0.25 + 0.75 * c;
    for (int i = 0; i < 3; i++)
        rgba[i] = (float)(base[i] * k);
    rgba[3] = 1.0f;
}

double crisp__view_depth(const crisp_camera *cam, const double p[3])
{
    double f[3], d[3];
    crisp_vec3_sub(cam->target, cam->eye, d);
    crisp_vec3_normalize(d, f);
    crisp_vec3_sub(p, cam->eye, d);
    return crisp_vec3_dot(d, f);
}
