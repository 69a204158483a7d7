/* bench_occt: crisp beside Open CASCADE's BRepMesh on the same models and camera (rendering
 * issue, "Speed"; optional: built only where Open CASCADE is installed, bench/CMakeLists.txt).
 *
 * For occt_bearing.iges (sewn, as in data/README.md) and gpucast_part.igs, with the
 * camera bench_render uses (crisp_camera_frame_box of the scene's box at 1920x1080: looking
 * along -Z, +Y up, fov 30), it
 *  - takes the deflection that equals 0.5 px at the nearest visible point: the world size of
 *    half a pixel, z tan(fov/2) / H, at the smallest camera-space depth z of the scene's box
 *    (the box corner nearest the eye along the view axis, clamped to the near plane: a bound for
 *    every visible point of the model, since the box contains it);
 *  - meshes the model with BRepMesh_IncrementalMesh (parallel, 2 threads) at that deflection,
 *    and again at halved deflections (down to 1/8) until its worst screen error is within 0.5 px;
 *  - renders the same frame with crisp's CPU backend (2 threads) and reports its triangles and
 *    its plan + tessellation time;
 *  - measures both meshes' worst screen error the same way (crisp's surface-accuracy test,
 *    tests/render/test_cpu_render.c): at seven barycentric points of every triangle, the
 *    distance max(|dx|, |dy|) in pixels between the triangle's point and the true surface at the
 *    triangle's interpolated (u, v).
 *
 *   bench_occt [RUNS [ANGLE]]   RUNS: crisp frames and BRepMesh runs, medians (default 7);
 *                               ANGLE: BRepMesh's angular deflection in radians (default 0.5) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "bench_util.h"
#include "crisp/io.h"
#include "crisp/render.h"
#include "occt/occt_mesh.h"
#include "render/raster.h"
#include "render/render_internal.h"

#define WIDTH 1920
#define HEIGHT 1080
#define THREADS 2

typedef struct crisp_result {
    unsigned long long triangles, ribbon_triangles;
    unsigned visible_patches;
    double plan_tess_ms, plan_tess_min, plan_tess_max, frame_ms;
    double nearest_drawn; /* smallest depth in crisp's image: the nearest pixel centre's hit */
    double worst_px, worst_px_euclid;
    long long samples;
} crisp_result;

static void die(const char *what)
{
    fprintf(stderr, "bench_occt: %s: %s\n", what, crisp_error_message());
    exit(1);
}

/* Worst screen distance between crisp's drawn triangles and the surface at the interpolated
 * (u, v), as tests/render/test_cpu_render.c measures it. */
static void crisp_mesh_error(const crisp_renderer *r, const crisp_scene *sc,
                             const crisp_camera *cam, crisp_result *res)
{
    const crisp_raster_vertex *v;
    const crisp_raster_tri *t;
    size_t nv, nt;
    crisp__renderer_mesh(r, &v, &nv, &t, &nt);
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    static const double bary[7][3] = {{1. / 3, 1. / 3, 1. / 3},
                                      {.5, .5, 0},
                                      {0, .5, .5},
                                      {.5, 0, .5},
                                      {.7, .2, .1},
                                      {.1, .7, .2},
                                      {.2, .1, .7}};
    for (size_t k = 0; k < nt; k++) {
        const crisp_raster_vertex *a = &v[t[k].v[0]], *b = &v[t[k].v[1]], *c = &v[t[k].v[2]];
        if (a->clip[3] <= cam->znear || b->clip[3] <= cam->znear || c->clip[3] <= cam->znear)
            continue;
        const crisp_surface *surf = sc->faces[t[k].face].src->surface;
        for (int q = 0; q < 7; q++) {
            double cl[4], uv[2], P[3], tri[3], sc4[4], sp[3];
            for (int i = 0; i < 4; i++)
                cl[i] = bary[q][0] * a->clip[i] + bary[q][1] * b->clip[i] + bary[q][2] * c->clip[i];
            for (int i = 0; i < 2; i++)
                uv[i] = bary[q][0] * a->attr[i] + bary[q][1] * b->attr[i] + bary[q][2] * c->attr[i];
            crisp_camera_to_pixel(cam, cl, tri);
            if (tri[0] < -2 || tri[1] < -2 || tri[0] > cam->width + 2 || tri[1] > cam->height + 2)
                continue;
            crisp_surface_eval(surf, uv[0], uv[1], P);
            crisp_mat4_mulp(m.view_proj, P, sc4);
            crisp_camera_to_pixel(cam, sc4, sp);
            double dx = fabs(sp[0] - tri[0]), dy = fabs(sp[1] - tri[1]);
            if (fmax(dx, dy) > res->worst_px) res->worst_px = fmax(dx, dy);
            if (hypot(dx, dy) > res->worst_px_euclid) res->worst_px_euclid = hypot(dx, dy);
            res->samples++;
        }
    }
}

