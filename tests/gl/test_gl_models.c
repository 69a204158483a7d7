/* GL and CPU backends on the same frame plan of every bundled model (data/nurbs) under 20 cameras
 * (every file of data/nurbs; orbits at several elevations, close-ups of patch centres at 3 and 0.01
 * degree): face id and coverage must agree on every pixel farther than 1 px from a face or
 * background transition (silhouettes, trim curves, face boundaries) and from a patch boundary in
 * either image, except where the two faces' depths agree to 1e-4 (faces of the file that
 * coincide there: either may win; counted, and rare). Depth agrees there to 1e-3 relative on all
 * but 0.1% of them (both tessellations are within the tolerance on screen, a grazing surface turns
 * that into larger depth changes). Then the layout probe: a compute shader reads each real plan's
 * leaves and trim tables, and its lookups at many (u, v) points equal crisp_plan_trim_test and the
 * C records.
 *
 * test_gl_models [--size WxH] (default 160x120; the slow variant renders 480x360). */
#include <dirent.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "crisp/gl.h"
#include "crisp/io.h"
#include "crisp/plan.h"
#include "gl/gl_internal.h"
#include "gl/gl_test_util.h"

static int W = 160, H = 120;

/* Every bundled model: the files of data/nurbs, sorted by name. */
static char models[64][256];
static int model_count;

static int cmp_name(const void *a, const void *b)
{
    return strcmp(a, b);
}

static void list_models(void)
{
    char dir[512];
    snprintf(dir, sizeof dir, "%s/nurbs", CRISP_DATA_DIR);
    DIR *d = opendir(dir);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d)) && model_count < 64)
        if (e->d_name[0] != '.') snprintf(models[model_count++], sizeof models[0], "%s", e->d_name);
    closedir(d);
    qsort(models, (size_t)model_count, sizeof models[0], cmp_name);
}
#define CAMERAS 20

static crisp_camera make_camera(const crisp_scene *sc, int k)
{
    crisp_camera base;
    assert_int_equal(crisp_camera_frame_box(sc->box, W, H, &base), CRISP_OK);
    double d[3], dist;
    crisp_vec3_sub(base.eye, base.target, d);
    dist = crisp_vec3_norm(d);
    crisp_camera c = base;
    if (k % 5 == 4) {
        /* close-up of a patch centre, from the side of its normal */
        const crisp_scene_patch *p = &sc->patches[(uint32_t)(k * 7919u) % sc->patch_count];
        double P[3], Ps[3], Pt[3], n[3];
        crisp_bezier_patch_derivs(&p->bez, 0.5, 0.5, P, Ps, Pt);
        crisp_vec3_cross(Ps, Pt, n);
        if (!crisp_vec3_normalize(n, n)) n[2] = 1;
        double tilt[3] = {0.3, 0.5, 0.2};
        for (int a = 0; a < 3; a++)
            d[a] = n[a] + tilt[a];
        crisp_vec3_normalize(d, d);
        double r = k % 10 == 4 ? 0.3 * dist : 0.8 * dist;
        for (int a = 0; a < 3; a++) {
            c.target[a] = P[a];
            c.eye[a] = P[a] + r * d[a];
        }
        c.fov_deg = k % 10 == 4 ? 3 : 0.01;
        c.znear = 1e-3 * r;
        c.zfar = 4 * dist;
        if (fabs(d[1]) > 0.95) c.up[0] = 1, c.up[1] = 0;
        return c;
    }
    double az = 2 * M_PI * k / CAMERAS + 0.3, el = (k % 3 - 1) * 0.6 + 0.1;
    double dir[3] = {cos(el) * sin(az), sin(el), cos(el) * cos(az)};
    for (int a = 0; a < 3; a++)
        c.eye[a] = base.target[a] + dist * dir[a];
    return c;
}

