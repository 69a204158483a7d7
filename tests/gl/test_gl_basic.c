/* GL backend on plans filled by hand (no planner): a bilinear square seen from the front, with and
 * without a trim table, at 1, 4 and 16 samples and at extreme zoom; the error paths (compile and
 * link failure, buffer limit, bad leaves); the layout probe against the C records. Each pixel
 * farther than 1 px from an edge must be classified as the exact ray cast says. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "crisp/gl.h"
#include "gl/gl_internal.h"
#include "gl/gl_test_util.h"

/* The square [-1, 1]^2 in z = 0 as one bilinear patch, u = (x + 1) / 2, v = (y + 1) / 2. */
static const double square_cps[16] = {-1, -1, 0, 1, 1, -1, 0, 1, -1, 1, 0, 1, 1, 1, 0, 1};
static const crisp_scene_patch_record square_rec = {0, 1, 1, 0, 0, 1, 0, 1};
static const float square_color[4] = {0.8f, 0.6f, 0.4f, 1};

/* A trim table: one strip over v in [0, 1] with `rows` rows; each row holds the crossings of the
 * disc of radius 0.3 around (0.5, 0.5) (or none) at the row's centre line. */
typedef struct hand_plan {
    crisp_frame_plan plan;
    crisp_plan_leaf leaves[64];
    crisp_plan_face face;
    crisp_plan_strip strip;
    uint32_t row_offset[257];
    double crossings[512];
    crisp_plan_ribbon_vertex ribbon[4];
} hand_plan;

static void make_plan(hand_plan *h, const crisp_camera *cam, int trimmed, int depth, int rows)
{
    memset(h, 0, sizeof *h);
    crisp_frame_plan *p = &h->plan;
    gl_plan_camera(p, cam);
    int n = 1 << depth;
    /* Levels 4: a vertex's leaf-local k / 4 is exact in float, so the float (s, t) the fragment
     * stage receives are the vertices' parameters even for test_zoom's single leaf of 2e10 px
     * (the plan splits leaves over CRISP_PLAN_MAX_LEAF_PX; at level 3 the shaders' exact k / 3
     * for edge vertices, surface_tes.glsl, is 1e-8 off its float copy: 100 px on that leaf). */
    for (int iy = 0; iy < n; iy++)
        for (int ix = 0; ix < n; ix++) {
            crisp_plan_leaf *L = &h->leaves[iy * n + ix];
            *L = (crisp_plan_leaf){.patch = 0,
                                   .face = 0,
                                   .depth = (uint32_t)depth,
                                   .tau = 4,
                                   .ix = (uint32_t)ix,
                                   .iy = (uint32_t)iy,
                                   .edge = {4, 4, 4, 4}};
        }
    p->leaves = h->leaves;
    p->leaf_count = (uint32_t)(n * n);
    h->face = (crisp_plan_face){.v0 = 0,
                                .v1 = 1,
                                .strip_scale = 1,
                                .first_strip = 0,
                                .strip_count = 1,
                                .first_leaf = 0,
                                .leaf_count = p->leaf_count,
                                .flags = CRISP_PLAN_FACE_VISIBLE,
                                .tau_max = 4};
    if (!trimmed) h->face.flags |= CRISP_PLAN_FACE_ALL_INSIDE;
    p->faces = &h->face;
    p->face_count = 1;
    h->strip =
        (crisp_plan_strip){.a = 0, .row_scale = rows, .first_row = 0, .row_count = (uint32_t)rows};
    p->strips = &h->strip;
    p->strip_count = 1;
    uint32_t c = 0;
    for (int r = 0; r < rows; r++) {
        h->row_offset[r] = c;
        double v = (r + 0.5) / rows, dy = v - 0.5;
        if (fabs(dy) < 0.3) {
            double dx = sqrt(0.09 - dy * dy);
            h->crossings[c++] = 0.5 - dx;
            h->crossings[c++] = 0.5 + dx;
        }
    }
    h->row_offset[rows] = c;
    p->row_offset = h->row_offset;
    p->row_count = (uint32_t)rows;
    p->crossings = h->crossings;
    p->crossing_count = c;
    p->ribbon_vertices = h->ribbon;
    p->ribbon_quad_count = 0;
    /* as a planner does: every array changed (the backend uploads by version) */
    static uint64_t version;
    version++;
    p->leaves_version = p->faces_version = p->table_version = p->ribbons_version = version;
}

