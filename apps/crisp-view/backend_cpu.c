/* crisp-view's display backend: a frame into a crisp_image, shown through a texture. The frame
 * comes from the CPU backend (crisp_render_cpu) or, where crisp is built with the GL backend
 * (CRISP_HAVE_GL) and --backend gl asks for it, from the GL backend on the window's own context
 * (crisp_gl_draw of the same plan, read back); f-rep parts are composited on the CPU either way.
 * Overlays are applied while converting to 8 bits: the selected face is tinted, and edges come from
 * the face-id AOV (a face border, a trim boundary or a silhouette is where the face id changes
 * between neighbouring pixels; never a triangle edge); a border where the normals turn by more than
 * 30 degrees is drawn dark (hard), else light (smooth). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/plan.h"
#include "proxy.h"
#include "view.h"
#ifdef CRISP_HAVE_GL
#include "crisp/gl.h"
#endif

typedef struct cpu_backend {
    crisp_renderer *renderer;    /* 1 sample per pixel */
    crisp_renderer *renderer_aa; /* 4 samples per pixel */
    crisp_image img;
    uint8_t *rgba8;
    size_t rgba8_cap;
    app_image_view iv;
    int threads;
    const crisp_frame_plan *plan; /* of the last frame; NULL after an off-screen render */
    int img_stale;                /* the last frame was blitted: img is not its image */
    const app_doc *tdoc;          /* view_backend.set_transparent */
    crisp_renderer *renderer_t;   /* the transparent faces (1 sample per pixel) */
    crisp_image timg;
    int section; /* view_backend.set_section */
    double plane[4], box[6];
    /* frames while the camera moves reuse one plan (motion_plan) made for a widened view */
    crisp_planner *motion_planner;
    const crisp_frame_plan *motion_plan; /* NULL: none for this document */
    const crisp_scene *motion_scene;
    crisp_frame_plan motion_copy;   /* the motion plan with the current camera's matrices */
    crisp_camera motion_cam;        /* what it was planned for (full size) */
    int motion_scale, motion_whole; /* the widened view holds the box's whole sphere */
    double motion_half;             /* half angle of its narrower side */
    view_proxy proxy;               /* the motion plan as a GPU mesh (proxy.c) */
    int proxy_failed;               /* its shaders did not build: moving frames on the CPU */
#ifdef CRISP_HAVE_GL
    int use_gl;
    crisp_gl *gl[2]; /* 1 and 4 samples per pixel */
    const crisp_scene *gl_scene[2];
    crisp_planner *planner;
    GLuint blit_fbo; /* on the image view's texture: moving GL frames are blitted into it */
    int blit_tex;    /* the texture name it was made for */
#endif
} cpu_backend;

/* ---- the motion plan --------------------------------------------------------------------------
 * Frames drawn while the camera moves are bound by planning on large models (SLEFE levels and
 * trim tables for every visible patch, every frame). The viewer plans once when the camera stops
 * (for the next motion), for the current camera with its frustum widened until it holds the
 * sphere around the box (at most 8x the tangent; the pixel size kept), at 1/scale of the window
 * and a 1 px tolerance there; moving frames then draw that plan's leaves and trim tables with
 * their own camera's matrices (the planner culls by the frustum only, so an orbit at about the
 * same distance finds every leaf in it). Levels are then those of a nearby camera: the image
 * of a moving frame is within a few pixels of the true one, the refined frame is exact. The
 * ribbons (clip-space quads of the planned camera) are left out. */

#define MOTION_EPS_PX 1.0 /* tolerance of the motion plan, in its own (reduced) pixels */
/* The motion plan's faces: the GPU mesh (proxy.c) draws leaves only, so with it the motion
 * planner draws no face as splats (a splatted face would be missing from the moving frames, and
 * its splat set is the costliest part of a large model's first motion plan: imp49 default at
 * 960x540: 3.4 s of CPU with every set, 1.2 s without splats). Without it (moving frames on the
 * CPU) the motion plan draws splats, its sets built VIEW_SPLAT_BUILD_LIMIT splats at a time: the
 * rest while the viewer is idle (view_backend.prepare_motion's *more). */
