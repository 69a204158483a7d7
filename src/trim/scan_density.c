/* The v-scan (and u-scan) density bound of Wu & Peters 2015 (eqs. 6-8), computed for the current
 * frame as a guaranteed upper bound instead of being read back from the previous frame.
 *
 * In clip space the face's homogeneous patch is four polynomial patches X, Y, Z, W, and
 * x~ = w_x X / W + c_x, so with r_x = X / W
 *   x~_v = w_x (X_v W - X W_v) / W^2 = w_x (X_v - r_x W_v) / W.
 * On a sub-patch whose W coefficients W_k are all positive:
 *   - r_x lies in [min X_k / W_k, max X_k / W_k] (X / W is a convex combination of the ratios,
 *     with weights W_k B_k / W), and at the points that matter (inside the widened frustum) also
 *     in [-(1 + m_x), 1 + m_x]; call the intersection R_x (empty: nothing visible, culled);
 *   - with X_v and W_v degree-elevated to the patch's degrees (coefficients X'_k, W'_k), at a
 *     point where r_x = r: X_v - r W_v = sum (X'_k - r W'_k) B_k and W = sum W_k B_k, so for the
 *     vector n_k = (w_x (X'_k - r_x W'_k), w_y (Y'_k - r_y W'_k)) the triangle inequality gives
 *       |(x~_v, y~_v)| <= sum |n_k| B_k / sum W_k B_k <= max_k |n_k| / W_k,
 *     and |n_k|^2 is convex in (r_x, r_y), so its largest value over R_x x R_y is at a corner:
 *       |n_k|^2 <= w_x^2 max_{r in R_x} (X'_k - r W'_k)^2 + w_y^2 max_{r in R_y} (Y'_k - r W'_k)^2.
 * That is O(coefficients) per sub-patch, camera and all: no products of Bernstein forms (the
 * first version bounded the exact numerator X_v W - X W_v through such products, which cost
 * O(coefficients^2) and was 90% of a frame's plan). The bound tightens as sub-patches shrink
 * (R_x narrows), so the refinement below pays for the looser start.
 * Sub-patches whose coefficients put them wholly outside one plane of the widened frustum are
 * dropped; where min(W) is not positive or the bound is well above the values sampled on the
 * sub-patch, it is split 2x2 and examined again (docs/design.md section 5).
 *
 * Near (and far) plane. The 1 px guarantee (include/crisp/trim.h) follows the surface from a
 * pixel's point p along a path of parameter length at most 3h/4 in v (to its scan line, then
 * to the polyline within h/4) and 1 / (4 rho_u) in u, and bounds the path's screen length by
 * rho_v and rho_u. That needs the whole path inside the region the bounds cover. Through a side
 * plane it cannot leave: the side planes are widened by margin_px >= 2 px and p is on screen,
 * so leaving would take a screen length of 2 px while the bounds allow at most 1 px before the
 * exit. Through the near plane it could: the depth is not a screen distance, and behind the near
 * plane, towards the eye plane, the screen speed is unbounded. So the covered region also
 * reaches DEPTH_MARGIN = delta beyond the near and far planes in NDC depth (z~ = Z / W in
 * [-1 - delta, 1 + delta]; points nearer than about 2/3 of the near distance are still left out,
 * W stays positive), and the bounds also cover the depth speed: rho_v >= sup |z~_v| / delta and
 * rho_u >= sup |z~_u| / delta over the region, from the same coefficient bound with Z in place
 * of X. Along the path, then, z~ moves by at most (3/4) delta + (1/4) delta = delta, strictly
 * less with the 1 + 1e-9 widening: a path from p (z~ in [-1, 1]) cannot reach the widened depth
 * planes before its end, and its screen length is bounded as claimed. In most views the depth
 * term is far below the screen term (near the near plane |z~_v| ~ 2 |d_v| / near against a
 * screen speed of ~ (w / 2) |d_v| tan(angle) / near); it only decides for a surface running
 * along the ray through the eye, whose image hardly moves while its depth does.
 */
#include "trim_internal.h"

#include <math.h>
#include <string.h>

#define MIN_PIECE 0x1p-20 /* a strip part thinner than this (of the patch) is a rounding sliver */
/* A (sub-)patch or block whose bound asks for at most this many rows and u-pixels over its
 * parameter box is accepted without refining (a bound over it is a bound; refining would only
 * save a few rows). 8 until session 8 (issue 12): 32 takes impeller x 49 far's density walk from
 * 214 M to 151 M instructions for 23 k -> 32 k table rows; the impeller's default view and
 * close-up get 0.3% more rows and a few per cent fewer plan instructions. */
#define FEW_ROWS 32.0
#define SMALL_BLOCK 16u  /* blocks of at most this many patches: see walk_block */
#define DEPTH_MARGIN 1.0 /* delta: the bound covers NDC depth z~ in [-1 - delta, 1 + delta] */

typedef struct density_ctx {
    int du, dv;
    size_t n;       /* (du + 1) * (dv + 1) coefficients per plane */
    double wx, wy;  /* pixels per NDC unit: width / 2, height / 2 */
    double mx, my;  /* widened frustum: |X| <= (1 + mx) W */
    double floor_v; /* a v-bound below this gives mu = 1 anyway */
    double slack;
    int max_depth;
    double *levels;  /* (max_depth + 1) * 4 children * 4 planes * n */
    double *scratch; /* elevated derivatives: 4 planes */
    double cur_v, cur_u;
    double vis_lo, vis_hi;   /* v-range of the sub-patches kept */
    double visu_lo, visu_hi; /* u-range of the sub-patches kept */
    double ulo, uhi;         /* the strip's u-range of interest (desc->strip_u), else infinite */
    int visible, unbounded;
    long budget;
    crisp_trim_density_stats *stats;
} density_ctx;

/* 1 when every coefficient of a*W + b*P (P one of X, Y, Z) is negative: the sub-patch lies
 * strictly outside that frustum plane. */
static int outside_plane(const double *P, const double *W, size_t n, double a, double b)
{
    for (size_t k = 0; k < n; k++)
        if (a * W[k] + b * P[k] >= 0.0) return 0;
    return 1;
}

static int culled(const density_ctx *c, const double *s)
{
    const double *X = s, *Y = s + c->n, *Z = s + 2 * c->n, *W = s + 3 * c->n;
    return outside_plane(X, W, c->n, 1.0 + c->mx, -1.0) ||
           outside_plane(X, W, c->n, 1.0 + c->mx, 1.0) ||
           outside_plane(Y, W, c->n, 1.0 + c->my, -1.0) ||
           outside_plane(Y, W, c->n, 1.0 + c->my, 1.0) ||
           outside_plane(Z, W, c->n, 1.0 + DEPTH_MARGIN, 1.0) ||
           outside_plane(Z, W, c->n, 1.0 + DEPTH_MARGIN, -1.0);
}

/* Derivative of a tensor-product Bernstein patch in v (dir 1) or u (dir 0), degree-elevated back
 * to the patch's degrees (du, dv): along the direction, with d the degree,
 *   E_j = j (c_j - c_{j-1}) + (d - j) (c_{j+1} - c_j)
 * (the elevation (j/d) D_{j-1} + (1 - j/d) D_j of D_j = d (c_{j+1} - c_j), no division). */
static void derivative_elevated(const double *c, int du, int dv, int dir, double *dest)
{
    int d = dir ? dv : du;
    size_t step = dir ? (size_t)(du + 1) : 1; /* between neighbours along the direction */
    int lines = dir ? du + 1 : dv + 1;
    for (int l = 0; l < lines; l++) {
        const double *p = dir ? c + l : c + (size_t)l * (du + 1);
        double *q = dir ? dest + l : dest + (size_t)l * (du + 1);
        if (d == 0) {
            q[0] = 0.0;
            continue;
        }
        /* the ends apart (no branches inside; the same sums, 0 + a [+ b], so the same numbers) */
        q[0] = 0.0 + d * (p[step] - p[0]);
        for (int j = 1; j < d; j++) {
            double e = 0.0 + j * (p[j * step] - p[(j - 1) * step]);
            q[j * step] = e + (d - j) * (p[(j + 1) * step] - p[j * step]);
        }
        q[d * step] = 0.0 + d * (p[d * step] - p[(d - 1) * step]);
    }
}

