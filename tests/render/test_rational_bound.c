/* The rational flatness bound (src/render/rational_bound.c, issue 12) on random rational patches
 * and blocks (weights spread 0.3..3) under random cameras:
 *   - the reparametrisation bounds hold at dense samples;
 *   - every triangle with vertices on the patch (or block) - the two of the coarse quad, either
 *     diagonal, random triangles, and the leaf meshes of crisp_tess at random levels - lies
 *     within the bound of the surface at dense barycentric samples, each triangle point (clip-
 *     space barycentrics, as the rasterizer interpolates) against the surface point at the same
 *     parameters.
 * (The planner's O(1) block bound, patch_groups.c, is this bound's last step on per-block ranges
 * that hold the control points' deviations; finish grows with the ranges, so it is at least the
 * bound here: tests/render/test_group_leaves.c's test_block_deviation checks the ranges.)
 * Prints the tightness (largest sampled distance / bound) and how the bound compares with the
 * homogeneous SLEFE error at level 1 (crisp_slefe_patch_screen_error). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/render.h"
#include "crisp/slefe.h"
#include "crisp/tess.h"
#include "render/rational_bound.h"
#include "render/render_test_util.h"

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

/* A random rational patch of degrees du x dv over about [-1, 1]^2 with bumps of height h. */
static void random_patch(crisp_bezier_patch *p, double *cpw, int du, int dv, double h)
{
    *p = (crisp_bezier_patch){.du = du, .dv = dv, .rational = 1, .u1 = 1, .v1 = 1, .cpw = cpw};
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++) {
            double *q = cpw + 4 * (j * (du + 1) + i), w = weight();
            double x = -1 + 2.0 * i / du + 0.3 * (rnd() - 0.5);
            double y = -1 + 2.0 * j / dv + 0.3 * (rnd() - 0.5);
            double z = h * (rnd() - 0.5);
            q[0] = w * x, q[1] = w * y, q[2] = w * z, q[3] = w;
        }
}

/* A camera looking at the origin from a random direction in front (z > 0 side, up to 70 degrees
 * off the normal) at distance dist, with the target moved off the centre of the image. */
static void random_view(double dist, crisp_mat4 vp, int *width, int *height)
{
    crisp_camera c;
    crisp_camera_matrices m;
    rt_random_camera(rnd, dist, 0, 1.2, 0.3, 0.01, &c, &m);
    crisp_mat4_copy(m.view_proj, vp);
    *width = c.width, *height = c.height;
}

/* Clip point of the Euclidean surface point at (s, t). */
static void clip_at(const crisp_bezier_patch *p, crisp_mat4 vp, double s, double t, double h[4])
{
    double P[3];
    crisp_bezier_patch_eval(p, s, t, P);
    crisp_mat4_mulp(vp, P, h);
}

static void to_px(const double h[4], int width, int height, double px[2])
{
    px[0] = (h[0] / h[3] + 1) * 0.5 * width;
    px[1] = (1 - h[1] / h[3]) * 0.5 * height;
}

/* A block of patches: nu x nv patches (row-major); block parameters (S, T) in [0, 1]^2. */
typedef struct block {
    const crisp_scene_patch *first;
    uint32_t stride, nu, nv;
} block;

static void block_clip(const block *b, crisp_mat4 vp, double S, double T, double h[4])
{
    double x = S * b->nu, y = T * b->nv;
    uint32_t iu = x >= b->nu ? b->nu - 1 : (uint32_t)x, iv = y >= b->nv ? b->nv - 1 : (uint32_t)y;
    clip_at(&b->first[iv * b->stride + iu].bez, vp, x - iu, y - iv, h);
}

/* Largest screen distance (pixels, max of x and y) between the triangle with vertices at block
 * parameters st[0..2] and the surface, at the same parameters, over N x N barycentric samples. */
