/* The depth bound along the view (src/render/depth_bound.c, issue 13) on random polynomial and
 * rational patches (degrees 1-6, weights 0.5..2) under random cameras: at the level
 * crisp__depth_tess_level picks, every triangle of the tessellation (the uniform grid along
 * either diagonal, and crisp_tess meshes with that inner level and finer edges) lies within eps
 * pixels' world size of the surface along the view, at dense barycentric samples: the triangle
 * point's camera-space depth (clip W of the flat triangle, as the rasterizer draws it) against
 * the surface point at the same parameters, measured against the pixel size at that depth
 * computed from the camera itself. Prints the tightness (largest sampled error / eps) and, one
 * level coarser, how often the error there was already within eps. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "crisp/render.h"
#include "crisp/tess.h"
#include "render/depth_bound.h"
#include "render/render_test_util.h"

static uint64_t rng = 0x9e3779b97f4a7c15ull;
static double rnd(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* A random patch of degrees du x dv over about [-s, s]^2 (s = size) with bumps of height h;
 * weights 1 or log-uniform in [0.5, 2]. */
static void random_patch(crisp_bezier_patch *p, double *cpw, int du, int dv, double size, double h,
                         int rational)
{
    *p = (crisp_bezier_patch){
        .du = du, .dv = dv, .rational = rational, .u1 = 1, .v1 = 1, .cpw = cpw};
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++) {
            double *q = cpw + 4 * (j * (du + 1) + i);
            double w = rational ? exp(log(0.5) + rnd() * log(4.0)) : 1;
            double x = size * (-1 + 2.0 * i / du + 0.3 * (rnd() - 0.5));
            double y = size * (-1 + 2.0 * j / dv + 0.3 * (rnd() - 0.5));
            double z = h * (rnd() - 0.5);
            q[0] = w * x, q[1] = w * y, q[2] = w * z, q[3] = w;
        }
}

typedef struct view {
    crisp_mat4 vp;
    int width, height;
    double px_per_rad; /* pixels per radian at the image centre: the pixel's world size at depth d
                          is d / px_per_rad */
} view;

/* A camera looking at the origin from up to 80 degrees off the patch's normal, at distance dist,
 * target moved off the centre; fov 10-70 degrees. */
static void random_view(double dist, view *v)
{
    crisp_camera c;
    crisp_camera_matrices m;
    rt_random_camera(rnd, dist, 1, 1.4, 0.2, 0.001, &c, &m);
    crisp_mat4_copy(m.view_proj, v->vp);
    v->width = c.width, v->height = c.height;
    v->px_per_rad = 0.5 * c.height / tan(0.5 * c.fov_deg * 3.14159265358979323846 / 180);
}

static double depth_at(const crisp_bezier_patch *p, crisp_mat4 vp, double s, double t, double P[3])
{
    double h[4];
    crisp_bezier_patch_eval(p, s, t, P);
    crisp_mat4_mulp(vp, P, h);
    return h[3];
}

/* Largest depth error of the triangle with parameters st[0..2], in pixels' world size at the
 * surface point's depth, over N x N barycentric samples. */
static double triangle_error(const crisp_bezier_patch *p, view *v, const double st[3][2], int N)
{
    double d[3], P[3], worst = 0;
    for (int k = 0; k < 3; k++)
        d[k] = depth_at(p, v->vp, st[k][0], st[k][1], P);
    for (int i = 0; i <= N; i++)
        for (int j = 0; i + j <= N; j++) {
            double l[3] = {(double)i / N, (double)j / N, (double)(N - i - j) / N};
            double s = 0, t = 0, dt = 0;
            for (int k = 0; k < 3; k++)
                s += l[k] * st[k][0], t += l[k] * st[k][1], dt += l[k] * d[k];
            double ds = depth_at(p, v->vp, s, t, P);
            /* The pixel's world size at depth ds (the image's smallest: the centre's). */
            worst = fmax(worst, fabs(dt - ds) / (ds / v->px_per_rad));
        }
    return worst;
}

/* Largest error over the tessellation at level tau: the grid's cells along both diagonals, and
 * a crisp_tess mesh with inner level tau and edge levels tau..3 tau. */
