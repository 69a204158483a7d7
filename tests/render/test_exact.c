/* Tests for the exact reference renderer: on a rational cylinder and a bicubic patch, every hit
 * lies on its ray and on the surface at the reported (u, v), hit depths match the analytic
 * intersection, and coverage matches except next to silhouettes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/render.h"

/* A unit-radius cylinder around Z from z = 0 to 2: rational quadratic circle x linear. */
static crisp_surface *make_cylinder(void)
{
    double ku[12] = {0, 0, 0, .25, .25, .5, .5, .75, .75, 1, 1, 1}, kv[4] = {0, 0, 1, 1};
    double circ[9][2] = {{1, 0},   {1, 1},  {0, 1},  {-1, 1}, {-1, 0},
                         {-1, -1}, {0, -1}, {1, -1}, {1, 0}};
    double pts[18 * 3], w[18];
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 9; i++) {
            pts[(j * 9 + i) * 3] = circ[i][0];
            pts[(j * 9 + i) * 3 + 1] = circ[i][1];
            pts[(j * 9 + i) * 3 + 2] = 2.0 * j;
            w[j * 9 + i] = i % 2 ? sqrt(0.5) : 1;
        }
    crisp_surface *s = NULL;
    assert_int_equal(crisp_surface_create(2, 1, 9, 2, ku, kv, pts, w, &s), CRISP_OK);
    return s;
}

static crisp_model *model_of(crisp_surface *s)
{
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    crisp_face f = {.surface = s};
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
    return m;
}

static void test_cylinder(void **state)
{
    (void)state;
    crisp_model *m = model_of(make_cylinder());
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    assert_int_equal(sc->patch_count, 4);
    crisp_camera cam = {.eye = {4, 1.5, 3.2},
                        .target = {0, 0, 1},
                        .up = {0, 0, 1},
                        .fov_deg = 45,
                        .znear = 0.1,
                        .zfar = 50,
                        .width = 96,
                        .height = 72};
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, cam.width, cam.height), CRISP_OK);
    assert_int_equal(crisp_render_exact(sc, &cam, &(crisp_exact_desc){.threads = 2}, &img),
                     CRISP_OK);
    int W = cam.width, H = cam.height, covered = 0;
    char *ana = calloc((size_t)W * H, 1);
    double *at = calloc((size_t)W * H, sizeof(double));
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            double o[3], d[3];
            crisp_camera_ray(&cam, i + 0.5, j + 0.5, o, d);
            /* Nearest of the two roots of |o + t d|_xy = 1 with z in [0, 2]. */
            double a = d[0] * d[0] + d[1] * d[1], b = 2 * (o[0] * d[0] + o[1] * d[1]);
            double c = o[0] * o[0] + o[1] * o[1] - 1, disc = b * b - 4 * a * c;
            if (disc < 0 || a == 0) continue;
            for (int r = 0; r < 2; r++) {
                double t = (-b + (r ? 1 : -1) * sqrt(disc)) / (2 * a);
                double z = o[2] + t * d[2];
                if (t > 0 && z >= 0 && z <= 2) {
                    ana[j * W + i] = 1;
                    at[j * W + i] = t;
                    break;
                }
            }
        }
    for (int j = 1; j < H - 1; j++)
        for (int i = 1; i < W - 1; i++) {
            int same = 1, c = ana[j * W + i];
            for (int dj = -1; dj <= 1; dj++)
                for (int di = -1; di <= 1; di++)
                    same &= ana[(j + dj) * W + i + di] == c;
            int px = j * W + i;
            if (!same) continue;
            assert_int_equal(img.face[px] >= 0, c);
            if (!c) continue;
            covered++;
            /* Depth along the ray: compare the hit point with the analytic one. */
            double o[3], d[3], P[3];
            crisp_camera_ray(&cam, i + 0.5, j + 0.5, o, d);
            crisp_surface_eval(m->faces[0].surface, img.uv[2 * px], img.uv[2 * px + 1], P);
            double Q[3] = {o[0] + at[px] * d[0], o[1] + at[px] * d[1], o[2] + at[px] * d[2]};
            /* uv are stored as float: compare within float resolution of the parameters. */
            assert_true(fabs(P[0] - Q[0]) + fabs(P[1] - Q[1]) + fabs(P[2] - Q[2]) < 1e-5);
            assert_true(fabs(hypot(Q[0], Q[1]) - 1) < 1e-12);
        }
    assert_true(covered > 1000);
    /* crisp_exact_ray gives full precision. */
    double o[3] = {5, 0.3, 1.1}, d[3] = {-1, 0, 0}, t, uv[2], n[3];
    uint32_t face;
    assert_true(crisp_exact_ray(sc, NULL, o, d, 0, 100, &t, &face, uv, n));
    assert_true(fabs(t - (5 - sqrt(1 - 0.09))) < 1e-12);
    double P[3];
    crisp_surface_eval(m->faces[0].surface, uv[0], uv[1], P);
    assert_true(fabs(P[0] - (5 - t)) < 1e-12 && fabs(P[1] - 0.3) < 1e-12 &&
                fabs(P[2] - 1.1) < 1e-12);
    assert_true(fabs(fabs(n[0]) - sqrt(1 - 0.09)) < 1e-9);
    /* A ray that misses. */
    double o2[3] = {5, 1.2, 1.1};
    assert_false(crisp_exact_ray(sc, NULL, o2, d, 0, 100, &t, &face, uv, n));
    free(ana);
    free(at);
    crisp_image_free(&img);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

