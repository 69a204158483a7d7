/* Tests for f-rep parts in scenes (src/render/frep_part.c, src/io/scene.c): a sphere and an
 * affinely transformed sphere (an ellipsoid) through random perspective cameras against the
 * analytic ray intersection (depth, coverage away from silhouettes, normals), an f-rep sphere
 * cutting a NURBS plane (each pixel shows the nearer one), cameras inside and across the solid,
 * and scene files (good ones load; bad ones fail with file:line:column). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/frep.h"
#include "crisp/render.h"
#include "crisp/scene_file.h"

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static double urand(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}

static crisp_frep_tape *sphere_tape(crisp_frep **fp)
{
    const char *src = "sqrt(X*X + Y*Y + Z*Z) - 1";
    assert_int_equal(crisp_frep_read_math_mem("sphere", src, strlen(src), fp), CRISP_OK);
    crisp_frep_tape *t = NULL;
    assert_int_equal(crisp_frep_tape_create(*fp, &t), CRISP_OK);
    return t;
}

/* Analytic: nearest t > 0 where the ray meets the ellipsoid M(unit sphere) with camera-space
 * depth in [znear, zfar]; depth and world normal out. */
static int ellipsoid_hit(crisp_mat4 inv, const crisp_camera *cam, const double o[3],
                         const double d[3], double *depth, double n[3])
{
    double f[3], w[3];
    crisp_vec3_sub(cam->target, cam->eye, w);
    crisp_vec3_normalize(w, f);
    double lo[3], ld[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = inv[3][a];
        ld[a] = 0;
        for (int b = 0; b < 3; b++) {
            lo[a] += inv[b][a] * o[b];
            ld[a] += inv[b][a] * d[b];
        }
    }
    double A = crisp_vec3_dot(ld, ld), B = 2 * crisp_vec3_dot(lo, ld),
           C = crisp_vec3_dot(lo, lo) - 1;
    double disc = B * B - 4 * A * C;
    if (disc < 0) return 0;
    double fd = crisp_vec3_dot(d, f);
    for (int r = 0; r < 2; r++) {
        double t = (-B + (r ? 1 : -1) * sqrt(disc)) / (2 * A);
        double z = t * fd;
        if (t > 0 && z >= cam->znear && z <= cam->zfar) {
            *depth = z;
            double q[3];
            for (int a = 0; a < 3; a++)
                q[a] = lo[a] + t * ld[a];
            for (int a = 0; a < 3; a++)
                n[a] = inv[a][0] * q[0] + inv[a][1] * q[1] + inv[a][2] * q[2];
            double len = crisp_vec3_norm(n);
            for (int a = 0; a < 3; a++)
                n[a] /= len;
            return 1;
        }
        if (t > 0 && z < cam->znear) {
            /* The near plane cuts the solid here: the part shows its inside at the near plane. */
        }
    }
    return 0;
}

static void random_camera(crisp_camera *cam, double dist)
{
    double dir[3];
    do {
        for (int a = 0; a < 3; a++)
            dir[a] = 2 * urand() - 1;
    } while (crisp_vec3_norm(dir) < 0.2 || crisp_vec3_norm(dir) > 1);
    crisp_vec3_normalize(dir, dir);
    double r = dist * (1 + urand());
    *cam = (crisp_camera){.fov_deg = 20 + 40 * urand(),
                          .znear = 0.05,
                          .zfar = 30,
                          .width = 64 + (int)(32 * urand()),
                          .height = 48 + (int)(24 * urand())};
    for (int a = 0; a < 3; a++) {
        cam->eye[a] = r * dir[a];
        cam->target[a] = 0.3 * (2 * urand() - 1);
        cam->up[a] = 2 * urand() - 1;
    }
}

