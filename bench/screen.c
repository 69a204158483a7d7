/* bench_screen: does a frame's cost follow the screen or the model? (issue 12)
 *
 * Scenes:
 *   gen50    a generated model: 20 trimmed bicubic B-spline faces (5 x 4 grid of wavy sheets,
 *            each 50 x 50 uniform knot spans = 2,500 Bézier patches, trimmed by an outer circle
 *            and a circular hole): 50,000 patches
 *   gen100   the same shape with a knot inserted in the middle of every span in u and v (exactly
 *            the same surfaces): 100 x 100 spans per face, 200,000 patches
 *   imp49    impeller.igs instanced 7 x 7 times in a grid (>= 200,000 patches)
 *   imp      impeller.igs alone (the reference for imp49)
 * Cameras (1920x1080):
 *   default  crisp_camera_frame_box of the scene
 *   close    a close-up on the middle of the model filling the screen
 *   far      the default view from 12x the distance (the instances shrink to a few pixels)
 *   far10    (imp) the default view from 10x the distance: one impeller covering about as many
 *            pixels as imp49's 49 instances at "far" (the instancing comparison)
 *
 * Each row runs in a child process (fork) so that its peak memory is its own: the peak resident
 * size (VmHWM) is reset after the scene is prepared (/proc/self/clear_refs) and read after the
 * frames; "frame MB" is the peak minus the resident size before the frames ("scene MB": model +
 * prepared scene). Per patch and per triangle drawn: "peak B/patch" (the whole peak over the
 * model's patches), "frame B/tri" (frame memory over the surface triangles, as before session 7)
 * and "frame B/drawn tri" (over every triangle drawn: surfaces and trim ribbons, whose quads are
 * two triangles and a core of two more). Warm frame = median of the plan +
 * crisp_render_cpu_plan calls after one warm-up frame, on THREADS threads: at least FRAMES of them
 * and as many more as fill 0.5 s (BENCH_SCREEN_MIN_MS=N: N ms, 0: exactly FRAMES; FRAMES = 1:
 * exactly one, as callgrind's --toggle-collect=warm_frame recipes expect); a 3 ms frame's median
 * over 7 frames followed the machine's passing load. Plan = median of crisp_renderer_plan alone,
 * at least PLAN_CALLS calls (a plan takes well under a millisecond at a distance) and filling the
 * same time (BENCH_SCREEN_PLANS=N: exactly N calls, e.g. for a profile of the plan alone);
 * the CPU columns are the mean CPU time of the process (all threads) per frame or plan, less
 * sensitive to a loaded machine than wall time. tri/px = surface triangles per covered pixel. Each
 * row runs twice: with the default planner (group leaves) and with crisp_planner_desc.no_groups (at
 * least one leaf per visible patch), one after the other, so the two are compared under the same
 * load.
 *
 * First frame = the row's first plan + crisp_render_cpu_plan (wall and process CPU time: what a
 * viewer opening the model waits for, the planner's kept data built); BENCH_SCREEN_BUILD_LIMIT=N
 * plans with crisp_planner_desc.splat_build_limit N, and the frames after the first are drawn
 * until no splat set is pending ("build frames" of them, "built ms" from the first frame's start:
 * the warm frames then are those of the planner without a limit, the same image). The peak memory
 * includes the first frames.
 *
 * Occlusion culling (crisp_render_desc.no_occlusion) is on in every row;
 * BENCH_SCREEN_OCCLUSION=both runs each row with the default planner, culling off then on, instead
 * of the two planners (the image hash must be the same). BENCH_SCREEN_PNG=folder writes each row's
 * image there. BENCH_SCREEN_PERF_CTL=FIFO: perf_control below.
 *
 * The run ends with the ratios measured in it (the default planner's rows): gen100 over
 * gen50 at each camera (a model refined to 4x the patches), imp49:far over imp:far10 (49
 * instances against one at the same coverage), each frame and plan against the 1.3x target:
 * first as the ratio of the two rows' medians (each row its own process, so a change in the
 * machine's speed between the two processes goes into the ratio: imp49 far / imp far10's frame
 * gave 0.74-1.08x with 7 frames a row and 1.00-1.86x with 0.5 s a row, in six runs each at load
 * 2.6-4.1), then each pair whose two rows ran (or that is
 * named, e.g. imp49:far/imp:far10) measured alternately in one child process: both scenes
 * prepared and their first frames drawn, then a warm frame of one, a warm frame of the other (the
 * order swapped every round), until each side has at least FRAMES frames and 0.5 s, then their
 * plans the same way. Its table gives the medians, their ratio, the median of the per-round
 * ratios (each frame of A over the frame of B beside it: a slow spell reaches both), the ratio of
 * the process CPU times, "within 1.3x" from both ratios, and the two images' hashes (those of the
 * rows). The same pair gave 0.96-1.08x (median of the ratios 1.00-1.09) in the same six runs.
 * BENCH_SCREEN_PAIRS=0: no pairs.
 * Lines of both ratio tables hold a ':' (the scripts that keep the rows drop them).
 *
 *   bench_screen [FRAMES] [THREADS] [ROWS...]     (defaults 3, 2, all rows; a row is e.g.
 * gen50:far, a pair imp49:far/imp:far10) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "bench_image.h"
#include "bench_scenes.h"
#include "bench_util.h"
#include "crisp/construct.h"
#include "crisp/image.h"
#include "crisp/io.h"
#include "crisp/plan.h"
#include "crisp/render.h"

#define GRID_X 5
#define GRID_Y 4
#define SHEET 10.0 /* size of one face's square */
#define GAP 0.5

