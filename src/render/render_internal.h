/* Internal helpers shared by the render module's backends. */
#ifndef CRISP_RENDER_INTERNAL_H
#define CRISP_RENDER_INTERNAL_H

#include <math.h>

#include "crisp/render.h"

/* Headlight shading: base colour times (ambient + diffuse |n . v|), two-sided; writes RGBA with
 * alpha 1. n and view (from the eye to the point) need not be unit. */
void crisp__shade(const float base[4], const double n[3], const double view[3], float rgba[4]);
/* crisp__shade's arithmetic (shade.c calls it), inline for the CPU backend's per-pixel resolve. */
static inline void crisp__shade_inline(const float base[4], const double n[3], const double view[3],
                                       float rgba[4])
{
    double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    double vv = sqrt(view[0] * view[0] + view[1] * view[1] + view[2] * view[2]);
    double c =
        nn > 0 && vv > 0 ? fabs(n[0] * view[0] + n[1] * view[1] + n[2] * view[2]) / (nn * vv) : 1;
    double k = 0.25 + 0.75 * c;
    for (int i = 0; i < 3; i++)
        rgba[i] = (float)(base[i] * k);
    rgba[3] = 1.0f;
}

/* Background everywhere: rgba, normal, uv 0, depth +inf, face -1. Both backends start a frame
 * with it, so an image can be rendered into again (they write covered pixels only). */
void crisp__image_clear(crisp_image *img);

/* Camera-space depth of a world point (distance along the view axis). */
double crisp__view_depth(const crisp_camera *cam, const double p[3]);

/* 1 when the normal n = a x b of partials a, b is not to be trusted: one partial is within
 * CRISP_NORMAL_TAU of vanishing next to the other (an apex, a pole, a collapsed side: rounding
 * leaves |a| ~ 1e-16 |b|, a file's rounding of the apex points 1e-9..1e-6, and the cross product
 * points anywhere) or the partials are that close to parallel. Then the backends take the limit
 * normal from inside the patch (crisp_bezier_patch_normal, crisp_surface_normal; the GL
 * backend's patch_normal in shaders/common.glsl tests the same). */
static inline int crisp__normal_degenerate(const double a[3], const double b[3], const double n[3])
{
    double aa = a[0] * a[0] + a[1] * a[1] + a[2] * a[2],
           bb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
    double nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2], t2 = CRISP_NORMAL_TAU * CRISP_NORMAL_TAU;
    return !(aa > t2 * bb) || !(bb > t2 * aa) || !(nn > t2 * aa * bb);
}

/* The pixel position p (x right, y down) of the clip-space point c (x, y, z, W) in a width x
 * height image (an int size converts exactly, so int and double callers get the same bits).
 * Not crisp_camera_to_pixel: that multiplies by 1 / W, which rounds otherwise than the division
 * here, and the backends' pixel boxes and culls must keep their bits. */
static inline void crisp__clip_px(const double c[4], double width, double height, double p[2])
{
    p[0] = (c[0] / c[3] + 1) * 0.5 * width;
    p[1] = (1 - c[1] / c[3]) * 0.5 * height;
}

/* Doubles in the largest patch's control net. */
#define CRISP__PATCH_DOUBLES ((CRISP_MAX_DEGREE + 1) * (CRISP_MAX_DEGREE + 1) * 4)

/* The sub-patch [s0, s1] x [t0, t1] (local parameters) of p, its control points in storage
 * (2 * CRISP__PATCH_DOUBLES; tmp, CRISP__PATCH_DOUBLES, is not written); dest->cpw = storage. The
 * same bits as cutting p with crisp_bezier_patch_split_u/_v at s0, then at (s1 - s0) / (1 - s0)
 * of the rest, then likewise in v. */
void crisp__subpatch(const crisp_bezier_patch *p, double s0, double s1, double t0, double t1,
                     double *storage, double *tmp, crisp_bezier_patch *dest);

