/* crisp frep_mesh: watertight, 2-manifold, self-intersection-free triangle meshes of f-rep parts
 * on the interval octree (cells proven inside or outside are never split; the tape is shortened
 * per cell), streamed to a sink, and binary STL / OBJ / PLY writers for the sink.
 *
 * Offers:
 *   crisp_frep_mesh_desc, crisp_frep_mesh_sink, crisp_frep_mesh_stats
 *   crisp_frep_mesh                  mesh a tape over a region (marching tetrahedra, mesh.c)
 *   crisp_frep_mesh_writer_open/_close   a sink that writes .stl (binary), .obj or .ply (binary)
 *
 * Method (why: src/frep/mesh.c): marching tetrahedra on the Kuhn (Freudenthal) split of the
 * finest grid cubes of the octree's undecided cells, with each edge's vertex found on the
 * function by regula falsi; vertices are shared by edge, so the mesh is closed and manifold
 * by construction, and each triangle lies inside its tetrahedron, so triangles of different
 * tetrahedra meet only in shared edges and vertices. Creases: a crease crossing a
 * tetrahedron's face bends the face's path at a face point, and the polygon is fanned from a
 * cell point (the QEF point of the tangent planes) strictly inside the tetrahedron, which cannot
 * fold. Memory: the edge table keeps only the walk's front.
 */
#ifndef CRISP_FREP_MESH_H
#define CRISP_FREP_MESH_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "crisp/core.h"
#include "crisp/frep.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct crisp_frep_mesh_desc {
    double region[6];     /* x0, x1, y0, y1, z0, z1; all zero: crisp_frep_fit_region's box */
    int resolution;       /* grid cells along the region's longest side; 0: 128 */
    double cell;          /* > 0: the grid cell's edge instead (overrides resolution) */
    double max_megabytes; /* the edge table's limit (it holds the walk's front); 0: 8192 */
    int no_features;      /* 1: no feature points (plain marching tetrahedra) */
    int no_tips;          /* 1: cell points stay inside their own tetrahedron (for measuring) */
    /* index, count (count = 8^k): mesh only the octree's cell `index` of its 8^k cells k levels
     * below the root (octant digits of index, most significant first; bits x, y, z). The
     * cells' meshes are the whole mesh's pieces, vertex for vertex: a vertex on a face between
     * cells is the same point in both (issue 15: split jobs, welded by crisp merge). 0, 0: the
     * whole region. CRISP_ERR_INVALID_ARG when the octree has fewer than k levels. */
    int split_cell[2];
} crisp_frep_mesh_desc;

/* Receives the mesh as it is made: vertices numbered from 0 in the order given, each triangle
 * after its vertices, counter-clockwise seen from outside (normals point out of the part). */
typedef struct crisp_frep_mesh_sink {
    void *ctx;
    crisp_status (*vertex)(void *ctx, const float p[3]);
    crisp_status (*triangle)(void *ctx, const uint32_t v[3], const float p[3][3]);
} crisp_frep_mesh_sink;

typedef struct crisp_frep_mesh_stats {
    size_t vertices, triangles;
    double cell;           /* the grid cell's edge */
    double region[6];      /* the region meshed */
    size_t leaves;         /* undecided octree leaves (blocks of 4^3 grid cubes) meshed */
    size_t intervals;      /* interval evaluations */
    size_t thin_cubes;     /* grid cubes whose corners agree but whose centre differs: a feature
                              thinner than the cell, lost in the mesh */
    double thin_at[3];     /* the centre of one such cube */
    size_t cut_points;     /* inside grid points on the region's border (the region cuts the part;
                              the mesh is closed there by the region's faces) */
    size_t nan_points;     /* grid points where f is NaN (taken as outside) */
    size_t peak_bytes;     /* the mesher's own peak memory (edge table, tapes) */
    size_t feature_points; /* tetrahedra whose polygon was fanned from a cell point */
    size_t face_points;    /* faces where a crease crosses: their path bends at a face point */
    size_t tip_points;     /* cell points in the all-outside tetrahedron beside their own */
} crisp_frep_mesh_stats;

/* Mesh the part f < 0 of tape t. CRISP_ERR_INVALID_ARG on a bad region or resolution,
 * CRISP_ERR_LIMIT above 2^20 cells per side or when the edge table would pass max_megabytes,
 * errors of the region fit, and the sink's errors. */
crisp_status crisp_frep_mesh(const crisp_frep_tape *t, const crisp_frep_mesh_desc *desc,
                             const crisp_frep_mesh_sink *sink, crisp_frep_mesh_stats *stats);

/* A sink writing path: binary STL (.stl), OBJ (.obj) or binary little-endian PLY (.ply), by the
 * extension. Memory: none per triangle (PLY keeps its faces in a temporary file until close). */
typedef struct crisp_frep_mesh_writer crisp_frep_mesh_writer;
crisp_status crisp_frep_mesh_writer_open(const char *path, crisp_frep_mesh_writer **dest,
                                         crisp_frep_mesh_sink *sink);
/* Finishes the file (counts in the STL and PLY headers) and frees the writer; NULL is a no-op. */
crisp_status crisp_frep_mesh_writer_close(crisp_frep_mesh_writer *w);

#ifdef __cplusplus
}
#endif
#endif
