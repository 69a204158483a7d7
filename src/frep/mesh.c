/* The f-rep mesher: marching tetrahedra on the interval octree (Keeter 2012's subdivision with
 * per-cell tape shortening; the Kuhn/Freudenthal split of each grid cube into 6 tetrahedra, as in
 * Schaefer's notes on marching tetrahedra; Bloomenthal's polygonizer finds edge roots the same
 * way).
 *
 * Why marching tetrahedra, not dual contouring: the issue asks for a mesh that is watertight,
 * 2-manifold and free of self-intersections, checked by an exact test. Every triangle here lies
 * inside its tetrahedron (its vertices are on the tetrahedron's edges, strictly inside them), and
 * the tetrahedra of the grid meet face to face, so two triangles of different tetrahedra can
 * meet only in a shared edge or vertex; each edge vertex is made once (a table keyed by the grid
 * edge), so every mesh edge is shared by exactly two triangles; there are no ambiguous cases.
 * Dual contouring keeps sharp corners by moving vertices off the grid edges, which is what makes
 * its triangles cross (libfive issues 284 and 150); confining its vertex to the cell does not
 * prevent folds between neighbouring cells. Sharp features here: edge vertices lie on the surface
 * (regula falsi along the edge), and where the normals at a tetrahedron's edge vertices disagree
 * by more than 30 degrees its polygon is fanned from a feature point (the QEF point of their
 * tangent planes, as in Kobbelt's extended marching cubes), accepted only inside the
 * tetrahedron and only when no fan triangle turns against the polygon's normal, which keeps both
 * guarantees (feature_point). A feature thinner than the cell that no grid corner sees is
 * reported (a cube whose centre differs in sign from its eight agreeing corners), not lost
 * silently.
 *
 * Octree: cells proven inside or outside by one interval are never split; undecided cells are
 * split down to blocks of 4^3 grid cubes, which evaluate their 5^3 corners with the tape
 * shortened for them. Memory: the octree's tapes (one per level) and the edge table, which holds
 * the vertices of surface cubes only, so it grows with the surface, not the volume. Output is
 * streamed to the sink as it is made. */
#include "crisp/frep_mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "frep_octree.h"

#define B 4        /* grid cubes per leaf block side */
#define BP (B + 1) /* grid points per leaf block side */
#define NPTS (BP * BP * BP)
#define MAX_LEVELS 19 /* 4 * 2^18 = 2^20 cubes per side */
#define FALSI_STEPS 6

typedef struct edge_entry {
    uint64_t key; /* 0 = empty (keys are stored + 1) */
    uint32_t v;
    float p[3];
    float n[3]; /* unit gradient at p (0 when unknown) */
} edge_entry;

typedef struct mesher {
    const crisp_frep_tape *t;
    const crisp_frep_mesh_sink *sink;
    crisp_frep_mesh_stats *st;
    frep_octree o; /* scratch: intervals, choices, tapes per level */
    double org[3], h;
    int n;                 /* grid cubes per side of the octree's root (4 * 2^levels) */
    int lim[3];            /* grid points with index >= 1 and <= lim[a] are inside the region */
    double rlo[3], rhi[3]; /* the region */
    float *regs;           /* registers x FREP_LANES */
    float *gregs;          /* registers x 4 x FREP_LANES */
    int features;          /* fans through a feature point where the normals disagree */
    int cell_lo[3], cell_hi[3]; /* desc->split_cell: the blocks meshed (grid cube indices) */
    edge_entry *table;
    size_t tcount, tcap, max_bytes;
    crisp_status status;
} mesher;

static float coord(const mesher *m, int a, int i)
{
    return (float)(m->org[a] + i * m->h);
}

/* ---- edge table ------------------------------------------------------------------------------ */

static uint64_t hash64(uint64_t k)
{
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    k *= 0xc4ceb9fe1a85ec53ull;
    return k ^ (k >> 33);
}

static edge_entry *edge_slot(mesher *m, uint64_t key)
{
    size_t mask = m->tcap - 1, i = (size_t)hash64(key) & mask;
    while (m->table[i].key && m->table[i].key != key + 1)
        i = (i + 1) & mask;
    return &m->table[i];
}

static int table_grow(mesher *m)
{
    if ((m->tcount + 1) * 2 <= m->tcap) return 0;
    size_t ncap = m->tcap ? m->tcap * 2 : 4096;
    if (ncap * sizeof *m->table > m->max_bytes) return -2;
    edge_entry *old = m->table;
    size_t ocap = m->tcap;
    m->table = crisp_calloc_array(ncap, sizeof *m->table);
    if (!m->table) {
        m->table = old;
        return -1;
    }
    m->tcap = ncap;
    for (size_t i = 0; i < ocap; i++)
        if (old[i].key) *edge_slot(m, old[i].key - 1) = old[i];
    crisp_free(old);
    size_t bytes = m->tcap * sizeof *m->table;
    if (bytes > m->st->peak_bytes) m->st->peak_bytes = bytes;
    return 0;
}