/* The patch of (face, u, v): the index of the face's patch whose box holds (u, v), -1 if none. */
static int patch_of(const crisp_scene *sc, int face, float u, float v)
{
    if (face < 0) return -1;
    const crisp_scene_face *f = &sc->faces[face];
    for (uint32_t p = f->first_patch; p < f->first_patch + f->patch_count; p++) {
        const crisp_bezier_patch *b = &sc->patches[p].bez;
        if (u >= b->u0 && u <= b->u1 && v >= b->v0 && v <= b->v1) return (int)p;
    }
    return -2;
}

/* Relative depth within which two different faces at a pixel count as a tie: a tenth of the
 * depth check's 1e-3 below, which each backend's tessellation meets against the other's. */
#define TIE_DEPTH 1e-4

typedef struct tally {
    long compared, face_diff, ties, alpha_diff, depth_diff, band, band_diff;
    double worst_depth;
} tally;

static void compare(const crisp_scene *sc, const crisp_image *a, const crisp_image *b, tally *t,
                    const char *what)
{
    int w = a->width, h = a->height;
    int *pa = malloc(sizeof(int) * (size_t)w * h), *pb = malloc(sizeof(int) * (size_t)w * h);
    for (int k = 0; k < w * h; k++) {
        pa[k] = patch_of(sc, a->face[k], a->uv[2 * k], a->uv[2 * k + 1]);
        pb[k] = patch_of(sc, b->face[k], b->uv[2 * k], b->uv[2 * k + 1]);
    }
    for (int j = 1; j + 1 < h; j++)
        for (int i = 1; i + 1 < w; i++) {
            int k = j * w + i, uniform = 1;
            for (int dj = -1; dj <= 1; dj++)
                for (int di = -1; di <= 1; di++) {
                    int q = k + dj * w + di;
                    if (a->face[q] != a->face[k] || b->face[q] != b->face[k] || pa[q] != pa[k] ||
                        pb[q] != pb[k])
                        uniform = 0;
                }
            int differs = a->face[k] != b->face[k] || a->rgba[4 * k + 3] != b->rgba[4 * k + 3];
            if (!uniform) {
                t->band++;
                t->band_diff += differs;
                continue;
            }
            t->compared++;
            if (a->face[k] != b->face[k]) {
                /* Two faces within the depth tolerance of each other here (coincident faces of
                 * the file): each backend's depth is its own face's within the tolerance, so when
                 * they agree either face may be in front. Farther apart, one backend is wrong. */
                if (a->face[k] >= 0 && b->face[k] >= 0 &&
                    fabs(a->depth[k] - b->depth[k]) <= TIE_DEPTH * a->depth[k]) {
                    t->ties++;
                } else {
                    if (t->face_diff < 5)
                        fprintf(stderr, "%s: pixel (%d, %d) face cpu %d gl %d (depth %g %g)\n",
                                what, i, j, a->face[k], b->face[k], a->depth[k], b->depth[k]);
                    t->face_diff++;
                }
            }
            t->alpha_diff += a->rgba[4 * k + 3] != b->rgba[4 * k + 3];
            if (a->face[k] >= 0 && a->face[k] == b->face[k]) {
                double e = fabs(a->depth[k] - b->depth[k]) / a->depth[k];
                if (e > t->worst_depth) t->worst_depth = e;
                t->depth_diff += e > 1e-3;
            }
        }
    free(pa);
    free(pb);
}