static crisp_result run_crisp(const crisp_scene *sc, const crisp_camera *cam, int runs)
{
    crisp_renderer *r;
    if (crisp_renderer_create(&(crisp_render_desc){.threads = THREADS}, &r)) die("renderer");
    crisp_image img;
    if (crisp_image_init(&img, cam->width, cam->height)) die("image");
    double *pt = calloc((size_t)runs, sizeof *pt), *fr = calloc((size_t)runs, sizeof *fr);
    if (!pt || !fr) die("out of memory");
    crisp_result res = {0};
    for (int f = -1; f < runs; f++) { /* one warm-up frame: it allocates, later frames reuse */
        crisp_render_stats st;
        double a = crisp_time_now();
        if (crisp_render_cpu(r, sc, cam, &img, &st)) die("render");
        double b = crisp_time_now();
        if (f < 0) continue;
        fr[f] = 1e3 * (b - a);
        pt[f] = fr[f] - st.ms_raster - st.ms_resolve; /* plan + tessellation (with ribbons) */
        res.triangles = st.triangles;
        res.ribbon_triangles = st.ribbon_triangles;
        res.visible_patches = st.visible_patches;
    }
    res.plan_tess_ms = bench_median(pt, runs); /* sorts pt */
    res.plan_tess_min = pt[0];
    res.plan_tess_max = pt[runs - 1];
    res.frame_ms = bench_median(fr, runs);
    crisp_mesh_error(r, sc, cam, &res);
    res.nearest_drawn = INFINITY;
    for (size_t k = 0; k < (size_t)img.width * (size_t)img.height; k++)
        if (img.depth[k] < res.nearest_drawn) res.nearest_drawn = img.depth[k];
    free(pt);
    free(fr);
    crisp_image_free(&img);
    crisp_renderer_destroy(r);
    return res;
}

/* Smallest camera-space depth of the box, clamped to the near plane. Depth is linear, so its
 * minimum over the box is at a corner. */
static double nearest_depth(const double box[6], const crisp_camera *cam)
{
    double f[3], n = 0;
    for (int i = 0; i < 3; i++)
        f[i] = cam->target[i] - cam->eye[i], n += f[i] * f[i];
    n = sqrt(n);
    double zmin = INFINITY;
    for (int k = 0; k < 8; k++) {
        double z = 0;
        for (int i = 0; i < 3; i++)
            z += ((k >> i & 1 ? box[i + 3] : box[i]) - cam->eye[i]) * f[i] / n;
        zmin = fmin(zmin, z);
    }
    return fmax(zmin, cam->znear);
}

