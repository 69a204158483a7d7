/* crisp frep as a user meets it (issue 14): getopt options per subcommand, --help for each
 * with every option and its default, bad values named with their option (exit 2), FILE or -e,
 * and one short run of each subcommand. Runs the built binary in a scratch folder of its own. */
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

#define BEAR CRISP_DATA_DIR "/frep/bear.vm"
#define SPHERE "-e 'X^2+Y^2+Z^2-1'"

/* Each subcommand's --help lists its options, each with a [default] on its line or the next. */
static void test_help(void **state)
{
    (void)state;
    static const struct {
        const char *sub;
        const char *opts[16];
    } subs[] = {
        {"render",
         {"-e, --expr", "-o, --output", "--size", "--3d", "--depth", "--region", "--depth-out",
          "--threads", "--runs", "--stats", "--no-prune", "--no-batch", "--no-subcells", "--brute",
          "-h, --help", NULL}},
        {"bench", {"--runs", "-h, --help", NULL}},
        {"mesh",
         {"-e, --expr", "-o, --output", "--resolution", "--cell", "--region", "--max-memory",
          "--no-features", "--stats", "-h, --help", NULL}},
        {"mass",
         {"-e, --expr", "--accuracy", "--time", "--predict", "--level", "--seed", "--region",
          "-h, --help", NULL}},
    };
    for (size_t i = 0; i < sizeof subs / sizeof subs[0]; i++) {
        for (int h = 0; h < 3; h++) {
            /* --help, -h, and --help after other arguments */
            int rc = cli_run("frep %s %s", subs[i].sub,
                             h == 0   ? "--help"
                             : h == 1 ? "-h"
                                      : BEAR " -e X --help");
            EXPECT(rc, 0, cli_out, "usage: crisp frep");
            assert_string_equal(cli_err, "");
        }
        for (int k = 0; subs[i].opts[k]; k++) {
            /* the option where it starts a line of the list (not in the usage line) */
            const char *at = cli_out;
            while ((at = strstr(at, subs[i].opts[k]))) {
                const char *p = at;
                while (p > cli_out && p[-1] == ' ')
                    p--;
                if (p > cli_out && p[-1] == '\n') break;
                at++;
            }
            if (!at) fprintf(stderr, "'%s' missing from:\n%s", subs[i].opts[k], cli_out);
            assert_non_null(at);
            if (!strcmp(subs[i].opts[k], "-h, --help") || !strcmp(subs[i].opts[k], "-e, --expr"))
                continue;
            const char *next = strstr(at + 1, "\n  -");
            const char *bracket = strchr(at, '[');
            if (!bracket || (next && bracket > next))
                fprintf(stderr, "no [default] for %s\n", subs[i].opts[k]);
            assert_true(bracket && (!next || bracket < next));
        }
    }
    int rc = cli_run("frep --help");
    EXPECT(rc, 0, cli_out, "crisp frep mesh FILE");
    rc = cli_run("frep");
    EXPECT(rc, 2, cli_err, "usage: crisp frep");
    rc = cli_run("frep carve %s", BEAR);
    EXPECT(rc, 2, cli_err, "unknown subcommand 'carve'");
}

