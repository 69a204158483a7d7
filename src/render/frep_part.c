/* f-rep parts in a crisp scene (docs/design.md section 7), drawn through the perspective camera of
 * docs/design.md section 6 and composited with what the image already holds by camera-space depth.
 *
 * Method (Keeter 2012's z-culled heightmaps with branch caching, carried into the view frustum;
 * tape shortening and batched leaves as in Fidget): a cell is a rectangle of pixel centres times
 * a camera-space depth interval [z0, z1]. A camera-space point is P = eye + z (f + nx r + ny u)
 * with nx, ny the normalised image coordinates, so the part's local coordinates Q = M^-1 P are
 * multilinear in (nx, ny, z) and a cell's 8 corners bound them: their box (rounded outwards to
 * float) goes to the interval evaluator (src/frep/cell.c), which also records which side of each
 * min/max wins, and the cell's children get the tape shortened after those choices. Cells where
 * f >= 0 are skipped; cells that start behind every pixel's current depth are culled (z-culling,
 * and each hit lowers the depth at once); cells where f < 0 give their pixels a hit at their
 * near depth; other cells split every axis at least half as long as the longest one (depth
 * counted in pixel footprints at the cell's far end), near depth half first, down to leaves of
 * at most LEAF x LEAF pixels and LEAF_DEPTH footprints. In a leaf each pixel's centre ray is
 * sampled every STEP pixel footprints, 64 points (of all the leaf's pixels) per batched
 * evaluation, and the first sign change is narrowed to 1e-7 of the depth by secant-guided
 * multisection (trial_depths), again with every pending pixel's points in one batch. Normals
 * come from the batched gradient of the full tape, 64 hits at a time, mapped to world space by
 * the inverse transpose. Resolution along a ray is STEP footprints: a feature thinner than that
 * along the ray can be missed (as a heightmap misses one thinner than a voxel).
 *
 * The tiles (TILE x TILE pixels, the whole depth range) are shared dynamically among the pool's
 * workers; each worker owns a crisp_frep_cell (allocated once per part and frame), so no cell
 * allocates. */
#include "render_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/frep.h"
#include "crisp/frep_cell.h"

#define TILE 32
#define LEAF 8       /* pixels */
#define LEAF_DEPTH 8 /* pixel footprints */
#define LANES CRISP_FREP_CELL_LANES
/* Sample spacing along a leaf's rays, in pixel footprints at the leaf's far depth. */
#define STEP 1.0
#define MAX_LEVEL 160
#define MAX_SECTIONS 16

#if LEAF * LEAF > LANES
#error "a leaf's pixels must fit in one batch's lanes"
#endif

typedef struct part_view {
    double inv[4][4];                  /* world -> local, m[col][row] */
    double qe[3], qf[3], qr[3], qu[3]; /* Q = qe + z (qf + nx qr + ny qu) */
    float color[4];
    int32_t id;
} part_view;

typedef struct frep_worker {
    crisp_frep_cell *cell;
    int i0, j0;                /* the tile's first pixel */
    uint8_t done[TILE * TILE]; /* the pixel has its hit for this part (the float depth it holds
                                  may round above the hit, so depth alone cannot cull it) */
    int nhit;                  /* hits waiting for their normals */
    int32_t hit_pixel[LANES];
    double hit_depth[LANES];
    float hx[LANES], hy[LANES], hz[LANES];
    crisp_frep_parts_stats st;
    char pad[64];
} frep_worker;

typedef struct frep_ctx {
    const part_view *pv;
    const crisp_camera *cam;
    crisp_image *img;
    frep_worker *workers;
    double f[3], r[3], u[3]; /* camera basis (as crisp_camera_ray) */
    double sx, sy;           /* nx = (2 (i + 0.5) / W - 1) sx, ny = (1 - 2 (j + 0.5) / H) sy */
    double pix;              /* one pixel in normalised image units (footprint / depth) */
    int tiles_x;
    int per_pixel, shorten;
    int wx, wy, ww, wh; /* the window of the camera's image that img holds (desc->window) */
} frep_ctx;

