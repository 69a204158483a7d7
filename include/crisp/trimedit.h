/* crisp trimedit: the edit model of the trim-editing demo (issue 11). The trim loops of one face
 * of a crisp_model are edited in place as NURBS curves in the face's (u, v) domain; after every
 * edit the face is valid for the renderer and the OBJ writer (what crisp_scene_update_trim and
 * crisp_write_obj assume of a model: every curve well formed, every loop closed and inside the
 * domain, outer loops counter-clockwise and holes clockwise). Wu & Peters 2015 ("real-time trim
 * curve editing") is the use; the operations follow The NURBS Book (knot insertion A5.1, knot
 * removal 5.4, circles as rational quadratics 7.5).
 *
 * Offers:
 *   crisp_trimedit_create / _destroy     an editor on face `face` of a model (the model is
 *                                        borrowed and changed in place)
 *   crisp_trimedit_move_point            move a control point (joints of curves move together;
 *                                        clamped to the domain; optional snap to its boundary)
 *   crisp_trimedit_set_weight            change a weight (zero, negative, non-finite: refused)
 *   crisp_trimedit_insert_knot           knot insertion: one more control point, same curve
 *   crisp_trimedit_remove_knot           knot removal where the curve allows it, else refused
 *   crisp_trimedit_delete_point          remove a control point and one knot (the curve changes)
 *   crisp_trimedit_transform_loop        an affine map of a whole loop (move, scale, rotate)
 *   crisp_trimedit_add_circle / _add_rectangle / _add_polygon
 *                                        a new hole (the circle as an exact rational quadratic)
 *   crisp_trimedit_delete_loop           delete a hole (the outer loop stays)
 *   crisp_trimedit_undo / _redo / _group_begin / _group_end
 *                                        every edit is undoable; a group (a drag) is one step
 *   crisp_trimedit_pick_point / _pick_curve
 *                                        the control point or curve point nearest a (u, v)
 *   crisp_trimedit_check                 loops crossing themselves or each other (flagged, not
 *                                        refused: the renderer's even-odd rule still draws them)
 *   crisp_trimedit_example               the built-in example: a bicubic surface with an outer
 *                                        loop and two holes
 *
 * Every operation either succeeds, or returns an error with a message (crisp_error_message())
 * and leaves the face as it was. Control points are named by (loop, curve, index); the ends of
 * the curves of a loop are joints shared by two curves (curves are clamped when the editor opens
 * the face, which keeps every curve exactly). When an edit reverses a loop to keep its
 * orientation, a crisp_trimedit_ref passed to it is updated to name the same point.
 */
#ifndef CRISP_TRIMEDIT_H
#define CRISP_TRIMEDIT_H

#include <stdint.h>

#include "crisp/model.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct crisp_trimedit crisp_trimedit;

/* A control point of the edited face: curve `curve` of loop `loop`, point `index`. */
typedef struct crisp_trimedit_ref {
    int loop, curve, index;
} crisp_trimedit_ref;

typedef struct crisp_trimedit_desc {
    int history; /* undo steps kept; 0: 256 */
    /* Knot removal tolerance on homogeneous control points, as a fraction of the domain's
     * size; 0: 1e-9. */
    double remove_tol;
} crisp_trimedit_desc;

/* The face's loops are made ready for editing without changing any curve: unclamped curves are
 * replaced by their clamped equals, the gaps at joints (within the model's closure tolerance)
 * closed exactly, orientation normalised. A face without loops gets an outer loop along its
 * domain boundary. desc may be NULL. The model must outlive the editor; the editor changes only
 * model->faces[face].loops and .loop_count. */
crisp_status crisp_trimedit_create(crisp_model *model, int face, const crisp_trimedit_desc *desc,
                                   crisp_trimedit **dest);
void crisp_trimedit_destroy(crisp_trimedit *ed);

const crisp_face *crisp_trimedit_face(const crisp_trimedit *ed);
int crisp_trimedit_face_index(const crisp_trimedit *ed);
/* u0, u1, v0, v1 of the face's surface. */
void crisp_trimedit_domain(const crisp_trimedit *ed, double dest[4]);
/* Bumped by every change of the loops (edits, undo, redo). */
uint64_t crisp_trimedit_version(const crisp_trimedit *ed);

/* Euclidean (u, v) and weight of a control point; CRISP_ERR_INVALID_ARG for a bad ref. */
crisp_status crisp_trimedit_point(const crisp_trimedit *ed, crisp_trimedit_ref ref, double uv[2],
                                  double *weight);

/* ---- edits ----------------------------------------------------------------------------------- */

/* Move a control point to uv (clamped to the domain). A point at a joint moves the neighbouring
 * curve's end with it. snap > 0: a coordinate within snap of a domain edge is put on that edge.
 * A move to where the point already is changes nothing (no new version, no undo step). */
