/* bench_render: the CPU backend's frame on the bundled models (docs/design.md section 2): the plan
 * alone (tess levels, edge levels, trim plans: what the trim-editing demo redoes every frame) and
 * plan + tessellate + rasterise + resolve, at 1920x1080, one thread and all threads, median of
 * repeated frames after one warm-up frame (the warm-up allocates; later frames reuse buffers).
 * Also the plan of impeller.igs and of a scene instancing it to over 32,000 Bézier patches (the
 * size of the largest model in Wu & Peters 2015), with the time of each stage.
 *
 *   bench_render [FRAMES]          (default 10) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "crisp/io.h"
#include "crisp/render.h"

static crisp_model *load(const char *name)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, name);
    crisp_model *m = NULL;
    if (crisp_model_load(path, NULL, &m)) {
        fprintf(stderr, "bench_render: %s\n", crisp_error_message());
        exit(1);
    }
    return m;
}

/* Copies of every face of src, translated by k * step along x, appended to dst. */
static void instance(crisp_model *dst, const crisp_model *src, int copies, double step)
{
    for (int k = 0; k < copies; k++)
        for (int f = 0; f < src->face_count; f++) {
            const crisp_face *sf = &src->faces[f];
            crisp_face face = *sf;
            if (crisp_surface_copy(sf->surface, &face.surface)) exit(1);
            crisp_surface *s = face.surface;
            for (int i = 0; i < s->count_u * s->count_v; i++)
                s->cpw[4 * i] += k * step * s->cpw[4 * i + 3];
            face.loops = calloc((size_t)sf->loop_count, sizeof *face.loops);
            for (int l = 0; l < sf->loop_count; l++) {
                face.loops[l] = sf->loops[l];
                face.loops[l].curves =
                    calloc((size_t)sf->loops[l].curve_count, sizeof(crisp_curve *));
                for (int c = 0; c < sf->loops[l].curve_count; c++)
                    if (crisp_curve_copy(sf->loops[l].curves[c], &face.loops[l].curves[c])) exit(1);
            }
            if (crisp_model_add_face(dst, &face)) exit(1);
        }
}

typedef struct result {
    double plan, frame, levels, edges, trim, tess, raster, resolve;
    crisp_render_stats st;
} result;

static result run(const crisp_scene *sc, const crisp_camera *cam, int threads, int frames, int full)
{
    crisp_renderer *r;
    if (crisp_renderer_create(&(crisp_render_desc){.threads = threads}, &r)) {
        fprintf(stderr, "bench_render: %s\n", crisp_error_message());
        exit(1);
    }
    crisp_image img;
    crisp_image_init(&img, cam->width, cam->height);
    double *t[8];
    for (int k = 0; k < 8; k++)
        t[k] = calloc((size_t)frames, sizeof(double));
    result res = {0};
    for (int f = -1; f < frames; f++) {
        crisp_render_stats st;
        double a = crisp_time_now();
        if (crisp_renderer_plan(r, sc, cam, &st)) {
            fprintf(stderr, "bench_render: %s\n", crisp_error_message());
            exit(1);
        }
        double b = crisp_time_now();
        if (full && crisp_render_cpu(r, sc, cam, &img, &st)) {
            fprintf(stderr, "bench_render: %s\n", crisp_error_message());
            exit(1);
        }
        double c = crisp_time_now();
        if (f < 0) continue;
        t[0][f] = 1e3 * (b - a);
        t[1][f] = 1e3 * (c - b);
        t[2][f] = st.ms_levels, t[3][f] = st.ms_edges, t[4][f] = st.ms_trim;
        t[5][f] = st.ms_tess, t[6][f] = st.ms_raster, t[7][f] = st.ms_resolve;
        res.st = st;
    }
    res.plan = bench_median(t[0], frames);
    res.frame = bench_median(t[1], frames);
    res.levels = bench_median(t[2], frames);
    res.edges = bench_median(t[3], frames);
    res.trim = bench_median(t[4], frames);
    res.tess = bench_median(t[5], frames);
    res.raster = bench_median(t[6], frames);
    res.resolve = bench_median(t[7], frames);
    for (int k = 0; k < 8; k++)
        free(t[k]);
    crisp_image_free(&img);
    crisp_renderer_destroy(r);
    return res;
}

int main(int argc, char **argv)
{
    int frames = argc > 1 ? atoi(argv[1]) : 10;
    if (frames < 1) frames = 1;
    int all = crisp_pool_default_threads();
    bench_print_machine(stdout);
    printf("1920x1080, default camera (the model's box, fov 30), median of %d frames after a "
           "warm-up\n\n",
           frames);

    printf("| model | threads | patches drawn | triangles | table rows | table KiB | plan ms | "
           "frame ms (plan+tess+raster+resolve) | levels | edges | trim | tess | raster | resolve "
           "|\n");
    printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    const char *models[] = {"gpucast_part.igs", "occt_bearing.iges"};
    for (int mi = 0; mi < 2; mi++) {
        crisp_model *m = load(models[mi]);
        crisp_scene *sc;
        crisp_scene_prepare(m, &sc);
        crisp_camera cam;
        crisp_camera_frame_box(sc->box, 1920, 1080, &cam);
        int tl[2] = {1, all};
        for (int ti = 0; ti < (all > 1 ? 2 : 1); ti++) {
            result r = run(sc, &cam, tl[ti], frames, 1);
            /* The frame's own stage times (the plan inside the frame is measured again). */
            printf("| %s | %d | %u | %llu | %llu | %.1f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f "
                   "| %.2f | %.2f |\n",
                   models[mi], tl[ti], r.st.visible_patches, (unsigned long long)r.st.triangles,
                   (unsigned long long)r.st.table_rows, r.st.table_bytes / 1024.0, r.plan, r.frame,
                   r.levels, r.edges, r.trim, r.tess, r.raster, r.resolve);
        }
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
    }

    printf("\nPlan alone (the per-frame work), 1920x1080, default camera:\n\n");
    printf("| scene | Bézier patches | threads | patches drawn | leaves | table rows | plan ms | "
           "levels | edges | trim |\n");
    printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    crisp_model *imp = load("impeller.igs");
    crisp_model *big;
    crisp_model_create(&big);
    double box[6];
    crisp_model_bbox(imp, box);
    instance(big, imp, 7, 1.1 * (box[3] - box[0]));
    crisp_model *scenes[2] = {imp, big};
    const char *names[2] = {"impeller.igs", "impeller x 7 (instanced)"};
    for (int si = 0; si < 2; si++) {
        crisp_scene *sc;
        crisp_scene_prepare(scenes[si], &sc);
        crisp_camera cam;
        crisp_camera_frame_box(sc->box, 1920, 1080, &cam);
        int tl[2] = {1, all};
        for (int ti = 0; ti < (all > 1 ? 2 : 1); ti++) {
            result r = run(sc, &cam, tl[ti], frames, 0);
            printf("| %s | %u | %d | %u | %u | %llu | %.2f | %.2f | %.2f | %.2f |\n", names[si],
                   sc->patch_count, tl[ti], r.st.visible_patches, r.st.leaves,
                   (unsigned long long)r.st.table_rows, r.plan, r.levels, r.edges, r.trim);
        }
        crisp_scene_destroy(sc);
    }
    crisp_model_destroy(big);
    crisp_model_destroy(imp);
    printf(
        "\nTargets (rendering issue): plan + rasterize gpucast_part and occt_bearing at 1920x1080 "
        "under 100 ms, the plan alone under 10 ms.\n");
    return 0;
}
