/* crisp render: camera and pixel conventions (docs/design.md section 6), and (to come) the scene,
 * the frame planner and the CPU backend.
 *
 * Offers:
 *   crisp_camera            eye, target, up, vertical fov, near, far, image size
 *   crisp_camera_check      validate with a message naming the bad value
 *   crisp_camera_matrices   view, projection and view-projection (gluLookAt / gluPerspective)
 *   crisp_camera_ray        the ray through a point of the image (pixel centre = (i+0.5, j+0.5))
 *   crisp_camera_frame_box  the default camera that frames a box (looking along -Z, +Y up, fov 30)
 *   crisp_camera_to_pixel   clip-space point -> pixel coordinates
 *   crisp_scene             a model prepared for rendering (Bézier patches, trim pieces, boxes)
 *   crisp_image             colour and AOVs (depth, normal, u, v, face)
 *   crisp_render_exact      the exact reference renderer (ray casting + exact trim classifier)
 *   crisp_renderer, crisp_render_cpu
 *                           the CPU backend: frame plan (SLEFE tess levels, crack-free edges,
 *                           u-intercept tables), tessellation, rasterizer with the trim test
 *   crisp_render_cpu_plan_faces
 *                           some faces of a plan only, alone or over an image of the others
 *   crisp_frep_part, crisp_render_frep_parts
 *                           f-rep parts composited into an image by depth (interval subdivision
 *                           of the view frustum, src/render/frep_part.c)
 */
#ifndef CRISP_RENDER_H
#define CRISP_RENDER_H

#include "crisp/core.h"
#include "crisp/model.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct crisp_camera {
    double eye[3], target[3], up[3];
    double fov_deg;     /* vertical field of view in degrees, in (0, 180) */
    double znear, zfar; /* 0 < znear < zfar */
    int width, height;  /* image size in pixels */
} crisp_camera;

typedef struct crisp_camera_matrices {
    crisp_mat4 view, proj, view_proj;
} crisp_camera_matrices;

crisp_status crisp_camera_check(const crisp_camera *cam);
void crisp_camera_matrices_compute(const crisp_camera *cam, crisp_camera_matrices *dest);
/* Ray through image point (x, y) in pixels, y down (a pixel centre is (i + 0.5, j + 0.5)):
 * origin = eye, dir unit length. */
void crisp_camera_ray(const crisp_camera *cam, double x, double y, double origin[3], double dir[3]);
/* Clip-space (X, Y, Z, W) with W > 0 -> pixel coordinates (x right, y down) and NDC depth. */
void crisp_camera_to_pixel(const crisp_camera *cam, const double clip[4], double dest[3]);
/* A camera looking along -Z with +Y up and a 30 degree fov that shows the whole box
 * (xmin, ymin, zmin, xmax, ymax, zmax) with a small margin; near and far enclose it. */
crisp_status crisp_camera_frame_box(const double box[6], int width, int height, crisp_camera *dest);

/* ---- scene --------------------------------------------------------------------------------- */

/* One Bézier patch of a face, with a box that contains it (SLEFE tile boxes within the control
 * hull). */
typedef struct crisp_scene_patch {
    crisp_bezier_patch bez;
    uint32_t face;
    uint32_t iu, iv; /* position in the face's grid of patches */
    double box[6];
} crisp_scene_patch;

typedef struct crisp_scene_face {
    const crisp_face *src;
    uint32_t first_patch, patch_count;
    uint32_t grid_u, grid_v; /* patches per direction (u fastest) */
    int closed_u, closed_v;  /* the surface closes on itself across its u (v) domain ends: the
                                first and last patch columns (rows) share an edge */
    double domain[4];        /* u0, u1, v0, v1 of the surface */
    uint32_t first_piece, piece_count; /* Bézier trim pieces of all loops, loop after loop
                                          (faces with the same pieces share one range) */
    uint32_t first_loop, loop_count;
    float color[4];
} crisp_scene_face;

typedef struct crisp_scene_loop {
    uint32_t first_piece, piece_count;
    int is_outer;
} crisp_scene_loop;

