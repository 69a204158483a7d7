/* A flatness bound for rational patches (and blocks of patches) on screen that does not divide
 * by the homogeneous weight (issue 12). The homogeneous bounds (the SLEFE of the clip-space patch
 * (w X, w Y, w Z, w w_clip), quadtree.c flat_px, patch_groups.c group_leaf_ok) treat the weight
 * w as a fourth coordinate: where the weights vary (impeller.igs: up to 3x within a patch) the
 * product's deviation from linear is of the order of W itself and the bounds lose 10-100x.
 *
 * What is measured. A triangle of a leaf has vertices on the surface at parameters x_0, x_1, x_2;
 * the rasterizer interpolates in clip space: the triangle point with barycentrics l is
 * T(x) = sum l_k Q(x_k) at the parameters x = sum l_k x_k, where Q(x) = view_proj (P(x), 1) is
 * the clip-space point of the Euclidean surface point P(x) (its 4th coordinate is the camera's
 * w, not the weight). The bound is on |T(x)/T_w - Q(x)/Q_w| in pixels for every such triangle of
 * the patch (or block), whatever the tessellation: the tests compare exactly these two points.
 *
 * Derivation. A rational Bézier patch with weights w_ij and Euclidean control points P_ij is
 * P(x) = sum r_ij(x) P_ij with the convex weights r_ij = w_ij B_ij / sum w B, so
 * Q(x) = sum r_ij(x) Q_ij, Q_ij = view_proj (P_ij, 1) (a rational Bézier in clip space with the
 * same weights: the camera's perspective stays in the final division, as in the homogeneous
 * bounds, and only the weights are handled here). Let L be the bilinear through the four corner
 * points Q_00, Q_n0, Q_0m, Q_nm (a rational patch interpolates its corners) and g_ij = (i/n, j/m)
 * the control points' grid parameters. Then
 *   Q(x) - L(x) = sum r_ij (Q_ij - L(g_ij)) + [sum r_ij L(g_ij) - L(x)].
 * The first term is at most D = max |Q_ij - L(g_ij)| per coordinate (convex combination). L is
 * bilinear, so expanded at x = (s, t): L(g) - L(x) = (g_s - s) L_s(x) + (g_t - t) L_t(x) +
 * (g_s - s)(g_t - t) L_st, and the second term is (s' - s) L_s + (t' - t) L_t + c L_st with
 * s' = sum r_ij i/n, t' = sum r_ij j/m (the reparametrisation the weights cause) and
 * c = sum r_ij (i/n - s)(j/m - t). Each is a ratio N / sum w B of two Bernstein polynomials. For
 * s' - s: sum_i w_i B_i^n(s) (i/n - s) has, in degree n + 1, the coefficients
 *   N_k = k (n + 1 - k) / (n (n + 1)) (w_k - w_{k-1}),  k = 0..n + 1
 * (multiply out s B_i^n = (i + 1)/(n + 1) B_{i+1}^{n+1} and elevate i/n B_i^n; the terms cancel
 * to this: zero for equal weights, linear precision), tensor-multiplied in the other direction;
 * c's numerator is the same operator in both directions, with the mixed difference of w. Over
 * the denominator sum w B elevated to the same degree (coefficients > 0), the ratio is a convex
 * combination of the coefficient ratios, so |s' - s| <= max_k |N_k| / (elevated w)_k (a rational
 * Bézier lies in the hull of its points; Farin, "Curves and Surfaces for CAGD", ch. 13 on
 * rational Bézier curves and degree elevation). These sigma's are view-independent. With Eu, Ev
 * the largest of L's two opposite edges per coordinate (|L_s| <= Eu, |L_t| <= Ev, since L_s is
 * linear in t) and tw = |L_st|:
 *   |Q(x) - L(x)| <= E_S = D + sigma_s Eu + sigma_t Ev + sigma_st tw,
 *   |T(x) - L(x)| <= sum l_k |Q(x_k) - L(x_k)| + |sum l_k L(x_k) - L(x)| <= E_S + tw / 4
 * (the bilinear against its linear interpolant on a triangle: L_st times a covariance of the
 * triangle's parameters, at most 1/4). Both are measured against L(x), whose w is at least the
 * corners' least w, so on screen |T(x) - Q(x)| <= px(E_S) + px(E_S + tw / 4) with
 * px(e) = (e_X + |x_L| e_W) / (w_L - e_W) (crisp__clip_screen_px). For a block of nu x nv patches,
 * L is the bilinear through the block's corners; on a patch of the block it is a bilinear in the
 * patch's local parameters with edges 1/nu, 1/nv and twist 1/(nu nv) of the block's, and the
 * block's E_S is the largest over its patches. For a polynomial patch (all weights 1) this is
 * the homogeneous flat bound. patch_groups.c keeps view-independent ranges of the deviations per
 * block and ends with this bound's last step (crisp__rational_block_finish_px). */
