/* bench_frep: the f-rep renderer on the bundled models (data/frep): prospero at 1024^2 and 4096^2
 * in 2D, bear as a 512^3 heightmap, with 1 and 2 threads; then each optimisation switched off in
 * turn (tape shortening, batched leaves, interval subdivision altogether, threads), as in
 * Keeter's 2012 solver slides. Medians of repeated renders; the set-up (parse, DAG, tape,
 * renderer) is timed separately. Also prints the process CPU time per render, which the load of
 * other processes on a shared machine disturbs less than the wall clock.
 *   bench_frep [--quick]   (--quick: fewer runs, no 4096^2) */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench_util.h"
#include "crisp/frep.h"

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

typedef struct result {
    double render_ms, render_min_ms, cpu_ms, setup_ms;
    size_t inside;
} result;

static int run(const char *model, int size, int depth, int threads, unsigned flags, int runs,
               result *res)
{
    char path[512];
    snprintf(path, sizeof path, "%s/frep/%s.vm", CRISP_DATA_DIR, model);
    double setup[64], wall[64], cpu[64];
    if (runs > 64) runs = 64;
    crisp_frep *f = NULL;
    crisp_frep_tape *t = NULL;
    crisp_frep_renderer *r = NULL;
    crisp_frep_render_desc d = {
        .width = size, .height = size, .depth = depth, .threads = threads, .flags = flags};
    for (int n = 0; n < 5; n++) {
        crisp_frep_renderer_destroy(r);
        crisp_frep_tape_destroy(t);
        crisp_frep_destroy(f);
        double t0 = crisp_time_now();
        if (crisp_frep_read_vm(path, &f) || crisp_frep_tape_create(f, &t) ||
            crisp_frep_renderer_create(t, &d, &r)) {
            fprintf(stderr, "bench_frep: %s\n", crisp_error_message());
            return 1;
        }
        setup[n] = crisp_time_now() - t0;
    }
    crisp_frep_renderer_run(r); /* warm-up */
    for (int n = 0; n < runs; n++) {
        double c0 = cpu_now(), t0 = crisp_time_now();
        crisp_frep_renderer_run(r);
        wall[n] = crisp_time_now() - t0;
        cpu[n] = cpu_now() - c0;
    }
    const crisp_frep_image *img = crisp_frep_renderer_image(r);
    res->inside = 0;
    for (size_t p = 0; p < (size_t)size * size; p++)
        res->inside += img->inside[p] != 0;
    res->setup_ms = 1000 * bench_median(setup, 5);
    res->render_ms = 1000 * bench_median(wall, runs);
    res->render_min_ms = 1000 * wall[0];
    res->cpu_ms = 1000 * bench_median(cpu, runs);
    crisp_frep_renderer_destroy(r);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
    return 0;
}

static void row(const char *label, const char *model, int size, int depth, int threads,
                unsigned flags, int runs, double *base)
{
    result res;
    if (run(model, size, depth, threads, flags, runs, &res)) return;
    char dims[32];
    if (depth)
        snprintf(dims, sizeof dims, "%dx%dx%d", size, size, depth);
    else
        snprintf(dims, sizeof dims, "%dx%d", size, size);
    double ratio = base && *base > 0 ? res.render_ms / *base : 1;
    if (base && *base <= 0) *base = res.render_ms;
    printf(
        "| %-26s | %-10s | %-12s | %7d | %4d | %10.2f | %9.2f | %9.2f | %8.2f | %6.2fx | %8zu |\n",
        label, model, dims, threads, runs, res.render_ms, res.render_min_ms, res.cpu_ms,
        res.setup_ms, ratio, res.inside);
    fflush(stdout);
}

int main(int argc, char **argv)
{
    int quick = argc > 1 && !strcmp(argv[1], "--quick");
    int R = quick ? 5 : 15;
    bench_print_machine(stdout);
    printf("load average at start: %.2f (other processes share the cores: wall times are "
           "noisy)\n\n",
           bench_load_average());
    printf("| case | model | size | threads | runs | median ms | min ms | CPU ms | set-up ms | vs "
           "full | inside px |\n");
    printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
    double b;
    b = 0, row("full", "prospero", 1024, 0, 2, 0, R, &b);
    row("1 thread", "prospero", 1024, 0, 1, 0, R, &b);
    row("no tape shortening", "prospero", 1024, 0, 2, CRISP_FREP_NO_PRUNE, quick ? 3 : 5, &b);
    row("no batched sub-cell intervals", "prospero", 1024, 0, 2, CRISP_FREP_NO_SUBCELLS, R, &b);
    row("no batching (1 point)", "prospero", 1024, 0, 2, CRISP_FREP_NO_BATCH, R, &b);
    row("brute force (no intervals)", "prospero", 1024, 0, 2, CRISP_FREP_BRUTE, 3, &b);
    if (!quick) {
        b = 0, row("full", "prospero", 4096, 0, 2, 0, 10, &b);
        row("1 thread", "prospero", 4096, 0, 1, 0, 10, &b);
    }
    b = 0, row("full", "bear", 512, 512, 2, 0, quick ? 3 : 10, &b);
    row("1 thread", "bear", 512, 512, 1, 0, quick ? 3 : 10, &b);
    row("no batched sub-cell intervals", "bear", 512, 512, 2, CRISP_FREP_NO_SUBCELLS,
        quick ? 3 : 10, &b);
    b = 0, row("full", "bear", 256, 256, 2, 0, R, &b);
    row("1 thread", "bear", 256, 256, 1, 0, R, &b);
    row("no tape shortening", "bear", 256, 256, 2, CRISP_FREP_NO_PRUNE, R, &b);
    row("no batching (1 point)", "bear", 256, 256, 2, CRISP_FREP_NO_BATCH, 3, &b);
    row("brute force (no intervals)", "bear", 256, 256, 2, CRISP_FREP_BRUTE, 3, &b);
    return 0;
}
