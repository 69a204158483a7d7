/* The STEP reader on what real files bring beyond the bundled models: B-spline forms with implied
 * knots (QUASI_UNIFORM_, UNIFORM_, BEZIER_ surfaces and curves, also rational complex entities),
 * CURVE_BOUNDED_SURFACEs and bare surfaces in a GEOMETRIC_SET, a full sphere given as a face
 * without bounds, a RECTANGULAR_TRIMMED_SURFACE alone, lenient Part 21 syntax (section keywords in
 * any case, a lone quote inside a string, an entity number out of range, identical duplicate
 * instances, bare numbers as trim parameters), one bad face or shell skipped with a note while the
 * rest loads, and clear errors for files that hold nothing crisp can draw.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/step/step_internal.h"
#include "step/test_step_util.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define HEAD                                                                                       \
    "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('test'),'2;1');\n"                                  \
    "FILE_NAME('t','',(''),(''),'','','');\nFILE_SCHEMA(('AUTOMOTIVE_DESIGN'));\nENDSEC;\nDATA;\n"
#define TAIL "ENDSEC;\nEND-ISO-10303-21;\n"

static crisp_status read_str(const char *text, crisp_model **m)
{
    step_read_stats st = {.verify = 1};
    crisp_status s = crisp__step_read_mem("snippet.stp", text, strlen(text), NULL, m, &st);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    return s;
}

static char *replace(const char *text, const char *from, const char *to)
{
    const char *at = strstr(text, from);
    assert_non_null(at);
    size_t n = strlen(text) - strlen(from) + strlen(to);
    char *out = malloc(n + 1);
    size_t k = (size_t)(at - text);
    memcpy(out, text, k);
    strcpy(out + k, to);
    strcat(out, at + strlen(from));
    return out;
}

static void assert_knots(const double *k, const double *want, int n)
{
    for (int i = 0; i < n; i++) {
        if (k[i] != want[i]) fprintf(stderr, "knot %d: %g, expected %g\n", i, k[i], want[i]);
        assert_true(k[i] == want[i]);
    }
}

static int has_note(const crisp_model *m, const char *needle)
{
    for (int k = 0; k < m->skip_count; k++)
        if (strstr(m->skips[k].what, needle)) return 1;
    return 0;
}

/* Points of a 4 x 2 net: x = i, y = j, z = i^2 (a parabolic cylinder). */
#define NET                                                                                        \
    "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=CARTESIAN_POINT('',(0.,1.,0.));\n"                     \
    "#3=CARTESIAN_POINT('',(1.,0.,1.));\n#4=CARTESIAN_POINT('',(1.,1.,1.));\n"                     \
    "#5=CARTESIAN_POINT('',(2.,0.,4.));\n#6=CARTESIAN_POINT('',(2.,1.,4.));\n"                     \
    "#7=CARTESIAN_POINT('',(3.,0.,9.));\n#8=CARTESIAN_POINT('',(3.,1.,9.));\n"                     \
    "#9=CARTESIAN_POINT('',(4.,0.,16.));\n#10=CARTESIAN_POINT('',(4.,1.,16.));\n"

/* ISO 10303-42's implied knots, read from bare surfaces of a geometric set. */
static void test_implied_knots(void **state)
{
    (void)state;
    static const char text[] = HEAD NET
        "#20=QUASI_UNIFORM_SURFACE('',2,1,((#1,#2),(#3,#4),(#5,#6),(#7,#8)),.UNSPECIFIED.,.F.,.F.,."
        "U.);\n"
        "#21=UNIFORM_SURFACE('',1,1,((#1,#2),(#3,#4),(#5,#6)),.UNSPECIFIED.,.F.,.F.,.U.);\n"
        "#22=BEZIER_SURFACE('',2,1,((#1,#2),(#3,#4),(#5,#6),(#7,#8),(#9,#10)),.UNSPECIFIED.,.F.,.F."
        ",.U.);\n"
        "#23=(BOUNDED_SURFACE() "
        "B_SPLINE_SURFACE(2,1,((#1,#2),(#3,#4),(#5,#6),(#7,#8)),.UNSPECIFIED.,.F.,.F.,.F.)\n"
        " QUASI_UNIFORM_SURFACE() GEOMETRIC_REPRESENTATION_ITEM()\n"
        " RATIONAL_B_SPLINE_SURFACE(((1.,1.),(2.,2.),(2.,2.),(1.,1.))) REPRESENTATION_ITEM('') "
        "SURFACE());\n"
        "#30=GEOMETRIC_SET('',(#20,#21,#22,#23));\n" TAIL;
    crisp_model *m;
    assert_int_equal(read_str(text, &m), CRISP_OK);
    assert_int_equal(m->face_count, 4);
    const crisp_surface *q = m->faces[0].surface, *u = m->faces[1].surface,
                        *b = m->faces[2].surface;
    const crisp_surface *rq = m->faces[3].surface;
    assert_knots(q->knots_u, (const double[]){0, 0, 0, 1, 2, 2, 2}, 7);
    assert_knots(q->knots_v, (const double[]){0, 0, 1, 1}, 4);
    assert_knots(u->knots_u, (const double[]){-1, 0, 1, 2, 3}, 5);
    assert_knots(b->knots_u, (const double[]){0, 0, 0, 1, 1, 2, 2, 2}, 8);
    assert_knots(rq->knots_u, (const double[]){0, 0, 0, 1, 2, 2, 2}, 7);
    assert_true(rq->rational && !q->rational);
    /* The Bezier form interpolates its segment ends: (2, y, 4) at u = 1. */
    double p[3];
    crisp_surface_eval(b, 1, 0.5, p);
    assert_true(fabs(p[0] - 2) < 1e-12 && fabs(p[1] - 0.5) < 1e-12 && fabs(p[2] - 4) < 1e-12);
    /* Every face is the whole of its domain (no loops). */
    for (int f = 0; f < 4; f++)
        assert_int_equal(m->faces[f].loop_count, 0);
    crisp_model_destroy(m);
    /* A Bezier form whose point count does not fit its degree is refused, by name. */
    char *bad =
        replace(text, "#22=BEZIER_SURFACE('',2,1,((#1,#2),(#3,#4),(#5,#6),(#7,#8),(#9,#10))",
                "#22=BEZIER_SURFACE('',2,1,((#1,#2),(#3,#4),(#5,#6),(#7,#8))");
    assert_int_equal(read_str(bad, &m), CRISP_OK);
    assert_int_equal(m->face_count, 3);
    assert_true(has_note(m, "#22"));
    crisp_model_destroy(m);
    free(bad);
}