/* Render the part through cam (both modes) and compare with the analytic ellipsoid. */
static void check_part(const crisp_frep_part *part, const crisp_camera *cam, int per_pixel)
{
    crisp_mat4 m, inv;
    memcpy(m, part->transform, sizeof m);
    assert_true(crisp_mat4_inverse(m, inv));
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, cam->width, cam->height), CRISP_OK);
    assert_int_equal(
        crisp_render_frep_parts(
            part, 1, cam, &(crisp_frep_parts_desc){.threads = 2, .per_pixel = per_pixel}, &img),
        CRISP_OK);
    int W = cam->width, H = cam->height, compared = 0, hits = 0;
    char *ana = calloc((size_t)W * H, 1);
    double *dep = calloc((size_t)W * H, sizeof(double)),
           *nor = calloc((size_t)W * H * 3, sizeof(double));
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            double o[3], d[3];
            crisp_camera_ray(cam, i + 0.5, j + 0.5, o, d);
            ana[j * W + i] =
                (char)ellipsoid_hit(inv, cam, o, d, &dep[j * W + i], &nor[3 * (j * W + i)]);
        }
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            size_t p = (size_t)j * W + i;
            assert_false(isnan(img.depth[p]) || isnan(img.rgba[4 * p]) || isnan(img.normal[3 * p]));
            int same = 1;
            for (int dj = -1; dj <= 1; dj++)
                for (int di = -1; di <= 1; di++) {
                    int ii = i + di, jj = j + dj;
                    if (ii >= 0 && jj >= 0 && ii < W && jj < H) same &= ana[jj * W + ii] == ana[p];
                }
            if (!same) continue;
            compared++;
            int got = img.face[p] == CRISP_FREP_FACE_ID(0);
            if (got != ana[p])
                fail_msg("pixel %d,%d: f-rep %s, analytic %s", i, j, got ? "hit" : "miss",
                         ana[p] ? "hit" : "miss");
            if (!got) {
                assert_true(isinf(img.depth[p]));
                continue;
            }
            hits++;
            double rel = fabs(img.depth[p] - dep[p]) / dep[p];
            if (rel > 1e-3)
                fail_msg("pixel %d,%d: depth %.7g, analytic %.7g", i, j, img.depth[p], dep[p]);
            for (int a = 0; a < 3; a++)
                if (fabs(img.normal[3 * p + a] - nor[3 * p + a]) > 1e-3)
                    fail_msg("pixel %d,%d: normal[%d] %.6f, analytic %.6f", i, j, a,
                             img.normal[3 * p + a], nor[3 * p + a]);
        }
    assert_true(compared > W * H / 2);
    assert_true(hits > 20);
    free(ana);
    free(dep);
    free(nor);
    crisp_image_free(&img);
}