/* The table test of include/crisp/plan.h on the hand plan. */
static int ref_trim(const hand_plan *h, double u, double v)
{
    return crisp_plan_trim_test(&h->plan, 0, u, v);
}

static crisp_gl *make_gl(int samples)
{
    crisp_gl *gl = NULL;
    crisp_status st =
        crisp_gl_create(crisp_gl_context_getproc(ctx), &(crisp_gl_desc){.samples = samples}, &gl);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    crisp_gl_scene_data d = {square_cps, 4, &square_rec, 1, square_color, 1};
    assert_int_equal(crisp_gl_set_scene_data(gl, &d), CRISP_OK);
    return gl;
}

/* Renders and checks every pixel whose sample points are farther than 1 px (on screen) from the
 * square's edges and the trim boundary: coverage, face, depth, (u, v), normal. Returns how many
 * pixels were checked. */
static int check_square(int samples, const crisp_camera *cam, int trimmed, int depth)
{
    crisp_gl *gl = make_gl(samples);
    hand_plan *h = malloc(sizeof *h);
    int rows = 256;
    make_plan(h, cam, trimmed, depth, rows);
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, cam->width, cam->height), CRISP_OK);
    crisp_gl_stats gs;
    crisp_status st = crisp_gl_draw(gl, &h->plan, &gs);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    assert_int_equal(crisp_gl_read(gl, &img, &gs), CRISP_OK);
    /* Pixel size in world units at z = 0 (frontal camera on the z axis). */
    double dist = cam->eye[2], px = 2 * dist * tan(cam->fov_deg * M_PI / 360) / cam->height;
    int checked = 0, covered = 0;
    for (int j = 0; j < cam->height; j++)
        for (int i = 0; i < cam->width; i++) {
            double o[3], d[3];
            crisp_camera_ray(cam, i + 0.5, j + 0.5, o, d);
            double t = -o[2] / d[2], x = o[0] + t * d[0], y = o[1] + t * d[1];
            double u = (x + 1) / 2, v = (y + 1) / 2;
            /* distance to the square's edges and the trim circle (u, v units), in pixels */
            double e = fmin(fmin(fabs(x - 1), fabs(x + 1)), fmin(fabs(y - 1), fabs(y + 1))) / px;
            double rr = hypot(u - 0.5, v - 0.5);
            int in_square = fabs(x) < 1 && fabs(y) < 1;
            int want = in_square && ref_trim(h, u, v);
            if (trimmed) {
                /* rows sample the circle at their centre lines: the table's boundary is within a
                 * row height of the circle */
                double band = fabs(rr - 0.3) * 2 / px - 2.0 / rows / px;
                e = fmin(e, band);
            }
            if (e < 1.5) continue;
            checked++;
            size_t k = (size_t)j * cam->width + i;
            if (!want) {
                assert_int_equal(img.face[k], -1);
                assert_true(img.rgba[4 * k + 3] == 0);
                assert_true(isinf(img.depth[k]));
                continue;
            }
            covered++;
            if (img.face[k] != 0 || img.rgba[4 * k + 3] != 1)
                fail_msg("pixel (%d, %d): face %d alpha %g, expected covered (u %g v %g)", i, j,
                         img.face[k], img.rgba[4 * k + 3], u, v);
            assert_true(fabs(img.depth[k] - dist) < 1e-5 * dist);
            /* uv at the nearest sample: within one pixel of the centre's */
            assert_true(fabs(img.uv[2 * k] - u) < px && fabs(img.uv[2 * k + 1] - v) < px);
            assert_true(fabs(img.normal[3 * k + 2] - 1) < 1e-5);
            /* headlight: |n . d| / |d| at the sample; frontal view, close to 1 */
            assert_true(fabs(img.rgba[4 * k] - square_color[0] * (0.25 + 0.75 * fabs(d[2]))) <
                        1e-3);
        }
    assert_true(covered > 0);
    /* the viewer's path: the colour blitted into an app framebuffer, the image's top row at the
     * top (GL's last row) */
    uint8_t *px8 = malloc((size_t)cam->width * cam->height * 4);
    assert_int_equal(crisp__gl_blit_probe(gl, px8), CRISP_OK);
    for (int j = 0; j < cam->height; j++)
        for (int i = 0; i < cam->width; i++) {
            size_t k = (size_t)j * cam->width + i,
                   g = (size_t)(cam->height - 1 - j) * cam->width + i;
            for (int c = 0; c < 4; c++)
                assert_true(abs((int)px8[4 * g + c] - (int)lrintf(255 * img.rgba[4 * k + c])) <= 1);
        }
    free(px8);
    crisp_image_free(&img);
    free(h);
    crisp_gl_destroy(gl);
    return checked;
}

