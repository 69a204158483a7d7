/* Trim-editing benchmark (issue 11): per frame of a drag of one control point, the work the
 * editor does: the edit itself (crisp_trimedit_move_point), taking the loops into the scene
 * (crisp_scene_update_trim), re-planning only the edited face (crisp_planner_replan_face: "the
 * plan time of the edited face", goal < 2 ms) and drawing the frame with the CPU backend at
 * 1280x720: only the edited face over an image of the other faces drawn once
 * (crisp_render_cpu_plan_faces, what the editor does during a drag; frame goal < 33 ms).
 * Baselines in the same run: the whole plan drawn again (crisp_render_cpu_plan) and a whole-scene
 * plan (crisp_planner_plan) of the same camera. --gl adds the GL backend's draw. Inputs: the
 * built-in example, and the face with the most Bézier trim pieces among the bundled models (found
 * by scanning data/nurbs, or given: --model PATH --face N). Views: the default camera of the model,
 * for a face of a larger model also its surface's box framed (the editor's start view), and
 * zoomed in on the dragged point until the trim curve crosses the window. Usage: bench_trimedit
 * [--model PATH --face N] [--frames N] [--size WxH]
 */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench_util.h"
#include "crisp/io.h"
#include "crisp/plan.h"
#include "crisp/render.h"
#include "crisp/trimedit.h"
#ifdef CRISP_HAVE_GL /* defined where the GL backend is built (CRISP_GL=ON) */
#include "crisp/gl.h"
#define HAVE_GL 1
#endif

static int frames = 60, width = 1280, height = 720, with_gl = 0;

/* Pieces of face f (Bézier pieces of all its loops). */
static int face_pieces(const crisp_face *f)
{
    int n = 0;
    for (int l = 0; l < f->loop_count; l++)
        for (int c = 0; c < f->loops[l].curve_count; c++) {
            const crisp_curve *cv = f->loops[l].curves[c];
            for (int k = cv->degree; k < cv->count; k++)
                n += cv->knots[k] < cv->knots[k + 1];
        }
    return n;
}

/* The bundled face with the most trim pieces. */
static int find_busiest(char *path, size_t size, int *face, int *pieces)
{
    DIR *d = opendir(CRISP_DATA_DIR "/nurbs");
    if (!d) return 0;
    struct dirent *e;
    *pieces = -1;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        char p[1024];
        snprintf(p, sizeof p, "%s/nurbs/%s", CRISP_DATA_DIR, e->d_name);
        crisp_model *m;
        if (crisp_model_load(p, NULL, &m)) continue;
        for (int f = 0; f < m->face_count; f++) {
            int n = face_pieces(&m->faces[f]);
            if (n > *pieces) {
                *pieces = n;
                *face = f;
                snprintf(path, size, "%s", p);
            }
        }
        crisp_model_destroy(m);
    }
    closedir(d);
    return *pieces >= 0;
}

/* The control point to drag: the middle point of the loop's longest curve (by control points) of
 * the face's first loop, and a step of 1% of the domain. */
static crisp_trimedit_ref pick_point(const crisp_face *f)
{
    crisp_trimedit_ref r = {0, 0, 0};
    int best = -1;
    for (int c = 0; c < f->loops[0].curve_count; c++)
        if (f->loops[0].curves[c]->count > best) {
            best = f->loops[0].curves[c]->count;
            r.curve = c;
        }
    r.index = best / 2;
    return r;
}

/* Camera looking down the normal at surface point (u, v), the window spanning `span` model units.
 */
static void zoom_camera(const crisp_surface *s, const double uv[2], double span, crisp_camera *cam)
{
    double P[3], Su[3], Sv[3], N[3];
    crisp_surface_derivs(s, uv[0], uv[1], P, Su, Sv, NULL, NULL, NULL);
    crisp_vec3_cross(Su, Sv, N);
    if (!crisp_vec3_normalize(N, N)) N[0] = 0, N[1] = 0, N[2] = 1;
    double dist = 20 * span, fov = 2 * atan(0.5 * span / dist) * 180 / M_PI;
    *cam = (crisp_camera){
        .fov_deg = fov, .znear = dist * 0.01, .zfar = dist * 100, .width = width, .height = height};
    double up[3] = {0, 0, 1};
    if (fabs(N[2]) > 0.9) up[1] = 1, up[2] = 0;
    for (int k = 0; k < 3; k++) {
        cam->target[k] = P[k];
        cam->eye[k] = P[k] + dist * N[k];
        cam->up[k] = up[k];
    }
}