/* ---- tetrahedra ------------------------------------------------------------------------------ */

/* The 6 Kuhn tetrahedra of a cube: corners as offsets (bit 0 x, bit 1 y, bit 2 z) along a chain
 * 0 -> e_a -> e_a + e_b -> 7, listed positively oriented (odd permutations swap the middle two). */
static int tets[6][4];
/* even permutations of (0,1,2,3), by first element */
static const int even[4][3][4] = {
    {{0, 1, 2, 3}, {0, 2, 3, 1}, {0, 3, 1, 2}},
    {{1, 0, 3, 2}, {1, 2, 0, 3}, {1, 3, 2, 0}},
    {{2, 0, 1, 3}, {2, 1, 3, 0}, {2, 3, 0, 1}},
    {{3, 0, 2, 1}, {3, 1, 0, 2}, {3, 2, 1, 0}},
};

static void init_tets(void)
{
    static const int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1},
                                   {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
    for (int p = 0; p < 6; p++) {
        int v1 = 1 << perm[p][0], v2 = v1 | (1 << perm[p][1]);
        int odd = p >= 3;
        tets[p][0] = 0;
        tets[p][1] = odd ? v2 : v1;
        tets[p][2] = odd ? v1 : v2;
        tets[p][3] = 7;
    }
}

/* ---- a leaf block ---------------------------------------------------------------------------- */

typedef struct block {
    int i0[3];
    float v[NPTS];    /* values at the block's grid points (outside the region: +1) */
    float f[NPTS];    /* the function's own values there */
    uint8_t in[NPTS]; /* inside */
} block;

static int pidx(int x, int y, int z)
{
    return (z * BP + y) * BP + x;
}

/* Evaluate the tape at n points (any n) into out, in batches of FREP_LANES. */
static void eval_points(mesher *m, frep_span t, int n, const float *x, const float *y,
                        const float *z, float *out)
{
    float px[FREP_LANES], py[FREP_LANES], pz[FREP_LANES];
    for (int b = 0; b < n; b += FREP_LANES) {
        int k = n - b < FREP_LANES ? n - b : FREP_LANES;
        for (int q = 0; q < FREP_LANES; q++) {
            int s = b + (q < k ? q : 0);
            px[q] = x[s], py[q] = y[s], pz[q] = z[s];
        }
        crisp__frep_eval_lanes(t.ins, t.len, m->regs, px, py, pz);
        const float *v = m->regs + (size_t)t.ins[t.len - 1].out * FREP_LANES;
        memcpy(out + b, v, (size_t)k * sizeof *out);
    }
}

static int in_region(const mesher *m, const int g[3])
{
    for (int a = 0; a < 3; a++)
        if (g[a] < 1 || g[a] > m->lim[a]) return 0;
    return 1;
}

typedef struct pending {
    uint64_t key;
    int ga[3], gb[3]; /* grid points: a inside, b outside */
    double ta, tb;    /* bracket on [0, 1] from a to b */
    double umax;      /* where the edge leaves the region (1 inside it) */
    float fa, fb;
    int lo_first; /* a is the edge's lower end */
} pending;

/* The vertices of the block's new crossing edges: regula falsi from both sides in batches. */
static void solve_edges(mesher *m, frep_span t, pending *pe, int np)
{
    float x[FREP_LANES], y[FREP_LANES], z[FREP_LANES], f[FREP_LANES];
    double tt[FREP_LANES];
    for (int b = 0; b < np; b += FREP_LANES) {
        int k = np - b < FREP_LANES ? np - b : FREP_LANES;
        for (int step = 0; step < FALSI_STEPS; step++) {
            for (int q = 0; q < k; q++) {
                pending *p = &pe[b + q];
                double s = p->fa / ((double)p->fa - p->fb);
                if (!(s > 0.02 && s < 0.98)) s = 0.5; /* NaN side, or stalling: bisect */
                double u = p->ta + s * (p->tb - p->ta);
                tt[q] = u;
                float c[3];
                for (int a = 0; a < 3; a++)
                    c[a] = (float)(m->org[a] + (p->ga[a] + u * (p->gb[a] - p->ga[a])) * m->h);
                x[q] = c[0], y[q] = c[1], z[q] = c[2];
            }
            eval_points(m, t, k, x, y, z, f);
            for (int q = 0; q < k; q++) {
                pending *p = &pe[b + q];
                if (f[q] < 0)
                    p->ta = tt[q], p->fa = f[q];
                else
                    p->tb = tt[q], p->fb = f[q] == f[q] ? f[q] : 1;
            }
        }
    }
}

