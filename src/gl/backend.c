/* The OpenGL 4.5 core backend (include/crisp/gl.h): the frame plan's arrays in storage buffers,
 * leaves drawn as one-vertex GL patches tessellated at the plan's levels (Wu & Peters 2015: the
 * trim test against the u-intercept table in the fragment shader), the trim ribbons in a fill
 * pass, one pass per sample at the CPU backend's sample positions, resolved as the CPU backend
 * resolves (src/render/cpu.c). The shaders are in shaders/ (embedded at build time). */
#include <glad/gl.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/gl.h"
#include "gl_internal.h"
#include "render/raster.h"
#include "render/ribbon.h"

/* Splats are drawn as points this much larger than the plan's 2 h (px) and the samples outside
 * the rule's square discarded (splat_fs.glsl): llvmpipe's snapping of the point's centre and
 * size to 1/256 px moves its square's sides by less than 1/128 px. */
#define CRISP__GL_SPLAT_MARGIN (1.0 / 16)

/* The records the shaders read: their C layout must be the std430 layout in common.glsl. */
_Static_assert(sizeof(crisp_plan_leaf) == 48, "crisp_plan_leaf: 3 uvec4");
_Static_assert(sizeof(crisp_plan_face) == 64, "crisp_plan_face: std430 Face");
_Static_assert(sizeof(crisp_plan_strip) == 24, "crisp_plan_strip: std430 Strip");
_Static_assert(sizeof(crisp_plan_ribbon_vertex) == 56,
               "crisp_plan_ribbon_vertex: std430 RibbonVertex");
_Static_assert(sizeof(crisp_plan_splat) == 24, "crisp_plan_splat: std430 Splat (splat_vs.glsl)");
_Static_assert(sizeof(crisp_scene_patch_record) == 48,
               "crisp_scene_patch_record: std430 PatchRecord");
_Static_assert(sizeof(crisp__gl_query) == 48 && sizeof(crisp__gl_result) == 72,
               "layout probe records");

extern const char crisp__shader_common_glsl[], crisp__shader_surface_vs_glsl[],
    crisp__shader_surface_tcs_glsl[], crisp__shader_surface_tes_glsl[],
    crisp__shader_surface_fs_glsl[], crisp__shader_ribbon_vs_glsl[], crisp__shader_ribbon_fs_glsl[],
    crisp__shader_fullscreen_vs_glsl[], crisp__shader_slack_fs_glsl[],
    crisp__shader_accum_cs_glsl[], crisp__shader_finish_cs_glsl[], crisp__shader_layout_cs_glsl[],
    crisp__shader_splat_vs_glsl[], crisp__shader_splat_fs_glsl[];

enum {
    B_LEAVES,
    B_FACES,
    B_STRIPS,
    B_ROWS,
    B_CROSSINGS,
    B_RIBBONS,
    B_PATCHES,
    B_CPS,
    B_COLORS,
    B_QUERIES,
    B_RESULTS,
    B_SPLATS,        /* binding 11: the plan's splat store */
    B_SPLAT_ORIGINS, /* binding 12: splat_clip_origin, 4 floats per face */
    B_SPLAT_RUNS,    /* binding 13: the frame's ranges as (first, face), by first */
    B_COUNT
};
static const char *const buffer_names[B_COUNT] = {
    "leaves",          "faces",         "trim strips",        "trim rows",    "trim crossings",
    "ribbon vertices", "patch records", "control points",     "face colours", "layout queries",
    "layout results",  "splats",        "splat clip origins", "splat runs"};

typedef struct uniforms {
    GLint leaf_base, view_proj, jitter, zconst, slack_tex, nw_tex, uv_tex, face_tex, dir0, dir_x,
        dir_y, offset, samples, count, keep_samples, sample_index, clip_plane, image_size,
        slack_scale, core_scale, view_proj_f, view, point_size, half_px, raw, splat_base, run_count;
} uniforms;

struct crisp_gl {
    crisp_gl_desc desc;
    char renderer[300];
    size_t max_block;
    size_t chunk_leaves, chunk_quads; /* leaves and ribbon quads drawn per bound buffer range */
    size_t chunk_splats;              /* splats of the store bound at once */
    GLuint vao;
    GLuint surface, ribbon, slack, accum, finish, layout, splat;
    uniforms u_surface, u_ribbon, u_slack, u_accum, u_finish, u_layout, u_splat;
    GLuint buf[B_COUNT];
    size_t buf_cap[B_COUNT];
    /* targets */
    int width, height;
    GLuint t_nw, t_uv, t_face, t_depth, t_slack, t_acc, t_best_nw, t_best_uv, t_best_face;
    GLuint fbo_pass, fbo_slack, fbo_out;
    /* what is uploaded */
    const crisp_frame_plan *plan;
    uint64_t v_leaves, v_faces, v_table, v_ribbons, v_splats;
    const crisp_scene *scene;
    int have_scene, drawn;
    uint32_t scene_patches, scene_faces;
    uint64_t scene_bytes;
    float *tmp;
    size_t tmp_cap;
    int keep_samples;      /* tests: keep every sample's face (crisp__gl_sample_faces) */
    GLuint t_sample_faces; /* GL_R32I, one layer per sample */
    int sample_w, sample_h;
    /* splats: the largest point size, the viewport limit, the draw's firsts and counts */
    float max_point;
    int max_viewport[2];
    GLint *splat_first; /* the frame's runs of splats (absolute indices into the store) */
    GLsizei *splat_n;
    size_t splat_cap, splat_pieces;
    struct splat_batch {
        size_t chunk, first_piece, pieces; /* one glMultiDrawArrays with the chunk bound */
    } * splat_batch;
    size_t batch_cap, splat_batches;
    uint32_t *runs; /* the frame's ranges: first, face; sorted by first */
    size_t runs_cap;
    uint64_t splats_drawn;
    int splat_raw; /* tests: GL's point coverage without the exact test (crisp__gl_splat_raw) */
};

/* ---- shaders ----------------------------------------------------------------------------------
 */

static GLuint compile(const char *name, GLenum stage, const char *src, crisp_status *st)
{
    const char *parts[3] = {"#version 450 core\n", crisp__shader_common_glsl, src};
    GLuint sh = glCreateShader(stage);
    glShaderSource(sh, 3, parts, NULL);
    glCompileShader(sh);
    GLint ok = 0;
    glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[2048] = "";
        glGetShaderInfoLog(sh, sizeof log, NULL, log);
        glDeleteShader(sh);
        *st = crisp_error(CRISP_ERR_GL,
                          "GL shader %s does not compile (lines count from common.glsl's "
                          "start, after the #version line): %s",
                          name, log);
        return 0;
    }
    return sh;
}

