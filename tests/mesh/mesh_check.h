/* Independent checks of a triangle mesh (tests and bench): closed and 2-manifold with consistent
 * orientation (every edge in exactly two triangles, once in each direction; every vertex's
 * triangles form one fan), no self-intersections (an exact triangle-triangle test on integer
 * coordinates, over the pairs whose boxes share a bin of a uniform grid), and the enclosed volume.
 *
 * Exactness: coordinates are quantised to a grid of 2^-28 of the mesh's extent (finer than a
 * float's precision at that extent), so orientations are determinants of 30-bit integers, exact
 * in 128-bit arithmetic. The triangle test follows from orientation predicates only: non-coplanar
 * triangles meet iff an edge of one meets the other; triangles sharing a vertex or an edge may
 * meet only there (see the cases below). */
#ifndef CRISP_TEST_MESH_CHECK_H
#define CRISP_TEST_MESH_CHECK_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct mc_mesh {
    float *p;    /* 3 per vertex */
    uint32_t *t; /* 3 per triangle */
    size_t nv, nt, cv, ct;
} mc_mesh;

static inline int mc_grow(void **a, size_t *cap, size_t need, size_t size)
{
    if (need <= *cap) return 0;
    size_t n = *cap ? *cap * 2 : 1024;
    while (n < need)
        n *= 2;
    void *q = realloc(*a, n * size);
    if (!q) return -1;
    *a = q;
    *cap = n;
    return 0;
}

static inline void mc_free(mc_mesh *m)
{
    free(m->p);
    free(m->t);
    memset(m, 0, sizeof *m);
}

/* ---- closed, oriented, 2-manifold ------------------------------------------------------------ */

typedef struct mc_edge {
    uint32_t a, b, t;
} mc_edge;

static int mc_edge_cmp(const void *x, const void *y)
{
    const mc_edge *p = x, *q = y;
    uint32_t pa = p->a < p->b ? p->a : p->b, pb = p->a < p->b ? p->b : p->a;
    uint32_t qa = q->a < q->b ? q->a : q->b, qb = q->a < q->b ? q->b : q->a;
    if (pa != qa) return pa < qa ? -1 : 1;
    if (pb != qb) return pb < qb ? -1 : 1;
    return (p->a > q->a) - (p->a < q->a);
}

/* Returns the number of defects: edges not in exactly two triangles of opposite direction,
 * degenerate triangles (a repeated vertex), and vertices whose triangles form more than one fan
 * or none. */
static inline size_t mc_manifold_defects(const mc_mesh *m)
{
    size_t ne = 3 * m->nt, bad = 0;
    mc_edge *e = malloc((ne ? ne : 1) * sizeof *e);
    if (!e) return (size_t)-1;
    for (size_t i = 0; i < m->nt; i++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = m->t[3 * i + k], b = m->t[3 * i + (k + 1) % 3];
            e[3 * i + k] = (mc_edge){a, b, (uint32_t)i};
            if (a == b) bad++;
        }
    qsort(e, ne, sizeof *e, mc_edge_cmp);
    for (size_t i = 0; i < ne;) {
        size_t j = i + 1;
        uint32_t lo = e[i].a < e[i].b ? e[i].a : e[i].b, hi = e[i].a < e[i].b ? e[i].b : e[i].a;
        while (j < ne && (e[j].a < e[j].b ? e[j].a : e[j].b) == lo &&
               (e[j].a < e[j].b ? e[j].b : e[j].a) == hi)
            j++;
        if (j - i != 2 || e[i].a == e[i + 1].a) bad++; /* not two, or the same direction twice */
        i = j;
    }
    /* fans: per vertex v, the map b -> c over its triangles (v, b, c) must be one cycle */
    uint32_t *start = calloc(m->nv + 1, sizeof *start),
             *nb = malloc((ne ? ne : 1) * 2 * sizeof *nb);
    if (!start || !nb) {
        free(e), free(start), free(nb);
        return (size_t)-1;
    }
    for (size_t i = 0; i < ne; i++)
        start[m->t[i] + 1]++;
    for (size_t v = 0; v < m->nv; v++)
        start[v + 1] += start[v];
    uint32_t *fill = calloc(m->nv + 1, sizeof *fill);
    for (size_t i = 0; i < m->nt; i++)
        for (int k = 0; k < 3; k++) {
            uint32_t v = m->t[3 * i + k], b = m->t[3 * i + (k + 1) % 3],
                     c = m->t[3 * i + (k + 2) % 3];
            uint32_t s = start[v] + fill[v]++;
            nb[2 * s] = b, nb[2 * s + 1] = c;
        }
    for (size_t v = 0; v < m->nv; v++) {
        uint32_t s = start[v], n = start[v + 1] - s;
        if (n == 0) {
            bad++; /* an unused vertex */
            continue;
        }
        /* walk b -> c from the first triangle; a single cycle visits all n */
        uint32_t first = nb[2 * s], cur = nb[2 * s + 1], steps = 1;
        while (cur != first && steps <= n) {
            uint32_t k = 0;
            while (k < n && nb[2 * (s + k)] != cur)
                k++;
            if (k == n) break;
            cur = nb[2 * (s + k) + 1];
            steps++;
        }
        if (cur != first || steps != n) bad++;
    }
    free(e), free(start), free(nb), free(fill);
    return bad;
}

