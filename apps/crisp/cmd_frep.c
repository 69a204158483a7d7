/* crisp frep: render an f-rep model (.vm file or infix math string) to a PNG (2D image or 3D
 * heightmap shaded by its normals) and an EXR of depth and normals, time the renderer, mesh the
 * part (crisp_frep_mesh) or measure it (crisp_frep_mass). Options by getopt_long per subcommand,
 * values checked by cli.h (messages name the option). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "crisp/cells.h"
#include "crisp/frep.h"
#include "crisp/frep_mass.h"
#include "crisp/frep_mesh.h"
#include "crisp/image.h"

const char crisp_cmd_frep_help[] = "frep render|bench|mesh|mass FILE  render, mesh or measure an "
                                   "implicit model (.vm or math string)";

static const char usage_frep[] =
    "usage: crisp frep render FILE [options]   render to a PNG (2D, or a 3D heightmap)\n"
    "       crisp frep bench FILE [options]    time the renderer\n"
    "       crisp frep mesh FILE -o OUT [options]   a watertight triangle mesh\n"
    "       crisp frep mass FILE [options]     volume, area, centroid, inertia with error bars\n"
    "FILE is a .vm file, or any other file holding an infix math string (X, Y, Z, + - * / ^,\n"
    "sqrt, min, max, ...; inside where the value is below 0); -e EXPR gives the string itself.\n"
    "crisp frep SUBCOMMAND --help lists the subcommand's options.\n";

static const char usage_render[] =
    "usage: crisp frep render FILE [options]\n"
    "       crisp frep bench FILE [options] [--runs N]\n"
    "  Renders the part f < 0 by interval subdivision; bench renders N times and prints the\n"
    "  median render and set-up times. Options (default in brackets):\n"
    "  -e, --expr EXPR       the infix math string itself instead of FILE\n"
    "  -o, --output FILE     PNG to write: 2D 8-bit grayscale, 255 inside; 3D shaded [none]\n"
    "      --size N|WxH      image size, each 1..16384 [1024]\n"
    "      --3d              a heightmap seen from +Z, shaded by its normals [2D]\n"
    "      --depth D         3D: voxels along z, 1..65536 [max(W, H)]\n"
    "      --region x0,x1,y0,y1[,z0,z1]\n"
    "                        the region shown [the part's box by interval subdivision, padded\n"
    "                        4%; an unbounded axis shows [-1, 1]]\n"
    "      --depth-out FILE.exr  also write Z and N.x N.y N.z (Z = -inf where nothing) [none]\n"
    "      --threads N       worker threads, 1..1024 [all cores]\n"
    "      --runs N          bench: renders, 1..100000 [20]\n"
    "      --stats           print counts and times [off]\n"
    "      --no-prune        no tape shortening (for measuring it) [off]\n"
    "      --no-batch        no batched intervals (for measuring them) [off]\n"
    "      --no-subcells     no sub-cell intervals (for measuring them) [off]\n"
    "      --brute           evaluate every sample (reference) [off]\n"
    "      --tile I/N        render tile I of N of the image (same pixels as the whole image;\n"
    "                        written with a cell header for crisp merge) [whole image]\n"
    "  -h, --help            print this help and exit\n"
    "  Exit status: 0 success, 1 bad input or failure, 2 bad usage.\n";

static const char usage_mesh[] =
    "usage: crisp frep mesh FILE -o OUT [options]\n"
    "  A closed, 2-manifold, self-intersection-free triangle mesh of the part f < 0 (marching\n"
    "  tetrahedra on the interval octree, with feature points at creases), streamed to OUT.\n"
    "  Warns about features thinner than the cell and about a region that cuts the part (the\n"
    "  mesh is then closed by its faces). Options (default in brackets):\n"
    "  -e, --expr EXPR       the infix math string itself instead of FILE\n"
    "  -o, --output OUT      .stl (binary), .obj or .ply (binary) [required]\n"
    "      --resolution N    grid cells along the region's longest side, 4..1048574 [128]\n"
    "      --cell SIZE       the grid cell's edge instead, > 0 [from --resolution]\n"
    "      --cell I/N        mesh octant I of N = 8^k only, written to -o CELL.cmesh for\n"
    "                        crisp merge, which welds the cells [whole mesh]\n"
    "      --region x0,x1,y0,y1,z0,z1\n"
    "                        the region meshed [the part's box by interval subdivision]\n"
    "      --max-memory MB   the mesher's edge table limit in MB, >= 1 [8192]\n"
    "      --no-features     plain marching tetrahedra (no feature points) [off]\n"
    "      --stats           print octree counts [off]\n"
    "  -h, --help            print this help and exit\n"
    "  Exit status: 0 success, 1 bad input or failure, 2 bad usage.\n";

static const char usage_mass[] =
    "usage: crisp frep mass FILE [options]\n"
    "  Volume (with certified bounds), area, centroid and inertia tensor (about the centroid,\n"
    "  density 1) with standard errors, by octree block decomposition and stratified Monte\n"
    "  Carlo in the boundary cells (Clark, PADL-2). Levels 3.. are run until one takes 0.1 s;\n"
    "  their costs and errors predict the finer levels (least squares), which picks the level.\n"
    "  Options (default in brackets):\n"
    "  -e, --expr EXPR       the infix math string itself instead of FILE\n"
    "      --accuracy REL    relative standard error of the volume, in [1e-12, 1] [1e-3]\n"
    "      --time SECONDS    the finest level predicted to fit in SECONDS, in [0.001, 1e7]\n"
    "                        [unset: --accuracy decides]\n"
    "      --predict         print the coarse levels and the predicted time and error of the\n"
    "                        next four [off]\n"
    "      --level L         run level L only (cells of the region / 2^L), 1..20 [predicted]\n"
    "      --seed N          sampling seed, 0..2147483647 [1]\n"
    "      --region x0,x1,y0,y1,z0,z1\n"
    "                        the region measured [the part's box, padded 2%]\n"
    "      --cell I/N        measure octant I of N = 8^k only at --level L (default 7),\n"
    "                        partial sums written to -o CELL for crisp merge [whole region]\n"
    "  -o, --output CELL     the cell file (with --cell only)\n"
    "  -h, --help            print this help and exit\n"
    "  Exit status: 0 success, 1 bad input or failure, 2 bad usage.\n";

static int ends_with(const char *s, const char *t)
{
    size_t a = strlen(s), b = strlen(t);
    return a >= b && !strcmp(s + a - b, t);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The default region: the part's fitted box (crisp_frep_fit_region), padded by 4% and widened
 * to the image's aspect; an axis on which the part is unbounded keeps [-1, 1], with a note. */
