/* GL backend: splats (issue 12) on plans filled by hand. Every sample of every pixel is compared
 * with a reference computed here from include/crisp/plan.h's rule: splat k of a drawn range
 * covers the sample at image position (x, y) (pixels, y down) when cx - h <= x < cx + h and
 * cy - h <= y < cy + h, (cx, cy) its projection of the float clip position
 * splat_clip_origin[4 face + k] + sum_j view_proj_f[k + 4 j] p[j]; the nearest covering splat wins
 * (the first drawn among equal depths). The image's face, depth, normal (flipped for reversed
 * faces) and (u, v) are the nearest sample's, alpha the covered fraction. At 1 and 4 samples:
 *   - test_exact: a view matrix that makes every centre an exact binary fraction, centres on and
 *     beside (2^-12 .. 2^-6 px) the squares' sides and outside the image by up to 3 px, several h;
 *   - test_camera: a real camera, splats on planes at several depths, and the same with the
 *     plane z = 0 drawn as a surface leaf between them (splats in front of it win, behind lose);
 *   - test_clip: the section plane cuts the squares per sample;
 *   - test_raw: GL's own point rasterization (size 2 h, no coverage test in the fragment stage)
 *     against the rule: on llvmpipe a sample exactly on a side is covered as the rule says
 *     (closed left and top, open right and bottom), but one within 1/512 px of a side may not be
 *     (it rounds the point's centre to 1/256 px), which is why the backend draws points a margin
 *     larger and tests the rule itself;
 *   - test_upload: the store goes up only when splats_version changes; bad ranges, bad faces and
 *     a half-size beyond the point size limit are errors;
 *   - test_chunks: a store above the storage block limit, drawn a chunk at a time. */
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
#include "render/raster.h"
#include "render/splat.h"

/* The square [-1, 1]^2 in z = 0 as one bilinear patch of face 0 (as test_gl_basic). */
static const double square_cps[16] = {-1, -1, 0, 1, 1, -1, 0, 1, -1, 1, 0, 1, 1, 1, 0, 1};
static const crisp_scene_patch_record square_rec = {0, 1, 1, 0, 0, 1, 0, 1};
enum { NF = 4, MAX_SPLATS = 4096, MAX_RANGES = 64 };
static const float colors[4 * NF] = {0.8f, 0.6f, 0.4f, 1, 0.2f, 0.7f, 0.3f, 1,
                                     0.3f, 0.3f, 0.9f, 1, 0.9f, 0.2f, 0.2f, 1};

typedef struct splat_plan {
    crisp_frame_plan plan;
    crisp_plan_face faces[NF];
    crisp_plan_leaf leaf;
    crisp_plan_strip strip;
    uint32_t row_offset[2];
    crisp_plan_splat splats[MAX_SPLATS];
    uint32_t face[MAX_SPLATS]; /* each splat's face (the ranges carry it) */
    crisp_plan_splat_range ranges[MAX_RANGES];
    float origin[4 * NF];
} splat_plan;

static uint64_t version;

static crisp_camera front_camera(double dist, int w, int h)
{
    crisp_camera cam = {.eye = {0, 0, dist},
                        .target = {0, 0, 0},
                        .up = {0, 1, 0},
                        .fov_deg = 40,
                        .znear = 0.1,
                        .zfar = 100,
                        .width = w,
                        .height = h};
    return cam;
}

/* A plan of the camera's view with no leaves (with_leaf: the square as one leaf of face 0);
 * faces 1..3 drawn as splats, face 3 reversed. */
static void plan_init(splat_plan *s, const crisp_camera *cam, int with_leaf, double h)
{
    memset(s, 0, sizeof *s);
    crisp_frame_plan *p = &s->plan;
    gl_plan_camera(p, cam);
    s->leaf = (crisp_plan_leaf){.tau = 4, .edge = {4, 4, 4, 4}};
    p->leaves = &s->leaf;
    p->leaf_count = with_leaf ? 1 : 0;
    s->faces[0] = (crisp_plan_face){.v0 = 0,
                                    .v1 = 1,
                                    .strip_scale = 1,
                                    .strip_count = 1,
                                    .leaf_count = p->leaf_count,
                                    .flags = CRISP_PLAN_FACE_VISIBLE | CRISP_PLAN_FACE_ALL_INSIDE,
                                    .tau_max = 4};
    for (int f = 1; f < NF; f++)
        s->faces[f].flags = CRISP_PLAN_FACE_SPLATS | (f == 3 ? CRISP_PLAN_FACE_REVERSED : 0);
    p->faces = s->faces;
    p->face_count = NF;
    s->strip = (crisp_plan_strip){.a = 0, .row_scale = 1, .first_row = 0, .row_count = 1};
    p->strips = &s->strip;
    p->strip_count = 1;
    p->row_offset = s->row_offset;
    p->row_count = 1;
    p->splats = s->splats;
    p->splat_ranges = s->ranges;
    p->splat_clip_origin = s->origin;
    p->splat_half_px = h;
    version++;
    p->leaves_version = p->faces_version = p->table_version = p->ribbons_version =
        p->splats_version = version;
}

