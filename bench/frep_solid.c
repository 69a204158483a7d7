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

static crisp_frep_tape *load_expr(const char *expr, crisp_frep **f)
{
    crisp_frep_tape *t = NULL;
    if (crisp_frep_read_math_mem("-e", expr, strlen(expr), f) || crisp_frep_tape_create(*f, &t)) {
        fprintf(stderr, "%s\n", crisp_error_message());
        exit(1);
    }
    return t;
}

static void bench_mass(void)
{
    printf("\nmass: levels 3..6 measured; levels 7 and 8 predicted by crisp_frep_mass_predict "
           "(least squares of each level's processor time, less the region check, on "
           "a 4^L + b 2^L + c) and measured\n");
    printf("| model | level | boundary cells | predicted CPU s | measured CPU s | measured / "
           "predicted | predicted SE | measured SE | ratio |\n"
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    /* the bundled 3D models over their fitted boxes (the colonnade, unbounded in y, over
     * [-1, 1]^3), the 2D ones extruded (z in [-0.25, 0.25]), and two analytic solids */
    static const struct {
        const char *name, *expr;
        double region[6];
    } models[] = {
        {"bear", NULL, {0}},
        {"tanglecube", NULL, {0}},
        {"colonnade", NULL, {-1, 1, -1, 1, -1, 1}},
        {"prospero", NULL, {-1, 1, -1, 1, -0.25, 0.25}},
        {"hi", NULL, {-1, 1, -1, 1, -0.25, 0.25}},
        {"quarter", NULL, {-1, 1, -1, 1, -0.25, 0.25}},
        {"sphere", "X^2+Y^2+Z^2-1", {0}},
        {"torus", "(sqrt(X^2+Y^2)-1)^2+Z^2-0.09", {0}},
    };
    double worst = 0;
    for (size_t m = 0; m < sizeof models / sizeof models[0]; m++) {
        crisp_frep *f;
        crisp_frep_tape *t =
            models[m].expr ? load_expr(models[m].expr, &f) : load(models[m].name, &f);
        crisp_frep_mass lv[9];
        crisp_frep_mass_desc d = {.level = 1, .seed = 1};
        memcpy(d.region, models[m].region, sizeof d.region);
        crisp_frep_mass_level(t, &d, &lv[1]);
        memcpy(d.region, lv[1].region, sizeof d.region);
        crisp_error_clear();
        for (int L = 3; L <= 8; L++) {
            d.level = L;
            /* the colonnade and the extruded 2D parts are cut by their region: reported, and
             * measured within it */
            crisp_frep_mass_level(t, &d, &lv[L]);
            crisp_error_clear();
        }
        for (int L = 7; L <= 8; L++) {
            double pt, pe;
            crisp_frep_mass_predict(&lv[3], 4, L, &pt, &pe);
            double r = lv[L].cpu_seconds / pt;
            worst = fmax(worst, fabs(r - 1));
            printf("| %s | %d | %zu | %.3f | %.3f | %.2f | %.3g | %.3g | %.2f |\n", models[m].name,
                   L, lv[L].boundary_cells, pt, lv[L].cpu_seconds, r, pe, lv[L].volume_se,
                   lv[L].volume_se / pe);
            if (getenv("MASSDBG"))
                for (int q = 3; q <= 8; q++)
                    fprintf(stderr, "  L%d cells %zu cpu %.4f fixed %.4f\n", q,
                            lv[q].boundary_cells, lv[q].cpu_seconds, lv[q].cpu_fixed);
        }
        fflush(stdout);
        crisp_frep_tape_destroy(t);
        crisp_frep_destroy(f);
    }
    printf("largest time prediction error: %.0f%%\n", 100 * worst);
}

int main(int argc, char **argv)
{
    const char *what = argc > 1 ? argv[1] : "all";
    int maxres = argc > 2 ? (int)strtol(argv[2], NULL, 10) : 512;
    bench_print_machine(stdout);
    printf("load average: %.2f\n", bench_load_average());
    if (!strcmp(what, "mesh") || !strcmp(what, "all")) bench_mesh(maxres);
    if (!strcmp(what, "mass") || !strcmp(what, "all")) bench_mass();
    return 0;
}
