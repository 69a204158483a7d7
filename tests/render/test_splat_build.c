/* The splat builder (src/render/splat_build.c, issue 12) against its guarantee (src/render/
 * splat.h), at dense samples:
 *   - coverage: every sampled point S(u, v) with (u, v) inside the trim (crisp_trim_exact_classify)
 *     is within the radius of some splat's stored position (origin + float p), and within the
 *     set's own stated radius;
 *   - splats are points of the trimmed face: (u, v) inside, or on a trim curve within the float
 *     rounding of the stored (u, v); origin + p is S(u, v); n is crisp_surface_normal's, unit;
 *   - on random rational B-spline surfaces (degrees 1..5, weights 0.3..3, several spans) with
 *     random trim loops (lines and rational arcs, partly leaving the domain, holes), on faces
 *     without loops, and on faces of impeller.igs and a STEP file, at several radii;
 *   - max_count (CRISP_ERR_LIMIT, no partial set) and invalid arguments.
 * Prints the tightness (largest sampled distance to the nearest splat / radius): the coverage
 * check is sharp when it is above 0.5 (a builder meeting only twice the radius would fail), which
 * test_random_faces asserts. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_test_util.h"
#include "crisp/construct.h"
#include "crisp/io.h"
#include "crisp/render.h"
#include "crisp/trim.h"
#include "render/splat.h"
#include "render/splat_store.h"

static uint64_t rng = 0x2545f4914f6cdd1dull;
static double rnd(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* A weight in [0.3, 3], log-uniform. */
static double weight(void)
{
    return exp(log(0.3) + rnd() * log(10.0));
}

/* ---- nearest splat: a hash grid of cell size h -------------------------------------------------
 */

typedef struct grid {
    double h;
    uint32_t mask;
    uint32_t *start; /* mask + 2 */
    uint32_t *items;
    double (*pos)[3];
} grid;

static uint32_t hash3(int64_t x, int64_t y, int64_t z, uint32_t mask)
{
    uint64_t k = (uint64_t)x * 0x9E3779B97F4A7C15ull ^ (uint64_t)y * 0xC2B2AE3D27D4EB4Full ^
                 (uint64_t)z * 0x165667B19E3779F9ull;
    k ^= k >> 29;
    return (uint32_t)k & mask;
}

static void grid_build(grid *g, const crisp_splat_set *set, double h)
{
    g->h = h;
    uint32_t n = set->count, size = 1;
    while (size < 2 * n + 2)
        size <<= 1;
    g->mask = size - 1;
    g->start = calloc(size + 1, sizeof *g->start);
    g->items = malloc((n ? n : 1) * sizeof *g->items);
    g->pos = malloc((n ? n : 1) * sizeof *g->pos);
    uint32_t *key = malloc((n ? n : 1) * sizeof *key);
    for (uint32_t i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++)
            g->pos[i][k] = set->origin[k] + (double)set->splats[i].p[k];
        key[i] = hash3((int64_t)floor(g->pos[i][0] / h), (int64_t)floor(g->pos[i][1] / h),
                       (int64_t)floor(g->pos[i][2] / h), g->mask);
        g->start[key[i] + 1]++;
    }
    for (uint32_t i = 0; i < size; i++)
        g->start[i + 1] += g->start[i];
    uint32_t *fill = malloc(size * sizeof *fill);
    memcpy(fill, g->start, size * sizeof *fill);
    for (uint32_t i = 0; i < n; i++)
        g->items[fill[key[i]]++] = i;
    free(fill);
    free(key);
}

/* Distance from x to the nearest splat, exact when it is below h (else some value >= h). */
static double grid_nearest(const grid *g, const double x[3])
{
    double best = HUGE_VAL;
    int64_t c[3];
    for (int k = 0; k < 3; k++)
        c[k] = (int64_t)floor(x[k] / g->h);
    for (int dz = -1; dz <= 1; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                uint32_t b = hash3(c[0] + dx, c[1] + dy, c[2] + dz, g->mask);
                for (uint32_t i = g->start[b]; i < g->start[b + 1]; i++) {
                    const double *p = g->pos[g->items[i]];
                    double d = sqrt((p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]) +
                                    (p[2] - x[2]) * (p[2] - x[2]));
                    if (d < best) best = d;
                }
            }
    return best;
}

/* The least |x - splat i| - rho_i over the splats within h of x (HUGE_VAL: none): at most 0
 * when one splat's own radius covers x. */
