/* Trim curve tessellation with a proven deviation bound (Wu & Peters 2015, section 5: the trim
 * polyline must lie within the table's resolution of the true curve).
 *
 * For a polynomial f of degree d in Bernstein form on [0, 1], the chords of n uniform segments
 * deviate from f by at most (1/8) n^-2 max|f''| <= d (d - 1) max|Δ²b| / (8 n²) (Filip, Magedson &
 * Markot 1986). A rational piece c = P / w is handled through its homogeneous form: with the
 * homogeneous chord L = (L_P, L_w), whose projection L_P / L_w runs along the same straight chord,
 *   P / w - L_P / L_w = (e_P - (L_P / L_w) e_w) / w,   e = homogeneous chord errors,
 * so after translating the piece so that its control-point box is centred at 0 (|L_P / L_w| <= r,
 * the box half-size), the Euclidean deviation per coordinate is at most
 *   d (d - 1) (max|Δ² P'| + r max|Δ² w|) / (8 n² min w).
 * Any point classified differently by the polyline and by the curve lies on a segment between c(t)
 * and the polyline point of the same t (the linear homotopy between them must sweep over it), so
 * this per-coordinate deviation is what the trim guarantee needs.
 */
#include "trim_internal.h"

#include <math.h>
#include <string.h>

crisp_status crisp_trim_pieces_check(const crisp_bezier_curve *pieces, int piece_count)
{
    if (piece_count < 0 || (piece_count > 0 && !pieces))
        return crisp_error(CRISP_ERR_INVALID_ARG, "trim pieces: count %d with %s pieces",
                           piece_count, pieces ? "given" : "no");
    for (int k = 0; k < piece_count; k++) {
        const crisp_bezier_curve *b = &pieces[k];
        if (b->dim != 2)
            return crisp_error(CRISP_ERR_INVALID_ARG, "trim piece %d: dim %d, expected 2 (uv)", k,
                               b->dim);
        if (b->degree < 1 || b->degree > CRISP_MAX_DEGREE)
            return crisp_error(CRISP_ERR_INVALID_ARG, "trim piece %d: degree %d, expected 1..%d", k,
                               b->degree, CRISP_MAX_DEGREE);
        for (int i = 0; i <= b->degree; i++) {
            const double *h = b->cpw + 3 * i;
            if (!isfinite(h[0]) || !isfinite(h[1]) || !(h[2] > 0.0) || !isfinite(h[2]))
                return crisp_error(CRISP_ERR_INVALID_ARG,
                                   "trim piece %d control point %d: (%g, %g, w %g), expected "
                                   "finite coordinates and a positive weight",
                                   k, i, h[0], h[1], h[2]);
        }
    }
    return CRISP_OK;
}

/* Segments piece b needs for per-coordinate deviations tol_u and tol_v (> 0). */
static double segments_needed(const crisp_bezier_curve *b, double tol_u, double tol_v)
{
    int d = b->degree;
    if (d < 2) return 1.0; /* a (possibly rational) line segment is its own chord */
    double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL}, wmin = HUGE_VAL;
    for (int i = 0; i <= d; i++) {
        const double *h = b->cpw + 3 * i;
        for (int c = 0; c < 2; c++) {
            lo[c] = crisp__trim_min(lo[c], h[c] / h[2]);
            hi[c] = crisp__trim_max(hi[c], h[c] / h[2]);
        }
        wmin = crisp__trim_min(wmin, h[2]);
    }
    double mw = 0.0, mp[2] = {0.0, 0.0};
    for (int i = 0; i + 2 <= d; i++) {
        const double *h0 = b->cpw + 3 * i, *h1 = h0 + 3, *h2 = h0 + 6;
        mw = crisp__trim_max(mw, fabs(h0[2] - 2 * h1[2] + h2[2]));
        for (int c = 0; c < 2; c++) {
            double ctr = 0.5 * (lo[c] + hi[c]);
            double p0 = h0[c] - ctr * h0[2], p1 = h1[c] - ctr * h1[2], p2 = h2[c] - ctr * h2[2];
            mp[c] = crisp__trim_max(mp[c], fabs(p0 - 2 * p1 + p2));
        }
    }
    double tol[2] = {tol_u, tol_v}, n = 1.0;
    for (int c = 0; c < 2; c++) {
        double r = 0.5 * (hi[c] - lo[c]);
        double num = d * (d - 1) * (mp[c] + r * mw) * (1.0 + 1e-12);
        double need = sqrt(num / (8.0 * wmin * tol[c]));
        n = crisp__trim_max(n, ceil(need));
    }
    return n;
}