/* Splats made per full frame for splat sets not built yet (crisp_planner_desc.splat_build_limit):
 * a large model's first frame draws its faces as patches instead of waiting for every set (imp49
 * default: about 4 M splats, seconds); the frames after it build the rest. */
#define VIEW_SPLAT_BUILD_LIMIT 500000
#define MOTION_MAX_WIDEN 8.0
#define MOTION_PROXY_SCALE 2 /* the GPU mesh's plan: at most half size */

static double vlen(const double a[3])
{
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}

static void vsub(const double a[3], const double b[3], double d[3])
{
    for (int k = 0; k < 3; k++)
        d[k] = a[k] - b[k];
}

static double vdot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The widened camera: same eye, direction and pixel size, a frustum holding the box's sphere
 * (whole = 1) or MOTION_MAX_WIDEN times the tangents. */
static void motion_camera(const crisp_camera *cam, const double box[6], int scale,
                          crisp_camera *dest, int *whole, double *half)
{
    double c[3], f[3], e[3];
    for (int k = 0; k < 3; k++)
        c[k] = 0.5 * (box[k] + box[k + 3]);
    double R =
        0.5 * sqrt((box[3] - box[0]) * (box[3] - box[0]) + (box[4] - box[1]) * (box[4] - box[1]) +
                   (box[5] - box[2]) * (box[5] - box[2]));
    vsub(cam->target, cam->eye, f);
    double fl = vlen(f);
    vsub(c, cam->eye, e);
    double d = vlen(e);
    double tv = tan(cam->fov_deg * M_PI / 360.0), th = tv * cam->width / cam->height;
    double tmin = tv < th ? tv : th, k = MOTION_MAX_WIDEN;
    *whole = 0;
    if (d > 1.02 * R && fl > 0) {
        double off = acos(fmax(-1, fmin(1, vdot(e, f) / (d * fl))));
        double need = off + asin(R / d);
        if (need < 0.49 * M_PI) {
            double kk = tan(need) / tmin;
            if (kk <= MOTION_MAX_WIDEN) *whole = 1, k = kk;
        }
    }
    if (k < 1) k = 1;
    int sw = cam->width / scale > 0 ? cam->width / scale : 1,
        sh = cam->height / scale > 0 ? cam->height / scale : 1;
    *dest = *cam;
    dest->width = (int)ceil(k * sw);
    dest->height = (int)ceil(k * sh);
    /* the pixel angle kept: tan(fov'/2) / height' = tan(fov/2) / height */
    dest->fov_deg = 360.0 / M_PI * atan(tv * dest->height / sh);
    if (dest->fov_deg > 170) dest->fov_deg = 170;
    dest->znear = cam->znear * 0.5;
    dest->zfar = fmax(cam->zfar, d + R) * 1.5;
    *half = atan(fmin(tan(dest->fov_deg * M_PI / 360.0),
                      tan(dest->fov_deg * M_PI / 360.0) * dest->width / dest->height));
}

/* Whether the motion plan still serves cam: the same scene and projection, the eye at about the
 * planned distance from the box, and (when the widened view did not hold the whole box) the view
 * cone inside the planned one. */
static int motion_serves(const cpu_backend *b, const app_doc *doc, const crisp_camera *cam,
                         int scale)
{
    if (!b->motion_plan || b->motion_scene != doc->scene) return 0;
    const crisp_camera *m = &b->motion_cam;
    if (fabs(m->fov_deg - cam->fov_deg) > 1e-9 * cam->fov_deg || m->width != cam->width ||
        m->height != cam->height)
        return 0;
    if (b->proxy_failed && (scale > 2 * b->motion_scale || 2 * scale < b->motion_scale)) return 0;
    double c[3], e0[3], e1[3];
    for (int k = 0; k < 3; k++)
        c[k] = 0.5 * (doc->box[k] + doc->box[k + 3]);
    vsub(c, m->eye, e0);
    vsub(c, cam->eye, e1);
    double d0 = vlen(e0), d1 = vlen(e1);
    if (!(d1 < 1.5 * d0 && d1 > d0 / 1.5)) return 0;
    if (b->motion_whole) return 1;
    double mv[3], f0[3], f1[3];
    vsub(cam->eye, m->eye, mv);
    if (vlen(mv) > 0.02 * d0) return 0;
    vsub(m->target, m->eye, f0);
    vsub(cam->target, cam->eye, f1);
    double cosang = vdot(f0, f1) / (vlen(f0) * vlen(f1));
    double tv = tan(cam->fov_deg * M_PI / 360.0), th = tv * cam->width / cam->height;
    double diag = atan(sqrt(tv * tv + th * th));
    return acos(fmax(-1, fmin(1, cosang))) + diag <= b->motion_half;
}

