/* STEP assemblies (step_assembly.c): a hand-written AP214 assembly with two instances of one part
 * (one written with the relationship's representations in the parent-first order), a nested
 * sub-assembly and a MAPPED_ITEM, checked for the number of faces and where each copy lands; a
 * sub-assembly in centimetres; CARTESIAN_TRANSFORMATION_OPERATOR_3D placements (a mirror: the face
 * turns round; a scale); a cycle (loads, with a note); an instance explosion (refused with
 * CRISP_ERR_LIMIT); colours per occurrence; and a real CAx-IF assembly from Open CASCADE's samples
 * (face count and box against Open CASCADE 7.6.3's).
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

#define HEAD                                                                                       \
    "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('test'),'2;1');\n"                                  \
    "FILE_NAME('t','',(''),(''),'','','');\nFILE_SCHEMA(('AUTOMOTIVE_DESIGN'));\nENDSEC;\nDATA;\n"
#define TAIL "ENDSEC;\nEND-ISO-10303-21;\n"

/* data/nurbs/occt_as1_ec.stp (Open CASCADE data/step/trj6_as1-ec-214.stp): Open CASCADE 7.6.3
 * reads 160 faces in the box below (mm). */
#define AS1_FILE "occt_as1_ec.stp"
#define AS1_FACES 160
#define AS1_BOX                                                                                    \
    {                                                                                              \
        -10, 0, -4, 190, 150, 80                                                                   \
    }

/* Geometry: part P is the unit square [0,1]^2 at z = 0, part Q the rectangle [0,2] x [0,1], both
 * bilinear B-spline faces in a MANIFOLD_SURFACE_SHAPE_REPRESENTATION tied to the part's
 * SHAPE_REPRESENTATION by a SHAPE_REPRESENTATION_RELATIONSHIP. */
#define CONTEXTS                                                                                   \
    "#900=(GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNIT_ASSIGNED_CONTEXT((#901)) "              \
    "REPRESENTATION_CONTEXT('',''));\n"                                                            \
    "#901=(LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.));\n"                               \
    "#902=(GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNIT_ASSIGNED_CONTEXT((#903)) "              \
    "REPRESENTATION_CONTEXT('',''));\n"                                                            \
    "#903=(LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.CENTI.,.METRE.));\n"                               \
    "#1=DIRECTION('',(0.,0.,1.));\n#2=DIRECTION('',(1.,0.,0.));\n#3=DIRECTION('',(0.,1.,0.));\n"

#define PARTS                                                                                      \
    "#10=CARTESIAN_POINT('',(0.,0.,0.));\n#11=CARTESIAN_POINT('',(0.,1.,0.));\n"                   \
    "#12=CARTESIAN_POINT('',(1.,0.,0.));\n#13=CARTESIAN_POINT('',(1.,1.,0.));\n"                   \
    "#14=B_SPLINE_SURFACE_WITH_KNOTS('',1,1,((#10,#11),(#12,#13)),.UNSPECIFIED.,.F.,.F.,.F.,"      \
    "(2,2),(2,2),(0.,1.),(0.,1.),.UNSPECIFIED.);\n"                                                \
    "#15=ADVANCED_FACE('',(),#14,.T.);\n#16=OPEN_SHELL('',(#15));\n"                               \
    "#17=SHELL_BASED_SURFACE_MODEL('',(#16));\n"                                                   \
    "#18=MANIFOLD_SURFACE_SHAPE_REPRESENTATION('P geometry',(#17,#19),#900);\n"                    \
    "#19=AXIS2_PLACEMENT_3D('',#10,#1,#2);\n"                                                      \
    "#20=SHAPE_REPRESENTATION('P',(#19),#900);\n"                                                  \
    "#21=SHAPE_REPRESENTATION_RELATIONSHIP('','',#20,#18);\n"                                      \
    "#30=CARTESIAN_POINT('',(0.,0.,0.));\n#31=CARTESIAN_POINT('',(0.,1.,0.));\n"                   \
    "#32=CARTESIAN_POINT('',(2.,0.,0.));\n#33=CARTESIAN_POINT('',(2.,1.,0.));\n"                   \
    "#34=B_SPLINE_SURFACE_WITH_KNOTS('',1,1,((#30,#31),(#32,#33)),.UNSPECIFIED.,.F.,.F.,.F.,"      \
    "(2,2),(2,2),(0.,1.),(0.,1.),.UNSPECIFIED.);\n"                                                \
    "#35=ADVANCED_FACE('',(),#34,.T.);\n#36=OPEN_SHELL('',(#35));\n"                               \
    "#37=SHELL_BASED_SURFACE_MODEL('',(#36));\n"                                                   \
    "#38=MANIFOLD_SURFACE_SHAPE_REPRESENTATION('Q geometry',(#37,#39),#900);\n"                    \
    "#39=AXIS2_PLACEMENT_3D('',#30,#1,#2);\n"                                                      \
    "#40=SHAPE_REPRESENTATION('Q',(#39),#900);\n"                                                  \
    "#41=SHAPE_REPRESENTATION_RELATIONSHIP('','',#40,#38);\n"

