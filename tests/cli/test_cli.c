/* The crisp command line as a user meets it: --help and --version everywhere, every option of
 * `crisp render` listed with its default, numbers validated and named in messages, outputs and
 * memory checked before any work (a refused run leaves no file), the "wrote" line and --quiet,
 * --repeat with --stats, the progress bar switches. Runs the built binary in a scratch folder. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "cli/cli_run.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "crisp/version.h"

#define TEAPOT CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs"

static void test_version_and_help(void **state)
{
    (void)state;
    int rc = cli_run("--version");
    EXPECT(rc, 0, cli_out, "crisp " CRISP_VERSION_STRING "\n");
    rc = cli_run("version");
    EXPECT(rc, 0, cli_out, "crisp " CRISP_VERSION_STRING);
    rc = cli_run("--help");
    EXPECT(rc, 0, cli_out, "render");
    assert_non_null(strstr(cli_out, "--version"));
    rc = cli_run("");
    EXPECT(rc, 2, cli_err, "usage");
    rc = cli_run("--bogus");
    EXPECT(rc, 2, cli_err, "unknown option '--bogus'");
    rc = cli_run("nosuchcommand");
    EXPECT(rc, 2, cli_err, "unknown command 'nosuchcommand'");
    static const char *const subs[] = {"render --help", "render -h", "info --help",
                                       "version --help", "render " TEAPOT " --help"};
    for (size_t i = 0; i < sizeof subs / sizeof subs[0]; i++) {
        rc = cli_run("%s", subs[i]);
        EXPECT(rc, 0, cli_out, "usage: crisp");
        assert_string_equal(cli_err, "");
    }
}

/* Every option of crisp render is in its --help, each with a default in brackets. */
static void test_render_help_lists_options(void **state)
{
    (void)state;
    assert_int_equal(cli_run("render --help"), 0);
    static const char *const opts[] = {
        "-o, --output",  "--aov",       "--size",    "--view",  "--fit",        "--eye",
        "--target",      "--up",        "--fov",     "--near",  "--far",        "--samples",
        "--backend",     "--threads",   "--repeat",  "--stats", "--max-memory", "--progress",
        "--no-progress", "-q, --quiet", "-h, --help"};
    for (size_t i = 0; i < sizeof opts / sizeof opts[0]; i++) {
        const char *at = strstr(cli_out, opts[i]);
        if (!at) fprintf(stderr, "'%s' missing from:\n%s", opts[i], cli_out);
        assert_non_null(at);
        /* a default in brackets on the option's line or its continuation (not for the switches
         * that only print or stop something) */
        if (!strcmp(opts[i], "-h, --help") || !strcmp(opts[i], "--no-progress") ||
            !strcmp(opts[i], "-q, --quiet"))
            continue;
        const char *next = strstr(at + 1, "\n  -");
        const char *bracket = strchr(at, '[');
        if (!bracket || (next && bracket > next)) fprintf(stderr, "no [default] for %s\n", opts[i]);
        assert_non_null(bracket);
        assert_true(!next || bracket < next);
    }
    assert_int_equal(cli_run("info --help"), 0);
    assert_non_null(strstr(cli_out, "--json"));
}

