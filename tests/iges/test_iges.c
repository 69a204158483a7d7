/* Tests for the IGES reader on hand-written files: each analytic entity checked against its
 * analytic shape (100 arc under a 124 transform, 104 ellipse, 112 and 114 power-basis splines,
 * 118 ruled, 120 revolution with pcurves in (t, angle), 122 tabulated cylinder, 108 bounded
 * plane, a 186/514/510/508/504/502 B-rep face without pcurves), the lenient record handling, and
 * malformed files rejected with the expected status and a message naming the DE. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "crisp/io.h"
#include "iges/iges_builder.h"
#include "io/iges/iges_internal.h"

#define N_OF(a) ((int)(sizeof(a) / sizeof((a)[0])))

static crisp_model *load(const test_entity *ents, int n)
{
    char *text = test_iges_build(ents, n);
    crisp_model *m = NULL;
    crisp_status st = crisp_read_iges_mem("test.igs", text, strlen(text), NULL, &m);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    free(text);
    return m;
}

/* Parse only, for converting single entities. */
static void parse(const test_entity *ents, int n, iges_file *f, char **text)
{
    *text = test_iges_build(ents, n);
    crisp_status st = crisp__iges_file_parse("test.igs", *text, strlen(*text), f);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    f->projection_fraction = 1e-5;
    f->closure_fraction = 1e-6;
}

static crisp_curve *one_curve(iges_file *f, int index, int dim)
{
    iges_curves out = {0};
    crisp_status st = crisp__iges_curve_convert(f, index, dim, NULL, 0, &out);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    assert_int_equal(out.count, 1);
    crisp_curve *c = out.items[0];
    crisp_free(out.items);
    return c;
}

/* ---- curves --------------------------------------------------------------------------------- */

static void test_arc_with_transform(void **state)
{
    (void)state;
    /* 124: rotate 90 degrees about z, then move by (10, 0, 0); 100: quarter circle of radius 2
     * about (1, 1) at z = 2 from (3, 1) to (1, 3) */
    test_entity e[] = {
        {124, 0, 0, NULL, 0, "0.,-1.,0.,10.,1.,0.,0.,0.,0.,0.,1.,0.;"},
        {100, 0, 1, NULL, 0, "2.,1.,1.,3.,1.,1.,3.;"},
    };
    iges_file f;
    char *text;
    parse(e, 2, &f, &text);
    crisp_curve *c = one_curve(&f, 1, 3);
    double t0, t1, p[3], centre[3] = {9, 1, 2};
    crisp_curve_domain(c, &t0, &t1);
    for (int k = 0; k <= 50; k++) {
        crisp_curve_eval(c, t0 + (t1 - t0) * k / 50, p);
        double r = hypot(p[0] - centre[0], p[1] - centre[1]);
        assert_true(fabs(r - 2) < 1e-12);
        assert_true(fabs(p[2] - 2) < 1e-12);
        /* the arc stays in the rotated quarter: x <= 9, y >= 1 */
        assert_true(p[0] <= 9 + 1e-12 && p[1] >= 1 - 1e-12);
    }
    crisp_curve_eval(c, t0, p);
    assert_true(fabs(p[0] - 9) < 1e-12 && fabs(p[1] - 3) < 1e-12);
    crisp_curve_eval(c, t1, p);
    assert_true(fabs(p[0] - 7) < 1e-12 && fabs(p[1] - 1) < 1e-12);
    crisp_curve_destroy(c);
    crisp__iges_file_free(&f);
    free(text);
}

static void test_transform_chain(void **state)
{
    (void)state;
    /* a line under T1 = translate (1, 0, 0), whose own DE points to T2 = scale 2: x' = T2 T1 x */
    test_entity e[] = {
        {124, 0, 0, NULL, 0, "2.,0.,0.,0.,0.,2.,0.,0.,0.,0.,2.,0.;"},
        {124, 0, 1, NULL, 0, "1.,0.,0.,1.,0.,1.,0.,0.,0.,0.,1.,0.;"},
        {110, 0, 3, NULL, 0, "0.,0.,0.,1.,1.,1.;"},
    };
    iges_file f;
    char *text;
    parse(e, 3, &f, &text);
    crisp_curve *c = one_curve(&f, 2, 3);
    double p[3];
    crisp_curve_eval(c, 0, p);
    assert_true(fabs(p[0] - 2) < 1e-15 && fabs(p[1]) < 1e-15 && fabs(p[2]) < 1e-15);
    crisp_curve_eval(c, 1, p);
    assert_true(fabs(p[0] - 4) < 1e-15 && fabs(p[1] - 2) < 1e-15 && fabs(p[2] - 2) < 1e-15);
    crisp_curve_destroy(c);
    crisp__iges_file_free(&f);
    free(text);
}

