/* Tests of the OpenSubdiv shim: the bicubic B-spline patches crisp builds must reproduce
 * OpenSubdiv's own limit evaluation (PatchMap + EvaluateBasis) everywhere on their ptex box, and
 * the patch corners at cage vertices must be the exact limit positions (PrimvarRefiner::Limit),
 * measured within 1e-13 on these cages, asserted within 1e-10. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>

#include <cmocka.h>

#include "crisp/osd.h"

static const double cube_pos[] = {-1, -1, -1, 1, -1, -1, 1, 1, -1, -1, 1, -1,
                                  -1, -1, 1,  1, -1, 1,  1, 1, 1,  -1, 1, 1};
static const int cube_sizes[] = {4, 4, 4, 4, 4, 4};
/* CCW seen from outside. */
static const int cube_faces[] = {0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4,
                                 1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7};

/* An open, bumpy 4 x 3 grid of quads plus a triangle and a pentagon hanging off its edges:
 * boundaries, corners, non-quads, and extraordinary vertices. */
static double grid_pos[(5 * 4 + 4) * 3];
static int grid_sizes[12 + 2];
static int grid_faces[12 * 4 + 3 + 5];

static void make_grid(crisp_osd_desc *d)
{
    int n = 0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 5; i++, n++) {
            grid_pos[n * 3 + 0] = i;
            grid_pos[n * 3 + 1] = j;
            grid_pos[n * 3 + 2] = 0.3 * sin(1.7 * i + 0.9 * j) + 0.1 * i * j;
        }
    /* extra vertices 20..23 below the j = 0 row */
    double extra[4][3] = {{0.5, -1, 0.2}, {2, -1.2, 0}, {3, -1.5, 0.4}, {4, -1, -0.1}};
    for (int k = 0; k < 4; k++)
        for (int c = 0; c < 3; c++)
            grid_pos[(20 + k) * 3 + c] = extra[k][c];
    int f = 0, q = 0;
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 4; i++, f++) {
            grid_sizes[f] = 4;
            grid_faces[q++] = j * 5 + i;
            grid_faces[q++] = j * 5 + i + 1;
            grid_faces[q++] = (j + 1) * 5 + i + 1;
            grid_faces[q++] = (j + 1) * 5 + i;
        }
    /* triangle 0, 20, 1 and pentagon 2, 21, 22, 23, 4 ... both below row 0, CCW like the grid */
    grid_sizes[f++] = 3;
    grid_faces[q++] = 0;
    grid_faces[q++] = 20;
    grid_faces[q++] = 1;
    grid_sizes[f++] = 5;
    grid_faces[q++] = 2;
    grid_faces[q++] = 21;
    grid_faces[q++] = 22;
    grid_faces[q++] = 23;
    grid_faces[q++] = 4;
    *d = (crisp_osd_desc){.vertex_count = 24,
                          .positions = grid_pos,
                          .face_count = f,
                          .face_sizes = grid_sizes,
                          .face_vertices = grid_faces};
}

static double dist3(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}

/* Every patch, as a crisp surface, against OpenSubdiv's evaluation at many points. */
static void check_patches_match_limit(const crisp_osd_mesh *m)
{
    int n = crisp_osd_mesh_patch_count(m);
    assert_true(n > 0);
    double worst = 0;
    for (int p = 0; p < n; p++) {
        crisp_surface *s = NULL;
        assert_int_equal(crisp_osd_mesh_patch_surface(m, p, &s), CRISP_OK);
        double dom[4];
        crisp_surface_domain(s, dom);
        assert_true(dom[0] == 0 && dom[1] == 1 && dom[2] == 0 && dom[3] == 1);
        int ptex = -1, base = -1;
        double box[3];
        crisp_osd_mesh_patch_info(m, p, &base, &ptex, box);
        assert_true(ptex >= 0 && ptex < crisp_osd_mesh_ptex_count(m));
        assert_true(base >= 0);
        assert_true(box[2] > 0 && box[0] >= 0 && box[0] + box[2] <= 1 + 1e-12);
        for (int k = 0; k < 7; k++)
            for (int l = 0; l < 7; l++) {
                /* off the 1/3 grid the fit used, plus the box corners */
                double su = k == 6 ? 1.0 : k * 0.161, tv = l == 6 ? 1.0 : l * 0.173;
                double a[3], b[3];
                crisp_surface_eval(s, su, tv, a);
                assert_int_equal(
                    crisp_osd_mesh_eval(m, ptex, box[0] + su * box[2], box[1] + tv * box[2], b),
                    CRISP_OK);
                double d = dist3(a, b);
                if (d > worst) worst = d;
            }
        crisp_surface_destroy(s);
    }
    print_message("worst patch deviation %g\n", worst);
    assert_true(worst < 1e-9);
}

