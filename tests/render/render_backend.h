/* One test body, run per backend: render_backend() draws a frame with the CPU backend or, on the
 * same plan (the renderer's planner), with the GL backend on a headless context; the test program
 * picks the backend from its arguments (`--backend gl`, registered with the gl label). Per-sample
 * faces come from rb_sample_faces() in the CPU backend's layout for either. */
#ifndef CRISP_RENDER_BACKEND_H
#define CRISP_RENDER_BACKEND_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/plan.h"
#include "crisp/render.h"
#include "render/raster.h"
#include "render/render_internal.h"
#ifdef CRISP_HAVE_GL
#include "crisp/gl.h"
#include "gl/gl_internal.h"
#endif

typedef enum render_kind { RENDER_CPU, RENDER_GL } render_kind;

/* The backend the program runs its tests on (rb_parse_args). */
static render_kind rb_kind = RENDER_CPU;
static int32_t *rb_faces;
static int rb_last_kind = RENDER_CPU;
static crisp_renderer *rb_last_renderer;

/* Removes `--backend cpu|gl` from argv, sets rb_kind; returns the new argc. */
static inline int rb_parse_args(int argc, char **argv)
{
    int n = 1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--backend") && i + 1 < argc) {
            rb_kind = !strcmp(argv[++i], "gl") ? RENDER_GL : RENDER_CPU;
            continue;
        }
        argv[n++] = argv[i];
    }
    return n;
}

static inline const char *rb_name(void)
{
    return rb_kind == RENDER_GL ? "gl" : "cpu";
}

#ifdef CRISP_HAVE_GL
static size_t rb_faces_cap;
static crisp_gl_context *rb_ctx;
static crisp_gl *rb_gl[17];

static inline crisp_status rb_gl_for(int samples, crisp_gl **dest)
{
    crisp_status st = CRISP_OK;
    if (!rb_ctx && (st = crisp_gl_context_create(&rb_ctx))) return st;
    if (!rb_gl[samples]) {
        if ((st = crisp_gl_create(crisp_gl_context_getproc(rb_ctx),
                                  &(crisp_gl_desc){.samples = samples}, &rb_gl[samples])))
            return st;
        crisp__gl_keep_sample_faces(rb_gl[samples]);
    }
    *dest = rb_gl[samples];
    return CRISP_OK;
}
#endif

/* Render a frame with `kind` (samples must be the renderer's). stats may be NULL; with the GL
 * backend only its plan's fields are filled. */
static inline crisp_status render_backend(render_kind kind, crisp_renderer *r, int samples,
                                          const crisp_scene *sc, const crisp_camera *cam,
                                          crisp_image *img, crisp_render_stats *stats)
{
    rb_last_kind = kind;
    rb_last_renderer = r;
    if (kind == RENDER_CPU) return crisp_render_cpu(r, sc, cam, img, stats);
#ifdef CRISP_HAVE_GL
    crisp_gl *gl;
    crisp_status st = rb_gl_for(samples, &gl);
    const crisp_frame_plan *plan;
    if (!st) st = crisp_planner_plan(crisp_renderer_planner(r), sc, cam, &plan);
    if (!st) st = crisp_gl_render(gl, sc, plan, img, NULL);
    size_t n = (size_t)cam->width * cam->height * samples;
    if (!st && rb_faces_cap < n) {
        free(rb_faces);
        rb_faces = malloc(n * sizeof *rb_faces);
        rb_faces_cap = rb_faces ? n : 0;
        if (!rb_faces) st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    }
    if (!st) st = crisp__gl_sample_faces(gl, rb_faces);
    if (!st && stats) {
        memset(stats, 0, sizeof *stats);
        const crisp_plan_stats *p = &plan->stats;
        stats->patches = p->patches;
        stats->visible_patches = p->visible_patches;
        stats->split_patches = p->split_patches;
        stats->leaves = p->leaves;
        stats->visible_faces = p->visible_faces;
        stats->unresolved = p->unresolved;
        stats->table_rows = p->table_rows;
        stats->table_bytes = p->table_bytes;
        stats->triangles = p->triangles;
    }
    return st;
#else
    (void)samples, (void)sc, (void)cam, (void)img, (void)stats;
    return crisp_error(CRISP_ERR_UNSUPPORTED, "built without the GL backend");
#endif
}

/* Every sample's face (-1: nothing) of the last render_backend frame: sample s of pixel (i, j)
 * at (j * width + i) * samples + s. */
static inline const int32_t *rb_sample_faces(void)
{
    if (rb_last_kind == RENDER_CPU) return crisp__renderer_target(rb_last_renderer)->face;
    return rb_faces;
}

#endif