static void die(const char *what)
{
    fprintf(stderr, "bench_screen: %s: %s\n", what, crisp_error_message());
    exit(1);
}

/* ---- the generated model ------------------------------------------------------------------------
 */

static double height(double x, double y, int face)
{
    double a = 0.6 + 0.1 * (face % 3);
    return a * sin(0.9 * x + 0.3 * face) * cos(0.7 * y) + 0.25 * sin(2.3 * x + 1.7 * y);
}

/* A trim circle in (u, v) (dim 2) centred at (cx, cy), as two half arcs. */
static void circle_loop(double cx, double cy, double r, int outer, crisp_trim_loop *loop)
{
    double c[2] = {cx, cy}, ex[2] = {1, 0}, ey[2] = {0, 1};
    loop->is_outer = outer;
    loop->curve_count = 2;
    loop->curves = calloc(2, sizeof *loop->curves);
    if (crisp_make_arc(2, c, ex, ey, r, r, 0, M_PI, &loop->curves[0]) ||
        crisp_make_arc(2, c, ex, ey, r, r, M_PI, 2 * M_PI, &loop->curves[1]))
        die("trim circle");
}

/* 20 faces of spans x spans bicubic knot spans; refine: insert every span's midpoint. */
static crisp_model *generated(int spans, int refine)
{
    crisp_model *m;
    if (crisp_model_create(&m)) die("model");
    int n = spans + 3;
    double *knots = malloc((size_t)(n + 4) * sizeof *knots);
    double *pts = malloc((size_t)n * n * 3 * sizeof *pts);
    for (int i = 0; i < n + 4; i++)
        knots[i] = i < 4 ? 0 : i >= n ? 1 : (double)(i - 3) / spans;
    for (int fy = 0; fy < GRID_Y; fy++)
        for (int fx = 0; fx < GRID_X; fx++) {
            int f = fy * GRID_X + fx;
            double x0 = fx * (SHEET + GAP), y0 = fy * (SHEET + GAP);
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    /* Greville abscissae: the control net samples the height field. */
                    double gu = (knots[i + 1] + knots[i + 2] + knots[i + 3]) / 3;
                    double gv = (knots[j + 1] + knots[j + 2] + knots[j + 3]) / 3;
                    double x = x0 + gu * SHEET, y = y0 + gv * SHEET;
                    double *p = pts + 3 * ((size_t)j * n + i);
                    p[0] = x, p[1] = y, p[2] = height(x, y, f);
                }
            crisp_face face = {0};
            if (crisp_surface_create(3, 3, n, n, knots, knots, pts, NULL, &face.surface))
                die("surface");
            if (refine)
                for (int k = 0; k < spans; k++) {
                    double mid = (k + 0.5) / spans;
                    if (crisp_surface_insert_knot_u(face.surface, mid, 1) ||
                        crisp_surface_insert_knot_v(face.surface, mid, 1))
                        die("knot insertion");
                }
            face.loop_count = 2;
            face.loops = calloc(2, sizeof *face.loops);
            circle_loop(0.5, 0.5, 0.48, 1, &face.loops[0]);
            circle_loop(0.45 + 0.02 * (f % 5), 0.5, 0.12 + 0.01 * (f % 4), 0, &face.loops[1]);
            if (crisp_face_normalize_loops(&face, 1e-9)) die("loops");
            face.source_id = f;
            if (crisp_model_add_face(m, &face)) die("add face");
        }
    free(knots);
    free(pts);
    return m;
}

