/* Brute-force references for the frep tests: every pixel (2D) or every voxel top down (3D)
 * evaluated on the full tape with no subdivision. */
#ifndef CRISP_TEST_FREP_BRUTE_H
#define CRISP_TEST_FREP_BRUTE_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/frep.h"

static inline float brute_coord(double a, double b, int n, int i)
{
    return (float)(a + (i + 0.5) * (b - a) / n);
}

/* 2D: 255 inside, 0 outside, over [-1,1]^2 at pixel centres (row 0 at y = +1). */
static inline uint8_t *brute_2d(const crisp_frep_tape *t, int n)
{
    size_t np = (size_t)n * n;
    float *x = malloc(np * sizeof *x), *y = malloc(np * sizeof *y), *z = calloc(np, sizeof *z),
          *v = malloc(np * sizeof *v);
    uint8_t *img = malloc(np);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            x[(size_t)j * n + i] = brute_coord(-1, 1, n, i);
            y[(size_t)j * n + i] = (float)(1 - (j + 0.5) * 2.0 / n);
        }
    crisp_frep_eval_batch(t, np, x, y, z, v);
    for (size_t p = 0; p < np; p++)
        img[p] = v[p] < 0 ? 255 : 0;
    free(x), free(y), free(z), free(v);
    return img;
}

/* 3D: for each pixel, the highest voxel index in [0, n) with f < 0, or -1. */
static inline int32_t *brute_3d(const crisp_frep_tape *t, int n)
{
    size_t np = (size_t)n * n;
    float *x = malloc(np * sizeof *x), *y = malloc(np * sizeof *y), *z = malloc(np * sizeof *z),
          *v = malloc(np * sizeof *v);
    int32_t *h = malloc(np * sizeof *h);
    size_t *open = malloc(np * sizeof *open);
    for (size_t p = 0; p < np; p++)
        h[p] = -1, open[p] = p;
    size_t nopen = np;
    for (int k = n - 1; k >= 0 && nopen; k--) {
        float zk = brute_coord(-1, 1, n, k);
        for (size_t q = 0; q < nopen; q++) {
            size_t p = open[q];
            int i = (int)(p % (size_t)n), j = (int)(p / (size_t)n);
            x[q] = brute_coord(-1, 1, n, i);
            y[q] = (float)(1 - (j + 0.5) * 2.0 / n);
            z[q] = zk;
        }
        crisp_frep_eval_batch(t, nopen, x, y, z, v);
        size_t m = 0;
        for (size_t q = 0; q < nopen; q++) {
            if (v[q] < 0)
                h[open[q]] = k;
            else
                open[m++] = open[q];
        }
        nopen = m;
    }
    free(x), free(y), free(z), free(v), free(open);
    return h;
}

#ifdef cmocka_unit_test
/* A 3D render of f at n^3 over [-1,1]^3 against brute force: heights equal brute_3d; each hit
 * pixel's normal is the full tape's gradient direction at the hit voxel, and that gradient is
 * finite wherever the value is (a NaN gradient would hide behind the renderer's fallback normal);
 * and the renderer's own brute-force mode gives bit for bit the same heights, normals and shading
 * (crisp_frep_shade), so tape shortening changes nothing a viewer sees. Takes ownership of f. */
static inline void check_model_3d(crisp_frep *f, const char *name, int n)
{
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    int32_t *ref = brute_3d(t, n);
    crisp_frep_renderer *r[2];
    for (int b = 0; b < 2; b++) {
        crisp_frep_render_desc d = {
            .width = n, .height = n, .depth = n, .threads = 2, .flags = b ? CRISP_FREP_BRUTE : 0};
        assert_int_equal(crisp_frep_renderer_create(t, &d, &r[b]), CRISP_OK);
        assert_int_equal(crisp_frep_renderer_run(r[b]), CRISP_OK);
    }
    const crisp_frep_image *img = crisp_frep_renderer_image(r[0]);
    const crisp_frep_image *bru = crisp_frep_renderer_image(r[1]);
    size_t np = (size_t)n * n, differ = 0, hit = 0, nan_grad = 0, normals = 0, shades = 0;
    uint8_t *sa = malloc(np), *sb = malloc(np);
    assert_non_null(sa);
    assert_non_null(sb);
    crisp_frep_shade(img, sa);
    crisp_frep_shade(bru, sb);
    for (size_t p = 0; p < np; p++) {
        differ += img->heights[p] != ref[p] || bru->heights[p] != ref[p];
        normals += memcmp(img->normal + 3 * p, bru->normal + 3 * p, 3 * sizeof(float)) != 0;
        shades += sa[p] != sb[p];
        if (ref[p] >= 0) {
            hit++;
            const float *nv = img->normal + 3 * p;
            float len = nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2];
            assert_float_equal(len, 1, 1e-4);
            /* the normal is the full tape's gradient direction at the hit voxel */
            int i = (int)(p % (size_t)n), j = (int)(p / (size_t)n);
            float x = brute_coord(-1, 1, n, i), y = (float)(1 - (j + 0.5) * 2.0 / n);
            float z = brute_coord(-1, 1, n, ref[p]), g[4];
            assert_int_equal(crisp_frep_eval_grad(t, 1, &x, &y, &z, g), CRISP_OK);
            float gl = sqrtf(g[1] * g[1] + g[2] * g[2] + g[3] * g[3]);
            if (isfinite(g[0]) && !isfinite(gl)) nan_grad++;
            if (gl > 0 && isfinite(gl))
                for (int c = 0; c < 3; c++)
                    assert_float_equal(nv[c], g[1 + c] / gl, 1e-5);
            assert_true((img->inside[p] == 255));
        } else {
            assert_true(isinf(img->z[p]) && img->z[p] < 0);
        }
    }
    if (differ || normals || shades || nan_grad)
        fprintf(stderr,
                "%s 3D %d: %zu heights, %zu normals, %zu shades differ from brute force; "
                "%zu non-finite gradients\n",
                name, n, differ, normals, shades, nan_grad);
    assert_int_equal(differ, 0);
    assert_int_equal(normals, 0);
    assert_int_equal(shades, 0);
    assert_int_equal(nan_grad, 0);
    assert_true(hit > 0);
    free(sa), free(sb), free(ref);
    for (int b = 0; b < 2; b++)
        crisp_frep_renderer_destroy(r[b]);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}
#endif

#endif