static void eval_point(const crisp_bezier_curve *b, double t, double *uv)
{
    double U = crisp__trim_eval(b->cpw, b->degree, 3, t);
    double V = crisp__trim_eval(b->cpw + 1, b->degree, 3, t);
    double W = crisp__trim_eval(b->cpw + 2, b->degree, 3, t);
    uv[0] = U / W;
    uv[1] = V / W;
}

/* Segments a (sub-)piece needs: from the strips its control polygon's v-range overlaps (their row
 * spacing and u-density); 1 when none of them is visible. */
typedef struct tess_ctx {
    const crisp_trim_tess_desc *desc;
    double fu, fv, hv;
    int capped;
} tess_ctx;

static double piece_need(const tess_ctx *c, const crisp_bezier_curve *b)
{
    const crisp_trim_tess_desc *desc = c->desc;
    int n_strips = desc->strip_count;
    double vmin = HUGE_VAL, vmax = -HUGE_VAL;
    for (int i = 0; i <= b->degree; i++) {
        double v = b->cpw[3 * i + 1] / b->cpw[3 * i + 2];
        vmin = crisp__trim_min(vmin, v);
        vmax = crisp__trim_max(vmax, v);
    }
    if (!(vmax >= desc->v0 && vmin <= desc->v1)) return 1.0;
    double fs = floor((vmin - desc->v0) / c->hv), fe = floor((vmax - desc->v0) / c->hv);
    int is = fs < 0 ? 0 : fs > n_strips - 1 ? n_strips - 1 : (int)fs;
    int ie = fe < 0 ? 0 : fe > n_strips - 1 ? n_strips - 1 : (int)fe;
    if (is > 0) is--; /* a crossing at a strip boundary may be decided by either side */
    if (ie < n_strips - 1) ie++;
    double hmin = HUGE_VAL, rho_u = 0.0;
    int visible = 0;
    for (int i = is; i <= ie; i++) {
        if (!desc->mu[i]) continue;
        visible = 1;
        double range = desc->row_v ? desc->row_v[2 * i + 1] - desc->row_v[2 * i] : c->hv;
        hmin = crisp__trim_min(hmin, range / desc->mu[i]);
        /* An unbounded strip (HUGE_VAL) has lost its guarantee already; letting it ask for
         * infinitely fine polylines would only cost memory. */
        if (isfinite(desc->rho_u[i])) rho_u = crisp__trim_max(rho_u, desc->rho_u[i]);
    }
    if (!visible) return 1.0;
    double tol_u = rho_u > 0.0 ? c->fu / rho_u : HUGE_VAL;
    return segments_needed(b, tol_u, c->fv * hmin);
}

/* de Casteljau halves of a homogeneous 2D piece. */
static void halve(const crisp_bezier_curve *b, crisp_bezier_curve *lo, crisp_bezier_curve *hi)
{
    int d = b->degree;
    *lo = *b;
    *hi = *b;
    double tmp[(CRISP_MAX_DEGREE + 1) * 3];
    memcpy(tmp, b->cpw, (size_t)(d + 1) * 3 * sizeof *tmp);
    for (int r = 0; r <= d; r++) {
        for (int c = 0; c < 3; c++) {
            lo->cpw[3 * r + c] = tmp[c];
            hi->cpw[3 * (d - r) + c] = tmp[3 * (d - r) + c];
        }
        for (int k = 0; k < d - r; k++)
            for (int c = 0; c < 3; c++)
                tmp[3 * k + c] = 0.5 * (tmp[3 * k + c] + tmp[3 * (k + 1) + c]);
    }
}

/* Adaptive tessellation of a piece: a sub-piece that needs more than LEAF_SEGMENTS uniform segments
 * is halved, so only the parts over visible strips get fine polylines (at extreme zoom a piece
 * can cross the view over a tiny part of its length). Each leaf keeps its own Filip bound, so
 * the guarantee holds leaf by leaf. Writes the points after the sub-piece's start (its interior
 * points and its end point) when uv is not NULL; returns how many. */
