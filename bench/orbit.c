/* bench_orbit: a moving camera through the CPU backend (issue 12, session 14): FRAMES consecutive
 * cameras of an orbit about the view's target (the eye turned about the camera's up axis by STEP
 * degrees a frame), each drawn once, as crisp-view draws the frames on screen at full size. Two
 * ways per row, on their own renderers: "plan" = crisp_planner_plan + crisp_render_cpu_plan (the
 * viewer's frames before session 14: the whole plan first), "stages" = crisp_render_cpu (the
 * frame planned in stages, the first stage the faces the previous frame showed). Every frame's
 * image must be the same bit for bit both ways (the hash column; the bench fails otherwise).
 * Views as bench_interactive's (1920x1080, 1 sample): default, close, zoom.
 *
 *   bench_orbit [FRAMES [THREADS [MODEL...]]]   (defaults 24, 2, impeller.igs:close,
 *                                                occt_as1_ec.stp:close, occt_bearing.iges:close;
 *                                                MODEL: rows whose "model:view" contains it)
 *
 * BENCH_ORBIT_STEP=degrees (default 2). BENCH_SPLATS=off: no splats (as bench_interactive's
 * reported rows). For callgrind (1 thread): `--collect-atstart=no --toggle-collect=frame_plan
 * --toggle-collect=frame_stages` and callgrind_annotate --inclusive=yes: each function's total is
 * one way's frames of the orbit (after its warm-up frame). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "bench_camera.h"
#include "bench_util.h"
#include "crisp/io.h"
#include "crisp/plan.h"
#include "crisp/render.h"

static void die(const char *what)
{
    fprintf(stderr, "bench_orbit: %s: %s\n", what, crisp_error_message());
    exit(1);
}

/* Camera k of the orbit: base's eye turned about the line through its target along its up axis
 * by k * step degrees (Rodrigues' rotation). */
static crisp_camera orbit_camera(const crisp_camera *base, int k, double step)
{
    crisp_camera c = *base;
    double a = k * step * M_PI / 180, u[3], d[3], x[3];
    crisp_vec3_normalize(base->up, u);
    crisp_vec3_sub(base->eye, base->target, d);
    crisp_vec3_cross(u, d, x);
    double ud = crisp_vec3_dot(u, d);
    for (int i = 0; i < 3; i++)
        c.eye[i] = base->target[i] + d[i] * cos(a) + x[i] * sin(a) + u[i] * ud * (1 - cos(a));
    return c;
}

typedef struct orbit_run {
    double *ms;      /* per frame: wall ms */
    uint32_t *hash;  /* per frame: the image's hash */
    double cpu;      /* process CPU ms over the orbit */
    uint64_t hidden; /* faces hidden before planning, summed over the frames */
    uint64_t triangles;
} orbit_run;

/* One frame as crisp-view drew it before: the whole plan, then the draw. Out of line for
 * callgrind's toggles (the frame only, not the hash). */
__attribute__((noinline)) static void frame_plan(crisp_renderer *r, const crisp_scene *sc,
                                                 const crisp_camera *cam, crisp_image *img,
                                                 crisp_render_stats *st)
{
    const crisp_frame_plan *plan;
    if (crisp_planner_plan(crisp_renderer_planner(r), sc, cam, &plan)) die("plan");
    if (crisp_render_cpu_plan(r, sc, plan, cam, img, st)) die("frame");
}

/* One frame drawn by crisp_render_cpu (in stages). */
__attribute__((noinline)) static void frame_stages(crisp_renderer *r, const crisp_scene *sc,
                                                   const crisp_camera *cam, crisp_image *img,
                                                   crisp_render_stats *st)
{
    if (crisp_render_cpu(r, sc, cam, img, st)) die("frame");
}

/* The orbit drawn one way (stages: 0 = frame_plan, 1 = frame_stages). */
static void orbit(crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cams, int frames,
                  int stages, crisp_image *img, orbit_run *o)
{
    double busy = 0;
    for (int f = 0; f < frames; f++) {
        double t0 = crisp_time_now(), b0 = bench_cpu_ms();
        crisp_render_stats st;
        (stages ? frame_stages : frame_plan)(r, sc, &cams[f], img, &st);
        o->ms[f] = 1e3 * (crisp_time_now() - t0);
        busy += bench_cpu_ms() - b0;
        o->hash[f] = bench_image_hash(img);
        o->hidden += st.hidden_faces;
        o->triangles += st.triangles;
    }
    o->cpu = busy;
}

