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
 * prevent folds between neighbouring cells. Sharp features here ("sharp features" below):
 * extended marching cubes (Kobbelt et al.) on the tetrahedra: face points where a crease crosses
 * a tetrahedron's face, and a fan from a cell point strictly inside the tetrahedron (or inside
 * the all-outside tetrahedron beside it that holds the crease's tip), which keeps both
 * guarantees by construction (a fan from an interior point of a star-shaped cell over a simple
 * curve on its boundary is embedded). A feature thinner than the cell that no grid corner sees is
 * reported (a cube whose centre differs in sign from its eight agreeing corners), not lost
 * silently.
 *
 * Octree: cells proven inside or outside by one interval are never split; undecided cells are
 * split down to blocks of 4^3 grid cubes, which evaluate their 5^3 corners with the tape
 * shortened for them. Memory: the octree's tapes (one per level) and the edge table, which holds
 * the vertices of surface cubes only, and only while a cube that uses them is still to be meshed:
 * the walk visits blocks in Morton order, and when the table fills, the edges whose cubes all
 * precede the current block are dropped (table_purge). What stays is the surface along the
 * walk's front (the faces between visited and unvisited octree cells), which grows about like
 * the resolution, not its square (the surface) or cube (the volume). Output is streamed to the
 * sink as it is made. */
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
#define FACE_BIT (1ull << 63)     /* table keys of faces (face points) */
#define NO_POINT (UINT32_MAX - 1) /* a face without a face point */

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
    int no_tips;           /* cell points stay in their tetrahedron */
    int cell_lo[3], cell_hi[3]; /* desc->split_cell: the blocks meshed (grid cube indices) */
    edge_entry *table;
    size_t tcount, tcap, max_bytes;
    size_t table_peak;  /* bytes */
    uint64_t cur_block; /* Morton code of the block being meshed (the walk's order) */
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

/* Morton code of a block (bits of x lowest), the order in which walk visits blocks */
static uint64_t morton(const int b[3])
{
    uint64_t code = 0;
    for (int bit = 0; bit < 21; bit++)
        for (int a = 0; a < 3; a++)
            code |= (uint64_t)((b[a] >> bit) & 1) << (3 * bit + a);
    return code;
}

/* The last block (in the walk's order) holding a cube that contains the grid edge of key: the
 * cubes containing the edge from lo along the offset dir have corners lo - {0,1} on the axes
 * where dir is 0 and lo on the others; Morton order grows with each coordinate, so the last is
 * the block of the cube at lo (clamped into the grid). */
static uint64_t edge_last_block(const mesher *m, uint64_t key)
{
    uint64_t n1 = (uint64_t)m->n + 1, k = key & FACE_BIT ? (key & ~FACE_BIT) / 64 : key / 8;
    int lo[3] = {(int)(k % n1), (int)((k / n1) % n1), (int)(k / n1 / n1)}, b[3];
    for (int a = 0; a < 3; a++)
        b[a] = (lo[a] < m->n ? lo[a] : m->n - 1) / B;
    return morton(b);
}

/* Drop the edges whose cubes have all been meshed (their blocks precede the current one): the
 * table then holds the front of the walk, not the whole surface. Linear probing with backward
 * shift deletion, in place. */
static void table_purge(mesher *m)
{
    size_t mask = m->tcap - 1;
    for (size_t i = 0; i < m->tcap; i++) {
        while (m->table[i].key && edge_last_block(m, m->table[i].key - 1) < m->cur_block) {
            size_t hole = i, j = i;
            for (;;) {
                j = (j + 1) & mask;
                if (!m->table[j].key) break;
                size_t home = (size_t)hash64(m->table[j].key - 1) & mask;
                /* j's entry may fill the hole when its home is not cyclically in (hole, j] */
                int stays = hole <= j ? (home > hole && home <= j) : (home > hole || home <= j);
                if (!stays) {
                    m->table[hole] = m->table[j];
                    hole = j;
                }
            }
            m->table[hole].key = 0;
            m->tcount--;
        }
    }
}

