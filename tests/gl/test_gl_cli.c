/* `crisp render --backend gl`: the same files as --backend cpu (PNG of the requested size, EXR
 * AOVs), and without a usable GL (glvnd finds no EGL vendor) a clear message, a non-zero exit and
 * no image; --backend cpu keeps working there. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "cli/cli_run.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

static void test_render_gl(void **state)
{
    (void)state;
    char out[8192], args[1024];
    for (int s = 1; s <= 4; s += 3) {
        remove("cli_gl.png");
        remove("cli_gl.exr");
        snprintf(args, sizeof args,
                 "render %s/nurbs/gpucast_teapot.igs --backend gl --samples %d --size 64x40 -o "
                 "cli_gl.png "
                 "--aov cli_gl.exr --stats",
                 CRISP_DATA_DIR, s);
        int rc = cli_run_merged("", args, out, sizeof out);
        if (rc) fail_msg("%s", out);
        assert_non_null(strstr(out, "backend          gl"));
        int w, h;
        cli_png_size("cli_gl.png", &w, &h);
        assert_int_equal(w, 64);
        assert_int_equal(h, 40);
        FILE *f = fopen("cli_gl.exr", "rb");
        assert_non_null(f);
        unsigned char magic[4];
        assert_int_equal(fread(magic, 1, 4, f), 4);
        fclose(f);
        assert_int_equal(magic[0], 0x76);
        /* the same pixel count as the CPU backend */
        const char *cov = strstr(out, "pixels covered");
        assert_non_null(cov);
        char gl_cov[64];
        snprintf(gl_cov, sizeof gl_cov, "%.40s", cov);
        snprintf(
            args, sizeof args,
            "render %s/nurbs/gpucast_teapot.igs --samples %d --size 64x40 -o cli_cpu.png --stats",
            CRISP_DATA_DIR, s);
        assert_int_equal(cli_run_merged("", args, out, sizeof out), 0);
        assert_non_null(strstr(out, gl_cov));
    }
}

static void test_no_gl(void **state)
{
    (void)state;
    char out[8192], args[1024];
    const char *env = "__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent/egl_vendor.json";
    remove("cli_nogl.png");
    snprintf(args, sizeof args,
             "render %s/nurbs/gpucast_teapot.igs --backend gl --size 32x20 -o cli_nogl.png",
             CRISP_DATA_DIR);
    int rc = cli_run_merged(env, args, out, sizeof out);
    assert_true(rc != 0);
    assert_non_null(strstr(out, "no usable OpenGL"));
    assert_null(fopen("cli_nogl.png", "rb"));
    /* the CPU backend does not need GL */
    snprintf(args, sizeof args,
             "render %s/nurbs/gpucast_teapot.igs --backend cpu --size 32x20 -o cli_nogl.png",
             CRISP_DATA_DIR);
    assert_int_equal(cli_run_merged(env, args, out, sizeof out), 0);
    int w, h;
    cli_png_size("cli_nogl.png", &w, &h);
    assert_int_equal(w, 32);
    /* a sample count the backend does not draw */
    snprintf(args, sizeof args,
             "render %s/nurbs/gpucast_teapot.igs --backend gl --samples 3 --size 32x20 -o x.png",
             CRISP_DATA_DIR);
    assert_true(cli_run_merged("", args, out, sizeof out) != 0);
    assert_non_null(strstr(out, "samples"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_render_gl),
                                       cmocka_unit_test(test_no_gl)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
