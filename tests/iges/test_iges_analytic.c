/* Issue 13: IGES analytic surfaces (192 right circular cylinder, 194 cone, 196 sphere, 198 torus)
 * and 140 offset surfaces, on hand-written files: each face is kept, every trim's image lies on
 * the analytic surface (or at the offset distance from the base), and the face covers the side
 * its loop bounds. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/io.h"
#include "crisp/mass.h"
#include "iges/iges_builder.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define N_OF(a) ((int)(sizeof(a) / sizeof((a)[0])))

static crisp_model *load(const test_entity *ents, int n)
{
    char *text = test_iges_build(ents, n);
    crisp_model *m = NULL;
    crisp_status st = crisp_read_iges_mem("test.igs", text, strlen(text), NULL, &m);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    for (int i = 0; i < m->skip_count; i++)
        fprintf(stderr, "note: %s\n", m->skips[i].what);
    free(text);
    return m;
}

typedef double (*implicit_fn)(const double p[3]);

/* Every trim image on f = 0 within tol; returns the surface point at the centre of the loop's
 * (u, v) box in mid. */
static void check_trims(const crisp_face *fc, implicit_fn f, double tol, double mid[3])
{
    double box[4] = {INFINITY, -INFINITY, INFINITY, -INFINITY};
    assert_true(fc->loop_count >= 1);
    for (int l = 0; l < fc->loop_count; l++) {
        assert_true(crisp_trim_loop_closure_gap(&fc->loops[l]) < 1e-9);
        for (int k = 0; k < fc->loops[l].curve_count; k++) {
            const crisp_curve *cv = fc->loops[l].curves[k];
            double t0, t1;
            crisp_curve_domain(cv, &t0, &t1);
            for (int i = 0; i <= 32; i++) {
                double uv[2], p[3];
                crisp_curve_eval(cv, t0 + (t1 - t0) * i / 32, uv);
                crisp_surface_eval(fc->surface, uv[0], uv[1], p);
                assert_true(fabs(f(p)) < tol);
                box[0] = fmin(box[0], uv[0]), box[1] = fmax(box[1], uv[0]);
                box[2] = fmin(box[2], uv[1]), box[3] = fmax(box[3], uv[1]);
            }
        }
    }
    crisp_surface_eval(fc->surface, 0.5 * (box[0] + box[1]), 0.5 * (box[2] + box[3]), mid);
}

/* The loop of a quarter cylinder r = 2 about z, angle 0..90 degrees, z 0..3: the arc at z = 0
 * (100, counter-clockwise), a line up, the arc at z = 3 back (126, rational quadratic), a line
 * down; a 102 chains them. Entities DE 1..11; the 142 (DE 13) lies on surface DE `surf`. */
#define QUARTER_LOOP(surf)                                                                         \
    {100, 0, 0, "00010000", 0, "0.,0.,0.,2.,0.,0.,2.;"},  /* DE 1 */                               \
        {110, 0, 0, "00010000", 0, "0.,2.,0.,0.,2.,3.;"}, /* DE 3 */                               \
        {126,                                                                                      \
         0,                                                                                        \
         0,                                                                                        \
         "00010000",                                                                               \
         0,                                                                                        \
         "2,2,1,0,0,0,0.,0.,0.,1.,1.,1.,1.,0.7071067811865476,1.,0.,2.,3.,2.,2.,3.,2.,0.,3.,0.,1." \
         ",0.,0.,1.;"},                                                                            \
        {110, 0, 0, "00010000", 0, "2.,0.,3.,2.,0.,0.;"}, /* DE 7 */                               \
        {102, 0, 0, "00010000", 0, "4,1,3,5,7;"},         /* DE 9 */                               \
        {116, 0, 0, "00010000", 0, "0.,0.,0.;"},          /* DE 11 */                              \
    {                                                                                              \
        142, 0, 0, "00010500", 0, "0," #surf ",0,9,2;"                                             \
    } /* DE 13 */

