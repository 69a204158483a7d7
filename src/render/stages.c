/* The CPU backend's frames planned in stages (issue 12; render_internal.h says how
 * crisp_render_cpu uses them): the nearest faces (those seen in the last frame, else by their
 * boxes) planned and drawn first, then the faces of each later stage that the depth drawn so far
 * does not hide whole, and so on; a hidden face gets no trees, trim plan or ribbons. Every other
 * face gets what a one-stage plan (crisp_planner_plan) gives it, and the last stage's plan is
 * laid out as that one is, from the steps planner.c shares (planner.h). Whether stages pay is
 * decided frame by frame (STAGE_PAYS). */
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "occlusion.h"
#include "planner.h"
#include "render_internal.h"

/* Per face, the union of its patches' boxes; per patch, whether its parameter box meets the box
 * of its face's trim pieces' control points (kept while the scene and its trims are the same). A
 * point of the face that the trim table keeps lies in that box: the table keeps only v in the
 * pieces' v-range, and u between two crossings of its row with the trim polylines, whose vertices
 * are points of the pieces (crisp_trim_tessellate; chains and levels of detail join such
 * vertices), so in their control points' convex hulls; the ribbons' curve points too. A face
 * without pieces keeps every patch. */
static crisp_status face_boxes(crisp_planner *p, const crisp_scene *sc)
{
    crisp__stages *s = &p->stages;
    if (s->face_box && s->face_box_serial == sc->serial && s->face_box_trim == sc->trim_serial)
        return CRISP_OK;
    crisp_status st;
    if ((st = crisp_grow((void **)&s->face_box, &s->face_box_cap,
                         6 * (size_t)(sc->face_count ? sc->face_count : 1), sizeof(double))) ||
        (st = crisp_grow((void **)&s->patch_in, &s->patch_in_cap,
                         sc->patch_count ? sc->patch_count : 1, 1)))
        return st;
    for (uint32_t f = 0; f < sc->face_count; f++) {
        double *b = s->face_box + 6 * (size_t)f;
        for (int a = 0; a < 3; a++)
            b[a] = INFINITY, b[a + 3] = -INFINITY;
        const crisp_scene_face *sf = &sc->faces[f];
        double t[4] = {INFINITY, -INFINITY, INFINITY, -INFINITY}; /* u0, u1, v0, v1 */
        for (uint32_t k = sf->first_piece; k < sf->first_piece + sf->piece_count; k++) {
            const crisp_bezier_curve *c = &sc->pieces[k];
            for (int i = 0; i <= c->degree; i++) {
                double u = c->cpw[3 * i] / c->cpw[3 * i + 2],
                       v = c->cpw[3 * i + 1] / c->cpw[3 * i + 2];
                t[0] = fmin(t[0], u), t[1] = fmax(t[1], u);
                t[2] = fmin(t[2], v), t[3] = fmax(t[3], v);
                if (!(c->cpw[3 * i + 2] > 0) || !isfinite(u + v)) /* not a hull: keep all */
                    t[0] = t[2] = -INFINITY, t[1] = t[3] = INFINITY;
            }
        }
        for (uint32_t q = sf->first_patch; q < sf->first_patch + sf->patch_count; q++) {
            const crisp_bezier_patch *z = &sc->patches[q].bez;
            s->patch_in[q] =
                !sf->piece_count || !(z->u1 < t[0] || z->u0 > t[1] || z->v1 < t[2] || z->v0 > t[3]);
            for (int a = 0; a < 3; a++) {
                b[a] = fmin(b[a], sc->patches[q].box[a]);
                b[a + 3] = fmax(b[a + 3], sc->patches[q].box[a + 3]);
            }
        }
    }
    s->face_box_serial = sc->serial;
    s->face_box_trim = sc->trim_serial;
    return CRISP_OK;
}

/* fmin / fmax of an accumulator that is never NaN (it starts at +-INFINITY) and a finite value:
 * the same comparisons downstream, without the library call (hull_screen, box_screen and
 * quad_unseen run per control point or corner, about a million times a frame on impeller.igs
 * close; their results feed block indices and comparisons only). */
static inline double lesser(double acc, double v)
{
    return v < acc ? v : acc;
}
static inline double greater(double acc, double v)
{
    return v > acc ? v : acc;
}

/* The box's corners in clip space: screen box lo, hi (pixels, y down) and the W range. Returns 0
 * when a corner is not in front of the eye (W <= 0 or not finite): then nothing is set but w0. */
static int box_screen(const double box[6], crisp_mat4 m, int width, int height, double lo[2],
                      double hi[2], double *w0, double *w1)
{
    lo[0] = lo[1] = INFINITY, hi[0] = hi[1] = -INFINITY;
    *w0 = INFINITY, *w1 = -INFINITY;
    for (int k = 0; k < 8; k++) {
        double c[3] = {box[(k & 1) ? 3 : 0], box[(k & 2) ? 4 : 1], box[(k & 4) ? 5 : 2]};
        double x = m[0][0] * c[0] + m[1][0] * c[1] + m[2][0] * c[2] + m[3][0];
        double y = m[0][1] * c[0] + m[1][1] * c[1] + m[2][1] * c[2] + m[3][1];
        double w = m[0][3] * c[0] + m[1][3] * c[1] + m[2][3] * c[2] + m[3][3];
        if (!(w > 0) || !isfinite(x + y + w)) {
            *w0 = -INFINITY;
            return 0;
        }
        double px = (x / w + 1) * 0.5 * width, py = (1 - y / w) * 0.5 * height;
        lo[0] = lesser(lo[0], px), hi[0] = greater(hi[0], px);
        lo[1] = lesser(lo[1], py), hi[1] = greater(hi[1], py);
        *w0 = lesser(*w0, w), *w1 = greater(*w1, w);
    }
    return 1;
}