/* fmax and fmin without the library call (operands here are finite). */
static inline double dmax(double a, double b)
{
    return a > b ? a : b;
}

static inline double dmin(double a, double b)
{
    return a < b ? a : b;
}

/* max over r in [lo, hi] of (a - r b)^2: at an end, the expression being convex in r. */
static double max_sq(double a, double b, double lo, double hi)
{
    double p = a - lo * b, q = a - hi * b;
    return dmax(p * p, q * q);
}

/* The bounds of the header comment for direction dir, per unit of the sub-patch's local
 * parameter: the screen speed (returned) and the NDC depth speed |z~_dir| (*depth). rx, ry, rz:
 * R_x, R_y, R_z. */
static double speed_bound(density_ctx *c, const double *X, const double *Y, const double *Z,
                          const double *W, const double rx[2], const double ry[2],
                          const double rz[2], int dir, double *depth)
{
    double *xe = c->scratch, *ye = xe + c->n, *ze = ye + c->n, *we = ze + c->n;
    derivative_elevated(X, c->du, c->dv, dir, xe);
    derivative_elevated(Y, c->du, c->dv, dir, ye);
    derivative_elevated(Z, c->du, c->dv, dir, ze);
    derivative_elevated(W, c->du, c->dv, dir, we);
    double b2 = 0.0, d2 = 0.0, wx2 = c->wx * c->wx, wy2 = c->wy * c->wy;
    for (size_t k = 0; k < c->n; k++) {
        double nx = max_sq(xe[k], we[k], rx[0], rx[1]), ny = max_sq(ye[k], we[k], ry[0], ry[1]);
        double w2 = W[k] * W[k];
        b2 = dmax(b2, (wx2 * nx + wy2 * ny) / w2);
        d2 = dmax(d2, max_sq(ze[k], we[k], rz[0], rz[1]) / w2);
    }
    *depth = sqrt(d2);
    return sqrt(b2);
}

/* Value and partials of a tensor-product Bernstein patch at (s, t). */
static void eval_tp(const double *c, int du, int dv, double s, double t, double out[3])
{
    double r[CRISP_MAX_DEGREE + 1], rs[CRISP_MAX_DEGREE + 1];
    for (int j = 0; j <= dv; j++)
        crisp__trim_eval_d(c + j * (du + 1), du, 1, s, &r[j], &rs[j]);
    crisp__trim_eval_d(r, dv, 1, t, &out[0], &out[2]);
    out[1] = crisp__trim_eval(rs, dv, 1, t);
}

/* Value and partials at a corner (a, b in {0, 1}) straight from the coefficients. */
static void corner_tp(const double *c, int du, int dv, int a, int b, double out[3])
{
    int i = a ? du : 0, j = b ? dv : 0, di = a ? -1 : 1, dj = b ? -1 : 1;
    out[0] = c[j * (du + 1) + i];
    out[1] = (a ? 1 : -1) * du * (c[j * (du + 1) + i] - c[j * (du + 1) + i + di]);
    out[2] = (b ? 1 : -1) * dv * (c[j * (du + 1) + i] - c[(j + dj) * (du + 1) + i]);
}

/* Largest screen speeds sampled at the sub-patch's four corners and centre, among the points
 * inside the widened frustum; returns the number of such points. (Only steers refinement.) */
static int sample_speeds(const density_ctx *c, const double *s, double sv, double su, double ua,
                         double ub, double *ev, double *eu, double *ev_min)
{
    int seen = 0;
    *ev = *eu = 0.0;
    if (ev_min) *ev_min = HUGE_VAL;
    for (int k = 0; k < 5; k++) {
        double X[3], Y[3], Z[3], W[3];
        double u = k < 4 ? (k & 1 ? ub : ua) : 0.5 * (ua + ub);
        if (u < c->ulo || u > c->uhi) continue; /* the bound need not cover it */
        if (k < 4) {
            int a = k & 1, b = k >> 1;
            corner_tp(s, c->du, c->dv, a, b, X);
            corner_tp(s + c->n, c->du, c->dv, a, b, Y);
            corner_tp(s + 2 * c->n, c->du, c->dv, a, b, Z);
            corner_tp(s + 3 * c->n, c->du, c->dv, a, b, W);
        } else {
            eval_tp(s, c->du, c->dv, 0.5, 0.5, X);
            eval_tp(s + c->n, c->du, c->dv, 0.5, 0.5, Y);
            eval_tp(s + 2 * c->n, c->du, c->dv, 0.5, 0.5, Z);
            eval_tp(s + 3 * c->n, c->du, c->dv, 0.5, 0.5, W);
        }
        if (!(W[0] > 0.0) || fabs(X[0]) > (1 + c->mx) * W[0] || fabs(Y[0]) > (1 + c->my) * W[0] ||
            fabs(Z[0]) > (1 + DEPTH_MARGIN) * W[0])
            continue;
        seen++;
        double w2 = W[0] * W[0];
        double xu = c->wx * (X[1] * W[0] - X[0] * W[1]) / w2;
        double yu = c->wy * (Y[1] * W[0] - Y[0] * W[1]) / w2;
        double xv = c->wx * (X[2] * W[0] - X[0] * W[2]) / w2;
        double yv = c->wy * (Y[2] * W[0] - Y[0] * W[2]) / w2;
        /* the depth terms as in the bound */
        double zu = fabs(Z[1] * W[0] - Z[0] * W[1]) / (w2 * DEPTH_MARGIN);
        double zv = fabs(Z[2] * W[0] - Z[0] * W[2]) / (w2 * DEPTH_MARGIN);
        double su_k = dmax(sqrt(xu * xu + yu * yu), zu) * su;
        double sv_k = dmax(sqrt(xv * xv + yv * yv), zv) * sv;
        *eu = dmax(*eu, su_k);
        *ev = dmax(*ev, sv_k);
        if (ev_min) *ev_min = dmin(*ev_min, sv_k);
    }
    return seen;
}

/* Split a plane of rows j = 0..dv (each of len values) at v = 1/2 by de Casteljau on whole rows:
 * lo holds the plane on entry and its lower half on exit, hi gets the upper half. */
static void split_rows(double *lo, double *hi, int dv, int len, double *tmp)
{
    size_t row = (size_t)len * sizeof *tmp;
    memcpy(tmp, lo, (size_t)(dv + 1) * row);
    memcpy(hi + (size_t)dv * len, tmp + (size_t)dv * len, row);
    for (int r = 1; r <= dv; r++) {
        for (int i = 0; i <= dv - r; i++) {
            double *a = tmp + (size_t)i * len, *b = a + len;
            for (int x = 0; x < len; x++)
                a[x] = 0.5 * (a[x] + b[x]);
        }
        memcpy(lo + (size_t)r * len, tmp, row);
        memcpy(hi + (size_t)(dv - r) * len, tmp + (size_t)(dv - r) * len, row);
    }
}

/* The four quarters of sub-patch s (kid k: u-half k & 1, v-half k >> 1), each 4 planes; with
 * u_only, the two u-halves (kids 0 and 1). */
static void split_half(const density_ctx *c, const double *s, double *kids, int u_only)
{
    int du = c->du, dv = c->dv, len = du + 1;
    size_t n = c->n, block = 4 * n;
    double tmp[(CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1)];
    for (int q = 0; q < 4; q++) {
        const double *src = s + q * n;
        double *k0 = kids + q * n, *k1 = k0 + block, *k2 = k1 + block, *k3 = k2 + block;
        for (int j = 0; j <= dv; j++) { /* u halves, row by row */
            double w[CRISP_MAX_DEGREE + 1], *lo = k0 + (size_t)j * len, *hi = k1 + (size_t)j * len;
            memcpy(w, src + (size_t)j * len, (size_t)len * sizeof *w);
            lo[0] = w[0];
            hi[du] = w[du];
            for (int r = 1; r <= du; r++) {
                for (int i = 0; i <= du - r; i++)
                    w[i] = 0.5 * (w[i] + w[i + 1]);
                lo[r] = w[0];
                hi[du - r] = w[du - r];
            }
        }
        if (u_only) continue;
        split_rows(k0, k2, dv, len, tmp); /* then v halves of each */
        split_rows(k1, k3, dv, len, tmp);
    }
}

