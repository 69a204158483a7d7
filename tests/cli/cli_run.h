/* Running the built `crisp` binary from a test program: its output captured (stdout and stderr
 * apart, or merged), a file's existence, a PNG's size, and an EXPECT on exit status and text.
 * Shared by the command-line tests (tests/cli, tests/render/test_cli_render.c,
 * tests/gl/test_gl_cli.c); include after <cmocka.h>. The capture files carry the test's process
 * id, so two test programs running at once in the same folder do not collide. */
#ifndef CRISP_TESTS_CLI_RUN_H
#define CRISP_TESTS_CLI_RUN_H

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char cli_out[65536], cli_err[65536];

/* Runs `ENV crisp ARGS` (ENV: variable assignments or "") with stdout in cli_out and stderr in
 * cli_err; returns the exit status (-1 if it did not exit). */
static inline int cli_run_env(const char *env, const char *fmt, va_list ap)
{
    char args[2048], cmd[4096], names[2][64];
    vsnprintf(args, sizeof args, fmt, ap);
    snprintf(names[0], sizeof names[0], "cli_stdout.%ld.txt", (long)getpid());
    snprintf(names[1], sizeof names[1], "cli_stderr.%ld.txt", (long)getpid());
    snprintf(cmd, sizeof cmd, "%s '%s/crisp' %s >%s 2>%s", env, CRISP_BIN_DIR, args, names[0],
             names[1]);
    int st = system(cmd);
    char *bufs[2] = {cli_out, cli_err};
    for (int i = 0; i < 2; i++) {
        FILE *f = fopen(names[i], "rb");
        size_t n = f ? fread(bufs[i], 1, sizeof cli_out - 1, f) : 0;
        bufs[i][n] = '\0';
        if (f) fclose(f);
        remove(names[i]);
    }
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* `crisp ARGS` (printf-style), stdout in cli_out, stderr in cli_err. */
static inline int cli_run(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int rc = cli_run_env("", fmt, ap);
    va_end(ap);
    return rc;
}

/* `ENV crisp ARGS` with stdout and stderr together in OUT (at most CAP - 1 bytes). */
static inline int cli_run_merged(const char *env, const char *args, char *out, size_t cap)
{
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "%s '%s/crisp' %s 2>&1", env, CRISP_BIN_DIR, args);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t n = fread(out, 1, cap - 1, p);
    out[n] = '\0';
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static inline int cli_exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

/* The width and height in a PNG's header (asserts that it is one). */
static inline void cli_png_size(const char *path, int *w, int *h)
{
    unsigned char b[24];
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    assert_int_equal(fread(b, 1, 24, f), 24);
    fclose(f);
    assert_memory_equal(b + 1, "PNG", 3);
    *w = b[16] << 24 | b[17] << 16 | b[18] << 8 | b[19];
    *h = b[20] << 24 | b[21] << 16 | b[22] << 8 | b[23];
}

/* Exit status RC must be CODE and STREAM must contain TEXT (prints what it got otherwise). */
#define EXPECT(rc, code, stream, text)                                                             \
    do {                                                                                           \
        if ((rc) != (code) || !strstr(stream, text))                                               \
            fprintf(stderr, "exit %d (expected %d), looking for '%s' in:\n%s\n", rc, code, text,   \
                    stream);                                                                       \
        assert_int_equal(rc, code);                                                                \
        assert_non_null(strstr(stream, text));                                                     \
    } while (0)

#endif
