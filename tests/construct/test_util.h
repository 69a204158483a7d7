/* Shared helpers for the construct/fit/project tests: a deterministic random source and random
 * B-spline curves. */
#ifndef CRISP_TEST_CONSTRUCT_UTIL_H
#define CRISP_TEST_CONSTRUCT_UTIL_H

#include <math.h>
#include <stdint.h>

#include "crisp/nurbs.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static uint64_t test_rng_state = 0x9E3779B97F4A7C15ull;

/* Uniform in [lo, hi) (xorshift64*, fixed seed: runs are reproducible). */
static inline double rnd(double lo, double hi)
{
    test_rng_state ^= test_rng_state >> 12;
    test_rng_state ^= test_rng_state << 25;
    test_rng_state ^= test_rng_state >> 27;
    uint64_t x = test_rng_state * 2685821657736338717ull;
    return lo + (hi - lo) * (double)(x >> 11) * (1.0 / 9007199254740992.0);
}

/* A clamped random curve over a random domain with non-uniform interior knots (some repeated). */
static inline crisp_curve *random_curve(int dim, int degree, int count, int rational)
{
    double knots[64], pts[3 * 48], w[48];
    double t0 = rnd(-2, 1), t1 = t0 + rnd(0.5, 3);
    for (int i = 0; i <= degree; i++) {
        knots[i] = t0;
        knots[count + i] = t1;
    }
    double x = t0;
    for (int i = degree + 1; i < count; i++) {
        if (i > degree + 1 && degree >= 2 && knots[i - 1] != knots[i - 2] && rnd(0, 1) < 0.2) {
            knots[i] = x; /* a repeated knot */
            continue;
        }
        x += (t1 - x) * rnd(0.1, 0.5);
        knots[i] = x;
    }
    for (int i = 0; i < count; i++) {
        for (int k = 0; k < dim; k++)
            pts[dim * i + k] = rnd(-2, 2);
        w[i] = rational ? rnd(0.3, 3) : 1;
    }
    crisp_curve *c = NULL;
    crisp_curve_create(dim, degree, count, knots, pts, rational ? w : NULL, &c);
    return c;
}

#endif
