/* The close-up camera of the frame benchmarks (bench_gl, bench_interactive): the default camera
 * turned to the surface point under the image centre (or, where the centre ray hits nothing, a
 * middle patch's centre) at 1/8 of its field of view, so the model fills the screen. */
#ifndef CRISP_BENCH_CAMERA_H
#define CRISP_BENCH_CAMERA_H

#include <math.h>
#include <stdlib.h>

#include "crisp/core.h"
#include "crisp/model.h"
#include "crisp/nurbs.h"
#include "crisp/render.h"
#include "crisp/trim.h"

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

/* The exact renderer's trim decision for bench_zoom: the face's true trim curves. */
static inline int bench_classify_exact(void *ctx, const crisp_scene *sc, uint32_t face, double u,
                                       double v)
{
    (void)ctx;
    const crisp_scene_face *f = &sc->faces[face];
    if (f->piece_count == 0) return 1;
    return crisp_trim_exact_classify(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
}

typedef struct bench_zoom_candidate {
    double d2, p[3];
} bench_zoom_candidate;

static inline int bench_zoom_cmp(const void *a, const void *b)
{
    double x = ((const bench_zoom_candidate *)a)->d2, y = ((const bench_zoom_candidate *)b)->d2;
    return (x > y) - (x < y);
}

/* Candidates tested for visibility by bench_zoom, nearest first. */
#define BENCH_ZOOM_TRIES 64

/* The extreme zoom of the frame benchmarks: from the default camera's eye, at the default field
 * of view divided by `factor` (1e4: a default pixel of a 100 mm part at 30 degrees is about 0.1
 * mm, zoomed it is about 10 nm), the visible trim curve point nearest to the surface point under
 * the image centre. Candidates are the middles of the faces' trim pieces, nearest first; one is
 * visible when the exact renderer's ray from the eye towards it (true trim curves) meets no face
 * before it (within 1e-5 of its distance: the point's own faces). Of the BENCH_ZOOM_TRIES nearest,
 * the first visible one is taken, else the nearest; the centre point itself when no face has trim
 * pieces. On a closed solid the point is on an edge where two faces meet, so the zoomed image shows
 * both faces and the trim edge between them across the screen. */
static inline crisp_camera bench_zoom(const crisp_scene *sc, const crisp_camera *base,
                                      double factor)
{
    crisp_camera c = bench_close_up(sc, base); /* target: the surface point under the centre */
    size_t n = 0;
    for (uint32_t f = 0; f < sc->face_count; f++)
        n += sc->faces[f].piece_count;
    bench_zoom_candidate *cand = n ? malloc(n * sizeof *cand) : NULL;
    if (cand) {
        size_t m = 0;
        for (uint32_t f = 0; f < sc->face_count; f++) {
            const crisp_scene_face *F = &sc->faces[f];
            for (uint32_t k = 0; k < F->piece_count; k++) {
                double uv[3], d2 = 0;
                bench_zoom_candidate *q = &cand[m++];
                crisp_bezier_curve_eval(&sc->pieces[F->first_piece + k], 0.5, uv);
                crisp_surface_eval(F->src->surface, uv[0], uv[1], q->p);
                for (int j = 0; j < 3; j++)
                    d2 += (q->p[j] - c.target[j]) * (q->p[j] - c.target[j]);
                q->d2 = d2;
            }
        }
        qsort(cand, n, sizeof *cand, bench_zoom_cmp);
        const bench_zoom_candidate *pick = &cand[0];
        crisp_exact_desc desc = {.threads = 1, .classify = bench_classify_exact};
        for (size_t i = 0; i < n && i < BENCH_ZOOM_TRIES; i++) {
            double d[3], dist;
            for (int j = 0; j < 3; j++)
                d[j] = cand[i].p[j] - base->eye[j];
            dist = crisp_vec3_norm(d);
            if (!(dist > base->znear)) continue;
            crisp_vec3_normalize(d, d);
            if (!crisp_exact_ray(sc, &desc, base->eye, d, base->znear, dist * (1 - 1e-5), NULL,
                                 NULL, NULL, NULL)) {
                pick = &cand[i];
                break;
            }
        }
        for (int j = 0; j < 3; j++)
            c.target[j] = pick->p[j];
        free(cand);
    }
    c.fov_deg = base->fov_deg / factor;
    return c;
}

#endif
