/* Normals at singular points (issue 13: "a starburst of wrong normals at the apex of a cone"):
 * the CPU backend's vertices on a cone's apex and on a sphere's poles carry the limit normal from
 * inside the patch (each cone generator its own), not the normalised zero cross product; the
 * exact renderer's hits on an apex or a pole do too; and the images of the CPU backend (or, with
 * `--backend gl`, the GL backend's) have the exact renderer's normals around a cone's apex and a
 * sphere's pole, also where the file's apex or pole control points coincide only to its
 * precision (a few 1e-9 to 1e-6 of the size apart: the rounding of a written file or a fit), where
 * the cross product at the collapsed side is regular but made of that noise. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>

#include "crisp/construct.h"
#include "crisp/render.h"
#include "render_backend.h"

static crisp_model *one_face(crisp_surface *s)
{
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    crisp_face f = {.surface = s};
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
    return m;
}

static void render(crisp_model *m, const double eye[3], crisp_renderer **r, crisp_scene **sc)
{
    assert_int_equal(crisp_scene_prepare(m, sc), CRISP_OK);
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, r), CRISP_OK);
    crisp_camera cam;
    assert_int_equal(crisp_camera_frame_box((*sc)->box, 200, 150, &cam), CRISP_OK);
    for (int k = 0; k < 3; k++)
        cam.eye[k] = eye[k];
    cam.target[0] = cam.target[1] = cam.target[2] = 0;
    cam.up[0] = 0, cam.up[1] = 0, cam.up[2] = 1;
    cam.znear = 0.01, cam.zfar = 100;
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, 200, 150), CRISP_OK);
    assert_int_equal(crisp_render_cpu(*r, *sc, &cam, &img, NULL), CRISP_OK);
    crisp_image_free(&img);
}

static void test_sphere_poles(void **state)
{
    (void)state;
    crisp_placement pl;
    double o[3] = {0, 0, 0}, z[3] = {0, 0, 1};
    assert_int_equal(crisp_placement_make(o, z, NULL, &pl), CRISP_OK);
    crisp_surface *s;
    assert_int_equal(crisp_make_sphere(&pl, 1, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &s), CRISP_OK);
    crisp_model *m = one_face(s);
    crisp_renderer *r;
    crisp_scene *sc;
    render(m, (double[3]){2, -3, 1.5}, &r, &sc);
    const crisp_raster_vertex *v;
    const crisp_raster_tri *tri;
    size_t nv, nt;
    crisp__renderer_mesh(r, &v, &nv, &tri, &nt);
    int poles = 0;
    for (size_t k = 0; k < nv; k++) {
        if (fabs(fabs(v[k].attr[1]) - M_PI / 2) > 1e-9) continue;
        poles++;
        /* The outward normal at a pole is +-z whatever the longitude. */
        double sign = v[k].attr[1] > 0 ? 1 : -1;
        assert_true(sign * v[k].attr[4] > 0.9999);
    }
    printf("sphere: %d vertices on the poles, every normal along the axis\n", poles);
    assert_true(poles > 0);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

static crisp_model *cone_model(double *v0)
{
    crisp_placement pl;
    double o[3] = {0, 0, 0}, z[3] = {0, 0, 1};
    assert_int_equal(crisp_placement_make(o, z, NULL, &pl), CRISP_OK);
    const double semi = M_PI / 6, t = tan(semi);
    *v0 = -1 / t;
    crisp_surface *s;
    assert_int_equal(crisp_make_cone(&pl, 1, semi, 0, 2 * M_PI, *v0, 0, &s), CRISP_OK);
    return one_face(s);
}

static crisp_model *sphere_model(void)
{
    crisp_placement pl;
    double o[3] = {0, 0, 0}, z[3] = {0, 0, 1};
    assert_int_equal(crisp_placement_make(o, z, NULL, &pl), CRISP_OK);
    crisp_surface *s;
    assert_int_equal(crisp_make_sphere(&pl, 1, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &s), CRISP_OK);
    return one_face(s);
}

/* The exact renderer's rays straight onto the apex and the poles: a unit normal, the limit from
 * inside (the hit generator's normal at the apex, the axis at a pole), not the zero cross
 * product of the collapsed edge. */
