/* crisp_read_obj / crisp_read_obj_mem: Wavefront OBJ free-form surfaces (and polygon meshes as
 * Catmull-Clark limit surfaces) into a crisp_model. Parsing is in obj_parse.c, conversion in
 * obj_build.c, materials (face colours from .mtl files) in obj_mtl.c; see those for the OBJ 3.0
 * rules followed. */
#include <stdio.h>
#include <string.h>

#include "obj/obj_internal.h"

crisp_status crisp__read_obj(const char *name, const char *data, size_t size,
                             const crisp_read_options *options, int resolve_files,
                             crisp_model **dest)
{
    if (!dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_read_obj: dest is NULL");
    *dest = NULL;
    if (!name) name = "(memory)";
    if (!data && size) return crisp_error(CRISP_ERR_INVALID_ARG, "%s: no data", name);
    crisp_model *m = NULL;
    crisp_status st = crisp_model_create(&m);
    if (st != CRISP_OK) return st;
    snprintf(m->format, sizeof m->format, "OBJ");
    obj_data d;
    memset(&d, 0, sizeof d);
    st = crisp__obj_parse(name, data ? data : "", size, &d, m);
    if (st == CRISP_OK && d.mtllibs_len) {
        if (resolve_files)
            st = crisp__obj_load_mtllibs(&d, name, m);
        else
            st = crisp_model_note_skip(m, "OBJ mtllib: not read (model read from memory)");
    }
    if (st == CRISP_OK) st = crisp__obj_build(&d, options, m);
    crisp__obj_data_free(&d);
    if (st != CRISP_OK) {
        crisp_model_destroy(m);
        return st;
    }
    *dest = m;
    return CRISP_OK;
}

crisp_status crisp_read_obj_mem(const char *name, const char *data, size_t size,
                                const crisp_read_options *options, crisp_model **dest)
{
    return crisp__read_obj(name, data, size, options, 0, dest);
}

crisp_status crisp_read_obj(const char *path, const crisp_read_options *options, crisp_model **dest)
{
    if (!path) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_read_obj: path is NULL");
    char *data = NULL;
    size_t size = 0;
    crisp_status st = crisp_read_file(path, &data, &size);
    if (st != CRISP_OK) return st;
    st = crisp__read_obj(path, data, size, options, 1, dest);
    crisp_free(data);
    return st;
}
