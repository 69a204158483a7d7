/* Cells of a split job (include/crisp/cells.h, issue 15): cell specs, the tile grid of an image,
 * the header every cell file carries (a small text file: which job, settings and cell it is and
 * the size and FNV-1a 64 hash of its data), written through a temporary file renamed into place
 * so that a killed run leaves no half cell. */
#include "crisp/cells.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

crisp_status crisp_cell_parse(const char *text, crisp_cell_spec *dest)
{
    crisp_cell_spec c = {0};
    const char *p = text ? text : "";
    char *end;
    errno = 0;
    long i = strtol(p, &end, 10), n = 0, cols = 0, rows = 0;
    int ok = end != p && *end == '/' && i >= 0 && (p[0] >= '0' && p[0] <= '9');
    if (ok) {
        p = end + 1;
        n = strtol(p, &end, 10);
        ok = end != p && (p[0] >= '0' && p[0] <= '9');
        if (ok && (*end == 'x' || *end == 'X')) {
            cols = n;
            p = end + 1;
            rows = strtol(p, &end, 10);
            ok = end != p && (p[0] >= '0' && p[0] <= '9') && cols >= 1 && rows >= 1 &&
                 cols <= 65536 && rows <= 65536;
            n = cols * rows;
        }
        ok = ok && !*end && !errno && n >= 1 && n <= 1048576 && i < n;
    }
    if (!ok)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "cell '%s': expected I/N (0 <= I < N <= 1048576) or I/CxR", text);
    c.index = (int)i, c.count = (int)n, c.cols = (int)cols, c.rows = (int)rows;
    *dest = c;
    return CRISP_OK;
}

crisp_status crisp_tile_grid(int width, int height, crisp_cell_spec *spec)
{
    enum { G = 32 };
    int n = spec->count;
    if (spec->cols && spec->rows) {
        if (width / spec->cols < G || height / spec->rows < G)
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "a %dx%d image cannot be split in %dx%d tiles of at least %d "
                               "pixels a side",
                               width, height, spec->cols, spec->rows, G);
        return CRISP_OK;
    }
    int best_c = 0;
    double best = INFINITY;
    for (int c = 1; c <= n; c++) {
        if (n % c) continue;
        int r = n / c;
        if (width / c < G || height / r < G) continue;
        double score = fabs(log(((double)width / c) / ((double)height / r)));
        if (score <= best + 1e-12) best = score, best_c = c;
    }
    if (!best_c)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "a %dx%d image cannot be split in %d tiles of at least %d pixels a side "
                           "(give fewer tiles, or a grid as I/CxR)",
                           width, height, n, G);
    spec->cols = best_c, spec->rows = n / best_c;
    return CRISP_OK;
}

/* Edge k of n along a side of `size` pixels, on the 32-pixel grid. */
static int edge(int size, int n, int k)
{
    if (k >= n) return size;
    return (int)(32 * floor((double)k * size / (32.0 * n) + 0.5));
}

void crisp_tile_rect(int width, int height, const crisp_cell_spec *spec, int dest[4])
{
    int cx = spec->index % spec->cols, cy = spec->index / spec->cols;
    int x0 = edge(width, spec->cols, cx), x1 = edge(width, spec->cols, cx + 1);
    int y0 = edge(height, spec->rows, cy), y1 = edge(height, spec->rows, cy + 1);
    dest[0] = x0, dest[1] = y0, dest[2] = x1 - x0, dest[3] = y1 - y0;
}

/* ---- hashes ------------------------------------------------------------------------------- */

uint64_t crisp_hash_bytes(uint64_t h, const void *data, size_t size)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < size; i++) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

crisp_status crisp_file_hash(const char *path, uint64_t *size, uint64_t *hash)
{
    FILE *f = fopen(path, "rb");
    if (!f) return crisp_error(CRISP_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    unsigned char buf[1 << 16];
    uint64_t h = CRISP_HASH_SEED, n = 0;
    size_t got;
    while ((got = fread(buf, 1, sizeof buf, f)) > 0) {
        h = crisp_hash_bytes(h, buf, got);
        n += got;
    }
    int err = ferror(f);
    fclose(f);
    if (err) return crisp_error(CRISP_ERR_IO, "%s: read error", path);
    *size = n;
    *hash = h;
    return CRISP_OK;
}

/* ---- headers ------------------------------------------------------------------------------ */

/* Copies src into dest[cap], cut at cap - 1 bytes. */
static void copy_str(char *dest, size_t cap, const char *src)
{
    size_t n = strlen(src);
    if (n >= cap) n = cap - 1;
    memcpy(dest, src, n);
    dest[n] = '\0';
}

double crisp_cell_header_sum(const crisp_cell_header *h, const char *name)
{
    for (int k = 0; k < h->sum_count; k++)
        if (!strcmp(h->sum_name[k], name)) return h->sum[k];
    return NAN;
}

void crisp_cell_header_add_sum(crisp_cell_header *h, const char *name, double value)
{
    if (h->sum_count >= CRISP_CELL_MAX_SUMS) return;
    snprintf(h->sum_name[h->sum_count], sizeof h->sum_name[0], "%s", name);
    h->sum[h->sum_count++] = value;
}

crisp_status crisp_cell_header_write(const char *path, const crisp_cell_header *h)
{
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp%ld", path, (long)getpid()) >= (int)sizeof tmp)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: path too long", path);
    FILE *f = fopen(tmp, "w");
    if (!f) return crisp_error(CRISP_ERR_IO, "%s: cannot write: %s", tmp, strerror(errno));
    fprintf(f, "crisp-cell 1\nkind %s\njob %016llx\nsettings %s\ncell %d %d %d %d\n", h->kind,
            (unsigned long long)h->job, h->settings, h->cell.index, h->cell.count, h->cell.cols,
            h->cell.rows);
    fprintf(f, "rect %d %d %d %d %d %d\n", h->rect[0], h->rect[1], h->rect[2], h->rect[3],
            h->rect[4], h->rect[5]);
    if (h->data[0])
        fprintf(f, "data %llu %016llx %s\n", (unsigned long long)h->data_size,
                (unsigned long long)h->data_hash, h->data);
    for (int k = 0; k < h->sum_count; k++)
        fprintf(f, "sum %s %.17g\n", h->sum_name[k], h->sum[k]);
    fprintf(f, "end\n");
    int bad = ferror(f);
    if (fclose(f) || bad) {
        remove(tmp);
        return crisp_error(CRISP_ERR_IO, "%s: cannot write", tmp);
    }
    if (rename(tmp, path)) {
        crisp_status s = crisp_error(CRISP_ERR_IO, "%s: cannot rename %s into place: %s", path, tmp,
                                     strerror(errno));
        remove(tmp);
        return s;
    }
    return CRISP_OK;
}

