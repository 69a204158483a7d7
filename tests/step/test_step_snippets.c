/* The STEP reader on small hand-written files: a cylinder face bounded by two circles and a seam
 * edge used twice (with pcurves, and again without: projected), a plane face with a hole, inch
 * units and a colour, a rational B-spline surface written as a complex entity; each checked
 * against its analytic shape. Malformed files are rejected with a message naming the entity.
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

/* Cylinder r = 1, z in [0, 2]: bottom circle, seam up, top circle back, seam down. */
static const char cylinder[] = HEAD
    "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,0.));"
    "\n"
    "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=CYLINDRICAL_SURFACE('',#4,1.);\n"
    "#10=CARTESIAN_POINT('',(1.,0.,0.));\n#11=CARTESIAN_POINT('',(1.,0.,2.));\n"
    "#12=VERTEX_POINT('',#10);\n#13=VERTEX_POINT('',#11);\n"
    "/* bottom circle */ "
    "#20=CIRCLE('',#4,1.);\n#21=CARTESIAN_POINT('',(0.,0.));\n#22=DIRECTION('',(1.,0.));\n"
    "#23=VECTOR('',#22,1.);\n#24=LINE('',#21,#23);\n#25=DEFINITIONAL_REPRESENTATION('',(#24),#99);"
    "\n"
    "#26=PCURVE('',#5,#25);\n#27=SURFACE_CURVE('',#20,(#26),.PCURVE_S1.);\n#28=EDGE_CURVE('',#12,#"
    "12,#27,.T.);\n"
    "/* top circle */ #30=CARTESIAN_POINT('',(0.,0.,2.));\n#31=AXIS2_PLACEMENT_3D('',#30,#2,#3);\n"
    "#32=CIRCLE('',#31,1.);\n#33=CARTESIAN_POINT('',(0.,2.));\n#34=LINE('',#33,#23);\n"
    "#35=DEFINITIONAL_REPRESENTATION('',(#34),#99);\n#36=PCURVE('',#5,#35);\n"
    "#37=SURFACE_CURVE('',#32,(#36),.PCURVE_S1.);\n#38=EDGE_CURVE('',#13,#13,#37,.T.);\n"
    "/* seam */ #40=VECTOR('',#2,1.);\n#41=LINE('',#10,#40);\n#42=CARTESIAN_POINT('',(0.,0.));\n"
    "#43=DIRECTION('',(0.,1.));\n#44=VECTOR('',#43,1.);\n#45=LINE('',#42,#44);\n"
    "#46=DEFINITIONAL_REPRESENTATION('',(#45),#99);\n#47=PCURVE('',#5,#46);\n"
    "#48=CARTESIAN_POINT('',(6.28318530718,0.));\n#49=LINE('',#48,#44);\n"
    "#50=DEFINITIONAL_REPRESENTATION('',(#49),#99);\n#51=PCURVE('',#5,#50);\n"
    "#52=SEAM_CURVE('',#41,(#47,#51),.PCURVE_S1.);\n#53=EDGE_CURVE('',#12,#13,#52,.T.);\n"
    "#60=ORIENTED_EDGE('',*,*,#28,.T.);\n#61=ORIENTED_EDGE('',*,*,#53,.T.);\n"
    "#62=ORIENTED_EDGE('',*,*,#38,.F.);\n#63=ORIENTED_EDGE('',*,*,#53,.F.);\n"
    "#64=EDGE_LOOP('',(#60,#61,#62,#63));\n#65=FACE_OUTER_BOUND('',#64,.T.);\n"
    "#66=ADVANCED_FACE('',(#65),#5,.T.);\n#67=OPEN_SHELL('',(#66));\n#68=SHELL_BASED_SURFACE_MODEL("
    "'',(#67));\n"
    "#99=( GEOMETRIC_REPRESENTATION_CONTEXT(2) PARAMETRIC_REPRESENTATION_CONTEXT() "
    "REPRESENTATION_CONTEXT('2D SPACE','') );\n" TAIL;