static void run_row(const char *name, const char *view, const crisp_scene *sc,
                    const crisp_camera *base, int frames, int threads, double step)
{
    crisp_camera *cams = malloc((size_t)frames * sizeof *cams);
    for (int f = 0; f < frames; f++)
        cams[f] = orbit_camera(base, f + 1, step);
    int no_splats = getenv("BENCH_SPLATS") && !strcmp(getenv("BENCH_SPLATS"), "off");
    crisp_render_desc d = {.threads = threads, .samples = 1, .no_splats = no_splats};
    crisp_renderer *r[2];
    orbit_run run[2];
    crisp_image img;
    if (crisp_image_init(&img, base->width, base->height)) die("image");
    for (int w = 0; w < 2; w++) {
        if (crisp_renderer_create(&d, &r[w])) die("renderer");
        run[w] = (orbit_run){.ms = calloc((size_t)frames, sizeof(double)),
                             .hash = calloc((size_t)frames, sizeof(uint32_t))};
        /* the warm-up frame, drawn the row's way: the orbit's start (its splat sets, buffers,
         * the first seen faces) */
        const crisp_frame_plan *plan;
        if (w == 0 && (crisp_planner_plan(crisp_renderer_planner(r[0]), sc, base, &plan) ||
                       crisp_render_cpu_plan(r[0], sc, plan, base, &img, NULL)))
            die("warm-up");
        if (w == 1 && crisp_render_cpu(r[1], sc, base, &img, NULL)) die("warm-up");
    }
    orbit(r[0], sc, cams, frames, 0, &img, &run[0]);
    orbit(r[1], sc, cams, frames, 1, &img, &run[1]);
    int same = !memcmp(run[0].hash, run[1].hash, (size_t)frames * sizeof(uint32_t));
    double med[2];
    for (int w = 0; w < 2; w++)
        med[w] = bench_median(run[w].ms, frames);
    printf("| %s | %s | %d | %.1f | %.1f | %.1f | %.1f | %.1f | %.3f | %.1f | %llu | %llu | %08x | "
           "%s |\n",
           name, view, frames, step, med[0], med[1], run[0].cpu / frames, run[1].cpu / frames,
           run[1].cpu / run[0].cpu, (double)run[1].hidden / frames,
           (unsigned long long)(run[0].triangles / (uint64_t)frames),
           (unsigned long long)(run[1].triangles / (uint64_t)frames), (unsigned)run[1].hash[0],
           same ? "same" : "DIFFERENT");
    fflush(stdout);
    for (int w = 0; w < 2; w++) {
        crisp_renderer_destroy(r[w]);
        free(run[w].ms);
        free(run[w].hash);
    }
    crisp_image_free(&img);
    free(cams);
    if (!same) {
        fprintf(stderr, "bench_orbit: %s %s: the two ways drew different images\n", name, view);
        exit(1);
    }
}

static int wanted(int argc, char **argv, const char *model, const char *view)
{
    static const char *const dflt[] = {"impeller.igs:close", "occt_as1_ec.stp:close",
                                       "occt_bearing.iges:close"};
    char key[300];
    snprintf(key, sizeof key, "%.255s:%.15s", model, view);
    if (argc <= 3) {
        for (size_t k = 0; k < sizeof dflt / sizeof *dflt; k++)
            if (!strcmp(key, dflt[k])) return 1;
        return 0;
    }
    for (int a = 3; a < argc; a++)
        if (strstr(key, argv[a])) return 1;
    return 0;
}

int main(int argc, char **argv)
{
    int frames = argc > 1 ? atoi(argv[1]) : 24;
    int threads = argc > 2 ? atoi(argv[2]) : 2;
    double step = getenv("BENCH_ORBIT_STEP") ? atof(getenv("BENCH_ORBIT_STEP")) : 2.0;
    if (frames < 1) frames = 1;
    if (threads < 1) threads = 1;
    char dir[512], models[64][256];
    snprintf(dir, sizeof dir, "%s/nurbs", CRISP_DATA_DIR);
    int model_count = bench_list_files(dir, models, 64);
    bench_print_machine(stdout);
    double la = bench_load_average();
    printf("load average %.2f at the start; 1920x1080, 1 sample, %d threads, an orbit of %d "
           "frames after a warm-up frame\n\n",
           la, threads, frames);
    printf("| model | view | frames | step deg | plan+draw ms | stages ms | plan+draw CPU ms | "
           "stages CPU ms | CPU ratio | hidden faces / frame | triangles (plan) | triangles "
           "(stages) | first hash | images |\n");
    printf("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|\n");
    fflush(stdout);
    for (int m = 0; m < model_count; m++) {
        static const char *const views[3] = {"default", "close", "zoom"};
        int any = 0;
        for (int v = 0; v < 3; v++)
            any |= wanted(argc, argv, models[m], views[v]);
        if (!any) continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/nurbs/%.255s", CRISP_DATA_DIR, models[m]);
        crisp_model *model;
        if (crisp_model_load(path, NULL, &model)) die(path);
        crisp_scene *sc;
        if (crisp_scene_prepare(model, &sc)) die("scene");
        crisp_camera cams[3];
        if (crisp_camera_frame_box(sc->box, 1920, 1080, &cams[0])) die("camera");
        cams[1] = bench_close_up(sc, &cams[0]);
        cams[2] = bench_zoom(sc, &cams[0], 1e4);
        for (int v = 0; v < 3; v++)
            if (wanted(argc, argv, models[m], views[v]))
                run_row(models[m], views[v], sc, &cams[v], frames, threads, step);
        crisp_scene_destroy(sc);
        crisp_model_destroy(model);
    }
    return 0;
}