/* The bounds bv, bu of the header comment for sub-patch s (per unit of the face's v and u: su, sv
 * are d(local)/d(global)). Returns 1 with the bounds, 0 when W is not provably positive on it, -1
 * when no point of it lies inside the widened frustum. */
static int node_bound(density_ctx *c, const double *s, double su, double sv, double *bv, double *bu)
{
    const double *X = s, *Y = s + c->n, *Z = s + 2 * c->n, *W = s + 3 * c->n;
    double wmin = HUGE_VAL;
    for (size_t k = 0; k < c->n; k++)
        wmin = dmin(wmin, W[k]);
    if (!(wmin > 0.0)) return 0;
    double rx[2] = {HUGE_VAL, -HUGE_VAL}, ry[2] = {HUGE_VAL, -HUGE_VAL},
           rz[2] = {HUGE_VAL, -HUGE_VAL};
    for (size_t k = 0; k < c->n; k++) {
        double qx = X[k] / W[k], qy = Y[k] / W[k], qz = Z[k] / W[k];
        rx[0] = dmin(rx[0], qx), rx[1] = dmax(rx[1], qx);
        ry[0] = dmin(ry[0], qy), ry[1] = dmax(ry[1], qy);
        rz[0] = dmin(rz[0], qz), rz[1] = dmax(rz[1], qz);
    }
    rx[0] = dmax(rx[0], -(1.0 + c->mx)), rx[1] = dmin(rx[1], 1.0 + c->mx);
    ry[0] = dmax(ry[0], -(1.0 + c->my)), ry[1] = dmin(ry[1], 1.0 + c->my);
    rz[0] = dmax(rz[0], -(1.0 + DEPTH_MARGIN)), rz[1] = dmin(rz[1], 1.0 + DEPTH_MARGIN);
    if (!(rx[0] <= rx[1] && ry[0] <= ry[1] && rz[0] <= rz[1])) return -1;
    /* Rounding in these few operations is relative ~1e-15; widen so the bounds stay upper
     * bounds (and the depth terms strict: see the header comment). */
    double dv, du;
    double sv_px = speed_bound(c, X, Y, Z, W, rx, ry, rz, 1, &dv);
    double su_px = speed_bound(c, X, Y, Z, W, rx, ry, rz, 0, &du);
    *bv = sv * dmax(sv_px, dv / DEPTH_MARGIN) * (1.0 + 1e-9);
    *bu = su * dmax(su_px, du / DEPTH_MARGIN) * (1.0 + 1e-9);
    return 1;
}

/* s: the sub-patch (4 planes) over [ua, ub] x [va, vb] of the face's parameters; su, sv:
 * d(local)/d(global) scale factors; pev, peu: the speeds sampled on the nearest ancestor that had
 * samples inside the region (0 at the root). */
static void refine(density_ctx *c, const double *s, int depth, double su, double sv, double ua,
                   double ub, double va, double vb, double pev, double peu)
{
    if (c->stats) c->stats->subpatches++;
    c->budget--;
    if (ub < c->ulo || ua > c->uhi || culled(c, s)) {
        if (c->stats) c->stats->culled++;
        return;
    }
    int last = depth >= c->max_depth || c->budget <= 0;
    double bv, bu;
    int b = node_bound(c, s, su, sv, &bv, &bu);
    if (b < 0) {
        if (c->stats) c->stats->culled++;
        return;
    }
    double ev = pev, eu = peu;
    if (b > 0) {
        int accept = last;
        if (!accept) {
            /* Nothing to gain: the bound is already covered by what other parts need. */
            if (bv <= fmax(c->cur_v, c->floor_v) && bu <= c->cur_u) accept = 1;
            /* Few rows and u-pixels in all, as for blocks (walk_block). */
            if ((vb - va) * bv <= FEW_ROWS && (ub - ua) * bu <= FEW_ROWS) accept = 1;
            /* Not while the sub-patch's v-range would take more scan lines than a screen can
             * show (16 (w + h)): at extreme zoom it is mostly off screen, and refining shrinks
             * the visible v-range (a face zoomed to fov 1e-7 deg otherwise took 2^22 rows). */
            int too_many = (vb - va) * bv > 32.0 * (c->wx + c->wy);
            /* Else the bound within the slack of the speeds sampled on the sub-patch (sampled
             * only where it may be refined: a sub-patch accepted above has no children to pass
             * them to; issue 12, a fifth of the density walk's work at impeller x 49 far). */
            if (!accept || too_many) {
                int seen = sample_speeds(c, s, sv, su, ua, ub, &ev, &eu, NULL);
                /* A sub-patch on the region's edge may have no sample inside: judge it by its
                 * ancestor's samples, or it is split along the edge down to the depth limit,
                 * where rounding in its coefficients makes the bound loose. */
                if (!seen) ev = pev, eu = peu;
                int ok_v = bv <= fmax(fmax(c->slack * ev, c->cur_v), c->floor_v);
                int ok_u = bu <= fmax(c->slack * eu, c->cur_u);
                accept = (seen > 0 || pev > 0.0) && ok_v && ok_u;
            }
            if (too_many) accept = 0;
        }
        if (accept) {
            c->vis_lo = fmin(c->vis_lo, va);
            c->vis_hi = fmax(c->vis_hi, vb);
            c->visu_lo = fmin(c->visu_lo, ua);
            c->visu_hi = fmax(c->visu_hi, ub);
            c->cur_v = fmax(c->cur_v, bv);
            c->cur_u = fmax(c->cur_u, bu);
            c->visible = 1;
            return;
        }
    } else if (last) {
        c->vis_lo = fmin(c->vis_lo, va);
        c->vis_hi = fmax(c->vis_hi, vb);
        c->visu_lo = fmin(c->visu_lo, ua);
        c->visu_hi = fmax(c->visu_hi, ub);
        c->unbounded = 1;
        c->visible = 1;
        return;
    }
    double *kids = c->levels + (size_t)(depth + 1) * 16 * c->n;
    /* A sub-patch far shorter on screen in v than in u (a thin strip) is split in u only: its
     * bounds vary along u, and halving v too would quadruple the work for little. */
    int u_only = b > 0 && (vb - va) * bv < 0.125 * (ub - ua) * bu;
    split_half(c, s, kids, u_only);
    double um = 0.5 * (ua + ub), vm = 0.5 * (va + vb);
    for (int k = 0; k < (u_only ? 2 : 4); k++)
        refine(c, kids + (size_t)k * 4 * c->n, depth + 1, 2 * su, u_only ? sv : 2 * sv,
               k & 1 ? um : ua, k & 1 ? ub : um, k < 2 ? va : vm, k < 2 ? (u_only ? vb : vm) : vb,
               ev, eu);
}

/* One patch's way through the strips it reaches. Strip by strip, each strip's part of the patch
 * is refined on its own (refine above). Before that, the patch is bisected at strip boundaries:
 * a piece over several strips whose bounds are already good enough (the v-bound within the slack
 * of the sampled speeds or asking for at most one row per strip, the u-bound within the slack)
 * gives its bounds to every strip it reaches (a bound over more of the surface is still a bound),
 * and only the other pieces go further down. Most patches of a model in full view stop there,
 * which saves restricting them to each strip (the first version restricted every patch to every
 * strip, 2 de Casteljau splits per column each). */
typedef struct patch_walk {
    const crisp_trim_density_desc *desc;
    density_ctx *c;
    const crisp_bezier_patch *bp;
    const double *clip; /* the whole patch in clip space */
    double *nodes;      /* bisection pieces: 2 per depth, 4 planes each */
    double *rho_v, *rho_u, *vis_v, *vis_u;
    double hv;
    double *clip_buf, *root_buf; /* a patch in clip space, and its part in the strips' v-range */
} patch_walk;

