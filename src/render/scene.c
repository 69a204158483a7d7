/* Preparing a model for rendering (docs/design.md section 2, "prepare"): Bézier extraction of every
 * face's surface and trim curves, patch boxes, and the scene box. View-independent; rebuilt only
 * when the model changes. */
#include "crisp/cells.h" /* crisp_hash_bytes */
#include "crisp/slefe.h"
#include "raster.h" /* crisp__alloc_lines */
#include "render_internal.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#ifdef __GLIBC__ /* (defined by the headers above) */
#include <malloc.h>
#endif

/* 1 when the surface's control net closes on itself: the first and last columns (dir 0) or
 * rows (dir 1) of Euclidean control points coincide, so the boundary curves are one curve. */
static int closes(const crisp_surface *s, int dir)
{
    int nu = s->count_u, nv = s->count_v, n = dir ? nu : nv;
    double size = 0, gap = 0;
    for (int k = 0; k < n; k++) {
        const double *a = s->cpw + 4 * (size_t)(dir ? k : k * nu);
        const double *b = s->cpw + 4 * (size_t)(dir ? (nv - 1) * nu + k : k * nu + nu - 1);
        for (int c = 0; c < 3; c++) {
            double pa = a[c] / a[3], pb = b[c] / b[3];
            gap = fmax(gap, fabs(pa - pb));
            size = fmax(size, fmax(fabs(pa), fabs(pb)));
        }
    }
    return gap <= 1e-12 * (size + 1e-300);
}

/* A box that contains the patch: its SLEFE tile boxes intersected with its control hull. Where
 * that is far larger than the patch's corners suggest (a control net that is wild although the
 * surface is small, as exporters leave over knot spans of 1e-7 of the domain, or a rational patch
 * with uneven weights) the patch is split in four, recursively, and the union of the parts'
 * boxes kept: sub-patch control nets converge to the surface. The boxes frame the default camera
 * and prune ray casting. */
#define BOX_SEGMENTS 4
#define BOX_DEPTH 5
static void tile_box(const crisp_bezier_patch *p, double box[6])
{
    double lo[CRISP_SLEFE_GRID(BOX_SEGMENTS) * 4], up[CRISP_SLEFE_GRID(BOX_SEGMENTS) * 4];
    double blo[BOX_SEGMENTS * BOX_SEGMENTS * 3], bhi[BOX_SEGMENTS * BOX_SEGMENTS * 3];
    crisp_bezier_patch_bbox(p, box);
    if (crisp_slefe_patch(p, BOX_SEGMENTS, lo, up) ||
        crisp_slefe_patch_tiles(BOX_SEGMENTS, lo, up, blo, bhi))
        return;
    double t[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < BOX_SEGMENTS * BOX_SEGMENTS; i++)
        for (int k = 0; k < 3; k++) {
            t[k] = fmin(t[k], blo[3 * i + k]);
            t[k + 3] = fmax(t[k + 3], bhi[3 * i + k]);
        }
    for (int k = 0; k < 3; k++) {
        box[k] = fmax(box[k], t[k]);
        box[k + 3] = fmin(box[k + 3], t[k + 3]);
    }
}

static double diag(const double b[6])
{
    return sqrt((b[3] - b[0]) * (b[3] - b[0]) + (b[4] - b[1]) * (b[4] - b[1]) +
                (b[5] - b[2]) * (b[5] - b[2]));
}

static void box_union(double box[6], const double b[6])
{
    for (int q = 0; q < 3; q++) {
        box[q] = fmin(box[q], b[q]);
        box[q + 3] = fmax(box[q + 3], b[q + 3]);
    }
}

