/* crisp gl: the OpenGL 4.5 core backend that draws a frame plan (include/crisp/plan.h), and a
 * headless context to run it without a window.
 *
 * Offers:
 *   crisp_gl_context       a headless GL 4.5 core context: EGL on the surfaceless platform
 *                          (EGL_MESA_platform_surfaceless), the device platform
 *                          (EGL_EXT_platform_device) as a fallback; no X server needed
 *   crisp_gl               the backend, on whatever GL 4.5 context is current when it is created
 *                          (the headless one, or a GLFW window's: pass glfwGetProcAddress)
 *   crisp_gl_set_scene     upload the prepared scene (control points, patch records, face
 *                          colours) into storage buffers, once per scene
 *   crisp_gl_draw          upload the plan arrays whose version changed, draw the frame
 *   crisp_gl_read          read the frame back into a crisp_image (the CPU backend's conventions)
 *   crisp_gl_blit          copy the frame's colour into a framebuffer of the app (no read-back)
 *   crisp_gl_render        set_scene + draw + read in one call
 *   crisp_gl_render_once   a headless context, a planner and the backend for one frame
 *
 * How a frame is drawn (docs/status/issue-09.md): one GL patch of one vertex per plan leaf, the
 * leaf fetched by gl_PrimitiveID; the tessellation control shader sets the plan's levels (never
 * clamped: the plan keeps them <= 64); the evaluation shader evaluates the rational Bézier patch
 * from the control-point buffer in double and hands local (s, t) of the leaf to the fragment
 * shader in float; the fragment shader forms (u, v) in double and runs the plan's trim test
 * (crisp_plan_trim_test) in double. The trim ribbons are drawn after the surfaces as by the CPU
 * backend (a fill pass that replaces a sample only when nearer by more than the depth slack).
 * Samples (1, 4, 16) are drawn as one pass per sample at the CPU backend's sample positions
 * (crisp__raster_sample_offset), so every sample is tested exactly as the CPU backend tests it,
 * on any GL implementation; the passes are resolved as the CPU backend resolves them. Faces the
 * plan draws as splats (CRISP_PLAN_FACE_SPLATS) are GL points fetched from the plan's splat store
 * (uploaded when splats_version changes), one glMultiDrawArrays over the frame's splat ranges
 * per pass, each point's samples kept by the plan's coverage rule exactly. f-rep
 * parts are not drawn by this backend: composite them into the read-back image with
 * crisp_render_frep_parts (the CPU path), as `crisp render --backend gl` does.
 */
#ifndef CRISP_GL_H
#define CRISP_GL_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/core.h"
#include "crisp/plan.h"
#include "crisp/render.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A GL function loader (eglGetProcAddress, glfwGetProcAddress, ...). */
typedef void (*crisp_gl_proc)(void);
typedef crisp_gl_proc (*crisp_gl_getproc_fn)(const char *name);

/* ---- headless context ------------------------------------------------------------------------ */

typedef struct crisp_gl_context crisp_gl_context;

/* Creates a GL 4.5 core context without a surface and makes it current on this thread. Fails
 * with CRISP_ERR_GL and a message naming what is missing (no EGL display, no GL 4.5 core
 * context, no surfaceless contexts). */
crisp_status crisp_gl_context_create(crisp_gl_context **dest);
void crisp_gl_context_destroy(crisp_gl_context *ctx);
crisp_status crisp_gl_context_make_current(crisp_gl_context *ctx);
crisp_gl_getproc_fn crisp_gl_context_getproc(const crisp_gl_context *ctx);
/* "EGL surfaceless" or "EGL device". */
const char *crisp_gl_context_platform(const crisp_gl_context *ctx);

/* ---- backend --------------------------------------------------------------------------------- */

typedef struct crisp_gl_desc {
    int samples;             /* per pixel: 1 (default), 4 or 16 */
    size_t max_buffer_bytes; /* largest storage buffer; 0: GL_MAX_SHADER_STORAGE_BLOCK_SIZE (a
                                smaller value tests the limit's error path) */
    int profile;             /* 1: finish the GL work after each stage to time it (slower) */
    double clip_plane[4];    /* a, b, c, d: what lies where a x + b y + c z + d < 0 (world
                                space) is not drawn (as crisp_render_desc.clip_plane); all 0:
                                none */
} crisp_gl_desc;

