/* Integral properties of trimmed-NURBS B-rep models: the divergence theorem over the faces, and
 * on each face Green's theorem over its trim loops, so the trimmed domain is integrated exactly
 * (as in the "u-intercept" view of the domain: every point between the loop and the line u = u0
 * counts with the loop's orientation).
 *
 * Volume integrals become surface integrals of vector fields whose divergence is the integrand:
 *   V = 1/3 (p . n), M_x = 1/2 x^2 n_x, S_xx = 1/3 x^3 n_x, S_xy = 1/2 x^2 y n_x (and cyclic),
 * each integrated over the faces with n dA = +-(S_u x S_v) du dv. On a face, with g(u, v) one of
 * these integrands, G(u, v) = integral of g(s, v) ds from the domain's u0 to u, and the loops
 * oriented (outer counter-clockwise, holes clockwise): integral over the trimmed domain of g =
 * loop integral of G dv. G: Gauss-Legendre (20 points, and 14 for the error estimate) on each knot
 * span of [u0, u]; the loop integral: adaptive Gauss-Legendre (24 against 16 points) on the
 * Bezier pieces of the trim curves. Coordinates are taken about the model's box centre. */
#include "crisp/mass.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NQ                                                                                         \
    CRISP_MASS_SUMS /* area, vector area (3), V, Mx My Mz, Sxx Syy Szz, Sxy Syz Sxz, Vx Vy         \
                     */
#define MAXG 24
#define MAX_DEPTH 18

typedef struct gauss {
    int n;
    double x[MAXG], w[MAXG]; /* on [0, 1] */
} gauss;

static void gauss_make(int n, gauss *g)
{
    g->n = n;
    for (int i = 0; i < n; i++) {
        double x = cos(3.14159265358979323846 * (i + 0.75) / (n + 0.5)), dp = 1;
        for (int it = 0; it < 100; it++) {
            double p0 = 1, p1 = x;
            for (int k = 2; k <= n; k++) {
                double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
                p0 = p1, p1 = p2;
            }
            dp = n * (x * p1 - p0) / (x * x - 1);
            double dx = p1 / dp;
            x -= dx;
            if (fabs(dx) < 1e-16) break;
        }
        g->x[i] = 0.5 * (1 - x);
        g->w[i] = 1 / ((1 - x * x) * dp * dp);
    }
}

typedef struct ctx {
    const crisp_face *f;
    double ref[3];
    double sign;
    double u0;
    const double *ku; /* distinct interior knots in u */
    int nku;
    gauss gi, gi2, go, go2;
    double scale[NQ];
    double tol;
    size_t evals;
    double err_outer[NQ];
} ctx;

static void integrand(ctx *c, double u, double v, double *q)
{
    double p[3], su[3], sv[3];
    crisp_surface_derivs(c->f->surface, u, v, p, su, sv, NULL, NULL, NULL);
    c->evals++;
    double n[3] = {su[1] * sv[2] - su[2] * sv[1], su[2] * sv[0] - su[0] * sv[2],
                   su[0] * sv[1] - su[1] * sv[0]};
    for (int a = 0; a < 3; a++)
        n[a] *= c->sign, p[a] -= c->ref[a];
    double x = p[0], y = p[1], z = p[2];
    q[0] = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    q[1] = n[0], q[2] = n[1], q[3] = n[2];
    q[4] = (x * n[0] + y * n[1] + z * n[2]) / 3;
    q[5] = x * x * n[0] / 2, q[6] = y * y * n[1] / 2, q[7] = z * z * n[2] / 2;
    q[8] = x * x * x * n[0] / 3, q[9] = y * y * y * n[1] / 3, q[10] = z * z * z * n[2] / 3;
    q[11] = x * x * y * n[0] / 2, q[12] = y * y * z * n[1] / 2, q[13] = z * z * x * n[2] / 2;
    q[14] = x * n[0], q[15] = y * n[1]; /* the volume by x and by y alone (closure test) */
}

/* G(u, v) with the rules gi (into G) and gi2 (into G2) */
static void inner(ctx *c, double u, double v, double *G, double *G2)
{
    memset(G, 0, NQ * sizeof *G);
    memset(G2, 0, NQ * sizeof *G2);
    double lo = c->u0, hi = u, sgn = 1;
    if (hi < lo) lo = u, hi = c->u0, sgn = -1;
    double a = lo;
    for (int k = 0; k <= c->nku; k++) {
        double b = k < c->nku ? c->ku[k] : hi;
        if (b <= a) continue;
        if (b > hi) b = hi;
        const gauss *rules[2] = {&c->gi, &c->gi2};
        double *dst[2] = {G, G2};
        for (int r = 0; r < 2; r++)
            for (int i = 0; i < rules[r]->n; i++) {
                double q[NQ];
                integrand(c, a + (b - a) * rules[r]->x[i], v, q);
                double w = sgn * (b - a) * rules[r]->w[i];
                for (int j = 0; j < NQ; j++)
                    dst[r][j] += w * q[j];
            }
        a = b;
        if (a >= hi) break;
    }
}

