/* Round trip through the OBJ free-form writer: model -> crisp_write_obj -> crisp_read_obj must give
 * back every surface and trim curve with bit-identical degrees, knots, weights and homogeneous
 * control points; loops keep their order, kind and orientation; writing the result again gives
 * the same bytes. Models: built in code (rational and polynomial, clamped and unclamped knots,
 * holes), and the bundled IGES and STEP files (Ventilator.stp only with CRISP_TEST_VENTILATOR
 * set: it takes about a second). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "crisp/io.h"

static void assert_same_doubles(const double *a, const double *b, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (memcmp(&a[i], &b[i], sizeof(double)) != 0) {
            print_error("value %zu: %.17g != %.17g\n", i, a[i], b[i]);
            fail();
        }
}

static void assert_same_curve(const crisp_curve *a, const crisp_curve *b)
{
    assert_int_equal(a->dim, b->dim);
    assert_int_equal(a->degree, b->degree);
    assert_int_equal(a->count, b->count);
    assert_int_equal(a->rational, b->rational);
    assert_same_doubles(a->knots, b->knots, (size_t)(a->count + a->degree + 1));
    assert_same_doubles(a->cpw, b->cpw, (size_t)a->count * (size_t)(a->dim + 1));
}

static void assert_same_model(const crisp_model *a, const crisp_model *b)
{
    assert_int_equal(a->face_count, b->face_count);
    for (int f = 0; f < a->face_count; f++) {
        const crisp_surface *s = a->faces[f].surface, *t = b->faces[f].surface;
        assert_int_equal(s->degree_u, t->degree_u);
        assert_int_equal(s->degree_v, t->degree_v);
        assert_int_equal(s->count_u, t->count_u);
        assert_int_equal(s->count_v, t->count_v);
        assert_int_equal(s->rational, t->rational);
        assert_same_doubles(s->knots_u, t->knots_u, (size_t)(s->count_u + s->degree_u + 1));
        assert_same_doubles(s->knots_v, t->knots_v, (size_t)(s->count_v + s->degree_v + 1));
        assert_same_doubles(s->cpw, t->cpw, (size_t)s->count_u * (size_t)s->count_v * 4);
        assert_int_equal(a->faces[f].has_color, b->faces[f].has_color);
        if (a->faces[f].has_color)
            assert_memory_equal(a->faces[f].color, b->faces[f].color, sizeof a->faces[f].color);
        assert_int_equal(a->faces[f].loop_count, b->faces[f].loop_count);
        for (int l = 0; l < a->faces[f].loop_count; l++) {
            const crisp_trim_loop *la = &a->faces[f].loops[l], *lb = &b->faces[f].loops[l];
            assert_int_equal(la->is_outer, lb->is_outer);
            assert_int_equal(la->curve_count, lb->curve_count);
            for (int c = 0; c < la->curve_count; c++)
                assert_same_curve(la->curves[c], lb->curves[c]);
        }
    }
}

static crisp_curve *line2(double x0, double y0, double x1, double y1, double t0, double t1)
{
    double k[4] = {t0, t0, t1, t1}, p[4] = {x0, y0, x1, y1};
    crisp_curve *c = NULL;
    assert_int_equal(crisp_curve_create(2, 1, 2, k, p, NULL, &c), CRISP_OK);
    return c;
}

/* Full circle as 4 rational quadratic arcs (weights sqrt(2)/2 at the corners), clockwise. */
static crisp_curve *circle_cw(double cx, double cy, double r)
{
    static const double sq[9][2] = {{1, 0},  {1, -1}, {0, -1}, {-1, -1}, {-1, 0},
                                    {-1, 1}, {0, 1},  {1, 1},  {1, 0}};
    double p[18], w[9], k[12] = {0, 0, 0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1, 1, 1};
    for (int i = 0; i < 9; i++) {
        p[2 * i] = cx + r * sq[i][0];
        p[2 * i + 1] = cy + r * sq[i][1];
        w[i] = i % 2 ? sqrt(0.5) : 1.0;
    }
    crisp_curve *c = NULL;
    assert_int_equal(crisp_curve_create(2, 2, 9, k, p, w, &c), CRISP_OK);
    return c;
}

