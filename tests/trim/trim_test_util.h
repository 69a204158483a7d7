/* Helpers for the trim tests and the trim benchmark: trim shapes as homogeneous Bézier pieces
 * (polygons, circles and ellipses as rational quadratics, cubic graphs), test patches with
 * non-uniform parametrisations, a camera, and evaluation by explicit Bernstein sums (written
 * independently of the library's de Casteljau code so that the two check each other).
 */
#ifndef CRISP_TRIM_TEST_UTIL_H
#define CRISP_TRIM_TEST_UTIL_H

#include <math.h>
#include <string.h>

#include "crisp/trim.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static inline double tu_bern(int d, int i, double t)
{
    double c = 1.0;
    for (int k = 1; k <= i; k++)
        c = c * (d - i + k) / k;
    return c * pow(t, i) * pow(1.0 - t, d - i);
}

static inline double tu_bern_d(int d, int i, double t)
{
    if (d == 0) return 0.0;
    double a = i > 0 ? tu_bern(d - 1, i - 1, t) : 0.0;
    double b = i < d ? tu_bern(d - 1, i, t) : 0.0;
    return d * (a - b);
}

/* ---- trim pieces -------------------------------------------------------------------------- */

static inline void tu_line(crisp_bezier_curve *b, double u0, double v0, double u1, double v1)
{
    memset(b, 0, sizeof *b);
    b->dim = 2;
    b->degree = 1;
    b->t1 = 1.0;
    double c[6] = {u0, v0, 1, u1, v1, 1};
    memcpy(b->cpw, c, sizeof c);
}

/* Closed polygon through n points (uv pairs); returns the number of pieces written (n). */
static inline int tu_polygon(crisp_bezier_curve *b, int n, const double *uv)
{
    for (int i = 0; i < n; i++) {
        int j = (i + 1) % n;
        tu_line(&b[i], uv[2 * i], uv[2 * i + 1], uv[2 * j], uv[2 * j + 1]);
    }
    return n;
}

/* Ellipse centre (cu, cv), semi-axes a, b, rotated by angle rot, as four rational quadratic
 * quarter arcs (weights 1, sqrt(2)/2, 1). ccw = 0 reverses the direction (a hole). Returns 4. */
static inline int tu_ellipse(crisp_bezier_curve *b, double cu, double cv, double a, double bb,
                             double rot, int ccw)
{
    static const double q[9][2] = {{1, 0},   {1, 1},  {0, 1},  {-1, 1}, {-1, 0},
                                   {-1, -1}, {0, -1}, {1, -1}, {1, 0}};
    double cr = cos(rot), sr = sin(rot), w1 = sqrt(0.5);
    for (int k = 0; k < 4; k++) {
        crisp_bezier_curve *p = &b[k];
        memset(p, 0, sizeof *p);
        p->dim = 2;
        p->degree = 2;
        p->rational = 1;
        p->t1 = 1.0;
        for (int i = 0; i < 3; i++) {
            int idx = ccw ? 2 * k + i : 8 - (2 * k + i);
            double x = a * q[idx][0], y = bb * q[idx][1];
            double u = cu + cr * x - sr * y, v = cv + sr * x + cr * y;
            double w = i == 1 ? w1 : 1.0;
            p->cpw[3 * i] = w * u;
            p->cpw[3 * i + 1] = w * v;
            p->cpw[3 * i + 2] = w;
        }
    }
    return 4;
}

/* Region under the cubic graph v = g(u) for u in [ua, ub] down to v = vb: the cubic (Bernstein
 * coefficients g[4] of g on [ua, ub], with non-uniformly spaced u control values) and three
 * lines. Returns 4. */
static inline int tu_cubic_graph(crisp_bezier_curve *b, double ua, double ub, const double g[4],
                                 double vb)
{
    crisp_bezier_curve *c = &b[0];
    memset(c, 0, sizeof *c);
    c->dim = 2;
    c->degree = 3;
    c->t1 = 1.0;
    /* u(t) = ua + (ub - ua) (0.6 t + 0.4 t^2): monotone, not uniform; Bernstein (0, .2, .533.., 1)
     */
    double uc[4] = {0.0, 0.2, 1.6 / 3.0, 1.0};
    for (int i = 0; i < 4; i++) {
        c->cpw[3 * i] = ua + (ub - ua) * uc[i];
        c->cpw[3 * i + 1] = g[i];
        c->cpw[3 * i + 2] = 1.0;
    }
    /* back along the bottom: (ub, g3) -> (ub, vb) -> (ua, vb) -> (ua, g0) */
    tu_line(&b[1], ub, g[3], ub, vb);
    tu_line(&b[2], ub, vb, ua, vb);
    tu_line(&b[3], ua, vb, ua, g[0]);
    return 4;
}

/* ---- patches ------------------------------------------------------------------------------- */

/* A patch of degrees (du, dv) over [0, 1]^2 whose control points (homogeneous, u fastest) live in
 * caller storage. */
static inline void tu_patch_init(crisp_bezier_patch *p, int du, int dv, double *cpw)
{
    memset(p, 0, sizeof *p);
    p->du = du;
    p->dv = dv;
    p->u1 = p->v1 = 1.0;
    p->cpw = cpw;
}

static inline void tu_set(crisp_bezier_patch *p, int i, int j, double x, double y, double z,
                          double w)
{
    double *h = p->cpw + 4 * (j * (p->du + 1) + i);
    h[0] = w * x;
    h[1] = w * y;
    h[2] = w * z;
    h[3] = w;
    if (w != 1.0) p->rational = 1;
}