/* Split a plane of rows j = 0..dv (each of len values) at v = t by de Casteljau on whole rows:
 * src into lo (v in [0, t]) and hi ([t, 1]). */
static void split_rows_at(const double *src, double *lo, double *hi, int dv, int len, double t,
                          double *tmp)
{
    size_t row = (size_t)len * sizeof *tmp;
    memcpy(tmp, src, (size_t)(dv + 1) * row);
    memcpy(lo, tmp, row);
    memcpy(hi + (size_t)dv * len, tmp + (size_t)dv * len, row);
    for (int r = 1; r <= dv; r++) {
        for (int i = 0; i <= dv - r; i++) {
            double *a = tmp + (size_t)i * len, *b = a + len;
            for (int x = 0; x < len; x++)
                a[x] += t * (b[x] - a[x]);
        }
        memcpy(lo + (size_t)r * len, tmp, row);
        memcpy(hi + (size_t)(dv - r) * len, tmp + (size_t)(dv - r) * len, row);
    }
}

/* Strip i's part of the patch, [ta, tb] of its local v, refined on its own. node: the patch
 * restricted to [t0, t1] of its local v (used when that is [ta, tb]; else, or NULL, the whole
 * patch is restricted here). */
static void strip_part(patch_walk *w, int i, const double *node, double t0, double t1)
{
    const crisp_trim_density_desc *desc = w->desc;
    density_ctx *c = w->c;
    const crisp_bezier_patch *bp = w->bp;
    double nu0 = desc->v0 + i * w->hv, nu1 = desc->v0 + (i + 1) * w->hv;
    double ta = (nu0 - bp->v0) / (bp->v1 - bp->v0), tb = (nu1 - bp->v0) / (bp->v1 - bp->v0);
    if (ta < 0.0) ta = 0.0;
    if (tb > 1.0) tb = 1.0;
    if (!(tb > ta)) return;
    /* A sliver of the patch (a strip boundary a rounding error away from the patch's) restricted
     * on its own would have derivative coefficients made of cancellation noise divided by its
     * tiny width: bound a piece of at least MIN_PIECE of the patch around it instead (a bound
     * over more of the surface is still a bound; the row range is cut back to the strip). */
    if (node && (fabs(t0 - ta) > 1e-14 || fabs(t1 - tb) > 1e-14)) node = NULL;
    if (tb - ta < MIN_PIECE) {
        node = NULL;
        if (ta + MIN_PIECE <= 1.0)
            tb = ta + MIN_PIECE;
        else
            ta = 1.0 - MIN_PIECE, tb = 1.0;
    }
    double *root = c->levels; /* refine copies children deeper */
    if (node) {
        memcpy(root, node, sizeof(double) * 4 * c->n);
    } else {
        memcpy(root, w->clip, sizeof(double) * 4 * c->n);
        for (int q = 0; q < 4; q++)
            for (int col = 0; col <= c->du; col++)
                crisp__trim_restrict(root + q * c->n + col, c->dv, c->du + 1, ta, tb);
    }
    double *rho_v = w->rho_v, *rho_u = w->rho_u, *vis_v = w->vis_v;
    c->cur_v = rho_v[i];
    c->cur_u = rho_u[i];
    c->visible = rho_v[i] > 0.0 || rho_u[i] > 0.0;
    c->unbounded = 0;
    c->vis_lo = vis_v ? vis_v[2 * i] : 0.0;
    c->vis_hi = vis_v ? vis_v[2 * i + 1] : 0.0;
    c->visu_lo = w->vis_u ? w->vis_u[2 * i] : 0.0;
    c->visu_hi = w->vis_u ? w->vis_u[2 * i + 1] : 0.0;
    c->floor_v = 1.0 / w->hv;
    c->budget = 16384; /* deep refinement at extreme zoom (fov 1e-7 deg) needs ~5000 */
    c->ulo = desc->strip_u ? desc->strip_u[2 * i] : -HUGE_VAL;
    c->uhi = desc->strip_u ? desc->strip_u[2 * i + 1] : HUGE_VAL;
    refine(c, root, 0, 1.0 / (bp->u1 - bp->u0), 1.0 / ((bp->v1 - bp->v0) * (tb - ta)), bp->u0,
           bp->u1, bp->v0 + (bp->v1 - bp->v0) * ta, bp->v0 + (bp->v1 - bp->v0) * tb, 0.0, 0.0);
    if (vis_v) vis_v[2 * i] = c->vis_lo, vis_v[2 * i + 1] = c->vis_hi;
    if (w->vis_u) w->vis_u[2 * i] = c->visu_lo, w->vis_u[2 * i + 1] = c->visu_hi;
    if (c->unbounded) {
        rho_v[i] = rho_u[i] = HUGE_VAL;
        c->stats->unbounded++;
    } else if (c->visible) {
        rho_v[i] = c->cur_v;
        rho_u[i] = c->cur_u;
        /* A visible strip always needs a row, even if the surface is edge-on in v. */
        if (!(rho_v[i] > 0.0)) rho_v[i] = 1e-300;
        if (!(rho_u[i] > 0.0)) rho_u[i] = 1e-300;
    }
}

/* node: the patch over [t0, t1] of its local v, which covers strips i0..i1 (exactly, up to the
 * patch's own ends). */
static void walk_strips(patch_walk *w, const double *node, int depth, int i0, int i1, double t0,
                        double t1)
{
    if (i0 == i1) {
        strip_part(w, i0, node, t0, t1);
        return;
    }
    const crisp_trim_density_desc *desc = w->desc;
    density_ctx *c = w->c;
    const crisp_bezier_patch *bp = w->bp;
    c->ulo = desc->strip_u ? HUGE_VAL : -HUGE_VAL;
    c->uhi = desc->strip_u ? -HUGE_VAL : HUGE_VAL;
    for (int i = i0; desc->strip_u && i <= i1; i++) {
        c->ulo = dmin(c->ulo, desc->strip_u[2 * i]);
        c->uhi = dmax(c->uhi, desc->strip_u[2 * i + 1]);
    }
    c->stats->subpatches++;
    if (c->uhi < bp->u0 || c->ulo > bp->u1 || culled(c, node)) {
        c->stats->culled++;
        return;
    }
    double dv = bp->v1 - bp->v0, su = 1.0 / (bp->u1 - bp->u0), sv = 1.0 / (dv * (t1 - t0));
    double bv, bu, ev, eu, ev_min;
    int b = node_bound(c, node, su, sv, &bv, &bu);
    if (b < 0) {
        c->stats->culled++;
        return;
    }
    if (b > 0 && ((dv * (t1 - t0) * bv <= FEW_ROWS && (bp->u1 - bp->u0) * bu <= FEW_ROWS) ||
                  (sample_speeds(c, node, sv, su, bp->u0, bp->u1, &ev, &eu, &ev_min) > 0 &&
                   bv <= dmax(c->slack * ev_min, 1.0 / w->hv) && bu <= c->slack * eu &&
                   dv * (t1 - t0) * bv <= 32.0 * (c->wx + c->wy)))) {
        for (int i = i0; i <= i1; i++) {
            double nu0 = desc->v0 + i * w->hv, nu1 = desc->v0 + (i + 1) * w->hv;
            double lo = dmax(nu0, bp->v0), hi = dmin(nu1, bp->v1);
            if (!(hi > lo)) continue;
            if (w->vis_v) {
                w->vis_v[2 * i] = dmin(w->vis_v[2 * i], lo);
                w->vis_v[2 * i + 1] = dmax(w->vis_v[2 * i + 1], hi);
            }
            if (w->vis_u) {
                w->vis_u[2 * i] = dmin(w->vis_u[2 * i], bp->u0);
                w->vis_u[2 * i + 1] = dmax(w->vis_u[2 * i + 1], bp->u1);
            }
            if (w->rho_v[i] < HUGE_VAL) { /* a visible strip always needs a row */
                w->rho_v[i] = dmax(w->rho_v[i], dmax(bv, 1e-300));
                w->rho_u[i] = dmax(w->rho_u[i], dmax(bu, 1e-300));
            }
        }
        return;
    }
    /* Bisect at the strip boundary nearest the middle. */
    int k = (i0 + i1 + 1) / 2;
    double tk = (desc->v0 + k * w->hv - bp->v0) / dv, s = (tk - t0) / (t1 - t0);
    if (!(s > 0.0 && s < 1.0) || depth >= 60) { /* rounding: strip by strip from the patch */
        for (int i = i0; i <= i1; i++)
            strip_part(w, i, NULL, 0.0, 1.0);
        return;
    }
    double *lo = w->nodes + (size_t)depth * 8 * c->n, *hi = lo + 4 * c->n;
    double tmp[(CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1)];
    for (int q = 0; q < 4; q++)
        split_rows_at(node + q * c->n, lo + q * c->n, hi + q * c->n, c->dv, c->du + 1, s, tmp);
    walk_strips(w, lo, depth + 1, i0, k - 1, t0, tk);
    walk_strips(w, hi, depth + 1, k, i1, tk, t1);
}

