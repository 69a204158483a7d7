/* The C side of bench_occt's one C++ file (occt_mesh.cpp): mesh a model with Open CASCADE's
 * BRepMesh_IncrementalMesh and measure the mesh's worst screen error under crisp's camera.
 * Open CASCADE is optional and never a dependency of crisp: this is built only where its headers
 * and libraries are found (bench/CMakeLists.txt). */
#ifndef CRISP_BENCH_OCCT_MESH_H
#define CRISP_BENCH_OCCT_MESH_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct occt_mesh_desc {
    const char *path;      /* an IGES file, read with IGESControl_Reader */
    int sew;               /* 1: sew the faces (BRepBuilderAPI_Sewing) before meshing */
    double sew_rel_tol;    /* sewing tolerance as a fraction of the shape's box diagonal */
    double deflection;     /* BRepMesh linear deflection, absolute (model units) */
    double ang_deflection; /* BRepMesh angular deflection in radians (0: OCCT's default, 0.5) */
    int threads;           /* OCCT's default thread pool size; BRepMesh runs in parallel */
    int runs;              /* meshing runs timed (triangulation cleaned between runs) */
    /* The camera: clip = view_proj * (x, y, z, 1) with view_proj column-major (m[col][row], as
     * crisp_mat4); pixel x = (X/W + 1) W_img / 2, y = (1 - Y/W) H_img / 2 (crisp_camera_to_pixel).
     */
    double view_proj[4][4];
    double znear;
    int width, height;
} occt_mesh_desc;

typedef struct occt_mesh_result {
    int faces;        /* faces of the shape that is meshed */
    int faces_meshed; /* faces with a triangulation that has (u, v) nodes */
    long long triangles;
    double ms_median, ms_min, ms_max; /* BRepMesh_IncrementalMesh over `runs` runs */
    double worst_px; /* max over samples of max(|dx|, |dy|) on screen (crisp's test measure) */
    double worst_px_euclid; /* the same samples, Euclidean screen distance */
    double worst_3d;        /* largest 3D gap between a triangle point and S(interpolated uv) */
    long long samples_over; /* samples farther than 0.5 px (by worst_px's measure) */
    /* Those samples measured against the nearest point of the (untrimmed) surface instead
     * (GeomAPI_ProjectPointOnSurf): how many stay over 0.5 px, and the largest such distance.
     * Near worst_px: the triangles are off the surface; near 0: only their (u, v) is off. */
    long long samples_over_nearest;
    double worst_nearest_px;
    double occt_deflection; /* largest deflection BRepMesh reports on a face's triangulation */
    long long samples;      /* sample points measured (on screen, in front of the near plane) */
    double box[6];          /* the shape's bounding box as read (BRepBndLib) */
} occt_mesh_result;

/* Returns 0 on success; otherwise non-zero with a message in err (never throws). */
int occt_mesh_measure(const occt_mesh_desc *desc, occt_mesh_result *dest, char *err,
                      size_t err_size);

#ifdef __cplusplus
}
#endif
#endif
