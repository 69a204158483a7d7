/* Opening a file for the window apps (doc.h): by content and extension, in the order scene file,
 * .vm, CAD model, math string. */
#include "doc.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "crisp/io.h"

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && !strcmp(s + n - m, suffix);
}

static crisp_status add_watch(app_doc *d, const char *path)
{
    char **w = realloc(d->watch, (d->watch_count + 1) * sizeof *w);
    if (!w) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    d->watch = w;
    if (!(w[d->watch_count] = strdup(path))) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    d->watch_count++;
    return CRISP_OK;
}

static crisp_status load_scene_text(app_doc *d, const char *name, const char *text)
{
    crisp_status st = crisp_scene_file_read_mem(name, "", text, strlen(text), &d->scene_file);
    if (!st) st = crisp_scene_assets_load(d->scene_file, &d->assets);
    return st;
}

/* An f-rep part file as a one-line scene: "frep PATH". */
static crisp_status load_frep(app_doc *d, const char *path)
{
    if (strchr(path, '"') || strchr(path, '\n'))
        return crisp_error(CRISP_ERR_UNSUPPORTED, "%s: f-rep file names with '\"' are not supported", path);
    size_t n = strlen(path) + 16;
    char *text = malloc(n);
    if (!text) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    snprintf(text, n, "frep \"%s\"\n", path);
    crisp_status st = load_scene_text(d, path, text);
    free(text);
    return st;
}

crisp_status app_doc_load(const char *path, app_doc **dest)
{
    *dest = NULL;
    struct stat sb;
    if (stat(path, &sb) != 0)
        return crisp_error(CRISP_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (S_ISDIR(sb.st_mode))
        return crisp_error(CRISP_ERR_IO, "%s: is a folder, not a file (open an IGES, STEP, OBJ, .vm "
                                         "or .scene file)", path);
    if (!S_ISREG(sb.st_mode))
        return crisp_error(CRISP_ERR_IO, "%s: not a regular file", path);
    if ((unsigned long long)sb.st_size > APP_DOC_MAX_BYTES)
        return crisp_error(CRISP_ERR_LIMIT, "%s: %.1f GB: larger than the %.0f GB the viewer opens",
                           path, sb.st_size / 1e9, APP_DOC_MAX_BYTES / 1e9);
    app_doc *d = calloc(1, sizeof *d);
    if (!d || !(d->path = strdup(path))) {
        free(d);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    }
    crisp_status st = add_watch(d, path);
    double t0 = crisp_time_now();
    if (!st && crisp_scene_file_detect(path)) {
        d->kind = "scene";
        st = crisp_scene_file_read(path, &d->scene_file);
        if (!st) st = crisp_scene_assets_load(d->scene_file, &d->assets);
        for (size_t i = 0; !st && d->scene_file && i < d->scene_file->item_count; i++)
            if (d->scene_file->items[i].path) st = add_watch(d, d->scene_file->items[i].path);
    } else if (!st && ends_with(path, ".vm")) {
        d->kind = "f-rep";
        st = load_frep(d, path);
    } else if (!st) {
        st = crisp_model_load(path, NULL, &d->model);
        if (st == CRISP_ERR_UNSUPPORTED && sb.st_size < (1 << 20)) {
            /* not a CAD file: maybe a math string; if not, report the CAD error */
            char *msg = strdup(crisp_error_message());
            crisp_error_clear();
            if (load_frep(d, path) == CRISP_OK) {
                st = CRISP_OK;
                d->kind = "f-rep";
            } else {
                crisp_scene_assets_destroy(d->assets);
                crisp_scene_file_destroy(d->scene_file);
                d->assets = NULL;
                d->scene_file = NULL;
                crisp_error(st, "%s (nor a math string)", msg ? msg : "unknown format");
            }
            free(msg);
        } else if (!st) {
            d->kind = d->model->format;
        }
    }
    if (!st && d->assets) {
        d->parts = d->assets->parts;
        d->part_count = d->assets->part_count;
    }
    double t1 = crisp_time_now();
    const crisp_model *m = d->assets ? d->assets->model : d->model;
    if (!st && !m) st = crisp_model_create(&d->model), m = d->model;
    if (!st) st = crisp_scene_prepare(m, &d->scene);
    double t2 = crisp_time_now();
    if (!st && d->scene->patch_count == 0 && d->part_count == 0)
        st = crisp_error(CRISP_ERR_INVALID_ARG, "%s: no surfaces to show (%d faces read)", path,
                         m->face_count);
    if (st) {
        app_doc_destroy(d);
        return st;
    }
    d->ms_read = 1e3 * (t1 - t0);
    d->ms_prepare = 1e3 * (t2 - t1);
    for (int a = 0; a < 3; a++) d->box[a] = INFINITY, d->box[a + 3] = -INFINITY;
    if (d->scene->patch_count) memcpy(d->box, d->scene->box, sizeof d->box);
    for (size_t k = 0; k < d->part_count; k++)
        for (int c = 0; c < 8; c++) {
            double p[3] = {c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1}, w[4];
            crisp_mat4 mt;
            memcpy(mt, d->parts[k].transform, sizeof mt);
            crisp_mat4_mulp(mt, p, w);
            for (int a = 0; a < 3; a++) {
                d->box[a] = fmin(d->box[a], w[a]);
                d->box[a + 3] = fmax(d->box[a + 3], w[a]);
            }
        }
    *dest = d;
    return CRISP_OK;
}

void app_doc_destroy(app_doc *d)
{
    if (!d) return;
    crisp_scene_destroy(d->scene);
    if (d->assets) crisp_scene_assets_destroy(d->assets);
    crisp_model_destroy(d->model);
    crisp_scene_file_destroy(d->scene_file);
    for (size_t i = 0; i < d->watch_count; i++) free(d->watch[i]);
    free(d->watch);
    free(d->path);
    free(d);
}
