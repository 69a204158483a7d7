/* Trim-boundary ribbons of the frame plan (ribbon.c). */
#ifndef CRISP_RENDER_RIBBON_H
#define CRISP_RENDER_RIBBON_H

#include "crisp/plan.h"
#include "quadtree.h"

typedef struct crisp__ribbons crisp__ribbons; /* sampling scratch, reused from frame to frame */

crisp_status crisp__ribbons_create(int workers, crisp__ribbons **dest);
void crisp__ribbons_destroy(crisp__ribbons *rb);

/* The ribbon quads of every visible face (only_face = UINT32_MAX) or of one face, laid out face
 * after face into *verts (4 vertices per quad; grown as needed, capacity *cap). face_first and
 * face_quads receive, per face of the range (indexed from its first face), the face's first quad
 * and quad count; *quad_count the total. */
crisp_status crisp__ribbons_build(crisp__ribbons *rb, const crisp__trees *trees,
                                  const crisp_scene *sc, uint32_t only_face, crisp_pool *pool,
                                  crisp_plan_ribbon_vertex **verts, size_t *cap,
                                  uint32_t *face_first, uint32_t *face_quads, uint32_t *quad_count);

#endif
