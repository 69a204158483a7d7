/* The C side of bench_occt_depth's Open CASCADE file (occt_tris.cpp): read an IGES or STEP file
 * with Open CASCADE's readers, mesh it with BRepMesh_IncrementalMesh at a given linear deflection
 * and hand back its triangles in world coordinates, each flagged where the mesh breaks its own
 * deflection. Open CASCADE is optional and never a dependency of crisp (bench/CMakeLists.txt). */
#ifndef CRISP_BENCH_OCCT_TRIS_H
#define CRISP_BENCH_OCCT_TRIS_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct occt_tris_desc {
    const char *path;   /* IGES or STEP (told apart by the ISO-10303-21 header) */
    int sew;            /* 1: sew the faces (BRepBuilderAPI_Sewing) before meshing */
    double sew_rel_tol; /* sewing tolerance as a fraction of the shape's box diagonal */
    double deflection;  /* BRepMesh linear deflection, absolute (crisp's model units) */
    double unit_to_mm;  /* crisp's model unit in mm (Open CASCADE's readers give mm); 0: 1 */
    int threads;        /* OCCT's default thread pool size */
} occt_tris_desc;

typedef struct occt_tris {
    double (*p)[3][3];  /* triangles' corners, world coordinates */
    unsigned char *off; /* per triangle: 1 where a sample point of it lies farther than the
                           deflection from the nearest point of its face's surface */
    long long count;    /* triangles */
    int faces, faces_meshed;
    long long off_count; /* triangles flagged */
    double box[6];       /* the shape's box as read (BRepBndLib, mm) */
} occt_tris;

/* Returns 0 on success; otherwise non-zero with a message in err (never throws). */
int occt_tris_mesh(const occt_tris_desc *desc, occt_tris *dest, char *err, size_t err_size);
void occt_tris_free(occt_tris *t);

#ifdef __cplusplus
}
#endif
#endif
