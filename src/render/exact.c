/* The exact reference renderer: one ray per pixel centre against the true rational Bézier
 * patches, and the trim decision on the true curves (through a classify callback). Slow is
 * fine; wrong is not.
 *
 * Ray-patch intersection (Nishita-style subdivision): the ray is the intersection of two planes
 * n1 . (P - o) = 0 and n2 . (P - o) = 0. Multiplied through by the weight, both are polynomial
 * patches with Bézier coefficients n_k . (wP) - w (n_k . o), so a sub-patch can hold a hit only
 * when the box of its 2D coefficients contains the origin (convex hull property). Sub-patches
 * are split until small, then Newton on the rational patch polishes the hit to full precision;
 * where Newton does not converge inside its sub-patch, splitting continues. A BVH over patch
 * boxes limits the patches tested. */
#include "render_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAXC ((CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1))
#define STACK 96
#define NEWTON_SIZE (1.0 / 128)
#define MIN_SIZE (1.0 / 65536)
#define MAX_HITS 64

/* ---- BVH over patch boxes ----------------------------------------------------------------------
 */

typedef struct bvh_node {
    double box[6];
    uint32_t left,
        count; /* leaf: first index into order, count > 0; inner: children left, left+1 */
} bvh_node;

typedef struct bvh {
    bvh_node *nodes;
    uint32_t *order;
    uint32_t node_count;
} bvh;

typedef struct {
    double key;
    uint32_t index;
} keyed;

static void box_of(const crisp_scene *s, const uint32_t *idx, uint32_t n, double box[6])
{
    for (int k = 0; k < 3; k++) {
        box[k] = INFINITY;
        box[k + 3] = -INFINITY;
    }
    for (uint32_t i = 0; i < n; i++) {
        const double *b = s->patches[idx[i]].box;
        for (int k = 0; k < 3; k++) {
            box[k] = fmin(box[k], b[k]);
            box[k + 3] = fmax(box[k + 3], b[k + 3]);
        }
    }
}

static int cmp_key(const void *a, const void *b)
{
    double x = ((const keyed *)a)->key, y = ((const keyed *)b)->key;
    return (x > y) - (x < y);
}

static crisp_status bvh_build(const crisp_scene *s, bvh *b)
{
    uint32_t n = s->patch_count;
    b->order = crisp_malloc_array(n ? n : 1, sizeof *b->order);
    b->nodes = crisp_malloc_array(2 * (size_t)(n ? n : 1), sizeof *b->nodes);
    keyed *keys = crisp_malloc_array(n ? n : 1, sizeof *keys);
    if (!b->order || !b->nodes || !keys) {
        free(keys);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the ray-casting BVH");
    }
    for (uint32_t i = 0; i < n; i++)
        b->order[i] = i;
    b->node_count = 1;
    b->nodes[0].left = 0;
    b->nodes[0].count = n;
    box_of(s, b->order, n, b->nodes[0].box);
    /* Build top-down with an explicit work list (node index, first, count). */
    uint32_t work[128][3], top = 0;
    work[top][0] = 0, work[top][1] = 0, work[top][2] = n, top++;
    while (top > 0) {
        top--;
        uint32_t ni = work[top][0], first = work[top][1], count = work[top][2];
        bvh_node *nd = &b->nodes[ni];
        box_of(s, b->order + first, count, nd->box);
        if (count <= 4 || top + 2 >= 128) {
            nd->left = first;
            nd->count = count;
            continue;
        }
        double ext[3] = {nd->box[3] - nd->box[0], nd->box[4] - nd->box[1], nd->box[5] - nd->box[2]};
        int axis = ext[0] >= ext[1] && ext[0] >= ext[2] ? 0 : ext[1] >= ext[2] ? 1 : 2;
        for (uint32_t i = 0; i < count; i++) {
            const double *pb = s->patches[b->order[first + i]].box;
            keys[i] = (keyed){pb[axis] + pb[axis + 3], b->order[first + i]};
        }
        qsort(keys, count, sizeof *keys, cmp_key);
        for (uint32_t i = 0; i < count; i++)
            b->order[first + i] = keys[i].index;
        uint32_t l = b->node_count;
        b->node_count += 2;
        nd->left = l;
        nd->count = 0;
        uint32_t half = count / 2;
        work[top][0] = l, work[top][1] = first, work[top][2] = half, top++;
        work[top][0] = l + 1, work[top][1] = first + half, work[top][2] = count - half, top++;
    }
    free(keys);
    return CRISP_OK;
}