/* Product structure: A holds P twice (at (10,0,0); at (0,10,0) turned 90 degrees about z, written
 * parent first) and sub-assembly S at (0,0,100); S holds P at (1,2,3) and, through a MAPPED_ITEM,
 * Q at (5,0,0). */
#define PRODUCTS                                                                                   \
    "#100=PRODUCT_DEFINITION('A','',$,$);\n#101=PRODUCT_DEFINITION('S','',$,$);\n"                 \
    "#102=PRODUCT_DEFINITION('P','',$,$);\n#103=PRODUCT_DEFINITION('Q','',$,$);\n"                 \
    "#110=PRODUCT_DEFINITION_SHAPE('','',#100);\n#111=PRODUCT_DEFINITION_SHAPE('','',#101);\n"     \
    "#112=PRODUCT_DEFINITION_SHAPE('','',#102);\n#113=PRODUCT_DEFINITION_SHAPE('','',#103);\n"     \
    "#120=SHAPE_DEFINITION_REPRESENTATION(#110,#200);\n"                                           \
    "#121=SHAPE_DEFINITION_REPRESENTATION(#111,#210);\n"                                           \
    "#122=SHAPE_DEFINITION_REPRESENTATION(#112,#20);\n"                                            \
    "#123=SHAPE_DEFINITION_REPRESENTATION(#113,#40);\n"                                            \
    "#199=CARTESIAN_POINT('',(0.,0.,0.));\n"                                                       \
    "#201=AXIS2_PLACEMENT_3D('',#199,#1,#2);\n"                                                    \
    "#202=CARTESIAN_POINT('',(10.,0.,0.));\n#203=AXIS2_PLACEMENT_3D('',#202,#1,#2);\n"             \
    "#204=CARTESIAN_POINT('',(0.,10.,0.));\n#205=AXIS2_PLACEMENT_3D('',#204,#1,#3);\n"             \
    "#206=CARTESIAN_POINT('',(0.,0.,100.));\n#207=AXIS2_PLACEMENT_3D('',#206,#1,#2);\n"            \
    "#200=SHAPE_REPRESENTATION('A',(#201,#203,#205,#207),#900);\n"                                 \
    "#211=AXIS2_PLACEMENT_3D('',#199,#1,#2);\n"                                                    \
    "#212=CARTESIAN_POINT('',(" S_P "));\n#213=AXIS2_PLACEMENT_3D('',#212,#1,#2);\n"               \
    "#214=CARTESIAN_POINT('',(" S_Q "));\n#215=AXIS2_PLACEMENT_3D('',#214,#1,#2);\n"               \
    "#216=REPRESENTATION_MAP(#39,#40);\n#217=MAPPED_ITEM('',#216,#215);\n"                         \
    "#210=SHAPE_REPRESENTATION('S',(#211,#213,#217)," S_CTX                                        \
    ");\n" NAUO("300", "#100", "#102", "#20", "#200", "#19", "#203")                               \
        NAUO("310", "#100", "#102", "#200", "#20", "#205", "#19")                                  \
            NAUO("320", "#100", "#101", "#210", "#200", "#211", "#207")                            \
                NAUO("330", "#101", "#102", "#20", "#210", "#19", "#213")

#define NAUO(n, parent, child, rep1, rep2, item1, item2)                                           \
    "#" n "=NEXT_ASSEMBLY_USAGE_OCCURRENCE('" n "','','', " parent "," child ",$);\n"              \
    "#" n "1=PRODUCT_DEFINITION_SHAPE('','',#" n ");\n"                                            \
    "#" n "2=(REPRESENTATION_RELATIONSHIP('',''," rep1 "," rep2 ") "                               \
    "REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION(#" n                                          \
    "3) SHAPE_REPRESENTATION_RELATIONSHIP());\n"                                                   \
    "#" n "3=ITEM_DEFINED_TRANSFORMATION('',''," item1 "," item2 ");\n"                            \
    "#" n "4=CONTEXT_DEPENDENT_SHAPE_REPRESENTATION(#" n "2,#" n "1);\n"

