/* Helpers shared by the render tests: the largest screen distance between the CPU backend's
 * last frame of triangles and the true surface. */
#ifndef CRISP_RENDER_TEST_UTIL_H
#define CRISP_RENDER_TEST_UTIL_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "crisp/io.h"
#include "crisp/render.h"
#include "render/raster.h"
#include "render/render_internal.h"

/* data/nurbs/NAME loaded (the test fails, printing the error, when it does not load). */
static inline crisp_model *rt_load_model(const char *name)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, name);
    crisp_model *m = NULL;
    crisp_status st = crisp_model_load(path, NULL, &m);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    return m;
}

/* data/nurbs/NAME loaded into *model (the scene reads it: destroy the scene first) and its scene
 * prepared. */
static inline crisp_scene *rt_load_scene(const char *name, crisp_model **model)
{
    *model = rt_load_model(name);
    crisp_scene *sc = NULL;
    assert_int_equal(crisp_scene_prepare(*model, &sc), CRISP_OK);
    return sc;
}

/* A random perspective camera for the bound tests, drawing from rnd() (uniform in [0, 1)): the
 * eye at distance dist from the origin, at a polar angle up to th_max from +Z, looking at a point
 * off the origin by up to off * dist in x and y, +Y up. With random_size, a field of view of
 * 10-70 degrees and a 640-1920 x 360-1080 image (drawn first); else 40 degrees at 1920 x 1080. */
static inline void rt_random_camera(double (*rnd)(void), double dist, int random_size,
                                    double th_max, double off, double znear, crisp_camera *dest,
                                    crisp_camera_matrices *m)
{
    crisp_camera c = {.fov_deg = 40, .width = 1920, .height = 1080, .znear = znear, .zfar = 1e5};
    if (random_size) {
        c.fov_deg = 10 + 60 * rnd();
        c.width = 640 + (int)(1280 * rnd());
        c.height = 360 + (int)(720 * rnd());
    }
    double th = th_max * rnd(), ph = 6.283 * rnd();
    c.eye[0] = dist * sin(th) * cos(ph), c.eye[1] = dist * sin(th) * sin(ph);
    c.eye[2] = dist * cos(th);
    double o = off * dist * rnd();
    c.target[0] = o * (rnd() - 0.5), c.target[1] = o * (rnd() - 0.5);
    c.up[1] = 1;
    crisp_camera_matrices_compute(&c, m);
    *dest = c;
}

/* Screen distance (max norm, pixels) between the screen point (x, y) of a triangle and the
 * surface at the triangle's perspective-correct (u, v) there (as the rasterizer interpolates). */
static inline double rt_point_error(const crisp_camera *cam, crisp_mat4 vp,
                                    const crisp_surface *surf, const double sx[3],
                                    const double sy[3], const double iw[3], double uv[3][2],
                                    double x, double y)
{
    double det = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sy[1] - sy[0]) * (sx[2] - sx[0]);
    if (!(fabs(det) > 0)) return 0;
    double l1 = ((x - sx[0]) * (sy[2] - sy[0]) - (y - sy[0]) * (sx[2] - sx[0])) / det;
    double l2 = ((sx[1] - sx[0]) * (y - sy[0]) - (sy[1] - sy[0]) * (x - sx[0])) / det;
    double l[3] = {1 - l1 - l2, l1, l2};
    if (l[0] < -1e-9 || l[1] < -1e-9 || l[2] < -1e-9) return -1; /* outside the triangle */
    double wsum = l[0] * iw[0] + l[1] * iw[1] + l[2] * iw[2], u = 0, v = 0;
    for (int i = 0; i < 3; i++) {
        u += l[i] * iw[i] * uv[i][0] / wsum;
        v += l[i] * iw[i] * uv[i][1] / wsum;
    }
    double P[3], pc[4], sp[3];
    crisp_surface_eval(surf, u, v, P);
    crisp_mat4_mulp(vp, P, pc);
    crisp_camera_to_pixel(cam, pc, sp);
    return fmax(fabs(sp[0] - x), fabs(sp[1] - y));
}

/* The faces the renderer's last resolve listed as shown (crisp__renderer_seen, the planner's next
 * first stage) are exactly the faces of img's pixels, ascending. Returns how many. */