static crisp_status fit_region(const crisp_frep_tape *tape, int is3d, crisp_frep_render_desc *desc)
{
    crisp_frep_fit fit;
    crisp_status s = crisp_frep_fit_region(
        tape, &(crisp_frep_fit_desc){.planar = !is3d, .free_axes = is3d ? 4u : 0u}, &fit);
    if (s) return s;
    static const char axis[3] = {'x', 'y', 'z'};
    if (fit.unbounded & 3u) {
        /* fit the bounded axes again within the slab shown ([-1, 1] on the unbounded ones): the
         * first fit was over the largest search box, at its coarse resolution */
        crisp_frep_fit_desc d2 = {.planar = !is3d};
        for (int a = 0; a < 3; a++) {
            int unb = (fit.unbounded >> a) & 1;
            d2.search[2 * a] = unb ? -1 : fit.box[2 * a] - fit.cell;
            d2.search[2 * a + 1] = unb ? 1 : fit.box[2 * a + 1] + fit.cell;
        }
        crisp_frep_fit fit2;
        if (!crisp_frep_fit_region(tape, &d2, &fit2)) {
            for (int a = 0; a < 3; a++)
                if (!((fit.unbounded >> a) & 1))
                    fit.box[2 * a] = fit2.box[2 * a], fit.box[2 * a + 1] = fit2.box[2 * a + 1];
        }
        crisp_error_clear();
    }
    double *g = desc->region, ext[3], mid[3];
    for (int a = 0; a < 3; a++) {
        if (fit.unbounded & (1u << a)) {
            fprintf(stderr,
                    "crisp %s: the part is not bounded in %c within [%g, %g]; showing %c in "
                    "[-1, 1] (give --region to choose)\n",
                    cli_cmd, axis[a], fit.search[2 * a], fit.search[2 * a + 1], axis[a]);
            mid[a] = 0, ext[a] = 2;
        } else {
            mid[a] = 0.5 * (fit.box[2 * a] + fit.box[2 * a + 1]);
            ext[a] = 1.04 * (fit.box[2 * a + 1] - fit.box[2 * a]);
        }
    }
    if (!is3d) mid[2] = 0, ext[2] = 0;
    /* square pixels: the x:y extents follow the image's W:H */
    double aspect = (double)desc->width / desc->height;
    if (ext[0] < ext[1] * aspect)
        ext[0] = ext[1] * aspect;
    else
        ext[1] = ext[0] / aspect;
    for (int a = 0; a < 3; a++) {
        if (!(ext[a] > 0)) ext[a] = a < 2 || is3d ? 2 : 0;
        g[2 * a] = mid[a] - 0.5 * ext[a];
        g[2 * a + 1] = mid[a] + 0.5 * ext[a];
    }
    return CRISP_OK;
}

/* --region: x0,x1,y0,y1,z0,z1 (or x0,x1,y0,y1 where `planar` allows it: z in [-1, 1]), each
 * pair increasing. */
static int parse_region(const char *v, int planar, double g[6])
{
    int commas = 0;
    for (const char *p = v; *p; p++)
        commas += *p == ',';
    int n = planar && commas == 3 ? 4 : 6;
    if (!cli_doubles("--region", v, n, g)) return 0;
    if (n == 4) g[4] = -1, g[5] = 1;
    for (int a = 0; a < 3; a++)
        if (!(g[2 * a] < g[2 * a + 1])) {
            fprintf(stderr, "crisp %s: --region %s: axis %c [%g, %g] is empty\n", cli_cmd, v,
                    "xyz"[a], g[2 * a], g[2 * a + 1]);
            return 0;
        }
    return 1;
}

/* FILE (one, after or among the options) or -e EXPR; 0 after a message. */
static int take_file(int argc, char **argv, const char *expr, const char **file, const char *usage)
{
    if (optind < argc && expr) {
        fprintf(stderr, "crisp %s: both FILE ('%s') and -e given: give one\n", cli_cmd,
                argv[optind]);
        return 0;
    }
    if (optind + 1 < argc) {
        fprintf(stderr, "crisp %s: more than one FILE given ('%s', '%s')\n", cli_cmd, argv[optind],
                argv[optind + 1]);
        return 0;
    }
    if (optind >= argc && !expr) {
        fprintf(stderr, "crisp %s: no FILE given\n%s", cli_cmd, usage);
        return 0;
    }
    *file = optind < argc ? argv[optind] : NULL;
    return 1;
}

static crisp_status load_model(const char *file, const char *expr, crisp_frep **f,
                               crisp_frep_tape **tape)
{
    crisp_status s;
    if (expr)
        s = crisp_frep_read_math_mem("-e", expr, strlen(expr), f);
    else if (ends_with(file, ".vm"))
        s = crisp_frep_read_vm(file, f);
    else
        s = crisp_frep_read_math(file, f);
    if (!s) s = crisp_frep_tape_create(*f, tape);
    return s;
}

enum {
    OPT_SIZE = 256,
    OPT_3D,
    OPT_DEPTH,
    OPT_REGION,
    OPT_DEPTH_OUT,
    OPT_THREADS,
    OPT_RUNS,
    OPT_STATS,
    OPT_NO_PRUNE,
    OPT_NO_BATCH,
    OPT_NO_SUBCELLS,
    OPT_BRUTE,
    OPT_RESOLUTION,
    OPT_CELL,
    OPT_MAXMEM,
    OPT_NO_FEATURES,
    OPT_ACCURACY,
    OPT_TIME,
    OPT_PREDICT,
    OPT_LEVEL,
    OPT_SEED,
    OPT_TILE
};

/* argv[0] is the subcommand; getopt_long from argv[1]. */
static void getopt_start(void)
{
    optind = 0; /* GNU getopt: start afresh */
    opterr = 0;
}

/* The cell header's job id: the -e string's or the file's bytes, with the settings. */
static crisp_status frep_job_id(const char *file, const char *expr, crisp_cell_header *h)
{
    if (!expr) return crisp_cell_job_id(file, h->settings, &h->job);
    h->job = crisp_hash_bytes(CRISP_HASH_SEED, expr, strlen(expr));
    h->job = crisp_hash_bytes(h->job, h->settings, strlen(h->settings));
    return CRISP_OK;
}

/* ---- mesh cells (issue 15): octants of the mesher's octree, welded by crisp merge -------- */

typedef struct mesh_mem {
    float *p;
    uint32_t *t;
    size_t nv, nt, cv, ct;
} mesh_mem;

static crisp_status mem_vertex(void *ctx, const float p[3])
{
    mesh_mem *m = ctx;
    if (m->nv == m->cv) {
        size_t c = m->cv ? 2 * m->cv : 4096;
        float *q = realloc(m->p, c * 3 * sizeof *q);
        if (!q) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the mesh cell");
        m->p = q, m->cv = c;
    }
    memcpy(m->p + 3 * m->nv++, p, 3 * sizeof *p);
    return CRISP_OK;
}