static void test_conic_ellipse(void **state)
{
    (void)state;
    /* x^2 / 4 + y^2 = 1 from (2, 0) to (0, 1), and a full ellipse with a tilted axis */
    test_entity e[] = {
        {104, 1, 0, NULL, 0, "0.25,0.,1.,0.,0.,-1.,0.5,2.,0.,0.,1.;"},
        {104, 1, 0, NULL, 0, "0.3125,-0.375,0.3125,0.,0.,-1.,0.,2.,2.,2.,2.;"},
    };
    iges_file f;
    char *text;
    parse(e, 2, &f, &text);
    const double k[2][6] = {{0.25, 0, 1, 0, 0, -1}, {0.3125, -0.375, 0.3125, 0, 0, -1}};
    for (int i = 0; i < 2; i++) {
        crisp_curve *c = one_curve(&f, i, 3);
        double t0, t1, p[3];
        crisp_curve_domain(c, &t0, &t1);
        for (int s = 0; s <= 40; s++) {
            crisp_curve_eval(c, t0 + (t1 - t0) * s / 40, p);
            double q =
                k[i][0] * p[0] * p[0] + k[i][1] * p[0] * p[1] + k[i][2] * p[1] * p[1] + k[i][5];
            assert_true(fabs(q) < 1e-12);
        }
        crisp_curve_eval(c, t1, p);
        if (i == 0)
            assert_true(fabs(p[0]) < 1e-12 && fabs(p[1] - 1) < 1e-12 && fabs(p[2] - 0.5) < 1e-12);
        crisp_curve_destroy(c);
    }
    crisp__iges_file_free(&f);
    free(text);
}

static void test_parametric_spline_curve(void **state)
{
    (void)state;
    /* two cubic segments over breaks 0, 2, 3 (only continuity C0 is needed for exactness) */
    const double co[2][12] = {
        {1, 2, -1, 0.5, 0, 1, 0, -0.25, 3, 0, 0.5, 0.1},
        {1 + 4 - 4 + 4, 0.3, 0.2, -1, 0 + 2 - 2, 0.7, -0.4, 0.9, 3 + 2 + 0.8, 1, 0, 0}};
    char params[1024];
    int n = snprintf(params, sizeof params, "3,3,3,2,0.,2.,3.");
    for (int s = 0; s < 2; s++)
        for (int i = 0; i < 12; i++)
            n += snprintf(params + n, sizeof params - n, ",%.17g", co[s][i]);
    snprintf(params + n, sizeof params - n, ";");
    test_entity e[] = {{112, 0, 0, NULL, 0, params}};
    iges_file f;
    char *text;
    parse(e, 1, &f, &text);
    crisp_curve *c = one_curve(&f, 0, 3);
    const double brk[3] = {0, 2, 3};
    for (int s = 0; s < 2; s++)
        for (int k = 0; k <= 10; k++) {
            double t = brk[s] + (brk[s + 1] - brk[s]) * k / 10 * (k == 10 ? 0.999999 : 1);
            double x = t - brk[s], p[3];
            crisp_curve_eval(c, t, p);
            for (int d = 0; d < 3; d++) {
                const double *a = co[s] + 4 * d;
                double want = a[0] + a[1] * x + a[2] * x * x + a[3] * x * x * x;
                assert_true(fabs(p[d] - want) < 1e-9);
            }
        }
    crisp_curve_destroy(c);
    crisp__iges_file_free(&f);
    free(text);
}

/* ---- surfaces ------------------------------------------------------------------------------- */

static double binom(int n, int k)
{
    double r = 1;
    for (int i = 1; i <= k; i++)
        r = r * (n - k + i) / i;
    return r;
}

