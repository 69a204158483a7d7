/* Tests of the Wavefront OBJ free-form reader and writer: the spec's Example 9, Bézier and
 * B-spline forms, the surf range, negative references, continuation lines, polygon meshes, every
 * class of bad input (each must fail with file:line:column, never crash), and the write -> read
 * round trip (control points, weights and knots bit-identical). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "crisp/io.h"

static const char example9[] =
    "# Wavefront OBJ spec, Example 9 (shortened): a rational Bezier trim on a rational surface\n"
    "vp -0.675 1.850 3.000\n"
    "vp 0.915 1.930\n"
    "vp 2.485 0.470 2.000\n"
    "vp 2.485 -1.030\n"
    "vp 1.605 -1.890 10.700\n"
    "vp -0.745 -0.654 0.500\n"
    "cstype rat bezier\n"
    "deg 3\n"
    "curv2 -6 -5 -4 -3 -2 -1 -6\n"
    "parm u 0.00 1.00 2.00\n"
    "end\n"
    "v -1.350 -1.030 0.000\n"
    "v 0.130 -1.030 0.432 7.600\n"
    "v 1.480 -1.030 0.000 2.300\n"
    "v -1.460 0.060 0.201\n"
    "v 0.120 0.060 0.915 0.500\n"
    "v 1.380 0.060 0.454 1.500\n"
    "v -1.480 1.030 0.000 2.300\n"
    "v 0.120 1.030 0.394 6.100\n"
    "v 1.170 1.030 0.000 3.300\n"
    "cstype rat bspline\n"
    "deg 2 2\n"
    "surf -1.0 2.5 -2.0 2.0 -9 -8 -7 -6 -5 -4 -3 -2 -1\n"
    "parm u -1.00 -1.00 -1.00 2.50 2.50 2.50\n"
    "parm v -2.00 -2.00 -2.00 2.00 2.00 2.00\n"
    "trim 0.0 2.0 1\n"
    "end\n";

static crisp_status read_str(const char *text, crisp_model **m)
{
    return crisp_read_obj_mem("test.obj", text, strlen(text), NULL, m);
}

static void test_example9(void **state)
{
    (void)state;
    crisp_model *m = NULL;
    assert_int_equal(read_str(example9, &m), CRISP_OK);
    assert_string_equal(m->format, "OBJ");
    assert_int_equal(m->face_count, 1);
    const crisp_face *f = &m->faces[0];
    const crisp_surface *s = f->surface;
    assert_int_equal(s->degree_u, 2);
    assert_int_equal(s->degree_v, 2);
    assert_int_equal(s->count_u, 3);
    assert_int_equal(s->count_v, 3);
    assert_true(s->rational);
    /* v 0.130 -1.030 0.432 7.600: Euclidean point and weight, stored homogeneous */
    assert_true(s->cpw[1 * 4 + 3] == 7.6);
    assert_true(fabs(s->cpw[1 * 4 + 0] - 0.130 * 7.6) < 1e-15);
    double p[3];
    crisp_surface_eval(s, -1.0, -2.0, p);
    assert_true(fabs(p[0] + 1.35) < 1e-12 && fabs(p[1] + 1.03) < 1e-12);
    assert_int_equal(f->source_id, 24);
    /* one outer loop: one rational cubic of two Bezier segments, closed, CCW, in the domain */
    assert_int_equal(f->loop_count, 1);
    const crisp_trim_loop *l = &f->loops[0];
    assert_true(l->is_outer);
    assert_int_equal(l->curve_count, 1);
    const crisp_curve *c = l->curves[0];
    assert_int_equal(c->degree, 3);
    assert_int_equal(c->count, 7);
    assert_true(c->rational);
    static const double knots[] = {0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2};
    for (int i = 0; i < 11; i++)
        assert_true(c->knots[i] == knots[i]);
    assert_true(crisp_trim_loop_closure_gap(l) < 1e-12);
    assert_true(crisp_trim_loop_signed_area(l) > 0);
    double dom[4];
    crisp_surface_domain(s, dom);
    assert_true(crisp_trim_loop_domain_excess(l, dom) == 0);
    crisp_model_destroy(m);
}

/* A Bezier surface with breakpoints 0 1 3 (u) and 0 2 (v) whose control points sit at the
 * Greville abscissae reproduces S(u, v) = (u, v, u + 2v) exactly: checks the breakpoint -> knot
 * conversion (multiplicity deg at interior breakpoints). */