/* Index in img of pixel (i, j) of the camera's image. */
static size_t pix(const frep_ctx *c, int i, int j)
{
    return (size_t)(j - c->wy) * (size_t)c->ww + (size_t)(i - c->wx);
}

static double nx_of(const frep_ctx *c, double i)
{
    return (2.0 * (i + 0.5) / c->cam->width - 1.0) * c->sx;
}
static double ny_of(const frep_ctx *c, double j)
{
    return (1.0 - 2.0 * (j + 0.5) / c->cam->height) * c->sy;
}

static float round_down(double v)
{
    float f = (float)v;
    if (!((double)f <= v)) f = nextafterf(f, -INFINITY);
    return nextafterf(f, -INFINITY); /* one more ulp for the double rounding of the corners */
}

static float round_up(double v)
{
    float f = (float)v;
    if (!((double)f >= v)) f = nextafterf(f, INFINITY);
    return nextafterf(f, INFINITY);
}

/* Interval of f over the box of local points Q(nx, ny, z), nx in [a0, a1], ny in [b0, b1],
 * z in [z0, z1] (multilinear, so the corners bound it); records the min/max choices. */
static size_t cell_interval(const part_view *pv, crisp_frep_cell *cell, crisp_frep_subtape t,
                            double a0, double a1, double b0, double b1, double z0, double z1,
                            float dest[2])
{
    float box[3][2];
    for (int k = 0; k < 3; k++) {
        double lo = INFINITY, hi = -INFINITY;
        for (int c = 0; c < 8; c++) {
            double nx = c & 1 ? a1 : a0, ny = c & 2 ? b1 : b0, z = c & 4 ? z1 : z0;
            double q = pv->qe[k] + z * (pv->qf[k] + nx * pv->qr[k] + ny * pv->qu[k]);
            lo = q < lo ? q : lo;
            hi = q > hi ? q : hi;
        }
        box[k][0] = round_down(lo);
        box[k][1] = round_up(hi);
    }
    return crisp_frep_cell_interval(cell, t, box[0], box[1], box[2], dest);
}

static void local_point(const part_view *pv, double nx, double ny, double z, float *qx, float *qy,
                        float *qz)
{
    *qx = (float)(pv->qe[0] + z * (pv->qf[0] + nx * pv->qr[0] + ny * pv->qu[0]));
    *qy = (float)(pv->qe[1] + z * (pv->qf[1] + nx * pv->qr[1] + ny * pv->qu[1]));
    *qz = (float)(pv->qe[2] + z * (pv->qf[2] + nx * pv->qr[2] + ny * pv->qu[2]));
}

/* Depth limit of pixel p: what it holds, within the camera's far plane. */
static double pixel_limit(const frep_ctx *c, size_t p)
{
    double d = c->img->depth[p];
    return d < c->cam->zfar ? d : c->cam->zfar;
}

/* Normals and shading of the worker's pending hits, through tape t (valid at every hit). */
static void flush_hits(const frep_ctx *c, frep_worker *w)
{
    crisp_frep_subtape t = crisp_frep_cell_full(w->cell);
    int n = w->nhit;
    if (n == 0) return;
    for (int k = n; k < LANES; k++)
        w->hx[k] = w->hx[0], w->hy[k] = w->hy[0], w->hz[k] = w->hz[0];
    const float *g = crisp_frep_cell_grad(w->cell, t, w->hx, w->hy, w->hz);
    const part_view *pv = c->pv;
    int W = c->ww;
    for (int k = 0; k < n; k++) {
        size_t p = (size_t)w->hit_pixel[k];
        int i = c->wx + (int)(p % (size_t)W), j = c->wy + (int)(p / (size_t)W);
        double nx = nx_of(c, i), ny = ny_of(c, j), z = w->hit_depth[k];
        double view[3], nrm[3] = {0, 0, 0};
        for (int a = 0; a < 3; a++)
            view[a] = z * (c->f[a] + nx * c->r[a] + ny * c->u[a]);
        for (int a = 0; a < 3; a++) /* world gradient = (M^-1)^T local gradient */
            for (int b = 0; b < 3; b++)
                nrm[a] += pv->inv[a][b] * (double)g[(1 + b) * LANES + k];
        double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        if (!(len > 0) || !isfinite(len)) {
            for (int a = 0; a < 3; a++)
                nrm[a] = -c->f[a]; /* no gradient: face the camera */
            len = 1;
        }
        for (int a = 0; a < 3; a++)
            c->img->normal[3 * p + a] = (float)(nrm[a] / len);
        crisp__shade(pv->color, nrm, view, c->img->rgba + 4 * p);
        c->img->rgba[4 * p + 3] = pv->color[3];
        c->img->uv[2 * p] = c->img->uv[2 * p + 1] = 0;
        c->img->face[p] = pv->id;
    }
    w->nhit = 0;
}