static crisp_status emit_vertex(mesher *m, pending *p, uint32_t *dest, float c[3])
{
    /* the last bracket's secant point, kept strictly inside the edge and the region */
    double s = p->fa / ((double)p->fa - p->fb);
    if (!(s >= 0 && s <= 1)) s = 0.5;
    double u = p->ta + s * (p->tb - p->ta);
    if (u > p->umax) u = p->umax;
    if (u < 1e-3) u = 1e-3;
    if (u > 1 - 1e-3) u = 1 - 1e-3;
    for (int a = 0; a < 3; a++)
        c[a] = (float)(m->org[a] + (p->ga[a] + u * (p->gb[a] - p->ga[a])) * m->h);
    crisp_status s2 = m->sink->vertex(m->sink->ctx, c);
    if (s2) return s2;
    *dest = (uint32_t)m->st->vertices++;
    return CRISP_OK;
}

static uint64_t edge_key(const mesher *m, const int lo[3], int dir)
{
    uint64_t n1 = (uint64_t)m->n + 1;
    return (((uint64_t)lo[2] * n1 + (uint64_t)lo[1]) * n1 + (uint64_t)lo[0]) * 8 + (uint64_t)dir;
}

/* A feature point for the polygon v[0 .. n) (loop order, outward) of a tetrahedron whose vertex
 * normals disagree by more than 30 degrees: the point nearest to their tangent planes (a QEF,
 * regularised towards the polygon's centre, Kobbelt's extended marching cubes / dual contouring's
 * vertex), taken only when it lies inside the tetrahedron and the fan from it over the polygon
 * keeps every triangle facing the polygon's own normal. Then the fan stays inside the
 * tetrahedron (no crossing with other tetrahedra's triangles) and projects along that normal to
 * a simple star (no crossing within it): the guarantees of the plain polygon hold. */
static int feature_point(const mesher *m, const int i0[3], int cx, int cy, int cz, const int tv[4],
                         float v[4][3], float nv[4][3], int n, float out[3])
{
    double mind = 1;
    for (int a = 0; a < n; a++) {
        if (nv[a][0] == 0 && nv[a][1] == 0 && nv[a][2] == 0) return 0;
        for (int b = a + 1; b < n; b++)
            mind = fmin(mind, nv[a][0] * nv[b][0] + nv[a][1] * nv[b][1] + nv[a][2] * nv[b][2]);
    }
    if (mind > 0.866) return 0;
    double c[3] = {0, 0, 0}, A[3][3] = {{0}}, rhs[3] = {0};
    for (int a = 0; a < n; a++)
        for (int k = 0; k < 3; k++)
            c[k] += v[a][k] / n;
    const double lambda = 0.05;
    for (int a = 0; a < n; a++) {
        double d = 0;
        for (int k = 0; k < 3; k++)
            d += nv[a][k] * (v[a][k] - c[k]);
        for (int i = 0; i < 3; i++) {
            rhs[i] += nv[a][i] * d;
            for (int j = 0; j < 3; j++)
                A[i][j] += nv[a][i] * nv[a][j];
        }
    }
    for (int i = 0; i < 3; i++)
        A[i][i] += lambda;
    /* solve A x = rhs (offset from c) by Cramer's rule */
    double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
                 A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
                 A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
    if (!(fabs(det) > 1e-12)) return 0;
    double x[3];
    for (int k = 0; k < 3; k++) {
        double M[3][3];
        memcpy(M, A, sizeof M);
        for (int i = 0; i < 3; i++)
            M[i][k] = rhs[i];
        x[k] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) /
               det;
    }
    double p[3];
    for (int k = 0; k < 3; k++) {
        out[k] = (float)(c[k] + x[k]);
        p[k] = out[k];
    }
    /* inside the tetrahedron: barycentric coordinates from its corners */
    double T[4][3];
    for (int q = 0; q < 4; q++) {
        int o = tv[q],
            g[3] = {i0[0] + cx + (o & 1), i0[1] + cy + ((o >> 1) & 1), i0[2] + cz + (o >> 2)};
        for (int k = 0; k < 3; k++)
            T[q][k] = m->org[k] + g[k] * m->h;
    }
    double e1[3], e2[3], e3[3], r[3];
    for (int k = 0; k < 3; k++)
        e1[k] = T[1][k] - T[0][k], e2[k] = T[2][k] - T[0][k], e3[k] = T[3][k] - T[0][k],
        r[k] = p[k] - T[0][k];
