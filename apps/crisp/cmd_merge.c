/* crisp merge: assemble the cells of a split job (issue 15, include/crisp/cells.h): image tiles
 * of crisp render / crisp frep render --tile into the whole image (PNG or EXR, every channel), and
 * mass cells into the whole part's properties. Refuses a missing, corrupt or foreign cell and an
 * incomplete set, naming the cell. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "crisp/cells.h"
#include "crisp/frep_mesh.h"
#include "crisp/mass.h"

const char crisp_cmd_merge_help[] =
    "merge -o OUT CELLS...        assemble the cells of a split job (tiles, mesh, mass cells)";

static const char usage_text[] =
    "usage: crisp merge -o OUT [-q] CELLS...\n"
    "  Assembles the cells written by 'crisp render --tile', 'crisp frep render --tile',\n"
    "  'crisp frep mesh --cell', 'crisp mass --cell' and 'crisp frep mass --cell' (crisp jobs\n"
    "  writes the commands). Mesh cells (CELL.cmesh): OUT is the welded .stl, .obj or .ply.\n"
    "  Image tiles: CELLS are the tile images (PNG or EXR; each with its header TILE.cell) and\n"
    "  OUT the whole image in the same format, every channel bit for bit. Mass cells: CELLS are\n"
    "  the cell files and OUT a text file of the merged properties ('-' for stdout).\n"
    "  Every cell of the job must be given exactly once; a missing, truncated or changed cell,\n"
    "  a cell of another job or other settings is refused with a message naming it.\n"
    "  -o, --output FILE   the merged result (required)\n"
    "  -q, --quiet         do not print the 'merged N cells into OUT' line\n"
    "  -h, --help          print this help and exit\n"
    "  Exit status: 0 success, 1 bad or missing cells, 2 bad usage.\n";

int crisp__merge_mass(const char *const *cells, size_t count, const char *out, int quiet);
static int merge_mesh(const char *const *cells, size_t count, const char *out, int quiet);

int crisp_cmd_merge(int argc, char **argv)
{
    cli_cmd = "merge";
    static const struct option opts[] = {{"output", required_argument, 0, 'o'},
                                         {"quiet", no_argument, 0, 'q'},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *out = NULL;
    int quiet = 0, c;
    optind = 0;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o':
            out = optarg;
            break;
        case 'q':
            quiet = 1;
            break;
        case 'h':
            fputs(usage_text, stdout);
            return 0;
        default:
            cli_bad_option(c, argv);
            return 2;
        }
    }
    if (!out) {
        fprintf(stderr, "crisp merge: no output given (-o OUT)\n%s", usage_text);
        return 2;
    }
    if (optind >= argc) {
        fprintf(stderr, "crisp merge: no cells given\n");
        return 2;
    }
    const char *const *cells = (const char *const *)argv + optind;
    size_t n = (size_t)(argc - optind);
    /* the kind of job from the first cell's header (an image's header is beside it) */
    crisp_cell_header *h = calloc(1, sizeof *h);
    if (!h) return 1;
    char head[4096];
    size_t len = strlen(cells[0]);
    int is_header = len > 5 && !strcmp(cells[0] + len - 5, ".cell");
    snprintf(head, sizeof head, is_header ? "%s" : "%s.cell", cells[0]);
    crisp_status s = crisp_cell_header_read(head, h);
    if (s && !is_header) s = crisp_cell_header_read(cells[0], h);
    if (s) {
        fprintf(stderr, "crisp merge: %s: not a cell (%s)\n", cells[0], crisp_error_message());
        free(h);
        return 1;
    }
    int rc;
    if (!strcmp(h->kind, "image")) {
        double t0 = crisp_time_now();
        s = crisp_merge_images(cells, n, out);
        if (s) {
            fprintf(stderr, "crisp merge: %s\n", crisp_error_message());
            rc = 1;
        } else {
            if (!quiet)
                printf("merged %zu tiles into %s (%dx%d, %.0f ms)\n", n, out, h->rect[4],
                       h->rect[5], 1e3 * (crisp_time_now() - t0));
            rc = 0;
        }
    } else if (!strcmp(h->kind, "mesh")) {
        rc = merge_mesh(cells, n, out, quiet);
    } else if (!strcmp(h->kind, "mass") || !strcmp(h->kind, "frep-mass")) {
        rc = crisp__merge_mass(cells, n, out, quiet);
    } else {
        fprintf(stderr, "crisp merge: %s: cells of kind '%s' cannot be merged by this crisp\n",
                cells[0], h->kind);
        rc = 1;
    }
    free(h);
    return rc;
}

