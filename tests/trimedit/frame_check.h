/* Per-frame trim check of the trim editor's tests (issue 11): an image of one face is compared
 * pixel by pixel with the exact classifier on that frame's curves. The reference is the exact
 * renderer on the untrimmed face (crisp_render_exact without a classifier: the true surface's
 * (u, v) at every pixel centre, computed once per camera since edits keep the surface). A pixel
 * the face covers untrimmed is expected drawn iff crisp_trim_exact_classify says inside; where
 * the image disagrees, the distance in pixels to the true curve is bounded by searching rings
 * around the pixel centre (radius k / 16 px, mapped into (u, v) through the local Jacobian of the
 * exact (u, v), central differences) for a point the exact classifier puts on the image's side:
 * the curve passes between, so within that radius (to first order in the Jacobian; 1/16 px
 * resolution, rounded up). Pixels within 2 px of the untrimmed face's silhouette, outline or
 * self-occlusion contour, are skipped (silhouettes are not the trim's business; the repository's
 * other end-to-end trim tests exclude them the same way). */
#ifndef TRIMEDIT_FRAME_CHECK_H
#define TRIMEDIT_FRAME_CHECK_H

#include <math.h>
#include <stdio.h>
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
    long behind;     /* drawn pixels showing the face through its own hole (agreements) */
    long contour;    /* pixels skipped within 2 px of a self-occlusion contour */
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

typedef struct fc_pieces {
    const crisp_bezier_curve *pieces;
    int count;
} fc_pieces;

static inline int fc_classify(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)sc, (void)face;
    const fc_pieces *p = ctx;
    return crisp_trim_exact_classify(p->pieces, p->count, u, v);
}

/* drawn[p] != 0 where the image shows face `face` at pixel p. ref: fc_exact_uv of `bare` (the
 * untrimmed face, alone in its scene) for cam. A pixel drawn where the first surface point along
 * its ray is trimmed away is right when a farther point of the face along the ray is inside the
 * trim (the face seen through its own hole): the exact ray with the exact classifier decides. */
static inline void fc_compare(const crisp_image *ref, const crisp_scene *bare,
                              const crisp_camera *cam, int32_t face,
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
            /* Self-occlusion contours of the face (a fold seen from the side) are silhouettes too:
             * the exact (u, v) stops being smooth there (second differences as large as first
             * differences). Skip pixels within 2 px of one. */
            for (int dy = -2; dy <= 2 && inner; dy++)
                for (int dx = -2; dx <= 2 && inner; dx++) {
                    int qx = x + dx, qy = y + dy;
                    if (qx < 1 || qy < 1 || qx > w - 2 || qy > h - 2) continue;
                    size_t q = (size_t)qy * w + qx;
                    const size_t step[2] = {1, (size_t)w};
                    for (int k = 0; k < 2 && inner; k++) {
                        if (ref->face[q - step[k]] != face || ref->face[q + step[k]] != face)
                            continue;
                        double d1 = 0, d2 = 0;
                        for (int c2 = 0; c2 < 2; c2++) {
                            double lo = ref->uv[2 * (q - step[k]) + c2], mid = ref->uv[2 * q + c2],
                                   hi = ref->uv[2 * (q + step[k]) + c2];
                            d1 = hypot(d1, hi - lo);
                            d2 = hypot(d2, lo - 2 * mid + hi);
                        }
                        if (d2 > 0.5 * d1) inner = 0;
                    }
                }
            if (!inner) {
                res->contour++;
                continue;
            }
            res->pixels++;
            double u = ref->uv[2 * p], v = ref->uv[2 * p + 1];
            int inside = crisp_trim_exact_classify(pieces, piece_count, u, v);
            if (inside == (drawn[p] != 0)) continue;
            if (drawn[p] && !inside) {
                double o[3], dir[3];
                fc_pieces fp = {pieces, piece_count};
                crisp_exact_desc ed = {.threads = 1, .classify = fc_classify, .classify_ctx = &fp};
                crisp_camera_ray(cam, x + 0.5, y + 0.5, o, dir);
                if (crisp_exact_ray(bare, &ed, o, dir, 0.0, INFINITY, NULL, NULL, NULL, NULL)) {
                    res->behind++;
                    continue;
                }
            }
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
            if (d_px > limit_px && res->beyond++ < 5)
                fprintf(stderr,
                        "frame_check: pixel (%d, %d) uv (%.9g, %.9g) drawn %d exact %d: the true "
                        "curve is %.3f px away (J = %.3g %.3g %.3g %.3g)\n",
                        x, y, u, v, drawn[p] != 0, inside, d_px, a, b, c, d);
        }
}

#endif