static double grid_rho_slack(const grid *g, const crisp_splat_set *set, const double x[3])
{
    double best = HUGE_VAL;
    int64_t c[3];
    for (int k = 0; k < 3; k++)
        c[k] = (int64_t)floor(x[k] / g->h);
    for (int dz = -1; dz <= 1; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                uint32_t b = hash3(c[0] + dx, c[1] + dy, c[2] + dz, g->mask);
                for (uint32_t i = g->start[b]; i < g->start[b + 1]; i++) {
                    const double *p = g->pos[g->items[i]];
                    double d = sqrt((p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]) +
                                    (p[2] - x[2]) * (p[2] - x[2]));
                    if (d <= g->h) best = fmin(best, d - set->splats[g->items[i]].rho);
                }
            }
    return best;
}

static void grid_free(grid *g)
{
    free(g->start);
    free(g->items);
    free(g->pos);
}

/* ---- checking one set -------------------------------------------------------------------------
 */

typedef struct check_result {
    double tightness;      /* largest sampled nearest distance / radius */
    double rho_tightness;  /* largest sampled least (distance - rho) over the splats / radius */
    double thin_tightness; /* largest sampled nearest distance in the thinned set / radius */
    uint32_t thinned;      /* splats kept by crisp__splat_thin */
    long inside;           /* samples inside the trim */
    double curve_tightness;
    long curve; /* samples on the trim curves */
    uint32_t splats;
} check_result;