/* The control points of one Bézier patch in crisp_scene.control_points. std430: 48 bytes
 * (include/crisp/plan.h). */
typedef struct crisp_scene_patch_record {
    uint32_t first_cp; /* index of its first control point (4 doubles each: w x, w y, w z, w) */
    uint32_t du, dv;   /* degrees (1..15); (du + 1) (dv + 1) control points, u fastest */
    uint32_t face;
    double u0, u1, v0, v1; /* the patch's parameter box on the face's surface */
} crisp_scene_patch_record;

/* The view-independent preparation of a model: Bézier patches of every face, Bézier pieces of
 * every trim loop, boxes. Built once per model edit; the model must outlive it. */
typedef struct crisp_scene {
    const crisp_model *model;
    uint32_t face_count, patch_count, piece_count, loop_count;
    crisp_scene_face *faces;
    crisp_scene_patch *patches;
    crisp_bezier_curve *pieces;
    crisp_scene_loop *loops;
    crisp_bezier_patches *face_patches; /* one per face; their control points live in
                                           control_points */
    /* Every patch's homogeneous control points, patch after patch (each patch's bez.cpw points
     * here): the array a GPU uploads as it is, with patch_records saying where each patch's are. */
    double *control_points;
    size_t control_point_count;              /* points of 4 doubles */
    crisp_scene_patch_record *patch_records; /* patch_count */
    double box[6];
    uint64_t serial; /* unique among the scenes this process prepared: what a renderer builds from
                        a scene's patches is kept by it (a new scene may reuse an address) */
    uint64_t trim_serial; /* likewise for the trim pieces: new whenever they are rebuilt
                             (crisp_scene_update_trim) */
} crisp_scene;

crisp_status crisp_scene_prepare(const crisp_model *model, crisp_scene **dest);
void crisp_scene_destroy(crisp_scene *scene);
/* After the trim loops of face `face` of the scene's model changed (the trim-editing case), take
 * the new loops' Bézier pieces into the scene (the surface must be unchanged). Other faces keep
 * their pieces (their indices may move). Then crisp_planner_replan_face re-plans the face. */
crisp_status crisp_scene_update_trim(crisp_scene *scene, uint32_t face);

/* ---- images ------------------------------------------------------------------------------- */

typedef struct crisp_image {
    int width, height;
    float *rgba;   /* 4 per pixel, straight alpha = coverage */
    float *depth;  /* camera-space depth (distance along the view axis), +inf for background */
    float *normal; /* 3 per pixel, world space, unit; 0 for background */
    float *uv;     /* 2 per pixel, surface parameters of the face */
    int32_t *face; /* face index, -1 for background */
} crisp_image;

crisp_status crisp_image_init(crisp_image *img, int width, int height);
void crisp_image_free(crisp_image *img);

/* ---- exact reference renderer ---------------------------------------------------------------- */

/* Decides whether (u, v) of a face is inside its trim (1) or not (0); the exact renderer uses the
 * exact classifier on the true curves when this is NULL. */
typedef int (*crisp_trim_classify_fn)(void *ctx, const crisp_scene *scene, uint32_t face, double u,
                                      double v);

typedef struct crisp_exact_desc {
    int threads;                     /* 0: default */
    crisp_trim_classify_fn classify; /* NULL: every point of a face counts as inside */
    void *classify_ctx;
    /* x0, y0, width, height: img holds only this window of the camera's image (every pixel is
     * its own ray, so a window's pixels equal the whole image's); all zero: the whole image */
    int window[4];
} crisp_exact_desc;

/* The nearest surface point inside its trim along the ray (origin, unit dir) with parameter t in
 * [tmin, tmax]; returns 1 and fills the outputs (any may be NULL) when there is one. */
int crisp_exact_ray(const crisp_scene *scene, const crisp_exact_desc *desc, const double origin[3],
                    const double dir[3], double tmin, double tmax, double *t, uint32_t *face,
                    double uv[2], double normal[3]);

/* One ray per pixel centre (docs/design.md section 6); near and far bound the camera-space depth.
 */
crisp_status crisp_render_exact(const crisp_scene *scene, const crisp_camera *cam,
                                const crisp_exact_desc *desc, crisp_image *img);