#include "rational_bound.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "render_internal.h"

/* fmax / fmin without the library call (no NaN handling needed: the inputs are finite or
 * +-INFINITY, and a NaN would fail the callers' <= eps tests either way). */
static inline double dmax(double a, double b)
{
    return a > b ? a : b;
}
static inline double dmin(double a, double b)
{
    return a < b ? a : b;
}

/* Levels above this are left to the homogeneous bound (the windows' cost grows as tau^2). */
#define RATIONAL_MAX_SEARCH 12
/* Halvings of the reparametrisation ratios (4 pieces per row). */
#define REPARAM_HALVINGS 2

/* Euclidean point of control point q (homogeneous); 0 when its weight is not positive. */
static int euclid(const double *q, double P[3])
{
    if (!(q[3] > 0)) return 0;
    P[0] = q[0] / q[3], P[1] = q[1] / q[3], P[2] = q[2] / q[3];
    return 1;
}

/* Three rows of a 3 x 4 affine map applied to Euclidean points: the clip rows X, Y, W of
 * view_proj, or the identity on x, y, z. */
typedef struct map3 {
    double a[3][4];
} map3;

static inline void apply(const map3 *A, const double P[3], double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = A->a[r][0] * P[0] + A->a[r][1] * P[1] + A->a[r][2] * P[2] + A->a[r][3];
}

static map3 clip_map(crisp_mat4 m)
{
    map3 A;
    for (int r = 0; r < 3; r++) {
        int row = r == 2 ? 3 : r; /* x, y, w rows of view_proj (column-major) */
        for (int c = 0; c < 4; c++)
            A.a[r][c] = m[c][row];
    }
    return A;
}

/* Split the Bernstein coefficients c[0..p] at 1/2 into left and right halves (de Casteljau). */
static void halve(const double *c, int p, double *left, double *right)
{
    /* in place in right: after step r, right[p - r] is final and right[0] is left[r] */
    for (int i = 0; i <= p; i++)
        right[i] = c[i];
    left[0] = right[0];
    for (int r = 1; r <= p; r++) {
        for (int i = 0; i <= p - r; i++)
            right[i] = 0.5 * (right[i] + right[i + 1]);
        left[r] = right[0];
    }
}

/* max(best, max |num / den| over [0, 1]) for two polynomials of degree p in Bernstein form (den's
 * coefficients > 0), bounded by the coefficient ratios after up to `depth` halvings (the ratio is
 * a convex combination of them on each piece; the excess falls about 4x per halving). A piece
 * whose coefficient ratios are all within best is not halved further. */
static double ratio_bound(const double *num, const double *den, int p, int depth, double best)
{
    double r = 0;
    for (int k = 0; k <= p; k++)
        r = dmax(r, fabs(num[k]) / den[k]);
    if (depth == 0 || r <= best) return dmax(best, r);
    /* the end coefficients are the function's values there */
    best = dmax(best, dmax(fabs(num[0]) / den[0], fabs(num[p]) / den[p]));
    double nl[CRISP_MAX_DEGREE + 2] = {0}, nr[CRISP_MAX_DEGREE + 2] = {0},
                                 dl[CRISP_MAX_DEGREE + 2] = {0}, dr[CRISP_MAX_DEGREE + 2] = {0};
    halve(num, p, nl, nr);
    halve(den, p, dl, dr);
    best = ratio_bound(nl, dl, p, depth - 1, best);
    return ratio_bound(nr, dr, p, depth - 1, best);
}