/* more (NULL: the plan is needed now, for a moving frame): set to 1 when the motion plan still
 * has splat sets to build (the viewer calls again while idle: each call builds more). */
static crisp_status motion_prepare(void *self, const app_doc *doc, const crisp_camera *cam,
                                   int scale, int *more)
{
    cpu_backend *b = self;
    if (more) *more = 0;
    if (scale < 1) scale = 1;
    /* the GPU mesh is drawn at any scale the frame time allows; its plan's size (its number of
     * triangles) follows the viewer's first guess of the moving scale, at least half size */
    if (!b->proxy_failed && scale < MOTION_PROXY_SCALE) scale = MOTION_PROXY_SCALE;
    crisp_camera mc;
    int whole;
    double half;
    if (!doc->scene->patch_count) return CRISP_OK;
    /* idle with sets pending: planned again, building the next ones */
    if (motion_serves(b, doc, cam, scale) && (!more || !b->motion_plan->stats.splat_pending))
        return CRISP_OK;
    motion_camera(cam, doc->box, scale, &mc, &whole, &half);
    const crisp_frame_plan *p;
    b->motion_plan = NULL;
    crisp_status st = crisp_planner_plan(b->motion_planner, doc->scene, &mc, &p);
    if (st) return st;
    b->motion_plan = p;
    b->motion_scene = doc->scene;
    if (!b->proxy_failed) {
        st = view_proxy_build(&b->proxy, doc->scene, p, doc->box);
        if (st) b->proxy_failed = 1; /* the CPU path draws the motion plan instead */
    }
    b->motion_cam = *cam;
    b->motion_scale = scale;
    b->motion_whole = whole;
    b->motion_half = half;
    if (more) *more = p->stats.splat_pending > 0;
    return CRISP_OK;
}

/* The motion plan with cam's matrices and size (cam is the frame's, already reduced). */
static const crisp_frame_plan *motion_plan_for(cpu_backend *b, const crisp_camera *cam)
{
    crisp_frame_plan *p = &b->motion_copy;
    *p = *b->motion_plan;
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    memcpy(p->view_proj, m.view_proj, sizeof p->view_proj);
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 4; r++)
            p->view_proj_f[4 * c + r] = (float)m.view_proj[c][r];
    memcpy(p->eye, cam->eye, sizeof p->eye);
    p->width = cam->width;
    p->height = cam->height;
    p->ribbon_quad_count = 0;
    return p;
}

static void clear_image(crisp_image *img)
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

/* The transparent faces over img: their own frame (same clip plane), then where its nearest
 * surface is nearer than img's, blended over it (straight alpha); the face AOV stays the opaque
 * one. Only the nearest transparent surface is blended: one behind another is not seen. */
static crisp_status draw_transparent(cpu_backend *b, const crisp_camera *cam, crisp_image *img)
{
    crisp_status st = CRISP_OK;
    if (b->timg.width != cam->width || b->timg.height != cam->height) {
        crisp_image_free(&b->timg);
        if ((st = crisp_image_init(&b->timg, cam->width, cam->height))) return st;
    }
    crisp_renderer_set_clip_plane(b->renderer_t, b->section ? b->plane : NULL);
    if ((st = crisp_render_cpu(b->renderer_t, b->tdoc->scene, cam, &b->timg, NULL))) return st;
    const crisp_image *t = &b->timg;
    for (size_t k = 0; k < (size_t)cam->width * cam->height; k++) {
        if (t->face[k] < 0 || !(t->depth[k] < img->depth[k])) continue;
        float A = VIEW_ALPHA * t->rgba[4 * k + 3], ao = img->rgba[4 * k + 3];
        float out = A + ao * (1 - A);
        for (int q = 0; q < 3; q++)
            img->rgba[4 * k + q] =
                (A * t->rgba[4 * k + q] + (1 - A) * ao * img->rgba[4 * k + q]) / out;
        img->rgba[4 * k + 3] = out;
    }
    return CRISP_OK;
}

