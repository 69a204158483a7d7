/* The crisp command line as a user meets it: --help and --version everywhere, every option of
 * `crisp render` listed with its default, numbers validated and named in messages, outputs and
 * memory checked before any work (a refused run leaves no file), the "wrote" line and --quiet,
 * --repeat with --stats, the progress bar switches. Runs the built binary in a scratch folder. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "crisp/version.h"

#define TEAPOT CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs"

static char out_buf[65536], err_buf[65536];

/* Runs `crisp ARGS` with stdout and stderr captured separately; returns the exit status. */
static int run(const char *fmt, ...)
{
    char args[2048], cmd[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(args, sizeof args, fmt, ap);
    va_end(ap);
    snprintf(cmd, sizeof cmd, "'%s/crisp' %s >cli_stdout.txt 2>cli_stderr.txt", CRISP_BIN_DIR,
             args);
    int st = system(cmd);
    char *bufs[2] = {out_buf, err_buf};
    const char *names[2] = {"cli_stdout.txt", "cli_stderr.txt"};
    for (int i = 0; i < 2; i++) {
        FILE *f = fopen(names[i], "rb");
        size_t n = f ? fread(bufs[i], 1, sizeof out_buf - 1, f) : 0;
        bufs[i][n] = '\0';
        if (f) fclose(f);
    }
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

#define EXPECT(rc, code, stream, text)                                                             \
    do {                                                                                           \
        if ((rc) != (code) || !strstr(stream, text))                                               \
            fprintf(stderr, "exit %d (expected %d), looking for '%s' in:\n%s\n", rc, code, text,   \
                    stream);                                                                       \
        assert_int_equal(rc, code);                                                                \
        assert_non_null(strstr(stream, text));                                                     \
    } while (0)

static void test_version_and_help(void **state)
{
    (void)state;
    int rc = run("--version");
    EXPECT(rc, 0, out_buf, "crisp " CRISP_VERSION_STRING "\n");
    rc = run("version");
    EXPECT(rc, 0, out_buf, "crisp " CRISP_VERSION_STRING);
    rc = run("--help");
    EXPECT(rc, 0, out_buf, "render");
    assert_non_null(strstr(out_buf, "--version"));
    rc = run("");
    EXPECT(rc, 2, err_buf, "usage");
    rc = run("--bogus");
    EXPECT(rc, 2, err_buf, "unknown option '--bogus'");
    rc = run("nosuchcommand");
    EXPECT(rc, 2, err_buf, "unknown command 'nosuchcommand'");
    static const char *const subs[] = {"render --help", "render -h", "info --help",
                                       "version --help", "render " TEAPOT " --help"};
    for (size_t i = 0; i < sizeof subs / sizeof subs[0]; i++) {
        rc = run("%s", subs[i]);
        EXPECT(rc, 0, out_buf, "usage: crisp");
        assert_string_equal(err_buf, "");
    }
}

/* Every option of crisp render is in its --help, each with a default in brackets. */
static void test_render_help_lists_options(void **state)
{
    (void)state;
    assert_int_equal(run("render --help"), 0);
    static const char *const opts[] = {
        "-o, --output",  "--aov",       "--size",    "--view",  "--fit",        "--eye",
        "--target",      "--up",        "--fov",     "--near",  "--far",        "--samples",
        "--backend",     "--threads",   "--repeat",  "--stats", "--max-memory", "--progress",
        "--no-progress", "-q, --quiet", "-h, --help"};
    for (size_t i = 0; i < sizeof opts / sizeof opts[0]; i++) {
        const char *at = strstr(out_buf, opts[i]);
        if (!at) fprintf(stderr, "'%s' missing from:\n%s", opts[i], out_buf);
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
    assert_int_equal(run("info --help"), 0);
    assert_non_null(strstr(out_buf, "--json"));
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
        int rc = run("render %s -o cli_bad.png %s", TEAPOT, bad[k].opts);
        EXPECT(rc, 2, err_buf, bad[k].expect);
        assert_false(exists("cli_bad.png"));
    }
}

/* getopt_long's cases: an unknown option is named as unknown, even when last; a missing value is
 * reported as missing; FILE may come after the options; one FILE only. */
static void test_option_errors(void **state)
{
    (void)state;
    int rc = run("render %s --bogus", TEAPOT);
    EXPECT(rc, 2, err_buf, "unknown option '--bogus'");
    rc = run("render %s -Z", TEAPOT);
    EXPECT(rc, 2, err_buf, "unknown option '-Z'");
    rc = run("render %s --size", TEAPOT);
    EXPECT(rc, 2, err_buf, "--size needs a value");
    rc = run("render");
    EXPECT(rc, 2, err_buf, "no FILE given");
    rc = run("render a.igs b.igs");
    EXPECT(rc, 2, err_buf, "more than one FILE");
    rc = run("render /nonexistent/model.igs -o cli_x.png");
    EXPECT(rc, 1, err_buf, "/nonexistent/model.igs");
    rc = run("render %s -o cli_x.png", CRISP_DATA_DIR);
    EXPECT(rc, 1, err_buf, "is a directory");
    rc = run("info %s", CRISP_DATA_DIR);
    EXPECT(rc, 1, err_buf, "is a directory");
    assert_false(exists("cli_x.png"));
}

/* Outputs are checked before the model is even opened: a bad output beside a missing model
 * reports the output, and no file is left behind. */
static void test_outputs_checked_first(void **state)
{
    (void)state;
    int rc = run("render /nonexistent/model.igs -o cli_out.jpg");
    EXPECT(rc, 2, err_buf,
           "cli_out.jpg: unknown image format (expected a name ending in .png or .exr)");
    assert_false(exists("cli_out.jpg"));
    rc = run("render /nonexistent/model.igs -o /nonexistent/folder/x.png");
    EXPECT(rc, 2, err_buf, "folder /nonexistent/folder");
    rc = run("render /nonexistent/model.igs --aov cli_aov.png");
    EXPECT(rc, 2, err_buf, "cli_aov.png: expected a name ending in .exr");
    assert_false(exists("cli_aov.png"));
    mkdir("cli_dir.png", 0755);
    rc = run("render /nonexistent/model.igs -o cli_dir.png");
    EXPECT(rc, 2, err_buf, "cli_dir.png: is a directory");
    rmdir("cli_dir.png");
    /* a read-only folder (unless running as root, who may write anyway) */
    mkdir("cli_ro", 0555);
    if (access("cli_ro", W_OK) != 0) {
        rc = run("render /nonexistent/model.igs -o cli_ro/x.png");
        EXPECT(rc, 2, err_buf, "cannot write in folder cli_ro");
    }
    rmdir("cli_ro");
}

/* Memory: a warning with the estimate over 2 GB, a refusal over the limit (raisable). The model
 * does not exist, so no render runs: the checks come first. */
static void test_memory(void **state)
{
    (void)state;
    remove("cli_big.png");
    int rc = run("render %s --size 16384x16384 -o cli_big.png", TEAPOT);
    EXPECT(rc, 2, err_buf, "more than the limit of 8.0 GB (raise it with --max-memory");
    assert_non_null(strstr(err_buf, "needs about"));
    assert_false(exists("cli_big.png"));
    rc = run("render /nonexistent/model.igs --size 8192x8192 --samples 1 -o cli_big.png");
    EXPECT(rc, 1, err_buf, "warning: --size 8192x8192 with 1 sample(s) per pixel needs about");
    assert_non_null(strstr(err_buf, "GB"));
    rc = run("render /nonexistent/model.igs --size 16384x16384 --max-memory 1T -o cli_big.png");
    EXPECT(rc, 1, err_buf, "/nonexistent/model.igs"); /* past the limit check */
    rc = run("render /nonexistent/model.igs --size 4096x4096 --samples 16 --max-memory 2G -o "
             "cli_big.png");
    EXPECT(rc, 2, err_buf, "limit of 2.0 GB");
    assert_false(exists("cli_big.png"));
}

/* A successful render says what it wrote; --quiet says nothing; defaults: 4 samples for a PNG
 * from the cpu backend, 1 for an EXR only. */
static void test_wrote_line_and_defaults(void **state)
{
    (void)state;
    remove("cli_ok.png");
    int rc = run("render %s -o cli_ok.png --size 64x48 --stats", TEAPOT);
    EXPECT(rc, 0, out_buf, "wrote cli_ok.png (64x48, 32 faces, ");
    assert_non_null(strstr(out_buf, " ms)\n"));
    assert_non_null(strstr(out_buf, "samples          4\n"));
    assert_true(exists("cli_ok.png"));
    remove("cli_ok.png");
    rc = run("render %s -o cli_ok.png --size 64x48 -q", TEAPOT);
    assert_int_equal(rc, 0);
    assert_string_equal(out_buf, "");
    assert_string_equal(err_buf, "");
    assert_true(exists("cli_ok.png"));
    remove("cli_ok.exr");
    rc = run("render %s -o cli_ok.exr --size 32x24 --stats", TEAPOT);
    EXPECT(rc, 0, out_buf, "wrote cli_ok.exr (32x24");
    assert_non_null(strstr(out_buf, "samples          1\n"));
    rc = run("render %s -o cli_ok.png --aov cli_ok.exr --size 32x24", TEAPOT);
    EXPECT(rc, 0, out_buf, "wrote cli_ok.png");
    assert_non_null(strstr(out_buf, "wrote cli_ok.exr"));
    remove("cli_ok.png");
    remove("cli_ok.exr");
}

/* --repeat N renders N frames and --stats prints medians. */
static void test_repeat_stats(void **state)
{
    (void)state;
    int rc = run("render %s -o cli_rep.png --size 64x48 --repeat 3 --stats -q", TEAPOT);
    EXPECT(rc, 0, out_buf, "frames           3\n");
    assert_non_null(strstr(out_buf, "time render"));
    assert_non_null(strstr(out_buf, "(median)"));
    assert_non_null(strstr(out_buf, "time rasterize"));
    remove("cli_rep.png");
}

/* The bar is off when stderr is not a terminal, on with --progress, off with --no-progress. */
static void test_progress_switches(void **state)
{
    (void)state;
    setenv("CRISP_PROGRESS_AFTER", "0", 1);
    int rc = run("render %s -o cli_p.png --size 64x48 --backend exact -q", TEAPOT);
    assert_int_equal(rc, 0);
    assert_null(strstr(err_buf, "rendering ["));
    rc = run("render %s -o cli_p.png --size 64x48 --backend exact -q --progress", TEAPOT);
    EXPECT(rc, 0, err_buf, "rendering [");
    assert_non_null(strstr(err_buf, "100%"));
    rc = run("render %s -o cli_p.png --size 64x48 --backend exact -q --progress --no-progress",
             TEAPOT);
    assert_int_equal(rc, 0);
    assert_null(strstr(err_buf, "rendering ["));
    unsetenv("CRISP_PROGRESS_AFTER");
    remove("cli_p.png");
}

/* --view takes every name, --fit refits a given direction. */
static void test_views(void **state)
{
    (void)state;
    static const char *const views[] = {"front", "back", "left", "right", "top", "bottom", "iso"};
    for (size_t i = 0; i < sizeof views / sizeof views[0]; i++) {
        int rc = run("render %s -o cli_v.png --size 32x24 --samples 1 --view %s --stats", TEAPOT,
                     views[i]);
        EXPECT(rc, 0, out_buf, "camera");
    }
    int rc =
        run("render %s -o cli_v.png --size 32x24 --samples 1 --eye 100,0,0 --fit --stats", TEAPOT);
    EXPECT(rc, 0, out_buf, "camera");
    /* fitted: the eye moved from x = 100 towards the model */
    assert_null(strstr(out_buf, "eye 100,"));
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
