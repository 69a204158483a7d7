/* crisp scene files: NURBS models and f-rep parts placed together (README.md, "Scene files").
 *
 * Offers:
 *   crisp_scene_file                 the parsed lines (what to load, where, in which colour)
 *   crisp_scene_file_read/_read_mem  the text format, errors as "file:line:column: expected ..."
 *   crisp_scene_file_detect          whether a file is a scene file (by extension or content)
 *   crisp_scene_assets               what a scene file loads into: one merged model (item
 *                                    transforms applied to control points) and f-rep parts
 *   crisp_scene_assets_load/_destroy
 *
 * Format: one item a line, '#' starts a comment.
 *   model PATH            [OPS] [color r g b]
 *   frep  PATH            [OPS] [color r g b]    PATH.vm: the .vm format; else a math-string file
 *   frep  math "EXPR"     [OPS] [color r g b]    an inline math string (docs/design.md section 7)
 *   camera eye x y z [target x y z] [up x y z] [fov degrees]   at most one; the view that
 *                                                  `crisp render` uses without --eye
 * OPS, applied in the order written: translate x y z | scale s | scale sx sy sz |
 * rotate ax ay az degrees | transform m00 m01 m02 m03 ... m33 (16 numbers, row by row, last row
 * 0 0 0 1). Relative paths are relative to the scene file's folder; a path with spaces is
 * written in double quotes. */
#ifndef CRISP_SCENE_FILE_H
#define CRISP_SCENE_FILE_H

#include <stddef.h>

#include "crisp/model.h"
#include "crisp/render.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum crisp_scene_item_kind { CRISP_SCENE_MODEL, CRISP_SCENE_FREP } crisp_scene_item_kind;

typedef struct crisp_scene_item {
    crisp_scene_item_kind kind;
    char *path;           /* resolved against the scene file's folder; NULL for inline math */
    char *math;           /* inline math string, or NULL */
    crisp_mat4 transform; /* object to world, m[col][row] */
    int has_color;
    float color[4];
    int line; /* in the scene file, for messages */
} crisp_scene_item;

typedef struct crisp_scene_file {
    char *name; /* the scene file, for messages */
    /* camera line: has_camera = 1; has_target = 0 means the middle of the scene's box; has_up = 0
     * means the default up of an eye given on the command line (+Z, or +Y / -Y looking straight
     * down / up), up is then left (0, 0, 0) */
    int has_camera, has_target, has_up;
    double eye[3], target[3], up[3], fov_deg; /* fov 30 when not given */
    size_t item_count;
    crisp_scene_item *items;
} crisp_scene_file;

crisp_status crisp_scene_file_read(const char *path, crisp_scene_file **dest);
/* dir: the folder relative paths start from (NULL or "" for the current one). */
crisp_status crisp_scene_file_read_mem(const char *name, const char *dir, const char *data,
                                       size_t size, crisp_scene_file **dest);
void crisp_scene_file_destroy(crisp_scene_file *s);
/* 1 when path ends in .scene or its first item line starts with "model", "frep" or "camera". */
int crisp_scene_file_detect(const char *path);

typedef struct crisp_scene_assets {
    crisp_model *model; /* every model item's faces, transformed; may have no faces */
    size_t part_count;
    crisp_frep_part *parts; /* tapes owned here */
    struct crisp_frep **freps;
    crisp_frep_tape **tapes;
} crisp_scene_assets;

crisp_status crisp_scene_assets_load(const crisp_scene_file *s, crisp_scene_assets **dest);
void crisp_scene_assets_destroy(crisp_scene_assets *a);

#ifdef __cplusplus
}
#endif
#endif
