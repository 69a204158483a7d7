/* crisp frep_cell: a per-worker evaluator of one tape over cells (axis-aligned boxes) and batches
 * of points, for renderers outside src/frep that subdivide their own space (the scene renderer's
 * view frustum, src/render/frep_part.c). It brings the 2D/3D solver's tools (Keeter 2012 branch
 * caching, Fidget-style SSA tape shortening) to them without exposing the tape's layout.
 *
 * Offers:
 *   crisp_frep_cell                 scratch for one worker: interval registers and choices, a
 *                                   stack of shortened tapes, float and gradient lanes; all
 *                                   allocated once by crisp_frep_cell_create
 *   crisp_frep_subtape              a tape or a shortened copy of it (a view; no ownership)
 *   crisp_frep_cell_interval        interval over a box, recording min/max choices
 *   crisp_frep_cell_shorten         the tape for the box's sub-boxes, after those choices
 *   crisp_frep_cell_mark/_release   stack discipline for the shortened tapes
 *   crisp_frep_cell_eval/_grad      CRISP_FREP_CELL_LANES points at once (value; gradient)
 *
 * A shortened tape gives, at every point of the box it was made for and of its sub-boxes, the
 * same float value and gradient as the tape it came from, and the same interval on every sub-box
 * (the dropped side of a min/max loses everywhere there), so subdivision decisions do not change.
 */
#ifndef CRISP_FREP_CELL_H
#define CRISP_FREP_CELL_H

#include <stddef.h>

#include "crisp/core.h"
#include "crisp/frep.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Points per call of crisp_frep_cell_eval / _grad. */
#define CRISP_FREP_CELL_LANES 64

typedef struct crisp_frep_cell crisp_frep_cell;

typedef struct crisp_frep_subtape {
    const void *ins; /* the instructions (private layout) */
    const void *ssa; /* their SSA operands */
    size_t length;   /* instructions */
    int registers;
} crisp_frep_subtape;

/* Scratch for evaluating tape (which must outlive it) and its shortened copies; stack_entries is
 * the room for shortened tapes, in instructions (0: 8 x the tape's length, at most 2^20, never
 * less than the length). */
crisp_status crisp_frep_cell_create(const crisp_frep_tape *tape, size_t stack_entries,
                                    crisp_frep_cell **dest);
void crisp_frep_cell_destroy(crisp_frep_cell *c);
/* The whole tape. */
crisp_frep_subtape crisp_frep_cell_full(const crisp_frep_cell *c);

/* Interval of t over the box [x0, x1] x [y0, y1] x [z0, z1] into dest (lo, hi; both NaN when some
 * point may give NaN), as crisp_frep_eval_interval. Records which side of each min/max wins over
 * the box, for crisp_frep_cell_shorten. Returns the number of decided min/max. */
size_t crisp_frep_cell_interval(crisp_frep_cell *c, crisp_frep_subtape t, const float x[2],
                                const float y[2], const float z[2], float dest[2]);
/* The tape t shortened after the choices of the last crisp_frep_cell_interval call (which must
 * have been on t), pushed on the cell's stack; t itself when there is no room left or the
 * shortened tape would need more registers than the full one. */
crisp_frep_subtape crisp_frep_cell_shorten(crisp_frep_cell *c, crisp_frep_subtape t);
/* Stack position, and popping every tape pushed since that mark. */
size_t crisp_frep_cell_mark(const crisp_frep_cell *c);
void crisp_frep_cell_release(crisp_frep_cell *c, size_t mark);

/* Values of t at CRISP_FREP_CELL_LANES points; the result stays valid until the next call. */
const float *crisp_frep_cell_eval(crisp_frep_cell *c, crisp_frep_subtape t, const float *x,
                                  const float *y, const float *z);
/* Value and gradient at CRISP_FREP_CELL_LANES points: four planes of CRISP_FREP_CELL_LANES floats
 * (f, df/dx, df/dy, df/dz); valid until the next call. */
const float *crisp_frep_cell_grad(crisp_frep_cell *c, crisp_frep_subtape t, const float *x,
                                  const float *y, const float *z);

#ifdef __cplusplus
}
#endif
#endif
