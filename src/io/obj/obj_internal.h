/* Private to the OBJ reader: the parsed (not yet converted) content of a Wavefront OBJ file.
 * obj_parse.c fills it from the text (statements, state, references resolved to 0-based
 * indices); obj_build.c turns it into crisp faces. */
#ifndef CRISP_IO_OBJ_INTERNAL_H
#define CRISP_IO_OBJ_INTERNAL_H

#include "crisp/io.h"

enum { OBJ_BSPLINE = 1, OBJ_BEZIER = 2 };

/* A span of entries in one of the shared arrays. */
typedef struct obj_span {
    int off, count;
} obj_span;

typedef struct obj_curv2 {
    int type, rational, degree;
    int line;
    obj_span refs;      /* into obj_data.refs: vp indices */
    obj_span knots;     /* into obj_data.reals: parm u (B-spline knots or Bézier breakpoints) */
    crisp_curve *curve; /* converted on first use (owned) */
    int failed;         /* conversion failed once: the error was already reported */
} obj_curv2;

typedef struct obj_loop {
    int is_outer;
    int line;
    obj_span triples; /* into obj_data.reals: u0, u1, curv2 index (0-based), 3 per piece */
} obj_loop;

typedef struct obj_surf {
    int type, rational, degree_u, degree_v;
    int line;
    int material;    /* index into obj_data.materials, -1 for none */
    double range[4]; /* s0 s1 t0 t1 */
    obj_span refs;   /* v indices, u fastest */
    obj_span knots_u, knots_v;
    obj_span loops; /* into obj_data.loops */
} obj_surf;

typedef struct obj_polygon {
    int line;
    int material;
    obj_span refs; /* v indices */
} obj_polygon;

/* A material named by usemtl; its colour comes from an .mtl file (Kd, d / Tr). */
typedef struct obj_material {
    char name[64];
    int has_color;
    float rgba[4];
} obj_material;

/* Coordinates are kept in double and in long double: a rational control point's homogeneous
 * value w * x is formed in extended precision, so that the 21-digit Euclidean values that
 * crisp_write_obj writes give back exactly the homogeneous doubles that were written. */
typedef struct obj_vertex {
    double x[4];        /* x y z w */
    long double ext[3]; /* x y z */
} obj_vertex;

typedef struct obj_pvertex {
    double x[3];        /* u v w (w = 1 when absent) */
    long double ext[2]; /* u v */
} obj_pvertex;

typedef struct obj_data {
    const char *name;
    obj_vertex *v;
    int v_count, v_cap;
    obj_pvertex *vp;
    int vp_count, vp_cap;
    int *refs;
    int ref_count, ref_cap;
    double *reals;
    int real_count, real_cap;
    obj_curv2 *curv2;
    int curv2_count, curv2_cap;
    obj_surf *surfs;
    int surf_count, surf_cap;
    obj_loop *loops;
    int loop_count, loop_cap;
    obj_polygon *polys;
    int poly_count, poly_cap;
    long trim_points; /* control points of all trim pieces made so far (bounded) */
    obj_material *materials;
    int material_count, material_cap;
    char *mtllibs; /* file names from mtllib statements, each NUL-terminated */
    size_t mtllibs_len, mtllibs_cap;
} obj_data;

/* The reader behind crisp_read_obj(_mem) and crisp_model_load: with resolve_files, mtllib names
 * are opened relative to the directory of name (a path); from memory they are not. */
crisp_status crisp__read_obj(const char *name, const char *data, size_t size,
                             const crisp_read_options *options, int resolve_files,
                             crisp_model **dest);
/* Parse the text (size bytes, need not be NUL-terminated) into d (zeroed by the caller); skipped
 * statements are noted in m. */
crisp_status crisp__obj_parse(const char *name, const char *text, size_t size, obj_data *d,
                              crisp_model *m);
/* Convert everything parsed into faces of m. */
crisp_status crisp__obj_build(obj_data *d, const crisp_read_options *options, crisp_model *m);
void crisp__obj_data_free(obj_data *d);
/* The material called name (created without colour when new); -1 when out of memory or too many. */
int crisp__obj_material(obj_data *d, const char *name, size_t len);
/* Read the .mtl files named by mtllib, relative to the directory of the OBJ file `path`, and give
 * the materials their colours. Missing or unreadable files are noted in m, not fatal. */
crisp_status crisp__obj_load_mtllibs(obj_data *d, const char *path, crisp_model *m);

#endif