static void test_exact_singular(void **state)
{
    (void)state;
    double v0;
    crisp_model *cone = cone_model(&v0), *sphere = sphere_model();
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(cone, &sc), CRISP_OK);
    const double t = tan(M_PI / 6);
    int hits = 0;
    for (int k = 0; k < 16; k++) {
        /* from below the apex, inside the cone's outer side: each ray ends on the apex */
        double a = 2 * M_PI * (k + 0.3) / 16, o[3] = {3 * cos(a), 3 * sin(a), v0 - 1}, d[3];
        double apex[3] = {0, 0, v0};
        crisp_vec3_sub(apex, o, d);
        crisp_vec3_normalize(d, d);
        double tt, uv[2], n[3];
        uint32_t face;
        if (!crisp_exact_ray(sc, NULL, o, d, 0, 100, &tt, &face, uv, n)) continue;
        hits++;
        double P[3] = {o[0] + tt * d[0], o[1] + tt * d[1], o[2] + tt * d[2]};
        double h = crisp_param_to_angle(0, 2 * M_PI, uv[0]);
        double e[3] = {cos(h) / sqrt(1 + t * t), sin(h) / sqrt(1 + t * t), -t / sqrt(1 + t * t)};
        double c = crisp_vec3_dot(e, n), len = crisp_vec3_norm(n);
        printf("cone apex ray %d: hit %.3g from the apex at v %.17g, |n| %.9f, cos %.9f\n", k,
               hypot(hypot(P[0], P[1]), P[2] - v0), uv[1], len, c);
        assert_true(fabs(len - 1) < 1e-9);
        assert_true(c > 0.9999);
    }
    assert_true(hits >= 8);
    crisp_scene_destroy(sc);
    assert_int_equal(crisp_scene_prepare(sphere, &sc), CRISP_OK);
    for (int pole = -1; pole <= 1; pole += 2) {
        double o[3] = {0, 0, 3.0 * pole}, d[3] = {0, 0, -pole}, tt, n[3];
        assert_true(crisp_exact_ray(sc, NULL, o, d, 0, 100, &tt, NULL, NULL, n));
        printf("sphere pole %+d: t %.17g, normal %g %g %g\n", pole, tt, n[0], n[1], n[2]);
        assert_true(fabs(tt - 2) < 1e-9);
        assert_true(pole * n[2] > 0.9999);
    }
    crisp_scene_destroy(sc);
    crisp_model_destroy(cone);
    crisp_model_destroy(sphere);
}

/* The backend's image (CPU, or GL with --backend gl) against the exact renderer's around the
 * singular point: every pixel within 12 px of the apex's or the pole's image whose 3x3
 * neighbourhood is all surface in both images has the exact normal within 10 degrees (the
 * tessellation's generators are a few degrees apart around the apex; a starburst of wrong normals
 * there was off by up to 90). */
static void check_image_normals(const char *name, crisp_model *m, const double eye[3],
                                const double point[3])
{
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_renderer *r;
    assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
    const int w = 160, h = 120;
    crisp_camera cam = {.width = w, .height = h, .fov_deg = 30, .znear = 0.01, .zfar = 100};
    for (int k = 0; k < 3; k++)
        cam.eye[k] = eye[k], cam.target[k] = point[k];
    cam.up[2] = 1;
    crisp_image img, ex;
    assert_int_equal(crisp_image_init(&img, w, h), CRISP_OK);
    assert_int_equal(crisp_image_init(&ex, w, h), CRISP_OK);
    assert_int_equal(render_backend(rb_kind, r, 1, sc, &cam, &img, NULL), CRISP_OK);
    assert_int_equal(crisp_render_exact(sc, &cam, &(crisp_exact_desc){.threads = 2}, &ex),
                     CRISP_OK);
    int compared = 0;
    double worst = 1;
    for (int j = h / 2 - 12; j <= h / 2 + 12; j++)
        for (int i = w / 2 - 12; i <= w / 2 + 12; i++) {
            int all = 1;
            for (int dj = -1; dj <= 1; dj++)
                for (int di = -1; di <= 1; di++) {
                    size_t q = (size_t)(j + dj) * w + (size_t)(i + di);
                    all &= ex.face[q] >= 0 && img.face[q] >= 0;
                }
            if (!all) continue;
            size_t p = (size_t)j * w + (size_t)i;
            double c = 0;
            for (int k = 0; k < 3; k++)
                c += (double)img.normal[3 * p + k] * ex.normal[3 * p + k];
            compared++;
            worst = fmin(worst, c);
        }
    printf("%s backend, %s: %d pixels around the singular point, smallest cos to the exact normal "
           "%.6f\n",
           rb_name(), name, compared, worst);
    assert_true(compared > 100);
    assert_true(worst > cos(10 * M_PI / 180));
    crisp_image_free(&img);
    crisp_image_free(&ex);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
}

static void test_image_apex(void **state)
{
    (void)state;
    double v0;
    crisp_model *m = cone_model(&v0);
    /* below the apex, looking up at it from outside the cone */
    check_image_normals("cone apex", m, (double[3]){0.8, -0.5, v0 - 3}, (double[3]){0, 0, v0});
    crisp_model_destroy(m);
}

