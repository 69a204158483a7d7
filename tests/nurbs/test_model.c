/* Tests for the in-memory model (src/nurbs/model.c, trim_loop.c): face list, skip notes, box,
 * statistics by span counting, trim-loop area, closure gap, reversal, domain excess and loop
 * normalisation (orientation, gap snapping, open-loop errors naming the face).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/model.h"

static crisp_curve *line2(double x0, double y0, double x1, double y1)
{
    const double k[4] = {0, 0, 1, 1};
    const double p[4] = {x0, y0, x1, y1};
    crisp_curve *c = NULL;
    assert_int_equal(crisp_curve_create(2, 1, 2, k, p, NULL, &c), CRISP_OK);
    return c;
}

/* Unit circle of radius r around (cx, cy), CCW, 4 rational quadratic spans. */
static crisp_curve *circle2(double cx, double cy, double r)
{
    static const double k[12] = {0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1};
    static const double u[18] = {1, 0, 1, 1, 0, 1, -1, 1, -1, 0, -1, -1, 0, -1, 1, -1, 1, 0};
    double p[18], w[9];
    for (int i = 0; i < 9; i++) {
        p[2 * i] = cx + r * u[2 * i];
        p[2 * i + 1] = cy + r * u[2 * i + 1];
        w[i] = (i % 2) ? sqrt(0.5) : 1.0;
    }
    crisp_curve *c = NULL;
    assert_int_equal(crisp_curve_create(2, 2, 9, k, p, w, &c), CRISP_OK);
    return c;
}

/* A square loop over [x0, x1] x [y0, y1], CCW when ccw is set, else CW. */
static crisp_trim_loop square_loop(double x0, double y0, double x1, double y1, int ccw,
                                   int is_outer)
{
    crisp_trim_loop l = {.is_outer = is_outer, .curve_count = 4};
    l.curves = calloc(4, sizeof *l.curves);
    if (ccw) {
        l.curves[0] = line2(x0, y0, x1, y0);
        l.curves[1] = line2(x1, y0, x1, y1);
        l.curves[2] = line2(x1, y1, x0, y1);
        l.curves[3] = line2(x0, y1, x0, y0);
    } else {
        l.curves[0] = line2(x0, y0, x0, y1);
        l.curves[1] = line2(x0, y1, x1, y1);
        l.curves[2] = line2(x1, y1, x1, y0);
        l.curves[3] = line2(x1, y0, x0, y0);
    }
    return l;
}

/* Bicubic surface with 5 x 4 control points, clamped: 2 x 1 spans. */
static crisp_surface *bicubic(void)
{
    const double ku[9] = {0, 0, 0, 0, 0.5, 1, 1, 1, 1};
    const double kv[8] = {0, 0, 0, 0, 1, 1, 1, 1};
    double p[5 * 4 * 3];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 5; i++) {
            p[(j * 5 + i) * 3] = i;
            p[(j * 5 + i) * 3 + 1] = j;
            p[(j * 5 + i) * 3 + 2] = 0.1 * i * j - 2.0;
        }
    crisp_surface *s = NULL;
    assert_int_equal(crisp_surface_create(3, 3, 5, 4, ku, kv, p, NULL, &s), CRISP_OK);
    return s;
}

/* Rational quadratic x linear quarter-cylinder pieces: 4 x 1 spans, rational. */
static crisp_surface *cylinder(void)
{
    static const double k[12] = {0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1};
    static const double u[18] = {1, 0, 1, 1, 0, 1, -1, 1, -1, 0, -1, -1, 0, -1, 1, -1, 1, 0};
    const double kv[4] = {0, 0, 1, 1};
    double p[18 * 3], w[18];
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 9; i++) {
            p[(j * 9 + i) * 3] = u[2 * i];
            p[(j * 9 + i) * 3 + 1] = u[2 * i + 1];
            p[(j * 9 + i) * 3 + 2] = 4.0 * j;
            w[j * 9 + i] = (i % 2) ? sqrt(0.5) : 1.0;
        }
    crisp_surface *s = NULL;
    assert_int_equal(crisp_surface_create(2, 1, 9, 2, k, kv, p, w, &s), CRISP_OK);
    return s;
}