/* A plane z = 0 bounded by a CURVE_BOUNDED_SURFACE: a 2 x 1 rectangle whose sides are pcurves
 * (lines trimmed by bare numbers, one segment used against its sense), with a square hole whose
 * sides are quasi-uniform 3D curves without pcurves (projected). */
static const char bounded[] =
    HEAD "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,"
         "0.));\n"
         "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=PLANE('',#4);\n"
         "#9=(GEOMETRIC_REPRESENTATION_CONTEXT(2) PARAMETRIC_REPRESENTATION_CONTEXT() "
         "REPRESENTATION_CONTEXT('',''));\n"
         "#10=DIRECTION('',(1.,0.));\n#11=DIRECTION('',(0.,1.));\n#12=VECTOR('',#10,1.);\n#13="
         "VECTOR('',#11,1.);\n"
         "#20=CARTESIAN_POINT('',(0.,0.));\n#21=LINE('',#20,#12);\n#22=TRIMMED_CURVE('',#21,(0.),("
         "2.),.T.,.PARAMETER.);\n"
         "#23=DEFINITIONAL_REPRESENTATION('',(#22),#9);\n#24=PCURVE('',#5,#23);\n#25=COMPOSITE_"
         "CURVE_SEGMENT(.CONTINUOUS.,.T.,#24);\n"
         "#30=CARTESIAN_POINT('',(2.,0.));\n#31=LINE('',#30,#13);\n#32=TRIMMED_CURVE('',#31,(0.),("
         "1.),.T.,.PARAMETER.);\n"
         "#33=(DEFINITIONAL_REPRESENTATION() REPRESENTATION('',(#32),#9) SHAPE_REPRESENTATION());\n"
         "#34=PCURVE('',#5,#33);\n#35=COMPOSITE_CURVE_SEGMENT(.CONTINUOUS.,.T.,#34);\n"
         "#40=CARTESIAN_POINT('',(0.,1.));\n#41=LINE('',#40,#12);\n#42=TRIMMED_CURVE('',#41,(0.),("
         "2.),.T.,.PARAMETER.);\n"
         "#43=DEFINITIONAL_REPRESENTATION('',(#42),#9);\n#44=PCURVE('',#5,#43);\n#45=COMPOSITE_"
         "CURVE_SEGMENT(.CONTINUOUS.,.F.,#44);\n"
         "#50=LINE('',#20,#13);\n#51=TRIMMED_CURVE('',#50,(PARAMETER_VALUE(1.)),(PARAMETER_VALUE(0."
         ")),.F.,.PARAMETER.);\n"
         "#52=DEFINITIONAL_REPRESENTATION('',(#51),#9);\n#53=PCURVE('',#5,#52);\n#54=COMPOSITE_"
         "CURVE_SEGMENT(.CONTINUOUS.,.T.,#53);\n"
         "#60=OUTER_BOUNDARY_CURVE('',(#25,#35,#45,#54),.F.);\n"
         "#70=CARTESIAN_POINT('',(0.5,0.25,0.));\n#71=CARTESIAN_POINT('',(0.5,0.75,0.));\n"
         "#72=CARTESIAN_POINT('',(1.,0.75,0.));\n#73=CARTESIAN_POINT('',(1.,0.25,0.));\n"
         "#74=QUASI_UNIFORM_CURVE('',1,(#70,#71,#72),.POLYLINE_FORM.,.F.,.U.);\n"
         "#75=QUASI_UNIFORM_CURVE('',1,(#72,#73,#70),.POLYLINE_FORM.,.F.,.U.);\n"
         "#76=(BOUNDED_CURVE() CURVE() GEOMETRIC_REPRESENTATION_ITEM() REPRESENTATION_ITEM('') "
         "SURFACE_CURVE(#74,(#5),.CURVE_3D.));\n"
         "#77=COMPOSITE_CURVE_SEGMENT(.CONTINUOUS.,.T.,#76);\n#78=COMPOSITE_CURVE_SEGMENT(."
         "CONTINUOUS.,.T.,#75);\n"
         "#79=BOUNDARY_CURVE('',(#77,#78),.F.);\n"
         "#80=CURVE_BOUNDED_SURFACE('',#5,(#60,#79),.F.);\n#81=GEOMETRIC_SET('',(#80));\n"
         "#82=GEOMETRICALLY_BOUNDED_SURFACE_SHAPE_REPRESENTATION('',(#81),#9);\n" TAIL;