int main(int argc, char **argv)
{
    int runs = argc > 1 ? atoi(argv[1]) : 7;
    if (runs < 1) runs = 1;
    double angle = argc > 2 ? atof(argv[2]) : 0.5;
    if (!(angle > 0 && angle < 3.2)) {
        fprintf(stderr, "bench_occt: angular deflection '%s': expected radians in (0, 3.2)\n",
                argv[2]);
        return 2;
    }
    bench_print_machine(stdout);
    printf(
        "%dx%d, default camera (crisp_camera_frame_box: the scene's box, looking along -Z, "
        "fov 30), %d threads, medians of %d runs (crisp: after a warm-up frame); BRepMesh angular "
        "deflection %g rad\n\n",
        WIDTH, HEIGHT, THREADS, runs, angle);
    static const struct {
        const char *name;
        int sew;
    } models[] = {{"occt_bearing.iges", 1}, {"gpucast_part.igs", 0}};
    printf("| model | mesher | deflection | triangles | time ms median (min-max) "
           "| worst px (larger of dx, dy) | worst px Euclidean | samples | notes |\n");
    printf("|---|---|---:|---:|---:|---:|---:|---:|---|\n");
    char notes[4][512];
    for (int mi = 0; mi < 2; mi++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, models[mi].name);
        crisp_model *m = NULL;
        crisp_scene *sc = NULL;
        if (crisp_model_load(path, NULL, &m)) die(path);
        if (crisp_scene_prepare(m, &sc)) die(path);
        crisp_camera cam;
        if (crisp_camera_frame_box(sc->box, WIDTH, HEIGHT, &cam)) die("camera");
        double z = nearest_depth(sc->box, &cam);
        double defl = z * tan(cam.fov_deg * (M_PI / 360.0)) / cam.height;

        crisp_result c = run_crisp(sc, &cam, runs);
        printf("| %s | crisp (plan + tess) | - | %llu | %.1f (%.1f-%.1f) | %.3f | %.3f | %lld "
               "| %u patches drawn; +%llu ribbon triangles; whole frame %.2f ms |\n",
               models[mi].name, c.triangles, c.plan_tess_ms, c.plan_tess_min, c.plan_tess_max,
               c.worst_px, c.worst_px_euclid, c.samples, c.visible_patches, c.ribbon_triangles,
               c.frame_ms);

        occt_mesh_desc d = {.path = path,
                            .sew = models[mi].sew,
                            .sew_rel_tol = 1e-4,
                            .ang_deflection = angle,
                            .threads = THREADS,
                            .runs = runs,
                            .znear = cam.znear,
                            .width = cam.width,
                            .height = cam.height};
        crisp_camera_matrices mats;
        crisp_camera_matrices_compute(&cam, &mats);
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++)
                d.view_proj[i][j] = mats.view_proj[i][j];
        /* The deflection, then halved until BRepMesh is within 0.5 px (at most 3 times). */
        occt_mesh_result o = {0};
        double first_ms = 0;
        for (int h = 0; h <= 3; h++) {
            char err[512];
            d.deflection = defl / (double)(1 << h);
            if (occt_mesh_measure(&d, &o, err, sizeof err)) {
                fprintf(stderr, "bench_occt: %s\n", err);
                return 1;
            }
            char label[32] = "0.5 px";
            if (h) snprintf(label, sizeof label, "0.5 px / %d", 1 << h);
            printf("| %s | BRepMesh%s | %.3g (%s) | %lld | %.1f (%.1f-%.1f) | %.3f | %.3f | %lld "
                   "| %d of %d faces meshed; OCCT reports deflection up to %.3g (%.1fx asked); "
                   "worst 3D gap %.3g (%.1fx); %lld samples over 0.5 px, %lld of them also from "
                   "the nearest surface point (up to %.2f px) |\n",
                   models[mi].name, models[mi].sew ? " (sewn)" : "", d.deflection, label,
                   o.triangles, o.ms_median, o.ms_min, o.ms_max, o.worst_px, o.worst_px_euclid,
                   o.samples, o.faces_meshed, o.faces, o.occt_deflection,
                   o.occt_deflection / d.deflection, o.worst_3d, o.worst_3d / d.deflection,
                   o.samples_over, o.samples_over_nearest, o.worst_nearest_px);
            if (!h) first_ms = o.ms_median;
            fflush(stdout);
            if (o.worst_px <= 0.5) break;
        }
        snprintf(
            notes[mi], sizeof notes[mi],
            "%s: scene box (%.5g %.5g %.5g)-(%.5g %.5g %.5g), Open CASCADE box "
            "(%.5g %.5g %.5g)-(%.5g %.5g %.5g); eye (%.5g %.5g %.5g), near %.5g; "
            "nearest depth %.5g (nearest depth crisp drew: %.5g) -> 0.5 px = %.4g model units; "
            "BRepMesh at that deflection "
            "took %.2fx the time of crisp's plan + tess (same run)",
            models[mi].name, sc->box[0], sc->box[1], sc->box[2], sc->box[3], sc->box[4], sc->box[5],
            o.box[0], o.box[1], o.box[2], o.box[3], o.box[4], o.box[5], cam.eye[0], cam.eye[1],
            cam.eye[2], cam.znear, z, c.nearest_drawn, defl, first_ms / c.plan_tess_ms);
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
    }
    printf("\n");
    for (int mi = 0; mi < 2; mi++)
        printf("%s\n", notes[mi]);
    return 0;
}