static crisp_model *model_in_code(void)
{
    crisp_model *m = NULL;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    /* face 1: rational biquadratic x bicubic, clamped non-uniform knots, with weights far from
     * 1 (so Euclidean -> homogeneous rounding is exercised), square outer loop + circular hole */
    {
        enum { NU = 4, NV = 5 };
        double ku[NU + 3] = {0, 0, 0, 0.3, 1, 1, 1}, kv[NV + 4] = {-1, -1, -1, -1, 0.1, 2, 2, 2, 2};
        double pts[NU * NV * 3], w[NU * NV];
        for (int j = 0; j < NV; j++)
            for (int i = 0; i < NU; i++) {
                int k = j * NU + i;
                pts[3 * k] = i * 0.7 + 0.01 * j;
                pts[3 * k + 1] = j * 1.3 / 3.0;
                pts[3 * k + 2] = sin(0.9 * i + 0.4 * j) / 7.0;
                w[k] = 0.3 + 2.7 * fabs(sin(1.1 * k + 0.2));
            }
        crisp_face face = {0};
        assert_int_equal(crisp_surface_create(2, 3, NU, NV, ku, kv, pts, w, &face.surface),
                         CRISP_OK);
        face.loop_count = 2;
        face.loops = calloc(2, sizeof(crisp_trim_loop));
        face.loops[0].is_outer = 1;
        face.loops[0].curve_count = 4;
        face.loops[0].curves = calloc(4, sizeof(crisp_curve *));
        face.loops[0].curves[0] = line2(0.1, -0.9, 0.9, -0.9, 0, 1);
        face.loops[0].curves[1] = line2(0.9, -0.9, 0.9, 1.9, 1, 2.5);
        face.loops[0].curves[2] = line2(0.9, 1.9, 0.1, 1.9, 0, 1.0 / 3.0);
        face.loops[0].curves[3] = line2(0.1, 1.9, 0.1, -0.9, -2, 7);
        face.loops[1].is_outer = 0;
        face.loops[1].curve_count = 1;
        face.loops[1].curves = calloc(1, sizeof(crisp_curve *));
        face.loops[1].curves[0] = circle_cw(0.5, 0.5, 0.2);
        assert_int_equal(crisp_face_normalize_loops(&face, 1e-9), CRISP_OK);
        face.source_id = 7;
        face.has_color = 1;
        face.color[0] = 0.1f;
        face.color[1] = 0.7f;
        face.color[2] = 1.0f / 3.0f;
        face.color[3] = 0.5f;
        assert_int_equal(crisp_model_add_face(m, &face), CRISP_OK);
    }
    /* face 2: polynomial bicubic with unclamped uniform knots (domain [3, 4] x [3, 5]) */
    {
        double ku[8] = {0, 1, 2, 3, 4, 5, 6, 7}, kv[9] = {0, 1, 2, 3, 4, 5, 6, 7, 8};
        double pts[4 * 5 * 3];
        for (int k = 0; k < 20; k++) {
            pts[3 * k] = (k % 4) / 3.0;
            pts[3 * k + 1] = (k / 4) * 0.1;
            pts[3 * k + 2] = 1e-3 * k * k - 5e8;
        }
        crisp_face face = {0};
        assert_int_equal(crisp_surface_create(3, 3, 4, 5, ku, kv, pts, NULL, &face.surface),
                         CRISP_OK);
        assert_int_equal(crisp_model_add_face(m, &face), CRISP_OK);
    }
    return m;
}

static void strip_comments(char *text)
{
    char *out = text;
    for (const char *p = text; *p;) {
        const char *eol = strchr(p, '\n');
        size_t n = eol ? (size_t)(eol - p) + 1 : strlen(p);
        if (*p != '#' && strncmp(p, "mtllib ", 7) != 0) {
            memmove(out, p, n);
            out += n;
        }
        p += n;
    }
    *out = '\0';
}

/* The model.h contract on what a reader returns: every loop closed, inside the domain, oriented. */
static void assert_loops_valid(const crisp_model *m)
{
    for (int f = 0; f < m->face_count; f++) {
        double dom[4];
        crisp_surface_domain(m->faces[f].surface, dom);
        double tol = 1e-6 * fmax(dom[1] - dom[0], dom[3] - dom[2]);
        for (int l = 0; l < m->faces[f].loop_count; l++) {
            const crisp_trim_loop *loop = &m->faces[f].loops[l];
            assert_true(crisp_trim_loop_closure_gap(loop) <= tol);
            assert_true(crisp_trim_loop_domain_excess(loop, dom) <= tol);
            double area = crisp_trim_loop_signed_area(loop);
            assert_true(loop->is_outer ? area > 0 : area < 0);
        }
    }
}