typedef struct crisp_gl_stats {
    uint64_t bytes_uploaded; /* plan bytes uploaded by the last crisp_gl_draw */
    uint64_t scene_bytes;    /* bytes of the scene's buffers */
    uint32_t leaves, ribbon_quads, passes;
    uint64_t splats;           /* splats drawn (per sample pass) */
    double ms_upload, ms_draw; /* wall time of the upload and of the draw calls until glFinish */
    double ms_read;
    double ms_surfaces, ms_ribbons, ms_resolve; /* with crisp_gl_desc.profile: the stages, summed
                                                   over the sample passes */
    double ms_splats;                           /* the same for the splat draw */
} crisp_gl_stats;

typedef struct crisp_gl crisp_gl;

/* The scene's arrays as they go to the GPU (crisp_gl_set_scene fills this from a crisp_scene). */
typedef struct crisp_gl_scene_data {
    const double *control_points; /* 4 per point: w x, w y, w z, w */
    size_t control_point_count;
    const crisp_scene_patch_record *patch_records;
    uint32_t patch_count;
    const float *face_colors; /* 4 per face (rgba) */
    uint32_t face_count;
} crisp_gl_scene_data;

/* Loads GL through getproc (the context must be current and stay current for every call) and
 * compiles the shaders. Fails with CRISP_ERR_GL on a context below 4.5, missing limits (storage
 * buffers in the tessellation stages) or a shader that does not compile or link (the message
 * holds the compiler's log). */
crisp_status crisp_gl_create(crisp_gl_getproc_fn getproc, const crisp_gl_desc *desc,
                             crisp_gl **dest);
void crisp_gl_destroy(crisp_gl *gl);
crisp_status crisp_gl_set_scene(crisp_gl *gl, const crisp_scene *scene);
crisp_status crisp_gl_set_scene_data(crisp_gl *gl, const crisp_gl_scene_data *data);
/* GL state: crisp_gl_draw, crisp_gl_read and crisp_gl_blit leave the context with framebuffer 0,
 * program 0, clip control (lower left, -1..1), depth test off, GL_LESS; they change the viewport,
 * the vertex array binding, texture units 0-3, image units 0-4, storage buffer bindings 0-12 and
 * the pack alignment (1). An app that shares the context sets what it needs after them. */
/* Draws the plan (of the scene last set) into the backend's targets. Uploads only the arrays
 * whose *_version differs from the last plan drawn (everything when the plan pointer changed,
 * after crisp_gl_set_scene and after crisp_gl_forget_plan: call that when a new planner may
 * return a plan at a freed planner's address).
 * A plan array larger than the buffer limit: CRISP_ERR_LIMIT naming the array. stats may be
 * NULL. */
crisp_status crisp_gl_draw(crisp_gl *gl, const crisp_frame_plan *plan, crisp_gl_stats *stats);
void crisp_gl_forget_plan(crisp_gl *gl);
/* Reads the last frame into img (its size must be the plan's): rgba straight alpha = coverage,
 * depth = camera-space depth (+inf background), world normal, u, v, face id (-1 background). */
crisp_status crisp_gl_read(crisp_gl *gl, crisp_image *img, crisp_gl_stats *stats);
/* Change the clip plane (crisp_gl_desc.clip_plane; NULL or all 0: none) for the next draws. */
void crisp_gl_set_clip_plane(crisp_gl *gl, const double plane[4]);
/* Copies the last frame's colour (straight alpha) into framebuffer `fbo` (0: the default one)
 * at (x, y, width, height) in its window coordinates, the image's top row at the top. */
crisp_status crisp_gl_blit(crisp_gl *gl, unsigned fbo, int x, int y, int width, int height);
/* The last frame's colour texture (GL_RGBA32F, row 0 = the image's top row). */
unsigned crisp_gl_color_texture(const crisp_gl *gl);
/* crisp_gl_set_scene, crisp_gl_draw, crisp_gl_read: uploads everything (for single frames; an
 * interactive app sets the scene once and calls crisp_gl_draw per frame). */
crisp_status crisp_gl_render(crisp_gl *gl, const crisp_scene *scene, const crisp_frame_plan *plan,
                             crisp_image *img, crisp_gl_stats *stats);
/* One frame without a window: a headless context, the backend, a planner (default tolerance),
 * draw and read back, everything destroyed again (what `crisp render --backend gl` does). img
 * must have the camera's size. renderer (may be NULL) receives crisp_gl_renderer's text. */
crisp_status crisp_gl_render_once(const crisp_scene *scene, const crisp_camera *cam, int samples,
                                  crisp_image *img, crisp_gl_stats *stats, char *renderer,
                                  size_t renderer_size);
/* GL_RENDERER and GL_VERSION of the context the backend runs on. */
const char *crisp_gl_renderer(const crisp_gl *gl);

#ifdef __cplusplus
}
#endif
#endif
