/* Trim-boundary ribbons, part of the frame plan (include/crisp/plan.h).
 *
 * Where two trimmed faces meet, each face's trim test may be wrong within its 1 px band, so the
 * shared edge can open a sub-pixel gap. Like Wu & Peters (who draw x(gamma(t))), each face's trim
 * boundary is also drawn as its surface image: a screen-space ribbon of half-width RIBBON_PX
 * along the trim polyline mapped onto the true surface, sampled until consecutive samples are at
 * most RIBBON_STEP_PX apart on screen and a chord's middle lies within RIBBON_BOW_PX of the image
 * (refine() below: that check, not the step, keeps the straight ribbon pieces on the curved
 * image; test_cracks' test_ribbons_follow_curves measures 0.26 px at a step of 4 px, 0.30 at 64,
 * 18 px at 64 without the check). The step was 2 px until session 7 (issue 12: 4 px takes
 * impeller x 49 from 276 k to 185 k ribbon quads, a third of the frame's memory).
 * The polyline is within 0.25 px of the true curve, so a ribbon reaches at most about
 * RIBBON_PX + 0.25 < 1 px beyond the true boundary: inside the band where the trim decision may
 * go either way. Samples outside the widened frustum are dropped. The quads are placed in clip
 * space here, so every backend draws the same ribbons. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/compiler.h"
#include "raster.h"
#include "render_internal.h"
#include "ribbon.h"

#define RIBBON_PX 0.7
#define RIBBON_STEP_PX 4.0
#define RIBBON_MAX_DEPTH 48
#define RIBBON_BOW_PX 0.1 /* largest distance of a piece's middle from its chord on screen */
/* A face without trim loops is bounded by its domain's edges (t = 0, s = 1, t = 1, s = 0 of the
 * patch grid, as leaf edges): where it meets another face there, the two faces' tessellations
 * differ as along a trim, so the edge gets a ribbon too (not the edges where the surface closes
 * on itself: those are shared within the face's own crack-free mesh). */
#define RIBBON_EDGE 0x80000000u

/* Ribbon samples' world-space points and normals kept across frames (issue 12, session 19): a
 * sample's position and normal are a function of the scene, its face and the bits of its (u, v)
 * alone (ribbon_vertex); only the clip position depends on the camera, and projecting the kept
 * point (the same crisp_mat4_mulp of the same point) gives the same clip position bit for bit.
 * Keyed by the scene (serial: a new scene's keys never match), the face and (u, v); two slots a
 * key. The workers only read the table; what each finds missing (up to RPT_FRESH a build) goes
 * in after the sampling pass (keep_points). */
#define RPT_BITS 16
#define RPT_SLOTS (1u << RPT_BITS)
#define RPT_FRESH 8192
typedef struct ribbon_point_kept {
    uint64_t serial, u, v; /* serial 0: an empty slot */
    uint32_t face;
    double p[3], n[3]; /* the point, the unit normal (the face's orientation applied) */
} ribbon_point_kept;

typedef struct point_keep {
    const ribbon_point_kept *table; /* RPT_SLOTS, NULL: none */
    ribbon_point_kept *fresh;       /* this worker's misses (RPT_FRESH) */
    uint32_t *fresh_count;
    uint64_t serial;
} point_keep;

static size_t rpt_slot(uint32_t face, uint64_t u, uint64_t v)
{
    return (size_t)(((u * 0x9E3779B97F4A7C15ull) ^ (v * 0xC2B2AE3D27D4EB4Full) ^
                     (face * 0x165667B19E3779F9ull)) >>
                    (64 - RPT_BITS));
}

static int rpt_is(const ribbon_point_kept *e, uint64_t serial, uint32_t face, uint64_t u,
                  uint64_t v)
{
    return e->serial == serial && e->face == face && e->u == u && e->v == v;
}

/* Ask for the two slots of (u, v)'s key ahead of their look-up (ribbon_vertex): the table is
 * 5 MB and its keys are spread on purpose, so a look-up not asked for ahead waits on memory
 * (perf, impeller.igs close: ribbon_vertex then took more time than any other plan function for
 * a tenth of their instructions). Reads nothing; changes no value. */
static ALWAYS_INLINE void rpt_prefetch(const point_keep *pk, uint32_t face, double u, double v)
{
    if (!pk->table) return;
    uint64_t ub, vb;
    memcpy(&ub, &u, sizeof ub);
    memcpy(&vb, &v, sizeof vb);
    const ribbon_point_kept *e = &pk->table[rpt_slot(face, ub, vb) & ~(size_t)1];
    __builtin_prefetch(e);
    __builtin_prefetch((const char *)e + 64);
    __builtin_prefetch((const char *)(e + 2) - 1);
}

typedef struct ribbon_job {
    uint32_t face, piece; /* piece of the trim polyline, or RIBBON_EDGE + k: edge k of the domain */
    crisp_raster_vertex *pts; /* samples (per-worker arena, valid this frame) */
    uint32_t count;           /* samples; a sample with clip[3] < 0 breaks the ribbon */
    uint32_t qbase;           /* first quad */
} ribbon_job;

struct crisp__ribbons {
    int workers;
    crisp_arena **arena;   /* per worker, reset every build */
    crisp_status *wstatus; /* per worker */
    ribbon_job *jobs;
    size_t job_cap;
    size_t last_used;              /* bytes of samples over all workers in the last build */
    crisp_raster_vertex **scratch; /* per worker: one job's samples while it is sampled */
    uint32_t *scratch_cap;
    uint32_t last_max;              /* most samples of one job in the last build */
    crisp__ribbon_pieces_fn hidden; /* crisp__ribbons_set_hidden (NULL: none) */
    const void *hidden_ctx;
    ribbon_point_kept *points; /* RPT_SLOTS (NULL: none yet) */
    ribbon_point_kept **fresh; /* per worker: RPT_FRESH */
    uint32_t *fresh_count;     /* per worker */
};

