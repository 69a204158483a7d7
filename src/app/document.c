/* crisp_document: one file opened into everything a frame needs (the model, its prepared scene,
 * the f-rep parts, the scene file's camera line and the points a camera frames). The format is
 * chosen by content for CAD models (src/io/load.c), by extension or first item line for scene
 * files, by extension for .vm, and a file that is none of these is tried as a math string. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "app_internal.h"
#include "crisp/frep.h"

/* The assets of a one-part document: the .vm or math-string part with the identity transform. */
static crisp_status open_frep(const char *path, int vm, crisp_scene_assets **dest)
{
    crisp_scene_assets *a = crisp_calloc_array(1, sizeof *a);
    crisp_status st = a ? crisp_model_create(&a->model) : CRISP_ERR_NO_MEMORY;
    if (!st) {
        a->parts = crisp_calloc_array(1, sizeof *a->parts);
        a->freps = crisp_calloc_array(1, sizeof *a->freps);
        a->tapes = crisp_calloc_array(1, sizeof *a->tapes);
        if (!a->parts || !a->freps || !a->tapes) st = CRISP_ERR_NO_MEMORY;
    }
    if (st == CRISP_ERR_NO_MEMORY) st = crisp_error(st, "%s: out of memory", path);
    if (!st)
        st = vm ? crisp_frep_read_vm(path, &a->freps[0]) : crisp_frep_read_math(path, &a->freps[0]);
    if (!st) st = crisp_frep_tape_create(a->freps[0], &a->tapes[0]);
    if (st) {
        if (a && a->freps) crisp_frep_destroy(a->freps[0]); /* part_count = 0: not freed below */
        crisp_scene_assets_destroy(a);
        return st;
    }
    a->part_count = 1;
    a->parts[0].tape = a->tapes[0];
    crisp_mat4_identity(a->parts[0].transform);
    a->parts[0].color[0] = 0.85f, a->parts[0].color[1] = 0.55f, a->parts[0].color[2] = 0.35f;
    a->parts[0].color[3] = 1;
    *dest = a;
    return CRISP_OK;
}

static int has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && !strcasecmp(path + n - e, ext);
}

/* A box of the part (in its own coordinates): interval subdivision of [-L, L]^3 level by level
 * keeps the cells whose interval may reach below 0 (or is unknown), down to cells L/64 wide or
 * until too many are kept; then points sampled in the kept cells give the box of what is inside
 * (grown by one sample spacing), much tighter than the intervals' cells. An axis along which
 * inside points reach the outer cube (an unbounded part: a 2D .vm model is a prism along Z; or
 * a part larger than L) gets [-1, 1], the .vm models' region. */
enum { PART_L = 4, PART_MAX_CELLS = 4096, PART_LEVELS = 7, PART_POINTS = 1 << 16 };