static crisp_gl *make_gl_limit(int samples, size_t max_buffer_bytes)
{
    crisp_gl *gl = NULL;
    crisp_status st = crisp_gl_create(
        crisp_gl_context_getproc(ctx),
        &(crisp_gl_desc){.samples = samples, .max_buffer_bytes = max_buffer_bytes}, &gl);
    if (st) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    crisp_gl_scene_data d = {square_cps, 4, &square_rec, 1, colors, NF};
    assert_int_equal(crisp_gl_set_scene_data(gl, &d), CRISP_OK);
    crisp__gl_keep_sample_faces(gl);
    return gl;
}

static crisp_gl *make_gl(int samples)
{
    return make_gl_limit(samples, 0);
}

/* ---- the reference ------------------------------------------------------------------------ */

/* The rule's float clip position of a splat and its centre on the image (double). */
static void splat_clip(const crisp_frame_plan *p, uint32_t face, const crisp_plan_splat *sp,
                       float c[4])
{
    for (int k = 0; k < 4; k++) {
        float v = p->splat_clip_origin[4 * face + k];
        for (int j = 0; j < 3; j++) {
            volatile float t = p->view_proj_f[k + 4 * j] * sp->p[j]; /* no fused multiply-add */
            v = v + t;
        }
        c[k] = v;
    }
}

static void splat_centre(const crisp_frame_plan *p, const float c[4], double *cx, double *cy)
{
    double w = c[3];
    *cx = ((double)c[0] / w + 1.0) * 0.5 * p->width;
    *cy = (1.0 - (double)c[1] / w) * 0.5 * p->height;
}

typedef struct ref_sample {
    int32_t face;
    int32_t splat; /* -1: none */
    float w;
} ref_sample;

/* Every sample's nearest covering splat (samples in the CPU backend's layout: (j W + i) S + s);
 * under[] (may be NULL): what a sample holds before the splats (face, depth W). */
static const double *plane; /* the section plane in clip space (test_clip), NULL: none */

static void reference(const crisp_frame_plan *p, int S, const ref_sample *under, ref_sample *out)
{
    int W = p->width, H = p->height;
    double h = p->splat_half_px;
    for (size_t k = 0; k < (size_t)W * H * S; k++)
        out[k] = under ? under[k] : (ref_sample){-1, -1, INFINITY};
    for (uint32_t r = 0; r < p->splat_range_count; r++)
        for (uint32_t i = p->splat_ranges[r].first;
             i < p->splat_ranges[r].first + p->splat_ranges[r].count; i++) {
            const crisp_plan_splat *sp = &p->splats[i];
            uint32_t face = p->splat_ranges[r].face;
            float c[4];
            splat_clip(p, face, sp, c);
            /* behind the eye, beyond the near or far plane: not drawn (as the CPU backend) */
            if (!(c[3] > 0) || !(c[2] >= -c[3]) || !(c[2] <= c[3]) || !isfinite(c[0] + c[1]))
                continue;
            double cx, cy;
            splat_centre(p, c, &cx, &cy);
            for (int j = (int)floor(cy - h) - 1; j <= (int)ceil(cy + h) + 1; j++)
                for (int x = (int)floor(cx - h) - 1; x <= (int)ceil(cx + h) + 1; x++) {
                    if (x < 0 || j < 0 || x >= W || j >= H) continue;
                    for (int s = 0; s < S; s++) {
                        double off[2];
                        crisp__raster_sample_offset(S, s, off);
                        double X = x + off[0], Y = j + off[1];
                        if (!(cx - h <= X && X < cx + h && cy - h <= Y && Y < cy + h)) continue;
                        /* the section plane at the sample's point of the square */
                        double w = c[3],
                               cc[4] = {(2 * X / W - 1) * w, (1 - 2 * Y / H) * w, c[2], w};
                        if (plane && plane[0] * cc[0] + plane[1] * cc[1] + plane[2] * cc[2] +
                                             plane[3] * cc[3] <
                                         0)
                            continue;
                        ref_sample *o = &out[((size_t)j * W + x) * S + s];
                        /* the depth test: nearer wins (the backends compare 1 / W), equal keeps
                         * the first */
                        if (c[3] < o->w) *o = (ref_sample){(int32_t)face, (int32_t)i, c[3]};
                    }
                }
        }
}

