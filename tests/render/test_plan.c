/* The public frame plan (include/crisp/plan.h): every level within 1..64 (high crack-free levels
 * become leaf splits), leaves grouped by face, no leaf over CRISP_PLAN_MAX_LEAF_PX on screen,
 * crack-free edges (the vertices two leaves place on a shared edge coincide), the flat trim
 * lookup equal to the face's own table, versions that move only with content, and re-planning one
 * edited face equal to planning the whole scene again. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_test_util.h"
#include "crisp/io.h"
#include "crisp/plan.h"
#include "crisp/trim.h"
#include "render/planner.h"
#include "render/render_internal.h"

static uint64_t rng = 88172645463325252ull;
static double rnd(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* Cameras: the default view, a close-up on a point of the model, a grazing close-up, and extreme
 * zooms (fov 1e-2 and 1e-4 degrees) onto a surface point. */
static int cameras(const crisp_scene *sc, crisp_camera *cams, int w, int h)
{
    int n = 0;
    assert_int_equal(crisp_camera_frame_box(sc->box, w, h, &cams[n]), CRISP_OK);
    n++;
    const crisp_scene_patch *sp = &sc->patches[sc->patch_count / 3];
    double P[3];
    crisp_bezier_patch_eval(&sp->bez, 0.37, 0.61, P);
    double size = 0;
    for (int k = 0; k < 3; k++)
        size = fmax(size, sc->box[k + 3] - sc->box[k]);
    static const double dirs[4][3] = {
        {0.3, 0.4, 1.0}, {1.0, 0.05, 0.02}, {0.2, -1.0, 0.3}, {-0.5, 0.5, 0.7}};
    static const double dist[4] = {0.05, 0.02, 0.3, 0.3};
    static const double fov[4] = {40, 60, 1e-2, 1e-4};
    for (int c = 0; c < 4; c++) {
        crisp_camera *cam = &cams[n++];
        double d =
            sqrt(dirs[c][0] * dirs[c][0] + dirs[c][1] * dirs[c][1] + dirs[c][2] * dirs[c][2]);
        for (int k = 0; k < 3; k++) {
            cam->eye[k] = P[k] + dist[c] * size * dirs[c][k] / d;
            cam->target[k] = P[k];
        }
        cam->up[0] = 0, cam->up[1] = 0, cam->up[2] = 1;
        if (fabs(dirs[c][2] / d) > 0.9) cam->up[1] = 1, cam->up[2] = 0;
        cam->fov_deg = fov[c];
        cam->znear = 1e-4 * dist[c] * size;
        cam->zfar = 10 * size;
        cam->width = w, cam->height = h;
    }
    return n;
}

/* Screen extent of leaf L's control hull (pixels, largest of x and y); -1 when it reaches the
 * eye plane. */
static double leaf_extent(const crisp_scene *sc, const crisp_frame_plan *plan,
                          const crisp_plan_leaf *L)
{
    double storage[2 * CRISP__PATCH_DOUBLES], tmp[CRISP__PATCH_DOUBLES];
    double sz = ldexp(1.0, -(int)L->depth);
    crisp_bezier_patch sub;
    crisp__subpatch(&sc->patches[L->patch].bez, L->ix * sz, (L->ix + 1) * sz, L->iy * sz,
                    (L->iy + 1) * sz, storage, tmp, &sub);
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < (sub.du + 1) * (sub.dv + 1); i++) {
        double c[4];
        crisp_mat4_mulv(*(crisp_mat4 *)&plan->view_proj, sub.cpw + 4 * i, c);
        if (!(c[3] > 0)) return -1;
        lo[0] = fmin(lo[0], c[0] / c[3]), hi[0] = fmax(hi[0], c[0] / c[3]);
        lo[1] = fmin(lo[1], c[1] / c[3]), hi[1] = fmax(hi[1], c[1] / c[3]);
    }
    return fmax((hi[0] - lo[0]) * 0.5 * plan->width, (hi[1] - lo[1]) * 0.5 * plan->height);
}