static void bvh_free(bvh *b)
{
    free(b->nodes);
    free(b->order);
}

/* Slab test: the ray's parameter range inside the box, intersected with [t0, t1]. The box is
 * widened by 1e-9 of its size: boxes from control points round (a sphere's quarters reach the
 * axis only to within 1e-32), and a ray along that axis, parallel to the slabs, then missed every
 * patch at the pole (test_normals' test_exact_singular). */
static int ray_box(const double box[6], const double o[3], const double inv[3], double t0,
                   double t1)
{
    double pad = 1e-9 * fmax(fmax(box[3] - box[0], box[4] - box[1]), box[5] - box[2]);
    for (int k = 0; k < 3; k++) {
        double a = (box[k] - pad - o[k]) * inv[k], b = (box[k + 3] + pad - o[k]) * inv[k];
        if (a > b) {
            double t = a;
            a = b;
            b = t;
        }
        if (isnan(a) || isnan(b)) continue; /* ray parallel and on a slab plane: keep */
        t0 = a > t0 ? a : t0;
        t1 = b < t1 ? b : t1;
        if (t0 > t1) return 0;
    }
    return 1;
}

/* ---- ray-patch intersection --------------------------------------------------------------------
 */

typedef struct sub {
    double s0, s1, t0, t1;
    double c[MAXC][2];
} sub;

typedef struct scratch {
    sub stack[STACK];
} scratch;

typedef struct hit {
    double t, s, u, v;
    double local[2];
    uint32_t patch;
} hit;

static void split_dir(const sub *in, int nu, int nv, int along_u, sub *lo, sub *hi)
{
    /* de Casteljau at 1/2 on each row (along_u) or column. */
    int n = along_u ? nu : nv, lines = along_u ? nv : nu;
    for (int l = 0; l < lines; l++) {
        double tmp[CRISP_MAX_DEGREE + 1][2];
        for (int k = 0; k < n; k++) {
            int idx = along_u ? l * nu + k : k * nu + l;
            tmp[k][0] = in->c[idx][0];
            tmp[k][1] = in->c[idx][1];
        }
        for (int r = 0; r < n; r++) {
            int ilo = along_u ? l * nu + r : r * nu + l;
            int ihi = along_u ? l * nu + (n - 1 - r) : (n - 1 - r) * nu + l;
            lo->c[ilo][0] = tmp[0][0];
            lo->c[ilo][1] = tmp[0][1];
            hi->c[ihi][0] = tmp[n - 1 - r][0];
            hi->c[ihi][1] = tmp[n - 1 - r][1];
            for (int k = 0; k < n - 1 - r; k++) {
                tmp[k][0] = 0.5 * (tmp[k][0] + tmp[k + 1][0]);
                tmp[k][1] = 0.5 * (tmp[k][1] + tmp[k + 1][1]);
            }
        }
    }
}

/* Plane frame of the ray: n1, n2 orthonormal and orthogonal to d. */
static void ray_planes(const double d[3], double n1[3], double n2[3])
{
    double a[3] = {0, 0, 0};
    int k = fabs(d[0]) < fabs(d[1]) ? (fabs(d[0]) < fabs(d[2]) ? 0 : 2)
                                    : (fabs(d[1]) < fabs(d[2]) ? 1 : 2);
    a[k] = 1;
    double t[3];
    crisp_vec3_cross(d, a, t);
    crisp_vec3_normalize(t, n1);
    crisp_vec3_cross(d, n1, t);
    crisp_vec3_normalize(t, n2);
}