/* The CPU backend's trim test for a box of (u, v) of a face (cpu.c): 1 when
 * crisp_plan_trim_test keeps every point of [lo, hi], 0 when it discards every one, -1 when
 * mixed or not decided. */
int crisp__plan_trim_box(const struct crisp_frame_plan *plan, uint32_t face, const double lo[2],
                         const double hi[2]);

/* crisp__plan_trim_box with a memory of the row ranges it decided (cpu.c): the same answers
 * where that gives 0 or 1, and 0 or 1 (still exact: the point test's answer on all of the box)
 * for boxes inside a decided range of one strip's rows and one gap between crossings. One cache
 * per thread; entries count only while their generation is the cache's (set it to a new value
 * for each plan drawn, nonzero). */
#define CRISP_TRIM_BOX_CACHE 1024
#define CRISP_TRIM_BOX_WAYS 16 /* entries per face and strip (a set; the oldest replaced) */
typedef struct crisp_trim_box_entry {
    uint64_t generation;
    double ua, ub;                 /* u in (ua, ub] */
    uint32_t face, ia, ib, ra, rb; /* strips ia .. ib, their global rows ra .. rb */
    int answer;
    uint32_t stamp; /* when it was made (the cache's count) */
} crisp_trim_box_entry;
typedef struct crisp_trim_box_cache {
    uint64_t generation;
    uint32_t stamp;
    crisp_trim_box_entry entry[CRISP_TRIM_BOX_CACHE];
} crisp_trim_box_cache;
int crisp__plan_trim_box_cached(crisp_trim_box_cache *c, const struct crisp_frame_plan *plan,
                                uint32_t face, const double lo[2], const double hi[2]);

/* The last frame's surface triangles (CPU backend; the trim ribbons follow them in the buffers
 * but are not counted), for tests that measure them. */
struct crisp_raster_vertex;
struct crisp_raster_tri;
void crisp__renderer_mesh(const crisp_renderer *r, const struct crisp_raster_vertex **verts,
                          size_t *vert_count, const struct crisp_raster_tri **tris,
                          size_t *tri_count);

/* crisp_render_cpu_plan drawing only a window of the frame (issue 15, image tiles): window = x0,
 * y0, width, height of the pixels drawn (x0, y0 multiples of 8; NULL: the whole frame), img has
 * the window's size. Every pixel of the window is computed with the same arithmetic as in the
 * whole frame, except that the ribbons' depth slack (which looks at the 4 neighbouring pixels)
 * sees no neighbour outside the window: draw a margin of at least 1 pixel and crop it. */
struct crisp_frame_plan;
crisp_status crisp__render_cpu_window(crisp_renderer *r, const crisp_scene *sc,
                                      const struct crisp_frame_plan *plan, const crisp_camera *cam,
                                      const int window[4], crisp_image *img,
                                      crisp_render_stats *stats);

/* The last frame's per-sample results (CPU backend), for tests that check every sample. */
struct crisp_raster_target;
const struct crisp_raster_target *crisp__renderer_target(const crisp_renderer *r);
/* The faces the last image drawn by crisp_render_cpu shows, as its resolve listed them for the
 * planner's next first stage (crisp__planner_seen), in face order; count 0 when the planner did
 * not want them. */
void crisp__renderer_seen(const crisp_renderer *r, const int32_t **faces, size_t *count);
/* The SIMD paths (the rasterizer's vector path and the resolve's two-pixel one) on (default)
 * or off (the scalar code, for tests that compare the two bit for bit); 2: on, but not the
 * rasterizer's AVX2 tiles (crisp__raster_set_vectors). */
void crisp__renderer_set_vectors(crisp_renderer *r, int on);
/* The fastest resolve path the renderer may take for one-sample targets (tests that compare
 * them): 0 the scalar code, 1 two pixels at a time (SSE2), 2 four (AVX), 3 eight (AVX-512);
 * -1: the fastest the processor has (the default). Returns the fastest the processor has. */
