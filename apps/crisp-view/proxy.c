/* crisp-view's moving frames on the GPU: the motion plan (backend_cpu.c) tessellated once into a
 * world-space mesh (its leaves at their levels, crisp_tess_mesh_generate, vertices evaluated on
 * the true Bézier patches with their normals and (u, v)), kept in GL buffers with the plan's trim
 * tables, and drawn by the window's own OpenGL context for every frame while the camera moves:
 * only a matrix changes per frame, nothing is planned, tessellated or read back. The fragment
 * shader runs the plan's trim test (crisp_plan_trim_test: strip, row, binary search of the row's
 * u-crossings, in double) and the backends' headlight shading (src/render/shade.c), and writes the
 * face id beside the colour so a second pass draws the face borders, trims and silhouettes as the
 * CPU overlay does (backend_cpu.c convert; every border dark here: hard and smooth are told apart
 * in the refined frame only). With a section plane, the clip distance cuts the mesh and the back
 * faces behind the plane show the hatched cap (as section.c). (u, v) are interpolated in float, so
 * a trim edge of a moving frame may sit a fraction of a pixel off the refined one's. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/plan.h"
#include "crisp/tess.h"
#include "proxy.h"

typedef struct proxy_vertex {
    float pos[3]; /* relative to the box centre */
    float normal[3];
    float uv[2];
    uint32_t face;
} proxy_vertex;

/* std430 face record of the trim test (the plan's crisp_plan_face fields it needs): 64 bytes,
 * the vec4 at offset 48. */
typedef struct proxy_face {
    double v0, v1, strip_scale;
    uint32_t first_strip, strip_count, flags, pad[3];
    float color[4];
} proxy_face;
_Static_assert(sizeof(proxy_face) == 64, "proxy_face: the shader's std430 Face");

static const char *vs_src = "#version 450 core\n"
                            "layout(location = 0) in vec3 pos;\n"
                            "layout(location = 1) in vec3 nrm;\n"
                            "layout(location = 2) in vec2 uv;\n"
                            "layout(location = 3) in uint face;\n"
                            "uniform mat4 mvp;\n"
                            "uniform vec3 eye;\n"
                            "uniform vec4 clip_plane;\n"
                            "out vec3 n_w;\n"
                            "out vec3 view_w;\n"
                            "out vec2 uv_f;\n"
                            "flat out uint face_f;\n"
                            "void main() {\n"
                            "  gl_Position = mvp * vec4(pos, 1.0);\n"
                            "  gl_ClipDistance[0] = dot(clip_plane.xyz, pos) + clip_plane.w;\n"
                            "  n_w = nrm; view_w = pos - eye; uv_f = uv; face_f = face;\n"
                            "}\n";

