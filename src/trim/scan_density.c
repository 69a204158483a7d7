/* The v-scan (and u-scan) density bound of Wu & Peters 2015 (eqs. 6-8), computed for the current
 * frame as a guaranteed upper bound instead of being read back from the previous frame.
 *
 * In clip space the face's homogeneous patch is four polynomial patches X, Y, Z, W, and
 * x~ = w_x X / W + c_x, so x~_v = w_x (X_v W - X W_v) / W^2. The numerator is a polynomial patch of
 * degree (2du, 2dv - 1) whose Bernstein coefficients come from products of Bernstein forms; by the
 * convex hull property |numerator| <= its largest |coefficient| and W >= its smallest coefficient.
 * The bound of the Euclidean screen speed sqrt(x~_v^2 + y~_v^2) is
 *   sqrt((w_x max|N_x|)^2 + (w_y max|N_y|)^2) / min(W)^2.
 * Sub-patches whose coefficients put them wholly outside one plane of the (slightly widened)
 * frustum are dropped; where min(W) is not positive or the bound is well above the values sampled
 * on the sub-patch, it is split 2x2 and examined again (DESIGN.md section 5).
 */
#include "trim_internal.h"

#include <math.h>
#include <string.h>

#define MIN_PIECE (1.0 / 16.0)

typedef struct density_ctx {
    int du, dv;
    size_t n;       /* (du + 1) * (dv + 1) coefficients per plane */
    double wx, wy;  /* pixels per NDC unit: width / 2, height / 2 */
    double mx, my;  /* widened frustum: |X| <= (1 + mx) W */
    double floor_v; /* a v-bound below this gives mu = 1 anyway */
    double slack;
    int max_depth;
    double *levels;  /* (max_depth + 1) * 4 children * 4 planes * n */
    double *scratch; /* derivative and product work space */
    double cur_v, cur_u;
    double vis_lo, vis_hi; /* v-range of the sub-patches kept */
    double ulo, uhi;       /* the strip's u-range of interest (desc->strip_u), else infinite */
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
           outside_plane(Y, W, c->n, 1.0 + c->my, 1.0) || outside_plane(Z, W, c->n, 1.0, 1.0) ||
           outside_plane(Z, W, c->n, 1.0, -1.0);
}

/* Derivative coefficients in v (dir 1: degrees (du, dv - 1)) or u (dir 0: (du - 1, dv)). */
static void derivative(const double *c, int du, int dv, int dir, double *dest)
{
    if (dir) {
        for (int j = 0; j < dv; j++)
            for (int i = 0; i <= du; i++)
                dest[j * (du + 1) + i] = dv * (c[(j + 1) * (du + 1) + i] - c[j * (du + 1) + i]);
    } else {
        for (int j = 0; j <= dv; j++)
            for (int i = 0; i < du; i++)
                dest[j * du + i] = du * (c[j * (du + 1) + i + 1] - c[j * (du + 1) + i]);
    }
}

/* Bernstein coefficients of the numerator P_dir W - P W_dir (degree (2du, 2dv - 1) for dir 1,
 * (2du - 1, 2dv) for dir 0), degree-elevated by one in dir to the degree (2du, 2dv) of W^2. */
static void numerator(density_ctx *c, const double *P, const double *W, int dir, double *dest)
{
    int du = c->du, dv = c->dv;
    int ddu = dir ? du : du - 1, ddv = dir ? dv - 1 : dv;
    double *Pd = c->scratch, *Wd = Pd + c->n;
    double *p1 = Wd + c->n;
    int m = du + ddu, n = dv + ddv; /* numerator degrees */
    size_t pn = (size_t)(m + 1) * (size_t)(n + 1);
    double *p2 = p1 + pn;
    derivative(P, du, dv, dir, Pd);
    derivative(W, du, dv, dir, Wd);
    crisp__trim_product2(Pd, ddu, ddv, W, du, dv, p1);
    crisp__trim_product2(P, du, dv, Wd, ddu, ddv, p2);
    for (size_t k = 0; k < pn; k++)
        p1[k] -= p2[k];
    /* Elevate: c'_k = k/(d+1) c_{k-1} + (1 - k/(d+1)) c_k along dir. */
    int M = 2 * du, N = 2 * dv;
    for (int j = 0; j <= N; j++)
        for (int i = 0; i <= M; i++) {
            double v;
            if (dir) {
                double lo = j > 0 ? p1[(j - 1) * (m + 1) + i] : 0.0;
                double hi = j < N ? p1[j * (m + 1) + i] : 0.0;
                v = (double)j / N * lo + (1.0 - (double)j / N) * hi;
            } else {
                double lo = i > 0 ? p1[j * (m + 1) + i - 1] : 0.0;
                double hi = i < M ? p1[j * (m + 1) + i] : 0.0;
                v = (double)i / M * lo + (1.0 - (double)i / M) * hi;
            }
            dest[j * (M + 1) + i] = v;
        }
}