static crisp_camera front_camera(double fov, int w, int h)
{
    crisp_camera cam = {.eye = {0, 0, 4},
                        .target = {0, 0, 0},
                        .up = {0, 1, 0},
                        .fov_deg = fov,
                        .znear = 0.5,
                        .zfar = 100,
                        .width = w,
                        .height = h};
    return cam;
}

static void test_square(void **state)
{
    (void)state;
    crisp_camera cam = front_camera(40, 96, 72);
    assert_true(check_square(1, &cam, 0, 0) > 3000);
    assert_true(check_square(1, &cam, 0, 2) > 3000);
}

static void test_trimmed(void **state)
{
    (void)state;
    crisp_camera cam = front_camera(40, 96, 72);
    assert_true(check_square(1, &cam, 1, 1) > 3000);
}

static void test_samples(void **state)
{
    (void)state;
    crisp_camera cam = front_camera(40, 64, 48);
    assert_true(check_square(4, &cam, 1, 1) > 1000);
    assert_true(check_square(16, &cam, 1, 1) > 1000);
}

/* Extreme zoom: fov 1e-4 and 1e-6 degree looking at a point of the trim circle (the pixel is
 * 1e-8 .. 1e-10 of the square): the boundary still splits the image where the exact test says. */
static void test_zoom(void **state)
{
    (void)state;
    double fovs[2] = {1e-4, 1e-6};
    for (int k = 0; k < 2; k++) {
        crisp_camera cam = front_camera(fovs[k], 64, 48);
        /* look at the circle's leftmost point, (u, v) = (0.2, 0.5): x = -0.6, y = 0 */
        cam.eye[0] = cam.target[0] = -0.6 + 3e-12;
        cam.eye[1] = cam.target[1] = 1e-12;
        crisp_gl *gl = make_gl(1);
        hand_plan *h = malloc(sizeof *h);
        make_plan(h, &cam, 1, 0, 4);
        /* one exact crossing at the look-at point in every row */
        h->crossings[0] = 0.2;
        h->crossings[1] = 0.8;
        h->row_offset[0] = 0;
        for (int r = 1; r <= 4; r++)
            h->row_offset[r] = 2;
        h->strip.row_count = 1;
        h->strip.row_scale = 1;
        h->plan.row_count = 1;
        crisp_image img;
        assert_int_equal(crisp_image_init(&img, cam.width, cam.height), CRISP_OK);
        assert_int_equal(crisp_gl_draw(gl, &h->plan, NULL), CRISP_OK);
        assert_int_equal(crisp_gl_read(gl, &img, NULL), CRISP_OK);
        double px = 2 * 4 * tan(cam.fov_deg * M_PI / 360) / cam.height;
        int checked = 0, inside = 0;
        for (int j = 0; j < cam.height; j++)
            for (int i = 0; i < cam.width; i++) {
                double o[3], d[3];
                crisp_camera_ray(&cam, i + 0.5, j + 0.5, o, d);
                double t = -o[2] / d[2], x = o[0] + t * d[0];
                double u = (x + 1) / 2;
                if (fabs(u - 0.2) * 2 < 1.0 * px) continue; /* within 1 px of the boundary */
                int want = u > 0.2;
                size_t q = (size_t)j * cam.width + i;
                if (img.face[q] != (want ? 0 : -1))
                    fail_msg("fov %g: pixel (%d, %d) u - 0.2 = %g px: face %d, expected %d",
                             cam.fov_deg, i, j, (u - 0.2) * 2 / px, img.face[q], want ? 0 : -1);
                checked++;
                inside += want;
            }
        assert_true(checked > 60 * 48 && inside > 20 * 48 && inside < 40 * 48);
        crisp_image_free(&img);
        free(h);
        crisp_gl_destroy(gl);
    }
}

