/* crisp render FILE [options]: parse the options, open the file into a crisp_document, frame it,
 * render it (crisp_document_render) and write the outputs (include/crisp/app.h). Outputs and the
 * memory a frame needs are checked before any work starts. Camera and pixel conventions as
 * docs/design.md (camera). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "crisp/app.h"
#include "crisp/cells.h"

const char crisp_cmd_render_help[] =
    "render FILE [options]       render a model, a .scene file or an f-rep part to an image";

static const char usage_text[] =
    "usage: crisp render FILE [options]\n"
    "  Renders FILE (IGES, STEP or OBJ model by content, .scene file, .vm or math-string f-rep "
    "part)\n"
    "  and writes the picture. Options (default in brackets):\n"
    "  -o, --output FILE     image to write, .png (8-bit RGBA, alpha = coverage) or .exr (float\n"
    "                        R G B A Z N.x N.y N.z u v face) [out.png]\n"
    "      --aov FILE.exr    also write the EXR with every AOV [none]\n"
    "      --size WxH        image size in pixels, each 1..16384 (with --tile 1..65536) "
    "[1280x720]\n"
    "      --view NAME       front (seen from -Y), back, left, right, top (from +Z), bottom or "
    "iso\n"
    "                        (from 1,-1,1), +Z up, fitted to the trimmed geometry\n"
    "                        [the scene file's camera line, else iso]\n"
    "      --fit             keep the direction of --eye/--target (or the camera line) and move "
    "the\n"
    "                        camera so the geometry just fits [off]\n"
    "      --eye x,y,z       camera position [fitted]\n"
    "      --target x,y,z    point looked at [the middle of the box]\n"
    "      --up x,y,z        up direction [0,0,1; 0,1,0 / 0,-1,0 looking straight down / up]\n"
    "      --fov DEG         vertical field of view in (0, 180) [30]\n"
    "      --near N          near plane distance > 0 [encloses the box]\n"
    "      --far F           far plane distance > near [encloses the box]\n"
    "      --samples N       samples per pixel, 1, 4 or 16 (cpu and gl backends) [4 when a PNG is\n"
    "                        written with the cpu or gl backend, else 1]\n"
    "      --backend NAME    cpu (SLEFE tessellation, u-intercept tables), gl (the same plan "
    "drawn\n"
    "                        by OpenGL 4.5 on a headless EGL context) or exact (ray casting on\n"
    "                        the true surfaces and trim curves; slow) [cpu]\n"
    "      --threads N       worker threads, 1..1024 [CRISP_THREADS, else all cores]\n"
    "      --repeat N        render N frames of the same view with the same renderer, 1..100000 "
    "[1]\n"
    "      --stats           print counts and each stage's time (medians over --repeat) [off]\n"
    "      --max-memory SIZE refuse a frame estimated to need more (K, M, G, T suffixes); a frame\n"
    "                        over 2 GB prints a warning [8G]\n"
    "      --tile I/N        render only tile I (0..N-1, row-major) of N tiles of the image, or\n"
    "                        I/CxR of a C x R grid, bit for bit the same pixels (cpu, exact);\n"
    "                        each output gets a header OUT.cell for crisp merge [whole image]\n"
    "      --progress        show a progress bar on stderr [only when stderr is a terminal]\n"
    "      --no-progress     never show the progress bar\n"
    "  -q, --quiet           do not print the 'wrote FILE (WxH, N faces, T ms)' line\n"
    "  -h, --help            print this help and exit\n"
    "  Exit status: 0 success, 1 bad input or failure, 2 bad usage.\n";

typedef struct render_args {
    const char *path, *out, *aov;
    crisp_camera_desc cam;
    double eye[3], target[3], up[3];
    crisp_document_render_desc render;
    int samples_given, stats, quiet, repeat, progress;
    uint64_t max_memory;
    int tiled;            /* --tile */
    crisp_cell_spec tile; /* its grid (crisp_tile_grid) */
    int rect[4];          /* the tile's pixels */
} render_args;