static crisp_status mem_triangle(void *ctx, const uint32_t v[3], const float p[3][3])
{
    (void)p;
    mesh_mem *m = ctx;
    if (m->nt == m->ct) {
        size_t c = m->ct ? 2 * m->ct : 4096;
        uint32_t *q = realloc(m->t, c * 3 * sizeof *q);
        if (!q) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the mesh cell");
        m->t = q, m->ct = c;
    }
    memcpy(m->t + 3 * m->nt++, v, 3 * sizeof *v);
    return CRISP_OK;
}

/* The cell's data: "CRISPMSH", vertex and triangle counts (uint64), the vertices (3 floats),
 * the triangles (3 uint32), little-endian as the machine (crisp merge checks the magic). */
static crisp_status mesh_cell_write(void *ctx, const char *tmp)
{
    const mesh_mem *m = ctx;
    FILE *f = fopen(tmp, "wb");
    if (!f) return crisp_error(CRISP_ERR_IO, "%s: cannot write", tmp);
    uint64_t n[2] = {m->nv, m->nt};
    /* (a cell may be empty: no arrays) */
    int ok = fwrite("CRISPMSH", 1, 8, f) == 8 && fwrite(n, sizeof n, 1, f) == 1 &&
             (!m->nv || fwrite(m->p, 3 * sizeof(float), m->nv, f) == m->nv) &&
             (!m->nt || fwrite(m->t, 3 * sizeof(uint32_t), m->nt, f) == m->nt);
    if (fclose(f) || !ok) return crisp_error(CRISP_ERR_IO, "%s: cannot write", tmp);
    return CRISP_OK;
}

static int mesh_cell(const crisp_frep_tape *tape, crisp_frep_mesh_desc *desc,
                     const crisp_cell_spec *cell, const char *file, const char *expr,
                     const char *out)
{
    if (cell->cols) {
        fprintf(stderr, "crisp frep mesh: --cell I/N: N is a power of 8 (no grid)\n");
        return 2;
    }
    desc->split_cell[0] = cell->index, desc->split_cell[1] = cell->count;
    mesh_mem m = {0};
    crisp_frep_mesh_sink sink = {.ctx = &m, .vertex = mem_vertex, .triangle = mem_triangle};
    crisp_frep_mesh_stats st;
    crisp_status s = crisp_frep_mesh(tape, desc, &sink, &st);
    crisp_cell_header *h = calloc(1, sizeof *h);
    if (!s && !h) s = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    if (!s) {
        snprintf(h->kind, sizeof h->kind, "mesh");
        snprintf(h->settings, sizeof h->settings,
                 "frep-mesh region=%.17g,%.17g,%.17g,%.17g,%.17g,%.17g cell=%.17g features=%d "
                 "cells=%d",
                 st.region[0], st.region[1], st.region[2], st.region[3], st.region[4], st.region[5],
                 st.cell, !desc->no_features, cell->count);
        s = frep_job_id(file, expr, h);
        h->cell = *cell;
        crisp_cell_header_add_sum(h, "vertices", (double)m.nv);
        crisp_cell_header_add_sum(h, "triangles", (double)m.nt);
        crisp_cell_header_add_sum(h, "thin_cubes", (double)st.thin_cubes);
    }
    if (!s) s = crisp_cell_commit(out, h, mesh_cell_write, &m);
    if (s)
        fprintf(stderr, "crisp frep mesh: %s\n", crisp_error_message());
    else
        printf("%s: cell %d of %d: %zu vertices, %zu triangles\n", out, cell->index, cell->count,
               m.nv, m.nt);
    free(h);
    free(m.p);
    free(m.t);
    return s ? 1 : 0;
}

