/* Patch groups (issue 12): per face, a quadtree of aligned 2^g x 2^g blocks over its grid of
 * Bézier patches, each block with an object-space box that contains its patches (the union of
 * the scene's patch boxes). Per frame the planner walks it from the top and stops where a whole
 * block is outside the frustum (every patch culled) or can be drawn as one group leaf (every
 * triangle with vertices on its surface within eps on screen: its projected box within eps, or
 * a bound from its patches' control points against the block's corners, see group_leaf_ok). Only
 * the patches of the blocks left open get their own quadtree, SLEFE levels and frustum tests, so a
 * plan's cost follows what is on screen.
 * A face's hierarchy (view-independent) is built the first time a frame walks the face and kept
 * by the planner until the scene changes: faces drawn as splats (skip_faces) never build it
 * (imp49 default: 12,907 of 13,573 faces; the whole scene's took 5.7 G instructions and 157 MB). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "depth_bound.h"
#include "quadtree.h"
#include "rational_bound.h"

/* fmin / fmax without the library call (the values here are finite or +-INFINITY). */
static inline double dmin(double a, double b)
{
    return a < b ? a : b;
}
static inline double dmax(double a, double b)
{
    return a > b ? a : b;
}

typedef struct group {
    uint32_t iu0, iv0, nu, nv; /* patch grid block: columns iu0.., rows iv0.. (clipped) */
    uint32_t g;                /* the block is 2^g x 2^g patches before clipping */
    int32_t child[4];          /* -1: none (outside the grid, or a single patch) */
    int32_t dev;               /* blocks of more than one patch: its block_dev, else -1 */
    double box[6];
    double wlo, whi; /* the least and largest weight of the block's patches */
    int rational;    /* the weights vary over the block (whi > wlo) */
} group;

/* What a frame needs to bound, in O(1), the distance between a block's control points and the
 * bilinear L through its four corners (block_deviation, group_leaf_ok). For a control point of a
 * patch of the block, Euclidean point P (its homogeneous point divided by its weight), at its
 * block parameters (s, t), let d = P - L(s, t), L through the corners' Euclidean points. An
 * affine map A (a row of view_proj) maps them to A P - L_A(s, t) = A_xyz . d (L_A the bilinear
 * through the mapped corners), and A_xyz . d lies in sum_a A_a [lo_a, hi_a] (the coordinate box)
 * and in sum_k (A_xyz . f_k) [flo_k, fhi_k] +- |A_xyz| slack (the box in the principal axes f_k of
 * the deviations): the second is the tight one where the deviations lie along one direction that
 * is not a coordinate axis (the normal of a curved block), the first where they lie along an
 * axis; their intersection holds. */
typedef struct block_dev {
    double lo[3], hi[3];   /* d_a in [lo_a, hi_a] (lo <= 0 <= hi: the corners; with rounding) */
    double f[3][3];        /* orthonormal to 1e-12 */
    double flo[3], fhi[3]; /* d . f_k in [flo_k, fhi_k] (with rounding) */
    double slack;          /* 1e-10 times the largest |d|: f's departure from orthonormal */
    float wit[6][3];     /* the d with the least and largest d . f_k (control points of the block: a
                            lower bound of the frame's range up to rounding, for cost decisions) */
    double sigma[3];     /* the largest crisp__rational_reparam of its patches (0: polynomial) */
    double corner[4][3]; /* its Euclidean corners (block_corners' points; the frame reads these,
                            not the corner patches scattered over the scene's memory) */
    int bounded;         /* 0: a weight is not positive (no O(1) bound) */
} block_dev;

/* One face's hierarchy, in one allocation (at nodes): its blocks depth first from the root (node
 * 0), the block_devs of its blocks of more than one patch (group.dev) in the same order, and this
 * frame's decision per block (node_kind, current where node_frame is the classify call's). */
typedef struct face_hier {
    group *nodes; /* NULL: not built yet */
    block_dev *devs;
    uint32_t *node_frame; /* the classify call that wrote node_kind (0: none) */
    uint8_t *node_kind;   /* NODE_* */
    uint32_t node_count;
} face_hier;

struct crisp__groups {
    const crisp_scene *scene;
    uint64_t key; /* the serial of the scene the hierarchy was built from */
    uint32_t patch_count, face_count;
    face_hier *hier;     /* per face (faces without a grid of patches, face_has_groups: none) */
    uint8_t *face_small; /* per face, this frame: the whole (untrimmed) face within FACE_SMALL_PX */
    uint32_t group_leaves; /* this frame */
    uint32_t *counts;      /* per face: group leaves this frame */
    float *face_px;        /* per face, this frame: screen extent of its box (INFINITY: unknown) */
    double *patch_sigma;   /* per scene patch of a face with a hierarchy: its
                              crisp__rational_sigmas (CRISP__SIGMA_STRIDE values, the last 3 its
                              crisp__rational_reparam; they depend on the weights only, so they
                              are formed once with the hierarchy, not per frame) */
    /* Per scene patch whose weights vary: the crisp__rational_sigmas of its four quarters
     * (build_cell's depth-1 cells), formed the first time a frame asks and kept with the scene.
     * quarter_slot: per patch, its slot or UINT32_MAX; quarter_formed: per slot, a bit per
     * quarter. */
    uint32_t *quarter_slot;
    double *quarter_sigma; /* 4 x CRISP__SIGMA_STRIDE per slot */
    uint8_t *quarter_formed;
    uint64_t generation; /* bumped whenever the hierarchy is rebuilt (a new scene) */
    /* This frame's decisions per block (face_hier.node_kind): what owns its patches. Only the
     * blocks the walk reached are written; node_frame says which are current. */
    uint32_t frame;         /* classify calls so far */
    uint32_t **face_active; /* per face: this frame's active patches (see crisp__groups_classify) */
    uint32_t *face_active_count;
    size_t *face_active_cap;
    /* Per patch: (frame << 32) | the lower-left patch of the group leaf that draws it, written
     * for the patches on the perimeter of each group leaf's block (crisp__groups_owner). */
    uint64_t *patch_owner;
    /* The faces the last classify walked (not skipped), ascending: only theirs of face_small,
     * face_px, counts and face_active_count may differ from a skipped face's (0, INFINITY, 0,
     * 0); the next classify resets those and walks its own list, so that a far view of faces
     * all drawn as splats passes over none of them (issue 12, inst5: imp49 far's 13,573 faces
     * were two passes over five per-face arrays, one of them parallel). */
    uint32_t *walked;
    uint32_t walked_count;
    int oom; /* a walk ran out of memory */
};

/* A face whose box spans at most this many pixels in x and in y on screen: any two of its points,
 * in particular a pixel's point and any point of its trim curves, are at most sqrt(2) times that
 * (< 1 px) apart, so every trim decision on it is within the 1 px guarantee of
 * include/crisp/trim.h (crisp__groups_face_small). */
#define FACE_SMALL_PX 0.7

/* OWN: patches own trees; PASS / FAIL: not reached by the walk, but tried as a cell of its parent
 * this frame (cells_flat_ok), with that result */
enum { NODE_OPEN = 0, NODE_CULLED = 1, NODE_GROUP = 2, NODE_OWN = 3, NODE_PASS = 4, NODE_FAIL = 5 };

/* The corner control points of block n (Bézier patches interpolate their corners): lower left,
 * lower right, upper left, upper right. */
static void block_corners(const crisp_scene *sc, const crisp_scene_face *f, const group *n,
                          const double *dest[4])
{
    uint32_t base = f->first_patch + n->iv0 * f->grid_u + n->iu0;
    const crisp_bezier_patch *p00 = &sc->patches[base].bez,
                             *p10 = &sc->patches[base + n->nu - 1].bez,
                             *p01 = &sc->patches[base + (n->nv - 1) * f->grid_u].bez,
                             *p11 = &sc->patches[base + (n->nv - 1) * f->grid_u + n->nu - 1].bez;
    dest[0] = p00->cpw;
    dest[1] = p10->cpw + 4 * p10->du;
    dest[2] = p01->cpw + 4 * (p01->du + 1) * p01->dv;
    dest[3] = p11->cpw + 4 * ((p11->du + 1) * p11->dv + p11->du);
}

/* The bilinear through corner values c0 (s, t = 0, 0), c1 (1, 0), c2 (0, 1), c3 (1, 1). */
static inline double bilinear(double c0, double c1, double c2, double c3, double s, double t)
{
    return (1 - t) * ((1 - s) * c0 + s * c1) + t * ((1 - s) * c2 + s * c3);
}

/* Calls visit for every control point q of every patch of block n (corners: only each patch's
 * four corner points) with its block parameters (s, t) in [0, 1]^2: the patch's sub-rectangle of
 * the block, its control points uniformly spaced there (a bilinear function restricted to the
 * sub-rectangle and raised to the patch's degrees has exactly its values there as control
 * points). `last` is 1 at each patch's last point. Stops and returns 0 as soon as visit returns
 * 0. The hierarchy's build (block_deviation) and the test hook walk blocks this way. */