#define DET3(a, b, c)                                                                              \
    ((a)[0] * ((b)[1] * (c)[2] - (b)[2] * (c)[1]) - (a)[1] * ((b)[0] * (c)[2] - (b)[2] * (c)[0]) + \
     (a)[2] * ((b)[0] * (c)[1] - (b)[1] * (c)[0]))
    double D = DET3(e1, e2, e3);
    double l1 = DET3(r, e2, e3) / D, l2 = DET3(e1, r, e3) / D, l3 = DET3(e1, e2, r) / D,
           l0 = 1 - l1 - l2 - l3;
#undef DET3
    const double margin = 1e-3;
    if (!(l0 > margin && l1 > margin && l2 > margin && l3 > margin)) return 0;
    /* the polygon's normal (Newell) and the fan's triangles facing it */
    double pn[3] = {0, 0, 0};
    for (int a = 0; a < n; a++) {
        const float *u = v[a], *w = v[(a + 1) % n];
        pn[0] += ((double)u[1] - w[1]) * ((double)u[2] + w[2]);
        pn[1] += ((double)u[2] - w[2]) * ((double)u[0] + w[0]);
        pn[2] += ((double)u[0] - w[0]) * ((double)u[1] + w[1]);
    }
    double pl = sqrt(pn[0] * pn[0] + pn[1] * pn[1] + pn[2] * pn[2]);
    if (!(pl > 0)) return 0;
    for (int a = 0; a < n; a++) {
        double u[3], w[3];
        for (int k = 0; k < 3; k++)
            u[k] = v[a][k] - p[k], w[k] = v[(a + 1) % n][k] - p[k];
        double cr[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                        u[0] * w[1] - u[1] * w[0]};
        double cl = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
        if (!((cr[0] * pn[0] + cr[1] * pn[1] + cr[2] * pn[2]) > 0.05 * cl * pl)) return 0;
    }
    return 1;
}

