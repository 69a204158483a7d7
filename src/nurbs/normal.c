/* Unit normals that stay right at singular points (issue 13): cone apexes, sphere poles and other
 * collapsed patch sides, where S_u x S_v vanishes and a plain normalisation gives zero, NaN or a
 * direction made of rounding noise (the "starburst" at a cone's apex).
 *
 * The cross product is trusted when the smaller partial is more than CRISP_NORMAL_TAU = 1e-5 of
 * the larger and the sine of their angle is more than that too (its "quality" q, 0..1). Below
 * that it is a collapsed side (or parallel partials), exact or as a file rounds it: an apex whose
 * control points coincide only to 1e-9..1e-6 of the size (written decimals, a fit) has a regular
 * but meaningless cross product there, made of that noise (up to 160 degrees off before this
 * threshold was raised from 1e-9). Then the normal is taken as its limit from inside the
 * parameter domain, along the direction that leaves the degenerate side: along t where S_s is the
 * small one (the side t = const collapses), along s where S_t is, diagonally for parallel
 * partials; always towards the domain's middle. The limit is estimated from normals at two
 * nearby points (h and 2h away, Richardson extrapolation 2 n(h) - n(2h), exact for a cone, whose
 * normal is constant along a generator, and O(h^2) for a sphere's pole); h grows (1e-6 to 1e-2 of
 * the parameter range, times 10) until both nearby points have 100 times the quality of the
 * point itself, i.e. lie well outside the rounded side's noise (whose error there is about
 * 1/100 rad). Where no h does (a regular point of a parametrisation stretched 1e5 : 1, whose
 * quality is low everywhere near it) the point's own cross product is kept if its quality is
 * above 1e-9 (below, it is rounding: the patch is a curve or a point there, and has no normal).
 * This is the directional limit the shading of a mesh vertex at the singular point needs: around a
 * cone's apex each generator keeps its own normal.
 *
 * The GL backend's evaluation stage does the same in GLSL (shaders/common.glsl, limit_normal),
 * and the renderers' test for "degenerate" (crisp__normal_degenerate, render_internal.h) is the
 * same threshold, so the CPU backend, the exact renderer, the ribbons and the GL backend agree. */
#include "crisp/nurbs.h"

#include "nurbs_internal.h"

#include <immintrin.h>
#include <math.h>
#include <string.h>

typedef void (*derivs_fn)(const void *surf, double a, double b, double *p, double *da, double *db);

static double norm3(const double *a)
{
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}

static void cross3(const double *a, const double *b, double *d)
{
    d[0] = a[1] * b[2] - a[2] * b[1];
    d[1] = a[2] * b[0] - a[0] * b[2];
    d[2] = a[0] * b[1] - a[1] * b[0];
}

/* The cross product n at (a, b), its partials' lengths and its quality: min(smaller partial /
 * larger, sine of their angle), 0 when either partial is 0. */
static double cross_at(derivs_fn f, const void *surf, double a, double b, double n[3], double *la,
                       double *lb)
{
    double p[3], da[3], db[3];
    f(surf, a, b, p, da, db);
    cross3(da, db, n);
    *la = norm3(da), *lb = norm3(db);
    double lo = fmin(*la, *lb), hi = fmax(*la, *lb);
    if (!(lo > 0)) return 0;
    return fmin(lo / hi, norm3(n) / (*la * *lb));
}

/* The unit cross product at (a, b) when its quality exceeds q_min, else 0. */
static int good_cross(derivs_fn f, const void *surf, double a, double b, double q_min, double n[3])
{
    double la, lb;
    if (!(cross_at(f, surf, a, b, n, &la, &lb) > q_min)) return 0;
    double ln = norm3(n);
    for (int k = 0; k < 3; k++)
        n[k] /= ln;
    return 1;
}