/* ---- CPU backend ----------------------------------------------------------------------------- */

typedef struct crisp_render_desc {
    int samples;          /* per pixel: 1 (default), 4 or 16 */
    int threads;          /* 0: default */
    double eps_px;        /* tessellation tolerance in pixels; 0: 0.5 */
    int strip_count;      /* trim strips per face (n_V); 0: from the face's tess level */
    double clip_plane[4]; /* a, b, c, d: fragments where a x + b y + c z + d < 0 (world space)
                             are discarded (a section view); all 0: none */
    int no_occlusion;     /* 1: tessellate and draw every leaf on screen (occlusion culling off:
                             the same image, for tests and measurements) */
    int no_splats;        /* 1: no face is drawn as splats (crisp_planner_desc.no_splats) */
    uint64_t splat_build_limit; /* splats built per frame (crisp_planner_desc.splat_build_limit;
                                   0: no limit) */
} crisp_render_desc;

typedef struct crisp_render_stats {
    uint32_t patches, visible_patches, split_patches, leaves, visible_faces, unresolved;
    uint64_t vertices, triangles, ribbon_triangles, table_rows, table_bytes;
    uint64_t fragments_tested, fragments_trimmed;
    uint64_t occluded_leaves, occluded_triangles; /* not tessellated: hidden by drawn depth */
    uint32_t hidden_faces; /* not planned: hidden whole by the nearer faces drawn first
                              (crisp_render_cpu with occlusion culling; 0 otherwise) */
    uint32_t splat_faces;  /* faces drawn as splats (issue 12), less those hidden whole */
    uint64_t splats;       /* splats of the faces drawn as splats (some may be hidden) */
    double ms_levels, ms_edges, ms_trim, ms_tess, ms_raster, ms_resolve;
} crisp_render_stats;

/* Buffers and threads reused from frame to frame. */
typedef struct crisp_renderer crisp_renderer;

crisp_status crisp_renderer_create(const crisp_render_desc *desc, crisp_renderer **dest);
void crisp_renderer_destroy(crisp_renderer *r);
/* Plan the frame only (the per-frame work of the trim-editing demo); stats may be NULL. */
crisp_status crisp_renderer_plan(crisp_renderer *r, const crisp_scene *scene,
                                 const crisp_camera *cam, crisp_render_stats *stats);
/* Plan, tessellate, rasterise with the per-sample trim test, shade. img must match the camera's
 * size. stats may be NULL. With occlusion culling (the default) the frame is planned in two
 * stages: the nearest faces are planned and drawn first, and the other faces that their depth
 * hides whole are not planned at all (stats->hidden_faces); the image is the one
 * crisp_planner_plan + crisp_render_cpu_plan draw. The plan drawn (the final plan of the stages:
 * the hidden faces left out) is crisp_planner_last_plan(crisp_renderer_planner(r)) afterwards. */
crisp_status crisp_render_cpu(crisp_renderer *r, const crisp_scene *scene, const crisp_camera *cam,
                              crisp_image *img, crisp_render_stats *stats);

/* The CPU backend on a given plan (include/crisp/plan.h) of this scene for this camera (the
 * camera gives the shading's view directions; its size must be the plan's): tessellate the
 * plan's leaves, rasterise with the plan's trim tables, draw its ribbons, shade. */
typedef struct crisp_frame_plan crisp_frame_plan;
typedef struct crisp_planner crisp_planner;
crisp_status crisp_render_cpu_plan(crisp_renderer *r, const crisp_scene *scene,
                                   const crisp_frame_plan *plan, const crisp_camera *cam,
                                   crisp_image *img, crisp_render_stats *stats);
/* Change the renderer's clip plane (crisp_render_desc.clip_plane; NULL or all 0: none) for the
 * next frames. */
