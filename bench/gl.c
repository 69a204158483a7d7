/* bench_gl: the GL backend (include/crisp/gl.h) against the CPU backend on the same frame plans
 * (issue 9): every bundled model at 1920x1080 with the default camera and with a close-up whose
 * surface fills the screen (the default camera's centre ray hit point seen with a 1/8 field of
 * view), median frame times of both backends measured in the same run and their ratio; then the
 * trim-editing case: one face's trim loops move, the planner re-plans that face only, and the GL
 * backend uploads the arrays whose version changed (bytes per frame against the whole plan).
 * Times are wall clock (the GL frame ends with glFinish; llvmpipe uses every core).
 *
 *   bench_gl [FRAMES [MODEL]]   (default 5 frames, every model; MODEL: only names containing it)
 *
 * Splats (issue 12): `bench_gl FRAMES splats [ROWS...]` draws bench_screen's far views (rows
 * imp49:far, imp:far10, imp49:default; impeller.igs instanced 7 x 7, the default camera from 12x
 * its distance, imp alone from 10x) with the default planner (faces drawn as splats where the plan
 * says) and with crisp_planner_desc.no_splats, one after the other: plan, CPU and GL frame times
 * (median wall time; the process's CPU time per frame, all threads, llvmpipe's included), the
 * splats drawn, the store's bytes (uploaded by the first frame only) and the bytes uploaded per
 * later frame, and the pixels whose face differs between the two backends. */
#include <sys/resource.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_camera.h"
#include "bench_scenes.h"
#include "bench_util.h"
#include "crisp/gl.h"
#include "crisp/io.h"
#include "crisp/plan.h"
#include "crisp/render.h"

/* Every bundled model: the files of data/nurbs, sorted by name. */
static char models[64][256];
static int model_count;

static void die(const char *what)
{
    fprintf(stderr, "bench_gl: %s: %s\n", what, crisp_error_message());
    exit(1);
}

typedef struct result {
    double cpu_ms, gl_ms, read_ms;
    uint64_t upload, plan_bytes, triangles;
    uint32_t leaves, quads;
    long covered;
} result;

static void run_view(crisp_renderer *r, crisp_gl *gl, const crisp_scene *sc,
                     const crisp_camera *cam, int frames, result *res)
{
    const crisp_frame_plan *plan;
    if (crisp_planner_plan(crisp_renderer_planner(r), sc, cam, &plan)) die("plan");
    crisp_image img;
    if (crisp_image_init(&img, cam->width, cam->height)) die("image");
    double *t = malloc(sizeof(double) * (size_t)(frames + 1));
    /* CPU: warm-up, then frames */
    for (int f = 0; f <= frames; f++) {
        double t0 = crisp_time_now();
        if (crisp_render_cpu_plan(r, sc, plan, cam, &img, NULL)) die("cpu frame");
        t[f] = 1e3 * (crisp_time_now() - t0);
    }
    res->cpu_ms = bench_median(t + 1, frames);
    /* GL: the first frame uploads the plan; later frames draw the same plan */
    crisp_gl_stats gs;
    crisp_gl_forget_plan(gl);
    if (crisp_gl_set_scene(gl, sc)) die("gl scene");
    for (int f = 0; f <= frames; f++) {
        double t0 = crisp_time_now();
        if (crisp_gl_draw(gl, plan, &gs)) die("gl frame");
        t[f] = 1e3 * (crisp_time_now() - t0);
        if (f == 0) res->upload = gs.bytes_uploaded;
    }
    res->gl_ms = bench_median(t + 1, frames);
    if (getenv("PROFILE"))
        fprintf(stderr, "  surfaces %.1f ms, ribbons %.1f ms, resolve %.1f ms\n", gs.ms_surfaces,
                gs.ms_ribbons, gs.ms_resolve);
    if (crisp_gl_read(gl, &img, &gs)) die("gl read");
    res->read_ms = gs.ms_read;
    res->covered = 0;
    for (size_t k = 0; k < (size_t)cam->width * cam->height; k++)
        res->covered += img.face[k] >= 0;
    res->plan_bytes = crisp_plan_bytes(plan);
    res->triangles = plan->stats.triangles;
    res->leaves = plan->leaf_count;
    res->quads = plan->ribbon_quad_count;
    crisp_image_free(&img);
    free(t);
}