/* Draws the plan and checks every sample's face against the reference, and every pixel's
 * coverage, face, depth, normal and (u, v) against the nearest reference sample. Returns the
 * covered samples. */
static long check_plan(crisp_gl *gl, const crisp_frame_plan *p, int S, const ref_sample *under,
                       const float *under_normal)
{
    int W = p->width, H = p->height;
    size_t n = (size_t)W * H;
    ref_sample *ref = malloc(n * S * sizeof *ref);
    reference(p, S, under, ref);
    crisp_gl_stats gs;
    crisp_status st = crisp_gl_draw(gl, p, &gs);
    if (st) fail_msg("%s", crisp_error_message());
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, W, H), CRISP_OK);
    assert_int_equal(crisp_gl_read(gl, &img, NULL), CRISP_OK);
    int32_t *faces = malloc(n * S * sizeof *faces);
    assert_int_equal(crisp__gl_sample_faces(gl, faces), CRISP_OK);
    long covered = 0, wrong = 0;
    for (size_t k = 0; k < n * S; k++) {
        covered += ref[k].face >= 0;
        if (faces[k] != ref[k].face) {
            if (wrong++ < 5)
                fprintf(stderr, "sample (%zu, %zu) #%zu: gl face %d, rule %d (splat %d)\n",
                        k / S % W, k / S / W, k % S, faces[k], ref[k].face, ref[k].splat);
        }
    }
    assert_int_equal(wrong, 0);
    uint64_t drawn = 0;
    for (uint32_t r = 0; r < p->splat_range_count; r++)
        drawn += p->splat_ranges[r].count;
    assert_true(gs.splats == drawn);
    for (size_t k = 0; k < n; k++) {
        int best = -1, count = 0;
        for (int s = 0; s < S; s++) {
            const ref_sample *r = &ref[k * S + s];
            if (r->face < 0) continue;
            count++;
            if (best < 0 || r->w < ref[k * S + best].w) best = s;
        }
        assert_true(img.rgba[4 * k + 3] == (float)count / S);
        if (best < 0) {
            assert_int_equal(img.face[k], -1);
            assert_true(isinf(img.depth[k]));
            continue;
        }
        const ref_sample *r = &ref[k * S + best];
        assert_int_equal(img.face[k], r->face);
        if (r->splat < 0) { /* the surface's sample */
            if (under_normal) assert_true(fabsf(img.normal[3 * k + 2] - under_normal[2]) < 1e-5f);
            continue;
        }
        const crisp_plan_splat *sp = &p->splats[r->splat];
        assert_true(img.depth[k] == r->w);
        float sign = (p->faces[r->face].flags & CRISP_PLAN_FACE_REVERSED) ? -1.0f : 1.0f, nrm[3];
        crisp_plan_splat_normal(sp->n, nrm);
        for (int a = 0; a < 3; a++)
            assert_true(img.normal[3 * k + a] == sign * nrm[a]);
        assert_true(img.uv[2 * k] == sp->uv[0] && img.uv[2 * k + 1] == sp->uv[1]);
    }
    free(faces);
    crisp_image_free(&img);
    free(ref);
    return covered;
}

static double urand(void)
{
    return rand() / (RAND_MAX + 1.0);
}

/* A random unit normal, packed (some pointing away: the octahedron's folded half). */
static uint32_t random_normal(void)
{
    double v[3] = {urand() - 0.5, urand() - 0.5, urand() - 0.3},
           l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    float n[3];
    for (int a = 0; a < 3; a++)
        n[a] = (float)(v[a] / l);
    return crisp__splat_pack_normal(n);
}

/* Ranges over the store: runs of up to 40 splats of one face (splats are made face by face),
 * some skipped (not drawn) and one empty. */