static void reparam(const crisp_bezier_patch *p, int halvings, double sigma[3])
{
    sigma[0] = sigma[1] = sigma[2] = 0;
    if (!p->rational) return;
    int n = p->du, m = p->dv, row = n + 1;
    const double *c = p->cpw;
#define OM(i, j) c[((j)*row + (i)) * 4 + 3]
    for (int j = 0; j <= m; j++)
        for (int i = 0; i <= n; i++)
            if (!(OM(i, j) > 0)) {
                sigma[0] = sigma[1] = sigma[2] = INFINITY;
                return;
            }
    /* Along s, row by row: over the denominator sum_ij w_ij B_i B_j, the ratio is a convex
     * combination (weights w_j(s) B_j(t) / sum) of the rows' ratios N_j(s) / W_j(s), so the
     * largest row ratio bounds it. A row's numerator in degree n + 1 has the coefficients
     * alpha_k (w_k - w_{k-1}), its elevated denominator (k w_{k-1} + (n + 1 - k) w_k) / (n + 1). */
    double num[CRISP_MAX_DEGREE + 2], den[CRISP_MAX_DEGREE + 2];
    for (int j = 0; j <= m; j++) {
        for (int k = 0; k <= n + 1; k++) {
            double wl = k > 0 ? OM(k - 1, j) : 0, wr = k <= n ? OM(k, j) : 0;
            num[k] = (double)k * (n + 1 - k) / ((double)n * (n + 1)) * (wr - wl);
            den[k] = (k * wl + (n + 1 - k) * wr) / (n + 1);
        }
        sigma[0] = ratio_bound(num, den, n + 1, halvings, sigma[0]);
    }
    for (int i = 0; i <= n; i++) {
        for (int l = 0; l <= m + 1; l++) {
            double wl = l > 0 ? OM(i, l - 1) : 0, wr = l <= m ? OM(i, l) : 0;
            num[l] = (double)l * (m + 1 - l) / ((double)m * (m + 1)) * (wr - wl);
            den[l] = (l * wl + (m + 1 - l) * wr) / (m + 1);
        }
        sigma[1] = ratio_bound(num, den, m + 1, halvings, sigma[1]);
    }
    /* The mixed term: the same operator in both directions (mixed differences of w), bounded by
     * the tensor coefficient ratios (no halving: it is second order and small). */
    for (int l = 1; l <= m; l++)
        for (int k = 1; k <= n; k++) {
            double a = (double)k * (n + 1 - k) / ((double)n * (n + 1)) * (double)l * (m + 1 - l) /
                       ((double)m * (m + 1));
            double mixed = OM(k, l) - OM(k - 1, l) - OM(k, l - 1) + OM(k - 1, l - 1);
            double fu0 = (double)k / (n + 1), fu1 = (double)(n + 1 - k) / (n + 1);
            double fv0 = (double)l / (m + 1), fv1 = (double)(m + 1 - l) / (m + 1);
            double d = fu0 * fv0 * OM(k - 1, l - 1) + fu1 * fv0 * OM(k, l - 1) +
                       fu0 * fv1 * OM(k - 1, l) + fu1 * fv1 * OM(k, l);
            sigma[2] = dmax(sigma[2], a * fabs(mixed) / d);
        }
#undef OM
    /* a relative allowance for the rounding of the ratios and the halvings */
    for (int k = 0; k < 3; k++)
        sigma[k] = sigma[k] * (1 + 1e-12) + 1e-15;
}

void crisp__rational_reparam(const crisp_bezier_patch *p, double sigma[3])
{
    reparam(p, REPARAM_HALVINGS, sigma);
}

void crisp__rational_sigmas(const crisp_bezier_patch *p, double dest[CRISP__SIGMA_STRIDE])
{
    reparam(p, 0, dest);
    reparam(p, REPARAM_HALVINGS, dest + 3);
}