typedef struct ribbon_ctx {
    crisp__ribbons *rb;
    const crisp__trees *trees;
    const crisp_scene *sc;
    crisp_plan_ribbon_vertex *out;
} ribbon_ctx;

crisp_status crisp__ribbons_create(int workers, crisp__ribbons **dest)
{
    crisp__ribbons *rb = calloc(1, sizeof *rb);
    if (!rb) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim ribbons");
    rb->workers = workers;
    rb->arena = calloc((size_t)workers, sizeof *rb->arena);
    rb->wstatus = calloc((size_t)workers, sizeof *rb->wstatus);
    rb->scratch = calloc((size_t)workers, sizeof *rb->scratch);
    rb->scratch_cap = calloc((size_t)workers, sizeof *rb->scratch_cap);
    rb->fresh = calloc((size_t)workers, sizeof *rb->fresh);
    rb->fresh_count = calloc((size_t)workers, sizeof *rb->fresh_count);
    crisp_status st =
        rb->arena && rb->wstatus && rb->scratch && rb->scratch_cap && rb->fresh && rb->fresh_count
            ? CRISP_OK
            : crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim ribbons");
    for (int w = 0; !st && w < workers; w++)
        st = crisp_arena_create(1 << 16, &rb->arena[w]);
    if (st) {
        crisp__ribbons_destroy(rb);
        return st;
    }
    *dest = rb;
    return CRISP_OK;
}

void crisp__ribbons_destroy(crisp__ribbons *rb)
{
    if (!rb) return;
    if (rb->arena)
        for (int w = 0; w < rb->workers; w++)
            crisp_arena_destroy(rb->arena[w]);
    free(rb->arena);
    free(rb->wstatus);
    if (rb->scratch)
        for (int w = 0; w < rb->workers; w++)
            free(rb->scratch[w]);
    free(rb->scratch);
    free(rb->scratch_cap);
    if (rb->fresh)
        for (int w = 0; w < rb->workers; w++)
            free(rb->fresh[w]);
    free(rb->fresh);
    free(rb->fresh_count);
    free(rb->points);
    free(rb->jobs);
    free(rb);
}

/* The column iu and row iv of the patch of face f's grid (its patches P) that holds (u, v):
 * binary searches over the first row's u-ends and the first column's v-ends, each monotone in its
 * coordinate (a box of (u, v) maps into the cells between those of its corners). Inlined:
 * grid_patch's search, on the path of every ribbon sample. */
static ALWAYS_INLINE void grid_cell(const crisp_scene_face *f, const crisp_scene_patch *P, double u,
                                    double v, uint32_t *iu, uint32_t *iv)
{
    uint32_t lo = 0, hi = f->grid_u - 1;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (u < P[mid].bez.u1)
            hi = mid;
        else
            lo = mid + 1;
    }
    *iu = lo;
    lo = 0, hi = f->grid_v - 1;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (v < P[(size_t)mid * f->grid_u].bez.v1)
            hi = mid;
        else
            lo = mid + 1;
    }
    *iv = lo;
}

void crisp__ribbons_set_hidden(crisp__ribbons *rb, crisp__ribbon_pieces_fn fn, const void *ctx)
{
    rb->hidden = fn;
    rb->hidden_ctx = ctx;
}

/* The pieces (crisp__ribbons_set_hidden) of the patch b that hold points with s in [s0, s1] and
 * t in [t0, t1] (clamped to [0, 1]), as a mask: the cells reached, widened by 1e-9 so that a
 * point on a cut between pieces, which is in both of their hulls, may be counted in either. */
static inline int piece_index(double x)
{
    /* (int)fmax(0, fmin(n - 1, x)) without the library calls: NaN gives n - 1 as fmin's rule,
     * and a zero of either sign gives 0 */
    const double top = CRISP__RIBBON_PIECES - 1;
    double y = x < top ? x : top;
    return (int)(y > 0 ? y : 0);
}

static uint32_t pieces_reached(double s0, double s1, double t0, double t1)
{
    const int n = CRISP__RIBBON_PIECES;
    double e = 1e-9;
    int c0 = piece_index(floor((s0 - e) * n)), c1 = piece_index(floor((s1 + e) * n));
    int r0 = piece_index(floor((t0 - e) * n)), r1 = piece_index(floor((t1 + e) * n));
    uint32_t row = ((1u << (c1 + 1)) - 1) & ~((1u << c0) - 1), m = 0;
    for (int r = r0; r <= r1; r++)
        m |= row << (n * r);
    return m;
}

/* 1 when every point ribbon_vertex takes on the (u, v) segment from p to q of face f (each point
 * of its box, in the grid patch grid_patch finds for it, at the clamped (s, t) there) lies in a
 * piece rb's hidden test marks: each patch of the grid cells between those of the box's corners,
 * and in it the pieces of the box's (s, t) range. */
static int pieces_hidden(const crisp__ribbons *rb, const crisp_scene *sc, uint32_t face,
                         const double p[2], const double q[2])
{
    const crisp_scene_face *f = &sc->faces[face];
    if (!f->patch_count || f->grid_u * f->grid_v != f->patch_count) return 0;
    double ulo = fmin(p[0], q[0]), uhi = fmax(p[0], q[0]);
    double vlo = fmin(p[1], q[1]), vhi = fmax(p[1], q[1]);
    if (!isfinite(ulo + uhi + vlo + vhi)) return 0;
    const crisp_scene_patch *P = sc->patches + f->first_patch;
    uint32_t i0, j0, i1, j1;
    grid_cell(f, P, ulo, vlo, &i0, &j0);
    grid_cell(f, P, uhi, vhi, &i1, &j1);
    for (uint32_t j = j0; j <= j1; j++)
        for (uint32_t i = i0; i <= i1; i++) {
            uint32_t k = j * f->grid_u + i;
            uint32_t hidden = rb->hidden(rb->hidden_ctx, f->first_patch + k);
            const crisp_bezier_patch *b = &P[k].bez;
            if (!hidden || !(b->u1 > b->u0) || !(b->v1 > b->v0)) return 0;
            double s0 = (ulo - b->u0) / (b->u1 - b->u0), s1 = (uhi - b->u0) / (b->u1 - b->u0);
            double t0 = (vlo - b->v0) / (b->v1 - b->v0), t1 = (vhi - b->v0) / (b->v1 - b->v0);
            uint32_t need = pieces_reached(s0, s1, t0, t1);
            if ((hidden & need) != need) return 0;
        }
    return 1;
}

