/* Benchmark of the trim module (Wu & Peters 2015) against two baselines, over a zoom sequence:
 *  - the u-intercept table: crisp_trim_plan_face (density bound, polylines, table) plus the trim
 *    test of every pixel's (u, v);
 *  - a uniform trim texture (Guthe et al. 2005) at the precision of the table: n_V * max mu_i rows
 *    by ceil(max rho_u * (u1 - u0)) columns, one byte per texel, filled by rasterising the trim
 *    polylines with parity (memory compared; built and timed only while it fits in 64 MB);
 *  - a direct per-pixel test on the true curves in the style of Schollmeyer & Froehlich 2009:
 *    curves split once into pieces monotone in u and v, v-intervals holding the pieces that span
 *    them sorted in u, then per pixel a binary search over the v-intervals, a binary search over
 *    the pieces, and bisection on one piece (stopping as soon as its u-range excludes the pixel).
 * Times are on one thread, medians of several runs, measured in the same run for the ratio.
 * The scene: a rational planar biquadratic patch with non-uniform parametrisation, trimmed by an
 * ellipse with three holes (circle, star polygon, ellipse); the camera looks down at a point of
 * the outer boundary from distances shrinking by 10x, so at the closest zoom the boundary crosses
 * the whole image. */
#include "bench_util.h"

#include <math.h>
#include <stdint.h>

#include "../tests/trim/trim_test_util.h"
#include "crisp/trim.h"
#include "trim/trim_internal.h"

#define IMG 512
#define RUNS 11

/* Thread CPU time in seconds: other jobs share the machine, and descheduled time is not ours. */
static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* ---- direct test on the true curves (Schollmeyer & Froehlich 2009 style) -------------------- */

typedef struct mono {
    int degree;
    double cpw[3 * (CRISP_MAX_DEGREE + 1)];
    double umin, umax, vmin, vmax;
    int v_up; /* v increases with t */
} mono;

typedef struct direct {
    mono *m;
    int count, cap;
    double *breaks; /* sorted distinct v of the pieces' ends */
    int nbreaks;
    int *offset, *list; /* per v-interval: pieces spanning it, sorted by u */
} direct;

static void pt(const double *cpw, int d, double t, double *u, double *v)
{
    double U = crisp__trim_eval(cpw, d, 3, t), V = crisp__trim_eval(cpw + 1, d, 3, t);
    double W = crisp__trim_eval(cpw + 2, d, 3, t);
    *u = U / W;
    *v = V / W;
}

