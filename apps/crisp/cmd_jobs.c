/* crisp jobs JOB ... -o DIR (issue 15): split a long job into cells and write what an existing
 * job engine needs to run them: a Makefile (cells as targets, the merge as the final target;
 * make -j N, resumable by file time), a GNU parallel job list (--joblog/--resume,
 * --sshloginfile) with the merge as a script, and a Slurm array script running GNU parallel in
 * each allocation over a batch of cells. crisp schedules nothing itself.
 *
 * The cell count follows from two quick runs of the cell command itself (a corner tile of the
 * full image: the overhead of a cell, and its peak memory; the whole image at a reduced size: the
 * time per pixel), so that a cell takes at least --cell-seconds, its overhead stays under 10% of
 * it, and its predicted memory stays under --max-cell-memory; both predictions are printed. */
#define _DEFAULT_SOURCE /* wait4, realpath */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cli.h"
#include "crisp/app.h"
#include "crisp/cells.h"

const char crisp_cmd_jobs_help[] =
    "jobs JOB ... -o DIR          split a job into cells for make, GNU parallel or Slurm";

static const char usage_text[] =
    "usage: crisp jobs JOB INPUT... [options] [cell options] -o DIR\n"
    "  Splits a long job into cells and writes, in DIR: Makefile (make -j N -C DIR; run again to\n"
    "  redo only missing cells), jobs.txt and merge.sh (GNU parallel: parallel -j N --joblog\n"
    "  DIR/joblog --resume < DIR/jobs.txt && sh DIR/merge.sh; --sshloginfile FILE spreads them\n"
    "  over hosts sharing DIR's file system), slurm.sh (a Slurm array, each task running a batch\n"
    "  of cells with GNU parallel; then merge.sh as a dependent job). JOB is one of:\n"
    "    render FILE        an image in tiles (crisp render --tile), merged by crisp merge\n"
    "    frep-render FILE   an f-rep image or heightmap in tiles (crisp frep render --tile)\n"
    "    turntable FILE     --frames N frames of a camera orbiting the model about +Z\n"
    "    batch FILE...      one image per file (thumbnails of many models)\n"
    "    mass MODEL         NURBS mass properties in cells of faces (crisp mass --cell)\n"
    "    frep-mass FILE     f-rep mass properties in octree cells (crisp frep mass --cell)\n"
    "    frep-mesh FILE     an f-rep mesh in octree cells welded by crisp merge (--output\n"
    "                       mesh.stl, .obj or .ply)\n"
    "  Options not listed here are passed to each cell's command (e.g. --size, --samples,\n"
    "  --view for render; --size, --3d, --region for frep-render; --level for frep-mass).\n"
    "  -o, --dir DIR            the folder to write (created) [required]\n"
    "      --output NAME        the merged result in DIR [image.png; mass.txt]; .exr: every AOV\n"
    "      --cells N            the number of cells [chosen: each at least --cell-seconds]\n"
    "      --cell-seconds S     the least time a cell should take [1]\n"
    "      --max-cell-memory SIZE  the most memory a cell may need (K, M, G suffixes) [1G]\n"
    "      --frames N           turntable frames [120]\n"
    "      --batch K            cells per Slurm array task [so that there are at most 64 tasks]\n"
    "      --crisp PATH         the crisp the files run [this one]\n"
    "      --no-timing          do not time a cell (the cell count then needs --cells)\n"
    "  -q, --quiet              print nothing but errors\n"
    "  -h, --help               print this help and exit\n";

enum {
    JOB_RENDER,
    JOB_FREP_RENDER,
    JOB_TURNTABLE,
    JOB_BATCH,
    JOB_MASS,
    JOB_FREP_MASS,
    JOB_FREP_MESH
};

typedef struct cell {
    char *target;      /* the file the cell makes, relative to DIR */
    const char *input; /* the input it reads (a prerequisite in the Makefile) */
    char *cmd;         /* its shell command, run in DIR */
} cell;

typedef struct job {
    int kind;
    const char *dir, *output, *crisp_path;
    char crisp[PATH_MAX], absdir[PATH_MAX];
    char **inputs; /* absolute */
    int input_count;
    char **fwd; /* options passed to the cells */
    int fwd_count;
    int cells_given, frames, batch, timing, quiet;
    double cell_seconds;
    uint64_t max_mem;
    cell *cells;
    int cell_count;
    char *merge; /* the merge command ("" when there is none) */
    double cell_time, total_time;
    uint64_t cell_mem;
    int measured; /* cell_time and cell_mem are cell 0's, run by crisp jobs itself */
    char note[512];
} job;

/* ---- strings ------------------------------------------------------------------------------ */