static void test_curve_bounded_surface(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(read_str(bounded, &m), CRISP_OK);
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->skip_count, 0);
    const crisp_face *f = &m->faces[0];
    assert_int_equal(f->loop_count, 2);
    loop_check c;
    check_model_loops(m, 1e-6, 1e-9, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    /* Outer 2 x 1 (area 2), hole 0.5 x 0.5 (area -0.25) in the plane's (x, y). */
    int outer = f->loops[0].is_outer ? 0 : 1;
    assert_true(fabs(crisp_trim_loop_signed_area(&f->loops[outer]) - 2) < 1e-9);
    assert_true(fabs(crisp_trim_loop_signed_area(&f->loops[1 - outer]) + 0.25) < 1e-9);
    crisp_model_destroy(m);
    /* A segment with the wrong same_sense (as Pro/ENGINEER writes them) is turned round. */
    char *flip = replace(bounded, "#35=COMPOSITE_CURVE_SEGMENT(.CONTINUOUS.,.T.,#34)",
                         "#35=COMPOSITE_CURVE_SEGMENT(.CONTINUOUS.,.F.,#34)");
    step_read_stats st = {0};
    assert_int_equal(crisp__step_read_mem("snippet.stp", flip, strlen(flip), NULL, &m, &st),
                     CRISP_OK);
    assert_int_equal(st.flipped_segments, 1);
    assert_int_equal(m->face_count, 1);
    outer = m->faces[0].loops[0].is_outer ? 0 : 1;
    assert_true(fabs(crisp_trim_loop_signed_area(&m->faces[0].loops[outer]) - 2) < 1e-9);
    crisp_model_destroy(m);
    free(flip);
    /* A segment on an unbounded line cannot bound anything: the face is dropped, by name. */
    char *bad = replace(bounded, "#24=PCURVE('',#5,#23)",
                        "#24=PCURVE('',#5,#91);\n#91=DEFINITIONAL_REPRESENTATION('',(#21),#9)");
    assert_int_not_equal(read_str(bad, &m), CRISP_OK);
    assert_non_null(strstr(crisp_error_message(), "unbounded curve"));
    assert_non_null(strstr(crisp_error_message(), "#24 (line"));
    free(bad);
}

/* Even-odd test of uv against every loop of the face (polylines of 400 points per curve). */
static int inside_face(const crisp_face *f, const double uv[2])
{
    int in = 0;
    for (int l = 0; l < f->loop_count; l++)
        for (int k = 0; k < f->loops[l].curve_count; k++) {
            const crisp_curve *c = f->loops[l].curves[k];
            double t0, t1, a[2], b[2];
            crisp_curve_domain(c, &t0, &t1);
            crisp_curve_eval(c, t0, a);
            for (int i = 1; i <= 400; i++) {
                crisp_curve_eval(c, t0 + (t1 - t0) * i / 400, b);
                if ((a[1] > uv[1]) != (b[1] > uv[1]) &&
                    uv[0] < a[0] + (b[0] - a[0]) * (uv[1] - a[1]) / (b[1] - a[1]))
                    in ^= 1;
                a[0] = b[0], a[1] = b[1];
            }
        }
    return in;
}

/* On the unit sphere, curve-bounded by 3D curves only: the cap above z = 0.5 (a circle running
 * counter-clockwise seen from +z: the pole on its left), the cap below it (the same circle run
 * the other way), and the quarter z > 0, y < 0 bounded by a meridian over the north pole (its
 * (u, v) image jumps by pi there) and half the equator. Every sample of each face's domain away
 * from the boundary is inside exactly when its point is in the region. */
