/* The GL tests' one headless context (EGL, surfaceless): made before a program's tests by
 * gl_setup, destroyed after them by gl_teardown (cmocka group fixtures). */
#ifndef CRISP_TESTS_GL_TEST_UTIL_H
#define CRISP_TESTS_GL_TEST_UTIL_H

#include <stdio.h>

#include "crisp/core.h"
#include "crisp/gl.h"

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

#endif