int crisp__renderer_set_resolve(crisp_renderer *r, int path);
/* Resolves the rectangle rect (x0, y0, x1, y1) of target t (the pixels of cam's image that t's
 * window holds) into img (t's size) by the given path (as crisp__renderer_set_resolve; a path
 * the processor lacks, or -1: its fastest; several samples: the scalar code), as the CPU
 * backend's draws do; with seen, the faces shown then in crisp__renderer_seen. For tests that
 * compare the paths on targets they fill. */
crisp_status crisp__renderer_resolve(crisp_renderer *r, const crisp_scene *sc,
                                     const crisp_camera *cam, const struct crisp_raster_target *t,
                                     const int rect[4], int path, int seen, crisp_image *img);

/* The trim table the planner built for face f in its last plan (for tests that hold the plan's
 * flat arrays against it). */
struct crisp_trim_table;
struct crisp_planner;
const struct crisp_trim_table *crisp__planner_table(const struct crisp_planner *p, uint32_t f);

/* The plan in stages (crisp_render_cpu, issue 12): a face that the nearer faces hide whole needs
 * no levels, trim plan or ribbons, and every other face's are what a one-stage plan gives (the
 * edge rule and the trim plans are per face), so the CPU backend plans the nearest faces, draws
 * them, plans the next ones that the depth drawn does not hide, draws them, and so on.
 * crisp__planner_plan_near: the splat choice, then the faces' stages (first the faces seen in the
 * last frame (crisp__planner_seen), then nearest first by their boxes' least W, a stage ending
 * where their screen boxes cover 1, 4, 16 images; the rest last)
 * and the first stage planned: a plan of its faces' leaves and tables to draw the surfaces from
 * (no splats, no versions: not to be handed on). Stages are tried while they hide enough (an
 * eighth of the patches), else every 16th frame. *later is NULL when there is one stage: then the
 * plan is crisp_planner_plan's, final. Else *later (per face) marks the faces of the stage
 * planned last (updated by each call below).
 * crisp__planner_plan_next: the later stages' faces none of whose patches' boxes (widened by 2 px
 * for the ribbons; only the patches that the face's trim pieces' box reaches, unless the face is
 * a few pixels across) reach a sample of window win (x0, y0, width, height of the image) that hiz
 * (crisp__raster_block_depth at CRISP_OCCL_BLOCK over the window of what was drawn so far; NULL:
 * none hidden) does not show nearer are dropped (stats.hidden_faces), and the next stage planned.
 * *last = 0: a plan of that stage's faces, drawn like the first; *last = 1: the final plan of every
 * stage (the same leaves, tables and ribbons per face as crisp_planner_plan's; hidden faces
 * invisible), published, whose faces with later[f] are still to be drawn. */
crisp_status crisp__planner_plan_near(struct crisp_planner *p, const crisp_scene *sc,
                                      const crisp_camera *cam, const struct crisp_frame_plan **dest,
                                      const uint8_t **later);
/* The faces in face[0 .. count) (the faces an image shows, as the CPU backend's resolve lists
 * them; repeats, the background's -1 and ids past the scene's faces allowed) are the first stage
 * of the next crisp__planner_plan_near of scene sc (an order only: see there). */
crisp_status crisp__planner_seen(struct crisp_planner *p, const crisp_scene *sc,
                                 const int32_t *face, size_t count);
/* 1 when the next crisp__planner_plan_near of scene sc may plan in stages (after a frame in
 * stages that hid too little, every 16th frame does): only then are crisp__planner_seen's marks
 * read. */
int crisp__planner_seen_wanted(const struct crisp_planner *p, const crisp_scene *sc);
/* Test hook: 1 = every crisp__planner_plan_near plans in stages (whether they pay or not). */
void crisp__planner_always_stages(struct crisp_planner *p, int on);
crisp_status crisp__planner_plan_next(struct crisp_planner *p, const crisp_scene *sc,
                                      const double *hiz, const int win[4],
                                      const struct crisp_frame_plan **dest, int *last);

#endif