static void test_model_faces_stats(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    assert_true(m->unit_to_mm == 1.0);

    crisp_face f = {.surface = bicubic(), .loop_count = 2, .source_id = 17};
    f.loops = calloc(2, sizeof *f.loops);
    f.loops[0] = square_loop(0.1, 0.1, 0.9, 0.9, 1, 1);
    f.loops[1] = (crisp_trim_loop){.is_outer = 0, .curve_count = 1};
    f.loops[1].curves = calloc(1, sizeof(crisp_curve *));
    f.loops[1].curves[0] = circle2(0.5, 0.5, 0.2);
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
    assert_null(f.surface); /* moved */
    assert_null(f.loops);

    crisp_face g = {.surface = cylinder(), .source_id = 18};
    assert_int_equal(crisp_model_add_face(m, &g), CRISP_OK);
    for (int i = 0; i < 40; i++) { /* growth keeps earlier faces */
        crisp_face h = {.surface = bicubic(), .source_id = 100 + i};
        assert_int_equal(crisp_model_add_face(m, &h), CRISP_OK);
    }
    assert_int_equal(m->face_count, 42);
    assert_int_equal(m->faces[0].source_id, 17);
    assert_int_equal(m->faces[41].source_id, 139);

    crisp_model_stats st;
    assert_int_equal(crisp_model_stats_compute(m, &st), CRISP_OK);
    assert_int_equal(st.faces, 42);
    assert_int_equal(st.bezier_patches, 2 + 4 + 40 * 2);
    assert_int_equal(st.outer_loops, 1);
    assert_int_equal(st.hole_loops, 1);
    assert_int_equal(st.trim_curves, 5);
    assert_int_equal(st.trim_pieces, 4 + 4);
    assert_int_equal(st.rational_surfaces, 1);
    assert_int_equal(st.max_degree_u, 3);
    assert_int_equal(st.max_degree_v, 3);
    assert_int_equal(st.max_trim_degree, 2);
    assert_int_equal(st.degrees_seen, (1u << 1) | (1u << 2) | (1u << 3));

    /* the stats agree with an actual extraction */
    int total = 0;
    for (int i = 0; i < m->face_count; i++) {
        crisp_bezier_patches bp;
        assert_int_equal(crisp_surface_to_bezier(m->faces[i].surface, &bp), CRISP_OK);
        total += bp.count;
        crisp_bezier_patches_free(&bp);
    }
    assert_int_equal(total, st.bezier_patches);

    double box[6];
    crisp_model_bbox(m, box);
    assert_true(box[0] == -1.0 && box[3] == 4.0);
    assert_true(box[1] == -1.0 && box[4] == 3.0);
    assert_true(box[2] == -2.0 && box[5] == 4.0);
    crisp_model_destroy(m);
    crisp_model_destroy(NULL);
}

static void test_model_skips(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    assert_int_equal(crisp_model_note_skip(m, "entity 116 point: not a surface"), CRISP_OK);
    assert_int_equal(crisp_model_note_skip(m, "entity 110 line: unused"), CRISP_OK);
    assert_int_equal(crisp_model_note_skip(m, "entity 116 point: not a surface"), CRISP_OK);
    assert_int_equal(m->skip_count, 2);
    assert_string_equal(m->skips[0].what, "entity 116 point: not a surface");
    assert_int_equal(m->skips[0].count, 2);
    assert_int_equal(m->skips[1].count, 1);
    char longtext[300];
    memset(longtext, 'x', sizeof longtext - 1);
    longtext[sizeof longtext - 1] = '\0';
    assert_int_equal(crisp_model_note_skip(m, longtext), CRISP_OK);
    assert_int_equal(crisp_model_note_skip(m, longtext), CRISP_OK);
    assert_int_equal(m->skip_count, 3);
    assert_int_equal(m->skips[2].count, 2);
    /* kept in full (issue 13: no cut at 95 characters) */
    assert_string_equal(m->skips[2].what, longtext);
    assert_int_equal(m->faces_dropped, 0);
    assert_int_equal(crisp_model_note_dropped(m, "face #%d dropped: %s", 7, longtext), CRISP_OK);
    assert_int_equal(m->faces_dropped, 1);
    assert_int_equal((int)strlen(m->skips[3].what), (int)strlen("face #7 dropped: ") + 299);
    assert_int_equal(crisp_model_note_skipf(m, "x%d", 1), CRISP_OK);
    assert_string_equal(m->skips[4].what, "x1");
    /* a bound on distinct notes: the last one counts the rest */
    for (int i = 0; i < CRISP_MODEL_MAX_NOTES + 10; i++)
        assert_int_equal(crisp_model_note_skipf(m, "note %d", i), CRISP_OK);
    assert_int_equal(m->skip_count, CRISP_MODEL_MAX_NOTES);
    assert_non_null(strstr(m->skips[m->skip_count - 1].what, "not kept"));
    crisp_model_destroy(m);
}