/* More Newton steps while they shrink the residual r = |f1| + |f2|: the tolerance below is
 * relative to the model's size, which at extreme zoom (a pixel of 1e-12 of the model) is more
 * than a pixel; the hit must be as exact as double precision allows. */
static void polish(const crisp_bezier_patch *p, const double o[3], const double n1[3],
                   const double n2[3], double r, double *s, double *t)
{
    for (int it = 0; it < 4 && r > 0; it++) {
        double P[3], Ps[3], Pt[3], d[3];
        crisp_bezier_patch_derivs(p, *s, *t, P, Ps, Pt);
        for (int k = 0; k < 3; k++)
            d[k] = P[k] - o[k];
        double f1 = crisp_vec3_dot(n1, d), f2 = crisp_vec3_dot(n2, d);
        double a = crisp_vec3_dot(n1, Ps), b = crisp_vec3_dot(n1, Pt);
        double c = crisp_vec3_dot(n2, Ps), e = crisp_vec3_dot(n2, Pt);
        double det = a * e - b * c;
        if (!(fabs(det) > 0) || !isfinite(det)) return;
        double s1 = *s - (f1 * e - f2 * b) / det, t1 = *t - (a * f2 - c * f1) / det;
        if (!isfinite(s1) || !isfinite(t1)) return;
        crisp_bezier_patch_eval(p, s1, t1, P);
        for (int k = 0; k < 3; k++)
            d[k] = P[k] - o[k];
        double r1 = fabs(crisp_vec3_dot(n1, d)) + fabs(crisp_vec3_dot(n2, d));
        if (!(r1 < r)) return;
        *s = s1, *t = t1, r = r1;
    }
}

/* Newton on the rational patch from (s, t): solve n_k . (P(s, t) - o) = 0. */
static int newton(const crisp_bezier_patch *p, const double o[3], const double n1[3],
                  const double n2[3], double tol, double *s, double *t)
{
    for (int it = 0; it < 24; it++) {
        double P[3], Ps[3], Pt[3];
        crisp_bezier_patch_derivs(p, *s, *t, P, Ps, Pt);
        double d[3] = {P[0] - o[0], P[1] - o[1], P[2] - o[2]};
        double f1 = crisp_vec3_dot(n1, d), f2 = crisp_vec3_dot(n2, d);
        if (fabs(f1) <= tol && fabs(f2) <= tol && it > 0) {
            polish(p, o, n1, n2, fabs(f1) + fabs(f2), s, t);
            return 1;
        }
        double a = crisp_vec3_dot(n1, Ps), b = crisp_vec3_dot(n1, Pt);
        double c = crisp_vec3_dot(n2, Ps), e = crisp_vec3_dot(n2, Pt);
        double det = a * e - b * c;
        if (!(fabs(det) > 0) || !isfinite(det)) return 0;
        double ds = (f1 * e - f2 * b) / det, dt = (a * f2 - c * f1) / det;
        *s -= ds;
        *t -= dt;
        if (!isfinite(*s) || !isfinite(*t) || *s < -0.5 || *s > 1.5 || *t < -0.5 || *t > 1.5)
            return 0;
        if (fabs(ds) < 1e-15 && fabs(dt) < 1e-15) {
            crisp_bezier_patch_derivs(p, *s, *t, P, Ps, Pt);
            for (int k = 0; k < 3; k++)
                d[k] = P[k] - o[k];
            return fabs(crisp_vec3_dot(n1, d)) <= tol * 16 &&
                   fabs(crisp_vec3_dot(n2, d)) <= tol * 16;
        }
    }
    return 0;
}

/* Whether the patch's point at (s, t) lies on the ray within tol. */
static int on_ray(const crisp_bezier_patch *p, const double o[3], const double n1[3],
                  const double n2[3], double tol, double s, double t)
{
    double P[3], d[3];
    crisp_bezier_patch_eval(p, s, t, P);
    crisp_vec3_sub(P, o, d);
    return fabs(crisp_vec3_dot(n1, d)) <= tol && fabs(crisp_vec3_dot(n2, d)) <= tol;
}