/* Leaf side k as a segment in the face's grid coordinates (patch column + local s, row + t):
 * fixed coordinate, along-range, and the direction (0: along s, 1: along t). */
static void side_segment(const crisp_scene *sc, const crisp_plan_leaf *L, int k, double *fixed,
                         double *a0, double *a1, int *dir)
{
    const crisp_scene_patch *sp = &sc->patches[L->patch];
    double sz = ldexp(1.0, -(int)L->depth), su = sz, sv = sz;
    double s0 = sp->iu + L->ix * sz, t0 = sp->iv + L->iy * sz;
    if (L->group) { /* a group leaf: a block of patches of the grid */
        s0 = sp->iu, t0 = sp->iv, su = L->block & 0xffff, sv = L->block >> 16;
    }
    if (k == 0 || k == 2) {
        *dir = 0, *fixed = t0 + (k == 2) * sv, *a0 = s0, *a1 = s0 + su;
    } else {
        *dir = 1, *fixed = s0 + (k == 1) * su, *a0 = t0, *a1 = t0 + sv;
    }
}

/* Two leaves of one face that share a piece of edge place the same vertices on it: every vertex
 * of one inside the shared piece is a vertex of the other. Checked on faces of at most max_leaves
 * leaves (pairs are examined all against all), or, with only_patch, the edges of that patch's
 * leaves. Returns the pairs checked. */
static long check_crack_free(const crisp_scene *sc, const crisp_frame_plan *plan,
                             uint32_t max_leaves, uint32_t only_patch)
{
    long pairs = 0;
    for (uint32_t f = 0; f < plan->face_count; f++) {
        const crisp_plan_face *pf = &plan->faces[f];
        if (pf->leaf_count > max_leaves && only_patch == UINT32_MAX) continue;
        for (uint32_t i = 0; i < pf->leaf_count; i++)
            for (uint32_t j = 0; j < pf->leaf_count; j++) {
                if (i == j) continue;
                const crisp_plan_leaf *A = &plan->leaves[pf->first_leaf + i],
                                      *B = &plan->leaves[pf->first_leaf + j];
                if (only_patch != UINT32_MAX && A->patch != only_patch && B->patch != only_patch)
                    continue;
                for (int ka = 0; ka < 4; ka++) {
                    int kb = (ka + 2) % 4, da, db;
                    double fa, a0, a1, fb, b0, b1;
                    side_segment(sc, A, ka, &fa, &a0, &a1, &da);
                    side_segment(sc, B, kb, &fb, &b0, &b1, &db);
                    if (da != db || fabs(fa - fb) > 1e-12) continue;
                    double lo = fmax(a0, b0), hi = fmin(a1, b1);
                    if (!(hi - lo > 1e-12)) continue;
                    pairs++;
                    /* Vertices of A on the shared piece must be vertices of B. */
                    uint32_t ea = A->edge[ka], eb = B->edge[kb];
                    for (uint32_t q = 0; q <= ea; q++) {
                        double x = a0 + (a1 - a0) * q / ea;
                        if (x < lo - 1e-12 || x > hi + 1e-12) continue;
                        double pos = (x - b0) / (b1 - b0) * eb;
                        if (fabs(pos - round(pos)) > 1e-6)
                            fail_msg(
                                "face %u: leaves %u and %u: vertex %u/%u of side %d not on the "
                                "other's side (%g of %u)",
                                f, i, j, q, ea, ka, pos, eb);
                    }
                }
            }
    }
    return pairs;
}

