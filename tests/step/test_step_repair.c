/* Issue 13: faces that real STEP files bound loosely and that crisp used to drop, on small
 * hand-written files, each checked against its analytic shape:
 *  - periodic faces whose loop crosses a cone's apex or a sphere's pole (a half cone bounded by a
 *    half circle and two generators; a lune of a sphere between two meridians), where the turn
 *    of u is undefined and continuity alone picked the wrong one ("winds around u without a seam
 *    edge");
 *  - a hemisphere bounded by a great circle that passes within 1e-10 of both poles;
 *  - faces on a cone's far nappe (beyond the apex) and on a spindle torus, whose points the
 *    analytic inversion put on the wrong branch;
 *  - a pcurve that lies off its edge: the trim is projected from the 3D edge;
 *  - a half circle written as one rational cubic on a plane (its control polygon leaves the
 *    curve's box: the plane grows instead of the trim being clamped);
 *  - loops the file leaves open (edges whose 3D ends do not meet: a strip bounded by its two long
 *    edges only) closed by straight (u, v) segments with a note, and not when the bridges would
 *    be most of the loop;
 *  - (more cases are added below as they are built).
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

#include "crisp/mass.h"
#include "crisp/render.h"
#include "io/step/step_internal.h"
#include "step/test_step_util.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define HEAD                                                                                       \
    "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('test'),'2;1');\n"                                  \
    "FILE_NAME('t','',(''),(''),'','','');\nFILE_SCHEMA(('AUTOMOTIVE_DESIGN'));\nENDSEC;\nDATA;\n"
#define TAIL "ENDSEC;\nEND-ISO-10303-21;\n"

static crisp_status read_str(const char *text, crisp_model **m, step_read_stats *st)
{
    step_read_stats local = {0};
    if (!st) st = &local;
    st->verify = 1;
    return crisp__step_read_mem("snippet.stp", text, strlen(text), NULL, m, st);
}

/* A copy of text with every occurrence of `from` replaced by `to`. */
static char *replace_all(const char *text, const char *from, const char *to)
{
    size_t nf = strlen(from), nt = strlen(to), n = 0;
    for (const char *p = strstr(text, from); p; p = strstr(p + nf, from))
        n++;
    assert_true(n > 0);
    char *out = malloc(strlen(text) + n * (nt > nf ? nt - nf : 0) + 1), *o = out;
    for (const char *p = text;;) {
        const char *q = strstr(p, from);
        if (!q) {
            strcpy(o, p);
            break;
        }
        memcpy(o, p, (size_t)(q - p));
        o += q - p;
        memcpy(o, to, nt);
        o += nt;
        p = q + nf;
    }
    return out;
}

static int has_note(const crisp_model *m, const char *a, const char *b)
{
    for (int i = 0; i < m->skip_count; i++)
        if (strstr(m->skips[i].what, a) && (!b || strstr(m->skips[i].what, b))) return 1;
    return 0;
}

/* Every trim's image lies on the implicit surface f(p) = 0 (|f| < tol), the loops are closed,
 * inside the domain and oriented, and the surface at the centre of the outer loop's (u, v) box
 * satisfies inside(p) (the face covers the intended side). */
typedef double (*implicit_fn)(const double p[3]);
typedef int (*side_fn)(const double p[3]);