/* The face's Bézier patch holding (u, v) and the local (s, t) there, found in the face's patch
 * grid (grid_cell); NULL when its patches do not form a grid. */
static const crisp_bezier_patch *grid_patch(const crisp_scene *sc, uint32_t face, double u,
                                            double v, double *s, double *t)
{
    const crisp_scene_face *f = &sc->faces[face];
    if (!f->patch_count || f->grid_u * f->grid_v != f->patch_count) return NULL;
    const crisp_scene_patch *P = sc->patches + f->first_patch;
    uint32_t iu, iv;
    grid_cell(f, P, u, v, &iu, &iv);
    const crisp_bezier_patch *b = &P[(size_t)iv * f->grid_u + iu].bez;
    *s = fmin(1.0, fmax(0.0, (u - b->u0) / (b->u1 - b->u0)));
    *t = fmin(1.0, fmax(0.0, (v - b->v0) / (b->v1 - b->v0)));
    return b;
}

/* The surface point at (u, v) with its normal, in clip space: from the face's Bézier patch (a
 * few times cheaper than the B-spline evaluation, issue 12), else from the surface. */
static void ribbon_vertex(const crisp_scene *sc, uint32_t face, const crisp_surface *surf,
                          int reversed, crisp_mat4 m, double u, double v, crisp_raster_vertex *out,
                          const point_keep *pk)
{
    uint64_t ub, vb;
    memcpy(&ub, &u, sizeof ub);
    memcpy(&vb, &v, sizeof vb);
    size_t slot = 0;
    if (pk && pk->table) {
        slot = rpt_slot(face, ub, vb);
        const ribbon_point_kept *e = &pk->table[slot];
        if (!rpt_is(e, pk->serial, face, ub, vb)) e = &pk->table[slot ^ 1];
        if (rpt_is(e, pk->serial, face, ub, vb)) {
            crisp_mat4_mulp(m, e->p, out->clip);
            out->attr[0] = u;
            out->attr[1] = v;
            memcpy(out->attr + 2, e->n, sizeof e->n);
            return;
        }
    }
    double P[3], Su[3], Sv[3], n[3], s, t;
    const crisp_bezier_patch *b = grid_patch(sc, face, u, v, &s, &t);
    if (b) {
        crisp_bezier_patch_derivs(b, s, t, P, Su, Sv);
        for (int k = 0; k < 3; k++) {
            Su[k] /= b->u1 - b->u0;
            Sv[k] /= b->v1 - b->v0;
        }
    } else {
        crisp_surface_derivs(surf, u, v, P, Su, Sv, NULL, NULL, NULL);
    }
    crisp_mat4_mulp(m, P, out->clip);
    out->attr[0] = u;
    out->attr[1] = v;
    crisp_vec3_cross(Su, Sv, n);
    if (crisp__normal_degenerate(Su, Sv, n))
        crisp_surface_normal(surf, u, v, n); /* apex, pole, collapsed side: the limit from inside */
    if (reversed) crisp_vec3_scale(n, -1, n);
    crisp_vec3_normalize(n, out->attr + 2);
    if (pk && pk->fresh && *pk->fresh_count < RPT_FRESH) {
        ribbon_point_kept *e = &pk->fresh[(*pk->fresh_count)++];
        *e = (ribbon_point_kept){pk->serial,
                                 ub,
                                 vb,
                                 face,
                                 {P[0], P[1], P[2]},
                                 {out->attr[2], out->attr[3], out->attr[4]}};
    }
}

/* ribbon_vertex's clip position and (u, v) alone (no normal): a chord's middle looked at only for
 * the bow and step checks in refine() becomes a sample (and gets its normal) in the few cases
 * where it splits the chord (issue 12: about 1 in 25 at impeller x 49 far). */
static void ribbon_point(const crisp_scene *sc, uint32_t face, const crisp_surface *surf,
                         crisp_mat4 m, double u, double v, crisp_raster_vertex *out)
{
    double P[3], s, t;
    const crisp_bezier_patch *b = grid_patch(sc, face, u, v, &s, &t);
    if (b)
        crisp_bezier_patch_eval(b, s, t, P);
    else
        crisp_surface_eval(surf, u, v, P);
    crisp_mat4_mulp(m, P, out->clip);
    out->attr[0] = u;
    out->attr[1] = v;
}

static int in_view(const crisp_raster_vertex *a, double gx, double gy)
{
    const double *c = a->clip;
    return c[3] > 0 && c[2] >= -c[3] && c[2] <= c[3] && fabs(c[0]) <= gx * c[3] &&
           fabs(c[1]) <= gy * c[3];
}

/* The screen offset in pixels from b to a, or behind (nonzero) when either is behind the eye:
 * screen_dist's value is then INFINITY, else hypot(dx, dy). */
typedef struct screen_offset {
    double dx, dy;
    int behind;
} screen_offset;

static screen_offset screen_offset_of(const crisp_raster_vertex *a, const crisp_raster_vertex *b,
                                      double w, double h)
{
    screen_offset o = {0, 0, 1};
    if (!(a->clip[3] > 0 && b->clip[3] > 0)) return o;
    o.dx = (a->clip[0] / a->clip[3] - b->clip[0] / b->clip[3]) * 0.5 * w;
    o.dy = (a->clip[1] / a->clip[3] - b->clip[1] / b->clip[3]) * 0.5 * h;
    o.behind = 0;
    return o;
}