/* kind 0: planar (z = 0), rational biquadratic with non-uniform weights and spacing, image the
 * square [0, 2] x [0, 2]; kind 1: bilinear saddle; kind 2: curved bicubic height field with
 * non-uniform spacing. cpw: at least 64 doubles. */
static inline void tu_patch_kind(crisp_bezier_patch *p, int kind, double *cpw)
{
    if (kind == 0) {
        tu_patch_init(p, 2, 2, cpw);
        const double xs[3] = {0.0, 0.3, 2.0}, ys[3] = {0.0, 1.5, 2.0};
        const double wu[3] = {1.0, 2.0, 1.0}, wv[3] = {1.0, 0.6, 1.0};
        for (int j = 0; j < 3; j++)
            for (int i = 0; i < 3; i++)
                tu_set(p, i, j, xs[i], ys[j], 0.0, wu[i] * wv[j]);
    } else if (kind == 1) {
        tu_patch_init(p, 1, 1, cpw);
        tu_set(p, 0, 0, 0.0, 0.0, 0.0, 1.0);
        tu_set(p, 1, 0, 2.0, 0.0, 0.4, 1.0);
        tu_set(p, 0, 1, 0.0, 2.0, -0.3, 1.0);
        tu_set(p, 1, 1, 2.0, 2.0, 0.5, 1.0);
    } else {
        tu_patch_init(p, 3, 3, cpw);
        const double xs[4] = {0.0, 0.2, 0.9, 2.0}, ys[4] = {0.0, 0.8, 1.4, 2.0};
        const double zs[4][4] = {
            {0.0, 0.1, 0.2, 0.0}, {0.1, 0.5, 0.3, 0.1}, {0.0, 0.2, 0.6, 0.2}, {0.1, 0.0, 0.2, 0.3}};
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++)
                tu_set(p, i, j, xs[i], ys[j], zs[j][i], 1.0);
    }
}

/* Homogeneous point and its partials in (s, t) by explicit Bernstein sums: h, hs, ht: 4 each. */
static inline void tu_patch_eval_h(const crisp_bezier_patch *p, double s, double t, double h[4],
                                   double hs[4], double ht[4])
{
    for (int c = 0; c < 4; c++)
        h[c] = hs[c] = ht[c] = 0.0;
    for (int j = 0; j <= p->dv; j++) {
        double bv = tu_bern(p->dv, j, t), dbv = tu_bern_d(p->dv, j, t);
        for (int i = 0; i <= p->du; i++) {
            double bu = tu_bern(p->du, i, s), dbu = tu_bern_d(p->du, i, s);
            const double *cp = p->cpw + 4 * (j * (p->du + 1) + i);
            for (int c = 0; c < 4; c++) {
                h[c] += bu * bv * cp[c];
                hs[c] += dbu * bv * cp[c];
                ht[c] += bu * dbv * cp[c];
            }
        }
    }
}

/* Screen position and its partials for the patch point (s, t) (global = local here: [0,1]^2).
 * Returns clip W; *visible = inside the frustum (near/far and the image rectangle) */
static inline double tu_screen(const crisp_bezier_patch *p, crisp_mat4 vp, int width, int height,
                               double s, double t, double xy[2], double ds[2], double dt[2],
                               int *visible)
{
    double h[4], hs[4], ht[4];
    tu_patch_eval_h(p, s, t, h, hs, ht);
    double c[4], cs[4], ct[4];
    for (int r = 0; r < 4; r++) {
        c[r] = cs[r] = ct[r] = 0.0;
        for (int k = 0; k < 4; k++) {
            c[r] += vp[k][r] * h[k];
            cs[r] += vp[k][r] * hs[k];
            ct[r] += vp[k][r] * ht[k];
        }
    }
    double W = c[3];
    double sx = 0.5 * width, sy = -0.5 * height;
    xy[0] = (c[0] / W + 1.0) * sx;
    xy[1] = (c[1] / W - 1.0) * sy;
    ds[0] = sx * (cs[0] * W - c[0] * cs[3]) / (W * W);
    ds[1] = sy * (cs[1] * W - c[1] * cs[3]) / (W * W);
    dt[0] = sx * (ct[0] * W - c[0] * ct[3]) / (W * W);
    dt[1] = sy * (ct[1] * W - c[1] * ct[3]) / (W * W);
    if (visible)
        *visible = W > 0.0 && c[2] >= -W && c[2] <= W && xy[0] >= 0 && xy[0] <= width &&
                   xy[1] >= 0 && xy[1] <= height;
    return W;
}

/* A camera: view-projection from eye, target, fovy (degrees), near, far; up = +z unless the view
 * is vertical, then +y. */
static inline void tu_camera(const double eye[3], const double target[3], double fovy, double znear,
                             double zfar, int width, int height, crisp_mat4 vp)
{
    double f[3] = {target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]};
    double n = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    double up[3] = {0, 0, 1};
    if (fabs(f[2]) > 0.99 * n) {
        up[1] = 1;
        up[2] = 0;
    }
    crisp_mat4 view, proj;
    crisp_mat4_lookat(eye, target, up, view);
    crisp_mat4_perspective(fovy, (double)width / height, znear, zfar, proj);
    crisp_mat4_mul(proj, view, vp);
}

#endif