static int cmd_mesh(int argc, char **argv)
{
    static const struct option opts[] = {{"expr", required_argument, 0, 'e'},
                                         {"output", required_argument, 0, 'o'},
                                         {"resolution", required_argument, 0, OPT_RESOLUTION},
                                         {"cell", required_argument, 0, OPT_CELL},
                                         {"region", required_argument, 0, OPT_REGION},
                                         {"max-memory", required_argument, 0, OPT_MAXMEM},
                                         {"no-features", no_argument, 0, OPT_NO_FEATURES},
                                         {"stats", no_argument, 0, OPT_STATS},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *file = NULL, *expr = NULL, *out = NULL;
    crisp_frep_mesh_desc desc = {0};
    int stats = 0, c, celled = 0;
    crisp_cell_spec cell = {0};
    getopt_start();
    while ((c = getopt_long(argc, argv, ":e:o:h", opts, NULL)) != -1) {
        switch (c) {
        case 'e':
            expr = optarg;
            break;
        case 'o':
            out = optarg;
            break;
        case OPT_RESOLUTION:
            if (!cli_int("--resolution", optarg, 4, (1 << 20) - 2, &desc.resolution)) return 2;
            break;
        case OPT_CELL:
            if (strchr(optarg, '/')) { /* --cell I/N: one octant of the mesh */
                if (!cli_cell("--cell", optarg, &cell)) return 2;
                celled = 1;
            } else if (!cli_double("--cell", optarg, 0, INFINITY, 1, 1, &desc.cell)) {
                return 2;
            }
            break;
        case OPT_REGION:
            if (!parse_region(optarg, 0, desc.region)) return 2;
            break;
        case OPT_MAXMEM:
            if (!cli_double("--max-memory", optarg, 1, 1e9, 0, 0, &desc.max_megabytes)) return 2;
            break;
        case OPT_NO_FEATURES:
            desc.no_features = 1;
            break;
        case OPT_STATS:
            stats = 1;
            break;
        case 'h':
            fputs(usage_mesh, stdout);
            return 0;
        default:
            cli_bad_option(c, argv);
            return 2;
        }
    }
    if (!take_file(argc, argv, expr, &file, usage_mesh)) return 2;
    if (!out) {
        fprintf(stderr, "crisp frep mesh: no output given (-o out.stl, out.obj or out.ply)\n");
        return 2;
    }
    if (!celled && !ends_with(out, ".stl") && !ends_with(out, ".obj") && !ends_with(out, ".ply")) {
        fprintf(stderr, "crisp frep mesh: -o %s: expected a name ending in .stl, .obj or .ply\n",
                out);
        return 2;
    }
    crisp_frep *f = NULL;
    crisp_frep_tape *tape = NULL;
    crisp_frep_mesh_writer *w = NULL;
    crisp_frep_mesh_sink sink;
    crisp_frep_mesh_stats st;
    double t0 = crisp_time_now();
    crisp_status s = load_model(file, expr, &f, &tape);
    if (celled) {
        int rc = s ? 1 : mesh_cell(tape, &desc, &cell, file, expr, out);
        if (s) fprintf(stderr, "crisp frep mesh: %s\n", crisp_error_message());
        crisp_frep_tape_destroy(tape);
        crisp_frep_destroy(f);
        return rc;
    }
    if (!s) s = crisp_frep_mesh_writer_open(out, &w, &sink);
    if (!s) s = crisp_frep_mesh(tape, &desc, &sink, &st);
    crisp_status s2 = crisp_frep_mesh_writer_close(w);
    if (!s) s = s2;
    int rc = 0;
    if (s) {
        fprintf(stderr, "crisp frep mesh: %s\n", crisp_error_message());
        rc = 1;
    } else {
        double dt = crisp_time_now() - t0;
        printf(
            "%s: %zu vertices, %zu triangles, cell %g over [%g, %g] x [%g, %g] x [%g, %g]; %.3f s, "
            "%.1f MB peak (mesher)\n",
            out, st.vertices, st.triangles, st.cell, st.region[0], st.region[1], st.region[2],
            st.region[3], st.region[4], st.region[5], dt, st.peak_bytes / 1e6);
        if (stats)
            printf("leaves %zu, intervals %zu, NaN points %zu\n", st.leaves, st.intervals,
                   st.nan_points);
        if (st.thin_cubes)
            fprintf(stderr,
                    "crisp frep mesh: warning: %zu grid cubes hold a feature thinner than the cell "
                    "(%g), lost in the mesh (one near %g, %g, %g); use a finer --cell\n",
                    st.thin_cubes, st.cell, st.thin_at[0], st.thin_at[1], st.thin_at[2]);
        if (st.cut_points)
            fprintf(stderr,
                    "crisp frep mesh: warning: the region cuts the part (%zu inside grid points on "
                    "its border); the mesh is closed by the region's faces there\n",
                    st.cut_points);
        if (!st.triangles)
            fprintf(stderr,
                    "crisp frep mesh: warning: empty mesh: no grid point is inside the part\n");
    }
    crisp_frep_tape_destroy(tape);
    crisp_frep_destroy(f);
    return rc;
}

/* ---- mass ------------------------------------------------------------------------------------ */

typedef struct area_sum {
    double area;
} area_sum;

static crisp_status area_vertex(void *ctx, const float p[3])
{
    (void)ctx, (void)p;
    return CRISP_OK;
}

static crisp_status area_triangle(void *ctx, const uint32_t v[3], const float p[3][3])
{
    (void)v;
    double e1[3], e2[3];
    for (int a = 0; a < 3; a++)
        e1[a] = (double)p[1][a] - p[0][a], e2[a] = (double)p[2][a] - p[0][a];
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
    ((area_sum *)ctx)->area += 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    return CRISP_OK;
}

/* Surface area from the meshes at two resolutions (the finer one, and their difference as the
 * error estimate). */
static crisp_status mesh_area(const crisp_frep_tape *tape, const double region[6], int resolution,
                              double *area, double *err)
{
    double a[2];
    for (int k = 0; k < 2; k++) {
        area_sum sum = {0};
        crisp_frep_mesh_sink sink = {.ctx = &sum, .vertex = area_vertex, .triangle = area_triangle};
        crisp_frep_mesh_desc d = {.resolution = resolution >> k};
        memcpy(d.region, region, sizeof d.region);
        crisp_frep_mesh_stats st;
        crisp_status s = crisp_frep_mesh(tape, &d, &sink, &st);
        if (s) return s;
        a[k] = sum.area;
    }
    *area = a[0];
    *err = fabs(a[0] - a[1]);
    return CRISP_OK;
}

static void print_level(const crisp_frep_mass *m)
{
    printf("  level %2d  cell %.3g  boundary cells %9zu  processor time %8.3f s  volume %.10g +- "
           "%.2g  "
           "bounds [%.10g, %.10g]\n",
           m->level, fmax(m->cell[0], fmax(m->cell[1], m->cell[2])), m->boundary_cells,
           m->cpu_seconds, m->volume, m->volume_se, m->volume_lo, m->volume_hi);
}

/* One level; a region that cuts the part is a warning (once): the results are those of the part
 * within the region. */
static crisp_status mass_level(const crisp_frep_tape *tape, const crisp_frep_mass_desc *desc,
                               crisp_frep_mass *dest, int *warned)
{
    crisp_status s = crisp_frep_mass_level(tape, desc, dest);
    if (s && dest->cut_cells) {
        if (!*warned) fprintf(stderr, "crisp frep mass: warning: %s\n", crisp_error_message());
        *warned = 1;
        crisp_error_clear();
        s = CRISP_OK;
    }
    return s;
}

/* ---- mass cells (issue 15): octants of the region's octree ------------------------------ */

/* Cell I of N = 8^k: the octant path of I's base-8 digits (most significant first; digit bits x,
 * y, z) through k halvings of the region, measured at level - k, so that its octree cells are
 * the whole run's at `level`. Its sums (volume, first and raw second moments about the whole
 * region's centre, their variances, the certified bounds) go to a cell file for crisp merge. */
static int frep_mass_cell(const crisp_frep_tape *tape, const double region[6], int level,
                          uint64_t seed, const crisp_cell_spec *cell, const char *file,
                          const char *expr, const char *out)
{
    int k = 0;
    long n = 1;
    while (n < cell->count)
        n *= 8, k++;
    if (n != cell->count || cell->cols) {
        fprintf(stderr,
                "crisp frep mass: --cell %d/%d: the number of cells must be a power of 8 (1, 8, "
                "64, 512, ...): cells are octants of the region's octree\n",
                cell->index, cell->count);
        return 2;
    }
    if (level - k < 1) {
        fprintf(stderr, "crisp frep mass: --level %d is too coarse for %d cells (at least %d)\n",
                level, cell->count, k + 1);
        return 2;
    }
    long ix[3] = {0, 0, 0};
    for (int d = 0; d < k; d++) {
        int o = (cell->index >> (3 * (k - 1 - d))) & 7;
        for (int a = 0; a < 3; a++)
            ix[a] = 2 * ix[a] + ((o >> a) & 1);
    }
    crisp_frep_mass_desc d = {.level = level - k, .seed = seed * 1000003u + (uint64_t)cell->index};
    double ref[3], span = (double)(1L << (level - k));
    for (int a = 0; a < 3; a++) {
        double w = (region[2 * a + 1] - region[2 * a]) / (double)(1L << level);
        d.region[2 * a] = region[2 * a] + (double)ix[a] * span * w;
        d.region[2 * a + 1] = ix[a] + 1 == (1L << k)
                                  ? region[2 * a + 1]
                                  : region[2 * a] + (double)(ix[a] + 1) * span * w;
        ref[a] = 0.5 * (region[2 * a] + region[2 * a + 1]);
    }
    crisp_frep_mass r;
    crisp_status s = crisp_frep_mass_level(tape, &d, &r);
    int empty = s == CRISP_ERR_NUMERIC && !(r.volume > 0) && r.inside_cells == 0;
    if (s && !r.cut_cells && !empty) {
        fprintf(stderr, "crisp frep mass: cell %d: %s\n", cell->index, crisp_error_message());
        return 1;
    }
    crisp_error_clear();
    crisp_cell_header *h = calloc(1, sizeof *h);
    if (!h) return 1;
    snprintf(h->kind, sizeof h->kind, "frep-mass");
    snprintf(h->settings, sizeof h->settings,
             "frep-mass level=%d region=%.17g,%.17g,%.17g,%.17g,%.17g,%.17g seed=%llu cells=%d",
             level, region[0], region[1], region[2], region[3], region[4], region[5],
             (unsigned long long)seed, cell->count);
    if (frep_job_id(file, expr, h)) {
        fprintf(stderr, "crisp frep mass: %s\n", crisp_error_message());
        free(h);
        return 1;
    }
    h->cell = *cell;
    /* raw moments about ref from the centroid and the central moments (Ixx = Cyy + Czz,
     * Ixy = -Cxy); variances from the standard errors (delta method, correlations dropped) */
    double V = empty ? 0 : r.volume, c[3], sv = empty ? 0 : r.volume_se;
    for (int a = 0; a < 3; a++)
        c[a] = empty ? 0 : r.centroid[a] - ref[a];
    const double *I = r.inertia, *se = r.inertia_se;
    double C[6] = {0.5 * (I[1] + I[2] - I[0]),
                   0.5 * (I[0] + I[2] - I[1]),
                   0.5 * (I[0] + I[1] - I[2]),
                   -I[3],
                   -I[4],
                   -I[5]};
    double vC[6] = {0.25 * (se[0] * se[0] + se[1] * se[1] + se[2] * se[2]),
                    0.25 * (se[0] * se[0] + se[1] * se[1] + se[2] * se[2]),
                    0.25 * (se[0] * se[0] + se[1] * se[1] + se[2] * se[2]),
                    se[3] * se[3],
                    se[4] * se[4],
                    se[5] * se[5]};
    static const int pa[6] = {0, 1, 2, 0, 1, 0}, pb[6] = {0, 1, 2, 1, 2, 2};
    crisp_cell_header_add_sum(h, "V", V);
    crisp_cell_header_add_sum(h, "var_V", sv * sv);
    static const char *const mk[3] = {"Mx", "My", "Mz"};
    char name[32];
    for (int a = 0; a < 3; a++) {
        double sc = empty ? 0 : r.centroid_se[a];
        crisp_cell_header_add_sum(h, mk[a], V * c[a]);
        snprintf(name, sizeof name, "var_%s", mk[a]);
        crisp_cell_header_add_sum(h, name, V * V * sc * sc + c[a] * c[a] * sv * sv);
    }
    static const char *const sk[6] = {"Sxx", "Syy", "Szz", "Sxy", "Syz", "Sxz"};
    for (int q = 0; q < 6; q++) {
        int a = pa[q], b = pb[q];
        double S = empty ? 0 : C[q] + V * c[a] * c[b];
        double sa = empty ? 0 : r.centroid_se[a], sb = empty ? 0 : r.centroid_se[b];
        double var = empty ? 0
                           : vC[q] + c[a] * c[a] * c[b] * c[b] * sv * sv +
                                 V * V * (c[b] * c[b] * sa * sa + c[a] * c[a] * sb * sb);
        crisp_cell_header_add_sum(h, sk[q], S);
        snprintf(name, sizeof name, "var_%s", sk[q]);
        crisp_cell_header_add_sum(h, name, var);
    }
    crisp_cell_header_add_sum(h, "lo", r.volume_lo);
    crisp_cell_header_add_sum(h, "hi", r.volume_hi);
    crisp_cell_header_add_sum(h, "boundary_cells", (double)r.boundary_cells);
    crisp_cell_header_add_sum(h, "samples", (double)r.samples);
    crisp_cell_header_add_sum(h, "seconds", r.seconds);
    for (int a = 0; a < 3; a++) {
        snprintf(name, sizeof name, "ref%d", a);
        crisp_cell_header_add_sum(h, name, ref[a]);
    }
    crisp_status ws = crisp_cell_header_write(out, h);
    free(h);
    if (ws) {
        fprintf(stderr, "crisp frep mass: %s\n", crisp_error_message());
        return 1;
    }
    printf("%s: cell %d of %d (level %d of [%g, %g] x [%g, %g] x [%g, %g]): volume %.10g +- "
           "%.2g, bounds [%.10g, %.10g], %.3f s\n",
           out, cell->index, cell->count, d.level, d.region[0], d.region[1], d.region[2],
           d.region[3], d.region[4], d.region[5], V, sv, r.volume_lo, r.volume_hi, r.seconds);
    return 0;
}

static int cmd_mass(int argc, char **argv)
{
    static const struct option opts[] = {{"expr", required_argument, 0, 'e'},
                                         {"accuracy", required_argument, 0, OPT_ACCURACY},
                                         {"time", required_argument, 0, OPT_TIME},
                                         {"predict", no_argument, 0, OPT_PREDICT},
                                         {"level", required_argument, 0, OPT_LEVEL},
                                         {"seed", required_argument, 0, OPT_SEED},
                                         {"region", required_argument, 0, OPT_REGION},
                                         {"cell", required_argument, 0, OPT_CELL},
                                         {"output", required_argument, 0, 'o'},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *file = NULL, *expr = NULL, *cell_out = NULL;
    crisp_cell_spec cell = {0};
    int celled = 0;
    double accuracy = 0, time_limit = 0;
    int predict = 0, level = 0, seed = 1, c, warned = 0;
    crisp_frep_mass_desc desc = {0};
    getopt_start();
    while ((c = getopt_long(argc, argv, ":e:o:h", opts, NULL)) != -1) {
        switch (c) {
        case 'e':
            expr = optarg;
            break;
        case 'o':
            cell_out = optarg;
            break;
        case OPT_CELL:
            if (!cli_cell("--cell", optarg, &cell)) return 2;
            celled = 1;
            break;
        case OPT_ACCURACY:
            if (!cli_double("--accuracy", optarg, 1e-12, 1, 0, 0, &accuracy)) return 2;
            break;
        case OPT_TIME:
            if (!cli_double("--time", optarg, 1e-3, 1e7, 0, 0, &time_limit)) return 2;
            break;
        case OPT_PREDICT:
            predict = 1;
            break;
        case OPT_LEVEL:
            if (!cli_int("--level", optarg, 1, 20, &level)) return 2;
            break;
        case OPT_SEED:
            if (!cli_int("--seed", optarg, 0, 2147483647L, &seed)) return 2;
            break;
        case OPT_REGION:
            if (!parse_region(optarg, 0, desc.region)) return 2;
            break;
        case 'h':
            fputs(usage_mass, stdout);
            return 0;
        default:
            cli_bad_option(c, argv);
            return 2;
        }
    }
    if (!take_file(argc, argv, expr, &file, usage_mass)) return 2;
    if (level && (accuracy || time_limit || predict)) {
        fprintf(stderr, "crisp frep mass: --level runs one level: it does not go with --accuracy, "
                        "--time or --predict\n");
        return 2;
    }
    if (accuracy && time_limit) {
        fprintf(stderr, "crisp frep mass: --accuracy and --time both pick the level: give one\n");
        return 2;
    }
    if (celled != (cell_out != NULL)) {
        fprintf(stderr, "crisp frep mass: --cell and -o go together (-o names the cell file)\n");
        return 2;
    }
    if (!accuracy && !time_limit && !level) accuracy = 1e-3;
    crisp_frep *f = NULL;
    crisp_frep_tape *tape = NULL;
    int rc = 1;
    crisp_status s = load_model(file, expr, &f, &tape);
    if (s) goto fail;
    desc.seed = (uint64_t)seed;
    /* the region once (fitted unless given), so that every level measures the same box */
    if (!desc.region[0] && !desc.region[1] && !desc.region[2] && !desc.region[3] &&
        !desc.region[4] && !desc.region[5]) {
        crisp_frep_mass first;
        desc.level = 1;
        s = crisp_frep_mass_level(tape, &desc, &first);
        if (s && !first.cut_cells) goto fail;
        memcpy(desc.region, first.region, sizeof desc.region);
    }
    crisp_error_clear();
    if (celled) {
        rc = frep_mass_cell(tape, desc.region, level ? (int)level : 7, desc.seed, &cell, file, expr,
                            cell_out);
        goto done;
    }
    /* coarse levels (Clark: the cost and the error of a level predict the next ones) */
    crisp_frep_mass lv[21];
    int n = 0;
    double spent = 0;
    int target = (int)level;
    if (!target) {
        for (int L = 3; L <= 20; L++) {
            desc.level = L;
            s = mass_level(tape, &desc, &lv[L], &warned);
            if (s) goto fail;
            spent += lv[L].seconds;
            n = L;
            if (predict) print_level(&lv[L]);
            double rel = lv[L].volume_se / fabs(lv[L].volume);
            if (accuracy && rel <= accuracy && !predict) break;
            /* enough to fit: a level costing 0.1 s besides the region check (the same at every
             * level), or level 7 */
            if (L >= 5 && (lv[L].cpu_seconds - lv[L].cpu_fixed > 0.1 || L >= 7)) break;
        }
        /* Clark: the coarse levels' cells, time and error predict the finer ones */
        int first = 3; /* every coarse level: a least-squares fit */
        double gc = (double)lv[n].boundary_cells /
                    (double)(lv[n - 1].boundary_cells ? lv[n - 1].boundary_cells : 1);
        double K = (double)lv[n].boundary_cells / pow(4.0, n);
        if (predict) {
            printf("growth per level: boundary cells x%.2f, volume error x%.3f (Clark's K = "
                   "boundary cells / "
                   "4^level = %.3g)\n",
                   gc, lv[n].volume_se / lv[n - 1].volume_se, K);
            for (int k = 1; k <= 4 && n + k <= 20; k++) {
                double pt, pe;
                crisp_frep_mass_predict(&lv[first], n - first + 1, n + k, &pt, &pe);
                printf("  level %2d  predicted: processor time %8.3f s  volume error %.2g "
                       "(relative %.2g)\n",
                       n + k, pt, pe, pe / fabs(lv[n].volume));
            }
        }
        target = n;
        double rel = lv[n].volume_se / fabs(lv[n].volume), tpred = 0;
        for (int L = n + 1; L <= 20; L++) {
            double pt, pe;
            crisp_frep_mass_predict(&lv[first], n - first + 1, L, &pt, &pe);
            if (accuracy) {
                if (rel <= accuracy) break;
                target = L, tpred = pt;
                if (pe / fabs(lv[n].volume) <= accuracy) break;
            } else if (time_limit) {
                if (spent + pt > time_limit) break;
                target = L, tpred = pt;
            }
        }
        if (target > 20) target = 20;
        double cap = time_limit ? time_limit : 600;
        if (tpred > cap) {
            fprintf(
                stderr,
                "crisp frep mass: level %d would take about %.0f s (over %.0f s); give a larger "
                "--time or a coarser --accuracy\n",
                target, tpred, cap);
            goto done;
        }
        if (target != n && predict) printf("running level %d (predicted %.3f s)\n", target, tpred);
    }
    crisp_frep_mass r;
    if (target == n && n > 0) {
        r = lv[n];
    } else {
        desc.level = target;
        s = mass_level(tape, &desc, &r, &warned);
        if (s) goto fail;
        if (predict) print_level(&r);
    }
    double area = 0, area_err = 0;
    s = mesh_area(tape, r.region, 1 << (r.level < 7 ? r.level : 7), &area, &area_err);
    if (s) goto fail;
    printf("level %d (cells %.3g), %zu boundary cells, %zu samples, %.3f s\n", r.level,
           fmax(r.cell[0], fmax(r.cell[1], r.cell[2])), r.boundary_cells, r.samples, r.seconds);
    printf("volume    %.12g +- %.3g (standard error); certified bounds [%.12g, %.12g]\n", r.volume,
           r.volume_se, r.volume_lo, r.volume_hi);
    printf("area      %.6g (mesh; +- %.2g between two resolutions)\n", area, area_err);
    printf("centroid  %.10g %.10g %.10g\n       +-  %.3g %.3g %.3g\n", r.centroid[0], r.centroid[1],
           r.centroid[2], r.centroid_se[0], r.centroid_se[1], r.centroid_se[2]);
    printf("inertia about the centroid (density 1): Ixx Iyy Izz Ixy Iyz Ixz\n  ");
    for (int k = 0; k < 6; k++)
        printf(" %.10g", r.inertia[k]);
    printf("\n +-");
    for (int k = 0; k < 6; k++)
        printf(" %.3g", r.inertia_se[k]);
    printf("\n");
    rc = 0;
    goto done;
fail:
    fprintf(stderr, "crisp frep mass: %s\n", crisp_error_message());
done:
    crisp_frep_tape_destroy(tape);
    crisp_frep_destroy(f);
    return rc;
}

/* ---- tiles (issue 15): --tile I/N renders one tile of the image, written with its header -- */

typedef struct frep_tile_out {
    const crisp_frep_image *img;
    int is3d, exr;
} frep_tile_out;

static crisp_status frep_tile_write(void *ctx, const char *tmp)
{
    const frep_tile_out *t = ctx;
    const crisp_frep_image *img = t->img;
    size_t npix = (size_t)img->width * (size_t)img->height;
    crisp_status s;
    if (!t->exr) {
        if (!t->is3d) return crisp_write_png_gray(tmp, img->width, img->height, img->inside);
        uint8_t *shade = malloc(npix);
        if (!shade) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
        crisp_frep_shade(img, shade);
        s = crisp_write_png_gray(tmp, img->width, img->height, shade);
        free(shade);
        return s;
    }
    float *buf = malloc(npix * 4 * sizeof *buf);
    if (!buf) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    for (size_t p = 0; p < npix; p++) {
        buf[4 * p] = t->is3d ? img->z[p] : (img->inside[p] ? 0.0f : -INFINITY);
        for (int c = 0; c < 3; c++)
            buf[4 * p + 1 + (size_t)c] = t->is3d ? img->normal[3 * p + (size_t)c] : 0;
    }
    const char *names[4] = {"Z", "N.x", "N.y", "N.z"};
    s = crisp_write_exr(tmp, img->width, img->height, 4, names, buf);
    free(buf);
    return s;
}

/* The tile's PNG and EXR, each with its header: the job is the input (file, or the -e string)
 * and every setting that changes a pixel. */
static int frep_write_tiles(const char *file, const char *expr, const crisp_frep_render_desc *d,
                            const crisp_cell_spec *tile, const crisp_frep_image *img,
                            const char *out, const char *depth_out)
{
    crisp_cell_header *h = calloc(1, sizeof *h);
    if (!h) return 1;
    snprintf(h->kind, sizeof h->kind, "image");
    const double *g = d->region;
    snprintf(h->settings, sizeof h->settings,
             "frep-render size=%dx%d depth=%d region=%.17g,%.17g,%.17g,%.17g,%.17g,%.17g "
             "flags=%u grid=%dx%d",
             d->width, d->height, d->depth, g[0], g[1], g[2], g[3], g[4], g[5], d->flags,
             tile->cols, tile->rows);
    crisp_status s = frep_job_id(file, expr, h);
    h->cell = *tile;
    memcpy(h->rect, d->window, sizeof d->window);
    h->rect[4] = d->width, h->rect[5] = d->height;
    frep_tile_out t = {img, d->depth > 0, 0};
    if (!s && out) s = crisp_cell_commit(out, h, frep_tile_write, &t);
    t.exr = 1;
    if (!s && depth_out) s = crisp_cell_commit(depth_out, h, frep_tile_write, &t);
    free(h);
    if (s) fprintf(stderr, "crisp frep: %s\n", crisp_error_message());
    return s ? 1 : 0;
}

static int cmd_render(int argc, char **argv, int bench);

int crisp_cmd_frep(int argc, char **argv)
{
    cli_cmd = "frep";
    if (argc < 2) {
        fputs(usage_frep, stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        fputs(usage_frep, stdout);
        return 0;
    }
    static const char *const names[4] = {"frep render", "frep bench", "frep mesh", "frep mass"};
    for (int k = 0; k < 4; k++)
        if (!strcmp(argv[1], names[k] + 5)) {
            cli_cmd = names[k];
            /* getopt_long sees the subcommand as argv[0] */
            switch (k) {
            case 0:
            case 1:
                return cmd_render(argc - 1, argv + 1, k == 1);
            case 2:
                return cmd_mesh(argc - 1, argv + 1);
            default:
                return cmd_mass(argc - 1, argv + 1);
            }
        }
    fprintf(stderr,
            "crisp frep: unknown subcommand '%s' (expected render, bench, mesh or mass)\n%s",
            argv[1], usage_frep);
    return 2;
}

static int cmd_render(int argc, char **argv, int bench)
{
    static const struct option opts[] = {{"expr", required_argument, 0, 'e'},
                                         {"output", required_argument, 0, 'o'},
                                         {"size", required_argument, 0, OPT_SIZE},
                                         {"3d", no_argument, 0, OPT_3D},
                                         {"depth", required_argument, 0, OPT_DEPTH},
                                         {"region", required_argument, 0, OPT_REGION},
                                         {"depth-out", required_argument, 0, OPT_DEPTH_OUT},
                                         {"threads", required_argument, 0, OPT_THREADS},
                                         {"runs", required_argument, 0, OPT_RUNS},
                                         {"stats", no_argument, 0, OPT_STATS},
                                         {"no-prune", no_argument, 0, OPT_NO_PRUNE},
                                         {"no-batch", no_argument, 0, OPT_NO_BATCH},
                                         {"no-subcells", no_argument, 0, OPT_NO_SUBCELLS},
                                         {"brute", no_argument, 0, OPT_BRUTE},
                                         {"tile", required_argument, 0, OPT_TILE},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *file = NULL, *expr = NULL, *out = NULL, *depth_out = NULL;
    crisp_frep_render_desc desc = {.width = 1024, .height = 1024};
    int is3d = 0, depth = 0, stats = 0, runs = 20, region_given = 0, c, tiled = 0;
    crisp_cell_spec tile = {0};
    getopt_start();
    while ((c = getopt_long(argc, argv, ":e:o:h", opts, NULL)) != -1) {
        switch (c) {
        case 'e':
            expr = optarg;
            break;
        case 'o':
            out = optarg;
            break;
        case OPT_SIZE:
            if (strchr(optarg, 'x') || strchr(optarg, 'X')) {
                if (!cli_size("--size", optarg, 16384, &desc.width, &desc.height)) return 2;
            } else {
                if (!cli_int("--size", optarg, 1, 16384, &desc.width)) return 2;
                desc.height = desc.width;
            }
            break;
        case OPT_3D:
            is3d = 1;
            break;
        case OPT_DEPTH:
            if (!cli_int("--depth", optarg, 1, 65536, &depth)) return 2;
            break;
        case OPT_REGION:
            if (!parse_region(optarg, 1, desc.region)) return 2;
            region_given = 1;
            break;
        case OPT_DEPTH_OUT:
            depth_out = optarg;
            break;
        case OPT_THREADS:
            if (!cli_int("--threads", optarg, 1, 1024, &desc.threads)) return 2;
            break;
        case OPT_RUNS:
            if (!cli_int("--runs", optarg, 1, 100000, &runs)) return 2;
            break;
        case OPT_STATS:
            stats = 1;
            break;
        case OPT_NO_PRUNE:
            desc.flags |= CRISP_FREP_NO_PRUNE;
            break;
        case OPT_NO_SUBCELLS:
            desc.flags |= CRISP_FREP_NO_SUBCELLS;
            break;
        case OPT_NO_BATCH:
            desc.flags |= CRISP_FREP_NO_BATCH;
            break;
        case OPT_BRUTE:
            desc.flags |= CRISP_FREP_BRUTE;
            break;
        case OPT_TILE:
            if (!cli_cell("--tile", optarg, &tile)) return 2;
            tiled = 1;
            break;
        case 'h':
            fputs(usage_render, stdout);
            return 0;
        default:
            cli_bad_option(c, argv);
            return 2;
        }
    }
    if (!take_file(argc, argv, expr, &file, usage_render)) return 2;
    if (out && !ends_with(out, ".png")) {
        fprintf(stderr, "crisp %s: -o %s: expected a name ending in .png\n", cli_cmd, out);
        return 2;
    }
    if (depth_out && !ends_with(depth_out, ".exr")) {
        fprintf(stderr, "crisp %s: --depth-out %s: expected a name ending in .exr\n", cli_cmd,
                depth_out);
        return 2;
    }
    if (depth && !is3d) {
        fprintf(stderr, "crisp %s: --depth %d needs --3d\n", cli_cmd, depth);
        return 2;
    }
    if (tiled && crisp_tile_grid(desc.width, desc.height, &tile)) {
        fprintf(stderr, "crisp frep: --tile: %s\n", crisp_error_message());
        return 2;
    }
    if (is3d)
        desc.depth = depth > 0 ? depth : (desc.width > desc.height ? desc.width : desc.height);
    int nsetup = bench ? runs : 1;
    double *setup = calloc((size_t)nsetup, sizeof *setup),
           *render = calloc((size_t)runs, sizeof *render);
    crisp_frep *f = NULL;
    crisp_frep_tape *tape = NULL;
    crisp_frep_renderer *r = NULL;
    int rc = 1;
    if (!setup || !render) goto done;
    for (int n = 0; n < nsetup; n++) {
        crisp_frep_renderer_destroy(r);
        crisp_frep_tape_destroy(tape);
        crisp_frep_destroy(f);
        r = NULL, tape = NULL, f = NULL;
        double t0 = crisp_time_now();
        crisp_status s;
        if (expr)
            s = crisp_frep_read_math_mem("-e", expr, strlen(expr), &f);
        else if (ends_with(file, ".vm"))
            s = crisp_frep_read_vm(file, &f);
        else
            s = crisp_frep_read_math(file, &f);
        if (!s) s = crisp_frep_tape_create(f, &tape);
        if (!s && !region_given && n == 0) s = fit_region(tape, is3d, &desc);
        if (!s && tiled) crisp_tile_rect(desc.width, desc.height, &tile, desc.window);
        if (!s) s = crisp_frep_renderer_create(tape, &desc, &r);
        if (s) {
            fprintf(stderr, "crisp %s: %s\n", cli_cmd, crisp_error_message());
            goto done;
        }
        setup[n] = crisp_time_now() - t0;
    }
    for (int n = 0; n < (bench ? runs : 1); n++) {
        double t0 = crisp_time_now();
        crisp_status s = crisp_frep_renderer_run(r);
        render[n] = crisp_time_now() - t0;
        if (s) {
            fprintf(stderr, "crisp %s: %s\n", cli_cmd, crisp_error_message());
            goto done;
        }
    }
    const crisp_frep_image *img = crisp_frep_renderer_image(r);
    size_t npix = (size_t)img->width * (size_t)img->height, inside = 0;
    for (size_t p = 0; p < npix; p++)
        inside += img->inside[p] != 0;
    if (!inside && !tiled) /* a tile may well be empty */
        fprintf(stderr,
                "crisp %s: empty image: no sample of [%g, %g] x [%g, %g]%s is inside the part\n",
                cli_cmd, desc.region[0], desc.region[1], desc.region[2], desc.region[3],
                is3d ? " x [z]" : "");
    if (bench) {
        qsort(render, (size_t)runs, sizeof *render, cmp_double);
        qsort(setup, (size_t)nsetup, sizeof *setup, cmp_double);
        char dims[48];
        if (is3d)
            snprintf(dims, sizeof dims, "%dx%dx%d", img->width, img->height, img->depth);
        else
            snprintf(dims, sizeof dims, "%dx%d", img->width, img->height);
        printf("%s %s, threads %d: render median %.3f ms (min %.3f, max %.3f, %d runs), set-up "
               "median %.3f ms\n",
               expr ? "-e" : file, dims,
               desc.threads > 0 ? desc.threads : crisp_pool_default_threads(),
               1000 * render[runs / 2], 1000 * render[0], 1000 * render[runs - 1], runs,
               1000 * setup[nsetup / 2]);
    }
    if (stats || !bench) {
        crisp_frep_render_stats st = crisp_frep_renderer_stats(r);
        if (stats)
            printf("nodes %zu, tape %zu instructions, %d registers; intervals %zu, filled %zu, "
                   "leaves %zu "
                   "(mean tape %.1f), points %zu, culled %zu; %zu of %zu pixels inside; render "
                   "%.3f ms, "
                   "set-up %.3f ms\n",
                   crisp_frep_node_count(f), crisp_frep_tape_length(tape),
                   crisp_frep_tape_registers(tape), st.intervals, st.filled, st.leaves,
                   st.leaves ? (double)st.tape_sum / st.leaves : 0.0, st.points, st.culled, inside,
                   npix, 1000 * render[0], 1000 * setup[0]);
    }
    if (tiled) {
        rc = frep_write_tiles(file, expr, &desc, &tile, img, out, depth_out);
        goto done;
    }
    if (out) {
        crisp_status s;
        if (!is3d) {
            s = crisp_write_png_gray(out, img->width, img->height, img->inside);
        } else {
            uint8_t *shade = malloc(npix);
            if (!shade) goto done;
            crisp_frep_shade(img, shade);
            s = crisp_write_png_gray(out, img->width, img->height, shade);
            free(shade);
        }
        if (s) {
            fprintf(stderr, "crisp %s: %s\n", cli_cmd, crisp_error_message());
            goto done;
        }
    }
    if (depth_out) {
        float *buf = malloc(npix * 4 * sizeof *buf);
        if (!buf) goto done;
        for (size_t p = 0; p < npix; p++) {
            buf[4 * p] = is3d ? img->z[p] : (img->inside[p] ? 0.0f : -INFINITY);
            for (int c = 0; c < 3; c++)
                buf[4 * p + 1 + (size_t)c] = is3d ? img->normal[3 * p + (size_t)c] : 0;
        }
        const char *names[4] = {"Z", "N.x", "N.y", "N.z"};
        crisp_status s = crisp_write_exr(depth_out, img->width, img->height, 4, names, buf);
        free(buf);
        if (s) {
            fprintf(stderr, "crisp %s: %s\n", cli_cmd, crisp_error_message());
            goto done;
        }
    }
    rc = 0;
done:
    crisp_frep_renderer_destroy(r);
    crisp_frep_tape_destroy(tape);
    crisp_frep_destroy(f);
    free(setup);
    free(render);
    return rc;
}