static const char *fs_src =
    "#version 450 core\n"
    "struct Face { double v0, v1, strip_scale; uint first_strip, strip_count, flags, pad0;\n"
    "              uint pad1, pad2;\n"
    "              vec4 color; };\n"
    "struct Strip { double a, row_scale; uint first_row, row_count; };\n"
    "layout(std430, binding = 0) readonly buffer Faces { Face faces[]; };\n"
    "layout(std430, binding = 1) readonly buffer Strips { Strip strips[]; };\n"
    "layout(std430, binding = 2) readonly buffer Rows { uint row_offset[]; };\n"
    "layout(std430, binding = 3) readonly buffer Cross { double crossings[]; };\n"
    "in vec3 n_w;\n"
    "in vec3 view_w;\n"
    "in vec2 uv_f;\n"
    "flat in uint face_f;\n"
    "uniform uint selected;\n"
    "uniform vec4 clip_plane;\n"
    "uniform int cap;\n"
    "uniform vec3 eye;\n"
    "uniform vec3 hatch_u;\n"
    "uniform float hatch_off;\n"
    "layout(location = 0) out vec4 color;\n"
    "layout(location = 1) out int face_out;\n"
    "bool inside(uint fi, double u, double v) {\n"
    "  Face f = faces[fi];\n"
    "  if (!(v >= f.v0 && v <= f.v1)) return false;\n"
    "  if ((f.flags & 2u) != 0u) return true;\n"
    "  uint n = f.strip_count;\n"
    "  if (n == 0u) return false;\n"
    "  double fi_ = (v - f.v0) * f.strip_scale;\n"
    "  uint i = fi_ < double(n) ? uint(fi_) : n - 1u;\n"
    "  Strip s = strips[f.first_strip + i];\n"
    "  uint mu = s.row_count;\n"
    "  if (mu == 0u) return false;\n"
    "  double fj = (v - s.a) * s.row_scale;\n"
    "  uint j = fj > 0.0LF ? (fj < double(mu) ? uint(fj) : mu - 1u) : 0u;\n"
    "  uint r = s.first_row + j;\n"
    "  uint lo = row_offset[r], hi = row_offset[r + 1u], first = lo;\n"
    "  while (lo < hi) {\n"
    "    uint mid = lo + (hi - lo) / 2u;\n"
    "    if (crossings[mid] < u) lo = mid + 1u; else hi = mid;\n"
    "  }\n"
    "  return ((lo - first) & 1u) != 0u;\n"
    "}\n"
    "void main() {\n"
    "  if (!inside(face_f, double(uv_f.x), double(uv_f.y))) discard;\n"
    "  vec3 n = normalize(n_w), d = normalize(view_w);\n"
    "  float k = 0.25 + 0.75 * abs(dot(n, d));\n"
    "  vec3 c = faces[face_f].color.rgb * k;\n"
    "  if (face_f == selected) c = 0.55 * c + 0.45 * vec3(0.25, 0.55, 1.0);\n"
    "  int id = int(face_f);\n"
    "  if (cap != 0 && dot(n, d) > 0.0) {\n"
    "    // the back of a surface behind the section plane: the cut, hatched (section.c)\n"
    "    float nd = dot(clip_plane.xyz, d);\n"
    "    float t = nd != 0.0 ? -(dot(clip_plane.xyz, eye) + clip_plane.w) / nd : -1.0;\n"
    "    if (t > 0.0 && t < length(view_w)) {\n"
    "      float s = dot(hatch_u, eye + t * d) + hatch_off;\n"
    "      c = s - floor(s) < 0.18 ? vec3(0.30, 0.20, 0.12) : vec3(0.80, 0.62, 0.42);\n"
    "      id = -1000000;\n"
    "    }\n"
    "  }\n"
    "  color = vec4(c, 1.0);\n"
    "  face_out = id;\n"
    "}\n";

/* The edge pass: where the face id changes between neighbours (as backend_cpu.c convert). */
static const char *edge_vs_src = "#version 450 core\n"
                                 "void main() {\n"
                                 "  vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);\n"
                                 "  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);\n"
                                 "}\n";
static const char *edge_fs_src =
    "#version 450 core\n"
    "layout(binding = 0) uniform isampler2D faces;\n"
    "layout(location = 0) out vec4 color;\n"
    "void main() {\n"
    "  ivec2 p = ivec2(gl_FragCoord.xy), sz = textureSize(faces, 0);\n"
    "  int f = texelFetch(faces, p, 0).r;\n"
    "  int edge = 0;\n"
    "  ivec2 d[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));\n"
    "  for (int q = 0; q < 4; q++) {\n"
    "    ivec2 pp = p + d[q];\n"
    "    if (any(lessThan(pp, ivec2(0))) || any(greaterThanEqual(pp, sz))) continue;\n"
    "    int g = texelFetch(faces, pp, 0).r;\n"
    "    if (g == f) continue;\n"
    "    edge = 2;\n"
    "  }\n"
    "  if (edge == 0) discard;\n"
    "  if (f == -1) color = vec4(0.05, 0.05, 0.05, 1.0);\n"
    "  else color = vec4(0.0, 0.0, 0.0, 0.85);\n"
    "}\n";

crisp_status view_proxy_init(view_proxy *px)
{
    memset(px, 0, sizeof *px);
    char log[1024] = "";
    px->program = app_gl_program(vs_src, fs_src, log, sizeof log);
    if (px->program) px->edge_program = app_gl_program(edge_vs_src, edge_fs_src, log, sizeof log);
    if (!px->program || !px->edge_program) {
        view_proxy_free(px);
        return crisp_error(CRISP_ERR_GL, "moving-frame shaders: %s", log);
    }
    px->u_mvp = glGetUniformLocation(px->program, "mvp");
    px->u_eye = glGetUniformLocation(px->program, "eye");
    px->u_clip = glGetUniformLocation(px->program, "clip_plane");
    px->u_selected = glGetUniformLocation(px->program, "selected");
    px->u_cap = glGetUniformLocation(px->program, "cap");
    px->u_hatch_u = glGetUniformLocation(px->program, "hatch_u");
    px->u_hatch_off = glGetUniformLocation(px->program, "hatch_off");
    glCreateVertexArrays(1, &px->vao);
    glCreateVertexArrays(1, &px->edge_vao);
    return CRISP_OK;
}

