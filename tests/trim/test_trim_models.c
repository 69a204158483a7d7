/* Trim plans on a real file: occt_linkrods.step, whose faces 20, 22, 33 and 35 are rational
 * (6, 10) surfaces with exporter knot noise (v-spans of ~2e-8 of the domain where the surface
 * really does fold back and forth, with screen speeds of 1e7 px per unit v) in a part of the
 * domain that the trim loops cut away. Before the strips and the density bound were restricted
 * to the part of the face the loops can enclose, each of these faces asked for 1 to 18 million
 * scan lines (the row cap). Here, under several cameras and strip counts, every face's table must
 * stay within a few times the pixel rows of the image: at most 4 x the image diagonal + 2 per
 * strip (rows follow the largest screen speed in each strip, so a face whose visible part runs
 * from the near plane outwards can need more rows than its own screen box has pixels; the ratio
 * to the screen box of its sampled visible inside points is printed). The classification stays
 * correct:
 * the table agrees with the exact classifier on the true curves at sampled points farther than
 * 1.5 px (on screen) from the boundary.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "crisp/io.h"
#include "crisp/render.h"
#include "crisp/trim.h"

#define GRID 96

static crisp_model *model;
static crisp_scene *scene;

static int setup(void **state)
{
    (void)state;
    if (crisp_model_load(CRISP_DATA_DIR "/nurbs/occt_linkrods.step", NULL, &model)) return -1;
    return crisp_scene_prepare(model, &scene) ? -1 : 0;
}

static int teardown(void **state)
{
    (void)state;
    crisp_scene_destroy(scene);
    crisp_model_destroy(model);
    return 0;
}

/* Pixel position of the surface point (u, v); 0 when it is behind the near plane or more than
 * 4 px outside the viewport. */
static int project(const crisp_scene_face *f, const crisp_camera *cam, crisp_mat4 vp, double u,
                   double v, double xy[2])
{
    double p[4], c[4];
    crisp_surface_eval(f->src->surface, u, v, p);
    p[3] = 1.0;
    for (int r = 0; r < 4; r++)
        c[r] = vp[0][r] * p[0] + vp[1][r] * p[1] + vp[2][r] * p[2] + vp[3][r] * p[3];
    if (!(c[3] > 0.0) || c[2] < -c[3] || c[2] > c[3]) return 0;
    xy[0] = (c[0] / c[3] + 1.0) * 0.5 * cam->width;
    xy[1] = (1.0 - c[1] / c[3]) * 0.5 * cam->height;
    return xy[0] >= -4 && xy[0] <= cam->width + 4 && xy[1] >= -4 && xy[1] <= cam->height + 4;
}

typedef struct tally {
    long rows, faces_checked, far_points, far_wrong;
    double worst_ratio; /* rows / (4 diag + 2 strips) */
} tally;

