/* Splats (issue 12, src/render/splat_store.c, splat_raster.c): faces so small on screen that
 * their point samples are drawn instead of their patches.
 *
 * - test_draw_reference: hand-made splat sets drawn into a target that already holds depth,
 *   at 1, 4 and 16 samples, on 1 and 3 threads: every sample equals a reference computed here
 *   (the squares cx - h <= x < cx + h, cy - h <= y < cy + h; larger 1/W wins, ties keep the
 *   earlier; reversed faces' normals flipped; W <= 0 and splats beyond near or far skipped).
 * - test_choice_near_plane: a thin strip along the view axis, a fraction of a pixel on screen,
 *   is splatted when its box lies in front of the near plane and not when the near plane cuts
 *   its box; desc.no_splats turns splats off; a splatted face has no leaves, strips or ribbons.
 * - test_true_points, test_no_holes: bundled models at far views (1 sample): every pixel that
 *   shows a splatted face shows a true point of it (its (u, v) inside the trim by the exact
 *   classifier, the surface point there within 0.5 px of the pixel centre in x and y), and every
 *   pixel centre whose exact ray meets a splatted face is covered.
 * - test_solids_far: closed solids far away (splatted and patch-drawn faces mixed, 1 and 4
 *   samples): no background pixel wherever the exact renderer sees the solid on the pixel and
 *   its 8 neighbours.
 * - test_near_edges: images with and without splats differ only at pixels that lie at a face
 *   edge (a 3x3 neighbour of another face or the background) in one of the two images.
 * - test_build_limit: with a per-frame build limit, every frame of a view keeps those guarantees
 *   until the sets are built, and the last frame is bit for bit the one without a limit.
 * - test_build_order: with a build limit, the faces built first are those whose patches cost the
 *   most per splat they need (patches / 2^level): every face the first frame splats ranks at
 *   least as high as every face left pending.
 * - test_trim_rule: malloc_trim (glibc) once when a scene is prepared, not after a frame that built
 *   a few sets, after each frame that built its build limit's worth. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_test_util.h"
#include "crisp/io.h"
#include "crisp/plan.h"
#include "crisp/render.h"
#include "crisp/trim.h"
#include "render/occlusion.h"
#include "render/raster.h"
#include "render/splat.h"
#include "render/splat_raster.h"
#include "render/splat_store.h"

#ifdef __GLIBC__
#include <malloc.h>
/* The library's malloc_trim calls (this definition takes glibc's place in the test program). */
static int trims;
int malloc_trim(size_t pad)
{
    (void)pad;
    trims++;
    return 0;
}
#endif