/* ---- cameras ------------------------------------------------------------------------------------
 */

static crisp_camera camera(const crisp_scene *sc, const char *which)
{
    crisp_camera cam;
    if (crisp_camera_frame_box(sc->box, 1920, 1080, &cam)) die("camera");
    double d[3];
    for (int k = 0; k < 3; k++)
        d[k] = cam.eye[k] - cam.target[k];
    double dist = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!strncmp(which, "far", 3)) {
        /* "far": 12x the default distance; "farN": N times (imp:far10 covers about as many
         * pixels as imp49:far's 49 instances together). */
        double f = which[3] ? atof(which + 3) : 12;
        for (int k = 0; k < 3; k++)
            cam.eye[k] = cam.target[k] + f * d[k];
        cam.zfar = (f + 2) * dist + (sc->box[5] - sc->box[2]);
    } else if (!strcmp(which, "close")) {
        /* Look down (-Z) at the middle of the model from 1/8 of the default distance, slightly
         * tilted: the surfaces fill the screen. */
        double cx = 0.5 * (sc->box[0] + sc->box[3]), cy = 0.5 * (sc->box[1] + sc->box[4]);
        double h = 0.125 * dist;
        cam.target[0] = cx, cam.target[1] = cy, cam.target[2] = sc->box[2];
        cam.eye[0] = cx, cam.eye[1] = cy - 0.3 * h, cam.eye[2] = sc->box[5] + h;
        cam.znear = 1e-3 * h;
        cam.zfar = 4 * dist;
    }
    return cam;
}

/* ---- one row ------------------------------------------------------------------------------------
 */

static double status_kb(const char *key)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    double v = 0;
    size_t n = strlen(key);
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, key, n)) v = atof(line + n + 1);
    if (f) fclose(f);
    return v;
}

static void reset_peak(void)
{
    FILE *f = fopen("/proc/self/clear_refs", "w");
    if (f) {
        fputs("5", f);
        fclose(f);
    }
}

static crisp_model *scene_model(const char *name)
{
    if (!strcmp(name, "gen50")) return generated(50, 0);
    if (!strcmp(name, "gen100")) return generated(50, 1);
    if (!strcmp(name, "imp49")) return bench_instanced("impeller.igs", 7, 7, die);
    if (!strcmp(name, "imp")) return bench_instanced("impeller.igs", 1, 1, die);
    fprintf(stderr, "bench_screen: unknown scene %s\n", name);
    exit(1);
}

/* One warm frame and one plan, kept out of line so that callgrind can count them alone
 * (--toggle-collect=warm_frame, --toggle-collect=warm_plan: the warm-up frame, which builds what
 * the planner keeps, is not counted; no_icf: GCC would fold the identical first_frame into it). */
static __attribute__((noinline, no_icf)) int
warm_frame(crisp_planner *pl, crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cam,
           const crisp_frame_plan **plan, crisp_image *img, crisp_render_stats *st)
{
    return crisp_planner_plan(pl, sc, cam, plan) ||
           crisp_render_cpu_plan(r, sc, *plan, cam, img, st);
}

/* The first frame (what the planner keeps is built: per-patch bounds, splat sets), out of line
 * for --toggle-collect=first_frame. */
static __attribute__((noinline, no_icf)) int
first_frame(crisp_planner *pl, crisp_renderer *r, const crisp_scene *sc, const crisp_camera *cam,
            const crisp_frame_plan **plan, crisp_image *img, crisp_render_stats *st)
{
    return crisp_planner_plan(pl, sc, cam, plan) ||
           crisp_render_cpu_plan(r, sc, *plan, cam, img, st);
}

static __attribute__((noinline, no_icf)) int warm_plan(crisp_planner *pl, const crisp_scene *sc,
                                                       const crisp_camera *cam,
                                                       const crisp_frame_plan **plan)
{
    return crisp_planner_plan(pl, sc, cam, plan);
}

/* BENCH_SCREEN_PERF_CTL=FIFO: "enable" and "disable" written to FIFO around the warm frames (not
 * the warm plans), for `perf record -D -1 --control=fifo:FIFO`: a profile of the warm frames
 * alone. */
static void perf_control(const char *command)
{
    const char *path = getenv("BENCH_SCREEN_PERF_CTL");
    if (!path) return;
    FILE *f = fopen(path, "w");
    if (!f) die(path);
    fprintf(f, "%s\n", command);
    fclose(f);
}

/* One row: variant 0 = group leaves (the default planner), 1 = no group leaves (at least one
 * leaf per visible patch, as before issue 12's group leaves). */
