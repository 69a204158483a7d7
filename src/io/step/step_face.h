/* Private interface between the STEP face conversion files: edge uses and loops in the file's
 * (u, v) (step_edge.c) and their trims in the NURBS (u, v) of the face's surface (step_face.c).
 */
#ifndef CRISP_STEP_FACE_H
#define CRISP_STEP_FACE_H

#include "step_internal.h"

typedef struct edge_use {
    step_curve c3;  /* 3D curve in the file's parametrisation */
    double lo, hi;  /* curve parameter range, lo < hi (hi may pass the end of a closed B-spline) */
    int increasing; /* the loop runs along increasing curve parameter */
    int npc;        /* pcurve candidates on this face's surface */
    step_curve pc[2];
    int chosen;
    double pt0[2], pt1[2]; /* pcurve parameter range of each candidate */
    double shift[2];       /* multiple of the period added to the chosen pcurve (file uv) */
    int ns;                /* samples in loop order: curve parameter and file (u, v) */
    double *ts, *uv;
    int id;      /* ORIENTED_EDGE for messages */
    int edge_id; /* its EDGE_CURVE (a seam is used twice in one loop) */
} edge_use;

typedef struct loop_work {
    int outer_flag; /* FACE_OUTER_BOUND */
    int sense;      /* 0 when the bound's orientation is .T. (or there is none), 1 when .F. */
    int count;
    edge_use *edges;
    double box[4];
    int collapse; /* the loop passes through an apex or pole (its u jumps freely there) */
} loop_work;

typedef struct face_work {
    step_reader *r;
    const step_entity *fe;
    step_surface s;
    int nloops;
    loop_work *loops;
    double period[2]; /* 2 pi for angle coordinates, else 0 */
    double box[4];    /* file (u, v) box the NURBS covers */
    double nbox[4];   /* NURBS domain */
    double tol_uv;
    int band_a, band_b, band_rev; /* two winding loops joined along the seam (band_b follows a) */
    int ncap;                     /* VERTEX_LOOP points (a cone's apex, a sphere's pole) */
    double cap_pt[2][3];
    int cap_k; /* band_a closed at the degenerate line (coordinate 1 - cap_k) = cap_v */
    double cap_v;
    int repaired; /* the edge in progress needed a repair (checked afterwards) */
    int same;     /* the face's same_sense (its normal is the surface's) */
} face_work;

/* Set up the work of a face (or curve-bounded surface) fe on surface entity se. */
crisp_status crisp__step_work_init(face_work *w, step_reader *r, const step_entity *fe,
                                   const step_entity *se);
/* The crisp face from the loops in w (read by crisp__step_read_loops or from the boundaries of a
 * CURVE_BOUNDED_SURFACE): surface over the loops' box, trims, orientation and closure. `same` is
 * the face's same_sense. The caller still frees w. */
crisp_status crisp__step_face_finish(face_work *w, int same, crisp_face *dest);
double crisp__step_dist3(const double *a, const double *b);
/* Curve parameter t of an edge, wrapped back into a closed B-spline's domain. */
double crisp__step_curve_wrap(const step_curve *c, double t);
/* The 2D curve of a PCURVE entity pe (from its definitional representation), its angle
 * coordinates on surface s (when not NULL) converted to radians. */
crisp_status crisp__step_pcurve_curve(step_reader *r, const step_entity *pe, const step_surface *s,
                                      step_curve *dest);
/* The pcurves of a SURFACE_CURVE / SEAM_CURVE ge that lie on surface surf (its entity, at most 2).
 */
crisp_status crisp__step_find_pcurves(step_reader *r, const step_entity *ge,
                                      const step_surface *surf, edge_use *eu);
/* The boundaries of a CURVE_BOUNDED_SURFACE as loops of edge uses (step_bounded.c). */
crisp_status crisp__step_read_boundaries(face_work *w);
void crisp__step_work_free(face_work *w);
/* The bounds of the face: loops of edge uses (3D curve, range, direction, pcurves). */
crisp_status crisp__step_read_loops(face_work *w);
/* File-uv samples of every edge of a loop, continuous along the loop (seams chosen by
 * continuity, angles unwrapped). */
crisp_status crisp__step_loop_samples(face_work *w, loop_work *lw);
/* Shift of uv (per periodic coordinate) that brings it nearest to ref. */
void crisp__step_period_shift(const face_work *w, const double uv[2], const double ref[2],
                              double shift[2]);
void crisp__step_shift_loop(loop_work *lw, const double shift[2]);
/* The file-uv box the NURBS surface covers (loops' box with a margin). */
void crisp__step_choose_box(face_work *w, int outer);
/* How far a loop's end is from its start in periodic coordinate k (+-period when it winds). */
double crisp__step_winding(const face_work *w, const loop_work *lw, int k);
/* Join winding loops a and b (coordinate k) into one band: sets w->band_a, band_b, band_rev. */
crisp_status crisp__step_make_band(face_work *w, int a, int b, int k);
/* File uv of an edge use at loop fraction s in [0, 1]. */
void crisp__step_file_uv(face_work *w, edge_use *eu, double s, double uv[2]);

#endif