static void make_ranges(splat_plan *s)
{
    crisp_frame_plan *p = &s->plan;
    uint32_t first = 0, r = 0;
    for (int run = 0; first < p->splat_count && r + 1 < MAX_RANGES; run++) {
        uint32_t f = s->face[first], n = 1;
        while (first + n < p->splat_count && n < 40 && s->face[first + n] == f)
            n++;
        if (run % 5 != 3) s->ranges[r++] = (crisp_plan_splat_range){first, n, f};
        first += n;
        if (r == 2) s->ranges[r++] = (crisp_plan_splat_range){first, 0, 1};
    }
    p->splat_range_count = r;
}

/* ---- tests ---------------------------------------------------------------------------------- */

/* view_proj_f maps p to clip (p0, p1, p2, 0) and each face's origin adds (0, 0, 0, W_f) (W_f a
 * power of two): the centre is exactly (p0 / W_f + 1) 32, (1 - p1 / W_f) 32 on the 64x64 image, so
 * centres can be put exactly on the squares' sides, or 2^-12 .. 2^-6 px beside them; clip z = p2
 * puts a sixth of them beyond the near or the far plane. */
static void fill_exact(splat_plan *s, int count)
{
    crisp_frame_plan *p = &s->plan;
    memset(p->view_proj_f, 0, sizeof p->view_proj_f);
    p->view_proj_f[0] = 1;
    p->view_proj_f[5] = 1;
    p->view_proj_f[10] = 1;
    static const float ws[NF] = {1, 4, 2, 4}; /* faces 1 and 3 at the same depth */
    for (int f = 0; f < NF; f++) {
        s->origin[4 * f + 0] = s->origin[4 * f + 1] = s->origin[4 * f + 2] = 0;
        s->origin[4 * f + 3] = ws[f];
    }
    double h = p->splat_half_px;
    for (int k = 0; k < count; k++) {
        crisp_plan_splat *sp = &s->splats[k];
        uint32_t f = 1 + (uint32_t)(k * 3 / count);
        double c[2];
        for (int a = 0; a < 2; a++) {
            /* a sample position (a multiple of 1/8 at 1 and 4 samples), minus or plus h (on a
             * side), or 2^-12 .. 2^-6 px beside that, over [-3, 67] */
            double x = -3 + floor(urand() * 70 * 8) / 8;
            int kind = rand() % 4;
            if (kind == 1) x += h;
            if (kind == 2) x -= h;
            if (kind == 3) x += (rand() % 2 ? 1 : -1) * ldexp(1 + rand() % 64, -12);
            c[a] = x;
        }
        float w = ws[f];
        sp->p[0] = (float)((c[0] / 32 - 1) * w);
        sp->p[1] = (float)((1 - c[1] / 32) * w);
        sp->p[2] = (float)((urand() * 2.4 - 1.2) * w);
        assert_true((double)sp->p[0] == (c[0] / 32 - 1) * w);
        s->face[k] = f;
        sp->n = random_normal();
        sp->uv[0] = (float)urand();
        sp->uv[1] = (float)urand();
    }
    p->splat_count = (uint32_t)count;
    make_ranges(s);
}

static void test_exact(void **state)
{
    (void)state;
    static const double hs[] = {0.5, 0.75, 1, 1.5, 2.25, 0.3125};
    splat_plan *s = malloc(sizeof *s);
    crisp_camera cam = front_camera(4, 64, 64);
    for (int samples = 1; samples <= 4; samples += 3) {
        crisp_gl *gl = make_gl(samples);
        for (size_t k = 0; k < sizeof hs / sizeof *hs; k++) {
            srand(17 + (unsigned)k);
            plan_init(s, &cam, 0, hs[k]);
            fill_exact(s, 600);
            long covered = check_plan(gl, &s->plan, samples, NULL, NULL);
            printf("exact: %d samples, h %g: %ld samples covered\n", samples, hs[k], covered);
            assert_true(covered > 100 * samples);
        }
        crisp_gl_destroy(gl);
    }
    free(s);
}

/* Splats on planes z = zs[f] seen by a real camera: each face's origin a point of its plane,
 * projected in double as the planner does; p in float. */
