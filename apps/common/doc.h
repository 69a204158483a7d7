/* What a window app opens: a crisp_document (include/crisp/app.h: a CAD model, an f-rep part or
 * a scene file, prepared, with points of its true trimmed geometry to frame), plus what the
 * window apps need beside it: a size limit checked before reading, a short name of its kind and
 * the files it was read from (for watching).
 *
 * Offers:
 *   app_doc, app_doc_load, app_doc_destroy
 */
#ifndef APP_DOC_H
#define APP_DOC_H

#include <stddef.h>

#include "crisp/app.h"

#ifdef __cplusplus
extern "C" {
#endif

#define APP_DOC_MAX_BYTES (1ull << 30) /* files larger than this are refused with a message */

typedef struct app_doc {
    crisp_document *doc;
    const char *path;             /* doc->path */
    const char *kind;             /* "IGES", "STEP", "OBJ", "f-rep", "scene" */
    const crisp_scene *scene;     /* doc->scene (may have no faces) */
    const crisp_frep_part *parts; /* doc->parts */
    size_t part_count;
    double box[6];                /* doc->box (the sample points') grown to the scene's box */
    size_t watch_count;
    char **watch;                 /* the files read: the path and a scene's items */
    double ms_read, ms_prepare;
} app_doc;

/* Reads and prepares; on failure *dest is NULL and crisp_error_message() says why. */
crisp_status app_doc_load(const char *path, app_doc **dest);
void app_doc_destroy(app_doc *doc);

#ifdef __cplusplus
}
#endif
#endif
