/* bench_interactive: issue 12's interactive targets, stage by stage. Every bundled model
 * (data/nurbs) at 1920x1080, 1 sample per pixel, with the default camera (crisp_camera_frame_box)
 * with a close-up whose surface fills the screen (the default camera's centre-ray hit point
 * seen with a 1/8 field of view, as bench_gl) and with an extreme zoom (view "zoom": the visible
 * trim curve point nearest that hit point at 1/10,000 of the default field of view:
 * bench_camera.h). Per row, medians of FRAMES warm frames (after one
 * warm-up frame) on THREADS threads: the plan (crisp_planner_plan), the CPU backend's stages
 * (tessellate, rasterise, resolve and shade: crisp_render_stats), the whole frame (plan + draw),
 * the process CPU time per frame (all threads; fairer than wall time on a shared machine), the
 * triangles, covered pixels and triangles per covered pixel, the fragments that ran the trim
 * lookup, and the lookups' estimated time (the lookups of the image's own samples replayed and
 * timed on one thread, scaled to the frame's count and divided by the threads), and a hash of
 * the image and its AOVs (equal hashes across builds: the same picture).
 *
 *   bench_interactive [FRAMES [THREADS [MODEL...]]]   (defaults 5, 2, every model; MODEL: only
 *                                                      rows whose "model:view" contains it,
 *                                                      e.g. bearing or bearing.iges:close)
 *
 * Occlusion culling (crisp_render_desc.no_occlusion) is on; BENCH_OCCLUSION=off runs it off,
 * BENCH_OCCLUSION=both runs every row off and then on (the same image hash expected).
 * BENCH_SPLATS=off: no face drawn as splats (crisp_render_desc.no_splats; issue 12, session 9).
 * BENCH_INTERACTIVE_PNG=folder writes each row's image there (MODEL_VIEW.png).
 * BENCH_INTERACTIVE_STAGES=1 also prints each row's plan stages (levels, edges, trim, ribbons)
 * to stderr. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "bench_camera.h"
#include "bench_image.h"
#include "bench_util.h"
#include "crisp/io.h"
#include "crisp/plan.h"
#include "crisp/render.h"

static char models[64][256];
static int model_count;

static void die(const char *what)
{
    fprintf(stderr, "bench_interactive: %s: %s\n", what, crisp_error_message());
    exit(1);
}

/* The trim lookups of the image's covered pixels (faces with trim loops), replayed and timed:
 * ms per lookup. */
static double lookup_ms_each(const crisp_frame_plan *plan, const crisp_image *img)
{
    size_t n = (size_t)img->width * img->height, m = 0;
    uint32_t *face = malloc(n * sizeof *face);
    double *uv = malloc(2 * n * sizeof *uv);
    for (size_t p = 0; p < n; p++) {
        int32_t f = img->face[p];
        if (f < 0 || (plan->faces[f].flags & CRISP_PLAN_FACE_ALL_INSIDE)) continue;
        face[m] = (uint32_t)f;
        uv[2 * m] = img->uv[2 * p];
        uv[2 * m + 1] = img->uv[2 * p + 1];
        m++;
    }
    double each = 0;
    if (m) {
        volatile int sink = 0;
        double t0 = crisp_time_now();
        for (int rep = 0; rep < 3; rep++)
            for (size_t k = 0; k < m; k++)
                sink += crisp_plan_trim_test(plan, face[k], uv[2 * k], uv[2 * k + 1]);
        each = 1e3 * (crisp_time_now() - t0) / (3.0 * (double)m);
        (void)sink;
    }
    free(face);
    free(uv);
    return each;
}