static char *str_printf(const char *fmt, ...) CRISP_PRINTF(1, 2);
static char *str_printf(const char *fmt, ...)
{
    va_list ap, ap2;
    va_start(ap, fmt);
    va_copy(ap2, ap);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    char *s = malloc((size_t)n + 1);
    if (s) vsnprintf(s, (size_t)n + 1, fmt, ap2);
    va_end(ap2);
    if (!s) {
        fprintf(stderr, "crisp jobs: out of memory\n");
        exit(1);
    }
    return s;
}

/* A word for sh: as it is when it holds only safe characters, else in single quotes. */
static char *sh_quote(const char *w)
{
    int safe = *w != '\0';
    for (const char *p = w; *p; p++)
        if (!strchr("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-+=./,:%@", *p))
            safe = 0;
    if (safe) return str_printf("%s", w);
    size_t n = strlen(w), k = 0;
    char *s = malloc(4 * n + 3);
    if (!s) exit(1);
    s[k++] = '\'';
    for (const char *p = w; *p; p++) {
        if (*p == '\'') {
            memcpy(s + k, "'\\''", 4);
            k += 4;
        } else {
            s[k++] = *p;
        }
    }
    s[k++] = '\'';
    s[k] = '\0';
    return s;
}

/* The forwarded options as one quoted string. */
static char *fwd_string(const job *j)
{
    char *s = str_printf("%s", "");
    for (int k = 0; k < j->fwd_count; k++) {
        char *q = sh_quote(j->fwd[k]), *t = str_printf("%s %s", s, q);
        free(q), free(s);
        s = t;
    }
    return s;
}

/* The last value of forwarded option name (NULL when absent). */
static const char *fwd_value(const job *j, const char *name)
{
    const char *v = NULL;
    size_t n = strlen(name);
    for (int k = 0; k < j->fwd_count; k++) {
        if (!strcmp(j->fwd[k], name) && k + 1 < j->fwd_count) v = j->fwd[k + 1];
        if (!strncmp(j->fwd[k], name, n) && j->fwd[k][n] == '=') v = j->fwd[k] + n + 1;
    }
    return v;
}

static int fwd_has(const job *j, const char *name)
{
    for (int k = 0; k < j->fwd_count; k++)
        if (!strcmp(j->fwd[k], name)) return 1;
    return 0;
}

/* ---- child runs --------------------------------------------------------------------------- */

/* Runs crisp with argv (argv[0] ignored) quietly; its wall time and peak resident memory. */
static int run_crisp(const job *j, char **argv, double *seconds, uint64_t *peak)
{
    double t0 = crisp_time_now();
    pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        FILE *devnull = freopen("/dev/null", "w", stdout);
        (void)devnull;
        argv[0] = (char *)j->crisp;
        execv(j->crisp, argv);
        _exit(127);
    }
    int status = 0;
    struct rusage ru;
    if (wait4(pid, &status, 0, &ru) < 0) return -1;
    *seconds = crisp_time_now() - t0;
    *peak = (uint64_t)ru.ru_maxrss * 1024u;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/* ---- the cells of each job ---------------------------------------------------------------- */

static void add_cell(job *j, char *target, char *cmd)
{
    cell *c = realloc(j->cells, (size_t)(j->cell_count + 1) * sizeof *c);
    if (!c) exit(1);
    j->cells = c;
    j->cells[j->cell_count].target = target;
    j->cells[j->cell_count].cmd = cmd;
    j->cells[j->cell_count].input = j->inputs[j->input_count > 1 ? j->cell_count : 0];
    j->cell_count++;
}

static int parse_size(const char *s, int *w, int *h)
{
    char c;
    if (sscanf(s, "%dx%d%c", w, h, &c) == 2 && *w > 0 && *h > 0) return 1;
    if (sscanf(s, "%d%c", w, &c) == 1 && *w > 0) return *h = *w, 1;
    return 0;
}

static const char *ext_of(const char *name)
{
    const char *dot = strrchr(name, '.');
    return dot && !strchr(dot, '/') ? dot : "";
}

/* Tiled images (render, frep-render): time a corner tile of the full image (a cell's overhead
 * and memory besides its pixels) and the whole image at a reduced size (the time per pixel). */
