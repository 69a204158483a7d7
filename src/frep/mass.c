/* Integral properties of f-rep parts by block decomposition (Clark, "Integral properties of CSG
 * solids", PADL-2): the region's octree to a level, with Keeter's interval classification and
 * the tape shortened per cell. Cells proven inside add their exact box moments; cells proven
 * outside are dropped; each boundary cell at the level is sampled with one jittered point per
 * octant (stratified Monte Carlo), its 8 children first classified by one batched interval pass
 * so that children proven inside or outside are exact too. Per cell the 10 integrands' sample
 * covariance gives the variance (conservatively, as if the 8 points were independent); cells are
 * independent strata, so variances add. The centroid and the inertia about it are ratios of the
 * totals: their standard errors follow by the delta method.
 *
 * Interval boxes are widened to float bounds that contain the cell (nextafterf), so "proven
 * inside" holds for every real point of the cell whose float coordinates give f < 0: the volume
 * bounds are certified for the part as the evaluators define it. Coordinates are taken about
 * the region's centre so that second moments keep their precision. */
#include "crisp/frep_mass.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "frep_octree.h"

#define NQ 10 /* 1, x, y, z, xx, yy, zz, xy, yz, xz */
#define NCOV (NQ * (NQ + 1) / 2)

typedef struct masser {
    const crisp_frep_tape *t;
    frep_octree o;
    int level;
    double r0[3], w[3]; /* region origin and cell edges at the level */
    double ctr[3];      /* the region's centre (moments are taken about it) */
    long n[3];          /* cells per axis at the level */
    uint64_t seed;
    double T[NQ];   /* exact parts (inside cells) and estimates (boundary cells) */
    double C[NCOV]; /* covariance of the totals */
    float *lo, *hi, *regs;
    crisp_frep_mass *out;
} masser;