enum {
    OPT_AOV = 256,
    OPT_SIZE,
    OPT_VIEW,
    OPT_FIT,
    OPT_EYE,
    OPT_TARGET,
    OPT_UP,
    OPT_FOV,
    OPT_NEAR,
    OPT_FAR,
    OPT_SAMPLES,
    OPT_BACKEND,
    OPT_THREADS,
    OPT_REPEAT,
    OPT_STATS,
    OPT_MAXMEM,
    OPT_PROGRESS,
    OPT_NO_PROGRESS,
    OPT_TILE
};

/* 0: run; 1: --help printed; 2: usage error (message printed). */
static int parse(int argc, char **argv, render_args *a)
{
    static const struct option opts[] = {{"output", required_argument, 0, 'o'},
                                         {"aov", required_argument, 0, OPT_AOV},
                                         {"size", required_argument, 0, OPT_SIZE},
                                         {"view", required_argument, 0, OPT_VIEW},
                                         {"fit", no_argument, 0, OPT_FIT},
                                         {"eye", required_argument, 0, OPT_EYE},
                                         {"target", required_argument, 0, OPT_TARGET},
                                         {"up", required_argument, 0, OPT_UP},
                                         {"fov", required_argument, 0, OPT_FOV},
                                         {"near", required_argument, 0, OPT_NEAR},
                                         {"far", required_argument, 0, OPT_FAR},
                                         {"samples", required_argument, 0, OPT_SAMPLES},
                                         {"backend", required_argument, 0, OPT_BACKEND},
                                         {"threads", required_argument, 0, OPT_THREADS},
                                         {"repeat", required_argument, 0, OPT_REPEAT},
                                         {"stats", no_argument, 0, OPT_STATS},
                                         {"max-memory", required_argument, 0, OPT_MAXMEM},
                                         {"progress", no_argument, 0, OPT_PROGRESS},
                                         {"no-progress", no_argument, 0, OPT_NO_PROGRESS},
                                         {"tile", required_argument, 0, OPT_TILE},
                                         {"quiet", no_argument, 0, 'q'},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    *a = (render_args){.cam = {.width = 1280, .height = 720},
                       .repeat = 1,
                       .progress = -1,
                       .max_memory = 8ull << 30};
    optind = 0; /* GNU getopt: start afresh */
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o':
            a->out = optarg;
            break;
        case OPT_AOV:
            a->aov = optarg;
            break;
        case OPT_SIZE:
            if (!cli_size("--size", optarg, 65536, &a->cam.width, &a->cam.height)) return 2;
            break;
        case OPT_VIEW:
            if (!crisp_view_parse(optarg, &a->cam.view)) {
                fprintf(stderr,
                        "crisp render: --view %s: expected front, back, left, right, top, bottom "
                        "or iso\n",
                        optarg);
                return 2;
            }
            break;
        case OPT_FIT:
            a->cam.fit = 1;
            break;
        case OPT_EYE:
            if (!cli_doubles("--eye", optarg, 3, a->eye)) return 2;
            a->cam.eye = a->eye;
            break;
        case OPT_TARGET:
            if (!cli_doubles("--target", optarg, 3, a->target)) return 2;
            a->cam.target = a->target;
            break;
        case OPT_UP:
            if (!cli_doubles("--up", optarg, 3, a->up)) return 2;
            a->cam.up = a->up;
            break;
        case OPT_FOV:
            if (!cli_double("--fov", optarg, 0, 180, 1, 1, &a->cam.fov_deg)) return 2;
            break;
        case OPT_NEAR:
            if (!cli_double("--near", optarg, 0, INFINITY, 1, 1, &a->cam.znear)) return 2;
            break;
        case OPT_FAR:
            if (!cli_double("--far", optarg, 0, INFINITY, 1, 1, &a->cam.zfar)) return 2;
            break;
        case OPT_SAMPLES:
            if (!cli_int("--samples", optarg, 1, 16, &a->render.samples)) return 2;
            if (a->render.samples != 1 && a->render.samples != 4 && a->render.samples != 16) {
                fprintf(stderr, "crisp render: --samples %s: expected 1, 4 or 16\n", optarg);
                return 2;
            }
            a->samples_given = 1;
            break;
        case OPT_BACKEND:
            if (!strcmp(optarg, "cpu")) {
                a->render.backend = CRISP_BACKEND_CPU;
            } else if (!strcmp(optarg, "exact")) {
                a->render.backend = CRISP_BACKEND_EXACT;
            } else if (!strcmp(optarg, "gl")) {
                a->render.backend = CRISP_BACKEND_GL;
            } else {
                fprintf(stderr, "crisp render: --backend %s: expected cpu, exact or gl\n", optarg);
                return 2;
            }
            break;
        case OPT_THREADS:
            if (!cli_int("--threads", optarg, 1, 1024, &a->render.threads)) return 2;
            break;
        case OPT_REPEAT:
            if (!cli_int("--repeat", optarg, 1, 100000, &a->repeat)) return 2;
            break;
        case OPT_STATS:
            a->stats = 1;
            break;
        case OPT_MAXMEM:
            if (!cli_bytes("--max-memory", optarg, &a->max_memory)) return 2;
            break;
        case OPT_PROGRESS:
            a->progress = 1;
            break;
        case OPT_NO_PROGRESS:
            a->progress = 0;
            break;
        case OPT_TILE:
            if (!cli_cell("--tile", optarg, &a->tile)) return 2;
            a->tiled = 1;
            break;
        case 'q':
            a->quiet = 1;
            break;
        case 'h':
            fputs(usage_text, stdout);
            return 1;
        default:
            cli_bad_option(c, argv);
            return 2;
        }
    }
    if (optind >= argc) {
        fprintf(stderr, "crisp render: no FILE given\n%s", usage_text);
        return 2;
    }
    if (optind + 1 < argc) {
        fprintf(stderr, "crisp render: more than one FILE given ('%s', '%s')\n", argv[optind],
                argv[optind + 1]);
        return 2;
    }
    a->path = argv[optind];
    if (a->cam.view != CRISP_VIEW_DEFAULT && a->cam.eye) {
        fprintf(stderr, "crisp render: --view and --eye both place the camera: give one (--fit "
                        "refits --eye)\n");
        return 2;
    }
    if (!a->out && !a->aov) a->out = "out.png";
    int cpu = a->render.backend != CRISP_BACKEND_EXACT; /* cpu and gl take samples */
    if (!cpu && a->samples_given && a->render.samples != 1) {
        fprintf(
            stderr,
            "crisp render: the exact backend casts one ray per pixel centre; --samples %d needs "
            "the cpu backend\n",
            a->render.samples);
        return 2;
    }
    if (!a->samples_given)
        a->render.samples =
            cpu && a->out && crisp_image_format_of(a->out) == CRISP_IMAGE_PNG ? 4 : 1;
    if (!a->tiled && (a->cam.width > 16384 || a->cam.height > 16384)) {
        fprintf(stderr,
                "crisp render: --size %dx%d: each side at most 16384 in one piece; larger "
                "images are rendered in tiles (--tile, crisp jobs render)\n",
                a->cam.width, a->cam.height);
        return 2;
    }
    if (a->tiled) {
        if (a->render.backend == CRISP_BACKEND_GL) {
            fprintf(stderr, "crisp render: --tile draws with the cpu and exact backends only (the "
                            "gl backend's float rounding changes with a tile's projection)\n");
            return 2;
        }
        if (a->repeat != 1) {
            fprintf(stderr, "crisp render: --tile and --repeat do not go together\n");
            return 2;
        }
        if (crisp_tile_grid(a->cam.width, a->cam.height, &a->tile)) {
            fprintf(stderr, "crisp render: --tile: %s\n", crisp_error_message());
            return 2;
        }
        crisp_tile_rect(a->cam.width, a->cam.height, &a->tile, a->rect);
    }
    return 0;
}

