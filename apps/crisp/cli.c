/* Shared pieces of the crisp subcommands (cli.h). */
#include "cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "crisp/cells.h"
#include "crisp/core.h"

const char *cli_cmd = "";

int cli_int(const char *opt, const char *s, long lo, long hi, int *dest)
{
    char *end;
    errno = 0;
    long x = strtol(s, &end, 10);
    if (end == s || *end || errno || x < lo || x > hi) {
        fprintf(stderr, "crisp %s: %s %s: expected an integer in %ld..%ld\n", cli_cmd, opt, s, lo,
                hi);
        return 0;
    }
    *dest = (int)x;
    return 1;
}

int cli_cell(const char *opt, const char *s, crisp_cell_spec *dest)
{
    if (crisp_cell_parse(s, dest) == CRISP_OK) return 1;
    fprintf(stderr, "crisp %s: %s: %s\n", cli_cmd, opt, crisp_error_message());
    return 0;
}

int cli_double(const char *opt, const char *s, double lo, double hi, int open_lo, int open_hi,
               double *dest)
{
    char *end;
    double x = strtod(s, &end);
    int ok = end != s && !*end && isfinite(x) && (open_lo ? x > lo : x >= lo) &&
             (open_hi ? x < hi : x <= hi);
    if (!ok) {
        if (isinf(lo) && isinf(hi))
            fprintf(stderr, "crisp %s: %s %s: expected a finite number\n", cli_cmd, opt, s);
        else
            fprintf(stderr, "crisp %s: %s %s: expected a number in %c%g, %g%c\n", cli_cmd, opt, s,
                    open_lo ? '(' : '[', lo, hi, open_hi ? ')' : ']');
        return 0;
    }
    *dest = x;
    return 1;
}

int cli_doubles(const char *opt, const char *s, int n, double *dest)
{
    const char *p = s;
    for (int i = 0; i < n; i++) {
        char *end;
        double x = strtod(p, &end);
        const char *piece_end = strchr(p, ',');
        size_t len = piece_end ? (size_t)(piece_end - p) : strlen(p);
        if (end == p || !isfinite(x) || (size_t)(end - p) != len) {
            fprintf(
                stderr,
                "crisp %s: %s %s: number %d ('%.*s') is not a finite number (expected %d numbers "
                "separated by commas)\n",
                cli_cmd, opt, s, i + 1, (int)len, p, n);
            return 0;
        }
        if (i < n - 1 && *end != ',') {
            fprintf(stderr, "crisp %s: %s %s: %d number%s given, expected %d separated by commas\n",
                    cli_cmd, opt, s, i + 1, i ? "s" : "", n);
            return 0;
        }
        if (i == n - 1 && *end != '\0') {
            fprintf(stderr, "crisp %s: %s %s: more than %d numbers\n", cli_cmd, opt, s, n);
            return 0;
        }
        dest[i] = x;
        p = end + 1;
    }
    return 1;
}

int cli_size(const char *opt, const char *s, int max, int *w, int *h)
{
    char *end, *end2;
    errno = 0;
    long a = strtol(s, &end, 10), b = 0;
    int ok = end != s && (*end == 'x' || *end == 'X');
    if (ok) {
        b = strtol(end + 1, &end2, 10);
        ok = end2 != end + 1 && !*end2 && !errno && a >= 1 && b >= 1 && a <= max && b <= max &&
             end[1] != '-' && end[1] != '+' && s[0] != '-' && s[0] != '+';
    }
    if (!ok) {
        fprintf(stderr, "crisp %s: %s %s: expected WxH, each 1..%d\n", cli_cmd, opt, s, max);
        return 0;
    }
    *w = (int)a;
    *h = (int)b;
    return 1;
}