static void test_errors(void **state)
{
    (void)state;
    /* compile and link failures name the shader and carry the log */
    assert_int_equal(
        crisp__gl_try_program("broken", CRISP__GL_FRAGMENT, "void main() { nonsense; }"),
        CRISP_ERR_GL);
    assert_non_null(strstr(crisp_error_message(), "broken"));
    assert_int_equal(crisp__gl_try_program("ok", CRISP__GL_COMPUTE,
                                           "layout(local_size_x = 1) in; void main() {}"),
                     CRISP_OK);
    assert_int_equal(
        crisp__gl_try_program("unlinked", CRISP__GL_VERTEX, "void f(); void main() { f(); }"),
        CRISP_ERR_GL);
    assert_non_null(strstr(crisp_error_message(), "unlinked"));
    /* a plan larger than the buffer limit */
    crisp_gl *gl = NULL;
    assert_int_equal(crisp_gl_create(crisp_gl_context_getproc(ctx),
                                     &(crisp_gl_desc){.max_buffer_bytes = 1024}, &gl),
                     CRISP_OK);
    crisp_gl_scene_data d = {square_cps, 4, &square_rec, 1, square_color, 1};
    assert_int_equal(crisp_gl_set_scene_data(gl, &d), CRISP_OK);
    crisp_camera cam = front_camera(40, 32, 24);
    hand_plan *h = malloc(sizeof *h);
    make_plan(h, &cam, 1, 3, 256); /* 64 leaves = 3072 bytes, 2.4 kB of crossings */
    assert_int_equal(crisp_gl_draw(gl, &h->plan, NULL), CRISP_ERR_LIMIT);
    assert_non_null(strstr(crisp_error_message(), "trim"));
    assert_non_null(strstr(crisp_error_message(), "GL_MAX_SHADER_STORAGE_BLOCK_SIZE"));
    crisp_image img, ref;
    assert_int_equal(crisp_image_init(&img, cam.width, cam.height), CRISP_OK);
    assert_int_equal(crisp_image_init(&ref, cam.width, cam.height), CRISP_OK);
    assert_int_equal(crisp_gl_read(gl, &img, NULL), CRISP_ERR_INVALID_ARG); /* nothing to read */
    /* leaves beyond the limit are drawn in chunks: the same image as without the limit */
    make_plan(h, &cam, 1, 3, 8);
    assert_int_equal(crisp_gl_draw(gl, &h->plan, NULL), CRISP_OK);
    assert_int_equal(crisp_gl_read(gl, &img, NULL), CRISP_OK);
    crisp_gl *big = make_gl(1);
    assert_int_equal(crisp_gl_draw(big, &h->plan, NULL), CRISP_OK);
    assert_int_equal(crisp_gl_read(big, &ref, NULL), CRISP_OK);
    crisp_gl_destroy(big);
    size_t n = (size_t)cam.width * cam.height, covered = 0;
    for (size_t k = 0; k < n; k++)
        covered += img.face[k] == 0;
    assert_true(covered > n / 20);
    assert_memory_equal(img.face, ref.face, n * sizeof *img.face);
    assert_memory_equal(img.rgba, ref.rgba, 4 * n * sizeof *img.rgba);
    /* a leaf with a level above 64, a bad patch index, an out-of-range control net */
    make_plan(h, &cam, 1, 0, 8);
    h->leaves[0].edge[2] = 65;
    assert_int_equal(crisp_gl_draw(gl, &h->plan, NULL), CRISP_ERR_INVALID_ARG);
    assert_non_null(strstr(crisp_error_message(), "65"));
    h->leaves[0].edge[2] = 3;
    h->leaves[0].patch = 1;
    h->plan.leaves_version++;
    assert_int_equal(crisp_gl_draw(gl, &h->plan, NULL), CRISP_ERR_INVALID_ARG);
    h->leaves[0].patch = 0;
    h->plan.leaves_version++;
    assert_int_equal(crisp_gl_draw(gl, &h->plan, NULL), CRISP_OK);
    assert_int_equal(crisp_gl_read(gl, &img, NULL), CRISP_OK);
    crisp_scene_patch_record bad = square_rec;
    bad.du = 2;
    crisp_gl_scene_data d2 = {square_cps, 4, &bad, 1, square_color, 1};
    assert_int_equal(crisp_gl_set_scene_data(gl, &d2), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_gl_draw(gl, &h->plan, NULL), CRISP_ERR_INVALID_ARG); /* no scene now */
    crisp_image_free(&img);
    crisp_image_free(&ref);
    crisp_gl_destroy(gl);
    /* bad sample counts */
    assert_int_equal(
        crisp_gl_create(crisp_gl_context_getproc(ctx), &(crisp_gl_desc){.samples = 3}, &gl),
        CRISP_ERR_INVALID_ARG);
    free(h);
}