typedef struct near_key {
    double w;
    uint32_t face;
} near_key;

static int near_key_cmp(const void *a, const void *b)
{
    const near_key *x = a, *y = b;
    if (x->w != y->w) return x->w < y->w ? -1 : 1;
    return x->face < y->face ? -1 : x->face > y->face;
}

#define STAGE_HIDDEN 255
/* Frames in stages go on while the hidden faces' patches are at least STAGE_PAYS_MIN and
 * STAGE_PAYS of those and the patches planned (a frame in stages costs a second trees build, a
 * block depth pass, the tests, and the draw's leaves batched by depth per stage rather than over
 * the frame); after one that hid less, every STAGE_PROBE-th frame tries again. */
#define STAGE_PAYS 0.125
#define STAGE_PAYS_MIN 64
#define STAGE_PROBE 16
/* Where the stages end: the screens the faces' boxes (clipped to the image) cover together, the
 * faces taken nearest first; the faces beyond the last are the last stage's. */
static const double stage_screens[] = {1, 4, 16};
#define STAGES ((int)(sizeof stage_screens / sizeof *stage_screens) + 1)

/* p->stages.stage: each face's stage. The faces seen in the last frame drawn in stages (of this
 * scene) are the first stage: a camera that moved a little sees most of them again, and their depth
 * hides most of the others. The other faces are taken nearest first (the least W of their box) and
 * a stage ends where their screen boxes, clipped to the image, add up to stage_screens images (the
 * first stage's included); faces that reach the eye plane are in the first stage, as are the
 * splat faces. Which stage a face is in changes the cost only : a face is dropped only when the
 * depth drawn hides it. Returns the count of faces not in the first stage. */
static crisp_status choose_stages(crisp_planner *p, const crisp_scene *sc, const crisp_camera *cam,
                                  uint32_t *deferred)
{
    crisp__stages *s = &p->stages;
    crisp_status st;
    *deferred = 0;
    if ((st = face_boxes(p, sc))) return st;
    uint32_t n = sc->face_count;
    near_key *key = crisp_malloc_array(n ? n : 1, sizeof *key);
    double *area = crisp_malloc_array(n ? n : 1, sizeof *area);
    if (!key || !area) {
        free(key);
        free(area);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory ordering %u faces", n);
    }
    crisp_camera_matrices cm;
    crisp_camera_matrices_compute(cam, &cm);
    uint32_t m = 0;
    double screen = (double)cam->width * cam->height, covered = 0;
    int seen = s->seen && s->seen_serial == sc->serial;
    for (uint32_t f = 0; f < n; f++) {
        s->stage[f] = 0;
        if (p->splat_face[f] || !sc->faces[f].patch_count) continue;
        if (seen && s->seen[f]) {
            covered = screen; /* the other faces come after it */
            continue;
        }
        double lo[2], hi[2], w0, w1;
        const double *b = s->face_box + 6 * (size_t)f;
        if (!box_screen(b, cm.view_proj, cam->width, cam->height, lo, hi, &w0, &w1)) {
            area[f] = screen;
            key[m++] = (near_key){-INFINITY, f};
            continue;
        }
        double x0 = fmax(lo[0], 0), x1 = fmin(hi[0], cam->width);
        double y0 = fmax(lo[1], 0), y1 = fmin(hi[1], cam->height);
        area[f] = x1 > x0 && y1 > y0 ? (x1 - x0) * (y1 - y0) : 0;
        key[m++] = (near_key){w0, f};
    }
    qsort(key, m, sizeof *key, near_key_cmp);
    int at = 0;
    for (uint32_t i = 0; i < m; i++) {
        uint32_t f = key[i].face;
        /* After the seen faces, one stage: their depth is most of the frame's. */
        int end = seen ? 1 : STAGES - 1;
        while (at < end && covered >= stage_screens[at] * screen && key[i].w > -INFINITY)
            at++;
        s->stage[f] = (uint8_t)at;
        *deferred += at > 0;
        covered += area[f];
    }
    s->stage_count = at + 1;
    free(key);
    free(area);
    return CRISP_OK;
}

typedef struct depth_drawn depth_drawn;
static depth_drawn depth_of(const double *hiz, const int win[4], double *coarse);
static int quad_unseen(const crisp_plan_ribbon_vertex *v, int width, int height, const int win[4],
                       const depth_drawn *d);

/* The current stage's faces (later) kept: their leaves (laid out), ribbons, levels and stats;
 * with the depth drawn by the earlier stages d (of the window win; NULL: none), not the ribbon
 * quads it finds unseen (quad_unseen). */
