/* Trim-boundary ribbons of the frame plan (ribbon.c). */
#ifndef CRISP_RENDER_RIBBON_H
#define CRISP_RENDER_RIBBON_H

#include <math.h>

#include "crisp/plan.h"
#include "quadtree.h"

typedef struct crisp__ribbons crisp__ribbons; /* sampling scratch, reused from frame to frame */

crisp_status crisp__ribbons_create(int workers, crisp__ribbons **dest);
void crisp__ribbons_destroy(crisp__ribbons *rb);

/* The ribbon quads of every visible face (only_face = UINT32_MAX) or of one face, laid out face
 * after face into *verts (4 vertices per quad; grown as needed, capacity *cap). face_first and
 * face_quads receive, per face of the range (indexed from its first face), the face's first quad
 * and quad count; *quad_count the total. */
/* A ribbon fragment is drawn over a surface sample only when nearer by more than the sample's
 * depth slack: CRISP__RIBBON_SLACK times the surface's largest depth change to a neighbouring
 * pixel (crisp__raster_depth_slack_tris). The surface's tessellation lies within 0.5 px of it on
 * screen, and the ribbon's depth is that of its curve point, up to 0.7 px across and 0.7 px
 * along (0.99 px) from the fragment: a ribbon hidden under a surface by less than 1.5 px of the
 * surface's depth change could otherwise show through it. Each quad's core, the part within
 * CRISP__RIBBON_CORE_PX across its centre line and between its two curve points, takes the
 * smaller slack CRISP__RIBBON_CORE_SLACK (0.5 px, its 0.35 px reach and the 0.1 px a piece's
 * middle may lie off its chord) at the core's own depth (the curve points' 1/W, affine between
 * them): a fragment there that the quad's slack refuses is tested again so, in the same fill pass
 * (the CPU backend's ribbon_core and crisp__raster_draw_fill2, the GL ribbon shaders). A pixel
 * whose face was trimmed a little inside its true boundary, with a steep face behind, is filled
 * there (occt_linkrods.step, test_cracks' test_linkrods_steep_behind). */
#define CRISP__RIBBON_SLACK 1.5
#define CRISP__RIBBON_CORE_PX 0.35
#define CRISP__RIBBON_CORE_SLACK 0.95

/* A patch's pieces (crisp__ribbons_set_hidden): its parameter rectangle cut into
 * CRISP__RIBBON_PIECES equal parts in s and in t; the piece in column i (along s) and row j
 * (along t) is bit CRISP__RIBBON_PIECES j + i of a mask. */
#define CRISP__RIBBON_PIECES 4
typedef uint32_t (*crisp__ribbon_pieces_fn)(const void *ctx, uint32_t patch);

/* hypot(x, y) > c for a positive finite c (above 1e-150: c^2 normal), mostly without hypot: x x + y
 * y rounds by under 3 2^-53 of itself, and glibc's hypot is within an ulp (2^-52 relative) of the
 * true length, so a square more than 2^-40 of c^2 from c^2 decides it as hypot would; an
 * overflowing square (infinite) means a length above c as well (hypot is then at least |x| or |y|,
 * above 1e154); NaN or the narrow band around c^2 asks hypot itself. The same answer bit for bit as
 * hypot(x, y) > c (tests/render/test_plan.c, test_ribbon_length_compare). */
static inline int crisp__ribbon_length_above(double x, double y, double c)
{
    double s2 = x * x + y * y, c2 = c * c;
    if (s2 > c2 * (1 + 0x1p-40)) return 1;
    if (s2 < c2 * (1 - 0x1p-40)) return 0;
    return hypot(x, y) > c;
}

/* While fn is set (NULL: off), a build leaves out the ribbon along a segment of a face's trim
 * polyline (or domain edge) whose (u, v) box lies in pieces of the face's patch grid that
 * fn(ctx, patch) (the scene's patch index; callable from several threads) marks hidden: pieces
 * where no sample the ribbons of its surface points can reach would take their fragments (the
 * later stages' depth, stages.c). Such a segment, or such a part of one that the sampling
 * splits, gets no samples: the ribbon breaks there, as off screen. */
void crisp__ribbons_set_hidden(crisp__ribbons *rb, crisp__ribbon_pieces_fn fn, const void *ctx);

crisp_status crisp__ribbons_build(crisp__ribbons *rb, const crisp__trees *trees,
                                  const crisp_scene *sc, uint32_t only_face, crisp_pool *pool,
                                  crisp_plan_ribbon_vertex **verts, size_t *cap,
                                  uint32_t *face_first, uint32_t *face_quads, uint32_t *quad_count);

#endif