/* ---- mass cells ----------------------------------------------------------------------- */

/* As crisp mass prints a whole model's properties (apps/crisp/cmd_mass.c). */
void crisp__mass_print(FILE *out, const char *name, int faces, const crisp_mass_props *p);

static int by_index(const void *a, const void *b)
{
    const crisp_cell_header *x = a, *y = b;
    return (x->cell.index > y->cell.index) - (x->cell.index < y->cell.index);
}

/* Every cell read and checked against the first: one job, one set of settings, each index once,
 * all of them. Sorted by index. */
static int load_cells(const char *const *cells, size_t n, crisp_cell_header *h)
{
    for (size_t k = 0; k < n; k++) {
        if (crisp_cell_header_read(cells[k], &h[k])) {
            fprintf(stderr, "crisp merge: %s: missing or corrupt cell: %s\n", cells[k],
                    crisp_error_message());
            return 0;
        }
        const crisp_cell_header *a = &h[0], *b = &h[k];
        if (strcmp(a->kind, b->kind) || strcmp(a->settings, b->settings) ||
            a->cell.count != b->cell.count) {
            fprintf(stderr,
                    "crisp merge: %s: cell %d has other settings than cell %d (%s): '%s %s' "
                    "against '%s %s'\n",
                    cells[k], b->cell.index, a->cell.index, cells[0], b->kind, b->settings, a->kind,
                    a->settings);
            return 0;
        }
        if (a->job != b->job) {
            fprintf(stderr,
                    "crisp merge: %s: cell %d belongs to another job (job %016llx, cell %d of %s "
                    "is of job %016llx): the input file differs\n",
                    cells[k], b->cell.index, (unsigned long long)b->job, a->cell.index, cells[0],
                    (unsigned long long)a->job);
            return 0;
        }
    }
    int N = h[0].cell.count;
    /* sort, remembering the files for the messages */
    for (size_t k = 0; k < n; k++)
        snprintf(h[k].data, sizeof h[k].data, "%s", cells[k]);
    qsort(h, n, sizeof *h, by_index);
    for (size_t k = 0; k + 1 < n; k++)
        if (h[k].cell.index == h[k + 1].cell.index) {
            fprintf(stderr, "crisp merge: cell %d is given twice: %s and %s\n", h[k].cell.index,
                    h[k].data, h[k + 1].data);
            return 0;
        }
    if (n != (size_t)N) {
        fprintf(stderr, "crisp merge: incomplete set: %d of the %d cells of %s's job are missing:",
                N - (int)n, N, cells[0]);
        size_t k = 0;
        int shown = 0;
        for (int i = 0; i < N; i++) {
            if (k < n && h[k].cell.index == i) {
                k++;
                continue;
            }
            if (shown++ < 8) fprintf(stderr, " cell %d", i);
        }
        fprintf(stderr, "%s\n", shown > 8 ? " ..." : "");
        return 0;
    }
    return 1;
}

static double sum_of(const crisp_cell_header *h, const char *name, int *missing)
{
    double v = crisp_cell_header_sum(h, name);
    if (isnan(v)) {
        fprintf(stderr, "crisp merge: %s: cell %d has no sum '%s'\n", h->data, h->cell.index, name);
        *missing = 1;
        return 0;
    }
    return v;
}