static crisp_status keep_stage(crisp_planner *p, const crisp_scene *sc, const depth_drawn *d,
                               const int win[4])
{
    crisp__stages *s = &p->stages;
    crisp_status st;
    const crisp_frame_plan *o = &p->out;
    size_t leaves = s->kept_leaf_count + o->leaf_count,
           quads = s->kept_quads + o->ribbon_quad_count;
    if ((st = crisp_grow((void **)&s->kept_leaves, &s->kept_leaf_cap, leaves ? leaves : 1,
                         sizeof *s->kept_leaves)) ||
        (st = crisp_grow((void **)&s->kept_ribbons, &s->kept_ribbon_cap, 4 * (quads ? quads : 1),
                         sizeof *s->kept_ribbons)))
        return st;
    for (uint32_t f = 0; f < sc->face_count; f++) {
        if (!s->later[f]) continue;
        uint32_t *k = s->kept + 5 * (size_t)f;
        const crisp_plan_face *pf = &p->faces[f];
        k[0] = (uint32_t)s->kept_leaf_count;
        k[1] = pf->leaf_count;
        memcpy(s->kept_leaves + s->kept_leaf_count, p->leaves + pf->first_leaf,
               pf->leaf_count * sizeof *p->leaves);
        s->kept_leaf_count += pf->leaf_count;
        k[2] = (uint32_t)s->kept_quads;
        k[3] = p->trees->face_tau[f] ? p->ribbon_quads[f] : 0;
        const crisp_plan_ribbon_vertex *v = p->ribbon_verts + 4 * (size_t)p->ribbon_first[f];
        if (!d) {
            memcpy(s->kept_ribbons + 4 * s->kept_quads, v, 4 * (size_t)k[3] * sizeof *v);
        } else {
            uint32_t kept = 0;
            for (uint32_t q = 0; q < k[3]; q++, v += 4)
                if (!quad_unseen(v, p->cam.width, p->cam.height, win, d))
                    memcpy(s->kept_ribbons + 4 * (s->kept_quads + kept++), v, 4 * sizeof *v);
            k[3] = kept;
        }
        s->kept_quads += k[3];
        k[4] = p->trees->face_tau[f];
        s->kept_rows[f] = p->trees->face_rows[f];
    }
    crisp_plan_stats *k = &s->kept_stats;
    const crisp_plan_stats *a = &o->stats;
    k->patches = a->patches;
    k->visible_patches += a->visible_patches;
    k->split_patches += a->split_patches;
    k->leaves += a->leaves;
    k->visible_faces += a->visible_faces;
    k->unresolved += a->unresolved;
    k->rows_clamped += a->rows_clamped;
    k->level_splits += a->level_splits;
    k->group_leaves += a->group_leaves;
    k->grouped_patches += a->grouped_patches;
    k->ms_levels += a->ms_levels;
    k->ms_edges += a->ms_edges;
    k->ms_trim += a->ms_trim;
    k->ms_ribbons += a->ms_ribbons;
    return CRISP_OK;
}

/* Plan the faces of the current stage (later), laid out to be drawn; kept for the final plan
 * (keep_stage with d and win). */
static crisp_status plan_stage(crisp_planner *p, const crisp_scene *sc, const crisp_camera *cam,
                               const depth_drawn *d, const int win[4])
{
    crisp__stages *s = &p->stages;
    crisp_status st;
    for (uint32_t f = 0; f < sc->face_count; f++)
        s->skip[f] = p->splat_face[f] || !s->later[f];
    if ((st = crisp__planner_plan_faces(p, sc, cam, s->skip, 1)) ||
        (st = crisp__planner_lay_out_leaves(p, sc, NULL)) ||
        (st = crisp__planner_lay_out_tables(p, sc)))
        return st;
    crisp__planner_point_out(p, sc);
    p->out.splat_range_count = 0;
    return keep_stage(p, sc, d, win);
}

crisp_status crisp__planner_plan_near(crisp_planner *p, const crisp_scene *sc,
                                      const crisp_camera *cam, const crisp_frame_plan **dest,
                                      const uint8_t **later)
{
    crisp__stages *s = &p->stages;
    crisp_status st = crisp_camera_check(cam);
    if (st) return st;
    p->finished = 0;
    if ((st = crisp__planner_ensure_faces(p, sc->face_count))) return st;
    size_t nf = sc->face_count ? sc->face_count : 1;
    if ((st = crisp_grow((void **)&s->stage, &s->stage_cap, nf, 1)) ||
        (st = crisp_grow((void **)&s->later, &s->later_cap, nf, 1)) ||
        (st = crisp_grow((void **)&s->skip, &s->skip_cap, nf, 1)) ||
        (st = crisp_grow((void **)&s->kept, &s->kept_cap, 5 * nf, sizeof *s->kept)) ||
        (st = crisp_grow((void **)&s->kept_rows, &s->kept_rows_cap, nf, sizeof *s->kept_rows)))
        return st;
    /* The splat choice first (a splat face is drawn as splats whichever stage). */
    double ts = crisp_time_now();
    if ((st = crisp__planner_choose_splats(p, sc, cam))) return st;
    double ms_splats = 1e3 * (crisp_time_now() - ts);
    uint32_t deferred = 0;
    *later = NULL;
    int probe =
        s->always || s->pays_serial != sc->serial || s->pays || ++s->quiet % STAGE_PROBE == 0;
    if (probe && (st = choose_stages(p, sc, cam, &deferred))) return st;
    if (!deferred) { /* one stage: the whole plan */
        p->staged = 0;
        if ((st = crisp__planner_plan_faces(p, sc, cam, NULL, 1)) ||
            (st = crisp__planner_finish_plan(p, sc, cam, NULL)))
            return st;
        p->out.stats.ms_levels += ms_splats;
        *dest = &p->out;
        return CRISP_OK;
    }
    memset(s->kept, 0, 5 * nf * sizeof *s->kept);
    memset(s->kept_rows, 0, nf * sizeof *s->kept_rows);
    s->kept_leaf_count = s->kept_quads = 0;
    s->kept_stats = (crisp_plan_stats){.ms_levels = ms_splats};
    s->hidden = 0;
    s->stage_at = 0;
    for (uint32_t f = 0; f < sc->face_count; f++)
        s->later[f] = s->stage[f] == 0;
    if ((st = plan_stage(p, sc, cam, NULL, NULL))) return st;
    p->staged = 2;
    p->cam = *cam;
    p->scene = sc;
    *later = s->later;
    *dest = &p->out;
    return CRISP_OK;
}

/* A patch's control net projected: per control point its clip x, y and W times its weight, and
 * the weight (homogeneous, so de Casteljau's subdivision applies to it as to the net); nu x nv
 * points, u fastest. */
#define HULL_SPLITS 4 /* halvings of a net, u and v in turn: at most 16 pieces a patch */
typedef struct hull_net {
    int nu, nv;
    double (*p)[4];
} hull_net;