#define S_P "1.,2.,3."
#define S_Q "5.,0.,0."
#define S_CTX "#900"
static const char *const assembly[] = {HEAD CONTEXTS, PARTS, PRODUCTS, TAIL, NULL};
#undef S_P
#undef S_Q
#undef S_CTX

/* The same with S in centimetres: its placements are written in cm. */
#define S_P "0.1,0.2,0.3"
#define S_Q "0.5,0.,0."
#define S_CTX "#902"
static const char *const assembly_cm[] = {HEAD CONTEXTS, PARTS, PRODUCTS, TAIL, NULL};

/* Read the concatenation of pieces (each under C's 4095-character literal limit). */
static crisp_status read_str(const char *const *pieces, crisp_model **m)
{
    size_t len = 0;
    for (int i = 0; pieces[i]; i++)
        len += strlen(pieces[i]);
    char *text = malloc(len + 1);
    assert_non_null(text);
    text[0] = '\0';
    for (int i = 0; pieces[i]; i++)
        strcat(text, pieces[i]);
    crisp_status st = crisp__step_read_mem("assembly.stp", text, len, NULL, m, NULL);
    free(text);
    return st;
}

/* Index of the face whose surface has corners (u,v) = (0,0) at a and (1,0) at b, or -1. */
static int find_face(const crisp_model *m, const double a[3], const double b[3], unsigned *used)
{
    for (int i = 0; i < m->face_count; i++) {
        double p[3], q[3], d[4];
        if (*used & (1u << i)) continue;
        crisp_surface_domain(m->faces[i].surface, d);
        crisp_surface_eval(m->faces[i].surface, d[0], d[2], p);
        crisp_surface_eval(m->faces[i].surface, d[1], d[2], q);
        double e = 0;
        for (int k = 0; k < 3; k++)
            e = fmax(e, fmax(fabs(p[k] - a[k]), fabs(q[k] - b[k])));
        if (e < 1e-9) {
            *used |= 1u << i;
            return i;
        }
    }
    return -1;
}

static void check_placed(const crisp_model *m)
{
    assert_int_equal(m->face_count, 4);
    static const double corners[4][2][3] = {
        {{10, 0, 0}, {11, 0, 0}},   /* P in A */
        {{0, 10, 0}, {0, 11, 0}},   /* P in A, turned: x -> y */
        {{1, 2, 103}, {2, 2, 103}}, /* P in S in A */
        {{5, 0, 100}, {7, 0, 100}}, /* Q mapped into S in A */
    };
    unsigned used = 0;
    for (int k = 0; k < 4; k++) {
        int i = find_face(m, corners[k][0], corners[k][1], &used);
        if (i < 0)
            fail_msg("no face with corners (%g %g %g) (%g %g %g)", corners[k][0][0],
                     corners[k][0][1], corners[k][0][2], corners[k][1][0], corners[k][1][1],
                     corners[k][1][2]);
        assert_int_equal(m->faces[i].reversed, 0); /* rigid motions keep the orientation */
    }
}

static void test_assembly_placements(void **state)
{
    (void)state;
    crisp_model *m = NULL;
    assert_int_equal(read_str(assembly, &m), CRISP_OK);
    check_placed(m);
    assert_true(fabs(m->unit_to_mm - 1) < 1e-12);
    crisp_model_destroy(m);
}

static void test_assembly_units(void **state)
{
    (void)state;
    crisp_model *m = NULL;
    assert_int_equal(read_str(assembly_cm, &m), CRISP_OK);
    check_placed(m);
    crisp_model_destroy(m);
}

/* Colours per occurrence (issue 13): part P's face is blue (a STYLED_ITEM on the face); the copy of
 * P placed by NAUO 300 is red (a CONTEXT_DEPENDENT_OVER_RIDING_STYLED_ITEM on the face in the
 * context of that NAUO's relationship); Q, placed by a MAPPED_ITEM, is green (a STYLED_ITEM on the
 * MAPPED_ITEM); the copy of P in S is yellow (a STYLED_ITEM on NAUO 330). The other copy of P
 * keeps its part's blue. */