int crisp__merge_mass(const char *const *cells, size_t n, const char *out, int quiet)
{
    crisp_cell_header *h = calloc(n, sizeof *h);
    if (!h) return 1;
    int rc = 1, missing = 0;
    FILE *f = NULL;
    if (!load_cells(cells, n, h)) goto done;
    f = !strcmp(out, "-") ? stdout : fopen(out, "w");
    if (!f) {
        fprintf(stderr, "crisp merge: %s: cannot write\n", out);
        goto done;
    }
    char name[16];
    if (!strcmp(h[0].kind, "mass")) {
        crisp_mass_props p = {0};
        double *T = p.sums, *E = p.sums_err, *ref = p.ref;
        int faces = 0;
        for (int a = 0; a < 3; a++) {
            snprintf(name, sizeof name, "ref%d", a);
            ref[a] = sum_of(&h[0], name, &missing);
        }
        p.size = sum_of(&h[0], "size", &missing);
        for (size_t k = 0; k < n; k++) {
            for (int j = 0; j < CRISP_MASS_SUMS; j++) {
                snprintf(name, sizeof name, "T%d", j);
                T[j] += sum_of(&h[k], name, &missing);
                snprintf(name, sizeof name, "E%d", j);
                E[j] += sum_of(&h[k], name, &missing);
            }
            for (int a = 0; a < 3; a++) {
                snprintf(name, sizeof name, "ref%d", a);
                if (sum_of(&h[k], name, &missing) != ref[a]) {
                    fprintf(stderr, "crisp merge: %s: cell %d measures about another point\n",
                            h[k].data, h[k].cell.index);
                    missing = 1;
                }
            }
            if (h[k].rect[0] != faces) {
                fprintf(stderr, "crisp merge: %s: cell %d starts at face %d, expected %d\n",
                        h[k].data, h[k].cell.index, h[k].rect[0], faces);
                missing = 1;
            }
            faces = h[k].rect[1];
        }
        if (missing) goto done;
        crisp_mass_props_finish(&p);
        crisp__mass_print(f, "merged", faces, &p);
    } else {
        /* frep-mass: volume, first and raw second moments with their variances, bounds */
        static const char *const keys[] = {"V",   "Mx",  "My",  "Mz",  "Sxx", "Syy",
                                           "Szz", "Sxy", "Syz", "Sxz", "lo",  "hi"};
        double S[12] = {0}, var[10] = {0}, cells_b = 0, samples = 0, secs = 0;
        for (size_t k = 0; k < n; k++) {
            for (int j = 0; j < 12; j++)
                S[j] += sum_of(&h[k], keys[j], &missing);
            for (int j = 0; j < 10; j++) {
                snprintf(name, sizeof name, "var_%s", keys[j]);
                var[j] += sum_of(&h[k], name, &missing);
            }
            cells_b += sum_of(&h[k], "boundary_cells", &missing);
            samples += sum_of(&h[k], "samples", &missing);
            secs += sum_of(&h[k], "seconds", &missing);
        }
        if (missing) goto done;
        double V = S[0], c[3] = {S[1] / V, S[2] / V, S[3] / V};
        double C[6] = {S[4] - V * c[0] * c[0], S[5] - V * c[1] * c[1], S[6] - V * c[2] * c[2],
                       S[7] - V * c[0] * c[1], S[8] - V * c[1] * c[2], S[9] - V * c[0] * c[2]};
        double I[6] = {C[1] + C[2], C[0] + C[2], C[0] + C[1], -C[3], -C[4], -C[5]};
        /* standard errors (delta method, the cells' moments taken as independent) */
        double se_c[3], se_I[6], *M = S + 1;
        for (int a = 0; a < 3; a++) {
            int b = (a + 1) % 3, d = (a + 2) % 3;
            double g = (M[b] * M[b] + M[d] * M[d]) / (V * V);
            se_I[a] = sqrt(var[4 + b] + var[4 + d] + 4 * c[b] * c[b] * var[1 + b] +
                           4 * c[d] * c[d] * var[1 + d] + g * g * var[0]);
        }
        static const int pq[3][2] = {{0, 1}, {1, 2}, {0, 2}};
        for (int q = 0; q < 3; q++) {
            int a = pq[q][0], b = pq[q][1];
            double g = M[a] * M[b] / (V * V);
            se_I[3 + q] = sqrt(var[7 + q] + c[b] * c[b] * var[1 + a] + c[a] * c[a] * var[1 + b] +
                               g * g * var[0]);
        }
        for (int a = 0; a < 3; a++)
            se_c[a] = sqrt(var[1 + a] + c[a] * c[a] * var[0]) / fabs(V);
        fprintf(f, "merged %zu cells: %.0f boundary cells, %.0f samples, %.3f s in the cells\n", n,
                cells_b, samples, secs);
        fprintf(f, "volume    %.12g +- %.3g (standard error); certified bounds [%.12g, %.12g]\n", V,
                sqrt(var[0]), S[10], S[11]);
        double ref[3] = {sum_of(&h[0], "ref0", &missing), sum_of(&h[0], "ref1", &missing),
                         sum_of(&h[0], "ref2", &missing)};
        if (missing) goto done;
        fprintf(f, "centroid  %.10g %.10g %.10g\n       +-  %.3g %.3g %.3g\n", ref[0] + c[0],
                ref[1] + c[1], ref[2] + c[2], se_c[0], se_c[1], se_c[2]);
        fprintf(f, "inertia about the centroid (density 1): Ixx Iyy Izz Ixy Iyz Ixz\n  ");
        for (int k = 0; k < 6; k++)
            fprintf(f, " %.10g", I[k]);
        fprintf(f, "\n +-");
        for (int k = 0; k < 6; k++)
            fprintf(f, " %.3g", se_I[k]);
        fprintf(f, "\n");
    }
    rc = 0;
    if (!quiet && f != stdout) printf("merged %zu %s cells into %s\n", n, h[0].kind, out);
done:
    if (f && f != stdout && fclose(f)) rc = 1;
    if (rc && f && f != stdout) remove(out);
    free(h);
    return rc;
}