static int keep_left_half(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)ctx, (void)sc, (void)face, (void)v;
    return u < 0.5;
}

static void test_bicubic_and_classify(void **state)
{
    (void)state;
    /* A wavy bicubic patch over [-1, 1]^2 in the xy plane, z up. */
    double k[8] = {0, 0, 0, 0, 1, 1, 1, 1}, pts[16 * 3];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            pts[(j * 4 + i) * 3] = -1 + 2.0 * i / 3;
            pts[(j * 4 + i) * 3 + 1] = -1 + 2.0 * j / 3;
            pts[(j * 4 + i) * 3 + 2] = ((i + j) % 2 ? 0.6 : -0.4);
        }
    crisp_surface *s;
    assert_int_equal(crisp_surface_create(3, 3, 4, 4, k, k, pts, NULL, &s), CRISP_OK);
    crisp_model *m = model_of(s);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_camera cam = {.eye = {0.4, -3, 4},
                        .target = {0, 0, 0},
                        .up = {0, 0, 1},
                        .fov_deg = 40,
                        .znear = 0.1,
                        .zfar = 50,
                        .width = 64,
                        .height = 48};
    crisp_image img, half;
    crisp_image_init(&img, 64, 48);
    crisp_image_init(&half, 64, 48);
    assert_int_equal(crisp_render_exact(sc, &cam, NULL, &img), CRISP_OK);
    crisp_exact_desc desc = {.classify = keep_left_half};
    assert_int_equal(crisp_render_exact(sc, &cam, &desc, &half), CRISP_OK);
    int hits = 0, kept = 0;
    for (int px = 0; px < 64 * 48; px++) {
        if (img.face[px] < 0) continue;
        hits++;
        double o[3], d[3], P[3];
        crisp_camera_ray(&cam, px % 64 + 0.5, px / 64 + 0.5, o, d);
        crisp_surface_eval(s, img.uv[2 * px], img.uv[2 * px + 1], P);
        /* P lies on the ray (up to float storage of uv). */
        double v[3] = {P[0] - o[0], P[1] - o[1], P[2] - o[2]}, c[3];
        crisp_vec3_cross(v, d, c);
        assert_true(crisp_vec3_norm(c) < 1e-5);
        if (half.face[px] >= 0) {
            kept++;
            assert_true(half.uv[2 * px] < 0.5);
            if (img.uv[2 * px] < 0.5) assert_true(fabs(half.depth[px] - img.depth[px]) < 1e-6);
        } else {
            assert_true(img.uv[2 * px] >= 0.5 - 1e-6);
        }
    }
    assert_true(hits > 500 && kept > 100 && kept < hits);
    crisp_image_free(&img);
    crisp_image_free(&half);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cylinder),
        cmocka_unit_test(test_bicubic_and_classify),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
