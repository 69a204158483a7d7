/* SLEFE benchmark: enclosures per second for bicubic patches (m = 3, x y z), degree (5, 6)
 * patches, cubic curve pieces and rational bicubic patches through a perspective camera (NDC tile
 * boxes + w_px), on one thread and on all threads (crisp_pool_parallel_for). The baseline,
 * measured in the same run, is evaluating the same patches at the (m + 1)^2 grid points by
 * de Casteljau (what a tessellator does anyway). Medians over repeated runs.
 *
 * usage: bench_slefe [--quick]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "crisp/core.h"
#include "crisp/slefe.h"

#define COUNT 4096 /* inputs per workload (they fit in L2 for bicubics) */
#define M 3

typedef struct {
    int kind;
    int du, dv;
    double *cpw;                 /* COUNT patches or curves */
    crisp_bezier_patch *patches; /* COUNT */
    crisp_bezier_curve *curves;  /* COUNT */
    crisp_slefe_view view;
    double *out; /* per worker scratch */
    size_t out_stride;
    volatile double sink[64];
} workload;

enum { K_PATCH, K_SCREEN, K_CURVE, K_EVAL, K_LEVEL };

static uint64_t rng_state = 12345;
static double uniform(double a, double b)
{
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return a + (b - a) * (double)(z >> 11) * 0x1.0p-53;
}

/* Baseline: de Casteljau evaluation of all four homogeneous coordinates at the grid points. */
static double eval_grid(const crisp_bezier_patch *p, int m, double *dest)
{
    int du = p->du, dv = p->dv;
    double acc = 0;
    for (int kv = 0; kv <= m; kv++) {
        double t = (double)kv / m, col[16][4];
        for (int i = 0; i <= du; i++) {
            double b[16][4];
            for (int j = 0; j <= dv; j++)
                for (int c = 0; c < 4; c++)
                    b[j][c] = p->cpw[(j * (du + 1) + i) * 4 + c];
            for (int r = 1; r <= dv; r++)
                for (int j = 0; j <= dv - r; j++)
                    for (int c = 0; c < 4; c++)
                        b[j][c] = (1 - t) * b[j][c] + t * b[j + 1][c];
            for (int c = 0; c < 4; c++)
                col[i][c] = b[0][c];
        }
        for (int ku = 0; ku <= m; ku++) {
            double s = (double)ku / m, b[16][4];
            memcpy(b, col, sizeof b);
            for (int r = 1; r <= du; r++)
                for (int i = 0; i <= du - r; i++)
                    for (int c = 0; c < 4; c++)
                        b[i][c] = (1 - s) * b[i][c] + s * b[i + 1][c];
            for (int c = 0; c < 4; c++)
                dest[(kv * (m + 1) + ku) * 4 + c] = b[0][c];
            acc += b[0][0];
        }
    }
    return acc;
}

static void run(void *ctx, size_t begin, size_t end, int worker)
{
    workload *w = ctx;
    double *lo = w->out + (size_t)worker * w->out_stride, *up = lo + w->out_stride / 2;
    double acc = 0;
    for (size_t i = begin; i < end; i++) {
        switch (w->kind) {
        case K_PATCH:
            crisp_slefe_patch(&w->patches[i], M, lo, up);
            acc += lo[5] + up[7];
            break;
        case K_SCREEN: {
            double w_px = 0;
            crisp_slefe_patch_screen(&w->patches[i], M, &w->view, lo, up, &w_px);
            acc += w_px;
            break;
        }
        case K_LEVEL: {
            int tau = 0;
            crisp_slefe_patch_tess_level(&w->patches[i], &w->view, 0.5, 64, &tau);
            acc += tau;
            break;
        }
        case K_CURVE:
            crisp_slefe_curve(&w->curves[i], M, lo, up);
            acc += lo[4] + up[6];
            break;
        case K_EVAL:
            acc += eval_grid(&w->patches[i], M, lo);
            break;
        }
    }
    w->sink[worker & 63] += acc;
}

static void make_patches(workload *w, int du, int dv, int rational, double scale)
{
    int n = (du + 1) * (dv + 1) * 4;
    for (int k = 0; k < COUNT; k++) {
        double *cpw = w->cpw + (size_t)k * n;
        for (int i = 0; i < (du + 1) * (dv + 1); i++) {
            double wt = rational ? uniform(0.5, 2.0) : 1.0;
            for (int c = 0; c < 3; c++)
                cpw[i * 4 + c] = wt * scale * uniform(-1, 1);
            cpw[i * 4 + 3] = wt;
        }
        w->patches[k] = (crisp_bezier_patch){
            .du = du, .dv = dv, .rational = rational, .u1 = 1, .v1 = 1, .cpw = cpw};
    }
}