/* Patch p of the face through the strips it reaches (walk_strips), after mapping it to clip
 * space. */
static crisp_status walk_patch(patch_walk *w, int p)
{
    const crisp_trim_density_desc *desc = w->desc;
    density_ctx *c = w->c;
    crisp_mat4 *m = desc->view_proj;
    double *clip = w->clip_buf, *root = w->root_buf, hv = w->hv;
    const crisp_bezier_patch *bp = &desc->patches[p];
    w->bp = bp;
    w->clip = clip;
    c->du = bp->du;
    c->dv = bp->dv;
    c->n = (size_t)(bp->du + 1) * (size_t)(bp->dv + 1);
    for (size_t k = 0; k < c->n; k++) {
        const double *h = bp->cpw + 4 * k;
        for (int r = 0; r < 4; r++)
            clip[r * c->n + k] =
                (*m)[0][r] * h[0] + (*m)[1][r] * h[1] + (*m)[2][r] * h[2] + (*m)[3][r] * h[3];
        for (int r = 0; r < 4; r++)
            if (!isfinite(clip[r * c->n + k]))
                return crisp_error(CRISP_ERR_NUMERIC,
                                   "crisp_trim_scan_density: patch %d control point %zu is not "
                                   "finite in clip space",
                                   p, k);
    }
    int i0 = (int)floor((bp->v0 - desc->v0) / hv), i1 = (int)floor((bp->v1 - desc->v0) / hv);
    if (i0 < 0) i0 = 0;
    if (i1 > desc->strip_count - 1) i1 = desc->strip_count - 1;
    /* The root: the patch's part inside the strips' v-range (a patch reaching beyond it would
     * otherwise be bounded over more than its strips). */
    double dvp = bp->v1 - bp->v0;
    double r0 = fmax(0.0, (desc->v0 - bp->v0) / dvp), r1 = fmin(1.0, (desc->v1 - bp->v0) / dvp);
    if (!(r1 > r0)) return CRISP_OK;
    const double *rootp = clip;
    if (r1 - r0 >= MIN_PIECE && (r0 > 0.0 || r1 < 1.0)) {
        memcpy(root, clip, sizeof(double) * 4 * c->n);
        for (int q = 0; q < 4; q++)
            for (int col = 0; col <= c->du; col++)
                crisp__trim_restrict(root + q * c->n + col, c->dv, c->du + 1, r0, r1);
        rootp = root;
    } else {
        r0 = 0.0, r1 = 1.0;
    }
    walk_strips(w, rootp, 0, i0, i1, r0, r1);
    return CRISP_OK;
}

/* ---- blocks of patches (issue 12) ------------------------------------------------------------
 * A block B of the face's patch grid, with boxes (per homogeneous object coordinate) of its
 * patches' control points h_k and of their degree-elevated derivative coefficients e_k per unit
 * of the face's v (and u). At a point of B's surface, H = sum h_k B_k and H_v = sum e_k B_k (the
 * same patch's Bernstein basis) lie in the boxes, being convex combinations. In clip space, with
 * row vectors R_X, R_Y, R_Z, R_W of view_proj and r_x = X / W at the point,
 *   x~_v = w_x (R_X - r_x R_W) . H_v / W,
 * so, with R_x the range of X / W over the control-point box (a ratio of linear functions with a
 * positive denominator takes its extremes over a box at its corners), intersected with the
 * widened frustum's [-(1 + m_x), 1 + m_x] as in the per-patch bound, and W >= W_min over the box:
 *   |(x~_v, y~_v)| <= sqrt(w_x^2 A_X^2 + w_y^2 A_Y^2) / W_min,
 *   A_P = max over r in R_P (at its ends: the expression is linear in r) and e in the
 *         derivative box of |(R_P - r R_W) . e| = |c . mid| + |c| . half (c = R_P - r R_W),
 * and |z~_v| <= A_Z / W_min for the depth term. Every coefficient of every patch of B lies in the
 * boxes, so this is at least the per-patch bound of the header comment for each of B's patches
 * (tests/trim/test_trim.c checks it, and its tightness). It costs O(1) per block whatever the
 * block's size, which is what lets a face's density bound follow its size on screen: whole
 * blocks off screen are dropped, and a block whose bound asks for few rows, or is within the
 * slack of the speeds sampled at its corners, gives its bound to its strips without reading its
 * patches. */

/* Min and max over the box [lo, hi] (4 coordinates) of the linear function coef . x, widened by
 * a relative allowance for rounding. */
static void box_range(const double coef[4], const double *lo, const double *hi, double *mn,
                      double *mx)
{
    double a = 0.0, b = 0.0, mag = 0.0;
    for (int k = 0; k < 4; k++) {
        double p = coef[k] * lo[k], q = coef[k] * hi[k];
        a += dmin(p, q);
        b += dmax(p, q);
        mag += dmax(fabs(p), fabs(q));
    }
    *mn = a - 1e-12 * mag;
    *mx = b + 1e-12 * mag;
}

/* max over e in the box of |c . e|. */
static double box_abs_max(const double c[4], const double *lo, const double *hi)
{
    double mid = 0.0, half = 0.0;
    for (int k = 0; k < 4; k++) {
        mid += c[k] * 0.5 * (lo[k] + hi[k]);
        half += fabs(c[k]) * 0.5 * (hi[k] - lo[k]);
    }
    return (fabs(mid) + half) * (1.0 + 1e-12);
}

/* The bound of the comment above for one direction's derivative box d (lo[4], hi[4]): the screen
 * speed (returned) and the depth speed (*depth), per unit of the face's parameter. */
static double block_speed(const density_ctx *c, double R[4][4], double r[3][2], const double *d,
                          double wmin, double *depth)
{
    double A[3] = {0.0, 0.0, 0.0};
    for (int p = 0; p < 3; p++)
        for (int e = 0; e < 2; e++) {
            double coef[4];
            for (int k = 0; k < 4; k++)
                coef[k] = R[p][k] - r[p][e] * R[3][k];
            A[p] = dmax(A[p], box_abs_max(coef, d, d + 4));
        }
    *depth = A[2] / wmin;
    return sqrt(c->wx * c->wx * A[0] * A[0] + c->wy * c->wy * A[1] * A[1]) / wmin;
}