/* Pixel (i, j)'s first inside depth is z: record it when nearer than what the pixel holds. */
static void record_hit(const frep_ctx *c, frep_worker *w, int i, int j, double z)
{
    size_t p = pix(c, i, j);
    if (!(z < c->img->depth[p])) return;
    c->img->depth[p] = (float)z; /* z-culls the rest of this pixel at once */
    w->st.hits++;
    w->done[(j - w->j0) * TILE + (i - w->i0)] = 1;
    int k = w->nhit++;
    w->hit_pixel[k] = (int32_t)p;
    w->hit_depth[k] = z;
    local_point(c->pv, nx_of(c, i), ny_of(c, j), z, &w->hx[k], &w->hy[k], &w->hz[k]);
    if (w->nhit == LANES) flush_hits(c, w);
}

/* The cell is inside everywhere: each open pixel's first inside depth is the cell's near one
 * (every nearer depth of its ray was shown outside or lies between two outside samples). */
static void fill_cell(const frep_ctx *c, frep_worker *w, int i0, int j0, int i1, int j1, double z0)
{
    for (int j = j0; j < j1; j++)
        for (int i = i0; i < i1; i++)
            if (!w->done[(j - w->j0) * TILE + (i - w->i0)] && z0 < pixel_limit(c, pix(c, i, j)))
                record_hit(c, w, i, j, z0);
}

static const float *eval_batch(frep_worker *w, crisp_frep_subtape t, int m, float *x, float *y,
                               float *z)
{
    for (int k = m; k < LANES; k++)
        x[k] = x[0], y[k] = y[0], z[k] = z[0];
    w->st.batches++;
    w->st.points += (size_t)m;
    w->st.tape_sum += t.length;
    return crisp_frep_cell_eval(w->cell, t, x, y, z);
}

/* Pixel states in a leaf. */
enum { PX_SAMPLING, PX_BRACKET, PX_DONE };

/* Trial depths inside the bracket (a, b) for one round of the root search, ascending. With the
 * values fa >= 0 at a and fb < 0 at b known: pairs of points around the secant estimate, 2^-6,
 * 2^-12 and 2^-18 of the bracket apart as lanes allow (a smooth f has its root very close to
 * the estimate, and the bracket then shrinks by up to 2^18 in one round), plus at least two
 * evenly spread points, so that it shrinks by a factor 3 whatever f does. With fewer than four
 * lanes: one point, at the (Illinois-weighted) secant estimate, or at the middle when slow says
 * that the last two rounds did not halve the bracket (as Brent's method guards the secant). */
