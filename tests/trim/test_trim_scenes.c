/* Trim correctness scenes (the "Trim correctness" criterion at the uv level with a real
 * camera): planar, bilinear and curved patches with non-uniform parametrisations; trims made of
 * rational-quadratic ellipses and circles, polygons and cubic graphs, with holes; cameras frontal,
 * grazing (85 degrees from the normal), zoomed until a trim curve crosses the whole image, and with
 * the surface crossing the near plane. For every pixel centre the surface point it sees is found
 * by Newton's method on the projected patch (seeded by a subdivision of the domain), classified by
 * the u-intercept table of crisp_trim_plan_face and by the exact classifier, and every disagreement
 * is measured in screen space against a dense projection of the true trim curves: none may lie
 * farther than 1.0 px from the true boundary. Argument: image size (default 64). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>

#include "trim/trim_test_util.h"

static int image_size = 64;

typedef struct scene {
    crisp_bezier_patch patch;
    double cpw[64];
    crisp_bezier_curve pieces[32];
    int piece_count;
    crisp_mat4 vp;
    int width, height;
    double znear;
} scene;

/* Screen point of the surface point (s, t); returns clip W, 0 when behind the near plane. */
static double screen_at(const scene *sc, double s, double t, double xy[2], double ds[2],
                        double dt[2])
{
    double p[3], ps[3], pt[3];
    crisp_bezier_patch_derivs(&sc->patch, s, t, p, ps, pt);
    double c[4], cs[4], ct[4];
    for (int r = 0; r < 4; r++) {
        c[r] = sc->vp[3][r];
        cs[r] = ct[r] = 0.0;
        for (int k = 0; k < 3; k++) {
            c[r] += sc->vp[k][r] * p[k];
            cs[r] += sc->vp[k][r] * ps[k];
            ct[r] += sc->vp[k][r] * pt[k];
        }
    }
    double W = c[3];
    if (!(c[2] >= -W) || !(W > 0)) return 0.0; /* behind the near plane */
    double sx = 0.5 * sc->width, sy = -0.5 * sc->height;
    xy[0] = (c[0] / W + 1.0) * sx;
    xy[1] = (c[1] / W - 1.0) * sy;
    if (ds) {
        ds[0] = sx * (cs[0] * W - c[0] * cs[3]) / (W * W);
        ds[1] = sy * (cs[1] * W - c[1] * cs[3]) / (W * W);
        dt[0] = sx * (ct[0] * W - c[0] * ct[3]) / (W * W);
        dt[1] = sy * (ct[1] * W - c[1] * ct[3]) / (W * W);
    }
    return W;
}

/* ---- seeds: the nearest cell of a domain subdivision whose screen box holds the pixel ------- */

typedef struct seeds {
    int w, h;
    double *st; /* 2 per pixel */
    double *depth;
} seeds;

static void seed_cells(const scene *sc, seeds *sd, double s0, double s1, double t0, double t1,
                       int depth)
{
    double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL}, wc = 0.0;
    int behind = 0;
    for (int b = 0; b <= 2; b++)
        for (int a = 0; a <= 2; a++) {
            double xy[2];
            double W =
                screen_at(sc, s0 + (s1 - s0) * 0.5 * a, t0 + (t1 - t0) * 0.5 * b, xy, NULL, NULL);
            if (W <= 0.0) {
                behind++;
                continue;
            }
            if (a == 1 && b == 1) wc = W;
            for (int q = 0; q < 2; q++) {
                lo[q] = fmin(lo[q], xy[q]);
                hi[q] = fmax(hi[q], xy[q]);
            }
        }
    if (behind == 9) return;
    double size = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    double grow = 0.25 * size + 1.0;
    /* Off the image. A cell that straddles the near plane is judged by its visible samples once
     * it is small, with a wider margin (its visible part may project far). */
    if (behind && depth >= 6) grow = size + 4.0;
    if ((!behind || depth >= 6) &&
        (hi[0] + grow < 0 || lo[0] - grow > sd->w || hi[1] + grow < 0 || lo[1] - grow > sd->h))
        return;
    if ((size > 3.0 && depth < 16) || (behind && depth < 12)) {
        double sm = 0.5 * (s0 + s1), tm = 0.5 * (t0 + t1);
        seed_cells(sc, sd, s0, sm, t0, tm, depth + 1);
        seed_cells(sc, sd, sm, s1, t0, tm, depth + 1);
        seed_cells(sc, sd, s0, sm, tm, t1, depth + 1);
        seed_cells(sc, sd, sm, s1, tm, t1, depth + 1);
        return;
    }
    if (behind || wc <= 0.0) return;
    int i0 = (int)floor(lo[0] - grow), i1 = (int)ceil(hi[0] + grow);
    int j0 = (int)floor(lo[1] - grow), j1 = (int)ceil(hi[1] + grow);
    if (i0 < 0) i0 = 0;
    if (j0 < 0) j0 = 0;
    if (i1 > sd->w - 1) i1 = sd->w - 1;
    if (j1 > sd->h - 1) j1 = sd->h - 1;
    for (int j = j0; j <= j1; j++)
        for (int i = i0; i <= i1; i++) {
            size_t k = (size_t)j * sd->w + i;
            if (wc < sd->depth[k]) {
                sd->depth[k] = wc;
                sd->st[2 * k] = 0.5 * (s0 + s1);
                sd->st[2 * k + 1] = 0.5 * (t0 + t1);
            }
        }
}