static void check_face(const crisp_model *m, int face, implicit_fn f, double tol, side_fn inside)
{
    const crisp_face *fc = &m->faces[face];
    loop_check c;
    check_model_loops(m, 1e-6, 1e-9, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    double box[4] = {INFINITY, -INFINITY, INFINITY, -INFINITY};
    for (int l = 0; l < fc->loop_count; l++)
        for (int k = 0; k < fc->loops[l].curve_count; k++) {
            const crisp_curve *cv = fc->loops[l].curves[k];
            double t0, t1;
            crisp_curve_domain(cv, &t0, &t1);
            for (int i = 0; i <= 32; i++) {
                double uv[2], p[3];
                crisp_curve_eval(cv, t0 + (t1 - t0) * i / 32, uv);
                crisp_surface_eval(fc->surface, uv[0], uv[1], p);
                assert_true(fabs(f(p)) < tol);
                if (fc->loops[l].is_outer) {
                    box[0] = fmin(box[0], uv[0]), box[1] = fmax(box[1], uv[0]);
                    box[2] = fmin(box[2], uv[1]), box[3] = fmax(box[3], uv[1]);
                }
            }
        }
    double p[3];
    crisp_surface_eval(fc->surface, 0.5 * (box[0] + box[1]), 0.5 * (box[2] + box[3]), p);
    assert_true(inside(p));
}

/* ---- a half cone: half circle + two generators meeting at the apex, no pcurves ----------------
 */

/* Cone x^2 + y^2 = (1 + z)^2 (radius 1 at z = 0, semi-angle 45 degrees, apex (0, 0, -1)). The
 * face: the circle from (0, 1, 0) counter-clockwise to (0, -1, 0) (the x < 0 half), the generator
 * down to the apex and back up to (0, 1, 0). The generators lie half a turn apart. */
static const char half_cone[] =
    HEAD "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,"
         "0.));\n"
         "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=CONICAL_SURFACE('',#4,1.,0.785398163397448);\n"
         "#10=CARTESIAN_POINT('',(0.,1.,0.));\n#11=CARTESIAN_POINT('',(0.,-1.,0.));\n"
         "#12=CARTESIAN_POINT('',(0.,0.,-1.));\n"
         "#13=VERTEX_POINT('',#10);\n#14=VERTEX_POINT('',#11);\n#15=VERTEX_POINT('',#12);\n"
         "#20=CIRCLE('',#4,1.);\n#21=EDGE_CURVE('',#13,#14,#20,.T.);\n"
         "#22=DIRECTION('',(0.,1.,-1.));\n#23=VECTOR('',#22,1.);\n#24=LINE('',#11,#23);\n"
         "#25=EDGE_CURVE('',#14,#15,#24,.T.);\n"
         "#26=DIRECTION('',(0.,1.,1.));\n#27=VECTOR('',#26,1.);\n#28=LINE('',#12,#27);\n"
         "#29=EDGE_CURVE('',#15,#13,#28,.T.);\n"
         "#30=ORIENTED_EDGE('',*,*,#21,.T.);\n#31=ORIENTED_EDGE('',*,*,#25,.T.);\n"
         "#32=ORIENTED_EDGE('',*,*,#29,.T.);\n#33=EDGE_LOOP('',(#30,#31,#32));\n"
         "#34=FACE_OUTER_BOUND('',#33,.T.);\n#35=ADVANCED_FACE('',(#34),#5,.T.);\n"
         "#36=OPEN_SHELL('',(#35));\n" TAIL;

static double on_cone(const double p[3])
{
    return hypot(p[0], p[1]) - fabs(1 + p[2]);
}
static int left_half(const double p[3])
{
    return p[0] < -0.1 && p[2] > -1 && p[2] < 0;
}
static int right_half(const double p[3])
{
    return p[0] > 0.1 && p[2] > -1 && p[2] < 0;
}

static void test_half_cone_through_apex(void **state)
{
    (void)state;
    /* As written, then the loop started at each edge (the apex first, last, in the middle),
     * then the other half (the circle clockwise from (0, 1, 0): x > 0). */
    const char *orders[] = {"(#30,#31,#32)", "(#31,#32,#30)", "(#32,#30,#31)"};
    for (int other = 0; other < 2; other++)
        for (int o = 0; o < 3; o++) {
            char *t1 = replace_all(half_cone, "(#30,#31,#32)", orders[o]);
            /* the other half: the circle with the opposite sense (an axis along -z) */
            char *t2 = other ? replace_all(t1, "#20=CIRCLE('',#4,1.);",
                                           "#19=DIRECTION('',(0.,0.,-1.));\n"
                                           "#18=AXIS2_PLACEMENT_3D('',#1,#19,#3);\n"
                                           "#20=CIRCLE('',#18,1.);")
                             : replace_all(t1, "#", "#");
            crisp_model *m;
            step_read_stats st = {0};
            crisp_status s = read_str(t2, &m, &st);
            if (s) fprintf(stderr, "%s\n", crisp_error_message());
            assert_int_equal(s, CRISP_OK);
            assert_int_equal(m->face_count, 1);
            assert_int_equal(m->faces_dropped, 0);
            check_face(m, 0, on_cone, 1e-7, other ? right_half : left_half);
            assert_true(st.max_edge_dev < 1e-4);
            crisp_model_destroy(m);
            free(t1);
            free(t2);
        }
}

static int three_quarters(const double p[3])
{
    return p[0] < -0.1 && p[1] < -0.1 && p[2] > -1 && p[2] < 0;
}

/* A sector of three quarters of a turn (the circle from (0, 1, 0) counter-clockwise to
 * (1, 0, 0)), its loop started at each edge: more than half a turn is not "winding" when the
 * loop passes through the apex (bug29241.stp: 10 such faces were dropped). */
static void test_cone_sector_three_quarters(void **state)
{
    (void)state;
    const char *orders[] = {"(#30,#31,#32)", "(#31,#32,#30)", "(#32,#30,#31)"};
    for (int o = 0; o < 3; o++) {
        char *t1 = replace_all(half_cone, "(#30,#31,#32)", orders[o]);
        char *t2 = replace_all(t1, "#11=CARTESIAN_POINT('',(0.,-1.,0.));",
                               "#11=CARTESIAN_POINT('',(1.,0.,0.));");
        char *t3 =
            replace_all(t2, "#22=DIRECTION('',(0.,1.,-1.));", "#22=DIRECTION('',(-1.,0.,-1.));");
        crisp_model *m;
        step_read_stats st = {0};
        crisp_status s = read_str(t3, &m, &st);
        if (s) fprintf(stderr, "%s\n", crisp_error_message());
        assert_int_equal(s, CRISP_OK);
        assert_int_equal(m->face_count, 1);
        check_face(m, 0, on_cone, 1e-7, three_quarters);
        assert_true(st.max_edge_dev < 1e-4);
        crisp_model_destroy(m);
        free(t1);
        free(t2);
        free(t3);
    }
}

/* The cone's other nappe (ISO 10303-42 cones have both: R + v tan a < 0 beyond the apex): a face
 * bounded by the circle of radius 2 at z = -3 and a vertex loop at the apex (0, 0, -1). Analytic
 * inversion used to take the foot on the wrong nappe (screw.step: 4 faces dropped, "the trim of
 * edge lies 3.09 from the edge"). */
static const char far_nappe[] = HEAD
    "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,0.));"
    "\n"
    "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=CONICAL_SURFACE('',#4,1.,0.785398163397448);\n"
    "#6=CARTESIAN_POINT('',(0.,0.,-3.));\n#7=AXIS2_PLACEMENT_3D('',#6,#2,#3);\n"
    "#10=CARTESIAN_POINT('',(2.,0.,-3.));\n#12=VERTEX_POINT('',#10);\n#20=CIRCLE('',#7,2.);\n"
    "#28=EDGE_CURVE('',#12,#12,#20,.T.);\n#60=ORIENTED_EDGE('',*,*,#28,.T.);\n#64=EDGE_LOOP('',(#"
    "60));\n"
    "#65=FACE_BOUND('',#64,.T.);\n#30=CARTESIAN_POINT('',(0.,0.,-1.));\n#31=VERTEX_POINT('',#30);\n"
    "#32=VERTEX_LOOP('',#31);\n#33=FACE_BOUND('',#32,.T.);\n#66=ADVANCED_FACE('',(#65,#33),#5,.T.);"
    "\n"
    "#67=OPEN_SHELL('',(#66));\n" TAIL;

static int below_apex(const double p[3])
{
    return p[2] < -1.01 && p[2] > -3;
}

static void test_cone_far_nappe(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st = {0};
    crisp_status s = read_str(far_nappe, &m, &st);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    assert_int_equal(m->face_count, 1);
    check_face(m, 0, on_cone, 1e-7, below_apex);
    assert_true(st.max_edge_dev < 1e-4);
    crisp_model_destroy(m);
}

/* ---- a lune of a sphere: two meridians through both poles ---------------------------------- */

/* Unit sphere; meridian A in the plane y = 0 from the south pole (0, 0, -1) up through (1, 0, 0)
 * to the north pole, then meridian B in the plane x = 0 down through (0, -1, 0) back to the south
 * pole: counter-clockwise seen from outside, the face is the quarter lune x > 0, y < 0 (angles
 * -90 to 0 degrees), not the three quarters on the other side. */
static const char lune[] =
    HEAD "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,"
         "0.));\n"
         "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=SPHERICAL_SURFACE('',#4,1.);\n"
         "#10=CARTESIAN_POINT('',(0.,0.,-1.));\n#11=CARTESIAN_POINT('',(0.,0.,1.));\n"
         "#13=VERTEX_POINT('',#10);\n#14=VERTEX_POINT('',#11);\n"
         "#40=DIRECTION('',(0.,-1.,0.));\n#41=AXIS2_PLACEMENT_3D('',#1,#40,#3);\n#42=CIRCLE('',#41,"
         "1.);\n"
         "#43=EDGE_CURVE('',#13,#14,#42,.T.);\n"
         "#50=DIRECTION('',(1.,0.,0.));\n#51=DIRECTION('',(0.,1.,0.));\n#52=AXIS2_PLACEMENT_3D('',#"
         "1,#50,#51);\n"
         "#53=CIRCLE('',#52,1.);\n#54=EDGE_CURVE('',#14,#13,#53,.T.);\n"
         "#30=ORIENTED_EDGE('',*,*,#43,.T.);\n#31=ORIENTED_EDGE('',*,*,#54,.T.);\n"
         "#33=EDGE_LOOP('',(#30,#31));\n"
         "#34=FACE_OUTER_BOUND('',#33,.T.);\n#35=ADVANCED_FACE('',(#34),#5,.T.);\n"
         "#36=OPEN_SHELL('',(#35));\n" TAIL;

static double on_sphere(const double p[3])
{
    return sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 1;
}
static int quarter_lune(const double p[3])
{
    return p[0] > 0.05 && p[1] < -0.05;
}

static void test_sphere_lune_through_poles(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st = {0};
    crisp_status s = read_str(lune, &m, &st);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    assert_int_equal(m->face_count, 1);
    check_face(m, 0, on_sphere, 1e-7, quarter_lune);
    assert_true(st.max_edge_dev < 1e-4);
    crisp_model_destroy(m);
}

/* A hemisphere of a sphere about x bounded by one great circle through both poles, the circle's
 * centre 1e-10 off the sphere's (trj3_s1-md-214.stp: 6 such faces were dropped, "no fit within
 * the tolerance": u turns by pi within 1e-10 of each pole, too fast to fit and too slow to be cut
 * as a jump). The turns within the tolerance of a pole are cut now and bridged along the pole. */
static const char near_pole[] = HEAD
    "#1=CARTESIAN_POINT('',(-6.5E-011,-1.1E-010,0.));\n#2=DIRECTION('',(1.,0.,0.));\n"
    "#3=DIRECTION('',(0.,-1.,0.));\n#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=SPHERICAL_SURFACE('',#"
    "4,6.);\n"
    "#10=CARTESIAN_POINT('',(-6.5E-011,1.9E-014,-6.));\n#11=VERTEX_POINT('',#10);\n"
    "#6=CARTESIAN_POINT('',(-6.5E-011,1.9E-014,0.));\n"
    "#12=DIRECTION('',(0.,-1.,0.));\n#13=DIRECTION('',(0.,0.,-1.));\n#14=AXIS2_PLACEMENT_3D('',#6,#"
    "12,#13);\n"
    "#15=CIRCLE('',#14,6.);\n#16=EDGE_CURVE('',#11,#11,#15,.F.);\n#17=ORIENTED_EDGE('',*,*,#16,.F.)"
    ";\n"
    "#18=EDGE_LOOP('',(#17));\n#19=FACE_BOUND('',#18,.T.);\n#20=ADVANCED_FACE('',(#19),#5,.T.);\n"
    "#21=OPEN_SHELL('',(#20));\n" TAIL;

static double on_sphere6(const double p[3])
{
    return sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 6;
}
static int off_the_circle(const double p[3])
{
    return fabs(p[1]) > 1;
}

static void test_hemisphere_near_poles(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st = {0};
    crisp_status s = read_str(near_pole, &m, &st);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    assert_int_equal(m->face_count, 1);
    check_face(m, 0, on_sphere6, 1e-6, off_the_circle);
    assert_true(st.max_edge_dev < 1e-3);
    crisp_model_destroy(m);
}

/* ---- a pcurve off its edge ---------------------------------------------------------------- */

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

/* The bottom circle's pcurve bulges to v = 0.3 between its ends (a parabola in (u, v) that meets
 * the edge at its ends): 0.3 off its edge. The trim comes from the 3D circle (the pcurve is
 * checked at 9 points first; one that passes those but whose finished trim lies off the edge is
 * now projected from the 3D edge as well, with a note, instead of dropping the face). */
static void test_pcurve_off_edge_reprojected(void **state)
{
    (void)state;
    char *t = replace_all(
        cylinder, "#25=DEFINITIONAL_REPRESENTATION('',(#24),#99);",
        "#80=CARTESIAN_POINT('',(0.,0.));\n#81=CARTESIAN_POINT('',(3.14159265358979,0.6));\n"
        "#82=CARTESIAN_POINT('',(6.28318530717959,0.));\n"
        "#83=B_SPLINE_CURVE_WITH_KNOTS('',2,(#80,#81,#82),.UNSPECIFIED.,.F.,.F.,(3,3),(0.,6."
        "28318530717959),"
        ".UNSPECIFIED.);\n#25=DEFINITIONAL_REPRESENTATION('',(#83),#99);");
    crisp_model *m;
    step_read_stats st = {0};
    crisp_status s = read_str(t, &m, &st);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    assert_int_equal(m->face_count, 1);
    /* every trim on the cylinder, and the lowest point of the loop at z = 0 (the 3D circle), not
     * 0.3 (the pcurve) */
    const crisp_face *f = &m->faces[0];
    double zmin = INFINITY;
    for (int k = 0; k < f->loops[0].curve_count; k++) {
        const crisp_curve *cv = f->loops[0].curves[k];
        double t0, t1;
        crisp_curve_domain(cv, &t0, &t1);
        for (int i = 0; i <= 32; i++) {
            double uv[2], p[3];
            crisp_curve_eval(cv, t0 + (t1 - t0) * i / 32, uv);
            crisp_surface_eval(f->surface, uv[0], uv[1], p);
            assert_true(fabs(hypot(p[0], p[1]) - 1) < 1e-9);
            zmin = fmin(zmin, p[2]);
        }
    }
    assert_true(fabs(zmin) < 1e-5);
    loop_check c;
    check_model_loops(m, 1e-6, 1e-9, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    assert_true(st.max_edge_dev < 1e-4);
    crisp_model_destroy(m);
    free(t);
}

/* ---- a rational cubic half circle on a plane ------------------------------------------------ */

/* A plane face bounded by a half circle of radius 7.5 written as one rational cubic (weights 1,
 * 1/3, 1/3, 1: its middle control points lie 15 out, twice the radius) and its diameter. The
 * trim's control points used to be clamped into the box of the curve, which squashed the arc to
 * half its radius (occt_as1_ec.stp's bolt heads: holes 2.6 wide, found by crisp info's gaps). */
static const char half_circle[] = HEAD
    "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,-1.));\n#3=DIRECTION('',(-1.,0.,0.)"
    ");\n"
    "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=PLANE('',#4);\n"
    "#919=CARTESIAN_POINT('',(-7.5,0.,0.));\n#920=CARTESIAN_POINT('',(-7.5,-15.,0.));\n"
    "#921=CARTESIAN_POINT('',(7.5,-15.,0.));\n#922=CARTESIAN_POINT('',(7.5,0.,0.));\n"
    "#918=( BOUNDED_CURVE() B_SPLINE_CURVE(3,(#919,#920,#921,#922),.UNSPECIFIED.,.F.,.F.) "
    "B_SPLINE_CURVE_WITH_KNOTS((4,4),(0.,0.5),.PIECEWISE_BEZIER_KNOTS.) CURVE() "
    "GEOMETRIC_REPRESENTATION_ITEM() "
    "RATIONAL_B_SPLINE_CURVE((1.,0.33333333333,0.33333333333,1.)) REPRESENTATION_ITEM('') );\n"
    "#10=VERTEX_POINT('',#919);\n#11=VERTEX_POINT('',#922);\n#12=EDGE_CURVE('',#10,#11,#918,.T.);\n"
    "#20=DIRECTION('',(1.,0.,0.));\n#21=VECTOR('',#20,1.);\n#22=LINE('',#919,#21);\n"
    "#23=EDGE_CURVE('',#10,#11,#22,.T.);\n#30=ORIENTED_EDGE('',*,*,#12,.T.);\n#31=ORIENTED_EDGE('',"
    "*,*,#23,.F.);\n"
    "#32=EDGE_LOOP('',(#30,#31));\n#33=FACE_BOUND('',#32,.T.);\n#34=ADVANCED_FACE('',(#33),#5,.T.);"
    "\n"
    "#35=OPEN_SHELL('',(#34));\n" TAIL;

static double on_half_disc_rim(const double p[3])
{
    return fmin(fabs(p[1]), fabs(hypot(p[0], p[1]) - 7.5)) + fabs(p[2]);
}
static int in_half_disc(const double p[3])
{
    return p[1] < -1 && hypot(p[0], p[1]) < 7.5;
}

static void test_rational_half_circle_on_plane(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st = {0};
    crisp_status s = read_str(half_circle, &m, &st);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    assert_int_equal(m->face_count, 1);
    check_face(m, 0, on_half_disc_rim, 1e-9, in_half_disc);
    /* the half disc's area, pi r^2 / 2 (the plane's (u, v) are lengths) */
    /* (the area is measured on a polyline: within 2%; the squashed arc had half of it) */
    assert_true(fabs(fabs(crisp_trim_loop_signed_area(&m->faces[0].loops[0])) -
                     M_PI * 7.5 * 7.5 / 2) < 0.02 * M_PI * 7.5 * 7.5 / 2);
    assert_true(st.max_edge_dev < 1e-6);
    crisp_model_destroy(m);
}

/* ---- a loop left open by the file ----------------------------------------------------------- */

/* Plane z = 0; the loop lists only the two long edges of the rectangle [0, 2] x [0, 1]: (0, 0) to
 * (2, 0) and (2, 1) to (0, 1), four distinct vertices (trj3_s1-al-214.stp writes half-cylinder
 * strips so). */
static const char open_strip[] =
    HEAD "#1=CARTESIAN_POINT('',(0.,0.,0.));\n#2=DIRECTION('',(0.,0.,1.));\n#3=DIRECTION('',(1.,0.,"
         "0.));\n"
         "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n#5=PLANE('',#4);\n"
         "#10=CARTESIAN_POINT('',(0.,0.,0.));\n#11=CARTESIAN_POINT('',(2.,0.,0.));\n"
         "#12=CARTESIAN_POINT('',(2.,1.,0.));\n#13=CARTESIAN_POINT('',(0.,1.,0.));\n"
         "#14=VERTEX_POINT('',#10);\n#15=VERTEX_POINT('',#11);\n#16=VERTEX_POINT('',#12);\n#17="
         "VERTEX_POINT('',#13);\n"
         "#20=DIRECTION('',(1.,0.,0.));\n#21=VECTOR('',#20,1.);\n#22=LINE('',#10,#21);\n"
         "#23=EDGE_CURVE('',#14,#15,#22,.T.);\n#28=LINE('',#13,#21);\n#29=EDGE_CURVE('',#17,#16,#"
         "28,.T.);\n"
         "#32=ORIENTED_EDGE('',*,*,#23,.T.);\n#34=ORIENTED_EDGE('',*,*,#29,.F.);\n"
         "#36=EDGE_LOOP('',(#32,#34));\n#37=FACE_OUTER_BOUND('',#36,.T.);\n"
         "#50=ADVANCED_FACE('',(#37),#5,.T.);\n#51=OPEN_SHELL('',(#50));\n" TAIL;

static void test_open_loop_bridged(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_status s = read_str(open_strip, &m, NULL);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces_dropped, 0);
    loop_check c;
    check_model_loops(m, 1e-9, 1e-9, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    /* the rectangle: area 2 (the plane's (u, v) is x, y), two bridges */
    assert_int_equal(m->faces[0].loops[0].curve_count, 4);
    assert_true(fabs(crisp_trim_loop_signed_area(&m->faces[0].loops[0]) - 2) < 1e-9);
    assert_true(has_note(m, "left open by the file (2 gaps", "closed by straight"));
    crisp_model_destroy(m);

    /* One short edge (0.2 long) and one of 2: the bridges would be half the loop or more: the
     * face is dropped, and the note says why. */
    char *t = replace_all(open_strip, "#13=CARTESIAN_POINT('',(0.,1.,0.));",
                          "#13=CARTESIAN_POINT('',(1.8,1.,0.));");
    m = NULL;
    assert_int_not_equal(read_str(t, &m, NULL), CRISP_OK);
    assert_null(m);
    assert_non_null(strstr(crisp_error_message(), "open"));
    free(t);
}

/* A band of a B-spline surface closed in both directions (a torus of rational patches), bounded
 * by two circles and a seam edge used twice (face #1321 of Open CASCADE's trj5_k1-id-214.stp, cut
 * with what it references: data/cuts). The projected trims fall on either side of both seams; the
 * loop is unwound onto one turn: the band between the circles, v in [0.5779, 1] over the whole u
 * range [0, 3] (the same face in trj4_k1_top-id-214.stp and trj6_k1-id-203.stp was dropped as an
 * open loop). */
static void test_bspline_closed_both_ways(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(
        crisp_model_load(CRISP_DATA_DIR "/cuts/occt_trj5_k1_id_face1321.stp", NULL, &m), CRISP_OK);
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces_dropped, 0);
    loop_check c;
    check_model_loops(m, 1e-6, 1e-6, &c);
    assert_int_equal(c.open_loops + c.outside_loops + c.misoriented_loops, 0);
    assert_int_equal(m->faces[0].loop_count, 1);
    double a = crisp_trim_loop_signed_area(&m->faces[0].loops[0]);
    if (fabs(a - 3 * (1 - 0.577887)) > 1e-3) fprintf(stderr, "band area %g\n", a);
    assert_true(fabs(a - 3 * (1 - 0.577887)) < 1e-3);
    crisp_model_destroy(m);
}

/* The whole of a file into a string (freed by the caller). */
static char *read_whole(const char *path)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *t = malloc((size_t)n + 1);
    assert_non_null(t);
    assert_int_equal(fread(t, 1, (size_t)n, f), (size_t)n);
    t[n] = 0;
    fclose(f);
    return t;
}

