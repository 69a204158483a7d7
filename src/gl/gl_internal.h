/* Internals of the GL backend shared with its tests (tests/gl). */
#ifndef CRISP_GL_INTERNAL_H
#define CRISP_GL_INTERNAL_H

#include "crisp/gl.h"

/* A query of the layout probe (std430: 48 bytes): the trim test at (u, v) of `face`, and the
 * (u, v) and levels of leaf `leaf` at its local (s, t). */
typedef struct crisp__gl_query {
    double u, v, s, t;
    uint32_t face, leaf, pad[2];
} crisp__gl_query;

typedef struct crisp__gl_result {
    double u, v;
    uint32_t inside, tau, patch, depth;
    uint32_t edge[4];
    double point[3]; /* the leaf's patch at (s, t) */
} crisp__gl_result;

/* Uploads the plan like crisp_gl_draw and runs shaders/layout_cs.glsl on the queries. */
crisp_status crisp__gl_layout_probe(crisp_gl *gl, const crisp_frame_plan *plan,
                                    const crisp__gl_query *q, size_t n, crisp__gl_result *out);

/* The scene last uploaded by crisp_gl_set_scene (NULL after crisp_gl_set_scene_data). */
void crisp__gl_scene_is(crisp_gl *gl, const crisp_scene *scene);
const crisp_scene *crisp__gl_scene(const crisp_gl *gl);

/* Tests: keep every sample's face from now on; after a draw, read them in the CPU backend's
 * layout (sample s of pixel (i, j) at (j * width + i) * samples + s). */
void crisp__gl_keep_sample_faces(crisp_gl *gl);
crisp_status crisp__gl_sample_faces(crisp_gl *gl, int32_t *dest);

/* Tests: crisp_gl_blit into an RGBA8 texture of the frame's size, read back in GL's row order
 * (row 0 = the bottom: the image's last row). */
crisp_status crisp__gl_blit_probe(crisp_gl *gl, uint8_t *rgba);

/* Tests: 1 draws splats as GL's points of size 2 h alone (no margin, no exact coverage test in
 * splat_fs.glsl), to measure how the GL implementation's point rasterization differs from the
 * plan's rule; 0 (the default) draws them by the rule. */
void crisp__gl_splat_raw(crisp_gl *gl, int raw);

enum { CRISP__GL_VERTEX, CRISP__GL_FRAGMENT, CRISP__GL_COMPUTE };
/* Compiles and links one shader of the given stage (after the #version line and common.glsl)
 * and deletes the program: the compile and link error path, for tests. */
crisp_status crisp__gl_try_program(const char *name, int stage, const char *src);

#endif