/* Patch corner at a quad's first vertex == PrimvarRefiner::Limit of that vertex. */
static void check_corners_are_limit_points(const crisp_osd_mesh *m, const crisp_osd_desc *d)
{
    double *lim = malloc(sizeof(double) * 3 * d->vertex_count);
    assert_non_null(lim);
    assert_int_equal(crisp_osd_mesh_limit_vertices(m, lim), CRISP_OK);
    int corner = 0, checked = 0;
    for (int f = 0; f < d->face_count; corner += d->face_sizes[f], f++) {
        int ptex = crisp_osd_mesh_ptex_of_face(m, f);
        assert_true(ptex >= 0);
        if (d->face_sizes[f] != 4) {
            /* n-gons: ptex face k has (0,0) at vertex k */
            for (int k = 0; k < d->face_sizes[f]; k++) {
                double p[3];
                assert_int_equal(crisp_osd_mesh_eval(m, ptex + k, 0, 0, p), CRISP_OK);
                assert_true(dist3(p, lim + 3 * d->face_vertices[corner + k]) < 1e-10);
                checked++;
            }
            continue;
        }
        static const double uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        for (int k = 0; k < 4; k++) {
            double p[3];
            assert_int_equal(crisp_osd_mesh_eval(m, ptex, uv[k][0], uv[k][1], p), CRISP_OK);
            assert_true(dist3(p, lim + 3 * d->face_vertices[corner + k]) < 1e-10);
            checked++;
        }
        /* and through the crisp surface of the patch touching ptex (0, 0) */
        for (int p = 0; p < crisp_osd_mesh_patch_count(m); p++) {
            int pt;
            double box[3];
            crisp_osd_mesh_patch_info(m, p, NULL, &pt, box);
            if (pt != ptex || box[0] != 0 || box[1] != 0) continue;
            crisp_surface *s = NULL;
            assert_int_equal(crisp_osd_mesh_patch_surface(m, p, &s), CRISP_OK);
            double q[3];
            crisp_surface_eval(s, 0, 0, q);
            assert_true(dist3(q, lim + 3 * d->face_vertices[corner]) < 1e-10);
            crisp_surface_destroy(s);
        }
    }
    assert_true(checked >= d->face_count);
    free(lim);
}

static void test_cube(void **state)
{
    (void)state;
    crisp_osd_desc d = {.vertex_count = 8,
                        .positions = cube_pos,
                        .face_count = 6,
                        .face_sizes = cube_sizes,
                        .face_vertices = cube_faces,
                        .isolation = 2};
    crisp_osd_mesh *m = NULL;
    assert_int_equal(crisp_osd_mesh_create(&d, &m), CRISP_OK);
    /* every face touches extraordinary (valence 3) corners: 4 x 4 x 6 at level 2 */
    assert_int_equal(crisp_osd_mesh_patch_count(m), 96);
    assert_int_equal(crisp_osd_mesh_ptex_count(m), 6);
    check_patches_match_limit(m);
    check_corners_are_limit_points(m, &d);
    /* the limit surface is symmetric: the face centres all lie at the same distance */
    double c0[3];
    assert_int_equal(crisp_osd_mesh_eval(m, 0, 0.5, 0.5, c0), CRISP_OK);
    for (int f = 1; f < 6; f++) {
        double c[3];
        assert_int_equal(crisp_osd_mesh_eval(m, f, 0.5, 0.5, c), CRISP_OK);
        double z[3] = {0, 0, 0};
        assert_true(fabs(dist3(c, z) - dist3(c0, z)) < 1e-12);
    }
    /* outward orientation: Su x Sv at a face centre points away from the origin */
    for (int p = 0; p < crisp_osd_mesh_patch_count(m); p++) {
        crisp_surface *s = NULL;
        assert_int_equal(crisp_osd_mesh_patch_surface(m, p, &s), CRISP_OK);
        double pt[3], su[3], sv[3], n[3];
        crisp_surface_derivs(s, 0.5, 0.5, pt, su, sv, NULL, NULL, NULL);
        crisp_vec3_cross(su, sv, n);
        assert_true(crisp_vec3_dot(n, pt) > 0);
        crisp_surface_destroy(s);
    }
    crisp_osd_mesh_destroy(m);
}