/* As node_bound, for block b from its boxes. */
static int block_bound(const density_ctx *c, crisp_mat4 *m, const crisp_trim_density_block *b,
                       double *bv, double *bu)
{
    double R[4][4]; /* rows of view_proj: X, Y, Z, W */
    for (int r = 0; r < 4; r++)
        for (int k = 0; k < 4; k++)
            R[r][k] = (*m)[k][r];
    const double *lo = b->h, *hi = b->h + 4;
    double wmin, wmax;
    box_range(R[3], lo, hi, &wmin, &wmax);
    if (!(wmin > 0.0)) return 0;
    /* Outside one plane of the widened frustum (as culled()). */
    const double g[3] = {1.0 + c->mx, 1.0 + c->my, 1.0 + DEPTH_MARGIN};
    for (int p = 0; p < 3; p++)
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            double coef[4], mn, mx;
            for (int k = 0; k < 4; k++)
                coef[k] = g[p] * R[3][k] + sgn * R[p][k];
            box_range(coef, lo, hi, &mn, &mx);
            if (mx < 0.0) return -1;
        }
    /* Ranges of X / W, Y / W, Z / W over the box's corners. */
    double r[3][2] = {{HUGE_VAL, -HUGE_VAL}, {HUGE_VAL, -HUGE_VAL}, {HUGE_VAL, -HUGE_VAL}};
    for (int k = 0; k < 16; k++) {
        double x[4], v[4];
        for (int a = 0; a < 4; a++)
            x[a] = (k >> a) & 1 ? hi[a] : lo[a];
        for (int q = 0; q < 4; q++)
            v[q] = R[q][0] * x[0] + R[q][1] * x[1] + R[q][2] * x[2] + R[q][3] * x[3];
        if (!(v[3] > 0.0)) return 0;
        for (int p = 0; p < 3; p++) {
            double q = v[p] / v[3];
            r[p][0] = dmin(r[p][0], q);
            r[p][1] = dmax(r[p][1], q);
        }
    }
    for (int p = 0; p < 3; p++) {
        r[p][0] = dmax(r[p][0], -g[p]);
        r[p][1] = dmin(r[p][1], g[p]);
        if (!(r[p][0] <= r[p][1])) return -1;
    }
    double dv, du;
    double sv_px = block_speed(c, R, r, b->dv, wmin, &dv);
    double su_px = block_speed(c, R, r, b->du, wmin, &du);
    *bv = dmax(sv_px, dv / DEPTH_MARGIN) * (1.0 + 1e-9);
    *bu = dmax(su_px, du / DEPTH_MARGIN) * (1.0 + 1e-9);
    return 1;
}

/* Speeds (per unit of the face's v and u) sampled at the block's four corners and at the grid
 * vertex nearest its centre, among the points inside the widened frustum with u in [ulo, uhi]:
 * the largest and smallest in v and the largest in u. Returns the number of such points. (Only
 * steers refinement.) */
static int block_samples(const density_ctx *c, const crisp_trim_density_desc *desc,
                         const crisp_trim_density_block *b, double *ev_max, double *ev_min,
                         double *eu_max)
{
    crisp_mat4 *m = desc->view_proj;
    int gu = desc->tree->grid_u, seen = 0;
    *ev_max = *eu_max = 0.0;
    *ev_min = HUGE_VAL;
    for (int k = 0; k < 5; k++) {
        uint32_t iu = k < 4 ? b->iu0 + (k & 1) * (b->nu - 1) : b->iu0 + b->nu / 2;
        uint32_t iv = k < 4 ? b->iv0 + (k >> 1) * (b->nv - 1) : b->iv0 + b->nv / 2;
        int a = k < 4 ? k & 1 : 0, e = k < 4 ? k >> 1 : 0;
        const crisp_bezier_patch *p = &desc->patches[(size_t)iv * gu + iu];
        double u = a ? p->u1 : p->u0;
        if (u < c->ulo || u > c->uhi) continue;
        int du = p->du, dv = p->dv, i = a ? du : 0, j = e ? dv : 0, di = a ? -1 : 1,
            dj = e ? -1 : 1;
        const double *h = p->cpw + 4 * (j * (du + 1) + i),
                     *hu = p->cpw + 4 * (j * (du + 1) + i + di),
                     *hv = p->cpw + 4 * ((j + dj) * (du + 1) + i);
        double H[4], Hu[4], Hv[4];
        for (int q = 0; q < 4; q++) {
            H[q] = h[q];
            Hu[q] = (a ? 1 : -1) * du * (h[q] - hu[q]) / (p->u1 - p->u0);
            Hv[q] = (e ? 1 : -1) * dv * (h[q] - hv[q]) / (p->v1 - p->v0);
        }
        double X[3][4]; /* clip value, d/du, d/dv of X, Y, Z, W */
        for (int r = 0; r < 4; r++) {
            X[0][r] = X[1][r] = X[2][r] = 0.0;
            for (int q = 0; q < 4; q++) {
                X[0][r] += (*m)[q][r] * H[q];
                X[1][r] += (*m)[q][r] * Hu[q];
                X[2][r] += (*m)[q][r] * Hv[q];
            }
        }
        double W = X[0][3];
        if (!(W > 0.0) || fabs(X[0][0]) > (1 + c->mx) * W || fabs(X[0][1]) > (1 + c->my) * W ||
            fabs(X[0][2]) > (1 + DEPTH_MARGIN) * W)
            continue;
        seen++;
        double w2 = W * W, sp[2];
        for (int d = 1; d <= 2; d++) {
            double xd = c->wx * (X[d][0] * W - X[0][0] * X[d][3]) / w2;
            double yd = c->wy * (X[d][1] * W - X[0][1] * X[d][3]) / w2;
            double zd = fabs(X[d][2] * W - X[0][2] * X[d][3]) / (w2 * DEPTH_MARGIN);
            sp[d - 1] = dmax(sqrt(xd * xd + yd * yd), zd);
        }
        *eu_max = dmax(*eu_max, sp[0]);
        *ev_max = dmax(*ev_max, sp[1]);
        *ev_min = dmin(*ev_min, sp[1]);
    }
    return seen;
}

/* Block bi of desc->tree through the strips it reaches: dropped, bounded as a whole, or refined
 * to its sub-blocks (or, for the smallest blocks, to its patches' own walks). */
static crisp_status walk_block(patch_walk *w, int32_t bi)
{
    const crisp_trim_density_desc *desc = w->desc;
    const crisp_trim_density_tree *t = desc->tree;
    const crisp_trim_density_block *b = &t->blocks[bi];
    density_ctx *c = w->c;
    double hv = w->hv;
    double va = dmax(b->v0, desc->v0), vb = dmin(b->v1, desc->v1);
    if (!(vb > va)) return CRISP_OK;
    int i0 = (int)floor((b->v0 - desc->v0) / hv), i1 = (int)floor((b->v1 - desc->v0) / hv);
    if (i0 < 0) i0 = 0;
    if (i1 > desc->strip_count - 1) i1 = desc->strip_count - 1;
    c->ulo = desc->strip_u ? HUGE_VAL : -HUGE_VAL;
    c->uhi = desc->strip_u ? -HUGE_VAL : HUGE_VAL;
    double min_v = HUGE_VAL, min_u = HUGE_VAL;
    for (int i = i0; i <= i1; i++) {
        if (desc->strip_u) {
            c->ulo = dmin(c->ulo, desc->strip_u[2 * i]);
            c->uhi = dmax(c->uhi, desc->strip_u[2 * i + 1]);
        }
        min_v = dmin(min_v, w->rho_v[i]);
        min_u = dmin(min_u, w->rho_u[i]);
    }
    c->stats->subpatches++;
    if (c->uhi < b->u0 || c->ulo > b->u1) {
        c->stats->culled++;
        return CRISP_OK;
    }
    double bv, bu;
    int k = block_bound(c, desc->view_proj, b, &bv, &bu);
    if (k < 0) {
        c->stats->culled++;
        return CRISP_OK;
    }
    int accept = 0;
    if (k > 0) {
        double ev_max, ev_min, eu_max;
        if (bv <= min_v && bu <= min_u) accept = 1; /* nothing to gain */
        if ((vb - va) * bv <= FEW_ROWS && (b->u1 - b->u0) * bu <= FEW_ROWS) accept = 1;
        if (!accept && block_samples(c, desc, b, &ev_max, &ev_min, &eu_max) > 0 &&
            bv <= dmax(c->slack * ev_min, 1.0 / hv) && bu <= c->slack * eu_max)
            accept = 1;
        /* As refine(): not while the block's v-range would take more scan lines than a screen
         * can show. */
        if ((vb - va) * bv > 32.0 * (c->wx + c->wy)) accept = 0;
    }
    if (accept) {
        for (int i = i0; i <= i1; i++) {
            double nu0 = desc->v0 + i * hv, nu1 = desc->v0 + (i + 1) * hv;
            double lo = dmax(nu0, b->v0), hi = dmin(nu1, b->v1);
            if (!(hi > lo)) continue;
            if (w->vis_v) {
                w->vis_v[2 * i] = dmin(w->vis_v[2 * i], lo);
                w->vis_v[2 * i + 1] = dmax(w->vis_v[2 * i + 1], hi);
            }
            if (w->vis_u) {
                w->vis_u[2 * i] = dmin(w->vis_u[2 * i], b->u0);
                w->vis_u[2 * i + 1] = dmax(w->vis_u[2 * i + 1], b->u1);
            }
            if (w->rho_v[i] < HUGE_VAL) { /* a visible strip always needs a row */
                w->rho_v[i] = dmax(w->rho_v[i], dmax(bv, 1e-300));
                w->rho_u[i] = dmax(w->rho_u[i], dmax(bu, 1e-300));
            }
        }
        return CRISP_OK;
    }
    crisp_status st = CRISP_OK;
    /* A refused block of at most SMALL_BLOCK patches goes to its patches' own walks, not to its
     * sub-blocks: their box bounds mostly fail with it (rational patches with varying weights,
     * whose homogeneous boxes are loose), and each costs as much as a patch's bound (issue 12:
     * impeller x 49 far, density walk 124 -> 86 M instructions; the generated sheets' faces, whose
     * blocks are accepted higher up, unchanged). */
    if (b->nu * b->nv > SMALL_BLOCK &&
        (b->child[0] >= 0 || b->child[1] >= 0 || b->child[2] >= 0 || b->child[3] >= 0)) {
        for (int q = 0; q < 4 && !st; q++)
            if (b->child[q] >= 0) st = walk_block(w, b->child[q]);
        return st;
    }
    for (uint32_t iv = b->iv0; iv < b->iv0 + b->nv && !st; iv++)
        for (uint32_t iu = b->iu0; iu < b->iu0 + b->nu && !st; iu++)
            st = walk_patch(w, (int)(iv * (uint32_t)t->grid_u + iu));
    return st;
}