void view_proxy_free(view_proxy *px)
{
    if (px->program) glDeleteProgram(px->program);
    if (px->edge_program) glDeleteProgram(px->edge_program);
    if (px->vao) glDeleteVertexArrays(1, &px->vao);
    if (px->edge_vao) glDeleteVertexArrays(1, &px->edge_vao);
    GLuint bufs[6] = {px->vbo, px->ibo, px->ssbo[0], px->ssbo[1], px->ssbo[2], px->ssbo[3]};
    for (int k = 0; k < 6; k++)
        if (bufs[k]) glDeleteBuffers(1, &bufs[k]);
    if (px->fbo) glDeleteFramebuffers(1, &px->fbo);
    if (px->depth) glDeleteRenderbuffers(1, &px->depth);
    if (px->face_tex) glDeleteTextures(1, &px->face_tex);
    memset(px, 0, sizeof *px);
}

static void upload(GLuint *buf, const void *data, size_t bytes)
{
    if (*buf) glDeleteBuffers(1, buf);
    glCreateBuffers(1, buf);
    glNamedBufferStorage(*buf, bytes ? (GLsizeiptr)bytes : 16, bytes ? data : NULL, 0);
}

crisp_status view_proxy_build(view_proxy *px, const crisp_scene *sc, const crisp_frame_plan *p,
                              const double box[6])
{
    px->index_count = 0;
    px->ready = 0;
    size_t nv = 0, nt = 0;
    int max_v = 0;
    crisp_status st;
    for (uint32_t j = 0; j < p->leaf_count; j++) {
        const crisp_plan_leaf *L = &p->leaves[j];
        crisp_tess_levels lv = {
            {(int)L->tau, (int)L->tau},
            {(int)L->edge[0], (int)L->edge[1], (int)L->edge[2], (int)L->edge[3]}};
        size_t v, t;
        if ((st = crisp_tess_mesh_counts(&lv, &v, &t))) return st;
        nv += v;
        nt += t;
        if ((int)v > max_v) max_v = (int)v;
    }
    if (nv > UINT32_MAX / 2 || nt > UINT32_MAX / 6)
        return crisp_error(CRISP_ERR_LIMIT, "moving-frame mesh: too many vertices");
    proxy_vertex *verts = malloc((nv ? nv : 1) * sizeof *verts);
    uint32_t *idx = malloc((nt ? 3 * nt : 3) * sizeof *idx);
    double *stv = malloc((size_t)(max_v ? max_v : 1) * 2 * sizeof *stv);
    proxy_face *faces = calloc(p->face_count + 1, sizeof *faces);
    if (!verts || !idx || !stv || !faces) {
        free(verts), free(idx), free(stv), free(faces);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the moving-frame mesh");
    }
    for (int k = 0; k < 3; k++)
        px->centre[k] = 0.5 * (box[k] + box[k + 3]);
    size_t vb = 0, tb = 0;
    for (uint32_t j = 0; j < p->leaf_count; j++) {
        const crisp_plan_leaf *L = &p->leaves[j];
        const crisp_bezier_patch *bez = &sc->patches[L->patch].bez;
        crisp_tess_levels lv = {
            {(int)L->tau, (int)L->tau},
            {(int)L->edge[0], (int)L->edge[1], (int)L->edge[2], (int)L->edge[3]}};
        size_t v, t;
        crisp_tess_mesh_counts(&lv, &v, &t);
        crisp_tess_mesh_generate(&lv, stv, idx + 3 * tb, (uint32_t)vb);
        double scale = ldexp(1.0, -(int)L->depth);
        int reversed = (p->faces[L->face].flags & CRISP_PLAN_FACE_REVERSED) != 0;
        for (size_t k = 0; k < v; k++) {
            double s = (L->ix + stv[2 * k]) * scale, tt = (L->iy + stv[2 * k + 1]) * scale;
            double P[3], Ps[3], Pt[3], n[3];
            crisp_bezier_patch_derivs(bez, s, tt, P, Ps, Pt);
            n[0] = Ps[1] * Pt[2] - Ps[2] * Pt[1];
            n[1] = Ps[2] * Pt[0] - Ps[0] * Pt[2];
            n[2] = Ps[0] * Pt[1] - Ps[1] * Pt[0];
            double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            double ref = sqrt((Ps[0] * Ps[0] + Ps[1] * Ps[1] + Ps[2] * Ps[2]) *
                              (Pt[0] * Pt[0] + Pt[1] * Pt[1] + Pt[2] * Pt[2]));
            if (!(nn > 1e-12 * ref)) {
                crisp_bezier_patch_normal(bez, s, tt, n);
                nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            }
            proxy_vertex *o = &verts[vb + k];
            for (int q = 0; q < 3; q++) {
                o->pos[q] = (float)(P[q] - px->centre[q]);
                o->normal[q] = (float)(nn > 0 ? (reversed ? -n[q] : n[q]) / nn : 0);
            }
            o->uv[0] = (float)(bez->u0 + s * (bez->u1 - bez->u0));
            o->uv[1] = (float)(bez->v0 + tt * (bez->v1 - bez->v0));
            o->face = L->face;
        }
        vb += v;
        tb += t;
    }
    for (uint32_t f = 0; f < p->face_count; f++) {
        const crisp_plan_face *pf = &p->faces[f];
        faces[f] = (proxy_face){.v0 = pf->v0,
                                .v1 = pf->v1,
                                .strip_scale = pf->strip_scale,
                                .first_strip = pf->first_strip,
                                .strip_count = pf->strip_count,
                                .flags = pf->flags};
        memcpy(faces[f].color, sc->faces[f].color, sizeof faces[f].color);
    }
    upload(&px->vbo, verts, nv * sizeof *verts);
    upload(&px->ibo, idx, 3 * nt * sizeof *idx);
    upload(&px->ssbo[0], faces, p->face_count * sizeof *faces);
    upload(&px->ssbo[1], p->strips, p->strip_count * sizeof *p->strips);
    upload(&px->ssbo[2], p->row_offset, (p->row_count + 1) * sizeof *p->row_offset);
    upload(&px->ssbo[3], p->crossings, p->crossing_count * sizeof *p->crossings);
    free(verts), free(idx), free(stv), free(faces);
    glVertexArrayVertexBuffer(px->vao, 0, px->vbo, 0, sizeof(proxy_vertex));
    glVertexArrayElementBuffer(px->vao, px->ibo);
    for (GLuint a = 0; a < 4; a++) {
        glEnableVertexArrayAttrib(px->vao, a);
        glVertexArrayAttribBinding(px->vao, a, 0);
    }
    glVertexArrayAttribFormat(px->vao, 0, 3, GL_FLOAT, GL_FALSE, offsetof(proxy_vertex, pos));
    glVertexArrayAttribFormat(px->vao, 1, 3, GL_FLOAT, GL_FALSE, offsetof(proxy_vertex, normal));
    glVertexArrayAttribFormat(px->vao, 2, 2, GL_FLOAT, GL_FALSE, offsetof(proxy_vertex, uv));
    glVertexArrayAttribIFormat(px->vao, 3, 1, GL_UNSIGNED_INT, offsetof(proxy_vertex, face));
    px->index_count = 3 * nt;
    px->triangles = nt;
    px->ready = 1;
    GLenum e = glGetError();
    if (e != GL_NO_ERROR) {
        px->ready = 0;
        return crisp_error(CRISP_ERR_GL, "moving-frame mesh upload: GL error 0x%x", e);
    }
    return CRISP_OK;
}