static int trial_depths(double a, double b, float fa, float fb, int e, int round, int slow,
                        double *dest)
{
    int n = 0;
    if (round == 0 && !(fa == fa)) {
        /* f(a) unknown (a nearer cell sampled it): evaluate it with an even multisection */
        dest[n++] = a;
        for (int d = 1; d < e; d++)
            dest[n++] = a + (b - a) * d / e;
        return n;
    }
    int secant = isfinite(fa) && isfinite(fb) && fa > fb;
    double s = secant ? (double)fa / ((double)fa - (double)fb) : 0.5;
    if (e < 4) {
        if (fa == 0)
            s = 1.0 / 16; /* f(a) = 0: the sign changes just after a (the secant's 0 stalls) */
        if (slow) s = 0.5;
        s = s < 0x1p-20 ? 0x1p-20 : s > 1 - 0x1p-20 ? 1 - 0x1p-20 : s;
        dest[0] = a + (b - a) * s;
        return 1;
    }
    int pairs = secant ? (e >= 8 ? 3 : e >= 6 ? 2 : 1) : 0;
    int even = e - 2 * pairs;
    double t[MAX_SECTIONS];
    for (int d = 1; d <= even; d++)
        t[n++] = (double)d / (even + 1);
    for (int k = 1; k <= pairs; k++) {
        double g = ldexp(0.5, -6 * k);
        double c = s < g ? g : s > 1 - g ? 1 - g : s;
        t[n++] = c - g;
        t[n++] = c + g;
    }
    for (int i = 1; i < n; i++) /* insertion sort of at most MAX_SECTIONS */
        for (int j = i; j > 0 && t[j] < t[j - 1]; j--) {
            double tmp = t[j];
            t[j] = t[j - 1], t[j - 1] = tmp;
        }
    for (int i = 0; i < n; i++)
        dest[i] = a + (b - a) * t[i];
    return n;
}

/* A leaf: pixels [i0, i1) x [j0, j1) (at most LANES), depths [z0, z1]. */
static void leaf(const frep_ctx *c, frep_worker *w, crisp_frep_subtape t, int i0, int j0, int i1,
                 int j1, double z0, double z1)
{
    const part_view *pv = c->pv;
    int pi[LANES], pj[LANES], state[LANES], next[LANES], count[LANES], side[LANES], slow[LANES];
    int np = 0;
    double nx[LANES], ny[LANES], zb[LANES], ba[LANES], bb[LANES], w2[LANES];
    float fa[LANES], fb[LANES], last[LANES];
    double h = STEP * c->pix * z1;
    int first = z0 <= c->cam->znear; /* the frustum's start: no nearer cell sampled it */
    for (int j = j0; j < j1; j++)
        for (int i = i0; i < i1; i++) {
            if (w->done[(j - w->j0) * TILE + (i - w->i0)]) continue;
            double lim = pixel_limit(c, pix(c, i, j));
            double end = lim < z1 ? lim : z1;
            if (!(end > z0)) continue;
            double n = ceil((end - z0) / h);
            pi[np] = i, pj[np] = j;
            nx[np] = nx_of(c, i), ny[np] = ny_of(c, j);
            zb[np] = end;
            count[np] = n < 1 ? 1 : n > 4096 ? 4096 : (int)n;
            next[np] = first ? 0 : 1;
            last[np] = NAN; /* the value at z0 when a nearer cell sampled it is not kept */
            state[np] = PX_SAMPLING;
            np++;
        }
    w->st.leaves++;
    float x[LANES], y[LANES], z[LANES];
    int lane_q[LANES], lane_k[LANES];
    double lane_z[LANES];
    /* sampling: the open pixels share the lanes, consecutive samples of one pixel together */
    int open = np;
    while (open > 0) {
        int each = LANES / open, m = 0;
        for (int q = 0; q < np && m < LANES; q++) {
            if (state[q] != PX_SAMPLING) continue;
            for (int d = 0; d < each && next[q] + d <= count[q] && m < LANES; d++) {
                int k = next[q] + d;
                double zk = k == count[q] ? zb[q] : z0 + (zb[q] - z0) * k / count[q];
                lane_q[m] = q, lane_k[m] = k, lane_z[m] = zk;
                local_point(pv, nx[q], ny[q], zk, &x[m], &y[m], &z[m]);
                m++;
            }
        }
        const float *v = eval_batch(w, t, m, x, y, z);
        for (int k = 0; k < m; k++) {
            int q = lane_q[k];
            if (state[q] != PX_SAMPLING) continue; /* decided by an earlier lane */
            if (v[k] < 0) {
                open--;
                if (lane_k[k] == 0) {
                    state[q] = PX_DONE;
                    record_hit(c, w, pi[q], pj[q], z0);
                } else {
                    state[q] = PX_BRACKET;
                    int kp = lane_k[k] - 1;
                    ba[q] = kp == 0 ? z0 : z0 + (zb[q] - z0) * kp / count[q];
                    bb[q] = lane_z[k];
                    fa[q] = last[q];
                    fb[q] = v[k];
                    side[q] = 0;
                    slow[q] = 0;
                    w2[q] = INFINITY;
                }
            } else {
                last[q] = v[k];
                if (k + 1 == m || lane_q[k + 1] != q) {
                    next[q] =
                        lane_k[k] + 1; /* every sample of this pixel in the batch was outside */
                    if (next[q] > count[q]) {
                        state[q] = PX_DONE;
                        open--;
                    }
                }
            }
        }
    }
    /* root search in each bracket [a, b] (f(a) not < 0, f(b) < 0) down to float precision */
    int pending = 0;
    for (int q = 0; q < np; q++)
        pending += state[q] == PX_BRACKET;
    for (int round = 0; pending > 0; round++) {
        int each = LANES / pending, m = 0;
        if (each > MAX_SECTIONS) each = MAX_SECTIONS;
        for (int q = 0; q < np; q++) {
            if (state[q] != PX_BRACKET) continue;
            double zt[MAX_SECTIONS];
            int e = trial_depths(ba[q], bb[q], fa[q], fb[q], each, round, slow[q], zt);
            for (int d = 0; d < e; d++) {
                lane_q[m] = q, lane_z[m] = zt[d];
                local_point(pv, nx[q], ny[q], zt[d], &x[m], &y[m], &z[m]);
                m++;
            }
        }
        const float *v = eval_batch(w, t, m, x, y, z);
        w->st.root_batches++;
        for (int k = 0; k < m;) {
            int q = lane_q[k], e = k;
            while (e < m && lane_q[e] == q)
                e++;
            double a = ba[q], b = bb[q];
            int hit = -1;
            for (int s = k; s < e && hit < 0; s++)
                if (v[s] < 0) hit = s;
            int moved = 0; /* 1: a moved, 2: b moved */
            if (hit >= 0) {
                b = lane_z[hit], fb[q] = v[hit], moved = 2;
                if (hit > k) a = lane_z[hit - 1], fa[q] = v[hit - 1], moved = 3;
            } else {
                a = lane_z[e - 1], fa[q] = v[e - 1], moved = 1;
            }
            if (e - k == 1) {
                /* Illinois: an end kept twice in a row has its value halved, so that the
                 * secant estimate moves past the root and both ends converge */
                if (moved == 2 && side[q] == 2) fa[q] *= 0.5f;
                if (moved == 1 && side[q] == 1) fb[q] *= 0.5f;
            }
            side[q] = moved;
            int stuck = round > 0 && !(a > ba[q] || b < bb[q]);
            slow[q] = b - a > 0.5 * w2[q]; /* the width two rounds ago */
            w2[q] = bb[q] - ba[q];
            ba[q] = a, bb[q] = b;
            if (b - a <= 1e-7 * b || stuck || round >= 64) {
                state[q] = PX_DONE;
                pending--;
                record_hit(c, w, pi[q], pj[q], b);
            }
            k = e;
        }
    }
}