/* Process CPU time in seconds (all threads): what the work costs with the machine to itself. */
static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static double ms_since(double t)
{
    return 1e3 * (crisp_time_now() - t);
}

static void run(const char *name, crisp_model *m, int face, int zoomed)
{
    crisp_trimedit *ed;
    if (crisp_trimedit_create(m, face, NULL, &ed)) {
        printf("%s: %s\n", name, crisp_error_message());
        return;
    }
    crisp_scene *sc;
    if (crisp_scene_prepare(m, &sc)) {
        printf("%s: %s\n", name, crisp_error_message());
        crisp_trimedit_destroy(ed);
        return;
    }
    const crisp_face *f = crisp_trimedit_face(ed);
    crisp_trimedit_ref ref = pick_point(f);
    double p0[2], dom[4];
    crisp_trimedit_point(ed, ref, p0, NULL);
    crisp_trimedit_domain(ed, dom);
    double amp = 0.01 * fmax(dom[1] - dom[0], dom[3] - dom[2]);
    crisp_camera cam;
    if (zoomed == 1) {
        /* The window spans about 40 steps of the drag on the surface. */
        double P0[3], P1[3], q[2] = {p0[0] + amp, p0[1]};
        crisp_surface_eval(f->surface, p0[0], p0[1], P0);
        crisp_surface_eval(f->surface, q[0], q[1], P1);
        double span = 4 * hypot(hypot(P1[0] - P0[0], P1[1] - P0[1]), P1[2] - P0[2]);
        /* Aim at the curve near the point (the curve, not the control point, must cross). */
        int l, c;
        double t, on[2];
        if (crisp_trimedit_pick_curve(ed, p0, INFINITY, &l, &c, &t))
            crisp_curve_eval(f->loops[l].curves[c], t, on);
        else
            on[0] = p0[0], on[1] = p0[1];
        zoom_camera(f->surface, on, span > 0 ? span : 1e-3, &cam);
    } else if (zoomed == 2) {
        double box[6];
        crisp_surface_bbox(f->surface, box);
        crisp_camera_frame_box(box, width, height, &cam);
    } else {
        crisp_camera_frame_box(sc->box, width, height, &cam);
    }
    crisp_renderer *r, *r_full;
    crisp_planner *pl;
    crisp_renderer_create(NULL, &r);
    crisp_renderer_create(NULL, &r_full);
    crisp_planner_create(NULL, NULL, &pl);
    crisp_image img, img_full, others;
    crisp_image_init(&img, width, height);
    crisp_image_init(&img_full, width, height);
    crisp_image_init(&others, width, height);
    const crisp_frame_plan *plan;
    enum { EDIT, UPD, REPLAN, REPLAN_CPU, FULL, FULL_CPU, PART, PART_CPU, GL, GL_CPU, COLS };
    double *col[COLS];
    for (int c = 0; c < COLS; c++)
        col[c] = calloc((size_t)frames, sizeof(double));
    double full_plan[5], ms_others = 0;
    int have_gl = 0;
#ifdef HAVE_GL
    crisp_gl_context *glc = NULL;
    crisp_gl *gl = NULL;
    if (with_gl) {
        if (!crisp_gl_context_create(&glc) &&
            !crisp_gl_create(crisp_gl_context_getproc(glc), NULL, &gl) &&
            !crisp_gl_set_scene(gl, sc))
            have_gl = 1;
        else
            fprintf(stderr, "GL: %s\n", crisp_error_message());
    }
#endif
    for (int k = 0; k < 5; k++) {
        double t = crisp_time_now();
        crisp_planner_plan(pl, sc, &cam, &plan);
        full_plan[k] = ms_since(t);
    }
    /* The other faces, drawn once for the drag (the editor does this at the drag's first frame
     * and after a camera change); img starts as their copy. */
    uint8_t *only = calloc(sc->face_count, 1), *rest = calloc(sc->face_count, 1);
    for (uint32_t k = 0; k < sc->face_count; k++)
        only[k] = (int)k == face, rest[k] = (int)k != face;
    {
        double t = crisp_time_now();
        crisp_render_cpu_plan_faces(r, sc, plan, &cam, rest, NULL, &others, NULL);
        ms_others = ms_since(t);
        size_t n = (size_t)width * height;
        memcpy(img.rgba, others.rgba, 4 * n * sizeof(float));
        memcpy(img.depth, others.depth, n * sizeof(float));
        memcpy(img.normal, others.normal, 3 * n * sizeof(float));
        memcpy(img.uv, others.uv, 2 * n * sizeof(float));
        memcpy(img.face, others.face, n * sizeof(int32_t));
    }
    int refused = 0;
    uint64_t face_px = 0, differ[3] = {0, 0, 0};
    crisp_trimedit_group_begin(ed);
    for (int k = 0; k < frames; k++) {
        double a = 2 * M_PI * k / frames,
               to[2] = {p0[0] + amp * sin(a), p0[1] + amp * (1 - cos(a))};
        double t0 = crisp_time_now();
        refused += crisp_trimedit_move_point(ed, &ref, to, 0) != CRISP_OK;
        double t1 = crisp_time_now();
        crisp_scene_update_trim(sc, (uint32_t)face);
        double t2 = crisp_time_now(), c2 = cpu_now();
        crisp_planner_replan_face(pl, sc, (uint32_t)face, &plan);
        double t3 = crisp_time_now(), c3 = cpu_now();
        col[EDIT][k] = 1e3 * (t1 - t0);
        col[UPD][k] = 1e3 * (t2 - t1);
        col[REPLAN][k] = 1e3 * (t3 - t2);
        col[REPLAN_CPU][k] = 1e3 * (c3 - c2);
        /* The edited face over the others (the editor's frame), then the baseline: the whole
         * plan drawn again. */
        crisp_render_cpu_plan_faces(r, sc, plan, &cam, only, &others, &img, NULL);
        double t4 = crisp_time_now(), c4 = cpu_now();
        col[PART][k] = 1e3 * (t4 - t3);
        col[PART_CPU][k] = 1e3 * (c4 - c3);
        crisp_render_cpu_plan(r_full, sc, plan, &cam, &img_full, NULL);
        col[FULL][k] = ms_since(t4);
        col[FULL_CPU][k] = 1e3 * (cpu_now() - c4);
#ifdef HAVE_GL
        if (have_gl) {
            double t5 = crisp_time_now(), c5 = cpu_now();
            crisp_gl_draw(gl, plan, NULL);
            col[GL][k] = ms_since(t5);
            col[GL_CPU][k] = 1e3 * (cpu_now() - c5);
        }
#endif
        for (size_t p = 0; p < (size_t)width * height; p++) {
            face_px += img_full.face[p] == face;
            if (img_full.face[p] == img.face[p] && img_full.depth[p] == img.depth[p]) continue;
            /* The nearest pixel of the edited face (either image), in the max norm, up to 8. */
            int x = (int)(p % (size_t)width), y = (int)(p / (size_t)width), dist = 9;
            for (int dy = -8; dy <= 8; dy++)
                for (int dx = -8; dx <= 8; dx++) {
                    int xx = x + dx, yy = y + dy, d = abs(dx) > abs(dy) ? abs(dx) : abs(dy);
                    if (xx < 0 || yy < 0 || xx >= width || yy >= height || d >= dist) continue;
                    size_t q = (size_t)yy * width + xx;
                    if (img_full.face[q] == face || img.face[q] == face) dist = d;
                }
            differ[dist <= 2 ? 0 : dist <= 8 ? 1 : 2]++;
        }
    }
    crisp_trimedit_group_end(ed);
    double med[COLS], max_replan = 0;
    for (int c = 0; c < COLS; c++)
        med[c] = bench_median(col[c], frames);
    for (int k = 0; k < frames; k++)
        max_replan = fmax(max_replan, col[REPLAN][k]);
    double pre = med[EDIT] + med[UPD] + med[REPLAN];
    char gls[64] = "";
    if (have_gl) snprintf(gls, sizeof gls, " GL draw %.2f ms (cpu %.2f)", med[GL], med[GL_CPU]);
    printf("| %-26s | %-7s | %4d | %5.1f%% | %6.3f | %6.3f | %6.3f | %7.2f | %7.2f | %7.2f | %7.2f "
           "| %7.2f | %7.2f | %7.2f | %5.1fx | %7.2f | %7.2f |%s%s\n",
           name,
           zoomed == 2 ? "face"
           : zoomed    ? "zoomed"
                       : "default",
           face_pieces(f), 100.0 * (double)face_px / ((double)frames * width * height), med[REPLAN],
           max_replan, med[REPLAN_CPU], med[FULL], med[FULL_CPU], med[PART], med[PART_CPU],
           pre + med[FULL], pre + med[PART], med[EDIT] + med[UPD] + med[REPLAN_CPU] + med[PART_CPU],
           med[PART] > 0 ? med[FULL] / med[PART] : 0, ms_others, bench_median(full_plan, 5),
           refused ? " (some moves refused)" : "", gls);
    if (differ[0] || differ[1] || differ[2])
        printf("  (pixels whose face or depth differ between the two draws over %d frames: %llu "
               "within 2 px of the edited face, %llu within 3-8 px, %llu farther)\n",
               frames, (unsigned long long)differ[0], (unsigned long long)differ[1],
               (unsigned long long)differ[2]);
    for (int c = 0; c < COLS; c++)
        free(col[c]);
    free(only);
    free(rest);
#ifdef HAVE_GL
    crisp_gl_destroy(gl);
    crisp_gl_context_destroy(glc);
#endif
    crisp_image_free(&img);
    crisp_image_free(&img_full);
    crisp_image_free(&others);
    crisp_planner_destroy(pl);
    crisp_renderer_destroy(r);
    crisp_renderer_destroy(r_full);
    crisp_scene_destroy(sc);
    crisp_trimedit_destroy(ed);
}