crisp_status view_proxy_draw(view_proxy *px, const crisp_camera *cam, GLuint color_tex,
                             const view_proxy_style *style)
{
    if (!px->ready) return crisp_error(CRISP_ERR_INVALID_ARG, "moving-frame mesh: none built");
    int w = cam->width, h = cam->height;
    if (!px->fbo || px->w != w || px->h != h || px->color_tex != color_tex) {
        if (px->fbo) glDeleteFramebuffers(1, &px->fbo);
        if (px->depth) glDeleteRenderbuffers(1, &px->depth);
        if (px->face_tex) glDeleteTextures(1, &px->face_tex);
        glCreateFramebuffers(1, &px->fbo);
        glCreateRenderbuffers(1, &px->depth);
        glNamedRenderbufferStorage(px->depth, GL_DEPTH_COMPONENT32F, w, h);
        glCreateTextures(GL_TEXTURE_2D, 1, &px->face_tex);
        glTextureStorage2D(px->face_tex, 1, GL_R32I, w, h);
        glTextureParameteri(px->face_tex, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTextureParameteri(px->face_tex, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        glNamedFramebufferTexture(px->fbo, GL_COLOR_ATTACHMENT0, color_tex, 0);
        glNamedFramebufferTexture(px->fbo, GL_COLOR_ATTACHMENT1, px->face_tex, 0);
        glNamedFramebufferRenderbuffer(px->fbo, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, px->depth);
        px->w = w, px->h = h, px->color_tex = color_tex;
    }
    /* The image's top row is texture row 0 (as an upload): flip y in clip space. */
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    float mvp[16], eye[3], plane[4] = {0, 0, 0, 1};
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 4; r++) {
            /* view_proj * translate(centre) */
            double v = m.view_proj[c][r];
            if (c == 3)
                v = m.view_proj[0][r] * px->centre[0] + m.view_proj[1][r] * px->centre[1] +
                    m.view_proj[2][r] * px->centre[2] + m.view_proj[3][r];
            mvp[4 * c + r] = (float)(r == 1 ? -v : v);
        }
    for (int k = 0; k < 3; k++)
        eye[k] = (float)(cam->eye[k] - px->centre[k]);
    if (style->clip) {
        /* n . (p + centre) + d = n . p + (n . centre + d) */
        for (int k = 0; k < 3; k++)
            plane[k] = (float)style->clip_plane[k];
        plane[3] =
            (float)(style->clip_plane[3] + style->clip_plane[0] * px->centre[0] +
                    style->clip_plane[1] * px->centre[1] + style->clip_plane[2] * px->centre[2]);
    }
    glNamedFramebufferTexture(px->fbo, GL_COLOR_ATTACHMENT1, px->face_tex, 0);
    glBindFramebuffer(GL_FRAMEBUFFER, px->fbo);
    GLenum bufs[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, bufs);
    glViewport(0, 0, w, h);
    glClearBufferfv(GL_COLOR, 0, (float[4]){0, 0, 0, 0});
    glClearBufferiv(GL_COLOR, 1, (GLint[4]){-1, 0, 0, 0});
    glClearBufferfv(GL_DEPTH, 0, (float[1]){1});
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    if (style->clip) glEnable(GL_CLIP_DISTANCE0);
    glUseProgram(px->program);
    glUniformMatrix4fv(px->u_mvp, 1, GL_FALSE, mvp);
    glUniform3fv(px->u_eye, 1, eye);
    glUniform4fv(px->u_clip, 1, plane);
    glUniform1i(px->u_cap, style->clip);
    glUniform3f(px->u_hatch_u, (float)style->hatch_u[0], (float)style->hatch_u[1],
                (float)style->hatch_u[2]);
    glUniform1f(px->u_hatch_off,
                (float)fmod(style->hatch_u[0] * px->centre[0] + style->hatch_u[1] * px->centre[1] +
                                style->hatch_u[2] * px->centre[2],
                            1.0));
    glUniform1ui(px->u_selected, style->selected >= 0 ? (GLuint)style->selected : 0xffffffffu);
    for (GLuint k = 0; k < 4; k++)
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, k, px->ssbo[k]);
    glBindVertexArray(px->vao);
    glDrawElements(GL_TRIANGLES, (GLsizei)px->index_count, GL_UNSIGNED_INT, NULL);
    glDisable(GL_CLIP_DISTANCE0);
    glDisable(GL_DEPTH_TEST);
    if (style->edges) {
        /* the face ids are read, not written: detached (no feedback loop) */
        glNamedFramebufferTexture(px->fbo, GL_COLOR_ATTACHMENT1, 0, 0);
        GLenum one = GL_COLOR_ATTACHMENT0;
        glDrawBuffers(1, &one);
        glEnable(GL_BLEND);
        glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE);
        glUseProgram(px->edge_program);
        glBindTextureUnit(0, px->face_tex);
        glBindVertexArray(px->edge_vao);
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glDisable(GL_BLEND);
    }
    glBindVertexArray(0);
    glUseProgram(0);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glFinish(); /* the frame's time is the GPU's time (the moving scale adapts to it) */
    GLenum e = glGetError();
    return e == GL_NO_ERROR ? CRISP_OK
                            : crisp_error(CRISP_ERR_GL, "moving frame: GL error 0x%x", e);
}