static double on_cylinder2(const double p[3])
{
    return hypot(p[0], p[1]) - 2;
}

static void test_cylinder_192(void **state)
{
    (void)state;
    test_entity e[] = {
        QUARTER_LOOP(19),
        {123, 0, 0, "00010000", 0, "0.,0.,1.;"}, /* DE 15 axis */
        {144, 0, 0, NULL, 0, "19,1,0,13;"},      /* DE 17 */
        {192, 0, 0, "00010000", 0, "11,15,2.;"}, /* DE 19 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces_dropped, 0);
    double mid[3];
    check_trims(&m->faces[0], on_cylinder2, 1e-5, mid);
    /* the quarter the loop bounds: angle about 45 degrees, z about 1.5 */
    assert_true(fabs(atan2(mid[1], mid[0]) - M_PI / 4) < 0.1 && fabs(mid[2] - 1.5) < 0.2);
    crisp_model_destroy(m);
}

/* The same quarter as a 143 bounded surface whose 141 boundary gives only the model-space
 * composite curve (no parameter-space curves: their conventions differ for analytic surfaces). */
static void test_cylinder_192_bounded(void **state)
{
    (void)state;
    test_entity e[] = {
        {100, 0, 0, "00010000", 0, "0.,0.,0.,2.,0.,0.,2.;"}, /* DE 1 */
        {110, 0, 0, "00010000", 0, "0.,2.,0.,0.,2.,3.;"},    /* DE 3 */
        {126, 0, 0, "00010000", 0,
         "2,2,1,0,0,0,0.,0.,0.,1.,1.,1.,1.,0.7071067811865476,1.,0.,2.,3.,2.,2.,3.,2.,0.,3.,0.,1."
         ",0.,0.,1.;"},                                   /* DE 5 */
        {110, 0, 0, "00010000", 0, "2.,0.,3.,2.,0.,0.;"}, /* DE 7 */
        {102, 0, 0, "00010000", 0, "4,1,3,5,7;"},         /* DE 9 */
        {116, 0, 0, "00010000", 0, "0.,0.,0.;"},          /* DE 11 */
        {141, 0, 0, "00010500", 0, "0,0,19,1,9,1,0;"},    /* DE 13 */
        {123, 0, 0, "00010000", 0, "0.,0.,1.;"},          /* DE 15 axis */
        {143, 0, 0, NULL, 0, "0,19,1,13;"},               /* DE 17 */
        {192, 0, 0, "00010000", 0, "11,15,2.;"},          /* DE 19 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces_dropped, 0);
    double mid[3];
    check_trims(&m->faces[0], on_cylinder2, 1e-5, mid);
    assert_true(fabs(atan2(mid[1], mid[0]) - M_PI / 4) < 0.1 && fabs(mid[2] - 1.5) < 0.2);
    crisp_model_destroy(m);
}

#define W "0.7071067811865476"
/* A rational quadratic arc (126) from a through control point b to c (90 degrees). */
#define ARC(a, b, c) "2,2,1,0,0,0,0.,0.,0.,1.,1.,1.,1.," W ",1.," a "," b "," c ",0.,1.,0.,0.,1.;"

static double on_cone45(const double p[3])
{
    return hypot(p[0], p[1]) - (2 + p[2]);
}

/* 194: the cone of radius 2 at z = 0, semi-angle 45 degrees (radius 2 + z): the quarter between
 * z = 0 and z = 3 and angles 0..90 degrees. */
static void test_cone_194(void **state)
{
    (void)state;
    test_entity e[] = {
        {100, 0, 0, "00010000", 0, "0.,0.,0.,2.,0.,0.,2.;"},                 /* DE 1 */
        {110, 0, 0, "00010000", 0, "0.,2.,0.,0.,5.,3.;"},                    /* DE 3 */
        {126, 0, 0, "00010000", 0, ARC("0.,5.,3.", "5.,5.,3.", "5.,0.,3.")}, /* DE 5 */
        {110, 0, 0, "00010000", 0, "5.,0.,3.,2.,0.,0.;"},                    /* DE 7 */
        {102, 0, 0, "00010000", 0, "4,1,3,5,7;"},                            /* DE 9 */
        {116, 0, 0, "00010000", 0, "0.,0.,0.;"},                             /* DE 11 */
        {142, 0, 0, "00010500", 0, "0,19,0,9,2;"},                           /* DE 13 */
        {123, 0, 0, "00010000", 0, "0.,0.,1.;"},                             /* DE 15 */
        {144, 0, 0, NULL, 0, "19,1,0,13;"},                                  /* DE 17 */
        {194, 0, 0, "00010000", 0, "11,15,2.,45.;"},                         /* DE 19 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    double mid[3];
    check_trims(&m->faces[0], on_cone45, 1e-5, mid);
    assert_true(fabs(atan2(mid[1], mid[0]) - M_PI / 4) < 0.1 && mid[2] > 0.5 && mid[2] < 2.5);
    crisp_model_destroy(m);
}

static double on_sphere2(const double p[3])
{
    return sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 2;
}

/* 196: the octant x, y, z > 0 of the sphere of radius 2, bounded by the equator's quarter and two
 * meridians meeting at the north pole (where the projection's u jumps). */
static void test_sphere_196_octant(void **state)
{
    (void)state;
    test_entity e[] = {
        {100, 0, 0, "00010000", 0, "0.,0.,0.,2.,0.,0.,2.;"},                 /* DE 1 equator */
        {126, 0, 0, "00010000", 0, ARC("0.,2.,0.", "0.,2.,2.", "0.,0.,2.")}, /* DE 3 meridian up */
        {126, 0, 0, "00010000", 0,
         ARC("0.,0.,2.", "2.,0.,2.", "2.,0.,0.")}, /* DE 5 meridian down */
        {102, 0, 0, "00010000", 0, "3,1,3,5;"},    /* DE 7 */
        {116, 0, 0, "00010000", 0, "0.,0.,0.;"},   /* DE 9 */
        {142, 0, 0, "00010500", 0, "0,17,0,7,2;"}, /* DE 11 */
        {123, 0, 0, "00010000", 0, "0.,0.,1.;"},   /* DE 13 */
        {144, 0, 0, NULL, 0, "17,1,0,11;"},        /* DE 15 */
        {196, 0, 0, "00010000", 0, "9,2.,13;"},    /* DE 17 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    double mid[3];
    check_trims(&m->faces[0], on_sphere2, 1e-5, mid);
    assert_true(mid[0] > 0.1 && mid[1] > 0.1 && mid[2] > 0.1);
    crisp_model_destroy(m);
}

static double on_torus31(const double p[3])
{
    double a = hypot(p[0], p[1]) - 3;
    return sqrt(a * a + p[2] * p[2]) - 1;
}

/* 198: the torus of radii 3 and 1 about z: the patch over angles 0..90 degrees round the axis and
 * 0..90 degrees round the tube (outer equator up to the top circle). */
static void test_torus_198(void **state)
{
    (void)state;
    test_entity e[] = {
        {100, 0, 0, "00010000", 0, "0.,0.,0.,4.,0.,0.,4.;"}, /* DE 1 outer equator */
        {126, 0, 0, "00010000", 0, ARC("0.,4.,0.", "0.,4.,1.", "0.,3.,1.")}, /* DE 3 */
        {126, 0, 0, "00010000", 0,
         ARC("0.,3.,1.", "3.,3.,1.", "3.,0.,1.")}, /* DE 5 top circle back */
        {126, 0, 0, "00010000", 0, ARC("3.,0.,1.", "4.,0.,1.", "4.,0.,0.")}, /* DE 7 */
        {102, 0, 0, "00010000", 0, "4,1,3,5,7;"},                            /* DE 9 */
        {116, 0, 0, "00010000", 0, "0.,0.,0.;"},                             /* DE 11 */
        {142, 0, 0, "00010500", 0, "0,19,0,9,2;"},                           /* DE 13 */
        {123, 0, 0, "00010000", 0, "0.,0.,1.;"},                             /* DE 15 */
        {144, 0, 0, NULL, 0, "19,1,0,13;"},                                  /* DE 17 */
        {198, 0, 0, "00010000", 0, "11,15,3.,1.;"},                          /* DE 19 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    double mid[3];
    check_trims(&m->faces[0], on_torus31, 1e-5, mid);
    assert_true(mid[0] > 0.5 && mid[1] > 0.5 && mid[2] > 0.1 && hypot(mid[0], mid[1]) > 3);
    crisp_model_destroy(m);
}

/* The quarter loop on a cylinder of the same axis offset outwards by 0.5 from radius 1.5 (140
 * over a 192): the offset is exact. */
static void test_offset_of_cylinder(void **state)
{
    (void)state;
    test_entity e[] = {
        QUARTER_LOOP(21),
        {123, 0, 0, "00010000", 0, "0.,0.,1.;"},        /* DE 15 axis */
        {144, 0, 0, NULL, 0, "21,1,0,13;"},             /* DE 17 */
        {192, 0, 0, "00010000", 0, "11,15,1.5;"},       /* DE 19 base */
        {140, 0, 0, "00010000", 0, "0.,0.,0.,0.5,19;"}, /* DE 21 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    double mid[3];
    check_trims(&m->faces[0], on_cylinder2, 1e-5, mid);
    assert_true(fabs(hypot(mid[0], mid[1]) - 2) < 1e-9);
    crisp_model_destroy(m);
}

/* 140 over a 128: the plane z = 0 over [0, 4]^2 (bilinear), offset by 0.25 with the indicator
 * along -z (against S_u x S_v = +z): the plane z = -0.25; its parameter-space trim (the
 * square [0.25, 0.75]^2 of (u, v)) trims it unchanged. */
static void test_offset_of_bspline_plane(void **state)
{
    (void)state;
    test_entity e[] = {
        {128, 0, 0, "00010000", 0,
         "1,1,1,1,0,0,1,0,0,0.,0.,1.,1.,0.,0.,1.,1.,1.,1.,1.,1.,"
         "0.,0.,0.,4.,0.,0.,0.,4.,0.,4.,4.,0.,0.,1.,0.,1.;"},     /* DE 1 */
        {140, 0, 0, "00010000", 0, "0.,0.,-1.,0.25,1;"},          /* DE 3 */
        {110, 0, 0, "00010500", 0, "0.25,0.25,0.,0.75,0.25,0.;"}, /* DE 5 */
        {110, 0, 0, "00010500", 0, "0.75,0.25,0.,0.75,0.75,0.;"}, /* DE 7 */
        {110, 0, 0, "00010500", 0, "0.75,0.75,0.,0.25,0.75,0.;"}, /* DE 9 */
        {110, 0, 0, "00010500", 0, "0.25,0.75,0.,0.25,0.25,0.;"}, /* DE 11 */
        {102, 0, 0, "00010500", 0, "4,5,7,9,11;"},                /* DE 13 */
        {142, 0, 0, "00010500", 0, "1,3,13,0,1;"},                /* DE 15 */
        {144, 0, 0, NULL, 0, "3,1,0,15;"},                        /* DE 17 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    const crisp_surface *s = m->faces[0].surface;
    double dom[4];
    crisp_surface_domain(s, dom);
    for (int a = 0; a <= 8; a++)
        for (int b = 0; b <= 8; b++) {
            double p[3];
            crisp_surface_eval(s, dom[0] + (dom[1] - dom[0]) * a / 8,
                               dom[2] + (dom[3] - dom[2]) * b / 8, p);
            assert_true(fabs(p[2] + 0.25) < 1e-9);
            /* same parametrisation as the base: x = 4 u, y = 4 v */
            /* (up to the rounding of the fit's difference quotients) */
            double want = 4 * (dom[0] + (dom[1] - dom[0]) * a / 8);
            assert_true(fabs(p[0] - want) < 1e-7);
        }
    assert_true(fabs(crisp_trim_loop_signed_area(&m->faces[0].loops[0]) - 0.25) < 1e-9);
    crisp_model_destroy(m);
}

/* 140 over a 120 (the cone of radius 1 + z / 3 about z, z in [0, 3]) by 0.2: a curved base, the
 * fitted offset within the tolerance of the true one: every point at distance 0.2 from the cone. */
static void test_offset_of_revolution(void **state)
{
    (void)state;
    test_entity e[] = {
        {110, 0, 0, "00010000", 0, "0.,0.,0.,0.,0.,1.;"},        /* DE 1 axis */
        {110, 0, 0, "00010000", 0, "1.,0.,0.,2.,0.,3.;"},        /* DE 3 generatrix */
        {120, 0, 0, "00010000", 0, "1,3,0.,3.141592653589793;"}, /* DE 5 */
        {140, 0, 0, NULL, 0, "0.,0.,0.,0.2,5;"},                 /* DE 7 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    const crisp_surface *s = m->faces[0].surface;
    double dom[4], worst = 0;
    crisp_surface_domain(s, dom);
    const double c = 3 / sqrt(10.0); /* cos of the cone's half-angle atan(1/3) */
    for (int a = 0; a <= 20; a++)
        for (int b = 0; b <= 20; b++) {
            double p[3];
            crisp_surface_eval(s, dom[0] + (dom[1] - dom[0]) * a / 20,
                               dom[2] + (dom[3] - dom[2]) * b / 20, p);
            /* distance from the cone's line rho = 1 + z / 3 in the meridian plane */
            double d = fabs((hypot(p[0], p[1]) - 1 - p[2] / 3) * c);
            worst = fmax(worst, fabs(d - 0.2));
        }
    assert_true(worst < 1e-4);
    crisp_model_destroy(m);
}

/* A 144 whose pcurves give three sides of its (u, v) rectangle (Open CASCADE's
 * bug22566_test_Bad.igs DE 351, written out here): a sphere of radius 10 as a 120 revolution of
 * a half circle, the pcurves running from the equator up a meridian to the pole, along the pole
 * and down again half a turn away; the fourth side, half the equator, is missing (20 apart in
 * 3D). The face was dropped ("trim loop not closed"); the gap is bridged as the STEP reader
 * bridges loops the file leaves open (the bridge is under half the loop) and the face is the
 * quarter sphere Open CASCADE draws: area 100 pi. */
static void test_loop_open_by_a_side(void **state)
{
    (void)state;
    const char *dep = "00010000";
    test_entity e[] = {
        {110, 0, 0, dep, 0, "0.,-115.,0.,0.,-125.,0.;"},       /* DE 1 axis */
        {100, 0, 0, dep, 0, "0.,0.,-115.,0.,-105.,0.,-125.;"}, /* DE 3 half circle */
        {120, 0, 0, dep, 0, "1,3,0.,6.28318530717959;"},       /* DE 5 sphere */
        {126, 0, 0, dep, 0,                                    /* DE 7 */
         "1,1,1,0,1,0,0.,0.,1.,1.,1.,1.,3.141592644,3.141592654,0.,1.570796317,3.141592654,0.,"
         "0.,1.,0.,0.,1.;"},
        {126, 0, 0, dep, 0, /* DE 9 */
         "1,1,1,0,1,0,0.,0.,1.,1.,1.,1.,1.570796317,3.141592654,0.,1.570796317,4.71238898,0.,0.,"
         "1.,0.,0.,1.;"},
        {126, 0, 0, dep, 0, /* DE 11 */
         "1,1,1,0,1,0,0.,0.,1.,1.,1.,1.,1.570796317,4.71238898,0.,1.570796317,6.283185307,0.,0.,"
         "1.,0.,0.,1.;"},
        {126, 0, 0, dep, 0, /* DE 13 */
         "1,1,1,0,1,0,0.,0.,1.,1.,1.,1.,1.570796317,6.283185307,0.,3.141592644,6.283185307,0.,"
         "0.,1.,0.,0.,1.;"},
        {102, 0, 0, dep, 0, "4,7,9,11,13;"},                     /* DE 15 pcurves */
        {100, 0, 0, dep, 0, "0.,0.,-115.,0.,-125.,10.,-115.;"},  /* DE 17 */
        {100, 0, 0, dep, 0, "0.,0.,-115.,10.,-115.,0.,-105.;"},  /* DE 19 */
        {100, 0, 0, dep, 0, "0.,0.,-115.,10.,-115.,0.,-105.;"},  /* DE 21 */
        {100, 0, 0, dep, 0, "0.,0.,-115.,-10.,-115.,0.,-125.;"}, /* DE 23 */
        {102, 0, 0, dep, 0, "4,17,19,21,23;"},                   /* DE 25 model space */
        {142, 0, 0, dep, 0, "1,5,15,25,1;"},                     /* DE 27 */
        {144, 0, 0, NULL, 0, "5,1,0,27;"},                       /* DE 29 */
    };
    crisp_model *m = load(e, N_OF(e));
    assert_int_equal(m->face_count, 1);
    assert_int_equal(m->faces_dropped, 0);
    crisp_mass_props mp;
    assert_int_equal(crisp_mass_model(m, NULL, &mp), CRISP_OK);
    assert_true(fabs(mp.area - 100 * M_PI) < 1e-6 * mp.area);
    crisp_model_destroy(m);
}

/* Open CASCADE's bug23171_tube_surf.igs: two 144 faces on 140 offsets (by 6.33) of 120 surfaces
 * of revolution (a tube of radius 100): both faces kept (they were dropped, and their base
 * surfaces drawn as stray faces) and in Open CASCADE 7.6.3's box in y and z: radius 106.33
 * about the axis y = 300, z = 0 (its box is padded by its tolerance along x). */
static void test_offset_tube_file(void **state)
{
    (void)state;
    crisp_model *m = NULL;
    crisp_status st =
        crisp_read_iges(CRISP_DATA_DIR "/nurbs/occt_bug23171_tube_surf.igs", NULL, &m);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    assert_int_equal(m->face_count, 2);
    assert_int_equal(m->faces_dropped, 0);
    double worst = 0;
    for (int f = 0; f < 2; f++) {
        const crisp_surface *s = m->faces[f].surface;
        double d[4];
        crisp_surface_domain(s, d);
        for (int a = 0; a <= 10; a++)
            for (int b = 0; b <= 10; b++) {
                double p[3];
                crisp_surface_eval(s, d[0] + (d[1] - d[0]) * a / 10, d[2] + (d[3] - d[2]) * b / 10,
                                   p);
                worst = fmax(worst, fabs(hypot(p[1] - 300, p[2]) - 106.329494));
            }
    }
    assert_true(worst < 0.01);
    crisp_model_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cylinder_192),
        cmocka_unit_test(test_cylinder_192_bounded),
        cmocka_unit_test(test_cone_194),
        cmocka_unit_test(test_sphere_196_octant),
        cmocka_unit_test(test_torus_198),
        cmocka_unit_test(test_offset_of_cylinder),
        cmocka_unit_test(test_offset_of_bspline_plane),
        cmocka_unit_test(test_offset_of_revolution),
        cmocka_unit_test(test_offset_tube_file),
        cmocka_unit_test(test_loop_open_by_a_side),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
