/* The planner's splat store (issue 12, splat_store.c): per face, splat sets at radii
 * s_k = s_0 2^(-k/2) built lazily (crisp__splat_build) and kept across frames, and the per-frame
 * choice of the faces drawn as splats (docs/status/issue-12-splats.md, "Planner and CPU draw").
 *
 * Offers:
 *   crisp__splat_store_create / _destroy
 *   crisp__splat_store_choose   which faces this frame draws as splats, at which level
 *   crisp__splat_store_publish  the plan's splat arrays for the faces chosen
 *   crisp__splat_store_drop_face forget one face's sets (its trim changed)
 *   crisp__splat_thin           a builder's set at radius r thinned to fewer splats, radius r */
#ifndef CRISP_RENDER_SPLAT_STORE_H
#define CRISP_RENDER_SPLAT_STORE_H

#include <stdint.h>

#include "crisp/plan.h"
#include "crisp/render.h"
#include "splat.h"

/* Levels per face: s_0 2^(-k / 2) for k < CRISP_SPLAT_LEVELS (steps of 2^-1/2 in the radius, so
 * the level chosen for a frame holds at most about 2x the splats that the exact radius needs, not
 * 4x as with halvings). */
#define CRISP_SPLAT_LEVELS 40

/* The splat budget of a face of P patches: min(A P + B, C) splats (a set above it is not built,
 * the face is planned as patches). A = 16, B = 64 in session 9; 64 and 256 since the record is
 * 24 bytes and the draw culls (bench/RESULTS.md, issue 12, session 11, splat2). */
#ifndef CRISP_SPLAT_PER_PATCH
#define CRISP_SPLAT_PER_PATCH 64
#endif
#ifndef CRISP_SPLAT_PER_FACE
#define CRISP_SPLAT_PER_FACE 256
#endif
/* ... and never more than this per face: splats are for faces a few pixels across. gen100
 * default (20 faces of 10,000 patches about a pixel each) would otherwise draw 3.3 M splats for
 * 310 k pixels (the frame 4x slower). */
#ifndef CRISP_SPLAT_MAX_FACE
#define CRISP_SPLAT_MAX_FACE 32768
#endif
/* A splat's half-size on screen (pixels) and the margin kept below it for the set's radius. */
#define CRISP_SPLAT_HALF_PX 0.5
/* The margin is for the float arithmetic of the splats' clip positions (about 1e-3 px at 1080p,
 * relative 5e-7 of the image's size); 0.1 in session 9, 0.05 now: (0.4 / 0.45)^2 = 0.79x the
 * splats. */
#define CRISP_SPLAT_MARGIN_PX 0.05

typedef struct crisp__splat_store crisp__splat_store;

crisp_status crisp__splat_store_create(crisp__splat_store **dest);
void crisp__splat_store_destroy(crisp__splat_store *s);

/* The faces of sc drawn as splats for view_proj at width x height: splat[f] = 1 for those,
 * 0 for the others (planned as patches as before). A face is drawn so when its box (the union of
 * its patches' boxes) lies wholly between the near and far planes and meets the frustum, and
 * its set at the coarsest level whose radius, projected at the box's nearest point, is at most
 * CRISP_SPLAT_HALF_PX - CRISP_SPLAT_MARGIN_PX pixels, holds at most the face's budget of splats
 * (built now when it is not yet). build_limit > 0: the sets not built yet are built in chunks
 * of faces until about that many splats were made this frame (the chunk that passes it is
 * finished); the faces left are planned as patches this frame (splat[f] = 0) and counted as
 * pending (crisp_plan_stats.splat_pending); later frames build them. 0: every set now. pool may
 * be NULL. */
crisp_status crisp__splat_store_choose(crisp__splat_store *s, const crisp_scene *sc,
                                       crisp_mat4 view_proj, int width, int height,
                                       uint64_t build_limit, crisp_pool *pool, uint8_t *splat);

/* Fill the plan's splat fields (splats, ranges, clip origins, half size, splats_version and the
 * splat stats, the last choose's pending faces included) for the faces with splat[f] != 0 (a subset
 * of the last choose's; all 0: none) and flag their records (faces: the plan's, sc->face_count of
 * them; NULL: the caller flags them) with CRISP_PLAN_FACE_SPLATS. */
crisp_status crisp__splat_store_publish(crisp__splat_store *s, const crisp_scene *sc,
                                        const uint8_t *splat, crisp_plan_face *faces,
                                        crisp_frame_plan *out);

/* Thin sp[0 .. n - 1], a builder's set of radius at most `radius` with each splat's own rho
 * (splat.h), to a subset that covers the face within `radius`: a splat is dropped when a kept one
 * lies within radius - rho of it. The kept splats are moved to the front in their order; returns
 * their count (n when there is no memory). */
uint32_t crisp__splat_thin(crisp_splat *sp, uint32_t n, double radius);

/* Forget face f's sets (they are rebuilt when next needed). */
void crisp__splat_store_drop_face(crisp__splat_store *s, uint32_t f);

/* Test hooks (tests/render/test_splats.c). The last choice's faces decided by the faces' tree
 * (dest[0]: culled with their group, dest[1]: their level from their group's bound) and one by one
 * (dest[2]). */
void crisp__splat_store_choice_counts(const crisp__splat_store *s, uint64_t dest[3]);
/* The level each face of sc wants for view_proj with the store's sets as they are (-1: planned as
 * patches; nothing is built) and its box's least W (where want >= 0), chosen through the faces'
 * tree (grouped = 1, as crisp__splat_store_choose does) or face by face (0). */
crisp_status crisp__splat_store_test_want(crisp__splat_store *s, const crisp_scene *sc,
                                          crisp_mat4 view_proj, int width, int height, int grouped,
                                          int8_t *want, double *near);
/* The choice takes four faces at a time with AVX2 (1; where the CPU has it) or one at a time (0);
 * -1: not known yet (set on the first choice). Tests set it to compare the two. */
extern int crisp__splat_choice_lanes;
/* Faces the four-lane path took since the program started (tests: that it ran). */
extern unsigned long long crisp__splat_lane_faces;

#endif