/* Cell: pixels [i0, i1) x [j0, j1), depths [z0, z1], evaluated with tape t. */
static void solve_cell(const frep_ctx *c, frep_worker *w, crisp_frep_subtape t, int i0, int j0,
                       int i1, int j1, double z0, double z1, int level)
{
    double zmax = 0;
    for (int j = j0; j < j1; j++)
        for (int i = i0; i < i1; i++)
            if (!w->done[(j - w->j0) * TILE + (i - w->i0)]) {
                double lim = pixel_limit(c, pix(c, i, j));
                zmax = lim > zmax ? lim : zmax;
            }
    if (z0 >= zmax) return; /* z-culled */
    if (z1 > zmax) z1 = zmax;
    double a0 = nx_of(c, i0), a1 = nx_of(c, i1 - 1), b0 = ny_of(c, j1 - 1), b1 = ny_of(c, j0);
    float iv[2];
    size_t decided = cell_interval(c->pv, w->cell, t, a0, a1, b0, b1, z0, z1, iv);
    w->st.intervals++;
    if (iv[0] >= 0) return; /* outside everywhere (f = 0 is not inside) */
    size_t mark = crisp_frep_cell_mark(w->cell);
    crisp_frep_subtape ct = decided && c->shorten ? crisp_frep_cell_shorten(w->cell, t) : t;
    /* split every axis at least half as long as the longest one (depth in pixel footprints at
     * the far end) and longer than a leaf's; near depth half first */
    int wx = i1 - i0, wy = j1 - j0;
    double wz = (z1 - z0) / (c->pix * z1), big = fmax(fmax(wx, wy), wz);
    int sx = wx > LEAF && 2 * wx >= big, sy = wy > LEAF && 2 * wy >= big;
    int sz = wz > LEAF_DEPTH && 2 * wz >= big;
    if (iv[1] < 0) {
        w->st.filled++;
        fill_cell(c, w, i0, j0, i1, j1, z0);
    } else if ((sx || sy || sz) && level < MAX_LEVEL) {
        int im = sx ? i0 + wx / 2 : i1, jm = sy ? j0 + wy / 2 : j1;
        double zm = sz ? 0.5 * (z0 + z1) : z1;
        for (int kz = 0; kz <= sz; kz++)
            for (int jy = 0; jy <= sy; jy++)
                for (int ix = 0; ix <= sx; ix++)
                    solve_cell(c, w, ct, ix ? im : i0, jy ? jm : j0, ix ? i1 : im, jy ? j1 : jm,
                               kz ? zm : z0, kz ? z1 : zm, level + 1);
    } else {
        leaf(c, w, ct, i0, j0, i1, j1, z0, z1);
    }
    crisp_frep_cell_release(w->cell, mark);
}

