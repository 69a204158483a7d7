/* IGES reader internals: the parsed file (sections, directory entries, parameter records) and
 * the per-concept converters (curves, surfaces, trimmed faces, B-rep faces) that turn entities
 * into crisp NURBS. Follows the IGES 5.3 specification (US PRO, 1996).
 *
 * Entity references in IGES are "DE pointers": the sequence number of the first of the two
 * directory-entry lines, so DE pointer d names entity (d - 1) / 2 in file order. Every pointer,
 * count and number is checked before use; messages say "<file>: DE <d> (entity <type>): ...".
 */
#ifndef CRISP_IO_IGES_INTERNAL_H
#define CRISP_IO_IGES_INTERNAL_H

#include "crisp/io.h"

/* Deepest nesting of references (composite in composite, 124 chains, surface -> curve) before a
 * file is rejected; real files nest 3 or 4 deep. */
#define IGES_MAX_DEPTH 32

enum iges_param_kind { IGES_PARAM_DEFAULT = 0, IGES_PARAM_NUMBER, IGES_PARAM_STRING };

typedef struct iges_param {
    int kind;
    int is_integer; /* the text had no '.' or exponent */
    double num;
    int str_off, str_len; /* Hollerith text in iges_file.strings */
} iges_param;

typedef struct iges_entity {
    int type, param_ptr, structure, line_font, level, view, transform, label_display;
    int blank, subordinate, use, hierarchy; /* the four status-number fields */
    int line_weight, color, param_lines, form;
    char label[9];
    int d_line;                   /* file line of the first DE record, for messages */
    int p_line;                   /* file line of the parameter record (0 when none) */
    int first_param, param_count; /* into iges_file.params; params[first_param] is the type */
    int visiting;                 /* cycle detection during conversion */
    int used;                     /* referenced by something that was converted */
    int consumed;                 /* referenced by a face or face part (not independent) */
    int in_subfigure;             /* a member of a 308 definition: drawn through its 408s */
} iges_entity;

typedef struct iges_file {
    const char *name;
    char pdelim, rdelim;
    double unit_to_mm;
    double resolution; /* global 19: minimum user-intended resolution (model units) */
    int entity_count;
    iges_entity *ents;
    int param_count;
    size_t param_cap;
    iges_param *params;
    size_t strings_len, strings_cap;
    char *strings;
    /* conversion state */
    double tol3d;               /* projection tolerance (model units); 0 until first needed */
    double projection_fraction; /* of the bounding-box diagonal */
    double closure_fraction;    /* closure tolerance as a fraction of a face's domain size */
    crisp_model *model;
    crisp_status first_error; /* of the first face skipped because it could not be built */
    char first_message[512];
    int blanked_faces; /* faces not drawn because the file blanks them */
    int draw_blanked;  /* set when every face is blanked: draw them anyway */
    int body;          /* DE of the 186 solid or 514 shell whose faces are being built, else 0 */
} iges_file;

/* ---- sections and parameters (iges_sections.c) ---------------------------------------------- */

crisp_status crisp__iges_file_parse(const char *name, const char *data, size_t size,
                                    iges_file *dest);
void crisp__iges_file_free(iges_file *f);

/* DE pointer of entity index i, and index of a DE pointer (-1 when out of range / even). */
static inline int iges_de(int index)
{
    return 2 * index + 1;
}
int crisp__iges_index(const iges_file *f, int de);
const char *crisp__iges_type_name(int type);

/* Parameter access for entity e (index), parameter k (1 = the first after the type number).
 * Each fails with a message naming the DE, the parameter and what was expected. */
crisp_status crisp__iges_real(const iges_file *f, int e, int k, double *dest);
/* A real that may be absent (default value def). */
crisp_status crisp__iges_real_def(const iges_file *f, int e, int k, double def, double *dest);
crisp_status crisp__iges_int(const iges_file *f, int e, int k, int *dest);
crisp_status crisp__iges_int_def(const iges_file *f, int e, int k, int def, int *dest);
/* An integer in [lo, hi]. */
crisp_status crisp__iges_int_range(const iges_file *f, int e, int k, int lo, int hi, int *dest);
/* A DE pointer to an existing entity: *dest gets its index; with allow_null a 0 gives -1. */
crisp_status crisp__iges_ptr(const iges_file *f, int e, int k, int allow_null, int *dest);
/* Fails unless entity e has at least k parameters after the type number. */
crisp_status crisp__iges_need(const iges_file *f, int e, int k, const char *what);
int crisp__iges_nparams(const iges_file *f, int e); /* parameters after the type number */
/* An error naming entity e: "<file>: DE <d> (entity <type>): <message>". */
crisp_status crisp__iges_fail(const iges_file *f, int e, crisp_status st, const char *fmt, ...)
    CRISP_PRINTF(4, 5);

/* ---- transforms (iges_curves.c) ------------------------------------------------------------- */

/* A 3x4 affine map, rows (R | T): x' = R x + T. */
typedef struct iges_xform {
    double m[3][4];
} iges_xform;

void crisp__iges_xform_identity(iges_xform *dest);
/* dest = a * b (apply b first). */
void crisp__iges_xform_mul(const iges_xform *a, const iges_xform *b, iges_xform *dest);
/* Entity e's own transformation matrix (its DE field 7, composed down 124 chains); identity when
 * there is none. */
crisp_status crisp__iges_entity_xform(iges_file *f, int e, int depth, iges_xform *dest);
void crisp__iges_xform_point(const iges_xform *x, const double p[3], double dest[3]);

/* ---- curves (iges_curves.c) ----------------------------------------------------------------- */

typedef struct iges_curves {
    int count, cap;
    crisp_curve **items;
} iges_curves;