static void fill_camera(splat_plan *s, int count, const double zs[NF])
{
    crisp_frame_plan *p = &s->plan;
    double O[NF][3];
    for (int f = 0; f < NF; f++) {
        O[f][0] = 0.1 * f - 0.2;
        O[f][1] = 0.05 * f;
        O[f][2] = zs[f];
        const double(*m)[4] = (const double(*)[4])p->view_proj;
        for (int k = 0; k < 4; k++)
            s->origin[4 * f + k] =
                (float)(m[0][k] * O[f][0] + m[1][k] * O[f][1] + m[2][k] * O[f][2] + m[3][k]);
    }
    for (int k = 0; k < count; k++) {
        crisp_plan_splat *sp = &s->splats[k];
        uint32_t f = 1 + (uint32_t)(k * 3 / count);
        double x = (urand() * 2 - 1) * 0.45, y = (urand() * 2 - 1) * 0.35;
        sp->p[0] = (float)(x - O[f][0]);
        sp->p[1] = (float)(y - O[f][1]);
        sp->p[2] = 0;
        s->face[k] = f;
        sp->n = random_normal();
        sp->uv[0] = (float)urand();
        sp->uv[1] = (float)urand();
    }
    p->splat_count = (uint32_t)count;
    make_ranges(s);
}

static void test_camera(void **state)
{
    (void)state;
    splat_plan *s = malloc(sizeof *s);
    crisp_camera cam = front_camera(1, 80, 60); /* the square fills the image */
    int W = cam.width, H = cam.height;
    for (int samples = 1; samples <= 4; samples += 3) {
        crisp_gl *gl = make_gl(samples);
        ref_sample *under = malloc((size_t)W * H * samples * sizeof *under);
        for (int with_leaf = 0; with_leaf <= 1; with_leaf++)
            for (int rep = 0; rep < 3; rep++) {
                srand(5 + rep);
                double h = rep == 0 ? 0.5 : rep == 1 ? 0.9 : 1.7;
                plan_init(s, &cam, with_leaf, h);
                /* faces 1 and 3 in front of the square, face 2 behind it */
                double zs[NF] = {0, 0.02, -0.05, 0.1};
                fill_camera(s, 900, zs);
                const ref_sample *u = NULL;
                float n0[3] = {0, 0, 1};
                if (with_leaf) {
                    /* every sample shows the square (face 0) before the splats: its depth is
                     * the ray's distance along the view axis, 1 */
                    for (size_t k = 0; k < (size_t)W * H * samples; k++)
                        under[k] = (ref_sample){0, -1, 1.0f};
                    u = under;
                }
                long covered = check_plan(gl, &s->plan, samples, u, n0);
                printf("camera: %d samples, h %g, leaf %d: %ld samples covered\n", samples, h,
                       with_leaf, covered);
                assert_true(covered >= (with_leaf ? (long)W * H * samples : 500));
            }
        free(under);
        crisp_gl_destroy(gl);
    }
    free(s);
}

/* The section plane (crisp_gl_set_clip_plane) cuts the squares per sample, as on the CPU: the
 * plane in clip space (through the inverse view-projection, as the backend) at each sample's
 * point of its square (its image position at the splat's clip z and W). */
static void test_clip(void **state)
{
    (void)state;
    splat_plan *s = malloc(sizeof *s);
    crisp_camera cam = front_camera(1, 80, 60);
    const double world[4] = {1, 0.3, 0.2, -0.05};
    for (int samples = 1; samples <= 4; samples += 3) {
        crisp_gl *gl = make_gl(samples);
        crisp_gl_set_clip_plane(gl, world);
        srand(41);
        plan_init(s, &cam, 0, 1.3);
        double zs[NF] = {0, 0.02, -0.05, 0.1};
        fill_camera(s, 900, zs);
        crisp_mat4 m, inv;
        memcpy(m, s->plan.view_proj, sizeof m);
        assert_true(crisp_mat4_inverse(m, inv));
        double cpl[4] = {0, 0, 0, 0};
        for (int c = 0; c < 4; c++)
            for (int k = 0; k < 4; k++)
                cpl[c] += world[k] * inv[c][k];
        plane = cpl;
        long covered = check_plan(gl, &s->plan, samples, NULL, NULL);
        plane = NULL;
        /* about half the splats' samples are cut away */
        crisp_gl_set_clip_plane(gl, NULL);
        long all = check_plan(gl, &s->plan, samples, NULL, NULL);
        printf("clip: %d samples: %ld of %ld samples kept\n", samples, covered, all);
        assert_true(covered > all / 4 && covered < 3 * all / 4);
        crisp_gl_destroy(gl);
    }
    free(s);
}