/* The screen box lo, hi (pixels, y down) and the least W of the convex hull of the net's control
 * points: the patch piece, its tessellation (chords of its surface points) and its ribbons' curve
 * points lie in that hull, and a projection keeps a point of the hull of points in front of the
 * eye in the hull of their images (a point of the patch is a convex combination of the control
 * points with weights B_i w_i; on screen of their images with weights B_i W_i w_i, and its W of
 * their W). 0 when a control point is not in front of the eye (or its weight not positive). */
static int hull_screen(const hull_net *n, int width, int height, double lo[2], double hi[2],
                       double *w0)
{
    lo[0] = lo[1] = INFINITY, hi[0] = hi[1] = -INFINITY;
    *w0 = INFINITY;
    for (int k = 0; k < n->nu * n->nv; k++) {
        const double *c = n->p[k];
        if (!(c[2] > 0 && c[3] > 0) || !isfinite(c[0] + c[1] + c[2] + c[3])) return 0;
        double px = (c[0] / c[2] + 1) * 0.5 * width, py = (1 - c[1] / c[2]) * 0.5 * height;
        lo[0] = lesser(lo[0], px), hi[0] = greater(hi[0], px);
        lo[1] = lesser(lo[1], py), hi[1] = greater(hi[1], py);
        *w0 = lesser(*w0, c[2] / c[3]);
    }
    return 1;
}

/* The two halves a, b of net n at the middle of u (dir 0) or v (dir 1), by de Casteljau. */
static void hull_split(const hull_net *n, int dir, hull_net *a, hull_net *b)
{
    a->nu = b->nu = n->nu, a->nv = b->nv = n->nv;
    int len = dir ? n->nv : n->nu, lines = dir ? n->nu : n->nv;
    int step = dir ? n->nu : 1, next = dir ? 1 : n->nu; /* along a line; to the next line */
    for (int l = 0; l < lines; l++) {
        double t[16][4];
        for (int i = 0; i < len; i++)
            memcpy(t[i], n->p[l * next + i * step], sizeof t[i]);
        for (int r = 0; r < len; r++) {
            memcpy(a->p[l * next + r * step], t[0], sizeof t[0]);
            memcpy(b->p[l * next + (len - 1 - r) * step], t[len - 1 - r], sizeof t[0]);
            for (int i = 0; i < len - 1 - r; i++)
                for (int q = 0; q < 4; q++)
                    t[i][q] = 0.5 * (t[i][q] + t[i + 1][q]);
        }
    }
}

/* The block depth drawn by the earlier stages (crisp__occl_hidden's hiz, blocks_x x blocks_y
 * blocks) and a coarser level of it: per cell of DEPTH_CELL x DEPTH_CELL blocks the least of
 * their values (NaN when one is NaN), so that a rectangle's test reads a cell where it covers all
 * of its blocks (coarse NULL: none). */
#define DEPTH_CELL 4
struct depth_drawn {
    const double *hiz;
    int blocks_x, blocks_y;
    const double *coarse;
    int cells_x;
};

static int rect_hidden(const double lo_in[2], const double hi_in[2], double w0, const int win[4],
                       const depth_drawn *d);

/* 1 when rect_hidden holds for the net's hull, or for those of both its halves (level: the
 * halvings done; the next is in u on even levels, in v on odd ones; scratch: room for two nets
 * per halving left). */
static int net_hidden(const hull_net *n, int width, int height, const int win[4],
                      const depth_drawn *d, int level, double (*scratch)[4])
{
    double lo[2], hi[2], w0;
    if (!hull_screen(n, width, height, lo, hi, &w0)) return 0;
    if (rect_hidden(lo, hi, w0, win, d)) return 1;
    if (level == HULL_SPLITS) return 0;
    int np = n->nu * n->nv;
    hull_net h[2] = {{0, 0, scratch}, {0, 0, scratch + np}};
    hull_split(n, level & 1, &h[0], &h[1]);
    return net_hidden(&h[0], width, height, win, d, level + 1, scratch + 2 * np) &&
           net_hidden(&h[1], width, height, win, d, level + 1, scratch + 2 * np);
}

/* Room for a net and its halvings: HULL_ROOM nets of up to HULL_SMALL points (degrees up to 5
 * both ways) on the caller's stack (the later stages' face test is on the hot path of a close-up:
 * no malloc per patch), larger nets on the heap. */
#define HULL_ROOM (1 + 2 * HULL_SPLITS)
#define HULL_SMALL 36

/* Patch z's control net projected by m into n; its points go to room (HULL_ROOM nets of
 * HULL_SMALL points) when they fit, else to memory allocated here (free it when the result is
 * not room). NULL when z's degrees are above 15 or there is no memory. */
static double (*hull_project(const crisp_bezier_patch *z, crisp_mat4 m, hull_net *n,
                             double (*room)[4]))[4]
{
    if (z->du < 0 || z->dv < 0 || z->du > 15 || z->dv > 15) return NULL;
    int np = (z->du + 1) * (z->dv + 1);
    double(*p)[4] = np <= HULL_SMALL ? room : malloc((size_t)HULL_ROOM * (size_t)np * sizeof *p);
    if (!p) return NULL;
    *n = (hull_net){z->du + 1, z->dv + 1, p};
    for (int k = 0; k < np; k++) {
        const double *c = z->cpw + 4 * (size_t)k;
        for (int r = 0; r < 3; r++) {
            int row = r < 2 ? r : 3; /* clip x, y, W */
            p[k][r] = m[0][row] * c[0] + m[1][row] * c[1] + m[2][row] * c[2] + m[3][row] * c[3];
        }
        p[k][3] = c[3];
    }
    return p;
}

/* net_hidden of patch z's control net (not hidden when it cannot be projected: always safe). */
static int patch_hidden(const crisp_bezier_patch *z, crisp_mat4 m, int width, int height,
                        const int win[4], const depth_drawn *d)
{
    hull_net n;
    double room[HULL_ROOM * HULL_SMALL][4];
    double(*p)[4] = hull_project(z, m, &n, room);
    if (!p) return 0;
    int hidden = net_hidden(&n, width, height, win, d, 0, p + n.nu * n.nv);
    if (p != room) free(p);
    return hidden;
}