/* CPU time of the calling thread: on a machine shared with other jobs it leaves out the time the
 * thread spent waiting for a core, which wall time cannot. */
static double thread_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* Median seconds per item over reps runs of the whole workload: thread CPU time for one thread
 * (pool == NULL), wall time otherwise. */
static double time_per_item(workload *w, crisp_pool *pool, int reps)
{
    double t[64];
    for (int r = 0; r < reps; r++) {
        double t0 = pool ? crisp_time_now() : thread_seconds();
        crisp_pool_parallel_for(pool, COUNT, 64, run, w);
        t[r] = ((pool ? crisp_time_now() : thread_seconds()) - t0) / COUNT;
    }
    return bench_median(t, reps);
}

/* Homogeneous point of a patch at (s, t) by de Casteljau. */
static void eval_point(const crisp_bezier_patch *p, double s, double t, double *dest)
{
    double col[16][4];
    for (int i = 0; i <= p->du; i++) {
        double b[16][4];
        for (int j = 0; j <= p->dv; j++)
            for (int c = 0; c < 4; c++)
                b[j][c] = p->cpw[(j * (p->du + 1) + i) * 4 + c];
        for (int r = 1; r <= p->dv; r++)
            for (int j = 0; j <= p->dv - r; j++)
                for (int c = 0; c < 4; c++)
                    b[j][c] = (1 - t) * b[j][c] + t * b[j + 1][c];
        memcpy(col[i], b[0], sizeof col[i]);
    }
    for (int r = 1; r <= p->du; r++)
        for (int i = 0; i <= p->du - r; i++)
            for (int c = 0; c < 4; c++)
                col[i][c] = (1 - s) * col[i][c] + s * col[i + 1][c];
    memcpy(dest, col[0], 4 * sizeof *dest);
}

/* Clip-space X, Y, W of the patch point at (s, t). */
static void clip_at(const crisp_bezier_patch *p, const crisp_slefe_view *v, double s, double t,
                    double *dest)
{
    double h[4];
    eval_point(p, s, t, h);
    for (int r = 0; r < 3; r++) {
        int k = r == 2 ? 3 : r;
        dest[r] = v->view_proj[0][k] * h[0] + v->view_proj[1][k] * h[1] +
                  v->view_proj[2][k] * h[2] + v->view_proj[3][k] * h[3];
    }
}

static void to_pixel(const crisp_slefe_view *v, const double *q, double *dest)
{
    dest[0] = (q[0] / q[2] + 1) * 0.5 * v->width;
    dest[1] = (q[1] / q[2] + 1) * 0.5 * v->height;
}

/* How well tau = ceil(m sqrt(w_px / eps)) holds up: random patches seen from random distances,
 * tessellated uniformly at tau into two triangles per cell. For a sample (s, t) inside a
 * triangle, the triangle point with the same barycentrics *in clip space* (what a rasterizer
 * interpolates; it projects onto the screen triangle) is compared with the surface point: their
 * pixel distance per axis bounds the distance from the surface point to the drawn triangle. */