static void add_hit(hit *hits, int *nh, const crisp_scene_patch *sp, uint32_t pi, double s,
                    double t, const double o[3], const double d[3])
{
    double P[3];
    crisp_bezier_patch_eval(&sp->bez, s, t, P);
    double rt = (P[0] - o[0]) * d[0] + (P[1] - o[1]) * d[1] + (P[2] - o[2]) * d[2];
    /* The same hit again: the same local point, or the same point of the ray (along an edge the
     * patch collapses, every wedge of it finds the pole or apex at its own parameters; they
     * filled the list and hid the hits behind them). */
    for (int k = 0; k < *nh; k++)
        if (hits[k].patch == pi &&
            ((fabs(hits[k].local[0] - s) < 1e-7 && fabs(hits[k].local[1] - t) < 1e-7) ||
             fabs(hits[k].t - rt) <= 1e-13 * fabs(rt)))
            return;
    if (*nh >= MAX_HITS) return;
    hit *h = &hits[(*nh)++];
    h->t = rt;
    h->patch = pi;
    h->local[0] = s;
    h->local[1] = t;
    h->u = sp->bez.u0 + s * (sp->bez.u1 - sp->bez.u0);
    h->v = sp->bez.v0 + t * (sp->bez.v1 - sp->bez.v0);
}

/* Whether a line through the origin separates the ray's point (0, 0) from the hull of the
 * sub-patch's projected (homogeneous, positive-weight) control points, beyond the box test: along
 * the direction of their centroid and across both diagonals. Sub-patches along an edge that the
 * surface collapses to one point (a sphere's pole, a cone's apex) are thin wedges from that point;
 * their boxes hold a ray passing near it whatever their direction, so every wedge was split down
 * to MIN_SIZE with Newton at each level (test_cracks' octant sphere zoomed onto its pole: minutes
 * for one view). */
static int separated(double (*c)[2], int nu, int nv, double tol)
{
    int n = nu * nv;
    double axes[3][2] = {{0, 0}, {0, 0}, {0, 0}};
    for (int k = 0; k < n; k++)
        axes[0][0] += c[k][0], axes[0][1] += c[k][1];
    const double *a = c[0], *b = c[n - 1], *e = c[nu - 1], *f = c[n - nu];
    axes[1][0] = a[1] - b[1], axes[1][1] = b[0] - a[0];
    axes[2][0] = e[1] - f[1], axes[2][1] = f[0] - e[0];
    for (int q = 0; q < 3; q++) {
        double len = fabs(axes[q][0]) + fabs(axes[q][1]);
        if (!(len > 0)) continue;
        double lo = INFINITY, hi = -INFINITY;
        for (int k = 0; k < n; k++) {
            double x = c[k][0] * axes[q][0] + c[k][1] * axes[q][1];
            lo = fmin(lo, x), hi = fmax(hi, x);
        }
        if (lo > tol * len || hi < -tol * len) return 1;
    }
    return 0;
}