enum { PLAN_CALLS = 51, MAX_SAMPLES = 1 << 20 };

/* What a row's child process hands back to the run (through a pipe). */
typedef struct row_result {
    int done;
    double frame_ms, plan_ms;
} row_result;

/* The least wall time (ms) that a row's warm frames, and apart from them its plans, fill: a 3 ms
 * frame's median over 7 frames follows the machine's passing load, one over 0.5 s of frames far
 * less. BENCH_SCREEN_MIN_MS=N: N ms (0: exactly FRAMES frames). FRAMES = 1 runs exactly one warm
 * frame and PLAN_CALLS plans whatever the setting (the count the callgrind recipes rely on). */
static double fill_ms(int frames)
{
    const char *e = getenv("BENCH_SCREEN_MIN_MS");
    if (frames <= 1) return 0;
    return e ? atof(e) : 500;
}

/* A growing list of samples (ms). */
typedef struct samples {
    double *v;
    int n, cap;
} samples;

static void add_sample(samples *s, double x)
{
    if (s->n == s->cap) {
        s->cap = s->cap ? 2 * s->cap : 64;
        s->v = realloc(s->v, (size_t)s->cap * sizeof *s->v);
        if (!s->v) die("out of memory for samples");
    }
    s->v[s->n++] = x;
}

/* Whether a timed loop goes on: at least `least` runs, and until `ms` of wall time from t0. */
static int keep_going(int n, int least, double t0, double ms)
{
    return n < least || (n < MAX_SAMPLES && 1e3 * (crisp_time_now() - t0) < ms);
}

/* A scene, camera, planner and renderer ready to draw (a row, or one side of a pair). */
typedef struct row_state {
    const char *scene_name, *cam_name;
    int no_groups, no_splats;
    crisp_model *m;
    crisp_scene *sc;
    crisp_camera cam;
    crisp_renderer *r;
    crisp_planner *pl;
    crisp_image img;
    crisp_render_stats st;
    const crisp_frame_plan *plan;
    double ms_first, cpu_first, ms_built;
    int build_frames;
} row_state;

static void row_open(row_state *s, const char *scene_name, const char *cam_name, int threads,
                     int no_groups, int occlusion, int no_splats)
{
    *s = (row_state){.scene_name = scene_name,
                     .cam_name = cam_name,
                     .no_groups = no_groups,
                     .no_splats = no_splats};
    s->m = scene_model(scene_name);
    if (crisp_scene_prepare(s->m, &s->sc)) die("prepare");
    s->cam = camera(s->sc, cam_name);
    if (crisp_renderer_create(&(crisp_render_desc){.threads = threads, .no_occlusion = !occlusion},
                              &s->r))
        die("renderer");
    const char *lim = getenv("BENCH_SCREEN_BUILD_LIMIT");
    if (crisp_planner_create(
            &(crisp_planner_desc){.no_groups = no_groups,
                                  .no_splats = no_splats,
                                  .splat_build_limit = lim ? strtoull(lim, NULL, 10) : 0},
            NULL, &s->pl))
        die("planner");
    if (crisp_image_init(&s->img, s->cam.width, s->cam.height)) die("image");
}

/* The first frame; with a build limit, the frames after it until no splat set is pending (then
 * the warm frames are those of the unlimited planner). */
static void row_first(row_state *s)
{
    double c_first = bench_cpu_ms(), t_first = crisp_time_now();
    if (first_frame(s->pl, s->r, s->sc, &s->cam, &s->plan, &s->img, &s->st)) die("render");
    s->ms_first = 1e3 * (crisp_time_now() - t_first);
    s->cpu_first = bench_cpu_ms() - c_first;
    s->build_frames = 1;
    while (s->plan->stats.splat_pending) {
        if (crisp_planner_plan(s->pl, s->sc, &s->cam, &s->plan) ||
            crisp_render_cpu_plan(s->r, s->sc, s->plan, &s->cam, &s->img, &s->st))
            die("render");
        s->build_frames++;
    }
    s->ms_built = 1e3 * (crisp_time_now() - t_first);
}

/* One warm frame of s: its wall time (ms); *cpu += its process CPU time. */
static double row_frame(row_state *s, double *cpu)
{
    double c0 = bench_cpu_ms(), a = crisp_time_now();
    if (warm_frame(s->pl, s->r, s->sc, &s->cam, &s->plan, &s->img, &s->st)) die("render");
    double b = crisp_time_now();
    *cpu += bench_cpu_ms() - c0;
    return 1e3 * (b - a);
}