/* A bad value is named with its option and refused before any work (exit 2, no file). */
static void test_values(void **state)
{
    (void)state;
    static const struct {
        const char *args, *expect;
    } bad[] = {
        {"render " BEAR " --size 0",
         "crisp frep render: --size 0: expected an integer in 1..16384"},
        {"render " BEAR " --size 64x", "--size 64x: expected WxH"},
        {"render " BEAR " --threads abc", "--threads abc: expected an integer"},
        {"render " BEAR " --3d --depth -4", "--depth -4"},
        {"render " BEAR " --depth 8", "--depth 8 needs --3d"},
        {"render " BEAR " --region 0,1,2", "--region 0,1,2: 3 numbers given"},
        {"render " BEAR " --region 1,0,0,1", "axis x [1, 0] is empty"},
        {"render " BEAR " -o frep_x.jpg", "-o frep_x.jpg: expected a name ending in .png"},
        {"render " BEAR " --depth-out frep_x.png", "--depth-out frep_x.png: expected a name"},
        {"bench " BEAR " --runs 0", "crisp frep bench: --runs 0"},
        {"mesh " BEAR " -o frep_x.stl --resolution 2",
         "--resolution 2: expected an integer in 4.."},
        {"mesh " BEAR " -o frep_x.stl --cell -1", "--cell -1: expected a number in (0, inf)"},
        {"mesh " BEAR " -o frep_x.stl --cell nan", "--cell nan"},
        {"mesh " BEAR " -o frep_x.stl --region -1,1,-1,1", "--region -1,1,-1,1: 4 numbers given"},
        {"mesh " BEAR " -o frep_x.stl --max-memory 0", "--max-memory 0"},
        {"mesh " BEAR " -o frep_x.stp", "-o frep_x.stp: expected a name ending in .stl"},
        {"mesh " BEAR, "no output given"},
        {"mass " BEAR " --accuracy 2", "crisp frep mass: --accuracy 2: expected a number in"},
        {"mass " BEAR " --time 0", "--time 0"},
        {"mass " BEAR " --level 21", "--level 21: expected an integer in 1..20"},
        {"mass " BEAR " --seed -1", "--seed -1"},
        {"mass " BEAR " --level 4 --predict", "--level runs one level"},
        {"mass " BEAR " --accuracy 1e-3 --time 1", "--accuracy and --time"},
        {"mass " BEAR " --bogus", "crisp frep mass: unknown option '--bogus'"},
        {"mass " BEAR " --level", "option --level needs a value"},
        {"mass", "crisp frep mass: no FILE given"},
        {"mass a.vm b.vm", "more than one FILE given ('a.vm', 'b.vm')"},
        {"mass " BEAR " " SPHERE, "both FILE"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        remove("frep_x.stl");
        int rc = cli_run("frep %s", bad[k].args);
        EXPECT(rc, 2, cli_err, bad[k].expect);
        assert_false(cli_exists("frep_x.stl"));
    }
}

/* One short run of each: FILE after the options, -e, the outputs written. */
static void test_runs(void **state)
{
    (void)state;
    remove("frep_r.png");
    int rc = cli_run("frep render --size 48x32 -o frep_r.png --3d " BEAR);
    assert_int_equal(rc, 0);
    assert_true(cli_exists("frep_r.png"));
    rc = cli_run("frep bench " SPHERE " --size 32 --runs 2");
    EXPECT(rc, 0, cli_out, "render median");
    rc = cli_run("frep mesh " SPHERE " --resolution 8 -o frep_m.obj --stats");
    EXPECT(rc, 0, cli_out, "frep_m.obj: ");
    assert_non_null(strstr(cli_out, "leaves"));
    rc = cli_run("frep mass " SPHERE " --level 5 --seed 3");
    EXPECT(rc, 0, cli_out, "volume    4.1");
    rc = cli_run("frep mass " SPHERE " --predict --accuracy 1e-2");
    EXPECT(rc, 0, cli_out, "predicted: processor time");
    /* a region that cuts the part: a warning, and the part within it */
    rc = cli_run("frep mass " SPHERE " --level 4 --region 0,1,-1,1,-1,1");
    EXPECT(rc, 0, cli_err, "warning: the region");
    assert_non_null(strstr(cli_out, "volume    2.0"));
    /* bad input: a message and exit 1 */
    rc = cli_run("frep mass -e 'X'");
    EXPECT(rc, 1, cli_err, "crisp frep mass: ");
    rc = cli_run("frep mesh /nonexistent.vm -o frep_m.stl");
    EXPECT(rc, 1, cli_err, "/nonexistent.vm");
    remove("frep_r.png");
    remove("frep_m.obj");
}

int main(void)
{
    mkdir(CRISP_BIN_DIR "/cli_frep_scratch", 0755);
    if (chdir(CRISP_BIN_DIR "/cli_frep_scratch") != 0) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_help),
        cmocka_unit_test(test_values),
        cmocka_unit_test(test_runs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