/* Outputs and memory, before the work starts. */
static int check_outputs(const render_args *a)
{
    if ((a->out && crisp_image_output_check(a->out, CRISP_IMAGE_UNKNOWN)) ||
        (a->aov && crisp_image_output_check(a->aov, CRISP_IMAGE_EXR))) {
        fprintf(stderr, "crisp render: %s\n", crisp_error_message());
        return 0;
    }
    /* a tile draws its pixels and a ring of up to 64 more on each side (crisp_document_render) */
    uint64_t need =
        a->tiled
            ? crisp_render_memory_estimate(a->rect[2] + 128, a->rect[3] + 128, a->render.samples) +
                  (uint64_t)a->rect[2] * (uint64_t)a->rect[3] * 56u
            : crisp_render_memory_estimate(a->cam.width, a->cam.height, a->render.samples);
    char nb[32], lb[32];
    cli_format_bytes(need, nb, sizeof nb);
    cli_format_bytes(a->max_memory, lb, sizeof lb);
    if (need > a->max_memory) {
        fprintf(
            stderr,
            "crisp render: --size %dx%d with %d sample(s) per pixel needs about %s, more than the "
            "limit of %s (raise it with --max-memory, or lower --size or --samples)\n",
            a->cam.width, a->cam.height, a->render.samples, nb, lb);
        return 0;
    }
    if (need > (2ull << 30))
        fprintf(stderr,
                "crisp render: warning: --size %dx%d with %d sample(s) per pixel needs about %s\n",
                a->cam.width, a->cam.height, a->render.samples, nb);
    return 1;
}