static int plan_tiles(job *j)
{
    int frep = j->kind == JOB_FREP_RENDER;
    int W = frep ? 1024 : 1280, H = frep ? 1024 : 720;
    const char *sz = fwd_value(j, "--size");
    if (sz && !parse_size(sz, &W, &H)) {
        fprintf(stderr, "crisp jobs: --size %s: expected WxH (or N)\n", sz);
        return 2;
    }
    int is3d = frep && fwd_has(j, "--3d");
    int samples = 1;
    const char *sv = fwd_value(j, "--samples");
    if (!frep) samples = sv ? atoi(sv) : !strcasecmp(ext_of(j->output), ".png") ? 4 : 1;
    /* bytes per pixel of a cell besides what the corner run holds: the raster target and image
     * (crisp_render_memory_estimate) and the cropped tile; f-rep: the renderer's image */
    double bpp = frep ? (is3d ? 40.0 : 4.0)
                      : (double)crisp_render_memory_estimate(1000, 1000, samples) / 1e6 + 56;
    double px = (double)W * H, overhead = 0, per_px = 0;
    uint64_t base_mem = 0;
    if (j->timing) {
        char out[PATH_MAX + 64], tile[64], size[64], small[64];
        const char *ext = frep ? ".png" : ext_of(j->output);
        snprintf(out, sizeof out, "%s/.timing%s", j->absdir, ext);
        snprintf(size, sizeof size, "%dx%d", W, H);
        snprintf(tile, sizeof tile, "0/%dx%d", W / 32, H / 32);
        double f = sqrt(fmin(1.0, 512.0 * 512.0 / px));
        int sw = (int)fmax(64, W * f), sh = (int)fmax(64, H * f);
        snprintf(small, sizeof small, "%dx%d", sw, sh);
        char *argv[64];
        int n = 0;
        argv[n++] = NULL;
        if (frep) argv[n++] = "frep";
        argv[n++] = "render";
        argv[n++] = j->inputs[0];
        for (int k = 0; k < j->fwd_count && n < 50; k++)
            argv[n++] = j->fwd[k];
        int base = n;
        const char *a1[] = {"--size", size, "--tile", tile, "-o", out};
        for (int k = 0; k < 6; k++)
            argv[n++] = (char *)a1[k];
        if (!frep) argv[n++] = "-q";
        argv[n] = NULL;
        double t_corner, t_small;
        uint64_t m_corner, m_small;
        int rc = run_crisp(j, argv, &t_corner, &m_corner);
        n = base;
        const char *a2[] = {"--size", small, "-o", out};
        for (int k = 0; k < 4; k++)
            argv[n++] = (char *)a2[k];
        if (!frep) argv[n++] = "-q";
        argv[n] = NULL;
        if (!rc) rc = run_crisp(j, argv, &t_small, &m_small);
        /* and a corner tile of the reduced image: the small run's own overhead */
        char tile_small[64];
        snprintf(tile_small, sizeof tile_small, "0/%dx%d", sw / 32, sh / 32);
        const char *a3[] = {"--tile", tile_small};
        n = base + 4 + !frep;
        argv[n++] = (char *)a3[0], argv[n++] = (char *)a3[1];
        argv[n] = NULL;
        double t_small0 = 0;
        uint64_t m_small0;
        if (!rc) rc = run_crisp(j, argv, &t_small0, &m_small0);
        char cellf[PATH_MAX + 80];
        snprintf(cellf, sizeof cellf, "%s.cell", out);
        remove(out), remove(cellf);
        if (rc) {
            fprintf(stderr,
                    "crisp jobs: the timing run of a cell failed (exit %d): try the cell command "
                    "by hand: %s%s render %s ...\n",
                    rc, j->crisp, frep ? " frep" : "", j->inputs[0]);
            return 1;
        }
        overhead = t_corner;
        per_px = fmax(t_small - t_small0, 0.02 * t_small) / ((double)sw * sh);
        base_mem = m_corner;
    }
    int n = j->cells_given;
    double work = per_px * px;
    if (!n) {
        if (!j->timing) {
            fprintf(stderr, "crisp jobs: --no-timing needs --cells N\n");
            return 2;
        }
        /* as many cells as keep each at least cell_seconds long (the overhead counts) with the
         * overhead under 10% of it, then at least as many as keep each under the memory limit */
        double per_cell = fmax(j->cell_seconds - overhead, 9 * overhead);
        n = (int)fmax(1, floor(work / fmax(per_cell, 1e-3)));
        double room = (double)j->max_mem - (double)base_mem;
        if (room <= 0) {
            fprintf(stderr,
                    "crisp jobs: a cell's fixed part alone needs %.0f MB, more than "
                    "--max-cell-memory %.0f MB\n",
                    base_mem / 1e6, j->max_mem / 1e6);
            return 1;
        }
        /* pixels per cell, with a 64-pixel ring drawn around each tile */
        while (n < 1048576) {
            double side = sqrt(px / n);
            if ((side + 128) * (side + 128) * bpp <= room) break;
            n = n < 4 ? n + 1 : (int)(n * 1.25);
        }
    }
    /* a grid of near-square tiles of at least 32 pixels */
    double side = sqrt(px / n);
    int cols = (int)fmax(1, floor(W / side + 0.5)), rows = (int)fmax(1, floor(H / side + 0.5));
    while ((long)cols * rows < n) {
        if (W / (double)cols > H / (double)rows)
            cols++;
        else
            rows++;
    }
    cols = cols > W / 32 ? W / 32 : cols, rows = rows > H / 32 ? H / 32 : rows;
    if (cols < 1 || rows < 1) {
        fprintf(stderr, "crisp jobs: the image %dx%d is too small to split\n", W, H);
        return 2;
    }
    double tw = (double)W / cols, th = (double)H / rows;
    j->cell_time = overhead + per_px * tw * th;
    j->total_time = overhead + work;
    j->cell_mem = base_mem + (uint64_t)((fmin(tw + 128, W) * fmin(th + 128, H)) * bpp);
    snprintf(j->note, sizeof j->note, "%dx%d tiles of about %.0fx%.0f pixels of %dx%d", cols, rows,
             tw, th, W, H);
    char *fwd = fwd_string(j), *in = sh_quote(j->inputs[0]);
    const char *ext = ext_of(j->output);
    int exr = !strcasecmp(ext, ".exr");
    char *tiles = str_printf("%s", "");
    for (int i = 0; i < cols * rows; i++) {
        char *target = str_printf("cells/t%05d%s", i, ext);
        char *cmd;
        if (frep)
            cmd = str_printf("%s frep render %s%s --tile %d/%dx%d %s %s", j->crisp, in, fwd, i,
                             cols, rows, exr ? "--depth-out" : "-o", target);
        else
            cmd = str_printf("%s render %s%s --tile %d/%dx%d -o %s -q", j->crisp, in, fwd, i, cols,
                             rows, target);
        char *t = str_printf("%s %s", tiles, target);
        free(tiles);
        tiles = t;
        add_cell(j, target, cmd);
    }
    j->merge = str_printf("%s merge -q -o .tmp-%s%s && mv .tmp-%s %s", j->crisp, j->output, tiles,
                          j->output, j->output);
    free(tiles), free(fwd), free(in);
    return 0;
}