/* Reads path (its text in *text, freed by the caller after the model), which must give one face,
 * none dropped, whose loops are closed, inside its domain and oriented (*c: check_model_loops at
 * 1e-6). */
static crisp_model *read_one_clean_face(const char *path, char **text, step_read_stats *st,
                                        loop_check *c)
{
    *text = read_whole(path);
    crisp_model *m;
    crisp_status s = read_str(*text, &m, st);
    if (s) fprintf(stderr, "%s: %s\n", path, crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces_dropped, 0);
    check_model_loops(m, 1e-6, 1e-6, c);
    assert_int_equal(c->open_loops + c->outside_loops + c->misoriented_loops, 0);
    return m;
}

/* A band on a revolved B-spline surface closed in v, bounded by two circles (face #934 of Open
 * CASCADE's trj3_s1-md-214.stp, data/cuts): the inner circle's projection runs continuously
 * from v = 0.5 down across the seam to -0.5; it is cut at the seam and the part beyond moved by
 * the period, so both circles wind and bound one band: the whole domain [0, 1] x [0, 1]. (It was
 * clamped onto the seam and the face dropped as open.) Every trim lies on its edge. */
static void test_bspline_band_across_seam(void **state)
{
    (void)state;
    char *t;
    step_read_stats st = {0};
    loop_check c;
    crisp_model *m =
        read_one_clean_face(CRISP_DATA_DIR "/cuts/occt_trj3_s1_md_face934.stp", &t, &st, &c);
    assert_int_equal(m->faces[0].loop_count, 1);
    double a = crisp_trim_loop_signed_area(&m->faces[0].loops[0]);
    assert_true(fabs(a - 1) < 1e-6);
    assert_true(st.max_edge_dev < 1e-6);
    crisp_model_destroy(m);
    free(t);
}