/* One warm plan of s alone: its wall time (ms); *cpu += its process CPU time. */
static double row_plan(row_state *s, double *cpu)
{
    double a = crisp_time_now(), c0 = bench_cpu_ms();
    if (warm_plan(s->pl, s->sc, &s->cam, &s->plan)) die("plan");
    double b = crisp_time_now();
    *cpu += bench_cpu_ms() - c0;
    return 1e3 * (b - a);
}

static void row_close(row_state *s)
{
    crisp_image_free(&s->img);
    crisp_planner_destroy(s->pl);
    crisp_renderer_destroy(s->r);
    crisp_scene_destroy(s->sc);
    crisp_model_destroy(s->m);
}

static void row(const char *scene_name, const char *cam_name, int frames, int threads,
                int no_groups, int occlusion, int no_splats, row_result *result)
{
    row_state rs;
    row_open(&rs, scene_name, cam_name, threads, no_groups, occlusion, no_splats);
    double scene_kb = status_kb("VmRSS:");
    reset_peak();
    int plans = frames > PLAN_CALLS ? frames : PLAN_CALLS;
    double least_ms = fill_ms(frames), least_plan_ms = least_ms;
    const char *np = getenv("BENCH_SCREEN_PLANS");
    if (np && atoi(np) > 0) plans = atoi(np), least_plan_ms = 0;
    samples tf = {0}, tp = {0}, tt = {0}, tr = {0};
    double cpu_frames = 0, cpu_plans = 0;
    row_first(&rs);
    perf_control("enable");
    double t0 = crisp_time_now();
    while (keep_going(tf.n, frames, t0, least_ms)) {
        add_sample(&tf, row_frame(&rs, &cpu_frames));
        add_sample(&tt, rs.st.ms_tess);
        add_sample(&tr, rs.st.ms_raster);
    }
    perf_control("disable");
    t0 = crisp_time_now();
    while (keep_going(tp.n, plans, t0, least_plan_ms))
        add_sample(&tp, row_plan(&rs, &cpu_plans));
    const crisp_frame_plan *plan = rs.plan;
    const crisp_render_stats st = rs.st;
    const crisp_image img = rs.img;
    const crisp_scene *sc = rs.sc;
    if (getenv("BENCH_SCREEN_STAGES"))
        fprintf(stderr,
                "%s %s %s: levels %.1f edges %.1f trim %.1f ribbons %.1f ms; %u visible faces, "
                "%u table rows, %u ribbon quads\n",
                scene_name, cam_name, no_groups ? "no groups" : "groups", plan->stats.ms_levels,
                plan->stats.ms_edges, plan->stats.ms_trim, plan->stats.ms_ribbons,
                plan->stats.visible_faces, plan->row_count, plan->ribbon_quad_count);
    double peak_kb = status_kb("VmHWM:");
    size_t covered = 0;
    for (size_t p = 0; p < (size_t)img.width * img.height; p++)
        covered += img.face[p] >= 0;
    double frame_mb = (peak_kb - scene_kb) / 1024;
    const char *png = getenv("BENCH_SCREEN_PNG"); /* a folder: look at what each row draws */
    if (png) {
        char path[1200];
        snprintf(path, sizeof path, "%s/%s_%s%s%s.png", png, scene_name, cam_name,
                 no_groups ? "_nogroups" : "", no_splats ? "_nosplats" : "");
        if (bench_write_png(path, &img)) die(path);
    }
    uint32_t hash = bench_image_hash(&img); /* culling must not change it */
    printf(
        "| %s | %s | %s | %s | %u | %.1f | %.1f | %.2f | %.2f | %.1f | %.1f | %u | %u | %llu | "
        "%llu | %llu | %zu | %.2f | %.0f | %.0f | %.0f | %.0f | %.0f | %.0f | %u | %llu | %.2f | "
        "%.1f | %.1f | %.1f | %d | %.1f | %08x |\n",
        scene_name, cam_name,
        no_groups   ? "no groups"
        : no_splats ? "groups, no splats"
                    : "groups, splats",
        occlusion ? "on" : "off", sc->patch_count, bench_median(tf.v, tf.n), cpu_frames / tf.n,
        bench_median(tp.v, tp.n), cpu_plans / tp.n, bench_median(tt.v, tt.n),
        bench_median(tr.v, tr.n), plan->leaf_count, plan->stats.group_leaves,
        (unsigned long long)st.triangles, (unsigned long long)st.occluded_triangles,
        (unsigned long long)st.ribbon_triangles, covered,
        covered ? (double)st.triangles / covered : 0.0, peak_kb / 1024, scene_kb / 1024, frame_mb,
        peak_kb * 1024 / sc->patch_count, st.triangles ? frame_mb * 1048576 / st.triangles : 0.0,
        st.triangles + st.ribbon_triangles
            ? frame_mb * 1048576 / (double)(st.triangles + st.ribbon_triangles)
            : 0.0,
        plan->stats.splat_faces, (unsigned long long)plan->stats.splats_drawn,
        covered ? (double)(st.triangles + plan->stats.splats_drawn) / covered : 0.0,
        plan->stats.splat_bytes / 1048576.0, rs.ms_first, rs.cpu_first, rs.build_frames,
        rs.ms_built, (unsigned)hash);
    fflush(stdout);
    *result = (row_result){
        .done = 1, .frame_ms = bench_median(tf.v, tf.n), .plan_ms = bench_median(tp.v, tp.n)};
    free(tf.v), free(tp.v), free(tt.v), free(tr.v);
    row_close(&rs);
}