static uint64_t rng = 0x853c49e6748fea9bull;
static double rnd(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

/* ---- the draw against a reference ----------------------------------------------------------- */

#define NF 3

/* The plan's splats drawn into a target that is the window win (x0, y0, width, height) of a
 * width x height image, against every splat tested at every sample of the image in draw order.
 * small: the splats as many ranges of 1 to 6 splats each, each about one point (a far view of
 * many small faces: ranges a few pixels across, many across a band's edge). */
static void draw_case_window(int samples, int width, int height, const int win[4], int small)
{
    crisp_camera cam = {.eye = {0.3, -0.2, 6},
                        .target = {0, 0, 0},
                        .up = {0, 1, 0},
                        .fov_deg = 40,
                        .znear = 1,
                        .zfar = 9,
                        .width = width,
                        .height = height};
    crisp_camera_matrices cm;
    crisp_camera_matrices_compute(&cam, &cm);
    crisp_frame_plan plan = {0};
    crisp_mat4_copy(cm.view_proj, plan.view_proj);
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 4; r++)
            plan.view_proj_f[4 * c + r] = (float)cm.view_proj[c][r];
    plan.width = width, plan.height = height;
    plan.splat_half_px = 0.5;
    crisp_plan_face faces[NF] = {{0}};
    faces[1].flags = CRISP_PLAN_FACE_REVERSED | CRISP_PLAN_FACE_SPLATS;
    faces[0].flags = faces[2].flags = CRISP_PLAN_FACE_SPLATS;
    plan.faces = faces, plan.face_count = NF;
    double origin[NF][3] = {{0.5, 0.2, 0}, {-0.4, 0.1, 1}, {0, -0.3, -1}};
    float clip_origin[4 * NF];
    for (int f = 0; f < NF; f++) {
        double h[4];
        crisp_mat4_mulp(cm.view_proj, origin[f], h);
        for (int q = 0; q < 4; q++)
            clip_origin[4 * f + q] = (float)h[q];
    }
    plan.splat_clip_origin = clip_origin;
    enum { N = 440, MAX_NR = N };
    crisp_plan_splat sp[N];
    uint32_t sp_face[N];
    /* the last range: behind the surface drawn over the left half (culled with occlude) */
    crisp_plan_splat_range ranges[MAX_NR] = {
        {0, 150, 0}, {150, 130, 1}, {280, 120, 2}, {400, 40, 0}};
    int NR = NF + 1;
    if (small) /* ranges of 1 to 6 splats up to 400, then the hidden one */
        for (uint32_t first = 0, r = 0;; r++) {
            uint32_t n = first + 6 > 400 ? 400 - first : 1 + (uint32_t)(6 * rnd()) % 6;
            ranges[r] = (crisp_plan_splat_range){first, n, r % NF};
            first += n;
            if (first == 400) {
                ranges[r + 1] = (crisp_plan_splat_range){400, 40, 0};
                NR = (int)r + 2;
                break;
            }
        }
    double centre[3] = {0};
    for (int r = 0, k = 0; r < NR; r++)
        for (uint32_t q = 0; q < ranges[r].count; q++, k++) {
            crisp_plan_splat *s = &sp[k];
            int f = (int)ranges[r].face;
            sp_face[k] = (uint32_t)f;
            if (small && q == 0)
                for (int a = 0; a < 3; a++)
                    centre[a] = 2.4 * rnd() - 1.2;
            for (int a = 0; a < 3; a++)
                s->p[a] = (float)(small ? centre[a] + 0.03 * rnd() : 2.4 * rnd() - 1.2);
            if (r == NR - 1) {
                s->p[0] = (float)(-1.5 - 0.4 * rnd()), s->p[1] = (float)(0.6 * rnd() - 0.5);
                s->p[2] = (float)(-0.3 - 0.5 * rnd());
            }
            if (k % 37 == 0) s->p[2] = (float)(7 - origin[f][2]);   /* behind the eye */
            if (k % 41 == 0) s->p[2] = (float)(5.5 - origin[f][2]); /* before the near plane */
            if (k % 43 == 0) s->p[2] = s->p[2] - 4.5f;              /* beyond the far plane */
            if (k % 5 == 0 && k && r < NR - 1)
                s->p[0] = sp[k - 1].p[0], s->p[1] = sp[k - 1].p[1],
                s->p[2] = sp[k - 1].p[2]; /* a tie: the earlier stays */
            float n[3] = {(float)rnd(), (float)rnd(), k % 3 ? 1.0f : -1.0f};
            float l = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            for (int a = 0; a < 3; a++)
                n[a] /= l;
            s->n = crisp__splat_pack_normal(n);
            s->uv[0] = (float)k, s->uv[1] = (float)(0.5 * k);
        }
    plan.splats = sp, plan.splat_count = N;
    plan.splat_ranges = ranges, plan.splat_range_count = NR;

    crisp_raster_target t[4]; /* 1 and 3 threads; culling from the splats, and from hiz too */
    memset(t, 0, sizeof t);
    size_t ns = (size_t)width * height * samples, nw = (size_t)win[2] * win[3] * samples;
    double *ref_iw = calloc(ns, sizeof *ref_iw);
    int32_t *ref_face = malloc(ns * sizeof *ref_face);
    float *ref_attr = calloc(ns * CRISP_RASTER_ATTRS, sizeof *ref_attr);
    for (int k = 0; k < 4; k++) {
        assert_int_equal(crisp__raster_target_init(&t[k], win[2], win[3], samples), CRISP_OK);
        crisp__raster_target_clear(&t[k]);
    }
    /* Depth already drawn (a surface at W = 6 over the left half): splats behind it stay hidden. */
    for (size_t i = 0; i < ns; i++) {
        size_t px = i / (size_t)samples;
        int x = (int)(px % (size_t)width);
        ref_face[i] = -1;
        if (x < width / 2) {
            ref_iw[i] = 1.0 / 6, ref_face[i] = 7;
            for (int a = 0; a < CRISP_RASTER_ATTRS; a++)
                ref_attr[i * CRISP_RASTER_ATTRS + a] = -3;
        }
    }
    /* sample s of pixel (x, y) of the window: sample at[s] of the image */
    size_t *at = malloc(nw * sizeof *at);
    for (int y = 0; y < win[3]; y++)
        for (int x = 0; x < win[2]; x++)
            for (int q = 0; q < samples; q++)
                at[((size_t)y * win[2] + x) * samples + q] =
                    ((size_t)(y + win[1]) * width + (x + win[0])) * samples + q;
    for (int k = 0; k < 4; k++)
        for (size_t i = 0; i < nw; i++) {
            t[k].inv_w[i] = ref_iw[at[i]], t[k].face[i] = ref_face[at[i]];
            memcpy(t[k].attr + i * CRISP_RASTER_ATTRS, ref_attr + at[i] * CRISP_RASTER_ATTRS,
                   CRISP_RASTER_ATTRS * sizeof *ref_attr);
        }
    double *start_iw = malloc(nw * sizeof *start_iw);
    memcpy(start_iw, t[0].inv_w, nw * sizeof *start_iw);
    /* The reference: every splat against every sample, in draw order. */
    long covered = 0;
    for (int k = 0; k < N; k++) {
        const crisp_plan_splat *s = &sp[k];
        const float *o = clip_origin + 4 * sp_face[k], *m = plan.view_proj_f;
        float c[4];
        for (int q = 0; q < 4; q++)
            c[q] = o[q] + m[q] * s->p[0] + m[q + 4] * s->p[1] + m[q + 8] * s->p[2];
        double w = c[3];
        if (!(w > 0) || !(c[2] >= -w) || !(c[2] <= w)) continue;
        double cx = ((double)c[0] / w + 1) * 0.5 * width,
               cy = (1 - (double)c[1] / w) * 0.5 * height;
        double iw = 1.0 / w;
        for (int j = 0; j < height; j++)
            for (int i = 0; i < width; i++)
                for (int q = 0; q < samples; q++) {
                    double off[2];
                    crisp__raster_sample_offset(samples, q, off);
                    double x = i + off[0], y = j + off[1];
                    if (!(cx - 0.5 <= x && x < cx + 0.5 && cy - 0.5 <= y && y < cy + 0.5)) continue;
                    covered++;
                    size_t idx = ((size_t)j * width + i) * samples + q;
                    if (!(iw > ref_iw[idx])) continue;
                    ref_iw[idx] = iw;
                    ref_face[idx] = (int32_t)sp_face[k];
                    float sg = sp_face[k] == 1 ? -1.0f : 1.0f, n[3];
                    crisp_plan_splat_normal(s->n, n);
                    float *a = ref_attr + idx * CRISP_RASTER_ATTRS;
                    a[0] = s->uv[0], a[1] = s->uv[1];
                    a[2] = sg * n[0], a[3] = sg * n[1], a[4] = sg * n[2];
                }
    }
    assert_true(covered > 50);
    crisp_pool *pool;
    assert_int_equal(crisp_pool_create(3, &pool), CRISP_OK);
    crisp__splat_scratch scratch = {0};
    crisp__splat_draw_desc d = {.plan = &plan, .win = {win[0], win[1], win[2], win[3]}};
    crisp__splat_draw_stats stats;
    assert_int_equal(crisp__splat_draw(&scratch, &t[0], NULL, &d, &stats), CRISP_OK);
    assert_int_equal(stats.ranges, NR);
    /* every sample written lies in the blocks the stats name */
    for (size_t i = 0; i < nw; i++) {
        if (t[0].inv_w[i] == start_iw[i]) continue;
        int x = (int)(i / (size_t)samples % (size_t)win[2]),
            y = (int)(i / (size_t)samples / (size_t)win[2]);
        assert_true(x / CRISP_OCCL_BLOCK >= stats.box[0] && x / CRISP_OCCL_BLOCK <= stats.box[2]);
        assert_true(y / CRISP_OCCL_BLOCK >= stats.box[1] && y / CRISP_OCCL_BLOCK <= stats.box[3]);
    }
    /* the same ranges hidden on 3 threads */
    crisp__splat_draw_stats stats3;
    assert_int_equal(crisp__splat_draw(&scratch, &t[1], pool, &d, &stats3), CRISP_OK);
    assert_int_equal(stats3.hidden_ranges, stats.hidden_ranges);
    assert_memory_equal(stats3.box, stats.box, sizeof stats.box);
    /* Culling (occlude) skips only what could not be drawn: the same samples. */
    int bw = (win[2] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK,
        bh = (win[3] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK;
    double *hiz = malloc((size_t)bw * bh * sizeof *hiz);
    crisp__raster_block_depth(&t[3], NULL, CRISP_OCCL_BLOCK, NULL, hiz);
    crisp__splat_draw_desc dc = d;
    dc.occlude = 1;
    crisp__splat_draw_stats sc;
    assert_int_equal(crisp__splat_draw(&scratch, &t[2], pool, &dc, &sc), CRISP_OK);
    dc.hiz = hiz;
    assert_int_equal(crisp__splat_draw(&scratch, &t[3], NULL, &dc, &sc), CRISP_OK);
    assert_true(sc.hidden_ranges + sc.culled + sc.chunks_culled > 0);
    for (int k = 2; k < 4; k++) {
        assert_memory_equal(t[0].inv_w, t[k].inv_w, nw * sizeof *ref_iw);
        assert_memory_equal(t[0].face, t[k].face, nw * sizeof *ref_face);
        assert_memory_equal(t[0].attr, t[k].attr, nw * CRISP_RASTER_ATTRS * sizeof *ref_attr);
    }
    free(hiz);
    long differ = 0;
    for (size_t i = 0; i < nw; i++) {
        size_t r = at[i];
        int bad = t[0].face[i] != ref_face[r] || t[0].inv_w[i] != ref_iw[r] ||
                  memcmp(t[0].attr + i * CRISP_RASTER_ATTRS, ref_attr + r * CRISP_RASTER_ATTRS,
                         CRISP_RASTER_ATTRS * sizeof(float));
        if (bad && differ < 5)
            fprintf(stderr, "%d samples: sample %zu: face %d iw %g, reference face %d iw %g\n",
                    samples, i, t[0].face[i], t[0].inv_w[i], ref_face[r], ref_iw[r]);
        differ += bad;
    }
    assert_int_equal(differ, 0);
    /* The same on 3 threads, bit for bit. */
    assert_memory_equal(t[0].inv_w, t[1].inv_w, nw * sizeof *ref_iw);
    assert_memory_equal(t[0].face, t[1].face, nw * sizeof *ref_face);
    assert_memory_equal(t[0].attr, t[1].attr, nw * CRISP_RASTER_ATTRS * sizeof *ref_attr);
    free(at), free(start_iw);
    crisp__splat_scratch_free(&scratch);
    crisp_pool_destroy(pool);
    for (int k = 0; k < 4; k++)
        crisp__raster_target_free(&t[k]);
    free(ref_iw), free(ref_face), free(ref_attr);
}

static void draw_case(int samples, int width, int height)
{
    draw_case_window(samples, width, height, (int[4]){0, 0, width, height}, 0);
}

static void test_draw_reference(void **state)
{
    (void)state;
    draw_case(1, 37, 23);
    draw_case(4, 29, 41);
    draw_case(16, 19, 17);
    draw_case(1, 64, 48);
}

/* Many small ranges (each a few pixels across, many across the edge of a band of rows), and
 * targets that are a window of the image (bands counted from the window's first row). */
static void test_draw_small_ranges(void **state)
{
    (void)state;
    draw_case_window(1, 64, 48, (int[4]){0, 0, 64, 48}, 1);
    draw_case_window(1, 96, 80, (int[4]){0, 0, 96, 80}, 1);
    draw_case_window(1, 96, 80, (int[4]){13, 7, 61, 53}, 1);
    draw_case_window(4, 96, 80, (int[4]){5, 21, 70, 45}, 1);
    draw_case_window(1, 64, 48, (int[4]){9, 11, 40, 30}, 0);
    draw_case_window(16, 40, 36, (int[4]){3, 5, 30, 25}, 1);
}

/* ---- the choice ------------------------------------------------------------------------------ */

/* A bilinear strip from (x0, 0, z0) to (x0 + w, 0, z1): along the view axis (-Z) when seen from
 * +Z. */
static crisp_model *strip_model(double x0, double w, double z0, double z1)
{
    crisp_model *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    double knots[4] = {0, 0, 1, 1};
    double pts[12] = {x0, 0, z0, x0 + w, 0, z0, x0, 0, z1, x0 + w, 0, z1};
    crisp_surface *s;
    assert_int_equal(crisp_surface_create(1, 1, 2, 2, knots, knots, pts, NULL, &s), CRISP_OK);
    crisp_face f = {.surface = s};
    assert_int_equal(crisp_model_add_face(m, &f), CRISP_OK);
    return m;
}

static void test_choice_near_plane(void **state)
{
    (void)state;
    /* The strip x in [0, 0.01], z from 0 to -0.1; the eye at z = 10.2 looking down -Z. Its box
     * spans W from 10.2 to 10.3: about 0.1 px across at 64 px wide. */
    crisp_model *m = strip_model(0, 0.01, 0, -0.1);
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_camera cam = {.eye = {0.002, 0.001, 10.2},
                        .target = {0.002, 0.001, 0},
                        .up = {0, 1, 0},
                        .fov_deg = 30,
                        .znear = 1,
                        .zfar = 100,
                        .width = 64,
                        .height = 48};
    crisp_planner *pl, *off;
    assert_int_equal(crisp_planner_create(NULL, NULL, &pl), CRISP_OK);
    assert_int_equal(crisp_planner_create(&(crisp_planner_desc){.no_splats = 1}, NULL, &off),
                     CRISP_OK);
    const crisp_frame_plan *plan;
    assert_int_equal(crisp_planner_plan(pl, sc, &cam, &plan), CRISP_OK);
    assert_true(plan->faces[0].flags & CRISP_PLAN_FACE_SPLATS);
    assert_int_equal(plan->faces[0].leaf_count, 0);
    assert_int_equal(plan->faces[0].strip_count, 0);
    assert_int_equal(plan->faces[0].ribbon_count, 0);
    assert_int_equal(plan->splat_range_count, 1);
    assert_true(plan->splat_ranges[0].count > 0);
    assert_int_equal(plan->stats.splat_faces, 1);
    assert_true(plan->stats.splat_bytes > 0);
    assert_int_equal(plan->splat_ranges[0].face, 0);
    /* The near plane through the box (at z = -0.05 of the strip): not splatted, planned as a
     * patch. */
    crisp_camera cut = cam;
    cut.znear = 10.25;
    assert_int_equal(crisp_planner_plan(pl, sc, &cut, &plan), CRISP_OK);
    assert_false(plan->faces[0].flags & CRISP_PLAN_FACE_SPLATS);
    assert_int_equal(plan->splat_range_count, 0);
    assert_true(plan->faces[0].leaf_count > 0);
    /* Splats off. */
    assert_int_equal(crisp_planner_plan(off, sc, &cam, &plan), CRISP_OK);
    assert_false(plan->faces[0].flags & CRISP_PLAN_FACE_SPLATS);
    assert_int_equal(plan->splat_range_count, 0);
    assert_true(plan->faces[0].leaf_count > 0);
    crisp_planner_destroy(pl);
    crisp_planner_destroy(off);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* ---- images of bundled models -----------------------------------------------------------------
 */

static int exact_classify(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)ctx;
    const crisp_scene_face *f = &sc->faces[face];
    if (!f->piece_count) return 1;
    return crisp_trim_exact_classify(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
}

/* A view of the scene from a random direction with its bounding sphere radius_px on screen. */
static crisp_camera far_view(const crisp_scene *sc, double radius_px, int w, int h)
{
    double c[3], r = 0, d[3], n;
    for (int q = 0; q < 3; q++) {
        c[q] = 0.5 * (sc->box[q] + sc->box[q + 3]);
        r += 0.25 * (sc->box[q + 3] - sc->box[q]) * (sc->box[q + 3] - sc->box[q]);
    }
    r = sqrt(r);
    do {
        for (int q = 0; q < 3; q++)
            d[q] = 2 * rnd() - 1;
        n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    } while (n < 0.1 || n > 1);
    crisp_camera cam = {.width = w, .height = h, .up = {0.1, 1, 0.2}, .fov_deg = 30};
    double dist = r * (0.5 * h) / (radius_px * tan(15 * M_PI / 180));
    for (int q = 0; q < 3; q++)
        cam.eye[q] = c[q] + dist * d[q] / n, cam.target[q] = c[q] + 0.1 * r * (2 * rnd() - 1);
    cam.znear = 0.5 * dist, cam.zfar = 2 * dist;
    return cam;
}

typedef struct view_case {
    const char *model;
    double radius_px;
} view_case;

static const view_case cases[] = {
    {"occt_linkrods.step", 15}, {"occt_linkrods.step", 30}, {"occt_bearing.iges", 20},
    {"occt_bearing.iges", 40},  {"impeller.igs", 25},       {"impeller.igs", 50},
    {"gpucast_teapot.igs", 15}, {"occt_hammer.iges", 30},
};

/* For each case: a far view, the CPU image with splats (1 sample), its plan, and the exact image;
 * calls check() on them. */
typedef void (*check_fn)(const crisp_scene *sc, const crisp_camera *cam,
                         const crisp_frame_plan *plan, const crisp_image *cpu,
                         const crisp_image *ex, long *counts);

static void run_cases(check_fn check, long *counts, int views)
{
    long splat_faces = 0;
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        crisp_model *m = rt_load_model(cases[k].model);
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
        crisp_renderer *r;
        assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
        crisp_image cpu, ex;
        const int w = 160, h = 120;
        assert_int_equal(crisp_image_init(&cpu, w, h), CRISP_OK);
        assert_int_equal(crisp_image_init(&ex, w, h), CRISP_OK);
        for (int v = 0; v < views; v++) {
            crisp_camera cam = far_view(sc, cases[k].radius_px, w, h);
            crisp_render_stats st;
            assert_int_equal(crisp_render_cpu(r, sc, &cam, &cpu, &st), CRISP_OK);
            const crisp_frame_plan *plan;
            assert_int_equal(crisp_planner_plan(crisp_renderer_planner(r), sc, &cam, &plan),
                             CRISP_OK);
            splat_faces += plan->stats.splat_faces;
            crisp_exact_desc ed = {.threads = 2, .classify = exact_classify};
            assert_int_equal(crisp_render_exact(sc, &cam, &ed, &ex), CRISP_OK);
            check(sc, &cam, plan, &cpu, &ex, counts);
        }
        crisp_image_free(&cpu);
        crisp_image_free(&ex);
        crisp_renderer_destroy(r);
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
    }
    printf("%ld faces drawn as splats over the views\n", splat_faces);
    assert_true(splat_faces > 20);
}

/* counts: [0] pixels of splatted faces checked, [1] of them not a true point within 0.5 px. */
static void check_true_points(const crisp_scene *sc, const crisp_camera *cam,
                              const crisp_frame_plan *plan, const crisp_image *cpu,
                              const crisp_image *ex, long *counts)
{
    (void)ex;
    crisp_camera_matrices cm;
    crisp_camera_matrices_compute(cam, &cm);
    for (int j = 0; j < cpu->height; j++)
        for (int i = 0; i < cpu->width; i++) {
            size_t p = (size_t)j * cpu->width + (size_t)i;
            int32_t f = cpu->face[p];
            if (f < 0 || !(plan->faces[f].flags & CRISP_PLAN_FACE_SPLATS)) continue;
            counts[0]++;
            double u = cpu->uv[2 * p], v = cpu->uv[2 * p + 1], P[3], c[4], s[3];
            /* inside the trim, or on a trim curve (splats are points of the trimmed face, its
             * boundary included; (u, v) in float) */
            int inside = exact_classify(NULL, sc, (uint32_t)f, u, v);
            const crisp_scene_face *sf = &sc->faces[f];
            if (!inside) {
                double ext =
                    fmax(fabs(sf->domain[1] - sf->domain[0]), fabs(sf->domain[3] - sf->domain[2]));
                double dist = crisp_trim_exact_distance(sc->pieces + sf->first_piece,
                                                        (int)sf->piece_count, u, v);
                inside = dist <= 1e-6 * ext + 1e-6 * (fabs(u) + fabs(v));
            }
            crisp_surface_eval(sc->faces[f].src->surface, u, v, P);
            crisp_mat4_mulp(cm.view_proj, P, c);
            crisp_camera_to_pixel(cam, c, s);
            /* 0.5 px, and float (u, v) and clip arithmetic: 1e-3 px */
            double e = fmax(fabs(s[0] - (i + 0.5)), fabs(s[1] - (j + 0.5)));
            if (!inside || !(e <= 0.5 + 1e-3)) {
                if (counts[1] < 8)
                    fprintf(stderr, "pixel (%d, %d) face %d: uv %g %g inside %d, %.4f px away\n", i,
                            j, f, u, v, inside, e);
                counts[1]++;
            }
        }
}

static void test_true_points(void **state)
{
    (void)state;
    long counts[2] = {0, 0};
    run_cases(check_true_points, counts, 3);
    printf("%ld pixels of splatted faces, %ld not a true point within 0.5 px\n", counts[0],
           counts[1]);
    assert_true(counts[0] > 30);
    assert_int_equal(counts[1], 0);
}

/* counts: [0] pixel centres whose exact ray meets a splatted face, [1] of them not covered. */
static void check_no_holes(const crisp_scene *sc, const crisp_camera *cam,
                           const crisp_frame_plan *plan, const crisp_image *cpu,
                           const crisp_image *ex, long *counts)
{
    (void)sc, (void)cam;
    for (size_t p = 0; p < (size_t)ex->width * ex->height; p++) {
        int32_t f = ex->face[p];
        if (f < 0 || !(plan->faces[f].flags & CRISP_PLAN_FACE_SPLATS)) continue;
        counts[0]++;
        if (cpu->face[p] < 0) {
            if (counts[1] < 8)
                fprintf(stderr, "pixel (%zu, %zu): exact face %d (splatted), background drawn\n",
                        p % (size_t)ex->width, p / (size_t)ex->width, f);
            counts[1]++;
        }
    }
}

static void test_no_holes(void **state)
{
    (void)state;
    long counts[2] = {0, 0};
    run_cases(check_no_holes, counts, 3);
    printf("%ld pixel centres on splatted faces, %ld not covered\n", counts[0], counts[1]);
    assert_true(counts[0] > 30);
    assert_int_equal(counts[1], 0);
}

/* Closed solids far away: no background where the exact image sees the solid on a pixel and its
 * 8 neighbours. */
static void test_solids_far(void **state)
{
    (void)state;
    static const char *names[2] = {"occt_linkrods.step", "occt_bearing.iges"};
    long inside = 0, background = 0, splat_faces = 0, patch_faces = 0;
    for (int k = 0; k < 2; k++) {
        crisp_model *m = rt_load_model(names[k]);
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
        for (int samples = 1; samples <= 4; samples *= 4) {
            crisp_renderer *r;
            assert_int_equal(
                crisp_renderer_create(&(crisp_render_desc){.threads = 2, .samples = samples}, &r),
                CRISP_OK);
            const int w = 120, h = 90;
            crisp_image cpu, ex;
            assert_int_equal(crisp_image_init(&cpu, w, h), CRISP_OK);
            assert_int_equal(crisp_image_init(&ex, w, h), CRISP_OK);
            for (int v = 0; v < 4; v++) {
                crisp_camera cam = far_view(sc, 15 + 12 * v, w, h);
                crisp_render_stats st;
                assert_int_equal(crisp_render_cpu(r, sc, &cam, &cpu, &st), CRISP_OK);
                splat_faces += st.splat_faces;
                patch_faces += st.visible_faces;
                crisp_exact_desc ed = {.threads = 2, .classify = exact_classify};
                assert_int_equal(crisp_render_exact(sc, &cam, &ed, &ex), CRISP_OK);
                for (int j = 1; j < h - 1; j++)
                    for (int i = 1; i < w - 1; i++) {
                        int all = 1;
                        for (int dj = -1; dj <= 1; dj++)
                            for (int di = -1; di <= 1; di++)
                                all &= ex.face[(size_t)(j + dj) * w + (size_t)(i + di)] >= 0;
                        if (!all) continue;
                        inside++;
                        if (cpu.face[(size_t)j * w + (size_t)i] < 0) {
                            if (background < 8)
                                fprintf(stderr, "%s view %d, %d samples: background at (%d, %d)\n",
                                        names[k], v, samples, i, j);
                            background++;
                        }
                    }
            }
            crisp_image_free(&cpu);
            crisp_image_free(&ex);
            crisp_renderer_destroy(r);
        }
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
    }
    printf(
        "%ld pixels inside silhouettes, %ld background; %ld splatted and %ld patch-drawn faces\n",
        inside, background, splat_faces, patch_faces);
    assert_true(inside > 1000);
    assert_true(splat_faces > 50 && patch_faces > 10); /* both kinds of faces side by side */
    assert_int_equal(background, 0);
}

static int at_edge(const crisp_image *im, int i, int j)
{
    int32_t f = im->face[(size_t)j * im->width + (size_t)i];
    for (int dj = -1; dj <= 1; dj++)
        for (int di = -1; di <= 1; di++) {
            int x = i + di, y = j + dj;
            if (x < 0 || y < 0 || x >= im->width || y >= im->height) continue;
            if (im->face[(size_t)y * im->width + (size_t)x] != f) return 1;
        }
    return 0;
}

static void test_near_edges(void **state)
{
    (void)state;
    long differ = 0, inner = 0, splat_faces = 0;
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        crisp_model *m = rt_load_model(cases[k].model);
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
        crisp_renderer *on, *off;
        assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &on), CRISP_OK);
        assert_int_equal(
            crisp_renderer_create(&(crisp_render_desc){.threads = 2, .no_splats = 1}, &off),
            CRISP_OK);
        const int w = 160, h = 120;
        crisp_image a, b;
        assert_int_equal(crisp_image_init(&a, w, h), CRISP_OK);
        assert_int_equal(crisp_image_init(&b, w, h), CRISP_OK);
        for (int v = 0; v < 2; v++) {
            crisp_camera cam = far_view(sc, cases[k].radius_px, w, h);
            crisp_render_stats st;
            assert_int_equal(crisp_render_cpu(on, sc, &cam, &a, &st), CRISP_OK);
            splat_faces += st.splat_faces;
            assert_int_equal(crisp_render_cpu(off, sc, &cam, &b, NULL), CRISP_OK);
            for (int j = 0; j < h; j++)
                for (int i = 0; i < w; i++) {
                    size_t p = (size_t)j * w + (size_t)i;
                    if (a.face[p] == b.face[p]) continue;
                    differ++;
                    if (!at_edge(&a, i, j) && !at_edge(&b, i, j)) {
                        if (inner < 8)
                            fprintf(stderr, "%s: (%d, %d) face %d with splats, %d without\n",
                                    cases[k].model, i, j, a.face[p], b.face[p]);
                        inner++;
                    }
                }
        }
        crisp_image_free(&a);
        crisp_image_free(&b);
        crisp_renderer_destroy(on);
        crisp_renderer_destroy(off);
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
    }
    printf("%ld pixels differ with splats (%ld splatted faces), %ld away from face edges\n", differ,
           splat_faces, inner);
    assert_true(splat_faces > 20);
    assert_int_equal(inner, 0);
}