static double triangle_distance(const block *b, crisp_mat4 vp, int width, int height,
                                const double st[3][2], int N)
{
    double V[3][4], worst = 0;
    for (int k = 0; k < 3; k++)
        block_clip(b, vp, st[k][0], st[k][1], V[k]);
    for (int i = 0; i <= N; i++)
        for (int j = 0; i + j <= N; j++) {
            double l[3] = {(double)i / N, (double)j / N, (double)(N - i - j) / N};
            double S = 0, T = 0, h[4] = {0, 0, 0, 0}, g[4], a[2], c[2];
            for (int k = 0; k < 3; k++) {
                S += l[k] * st[k][0], T += l[k] * st[k][1];
                for (int q = 0; q < 4; q++)
                    h[q] += l[k] * V[k][q];
            }
            block_clip(b, vp, S, T, g);
            to_px(h, width, height, a);
            to_px(g, width, height, c);
            worst = fmax(worst, fmax(fabs(a[0] - c[0]), fabs(a[1] - c[1])));
        }
    return worst;
}

/* The largest distance over many triangles of the block: the coarse quad along either diagonal,
 * random triangles, and crisp_tess meshes at random levels. */
static double block_distance(const block *b, crisp_mat4 vp, int width, int height)
{
    double worst = 0;
    static const double quad[4][3][2] = {{{0, 0}, {1, 0}, {1, 1}},
                                         {{0, 0}, {1, 1}, {0, 1}},
                                         {{0, 0}, {1, 0}, {0, 1}},
                                         {{1, 0}, {1, 1}, {0, 1}}};
    for (int k = 0; k < 4; k++)
        worst = fmax(worst, triangle_distance(b, vp, width, height, quad[k], 24));
    for (int k = 0; k < 12; k++) {
        double st[3][2];
        for (int v = 0; v < 3; v++)
            st[v][0] = rnd(), st[v][1] = rnd();
        worst = fmax(worst, triangle_distance(b, vp, width, height, (const double(*)[2])st, 12));
    }
    crisp_tess_levels lv = {{1 + (int)(4 * rnd()), 1 + (int)(4 * rnd())}, {0}};
    for (int k = 0; k < 4; k++)
        lv.outer[k] = 1 + (int)(6 * rnd());
    size_t nv, nt;
    assert_int_equal(crisp_tess_mesh_counts(&lv, &nv, &nt), CRISP_OK);
    double *st = malloc(sizeof(double) * 2 * nv);
    uint32_t *tri = malloc(sizeof(uint32_t) * 3 * nt);
    crisp_tess_mesh_generate(&lv, st, tri, 0);
    for (size_t k = 0; k < nt; k++) {
        double t3[3][2];
        for (int v = 0; v < 3; v++)
            t3[v][0] = st[2 * tri[3 * k + v]], t3[v][1] = st[2 * tri[3 * k + v] + 1];
        worst = fmax(worst, triangle_distance(b, vp, width, height, (const double(*)[2])t3, 8));
    }
    free(st);
    free(tri);
    return worst;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The reparametrisation bounds at 41 x 41 samples of random patches. */
static void test_reparam(void **state)
{
    (void)state;
    double cpw[6 * 6 * 4], worst = 0;
    for (int trial = 0; trial < 400; trial++) {
        crisp_bezier_patch p;
        int du = 1 + (int)(5 * rnd()), dv = 1 + (int)(5 * rnd());
        random_patch(&p, cpw, du, dv, 1);
        double sigma[3];
        crisp__rational_reparam(&p, sigma);
        double got[3] = {0, 0, 0};
        for (int a = 0; a <= 40; a++)
            for (int c = 0; c <= 40; c++) {
                double s = a / 40.0, t = c / 40.0, den = 0, ss = 0, tt = 0, st = 0;
                for (int j = 0; j <= dv; j++)
                    for (int i = 0; i <= du; i++) {
                        double bi = 1, bj = 1;
                        for (int k = 0; k < i; k++)
                            bi *= s * (du - k) / (k + 1);
                        bi *= pow(1 - s, du - i);
                        for (int k = 0; k < j; k++)
                            bj *= t * (dv - k) / (k + 1);
                        bj *= pow(1 - t, dv - j);
                        double r = cpw[4 * (j * (du + 1) + i) + 3] * bi * bj;
                        den += r;
                        ss += r * ((double)i / du - s);
                        tt += r * ((double)j / dv - t);
                        st += r * ((double)i / du - s) * ((double)j / dv - t);
                    }
                got[0] = fmax(got[0], fabs(ss / den));
                got[1] = fmax(got[1], fabs(tt / den));
                got[2] = fmax(got[2], fabs(st / den));
            }
        for (int k = 0; k < 3; k++) {
            if (got[k] > sigma[k] * (1 + 1e-9) + 1e-14)
                fail_msg("patch %d (%d x %d): reparametrisation %d: %g sampled, bound %g", trial,
                         du, dv, k, got[k], sigma[k]);
            if (sigma[k] > 1e-3) worst = fmax(worst, got[k] / sigma[k]);
        }
    }
    printf("reparametrisation bounds on 400 random patches: largest sampled / bound %.2f\n", worst);
    assert_true(worst > 0.3); /* the bound is not vacuous */
}

/* Single patches: the bound against the triangles, and against the homogeneous SLEFE level 1. */
static void test_patches(void **state)
{
    (void)state;
    enum { TRIALS = 300 };
    double tight[TRIALS], ratio[TRIALS];
    int n = 0, nr = 0;
    double cpw[4 * 4 * 4];
    for (int trial = 0; trial < TRIALS; trial++) {
        crisp_bezier_patch p;
        int du = 1 + (int)(3 * rnd()), dv = 1 + (int)(3 * rnd());
        random_patch(&p, cpw, du, dv, 0.5 * rnd());
        crisp_mat4 vp;
        int width, height;
        /* patches from a few pixels to a few hundred across */
        random_view(exp(log(6.0) + rnd() * log(300.0)), vp, &width, &height);
        crisp_scene_patch sp = {.bez = p};
        double bound = crisp__rational_block_px(&sp, 1, 1, 1, vp, width, height, 0);
        if (!isfinite(bound)) continue;
        block b = {&sp, 1, 1, 1};
        double d = block_distance(&b, vp, width, height);
        if (d > bound)
            fail_msg("patch %d (%d x %d): triangles %g px from the surface, bound %g px", trial, du,
                     dv, d, bound);
        tight[n++] = d / bound;
        crisp_slefe_view view = {.width = width, .height = height};
        crisp_mat4_copy(vp, view.view_proj);
        double homog;
        if (crisp_slefe_patch_screen_error(&p, 1, &view, &homog) == CRISP_OK)
            ratio[nr++] = homog / bound;
        else
            ratio[nr++] = INFINITY;
    }
    qsort(tight, (size_t)n, sizeof *tight, cmp_double);
    qsort(ratio, (size_t)nr, sizeof *ratio, cmp_double);
    printf("rational patches (weights 0.3..3), %d cameras: tightness (sampled / bound) median "
           "%.2f, 90%% %.2f, max %.2f; homogeneous SLEFE err(1) / this bound: 10%% %.2g, median "
           "%.2g, 90%% %.2g\n",
           n, tight[n / 2], tight[n * 9 / 10], tight[n - 1], ratio[nr / 10], ratio[nr / 2],
           ratio[nr * 9 / 10]);
    assert_true(n > TRIALS / 2);
}

/* The triangles of the tessellation mesh at levels lv, each as its three (s, t) corners;
 * *count of them (free the array). */
static double (*mesh_triangles(const crisp_tess_levels *lv, size_t *count))[3][2]
{
    size_t nv, nt;
    assert_int_equal(crisp_tess_mesh_counts(lv, &nv, &nt), CRISP_OK);
    double *st = malloc(sizeof(double) * 2 * nv);
    uint32_t *tri = malloc(sizeof(uint32_t) * 3 * nt);
    double(*t3)[3][2] = malloc(sizeof *t3 * nt);
    assert_non_null(st);
    assert_non_null(tri);
    assert_non_null(t3);
    crisp_tess_mesh_generate(lv, st, tri, 0);
    for (size_t k = 0; k < nt; k++)
        for (int v = 0; v < 3; v++)
            t3[k][v][0] = st[2 * tri[3 * k + v]], t3[k][v][1] = st[2 * tri[3 * k + v] + 1];
    free(st);
    free(tri);
    *count = nt;
    return t3;
}

/* Leaf meshes at level tau (edge levels tau..3 tau): the windowed level bound holds. */
static void test_levels(void **state)
{
    (void)state;
    enum { TRIALS = 120 };
    double tight[TRIALS], gain[TRIALS];
    int n = 0;
    double cpw[4 * 4 * 4];
    for (int trial = 0; trial < TRIALS; trial++) {
        crisp_bezier_patch p;
        int du = 2 + (int)(2 * rnd()), dv = 1 + (int)(3 * rnd());
        random_patch(&p, cpw, du, dv, 0.6 * rnd());
        crisp_mat4 vp;
        int width, height;
        random_view(exp(log(4.0) + rnd() * log(30.0)), vp, &width, &height);
        int tau = 2 + trial % 5;
        double bound = crisp__rational_level_px(&p, tau, vp, width, height, 0);
        if (!isfinite(bound)) continue;
        crisp_tess_levels lv = {{tau, tau}, {0}};
        for (int k = 0; k < 4; k++)
            lv.outer[k] = tau + (int)(2 * tau * rnd());
        size_t nt;
        double(*t3)[3][2] = mesh_triangles(&lv, &nt);
        crisp_scene_patch sp = {.bez = p};
        block b = {&sp, 1, 1, 1};
        double d = 0;
        for (size_t k = 0; k < nt; k++)
            d = fmax(d, triangle_distance(&b, vp, width, height, (const double(*)[2])t3[k], 10));
        free(t3);
        if (d > bound)
            fail_msg("patch %d at level %d (edges %d %d %d %d): mesh %g px from the surface, "
                     "bound %g px",
                     trial, tau, lv.outer[0], lv.outer[1], lv.outer[2], lv.outer[3], d, bound);
        tight[n] = d / bound;
        gain[n++] = crisp__rational_level_px(&p, 1, vp, width, height, 0) / bound;
    }
    qsort(tight, (size_t)n, sizeof *tight, cmp_double);
    qsort(gain, (size_t)n, sizeof *gain, cmp_double);
    printf("leaf meshes at levels 2..6, %d patches: tightness median %.2f, max %.2f; bound at "
           "level 1 / at tau: median %.1f\n",
           n, tight[n / 2], tight[n - 1], gain[n / 2]);
    assert_true(n > TRIALS / 2);
}

/* The premise of crisp__rational_level_px's windows: at level tau with any edge levels >= tau,
 * every triangle of the leaf mesh lies in a cell of the tau x tau grid or in two neighbouring
 * cells of the ring along a side, and with edge levels that are not multiples of tau some lie
 * in such a window away from the corners (the four corner windows alone, an earlier form of the
 * bound, do not hold them). */
static void test_ring_windows(void **state)
{
    (void)state;
    size_t off_corner = 0;
    for (int trial = 0; trial < 400; trial++) {
        int tau = 2 + trial % 7;
        double slack = 1e-12;
        crisp_tess_levels lv = {{tau, tau}, {0}};
        for (int k = 0; k < 4; k++)
            lv.outer[k] = tau + (int)(3 * tau * rnd());
        size_t nt;
        double(*t3)[3][2] = mesh_triangles(&lv, &nt);
        for (size_t k = 0; k < nt; k++) {
            double lo[2] = {1, 1}, hi[2] = {0, 0};
            for (int v = 0; v < 3; v++)
                for (int a = 0; a < 2; a++)
                    lo[a] = fmin(lo[a], t3[k][v][a]), hi[a] = fmax(hi[a], t3[k][v][a]);
            /* the cells' index ranges the triangle's box meets */
            int c0[2], c1[2];
            for (int a = 0; a < 2; a++) {
                c0[a] = (int)floor(lo[a] * tau + slack * tau);
                c1[a] = (int)ceil(hi[a] * tau - slack * tau) - 1;
                if (c0[a] > tau - 1) c0[a] = tau - 1;
                if (c1[a] < c0[a]) c1[a] = c0[a];
            }
            int ns = c1[0] - c0[0] + 1, nq = c1[1] - c0[1] + 1;
            if (ns == 1 && nq == 1) continue; /* one cell */
            /* two cells of the ring along a side: along s in the first or last row, or along t
             * in the first or last column */
            int ok = (ns == 2 && nq == 1 && (c0[1] == 0 || c0[1] == tau - 1)) ||
                     (nq == 2 && ns == 1 && (c0[0] == 0 || c0[0] == tau - 1));
            if (!ok)
                fail_msg("level %d, edges %d %d %d %d: triangle (%g %g) (%g %g) (%g %g) in "
                         "cells s %d..%d, t %d..%d",
                         tau, lv.outer[0], lv.outer[1], lv.outer[2], lv.outer[3], t3[k][0][0],
                         t3[k][0][1], t3[k][1][0], t3[k][1][1], t3[k][2][0], t3[k][2][1], c0[0],
                         c1[0], c0[1], c1[1]);
            int corner = (ns == 2 && (c0[0] == 0 || c1[0] == tau - 1)) ||
                         (nq == 2 && (c0[1] == 0 || c1[1] == tau - 1));
            off_corner += !corner;
        }
        free(t3);
    }
    printf("ring windows: %zu triangles across two ring cells away from the corners\n", off_corner);
    assert_true(off_corner > 0);
}

/* Blocks of a rational B-spline surface: the bound against triangles with vertices anywhere in
 * the block. (The planner's O(1) form of it, patch_groups.c, is rational_bound.c's last step on
 * ranges that hold the control points' deviations: tests/render/test_group_leaves.c checks those
 * ranges, test_block_deviation.) */
static void test_blocks(void **state)
{
    (void)state;
    enum { TRIALS = 60, NU = 6, NV = 5 };
    double tight[TRIALS];
    int n = 0;
    for (int trial = 0; trial < TRIALS; trial++) {
        int deg = 2 + trial % 2, cu = NU + deg, cv = NV + deg;
        double ku[NU + 8], kv[NV + 8], pts[(NU + 4) * (NV + 4) * 3], w[(NU + 4) * (NV + 4)];
        for (int i = 0; i < cu + deg + 1; i++)
            ku[i] = i <= deg ? 0 : i >= cu ? 1 : (double)(i - deg) / NU;
        for (int i = 0; i < cv + deg + 1; i++)
            kv[i] = i <= deg ? 0 : i >= cv ? 1 : (double)(i - deg) / NV;
        for (int j = 0; j < cv; j++)
            for (int i = 0; i < cu; i++) {
                double *q = pts + 3 * (j * cu + i);
                q[0] = -1 + 2.0 * i / (cu - 1) + 0.1 * (rnd() - 0.5);
                q[1] = -1 + 2.0 * j / (cv - 1) + 0.1 * (rnd() - 0.5);
                q[2] = 0.3 * (rnd() - 0.5);
                w[j * cu + i] = weight();
            }
        crisp_surface *s;
        assert_int_equal(crisp_surface_create(deg, deg, cu, cv, ku, kv, pts, w, &s), CRISP_OK);
        crisp_bezier_patches bp;
        assert_int_equal(crisp_surface_to_bezier(s, &bp), CRISP_OK);
        assert_int_equal(bp.count, NU * NV);
        crisp_scene_patch sp[NU * NV];
        for (int k = 0; k < NU * NV; k++)
            sp[k] = (crisp_scene_patch){.bez = bp.patches[k]};
        /* a random sub-block */
        uint32_t iu0 = (uint32_t)(rnd() * 3), iv0 = (uint32_t)(rnd() * 3);
        uint32_t nu = 1 + (uint32_t)(rnd() * (NU - iu0)), nv = 1 + (uint32_t)(rnd() * (NV - iv0));
        if (nu > NU - iu0) nu = NU - iu0;
        if (nv > NV - iv0) nv = NV - iv0;
        block b = {sp + iv0 * NU + iu0, NU, nu, nv};
        crisp_mat4 vp;
        int width, height;
        random_view(exp(log(20.0) + rnd() * log(100.0)), vp, &width, &height);
        double bound = crisp__rational_block_px(b.first, b.stride, nu, nv, vp, width, height, 0);
        /* The planner's form with each patch's sigma's formed once and kept (patch_groups.c):
         * the same number, at every accept (the coarse sigma's decide some, the halved ones
         * others). */
        double sig[NU * NV * CRISP__SIGMA_STRIDE];
        for (int k = 0; k < NU * NV; k++)
            crisp__rational_sigmas(&sp[k].bez, sig + CRISP__SIGMA_STRIDE * k);
        for (int k = 0; k < 4; k++) {
            double accept = k == 0 ? 0 : bound * (k == 1 ? 0.5 : k == 2 ? 1.0 : 2.0);
            double with = crisp__rational_block_px_sigmas(
                b.first, sig + CRISP__SIGMA_STRIDE * (iv0 * NU + iu0), b.stride, nu, nv, vp, width,
                height, accept);
            double without =
                crisp__rational_block_px(b.first, b.stride, nu, nv, vp, width, height, accept);
            if (!(with == without || (isnan(with) && isnan(without))))
                fail_msg("block %d, accept %g: %.17g with kept sigma's, %.17g formed", trial,
                         accept, with, without);
        }
        if (isfinite(bound)) {
            double d = block_distance(&b, vp, width, height);
            if (d > bound)
                fail_msg("block %d (%u x %u patches, degree %d): triangles %g px from the "
                         "surface, bound %g px",
                         trial, nu, nv, deg, d, bound);
            tight[n++] = d / bound;
        }
        crisp_bezier_patches_free(&bp);
        crisp_surface_destroy(s);
    }
    qsort(tight, (size_t)n, sizeof *tight, cmp_double);
    printf("rational blocks (weights 0.3..3), %d cameras: tightness median %.2f, max %.2f\n", n,
           tight[n / 2], tight[n - 1]);
    assert_true(n > TRIALS / 2);
}

/* Largest |T_w - S_w| (clip W: the depth the rasterizer writes) between the triangle with vertices
 * at block parameters st[0..2] and the surface at the same parameters, over N x N barycentric
 * samples; the least surface W into *wmin. */
static double triangle_depth(const block *b, crisp_mat4 vp, const double st[3][2], int N,
                             double *wmin)
{
    double V[3][4], worst = 0;
    for (int k = 0; k < 3; k++)
        block_clip(b, vp, st[k][0], st[k][1], V[k]);
    for (int i = 0; i <= N; i++)
        for (int j = 0; i + j <= N; j++) {
            double l[3] = {(double)i / N, (double)j / N, (double)(N - i - j) / N};
            double S = 0, T = 0, hw = 0, g[4];
            for (int k = 0; k < 3; k++) {
                S += l[k] * st[k][0], T += l[k] * st[k][1];
                hw += l[k] * V[k][3];
            }
            block_clip(b, vp, S, T, g);
            worst = fmax(worst, fabs(hw - g[3]));
            *wmin = fmin(*wmin, g[3]);
        }
    return worst;
}

/* block_distance's triangles, along the view. */
static double block_depth(const block *b, crisp_mat4 vp, double *wmin)
{
    double worst = 0;
    static const double quad[4][3][2] = {{{0, 0}, {1, 0}, {1, 1}},
                                         {{0, 0}, {1, 1}, {0, 1}},
                                         {{0, 0}, {1, 0}, {0, 1}},
                                         {{1, 0}, {1, 1}, {0, 1}}};
    for (int k = 0; k < 4; k++)
        worst = fmax(worst, triangle_depth(b, vp, quad[k], 24, wmin));
    for (int k = 0; k < 12; k++) {
        double st[3][2];
        for (int v = 0; v < 3; v++)
            st[v][0] = rnd(), st[v][1] = rnd();
        worst = fmax(worst, triangle_depth(b, vp, (const double(*)[2])st, 12, wmin));
    }
    crisp_tess_levels lv = {{1 + (int)(4 * rnd()), 1 + (int)(4 * rnd())}, {0}};
    for (int k = 0; k < 4; k++)
        lv.outer[k] = 1 + (int)(6 * rnd());
    size_t nt;
    double(*t3)[3][2] = mesh_triangles(&lv, &nt);
    for (size_t k = 0; k < nt; k++)
        worst = fmax(worst, triangle_depth(b, vp, (const double(*)[2])t3[k], 8, wmin));
    free(t3);
    return worst;
}

/* The bound's W part (crisp__rational_block_px_depth, which the planner takes as a level-1
 * leaf's depth bound, quadtree.c build_cell): on random patches and cameras, every triangle's
 * clip W within depth[0] of the surface's at the same parameters and the surface's W at least
 * depth[1], at dense samples, for every accept (the coarse and the halved sigma's each give it);
 * the screen bound is crisp__rational_block_px_sigmas's number. */
static void test_depth_part(void **state)
{
    (void)state;
    enum { TRIALS = 300 };
    double tight[TRIALS], margin[TRIALS];
    int n = 0;
    double cpw[6 * 6 * 4];
    for (int trial = 0; trial < TRIALS; trial++) {
        crisp_bezier_patch p;
        int du = 1 + (int)(5 * rnd()), dv = 1 + (int)(5 * rnd());
        random_patch(&p, cpw, du, dv, 0.5 * rnd());
        crisp_mat4 vp;
        int width, height;
        random_view(exp(log(4.0) + rnd() * log(300.0)), vp, &width, &height);
        crisp_scene_patch sp = {.bez = p};
        double sig[CRISP__SIGMA_STRIDE];
        crisp__rational_sigmas(&p, sig);
        double full = crisp__rational_block_px_sigmas(&sp, sig, 1, 1, 1, vp, width, height, 0);
        if (!isfinite(full)) continue;
        block b = {&sp, 1, 1, 1};
        double wmin = INFINITY, d = block_depth(&b, vp, &wmin), loosest = 0, least = INFINITY;
        for (int k = 0; k < 3; k++) {
            double accept = k == 0 ? 0 : full * (k == 1 ? 0.5 : 2.0), depth[2];
            double e =
                crisp__rational_block_px_depth(&sp, sig, 1, 1, 1, vp, width, height, accept, depth);
            double want =
                crisp__rational_block_px_sigmas(&sp, sig, 1, 1, 1, vp, width, height, accept);
            if (!(e == want))
                fail_msg("patch %d, accept %g: %.17g with the depth part, %.17g without", trial,
                         accept, e, want);
            if (d > depth[0] || wmin < depth[1])
                fail_msg("patch %d (%d x %d), accept %g: triangles' W %g from the surface's "
                         "(bound %g), least W %g (bound %g)",
                         trial, du, dv, accept, d, depth[0], wmin, depth[1]);
            loosest = fmax(loosest, depth[0]);
            least = fmin(least, depth[1]);
        }
        tight[n] = d / loosest;
        margin[n++] = least / wmin;
    }
    qsort(tight, (size_t)n, sizeof *tight, cmp_double);
    qsort(margin, (size_t)n, sizeof *margin, cmp_double);
    printf(
        "W part on %d rational patches (weights 0.3..3): tightness (sampled |T_w - S_w| / bound) "
        "median %.2f, 90%% %.2f, max %.2f; least W bound / sampled: median %.4f, min %.4f\n",
        n, tight[n / 2], tight[n * 9 / 10], tight[n - 1], margin[n / 2], margin[0]);
    assert_true(n > TRIALS / 2);
    assert_true(tight[n - 1] > 0.2); /* not vacuous */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reparam), cmocka_unit_test(test_patches),
        cmocka_unit_test(test_levels),  cmocka_unit_test(test_ring_windows),
        cmocka_unit_test(test_blocks),  cmocka_unit_test(test_depth_part),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