/* The pairs: row A (scene, camera) over row B, each against the 1.3x target. */
static const char *pairs[][4] = {{"gen100", "default", "gen50", "default"},
                                 {"gen100", "close", "gen50", "close"},
                                 {"gen100", "far", "gen50", "far"},
                                 {"imp49", "far", "imp", "far10"}};
enum { PAIRS = sizeof pairs / sizeof pairs[0] };

/* Median of the ratios a[k] / b[k] over the k where b[k] > 0 (0 when there is none). */
static double median_ratio(const samples *a, const samples *b)
{
    samples r = {0};
    for (int k = 0; k < a->n && k < b->n; k++)
        if (b->v[k] > 0) add_sample(&r, a->v[k] / b->v[k]);
    double m = r.n ? bench_median(r.v, r.n) : 0;
    free(r.v);
    return m;
}

static void print_ratio(double x)
{
    if (x > 0 && isfinite(x))
        printf(" %.2f |", x);
    else
        printf(" - |");
}

/* Runs of one (row_frame or row_plan) on a and b alternating (A B, B A, A B, ...) until each side
 * has at least `least` samples and least_ms have passed (keep_going): samples into sa and sb, CPU
 * times added to ca and cb. */
static void alternate(row_state *a, row_state *b, double (*one)(row_state *, double *), int least,
                      double least_ms, samples *sa, samples *sb, double *ca, double *cb)
{
    double t0 = crisp_time_now();
    while (keep_going(sa->n, least, t0, least_ms)) {
        double x, y;
        if (sa->n % 2 == 0)
            x = one(a, ca), y = one(b, cb);
        else
            y = one(b, cb), x = one(a, ca);
        add_sample(sa, x), add_sample(sb, y);
    }
}

/* Pair p measured in one process, its two rows' frames alternating (A B, B A, A B, ...: each
 * ratio a frame of A over the frame of B next to it), then their plans alternating the same way,
 * each side filling fill_ms(frames) or more: a change in the machine's speed over the run
 * (another process's load, the CPU's clock) reaches both sides alike. Prints the ratio of the
 * two sides' medians and the median of the per-frame ratios, and the two images' hashes (the
 * separate rows' ones). */
static void pair(size_t p, int frames, int threads)
{
    row_state a, b;
    row_open(&a, pairs[p][0], pairs[p][1], threads, 0, 1, 0);
    row_open(&b, pairs[p][2], pairs[p][3], threads, 0, 1, 0);
    row_first(&a);
    row_first(&b);
    double least_ms = 2 * fill_ms(frames); /* both sides */
    samples fa = {0}, fb = {0}, pa = {0}, pb = {0};
    double cfa = 0, cfb = 0, cpa = 0, cpb = 0;
    alternate(&a, &b, row_frame, frames, least_ms, &fa, &fb, &cfa, &cfb);
    alternate(&a, &b, row_plan, frames > PLAN_CALLS ? frames : PLAN_CALLS, least_ms, &pa, &pb, &cpa,
              &cpb);
    /* the per-frame ratios before the medians sort the samples */
    double fr_med = median_ratio(&fa, &fb), pr_med = median_ratio(&pa, &pb);
    double fma = bench_median(fa.v, fa.n), fmb = bench_median(fb.v, fb.n);
    double pma = bench_median(pa.v, pa.n), pmb = bench_median(pb.v, pb.n);
    printf("| %s:%s/%s:%s | %d | %.2f | %.2f |", pairs[p][0], pairs[p][1], pairs[p][2], pairs[p][3],
           fa.n, fma, fmb);
    print_ratio(fma / fmb);
    print_ratio(fr_med);
    print_ratio(cfa / cfb);
    printf(" %d | %.3f | %.3f |", pa.n, pma, pmb);
    print_ratio(pma / pmb);
    print_ratio(pr_med);
    print_ratio(cpa / cpb);
    int fok = fma <= 1.3 * fmb && fr_med <= 1.3, pok = pma <= 1.3 * pmb && pr_med <= 1.3;
    printf(" %s | %08x %08x |\n",
           fok && pok ? "yes"
           : fok      ? "frame only"
           : pok      ? "plan only"
                      : "no",
           (unsigned)bench_image_hash(&a.img), (unsigned)bench_image_hash(&b.img));
    fflush(stdout);
    free(fa.v), free(fb.v), free(pa.v), free(pb.v);
    row_close(&a);
    row_close(&b);
}