crisp_status crisp_trimedit_move_point(crisp_trimedit *ed, crisp_trimedit_ref *ref,
                                       const double uv[2], double snap);
/* Put the point on the nearest domain edge (the snap of the menu). */
crisp_status crisp_trimedit_snap_point(crisp_trimedit *ed, crisp_trimedit_ref *ref);
/* The point keeps its (u, v); weight must be finite and > 0. */
crisp_status crisp_trimedit_set_weight(crisp_trimedit *ed, crisp_trimedit_ref ref, double weight);
/* Insert knot t (inside the curve's domain, multiplicity kept <= degree) into a curve. */
crisp_status crisp_trimedit_insert_knot(crisp_trimedit *ed, int loop, int curve, double t);
/* Remove interior knot knots[knot] of a curve when the curve stays within the tolerance. */
crisp_status crisp_trimedit_remove_knot(crisp_trimedit *ed, int loop, int curve, int knot);
/* Remove an interior control point (not a joint) and one knot of its support; refused when the
 * curve would have fewer than degree + 1 points or the loop would have fewer than 3. */
crisp_status crisp_trimedit_delete_point(crisp_trimedit *ed, crisp_trimedit_ref ref);
/* uv' = m[.][0] u + m[.][1] v + m[.][2] for every control point of the loop (exact for rational
 * curves). Refused when the loop would leave the domain or collapse (|det| < 1e-12). */
crisp_status crisp_trimedit_transform_loop(crisp_trimedit *ed, int loop, const double m[2][3]);
/* The centre of the loop's control-point box (the pivot for scale and rotate). */
void crisp_trimedit_loop_center(const crisp_trimedit *ed, int loop, double dest[2]);
/* New holes (clockwise, appended as the last loop); refused outside the domain. */
crisp_status crisp_trimedit_add_circle(crisp_trimedit *ed, const double center[2], double radius);
crisp_status crisp_trimedit_add_rectangle(crisp_trimedit *ed, const double lo[2],
                                          const double hi[2]);
/* A closed polygon of n >= 3 corners (2 n values), degree 1, either orientation. */
crisp_status crisp_trimedit_add_polygon(crisp_trimedit *ed, int n, const double *uv);
/* Delete a hole; outer loops are refused. */
crisp_status crisp_trimedit_delete_loop(crisp_trimedit *ed, int loop);

/* ---- history --------------------------------------------------------------------------------- */

crisp_status crisp_trimedit_undo(crisp_trimedit *ed);
crisp_status crisp_trimedit_redo(crisp_trimedit *ed);
int crisp_trimedit_can_undo(const crisp_trimedit *ed);
int crisp_trimedit_can_redo(const crisp_trimedit *ed);
/* Edits between begin and end are one undo step (a drag); groups do not nest. */
void crisp_trimedit_group_begin(crisp_trimedit *ed);
void crisp_trimedit_group_end(crisp_trimedit *ed);

/* ---- picking --------------------------------------------------------------------------------- */

/* The control point nearest uv within radius (Euclidean in (u, v)); 0 when none. */
int crisp_trimedit_pick_point(const crisp_trimedit *ed, const double uv[2], double radius,
                              crisp_trimedit_ref *dest);
/* The curve point nearest uv within radius: loop, curve and parameter; 0 when none. */
int crisp_trimedit_pick_curve(const crisp_trimedit *ed, const double uv[2], double radius,
                              int *loop, int *curve, double *t);

/* ---- validity -------------------------------------------------------------------------------- */

#define CRISP_TRIMEDIT_SELF_CROSSING 1u /* the loop crosses itself */
#define CRISP_TRIMEDIT_CROSSES_OTHER 2u /* the loop crosses another loop */

typedef struct crisp_trimedit_report {
    int valid; /* no loop crosses itself or another */
    int loop_count;
    unsigned flags[64]; /* CRISP_TRIMEDIT_* of the first 64 loops */
    double where[2];    /* (u, v) of the first crossing found */
    char message[160];  /* "loop 2 crosses loop 0 near (0.41, 0.52)" or "" */
} crisp_trimedit_report;

/* Crossings of the loops' polylines (each Bézier piece sampled finely enough to show crossings
 * of the curves themselves; touching is not crossing). Cached per version. */
const crisp_trimedit_report *crisp_trimedit_check(crisp_trimedit *ed);

/* ---- the built-in example -------------------------------------------------------------------- */

/* A model with one face: a bicubic B-spline surface (4 x 4 patches over [0, 1]^2, a smooth bump)
 * with an outer loop (a closed cubic B-spline), a circular hole (rational quadratic) and a
 * rectangular hole (degree 1). */
crisp_status crisp_trimedit_example(crisp_model **dest);

#ifdef __cplusplus
}
#endif
#endif
