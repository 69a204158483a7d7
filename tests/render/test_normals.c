/* Normals at singular points (issue 13: "a starburst of wrong normals at the apex of a cone"):
 * the CPU backend's vertices on a cone's apex and on a sphere's poles carry the limit normal from
 * inside the patch (each cone generator its own), not the normalised zero cross product. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>

#include "crisp/construct.h"
#include "crisp/render.h"
#include "render/raster.h"
#include "render/render_internal.h"

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

static void test_cone_apex(void **state)
{
    (void)state;
    crisp_placement pl;
    double o[3] = {0, 0, 0}, z[3] = {0, 0, 1};
    assert_int_equal(crisp_placement_make(o, z, NULL, &pl), CRISP_OK);
    const double semi = M_PI / 6, t = tan(semi), v0 = -1 / t;
    crisp_surface *s;
    assert_int_equal(crisp_make_cone(&pl, 1, semi, 0, 2 * M_PI, v0, 0, &s), CRISP_OK);
    crisp_model *m = one_face(s);
    crisp_renderer *r;
    crisp_scene *sc;
    render(m, (double[3]){3, -2, -2.5}, &r, &sc);
    const crisp_raster_vertex *v;
    const crisp_raster_tri *tri;
    size_t nv, nt;
    crisp__renderer_mesh(r, &v, &nv, &tri, &nt);
    int apex = 0;
    double worst = 1;
    for (size_t k = 0; k < nv; k++) {
        if (fabs(v[k].attr[1] - v0) > 1e-9) continue;
        apex++;
        /* S(u, v) = (1 + v t)(cos a, sin a, 0) + v z: S_u x S_v is (1 + v t)(cos a, sin a, -t). */
        double a = crisp_param_to_angle(0, 2 * M_PI, v[k].attr[0]);
        double e[3] = {cos(a) / sqrt(1 + t * t), sin(a) / sqrt(1 + t * t), -t / sqrt(1 + t * t)};
        double d = e[0] * v[k].attr[2] + e[1] * v[k].attr[3] + e[2] * v[k].attr[4];
        if (d < 0.9999)
            printf("  apex vertex u %.17g: normal %g %g %g\n", v[k].attr[0], v[k].attr[2],
                   v[k].attr[3], v[k].attr[4]);
        if (!(d <= worst)) continue;
        worst = d;
    }
    printf("cone: %d vertices on the apex, smallest cos(normal, generator's normal) %.9f\n", apex,
           worst);
    assert_true(apex > 4);
    assert_true(worst > 0.9999);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cone_apex),
        cmocka_unit_test(test_sphere_poles),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
