/* Tests of the B-rep mass properties (crisp_mass_model) on exact rational solids built with
 * construct.h: a sphere, a cylinder closed by two discs (planes trimmed by rational circles, so
 * Green's theorem meets exact trims), and a torus, placed off the origin; volume, centroid and
 * inertia within 1e-9 relative of the analytic values. An open shell gets its area and
 * closed = 0. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "crisp/construct.h"
#include "crisp/io.h"
#include "crisp/mass.h"
#include "crisp/model.h"

static const double PI = 3.14159265358979323846;
static const double O[3] = {0.3, -1.2, 2.5}; /* the solids' centre */

static void add(crisp_model *m, crisp_surface *s, crisp_curve *loop_curve, int reversed)
{
    crisp_face f = {.surface = s, .reversed = reversed};
    if (loop_curve) {
        f.loop_count = 1;
        f.loops = calloc(1, sizeof *f.loops);
        f.loops[0].is_outer = 1;
        f.loops[0].curve_count = 1;
        f.loops[0].curves = calloc(1, sizeof *f.loops[0].curves);
        f.loops[0].curves[0] = loop_curve;
    }
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
}

static crisp_placement at(double dz)
{
    crisp_placement pl;
    double o[3] = {O[0], O[1], O[2] + dz}, z[3] = {0, 0, 1}, x[3] = {1, 0, 0};
    assert_int_equal(crisp_placement_make(o, z, x, &pl), CRISP_OK);
    return pl;
}

static void check(const crisp_model *m, double V, const double I[6], double tol)
{
    crisp_mass_props p;
    assert_int_equal(crisp_mass_model(m, NULL, &p), CRISP_OK);
    fprintf(stderr,
            "closed %d V %.15g (true %.15g, rel %.2g, est %.2g) c %.12g %.12g %.12g I %.12g %.12g "
            "%.12g\n",
            p.closed, p.volume, V, fabs(p.volume - V) / V, p.volume_err, p.centroid[0],
            p.centroid[1], p.centroid[2], p.inertia[0], p.inertia[1], p.inertia[2]);
    assert_true(p.closed);
    assert_true(fabs(p.volume - V) <= tol * V);
    double L = pow(V, 1.0 / 3);
    for (int a = 0; a < 3; a++)
        assert_true(fabs(p.centroid[a] - O[a]) <= tol * L);
    double In = fmax(I[0], fmax(I[1], I[2]));
    for (int k = 0; k < 6; k++)
        assert_true(fabs(p.inertia[k] - I[k]) <= tol * In);
    assert_true(p.volume_err < 1e-6 * V);
}

static void test_sphere(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    crisp_placement pl = at(0);
    crisp_surface *s;
    double r = 1.3;
    assert_int_equal(crisp_make_sphere(&pl, r, 0, 2 * PI, -PI / 2, PI / 2, &s), CRISP_OK);
    add(m, s, NULL, 0);
    double V = 4.0 / 3 * PI * r * r * r, i = 0.4 * V * r * r;
    check(m, V, (double[6]){i, i, i, 0, 0, 0}, 1e-9);
    crisp_model_destroy(m);
    /* half of it: open, area only */
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    assert_int_equal(crisp_make_sphere(&pl, r, 0, 2 * PI, 0, PI / 2, &s), CRISP_OK);
    add(m, s, NULL, 0);
    crisp_mass_props p;
    assert_int_equal(crisp_mass_model(m, NULL, &p), CRISP_OK);
    assert_false(p.closed);
    assert_true(fabs(p.area - 2 * PI * r * r) < 1e-9 * p.area);
    assert_true(p.volume == 0);
    crisp_model_destroy(m);
}

static void test_capped_cylinder(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    double r = 0.7, h = 2.2;
    crisp_placement pl = at(-h / 2);
    crisp_surface *s;
    assert_int_equal(crisp_make_cylinder(&pl, r, 0, 2 * PI, 0, h, &s), CRISP_OK);
    add(m, s, NULL, 0);
    for (int cap = 0; cap < 2; cap++) {
        crisp_placement pc = at(cap ? h / 2 : -h / 2);
        crisp_surface *plane;
        assert_int_equal(crisp_make_plane(&pc, -1, 1, -1, 1, &plane), CRISP_OK);
        crisp_curve *circle;
        const double c[2] = {0, 0}, x[2] = {1, 0}, y[2] = {0, 1};
        assert_int_equal(crisp_make_arc(2, c, x, y, r, r, 0, 2 * PI, &circle), CRISP_OK);
        add(m, plane, circle, cap == 0); /* the bottom disc faces -z */
    }
    double V = PI * r * r * h, ix = V * (3 * r * r + h * h) / 12;
    check(m, V, (double[6]){ix, ix, V * r * r / 2, 0, 0, 0}, 1e-9);
    crisp_model_destroy(m);
}