static void test_sphere_random_cameras(void **state)
{
    (void)state;
    crisp_frep *f;
    crisp_frep_tape *t = sphere_tape(&f);
    crisp_frep_part part = {.tape = t, .color = {0.8f, 0.3f, 0.2f, 1}};
    crisp_mat4_identity(part.transform);
    for (int k = 0; k < 8; k++) {
        crisp_camera cam;
        random_camera(&cam, 2.5);
        check_part(&part, &cam, k & 1);
    }
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

static void test_transformed_part(void **state)
{
    (void)state;
    crisp_frep *f;
    crisp_frep_tape *t = sphere_tape(&f);
    crisp_frep_part part = {.tape = t, .color = {0.2f, 0.8f, 0.3f, 1}};
    /* scale (1.5, 0.6, 0.9), then rotate 35 degrees about (1, 2, 0.5), then translate. */
    crisp_mat4 s, r, tr, tmp;
    crisp_mat4_identity(s);
    s[0][0] = 1.5, s[1][1] = 0.6, s[2][2] = 0.9;
    double ax[3] = {1, 2, 0.5}, c = cos(35 * M_PI / 180), sn = sin(35 * M_PI / 180);
    crisp_vec3_normalize(ax, ax);
    crisp_mat4_identity(r);
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            double v = (1 - c) * ax[a] * ax[b] + (a == b ? c : 0);
            int k = 3 - a - b;
            if (a != b) v += ((a + 1) % 3 == b ? -1 : 1) * sn * ax[k];
            r[b][a] = v; /* m[col][row] */
        }
    crisp_mat4_identity(tr);
    tr[3][0] = 0.3, tr[3][1] = -0.2, tr[3][2] = 0.4;
    crisp_mat4_mul(r, s, tmp);
    crisp_mat4_mul(tr, tmp, part.transform);
    for (int k = 0; k < 6; k++) {
        crisp_camera cam;
        random_camera(&cam, 3.5);
        check_part(&part, &cam, k & 1);
    }
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

/* A bilinear NURBS plane z = h over [-3, 3]^2. */
static crisp_model *plane_model(double h)
{
    double ku[4] = {0, 0, 1, 1}, pts[12] = {-3, -3, h, 3, -3, h, -3, 3, h, 3, 3, h};
    crisp_surface *s = NULL;
    assert_int_equal(crisp_surface_create(1, 1, 2, 2, ku, ku, pts, NULL, &s), CRISP_OK);
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    crisp_face face = {.surface = s};
    assert_int_equal(crisp_model_add_face(m, &face), CRISP_OK);
    return m;
}

static void test_sphere_cuts_plane(void **state)
{
    (void)state;
    crisp_frep *f;
    crisp_frep_tape *t = sphere_tape(&f);
    crisp_frep_part part = {.tape = t, .color = {0.8f, 0.3f, 0.2f, 1}};
    crisp_mat4_identity(part.transform);
    crisp_model *m = plane_model(0.3);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_mat4 inv;
    crisp_mat4_identity(inv);
    for (int k = 0; k < 4; k++) {
        crisp_camera cam = {.eye = {3.5 * cos(k), 3.5 * sin(k), 2.5 + 0.3 * k},
                            .target = {0, 0, 0.2},
                            .up = {0, 0, 1},
                            .fov_deg = 40,
                            .znear = 0.1,
                            .zfar = 20,
                            .width = 80,
                            .height = 60};
        crisp_image img;
        assert_int_equal(crisp_image_init(&img, cam.width, cam.height), CRISP_OK);
        if (k & 1) {
            assert_int_equal(crisp_render_exact(sc, &cam, &(crisp_exact_desc){.threads = 2}, &img),
                             CRISP_OK);
        } else {
            crisp_renderer *r;
            assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r),
                             CRISP_OK);
            assert_int_equal(crisp_render_cpu(r, sc, &cam, &img, NULL), CRISP_OK);
            crisp_renderer_destroy(r);
        }
        assert_int_equal(
            crisp_render_frep_parts(
                &part, 1, &cam, &(crisp_frep_parts_desc){.threads = 2, .per_pixel = k & 1}, &img),
            CRISP_OK);
        int W = cam.width, H = cam.height, spheres = 0, planes = 0;
        int *who = calloc((size_t)W * H, sizeof(int));
        double *dep = calloc((size_t)W * H, sizeof(double));
        double fw[3], w[3];
        crisp_vec3_sub(cam.target, cam.eye, w);
        crisp_vec3_normalize(w, fw);
        for (int j = 0; j < H; j++)
            for (int i = 0; i < W; i++) {
                double o[3], d[3], ds, n[3];
                crisp_camera_ray(&cam, i + 0.5, j + 0.5, o, d);
                int p = j * W + i;
                who[p] = -1;
                dep[p] = INFINITY;
                if (ellipsoid_hit(inv, &cam, o, d, &ds, n)) who[p] = -2, dep[p] = ds;
                double tp = (0.3 - o[2]) / d[2];
                double x = o[0] + tp * d[0], y = o[1] + tp * d[1], zp = tp * crisp_vec3_dot(d, fw);
                if (tp > 0 && fabs(x) <= 3 && fabs(y) <= 3 && zp < dep[p]) who[p] = 0, dep[p] = zp;
            }
        for (int j = 1; j < H - 1; j++)
            for (int i = 1; i < W - 1; i++) {
                int p = j * W + i, same = 1;
                for (int dj = -1; dj <= 1; dj++)
                    for (int di = -1; di <= 1; di++)
                        same &= who[(j + dj) * W + i + di] == who[p];
                if (!same) continue;
                if (img.face[p] != who[p])
                    fail_msg("camera %d pixel %d,%d: face %d, analytic %d", k, i, j, img.face[p],
                             who[p]);
                if (who[p] == -1) continue;
                spheres += who[p] == -2;
                planes += who[p] == 0;
                if (fabs(img.depth[p] - dep[p]) > 1e-3 * dep[p])
                    fail_msg("camera %d pixel %d,%d: depth %.7g, analytic %.7g", k, i, j,
                             img.depth[p], dep[p]);
            }
        assert_true(spheres > 50);
        assert_true(planes > 50);
        free(who);
        free(dep);
        crisp_image_free(&img);
    }
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