/* screen_dist(a, b) > c (c positive, finite) */
static int offset_above(const screen_offset *o, double c)
{
    return o->behind || crisp__ribbon_length_above(o->dx, o->dy, c);
}

/* screen_dist(a, b) < INFINITY: a finite square means a finite length */
static int offset_finite(const screen_offset *o)
{
    if (o->behind) return 0;
    double s2 = o->dx * o->dx + o->dy * o->dy;
    return s2 < INFINITY || hypot(o->dx, o->dy) < INFINITY;
}

/* Screen distance in pixels (infinite when either point is behind the eye). */
static double screen_dist(const crisp_raster_vertex *a, const crisp_raster_vertex *b, double w,
                          double h)
{
    if (!(a->clip[3] > 0 && b->clip[3] > 0)) return INFINITY;
    double dx = (a->clip[0] / a->clip[3] - b->clip[0] / b->clip[3]) * 0.5 * w;
    double dy = (a->clip[1] / a->clip[3] - b->clip[1] / b->clip[3]) * 0.5 * h;
    return hypot(dx, dy);
}

/* Conservatively: can the ribbon piece between a and b (surface points) show on screen? Both in
 * front of the eye, and the screen box of the chord, widened by the chord's length (the surface
 * image between two samples bulges by less than that), meets the viewport. */
static int segment_may_show(const crisp_raster_vertex *a, const crisp_raster_vertex *b, double w,
                            double h)
{
    if (!(a->clip[3] > 0) || !(b->clip[3] > 0)) return 1; /* let refine() split it */
    double pa[2], pb[2];
    crisp__clip_px(a->clip, w, h, pa);
    crisp__clip_px(b->clip, w, h, pb);
    double len = hypot(pb[0] - pa[0], pb[1] - pa[1]) + 2;
    if (!isfinite(len)) return 1;
    return fmax(pa[0], pb[0]) + len >= 0 && fmin(pa[0], pb[0]) - len <= w &&
           fmax(pa[1], pb[1]) + len >= 0 && fmin(pa[1], pb[1]) - len <= h;
}

/* A job's samples go to the worker's scratch buffer (kept from frame to frame), then exactly
 * count of them to the worker's arena: most jobs of a large model far away have a few samples,
 * and a first chunk of 64 per job in the arena made the ribbons' memory 1 GB for impeller x 49
 * (issue 12). */
typedef struct sampler {
    crisp_raster_vertex **pts; /* the worker's scratch buffer */
    uint32_t *cap;
    uint32_t count;
    const crisp_surface *surf;
    const crisp_scene *sc;
    uint32_t face;
    int reversed;
    crisp_mat4 *m;
    double w, h, gx, gy;
    const crisp_trim_plan *tp; /* a face with chains: its strips (speed bounds); else NULL */
    int failed;
    const crisp__ribbons *rb; /* its hidden test (crisp__ribbons_set_hidden) when set */
    point_keep pk;            /* the kept sample points */
} sampler;

static void emit(sampler *s, const crisp_raster_vertex *v)
{
    if (s->failed) return;
    if (s->count == *s->cap) {
        uint32_t cap = *s->cap ? 2 * *s->cap : 256;
        crisp_raster_vertex *n = realloc(*s->pts, (size_t)cap * sizeof *n);
        if (!n) {
            s->failed = 1;
            return;
        }
        *s->pts = n;
        *s->cap = cap;
    }
    (*s->pts)[s->count++] = *v;
}

/* Screen distance in pixels from m to the chord from a to b (all three in front of the eye)
 * above c: hypot(x, y) > c of the offset below (crisp__ribbon_length_above). */
static int chord_above(const crisp_raster_vertex *a, const crisp_raster_vertex *m,
                       const crisp_raster_vertex *b, double w, double h, double c)
{
    double ax = a->clip[0] / a->clip[3] * 0.5 * w, ay = a->clip[1] / a->clip[3] * 0.5 * h;
    double bx = b->clip[0] / b->clip[3] * 0.5 * w - ax, by = b->clip[1] / b->clip[3] * 0.5 * h - ay;
    double mx = m->clip[0] / m->clip[3] * 0.5 * w - ax, my = m->clip[1] / m->clip[3] * 0.5 * h - ay;
    double len2 = bx * bx + by * by, t = len2 > 0 ? (mx * bx + my * by) / len2 : 0;
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
    return crisp__ribbon_length_above(mx - t * bx, my - t * by, c);
}

/* The largest finite speed bounds (pixels per unit u and v) of the strips that v-range [va, vb]
 * (either order) reaches, and of one strip more on each side. */
static void strip_speeds(const crisp_trim_plan *tp, double va, double vb, double *ru, double *rv)
{
    *ru = *rv = 0.0;
    int n = tp->strip_count;
    if (n < 1 || !(tp->v1 > tp->v0)) return;
    double h = (tp->v1 - tp->v0) / n;
    double f0 = floor((fmin(va, vb) - tp->v0) / h) - 1, f1 = floor((fmax(va, vb) - tp->v0) / h) + 1;
    int i0 = f0 < 0 ? 0 : f0 > n - 1 ? n - 1 : (int)f0;
    int i1 = f1 < 0 ? 0 : f1 > n - 1 ? n - 1 : (int)f1;
    for (int i = i0; i <= i1; i++) {
        if (isfinite(tp->rho_u[i]) && tp->rho_u[i] > *ru) *ru = tp->rho_u[i];
        if (isfinite(tp->rho_v[i]) && tp->rho_v[i] > *rv) *rv = tp->rho_v[i];
    }
}

/* 1 when the strips' speed bounds allow the image of the uv segment from a to b a longer path on
 * screen than a step: its chord then says little of where it runs (a chord of a chain can run
 * around a closed surface's whole turn, both ends at one point: occt_linkrods.step face 0's edge
 * v = 2 pi is one chord from u = 2 pi to 0, and with the seam just off screen the whole edge had
 * no ribbon; test_cracks test_linkrods_seam_at_border). */