void crisp__rational_weight_range(const crisp_bezier_patch *p, double *lo, double *hi)
{
    *lo = *hi = 1;
    if (!p->rational) return;
    *lo = INFINITY, *hi = -INFINITY;
    for (int i = 0; i < (p->du + 1) * (p->dv + 1); i++) {
        *lo = dmin(*lo, p->cpw[4 * i + 3]);
        *hi = dmax(*hi, p->cpw[4 * i + 3]);
    }
}

/* The four corner control points (Euclidean) of the block whose corner patches are c[]. */
static int block_corners(const crisp_bezier_patch *const c[4], double P[4][3])
{
    const double *q[4] = {c[0]->cpw, c[1]->cpw + 4 * c[1]->du,
                          c[2]->cpw + 4 * (c[2]->du + 1) * c[2]->dv,
                          c[3]->cpw + 4 * ((c[3]->du + 1) * c[3]->dv + c[3]->du)};
    for (int k = 0; k < 4; k++)
        if (!euclid(q[k], P[k])) return 0;
    return 1;
}

/* L's edges and twist (per coordinate) for one patch of an nu x nv block. */
static void edge_terms(const double C[4][3], uint32_t nu, uint32_t nv, double eu[3], double ev[3],
                       double tw[3])
{
    for (int a = 0; a < 3; a++) {
        eu[a] = dmax(fabs(C[1][a] - C[0][a]), fabs(C[3][a] - C[2][a])) / nu;
        ev[a] = dmax(fabs(C[2][a] - C[0][a]), fabs(C[3][a] - C[1][a])) / nv;
        tw[a] = fabs(C[0][a] - C[1][a] - C[2][a] + C[3][a]) / ((double)nu * nv);
    }
}

double crisp__clip_screen_px(const double e[3], double wmin, double xmax, double ymax, int width,
                             int height)
{
    double den = wmin - e[2];
    if (!(den > 0)) return INFINITY;
    double dx = (e[0] + xmax * e[2]) / den, dy = (e[1] + ymax * e[2]) / den;
    return dmax(dx * 0.5 * width, dy * 0.5 * height) * (1 + 1e-9) + 1e-12;
}

typedef struct stop_rule {
    double wmin, accept;
    int width, height;
} stop_rule;

/* The block's deviations from the bilinear L through its corners, per coordinate: the control
 * points' deviations Q_ij - L(g_ij) lie in [lo, hi] (which holds 0: the corners), and the
 * reparametrisation term (sigma's times L's edges and twist) is at most r. */
typedef struct block_dev {
    double lo[3], hi[3], r[3];
} block_dev;

/* E_S = max(|lo|, |hi|) + r. */
static void dev_max(const block_dev *d, double E[3])
{
    for (int a = 0; a < 3; a++)
        E[a] = dmax(-d->lo[a], d->hi[a]) + d->r[a];
}

/* The deviations of the block's patches in the coordinates of A, against the bilinear through C
 * (the block's corners mapped by A), the sigma's without halvings. 0 when a weight is not
 * positive or (stop) the bound must already exceed stop->accept: both forms in finish are at
 * least max(|lo|, |hi|) / w_min in pixels. */