typedef int (*point_visit)(void *ctx, const double q[4], double s, double t, int last);
static int block_points(const crisp_scene *sc, const crisp_scene_face *f, const group *n,
                        int corners, point_visit visit, void *ctx)
{
    uint32_t base = f->first_patch + n->iv0 * f->grid_u + n->iu0;
    for (uint32_t jv = 0; jv < n->nv; jv++)
        for (uint32_t iu = 0; iu < n->nu; iu++) {
            const crisp_bezier_patch *b = &sc->patches[base + jv * f->grid_u + iu].bez;
            int sj = corners && b->dv > 0 ? b->dv : 1, si = corners && b->du > 0 ? b->du : 1;
            for (int j = 0; j <= b->dv; j += sj) {
                double t = (jv + (double)j / b->dv) / n->nv;
                for (int i = 0; i <= b->du; i += si) {
                    double s = (iu + (double)i / b->du) / n->nu;
                    if (!visit(ctx, b->cpw + 4 * (j * (b->du + 1) + i), s, t,
                               j == b->dv && i == b->du))
                        return 0;
                }
            }
        }
    return 1;
}

/* Eigenvectors of the symmetric 3 x 3 matrix a (destroyed) by cyclic Jacobi rotations, as the
 * columns of v (Golub & Van Loan, "Matrix Computations", sec. 8.5). Only their directions
 * matter here: callers re-orthonormalise them and check the result. */
static void jacobi_axes(double a[3][3], double v[3][3])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            v[i][j] = i == j;
    for (int sweep = 0; sweep < 12; sweep++) {
        double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
        if (!(off > 1e-30 * diag)) break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (a[p][q] == 0) continue;
                double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
                double t = (theta >= 0 ? 1 : -1) / (fabs(theta) + sqrt(theta * theta + 1));
                double c = 1 / sqrt(t * t + 1), sn = t * c;
                for (int k = 0; k < 3; k++) { /* a <- a P, v <- v P */
                    double akp = a[k][p], akq = a[k][q], vkp = v[k][p], vkq = v[k][q];
                    a[k][p] = c * akp - sn * akq, a[k][q] = sn * akp + c * akq;
                    v[k][p] = c * vkp - sn * vkq, v[k][q] = sn * vkp + c * vkq;
                }
                for (int k = 0; k < 3; k++) { /* a <- P^T a */
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - sn * aqk, a[q][k] = sn * apk + c * aqk;
                }
            }
    }
}

/* Orthonormal f[0..2] from the columns of v (Gram-Schmidt, f2 = f0 x f1); 0 when they are not
 * orthonormal to 1e-12 afterwards (the caller then keeps the coordinate axes). */
static int orthonormal_frame(double v[3][3], double f[3][3])
{
    for (int k = 0; k < 3; k++)
        f[0][k] = v[k][0], f[1][k] = v[k][1];
    double l = sqrt(f[0][0] * f[0][0] + f[0][1] * f[0][1] + f[0][2] * f[0][2]);
    if (!(l > 0)) return 0;
    for (int k = 0; k < 3; k++)
        f[0][k] /= l;
    double dot = f[1][0] * f[0][0] + f[1][1] * f[0][1] + f[1][2] * f[0][2];
    for (int k = 0; k < 3; k++)
        f[1][k] -= dot * f[0][k];
    l = sqrt(f[1][0] * f[1][0] + f[1][1] * f[1][1] + f[1][2] * f[1][2]);
    if (!(l > 0)) return 0;
    for (int k = 0; k < 3; k++)
        f[1][k] /= l;
    f[2][0] = f[0][1] * f[1][2] - f[0][2] * f[1][1];
    f[2][1] = f[0][2] * f[1][0] - f[0][0] * f[1][2];
    f[2][2] = f[0][0] * f[1][1] - f[0][1] * f[1][0];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double e = f[i][0] * f[j][0] + f[i][1] * f[j][1] + f[i][2] * f[j][2] - (i == j);
            if (!(fabs(e) <= 1e-12)) return 0;
        }
    return 1;
}

/* block_deviation's two walks: pass 0 the second moments of d at the patches' corner points
 * (they choose the axes f: any orthonormal axes are sound, these make the box tight), pass 1 over
 * every control point the coordinate box, the ranges along f and the witnesses. */
typedef struct dev_walk {
    double C[4][3], cmag[3]; /* the block's Euclidean corners, their largest |C_a| */
    block_dev *d;
    int pass, axes; /* axes: principal axes and witnesses (else the coordinate box alone) */
    double moments[3][3], least[3], most[3], norm2, rmax;
} dev_walk;