/* Plane z = 0: a 4 x 4 square with a hole of radius 0.5, in inches, coloured. */
static const char plane[] = HEAD
    "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,0.));"
    "\n"
    "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=PLANE('',#4);\n"
    "#10=CARTESIAN_POINT('',(-2.,-2.,0.));\n#11=CARTESIAN_POINT('',(2.,-2.,0.));\n"
    "#12=CARTESIAN_POINT('',(2.,2.,0.));\n#13=CARTESIAN_POINT('',(-2.,2.,0.));\n"
    "#14=VERTEX_POINT('',#10);\n#15=VERTEX_POINT('',#11);\n#16=VERTEX_POINT('',#12);\n#17=VERTEX_"
    "POINT('',#13);\n"
    "#20=DIRECTION('',(1.,0.,0.));\n#21=VECTOR('',#20,1.);\n#22=LINE('',#10,#21);\n"
    "#23=EDGE_CURVE('',#14,#15,#22,.T.);\n#24=DIRECTION('',(0.,1.,0.));\n#25=VECTOR('',#24,1.);\n"
    "#26=LINE('',#11,#25);\n#27=EDGE_CURVE('',#15,#16,#26,.T.);\n#28=LINE('',#12,#21);\n"
    "#29=EDGE_CURVE('',#17,#16,#28,.T.);\n#30=LINE('',#13,#25);\n#31=EDGE_CURVE('',#14,#17,#30,.T.)"
    ";\n"
    "#32=ORIENTED_EDGE('',*,*,#23,.T.);\n#33=ORIENTED_EDGE('',*,*,#27,.T.);\n"
    "#34=ORIENTED_EDGE('',*,*,#29,.F.);\n#35=ORIENTED_EDGE('',*,*,#31,.F.);\n"
    "#36=EDGE_LOOP('',(#32,#33,#34,#35));\n#37=FACE_OUTER_BOUND('',#36,.T.);\n"
    "#40=CARTESIAN_POINT('',(0.5,0.,0.));\n#41=VERTEX_POINT('',#40);\n#42=CIRCLE('',#4,0.5);\n"
    "#43=EDGE_CURVE('',#41,#41,#42,.T.);\n#44=ORIENTED_EDGE('',*,*,#43,.F.);\n#45=EDGE_LOOP('',(#"
    "44));\n"
    "#46=FACE_BOUND('',#45,.T.);\n#50=ADVANCED_FACE('',(#37,#46),#5,.T.);\n#51=OPEN_SHELL('',(#50))"
    ";\n"
    "#52=SHELL_BASED_SURFACE_MODEL('',(#51));\n"
    "#60=(LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.));\n"
    "#61=LENGTH_MEASURE_WITH_UNIT(LENGTH_MEASURE(25.4),#60);\n"
    "#62=DIMENSIONAL_EXPONENTS(1.,0.,0.,0.,0.,0.,0.);\n"
    "#63=(CONVERSION_BASED_UNIT('INCH',#61) LENGTH_UNIT() NAMED_UNIT(#62));\n"
    "#64=(NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.));\n"
    "#65=(GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNIT_ASSIGNED_CONTEXT((#63,#64)) "
    "REPRESENTATION_CONTEXT('',''));\n"
    "#70=COLOUR_RGB('',0.2,0.4,0.6);\n#71=FILL_AREA_STYLE_COLOUR('',#70);\n#72=FILL_AREA_STYLE('',("
    "#71));\n"
    "#73=SURFACE_STYLE_FILL_AREA(#72);\n#74=SURFACE_SIDE_STYLE('',(#73));\n"
    "#75=SURFACE_STYLE_USAGE(.BOTH.,#74);\n#76=PRESENTATION_STYLE_ASSIGNMENT((#75));\n"
    "#77=STYLED_ITEM('color',(#76),#50);\n" TAIL;

