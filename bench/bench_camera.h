/* The close-up camera of the frame benchmarks (bench_gl, bench_interactive): the default camera
 * turned to the surface point under the image centre (or, where the centre ray hits nothing, a
 * middle patch's centre) at 1/8 of its field of view, so the model fills the screen. */
#ifndef CRISP_BENCH_CAMERA_H
#define CRISP_BENCH_CAMERA_H

#include <math.h>

#include "crisp/core.h"
#include "crisp/model.h"
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

/* The extreme zoom of the frame benchmarks: from the default camera's eye, the trim curve point
 * nearest to the surface point under the image centre (the middle of a trim piece of any face;
 * the centre point itself when no face has trim pieces) at the default field of view divided by
 * `factor` (1e4: a default pixel of a 100 mm part at 30 degrees is about 0.1 mm, zoomed it is
 * about 10 nm). The point is not tested for visibility: on impeller.igs and occt_linkrods.step
 * two faces meet across the screen there, on occt_hammer.iges a face in front covers it (the
 * trim curve is behind; its rows still run the trim lookups of the hidden triangles). */
static inline crisp_camera bench_zoom(const crisp_scene *sc, const crisp_camera *base,
                                      double factor)
{
    crisp_camera c = bench_close_up(sc, base); /* target: the surface point under the centre */
    double best = INFINITY, target[3] = {c.target[0], c.target[1], c.target[2]};
    for (uint32_t f = 0; f < sc->face_count; f++) {
        const crisp_scene_face *F = &sc->faces[f];
        for (uint32_t k = 0; k < F->piece_count; k++) {
            double uv[3], P[3], d2 = 0;
            crisp_bezier_curve_eval(&sc->pieces[F->first_piece + k], 0.5, uv);
            crisp_surface_eval(F->src->surface, uv[0], uv[1], P);
            for (int q = 0; q < 3; q++)
                d2 += (P[q] - c.target[q]) * (P[q] - c.target[q]);
            if (d2 < best) best = d2, target[0] = P[0], target[1] = P[1], target[2] = P[2];
        }
    }
    for (int q = 0; q < 3; q++)
        c.target[q] = target[q];
    c.fov_deg = base->fov_deg / factor;
    return c;
}

#endif
