/* OBJ free-form writer and reader on the bundled models: for every model that loads, the time to
 * load it from its native file (IGES/STEP, the baseline, measured in the same run), to write it
 * as OBJ free-form, and to read that OBJ back, as medians of repeated runs; plus the OBJ size.
 * Also the Catmull-Clark route: a subdivided cube cage of growing size through OpenSubdiv.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "bench_util.h"
#include "crisp/io.h"

#define RUNS 7

static const char *const models[] = {
    "occt_bearing.iges", "occt_hammer.iges",   "gpucast_part.igs", "gpucast_teapot.igs",
    "impeller.igs",      "occt_linkrods.step", "Ventilator.stp",   NULL};

static void bench_model(const char *name, const char *tmp)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, name);
    double t_native[RUNS], t_write[RUNS], t_read[RUNS];
    crisp_model *m = NULL;
    for (int r = 0; r < RUNS; r++) {
        double t0 = crisp_time_now();
        crisp_status st = crisp_model_load(path, NULL, &m);
        t_native[r] = crisp_time_now() - t0;
        if (st != CRISP_OK) {
            printf("| %s | not loadable: %.60s |\n", name, crisp_error_message());
            return;
        }
        if (r + 1 < RUNS) crisp_model_destroy(m);
    }
    for (int r = 0; r < RUNS; r++) {
        double t0 = crisp_time_now();
        crisp_write_obj(m, tmp);
        t_write[r] = crisp_time_now() - t0;
    }
    int faces = m->face_count, back = -1;
    for (int r = 0; r < RUNS; r++) {
        crisp_model *b = NULL;
        double t0 = crisp_time_now();
        crisp_status st = crisp_read_obj(tmp, NULL, &b);
        t_read[r] = crisp_time_now() - t0;
        if (st == CRISP_OK) back = b->face_count;
        crisp_model_destroy(b);
    }
    FILE *f = fopen(tmp, "rb");
    long size = 0;
    if (f) {
        fseek(f, 0, SEEK_END);
        size = ftell(f);
        fclose(f);
    }
    double native = bench_median(t_native, RUNS), rd = bench_median(t_read, RUNS);
    printf("| %s | %d | %d | %.1f | %.1f | %.1f | %.2fx | %.2f |\n", name, faces, back,
           native * 1e3, bench_median(t_write, RUNS) * 1e3, rd * 1e3, rd / native, size / 1e6);
    crisp_model_destroy(m);
    remove(tmp);
}

/* An n x n x n subdivided cube cage (6 n^2 quads) as OBJ polygon faces, through OpenSubdiv. */
static void bench_cage(int n, const char *tmp)
{
    FILE *f = fopen(tmp, "w");
    if (!f) return;
    /* vertices on the cube surface grid, indexed by a map over the (n+1)^3 lattice */
    int N = n + 1, *id = calloc((size_t)N * N * N, sizeof(int)), next = 0;
    for (int z = 0; z < N; z++)
        for (int y = 0; y < N; y++)
            for (int x = 0; x < N; x++)
                if (x == 0 || y == 0 || z == 0 || x == n || y == n || z == n) {
                    id[(z * N + y) * N + x] = ++next;
                    fprintf(f, "v %g %g %g\n", 2.0 * x / n - 1, 2.0 * y / n - 1, 2.0 * z / n - 1);
                }
#define ID(x, y, z) id[((z)*N + (y)) * N + (x)]
    for (int a = 0; a < n; a++)
        for (int b = 0; b < n; b++) {
            fprintf(f, "f %d %d %d %d\n", ID(a, b, 0), ID(a, b + 1, 0), ID(a + 1, b + 1, 0),
                    ID(a + 1, b, 0));
            fprintf(f, "f %d %d %d %d\n", ID(a, b, n), ID(a + 1, b, n), ID(a + 1, b + 1, n),
                    ID(a, b + 1, n));
            fprintf(f, "f %d %d %d %d\n", ID(a, 0, b), ID(a + 1, 0, b), ID(a + 1, 0, b + 1),
                    ID(a, 0, b + 1));
            fprintf(f, "f %d %d %d %d\n", ID(a, n, b), ID(a, n, b + 1), ID(a + 1, n, b + 1),
                    ID(a + 1, n, b));
            fprintf(f, "f %d %d %d %d\n", ID(0, a, b), ID(0, a, b + 1), ID(0, a + 1, b + 1),
                    ID(0, a + 1, b));
            fprintf(f, "f %d %d %d %d\n", ID(n, a, b), ID(n, a + 1, b), ID(n, a + 1, b + 1),
                    ID(n, a, b + 1));
        }
#undef ID
    fclose(f);
    free(id);
    double t[RUNS];
    int patches = 0;
    for (int r = 0; r < RUNS; r++) {
        crisp_model *m = NULL;
        double t0 = crisp_time_now();
        crisp_status st = crisp_read_obj(tmp, NULL, &m);
        t[r] = crisp_time_now() - t0;
        if (st != CRISP_OK) {
            printf("| cube cage %d | failed: %.60s |\n", n, crisp_error_message());
            remove(tmp);
            return;
        }
        patches = m->face_count;
        crisp_model_destroy(m);
    }
    printf("| cube cage, %d quads | %d | %.1f |\n", 6 * n * n, patches,
           bench_median(t, RUNS) * 1e3);
    remove(tmp);
}

int main(void)
{
    const char *tmp = "bench_obj_io.tmp.obj";
    bench_print_machine(stdout);
    printf("medians of %d runs, wall time (the machine is shared: timings are noisy)\n\n", RUNS);
    printf("| model | faces | faces read back | native load /ms | OBJ write /ms | OBJ read /ms "
           "| OBJ read / native | OBJ MB |\n|---|---|---|---|---|---|---|---|\n");
    for (const char *const *m = models; *m; m++)
        bench_model(*m, tmp);
    printf("\nCatmull-Clark cages through OpenSubdiv (isolation 3, B-spline end caps):\n\n"
           "| cage | bicubic patches | OBJ read /ms |\n|---|---|---|\n");
    for (int n = 1; n <= 16; n *= 2)
        bench_cage(n, tmp);
    return 0;
}