static void part_box(const crisp_frep_tape *t, double box[6], double **inside, size_t *inside_n)
{
    *inside = NULL;
    *inside_n = 0;
    float(*cells)[3] = crisp_malloc_array(8 * PART_MAX_CELLS, sizeof *cells);
    float(*kept)[3] = crisp_malloc_array(8 * PART_MAX_CELLS, sizeof *kept);
    float *px = NULL;
    for (int a = 0; a < 3; a++)
        box[a] = -1, box[a + 3] = 1;
    if (!cells || !kept) goto done;
    size_t n = 1, m = 0;
    float h = PART_L, kept_h = h; /* half width of the cells of this level */
    cells[0][0] = cells[0][1] = cells[0][2] = 0;
    int unbounded[3] = {0, 0, 0};
    /* First a cheap look at the outer cube's faces: inside points there mean an unbounded part
     * (a 2D .vm model is a prism along Z); its box is the default, without the subdivision. */
    {
        enum { G = 16 };
        float fx[6 * G * G], fy[6 * G * G], fz[6 * G * G], fv[6 * G * G];
        size_t q = 0;
        for (int f = 0; f < 6; f++)
            for (int i = 0; i < G; i++)
                for (int j = 0; j < G; j++) {
                    float c[3], u = -PART_L + 2.0f * PART_L * (i + 0.5f) / G;
                    float v = -PART_L + 2.0f * PART_L * (j + 0.5f) / G;
                    int a = f >> 1;
                    c[a] = f & 1 ? PART_L : -PART_L;
                    c[(a + 1) % 3] = u;
                    c[(a + 2) % 3] = v;
                    fx[q] = c[0], fy[q] = c[1], fz[q] = c[2];
                    q++;
                }
        if (crisp_frep_eval_batch(t, q, fx, fy, fz, fv)) goto done;
        for (size_t k = 0; k < q; k++)
            if (fv[k] < 0) goto done;
    }
    for (int level = 0; level <= PART_LEVELS; level++) {
        size_t k = 0;
        for (size_t c = 0; c < n; c++) {
            float x[2] = {cells[c][0] - h, cells[c][0] + h},
                  y[2] = {cells[c][1] - h, cells[c][1] + h};
            float z[2] = {cells[c][2] - h, cells[c][2] + h}, v[2];
            crisp_frep_eval_interval(t, x, y, z, v);
            if (v[0] >= 0) continue; /* outside everywhere (NaN: unknown, kept) */
            memcpy(kept[k++], cells[c], sizeof cells[c]);
        }
        m = k;
        kept_h = h;
        if (!m) goto done;
        if (level == PART_LEVELS || m > PART_MAX_CELLS) break;
        n = 0;
        float q = h / 2;
        for (size_t c = 0; c < m; c++)
            for (int e = 0; e < 8; e++) {
                cells[n][0] = kept[c][0] + (e & 1 ? q : -q);
                cells[n][1] = kept[c][1] + (e & 2 ? q : -q);
                cells[n][2] = kept[c][2] + (e & 4 ? q : -q);
                n++;
            }
        h = q;
    }
    /* points in the kept cells: s^3 per cell */
    int s = 2;
    while ((size_t)(s + 1) * (s + 1) * (s + 1) * m <= PART_POINTS && s < 16)
        s++;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    size_t cap = (size_t)s * s * s * m;
    if (!(px = crisp_malloc_array(4 * cap, sizeof(float)))) goto done;
    float *py = px + cap, *pz = py + cap, *val = pz + cap;
    size_t np = 0;
    for (size_t c = 0; c < m; c++)
        for (int e = 0; e < s * s * s; e++) {
            px[np] = kept[c][0] - kept_h + 2 * kept_h * (e % s + 0.5f) / s;
            py[np] = kept[c][1] - kept_h + 2 * kept_h * (e / s % s + 0.5f) / s;
            pz[np] = kept[c][2] - kept_h + 2 * kept_h * (e / (s * s) + 0.5f) / s;
            np++;
        }
    if (crisp_frep_eval_batch(t, np, px, py, pz, val)) goto done;
    double step = 2.0 * kept_h / s;
    for (size_t q = 0; q < np; q++)
        if (val[q] < 0) {
            double p[3] = {px[q], py[q], pz[q]};
            for (int a = 0; a < 3; a++) {
                lo[a] = fmin(lo[a], p[a] - step), hi[a] = fmax(hi[a], p[a] + step);
                if (fabs(p[a]) + step >= PART_L) unbounded[a] = 1;
            }
        }
    for (int a = 0; a < 3; a++)
        if (!unbounded[a] && lo[a] <= hi[a]) box[a] = lo[a], box[a + 3] = hi[a];
    /* bounded: the inside samples themselves frame the part (its silhouette, not its box) */
    if (!unbounded[0] && !unbounded[1] && !unbounded[2] && lo[0] <= hi[0]) {
        /* each inside sample stands for the cube of one spacing around it: its 6 neighbours
         * one spacing away along the axes (the part may reach that far between samples) */
        size_t n = 0;
        for (size_t q = 0; q < np; q++)
            n += val[q] < 0;
        double *pts = crisp_malloc_array(6 * n, 3 * sizeof(double));
        if (pts) {
            n = 0;
            for (size_t q = 0; q < np; q++)
                if (val[q] < 0)
                    for (int k = 0; k < 6; k++) {
                        double *d = pts + 3 * n++;
                        d[0] = px[q], d[1] = py[q], d[2] = pz[q];
                        d[k >> 1] += k & 1 ? step : -step;
                    }
            *inside = pts;
            *inside_n = n;
        }
    }
done:
    crisp_free(cells);
    crisp_free(kept);
    crisp_free(px);
}

/* What the default camera frames: points of the trimmed faces (sampled on the true surfaces,
 * drawn_box.c) and each part's inside samples (or its box's corners when it is unbounded;
 * part_box) through its transform; and their box. */
static crisp_status document_points(crisp_document *d)
{
    double *box = d->box, *pts = NULL;
    size_t n = 0;
    for (int a = 0; a < 3; a++)
        box[a] = INFINITY, box[a + 3] = -INFINITY;
    if (d->scene && d->scene->patch_count > 0) {
        crisp_status st = crisp__scene_drawn_points(d->scene, &pts, &n, box);
        if (st) return st;
    }
    for (size_t k = 0; k < d->part_count; k++) {
        double pb[6], *in = NULL;
        size_t in_n = 0;
        part_box(d->parts[k].tape, pb, &in, &in_n);
        size_t add = in_n ? in_n : 8;
        double *grown = crisp_realloc_array(pts, n + add, 3 * sizeof(double));
        if (!grown) {
            crisp_free(in);
            crisp_free(pts);
            return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", d->path);
        }
        pts = grown;
        crisp_mat4 m;
        memcpy(m, d->parts[k].transform, sizeof m);
        for (size_t c = 0; c < add; c++) {
            double p[3], w[4];
            if (in_n) {
                memcpy(p, in + 3 * c, sizeof p);
            } else {
                p[0] = pb[c & 1 ? 3 : 0], p[1] = pb[c & 2 ? 4 : 1], p[2] = pb[c & 4 ? 5 : 2];
            }
            crisp_mat4_mulp(m, p, w);
            memcpy(pts + 3 * n++, w, 3 * sizeof(double));
            for (int a = 0; a < 3; a++) {
                box[a] = fmin(box[a], w[a]);
                box[a + 3] = fmax(box[a + 3], w[a]);
            }
        }
        crisp_free(in);
    }
    d->points = pts;
    d->point_count = n;
    return CRISP_OK;
}