#define LEAF_SEGMENTS 32
#define MAX_HALVINGS 40
static long tess_leaf(tess_ctx *c, const crisp_bezier_curve *b, double n, double t0, double t1,
                      double *uv, double *tp);

static long tess_rec(tess_ctx *c, const crisp_bezier_curve *b, int depth, double t0, double t1,
                     double *uv, double *tp)
{
    double n = piece_need(c, b);
    if (n > LEAF_SEGMENTS && depth < MAX_HALVINGS) {
        crisp_bezier_curve lo, hi;
        halve(b, &lo, &hi);
        double tm = 0.5 * (t0 + t1);
        long a = tess_rec(c, &lo, depth + 1, t0, tm, uv, tp);
        return a + tess_rec(c, &hi, depth + 1, tm, t1, uv ? uv + 2 * a : NULL, tp ? tp + a : NULL);
    }
    return tess_leaf(c, b, n, t0, t1, uv, tp);
}

/* A leaf of n uniform segments (capped at CRISP_TRIM_MAX_SEGMENTS_PER_PIECE). */
static long tess_leaf(tess_ctx *c, const crisp_bezier_curve *b, double n, double t0, double t1,
                      double *uv, double *tp)
{
    if (!(n <= CRISP_TRIM_MAX_SEGMENTS_PER_PIECE)) {
        n = CRISP_TRIM_MAX_SEGMENTS_PER_PIECE;
        if (!uv) c->capped++;
    }
    int m = (int)n;
    if (uv) {
        for (int q = 1; q < m; q++) {
            eval_point(b, (double)q / m, uv + 2 * (q - 1));
            tp[q - 1] = t0 + (t1 - t0) * q / m;
        }
        tp[m - 1] = t1;
        /* The end point from the end control point exactly: neighbouring pieces that share a
         * control point share the vertex bit for bit. */
        const double *cd = b->cpw + 3 * b->degree;
        uv[2 * (m - 1)] = cd[0] / cd[2];
        uv[2 * (m - 1) + 1] = cd[1] / cd[2];
    }
    return m;
}

crisp_status crisp_trim_tessellate(const crisp_trim_tess_desc *desc, crisp_trim_polyline *dest)
{
    if (!desc || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_trim_tessellate: NULL argument");
    crisp_status st = crisp_trim_pieces_check(desc->pieces, desc->piece_count);
    if (st) return st;
    return crisp__trim_tessellate_checked(desc, dest);
}

crisp_status crisp__trim_tessellate_checked(const crisp_trim_tess_desc *desc,
                                            crisp_trim_polyline *dest)
{
    if (desc->strip_count < 1 || !desc->mu || !desc->rho_u || !(desc->v1 > desc->v0))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_tessellate: strips %d over [%g, %g], expected >= 1 strips "
                           "with mu and rho_u over a non-empty range",
                           desc->strip_count, desc->v0, desc->v1);
    tess_ctx c = {.desc = desc,
                  .fu = desc->tol_u > 0.0 ? desc->tol_u : 0.25,
                  .fv = desc->tol_v > 0.0 ? desc->tol_v : 0.25,
                  .hv = (desc->v1 - desc->v0) / desc->strip_count};
    crisp_trim_polyline *pl = dest;
    if (crisp_grow((void **)&pl->first, &pl->cap_first, (size_t)desc->piece_count + 1,
                   sizeof *pl->first))
        return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_trim_tessellate: out of memory");
    pl->piece_count = desc->piece_count;
    /* Pass 1: point counts (first[k + 1] temporarily holds piece k's segment count). */
    long total = 0;
    pl->first[0] = 0;
    for (int k = 0; k < desc->piece_count; k++) {
        /* A piece that is a single leaf (most of them) keeps its count as -n: pass 2 then
         * does not form its bound again. */
        double need = piece_need(&c, &desc->pieces[k]);
        if (need <= LEAF_SEGMENTS) {
            pl->first[k + 1] = -(int)need;
            total += (long)need + 1;
            continue;
        }
        long n = tess_rec(&c, &desc->pieces[k], 0, 0.0, 1.0, NULL, NULL);
        if (n > (long)1 << 30)
            return crisp_error(CRISP_ERR_LIMIT,
                               "crisp_trim_tessellate: piece %d needs %ld segments", k, n);
        pl->first[k + 1] = (int)n;
        total += n + 1;
        if (total > (long)1 << 30)
            return crisp_error(CRISP_ERR_LIMIT,
                               "crisp_trim_tessellate: %ld polyline points, too many", total);
    }
    pl->capped = c.capped;
    if (crisp_grow((void **)&pl->uv, &pl->cap_uv, 2 * (size_t)(total ? total : 1),
                   sizeof *pl->uv) ||
        crisp_grow((void **)&pl->t, &pl->cap_t, (size_t)(total ? total : 1), sizeof *pl->t))
        return crisp_error(CRISP_ERR_NO_MEMORY,
                           "crisp_trim_tessellate: out of memory for %ld points", total);
    /* Pass 2: points. The start point comes from the start control point exactly. */
    int at = 0;
    for (int k = 0; k < desc->piece_count; k++) {
        const crisp_bezier_curve *b = &desc->pieces[k];
        int n = pl->first[k + 1];
        pl->first[k] = at;
        double *uv = pl->uv + 2 * at;
        uv[0] = b->cpw[0] / b->cpw[2];
        uv[1] = b->cpw[1] / b->cpw[2];
        pl->t[at] = 0.0;
        if (n < 0) {
            n = -n;
            tess_leaf(&c, b, n, 0.0, 1.0, uv + 2, pl->t + at + 1);
        } else {
            tess_rec(&c, b, 0, 0.0, 1.0, uv + 2, pl->t + at + 1);
        }
        at += n + 1;
    }
    pl->first[desc->piece_count] = at;
    return CRISP_OK;
}