int crisp__stages_hull_piece(const crisp_bezier_patch *z, crisp_mat4 m, int width, int height,
                             int splits, unsigned piece, double lo[2], double hi[2], double *w0)
{
    hull_net n;
    double room[HULL_ROOM * HULL_SMALL][4];
    double(*p)[4] = hull_project(z, m, &n, room);
    if (!p || splits < 0 || splits > HULL_SPLITS) {
        if (p != room) free(p);
        return 0;
    }
    int np = n.nu * n.nv;
    for (int level = 0; level < splits; level++) {
        double(*at)[4] = p + (1 + 2 * level) * np;
        hull_net h[2] = {{0, 0, at}, {0, 0, at + np}};
        hull_split(&n, level & 1, &h[0], &h[1]);
        n = h[(piece >> level) & 1];
    }
    int ok = hull_screen(&n, width, height, lo, hi, w0);
    if (p != room) free(p);
    return ok;
}

/* The least of m and the n values from v on (NaN when one is NaN). */
static double least(const double *v, int n, double m)
{
    for (int k = 0; k < n; k++) {
        double x = v[k];
        m = x < m || x != x ? x : m;
    }
    return m;
}

/* crisp__occl_hidden(o, d->hiz, d->blocks_x), the same answer: o's bound is below every block of
 * its rectangle; the cells of the coarse level that the rectangle covers whole are read there. */
static int depth_hides(const crisp_occl_leaf *o, const depth_drawn *d)
{
    double iw = o->iw;
    if (!d->coarse) return crisp__occl_hidden(o, d->hiz, d->blocks_x);
    if (!(iw < INFINITY)) return 0;
    int x0 = o->bx0, y0 = o->by0, x1 = o->bx1 + 1, y1 = o->by1 + 1;      /* blocks [x0, x1) */
    int cx0 = (x0 + DEPTH_CELL - 1) / DEPTH_CELL, cx1 = x1 / DEPTH_CELL; /* cells [cx0, cx1) */
    int cy0 = (y0 + DEPTH_CELL - 1) / DEPTH_CELL, cy1 = y1 / DEPTH_CELL;
    if (cx0 >= cx1 || cy0 >= cy1) return crisp__occl_hidden(o, d->hiz, d->blocks_x);
    for (int cy = cy0; cy < cy1; cy++)
        if (!(iw < least(d->coarse + (size_t)cy * d->cells_x + cx0, cx1 - cx0, INFINITY))) return 0;
    /* The blocks around the cells: rows above and below, columns left and right between them. */
    int bxa = cx0 * DEPTH_CELL, bxb = cx1 * DEPTH_CELL, bya = cy0 * DEPTH_CELL,
        byb = cy1 * DEPTH_CELL;
    for (int by = y0; by < y1; by++) {
        const double *row = d->hiz + (size_t)by * d->blocks_x;
        double m = INFINITY;
        if (by < bya || by >= byb) {
            m = least(row + x0, x1 - x0, m);
        } else {
            m = least(row + x0, bxa - x0, m);
            m = least(row + bxb, x1 - bxb, m);
        }
        if (!(iw < m)) return 0;
    }
    return 1;
}

/* The coarse level of d (DEPTH_CELL x DEPTH_CELL blocks a cell) into coarse: block row after
 * block row into the cells' row (one pass over hiz in memory order), NaN kept by a flag. */
_Static_assert(DEPTH_CELL == 4, "depth_cells reads a cell's blocks of a row four at a time");
static void depth_cells(const depth_drawn *d, double *coarse)
{
    int full = d->blocks_x / DEPTH_CELL; /* cells with all their columns */
    for (int by = 0; by < d->blocks_y; by++) {
        double *out = coarse + (size_t)(by / DEPTH_CELL) * d->cells_x;
        const double *row = d->hiz + (size_t)by * d->blocks_x;
        int nan = 0;
        if (by % DEPTH_CELL == 0)
            for (int cx = 0; cx < d->cells_x; cx++)
                out[cx] = INFINITY;
        for (int cx = 0; cx < full; cx++) {
            const double *r = row + DEPTH_CELL * cx;
            double a = r[0] < r[1] ? r[0] : r[1], b = r[2] < r[3] ? r[2] : r[3];
            a = a < b ? a : b;
            out[cx] = a < out[cx] ? a : out[cx];
            nan |= (r[0] != r[0]) | (r[1] != r[1]) | (r[2] != r[2]) | (r[3] != r[3]);
        }
        for (int b = full * DEPTH_CELL; b < d->blocks_x; b++) {
            out[full] = row[b] < out[full] ? row[b] : out[full];
            nan |= row[b] != row[b];
        }
        if (nan) /* rare: the cells of this row with a NaN block are NaN (and stay so) */
            for (int b = 0; b < d->blocks_x; b++)
                if (row[b] != row[b]) out[b / DEPTH_CELL] = row[b];
    }
}

/* 1 when the screen box lo, hi widened by 2 px (the ribbons reach 1 px from their curve points)
 * at least W w0 is hidden by the depth drawn (crisp__occl_hidden), or holds no sample of the
 * window. */
static int rect_hidden(const double lo_in[2], const double hi_in[2], double w0, const int win[4],
                       const depth_drawn *d)
{
    double lo[2] = {lo_in[0] - 2, lo_in[1] - 2}, hi[2] = {hi_in[0] + 2, hi_in[1] + 2};
    if (hi[0] < win[0] || hi[1] < win[1] || lo[0] > win[0] + win[2] || lo[1] > win[1] + win[3])
        return 1; /* no sample of the window */
    crisp_occl_leaf o;
    crisp__occl_set(&o, win, lo, hi, 1.0 / w0);
    return depth_hides(&o, d);
}