static void round_trip(const crisp_model *a, const char *path)
{
    assert_int_equal(crisp_write_obj(a, path), CRISP_OK);
    crisp_model *b = NULL;
    crisp_status st = crisp_read_obj(path, NULL, &b);
    if (st != CRISP_OK) print_error("%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    assert_int_equal(b->skip_count, 0);
    assert_same_model(a, b);
    assert_loops_valid(b);
    /* writing what was read gives the same file */
    char path2[512];
    snprintf(path2, sizeof path2, "%s.again.obj", path);
    assert_int_equal(crisp_write_obj(b, path2), CRISP_OK);
    char *t1 = NULL, *t2 = NULL;
    size_t n1 = 0, n2 = 0;
    assert_int_equal(crisp_read_file(path, &t1, &n1), CRISP_OK);
    assert_int_equal(crisp_read_file(path2, &t2, &n2), CRISP_OK);
    /* comments (source format, lines) and the .mtl file name differ; everything else may not */
    strip_comments(t1);
    strip_comments(t2);
    int same = strcmp(t1, t2) == 0;
    crisp_free(t1);
    crisp_free(t2);
    if (!same) print_error("%s and %s differ\n", path, path2);
    assert_true(same);
    remove(path);
    remove(path2);
    char mtl[600];
    snprintf(mtl, sizeof mtl, "%.*s.mtl", (int)(strlen(path) - 4), path);
    remove(mtl);
    snprintf(mtl, sizeof mtl, "%s.again.mtl", path);
    remove(mtl);
    crisp_model_destroy(b);
}

static void test_model_in_code(void **state)
{
    (void)state;
    crisp_model *a = model_in_code();
    round_trip(a, CRISP_BIN_DIR "/test_obj_roundtrip_code.obj");
    crisp_model_destroy(a);
}

static void test_write_errors(void **state)
{
    (void)state;
    crisp_model *a = model_in_code();
    assert_int_equal(crisp_write_obj(a, "/nonexistent-dir/x.obj"), CRISP_ERR_IO);
    assert_non_null(strstr(crisp_error_message(), "/nonexistent-dir/x.obj"));
    crisp_model_destroy(a);
}

#ifdef CRISP_TEST_HAVE_IGES
static void round_trip_file(const char *name)
{
    char path[512], out[512];
    snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, name);
    snprintf(out, sizeof out, "%s/test_obj_roundtrip_%s.obj", CRISP_BIN_DIR, name);
    crisp_model *a = NULL;
    crisp_status st = crisp_model_load(path, NULL, &a);
    if (st != CRISP_OK) print_error("%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    assert_true(a->face_count > 0);
    round_trip(a, out);
    crisp_model_destroy(a);
}

static void test_iges_hammer(void **state)
{
    (void)state;
    round_trip_file("occt_hammer.iges");
}

static void test_iges_gpucast_part(void **state)
{
    (void)state;
    round_trip_file("gpucast_part.igs");
}

/* the rest of the bundled IGES files: rational high-degree (impeller), B-rep (bearing), and the
 * standard-bending teapot */
static void test_iges_others(void **state)
{
    (void)state;
    round_trip_file("impeller.igs");
    round_trip_file("occt_bearing.iges");
    round_trip_file("gpucast_teapot.igs");
}

/* STEP -> OBJ -> crisp: analytic surfaces converted to NURBS, degrees up to 10 */
static void test_step_linkrods(void **state)
{
    (void)state;
    round_trip_file("occt_linkrods.step");
    if (getenv("CRISP_TEST_VENTILATOR")) round_trip_file("Ventilator.stp");
}
#endif

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_model_in_code), cmocka_unit_test(test_write_errors),
#ifdef CRISP_TEST_HAVE_IGES
        cmocka_unit_test(test_iges_hammer),   cmocka_unit_test(test_iges_gpucast_part),
        cmocka_unit_test(test_iges_others),   cmocka_unit_test(test_step_linkrods),
#endif
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
