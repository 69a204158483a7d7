/* The `crisp render` command: renders a bundled model with the exact backend to a PNG of the
 * requested size, writes the EXR AOVs, and fails with a message naming the problem on bad input. */
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

static void test_render_teapot(void **state)
{
    (void)state;
    char out[8192], args[1024];
    remove("cli_teapot.png");
    remove("cli_teapot.exr");
    snprintf(args, sizeof args,
             "render %s/nurbs/gpucast_teapot.igs --backend exact --size 64x40 -o cli_teapot.png "
             "--aov cli_teapot.exr --stats",
             CRISP_DATA_DIR);
    assert_int_equal(cli_run_merged("", args, out, sizeof out), 0);
    assert_non_null(strstr(out, "patches          32"));
    int w, h;
    cli_png_size("cli_teapot.png", &w, &h);
    assert_int_equal(w, 64);
    assert_int_equal(h, 40);
    FILE *f = fopen("cli_teapot.exr", "rb");
    assert_non_null(f);
    unsigned char magic[4];
    assert_int_equal(fread(magic, 1, 4, f), 4);
    fclose(f);
    assert_int_equal(magic[0], 0x76); /* OpenEXR magic 20000630 */
    assert_int_equal(magic[1], 0x2f);
}

static void test_render_errors(void **state)
{
    (void)state;
    char out[8192];
    assert_int_not_equal(
        cli_run_merged("", "render /nonexistent/model.igs --backend exact", out, sizeof out), 0);
    assert_non_null(strstr(out, "/nonexistent/model.igs"));
    assert_int_not_equal(cli_run_merged("", "render x.igs --size 10by10", out, sizeof out), 0);
    assert_non_null(strstr(out, "--size"));
    assert_int_not_equal(cli_run_merged("", "render x.igs --eye 1,2", out, sizeof out), 0);
    assert_non_null(strstr(out, "--eye"));
    assert_int_not_equal(cli_run_merged("", "render x.igs --backend gpu", out, sizeof out), 0);
    assert_non_null(strstr(out, "expected cpu, exact or gl"));
}

/* Bad camera values are named in the message; looking straight down without --up picks a
 * defined up vector, while an explicit up parallel to the view is an error. */
static void test_camera_values(void **state)
{
    (void)state;
    char out[8192], args[1024];
    static const struct {
        const char *opts, *expect;
    } bad[] = {
        {"--size 0x10", "--size"},
        {"--size 10x-3", "--size"},
        {"--size 20000x10", "--size"},
        {"--size 64x", "--size"},
        {"--fov 0", "fov 0"},
        {"--fov 180", "fov 180"},
        {"--fov -3", "fov -3"},
        {"--fov nan", "--fov"},
        {"--fov 1e400", "--fov"},
        {"--near 0", "near 0"},
        {"--near -1", "near -1"},
        {"--near 5 --far 2", "near 5"},
        {"--near abc", "--near"},
        {"--far inf", "--far"},
        {"--samples 3", "--samples"},
        {"--threads 0", "--threads"},
        {"--eye 1,2,nan", "--eye"},
        {"--size 16384x16384", "--max-memory"},
        {"--size 4096x4096 --samples 16", "--max-memory"},
        {"--eye 0,5,0 --target 0,0,0 --up 0,2,0", "parallel"},
        {"--eye 1,1,1 --target 1,1,1", "equals target"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        snprintf(args, sizeof args,
                 "render %s/nurbs/gpucast_teapot.igs --size 16x12 -o cli_bad.png %s",
                 CRISP_DATA_DIR, bad[k].opts);
        int rc = cli_run_merged("", args, out, sizeof out);
        if (rc == 0 || !strstr(out, bad[k].expect))
            fprintf(stderr, "'%s': exit %d, message '%s' (expected '%s')\n", bad[k].opts, rc, out,
                    bad[k].expect);
        assert_int_not_equal(rc, 0);
        assert_non_null(strstr(out, bad[k].expect));
    }
    /* Straight down onto the model's centre with the default up: an image, not an error. */
    remove("cli_down.png");
    snprintf(args, sizeof args,
             "render %s/nurbs/gpucast_teapot.igs --size 32x24 -o cli_down.png --eye 0,40,0 --stats",
             CRISP_DATA_DIR);
    int rc = cli_run_merged("", args, out, sizeof out);
    if (rc) fprintf(stderr, "%s\n", out);
    assert_int_equal(rc, 0);
    int w, h;
    cli_png_size("cli_down.png", &w, &h);
    assert_int_equal(w, 32);
    assert_int_equal(h, 24);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_teapot),
        cmocka_unit_test(test_render_errors),
        cmocka_unit_test(test_camera_values),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