/* ---- a per-frame build limit ---------------------------------------------------------------- */

static int images_equal(const crisp_image *a, const crisp_image *b)
{
    size_t n = (size_t)a->width * a->height;
    return !memcmp(a->rgba, b->rgba, 4 * n * sizeof *a->rgba) &&
           !memcmp(a->depth, b->depth, n * sizeof *a->depth) &&
           !memcmp(a->normal, b->normal, 3 * n * sizeof *a->normal) &&
           !memcmp(a->uv, b->uv, 2 * n * sizeof *a->uv) &&
           !memcmp(a->face, b->face, n * sizeof *a->face);
}

/* crisp_planner_desc.splat_build_limit: a view planned and drawn frame after frame with a small
 * limit (each frame builds one chunk of sets, the faces not built yet are drawn as patches) until
 * nothing is pending. Every frame keeps the guarantee: its splatted faces' pixels are true points
 * within 0.5 px and cover every pixel centre whose exact ray meets them, and its pixels differ
 * from the image without splats only at face edges (as test_near_edges); each frame splats more
 * faces and leaves fewer pending; the last frame is bit for bit the one a planner without a limit
 * draws (so are the frames after it). */
static void test_build_limit(void **state)
{
    (void)state;
    static const view_case lim_cases[] = {{"impeller.igs", 60}, {"occt_bearing.iges", 40}};
    long frames = 0, counts_tp[2] = {0, 0}, counts_nh[2] = {0, 0}, inner = 0;
    for (size_t k = 0; k < sizeof lim_cases / sizeof lim_cases[0]; k++) {
        crisp_model *m = rt_load_model(lim_cases[k].model);
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
        crisp_renderer *r;
        assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
        crisp_planner *full, *lim, *off;
        assert_int_equal(crisp_planner_create(NULL, NULL, &full), CRISP_OK);
        assert_int_equal(
            crisp_planner_create(&(crisp_planner_desc){.splat_build_limit = 1}, NULL, &lim),
            CRISP_OK);
        assert_int_equal(crisp_planner_create(&(crisp_planner_desc){.no_splats = 1}, NULL, &off),
                         CRISP_OK);
        const int w = 240, h = 180;
        crisp_image ref, img, ex, nos;
        assert_int_equal(crisp_image_init(&ref, w, h), CRISP_OK);
        assert_int_equal(crisp_image_init(&img, w, h), CRISP_OK);
        assert_int_equal(crisp_image_init(&ex, w, h), CRISP_OK);
        assert_int_equal(crisp_image_init(&nos, w, h), CRISP_OK);
        crisp_camera cam = far_view(sc, lim_cases[k].radius_px, w, h);
        const crisp_frame_plan *plan;
        assert_int_equal(crisp_planner_plan(full, sc, &cam, &plan), CRISP_OK);
        uint32_t want = plan->stats.splat_faces;
        assert_int_equal(plan->stats.splat_pending, 0);
        assert_int_equal(crisp_render_cpu_plan(r, sc, plan, &cam, &ref, NULL), CRISP_OK);
        assert_int_equal(crisp_planner_plan(off, sc, &cam, &plan), CRISP_OK);
        assert_int_equal(crisp_render_cpu_plan(r, sc, plan, &cam, &nos, NULL), CRISP_OK);
        crisp_exact_desc ed = {.threads = 2, .classify = exact_classify};
        assert_int_equal(crisp_render_exact(sc, &cam, &ed, &ex), CRISP_OK);
        uint32_t last_faces = 0, last_pending = UINT32_MAX;
        int n = 0;
        for (;; n++) {
            assert_true(n < 100);
            assert_int_equal(crisp_planner_plan(lim, sc, &cam, &plan), CRISP_OK);
            assert_int_equal(crisp_render_cpu_plan(r, sc, plan, &cam, &img, NULL), CRISP_OK);
            uint32_t pending = plan->stats.splat_pending;
            printf("%s frame %d: %u faces splatted, %u pending\n", lim_cases[k].model, n,
                   plan->stats.splat_faces, pending);
            assert_true(pending < last_pending);
            assert_true(plan->stats.splat_faces >= last_faces);
            /* the faces left are pending (some of them may be refused when built) */
            assert_true(plan->stats.splat_faces <= want);
            assert_true((uint64_t)plan->stats.splat_faces + pending >= want);
            last_faces = plan->stats.splat_faces, last_pending = pending;
            check_true_points(sc, &cam, plan, &img, &ex, counts_tp);
            check_no_holes(sc, &cam, plan, &img, &ex, counts_nh);
            for (int j = 0; j < h; j++)
                for (int i = 0; i < w; i++) {
                    size_t p = (size_t)j * w + (size_t)i;
                    if (img.face[p] != nos.face[p] && !at_edge(&img, i, j) && !at_edge(&nos, i, j))
                        inner++;
                }
            if (!pending) break;
            assert_false(images_equal(&img, &ref) && n == 0); /* the first frame is not the last */
        }
        frames += n + 1;
        assert_true(n >= 2); /* the limit spread the builds over several frames */
        assert_int_equal(plan->stats.splat_faces, want);
        assert_true(images_equal(&img, &ref));
        /* and the frame after it too */
        assert_int_equal(crisp_planner_plan(lim, sc, &cam, &plan), CRISP_OK);
        assert_int_equal(crisp_render_cpu_plan(r, sc, plan, &cam, &img, NULL), CRISP_OK);
        assert_true(images_equal(&img, &ref));
        crisp_image_free(&ref), crisp_image_free(&img), crisp_image_free(&ex);
        crisp_image_free(&nos);
        crisp_planner_destroy(full), crisp_planner_destroy(lim), crisp_planner_destroy(off);
        crisp_renderer_destroy(r);
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
    }
    printf("%ld frames; splatted pixels %ld (%ld not true points), splatted centres %ld (%ld "
           "holes), %ld pixels differing from the image without splats away from edges\n",
           frames, counts_tp[0], counts_tp[1], counts_nh[0], counts_nh[1], inner);
    assert_true(counts_tp[0] > 100 && counts_nh[0] > 100);
    assert_int_equal(counts_tp[1], 0);
    assert_int_equal(counts_nh[1], 0);
    assert_int_equal(inner, 0);
}