static void test_open_mixed_mesh(void **state)
{
    (void)state;
    crisp_osd_desc d;
    make_grid(&d);
    for (int iso = 1; iso <= 4; iso += 3) {
        d.isolation = iso;
        crisp_osd_mesh *m = NULL;
        assert_int_equal(crisp_osd_mesh_create(&d, &m), CRISP_OK);
        /* quads: 1 ptex each; triangle 3, pentagon 5 */
        assert_int_equal(crisp_osd_mesh_ptex_count(m), 12 + 3 + 5);
        check_patches_match_limit(m);
        check_corners_are_limit_points(m, &d);
        crisp_osd_mesh_destroy(m);
    }
}

static void test_planar_grid_stays_planar(void **state)
{
    (void)state;
    crisp_osd_desc d;
    make_grid(&d);
    double flat[24 * 3];
    for (int i = 0; i < 24 * 3; i++)
        flat[i] = i % 3 == 2 ? 0.0 : grid_pos[i];
    d.positions = flat;
    crisp_osd_mesh *m = NULL;
    assert_int_equal(crisp_osd_mesh_create(&d, &m), CRISP_OK);
    for (int p = 0; p < crisp_osd_mesh_patch_count(m); p++) {
        double cv[48];
        crisp_osd_mesh_patch_points(m, p, cv);
        for (int k = 0; k < 16; k++)
            assert_true(fabs(cv[k * 3 + 2]) < 1e-12);
    }
    crisp_osd_mesh_destroy(m);
}

static void test_bad_cages_are_rejected(void **state)
{
    (void)state;
    crisp_osd_mesh *m = NULL;
    int out_of_range[] = {0, 1, 2, 8};
    int repeated[] = {0, 1, 1, 2};
    int sizes4[] = {4};
    int sizes2[] = {2};
    crisp_osd_desc d = {.vertex_count = 8,
                        .positions = cube_pos,
                        .face_count = 1,
                        .face_sizes = sizes4,
                        .face_vertices = out_of_range};
    assert_int_equal(crisp_osd_mesh_create(&d, &m), CRISP_ERR_INVALID_ARG);
    assert_null(m);
    d.face_vertices = repeated;
    assert_int_equal(crisp_osd_mesh_create(&d, &m), CRISP_ERR_INVALID_ARG);
    d.face_sizes = sizes2;
    assert_int_equal(crisp_osd_mesh_create(&d, &m), CRISP_ERR_INVALID_ARG);
    double nan_pos[24];
    for (int i = 0; i < 24; i++)
        nan_pos[i] = cube_pos[i];
    nan_pos[5] = NAN;
    crisp_osd_desc dn = {.vertex_count = 8,
                         .positions = nan_pos,
                         .face_count = 6,
                         .face_sizes = cube_sizes,
                         .face_vertices = cube_faces};
    assert_int_equal(crisp_osd_mesh_create(&dn, &m), CRISP_ERR_NUMERIC);
    crisp_osd_desc di = {.vertex_count = 8,
                         .positions = cube_pos,
                         .face_count = 6,
                         .face_sizes = cube_sizes,
                         .face_vertices = cube_faces,
                         .isolation = 11};
    assert_int_equal(crisp_osd_mesh_create(&di, &m), CRISP_ERR_INVALID_ARG);
    /* a non-manifold fan (three quads on one edge) is accepted and still evaluates */
    static const double fan_pos[] = {0,  0, 0, 0,  0, 1, 1, 0, 0, 1, 0, 1,
                                     -1, 0, 0, -1, 0, 1, 0, 1, 0, 0, 1, 1};
    static const int fan_sizes[] = {4, 4, 4};
    static const int fan_faces[] = {0, 2, 3, 1, 1, 5, 4, 0, 0, 6, 7, 1};
    crisp_osd_desc df = {.vertex_count = 8,
                         .positions = fan_pos,
                         .face_count = 3,
                         .face_sizes = fan_sizes,
                         .face_vertices = fan_faces};
    crisp_status st = crisp_osd_mesh_create(&df, &m);
    if (st == CRISP_OK) {
        check_patches_match_limit(m);
        crisp_osd_mesh_destroy(m);
    }
    crisp_osd_mesh_destroy(NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cube),
        cmocka_unit_test(test_open_mixed_mesh),
        cmocka_unit_test(test_planar_grid_stays_planar),
        cmocka_unit_test(test_bad_cages_are_rejected),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