static void test_bezier_breakpoints(void **state)
{
    (void)state;
    char text[4096];
    int n = snprintf(text, sizeof text, "cstype bezier\ndeg 2 1\n");
    static const double gu[] = {0, 0.5, 1, 2, 3}, gv[] = {0, 2};
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 5; i++)
            n += snprintf(text + n, sizeof text - n, "v %g %g %g\n", gu[i], gv[j],
                          gu[i] + 2 * gv[j]);
    n += snprintf(text + n, sizeof text - n,
                  "surf 0 3 0 2 1 2 3 4 5 6 7 8 9 10\nparm u 0 1 3\nparm v 0 2\nend\n");
    crisp_model *m = NULL;
    assert_int_equal(read_str(text, &m), CRISP_OK);
    assert_int_equal(m->face_count, 1);
    const crisp_surface *s = m->faces[0].surface;
    assert_int_equal(s->count_u, 5);
    assert_int_equal(s->count_v, 2);
    static const double ku[] = {0, 0, 0, 1, 1, 3, 3, 3};
    for (int i = 0; i < 8; i++)
        assert_true(s->knots_u[i] == ku[i]);
    for (double u = 0; u <= 3; u += 0.37)
        for (double v = 0; v <= 2; v += 0.29) {
            double p[3];
            crisp_surface_eval(s, u, v, p);
            assert_true(fabs(p[0] - u) < 1e-12 && fabs(p[1] - v) < 1e-12 &&
                        fabs(p[2] - (u + 2 * v)) < 1e-12);
        }
    crisp_model_destroy(m);
}

/* 5 x 4 bicubic/biquadratic grid over knots 0..3 (u) and 0..2 (v), text built by make_grid. */
static int make_grid(char *text, size_t cap, const char *range)
{
    int n = snprintf(text, cap, "# grid\ncstype bspline\ndeg 2 2\n");
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 5; i++)
            n += snprintf(text + n, cap - n, "v %d %d %g\n", i, j, sin(i * 1.3 + j * 0.7));
    n += snprintf(text + n, cap - n, "surf %s", range);
    for (int k = 1; k <= 20; k++)
        n += snprintf(text + n, cap - n, " %d", k);
    n += snprintf(text + n, cap - n, "\nparm u 0 0 0 1 2 3 3 3\nparm v 0 0 0 1 2 2 2\nend\n");
    return n;
}

static void test_surf_range_restricts(void **state)
{
    (void)state;
    char full[4096], part[4096];
    make_grid(full, sizeof full, "0 3 0 2");
    make_grid(part, sizeof part, "0.5 2.25 0.4 2");
    crisp_model *a = NULL, *b = NULL;
    assert_int_equal(read_str(full, &a), CRISP_OK);
    assert_int_equal(read_str(part, &b), CRISP_OK);
    double dom[4];
    crisp_surface_domain(b->faces[0].surface, dom);
    assert_true(dom[0] == 0.5 && dom[1] == 2.25 && dom[2] == 0.4 && dom[3] == 2);
    for (double u = 0.5; u <= 2.25; u += 0.05)
        for (double v = 0.4; v <= 2; v += 0.1) {
            double p[3], q[3];
            crisp_surface_eval(a->faces[0].surface, u, v, p);
            crisp_surface_eval(b->faces[0].surface, u, v, q);
            assert_true(fabs(p[0] - q[0]) + fabs(p[1] - q[1]) + fabs(p[2] - q[2]) < 1e-12);
        }
    crisp_model_destroy(a);
    crisp_model_destroy(b);
    /* a range outside the knot domain is an error naming the line */
    make_grid(part, sizeof part, "0 3.5 0 2");
    assert_int_equal(read_str(part, &b), CRISP_ERR_PARSE);
    assert_non_null(strstr(crisp_error_message(), "test.obj:24"));
}