static void test_models(void **state)
{
    (void)state;
    crisp_gl *gl = NULL;
    assert_int_equal(crisp_gl_create(crisp_gl_context_getproc(ctx), NULL, &gl), CRISP_OK);
    tally all = {0};
    for (size_t m = 0; m < (size_t)model_count; m++) {
        char path[512];
        snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, models[m]);
        crisp_model *model;
        assert_int_equal(crisp_model_load(path, NULL, &model), CRISP_OK);
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(model, &sc), CRISP_OK);
        crisp_renderer *r;
        assert_int_equal(crisp_renderer_create(&(crisp_render_desc){.threads = 2}, &r), CRISP_OK);
        crisp_image a, b;
        assert_int_equal(crisp_image_init(&a, W, H), CRISP_OK);
        assert_int_equal(crisp_image_init(&b, W, H), CRISP_OK);
        tally t = {0};
        for (int k = 0; k < CAMERAS; k++) {
            crisp_camera cam = make_camera(sc, k);
            const crisp_frame_plan *plan;
            assert_int_equal(crisp_planner_plan(crisp_renderer_planner(r), sc, &cam, &plan),
                             CRISP_OK);
            assert_int_equal(crisp_render_cpu_plan(r, sc, plan, &cam, &a, NULL), CRISP_OK);
            crisp_status st = crisp_gl_render(gl, sc, plan, &b, NULL);
            if (st) fail_msg("%s camera %d: %s", models[m], k, crisp_error_message());
            char what[128];
            snprintf(what, sizeof what, "%s camera %d", models[m], k);
            compare(sc, &a, &b, &t, what);
        }
        printf("%-24s %7ld pixels compared: %ld face (%ld ties of coincident faces), %ld coverage, "
               "%ld depth (> 1e-3) differ (worst depth %.1e); band %ld pixels, %ld differ\n",
               models[m], t.compared, t.face_diff, t.ties, t.alpha_diff, t.depth_diff,
               t.worst_depth, t.band, t.band_diff);
        all.compared += t.compared;
        all.face_diff += t.face_diff;
        all.ties += t.ties;
        all.alpha_diff += t.alpha_diff;
        all.depth_diff += t.depth_diff;
        crisp_image_free(&a);
        crisp_image_free(&b);
        crisp_renderer_destroy(r);
        crisp_scene_destroy(sc);
        crisp_model_destroy(model);
    }
    assert_true(all.compared > (long)model_count * CAMERAS * W * H / 20);
    assert_int_equal(all.face_diff, 0);
    /* ties only where the file's faces coincide: rare */
    assert_true(all.ties * 10000 < all.compared);
    assert_int_equal(all.alpha_diff, 0);
    /* depth: the two tessellations of a leaf differ inside (GL's quad pattern, the CPU's), each
     * within the tolerance on screen; seen at grazing angles that is a larger change in depth */
    assert_true(all.depth_diff * 1000 < all.compared);
    crisp_gl_destroy(gl);
}

/* Faces drawn as splats (issue 12): both backends draw the plan's squares by the same rule, so a
 * pixel where either shows a splatted face shows the same face in both, at the same depth and with
 * the same normal and (u, v), except where the nearest sample is contested by a surface: the
 * pixel is in a surface's silhouette or edge band (its 3x3 neighbourhood not uniform in the image
 * that shows the surface; surfaces' coverage differs there, as test_models allows), or two faces
 * lie within the depth tolerance of each other there (a splat square reaches over its trim curve
 * onto the neighbouring face by up to h - r; each backend's surface depth is within its
 * tessellation's tolerance, so either may be in front: counted, and few), or two samples lie at
 * the same depth to float precision (GL's depth buffer holds zconst / W in float, where two W a
 * float step apart can compare equal and the first drawn stays; the CPU compares 1 / W in double:
 * counted as ties, and few). Every bundled model at
 * the default view and from 3 and 8 times as far, 1 and 4 samples per pixel; the alpha of the
 * pixels where both show splats only (or splats and background) must agree too. */
typedef struct splat_tally {
    long faces, pixels, agree, band, ties, contested, alpha_diff, wrong;
} splat_tally;

static int is_splat(const crisp_frame_plan *plan, int face)
{
    return face >= 0 && (plan->faces[face].flags & CRISP_PLAN_FACE_SPLATS);
}

static int uniform_at(const crisp_image *im, int i, int j)
{
    int w = im->width, h = im->height, f = im->face[j * w + i];
    for (int dj = -1; dj <= 1; dj++)
        for (int di = -1; di <= 1; di++) {
            int x = i + di, y = j + dj;
            if (x < 0 || y < 0 || x >= w || y >= h) continue;
            if (im->face[y * w + x] != f) return 0;
        }
    return 1;
}