/* GL's point rasterization alone against the rule (docs/status/issue-12-splats.md "GL draw"). */
static void test_raw(void **state)
{
    (void)state;
    static const double hs[] = {0.5, 0.75, 1, 1.5, 2.25};
    splat_plan *s = malloc(sizeof *s);
    crisp_camera cam = front_camera(4, 64, 64);
    long on_side = 0, near_side = 0, total = 0;
    double worst = 0;
    for (int samples = 1; samples <= 4; samples += 3) {
        crisp_gl *gl = make_gl(samples);
        crisp__gl_splat_raw(gl, 1);
        /* elsewhere the sides' convention and the rounding may differ: only reported */
        int llvmpipe = strstr(crisp_gl_renderer(gl), "llvmpipe") != NULL;
        int W = cam.width, H = cam.height, S = samples;
        size_t n = (size_t)W * H;
        ref_sample *ref = malloc(n * S * sizeof *ref);
        int32_t *faces = malloc(n * S * sizeof *faces);
        for (size_t k = 0; k < sizeof hs / sizeof *hs; k++) {
            srand(99 + (unsigned)k);
            plan_init(s, &cam, 0, hs[k]);
            /* one splat per range, so a sample's splat is its only one */
            fill_exact(s, 1);
            crisp_frame_plan *p = &s->plan;
            for (int rep = 0; rep < 200; rep++) {
                fill_exact(s, 1);
                uint32_t f = 1 + (uint32_t)(rep % 3);
                s->face[0] = f;
                s->splats[0].p[0] *= s->origin[4 * f + 3] / s->origin[4 + 3];
                s->splats[0].p[1] *= s->origin[4 * f + 3] / s->origin[4 + 3];
                make_ranges(s);
                p->splats_version = ++version;
                reference(p, S, NULL, ref);
                assert_int_equal(crisp_gl_draw(gl, p, NULL), CRISP_OK);
                assert_int_equal(crisp__gl_sample_faces(gl, faces), CRISP_OK);
                float c[4];
                double cx, cy, h = hs[k];
                splat_clip(p, f, &s->splats[0], c);
                splat_centre(p, c, &cx, &cy);
                for (size_t q = 0; q < n * S; q++) {
                    total += ref[q].face >= 0;
                    if ((faces[q] >= 0) == (ref[q].face >= 0)) continue;
                    double off[2];
                    crisp__raster_sample_offset(S, (int)(q % S), off);
                    double X = (double)(q / S % W) + off[0], Y = (double)(q / S / W) + off[1];
                    /* how far the sample is from the side(s) GL put elsewhere: covered by
                     * GL only, from each side the rule has it outside of (GL moved them all);
                     * covered by the rule only, from its nearest side */
                    double dx = fmin(fabs(X - (cx - h)), fabs(X - (cx + h))),
                           dy = fmin(fabs(Y - (cy - h)), fabs(Y - (cy + h))), d;
                    if (faces[q] >= 0) {
                        int in_x = cx - h <= X && X < cx + h, in_y = cy - h <= Y && Y < cy + h;
                        d = fmax(in_x ? 0 : dx, in_y ? 0 : dy);
                    } else {
                        d = fmin(dx, dy);
                    }
                    /* llvmpipe (Mesa 22.3, lp_setup_point.c) rounds the point's window position to
                     * 1/256 px; its size 2 h here is a multiple of 1/128 px, so the sides move by
                     * at most 1/512 px */
                    if (llvmpipe && !(d > 0 && d <= 1.0 / 512))
                        fail_msg("h %g centre (%g, %g): GL's point %s sample (%g, %g), %g px "
                                 "from the square's side",
                                 h, cx, cy, faces[q] >= 0 ? "covers" : "misses", X, Y, d);
                    if (d > worst) worst = d;
                    if (d == 0)
                        on_side++;
                    else
                        near_side++;
                }
            }
        }
        free(ref);
        free(faces);
        crisp_gl_destroy(gl);
    }
    printf("GL points without the rule's test: %ld samples covered by the rule; %ld differ on a "
           "square's side, %ld beside one (at most %.4g px from it)\n",
           total, on_side, near_side, worst);
    free(s);
}