/* Continuations, comments, accepted-and-ignored statements, negative references, v/vt/vn refs. */
static void test_syntax_variants(void **state)
{
    (void)state;
    static const char text[] = "mtllib x.mtl\n"
                               "g part\n"
                               "v 0 0 0\n"
                               "v 1 0 0 # a comment\n"
                               "v 0 1 0\n"
                               "v 1 1 0\n"
                               "vt 0 0\n"
                               "vn 0 0 1\n"
                               "mg 1 0.5\n"
                               "ctech cparm 1\n"
                               "stech cparma 1 1\n"
                               "bmat u 1 0 0 1\n"
                               "step 1 1\n"
                               "cstype bspline\n"
                               "deg 1 1\n"
                               "surf 0 1 0 1 -4/1/1 -3 \\\n"
                               "    -2//1 -1\n"
                               "parm u 0 0 \\\n"
                               "  1 1\n"
                               "parm v 0 0 1 1\n"
                               "scrv 0 1 1\n"
                               "end\n"
                               "frobnicate 3\n"
                               "con 1 0 1 1 2 0 1 1\n";
    crisp_model *m = NULL;
    assert_int_equal(read_str(text, &m), CRISP_OK);
    assert_int_equal(m->face_count, 1);
    double p[3];
    crisp_surface_eval(m->faces[0].surface, 1, 1, p);
    assert_true(p[0] == 1 && p[1] == 1);
    /* unknown statements and scrv are reported, not fatal */
    int unknown = 0, scrv = 0;
    for (int i = 0; i < m->skip_count; i++) {
        if (strstr(m->skips[i].what, "frobnicate")) unknown = m->skips[i].count;
        if (strstr(m->skips[i].what, "scrv")) scrv = m->skips[i].count;
    }
    assert_int_equal(unknown, 1);
    assert_int_equal(scrv, 1);
    crisp_model_destroy(m);
}

/* Polygon faces: a cube cage with v/vt/vn and negative references becomes Catmull-Clark patches. */
static void test_polygon_cube(void **state)
{
    (void)state;
    static const char text[] =
        "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
        "vt 0 0\nvn 0 0 1\n"
        "f 1/1/1 4/1/1 3/1/1 2/1/1\nf 5//1 6//1 7//1 8//1\nf 1 2 6 5\n"
        "f -7 -6 -2 -3\nf 3 4 8 7\nf 4 1 5 8\n";
    crisp_model *m = NULL;
    crisp_status st = read_str(text, &m);
    assert_int_equal(st, CRISP_OK);
#ifdef CRISP_HAVE_OSD
    /* isolation 3 around the 8 valence-3 corners (OpenSubdiv 3.5 gives 168 patches) */
    assert_int_equal(m->face_count, 168);
    for (int i = 0; i < m->face_count; i++) {
        const crisp_surface *s = m->faces[i].surface;
        assert_int_equal(s->degree_u, 3);
        assert_int_equal(s->count_u, 4);
        assert_int_equal(m->faces[i].loop_count, 0);
        assert_true(m->faces[i].source_id >= 11 && m->faces[i].source_id <= 16);
        /* the limit surface of this cage lies between the inscribed and the cage's sphere */
        double p[3];
        crisp_surface_eval(s, 0.5, 0.5, p);
        double r = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        assert_true(r > 0.5 && r < sqrt(3.0));
    }
#else
    assert_int_equal(m->face_count, 0);
    assert_int_equal(m->skip_count, 1);
#endif
    crisp_model_destroy(m);
}

typedef struct bad_case {
    const char *text;
    crisp_status status;
    const char *where; /* expected in the message */
} bad_case;