static uint64_t mix(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* float bounds containing [a, b] */
static void fbox(double a, double b, float *lo, float *hi)
{
    float l = (float)a, h = (float)b;
    if ((double)l > a) l = nextafterf(l, -INFINITY);
    if ((double)h < b) h = nextafterf(h, INFINITY);
    *lo = l, *hi = h;
}

/* the exact moments of the box [a0,a1] x [b0,b1] x [c0,c1] (centred coordinates) */
static void box_moments(const double a[2], const double b[2], const double c[2], double T[NQ])
{
    double dx = a[1] - a[0], dy = b[1] - b[0], dz = c[1] - c[0];
    double v = dx * dy * dz;
    double mx = 0.5 * (a[0] + a[1]), my = 0.5 * (b[0] + b[1]), mz = 0.5 * (c[0] + c[1]);
    /* integral of x^2 over [a0, a1] / dx = mean^2 + dx^2 / 12 */
    T[0] += v;
    T[1] += v * mx, T[2] += v * my, T[3] += v * mz;
    T[4] += v * (mx * mx + dx * dx / 12);
    T[5] += v * (my * my + dy * dy / 12);
    T[6] += v * (mz * mz + dz * dz / 12);
    T[7] += v * mx * my, T[8] += v * my * mz, T[9] += v * mx * mz;
}

static void cell_coords(const masser *m, const long i[3], long size, double a[3][2])
{
    for (int k = 0; k < 3; k++) {
        a[k][0] = m->r0[k] + (double)i[k] * m->w[k] - m->ctr[k];
        a[k][1] = m->r0[k] + (double)(i[k] + size) * m->w[k] - m->ctr[k];
    }
}

/* Pieces of a face of the region (a box flat on one axis) holding inside points: interval
 * quadtree to depth 7, then 16 sample points per undecided piece. */
static size_t face_cut(masser *m, const double b[6], int depth)
{
    float fb[6];
    for (int k = 0; k < 3; k++)
        fbox(b[2 * k], b[2 * k + 1], &fb[2 * k], &fb[2 * k + 1]);
    const crisp_frep_tape *t = m->t;
    frep_span full = {t->ins, t->ssa, t->length, t->registers};
    int cls = crisp__frep_octree_classify(&m->o, full, fb, NULL);
    if (cls == FREP_CELL_OUT) return 0;
    if (cls == FREP_CELL_IN) return 1;
    int flat = b[0] == b[1] ? 0 : b[2] == b[3] ? 1 : 2, u = (flat + 1) % 3, v = (flat + 2) % 3;
    if (depth >= 7) {
        float x[FREP_LANES], y[FREP_LANES], z[FREP_LANES];
        for (int q = 0; q < FREP_LANES; q++) {
            double p[3];
            p[flat] = b[2 * flat];
            p[u] = b[2 * u] + (b[2 * u + 1] - b[2 * u]) * ((q & 7) + 0.5) / 8;
            p[v] = b[2 * v] + (b[2 * v + 1] - b[2 * v]) * ((q >> 3) + 0.5) / 8;
            x[q] = (float)p[0], y[q] = (float)p[1], z[q] = (float)p[2];
        }
        crisp__frep_eval_lanes(t->ins, t->length, m->regs, x, y, z);
        const float *val = m->regs + (size_t)t->result * FREP_LANES;
        for (int q = 0; q < FREP_LANES; q++)
            if (val[q] < 0) return 1;
        return 0;
    }
    size_t n = 0;
    for (int q = 0; q < 4; q++) {
        double c[6];
        memcpy(c, b, sizeof c);
        double mu = 0.5 * (b[2 * u] + b[2 * u + 1]), mv = 0.5 * (b[2 * v] + b[2 * v + 1]);
        if (q & 1)
            c[2 * u] = mu;
        else
            c[2 * u + 1] = mu;
        if (q & 2)
            c[2 * v] = mv;
        else
            c[2 * v + 1] = mv;
        n += face_cut(m, c, depth + 1);
    }
    return n;
}

/* A boundary cell at level-1 (tape t): its 8 children classified together, inside children
 * exact, boundary children sampled with one jittered point per octant. */
static void sample_cell(masser *m, frep_span t, const long i[3])
{
    float bx[6][FREP_LANES];
    double cc[8][3][2];
    for (int q = 0; q < 16; q++) {
        int c = q & 7;
        long ci[3] = {i[0] + (c & 1), i[1] + ((c >> 1) & 1), i[2] + (c >> 2)};
        double a[3][2];
        cell_coords(m, ci, 1, a);
        if (q < 8) memcpy(cc[c], a, sizeof a);
        for (int k = 0; k < 3; k++)
            fbox(a[k][0] + m->ctr[k], a[k][1] + m->ctr[k], &bx[2 * k][q], &bx[2 * k + 1][q]);
    }
    const float *box[6] = {bx[0], bx[1], bx[2], bx[3], bx[4], bx[5]};
    crisp__frep_interval_lanes(t.ins, t.len, 16, m->lo, m->hi, box, NULL, NULL);
    m->out->intervals += 8;
    m->out->cell_ops += t.len;
    uint16_t res = t.ins[t.len - 1].out;
    int cls[8];
    for (int c = 0; c < 8; c++) {
        float l = m->lo[(size_t)res * FREP_LANES + c], h = m->hi[(size_t)res * FREP_LANES + c];
        cls[c] = l != l ? 2 : l >= 0 ? 0 : h < 0 ? 1 : 2;
    }
    float x[FREP_LANES], y[FREP_LANES], z[FREP_LANES];
    double px[FREP_LANES][3];
    for (int c = 0; c < 8; c++) {
        long ci[3] = {i[0] + (c & 1), i[1] + ((c >> 1) & 1), i[2] + (c >> 2)};
        if (cls[c] == 1) {
            box_moments(cc[c][0], cc[c][1], cc[c][2], m->T);
            m->out->inside_cells++;
            m->out->volume_hi += (cc[c][0][1] - cc[c][0][0]) * (cc[c][1][1] - cc[c][1][0]) *
                                 (cc[c][2][1] - cc[c][2][0]);
        }
        uint64_t s =
            mix(m->seed ^
                mix((uint64_t)ci[0] ^
                    mix((uint64_t)ci[1] ^ mix((uint64_t)ci[2] + (uint64_t)m->level * 0x1000003))));
        for (int o = 0; o < 8; o++) {
            int lane = 8 * c + o;
            for (int k = 0; k < 3; k++) {
                s = mix(s);
                double u = ((double)(s >> 11) + 0.5) * 0x1.0p-53; /* (0, 1) */
                int half = (o >> k) & 1;
                double lo = cc[c][k][0], w = cc[c][k][1] - cc[c][k][0];
                px[lane][k] = lo + w * 0.5 * (half + u);
            }
            x[lane] = (float)(px[lane][0] + m->ctr[0]);
            y[lane] = (float)(px[lane][1] + m->ctr[1]);
            z[lane] = (float)(px[lane][2] + m->ctr[2]);
        }
    }
    crisp__frep_eval_lanes(t.ins, t.len, m->regs, x, y, z);
    const float *v = m->regs + (size_t)res * FREP_LANES;
    for (int c = 0; c < 8; c++) {
        if (cls[c] != 2) continue;
        double vol =
            (cc[c][0][1] - cc[c][0][0]) * (cc[c][1][1] - cc[c][1][0]) * (cc[c][2][1] - cc[c][2][0]);
        m->out->boundary_cells++;
        m->out->volume_hi += vol;
        m->out->samples += 8;
        double q[8][NQ], mean[NQ] = {0};
        int any = 0;
        for (int o = 0; o < 8; o++) {
            int lane = 8 * c + o;
            double chi = v[lane] < 0 ? 1 : 0, X = px[lane][0], Y = px[lane][1], Z = px[lane][2];
            any |= chi > 0;
            double *r = q[o];
            r[0] = chi, r[1] = chi * X, r[2] = chi * Y, r[3] = chi * Z;
            r[4] = chi * X * X, r[5] = chi * Y * Y, r[6] = chi * Z * Z;
            r[7] = chi * X * Y, r[8] = chi * Y * Z, r[9] = chi * X * Z;
            for (int k = 0; k < NQ; k++)
                mean[k] += r[k] / 8;
        }
        if (!any) continue;
        for (int k = 0; k < NQ; k++)
            m->T[k] += vol * mean[k];
        /* covariance of the cell's total: vol^2 * S / 8, S the sample covariance */
        int p = 0;
        for (int a = 0; a < NQ; a++)
            for (int b = a; b < NQ; b++, p++) {
                double s = 0;
                for (int o = 0; o < 8; o++)
                    s += (q[o][a] - mean[a]) * (q[o][b] - mean[b]);
                m->C[p] += vol * vol * s / 7 / 8;
            }
    }
}

static void walk(masser *m, frep_span t, const long i[3], long size, int depth)
{
    double a[3][2];
    cell_coords(m, i, size, a);
    float b[6];
    for (int k = 0; k < 3; k++)
        fbox(a[k][0] + m->ctr[k], a[k][1] + m->ctr[k], &b[2 * k], &b[2 * k + 1]);
    size_t d;
    int cls = crisp__frep_octree_classify(&m->o, t, b, &d);
    m->out->intervals++;
    m->out->walk_ops += t.len;
    if (cls == FREP_CELL_OUT) return;
    if (cls == FREP_CELL_IN) {
        box_moments(a[0], a[1], a[2], m->T);
        m->out->inside_cells++;
        double v = (a[0][1] - a[0][0]) * (a[1][1] - a[1][0]) * (a[2][1] - a[2][0]);
        m->out->volume_hi += v;
        return;
    }
    frep_span ct = t;
    if (d && depth < m->o.max_depth) {
        frep_span out;
        size_t len = m->t->length;
        if (!crisp__frep_shorten(t, m->o.choices, &m->o.sc, m->o.tapes + (size_t)depth * len,
                                 m->o.ssas + 2 * (size_t)depth * len, &out))
            ct = out;
    }
    if (size == 2) {
        sample_cell(m, ct, i);
        return;
    }
    long c = size / 2;
    for (int q = 0; q < 8; q++) {
        long ci[3] = {i[0] + (q & 1) * c, i[1] + ((q >> 1) & 1) * c, i[2] + (q >> 2) * c};
        walk(m, ct, ci, c, depth + 1);
    }
}

crisp_status crisp_frep_mass_level(const crisp_frep_tape *t, const crisp_frep_mass_desc *desc,
                                   crisp_frep_mass *dest)
{
    if (!t || !desc || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_mass_level: NULL argument");
    memset(dest, 0, sizeof *dest);
    double t0 = crisp_time_now();
    struct timespec c0;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
    int level = desc->level ? desc->level : 6;
    if (level < 1 || level > 20)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_frep_mass_level: level %d is outside 1..20", level);
    double r[6];
    int zero = 1;
    for (int k = 0; k < 6; k++)
        zero &= desc->region[k] == 0;
    if (zero) {
        crisp_frep_fit fit;
        crisp_status s = crisp_frep_fit_region(t, &(crisp_frep_fit_desc){0}, &fit);
        if (!s) s = crisp_frep_fit_check(&fit, 0);
        if (s) return s;
        for (int a = 0; a < 3; a++) {
            double mid = 0.5 * (fit.box[2 * a] + fit.box[2 * a + 1]),
                   half = 0.51 * (fit.box[2 * a + 1] - fit.box[2 * a]);
            if (!(half > 0)) half = fit.cell > 0 ? fit.cell : 1e-3;
            r[2 * a] = mid - half, r[2 * a + 1] = mid + half;
        }
    } else {
        memcpy(r, desc->region, sizeof r);
    }
    for (int a = 0; a < 3; a++)
        if (!(r[2 * a] < r[2 * a + 1]) || !isfinite(r[2 * a]) || !isfinite(r[2 * a + 1]))
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "crisp_frep_mass_level: region axis %d [%g, %g] is empty", a,
                               r[2 * a], r[2 * a + 1]);
    masser m = {.t = t, .level = level, .seed = desc->seed, .out = dest};
    long n = 1L << level;
    for (int a = 0; a < 3; a++) {
        m.r0[a] = r[2 * a];
        m.w[a] = (r[2 * a + 1] - r[2 * a]) / (double)n;
        m.ctr[a] = 0.5 * (r[2 * a] + r[2 * a + 1]);
        m.n[a] = n;
        dest->cell[a] = m.w[a];
    }
    memcpy(dest->region, r, sizeof r);
    dest->level = level;
    crisp_status s = crisp__frep_octree_init(&m.o, t, level);
    if (s) return s;
    size_t nr = (size_t)t->registers;
    m.lo = crisp_malloc_array(nr * 2 * FREP_LANES, sizeof *m.lo);
    m.regs = crisp_malloc_array(nr * FREP_LANES, sizeof *m.regs);
    if (!m.lo || !m.regs) {
        s = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_mass_level: out of memory");
        goto done;
    }
    m.hi = m.lo + nr * FREP_LANES;
    const frep_span full = {t->ins, t->ssa, t->length, t->registers};
    walk(&m, full, (long[3]){0, 0, 0}, n, 0);

    /* results */
    double V = m.T[0];
    dest->volume = V;
    /* volume_hi sums every cell not proven outside; volume_lo leaves out the boundary cells */
    double cellv = m.w[0] * m.w[1] * m.w[2];
    dest->volume_lo = dest->volume_hi - (double)dest->boundary_cells * cellv;
    if (!(V > 0) && dest->inside_cells == 0) {
        s = crisp_error(
            CRISP_ERR_NUMERIC,
            "the part is empty at level %d: no cell of [%g, %g] x [%g, %g] x [%g, %g] is "
            "inside and no sample is",
            level, r[0], r[1], r[2], r[3], r[4], r[5]);
        goto done;
    }
    double Cm[NQ][NQ];
    for (int a = 0, p = 0; a < NQ; a++)
        for (int b = a; b < NQ; b++, p++)
            Cm[a][b] = Cm[b][a] = m.C[p];
    dest->volume_se = sqrt(Cm[0][0]);
    double M[3] = {m.T[1], m.T[2], m.T[3]};
    for (int a = 0; a < 3; a++) {
        dest->centroid[a] = m.ctr[a] + M[a] / V;
        double g[NQ] = {0};
        g[1 + a] = 1 / V;
        g[0] = -M[a] / (V * V);
        double var = 0;
        for (int i = 0; i < NQ; i++)
            for (int j = 0; j < NQ; j++)
                var += g[i] * Cm[i][j] * g[j];
        dest->centroid_se[a] = sqrt(fmax(var, 0));
    }
    /* inertia about the centroid: diagonal I_aa = S_bb + S_cc - (M_b^2 + M_c^2) / V; products
     * I_ab = -(S_ab - M_a M_b / V) */
    static const int sidx[3] = {4, 5, 6};                   /* S_xx, S_yy, S_zz */
    static const int pidx[3][2] = {{0, 1}, {1, 2}, {0, 2}}; /* xy, yz, xz */
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        double g[NQ] = {0};
        dest->inertia[a] = m.T[sidx[b]] + m.T[sidx[c]] - (M[b] * M[b] + M[c] * M[c]) / V;
        g[sidx[b]] = 1, g[sidx[c]] = 1;
        g[1 + b] = -2 * M[b] / V, g[1 + c] = -2 * M[c] / V;
        g[0] = (M[b] * M[b] + M[c] * M[c]) / (V * V);
        double var = 0;
        for (int i = 0; i < NQ; i++)
            for (int j = 0; j < NQ; j++)
                var += g[i] * Cm[i][j] * g[j];
        dest->inertia_se[a] = sqrt(fmax(var, 0));
    }
    for (int k = 0; k < 3; k++) {
        int a = pidx[k][0], b = pidx[k][1];
        double g[NQ] = {0};
        dest->inertia[3 + k] = -(m.T[7 + k] - M[a] * M[b] / V);
        g[7 + k] = -1;
        g[1 + a] = M[b] / V, g[1 + b] = M[a] / V;
        g[0] = -M[a] * M[b] / (V * V);
        double var = 0;
        for (int i = 0; i < NQ; i++)
            for (int j = 0; j < NQ; j++)
                var += g[i] * Cm[i][j] * g[j];
        dest->inertia_se[3 + k] = sqrt(fmax(var, 0));
    }
    /* does the part reach the region's faces? */
    struct timespec f0;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &f0);
    for (int f = 0; f < 6; f++) {
        double b[6];
        memcpy(b, r, sizeof b);
        b[(f & ~1) + 1 - (f & 1)] = b[f]; /* flat at face f */
        dest->cut_cells += face_cut(&m, b, 0);
    }
    dest->seconds = crisp_time_now() - t0;
    struct timespec c1;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
    dest->cpu_seconds = (double)(c1.tv_sec - c0.tv_sec) + 1e-9 * (double)(c1.tv_nsec - c0.tv_nsec);
    dest->cpu_fixed = (double)(c1.tv_sec - f0.tv_sec) + 1e-9 * (double)(c1.tv_nsec - f0.tv_nsec);
    if (dest->cut_cells)
        s = crisp_error(
            CRISP_ERR_NUMERIC,
            "the region [%g, %g] x [%g, %g] x [%g, %g] cuts the part: %zu pieces of its faces "
            "hold inside points (the result is the part within the region)",
            r[0], r[1], r[2], r[3], r[4], r[5], dest->cut_cells);