/* a boundary piece: a Bezier trim piece, or a straight segment of the domain rectangle */
typedef struct piece {
    const crisp_bezier_curve *b;
    double p0[2], p1[2];
} piece;

static void piece_eval(const piece *p, double t, double uv[2], double d[2])
{
    if (p->b) {
        double r[4];
        crisp_bezier_curve_derivs(p->b, t, 1, r);
        uv[0] = r[0], uv[1] = r[1], d[0] = r[2], d[1] = r[3];
    } else {
        for (int a = 0; a < 2; a++)
            uv[a] = p->p0[a] + t * (p->p1[a] - p->p0[a]), d[a] = p->p1[a] - p->p0[a];
    }
}

/* Rule g over [a, b] of G dv (into I) and G2 dv (into I2). */
static void outer_rule(ctx *c, const piece *p, const gauss *g, double a, double b, double *I,
                       double *I2)
{
    memset(I, 0, NQ * sizeof *I);
    memset(I2, 0, NQ * sizeof *I2);
    for (int i = 0; i < g->n; i++) {
        double uv[2], d[2], G[NQ], G2[NQ];
        piece_eval(p, a + (b - a) * g->x[i], uv, d);
        if (d[1] == 0) continue;
        inner(c, uv[0], uv[1], G, G2);
        double w = (b - a) * g->w[i] * d[1];
        for (int j = 0; j < NQ; j++)
            I[j] += w * G[j], I2[j] += w * G2[j];
    }
}

