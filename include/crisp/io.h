/* crisp io: files into the in-memory model and back.
 *
 * Offers:
 *   crisp_model_load      any supported CAD file, by content (IGES, STEP, OBJ)
 *   crisp_read_iges       IGES 5.3 (fixed 80-column records)
 *   crisp_read_step       ISO 10303-21 (AP203 / AP214 / AP242 geometry)
 *   crisp_read_obj        Wavefront OBJ free-form (+ polygon meshes via OpenSubdiv)
 *   crisp_write_obj       OBJ free-form writer (round-trips every surface and trim curve)
 *
 * Every reader reports bad input as a crisp_status with a message naming the file, the line (or
 * entity number) and what was expected; unsupported entities are counted in model->skips.
 */
#ifndef CRISP_IO_H
#define CRISP_IO_H

#include <stddef.h>

#include "crisp/model.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct crisp_read_options {
    /* Tolerance for trims projected from 3D edges, as a fraction of the model's bounding-box
     * diagonal; 0 means the default (1e-5). */
    double projection_tolerance;
    /* Gap allowed when closing a loop, as a fraction of the face's domain size; 0: 1e-6. */
    double closure_tolerance;
} crisp_read_options;

/* options may be NULL (defaults). */
crisp_status crisp_model_load(const char *path, const crisp_read_options *options,
                              crisp_model **dest);

/* The readers on a file path and on memory (name is used in messages). */
crisp_status crisp_read_iges(const char *path, const crisp_read_options *options,
                             crisp_model **dest);
crisp_status crisp_read_iges_mem(const char *name, const char *data, size_t size,
                                 const crisp_read_options *options, crisp_model **dest);
crisp_status crisp_read_step(const char *path, const crisp_read_options *options,
                             crisp_model **dest);
crisp_status crisp_read_step_mem(const char *name, const char *data, size_t size,
                                 const crisp_read_options *options, crisp_model **dest);
crisp_status crisp_read_obj(const char *path, const crisp_read_options *options,
                            crisp_model **dest);
crisp_status crisp_read_obj_mem(const char *name, const char *data, size_t size,
                                const crisp_read_options *options, crisp_model **dest);

crisp_status crisp_write_obj(const crisp_model *m, const char *path);

/* Whole file into memory (NUL-terminated; size excludes the NUL). Caller frees with crisp_free. */
crisp_status crisp_read_file(const char *path, char **data, size_t *size);

#ifdef __cplusplus
}
#endif
#endif