static double mesh_error(const crisp_bezier_patch *p, view *v, int tau)
{
    double worst = 0, h = 1.0 / tau;
    for (int j = 0; j < tau; j++)
        for (int i = 0; i < tau; i++) {
            double s0 = i * h, s1 = (i + 1) * h, t0 = j * h, t1 = (j + 1) * h;
            const double tris[4][3][2] = {{{s0, t0}, {s1, t0}, {s1, t1}},
                                          {{s0, t0}, {s1, t1}, {s0, t1}},
                                          {{s0, t0}, {s1, t0}, {s0, t1}},
                                          {{s1, t0}, {s1, t1}, {s0, t1}}};
            for (int k = 0; k < 4; k++)
                worst = fmax(worst, triangle_error(p, v, tris[k], 6));
        }
    crisp_tess_levels lv = {{tau, tau}, {0}};
    for (int k = 0; k < 4; k++)
        lv.outer[k] = tau + (int)(2 * tau * rnd());
    size_t nv, nt;
    assert_int_equal(crisp_tess_mesh_counts(&lv, &nv, &nt), CRISP_OK);
    double *st = malloc(sizeof(double) * 2 * nv);
    uint32_t *tri = malloc(sizeof(uint32_t) * 3 * nt);
    assert_non_null(st);
    assert_non_null(tri);
    crisp_tess_mesh_generate(&lv, st, tri, 0);
    for (size_t k = 0; k < nt; k++) {
        double t3[3][2];
        for (int q = 0; q < 3; q++)
            t3[q][0] = st[2 * tri[3 * k + q]], t3[q][1] = st[2 * tri[3 * k + q] + 1];
        worst = fmax(worst, triangle_error(p, v, (const double(*)[2])t3, 4));
    }
    free(st);
    free(tri);
    return worst;
}

static void run(int rational)
{
    double cpw[7 * 7 * 4], eps = 0.5, tight = 0;
    int raised = 0, trials = 0, least_n = 0;
    double ratio_sum = 0, ratio_max = 0;
    for (int trial = 0; trial < 300; trial++) {
        int du = 1 + (int)(6 * rnd()), dv = 1 + (int)(6 * rnd());
        crisp_bezier_patch p;
        /* Patches from 1/100 to about the view's width; bumps up to as high as wide. */
        double size = exp(log(0.01) + rnd() * log(100.0));
        random_patch(&p, cpw, du, dv, size, size * 2 * rnd(), rational);
        view v;
        random_view(3 + 3 * rnd(), &v);
        int tau = crisp__depth_tess_level(&p, v.vp, v.width, v.height, eps, 1, 64);
        double wmin = 0;
        if (!isfinite(crisp__depth_error_bound(&p, v.vp, 1, &wmin))) continue;
        if (tau > 64) continue; /* split: its children are tested like any patch */
        trials++;
        raised += tau > 1;
        double e = mesh_error(&p, &v, tau) / eps;
        if (e > 1 + 1e-9)
            fail_msg("trial %d (degrees %d x %d, rational %d, level %d): depth error %.4g eps",
                     trial, du, dv, rational, tau, e);
        tight = fmax(tight, e);
        if (tau > 1 && tau <= 16) {
            /* The least level whose sampled error is within eps. */
            int least = tau;
            while (least > 1 && mesh_error(&p, &v, least - 1) / eps <= 1)
                least--;
            least_n++;
            ratio_sum += (double)tau / least, ratio_max = fmax(ratio_max, (double)tau / least);
        }
    }
    printf("%s: %d patches, %d raised above level 1; largest sampled depth error %.3f eps at the "
           "chosen level; chosen level / least sampled level within eps: mean %.2f, worst %.2f "
           "(%d patches at levels 2-16)\n",
           rational ? "rational" : "polynomial", trials, raised, tight, ratio_sum / least_n,
           ratio_max, least_n);
    assert_true(trials > 200);
    assert_true(raised > 20);
}

static void test_depth_polynomial(void **state)
{
    (void)state;
    run(0);
}

static void test_depth_rational(void **state)
{
    (void)state;
    run(1);
}

/* A bulge facing the eye (the case of issue 13's bearing face 181): a flat-on-screen bicubic
 * whose middle rises toward the camera; the screen bound would take level 1, the depth bound
 * asks for more and its triangles lie within eps. */
static void test_bulge_facing_eye(void **state)
{
    (void)state;
    double cpw[16 * 4];
    crisp_bezier_patch p = {.du = 3, .dv = 3, .u1 = 1, .v1 = 1, .cpw = cpw};
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            double *q = cpw + 4 * (j * 4 + i);
            q[0] = i / 3.0 - 0.5, q[1] = j / 3.0 - 0.5;
            q[2] = (i == 1 || i == 2) && (j == 1 || j == 2) ? 0.02 : 0;
            q[3] = 1;
        }
    crisp_camera c = {.fov_deg = 30,
                      .width = 800,
                      .height = 600,
                      .znear = 0.01,
                      .zfar = 100,
                      .eye = {0, 0, 3},
                      .up = {0, 1, 0}};
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(&c, &m);
    int tau = crisp__depth_tess_level(&p, m.view_proj, c.width, c.height, 0.5, 1, 64);
    assert_true(tau > 1);
    view v = {.width = c.width,
              .height = c.height,
              .px_per_rad = 0.5 * c.height / tan(15 * 3.14159265358979323846 / 180)};
    crisp_mat4_copy(m.view_proj, v.vp);
    assert_true(mesh_error(&p, &v, 1) > 0.5);
    assert_true(mesh_error(&p, &v, tau) <= 0.5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_depth_polynomial),
        cmocka_unit_test(test_depth_rational),
        cmocka_unit_test(test_bulge_facing_eye),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