/* With W > 0, W^2 = sum w_k B_k has w_k > 0, and for the vector numerator (N_x, N_y) = sum n_k B_k
 * the triangle inequality gives |(N_x, N_y)| <= sum |n_k| B_k <= max_k (|n_k| / w_k) W^2: a bound
 * of the screen speed by coefficient ratios, much tighter than max|n| / min(W)^2 where W varies. */
static double speed_bound(density_ctx *c, const double *X, const double *Y, const double *W,
                          const double *w2, int dir)
{
    int M = 2 * c->du, N = 2 * c->dv;
    size_t pn = (size_t)(M + 1) * (size_t)(N + 1);
    double *nx = c->scratch + 2 * c->n + 2 * pn, *ny = nx + pn;
    numerator(c, X, W, dir, nx);
    numerator(c, Y, W, dir, ny);
    double b2 = 0.0, wx2 = c->wx * c->wx, wy2 = c->wy * c->wy;
    for (size_t k = 0; k < pn; k++)
        b2 = fmax(b2, (wx2 * nx[k] * nx[k] + wy2 * ny[k] * ny[k]) / (w2[k] * w2[k]));
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
                         double ub, double *ev, double *eu)
{
    int seen = 0;
    *ev = *eu = 0.0;
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
            fabs(Z[0]) > W[0])
            continue;
        seen++;
        double w2 = W[0] * W[0];
        double xu = c->wx * (X[1] * W[0] - X[0] * W[1]) / w2;
        double yu = c->wy * (Y[1] * W[0] - Y[0] * W[1]) / w2;
        double xv = c->wx * (X[2] * W[0] - X[0] * W[2]) / w2;
        double yv = c->wy * (Y[2] * W[0] - Y[0] * W[2]) / w2;
        *eu = fmax(*eu, sqrt(xu * xu + yu * yu) * su);
        *ev = fmax(*ev, sqrt(xv * xv + yv * yv) * sv);
    }
    return seen;
}

static void split_half(const density_ctx *c, const double *s, double *kids)
{
    int du = c->du, dv = c->dv;
    size_t block = 4 * c->n;
    double lo[CRISP_MAX_DEGREE + 1], hi[CRISP_MAX_DEGREE + 1];
    for (int q = 0; q < 4; q++) {
        const double *src = s + q * c->n;
        double *k0 = kids + q * c->n, *k1 = kids + block + q * c->n;
        for (int j = 0; j <= dv; j++) {
            crisp__trim_split(src + j * (du + 1), du, 1, 0.5, lo, hi);
            memcpy(k0 + j * (du + 1), lo, sizeof(double) * (size_t)(du + 1));
            memcpy(k1 + j * (du + 1), hi, sizeof(double) * (size_t)(du + 1));
        }
        /* Now split each u-half in v into the lower (kid 0, 1) and upper (kid 2, 3) halves. */
        double *k2 = kids + 2 * block + q * c->n, *k3 = kids + 3 * block + q * c->n;
        for (int i = 0; i <= du; i++) {
            crisp__trim_split(k0 + i, dv, du + 1, 0.5, lo, hi);
            for (int j = 0; j <= dv; j++) {
                k0[j * (du + 1) + i] = lo[j];
                k2[j * (du + 1) + i] = hi[j];
            }
            crisp__trim_split(k1 + i, dv, du + 1, 0.5, lo, hi);
            for (int j = 0; j <= dv; j++) {
                k1[j * (du + 1) + i] = lo[j];
                k3[j * (du + 1) + i] = hi[j];
            }
        }
    }
}

/* s: the sub-patch (4 planes) over [ua, ub] x [va, vb] of the face's parameters; su, sv:
 * d(local)/d(global) scale factors. */