/* Links the given stages (sources NULL are skipped); 0 and an error on failure. */
static GLuint program(const char *name, const char *vs, const char *tcs, const char *tes,
                      const char *fs, const char *cs, crisp_status *st)
{
    const char *srcs[5] = {vs, tcs, tes, fs, cs};
    static const GLenum stages[5] = {GL_VERTEX_SHADER, GL_TESS_CONTROL_SHADER,
                                     GL_TESS_EVALUATION_SHADER, GL_FRAGMENT_SHADER,
                                     GL_COMPUTE_SHADER};
    static const char *const stage_names[5] = {"vertex", "tessellation control",
                                               "tessellation evaluation", "fragment", "compute"};
    GLuint prog = glCreateProgram(), sh[5] = {0};
    for (int k = 0; k < 5; k++) {
        if (!srcs[k]) continue;
        char what[120];
        snprintf(what, sizeof what, "'%s' (%s stage)", name, stage_names[k]);
        if (!(sh[k] = compile(what, stages[k], srcs[k], st))) {
            for (int j = 0; j < k; j++)
                if (sh[j]) glDeleteShader(sh[j]);
            glDeleteProgram(prog);
            return 0;
        }
        glAttachShader(prog, sh[k]);
    }
    glLinkProgram(prog);
    for (int k = 0; k < 5; k++)
        if (sh[k]) glDeleteShader(sh[k]);
    GLint ok = 0;
    glGetProgramiv(prog, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[2048] = "";
        glGetProgramInfoLog(prog, sizeof log, NULL, log);
        glDeleteProgram(prog);
        *st = crisp_error(CRISP_ERR_GL, "GL program '%s' does not link: %s", name, log);
        return 0;
    }
    return prog;
}

static void locate(GLuint p, uniforms *u)
{
    u->leaf_base = glGetUniformLocation(p, "leaf_base");
    u->view_proj = glGetUniformLocation(p, "view_proj");
    u->clip_plane = glGetUniformLocation(p, "clip_plane");
    u->jitter = glGetUniformLocation(p, "jitter");
    u->zconst = glGetUniformLocation(p, "zconst");
    u->slack_tex = glGetUniformLocation(p, "slack_tex");
    u->nw_tex = glGetUniformLocation(p, "nw_tex");
    u->uv_tex = glGetUniformLocation(p, "uv_tex");
    u->face_tex = glGetUniformLocation(p, "face_tex");
    u->dir0 = glGetUniformLocation(p, "dir0");
    u->dir_x = glGetUniformLocation(p, "dir_x");
    u->dir_y = glGetUniformLocation(p, "dir_y");
    u->offset = glGetUniformLocation(p, "offset");
    u->samples = glGetUniformLocation(p, "samples");
    u->count = glGetUniformLocation(p, "count");
    u->keep_samples = glGetUniformLocation(p, "keep_samples");
    u->sample_index = glGetUniformLocation(p, "sample_index");
    u->image_size = glGetUniformLocation(p, "image_size");
    u->slack_scale = glGetUniformLocation(p, "slack_scale");
    u->core_scale = glGetUniformLocation(p, "core_scale");
    u->view_proj_f = glGetUniformLocation(p, "view_proj_f");
    u->view = glGetUniformLocation(p, "view");
    u->point_size = glGetUniformLocation(p, "point_size");
    u->half_px = glGetUniformLocation(p, "half_px");
    u->raw = glGetUniformLocation(p, "raw");
    u->splat_base = glGetUniformLocation(p, "splat_base");
    u->run_count = glGetUniformLocation(p, "run_count");
}

crisp_status crisp__gl_try_program(const char *name, int stage, const char *src)
{
    crisp_status st = CRISP_OK;
    GLuint p = program(name, stage == CRISP__GL_VERTEX ? src : NULL, NULL, NULL,
                       stage == CRISP__GL_FRAGMENT ? src : NULL,
                       stage == CRISP__GL_COMPUTE ? src : NULL, &st);
    if (p) glDeleteProgram(p);
    return st;
}

/* ---- create / destroy -------------------------------------------------------------------------
 */

static crisp_status gl_check(const char *what)
{
    GLenum e = glGetError(), first = e;
    while (e != GL_NO_ERROR)
        e = glGetError();
    if (first == GL_NO_ERROR) return CRISP_OK;
    return crisp_error(CRISP_ERR_GL, "GL error 0x%x %s%s", (unsigned)first, what,
                       first == GL_OUT_OF_MEMORY ? " (out of GPU memory)" : "");
}

crisp_status crisp_gl_create(crisp_gl_getproc_fn getproc, const crisp_gl_desc *desc,
                             crisp_gl **dest)
{
    if (!getproc)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_gl_create: no GL loader function");
    crisp_gl_desc d = {0};
    if (desc) d = *desc;
    if (!d.samples) d.samples = 1;
    if (d.samples != 1 && d.samples != 4 && d.samples != 16)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%d samples per pixel: expected 1, 4 or 16",
                           d.samples);
    int version = gladLoadGL((GLADloadfunc)getproc);
    if (!version || !glGetString)
        return crisp_error(CRISP_ERR_GL,
                           "no current OpenGL context (the GL functions could not be loaded)");
    if (GLAD_VERSION_MAJOR(version) < 4 ||
        (GLAD_VERSION_MAJOR(version) == 4 && GLAD_VERSION_MINOR(version) < 5))
        return crisp_error(CRISP_ERR_GL, "OpenGL %d.%d (%s): the GL backend needs OpenGL 4.5 core",
                           GLAD_VERSION_MAJOR(version), GLAD_VERSION_MINOR(version),
                           (const char *)glGetString(GL_RENDERER));
    GLint tes_blocks = 0, tcs_blocks = 0, fs_blocks = 0, max_level = 0;
    GLint64 block = 0;
    glGetIntegerv(GL_MAX_TESS_EVALUATION_SHADER_STORAGE_BLOCKS, &tes_blocks);
    glGetIntegerv(GL_MAX_TESS_CONTROL_SHADER_STORAGE_BLOCKS, &tcs_blocks);
    glGetIntegerv(GL_MAX_FRAGMENT_SHADER_STORAGE_BLOCKS, &fs_blocks);
    glGetIntegerv(GL_MAX_TESS_GEN_LEVEL, &max_level);
    glGetInteger64v(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &block);
    const char *renderer = (const char *)glGetString(GL_RENDERER);
    if (tes_blocks < 4 || tcs_blocks < 1 || fs_blocks < 6 || max_level < CRISP_PLAN_MAX_LEVEL)
        return crisp_error(
            CRISP_ERR_GL,
            "%s: the GL backend needs storage buffers in the tessellation and fragment "
            "stages (has %d control, %d evaluation, %d fragment; needs 1, 4, 6) and "
            "GL_MAX_TESS_GEN_LEVEL >= %d (has %d)",
            renderer, tcs_blocks, tes_blocks, fs_blocks, CRISP_PLAN_MAX_LEVEL, max_level);
    crisp_gl *gl = calloc(1, sizeof *gl);
    if (!gl) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating the GL backend");
    gl->desc = d;
    snprintf(gl->renderer, sizeof gl->renderer, "%s, OpenGL %s", renderer,
             (const char *)glGetString(GL_VERSION));
    gl->max_block = (size_t)block;
    if (d.max_buffer_bytes && d.max_buffer_bytes < gl->max_block)
        gl->max_block = d.max_buffer_bytes;
    /* Leaves and ribbons are read by index within one draw: a plan with more than one storage
     * block's worth is drawn in chunks, each bound as a range at an aligned offset. */
    GLint align = 0;
    glGetIntegerv(GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT, &align);
    if (align < 1) align = 1;
    size_t unit_l = (size_t)align, unit_q = (size_t)align;
    while (unit_l % sizeof(crisp_plan_leaf))
        unit_l += (size_t)align;
    while (unit_q % (4 * sizeof(crisp_plan_ribbon_vertex)))
        unit_q += (size_t)align;
    size_t unit_s = (size_t)align;
    while (unit_s % sizeof(crisp_plan_splat))
        unit_s += (size_t)align;
    gl->chunk_splats = gl->max_block / unit_s * (unit_s / sizeof(crisp_plan_splat));
    if (gl->chunk_splats > (1u << 30)) gl->chunk_splats = 1u << 30;
    gl->chunk_leaves = gl->max_block / unit_l * (unit_l / sizeof(crisp_plan_leaf));
    gl->chunk_quads = gl->max_block / unit_q * (unit_q / (4 * sizeof(crisp_plan_ribbon_vertex)));
    if (gl->chunk_leaves > (1u << 30)) gl->chunk_leaves = 1u << 30;
    if (gl->chunk_quads > (1u << 26)) gl->chunk_quads = 1u << 26;
    crisp_status st = CRISP_OK;
    gl->surface = program("surface", crisp__shader_surface_vs_glsl, crisp__shader_surface_tcs_glsl,
                          crisp__shader_surface_tes_glsl, crisp__shader_surface_fs_glsl, NULL, &st);
    if (!st)
        gl->ribbon = program("ribbon", crisp__shader_ribbon_vs_glsl, NULL, NULL,
                             crisp__shader_ribbon_fs_glsl, NULL, &st);
    if (!st)
        gl->slack = program("slack", crisp__shader_fullscreen_vs_glsl, NULL, NULL,
                            crisp__shader_slack_fs_glsl, NULL, &st);
    if (!st) gl->accum = program("accum", NULL, NULL, NULL, NULL, crisp__shader_accum_cs_glsl, &st);
    if (!st)
        gl->finish = program("finish", NULL, NULL, NULL, NULL, crisp__shader_finish_cs_glsl, &st);
    if (!st)
        gl->layout = program("layout", NULL, NULL, NULL, NULL, crisp__shader_layout_cs_glsl, &st);
    if (!st)
        gl->splat = program("splat", crisp__shader_splat_vs_glsl, NULL, NULL,
                            crisp__shader_splat_fs_glsl, NULL, &st);
    if (st) {
        crisp_gl_destroy(gl);
        return st;
    }
    locate(gl->surface, &gl->u_surface);
    locate(gl->ribbon, &gl->u_ribbon);
    locate(gl->slack, &gl->u_slack);
    locate(gl->accum, &gl->u_accum);
    locate(gl->finish, &gl->u_finish);
    locate(gl->layout, &gl->u_layout);
    locate(gl->splat, &gl->u_splat);
    GLfloat point_range[2] = {1, 1};
    glGetFloatv(GL_POINT_SIZE_RANGE, point_range);
    gl->max_point = point_range[1];
    glGetIntegerv(GL_MAX_VIEWPORT_DIMS, gl->max_viewport);
    glCreateVertexArrays(1, &gl->vao);
    glCreateBuffers(B_COUNT, gl->buf);
    glCreateFramebuffers(1, &gl->fbo_pass);
    glCreateFramebuffers(1, &gl->fbo_slack);
    glCreateFramebuffers(1, &gl->fbo_out);
    if ((st = gl_check("creating the GL backend's objects"))) {
        crisp_gl_destroy(gl);
        return st;
    }
    *dest = gl;
    return CRISP_OK;
}

