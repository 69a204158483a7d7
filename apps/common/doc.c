/* Opening a file for the window apps (doc.h) through crisp_document_open. */
#include "doc.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static crisp_status add_watch(app_doc *d, const char *path)
{
    char **w = realloc(d->watch, (d->watch_count + 1) * sizeof *w);
    if (!w) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    d->watch = w;
    if (!(w[d->watch_count] = strdup(path))) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    d->watch_count++;
    return CRISP_OK;
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
    if (!S_ISREG(sb.st_mode)) return crisp_error(CRISP_ERR_IO, "%s: not a regular file", path);
    if ((unsigned long long)sb.st_size > APP_DOC_MAX_BYTES)
        return crisp_error(CRISP_ERR_LIMIT, "%s: %.1f GB: larger than the %.0f GB the viewer opens",
                           path, sb.st_size / 1e9, APP_DOC_MAX_BYTES / 1e9);
    app_doc *d = calloc(1, sizeof *d);
    if (!d) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    crisp_status st = crisp_document_open(path, NULL, &d->doc);
    if (st) {
        free(d);
        return st;
    }
    const crisp_document *doc = d->doc;
    d->path = doc->path;
    d->kind = doc->kind == CRISP_DOCUMENT_SCENE ? "scene"
              : doc->kind == CRISP_DOCUMENT_FREP ? "f-rep"
                                                 : doc->model->format;
    d->scene = doc->scene;
    d->parts = doc->parts;
    d->part_count = doc->part_count;
    /* the sample points' box, grown to the scene's (its patches' boxes within the trims' uv
     * box: it holds all of the geometry, so near and far never cut it) */
    memcpy(d->box, doc->box, sizeof d->box);
    if (doc->scene->patch_count)
        for (int a = 0; a < 3; a++) {
            if (doc->scene->box[a] < d->box[a]) d->box[a] = doc->scene->box[a];
            if (doc->scene->box[a + 3] > d->box[a + 3]) d->box[a + 3] = doc->scene->box[a + 3];
        }
    d->ms_read = doc->ms_load;
    d->ms_prepare = doc->ms_prepare;
    st = add_watch(d, path);
    const crisp_scene_file *sf = doc->kind == CRISP_DOCUMENT_SCENE ? doc->scene_file : NULL;
    for (size_t i = 0; !st && sf && i < sf->item_count; i++)
        if (sf->items[i].path) st = add_watch(d, sf->items[i].path);
    if (st) {
        app_doc_destroy(d);
        return st;
    }
    *dest = d;
    return CRISP_OK;
}

void app_doc_destroy(app_doc *d)
{
    if (!d) return;
    crisp_document_destroy(d->doc);
    for (size_t i = 0; i < d->watch_count; i++) free(d->watch[i]);
    free(d->watch);
    free(d);
}