/* The control points of row j (v index) of s moved by up to `noise` (relative to the weight: the
 * Euclidean points move by up to noise) in each coordinate, pseudo-randomly: a collapsed side as
 * a file rounds it. */
static void jitter_row(crisp_surface *s, int j, double noise, unsigned seed)
{
    for (int i = 0; i < s->count_u; i++) {
        double *c = s->cpw + 4 * ((size_t)j * s->count_u + i);
        for (int k = 0; k < 3; k++) {
            seed = seed * 1103515245u + 12345u;
            c[k] += noise * c[3] * (((seed >> 8) & 0xffff) / 32768.0 - 1);
        }
    }
}

/* The backend's vertices on a cone's apex whose control points are `noise` apart (0: exactly
 * one point): each carries its generator's normal, the cosine with it above min_cos (the first
 * row of triangles would otherwise shade as a starburst). */
static void check_apex_vertices(double noise, double min_cos)
{
    double v0;
    crisp_model *m = cone_model(&v0);
    jitter_row(m->faces[0].surface, 0, noise, 7);
    crisp_renderer *r;
    crisp_scene *sc;
    render(m, (double[3]){3, -2, -2.5}, &r, &sc);
    const crisp_raster_vertex *v;
    const crisp_raster_tri *tri;
    size_t nv, nt;
    crisp__renderer_mesh(r, &v, &nv, &tri, &nt);
    const double t = tan(M_PI / 6);
    int apex = 0;
    double worst = 1;
    for (size_t k = 0; k < nv; k++) {
        if (fabs(v[k].attr[1] - v0) > 1e-9) continue;
        apex++;
        double a = crisp_param_to_angle(0, 2 * M_PI, v[k].attr[0]);
        double e[3] = {cos(a) / sqrt(1 + t * t), sin(a) / sqrt(1 + t * t), -t / sqrt(1 + t * t)};
        worst = fmin(worst, e[0] * v[k].attr[2] + e[1] * v[k].attr[3] + e[2] * v[k].attr[4]);
    }
    printf("cone, apex points %g apart: %d vertices on the apex, smallest cos %.9f (%.3g deg)\n",
           noise, apex, worst, acos(fmin(1, worst)) * 180 / M_PI);
    assert_true(apex > 4);
    assert_true(worst > min_cos);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* An exact apex: the limit normal of each generator, to 1e-4 in the cosine. */
static void test_cone_apex(void **state)
{
    (void)state;
    check_apex_vertices(0, 0.9999);
}

static void test_noisy_apex_vertices(void **state)
{
    (void)state;
    check_apex_vertices(1e-9, cos(1 * M_PI / 180));
    check_apex_vertices(1e-7, cos(1 * M_PI / 180));
    check_apex_vertices(2e-6, cos(1 * M_PI / 180));
}

/* The images around an apex and a pole whose control points are 1e-8 and 1e-6 apart (the
 * starburst: up to 118 degrees off on both backends before). */
static void test_image_noisy(void **state)
{
    (void)state;
    for (int k = 0; k < 2; k++) {
        double noise = k ? 1e-6 : 1e-8, v0;
        crisp_model *m = cone_model(&v0);
        jitter_row(m->faces[0].surface, 0, noise, 11);
        char name[64];
        snprintf(name, sizeof name, "cone apex %g apart", noise);
        check_image_normals(name, m, (double[3]){0.8, -0.5, v0 - 3}, (double[3]){0, 0, v0});
        crisp_model_destroy(m);
        m = sphere_model();
        crisp_surface *s = m->faces[0].surface;
        jitter_row(s, s->count_v - 1, noise, 13);
        snprintf(name, sizeof name, "sphere pole %g apart", noise);
        check_image_normals(name, m, (double[3]){1.2, -0.9, 3}, (double[3]){0, 0, 1});
        crisp_model_destroy(m);
    }
}

static void test_image_pole(void **state)
{
    (void)state;
    crisp_model *m = sphere_model();
    check_image_normals("sphere pole", m, (double[3]){1.2, -0.9, 3}, (double[3]){0, 0, 1});
    crisp_model_destroy(m);
}

int main(int argc, char **argv)
{
    argc = rb_parse_args(argc, argv);
    (void)argc;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cone_apex),      cmocka_unit_test(test_sphere_poles),
        cmocka_unit_test(test_exact_singular), cmocka_unit_test(test_image_apex),
        cmocka_unit_test(test_image_pole),     cmocka_unit_test(test_noisy_apex_vertices),
        cmocka_unit_test(test_image_noisy),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