static void free_targets(crisp_gl *gl)
{
    GLuint t[] = {gl->t_nw,  gl->t_uv,      gl->t_face,    gl->t_depth,    gl->t_slack,
                  gl->t_acc, gl->t_best_nw, gl->t_best_uv, gl->t_best_face};
    glDeleteTextures((GLsizei)(sizeof t / sizeof *t), t);
    gl->t_nw = gl->t_uv = gl->t_face = gl->t_depth = gl->t_slack = 0;
    gl->t_acc = gl->t_best_nw = gl->t_best_uv = gl->t_best_face = 0;
    gl->width = gl->height = 0;
}

void crisp_gl_destroy(crisp_gl *gl)
{
    if (!gl) return;
    GLuint progs[] = {gl->surface, gl->ribbon, gl->slack, gl->accum,
                      gl->finish,  gl->layout, gl->splat};
    for (size_t k = 0; k < sizeof progs / sizeof *progs; k++)
        if (progs[k]) glDeleteProgram(progs[k]);
    if (gl->vao) {
        glDeleteVertexArrays(1, &gl->vao);
        glDeleteBuffers(B_COUNT, gl->buf);
        glDeleteFramebuffers(1, &gl->fbo_pass);
        glDeleteFramebuffers(1, &gl->fbo_slack);
        glDeleteFramebuffers(1, &gl->fbo_out);
        free_targets(gl);
    }
    if (gl->t_sample_faces) glDeleteTextures(1, &gl->t_sample_faces);
    free(gl->tmp);
    free(gl->splat_first);
    free(gl->splat_n);
    free(gl->splat_batch);
    free(gl->runs);
    free(gl);
}

const char *crisp_gl_renderer(const crisp_gl *gl)
{
    return gl->renderer;
}

/* ---- buffers ----------------------------------------------------------------------------------
 */

static crisp_status upload(crisp_gl *gl, int b, const void *data, size_t bytes, uint64_t *counter)
{
    int streamed = b == B_LEAVES || b == B_RIBBONS || b == B_SPLATS; /* drawn in chunks */
    if (bytes > gl->max_block &&
        !(streamed && gl->chunk_leaves && gl->chunk_quads && gl->chunk_splats))
        return crisp_error(
            CRISP_ERR_LIMIT,
            "the %s need %zu bytes, more than the GL storage buffer limit of %zu bytes "
            "(GL_MAX_SHADER_STORAGE_BLOCK_SIZE%s): the frame is not drawn",
            buffer_names[b], bytes, gl->max_block,
            gl->desc.max_buffer_bytes ? " or crisp_gl_desc.max_buffer_bytes" : "");
    size_t need = bytes ? bytes : 16;
    if (gl->buf_cap[b] < need) {
        size_t cap = need + need / 4;
        if (cap > gl->max_block && !streamed) cap = need;
        glNamedBufferData(gl->buf[b], (GLsizeiptr)cap, NULL, GL_DYNAMIC_DRAW);
        crisp_status st = gl_check("allocating a storage buffer");
        if (st) {
            gl->buf_cap[b] = 0;
            return crisp_error(CRISP_ERR_GL, "the %s (%zu bytes) do not fit in GPU memory",
                               buffer_names[b], bytes);
        }
        gl->buf_cap[b] = cap;
    }
    if (bytes && data) glNamedBufferSubData(gl->buf[b], 0, (GLsizeiptr)bytes, data);
    if (counter) *counter += bytes;
    return CRISP_OK;
}