static void refine(density_ctx *c, const double *s, int depth, double su, double sv, double ua,
                   double ub, double va, double vb)
{
    if (c->stats) c->stats->subpatches++;
    c->budget--;
    if (ub < c->ulo || ua > c->uhi || culled(c, s)) {
        if (c->stats) c->stats->culled++;
        return;
    }
    const double *X = s, *Y = s + c->n, *W = s + 3 * c->n;
    double wmin = HUGE_VAL;
    for (size_t k = 0; k < c->n; k++)
        wmin = fmin(wmin, W[k]);
    int last = depth >= c->max_depth || c->budget <= 0;
    if (wmin > 0.0) {
        size_t pn = (size_t)(2 * c->du + 1) * (size_t)(2 * c->dv + 1);
        double *w2 = c->scratch + 2 * c->n + 4 * pn;
        crisp__trim_product2(W, c->du, c->dv, W, c->du, c->dv, w2);
        double bv = sv * speed_bound(c, X, Y, W, w2, 1);
        double bu = su * speed_bound(c, X, Y, W, w2, 0);
        /* Rounding in the products is relative ~1e-15; widen so the bound stays an upper bound. */
        bv *= 1.0 + 1e-9;
        bu *= 1.0 + 1e-9;
        int accept = last;
        if (!accept) {
            double ev, eu;
            int seen = sample_speeds(c, s, sv, su, ua, ub, &ev, &eu);
            int ok_v = bv <= fmax(fmax(c->slack * ev, c->cur_v), c->floor_v);
            int ok_u = bu <= fmax(c->slack * eu, c->cur_u);
            accept = seen > 0 && ok_v && ok_u;
            /* Nothing to gain: the bound is already covered by what other parts need. */
            if (bv <= fmax(c->cur_v, c->floor_v) && bu <= c->cur_u) accept = 1;
            /* Not while the sub-patch's v-range would take more scan lines than a screen can
             * show (16 (w + h)): at extreme zoom it is mostly off screen, and refining shrinks
             * the visible v-range (a face zoomed to fov 1e-7 deg otherwise took 2^22 rows). */
            if ((vb - va) * bv > 32.0 * (c->wx + c->wy)) accept = 0;
        }
        if (accept) {
            c->vis_lo = fmin(c->vis_lo, va);
            c->vis_hi = fmax(c->vis_hi, vb);
            c->cur_v = fmax(c->cur_v, bv);
            c->cur_u = fmax(c->cur_u, bu);
            c->visible = 1;
            return;
        }
    } else if (last) {
        c->vis_lo = fmin(c->vis_lo, va);
        c->vis_hi = fmax(c->vis_hi, vb);
        c->unbounded = 1;
        c->visible = 1;
        return;
    }
    double *kids = c->levels + (size_t)(depth + 1) * 16 * c->n;
    split_half(c, s, kids);
    double um = 0.5 * (ua + ub), vm = 0.5 * (va + vb);
    for (int k = 0; k < 4; k++)
        refine(c, kids + (size_t)k * 4 * c->n, depth + 1, 2 * su, 2 * sv, k & 1 ? um : ua,
               k & 1 ? ub : um, k < 2 ? va : vm, k < 2 ? vm : vb);
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
    int maxdu = 1, maxdv = 1;
    for (int p = 0; p < desc->patch_count; p++) {
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
    size_t pmax = (size_t)(2 * maxdu + 1) * (size_t)(2 * maxdv + 1);
    double *clip = crisp_arena_alloc(arena, 4 * nmax, sizeof(double));
    double *strip = crisp_arena_alloc(arena, 4 * nmax, sizeof(double));
    c.levels = crisp_arena_alloc(arena, (size_t)(c.max_depth + 2) * 16 * nmax, sizeof(double));
    c.scratch = crisp_arena_alloc(arena, 2 * nmax + 5 * pmax, sizeof(double));
    crisp_status st = CRISP_OK;
    if (!clip || !strip || !c.levels || !c.scratch) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_trim_scan_density: out of memory");
        goto done;
    }
    double hv = (desc->v1 - desc->v0) / desc->strip_count;
    crisp_mat4 *m = desc->view_proj;
    for (int p = 0; p < desc->patch_count; p++) {
        const crisp_bezier_patch *bp = &desc->patches[p];
        c.du = bp->du;
        c.dv = bp->dv;
        c.n = (size_t)(bp->du + 1) * (size_t)(bp->dv + 1);
        for (size_t k = 0; k < c.n; k++) {
            const double *h = bp->cpw + 4 * k;
            for (int r = 0; r < 4; r++)
                clip[r * c.n + k] =
                    (*m)[0][r] * h[0] + (*m)[1][r] * h[1] + (*m)[2][r] * h[2] + (*m)[3][r] * h[3];
            for (int r = 0; r < 4; r++)
                if (!isfinite(clip[r * c.n + k])) {
                    st = crisp_error(CRISP_ERR_NUMERIC,
                                     "crisp_trim_scan_density: patch %d control point %zu is not "
                                     "finite in clip space",
                                     p, k);
                    goto done;
                }
        }
        int i0 = (int)floor((bp->v0 - desc->v0) / hv), i1 = (int)floor((bp->v1 - desc->v0) / hv);
        if (i0 < 0) i0 = 0;
        if (i1 > desc->strip_count - 1) i1 = desc->strip_count - 1;
        for (int i = i0; i <= i1; i++) {
            double nu0 = desc->v0 + i * hv, nu1 = desc->v0 + (i + 1) * hv;
            double ta = (nu0 - bp->v0) / (bp->v1 - bp->v0), tb = (nu1 - bp->v0) / (bp->v1 - bp->v0);
            if (ta < 0.0) ta = 0.0;
            if (tb > 1.0) tb = 1.0;
            if (!(tb > ta)) continue;
            /* A sliver of the patch (a strip boundary a rounding error away from the patch's)
             * restricted on its own would have derivative coefficients made of cancellation
             * noise divided by its tiny width: bound a piece of at least MIN_PIECE of the patch
             * around it instead (a bound over more of the surface is still a bound; the row
             * range is cut back to the strip below). */
            if (tb - ta < MIN_PIECE) {
                if (ta + MIN_PIECE <= 1.0)
                    tb = ta + MIN_PIECE;
                else
                    ta = 1.0 - MIN_PIECE, tb = 1.0;
            }
            memcpy(strip, clip, sizeof(double) * 4 * c.n);
            for (int q = 0; q < 4; q++)
                for (int col = 0; col <= c.du; col++)
                    crisp__trim_restrict(strip + q * c.n + col, c.dv, c.du + 1, ta, tb);
            c.cur_v = rho_v[i];
            c.cur_u = rho_u[i];
            c.visible = rho_v[i] > 0.0 || rho_u[i] > 0.0;
            c.unbounded = 0;
            c.vis_lo = vis_v ? vis_v[2 * i] : 0.0;
            c.vis_hi = vis_v ? vis_v[2 * i + 1] : 0.0;
            c.floor_v = 1.0 / hv;
            c.budget = 16384; /* deep refinement at extreme zoom (fov 1e-7 deg) needs ~5000 */
            c.ulo = desc->strip_u ? desc->strip_u[2 * i] : -HUGE_VAL;
            c.uhi = desc->strip_u ? desc->strip_u[2 * i + 1] : HUGE_VAL;
            /* The strip's levels start at level 0 of c.levels; refine copies children deeper. */
            double *root = c.levels;
            memcpy(root, strip, sizeof(double) * 4 * c.n);
            refine(&c, root, 0, 1.0 / (bp->u1 - bp->u0), 1.0 / ((bp->v1 - bp->v0) * (tb - ta)),
                   bp->u0, bp->u1, bp->v0 + (bp->v1 - bp->v0) * ta,
                   bp->v0 + (bp->v1 - bp->v0) * tb);
            if (vis_v) vis_v[2 * i] = c.vis_lo, vis_v[2 * i + 1] = c.vis_hi;
            if (c.unbounded) {
                rho_v[i] = rho_u[i] = HUGE_VAL;
                stats->unbounded++;
            } else if (c.visible) {
                rho_v[i] = c.cur_v;
                rho_u[i] = c.cur_u;
                /* A visible strip always needs a row, even if the surface is edge-on in v. */
                if (!(rho_v[i] > 0.0)) rho_v[i] = 1e-300;
                if (!(rho_u[i] > 0.0)) rho_u[i] = 1e-300;
            }
        }
    }
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
