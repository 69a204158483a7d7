/* Bézier extraction and evaluation throughput of the NURBS kernel on synthetic models of about
 * 4,500 patches (bicubic; rational biquadratic; degree (10, 8)). Baseline, in the same run:
 * extraction by global knot insertion (every interior knot raised to full multiplicity with
 * crisp_surface_insert_knot_u/v on a copy), the textbook route that crisp_surface_to_bezier's
 * span-local insertion replaces. Prints medians of repeated runs.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "bench_util.h"
#include "crisp/io.h"
#include "crisp/model.h"
#include "crisp/nurbs.h"

static crisp_surface *make_surface(int du, int dv, int su, int sv, int rational, unsigned seed)
{
    int nu = su + du, nv = sv + dv;
    double *ku = malloc((size_t)(nu + du + 1) * sizeof *ku);
    double *kv = malloc((size_t)(nv + dv + 1) * sizeof *kv);
    double *p = malloc((size_t)nu * nv * 3 * sizeof *p), *w = malloc((size_t)nu * nv * sizeof *w);
    for (int i = 0; i < nu + du + 1; i++)
        ku[i] = i < du ? 0 : i > nu ? su : i - du;
    for (int i = 0; i < nv + dv + 1; i++)
        kv[i] = i < dv ? 0 : i > nv ? sv : i - dv;
    srand(seed);
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            double *q = p + ((size_t)j * nu + i) * 3;
            q[0] = i;
            q[1] = j;
            q[2] = (double)rand() / RAND_MAX;
            w[j * nu + i] = 0.5 + (double)rand() / RAND_MAX;
        }
    crisp_surface *s = NULL;
    if (crisp_surface_create(du, dv, nu, nv, ku, kv, p, rational ? w : NULL, &s)) s = NULL;
    free(ku);
    free(kv);
    free(p);
    free(w);
    return s;
}

/* Baseline: raise every interior knot to multiplicity degree on a copy. Returns patch count. */
static int global_insertion(const crisp_surface *s)
{
    crisp_surface *c;
    if (crisp_surface_copy(s, &c)) return -1;
    for (int dir = 0; dir < 2; dir++) {
        int p = dir ? s->degree_v : s->degree_u, n = dir ? s->count_v : s->count_u;
        const double *k = dir ? s->knots_v : s->knots_u;
        for (int i = p + 1; i < n; i++) {
            if (k[i] == k[i - 1]) continue;
            int m = 0;
            while (k[i + m] == k[i])
                m++;
            if (m < p) {
                crisp_status st = dir ? crisp_surface_insert_knot_v(c, k[i], p - m)
                                      : crisp_surface_insert_knot_u(c, k[i], p - m);
                if (st) return -1;
            }
        }
    }
    int patches = ((c->count_u - 1) / c->degree_u) * ((c->count_v - 1) / c->degree_v);
    crisp_surface_destroy(c);
    return patches;
}