crisp_status crisp_gl_set_scene_data(crisp_gl *gl, const crisp_gl_scene_data *d)
{
    gl->have_scene = 0;
    gl->scene = NULL;
    for (uint32_t p = 0; p < d->patch_count; p++) {
        const crisp_scene_patch_record *r = &d->patch_records[p];
        if (r->du < 1 || r->du > 15 || r->dv < 1 || r->dv > 15 || r->face >= d->face_count ||
            r->first_cp > d->control_point_count ||
            (size_t)(r->du + 1) * (r->dv + 1) > d->control_point_count - r->first_cp)
            return crisp_error(
                CRISP_ERR_INVALID_ARG,
                "patch record %u: degrees %ux%u, face %u, control points from %u: expected "
                "degrees 1..15, a face below %u and points within the %zu given",
                p, r->du, r->dv, r->face, r->first_cp, d->face_count, d->control_point_count);
    }
    uint64_t bytes = 0;
    crisp_status st =
        upload(gl, B_CPS, d->control_points, d->control_point_count * 4 * sizeof(double), &bytes);
    if (!st)
        st = upload(gl, B_PATCHES, d->patch_records, d->patch_count * sizeof *d->patch_records,
                    &bytes);
    if (!st) st = upload(gl, B_COLORS, d->face_colors, d->face_count * 4 * sizeof(float), &bytes);
    if (st) return st;
    gl->scene_patches = d->patch_count;
    gl->scene_faces = d->face_count;
    gl->scene_bytes = bytes;
    gl->have_scene = 1;
    gl->plan = NULL; /* leaves are checked against the new scene */
    return CRISP_OK;
}

void crisp_gl_forget_plan(crisp_gl *gl)
{
    gl->plan = NULL;
}

void crisp__gl_scene_is(crisp_gl *gl, const crisp_scene *scene)
{
    gl->scene = scene;
}

const crisp_scene *crisp__gl_scene(const crisp_gl *gl)
{
    return gl->have_scene ? gl->scene : NULL;
}

/* Uploads the arrays of the plan that changed; checks the leaves and ribbons against the scene
 * (an index out of range would read outside a buffer on the GPU). */
static crisp_status upload_plan(crisp_gl *gl, const crisp_frame_plan *p, uint64_t *bytes)
{
    if (!gl->have_scene) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_gl_draw: no scene set");
    if (p->face_count != gl->scene_faces)
        return crisp_error(CRISP_ERR_INVALID_ARG, "the plan has %u faces, the scene %u",
                           p->face_count, gl->scene_faces);
    int all = gl->plan != p;
    crisp_status st = CRISP_OK;
    if (all || p->leaves_version != gl->v_leaves) {
        for (uint32_t k = 0; k < p->leaf_count; k++) {
            const crisp_plan_leaf *L = &p->leaves[k];
            if (L->patch >= gl->scene_patches || L->face >= p->face_count ||
                L->depth > CRISP_PLAN_MAX_DEPTH || L->tau < 1 || L->tau > CRISP_PLAN_MAX_LEVEL)
                return crisp_error(
                    CRISP_ERR_INVALID_ARG,
                    "plan leaf %u: patch %u, face %u, depth %u, level %u: expected a patch "
                    "below %u, a face below %u, depth <= %d, level 1..%d",
                    k, L->patch, L->face, L->depth, L->tau, gl->scene_patches, p->face_count,
                    CRISP_PLAN_MAX_DEPTH, CRISP_PLAN_MAX_LEVEL);
            for (int e = 0; e < 4; e++)
                if (L->edge[e] < 1 || L->edge[e] > CRISP_PLAN_MAX_LEVEL)
                    return crisp_error(
                        CRISP_ERR_INVALID_ARG,
                        "plan leaf %u: edge level %u: expected 1..%d (the plan splits "
                        "leaves instead of exceeding GL_MAX_TESS_GEN_LEVEL)",
                        k, L->edge[e], CRISP_PLAN_MAX_LEVEL);
        }
        st = upload(gl, B_LEAVES, p->leaves, (size_t)p->leaf_count * sizeof *p->leaves, bytes);
    }
    if (!st && (all || p->faces_version != gl->v_faces))
        st = upload(gl, B_FACES, p->faces, (size_t)p->face_count * sizeof *p->faces, bytes);
    if (!st && (all || p->table_version != gl->v_table)) {
        st = upload(gl, B_STRIPS, p->strips, (size_t)p->strip_count * sizeof *p->strips, bytes);
        if (!st)
            st = upload(gl, B_ROWS, p->row_offset, ((size_t)p->row_count + 1) * sizeof(uint32_t),
                        bytes);
        if (!st)
            st = upload(gl, B_CROSSINGS, p->crossings, (size_t)p->crossing_count * sizeof(double),
                        bytes);
    }
    if (!st && (all || p->ribbons_version != gl->v_ribbons)) {
        for (uint64_t k = 0; k < 4 * (uint64_t)p->ribbon_quad_count; k++)
            if (p->ribbon_vertices[k].face >= p->face_count)
                return crisp_error(CRISP_ERR_INVALID_ARG, "plan ribbon vertex %llu: face %u of %u",
                                   (unsigned long long)k, p->ribbon_vertices[k].face,
                                   p->face_count);
        st = upload(gl, B_RIBBONS, p->ribbon_vertices,
                    4 * (size_t)p->ribbon_quad_count * sizeof *p->ribbon_vertices, bytes);
    }
    /* The splat store: the planner's every face set built so far, uploaded whole when it changed
     * (grown or rebuilt). The planner appends sets as faces first need them, so on a real GPU an
     * app would upload only the store's new tail (a persistently mapped buffer grown by
     * doubling, glNamedBufferSubData of [old count, count)) and the whole store only when a set
     * was rebuilt; the plan's single version does not tell the two apart yet. */
    if (!st && (all || p->splats_version != gl->v_splats)) {
        st = upload(gl, B_SPLATS, p->splats, (size_t)p->splat_count * sizeof *p->splats, bytes);
    }
    if (st) {
        gl->plan = NULL;
        return st;
    }
    gl->plan = p;
    gl->v_leaves = p->leaves_version;
    gl->v_faces = p->faces_version;
    gl->v_table = p->table_version;
    gl->v_ribbons = p->ribbons_version;
    gl->v_splats = p->splats_version;
    for (int b = 0; b < B_QUERIES; b++)
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, (GLuint)b, gl->buf[b]);
    return gl_check("uploading the plan");
}

/* Appends a run of splats to the frame's list; a new batch when its chunk differs from the last
 * run's. */
static int add_piece(crisp_gl *gl, size_t chunk, uint32_t first, uint32_t count)
{
    if (gl->splat_pieces == gl->splat_cap) {
        size_t cap = gl->splat_cap ? 2 * gl->splat_cap : 1024;
        GLint *f = realloc(gl->splat_first, cap * sizeof *f);
        if (f) gl->splat_first = f;
        GLsizei *n = realloc(gl->splat_n, cap * sizeof *n);
        if (n) gl->splat_n = n;
        if (!f || !n) return 0;
        gl->splat_cap = cap;
    }
    if (!gl->splat_batches || gl->splat_batch[gl->splat_batches - 1].chunk != chunk) {
        if (gl->splat_batches == gl->batch_cap) {
            size_t cap = gl->batch_cap ? 2 * gl->batch_cap : 16;
            struct splat_batch *b = realloc(gl->splat_batch, cap * sizeof *b);
            if (!b) return 0;
            gl->splat_batch = b;
            gl->batch_cap = cap;
        }
        gl->splat_batch[gl->splat_batches++] = (struct splat_batch){chunk, gl->splat_pieces, 0};
    }
    gl->splat_batch[gl->splat_batches - 1].pieces++;
    gl->splat_first[gl->splat_pieces] = (GLint)first;
    gl->splat_n[gl->splat_pieces++] = (GLsizei)count;
    gl->splats_drawn += count;
    return 1;
}