typedef struct frame_times {
    double *total, *levels, *edges, *trim, *tess, *raster, *resolve, *faces, *parts;
} frame_times;

static void print_stats(const render_args *a, const crisp_document *doc, const crisp_camera *cam,
                        const crisp_image *img, const crisp_render_stats *rs, frame_times *t,
                        double ms_write)
{
    int cpu = a->render.backend == CRISP_BACKEND_CPU;
    size_t n = (size_t)img->width * img->height, drawn = 0, frep_drawn = 0;
    for (size_t i = 0; i < n; i++) {
        drawn += img->face[i] >= 0;
        frep_drawn += img->face[i] <= -2;
    }
    const crisp_scene *sc = doc->scene;
    size_t r = (size_t)a->repeat;
    printf("backend          %s\n", cpu ? "cpu (SLEFE tessellation, u-intercept tables)"
                                    : a->render.backend == CRISP_BACKEND_GL
                                        ? "gl (OpenGL 4.5 tessellation, u-intercept tables)"
                                        : "exact (ray casting, exact trim classifier)");
    printf("samples          %d\n", a->render.samples);
    printf("faces            %u\n", sc->face_count);
    printf("patches          %u\n", sc->patch_count);
    printf("trim pieces      %u\n", sc->piece_count);
    printf("box              %g %g %g .. %g %g %g\n", doc->box[0], doc->box[1], doc->box[2],
           doc->box[3], doc->box[4], doc->box[5]);
    printf("camera           eye %g,%g,%g target %g,%g,%g up %g,%g,%g fov %g near %g far %g\n",
           cam->eye[0], cam->eye[1], cam->eye[2], cam->target[0], cam->target[1], cam->target[2],
           cam->up[0], cam->up[1], cam->up[2], cam->fov_deg, cam->znear, cam->zfar);
    if (cpu && sc->patch_count) {
        printf("patches drawn    %u (%u split, %u leaves)\n", rs->visible_patches,
               rs->split_patches, rs->leaves);
        printf("faces drawn      %u\n", rs->visible_faces);
        if (rs->splat_faces)
            printf("faces as splats  %u (%llu splats: faces so small on screen that point samples "
                   "cover them)\n",
                   rs->splat_faces, (unsigned long long)rs->splats);
        if (rs->hidden_faces)
            printf("faces hidden     %u not planned (hidden whole behind the faces drawn first)\n",
                   rs->hidden_faces);
        printf("triangles        %llu\n", (unsigned long long)rs->triangles);
        if (rs->occluded_triangles)
            printf("triangles hidden %llu not tessellated (%llu leaves behind drawn depth)\n",
                   (unsigned long long)rs->occluded_triangles,
                   (unsigned long long)rs->occluded_leaves);
        printf("vertices         %llu\n", (unsigned long long)rs->vertices);
        printf("table rows       %llu\n", (unsigned long long)rs->table_rows);
        printf("table bytes      %llu\n", (unsigned long long)rs->table_bytes);
        if (rs->unresolved)
            printf("unresolved       %u leaves at the split limit (0.5 px not guaranteed there)\n",
                   rs->unresolved);
    }
    printf("pixels covered   %zu of %zu\n", drawn, n);
    if (doc->part_count) {
        printf("f-rep parts      %zu\n", doc->part_count);
        printf("f-rep pixels     %zu\n", frep_drawn);
    }
    printf("time load        %.1f ms\n", doc->ms_load);
    printf("time prepare     %.1f ms\n", doc->ms_prepare);
    const char *med = r > 1 ? " (median)" : "";
    if (cpu && sc->patch_count) {
        printf("time levels      %.2f ms%s\n", cli_median(t->levels, r), med);
        printf("time edges       %.2f ms%s\n", cli_median(t->edges, r), med);
        printf("time trim plan   %.2f ms%s\n", cli_median(t->trim, r), med);
        printf("time tessellate  %.2f ms%s\n", cli_median(t->tess, r), med);
        printf("time rasterize   %.2f ms%s\n", cli_median(t->raster, r), med);
        printf("time resolve     %.2f ms%s\n", cli_median(t->resolve, r), med);
    }
    printf("time render      %.2f ms%s\n", cli_median(t->total, r), med);
    if (doc->part_count) {
        printf("time faces       %.2f ms%s\n", cli_median(t->faces, r), med);
        printf("time f-rep parts %.2f ms%s\n", cli_median(t->parts, r), med);
    }
    if (r > 1) printf("frames           %zu\n", r);
    printf("time write       %.1f ms\n", ms_write);
}