/* ---- chains (issue 12) ------------------------------------------------------------------------
 */

#define CHAIN_RUN 64 /* points one chord may replace: bounds the quadratic greedy search */

/* 1 when the chord from point i to point c of pl replaces the points between within (tol_u,
 * tol_v): each point j in between is matched to the chord point at s_j, the projection in the
 * metric scaled by the tolerances (su, sv = 1 / tol), clamped to [s_{j-1}, 1] (monotone, s_i = 0,
 * s_c = 1), and must lie within the tolerances of it per coordinate. */
static int chord_fits(const double *uv, int i, int c, double tol_u, double tol_v, double su,
                      double sv)
{
    double au = uv[2 * i], av = uv[2 * i + 1];
    double du = uv[2 * c] - au, dv = uv[2 * c + 1] - av;
    double l2 = su * su * du * du + sv * sv * dv * dv;
    double s_prev = 0.0;
    for (int j = i + 1; j < c; j++) {
        double pu = uv[2 * j] - au, pv = uv[2 * j + 1] - av;
        double s = l2 > 0.0 ? (su * su * pu * du + sv * sv * pv * dv) / l2 : 0.0;
        if (!(s >= s_prev)) s = s_prev; /* also NaN */
        if (s > 1.0) s = 1.0;
        if (!(fabs(pu - s * du) <= tol_u && fabs(pv - s * dv) <= tol_v)) return 0;
        s_prev = s;
    }
    return 1;
}

crisp_status crisp_trim_polyline_chains(crisp_trim_polyline *pl, double tol_u, double tol_v)
{
    if (!pl || !(tol_u > 0.0) || !(tol_v > 0.0))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_trim_polyline_chains: tolerances %g, %g, expected > 0 with a "
                           "polyline",
                           tol_u, tol_v);
    int n = pl->piece_count;
    if (n < 1) return CRISP_OK;
    /* Pass 1: pieces -> chains, the shared point kept once (writes never pass reads). */
    int w = 0, chains = 0, open = 0;
    int a = pl->first[0];
    for (int k = 0; k < n; k++) {
        int b = pl->first[k + 1]; /* read before first[chains <= k] is written */
        if (b - a < 1) {
            a = b;
            continue;
        }
        int joins = open && pl->uv[2 * (w - 1)] == pl->uv[2 * a] &&
                    pl->uv[2 * (w - 1) + 1] == pl->uv[2 * a + 1];
        if (joins) {
            a++;
        } else {
            pl->first[chains++] = w;
            open = 1;
        }
        for (int q = a; q < b; q++, w++) {
            pl->uv[2 * w] = pl->uv[2 * q];
            pl->uv[2 * w + 1] = pl->uv[2 * q + 1];
            pl->t[w] = pl->t[q];
        }
        a = b;
    }
    pl->first[chains] = w;
    pl->piece_count = chains;
    /* Pass 2: along each chain, greedily the longest chord that fits (at most CHAIN_RUN points
     * apart); again in place. */
    double su = isfinite(tol_u) ? 1.0 / tol_u : 0.0, sv = isfinite(tol_v) ? 1.0 / tol_v : 0.0;
    int out = 0, s = pl->first[0];
    for (int c = 0; c < chains; c++) {
        int e = pl->first[c + 1]; /* the chain's points s .. e - 1 (first[c + 1] not yet written) */
        pl->first[c] = out;
        int i = s;
        pl->uv[2 * out] = pl->uv[2 * i];
        pl->uv[2 * out + 1] = pl->uv[2 * i + 1];
        pl->t[out++] = pl->t[i];
        while (i < e - 1) {
            int best = i + 1;
            for (int c2 = i + 2; c2 < e && c2 - i <= CHAIN_RUN; c2++) {
                if (!chord_fits(pl->uv, i, c2, tol_u, tol_v, su, sv)) break;
                best = c2;
            }
            pl->uv[2 * out] = pl->uv[2 * best];
            pl->uv[2 * out + 1] = pl->uv[2 * best + 1];
            pl->t[out++] = pl->t[best];
            i = best;
        }
        s = e;
    }
    pl->first[chains] = out;
    return CRISP_OK;
}

