/* crisp frep_mass: integral properties of f-rep parts (volume, centroid, inertia tensor) with
 * certified volume bounds and Monte Carlo standard errors, after Clark's PADL-2 block
 * decomposition: the region's octree to a given level, cells proven inside summed exactly
 * (their box moments), cells proven outside dropped, boundary cells sampled (stratified: one
 * jittered point per octant of each boundary cell, 8 per cell).
 *
 * Offers:
 *   crisp_frep_mass_desc, crisp_frep_mass
 *   crisp_frep_mass_level     one level's estimate
 *   crisp_frep_mass_predict   the time and error of a finer level, from coarser ones
 *
 * Bounds: volume_lo sums the cells proven inside, volume_hi adds every cell not proven outside;
 * the part (the points whose float coordinates give f < 0) lies between, whatever the sampling.
 * Standard errors: per boundary cell the sample covariance of the 10 integrands (1, x, y, z, x^2,
 * ..., xz) over its 8 points, as if they were independent (stratification only lowers the true
 * variance, so this is conservative), summed over the cells (independent strata); the centroid's
 * and the inertia's errors follow by the delta method.
 */
#ifndef CRISP_FREP_MASS_H
#define CRISP_FREP_MASS_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/core.h"
#include "crisp/frep.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct crisp_frep_mass_desc {
    double region[6]; /* x0, x1, y0, y1, z0, z1; all zero: the fitted box, padded by 2% */
    int level;        /* octree depth: cells of the region / 2^level per axis; 1..20 (0: 6) */
    uint64_t seed;    /* sampling seed (the same seed gives the same result) */
} crisp_frep_mass_desc;

typedef struct crisp_frep_mass {
    int level;
    double cell[3]; /* a cell's edges */
    double region[6];
    double volume, volume_se;    /* estimate and standard error */
    double volume_lo, volume_hi; /* certified bounds */
    double centroid[3], centroid_se[3];
    /* about the centroid, density 1: Ixx, Iyy, Izz, Ixy, Iyz, Ixz with Ixy = -integral of x y */
    double inertia[6], inertia_se[6];
    size_t inside_cells, boundary_cells, samples, intervals;
    double seconds;     /* time of this level (wall clock) */
    double cpu_seconds; /* and the thread's processor time (steadier under load) */
    double cpu_fixed;   /* of which the check of the region's faces (the same at every level) */
    size_t cut_cells;   /* pieces of the region's faces holding inside points */
    /* tape instructions evaluated: by the walk's single-box intervals, and by the boundary cells'
     * batched passes (16-lane interval + 64-lane points); deterministic cost measures */
    size_t walk_ops, cell_ops;
} crisp_frep_mass;

/* One level. CRISP_ERR_NUMERIC when the part is empty at this level (no inside cell or sample)
 * or the region cuts it (dest->cut_cells > 0: the result is that of the part within the region);
 * the region fit's errors when the region is to be fitted. */
crisp_status crisp_frep_mass_level(const crisp_frep_tape *t, const crisp_frep_mass_desc *desc,
                                   crisp_frep_mass *dest);

/* Clark's prediction from n >= 1 measured levels lv[0 .. n) (consecutive, coarse to fine): the
 * processor time and the volume's standard error of a finer level. Time: the region check
 * (cpu_fixed, the same at every level) plus a least-squares fit of the other processor time
 * per level to a 4^L + b 2^L + c (relative residuals): the surface's cells (Clark's K 4^L),
 * those along edges and silhouettes, and a per-level overhead. Error: falls by the last two
 * levels' factor per level. */
void crisp_frep_mass_predict(const crisp_frep_mass *lv, int n, int level, double *seconds,
                             double *se);

#ifdef __cplusplus
}
#endif
#endif