static crisp_status mesh_block(mesher *m, frep_span t, const int i0[3])
{
    block bl;
    float x[NPTS], y[NPTS], z[NPTS];
    for (int c = 0; c < NPTS; c++) {
        int g[3] = {i0[0] + c % BP, i0[1] + (c / BP) % BP, i0[2] + c / (BP * BP)};
        x[c] = coord(m, 0, g[0]), y[c] = coord(m, 1, g[1]), z[c] = coord(m, 2, g[2]);
    }
    eval_points(m, t, NPTS, x, y, z, bl.v);
    memcpy(bl.f, bl.v, sizeof bl.f);
    int any_in = 0, any_out = 0;
    for (int c = 0; c < NPTS; c++) {
        int g[3] = {i0[0] + c % BP, i0[1] + (c / BP) % BP, i0[2] + c / (BP * BP)};
        float v = bl.v[c];
        if (v != v) m->st->nan_points++;
        int inside = v < 0;
        if (!in_region(m, g)) {
            if (inside && g[0] >= 0 && g[1] >= 0 && g[2] >= 0 && g[0] <= m->lim[0] + 1 &&
                g[1] <= m->lim[1] + 1 && g[2] <= m->lim[2] + 1)
                m->st->cut_points++;
            inside = 0;
            bl.v[c] = 1;
        }
        bl.in[c] = (uint8_t)inside;
        any_in |= inside;
        any_out |= !inside;
    }
    /* thin features: cube centres against agreeing corners */
    {
        float cx[B * B * B], cy[B * B * B], cz[B * B * B], cv[B * B * B];
        int nq = 0, idx[B * B * B];
        for (int q = 0; q < B * B * B; q++) {
            int cxq = q % B, cyq = (q / B) % B, czq = q / (B * B);
            int base = pidx(cxq, cyq, czq), s = bl.in[base], agree = 1;
            for (int k = 1; k < 8 && agree; k++)
                agree = bl.in[base + (k & 1) + ((k >> 1) & 1) * BP + (k >> 2) * BP * BP] == s;
            if (!agree) continue;
            int g[3] = {i0[0] + cxq, i0[1] + cyq, i0[2] + czq};
            if (!in_region(m, g) || g[0] + 1 > m->lim[0] || g[1] + 1 > m->lim[1] ||
                g[2] + 1 > m->lim[2])
                continue;
            cx[nq] = (float)(m->org[0] + (g[0] + 0.5) * m->h);
            cy[nq] = (float)(m->org[1] + (g[1] + 0.5) * m->h);
            cz[nq] = (float)(m->org[2] + (g[2] + 0.5) * m->h);
            idx[nq++] = s;
        }
        if (nq) {
            eval_points(m, t, nq, cx, cy, cz, cv);
            for (int q = 0; q < nq; q++)
                if ((cv[q] < 0) != idx[q]) {
                    if (!m->st->thin_cubes)
                        m->st->thin_at[0] = cx[q], m->st->thin_at[1] = cy[q],
                        m->st->thin_at[2] = cz[q];
                    m->st->thin_cubes++;
                }
        }
    }
    if (!any_in || !any_out) return CRISP_OK;
    m->st->leaves++;

    /* new crossing edges of the block's tetrahedra */
    pending pe[NPTS * 7];
    int np = 0;
    static const int dirs[7] = {1, 2, 3, 4, 5, 6, 7};
    for (int c = 0; c < NPTS; c++) {
        int lx = c % BP, ly = (c / BP) % BP, lz = c / (BP * BP);
        for (int d = 0; d < 7; d++) {
            int dx = dirs[d] & 1, dy = (dirs[d] >> 1) & 1, dz = dirs[d] >> 2;
            if (lx + dx > B || ly + dy > B || lz + dz > B) continue;
            int c2 = pidx(lx + dx, ly + dy, lz + dz);
            if (bl.in[c] == bl.in[c2]) continue;
            int lo[3] = {i0[0] + lx, i0[1] + ly, i0[2] + lz};
            uint64_t key = edge_key(m, lo, dirs[d]);
            int g = table_grow(m);
            if (g == -2)
                return crisp_error(
                    CRISP_ERR_LIMIT,
                    "frep mesh: the edge table would pass %.0f MB (more than %zu vertices); use a "
                    "coarser cell",
                    m->max_bytes / 1e6, m->tcount);
            if (g)
                return crisp_error(CRISP_ERR_NO_MEMORY,
                                   "frep mesh: out of memory for the edge table");
            edge_entry *e = edge_slot(m, key);
            if (e->key) continue;
            e->key = key + 1;
            e->v = UINT32_MAX; /* solved below */
            m->tcount++;
            pending *p = &pe[np++];
            int hi[3] = {lo[0] + dx, lo[1] + dy, lo[2] + dz};
            int a_lo = bl.in[c];
            p->key = key;
            memcpy(p->ga, a_lo ? lo : hi, sizeof p->ga);
            memcpy(p->gb, a_lo ? hi : lo, sizeof p->gb);
            p->fa = a_lo ? bl.v[c] : bl.v[c2];
            p->fb = a_lo ? bl.f[c2] : bl.f[c];
            if (p->fb != p->fb) p->fb = 1;
            /* an edge leaving the region: its vertex goes no further than the region's face */
            p->umax = 1;
            for (int ax = 0; ax < 3; ax++) {
                int gin = p->ga[ax], gout = p->gb[ax];
                if (gout == gin) continue;
                int edge_pt = gout < 1 ? 1 : gout > m->lim[ax] ? m->lim[ax] : gout;
                if (edge_pt == gout) continue;
                /* the face is at the region's bound, between the grid points gin and gout */
                double bound = gout < 1 ? m->rlo[ax] : m->rhi[ax];
                double cin = m->org[ax] + gin * m->h, cout = m->org[ax] + gout * m->h;
                double u = (bound - cin) / (cout - cin);
                if (u < p->umax) p->umax = u;
            }
            p->ta = 0, p->tb = 1;
            p->lo_first = a_lo;
        }
    }
    /* edges whose outer end is inside the part but outside the region get no root search: their
     * vertex is on the region's face */
    int nsolve = 0;
    for (int q = 0; q < np; q++) {
        if (!(pe[q].fb < 0)) {
            pending tmp = pe[nsolve];
            pe[nsolve++] = pe[q];
            pe[q] = tmp;
        }
    }
    solve_edges(m, t, pe, nsolve);
    for (int q = 0; q < np; q++) {
        if (q >= nsolve) pe[q].ta = pe[q].umax, pe[q].tb = pe[q].umax, pe[q].fb = -pe[q].fa;
        edge_entry *e = edge_slot(m, pe[q].key);
        crisp_status s = emit_vertex(m, &pe[q], &e->v, e->p);
        if (s) return s;
    }
    /* normals of the new vertices (for the feature points) */
    for (int b = 0; m->features && b < np; b += FREP_LANES) {
        int k = np - b < FREP_LANES ? np - b : FREP_LANES;
        float x[FREP_LANES], y[FREP_LANES], z[FREP_LANES];
        edge_entry *es[FREP_LANES];
        for (int q = 0; q < FREP_LANES; q++) {
            edge_entry *e = edge_slot(m, pe[b + (q < k ? q : 0)].key);
            es[q] = e;
            x[q] = e->p[0], y[q] = e->p[1], z[q] = e->p[2];
        }
        crisp__frep_grad_lanes(t.ins, t.len, m->gregs, x, y, z);
        const float *g = m->gregs + (size_t)t.ins[t.len - 1].out * 4 * FREP_LANES;
        for (int q = 0; q < k; q++) {
            double gx = g[FREP_LANES + q], gy = g[2 * FREP_LANES + q], gz = g[3 * FREP_LANES + q];
            double l = sqrt(gx * gx + gy * gy + gz * gz);
            int ok = l > 0 && isfinite(l) && in_region(m, pe[b + q].gb);
            es[q]->n[0] = ok ? (float)(gx / l) : 0;
            es[q]->n[1] = ok ? (float)(gy / l) : 0;
            es[q]->n[2] = ok ? (float)(gz / l) : 0;
        }
    }

    /* triangles */
    for (int cz2 = 0; cz2 < B; cz2++)
        for (int cy2 = 0; cy2 < B; cy2++)
            for (int cx2 = 0; cx2 < B; cx2++) {
                int base = pidx(cx2, cy2, cz2);
                int cin = 0;
                for (int k = 0; k < 8; k++)
                    cin += bl.in[base + (k & 1) + ((k >> 1) & 1) * BP + (k >> 2) * BP * BP];
                if (cin == 0 || cin == 8) continue;
                for (int tt = 0; tt < 6; tt++) {
                    const int *tv = tets[tt];
                    int ins[4], nin = 0;
                    for (int k = 0; k < 4; k++) {
                        int o = tv[k];
                        ins[k] = bl.in[base + (o & 1) + ((o >> 1) & 1) * BP + (o >> 2) * BP * BP];
                        nin += ins[k];
                    }
                    if (nin == 0 || nin == 4) continue;
                        /* vertex on the edge between tet corners p and q */
#define EV(P, Q, DEST)                                                                             \
    do {                                                                                           \
        int oa = tv[P], ob = tv[Q];                                                                \
        if ((oa & ob) != oa) {                                                                     \
            int sw = oa;                                                                           \
            oa = ob;                                                                               \
            ob = sw;                                                                               \
        } /* oa is the lower end */                                                                \
        int lo3[3] = {i0[0] + cx2 + (oa & 1), i0[1] + cy2 + ((oa >> 1) & 1),                       \
                      i0[2] + cz2 + (oa >> 2)};                                                    \
        edge_entry *en = edge_slot(m, edge_key(m, lo3, oa ^ ob));                                  \
        DEST = en->v;                                                                              \
        memcpy(tn[ntp], en->n, sizeof tn[0]);                                                      \
        poly[ntp] = en->v;                                                                         \
        memcpy(tp[ntp++], en->p, sizeof tp[0]);                                                    \
    } while (0)
                    uint32_t tri[2][3], poly[4];
                    float tp[4][3], tq[2][3][3], tn[4][3];
                    int ntri = 0, ntp = 0;
                    if (nin == 1 || nin == 3) {
                        int i = 0;
                        while (ins[i] != (nin == 1))
                            i++;
                        const int *pr = even[i][0];
                        EV(pr[0], pr[1], tri[0][0]);
                        if (nin == 1) {
                            EV(pr[0], pr[2], tri[0][1]);
                            EV(pr[0], pr[3], tri[0][2]);
                        } else {
                            EV(pr[0], pr[3], tri[0][1]);
                            EV(pr[0], pr[2], tri[0][2]);
                        }
                        ntri = 1;
                    } else {
                        int i = 0;
                        while (!ins[i])
                            i++;
                        int j = i + 1;
                        while (!ins[j])
                            j++;
                        const int *pr = NULL;
                        for (int e = 0; e < 3; e++)
                            if (even[i][e][1] == j) pr = even[i][e];
                        uint32_t eik, eil, ejl, ejk;
                        EV(pr[0], pr[2], eik);
                        EV(pr[0], pr[3], eil);
                        EV(pr[1], pr[3], ejl);
                        EV(pr[1], pr[2], ejk);
                        tri[0][0] = eik, tri[0][1] = eil, tri[0][2] = ejl;
                        tri[1][0] = eik, tri[1][1] = ejl, tri[1][2] = ejk;
                        memcpy(tq[0][0], tp[0], sizeof tp[0]);
                        memcpy(tq[0][1], tp[1], sizeof tp[0]);
                        memcpy(tq[0][2], tp[2], sizeof tp[0]);
                        memcpy(tq[1][0], tp[0], sizeof tp[0]);
                        memcpy(tq[1][1], tp[2], sizeof tp[0]);
                        memcpy(tq[1][2], tp[3], sizeof tp[0]);
                        ntri = 2;
                    }
                    if (ntri == 1) memcpy(tq[0], tp, sizeof tq[0]);
#undef EV
                    float fp[3];
                    if (m->features && feature_point(m, i0, cx2, cy2, cz2, tv, tp, tn, ntp, fp)) {
                        uint32_t c;
                        crisp_status s = m->sink->vertex(m->sink->ctx, fp);
                        if (s) return s;
                        c = (uint32_t)m->st->vertices++;
                        m->st->feature_points++;
                        for (int q = 0; q < ntp; q++) {
                            uint32_t ft[3] = {c, poly[q], poly[(q + 1) % ntp]};
                            float fq[3][3];
                            memcpy(fq[0], fp, sizeof fp);
                            memcpy(fq[1], tp[q], sizeof fp);
                            memcpy(fq[2], tp[(q + 1) % ntp], sizeof fp);
                            s = m->sink->triangle(m->sink->ctx, ft, (const float(*)[3])fq);
                            if (s) return s;
                            m->st->triangles++;
                        }
                        continue;
                    }
                    for (int q = 0; q < ntri; q++) {
                        crisp_status s =
                            m->sink->triangle(m->sink->ctx, tri[q], (const float(*)[3])tq[q]);
                        if (s) return s;
                        m->st->triangles++;
                    }
                }
            }
    return CRISP_OK;
}

