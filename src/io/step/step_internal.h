/* Private interface of the STEP reader (ISO 10303-21 exchange structure, ISO 10303-42 geometry
 * and topology). The Part 21 parser (step_p21.c) turns the text into an entity table; access
 * helpers (step_access.c) read typed parameters with messages naming the file, the #entity and
 * its line; step_curve.c, step_surface.c and step_face.c convert geometry and topology into
 * crisp faces; step_style.c reads units and colours; step_read.c holds the entry points.
 */
#ifndef CRISP_STEP_INTERNAL_H
#define CRISP_STEP_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/construct.h"
#include "crisp/io.h"

/* ---- Part 21 entity table ---------------------------------------------------------------------
 */

typedef enum step_kind {
    STEP_INT,
    STEP_REAL,
    STEP_STRING,  /* raw bytes between the quotes ('' and \X\ escapes kept as written) */
    STEP_ENUM,    /* .NAME. without the dots */
    STEP_BINARY,  /* "..." */
    STEP_REF,     /* #id */
    STEP_OMITTED, /* $ */
    STEP_DERIVED, /* * */
    STEP_LIST,    /* ( ... ): children first .. first + len - 1 */
    STEP_TYPED    /* NAME( value ): name at off/len, the single value at first */
} step_kind;

typedef struct step_value {
    uint32_t kind;
    uint32_t len;   /* list: element count; string/enum/binary/typed: name or text length */
    uint32_t off;   /* string/enum/binary/typed: offset of the text in the source */
    uint32_t first; /* list: index of the first element; typed: index of the wrapped value */
    double num;     /* int and real values; ref: the referenced id */
} step_value;

/* One partial entity of an instance: NAME(params). A simple instance has one part; a complex
 * instance #n = (A(...) B(...)) has several, in file order. */
typedef struct step_part {
    uint32_t name_off, name_len;
    uint32_t params; /* index of a STEP_LIST value */
} step_part;

typedef struct step_entity {
    int id;
    int line;
    uint32_t first_part, part_count;
    uint32_t src_off, src_len; /* the instance's text after '=' (to tell identical copies) */
} step_entity;

typedef struct step_file {
    const char *name; /* for messages */
    char *text;       /* NUL-terminated copy of the input */
    size_t size;
    step_value *values;
    size_t value_count, value_cap;
    step_part *parts;
    size_t part_count, part_cap;
    step_entity *entities;
    size_t entity_count, entity_cap;
    int *map; /* open-addressing hash: id -> entity index + 1 (0 = empty) */
    size_t map_cap;
    int duplicates; /* instances defined twice with identical text (the first is kept) */
    int broken;     /* DATA instances that did not parse and were skipped */
    int first_broken_line;
    char first_broken[200]; /* the first one's error message */
    int first_duplicate;    /* id of the first such */
} step_file;

/* Parse a whole exchange structure. On failure the message names the file, line and column. */
crisp_status crisp__step_parse(const char *name, const char *data, size_t size, step_file *dest);
void crisp__step_file_free(step_file *f);
/* Entity with this id, or NULL (also for ids no entity can have: a reference's value is passed
 * as it was read). */
const step_entity *crisp__step_find(const step_file *f, double id);

/* ---- conversion context -----------------------------------------------------------------------
 */

/* What the reader did, for tests and benchmarks. */
typedef struct step_read_stats {
    int verify;           /* in: measure how far trims lie from their 3D edges (slower) */
    int pcurve_edges;     /* edge uses trimmed from a PCURVE */
    int projected_edges;  /* edge uses trimmed by projecting the 3D edge */
    int rejected_pcurves; /* pcurves that did not follow their 3D curve (edge projected instead) */
    int dropped_faces;
    int degenerate_edges;  /* uv segments inserted along collapsed surface boundaries */
    int loose_projections; /* edge trims projected only with a looser tolerance */
    int flipped_segments;  /* boundary segments whose same_sense was turned round to chain */
    double max_edge_dev;   /* largest 3D distance of a trim's image from its edge's projection onto
                              the surface (verify) */
    double max_edge_gap;   /* largest distance of an edge from its face's surface in the file */
    double tol;            /* 3D tolerance used */
    double parse_seconds, total_seconds;
} step_read_stats;

crisp_status crisp__step_read_mem(const char *name, const char *data, size_t size,
                                  const crisp_read_options *options, crisp_model **dest,
                                  step_read_stats *stats);

typedef struct step_reader {
    const step_file *f;
    crisp_model *model;
    double tol;             /* 3D tolerance (projection, vertex matching) */
    double close_rel;       /* closure tolerance, fraction of a face's domain size */
    double angle_unit;      /* radians per file angle unit */
    int depth;              /* reference nesting of the conversion in progress (cycle guard) */
    step_read_stats *stats; /* never NULL during conversion */
} step_reader;

#define STEP_MAX_DEPTH 48

/* ---- access helpers (step_access.c) -------------------------------------------------------------
 * Each returns CRISP_OK or an error whose message reads
 *   "<file>: #<id> (line <n>) <TYPE>: <what was expected>". */