static void tau_check(int du, int dv, int rational, int trials, int bilinear, int sound,
                      const char *name)
{
    double tau_sum = 0;
    const double eps = 0.5;
    double worst = 0, sum = 0;
    int over = 0, split = 0, used = 0;
    static double cpw[16 * 16 * 4];
    static double grid[129 * 129][3];
    for (int k = 0; k < trials; k++) {
        crisp_bezier_patch p = {
            .du = du, .dv = dv, .rational = rational, .u1 = 1, .v1 = 1, .cpw = cpw};
        double scale = uniform(0.2, 1.0);
        for (int i = 0; i < (du + 1) * (dv + 1); i++) {
            double wt = rational ? uniform(0.5, 2.0) : 1.0;
            for (int c = 0; c < 3; c++)
                cpw[i * 4 + c] = wt * scale * uniform(-1, 1);
            cpw[i * 4 + 3] = wt;
        }
        crisp_slefe_view v = {.width = 1920, .height = 1080};
        double dist = uniform(2.5, 30.0), a = uniform(0, 6.283), b = uniform(-1.2, 1.2);
        double eye[3] = {dist * cos(b) * cos(a), dist * sin(b), dist * cos(b) * sin(a)};
        double target[3] = {0, 0, 0}, upv[3] = {0, 1, 0};
        crisp_mat4 view, proj;
        crisp_mat4_lookat(eye, target, upv, view);
        crisp_mat4_perspective(45, 16.0 / 9.0, 0.1, 100, proj);
        crisp_mat4_mul(proj, view, v.view_proj);
        double w_px;
        if (crisp_slefe_patch_screen(&p, M, &v, NULL, NULL, &w_px)) continue;
        int tau = crisp_slefe_tess_level(w_px, M, eps);
        if (sound && crisp_slefe_patch_tess_level(&p, &v, eps, 64, &tau)) continue;
        if (tau > 64) {
            split++;
            continue;
        }
        used++;
        tau_sum += tau;
        for (int j = 0; j <= tau; j++)
            for (int i = 0; i <= tau; i++)
                clip_at(&p, &v, (double)i / tau, (double)j / tau, grid[j * (tau + 1) + i]);
        double err = 0;
        static const double bary[4][2] = {{1 / 3.0, 1 / 3.0}, {0.5, 0.25}, {0.25, 0.5}, {0.5, 0.0}};
        for (int j = 0; j < tau; j++)
            for (int i = 0; i < tau; i++)
                for (int tri = 0; tri < 2; tri++)
                    for (int q = 0; q < 4; q++) {
                        /* triangle (00, 10, 11) or (00, 11, 01); (a, b) weights of its 2nd, 3rd */
                        double wa = bary[q][0], wb = bary[q][1], s, t;
                        const double *p0 = grid[j * (tau + 1) + i];
                        const double *p1 =
                            tri ? grid[(j + 1) * (tau + 1) + i + 1] : grid[j * (tau + 1) + i + 1];
                        const double *p2 =
                            tri ? grid[(j + 1) * (tau + 1) + i] : grid[(j + 1) * (tau + 1) + i + 1];
                        if (!tri) {
                            s = (i + wa + wb) / tau;
                            t = (j + wb) / tau;
                        } else {
                            s = (i + wa) / tau;
                            t = (j + wa + wb) / tau;
                        }
                        double h[3], xy[2], hq[3], tq[2], e = 0;
                        clip_at(&p, &v, s, t, h);
                        to_pixel(&v, h, xy);
                        for (int c = 0; c < 3; c++) {
                            hq[c] = (1 - wa - wb) * p0[c] + wa * p1[c] + wb * p2[c];
                            if (bilinear) {
                                double fu = s * tau - i, fv = t * tau - j;
                                const double *g00 = grid[j * (tau + 1) + i];
                                const double *g10 = grid[j * (tau + 1) + i + 1];
                                const double *g01 = grid[(j + 1) * (tau + 1) + i];
                                const double *g11 = grid[(j + 1) * (tau + 1) + i + 1];
                                hq[c] = (1 - fv) * ((1 - fu) * g00[c] + fu * g10[c]) +
                                        fv * ((1 - fu) * g01[c] + fu * g11[c]);
                            }
                        }
                        to_pixel(&v, hq, tq);
                        for (int c = 0; c < 2; c++)
                            e = fmax(e, fabs(xy[c] - tq[c]));
                        err = fmax(err, e);
                    }
        worst = fmax(worst, err / eps);
        sum += err / eps;
        over += err > eps;
    }
    printf("%-34s %8d %8d %8.1f %10.3f %10.3f %9d\n", name, used, split, used ? tau_sum / used : 0,
           used ? sum / used : 0, worst, over);
}