/* A strip around most of a turn of a B-spline surface closed in v, through its seam (face #1485
 * of Open CASCADE's trj5_k1-sh-203.stp, data/cuts): the loop jumps across the domain twice. It
 * becomes two outer loops closed along the seam, v in [0, 4.03] and [4.49, 5.65], u across the
 * strip's width 1/9 (the ends of the strip bulge a little). (It was dropped as open.) */
static void test_bspline_strip_through_seam(void **state)
{
    (void)state;
    char *t;
    step_read_stats st = {0};
    loop_check c;
    crisp_model *m =
        read_one_clean_face(CRISP_DATA_DIR "/cuts/occt_trj5_k1_sh_face1485.stp", &t, &st, &c);
    assert_int_equal(m->faces[0].loop_count, 2);
    assert_int_equal(c.outer, 2);
    double a0 = crisp_trim_loop_signed_area(&m->faces[0].loops[0]),
           a1 = crisp_trim_loop_signed_area(&m->faces[0].loops[1]);
    double lo = (1.0 / 9) * 4.0329, hi = (1.0 / 9) * (5.65487 - 4.4867);
    if (a0 < a1) {
        double x = a0;
        a0 = a1, a1 = x;
    }
    assert_true(fabs(a0 - lo) < 0.02 * lo);
    assert_true(fabs(a1 - hi) < 0.05 * hi);
    assert_true(st.max_edge_dev < 1e-4);
    crisp_model_destroy(m);
    free(t);
}

