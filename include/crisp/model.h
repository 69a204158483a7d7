/* crisp model: what a CAD file becomes in memory. A model is a list of faces; a face is a NURBS
 * surface cut by trim loops in its (u, v) domain. Every loop is closed, lies in the surface's
 * domain, and is oriented: outer loops counter-clockwise, holes clockwise (normalised on load).
 * A face without loops is the whole domain rectangle.
 *
 * Offers:
 *   crisp_model_create / _destroy / _add_face / _bbox / _stats
 *   crisp_trim_loop_* helpers: signed area, closure gap, orientation, domain check
 *
 * A loop is a sequence of 2D curves (crisp_curve, dim 2), each used over its whole domain and
 * in loop order: the end of curve k meets the start of curve k + 1 and the last meets the first
 * (within the closure tolerance). Readers trim and reverse source curves to reach this form.
 */
#ifndef CRISP_MODEL_H
#define CRISP_MODEL_H

#include "crisp/nurbs.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct crisp_trim_loop {
    int is_outer; /* 1: outer boundary (CCW), 0: hole (CW) */
    int curve_count;
    crisp_curve **curves; /* owned; dim 2 */
} crisp_trim_loop;

typedef struct crisp_face {
    crisp_surface *surface; /* owned */
    int loop_count;
    crisp_trim_loop *loops; /* owned */
    int has_color;
    float color[4]; /* RGBA in [0, 1] when has_color */
    int source_id;  /* entity number / DE pointer / line in the source file, for messages */
    int reversed;   /* 1 when the face's outward normal is -(S_u x S_v) */
    int body;       /* faces of one shell or solid (one placed copy of it) share a
                       non-zero body; 0 when the reader does not say */
    int occurrence; /* 1 + index into crisp_model.occurrences of the assembly occurrence (STEP
                       product occurrence) this copy of the face belongs to; 0: none */
} crisp_face;

/* One node of a model's assembly tree (STEP: a placed product occurrence). */
typedef struct crisp_occurrence {
    char *name;    /* owned: the occurrence's name from the file ("" when it has none) */
    int parent;    /* index into crisp_model.occurrences, -1 for a root */
    int source_id; /* the entity that placed it (STEP NEXT_ASSEMBLY_USAGE_OCCURRENCE #id), 0 */
} crisp_occurrence;

/* One counted kind of thing a reader skipped, with why ("entity 116 point: not a surface"), in
 * full (no length limit). */
typedef struct crisp_skip_note {
    char *what; /* owned */
    int count;
} crisp_skip_note;

typedef struct crisp_model {
    int face_count, face_cap;
    crisp_face *faces;
    char format[16];   /* "IGES", "STEP", "OBJ" */
    double unit_to_mm; /* model units in millimetres (1 when unknown) */
    int skip_count;
    crisp_skip_note *skips; /* what the reader skipped and why */
    int faces_dropped;      /* faces the reader could not build (each also has a skip note) */
    double tolerance;       /* the reader's distance tolerance in model units (0: not known) */
    int occurrence_count;   /* the assembly tree (parents before children); 0: none read */
    crisp_occurrence *occurrences;
} crisp_model;

crisp_status crisp_model_create(crisp_model **dest);
void crisp_model_destroy(crisp_model *m);
/* Moves *face into the model (the model owns its surface and loops afterwards). */
crisp_status crisp_model_add_face(crisp_model *m, crisp_face *face);
/* Count one skipped item under `what` (merged with earlier notes of the same text). At most
 * CRISP_MODEL_MAX_NOTES different texts are kept; later new ones count under a last note. */
#define CRISP_MODEL_MAX_NOTES 10000
crisp_status crisp_model_note_skip(crisp_model *m, const char *what);
/* crisp_model_note_skip with a printf format. */
crisp_status crisp_model_note_skipf(crisp_model *m, const char *fmt, ...) CRISP_PRINTF(2, 3);
/* A face the reader could not build: its note (printf format), and faces_dropped + 1. */
crisp_status crisp_model_note_dropped(crisp_model *m, const char *fmt, ...) CRISP_PRINTF(2, 3);
/* Append an assembly occurrence (name copied; NULL: ""); its index in *index (may be NULL). */
crisp_status crisp_model_add_occurrence(crisp_model *m, const char *name, int parent, int source_id,
                                        int *index);
/* Box of all faces' control hulls: xmin, ymin, zmin, xmax, ymax, zmax. */
void crisp_model_bbox(const crisp_model *m, double *dest);

/* Frees the loops and surface of a face that was not added to a model. */
void crisp_face_free(crisp_face *face);
/* A deep copy of src (surface and loops) into *dest, which owns it afterwards. */
crisp_status crisp_face_copy(const crisp_face *src, crisp_face *dest);
/* Apply the affine map m (x' = m[.][0..2] x + m[.][3], rows x, y, z) to the face's homogeneous
 * control points (exact for rational surfaces); a mirroring map flips `reversed`. */
void crisp_face_transform(crisp_face *f, const double m[3][4]);
void crisp_trim_loop_free(crisp_trim_loop *loop);

typedef struct crisp_model_stats {
    int faces;
    int bezier_patches; /* after Bézier extraction of every surface */
    int outer_loops, hole_loops;
    int trim_curves; /* B-spline trim curves */
    int trim_pieces; /* Bézier trim pieces after extraction */
    int rational_surfaces;
    int max_degree_u, max_degree_v, max_trim_degree;
    unsigned degrees_seen; /* bit d set when some surface has degree d in u or v */
} crisp_model_stats;

crisp_status crisp_model_stats_compute(const crisp_model *m, crisp_model_stats *dest);

/* Places where faces that meet in the file do not meet in crisp's model (issue 13): a boundary
 * point of one face whose nearest boundary of another face is farther than tol but nearer than
 * limit (farther than limit: a free edge, not a gap). Faces of different non-zero bodies are not
 * neighbours (parts of an assembly may touch without sharing edges). Grouped per pair of faces
 * (indices into m->faces), largest first. */
typedef struct crisp_gap {
    int face[2];
    double gap;   /* largest distance found between the two faces' boundaries */
    double at[3]; /* where (on face[0] or face[1]) */
} crisp_gap;

typedef struct crisp_gap_report {
    double tolerance, limit;
    long samples;     /* boundary samples with another face within limit */
    long gap_samples; /* of those, farther than tolerance */
    int incomplete;   /* 1: the model's boundaries were too long to measure (nothing reported) */
    int count, cap;
    crisp_gap *gaps; /* count pairs, largest gap first */
} crisp_gap_report;

crisp_status crisp_model_gaps(const crisp_model *m, double tol, double limit,
                              crisp_gap_report *dest);
void crisp_gap_report_free(crisp_gap_report *r);

/* Signed area of the loop (shoelace on a dense polyline of its curves): > 0 when CCW. */
double crisp_trim_loop_signed_area(const crisp_trim_loop *loop);
/* Largest gap between the end of a curve and the start of the next (including last -> first). */
double crisp_trim_loop_closure_gap(const crisp_trim_loop *loop);
/* Reverse the loop's direction (curve order and each curve). */
void crisp_trim_loop_reverse(crisp_trim_loop *loop);
/* Largest distance by which the loop's control polygons leave the domain box (0 when inside). */
double crisp_trim_loop_domain_excess(const crisp_trim_loop *loop, const double domain[4]);
/* Orient every loop of the face (outer CCW, holes CW) and close gaps up to tol by moving the
 * end points; fails with a message naming the face when a gap is larger. */
crisp_status crisp_face_normalize_loops(crisp_face *face, double tol);

#ifdef __cplusplus
}
#endif
#endif