/* Newton on screen(s, t) = (px, py). Returns 1 with st on a converged point of the domain. */
static int solve_pixel(const scene *sc, double px, double py, double st[2])
{
    double s = st[0], t = st[1];
    for (int it = 0; it < 40; it++) {
        double xy[2], ds[2], dt[2];
        if (screen_at(sc, s, t, xy, ds, dt) <= 0.0) return 0;
        double fx = xy[0] - px, fy = xy[1] - py;
        if (fabs(fx) < 1e-8 && fabs(fy) < 1e-8) {
            if (s < 0 || s > 1 || t < 0 || t > 1) return 0;
            st[0] = s;
            st[1] = t;
            return 1;
        }
        double det = ds[0] * dt[1] - dt[0] * ds[1];
        if (!(fabs(det) > 1e-300)) return 0;
        double a = (fx * dt[1] - dt[0] * fy) / det, b = (ds[0] * fy - fx * ds[1]) / det;
        s -= a;
        t -= b;
        if (!(s > -0.5 && s < 1.5 && t > -0.5 && t < 1.5)) return 0;
    }
    return 0;
}

/* ---- the true boundary on screen: a dense polyline of the projected trim curves ------------ */

typedef struct spoly {
    double *xy; /* segments: 4 values each */
    size_t n, cap;
} spoly;

static void add_seg(spoly *sp, const double a[2], const double b[2])
{
    if (sp->n == sp->cap) {
        sp->cap = sp->cap ? 2 * sp->cap : 1024;
        sp->xy = realloc(sp->xy, sp->cap * 4 * sizeof(double));
        assert_non_null(sp->xy);
    }
    double *d = sp->xy + 4 * sp->n++;
    d[0] = a[0];
    d[1] = a[1];
    d[2] = b[0];
    d[3] = b[1];
}

static int curve_screen(const scene *sc, const crisp_bezier_curve *b, double t, double xy[2])
{
    double uv[2];
    crisp_bezier_curve_eval(b, t, uv);
    return screen_at(sc, uv[0], uv[1], xy, NULL, NULL) > 0.0;
}

static void project_piece(const scene *sc, spoly *sp, const crisp_bezier_curve *b, double t0,
                          double t1, const double p0[2], int ok0, const double p1[2], int ok1,
                          int depth)
{
    if (ok0 && ok1) {
        double len = hypot(p1[0] - p0[0], p1[1] - p0[1]);
        double far_x = fmax(fmax(-fmax(p0[0], p1[0]), fmin(p0[0], p1[0]) - sc->width), 0.0);
        double far_y = fmax(fmax(-fmax(p0[1], p1[1]), fmin(p0[1], p1[1]) - sc->height), 0.0);
        if (hypot(far_x, far_y) > len + 4.0 && depth > 6) return; /* well away from the image */
        if (len <= 0.02 || depth >= 40) {
            add_seg(sp, p0, p1);
            return;
        }
    } else if (depth >= 40 || (!ok0 && !ok1 && depth >= 8)) {
        return; /* behind the near plane */
    }
    double tm = 0.5 * (t0 + t1), pm[2];
    int okm = curve_screen(sc, b, tm, pm);
    project_piece(sc, sp, b, t0, tm, p0, ok0, pm, okm, depth + 1);
    project_piece(sc, sp, b, tm, t1, pm, okm, p1, ok1, depth + 1);
}

static double seg_dist(const double *s, double x, double y)
{
    double dx = s[2] - s[0], dy = s[3] - s[1], l2 = dx * dx + dy * dy;
    double u = l2 > 0 ? ((x - s[0]) * dx + (y - s[1]) * dy) / l2 : 0.0;
    u = fmin(fmax(u, 0.0), 1.0);
    return hypot(s[0] + u * dx - x, s[1] + u * dy - y);
}

/* ---- scenes -------------------------------------------------------------------------------- */