static void intersect_patch(const crisp_scene *sc, uint32_t pi, const double o[3],
                            const double d[3], const double n1[3], const double n2[3], scratch *scr,
                            hit *hits, int *nh)
{
    const crisp_scene_patch *sp = &sc->patches[pi];
    const crisp_bezier_patch *p = &sp->bez;
    int nu = p->du + 1, nv = p->dv + 1;
    double o1 = crisp_vec3_dot(n1, o), o2 = crisp_vec3_dot(n2, o);
    double scale = 0;
    for (int k = 0; k < 3; k++)
        scale = fmax(scale, sp->box[k + 3] - sp->box[k]);
    scale = fmax(scale, fmax(fabs(o1), fabs(o2)) * 1e-3);
    double tol = 1e-12 * (scale + fabs(o1) + fabs(o2));
    int top = 0;
    sub *root = &scr->stack[top++];
    root->s0 = 0, root->s1 = 1, root->t0 = 0, root->t1 = 1;
    for (int k = 0; k < nu * nv; k++) {
        const double *c = p->cpw + 4 * k;
        root->c[k][0] = n1[0] * c[0] + n1[1] * c[1] + n1[2] * c[2] - c[3] * o1;
        root->c[k][1] = n2[0] * c[0] + n2[1] * c[1] + n2[2] * c[2] - c[3] * o2;
    }
    while (top > 0) {
        sub *cur = &scr->stack[--top];
        double lo0 = INFINITY, hi0 = -INFINITY, lo1 = INFINITY, hi1 = -INFINITY;
        for (int k = 0; k < nu * nv; k++) {
            lo0 = fmin(lo0, cur->c[k][0]);
            hi0 = fmax(hi0, cur->c[k][0]);
            lo1 = fmin(lo1, cur->c[k][1]);
            hi1 = fmax(hi1, cur->c[k][1]);
        }
        if (lo0 > tol || hi0 < -tol || lo1 > tol || hi1 < -tol) continue;
        if (separated(cur->c, nu, nv, tol)) continue;
        double ws = cur->s1 - cur->s0, wt = cur->t1 - cur->t0;
        if (ws <= NEWTON_SIZE && wt <= NEWTON_SIZE) {
            double s = 0.5 * (cur->s0 + cur->s1), t = 0.5 * (cur->t0 + cur->t1);
            if (newton(p, o, n1, n2, tol, &s, &t)) {
                if (s >= cur->s0 - 1e-9 && s <= cur->s1 + 1e-9 && t >= cur->t0 - 1e-9 &&
                    t <= cur->t1 + 1e-9) {
                    add_hit(hits, nh, sp, pi, fmin(fmax(s, 0), 1), fmin(fmax(t, 0), 1), o, d);
                    continue;
                }
                /* Converged outside the sub-patch: where the hit lies on an edge the patch
                 * collapses to one point (a ray straight onto a pole or an apex), its parameter
                 * along that edge is free and Newton leaves it anywhere; the point of the
                 * sub-patch nearest in parameters is then the same hit. */
                double sc = fmin(fmax(s, cur->s0), cur->s1), tc = fmin(fmax(t, cur->t0), cur->t1);
                if (on_ray(p, o, n1, n2, 16 * tol, sc, tc)) {
                    add_hit(hits, nh, sp, pi, sc, tc, o, d);
                    continue;
                }
            }
            if (ws <= MIN_SIZE && wt <= MIN_SIZE) {
                /* Newton failed (a tangent ray): the sub-patch is below any pixel's size. */
                if (hi0 - lo0 < 1e-9 * scale && hi1 - lo1 < 1e-9 * scale)
                    add_hit(hits, nh, sp, pi, 0.5 * (cur->s0 + cur->s1), 0.5 * (cur->t0 + cur->t1),
                            o, d);
                continue;
            }
        }
        if (top + 2 > STACK) continue; /* cannot happen with halving to MIN_SIZE; stay bounded */
        int along_u = ws >= wt;
        if (ws <= NEWTON_SIZE && wt <= NEWTON_SIZE) {
            /* Newton failed at this size (a ray grazing the surface, or passing near a point
             * where the patch collapses): split across the longer side of the projected net.
             * Halving the parameter sides alike split the wedges along a sphere's pole into
             * ever thinner wedges that all still reach the ray (test_cracks' octant sphere at a
             * grazing view of the pole: up to 48,854 sub-patches for one ray). */
            double ls = 0, lt = 0;
            for (int j = 0; j < nv; j++) {
                const double *a = cur->c[j * nu], *b = cur->c[j * nu + nu - 1];
                ls = fmax(ls, fabs(b[0] - a[0]) + fabs(b[1] - a[1]));
            }
            for (int i = 0; i < nu; i++) {
                const double *a = cur->c[i], *b = cur->c[(nv - 1) * nu + i];
                lt = fmax(lt, fabs(b[0] - a[0]) + fabs(b[1] - a[1]));
            }
            along_u = ls >= lt;
            if (along_u && ws <= MIN_SIZE) along_u = 0;
            if (!along_u && wt <= MIN_SIZE) along_u = 1;
        }
        sub tmp = *cur; /* cur is the slot lo overwrites */
        sub *lo = &scr->stack[top], *hi = &scr->stack[top + 1];
        split_dir(&tmp, nu, nv, along_u, lo, hi);
        if (along_u) {
            double m = 0.5 * (tmp.s0 + tmp.s1);
            lo->s0 = tmp.s0, lo->s1 = m, hi->s0 = m, hi->s1 = tmp.s1;
            lo->t0 = hi->t0 = tmp.t0, lo->t1 = hi->t1 = tmp.t1;
        } else {
            double m = 0.5 * (tmp.t0 + tmp.t1);
            lo->t0 = tmp.t0, lo->t1 = m, hi->t0 = m, hi->t1 = tmp.t1;
            lo->s0 = hi->s0 = tmp.s0, lo->s1 = hi->s1 = tmp.s1;
        }
        top += 2;
    }
}

