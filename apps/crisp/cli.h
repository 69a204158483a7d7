/* Shared pieces of the crisp subcommands: checked number parsing (no atoi: every value is
 * validated and a bad one is named with its option), getopt_long error messages, byte sizes,
 * medians, and the progress bar on stderr. Each function prints its own message, prefixed with
 * "crisp CMD: ", and returns 0 on a bad value. */
#ifndef CRISP_CLI_H
#define CRISP_CLI_H

#include <stddef.h>
#include <stdint.h>

/* The command name used in messages ("render", "frep render", ...). */
extern const char *cli_cmd;

int cli_int(const char *opt, const char *s, long lo, long hi, int *dest);
/* A finite number in [lo, hi] (open at an end when the flag says so). */
int cli_double(const char *opt, const char *s, double lo, double hi, int open_lo, int open_hi,
               double *dest);
/* n comma-separated finite numbers. */
int cli_doubles(const char *opt, const char *s, int n, double *dest);
/* WxH, each in 1..max. */
int cli_size(const char *opt, const char *s, int max, int *w, int *h);
/* A byte count with an optional K, M, G or T suffix (powers of 1024), at least 1 MiB. */
int cli_bytes(const char *opt, const char *s, uint64_t *dest);
/* A cell or tile of a split job, "I/N" or "I/CxR" (crisp_cell_parse). */
struct crisp_cell_spec;
int cli_cell(const char *opt, const char *s, struct crisp_cell_spec *dest);
/* getopt_long returned '?' or ':' (with optstring starting with ':'): print what was wrong. */
void cli_bad_option(int c, char **argv);
void cli_format_bytes(uint64_t bytes, char *buf, size_t cap);
/* Median of n values (sorts the array). */
double cli_median(double *v, size_t n);

/* Progress bar on stderr: mode -1 (default: only when stderr is a terminal), 0 off, 1 on.
 * Installs a crisp_progress sink that draws a bar for work lasting over about a second. */
void cli_progress_begin(int mode, const char *label);
void cli_progress_end(void);

#endif
