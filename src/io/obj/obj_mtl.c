/* Materials of an OBJ file: the names given by usemtl and their colours from the .mtl files named
 * by mtllib (Wavefront MTL: `newmtl name`, `Kd r g b` diffuse colour, `d alpha` dissolve or
 * `Tr t` = 1 - alpha). crisp only takes the face colour from them; everything else in an .mtl
 * file (textures, illumination models) is ignored. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "obj/obj_internal.h"

#define MAX_MATERIALS 65536

int crisp__obj_material(obj_data *d, const char *name, size_t len)
{
    if (len >= sizeof d->materials[0].name) len = sizeof d->materials[0].name - 1;
    for (int i = 0; i < d->material_count; i++)
        if (strlen(d->materials[i].name) == len && memcmp(d->materials[i].name, name, len) == 0)
            return i;
    if (d->material_count >= MAX_MATERIALS) return -1;
    size_t cap = (size_t)d->material_cap;
    if (crisp_grow((void **)&d->materials, &cap, (size_t)d->material_count + 1,
                   sizeof(obj_material)) != CRISP_OK)
        return -1;
    d->material_cap = (int)cap;
    obj_material *mt = &d->materials[d->material_count];
    memset(mt, 0, sizeof *mt);
    memcpy(mt->name, name, len);
    mt->rgba[3] = 1.0f;
    return d->material_count++;
}

static int clamp01(double x, float *dest)
{
    if (!isfinite(x)) return 0;
    *dest = (float)(x < 0 ? 0 : x > 1 ? 1 : x);
    return 1;
}

/* One .mtl file's text: only the materials the OBJ file uses get colours. */
static void parse_mtl(obj_data *d, const char *text, size_t size)
{
    int current = -1;
    const char *p = text, *end = text + size;
    while (p < end) {
        const char *eol = memchr(p, '\n', (size_t)(end - p));
        if (!eol) eol = end;
        char line[256];
        size_t n = (size_t)(eol - p);
        if (n >= sizeof line) n = sizeof line - 1;
        memcpy(line, p, n);
        line[n] = '\0';
        p = eol < end ? eol + 1 : end;
        char *h = strchr(line, '#');
        if (h) *h = '\0';
        char *save = NULL;
        char *key = strtok_r(line, " \t\r", &save);
        if (!key) continue;
        if (!strcmp(key, "newmtl")) {
            char *name = strtok_r(NULL, " \t\r", &save);
            current = -1;
            if (!name) continue;
            size_t len = strlen(name);
            for (int i = 0; i < d->material_count; i++)
                if (strlen(d->materials[i].name) == len && !memcmp(d->materials[i].name, name, len))
                    current = i;
            continue;
        }
        if (current < 0) continue;
        obj_material *mt = &d->materials[current];
        if (!strcmp(key, "Kd")) {
            float rgb[3];
            int ok = 1;
            for (int c = 0; c < 3; c++) {
                char *v = strtok_r(NULL, " \t\r", &save), *e = NULL;
                double x = v ? strtod(v, &e) : NAN;
                ok = ok && v && e && *e == '\0' && clamp01(x, &rgb[c]);
            }
            if (ok) {
                memcpy(mt->rgba, rgb, sizeof rgb);
                mt->has_color = 1;
            }
        } else if (!strcmp(key, "d") || !strcmp(key, "Tr")) {
            char *v = strtok_r(NULL, " \t\r", &save), *e = NULL;
            double x = v ? strtod(v, &e) : NAN;
            float a;
            if (v && e && *e == '\0' && clamp01(key[0] == 'd' ? x : 1.0 - x, &a)) mt->rgba[3] = a;
        }
    }
}

crisp_status crisp__obj_load_mtllibs(obj_data *d, const char *path, crisp_model *m)
{
    if (!d->mtllibs_len || !d->material_count) return CRISP_OK;
    const char *slash = path ? strrchr(path, '/') : NULL;
    size_t dir_len = slash ? (size_t)(slash - path) + 1 : 0;
    for (size_t off = 0; off < d->mtllibs_len; off += strlen(d->mtllibs + off) + 1) {
        const char *lib = d->mtllibs + off;
        char full[4096];
        if (lib[0] == '/')
            snprintf(full, sizeof full, "%s", lib);
        else
            snprintf(full, sizeof full, "%.*s%s", (int)dir_len, path, lib);
        char *text = NULL;
        size_t size = 0;
        crisp_status saved = CRISP_OK;
        if (crisp_read_file(full, &text, &size) != CRISP_OK) {
            crisp_error_clear();
            saved = crisp_model_note_skipf(m, "OBJ mtllib '%s': not readable, no colours", lib);
            if (saved != CRISP_OK) return saved;
            continue;
        }
        parse_mtl(d, text, size);
        crisp_free(text);
    }
    return CRISP_OK;
}