/* ---- mesh cells ----------------------------------------------------------------------- */

/* Welding: vertices equal bit for bit are one (a vertex on a face between cells is computed
 * the same way by both cells: the same grid edge, the same regula falsi). */
typedef struct weld {
    uint32_t *slot; /* vertex index + 1, 0 empty */
    size_t cap;
    float *p;
    size_t n, pcap;
} weld;

static uint64_t key_hash(const float p[3])
{
    uint32_t b[3];
    memcpy(b, p, sizeof b);
    uint64_t h = crisp_hash_bytes(CRISP_HASH_SEED, b, sizeof b);
    return h ^ (h >> 29);
}

static int weld_add(weld *w, const float p[3], uint32_t *dest)
{
    if (2 * (w->n + 1) > w->cap) {
        size_t cap = w->cap ? 2 * w->cap : 1 << 16;
        uint32_t *slot = calloc(cap, sizeof *slot);
        if (!slot) return 0;
        for (size_t k = 0; k < w->cap; k++)
            if (w->slot[k]) {
                size_t i = key_hash(w->p + 3 * (w->slot[k] - 1)) & (cap - 1);
                while (slot[i])
                    i = (i + 1) & (cap - 1);
                slot[i] = w->slot[k];
            }
        free(w->slot);
        w->slot = slot, w->cap = cap;
    }
    size_t i = key_hash(p) & (w->cap - 1);
    while (w->slot[i]) {
        if (!memcmp(w->p + 3 * (w->slot[i] - 1), p, 3 * sizeof(float)))
            return *dest = w->slot[i] - 1, 1;
        i = (i + 1) & (w->cap - 1);
    }
    if (w->n == w->pcap) {
        size_t c = w->pcap ? 2 * w->pcap : 1 << 15;
        float *q = realloc(w->p, c * 3 * sizeof *q);
        if (!q) return 0;
        w->p = q, w->pcap = c;
    }
    memcpy(w->p + 3 * w->n, p, 3 * sizeof(float));
    w->slot[i] = (uint32_t)(++w->n);
    *dest = (uint32_t)(w->n - 1);
    return 1;
}