/* ---- exact predicates ------------------------------------------------------------------------ */

__extension__ typedef __int128 mc_i128;

static inline int mc_orient3(const int64_t *p, const int64_t *q, const int64_t *r, const int64_t *s)
{
    mc_i128 a[3], b[3], c[3];
    for (int k = 0; k < 3; k++)
        a[k] = q[k] - p[k], b[k] = r[k] - p[k], c[k] = s[k] - p[k];
    mc_i128 d = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                a[2] * (b[0] * c[1] - b[1] * c[0]);
    return (d > 0) - (d < 0);
}

/* 2D orientation after dropping axis `drop` */
static inline int mc_orient2(const int64_t *p, const int64_t *q, const int64_t *r, int drop)
{
    int u = drop == 0 ? 1 : 0, v = drop == 2 ? 1 : 2;
    mc_i128 d = (mc_i128)(q[u] - p[u]) * (r[v] - p[v]) - (mc_i128)(q[v] - p[v]) * (r[u] - p[u]);
    return (d > 0) - (d < 0);
}

static inline int mc_drop_axis(const int64_t *a, const int64_t *b, const int64_t *c)
{
    mc_i128 u[3], v[3], n[3];
    for (int k = 0; k < 3; k++)
        u[k] = b[k] - a[k], v[k] = c[k] - a[k];
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
    for (int k = 0; k < 3; k++)
        n[k] = n[k] < 0 ? -n[k] : n[k];
    return n[0] >= n[1] && n[0] >= n[2] ? 0 : n[1] >= n[2] ? 1 : 2;
}

/* closed 2D segments pq and rs meet */
static inline int mc_seg_seg2(const int64_t *p, const int64_t *q, const int64_t *r,
                              const int64_t *s, int d)
{
    int o1 = mc_orient2(p, q, r, d), o2 = mc_orient2(p, q, s, d), o3 = mc_orient2(r, s, p, d),
        o4 = mc_orient2(r, s, q, d);
    if (o1 * o2 < 0 && o3 * o4 < 0) return 1;
    int u = d == 0 ? 1 : 0, v = d == 2 ? 1 : 2;
#define MC_ON(a, b, c)                                                                             \
    (((c)[u] >= ((a)[u] < (b)[u] ? (a)[u] : (b)[u])) &&                                            \
     ((c)[u] <= ((a)[u] > (b)[u] ? (a)[u] : (b)[u])) &&                                            \
     ((c)[v] >= ((a)[v] < (b)[v] ? (a)[v] : (b)[v])) &&                                            \
     ((c)[v] <= ((a)[v] > (b)[v] ? (a)[v] : (b)[v])))
    if (o1 == 0 && MC_ON(p, q, r)) return 1;
    if (o2 == 0 && MC_ON(p, q, s)) return 1;
    if (o3 == 0 && MC_ON(r, s, p)) return 1;
    if (o4 == 0 && MC_ON(r, s, q)) return 1;
#undef MC_ON
    return 0;
}

/* closed 2D point in triangle */
static inline int mc_pt_tri2(const int64_t *p, const int64_t *a, const int64_t *b, const int64_t *c,
                             int d)
{
    int o1 = mc_orient2(a, b, p, d), o2 = mc_orient2(b, c, p, d), o3 = mc_orient2(c, a, p, d);
    return !((o1 < 0 || o2 < 0 || o3 < 0) && (o1 > 0 || o2 > 0 || o3 > 0));
}