/* ---- the choice per group of faces ------------------------------------------------------------
 */

/* impeller.igs n x n times in a grid (bench/bench_scenes.h's instancing) */
static crisp_model *instanced(const char *name, int n)
{
    crisp_model *src = rt_load_model(name), *m;
    assert_int_equal(crisp_model_create(&m), CRISP_OK);
    double box[6];
    crisp_model_bbox(src, box);
    double sx = 1.1 * (box[3] - box[0]), sy = 1.1 * (box[4] - box[1]);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++)
            for (int f = 0; f < src->face_count; f++) {
                crisp_face face;
                assert_int_equal(crisp_face_copy(&src->faces[f], &face), CRISP_OK);
                const double t[3][4] = {{1, 0, 0, i * sx}, {0, 1, 0, j * sy}, {0, 0, 1, 0}};
                crisp_face_transform(&face, t);
                assert_int_equal(crisp_model_add_face(m, &face), CRISP_OK);
            }
    crisp_model_destroy(src);
    return m;
}

/* A view from a random direction with the scene's bounding sphere radius_px on screen, aimed at a
 * random point up to `off` radii from its centre (so part of it may be off screen), the near
 * plane at `cut` radii in front of the centre (below 1: through the scene). */
/* cam planned by pl (which planned other views before) and by a new planner (returned, for the
 * caller to destroy after comparing more): their face records must be the same bytes. */