void crisp_renderer_set_clip_plane(crisp_renderer *r, const double plane[4]);
/* Only some faces of a plan (faces[f] != 0 for the scene's face f). base NULL: as
 * crisp_render_cpu_plan with the other faces left out (faces NULL: every face). With base, a
 * render of the plan's other faces for the same camera (colour, depth, normal, u, v, face: what
 * this call with the complement of faces and no base wrote): the faces are drawn over it with
 * the depth test against its depth, and only their region of img is written (their leaves' and
 * ribbons' screen boxes widened by 2 px: base's pixels where they do not win, theirs where they
 * do; the previous call's region goes back to base where it is left); the rest of img is left as
 * it is, so it must hold base's pixels there (a copy of base made once). That is the trim-editing
 * demo's frame: while one face is edited the others do not change, so they are drawn once. Its
 * pixels equal those of crisp_render_cpu_plan of the whole plan away from the drawn faces' edges
 * (there the depth of base is compared in float, and the ribbons of faces on either side of an edge
 * are drawn in another order). With base the renderer must draw 1 sample per pixel (the image holds
 * one). */
crisp_status crisp_render_cpu_plan_faces(crisp_renderer *r, const crisp_scene *scene,
                                         const crisp_frame_plan *plan, const crisp_camera *cam,
                                         const uint8_t *faces, const crisp_image *base,
                                         crisp_image *img, crisp_render_stats *stats);
/* The renderer's own planner (used by crisp_render_cpu and crisp_renderer_plan). */
crisp_planner *crisp_renderer_planner(crisp_renderer *r);

/* ---- f-rep parts ----------------------------------------------------------------------------- */

typedef struct crisp_frep_tape crisp_frep_tape; /* include/crisp/frep.h */

/* An implicit part in a scene: f(X, Y, Z) < 0 inside, in the part's own coordinates. */
typedef struct crisp_frep_part {
    const crisp_frep_tape *tape;
    crisp_mat4 transform; /* object to world, affine (last row 0 0 0 1), invertible */
    float color[4];
} crisp_frep_part;

/* Pixels drawn by part k get face id CRISP_FREP_FACE_ID(k) = -2 - k (NURBS faces are >= 0,
 * background -1). */
#define CRISP_FREP_FACE_ID(k) (-2 - (int32_t)(k))

/* Counters of one crisp_render_frep_parts call (summed over parts and threads). */
typedef struct crisp_frep_parts_stats {
    size_t intervals;    /* interval evaluations of frustum cells */
    size_t filled;       /* cells found inside everywhere */
    size_t leaves;       /* leaf cells sampled point by point */
    size_t batches;      /* batched point evaluations (CRISP_FREP_CELL_LANES points each) */
    size_t root_batches; /* of which narrowing sign changes to float precision */
    size_t points;       /* points evaluated in them */
    size_t tape_sum;     /* sum of the tape lengths of those batches (mean = tape_sum / batches) */
    size_t hits;         /* pixels drawn */
} crisp_frep_parts_stats;

typedef struct crisp_frep_parts_desc {
    int threads;   /* 0: default */
    int per_pixel; /* 1: no frustum subdivision, every pixel's ray bisected alone (exact backend) */
    int no_shorten; /* 1: evaluate the full tape in every cell (for measuring tape shortening) */
    crisp_frep_parts_stats *stats; /* NULL, or receives the call's counters */
    /* x0, y0, width, height: img holds only this window of the camera's image (x0, y0 multiples
     * of 32; issue 15, image tiles); all zero: the whole image. A window pixel gets the value it
     * has in the whole image when every pixel of its 32x32 tile holds its whole-image value. */
    int window[4];
} crisp_frep_parts_desc;

/* Draw the parts into img (which already holds the NURBS render, or a cleared image) where they
 * are nearer than what each pixel holds: the first camera-space depth in [near, far] along the
 * pixel's centre ray where f < 0, found by interval subdivision of the view frustum (tile x depth
 * cells, z-culled against the image's depth) and bisection to float precision; writes rgba
 * (headlight shading), depth, world normal (the gradient direction), uv = 0 and the face id.
 * desc may be NULL. */
crisp_status crisp_render_frep_parts(const crisp_frep_part *parts, size_t count,
                                     const crisp_camera *cam, const crisp_frep_parts_desc *desc,
                                     crisp_image *img);

#ifdef __cplusplus
}
#endif
#endif