static void test_camera_inside_and_crossing(void **state)
{
    (void)state;
    crisp_frep *f;
    crisp_frep_tape *t = sphere_tape(&f);
    crisp_frep_part part = {.tape = t, .color = {0.5f, 0.5f, 0.9f, 1}};
    crisp_mat4_identity(part.transform);
    crisp_camera cams[3] = {
        {.eye = {0.1, 0.2, 0.1},
         .target = {1, 0, 0},
         .up = {0, 0, 1},
         .fov_deg = 60,
         .znear = 0.01,
         .zfar = 10,
         .width = 40,
         .height = 30},
        {.eye = {0, 0, 1.05},
         .target = {0, 0, 0},
         .up = {0, 1, 0},
         .fov_deg = 90,
         .znear = 0.2,
         .zfar = 10,
         .width = 40,
         .height = 30},
        {.eye = {0, 0, 1e-3},
         .target = {0, 0, -1},
         .up = {0, 1, 0},
         .fov_deg = 179,
         .znear = 1e-6,
         .zfar = 1e6,
         .width = 33,
         .height = 17},
    };
    for (int k = 0; k < 3; k++)
        for (int pp = 0; pp < 2; pp++) {
            crisp_image img;
            assert_int_equal(crisp_image_init(&img, cams[k].width, cams[k].height), CRISP_OK);
            assert_int_equal(crisp_render_frep_parts(&part, 1, &cams[k],
                                                     &(crisp_frep_parts_desc){.per_pixel = pp},
                                                     &img),
                             CRISP_OK);
            size_t n = (size_t)img.width * img.height, drawn = 0;
            for (size_t p = 0; p < n; p++) {
                for (int a = 0; a < 4; a++)
                    assert_false(isnan(img.rgba[4 * p + a]));
                for (int a = 0; a < 3; a++)
                    assert_false(isnan(img.normal[3 * p + a]));
                assert_false(isnan(img.depth[p]));
                if (img.face[p] == -2) {
                    drawn++;
                    assert_true(img.depth[p] >= cams[k].znear * (1 - 1e-6));
                    assert_true(img.depth[p] <= cams[k].zfar);
                }
            }
            /* Inside the solid (k = 0, 2) every pixel sees it at the near plane. */
            if (k != 1)
                assert_int_equal(drawn, n);
            else
                assert_true(drawn > 0);
            crisp_image_free(&img);
        }
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

/* Bad scene text: the error names the file, line and column and says what was expected. */
static void expect_error(const char *text, const char *where, const char *what)
{
    crisp_scene_file *s = (crisp_scene_file *)1;
    assert_int_not_equal(crisp_scene_file_read_mem("bad.scene", NULL, text, strlen(text), &s),
                         CRISP_OK);
    assert_null(s);
    const char *msg = crisp_error_message();
    if (!strstr(msg, where) || !strstr(msg, what))
        fail_msg("for '%s': message '%s' lacks '%s' or '%s'", text, msg, where, what);
}

static void test_scene_file_errors(void **state)
{
    (void)state;
    expect_error("", "bad.scene:", "expected at least one");
    expect_error("# only a comment\n", "bad.scene:", "expected at least one");
    expect_error("model a.igs\nmesh b.obj\n", "bad.scene:2:1:", "expected 'model' or 'frep'");
    expect_error("model\n", "bad.scene:1:6:", "expected a file path");
    expect_error("frep a.vm translate 1 2\n", "bad.scene:1:", "three numbers after 'translate'");
    expect_error("frep a.vm translate 1 x 2\n", "bad.scene:1:23:", "three numbers");
    expect_error("frep a.vm\n\nfrep b.vm scale 0\n", "bad.scene:3:11:", "non-zero scale");
    expect_error("frep a.vm rotate 0 0 0 30\n", "bad.scene:1:11:", "non-zero rotation axis");
    expect_error("frep a.vm color 1 2 0\n", "bad.scene:1:19:", "in [0, 1]");
    expect_error("frep a.vm wobble 3\n", "bad.scene:1:11:", "expected translate, scale");
    expect_error("frep math X*X\n", "bad.scene:1:11:", "math string in double quotes");
    expect_error("frep math \"X - 1\n", "bad.scene:1:11:", "closing");
    expect_error("frep a.vm transform 1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1\n",
                 "bad.scene:1:11:", "affine");
    expect_error("frep a.vm transform 1 0 0 0 0 1 0 0 0 0 0 0 0 0 0 1\n",
                 "bad.scene:1:11:", "invertible");
    expect_error("frep a.vm scale 1e300 scale 1e300\n", "bad.scene:1:1:", "finite");
    expect_error("frep a.vm translate 1 2 nan\n", "bad.scene:1:25:", "three numbers");
    /* Loading reports the scene line of a file that is missing or does not parse. */
    const char *text = "frep math \"X +\"\n";
    crisp_scene_file *s;
    assert_int_equal(crisp_scene_file_read_mem("bad.scene", NULL, text, strlen(text), &s),
                     CRISP_OK);
    crisp_scene_assets *a = (crisp_scene_assets *)1;
    assert_int_not_equal(crisp_scene_assets_load(s, &a), CRISP_OK);
    assert_null(a);
    assert_non_null(strstr(crisp_error_message(), "bad.scene:1:"));
    crisp_scene_file_destroy(s);
    text = "model does_not_exist.igs\n";
    assert_int_equal(crisp_scene_file_read_mem("bad.scene", "/nonexistent", text, strlen(text), &s),
                     CRISP_OK);
    assert_int_not_equal(crisp_scene_assets_load(s, &a), CRISP_OK);
    assert_non_null(strstr(crisp_error_message(), "bad.scene:1:"));
    crisp_scene_file_destroy(s);
}

/* The bundled example: paths relative to the scene file, the teapot merged, parts placed. */
static void test_scene_file_example(void **state)
{
    (void)state;
    const char *path = CRISP_DATA_DIR "/scenes/teapot_frep.scene";
    assert_true(crisp_scene_file_detect(path));
    assert_false(crisp_scene_file_detect(CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs"));
    crisp_scene_file *s;
    assert_int_equal(crisp_scene_file_read(path, &s), CRISP_OK);
    assert_int_equal(s->item_count, 3);
    assert_int_equal(s->items[0].kind, CRISP_SCENE_MODEL);
    assert_int_equal(s->items[2].kind, CRISP_SCENE_FREP);
    assert_non_null(s->items[2].math);
    /* scale 1.3 then translate (-1, 0.5, 1.6): the origin goes to the translation. */
    assert_float_equal(s->items[2].transform[0][0], 1.3, 1e-12);
    assert_float_equal(s->items[2].transform[3][0], -1, 1e-12);
    assert_float_equal(s->items[2].transform[3][2], 1.6, 1e-12);
    crisp_scene_assets *a;
    assert_int_equal(crisp_scene_assets_load(s, &a), CRISP_OK);
    assert_int_equal(a->model->face_count, 32);
    assert_int_equal(a->part_count, 2);
    assert_true(a->model->faces[0].has_color);
    /* the sphere part is negative at its placed centre, positive 1.4 away */
    assert_true(crisp_frep_eval_point(a->parts[1].tape, 0, 0, 0) < 0);
    crisp_scene_assets_destroy(a);
    crisp_scene_file_destroy(s);
    /* Model transforms move the control points: translate the teapot by (10, 0, 0). */
    const char *text =
        "model " CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs rotate 0 0 1 180 translate 10 0 0\n";
    assert_int_equal(crisp_scene_file_read_mem("t.scene", NULL, text, strlen(text), &s), CRISP_OK);
    assert_int_equal(crisp_scene_assets_load(s, &a), CRISP_OK);
    double box[6];
    crisp_model_bbox(a->model, box);
    /* [-3, 3.525] in x, rotated by 180 degrees and moved by 10: [6.475, 13]. */
    assert_float_equal(box[0], 6.475, 1e-9);
    assert_float_equal(box[3], 13, 1e-9);
    assert_float_equal(box[5], 3.15, 1e-9);
    crisp_scene_assets_destroy(a);
    crisp_scene_file_destroy(s);
}

/* tanglecube.vm through a perspective camera: the frustum subdivision (cpu) and the per-pixel
 * ray bisection (exact) agree on coverage except at a few silhouette pixels, and on depth; no
 * pixel is drawn with a NaN. */
static void test_tiles_match_per_pixel(void **state)
{
    (void)state;
    crisp_frep *f;
    assert_int_equal(crisp_frep_read_vm(CRISP_DATA_DIR "/frep/tanglecube.vm", &f), CRISP_OK);
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    crisp_frep_part part = {.tape = t, .color = {1, 1, 1, 1}};
    crisp_mat4_identity(part.transform);
    part.transform[0][0] = part.transform[1][1] = part.transform[2][2] = 1.2;
    crisp_camera cam = {.eye = {-2.5, -14, 7},
                        .target = {0, 0, 0},
                        .up = {0, 0, 1},
                        .fov_deg = 12,
                        .znear = 0.002,
                        .zfar = 40,
                        .width = 160,
                        .height = 90};
    crisp_image a, b;
    assert_int_equal(crisp_image_init(&a, cam.width, cam.height), CRISP_OK);
    assert_int_equal(crisp_image_init(&b, cam.width, cam.height), CRISP_OK);
    assert_int_equal(
        crisp_render_frep_parts(&part, 1, &cam, &(crisp_frep_parts_desc){.threads = 2}, &a),
        CRISP_OK);
    assert_int_equal(
        crisp_render_frep_parts(&part, 1, &cam, &(crisp_frep_parts_desc){.per_pixel = 1}, &b),
        CRISP_OK);
    size_t n = (size_t)cam.width * cam.height, differ = 0, both = 0;
    for (size_t p = 0; p < n; p++) {
        assert_false(isnan(a.rgba[4 * p]) || isnan(a.normal[3 * p]));
        if ((a.face[p] == -2) != (b.face[p] == -2))
            differ++;
        else if (a.face[p] == -2) {
            both++;
            if (fabs(a.depth[p] - b.depth[p]) > 1e-3 * b.depth[p])
                fail_msg("pixel %zu: depth %.7g (tiles) vs %.7g (per pixel)", p, a.depth[p],
                         b.depth[p]);
        }
    }
    assert_true(both > n / 10);
    if (differ > n / 500) fail_msg("%zu of %zu pixels differ in coverage", differ, n);
    crisp_image_free(&a);
    crisp_image_free(&b);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

/* Render part through cam with tape shortening on and off; the two images must be identical
 * (the shortened tape gives the same values at every point of its cell and the same intervals on
 * its sub-cells, so every decision is the same), and shortening must have happened. */
static void check_shortening_changes_nothing(const crisp_frep_part *part, const crisp_camera *cam,
                                             int per_pixel, crisp_image *dest)
{
    crisp_image a, b;
    crisp_frep_parts_stats sa, sb;
    assert_int_equal(crisp_image_init(&a, cam->width, cam->height), CRISP_OK);
    assert_int_equal(crisp_image_init(&b, cam->width, cam->height), CRISP_OK);
    assert_int_equal(
        crisp_render_frep_parts(
            part, 1, cam,
            &(crisp_frep_parts_desc){.threads = 2, .per_pixel = per_pixel, .stats = &sa}, &a),
        CRISP_OK);
    assert_int_equal(crisp_render_frep_parts(
                         part, 1, cam,
                         &(crisp_frep_parts_desc){
                             .threads = 2, .per_pixel = per_pixel, .no_shorten = 1, .stats = &sb},
                         &b),
                     CRISP_OK);
    size_t n = (size_t)cam->width * cam->height, drawn = 0;
    for (size_t p = 0; p < n; p++) {
        if (a.face[p] != b.face[p] || memcmp(&a.depth[p], &b.depth[p], sizeof(float)))
            fail_msg("pixel %zu: shortened face %d depth %.9g, full tape face %d depth %.9g", p,
                     a.face[p], a.depth[p], b.face[p], b.depth[p]);
        for (int k = 0; k < 3; k++)
            assert_true(fabsf(a.normal[3 * p + k] - b.normal[3 * p + k]) <= 1e-6f);
        drawn += a.face[p] == -2;
    }
    assert_true(drawn > n / 20);
    /* the same cells and points, on shorter tapes */
    assert_int_equal(sa.intervals, sb.intervals);
    assert_int_equal(sa.batches, sb.batches);
    assert_int_equal(sa.hits, drawn);
    assert_true(sb.tape_sum == sb.batches * crisp_frep_tape_length(part->tape));
    assert_true(sa.tape_sum < sb.tape_sum);
    if (dest)
        *dest = a;
    else
        crisp_image_free(&a);
    crisp_image_free(&b);
}

/* A union of 40 random spheres (a min-heavy tape whose leaves keep one or two spheres): the
 * shortened-tape renderer equals the full-tape one, and both equal the analytic first hit of the
 * union (the nearest of the spheres' first hits) away from silhouettes. */
static void test_sphere_union_shortened(void **state)
{
    (void)state;
    enum { NS = 40 };
    double ctr[NS][3], rad[NS];
    char *src = malloc(NS * 160);
    size_t len = 0;
    for (int k = 0; k < NS; k++) {
        for (int a = 0; a < 3; a++)
            ctr[k][a] = 1.6 * urand() - 0.8;
        rad[k] = 0.08 + 0.17 * urand();
        len += (size_t)sprintf(src + len, "%ssqrt((X-%.6f)^2 + (Y-%.6f)^2 + (Z-%.6f)^2) - %.6f%s",
                               k + 1 < NS ? "min(" : "", ctr[k][0], ctr[k][1], ctr[k][2], rad[k],
                               k + 1 < NS ? ", " : "");
    }
    for (int k = 0; k + 1 < NS; k++)
        src[len++] = ')';
    crisp_frep *f;
    assert_int_equal(crisp_frep_read_math_mem("spheres", src, len, &f), CRISP_OK);
    free(src);
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    crisp_frep_part part = {.tape = t, .color = {0.9f, 0.7f, 0.3f, 1}};
    crisp_mat4_identity(part.transform);
    for (int view = 0; view < 4; view++) {
        crisp_camera cam;
        random_camera(&cam, 3.5);
        cam.width *= 2, cam.height *= 2;
        crisp_image img;
        check_shortening_changes_nothing(&part, &cam, view == 3, &img);
        int W = cam.width, H = cam.height;
        char *ana = calloc((size_t)W * H, 1);
        int *which = calloc((size_t)W * H, sizeof(int));
        double *dep = calloc((size_t)W * H, sizeof(double));
        double fv[3], w[3];
        crisp_vec3_sub(cam.target, cam.eye, w);
        crisp_vec3_normalize(w, fv);
        for (int j = 0; j < H; j++)
            for (int i = 0; i < W; i++) {
                double o[3], d[3];
                crisp_camera_ray(&cam, i + 0.5, j + 0.5, o, d);
                double best = INFINITY, fd = crisp_vec3_dot(d, fv);
                int best_k = -1;
                for (int k = 0; k < NS; k++) {
                    double oc[3];
                    crisp_vec3_sub(o, ctr[k], oc);
                    double B = crisp_vec3_dot(oc, d), C = crisp_vec3_dot(oc, oc) - rad[k] * rad[k];
                    double A = crisp_vec3_dot(d, d), disc = B * B - A * C;
                    if (disc < 0) continue;
                    for (int r = 0; r < 2; r++) {
                        double tt = (-B + (r ? 1 : -1) * sqrt(disc)) / A, z = tt * fd;
                        if (z < cam.znear && (-B + sqrt(disc)) / A * fd > cam.znear)
                            z = cam.znear; /* the near plane cuts this sphere */
                        if (z >= cam.znear && z <= cam.zfar) {
                            if (z < best) best = z, best_k = k;
                            break;
                        }
                    }
                }
                ana[j * W + i] = best < INFINITY;
                which[j * W + i] = best_k;
                dep[j * W + i] = best;
            }
        int compared = 0;
        for (int j = 1; j + 1 < H; j++)
            for (int i = 1; i + 1 < W; i++) {
                size_t p = (size_t)j * W + i;
                int same = 1;
                for (int dj = -1; dj <= 1; dj++)
                    for (int di = -1; di <= 1; di++) {
                        size_t p2 = (size_t)(j + dj) * W + (i + di);
                        same &= which[p2] == which[p];
                    }
                if (!same) continue; /* silhouettes, including one sphere's over another's */
                compared++;
                int got = img.face[p] == -2;
                if (got != ana[p])
                    fail_msg("view %d pixel %d,%d: f-rep %s, analytic %s", view, i, j,
                             got ? "hit" : "miss", ana[p] ? "hit" : "miss");
                if (got && fabs(img.depth[p] - dep[p]) > 1e-3 * dep[p])
                    fail_msg("view %d pixel %d,%d: depth %.7g, analytic %.7g", view, i, j,
                             img.depth[p], dep[p]);
            }
        assert_true(compared > W * H / 2);
        free(ana);
        free(which);
        free(dep);
        crisp_image_free(&img);
    }
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

/* bear.vm (exp/ln blends, few min/max) at a small size, tiles and per pixel: shortened equals
 * full tape. */
static void test_bear_shortened(void **state)
{
    (void)state;
    crisp_frep *f;
    assert_int_equal(crisp_frep_read_vm(CRISP_DATA_DIR "/frep/bear.vm", &f), CRISP_OK);
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    crisp_frep_part part = {.tape = t, .color = {0.8f, 0.6f, 0.4f, 1}};
    crisp_mat4_identity(part.transform);
    crisp_camera cam = {.eye = {0.4, 0.6, 4.5},
                        .target = {0, 0, 0},
                        .up = {0, 1, 0},
                        .fov_deg = 30,
                        .znear = 0.05,
                        .zfar = 20,
                        .width = 96,
                        .height = 64};
    check_shortening_changes_nothing(&part, &cam, 0, NULL);
    cam.width = 40, cam.height = 30;
    check_shortening_changes_nothing(&part, &cam, 1, NULL);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

/* The camera line: parsed with defaults, at most one, errors with line and column. */
static void test_scene_camera(void **state)
{
    (void)state;
    const char *text = "# view\ncamera eye 1 2 3 fov 45\nfrep math \"X*X + Y*Y + Z*Z - 1\"\n";
    crisp_scene_file *s;
    assert_int_equal(crisp_scene_file_read_mem("c.scene", NULL, text, strlen(text), &s), CRISP_OK);
    assert_int_equal(s->item_count, 1);
    assert_true(s->has_camera);
    assert_false(s->has_target);
    assert_float_equal(s->eye[2], 3, 0);
    assert_false(s->has_up); /* the default up is the command line's: +Z */
    assert_float_equal(s->fov_deg, 45, 0);
    crisp_scene_file_destroy(s);
    text = "frep a.vm\ncamera up 0 0 1 target 1 1 1 eye -4 0.5 2\n";
    assert_int_equal(crisp_scene_file_read_mem("c.scene", NULL, text, strlen(text), &s), CRISP_OK);
    assert_true(s->has_camera && s->has_target);
    assert_float_equal(s->target[0], 1, 0);
    assert_true(s->has_up);
    assert_float_equal(s->up[2], 1, 0);
    assert_float_equal(s->eye[0], -4, 0);
    assert_float_equal(s->fov_deg, 30, 0);
    crisp_scene_file_destroy(s);
    expect_error("camera eye 0 0 5\ncamera eye 0 0 6\nfrep a.vm\n",
                 "bad.scene:2:1:", "at most one");
    expect_error("camera fov 20\nfrep a.vm\n", "bad.scene:1:1:", "'eye x y z'");
    expect_error("camera eye 0 0 5 fov 180\nfrep a.vm\n", "bad.scene:1:18:", "(0, 180)");
    expect_error("camera eye 0 0 x\nfrep a.vm\n", "bad.scene:1:16:", "three numbers after 'eye'");
    expect_error("camera eye 0 0 5 look 1\nfrep a.vm\n", "bad.scene:1:18:", "eye, target, up");
    expect_error("camera eye 1 1 1 target 1 1 1\nfrep a.vm\n", "bad.scene:1:1:", "different");
    expect_error("camera eye 1 1 1 up 0 0 0\nfrep a.vm\n", "bad.scene:1:18:", "non-zero 'up'");
    expect_error("camera eye 1 1 1\n", "bad.scene:", "expected at least one");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere_random_cameras),
        cmocka_unit_test(test_transformed_part),
        cmocka_unit_test(test_sphere_cuts_plane),
        cmocka_unit_test(test_camera_inside_and_crossing),
        cmocka_unit_test(test_tiles_match_per_pixel),
        cmocka_unit_test(test_sphere_union_shortened),
        cmocka_unit_test(test_bear_shortened),
        cmocka_unit_test(test_scene_file_errors),
        cmocka_unit_test(test_scene_camera),
        cmocka_unit_test(test_scene_file_example),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
