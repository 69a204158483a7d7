/* Tests for the camera and the CPU rasterizer: watertight shared edges, perspective-correct
 * attributes, near-plane clipping, thread-count independence, multisampling. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/render.h"
#include "render/raster.h"

/* A tiny deterministic generator so failures reproduce. */
static uint64_t rng_state = 88172645463325252ull;
static double rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}

typedef struct {
    int w, h;
    int *count;
} count_ctx;

/* Counts every fragment at the pixel given by its attributes and discards it, so later
 * fragments at the same sample are still tested. */
static int count_and_discard(void *vctx, uint32_t face, double u, double v)
{
    count_ctx *c = vctx;
    (void)face;
    int i = (int)floor(u), j = (int)floor(v);
    if (i >= 0 && j >= 0 && i < c->w && j < c->h) c->count[j * c->w + i]++;
    return 0;
}

/* Screen-space vertex (x, y in pixels) with W = 1 and attributes (x, y). */
static crisp_raster_vertex screen_vertex(double x, double y, int w, int h)
{
    crisp_raster_vertex v = {{2 * x / w - 1, 1 - 2 * y / h, 0, 1}, {x, y, 0, 0, 1}};
    return v;
}

static void test_watertight(void **state)
{
    (void)state;
    enum { W = 200, H = 150, N = 23 };
    crisp_raster_vertex verts[(N + 1) * (N + 1)];
    crisp_raster_tri tris[N * N * 2];
    /* A jittered grid over [10.3, 187.9] x [5.1, 141.7] with vertices snapped onto some pixel
     * centres, so samples fall exactly on shared edges and vertices. */
    for (int j = 0; j <= N; j++)
        for (int i = 0; i <= N; i++) {
            double x = 10.3 + (187.9 - 10.3) * i / N, y = 5.1 + (141.7 - 5.1) * j / N;
            if (i > 0 && i < N && j > 0 && j < N) {
                x += (rnd() - 0.5) * 3;
                y += (rnd() - 0.5) * 3;
                if ((i + j) % 3 == 0) {
                    x = floor(x) + 0.5;
                    y = floor(y) + 0.5;
                }
            }
            verts[j * (N + 1) + i] = screen_vertex(x, y, W, H);
        }
    int nt = 0;
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            uint32_t a = j * (N + 1) + i, b = a + 1, c = a + N + 1, d = c + 1;
            if ((i + j) % 2) {
                tris[nt++] = (crisp_raster_tri){{a, b, d}, 0};
                tris[nt++] = (crisp_raster_tri){{a, d, c}, 0};
            } else {
                tris[nt++] = (crisp_raster_tri){{a, b, c}, 0};
                tris[nt++] = (crisp_raster_tri){{b, c, d}, 0}; /* clockwise on purpose */
            }
        }
    crisp_raster *r;
    assert_int_equal(crisp__raster_create(&r), CRISP_OK);
    crisp_raster_target t = {0};
    assert_int_equal(crisp__raster_target_init(&t, W, H, 1), CRISP_OK);
    crisp__raster_target_clear(&t);
    static int count[W * H];
    memset(count, 0, sizeof count);
    count_ctx cc = {W, H, count};
    assert_int_equal(crisp__raster_draw(r, &t, NULL, verts, (N + 1) * (N + 1), tris, nt,
                                        count_and_discard, &cc, NULL),
                     CRISP_OK);
    /* Pixels whose centre is well inside the outline are covered exactly once. */
    int inside = 0;
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            double x = i + 0.5, y = j + 0.5;
            if (x > 12 && x < 186 && y > 7 && y < 140) {
                assert_int_equal(count[j * W + i], 1);
                inside++;
            }
            if (x < 10 || x > 188 || y < 5 || y > 142) assert_int_equal(count[j * W + i], 0);
        }
    assert_true(inside > 20000);
    crisp__raster_target_free(&t);
    crisp__raster_destroy(r);
}

/* A quad on the plane y = -1 (u along x, v along z) rendered through a camera; compare the
 * interpolated (u, v) and coverage with ray casting. Returns how many pixels were checked. */