static int dev_visit(void *vctx, const double q[4], double s, double t, int last)
{
    (void)last;
    dev_walk *w = vctx;
    block_dev *d = w->d;
    if (!(q[3] > 0)) return d->bounded = 0;
    double e[3], r = 0, iw = q[3] == 1 ? 1 : 1 / q[3];
    for (int a = 0; a < 3; a++) {
        /* (a relative error of 2^-52 more in P than q[a] / q[3]: within al) */
        double P = q[a] * iw, bl = bilinear(w->C[0][a], w->C[1][a], w->C[2][a], w->C[3][a], s, t);
        /* the rounding of both sides (bl's relative to the corners': |bl| <= cmag): the exact
         * deviation is within al of e[a] */
        double al = 1e-12 * (fabs(P) + w->cmag[a]);
        e[a] = P - bl;
        if (w->pass) d->lo[a] = dmin(d->lo[a], e[a] - al), d->hi[a] = dmax(d->hi[a], e[a] + al);
        r += al;
    }
    if (w->pass == 0) {
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                w->moments[i][j] += e[i] * e[j];
        return 1;
    }
    if (!w->axes) return 1;
    w->norm2 = dmax(w->norm2, e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    w->rmax = dmax(w->rmax, r);
    for (int k = 0; k < 3; k++) {
        /* |f_k| = 1: |f_k . (exact - e)| <= r */
        double v = e[0] * d->f[k][0] + e[1] * d->f[k][1] + e[2] * d->f[k][2];
        d->flo[k] = dmin(d->flo[k], v - r), d->fhi[k] = dmax(d->fhi[k], v + r);
        for (int side = 0; side < 2; side++)
            if (side ? v > w->most[k] : v < w->least[k]) {
                if (side)
                    w->most[k] = v;
                else
                    w->least[k] = v;
                for (int a = 0; a < 3; a++)
                    d->wit[2 * k + side][a] = (float)e[a];
            }
    }
    return 1;
}

/* The block's block_dev (view-independent): a frame bounds the block's deviation in clip space
 * from it alone (deviation_range). */
static void block_deviation(const crisp_scene *sc, const crisp_scene_face *f, const group *n,
                            block_dev *d)
{
    dev_walk w = {.d = d};
    const double *cw[4];
    block_corners(sc, f, n, cw);
    *d = (block_dev){.bounded = 1};
    for (int k = 0; k < 4; k++) {
        if (!(cw[k][3] > 0)) d->bounded = 0;
        for (int a = 0; a < 3; a++) {
            w.C[k][a] = cw[k][a] / cw[k][3];
            w.cmag[a] = dmax(w.cmag[a], fabs(w.C[k][a]));
            d->corner[k][a] = w.C[k][a];
        }
    }
    /* Blocks of more than 64 patches (read by no frame: group_leaf_ok's `small`) keep the
     * coordinate box alone, at the build cost of one cheap walk; their axes are the coordinate
     * axes and they have no witnesses (0 lies in every range). */
    w.axes = n->nu * n->nv <= 64;
    double v[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            d->f[i][j] = v[i][j] = i == j;
    if (!d->bounded || (w.axes && !block_points(sc, f, n, 1, dev_visit, &w))) {
        d->bounded = 0;
        return;
    }
    if (w.axes) {
        jacobi_axes(w.moments, v);
        if (!orthonormal_frame(v, d->f))
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                    d->f[i][j] = i == j;
    }
    w.pass = 1;
    if (!block_points(sc, f, n, 0, dev_visit, &w)) {
        d->bounded = 0;
        return;
    }
    if (!w.axes)
        for (int k = 0; k < 3; k++)
            d->flo[k] = d->lo[k], d->fhi[k] = d->hi[k];
    /* |d - sum_k (d . f_k) f_k| <= 3e-12 |d| for f orthonormal to 1e-12 (0 for the exact axes),
     * and |d| <= |e| + r */
    d->slack = 1e-10 * (sqrt(w.norm2) + w.rmax);
}

/* The witnesses' range [wlo, whi] (with 0) of A_xyz . d per clip coordinate x, y, w (rows 0, 1,
 * 3 of m): within the control points' own range up to rounding (cost decisions only). */
static void witness_range(const block_dev *d, crisp_mat4 m, double wlo[3], double whi[3])
{
    for (int a = 0; a < 3; a++) {
        int r = a == 2 ? 3 : a;
        double A[3] = {m[0][r], m[1][r], m[2][r]};
        wlo[a] = whi[a] = 0;
        for (int k = 0; k < 6; k++) {
            double x = A[0] * d->wit[k][0] + A[1] * d->wit[k][1] + A[2] * d->wit[k][2];
            wlo[a] = dmin(wlo[a], x), whi[a] = dmax(whi[a], x);
        }
    }
}

/* The range [lo, hi] of A_xyz . d over the block's control points, per clip coordinate x, y, w
 * (rows 0, 1, 3 of m), from its block_dev (see there); box_lo, box_hi (NULL: not wanted): from
 * the coordinate box alone; wlo, whi (NULL: not wanted): the witnesses' range (with 0), within
 * the control points' own range up to rounding. */
static void deviation_range(const block_dev *d, crisp_mat4 m, double lo[3], double hi[3],
                            double box_lo[3], double box_hi[3], double wlo[3], double whi[3])
{
    for (int a = 0; a < 3; a++) {
        int r = a == 2 ? 3 : a;
        double A[3] = {m[0][r], m[1][r], m[2][r]}, blo = 0, bhi = 0, flo = 0, fhi = 0;
        for (int c = 0; c < 3; c++) {
            double x = A[c] * d->lo[c], y = A[c] * d->hi[c];
            blo += dmin(x, y), bhi += dmax(x, y);
        }
        for (int k = 0; k < 3; k++) {
            double af = A[0] * d->f[k][0] + A[1] * d->f[k][1] + A[2] * d->f[k][2];
            double x = af * d->flo[k], y = af * d->fhi[k];
            flo += dmin(x, y), fhi += dmax(x, y);
        }
        double s = sqrt(A[0] * A[0] + A[1] * A[1] + A[2] * A[2]) * d->slack;
        /* both hold 0 (the corners); the factor: the rounding of these sums */
        lo[a] = dmax(blo, flo - s) * (1 + 1e-12), hi[a] = dmin(bhi, fhi + s) * (1 + 1e-12);
        if (box_lo) box_lo[a] = blo * (1 + 1e-12), box_hi[a] = bhi * (1 + 1e-12);
    }
    if (wlo) witness_range(d, m, wlo, whi);
}

/* The aligned block (g, bu, bv) of face f's grid: patches [bu 2^g, (bu + 1) 2^g) x
 * [bv 2^g, (bv + 1) 2^g) clipped to the grid. Blocks of one face nest like a quadtree, so two
 * blocks' sides either contain one another or meet in at most a point (the crack-free edge rule
 * relies on it). sigma: the largest crisp__rational_reparam of the block's patches. */
/* Where build_group puts a face's blocks: the face's arrays (sized beforehand by count_blocks). */
typedef struct group_arena {
    group *nodes;
    size_t node_count, node_end; /* the next node; the end of the face's array */
    block_dev *devs;
    size_t dev_count, dev_end;
} group_arena;

/* The blocks build_group makes for block (lv, bu, bv) of a grid_u x grid_v grid: nodes, and
 * devs (the blocks of more than one patch). */
static void count_blocks(uint32_t grid_u, uint32_t grid_v, uint32_t lv, uint32_t bu, uint32_t bv,
                         size_t *nodes, size_t *devs)
{
    uint32_t iu0 = bu << lv, iv0 = bv << lv, size = 1u << lv;
    uint32_t nu = grid_u - iu0 < size ? grid_u - iu0 : size;
    uint32_t nv = grid_v - iv0 < size ? grid_v - iv0 : size;
    ++*nodes;
    if (nu * nv > 1) ++*devs;
    if (lv == 0) return;
    for (int k = 0; k < 4; k++) {
        uint32_t cu = 2 * bu + (k & 1), cv = 2 * bv + (k >> 1);
        if ((cu << (lv - 1)) >= grid_u || (cv << (lv - 1)) >= grid_v) continue;
        count_blocks(grid_u, grid_v, lv - 1, cu, cv, nodes, devs);
    }
}

static crisp_status build_group(group_arena *g, double *patch_sigma, const crisp_scene *sc,
                                const crisp_scene_face *f, uint32_t lv, uint32_t bu, uint32_t bv,
                                int32_t *dest, double sigma[3])
{
    crisp_status st = CRISP_OK;
    if (g->node_count >= g->node_end)
        return crisp_error(CRISP_ERR_INVALID_ARG, "patch groups: a face's blocks miscounted");
    int32_t me = (int32_t)g->node_count++;
    uint32_t iu0 = bu << lv, iv0 = bv << lv, size = 1u << lv;
    group n = {iu0,
               iv0,
               f->grid_u - iu0 < size ? f->grid_u - iu0 : size,
               f->grid_v - iv0 < size ? f->grid_v - iv0 : size,
               lv,
               {-1, -1, -1, -1},
               -1,
               {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY},
               INFINITY,
               -INFINITY,
               0};
    sigma[0] = sigma[1] = sigma[2] = 0;
    /* The block's block_dev is placed now, before its children's, so that devs lie in the same
     * (depth-first) order as the nodes and the frame's walk reads both front to back. */
    if (n.nu * n.nv > 1) {
        if (g->dev_count >= g->dev_end)
            return crisp_error(CRISP_ERR_INVALID_ARG, "patch groups: a face's blocks miscounted");
        n.dev = (int32_t)g->dev_count++;
    }
    if (lv == 0) {
        const double *b = sc->patches[f->first_patch + iv0 * f->grid_u + iu0].box;
        memcpy(n.box, b, sizeof n.box);
        uint32_t pi = f->first_patch + iv0 * f->grid_u + iu0;
        double *ps = patch_sigma + CRISP__SIGMA_STRIDE * (size_t)pi;
        crisp__rational_sigmas(&sc->patches[pi].bez, ps);
        memcpy(sigma, ps + 3, 3 * sizeof *sigma);
    } else {
        for (int k = 0; k < 4; k++) {
            uint32_t cu = 2 * bu + (k & 1), cv = 2 * bv + (k >> 1);
            if ((cu << (lv - 1)) >= f->grid_u || (cv << (lv - 1)) >= f->grid_v) continue;
            int32_t c;
            double cs[3];
            if ((st = build_group(g, patch_sigma, sc, f, lv - 1, cu, cv, &c, cs))) return st;
            for (int a = 0; a < 3; a++)
                sigma[a] = dmax(sigma[a], cs[a]); /* INFINITY stays */
            n.child[k] = c;
            for (int a = 0; a < 3; a++) {
                n.box[a] = dmin(n.box[a], g->nodes[c].box[a]);
                n.box[3 + a] = dmax(n.box[3 + a], g->nodes[c].box[3 + a]);
            }
        }
    }
    if (lv == 0)
        crisp__rational_weight_range(&sc->patches[f->first_patch + iv0 * f->grid_u + iu0].bez,
                                     &n.wlo, &n.whi);
    else
        for (int k = 0; k < 4; k++)
            if (n.child[k] >= 0) {
                n.wlo = dmin(n.wlo, g->nodes[n.child[k]].wlo);
                n.whi = dmax(n.whi, g->nodes[n.child[k]].whi);
            }
    n.rational = n.whi > n.wlo;
    if (n.dev >= 0) {
        block_dev *d = &g->devs[n.dev];
        block_deviation(sc, f, &n, d);
        memcpy(d->sigma, sigma, sizeof d->sigma);
        if (!isfinite(sigma[0]) || !isfinite(sigma[1]) || !isfinite(sigma[2])) d->bounded = 0;
    }
    g->nodes[me] = n;
    *dest = me;
    return CRISP_OK;
}

crisp_status crisp__groups_create(crisp__groups **dest)
{
    crisp__groups *g = calloc(1, sizeof *g);
    if (!g) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating patch groups");
    *dest = g;
    return CRISP_OK;
}

static void free_frame_state(crisp__groups *g)
{
    if (g->face_active)
        for (uint32_t f = 0; f < g->face_count; f++)
            free(g->face_active[f]);
    free(g->face_active);
    free(g->face_active_count);
    free(g->face_active_cap);
    free(g->patch_owner);
    free(g->walked);
    g->patch_owner = NULL;
    g->walked = NULL;
    g->walked_count = 0;
    g->face_active = NULL;
    g->face_active_count = NULL;
    g->face_active_cap = NULL;
}

static void free_hier(crisp__groups *g)
{
    if (g->hier)
        for (uint32_t f = 0; f < g->face_count; f++)
            free(g->hier[f].nodes);
    free(g->hier);
    g->hier = NULL;
}

void crisp__groups_destroy(crisp__groups *g)
{
    if (!g) return;
    free_frame_state(g);
    free_hier(g);
    free(g->face_small);
    free(g->counts);
    free(g->face_px);
    free(g->patch_sigma);
    free(g->quarter_slot);
    free(g->quarter_sigma);
    free(g->quarter_formed);
    free(g);
}

/* The quarter slots of scene sc (after the hierarchy is built for it). */
static crisp_status build_quarter_slots(crisp__groups *g, const crisp_scene *sc)
{
    free(g->quarter_slot);
    free(g->quarter_sigma);
    free(g->quarter_formed);
    g->quarter_sigma = NULL;
    g->quarter_formed = NULL;
    g->quarter_slot = crisp_malloc_array(sc->patch_count ? sc->patch_count : 1, sizeof(uint32_t));
    if (!g->quarter_slot) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
    uint32_t slots = 0;
    for (uint32_t q = 0; q < sc->patch_count; q++) {
        double lo, hi;
        crisp__rational_weight_range(&sc->patches[q].bez, &lo, &hi);
        g->quarter_slot[q] = hi > lo ? slots++ : UINT32_MAX;
    }
    g->quarter_sigma =
        crisp_malloc_array(slots ? slots : 1, 4 * CRISP__SIGMA_STRIDE * sizeof(double));
    g->quarter_formed = calloc(slots ? slots : 1, 1);
    if (!g->quarter_sigma || !g->quarter_formed)
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
    return CRISP_OK;
}

static uint32_t face_levels(const crisp_scene_face *sf)
{
    uint32_t lv = 0;
    while ((1u << lv) < sf->grid_u || (1u << lv) < sf->grid_v)
        lv++;
    return lv;
}

static int face_has_groups(const crisp_scene_face *sf)
{
    return sf->patch_count && sf->grid_u * sf->grid_v == sf->patch_count;
}

/* Builds face fi's hierarchy (face_has_groups) the first time it is asked for; 0 when out of
 * memory. Faces are independent: the walk's workers build the faces they walk. */
static int ensure_face(crisp__groups *g, const crisp_scene *sc, uint32_t fi)
{
    face_hier *h = &g->hier[fi];
    if (h->nodes) return 1;
    const crisp_scene_face *sf = &sc->faces[fi];
    size_t nn = 0, nd = 0;
    count_blocks(sf->grid_u, sf->grid_v, face_levels(sf), 0, 0, &nn, &nd);
    /* sizeof (group) and sizeof (block_dev) are multiples of 8 (they hold doubles) */
    size_t bytes = nn * (sizeof(group) + sizeof(uint32_t) + 1) + nd * sizeof(block_dev);
    char *mem = malloc(bytes);
    if (!mem) return 0;
    group *nodes = (group *)mem;
    block_dev *devs = (block_dev *)(mem + nn * sizeof(group));
    uint32_t *frame = (uint32_t *)(mem + nn * sizeof(group) + nd * sizeof(block_dev));
    group_arena a = {nodes, 0, nn, devs, 0, nd};
    int32_t root;
    double sigma[3];
    if (build_group(&a, g->patch_sigma, sc, sf, face_levels(sf), 0, 0, &root, sigma) ||
        a.node_count != nn || a.dev_count != nd) {
        free(mem);
        return 0;
    }
    memset(frame, 0, nn * sizeof *frame);
    *h = (face_hier){nodes, devs, frame, (uint8_t *)(frame + nn), (uint32_t)nn};
    return 1;
}

static crisp_status ensure_built(crisp__groups *g, const crisp_scene *sc)
{
    /* A scene destroyed and another prepared at the same address must not reuse the hierarchy:
     * scenes have serial numbers. */
    if (g->scene == sc && g->key == sc->serial && g->patch_count == sc->patch_count &&
        g->face_count == sc->face_count)
        return CRISP_OK;
    g->key = sc->serial;
    free_frame_state(g);
    free_hier(g);
    g->scene = NULL;
    g->face_count = 0;
    free(g->face_small);
    free(g->counts);
    free(g->face_px);
    free(g->patch_sigma);
    g->face_px = malloc((sc->face_count ? sc->face_count : 1) * sizeof *g->face_px);
    g->patch_sigma = crisp_malloc_array(sc->patch_count ? sc->patch_count : 1,
                                        CRISP__SIGMA_STRIDE * sizeof *g->patch_sigma);
    size_t nf = sc->face_count ? sc->face_count : 1;
    g->hier = calloc(nf, sizeof *g->hier);
    g->face_small = calloc(nf, 1);
    g->counts = calloc(nf, sizeof *g->counts);
    if (!g->hier || !g->face_small || !g->counts || !g->face_px || !g->patch_sigma)
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
    g->face_count = sc->face_count;
    g->face_active = calloc(nf, sizeof *g->face_active);
    g->face_active_count = calloc(nf, sizeof *g->face_active_count);
    g->face_active_cap = calloc(nf, sizeof *g->face_active_cap);
    g->patch_owner = calloc(sc->patch_count ? sc->patch_count : 1, sizeof *g->patch_owner);
    g->walked = crisp_malloc_array(nf, sizeof *g->walked);
    if (!g->face_active || !g->face_active_count || !g->face_active_cap || !g->patch_owner ||
        !g->walked)
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
    for (uint32_t f = 0; f < sc->face_count; f++) /* (every face as a skipped one's) */
        g->face_px[f] = INFINITY;
    g->walked_count = 0;
    crisp_status st = build_quarter_slots(g, sc);
    if (st) return st;
    g->scene = sc;
    g->generation++;
    g->patch_count = sc->patch_count;
    return CRISP_OK;
}

/* 1: the box is outside one (widened) frustum plane; 2: in front of the eye and within eps
 * pixels on screen; 0: neither (*extent: its screen extent in pixels, INFINITY when it reaches
 * the eye plane). */
static int classify(const double *box, crisp_mat4 m, double gx, double gy, int width, int height,
                    double eps, double *extent)
{
    *extent = INFINITY;
    int out[6] = {1, 1, 1, 1, 1, 1}, front = 1;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    /* Each clip coordinate of a corner is ((m_0r p_0 + m_1r p_1) + m_2r p_2) + m_3r: the
     * products per axis and side, and the first sums per (x, y) side pair, are formed once for
     * the eight corners (the same operations on the same operands, so the same numbers). */
    double t[4][3][2], xy[4][4];
    for (int r = 0; r < 4; r++) {
        for (int a = 0; a < 3; a++)
            t[r][a][0] = m[a][r] * box[a], t[r][a][1] = m[a][r] * box[3 + a];
        for (int k = 0; k < 4; k++)
            xy[r][k] = t[r][0][k & 1] + t[r][1][(k >> 1) & 1];
    }
    for (int k = 0; k < 8; k++) {
        int z2 = (k >> 2) & 1;
        double x = xy[0][k & 3] + t[0][2][z2] + m[3][0];
        double y = xy[1][k & 3] + t[1][2][z2] + m[3][1];
        double z = xy[2][k & 3] + t[2][2][z2] + m[3][2];
        double w = xy[3][k & 3] + t[3][2][z2] + m[3][3];
        out[0] &= x > gx * w;
        out[1] &= x < -gx * w;
        out[2] &= y > gy * w;
        out[3] &= y < -gy * w;
        out[4] &= z < -w;
        out[5] &= z > w;
        if (!(w > 0)) {
            front = 0;
            continue;
        }
        lo[0] = dmin(lo[0], x / w), hi[0] = dmax(hi[0], x / w);
        lo[1] = dmin(lo[1], y / w), hi[1] = dmax(hi[1], y / w);
    }
    if (out[0] | out[1] | out[2] | out[3] | out[4] | out[5]) return 1;
    if (!front) return 0;
    double e = dmax((hi[0] - lo[0]) * 0.5 * width, (hi[1] - lo[1]) * 0.5 * height);
    *extent = e * (1 + 1e-9) + 1e-9;
    return *extent <= eps ? 2 : 0;
}

typedef struct walk_ctx {
    crisp__groups *g;
    const crisp_scene *sc;
    crisp_mat4 m;
    double gx, gy, eps;
    double depth_scale; /* crisp__depth_px_scale: a pixel's world size per unit of clip W */
    int width, height;
    crisp__patch_groups *out;
    uint32_t *counts;      /* group leaves per face */
    const uint32_t *faces; /* the faces walked (walk_faces' items index it) */
} walk_ctx;

/* Depth along the view (issue 13, depth_bound.c): a leaf drawn at level 1 without a tree of its
 * own (a block's group leaf, or a patch or block within eps on screen) must also lie within eps
 * pixels' world size of the surface along the view, as build_cell's leaves do
 * (crisp__depth_tess_level). The depth the rasterizer writes is the triangle point's clip W, a
 * convex combination (clip-space barycentrics) of surface points' W; the surface point's W at the
 * same parameters is another: both lie in the W range of the block's box, so that range is a
 * bound on the depth error; the allowance is eps times the pixel's world size at the box's least
 * W (depth_allow). No allowance (not a perspective view: crisp__depth_px_scale 0): no bound, as
 * in crisp__depth_tess_level. */
static double depth_allow(const walk_ctx *c, double wmin)
{
    return c->eps * c->depth_scale * wmin;
}

static int box_depth_ok(const walk_ctx *c, const double box[6])
{
    double w = c->m[3][3], half = 0;
    for (int a = 0; a < 3; a++) {
        double mid = 0.5 * (box[a] + box[3 + a]), ext = 0.5 * (box[3 + a] - box[a]);
        w += c->m[a][3] * mid;
        half += fabs(c->m[a][3]) * ext;
    }
    half = half * (1 + 1e-12) + 1e-12 * fabs(w);
    double allow = depth_allow(c, w - half);
    return !(allow > 0) || 2 * half <= allow;
}

/* Patches of face fi that get a tree of their own this frame, with their mode. */
static void activate(walk_ctx *c, uint32_t fi, uint32_t p, uint8_t mode)
{
    crisp__groups *g = c->g;
    uint32_t n = g->face_active_count[fi];
    if (crisp_grow((void **)&g->face_active[fi], &g->face_active_cap[fi], (size_t)n + 1,
                   sizeof **g->face_active)) {
        g->oom = 1;
        return;
    }
    g->face_active[fi][n] = p;
    g->face_active_count[fi] = n + 1;
    c->out->mode[p] = mode;
}

static void activate_block(walk_ctx *c, uint32_t fi, const crisp_scene_face *f, const group *n,
                           uint8_t mode)
{
    for (uint32_t iv = n->iv0; iv < n->iv0 + n->nv; iv++)
        for (uint32_t iu = n->iu0; iu < n->iu0 + n->nu; iu++)
            activate(c, fi, f->first_patch + iv * f->grid_u + iu, mode);
}

/* 1 when the block can be one group leaf: every triangle with vertices on its surface lies
 * within eps on screen, whatever its levels. Either its box is within eps, or rational_bound.c's
 * block bound is (crisp__rational_block_px; its header has the argument): with L the bilinear
 * through the block's four corners (the corner control points of its corner patches: Bézier
 * patches interpolate their corners) and D the deviations, per coordinate, of its patches'
 * control points from L at their parameters (the patch's sub-rectangle of the block, uniformly
 * spaced: L restricted to it and raised to the patch's degrees has exactly those values as
 * control points), the surface and the triangles drawn on it (clip-space barycentrics, as the
 * rasterizer interpolates) are each within D plus the reparametrisation term that varying
 * weights cause (sigma's times L's edges and twist; 0 for polynomial patches) plus, for the
 * triangles, a quarter of L's twist, and within the range of D plus those of each other.
 * This needs no B-spline form of the face, only its grid of Bézier patches. The B-spline net
 * bound (crisp_slefe_group_screen's quad_px) was tried first: on wavy bicubic sheets it exceeded
 * the block's own screen extent (tests/render/test_group_leaves.c). The leaf must also stay
 * within CRISP_PLAN_MAX_LEAF_PX (float local parameters on a GPU).
 * In O(1) first (the block's view-independent block_dev): D's range from deviation_range, and
 * per patch the reparametrisation term sigma_s Eu + sigma_t Ev + sigma_st tw, with L's edges and
 * twist scaled to the patch (1 / nu, 1 / nv, 1 / (nu nv) of the block's: the same for every
 * patch), at most the block's largest sigma's times them. So a face far away is decided at its
 * root without reading its patches. Where that is not enough, blocks of at most 64 patches and
 * GROUP_TRY_PX pixels take crisp__rational_block_px (every control point, the sigma's per
 * patch), unless the witnesses (control points of the block) already put that bound beyond eps:
 * both of its forms are at least (dl_x + max |x_L / w_L| dl_w) / w_min in pixels (and y alike),
 * dl = the witnesses' range + 2 x each sigma term alone + a quarter of L's twist. Cost only:
 * larger blocks rarely pass, and on the bundled models the O(1) bound decided every block the
 * control points would have accepted. */
#define GROUP_TRY_PX 64.0

/* The block's Euclidean corners P in clip coordinates x, y, w (C), with their least w and largest
 * |x / w|, |y / w|; 0 when one is not in front of the eye. */
static int clip_points(const double P[4][3], crisp_mat4 m, double C[4][3], double *wmin,
                       double *xmax, double *ymax)
{
    *wmin = INFINITY, *xmax = *ymax = 0;
    for (int i = 0; i < 4; i++) {
        for (int a = 0; a < 3; a++) {
            int r = a == 2 ? 3 : a; /* x, y, w rows of view_proj */
            C[i][a] = m[0][r] * P[i][0] + m[1][r] * P[i][1] + m[2][r] * P[i][2] + m[3][r];
        }
        if (!(C[i][2] > 0)) return 0;
        *wmin = dmin(*wmin, C[i][2]);
        *xmax = dmax(*xmax, fabs(C[i][0] / C[i][2]));
        *ymax = dmax(*ymax, fabs(C[i][1] / C[i][2]));
    }
    return 1;
}

/* clip_points from the homogeneous corners cw. */
static int clip_corners(const double *const cw[4], crisp_mat4 m, double C[4][3], double *wmin,
                        double *xmax, double *ymax)
{
    double P[4][3];
    for (int i = 0; i < 4; i++) {
        const double *q = cw[i];
        if (!(q[3] > 0)) return 0;
        P[i][0] = q[0] / q[3], P[i][1] = q[1] / q[3], P[i][2] = q[2] / q[3];
    }
    return clip_points((const double(*)[3])P, m, C, wmin, xmax, ymax);
}

static int group_leaf_ok(const walk_ctx *c, const crisp_scene_face *f, const face_hier *h,
                         const group *n, double extent)
{
    int box_depth = box_depth_ok(c, n->box);
    if (extent <= c->eps && box_depth) return 1;
    if (!isfinite(extent) || extent > CRISP_PLAN_MAX_LEAF_PX) return 0;
    const block_dev *dev = &h->devs[n->dev];
    double(*m)[4] = (double(*)[4])c->m;
    double C[4][3], wmin, xmax, ymax;
    if (!dev->bounded || !clip_points((const double(*)[3])dev->corner, m, C, &wmin, &xmax, &ymax))
        return 0;
    int small = n->nu * n->nv <= 64 && extent <= GROUP_TRY_PX;
    double lo[3], hi[3], wlo[3], whi[3], r[3], rlow[3];
    deviation_range(dev, m, lo, hi, NULL, NULL, NULL, NULL);
    for (int a = 0; a < 3; a++) {
        double eu = dmax(fabs(C[1][a] - C[0][a]), fabs(C[3][a] - C[2][a])) / n->nu;
        double ev = dmax(fabs(C[2][a] - C[0][a]), fabs(C[3][a] - C[1][a])) / n->nv;
        double tw = fabs(C[0][a] - C[1][a] - C[2][a] + C[3][a]) / ((double)n->nu * n->nv);
        double su = dev->sigma[0] * eu, sv = dev->sigma[1] * ev, st = dev->sigma[2] * tw;
        r[a] = (su + sv + st) * (1 + 1e-12);
        rlow[a] = dmax(su, dmax(sv, st));
    }
    if (!box_depth) {
        /* The depth error along the view: |T_w - S_w| <= hi_w - lo_w + 2 r_w + tw_w / 4 (the
         * direct form of rational_bound.c's finish, its W coordinate), against the allowance at
         * a least W of the surface (L's least plus the least deviation, or the box's). */
        double tw = 0.25 * fabs(C[0][2] - C[1][2] - C[2][2] + C[3][2]);
        double dw = (hi[2] - lo[2] + 2 * r[2] + tw) * (1 + 1e-9);
        double bw = c->m[3][3];
        for (int a = 0; a < 3; a++)
            bw += c->m[a][3] < 0 ? c->m[a][3] * n->box[3 + a] : c->m[a][3] * n->box[a];
        double allow = depth_allow(c, dmax(wmin + lo[2] - r[2], bw) * (1 - 1e-9));
        if (!(dw <= allow)) return 0;
    }
    if (extent <= c->eps) return 1;
    if (crisp__rational_block_finish_px((const double(*)[3])C, lo, hi, r, c->width, c->height) <=
        c->eps)
        return 1;
    if (!small) return 0;
    witness_range(dev, m, wlo, whi);
    double dl[3];
    for (int a = 0; a < 3; a++)
        dl[a] = whi[a] - wlo[a] + 2 * rlow[a] + 0.25 * fabs(C[0][a] - C[1][a] - C[2][a] + C[3][a]);
    for (int a = 0; a < 2; a++)
        if ((dl[a] + (a ? ymax : xmax) * dl[2]) * 0.5 * (a ? c->height : c->width) > c->eps * wmin)
            return 0;
    uint32_t base = f->first_patch + n->iv0 * f->grid_u + n->iu0;
    return crisp__rational_block_px_sigmas(
               &c->sc->patches[base], c->g->patch_sigma + CRISP__SIGMA_STRIDE * (size_t)base,
               f->grid_u, n->nu, n->nv, m, c->width, c->height, c->eps) <= c->eps;
}

/* 1 when the single patch of node n (extent: its box's screen extent) can be one leaf at level 1
 * without a tree: every triangle with vertices on it lies within eps of it on screen
 * (rational_bound.c's bound from its control points, as group_leaf_ok's for a block of one
 * patch; build_cell's flat_bound is the same bound) and along the view (box_depth_ok, or the
 * same bound's W coordinate). Cost only: a patch this refuses gets its tree (build_cell), which
 * decides as before (depth_bound.c's crisp__depth_tess_level is not called here: where the cheap
 * bound refuses, build_cell calls it, and calling it here too doubled it at close-ups). At the
 * default view of bench_screen's gen50 (wavy sheets facing the eye) most visible patches take
 * level 1 this way instead of a quadtree, a SLEFE level and the curvature bound each. */
static int patch_flat_ok(const walk_ctx *c, const crisp_scene_face *f, const group *n,
                         double extent)
{
    if (!isfinite(extent) || extent > CRISP_PLAN_MAX_LEAF_PX) return 0;
    uint32_t pi = f->first_patch + n->iv0 * f->grid_u + n->iu0;
    const crisp_bezier_patch *p = &c->sc->patches[pi].bez;
    if (p->du < 1 || p->dv < 1) return 0;
    double(*m)[4] = (double(*)[4])c->m;
    const double *cw[4];
    block_corners(c->sc, f, n, cw);
    double C[4][3], wmin, xmax, ymax, lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}, sigma[3], r[3];
    if (!clip_corners(cw, m, C, &wmin, &xmax, &ymax)) return 0;
    /* Every control point's clip deviation from the bilinear through C at its grid parameters
     * (i / du, j / dv): L along a row of constant t is linear in s, between its ends e0, e1.
     * The middle row first (the ranges do not depend on the order; see the early refusal). */
    double mag = 0, pmag = 1;
    for (int k = 0; k <= p->dv; k++) {
        int jj = k == 0 ? p->dv / 2 : k <= p->dv / 2 ? k - 1 : k;
        double t = (double)jj / p->dv, e0[3], e1[3];
        for (int a = 0; a < 3; a++) {
            e0[a] = (1 - t) * C[0][a] + t * C[2][a], e1[a] = (1 - t) * C[1][a] + t * C[3][a];
            mag = dmax(mag, dmax(fabs(e0[a]), fabs(e1[a])));
        }
        for (int ii = 0; ii <= p->du; ii++) {
            const double *q = p->cpw + 4 * (jj * (p->du + 1) + ii);
            if (!(q[3] > 0)) return 0;
            double s = (double)ii / p->du, iw = q[3] == 1 ? 1 : 1 / q[3];
            double P[3] = {q[0] * iw, q[1] * iw, q[2] * iw};
            pmag = dmax(pmag, dmax(fabs(P[0]), dmax(fabs(P[1]), fabs(P[2]))));
            for (int a = 0; a < 3; a++) {
                int row = a == 2 ? 3 : a;
                double x = m[0][row] * P[0] + m[1][row] * P[1] + m[2][row] * P[2] + m[3][row];
                double e = x - ((1 - s) * e0[a] + s * e1[a]);
                lo[a] = dmin(lo[a], e), hi[a] = dmax(hi[a], e);
                mag = dmax(mag, fabs(x));
            }
        }
        /* Refused early where the middle row already puts the bound beyond eps: both forms in
         * finish are at least max(-lo, hi) / w_min in pixels per coordinate (lo <= 0 <= hi only
         * widen with more points, the allowance and r; the factor: their roundings), so the
         * decision is the full scan's. (Once: a test after every row cost the patches that pass
         * more than it saved, gen50 default +0.8%.) */
        if (k == 0 && p->dv > 0 &&
            dmax(dmax(-lo[0], hi[0]) * c->width, dmax(-lo[1], hi[1]) * c->height) * 0.5 >
                c->eps * wmin * (1 + 1e-6))
            return 0;
    }
    /* the rounding of both sides: each within 1e-12 of the largest magnitude involved (the
     * terms of the map's rows, the mapped points, the corners) */
    for (int a = 0; a < 3; a++) {
        int row = a == 2 ? 3 : a;
        double terms =
            (fabs(m[0][row]) + fabs(m[1][row]) + fabs(m[2][row])) * pmag + fabs(m[3][row]);
        lo[a] -= 1e-12 * (terms + mag), hi[a] += 1e-12 * (terms + mag);
    }
    memcpy(sigma, c->g->patch_sigma + CRISP__SIGMA_STRIDE * (size_t)pi + 3,
           sizeof sigma); /* crisp__rational_reparam(p) */
    for (int a = 0; a < 3; a++) {
        double eu = dmax(fabs(C[1][a] - C[0][a]), fabs(C[3][a] - C[2][a]));
        double ev = dmax(fabs(C[2][a] - C[0][a]), fabs(C[3][a] - C[1][a]));
        double tw = fabs(C[0][a] - C[1][a] - C[2][a] + C[3][a]);
        r[a] = (sigma[0] * eu + sigma[1] * ev + sigma[2] * tw) * (1 + 1e-12);
    }
    if (!(crisp__rational_block_finish_px((const double(*)[3])C, lo, hi, r, c->width, c->height) <=
          c->eps))
        return 0;
    /* (finish within eps puts every control point in front of the eye: its W is at least
     * wmin + lo_w > E_w + lo_w >= 0) */
    if (box_depth_ok(c, n->box)) return 1;
    double tw = 0.25 * fabs(C[0][2] - C[1][2] - C[2][2] + C[3][2]);
    double dw = (hi[2] - lo[2] + 2 * r[2] + tw) * (1 + 1e-9);
    return dw <= depth_allow(c, (wmin + lo[2] - r[2]) * (1 - 1e-9));
}

/* The edge rule asks who draws a patch only for patches next to another leaf's, so on the
 * perimeter of the block whose group leaf draws them (a patch inside the block has all four
 * neighbours in it). Those are stamped with this frame and the leaf's lower-left patch: the
 * lookup is then one read of one array (in patch order, like the edge rule's walk) instead of a
 * descent from the face's root through the hierarchy's nodes scattered in memory. */
static void mark_perimeter(crisp__groups *g, const crisp_scene_face *f, const group *n,
                           uint32_t origin)
{
    uint64_t e = (uint64_t)g->frame << 32 | origin;
    uint64_t *row0 = g->patch_owner + origin, *row1 = row0 + (size_t)(n->nv - 1) * f->grid_u;
    for (uint32_t i = 0; i < n->nu; i++)
        row0[i] = row1[i] = e;
    for (uint32_t j = 1; j + 1 < n->nv; j++)
        row0[(size_t)j * f->grid_u] = row0[(size_t)j * f->grid_u + n->nu - 1] = e;
}

/* 1 when block n (extent: its box's screen extent) can be one group leaf at level 2 whose four
 * cells are its four children (blocks or single patches): each child passes as a leaf at level 1
 * (group_leaf_ok, or patch_flat_ok for a single patch: every triangle with vertices on the child
 * within eps on screen and along the view; given the block's extent, which is at least the
 * child's: the extent only ever lets a bound accept more). That bound holds for the leaf's mesh
 * when every triangle of it lies in one cell of the 2 x 2 grid: so it does when every edge level
 * is a multiple of 2 (crisp_tess_mesh_generate's zipper then never takes an outer segment across
 * a cell's side; tests/render/test_group_leaves.c's test_tau_cells checks it), which the edge
 * rule makes sure of (quadtree.c split_high_levels plans the block's patches one by one
 * otherwise). Only whole blocks (2^g x 2^g patches: the cells are then the children). So a
 * bench_screen gen100 block of 2 x 2 patches, one gen50 patch, is one leaf at level 2 as that
 * patch is at the close-up: the hierarchy stops at the same screen-sized leaves whatever the knot
 * count, and at the default view a leaf of 2 x 2 cells stands for four leaves at level 1 (the
 * same triangles). Each child's result is kept for the walk (NODE_PASS / NODE_FAIL), which reaches
 * it when the block is refused: a child is tried once per frame. */
static int child_ok(const walk_ctx *c, const crisp_scene_face *f, const face_hier *h, uint32_t at,
                    double extent)
{
    uint32_t frame = c->g->frame;
    if (h->node_frame[at] == frame) return h->node_kind[at] == NODE_PASS;
    const group *n = &h->nodes[at];
    int ok =
        n->nu * n->nv == 1 ? patch_flat_ok(c, f, n, extent) : group_leaf_ok(c, f, h, n, extent);
    h->node_frame[at] = frame;
    h->node_kind[at] = ok ? NODE_PASS : NODE_FAIL;
    return ok;
}

/* Degrees up to this get quarter cells (patch_quarters_ok; the grid lives on the stack). */
#define QUARTER_MAX_DEGREE 7

/* De Casteljau at 1/2 of the n + 1 values v[0..n] (destroyed) into out[0], out[st], ..
 * out[2 n st]: the two halves' control values (they share out[n st]). */
static inline void halve(double *v, int n, double *out, int st)
{
    for (int lv = 0; lv <= n; lv++) {
        out[lv * st] = v[0], out[(2 * n - lv) * st] = v[n - lv];
        for (int i = 0; i < n - lv; i++)
            v[i] = 0.5 * (v[i] + v[i + 1]);
    }
}

/* The four quarters of a patch ([0, 1/2]^2 .. of its parameters) as cells of a group leaf: its
 * control points in clip coordinates x, y, w (Euclidean points mapped by the clip rows: a patch
 * whose weights do not vary is a polynomial one there), split at s = 1/2 and t = 1/2 (de Casteljau
 * is affine-invariant: the split of the mapped points is the map of the split). 1 when every
 * quarter passes: every triangle with vertices on it lies within eps on screen
 * (rational_bound.c's finish for a polynomial piece: the deviations from the bilinear through
 * its corners, r = 0) and along the view (|T_w - S_w| is at most the quarter's control points' W
 * range, both being convex combinations of surface points in its hull, and at most hi_w - lo_w +
 * tw_w / 4, the finish's direct form; against the allowance at the least W of the hull). The
 * rounding of the map and the splits is covered by err (1e-12 of the largest magnitudes
 * involved, per coordinate). du, dv: the patch's degrees. */
static inline int quarters_ok(const walk_ctx *c, const crisp_bezier_patch *p, int du, int dv)
{
    enum { N = 2 * QUARTER_MAX_DEGREE + 1 };
    double G[3][N * N], v[N], err[3], mag[3] = {0, 0, 0}, pmag = 1;
    double(*m)[4] = (double(*)[4])c->m;
    /* the mapped control points at G[a][(2 j) * N + i] */
    for (int j = 0; j <= dv; j++)
        for (int i = 0; i <= du; i++) {
            const double *q = p->cpw + 4 * (j * (du + 1) + i);
            if (!(q[3] > 0)) return 0;
            double iw = q[3] == 1 ? 1 : 1 / q[3];
            double P[3] = {q[0] * iw, q[1] * iw, q[2] * iw};
            pmag = dmax(pmag, dmax(fabs(P[0]), dmax(fabs(P[1]), fabs(P[2]))));
            for (int a = 0; a < 3; a++) {
                int row = a == 2 ? 3 : a;
                double x = m[0][row] * P[0] + m[1][row] * P[1] + m[2][row] * P[2] + m[3][row];
                G[a][(2 * j) * N + i] = x;
                mag[a] = dmax(mag[a], fabs(x));
            }
        }
    for (int a = 0; a < 3; a++) {
        int row = a == 2 ? 3 : a;
        err[a] = 2e-12 * ((fabs(m[0][row]) + fabs(m[1][row]) + fabs(m[2][row])) * pmag +
                          fabs(m[3][row]) + mag[a]);
        for (int j = 0; j <= dv; j++) { /* rows: du + 1 -> 2 du + 1 points */
            for (int i = 0; i <= du; i++)
                v[i] = G[a][(2 * j) * N + i];
            halve(v, du, &G[a][2 * j * N], 1);
        }
        for (int i = 0; i <= 2 * du; i++) { /* columns: dv + 1 -> 2 dv + 1 points */
            for (int j = 0; j <= dv; j++)
                v[j] = G[a][(2 * j) * N + i];
            halve(v, dv, &G[a][i], N);
        }
    }
    for (int k = 0; k < 4; k++) {
        int i0 = (k & 1) * du, j0 = (k >> 1) * dv;
        double C[4][3], lo[3], hi[3], r[3] = {0, 0, 0}, wlo = INFINITY, whi = -INFINITY;
        for (int a = 0; a < 3; a++) {
            C[0][a] = G[a][(j0)*N + i0], C[1][a] = G[a][(j0)*N + i0 + du];
            C[2][a] = G[a][(j0 + dv) * N + i0], C[3][a] = G[a][(j0 + dv) * N + i0 + du];
            double l = 0, h = 0;
            for (int j = 0; j <= dv; j++) {
                double t = (double)j / dv;
                double e0 = (1 - t) * C[0][a] + t * C[2][a], e1 = (1 - t) * C[1][a] + t * C[3][a];
                for (int i = 0; i <= du; i++) {
                    double s = (double)i / du, x = G[a][(j0 + j) * N + i0 + i];
                    double e = x - ((1 - s) * e0 + s * e1);
                    l = dmin(l, e), h = dmax(h, e);
                    if (a == 2) wlo = dmin(wlo, x), whi = dmax(whi, x);
                }
            }
            lo[a] = l - err[a], hi[a] = h + err[a];
        }
        if (!(crisp__rational_block_finish_px((const double(*)[3])C, lo, hi, r, c->width,
                                              c->height) <= c->eps))
            return 0;
        double tw = 0.25 * fabs(C[0][2] - C[1][2] - C[2][2] + C[3][2]);
        double dw = dmin(whi - wlo + 2 * err[2], hi[2] - lo[2] + tw) * (1 + 1e-9);
        double allow = depth_allow(c, (wlo - err[2]) * (1 - 1e-9));
        if (allow > 0 && !(dw <= allow)) return 0;
    }
    return 1;
}

/* quarters_ok for the single patch of node n. Patches whose weights vary are not tried (a
 * quarter's reparametrisation term would need its own weights' bound; cost only: they are
 * planned as before). */
static int patch_quarters_ok(const walk_ctx *c, const crisp_scene_face *f, const group *n)
{
    if (n->rational) return 0;
    const crisp_bezier_patch *p = &c->sc->patches[f->first_patch + n->iv0 * f->grid_u + n->iu0].bez;
    if (p->du == 3 && p->dv == 3) return quarters_ok(c, p, 3, 3); /* (not unrolled at -O2) */
    if (p->du < 1 || p->dv < 1 || p->du > QUARTER_MAX_DEGREE || p->dv > QUARTER_MAX_DEGREE)
        return 0;
    return quarters_ok(c, p, p->du, p->dv);
}

int crisp__groups_test_quarters(const crisp_bezier_patch *p, crisp_mat4 view_proj, int width,
                                int height, double eps)
{
    double wlo, whi;
    crisp__rational_weight_range(p, &wlo, &whi);
    if (whi > wlo || p->du < 1 || p->dv < 1 || p->du > QUARTER_MAX_DEGREE ||
        p->dv > QUARTER_MAX_DEGREE)
        return 0;
    walk_ctx c = {.eps = eps,
                  .width = width,
                  .height = height,
                  .depth_scale = crisp__depth_px_scale(view_proj, width, height)};
    crisp_mat4_copy(view_proj, c.m);
    return quarters_ok(&c, p, p->du, p->dv);
}

/* 1 when block n (whole: 2^g x 2^g patches, g >= 1) can be one group leaf at level 2^j (j = 1,
 * 2) whose cells are its descendants j levels down, each passing as a leaf at level 1 (child_ok),
 * or, one level below a single patch, that patch's quarters (patch_quarters_ok). Every triangle of
 * the leaf's mesh lies in one cell of the 2^j x 2^j grid when every edge level is a multiple of
 * 2^j (test_group_leaves' test_tau_cells; quadtree.c split_high_levels plans the block's patches
 * one by one otherwise), so each cell's bound holds for the triangles in it. */
static int cells_ok(const walk_ctx *c, const crisp_scene_face *f, const face_hier *h, uint32_t at,
                    int j, double extent)
{
    if (j == 0) return child_ok(c, f, h, at, extent);
    const group *n = &h->nodes[at];
    if (n->nu * n->nv == 1) return j == 1 && patch_quarters_ok(c, f, n);
    for (int k = 0; k < 4; k++)
        if (n->child[k] < 0 || !cells_ok(c, f, h, (uint32_t)n->child[k], j - 1, extent)) return 0;
    return 1;
}

/* The level-2^j try of block n (j = 1, 2; see cells_ok). Level 4 only for a 2 x 2 block of
 * patches whose weights do not vary (its cells the patches' quarters). Blocks of blocks at level
 * 4 (cells their grandchildren) were tried: gen100 / gen50 at the default view 12,500 -> 3,860
 * leaves each for 0.4-0.8% more triangles, but impeller.igs at far10 5-12% more triangles (a
 * child refused at level 1 as a block still gets level 1 patch by patch in its own trees) with or
 * without a rule taking level 4 only where no child passes at level 1; not kept. */
static int cells_flat_ok(const walk_ctx *c, const crisp_scene_face *f, const face_hier *h,
                         const group *n, int j, double extent)
{
    if (n->g < 1 || n->nu != 1u << n->g || n->nv != 1u << n->g) return 0;
    if (!isfinite(extent) || extent > CRISP_PLAN_MAX_LEAF_PX) return 0;
    if (j == 2 && (n->g != 1 || n->rational)) return 0;
    for (int k = 0; k < 4; k++)
        if (n->child[k] < 0 || !cells_ok(c, f, h, (uint32_t)n->child[k], j - 1, extent)) return 0;
    return 1;
}

static void walk_faces(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    walk_ctx *c = vctx;
    crisp__groups *g = c->g;
    for (size_t i = begin; i < end; i++) {
        size_t fi = c->faces[i]; /* (not skipped; its values reset by crisp__groups_classify) */
        const crisp_scene_face *f = &c->sc->faces[fi];
        if (!face_has_groups(f)) {
            for (uint32_t p = 0; p < f->patch_count; p++)
                activate(c, (uint32_t)fi, f->first_patch + p, CRISP__PATCH_OPEN);
            continue;
        }
        if (!ensure_face(g, c->sc, (uint32_t)fi)) {
            g->oom = 1;
            continue;
        }
        face_hier *h = &g->hier[fi];
        const int32_t root = 0;
        int32_t stack[4 * 64];
        int top = 0;
        stack[top++] = root;
        while (top > 0) {
            int32_t at = stack[--top];
            const group *n = &h->nodes[at];
            double extent;
            int j;
            int k = classify(n->box, c->m, c->gx, c->gy, c->width, c->height, c->eps, &extent);
            /* tried as a cell of its parent this frame: that result (cells_flat_ok) */
            int tried = h->node_frame[at] == g->frame ? h->node_kind[at] : -1;
            if (at == root && k != 1 && extent <= FACE_SMALL_PX) g->face_small[fi] = 1;
            if (at == root) g->face_px[fi] = (float)extent;
            h->node_frame[at] = g->frame;
            h->node_kind[at] = NODE_OWN;
            if (k == 1) {
                h->node_kind[at] = NODE_CULLED; /* its patches: no tree (crisp__groups_owner) */
            } else if (n->nu * n->nv == 1) {
                /* (Within eps on screen but not along the view: its tree's leaf takes the depth
                 * bound's level, build_cell.) */
                int small =
                    (k == 2 && box_depth_ok(c, n->box)) ||
                    (c->out->group_g && (tried == NODE_PASS ||
                                         (tried != NODE_FAIL && patch_flat_ok(c, f, n, extent))));
                activate(c, (uint32_t)fi, f->first_patch + n->iv0 * f->grid_u + n->iu0,
                         small ? CRISP__PATCH_SMALL : CRISP__PATCH_OPEN);
            } else if (c->out->group_g &&
                       (tried == NODE_PASS ||
                        (tried != NODE_FAIL && group_leaf_ok(c, f, h, n, extent)))) {
                uint32_t origin = f->first_patch + n->iv0 * f->grid_u + n->iu0;
                h->node_kind[at] = NODE_GROUP;
                mark_perimeter(g, f, n, origin);
                activate(c, (uint32_t)fi, origin, CRISP__PATCH_GROUP);
                c->out->group_g[origin] = (uint8_t)n->g;
                c->counts[fi]++;
            } else if (k == 2 && box_depth_ok(c, n->box)) {
                activate_block(c, (uint32_t)fi, f, n, CRISP__PATCH_SMALL);
            } else if (c->out->group_g && (j = cells_flat_ok(c, f, h, n, 1, extent)   ? 1
                                               : cells_flat_ok(c, f, h, n, 2, extent) ? 2
                                                                                      : 0)) {
                uint32_t origin = f->first_patch + n->iv0 * f->grid_u + n->iu0;
                h->node_kind[at] = NODE_GROUP;
                mark_perimeter(g, f, n, origin);
                activate(c, (uint32_t)fi, origin, CRISP__PATCH_GROUP);
                c->out->group_g[origin] = (uint8_t)(n->g | (unsigned)j << 4); /* tau 2^j */
                c->counts[fi]++;
            } else {
                h->node_kind[at] = NODE_OPEN;
                for (int q = 3; q >= 0; q--)
                    if (n->child[q] >= 0) stack[top++] = n->child[q];
            }
        }
    }
}

static int u32_cmp(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

crisp_status crisp__groups_classify(crisp__groups *g, const crisp_scene *sc, crisp_mat4 view_proj,
                                    int width, int height, double gx, double gy, double eps,
                                    crisp_pool *pool, crisp__patch_groups *out)
{
    crisp_status st = ensure_built(g, sc);
    if (st) return st;
    uint32_t *counts = g->counts;
    if (++g->frame == 0) { /* stamps of 0 never match; after 2^32 walks clear them once */
        for (uint32_t f = 0; f < g->face_count; f++)
            if (g->hier[f].nodes)
                memset(g->hier[f].node_frame, 0,
                       g->hier[f].node_count * sizeof *g->hier[f].node_frame);
        memset(g->patch_owner, 0, (g->patch_count ? g->patch_count : 1) * sizeof *g->patch_owner);
        g->frame = 1;
    }
    g->oom = 0;
    /* The last walk's faces back to a skipped face's values, then this walk's faces listed (the
     * faces not skipped, ascending). */
    for (uint32_t i = 0; i < g->walked_count; i++) {
        uint32_t f = g->walked[i];
        g->face_small[f] = 0;
        g->face_px[f] = INFINITY;
        g->face_active_count[f] = 0;
        counts[f] = 0;
    }
    uint32_t n = 0;
    const uint8_t *skip = out->skip_faces;
    for (uint32_t f = 0; f < sc->face_count;) {
        uint64_t word;
        if (skip && f + 8 <= sc->face_count &&
            (memcpy(&word, skip + f, sizeof word), word == 0x0101010101010101ull)) {
            f += 8; /* (eight faces drawn as splats; skip's values are 0 or 1) */
            continue;
        }
        if (!skip || !skip[f]) g->walked[n++] = f;
        f++;
    }
    g->walked_count = n;
    walk_ctx c = {.g = g,
                  .sc = sc,
                  .gx = gx,
                  .gy = gy,
                  .eps = eps,
                  .width = width,
                  .height = height,
                  .out = out,
                  .counts = counts,
                  .faces = g->walked,
                  .depth_scale = crisp__depth_px_scale(view_proj, width, height)};
    crisp_mat4_copy(view_proj, c.m);
    /* Grain: 4 faces, or a 64th of them (issue 12, inst2: imp49 far's 13,573 faces, all skipped
     * as splats, in items of 4 cost 0.35 ms on 2 threads, the workers trading the item counter's
     * and the per-face arrays' cache lines) */
    size_t grain = n / 64 > 4 ? n / 64 : 4;
    if (n) crisp_pool_parallel_for(pool, n, grain, walk_faces, &c);
    if (g->oom) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
    g->group_leaves = 0;
    size_t total = 0;
    for (uint32_t i = 0; i < n; i++) {
        g->group_leaves += counts[g->walked[i]];
        total += g->face_active_count[g->walked[i]];
    }
    if ((st = crisp_grow((void **)out->active, out->active_cap, total ? total : 1,
                         sizeof **out->active)))
        return st;
    size_t at = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t f = g->walked[i], m = g->face_active_count[f];
        if (!m) continue;
        memcpy(*out->active + at, g->face_active[f], m * sizeof **out->active);
        qsort(*out->active + at, m, sizeof **out->active, u32_cmp);
        at += m;
    }
    *out->active_count = at;
    return CRISP_OK;
}

uint32_t crisp__groups_owner(const crisp__groups *g, const crisp_scene *sc, uint32_t q)
{
    uint64_t e = g->patch_owner[q];
    if ((uint32_t)(e >> 32) == g->frame) return (uint32_t)e;
    /* Not on a group leaf's perimeter this frame: culled, or inside a block (the descent). */
    const crisp_scene_patch *sp = &sc->patches[q];
    const crisp_scene_face *f = &sc->faces[sp->face];
    const face_hier *h = &g->hier[sp->face];
    uint32_t at = h->nodes ? 0 : UINT32_MAX; /* not built: never walked */
    while (at != UINT32_MAX && h->node_frame[at] == g->frame) {
        const group *n = &h->nodes[at];
        switch (h->node_kind[at]) {
        case NODE_GROUP:
            return f->first_patch + n->iv0 * f->grid_u + n->iu0;
        case NODE_OPEN: {
            uint32_t h = n->g - 1;
            int k = (int)((sp->iu >> h) & 1) | (int)(((sp->iv >> h) & 1) << 1);
            at = n->child[k] >= 0 ? (uint32_t)n->child[k] : UINT32_MAX;
            break;
        }
        default:
            return q;
        }
    }
    return q;
}

double crisp__groups_face_px(const crisp__groups *g, uint32_t face)
{
    return g && g->face_px && face < g->face_count ? g->face_px[face] : INFINITY;
}

int crisp__groups_face_small(const crisp__groups *g, uint32_t face)
{
    return g && g->face_small && face < g->face_count && g->face_small[face];
}

const double *crisp__groups_patch_sigmas(const crisp__groups *g, const crisp_scene *sc,
                                         uint32_t patch)
{
    if (!g || g->scene != sc || g->key != sc->serial || patch >= g->patch_count) return NULL;
    if (!g->hier[sc->patches[patch].face].nodes) return NULL; /* not formed */
    return g->patch_sigma + CRISP__SIGMA_STRIDE * (size_t)patch;
}

const double *crisp__groups_quarter_sigmas(crisp__groups *g, const crisp_scene *sc, uint32_t patch,
                                           int quarter, const crisp_bezier_patch *q)
{
    if (!g || g->scene != sc || g->key != sc->serial || patch >= g->patch_count) return NULL;
    uint32_t slot = g->quarter_slot[patch];
    if (slot == UINT32_MAX || quarter < 0 || quarter > 3) return NULL;
    double *s = g->quarter_sigma + CRISP__SIGMA_STRIDE * (4 * (size_t)slot + (size_t)quarter);
    if (!(g->quarter_formed[slot] >> quarter & 1)) {
        crisp__rational_sigmas(q, s);
        g->quarter_formed[slot] |= (uint8_t)(1u << quarter);
    }
    return s;
}

uint64_t crisp__groups_generation(const crisp__groups *g)
{
    return g ? g->generation : 0;
}

/* crisp__groups_test_deviations's walk: the range of A_xyz . d over the control points, in clip
 * coordinates, with no rounding allowance. */
typedef struct exact_walk {
    double C[4][3];
    const double (*m)[4];
    double lo[3], hi[3];
} exact_walk;

static int exact_visit(void *vctx, const double q[4], double s, double t, int last)
{
    (void)last;
    exact_walk *w = vctx;
    double P[3] = {q[0] / q[3], q[1] / q[3], q[2] / q[3]};
    for (int a = 0; a < 3; a++) {
        int r = a == 2 ? 3 : a;
        double x = w->m[0][r] * P[0] + w->m[1][r] * P[1] + w->m[2][r] * P[2] + w->m[3][r];
        double e = x - bilinear(w->C[0][a], w->C[1][a], w->C[2][a], w->C[3][a], s, t);
        w->lo[a] = dmin(w->lo[a], e), w->hi[a] = dmax(w->hi[a], e);
    }
    return 1;
}

crisp_status crisp__groups_test_deviations(crisp__groups *g, const crisp_scene *sc, crisp_mat4 m,
                                           void (*visit)(void *ctx,
                                                         const crisp__groups_dev_sample *s),
                                           void *ctx)
{
    crisp_status st = ensure_built(g, sc);
    if (st) return st;
    for (uint32_t fi = 0; fi < sc->face_count; fi++) {
        const crisp_scene_face *f = &sc->faces[fi];
        if (!face_has_groups(f)) continue;
        if (!ensure_face(g, sc, fi))
            return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for patch groups");
        const face_hier *h = &g->hier[fi];
        int32_t stack[4 * 64];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const group *n = &h->nodes[stack[--top]];
            for (int q = 0; q < 4; q++)
                if (n->child[q] >= 0) stack[top++] = n->child[q];
            if (n->dev < 0 || !h->devs[n->dev].bounded) continue;
            /* the corners mapped without the front-of-eye check (any affine map) */
            const double *cw[4];
            block_corners(sc, f, n, cw);
            exact_walk w = {.m = (const double(*)[4])m};
            for (int i = 0; i < 4; i++)
                for (int a = 0; a < 3; a++) {
                    int r = a == 2 ? 3 : a;
                    w.C[i][a] =
                        (m[0][r] * cw[i][0] + m[1][r] * cw[i][1] + m[2][r] * cw[i][2]) / cw[i][3] +
                        m[3][r];
                }
            block_points(sc, f, n, 0, exact_visit, &w);
            crisp__groups_dev_sample s = {
                .face = fi, .patches = n->nu * n->nv, .rational = n->rational};
            deviation_range(&h->devs[n->dev], m, s.lo, s.hi, s.box_lo, s.box_hi, s.wlo, s.whi);
            memcpy(s.exact_lo, w.lo, sizeof w.lo);
            memcpy(s.exact_hi, w.hi, sizeof w.hi);
            visit(ctx, &s);
        }
    }
    return CRISP_OK;
}