/* Numbers are validated (no atoi) and the message names the option and the value. */
static void test_numbers_validated(void **state)
{
    (void)state;
    static const struct {
        const char *opts, *expect;
    } bad[] = {
        {"--threads abc", "--threads abc: expected an integer"},
        {"--threads 0", "--threads 0: expected an integer in 1..1024"},
        {"--threads 12x", "--threads 12x"},
        {"--repeat abc", "--repeat abc"},
        {"--repeat 0", "--repeat 0"},
        {"--samples 3", "--samples 3: expected 1, 4 or 16"},
        {"--samples -5", "--samples -5"},
        {"--size 10by10", "--size 10by10: expected WxH"},
        {"--size 64x", "--size 64x"},
        {"--fov abc", "--fov abc"},
        {"--fov 0", "--fov 0"},
        {"--near -1", "--near -1"},
        {"--far nan", "--far nan"},
        {"--eye 1,2", "--eye 1,2: 2 numbers given, expected 3"},
        {"--eye 1,x,3", "number 2 ('x')"},
        {"--eye 1,2,3,4", "more than 3 numbers"},
        {"--up ,,", "number 1 ('')"},
        {"--max-memory lots", "--max-memory lots"},
        {"--max-memory 10", "at least 1M"},
        {"--view diagonal", "--view diagonal: expected front, back"},
        {"--backend gpu", "--backend gpu: expected cpu, exact or gl"},
        {"--backend exact --samples 4", "needs the cpu backend"},
        {"--view top --eye 1,2,3", "--view and --eye"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        remove("cli_bad.png");
        int rc = cli_run("render %s -o cli_bad.png %s", TEAPOT, bad[k].opts);
        EXPECT(rc, 2, cli_err, bad[k].expect);
        assert_false(cli_exists("cli_bad.png"));
    }
}

/* getopt_long's cases: an unknown option is named as unknown, even when last; a missing value is
 * reported as missing; FILE may come after the options; one FILE only. */
static void test_option_errors(void **state)
{
    (void)state;
    int rc = cli_run("render %s --bogus", TEAPOT);
    EXPECT(rc, 2, cli_err, "unknown option '--bogus'");
    rc = cli_run("render %s -Z", TEAPOT);
    EXPECT(rc, 2, cli_err, "unknown option '-Z'");
    rc = cli_run("render %s --size", TEAPOT);
    EXPECT(rc, 2, cli_err, "--size needs a value");
    rc = cli_run("render");
    EXPECT(rc, 2, cli_err, "no FILE given");
    rc = cli_run("render a.igs b.igs");
    EXPECT(rc, 2, cli_err, "more than one FILE");
    rc = cli_run("render /nonexistent/model.igs -o cli_x.png");
    EXPECT(rc, 1, cli_err, "/nonexistent/model.igs");
    rc = cli_run("render %s -o cli_x.png", CRISP_DATA_DIR);
    EXPECT(rc, 1, cli_err, "is a directory");
    rc = cli_run("info %s", CRISP_DATA_DIR);
    EXPECT(rc, 1, cli_err, "is a directory");
    assert_false(cli_exists("cli_x.png"));
}

/* Outputs are checked before the model is even opened: a bad output beside a missing model
 * reports the output, and no file is left behind. */
static void test_outputs_checked_first(void **state)
{
    (void)state;
    int rc = cli_run("render /nonexistent/model.igs -o cli_out.jpg");
    EXPECT(rc, 2, cli_err,
           "cli_out.jpg: unknown image format (expected a name ending in .png or .exr)");
    assert_false(cli_exists("cli_out.jpg"));
    rc = cli_run("render /nonexistent/model.igs -o /nonexistent/folder/x.png");
    EXPECT(rc, 2, cli_err, "folder /nonexistent/folder");
    rc = cli_run("render /nonexistent/model.igs --aov cli_aov.png");
    EXPECT(rc, 2, cli_err, "cli_aov.png: expected a name ending in .exr");
    assert_false(cli_exists("cli_aov.png"));
    mkdir("cli_dir.png", 0755);
    rc = cli_run("render /nonexistent/model.igs -o cli_dir.png");
    EXPECT(rc, 2, cli_err, "cli_dir.png: is a directory");
    rmdir("cli_dir.png");
    /* a read-only folder (unless running as root, who may write anyway) */
    mkdir("cli_ro", 0555);
    if (access("cli_ro", W_OK) != 0) {
        rc = cli_run("render /nonexistent/model.igs -o cli_ro/x.png");
        EXPECT(rc, 2, cli_err, "cannot write in folder cli_ro");
    }
    rmdir("cli_ro");
}

/* Memory: a warning with the estimate over 2 GB, a refusal over the limit (raisable). The model
 * does not exist, so no render runs: the checks come first. */
static void test_memory(void **state)
{
    (void)state;
    remove("cli_big.png");
    int rc = cli_run("render %s --size 16384x16384 -o cli_big.png", TEAPOT);
    EXPECT(rc, 2, cli_err, "more than the limit of 8.0 GB (raise it with --max-memory");
    assert_non_null(strstr(cli_err, "needs about"));
    assert_false(cli_exists("cli_big.png"));
    rc = cli_run("render /nonexistent/model.igs --size 8192x8192 --samples 1 -o cli_big.png");
    EXPECT(rc, 1, cli_err, "warning: --size 8192x8192 with 1 sample(s) per pixel needs about");
    assert_non_null(strstr(cli_err, "GB"));
    rc = cli_run("render /nonexistent/model.igs --size 16384x16384 --max-memory 1T -o cli_big.png");
    EXPECT(rc, 1, cli_err, "/nonexistent/model.igs"); /* past the limit check */
    rc = cli_run("render /nonexistent/model.igs --size 4096x4096 --samples 16 --max-memory 2G -o "
                 "cli_big.png");
    EXPECT(rc, 2, cli_err, "limit of 2.0 GB");
    assert_false(cli_exists("cli_big.png"));
}

/* A successful render says what it wrote; --quiet says nothing; defaults: 4 samples for a PNG
 * from the cpu backend, 1 for an EXR only. */
static void test_wrote_line_and_defaults(void **state)
{
    (void)state;
    remove("cli_ok.png");
    int rc = cli_run("render %s -o cli_ok.png --size 64x48 --stats", TEAPOT);
    EXPECT(rc, 0, cli_out, "wrote cli_ok.png (64x48, 32 faces, ");
    assert_non_null(strstr(cli_out, " ms)\n"));
    assert_non_null(strstr(cli_out, "samples          4\n"));
    assert_true(cli_exists("cli_ok.png"));
    remove("cli_ok.png");
    rc = cli_run("render %s -o cli_ok.png --size 64x48 -q", TEAPOT);
    assert_int_equal(rc, 0);
    assert_string_equal(cli_out, "");
    assert_string_equal(cli_err, "");
    assert_true(cli_exists("cli_ok.png"));
    remove("cli_ok.exr");
    rc = cli_run("render %s -o cli_ok.exr --size 32x24 --stats", TEAPOT);
    EXPECT(rc, 0, cli_out, "wrote cli_ok.exr (32x24");
    assert_non_null(strstr(cli_out, "samples          1\n"));
    rc = cli_run("render %s -o cli_ok.png --aov cli_ok.exr --size 32x24", TEAPOT);
    EXPECT(rc, 0, cli_out, "wrote cli_ok.png");
    assert_non_null(strstr(cli_out, "wrote cli_ok.exr"));
    remove("cli_ok.png");
    remove("cli_ok.exr");
}

/* --repeat N renders N frames and --stats prints medians. */
static void test_repeat_stats(void **state)
{
    (void)state;
    int rc = cli_run("render %s -o cli_rep.png --size 64x48 --repeat 3 --stats -q", TEAPOT);
    EXPECT(rc, 0, cli_out, "frames           3\n");
    assert_non_null(strstr(cli_out, "time render"));
    assert_non_null(strstr(cli_out, "(median)"));
    assert_non_null(strstr(cli_out, "time rasterize"));
    remove("cli_rep.png");
}

/* The bar is off when stderr is not a terminal, on with --progress, off with --no-progress. */
static void test_progress_switches(void **state)
{
    (void)state;
    setenv("CRISP_PROGRESS_AFTER", "0", 1);
    int rc = cli_run("render %s -o cli_p.png --size 64x48 --backend exact -q", TEAPOT);
    assert_int_equal(rc, 0);
    assert_null(strstr(cli_err, "rendering ["));
    rc = cli_run("render %s -o cli_p.png --size 64x48 --backend exact -q --progress", TEAPOT);
    EXPECT(rc, 0, cli_err, "rendering [");
    assert_non_null(strstr(cli_err, "100%"));
    rc = cli_run("render %s -o cli_p.png --size 64x48 --backend exact -q --progress --no-progress",
                 TEAPOT);
    assert_int_equal(rc, 0);
    assert_null(strstr(cli_err, "rendering ["));
    unsetenv("CRISP_PROGRESS_AFTER");
    remove("cli_p.png");
}

/* --view takes every name, --fit refits a given direction. */
static void test_views(void **state)
{
    (void)state;
    static const char *const views[] = {"front", "back", "left", "right", "top", "bottom", "iso"};
    for (size_t i = 0; i < sizeof views / sizeof views[0]; i++) {
        int rc = cli_run("render %s -o cli_v.png --size 32x24 --samples 1 --view %s --stats",
                         TEAPOT, views[i]);
        EXPECT(rc, 0, cli_out, "camera");
    }
    int rc = cli_run("render %s -o cli_v.png --size 32x24 --samples 1 --eye 100,0,0 --fit --stats",
                     TEAPOT);
    EXPECT(rc, 0, cli_out, "camera");
    /* fitted: the eye moved from x = 100 towards the model */
    assert_null(strstr(cli_out, "eye 100,"));
    remove("cli_v.png");
}

int main(void)
{
    /* work in a scratch folder of the build tree */
    mkdir(CRISP_BIN_DIR "/cli_scratch", 0755);
    if (chdir(CRISP_BIN_DIR "/cli_scratch") != 0) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_version_and_help),
        cmocka_unit_test(test_render_help_lists_options),
        cmocka_unit_test(test_numbers_validated),
        cmocka_unit_test(test_option_errors),
        cmocka_unit_test(test_outputs_checked_first),
        cmocka_unit_test(test_memory),
        cmocka_unit_test(test_wrote_line_and_defaults),
        cmocka_unit_test(test_repeat_stats),
        cmocka_unit_test(test_progress_switches),
        cmocka_unit_test(test_views),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