static void check_plan(const crisp_scene *sc, const crisp_frame_plan *plan, const crisp_planner *pl)
{
    assert_int_equal(plan->face_count, sc->face_count);
    uint32_t total = 0;
    for (uint32_t f = 0; f < plan->face_count; f++) {
        const crisp_plan_face *pf = &plan->faces[f];
        assert_int_equal(pf->first_leaf, total);
        total += pf->leaf_count;
        for (uint32_t l = pf->first_leaf; l < pf->first_leaf + pf->leaf_count; l++) {
            const crisp_plan_leaf *L = &plan->leaves[l];
            assert_int_equal(L->face, f);
            assert_int_equal(sc->patches[L->patch].face, f);
            assert_true(L->tau >= 1 && L->tau <= CRISP_PLAN_MAX_LEVEL);
            for (int k = 0; k < 4; k++)
                assert_true(L->edge[k] >= 1 && L->edge[k] <= CRISP_PLAN_MAX_LEVEL);
            if (L->depth < CRISP_PLAN_MAX_DEPTH) {
                double e = leaf_extent(sc, plan, L);
                if (e > CRISP_PLAN_MAX_LEAF_PX) fail_msg("leaf %u spans %g px", l, e);
            }
        }
        /* The flat lookup is the face's table. */
        if (!(pf->flags & CRISP_PLAN_FACE_VISIBLE)) continue;
        const crisp_trim_table *tb = crisp__planner_table(pl, f);
        double d[4];
        crisp_surface_domain(sc->faces[f].src->surface, d);
        for (int k = 0; k < 400; k++) {
            double u = d[0] + (d[1] - d[0]) * (1.2 * rnd() - 0.1),
                   v = d[2] + (d[3] - d[2]) * (1.2 * rnd() - 0.1);
            assert_int_equal(crisp_plan_trim_test(plan, f, u, v), crisp_trim_table_test(tb, u, v));
        }
    }
    assert_int_equal(total, plan->leaf_count);
    assert_int_equal(plan->row_offset[plan->row_count], plan->crossing_count);
}

static void run_model(const char *name, uint32_t *splits)
{
    crisp_model *m = rt_load_model(name);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_planner *pl;
    assert_int_equal(crisp_planner_create(NULL, NULL, &pl), CRISP_OK);
    crisp_camera cams[8];
    int n = cameras(sc, cams, 320, 240);
    for (int c = 0; c < n; c++) {
        const crisp_frame_plan *plan;
        assert_int_equal(crisp_planner_plan(pl, sc, &cams[c], &plan), CRISP_OK);
        check_plan(sc, plan, pl);
        long pairs = check_crack_free(sc, plan, 300, UINT32_MAX);
        *splits += plan->stats.level_splits;
        printf(
            "%s camera %d: %u leaves, %u level splits, %ld shared edges checked, %u ribbon quads\n",
            name, c, plan->leaf_count, plan->stats.level_splits, pairs, plan->ribbon_quad_count);
    }
    crisp_planner_destroy(pl);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

static void test_plan_models(void **state)
{
    (void)state;
    uint32_t splits = 0;
    run_model("occt_bearing.iges", &splits);
    run_model("gpucast_teapot.igs", &splits);
    run_model("gpucast_part.igs", &splits);
    run_model("occt_hammer.iges", &splits);
    printf("level splits over all cameras: %u\n", splits);
}

/* One face of two cubic spans in u: the first exactly bilinear (its triangles are exact at level
 * 1), the second bent hard. At a tiny tolerance the bent span's leaves are split 7 and more levels
 * deeper than the flat span's one leaf, so the crack-free rule would give the flat leaf an edge
 * level above 64 on the shared edge: the planner must split it instead. */
static void test_level_splits(void **state)
{
    (void)state;
    /* Two Bézier spans meeting with C0 continuity (a triple knot): the first has uniform
     * collinear control points (exactly bilinear), the second bends from the shared edge on. */
    const double ku[] = {0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2}, kv[] = {0, 0, 1, 1};
    static const double bend[7] = {0, 0, 0, 0, 2, -2, 0};
    double pts[2 * 7 * 3];
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 7; i++) {
            double *p = pts + 3 * (j * 7 + i);
            p[0] = i, p[1] = 3.0 * j, p[2] = bend[i];
        }
    crisp_face face = {0};
    assert_int_equal(crisp_surface_create(3, 1, 7, 2, ku, kv, pts, NULL, &face.surface), CRISP_OK);
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &face), CRISP_OK);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    assert_int_equal(sc->patch_count, 2);
    crisp_planner *pl;
    assert_int_equal(crisp_planner_create(&(crisp_planner_desc){.eps_px = 1e-6}, NULL, &pl),
                     CRISP_OK);
    crisp_camera cam;
    assert_int_equal(crisp_camera_frame_box(sc->box, 640, 480, &cam), CRISP_OK);
    const crisp_frame_plan *plan;
    assert_int_equal(crisp_planner_plan(pl, sc, &cam, &plan), CRISP_OK);
    check_plan(sc, plan, pl);
    long pairs = check_crack_free(sc, plan, 0, 0); /* every edge of the flat span */
    uint32_t deepest = 0, flat_depth = 99;
    for (uint32_t l = 0; l < plan->leaf_count; l++) {
        const crisp_plan_leaf *L = &plan->leaves[l];
        if (L->patch == 1 && L->depth > deepest) deepest = L->depth;
        if (L->patch == 0 && L->depth < flat_depth) flat_depth = L->depth;
    }
    printf("flat span: shallowest leaf depth %u; bent span: deepest %u; %u level splits; %ld "
           "shared edges\n",
           flat_depth, deepest, plan->stats.level_splits, pairs);
    assert_true(plan->stats.level_splits > 0);
    assert_true(pairs > 0);
    assert_int_equal(plan->stats.unresolved, 0);
    crisp_planner_destroy(pl);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* Versions move only with content; re-planning one edited face equals planning again. */