static int by_first(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

/* The frame's splat ranges as glMultiDrawArrays' firsts and counts, checked against the store,
 * in the plan's order (equal depths keep the first drawn); a range across a chunk boundary of the
 * store (a store above the storage block limit is bound a chunk at a time) is split there. The
 * faces' clip origins are uploaded (per frame: they move with the camera). */
static crisp_status prepare_splats(crisp_gl *gl, const crisp_frame_plan *p, uint64_t *bytes)
{
    gl->splat_pieces = gl->splat_batches = 0;
    gl->splats_drawn = 0;
    if (!p->splat_range_count) return CRISP_OK;
    if (!p->splat_clip_origin || !p->splats)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "the plan has %u splat ranges but no splat store or clip origins",
                           p->splat_range_count);
    double h = p->splat_half_px;
    if (!(h > 0) || !(2 * h + CRISP__GL_SPLAT_MARGIN <= gl->max_point))
        return crisp_error(CRISP_ERR_LIMIT,
                           "splat half-size %g px: the GL backend draws splats of 0..%g px (half "
                           "of GL_POINT_SIZE_RANGE's largest, less a margin)",
                           h, 0.5 * (gl->max_point - CRISP__GL_SPLAT_MARGIN));
    crisp_status gs = crisp_grow((void **)&gl->runs, &gl->runs_cap,
                                 2 * (size_t)p->splat_range_count, sizeof *gl->runs);
    if (gs) return gs;
    size_t chunk = gl->chunk_splats;
    for (uint32_t k = 0; k < p->splat_range_count; k++) {
        crisp_plan_splat_range r = p->splat_ranges[k];
        if ((uint64_t)r.first + r.count > p->splat_count || (uint64_t)r.first + r.count > INT32_MAX)
            return crisp_error(CRISP_ERR_INVALID_ARG,
                               "plan splat range %u: splats %u + %u, the store holds %u", k,
                               r.first, r.count, p->splat_count);
        if (r.face >= p->face_count)
            return crisp_error(CRISP_ERR_INVALID_ARG, "plan splat range %u: face %u of %u", k,
                               r.face, p->face_count);
        gl->runs[2 * k] = r.first, gl->runs[2 * k + 1] = r.face;
        while (r.count) {
            size_t c = r.first / chunk;
            uint32_t n = (uint32_t)((c + 1) * chunk - r.first < r.count ? (c + 1) * chunk - r.first
                                                                        : r.count);
            if (!add_piece(gl, c, r.first, n))
                return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory drawing %u splat ranges",
                                   p->splat_range_count);
            r.first += n;
            r.count -= n;
        }
    }
    /* The vertex stage finds a splat's face by its index: the run holding it (binary search). */
    qsort(gl->runs, p->splat_range_count, 2 * sizeof *gl->runs, by_first);
    crisp_status st = upload(gl, B_SPLAT_RUNS, gl->runs,
                             (size_t)p->splat_range_count * 2 * sizeof *gl->runs, bytes);
    if (st) return st;
    return upload(gl, B_SPLAT_ORIGINS, p->splat_clip_origin,
                  (size_t)p->face_count * 4 * sizeof(float), bytes);
}

/* ---- targets ----------------------------------------------------------------------------------
 */

static GLuint texture(GLenum format, int w, int h)
{
    GLuint t;
    glCreateTextures(GL_TEXTURE_2D, 1, &t);
    glTextureStorage2D(t, 1, format, w, h);
    glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    return t;
}

static crisp_status ensure_targets(crisp_gl *gl, int w, int h)
{
    if (gl->width == w && gl->height == h) return CRISP_OK;
    GLint max_size = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
    if (w < 1 || h < 1 || w > max_size || h > max_size)
        return crisp_error(CRISP_ERR_LIMIT,
                           "image %dx%d: the GL backend draws 1..%d pixels per side "
                           "(GL_MAX_TEXTURE_SIZE)",
                           w, h, max_size);
    if ((uint64_t)w * (uint64_t)h * 16 > INT32_MAX)
        return crisp_error(CRISP_ERR_LIMIT,
                           "image %dx%d: the GL backend reads back at most %d pixels (16 bytes "
                           "each in one call)",
                           w, h, INT32_MAX / 16);
    free_targets(gl);
    gl->t_nw = texture(GL_RGBA32F, w, h);
    gl->t_uv = texture(GL_RG32F, w, h);
    gl->t_face = texture(GL_R32I, w, h);
    gl->t_depth = texture(GL_DEPTH_COMPONENT32F, w, h);
    gl->t_slack = texture(GL_R32F, w, h);
    gl->t_acc = texture(GL_RGBA32F, w, h);
    gl->t_best_nw = texture(GL_RGBA32F, w, h);
    gl->t_best_uv = texture(GL_RG32F, w, h);
    gl->t_best_face = texture(GL_R32I, w, h);
    glNamedFramebufferTexture(gl->fbo_pass, GL_COLOR_ATTACHMENT0, gl->t_nw, 0);
    glNamedFramebufferTexture(gl->fbo_pass, GL_COLOR_ATTACHMENT1, gl->t_uv, 0);
    glNamedFramebufferTexture(gl->fbo_pass, GL_COLOR_ATTACHMENT2, gl->t_face, 0);
    glNamedFramebufferTexture(gl->fbo_pass, GL_DEPTH_ATTACHMENT, gl->t_depth, 0);
    static const GLenum bufs[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1,
                                   GL_COLOR_ATTACHMENT2};
    glNamedFramebufferDrawBuffers(gl->fbo_pass, 3, bufs);
    glNamedFramebufferTexture(gl->fbo_slack, GL_COLOR_ATTACHMENT0, gl->t_slack, 0);
    glNamedFramebufferDrawBuffer(gl->fbo_slack, GL_COLOR_ATTACHMENT0);
    glNamedFramebufferTexture(gl->fbo_out, GL_COLOR_ATTACHMENT0, gl->t_acc, 0);
    glNamedFramebufferReadBuffer(gl->fbo_out, GL_COLOR_ATTACHMENT0);
    crisp_status st = gl_check("creating the image targets");
    GLuint fbos[3] = {gl->fbo_pass, gl->fbo_slack, gl->fbo_out};
    for (int k = 0; !st && k < 3; k++) {
        GLenum s = glCheckNamedFramebufferStatus(fbos[k], GL_FRAMEBUFFER);
        if (s != GL_FRAMEBUFFER_COMPLETE)
            st = crisp_error(CRISP_ERR_GL, "GL framebuffer %d of %dx%d incomplete (status 0x%x)", k,
                             w, h, (unsigned)s);
    }
    if (st) {
        free_targets(gl);
        return st;
    }
    gl->width = w;
    gl->height = h;
    return CRISP_OK;
}

/* ---- drawing ----------------------------------------------------------------------------------
 */

/* The near plane's camera depth from a perspective view-projection (clip z = A z_eye + B, clip
 * w = -z_eye): 0 when the matrix is not one. */
static double near_depth(const crisp_frame_plan *p)
{
    const double(*m)[4] = (const double(*)[4])p->view_proj;
    int c = 0;
    for (int k = 1; k < 3; k++)
        if (fabs(m[k][3]) > fabs(m[c][3])) c = k;
    if (!(fabs(m[c][3]) > 0)) return 0;
    double A = -m[c][2] / m[c][3], B = m[3][2] + A * m[3][3];
    double n = B / (A - 1);
    return isfinite(n) && n > 0 ? n : 0;
}