static void compare_splats(const crisp_frame_plan *plan, const crisp_image *a, const crisp_image *b,
                           splat_tally *t, const char *what)
{
    int w = a->width, h = a->height;
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            int k = j * w + i, fa = a->face[k], fb = b->face[k];
            int sa = is_splat(plan, fa), sb = is_splat(plan, fb);
            /* a surface contesting a splat: a face of the plan's leaves */
            int surf = (fa >= 0 && !sa) || (fb >= 0 && !sb);
            if (!sa && !sb) continue;
            t->pixels++;
            if (!surf && a->rgba[4 * k + 3] != b->rgba[4 * k + 3]) {
                if (t->alpha_diff < 5)
                    fprintf(stderr, "%s: pixel (%d, %d) alpha cpu %g gl %g (faces %d %d)\n", what,
                            i, j, a->rgba[4 * k + 3], b->rgba[4 * k + 3], fa, fb);
                t->alpha_diff++;
            }
            if (fa == fb) {
                double e = fabs(a->depth[k] - b->depth[k]);
                float dn = 0;
                for (int c = 0; c < 3; c++)
                    dn = fmaxf(dn, fabsf(a->normal[3 * k + c] - b->normal[3 * k + c]));
                if (e <= 1e-6 * a->depth[k] && dn <= 1e-6f && a->uv[2 * k] == b->uv[2 * k] &&
                    a->uv[2 * k + 1] == b->uv[2 * k + 1]) {
                    t->agree++;
                    continue;
                }
            }
            if (fa != fb && ((fa >= 0 && !sa && !uniform_at(a, i, j)) ||
                             (fb >= 0 && !sb && !uniform_at(b, i, j)))) {
                t->band++;
                continue;
            }
            if (fa >= 0 && fb >= 0 && fabs(a->depth[k] - b->depth[k]) <= 0x1p-21 * a->depth[k]) {
                t->ties++;
                continue;
            }
            if (fa >= 0 && fb >= 0 && surf &&
                fabs(a->depth[k] - b->depth[k]) <= 1e-3 * a->depth[k]) {
                t->contested++;
                continue;
            }
            if (t->wrong < 5)
                fprintf(stderr,
                        "%s: pixel (%d, %d): cpu face %d depth %.9g, gl face %d depth %.9g\n", what,
                        i, j, fa, a->depth[k], fb, b->depth[k]);
            t->wrong++;
        }
}

static void test_splats(void **state)
{
    (void)state;
    splat_tally all = {0};
    for (int S = 1; S <= 4; S += 3) {
        crisp_gl *gl = NULL;
        assert_int_equal(
            crisp_gl_create(crisp_gl_context_getproc(ctx), &(crisp_gl_desc){.samples = S}, &gl),
            CRISP_OK);
        for (size_t m = 0; m < (size_t)model_count; m++) {
            char path[512];
            snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, models[m]);
            crisp_model *model;
            assert_int_equal(crisp_model_load(path, NULL, &model), CRISP_OK);
            crisp_scene *sc;
            assert_int_equal(crisp_scene_prepare(model, &sc), CRISP_OK);
            crisp_renderer *r;
            assert_int_equal(
                crisp_renderer_create(&(crisp_render_desc){.threads = 2, .samples = S}, &r),
                CRISP_OK);
            crisp_image a, b;
            assert_int_equal(crisp_image_init(&a, W, H), CRISP_OK);
            assert_int_equal(crisp_image_init(&b, W, H), CRISP_OK);
            splat_tally t = {0};
            static const double far[3] = {1, 3, 8};
            for (int v = 0; v < 3; v++) {
                crisp_camera cam;
                assert_int_equal(crisp_camera_frame_box(sc->box, W, H, &cam), CRISP_OK);
                double dist = 0;
                for (int c = 0; c < 3; c++) {
                    double d = cam.eye[c] - cam.target[c];
                    cam.eye[c] = cam.target[c] + far[v] * d;
                    dist += d * d;
                }
                cam.zfar = (far[v] + 2) * sqrt(dist);
                const crisp_frame_plan *plan;
                assert_int_equal(crisp_planner_plan(crisp_renderer_planner(r), sc, &cam, &plan),
                                 CRISP_OK);
                assert_int_equal(crisp_render_cpu_plan(r, sc, plan, &cam, &a, NULL), CRISP_OK);
                crisp_status st = crisp_gl_render(gl, sc, plan, &b, NULL);
                if (st) fail_msg("%s view %d: %s", models[m], v, crisp_error_message());
                char what[128];
                snprintf(what, sizeof what, "%s x%g, %d samples", models[m], far[v], S);
                t.faces += plan->stats.splat_faces;
                compare_splats(plan, &a, &b, &t, what);
            }
            printf("%-24s %d samples: %5ld faces as splats, %6ld pixels show one: %ld agree, %ld "
                   "in a surface's band, %ld float-depth ties, %ld contested within the depth "
                   "tolerance, %ld wrong; %ld alpha differ\n",
                   models[m], S, t.faces, t.pixels, t.agree, t.band, t.ties, t.contested, t.wrong,
                   t.alpha_diff);
            all.faces += t.faces;
            all.pixels += t.pixels;
            all.agree += t.agree;
            all.band += t.band;
            all.contested += t.contested;
            all.ties += t.ties;
            all.wrong += t.wrong;
            all.alpha_diff += t.alpha_diff;
            crisp_image_free(&a);
            crisp_image_free(&b);
            crisp_renderer_destroy(r);
            crisp_scene_destroy(sc);
            crisp_model_destroy(model);
        }
        crisp_gl_destroy(gl);
    }
    printf("all: %ld faces as splats, %ld pixels show one: %ld agree, %ld band, %ld float-depth "
           "ties, %ld contested, %ld wrong, %ld alpha differ\n",
           all.faces, all.pixels, all.agree, all.band, all.ties, all.contested, all.wrong,
           all.alpha_diff);
    assert_true(all.pixels > 1000);
    assert_int_equal(all.wrong, 0);
    assert_int_equal(all.alpha_diff, 0);
    assert_true(all.contested * 20 < all.pixels);
    assert_true(all.ties * 20 < all.pixels);
}

