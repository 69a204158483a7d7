/* crisp_document: one file opened into everything a frame needs (the model, its prepared scene,
 * the f-rep parts, the scene file's camera line and the box to frame). The format is chosen by
 * content for CAD models (src/io/load.c), by extension or first item line for scene files, by
 * extension for .vm, and a file that is none of these is tried as a math string. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "crisp/app.h"
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
    if (!st) st = vm ? crisp_frep_read_vm(path, &a->freps[0]) : crisp_frep_read_math(path, &a->freps[0]);
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

/* The trimmed faces' box joined with each part's [-1, 1]^3 (the region of the .vm models and of
 * the math strings' usual scale) through its transform. */
static void document_box(crisp_document *d)
{
    double *box = d->box;
    if (d->scene && d->scene->patch_count > 0) {
        memcpy(box, d->scene->box, sizeof d->box);
    } else {
        for (int a = 0; a < 3; a++) box[a] = INFINITY, box[a + 3] = -INFINITY;
    }
    for (size_t k = 0; k < d->part_count; k++)
        for (int c = 0; c < 8; c++) {
            double p[3] = {c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1}, w[4];
            crisp_mat4 m;
            memcpy(m, d->parts[k].transform, sizeof m);
            crisp_mat4_mulp(m, p, w);
            for (int a = 0; a < 3; a++) {
                box[a] = fmin(box[a], w[a]);
                box[a + 3] = fmax(box[a + 3], w[a]);
            }
        }
}

crisp_status crisp_document_open(const char *path, const crisp_document_desc *desc,
                                 crisp_document **dest)
{
    if (!path || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_document_open: NULL argument");
    *dest = NULL;
    const crisp_read_options *ro = desc ? desc->read : NULL;
    struct stat sb;
    if (stat(path, &sb) != 0)
        return crisp_error(CRISP_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (S_ISDIR(sb.st_mode))
        return crisp_error(CRISP_ERR_IO, "%s: is a directory (expected a model, scene or f-rep file)", path);
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
    double t2 = crisp_time_now();
    if (!st && d->scene->patch_count == 0 && d->part_count == 0)
        st = crisp_error(CRISP_ERR_INVALID_ARG, "%s: the file holds no surfaces or parts to render", path);
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
        memcpy(d->eye, sf->eye, sizeof d->eye);
        memcpy(d->target, sf->target, sizeof d->target);
        memcpy(d->up, sf->up, sizeof d->up);
        d->fov_deg = sf->fov_deg;
    }
    document_box(d);
    *dest = d;
    return CRISP_OK;
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
    crisp_free(d->path);
    crisp_free(d);
}