/* A quarter cylinder r = 2, z in [0, 1], as a rational B-spline surface (complex entity). */
static const char rational[] =
    HEAD "#1=CARTESIAN_POINT('',(2.,0.,0.));\n#2=CARTESIAN_POINT('',(2.,2.,0.));\n#3=CARTESIAN_"
         "POINT('',(0.,2.,0.));\n"
         "#4=CARTESIAN_POINT('',(2.,0.,1.));\n#5=CARTESIAN_POINT('',(2.,2.,1.));\n#6=CARTESIAN_"
         "POINT('',(0.,2.,1.));\n"
         "#10=( BOUNDED_SURFACE() "
         "B_SPLINE_SURFACE(2,1,((#1,#4),(#2,#5),(#3,#6)),.UNSPECIFIED.,.F.,.F.,.F.)\n"
         "  B_SPLINE_SURFACE_WITH_KNOTS((3,3),(2,2),(0.,1.),(0.,1.),.UNSPECIFIED.) "
         "GEOMETRIC_REPRESENTATION_ITEM()\n"
         "  RATIONAL_B_SPLINE_SURFACE(((1.,1.),(0.707106781186548,0.707106781186548),(1.,1.)))\n"
         "  REPRESENTATION_ITEM('') SURFACE() );\n"
         "#11=ADVANCED_FACE('',(),#10,.T.);\n#12=OPEN_SHELL('',(#11));\n" TAIL;

static crisp_status read_str(const char *text, crisp_model **m, step_read_stats *st)
{
    step_read_stats local = {0};
    if (!st) st = &local;
    st->verify = 1;
    return crisp__step_read_mem("snippet.stp", text, strlen(text), NULL, m, st);
}

/* A copy of text with the first occurrence of `from` replaced by `to`. */
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