static int image_may_be_long(const sampler *s, const crisp_raster_vertex *a,
                             const crisp_raster_vertex *b)
{
    if (!s->tp) return 0;
    double ru, rv;
    strip_speeds(s->tp, a->attr[1], b->attr[1], &ru, &rv);
    return ru * fabs(b->attr[0] - a->attr[0]) + rv * fabs(b->attr[1] - a->attr[1]) > RIBBON_STEP_PX;
}

/* Samples strictly after a up to and including b, along the uv segment. A piece shorter than
 * RIBBON_STEP_PX is still split where its middle lies more than RIBBON_BOW_PX off its chord: a
 * trim edge running over its surface's silhouette folds back on screen, and its chord there can
 * be short while the curve bows a pixel away from it (occt_bearing.iges: a 1.9 px chord with the
 * edge 1.3 px off it, a one-pixel hole beside the ribbon; test_cracks' test_bearing_fold). The
 * middle is evaluated for that only where the piece's parent bowed more than 4 RIBBON_BOW_PX off
 * its own chord (a half of a smooth piece bows about a quarter as much), or the piece has no
 * parent or its bow was not formed (parent_bowed 1): most pieces cost no extra evaluation.
 * Distances are compared, never used as values, so most need no hypot (crisp__ribbon_length_above).
 */
static void refine(sampler *s, const crisp_raster_vertex *a, const crisp_raster_vertex *b,
                   int depth, int parent_bowed)
{
    if (s->failed) return;
    int va = in_view(a, s->gx, s->gy), vb = in_view(b, s->gx, s->gy);
    /* d = screen_dist(a, b), looked at only through its comparisons */
    screen_offset d = screen_offset_of(a, b, s->w, s->h);
    int d_long = offset_above(&d, RIBBON_STEP_PX), d_finite = offset_finite(&d);
    int split = d_long;
    crisp_raster_vertex mid;
    int have_mid = 0;
    /* The ends' distance does not bound the image of the uv segment between them: a chord of a
     * chain (crisp_trim_polyline_chains) can run along a closed surface's seam and end where it
     * starts on screen. Where the strips' speed bounds allow an image longer than a step, the
     * middle is looked at: a path through it longer than a step splits too. */
    if (!split && s->tp && depth < RIBBON_MAX_DEPTH && d_finite) {
        double ru, rv;
        strip_speeds(s->tp, a->attr[1], b->attr[1], &ru, &rv);
        double len = ru * fabs(b->attr[0] - a->attr[0]) + rv * fabs(b->attr[1] - a->attr[1]);
        if (len > RIBBON_STEP_PX) {
            ribbon_point(s->sc, s->face, s->surf, *s->m, 0.5 * (a->attr[0] + b->attr[0]),
                         0.5 * (a->attr[1] + b->attr[1]), &mid);
            have_mid = 1;
            split = screen_dist(a, &mid, s->w, s->h) + screen_dist(&mid, b, s->w, s->h) >
                    RIBBON_STEP_PX;
        }
    }
    /* The bow of a short piece (above); where the middle was looked at, also of a chord whose
     * ends are one point (a chain around a closed turn only a few pixels across, at a far view:
     * occt_linkrods.step face 5, 4.4 px from a ribbon that was one point; issue 13). */
    if (!split && depth < RIBBON_MAX_DEPTH && (have_mid || offset_above(&d, RIBBON_BOW_PX)) &&
        d_finite && (va || vb) && (have_mid || parent_bowed)) {
        if (!have_mid)
            ribbon_point(s->sc, s->face, s->surf, *s->m, 0.5 * (a->attr[0] + b->attr[0]),
                         0.5 * (a->attr[1] + b->attr[1]), &mid);
        have_mid = 1;
        split = mid.clip[3] > 0 && chord_above(a, &mid, b, s->w, s->h, RIBBON_BOW_PX);
    }
    if (depth < RIBBON_MAX_DEPTH && split && (va || vb || d_finite)) {
        /* A part of a segment (the whole was tested in sample_ribbons) whose (u, v) box lies in
         * hidden pieces: its samples, and the quads between them, are hidden; the ribbon breaks
         * there, as it does off screen. */
        if (depth && s->rb && pieces_hidden(s->rb, s->sc, s->face, a->attr, b->attr)) {
            crisp_raster_vertex brk = *b;
            brk.clip[3] = -1;
            emit(s, &brk);
            emit(s, b);
            return;
        }
        /* The middle becomes a sample: its point and normal (over the position looked at). */
        ribbon_vertex(s->sc, s->face, s->surf, s->reversed, *s->m, 0.5 * (a->attr[0] + b->attr[0]),
                      0.5 * (a->attr[1] + b->attr[1]), &mid, &s->pk);
        /* Both ends and the middle outside the view and neither half's widened screen box
         * meeting the view: nothing of it shows. (At extreme zoom a piece crossing the window
         * would otherwise be sampled along its whole length, most of it far off screen; only the
         * halves near the window are split further, a few per level. A piece crossing the window
         * is split however deep that takes: a cut at depth 8 left a one-pixel crack on the
         * bearing at fov 1.1e-5 degree, test_cracks' test_bearing_zoom.) */
        /* the halves' middles, which refine() looks up next if it splits them */
        rpt_prefetch(&s->pk, s->face, 0.5 * (a->attr[0] + mid.attr[0]),
                     0.5 * (a->attr[1] + mid.attr[1]));
        rpt_prefetch(&s->pk, s->face, 0.5 * (mid.attr[0] + b->attr[0]),
                     0.5 * (mid.attr[1] + b->attr[1]));
        int mid_out = !in_view(&mid, s->gx, s->gy);
        if (!va && !vb && mid_out && !segment_may_show(a, &mid, s->w, s->h) &&
            !segment_may_show(&mid, b, s->w, s->h)) {
            crisp_raster_vertex brk = *b;
            brk.clip[3] = -1;
            emit(s, &brk);
            emit(s, b);
            return;
        }
        /* (the bow, INFINITY where not formed, above 4 RIBBON_BOW_PX) */
        int bowed = !(d_finite && mid.clip[3] > 0) ||
                    chord_above(a, &mid, b, s->w, s->h, 4 * RIBBON_BOW_PX);
        refine(s, a, &mid, depth + 1, bowed);
        refine(s, &mid, b, depth + 1, bowed);
        return;
    }
    if (d_long) {
        /* Not resolved (behind the eye or at the depth limit): break the ribbon here. */
        crisp_raster_vertex brk = *b;
        brk.clip[3] = -1;
        emit(s, &brk);
    }
    emit(s, b);
}