/* The layout probe reads the hand plan's records as the shaders do. */
static void test_layout_hand(void **state)
{
    (void)state;
    crisp_gl *gl = make_gl(1);
    crisp_camera cam = front_camera(40, 32, 24);
    hand_plan *h = malloc(sizeof *h);
    make_plan(h, &cam, 1, 2, 37);
    for (int k = 0; k < 16; k++) {
        h->leaves[k].tau = 1 + (uint32_t)(k * 4);
        for (int e = 0; e < 4; e++)
            h->leaves[k].edge[e] = 1 + (uint32_t)((k * 7 + e * 13) % 64);
    }
    enum { N = 4000 };
    crisp__gl_query *q = calloc(N, sizeof *q);
    crisp__gl_result *r = calloc(N, sizeof *r);
    srand(7);
    for (int k = 0; k < N; k++) {
        q[k].u = rand() / (double)RAND_MAX * 1.2 - 0.1;
        q[k].v = rand() / (double)RAND_MAX * 1.2 - 0.1;
        if (k % 5 == 0 && h->plan.crossing_count) q[k].u = h->crossings[k % h->plan.crossing_count];
        q[k].s = rand() / (double)RAND_MAX;
        q[k].t = rand() / (double)RAND_MAX;
        q[k].leaf = (uint32_t)(k % 16);
    }
    assert_int_equal(crisp__gl_layout_probe(gl, &h->plan, q, N, r), CRISP_OK);
    for (int k = 0; k < N; k++) {
        assert_int_equal(r[k].inside, ref_trim(h, q[k].u, q[k].v));
        const crisp_plan_leaf *L = &h->leaves[q[k].leaf];
        assert_int_equal(r[k].tau, L->tau);
        assert_int_equal(r[k].depth, L->depth);
        assert_int_equal(r[k].patch, L->patch);
        for (int e = 0; e < 4; e++)
            assert_int_equal(r[k].edge[e], L->edge[e]);
        double sc = ldexp(1, -(int)L->depth);
        double u = (L->ix + q[k].s) * sc, v = (L->iy + q[k].t) * sc;
        assert_true(fabs(r[k].u - u) < 1e-15 && fabs(r[k].v - v) < 1e-15);
    }
    free(q);
    free(r);
    free(h);
    crisp_gl_destroy(gl);
}

/* Ribbons: drawn over empty pixels; over a surface only where nearer by more than the depth slack
 * (1.5 x the surface's W change to the neighbouring pixels): the square tilted to z = y changes W
 * by about 0.04 per pixel, so a ribbon 0.01 in front of it stays hidden and one 0.3 in front shows.
 */
