/* What a window app opens: a CAD model (IGES, STEP, OBJ), an f-rep part (.vm file or a file
 * holding a math string) or a scene file mixing both, prepared for rendering, with its box and the
 * files it was read from (for watching). Stands in for the library's "open a model or scene file"
 * API (issue 16) until that lands.
 *
 * Offers:
 *   app_doc, app_doc_load, app_doc_destroy
 */
#ifndef APP_DOC_H
#define APP_DOC_H

#include <stddef.h>

#include "crisp/model.h"
#include "crisp/render.h"
#include "crisp/scene_file.h"

#ifdef __cplusplus
extern "C" {
#endif

#define APP_DOC_MAX_BYTES (1ull << 30) /* files larger than this are refused with a message */

typedef struct app_doc {
    char *path;
    const char *kind;             /* "IGES", "STEP", "OBJ", "f-rep", "scene" */
    crisp_model *model;           /* owned unless assets holds it */
    crisp_scene_file *scene_file; /* scene files and f-rep parts */
    crisp_scene_assets *assets;
    crisp_scene *scene;           /* prepared model (may have no faces) */
    const crisp_frep_part *parts;
    size_t part_count;
    double box[6];                /* faces' trimmed box and each part's [-1, 1]^3, transformed */
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