static void test_parametric_spline_surface(void **state)
{
    (void)state;
    /* M = 2 by N = 1 bicubic patches cut from one global polynomial per coordinate,
     * X(u, v) = sum g[d][p + 4 q] u^p v^q: each patch's power coefficients are its Taylor
     * coefficients about (TU(i), TV(j)), so the patches join and the surface must equal X. */
    const int m = 2, n = 1;
    const double tu[3] = {0, 1, 2.5}, tv[2] = {-1, 1};
    double g[3][16];
    for (int d = 0; d < 3; d++)
        for (int q = 0; q < 16; q++)
            g[d][q] = sin(1.3 * q + 0.7 * d);
    char params[16384];
    int w = snprintf(params, sizeof params, "3,0,%d,%d,0.,1.,2.5,-1.,1.", m, n);
    for (int i = 0; i <= m; i++)
        for (int j = 0; j <= n; j++)
            for (int d = 0; d < 3; d++)
                for (int q = 0; q < 4; q++)
                    for (int p = 0; p < 4; p++) {
                        double a = 0;
                        if (i < m && j < n)
                            for (int pp = p; pp < 4; pp++)
                                for (int qq = q; qq < 4; qq++)
                                    a += g[d][pp + 4 * qq] * binom(pp, p) * pow(tu[i], pp - p) *
                                         binom(qq, q) * pow(tv[j], qq - q);
                        w += snprintf(params + w, sizeof params - w, ",%.17g", a);
                    }
    snprintf(params + w, sizeof params - w, ";");
    test_entity e[] = {{114, 0, 0, NULL, 0, params}};
    crisp_model *model = load(e, 1);
    assert_int_equal(model->face_count, 1);
    const crisp_surface *s = model->faces[0].surface;
    assert_int_equal(s->count_u, 7);
    assert_int_equal(s->count_v, 4);
    for (int a = 0; a <= 10; a++)
        for (int b = 0; b <= 6; b++) {
            double u = tu[0] + (tu[m] - tu[0]) * a / 10, v = tv[0] + (tv[n] - tv[0]) * b / 6;
            double p[3];
            crisp_surface_eval(s, u, v, p);
            for (int d = 0; d < 3; d++) {
                double want = 0;
                for (int q = 0; q < 4; q++)
                    for (int pp = 0; pp < 4; pp++)
                        want += g[d][pp + 4 * q] * pow(u, pp) * pow(v, q);
                assert_true(fabs(p[d] - want) < 1e-9 * (1 + fabs(want)));
            }
        }
    crisp_model_destroy(model);
}

/* A cone-like surface of revolution: generatrix from (1, 0, 0) to (2, 0, 3) about z. The face is
 * trimmed by a triangle given in the file's (t, angle) parameters with one diagonal side, which
 * the reader must map into the NURBS parametrisation (exactly for the iso-lines, by fitting for
 * the diagonal). */