/* 1 when ribbon quad v can write no sample in the final draw: every corner behind the eye
 * (build_quads' quads at a break of the ribbon), or every corner in front of it and its
 * corners' screen box, at their largest 1/W, outside the window or hidden by the depth drawn d
 * (the quad's fragments, and its core's, lie in that box and are no nearer than its corners:
 * crisp__raster_quad_hidden's test at the earlier stages' depth, which the final depth only
 * makes nearer). */
static int quad_unseen(const crisp_plan_ribbon_vertex *v, int width, int height, const int win[4],
                       const depth_drawn *d)
{
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY}, iw = 0;
    int behind = 0;
    for (int k = 0; k < 4; k++) {
        const double *c = v[k].clip;
        if (c[3] < 0) {
            behind++;
            continue;
        }
        if (!(c[3] > 0) || !isfinite(c[0] + c[1] + c[3])) return 0;
        double px[2];
        crisp__clip_px(c, width, height, px);
        lo[0] = lesser(lo[0], px[0]), hi[0] = greater(hi[0], px[0]);
        lo[1] = lesser(lo[1], px[1]), hi[1] = greater(hi[1], px[1]);
        iw = greater(iw, 1 / c[3]);
    }
    if (behind) return behind == 4;
    if (hi[0] + 1 < win[0] || hi[1] + 1 < win[1] || lo[0] - 1 > win[0] + win[2] ||
        lo[1] - 1 > win[1] + win[3])
        return 1; /* no sample of the window */
    crisp_occl_leaf o;
    crisp__occl_set(&o, win, lo, hi, iw);
    return depth_hides(&o, d);
}

int crisp__stages_quad_unseen(const crisp_plan_ribbon_vertex v[4], int width, int height,
                              const int win[4], const double *hiz)
{
    depth_drawn d = depth_of(hiz, win, NULL);
    return quad_unseen(v, width, height, win, &d);
}

/* 1 when every sample that face f's surface or ribbons could reach holds a nearer depth in hiz:
 * each of its patches' boxes (which hold the surface and so the curve points of its ribbons) is
 * outside the widened frustum, or in front of the eye with its screen box widened by 2 px (the
 * ribbons reach 1 px from their curve points) hidden (crisp__occl_hidden at the box's least W). */
static int face_hidden(const crisp_planner *p, const crisp_scene *sc, uint32_t f, crisp_mat4 m,
                       int width, int height, const int win[4], const depth_drawn *d)
{
    const crisp__stages *s = &p->stages;
    const crisp_scene_face *sf = &sc->faces[f];
    double gx = 1 + 4.0 / width, gy = 1 + 4.0 / height;
    /* A face within FACE_SMALL_PX (patch_groups.c) on screen is drawn untrimmed: all patches. */
    double flo[2], fhi[2], fw0, fw1;
    int all = !box_screen(s->face_box + 6 * (size_t)f, m, width, height, flo, fhi, &fw0, &fw1) ||
              (fhi[0] - flo[0] <= 2 && fhi[1] - flo[1] <= 2);
    for (uint32_t q = sf->first_patch; q < sf->first_patch + sf->patch_count; q++) {
        if (!all && !s->patch_in[q]) continue; /* trimmed away whole */
        const double *box = sc->patches[q].box;
        double lo[2], hi[2], w0, w1;
        int front = box_screen(box, m, width, height, lo, hi, &w0, &w1);
        if (!front) {
            /* Behind the eye in part: hidden only when wholly outside one side plane. */
            int out[4] = {1, 1, 1, 1};
            for (int k = 0; k < 8; k++) {
                double c[3] = {box[(k & 1) ? 3 : 0], box[(k & 2) ? 4 : 1], box[(k & 4) ? 5 : 2]};
                double x = m[0][0] * c[0] + m[1][0] * c[1] + m[2][0] * c[2] + m[3][0];
                double y = m[0][1] * c[0] + m[1][1] * c[1] + m[2][1] * c[2] + m[3][1];
                double w = m[0][3] * c[0] + m[1][3] * c[1] + m[2][3] * c[2] + m[3][3];
                out[0] &= x > gx * w, out[1] &= x < -gx * w;
                out[2] &= y > gy * w, out[3] &= y < -gy * w;
            }
            if (out[0] | out[1] | out[2] | out[3]) continue;
            return 0;
        }
        if (!rect_hidden(lo, hi, w0, win, d) &&
            !patch_hidden(&sc->patches[q].bez, m, width, height, win, d))
            return 0;
    }
    return 1;
}

/* The pieces (crisp__ribbons_set_hidden) of net n's parameter rectangle whose hulls, or the
 * hulls of their halvings, rect_hidden finds hidden, as a mask (net_hidden's halvings, all of
 * them: the 2^HULL_SPLITS pieces are a CRISP__RIBBON_PIECES square grid, u halved on even levels,
 * v on odd ones). level: the halvings done; the net covers cells [c0, c0 + nc) x [r0, r0 + nr);
 * scratch as net_hidden's. */
_Static_assert(1 << HULL_SPLITS == CRISP__RIBBON_PIECES * CRISP__RIBBON_PIECES,
               "a patch's pieces are its hull pieces of HULL_SPLITS halvings");