/* The layout probe on real plans: trim lookups at (u, v) points around and on the crossings, leaf
 * levels and (u, v) of leaf points, against crisp_plan_trim_test and the C records. */
static void test_layout(void **state)
{
    (void)state;
    crisp_gl *gl = NULL;
    assert_int_equal(crisp_gl_create(crisp_gl_context_getproc(ctx), NULL, &gl), CRISP_OK);
    const char *names[3] = {"gpucast_part.igs", "impeller.igs", "occt_bearing.iges"};
    enum { N = 20000 };
    crisp__gl_query *q = calloc(N, sizeof *q);
    crisp__gl_result *res = calloc(N, sizeof *res);
    for (int m = 0; m < 3; m++) {
        char path[512];
        snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, names[m]);
        crisp_model *model;
        assert_int_equal(crisp_model_load(path, NULL, &model), CRISP_OK);
        crisp_scene *sc;
        assert_int_equal(crisp_scene_prepare(model, &sc), CRISP_OK);
        crisp_planner *pl;
        assert_int_equal(crisp_planner_create(NULL, NULL, &pl), CRISP_OK);
        crisp_camera cam;
        assert_int_equal(crisp_camera_frame_box(sc->box, 640, 480, &cam), CRISP_OK);
        const crisp_frame_plan *plan;
        assert_int_equal(crisp_planner_plan(pl, sc, &cam, &plan), CRISP_OK);
        assert_true(plan->leaf_count > 0 && plan->crossing_count > 0);
        assert_int_equal(crisp_gl_set_scene(gl, sc), CRISP_OK);
        srand(11 + m);
        long inside = 0;
        for (int k = 0; k < N; k++) {
            const crisp_plan_leaf *L = &plan->leaves[(uint32_t)rand() % plan->leaf_count];
            q[k].leaf = (uint32_t)(L - plan->leaves);
            q[k].s = rand() / (double)RAND_MAX;
            q[k].t = rand() / (double)RAND_MAX;
            double ls, lt;
            const crisp_scene_patch_record *pr =
                &sc->patch_records[crisp_plan_leaf_locate(plan, L, q[k].s, q[k].t, &ls, &lt)];
            q[k].face = L->face;
            q[k].u = pr->u0 + ls * (pr->u1 - pr->u0);
            q[k].v = pr->v0 + lt * (pr->v1 - pr->v0);
            if (k % 4 == 0 && plan->crossing_count) {
                /* exactly on, just left and right of a crossing of the face's table */
                const crisp_plan_face *f = &plan->faces[L->face];
                if (f->strip_count) {
                    const crisp_plan_strip *s =
                        &plan->strips[f->first_strip + (uint32_t)rand() % f->strip_count];
                    if (s->row_count) {
                        uint32_t r = s->first_row + (uint32_t)rand() % s->row_count;
                        uint32_t n = plan->row_offset[r + 1] - plan->row_offset[r];
                        if (n) {
                            double c = plan->crossings[plan->row_offset[r] + (uint32_t)rand() % n];
                            q[k].u =
                                k % 12 == 0 ? c : nextafter(c, k % 8 == 0 ? INFINITY : -INFINITY);
                            q[k].v = s->a + (r - s->first_row + 0.5) / s->row_scale;
                        }
                    }
                }
            }
        }
        assert_int_equal(crisp__gl_layout_probe(gl, plan, q, N, res), CRISP_OK);
        for (int k = 0; k < N; k++) {
            int want = crisp_plan_trim_test(plan, q[k].face, q[k].u, q[k].v);
            if ((int)res[k].inside != want)
                fail_msg("%s query %d: face %u (u, v) = (%.17g, %.17g): shader %u, C %d", names[m],
                         k, q[k].face, q[k].u, q[k].v, res[k].inside, want);
            inside += want;
            const crisp_plan_leaf *L = &plan->leaves[q[k].leaf];
            assert_int_equal(res[k].tau, L->tau);
            assert_int_equal(res[k].patch, L->patch);
            assert_int_equal(res[k].depth, L->depth);
            for (int e = 0; e < 4; e++)
                assert_int_equal(res[k].edge[e], L->edge[e]);
            {
                double P[3], ps[3], pt[3], ls, lt;
                uint32_t lp = crisp_plan_leaf_locate(plan, L, q[k].s, q[k].t, &ls, &lt);
                crisp_bezier_patch_derivs(&sc->patches[lp].bez, ls, lt, P, ps, pt);
                double e = fmax(fabs(P[0] - res[k].point[0]),
                                fmax(fabs(P[1] - res[k].point[1]), fabs(P[2] - res[k].point[2])));
                double size = fmax(fabs(P[0]), fmax(fabs(P[1]), fabs(P[2])));
                if (!(e <= 1e-12 * (1 + size)))
                    fail_msg("%s leaf %u patch %u at (%g, %g): shader (%.17g %.17g %.17g) C (%.17g "
                             "%.17g %.17g)",
                             names[m], q[k].leaf, L->patch, q[k].s, q[k].t, res[k].point[0],
                             res[k].point[1], res[k].point[2], P[0], P[1], P[2]);
            }
            if (k % 4) {
                double du = fabs(res[k].u - q[k].u), dv = fabs(res[k].v - q[k].v);
                assert_true(du <= 1e-14 * (1 + fabs(q[k].u)) && dv <= 1e-14 * (1 + fabs(q[k].v)));
            }
        }
        assert_true(inside > N / 10 && inside < N);
        crisp_planner_destroy(pl);
        crisp_scene_destroy(sc);
        crisp_model_destroy(model);
    }
    free(q);
    free(res);
    crisp_gl_destroy(gl);
}

int main(int argc, char **argv)
{
    for (int i = 1; i + 1 < argc; i++)
        if (!strcmp(argv[i], "--size") && sscanf(argv[i + 1], "%dx%d", &W, &H) != 2) return 2;
    list_models();
    if (model_count < 11) {
        fprintf(stderr, "test_gl_models: %d models in %s/nurbs\n", model_count, CRISP_DATA_DIR);
        return 1;
    }
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_layout), cmocka_unit_test(test_models),
                                       cmocka_unit_test(test_splats)};
    return cmocka_run_group_tests(tests, gl_setup, gl_teardown);
}
