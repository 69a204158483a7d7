/* bench_read: read times of every bundled CAD model (data/nurbs): reading the file into memory
 * (the baseline, in the same run), parsing and converting it into crisp's model
 * (crisp_read_iges / crisp_read_step), and preparing it (Bézier extraction of every surface and
 * trim curve). Medians over repeated runs. The target: occt_bearing.iges read and
 * prepared in under 0.2 s.
 *
 *   bench_read [MODEL...]     (default: every bundled model)
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bench_util.h"
#include "crisp/io.h"

typedef crisp_status (*reader_fn)(const char *, const char *, size_t, const crisp_read_options *,
                                  crisp_model **);

typedef struct prepared {
    int patches, pieces;
} prepared;

static crisp_status prepare(const crisp_model *m, prepared *dest)
{
    memset(dest, 0, sizeof *dest);
    for (int i = 0; i < m->face_count; i++) {
        const crisp_face *f = &m->faces[i];
        crisp_bezier_patches p;
        crisp_status st = crisp_surface_to_bezier(f->surface, &p);
        if (st) return st;
        dest->patches += p.count;
        crisp_bezier_patches_free(&p);
        for (int l = 0; l < f->loop_count; l++)
            for (int c = 0; c < f->loops[l].curve_count; c++) {
                crisp_bezier_curve *b = NULL;
                int n = 0;
                if ((st = crisp_curve_to_bezier(f->loops[l].curves[c], &b, &n))) return st;
                dest->pieces += n;
                crisp_free(b);
            }
    }
    return CRISP_OK;
}

static reader_fn reader_for(const char *name, const char **format)
{
    const char *dot = strrchr(name, '.');
    if (dot && (!strcmp(dot, ".igs") || !strcmp(dot, ".iges"))) {
        *format = "IGES";
        return crisp_read_iges_mem;
    }
    if (dot && (!strcmp(dot, ".stp") || !strcmp(dot, ".step"))) {
        *format = "STEP";
        return crisp_read_step_mem;
    }
    *format = "?";
    return NULL;
}

static int bench_one(const char *path)
{
    const char *name = strrchr(path, '/') ? strrchr(path, '/') + 1 : path, *format;
    reader_fn read = reader_for(name, &format);
    if (!read) {
        fprintf(stderr, "%s: not an IGES or STEP file\n", path);
        return 1;
    }
    enum { MAX_RUNS = 21 };
    double t_io[MAX_RUNS], t_read[MAX_RUNS], t_prep[MAX_RUNS], spent = 0;
    int runs = 0, faces = 0;
    prepared prep = {0};
    while (runs < MAX_RUNS && (runs < 3 || spent < 4.0)) {
        double t0 = crisp_time_now();
        char *data = NULL;
        size_t size = 0;
        if (crisp_read_file(path, &data, &size)) {
            fprintf(stderr, "%s\n", crisp_error_message());
            return 1;
        }
        double t1 = crisp_time_now();
        crisp_model *m = NULL;
        if (read(path, data, size, NULL, &m)) {
            fprintf(stderr, "%s\n", crisp_error_message());
            crisp_free(data);
            return 1;
        }
        double t2 = crisp_time_now();
        if (prepare(m, &prep)) {
            fprintf(stderr, "%s\n", crisp_error_message());
            return 1;
        }
        double t3 = crisp_time_now();
        faces = m->face_count;
        crisp_model_destroy(m);
        crisp_free(data);
        t_io[runs] = t1 - t0;
        t_read[runs] = t2 - t1;
        t_prep[runs] = t3 - t2;
        spent += t3 - t0;
        runs++;
    }
    double io = bench_median(t_io, runs), rd = bench_median(t_read, runs);
    double pr = bench_median(t_prep, runs), total = rd + pr;
    printf("| %s | %s | %d | %d | %d | %d | %.2f | %.1f | %.1f | %.1f | %.0fx |\n", name, format,
           faces, prep.patches, prep.pieces, runs, io * 1e3, rd * 1e3, pr * 1e3, total * 1e3,
           io > 0 ? (io + total) / io : 0.0);
    if (!strcmp(name, "occt_bearing.iges"))
        printf("\nocct_bearing.iges read + prepare: %.1f ms, target < 200 ms: %s\n\n", total * 1e3,
               total < 0.2 ? "met" : "NOT met");
    return 0;
}

int main(int argc, char **argv)
{
    static const char *models[] = {"occt_bearing.iges",  "occt_hammer.iges", "gpucast_part.igs",
                                   "gpucast_teapot.igs", "impeller.igs",     "occt_linkrods.step",
                                   "Ventilator.stp"};
    bench_print_machine(stdout);
    printf("\n| model | format | faces | Bézier patches | trim pieces | runs | file read ms "
           "(baseline) | parse + convert ms | Bézier extraction ms | total ms | vs file read "
           "|\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    int fails = 0;
    if (argc > 1) {
        for (int i = 1; i < argc; i++)
            fails += bench_one(argv[i]);
    } else {
        for (size_t i = 0; i < sizeof models / sizeof models[0]; i++) {
            char path[1024];
            snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, models[i]);
            fails += bench_one(path);
        }
    }
    return fails ? 1 : 0;
}