static void test_sphere_caps_and_pole_arc(void **state)
{
    (void)state;
    static const char text[] =
        HEAD "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1."
             ",0.,0.));\n"
             "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=SPHERICAL_SURFACE('',#4,1.);\n"
             "#10=CARTESIAN_POINT('',(0.,0.,0.5));\n#11=AXIS2_PLACEMENT_3D('',#10,#2,#3);\n#12="
             "CIRCLE('',#11,0.866025403784439);\n"
             "#13=TRIMMED_CURVE('',#12,(PARAMETER_VALUE(0.)),(PARAMETER_VALUE(6.283185307179586)),."
             "T.,.PARAMETER.);\n"
             "#14=SURFACE_CURVE('',#13,(#5),.CURVE_3D.);\n"
             "#15=COMPOSITE_CURVE_SEGMENT(.CONTINUOUS.,.T.,#14);\n#16=OUTER_BOUNDARY_CURVE('',(#15)"
             ",.F.);\n"
             "#17=CURVE_BOUNDED_SURFACE('north',#5,(#16),.F.);\n"
             "#20=COMPOSITE_CURVE_SEGMENT(.CONTINUOUS.,.F.,#14);\n#21=OUTER_BOUNDARY_CURVE('',(#20)"
             ",.F.);\n"
             "#22=CURVE_BOUNDED_SURFACE('south',#5,(#21),.F.);\n"
             "#30=DIRECTION('',(0.,-1.,0.));\n#31=AXIS2_PLACEMENT_3D('',#1,#30,#3);\n#32=CIRCLE('',"
             "#31,1.);\n"
             "#33=TRIMMED_CURVE('',#32,(PARAMETER_VALUE(0.)),(PARAMETER_VALUE(3.141592653589793)),."
             "T.,.PARAMETER.);\n"
             "#34=CIRCLE('',#4,1.);\n"
             "#35=TRIMMED_CURVE('',#34,(PARAMETER_VALUE(3.141592653589793)),(PARAMETER_VALUE(6."
             "283185307179586)),.T.,.PARAMETER.);\n"
             "#36=COMPOSITE_CURVE_SEGMENT(.CONTINUOUS.,.T.,#33);\n#37=COMPOSITE_CURVE_SEGMENT(."
             "CONTINUOUS.,.T.,#35);\n"
             "#38=OUTER_BOUNDARY_CURVE('',(#36,#37),.F.);\n#39=CURVE_BOUNDED_SURFACE('quarter',#5,("
             "#38),.F.);\n"
             "#40=GEOMETRIC_SET('',(#17,#22,#39));\n" TAIL;
    crisp_model *m;
    assert_int_equal(read_str(text, &m), CRISP_OK);
    assert_int_equal(m->face_count, 3);
    assert_int_equal(m->skip_count, 0);
    loop_check c;
    check_model_loops(m, 1e-6, 1e-9, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    for (int f = 0; f < 3; f++) {
        const crisp_face *face = &m->faces[f];
        double d[4];
        crisp_surface_domain(face->surface, d);
        int checked = 0;
        for (int i = 1; i < 60; i++)
            for (int j = 1; j < 60; j++) {
                double uv[2] = {d[0] + (d[1] - d[0]) * i / 60, d[2] + (d[3] - d[2]) * j / 60}, p[3];
                crisp_surface_eval(face->surface, uv[0], uv[1], p);
                int want;
                if (f < 2) {
                    if (fabs(p[2] - 0.5) < 0.05) continue;
                    want = (p[2] > 0.5) == (f == 0);
                } else {
                    if (fabs(p[2]) < 0.05 || fabs(p[1]) < 0.05) continue;
                    want = p[2] > 0 && p[1] < 0;
                }
                /* A point reached at a pole or seam from outside the NURBS domain's region is
                 * still the same point: the region test is on the surface point. */
                assert_int_equal(inside_face(face, uv), want);
                checked++;
            }
        assert_true(checked > 500);
    }
    crisp_model_destroy(m);
}

/* A full sphere (a face without bounds; another with only a vertex loop) and a quarter
 * cylinder given as a RECTANGULAR_TRIMMED_SURFACE in degrees, alone in a geometric set. */
static void test_whole_sphere_and_trimmed_surface(void **state)
{
    (void)state;
    static const char text[] =
        HEAD "#1=CARTESIAN_POINT('',(1.,2.,3.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1."
             ",0.,0.));\n"
             "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=SPHERICAL_SURFACE('',#4,2.);\n#6=ADVANCED_"
             "FACE('',(),#5,.T.);\n"
             "#7=CARTESIAN_POINT('',(1.,2.,5.));\n#8=VERTEX_POINT('',#7);\n#9=VERTEX_LOOP('',#8);\n"
             "#10=FACE_BOUND('',#9,.T.);\n#11=ADVANCED_FACE('',(#10),#5,.F.);\n#12=OPEN_SHELL('',(#"
             "6,#11));\n"
             "#20=CYLINDRICAL_SURFACE('',#4,1.);\n#21=RECTANGULAR_TRIMMED_SURFACE('',#20,0.,90.,-1."
             ",1.,.T.,.T.);\n"
             "#22=GEOMETRIC_SET('',(#21));\n"
             "#60=(NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.));\n"
             "#61=PLANE_ANGLE_MEASURE_WITH_UNIT(PLANE_ANGLE_MEASURE(0.0174532925199433),#60);\n"
             "#62=DIMENSIONAL_EXPONENTS(0.,0.,0.,0.,0.,0.,0.);\n"
             "#63=(CONVERSION_BASED_UNIT('DEGREE',#61) NAMED_UNIT(#62) PLANE_ANGLE_UNIT());\n"
             "#64=(LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.));\n"
             "#65=(GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNIT_ASSIGNED_CONTEXT((#64,#63)) "
             "REPRESENTATION_CONTEXT('',''));\n" TAIL;
    crisp_model *m;
    assert_int_equal(read_str(text, &m), CRISP_OK);
    assert_int_equal(m->face_count, 3);
    for (int f = 0; f < 2; f++) {
        assert_int_equal(m->faces[f].loop_count, 0);
        assert_int_equal(m->faces[f].reversed, f == 1);
        const crisp_surface *s = m->faces[f].surface;
        double d[4], lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
        crisp_surface_domain(s, d);
        for (int i = 0; i <= 40; i++)
            for (int j = 0; j <= 40; j++) {
                double p[3];
                crisp_surface_eval(s, d[0] + (d[1] - d[0]) * i / 40, d[2] + (d[3] - d[2]) * j / 40,
                                   p);
                assert_true(fabs(sqrt((p[0] - 1) * (p[0] - 1) + (p[1] - 2) * (p[1] - 2) +
                                      (p[2] - 3) * (p[2] - 3)) -
                                 2) < 1e-9);
                for (int k = 0; k < 3; k++)
                    lo[k] = fmin(lo[k], p[k]), hi[k] = fmax(hi[k], p[k]);
            }
        /* The whole sphere: the samples reach both poles and all round the equator. */
        assert_true(fabs(lo[2] - 1) < 1e-9 && fabs(hi[2] - 5) < 1e-9);
        assert_true(fabs(lo[0] + 1) < 1e-6 && fabs(hi[0] - 3) < 1e-6 && fabs(lo[1]) < 1e-6 &&
                    fabs(hi[1] - 4) < 1e-6);
    }
    /* The quarter cylinder: x, y in the first quadrant around (1, 2), z in [2, 4]. */
    const crisp_surface *s = m->faces[2].surface;
    double d[4];
    crisp_surface_domain(s, d);
    for (int i = 0; i <= 20; i++)
        for (int j = 0; j <= 4; j++) {
            double p[3];
            crisp_surface_eval(s, d[0] + (d[1] - d[0]) * i / 20, d[2] + (d[3] - d[2]) * j / 4, p);
            assert_true(fabs(hypot(p[0] - 1, p[1] - 2) - 1) < 1e-9);
            assert_true(p[0] > 1 - 1e-9 && p[1] > 2 - 1e-9 && p[2] > 2 - 1e-9 && p[2] < 4 + 1e-9);
        }
    double a[3], b[3];
    crisp_surface_eval(s, d[1], d[2], a);
    crisp_surface_eval(s, d[0], d[3], b);
    assert_true(fabs(a[0] - 1) < 1e-9 && fabs(a[1] - 3) < 1e-9 && fabs(a[2] - 2) < 1e-9);
    assert_true(fabs(b[0] - 2) < 1e-9 && fabs(b[1] - 2) < 1e-9 && fabs(b[2] - 4) < 1e-9);
    crisp_model_destroy(m);
}

/* A unit square on z = 0 as an ADVANCED_FACE, repeated as face #50 and #51 in two shells. */
static const char squares[] = HEAD
    "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,0.));"
    "\n"
    "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=PLANE('',#4);\n"
    "#10=CARTESIAN_POINT('',(0.,0.,0.));\n#11=CARTESIAN_POINT('',(1.,0.,0.));\n"
    "#12=CARTESIAN_POINT('',(1.,1.,0.));\n#13=CARTESIAN_POINT('',(0.,1.,0.));\n"
    "#14=VERTEX_POINT('',#10);\n#15=VERTEX_POINT('',#11);\n#16=VERTEX_POINT('',#12);\n#17=VERTEX_"
    "POINT('',#13);\n"
    "#20=DIRECTION('',(1.,0.,0.));\n#21=VECTOR('',#20,1.);\n#22=LINE('',#10,#21);\n"
    "#23=EDGE_CURVE('',#14,#15,#22,.T.);\n#24=DIRECTION('',(0.,1.,0.));\n#25=VECTOR('',#24,1.);\n"
    "#26=LINE('',#11,#25);\n#27=EDGE_CURVE('',#15,#16,#26,.T.);\n#28=LINE('',#13,#21);\n"
    "#29=EDGE_CURVE('',#17,#16,#28,.T.);\n#30=LINE('',#10,#25);\n#31=EDGE_CURVE('',#14,#17,#30,.T.)"
    ";\n"
    "#32=ORIENTED_EDGE('',*,*,#23,.T.);\n#33=ORIENTED_EDGE('',*,*,#27,.T.);\n"
    "#34=ORIENTED_EDGE('',*,*,#29,.F.);\n#35=ORIENTED_EDGE('',*,*,#31,.F.);\n"
    "#36=EDGE_LOOP('',(#32,#33,#34,#35));\n#37=FACE_OUTER_BOUND('',#36,.T.);\n"
    "#38=EDGE_LOOP('',(#32,#33,#34,#35));\n#39=FACE_OUTER_BOUND('',#38,.T.);\n"
    "#50=ADVANCED_FACE('',(#37),#5,.T.);\n#51=ADVANCED_FACE('',(#39),#5,.F.);\n"
    "#52=OPEN_SHELL('',(#50));\n#53=OPEN_SHELL('',(#51));\n" TAIL;

/* Real-file syntax: section keywords in any case, a lone quote in a string, an entity number out
 * of range (only the face using it is lost), identical duplicates, a broken shell. */
static void test_lenient_syntax_and_partial_loss(void **state)
{
    (void)state;
    crisp_model *m;
    char *a = replace(squares, "HEADER;", "Header;");
    char *b = replace(a, "ENDSEC;\nDATA;", "EndSec;\ndata;");
    char *c =
        replace(b, "#52=OPEN_SHELL('',(#50))", "#52=OPEN_SHELL('it\\X0\\'s ok, really',(#50))");
    char *d = replace(c, "#38=EDGE_LOOP('',(#32,#33,#34,#35))",
                      "#38=EDGE_LOOP('',(#32,#33,#34,#18446744073709551615))");
    char *e = replace(d, "#53=OPEN_SHELL('',(#51));",
                      "#53=OPEN_SHELL('',(#51));\n#24=DIRECTION('',(0.,1.,0.));\n"
                      "#54=CLOSED_SHELL('',#50);");
    assert_int_equal(read_str(e, &m), CRISP_OK);
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces[0].source_id, 50);
    assert_true(fabs(crisp_trim_loop_signed_area(&m->faces[0].loops[0]) - 1) < 1e-12);
    assert_true(has_note(m, "face #51 dropped"));
    assert_true(has_note(m, "out of range"));
    assert_true(has_note(m, "defined twice with identical text"));
    assert_true(has_note(m, "shell #54 unreadable"));
    crisp_model_destroy(m);
    /* An edge whose LINE runs from its end vertex to its start although same_sense is .T.
     * (trj9_ap209-mp.stp): the sense is turned round and the face loads whole. */
    char *h =
        replace(squares, "#22=LINE('',#10,#21)",
                "#22=LINE('',#11,#81);\n#80=DIRECTION('',(-1.,0.,0.));\n#81=VECTOR('',#80,1.)");
    step_read_stats hs = {0};
    assert_int_equal(crisp__step_read_mem("snippet.stp", h, strlen(h), NULL, &m, &hs), CRISP_OK);
    assert_int_equal(m->face_count, 2);
    assert_int_equal(hs.flipped_segments, 2); /* the edge is used by both faces */
    for (int k = 0; k < 2; k++)
        assert_true(fabs(fabs(crisp_trim_loop_signed_area(&m->faces[k].loops[0])) - 1) < 1e-12);
    crisp_model_destroy(m);
    free(h);
    /* When every face fails, the file fails with the reason. */
    char *f =
        replace(d, "#36=EDGE_LOOP('',(#32,#33,#34,#35))", "#36=EDGE_LOOP('',(#32,#33,#34,#99))");
    assert_int_not_equal(read_str(f, &m), CRISP_OK);
    assert_non_null(strstr(crisp_error_message(), "#99, which is not defined"));
    /* Two different definitions of one entity stay an error. */
    char *g = replace(squares, "#53=OPEN_SHELL('',(#51));",
                      "#53=OPEN_SHELL('',(#51));\n#24=DIRECTION('',(1.,1.,0.));");
    assert_int_not_equal(read_str(g, &m), CRISP_OK);
    assert_non_null(strstr(crisp_error_message(), "defined twice"));
    free(a), free(b), free(c), free(d), free(e), free(f), free(g);
}