/* Point k of a job's path in (u, v) and the number of points: the trim polyline piece, or a
 * domain edge through the patch grid's knot lines. */
static int path_points(const ribbon_ctx *c, const ribbon_job *job)
{
    if (!(job->piece & RIBBON_EDGE)) {
        const crisp_trim_polyline *pl = &c->trees->trims[job->face].polyline;
        return pl->first[job->piece + 1] - pl->first[job->piece];
    }
    const crisp_scene_face *f = &c->sc->faces[job->face];
    int edge = (int)(job->piece & 3u);
    return (int)((edge == 0 || edge == 2) ? f->grid_u : f->grid_v) + 1;
}

static void path_point(const ribbon_ctx *c, const ribbon_job *job, int k, double uv[2])
{
    if (!(job->piece & RIBBON_EDGE)) {
        const crisp_trim_polyline *pl = &c->trees->trims[job->face].polyline;
        int q = pl->first[job->piece] + k;
        uv[0] = pl->uv[2 * q], uv[1] = pl->uv[2 * q + 1];
        return;
    }
    const crisp_scene_face *f = &c->sc->faces[job->face];
    const crisp_scene_patch *first = &c->sc->patches[f->first_patch];
    int edge = (int)(job->piece & 3u);
    if (edge == 0 || edge == 2) {
        /* Along u at v = v0 (edge 0) or v1 (edge 2): the first row's patches' u boundaries. */
        uint32_t i = (uint32_t)k < f->grid_u ? (uint32_t)k : f->grid_u - 1;
        const crisp_bezier_patch *b = &c->sc->patches[f->first_patch + i].bez;
        uv[0] = (uint32_t)k < f->grid_u ? b->u0 : b->u1;
        uv[1] =
            edge == 0 ? first->bez.v0 : c->sc->patches[f->first_patch + f->patch_count - 1].bez.v1;
    } else {
        uint32_t j = (uint32_t)k < f->grid_v ? (uint32_t)k : f->grid_v - 1;
        const crisp_bezier_patch *b = &c->sc->patches[f->first_patch + j * f->grid_u].bez;
        uv[1] = (uint32_t)k < f->grid_v ? b->v0 : b->v1;
        uv[0] =
            edge == 3 ? first->bez.u0 : c->sc->patches[f->first_patch + f->patch_count - 1].bez.u1;
    }
}

/* 1 when no point of the uv segment from p to q can be on screen: in each strip of the face's
 * trim plan that the segment reaches, its part lies outside the box (vis_u x vis_v) that holds
 * every point of the strip inside the widened frustum (crisp_trim_density_desc.vis_u), or the
 * strip is invisible. The segment is a chord of a trim piece, inside the piece's control hull, so
 * it stays in the u-ranges the density bound covers. Costs no surface evaluation: at a close-up
 * most of a trim polyline is far off screen (issue 12). */
static int uv_hidden(const crisp_trim_plan *tp, const double p[2], const double q[2])
{
    double ulo = fmin(p[0], q[0]), uhi = fmax(p[0], q[0]);
    double vlo = fmin(p[1], q[1]), vhi = fmax(p[1], q[1]);
    int n = tp->strip_count;
    if (!(vlo >= tp->v0 && vhi <= tp->v1) || n < 1) return 0;
    double h = (tp->v1 - tp->v0) / n;
    /* Strip ends computed here, in the density walk and in its row ranges round differently (at
     * v = v1 the last strip's v0 + n h was 1 ulp short of v1, and a trim segment lying on the
     * domain edge v = v1 reached no strip: issue 13). So each strip reaches tol beyond its ends
     * (the first and last strips to the plan's ends), and so do the row ranges it is compared
     * with; likewise in u, where a piece on a domain edge may lie an ulp outside the patches' u
     * ends. A bigger box only hides less. */
    double tol = 1e-12 * (fabs(tp->v0) + fabs(tp->v1));
    int i0 = (int)floor((vlo - tp->v0) / h) - 1, i1 = (int)floor((vhi - tp->v0) / h) + 1;
    if (i0 < 0) i0 = 0;
    if (i1 > n - 1) i1 = n - 1;
    for (int i = i0; i <= i1; i++) {
        if (!(tp->rho_v[i] > 0)) continue; /* nothing of the strip in the frustum */
        double a = i == 0 ? vlo : fmax(vlo, tp->v0 + i * h - tol);
        double b = i == n - 1 ? vhi : fmin(vhi, tp->v0 + (i + 1) * h + tol);
        if (a > b) continue;
        double ul = tp->vis_u[2 * i], uh = tp->vis_u[2 * i + 1];
        double tol_u = 1e-12 * (fabs(ul) + fabs(uh));
        if (b >= tp->vis_v[2 * i] - tol && a <= tp->vis_v[2 * i + 1] + tol && uhi >= ul - tol_u &&
            ulo <= uh + tol_u)
            return 0;
    }
    return 1;
}