/* crisp_render_cpu, as `crisp render` draws (the frame planned in stages); plan != NULL (the
 * frames on screen): the plan drawn is kept there (crisp_planner_last_plan: the faces found
 * hidden have no leaves or table in it). moving: draw the motion plan (motion_prepare made it)
 * with cam's matrices. *blitted (may be NULL: always read back): a moving GL frame that nothing
 * needs the AOVs of is copied into the image view's texture on the GPU instead of read back. */
static crisp_status render_into(cpu_backend *b, const app_doc *doc, const crisp_camera *cam,
                                int samples, int moving, crisp_image *img, crisp_render_stats *rs,
                                const crisp_frame_plan **plan, int *blitted)
{
    crisp_status st = CRISP_OK;
    crisp_renderer *r = samples == 4 ? b->renderer_aa : b->renderer;
    b->plan = NULL;
    const double *clip = b->section ? b->plane : NULL;
    crisp_renderer_set_clip_plane(r, clip);
    int use_motion = moving && plan && b->motion_plan && b->motion_scene == doc->scene;
    int blit = 0;
#ifdef CRISP_HAVE_GL
    if (b->use_gl && doc->scene->patch_count > 0) {
        int k = samples == 4;
        const crisp_frame_plan *p = NULL;
        if (b->gl_scene[k] != doc->scene) {
            crisp_gl_forget_plan(b->gl[k]);
            st = crisp_gl_set_scene(b->gl[k], doc->scene);
            b->gl_scene[k] = st ? NULL : doc->scene;
        }
        crisp_gl_set_clip_plane(b->gl[k], clip);
        if (!st && use_motion)
            p = motion_plan_for(b, cam);
        else if (!st)
            st = crisp_planner_plan(b->planner, doc->scene, cam, &p);
        if (!st) st = crisp_gl_draw(b->gl[k], p, NULL);
        blit = blitted && !doc->part_count;
        if (!st && blit) {
            GLuint tex = app_image_view_target(&b->iv, cam->width, cam->height);
            if (!b->blit_fbo || b->blit_tex != (int)tex) {
                if (b->blit_fbo) glDeleteFramebuffers(1, &b->blit_fbo);
                glCreateFramebuffers(1, &b->blit_fbo);
                glNamedFramebufferTexture(b->blit_fbo, GL_COLOR_ATTACHMENT0, tex, 0);
                b->blit_tex = (int)tex;
            }
            /* a negative height: the image's top row to the texture's row 0, as an upload */
            st = crisp_gl_blit(b->gl[k], b->blit_fbo, 0, cam->height, cam->width, -cam->height);
        } else if (!st) {
            st = crisp_gl_read(b->gl[k], img, NULL);
        }
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        if (!st && rs) {
            rs->triangles = p->stats.triangles;
            rs->table_bytes = p->stats.table_bytes;
        }
        if (plan) *plan = p;
    } else
#endif
        if (doc->scene->patch_count > 0 && use_motion) {
        *plan = motion_plan_for(b, cam);
        st = crisp_render_cpu_plan(r, doc->scene, *plan, cam, img, rs);
    } else if (doc->scene->patch_count > 0) {
        /* planned in stages (the faces the nearer ones hide get no plan); the final plan kept */
        st = crisp_render_cpu(r, doc->scene, cam, img, rs);
        if (!st && plan) *plan = crisp_planner_last_plan(crisp_renderer_planner(r));
    } else {
        clear_image(img);
    }
    if (!st && b->section && !blit) view_section_cap(cam, b->plane, b->box, img);
    if (!st && b->tdoc && !blit) st = draw_transparent(b, cam, img);
    if (!st && doc->part_count)
        st = crisp_render_frep_parts(doc->parts, doc->part_count, cam,
                                     &(crisp_frep_parts_desc){.threads = b->threads}, img);
    if (blitted) *blitted = blit && !st;
    return st;
}