static crisp_planner *plan_beside_fresh(crisp_planner *pl, const crisp_scene *sc,
                                        const crisp_camera *cam, const crisp_frame_plan **plan,
                                        const crisp_frame_plan **ref)
{
    crisp_planner *fresh;
    assert_int_equal(crisp_planner_plan(pl, sc, cam, plan), CRISP_OK);
    assert_int_equal(crisp_planner_create(NULL, NULL, &fresh), CRISP_OK);
    assert_int_equal(crisp_planner_plan(fresh, sc, cam, ref), CRISP_OK);
    assert_int_equal(
        memcmp((*plan)->faces, (*ref)->faces, sc->face_count * sizeof(crisp_plan_face)), 0);
    return fresh;
}

static crisp_camera group_view_camera(const crisp_scene *sc, double radius_px, double off,
                                      double cut, int w, int h)
{
    crisp_camera cam = far_view(sc, radius_px, w, h);
    double c[3], r = 0, d = 0;
    for (int q = 0; q < 3; q++) {
        c[q] = 0.5 * (sc->box[q] + sc->box[q + 3]);
        r += 0.25 * (sc->box[q + 3] - sc->box[q]) * (sc->box[q + 3] - sc->box[q]);
        d += (cam.eye[q] - c[q]) * (cam.eye[q] - c[q]);
    }
    r = sqrt(r), d = sqrt(d);
    for (int q = 0; q < 3; q++)
        cam.target[q] = c[q] + off * r * (2 * rnd() - 1);
    cam.znear = d - cut * r > 1e-3 * d ? d - cut * r : 1e-3 * d;
    cam.zfar = d + 1.2 * r;
    return cam;
}

/* crisp__splat_store_choose decides groups of faces at once (the faces' tree: whole groups off
 * screen, or far enough that one bound gives each face its level). Its levels and near W must be
 * want_level's, face by face, bit for bit: random views of impeller.igs 3 x 3 and of
 * occt_linkrods.step, far (a few pixels per face) to close, partly off screen, the near and far
 * planes through the scene, with the sets built by earlier choices (built and refused levels). */