static int table_grow(mesher *m)
{
    if ((m->tcount + 1) * 2 <= m->tcap) return 0;
    if (m->tcap) {
        table_purge(m);
        if (m->tcount * 4 <= m->tcap) return 0;
    }
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
    size_t bytes = (m->tcap + ocap) * sizeof *m->table; /* both tables while rehashing */
    if (bytes > m->table_peak) m->table_peak = bytes;
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

/* ---- sharp features --------------------------------------------------------------------------
 * Extended marching cubes (Kobbelt et al. 2001) on the tetrahedra, kept embedded by construction:
 * - a face point: where the segment of the polygon on a tetrahedron's face joins two vertices
 *   whose normals disagree (a crease crosses the face), the point of the face's plane on both
 *   tangent planes replaces the segment by two, when it lies inside the face. It is a function
 *   of the face alone (its corners and the two edge vertices, taken in a canonical order), kept
 *   in the table by face, so both tetrahedra of the face use the same point;
 * - a cell point: a tetrahedron with a face point or disagreeing normals fans its polygon from
 *   the QEF point of its vertices' tangent planes, moved inside the tetrahedron when outside.
 * Why this cannot fold or cross: the polygon is a simple closed curve on the boundary of a convex
 * tetrahedron (one path per face: its segment, or the two halves through the face point, inside
 * the face), and the fan from any point strictly inside a convex body over a simple curve on its
 * boundary is an embedded disk (each ray from the point meets the boundary once, so the fan's
 * triangles meet only along the rays to shared vertices). The fan stays inside the tetrahedron,
 * and meets the neighbouring tetrahedra's triangles only along the shared paths. */

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double det3(const double a[3], const double b[3], const double c[3])
{
    double x[3];
    cross3(b, c, x);
    return dot3(a, x);
}

/* x with rows r: r[i] . x = d[i]; 0 when near singular (relative to the rows' lengths) */
static int solve_rows(const double r[3][3], const double d[3], double x[3])
{
    double D = det3(r[0], r[1], r[2]);
    double scale = sqrt(dot3(r[0], r[0]) * dot3(r[1], r[1]) * dot3(r[2], r[2]));
    if (!(fabs(D) > 1e-6 * scale)) return 0;
    /* Cramer on the columns: x_k = det(rows with column k replaced by d) / D */
    for (int k = 0; k < 3; k++) {
        double q[3][3];
        memcpy(q, r, sizeof q);
        for (int i = 0; i < 3; i++)
            q[i][k] = d[i];
        x[k] = det3(q[0], q[1], q[2]) / D;
    }
    return 1;
}

static int zero3(const float v[3])
{
    return v[0] == 0 && v[1] == 0 && v[2] == 0;
}

static uint64_t grid_lin(const mesher *m, const int g[3])
{
    uint64_t n1 = (uint64_t)m->n + 1;
    return ((uint64_t)g[2] * n1 + (uint64_t)g[1]) * n1 + (uint64_t)g[0];
}

/* The face point of the face with grid corners g[3] (sorted by grid_lin) for the segment from
 * vertex (pu, nu) to (pw, nw) (sorted by edge key): 1 and out when it lies inside the face by a
 * margin. */
static int face_point(const mesher *m, const int g[3][3], const float pu[3], const float nu[3],
                      const float pw[3], const float nw[3], float out[3])
{
    double F[3][3], e1[3], e2[3], N[3], rows[3][3], d[3], x[3];
    for (int q = 0; q < 3; q++)
        for (int k = 0; k < 3; k++)
            F[q][k] = m->org[k] + g[q][k] * m->h;
    for (int k = 0; k < 3; k++)
        e1[k] = F[1][k] - F[0][k], e2[k] = F[2][k] - F[0][k];
    cross3(e1, e2, N);
    for (int k = 0; k < 3; k++)
        rows[0][k] = nu[k], rows[1][k] = nw[k], rows[2][k] = N[k];
    d[0] = d[1] = 0;
    for (int k = 0; k < 3; k++)
        d[0] += (double)nu[k] * pu[k], d[1] += (double)nw[k] * pw[k];
    d[2] = dot3(N, F[0]);
    if (!solve_rows((const double(*)[3])rows, d, x)) return 0;
    /* barycentric coordinates in the face (areas against N) */
    double nn = dot3(N, N);
    for (int q = 0; q < 3; q++) {
        const double *A = F[(q + 1) % 3], *Bq = F[(q + 2) % 3];
        double a[3], b[3], c[3];
        for (int k = 0; k < 3; k++)
            a[k] = A[k] - x[k], b[k] = Bq[k] - x[k];
        cross3(a, b, c);
        if (!(dot3(c, N) / nn > 0.02)) return 0;
    }
    for (int k = 0; k < 3; k++)
        out[k] = (float)x[k];
    return 1;
}

/* The QEF point of the tangent planes at v[0 .. n) (normals nv; vertices without a normal
 * take no part), regularised towards their centre (as in dual contouring); the centre when
 * that is singular. */
static void qef_point(float (*v)[3], float (*nv)[3], int n, double p[3])
{
    double c[3] = {0, 0, 0}, A[3][3] = {{0}}, rhs[3] = {0}, x[3];
    for (int a = 0; a < n; a++)
        for (int k = 0; k < 3; k++)
            c[k] += (double)v[a][k] / n;
    const double lambda = 0.05;
    int planes = 0;
    for (int a = 0; a < n; a++) {
        if (zero3(nv[a])) continue;
        planes++;
        double d = 0;
        for (int k = 0; k < 3; k++)
            d += nv[a][k] * (v[a][k] - c[k]);
        for (int i = 0; i < 3; i++) {
            rhs[i] += nv[a][i] * d;
            for (int j = 0; j < 3; j++)
                A[i][j] += (double)nv[a][i] * nv[a][j];
        }
    }
    for (int i = 0; i < 3; i++)
        A[i][i] += lambda;
    if (planes && solve_rows((const double(*)[3])A, rhs, x))
        for (int k = 0; k < 3; k++)
            p[k] = c[k] + x[k];
    else
        memcpy(p, c, sizeof c);
}

/* barycentric coordinates of p in the tetrahedron T */
static void barycentric(const double T[4][3], const double p[3], double l[4])
{
    double e1[3], e2[3], e3[3], r[3];
    for (int k = 0; k < 3; k++)
        e1[k] = T[1][k] - T[0][k], e2[k] = T[2][k] - T[0][k], e3[k] = T[3][k] - T[0][k],
        r[k] = p[k] - T[0][k];
    double D = det3(e1, e2, e3);
    l[1] = det3(r, e2, e3) / D, l[2] = det3(e1, r, e3) / D, l[3] = det3(e1, e2, r) / D;
    l[0] = 1 - l[1] - l[2] - l[3];
}

#define CELL_MARGIN 0.01 /* of the barycentric coordinates, or of a cell for distances */

/* p moved strictly inside the tetrahedron: barycentric coordinates clamped to the margin */
static void clamp_into(const double T[4][3], double p[3])
{
    double l[4], sum = 0;
    barycentric(T, p, l);
    for (int q = 0; q < 4; q++) {
        if (!(l[q] >= CELL_MARGIN)) l[q] = CELL_MARGIN; /* NaN too */
        sum += l[q];
    }
    for (int k = 0; k < 3; k++) {
        p[k] = 0;
        for (int q = 0; q < 4; q++)
            p[k] += l[q] / sum * T[q][k];
    }
}

/* p strictly on the side of the plane (a, b, c) where o is, by the margin (h: the cell) */
static int inner_side(const double a[3], const double b[3], const double c[3], const double o[3],
                      const double p[3], double h)
{
    double u[3], w[3], nrm[3], dp[3], dop[3];
    for (int k = 0; k < 3; k++)
        u[k] = b[k] - a[k], w[k] = c[k] - a[k], dp[k] = p[k] - a[k], dop[k] = o[k] - a[k];
    cross3(u, w, nrm);
    double len = sqrt(dot3(nrm, nrm)), so = dot3(nrm, dop);
    if (!(len > 0)) return 0;
    return (so > 0 ? 1 : -1) * dot3(nrm, dp) / len > CELL_MARGIN * h;
}

/* A crease's tip outside the tetrahedron A (grid corners G, positions T, in tv's order): the
 * point p lies beyond A's face F opposite corner k. When the tetrahedron Z across F has all its
 * corners on the side opposite k's (outside the part for a convex crease, inside for a concave
 * one; so no triangle of the plain mesh touches Z), nobody has claimed Z
 * yet, and p lies in the kernel of A u Z (strictly inside the planes of the six faces other
 * than F), A's fan may take p: A's polygon lies on the boundary of A u Z (F carries no path),
 * and the fan from a kernel point of a star-shaped cell over a simple curve on its boundary is
 * embedded, like the convex case. Z is then claimed in the table, so no other fan enters it.
 * 1 when p may be used. */
static int extend_into(mesher *m, const uint8_t *in, const int i0[3], const int tv[4],
                       const int G[4][3], const double T[4][3], int k, const double p[3])
{
    if (m->no_tips) return 0;
    /* the chain order of A's corners: 0 = the cube's corner 0 ... 3 = corner 7 */
    int ch[4], pos[4];
    for (int q = 0; q < 4; q++) {
        int o = tv[q], bits = (o & 1) + ((o >> 1) & 1) + (o >> 2);
        ch[bits] = q, pos[q] = bits;
    }
    int kc = pos[k], gn[3];
    for (int a = 0; a < 3; a++) {
        if (kc == 1 || kc == 2)
            gn[a] = G[ch[kc - 1]][a] + G[ch[kc + 1]][a] - G[ch[kc]][a];
        else if (kc == 0)
            gn[a] = G[ch[3]][a] + G[ch[1]][a] - G[ch[0]][a];
        else
            gn[a] = G[ch[0]][a] - (G[ch[3]][a] - G[ch[2]][a]);
    }
    /* gn outside the part, within the block's evaluated points and the region */
    int loc[3];
    for (int a = 0; a < 3; a++) {
        loc[a] = gn[a] - i0[a];
        if (loc[a] < 0 || loc[a] > B) return 0;
    }
    /* Z's corners (F's and gn) agree in sign, against k's: no path on F, none in Z */
    int zin = in[pidx(loc[0], loc[1], loc[2])];
    if (!in_region(m, gn)) return 0;
    for (int q = 0; q < 4; q++) {
        int l3[3] = {G[q][0] - i0[0], G[q][1] - i0[1], G[q][2] - i0[2]};
        if ((in[pidx(l3[0], l3[1], l3[2])] == zin) != (q != k)) return 0;
    }
    double Tn[3];
    for (int a = 0; a < 3; a++)
        Tn[a] = m->org[a] + gn[a] * m->h;
    /* the kernel: A's faces through corner k, and Z's faces through gn */
    int f[3], nf = 0;
    for (int q = 0; q < 4; q++)
        if (q != k) f[nf++] = q;
    for (int j = 0; j < 3; j++) {
        int a = f[(j + 1) % 3], b = f[(j + 2) % 3];
        /* A's face (k, a, b), inward towards f[j]; Z's face (gn, a, b), inward towards f[j] */
        if (!inner_side(T[k], T[a], T[b], T[f[j]], p, m->h)) return 0;
        if (!inner_side(Tn, T[a], T[b], T[f[j]], p, m->h)) return 0;
    }
    /* claim Z: its lowest corner and its chain's first two axes */
    int zc[4][3], lo[3] = {gn[0], gn[1], gn[2]};
    for (int j = 0; j < 3; j++)
        memcpy(zc[j], G[f[j]], sizeof zc[j]);
    memcpy(zc[3], gn, sizeof gn);
    for (int j = 0; j < 3; j++)
        for (int a = 0; a < 3; a++)
            lo[a] = zc[j][a] < lo[a] ? zc[j][a] : lo[a];
    int ax1 = -1, ax2 = -1;
    for (int j = 0; j < 4; j++) {
        int d0 = zc[j][0] - lo[0], d1 = zc[j][1] - lo[1], d2 = zc[j][2] - lo[2];
        int bits = d0 + d1 + d2;
        if (bits == 1) ax1 = d0 ? 0 : d1 ? 1 : 2;
        if (bits == 2) ax2 = !d0 ? 0 : !d1 ? 1 : 2; /* the axis not yet taken */
    }
    if (ax1 < 0 || ax2 < 0) return 0;
    int second = 3 - ax1 - ax2; /* the chain's second axis */
    int code = ax1 * 2 + (second == (ax1 + 1) % 3 ? 0 : 1);
    int top[3] = {lo[0] + 1, lo[1] + 1, lo[2] + 1}; /* past every cube that may claim Z */
    uint64_t key = FACE_BIT | (grid_lin(m, top) * 64 + (uint64_t)code);
    if (table_grow(m)) return 0;
    edge_entry *e = edge_slot(m, key);
    if (e->key) return 0;
    e->key = key + 1;
    e->v = NO_POINT;
    m->tcount++;
    m->st->tip_points++;
    return 1;
}

/* Face points on the tetrahedron's faces and its cell point's fan (see "sharp features"). The
 * polygon: poly[0 .. n) in loop order, their edge keys, tet corners, positions and normals;
 * *done = 1 when the fan was emitted (else the caller emits the plain polygon). */
static crisp_status feature_fan(mesher *m, const uint8_t *in, const int i0[3], const int c3[3],
                                const int tv[4], int n, const uint32_t poly[4],
                                const uint64_t ekey[4], const int ecorner[4], float (*tp)[3],
                                float (*tn)[3], int *done)
{
    uint32_t ext[8];
    float ep[8][3];
    int ne = 0, nface = 0;
    /* normals disagree: the cell point's fan (a vertex without a normal, on the region's
     * faces, takes no part); a face point depends on its face's two vertices only, so that both
     * tetrahedra of the face decide alike */
    double mind = 1;
    for (int q = 0; q < n; q++)
        for (int r = q + 1; r < n; r++)
            if (!zero3(tn[q]) && !zero3(tn[r]))
                mind = fmin(mind, (double)tn[q][0] * tn[r][0] + (double)tn[q][1] * tn[r][1] +
                                      (double)tn[q][2] * tn[r][2]);
    int disagree = mind < 0.866;
    for (int q = 0; q < n; q++) {
        ext[ne] = poly[q];
        memcpy(ep[ne++], tp[q], sizeof ep[0]);
        int r = (q + 1) % n;
        if (zero3(tn[q]) || zero3(tn[r])) continue;
        double dn =
            (double)tn[q][0] * tn[r][0] + (double)tn[q][1] * tn[r][1] + (double)tn[q][2] * tn[r][2];
        if (!(dn < 0.866)) continue;
        /* the face: the three tet corners of the two edges, sorted by grid index */
        int cs = ecorner[q] | ecorner[r], g[3][3], k = 0;
        uint64_t lin[3];
        for (int c = 0; c < 4; c++) {
            if (!((cs >> c) & 1)) continue;
            int o = tv[c];
            g[k][0] = i0[0] + c3[0] + (o & 1), g[k][1] = i0[1] + c3[1] + ((o >> 1) & 1),
            g[k][2] = i0[2] + c3[2] + (o >> 2);
            lin[k] = grid_lin(m, g[k]);
            k++;
        }
        for (int a = 1; a < 3; a++)
            for (int b = a; b > 0 && lin[b] < lin[b - 1]; b--) {
                uint64_t t = lin[b];
                lin[b] = lin[b - 1], lin[b - 1] = t;
                int tg[3];
                memcpy(tg, g[b], sizeof tg);
                memcpy(g[b], g[b - 1], sizeof tg);
                memcpy(g[b - 1], tg, sizeof tg);
            }
        int off1 = (g[1][0] - g[0][0]) | (g[1][1] - g[0][1]) << 1 | (g[1][2] - g[0][2]) << 2;
        int off2 = (g[2][0] - g[0][0]) | (g[2][1] - g[0][1]) << 1 | (g[2][2] - g[0][2]) << 2;
        uint64_t key = FACE_BIT | (lin[0] * 64 + (uint64_t)off1 * 8 + (uint64_t)off2);
        int gr = table_grow(m);
        if (gr)
            return crisp_error(gr == -2 ? CRISP_ERR_LIMIT : CRISP_ERR_NO_MEMORY,
                               "frep mesh: the edge table would pass %.0f MB; use a coarser cell",
                               m->max_bytes / 1e6);
        edge_entry *e = edge_slot(m, key);
        if (!e->key) {
            e->key = key + 1;
            m->tcount++;
            e->v = NO_POINT;
            int first = ekey[q] < ekey[r] ? q : r, second = first == q ? r : q;
            float fp[3];
            if (face_point(m, (const int(*)[3])g, tp[first], tn[first], tp[second], tn[second],
                           fp)) {
                crisp_status s = m->sink->vertex(m->sink->ctx, fp);
                if (s) return s;
                e->v = (uint32_t)m->st->vertices++;
                memcpy(e->p, fp, sizeof fp);
                m->st->face_points++;
            }
        }
        if (e->v != NO_POINT) {
            ext[ne] = e->v;
            memcpy(ep[ne++], e->p, sizeof ep[0]);
            nface++;
        }
    }
    if (!disagree && !nface) return CRISP_OK;
    double T[4][3], p[3], l[4];
    int G[4][3];
    for (int q = 0; q < 4; q++) {
        int o = tv[q];
        G[q][0] = i0[0] + c3[0] + (o & 1), G[q][1] = i0[1] + c3[1] + ((o >> 1) & 1),
        G[q][2] = i0[2] + c3[2] + (o >> 2);
        for (int k = 0; k < 3; k++)
            T[q][k] = m->org[k] + G[q][k] * m->h;
    }
    /* the cell point: the QEF point inside A, or in the tetrahedron beyond the face it lies
     * behind (extend_into), else moved inside A */
    qef_point(tp, tn, n, p);
    barycentric((const double(*)[3])T, p, l);
    int kmin = 0;
    for (int q = 1; q < 4; q++)
        if (l[q] < l[kmin]) kmin = q;
    if (!(l[kmin] >= CELL_MARGIN) && !(l[kmin] < 0 && extend_into(m, in, i0, tv, (const int(*)[3])G,
                                                                  (const double(*)[3])T, kmin, p)))
        clamp_into((const double(*)[3])T, p);
    float cp[3] = {(float)p[0], (float)p[1], (float)p[2]};
    crisp_status s = m->sink->vertex(m->sink->ctx, cp);
    if (s) return s;
    uint32_t c = (uint32_t)m->st->vertices++;
    m->st->feature_points++;
    for (int q = 0; q < ne; q++) {
        uint32_t ft[3] = {c, ext[q], ext[(q + 1) % ne]};
        float fq[3][3];
        memcpy(fq[0], cp, sizeof cp);
        memcpy(fq[1], ep[q], sizeof cp);
        memcpy(fq[2], ep[(q + 1) % ne], sizeof cp);
        s = m->sink->triangle(m->sink->ctx, ft, (const float(*)[3])fq);
        if (s) return s;
        m->st->triangles++;
    }
    *done = 1;
    return CRISP_OK;
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
    m->cur_block = morton((const int[3]){i0[0] / B, i0[1] / B, i0[2] / B});

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
        ekey[ntp] = edge_key(m, lo3, oa ^ ob);                                                     \
        ecorner[ntp] = (1 << (P)) | (1 << (Q));                                                    \
        edge_entry *en = edge_slot(m, ekey[ntp]);                                                  \
        DEST = en->v;                                                                              \
        memcpy(tn[ntp], en->n, sizeof tn[0]);                                                      \
        poly[ntp] = en->v;                                                                         \
        memcpy(tp[ntp++], en->p, sizeof tp[0]);                                                    \
    } while (0)
                    uint32_t tri[2][3], poly[4];
                    uint64_t ekey[4];
                    int ecorner[4]; /* the tet corners (bits 0..3) of each vertex's edge */
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
                    if (m->features) {
                        int done = 0;
                        crisp_status s = feature_fan(m, bl.in, i0, (int[3]){cx2, cy2, cz2}, tv, ntp,
                                                     poly, ekey, ecorner, tp, tn, &done);
                        if (s) return s;
                        if (done) continue;
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
    m.features = !desc->no_features && m.n <= (1 << 18); /* face keys fit in 63 bits */
    m.no_tips = desc->no_tips;
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
    stats->peak_bytes += m.table_peak;
done:
    crisp__frep_octree_free(&m.o);
    crisp_free(m.regs);
    crisp_free(m.gregs);
    crisp_free(m.table);
    return s;
}