/* A band on a cylinder between its end circle and a notched loop, with two holes, one of them
 * straddling the angle where the end circle starts (face #1446 of Open CASCADE's
 * trj5_k1-sh-203.stp, data/cuts): the band's seam ran from that start through the hole, which
 * then lay half beyond the band's turn ("the trim of edge #471 lies 0.0837 from the edge"; the
 * face was dropped). The seam now runs where no hole is: one outer loop and two holes, every
 * trim on its edge, and the face's area is Open CASCADE's (BRepGProp, adaptive: 0.78355276). */
static void test_band_seam_clear_of_holes(void **state)
{
    (void)state;
    char *t;
    step_read_stats st = {0};
    loop_check c;
    crisp_model *m =
        read_one_clean_face(CRISP_DATA_DIR "/cuts/occt_trj5_k1_sh_face1446.stp", &t, &st, &c);
    assert_int_equal(m->faces[0].loop_count, 3);
    assert_int_equal(c.outer, 1);
    assert_true(st.max_edge_dev < 1e-4);
    crisp_mass_props mp;
    assert_int_equal(crisp_mass_model(m, NULL, &mp), CRISP_OK);
    assert_true(fabs(mp.area - 0.78355276) < 1e-6);
    crisp_model_destroy(m);
    free(t);
}