static void outer(ctx *c, const piece *p, double a, double b, int depth, double *sum, double *sum2)
{
    double I[NQ], I2[NQ], J[NQ], J2[NQ];
    outer_rule(c, p, &c->go, a, b, I, I2);
    outer_rule(c, p, &c->go2, a, b, J, J2);
    int ok = 1;
    for (int j = 0; j < NQ && ok; j++)
        ok = fabs(I[j] - J[j]) <= c->tol * c->scale[j] * (b - a);
    if (ok || depth >= MAX_DEPTH) {
        for (int j = 0; j < NQ; j++) {
            sum[j] += I[j], sum2[j] += I2[j];
            c->err_outer[j] += fabs(I[j] - J[j]);
        }
        return;
    }
    double m = 0.5 * (a + b);
    outer(c, p, a, m, depth + 1, sum, sum2);
    outer(c, p, m, b, depth + 1, sum, sum2);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

crisp_status crisp_mass_model(const crisp_model *m, const crisp_mass_desc *desc,
                              crisp_mass_props *dest)
{
    if (!m || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_mass_model: NULL argument");
    memset(dest, 0, sizeof *dest);
    if (m->face_count < 1)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_mass_model: the model has no face");
    ctx c = {0};
    gauss_make(20, &c.gi);
    gauss_make(14, &c.gi2);
    gauss_make(24, &c.go);
    gauss_make(16, &c.go2);
    c.tol = desc && desc->tolerance > 0 ? desc->tolerance : 1e-13;
    double box[6];
    crisp_model_bbox(m, box);
    double L = 0;
    for (int a = 0; a < 3; a++) {
        c.ref[a] = 0.5 * (box[a] + box[3 + a]);
        L = fmax(L, box[3 + a] - box[a]);
    }
    if (!(L > 0) || !isfinite(L))
        return crisp_error(CRISP_ERR_NUMERIC,
                           "crisp_mass_model: the model's box is empty or not finite");
    static const int power[NQ] = {2, 2, 2, 2, 3, 4, 4, 4, 5, 5, 5, 5, 5, 5, 3, 3};
    for (int j = 0; j < NQ; j++)
        c.scale[j] = pow(L, power[j]);
    double T[NQ] = {0}, T2[NQ] = {0};
    crisp_status s = CRISP_OK;
    int f0 = desc ? desc->face_begin : 0, f1 = desc ? desc->face_end : 0;
    if (!f0 && !f1) f1 = m->face_count;
    if (f0 < 0 || f1 > m->face_count || f0 >= f1)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_mass_model: faces [%d, %d) of a model of %d faces", f0, f1,
                           m->face_count);
    for (int fi = f0; fi < f1; fi++) {
        const crisp_face *f = &m->faces[fi];
        const crisp_surface *S = f->surface;
        double dom[4];
        crisp_surface_domain(S, dom);
        c.f = f;
        c.sign = f->reversed ? -1 : 1;
        c.u0 = dom[0];
        /* distinct interior knots of u */
        int nk = S->count_u + S->degree_u + 1, n = 0;
        double *ku = crisp_malloc_array((size_t)nk, sizeof *ku);
        if (!ku) return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_mass_model: out of memory");
        for (int k = 0; k < nk; k++)
            if (S->knots_u[k] > dom[0] && S->knots_u[k] < dom[1]) ku[n++] = S->knots_u[k];
        qsort(ku, (size_t)n, sizeof *ku, cmp_double);
        int w = 0;
        for (int k = 0; k < n; k++)
            if (!w || ku[k] != ku[w - 1]) ku[w++] = ku[k];
        c.ku = ku, c.nku = w;
        if (f->loop_count == 0) {
            const double corner[5][2] = {{dom[0], dom[2]},
                                         {dom[1], dom[2]},
                                         {dom[1], dom[3]},
                                         {dom[0], dom[3]},
                                         {dom[0], dom[2]}};
            for (int e = 0; e < 4; e++) {
                piece p = {.b = NULL,
                           .p0 = {corner[e][0], corner[e][1]},
                           .p1 = {corner[e + 1][0], corner[e + 1][1]}};
                outer(&c, &p, 0, 1, 0, T, T2);
            }
        }
        for (int l = 0; l < f->loop_count && !s; l++) {
            const crisp_trim_loop *loop = &f->loops[l];
            for (int k = 0; k < loop->curve_count && !s; k++) {
                crisp_bezier_curve *bz = NULL;
                int cnt = 0;
                s = crisp_curve_to_bezier(loop->curves[k], &bz, &cnt);
                if (s) {
                    crisp_error_prefix("face %d (source %d) loop %d curve %d", fi, f->source_id, l,
                                       k);
                    break;
                }
                for (int q = 0; q < cnt; q++) {
                    piece p = {.b = &bz[q]};
                    outer(&c, &p, 0, 1, 0, T, T2);
                }
                crisp_free(bz);
            }
        }
        crisp_free(ku);
        if (s) return s;
    }
    for (int j = 0; j < NQ; j++) {
        dest->sums[j] = T[j];
        dest->sums_err[j] = c.err_outer[j] + fabs(T[j] - T2[j]);
    }
    memcpy(dest->ref, c.ref, sizeof dest->ref);
    dest->size = L;
    crisp_mass_props_finish(dest);
    dest->evaluations = c.evals;
    return CRISP_OK;
}

void crisp_mass_props_finish(crisp_mass_props *p)
{
    const double *T = p->sums, *err = p->sums_err, L = p->size;
    p->area = T[0];
    for (int a = 0; a < 3; a++)
        p->vector_area[a] = T[1 + a];
    p->area_err = err[0];
    double va = sqrt(T[1] * T[1] + T[2] * T[2] + T[3] * T[3]);
    /* Closed: the vector area vanishes (the integral of n), and so does the traceless part of
     * the integral of x_i n_i: by the divergence theorem each of the integrals of x n_x, y n_y
     * and z n_z over a closed, outward shell is its volume. A tube without its ends has no vector
     * area but misses the volume along its axis. (A closed shell turned inside out stays closed,
     * with a negative volume.) */
    p->axis_volume[0] = T[14], p->axis_volume[1] = T[15];
    p->axis_volume[2] = 3 * T[4] - T[14] - T[15];
    double spread = 0;
    for (int a = 0; a < 3; a++)
        spread = fmax(spread, fabs(p->axis_volume[a] - T[4]));
    p->closed = va <= 1e-7 * T[0] && spread <= 1e-7 * T[0] * L;
    p->volume = p->volume_err = p->inertia_err = 0;
    memset(p->centroid, 0, sizeof p->centroid);
    memset(p->inertia, 0, sizeof p->inertia);
    if (!p->closed) return;
    double V = T[4];
    p->volume = V;
    /* the quadrature's error, and the shell's closure gap (trims that do not quite meet make the
     * axis volumes differ: the volume is no better known than that) */
    p->volume_err = err[4] + spread;
    double M[3] = {T[5], T[6], T[7]};
    for (int a = 0; a < 3; a++)
        p->centroid[a] = p->ref[a] + M[a] / V;
    p->inertia[0] = T[9] + T[10] - (M[1] * M[1] + M[2] * M[2]) / V;
    p->inertia[1] = T[8] + T[10] - (M[0] * M[0] + M[2] * M[2]) / V;
    p->inertia[2] = T[8] + T[9] - (M[0] * M[0] + M[1] * M[1]) / V;
    p->inertia[3] = -(T[11] - M[0] * M[1] / V);
    p->inertia[4] = -(T[12] - M[1] * M[2] / V);
    p->inertia[5] = -(T[13] - M[0] * M[2] / V);
    double ie = 0;
    for (int j = 8; j < 14; j++)
        ie = fmax(ie, err[j]);
    p->inertia_err = 2 * ie;
}