/* The ratios from this run's default-planner rows (variant 0), where both rows ran. */
static void print_ratios(const char *rows[][2], size_t n, row_result (*results)[2])
{
    int header = 0;
    for (size_t p = 0; p < PAIRS; p++) {
        const row_result *a = NULL, *b = NULL;
        for (size_t k = 0; k < n; k++) {
            if (!results[k][0].done) continue;
            if (!strcmp(rows[k][0], pairs[p][0]) && !strcmp(rows[k][1], pairs[p][1]))
                a = &results[k][0];
            if (!strcmp(rows[k][0], pairs[p][2]) && !strcmp(rows[k][1], pairs[p][3]))
                b = &results[k][0];
        }
        if (!a || !b) continue;
        if (!header) {
            printf("\nRatios in this run (default planner, each row its own process: the ratio of "
                   "the rows' medians; issue 12's target: at most 1.3x)\n\n"
                   "| row | against | frame ratio | plan ratio | within 1.3x |\n"
                   "|---|---|---:|---:|---|\n");
            header = 1;
        }
        double fr = a->frame_ms / b->frame_ms, pr = a->plan_ms / b->plan_ms;
        printf("| %s:%s | %s:%s | %.2f | %.2f | %s |\n", pairs[p][0], pairs[p][1], pairs[p][2],
               pairs[p][3], fr, pr,
               fr <= 1.3 && pr <= 1.3 ? "yes"
               : fr <= 1.3            ? "frame only"
               : pr <= 1.3            ? "plan only"
                                      : "no");
    }
}