static uint8_t to8(float c)
{
    return (uint8_t)lrintf(255.0f * (c < 0 ? 0 : c > 1 ? 1 : c));
}

static void convert(cpu_backend *b, const view_overlay *ov)
{
    const crisp_image *img = &b->img;
    int w = img->width, h = img->height;
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            size_t k = (size_t)j * w + i;
            float c[4];
            memcpy(c, img->rgba + 4 * k, sizeof c);
            int32_t f = img->face[k];
            if (ov->selected_face != -1 && f == ov->selected_face) {
                c[0] = 0.55f * c[0] + 0.45f * 0.25f;
                c[1] = 0.55f * c[1] + 0.45f * 0.55f;
                c[2] = 0.55f * c[2] + 0.45f * 1.0f;
            }
            if (ov->edges) {
                /* compare with the right and lower neighbours (and left/up for symmetry of width)
                 */
                int edge = 0;
                const int di[4] = {1, -1, 0, 0}, dj[4] = {0, 0, 1, -1};
                for (int q = 0; q < 4 && edge < 2; q++) {
                    int ii = i + di[q], jj = j + dj[q];
                    if (ii < 0 || jj < 0 || ii >= w || jj >= h) continue;
                    size_t kk = (size_t)jj * w + ii;
                    int32_t g = img->face[kk];
                    if (g == f) continue;
                    if (f < 0 && g < 0) continue;
                    if (f == -1 || g == -1) {
                        edge = 2; /* silhouette */
                        continue;
                    }
                    const float *n0 = img->normal + 3 * k, *n1 = img->normal + 3 * kk;
                    float d = n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2];
                    edge = fabsf(d) < 0.866f ? 2 : (edge ? edge : 1);
                }
                if (edge && f != -1) {
                    float t = edge == 2 ? 0.15f : 0.6f;
                    for (int q = 0; q < 3; q++)
                        c[q] *= t;
                } else if (edge == 2) {
                    c[0] = c[1] = c[2] = 0.05f;
                    c[3] = 1;
                }
            }
            uint8_t *o = b->rgba8 + 4 * k;
            for (int q = 0; q < 4; q++)
                o[q] = to8(c[q]);
        }
}

