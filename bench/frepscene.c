/* bench_frepscene: f-rep parts drawn in a scene (src/render/frep_part.c, crisp_render_frep_parts):
 * the time per frame of bear.vm filling a 1280x720 view and of bear.vm small at 320x180, and of
 * prospero.vm extruded into a slab (a long tape, max(prospero(X, Y), |Z| - 0.25)) seen at an
 * angle; each with tape shortening on and off (the full-tape path) in the same run, on 1 and 2
 * threads. Medians of repeated frames; the image is cleared before each frame. Counters: interval
 * evaluations, leaves, batches of 64 points and the mean tape length per batch.
 *   bench_frepscene [--quick]   (--quick: fewer runs) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <time.h>

#include "bench_util.h"
#include "crisp/frep.h"
#include "crisp/render.h"

typedef struct scene_case {
    const char *name;
    const crisp_frep_tape *tape;
    int width, height;
    double fov;
    double eye[3];
    int full_runs; /* frames of the full-tape path (slow on long tapes) */
} scene_case;

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Median wall and process CPU time of a frame. */
static int frame(const scene_case *sc, int threads, int no_shorten, int runs, double *median_ms,
                 double *cpu_ms, crisp_frep_parts_stats *st, size_t *drawn)
{
    crisp_frep_part part = {.tape = sc->tape, .color = {0.8f, 0.6f, 0.4f, 1}};
    crisp_mat4_identity(part.transform);
    crisp_camera cam;
    double box[6] = {-1, -1, -1, 1, 1, 1};
    if (crisp_camera_frame_box(box, sc->width, sc->height, &cam)) return 1;
    cam.fov_deg = sc->fov;
    if (sc->eye[0] || sc->eye[1] || sc->eye[2]) {
        memcpy(cam.eye, sc->eye, sizeof cam.eye);
        cam.zfar =
            4 * sqrt(sc->eye[0] * sc->eye[0] + sc->eye[1] * sc->eye[1] + sc->eye[2] * sc->eye[2]);
    }
    crisp_image img = {0};
    double t[64], cpu[64];
    if (runs > 64) runs = 64;
    crisp_frep_parts_desc d = {.threads = threads, .no_shorten = no_shorten, .stats = st};
    for (int n = -1; n < runs; n++) { /* n = -1: warm-up */
        crisp_image_free(&img);
        if (crisp_image_init(&img, sc->width, sc->height)) return 1;
        double t0 = crisp_time_now(), c0 = cpu_now();
        if (crisp_render_frep_parts(&part, 1, &cam, &d, &img)) {
            fprintf(stderr, "bench_frepscene: %s\n", crisp_error_message());
            crisp_image_free(&img);
            return 1;
        }
        if (n >= 0) t[n] = crisp_time_now() - t0, cpu[n] = cpu_now() - c0;
    }
    *median_ms = 1000 * bench_median(t, runs);
    *cpu_ms = 1000 * bench_median(cpu, runs);
    *drawn = 0;
    for (size_t p = 0; p < (size_t)sc->width * sc->height; p++)
        *drawn += img.face[p] == -2;
    crisp_image_free(&img);
    return 0;
}

static crisp_frep_tape *load(const char *name, int extrude, crisp_frep **fp)
{
    char path[512];
    snprintf(path, sizeof path, "%s/frep/%s.vm", CRISP_DATA_DIR, name);
    crisp_frep *f = NULL;
    crisp_frep_tape *t = NULL;
    if (crisp_frep_read_vm(path, &f)) goto fail;
    if (extrude) {
        crisp_frep_node z, az, c, slab, root;
        if (crisp_frep_var(f, 2, &z) || crisp_frep_unary(f, CRISP_FREP_ABS, z, &az) ||
            crisp_frep_const(f, 0.25f, &c) || crisp_frep_binary(f, CRISP_FREP_SUB, az, c, &slab) ||
            crisp_frep_binary(f, CRISP_FREP_MAX, crisp_frep_root(f), slab, &root))
            goto fail;
        crisp_frep_set_root(f, root);
    }
    if (crisp_frep_tape_create(f, &t)) goto fail;
    *fp = f;
    return t;
fail:
    fprintf(stderr, "bench_frepscene: %s\n", crisp_error_message());
    crisp_frep_destroy(f);
    return NULL;
}