static void test_ribbons(void **state)
{
    (void)state;
    static const double tilted[16] = {-1, -1, -1, 1, 1, -1, -1, 1, -1, 1, 1, 1, 1, 1, 1, 1};
    static const float colors[8] = {0.8f, 0.6f, 0.4f, 1, 0.1f, 0.9f, 0.1f, 1};
    crisp_camera cam = front_camera(40, 96, 72);
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(&cam, &m);
    double offsets[3] = {0.01, 0.3, -0.3};
    int expect_ribbon[3] = {0, 1, 0};
    for (int c = 0; c < 3; c++) {
        crisp_gl *gl = NULL;
        assert_int_equal(crisp_gl_create(crisp_gl_context_getproc(ctx), NULL, &gl), CRISP_OK);
        crisp_gl_scene_data d = {tilted, 4, &square_rec, 1, colors, 2};
        assert_int_equal(crisp_gl_set_scene_data(gl, &d), CRISP_OK);
        hand_plan *h = malloc(sizeof *h);
        make_plan(h, &cam, 0, 1, 8);
        crisp_plan_face faces[2] = {h->face, {.v0 = 0, .v1 = 1}};
        h->plan.faces = faces;
        h->plan.face_count = 2;
        /* a quad over x in [-0.5, 0.5], y in [-0.2, 0.2] on the plane, moved towards the eye, and
         * a second one over empty space (x in [1.5, 1.8]) */
        crisp_plan_ribbon_vertex rv[8];
        double corners[8][2] = {{-0.5, -0.2}, {0.5, -0.2}, {0.5, 0.2}, {-0.5, 0.2},
                                {1.5, -0.2},  {1.8, -0.2}, {1.8, 0.2}, {1.5, 0.2}};
        for (int k = 0; k < 8; k++) {
            double P[3] = {corners[k][0], corners[k][1], corners[k][1] + offsets[c]};
            memset(&rv[k], 0, sizeof rv[k]);
            crisp_mat4_mulp(m.view_proj, P, rv[k].clip);
            rv[k].uv[0] = 0.25f;
            rv[k].uv[1] = 0.75f;
            rv[k].normal[2] = 1;
            rv[k].face = 1;
        }
        h->plan.ribbon_vertices = rv;
        h->plan.ribbon_quad_count = 2;
        crisp_image img;
        assert_int_equal(crisp_image_init(&img, cam.width, cam.height), CRISP_OK);
        assert_int_equal(crisp_gl_draw(gl, &h->plan, NULL), CRISP_OK);
        assert_int_equal(crisp_gl_read(gl, &img, NULL), CRISP_OK);
        /* pixel centres well inside each quad */
        int over = 0, empty = 0, n_over = 0, n_empty = 0;
        for (int j = 0; j < cam.height; j++)
            for (int i = 0; i < cam.width; i++) {
                double o[3], dd[3];
                crisp_camera_ray(&cam, i + 0.5, j + 0.5, o, dd);
                double z = offsets[c]; /* the ribbon plane z = y + offset */
                double t = (z - o[2] + o[1]) / (dd[2] - dd[1]);
                double x = o[0] + t * dd[0], y = o[1] + t * dd[1];
                size_t k = (size_t)j * cam.width + i;
                if (fabs(x) < 0.4 && fabs(y) < 0.15) {
                    n_over++;
                    over += img.face[k] == 1;
                    if (img.face[k] == 1)
                        assert_true(fabs(img.uv[2 * k] - 0.25f) < 1e-6 &&
                                    fabs(img.uv[2 * k + 1] - 0.75f) < 1e-6);
                } else if (x > 1.55 && x < 1.75 && fabs(y) < 0.15) {
                    n_empty++;
                    empty += img.face[k] == 1;
                }
            }
        assert_true(n_over > 100 && n_empty > 20);
        assert_int_equal(empty, n_empty);
        assert_int_equal(over, expect_ribbon[c] ? n_over : 0);
        crisp_image_free(&img);
        free(h);
        crisp_gl_destroy(gl);
    }
}

