/* crisp_model_load: open any supported CAD file, choosing the reader by content rather than by
 * name. IGES 5.3: fixed 80-column records whose first line carries the section letter 'S' in
 * column 73 (IGES 5.3 section 2.2). STEP: ISO 10303-21 files begin with the token
 * "ISO-10303-21;" (after optional whitespace and comments). OBJ has no signature: a file whose
 * first statement is an OBJ keyword, or named *.obj, is read as OBJ. */
#include <ctype.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "crisp/io.h"
#include "obj/obj_internal.h"

typedef enum { FMT_UNKNOWN, FMT_IGES, FMT_STEP, FMT_OBJ } file_format;

static int is_iges(const char *d, size_t n)
{
    /* the first record: 72 columns of data, then the section letter and sequence number */
    size_t len = 0;
    while (len < n && d[len] != '\n' && d[len] != '\r')
        len++;
    return len >= 73 && d[72] == 'S';
}

static const char *skip_blank_and_comments(const char *p, const char *end)
{
    for (;;) {
        while (p < end && isspace((unsigned char)*p))
            p++;
        if (end - p >= 2 && p[0] == '/' && p[1] == '*') {
            const char *q = p + 2;
            while (q + 1 < end && !(q[0] == '*' && q[1] == '/'))
                q++;
            if (q + 1 >= end) return end;
            p = q + 2;
            continue;
        }
        return p;
    }
}

static int is_step(const char *d, size_t n)
{
    static const char magic[] = "ISO-10303-21;";
    const char *p = skip_blank_and_comments(d, d + n);
    return (size_t)(d + n - p) >= sizeof magic - 1 && memcmp(p, magic, sizeof magic - 1) == 0;
}

/* The first statement's keyword is one OBJ defines. */
static int looks_like_obj(const char *d, size_t n)
{
    static const char *const keywords[] = {"v",    "vt",    "vn",    "vp",     "f",      "l",
                                           "p",    "g",     "o",     "s",      "cstype", "deg",
                                           "curv", "curv2", "surf",  "mtllib", "usemtl", "mg",
                                           "bmat", "step",  "ctech", "stech",  "call",   NULL};
    const char *p = d, *end = d + n;
    while (p < end) {
        while (p < end && isspace((unsigned char)*p))
            p++;
        if (p < end && *p == '#') {
            while (p < end && *p != '\n')
                p++;
            continue;
        }
        break;
    }
    const char *w = p;
    while (p < end && !isspace((unsigned char)*p))
        p++;
    size_t len = (size_t)(p - w);
    if (len == 0 || p == end) return 0;
    for (const char *const *k = keywords; *k; k++)
        if (strlen(*k) == len && memcmp(*k, w, len) == 0) return 1;
    return 0;
}

static int has_obj_extension(const char *path)
{
    size_t n = strlen(path);
    return n >= 4 && strcasecmp(path + n - 4, ".obj") == 0;
}

static file_format detect(const char *path, const char *d, size_t n)
{
    if (is_iges(d, n)) return FMT_IGES;
    if (is_step(d, n)) return FMT_STEP;
    if (looks_like_obj(d, n) || has_obj_extension(path)) return FMT_OBJ;
    return FMT_UNKNOWN;
}

crisp_status crisp_model_load(const char *path, const crisp_read_options *options,
                              crisp_model **dest)
{
    if (!path || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_model_load: NULL argument");
    *dest = NULL;
    char *data = NULL;
    size_t size = 0;
    crisp_status st = crisp_read_file(path, &data, &size);
    if (st != CRISP_OK) return st;
    switch (detect(path, data, size)) {
    case FMT_IGES:
        st = crisp_read_iges_mem(path, data, size, options, dest);
        break;
    case FMT_STEP:
        st = crisp_read_step_mem(path, data, size, options, dest);
        break;
    case FMT_OBJ:
        st = crisp__read_obj(path, data, size, options, 1, dest);
        break;
    default:
        st = crisp_error(CRISP_ERR_UNSUPPORTED,
                         "%s:1: not an IGES, STEP or OBJ file (expected 'S' in column 73 of the "
                         "first line for IGES, 'ISO-10303-21;' for STEP, or an OBJ statement)",
                         path);
    }
    crisp_free(data);
    return st;
}