/* closed segment pq meets closed triangle abc (3D) */
static inline int mc_seg_tri(const int64_t *p, const int64_t *q, const int64_t *a, const int64_t *b,
                             const int64_t *c)
{
    int o1 = mc_orient3(a, b, c, p), o2 = mc_orient3(a, b, c, q);
    if (o1 * o2 > 0) return 0;
    if (o1 == 0 && o2 == 0) {
        int d = mc_drop_axis(a, b, c);
        return mc_pt_tri2(p, a, b, c, d) || mc_pt_tri2(q, a, b, c, d) ||
               mc_seg_seg2(p, q, a, b, d) || mc_seg_seg2(p, q, b, c, d) ||
               mc_seg_seg2(p, q, c, a, d);
    }
    int s1 = mc_orient3(p, q, a, b), s2 = mc_orient3(p, q, b, c), s3 = mc_orient3(p, q, c, a);
    return !((s1 < 0 || s2 < 0 || s3 < 0) && (s1 > 0 || s2 > 0 || s3 > 0));
}

/* direction w - v lies in the closed cone at v spanned by c - v and d - v (all coplanar) */
static inline int mc_in_cone(const int64_t *v, const int64_t *w, const int64_t *c, const int64_t *d,
                             int ax)
{
    int s = mc_orient2(v, c, d, ax), s1 = mc_orient2(v, c, w, ax), s2 = mc_orient2(v, w, d, ax);
    if (s == 0) return 0; /* degenerate triangle: reported elsewhere */
    if (s1 * s < 0 || s2 * s < 0) return 0;
    if (s1 == 0) { /* on the ray of c or its opposite */
        int u = ax == 0 ? 1 : 0, vv = ax == 2 ? 1 : 2;
        mc_i128 dot =
            (mc_i128)(w[u] - v[u]) * (c[u] - v[u]) + (mc_i128)(w[vv] - v[vv]) * (c[vv] - v[vv]);
        return dot > 0;
    }
    if (s2 == 0) {
        int u = ax == 0 ? 1 : 0, vv = ax == 2 ? 1 : 2;
        mc_i128 dot =
            (mc_i128)(w[u] - v[u]) * (d[u] - v[u]) + (mc_i128)(w[vv] - v[vv]) * (d[vv] - v[vv]);
        return dot > 0;
    }
    return 1;
}

/* Triangles i and j (vertex indices ti, tj; quantised points q) meet anywhere but in what they
 * share. */
static inline int mc_tri_tri(const int64_t *q, const uint32_t *ti, const uint32_t *tj)
{
    int shared = 0, si[3] = {-1, -1, -1};
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            if (ti[a] == tj[b]) si[a] = b, shared++;
#define P(x) (q + 3 * (size_t)(x))
    if (shared == 3) return 1; /* the same triangle twice */
    if (shared == 2) {
        int ka = 0, kb = 0;
        while (si[ka] >= 0)
            ka++;
        int used[3] = {0, 0, 0};
        for (int a = 0; a < 3; a++)
            if (si[a] >= 0) used[si[a]] = 1;
        while (used[kb])
            kb++;
        const int64_t *v1 = P(ti[(ka + 1) % 3]), *v2 = P(ti[(ka + 2) % 3]), *a = P(ti[ka]),
                      *b = P(tj[kb]);
        if (mc_orient3(v1, v2, a, b) != 0) return 0;
        int ax = mc_drop_axis(v1, v2, a);
        return mc_orient2(v1, v2, a, ax) * mc_orient2(v1, v2, b, ax) > 0; /* folded over */
    }
    if (shared == 1) {
        int ia = 0;
        while (si[ia] < 0)
            ia++;
        int jb = si[ia];
        const int64_t *v = P(ti[ia]), *a = P(ti[(ia + 1) % 3]), *b = P(ti[(ia + 2) % 3]);
        const int64_t *c = P(tj[(jb + 1) % 3]), *d = P(tj[(jb + 2) % 3]);
        if (mc_seg_tri(a, b, v, c, d) || mc_seg_tri(c, d, v, a, b)) return 1;
        /* an edge from v lying in the other's plane and inside its angle at v */
        if (mc_orient3(v, c, d, a) == 0 && mc_in_cone(v, a, c, d, mc_drop_axis(v, c, d))) return 1;
        if (mc_orient3(v, c, d, b) == 0 && mc_in_cone(v, b, c, d, mc_drop_axis(v, c, d))) return 1;
        if (mc_orient3(v, a, b, c) == 0 && mc_in_cone(v, c, a, b, mc_drop_axis(v, a, b))) return 1;
        if (mc_orient3(v, a, b, d) == 0 && mc_in_cone(v, d, a, b, mc_drop_axis(v, a, b))) return 1;
        return 0;
    }
    const int64_t *a = P(ti[0]), *b = P(ti[1]), *c = P(ti[2]), *d = P(tj[0]), *e = P(tj[1]),
                  *f = P(tj[2]);
#undef P
    return mc_seg_tri(a, b, d, e, f) || mc_seg_tri(b, c, d, e, f) || mc_seg_tri(c, a, d, e, f) ||
           mc_seg_tri(d, e, a, b, c) || mc_seg_tri(e, f, a, b, c) || mc_seg_tri(f, d, a, b, c);
}

