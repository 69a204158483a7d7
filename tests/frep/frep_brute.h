/* Brute-force references for the frep tests: every pixel (2D) or every voxel top down (3D)
 * evaluated on the full tape with no subdivision. */
#ifndef CRISP_TEST_FREP_BRUTE_H
#define CRISP_TEST_FREP_BRUTE_H

#include <stdlib.h>

#include "crisp/frep.h"

static inline float brute_coord(double a, double b, int n, int i) { return (float)(a + (i + 0.5) * (b - a) / n); }

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
    for (size_t p = 0; p < np; p++) img[p] = v[p] < 0 ? 255 : 0;
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
    for (size_t p = 0; p < np; p++) h[p] = -1, open[p] = p;
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
            if (v[q] < 0) h[open[q]] = k;
            else open[m++] = open[q];
        }
        nopen = m;
    }
    free(x), free(y), free(z), free(v), free(open);
    return h;
}

#endif