/* One image per frame of a camera orbiting the default view's target about +Z, at the largest
 * of the distances that fit each frame (so the model stays framed and the distance constant). */
static int plan_turntable(job *j)
{
    crisp_document *doc = NULL;
    if (crisp_document_open(j->inputs[0], NULL, &doc)) {
        fprintf(stderr, "crisp jobs: %s\n", crisp_error_message());
        return 1;
    }
    int W = 1280, H = 720;
    const char *sz = fwd_value(j, "--size");
    if (sz && !parse_size(sz, &W, &H)) {
        fprintf(stderr, "crisp jobs: --size %s: expected WxH\n", sz);
        crisp_document_destroy(doc);
        return 2;
    }
    double fov = 30;
    const char *fv = fwd_value(j, "--fov");
    if (fv) fov = atof(fv);
    double iso[3], up[3], z[3] = {0, 0, 1};
    crisp_view_direction(CRISP_VIEW_ISO, iso, up);
    double target[3], dist = 0;
    int N = j->frames;
    crisp_camera c0;
    crisp_camera_fit_desc fd = {.width = W, .height = H, .fov_deg = fov};
    for (int k = 0; k < N; k++) {
        double a = 2 * M_PI * k / N, d[3] = {iso[0] * cos(a) - iso[1] * sin(a),
                                             iso[0] * sin(a) + iso[1] * cos(a), iso[2]};
        crisp_camera c;
        if (crisp_camera_fit_points(doc->points, doc->point_count, d, z, &fd, &c)) {
            fprintf(stderr, "crisp jobs: %s\n", crisp_error_message());
            crisp_document_destroy(doc);
            return 1;
        }
        double e[3] = {c.eye[0] - c.target[0], c.eye[1] - c.target[1], c.eye[2] - c.target[2]};
        dist = fmax(dist, sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]));
        if (k == 0) c0 = c;
    }
    for (int a = 0; a < 3; a++)
        target[a] = 0.5 * (doc->box[a] + doc->box[3 + a]);
    (void)c0;
    crisp_document_destroy(doc);
    char *fwd = fwd_string(j), *in = sh_quote(j->inputs[0]);
    const char *ext = ext_of(j->output);
    for (int k = 0; k < N; k++) {
        double a = 2 * M_PI * k / N;
        double e[3] = {target[0] + dist * (iso[0] * cos(a) - iso[1] * sin(a)),
                       target[1] + dist * (iso[0] * sin(a) + iso[1] * cos(a)),
                       target[2] + dist * iso[2]};
        char *target_f = str_printf("frames/f%04d%s", k, ext);
        char *cmd = str_printf("%s render %s%s --eye %.9g,%.9g,%.9g --target %.9g,%.9g,%.9g --up "
                               "0,0,1 -o %s -q",
                               j->crisp, in, fwd, e[0], e[1], e[2], target[0], target[1], target[2],
                               target_f);
        add_cell(j, target_f, cmd);
    }
    free(fwd), free(in);
    j->merge = str_printf("%s", "");
    snprintf(j->note, sizeof j->note, "%d frames of %dx%d orbiting about +Z", N, W, H);
    return 0;
}