/* A rational patch: a quarter of the unit cylinder (biquadratic in u, linear in v) seen from
 * (4, 0, 4): depth and normal of each pixel within the tessellation tolerance of the true
 * cylinder's. */
static void test_rational(void **state)
{
    (void)state;
    double r = sqrt(0.5);
    const double cps[24] = {1, -1, 0, 1, r, -r, r, r, 0, -1, 1, 1,
                            1, 1,  0, 1, r, r,  r, r, 0, 1,  1, 1};
    crisp_scene_patch_record rec = {0, 2, 1, 0, 0, 1, 0, 1};
    crisp_camera cam = {.eye = {4, 0, 4},
                        .target = {0, 0, 0},
                        .up = {0, 1, 0},
                        .fov_deg = 30,
                        .znear = 0.5,
                        .zfar = 100,
                        .width = 80,
                        .height = 60};
    crisp_gl *gl = NULL;
    assert_int_equal(crisp_gl_create(crisp_gl_context_getproc(ctx), NULL, &gl), CRISP_OK);
    crisp_gl_scene_data d = {cps, 6, &rec, 1, square_color, 1};
    assert_int_equal(crisp_gl_set_scene_data(gl, &d), CRISP_OK);
    hand_plan *h = malloc(sizeof *h);
    make_plan(h, &cam, 0, 1, 8);
    for (int k = 0; k < 4; k++) {
        h->leaves[k].tau = 32;
        for (int e = 0; e < 4; e++)
            h->leaves[k].edge[e] = 32;
    }
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, cam.width, cam.height), CRISP_OK);
    assert_int_equal(crisp_gl_draw(gl, &h->plan, NULL), CRISP_OK);
    assert_int_equal(crisp_gl_read(gl, &img, NULL), CRISP_OK);
    double f[3] = {-r, 0, -r};
    int checked = 0;
    for (int j = 0; j < cam.height; j++)
        for (int i = 0; i < cam.width; i++) {
            double o[3], dd[3];
            crisp_camera_ray(&cam, i + 0.5, j + 0.5, o, dd);
            /* |(o + t d).xz| = 1, nearest root */
            double a = dd[0] * dd[0] + dd[2] * dd[2], b = 2 * (o[0] * dd[0] + o[2] * dd[2]);
            double c = o[0] * o[0] + o[2] * o[2] - 1, disc = b * b - 4 * a * c;
            size_t k = (size_t)j * cam.width + i;
            if (!(disc > 0)) continue;
            double t = (-b - sqrt(disc)) / (2 * a), P[3];
            for (int q = 0; q < 3; q++)
                P[q] = o[q] + t * dd[q];
            if (!(P[0] > 0.05 && P[2] > 0.05 && fabs(P[1]) < 0.9)) continue;
            checked++;
            assert_int_equal(img.face[k], 0);
            double depth = (P[0] - o[0]) * f[0] + (P[1] - o[1]) * f[1] + (P[2] - o[2]) * f[2];
            if (fabs(img.depth[k] - depth) > 2e-3)
                fail_msg("pixel (%d, %d): depth %g, expected %g", i, j, img.depth[k], depth);
            /* outward normal (x, 0, z) up to the patch's orientation */
            double dot = img.normal[3 * k] * P[0] + img.normal[3 * k + 2] * P[2];
            assert_true(fabs(fabs(dot) - 1) < 2e-3 && fabs(img.normal[3 * k + 1]) < 2e-3);
        }
    assert_true(checked > 500);
    crisp_image_free(&img);
    free(h);
    crisp_gl_destroy(gl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_square),  cmocka_unit_test(test_trimmed),
        cmocka_unit_test(test_samples), cmocka_unit_test(test_zoom),
        cmocka_unit_test(test_errors),  cmocka_unit_test(test_layout_hand),
        cmocka_unit_test(test_ribbons), cmocka_unit_test(test_rational),
    };
    return cmocka_run_group_tests(tests, gl_setup, gl_teardown);
}
