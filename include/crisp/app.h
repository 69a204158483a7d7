/* crisp app: what the command line, the viewer and the trim editor share, and what a program
 * that embeds crisp wants in a few calls: open a file, frame it, render it, write the picture.
 *
 * Offers:
 *   crisp_document               a model, its prepared scene, f-rep parts and the scene file's
 *                                camera line, opened from one file
 *   crisp_document_open/_destroy IGES, STEP, OBJ (by content), .scene, .vm or a math-string file
 *   crisp_document_update        prepare again after the model changed (trim editing)
 *   crisp_view, crisp_view_parse front, back, left, right, top, bottom, iso
 *   crisp_camera_fit(_points)    a perspective camera looking along a direction, moved so that
 *                                every corner of a box (every point) is on screen with a margin
 *   crisp_document_camera        the camera `crisp render` uses: options, the scene's camera
 *                                line, or the default (isometric, fitted to the trimmed box)
 *   crisp_document_render        one frame with the CPU or the exact backend, f-rep parts
 *                                composited by depth
 *   crisp_render_memory_estimate bytes a frame of a given size and sample count needs
 *   crisp_image_format_of, crisp_image_output_check, crisp_image_write(_png, _exr)
 *                                checked image outputs: PNG 8-bit RGBA, EXR with every AOV
 */
#ifndef CRISP_APP_H
#define CRISP_APP_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/core.h"
#include "crisp/io.h"
#include "crisp/model.h"
#include "crisp/render.h"
#include "crisp/scene_file.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- documents ------------------------------------------------------------------------------ */

typedef enum crisp_document_kind {
    CRISP_DOCUMENT_MODEL, /* an IGES, STEP or OBJ file */
    CRISP_DOCUMENT_SCENE, /* a scene file (include/crisp/scene_file.h) */
    CRISP_DOCUMENT_FREP   /* one f-rep part: a .vm file or a math-string file */
} crisp_document_kind;

typedef struct crisp_document {
    char *path;
    crisp_document_kind kind;
    crisp_model *model; /* faces (possibly none: a scene of f-rep parts only) */
    crisp_scene *scene; /* model prepared for rendering (Bézier patches, trim pieces, boxes) */
    size_t part_count;
    const crisp_frep_part *parts; /* f-rep parts, each with its transform and colour */
    /* the scene file's camera line (has_camera = 0 for other files; has_target = 0: the middle of
     * the box; has_up = 0: +Z, or +Y / -Y looking straight down / up) */
    int has_camera, has_target, has_up;
    double eye[3], target[3], up[3], fov_deg;
    /* what the default camera frames: points of the trimmed faces sampled on the true surfaces
     * (their trim curves mapped through the surface, and the inside points of a uv grid; clamped
     * to scene->box) and the corners of each part's [-1, 1]^3 through its transform */
    double *points; /* 3 per point */
    size_t point_count;
    double box[6];              /* their box: xmin, ymin, zmin, xmax, ymax, zmax */
    double ms_load, ms_prepare; /* time spent reading, and preparing (with the box) */
    /* owned storage */
    crisp_scene_file *scene_file;
    crisp_scene_assets *assets;
} crisp_document;

typedef struct crisp_document_desc {
    const crisp_read_options *read; /* NULL: defaults */
} crisp_document_desc;

/* Opens path: a scene file (by extension .scene or content), a .vm file, a file named *.math or
 * *.expr holding a math string, or a CAD model (IGES, STEP, OBJ by content); a file that is none
 * of these but parses as a math string is an f-rep part. Fails when the file holds nothing to
 * draw. desc may be NULL. */
crisp_status crisp_document_open(const char *path, const crisp_document_desc *desc,
                                 crisp_document **dest);
/* After doc->model changed (a trim edited, faces added): prepare the scene again and sample the
 * points to frame again. On failure the old scene is kept. */
crisp_status crisp_document_update(crisp_document *doc);
void crisp_document_destroy(crisp_document *doc);

/* ---- cameras ----------------------------------------------------------------------------------
 */

/* Directions the camera looks from, +Z up as in most CAD files (the eye is on the named side of
 * the box): front -Y, back +Y, right +X, left -X, top +Z (up +Y), bottom -Z (up -Y),
 * iso (1, -1, 1) (front, right and top seen). */
typedef enum crisp_view {
    CRISP_VIEW_DEFAULT = 0, /* the scene file's camera line if any, else iso */
    CRISP_VIEW_ISO,
    CRISP_VIEW_FRONT,
    CRISP_VIEW_BACK,
    CRISP_VIEW_LEFT,
    CRISP_VIEW_RIGHT,
    CRISP_VIEW_TOP,
    CRISP_VIEW_BOTTOM
} crisp_view;

/* "front", "back", "left", "right", "top", "bottom", "iso"; returns 0 for anything else. */
int crisp_view_parse(const char *name, crisp_view *dest);
const char *crisp_view_name(crisp_view view);
/* Unit direction from the target to the eye and the up vector of a view (DEFAULT = ISO). */
void crisp_view_direction(crisp_view view, double dir[3], double up[3]);

typedef struct crisp_camera_fit_desc {
    int width, height; /* image size; 0: 1280x720 */
    double fov_deg;    /* vertical; 0: 30 */
    double margin;     /* fraction of the half-frame left free on each side; 0: 0.04 */
} crisp_camera_fit_desc;