/* View directions (unnormalised) at image points: d(x, y) = dir0 + x dir_x + y dir_y. */
static crisp_status view_dirs(const crisp_frame_plan *p, double dir0[3], double dir_x[3],
                              double dir_y[3])
{
    crisp_mat4 m, inv;
    memcpy(m, p->view_proj, sizeof m);
    if (!crisp_mat4_inverse(m, inv))
        return crisp_error(CRISP_ERR_NUMERIC, "the plan's view-projection matrix is singular");
    double pts[3][2] = {{0, 0}, {1, 0}, {0, 1}}, d[3][3];
    for (int k = 0; k < 3; k++) {
        double ndc[4] = {2 * pts[k][0] / p->width - 1, 1 - 2 * pts[k][1] / p->height, 0, 1}, w[4];
        crisp_mat4_mulv(inv, ndc, w);
        for (int a = 0; a < 3; a++)
            d[k][a] = w[a] / w[3] - p->eye[a];
    }
    for (int a = 0; a < 3; a++) {
        dir0[a] = d[0][a];
        dir_x[a] = d[1][a] - d[0][a];
        dir_y[a] = d[2][a] - d[0][a];
    }
    return CRISP_OK;
}

crisp_status crisp_gl_draw(crisp_gl *gl, const crisp_frame_plan *p, crisp_gl_stats *stats)
{
    crisp_gl_stats local;
    if (!stats) stats = &local;
    memset(stats, 0, sizeof *stats);
    gl->drawn = 0;
    double t0 = crisp_time_now();
    double zn = near_depth(p);
    if (!(zn > 0))
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "the plan's view-projection is not a perspective projection "
                           "with a near plane in front of the eye");
    double dir0[3], dir_x[3], dir_y[3];
    crisp_status st = view_dirs(p, dir0, dir_x, dir_y);
    if (!st) st = ensure_targets(gl, p->width, p->height);
    if (!st) st = upload_plan(gl, p, &stats->bytes_uploaded);
    if (!st) st = prepare_splats(gl, p, &stats->bytes_uploaded);
    size_t splat_draws = gl->splat_pieces;
    if (st) return st;
    double t1 = crisp_time_now();
    int W = p->width, H = p->height, S = gl->desc.samples;
    float zconst = (float)(0.5 * zn);
    float inf = INFINITY;
    float zero4[4] = {0, 0, 0, 0}, best_init[4] = {0, 0, 0, inf};
    int none = -1;
    glClearTexImage(gl->t_acc, 0, GL_RGBA, GL_FLOAT, zero4);
    glClearTexImage(gl->t_best_nw, 0, GL_RGBA, GL_FLOAT, best_init);
    glClearTexImage(gl->t_best_uv, 0, GL_RG, GL_FLOAT, zero4);
    glClearTexImage(gl->t_best_face, 0, GL_RED_INTEGER, GL_INT, &none);

    glBindVertexArray(gl->vao);
    glViewport(0, 0, W, H);
    glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glDisable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_MULTISAMPLE);
    glEnable(GL_CLIP_DISTANCE0);
    glEnable(GL_CLIP_DISTANCE1);
    glEnable(GL_CLIP_DISTANCE2);
    glPatchParameteri(GL_PATCH_VERTICES, 1);
    double vp[16];
    memcpy(vp, p->view_proj, sizeof vp);
    glProgramUniformMatrix4dv(gl->surface, gl->u_surface.view_proj, 1, GL_FALSE, vp);
    /* The clip plane (crisp_gl_desc.clip_plane): world space for the surfaces; for the ribbons
     * (clip-space vertices) the same plane through the inverse view-projection. */
    const double *cpl = gl->desc.clip_plane;
    double cplc[4] = {0, 0, 0, 0};
    crisp_mat4 inv;
    if ((cpl[0] != 0 || cpl[1] != 0 || cpl[2] != 0) &&
        crisp_mat4_inverse(*(crisp_mat4 *)&p->view_proj, inv))
        for (int c = 0; c < 4; c++)
            for (int k = 0; k < 4; k++)
                cplc[c] += cpl[k] * inv[c][k]; /* plane . (inv c), m[col][row] */
    glProgramUniform4dv(gl->surface, gl->u_surface.clip_plane, 1, cpl);
    glProgramUniform4dv(gl->ribbon, gl->u_ribbon.clip_plane, 1, cplc);
    glProgramUniform1ui(gl->surface, gl->u_surface.leaf_base, 0);
    glProgramUniform1f(gl->surface, gl->u_surface.zconst, zconst);
    glProgramUniform1f(gl->ribbon, gl->u_ribbon.zconst, zconst);
    glProgramUniform1i(gl->ribbon, gl->u_ribbon.slack_tex, 2);
    glProgramUniform2d(gl->ribbon, gl->u_ribbon.image_size, W, H);
    glProgramUniform1f(gl->ribbon, gl->u_ribbon.slack_scale, (float)CRISP__RIBBON_SLACK);
    glProgramUniform1f(gl->ribbon, gl->u_ribbon.core_scale, (float)CRISP__RIBBON_CORE_SLACK);
    glProgramUniform1i(gl->slack, gl->u_slack.nw_tex, 0);
    glProgramUniform1i(gl->slack, gl->u_slack.face_tex, 1);
    glProgramUniform3dv(gl->slack, gl->u_slack.dir0, 1, dir0);
    glProgramUniform3dv(gl->slack, gl->u_slack.dir_x, 1, dir_x);
    glProgramUniform3dv(gl->slack, gl->u_slack.dir_y, 1, dir_y);
    glProgramUniform1i(gl->accum, gl->u_accum.nw_tex, 0);
    glProgramUniform1i(gl->accum, gl->u_accum.uv_tex, 3);
    glProgramUniform1i(gl->accum, gl->u_accum.face_tex, 1);
    glProgramUniform3dv(gl->accum, gl->u_accum.dir0, 1, dir0);
    glProgramUniform3dv(gl->accum, gl->u_accum.dir_x, 1, dir_x);
    glProgramUniform3dv(gl->accum, gl->u_accum.dir_y, 1, dir_y);
    glProgramUniform1f(gl->finish, gl->u_finish.samples, (float)S);
    /* Splats: points in a viewport grown by a margin of more than the half-size on each side (a
     * point whose centre is outside the viewport is clipped away whole, but its square may
     * still cover the image's border). The viewport's size is limited (GL_MAX_VIEWPORT_DIMS):
     * on an image within P px of that limit the margin shrinks, and a splat centred outside the
     * image by more than the shrunk margin is lost (not the case below 16384 - 2 P px on
     * llvmpipe). */
    int margin = 0;
    if (splat_draws) {
        double h = p->splat_half_px;
        margin = (int)ceil(h + CRISP__GL_SPLAT_MARGIN) + 1;
        if (W + 2 * margin > gl->max_viewport[0]) margin = (gl->max_viewport[0] - W) / 2;
        if (H + 2 * margin > gl->max_viewport[1]) margin = (gl->max_viewport[1] - H) / 2;
        if (margin < 0) margin = 0;
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, B_SPLAT_ORIGINS, gl->buf[B_SPLAT_ORIGINS]);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, B_SPLAT_RUNS, gl->buf[B_SPLAT_RUNS]);
        glProgramUniform1ui(gl->splat, gl->u_splat.run_count, p->splat_range_count);
        glProgramUniformMatrix4fv(gl->splat, gl->u_splat.view_proj_f, 1, GL_FALSE, p->view_proj_f);
        glProgramUniform2d(gl->splat, gl->u_splat.image_size, W, H);
        glProgramUniform4d(gl->splat, gl->u_splat.view, -margin, -margin, W + 2 * margin,
                           H + 2 * margin);
        glProgramUniform1f(gl->splat, gl->u_splat.point_size,
                           (float)(2 * h + (gl->splat_raw ? 0 : CRISP__GL_SPLAT_MARGIN)));
        glProgramUniform1d(gl->splat, gl->u_splat.half_px, h);
        glProgramUniform1i(gl->splat, gl->u_splat.raw, gl->splat_raw);
        glProgramUniform1f(gl->splat, gl->u_splat.zconst, zconst);
        glProgramUniform4dv(gl->splat, gl->u_splat.clip_plane, 1, cplc);
    }
    glBindTextureUnit(0, gl->t_nw);
    glBindTextureUnit(1, gl->t_face);
    glBindTextureUnit(2, gl->t_slack);
    glBindTextureUnit(3, gl->t_uv);
    glBindImageTexture(0, gl->t_acc, 0, GL_FALSE, 0, GL_READ_WRITE, GL_RGBA32F);
    glBindImageTexture(1, gl->t_best_nw, 0, GL_FALSE, 0, GL_READ_WRITE, GL_RGBA32F);
    glBindImageTexture(2, gl->t_best_uv, 0, GL_FALSE, 0, GL_READ_WRITE, GL_RG32F);
    glBindImageTexture(3, gl->t_best_face, 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32I);
    glProgramUniform1i(gl->accum, gl->u_accum.keep_samples, gl->keep_samples);
    if (gl->keep_samples) {
        if (gl->sample_w != W || gl->sample_h != H) {
            if (gl->t_sample_faces) glDeleteTextures(1, &gl->t_sample_faces);
            glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &gl->t_sample_faces);
            glTextureStorage3D(gl->t_sample_faces, 1, GL_R32I, W, H, S);
            gl->sample_w = W;
            gl->sample_h = H;
        }
        glBindImageTexture(4, gl->t_sample_faces, 0, GL_TRUE, 0, GL_WRITE_ONLY, GL_R32I);
    }
    GLuint gx = (GLuint)(W + 7) / 8, gy = (GLuint)(H + 7) / 8;
    float nw_clear[4] = {0, 0, 0, inf}, depth_clear = 0;
    for (int s = 0; s < S; s++) {
        double off[2];
        crisp__raster_sample_offset(S, s, off); /* the CPU backend's positions */
        /* The sample at (i + off) lands on the pass's pixel centre (i + 0.5). */
        double jitter[2] = {2 * (0.5 - off[0]) / W, 2 * (0.5 - off[1]) / H};
        glProgramUniform2dv(gl->surface, gl->u_surface.jitter, 1, jitter);
        glProgramUniform2dv(gl->ribbon, gl->u_ribbon.jitter, 1, jitter);
        glProgramUniform2dv(gl->accum, gl->u_accum.offset, 1, off);
        glProgramUniform2dv(gl->splat, gl->u_splat.offset, 1, off);
        glProgramUniform1i(gl->accum, gl->u_accum.sample_index, s);

        glBindFramebuffer(GL_FRAMEBUFFER, gl->fbo_pass);
        glClearNamedFramebufferfv(gl->fbo_pass, GL_COLOR, 0, nw_clear);
        glClearNamedFramebufferfv(gl->fbo_pass, GL_COLOR, 1, zero4);
        glClearNamedFramebufferiv(gl->fbo_pass, GL_COLOR, 2, &none);
        glDepthMask(GL_TRUE);
        glClearNamedFramebufferfv(gl->fbo_pass, GL_DEPTH, 0, &depth_clear);
        glEnable(GL_DEPTH_TEST);
        glDepthFunc(GL_GREATER); /* nearer wins; equal depth keeps the earlier leaf */
        double ts0 = gl->desc.profile ? crisp_time_now() : 0;
        if (p->leaf_count) {
            glUseProgram(gl->surface);
            for (size_t first = 0; first < p->leaf_count; first += gl->chunk_leaves) {
                size_t n = p->leaf_count - first < gl->chunk_leaves ? p->leaf_count - first
                                                                    : gl->chunk_leaves;
                glBindBufferRange(GL_SHADER_STORAGE_BUFFER, B_LEAVES, gl->buf[B_LEAVES],
                                  (GLintptr)(first * sizeof(crisp_plan_leaf)),
                                  (GLsizeiptr)(n * sizeof(crisp_plan_leaf)));
                glDrawArrays(GL_PATCHES, 0, (GLsizei)n);
            }
        }
        double ts1 = 0;
        if (gl->desc.profile) {
            glFinish();
            ts1 = crisp_time_now();
            stats->ms_surfaces += 1e3 * (ts1 - ts0);
        }
        if (splat_draws) {
            /* Every range in one call: gl_VertexID runs over first .. first + count - 1 of each,
             * the splats' indices in the store. Drawn after the surfaces under the same depth
             * test (nearer wins, equal depth keeps what was drawn first). */
            glViewport(-margin, -margin, W + 2 * margin, H + 2 * margin);
            glEnable(GL_PROGRAM_POINT_SIZE);
            glUseProgram(gl->splat);
            for (size_t b = 0; b < gl->splat_batches; b++) {
                const struct splat_batch *B = &gl->splat_batch[b];
                size_t base = B->chunk * gl->chunk_splats,
                       n = p->splat_count - base < gl->chunk_splats ? p->splat_count - base
                                                                    : gl->chunk_splats;
                glBindBufferRange(GL_SHADER_STORAGE_BUFFER, B_SPLATS, gl->buf[B_SPLATS],
                                  (GLintptr)(base * sizeof(crisp_plan_splat)),
                                  (GLsizeiptr)(n * sizeof(crisp_plan_splat)));
                glProgramUniform1ui(gl->splat, gl->u_splat.splat_base, (GLuint)base);
                glMultiDrawArrays(GL_POINTS, gl->splat_first + B->first_piece,
                                  gl->splat_n + B->first_piece, (GLsizei)B->pieces);
            }
            glDisable(GL_PROGRAM_POINT_SIZE);
            glViewport(0, 0, W, H);
            if (gl->desc.profile) {
                glFinish();
                double t = crisp_time_now();
                stats->ms_splats += 1e3 * (t - ts1);
                ts1 = t;
            }
        }
        if (p->ribbon_quad_count) {
            glBindFramebuffer(GL_FRAMEBUFFER, gl->fbo_slack);
            glDisable(GL_DEPTH_TEST);
            glUseProgram(gl->slack);
            glDrawArrays(GL_TRIANGLES, 0, 3);
            glBindFramebuffer(GL_FRAMEBUFFER, gl->fbo_pass);
            glEnable(GL_DEPTH_TEST);
            glUseProgram(gl->ribbon);
            size_t qb = 4 * sizeof(crisp_plan_ribbon_vertex);
            /* The quads, in their cores with the cores' slack too (src/render/ribbon.h), as
             * the CPU backend's fill pass. */
            for (size_t first = 0; first < p->ribbon_quad_count; first += gl->chunk_quads) {
                size_t n = p->ribbon_quad_count - first < gl->chunk_quads
                               ? p->ribbon_quad_count - first
                               : gl->chunk_quads;
                glBindBufferRange(GL_SHADER_STORAGE_BUFFER, B_RIBBONS, gl->buf[B_RIBBONS],
                                  (GLintptr)(first * qb), (GLsizeiptr)(n * qb));
                glDrawArrays(GL_TRIANGLES, 0, (GLsizei)(6 * n));
            }
        }
        double ts2 = 0;
        if (gl->desc.profile) {
            glFinish();
            ts2 = crisp_time_now();
            stats->ms_ribbons += 1e3 * (ts2 - ts1);
        }
        glUseProgram(gl->accum);
        glDispatchCompute(gx, gy, 1);
        glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
        if (gl->desc.profile) {
            glFinish();
            stats->ms_resolve += 1e3 * (crisp_time_now() - ts2);
        }
    }
    glUseProgram(gl->finish);
    glDispatchCompute(gx, gy, 1);
    glMemoryBarrier(GL_ALL_BARRIER_BITS);
    glUseProgram(0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glDisable(GL_CLIP_DISTANCE0);
    glDisable(GL_CLIP_DISTANCE1);
    glDisable(GL_CLIP_DISTANCE2);
    glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);
    glDisable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glFinish();
    if ((st = gl_check("drawing the frame"))) return st;
    double t2 = crisp_time_now();
    stats->scene_bytes = gl->scene_bytes;
    stats->leaves = p->leaf_count;
    stats->ribbon_quads = p->ribbon_quad_count;
    stats->splats = gl->splats_drawn;
    stats->passes = (uint32_t)S;
    stats->ms_upload = 1e3 * (t1 - t0);
    stats->ms_draw = 1e3 * (t2 - t1);
    gl->drawn = 1;
    return CRISP_OK;
}