static int make_trim(crisp_bezier_curve *pc, int kind)
{
    int n = 0;
    if (kind == 0) {
        n += tu_ellipse(pc, 0.5, 0.5, 0.4, 0.3, 0.3, 1);
        n += tu_ellipse(pc + n, 0.45, 0.5, 0.1, 0.1, 0.0, 0);
    } else if (kind == 1) {
        const double star[] = {0.1,  0.1, 0.5, 0.25, 0.9,  0.05, 0.8, 0.5,
                               0.95, 0.9, 0.5, 0.7,  0.15, 0.95, 0.3, 0.5};
        n += tu_polygon(pc, 8, star);
        const double hole[] = {0.45, 0.4, 0.45, 0.55, 0.6, 0.55, 0.6, 0.4}; /* clockwise */
        n += tu_polygon(pc + n, 4, hole);
    } else {
        const double g[4] = {0.5, 0.95, 0.2, 0.7};
        n += tu_cubic_graph(pc, 0.1, 0.9, g, 0.08);
        n += tu_ellipse(pc + n, 0.5, 0.25, 0.12, 0.06, 0.5, 0);
    }
    return n;
}

/* A point on the first trim curve, for the zoomed camera. */
static void boundary_point(const scene *sc, double uv[2])
{
    crisp_bezier_curve_eval(&sc->pieces[0], 0.37, uv);
}

static void make_camera(scene *sc, int cam, int pk)
{
    double eye[3], target[3], fovy = 45.0, znear = 0.05, zfar = 50.0;
    if (cam == 0) { /* frontal */
        eye[0] = 1.0, eye[1] = 1.0, eye[2] = 3.5;
        target[0] = 1.0, target[1] = 1.0, target[2] = 0.0;
    } else if (cam == 1) { /* grazing: 85 degrees from the normal */
        double el = 5.0 * M_PI / 180.0;
        target[0] = 1.0, target[1] = 1.0, target[2] = pk == 2 ? 0.25 : 0.0;
        eye[0] = target[0] - 3.0 * cos(el) * 0.8;
        eye[1] = target[1] - 3.0 * cos(el) * 0.6;
        eye[2] = target[2] + 3.0 * sin(el);
        fovy = 30.0;
    } else if (cam == 2) { /* zoomed: a trim curve crosses the whole image */
        double uv[2], p[3], ps[3], pt[3];
        boundary_point(sc, uv);
        crisp_bezier_patch_derivs(&sc->patch, uv[0], uv[1], p, ps, pt);
        double nrm[3];
        crisp_vec3_cross(ps, pt, nrm);
        crisp_vec3_normalize(nrm, nrm);
        if (nrm[2] < 0) crisp_vec3_scale(nrm, -1.0, nrm);
        for (int k = 0; k < 3; k++) {
            target[k] = p[k];
            eye[k] = p[k] + 0.004 * nrm[k] + (k == 0 ? 0.002 : 0.0);
        }
        fovy = 20.0;
        znear = 0.0005;
    } else { /* the surface crosses the near plane: low camera looking along the surface */
        double p[3];
        crisp_bezier_patch_eval(&sc->patch, 0.75, 0.5, p);
        eye[0] = p[0], eye[1] = p[1], eye[2] = p[2] + 0.12;
        target[0] = p[0] - 1.0, target[1] = p[1] + 0.15, target[2] = p[2] - 0.3;
        fovy = 80.0;
        znear = 0.25;
    }
    sc->znear = znear;
    tu_camera(eye, target, fovy, znear, zfar, sc->width, sc->height, sc->vp);
}

typedef struct tally {
    long covered, inside, disagree, in_band, out_band;
    double worst;
} tally;

