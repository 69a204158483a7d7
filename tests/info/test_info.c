/* The `crisp info` command line: runs the built binary on models and on broken files and checks
 * the summary, the JSON form, the messages (file, line, problem) and the exit codes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include <cmocka.h>

/* Run `crisp ARGS 2>&1`; returns the exit code, output in out. */
static int run(const char *args, char *out, size_t cap)
{
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "'%s/crisp' %s 2>&1", CRISP_BIN_DIR, args);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t n = fread(out, 1, cap - 1, p);
    out[n] = '\0';
    int status = pclose(p);
    assert_true(WIFEXITED(status));
    return WEXITSTATUS(status);
}

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static const char grid_obj[] =
    "v 0 0 0\nv 1 0 0\nv 2 0 1\nv 0 1 0\nv 1 1 0.5\nv 2 1 0\n"
    "vp 0.2 0.2\nvp 1.8 0.2\nvp 1.8 0.8\nvp 0.2 0.8\n"
    "vp 0.8 0.4\nvp 1.2 0.4\nvp 1.2 0.6\nvp 0.8 0.6\n"
    "cstype bspline\ndeg 1\ncurv2 1 2 3 4 1\nparm u 0 1 2 3 4 5 6\nend\n"
    "curv2 5 6 7 8 5\nparm u 0 1 2 3 4 5 6\nend\n"
    "cstype rat bspline\ndeg 2 1\nsurf 0 2 0 1 1 2 3 4 5 6\nparm u 0 0 0 2 2 2\nparm v 0 0 1 1\n"
    "trim 1 5 1\nhole 1 5 2\nend\n"
    "frobnicate\n";

static void test_obj_summary(void **state)
{
    (void)state;
    const char *path = CRISP_BIN_DIR "/test_info_grid.obj";
    write_file(path, grid_obj);
    char out[8192], args[512];
    snprintf(args, sizeof args, "info '%s'", path);
    assert_int_equal(run(args, out, sizeof out), 0);
    assert_non_null(strstr(out, "format:          OBJ"));
    assert_non_null(strstr(out, "faces:           1\n"));
    /* one Bezier patch (one span each way); 1 outer + 1 hole; curv2 pieces of 4 spans each */
    assert_non_null(strstr(out, "bezier patches:  1\n"));
    assert_non_null(strstr(out, "trim loops:      2 (1 outer, 1 holes)"));
    assert_non_null(strstr(out, "trim curves:     2 (8 Bezier pieces)"));
    assert_non_null(strstr(out, "surface degrees: 1, 2 (max 2 x 1)"));
    /* the box of the trimmed face (u in [0.2, 1.8], v in [0.2, 0.8] of a surface over [0, 2] x
     * [0, 1] in x and y), not the control hull [0, 0, 0] - [2, 1, 1] */
    assert_null(strstr(out, "bounding box:    [0, 0, 0] - [2, 1, 1]"));
    assert_non_null(strstr(out, "faces dropped:   0\n"));
    assert_non_null(strstr(out, "gaps:            none wider than the tolerance"));
    assert_non_null(strstr(out, "coloured faces:  0\n"));
    assert_non_null(strstr(out, "frobnicate"));

    snprintf(args, sizeof args, "info --json '%s'", path);
    assert_int_equal(run(args, out, sizeof out), 0);
    assert_non_null(strstr(out, "\"format\": \"OBJ\""));
    assert_non_null(strstr(out, "\"faces\": 1,"));
    assert_non_null(strstr(out, "\"loops\": {\"outer\": 1, \"holes\": 1}"));
    assert_non_null(strstr(out, "\"degrees_seen\": [1, 2]"));
    const char *bb = strstr(out, "\"bbox\": [");
    assert_non_null(bb);
    double b[6];
    assert_int_equal(sscanf(bb, "\"bbox\": [%lf, %lf, %lf, %lf, %lf, %lf]", b, b + 1, b + 2, b + 3,
                            b + 4, b + 5),
                     6);
    /* contains the trimmed face, and is well inside the hull in x and y */
    assert_true(b[0] <= 0.2 + 1e-9 && b[0] > 0.1 && b[3] >= 1.8 - 1e-9 && b[3] < 1.9);
    assert_true(b[1] <= 0.2 + 1e-9 && b[1] > 0.1 && b[4] >= 0.8 - 1e-9 && b[4] < 0.9);
    assert_non_null(strstr(out, "\"faces_dropped\": 0,"));
    /* one face: no other face near its boundary, no gap */
    assert_non_null(strstr(out, "\"gaps\": {\"measured\": true,"));
    assert_non_null(strstr(out, "\"pairs\": 0,"));
    snprintf(args, sizeof args, "info --no-gaps --json '%s'", path);
    assert_int_equal(run(args, out, sizeof out), 0);
    assert_non_null(strstr(out, "\"gaps\": {\"measured\": false,"));
    assert_non_null(strstr(out, "\"colored_faces\": 0,"));
    assert_non_null(strstr(out, "\"skipped\": [{\"what\": \"OBJ statement 'frobnicate'"));
    remove(path);
}

