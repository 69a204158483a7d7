/* The STEP reader on the bundled models (data/nurbs): occt_linkrods.step (AP214, OCCT, pcurves
 * on every edge) loads as a closed shell of 37 faces and Ventilator.stp (AP203, CATIA, no PCURVE)
 * as 305 faces whose trims all come from projecting the 3D edges. Every loop is closed, inside its
 * surface's domain and oriented; every trim's image on its surface lies on its 3D edge.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "io/step/step_internal.h"
#include "step/test_step_util.h"

static void load(const char *file, step_read_stats *stats, crisp_model **m)
{
    char path[1024], *data;
    size_t size;
    snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, file);
    assert_int_equal(crisp_read_file(path, &data, &size), CRISP_OK);
    stats->verify = 1;
    crisp_status st = crisp__step_read_mem(path, data, size, NULL, m, stats);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    crisp_free(data);
    printf(
        "%s: %d faces, %d pcurve / %d projected edge uses, %d pcurves rejected, %d faces dropped, "
        "max trim-to-edge distance %.3g (tolerance %.3g; edges lie up to %.3g off their surfaces "
        "in the file), parse %.1f ms, total %.1f ms\n",
        file, (*m)->face_count, stats->pcurve_edges, stats->projected_edges,
        stats->rejected_pcurves, stats->dropped_faces, stats->max_edge_dev, stats->tol,
        stats->max_edge_gap, stats->parse_seconds * 1e3, stats->total_seconds * 1e3);
    for (int k = 0; k < (*m)->skip_count; k++)
        printf("  skipped %d x %s\n", (*m)->skips[k].count, (*m)->skips[k].what);
}

static void check_loops(const crisp_model *m, loop_check *c)
{
    check_model_loops(m, 1e-6, 1e-9, c);
    printf(
        "  loops %d (%d outer, %d holes), %d curves; largest gap %.3g, largest domain excess %.3g "
        "(fractions of the domain)\n",
        c->loops, c->outer, c->holes, c->curves, c->max_gap_rel, c->max_excess_rel);
    assert_int_equal(c->open_loops, 0);
    assert_int_equal(c->outside_loops, 0);
    assert_int_equal(c->misoriented_loops, 0);
    for (int f = 0; f < m->face_count; f++) {
        int outer = 0;
        for (int l = 0; l < m->faces[f].loop_count; l++)
            outer += m->faces[f].loops[l].is_outer;
        assert_int_equal(outer, 1);
    }
}

static void test_linkrods(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st;
    load("occt_linkrods.step", &st, &m);
    assert_string_equal(m->format, "STEP");
    assert_int_equal(m->face_count, 37);
    assert_int_equal(st.dropped_faces, 0);
    assert_true(m->unit_to_mm == 1.0);
    /* Every face of the closed shell: no skipped shell members. */
    assert_int_equal(m->skip_count, 0);
    /* Every edge use (216 ORIENTED_EDGEs) has a pcurve in this file. Some pcurves on B-spline
     * surfaces do not follow their 3D edge (up to 0.047 off: the surfaces were re-approximated
     * when the file was written); those edges are projected instead. */
    assert_int_equal(st.pcurve_edges + st.projected_edges, 216);
    assert_int_equal(st.projected_edges, st.rejected_pcurves);
    assert_true(st.pcurve_edges >= 150);
    loop_check c;
    check_loops(m, &c);
    assert_int_equal(c.loops, 42);
    assert_int_equal(c.holes, 5);
    assert_true(st.max_edge_dev <= 10 * st.tol);
    crisp_model_destroy(m);
}

static void test_ventilator(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st;
    load("Ventilator.stp", &st, &m);
    assert_int_equal(m->face_count, 305);
    assert_int_equal(st.dropped_faces, 0);
    assert_true(m->unit_to_mm == 1.0);
    /* No PCURVE in the file: every trim is projected from its 3D edge (1580 ORIENTED_EDGEs). */
    assert_int_equal(st.pcurve_edges, 0);
    assert_int_equal(st.projected_edges, 1580);
    loop_check c;
    check_loops(m, &c);
    assert_int_equal(c.loops, 309);
    assert_int_equal(c.holes, 4);
    assert_true(st.max_edge_dev <= 10 * st.tol);
    crisp_model_destroy(m);
}

/* OCCT's CAx-IF test round files, each a case a plain B-rep reader drops: */