static crisp_status cpu_frame(void *self, const app_doc *doc, const crisp_camera *cam, int scale,
                              const view_overlay *ov, view_frame_stats *stats)
{
    cpu_backend *b = self;
    crisp_camera c = *cam;
    if (scale < 1) scale = 1;
    c.width = cam->width / scale > 0 ? cam->width / scale : 1;
    c.height = cam->height / scale > 0 ? cam->height / scale : 1;
    if (b->img.width != c.width || b->img.height != c.height) {
        crisp_image_free(&b->img);
        crisp_status st = crisp_image_init(&b->img, c.width, c.height);
        if (st) return st;
        size_t need = (size_t)c.width * c.height * 4;
        if (need > b->rgba8_cap) {
            uint8_t *p = realloc(b->rgba8, need);
            if (!p) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the view image");
            b->rgba8 = p;
            b->rgba8_cap = need;
        }
    }
    double t0 = crisp_time_now();
    crisp_render_stats rs = {0};
    const crisp_frame_plan *plan = NULL;
    crisp_status st = CRISP_OK;
    if (ov->moving)
        st = motion_prepare(b, doc, cam,
                            !b->proxy_failed && b->motion_scale ? b->motion_scale : scale, NULL);
    if (!st && ov->moving && ov->no_aovs && !b->proxy_failed && b->proxy.ready && b->motion_plan &&
        b->motion_scene == doc->scene) {
        view_proxy_style style = {
            .edges = ov->edges, .selected = ov->selected_face, .clip = b->section};
        if (b->section) {
            memcpy(style.clip_plane, b->plane, sizeof style.clip_plane);
            view_section_hatch(b->plane, b->box, style.hatch_u);
        }
        st = view_proxy_draw(&b->proxy, &c, app_image_view_target(&b->iv, c.width, c.height),
                             &style);
        if (st) return st;
        stats->ms = 1e3 * (crisp_time_now() - t0);
        stats->samples = 1;
        stats->scale = scale;
        stats->triangles = b->proxy.triangles;
        stats->table_bytes = b->motion_plan->stats.table_bytes;
        stats->min_depth = NAN;
        stats->cover[0] = stats->cover[1] = 0;
        stats->cover[2] = cam->width;
        stats->cover[3] = cam->height;
        b->img_stale = 1;
        b->plan = NULL;
        return CRISP_OK;
    }
    int blitted = 0, samples = scale == 1 && !ov->moving ? ov->samples : 1;
    if (!st)
        st = render_into(b, doc, &c, samples, ov->moving, &b->img, &rs, &plan,
                         ov->moving && ov->no_aovs ? &blitted : NULL);
    stats->samples = samples;
    if (st) return st;
    b->plan = plan;
    stats->pending = plan ? plan->stats.splat_pending : 0;
    stats->ms = 1e3 * (crisp_time_now() - t0);
    stats->triangles = rs.triangles + rs.ribbon_triangles;
    stats->table_bytes = rs.table_bytes;
    stats->scale = scale;
    if (blitted) { /* no AOVs on the CPU: the last frame's depth hint stays */
        stats->min_depth = NAN;
        stats->cover[0] = stats->cover[1] = 0;
        stats->cover[2] = cam->width;
        stats->cover[3] = cam->height;
        b->img_stale = 1;
        return CRISP_OK;
    }
    b->img_stale = 0;
    double dmin = INFINITY;
    int x0 = c.width, y0 = c.height, x1 = -1, y1 = -1;
    for (int j = 0; j < c.height; j++)
        for (int i = 0; i < c.width; i++) {
            size_t k = (size_t)j * c.width + i;
            if (b->img.face[k] == -1) continue;
            if (b->img.depth[k] < dmin) dmin = b->img.depth[k];
            if (i < x0) x0 = i;
            if (i > x1) x1 = i;
            if (j < y0) y0 = j;
            if (j > y1) y1 = j;
        }
    stats->min_depth = dmin;
    stats->cover[0] = (double)x0 * scale;
    stats->cover[1] = (double)y0 * scale;
    stats->cover[2] = (double)(x1 + 1) * scale;
    stats->cover[3] = (double)(y1 + 1) * scale;
    convert(b, ov);
    app_image_view_upload(&b->iv, c.width, c.height, b->rgba8);
    return CRISP_OK;
}

static void cpu_present(void *self, int fb_width, int fb_height)
{
    cpu_backend *b = self;
    app_image_view_draw(&b->iv, fb_width, fb_height);
}

static crisp_status cpu_offscreen(void *self, const app_doc *doc, const crisp_camera *cam,
                                  int samples, crisp_image *img)
{
    /* a screenshot is what `crisp render` draws: every splat set built first */
    cpu_backend *b = self;
    crisp_planner *pl = crisp_renderer_planner(samples == 4 ? b->renderer_aa : b->renderer);
#ifdef CRISP_HAVE_GL
    if (b->use_gl) pl = b->planner;
#endif
    if (!doc->scene->patch_count) pl = NULL;
    const crisp_frame_plan *p = NULL;
    crisp_status st = CRISP_OK;
    while (pl && !st && (!p || p->stats.splat_pending))
        st = crisp_planner_plan(pl, doc->scene, cam, &p);
    if (st) return st;
    return render_into(self, doc, cam, samples, 0, img, NULL, NULL, NULL);
}

static void cpu_set_section(void *self, int on, const double plane[4], const double box[6])
{
    cpu_backend *b = self;
    b->section = on;
    if (on) {
        memcpy(b->plane, plane, sizeof b->plane);
        memcpy(b->box, box, sizeof b->box);
    }
}

static void cpu_set_transparent(void *self, const app_doc *tdoc)
{
    ((cpu_backend *)self)->tdoc = tdoc;
}

static const crisp_frame_plan *cpu_plan(void *self)
{
    return ((cpu_backend *)self)->plan;
}

static const crisp_image *cpu_image(void *self)
{
    cpu_backend *b = self;
    return b->img.rgba && !b->img_stale ? &b->img : NULL;
}

static void cpu_set_doc(void *self, const app_doc *doc)
{
    (void)doc;
    cpu_backend *b = self;
    b->plan = NULL;
    b->motion_plan = NULL;
    b->motion_scene = NULL;
#ifdef CRISP_HAVE_GL
    /* a new scene may sit at a freed one's address */
    b->gl_scene[0] = b->gl_scene[1] = NULL;
#endif
}