/* A lens between two edges 0.046 apart at most, on a degree 8 x 8 patch whose control net is 2
 * units across and 30,000 long (faces #6387 and #9226, mirror images, of Open CASCADE's
 * trj6_b1-ec-214.stp, data/cuts): the edges lie on a level curve of z, which changes 2.4e5 times
 * faster across it than the other coordinates along it. Three causes dropped them: Newton crept
 * along that narrow curved valley of the distance (the projections stopped 0.3 off the edges
 * and the loop was open by 1.3 in (u, v)); the face's tolerance came from the size of its
 * surface's net (the trims could wander 0.14 off edges 0.046 apart); and the framing box was the
 * patch clipped to the loops' (u, v) box (z over +-14,000). Now: kept, every trim on its edge,
 * the area that of the lens (the strip between the two edges over their common path in x, y:
 * 0.0580657, computed from the edges alone), and the box the lens's. */
static void test_lens_on_long_patch(void **state)
{
    (void)state;
    const char *files[2] = {CRISP_DATA_DIR "/cuts/occt_trj6_b1_ec_face6387.stp",
                            CRISP_DATA_DIR "/cuts/occt_trj6_b1_ec_face9226.stp"};
    for (int k = 0; k < 2; k++) {
        char *t;
        step_read_stats st = {0};
        loop_check c;
        crisp_model *m = read_one_clean_face(files[k], &t, &st, &c);
        assert_true(st.max_edge_dev < 1e-3);
        crisp_mass_props mp;
        assert_int_equal(crisp_mass_model(m, NULL, &mp), CRISP_OK);
        assert_true(fabs(mp.area - 0.0580657) < 2e-4 * 0.0580657);
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
        assert_true(sc->box[2] > -5.05 && sc->box[5] < -4.95);
        assert_true(sc->box[3] - sc->box[0] < 1.6 && sc->box[4] - sc->box[1] < 1.5);
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
        free(t);
    }
}

