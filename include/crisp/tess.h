/* crisp tess: view-dependent tessellation of Bézier patches (docs/design.md section 4).
 *
 * Offers:
 *   crisp_tess_levels        inner levels (u, v) and four edge levels of one patch
 *   crisp_tess_mesh_counts   vertex and triangle counts of a patch's mesh
 *   crisp_tess_mesh_generate the (s, t) parameters and triangles of a patch's mesh
 *
 * Edge levels make neighbouring patches crack-free: an edge of level e gets the vertices
 * k / e (k = 0..e), computed as the quotient of two integers so that both patches that share
 * the edge produce bit-identical parameters, whichever direction they walk it in.
 */
#ifndef CRISP_TESS_H
#define CRISP_TESS_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/core.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CRISP_TESS_MAX_LEVEL 64
/* Edge levels may exceed 64 where a coarse patch meets much finer ones (CPU backend). */
#define CRISP_TESS_MAX_EDGE_LEVEL 16384

/* outer[0]: edge t = 0 (along s), outer[1]: s = 1, outer[2]: t = 1, outer[3]: s = 0. */
typedef struct crisp_tess_levels {
    int inner[2]; /* along s and along t, 1..64 */
    int outer[4]; /* 1..CRISP_TESS_MAX_EDGE_LEVEL */
} crisp_tess_levels;

/* Fails (CRISP_ERR_INVALID_ARG) on a level outside its range. */
crisp_status crisp_tess_mesh_counts(const crisp_tess_levels *lv, size_t *verts, size_t *tris);
/* st: 2 * verts doubles (local patch parameters in [0, 1]); tris: 3 * tris indices, each plus
 * base, counter-clockwise in (s, t). The first outer[0] + ... + outer[3] vertices are the
 * boundary, counter-clockwise from (0, 0). */
void crisp_tess_mesh_generate(const crisp_tess_levels *lv, double *st, uint32_t *tris,
                              uint32_t base);

#ifdef __cplusplus
}
#endif
#endif
