/* Per-frame trim check of the trim editor's tests (issue 11): an image of one face is compared
 * pixel by pixel with the exact classifier on that frame's curves. The reference is the exact
 * renderer on the untrimmed face (crisp_render_exact without a classifier: the true surface's
 * (u, v) at every pixel centre, computed once per camera since edits keep the surface). A pixel
 * the face covers untrimmed is expected drawn iff crisp_trim_exact_classify says inside; where
 * the image disagrees, the distance in pixels to the true curve is bounded by searching rings
 * around the pixel centre (radius k / 16 px, mapped into (u, v) through the local Jacobian of the
 * exact (u, v), central differences) for a point the exact classifier puts on the image's side:
 * the curve passes between, so within that radius (to first order in the Jacobian; 1/16 px
 * resolution, rounded up). Pixels within 2 px of the untrimmed face's silhouette are skipped
 * (silhouettes are not the trim's business). */
#ifndef TRIMEDIT_FRAME_CHECK_H
#define TRIMEDIT_FRAME_CHECK_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "crisp/render.h"
#include "crisp/trim.h"

#define FC_RINGS 16 /* rings per pixel of radius searched (up to 2 px) */

typedef struct fc_result {
    long pixels;     /* pixels compared */
    long disagree;   /* image != exact classifier */
    long beyond;     /* of which farther than limit_px from the true curve */
    double worst_px; /* largest distance of a disagreement */
} fc_result;

/* The untrimmed face's exact (u, v) per pixel: a scene of the face without loops. */
static inline crisp_status fc_exact_uv(const crisp_scene *untrimmed, const crisp_camera *cam,
                                       crisp_image *dest)
{
    crisp_status st = crisp_image_init(dest, cam->width, cam->height);
    if (st) return st;
    crisp_exact_desc d = {0};
    return crisp_render_exact(untrimmed, cam, &d, dest);
}

/* drawn[p] != 0 where the image shows face `face` at pixel p. */
static inline void fc_compare(const crisp_image *ref, int32_t face,
                              const crisp_bezier_curve *pieces, int piece_count,
                              const uint8_t *drawn, double limit_px, fc_result *res)
{
    const int w = ref->width, h = ref->height;
    *res = (fc_result){0};
    for (int y = 2; y < h - 2; y++)
        for (int x = 2; x < w - 2; x++) {
            size_t p = (size_t)y * w + x;
            int inner = 1;
            for (int dy = -2; dy <= 2 && inner; dy++)
                for (int dx = -2; dx <= 2; dx++)
                    if (ref->face[p + (ptrdiff_t)dy * w + dx] != face) {
                        inner = 0;
                        break;
                    }
            if (!inner) continue;
            res->pixels++;
            double u = ref->uv[2 * p], v = ref->uv[2 * p + 1];
            int inside = crisp_trim_exact_classify(pieces, piece_count, u, v);
            if (inside == (drawn[p] != 0)) continue;
            res->disagree++;
            /* J = d(u, v) / d(x, y) by central differences of the exact (u, v). */
            double a = 0.5 * (ref->uv[2 * (p + 1)] - ref->uv[2 * (p - 1)]);
            double c = 0.5 * (ref->uv[2 * (p + 1) + 1] - ref->uv[2 * (p - 1) + 1]);
            double b = 0.5 * (ref->uv[2 * (p + w)] - ref->uv[2 * (p - w)]);
            double d = 0.5 * (ref->uv[2 * (p + w) + 1] - ref->uv[2 * (p - w) + 1]);
            /* The smallest ring (radius k / 16 px, 32 directions, mapped through J) holding a
             * point the exact classifier puts on the image's side: the true curve passes
             * between, within that radius. */
            double d_px = INFINITY;
            for (int k = 1; k <= 2 * FC_RINGS && d_px == INFINITY; k++) {
                double rad = k / 16.0;
                for (int j = 0; j < 32; j++) {
                    double dx = rad * cos(j * M_PI / 16), dy = rad * sin(j * M_PI / 16);
                    if (crisp_trim_exact_classify(pieces, piece_count, u + a * dx + b * dy,
                                                  v + c * dx + d * dy) == (drawn[p] != 0)) {
                        d_px = rad;
                        break;
                    }
                }
            }
            if (d_px > res->worst_px) res->worst_px = d_px;
            if (d_px > limit_px) res->beyond++;
        }
}

#endif