static int check_plane(const crisp_camera *cam, crisp_pool *pool, double half, double *max_err,
                       int *bad_cover)
{
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    crisp_raster_vertex verts[4];
    double corner[4][3] = {
        {-half, -1, -half}, {half, -1, -half}, {half, -1, half}, {-half, -1, half}};
    for (int k = 0; k < 4; k++) {
        crisp_mat4_mulp(m.view_proj, corner[k], verts[k].clip);
        verts[k].attr[0] = corner[k][0];
        verts[k].attr[1] = corner[k][2];
        verts[k].attr[2] = 0;
        verts[k].attr[3] = 1;
        verts[k].attr[4] = 0;
    }
    crisp_raster_tri tris[2] = {{{0, 1, 2}, 7}, {{0, 2, 3}, 7}};
    crisp_raster *r;
    crisp__raster_create(&r);
    crisp_raster_target t = {0};
    crisp__raster_target_init(&t, cam->width, cam->height, 1);
    crisp__raster_target_clear(&t);
    crisp__raster_draw(r, &t, pool, verts, 4, tris, 2, NULL, NULL, NULL);
    /* The analytic coverage: ray hits the plane inside the quad, between near and far. */
    int W = cam->width, H = cam->height;
    char *cover = calloc((size_t)W * H, 1);
    double *hu = calloc((size_t)W * H * 2, sizeof(double));
    double f[3], fl;
    for (int k = 0; k < 3; k++)
        f[k] = cam->target[k] - cam->eye[k];
    fl = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            double o[3], d[3];
            crisp_camera_ray(cam, i + 0.5, j + 0.5, o, d);
            if (fabs(d[1]) < 1e-15) continue;
            double s = (-1 - o[1]) / d[1];
            double x = o[0] + s * d[0], z = o[2] + s * d[2];
            double depth = s * (d[0] * f[0] + d[1] * f[1] + d[2] * f[2]) / fl;
            if (s > 0 && depth >= cam->znear && depth <= cam->zfar && fabs(x) <= half &&
                fabs(z) <= half) {
                cover[j * W + i] = 1;
                hu[(j * W + i) * 2] = x;
                hu[(j * W + i) * 2 + 1] = z;
            }
        }
    int checked = 0;
    *max_err = 0;
    *bad_cover = 0;
    for (int j = 1; j < H - 1; j++)
        for (int i = 1; i < W - 1; i++) {
            int c = cover[j * W + i], same = 1;
            for (int dj = -1; dj <= 1; dj++)
                for (int di = -1; di <= 1; di++)
                    same &= cover[(j + dj) * W + i + di] == c;
            int drawn = t.face[j * W + i] >= 0;
            assert_false(isnan(t.attr[(j * W + i) * CRISP_RASTER_ATTRS]));
            if (!same) continue; /* within a pixel of the boundary */
            if (drawn != c) (*bad_cover)++;
            if (c && drawn) {
                assert_int_equal(t.face[j * W + i], 7);
                double du = t.attr[(j * W + i) * CRISP_RASTER_ATTRS] - hu[(j * W + i) * 2];
                double dv = t.attr[(j * W + i) * CRISP_RASTER_ATTRS + 1] - hu[(j * W + i) * 2 + 1];
                double e = fmax(fabs(du), fabs(dv)) /
                           (fabs(hu[(j * W + i) * 2]) + fabs(hu[(j * W + i) * 2 + 1]) + 1);
                if (e > *max_err) *max_err = e;
                checked++;
            }
        }
    free(cover);
    free(hu);
    crisp__raster_target_free(&t);
    crisp__raster_destroy(r);
    return checked;
}

static void test_perspective_correct(void **state)
{
    (void)state;
    crisp_camera cam = {.eye = {0.3, 2, 6},
                        .target = {0, -1, 0},
                        .up = {0, 1, 0},
                        .fov_deg = 40,
                        .znear = 0.1,
                        .zfar = 100,
                        .width = 160,
                        .height = 120};
    double err;
    int bad;
    int n = check_plane(&cam, NULL, 3, &err, &bad);
    assert_true(n > 2000);
    assert_int_equal(bad, 0);
    assert_true(err < 1e-5);
}

static void test_near_plane(void **state)
{
    (void)state;
    /* A floor that extends far behind the eye: it crosses the near plane. */
    crisp_camera cam = {.eye = {0, 0, 0},
                        .target = {0, -0.3, -1},
                        .up = {0, 1, 0},
                        .fov_deg = 70,
                        .znear = 0.5,
                        .zfar = 60,
                        .width = 160,
                        .height = 120};
    double err;
    int bad;
    int n = check_plane(&cam, NULL, 1000, &err, &bad);
    assert_true(n > 3000);
    assert_int_equal(bad, 0);
    assert_true(err < 1e-4);
    /* The same with the eye exactly on a grazing plane and a grazing view. */
    crisp_camera graze = {.eye = {0, -0.999, 0},
                          .target = {0, -1, -1},
                          .up = {0, 1, 0},
                          .fov_deg = 60,
                          .znear = 0.01,
                          .zfar = 100,
                          .width = 160,
                          .height = 120};
    n = check_plane(&graze, NULL, 50, &err, &bad);
    assert_true(n > 100);
    assert_int_equal(bad, 0);
}

