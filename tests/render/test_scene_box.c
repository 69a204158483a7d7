/* The scene box that frames the default camera covers what the faces can show: a large plane
 * trimmed to a small square frames the square (within the clipped patches' boxes), an untrimmed
 * face frames all of itself, and a patch that no loop reaches adds nothing. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>

#include "crisp/model.h"
#include "crisp/render.h"
#include "render/render_internal.h"

/* The plane z = 0 over [0, 10]^2 as a bilinear patch with (u, v) = (x, y), split by a knot at
 * u = 5 into two Bézier patches; trimmed (when `trim`) to the square [1, 2] x [6, 7]. */
static void add_plane(crisp_model *m, int trim, double z)
{
    double ku[5] = {0, 0, 5, 10, 10}, kv[4] = {0, 0, 10, 10};
    double pts[3 * 2 * 3];
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 3; i++) {
            double *p = pts + 3 * (j * 3 + i);
            p[0] = 5.0 * i, p[1] = 10.0 * j, p[2] = z;
        }
    crisp_face face = {0};
    assert_int_equal(crisp_surface_create(1, 1, 3, 2, ku, kv, pts, NULL, &face.surface), CRISP_OK);
    if (trim) {
        face.loop_count = 1;
        face.loops = crisp_calloc_array(1, sizeof *face.loops);
        face.loops[0].is_outer = 1;
        face.loops[0].curve_count = 4;
        face.loops[0].curves = crisp_calloc_array(4, sizeof(crisp_curve *));
        double c[5][2] = {{1, 6}, {2, 6}, {2, 7}, {1, 7}, {1, 6}}, k[4] = {0, 0, 1, 1};
        for (int e = 0; e < 4; e++) {
            double q[4] = {c[e][0], c[e][1], c[e + 1][0], c[e + 1][1]};
            assert_int_equal(crisp_curve_create(2, 1, 2, k, q, NULL, &face.loops[0].curves[e]),
                             CRISP_OK);
        }
    }
    assert_int_equal(crisp_model_add_face(m, &face), CRISP_OK);
}

static void test_trimmed_box(void **state)
{
    (void)state;
    crisp_model *m = NULL;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    add_plane(m, 1, 0);
    crisp_scene *sc = NULL;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    double want[6] = {1, 6, 0, 2, 7, 0};
    for (int k = 0; k < 6; k++)
        assert_true(fabs(sc->box[k] - want[k]) < 1e-9);
    crisp_scene_destroy(sc);
    /* an untrimmed face beside it frames all of itself */
    add_plane(m, 0, 3);
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    double want2[6] = {0, 0, 0, 10, 10, 3};
    for (int k = 0; k < 6; k++)
        assert_true(fabs(sc->box[k] - want2[k]) < 1e-9);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_trimmed_box)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