static int merge_mesh(const char *const *args, size_t n, const char *out, int quiet)
{
    crisp_cell_header *h = calloc(n, sizeof *h);
    char **heads = calloc(n, sizeof *heads);
    int rc = 1;
    weld w = {0};
    uint32_t *tris = NULL;
    size_t nt = 0, tcap = 0;
    if (!h || !heads) goto done;
    for (size_t k = 0; k < n; k++) {
        size_t len = strlen(args[k]);
        heads[k] = malloc(len + 6);
        if (!heads[k]) goto done;
        if (len > 5 && !strcmp(args[k] + len - 5, ".cell"))
            memcpy(heads[k], args[k], len + 1);
        else
            snprintf(heads[k], len + 6, "%s.cell", args[k]);
    }
    if (!load_cells((const char *const *)heads, n, h)) goto done;
    /* load_cells put each header's own path in data: the data file is beside it */
    for (size_t k = 0; k < n; k++) {
        crisp_cell_header hk;
        char path[4200];
        if (crisp_cell_header_read(h[k].data, &hk)) goto done;
        const char *slash = strrchr(h[k].data, '/');
        int dl = slash ? (int)(slash - h[k].data + 1) : 0;
        snprintf(path, sizeof path, "%.*s%s", dl, h[k].data, hk.data);
        uint64_t size, hash;
        if (crisp_file_hash(path, &size, &hash)) {
            fprintf(stderr, "crisp merge: cell %d (%s): its data file is missing: %s\n",
                    hk.cell.index, h[k].data, crisp_error_message());
            goto done;
        }
        if (size != hk.data_size || hash != hk.data_hash) {
            fprintf(stderr,
                    "crisp merge: cell %d: %s is corrupt: %llu bytes with hash %016llx, its "
                    "header %s says %llu bytes with hash %016llx\n",
                    hk.cell.index, path, (unsigned long long)size, (unsigned long long)hash,
                    h[k].data, (unsigned long long)hk.data_size, (unsigned long long)hk.data_hash);
            goto done;
        }
        FILE *f = fopen(path, "rb");
        char magic[8];
        uint64_t cnt[2];
        if (!f || fread(magic, 1, 8, f) != 8 || memcmp(magic, "CRISPMSH", 8) ||
            fread(cnt, sizeof cnt, 1, f) != 1 || cnt[0] > (1ull << 32) || cnt[1] > (1ull << 34)) {
            fprintf(stderr, "crisp merge: cell %d: %s is not a mesh cell\n", hk.cell.index, path);
            if (f) fclose(f);
            goto done;
        }
        float *p = malloc(cnt[0] * 3 * sizeof *p + 1);
        uint32_t *map = malloc(cnt[0] * sizeof *map + 1), t[3];
        int ok = p && map && fread(p, 3 * sizeof *p, cnt[0], f) == cnt[0];
        for (uint64_t v = 0; ok && v < cnt[0]; v++)
            ok = weld_add(&w, p + 3 * v, &map[v]);
        if (ok && nt + cnt[1] > tcap) {
            size_t c = tcap ? tcap : 1 << 16;
            while (c < nt + cnt[1])
                c *= 2;
            uint32_t *q = realloc(tris, c * 3 * sizeof *q);
            ok = q != NULL;
            if (ok) tris = q, tcap = c;
        }
        for (uint64_t q = 0; ok && q < cnt[1]; q++) {
            ok = fread(t, sizeof t, 1, f) == 1 && t[0] < cnt[0] && t[1] < cnt[0] && t[2] < cnt[0];
            for (int a = 0; ok && a < 3; a++)
                tris[3 * nt + a] = map[t[a]];
            nt += ok;
        }
        fclose(f);
        free(p);
        free(map);
        if (!ok) {
            fprintf(stderr, "crisp merge: cell %d: %s: truncated or bad mesh data\n", hk.cell.index,
                    path);
            goto done;
        }
    }
    crisp_frep_mesh_writer *mw = NULL;
    crisp_frep_mesh_sink sink;
    crisp_status s = crisp_frep_mesh_writer_open(out, &mw, &sink);
    for (size_t v = 0; !s && v < w.n; v++)
        s = sink.vertex(sink.ctx, w.p + 3 * v);
    for (size_t q = 0; !s && q < nt; q++) {
        float tp[3][3];
        for (int a = 0; a < 3; a++)
            memcpy(tp[a], w.p + 3 * (size_t)tris[3 * q + a], sizeof tp[a]);
        s = sink.triangle(sink.ctx, tris + 3 * q, (const float(*)[3])tp);
    }
    crisp_status s2 = crisp_frep_mesh_writer_close(mw);
    if (!s) s = s2;
    if (s) {
        fprintf(stderr, "crisp merge: %s\n", crisp_error_message());
        remove(out);
        goto done;
    }
    if (!quiet)
        printf("merged %zu mesh cells into %s: %zu vertices, %zu triangles\n", n, out, w.n, nt);
    rc = 0;
done:
    for (size_t k = 0; heads && k < n; k++)
        free(heads[k]);
    free(heads);
    free(h);
    free(w.slot);
    free(w.p);
    free(tris);
    return rc;
}
