/* A bounding hierarchy over a scene's faces (issue 12, face_tree.c): a binary tree of boxes, each
 * node's box the union of its faces' boxes, split at the median of the faces' box centres along
 * the longest axis of the centres. View-independent: its user builds it once per scene (the splat
 * store) and walks it per frame to decide a group of faces at once (all off screen, or all far
 * enough that one bound serves them), so that the per-face work follows what is on screen.
 *
 * Offers:
 *   crisp__face_tree_build  the tree of a scene's face boxes
 *   crisp__face_tree_free */
#ifndef CRISP_RENDER_FACE_TREE_H
#define CRISP_RENDER_FACE_TREE_H

#include <stdint.h>

#include "crisp/core.h"

/* Leaves hold at most this many faces. */
#define CRISP_FACE_TREE_LEAF 4
/* The tree's chunks (the units of parallel work) hold at most this many faces. */
#define CRISP_FACE_TREE_CHUNK 256

typedef struct crisp__face_node {
    double box[6];         /* the union of its faces' boxes (lo x, y, z, hi x, y, z) */
    uint32_t first, count; /* its faces: order[first .. first + count) */
    int32_t child[2];      /* -1: a leaf */
} crisp__face_node;

typedef struct crisp__face_tree {
    crisp__face_node *nodes; /* nodes[0] is the root (when node_count > 0) */
    uint32_t node_count;
    uint32_t *order;  /* the faces in the tree, each node's a contiguous range */
    uint32_t *chunks; /* disjoint subtrees of at most CRISP_FACE_TREE_CHUNK faces (or leaves)
                         that hold every face of the tree, in tree order */
    uint32_t chunk_count;
} crisp__face_tree;

/* The tree of faces f < face_count with include[f] != 0 (include NULL: all), boxes[6 f ..] their
 * boxes (finite, lo <= hi). dest is replaced (free it first if it held a tree). */
crisp_status crisp__face_tree_build(const double *boxes, const uint8_t *include,
                                    uint32_t face_count, crisp__face_tree *dest);
void crisp__face_tree_free(crisp__face_tree *t);

#endif