/* ---- the octree ------------------------------------------------------------------------------ */

static crisp_status walk(mesher *m, frep_span t, const int i0[3], int size, int depth)
{
    /* cells wholly outside the region's grid points are outside */
    for (int a = 0; a < 3; a++)
        if (i0[a] > m->lim[a] || i0[a] + size < 1) return CRISP_OK;
    float b[6];
    for (int a = 0; a < 3; a++)
        b[2 * a] = coord(m, a, i0[a]), b[2 * a + 1] = coord(m, a, i0[a] + size);
    size_t d;
    int cls = crisp__frep_octree_classify(&m->o, t, b, &d);
    m->st->intervals++;
    if (cls == FREP_CELL_OUT) return CRISP_OK;
    int border = 0;
    for (int a = 0; a < 3; a++)
        border |= i0[a] < 1 || i0[a] + size > m->lim[a];
    if (cls == FREP_CELL_IN && !border) return CRISP_OK;
    frep_span ct = t;
    if (d && depth < m->o.max_depth) {
        frep_span out;
        size_t len = m->t->length;
        if (!crisp__frep_shorten(t, m->o.choices, &m->o.sc, m->o.tapes + (size_t)depth * len,
                                 m->o.ssas + 2 * (size_t)depth * len, &out))
            ct = out;
    }
    if (size == B) return mesh_block(m, ct, i0);
    int c = size / 2;
    for (int q = 0; q < 8; q++) {
        int ci[3] = {i0[0] + (q & 1) * c, i0[1] + ((q >> 1) & 1) * c, i0[2] + (q >> 2) * c};
        /* a cell of a split job: only the nodes over its blocks */
        if (ci[0] >= m->cell_hi[0] || ci[0] + c <= m->cell_lo[0] || ci[1] >= m->cell_hi[1] ||
            ci[1] + c <= m->cell_lo[1] || ci[2] >= m->cell_hi[2] || ci[2] + c <= m->cell_lo[2])
            continue;
        crisp_status s = walk(m, ct, ci, c, depth + 1);
        if (s) return s;
    }
    return CRISP_OK;
}