/* A small part beside a huge one: a cylinder of radius 1 (a band between two circles, the top
 * one starting at another angle) and a plate 2e6 wide. The model's tolerance (1e-5 of 2.8e6 = 28)
 * would swallow the cylinder; its face gets a tolerance from its own size. */
static void test_small_face_in_huge_model(void **state)
{
    (void)state;
    static const char text[] = HEAD
        "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,"
        "0.));\n"
        "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=CYLINDRICAL_SURFACE('',#4,1.);\n"
        "#10=CARTESIAN_POINT('',(1.,0.,0.));\n#11=CARTESIAN_POINT('',(0.,1.,2.));\n"
        "#12=VERTEX_POINT('',#10);\n#13=VERTEX_POINT('',#11);\n#20=CIRCLE('',#4,1.);\n"
        "#21=EDGE_CURVE('',#12,#12,#20,.T.);\n#30=CARTESIAN_POINT('',(0.,0.,2.));\n"
        "#31=AXIS2_PLACEMENT_3D('',#30,#2,#3);\n#32=CIRCLE('',#31,1.);\n#33=EDGE_CURVE('',#13,#13,#"
        "32,.T.);\n"
        "#40=ORIENTED_EDGE('',*,*,#21,.T.);\n#41=ORIENTED_EDGE('',*,*,#33,.F.);\n"
        "#42=EDGE_LOOP('',(#40));\n#43=EDGE_LOOP('',(#41));\n#44=FACE_BOUND('',#42,.T.);\n#45=FACE_"
        "BOUND('',#43,.T.);\n"
        "#46=ADVANCED_FACE('',(#44,#45),#5,.T.);\n"
        "#50=CARTESIAN_POINT('',(-1.E6,-1.E6,-1.));\n#51=CARTESIAN_POINT('',(1.E6,-1.E6,-1.));\n"
        "#52=CARTESIAN_POINT('',(1.E6,1.E6,-1.));\n#53=CARTESIAN_POINT('',(-1.E6,1.E6,-1.));\n"
        "#54=VERTEX_POINT('',#50);\n#55=VERTEX_POINT('',#51);\n#56=VERTEX_POINT('',#52);\n#57="
        "VERTEX_POINT('',#53);\n"
        "#58=DIRECTION('',(1.,0.,0.));\n#59=VECTOR('',#58,1.);\n#60=DIRECTION('',(0.,1.,0.));\n#61="
        "VECTOR('',#60,1.);\n"
        "#62=LINE('',#50,#59);\n#63=LINE('',#51,#61);\n#64=LINE('',#53,#59);\n#65=LINE('',#50,#61);"
        "\n"
        "#66=EDGE_CURVE('',#54,#55,#62,.T.);\n#67=EDGE_CURVE('',#55,#56,#63,.T.);\n"
        "#68=EDGE_CURVE('',#57,#56,#64,.T.);\n#69=EDGE_CURVE('',#54,#57,#65,.T.);\n"
        "#70=ORIENTED_EDGE('',*,*,#66,.T.);\n#71=ORIENTED_EDGE('',*,*,#67,.T.);\n"
        "#72=ORIENTED_EDGE('',*,*,#68,.F.);\n#73=ORIENTED_EDGE('',*,*,#69,.F.);\n"
        "#74=EDGE_LOOP('',(#70,#71,#72,#73));\n#75=FACE_OUTER_BOUND('',#74,.T.);\n"
        "#76=CARTESIAN_POINT('',(0.,0.,-1.));\n#77=AXIS2_PLACEMENT_3D('',#76,#2,#3);\n#78=PLANE('',"
        "#77);\n"
        "#79=ADVANCED_FACE('',(#75),#78,.T.);\n#80=OPEN_SHELL('',(#46,#79));\n" TAIL;
    crisp_model *m;
    step_read_stats st = {.verify = 1};
    assert_int_equal(crisp__step_read_mem("snippet.stp", text, strlen(text), NULL, &m, &st),
                     CRISP_OK);
    assert_int_equal(m->face_count, 2);
    assert_true(st.tol > 10);
    loop_check c;
    check_model_loops(m, 1e-6, 1e-9, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    /* The cylinder's trims follow its circles to 1e-4 of its size (z stays 0 or 2 along each
     * circle piece), a precision the model's tolerance could not give. */
    const crisp_face *f = m->faces[0].source_id == 46 ? &m->faces[0] : &m->faces[1];
    assert_int_equal(f->loop_count, 1);
    for (int k = 0; k < f->loops[0].curve_count; k++) {
        const crisp_curve *cv = f->loops[0].curves[k];
        double t0, t1, a[2], b[2], pa[3], pb[3];
        crisp_curve_domain(cv, &t0, &t1);
        crisp_curve_eval(cv, t0, a);
        crisp_curve_eval(cv, t1, b);
        crisp_surface_eval(f->surface, a[0], a[1], pa);
        crisp_surface_eval(f->surface, b[0], b[1], pb);
        int circle = fabs(pa[2] - pb[2]) < 1e-9; /* else a seam segment */
        for (int i = 0; i <= 50; i++) {
            double uv[2], p[3];
            crisp_curve_eval(cv, t0 + (t1 - t0) * i / 50, uv);
            crisp_surface_eval(f->surface, uv[0], uv[1], p);
            assert_true(fabs(hypot(p[0], p[1]) - 1) < 1e-6);
            assert_true(p[2] > -1e-6 && p[2] < 2 + 1e-6);
            if (circle) assert_true(fabs(p[2] - pa[2]) < 1e-4);
        }
    }
    assert_true(fabs(fabs(crisp_trim_loop_signed_area(&f->loops[0])) - 4 * M_PI) < 1e-2);
    crisp_model_destroy(m);
}

/* Plane faces bounded by a hyperbola arc (x^2/4 - y^2 = 1, t in [-1, 1]) and by a parabola arc
 * (y^2 = 4 x, focal distance 1, t in [-1, 1]), each closed by a line: the trims lie on the conics.
 */
static void test_hyperbola_parabola(void **state)
{
    (void)state;
    static const char text[] =
        HEAD "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1."
             ",0.,0.));\n"
             "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=PLANE('',#4);\n#6=DIRECTION('',(0.,1.,0.));"
             "\n#7=VECTOR('',#6,1.);\n"
             "#10=HYPERBOLA('',#4,2.,1.);\n"
             "#11=CARTESIAN_POINT('',(3.0861612696304874,-1.1752011936438014,0.));\n"
             "#12=CARTESIAN_POINT('',(3.0861612696304874,1.1752011936438014,0.));\n"
             "#13=VERTEX_POINT('',#11);\n#14=VERTEX_POINT('',#12);\n#15=EDGE_CURVE('',#13,#14,#10,."
             "T.);\n"
             "#16=LINE('',#11,#7);\n#17=EDGE_CURVE('',#14,#13,#16,.F.);\n"
             "#18=ORIENTED_EDGE('',*,*,#15,.T.);\n#19=ORIENTED_EDGE('',*,*,#17,.T.);\n#20=EDGE_"
             "LOOP('',(#18,#19));\n"
             "#21=FACE_OUTER_BOUND('',#20,.T.);\n#22=ADVANCED_FACE('',(#21),#5,.T.);\n"
             "#30=PARABOLA('',#4,1.);\n#31=CARTESIAN_POINT('',(1.,-2.,0.));\n#32=CARTESIAN_POINT(''"
             ",(1.,2.,0.));\n"
             "#33=VERTEX_POINT('',#31);\n#34=VERTEX_POINT('',#32);\n#35=EDGE_CURVE('',#33,#34,#30,."
             "T.);\n"
             "#36=LINE('',#31,#7);\n#37=EDGE_CURVE('',#34,#33,#36,.F.);\n"
             "#38=ORIENTED_EDGE('',*,*,#35,.T.);\n#39=ORIENTED_EDGE('',*,*,#37,.T.);\n#40=EDGE_"
             "LOOP('',(#38,#39));\n"
             "#41=FACE_OUTER_BOUND('',#40,.T.);\n#42=ADVANCED_FACE('',(#41),#5,.T.);\n"
             "#50=OPEN_SHELL('',(#22,#42));\n" TAIL;
    crisp_model *m;
    assert_int_equal(read_str(text, &m), CRISP_OK);
    assert_int_equal(m->face_count, 2);
    loop_check c;
    check_model_loops(m, 1e-6, 1e-9, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    for (int f = 0; f < 2; f++) {
        const crisp_face *face = &m->faces[f];
        int hyper = face->source_id == 22, on_conic = 0;
        for (int k = 0; k < face->loops[0].curve_count; k++) {
            const crisp_curve *cv = face->loops[0].curves[k];
            double t0, t1, a[2], b[2], mid[2];
            crisp_curve_domain(cv, &t0, &t1);
            crisp_curve_eval(cv, t0, a);
            crisp_curve_eval(cv, t1, b);
            crisp_curve_eval(cv, 0.5 * (t0 + t1), mid);
            if (fabs(a[0] - mid[0]) < 1e-9 && fabs(b[0] - mid[0]) < 1e-9)
                continue; /* the closing line */
            on_conic++;
            for (int i = 0; i <= 50; i++) {
                double uv[2], p[3];
                crisp_curve_eval(cv, t0 + (t1 - t0) * i / 50, uv);
                crisp_surface_eval(face->surface, uv[0], uv[1], p);
                double e = hyper ? p[0] * p[0] / 4 - p[1] * p[1] - 1 : p[1] * p[1] - 4 * p[0];
                if (!(fabs(e) < 1e-9))
                    fprintf(stderr, "face %d: (%g, %g) off by %g\n", face->source_id, p[0], p[1],
                            e);
                assert_true(fabs(e) < 1e-9);
            }
        }
        assert_int_equal(on_conic, 1);
    }
    crisp_model_destroy(m);
}

/* Files with nothing crisp draws say what they hold. */
static void test_nothing_drawable(void **state)
{
    (void)state;
    static const char mesh[] =
        HEAD "#1=CARTESIAN_POINT('',(0.,0.,0.));\n"
             "#2=COORDINATES_LIST('',3,((0.,0.,0.),(1.,0.,0.),(0.,1.,0.)));\n"
             "#3=TRIANGULATED_FACE('',#2,0,(),$,(1,2,3),((1,2,3)));\n" TAIL;
    static const char wire[] = HEAD
        "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(1.,0.,0.));\n#3=VECTOR('',#2,1.);\n"
        "#4=LINE('',#1,#3);\n#5=TRIMMED_CURVE('',#4,(0.),(1.),.T.,.PARAMETER.);\n"
        "#6=GEOMETRIC_CURVE_SET('',(#5));\n" TAIL;
    static const char none[] =
        HEAD "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=PRODUCT('a','a','',());\n" TAIL;
    const char *texts[3] = {mesh, wire, none},
               *needles[3] = {"only tessellated geometry", "only wireframe", "no geometry"};
    for (int k = 0; k < 3; k++) {
        crisp_model *m = NULL;
        assert_int_equal(read_str(texts[k], &m), CRISP_ERR_UNSUPPORTED);
        assert_null(m);
        assert_non_null(strstr(crisp_error_message(), needles[k]));
        assert_non_null(strstr(crisp_error_message(), "snippet.stp"));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_implied_knots),
        cmocka_unit_test(test_curve_bounded_surface),
        cmocka_unit_test(test_whole_sphere_and_trimmed_surface),
        cmocka_unit_test(test_sphere_caps_and_pole_arc),
        cmocka_unit_test(test_lenient_syntax_and_partial_loss),
        cmocka_unit_test(test_small_face_in_huge_model),
        cmocka_unit_test(test_hyperbola_parabola),
        cmocka_unit_test(test_nothing_drawable),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
