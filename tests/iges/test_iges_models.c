/* Tests for the IGES reader on the bundled real models: face and hole counts, every loop closed,
 * inside its surface's domain and oriented, no face dropped, and (bearing) the parameter-space
 * trims mapped through the surface lie on the file's model-space curves. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "crisp/io.h"
#include "io/iges/iges_internal.h"

typedef struct model_case {
    const char *file;
    int faces, holes;
} model_case;

static const model_case cases[] = {
    {"occt_bearing.iges", 213, 0}, {"occt_hammer.iges", 45, 3}, {"gpucast_part.igs", 134, 0},
    {"gpucast_teapot.igs", 32, 0}, {"impeller.igs", 277, 2},
};

/* How far dense samples of the loop's curves leave the domain box (the control polygon may leave
 * it while the curve stays inside: bearing.iges has such trims). */
static double sampled_excess(const crisp_trim_loop *loop, const double dom[4])
{
    double worst = 0;
    for (int c = 0; c < loop->curve_count; c++) {
        double t0, t1;
        crisp_curve_domain(loop->curves[c], &t0, &t1);
        for (int k = 0; k <= 200; k++) {
            double q[2];
            crisp_curve_eval(loop->curves[c], t0 + (t1 - t0) * k / 200, q);
            worst = fmax(worst, fmax(fmax(dom[0] - q[0], q[0] - dom[1]),
                                     fmax(dom[2] - q[1], q[1] - dom[3])));
        }
    }
    return worst;
}

/* Every loop closed, inside its domain and oriented; returns the number of faces dropped (skip
 * notes that name a DE). */
static int check_model(const crisp_model *m, const char *file)
{
    double worst_gap = 0, worst_excess = 0, worst_hull = 0;
    for (int i = 0; i < m->face_count; i++) {
        const crisp_face *f = &m->faces[i];
        double dom[4];
        crisp_surface_domain(f->surface, dom);
        double size = fmax(dom[1] - dom[0], dom[3] - dom[2]);
        for (int l = 0; l < f->loop_count; l++) {
            const crisp_trim_loop *loop = &f->loops[l];
            assert_true(loop->curve_count > 0);
            double gap = crisp_trim_loop_closure_gap(loop) / size;
            double excess = sampled_excess(loop, dom) / size;
            double hull = crisp_trim_loop_domain_excess(loop, dom) / size;
            worst_hull = fmax(worst_hull, hull);
            double area = crisp_trim_loop_signed_area(loop);
            worst_gap = fmax(worst_gap, gap);
            worst_excess = fmax(worst_excess, excess);
            if (gap > 1e-9 || excess > 1e-9 || hull > 1e-9 ||
                (loop->is_outer ? area <= 0 : area >= 0))
                fprintf(stderr, "%s: face DE %d loop %d: gap %g excess %g area %g outer %d\n", file,
                        f->source_id, l, gap, excess, area, loop->is_outer);
            assert_true(gap <= 1e-9);
            /* The reader refines trims whose control polygon leaves the domain (bearing: 2%) and
             * moves points out by <= 1e-4 of the domain onto its edge (hammer: a trim dips
             * 4.5e-5 below v = 0); after that the control polygons are inside. */
            assert_true(excess <= 1e-9);
            assert_true(hull <= 1e-9);
            if (loop->is_outer)
                assert_true(area > 0);
            else
                assert_true(area < 0);
        }
    }
    int dropped = 0;
    for (int i = 0; i < m->skip_count; i++) {
        if (!strncmp(m->skips[i].what, "DE ", 3)) dropped += m->skips[i].count;
        fprintf(stderr, "%s: skipped %d x %s\n", file, m->skips[i].count, m->skips[i].what);
    }
    fprintf(stderr,
            "%s: %d faces, worst closure gap %.3g, worst domain excess %.3g (curve) %.3g "
            "(control polygon) of the domain size, %d faces dropped\n",
            file, m->face_count, worst_gap, worst_excess, worst_hull, dropped);
    return dropped;
}

static void test_bundled_models(void **state)
{
    (void)state;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, cases[c].file);
        crisp_model *m = NULL;
        crisp_status st = crisp_read_iges(path, NULL, &m);
        if (st) fprintf(stderr, "%s\n", crisp_error_message());
        assert_int_equal(st, CRISP_OK);
        assert_string_equal(m->format, "IGES");
        crisp_model_stats s;
        assert_int_equal(crisp_model_stats_compute(m, &s), CRISP_OK);
        assert_int_equal(s.faces, cases[c].faces);
        assert_int_equal(s.hole_loops, cases[c].holes);
        assert_int_equal(check_model(m, cases[c].file), 0);
        /* untrimmed teapot patches have no loops; every trimmed face has its outer loop */
        if (!strcmp(cases[c].file, "gpucast_teapot.igs"))
            assert_int_equal(s.outer_loops, 0);
        else
            assert_int_equal(s.outer_loops, cases[c].faces);
        /* impeller's 144s point to a 314 colour definition: 75.29% grey */
        if (!strcmp(cases[c].file, "impeller.igs"))
            for (int i = 0; i < m->face_count; i++) {
                assert_true(m->faces[i].has_color);
                assert_true(fabs(m->faces[i].color[0] - 0.752941f) < 1e-5);
            }
        crisp_model_destroy(m);
    }
}