/* Every trim's image on the surface lies on the cylinder r = 1, 0 <= z <= 2. */
static void check_cylinder(const crisp_model *m, const step_read_stats *st, int curves)
{
    assert_int_equal(m->face_count, 1);
    const crisp_face *f = &m->faces[0];
    assert_int_equal(f->loop_count, 1);
    assert_true(f->loops[0].is_outer);
    assert_int_equal(f->loops[0].curve_count, curves);
    assert_int_equal(f->reversed, 0);
    loop_check c;
    check_model_loops(m, 1e-6, 1e-12, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    /* The NURBS domain spans the full turn; the loop encloses all of it in u and [0, 2] in v. */
    double d[4];
    crisp_surface_domain(f->surface, d);
    assert_true(fabs((d[1] - d[0]) - 2 * M_PI) < 1e-9);
    assert_true(fabs(crisp_trim_loop_signed_area(&f->loops[0]) - 4 * M_PI) < 1e-3);
    for (int k = 0; k < curves; k++) {
        const crisp_curve *cv = f->loops[0].curves[k];
        double t0, t1;
        crisp_curve_domain(cv, &t0, &t1);
        for (int i = 0; i <= 20; i++) {
            double uv[2], p[3];
            crisp_curve_eval(cv, t0 + (t1 - t0) * i / 20, uv);
            crisp_surface_eval(f->surface, uv[0], uv[1], p);
            assert_true(fabs(hypot(p[0], p[1]) - 1) < 1e-9);
            assert_true(p[2] > -1e-6 && p[2] < 2 + 1e-6);
        }
    }
    assert_true(st->max_edge_dev < 1e-4);
}

static void test_cylinder_seam_pcurves(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st;
    assert_int_equal(read_str(cylinder, &m, &st), CRISP_OK);
    assert_int_equal(st.pcurve_edges, 4);
    check_cylinder(m, &st, 4);
    crisp_model_destroy(m);
}

/* The same face written with angles in degrees (a DEGREE plane angle unit; the seam's pcurve at
 * u = 360): the pcurves' angle coordinates are converted, so they are used, not projected. */
static void test_cylinder_pcurves_in_degrees(void **state)
{
    (void)state;
    char *a = replace(cylinder, "#48=CARTESIAN_POINT('',(6.28318530718,0.));",
                      "#48=CARTESIAN_POINT('',(360.,0.));");
    char *b =
        replace(a, "#99=( GEOMETRIC_REPRESENTATION_CONTEXT(2)",
                "#80=(NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.));\n"
                "#81=PLANE_ANGLE_MEASURE_WITH_UNIT(PLANE_ANGLE_MEASURE(0.0174532925199433),#80);\n"
                "#82=DIMENSIONAL_EXPONENTS(0.,0.,0.,0.,0.,0.,0.);\n"
                "#83=(CONVERSION_BASED_UNIT('DEGREE',#81) NAMED_UNIT(#82) PLANE_ANGLE_UNIT());\n"
                "#84=(LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.));\n"
                "#85=(GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNIT_ASSIGNED_CONTEXT((#84,#83)) "
                "REPRESENTATION_CONTEXT('',''));\n"
                "#99=( GEOMETRIC_REPRESENTATION_CONTEXT(2)");
    crisp_model *m;
    step_read_stats st;
    assert_int_equal(read_str(b, &m, &st), CRISP_OK);
    assert_int_equal(st.pcurve_edges, 4);
    assert_int_equal(st.rejected_pcurves, 0);
    check_cylinder(m, &st, 4);
    crisp_model_destroy(m);
    free(a);
    free(b);
}

static void test_cylinder_seam_projected(void **state)
{
    (void)state;
    /* The same face with bare 3D curves as edge geometry: trims come from projection, and the
     * seam edge lands on u = 2 pi going up and on u = 0 coming down. */
    char *a = replace(cylinder, "#28=EDGE_CURVE('',#12,#12,#27,.T.)",
                      "#28=EDGE_CURVE('',#12,#12,#20,.T.)");
    char *b =
        replace(a, "#38=EDGE_CURVE('',#13,#13,#37,.T.)", "#38=EDGE_CURVE('',#13,#13,#32,.T.)");
    char *c =
        replace(b, "#53=EDGE_CURVE('',#12,#13,#52,.T.)", "#53=EDGE_CURVE('',#12,#13,#41,.T.)");
    crisp_model *m;
    step_read_stats st;
    assert_int_equal(read_str(c, &m, &st), CRISP_OK);
    assert_int_equal(st.projected_edges, 4);
    check_cylinder(m, &st, 4);
    crisp_model_destroy(m);
    free(a);
    free(b);
    free(c);
}

/* The same cylinder bounded by its two circles only (two FACE_BOUNDs, no seam edge; the top
 * circle starts at angle pi/2): one outer loop joining them along the seam. */
static void test_cylinder_band(void **state)
{
    (void)state;
    char *a = replace(cylinder, "#11=CARTESIAN_POINT('',(1.,0.,2.));",
                      "#11=CARTESIAN_POINT('',(0.,1.,2.));");
    char *b =
        replace(a,
                "#64=EDGE_LOOP('',(#60,#61,#62,#63));\n#65=FACE_OUTER_BOUND('',#64,.T.);\n"
                "#66=ADVANCED_FACE('',(#65),#5,.T.);",
                "#64=EDGE_LOOP('',(#60));\n#65=FACE_BOUND('',#64,.T.);\n#69=EDGE_LOOP('',(#62));\n"
                "#70=FACE_BOUND('',#69,.T.);\n#66=ADVANCED_FACE('',(#65,#70),#5,.T.);");
    for (int variant = 0; variant < 2; variant++) {
        char *c = variant ? replace(b, "#28=EDGE_CURVE('',#12,#12,#27,.T.)",
                                    "#28=EDGE_CURVE('',#12,#12,#20,.T.)")
                          : NULL;
        char *d = variant ? replace(c, "#38=EDGE_CURVE('',#13,#13,#37,.T.)",
                                    "#38=EDGE_CURVE('',#13,#13,#32,.T.)")
                          : NULL;
        crisp_model *m;
        step_read_stats st;
        crisp_status s = read_str(variant ? d : b, &m, &st);
        if (s) fprintf(stderr, "%s\n", crisp_error_message());
        assert_int_equal(s, CRISP_OK);
        /* bottom circle, seam up, top circle cut at the seam into two, seam down */
        check_cylinder(m, &st, 5);
        crisp_model_destroy(m);
        free(c);
        free(d);
    }
    free(a);
    free(b);
}

/* A cone (r = 1 at z = 0, semi-angle 45 degrees, apex at z = -1) bounded by its base circle and
 * a VERTEX_LOOP at the apex: one loop that closes through the apex. */
static const char cone[] = HEAD
    "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,0.));"
    "\n"
    "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=CONICAL_SURFACE('',#4,1.,0.785398163397448);\n"
    "#10=CARTESIAN_POINT('',(1.,0.,0.));\n#12=VERTEX_POINT('',#10);\n#20=CIRCLE('',#4,1.);\n"
    "#28=EDGE_CURVE('',#12,#12,#20,.T.);\n#60=ORIENTED_EDGE('',*,*,#28,.T.);\n#64=EDGE_LOOP('',(#"
    "60));\n"
    "#65=FACE_BOUND('',#64,.T.);\n#30=CARTESIAN_POINT('',(0.,0.,-1.));\n#31=VERTEX_POINT('',#30);\n"
    "#32=VERTEX_LOOP('',#31);\n#33=FACE_BOUND('',#32,.T.);\n#66=ADVANCED_FACE('',(#65,#33),#5,.T.);"
    "\n"
    "#67=OPEN_SHELL('',(#66));\n" TAIL;

static void test_cone_apex(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st;
    crisp_status s = read_str(cone, &m, &st);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    assert_int_equal(m->face_count, 1);
    const crisp_face *f = &m->faces[0];
    assert_int_equal(f->loop_count, 1);
    assert_int_equal(f->loops[0].curve_count, 4);
    loop_check c;
    check_model_loops(m, 1e-6, 1e-12, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    /* u over a full turn (NURBS parameter = angle at the ends), v from the apex (-1) to 0. */
    assert_true(fabs(crisp_trim_loop_signed_area(&f->loops[0]) - 2 * M_PI) < 1e-3);
    /* The trims' images lie on the cone x^2 + y^2 = (1 + z)^2, between apex and base. */
    for (int k = 0; k < 4; k++) {
        const crisp_curve *cv = f->loops[0].curves[k];
        double t0, t1;
        crisp_curve_domain(cv, &t0, &t1);
        for (int i = 0; i <= 20; i++) {
            double uv[2], p[3];
            crisp_curve_eval(cv, t0 + (t1 - t0) * i / 20, uv);
            crisp_surface_eval(f->surface, uv[0], uv[1], p);
            assert_true(fabs(hypot(p[0], p[1]) - (1 + p[2])) < 1e-9);
            assert_true(p[2] > -1 - 1e-9 && p[2] < 1e-6);
        }
    }
    crisp_model_destroy(m);
}

static void test_plane_hole_units_colour(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st;
    assert_int_equal(read_str(plane, &m, &st), CRISP_OK);
    assert_int_equal(m->face_count, 1);
    assert_true(fabs(m->unit_to_mm - 25.4) < 1e-12);
    const crisp_face *f = &m->faces[0];
    assert_int_equal(f->loop_count, 2);
    assert_true(f->loops[0].is_outer);
    assert_false(f->loops[1].is_outer);
    /* The plane's NURBS is its placement's (x, y): the areas are the true areas. */
    assert_true(fabs(crisp_trim_loop_signed_area(&f->loops[0]) - 16) < 1e-9);
    assert_true(fabs(crisp_trim_loop_signed_area(&f->loops[1]) + M_PI * 0.25) < 1e-3);
    loop_check c;
    check_model_loops(m, 1e-6, 1e-12, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    assert_true(f->has_color);
    assert_true(fabsf(f->color[0] - 0.2f) < 1e-6f && fabsf(f->color[1] - 0.4f) < 1e-6f &&
                fabsf(f->color[2] - 0.6f) < 1e-6f);
    /* Hole points lie on the circle of radius 0.5. */
    const crisp_curve *hole = f->loops[1].curves[0];
    double t0, t1;
    crisp_curve_domain(hole, &t0, &t1);
    for (int i = 0; i <= 32; i++) {
        double uv[2];
        crisp_curve_eval(hole, t0 + (t1 - t0) * i / 32, uv);
        assert_true(fabs(hypot(uv[0], uv[1]) - 0.5) < 1e-9);
    }
    crisp_model_destroy(m);
    /* The bottom edge as a TRIMMED_CURVE against its line's sense, used against its own sense. */
    char *t = replace(plane, "#23=EDGE_CURVE('',#14,#15,#22,.T.)",
                      "#23=EDGE_CURVE('',#14,#15,#80,.F.);\n#80=TRIMMED_CURVE('',#22,(#11),(#10),."
                      "F.,.CARTESIAN.)");
    assert_int_equal(read_str(t, &m, &st), CRISP_OK);
    assert_true(fabs(crisp_trim_loop_signed_area(&m->faces[0].loops[0]) - 16) < 1e-9);
    assert_true(st.max_edge_dev < 1e-9);
    crisp_model_destroy(m);
    free(t);
}

/* A colour on the shell reaches its faces; a RECTANGULAR_TRIMMED_SURFACE over the plane reads as
 * the plane. */
static void test_shell_colour_trimmed_surface(void **state)
{
    (void)state;
    char *a =
        replace(plane, "#77=STYLED_ITEM('color',(#76),#50)", "#77=STYLED_ITEM('color',(#76),#51)");
    char *b = replace(a, "#50=ADVANCED_FACE('',(#37,#46),#5,.T.)",
                      "#50=ADVANCED_FACE('',(#37,#46),#81,.T.);\n"
                      "#81=RECTANGULAR_TRIMMED_SURFACE('',#5,-3.,3.,-3.,3.,.T.,.T.)");
    crisp_model *m;
    step_read_stats st;
    assert_int_equal(read_str(b, &m, &st), CRISP_OK);
    assert_int_equal(m->face_count, 1);
    assert_true(m->faces[0].has_color);
    assert_true(fabsf(m->faces[0].color[2] - 0.6f) < 1e-6f);
    assert_true(fabs(crisp_trim_loop_signed_area(&m->faces[0].loops[0]) - 16) < 1e-9);
    crisp_model_destroy(m);
    free(a);
    free(b);
}

static void test_rational_complex_entity(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(read_str(rational, &m, NULL), CRISP_OK);
    assert_int_equal(m->face_count, 1);
    const crisp_surface *s = m->faces[0].surface;
    assert_int_equal(s->degree_u, 2);
    assert_int_equal(s->degree_v, 1);
    assert_true(s->rational);
    assert_int_equal(m->faces[0].loop_count, 0);
    for (int i = 0; i <= 10; i++)
        for (int j = 0; j <= 4; j++) {
            double p[3];
            crisp_surface_eval(s, i / 10.0, j / 4.0, p);
            assert_true(fabs(hypot(p[0], p[1]) - 2) < 1e-12);
            assert_true(fabs(p[2] - j / 4.0) < 1e-12);
        }
    crisp_model_destroy(m);
}

/* Each malformed variant fails (never crashes) with a message containing `needle`. */
static void expect_error(const char *text, const char *needle)
{
    crisp_model *m = NULL;
    crisp_status st = read_str(text, &m, NULL);
    if (st == CRISP_OK) fprintf(stderr, "accepted: expected an error with \"%s\"\n", needle);
    if (st == CRISP_OK) crisp_model_destroy(m);
    assert_int_not_equal(st, CRISP_OK);
    assert_null(m);
    const char *msg = crisp_error_message();
    if (!strstr(msg, needle)) fprintf(stderr, "message \"%s\" lacks \"%s\"\n", msg, needle);
    assert_non_null(strstr(msg, needle));
    assert_non_null(strstr(msg, "snippet.stp"));
}

static void expect_error_replaced(const char *from, const char *to, const char *needle)
{
    char *t = replace(plane, from, to);
    expect_error(t, needle);
    free(t);
}

static void test_malformed(void **state)
{
    (void)state;
    /* missing reference */
    expect_error_replaced("#50=ADVANCED_FACE('',(#37,#46),#5,.T.)",
                          "#50=ADVANCED_FACE('',(#37,#46),#500,.T.)", "#500, which is not defined");
    /* wrong entity type */
    expect_error_replaced("#46=FACE_BOUND('',#45,.T.)", "#46=FACE_BOUND('',#40,.T.)", "#40 (line");
    /* reference cycle */
    expect_error_replaced(
        "#43=EDGE_CURVE('',#41,#41,#42,.T.)",
        "#43=EDGE_CURVE('',#41,#41,#90,.T.);\n#90=TRIMMED_CURVE('',#90,(PARAMETER_VALUE(0.)),"
        "(PARAMETER_VALUE(1.)),.T.,.PARAMETER.)",
        "nested too deeply");
    /* a surface that trims itself */
    expect_error_replaced("#50=ADVANCED_FACE('',(#37,#46),#5,.T.)",
                          "#50=ADVANCED_FACE('',(#37,#46),#81,.T.);\n"
                          "#81=RECTANGULAR_TRIMMED_SURFACE('',#81,-3.,3.,-3.,3.,.T.,.T.)",
                          "nested too deeply");
    /* huge degree */
    expect_error_replaced(
        "#43=EDGE_CURVE('',#41,#41,#42,.T.)",
        "#43=EDGE_CURVE('',#41,#41,#91,.T.);\n#91=B_SPLINE_CURVE_WITH_KNOTS('',99,(#10,#11),"
        ".UNSPECIFIED.,.F.,.F.,(100,100),(0.,1.),.UNSPECIFIED.)",
        "#91 (line");
    /* knot multiplicities that do not add up */
    expect_error_replaced(
        "#43=EDGE_CURVE('',#41,#41,#42,.T.)",
        "#43=EDGE_CURVE('',#41,#41,#91,.T.);\n#91=B_SPLINE_CURVE_WITH_KNOTS('',1,(#10,#11),"
        ".UNSPECIFIED.,.F.,.F.,(2,1),(0.,1.),.UNSPECIFIED.)",
        "knot multiplicities sum");
    /* a number that overflows to infinity */
    expect_error_replaced("#42=CIRCLE('',#4,0.5)", "#42=CIRCLE('',#4,1.E999)", "#42 (line");
    /* duplicate entity */
    expect_error_replaced("#77=STYLED_ITEM", "#5=STYLED_ITEM", "defined twice");
    /* syntax errors */
    expect_error_replaced("#22=LINE('',#10,#21);", "#22=LINE('',#10,#21;", "line 23, column 20");
    /* A broken instance whose end can be found is skipped with a note naming its line; the rest
     * loads (here the face, without its colour). */
    {
        char *t =
            replace(plane, "#70=COLOUR_RGB('',0.2,0.4,0.6);", "#70=COLOUR_RGB('',0.2,0.4,0.6) #71");
        crisp_model *m = NULL;
        assert_int_equal(read_str(t, &m, NULL), CRISP_OK);
        assert_int_equal(m->face_count, 1);
        assert_false(m->faces[0].has_color);
        int noted = 0;
        for (int k = 0; k < m->skip_count; k++)
            noted |= strstr(m->skips[k].what, "broken instances skipped; first: line ") != NULL;
        assert_true(noted);
        crisp_model_destroy(m);
        free(t);
    }
    /* An unterminated string in the last instance: that instance is skipped with a note. */
    {
        char *t = replace(plane, "'color'", "'unterminated");
        crisp_model *m = NULL;
        assert_int_equal(read_str(t, &m, NULL), CRISP_OK);
        assert_int_equal(m->face_count, 1);
        assert_false(m->faces[0].has_color);
        int noted = 0;
        for (int k = 0; k < m->skip_count; k++)
            noted |= strstr(m->skips[k].what, "broken instances skipped; first: line ") != NULL;
        assert_true(noted);
        crisp_model_destroy(m);
        free(t);
    }
    expect_error("hello", "not a STEP file");
    /* truncated at every length: never crashes, always an error or a model */
    size_t n = strlen(plane);
    for (size_t k = 0; k < n; k += 7) {
        crisp_model *m = NULL;
        crisp_status st = crisp__step_read_mem("snippet.stp", plane, k, NULL, &m, NULL);
        assert_int_not_equal(st, CRISP_OK);
        assert_non_null(strstr(crisp_error_message(), "snippet.stp"));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cylinder_seam_pcurves),
        cmocka_unit_test(test_cylinder_pcurves_in_degrees),
        cmocka_unit_test(test_cylinder_seam_projected),
        cmocka_unit_test(test_cylinder_band),
        cmocka_unit_test(test_cone_apex),
        cmocka_unit_test(test_plane_hole_units_colour),
        cmocka_unit_test(test_shell_colour_trimmed_surface),
        cmocka_unit_test(test_rational_complex_entity),
        cmocka_unit_test(test_malformed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
