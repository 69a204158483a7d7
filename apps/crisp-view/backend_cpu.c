/* crisp-view's display backend: a frame into a crisp_image, shown through a texture. The frame
 * comes from the CPU backend (crisp_render_cpu_plan) or, where crisp is built with the GL backend
 * (CRISP_HAVE_GL) and --backend gl asks for it, from the GL backend on the window's own context
 * (crisp_gl_draw of the same plan, read back); f-rep parts are composited on the CPU either way. Overlays are applied while converting to 8 bits: the selected face is
 * tinted, and edges come from the face-id AOV (a face border, a trim boundary or a silhouette is
 * where the face id changes between neighbouring pixels; never a triangle edge); a border where
 * the normals turn by more than 30 degrees is drawn dark (hard), else light (smooth). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/plan.h"
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
#ifdef CRISP_HAVE_GL
    int use_gl;
    crisp_gl *gl[2];              /* 1 and 4 samples per pixel */
    const crisp_scene *gl_scene[2];
    crisp_planner *planner;
#endif
} cpu_backend;

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

/* plan != NULL: plan first and keep the plan (the frames on screen); else crisp_render_cpu, as
 * `crisp render` does (screenshots). */
static crisp_status render_into(cpu_backend *b, const app_doc *doc, const crisp_camera *cam,
                                int samples, crisp_image *img, crisp_render_stats *rs,
                                const crisp_frame_plan **plan)
{
    crisp_status st = CRISP_OK;
    crisp_renderer *r = samples == 4 ? b->renderer_aa : b->renderer;
    b->plan = NULL;
#ifdef CRISP_HAVE_GL
    if (b->use_gl && doc->scene->patch_count > 0) {
        int k = samples == 4;
        const crisp_frame_plan *p = NULL;
        if (b->gl_scene[k] != doc->scene) {
            crisp_gl_forget_plan(b->gl[k]);
            st = crisp_gl_set_scene(b->gl[k], doc->scene);
            b->gl_scene[k] = st ? NULL : doc->scene;
        }
        if (!st) st = crisp_planner_plan(b->planner, doc->scene, cam, &p);
        if (!st) st = crisp_gl_draw(b->gl[k], p, NULL);
        if (!st) st = crisp_gl_read(b->gl[k], img, NULL);
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        if (!st && rs) {
            rs->triangles = p->stats.triangles;
            rs->table_bytes = p->stats.table_bytes;
        }
        if (plan) *plan = p;
    } else
#endif
    if (doc->scene->patch_count > 0 && plan) {
        st = crisp_planner_plan(crisp_renderer_planner(r), doc->scene, cam, plan);
        if (!st) st = crisp_render_cpu_plan(r, doc->scene, *plan, cam, img, rs);
    } else if (doc->scene->patch_count > 0) {
        st = crisp_render_cpu(r, doc->scene, cam, img, rs);
    } else {
        clear_image(img);
    }
    if (!st && doc->part_count)
        st = crisp_render_frep_parts(doc->parts, doc->part_count, cam,
                                     &(crisp_frep_parts_desc){.threads = b->threads}, img);
    return st;
}

static uint8_t to8(float c) { return (uint8_t)lrintf(255.0f * (c < 0 ? 0 : c > 1 ? 1 : c)); }

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
                /* compare with the right and lower neighbours (and left/up for symmetry of width) */
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
                    for (int q = 0; q < 3; q++) c[q] *= t;
                } else if (edge == 2) {
                    c[0] = c[1] = c[2] = 0.05f;
                    c[3] = 1;
                }
            }
            uint8_t *o = b->rgba8 + 4 * k;
            for (int q = 0; q < 4; q++) o[q] = to8(c[q]);
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
    crisp_status st = render_into(b, doc, &c, scale == 1 ? ov->samples : 1, &b->img, &rs, &plan);
    stats->samples = scale == 1 ? ov->samples : 1;
    if (st) return st;
    b->plan = plan;
    stats->ms = 1e3 * (crisp_time_now() - t0);
    stats->triangles = rs.triangles + rs.ribbon_triangles;
    stats->table_bytes = rs.table_bytes;
    stats->scale = scale;
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
    return render_into(self, doc, cam, samples, img, NULL, NULL);
}

static const crisp_frame_plan *cpu_plan(void *self) { return ((cpu_backend *)self)->plan; }

static const crisp_image *cpu_image(void *self)
{
    cpu_backend *b = self;
    return b->img.rgba ? &b->img : NULL;
}

static void cpu_set_doc(void *self, const app_doc *doc)
{
    (void)doc;
    cpu_backend *b = self;
    b->plan = NULL;
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
#endif
    crisp_renderer_destroy(b->renderer);
    crisp_renderer_destroy(b->renderer_aa);
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
        if (!gs) gs = crisp_planner_create(NULL, NULL, &b->planner);
        if (gs) {
            cpu_destroy(b);
            return gs;
        }
    }
#endif
    char err[512];
    crisp_status st = crisp_renderer_create(&(crisp_render_desc){.threads = threads}, &b->renderer);
    if (!st)
        st = crisp_renderer_create(&(crisp_render_desc){.threads = threads, .samples = 4},
                                   &b->renderer_aa);
    if (!st && !app_image_view_init(&b->iv, err, sizeof err))
        st = crisp_error(CRISP_ERR_GL, "%s", err);
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
                           .set_doc = cpu_set_doc,
                           .destroy = cpu_destroy};
    return CRISP_OK;
}