static void run_view(const char *name, const char *view, const crisp_scene *sc,
                     const crisp_camera *cam, int frames, int threads, int occlusion)
{
    crisp_renderer *r;
    if (crisp_renderer_create(
            &(crisp_render_desc){.threads = threads,
                                 .samples = 1,
                                 .no_occlusion = !occlusion,
                                 .no_splats = getenv("BENCH_SPLATS") &&
                                              !strcmp(getenv("BENCH_SPLATS"), "off")},
            &r))
        die("renderer");
    crisp_image img;
    if (crisp_image_init(&img, cam->width, cam->height)) die("image");
    double *t[6];
    for (int k = 0; k < 6; k++)
        t[k] = calloc((size_t)frames, sizeof(double));
    double cpu = 0;
    crisp_render_stats st = {0};
    const crisp_frame_plan *plan = NULL;
    /* The frame as crisp_render_cpu draws it (with occlusion culling: the plan in two stages, the
     * faces that the near ones hide not planned); BENCH_INTERACTIVE_SPLIT=1: crisp_planner_plan
     * then crisp_render_cpu_plan (the whole plan first, as before session 13). The plan column
     * is crisp_planner_plan's time, or with crisp_render_cpu the plan's stages (levels, edges,
     * trim and ribbons: the plan's own stats, without the lay-out of its arrays). */
    int split = getenv("BENCH_INTERACTIVE_SPLIT") && atoi(getenv("BENCH_INTERACTIVE_SPLIT"));
    for (int f = -1; f < frames; f++) {
        double c0 = bench_cpu_ms(), a = crisp_time_now(), b = a;
        if (split) {
            if (crisp_planner_plan(crisp_renderer_planner(r), sc, cam, &plan)) die("plan");
            b = crisp_time_now();
            if (crisp_render_cpu_plan(r, sc, plan, cam, &img, &st)) die("frame");
        } else if (crisp_render_cpu(r, sc, cam, &img, &st)) {
            die("frame");
        }
        double c = crisp_time_now();
        if (f < 0) continue;
        cpu += bench_cpu_ms() - c0;
        t[0][f] = split ? 1e3 * (b - a) : st.ms_levels + st.ms_edges + st.ms_trim;
        t[1][f] = st.ms_tess;
        t[2][f] = st.ms_raster;
        t[3][f] = st.ms_resolve;
        t[4][f] = 1e3 * (c - a);
    }
    /* The plan of the last frame's camera, for the lookups and the stages below. */
    if (!split && crisp_planner_plan(crisp_renderer_planner(r), sc, cam, &plan)) die("plan");
    if (getenv("BENCH_INTERACTIVE_STAGES")) /* the plan's own stages (last frame) */
        fprintf(stderr, "%s %s: plan levels %.1f edges %.1f trim %.1f ribbons %.1f ms\n", name,
                view, plan->stats.ms_levels, plan->stats.ms_edges, plan->stats.ms_trim,
                plan->stats.ms_ribbons);
    if (getenv("BENCH_INTERACTIVE_STAGES")) /* the draw's counts (last frame) */
        fprintf(stderr,
                "%s %s: faces visible %u, hidden before planning %u, leaves %llu, vertices %llu, "
                "ribbon triangles %llu, fragments tested %llu, trimmed %llu\n",
                name, view, st.visible_faces, st.hidden_faces, (unsigned long long)st.leaves,
                (unsigned long long)st.vertices, (unsigned long long)st.ribbon_triangles,
                (unsigned long long)st.fragments_tested, (unsigned long long)st.fragments_trimmed);
    const char *png = getenv("BENCH_INTERACTIVE_PNG"); /* a folder: look at what each row draws */
    if (png) {
        char path[1200];
        snprintf(path, sizeof path, "%s/%s_%s.png", png, name, view);
        if (bench_write_png(path, &img)) die(path);
    }
    size_t covered = 0;
    for (size_t p = 0; p < (size_t)img.width * img.height; p++)
        covered += img.face[p] >= 0;
    double lookup_ms = lookup_ms_each(plan, &img) * (double)st.fragments_tested / threads;
    printf("| %s | %s | %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %llu | %llu | %zu | "
           "%.2f | %llu | %.1f | %08x |\n",
           name, view, occlusion ? "on" : "off", bench_median(t[0], frames),
           bench_median(t[1], frames), bench_median(t[2], frames), bench_median(t[3], frames),
           bench_median(t[4], frames), cpu / frames, lookup_ms, (unsigned long long)st.triangles,
           (unsigned long long)st.occluded_triangles, covered,
           covered ? (double)st.triangles / covered : 0.0, (unsigned long long)st.fragments_tested,
           100.0 * covered / (cam->width * cam->height), (unsigned)bench_image_hash(&img));
    fflush(stdout);
    for (int k = 0; k < 6; k++)
        free(t[k]);
    crisp_image_free(&img);
    crisp_renderer_destroy(r);
}

/* A row is run when no MODEL argument is given or one is part of "model:view". */
static int wanted(int argc, char **argv, const char *model, const char *view)
{
    if (argc <= 3) return 1;
    char key[300];
    snprintf(key, sizeof key, "%.255s:%.15s", model, view);
    for (int a = 3; a < argc; a++)
        if (strstr(key, argv[a])) return 1;
    return 0;
}

int main(int argc, char **argv)
{
    int frames = argc > 1 ? atoi(argv[1]) : 5;
    int threads = argc > 2 ? atoi(argv[2]) : 2;
    if (frames < 1) frames = 1;
    if (threads < 1) threads = 1;
    const char *oe = getenv("BENCH_OCCLUSION");
    int occl_mode = oe && !strcmp(oe, "off") ? 0 : oe && !strcmp(oe, "both") ? 2 : 1;
    char dir[512];
    snprintf(dir, sizeof dir, "%s/nurbs", CRISP_DATA_DIR);
    model_count = bench_list_files(dir, models, 64);
    bench_print_machine(stdout);
    printf("load average %.2f at the start; 1920x1080, 1 sample, %d threads, median of %d warm "
           "frames\n\n",
           bench_load_average(), threads, frames);
    printf("| model | view | occlusion | plan ms | tess ms | raster ms | resolve ms | frame ms | "
           "frame CPU ms | trim lookups ms (est.) | triangles | occluded tri | covered px | tri/px "
           "| lookups | cover %% | image hash |\n");
    printf("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n");
    fflush(stdout);
    for (int m = 0; m < model_count; m++) {
        if (!wanted(argc, argv, models[m], "default") && !wanted(argc, argv, models[m], "close") &&
            !wanted(argc, argv, models[m], "zoom"))
            continue;
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
        static const char *const views[3] = {"default", "close", "zoom"};
        for (int v = 0; v < 3; v++) {
            const char *view = views[v];
            if (!wanted(argc, argv, models[m], view)) continue;
            if (occl_mode != 1) run_view(models[m], view, sc, &cams[v], frames, threads, 0);
            if (occl_mode != 0) run_view(models[m], view, sc, &cams[v], frames, threads, 1);
        }
        crisp_scene_destroy(sc);
        crisp_model_destroy(model);
    }
    printf("\nload average %.2f at the end\n", bench_load_average());
    return 0;
}