crisp_status crisp_frep_mesh(const crisp_frep_tape *t, const crisp_frep_mesh_desc *desc,
                             const crisp_frep_mesh_sink *sink, crisp_frep_mesh_stats *stats)
{
    if (!t || !desc || !sink || !sink->vertex || !sink->triangle || !stats)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_mesh: NULL argument");
    memset(stats, 0, sizeof *stats);
    init_tets();
    double r[6];
    int zero = 1;
    for (int k = 0; k < 6; k++)
        zero &= desc->region[k] == 0;
    if (zero) {
        crisp_frep_fit fit;
        crisp_status s = crisp_frep_fit_region(t, &(crisp_frep_fit_desc){0}, &fit);
        if (!s) s = crisp_frep_fit_check(&fit, 0);
        if (s) return s;
        memcpy(r, fit.box, sizeof r);
    } else {
        memcpy(r, desc->region, sizeof r);
    }
    double ext = 0;
    for (int a = 0; a < 3; a++) {
        if (!(r[2 * a] < r[2 * a + 1]) || !isfinite(r[2 * a]) || !isfinite(r[2 * a + 1]))
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "crisp_frep_mesh: region axis %d [%g, %g] is empty", a, r[2 * a],
                               r[2 * a + 1]);
        ext = fmax(ext, r[2 * a + 1] - r[2 * a]);
    }
    if (desc->resolution < 0 || desc->cell < 0 || desc->cell != desc->cell)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_frep_mesh: resolution %d / cell %g is negative", desc->resolution,
                           desc->cell);
    double h = desc->cell > 0 ? desc->cell : ext / (desc->resolution > 0 ? desc->resolution : 128);
    mesher m = {.t = t, .sink = sink, .st = stats, .h = h};
    m.max_bytes = desc->max_megabytes > 0 ? (size_t)(desc->max_megabytes * 1e6) : (size_t)8 << 30;
    int need = 0;
    for (int a = 0; a < 3; a++) {
        double cells = ceil((r[2 * a + 1] - r[2 * a]) / h);
        if (!(cells <= (1 << 20) - 2))
            return crisp_error(CRISP_ERR_LIMIT,
                               "crisp_frep_mesh: %.0f cells along axis %d (at most %d)", cells, a,
                               (1 << 20) - 2);
        /* grid points 1 .. lim are those inside the region (point 1 on its lower face) */
        m.lim[a] = 1 + (int)floor((r[2 * a + 1] - r[2 * a]) / h * (1 + 1e-12));
        m.org[a] = r[2 * a] - h;
        m.rlo[a] = r[2 * a], m.rhi[a] = r[2 * a + 1];
        need = m.lim[a] + 1 > need ? m.lim[a] + 1 : need;
    }
    int levels = 0;
    m.n = B;
    while (m.n < need)
        m.n *= 2, levels++;
    for (int a = 0; a < 3; a++)
        m.cell_lo[a] = 0, m.cell_hi[a] = m.n;
    if (desc->split_cell[1] > 1) {
        /* cell I of 8^k: along each axis the grid's cubes [0, need) in 2^k runs of whole blocks;
         * I's base-8 digits (most significant first) give one bit per axis per halving */
        long n8 = 1;
        int k = 0;
        while (n8 < desc->split_cell[1])
            n8 *= 8, k++;
        int parts = 1 << k, ix[3] = {0, 0, 0};
        if (n8 != desc->split_cell[1] || desc->split_cell[0] < 0 ||
            desc->split_cell[0] >= desc->split_cell[1] || need < B * parts)
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "crisp_frep_mesh: cell %d of %d: expected a power of 8 cells, of "
                               "at least %d grid cubes a side (the grid has %d)",
                               desc->split_cell[0], desc->split_cell[1], B, need);
        for (int d = 0; d < k; d++) {
            int o = (desc->split_cell[0] >> (3 * (k - 1 - d))) & 7;
            for (int a = 0; a < 3; a++)
                ix[a] = 2 * ix[a] + ((o >> a) & 1);
        }
        for (int a = 0; a < 3; a++) {
            int na = m.lim[a] + 1;
            m.cell_lo[a] = ix[a] ? B * (int)floor((double)ix[a] * na / (B * parts) + 0.5) : 0;
            m.cell_hi[a] = ix[a] + 1 < parts
                               ? B * (int)floor((double)(ix[a] + 1) * na / (B * parts) + 0.5)
                               : m.n;
        }
    }
    crisp_status s = crisp__frep_octree_init(&m.o, t, levels + 1);
    if (s) return s;
    m.regs = crisp_malloc_array((size_t)t->registers * FREP_LANES, sizeof *m.regs);
    m.gregs = crisp_malloc_array((size_t)t->registers * 4 * FREP_LANES, sizeof *m.gregs);
    m.features = !desc->no_features;
    if (!m.regs || !m.gregs) {
        s = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_mesh: out of memory");
        goto done;
    }
    stats->peak_bytes = (size_t)t->length * (size_t)(levels + 2) * (sizeof(frep_ins) + 8) +
                        (size_t)t->registers * (FREP_LANES + 2) * sizeof(float);
    const frep_span full = {t->ins, t->ssa, t->length, t->registers};
    s = walk(&m, full, (int[3]){0, 0, 0}, m.n, 0);
    stats->cell = h;
    for (int a = 0; a < 3; a++)
        stats->region[2 * a] = r[2 * a], stats->region[2 * a + 1] = r[2 * a + 1];
    stats->peak_bytes += m.tcap * sizeof *m.table;
done:
    crisp__frep_octree_free(&m.o);
    crisp_free(m.regs);
    crisp_free(m.gregs);
    crisp_free(m.table);
    return s;
}