static void test_bad_input(void **state)
{
    (void)state;
    static const bad_case cases[] = {
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\ncstype bspline\ndeg 1 1\nsurf 0 1 0 1 1 2 3 99\n",
         CRISP_ERR_PARSE, "test.obj:6:20"},
        {"v 0 0 0\ncstype bspline\ndeg 1 1\nsurf 0 1 0 1 1 0 1 1\n", CRISP_ERR_PARSE,
         "test.obj:4:16"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\ncstype bspline\ndeg 1 1\n"
         "surf 0 1 0 1 1 2 3 4\nparm u 0 0 1 1 2\nparm v 0 0 1 1\nend\n",
         CRISP_ERR_PARSE, "test.obj:7"},
        {"cstype bspline\ndeg 16 1\n", CRISP_ERR_LIMIT, "test.obj:2:5"},
        {"v nan 0 0\n", CRISP_ERR_NUMERIC, "test.obj:1:3"},
        {"v 1e999 0 0\n", CRISP_ERR_NUMERIC, "test.obj:1:3"},
        {"v 1 0x 0\n", CRISP_ERR_PARSE, "test.obj:1:5"},
        {"v 1 2\n", CRISP_ERR_PARSE, "test.obj:1:1"},
        {"parm u 0 1\n", CRISP_ERR_PARSE, "test.obj:1:1"},
        {"end\n", CRISP_ERR_PARSE, "test.obj:1:1"},
        {"deg 3\ncurv2 1 2\n", CRISP_ERR_PARSE, "test.obj:2:1"},
        {"cstype nurbs\n", CRISP_ERR_PARSE, "test.obj:1:8"},
        {"vp 0 0\nvp 1 0\ncstype bspline\ndeg 1\ncurv2 1 2\nparm u 0 0 1 1\nend\n"
         "cstype bspline\ndeg 1 1\ntrim 0 1 1\n",
         CRISP_ERR_PARSE, "test.obj:10:1"},
        /* trim refers to curv2 2, only 1 defined */
        {"vp 0 0\nvp 1 0\ncstype bspline\ndeg 1\ncurv2 1 2\nparm u 0 0 1 1\nend\n"
         "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\ndeg 1 1\nsurf 0 1 0 1 1 2 3 4\n"
         "parm u 0 0 1 1\nparm v 0 0 1 1\ntrim 0 1 2\nend\n",
         CRISP_ERR_PARSE, "test.obj:16:10"},
        /* a rational surface with a zero weight */
        {"v 0 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\ncstype rat bspline\ndeg 1 1\n"
         "surf 0 1 0 1 1 2 3 4\nparm u 0 0 1 1\nparm v 0 0 1 1\nend\n",
         CRISP_ERR_INVALID_ARG, "test.obj:7"},
        /* decreasing knots */
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\ncstype bspline\ndeg 1 1\n"
         "surf 0 1 0 1 1 2 3 4\nparm u 0 1 0 1\nparm v 0 0 1 1\nend\n",
         CRISP_ERR_PARSE, "test.obj:7"},
        /* a count far beyond the data */
        {"v 0 0 0\ncstype bezier\ndeg 15 15\nsurf 0 1 0 1 1 1 1 1\nparm u 0 1e300\n"
         "parm v 0 1\nend\n",
         CRISP_ERR_PARSE, "test.obj:4"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        crisp_model *m = (crisp_model *)&m;
        crisp_error_clear();
        crisp_status st = read_str(cases[i].text, &m);
        if (st != cases[i].status || !strstr(crisp_error_message(), cases[i].where))
            print_error("case %zu: status %d, message '%s'\n", i, (int)st, crisp_error_message());
        assert_int_equal(st, cases[i].status);
        assert_null(m);
        assert_non_null(strstr(crisp_error_message(), cases[i].where));
    }
}

/* A trim built from an unsupported curve type drops the face with a note; a file that reuses one
 * long curv2 in thousands of trim pieces hits the total bound instead of allocating gigabytes. */
static void test_trim_limits(void **state)
{
    (void)state;
    static const char unsupported[] =
        "vp 0 0\nvp 1 0\nvp 1 1\ncstype cardinal\ndeg 3\ncurv2 1 2 3\nparm u 0 1\nend\n"
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\ncstype bspline\ndeg 1 1\nsurf 0 1 0 1 1 2 3 4\n"
        "parm u 0 0 1 1\nparm v 0 0 1 1\ntrim 0 1 1\nend\n";
    crisp_model *m = NULL;
    assert_int_equal(read_str(unsupported, &m), CRISP_OK);
    assert_int_equal(m->face_count, 0);
    int dropped = 0, noted = 0;
    for (int i = 0; i < m->skip_count; i++) {
        if (strstr(m->skips[i].what, "line 15") && strstr(m->skips[i].what, "unsupported"))
            dropped++;
        if (strstr(m->skips[i].what, "cardinal")) noted++;
    }
    assert_int_equal(dropped, 1);
    assert_int_equal(noted, 1);
    crisp_model_destroy(m);

    enum { N = 2000, PIECES = 2100 };
    size_t cap = (size_t)N * 24 + PIECES * 12 + 4096, n = 0;
    char *text = malloc(cap);
    assert_non_null(text);
    for (int i = 0; i < N; i++)
        n += (size_t)snprintf(text + n, cap - n, "vp %d 0\n", i);
    n += (size_t)snprintf(text + n, cap - n, "cstype bspline\ndeg 1\ncurv2");
    for (int i = 1; i <= N; i++)
        n += (size_t)snprintf(text + n, cap - n, " %d", i);
    n += (size_t)snprintf(text + n, cap - n, "\nparm u 0");
    for (int i = 0; i < N; i++)
        n += (size_t)snprintf(text + n, cap - n, " %d", i);
    n += (size_t)snprintf(text + n, cap - n,
                          " %d\nend\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                          "deg 1 1\nsurf 0 1 0 1 1 2 3 4\nparm u 0 0 1 1\nparm v 0 0 1 1\ntrim",
                          N - 1);
    for (int i = 0; i < PIECES; i++)
        n += (size_t)snprintf(text + n, cap - n, " 0 %d 1", N - 1);
    n += (size_t)snprintf(text + n, cap - n, "\nend\n");
    assert_true(n < cap);
    m = NULL;
    assert_int_equal(read_str(text, &m), CRISP_ERR_LIMIT);
    assert_null(m);
    assert_non_null(strstr(crisp_error_message(), "control points in all"));
    free(text);
}