/* Skip reasons are kept in full in the text and the JSON (they used to be cut at 95 characters). */
static void test_full_skip_reasons(void **state)
{
    (void)state;
    char lib[200];
    memset(lib, 'q', 150);
    snprintf(lib + 150, sizeof lib - 150, "_end_of_a_long_name.mtl");
    char text[600];
    snprintf(text, sizeof text, "mtllib %s\nusemtl red\n%s", lib, grid_obj);
    const char *path = CRISP_BIN_DIR "/test_info_long.obj";
    write_file(path, text);
    char out[16384], args[512], want[400];
    snprintf(want, sizeof want, "OBJ mtllib '%s': not readable, no colours", lib);
    assert_true(strlen(want) > 95);
    snprintf(args, sizeof args, "info '%s'", path);
    assert_int_equal(run(args, out, sizeof out), 0);
    assert_non_null(strstr(out, want));
    snprintf(args, sizeof args, "info --json '%s'", path);
    assert_int_equal(run(args, out, sizeof out), 0);
    assert_non_null(strstr(out, want));
    remove(path);
}

static void test_broken_files(void **state)
{
    (void)state;
    char out[8192], args[512];
    const char *bad = CRISP_BIN_DIR "/test_info_bad.obj";
    write_file(bad, "v 0 0 0\nv 1 2\n");
    snprintf(args, sizeof args, "info '%s'", bad);
    assert_int_equal(run(args, out, sizeof out), 1);
    char where[600];
    snprintf(where, sizeof where, "%s:2:1", bad);
    assert_non_null(strstr(out, where));
    assert_non_null(strstr(out, "expected"));
    remove(bad);

    const char *junk = CRISP_BIN_DIR "/test_info_junk.bin";
    write_file(junk, "\x7f"
                     "ELF garbage\n");
    snprintf(args, sizeof args, "info '%s'", junk);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "not an IGES, STEP or OBJ file"));
    remove(junk);

    snprintf(args, sizeof args, "info '%s/does-not-exist.igs'", CRISP_BIN_DIR);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "does-not-exist.igs"));

    assert_int_equal(run("info", out, sizeof out), 2);
    assert_int_equal(run("info --bogus x", out, sizeof out), 2);
}

#ifdef CRISP_TEST_HAVE_IGES
static void test_iges_hammer(void **state)
{
    (void)state;
    char out[16384];
    assert_int_equal(run("info '" CRISP_DATA_DIR "/nurbs/occt_hammer.iges'", out, sizeof out), 0);
    assert_non_null(strstr(out, "format:          IGES"));
    assert_non_null(strstr(out, "faces:           45\n"));
    assert_non_null(strstr(out, " 3 holes)"));
}
#endif

#ifdef CRISP_TEST_HAVE_STEP
static void test_step_linkrods(void **state)
{
    (void)state;
    char out[16384];
    assert_int_equal(
        run("info --json '" CRISP_DATA_DIR "/nurbs/occt_linkrods.step'", out, sizeof out), 0);
    assert_non_null(strstr(out, "\"format\": \"STEP\""));
    assert_non_null(strstr(out, "\"faces\": 37,"));
}
#endif

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_obj_summary),   cmocka_unit_test(test_full_skip_reasons),
        cmocka_unit_test(test_broken_files),
#ifdef CRISP_TEST_HAVE_IGES
        cmocka_unit_test(test_iges_hammer),
#endif
#ifdef CRISP_TEST_HAVE_STEP
        cmocka_unit_test(test_step_linkrods),
#endif
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
