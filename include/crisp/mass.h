/* crisp mass: volume, surface area, centroid and inertia tensor of B-rep models made of trimmed
 * NURBS faces, from the exact surfaces, with an error estimate.
 *
 * Offers:
 *   crisp_mass_desc, crisp_mass_props
 *   crisp_mass_model          integral properties of a model
 *   crisp_mass_props_finish   the properties from raw sums (of cells of a split job)
 *
 * Method (src/mass/brep_mass.c): the divergence theorem turns each volume integral into a surface
 * integral over the faces (e.g. V = 1/3 of the integral of p . n dA); on a face that integral is
 * over its trimmed (u, v) domain, which Green's theorem turns into an integral along the trim
 * loops of G(u, v) = integral from u0 to u of the integrand, so the trimmed domain is handled
 * exactly (no tessellation of the trims). Inner integrals: Gauss-Legendre per knot span;
 * outer: adaptive Gauss-Legendre on the Bezier pieces of the trim curves. The error estimate is
 * the difference of two quadrature orders.
 */
#ifndef CRISP_MASS_H
#define CRISP_MASS_H

#include "crisp/core.h"
#include "crisp/model.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct crisp_mass_desc {
    double tolerance; /* relative, per trim piece; 0: 1e-13 */
    /* faces [face_begin, face_end) only (a cell of a split job, issue 15); 0, 0: every face.
     * The sums (crisp_mass_props.sums) of the cells of a split add up to the whole model's. */
    int face_begin, face_end;
} crisp_mass_desc;

#define CRISP_MASS_SUMS 16 /* raw integrals per model (crisp_mass_props.sums) */

typedef struct crisp_mass_props {
    int closed; /* a closed shell: the faces' vector area vanishes, and the volume taken along
                   each axis (integrals of x n_x, y n_y, z n_z) agrees (volume < 0: the faces
                   point inwards) */
    double area, volume;
    double centroid[3];
    /* about the centroid, density 1: Ixx Iyy Izz Ixy Iyz Ixz with Ixy = -integral of x y */
    double inertia[6];
    double vector_area[3]; /* integral of n dA over all faces (0 for a closed shell) */
    double axis_volume[3]; /* integrals of x n_x, y n_y, z n_z (each the volume when closed) */
    /* estimates from two quadrature orders; volume_err adds the closure gap (the axis volumes'
     * largest difference from the volume) */
    double area_err, volume_err, inertia_err;
    size_t evaluations; /* surface evaluations */
    /* The raw surface integrals over the faces measured, about ref (the whole model's box
     * centre): area, vector area (3), V, Mx My Mz, Sxx Syy Szz, Sxy Syz Sxz, Vx Vy, with their
     * error estimates; size is the box's largest side (the closure test's length). Cells of
     * faces (issue 15) add their sums; crisp_mass_props_finish makes the rest from them. */
    double sums[CRISP_MASS_SUMS], sums_err[CRISP_MASS_SUMS], ref[3], size;
} crisp_mass_props;

/* Every face's outward normal is S_u x S_v, or its negative when face->reversed. A model that is
 * not closed (|vector area| > 1e-7 area, or the axis volumes differing by more than 1e-7 area x
 * the box's size) gets its area and closed = 0; its volume terms are then meaningless and left
 * 0. */
crisp_status crisp_mass_model(const crisp_model *m, const crisp_mass_desc *desc,
                              crisp_mass_props *dest);

/* Every field of p but evaluations from p->sums, sums_err, ref and size (what crisp_mass_model
 * does after integrating; the sums of a split job's cells added up give the whole model's
 * properties). */
void crisp_mass_props_finish(crisp_mass_props *p);

#ifdef __cplusplus
}
#endif
#endif