#define STYLE(n, colour)                                                                           \
    "#" n "0=COLOUR_RGB(''," colour ");\n#" n "1=FILL_AREA_STYLE_COLOUR('',#" n "0);\n"            \
    "#" n "2=FILL_AREA_STYLE('',(#" n "1));\n#" n "3=SURFACE_STYLE_FILL_AREA(#" n "2);\n"          \
    "#" n "4=SURFACE_SIDE_STYLE('',(#" n "3));\n#" n "5=SURFACE_STYLE_USAGE(.BOTH.,#" n "4);\n"    \
    "#" n "6=PRESENTATION_STYLE_ASSIGNMENT((#" n "5));\n"

static void test_occurrence_colours(void **state)
{
    (void)state;
    static const char *const coloured[] = {
        HEAD CONTEXTS, PARTS, PRODUCTS,
        // clang-format off
        STYLE("80", "0.,0.,1.") "#807=STYLED_ITEM('',(#806),#15);\n"
        STYLE("81", "1.,0.,0.") "#817=CONTEXT_DEPENDENT_OVER_RIDING_STYLED_ITEM('',(#816),#15,#807,(#3002));\n"
        STYLE("82", "0.,1.,0.") "#827=STYLED_ITEM('',(#826),#217);\n"
        STYLE("83", "1.,1.,0.") "#837=STYLED_ITEM('',(#836),#330);\n",
        // clang-format on
        TAIL, NULL};
    crisp_model *m = NULL;
    assert_int_equal(read_str(coloured, &m), CRISP_OK);
    check_placed(m);
    static const double corners[4][2][3] = {{{10, 0, 0}, {11, 0, 0}},
                                            {{0, 10, 0}, {0, 11, 0}},
                                            {{1, 2, 103}, {2, 2, 103}},
                                            {{5, 0, 100}, {7, 0, 100}}};
    static const float want[4][3] = {{1, 0, 0}, {0, 0, 1}, {1, 1, 0}, {0, 1, 0}};
    unsigned used = 0;
    for (int k = 0; k < 4; k++) {
        int i = find_face(m, corners[k][0], corners[k][1], &used);
        assert_true(i >= 0);
        assert_true(m->faces[i].has_color);
        for (int c = 0; c < 3; c++)
            assert_true(fabsf(m->faces[i].color[c] - want[k][c]) < 1e-6f);
    }
    crisp_model_destroy(m);
}

/* Without any product structure the file loads as before: each face once, where it is. */
static void test_no_assembly(void **state)
{
    (void)state;
    static const char *const plain[] = {HEAD CONTEXTS, PARTS, TAIL, NULL};
    crisp_model *m = NULL;
    assert_int_equal(read_str(plain, &m), CRISP_OK);
    assert_int_equal(m->face_count, 2);
    double lo[3] = {0, 0, 0}, hi[3] = {1, 0, 0}, hi2[3] = {2, 0, 0};
    unsigned used = 0;
    assert_true(find_face(m, lo, hi, &used) >= 0);
    assert_true(find_face(m, lo, hi2, &used) >= 0);
    crisp_model_destroy(m);
}

/* P placed in Q and Q in P: no root, no hang; each face once, with a note of the cycle. */
static void test_cycle(void **state)
{
    (void)state;
    static const char *const cyc[] = {
        HEAD CONTEXTS, PARTS,
        "#202=CARTESIAN_POINT('',(10.,0.,0.));\n#203=AXIS2_PLACEMENT_3D('',#202,#1,#2);\n"
        "#50=MAPPED_ITEM('',#51,#203);\n#51=REPRESENTATION_MAP(#19,#20);\n"
        "#52=MAPPED_ITEM('',#53,#203);\n#53=REPRESENTATION_MAP(#39,#40);\n"
        "#60=SHAPE_REPRESENTATION('loop "
        "P',(#52),#900);\n#61=SHAPE_REPRESENTATION_RELATIONSHIP('','',#60,#20);\n"
        "#62=SHAPE_REPRESENTATION('loop "
        "Q',(#50),#900);\n#63=SHAPE_REPRESENTATION_RELATIONSHIP('','',#62,#40);\n"
        "#54=MAPPED_ITEM('',#51,#203);\n#70=SHAPE_REPRESENTATION('top',(#54),#900);\n",
        TAIL, NULL};
    crisp_model *m = NULL;
    assert_int_equal(read_str(cyc, &m), CRISP_OK);
    /* top places P at x + 10; P's group places Q (x + 20), Q's places P again: cut there. */
    assert_int_equal(m->face_count, 2);
    int noted = 0;
    for (int i = 0; i < m->skip_count; i++)
        noted |= strstr(m->skips[i].what, "cycle") != NULL;
    assert_true(noted);
    crisp_model_destroy(m);
}

