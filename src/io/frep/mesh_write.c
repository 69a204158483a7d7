/* Mesh writers for the f-rep mesher's streaming sink: binary STL (the 80-byte header, a triangle
 * count and 50 bytes per triangle), Wavefront OBJ (v and f lines; faces may follow their vertices
 * anywhere), and binary little-endian PLY 1.0 (vertex x y z float; face list uchar uint). Nothing
 * is kept per triangle: STL's count and PLY's header are written at close, PLY's faces wait in a
 * temporary file. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/frep_mesh.h"

enum { W_STL, W_OBJ, W_PLY };
#define PLY_HEADER 320

struct crisp_frep_mesh_writer {
    FILE *f, *faces;
    int kind;
    char *path;
    uint32_t nv, nt;
    int failed;
};

static void put_u32(unsigned char *b, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        b[i] = (unsigned char)(v >> (8 * i));
}
static void put_f32(unsigned char *b, float f)
{
    uint32_t v;
    memcpy(&v, &f, 4);
    put_u32(b, v);
}

static crisp_status wfail(crisp_frep_mesh_writer *w)
{
    w->failed = 1;
    return crisp_error(CRISP_ERR_IO, "%s: write failed", w->path);
}

static crisp_status on_vertex(void *ctx, const float p[3])
{
    crisp_frep_mesh_writer *w = ctx;
    w->nv++;
    if (w->kind == W_OBJ) {
        if (fprintf(w->f, "v %.9g %.9g %.9g\n", p[0], p[1], p[2]) < 0) return wfail(w);
    } else if (w->kind == W_PLY) {
        unsigned char b[12];
        for (int a = 0; a < 3; a++)
            put_f32(b + 4 * a, p[a]);
        if (fwrite(b, 1, 12, w->f) != 12) return wfail(w);
    }
    return CRISP_OK;
}

static crisp_status on_triangle(void *ctx, const uint32_t v[3], const float p[3][3])
{
    crisp_frep_mesh_writer *w = ctx;
    if (w->nt == UINT32_MAX)
        return crisp_error(CRISP_ERR_LIMIT, "%s: more than %u triangles", w->path, UINT32_MAX - 1);
    w->nt++;
    if (w->kind == W_STL) {
        unsigned char b[50];
        double e1[3], e2[3], n[3];
        for (int a = 0; a < 3; a++)
            e1[a] = (double)p[1][a] - p[0][a], e2[a] = (double)p[2][a] - p[0][a];
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int a = 0; a < 3; a++)
            put_f32(b + 4 * a, l > 0 ? (float)(n[a] / l) : 0.0f);
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++)
                put_f32(b + 12 + 12 * k + 4 * a, p[k][a]);
        b[48] = b[49] = 0;
        if (fwrite(b, 1, 50, w->f) != 50) return wfail(w);
    } else if (w->kind == W_OBJ) {
        if (fprintf(w->f, "f %u %u %u\n", v[0] + 1, v[1] + 1, v[2] + 1) < 0) return wfail(w);
    } else {
        unsigned char b[13];
        b[0] = 3;
        for (int k = 0; k < 3; k++)
            put_u32(b + 1 + 4 * k, v[k]);
        if (fwrite(b, 1, 13, w->faces) != 13) return wfail(w);
    }
    return CRISP_OK;
}

static int ends_with(const char *s, const char *t)
{
    size_t a = strlen(s), b = strlen(t);
    if (a < b) return 0;
    for (size_t i = 0; i < b; i++) {
        char c = s[a - b + i];
        if (c >= 'A' && c <= 'Z') c = (char)(c - 'A' + 'a');
        if (c != t[i]) return 0;
    }
    return 1;
}

crisp_status crisp_frep_mesh_writer_open(const char *path, crisp_frep_mesh_writer **dest,
                                         crisp_frep_mesh_sink *sink)
{
    if (!path || !dest || !sink)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_mesh_writer_open: NULL argument");
    *dest = NULL;
    int kind = ends_with(path, ".stl")   ? W_STL
               : ends_with(path, ".obj") ? W_OBJ
               : ends_with(path, ".ply") ? W_PLY
                                         : -1;
    if (kind < 0)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: unknown mesh format (expected .stl, .obj or .ply)", path);
    crisp_frep_mesh_writer *w = calloc(1, sizeof *w);
    if (!w) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", path);
    w->kind = kind;
    w->path = malloc(strlen(path) + 1);
    if (w->path) strcpy(w->path, path);
    w->f = fopen(path, kind == W_OBJ ? "w" : "wb");
    if (!w->f || !w->path) {
        free(w->path);
        free(w);
        return crisp_error(CRISP_ERR_IO, "%s: cannot open for writing", path);
    }
    crisp_status s = CRISP_OK;
    if (kind == W_STL) {
        unsigned char h[84] = {0};
        const char *title = "binary STL written by crisp frep mesh";
        memcpy(h, title, strlen(title));
        if (fwrite(h, 1, 84, w->f) != 84) s = wfail(w);
    } else if (kind == W_OBJ) {
        if (fprintf(w->f, "# written by crisp frep mesh\n") < 0) s = wfail(w);
    } else {
        char h[PLY_HEADER];
        memset(h, ' ', sizeof h);
        w->faces = tmpfile();
        if (!w->faces)
            s = crisp_error(CRISP_ERR_IO, "%s: cannot open a temporary file for faces", path);
        else if (fwrite(h, 1, sizeof h, w->f) != sizeof h)
            s = wfail(w);
    }
    if (s) {
        fclose(w->f);
        if (w->faces) fclose(w->faces);
        free(w->path);
        free(w);
        return s;
    }
    *sink = (crisp_frep_mesh_sink){.ctx = w, .vertex = on_vertex, .triangle = on_triangle};
    *dest = w;
    return CRISP_OK;
}

crisp_status crisp_frep_mesh_writer_close(crisp_frep_mesh_writer *w)
{
    if (!w) return CRISP_OK;
    crisp_status s = CRISP_OK;
    if (!w->failed && w->kind == W_STL) {
        unsigned char b[4];
        put_u32(b, w->nt);
        if (fseek(w->f, 80, SEEK_SET) || fwrite(b, 1, 4, w->f) != 4) s = wfail(w);
    } else if (!w->failed && w->kind == W_PLY) {
        char h[PLY_HEADER + 1];
        const char *end = "element face %u\nproperty list uchar uint vertex_indices\nend_header\n";
        int n =
            snprintf(h, sizeof h,
                     "ply\nformat binary_little_endian 1.0\ncomment written by crisp frep mesh\n"
                     "element vertex %u\nproperty float x\nproperty float y\nproperty float z\n",
                     w->nv);
        char tail[160];
        int m = snprintf(tail, sizeof tail, end, w->nt);
        /* pad with a comment line so that the header keeps its reserved size */
        int pad = PLY_HEADER - n - m - 9; /* "comment " + '\n' */
        if (pad < 0) {
            s = crisp_error(CRISP_ERR_INTERNAL, "%s: PLY header too long", w->path);
        } else {
            char *q = h + n;
            memcpy(q, "comment ", 8), q += 8;
            memset(q, ' ', (size_t)pad), q += pad;
            *q++ = '\n';
            memcpy(q, tail, (size_t)m);
            if (fseek(w->f, 0, SEEK_SET) || fwrite(h, 1, PLY_HEADER, w->f) != PLY_HEADER ||
                fseek(w->f, 0, SEEK_END))
                s = wfail(w);
            rewind(w->faces);
            char buf[1 << 15];
            size_t k;
            while (!s && (k = fread(buf, 1, sizeof buf, w->faces)) > 0)
                if (fwrite(buf, 1, k, w->f) != k) s = wfail(w);
        }
    }
    if (w->faces) fclose(w->faces);
    if (fclose(w->f) && !s) s = crisp_error(CRISP_ERR_IO, "%s: write failed on close", w->path);
    if (w->failed && !s) s = crisp_error(CRISP_ERR_IO, "%s: write failed", w->path);
    free(w->path);
    free(w);
    return s;
}