static uint32_t net_pieces(const hull_net *n, int width, int height, const int win[4],
                           const depth_drawn *d, int level, int c0, int r0, int nc, int nr,
                           double (*scratch)[4])
{
    double lo[2], hi[2], w0;
    if (!hull_screen(n, width, height, lo, hi, &w0)) return 0;
    if (rect_hidden(lo, hi, w0, win, d)) {
        uint32_t row = ((1u << nc) - 1) << c0, m = 0;
        for (int r = r0; r < r0 + nr; r++)
            m |= row << (CRISP__RIBBON_PIECES * r);
        return m;
    }
    if (level == HULL_SPLITS) return 0;
    int np = n->nu * n->nv, u = !(level & 1);
    hull_net h[2] = {{0, 0, scratch}, {0, 0, scratch + np}};
    hull_split(n, level & 1, &h[0], &h[1]);
    int hc = u ? nc / 2 : nc, hr = u ? nr : nr / 2;
    return net_pieces(&h[0], width, height, win, d, level + 1, c0, r0, hc, hr, scratch + 2 * np) |
           net_pieces(&h[1], width, height, win, d, level + 1, u ? c0 + hc : c0, u ? r0 : r0 + hr,
                      hc, hr, scratch + 2 * np);
}

/* crisp__stages_patch_pieces against the depth drawn d. */
static uint32_t patch_pieces(const crisp_bezier_patch *z, const double box[6], crisp_mat4 m,
                             int width, int height, const int win[4], const depth_drawn *d)
{
    const uint32_t all = (1u << (CRISP__RIBBON_PIECES * CRISP__RIBBON_PIECES)) - 1;
    double lo[2], hi[2], w0, w1;
    if (box_screen(box, m, width, height, lo, hi, &w0, &w1) && rect_hidden(lo, hi, w0, win, d))
        return all;
    hull_net n;
    double room[HULL_ROOM * HULL_SMALL][4];
    double(*p)[4] = hull_project(z, m, &n, room);
    if (!p) return 0;
    uint32_t mask = net_pieces(&n, width, height, win, d, 0, 0, 0, CRISP__RIBBON_PIECES,
                               CRISP__RIBBON_PIECES, p + n.nu * n.nv);
    if (p != room) free(p);
    return mask;
}

/* The depth drawn of the window win: hiz and its coarse level in coarse (room for depth_cells'
 * cells; NULL: none). */