static int plan_batch(job *j)
{
    char *fwd = fwd_string(j);
    const char *ext = ext_of(j->output);
    for (int k = 0; k < j->input_count; k++) {
        const char *slash = strrchr(j->inputs[k], '/');
        const char *base = slash ? slash + 1 : j->inputs[k];
        const char *dot = strrchr(base, '.');
        int len = dot && dot != base ? (int)(dot - base) : (int)strlen(base);
        char *target = str_printf("images/%05d-%.*s%s", k, len, base, ext);
        for (char *p = target + 7; *p; p++)
            if (!strchr("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.", *p))
                *p = '_';
        char *in = sh_quote(j->inputs[k]);
        add_cell(j, target, str_printf("%s render %s%s -o %s -q", j->crisp, in, fwd, target));
        free(in);
    }
    free(fwd);
    j->merge = str_printf("%s", "");
    snprintf(j->note, sizeof j->note, "%d files, one image each", j->input_count);
    return 0;
}

/* Mass and mesh jobs: N cells of the cell command, merged by crisp merge. */
static int plan_mass(job *j)
{
    int frep = j->kind != JOB_MASS, mesh = j->kind == JOB_FREP_MESH;
    int n = j->cells_given ? j->cells_given : frep ? 8 : 4;
    if (frep && (n & (n - 1) || __builtin_ctz((unsigned)n) % 3)) {
        fprintf(stderr,
                "crisp jobs: frep-mass --cells %d: expected a power of 8 (octants of the "
                "octree: 8, 64, 512, ...)\n",
                n);
        return 2;
    }
    char *fwd = fwd_string(j), *in = sh_quote(j->inputs[0]);
    char *list = str_printf("%s", "");
    for (int i = 0; i < n; i++) {
        char *target = str_printf(mesh ? "cells/m%05d.cmesh" : "cells/m%05d.cell", i);
        add_cell(j, target,
                 str_printf("%s %s %s%s --cell %d/%d -o %s", j->crisp,
                            mesh   ? "frep mesh"
                            : frep ? "frep mass"
                                   : "mass",
                            in, fwd, i, n, target));
        char *t = str_printf("%s %s", list, target);
        free(list);
        list = t;
    }
    j->merge = str_printf("%s merge -o .tmp-%s%s && mv .tmp-%s %s", j->crisp, j->output, list,
                          j->output, j->output);
    free(list), free(fwd), free(in);
    snprintf(j->note, sizeof j->note, "%d %s cells", n, frep ? "octree" : "face");
    return 0;
}

/* Jobs whose cells are whole frames, files or mass/mesh cells: cell 0 is run now (its file stays:
 * a finished cell) and its time and peak memory stand for every cell's. */
static int measure_first(job *j)
{
    const cell *c = &j->cells[0];
    const char *slash = strrchr(c->target, '/');
    char sub[PATH_MAX + 64];
    snprintf(sub, sizeof sub, "%s/%.*s", j->absdir, (int)(slash - c->target), c->target);
    mkdir(sub, 0777);
    char *cmd = str_printf("exec %s", c->cmd);
    double t0 = crisp_time_now();
    pid_t pid = fork();
    if (pid == 0) {
        FILE *devnull = freopen("/dev/null", "w", stdout);
        (void)devnull;
        if (chdir(j->absdir)) _exit(126);
        execl("/bin/sh", "sh", "-c", cmd, (char *)NULL);
        _exit(127);
    }
    free(cmd);
    int status = 0;
    struct rusage ru;
    if (pid < 0 || wait4(pid, &status, 0, &ru) < 0) return 1;
    if (!WIFEXITED(status) || WEXITSTATUS(status)) {
        fprintf(stderr, "crisp jobs: cell 0 failed (exit %d): %s\n",
                WIFEXITED(status) ? WEXITSTATUS(status) : -1, j->cells[0].cmd);
        return 1;
    }
    j->cell_time = crisp_time_now() - t0;
    j->cell_mem = (uint64_t)ru.ru_maxrss * 1024u;
    j->total_time = j->cell_time * j->cell_count;
    j->measured = 1;
    return 0;
}

/* ---- files -------------------------------------------------------------------------------- */

/* $ doubled for make; the crisp path at the start of a command is $(CRISP) (make CRISP=... runs
 * another crisp, or crisp under a wrapper such as /usr/bin/time). */
static void put_make(FILE *f, const char *s, const char *crisp)
{
    size_t n = strlen(crisp);
    if (!strncmp(s, crisp, n) && s[n] == ' ') fputs("$(CRISP)", f), s += n;
    for (; *s; s++) {
        if (*s == '$') fputc('$', f);
        fputc(*s, f);
    }
}

