/* crisp_document_render: one frame of a document with the CPU backend (plan, tessellation,
 * rasterizer with the u-intercept trim test) or the exact reference (ray casting, exact trim
 * classifier), then its f-rep parts composited by depth. */
#include <math.h>
#include <string.h>

#include "crisp/app.h"
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

crisp_status crisp_document_render(const crisp_document *doc, const crisp_camera *cam,
                                   const crisp_document_render_desc *desc, crisp_image *img,
                                   crisp_render_stats *stats)
{
    crisp_document_render_desc d = desc ? *desc : (crisp_document_render_desc){0};
    if (stats) memset(stats, 0, sizeof *stats);
    if (!doc || !cam || !img)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_document_render: NULL argument");
    if (img->width != cam->width || img->height != cam->height)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image %dx%d does not match the camera's %dx%d",
                           img->width, img->height, cam->width, cam->height);
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
                    &(crisp_render_desc){.samples = d.samples, .threads = d.threads}, &r);
            if (!st) st = crisp_render_cpu(r, doc->scene, cam, img, stats);
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
            st = crisp_render_exact(doc->scene, cam, &ed, img);
        }
    }
    double t1 = crisp_time_now();
    if (!st && doc->part_count)
        st = crisp_render_frep_parts(
            doc->parts, doc->part_count, cam,
            &(crisp_frep_parts_desc){.threads = d.threads,
                                     .per_pixel = d.backend == CRISP_BACKEND_EXACT},
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