static void test_threads_identical(void **state)
{
    (void)state;
    enum { W = 300, H = 200, NT = 3000 };
    static crisp_raster_vertex verts[NT * 3];
    static crisp_raster_tri tris[NT];
    for (int k = 0; k < NT; k++) {
        double cx = rnd() * W, cy = rnd() * H, z = 1 + rnd() * 5;
        for (int q = 0; q < 3; q++) {
            double x = cx + (rnd() - 0.5) * 60, y = cy + (rnd() - 0.5) * 60;
            crisp_raster_vertex v = screen_vertex(x, y, W, H);
            for (int c = 0; c < 4; c++)
                v.clip[c] *= z; /* same screen point, depth z */
            verts[k * 3 + q] = v;
        }
        tris[k] = (crisp_raster_tri){{k * 3, k * 3 + 1, k * 3 + 2}, (uint32_t)k};
        /* Some degenerate (repeated vertex, collinear) and off-image triangles among them: the
         * counting and writing passes of the setup must agree on them. */
        if (k % 7 == 3) verts[k * 3 + 2] = verts[k * 3];
        if (k % 11 == 5)
            for (int q = 0; q < 3; q++)
                verts[k * 3 + q].clip[0] += 5 * verts[k * 3 + q].clip[3];
    }
    crisp_raster_target t1 = {0}, t3 = {0};
    crisp_raster *r;
    crisp__raster_create(&r);
    crisp__raster_target_init(&t1, W, H, 4);
    crisp__raster_target_clear(&t1);
    crisp__raster_draw(r, &t1, NULL, verts, NT * 3, tris, NT, NULL, NULL, NULL);
    size_t n = (size_t)W * H * 4;
    /* The tiles are shared out in one home range per worker (raster_tiles): with 2, 3 and more
     * workers than tiles in a range, every tile is drawn, whoever draws it. The target starts
     * with garbage and a pending clear (each tile clears itself): a tile left out keeps it. */
    static const int threads[] = {2, 3, 8, 64};
    for (int k = 0; k < 4; k++) {
        crisp_pool *pool;
        assert_int_equal(crisp_pool_create(threads[k], &pool), CRISP_OK);
        crisp__raster_target_init(&t3, W, H, 4);
        memset(t3.face, 0x55, n * sizeof *t3.face);
        memset(t3.inv_w, 0x55, n * sizeof *t3.inv_w);
        crisp__raster_target_clear_depth(&t3, pool);
        crisp_raster_stats st;
        crisp__raster_draw(r, &t3, pool, verts, NT * 3, tris, NT, NULL, NULL, &st);
        assert_true(st.triangles_setup < NT && st.triangles_setup > NT / 2);
        assert_memory_equal(t1.face, t3.face, n * sizeof *t1.face);
        assert_memory_equal(t1.inv_w, t3.inv_w, n * sizeof *t1.inv_w);
        crisp_pool_destroy(pool);
    }
    crisp__raster_target_free(&t1);
    crisp__raster_target_free(&t3);
    crisp__raster_destroy(r);
}

static void test_bad_input(void **state)
{
    (void)state;
    crisp_raster *r;
    crisp__raster_create(&r);
    crisp_raster_target t = {0};
    assert_int_equal(crisp__raster_target_init(&t, 10, 10, 3), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp__raster_target_init(&t, 0, 10, 1), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp__raster_target_init(&t, 10, 10, 1), CRISP_OK);
    crisp__raster_target_clear(&t);
    crisp_raster_vertex v[3] = {
        {{NAN, 0, 0, 1}, {0}}, {{1, 0, 0, 1}, {0}}, {{0, 1, 0, INFINITY}, {0}}};
    crisp_raster_tri tri = {{0, 1, 2}, 0}, bad = {{0, 1, 5}, 0};
    assert_int_equal(crisp__raster_draw(r, &t, NULL, v, 3, &tri, 1, NULL, NULL, NULL), CRISP_OK);
    for (int i = 0; i < 100; i++)
        assert_int_equal(t.face[i], -1);
    assert_int_equal(crisp__raster_draw(r, &t, NULL, v, 3, &bad, 1, NULL, NULL, NULL),
                     CRISP_ERR_INVALID_ARG);
    crisp__raster_target_free(&t);
    crisp__raster_destroy(r);
}