void crisp__iges_curves_free(iges_curves *c);
crisp_status crisp__iges_curves_push(iges_curves *c, crisp_curve *curve);
/* Convert curve entity e (100, 102, 104, 110, 112, 126, and 142/130-style wrappers are not
 * curves) into a chain of NURBS curves of dimension dim (3: model space; 2: parameter space, z
 * dropped), each transformed by parent * (the entity's own matrix). Unsupported curve types fail
 * with CRISP_ERR_UNSUPPORTED. */
crisp_status crisp__iges_curve_convert(iges_file *f, int e, int dim, const iges_xform *parent,
                                       int depth, iges_curves *out);
int crisp__iges_is_curve_type(int type);
/* Mark an entity and what it refers to used (an alternative representation crisp did not need,
 * or the parts of a face that was skipped), so they are not reported as free geometry. */
void crisp__iges_mark_used(iges_file *f, int e, int depth);

/* How the file's parameter of an analytic curve maps to the crisp curve's parameter: either
 * affine (t' = scale * t + offset) or an angle passed through crisp_angle_to_param(a0, a1, .). */
typedef struct iges_param_map {
    int angular;
    double a0, a1;
    double scale, offset;
} iges_param_map;
double crisp__iges_param_map_apply(const iges_param_map *m, double t);
int crisp__iges_param_map_is_identity(const iges_param_map *m);
/* The map of a single-curve entity's parameter (identity for B-splines, lines; angular for arcs).
 */
crisp_status crisp__iges_curve_param_map(iges_file *f, int e, iges_param_map *dest);

/* ---- surfaces (iges_surfaces.c) ------------------------------------------------------------- */

typedef struct iges_surface {
    crisp_surface *surface;
    iges_param_map map_u, map_v;  /* file (u, v) -> crisp (u, v) */
    int is_plane;                 /* 108: the (u, v) are plane coordinates along axes x, y */
    int analytic;                 /* 192-198: the entity type; the NURBS is built from the loops'
                                     model-space curves (crisp__iges_finish_face), which are kept in 3D
                                     until then */
    double radius, radius2, semi; /* 192/194/196: radius; 198: major, minor; 194: semi-angle */
    int narrowed;                 /* 128 whose parameter range is inside its knot domain */
    double range[4];              /* that range: u0, u1, v0, v1 */
    double origin[3], x[3], y[3];
} iges_surface;

int crisp__iges_is_surface_type(int type);
/* Convert surface entity e. A 108 plane gets no NURBS surface here (it is sized from its trims):
 * is_plane is set with its frame. */
crisp_status crisp__iges_surface_convert(iges_file *f, int e, int depth, iges_surface *dest);
void crisp__iges_surface_free(iges_surface *s);
/* Map a file-parameter-space curve into the crisp surface's (u, v) (exact when the map is affine
 * or the curve is iso-parametric; fitted within tol_uv otherwise). Replaces *c. */
crisp_status crisp__iges_surface_map_curve(const iges_surface *s, double tol_uv, crisp_curve **c);

/* ---- faces (iges_faces.c, iges_brep.c) ------------------------------------------------------ */

/* Build the face of a 144 / 143 / 510 entity (or an independent surface) and add it to the
 * model; a face whose loops cannot be made valid is dropped with a skip note. */
crisp_status crisp__iges_face_trimmed(iges_file *f, int e);
crisp_status crisp__iges_face_bounded(iges_file *f, int e);
crisp_status crisp__iges_face_untrimmed(iges_file *f, int e);
crisp_status crisp__iges_face_plane(iges_file *f, int e);
crisp_status crisp__iges_brep_faces(iges_file *f, int e); /* 186 solid or 514 shell */
crisp_status crisp__iges_face_brep(iges_file *f, int e, int reversed);
/* A face-level failure st becomes a skip note naming entity e (returns CRISP_OK); running out of
 * memory stays fatal. */
crisp_status crisp__iges_soften(iges_file *f, int e, crisp_status st);
/* Build the faces of the listed entities (iges_read.c); other entity types are left alone. */
crisp_status crisp__iges_build_entities(iges_file *f, const int *list, int n);
/* Clear the conversion state (flags, counts, first error) for a second conversion. */
void crisp__iges_file_reset(iges_file *f);

/* ---- subfigures (iges_subfig.c) ------------------------------------------------------------- */

/* Flag the members of every 308 definition: they are drawn only through 408 instances. */
void crisp__iges_subfigure_mark(iges_file *f);
/* Append the faces of every top-level 408 instance, transformed, to f->model. */
crisp_status crisp__iges_subfigure_instances(iges_file *f);
/* Apply x to a surface's homogeneous control points (iges_surfaces.c). */
void crisp__iges_xform_surface(crisp_surface *s, const iges_xform *x);
/* The face's own region as a CCW rectangle loop: the 128's parameter range when it is narrower
 * than the knot domain, else the domain. */
crisp_status crisp__iges_domain_loop(const iges_surface *s, iges_curves *out);

/* Shared by the face builders: order and orient a chain of 2D curves into a closed loop, project
 * model-space curves, finish a face (colour, normalise, add or skip). */
crisp_status crisp__iges_project_curves(iges_file *f, int e, const iges_surface *s,
                                        const iges_curves *model, iges_curves *uv);
crisp_status crisp__iges_finish_face(iges_file *f, int e, int surf_e, iges_surface *s,
                                     iges_curves *loops, const int *is_outer, int loop_count,
                                     int reversed);
/* Colour of entity e (DE colour number or 314 definition); returns 0 when it has none. */
int crisp__iges_entity_color(iges_file *f, int e, float rgba[4]);

#endif