static void test_upload(void **state)
{
    (void)state;
    splat_plan *s = malloc(sizeof *s);
    crisp_camera cam = front_camera(4, 64, 64);
    crisp_gl *gl = make_gl(1);
    srand(3);
    plan_init(s, &cam, 0, 1);
    fill_exact(s, 300);
    crisp_frame_plan *p = &s->plan;
    crisp_gl_stats gs;
    assert_int_equal(crisp_gl_draw(gl, p, &gs), CRISP_OK);
    size_t store = p->splat_count * sizeof(crisp_plan_splat), origins = NF * 4 * sizeof(float),
           runs = p->splat_range_count * 2 * sizeof(uint32_t);
    assert_true(gs.bytes_uploaded >= store + origins + runs);
    /* same versions: only the clip origins and the ranges' faces go up (per frame); the store
     * stays as it was, so a store changed without a new version is not seen */
    crisp_plan_splat saved[300];
    memcpy(saved, s->splats, sizeof saved);
    for (uint32_t k = 0; k < p->splat_count; k++)
        s->splats[k].p[0] += 0.75f, s->splats[k].uv[0] = -1;
    assert_int_equal(crisp_gl_draw(gl, p, &gs), CRISP_OK);
    assert_true(gs.bytes_uploaded == origins + runs);
    memcpy(s->splats, saved, sizeof saved);
    check_plan(gl, p, 1, NULL, NULL); /* the old store = saved: the reference holds */
    for (uint32_t k = 0; k < p->splat_count; k++)
        s->splats[k].p[0] += 0.75f, s->splats[k].uv[0] = -1;
    p->splats_version = ++version;
    check_plan(gl, p, 1, NULL, NULL);
    assert_int_equal(crisp_gl_draw(gl, p, &gs), CRISP_OK);
    assert_true(gs.bytes_uploaded == origins + runs);
    /* a range beyond the store, a range of a face the scene has not, a half-size beyond the
     * point size limit or not positive */
    crisp_plan_splat_range r0 = s->ranges[1];
    s->ranges[1].count = p->splat_count - r0.first + 1;
    assert_int_equal(crisp_gl_draw(gl, p, NULL), CRISP_ERR_INVALID_ARG);
    assert_non_null(strstr(crisp_error_message(), "splat range 1"));
    s->ranges[1] = r0;
    s->ranges[1].face = NF;
    assert_int_equal(crisp_gl_draw(gl, p, NULL), CRISP_ERR_INVALID_ARG);
    assert_non_null(strstr(crisp_error_message(), "splat range 1: face"));
    s->ranges[1] = r0;
    p->splats_version = ++version;
    p->splat_half_px = 1e4;
    assert_int_equal(crisp_gl_draw(gl, p, NULL), CRISP_ERR_LIMIT);
    assert_non_null(strstr(crisp_error_message(), "GL_POINT_SIZE_RANGE"));
    p->splat_half_px = 0;
    assert_int_equal(crisp_gl_draw(gl, p, NULL), CRISP_ERR_LIMIT);
    p->splat_half_px = 1;
    check_plan(gl, p, 1, NULL, NULL);
    free(s);
    crisp_gl_destroy(gl);
}

/* A store larger than the storage block limit is bound a chunk at a time (of 28 splats at a
 * 1 kB limit and llvmpipe's 16-byte offset alignment: ranges of up to 40 cross chunks): the same
 * samples as the rule. */
static void test_chunks(void **state)
{
    (void)state;
    splat_plan *s = malloc(sizeof *s);
    crisp_camera cam = front_camera(4, 64, 64);
    for (int samples = 1; samples <= 4; samples += 3) {
        crisp_gl *gl = make_gl_limit(samples, 1024);
        srand(23);
        plan_init(s, &cam, 0, 1.25);
        fill_exact(s, 500);
        assert_true(s->plan.splat_count * sizeof(crisp_plan_splat) > 10 * 1024);
        long covered = check_plan(gl, &s->plan, samples, NULL, NULL);
        assert_true(covered > 500 * samples);
        crisp_gl_destroy(gl);
    }
    free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact), cmocka_unit_test(test_camera), cmocka_unit_test(test_clip),
        cmocka_unit_test(test_raw),   cmocka_unit_test(test_upload), cmocka_unit_test(test_chunks),
    };
    return cmocka_run_group_tests(tests, gl_setup, gl_teardown);
}