/* dom: a0, a1, b0, b1. */
static int robust_normal(derivs_fn f, const void *surf, const double dom[4], double a, double b,
                         double dest[3])
{
    double n0[3], la, lb;
    double q0 = cross_at(f, surf, a, b, n0, &la, &lb), l0 = norm3(n0);
    if (q0 > CRISP_NORMAL_TAU) {
        for (int k = 0; k < 3; k++)
            dest[k] = n0[k] / l0;
        return 1;
    }
    double ra = dom[1] - dom[0], rb = dom[3] - dom[2];
    double sa = a < 0.5 * (dom[0] + dom[1]) ? 1 : -1, sb = b < 0.5 * (dom[2] + dom[3]) ? 1 : -1;
    double dir[2] = {sa, sb};
    if (la < CRISP_NORMAL_TAU * lb)
        dir[0] = 0;
    else if (lb < CRISP_NORMAL_TAU * la)
        dir[1] = 0;
    for (double h = 1e-6; h < 2e-2; h *= 10) {
        double n1[3], n2[3];
        if (!good_cross(f, surf, a + dir[0] * h * ra, b + dir[1] * h * rb, 100 * q0, n1) ||
            !good_cross(f, surf, a + 2 * dir[0] * h * ra, b + 2 * dir[1] * h * rb, 100 * q0, n2))
            continue;
        double n[3];
        for (int k = 0; k < 3; k++)
            n[k] = 2 * n1[k] - n2[k];
        double ln = norm3(n);
        if (!(ln > 0.5)) continue; /* the normal turns fast here: keep the nearer one */
        for (int k = 0; k < 3; k++)
            dest[k] = n[k] / ln;
        return 1;
    }
    /* No point nearby is better: a stretched but regular point keeps its own normal; below 1e-9
     * the cross product is rounding (a patch collapsed to a curve or a point): no normal. */
    if (q0 > 1e-9) {
        for (int k = 0; k < 3; k++)
            dest[k] = n0[k] / l0;
        return 1;
    }
    dest[0] = dest[1] = dest[2] = 0;
    return 0;
}

static void bezier_derivs(const void *surf, double a, double b, double *p, double *da, double *db)
{
    crisp_bezier_patch_derivs(surf, a, b, p, da, db);
}

static void surface_derivs(const void *surf, double a, double b, double *p, double *da, double *db)
{
    crisp_surface_derivs(surf, a, b, p, da, db, NULL, NULL, NULL);
}

int crisp_bezier_patch_normal(const crisp_bezier_patch *p, double s, double t, double dest[3])
{
    const double dom[4] = {0, 1, 0, 1};
    return robust_normal(bezier_derivs, p, dom, s, t, dest);
}

int crisp_surface_normal(const crisp_surface *s, double u, double v, double dest[3])
{
    double dom[4];
    crisp_surface_domain(s, dom);
    return robust_normal(surface_derivs, s, dom, u, v, dest);
}

/* ---- many normals of one surface (nurbs_internal.h, crisp__surface_normals) ----------------- */

crisp_status crisp__surface_normals_init(crisp__surface_normals *c, const crisp_surface *s)
{
    memset(c, 0, sizeof *c);
    c->s = s;
    c->avx = __builtin_cpu_supports("avx");
    for (int dir = 0; dir < 2; dir++) {
        size_t p = (size_t)(dir ? s->degree_v : s->degree_u);
        c->basis[dir] = crisp_malloc_array(CRISP__BASIS_CACHE * 2 * (p + 1), sizeof(double));
        c->key[dir] = crisp_malloc_array(CRISP__BASIS_CACHE, sizeof(uint64_t));
        c->span[dir] = crisp_malloc_array(CRISP__BASIS_CACHE, sizeof(int));
        if (!c->basis[dir] || !c->key[dir] || !c->span[dir]) {
            crisp__surface_normals_free(c);
            return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a surface's normals");
        }
        for (int e = 0; e < CRISP__BASIS_CACHE; e++)
            c->span[dir][e] = -1;
    }
    return CRISP_OK;
}

void crisp__surface_normals_free(crisp__surface_normals *c)
{
    for (int dir = 0; dir < 2; dir++) {
        crisp_free(c->basis[dir]);
        crisp_free(c->key[dir]);
        crisp_free(c->span[dir]);
    }
    memset(c, 0, sizeof *c);
}

/* crisp_surface_derivs' basis in direction dir at t (clamped as it does): the values and first
 * derivatives (2 (degree + 1) values, crisp__basis_ders' layout) and the span in *span. */
static const double *basis_at(crisp__surface_normals *c, int dir, double t, int *span)
{
    const crisp_surface *s = c->s;
    const int p = dir ? s->degree_v : s->degree_u, n = dir ? s->count_v : s->count_u;
    const double *kn = dir ? s->knots_v : s->knots_u;
    t = t < kn[p] ? kn[p] : t > kn[n] ? kn[n] : t;
    uint64_t bits;
    memcpy(&bits, &t, sizeof bits);
    size_t e = (size_t)((bits * 0x9E3779B97F4A7C15ull) >> 58); /* 6 bits: CRISP__BASIS_CACHE */
    double *b = c->basis[dir] + e * 2 * (size_t)(p + 1);
    if (c->span[dir][e] < 0 || c->key[dir][e] != bits) {
        int k = crisp__find_span(kn, p, n, t);
        crisp__basis_ders(kn, p, k, t, 1, b);
        c->span[dir][e] = k;
        c->key[dir][e] = bits;
    }
    *span = c->span[dir][e];
    return b;
}