/* ---- tiles (issue 15) ------------------------------------------------------------------- */

typedef struct tile_write {
    const crisp_image *img;
    int exr;
} tile_write;

static crisp_status write_tile_data(void *ctx, const char *tmp)
{
    const tile_write *t = ctx;
    return t->exr ? crisp_image_write_exr(t->img, tmp) : crisp_image_write(t->img, tmp);
}

/* The tile's image through a temporary file, its header at OUT.cell: the job (the input file's
 * bytes and every setting that changes a pixel: the camera as resolved, size, samples, backend,
 * the grid), which tile, where. */
static crisp_status write_tile(const render_args *a, const crisp_camera *c, const crisp_image *img,
                               const char *path, int exr)
{
    crisp_cell_header *h = calloc(1, sizeof *h);
    if (!h) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    snprintf(h->kind, sizeof h->kind, "image");
    snprintf(h->settings, sizeof h->settings,
             "render size=%dx%d samples=%d backend=cpu eye=%.17g,%.17g,%.17g "
             "target=%.17g,%.17g,%.17g up=%.17g,%.17g,%.17g fov=%.17g near=%.17g far=%.17g "
             "grid=%dx%d",
             c->width, c->height, a->render.samples, c->eye[0], c->eye[1], c->eye[2], c->target[0],
             c->target[1], c->target[2], c->up[0], c->up[1], c->up[2], c->fov_deg, c->znear,
             c->zfar, a->tile.cols, a->tile.rows);
    crisp_status s = crisp_cell_job_id(a->path, h->settings, &h->job);
    h->cell = a->tile;
    memcpy(h->rect, a->rect, sizeof a->rect);
    h->rect[4] = c->width, h->rect[5] = c->height;
    tile_write tw = {img, exr};
    if (!s) s = crisp_cell_commit(path, h, write_tile_data, &tw);
    free(h);
    return s;
}