static void test_torus(void **state)
{
    (void)state;
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    double R = 1.5, r = 0.4;
    crisp_placement pl = at(0);
    crisp_surface *s;
    assert_int_equal(crisp_make_torus(&pl, R, r, 0, 2 * PI, 0, 2 * PI, &s), CRISP_OK);
    add(m, s, NULL, 0);
    double V = 2 * PI * PI * R * r * r, ix = V * (R * R / 2 + 5.0 / 8 * r * r);
    check(m, V, (double[6]){ix, ix, V * (R * R + 0.75 * r * r), 0, 0, 0}, 1e-9);
    crisp_model_destroy(m);
}

/* The bundled models that close (after the readers' orientation fix, branch io): closed, and the
 * volume and inertia Open CASCADE 7.6's BRepGProp gives (adaptive, eps 1e-9; bench/occt_gprop.cpp,
 * 2026-12-01). occt_as1_ec agrees to 1e-11. occt_pro10363: volume to 1e-11, the inertia to
 * 1.4e-8 (crisp's two quadrature orders agree to 1e-14 there, and its shell closes to 3e-11: the
 * difference is left to OCCT's inertia or to the two readers' trims). occt_trj9_io1 closes only to
 * 2.5e-6 (its axis volumes), which volume_err reports and which covers OCCT's volume. Open ones:
 * a tube without ends (no vector area, but no volume along its axis) and occt_screw (closes to the
 * accuracy of its trims, 1.8e-7) are refused. */
static void test_bundled(void **state)
{
    (void)state;
    static const struct {
        const char *file;
        double volume, inertia[3], rel_v, rel_i;
    } closed[] = {
        {"occt_as1_ec.stp",
         764518.029503184,
         {1426199720.82195, 2801526372.79843, 3736232884.49012},
         1e-9,
         1e-9},
        {"occt_pro10363.stp",
         1701057.58994736,
         {7672833670.99076, 23582317512.4241, 27412747551.0942},
         1e-9,
         2e-8},
        {"occt_trj9_io1.stp",
         78179.7287612332,
         {63753415.8914913, 38884988.6781655, 38884028.0183454},
         3e-6,
         3e-5},
    };
    for (size_t i = 0; i < sizeof closed / sizeof closed[0]; i++) {
        char path[512];
        snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, closed[i].file);
        crisp_model *m;
        assert_int_equal(crisp_model_load(path, NULL, &m), CRISP_OK);
        crisp_mass_props p;
        assert_int_equal(crisp_mass_model(m, NULL, &p), CRISP_OK);
        double dv = fabs(p.volume - closed[i].volume) / closed[i].volume;
        fprintf(stderr, "%s: closed %d, volume %.15g +- %.2g (%.2g from OCCT)", closed[i].file,
                p.closed, p.volume, p.volume_err, dv);
        assert_true(p.closed);
        assert_true(dv <= closed[i].rel_v);
        assert_true(fabs(p.volume - closed[i].volume) <= p.volume_err + 1e-9 * p.volume);
        for (int a = 0; a < 3; a++) {
            double di = fabs(p.inertia[a] - closed[i].inertia[a]) / closed[i].inertia[a];
            fprintf(stderr, ", I%c %.2g", "xyz"[a], di);
            assert_true(di <= closed[i].rel_i);
        }
        fprintf(stderr, "\n");
        crisp_model_destroy(m);
    }
    const char *open[2] = {"occt_bug23171_tube_surf.igs", "occt_screw.step"};
    for (int i = 0; i < 2; i++) {
        char path[512];
        snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, open[i]);
        crisp_model *m;
        assert_int_equal(crisp_model_load(path, NULL, &m), CRISP_OK);
        crisp_mass_props p;
        assert_int_equal(crisp_mass_model(m, NULL, &p), CRISP_OK);
        assert_false(p.closed);
        assert_true(p.area > 0);
        assert_true(p.volume == 0);
        crisp_model_destroy(m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere),
        cmocka_unit_test(test_capped_cylinder),
        cmocka_unit_test(test_torus),
        cmocka_unit_test(test_bundled),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