int main(int argc, char **argv)
{
    int quick = argc > 1 && !strcmp(argv[1], "--quick");
    int reps = quick ? 9 : 31;
    crisp_slefe_table t;
    if (crisp_slefe_table_get(3, 3, &t)) return 1; /* build the tables outside the timings */

    crisp_pool *pool = NULL;
    if (crisp_pool_create(0, &pool)) {
        fprintf(stderr, "bench_slefe: %s\n", crisp_error_message());
        return 1;
    }
    int threads = crisp_pool_threads(pool);
    workload w = {0};
    w.cpw = malloc(sizeof(double) * COUNT * 16 * 16 * 4);
    w.patches = malloc(sizeof *w.patches * COUNT);
    w.curves = malloc(sizeof *w.curves * COUNT);
    w.out_stride = 2 * CRISP_SLEFE_GRID(CRISP_SLEFE_MAX_SEGMENTS) * 4;
    w.out = malloc(sizeof(double) * w.out_stride * (size_t)(threads + 1));
    if (!w.cpw || !w.patches || !w.curves || !w.out) return 1;

    crisp_mat4 view, proj;
    double eye[3] = {4, 3, 5}, target[3] = {0, 0, 0}, upv[3] = {0, 1, 0};
    crisp_mat4_lookat(eye, target, upv, view);
    crisp_mat4_perspective(45, 16.0 / 9.0, 0.1, 100, proj);
    crisp_mat4_mul(proj, view, w.view.view_proj);
    w.view.width = 1920;
    w.view.height = 1080;

    for (int k = 0; k < COUNT; k++) {
        crisp_bezier_curve *c = &w.curves[k];
        memset(c, 0, sizeof *c);
        c->dim = 3;
        c->degree = 3;
        c->t1 = 1;
        for (int i = 0; i < 4; i++) {
            for (int j = 0; j < 3; j++)
                c->cpw[i * 4 + j] = uniform(-1, 1);
            c->cpw[i * 4 + 3] = 1;
        }
    }

    printf(
        "SLEFE enclosures (m = %d segments per direction), %d inputs per run, median of %d runs\n",
        M, COUNT, reps);
    bench_print_machine(stdout);
    printf("threads: 1 and %d (crisp_pool_parallel_for)\n\n", threads);
    printf("%-40s %14s %14s %9s %14s\n", "workload", "1 thread /s", "ns each", "vs eval",
           "all threads /s");

    struct {
        const char *name;
        int kind, du, dv, rational;
    } rows[] = {
        {"bicubic patch, x y z", K_PATCH, 3, 3, 0},
        {"rational bicubic patch, x y z w", K_PATCH, 3, 3, 1},
        {"rational bicubic, camera: NDC + w_px", K_SCREEN, 3, 3, 1},
        {"rational bicubic, sound tess level *", K_LEVEL, 3, 3, 1},
        {"degree (5,6) patch, x y z", K_PATCH, 5, 6, 0},
        {"cubic curve piece, x y z", K_CURVE, 3, 3, 0},
    };
    for (size_t r = 0; r < sizeof rows / sizeof rows[0]; r++) {
        w.kind = rows[r].kind;
        if (w.kind != K_CURVE)
            make_patches(&w, rows[r].du, rows[r].dv, rows[r].rational,
                         w.kind == K_LEVEL ? 0.1 : 1.0);
        double one = time_per_item(&w, NULL, reps);
        double all = time_per_item(&w, pool, reps);
        char ratio[32] = "";
        if (w.kind != K_CURVE) {
            /* the baseline on the same inputs, right after */
            w.kind = K_EVAL;
            snprintf(ratio, sizeof ratio, "%.2f", one / time_per_item(&w, NULL, reps));
        }
        printf("%-40s %14.0f %14.1f %9s %14.0f\n", rows[r].name, 1.0 / one, one * 1e9, ratio,
               1.0 / all);
    }
    printf("\n* patches scaled to [-0.1, 0.1]^3 (about 50-100 px on screen), eps = 0.5 px, max "
           "level 64.\n");
    printf("1 thread: median thread CPU time per item (robust to other jobs on the machine).\n"
           "all threads: items / wall time (drops when other jobs hold the cores).\n"
           "'vs eval': SLEFE time / time to evaluate the same patch at its (m+1)^2 grid points.\n");

    printf(
        "\ntau check: tau = ceil(%d sqrt(w_px / 0.5)) from crisp_slefe_patch_screen, uniform\n"
        "tessellation, max over samples of the per-axis pixel distance between the surface and\n"
        "its triangles at equal parameters, in units of eps = 0.5 px (1920x1080, fov 45,\n"
        "camera 2.5..30 away). Patches needing tau > 64 (to be split) are counted, not checked.\n",
        M);
    printf("%-34s %8s %8s %8s %10s %10s %9s\n", "patches", "checked", "split", "mean tau",
           "mean err", "worst err", "over eps");
    int trials = quick ? 60 : 120;
    const char *modes[3] = {"iPASS rule tau = ceil(3 sqrt(w_px/eps)), against the triangles:",
                            "iPASS rule, against the bilinear interpolant (what the SLEFE bounds):",
                            "crisp_slefe_patch_tess_level (sound bound), against the triangles:"};
    for (int mode = 0; mode < 3; mode++) {
        printf("%s\n", modes[mode]);
        int bl = mode == 1, sound = mode == 2;
        rng_state = 99;
        tau_check(3, 3, 0, trials, bl, sound, "  bicubic");
        tau_check(3, 3, 1, trials, bl, sound, "  rational bicubic");
        tau_check(5, 6, 0, trials, bl, sound, "  degree (5,6)");
        tau_check(5, 6, 1, trials, bl, sound, "  rational degree (5,6)");
    }
    crisp_pool_destroy(pool);
    free(w.cpw);
    free(w.patches);
    free(w.curves);
    free(w.out);
    return 0;
}