/* ---- view-independent levels (issue 12) -------------------------------------------------------
 */

crisp_status crisp_trim_lod_build(const crisp_bezier_curve *pieces, int piece_count,
                                  crisp_trim_lod *dest)
{
    if (!dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_trim_lod_build: NULL argument");
    dest->levels = 0;
    crisp_status st = crisp_trim_pieces_check(pieces, piece_count);
    if (st || piece_count < 1) return st;
    double *b = dest->box;
    b[0] = b[2] = HUGE_VAL;
    b[1] = b[3] = -HUGE_VAL;
    for (int k = 0; k < piece_count; k++)
        for (int i = 0; i <= pieces[k].degree; i++) {
            const double *h = pieces[k].cpw + 3 * i;
            double u = h[0] / h[2], v = h[1] / h[2];
            b[0] = crisp__trim_min(b[0], u), b[1] = crisp__trim_max(b[1], u);
            b[2] = crisp__trim_min(b[2], v), b[3] = crisp__trim_max(b[3], v);
        }
    double eu = b[1] - b[0], ev = b[3] - b[2];
    if (!(eu > 0.0) || !(ev > 0.0) || !isfinite(eu) || !isfinite(ev)) return CRISP_OK;
    for (int k = 0; k < CRISP_TRIM_LOD_LEVELS; k++) {
        double tu = ldexp(eu, -4 - k), tv = ldexp(ev, -4 - k);
        /* One strip over the box: rows of h <= 2 tv give the tessellation tv / 2 in v (a quarter
         * of h), and rho_u = 0.5 / tu gives it tu / 2 in u; the chains take the other halves. */
        uint32_t mu[1] = {(uint32_t)ceil(ev / (2 * tv)) + 1};
        double rho_u[1] = {0.5 / tu};
        crisp_trim_polyline *pl = &dest->level[k];
        st = crisp__trim_tessellate_checked(&(crisp_trim_tess_desc){.pieces = pieces,
                                                                    .piece_count = piece_count,
                                                                    .v0 = b[2],
                                                                    .v1 = b[3],
                                                                    .strip_count = 1,
                                                                    .mu = mu,
                                                                    .rho_u = rho_u},
                                            pl);
        if (!st) st = crisp_trim_polyline_chains(pl, 0.5 * tu, 0.5 * tv);
        if (st) return st;
        dest->tol_u[k] = tu;
        dest->tol_v[k] = tv;
    }
    dest->levels = CRISP_TRIM_LOD_LEVELS;
    return CRISP_OK;
}

void crisp_trim_lod_free(crisp_trim_lod *lod)
{
    if (!lod) return;
    for (int k = 0; k < CRISP_TRIM_LOD_LEVELS; k++)
        crisp_trim_polyline_free(&lod->level[k]);
    memset(lod, 0, sizeof *lod);
}

void crisp_trim_polyline_free(crisp_trim_polyline *p)
{
    if (!p) return;
    crisp_free(p->first);
    crisp_free(p->uv);
    crisp_free(p->t);
    memset(p, 0, sizeof *p);
}