/* Report an error about entity e. */
crisp_status crisp__step_fail(const step_reader *r, const step_entity *e, crisp_status st,
                              const char *fmt, ...) CRISP_PRINTF(4, 5);
/* The entity's (first) type name as a C string in buf. */
const char *crisp__step_type(const step_reader *r, const step_entity *e, char *buf, size_t cap);
/* 1 when the instance is (or, for a complex instance, contains a part) named `type`. */
int crisp__step_is(const step_reader *r, const step_entity *e, const char *type);
/* The part named type (or the only part of a simple instance when type is NULL). */
const step_part *crisp__step_part(const step_reader *r, const step_entity *e, const char *type);
/* Parameter i of the part (NULL when absent). */
const step_value *crisp__step_param(const step_reader *r, const step_part *p, int i);
/* 1 when value v's text (enum, string, typed name) equals s. */
int crisp__step_text_is(const step_reader *r, const step_value *v, const char *s);
/* List element i of v (v must be a list). */
const step_value *crisp__step_elem(const step_reader *r, const step_value *v, uint32_t i);

/* Typed getters on parameter i of part p of entity e. */
crisp_status crisp__step_get_real(const step_reader *r, const step_entity *e, const step_part *p,
                                  int i, double *dest);
crisp_status crisp__step_get_int(const step_reader *r, const step_entity *e, const step_part *p,
                                 int i, int lo, int hi, int *dest);
crisp_status crisp__step_get_bool(const step_reader *r, const step_entity *e, const step_part *p,
                                  int i, int *dest);
crisp_status crisp__step_get_list(const step_reader *r, const step_entity *e, const step_part *p,
                                  int i, const step_value **dest);
/* A reference parameter (or list element when v is given) resolved to its entity. */
crisp_status crisp__step_get_ref(const step_reader *r, const step_entity *e, const step_part *p,
                                 int i, const step_entity **dest);
crisp_status crisp__step_deref(const step_reader *r, const step_entity *e, const step_value *v,
                               const step_entity **dest);
/* Real number from a value (int, real or a typed measure wrapping one). */
int crisp__step_value_real(const step_reader *r, const step_value *v, double *dest);

/* CARTESIAN_POINT (dim 2 or 3 in *dim; missing coordinates are 0), DIRECTION (normalised),
 * VECTOR (direction * magnitude). */
crisp_status crisp__step_point(step_reader *r, const step_entity *e, double p[3], int *dim);
crisp_status crisp__step_direction(step_reader *r, const step_entity *e, double d[3]);
crisp_status crisp__step_vector(step_reader *r, const step_entity *e, double d[3]);
/* AXIS2_PLACEMENT_3D / AXIS2_PLACEMENT_2D / AXIS1_PLACEMENT. */
crisp_status crisp__step_placement(step_reader *r, const step_entity *e, crisp_placement *dest);

/* ---- curves (step_curve.c) ----------------------------------------------------------------------
 */

typedef enum step_curve_kind {
    STEP_CURVE_LINE,      /* p + t * d */
    STEP_CURVE_CONIC,     /* circle or ellipse: o + rx cos t x + ry sin t y */
    STEP_CURVE_BSPLINE,   /* nurbs over its own domain */
    STEP_CURVE_HYPERBOLA, /* o + rx cosh t x + ry sinh t y */
    STEP_CURVE_PARABOLA   /* o + rx (t^2 x + 2 t y), rx the focal distance */
} step_curve_kind;

/* A curve in the file's own parametrisation (the one vertex and pcurve parameters refer to). */
typedef struct step_curve {
    step_curve_kind kind;
    int dim;      /* 2 or 3 */
    int periodic; /* conics, closed periodic B-splines */
    double period;
    double p[3], d[3];  /* line */
    crisp_placement pl; /* conic */
    double rx, ry;
    crisp_curve *nurbs; /* B-spline (owned) */
    double t0, t1;      /* bounded parameter range (-inf/+inf for unbounded lines and conics) */
    int id;             /* entity of the geometry, for messages */
    int reversed;       /* a TRIMMED_CURVE against its basis' sense: the file's curve runs along
                           decreasing parameter of this one */
} step_curve;

/* Knot vector (count + degree + 1 values) implied by UNIFORM_*, QUASI_UNIFORM_* or BEZIER_* curve
 * and surface forms; an error for any other B-spline without knots. */
crisp_status crisp__step_implied_knots(step_reader *r, const step_entity *e, int degree, int count,
                                       double **dest);
/* The SURFACE_CURVE (SEAM_CURVE, ...) part of e; *off is the index of its curve_3d parameter
 * (after the name in a simple instance, first in a complex one). */
const step_part *crisp__step_surface_curve_part(const step_reader *r, const step_entity *e,
                                                int *off);
/* Convert a curve entity (LINE, CIRCLE, ELLIPSE, HYPERBOLA, PARABOLA, B_SPLINE_CURVE_WITH_KNOTS
 * (rational too), TRIMMED_CURVE, SURFACE_CURVE / SEAM_CURVE (their 3D curve), POLYLINE). */