/* Pairs of triangles that meet beyond what they share, over pairs whose boxes overlap (binned on
 * a grid of `bin` edge). *pairs gets the number of pairs tested. */
static inline size_t mc_self_intersections(const mc_mesh *m, double bin, size_t *pairs)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY},
           ext = 0;
    for (size_t i = 0; i < 3 * m->nv; i++) {
        lo[i % 3] = fmin(lo[i % 3], m->p[i]);
        hi[i % 3] = fmax(hi[i % 3], m->p[i]);
        ext = fmax(ext, fabs(m->p[i]));
    }
    *pairs = 0;
    if (!m->nt) return 0;
    double scale = ldexp(1.0, 28) / (ext > 0 ? ext : 1);
    int64_t *q = malloc(3 * m->nv * sizeof *q);
    int nb[3];
    for (int a = 0; a < 3; a++)
        nb[a] = (int)((hi[a] - lo[a]) / bin) + 1;
    size_t nbins = (size_t)nb[0] * nb[1] * nb[2];
    /* CSR of (bin, triangle) */
    uint32_t *cnt = calloc(nbins + 1, sizeof *cnt);
    for (size_t i = 0; i < 3 * m->nv; i++)
        q[i] = llround(m->p[i] * scale);
    size_t total = 0;
    for (int pass = 0; pass < 2; pass++) {
        uint32_t *list = NULL;
        if (pass == 1) {
            for (size_t b = 0; b < nbins; b++)
                cnt[b + 1] += cnt[b];
            list = malloc((total ? total : 1) * sizeof *list);
        }
        uint32_t *fill = pass ? calloc(nbins, sizeof *fill) : NULL;
        for (size_t t = 0; t < m->nt; t++) {
            int b0[3], b1[3];
            for (int a = 0; a < 3; a++) {
                double mn = INFINITY, mx = -INFINITY;
                for (int k = 0; k < 3; k++) {
                    double v = m->p[3 * m->t[3 * t + k] + a];
                    mn = fmin(mn, v), mx = fmax(mx, v);
                }
                b0[a] = (int)((mn - lo[a]) / bin), b1[a] = (int)((mx - lo[a]) / bin);
                if (b1[a] >= nb[a]) b1[a] = nb[a] - 1;
            }
            for (int z = b0[2]; z <= b1[2]; z++)
                for (int y = b0[1]; y <= b1[1]; y++)
                    for (int x = b0[0]; x <= b1[0]; x++) {
                        size_t b = ((size_t)z * nb[1] + y) * nb[0] + x;
                        if (!pass)
                            cnt[b + 1]++, total++;
                        else
                            list[cnt[b] + fill[b]++] = (uint32_t)t;
                    }
        }
        if (pass == 1) {
            size_t bad = 0;
            for (size_t b = 0; b < nbins; b++)
                for (uint32_t i = cnt[b]; i < cnt[b + 1]; i++)
                    for (uint32_t j = i + 1; j < cnt[b + 1]; j++) {
                        (*pairs)++;
                        if (mc_tri_tri(q, m->t + 3 * (size_t)list[i], m->t + 3 * (size_t)list[j]))
                            bad++;
                    }
            free(list), free(fill), free(cnt), free(q);
            return bad; /* a pair in several bins counts once per bin */
        }
    }
    return 0;
}

/* Enclosed volume (divergence theorem; positive for outward triangles). */
static inline double mc_volume(const mc_mesh *m)
{
    double v = 0;
    for (size_t i = 0; i < m->nt; i++) {
        const float *a = m->p + 3 * m->t[3 * i], *b = m->p + 3 * m->t[3 * i + 1],
                    *c = m->p + 3 * m->t[3 * i + 2];
        v += (double)a[0] * ((double)b[1] * c[2] - (double)b[2] * c[1]) -
             (double)a[1] * ((double)b[0] * c[2] - (double)b[2] * c[0]) +
             (double)a[2] * ((double)b[0] * c[1] - (double)b[1] * c[0]);
    }
    return v / 6;
}

#endif