/* The target's buffers and the image's planes start on a cache line (crisp__alloc_lines: the
 * tiles' and the resolve's 64-byte vector loads and stores then do not straddle two lines), at
 * any size and sample count, and hold every sample (cleared whole here: the sanitizer build checks
 * the bounds). */
static void test_target_lines(void **state)
{
    (void)state;
    static const int size[][3] = {{1, 1, 1},   {7, 3, 4},       {203, 149, 1},
                                  {13, 5, 16}, {1920, 1080, 1}, {3, 1, 1}};
    crisp_raster_target t = {0};
    for (size_t k = 0; k < sizeof size / sizeof *size; k++) {
        assert_int_equal(crisp__raster_target_init(&t, size[k][0], size[k][1], size[k][2]),
                         CRISP_OK);
        assert_int_equal((uintptr_t)t.inv_w % 64, 0);
        assert_int_equal((uintptr_t)t.attr % 64, 0);
        assert_int_equal((uintptr_t)t.face % 64, 0);
        crisp__raster_target_clear(&t);
        size_t n = (size_t)size[k][0] * size[k][1] * size[k][2];
        assert_int_equal(t.face[n - 1], -1);
        assert_true(t.inv_w[n - 1] == 0 && t.attr[CRISP_RASTER_ATTRS * n - 1] == 0);
    }
    /* Reused for the same sample count in another shape: still aligned. */
    assert_int_equal(crisp__raster_target_init(&t, 1, 3, 1), CRISP_OK);
    assert_int_equal((uintptr_t)t.inv_w % 64, 0);
    crisp__raster_target_free(&t);
    /* The image's planes too (the resolve's stores), cleared whole. */
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, 203, 149), CRISP_OK);
    assert_int_equal((uintptr_t)img.rgba % 64, 0);
    assert_int_equal((uintptr_t)img.depth % 64, 0);
    assert_int_equal((uintptr_t)img.normal % 64, 0);
    assert_int_equal((uintptr_t)img.uv % 64, 0);
    assert_int_equal((uintptr_t)img.face % 64, 0);
    size_t n = 203 * 149;
    assert_true(img.rgba[4 * n - 1] == 0 && img.normal[3 * n - 1] == 0 && img.uv[2 * n - 1] == 0);
    assert_true(isinf(img.depth[n - 1]) && img.face[n - 1] == -1);
    crisp_image_free(&img);
}

static void test_camera(void **state)
{
    (void)state;
    double box[6] = {-1, -2, -3, 3, 2, 1};
    crisp_camera cam;
    assert_int_equal(crisp_camera_frame_box(box, 640, 480, &cam), CRISP_OK);
    assert_int_equal(crisp_camera_check(&cam), CRISP_OK);
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(&cam, &m);
    /* Every box corner projects inside the image and between near and far. */
    for (int k = 0; k < 8; k++) {
        double p[3] = {box[(k & 1) ? 3 : 0], box[(k & 2) ? 4 : 1], box[(k & 4) ? 5 : 2]}, c[4],
               px[3];
        crisp_mat4_mulp(m.view_proj, p, c);
        crisp_camera_to_pixel(&cam, c, px);
        assert_true(px[0] > 0 && px[0] < 640 && px[1] > 0 && px[1] < 480);
        assert_true(px[2] > -1 && px[2] < 1);
    }
    /* The ray through a pixel centre passes through the point that projects to it. */
    double o[3], d[3], q[3], c[4], px[3];
    crisp_camera_ray(&cam, 100.5, 37.5, o, d);
    for (int i = 0; i < 3; i++)
        q[i] = o[i] + 7.3 * d[i];
    crisp_mat4_mulp(m.view_proj, q, c);
    crisp_camera_to_pixel(&cam, c, px);
    assert_true(fabs(px[0] - 100.5) < 1e-9 && fabs(px[1] - 37.5) < 1e-9);
    cam.fov_deg = 0;
    assert_int_equal(crisp_camera_check(&cam), CRISP_ERR_INVALID_ARG);
    assert_true(strstr(crisp_error_message(), "fov") != NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_watertight),   cmocka_unit_test(test_perspective_correct),
        cmocka_unit_test(test_near_plane),   cmocka_unit_test(test_threads_identical),
        cmocka_unit_test(test_bad_input),    cmocka_unit_test(test_camera),
        cmocka_unit_test(test_target_lines),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