static depth_drawn depth_of(const double *hiz, const int win[4], double *coarse)
{
    depth_drawn d = {hiz, (win[2] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK,
                     (win[3] + CRISP_OCCL_BLOCK - 1) / CRISP_OCCL_BLOCK, NULL, 0};
    d.cells_x = (d.blocks_x + DEPTH_CELL - 1) / DEPTH_CELL;
    if (coarse) {
        depth_cells(&d, coarse);
        d.coarse = coarse;
    }
    return d;
}

/* The cells of the coarse level of the window win's depth (depth_of's sizes). */
static size_t depth_cell_count(const int win[4])
{
    depth_drawn d = depth_of(NULL, win, NULL);
    return (size_t)d.cells_x * (size_t)((d.blocks_y + DEPTH_CELL - 1) / DEPTH_CELL);
}

uint32_t crisp__stages_patch_pieces(const crisp_bezier_patch *z, const double box[6], crisp_mat4 m,
                                    int width, int height, const int win[4], const double *hiz)
{
    double *coarse = malloc(depth_cell_count(win) * sizeof *coarse);
    depth_drawn d = depth_of(hiz, win, coarse); /* without memory: no coarse level */
    uint32_t mask = patch_pieces(z, box, m, width, height, win, &d);
    free(coarse);
    return mask;
}

/* The ribbons' hidden test of a later stage (crisp__ribbons_set_hidden): patch_pieces against the
 * depth drawn by the earlier stages, computed when first asked and kept for the stage (a patch's
 * mask in bits 0-15, bit 16 set once it is known). Sound for the final draw: the depth stored at
 * a sample only gets nearer (the surfaces' and splats' depth tests, the fill pass's slack test
 * and its cores' take only nearer fragments), so a ribbon fragment of a hidden piece, no nearer
 * than its curve points (a quad's 1/W and its core's lie between its two curve points'), is
 * refused wherever it lands, as the draw's own ribbon cull would find. */
typedef struct pieces_ctx {
    const crisp_scene *sc;
    crisp_mat4 m;
    int width, height;
    const int *win;
    const depth_drawn *d;
    _Atomic uint32_t *mask; /* per scene patch */
} pieces_ctx;

static uint32_t later_pieces(const void *vctx, uint32_t q)
{
    const pieces_ctx *c = vctx;
    uint32_t m = atomic_load_explicit(&c->mask[q], memory_order_relaxed);
    if (!m) {
        /* Two workers may compute the same mask: both store the same value. */
        crisp_mat4 vp;
        memcpy(vp, c->m, sizeof vp);
        const crisp_scene_patch *z = &c->sc->patches[q];
        m = 1u << 16 | patch_pieces(&z->bez, z->box, vp, c->width, c->height, c->win, c->d);
        atomic_store_explicit(&c->mask[q], m, memory_order_relaxed);
    }
    return m & 0xffffu;
}

typedef struct hidden_ctx {
    const crisp_planner *p;
    const crisp_scene *sc;
    const depth_drawn *d;
    const int *win;
    uint8_t *hidden; /* per face: face_hidden, for the later stages' faces not yet hidden */
} hidden_ctx;

static void faces_hidden(void *vctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const hidden_ctx *c = vctx;
    const crisp__stages *s = &c->p->stages;
    const crisp_camera *cam = &c->p->cam;
    for (size_t f = begin; f < end; f++)
        c->hidden[f] = s->stage[f] > s->stage_at && s->stage[f] != STAGE_HIDDEN &&
                       face_hidden(c->p, c->sc, (uint32_t)f, c->p->trees->view_proj, cam->width,
                                   cam->height, c->win, c->d);
}

crisp_status crisp__planner_plan_next(crisp_planner *p, const crisp_scene *sc, const double *hiz,
                                      const int win[4], const crisp_frame_plan **dest, int *last)
{
    crisp__stages *s = &p->stages;
    if (p->staged != 2 || p->scene != sc)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "planning a later stage: plan the first stage of this scene first");
    crisp_status st;
    const crisp_camera *cam = &p->cam;
    crisp_frame_plan *o = &p->out;
    uint32_t n = sc->face_count;
    /* The later stages' faces that the depth drawn hides get nothing (tested in parallel into
     * skip, which plan_stage sets afresh). */
    int next = STAGES;
    depth_drawn d = {0};
    if (hiz) {
        if ((st = crisp_grow((void **)&s->depth_cells, &s->depth_cells_cap, depth_cell_count(win),
                             sizeof *s->depth_cells)))
            return st;
        d = depth_of(hiz, win, s->depth_cells);
        hidden_ctx hc = {p, sc, &d, win, s->skip};
        crisp_pool_parallel_for(p->pool, n, 4, faces_hidden, &hc);
    }
    for (uint32_t f = 0; f < n; f++) {
        if (s->stage[f] <= s->stage_at || s->stage[f] == STAGE_HIDDEN) continue;
        if (hiz && s->skip[f]) {
            s->stage[f] = STAGE_HIDDEN;
            s->hidden++;
        } else if (s->stage[f] < next) {
            next = s->stage[f];
        }
    }
    /* The next stage with faces left, planned; the last one's faces drawn over the final plan. */
    int more = 0;
    for (uint32_t f = 0; f < n; f++) {
        s->later[f] = s->stage[f] == next;
        more |= s->stage[f] > next && s->stage[f] != STAGE_HIDDEN;
    }
    s->stage_at = next;
    if (next < STAGES) {
        /* The ribbons of the stage's faces left out where the depth drawn hides them. */
        pieces_ctx pc = {.sc = sc, .width = cam->width, .height = cam->height, .win = win, .d = &d};
        memcpy(pc.m, p->trees->view_proj, sizeof pc.m);
        if (hiz) {
            if ((st = crisp_grow((void **)&s->piece_mask, &s->piece_mask_cap,
                                 sc->patch_count ? sc->patch_count : 1, sizeof *s->piece_mask)))
                return st;
            memset((void *)s->piece_mask, 0, sc->patch_count * sizeof *s->piece_mask);
            pc.mask = s->piece_mask;
            crisp__ribbons_set_hidden(p->ribbons, later_pieces, &pc);
        }
        st = plan_stage(p, sc, cam, hiz ? &d : NULL, win);
        crisp__ribbons_set_hidden(p->ribbons, NULL, NULL);
        if (st) return st;
    }
    *last = !more;
    *dest = o;
    if (more) return CRISP_OK;
    /* The final plan: every stage's leaves, levels and ribbons, face after face. */
    size_t nf = n ? n : 1;
    for (uint32_t f = 0; f < n; f++) {
        p->trees->face_tau[f] = s->kept[5 * (size_t)f + 4];
        p->trees->face_rows[f] = s->kept_rows[f];
        s->skip[f] = 1;
    }
    if ((st = crisp_grow((void **)&p->ribbon_verts, &p->ribbon_cap,
                         4 * (s->kept_quads ? s->kept_quads : 1), sizeof *p->ribbon_verts)))
        return st;
    size_t at = 0;
    for (uint32_t f = 0; f < n; f++) {
        const uint32_t *k = s->kept + 5 * (size_t)f;
        if (k[3])
            memcpy(p->ribbon_verts + 4 * at, s->kept_ribbons + 4 * (size_t)k[2],
                   4 * (size_t)k[3] * sizeof *p->ribbon_verts);
        p->ribbon_first[f] = (uint32_t)at;
        p->ribbon_quads[f] = k[3];
        at += k[3];
    }
    (void)nf;
    o->ribbon_quad_count = (uint32_t)at;
    o->stats = s->kept_stats;
    o->stats.hidden_faces = s->hidden;
    /* Whether they paid: at least STAGE_PAYS_MIN hidden faces' patches, and STAGE_PAYS of those
     * and the patches planned with visible leaves. */
    uint64_t hidden_patches = 0;
    for (uint32_t f = 0; f < n; f++)
        if (s->stage[f] == STAGE_HIDDEN) hidden_patches += sc->faces[f].patch_count;
    s->pays = hidden_patches >= STAGE_PAYS_MIN &&
              (double)hidden_patches >=
                  STAGE_PAYS * (double)(hidden_patches + s->kept_stats.visible_patches);
    s->pays_serial = sc->serial;
    s->quiet = 0;
    if ((st = crisp__planner_finish_plan(p, sc, cam, s->skip))) return st;
    p->staged = 1;
    return CRISP_OK;
}

crisp_status crisp__planner_seen(crisp_planner *p, const crisp_scene *sc, const int32_t *face,
                                 size_t count)
{
    crisp__stages *s = &p->stages;
    crisp_status st =
        crisp_grow((void **)&s->seen, &s->seen_cap, sc->face_count ? sc->face_count : 1, 1);
    if (st) return st;
    memset(s->seen, 0, sc->face_count);
    for (size_t i = 0; i < count; i++)
        if (face[i] >= 0 && (uint32_t)face[i] < sc->face_count) s->seen[face[i]] = 1;
    s->seen_serial = sc->serial;
    return CRISP_OK;
}

void crisp__planner_always_stages(crisp_planner *p, int on)
{
    crisp__stages *s = &p->stages;
    s->always = on;
}

int crisp__planner_seen_wanted(const crisp_planner *p, const crisp_scene *sc)
{
    const crisp__stages *s = &p->stages;
    return s->always || s->pays_serial != sc->serial || s->pays ||
           (s->quiet + 1) % STAGE_PROBE == 0;
}

void crisp__stages_free(crisp__stages *s)
{
    free(s->stage);
    free(s->later);
    free(s->skip);
    free(s->kept_leaves);
    free(s->kept_ribbons);
    free(s->kept);
    free(s->kept_rows);
    free(s->seen);
    free(s->face_box);
    free(s->patch_in);
    free((void *)s->piece_mask);
    free(s->depth_cells);
}