/* usemtl + mtllib: face colours from the .mtl file beside the OBJ (Kd, Tr); from memory the
 * mtllib is not opened and a note says so. */
static void test_materials(void **state)
{
    (void)state;
    static const char obj[] =
        "mtllib test_obj_materials.mtl\n"
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\ncstype bspline\ndeg 1 1\n"
        "usemtl red\nsurf 0 1 0 1 1 2 3 4\nparm u 0 0 1 1\nparm v 0 0 1 1\nend\n"
        "usemtl undefined\nsurf 0 1 0 1 1 2 3 4\nparm u 0 0 1 1\nparm v 0 0 1 1\nend\n"
        "usemtl blue\nf 1 2 4 3\n";
    static const char mtl[] = "# test\nnewmtl red\nKd 1 0 0\nTr 0.25\nnewmtl blue\n"
                              "Ka 0 0 0\nKd 0 0 0.5 # half\nd 1\nmap_Kd tex.png\n";
    const char *objpath = CRISP_BIN_DIR "/test_obj_materials.obj";
    const char *mtlpath = CRISP_BIN_DIR "/test_obj_materials.mtl";
    FILE *f = fopen(objpath, "w");
    assert_non_null(f);
    fputs(obj, f);
    fclose(f);
    f = fopen(mtlpath, "w");
    assert_non_null(f);
    fputs(mtl, f);
    fclose(f);
    crisp_model *m = NULL;
    assert_int_equal(crisp_read_obj(objpath, NULL, &m), CRISP_OK);
    assert_true(m->face_count >= 3);
    assert_true(m->faces[0].has_color);
    assert_true(m->faces[0].color[0] == 1.0f && m->faces[0].color[1] == 0.0f &&
                m->faces[0].color[2] == 0.0f && m->faces[0].color[3] == 0.75f);
    assert_false(m->faces[1].has_color);
#ifdef CRISP_HAVE_OSD
    for (int i = 2; i < m->face_count; i++)
        assert_true(m->faces[i].has_color && m->faces[i].color[2] == 0.5f);
#endif
    crisp_model_destroy(m);
    /* crisp_model_load resolves the mtllib too */
    assert_int_equal(crisp_model_load(objpath, NULL, &m), CRISP_OK);
    assert_true(m->faces[0].has_color);
    crisp_model_destroy(m);
    remove(mtlpath);
    /* a missing .mtl is a note, not an error */
    assert_int_equal(crisp_read_obj(objpath, NULL, &m), CRISP_OK);
    assert_false(m->faces[0].has_color);
    assert_int_equal(m->skip_count, 1);
    assert_non_null(strstr(m->skips[0].what, "not readable"));
    crisp_model_destroy(m);
    remove(objpath);
    assert_int_equal(read_str(obj, &m), CRISP_OK);
    assert_false(m->faces[0].has_color);
    assert_non_null(strstr(m->skips[0].what, "memory"));
    crisp_model_destroy(m);
}

/* Every prefix of a valid file reads or fails cleanly (no crash, no leak, a message). */
static void test_truncated_files(void **state)
{
    (void)state;
    size_t n = strlen(example9);
    for (size_t len = 0; len <= n; len++) {
        crisp_model *m = NULL;
        crisp_error_clear();
        crisp_status st = crisp_read_obj_mem("cut.obj", example9, len, NULL, &m);
        if (st == CRISP_OK) {
            assert_non_null(m);
            crisp_model_destroy(m);
        } else {
            assert_null(m);
            assert_non_null(strstr(crisp_error_message(), "cut.obj"));
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_example9),
        cmocka_unit_test(test_bezier_breakpoints),
        cmocka_unit_test(test_surf_range_restricts),
        cmocka_unit_test(test_syntax_variants),
        cmocka_unit_test(test_polygon_cube),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_trim_limits),
        cmocka_unit_test(test_materials),
        cmocka_unit_test(test_truncated_files),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
