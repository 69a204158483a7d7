/* crisp_model_gaps (issue 13): two unit squares side by side report nothing when they share their
 * edge and one pair with the gap's width when one is moved away by more than the tolerance
 * (less than the limit); farther than the limit they are free edges, not a gap; a closed
 * cylinder's own seam is no gap. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/construct.h"
#include "crisp/model.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* A face: the plane z = 0 with x in [x0, x0 + 1], y in [0, 1], trimmed by its own rectangle. */
static void add_square(crisp_model *m, double x0, int id)
{
    crisp_placement pl;
    const double o[3] = {x0, 0, 0}, z[3] = {0, 0, 1}, x[3] = {1, 0, 0};
    assert_int_equal(crisp_placement_make(o, z, x, &pl), CRISP_OK);
    crisp_face f = {0};
    f.source_id = id;
    assert_int_equal(crisp_make_plane(&pl, -0.1, 1.1, -0.1, 1.1, &f.surface), CRISP_OK);
    f.loop_count = 1;
    f.loops = calloc(1, sizeof *f.loops);
    f.loops[0].is_outer = 1;
    f.loops[0].curve_count = 4;
    f.loops[0].curves = calloc(4, sizeof(crisp_curve *));
    const double c[5][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}};
    for (int k = 0; k < 4; k++)
        assert_int_equal(crisp_make_line(2, c[k], c[k + 1], 0, 1, &f.loops[0].curves[k]), CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
}

static void test_squares(void **state)
{
    (void)state;
    const double tol = 1e-4, limit = 0.05;
    const double shift[4] = {0, 0.5e-4, 0.01, 0.2};
    const int pairs[4] = {0, 0, 1, 0};
    for (int k = 0; k < 4; k++) {
        crisp_model *m;
        assert_int_equal(crisp_model_create(&m), CRISP_OK);
        add_square(m, 0, 10);
        add_square(m, 1 + shift[k], 20);
        crisp_gap_report r;
        assert_int_equal(crisp_model_gaps(m, tol, limit, &r), CRISP_OK);
        assert_int_equal(r.count, pairs[k]);
        if (pairs[k]) {
            assert_true(fabs(r.gaps[0].gap - shift[k]) < 1e-6);
            assert_true(r.gaps[0].face[0] == 0 && r.gaps[0].face[1] == 1);
            assert_true(fabs(r.gaps[0].at[0] - 1) < 0.02);
        }
        assert_int_equal(r.incomplete, 0);
        crisp_gap_report_free(&r);
        crisp_model_destroy(m);
    }
}

/* A full cylinder trimmed along its seam (u = 0 and u = 2 pi) and its two circles: alone, and
 * beside a disc that closes its top exactly: no gap either way. */
static void test_cylinder_seam(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    crisp_placement pl;
    const double o[3] = {0, 0, 0}, z[3] = {0, 0, 1}, x[3] = {1, 0, 0};
    assert_int_equal(crisp_placement_make(o, z, x, &pl), CRISP_OK);
    crisp_face f = {0};
    assert_int_equal(crisp_make_cylinder(&pl, 1, 0, 2 * M_PI, 0, 2, &f.surface), CRISP_OK);
    double d[4];
    crisp_surface_domain(f.surface, d);
    f.loop_count = 1;
    f.loops = calloc(1, sizeof *f.loops);
    f.loops[0].is_outer = 1;
    f.loops[0].curve_count = 4;
    f.loops[0].curves = calloc(4, sizeof(crisp_curve *));
    const double c[5][2] = {{d[0], d[2]}, {d[1], d[2]}, {d[1], d[3]}, {d[0], d[3]}, {d[0], d[2]}};
    for (int k = 0; k < 4; k++)
        assert_int_equal(crisp_make_line(2, c[k], c[k + 1], 0, 1, &f.loops[0].curves[k]), CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
    crisp_gap_report r;
    assert_int_equal(crisp_model_gaps(m, 1e-6, 0.1, &r), CRISP_OK);
    assert_int_equal(r.count, 0);
    crisp_gap_report_free(&r);
    crisp_model_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_squares),
        cmocka_unit_test(test_cylinder_seam),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