/* An octant of a sphere (radius 200) whose pcurves give latitudes 270 to 360 degrees (face #355
 * of Open CASCADE's bm2_pe_t4-A.stp, data/cuts): the sphere's parametrisation repeats every turn
 * of latitude, so these are -90 to 0; the face was dropped for an empty latitude range [4.70,
 * 1.57]. Kept: the octant's area pi 200^2 / 2 (Open CASCADE's BRepGProp gives the same). */
static void test_sphere_latitudes_a_turn_away(void **state)
{
    (void)state;
    char *t;
    step_read_stats st = {0};
    loop_check c;
    crisp_model *m =
        read_one_clean_face(CRISP_DATA_DIR "/cuts/occt_bm2_pe_t4_a_face355.stp", &t, &st, &c);
    assert_true(st.max_edge_dev < 1e-6);
    crisp_mass_props mp;
    assert_int_equal(crisp_mass_model(m, NULL, &mp), CRISP_OK);
    assert_true(fabs(mp.area - M_PI * 200 * 200 / 2) < 1e-6 * mp.area);
    crisp_model_destroy(m);
    free(t);
}

/* A face on a SURFACE_OF_LINEAR_EXTRUSION of a circle, its loop without pcurves, one arc ending
 * at the profile's angle pi (trj3_s1-tc-214.stp #3993, written by hand): checking the trims
 * against their edges inverted points just short of angle pi onto -pi (the search over
 * [-pi, pi] did not wrap), so the arc's trim seemed 0.15 off its edge and the face was dropped.
 */