static void test_group_choice(void **state)
{
    (void)state;
    static const double radii[] = {4, 12, 40, 120, 400, 1500};
    uint64_t total[3] = {0, 0, 0};
    long faces = 0, splatted = 0, differ = 0;
    for (int k = 0; k < 2; k++) {
        crisp_model *m = k ? rt_load_model("occt_linkrods.step") : instanced("impeller.igs", 3);
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
        crisp__splat_store *s;
        assert_int_equal(crisp__splat_store_create(&s), CRISP_OK);
        int8_t *wa = malloc(sc->face_count), *wb = malloc(sc->face_count);
        uint8_t *splat = malloc(sc->face_count);
        double *na = malloc(sc->face_count * sizeof *na), *nb = malloc(sc->face_count * sizeof *nb);
        assert_non_null(wa), assert_non_null(wb), assert_non_null(splat);
        assert_non_null(na), assert_non_null(nb);
        const int w = 320, h = 240;
        for (int v = 0; v < 60; v++) {
            double radius = radii[v % 6] * (0.8 + 0.4 * rnd());
            double off = v % 3 == 0 ? 0 : v % 3 == 1 ? 0.5 : 1.5;
            double cut = v % 4 == 3 ? 0.3 : 3;
            crisp_camera cam = group_view_camera(sc, radius, off, cut, w, h);
            crisp_camera_matrices cm;
            crisp_camera_matrices_compute(&cam, &cm);
            if (v % 5 == 0) /* builds the sets this view wants (later views meet them) */
                assert_int_equal(
                    crisp__splat_store_choose(s, sc, cm.view_proj, w, h, 0, NULL, splat), CRISP_OK);
            assert_int_equal(crisp__splat_store_test_want(s, sc, cm.view_proj, w, h, 0, wa, na),
                             CRISP_OK);
            assert_int_equal(crisp__splat_store_test_want(s, sc, cm.view_proj, w, h, 1, wb, nb),
                             CRISP_OK);
            uint64_t counts[3];
            crisp__splat_store_choice_counts(s, counts);
            assert_int_equal(counts[0] + counts[1] + counts[2], sc->face_count);
            for (int q = 0; q < 3; q++)
                total[q] += counts[q];
            for (uint32_t f = 0; f < sc->face_count; f++) {
                faces++;
                splatted += wa[f] >= 0;
                if (wa[f] == wb[f] && (wa[f] < 0 || memcmp(&na[f], &nb[f], sizeof na[f]) == 0))
                    continue;
                if (differ < 8)
                    fprintf(stderr,
                            "view %d face %u: level %d (W %.17g) face by face, %d (%.17g) "
                            "by groups\n",
                            v, f, wa[f], na[f], wb[f], nb[f]);
                differ++;
            }
        }
        free(wa), free(wb), free(splat), free(na), free(nb);
        crisp__splat_store_destroy(s);
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
    }
    printf("%ld face choices (%ld splatted): %llu culled by groups, %llu by their group's bound, "
           "%llu one by one; %ld differ\n",
           faces, splatted, (unsigned long long)total[0], (unsigned long long)total[1],
           (unsigned long long)total[2], differ);
    assert_int_equal(differ, 0);
    /* the groups' rules are used: most faces are decided by them */
    assert_true(splatted > faces / 10);
    assert_true(total[0] > (uint64_t)faces / 20 && total[1] > (uint64_t)faces / 4);
}

/* The plan's splat ranges come nearest first: by the least W of the face's box (as a float
 * rounded up), ties in face order (publish's radix sort; the draw's culling and its ties rely on
 * it). */
/* The plan's splat ranges are its splat faces (CRISP_PLAN_FACE_SPLATS), each once, nearest first:
 * by their boxes' least W as a float rounded up, ties in face order. Returns the ranges. */