static void sample_ribbons(void *vctx, size_t begin, size_t end, int worker)
{
    ribbon_ctx *c = vctx;
    const crisp__trees *plan = c->trees;
    for (size_t j = begin; j < end; j++) {
        ribbon_job *job = &c->rb->jobs[j];
        const crisp_scene_face *f = &c->sc->faces[job->face];
        int n = path_points(c, job);
        sampler s = {.pts = &c->rb->scratch[worker],
                     .cap = &c->rb->scratch_cap[worker],
                     .surf = f->src->surface,
                     .sc = c->sc,
                     .face = job->face,
                     .reversed = f->src->reversed,
                     .m = (crisp_mat4 *)&plan->view_proj,
                     .w = plan->width,
                     .h = plan->height,
                     .gx = 1 + 4.0 / plan->width,
                     .gy = 1 + 4.0 / plan->height,
                     .rb = c->rb->hidden ? c->rb : NULL,
                     .pk = {c->rb->points, c->rb->fresh[worker], &c->rb->fresh_count[worker],
                            c->sc->serial}};
        /* The face's strips say where its surface is off screen (not for a face drawn whole:
         * its trim plan is not this frame's). */
        const crisp_trim_plan *tp = &plan->trims[job->face];
        if (crisp__groups_face_small(plan->groups, job->face) || !tp->vis_u || !tp->rho_v ||
            !tp->vis_v)
            tp = NULL;
        s.tp = tp && tp->chains ? tp : NULL;
        crisp_raster_vertex a, b;
        double uv0[2], uv[2];
        path_point(c, job, 0, uv0);
        int have_a = 0, open = 0; /* open: the ribbon so far ends at a */
        for (int k = 0; k + 1 < n; k++) {
            path_point(c, job, k + 1, uv);
            /* (this segment's middle, where refine() splits it first, and the next point) */
            rpt_prefetch(&s.pk, job->face, 0.5 * (uv0[0] + uv[0]), 0.5 * (uv0[1] + uv[1]));
            if (k + 2 < n) {
                double nx[2];
                path_point(c, job, k + 2, nx);
                rpt_prefetch(&s.pk, job->face, nx[0], nx[1]);
            }
            if ((tp && uv_hidden(tp, uv0, uv)) ||
                (c->rb->hidden && pieces_hidden(c->rb, c->sc, job->face, uv0, uv))) {
                if (open) {
                    crisp_raster_vertex brk = a;
                    brk.clip[3] = -1;
                    emit(&s, &brk);
                    open = 0;
                }
                have_a = 0;
                uv0[0] = uv[0], uv0[1] = uv[1];
                continue;
            }
            if (!have_a)
                ribbon_vertex(c->sc, job->face, s.surf, s.reversed, *s.m, uv0[0], uv0[1], &a,
                              &s.pk);
            have_a = 1;
            ribbon_vertex(c->sc, job->face, s.surf, s.reversed, *s.m, uv[0], uv[1], &b, &s.pk);
            /* Segments that cannot reach the view are left out without a sample (at extreme zoom
             * almost all of a polyline is off screen); where the image may run far from the
             * chord, refine() looks at the middle. */
            if (!segment_may_show(&a, &b, s.w, s.h) && !image_may_be_long(&s, &a, &b)) {
                if (open) {
                    crisp_raster_vertex brk = a;
                    brk.clip[3] = -1;
                    emit(&s, &brk);
                    open = 0;
                }
            } else {
                if (!open) emit(&s, &a);
                refine(&s, &a, &b, 0, 1);
                open = 1;
            }
            a = b;
            uv0[0] = uv[0], uv0[1] = uv[1];
        }
        job->pts = NULL;
        job->count = 0;
        if (!s.failed && s.count) {
            job->pts = crisp_arena_alloc(c->rb->arena[worker], s.count, sizeof *job->pts);
            if (job->pts) memcpy(job->pts, *s.pts, s.count * sizeof *job->pts);
            s.failed = !job->pts;
            job->count = job->pts ? s.count : 0;
        }
        if (s.failed)
            c->rb->wstatus[worker] =
                crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim ribbons");
    }
}

/* Quads of 4 vertices (triangles 0 1 2, 0 2 3) between consecutive samples, offset on screen by
 * RIBBON_PX across and along the segment; a segment with an end behind the eye gets vertices with
 * clip[3] = -1 (not drawn). */
static void build_quads(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    ribbon_ctx *c = vctx;
    double sx = 2.0 / c->trees->width, sy = 2.0 / c->trees->height;
    for (size_t j = begin; j < end; j++) {
        const ribbon_job *job = &c->rb->jobs[j];
        for (uint32_t q = 0; q + 1 < job->count; q++) {
            const crisp_raster_vertex *a = &job->pts[q], *b = &job->pts[q + 1];
            crisp_plan_ribbon_vertex *v = c->out + 4 * ((size_t)job->qbase + q);
            double dx = 0, dy = 0;
            int ok = a->clip[3] > 0 && b->clip[3] > 0;
            if (ok) {
                dx = (b->clip[0] / b->clip[3] - a->clip[0] / a->clip[3]) / sx;
                dy = -(b->clip[1] / b->clip[3] - a->clip[1] / a->clip[3]) / sy;
                double len = hypot(dx, dy);
                ok = len > 0 && isfinite(len);
                if (ok) dx /= len, dy /= len;
            }
            for (int corner = 0; corner < 4; corner++) {
                const crisp_raster_vertex *src = corner < 2 ? a : b;
                crisp_plan_ribbon_vertex *o = &v[corner];
                memcpy(o->clip, src->clip, sizeof o->clip);
                o->uv[0] = (float)src->attr[0];
                o->uv[1] = (float)src->attr[1];
                for (int k = 0; k < 3; k++)
                    o->normal[k] = (float)src->attr[2 + k];
                o->face = job->face;
                if (!ok) {
                    o->clip[3] = -1; /* backends clip these triangles away */
                    continue;
                }
                double along = corner < 2 ? -RIBBON_PX : RIBBON_PX;
                double side = (corner == 0 || corner == 3) ? -RIBBON_PX : RIBBON_PX;
                double ox = along * dx - side * dy,
                       oy = along * dy + side * dx; /* pixels, y down */
                o->clip[0] += ox * sx * o->clip[3];
                o->clip[1] -= oy * sy * o->clip[3];
            }
        }
    }
}