/* crisp_surface_derivs' homogeneous sums for first derivatives: a[0] = A_00, a[1] = A_01 (d/dv),
 * a[2] = A_10 (d/du), each 4 coordinates; the same operations in the same order. */
static void partials(const crisp_surface *s, int ku, int kv, const double *bu, const double *bv,
                     double a[3][4])
{
    const int pu = s->degree_u, pv = s->degree_v;
    memset(a, 0, 3 * sizeof a[0]);
    for (int l = 0; l <= pv; l++) {
        const double *row = s->cpw + ((size_t)(kv - pv + l) * s->count_u + (size_t)(ku - pu)) * 4;
        double t[2][4];
        for (int k = 0; k <= 1; k++) {
            for (int d = 0; d < 4; d++)
                t[k][d] = 0.0;
            for (int i = 0; i <= pu; i++) {
                double b = bu[k * (pu + 1) + i];
                for (int d = 0; d < 4; d++)
                    t[k][d] += b * row[i * 4 + d];
            }
        }
        for (int d = 0; d < 4; d++) {
            a[0][d] += bv[l] * t[0][d];
            a[1][d] += bv[pv + 1 + l] * t[0][d];
            a[2][d] += bv[l] * t[1][d];
        }
    }
}

/* partials with a control point's four coordinates in one AVX register: the same products and
 * sums in the same order (no fused multiply-add), so the same bits. */
__attribute__((target("avx"))) static void partials_avx(const crisp_surface *s, int ku, int kv,
                                                        const double *bu, const double *bv,
                                                        double a[3][4])
{
    const int pu = s->degree_u, pv = s->degree_v;
    __m256d a00 = _mm256_setzero_pd(), a01 = _mm256_setzero_pd(), a10 = _mm256_setzero_pd();
    for (int l = 0; l <= pv; l++) {
        const double *row = s->cpw + ((size_t)(kv - pv + l) * s->count_u + (size_t)(ku - pu)) * 4;
        __m256d t0 = _mm256_setzero_pd(), t1 = _mm256_setzero_pd();
        for (int i = 0; i <= pu; i++) {
            __m256d r = _mm256_loadu_pd(row + 4 * i);
            t0 = _mm256_add_pd(t0, _mm256_mul_pd(_mm256_set1_pd(bu[i]), r));
            t1 = _mm256_add_pd(t1, _mm256_mul_pd(_mm256_set1_pd(bu[pu + 1 + i]), r));
        }
        __m256d b0 = _mm256_set1_pd(bv[l]), b1 = _mm256_set1_pd(bv[pv + 1 + l]);
        a00 = _mm256_add_pd(a00, _mm256_mul_pd(b0, t0));
        a01 = _mm256_add_pd(a01, _mm256_mul_pd(b1, t0));
        a10 = _mm256_add_pd(a10, _mm256_mul_pd(b0, t1));
    }
    _mm256_storeu_pd(a[0], a00);
    _mm256_storeu_pd(a[1], a01);
    _mm256_storeu_pd(a[2], a10);
}

int crisp__surface_normals_at(crisp__surface_normals *c, double u, double v, double dest[3])
{
    int ku, kv;
    const double *bu = basis_at(c, 0, u, &ku), *bv = basis_at(c, 1, v, &kv);
    double a[3][4];
    if (c->avx)
        partials_avx(c->s, ku, kv, bu, bv, a);
    else
        partials(c->s, ku, kv, bu, bv, a);
    /* crisp_surface_derivs' quotient rule for k + l <= 1 (its binomials are 1) */
    double w = a[0][3], p[3], su[3], sv[3];
    for (int d = 0; d < 3; d++)
        p[d] = a[0][d] / w;
    for (int d = 0; d < 3; d++)
        sv[d] = (a[1][d] - a[1][3] * p[d]) / w;
    for (int d = 0; d < 3; d++)
        su[d] = (a[2][d] - a[2][3] * p[d]) / w;
    /* robust_normal's trusted cross product (cross_at's quality above CRISP_NORMAL_TAU) */
    double n[3];
    cross3(su, sv, n);
    double la = norm3(su), lb = norm3(sv), lo = fmin(la, lb), hi = fmax(la, lb);
    if (lo > 0 && fmin(lo / hi, norm3(n) / (la * lb)) > CRISP_NORMAL_TAU) {
        double ln = norm3(n);
        for (int k = 0; k < 3; k++)
            dest[k] = n[k] / ln;
        return 1;
    }
    return crisp_surface_normal(c->s, u, v, dest);
}