/* Boxes of patch p (as crisp_trim_density_block's h, du, dv), widened for rounding. */
static void patch_boxes(const crisp_bezier_patch *p, double h[8], double du[8], double dv[8])
{
    int n = (p->du + 1) * (p->dv + 1);
    double plane[(CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1)];
    double e[(CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1)];
    for (int a = 0; a < 4; a++) {
        double mag = 0.0;
        h[a] = du[a] = dv[a] = HUGE_VAL;
        h[4 + a] = du[4 + a] = dv[4 + a] = -HUGE_VAL;
        for (int k = 0; k < n; k++) {
            plane[k] = p->cpw[4 * k + a];
            h[a] = dmin(h[a], plane[k]);
            h[4 + a] = dmax(h[4 + a], plane[k]);
            mag = dmax(mag, fabs(plane[k]));
        }
        for (int dir = 0; dir < 2; dir++) {
            double *box = dir ? dv : du;
            double len = dir ? p->v1 - p->v0 : p->u1 - p->u0;
            int d = dir ? p->dv : p->du;
            derivative_elevated(plane, p->du, p->dv, dir, e);
            for (int k = 0; k < n; k++) {
                box[a] = dmin(box[a], e[k] / len);
                box[4 + a] = dmax(box[4 + a], e[k] / len);
            }
            /* The differences carry rounding of the order of the coordinates' size. */
            double slop = 1e-13 * (4.0 * d * mag / len);
            box[a] -= slop + 1e-15 * fabs(box[a]);
            box[4 + a] += slop + 1e-15 * fabs(box[4 + a]);
        }
    }
}

static void box_union(double *dest, const double *src)
{
    for (int a = 0; a < 4; a++) {
        dest[a] = dmin(dest[a], src[a]);
        dest[4 + a] = dmax(dest[4 + a], src[4 + a]);
    }
}

/* The aligned block (lv >= 1, bu, bv): patches [bu 2^lv, (bu + 1) 2^lv) x [bv 2^lv, ...) clipped
 * to the grid. */
static crisp_status build_block(crisp_trim_density_tree *t, const crisp_bezier_patch *patches,
                                int lv, uint32_t bu, uint32_t bv, int32_t *dest)
{
    crisp_status st = crisp_grow((void **)&t->blocks, &t->cap, t->count + 1, sizeof *t->blocks);
    if (st) return st;
    int32_t me = (int32_t)t->count++;
    uint32_t gu = (uint32_t)t->grid_u, gv = (uint32_t)t->grid_v, size = 1u << lv;
    crisp_trim_density_block b = {.iu0 = bu << lv, .iv0 = bv << lv, .child = {-1, -1, -1, -1}};
    b.nu = gu - b.iu0 < size ? gu - b.iu0 : size;
    b.nv = gv - b.iv0 < size ? gv - b.iv0 : size;
    for (int a = 0; a < 4; a++) {
        b.h[a] = b.du[a] = b.dv[a] = HUGE_VAL;
        b.h[4 + a] = b.du[4 + a] = b.dv[4 + a] = -HUGE_VAL;
    }
    if (lv == 1) {
        for (uint32_t iv = b.iv0; iv < b.iv0 + b.nv; iv++)
            for (uint32_t iu = b.iu0; iu < b.iu0 + b.nu; iu++) {
                double h[8], du[8], dv[8];
                patch_boxes(&patches[iv * gu + iu], h, du, dv);
                box_union(b.h, h);
                box_union(b.du, du);
                box_union(b.dv, dv);
            }
    } else {
        for (int k = 0; k < 4; k++) {
            uint32_t cu = 2 * bu + (k & 1), cv = 2 * bv + (k >> 1);
            if ((cu << (lv - 1)) >= gu || (cv << (lv - 1)) >= gv) continue;
            int32_t ch;
            if ((st = build_block(t, patches, lv - 1, cu, cv, &ch))) return st;
            b.child[k] = ch;
            box_union(b.h, t->blocks[ch].h);
            box_union(b.du, t->blocks[ch].du);
            box_union(b.dv, t->blocks[ch].dv);
        }
    }
    const crisp_bezier_patch *first = &patches[b.iv0 * gu + b.iu0],
                             *last = &patches[(b.iv0 + b.nv - 1) * gu + b.iu0 + b.nu - 1];
    b.u0 = first->u0, b.v0 = first->v0, b.u1 = last->u1, b.v1 = last->v1;
    t->blocks[me] = b;
    *dest = me;
    return CRISP_OK;
}

crisp_status crisp_trim_density_tree_build(const crisp_bezier_patch *patches, int grid_u,
                                           int grid_v, crisp_trim_density_tree *dest)
{
    if (!dest || grid_u < 1 || grid_v < 1 || !patches)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_density_tree_build: grid %dx%d, expected positive sizes "
                           "and patches",
                           grid_u, grid_v);
    for (int p = 0; p < grid_u * grid_v; p++) {
        const crisp_bezier_patch *bp = &patches[p];
        if (bp->du < 1 || bp->du > CRISP_MAX_DEGREE || bp->dv < 1 || bp->dv > CRISP_MAX_DEGREE ||
            !bp->cpw || !(bp->u1 > bp->u0) || !(bp->v1 > bp->v0))
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "crisp_trim_density_tree_build: patch %d: degrees (%d, %d) or "
                               "parameter box invalid, expected degrees 1..%d and a non-empty box",
                               p, bp->du, bp->dv, CRISP_MAX_DEGREE);
    }
    dest->grid_u = grid_u;
    dest->grid_v = grid_v;
    dest->max_du = dest->max_dv = 1;
    for (int p = 0; p < grid_u * grid_v; p++) {
        if (patches[p].du > dest->max_du) dest->max_du = patches[p].du;
        if (patches[p].dv > dest->max_dv) dest->max_dv = patches[p].dv;
    }
    dest->count = 0;
    dest->root = -1;
    int lv = 0;
    while ((1 << lv) < grid_u || (1 << lv) < grid_v)
        lv++;
    if (lv == 0) return CRISP_OK;
    return build_block(dest, patches, lv, 0, 0, &dest->root);
}