static void test_loop_area_gap_reverse(void **state)
{
    (void)state;
    crisp_trim_loop l = square_loop(0, 0, 2, 1, 1, 1);
    assert_true(fabs(crisp_trim_loop_signed_area(&l) - 2.0) < 1e-12);
    assert_true(crisp_trim_loop_closure_gap(&l) == 0.0);
    crisp_trim_loop_reverse(&l);
    assert_true(fabs(crisp_trim_loop_signed_area(&l) + 2.0) < 1e-12);
    assert_true(crisp_trim_loop_closure_gap(&l) < 1e-15);
    const double dom[4] = {0, 1.5, -0.5, 1};
    assert_true(fabs(crisp_trim_loop_domain_excess(&l, dom) - 0.5) < 1e-15);
    const double big[4] = {-1, 3, -1, 3};
    assert_true(crisp_trim_loop_domain_excess(&l, big) == 0.0);
    crisp_trim_loop_free(&l);

    /* a circle: the dense polyline area is within 1e-3 of pi r^2 */
    crisp_trim_loop c = {.is_outer = 1, .curve_count = 1};
    c.curves = calloc(1, sizeof *c.curves);
    c.curves[0] = circle2(0.5, 0.5, 0.25);
    double a = crisp_trim_loop_signed_area(&c);
    assert_true(fabs(a - M_PI * 0.0625) < 1e-3 * M_PI * 0.0625);
    crisp_trim_loop_free(&c);
}

static void test_normalize_orientation(void **state)
{
    (void)state;
    crisp_face f = {.surface = bicubic(), .loop_count = 2, .source_id = 5};
    f.loops = calloc(2, sizeof *f.loops);
    f.loops[0] = square_loop(0, 0, 1, 1, 0, 1);           /* outer given CW */
    f.loops[1] = square_loop(0.25, 0.25, 0.5, 0.5, 1, 0); /* hole given CCW */
    assert_true(crisp_trim_loop_signed_area(&f.loops[0]) < 0);
    assert_int_equal(crisp_face_normalize_loops(&f, 1e-9), CRISP_OK);
    assert_true(crisp_trim_loop_signed_area(&f.loops[0]) > 0.99);
    assert_true(crisp_trim_loop_signed_area(&f.loops[1]) < -0.06);
    assert_true(crisp_trim_loop_closure_gap(&f.loops[0]) < 1e-15);
    assert_true(crisp_trim_loop_closure_gap(&f.loops[1]) < 1e-15);
    /* already normalised loops are left alone */
    const crisp_curve *first = f.loops[0].curves[0];
    assert_int_equal(crisp_face_normalize_loops(&f, 1e-9), CRISP_OK);
    assert_ptr_equal(f.loops[0].curves[0], first);
    crisp_face_free(&f);
    crisp_face_free(&f); /* freeing twice is harmless: the face was zeroed */
}

static void test_normalize_gaps(void **state)
{
    (void)state;
    crisp_face f = {.surface = bicubic(), .loop_count = 1, .source_id = 4242};
    f.loops = calloc(1, sizeof *f.loops);
    f.loops[0] = square_loop(0, 0, 1, 1, 1, 1);
    /* open the loop: move the third edge's end 0.01 off the fourth edge's start */
    crisp_curve_destroy(f.loops[0].curves[2]);
    f.loops[0].curves[2] = line2(1, 1, 0.0, 1.01);
    assert_true(fabs(crisp_trim_loop_closure_gap(&f.loops[0]) - 0.01) < 1e-12);
    crisp_error_clear();
    assert_int_equal(crisp_face_normalize_loops(&f, 1e-3), CRISP_ERR_INVALID_ARG);
    assert_non_null(strstr(crisp_error_message(), "face 4242"));
    assert_non_null(strstr(crisp_error_message(), "curve 2"));
    assert_int_equal(crisp_face_normalize_loops(&f, 0.1), CRISP_OK);
    assert_true(crisp_trim_loop_closure_gap(&f.loops[0]) < 1e-15);
    crisp_face_free(&f);

    /* an unclamped uniform cubic closes after being clamped */
    const double k[10] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
    const double p[12] = {0, 0, 1, 0, 1, 1, 0, 1, 0, 0, 1, 0};
    crisp_face g = {.surface = bicubic(), .loop_count = 1, .source_id = 7};
    g.loops = calloc(1, sizeof *g.loops);
    g.loops[0] = (crisp_trim_loop){.is_outer = 1, .curve_count = 2};
    g.loops[0].curves = calloc(2, sizeof(crisp_curve *));
    assert_int_equal(crisp_curve_create(2, 3, 6, k, p, NULL, &g.loops[0].curves[0]), CRISP_OK);
    double s[2], e[2];
    crisp_curve_eval(g.loops[0].curves[0], 3, s);
    crisp_curve_eval(g.loops[0].curves[0], 6, e);
    double back[4] = {e[0], e[1] + 0.001, s[0] + 0.001, s[1]};
    g.loops[0].curves[1] = line2(back[0], back[1], back[2], back[3]);
    assert_true(crisp_trim_loop_closure_gap(&g.loops[0]) > 9e-4);
    assert_int_equal(crisp_face_normalize_loops(&g, 0.01), CRISP_OK);
    assert_true(crisp_trim_loop_closure_gap(&g.loops[0]) < 1e-15);
    crisp_face_free(&g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_model_faces_stats),     cmocka_unit_test(test_model_skips),
        cmocka_unit_test(test_loop_area_gap_reverse), cmocka_unit_test(test_normalize_orientation),
        cmocka_unit_test(test_normalize_gaps),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