/* The trim-editing case: shrink face f's loops by 0.1% towards their first point, re-plan it. */
static void edit_trim(crisp_model *m, int f)
{
    crisp_face *face = &m->faces[f];
    for (int l = 0; l < face->loop_count; l++)
        for (int c = 0; c < face->loops[l].curve_count; c++) {
            crisp_curve *cv = face->loops[l].curves[c];
            double cu = face->loops[0].curves[0]->cpw[0] / face->loops[0].curves[0]->cpw[2];
            double cvv = face->loops[0].curves[0]->cpw[1] / face->loops[0].curves[0]->cpw[2];
            for (int k = 0; k < cv->count; k++) {
                double *p = cv->cpw + 3 * k;
                p[0] = cu * p[2] + 0.999 * (p[0] - cu * p[2]);
                p[1] = cvv * p[2] + 0.999 * (p[1] - cvv * p[2]);
            }
        }
}

/* ---- splats ---------------------------------------------------------------------------------- */

/* bench_screen's cameras: "default", "far" (12x the distance), "farN" (N times). */
static crisp_camera far_camera(const crisp_scene *sc, const char *which)
{
    crisp_camera cam;
    if (crisp_camera_frame_box(sc->box, 1920, 1080, &cam)) die("camera");
    if (strncmp(which, "far", 3)) return cam;
    double d[3];
    for (int k = 0; k < 3; k++)
        d[k] = cam.eye[k] - cam.target[k];
    double dist = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double f = which[3] ? atof(which + 3) : 12;
    for (int k = 0; k < 3; k++)
        cam.eye[k] = cam.target[k] + f * d[k];
    cam.zfar = (f + 2) * dist + (sc->box[5] - sc->box[2]);
    return cam;
}

static void splat_row(crisp_gl *gl, const char *scene_name, const char *cam_name, int frames)
{
    int n = strcmp(scene_name, "imp49") ? 1 : 7;
    crisp_model *m = bench_instanced("impeller.igs", n, n, die);
    crisp_scene *sc;
    if (crisp_scene_prepare(m, &sc)) die("prepare");
    crisp_camera cam = far_camera(sc, cam_name);
    crisp_renderer *r;
    if (crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r)) die("renderer");
    crisp_image a, b;
    if (crisp_image_init(&a, cam.width, cam.height) || crisp_image_init(&b, cam.width, cam.height))
        die("image");
    double *t = malloc(sizeof(double) * (size_t)(frames + 1));
    for (int v = 0; v < 2; v++) {
        crisp_planner *pl;
        if (crisp_planner_create(&(crisp_planner_desc){.no_splats = v}, NULL, &pl)) die("planner");
        const crisp_frame_plan *plan = NULL;
        /* plan: a warm-up (builds the splat sets), then frames */
        for (int f = 0; f <= frames; f++) {
            double t0 = crisp_time_now();
            if (crisp_planner_plan(pl, sc, &cam, &plan)) die("plan");
            t[f] = 1e3 * (crisp_time_now() - t0);
        }
        double plan_ms = bench_median(t + 1, frames);
        for (int f = 0; f <= frames; f++) {
            double t0 = crisp_time_now();
            if (crisp_render_cpu_plan(r, sc, plan, &cam, &a, NULL)) die("cpu frame");
            t[f] = 1e3 * (crisp_time_now() - t0);
        }
        double cpu_frame = bench_median(t + 1, frames);
        crisp_gl_stats gs;
        crisp_gl_forget_plan(gl);
        if (crisp_gl_set_scene(gl, sc)) die("gl scene");
        uint64_t first_upload = 0, later_upload = 0;
        double c0 = 0;
        for (int f = 0; f <= frames; f++) {
            if (f == 1) c0 = bench_cpu_ms();
            double t0 = crisp_time_now();
            if (crisp_gl_draw(gl, plan, &gs)) die("gl frame");
            t[f] = 1e3 * (crisp_time_now() - t0);
            if (f == 0)
                first_upload = gs.bytes_uploaded;
            else
                later_upload = gs.bytes_uploaded;
        }
        double gl_cpu = (bench_cpu_ms() - c0) / frames;
        if (getenv("PROFILE"))
            fprintf(stderr,
                    "  %s:%s %s: surfaces %.1f ms, splats %.1f ms, ribbons %.1f ms, "
                    "resolve %.1f ms (last frame)\n",
                    scene_name, cam_name, v ? "no_splats" : "splats", gs.ms_surfaces, gs.ms_splats,
                    gs.ms_ribbons, gs.ms_resolve);
        double gl_frame = bench_median(t + 1, frames);
        if (crisp_gl_read(gl, &b, &gs)) die("gl read");
        long covered = 0, differ = 0;
        for (size_t k = 0; k < (size_t)cam.width * cam.height; k++) {
            covered += b.face[k] >= 0;
            differ += a.face[k] != b.face[k];
        }
        printf("| %s:%s | %s | %u | %llu | %u | %llu | %.1f | %llu | %llu | %.1f | %.1f | %.1f | "
               "%.1f | %ld | %ld | %08x | %08x |\n",
               scene_name, cam_name, v ? "no_splats" : "splats", plan->leaf_count,
               (unsigned long long)plan->stats.triangles, plan->stats.splat_faces,
               (unsigned long long)plan->stats.splats_drawn,
               (double)plan->splat_count * sizeof(crisp_plan_splat) / 1e6,
               (unsigned long long)first_upload, (unsigned long long)later_upload, plan_ms,
               cpu_frame, gl_frame, gl_cpu, covered, differ, (unsigned)bench_image_hash(&a),
               (unsigned)bench_image_hash(&b));
        fflush(stdout);
        crisp_planner_destroy(pl);
    }
    free(t);
    crisp_image_free(&a);
    crisp_image_free(&b);
    crisp_renderer_destroy(r);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