static void test_revolution_with_pcurves(void **state)
{
    (void)state;
    test_entity e[] = {
        {110, 0, 0, NULL, 0, "0.,0.,0.,0.,0.,1.;"},                      /* DE 1 axis */
        {110, 0, 0, NULL, 0, "1.,0.,0.,2.,0.,3.;"},                      /* DE 3 generatrix */
        {120, 0, 0, "00010000", 0, "1,3,0.,6.283185307179586;"},         /* DE 5 */
        {110, 0, 0, "00010500", 0, "0.,0.,0.,1.,0.,0.;"},                /* DE 7 */
        {110, 0, 0, "00010500", 0, "1.,0.,0.,0.,3.141592653589793,0.;"}, /* DE 9 diagonal */
        {110, 0, 0, "00010500", 0, "0.,3.141592653589793,0.,0.,0.,0.;"}, /* DE 11 */
        {102, 0, 0, "00010500", 0, "3,7,9,11;"},                         /* DE 13 */
        {142, 0, 0, "00010500", 0, "1,5,13,0,1;"},                       /* DE 15 */
        {144, 0, 0, NULL, 4, "5,1,0,15;"},                               /* DE 17 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    const crisp_face *face = &m->faces[0];
    assert_int_equal(face->source_id, 17);
    assert_true(face->has_color); /* colour 4: blue */
    assert_true(face->color[2] == 1 && face->color[0] == 0);
    const crisp_surface *s = face->surface;
    /* the surface: radius 1 + z / 3 everywhere */
    double dom[4];
    crisp_surface_domain(s, dom);
    for (int a = 0; a <= 8; a++)
        for (int b = 0; b <= 8; b++) {
            double p[3];
            crisp_surface_eval(s, dom[0] + (dom[1] - dom[0]) * a / 8,
                               dom[2] + (dom[3] - dom[2]) * b / 8, p);
            assert_true(fabs(hypot(p[0], p[1]) - (1 + p[2] / 3)) < 1e-12);
        }
    /* the loop: every point on the surface satisfies the triangle's sides in (t, angle):
     * t = z / 3 and angle = atan2(y, x) in [0, pi]; on the diagonal t + angle / pi = 1 */
    assert_int_equal(face->loop_count, 1);
    const crisp_trim_loop *loop = &face->loops[0];
    assert_int_equal(loop->curve_count, 3);
    assert_true(crisp_trim_loop_closure_gap(loop) < 1e-12);
    int diagonal_points = 0;
    for (int c = 0; c < 3; c++) {
        double t0, t1;
        crisp_curve_domain(loop->curves[c], &t0, &t1);
        for (int k = 0; k <= 20; k++) {
            double q[2], p[3];
            crisp_curve_eval(loop->curves[c], t0 + (t1 - t0) * k / 20, q);
            crisp_surface_eval(s, q[0], q[1], p);
            double t = p[2] / 3, ang = atan2(p[1], p[0]);
            if (ang < -1e-9) ang += 2 * M_PI;
            double on_bottom = fabs(t), on_side = fabs(ang - M_PI),
                   on_diag = fabs(t + ang / M_PI - 1);
            double best = fmin(on_bottom, fmin(fmin(on_side, fabs(ang)), on_diag));
            if (on_diag < 1e-5 && on_bottom > 1e-3 && fabs(ang - M_PI) > 1e-3) diagonal_points++;
            assert_true(best < 1e-5);
        }
    }
    assert_true(diagonal_points > 5);
    /* the loop's curves are in the NURBS domain */
    assert_true(crisp_trim_loop_domain_excess(loop, dom) < 1e-12);
    crisp_model_destroy(m);
}

static void test_ruled_and_tabulated(void **state)
{
    (void)state;
    test_entity e[] = {
        {110, 0, 0, "00010000", 0, "0.,0.,0.,4.,0.,0.;"},     /* DE 1 */
        {110, 0, 0, "00010000", 0, "0.,2.,1.,4.,2.,3.;"},     /* DE 3 */
        {118, 1, 0, NULL, 0, "1,3,0,0;"},                     /* DE 5 ruled */
        {100, 0, 0, "00010000", 0, "0.,0.,0.,1.,0.,-1.,0.;"}, /* DE 7 half circle */
        {122, 0, 0, NULL, 0, "7,1.,0.,5.;"},                  /* DE 9 tabulated */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 2);
    /* ruled: S(u, v) = (1 - v) C0(u) + v C1(u) */
    const crisp_surface *r = m->faces[0].surface;
    for (int a = 0; a <= 4; a++)
        for (int b = 0; b <= 4; b++) {
            double u = a / 4.0, v = b / 4.0, p[3];
            crisp_surface_eval(r, u, v, p);
            double want[3] = {4 * u, 2 * v, v * (1 + 2 * u)};
            for (int d = 0; d < 3; d++)
                assert_true(fabs(p[d] - want[d]) < 1e-12);
        }
    /* tabulated cylinder: the half circle swept along z by 5 */
    const crisp_surface *t = m->faces[1].surface;
    double dom[4];
    crisp_surface_domain(t, dom);
    assert_true(fabs(dom[2]) < 1e-15 && fabs(dom[3] - 1) < 1e-15);
    for (int a = 0; a <= 8; a++)
        for (int b = 0; b <= 4; b++) {
            double p[3];
            crisp_surface_eval(t, dom[0] + (dom[1] - dom[0]) * a / 8, b / 4.0, p);
            assert_true(fabs(hypot(p[0], p[1]) - 1) < 1e-12);
            assert_true(p[1] >= -1e-12);
            assert_true(fabs(p[2] - 5.0 * b / 4) < 1e-12);
        }
    crisp_model_destroy(m);
}

static void test_bounded_plane(void **state)
{
    (void)state;
    /* plane z = 5 bounded by a full circle of radius 2 about (1, 1) */
    test_entity e[] = {
        {100, 0, 0, "00010000", 0, "5.,1.,1.,3.,1.,3.,1.;"}, /* DE 1 */
        {108, 1, 0, NULL, 0, "0.,0.,1.,5.,1,0.,0.,5.,1.;"},  /* DE 3 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    const crisp_face *face = &m->faces[0];
    assert_int_equal(face->loop_count, 1);
    const crisp_trim_loop *loop = &face->loops[0];
    assert_true(crisp_trim_loop_signed_area(loop) > 0);
    for (int c = 0; c < loop->curve_count; c++) {
        double t0, t1;
        crisp_curve_domain(loop->curves[c], &t0, &t1);
        for (int k = 0; k <= 30; k++) {
            double q[2], p[3];
            crisp_curve_eval(loop->curves[c], t0 + (t1 - t0) * k / 30, q);
            crisp_surface_eval(face->surface, q[0], q[1], p);
            assert_true(fabs(p[2] - 5) < 1e-12);
            assert_true(fabs(hypot(p[0] - 1, p[1] - 1) - 2) < 1e-12);
        }
    }
    crisp_model_destroy(m);
}

/* A B-rep square face on a bilinear 128 patch; its edges have no pcurves, so the reader
 * projects the 3D edges onto the surface. */
static void test_brep_face_projected(void **state)
{
    (void)state;
    test_entity e[] = {
        {128, 0, 0, "00010000", 0,
         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"},                 /* DE 1 */
        {110, 0, 0, "00010000", 0, "1.,1.,0.,3.,1.,0.;"},                     /* DE 3 */
        {110, 0, 0, "00010000", 0, "3.,1.,0.,3.,3.,0.;"},                     /* DE 5 */
        {110, 0, 0, "00010000", 0, "3.,3.,0.,1.,3.,0.;"},                     /* DE 7 */
        {110, 0, 0, "00010000", 0, "1.,1.,0.,1.,3.,0.;"},                     /* DE 9 */
        {502, 1, 0, "00010000", 0, "4,1.,1.,0.,3.,1.,0.,3.,3.,0.,1.,3.,0.;"}, /* DE 11 */
        {504, 1, 0, "00010000", 0, "4,3,11,1,11,2,5,11,2,11,3,7,11,3,11,4,9,11,1,11,4;"}, /* 13 */
        {508, 1, 0, "00010000", 0, "4,0,13,1,1,0,0,13,2,1,0,0,13,3,1,0,0,13,4,0,0;"},     /* 15 */
        {510, 1, 0, "00010000", 0, "1,1,1,15;"},                                          /* 17 */
        {514, 1, 0, "00010000", 0, "1,17,1;"},                                            /* 19 */
        {186, 0, 0, NULL, 0, "19,1,0;"},                                                  /* 21 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    const crisp_face *face = &m->faces[0];
    assert_int_equal(face->loop_count, 1);
    assert_int_equal(face->loops[0].curve_count, 4);
    assert_true(face->loops[0].is_outer);
    assert_true(crisp_trim_loop_closure_gap(&face->loops[0]) < 1e-12);
    /* the square [1, 3]^2 in model space is [0.25, 0.75]^2 in (u, v): area 0.25 */
    assert_true(fabs(crisp_trim_loop_signed_area(&face->loops[0]) - 0.25) < 1e-6);
    /* nothing left over: every entity was part of the solid */
    for (int i = 0; i < m->skip_count; i++)
        fprintf(stderr, "skip: %s\n", m->skips[i].what);
    assert_int_equal(m->skip_count, 0);
    crisp_model_destroy(m);
}

/* A free 128 whose parameter range (U0 U1 V0 V1) is narrower than its knots is bounded by it. */
static void test_bspline_parameter_range(void **state)
{
    (void)state;
    test_entity e[] = {
        {128, 0, 0, NULL, 0,
         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.25,0.75,0.,1.;"},
        {128, 0, 0, NULL, 0,
         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"},
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 2);
    assert_int_equal(m->faces[0].loop_count, 1);
    assert_true(fabs(crisp_trim_loop_signed_area(&m->faces[0].loops[0]) - 0.5) < 1e-12);
    assert_int_equal(m->faces[1].loop_count, 0); /* the full range: the whole domain */
    crisp_model_destroy(m);
}

/* A 142 whose parameter-space curve is an entity crisp does not read (130 offset curve) falls
 * back to projecting its model-space curve. */
static void test_pcurve_fallback_to_projection(void **state)
{
    (void)state;
    test_entity e[] = {
        {128, 0, 0, "00010000", 0,
         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"},                   /* DE 1 */
        {110, 0, 0, "00010500", 0, "1.,1.,0.,3.,1.,0.;"},                       /* DE 3 */
        {110, 0, 0, "00010500", 0, "3.,1.,0.,3.,3.,0.;"},                       /* DE 5 */
        {110, 0, 0, "00010500", 0, "3.,3.,0.,1.,3.,0.;"},                       /* DE 7 */
        {110, 0, 0, "00010500", 0, "1.,3.,0.,1.,1.,0.;"},                       /* DE 9 */
        {102, 0, 0, "00010500", 0, "4,3,5,7,9;"},                               /* DE 11 */
        {130, 0, 0, "00010500", 0, "11,1,0,0,0,0.1,0.,0.1,0.,0.,0.,1.,0.,1.;"}, /* DE 13 */
        {142, 0, 0, "00010500", 0, "0,1,13,11,1;"},                             /* DE 15 */
        {144, 0, 0, NULL, 0, "1,1,0,15;"},                                      /* DE 17 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces[0].loop_count, 1);
    assert_true(fabs(crisp_trim_loop_signed_area(&m->faces[0].loops[0]) - 0.25) < 1e-6);
    crisp_model_destroy(m);
}

/* ---- records -------------------------------------------------------------------------------- */

static void test_lenient_records(void **state)
{
    (void)state;
    /* CRLF, trailing blanks stripped, and a global section with other delimiters ('/' and '!') */
    test_entity e[] = {{110, 0, 0, NULL, 0, "0.,0.,0.,1.,2.,3.;"}};
    char *text = test_iges_build(e, 1);
    char out[8192], *w = out;
    for (const char *line = text; *line;) {
        const char *eol = strchr(line, '\n');
        int n = (int)(eol - line);
        while (n > 0 && line[n - 1] == ' ')
            n--;
        if (line[72] == 'G') {
            w += sprintf(w, "%-72sG%7d\r\n", "1H//1H!/4Htest!", 1);
        } else if (line[72] == 'P') {
            char buf[100];
            memcpy(buf, line, 80);
            buf[80] = 0;
            for (int i = 0; i < 64; i++) {
                if (buf[i] == ',') buf[i] = '/';
                if (buf[i] == ';') buf[i] = '!';
            }
            w += sprintf(w, "%s\r\n", buf);
        } else {
            memcpy(w, line, (size_t)n);
            w += n;
            w += sprintf(w, "\r\n");
        }
        line = eol + 1;
    }
    free(text);
    crisp_model *m = NULL;
    crisp_status st = crisp_read_iges_mem("lenient.igs", out, (size_t)(w - out), NULL, &m);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    assert_int_equal(m->face_count, 0);
    assert_int_equal(m->skip_count, 1); /* the free line */
    assert_non_null(strstr(m->skips[0].what, "entity 110"));
    crisp_model_destroy(m);
}

static void test_unsupported_counted(void **state)
{
    (void)state;
    test_entity e[] = {
        {116, 0, 0, NULL, 0, "1.,2.,3.,0;"},
        {116, 0, 0, NULL, 0, "1.,2.,4.,0;"},
        {212, 0, 0, NULL, 0, "0;"},
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 0);
    assert_int_equal(m->skip_count, 2);
    assert_non_null(strstr(m->skips[0].what, "entity 116 point"));
    assert_int_equal(m->skips[0].count, 2);
    assert_non_null(strstr(m->skips[1].what, "entity 212"));
    crisp_model_destroy(m);
}

/* ---- malformed input ------------------------------------------------------------------------ */

static void expect_error(const test_entity *ents, int n, crisp_status want, const char *needle)
{
    char *text = test_iges_build(ents, n);
    crisp_model *m = NULL;
    crisp_status st = crisp_read_iges_mem("bad.igs", text, strlen(text), NULL, &m);
    free(text);
    if (st != want || !strstr(crisp_error_message(), needle))
        fprintf(stderr, "status %d (%s), message: %s; expected \"%s\"\n", st, crisp_status_name(st),
                crisp_error_message(), needle);
    assert_int_equal(st, want);
    assert_null(m);
    assert_non_null(strstr(crisp_error_message(), "bad.igs"));
    assert_non_null(strstr(crisp_error_message(), needle));
}

#define PATCH_128                                                                                  \
    "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"                                       \
    "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"

/* A 126 with the given parameters as the trim of a face: the error must name its DE (3). */
static void expect_bad_trim(const char *params_126, crisp_status want)
{
    test_entity e[] = {
        {128, 0, 0, "00010000", 0, PATCH_128},
        {126, 0, 0, "00010500", 0, params_126},
        {142, 0, 0, "00010500", 0, "1,1,3,0,1;"},
        {144, 0, 0, NULL, 0, "1,1,0,5;"},
    };
    expect_error(e, N_OF(e), want, "DE 3 ");
}

static void test_malformed(void **state)
{
    (void)state;
    /* a pointer to a DE that does not exist */
    test_entity bad_ptr[] = {{144, 0, 0, NULL, 0, "99,1,0,0;"}};
    expect_error(bad_ptr, 1, CRISP_ERR_PARSE, "DE 1 ");
    /* the wrong entity type referenced */
    test_entity wrong_type[] = {
        {110, 0, 0, NULL, 0, "0.,0.,0.,1.,1.,1.;"},
        {144, 0, 0, NULL, 0, "1,1,0,0;"},
    };
    expect_error(wrong_type, 2, CRISP_ERR_PARSE, "DE 3 ");
    /* counts larger than the remaining parameters */
    expect_bad_trim("100,3,0,0,1,0,0.,0.,0.,0.,1.,1.;", CRISP_ERR_PARSE);
    /* a huge count */
    expect_bad_trim("2000000000,3,0,0,1,0;", CRISP_ERR_LIMIT);
    /* degree above 15 */
    expect_bad_trim("16,16,0,0,1,0;", CRISP_ERR_LIMIT);
    /* a non-positive weight, decreasing knots: the kernel's message, with the DE in front */
    expect_bad_trim("1,1,0,0,1,0,0.,0.,1.,1.,1.,-1.,0.1,0.1,0.,0.9,0.9,0.,0.,1.;",
                    CRISP_ERR_INVALID_ARG);
    expect_bad_trim("1,1,0,0,1,0,0.,1.,0.,1.,1.,1.,0.1,0.1,0.,0.9,0.9,0.,0.,1.;",
                    CRISP_ERR_INVALID_ARG);
    /* NaN and an overflowing number are not numbers */
    test_entity nan[] = {{110, 0, 0, NULL, 0, "0.,nan,0.,1.,1.,1.;"}};
    expect_error(nan, 1, CRISP_ERR_PARSE, "DE 1");
    test_entity inf[] = {{110, 0, 0, NULL, 0, "0.,1E999,0.,1.,1.,1.;"}};
    expect_error(inf, 1, CRISP_ERR_PARSE, "DE 1");
    /* a composite curve that contains itself, as a trim boundary */
    test_entity cycle[] = {
        {128, 0, 0, "00010000", 0,
         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"},
        {102, 0, 0, NULL, 0, "2,5,3;"},
        {102, 0, 0, NULL, 0, "1,3;"},
        {142, 0, 0, NULL, 0, "1,1,3,0,1;"},
        {144, 0, 0, NULL, 0, "1,1,0,7;"},
    };
    expect_error(cycle, N_OF(cycle), CRISP_ERR_PARSE, "cycle");
    /* a transformation matrix chain that loops */
    test_entity xcycle[] = {
        {124, 0, 3, NULL, 0, "1.,0.,0.,0.,0.,1.,0.,0.,0.,0.,1.,0.;"},
        {124, 0, 1, NULL, 0, "1.,0.,0.,0.,0.,1.,0.,0.,0.,0.,1.,0.;"},
        {128, 0, 1, NULL, 0,
         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"},
    };
    expect_error(xcycle, N_OF(xcycle), CRISP_ERR_PARSE, "cycle");
    /* a 142 with neither curve */
    test_entity missing[] = {
        {128, 0, 0, "00010000", 0,
         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"},
        {142, 0, 0, NULL, 0, "1,1,0,0,1;"},
        {144, 0, 0, NULL, 0, "1,1,0,3;"},
    };
    expect_error(missing, N_OF(missing), CRISP_ERR_PARSE, "DE 3 ");
}

/* Composite curves nested 40 deep as a trim: rejected at the depth bound, naming a DE. */
static void test_deep_nesting(void **state)
{
    (void)state;
    enum { DEPTH = 40 };
    test_entity e[DEPTH + 4];
    char params[DEPTH][32];
    e[0] = (test_entity){128,
                         0,
                         0,
                         "00010000",
                         0,
                         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
                         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"};
    for (int i = 0; i < DEPTH; i++) { /* entity 1 + i is DE 3 + 2 i, holding the next one */
        snprintf(params[i], sizeof params[i], "1,%d;", 2 * (i + 2) + 1);
        e[1 + i] = (test_entity){102, 0, 0, "00010500", 0, params[i]};
    }
    e[1 + DEPTH] = (test_entity){110, 0, 0, "00010500", 0, "0.,0.,0.,1.,1.,0.;"};
    e[2 + DEPTH] = (test_entity){142, 0, 0, "00010500", 0, "1,1,3,0,1;"};
    char p144[32];
    snprintf(p144, sizeof p144, "1,1,0,%d;", 2 * (2 + DEPTH) + 1);
    e[3 + DEPTH] = (test_entity){144, 0, 0, NULL, 0, p144};
    expect_error(e, DEPTH + 4, CRISP_ERR_LIMIT, "deeper than");
}

/* A face whose surface crisp cannot build (a 120 with a composite generatrix) is skipped with a
 * note naming it; the rest of the file loads. */
static void test_unsupported_face_skipped(void **state)
{
    (void)state;
    test_entity e[] = {
        {110, 0, 0, "00010000", 0, "0.,0.,0.,0.,0.,1.;"},  /* DE 1 */
        {110, 0, 0, "00010000", 0, "1.,0.,0.,2.,0.,3.;"},  /* DE 3 */
        {110, 0, 0, "00010000", 0, "2.,0.,3.,2.,0.,4.;"},  /* DE 5 */
        {102, 0, 0, "00010000", 0, "2,3,5;"},              /* DE 7 */
        {120, 0, 0, NULL, 0, "1,7,0.,6.283185307179586;"}, /* DE 9 */
        {128, 0, 0, NULL, 0,
         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"}, /* DE 11 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces[0].source_id, 11);
    int noted = 0;
    for (int i = 0; i < m->skip_count; i++)
        if (strstr(m->skips[i].what, "DE 9") && strstr(m->skips[i].what, "composite")) noted = 1;
    if (!noted || m->skip_count != 1)
        for (int i = 0; i < m->skip_count; i++)
            fprintf(stderr, "skip: %s\n", m->skips[i].what);
    assert_true(noted);
    assert_int_equal(m->skip_count, 1); /* its curves are not reported as free geometry */
    crisp_model_destroy(m);
}

static void test_truncated_and_garbage(void **state)
{
    (void)state;
    test_entity e[] = {
        {126, 0, 0, NULL, 0,
         "3,3,0,0,1,0,0.,0.,0.,0.,1.,1.,1.,1.,1.,1.,1.,1.,0.,0.,0.,1.,1.,0.,2.,1.,0.,3.,0.,0.,"
         "0.,1.,0.,0.,1.;"},
    };
    char *text = test_iges_build(e, 1);
    size_t len = strlen(text);
    /* every prefix of the file either loads or fails cleanly, naming the file */
    for (size_t cut = 0; cut < len; cut += 7) {
        crisp_model *m = NULL;
        crisp_status st = crisp_read_iges_mem("cut.igs", text, cut, NULL, &m);
        if (st) {
            assert_null(m);
            assert_non_null(strstr(crisp_error_message(), "cut.igs"));
        } else {
            crisp_model_destroy(m);
        }
    }
    /* cut after the first line of the two-line parameter record: no record delimiter */
    const char *p = strstr(text, "P      1\n");
    assert_non_null(p);
    crisp_model *m = NULL;
    assert_int_equal(crisp_read_iges_mem("cut.igs", text, (size_t)(p - text) + 9, NULL, &m),
                     CRISP_ERR_PARSE);
    assert_non_null(strstr(crisp_error_message(), "DE 1"));
    /* not IGES at all */
    assert_int_equal(crisp_read_iges_mem("x.igs", "hello\n", 6, NULL, &m), CRISP_ERR_PARSE);
    assert_int_equal(crisp_read_iges_mem("x.igs", "", 0, NULL, &m), CRISP_ERR_PARSE);
    free(text);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_arc_with_transform),
        cmocka_unit_test(test_transform_chain),
        cmocka_unit_test(test_conic_ellipse),
        cmocka_unit_test(test_parametric_spline_curve),
        cmocka_unit_test(test_parametric_spline_surface),
        cmocka_unit_test(test_revolution_with_pcurves),
        cmocka_unit_test(test_ruled_and_tabulated),
        cmocka_unit_test(test_bounded_plane),
        cmocka_unit_test(test_brep_face_projected),
        cmocka_unit_test(test_bspline_parameter_range),
        cmocka_unit_test(test_pcurve_fallback_to_projection),
        cmocka_unit_test(test_lenient_records),
        cmocka_unit_test(test_unsupported_counted),
        cmocka_unit_test(test_malformed),
        cmocka_unit_test(test_deep_nesting),
        cmocka_unit_test(test_unsupported_face_skipped),
        cmocka_unit_test(test_truncated_and_garbage),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