static int cmp_hit(const void *a, const void *b)
{
    double x = ((const hit *)a)->t, y = ((const hit *)b)->t;
    return (x > y) - (x < y);
}

static int trace(const crisp_scene *sc, const bvh *b, const crisp_exact_desc *desc, scratch *scr,
                 const double o[3], const double d[3], double tmin, double tmax, hit *best)
{
    double inv[3] = {1.0 / d[0], 1.0 / d[1], 1.0 / d[2]}, n1[3], n2[3];
    ray_planes(d, n1, n2);
    hit hits[MAX_HITS];
    int nh = 0;
    uint32_t stack[128];
    int top = 0;
    if (sc->patch_count) stack[top++] = 0;
    while (top > 0) {
        const bvh_node *nd = &b->nodes[stack[--top]];
        if (!ray_box(nd->box, o, inv, tmin, tmax)) continue;
        if (nd->count == 0) {
            if (top + 2 <= 128) {
                stack[top++] = nd->left;
                stack[top++] = nd->left + 1;
            }
            continue;
        }
        for (uint32_t k = 0; k < nd->count; k++) {
            uint32_t pi = b->order[nd->left + k];
            if (ray_box(sc->patches[pi].box, o, inv, tmin, tmax))
                intersect_patch(sc, pi, o, d, n1, n2, scr, hits, &nh);
        }
    }
    qsort(hits, (size_t)nh, sizeof *hits, cmp_hit);
    for (int k = 0; k < nh; k++) {
        if (hits[k].t < tmin || hits[k].t > tmax) continue;
        uint32_t face = sc->patches[hits[k].patch].face;
        if (desc && desc->classify &&
            !desc->classify(desc->classify_ctx, sc, face, hits[k].u, hits[k].v))
            continue;
        *best = hits[k];
        return 1;
    }
    return 0;
}

static void hit_outputs(const crisp_scene *sc, const hit *h, uint32_t *face, double uv[2],
                        double normal[3])
{
    const crisp_scene_patch *sp = &sc->patches[h->patch];
    if (face) *face = sp->face;
    if (uv) {
        uv[0] = h->u;
        uv[1] = h->v;
    }
    if (normal) {
        double P[3], Ps[3], Pt[3];
        crisp_bezier_patch_derivs(&sp->bez, h->local[0], h->local[1], P, Ps, Pt);
        double n[3];
        crisp_vec3_cross(Ps, Pt, n);
        /* A hit on a collapsed edge (a cone's apex, a sphere's pole) or where the partials are
         * parallel: the limit normal from inside the patch, as the other backends take it. */
        if (crisp__normal_degenerate(Ps, Pt, n))
            crisp_bezier_patch_normal(&sp->bez, h->local[0], h->local[1], n);
        if (sc->faces[sp->face].src->reversed) crisp_vec3_scale(n, -1, n);
        crisp_vec3_normalize(n, normal);
    }
}

int crisp_exact_ray(const crisp_scene *sc, const crisp_exact_desc *desc, const double o[3],
                    const double d[3], double tmin, double tmax, double *t, uint32_t *face,
                    double uv[2], double normal[3])
{
    bvh b = {0};
    scratch *scr = malloc(sizeof *scr);
    int found = 0;
    hit h;
    if (scr && bvh_build(sc, &b) == CRISP_OK)
        found = trace(sc, &b, desc, scr, o, d, tmin, tmax, &h);
    if (found) {
        if (t) *t = h.t;
        hit_outputs(sc, &h, face, uv, normal);
    }
    bvh_free(&b);
    free(scr);
    return found;
}