static inline size_t rt_assert_seen_faces(const crisp_renderer *r, const crisp_scene *sc,
                                          const crisp_image *img)
{
    const int32_t *seen;
    size_t count, listed = 0;
    crisp__renderer_seen(r, &seen, &count);
    uint8_t *shown = calloc(sc->face_count + 1, 1);
    assert_non_null(shown);
    for (size_t i = 0; i < (size_t)img->width * img->height; i++)
        if (img->face[i] >= 0) shown[img->face[i]] = 1;
    for (uint32_t f = 0; f < sc->face_count; f++)
        if (shown[f]) {
            assert_true(listed < count);
            assert_int_equal(seen[listed++], (int32_t)f);
        }
    assert_int_equal(listed, count);
    free(shown);
    return count;
}

/* Largest screen distance (max norm, pixels) between the last frame's triangles in front of the
 * near plane and the true surface at the interpolated (u, v): at seven points of every triangle
 * that fall within 2 px of the image, and, for triangles larger than a few pixels (at extreme
 * zoom one triangle covers the whole image), at every point of an 8 px grid over the image that
 * the triangle covers. */
static inline double rt_mesh_error(const crisp_renderer *r, const crisp_scene *sc,
                                   const crisp_camera *cam)
{
    const crisp_raster_vertex *v;
    const crisp_raster_tri *t;
    size_t nv, nt;
    crisp__renderer_mesh(r, &v, &nv, &t, &nt);
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    static const double bary[7][3] = {{1. / 3, 1. / 3, 1. / 3},
                                      {.5, .5, 0},
                                      {0, .5, .5},
                                      {.5, 0, .5},
                                      {.7, .2, .1},
                                      {.1, .7, .2},
                                      {.2, .1, .7}};
    double worst = 0;
    for (size_t k = 0; k < nt; k++) {
        const crisp_raster_vertex *c[3] = {&v[t[k].v[0]], &v[t[k].v[1]], &v[t[k].v[2]]};
        if (c[0]->clip[3] <= cam->znear || c[1]->clip[3] <= cam->znear ||
            c[2]->clip[3] <= cam->znear)
            continue;
        const crisp_surface *surf = sc->faces[t[k].face].src->surface;
        double sx[3], sy[3], iw[3], uv[3][2], lo[2] = {INFINITY, INFINITY},
                                              hi[2] = {-INFINITY, -INFINITY};
        for (int i = 0; i < 3; i++) {
            double p[3];
            crisp_camera_to_pixel(cam, c[i]->clip, p);
            sx[i] = p[0], sy[i] = p[1], iw[i] = 1 / c[i]->clip[3];
            uv[i][0] = c[i]->attr[0], uv[i][1] = c[i]->attr[1];
            lo[0] = fmin(lo[0], p[0]), hi[0] = fmax(hi[0], p[0]);
            lo[1] = fmin(lo[1], p[1]), hi[1] = fmax(hi[1], p[1]);
        }
        if (hi[0] < -2 || hi[1] < -2 || lo[0] > cam->width + 2 || lo[1] > cam->height + 2) continue;
        for (int q = 0; q < 7; q++) {
            double x = bary[q][0] * sx[0] + bary[q][1] * sx[1] + bary[q][2] * sx[2];
            double y = bary[q][0] * sy[0] + bary[q][1] * sy[1] + bary[q][2] * sy[2];
            if (x < -2 || y < -2 || x > cam->width + 2 || y > cam->height + 2) continue;
            double e = rt_point_error(cam, m.view_proj, surf, sx, sy, iw, uv, x, y);
            if (!(e <= worst)) worst = e;
        }
        if (hi[0] - lo[0] < 8 && hi[1] - lo[1] < 8) continue;
        for (int y = (int)fmax(0, ceil(lo[1] / 8)) * 8; y <= cam->height && y <= hi[1]; y += 8)
            for (int x = (int)fmax(0, ceil(lo[0] / 8)) * 8; x <= cam->width && x <= hi[0]; x += 8) {
                double e = rt_point_error(cam, m.view_proj, surf, sx, sy, iw, uv, x + 0.5, y + 0.5);
                if (!(e <= worst)) worst = e;
            }
    }
    return worst;
}

#endif