static void roots(const double *c, int d, double a, double b, double *out, int *n, int depth)
{
    int pos = 0, neg = 0;
    for (int i = 0; i <= d; i++) {
        pos += c[i] > 0;
        neg += c[i] < 0;
    }
    if (pos == d + 1 || neg == d + 1) return;
    if (depth > 45) {
        if (*n < 64) out[(*n)++] = 0.5 * (a + b);
        return;
    }
    double lo[2 * CRISP_MAX_DEGREE + 2], hi[2 * CRISP_MAX_DEGREE + 2];
    crisp__trim_split(c, d, 1, 0.5, lo, hi);
    roots(lo, d, a, 0.5 * (a + b), out, n, depth + 1);
    roots(hi, d, 0.5 * (a + b), b, out, n, depth + 1);
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void add_mono(direct *D, const crisp_bezier_curve *b, double ta, double tb)
{
    if (D->count == D->cap) {
        D->cap = D->cap ? 2 * D->cap : 64;
        D->m = realloc(D->m, (size_t)D->cap * sizeof *D->m);
    }
    mono *m = &D->m[D->count];
    m->degree = b->degree;
    memcpy(m->cpw, b->cpw, sizeof(double) * 3 * (size_t)(b->degree + 1));
    for (int q = 0; q < 3; q++)
        crisp__trim_restrict(m->cpw + q, b->degree, 3, ta, tb);
    double u0, v0, u1, v1;
    pt(m->cpw, m->degree, 0, &u0, &v0);
    pt(m->cpw, m->degree, 1, &u1, &v1);
    if (v0 == v1) return; /* horizontal: no crossings under the half-open rule */
    m->umin = fmin(u0, u1), m->umax = fmax(u0, u1), m->vmin = fmin(v0, v1), m->vmax = fmax(v0, v1);
    m->v_up = v1 > v0;
    D->count++;
}

/* u of monotone piece m at height v (full bisection; only used while building). */
static double mono_u_at(const mono *m, double v)
{
    double a = 0, b = 1;
    for (int it = 0; it < 60; it++) {
        double t = 0.5 * (a + b), u, vv;
        pt(m->cpw, m->degree, t, &u, &vv);
        if ((vv < v) == (m->v_up != 0))
            a = t;
        else
            b = t;
    }
    double u, vv;
    pt(m->cpw, m->degree, 0.5 * (a + b), &u, &vv);
    return u;
}

static const double *sort_key;
static int cmp_idx(const void *a, const void *b)
{
    double x = sort_key[*(const int *)a], y = sort_key[*(const int *)b];
    return (x > y) - (x < y);
}

static void direct_build(direct *D, const crisp_bezier_curve *pc, int n)
{
    memset(D, 0, sizeof *D);
    for (int k = 0; k < n; k++) {
        const crisp_bezier_curve *b = &pc[k];
        int d = b->degree;
        double ts[130];
        int nt = 0;
        if (d >= 2) {
            /* Numerators of u' and v': U' w - U w' (degree 2d - 2 after cancellation; computed
             * at degree 2d - 1 by a product of Bernstein forms). */
            for (int q = 0; q < 2; q++) {
                double P[16], W[16], dP[16], dW[16], p1[32], p2[32], N[32];
                for (int i = 0; i <= d; i++)
                    P[i] = b->cpw[3 * i + q], W[i] = b->cpw[3 * i + 2];
                for (int i = 0; i < d; i++)
                    dP[i] = d * (P[i + 1] - P[i]), dW[i] = d * (W[i + 1] - W[i]);
                crisp__trim_product2(dP, d - 1, 0, W, d, 0, p1);
                crisp__trim_product2(P, d, 0, dW, d - 1, 0, p2);
                for (int i = 0; i <= 2 * d - 1; i++)
                    N[i] = p1[i] - p2[i];
                int c = 0;
                roots(N, 2 * d - 1, 0, 1, ts + nt, &c, 0);
                nt += c;
            }
        }
        qsort(ts, (size_t)nt, sizeof *ts, cmp_d);
        double prev = 0;
        for (int i = 0; i <= nt; i++) {
            double t = i < nt ? ts[i] : 1.0;
            if (t - prev < 1e-9 && i < nt) continue;
            add_mono(D, b, prev, t);
            prev = t;
        }
    }
    double *br = malloc(sizeof(double) * 2 * (size_t)(D->count > 0 ? D->count : 1));
    int nb = 0;
    for (int i = 0; i < D->count; i++)
        br[nb++] = D->m[i].vmin, br[nb++] = D->m[i].vmax;
    qsort(br, (size_t)nb, sizeof *br, cmp_d);
    int u = 0;
    for (int i = 0; i < nb; i++)
        if (!u || br[i] != br[u - 1]) br[u++] = br[i];
    D->breaks = br;
    D->nbreaks = u;
    D->offset = calloc((size_t)u + 1, sizeof *D->offset);
    int total = 0;
    for (int k = 0; k + 1 < u; k++) {
        D->offset[k] = total;
        for (int i = 0; i < D->count; i++)
            if (D->m[i].vmin <= br[k] && D->m[i].vmax >= br[k + 1]) total++;
    }
    D->offset[u - 1 > 0 ? u - 1 : 0] = total;
    D->list = malloc(sizeof(int) * (size_t)(total > 0 ? total : 1));
    double *key = malloc(sizeof(double) * (size_t)(D->count > 0 ? D->count : 1));
    for (int k = 0; k + 1 < u; k++) {
        int at = D->offset[k];
        double vm = 0.5 * (br[k] + br[k + 1]);
        for (int i = 0; i < D->count; i++)
            if (D->m[i].vmin <= br[k] && D->m[i].vmax >= br[k + 1]) {
                key[i] = mono_u_at(&D->m[i], vm);
                D->list[at++] = i;
            }
        sort_key = key;
        qsort(D->list + D->offset[k], (size_t)(at - D->offset[k]), sizeof(int), cmp_idx);
    }
    free(key);
}

/* 1 when monotone piece m passes left of (u, v) (v inside its v-range). */
static int left_of(const mono *m, double u, double v)
{
    if (u > m->umax) return 1;
    if (u <= m->umin) return 0;
    double a = 0, b = 1;
    for (int it = 0; it < 60; it++) {
        double t = 0.5 * (a + b), pu, pv;
        pt(m->cpw, m->degree, t, &pu, &pv);
        if ((pv < v) == (m->v_up != 0))
            a = t;
        else
            b = t;
        /* the sub-arc [a, b] spans u between its end values: stop once u is outside them */
        double ua, va, ub, vb;
        pt(m->cpw, m->degree, a, &ua, &va);
        pt(m->cpw, m->degree, b, &ub, &vb);
        if (u > fmax(ua, ub)) return 1;
        if (u <= fmin(ua, ub)) return 0;
    }
    double pu, pv;
    pt(m->cpw, m->degree, 0.5 * (a + b), &pu, &pv);
    return pu < u;
}

static int direct_test(const direct *D, double u, double v)
{
    if (D->nbreaks < 2 || !(v > D->breaks[0] && v <= D->breaks[D->nbreaks - 1])) return 0;
    int lo = 0, hi = D->nbreaks - 1; /* interval k: (breaks[k], breaks[k + 1]] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (D->breaks[mid] < v)
            lo = mid;
        else
            hi = mid;
    }
    const int *l = D->list + D->offset[lo];
    int n = D->offset[lo + 1] - D->offset[lo];
    int a = 0, b = n; /* number of pieces left of the point */
    while (a < b) {
        int mid = (a + b) / 2;
        if (left_of(&D->m[l[mid]], u, v))
            a = mid + 1;
        else
            b = mid;
    }
    return a & 1;
}

static void direct_free(direct *D)
{
    free(D->m);
    free(D->breaks);
    free(D->offset);
    free(D->list);
}

/* ---- the uniform trim texture (Guthe et al. 2005) ------------------------------------------- */

typedef struct texture {
    int rows, cols;
    unsigned char *texel;       /* rows * cols, 1 = inside */
    crisp_trim_table crossings; /* one strip of `rows` scan lines: the rasteriser's crossings */
} texture;

/* Rasterise the polylines with parity: per texel row the crossings at its centre line, then the
 * texels whose centres lie between odd and even crossings are set. */
static int texture_build(texture *tx, const crisp_trim_polyline *pl, int rows, int cols)
{
    uint32_t mu = (uint32_t)rows;
    if (crisp_trim_table_build(
            &(crisp_trim_table_desc){.polyline = pl, .v0 = 0, .v1 = 1, .strip_count = 1, .mu = &mu},
            &tx->crossings))
        return 0;
    tx->rows = rows;
    tx->cols = cols;
    memset(tx->texel, 0, (size_t)rows * (size_t)cols);
    const crisp_trim_table *t = &tx->crossings;
    for (int r = 0; r < rows; r++) {
        unsigned char *row = tx->texel + (size_t)r * cols;
        for (uint32_t k = t->row_offset[r]; k + 1 < t->row_offset[r + 1]; k += 2) {
            /* texel c is inside when u_k < (c + 0.5) / cols <= u_{k+1} */
            long c0 = (long)ceil(t->u[k] * cols - 0.5), c1 = (long)ceil(t->u[k + 1] * cols - 0.5);
            if (t->u[k] * cols - 0.5 == (double)c0) c0++;
            if (c0 < 0) c0 = 0;
            if (c1 > cols) c1 = cols;
            for (long c = c0; c < c1; c++)
                row[c] = 1;
        }
    }
    return 1;
}

static int texture_test(const texture *tx, double u, double v)
{
    if (!(u >= 0 && u < 1 && v >= 0 && v <= 1)) return 0;
    int r = (int)(v * tx->rows), c = (int)(u * tx->cols);
    if (r > tx->rows - 1) r = tx->rows - 1;
    return tx->texel[(size_t)r * tx->cols + c];
}

/* ---- the scene ------------------------------------------------------------------------------ */

static int make_trim(crisp_bezier_curve *pc)
{
    int n = tu_ellipse(pc, 0.5, 0.5, 0.45, 0.38, 0.2, 1);
    n += tu_ellipse(pc + n, 0.33, 0.6, 0.1, 0.1, 0.0, 0);
    double star[20];
    for (int i = 0; i < 10; i++) {
        double a = -2 * M_PI * i / 10, r = i % 2 ? 0.05 : 0.12; /* clockwise */
        star[2 * i] = 0.65 + r * cos(a);
        star[2 * i + 1] = 0.4 + r * sin(a);
    }
    n += tu_polygon(pc + n, 10, star);
    n += tu_ellipse(pc + n, 0.6, 0.72, 0.08, 0.035, 0.4, 0);
    return n;
}

/* The planar patch's map is separable: x depends on u only, y on v only (weights wu_i wv_j). */
static double axis_map(const double *xs, const double *w, double t)
{
    double num = 0, den = 0;
    for (int i = 0; i < 3; i++) {
        double b = tu_bern(2, i, t);
        num += b * w[i] * xs[i];
        den += b * w[i];
    }
    return num / den;
}
static double axis_inverse(const double *xs, const double *w, double x)
{
    double a = 0, b = 1;
    for (int it = 0; it < 60; it++) {
        double m = 0.5 * (a + b);
        if (axis_map(xs, w, m) < x)
            a = m;
        else
            b = m;
    }
    return 0.5 * (a + b);
}

int main(void)
{
    static const double xs[3] = {0.0, 0.3, 2.0}, ys[3] = {0.0, 1.5, 2.0};
    static const double wu[3] = {1.0, 2.0, 1.0}, wv[3] = {1.0, 0.6, 1.0};
    double cpw[64];
    crisp_bezier_patch patch;
    tu_patch_kind(&patch, 0, cpw); /* the same planar rational patch */
    crisp_bezier_curve pc[40];
    int npieces = make_trim(pc);
    direct D;
    direct_build(&D, pc, npieces);

    bench_print_machine(stdout);
    printf(
        "trim: %d trim pieces (%d monotone), planar rational biquadratic patch, %dx%d image, "
        "one thread, median of %d runs; other jobs share the machine, so "
        "absolute times (thread CPU time) are noisy and the ratios (same run) are what to read\n\n",
        npieces, D.count, IMG, IMG, RUNS);
    static const int strip_counts[2] = {16, 64};
    for (int sc = 0; sc < 2; sc++) {
        const int STRIPS = strip_counts[sc];
        printf("\nn_V = %d strips\n\n", STRIPS);
        printf("| distance | px on face | rows | crossings | table bytes | texture (rows x cols) | "
               "texture build + lookups ms | "
               "texture bytes | table/texture | plan ms | lookups ms | direct ms | "
               "direct/(plan+lookups) "
               "| table vs direct disagree |\n");
        printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");

        double uvb[2];
        crisp_bezier_curve_eval(&pc[0], 0.6, uvb); /* a point of the outer boundary */
        double P[3] = {axis_map(xs, wu, uvb[0]), axis_map(ys, wv, uvb[1]), 0.0};
        double *uv = malloc(sizeof(double) * 2 * IMG * IMG);
        crisp_trim_plan plan = {0};
        for (double dist = 3.0; dist >= 0.9e-4; dist *= 0.1) {
            double dir[3] = {0.25, -0.35, 1.0}, nd = sqrt(0.25 * 0.25 + 0.35 * 0.35 + 1.0);
            double eye[3], target[3] = {P[0], P[1], P[2]};
            for (int k = 0; k < 3; k++)
                eye[k] = P[k] + dist * dir[k] / nd;
            crisp_mat4 vp, inv;
            tu_camera(eye, target, 35.0, 0.1 * dist, 100.0, IMG, IMG, vp);
            crisp_mat4_inverse(vp, inv);
            /* The (u, v) every pixel centre sees: ray / plane z = 0, then the separable inverse. */
            int npx = 0;
            for (int j = 0; j < IMG; j++)
                for (int i = 0; i < IMG; i++) {
                    double nx = 2.0 * (i + 0.5) / IMG - 1.0, ny = 1.0 - 2.0 * (j + 0.5) / IMG;
                    double a[4], b[4], ca[4] = {nx, ny, -1, 1}, cb[4] = {nx, ny, 1, 1};
                    crisp_mat4_mulv(inv, ca, a);
                    crisp_mat4_mulv(inv, cb, b);
                    for (int k = 0; k < 3; k++)
                        a[k] /= a[3], b[k] /= b[3];
                    if (a[2] == b[2]) continue;
                    double s = a[2] / (a[2] - b[2]);
                    if (s < 0 || s > 1) continue;
                    double x = a[0] + s * (b[0] - a[0]), y = a[1] + s * (b[1] - a[1]);
                    if (x < 0 || x > 2 || y < 0 || y > 2) continue;
                    uv[2 * npx] = axis_inverse(xs, wu, x);
                    uv[2 * npx + 1] = axis_inverse(ys, wv, y);
                    npx++;
                }
            crisp_trim_plan_desc pd = {.patches = &patch,
                                       .patch_count = 1,
                                       .pieces = pc,
                                       .piece_count = npieces,
                                       .view_proj = &vp,
                                       .width = IMG,
                                       .height = IMG,
                                       .v0 = 0,
                                       .v1 = 1,
                                       .strip_count = STRIPS};
            double t_plan[RUNS], t_look[RUNS], t_dir[RUNS];
            volatile long sink = 0;
            long disagree = 0;
            for (int r = 0; r < RUNS; r++) {
                double t0 = cpu_now();
                if (crisp_trim_plan_face(&pd, &plan)) {
                    fprintf(stderr, "plan failed: %s\n", crisp_error_message());
                    return 1;
                }
                double t1 = cpu_now();
                long in = 0;
                for (int p = 0; p < npx; p++)
                    in += crisp_trim_table_test(&plan.table, uv[2 * p], uv[2 * p + 1]);
                double t2 = cpu_now();
                long in2 = 0;
                for (int p = 0; p < npx; p++)
                    in2 += direct_test(&D, uv[2 * p], uv[2 * p + 1]);
                double t3 = cpu_now();
                sink += in + in2;
                t_plan[r] = 1e3 * (t1 - t0), t_look[r] = 1e3 * (t2 - t1),
                t_dir[r] = 1e3 * (t3 - t2);
            }
            for (int p = 0; p < npx; p++)
                disagree += crisp_trim_table_test(&plan.table, uv[2 * p], uv[2 * p + 1]) !=
                            direct_test(&D, uv[2 * p], uv[2 * p + 1]);
            double mp = bench_median(t_plan, RUNS), ml = bench_median(t_look, RUNS),
                   md = bench_median(t_dir, RUNS);
            /* The texture is uniform over the face: its rows as fine as the finest row of the
             * table, its columns one per pixel of u-extent at the largest u-density. */
            double hmin = HUGE_VAL, maxru = 0;
            for (int i = 0; i < STRIPS; i++) {
                if (!plan.mu[i]) continue;
                hmin = fmin(hmin, (plan.vis_v[2 * i + 1] - plan.vis_v[2 * i]) / plan.mu[i]);
                maxru = fmax(maxru, plan.rho_u[i]);
            }
            double trows = ceil(1.0 / hmin), tcols = ceil(maxru * 1.0);
            double tbytes = trows * tcols; /* one byte per texel */
            size_t bytes = crisp_trim_table_bytes(&plan.table);
            /* Build and use the texture while it fits in 64 MB (the same polylines as the table).
             */
            char tex_ms[64] = "not built (> 64 MB)";
            if (tbytes <= 64.0 * 1024 * 1024) {
                texture tx = {0};
                tx.texel = malloc((size_t)tbytes);
                double tt[RUNS];
                long agree = 0;
                for (int r = 0; r < RUNS && tx.texel; r++) {
                    double t0 = cpu_now();
                    texture_build(&tx, &plan.polyline, (int)trows, (int)tcols);
                    long in = 0;
                    for (int p = 0; p < npx; p++)
                        in += texture_test(&tx, uv[2 * p], uv[2 * p + 1]);
                    tt[r] = 1e3 * (cpu_now() - t0);
                    sink += in;
                }
                for (int p = 0; tx.texel && p < npx; p++)
                    agree += texture_test(&tx, uv[2 * p], uv[2 * p + 1]) ==
                             crisp_trim_table_test(&plan.table, uv[2 * p], uv[2 * p + 1]);
                if (tx.texel)
                    snprintf(tex_ms, sizeof tex_ms, "%.2f (%.2f%% px as table)",
                             bench_median(tt, RUNS), 100.0 * agree / npx);
                free(tx.texel);
                crisp_trim_table_free(&tx.crossings);
            }
            printf("| %.4g | %d | %u | %u | %zu | %.0f x %.0f | %s | %.3g | %.4f%% | %.3f | %.3f | "
                   "%.2f | "
                   "%.1fx | %ld |\n",
                   dist, npx, plan.table.row_count, plan.table.row_offset[plan.table.row_count],
                   bytes, trows, tcols, tex_ms, tbytes, 100.0 * bytes / tbytes, mp, ml, md,
                   md / (mp + ml), disagree);
            (void)sink;
        }
        crisp_trim_plan_free(&plan);
        free(uv);
    }
    direct_free(&D);
    return 0;
}
