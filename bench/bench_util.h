/* Shared helpers for the benchmarks: the machine line every table starts with, medians, and the
 * bundled models' names. */
#ifndef CRISP_BENCH_UTIL_H
#define CRISP_BENCH_UTIL_H

#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/resource.h>
#include <unistd.h>

#include "crisp/render.h"

static inline void bench_print_machine(FILE *out)
{
    char model[256] = "unknown CPU";
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (f) {
        char line[512];
        while (fgets(line, sizeof line, f)) {
            if (!strncmp(line, "model name", 10)) {
                char *c = strchr(line, ':');
                if (c) {
                    c += 2;
                    c[strcspn(c, "\n")] = 0;
                    snprintf(model, sizeof model, "%s", c);
                }
                break;
            }
        }
        fclose(f);
    }
    time_t now = time(NULL);
    char date[32];
    strftime(date, sizeof date, "%Y-%m-%d", gmtime(&now));
    fprintf(out, "machine: %s, %ld cores online, date %s\n", model, sysconf(_SC_NPROCESSORS_ONLN),
            date);
}

static int bench_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median of n values (sorts in place). */
static inline double bench_median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, bench_cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static int bench_cmp_name(const void *a, const void *b)
{
    return strcmp(a, b);
}

/* The names of the files in dir (no hidden ones), sorted; at most cap; returns how many. */
static inline int bench_list_files(const char *dir, char (*names)[256], int cap)
{
    int n = 0;
    DIR *d = opendir(dir);
    if (!d) return 0;
    struct dirent *e;
    while ((e = readdir(d)) && n < cap)
        if (e->d_name[0] != '.') snprintf(names[n++], sizeof names[0], "%s", e->d_name);
    closedir(d);
    qsort(names, (size_t)n, sizeof names[0], bench_cmp_name);
    return n;
}

/* CPU time of the process (all threads), in ms: less sensitive to other processes' load than
 * wall time. */
static inline double bench_cpu_ms(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return 1e3 * (u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
           1e-3 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

/* FNV-1a over an image and its AOVs: the same picture and AOVs give the same value (a check that
 * a faster build draws what the baseline drew). */
static inline uint32_t bench_image_hash(const crisp_image *img)
{
    size_t n = (size_t)img->width * img->height;
    const void *bufs[5] = {img->rgba, img->depth, img->normal, img->uv, img->face};
    const size_t sizes[5] = {16 * n, 4 * n, 12 * n, 8 * n, 4 * n};
    uint32_t h = 2166136261u;
    for (int b = 0; b < 5; b++)
        for (size_t k = 0; k < sizes[b]; k++)
            h = (h ^ ((const uint8_t *)bufs[b])[k]) * 16777619u;
    return h;
}

/* The 1-minute load average (/proc/loadavg), or -1 when it cannot be read. */
static inline double bench_load_average(void)
{
    double l = -1;
    FILE *f = fopen("/proc/loadavg", "r");
    if (f && fscanf(f, "%lf", &l) != 1) l = -1;
    if (f) fclose(f);
    return l;
}

#endif
