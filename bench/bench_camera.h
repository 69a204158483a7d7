/* The close-up camera of the frame benchmarks (bench_gl, bench_interactive): the default camera
 * turned to the surface point under the image centre (or, where the centre ray hits nothing, a
 * middle patch's centre) at 1/8 of its field of view, so the model fills the screen. */
#ifndef CRISP_BENCH_CAMERA_H
#define CRISP_BENCH_CAMERA_H

#include "crisp/core.h"
#include "crisp/nurbs.h"
#include "crisp/render.h"

static inline crisp_camera bench_close_up(const crisp_scene *sc, const crisp_camera *base)
{
    crisp_camera c = *base;
    double o[3], d[3], t;
    crisp_camera_ray(base, 0.5 * base->width, 0.5 * base->height, o, d);
    if (!crisp_exact_ray(sc, NULL, o, d, base->znear, base->zfar, &t, NULL, NULL, NULL)) {
        double P[3], Ps[3], Pt[3];
        crisp_bezier_patch_derivs(&sc->patches[sc->patch_count / 2].bez, 0.5, 0.5, P, Ps, Pt);
        for (int k = 0; k < 3; k++)
            d[k] = P[k] - o[k];
        t = crisp_vec3_norm(d);
        crisp_vec3_normalize(d, d);
    }
    for (int k = 0; k < 3; k++)
        c.target[k] = o[k] + t * d[k];
    c.fov_deg = base->fov_deg / 8;
    return c;
}

#endif
