/* STEP read times on the bundled STEP models: Part 21 parse alone, and the whole read (parse,
 * conversion of every face with its trims, units, colours), median of several runs, with the
 * number of faces and how their trims were made (pcurve or projection of the 3D edge).
 * Usage: bench_step_read [runs] */
#include <stdio.h>
#include <stdlib.h>

#include "bench_util.h"
#include "io/step/step_internal.h"

int main(int argc, char **argv)
{
    int runs = argc > 1 ? atoi(argv[1]) : 7;
    if (runs < 1 || runs > 1000) runs = 7;
    static const char *files[] = {"occt_linkrods.step", "Ventilator.stp"};
    bench_print_machine(stdout);
    printf("median of %d runs (wall time; the machine may be shared)\n\n", runs);
    printf("| file | MB | entities | parse ms | read ms | faces | pcurve trims | projected trims | "
           "dropped |\n");
    printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (size_t k = 0; k < sizeof files / sizeof *files; k++) {
        char path[1024], *data;
        size_t size;
        snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, files[k]);
        if (crisp_read_file(path, &data, &size)) {
            fprintf(stderr, "%s\n", crisp_error_message());
            return 1;
        }
        double *tp = malloc(sizeof *tp * (size_t)runs), *tr = malloc(sizeof *tr * (size_t)runs);
        size_t entities = 0;
        step_read_stats st = {0};
        int faces = 0;
        for (int i = 0; i < runs; i++) {
            step_file f;
            double t = crisp_time_now();
            if (crisp__step_parse(path, data, size, &f)) {
                fprintf(stderr, "%s\n", crisp_error_message());
                return 1;
            }
            tp[i] = crisp_time_now() - t;
            entities = f.entity_count;
            crisp__step_file_free(&f);
            crisp_model *m;
            t = crisp_time_now();
            if (crisp__step_read_mem(path, data, size, NULL, &m, &st)) {
                fprintf(stderr, "%s\n", crisp_error_message());
                return 1;
            }
            tr[i] = crisp_time_now() - t;
            faces = m->face_count;
            crisp_model_destroy(m);
        }
        printf("| %s | %.2f | %zu | %.1f | %.1f | %d | %d | %d | %d |\n", files[k], size / 1e6,
               entities, bench_median(tp, runs) * 1e3, bench_median(tr, runs) * 1e3, faces,
               st.pcurve_edges, st.projected_edges, st.dropped_faces);
        free(tp);
        free(tr);
        crisp_free(data);
    }
    return 0;
}
