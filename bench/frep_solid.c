/* Issue 14 benchmarks: the f-rep mesher's time and peak memory per million triangles by
 * resolution (a counting sink: no file), and the mass properties' predicted against measured
 * times and errors at the two levels after the coarse ones (Clark's PADL-2 prediction).
 * usage: bench_frep_solid [mesh|mass|all] [max mesh resolution, default 512] */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "bench_util.h"
#include "crisp/frep.h"
#include "crisp/frep_mass.h"
#include "crisp/frep_mesh.h"

static crisp_status count_vertex(void *ctx, const float p[3])
{
    (void)ctx, (void)p;
    return CRISP_OK;
}
static crisp_status count_triangle(void *ctx, const uint32_t v[3], const float p[3][3])
{
    (void)ctx, (void)v, (void)p;
    return CRISP_OK;
}

static crisp_frep_tape *load(const char *name, crisp_frep **f)
{
    char path[512];
    snprintf(path, sizeof path, "%s/frep/%s.vm", CRISP_DATA_DIR, name);
    crisp_frep_tape *t = NULL;
    if (crisp_frep_read_vm(path, f) || crisp_frep_tape_create(*f, &t)) {
        fprintf(stderr, "%s\n", crisp_error_message());
        exit(1);
    }
    return t;
}

static double rss_mb(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return u.ru_maxrss / 1024.0;
}

static void bench_mesh(int maxres)
{
    printf("\nmesh (counting sink): model, resolution, triangles, time, s per M triangles, mesher "
           "peak MB, "
           "process peak RSS MB\n");
    printf("| model | resolution | triangles | time s | s / M tri | mesher peak MB | RSS MB "
           "|\n|---|---:|---:|---:|---:|---:|---:|\n");
    const char *models[2] = {"bear", "prospero"};
    for (int m = 0; m < 2; m++) {
        crisp_frep *f;
        crisp_frep_tape *t = load(models[m], &f);
        for (int res = 128; res <= maxres; res *= 2) {
            crisp_frep_mesh_desc d = {.resolution = res};
            if (m == 1) { /* prospero extruded: a 2D model cut by z in [-0.25, 0.25] */
                double r[6] = {-1, 1, -1, 1, -0.25, 0.25};
                memcpy(d.region, r, sizeof r);
            }
            crisp_frep_mesh_sink sink = {.vertex = count_vertex, .triangle = count_triangle};
            crisp_frep_mesh_stats st;
            double t0 = crisp_time_now();
            if (crisp_frep_mesh(t, &d, &sink, &st)) {
                fprintf(stderr, "%s\n", crisp_error_message());
                exit(1);
            }
            double dt = crisp_time_now() - t0;
            printf("| %s | %d | %zu | %.2f | %.2f | %.1f | %.1f |\n", models[m], res, st.triangles,
                   dt, dt / (st.triangles / 1e6), st.peak_bytes / 1e6, rss_mb());
            fflush(stdout);
        }
        crisp_frep_tape_destroy(t);
        crisp_frep_destroy(f);
    }
}

static void bench_mass(void)
{
    printf("\nmass: levels 3..6 measured, levels 7 and 8 predicted (crisp_frep_mass_predict from "
           "levels 4..6) "
           "and measured\n");
    printf("| model | level | predicted CPU s | measured CPU s | ratio | predicted SE | measured "
           "SE | ratio |\n"
           "|---|---:|---:|---:|---:|---:|---:|---:|\n");
    const char *models[3] = {"bear", "tanglecube", "colonnade"};
    for (int m = 0; m < 3; m++) {
        crisp_frep *f;
        crisp_frep_tape *t = load(models[m], &f);
        crisp_frep_mass lv[9];
        crisp_frep_mass_desc d = {.level = 1, .seed = 1};
        if (m == 2) {
            double r[6] = {-1, 1, -1, 1, -1, 1};
            memcpy(d.region, r, sizeof r);
        }
        crisp_frep_mass_level(t, &d, &lv[1]);
        memcpy(d.region, lv[1].region, sizeof d.region);
        crisp_error_clear();
        for (int L = 3; L <= 8; L++) {
            d.level = L;
            crisp_frep_mass_level(
                t, &d, &lv[L]); /* the colonnade is cut by its region: reported, measured */
        }
        for (int L = 7; L <= 8; L++) {
            double pt, pe;
            crisp_frep_mass_predict(&lv[4], 3, L, &pt, &pe);
            printf("| %s | %d | %.3f | %.3f | %.2f | %.3g | %.3g | %.2f |\n", models[m], L, pt,
                   lv[L].cpu_seconds, lv[L].cpu_seconds / pt, pe, lv[L].volume_se,
                   lv[L].volume_se / pe);
            if (getenv("MASSDBG"))
                for (int q = 3; q <= 8; q++)
                    fprintf(stderr, "  L%d cells %zu inside %zu intervals %zu cpu %.4f\n", q,
                            lv[q].boundary_cells, lv[q].inside_cells, lv[q].intervals,
                            lv[q].cpu_seconds);
        }
        fflush(stdout);
        crisp_frep_tape_destroy(t);
        crisp_frep_destroy(f);
    }
}

int main(int argc, char **argv)
{
    const char *what = argc > 1 ? argv[1] : "all";
    int maxres = argc > 2 ? (int)strtol(argv[2], NULL, 10) : 512;
    bench_print_machine(stdout);
    FILE *l = fopen("/proc/loadavg", "r");
    char load[64] = "?";
    if (l && fgets(load, sizeof load, l)) load[strcspn(load, "\n")] = 0;
    if (l) fclose(l);
    printf("load average: %s\n", load);
    if (!strcmp(what, "mesh") || !strcmp(what, "all")) bench_mesh(maxres);
    if (!strcmp(what, "mass") || !strcmp(what, "all")) bench_mass();
    return 0;
}