crisp_status crisp_gl_read(crisp_gl *gl, crisp_image *img, crisp_gl_stats *stats)
{
    if (!gl->drawn) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_gl_read: no frame drawn");
    if (img->width != gl->width || img->height != gl->height)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image %dx%d does not match the frame's %dx%d",
                           img->width, img->height, gl->width, gl->height);
    double t0 = crisp_time_now();
    size_t n = (size_t)gl->width * gl->height;
    if (gl->tmp_cap < 4 * n) {
        float *t = realloc(gl->tmp, 4 * n * sizeof *t);
        if (!t)
            return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory reading a %dx%d frame",
                               gl->width, gl->height);
        gl->tmp = t;
        gl->tmp_cap = 4 * n;
    }
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glGetTextureImage(gl->t_acc, 0, GL_RGBA, GL_FLOAT, (GLsizei)(4 * n * sizeof(float)), img->rgba);
    glGetTextureImage(gl->t_best_nw, 0, GL_RGBA, GL_FLOAT, (GLsizei)(4 * n * sizeof(float)),
                      gl->tmp);
    glGetTextureImage(gl->t_best_uv, 0, GL_RG, GL_FLOAT, (GLsizei)(2 * n * sizeof(float)), img->uv);
    glGetTextureImage(gl->t_best_face, 0, GL_RED_INTEGER, GL_INT, (GLsizei)(n * sizeof(int32_t)),
                      img->face);
    crisp_status st = gl_check("reading the frame back");
    if (st) return st;
    for (size_t k = 0; k < n; k++) {
        memcpy(img->normal + 3 * k, gl->tmp + 4 * k, 3 * sizeof(float));
        img->depth[k] = gl->tmp[4 * k + 3];
    }
    if (stats) stats->ms_read = 1e3 * (crisp_time_now() - t0);
    return CRISP_OK;
}