typedef struct {
    const crisp_scene *sc;
    const bvh *b;
    const crisp_exact_desc *desc;
    const crisp_camera *cam;
    crisp_image *img;
    scratch *scr; /* one per worker */
    int win[4];   /* the window of the camera's image drawn: x0, y0, width, height */
} render_ctx;

static void render_rows(void *vctx, size_t begin, size_t end, int worker)
{
    render_ctx *c = vctx;
    const crisp_camera *cam = c->cam;
    double f[3], dd[3];
    crisp_vec3_sub(cam->target, cam->eye, dd);
    crisp_vec3_normalize(dd, f);
    const int *w = c->win;
    for (size_t j = begin; j < end; j++)
        for (int i = 0; i < w[2]; i++) {
            double o[3], d[3];
            /* the pixel (w[0] + i, w[1] + j) of the camera's image */
            crisp_camera_ray(cam, w[0] + i + 0.5, (double)(w[1] + (int)j) + 0.5, o, d);
            /* near/far bound the depth along the view axis: t = depth / cos. */
            double cosang = crisp_vec3_dot(d, f);
            hit h;
            if (!trace(c->sc, c->b, c->desc, &c->scr[worker], o, d, cam->znear / cosang,
                       cam->zfar / cosang, &h))
                continue;
            size_t px = j * (size_t)w[2] + (size_t)i;
            uint32_t face;
            double uv[2], n[3];
            hit_outputs(c->sc, &h, &face, uv, n);
            crisp_image *img = c->img;
            img->face[px] = (int32_t)face;
            img->depth[px] = (float)(h.t * cosang);
            img->uv[2 * px] = (float)uv[0];
            img->uv[2 * px + 1] = (float)uv[1];
            for (int k = 0; k < 3; k++)
                img->normal[3 * px + k] = (float)n[k];
            crisp__shade(c->sc->faces[face].color, n, d, img->rgba + 4 * px);
        }
}

crisp_status crisp_render_exact(const crisp_scene *sc, const crisp_camera *cam,
                                const crisp_exact_desc *desc, crisp_image *img)
{
    crisp_status st = crisp_camera_check(cam);
    if (st) return st;
    int win[4] = {0, 0, cam->width, cam->height};
    if (desc && (desc->window[0] || desc->window[1] || desc->window[2] || desc->window[3])) {
        memcpy(win, desc->window, sizeof win);
        if (win[0] < 0 || win[1] < 0 || win[2] < 1 || win[3] < 1 || win[0] > cam->width - win[2] ||
            win[1] > cam->height - win[3])
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "window %dx%d at (%d, %d): expected a window inside the camera's "
                               "%dx%d image",
                               win[2], win[3], win[0], win[1], cam->width, cam->height);
    }
    if (img->width != win[2] || img->height != win[3])
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "image %dx%d does not match the camera's %dx%d (or the window's)",
                           img->width, img->height, win[2], win[3]);
    crisp_pool *pool = NULL;
    int threads = desc && desc->threads > 0 ? desc->threads : crisp_pool_default_threads();
    if ((st = crisp_pool_get(threads, &pool))) return st; /* kept by crisp: no threads per call */
    threads = crisp_pool_threads(pool);
    bvh b = {0};
    scratch *scr = crisp_malloc_array((size_t)threads, sizeof *scr);
    if (!scr) st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for ray-casting scratch");
    if (!st) st = bvh_build(sc, &b);
    if (!st) {
        crisp__image_clear(img);
        render_ctx c = {sc, &b, desc, cam, img, scr, {win[0], win[1], win[2], win[3]}};
        crisp_pool_parallel_for(pool, (size_t)win[3], 1, render_rows, &c);
    }
    bvh_free(&b);
    free(scr);
    return st;
}