static void test_versions_and_replan(void **state)
{
    (void)state;
    crisp_model *m = rt_load_model("occt_hammer.iges");
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_planner *pl, *fresh;
    assert_int_equal(crisp_planner_create(NULL, NULL, &pl), CRISP_OK);
    assert_int_equal(crisp_planner_create(NULL, NULL, &fresh), CRISP_OK);
    crisp_camera cam;
    assert_int_equal(crisp_camera_frame_box(sc->box, 400, 300, &cam), CRISP_OK);
    const crisp_frame_plan *plan;
    assert_int_equal(crisp_planner_plan(pl, sc, &cam, &plan), CRISP_OK);
    uint64_t v[4] = {plan->leaves_version, plan->faces_version, plan->table_version,
                     plan->ribbons_version};
    assert_int_equal(crisp_planner_plan(pl, sc, &cam, &plan), CRISP_OK);
    assert_true(plan->leaves_version == v[0] && plan->faces_version == v[1] &&
                plan->table_version == v[2] && plan->ribbons_version == v[3]);
    /* Pick the visible face with the most trim pieces and move its first hole (or loop) a little.
     */
    uint32_t best = UINT32_MAX;
    for (uint32_t f = 0; f < sc->face_count; f++)
        if ((plan->faces[f].flags & CRISP_PLAN_FACE_VISIBLE) && m->faces[f].loop_count > 1 &&
            (best == UINT32_MAX || sc->faces[f].piece_count > sc->faces[best].piece_count))
            best = f;
    assert_true(best != UINT32_MAX);
    crisp_trim_loop *loop = &m->faces[best].loops[m->faces[best].loops[0].is_outer ? 1 : 0];
    double d[4];
    crisp_surface_domain(m->faces[best].surface, d);
    double du = 0.004 * (d[1] - d[0]);
    for (int c = 0; c < loop->curve_count; c++) {
        crisp_curve *cv = loop->curves[c];
        for (int k = 0; k < cv->count; k++)
            cv->cpw[3 * k] += du * cv->cpw[3 * k + 2]; /* (w u, w v, w) */
    }
    assert_int_equal(crisp_scene_update_trim(sc, best), CRISP_OK);
    assert_int_equal(crisp_planner_replan_face(pl, sc, best, &plan), CRISP_OK);
    assert_int_equal(plan->leaves_version, v[0]);
    assert_true(plan->table_version != v[2]);
    const crisp_frame_plan *again;
    assert_int_equal(crisp_planner_plan(fresh, sc, &cam, &again), CRISP_OK);
    assert_int_equal(plan->row_count, again->row_count);
    assert_int_equal(plan->crossing_count, again->crossing_count);
    assert_memory_equal(plan->crossings, again->crossings, plan->crossing_count * sizeof(double));
    assert_memory_equal(plan->strips, again->strips, plan->strip_count * sizeof *plan->strips);
    assert_int_equal(plan->ribbon_quad_count, again->ribbon_quad_count);
    assert_memory_equal(plan->ribbon_vertices, again->ribbon_vertices,
                        4 * (size_t)plan->ribbon_quad_count * sizeof *plan->ribbon_vertices);
    for (uint32_t f = 0; f < sc->face_count; f++) {
        assert_int_equal(plan->faces[f].first_ribbon, again->faces[f].first_ribbon);
        assert_int_equal(plan->faces[f].ribbon_count, again->faces[f].ribbon_count);
    }
    printf("replan of face %u: %.3f ms trim + %.3f ms ribbons; plan bytes %zu\n", best,
           plan->stats.ms_trim, plan->stats.ms_ribbons, crisp_plan_bytes(plan));
    crisp_planner_destroy(pl);
    crisp_planner_destroy(fresh);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* Each camera's leaves from a new planner that keeps no sub-patches across frames
 * (crisp__trees_keep_subpatches off): want[c], count[c]; returns the leaves below depth 2. */
static long fresh_leaves(const crisp_scene *sc, const crisp_camera *cams, int n,
                         crisp_plan_leaf **want, uint32_t *count)
{
    long deep = 0;
    for (int c = 0; c < n; c++) {
        crisp_planner *fresh;
        const crisp_frame_plan *plan;
        assert_int_equal(crisp_planner_create(NULL, NULL, &fresh), CRISP_OK);
        crisp__trees_keep_subpatches(fresh->trees, 0);
        assert_int_equal(crisp_planner_plan(fresh, sc, &cams[c], &plan), CRISP_OK);
        count[c] = plan->leaf_count;
        want[c] = malloc((plan->leaf_count ? plan->leaf_count : 1) * sizeof *want[c]);
        assert_non_null(want[c]);
        memcpy(want[c], plan->leaves, plan->leaf_count * sizeof *want[c]);
        for (uint32_t l = 0; l < plan->leaf_count; l++)
            deep += plan->leaves[l].depth >= 3;
        crisp_planner_destroy(fresh);
    }
    return deep;
}

static void plans_equal(crisp_planner *pl, const crisp_scene *sc, const crisp_camera *cams, int n,
                        crisp_plan_leaf *const *want, const uint32_t *count)
{
    for (int c = 0; c < n; c++) {
        const crisp_frame_plan *plan;
        assert_int_equal(crisp_planner_plan(pl, sc, &cams[c], &plan), CRISP_OK);
        assert_int_equal(plan->leaf_count, count[c]);
        assert_memory_equal(plan->leaves, want[c], count[c] * sizeof *want[c]);
    }
}

/* The sub-patches a planner keeps across frames (quadtree.c, cell_patch) give every plan what
 * cutting them afresh gives: one planner plans the linkrods (patches of degree up to 6 x 10, split
 * well below their quarters) from five cameras in turn, three rounds, then the bearing (another
 * scene: its patches must not read the linkrods' sub-patches), then the linkrods again; each
 * plan's leaves equal those of a new planner that keeps none (crisp__trees_keep_subpatches off),
 * bit for bit. */
static void test_kept_subpatches(void **state)
{
    (void)state;
    crisp_model *m[2];
    crisp_scene *sc[2] = {rt_load_scene("occt_linkrods.step", &m[0]),
                          rt_load_scene("occt_bearing.iges", &m[1])};
    crisp_camera cams[2][8];
    crisp_plan_leaf *want[2][8];
    uint32_t count[2][8];
    int n[2];
    for (int k = 0; k < 2; k++) {
        n[k] = cameras(sc[k], cams[k], 480, 360);
        long deep = fresh_leaves(sc[k], cams[k], n[k], want[k], count[k]);
        printf("scene %d: leaves below depth 2 over %d cameras: %ld\n", k, n[k], deep);
        assert_true(deep > (k ? 20 : 100));
    }
    crisp_planner *pl;
    assert_int_equal(crisp_planner_create(NULL, NULL, &pl), CRISP_OK);
    for (int round = 0; round < 3; round++)
        plans_equal(pl, sc[0], cams[0], n[0], want[0], count[0]);
    plans_equal(pl, sc[1], cams[1], n[1], want[1], count[1]);
    plans_equal(pl, sc[0], cams[0], n[0], want[0], count[0]);
    crisp_planner_destroy(pl);
    for (int k = 0; k < 2; k++) {
        for (int c = 0; c < n[k]; c++)
            free(want[k][c]);
        crisp_scene_destroy(sc[k]);
        crisp_model_destroy(m[k]);
    }
}

/* ribbon.c's distance comparisons without hypot (crisp__ribbon_length_above) answer as
 * hypot(x, y) > c does: at lengths within a few hundred ulps of c (where x x + y y alone decides
 * some differently: counted, so the test is sharp), at random lengths, and at zeros, subnormals,
 * huge, infinite and NaN coordinates. */
static void test_ribbon_length_compare(void **state)
{
    (void)state;
    uint64_t z = 12;
    double cs[] = {4.0, 0.1, 4 * 0.1, 1.0, 3.7e-3, 1234.5};
    long compared = 0, square_differs = 0;
    for (int ci = 0; ci < 6; ci++) {
        double c = cs[ci];
        for (int k = 0; k < 200000; k++) {
            z = z * 6364136223846793005ull + 1442695040888963407ull;
            double a = (double)(z >> 11) * 0x1.0p-53 * 6.283185307179586;
            z = z * 6364136223846793005ull + 1442695040888963407ull;
            int ulps = (int)(z >> 40) % 601 - 300;
            double r = k % 4 == 3 ? c * (double)(z >> 11) * 0x1.0p-52 : c * (1 + ulps * 0x1.0p-52);
            double x = r * cos(a), y = r * sin(a);
            if (k % 7 == 1) x = -x;
            int want = hypot(x, y) > c, got = crisp__ribbon_length_above(x, y, c);
            if (want != got) {
                printf("x %.17g y %.17g c %.17g: hypot %.17g, got %d\n", x, y, c, hypot(x, y), got);
                fail();
            }
            square_differs += (x * x + y * y > c * c) != want;
            compared++;
        }
    }
    double sp[] = {0.0,     -0.0,     0x1p-1074, 1e-300, 1e154, 1.5e154, 1e300,
                   DBL_MAX, INFINITY, -INFINITY, NAN,    4.0,   -4.0,    0.1};
    int m = (int)(sizeof sp / sizeof sp[0]);
    for (int i = 0; i < m; i++)
        for (int j = 0; j < m; j++)
            for (int ci = 0; ci < 6; ci++) {
                assert_int_equal(crisp__ribbon_length_above(sp[i], sp[j], cs[ci]),
                                 hypot(sp[i], sp[j]) > cs[ci]);
                compared++;
            }
    printf("length comparisons: %ld equal to hypot's, %ld where the square alone differs\n",
           compared, square_differs);
    assert_true(square_differs > 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_plan_models),           cmocka_unit_test(test_level_splits),
        cmocka_unit_test(test_versions_and_replan),   cmocka_unit_test(test_kept_subpatches),
        cmocka_unit_test(test_ribbon_length_compare),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