crisp_status crisp_document_open(const char *path, const crisp_document_desc *desc,
                                 crisp_document **dest)
{
    if (!path || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_document_open: NULL argument");
    *dest = NULL;
    const crisp_read_options *ro = desc ? desc->read : NULL;
    struct stat sb;
    if (stat(path, &sb) != 0)
        return crisp_error(CRISP_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (S_ISDIR(sb.st_mode))
        return crisp_error(CRISP_ERR_IO,
                           "%s: is a directory (expected a model, scene or f-rep file)", path);
    crisp_document *d = crisp_calloc_array(1, sizeof *d);
    size_t n = strlen(path);
    char *copy = crisp_malloc_array(n + 1, 1);
    if (!d || !copy) {
        crisp_free(d);
        crisp_free(copy);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", path);
    }
    memcpy(copy, path, n + 1);
    d->path = copy;
    double t0 = crisp_time_now();
    crisp_status st;
    if (crisp_scene_file_detect(path)) {
        d->kind = CRISP_DOCUMENT_SCENE;
        st = crisp_scene_file_read(path, &d->scene_file);
        if (!st) st = crisp_scene_assets_load(d->scene_file, &d->assets);
    } else if (has_ext(path, ".vm") || has_ext(path, ".math") || has_ext(path, ".expr")) {
        d->kind = CRISP_DOCUMENT_FREP;
        st = open_frep(path, has_ext(path, ".vm"), &d->assets);
    } else {
        d->kind = CRISP_DOCUMENT_MODEL;
        st = crisp_model_load(path, ro, &d->model);
        if (st == CRISP_ERR_UNSUPPORTED) {
            /* Not a CAD file: a math string? Keep the reader's message when it is not one. */
            char msg[1024];
            snprintf(msg, sizeof msg, "%s", crisp_error_message());
            if (!open_frep(path, 0, &d->assets)) {
                d->kind = CRISP_DOCUMENT_FREP;
                st = CRISP_OK;
            } else {
                st = crisp_error(st, "%s (nor a math string)", msg);
            }
        }
    }
    if (!st && d->assets) {
        d->model = d->assets->model;
        d->parts = d->assets->parts;
        d->part_count = d->assets->part_count;
    }
    double t1 = crisp_time_now();
    if (!st) st = crisp_scene_prepare(d->model, &d->scene);
    if (!st && d->scene->patch_count == 0 && d->part_count == 0)
        st = crisp_error(CRISP_ERR_INVALID_ARG, "%s: the file holds no surfaces or parts to render",
                         path);
    if (!st) st = document_points(d);
    double t2 = crisp_time_now();
    if (st) {
        crisp_document_destroy(d);
        return st;
    }
    d->ms_load = 1e3 * (t1 - t0);
    d->ms_prepare = 1e3 * (t2 - t1);
    const crisp_scene_file *sf = d->scene_file;
    if (sf && sf->has_camera) {
        d->has_camera = 1;
        d->has_target = sf->has_target;
        d->has_up = sf->has_up;
        memcpy(d->eye, sf->eye, sizeof d->eye);
        memcpy(d->target, sf->target, sizeof d->target);
        memcpy(d->up, sf->up, sizeof d->up);
        d->fov_deg = sf->fov_deg;
    }
    *dest = d;
    return CRISP_OK;
}

crisp_status crisp_document_update(crisp_document *d)
{
    if (!d) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_document_update: NULL document");
    double t0 = crisp_time_now();
    crisp_scene *scene = NULL;
    crisp_status st = crisp_scene_prepare(d->model, &scene);
    if (st) return st; /* the document keeps its old scene */
    crisp_scene_destroy(d->scene);
    d->scene = scene;
    crisp_free(d->points);
    d->points = NULL;
    d->point_count = 0;
    st = document_points(d);
    d->ms_prepare = 1e3 * (crisp_time_now() - t0);
    return st;
}

void crisp_document_destroy(crisp_document *d)
{
    if (!d) return;
    crisp_scene_destroy(d->scene);
    if (d->assets)
        crisp_scene_assets_destroy(d->assets);
    else
        crisp_model_destroy(d->model);
    crisp_scene_file_destroy(d->scene_file);
    crisp_free(d->points);
    crisp_free(d->path);
    crisp_free(d);
}
