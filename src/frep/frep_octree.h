/* Private to the frep module: the interval octree walker (octree.c) used by the region fit,
 * the mesher and the mass properties. */
#ifndef CRISP_FREP_OCTREE_H
#define CRISP_FREP_OCTREE_H

#include "frep_internal.h"

#define FREP_OCTREE_MAX_DEPTH 24

enum { FREP_CELL_OUT = 0, FREP_CELL_IN = 1, FREP_CELL_AMBIGUOUS = 2, FREP_CELL_UNKNOWN = 3 };

/* visit: a cell proven out or in (any depth), or an undecided leaf at max_depth (AMBIGUOUS, or
 * UNKNOWN when its interval is NaN or the walk ran out of intervals), with the tape shortened for
 * it (valid during the call). A nonzero return stops the walk and is returned by it. */
typedef int (*frep_octree_visit)(void *ctx, const float b[6], int depth, int cls, frep_span t);

typedef struct frep_octree {
    const crisp_frep_tape *t;
    int max_depth;
    int planar;           /* split x and y only */
    size_t max_intervals; /* 0: no limit; past it cells are reported UNKNOWN unsplit */
    frep_octree_visit visit;
    void *ctx;
    /* scratch and counters */
    float *lo, *hi;
    uint8_t *choices;
    frep_ins *tapes;
    uint32_t *ssas;
    frep_shorten_scratch sc;
    size_t intervals;
    int truncated;
} frep_octree;

crisp_status crisp__frep_octree_init(frep_octree *o, const crisp_frep_tape *t, int max_depth);
void crisp__frep_octree_free(frep_octree *o);
int crisp__frep_octree_walk(frep_octree *o, const float box[6]);
/* One interval of t over box b; the min/max choices go to o->choices, their count to *decided. */
int crisp__frep_octree_classify(frep_octree *o, frep_span t, const float b[6], size_t *decided);

#endif