int main(int argc, char **argv)
{
    int frames = argc > 1 ? atoi(argv[1]) : 3;
    int threads = argc > 2 ? atoi(argv[2]) : 2;
    if (frames < 1) frames = 1;
    /* BENCH_SCREEN_GROUPS_ONLY=1: only the default planner (no "no groups" rows). */
    int variants = getenv("BENCH_SCREEN_GROUPS_ONLY") ? 1 : 2;
    /* BENCH_SCREEN_OCCLUSION=both: the default planner with occlusion culling off, then on
     * (instead of the two planners; crisp_render_desc.no_occlusion). */
    int occl_both =
        getenv("BENCH_SCREEN_OCCLUSION") && !strcmp(getenv("BENCH_SCREEN_OCCLUSION"), "both");
    if (occl_both) variants = 2;
    /* BENCH_SCREEN_SPLATS=both: the default planner without splats, then with them (issue 12:
     * crisp_planner_desc.no_splats, the same binary), instead of the two planners. */
    int splats_both =
        getenv("BENCH_SCREEN_SPLATS") && !strcmp(getenv("BENCH_SCREEN_SPLATS"), "both");
    if (splats_both) variants = 2;
    static const char *rows[][2] = {{"gen50", "default"}, {"gen100", "default"}, {"gen50", "close"},
                                    {"gen100", "close"},  {"gen50", "far"},      {"gen100", "far"},
                                    {"imp", "default"},   {"imp49", "default"},  {"imp49", "close"},
                                    {"imp49", "far"},     {"imp", "far10"}};
    enum { ROWS = sizeof rows / sizeof rows[0] };
    row_result results[ROWS][2] = {{{0}}}; /* [row][variant], from the rows' child processes */
    bench_print_machine(stdout);
    printf("load average at start %.2f; 1920x1080, %d threads, median of at least %d warm frames "
           "filling %.0f ms or more (plans the same, at least %d)\n\n",
           bench_load_average(), threads, frames, fill_ms(frames),
           frames > PLAN_CALLS ? frames : PLAN_CALLS);
    printf(
        "| scene | camera | planner | occlusion | patches | frame ms | frame CPU ms | plan ms | "
        "plan CPU ms | tess ms | raster ms | leaves | group leaves | triangles | occluded tri | "
        "ribbon tri | covered px | tri/px | peak MB | scene MB | frame MB | peak B/patch | frame "
        "B/tri | frame B/drawn tri | splat faces | splats | (tri+splats)/px | splat store MB | "
        "first frame ms | first frame CPU ms | build frames | built ms | image hash |\n");
    printf("|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
           "---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n");
    fflush(stdout);
    for (size_t k = 0; k < ROWS; k++) {
        char key[64];
        snprintf(key, sizeof key, "%s:%s", rows[k][0], rows[k][1]);
        int wanted = argc <= 3;
        for (int a = 3; a < argc; a++)
            wanted |= !strcmp(argv[a], key);
        if (!wanted) continue;
        for (int variant = variants - 1; variant >= 0; variant--) {
            int fd[2];
            if (pipe(fd)) die("pipe");
            pid_t pid = fork();
            if (pid == 0) {
                row_result res = {0};
                close(fd[0]);
                if (splats_both)
                    row(rows[k][0], rows[k][1], frames, threads, 0, 1, variant, &res);
                else if (occl_both)
                    row(rows[k][0], rows[k][1], frames, threads, 0, !variant, 0, &res);
                else
                    row(rows[k][0], rows[k][1], frames, threads, variant, 1, 0, &res);
                /* under PIPE_BUF bytes: written whole before the parent reads */
                _exit(write(fd[1], &res, sizeof res) != (ssize_t)sizeof res);
            }
            close(fd[1]);
            if (read(fd[0], &results[k][variant], sizeof results[k][variant]) !=
                (ssize_t)sizeof results[k][variant])
                results[k][variant].done = 0;
            close(fd[0]);
            int status = 0;
            waitpid(pid, &status, 0);
            if (!WIFEXITED(status) || WEXITSTATUS(status))
                printf("| %s | %s | %s | failed |\n", rows[k][0], rows[k][1],
                       splats_both ? (variant ? "no splats" : "splats")
                       : occl_both ? (variant ? "occlusion off" : "occlusion on")
                                   : (variant ? "no groups" : "groups"));
        }
    }
    print_ratios(rows, ROWS, results);
    /* The pairs measured alternately in one process: those named (e.g. imp49:far/imp:far10) and
     * those whose two rows ran above (BENCH_SCREEN_PAIRS=0: none). */
    const char *pe = getenv("BENCH_SCREEN_PAIRS");
    int pair_header = 0;
    for (size_t p = 0; p < PAIRS && !(pe && !strcmp(pe, "0")); p++) {
        char key[128];
        snprintf(key, sizeof key, "%s:%s/%s:%s", pairs[p][0], pairs[p][1], pairs[p][2],
                 pairs[p][3]);
        int wanted = 0, ran = 0;
        for (int a = 3; a < argc; a++)
            wanted |= !strcmp(argv[a], key);
        for (size_t k = 0; k < ROWS; k++)
            ran += results[k][0].done &&
                   ((!strcmp(rows[k][0], pairs[p][0]) && !strcmp(rows[k][1], pairs[p][1])) ||
                    (!strcmp(rows[k][0], pairs[p][2]) && !strcmp(rows[k][1], pairs[p][3])));
        if (!wanted && ran < 2) continue;
        if (!pair_header) {
            printf("\nThe pairs measured alternately in one process (default planner, %d threads; "
                   "warm frames, then plans, of the two rows alternating, each side at least %d "
                   "and %.0f ms or more; ratio of the medians, median of the per-frame ratios, "
                   "ratio of the process CPU times)\n\n"
                   "| pair (row:camera/against:camera) | frames | frame ms | against frame ms | "
                   "frame ratio | median frame "
                   "ratio | frame CPU ratio | plans | plan ms | against plan ms | plan ratio | "
                   "median plan ratio | plan CPU ratio | within 1.3x | image hashes |\n"
                   "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|\n",
                   threads, frames, fill_ms(frames));
            fflush(stdout);
            pair_header = 1;
        }
        pid_t pid = fork();
        if (pid == 0) {
            pair(p, frames, threads);
            _exit(0);
        }
        int status = 0;
        waitpid(pid, &status, 0);
        if (!WIFEXITED(status) || WEXITSTATUS(status)) printf("| %s | failed |\n", key);
    }
    printf("\nload average at the end %.2f\n", bench_load_average());
    return 0;
}
