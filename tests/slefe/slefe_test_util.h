/* Helpers for the slefe tests: a seeded generator, long-double de Casteljau references and
 * random Bézier patches, so the tests do not depend on the nurbs kernel's implementation. */
#ifndef CRISP_SLEFE_TEST_UTIL_H
#define CRISP_SLEFE_TEST_UTIL_H

#include <math.h>
#include <stdint.h>

#include "crisp/nurbs.h"
#include "crisp/slefe.h"

typedef struct {
    uint64_t s;
} rng;

static inline uint64_t rng_next(rng *r)
{
    uint64_t z = (r->s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* Uniform in [a, b). */
static inline double rng_uniform(rng *r, double a, double b)
{
    return a + (b - a) * (double)(rng_next(r) >> 11) * 0x1.0p-53;
}

static inline int rng_int(rng *r, int a, int b) /* a..b inclusive */
{
    return a + (int)(rng_next(r) % (uint64_t)(b - a + 1));
}

/* sum_i coef[i * stride] B_i^d(t) in long double. */
static inline long double ref_bezier(int d, const double *coef, int stride, long double t)
{
    long double b[CRISP_MAX_DEGREE + 1];
    for (int i = 0; i <= d; i++)
        b[i] = coef[i * stride];
    for (int r = 1; r <= d; r++)
        for (int i = 0; i <= d - r; i++)
            b[i] = (1.0L - t) * b[i] + t * b[i + 1];
    return b[0];
}

/* Homogeneous coordinate c of a patch at (s, t), long double. */
static inline long double ref_patch(const crisp_bezier_patch *p, int c, long double s,
                                    long double t)
{
    long double col[CRISP_MAX_DEGREE + 1];
    for (int i = 0; i <= p->du; i++)
        col[i] = ref_bezier(p->dv, p->cpw + i * 4 + c, (p->du + 1) * 4, t);
    /* de Casteljau in u on the long double column values */
    for (int r = 1; r <= p->du; r++)
        for (int i = 0; i <= p->du - r; i++)
            col[i] = (1.0L - s) * col[i] + s * col[i + 1];
    return col[0];
}

/* Piecewise-linear interpolant of v[k * stride], k = 0..m, at t in [0, 1]. */
static inline long double pl_at(const double *v, int stride, int m, long double t)
{
    int k = (int)(t * m);
    if (k >= m) k = m - 1;
    if (k < 0) k = 0;
    long double f = t * m - k;
    return (1.0L - f) * v[k * stride] + f * v[(k + 1) * stride];
}

/* Random patch of degree (du, dv) in [-1, 1]^3 with weights in [0.2, 5] when rational (stored
 * homogeneous). cpw must hold (du + 1) * (dv + 1) * 4 doubles. */
static inline void random_patch(rng *r, int du, int dv, int rational, double *cpw,
                                crisp_bezier_patch *dest)
{
    int n = (du + 1) * (dv + 1);
    for (int i = 0; i < n; i++) {
        double w = rational ? rng_uniform(r, 0.2, 5.0) : 1.0;
        for (int c = 0; c < 3; c++)
            cpw[i * 4 + c] = w * rng_uniform(r, -1.0, 1.0);
        cpw[i * 4 + 3] = w;
    }
    *dest = (crisp_bezier_patch){
        .du = du, .dv = dv, .rational = rational, .u0 = 0, .u1 = 1, .v0 = 0, .v1 = 1, .cpw = cpw};
}

/* A random perspective view for the bound tests: the eye at a random direction from centre, at
 * a distance drawn in [dist_lo, dist_hi] and divided by the direction's length (drawn in the unit
 * ball, not too short), looking at centre moved by up to 0.3 on each axis; a 200-2000 px image
 * and a field of view in [fov_lo, fov_hi] degrees; near 0.1, far 100. */
static inline void random_slefe_view(rng *r, double dist_lo, double dist_hi, const double centre[3],
                                     double fov_lo, double fov_hi, crisp_slefe_view *v)
{
    double dir[3], n;
    do {
        n = 0;
        for (int i = 0; i < 3; i++) {
            dir[i] = rng_uniform(r, -1, 1);
            n += dir[i] * dir[i];
        }
    } while (n < 0.05 || n > 1);
    double dist = rng_uniform(r, dist_lo, dist_hi) / sqrt(n);
    double eye[3], target[3];
    for (int i = 0; i < 3; i++) {
        target[i] = centre[i] + rng_uniform(r, -0.3, 0.3);
        eye[i] = centre[i] + dir[i] * dist;
    }
    double upv[3] = {0, 1, 0};
    if (dir[1] * dir[1] > 0.9 * n) upv[1] = 0, upv[2] = 1;
    crisp_mat4 view, proj;
    assert_true(crisp_mat4_lookat(eye, target, upv, view));
    v->width = rng_int(r, 200, 2000);
    v->height = rng_int(r, 200, 2000);
    crisp_mat4_perspective(rng_uniform(r, fov_lo, fov_hi), v->width / v->height, 0.1, 100.0, proj);
    crisp_mat4_mul(proj, view, v->view_proj);
}

#endif