int main(int argc, char **argv)
{
    int quick = 0, only = -1, max_threads = 2;
    for (int a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "--quick"))
            quick = 1;
        else if (!strcmp(argv[a], "--case") && a + 1 < argc)
            only = atoi(argv[++a]);
        else if (!strcmp(argv[a], "--threads") && a + 1 < argc)
            max_threads = atoi(argv[++a]);
        else {
            fprintf(stderr, "usage: bench_frepscene [--quick] [--case N] [--threads N]\n");
            return 2;
        }
    }
    int runs = quick ? 3 : 11;
    setvbuf(stdout, NULL, _IONBF, 0);
    bench_print_machine(stdout);
    crisp_frep *fb = NULL, *fp = NULL;
    crisp_frep_tape *bear = load("bear", 0, &fb), *pros = load("prospero", 1, &fp);
    if (!bear || !pros) return 1;
    scene_case cases[] = {
        {"bear.vm filling the view", bear, 1280, 720, 13, {0, 0, 0}, 5},
        {"bear.vm small", bear, 320, 180, 30, {0, 0, 0}, 5},
        {"prospero.vm extruded, oblique", pros, 1280, 720, 30, {1.2, -2.4, 2.2}, 1},
    };
    printf(
        "f-rep parts in a scene: crisp_render_frep_parts, median of %d frames (warm-up excluded);\n"
        "'full tape' = the same renderer with tape shortening off (no_shorten), same run\n\n",
        runs);
    printf("%-30s %9s %3s %9s %9s %9s %9s %6s %9s %8s %8s %9s\n", "scene", "size", "thr",
           "short ms", "(cpu)", "full ms", "(cpu)", "ratio", "intervals", "leaves", "batches",
           "mean tape");
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        const scene_case *sc = &cases[k];
        if (only >= 0 && (size_t)only != k) continue;
        for (int threads = 1; threads <= max_threads; threads++) {
            double ms_short, ms_full, cpu_short, cpu_full;
            crisp_frep_parts_stats st, st_full;
            size_t drawn, drawn_full;
            int r = runs;
            if (frame(sc, threads, 0, r, &ms_short, &cpu_short, &st, &drawn) ||
                frame(sc, threads, 1, sc->full_runs < r ? sc->full_runs : r, &ms_full, &cpu_full,
                      &st_full, &drawn_full))
                return 1;
            char size[32];
            snprintf(size, sizeof size, "%dx%d", sc->width, sc->height);
            printf("%-30s %9s %3d %9.1f %9.1f %9.1f %9.1f %5.2fx %9zu %8zu %8zu %4.0f/%4.0f\n",
                   sc->name, size, threads, ms_short, cpu_short, ms_full, cpu_full,
                   ms_full / ms_short, st.intervals, st.leaves, st.batches,
                   st.batches ? (double)st.tape_sum / st.batches : 0,
                   st_full.batches ? (double)st_full.tape_sum / st_full.batches : 0);
            printf("  root search: %zu of the batches; %zu hits\n", st.root_batches, st.hits);
            if (drawn != drawn_full)
                printf("  !! shortened and full tape drew %zu and %zu pixels\n", drawn, drawn_full);
            if (threads == 2)
                printf("  (%zu pixels drawn, tape %zu instructions)\n", drawn,
                       crisp_frep_tape_length(sc->tape));
        }
    }
    crisp_frep_tape_destroy(bear);
    crisp_frep_tape_destroy(pros);
    crisp_frep_destroy(fb);
    crisp_frep_destroy(fp);
    return 0;
}
