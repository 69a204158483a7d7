/* crisp osd: Catmull-Clark limit surfaces of polygon meshes, through OpenSubdiv (the only C++ in
 * crisp, behind this C interface). The limit surface is turned into bicubic B-spline patches
 * (feature-adaptive refinement with B-spline end caps, no Gregory patches) so that the rest of
 * crisp renders them like any NURBS surface.
 *
 * Offers:
 *   crisp_osd_mesh_create / _destroy      refine a polygon cage, build the patch table
 *   crisp_osd_mesh_patch_count / _patch_surface / _patch_points / _patch_info
 *   crisp_osd_mesh_ptex_count / _eval     OpenSubdiv's own limit evaluation (PatchMap), for tests
 *   crisp_osd_mesh_limit_vertices         limit positions of the cage vertices (PrimvarRefiner)
 *
 * Conventions: boundary edges and corners are interpolated (Sdc VTX_BOUNDARY_EDGE_AND_CORNER).
 * Every patch becomes a non-rational bicubic B-spline surface with 4 x 4 control points and the
 * uniform knots -3, -2, -1, 0, 1, 2, 3, 4 in u and v, so its domain is [0, 1]^2; (u, v) of the
 * patch maps to the ptex coordinates (u0 + u * size, v0 + v * size) of its ptex face.
 * Only available when crisp is built with CRISP_OSD (CRISP_HAVE_OSD is then defined).
 */
#ifndef CRISP_OSD_H
#define CRISP_OSD_H

#include "crisp/nurbs.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CRISP_OSD_DEFAULT_ISOLATION 3
/* Bound on the cage size (vertices and face corners) accepted from a file. */
#define CRISP_OSD_MAX_ELEMENTS (1 << 22)

typedef struct crisp_osd_mesh crisp_osd_mesh;

typedef struct crisp_osd_desc {
    int vertex_count;
    const double *positions; /* vertex_count * 3 */
    int face_count;
    const int *face_sizes;    /* face_count values, each >= 3 */
    const int *face_vertices; /* sum of face_sizes 0-based vertex indices, CCW seen from outside */
    int isolation;            /* adaptive isolation level 1..10; 0: CRISP_OSD_DEFAULT_ISOLATION */
} crisp_osd_desc;

/* Fails (naming the face and the problem) on out-of-range indices, faces with fewer than three
 * or repeated vertices, non-finite positions, or topology OpenSubdiv rejects. */
crisp_status crisp_osd_mesh_create(const crisp_osd_desc *desc, crisp_osd_mesh **dest);
void crisp_osd_mesh_destroy(crisp_osd_mesh *m);

int crisp_osd_mesh_patch_count(const crisp_osd_mesh *m);
/* The patch as a bicubic B-spline surface (see the conventions above). */
crisp_status crisp_osd_mesh_patch_surface(const crisp_osd_mesh *m, int patch, crisp_surface **dest);
/* Its 16 control points (x, y, z each), u fastest: index (4 * j + i) * 3. */
void crisp_osd_mesh_patch_points(const crisp_osd_mesh *m, int patch, double dest[48]);
/* Where patch lies: its base face, its ptex face and the ptex box u0, v0, size. */
void crisp_osd_mesh_patch_info(const crisp_osd_mesh *m, int patch, int *base_face, int *ptex_face,
                               double box[3]);

/* Ptex faces: one per quad, n per n-gon (the n-gon is split into quads at its centre). */
int crisp_osd_mesh_ptex_count(const crisp_osd_mesh *m);
/* OpenSubdiv's evaluation of the limit surface at (u, v) in [0, 1]^2 of a ptex face. */
crisp_status crisp_osd_mesh_eval(const crisp_osd_mesh *m, int ptex_face, double u, double v,
                                 double dest[3]);
/* First ptex face of base face f (ptex (0,0) of a quad is its first vertex, (1,0) its second). */
int crisp_osd_mesh_ptex_of_face(const crisp_osd_mesh *m, int face);
/* Exact limit positions of the cage vertices (PrimvarRefiner::Limit): vertex_count * 3 values. */
crisp_status crisp_osd_mesh_limit_vertices(const crisp_osd_mesh *m, double *dest);

#ifdef __cplusplus
}
#endif
#endif