void crisp_gl_set_clip_plane(crisp_gl *gl, const double plane[4])
{
    for (int k = 0; k < 4; k++)
        gl->desc.clip_plane[k] = plane ? plane[k] : 0;
}

crisp_status crisp_gl_blit(crisp_gl *gl, unsigned fbo, int x, int y, int width, int height)
{
    if (!gl->drawn) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_gl_blit: no frame drawn");
    int scaled = width != gl->width || height != gl->height;
    glBlitNamedFramebuffer(gl->fbo_out, fbo, 0, 0, gl->width, gl->height, x, y + height, x + width,
                           y, GL_COLOR_BUFFER_BIT, scaled ? GL_LINEAR : GL_NEAREST);
    return gl_check("copying the frame into the app's framebuffer");
}

unsigned crisp_gl_color_texture(const crisp_gl *gl)
{
    return gl->t_acc;
}

void crisp__gl_splat_raw(crisp_gl *gl, int raw)
{
    gl->splat_raw = raw;
}

void crisp__gl_keep_sample_faces(crisp_gl *gl)
{
    gl->keep_samples = 1;
}

crisp_status crisp__gl_sample_faces(crisp_gl *gl, int32_t *dest)
{
    if (!gl->drawn || !gl->keep_samples || !gl->t_sample_faces)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp__gl_sample_faces: no frame drawn with the samples kept");
    int S = gl->desc.samples;
    size_t n = (size_t)gl->width * gl->height, total = n * S;
    int32_t *tmp = malloc(total * sizeof *tmp);
    if (!tmp) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory reading samples");
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glGetTextureImage(gl->t_sample_faces, 0, GL_RED_INTEGER, GL_INT, (GLsizei)(total * sizeof *tmp),
                      tmp);
    for (int s = 0; s < S; s++)
        for (size_t k = 0; k < n; k++)
            dest[k * S + s] = tmp[s * n + k];
    free(tmp);
    return gl_check("reading the samples' faces");
}

crisp_status crisp__gl_blit_probe(crisp_gl *gl, uint8_t *rgba)
{
    GLuint tex, fbo;
    glCreateTextures(GL_TEXTURE_2D, 1, &tex);
    glTextureStorage2D(tex, 1, GL_RGBA8, gl->width, gl->height);
    glCreateFramebuffers(1, &fbo);
    glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, tex, 0);
    crisp_status st = crisp_gl_blit(gl, fbo, 0, 0, gl->width, gl->height);
    if (!st) {
        glPixelStorei(GL_PACK_ALIGNMENT, 1);
        glGetTextureImage(tex, 0, GL_RGBA, GL_UNSIGNED_BYTE, gl->width * gl->height * 4, rgba);
        st = gl_check("reading the blit probe");
    }
    glDeleteFramebuffers(1, &fbo);
    glDeleteTextures(1, &tex);
    return st;
}

/* ---- layout probe (tests) ---------------------------------------------------------------------
 */

crisp_status crisp__gl_layout_probe(crisp_gl *gl, const crisp_frame_plan *plan,
                                    const crisp__gl_query *q, size_t n, crisp__gl_result *out)
{
    uint64_t bytes = 0;
    crisp_status st = upload_plan(gl, plan, &bytes);
    if (!st) st = upload(gl, B_QUERIES, q, n * sizeof *q, NULL);
    if (!st) st = upload(gl, B_RESULTS, NULL, n * sizeof *out, NULL);
    if (st) return st;
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 9, gl->buf[B_QUERIES]);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 10, gl->buf[B_RESULTS]);
    glProgramUniform1ui(gl->layout, gl->u_layout.count, (GLuint)n);
    glUseProgram(gl->layout);
    glDispatchCompute((GLuint)((n + 63) / 64), 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glUseProgram(0);
    glGetNamedBufferSubData(gl->buf[B_RESULTS], 0, (GLsizeiptr)(n * sizeof *out), out);
    return gl_check("running the layout probe");
}