static int classify(const crisp_scene *sc, uint32_t face, double u, double v)
{
    const crisp_scene_face *f = &sc->faces[face];
    if (!f->piece_count) return 1;
    return crisp_trim_exact_classify(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
}

/* Builds face `face` at radius r and checks the guarantee at n x n jittered samples. */
static check_result check_face(const crisp_scene *sc, uint32_t face, double r, int n)
{
    const crisp_scene_face *f = &sc->faces[face];
    const crisp_surface *s = f->src->surface;
    crisp_splat_set set;
    crisp_status st = crisp__splat_build(sc, face, r, 0, &set);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    assert_true(set.radius <= r);
    assert_true(set.radius > 0.0);
    const double *dom = f->domain;
    double ext = fmax(fmax(fabs(dom[0]), fabs(dom[1])), fmax(fabs(dom[2]), fabs(dom[3])));
    double ulen = fmax(dom[1] - dom[0], dom[3] - dom[2]);
    /* Size of the face (for the float tolerances). */
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (uint32_t k = 0; k < f->patch_count; k++) {
        const double *b = sc->patches[f->first_patch + k].box;
        for (int q = 0; q < 3; q++)
            lo[q] = fmin(lo[q], b[q]), hi[q] = fmax(hi[q], b[q + 3]);
    }
    double size = 0.0, big = 0.0;
    for (int q = 0; q < 3; q++) {
        size = fmax(size, hi[q] - lo[q]);
        big = fmax(big, fmax(fabs(lo[q]), fabs(hi[q])));
    }
    /* Every splat: a point of the trimmed face with the surface's normal, and its own radius
     * within the set's (rounded up to a float). */
    for (uint32_t i = 0; i < set.count; i++) {
        const crisp_splat *sp = &set.splats[i];
        assert_true(sp->rho > 0 && sp->rho <= nextafterf((float)set.radius, INFINITY));
        double u = sp->uv[0], v = sp->uv[1];
        assert_true(u >= dom[0] - 1e-6 * ulen && u <= dom[1] + 1e-6 * ulen);
        assert_true(v >= dom[2] - 1e-6 * ulen && v <= dom[3] + 1e-6 * ulen);
        if (f->piece_count && !classify(sc, face, u, v)) {
            double d =
                crisp_trim_exact_distance(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
            if (d > 1e-6 * fmax(ext, ulen))
                fprintf(stderr, "splat %u at (%g, %g): %g\n", i, u, v, d);
            assert_true(d <= 1e-6 * fmax(ext, ulen)); /* the float rounding of uv */
        }
        double x[3], nn[3], su[3], sv[3];
        crisp_surface_derivs(s, u, v, x, su, sv, NULL, NULL, NULL);
        /* uv is stored in float: the point moves by at most |S_u| du + |S_v| dv. */
        double slack = 1.2e-7 * (fabs(u) * sqrt(su[0] * su[0] + su[1] * su[1] + su[2] * su[2]) +
                                 fabs(v) * sqrt(sv[0] * sv[0] + sv[1] * sv[1] + sv[2] * sv[2])) +
                       1e-6 * size + 1e-12 * big;
        for (int q = 0; q < 3; q++)
            assert_true(fabs(set.origin[q] + sp->p[q] - x[q]) <= slack);
        double len = sqrt(sp->n[0] * sp->n[0] + sp->n[1] * sp->n[1] + sp->n[2] * sp->n[2]);
        if (crisp_surface_normal(s, u, v, nn)) {
            assert_true(fabs(len - 1.0) < 1e-5);
            double dot = nn[0] * sp->n[0] + nn[1] * sp->n[1] + nn[2] * sp->n[2];
            assert_true(dot > 0.999);
        }
    }
    /* The store's thinning of the set (crisp__splat_thin): a subset, covering within r. */
    crisp_splat_set thin = set;
    thin.splats = malloc((set.count ? set.count : 1) * sizeof *thin.splats);
    memcpy(thin.splats, set.splats, set.count * sizeof *thin.splats);
    thin.count = crisp__splat_thin(thin.splats, set.count, r);
    assert_true(thin.count <= set.count && (thin.count > 0 || set.count == 0));
    /* Coverage at dense samples inside the trim. */
    grid g, gt;
    grid_build(&g, &set, r);
    grid_build(&gt, &thin, r);
    check_result res = {.splats = set.count, .rho_tightness = -1};
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            double u = dom[0] + (dom[1] - dom[0]) * (i + rnd()) / n;
            double v = dom[2] + (dom[3] - dom[2]) * (j + rnd()) / n;
            if (i == 0 && j % 7 == 0) u = dom[0]; /* the domain's edges too */
            if (j == n - 1 && i % 5 == 0) v = dom[3];
            if (!classify(sc, face, u, v)) continue;
            double x[3];
            crisp_surface_eval(s, u, v, x);
            double d = grid_nearest(&g, x);
            res.inside++;
            if (d > r)
                fprintf(stderr, "face %u r %g: (%g, %g) is %g from a splat\n", face, r, u, v, d);
            assert_true(d <= r);
            assert_true(d <= set.radius * (1 + 1e-9));
            res.tightness = fmax(res.tightness, d / r);
            /* within its own splat's rho (the stores' thinning relies on it) */
            double e = grid_rho_slack(&g, &set, x);
            if (e > 1e-9 * r)
                fprintf(stderr, "face %u r %g: (%g, %g) is %g beyond every splat's rho\n", face, r,
                        u, v, e);
            assert_true(e <= 1e-9 * r);
            res.rho_tightness = fmax(res.rho_tightness, e / r);
            double dt = grid_nearest(&gt, x);
            if (dt > r)
                fprintf(stderr, "face %u r %g: (%g, %g) is %g from a thinned splat\n", face, r, u,
                        v, dt);
            assert_true(dt <= r);
            res.thin_tightness = fmax(res.thin_tightness, dt / r);
        }
    /* Points of the trim curves in the domain: each borders inside points (the parity flips
     * across it), so by continuity it is within the radius too. These find a builder that
     * covers the band along the curves too loosely. */
    for (uint32_t k = 0; k < f->piece_count; k++) {
        const crisp_bezier_curve *b = &sc->pieces[f->first_piece + k];
        for (int i = 0; i <= 4 * n; i++) {
            double uv[2];
            crisp_bezier_curve_eval(b, (i + 0.5 * rnd()) / (4 * n + 0.5), uv);
            if (uv[0] < dom[0] || uv[0] > dom[1] || uv[1] < dom[2] || uv[1] > dom[3]) continue;
            double x[3];
            /* Points just off the curve, inside: the band where the cells' centres lie outside. */
            for (int q = 0; q < 4; q++) {
                double del = ulen * 1e-3 * rnd();
                double u = uv[0] + (q & 1 ? del : -del), v = uv[1] + (q & 2 ? del : -del);
                if (u < dom[0] || u > dom[1] || v < dom[2] || v > dom[3]) continue;
                if (!classify(sc, face, u, v)) continue;
                crisp_surface_eval(s, u, v, x);
                double d = grid_nearest(&g, x);
                assert_true(d <= r);
                assert_true(grid_nearest(&gt, x) <= r);
                res.tightness = fmax(res.tightness, d / r);
                res.inside++;
            }
            crisp_surface_eval(s, uv[0], uv[1], x);
            double d = grid_nearest(&g, x);
            assert_true(grid_rho_slack(&g, &set, x) <= 1e-9 * r);
            assert_true(grid_nearest(&gt, x) <= r);
            res.curve++;
            if (d > r)
                fprintf(stderr, "face %u r %g: curve point (%g, %g) is %g from a splat\n", face, r,
                        uv[0], uv[1], d);
            assert_true(d <= r);
            res.curve_tightness = fmax(res.curve_tightness, d / r);
        }
    }
    grid_free(&g);
    grid_free(&gt);
    res.thinned = thin.count;
    free(thin.splats);
    crisp__splat_set_free(&set);
    assert_null(set.splats);
    return res;
}

/* ---- random faces -----------------------------------------------------------------------------
 */

/* A clamped knot vector of `count` control points and degree d over [0, 1] with random interior
 * knots. */
static void knots(int d, int count, double *k)
{
    int m = count + d + 1, inner = count - d - 1;
    for (int i = 0; i <= d; i++)
        k[i] = 0.0, k[m - 1 - i] = 1.0;
    double t = 0.0;
    for (int i = 0; i < inner; i++) {
        t += (1.0 - t) * (0.2 + 0.5 * rnd()) / (inner - i);
        k[d + 1 + i] = t;
    }
}

static crisp_surface *random_surface(int du, int dv, int extra_u, int extra_v, double h)
{
    int cu = du + 1 + extra_u, cv = dv + 1 + extra_v;
    double ku[40], kv[40], pts[3 * 400], w[400];
    knots(du, cu, ku);
    knots(dv, cv, kv);
    for (int j = 0; j < cv; j++)
        for (int i = 0; i < cu; i++) {
            double *p = pts + 3 * (j * cu + i);
            p[0] = -1 + 2.0 * i / (cu - 1) + 0.3 * (rnd() - 0.5);
            p[1] = -1 + 2.0 * j / (cv - 1) + 0.3 * (rnd() - 0.5);
            p[2] = h * (rnd() - 0.5);
            w[j * cu + i] = weight();
        }
    crisp_surface *s;
    assert_int_equal(crisp_surface_create(du, dv, cu, cv, ku, kv, pts, w, &s), CRISP_OK);
    return s;
}

static crisp_curve *segment(const double a[2], const double b[2], int arc)
{
    crisp_curve *c;
    if (!arc) {
        double k[4] = {0, 0, 1, 1}, p[4] = {a[0], a[1], b[0], b[1]};
        assert_int_equal(crisp_curve_create(2, 1, 2, k, p, NULL, &c), CRISP_OK);
        return c;
    }
    /* A rational quadratic with its middle point pushed sideways. */
    double mx = 0.5 * (a[0] + b[0]), my = 0.5 * (a[1] + b[1]);
    double off = 0.6 * (rnd() - 0.5);
    double k[6] = {0, 0, 0, 1, 1, 1};
    double p[6] = {a[0], a[1], mx - off * (b[1] - a[1]), my + off * (b[0] - a[0]), b[0], b[1]};
    double w[3] = {1, weight(), 1};
    assert_int_equal(crisp_curve_create(2, 2, 3, k, p, w, &c), CRISP_OK);
    return c;
}

/* A closed loop through n points around (cu, cv) at radii in [r0, r1] (lines and arcs). */
static crisp_trim_loop star_loop(int n, double cu, double cv, double r0, double r1, int outer)
{
    crisp_trim_loop loop = {.is_outer = outer, .curve_count = n};
    loop.curves = crisp_malloc_array((size_t)n, sizeof *loop.curves);
    double pts[32][2];
    for (int i = 0; i < n; i++) {
        double a = 2 * M_PI * (i + 0.3 * rnd()) / n * (outer ? 1 : -1);
        double rr = r0 + (r1 - r0) * rnd();
        pts[i][0] = cu + rr * cos(a);
        pts[i][1] = cv + rr * sin(a);
    }
    for (int i = 0; i < n; i++)
        loop.curves[i] = segment(pts[i], pts[(i + 1) % n], rnd() < 0.6);
    return loop;
}

/* A face on a random surface: no loops (kind 0), a star (1), a star with a hole (2), a star
 * reaching beyond the domain (3). */
static crisp_model *random_model(int du, int dv, int kind)
{
    crisp_surface *s = random_surface(du, dv, (int)(rnd() * 3), (int)(rnd() * 3), 1.5);
    crisp_face f = {.surface = s};
    if (kind) {
        f.loop_count = kind == 2 ? 2 : 1;
        f.loops = crisp_malloc_array((size_t)f.loop_count, sizeof *f.loops);
        double r1 = kind == 3 ? 0.75 : 0.48;
        f.loops[0] =
            star_loop(5 + (int)(rnd() * 6), 0.45 + 0.1 * rnd(), 0.45 + 0.1 * rnd(), 0.2, r1, 1);
        if (kind == 2) f.loops[1] = star_loop(4 + (int)(rnd() * 3), 0.5, 0.5, 0.05, 0.15, 0);
    }
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
    return m;
}

static double face_diagonal(const crisp_scene *sc, uint32_t face)
{
    const crisp_scene_face *f = &sc->faces[face];
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (uint32_t k = 0; k < f->patch_count; k++) {
        const double *b = sc->patches[f->first_patch + k].box;
        for (int q = 0; q < 3; q++)
            lo[q] = fmin(lo[q], b[q]), hi[q] = fmax(hi[q], b[q + 3]);
    }
    return sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

static void test_random_faces(void **state)
{
    (void)state;
    static const int deg[][2] = {{1, 1}, {2, 2}, {3, 3}, {3, 2}, {5, 4}, {2, 5}};
    static const double div[] = {8, 25, 70};
    double worst = 0.0, worst_curve = 0.0, worst_rho = -1.0;
    long samples = 0, splats = 0, curve = 0, thinned = 0;
    double worst_thin = 0.0;
    for (int t = 0; t < 6; t++)
        for (int kind = 0; kind < 4; kind++) {
            crisp_model *m = random_model(deg[t][0], deg[t][1], kind);
            crisp_scene *sc;
            assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
            double diag = face_diagonal(sc, 0);
            for (int k = 0; k < 3; k++) {
                check_result res = check_face(sc, 0, diag / div[k], 120);
                worst = fmax(worst, res.tightness);
                worst_curve = fmax(worst_curve, res.curve_tightness);
                worst_rho = fmax(worst_rho, res.rho_tightness);
                worst_thin = fmax(worst_thin, res.thin_tightness);
                thinned += res.thinned;
                samples += res.inside;
                curve += res.curve;
                splats += res.splats;
            }
            crisp_scene_destroy(sc);
            crisp_model_destroy(m);
        }
    printf("random faces: %ld samples inside, %ld on curves, %ld splats, tightness %.3f inside, "
           "%.3f on curves; largest (distance - rho) / radius %.3f; thinned to %ld splats, "
           "tightness %.3f\n",
           samples, curve, splats, worst, worst_curve, worst_rho, thinned, worst_thin);
    assert_true(samples > 100000);
    assert_true(worst > 0.5); /* the check would catch a builder at twice the radius */
    /* and one whose rho were a quarter of the radius too small */
    assert_true(worst_rho > -0.25);
    assert_true(worst_thin > 0.5);
}

/* ---- degenerate patches ------------------------------------------------------------------------
 */

/* Faces whose patches collapse to a point on a side (sphere poles, a cone's apex): the hull radii
 * still shrink with the cells, and the normals there are crisp_surface_normal's limits. */
static void test_degenerate(void **state)
{
    (void)state;
    crisp_placement pl;
    double o[3] = {0.3, -0.2, 0.1}, axis[3] = {0.2, 1, 0.3};
    assert_int_equal(crisp_placement_make(o, axis, NULL, &pl), CRISP_OK);
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    crisp_surface *sphere, *cone, *sphere2;
    assert_int_equal(crisp_make_sphere(&pl, 1.3, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sphere),
                     CRISP_OK);
    assert_int_equal(crisp_make_cone(&pl, 0.0, 0.4, 0, 2 * M_PI, 0, 2, &cone), CRISP_OK);
    assert_int_equal(crisp_make_sphere(&pl, 2, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sphere2),
                     CRISP_OK);
    crisp_face f0 = {.surface = sphere}, f1 = {.surface = cone}, f2 = {.surface = sphere2};
    /* A loop on the second sphere reaching almost to the north pole, with a hole. */
    f2.loop_count = 1;
    f2.loops = crisp_malloc_array(1, sizeof *f2.loops);
    static const double pts[][2] = {{0.5, -1.2}, {5.5, -1.4}, {6.0, 1.5}, {3.0, 1.565}, {0.3, 1.2}};
    f2.loops[0] = (crisp_trim_loop){.is_outer = 1, .curve_count = 5};
    f2.loops[0].curves = crisp_malloc_array(5, sizeof *f2.loops[0].curves);
    for (int i = 0; i < 5; i++)
        f2.loops[0].curves[i] = segment(pts[i], pts[(i + 1) % 5], i % 2);
    assert_int_equal(crisp_model_add_face(m, &f0), CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &f1), CRISP_OK);
    assert_int_equal(crisp_model_add_face(m, &f2), CRISP_OK);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    double worst = 0.0;
    for (uint32_t face = 0; face < 3; face++)
        for (int k = 0; k < 3; k++) {
            check_result res = check_face(sc, face, face_diagonal(sc, face) / (5 + 20 * k), 100);
            assert_true(res.inside > 1000);
            worst = fmax(worst, res.tightness);
        }
    printf("spheres and a cone: tightness %.3f\n", worst);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* ---- bundled models ---------------------------------------------------------------------------
 */

static void check_model(const char *name, int faces)
{
    crisp_model *m;
    crisp_scene *sc = rt_load_scene(name, &m);
    double worst = 0.0;
    long samples = 0, splats = 0;
    for (int i = 0; i < faces; i++) {
        uint32_t face = (uint32_t)(((uint64_t)i * 7919u + 13u) % sc->face_count);
        double diag = face_diagonal(sc, face);
        for (int k = 0; k < 2; k++) {
            check_result res = check_face(sc, face, diag / (k ? 40 : 10), 60);
            worst = fmax(worst, res.tightness);
            samples += res.inside;
            splats += res.splats;
        }
    }
    /* Every face at a coarse radius (the regime of faces a few pixels across), fewer samples. */
    for (uint32_t face = 0; face < sc->face_count; face++) {
        check_result res = check_face(sc, face, face_diagonal(sc, face) / 6, 16);
        worst = fmax(worst, res.tightness);
        samples += res.inside;
        splats += res.splats;
    }
    printf("%s: %d faces at two radii and all %u at d/6, %ld samples inside, %ld splats, "
           "tightness %.3f\n",
           name, faces, sc->face_count, samples, splats, worst);
    assert_true(samples > 1000);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

static void test_models(void **state)
{
    (void)state;
    check_model("impeller.igs", 12);
    check_model("occt_linkrods.step", 10);
}

/* ---- limits and arguments ---------------------------------------------------------------------
 */

static void test_limits(void **state)
{
    (void)state;
    crisp_model *m = random_model(3, 3, 2);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    double r = face_diagonal(sc, 0) / 30;
    crisp_splat_set set;
    assert_int_equal(crisp__splat_build(sc, 0, r, 0, &set), CRISP_OK);
    uint32_t n = set.count;
    assert_true(n > 10);
    crisp__splat_set_free(&set);
    /* Exactly enough, one too few. */
    assert_int_equal(crisp__splat_build(sc, 0, r, n, &set), CRISP_OK);
    assert_int_equal(set.count, n);
    crisp__splat_set_free(&set);
    assert_int_equal(crisp__splat_build(sc, 0, r, n - 1, &set), CRISP_ERR_LIMIT);
    assert_null(set.splats);
    assert_int_equal(set.count, 0);
    assert_int_equal(crisp__splat_build(sc, 0, r / 1000, 100, &set), CRISP_ERR_LIMIT);
    assert_null(set.splats);
    /* Invalid arguments. */
    assert_int_equal(crisp__splat_build(sc, 1, r, 0, &set), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp__splat_build(sc, 0, 0.0, 0, &set), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp__splat_build(sc, 0, -r, 0, &set), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp__splat_build(sc, 0, NAN, 0, &set), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp__splat_build(sc, 0, INFINITY, 0, &set), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp__splat_build(NULL, 0, r, 0, &set), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp__splat_build(sc, 0, r, 0, NULL), CRISP_ERR_INVALID_ARG);
    /* A radius far below the float precision of the face. */
    assert_int_equal(crisp__splat_build(sc, 0, 1e-12, 0, &set), CRISP_ERR_LIMIT);
    crisp__splat_set_free(&set);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_random_faces),
        cmocka_unit_test(test_degenerate),
        cmocka_unit_test(test_models),
        cmocka_unit_test(test_limits),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
