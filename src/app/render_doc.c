/* crisp_document_render: one frame of a document with the CPU backend (plan, tessellation,
 * rasterizer with the u-intercept trim test) or the exact reference (ray casting, exact trim
 * classifier), then its f-rep parts composited by depth. */
#include <math.h>
#include <string.h>

#include "crisp/app.h"
#include "crisp/plan.h"
#include "crisp/trim.h"
#include "render/render_internal.h"
#ifdef CRISP_HAVE_GL
#include "crisp/gl.h"
#endif

/* The exact backend's trim decision: the face's true trim curves. */
static int classify_exact(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)ctx;
    const crisp_scene_face *f = &sc->faces[face];
    if (f->piece_count == 0) return 1;
    return crisp_trim_exact_classify(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
}

/* One frame, or the window win of it (NULL: the whole frame; else aligned as the backends need:
 * x0, y0 multiples of 32) into img of the window's size. */
static crisp_status render_window(const crisp_document *doc, const crisp_camera *cam,
                                  crisp_document_render_desc d, const int *win, crisp_image *img,
                                  crisp_render_stats *stats);

/* The window drawn for a requested one (issue 15, image tiles): what a pixel of the window reads
 * from its neighbours must be drawn too. The CPU backend's ribbons read the 4 neighbouring
 * pixels' depth (crisp__raster_depth_slack), the f-rep parts z-cull whole 32x32 tiles of the
 * image against the depth they hold: so the window grows to the 32-pixel grid around it plus one
 * more 32-pixel ring (clamped to the image, whose own edges are the same as in the whole image).
 * tests/jobs/test_tiles.c fails without the ring. */
static void drawn_window(const crisp_camera *cam, const int win[4], int dest[4])
{
    enum { G = 32 };
    int x0 = win[0] / G * G - G, y0 = win[1] / G * G - G;
    int x1 = (win[0] + win[2] + G - 1) / G * G + G, y1 = (win[1] + win[3] + G - 1) / G * G + G;
    x0 = x0 < 0 ? 0 : x0, y0 = y0 < 0 ? 0 : y0;
    x1 = x1 > cam->width ? cam->width : x1, y1 = y1 > cam->height ? cam->height : y1;
    dest[0] = x0, dest[1] = y0, dest[2] = x1 - x0, dest[3] = y1 - y0;
}

crisp_status crisp_document_render(const crisp_document *doc, const crisp_camera *cam,
                                   const crisp_document_render_desc *desc, crisp_image *img,
                                   crisp_render_stats *stats)
{
    crisp_document_render_desc d = desc ? *desc : (crisp_document_render_desc){0};
    if (stats) memset(stats, 0, sizeof *stats);
    if (!doc || !cam || !img)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_document_render: NULL argument");
    const int *w = d.window;
    int windowed = w[0] || w[1] || w[2] || w[3];
    if (!windowed && (img->width != cam->width || img->height != cam->height))
        return crisp_error(CRISP_ERR_INVALID_ARG, "image %dx%d does not match the camera's %dx%d",
                           img->width, img->height, cam->width, cam->height);
    if (!windowed) return render_window(doc, cam, d, NULL, img, stats);
    if (w[0] < 0 || w[1] < 0 || w[2] < 1 || w[3] < 1 || w[0] > cam->width - w[2] ||
        w[1] > cam->height - w[3])
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "window %dx%d at (%d, %d) is not inside the %dx%d image", w[2], w[3],
                           w[0], w[1], cam->width, cam->height);
    if (img->width != w[2] || img->height != w[3])
        return crisp_error(CRISP_ERR_INVALID_ARG, "image %dx%d does not match the window's %dx%d",
                           img->width, img->height, w[2], w[3]);
    if (d.backend != CRISP_BACKEND_CPU && d.backend != CRISP_BACKEND_EXACT)
        return crisp_error(CRISP_ERR_UNSUPPORTED,
                           "an image window (a tile) is drawn by the cpu and exact backends only "
                           "(the gl backend's float rounding changes with the window's "
                           "projection)");
    int e[4];
    drawn_window(cam, w, e);
    if (!memcmp(e, w, sizeof e)) return render_window(doc, cam, d, e, img, stats);
    crisp_image big = {0};
    crisp_status st = crisp_image_init(&big, e[2], e[3]);
    if (!st) st = render_window(doc, cam, d, e, &big, stats);
    if (!st) {
        /* crop: the requested window's rows out of the drawn one */
        int ox = w[0] - e[0], oy = w[1] - e[1];
        for (int j = 0; j < w[3]; j++) {
            size_t s = (size_t)(j + oy) * (size_t)e[2] + (size_t)ox, t = (size_t)j * (size_t)w[2];
            size_t n = (size_t)w[2];
            memcpy(img->rgba + 4 * t, big.rgba + 4 * s, 4 * n * sizeof *img->rgba);
            memcpy(img->depth + t, big.depth + s, n * sizeof *img->depth);
            memcpy(img->normal + 3 * t, big.normal + 3 * s, 3 * n * sizeof *img->normal);
            memcpy(img->uv + 2 * t, big.uv + 2 * s, 2 * n * sizeof *img->uv);
            memcpy(img->face + t, big.face + s, n * sizeof *img->face);
        }
    }
    crisp_image_free(&big);
    return st;
}