static void cpu_destroy(void *self)
{
    cpu_backend *b = self;
    if (!b) return;
#ifdef CRISP_HAVE_GL
    crisp_gl_destroy(b->gl[0]);
    crisp_gl_destroy(b->gl[1]);
    crisp_planner_destroy(b->planner);
    if (b->blit_fbo) glDeleteFramebuffers(1, &b->blit_fbo);
#endif
    crisp_planner_destroy(b->motion_planner);
    view_proxy_free(&b->proxy);
    crisp_renderer_destroy(b->renderer);
    crisp_renderer_destroy(b->renderer_aa);
    crisp_renderer_destroy(b->renderer_t);
    crisp_image_free(&b->timg);
    crisp_image_free(&b->img);
    free(b->rgba8);
    app_image_view_free(&b->iv);
    free(b);
}

int view_backend_have_gl(void)
{
#ifdef CRISP_HAVE_GL
    return 1;
#else
    return 0;
#endif
}

crisp_status view_backend_create(int threads, int use_gl, view_backend *dest)
{
    cpu_backend *b = calloc(1, sizeof *b);
    if (!b) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    b->threads = threads;
    if (use_gl && !view_backend_have_gl()) {
        free(b);
        return crisp_error(CRISP_ERR_UNSUPPORTED, "--backend gl: crisp was built without the GL "
                                                  "backend (src/gl)");
    }
#ifdef CRISP_HAVE_GL
    b->use_gl = use_gl;
    if (use_gl) {
        crisp_status gs = crisp_gl_create((crisp_gl_getproc_fn)glfwGetProcAddress,
                                          &(crisp_gl_desc){.samples = 1}, &b->gl[0]);
        if (!gs)
            gs = crisp_gl_create((crisp_gl_getproc_fn)glfwGetProcAddress,
                                 &(crisp_gl_desc){.samples = 4}, &b->gl[1]);
        if (!gs)
            gs = crisp_planner_create(
                &(crisp_planner_desc){.splat_build_limit = VIEW_SPLAT_BUILD_LIMIT}, NULL,
                &b->planner);
        if (gs) {
            cpu_destroy(b);
            return gs;
        }
    }
#endif
    char err[512];
    crisp_status st = crisp_renderer_create(
        &(crisp_render_desc){.threads = threads, .splat_build_limit = VIEW_SPLAT_BUILD_LIMIT},
        &b->renderer);
    if (!st)
        st = crisp_renderer_create(
            &(crisp_render_desc){
                .threads = threads, .samples = 4, .splat_build_limit = VIEW_SPLAT_BUILD_LIMIT},
            &b->renderer_aa);
    if (!st) st = crisp_renderer_create(&(crisp_render_desc){.threads = threads}, &b->renderer_t);
    if (!st && !app_image_view_init(&b->iv, err, sizeof err))
        st = crisp_error(CRISP_ERR_GL, "%s", err);
    if (!st && view_proxy_init(&b->proxy)) {
        /* moving frames then draw the motion plan on the CPU */
        fprintf(stderr, "crisp-view: %s\n", crisp_error_message());
        b->proxy_failed = 1;
    }
    if (!st)
        st =
            crisp_planner_create(&(crisp_planner_desc){.eps_px = MOTION_EPS_PX,
                                                       .no_splats = !b->proxy_failed,
                                                       .splat_build_limit = VIEW_SPLAT_BUILD_LIMIT},
                                 NULL, &b->motion_planner);
    if (st) {
        cpu_destroy(b);
        return st;
    }
    *dest = (view_backend){.name = use_gl ? "gl" : "cpu",
                           .self = b,
                           .frame = cpu_frame,
                           .present = cpu_present,
                           .offscreen = cpu_offscreen,
                           .plan = cpu_plan,
                           .image = cpu_image,
                           .prepare_motion = motion_prepare,
                           .set_section = cpu_set_section,
                           .set_transparent = cpu_set_transparent,
                           .set_doc = cpu_set_doc,
                           .destroy = cpu_destroy};
    return CRISP_OK;
}
