/* The GL tests' one headless context (EGL, surfaceless): made before a program's tests by
 * gl_setup, destroyed after them by gl_teardown (cmocka group fixtures); and the camera part of a
 * hand-made frame plan. */
#ifndef CRISP_TESTS_GL_TEST_UTIL_H
#define CRISP_TESTS_GL_TEST_UTIL_H

#include <stdio.h>

#include <string.h>

#include "crisp/core.h"
#include "crisp/gl.h"
#include "crisp/plan.h"
#include "crisp/render.h"

static crisp_gl_context *ctx;

static int gl_setup(void **state)
{
    (void)state;
    if (crisp_gl_context_create(&ctx)) {
        fprintf(stderr, "no headless GL context: %s\n", crisp_error_message());
        return -1;
    }
    return 0;
}

static int gl_teardown(void **state)
{
    (void)state;
    crisp_gl_context_destroy(ctx);
    return 0;
}

/* A hand-made plan's view of cam: view-projection (double and float), eye, image size, and the
 * 0.5 px tolerance the planner plans for. */
static inline void gl_plan_camera(crisp_frame_plan *p, const crisp_camera *cam)
{
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    memcpy(p->view_proj, m.view_proj, sizeof p->view_proj);
    for (int k = 0; k < 16; k++)
        p->view_proj_f[k] = (float)m.view_proj[k / 4][k % 4];
    memcpy(p->eye, cam->eye, sizeof p->eye);
    p->width = cam->width;
    p->height = cam->height;
    p->eps_px = 0.5;
}

#endif