static void patch_box(const crisp_bezier_patch *p, int depth, double box[6])
{
    /* Cheap first: the control hull, when it is not much larger than the corners' box. */
    double c[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < 4; k++) {
        double P[3];
        crisp_bezier_patch_eval(p, k & 1, k >> 1, P);
        for (int q = 0; q < 3; q++) {
            c[q] = fmin(c[q], P[q]);
            c[q + 3] = fmax(c[q + 3], P[q]);
        }
    }
    double limit = 4 * diag(c) + 1e-300;
    crisp_bezier_patch_bbox(p, box);
    if (diag(box) <= limit) return;
    tile_box(p, box);
    double d = diag(box);
    if (depth >= BOX_DEPTH || !(d > limit) || !isfinite(d)) return;
    double storage[2 * CRISP__PATCH_DOUBLES], tmp[CRISP__PATCH_DOUBLES];
    double u[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < 4; k++) {
        crisp_bezier_patch cell;
        double cb[6], s0 = 0.5 * (k & 1), t0 = 0.5 * (k >> 1);
        crisp__subpatch(p, s0, s0 + 0.5, t0, t0 + 0.5, storage, tmp, &cell);
        patch_box(&cell, depth + 1, cb);
        box_union(u, cb);
    }
    for (int q = 0; q < 3; q++) {
        box[q] = fmax(box[q], u[q]);
        box[q + 3] = fmin(box[q + 3], u[q + 3]);
    }
}

/* 1 when the Bezier coefficients of coordinate q's derivative along dir (0: s, 1: t) of p keep
 * one strict sign: q is then monotone along dir over the patch, with no extreme inside it. */
static int monotone(const crisp_bezier_patch *p, int q, int dir)
{
    int nu = p->du + 1, sign = 0;
    if (p->rational) return 0;
    for (int j = 0; j <= p->dv - dir; j++)
        for (int i = 0; i <= p->du - (1 - dir); i++) {
            const double *a = p->cpw + 4 * (j * nu + i);
            const double *b = p->cpw + 4 * (dir ? (j + 1) * nu + i : j * nu + i + 1);
            double d = b[q] - a[q];
            int sg = d > 0 ? 1 : d < 0 ? -1 : 0;
            if (!sg || (sign && sg != sign)) return 0;
            sign = sg;
        }
    return sign != 0;
}

/* A face whose trimmed region is a thin sliver of the (u, v) box of its loops (its loops' area
 * under 1/16 of that box, as a lens between two close edges along a diagonal of a patch:
 * trj6_b1-ec-214.stp #6387, 1e-6 of its patch's v range wide, on a patch 30,000 long): the
 * patches clipped to the box reach far beyond what is drawn. Where a coordinate is monotone along
 * s or t over such a patch piece, it takes its extremes on the region's boundary, so the box of
 * the boundary's points (the trim pieces' images, sampled) bounds it; other coordinates keep the
 * clipped box (the sampled box widened by 1% of its diagonal). Returns 0 when the face is not thin
 * (or too large to look at), leaving box. */