static const char *extrusion_arc_at_pi =
    HEAD "#1=CARTESIAN_POINT('',(0.,0.,0.));\n"
         "#2=DIRECTION('',(0.,0.,1.));\n"
         "#3=DIRECTION('',(1.,0.,0.));\n"
         "#4=AXIS2_PLACEMENT_3D('',#1,#2,#3);\n"
         "#5=CIRCLE('',#4,2.);\n"
         "#6=VECTOR('',#2,1.);\n"
         "#7=SURFACE_OF_LINEAR_EXTRUSION('',#5,#6);\n"
         "#10=CARTESIAN_POINT('',(-1.7551651237807455,0.958851077208406,0.));\n"
         "#11=CARTESIAN_POINT('',(-1.7551651237807455,0.958851077208406,1.));\n"
         "#12=CARTESIAN_POINT('',(-2.,0.,1.));\n"
         "#13=CARTESIAN_POINT('',(-2.,0.,0.));\n"
         "#20=VERTEX_POINT('',#10);\n"
         "#21=VERTEX_POINT('',#11);\n"
         "#22=VERTEX_POINT('',#12);\n"
         "#23=VERTEX_POINT('',#13);\n"
         "#30=LINE('',#10,#6);\n"
         "#31=CARTESIAN_POINT('',(0.,0.,1.));\n"
         "#32=AXIS2_PLACEMENT_3D('',#31,#2,#3);\n"
         "#33=CIRCLE('',#32,2.);\n"
         "#34=LINE('',#12,#35);\n"
         "#35=VECTOR('',#36,1.);\n"
         "#36=DIRECTION('',(0.,0.,-1.));\n"
         "#37=CIRCLE('',#4,2.);\n"
         "#40=EDGE_CURVE('',#20,#21,#30,.T.);\n"
         "#41=EDGE_CURVE('',#21,#22,#33,.T.);\n"
         "#42=EDGE_CURVE('',#22,#23,#34,.T.);\n"
         "#43=EDGE_CURVE('',#20,#23,#37,.T.);\n"
         "#50=ORIENTED_EDGE('',*,*,#40,.T.);\n"
         "#51=ORIENTED_EDGE('',*,*,#41,.T.);\n"
         "#52=ORIENTED_EDGE('',*,*,#42,.T.);\n"
         "#53=ORIENTED_EDGE('',*,*,#43,.F.);\n"
         "#60=EDGE_LOOP('',(#50,#51,#52,#53));\n"
         "#61=FACE_OUTER_BOUND('',#60,.T.);\n"
         "#62=ADVANCED_FACE('',(#61),#7,.T.);\n" TAIL;

static double on_cylinder_r2(const double p[3])
{
    return hypot(p[0], p[1]) - 2;
}
static int near_angle_pi(const double p[3])
{
    double a = atan2(p[1], p[0]);
    return a > M_PI - 0.5 && a < M_PI && p[2] > 0 && p[2] < 1;
}

static void test_extrusion_arc_at_pi(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st = {0};
    crisp_status s = read_str(extrusion_arc_at_pi, &m, &st);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces_dropped, 0);
    check_face(m, 0, on_cylinder_r2, 1e-7, near_angle_pi);
    assert_true(st.max_edge_dev < 1e-6);
    crisp_model_destroy(m);
}

/* A face on an extrusion of a closed unclamped B-spline profile (parameters 3.32 to 62.89) whose
 * loop starts at the profile's closure point (face #30200 of Open CASCADE's trj7_k1-sd-214.stp,
 * data/cuts): its first sample took the end 62.89 (the two ends' distances differ by rounding
 * only) and the loop, over [3.32, 33.10], could not run on past it: trims 19.7 off their edges,
 * the face dropped. The end nearer the rest of the loop is taken now. */
static void test_extrusion_closed_profile_start(void **state)
{
    (void)state;
    char *t;
    step_read_stats st = {0};
    loop_check c;
    crisp_model *m =
        read_one_clean_face(CRISP_DATA_DIR "/cuts/occt_trj7_k1_sd_face30200.stp", &t, &st, &c);
    assert_true(st.max_edge_dev < 1e-6);
    crisp_model_destroy(m);
    free(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_half_cone_through_apex),
        cmocka_unit_test(test_cone_sector_three_quarters),
        cmocka_unit_test(test_cone_far_nappe),
        cmocka_unit_test(test_sphere_lune_through_poles),
        cmocka_unit_test(test_hemisphere_near_poles),
        cmocka_unit_test(test_pcurve_off_edge_reprojected),
        cmocka_unit_test(test_open_loop_bridged),
        cmocka_unit_test(test_rational_half_circle_on_plane),
        cmocka_unit_test(test_bspline_closed_both_ways),
        cmocka_unit_test(test_bspline_band_across_seam),
        cmocka_unit_test(test_bspline_strip_through_seam),
        cmocka_unit_test(test_band_seam_clear_of_holes),
        cmocka_unit_test(test_lens_on_long_patch),
        cmocka_unit_test(test_sphere_latitudes_a_turn_away),
        cmocka_unit_test(test_extrusion_arc_at_pi),
        cmocka_unit_test(test_extrusion_closed_profile_start),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