/* The samples the workers found missing in the last pass, into the table (made on first use;
 * without memory none is kept). */
static void keep_points(crisp__ribbons *rb)
{
    for (int w = 0; w < rb->workers; w++) {
        uint32_t n = rb->fresh[w] ? rb->fresh_count[w] : 0;
        if (n && !rb->points) rb->points = calloc(RPT_SLOTS, sizeof *rb->points);
        for (uint32_t i = 0; rb->points && i < n; i++) {
            const ribbon_point_kept *e = &rb->fresh[w][i];
            /* Two slots a key: the second when the first holds another key of this scene. */
            size_t k = rpt_slot(e->face, e->u, e->v);
            if (rb->points[k].serial == e->serial &&
                !rpt_is(&rb->points[k], e->serial, e->face, e->u, e->v))
                k ^= 1;
            rb->points[k] = *e;
        }
        rb->fresh_count[w] = 0;
    }
}

crisp_status crisp__ribbons_build(crisp__ribbons *rb, const crisp__trees *trees,
                                  const crisp_scene *sc, uint32_t only_face, crisp_pool *pool,
                                  crisp_plan_ribbon_vertex **verts, size_t *cap,
                                  uint32_t *face_first, uint32_t *face_quads, uint32_t *quad_count)
{
    crisp_status st;
    size_t jobs = 0;
    uint32_t f0 = only_face == UINT32_MAX ? 0 : only_face;
    uint32_t f1 = only_face == UINT32_MAX ? sc->face_count : only_face + 1;
    for (uint32_t f = f0; f < f1; f++) {
        if (!trees->face_tau[f]) continue;
        const crisp_scene_face *sf = &sc->faces[f];
        if (!sf->piece_count && sf->grid_u && sf->grid_v) {
            for (uint32_t k = 0; k < 4; k++) {
                if (((k & 1) ? sf->closed_u : sf->closed_v)) continue;
                if ((st = crisp_grow((void **)&rb->jobs, &rb->job_cap, jobs + 1, sizeof *rb->jobs)))
                    return st;
                rb->jobs[jobs++] = (ribbon_job){.face = f, .piece = RIBBON_EDGE | k};
            }
            continue;
        }
        const crisp_trim_polyline *pl = &trees->trims[f].polyline;
        for (int k = 0; k < pl->piece_count; k++) {
            if (pl->first[k + 1] - pl->first[k] < 2) continue;
            if ((st = crisp_grow((void **)&rb->jobs, &rb->job_cap, jobs + 1, sizeof *rb->jobs)))
                return st;
            rb->jobs[jobs++] = (ribbon_job){.face = f, .piece = (uint32_t)k};
        }
    }
    /* Which worker samples which job depends on scheduling: each worker's arena is made ready
     * for the whole of the last frame's samples (and a quarter more), so a steady view allocates
     * nothing whoever does the work. */
    size_t want = rb->last_used + rb->last_used / 4;
    /* Likewise every worker's scratch holds the last build's longest job (and a quarter more). */
    uint32_t want_pts = rb->last_max + rb->last_max / 4;
    for (int w = 0; w < rb->workers; w++) {
        crisp_arena_reset(rb->arena[w]);
        if (want && (st = crisp_arena_reserve(rb->arena[w], want))) return st;
        if (want_pts > rb->scratch_cap[w]) {
            crisp_raster_vertex *n = realloc(rb->scratch[w], (size_t)want_pts * sizeof *n);
            if (!n) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim ribbons");
            rb->scratch[w] = n;
            rb->scratch_cap[w] = want_pts;
        }
        rb->wstatus[w] = CRISP_OK;
    }
    for (int w = 0; w < rb->workers; w++) {
        rb->fresh_count[w] = 0;
        if (!rb->fresh[w]) rb->fresh[w] = malloc(RPT_FRESH * sizeof *rb->fresh[w]);
    }
    ribbon_ctx c = {rb, trees, sc, NULL};
    crisp_pool_parallel_for(pool, jobs, 4, sample_ribbons, &c);
    keep_points(rb);
    rb->last_used = 0;
    for (int w = 0; w < rb->workers; w++) {
        if (rb->wstatus[w]) return rb->wstatus[w];
        rb->last_used += crisp_arena_used(rb->arena[w]);
    }
    rb->last_max = 0;
    for (size_t j = 0; j < jobs; j++)
        rb->last_max = rb->jobs[j].count > rb->last_max ? rb->jobs[j].count : rb->last_max;
    /* Lay the quads out face after face. */
    size_t quads = 0;
    for (uint32_t f = f0; f < f1; f++)
        face_quads[f - f0] = 0;
    for (size_t j = 0; j < jobs; j++) {
        ribbon_job *job = &rb->jobs[j];
        uint32_t segs = job->count ? job->count - 1 : 0;
        if (!face_quads[job->face - f0]) face_first[job->face - f0] = (uint32_t)quads;
        job->qbase = (uint32_t)quads;
        face_quads[job->face - f0] += segs;
        quads += segs;
        if (quads > UINT32_MAX / 8)
            return crisp_error(CRISP_ERR_LIMIT, "more than 2^29 trim ribbon quads in one frame");
    }
    for (uint32_t f = f0; f < f1; f++)
        if (!face_quads[f - f0]) face_first[f - f0] = (uint32_t)quads;
    if ((st = crisp_grow((void **)verts, cap, 4 * (quads ? quads : 1), sizeof **verts))) return st;
    c.out = *verts;
    crisp_pool_parallel_for(pool, jobs, 16, build_quads, &c);
    *quad_count = (uint32_t)quads;
    return CRISP_OK;
}