static crisp_status render_window(const crisp_document *doc, const crisp_camera *cam,
                                  crisp_document_render_desc d, const int *win, crisp_image *img,
                                  crisp_render_stats *stats)
{
    if (d.samples == 0) d.samples = 1;
    crisp_status st = crisp_camera_check(cam);
    if (st) return st;
    if (d.backend == CRISP_BACKEND_CPU || d.backend == CRISP_BACKEND_GL) {
        if (d.samples != 1 && d.samples != 4 && d.samples != 16)
            return crisp_error(CRISP_ERR_INVALID_ARG, "%d samples per pixel: expected 1, 4 or 16",
                               d.samples);
    } else if (d.backend == CRISP_BACKEND_EXACT) {
        if (d.samples != 1)
            return crisp_error(
                CRISP_ERR_INVALID_ARG,
                "the exact backend casts one ray per pixel centre; %d samples need the cpu "
                "backend",
                d.samples);
    } else {
        return crisp_error(CRISP_ERR_INVALID_ARG, "backend %d: expected cpu, exact or gl",
                           (int)d.backend);
    }
    crisp__image_clear(img);
    double t0 = crisp_time_now();
    if (doc->scene && doc->scene->patch_count > 0) {
        if (d.backend == CRISP_BACKEND_CPU) {
            crisp_renderer *r = d.renderer;
            if (!r)
                st = crisp_renderer_create(
                    /* a renderer for this frame only: no splat sets (they pay off over frames) */
                    &(crisp_render_desc){
                        .samples = d.samples, .threads = d.threads, .no_splats = 1},
                    &r);
            if (!st && !win) st = crisp_render_cpu(r, doc->scene, cam, img, stats);
            const crisp_frame_plan *plan = NULL;
            if (!st && win)
                st = crisp_planner_plan(crisp_renderer_planner(r), doc->scene, cam, &plan);
            if (!st && win)
                st = crisp__render_cpu_window(r, doc->scene, plan, cam, win, img, stats);
            if (!d.renderer) crisp_renderer_destroy(r);
        } else if (d.backend == CRISP_BACKEND_GL) {
#ifdef CRISP_HAVE_GL
            /* the GL helper's one-frame path (a headless context, a planner and the backend) */
            crisp_gl_stats gs = {0};
            char name[256] = "";
            st = crisp_gl_render_once(doc->scene, cam, d.samples, img, &gs, name, sizeof name);
#else
            st = crisp_error(CRISP_ERR_UNSUPPORTED,
                             "the GL backend is not built into this crisp (CRISP_GL=OFF)");
#endif
        } else {
            crisp_exact_desc ed = {.threads = d.threads, .classify = classify_exact};
            if (win) memcpy(ed.window, win, sizeof ed.window);
            st = crisp_render_exact(doc->scene, cam, &ed, img);
        }
    }
    double t1 = crisp_time_now();
    if (!st && doc->part_count)
        st = crisp_render_frep_parts(
            doc->parts, doc->part_count, cam,
            &(crisp_frep_parts_desc){
                .threads = d.threads,
                .per_pixel = d.backend == CRISP_BACKEND_EXACT,
                .window = {win ? win[0] : 0, win ? win[1] : 0, win ? win[2] : 0, win ? win[3] : 0}},
            img);
    if (d.times) {
        d.times->ms_faces = 1e3 * (t1 - t0);
        d.times->ms_parts = 1e3 * (crisp_time_now() - t1);
    }
    return st;
}

/* Peak bytes: 32 per sample (the raster target) and 56 per pixel (the float image with its AOVs,
 * the 8-bit output), fitted to the peak RSS of `crisp render` on the teapot (2048x2048 with 1
 * sample: 358 MB, with 4: 751 MB; 1280x720 with 16: 523 MB; 4096x4096 with 1: 1.36 GB; the
 * formula gives 369, 772, 524 and 1476 MB). A large model adds its own size on top. */
uint64_t crisp_render_memory_estimate(int width, int height, int samples)
{
    if (width <= 0 || height <= 0) return 0;
    if (samples < 1) samples = 1;
    uint64_t px = (uint64_t)width * (uint64_t)height;
    return px * (uint64_t)samples * 32u + px * 56u;
}