static long check_range_order(const crisp_scene *sc, const crisp_camera *cam,
                              const crisp_frame_plan *plan)
{
    crisp_camera_matrices cm;
    crisp_camera_matrices_compute(cam, &cm);
    uint8_t *seen = calloc(sc->face_count, 1);
    assert_non_null(seen);
    float last = 0;
    uint32_t last_face = 0;
    for (uint32_t i = 0; i < plan->splat_range_count; i++) {
        uint32_t f = plan->splat_ranges[i].face;
        assert_true(f < sc->face_count && !seen[f]);
        assert_true(plan->faces[f].flags & CRISP_PLAN_FACE_SPLATS);
        seen[f] = 1;
        const crisp_scene_face *sf = &sc->faces[f];
        double b[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
        for (uint32_t p = 0; p < sf->patch_count; p++)
            for (int a = 0; a < 3; a++) {
                b[a] = fmin(b[a], sc->patches[sf->first_patch + p].box[a]);
                b[a + 3] = fmax(b[a + 3], sc->patches[sf->first_patch + p].box[a + 3]);
            }
        double w = INFINITY;
        for (int k = 0; k < 8; k++)
            w = fmin(w, cm.view_proj[0][3] * b[k & 1 ? 3 : 0] +
                            cm.view_proj[1][3] * b[k & 2 ? 4 : 1] +
                            cm.view_proj[2][3] * b[k & 4 ? 5 : 2] + cm.view_proj[3][3]);
        float key = (float)w;
        if ((double)key < w) key = nextafterf(key, INFINITY);
        if (i > 0) {
            assert_true(key >= last);
            if (key == last) assert_true(f > last_face);
        }
        last = key, last_face = f;
    }
    uint32_t flagged = 0;
    for (uint32_t f = 0; f < sc->face_count; f++)
        flagged += (plan->faces[f].flags & CRISP_PLAN_FACE_SPLATS) != 0;
    assert_int_equal(flagged, plan->splat_range_count);
    free(seen);
    return plan->splat_range_count;
}

/* impeller.igs instanced twice, its scene, and a planner with the defaults (the draw order and
 * face record tests). */
static crisp_scene *two_impellers(crisp_model **m, crisp_planner **pl)
{
    *m = instanced("impeller.igs", 2);
    crisp_scene *sc = NULL;
    assert_int_equal(crisp_scene_prepare(*m, &sc), CRISP_OK);
    assert_int_equal(crisp_planner_create(NULL, NULL, pl), CRISP_OK);
    return sc;
}

static void test_range_order(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_planner *pl;
    crisp_scene *sc = two_impellers(&m, &pl);
    long ranges = 0;
    for (int v = 0; v < 6; v++) {
        crisp_camera cam = group_view_camera(sc, 30 + 40 * v, 0.3, 3, 320, 240);
        const crisp_frame_plan *plan;
        assert_int_equal(crisp_planner_plan(pl, sc, &cam, &plan), CRISP_OK);
        ranges += check_range_order(sc, &cam, plan);
    }
    printf("%ld ranges in order\n", ranges);
    assert_true(ranges > 100);
    crisp_planner_destroy(pl);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* publish starts from the last plan's draw order when the splat faces are the same
 * (splat_store.c, sorted_as_before): through a view repeated, turned by small steps (the order
 * changes a little), turned by a large one, and moved so that parts leave the screen (the faces
 * change), every plan's ranges are its splat faces in the draw order (check_range_order).
 * Taking the last order without sorting it fails it. */
static void test_kept_order(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_planner *pl;
    crisp_scene *sc = two_impellers(&m, &pl);
    crisp_camera base = group_view_camera(sc, 60, 0.0, 3, 320, 240);
    static const double turn[] = {0, 0, 0.2, 0.4, 0.4, 0.6, 8, 8.2, 30, 30, 30.1};
    long ranges = 0, same = 0;
    uint32_t last_count = 0;
    for (size_t i = 0; i < sizeof turn / sizeof turn[0] + 2; i++) {
        crisp_camera cam = base;
        double a = i < sizeof turn / sizeof turn[0] ? turn[i] * M_PI / 180 : 0;
        double d[2] = {cam.eye[0] - cam.target[0], cam.eye[1] - cam.target[1]};
        cam.eye[0] = cam.target[0] + cos(a) * d[0] - sin(a) * d[1];
        cam.eye[1] = cam.target[1] + sin(a) * d[0] + cos(a) * d[1];
        if (i >= sizeof turn / sizeof turn[0]) /* the target moved: parts off screen */
            for (int q = 0; q < 2; q++)
                cam.target[q] += (i % 2 ? 0.35 : 0.2) * (sc->box[q + 3] - sc->box[q]);
        const crisp_frame_plan *plan;
        assert_int_equal(crisp_planner_plan(pl, sc, &cam, &plan), CRISP_OK);
        ranges += check_range_order(sc, &cam, plan);
        same += i > 0 && plan->splat_range_count == last_count;
        last_count = plan->splat_range_count;
    }
    printf("%ld ranges in order, %ld plans with as many as the last\n", ranges, same);
    assert_true(ranges > 100 && same >= 5);
    crisp_planner_destroy(pl);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* A far view whose faces are all splats or culled lays out every face's record plain (no leaves,
 * table or ribbons), and the planner keeps the array as it is when the next such plan has the same
 * splat faces (planner.c, lay_out_faces). Through views that change the splat faces (parts off
 * screen), views repeated, and a nearer view with faces planned as patches in between, each plan's
 * face records equal a fresh planner's at that view byte for byte, and faces_version moves exactly
 * when the records' bytes change. Leaving the array as it is when the splat faces changed (the
 * shortcut without its comparison) fails it. */
static void test_plain_faces(void **state)
{
    (void)state;
    crisp_model *m;
    crisp_planner *pl;
    crisp_scene *sc = two_impellers(&m, &pl);
    size_t bytes = sc->face_count * sizeof(crisp_plan_face);
    crisp_plan_face *last = malloc(bytes);
    assert_non_null(last);
    crisp_camera views[3];
    for (int v = 0; v < 3; v++)
        views[v] = group_view_camera(sc, 10 + 4 * v, v ? 16.0 : 0.0, 3, 320, 240);
    crisp_camera near = group_view_camera(sc, 3000, 0.0, 3, 320, 240);
    static const int seq[] = {0, 0, 1, 1, 2, 0, 3, 0, 0, 2, 2, 1};
    uint64_t version = 0;
    int changed = 0, kept = 0, plain = 0;
    for (size_t i = 0; i < sizeof seq / sizeof seq[0]; i++) {
        const crisp_camera *cam = seq[i] == 3 ? &near : &views[seq[i]];
        const crisp_frame_plan *plan, *ref;
        crisp_planner *fresh = plan_beside_fresh(pl, sc, cam, &plan, &ref);
        int all_plain = 1;
        for (uint32_t f = 0; f < sc->face_count; f++)
            all_plain &= !(plan->faces[f].flags & CRISP_PLAN_FACE_VISIBLE);
        plain += all_plain;
        if (i > 0) {
            int differs = memcmp(last, plan->faces, bytes) != 0;
            assert_int_equal(plan->faces_version != version, differs);
            changed += differs, kept += !differs && all_plain;
        }
        version = plan->faces_version;
        memcpy(last, plan->faces, bytes);
        crisp_planner_destroy(fresh);
    }
    printf("%d plain plans, %d kept as they were, %d changed\n", plain, kept, changed);
    assert_true(plain >= 8 && kept >= 3 && changed >= 4);
    free(last);
    crisp_planner_destroy(pl);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* With a build limit the store builds the faces of the largest patches / 2^level first
 * (splat_store.c, order_todo): after one limited choice, every splatted face's key is at least
 * every pending face's (refused faces are neither). Face order (the earlier rule) fails it. */
static void test_build_order(void **state)
{
    (void)state;
    static const view_case cases[] = {{"impeller.igs", 60}, {"occt_bearing.iges", 40}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        crisp_model *m = rt_load_model(cases[k].model);
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
        const int w = 240, h = 180;
        crisp_camera cam = far_view(sc, cases[k].radius_px, w, h);
        crisp_camera_matrices cm;
        crisp_camera_matrices_compute(&cam, &cm);
        crisp__splat_store *s;
        assert_int_equal(crisp__splat_store_create(&s), CRISP_OK);
        uint32_t nf = sc->face_count;
        int8_t *want = malloc(nf), *after = malloc(nf);
        double *near = malloc(nf * sizeof *near);
        uint8_t *splat = malloc(nf);
        assert_int_equal(crisp__splat_store_test_want(s, sc, cm.view_proj, w, h, 1, want, near),
                         CRISP_OK);
        assert_int_equal(crisp__splat_store_choose(s, sc, cm.view_proj, w, h, 1, NULL, splat),
                         CRISP_OK);
        assert_int_equal(crisp__splat_store_test_want(s, sc, cm.view_proj, w, h, 1, after, near),
                         CRISP_OK);
        double lo = INFINITY, hi = -INFINITY;
        uint32_t built = 0, pending = 0;
        for (uint32_t f = 0; f < nf; f++) {
            if (want[f] < 0) continue;
            double key = ldexp((double)sc->faces[f].patch_count, -want[f]);
            if (splat[f]) {
                assert_int_equal(after[f], want[f]);
                lo = fmin(lo, key), built++;
            } else if (after[f] >= 0) { /* pending (not refused) */
                hi = fmax(hi, key), pending++;
            }
        }
        printf("%s: %u faces built first (keys >= %g), %u pending (keys <= %g)\n", cases[k].model,
               built, lo, pending, hi);
        assert_true(built > 0 && pending > 0);
        assert_true(lo >= hi);
        free(want), free(after), free(near), free(splat);
        crisp__splat_store_destroy(s);
        crisp_scene_destroy(sc);
        crisp_model_destroy(m);
    }
}

/* When the library gives malloc's free memory back (scene.c, splat_store.c): once at the end of
 * crisp_scene_prepare (the conversions' temporaries), not after a frame that built a few sets
 * (fewer than a million splats), after every frame that built its build limit's worth, and not
 * after a frame that built nothing. */
static void test_trim_rule(void **state)
{
    (void)state;
#ifdef __GLIBC__
    crisp_model *m = rt_load_model("impeller.igs");
    int t0 = trims;
    crisp_scene *sc;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    assert_int_equal(trims, t0 + 1);
    crisp_planner *full, *lim;
    assert_int_equal(crisp_planner_create(NULL, NULL, &full), CRISP_OK);
    assert_int_equal(
        crisp_planner_create(&(crisp_planner_desc){.splat_build_limit = 1}, NULL, &lim), CRISP_OK);
    crisp_camera cam = far_view(sc, 60, 240, 180);
    const crisp_frame_plan *plan;
    assert_int_equal(crisp_planner_plan(full, sc, &cam, &plan), CRISP_OK);
    assert_true(plan->stats.splat_faces > 10 && plan->stats.splats_drawn < 1000000);
    assert_int_equal(trims, t0 + 1); /* sets built, a few */
    int frames = 0, before = trims;
    do {
        assert_true(frames < 100);
        assert_int_equal(crisp_planner_plan(lim, sc, &cam, &plan), CRISP_OK);
        frames++;
        assert_int_equal(trims, before + frames); /* each built at least its limit, 1 */
    } while (plan->stats.splat_pending);
    assert_true(frames >= 2);
    assert_int_equal(crisp_planner_plan(lim, sc, &cam, &plan), CRISP_OK);
    assert_int_equal(trims, before + frames); /* nothing built */
    printf("malloc_trim: once for the scene, none after a frame of %u faces' sets, one after each "
           "of %d limited frames\n",
           plan->stats.splat_faces, frames);
    crisp_planner_destroy(full), crisp_planner_destroy(lim);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
#endif
}

/* A plan equals a fresh planner's at the same view whatever came before (session 18, inst5):
 * patch_groups.c walks only the faces not drawn as splats (resetting the last walk's faces), the
 * store keys the faces drawn and publish takes the last draw order without a pass over every face
 * when the keyed faces are the last ones. impeller.igs 3 x 3 through far views (every face
 * splats), views from beside one instance across the others (near instances as patches, far ones
 * as splats), close views and repeats: each plan's face records, its splat ranges (face and
 * count, in order) with their clip origins, and its leaves and triangles equal a fresh planner's.
 * publish taking the last order when the last ranges' faces are keyed, without counting the keyed
 * faces (a view with more splat faces after one with fewer), fails it (tried). */
static crisp_camera beside_view(const crisp_scene *sc, double at, double up, int w, int h)
{
    crisp_camera cam = far_view(sc, 100, w, h);
    double c[3], dx = sc->box[3] - sc->box[0], dy = sc->box[4] - sc->box[1];
    for (int q = 0; q < 3; q++)
        c[q] = 0.5 * (sc->box[q] + sc->box[q + 3]);
    cam.eye[0] = sc->box[0] - at * dx, cam.eye[1] = sc->box[1] - at * dy;
    cam.eye[2] = c[2] + up * (sc->box[5] - sc->box[2]);
    memcpy(cam.target, c, sizeof c);
    cam.znear = 1e-3 * (dx + dy);
    cam.zfar = 4 * (dx + dy);
    return cam;
}

/* Two plans draw the same splat ranges in the same order (face and count; with same_store, also
 * their places in the store: planners that built the same sets in the same order) at the same
 * clip origins, bit for bit. */
static void assert_same_splats(const crisp_frame_plan *a, const crisp_frame_plan *b, int same_store)
{
    assert_int_equal(a->splat_range_count, b->splat_range_count);
    for (uint32_t r = 0; r < a->splat_range_count; r++) {
        const crisp_plan_splat_range *ra = &a->splat_ranges[r], *rb = &b->splat_ranges[r];
        assert_int_equal(ra->face, rb->face);
        if (same_store) assert_int_equal(ra->first, rb->first);
        assert_int_equal(ra->count, rb->count);
        assert_int_equal(memcmp(a->splat_clip_origin + 4 * (size_t)ra->face,
                                b->splat_clip_origin + 4 * (size_t)ra->face, 4 * sizeof(float)),
                         0);
    }
}

static void test_plan_history(void **state)
{
    (void)state;
    crisp_model *m = instanced("impeller.igs", 3);
    crisp_scene *sc = NULL;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_planner *pl;
    assert_int_equal(crisp_planner_create(NULL, NULL, &pl), CRISP_OK);
    crisp_camera views[8] = {
        group_view_camera(sc, 20, 0.0, 3, 320, 240),  group_view_camera(sc, 25, 0.5, 3, 320, 240),
        beside_view(sc, 0.05, 0.6, 320, 240),         beside_view(sc, 0.15, 1.5, 320, 240),
        group_view_camera(sc, 600, 0.0, 3, 320, 240), group_view_camera(sc, 60, 0.2, 3, 320, 240),
    };
    crisp_camera moved = group_view_camera(sc, 60, 0.0, 3, 320, 240);
    views[7] = moved; /* and with parts of the scene off screen (test_kept_order's move) */
    {                 /* sideways by 2.7 radii: the scene's centre near the screen's side */
        double f[3], rt[3], n = 0, r = 0;
        for (int q = 0; q < 3; q++) {
            f[q] = moved.target[q] - moved.eye[q];
            r += 0.25 * (sc->box[q + 3] - sc->box[q]) * (sc->box[q + 3] - sc->box[q]);
        }
        for (int q = 0; q < 3; q++) {
            rt[q] = f[(q + 1) % 3] * moved.up[(q + 2) % 3] - f[(q + 2) % 3] * moved.up[(q + 1) % 3];
            n += rt[q] * rt[q];
        }
        for (int q = 0; q < 3; q++) {
            double d = 2.7 * sqrt(r) * rt[q] / sqrt(n);
            moved.eye[q] += d, moved.target[q] += d;
        }
    }
    views[6] = moved;
    static const int seq[] = {0, 0, 2, 2, 0, 3, 1, 2, 4, 0, 5, 3,
                              3, 0, 7, 6, 7, 6, 6, 7, 1, 1, 4, 2};
    int mixed = 0;
    for (size_t i = 0; i < sizeof seq / sizeof seq[0]; i++) {
        const crisp_camera *cam = &views[seq[i]];
        const crisp_frame_plan *plan, *ref;
        crisp_planner *fresh = plan_beside_fresh(pl, sc, cam, &plan, &ref);
        assert_same_splats(plan, ref, 0);
        assert_int_equal(plan->stats.leaves, ref->stats.leaves);
        assert_int_equal(plan->stats.group_leaves, ref->stats.group_leaves);
        assert_int_equal(plan->stats.visible_patches, ref->stats.visible_patches);
        assert_int_equal(plan->stats.triangles, ref->stats.triangles);
        uint32_t visible = 0;
        for (uint32_t f = 0; f < sc->face_count; f++)
            visible += (plan->faces[f].flags & CRISP_PLAN_FACE_VISIBLE) != 0;
        printf("view %d: %u splat faces, %u faces as patches, %llu triangles\n", seq[i],
               plan->splat_range_count, visible, (unsigned long long)plan->stats.triangles);
        mixed += plan->splat_range_count > 50 && visible > 50;
        crisp_planner_destroy(fresh);
    }
    assert_true(mixed >= 3);
    crisp_planner_destroy(pl);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

/* The choice's four-lane path (choose_faces4, AVX2) against its scalar path: two planners plan
 * the same sequence of views of impeller.igs 4 x 4 (far, a few pixels a face, to near enough that
 * faces leave the splats; off to a side), one with the lanes, one without; every plan's splat
 * ranges, clip origins (bit for bit), face records and counts must be the same, and the lanes
 * must have taken most faces of the far views (where the CPU has AVX2). The two planners build
 * the same sets in the same order, so the ranges' places in the store match too. */
static void test_choice_lanes(void **state)
{
    (void)state;
    crisp_model *m = instanced("impeller.igs", 4);
    crisp_scene *sc = NULL;
    assert_int_equal(crisp_scene_prepare(m, &sc), CRISP_OK);
    crisp_planner *with, *without;
    assert_int_equal(crisp_planner_create(NULL, NULL, &with), CRISP_OK);
    assert_int_equal(crisp_planner_create(NULL, NULL, &without), CRISP_OK);
    crisp_camera views[6] = {
        group_view_camera(sc, 30, 0.0, 3, 640, 360),    group_view_camera(sc, 80, 0.3, 3, 640, 360),
        group_view_camera(sc, 400, 0.0, 3, 640, 360),   group_view_camera(sc, 30, 1.5, 3, 640, 360),
        group_view_camera(sc, 150, 0.2, 0.5, 640, 360), beside_view(sc, 0.05, 0.6, 640, 360),
    };
    static const int seq[] = {0, 0, 1, 1, 0, 2, 2, 3, 3, 4, 4, 0, 5, 5, 1, 0};
    unsigned long long taken = 0;
    const crisp_frame_plan *first;
    assert_int_equal(crisp_planner_plan(with, sc, &views[5], &first), CRISP_OK);
    const int lanes = crisp__splat_choice_lanes; /* (known after a choice) */
    assert_true(lanes >= 0);
    crisp__splat_choice_lanes = 0;
    assert_int_equal(crisp_planner_plan(without, sc, &views[5], &first), CRISP_OK);
    for (size_t i = 0; i < sizeof seq / sizeof seq[0]; i++) {
        const crisp_camera *cam = &views[seq[i]];
        const crisp_frame_plan *a, *b;
        unsigned long long before = crisp__splat_lane_faces;
        crisp__splat_choice_lanes = lanes;
        assert_int_equal(crisp_planner_plan(with, sc, cam, &a), CRISP_OK);
        unsigned long long now = crisp__splat_lane_faces - before;
        taken += now;
        crisp__splat_choice_lanes = 0;
        before = crisp__splat_lane_faces;
        assert_int_equal(crisp_planner_plan(without, sc, cam, &b), CRISP_OK);
        assert_true(crisp__splat_lane_faces == before);
        assert_same_splats(a, b, 1);
        assert_int_equal(memcmp(a->faces, b->faces, sc->face_count * sizeof(crisp_plan_face)), 0);
        assert_int_equal(a->stats.triangles, b->stats.triangles);
        assert_int_equal(a->stats.splats_drawn, b->stats.splats_drawn);
        printf("view %d: %u splat faces, the lanes took %llu\n", seq[i], a->splat_range_count, now);
    }
    crisp__splat_choice_lanes = lanes;
    printf("lanes %d: %llu faces taken four at a time\n", lanes, taken);
    if (lanes > 0) assert_true(taken > 4 * sc->face_count);
    crisp_planner_destroy(with);
    crisp_planner_destroy(without);
    crisp_scene_destroy(sc);
    crisp_model_destroy(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_draw_reference),    cmocka_unit_test(test_draw_small_ranges),
        cmocka_unit_test(test_choice_near_plane), cmocka_unit_test(test_true_points),
        cmocka_unit_test(test_no_holes),          cmocka_unit_test(test_solids_far),
        cmocka_unit_test(test_near_edges),        cmocka_unit_test(test_group_choice),
        cmocka_unit_test(test_range_order),       cmocka_unit_test(test_kept_order),
        cmocka_unit_test(test_build_limit),       cmocka_unit_test(test_build_order),
        cmocka_unit_test(test_trim_rule),         cmocka_unit_test(test_plain_faces),
        cmocka_unit_test(test_plan_history),      cmocka_unit_test(test_choice_lanes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