static void run(const char *name, int du, int dv, int su, int sv, int nsurf, int rational)
{
    crisp_surface **s = malloc((size_t)nsurf * sizeof *s);
    for (int i = 0; i < nsurf; i++)
        s[i] = make_surface(du, dv, su, sv, rational, (unsigned)i + 1);
    enum { RUNS = 15 };
    double t_ext[RUNS], t_base[RUNS], t_eval[RUNS], t_bez[RUNS];
    int patches = 0;
    const int evals = 200000;
    double sink = 0.0;
    for (int r = 0; r < RUNS; r++) {
        double t0 = crisp_time_now();
        patches = 0;
        for (int i = 0; i < nsurf; i++) {
            crisp_bezier_patches bp;
            if (crisp_surface_to_bezier(s[i], &bp)) return;
            patches += bp.count;
            sink += bp.storage[0];
            crisp_bezier_patches_free(&bp);
        }
        double t1 = crisp_time_now();
        for (int i = 0; i < nsurf; i++)
            sink += global_insertion(s[i]);
        double t2 = crisp_time_now();
        for (int i = 0; i < evals; i++) {
            double x[3];
            crisp_surface_eval(s[i % nsurf], su * ((i * 0.6180339887) - floor(i * 0.6180339887)),
                               sv * ((i * 0.7548776662) - floor(i * 0.7548776662)), x);
            sink += x[2];
        }
        double t3 = crisp_time_now();
        crisp_bezier_patches bp;
        if (crisp_surface_to_bezier(s[0], &bp)) return;
        double t4 = crisp_time_now();
        for (int i = 0; i < evals; i++) {
            double x[3];
            crisp_bezier_patch_eval(&bp.patches[i % bp.count],
                                    (i * 0.6180339887) - floor(i * 0.6180339887),
                                    (i * 0.7548776662) - floor(i * 0.7548776662), x);
            sink += x[2];
        }
        double t5 = crisp_time_now();
        crisp_bezier_patches_free(&bp);
        t_ext[r] = (t1 - t0) * 1e3;
        t_base[r] = (t2 - t1) * 1e3;
        t_eval[r] = (t3 - t2) * 1e9 / evals;
        t_bez[r] = (t5 - t4) * 1e9 / evals;
    }
    double e = bench_median(t_ext, RUNS), b = bench_median(t_base, RUNS);
    printf("| %-22s | %6d | %9.2f | %9.2f | %5.1fx | %8.0f | %8.0f |%s\n", name, patches, e, b,
           b / e, bench_median(t_eval, RUNS), bench_median(t_bez, RUNS), sink == 1.2345 ? " " : "");
    for (int i = 0; i < nsurf; i++)
        crisp_surface_destroy(s[i]);
    free(s);
}

/* Extraction of every face of a bundled model (surfaces and trim curves), median of 15 runs. */
static void run_file(const char *name)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, name);
    crisp_model *m = NULL;
    if (crisp_model_load(path, NULL, &m)) {
        printf("| %-22s | not loaded: %s |\n", name, crisp_error_message());
        return;
    }
    enum { RUNS = 15 };
    double ts[RUNS], tc[RUNS];
    int patches = 0, pieces = 0;
    for (int r = 0; r < RUNS; r++) {
        double t0 = crisp_time_now();
        patches = 0;
        for (int i = 0; i < m->face_count; i++) {
            crisp_bezier_patches bp;
            if (crisp_surface_to_bezier(m->faces[i].surface, &bp)) return;
            patches += bp.count;
            crisp_bezier_patches_free(&bp);
        }
        double t1 = crisp_time_now();
        pieces = 0;
        for (int i = 0; i < m->face_count; i++)
            for (int l = 0; l < m->faces[i].loop_count; l++)
                for (int c = 0; c < m->faces[i].loops[l].curve_count; c++) {
                    crisp_bezier_curve *b;
                    int n;
                    if (crisp_curve_to_bezier(m->faces[i].loops[l].curves[c], &b, &n)) return;
                    pieces += n;
                    crisp_free(b);
                }
        double t2 = crisp_time_now();
        ts[r] = (t1 - t0) * 1e3;
        tc[r] = (t2 - t1) * 1e3;
    }
    printf("| %-22s | %6d | %9.2f | %6d | %9.2f |\n", name, patches, bench_median(ts, RUNS), pieces,
           bench_median(tc, RUNS));
    crisp_model_destroy(m);
}

int main(void)
{
    bench_print_machine(stdout);
    printf("medians of 15 runs; the machine is shared, so absolute times are noisy, ratios less "
           "so\n\n");
    printf("| model                  | patches | extract ms | global-insertion ms | ratio | "
           "surface eval ns | Bézier eval ns |\n");
    printf("|---|---|---|---|---|---|---|\n");
    run("bicubic 30 x (10x15)", 3, 3, 10, 15, 30, 0);
    run("rational (2,2) 30x150", 2, 2, 10, 15, 30, 1);
    run("degree (10,8) 30x150", 10, 8, 10, 15, 30, 1);
    printf("\n| bundled model          | patches | surfaces ms | trim pieces | trims ms |\n");
    printf("|---|---|---|---|---|\n");
    const char *files[] = {"impeller.igs",     "occt_bearing.iges",  "occt_hammer.iges",
                           "gpucast_part.igs", "gpucast_teapot.igs", "occt_linkrods.step",
                           "Ventilator.stp"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++)
        run_file(files[i]);
    return 0;
}