crisp_status crisp_cell_header_read(const char *path, crisp_cell_header *h)
{
    memset(h, 0, sizeof *h);
    FILE *f = fopen(path, "r");
    if (!f) return crisp_error(CRISP_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    char line[4096];
    int ln = 0, ended = 0;
    crisp_status s = CRISP_OK;
    while (!s && fgets(line, sizeof line, f)) {
        ln++;
        size_t len = strlen(line);
        if (len && line[len - 1] == '\n') line[--len] = '\0';
        if (ln == 1) {
            if (strcmp(line, "crisp-cell 1"))
                s = crisp_error(CRISP_ERR_PARSE,
                                "%s:1: not a crisp cell header (expected "
                                "'crisp-cell 1')",
                                path);
            continue;
        }
        unsigned long long a = 0, b = 0;
        int n = 0;
        if (!strncmp(line, "kind ", 5)) {
            copy_str(h->kind, sizeof h->kind, line + 5);
        } else if (sscanf(line, "job %llx", &a) == 1) {
            h->job = a;
        } else if (!strncmp(line, "settings ", 9)) {
            copy_str(h->settings, sizeof h->settings, line + 9);
        } else if (!strncmp(line, "cell ", 5)) {
            if (sscanf(line + 5, "%d %d %d %d", &h->cell.index, &h->cell.count, &h->cell.cols,
                       &h->cell.rows) != 4 ||
                h->cell.count < 1 || h->cell.index < 0 || h->cell.index >= h->cell.count)
                s = crisp_error(CRISP_ERR_PARSE, "%s:%d: bad cell line '%s'", path, ln, line);
        } else if (!strncmp(line, "rect ", 5)) {
            if (sscanf(line + 5, "%d %d %d %d %d %d", &h->rect[0], &h->rect[1], &h->rect[2],
                       &h->rect[3], &h->rect[4], &h->rect[5]) != 6)
                s = crisp_error(CRISP_ERR_PARSE, "%s:%d: bad rect line '%s'", path, ln, line);
        } else if (sscanf(line, "data %llu %llx %n", &a, &b, &n) == 2 && n > 0) {
            h->data_size = a, h->data_hash = b;
            copy_str(h->data, sizeof h->data, line + n);
        } else if (!strncmp(line, "sum ", 4)) {
            char name[32];
            double v;
            if (sscanf(line + 4, "%31s %lf", name, &v) != 2)
                s = crisp_error(CRISP_ERR_PARSE, "%s:%d: bad sum line '%s'", path, ln, line);
            else
                crisp_cell_header_add_sum(h, name, v);
        } else if (!strcmp(line, "end")) {
            ended = 1;
            break;
        } else {
            s = crisp_error(CRISP_ERR_PARSE, "%s:%d: unknown line '%s'", path, ln, line);
        }
    }
    fclose(f);
    if (!s && !ln) s = crisp_error(CRISP_ERR_PARSE, "%s: empty cell header", path);
    if (!s && !ended)
        s = crisp_error(CRISP_ERR_PARSE, "%s: truncated cell header (no 'end' line)", path);
    if (!s && !h->kind[0]) s = crisp_error(CRISP_ERR_PARSE, "%s: no 'kind' line", path);
    if (!s && !h->cell.count) s = crisp_error(CRISP_ERR_PARSE, "%s: no 'cell' line", path);
    return s;
}

crisp_status crisp_cell_job_id(const char *input, const char *settings, uint64_t *dest)
{
    uint64_t size, h;
    crisp_status s = crisp_file_hash(input, &size, &h);
    if (s) return s;
    *dest = crisp_hash_bytes(h, settings, strlen(settings));
    return CRISP_OK;
}

crisp_status crisp_cell_commit(const char *path, crisp_cell_header *h, crisp_cell_write_fn write,
                               void *ctx)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    int dir = (int)(base - path);
    char tmp[4096], head[4096];
    if (!*base || strlen(base) >= sizeof h->data ||
        snprintf(tmp, sizeof tmp, "%.*s.tmp-%ld-%s", dir, path, (long)getpid(), base) >=
            (int)sizeof tmp ||
        snprintf(head, sizeof head, "%s.cell", path) >= (int)sizeof head)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: bad or too long cell file name", path);
    crisp_status s = write(ctx, tmp);
    if (!s) s = crisp_file_hash(tmp, &h->data_size, &h->data_hash);
    if (!s) {
        copy_str(h->data, sizeof h->data, base);
        s = crisp_cell_header_write(head, h);
    }
    if (!s && rename(tmp, path))
        s = crisp_error(CRISP_ERR_IO, "%s: cannot rename %s into place: %s", path, tmp,
                        strerror(errno));
    if (s) remove(tmp);
    return s;
}