/* Distance from p to the polyline through dense samples of the curves. */
static double distance_to_curves(const iges_curves *c, const double p[3])
{
    double best = INFINITY;
    for (int i = 0; i < c->count; i++) {
        double t0, t1, prev[3] = {0, 0, 0};
        crisp_curve_domain(c->items[i], &t0, &t1);
        const int n = 400;
        for (int k = 0; k <= n; k++) {
            double q[3];
            crisp_curve_eval(c->items[i], t0 + (t1 - t0) * k / n, q);
            if (k > 0) {
                double d[3], e[3];
                for (int j = 0; j < 3; j++)
                    d[j] = q[j] - prev[j], e[j] = p[j] - prev[j];
                double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                double t = dd > 0 ? (e[0] * d[0] + e[1] * d[1] + e[2] * d[2]) / dd : 0;
                t = t < 0 ? 0 : t > 1 ? 1 : t;
                double r[3];
                for (int j = 0; j < 3; j++)
                    r[j] = prev[j] + t * d[j] - p[j];
                best = fmin(best, sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]));
            }
            memcpy(prev, q, sizeof prev);
        }
    }
    return best;
}

/* bearing.iges gives every trim both ways (142 preference 3): S(B(t)) must lie on C. */
static void test_bearing_pcurves_on_model_curves(void **state)
{
    (void)state;
    char path[1024];
    snprintf(path, sizeof path, "%s/nurbs/occt_bearing.iges", CRISP_DATA_DIR);
    char *data = NULL;
    size_t size = 0;
    assert_int_equal(crisp_read_file(path, &data, &size), CRISP_OK);
    iges_file f;
    assert_int_equal(crisp__iges_file_parse(path, data, size, &f), CRISP_OK);
    crisp_model *m = NULL;
    assert_int_equal(crisp_read_iges(path, NULL, &m), CRISP_OK);
    double box[6];
    crisp_model_bbox(m, box);
    crisp_model_destroy(m);
    const double diag =
        sqrt((box[3] - box[0]) * (box[3] - box[0]) + (box[4] - box[1]) * (box[4] - box[1]) +
             (box[5] - box[2]) * (box[5] - box[2]));
    int checked = 0;
    double worst = 0;
    for (int e = 0; e < f.entity_count; e++) {
        if (f.ents[e].type != 142) continue;
        int sp, bp, cp;
        assert_int_equal(crisp__iges_ptr(&f, e, 2, 0, &sp), CRISP_OK);
        assert_int_equal(crisp__iges_ptr(&f, e, 3, 0, &bp), CRISP_OK);
        assert_int_equal(crisp__iges_ptr(&f, e, 4, 0, &cp), CRISP_OK);
        iges_surface s;
        iges_curves uv = {0}, model = {0};
        assert_int_equal(crisp__iges_surface_convert(&f, sp, 0, &s), CRISP_OK);
        assert_int_equal(crisp__iges_curve_convert(&f, bp, 2, NULL, 0, &uv), CRISP_OK);
        assert_int_equal(crisp__iges_curve_convert(&f, cp, 3, NULL, 0, &model), CRISP_OK);
        for (int i = 0; i < uv.count; i++) {
            double t0, t1;
            crisp_curve_domain(uv.items[i], &t0, &t1);
            for (int k = 0; k <= 10; k++) {
                double q[2], p[3];
                crisp_curve_eval(uv.items[i], t0 + (t1 - t0) * k / 10, q);
                crisp_surface_eval(s.surface, q[0], q[1], p);
                worst = fmax(worst, distance_to_curves(&model, p));
            }
        }
        checked++;
        crisp__iges_curves_free(&uv);
        crisp__iges_curves_free(&model);
        crisp__iges_surface_free(&s);
    }
    fprintf(stderr,
            "bearing: %d curves on surface, worst |S(B(t)) - C| = %.3g (%.3g of the "
            "diagonal)\n",
            checked, worst, worst / diag);
    assert_int_equal(checked, 213);
    /* The file's two representations agree to 6e-6 (its global section states a resolution of
     * 1e-4): within the reader's model-space closure tolerance, 1e-4 of the diagonal. */
    assert_true(worst <= 1e-4 * diag);
    crisp__iges_file_free(&f);
    crisp_free(data);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bundled_models),
        cmocka_unit_test(test_bearing_pcurves_on_model_curves),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