/* A geometrically bounded surface model (no topology): 44 CURVE_BOUNDED_SURFACEs in a GEOMETRIC_SET
 * on quasi-uniform and rational B-spline, spherical and other surfaces, with boundaries given as 3D
 * curves only (.CURVE_3D.): sphere caps closed at the pole, bands between two circles on closed
 * B-spline patches, arcs through a pole. */
static void test_curve_bounded_model(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st;
    load("occt_trj4_k1_geo_tu.stp", &st, &m);
    assert_int_equal(m->face_count, 44);
    assert_int_equal(st.dropped_faces, 0);
    assert_true(m->unit_to_mm == 25.4);
    assert_int_equal(st.pcurve_edges, 0);
    loop_check c;
    check_loops(m, &c);
    assert_int_equal(c.holes, 6);
    assert_true(st.max_edge_dev <= 10 * st.tol);
    crisp_model_destroy(m);
}

/* Pro/ENGINEER 1997 curve-bounded surfaces on planes, cylinders, cones, a sphere, a torus and
 * B-splines, whose boundary segments mostly carry the wrong same_sense: they are turned round to
 * chain (the flip count is what the file needs, so a change shows). */
static void test_curve_bounded_senses(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st;
    load("occt_bm2_pe_t4_b.stp", &st, &m);
    assert_int_equal(m->face_count, 9);
    assert_int_equal(st.dropped_faces, 0);
    assert_true(st.flipped_segments > 0);
    loop_check c;
    check_loops(m, &c);
    assert_int_equal(c.holes, 3);
    assert_true(st.max_edge_dev <= 10 * st.tol);
    crisp_model_destroy(m);
}

/* A solid of quasi-uniform B-spline faces without pcurves: closed cylinder patches whose seam
 * edge is used twice in one loop (its two projections must land on opposite sides). */
static void test_closed_bspline_seams(void **state)
{
    (void)state;
    crisp_model *m;
    step_read_stats st;
    load("occt_trj9_io1.stp", &st, &m);
    assert_int_equal(m->face_count, 17);
    assert_int_equal(st.dropped_faces, 0);
    assert_int_equal(st.pcurve_edges, 0);
    loop_check c;
    check_loops(m, &c);
    assert_int_equal(c.loops, 34);
    assert_true(st.max_edge_dev <= 10 * st.tol);
    /* The cylinder faces span their whole closed direction: the loop's area is the domain's. */
    int full = 0;
    for (int f = 0; f < m->face_count; f++) {
        double d[4];
        crisp_surface_domain(m->faces[f].surface, d);
        if (m->faces[f].loop_count == 1 && m->faces[f].loops[0].curve_count == 4 &&
            fabs(crisp_trim_loop_signed_area(&m->faces[f].loops[0]) -
                 (d[1] - d[0]) * (d[3] - d[2])) < 1e-6 * (d[1] - d[0]) * (d[3] - d[2]))
            full++;
    }
    assert_true(full >= 6);
    crisp_model_destroy(m);
}

/* Issue 13, on real files from Open CASCADE's samples: PRO10363.stp (CATIA V4) has two half cones
 * bounded by a half circle and two generators meeting at the apex (both were dropped: "winds
 * around the u direction without a seam edge"); screw.step has faces on a cone's far nappe and on
 * a spindle torus (4 of 10 were dropped: "the trim lies 3.09 from the edge"). Open CASCADE 7.6.3:
 * 15 and 10 faces. */
static void test_issue13_models(void **state)
{
    (void)state;
    static const struct {
        const char *file;
        int faces;
    } files[] = {{"occt_pro10363.stp", 15}, {"occt_screw.step", 10}};
    for (int i = 0; i < 2; i++) {
        crisp_model *m;
        step_read_stats st;
        load(files[i].file, &st, &m);
        assert_int_equal(m->face_count, files[i].faces);
        assert_int_equal(m->faces_dropped, 0);
        loop_check c;
        check_loops(m, &c);
        assert_true(st.max_edge_dev <= 20 * st.tol);
        crisp_model_destroy(m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_linkrods),
        cmocka_unit_test(test_ventilator),
        cmocka_unit_test(test_curve_bounded_model),
        cmocka_unit_test(test_curve_bounded_senses),
        cmocka_unit_test(test_closed_bspline_seams),
        cmocka_unit_test(test_issue13_models),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
