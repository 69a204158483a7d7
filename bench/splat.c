/* The splat builder (issue 12, src/render/splat_build.c) over every face of a model at radii
 * D / 2^k (D the model box's diagonal): build time, splats per face, and how near minimal the
 * count is: splats x 2 r^2 / trimmed area (an ideal covering of a flat square of side a by
 * points at the centres of squares of side sqrt(2) r needs a^2 / (2 r^2); below 1 is not
 * possible for a flat face, curved faces need a little more).
 *   bench_splat [MODEL (under data/nurbs, default impeller.igs)] [KMIN KMAX (6 10)]
 * A second table: radii relative to each face (its box diagonal d / 2^j, j = 1..5), the regime of
 * faces a few pixels across.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "bench_util.h"
#include "crisp/io.h"
#include "crisp/mass.h"
#include "crisp/render.h"
#include "render/splat.h"

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

int main(int argc, char **argv)
{
    const char *name = argc > 1 ? argv[1] : "impeller.igs";
    int kmin = argc > 3 ? atoi(argv[2]) : 6, kmax = argc > 3 ? atoi(argv[3]) : 10;
    char path[1024];
    snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, name);
    crisp_model *m;
    crisp_scene *sc;
    if (crisp_model_load(path, NULL, &m) || crisp_scene_prepare(m, &sc)) {
        fprintf(stderr, "%s: %s\n", path, crisp_error_message());
        return 1;
    }
    bench_print_machine(stdout);
    double *area = calloc(sc->face_count, sizeof *area), total_area = 0.0;
    /* BENCH_SPLAT_NO_AREA=1: skip the areas (for profiling the builder alone). */
    const char *no_area = getenv("BENCH_SPLAT_NO_AREA");
    for (uint32_t f = 0; f < sc->face_count && !(no_area && *no_area == '1'); f++) {
        crisp_mass_props mp;
        crisp_mass_desc md = {.tolerance = 1e-6, .face_begin = (int)f, .face_end = (int)f + 1};
        if (crisp_mass_model(m, &md, &mp) == CRISP_OK) area[f] = fabs(mp.area);
        total_area += area[f];
    }
    double d = 0.0;
    for (int q = 0; q < 3; q++)
        d += (sc->box[q + 3] - sc->box[q]) * (sc->box[q + 3] - sc->box[q]);
    d = sqrt(d);
    printf("model %s: %u faces, %u patches, %u trim pieces, box diagonal D %.6g, trimmed area "
           "%.6g\n",
           name, sc->face_count, sc->patch_count, sc->piece_count, d, total_area);
    printf("| k | radius D/2^k | build ms (all faces) | splats | per face mean / max | faces "
           "failed | splats x 2r^2 / area | faces > 8 x ideal | radius met / asked |\n");
    printf("|---|---|---|---|---|---|---|---|---|\n");
    for (int k = kmin; k <= kmax; k++) {
        double r = d / ldexp(1.0, k), t0 = now_ms(), met = 0.0;
        uint64_t total = 0;
        uint32_t maxc = 0, failed = 0, wasteful = 0;
        for (uint32_t f = 0; f < sc->face_count; f++) {
            crisp_splat_set set;
            if (crisp__splat_build(sc, f, r, 0, &set)) {
                failed++;
                continue;
            }
            total += set.count;
            maxc = set.count > maxc ? set.count : maxc;
            met = fmax(met, set.radius / r);
            if (area[f] > 0 && set.count > 8 && set.count * 2 * r * r / area[f] > 8) wasteful++;
            crisp__splat_set_free(&set);
        }
        double ms = now_ms() - t0;
        printf("| %d | %.4g | %.0f | %llu | %.1f / %u | %u | %.2f | %u | %.3f |\n", k, r, ms,
               (unsigned long long)total, (double)total / sc->face_count, maxc, failed,
               total * 2 * r * r / total_area, wasteful, met);
    }
    printf("\n| j | radius d/2^j per face | build ms (all faces) | splats | per face mean / max | "
           "faces failed |\n|---|---|---|---|---|---|\n");
    for (int j = 1; j <= 5; j++) {
        double t0 = now_ms();
        uint64_t total = 0;
        uint32_t maxc = 0, failed = 0;
        for (uint32_t f = 0; f < sc->face_count; f++) {
            const crisp_scene_face *sf = &sc->faces[f];
            double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL},
                   hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
            for (uint32_t k = 0; k < sf->patch_count; k++)
                for (int q = 0; q < 3; q++) {
                    lo[q] = fmin(lo[q], sc->patches[sf->first_patch + k].box[q]);
                    hi[q] = fmax(hi[q], sc->patches[sf->first_patch + k].box[q + 3]);
                }
            double fd = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                             (hi[2] - lo[2]) * (hi[2] - lo[2]));
            crisp_splat_set set;
            if (!(fd > 0) || crisp__splat_build(sc, f, fd / ldexp(1.0, j), 0, &set)) {
                failed++;
                continue;
            }
            total += set.count;
            maxc = set.count > maxc ? set.count : maxc;
            crisp__splat_set_free(&set);
        }
        printf("| %d | d/%d | %.0f | %llu | %.1f / %u | %u |\n", j, 1 << j, now_ms() - t0,
               (unsigned long long)total, (double)total / sc->face_count, maxc, failed);
    }
    free(area);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
    return 0;
}