int cli_bytes(const char *opt, const char *s, uint64_t *dest)
{
    char *end;
    double x = strtod(s, &end);
    double unit = 1;
    if (*end) {
        switch (*end == 0 ? 0 : (end[0] | 0x20)) {
        case 'k':
            unit = 1024.0;
            break;
        case 'm':
            unit = 1024.0 * 1024;
            break;
        case 'g':
            unit = 1024.0 * 1024 * 1024;
            break;
        case 't':
            unit = 1024.0 * 1024 * 1024 * 1024;
            break;
        default:
            unit = 0;
        }
        if (unit && end[1] && !((end[1] | 0x20) == 'b' && !end[2]) &&
            !((end[1] | 0x20) == 'i' && (end[2] | 0x20) == 'b' && !end[3]))
            unit = 0;
    }
    double v = x * unit;
    if (end == s || !unit || !isfinite(v) || v < 1048576.0 || v > 1.8e19) {
        fprintf(stderr, "crisp %s: %s %s: expected a size such as 512M, 8G or 1T (at least 1M)\n",
                cli_cmd, opt, s);
        return 0;
    }
    *dest = (uint64_t)v;
    return 1;
}

void cli_bad_option(int c, char **argv)
{
    extern int optind, optopt;
    const char *arg = argv[optind - 1];
    if (c == ':')
        fprintf(stderr, "crisp %s: option %s needs a value\n", cli_cmd, arg);
    else if (optopt && strncmp(arg, "--", 2))
        fprintf(stderr, "crisp %s: unknown option '-%c' (crisp %s --help lists them)\n", cli_cmd,
                optopt, cli_cmd);
    else
        fprintf(stderr, "crisp %s: unknown option '%s' (crisp %s --help lists them)\n", cli_cmd,
                arg, cli_cmd);
}

void cli_format_bytes(uint64_t b, char *buf, size_t cap)
{
    if (b >= (1ull << 30))
        snprintf(buf, cap, "%.1f GB", b / 1073741824.0);
    else
        snprintf(buf, cap, "%.0f MB", b / 1048576.0);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double cli_median(double *v, size_t n)
{
    if (!n) return 0;
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* ---- progress bar
 * -------------------------------------------------------------------------------- */

/* Drawn on stderr from the thread doing the work (crisp_progress_set), at most ten times a
 * second, once the work has run for a second; erased at the end on a terminal, ended with a
 * newline otherwise (--progress into a file). */
static struct {
    int on, tty, drawn;
    const char *label;
    double start, last, after;
} bar;

static void draw(void *ctx, double f)
{
    (void)ctx;
    double now = crisp_time_now();
    if (now - bar.start < bar.after || (now - bar.last < 0.1 && f < 1)) return;
    bar.last = now;
    enum { W = 30 };
    char cells[W + 1];
    int n = (int)(f * W + 0.5);
    for (int i = 0; i < W; i++)
        cells[i] = i < n ? '#' : '.';
    cells[W] = '\0';
    fprintf(stderr, "\r%s [%s] %3d%% %5.1f s", bar.label, cells, (int)(100 * f + 0.5),
            now - bar.start);
    fflush(stderr);
    bar.drawn = 1;
}

void cli_progress_begin(int mode, const char *label)
{
    bar.tty = isatty(STDERR_FILENO);
    bar.on = mode == 1 || (mode < 0 && bar.tty);
    if (!bar.on) return;
    bar.label = label;
    /* CRISP_PROGRESS_AFTER=seconds moves the one-second threshold (the tests use 0) */
    const char *after = getenv("CRISP_PROGRESS_AFTER");
    char *end;
    double a = after ? strtod(after, &end) : 1.0;
    if (!after || *end || !(a >= 0 && a <= 3600)) a = 1.0;
    bar.after = a;
    bar.start = crisp_time_now();
    bar.last = 0;
    bar.drawn = 0;
    crisp_progress_set(draw, NULL);
}

void cli_progress_end(void)
{
    if (!bar.on) return;
    crisp_progress_set(NULL, NULL);
    if (bar.drawn) fputs(bar.tty ? "\r\033[K" : "\n", stderr);
    bar.on = 0;
}