static void render_tiles(void *ctx, size_t begin, size_t end, int worker)
{
    const frep_ctx *c = ctx;
    frep_worker *w = &c->workers[worker];
    crisp_frep_subtape full = crisp_frep_cell_full(w->cell);
    for (size_t t = begin; t < end; t++) {
        int i0 = c->wx + (int)(t % (size_t)c->tiles_x) * TILE,
            j0 = c->wy + (int)(t / (size_t)c->tiles_x) * TILE;
        w->i0 = i0, w->j0 = j0;
        w->nhit = 0;
        memset(w->done, 0, sizeof w->done);
        int i1 = i0 + TILE < c->wx + c->ww ? i0 + TILE : c->wx + c->ww;
        int j1 = j0 + TILE < c->wy + c->wh ? j0 + TILE : c->wy + c->wh;
        if (c->per_pixel) {
            for (int j = j0; j < j1; j++)
                for (int i = i0; i < i1; i++)
                    solve_cell(c, w, full, i, j, i + 1, j + 1, c->cam->znear, c->cam->zfar, 0);
        } else {
            solve_cell(c, w, full, i0, j0, i1, j1, c->cam->znear, c->cam->zfar, 0);
        }
        flush_hits(c, w);
    }
}

static crisp_status part_view_init(const crisp_frep_part *part, size_t k, const crisp_camera *cam,
                                   const frep_ctx *c, part_view *pv)
{
    crisp_mat4 m;
    memcpy(m, part->transform, sizeof m);
    if (!part->tape) return crisp_error(CRISP_ERR_INVALID_ARG, "f-rep part %zu: no tape", k);
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++)
            if (!isfinite(m[a][b]))
                return crisp_error(CRISP_ERR_INVALID_ARG, "f-rep part %zu: non-finite transform",
                                   k);
    if (m[0][3] != 0 || m[1][3] != 0 || m[2][3] != 0 || m[3][3] != 1)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "f-rep part %zu: transform is not affine (expected last row 0 0 0 1)",
                           k);
    memset(pv, 0, sizeof *pv);
    if (!crisp_mat4_inverse(m, pv->inv))
        return crisp_error(CRISP_ERR_INVALID_ARG, "f-rep part %zu: transform is singular", k);
    memcpy(pv->color, part->color, sizeof pv->color);
    pv->id = CRISP_FREP_FACE_ID(k);
    /* Q = inv (eye + z d): columns of inv are m[col][row]. */
    for (int a = 0; a < 3; a++) {
        pv->qe[a] = pv->inv[3][a];
        for (int b = 0; b < 3; b++) {
            pv->qe[a] += pv->inv[b][a] * cam->eye[b];
            pv->qf[a] += pv->inv[b][a] * c->f[b];
            pv->qr[a] += pv->inv[b][a] * c->r[b];
            pv->qu[a] += pv->inv[b][a] * c->u[b];
        }
    }
    return CRISP_OK;
}