static void run_scene(int pk, int tk, int cam, tally *all)
{
    scene sc;
    memset(&sc, 0, sizeof sc);
    tu_patch_kind(&sc.patch, pk, sc.cpw);
    sc.piece_count = make_trim(sc.pieces, tk);
    sc.width = sc.height = image_size;
    make_camera(&sc, cam, pk);

    crisp_trim_plan plan = {0};
    assert_int_equal(crisp_trim_plan_face(&(crisp_trim_plan_desc){.patches = &sc.patch,
                                                                  .patch_count = 1,
                                                                  .pieces = sc.pieces,
                                                                  .piece_count = sc.piece_count,
                                                                  .view_proj = &sc.vp,
                                                                  .width = sc.width,
                                                                  .height = sc.height,
                                                                  .v0 = 0,
                                                                  .v1 = 1,
                                                                  .strip_count = 16},
                                          &plan),
                     CRISP_OK);
    assert_int_equal(plan.clamped, 0);
    assert_int_equal(plan.density_stats.unbounded, 0);
    assert_int_equal(plan.polyline.capped, 0);

    size_t npx = (size_t)sc.width * sc.height;
    seeds sd = {sc.width, sc.height, calloc(2 * npx, sizeof(double)), malloc(npx * sizeof(double))};
    assert_non_null(sd.st);
    assert_non_null(sd.depth);
    for (size_t k = 0; k < npx; k++)
        sd.depth[k] = HUGE_VAL;
    seed_cells(&sc, &sd, 0, 1, 0, 1, 0);

    spoly sp = {0};
    for (int k = 0; k < sc.piece_count; k++) {
        double p0[2], p1[2];
        int ok0 = curve_screen(&sc, &sc.pieces[k], 0.0, p0),
            ok1 = curve_screen(&sc, &sc.pieces[k], 1.0, p1);
        project_piece(&sc, &sp, &sc.pieces[k], 0.0, 1.0, p0, ok0, p1, ok1, 0);
    }

    tally t = {0};
    for (int j = 0; j < sc.height; j++)
        for (int i = 0; i < sc.width; i++) {
            size_t k = (size_t)j * sc.width + i;
            if (sd.depth[k] == HUGE_VAL) continue;
            double st[2] = {sd.st[2 * k], sd.st[2 * k + 1]};
            if (!solve_pixel(&sc, i + 0.5, j + 0.5, st)) continue;
            t.covered++;
            int want = crisp_trim_exact_classify(sc.pieces, sc.piece_count, st[0], st[1]);
            int got = crisp_trim_table_test(&plan.table, st[0], st[1]);
            t.inside += want;
            if (want == got) continue;
            t.disagree++;
            double d = HUGE_VAL;
            for (size_t q = 0; q < sp.n; q++)
                d = fmin(d, seg_dist(sp.xy + 4 * q, i + 0.5, j + 0.5));
            t.worst = fmax(t.worst, d);
            /* 0.02 px: the dense screen polyline's own distance from the true projected curve */
            if (d <= 1.0 + 0.02)
                t.in_band++;
            else
                t.out_band++;
        }
    print_message("patch %d trim %d camera %d: %ld px on the surface, %ld inside, %ld disagree "
                  "(%ld within 1 px, %ld beyond), farthest %.3f px; %u scan lines, %u crossings, "
                  "%d polyline points, table %zu bytes\n",
                  pk, tk, cam, t.covered, t.inside, t.disagree, t.in_band, t.out_band,
                  t.disagree ? t.worst : 0.0, plan.table.row_count,
                  plan.table.row_offset[plan.table.row_count], plan.polyline.first[sc.piece_count],
                  crisp_trim_table_bytes(&plan.table));
    /* Not vacuous: the camera sees a good part of the image, with both sides of the trim. */
    assert_true(t.covered > (long)npx / 8);
    assert_true(t.inside > t.covered / 50 && t.inside < t.covered - t.covered / 50);
    assert_int_equal(t.out_band, 0);
    all->covered += t.covered;
    all->disagree += t.disagree;
    all->in_band += t.in_band;
    all->out_band += t.out_band;
    all->worst = fmax(all->worst, t.disagree ? t.worst : 0.0);
    free(sp.xy);
    free(sd.st);
    free(sd.depth);
    crisp_trim_plan_free(&plan);
}

static void scenes_for_camera(int cam)
{
    tally all = {0};
    double t0 = crisp_time_now();
    for (int pk = 0; pk < 3; pk++)
        for (int tk = 0; tk < 3; tk++)
            run_scene(pk, tk, cam, &all);
    print_message("camera %d, %dx%d: %ld px on surfaces, %ld disagreements, all within 1 px: %ld "
                  "(farthest %.3f px), beyond: %ld (%.2f s)\n",
                  cam, image_size, image_size, all.covered, all.disagree, all.in_band, all.worst,
                  all.out_band, crisp_time_now() - t0);
}

static void test_frontal(void **state)
{
    (void)state;
    scenes_for_camera(0);
}
static void test_grazing(void **state)
{
    (void)state;
    scenes_for_camera(1);
}
static void test_zoomed(void **state)
{
    (void)state;
    scenes_for_camera(2);
}
static void test_near_plane(void **state)
{
    (void)state;
    scenes_for_camera(3);
}

int main(int argc, char **argv)
{
    if (argc > 1) image_size = atoi(argv[1]);
    if (image_size < 16 || image_size > 4096) image_size = 64;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frontal),
        cmocka_unit_test(test_grazing),
        cmocka_unit_test(test_zoomed),
        cmocka_unit_test(test_near_plane),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