int main(int argc, char **argv)
{
    char model[1024] = "";
    int face = -1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--model") && i + 1 < argc)
            snprintf(model, sizeof model, "%s", argv[++i]);
        else if (!strcmp(argv[i], "--face") && i + 1 < argc)
            face = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--frames") && i + 1 < argc)
            frames = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--size") && i + 1 < argc)
            sscanf(argv[++i], "%dx%d", &width, &height);
        else if (!strcmp(argv[i], "--gl"))
            with_gl = 1;
        else {
            fprintf(
                stderr,
                "usage: bench_trimedit [--model PATH --face N] [--frames N] [--size WxH] [--gl]\n");
            return 2;
        }
    }
    if (frames < 1) frames = 1;
    int pieces = 0;
    if (!model[0] && !find_busiest(model, sizeof model, &face, &pieces)) {
        fprintf(stderr, "no bundled model found in %s/nurbs\n", CRISP_DATA_DIR);
        return 1;
    }
    bench_print_machine(stdout);
    printf("load average %.2f; %d frames per drag at %dx%d, CPU backend, %d threads; times in ms "
           "(medians; replan max over the drag)\n\n",
           bench_load_average(), frames, width, height, crisp_pool_default_threads());
    printf("| %-26s | %-7s | %4s | %6s | %6s | %6s | %6s | %7s | %7s | %7s | %7s | %7s | %7s | "
           "%7s | %6s | %7s | %7s |\n",
           "face", "view", "pcs", "face", "replan", "max", "cpu", "full", "cpu", "face", "cpu",
           "frame", "frame", "frame", "ratio", "others", "plan");
    printf("| %-26s | %-7s | %4s | %6s | %6s | %6s | %6s | %7s | %7s | %7s | %7s | %7s | %7s | "
           "%7s | %6s | %7s | %7s |\n",
           "", "", "", "px", "", "", "", "draw", "", "draw", "", "full", "face", "cpu", "", "once",
           "");
    printf("|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|\n", "----------------------------",
           "---------", "------", "--------", "--------", "--------", "--------", "---------",
           "---------", "---------", "---------", "---------", "---------", "---------", "--------",
           "---------", "---------");
    for (int zoomed = 0; zoomed < 2; zoomed++) {
        crisp_model *m;
        if (crisp_trimedit_example(&m)) return 1;
        run("built-in example, face 0", m, 0, zoomed);
        crisp_model_destroy(m);
    }
    for (int view = 0; view < 3; view++) {
        int zoomed = view == 0 ? 0 : view == 1 ? 2 : 1; /* default, face, zoomed */
        crisp_model *m;
        if (crisp_model_load(model, NULL, &m)) {
            fprintf(stderr, "%s\n", crisp_error_message());
            return 1;
        }
        char name[256];
        const char *base = strrchr(model, '/');
        snprintf(name, sizeof name, "%s, face %d", base ? base + 1 : model, face);
        run(name, m, face, zoomed);
        crisp_model_destroy(m);
    }
    printf("\npcs: Bézier trim pieces of the edited face; face px: its share of the image; "
           "replan: crisp_scene_update_trim is not in it, crisp_planner_replan_face is (the "
           "edited face's plan; max: its slowest frame; cpu: its process CPU time); full draw: "
           "crisp_render_cpu_plan of the whole plan (the baseline, cpu: process CPU time); face "
           "draw: crisp_render_cpu_plan_faces of the edited face over the others' image (the "
           "editor's frame during a drag); frame: edit + update + replan + that draw (frame full: "
           "with the full draw; frame cpu: the face frame's process CPU time, edit and update "
           "counted as wall); ratio: full "
           "draw / face draw; others once: drawing the other faces alone, once per drag or camera "
           "change; plan: a whole-scene crisp_planner_plan of the camera.\n");
    return 0;
}