crisp_status crisp_render_frep_parts(const crisp_frep_part *parts, size_t count,
                                     const crisp_camera *cam, const crisp_frep_parts_desc *desc,
                                     crisp_image *img)
{
    crisp_status st = crisp_camera_check(cam);
    if (st) return st;
    int win[4] = {0, 0, cam->width, cam->height};
    if (desc && (desc->window[2] || desc->window[3])) memcpy(win, desc->window, sizeof win);
    if (win[0] < 0 || win[1] < 0 || win[2] < 1 || win[3] < 1 || win[0] + win[2] > cam->width ||
        win[1] + win[3] > cam->height || win[0] % TILE || win[1] % TILE)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "window %dx%d at (%d, %d) of the %dx%d image: expected a window inside "
                           "the image at a multiple of %d",
                           win[2], win[3], win[0], win[1], cam->width, cam->height, TILE);
    if (img->width != win[2] || img->height != win[3])
        return crisp_error(CRISP_ERR_INVALID_ARG, "image %dx%d does not match the camera's %dx%d",
                           img->width, img->height, win[2], win[3]);
    if (count == 0) return CRISP_OK;
    if (!parts) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_render_frep_parts: NULL parts");
    frep_ctx c = {.cam = cam,
                  .img = img,
                  .per_pixel = desc && desc->per_pixel,
                  .shorten = !(desc && desc->no_shorten),
                  .wx = win[0],
                  .wy = win[1],
                  .ww = win[2],
                  .wh = win[3]};
    crisp_vec3 d;
    crisp_vec3_sub(cam->target, cam->eye, d);
    crisp_vec3_normalize(d, c.f);
    crisp_vec3_cross(c.f, cam->up, d);
    crisp_vec3_normalize(d, c.r);
    crisp_vec3_cross(c.r, c.f, c.u);
    double t = tan(cam->fov_deg * (M_PI / 360.0));
    c.sx = t * cam->width / cam->height;
    c.sy = t;
    c.pix = 2.0 * t / cam->height;
    c.tiles_x = (win[2] + TILE - 1) / TILE;
    size_t tiles = (size_t)c.tiles_x * (size_t)((win[3] + TILE - 1) / TILE);
    crisp_pool *pool = NULL;
    int threads = desc && desc->threads > 0 ? desc->threads : crisp_pool_default_threads();
    if ((st = crisp_pool_get(threads, &pool))) return st; /* kept by crisp: no threads per call */
    threads = crisp_pool_threads(pool);
    c.workers = crisp_calloc_array((size_t)threads, sizeof *c.workers);
    if (!c.workers)
        return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_render_frep_parts: out of memory");
    for (size_t k = 0; k < count && !st; k++) {
        part_view pv;
        if ((st = part_view_init(&parts[k], k, cam, &c, &pv))) break;
        c.pv = &pv;
        for (int i = 0; i < threads && !st; i++)
            st = crisp_frep_cell_create(parts[k].tape, 0, &c.workers[i].cell);
        if (!st) crisp_pool_parallel_for(pool, tiles, 1, render_tiles, &c);
        for (int i = 0; i < threads; i++) {
            crisp_frep_cell_destroy(c.workers[i].cell);
            c.workers[i].cell = NULL;
        }
    }
    if (desc && desc->stats) {
        crisp_frep_parts_stats *s = desc->stats;
        memset(s, 0, sizeof *s);
        for (int i = 0; i < threads; i++) {
            const crisp_frep_parts_stats *a = &c.workers[i].st;
            s->intervals += a->intervals;
            s->filled += a->filled;
            s->leaves += a->leaves;
            s->batches += a->batches;
            s->root_batches += a->root_batches;
            s->points += a->points;
            s->tape_sum += a->tape_sum;
            s->hits += a->hits;
        }
    }
    crisp_free(c.workers);
    return st;
}
