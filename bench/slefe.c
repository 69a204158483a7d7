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

enum { K_PATCH, K_SCREEN, K_CURVE, K_EVAL };

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

static void make_patches(workload *w, int du, int dv, int rational)
{
    int n = (du + 1) * (dv + 1) * 4;
    for (int k = 0; k < COUNT; k++) {
        double *cpw = w->cpw + (size_t)k * n;
        for (int i = 0; i < (du + 1) * (dv + 1); i++) {
            double wt = rational ? uniform(0.5, 2.0) : 1.0;
            for (int c = 0; c < 3; c++)
                cpw[i * 4 + c] = wt * uniform(-1, 1);
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
        {"degree (5,6) patch, x y z", K_PATCH, 5, 6, 0},
        {"cubic curve piece, x y z", K_CURVE, 3, 3, 0},
    };
    for (size_t r = 0; r < sizeof rows / sizeof rows[0]; r++) {
        w.kind = rows[r].kind;
        if (w.kind != K_CURVE) make_patches(&w, rows[r].du, rows[r].dv, rows[r].rational);
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
    printf("\n1 thread: median thread CPU time per item (robust to other jobs on the machine).\n"
           "all threads: items / wall time (drops when other jobs hold the cores).\n"
           "'vs eval': SLEFE time / time to evaluate the same patch at its (m+1)^2 grid points.\n");
    crisp_pool_destroy(pool);
    free(w.cpw);
    free(w.patches);
    free(w.curves);
    free(w.out);
    return 0;
}