crisp_status crisp__step_curve(step_reader *r, const step_entity *e, step_curve *dest);
void crisp__step_curve_free(step_curve *c);
void crisp__step_curve_eval(const step_curve *c, double t, double *dest);
/* Parameter of the point of c nearest to p, searched in [lo, hi] (finite). */
double crisp__step_curve_invert(const step_curve *c, const double *p, double lo, double hi);
/* The curve over [t0, t1] as a NURBS in the same direction (t0 < t1). */
crisp_status crisp__step_curve_nurbs(const step_curve *c, double t0, double t1, crisp_curve **dest);

/* ---- surfaces (step_surface.c) ------------------------------------------------------------------
 */

typedef enum step_surface_kind {
    STEP_SURF_PLANE,
    STEP_SURF_CYLINDER,
    STEP_SURF_CONE,
    STEP_SURF_SPHERE,
    STEP_SURF_TORUS,
    STEP_SURF_REVOLUTION,
    STEP_SURF_EXTRUSION,
    STEP_SURF_BSPLINE
} step_surface_kind;

typedef struct step_surface {
    step_surface_kind kind;
    crisp_placement pl;
    double r, r2, semi;          /* radius, minor radius (torus), semi-angle (cone) */
    step_curve profile;          /* revolution / extrusion swept curve */
    double axis_p[3], axis_d[3]; /* revolution axis; extrusion vector */
    crisp_surface *nurbs;        /* B-spline (owned) */
    int u_periodic, v_periodic;  /* which file coordinates are angles (period 2 pi) */
    int id;
} step_surface;

crisp_status crisp__step_surface(step_reader *r, const step_entity *e, step_surface *dest);
void crisp__step_surface_free(step_surface *s);
/* Point of the surface at file parameters (u, v). */
void crisp__step_surface_eval(const step_surface *s, double u, double v, double p[3]);
/* File parameters of the point nearest p; angles are returned near the reference angles in ref
 * (ref may be NULL). Analytic for the elementary surfaces, point inversion otherwise. */
void crisp__step_surface_invert(const step_surface *s, const double p[3], const double *ref,
                                double uv[2]);
/* Build the NURBS surface covering the file-parameter box [u0, u1] x [v0, v1] (ignored for
 * B-spline surfaces). */
crisp_status crisp__step_surface_build(step_reader *r, const step_surface *s, const double box[4],
                                       crisp_surface **dest, double nbox[4]);
/* Map file parameters to the NURBS parameters of the surface built over box. */
void crisp__step_surface_map(const step_surface *s, const double box[4], const double uv[2],
                             double dest[2]);
/* 1 when the map exchanges u and v (the NURBS normal is then the opposite of the file's). */
int crisp__step_surface_swaps(const step_surface *s);
/* 1 when the map is affine in each coordinate (pcurves can be used as they are). */
int crisp__step_surface_map_linear(const step_surface *s, int coord);

/* ---- faces, units, colours ----------------------------------------------------------------------
 */

/* Convert one ADVANCED_FACE (or FACE_SURFACE) into face (not yet added). A face that cannot be
 * made valid returns CRISP_ERR_NUMERIC / CRISP_ERR_UNSUPPORTED with a message; the caller skips. */
crisp_status crisp__step_face(step_reader *r, const step_entity *e, crisp_face *dest);
/* A CURVE_BOUNDED_SURFACE, and a bare bounded surface (B-spline, RECTANGULAR_TRIMMED_SURFACE) of a
 * geometric set, as a face (step_bounded.c). Errors as for crisp__step_face. */
crisp_status crisp__step_bounded_face(step_reader *r, const step_entity *e, crisp_face *dest);
crisp_status crisp__step_bare_face(step_reader *r, const step_entity *e, crisp_face *dest);
/* model->unit_to_mm from the length unit; r->angle_unit from the plane angle unit. */
void crisp__step_units(step_reader *r);
/* Millimetres per length unit of a representation context; 0 when it names none. */
double crisp__step_context_length_unit(step_reader *r, const step_entity *ctx);
/* Colours of STYLED_ITEMs onto the faces (face_ids[i] is the entity of model face i). */
/* The first fill colour among a styled item's styles (a list value); 0 when none. */
int crisp__step_style_colour(step_reader *r, const step_value *styles, float rgb[3]);
void crisp__step_colors(step_reader *r, const int *face_ids, const int *shell_of_face,
                        int face_count);

/* ---- assemblies (step_assembly.c) --------------------------------------------------------------
 * Replace the model's faces (face i from entity face_ids[i], owners[2 i] its shell or set,
 * owners[2 i + 1] its solid or surface model, 0 when none) by one placed copy per use of the
 * representation holding them in the assembly structure; faces outside it stay as they are. */
crisp_status crisp__step_assembly(step_reader *r, const int *face_ids, const int *owners,
                                  int face_count);

#endif