/* CARTESIAN_TRANSFORMATION_OPERATOR_3D: as a relationship's transformation, mirroring (axis2 =
 * -y: the face's orientation flips), and as a MAPPED_ITEM's target with scale 2. */
static void test_cartesian_operator(void **state)
{
    (void)state;
    static const char *const cto[] = {
        HEAD CONTEXTS, PARTS,
        "#63=DIRECTION('',(0.,-1.,0.));\n#64=CARTESIAN_POINT('',(0.,0.,5.));\n"
        "#62=CARTESIAN_TRANSFORMATION_OPERATOR_3D('',#2,#63,#64,1.,#1);\n"
        "#61=(REPRESENTATION_RELATIONSHIP('','',#20,#60) "
        "REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION(#62) "
        "SHAPE_REPRESENTATION_RELATIONSHIP());\n"
        "#65=CARTESIAN_POINT('',(0.,0.,-5.));\n#66=CARTESIAN_TRANSFORMATION_OPERATOR_3D('',#2,#3,#"
        "65,2.,#1);\n"
        "#67=REPRESENTATION_MAP(#39,#40);\n#68=MAPPED_ITEM('',#67,#66);\n"
        "#60=SHAPE_REPRESENTATION('top',(#19,#68),#900);\n",
        TAIL, NULL};
    crisp_model *m = NULL;
    assert_int_equal(read_str(cto, &m), CRISP_OK);
    assert_int_equal(m->face_count, 2);
    static const double p0[3] = {0, 0, 5}, p1[3] = {1, 0, 5}, q0[3] = {0, 0, -5},
                        q1[3] = {4, 0, -5};
    unsigned used = 0;
    int ip = find_face(m, p0, p1, &used), iq = find_face(m, q0, q1, &used);
    assert_true(ip >= 0 && iq >= 0);
    double d[4], c[3];
    crisp_surface_domain(m->faces[ip].surface, d);
    crisp_surface_eval(m->faces[ip].surface, d[0], d[3], c); /* (0, 1) of P, mirrored to y = -1 */
    assert_true(fabs(c[0]) < 1e-12 && fabs(c[1] + 1) < 1e-12 && fabs(c[2] - 5) < 1e-12);
    assert_int_equal(m->faces[ip].reversed, 1);
    crisp_surface_domain(m->faces[iq].surface, d);
    crisp_surface_eval(m->faces[iq].surface, d[0], d[3], c); /* (0, 1) of Q, scaled to y = 2 */
    assert_true(fabs(c[0]) < 1e-12 && fabs(c[1] - 2) < 1e-12 && fabs(c[2] + 5) < 1e-12);
    assert_int_equal(m->faces[iq].reversed, 0);
    crisp_model_destroy(m);
}

/* Thirty levels, each holding the next twice: 2^30 copies are refused before any is made. */
static void test_explosion(void **state)
{
    (void)state;
    size_t cap = 1 << 16, len = 0;
    char *s = malloc(cap);
    assert_non_null(s);
    len += (size_t)snprintf(s + len, cap - len, "%s%s%s", HEAD, CONTEXTS, PARTS);
    for (int i = 0; i < 30; i++) {
        int rep = 1000 + 10 * i, child = i == 29 ? 20 : 1000 + 10 * (i + 1),
            childax = i == 29 ? 19 : 1009 + 10 * (i + 1);
        len += (size_t)snprintf(
            s + len, cap - len,
            "#%d=SHAPE_REPRESENTATION('',(#%d,#%d,#%d),#900);\n#%d=REPRESENTATION_MAP(#%d,#%d);\n"
            "#%d=MAPPED_ITEM('',#%d,#%d);\n#%d=MAPPED_ITEM('',#%d,#%d);\n"
            "#%d=AXIS2_PLACEMENT_3D('',#10,#1,#2);\n",
            rep, rep + 9, rep + 2, rep + 3, rep + 1, childax, child, rep + 2, rep + 1, rep + 9,
            rep + 3, rep + 1, rep + 9, rep + 9);
    }
    len += (size_t)snprintf(s + len, cap - len, "%s", TAIL);
    assert_true(len < cap);
    crisp_model *m = NULL;
    crisp_status st = crisp__step_read_mem("explode.stp", s, len, NULL, &m, NULL);
    assert_int_equal(st, CRISP_ERR_LIMIT);
    assert_non_null(strstr(crisp_error_message(), "explode.stp"));
    assert_null(m);
    free(s);
}