static int write_files(const job *j, const char *cmdline)
{
    char path[PATH_MAX + 32];
    const char *final = j->merge[0] ? j->output : "all-cells";
    /* Makefile */
    snprintf(path, sizeof path, "%s/Makefile", j->absdir);
    FILE *f = fopen(path, "w");
    if (!f) goto fail;
    fprintf(f,
            "# Written by: %s\n# %d cells (%s); make -j N -C %s runs them and %s. A cell's file "
            "appears only\n# when the cell is complete, so running make again after an "
            "interruption redoes only\n# the missing cells.\n.DELETE_ON_ERROR:\n",
            cmdline, j->cell_count, j->note, j->absdir,
            j->merge[0] ? "then the merge" : "that is all");
    fprintf(f, "CRISP := %s\nCELLS :=", j->crisp);
    for (int k = 0; k < j->cell_count; k++)
        fprintf(f, " \\\n  %s", j->cells[k].target);
    fprintf(f, "\n\n%s: $(CELLS)\n", final);
    if (j->merge[0]) {
        fputc('\t', f);
        put_make(f, j->merge, j->crisp);
        fputc('\n', f);
    } else {
        fprintf(f, "\t@echo %d cells done\n.PHONY: %s\n", j->cell_count, final);
    }
    fprintf(f, "\ncells:\n\tmkdir -p $@\n\n");
    for (int k = 0; k < j->cell_count; k++) {
        const char *t = j->cells[k].target;
        const char *slash = strrchr(t, '/');
        fprintf(f, "%s: ", t);
        for (const char *p = j->cells[k].input; *p; p++) /* a make word: escape its spaces */
            fprintf(f, "%s%c", *p == ' ' || *p == '#' || *p == ':' ? "\\" : "", *p);
        fprintf(f, " | %.*s\n\t", (int)(slash - t), t);
        put_make(f, j->cells[k].cmd, j->crisp);
        fprintf(f, "\n");
    }
    /* the folders of the cells */
    const char *folders[] = {"frames", "images"};
    for (int k = 0; k < 2; k++)
        if (!strncmp(j->cells[0].target, folders[k], strlen(folders[k])))
            fprintf(f, "%s:\n\tmkdir -p $@\n", folders[k]);
    if (fclose(f)) goto fail;
    /* jobs.txt: one line per cell for GNU parallel (run anywhere: each line enters DIR first) */
    snprintf(path, sizeof path, "%s/jobs.txt", j->absdir);
    if (!(f = fopen(path, "w"))) goto fail;
    char *qd = sh_quote(j->absdir);
    for (int k = 0; k < j->cell_count; k++) {
        const char *t = j->cells[k].target;
        const char *slash = strrchr(t, '/');
        fprintf(f, "cd %s && mkdir -p %.*s && { test -e %s || %s; }\n", qd, (int)(slash - t), t, t,
                j->cells[k].cmd);
    }
    if (fclose(f)) goto fail;
    /* merge.sh */
    snprintf(path, sizeof path, "%s/merge.sh", j->absdir);
    if (!(f = fopen(path, "w"))) goto fail;
    fprintf(
        f,
        "#!/bin/sh\n# The merge of the cells of %s (after they are all done).\nset -e\ncd %s\n%s\n",
        j->absdir, qd, j->merge[0] ? j->merge : "echo nothing to merge");
    if (fclose(f)) goto fail;
    chmod(path, 0755);
    /* slurm.sh */
    int batch = j->batch ? j->batch : (j->cell_count + 63) / 64;
    if (batch < 1) batch = 1;
    int tasks = (j->cell_count + batch - 1) / batch;
    int cpus = batch < 2 ? 1 : 2;
    double hours = fmax(0.25, 3 * j->cell_time * batch / cpus / 3600 + 0.1);
    int hh = (int)hours, mm = (int)((hours - hh) * 60);
    uint64_t mem = j->cell_mem ? j->cell_mem : (1ull << 30);
    snprintf(path, sizeof path, "%s/slurm.sh", j->absdir);
    if (!(f = fopen(path, "w"))) goto fail;
    fprintf(
        f,
        "#!/bin/bash\n"
        "# %d cells of %s as a Slurm array of %d tasks of %d cells each; each task runs its\n"
        "# cells with GNU parallel on the CPUs of its allocation. Submit, then merge after:\n"
        "#   id=$(sbatch --parsable %s/slurm.sh) && sbatch --dependency=afterok:$id %s/merge.sh\n"
        "# Resubmitting redoes only missing cells (a cell's file appears when it is complete).\n"
        "#SBATCH --job-name=crisp-cells\n"
        "#SBATCH --array=0-%d\n"
        "#SBATCH --cpus-per-task=%d\n"
        "#SBATCH --mem=%lluM\n"
        "#SBATCH --time=%02d:%02d:00\n"
        "#SBATCH --output=%s/slurm-%%A_%%a.log\n"
        "set -eu\n"
        "cd %s\n"
        "first=$(( ${SLURM_ARRAY_TASK_ID:-0} * %d + 1 ))\n"
        "sed -n \"${first},$(( first + %d - 1 ))p\" jobs.txt |\n"
        "  parallel -j \"${SLURM_CPUS_PER_TASK:-1}\" --halt now,fail=1 \\\n"
        "    --joblog \"joblog.${SLURM_ARRAY_TASK_ID:-0}\" --resume\n",
        j->cell_count, j->absdir, tasks, batch, j->absdir, j->absdir, tasks - 1, cpus,
        (unsigned long long)((mem * (uint64_t)cpus) / 1048576 + 256), hh, mm, j->absdir, qd, batch,
        batch);
    if (fclose(f)) goto fail;
    chmod(path, 0755);
    free(qd);
    return 0;
fail:
    fprintf(stderr, "crisp jobs: %s: cannot write: %s\n", path, strerror(errno));
    return 1;
}