static int thin_face_box(const crisp_scene *s, const crisp_scene_face *sf, const double lo[2],
                         const double hi[2], const double clipped[6], double box[6])
{
    if (sf->piece_count == 0 || sf->piece_count > 4096) return 0;
    double area = 0;
    for (uint32_t i = sf->first_piece; i < sf->first_piece + sf->piece_count; i++) {
        const crisp_bezier_curve *c = &s->pieces[i];
        for (int k = 0; k < c->degree; k++) {
            const double *a = c->cpw + 3 * k, *b = c->cpw + 3 * (k + 1);
            area += (a[0] / a[2]) * (b[1] / b[2]) - (b[0] / b[2]) * (a[1] / a[2]);
        }
    }
    area = 0.5 * fabs(area);
    if (!(area < (hi[0] - lo[0]) * (hi[1] - lo[1]) / 16)) return 0;
    /* Which coordinates are monotone on every patch the loops' box meets. */
    int mono[3] = {1, 1, 1};
    double storage[2 * CRISP__PATCH_DOUBLES], tmp[CRISP__PATCH_DOUBLES];
    for (uint32_t k = sf->first_patch; k < sf->first_patch + sf->patch_count; k++) {
        const crisp_bezier_patch *b = &s->patches[k].bez;
        double su = b->u1 - b->u0, sv = b->v1 - b->v0;
        if (!(su > 0) || !(sv > 0)) return 0;
        double s0 = fmax(0, (lo[0] - b->u0) / su), s1 = fmin(1, (hi[0] - b->u0) / su);
        double t0 = fmax(0, (lo[1] - b->v0) / sv), t1 = fmin(1, (hi[1] - b->v0) / sv);
        if (!(s0 <= s1 && t0 <= t1)) continue;
        crisp_bezier_patch cell;
        crisp__subpatch(b, s0, s1, t0, t1, storage, tmp, &cell);
        for (int q = 0; q < 3; q++)
            mono[q] &= monotone(&cell, q, 0) || monotone(&cell, q, 1);
    }
    if (!mono[0] && !mono[1] && !mono[2]) return 0;
    /* The boundary's points: every piece at 33 parameters, on the patch holding each. */
    double bb[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    uint32_t hint = sf->first_patch;
    for (uint32_t i = sf->first_piece; i < sf->first_piece + sf->piece_count; i++)
        for (int k = 0; k <= 32; k++) {
            double uv[3], P[3];
            crisp_bezier_curve_eval(&s->pieces[i], k / 32.0, uv);
            uint32_t at = UINT32_MAX;
            for (uint32_t m = 0; m < sf->patch_count && at == UINT32_MAX; m++) {
                uint32_t pk = sf->first_patch + (hint - sf->first_patch + m) % sf->patch_count;
                const crisp_bezier_patch *b = &s->patches[pk].bez;
                if (uv[0] >= b->u0 && uv[0] <= b->u1 && uv[1] >= b->v0 && uv[1] <= b->v1) at = pk;
            }
            if (at == UINT32_MAX) return 0;
            hint = at;
            const crisp_bezier_patch *b = &s->patches[at].bez;
            crisp_bezier_patch_eval(b, (uv[0] - b->u0) / (b->u1 - b->u0),
                                    (uv[1] - b->v0) / (b->v1 - b->v0), P);
            for (int q = 0; q < 3; q++)
                bb[q] = fmin(bb[q], P[q]), bb[q + 3] = fmax(bb[q + 3], P[q]);
        }
    double margin = 0.01 * diag(bb); /* for the samples' chords */
    for (int q = 0; q < 3; q++) {
        double l = mono[q] ? bb[q] - margin : clipped[q];
        double h = mono[q] ? bb[q + 3] + margin : clipped[q + 3];
        box[q] = fmin(box[q], l);
        box[q + 3] = fmax(box[q + 3], h);
    }
    return 1;
}

/* Add to box what face sf can show: its patches clipped to the (u, v) box of its trim loops (the
 * control polygons of the loops' pieces, which contain the curves). A large base surface trimmed
 * to a small face (real files do this: OCCT's PRO20358-W7.igs draws 1/8 of its surface) would
 * otherwise frame the default camera on the whole untrimmed surface. Patch boxes themselves
 * (culling, ray pruning) stay whole. */
static void face_framing_box(const crisp_scene *s, const crisp_scene_face *sf, double box[6])
{
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (uint32_t i = sf->first_piece; i < sf->first_piece + sf->piece_count; i++) {
        const crisp_bezier_curve *c = &s->pieces[i];
        for (int k = 0; k <= c->degree; k++) {
            const double *q = c->cpw + 3 * k;
            for (int a = 0; a < 2; a++) {
                double x = q[a] / q[2];
                lo[a] = fmin(lo[a], x);
                hi[a] = fmax(hi[a], x);
            }
        }
    }
    int trimmed = sf->piece_count > 0 && lo[0] <= hi[0] && lo[1] <= hi[1];
    double storage[2 * CRISP__PATCH_DOUBLES], tmp[CRISP__PATCH_DOUBLES];
    double clipped[6] = {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    double *into = box;
    if (trimmed) into = clipped;
    for (uint32_t k = sf->first_patch; k < sf->first_patch + sf->patch_count; k++) {
        const crisp_scene_patch *p = &s->patches[k];
        const crisp_bezier_patch *b = &p->bez;
        if (!trimmed) {
            box_union(into, p->box);
            continue;
        }
        double su = b->u1 - b->u0, sv = b->v1 - b->v0;
        if (!(su > 0) || !(sv > 0)) {
            box_union(into, p->box);
            continue;
        }
        double s0 = fmax(0, (lo[0] - b->u0) / su), s1 = fmin(1, (hi[0] - b->u0) / su);
        double t0 = fmax(0, (lo[1] - b->v0) / sv), t1 = fmin(1, (hi[1] - b->v0) / sv);
        if (!(s0 <= s1 && t0 <= t1)) continue; /* outside every loop: never drawn */
        if (s0 <= 0 && s1 >= 1 && t0 <= 0 && t1 >= 1) {
            box_union(into, p->box);
            continue;
        }
        crisp_bezier_patch cell;
        double cb[6];
        crisp__subpatch(b, s0, s1, t0, t1, storage, tmp, &cell);
        patch_box(&cell, 0, cb);
        box_union(into, cb);
    }
    if (trimmed && !thin_face_box(s, sf, lo, hi, clipped, box)) box_union(box, clipped);
}

void crisp_scene_destroy(crisp_scene *s)
{
    if (!s) return;
    if (s->face_patches)
        for (uint32_t f = 0; f < s->face_count; f++)
            crisp_bezier_patches_free(&s->face_patches[f]);
    free(s->face_patches);
    free(s->faces);
    free(s->patches);
    free(s->pieces);
    free(s->loops);
    free(s->control_points);
    free(s->patch_records);
    free(s);
}

/* One array of every patch's control points (the GPU's storage buffer), with a record per patch;
 * the patches' own arrays are then freed and their cpw point into it. */
static crisp_status flatten_control_points(crisp_scene *s)
{
    size_t total = 0;
    for (uint32_t p = 0; p < s->patch_count; p++)
        total += (size_t)(s->patches[p].bez.du + 1) * (size_t)(s->patches[p].bez.dv + 1);
    if (total > UINT32_MAX)
        return crisp_error(CRISP_ERR_LIMIT, "%zu control points in the scene: at most 2^32", total);
    s->control_points = crisp_malloc_array(total ? total : 1, 4 * sizeof(double));
    s->patch_records =
        crisp_calloc_array(s->patch_count ? s->patch_count : 1, sizeof *s->patch_records);
    if (!s->control_points || !s->patch_records)
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for %zu control points", total);
    s->control_point_count = total;
    size_t at = 0;
    for (uint32_t f = 0; f < s->face_count; f++) {
        crisp_bezier_patches *fp = &s->face_patches[f];
        for (int k = 0; k < fp->count; k++) {
            crisp_bezier_patch *b = &fp->patches[k];
            size_t n = (size_t)(b->du + 1) * (size_t)(b->dv + 1);
            memcpy(s->control_points + 4 * at, b->cpw, n * 4 * sizeof(double));
            b->cpw = s->control_points + 4 * at;
            uint32_t p = s->faces[f].first_patch + (uint32_t)k;
            s->patches[p].bez.cpw = b->cpw;
            s->patch_records[p] = (crisp_scene_patch_record){.first_cp = (uint32_t)at,
                                                             .du = (uint32_t)b->du,
                                                             .dv = (uint32_t)b->dv,
                                                             .face = f,
                                                             .u0 = b->u0,
                                                             .u1 = b->u1,
                                                             .v0 = b->v0,
                                                             .v1 = b->v1};
            at += n;
        }
        free(fp->storage);
        fp->storage = NULL;
    }
    return CRISP_OK;
}

static _Atomic uint64_t trim_serials; /* crisp_scene.trim_serial */

/* FNV-1a (crisp_hash_bytes, chained) over what a Bézier trim piece is made of (not its unused
 * control-point slots). */
static uint64_t piece_hash(uint64_t h, const crisp_bezier_curve *c)
{
    int head[3] = {c->dim, c->degree, c->rational};
    h = crisp_hash_bytes(h, head, sizeof head);
    h = crisp_hash_bytes(h, &c->t0, 2 * sizeof c->t0);
    return crisp_hash_bytes(h, c->cpw,
                            (size_t)(c->degree + 1) * (size_t)(c->dim + 1) * sizeof *c->cpw);
}

static int piece_equal(const crisp_bezier_curve *a, const crisp_bezier_curve *b)
{
    return a->dim == b->dim && a->degree == b->degree && a->rational == b->rational &&
           a->t0 == b->t0 && a->t1 == b->t1 &&
           !memcmp(a->cpw, b->cpw, (size_t)(a->degree + 1) * (size_t)(a->dim + 1) * sizeof *a->cpw);
}

/* The Bézier pieces of every face's trim loops, loop after loop, face after face (rebuilt whole
 * when one face's loops change: pieces are few next to patches). A face whose pieces are the same
 * as an earlier face's, piece for piece (instances of one part in an assembly: impeller.igs x 49
 * held 540,000 pieces of 544 bytes, 290 MB, for 11,000 different ones; issue 12), takes that
 * face's range instead of a copy: crisp_scene_face.first_piece may be shared, and what is built
 * per range of pieces (the planner's coarse trim polylines) can be shared too. */
static crisp_status extract_pieces(crisp_scene *s)
{
    const crisp_model *m = s->model;
    size_t loop_total = 0;
    for (uint32_t f = 0; f < s->face_count; f++)
        loop_total += (size_t)m->faces[f].loop_count;
    crisp_scene_loop *loops = crisp_calloc_array(loop_total ? loop_total : 1, sizeof *loops);
    if (!loops) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim loops");
    crisp_bezier_curve *all = NULL;
    size_t piece_cap = 0;
    uint32_t loop_count = 0, piece_count = 0;
    /* Faces with pieces by the hash of their pieces (open addressing, at most half full). */
    size_t slots = 16;
    while (slots < 2 * (size_t)s->face_count)
        slots *= 2;
    uint32_t *slot = crisp_malloc_array(slots, sizeof *slot);
    uint64_t *face_hash = crisp_malloc_array(s->face_count ? s->face_count : 1, sizeof *face_hash);
    if (!slot || !face_hash) {
        free(loops), free(slot), free(face_hash);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for trim pieces");
    }
    memset(slot, 0xff, slots * sizeof *slot);
    crisp_status st = CRISP_OK;
    for (uint32_t f = 0; f < s->face_count && !st; f++) {
        const crisp_face *src = &m->faces[f];
        crisp_scene_face *sf = &s->faces[f];
        sf->first_loop = loop_count;
        sf->loop_count = (uint32_t)src->loop_count;
        sf->first_piece = piece_count;
        for (int l = 0; l < src->loop_count && !st; l++) {
            const crisp_trim_loop *loop = &src->loops[l];
            crisp_scene_loop *sl = &loops[loop_count++];
            sl->first_piece = piece_count;
            sl->is_outer = loop->is_outer;
            for (int c = 0; c < loop->curve_count && !st; c++) {
                crisp_bezier_curve *pieces = NULL;
                int n = 0;
                if ((st = crisp_curve_to_bezier(loop->curves[c], &pieces, &n))) {
                    crisp_error_prefix("face %u (source entity %d), loop %d, curve %d", f,
                                       src->source_id, l, c);
                    break;
                }
                st = crisp_grow((void **)&all, &piece_cap, (size_t)piece_count + (size_t)n,
                                sizeof *all);
                if (!st) {
                    memcpy(all + piece_count, pieces, (size_t)n * sizeof *pieces);
                    piece_count += (uint32_t)n;
                }
                crisp_free(pieces);
            }
            sl->piece_count = piece_count - sl->first_piece;
        }
        sf->piece_count = piece_count - sf->first_piece;
        if (st || !sf->piece_count) continue;
        uint64_t h = 1469598103934665603ull ^ sf->piece_count;
        for (uint32_t k = sf->first_piece; k < piece_count; k++)
            h = piece_hash(h, &all[k]);
        face_hash[f] = h;
        size_t i = (size_t)h & (slots - 1);
        for (; slot[i] != UINT32_MAX; i = (i + 1) & (slots - 1)) {
            const crisp_scene_face *o = &s->faces[slot[i]];
            if (face_hash[slot[i]] != h || o->piece_count != sf->piece_count) continue;
            uint32_t k = 0;
            while (k < sf->piece_count &&
                   piece_equal(&all[o->first_piece + k], &all[sf->first_piece + k]))
                k++;
            if (k == sf->piece_count) break;
        }
        if (slot[i] == UINT32_MAX) {
            slot[i] = f;
            continue;
        }
        /* The same pieces as face slot[i]: point this face and its loops there. */
        uint32_t first = s->faces[slot[i]].first_piece;
        for (uint32_t l = sf->first_loop; l < loop_count; l++)
            loops[l].first_piece = first + (loops[l].first_piece - sf->first_piece);
        piece_count = sf->first_piece;
        sf->first_piece = first;
    }
    free(slot);
    free(face_hash);
    if (st) {
        free(loops);
        free(all);
        return st;
    }
    free(s->loops);
    free(s->pieces);
    s->loops = loops;
    s->pieces = all;
    s->loop_count = loop_count;
    s->piece_count = piece_count;
    s->trim_serial = atomic_fetch_add(&trim_serials, 1) + 1;
    return CRISP_OK;
}

crisp_status crisp_scene_update_trim(crisp_scene *s, uint32_t face)
{
    if (face >= s->face_count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "face %u: the scene has %u faces", face,
                           s->face_count);
    return extract_pieces(s);
}

crisp_status crisp_scene_prepare(const crisp_model *m, crisp_scene **dest)
{
    crisp_status st = CRISP_OK;
    crisp_scene *s = calloc(1, sizeof *s);
    if (!s) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory preparing the scene");
    static _Atomic uint64_t serials;
    s->serial = atomic_fetch_add(&serials, 1) + 1;
    s->model = m;
    s->face_count = (uint32_t)m->face_count;
    s->faces = crisp_calloc_array(s->face_count, sizeof *s->faces);
    s->face_patches = crisp_calloc_array(s->face_count, sizeof *s->face_patches);
    if (!s->faces || !s->face_patches) goto oom;
    size_t patch_total = 0;
    for (uint32_t f = 0; f < s->face_count; f++) {
        const crisp_face *src = &m->faces[f];
        if ((st = crisp_surface_to_bezier(src->surface, &s->face_patches[f]))) {
            crisp_error_prefix("face %u (source entity %d)", f, src->source_id);
            goto fail;
        }
        patch_total += (size_t)s->face_patches[f].count;
    }
    if (patch_total > UINT32_MAX / 2) {
        st = crisp_error(CRISP_ERR_LIMIT, "%zu Bézier patches: too many", patch_total);
        goto fail;
    }
    s->patches = crisp_calloc_array(patch_total, sizeof *s->patches);
    if (!s->patches) goto oom;
    for (int k = 0; k < 3; k++) {
        s->box[k] = INFINITY;
        s->box[k + 3] = -INFINITY;
    }
    for (uint32_t f = 0; f < s->face_count; f++) {
        const crisp_face *src = &m->faces[f];
        const crisp_surface *surf = src->surface;
        crisp_scene_face *sf = &s->faces[f];
        sf->src = src;
        sf->first_patch = s->patch_count;
        sf->patch_count = (uint32_t)s->face_patches[f].count;
        /* The patches come u fastest: the first row ends where v0 changes. */
        const crisp_bezier_patches *fp = &s->face_patches[f];
        uint32_t gu = 0;
        while (gu < (uint32_t)fp->count && fp->patches[gu].v0 == fp->patches[0].v0)
            gu++;
        sf->grid_u = gu;
        sf->grid_v = gu ? (uint32_t)fp->count / gu : 0;
        crisp_surface_domain(surf, sf->domain);
        sf->closed_u = sf->grid_u > 1 && closes(surf, 0);
        sf->closed_v = sf->grid_v > 1 && closes(surf, 1);
        static const float grey[4] = {0.72f, 0.74f, 0.78f, 1.0f};
        memcpy(sf->color, src->has_color ? src->color : grey, sizeof sf->color);
        for (uint32_t k = 0; k < sf->patch_count; k++) {
            crisp_scene_patch *p = &s->patches[s->patch_count++];
            p->bez = s->face_patches[f].patches[k];
            p->face = f;
            p->iu = sf->grid_u ? k % sf->grid_u : 0;
            p->iv = sf->grid_u ? k / sf->grid_u : 0;
            patch_box(&p->bez, 0, p->box);
        }
    }
    if ((st = flatten_control_points(s)) || (st = extract_pieces(s))) goto fail;
    for (uint32_t f = 0; f < s->face_count; f++)
        face_framing_box(s, &s->faces[f], s->box);
#ifdef __GLIBC__
    /* The conversions' temporaries (the faces' Bézier patches and trim pieces before they are
     * flattened and shared) leave their memory free in malloc's arenas but resident, between
     * what the scene keeps: give it back to the system here, before any frame (imp49: 105 MB
     * free, RSS 412 -> 324 MB, about 100 ms; inside the first frame it cost imp49 far's 130 ms
     * more, session 14). */
    malloc_trim(0);
#endif
    *dest = s;
    return CRISP_OK;
oom:
    st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory preparing the scene");
fail:
    crisp_scene_destroy(s);
    return st;
}

crisp_status crisp_image_init(crisp_image *img, int width, int height)
{
    if (width <= 0 || height <= 0 || width > 65536 || height > 65536)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image size %dx%d: expected 1..65536", width,
                           height);
    size_t n = (size_t)width * height;
    memset(img, 0, sizeof *img);
    img->width = width;
    img->height = height;
    /* On cache lines (the resolve's stores; crisp__image_clear below writes every value). */
    img->rgba = crisp__alloc_lines(n, 4 * sizeof(float));
    img->depth = crisp__alloc_lines(n, sizeof(float));
    img->normal = crisp__alloc_lines(n, 3 * sizeof(float));
    img->uv = crisp__alloc_lines(n, 2 * sizeof(float));
    img->face = crisp__alloc_lines(n, sizeof(int32_t));
    if (!img->rgba || !img->depth || !img->normal || !img->uv || !img->face) {
        crisp_image_free(img);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a %dx%d image", width, height);
    }
    crisp__image_clear(img);
    return CRISP_OK;
}

void crisp__image_clear(crisp_image *img)
{
    size_t n = (size_t)img->width * img->height;
    memset(img->rgba, 0, n * 4 * sizeof *img->rgba);
    memset(img->normal, 0, n * 3 * sizeof *img->normal);
    memset(img->uv, 0, n * 2 * sizeof *img->uv);
    for (size_t i = 0; i < n; i++) {
        img->depth[i] = INFINITY;
        img->face[i] = -1;
    }
}

void crisp_image_free(crisp_image *img)
{
    free(img->rgba);
    free(img->depth);
    free(img->normal);
    free(img->uv);
    free(img->face);
    memset(img, 0, sizeof *img);
}