static int block_error(const crisp_scene_patch *first, const double *sigmas, uint32_t stride,
                       uint32_t nu, uint32_t nv, const map3 *A, const double C[4][3],
                       const stop_rule *stop, block_dev *d)
{
    double eu[3], ev[3], tw[3];
    edge_terms(C, nu, nv, eu, ev, tw);
    *d = (block_dev){{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    for (uint32_t jv = 0; jv < nv; jv++)
        for (uint32_t iu = 0; iu < nu; iu++) {
            const crisp_bezier_patch *b = &first[jv * stride + iu].bez;
            double sigma[3], plo[3] = {0, 0, 0}, phi[3] = {0, 0, 0};
            if (b->du < 1 || b->dv < 1 || b->du > CRISP_MAX_DEGREE) return 0;
            /* L(s, t) = (1 - t) bot(s) + t top(s): the two rows' terms per column, formed once
             * (the same operations as the whole expression, so the same numbers) */
            double bot[CRISP_MAX_DEGREE + 1][3], top[CRISP_MAX_DEGREE + 1][3];
            for (int i = 0; i <= b->du; i++) {
                double s = (iu + (double)i / b->du) / nu;
                for (int a = 0; a < 3; a++) {
                    bot[i][a] = (1 - s) * C[0][a] + s * C[1][a];
                    top[i][a] = (1 - s) * C[2][a] + s * C[3][a];
                }
            }
            for (int j = 0; j <= b->dv; j++) {
                double t = (jv + (double)j / b->dv) / nv;
                for (int i = 0; i <= b->du; i++) {
                    double P[3], x[3];
                    if (!euclid(b->cpw + 4 * (j * (b->du + 1) + i), P)) return 0;
                    apply(A, P, x);
                    for (int a = 0; a < 3; a++) {
                        double bl = (1 - t) * bot[i][a] + t * top[i][a];
                        /* a relative allowance for the rounding of both sides */
                        double slack = 1e-12 * (fabs(x[a]) + fabs(bl));
                        plo[a] = dmin(plo[a], x[a] - bl - slack);
                        phi[a] = dmax(phi[a], x[a] - bl + slack);
                    }
                }
            }
            if (sigmas)
                memcpy(sigma, sigmas + CRISP__SIGMA_STRIDE * ((size_t)jv * stride + iu),
                       sizeof sigma);
            else
                reparam(b, 0, sigma);
            if (!isfinite(sigma[0])) return 0;
            for (int a = 0; a < 3; a++) {
                d->lo[a] = dmin(d->lo[a], plo[a]);
                d->hi[a] = dmax(d->hi[a], phi[a]);
            }
            for (int a = 0; a < 3; a++)
                d->r[a] = dmax(d->r[a], (sigma[0] * eu[a] + sigma[1] * ev[a] + sigma[2] * tw[a]) *
                                            (1 + 1e-12));
            if (stop) {
                double E[2];
                for (int a = 0; a < 2; a++)
                    E[a] = dmax(-d->lo[a], d->hi[a]);
                if (dmax(E[0] * stop->width, E[1] * stop->height) * 0.5 / stop->wmin > stop->accept)
                    return 0;
            }
        }
    return 1;
}

/* d->r again from the sigma's after REPARAM_HALVINGS (the control points' part is kept). */
static void block_refine(const crisp_scene_patch *first, const double *sigmas, uint32_t stride,
                         uint32_t nu, uint32_t nv, const double C[4][3], block_dev *d)
{
    double eu[3], ev[3], tw[3];
    edge_terms(C, nu, nv, eu, ev, tw);
    d->r[0] = d->r[1] = d->r[2] = 0;
    for (uint32_t jv = 0; jv < nv; jv++)
        for (uint32_t iu = 0; iu < nu; iu++) {
            double sigma[3];
            if (sigmas)
                memcpy(sigma, sigmas + CRISP__SIGMA_STRIDE * ((size_t)jv * stride + iu) + 3,
                       sizeof sigma);
            else
                reparam(&first[jv * stride + iu].bez, REPARAM_HALVINGS, sigma);
            for (int a = 0; a < 3; a++)
                d->r[a] = dmax(d->r[a], (sigma[0] * eu[a] + sigma[1] * ev[a] + sigma[2] * tw[a]) *
                                            (1 + 1e-12));
        }
}

/* The screen bound against the clip corners C (x, y, w) from the deviations d: the smaller of
 *  (1) px(E_S) + px(E_S + tw / 4): the surface point S(x) and the triangle point T(x) are each
 *      within those of L(x), whose w is at least the corners' least;
 *  (2) T(x) - S(x) directly: its control-point part is sum_k l_k sum r_ij(x_k) delta_ij -
 *      sum r_ij(x) delta_ij, coefficients summing to 0 with absolute sum <= 2, so within
 *      hi - lo (not 2 max |delta|: a patch that bulges one way gains 2x); the reparametrisation
 *      part within 2 r, the triangle's twist within tw / 4; so |T - S| <= dl per coordinate and
 *      |T_x/T_w - S_x/S_w| = |dX - s_x dW| / T_w <= (dl_X + |s_x| dl_W) / (w_min - E_T,W), with
 *      |s_x| at most the corners' largest |x| plus px(E_S) in NDC. */
static double finish(const double C[4][3], const block_dev *d, int width, int height)
{
    double wmin = INFINITY, xmax = 0, ymax = 0, E[3], ET[3], dl[3];
    for (int k = 0; k < 4; k++) {
        if (!(C[k][2] > 0)) return INFINITY;
        wmin = dmin(wmin, C[k][2]);
        xmax = dmax(xmax, fabs(C[k][0] / C[k][2]));
        ymax = dmax(ymax, fabs(C[k][1] / C[k][2]));
    }
    dev_max(d, E);
    for (int a = 0; a < 3; a++) {
        double tw = 0.25 * fabs(C[0][a] - C[1][a] - C[2][a] + C[3][a]);
        ET[a] = E[a] + tw;
        dl[a] = d->hi[a] - d->lo[a] + 2 * d->r[a] + tw;
    }
    double one = crisp__clip_screen_px(E, wmin, xmax, ymax, width, height) +
                 crisp__clip_screen_px(ET, wmin, xmax, ymax, width, height);
    double ws = wmin - E[2], wt = wmin - ET[2];
    if (!(ws > 0) || !(wt > 0)) return one;
    double xs = xmax + (E[0] + xmax * E[2]) / ws, ys = ymax + (E[1] + ymax * E[2]) / ws;
    double dx = (dl[0] + xs * dl[2]) / wt, dy = (dl[1] + ys * dl[2]) / wt;
    double two = dmax(dx * 0.5 * width, dy * 0.5 * height) * (1 + 1e-9) + 1e-12;
    return dmin(one, two);
}

/* The block's corner patches. */
static void corner_patches(const crisp_scene_patch *first, uint32_t stride, uint32_t nu,
                           uint32_t nv, const crisp_bezier_patch *c[4])
{
    c[0] = &first[0].bez, c[1] = &first[nu - 1].bez, c[2] = &first[(size_t)(nv - 1) * stride].bez,
    c[3] = &first[(size_t)(nv - 1) * stride + nu - 1].bez;
}

double crisp__rational_block_px(const crisp_scene_patch *first, uint32_t stride, uint32_t nu,
                                uint32_t nv, crisp_mat4 m, int width, int height, double accept)
{
    return crisp__rational_block_px_sigmas(first, NULL, stride, nu, nv, m, width, height, accept);
}

/* The W part of the bound from the deviations d (finish's direct form, its W coordinate): every
 * triangle point's clip W is within depth[0] of the surface point's at the same parameters, and
 * the surface's clip W is at least depth[1] (L's least W, the corners', plus the least
 * deviation). */
static void depth_part(const double C[4][3], const block_dev *d, double depth[2])
{
    double wmin = INFINITY;
    for (int k = 0; k < 4; k++)
        wmin = dmin(wmin, C[k][2]);
    double tw = 0.25 * fabs(C[0][2] - C[1][2] - C[2][2] + C[3][2]);
    depth[0] = (d->hi[2] - d->lo[2] + 2 * d->r[2] + tw) * (1 + 1e-9);
    depth[1] = (wmin + d->lo[2] - d->r[2]) * (1 - 1e-9);
}

static double block_px(const crisp_scene_patch *first, const double *sigmas, uint32_t stride,
                       uint32_t nu, uint32_t nv, crisp_mat4 m, int width, int height, double accept,
                       double depth[2])
{
    if (depth) depth[0] = INFINITY, depth[1] = 0;
    const crisp_bezier_patch *cp[4];
    corner_patches(first, stride, nu, nv, cp);
    double P[4][3], C[4][3];
    if (!block_corners(cp, P)) return INFINITY;
    map3 A = clip_map(m);
    stop_rule stop = {INFINITY, accept, width, height};
    for (int k = 0; k < 4; k++) {
        apply(&A, P[k], C[k]);
        if (!(C[k][2] > 0)) return INFINITY;
        stop.wmin = dmin(stop.wmin, C[k][2]);
    }
    /* The coarse sigma's first (cheap), the halved ones only where the coarse bound does not
     * accept; blocks stop early once the control points alone exceed accept. */
    const stop_rule *sr = accept > 0 && nu * nv > 1 ? &stop : NULL;
    block_dev d;
    if (!block_error(first, sigmas, stride, nu, nv, &A, (const double(*)[3])C, sr, &d))
        return INFINITY;
    double e = finish((const double(*)[3])C, &d, width, height);
    if ((accept > 0 && e <= accept) || (d.r[0] == 0 && d.r[1] == 0 && d.r[2] == 0)) {
        if (depth) depth_part((const double(*)[3])C, &d, depth);
        return e;
    }
    block_refine(first, sigmas, stride, nu, nv, (const double(*)[3])C, &d);
    if (depth) depth_part((const double(*)[3])C, &d, depth);
    return dmin(e, finish((const double(*)[3])C, &d, width, height));
}

double crisp__rational_block_px_sigmas(const crisp_scene_patch *first, const double *sigmas,
                                       uint32_t stride, uint32_t nu, uint32_t nv, crisp_mat4 m,
                                       int width, int height, double accept)
{
    return block_px(first, sigmas, stride, nu, nv, m, width, height, accept, NULL);
}

double crisp__rational_block_px_depth(const crisp_scene_patch *first, const double *sigmas,
                                      uint32_t stride, uint32_t nu, uint32_t nv, crisp_mat4 m,
                                      int width, int height, double accept, double depth[2])
{
    return block_px(first, sigmas, stride, nu, nv, m, width, height, accept, depth);
}

/* The largest screen extent (pixels, max of x and y) of the patch's projected control points,
 * INFINITY when one is not in front of the eye: the surface and every triangle with vertices on
 * it lie in that hull (convex hull property; clip-space barycentrics keep a triangle point in the
 * clip-space hull), so this also bounds their distance. */
static double hull_px(const crisp_bezier_patch *p, const map3 *A, int width, int height)
{
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < (p->du + 1) * (p->dv + 1); i++) {
        double P[3], x[3];
        if (!euclid(p->cpw + 4 * i, P)) return INFINITY;
        apply(A, P, x);
        if (!(x[2] > 0)) return INFINITY;
        lo[0] = dmin(lo[0], x[0] / x[2]), hi[0] = dmax(hi[0], x[0] / x[2]);
        lo[1] = dmin(lo[1], x[1] / x[2]), hi[1] = dmax(hi[1], x[1] / x[2]);
    }
    double e = dmax((hi[0] - lo[0]) * 0.5 * width, (hi[1] - lo[1]) * 0.5 * height);
    return e * (1 + 1e-9) + 1e-9;
}

/* One window: the smaller of the any-triangle bound and the hull's extent. */
static double window_px(const crisp_bezier_patch *p, crisp_mat4 m, int width, int height,
                        double accept)
{
    crisp_scene_patch one = {.bez = *p};
    map3 A = clip_map(m);
    double h = hull_px(p, &A, width, height);
    if (accept > 0 && h <= accept) return h;
    return dmin(h, crisp__rational_block_px(&one, 1, 1, 1, m, width, height, accept));
}

/* The leaf mesh of crisp_tess_mesh_generate at inner level tau >= 2 in both directions, with
 * every edge level >= tau (the planner's edge rule gives each edge at least the density of the
 * leaves on both sides), puts every triangle in a cell [i h, (i + 1) h] x [j h, (j + 1) h] of the
 * tau x tau grid (h = 1 / tau) or in a window of two neighbouring cells of the ring along a side.
 * The inner grid's triangles are in its cells. The ring between a side (outer vertices k / n,
 * n >= tau) and the inner grid's first row (inner points (j + 1) h at depth h) is stitched by
 * crisp_tess's zipper, walking the side from its first corner: it takes the outer segment
 * [i/n, (i + 1)/n] against inner point j while the segment's midpoint is at most the inner
 * segment's, and an inner segment otherwise. A triangle (outer segment, inner point j) thus has
 * its midpoint within h / 2 of (j + 1) h, and the segment (at most h long) lies in
 * [j h, (j + 2) h]: in the ring's two cells beside that point, and in both of them where n is not
 * a multiple of tau and the segment crosses a cell side (session 20, gen9's test_tau_windows: an
 * earlier version of this bound took only the four windows at the corners); a triangle (outer
 * point, inner segment j..j + 1) has the outer point on [(j + 1) h, (j + 2) h], in one cell;
 * after the last inner point, 1 - h, the remaining outer segments start beyond 1 - 2 h: the
 * window [1 - 2 h, 1] x [0, h] at the side's end. So the distance between the patch and the mesh
 * is at most the largest of the bounds (window_px) of the tau - 1 two-cell windows along each
 * side and of the inner cells. */
double crisp__rational_level_px(const crisp_bezier_patch *p, int tau, crisp_mat4 m, int width,
                                int height, double accept)
{
    if (tau <= 1) return window_px(p, m, width, height, accept);
    double storage[2 * CRISP__PATCH_DOUBLES], tmp[CRISP__PATCH_DOUBLES], worst = 0, h = 1.0 / tau;
    crisp_bezier_patch sub;
#define AT(k) ((k) >= tau ? 1.0 : (k)*h)
    /* The ring's windows, the four at the sides' ends first (the widest: a rejection is found
     * soonest): side t = 0 walks to s = 1, s = 1 to t = 1, t = 1 to s = 0, s = 0 to t = 0. */
    for (int i = tau - 2; i >= 0; i--) {
        const double a = AT(i), b = AT(i + 2),
                     side[4][4] = {{a, b, 0, h},
                                   {1 - h, 1, a, b},
                                   {1 - b, 1 - a, 1 - h, 1},
                                   {0, h, 1 - b, 1 - a}};
        for (int k = 0; k < 4; k++) {
            crisp__subpatch(p, dmax(side[k][0], 0), side[k][1], dmax(side[k][2], 0), side[k][3],
                            storage, tmp, &sub);
            worst = dmax(worst, window_px(&sub, m, width, height, accept));
            if (accept > 0 && worst > accept) return worst;
        }
    }
    /* The inner cells (the ring's are in its windows), a row of cells first, then each cell. */
    crisp_bezier_patch strip;
    double sstore[2 * CRISP__PATCH_DOUBLES], stmp[CRISP__PATCH_DOUBLES];
    for (int j = 1; j + 1 < tau; j++) {
        crisp__subpatch(p, 0, 1, AT(j), AT(j + 1), sstore, stmp, &strip);
        for (int i = 1; i + 1 < tau; i++) {
            crisp__subpatch(&strip, AT(i), AT(i + 1), 0, 1, storage, tmp, &sub);
            worst = dmax(worst, window_px(&sub, m, width, height, accept));
            if (accept > 0 && worst > accept) return worst;
        }
    }
#undef AT
    return worst;
}

int crisp__rational_tess_level(const crisp_bezier_patch *p, int below, double flat, crisp_mat4 m,
                               int width, int height, double eps)
{
    if (!p->rational || below <= 2 || !isfinite(flat)) return below;
    /* The windows' bounds fall about as 1 / tau^2 from the whole patch's (flat); the ring windows
     * are two cells long. Start a little below that prediction and step up by it. */
    int t = (int)floor(sqrt(flat / eps));
    if (t < 2) t = 2;
    for (int tries = 0; tries < 3 && t < below && t <= RATIONAL_MAX_SEARCH; tries++) {
        double e = crisp__rational_level_px(p, t, m, width, height, eps);
        if (e <= eps) return t;
        if (!isfinite(e)) return below;
        int next = (int)ceil(t * sqrt(e / eps));
        t = next > t ? next : t + 1;
    }
    return below;
}

double crisp__rational_block_finish_px(const double C[4][3], const double lo[3], const double hi[3],
                                       const double r[3], int width, int height)
{
    block_dev d;
    for (int a = 0; a < 3; a++)
        d.lo[a] = lo[a], d.hi[a] = hi[a], d.r[a] = r[a];
    return finish(C, &d, width, height);
}