/* ---- command ------------------------------------------------------------------------------ */

/* Options of the cell commands that take a value (so that the value is not taken for an input). */
static int takes_value(const char *o)
{
    static const char *const v[] = {
        "--size", "--view",    "--eye",     "--target",   "--up",         "--fov",       "--near",
        "--far",  "--samples", "--backend", "--threads",  "--max-memory", "--depth",     "--region",
        "-e",     "--level",   "--seed",    "--accuracy", "--time",       "--resolution"};
    for (size_t k = 0; k < sizeof v / sizeof v[0]; k++)
        if (!strcmp(o, v[k])) return 1;
    return 0;
}

int crisp_cmd_jobs(int argc, char **argv)
{
    cli_cmd = "jobs";
    if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        fputs(usage_text, argc < 2 ? stderr : stdout);
        return argc < 2 ? 2 : 0;
    }
    static const char *const kinds[] = {"render", "frep-render", "turntable", "batch",
                                        "mass",   "frep-mass",   "frep-mesh"};
    job j = {.kind = -1, .cell_seconds = 1, .max_mem = 1ull << 30, .frames = 120, .timing = 1};
    for (int k = 0; k < 7; k++)
        if (!strcmp(argv[1], kinds[k])) j.kind = k;
    if (j.kind < 0) {
        fprintf(stderr,
                "crisp jobs: unknown job '%s' (expected render, frep-render, turntable, batch, "
                "mass, frep-mass or frep-mesh)\n",
                argv[1]);
        return 2;
    }
    j.inputs = calloc((size_t)argc, sizeof *j.inputs);
    j.fwd = calloc((size_t)argc, sizeof *j.fwd);
    if (!j.inputs || !j.fwd) return 1;
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        int need = !strcmp(a, "-o") || !strcmp(a, "--dir") || !strcmp(a, "--output") ||
                   !strcmp(a, "--cells") || !strcmp(a, "--cell-seconds") ||
                   !strcmp(a, "--max-cell-memory") || !strcmp(a, "--frames") ||
                   !strcmp(a, "--batch") || !strcmp(a, "--crisp");
        if (need && !v) {
            fprintf(stderr, "crisp jobs: option %s needs a value\n", a);
            return 2;
        }
        if (!strcmp(a, "-o") || !strcmp(a, "--dir")) {
            j.dir = v, i++;
        } else if (!strcmp(a, "--output")) {
            j.output = v, i++;
        } else if (!strcmp(a, "--cells")) {
            if (!cli_int(a, v, 1, 1048576, &j.cells_given)) return 2;
            i++;
        } else if (!strcmp(a, "--cell-seconds")) {
            if (!cli_double(a, v, 0, 1e6, 1, 0, &j.cell_seconds)) return 2;
            i++;
        } else if (!strcmp(a, "--max-cell-memory")) {
            if (!cli_bytes(a, v, &j.max_mem)) return 2;
            i++;
        } else if (!strcmp(a, "--frames")) {
            if (!cli_int(a, v, 1, 1000000, &j.frames)) return 2;
            i++;
        } else if (!strcmp(a, "--batch")) {
            if (!cli_int(a, v, 1, 1000000, &j.batch)) return 2;
            i++;
        } else if (!strcmp(a, "--crisp")) {
            j.crisp_path = v, i++;
        } else if (!strcmp(a, "--no-timing")) {
            j.timing = 0;
        } else if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            j.quiet = 1;
        } else if (!strcmp(a, "--tile") || !strcmp(a, "--cell") || !strcmp(a, "--aov") ||
                   !strcmp(a, "--depth-out") || !strcmp(a, "--repeat") ||
                   (j.kind == JOB_TURNTABLE && (!strcmp(a, "--eye") || !strcmp(a, "--view") ||
                                                !strcmp(a, "--target") || !strcmp(a, "--up")))) {
            fprintf(stderr, "crisp jobs: %s is chosen by crisp jobs itself; leave it out\n", a);
            return 2;
        } else if (a[0] == '-' && a[1]) {
            j.fwd[j.fwd_count++] = argv[i];
            if (takes_value(a) && v) j.fwd[j.fwd_count++] = argv[++i];
        } else {
            char *abs = realpath(a, NULL);
            if (!abs) {
                fprintf(stderr, "crisp jobs: %s: %s\n", a, strerror(errno));
                return 1;
            }
            j.inputs[j.input_count++] = abs;
        }
    }
    if (!j.dir) {
        fprintf(stderr, "crisp jobs: no folder given (-o DIR)\n");
        return 2;
    }
    if (!j.input_count || (j.kind != JOB_BATCH && j.input_count > 1)) {
        fprintf(stderr, "crisp jobs: %s takes %s\n", kinds[j.kind],
                j.kind == JOB_BATCH ? "one or more files" : "one input file");
        return 2;
    }
    int mass = j.kind == JOB_MASS || j.kind == JOB_FREP_MASS, mesh = j.kind == JOB_FREP_MESH;
    if (!j.output) j.output = mass ? "mass.txt" : mesh ? "mesh.stl" : "image.png";
    if (strchr(j.output, '/') || j.output[0] == '.') {
        fprintf(stderr, "crisp jobs: --output %s: expected a plain file name (it goes in DIR)\n",
                j.output);
        return 2;
    }
    if (!mass && !mesh && crisp_image_format_of(j.output) == CRISP_IMAGE_UNKNOWN) {
        fprintf(stderr, "crisp jobs: --output %s: expected a name ending in .png or .exr\n",
                j.output);
        return 2;
    }
    if (mkdir(j.dir, 0777) && errno != EEXIST) {
        fprintf(stderr, "crisp jobs: %s: cannot create: %s\n", j.dir, strerror(errno));
        return 1;
    }
    if (!realpath(j.dir, j.absdir)) {
        fprintf(stderr, "crisp jobs: %s: %s\n", j.dir, strerror(errno));
        return 1;
    }
    if (j.crisp_path) {
        if (!realpath(j.crisp_path, j.crisp)) {
            fprintf(stderr, "crisp jobs: --crisp %s: %s\n", j.crisp_path, strerror(errno));
            return 1;
        }
    } else {
        ssize_t n = readlink("/proc/self/exe", j.crisp, sizeof j.crisp - 1);
        if (n <= 0) {
            fprintf(stderr, "crisp jobs: cannot find this crisp's path (give --crisp PATH)\n");
            return 1;
        }
        j.crisp[n] = '\0';
    }
    int rc;
    switch (j.kind) {
    case JOB_RENDER:
    case JOB_FREP_RENDER:
        rc = plan_tiles(&j);
        break;
    case JOB_TURNTABLE:
        rc = plan_turntable(&j);
        break;
    case JOB_BATCH:
        rc = plan_batch(&j);
        break;
    default:
        rc = plan_mass(&j);
    }
    char *cmdline = str_printf("crisp jobs");
    for (int i = 1; i < argc; i++) {
        char *q = sh_quote(argv[i]), *t = str_printf("%s %s", cmdline, q);
        free(q), free(cmdline);
        cmdline = t;
    }
    if (!rc && j.timing && j.kind != JOB_RENDER && j.kind != JOB_FREP_RENDER)
        rc = measure_first(&j);
    if (!rc) rc = write_files(&j, cmdline);
    if (!rc && !j.quiet) {
        printf("%s: %d cells (%s)\n", j.absdir, j.cell_count, j.note);
        char mb[32];
        cli_format_bytes(j.cell_mem, mb, sizeof mb);
        if (j.measured)
            printf("cell 0 (run now; its file is kept): %.2f s and %s; all %d cells about %.1f s "
                   "of work\n",
                   j.cell_time, mb, j.cell_count, j.total_time);
        else if (j.cell_time > 0)
            printf("predicted per cell: %.2f s and %s (one process each); the whole image in "
                   "one process: %.1f s\n",
                   j.cell_time, mb, j.total_time);
        printf("run:  make -j2 -C %s\n", j.absdir);
        printf("  or: parallel -j2 --joblog %s/joblog --resume < %s/jobs.txt && sh %s/merge.sh\n",
               j.absdir, j.absdir, j.absdir);
        printf("  or: id=$(sbatch --parsable %s/slurm.sh) && sbatch --dependency=afterok:$id "
               "%s/merge.sh\n",
               j.absdir, j.absdir);
    }
    free(cmdline);
    for (int k = 0; k < j.cell_count; k++)
        free(j.cells[k].target), free(j.cells[k].cmd);
    free(j.cells);
    free(j.merge);
    for (int k = 0; k < j.input_count; k++)
        free(j.inputs[k]);
    free(j.inputs);
    free(j.fwd);
    return rc;
}