void crisp_trim_density_tree_free(crisp_trim_density_tree *t)
{
    if (!t) return;
    crisp_free(t->blocks);
    t->blocks = NULL;
    t->count = t->cap = 0;
    t->root = -1;
}

/* A density_ctx for desc's viewport, as crisp_trim_scan_density sets it up. */
static void test_ctx(const crisp_trim_density_desc *desc, density_ctx *c)
{
    double margin = desc->margin_px > 0.0 ? desc->margin_px : 2.0;
    *c = (density_ctx){.wx = 0.5 * desc->width,
                       .wy = 0.5 * desc->height,
                       .mx = 2.0 * margin / desc->width,
                       .my = 2.0 * margin / desc->height};
}

int crisp__trim_block_bound(const crisp_trim_density_desc *desc, const crisp_trim_density_block *b,
                            double *bv, double *bu)
{
    density_ctx c;
    test_ctx(desc, &c);
    return block_bound(&c, desc->view_proj, b, bv, bu);
}

int crisp__trim_patch_bound(const crisp_trim_density_desc *desc, const crisp_bezier_patch *p,
                            double *bv, double *bu)
{
    density_ctx c;
    test_ctx(desc, &c);
    c.du = p->du;
    c.dv = p->dv;
    c.n = (size_t)(p->du + 1) * (size_t)(p->dv + 1);
    double clip[4 * (CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1)];
    double scratch[4 * (CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1)];
    c.scratch = scratch;
    crisp_mat4 *m = desc->view_proj;
    for (size_t k = 0; k < c.n; k++)
        for (int r = 0; r < 4; r++)
            clip[r * c.n + k] = (*m)[0][r] * p->cpw[4 * k] + (*m)[1][r] * p->cpw[4 * k + 1] +
                                (*m)[2][r] * p->cpw[4 * k + 2] + (*m)[3][r] * p->cpw[4 * k + 3];
    return node_bound(&c, clip, 1.0 / (p->u1 - p->u0), 1.0 / (p->v1 - p->v0), bv, bu);
}
crisp_status crisp_trim_scan_density(const crisp_trim_density_desc *desc, double *rho_v,
                                     double *rho_u, double *vis_v, crisp_trim_density_stats *stats)
{
    if (!desc || !rho_v || !rho_u)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_trim_scan_density: NULL argument");
    if (desc->strip_count < 1 || desc->strip_count > (1 << 20))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_scan_density: strip_count %d, expected 1..1048576",
                           desc->strip_count);
    if (desc->width < 1 || desc->height < 1)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_scan_density: viewport %dx%d, expected positive sizes",
                           desc->width, desc->height);
    if (!(desc->v1 > desc->v0) || !isfinite(desc->v0) || !isfinite(desc->v1))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_scan_density: v-range [%g, %g] is empty or not finite",
                           desc->v0, desc->v1);
    if (!desc->view_proj || (desc->patch_count > 0 && !desc->patches) || desc->patch_count < 0)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_scan_density: missing view_proj or patches");
    if (desc->tree && (desc->tree->grid_u < 1 || desc->tree->grid_v < 1 ||
                       (long)desc->tree->grid_u * desc->tree->grid_v != desc->patch_count))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_scan_density: a block tree of %dx%d patches for %d patches",
                           desc->tree->grid_u, desc->tree->grid_v, desc->patch_count);
    int maxdu = 1, maxdv = 1;
    if (desc->tree) maxdu = desc->tree->max_du, maxdv = desc->tree->max_dv;
    for (int p = 0; !desc->tree && p < desc->patch_count; p++) {
        const crisp_bezier_patch *bp = &desc->patches[p];
        if (bp->du < 1 || bp->du > CRISP_MAX_DEGREE || bp->dv < 1 || bp->dv > CRISP_MAX_DEGREE ||
            !bp->cpw || !(bp->u1 > bp->u0) || !(bp->v1 > bp->v0))
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "crisp_trim_scan_density: patch %d: degrees (%d, %d) or parameter "
                               "box invalid, expected degrees 1..%d and a non-empty box",
                               p, bp->du, bp->dv, CRISP_MAX_DEGREE);
        if (bp->du > maxdu) maxdu = bp->du;
        if (bp->dv > maxdv) maxdv = bp->dv;
    }
    crisp_trim_density_stats local_stats = {0};
    if (!stats) stats = &local_stats;
    memset(stats, 0, sizeof *stats);
    for (int i = 0; i < desc->strip_count; i++) {
        rho_v[i] = rho_u[i] = 0.0;
        if (vis_v) vis_v[2 * i] = HUGE_VAL, vis_v[2 * i + 1] = -HUGE_VAL;
        if (desc->vis_u) desc->vis_u[2 * i] = HUGE_VAL, desc->vis_u[2 * i + 1] = -HUGE_VAL;
    }

    crisp_arena *arena = desc->scratch, *own = NULL;
    if (!arena) {
        crisp_status st = crisp_arena_create(0, &own);
        if (st) return st;
        arena = own;
    }
    density_ctx c = {0};
    c.max_depth = desc->max_depth > 0 ? desc->max_depth : 50;
    if (c.max_depth > 60) c.max_depth = 60;
    c.slack = desc->slack > 1.0 ? desc->slack : 2.0;
    double margin = desc->margin_px > 0.0 ? desc->margin_px : 2.0;
    c.wx = 0.5 * desc->width;
    c.wy = 0.5 * desc->height;
    c.mx = 2.0 * margin / desc->width;
    c.my = 2.0 * margin / desc->height;
    c.stats = stats;
    size_t nmax = (size_t)(maxdu + 1) * (size_t)(maxdv + 1);
    double *clip = crisp_arena_alloc(arena, 4 * nmax, sizeof(double));
    double *nodes = crisp_arena_alloc(arena, 61 * 8 * nmax, sizeof(double));
    double *root = crisp_arena_alloc(arena, 4 * nmax, sizeof(double));
    c.levels = crisp_arena_alloc(arena, (size_t)(c.max_depth + 2) * 16 * nmax, sizeof(double));
    c.scratch = crisp_arena_alloc(arena, 4 * nmax, sizeof(double));
    crisp_status st = CRISP_OK;
    if (!clip || !nodes || !root || !c.levels || !c.scratch) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_trim_scan_density: out of memory");
        goto done;
    }
    double hv = (desc->v1 - desc->v0) / desc->strip_count;
    patch_walk walk = {.desc = desc,
                       .c = &c,
                       .clip = clip,
                       .nodes = nodes,
                       .rho_v = rho_v,
                       .rho_u = rho_u,
                       .vis_v = vis_v,
                       .vis_u = desc->vis_u,
                       .hv = hv,
                       .clip_buf = clip,
                       .root_buf = root};
    if (desc->tree && desc->tree->root >= 0)
        st = walk_block(&walk, desc->tree->root);
    else
        for (int p = 0; p < desc->patch_count && !st; p++)
            st = walk_patch(&walk, p);
    if (st) goto done;
    /* Row ranges inside their strips; invisible strips keep their bounds. */
    for (int i = 0; vis_v && i < desc->strip_count; i++) {
        double nu0 = desc->v0 + (desc->v1 - desc->v0) * ((double)i / desc->strip_count);
        double nu1 = i + 1 >= desc->strip_count
                         ? desc->v1
                         : desc->v0 + (desc->v1 - desc->v0) * ((double)(i + 1) / desc->strip_count);
        double lo = fmax(vis_v[2 * i], nu0), hi = fmin(vis_v[2 * i + 1], nu1);
        if (!(hi > lo)) lo = nu0, hi = nu1;
        vis_v[2 * i] = lo;
        vis_v[2 * i + 1] = hi;
    }
done:
    if (own) crisp_arena_destroy(own);
    return st;
}