/* A real AP214 assembly (CAx-IF round 6, AS1): 18 part instances of 5 parts. */
static void test_as1(void **state)
{
    (void)state;
    crisp_model *m = NULL;
    assert_int_equal(crisp_read_step(CRISP_DATA_DIR "/nurbs/" AS1_FILE, NULL, &m), CRISP_OK);
    assert_int_equal(m->face_count, AS1_FACES);
    double box[6];
    crisp_model_bbox(m, box);
    /* Open CASCADE's exact box; ours is the control points' box: it may only be larger, and by
     * less than the bulge of rational arcs. */
    static const double occt[6] = AS1_BOX;
    for (int k = 0; k < 3; k++) {
        assert_true(box[k] <= occt[k] + 1e-3 && box[k] > occt[k] - 3);
        assert_true(box[3 + k] >= occt[3 + k] - 1e-3 && box[3 + k] < occt[3 + k] + 3);
    }
    crisp_model_destroy(m);
}

/* The assembly tree (crisp_model.occurrences): as1's product occurrences, named by their
 * NEXT_ASSEMBLY_USAGE_OCCURRENCE, parents first; every bolt sits in a nut-bolt assembly (a nut
 * also in the rod assembly),
 * every face copy names the occurrence it was placed for, and each nut copy has the same faces. */
static void test_as1_occurrences(void **state)
{
    (void)state;
    crisp_model *m = NULL;
    assert_int_equal(crisp_read_step(CRISP_DATA_DIR "/nurbs/" AS1_FILE, NULL, &m), CRISP_OK);
    assert_true(m->occurrence_count > 0);
    int nuts = 0, bolts = 0, nb = 0, brackets = 0, nut_faces = -1;
    for (int k = 0; k < m->occurrence_count; k++) {
        const crisp_occurrence *o = &m->occurrences[k];
        assert_non_null(o->name);
        assert_true(o->parent >= -1 && o->parent < k);
        int nut = !strcmp(o->name, "-> Nut"), bolt = !strcmp(o->name, "-> Bolt");
        nuts += nut, bolts += bolt;
        nb += !strcmp(o->name, "-> Nut-Bolt Assembly");
        brackets += !strcmp(o->name, "-> L-Bracket");
        if (nut || bolt) {
            assert_true(o->parent >= 0);
            const char *p = m->occurrences[o->parent].name;
            if (bolt || strcmp(p, "-> Rod Assembly"))
                assert_string_equal(p, "-> Nut-Bolt Assembly");
        }
        if (nut) {
            int n = 0;
            for (int f = 0; f < m->face_count; f++)
                n += m->faces[f].occurrence == k + 1;
            assert_true(n > 0);
            if (nut_faces >= 0) assert_int_equal(n, nut_faces);
            nut_faces = n;
        }
    }
    for (int f = 0; f < m->face_count; f++)
        assert_true(m->faces[f].occurrence >= 1 && m->faces[f].occurrence <= m->occurrence_count);
    printf("as1: %d occurrences: %d nut-bolt assemblies (%d nuts, %d bolts), %d L-brackets; "
           "%d faces per nut\n",
           m->occurrence_count, nb, nuts, bolts, brackets, nut_faces);
    /* 2 L-bracket assemblies of 1 bracket and 3 nut-bolt assemblies each, 1 rod assembly with 2
     * nuts (the file's product structure) */
    assert_int_equal(nb, 6);
    assert_int_equal(bolts, 6);
    assert_int_equal(nuts, 8);
    assert_int_equal(brackets, 2);
    crisp_model_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_assembly_placements),
        cmocka_unit_test(test_assembly_units),
        cmocka_unit_test(test_no_assembly),
        cmocka_unit_test(test_cycle),
        cmocka_unit_test(test_cartesian_operator),
        cmocka_unit_test(test_explosion),
        cmocka_unit_test(test_as1),
        cmocka_unit_test(test_as1_occurrences),
        cmocka_unit_test(test_occurrence_colours),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