/* A perspective camera looking along -dir (dir points from the target towards the eye) with the
 * given up, placed as near as it can be with every corner of box inside the frame less the
 * margin; the target is on the view axis at the depth of the box's centre, near and far enclose
 * the box. desc may be NULL. */
crisp_status crisp_camera_fit(const double box[6], const double dir[3], const double up[3],
                              const crisp_camera_fit_desc *desc, crisp_camera *dest);
/* The same for a set of points (3 doubles each, count >= 1): every point on screen with the
 * margin, the target at the depth of the points' mean. */
crisp_status crisp_camera_fit_points(const double *points, size_t count, const double dir[3],
                                     const double up[3], const crisp_camera_fit_desc *desc,
                                     crisp_camera *dest);

/* What the caller asks of the camera; zero (or NULL) is the default for every field. */
typedef struct crisp_camera_desc {
    int width, height;    /* 0: 1280x720 */
    crisp_view view;      /* DEFAULT: the scene's camera line, else ISO */
    int fit;              /* 1: keep the direction of eye/target (or the camera line) and
                             move the camera to fit the box tightly */
    const double *eye;    /* 3 numbers, or NULL */
    const double *target; /* NULL: the middle of the box */
    const double *up;     /* NULL: +Z (+Y / -Y looking straight down / up) */
    double fov_deg;       /* 0: the camera line's, else 30 */
    double znear, zfar;   /* 0: enclose the box (other values are checked) */
    double margin;        /* 0: 0.04 (see crisp_camera_fit) */
} crisp_camera_desc;

/* The camera for doc: an explicit eye (optionally fitted), else the scene file's camera line
 * when desc->view is DEFAULT, else the view's direction fitted to doc->points (every sampled
 * point of the trimmed geometry on screen with the margin). Checked with crisp_camera_check.
 * desc may be NULL. */
crisp_status crisp_document_camera(const crisp_document *doc, const crisp_camera_desc *desc,
                                   crisp_camera *dest);

/* ---- rendering --------------------------------------------------------------------------------
 */

typedef enum crisp_backend {
    CRISP_BACKEND_CPU = 0, /* SLEFE tessellation, u-intercept tables, tile-binned rasterizer */
    CRISP_BACKEND_EXACT,   /* ray casting against the true surfaces and trim curves (slow) */
    CRISP_BACKEND_GL       /* OpenGL 4.5 on a headless context (include/crisp/gl.h); faces only,
                              the parts are composited on the CPU. CRISP_ERR_UNSUPPORTED when
                              crisp is built without it */
} crisp_backend;

/* Wall time of one crisp_document_render call by part of the document. */
typedef struct crisp_document_times {
    double ms_faces; /* the NURBS faces (plan, tessellation, raster, resolve; or exact rays) */
    double ms_parts; /* the f-rep parts */
} crisp_document_times;

typedef struct crisp_document_render_desc {
    crisp_backend backend;
    int samples;                 /* cpu, gl: 1, 4 or 16; 0: 1. exact: 1 */
    int threads;                 /* 0: default (CRISP_THREADS or all cores) */
    crisp_renderer *renderer;    /* cpu: reused when given (its samples win); NULL: one per call */
    crisp_document_times *times; /* NULL, or receives the call's times */
    /* x0, y0, width, height: draw only this window of the camera's image into img (which has
     * the window's size), each pixel bit for bit as in the whole image (issue 15, image tiles;
     * cpu backend: a margin around it is drawn and cropped). All zero: the whole image. */
    int window[4];
} crisp_document_render_desc;

/* Clears img (which must have the camera's size, or the window's) and draws doc's faces then its
 * f-rep parts. stats (may be NULL) receives the CPU backend's counters and stage times. */
crisp_status crisp_document_render(const crisp_document *doc, const crisp_camera *cam,
                                   const crisp_document_render_desc *desc, crisp_image *img,
                                   crisp_render_stats *stats);

/* Bytes a frame of width x height with samples per pixel needs at its peak (raster target,
 * image, outputs), measured on the bundled models; for warnings and limits. */
uint64_t crisp_render_memory_estimate(int width, int height, int samples);

/* ---- image outputs ----------------------------------------------------------------------------
 */

typedef enum crisp_image_format {
    CRISP_IMAGE_UNKNOWN = 0,
    CRISP_IMAGE_PNG, /* 8-bit RGBA, alpha = coverage */
    CRISP_IMAGE_EXR  /* float R G B A Z N.x N.y N.z u v face */
} crisp_image_format;

/* By the name's extension (.png, .exr, any case). */
crisp_image_format crisp_image_format_of(const char *path);
const char *crisp_image_format_name(crisp_image_format format);
/* Before the work starts: the extension names a supported format (want, when not UNKNOWN, the
 * one expected), the folder exists and is writable, and an existing file there is a writable
 * regular file. Creates nothing. */
crisp_status crisp_image_output_check(const char *path, crisp_image_format want);
/* By extension; PNG: rgba clamped to [0, 1] and rounded to 8 bits; EXR: every AOV as float. */
crisp_status crisp_image_write(const crisp_image *img, const char *path);
crisp_status crisp_image_write_png(const crisp_image *img, const char *path);
crisp_status crisp_image_write_exr(const crisp_image *img, const char *path);

#ifdef __cplusplus
}
#endif
#endif