done:
    crisp__frep_octree_free(&m.o);
    crisp_free(m.lo);
    crisp_free(m.regs);
    return s;
}

/* Solve the 3 x 3 system A x = b (Gaussian elimination, partial pivoting); 0 when singular. */
static int solve3(double A[3][3], double b[3], int n, double x[3])
{
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int r = c + 1; r < n; r++)
            if (fabs(A[r][c]) > fabs(A[p][c])) p = r;
        if (!(fabs(A[p][c]) > 1e-300)) return 0;
        for (int k = 0; k < n; k++) {
            double t = A[c][k];
            A[c][k] = A[p][k], A[p][k] = t;
        }
        double t = b[c];
        b[c] = b[p], b[p] = t;
        for (int r = 0; r < n; r++) {
            if (r == c) continue;
            double f = A[r][c] / A[c][c];
            for (int k = c; k < n; k++)
                A[r][k] -= f * A[c][k];
            b[r] -= f * b[c];
        }
    }
    for (int c = 0; c < n; c++)
        x[c] = b[c] / A[c][c];
    return 1;
}

void crisp_frep_mass_predict(const crisp_frep_mass *lv, int n, int level, double *seconds,
                             double *se)
{
    /* Time: the check of the region's faces is the same at every level (its mean is taken); the
     * rest, the level's cost C(L), is fitted by least squares over the measured levels to
     * a 4^L + b 2^L + c: Clark's K 4^L for the cells meeting a surface, a term for those along
     * its edges and silhouettes (and the coarse levels' excess), and a per-level overhead. The
     * residuals are relative (each row divided by its C), so that the coarse levels, whose costs
     * are tiny, count as much as the finer ones. With 2 levels: a 4^L + b 2^L through them; with
     * 1: K 4^L. A fit that does not grow at least 4x per level past the last one falls back to
     * 4x per level (a surface). */
    const crisp_frep_mass *b = &lv[n - 1];
    double fixed = 0;
    for (int k = 0; k < n; k++)
        fixed += lv[k].cpu_fixed / n;
    int L0 = b->level;
    double C[24], Ls[24];
    int m = 0;
    for (int k = 0; k < n && m < 24; k++) {
        double c = lv[k].cpu_seconds - lv[k].cpu_fixed;
        if (!(c > 1e-7)) continue;
        C[m] = c, Ls[m++] = lv[k].level - L0; /* basis scaled to the last level: 4^(L - L0) */
    }
    double last = b->cpu_seconds - b->cpu_fixed;
    if (!(last > 1e-7)) last = 1e-7;
    double pred = last * pow(4.0, level - L0);
    int nb = m >= 3 ? 3 : m;
    if (nb >= 2) {
        double A[3][3] = {{0}}, r[3] = {0}, x[3];
        for (int i = 0; i < m; i++) {
            double row[3] = {pow(4.0, Ls[i]) / C[i], pow(2.0, Ls[i]) / C[i], 1 / C[i]};
            for (int p = 0; p < nb; p++) {
                for (int q = 0; q < nb; q++)
                    A[p][q] += row[p] * row[q];
                r[p] += row[p];
            }
        }
        if (solve3(A, r, nb, x)) {
            double d = level - L0;
            double f = x[0] * pow(4.0, d) + x[1] * pow(2.0, d) + (nb > 2 ? x[2] : 0);
            double f1 = x[0] * 4 + x[1] * 2 + (nb > 2 ? x[2] : 0);
            double f0 = x[0] + x[1] + (nb > 2 ? x[2] : 0);
            /* growing (a surface): beyond the last level the fit rises at least 3x per level */
            if (x[0] > 0 && f0 > 0 && f1 >= 3 * f0 && f > 0) pred = f;
        }
    }
    *seconds = fixed + pred;
    /* Error: falls by the last two levels' factor per level (1/4 for a resolved surface:
     * Clark's error ~ K 2^-2L for a sampled boundary) */
    const crisp_frep_mass *a = n >= 2 ? &lv[n - 2] : b;
    double ge = n >= 2 && a->volume_se > 0 ? b->volume_se / a->volume_se : 0.25;
    *se = b->volume_se * pow(ge, level - L0);
}