int crisp_cmd_render(int argc, char **argv)
{
    cli_cmd = "render";
    render_args a;
    int rc = parse(argc, argv, &a);
    if (rc) return rc == 1 ? 0 : 2;
    if (!check_outputs(&a)) return 2;

    crisp_document *doc = NULL;
    crisp_renderer *renderer = NULL;
    crisp_image img = {0};
    crisp_render_stats rs = {0};
    double *times = crisp_calloc_array((size_t)a.repeat, 9 * sizeof(double));
    frame_times ft = {0};
    crisp_status st = times ? CRISP_OK : crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    if (!st) {
        size_t r = (size_t)a.repeat;
        ft =
            (frame_times){times,         times + r,     times + 2 * r, times + 3 * r, times + 4 * r,
                          times + 5 * r, times + 6 * r, times + 7 * r, times + 8 * r};
    }
    cli_progress_begin(a.progress, "loading");
    if (!st) st = crisp_document_open(a.path, NULL, &doc);
    cli_progress_end();
    crisp_camera cam;
    if (!st) st = crisp_document_camera(doc, &a.cam, &cam);
    if (!st && a.tiled && (cam.width != a.cam.width || cam.height != a.cam.height))
        st = crisp_error(CRISP_ERR_INTERNAL, "the camera is %dx%d, not the --size %dx%d", cam.width,
                         cam.height, a.cam.width, a.cam.height);
    if (!st && a.tiled) {
        memcpy(a.render.window, a.rect, sizeof a.rect);
        st = crisp_image_init(&img, a.rect[2], a.rect[3]);
    } else if (!st) {
        st = crisp_image_init(&img, cam.width, cam.height);
    }
    if (!st && a.render.backend == CRISP_BACKEND_CPU && doc->scene->patch_count > 0)
        st = crisp_renderer_create(
            /* Splat sets are built the first time a frame wants them and pay off over the
             * frames that follow (docs/status/issue-12-splats.md): one frame draws every face
             * by tessellation. */
            &(crisp_render_desc){.samples = a.render.samples,
                                 .threads = a.render.threads,
                                 .no_splats = a.repeat == 1},
            &renderer);
    a.render.renderer = renderer;
    crisp_document_times dt = {0};
    a.render.times = &dt;
    cli_progress_begin(a.progress, "rendering");
    for (int k = 0; k < a.repeat && !st; k++) {
        double t0 = crisp_time_now();
        st = crisp_document_render(doc, &cam, &a.render, &img, &rs);
        ft.total[k] = 1e3 * (crisp_time_now() - t0);
        ft.levels[k] = rs.ms_levels;
        ft.edges[k] = rs.ms_edges;
        ft.trim[k] = rs.ms_trim;
        ft.tess[k] = rs.ms_tess;
        ft.raster[k] = rs.ms_raster;
        ft.resolve[k] = rs.ms_resolve;
        ft.faces[k] = dt.ms_faces;
        ft.parts[k] = dt.ms_parts;
    }
    cli_progress_end();
    /* the frame time: the median over --repeat (cli_median sorts the times in place, which the
     * medians of print_stats do not mind) */
    double ms_render = st ? 0 : cli_median(ft.total, (size_t)a.repeat);
    double t_write = crisp_time_now();
    if (!st && a.tiled) {
        if (a.out) st = write_tile(&a, &cam, &img, a.out, 0);
        if (!st && a.aov) st = write_tile(&a, &cam, &img, a.aov, 1);
    } else {
        if (!st && a.out) st = crisp_image_write(&img, a.out);
        if (!st && a.aov) st = crisp_image_write_exr(&img, a.aov);
    }
    double ms_write = 1e3 * (crisp_time_now() - t_write);
    if (st) {
        fprintf(stderr, "crisp render: %s\n", crisp_error_message());
    } else {
        if (!a.quiet) {
            const char *files[2] = {a.out, a.aov};
            for (int i = 0; i < 2; i++)
                if (files[i]) {
                    printf("wrote %s (%dx%d, %u faces", files[i], img.width, img.height,
                           doc->scene->face_count);
                    if (a.tiled)
                        printf(", tile %d of %d at (%d, %d) of %dx%d", a.tile.index, a.tile.count,
                               a.rect[0], a.rect[1], cam.width, cam.height);
                    if (doc->part_count)
                        printf(", %zu f-rep part%s", doc->part_count,
                               doc->part_count > 1 ? "s" : "");
                    printf(", %.0f ms)\n", ms_render);
                }
        }
        if (a.stats) print_stats(&a, doc, &cam, &img, &rs, &ft, ms_write);
    }
    crisp_renderer_destroy(renderer);
    crisp_image_free(&img);
    crisp_document_destroy(doc);
    crisp_free(times);
    return st ? 1 : 0;
}