static void check_camera(const crisp_camera *cam, int strips, tally *t)
{
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    for (uint32_t fi = 0; fi < scene->face_count; fi++) {
        const crisp_scene_face *f = &scene->faces[fi];
        const crisp_bezier_curve *pieces = f->piece_count ? scene->pieces + f->first_piece : NULL;
        crisp_trim_plan plan = {0};
        crisp_trim_plan_desc d = {.patches = scene->face_patches[fi].patches,
                                  .patch_count = (int)scene->face_patches[fi].count,
                                  .pieces = pieces,
                                  .piece_count = (int)f->piece_count,
                                  .view_proj = &m.view_proj,
                                  .width = cam->width,
                                  .height = cam->height,
                                  .v0 = f->domain[2],
                                  .v1 = f->domain[3],
                                  .strip_count = strips};
        assert_int_equal(crisp_trim_plan_face(&d, &plan), CRISP_OK);
        assert_int_equal(plan.clamped, 0);
        /* Screen box of the visible points inside the loops, on a grid of the domain. */
        double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
        static double xy_grid[GRID + 1][GRID + 1][2];
        static signed char in_grid[GRID + 1][GRID + 1];
        for (int j = 0; j <= GRID; j++)
            for (int i = 0; i <= GRID; i++) {
                double u = f->domain[0] + (f->domain[1] - f->domain[0]) * i / GRID;
                double v = f->domain[2] + (f->domain[3] - f->domain[2]) * j / GRID;
                in_grid[j][i] = -1;
                if (!project(f, cam, m.view_proj, u, v, xy_grid[j][i])) continue;
                int inside =
                    pieces ? crisp_trim_exact_classify(pieces, (int)f->piece_count, u, v) : 1;
                in_grid[j][i] = (signed char)inside;
                if (!inside) continue;
                for (int k = 0; k < 2; k++) {
                    lo[k] = fmin(lo[k], xy_grid[j][i][k]);
                    hi[k] = fmax(hi[k], xy_grid[j][i][k]);
                }
            }
        double diag = hi[0] >= lo[0] ? hypot(hi[0] - lo[0], hi[1] - lo[1]) : 0.0;
        double ratio = plan.table.row_count / (4.0 * diag + 2.0 * plan.strip_count);
        if (ratio > t->worst_ratio) t->worst_ratio = ratio;
        if (ratio > 1.0)
            print_message("face %u: %u rows, sampled screen diagonal %.1f px, %d strips\n", fi,
                          plan.table.row_count, diag, plan.strip_count);
        assert_true(plan.table.row_count <=
                    4.0 * hypot(cam->width, cam->height) + 2.0 * plan.strip_count);
        t->rows += plan.table.row_count;
        t->faces_checked++;
        /* Far from the boundary: the 8 grid neighbours have the same class and lie at least
         * 1.5 px away on screen ... */
        for (int j = 1; j < GRID; j++)
            for (int i = 1; i < GRID; i++) {
                int c = in_grid[j][i];
                if (c < 0 || !pieces) continue;
                int near = 0;
                for (int dj = -1; dj <= 1 && !near; dj++)
                    for (int di = -1; di <= 1 && !near; di++) {
                        if (!di && !dj) continue;
                        if (in_grid[j + dj][i + di] != c ||
                            hypot(xy_grid[j + dj][i + di][0] - xy_grid[j][i][0],
                                  xy_grid[j + dj][i + di][1] - xy_grid[j][i][1]) < 1.5)
                            near = 1;
                    }
                if (near) continue;
                double u = f->domain[0] + (f->domain[1] - f->domain[0]) * i / GRID;
                double v = f->domain[2] + (f->domain[3] - f->domain[2]) * j / GRID;
                t->far_points++;
                if (crisp_trim_table_test(&plan.table, u, v) == c) continue;
                /* ... and no curve within a grid step in uv (a curve along a grid line, or a
                 * slit, would pass between the neighbours); measured only where the two disagree
                 * (the exact distance is slow). */
                double step = fmin(f->domain[1] - f->domain[0], f->domain[3] - f->domain[2]) / GRID;
                double dist = crisp_trim_exact_distance(pieces, (int)f->piece_count, u, v);
                if (dist < step) {
                    t->far_points--;
                    continue;
                }
                {
                    t->far_wrong++;
                    print_message("face %u: (%.9g, %.9g) at pixel (%.1f, %.1f): exact %d, table "
                                  "%d, uv distance to the curves %.3g\n",
                                  fi, u, v, xy_grid[j][i][0], xy_grid[j][i][1], c, !c, dist);
                }
            }
        crisp_trim_plan_free(&plan);
    }
}

static void test_linkrods_rows(void **state)
{
    (void)state;
    crisp_camera base;
    assert_int_equal(crisp_camera_frame_box(scene->box, 1280, 720, &base), CRISP_OK);
    /* The default view; zoomed 8x at face 33; close to the wild (trimmed away) part of face 33
     * at v = -3.61275; grazing along face 33. */
    const crisp_scene_face *f33 = &scene->faces[33];
    double mid[3], wild[3], nrm[3], su[3], sv[3];
    crisp_surface_derivs(f33->src->surface, 0.0, -1.85, mid, su, sv, NULL, NULL, NULL);
    crisp_vec3_cross(su, sv, nrm);
    crisp_vec3_normalize(nrm, nrm);
    crisp_surface_eval(f33->src->surface, 0.0, -3.61275, wild);
    crisp_camera cams[4] = {base, base, base, base};
    cams[1].fov_deg = base.fov_deg / 8;
    for (int k = 0; k < 3; k++) {
        cams[1].target[k] = mid[k];
        cams[1].eye[k] = base.eye[k] + (mid[k] - base.target[k]);
        cams[2].target[k] = wild[k];
        cams[2].eye[k] = wild[k] + 0.3 * nrm[k] + 0.2 * (k == 2);
        cams[3].target[k] = mid[k] + 2.0 * sv[k] / crisp_vec3_norm(sv);
        cams[3].eye[k] = mid[k] - 1.5 * sv[k] / crisp_vec3_norm(sv) + 0.15 * nrm[k];
    }
    cams[2].znear = cams[3].znear = 0.01;
    tally t = {0};
    const int strips[2] = {16, 256};
    for (int c = 0; c < 4; c++)
        for (int s = 0; s < 2; s++) {
            long before = t.rows;
            check_camera(&cams[c], strips[s], &t);
            print_message("camera %d, %d strips: %ld table rows over %u faces\n", c, strips[s],
                          t.rows - before, scene->face_count);
        }
    print_message("worst rows / (4 diag + 2 strips) = %.3f; %ld points far from the boundary, "
                  "%ld classified differently\n",
                  t.worst_ratio, t.far_points, t.far_wrong);
    assert_true(t.far_points > 10000);
    assert_int_equal(t.far_wrong, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_linkrods_rows),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