static int splat_bench(crisp_gl *gl, int frames, int argc, char **argv)
{
    printf("| row | planner | leaves | triangles | splat faces | splats drawn | store MB | first "
           "upload B | upload B per frame | plan ms | CPU frame ms | GL frame ms | GL CPU ms per "
           "frame | covered px (GL) | face differs CPU/GL px | CPU image hash | GL image hash |\n");
    printf("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|\n");
    static const char *const rows[] = {"imp49:far", "imp:far10", "imp49:default"};
    for (size_t k = 0; k < sizeof rows / sizeof *rows; k++) {
        int wanted = argc <= 3;
        for (int a = 3; a < argc; a++)
            wanted |= !strcmp(argv[a], rows[k]);
        if (!wanted) continue;
        char name[64];
        snprintf(name, sizeof name, "%s", rows[k]);
        char *colon = strchr(name, ':');
        *colon = 0;
        splat_row(gl, name, colon + 1, frames);
    }
    return 0;
}

int main(int argc, char **argv)
{
    int frames = argc > 1 ? atoi(argv[1]) : 5;
    if (frames < 1) frames = 1;
    int splats = argc > 2 && !strcmp(argv[2], "splats");
    char dir[512];
    snprintf(dir, sizeof dir, "%s/nurbs", CRISP_DATA_DIR);
    model_count = bench_list_files(dir, models, 64);
    crisp_gl_context *ctx;
    if (crisp_gl_context_create(&ctx)) die("GL context");
    crisp_gl *gl;
    if (crisp_gl_create(crisp_gl_context_getproc(ctx),
                        &(crisp_gl_desc){.profile = getenv("PROFILE") != NULL}, &gl))
        die("GL backend");
    bench_print_machine(stdout);
    printf("GL: %s; load average %.2f at the start; 1920x1080, 1 sample, median of %d frames after "
           "one\n\n",
           crisp_gl_renderer(gl), bench_load_average(), frames);
    if (splats) {
        int rc = splat_bench(gl, frames, argc, argv);
        crisp_gl_destroy(gl);
        crisp_gl_context_destroy(ctx);
        return rc;
    }
    printf("| model | view | leaves | triangles | ribbon quads | plan bytes | CPU ms | GL ms | "
           "GL/CPU | read-back ms |\n");
    printf("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    crisp_renderer *r;
    if (crisp_renderer_create(NULL, &r)) die("renderer");
    for (size_t m = 0; m < (size_t)model_count; m++) {
        if (argc > 2 && !strstr(models[m], argv[2])) continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, models[m]);
        crisp_model *model;
        if (crisp_model_load(path, NULL, &model)) die(path);
        crisp_scene *sc;
        if (crisp_scene_prepare(model, &sc)) die("scene");
        crisp_camera cams[2];
        if (crisp_camera_frame_box(sc->box, 1920, 1080, &cams[0])) die("camera");
        cams[1] = bench_close_up(sc, &cams[0]);
        for (int v = 0; v < 2; v++) {
            result res;
            run_view(r, gl, sc, &cams[v], frames, &res);
            printf("| %s | %s | %u | %llu | %u | %llu | %.1f | %.1f | %.2f | %.1f |\n", models[m],
                   v ? "close-up" : "default", res.leaves, (unsigned long long)res.triangles,
                   res.quads, (unsigned long long)res.plan_bytes, res.cpu_ms, res.gl_ms,
                   res.gl_ms / res.cpu_ms, res.read_ms);
            fflush(stdout);
        }
        crisp_scene_destroy(sc);
        crisp_model_destroy(model);
    }

    if (argc > 2 && !strstr("impeller.igs", argv[2])) return 0;
    /* Trim editing on impeller.igs: the face with the most trim pieces among the visible ones. */
    printf("\nTrim editing (impeller.igs, default camera): one face's loops change, "
           "crisp_planner_replan_face, "
           "crisp_gl_draw uploads what changed\n\n");
    char path[1024];
    snprintf(path, sizeof path, "%s/nurbs/impeller.igs", CRISP_DATA_DIR);
    crisp_model *model;
    crisp_scene *sc;
    if (crisp_model_load(path, NULL, &model) || crisp_scene_prepare(model, &sc)) die("impeller");
    crisp_camera cam;
    if (crisp_camera_frame_box(sc->box, 1920, 1080, &cam)) die("camera");
    crisp_planner *pl;
    if (crisp_planner_create(NULL, NULL, &pl)) die("planner");
    const crisp_frame_plan *plan;
    if (crisp_planner_plan(pl, sc, &cam, &plan)) die("plan");
    uint32_t face = 0, best = 0;
    for (uint32_t f = 0; f < sc->face_count; f++)
        if ((plan->faces[f].flags & CRISP_PLAN_FACE_VISIBLE) && sc->faces[f].piece_count > best &&
            model->faces[f].loop_count)
            best = sc->faces[f].piece_count, face = f;
    crisp_gl_stats gs;
    crisp_gl_forget_plan(gl);
    if (crisp_gl_set_scene(gl, sc) || crisp_gl_draw(gl, plan, &gs)) die("gl frame");
    uint64_t first = gs.bytes_uploaded;
    double *t = malloc(sizeof(double) * (size_t)frames),
           *tr = malloc(sizeof(double) * (size_t)frames);
    uint64_t bytes = 0;
    for (int f = 0; f < frames; f++) {
        edit_trim(model, (int)face);
        double t0 = crisp_time_now();
        if (crisp_scene_update_trim(sc, face) || crisp_planner_replan_face(pl, sc, face, &plan))
            die("replan");
        double t1 = crisp_time_now();
        if (crisp_gl_draw(gl, plan, &gs)) die("gl frame");
        tr[f] = 1e3 * (t1 - t0);
        t[f] = 1e3 * (crisp_time_now() - t1);
        bytes = gs.bytes_uploaded;
    }
    size_t leaves_b = (size_t)plan->leaf_count * sizeof(crisp_plan_leaf);
    size_t table_b = (size_t)plan->strip_count * sizeof(crisp_plan_strip) +
                     ((size_t)plan->row_count + 1) * 4 + (size_t)plan->crossing_count * 8;
    size_t ribbon_b = (size_t)plan->ribbon_quad_count * 4 * sizeof(crisp_plan_ribbon_vertex);
    printf("| face | its trim pieces | plan bytes | first frame upload | upload per edit | of "
           "which leaves | "
           "trim tables | ribbons | faces | update + re-plan ms | GL frame ms |\n");
    printf("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    printf("| %u | %u | %zu | %llu | %llu | 0 (unchanged: %zu) | %zu | %zu | %zu | %.2f | %.1f |\n",
           face, best, crisp_plan_bytes(plan), (unsigned long long)first, (unsigned long long)bytes,
           leaves_b, table_b, ribbon_b, (size_t)plan->face_count * sizeof(crisp_plan_face),
           bench_median(tr, frames), bench_median(t, frames));
    free(t);
    free(tr);
    crisp_planner_destroy(pl);
    crisp_scene_destroy(sc);
    crisp_model_destroy(model);
    crisp_renderer_destroy(r);
    crisp_gl_destroy(gl);
    crisp_gl_context_destroy(ctx);
    return 0;
}
