/* The in-memory model: a growable list of faces (NURBS surface + trim loops), the notes of what a
 * reader skipped, the model's box and its statistics. Bézier patch and trim piece counts come
 * from counting non-empty knot spans, so computing stats extracts nothing.
 */
#include "crisp/model.h"

#include "nurbs_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

crisp_status crisp_model_create(crisp_model **dest)
{
    *dest = NULL;
    crisp_model *m = crisp_calloc_array(1, sizeof *m);
    if (!m) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory allocating a model");
    m->unit_to_mm = 1.0;
    *dest = m;
    return CRISP_OK;
}

void crisp_trim_loop_free(crisp_trim_loop *loop)
{
    if (!loop) return;
    for (int i = 0; i < loop->curve_count; i++)
        if (loop->curves) crisp_curve_destroy(loop->curves[i]);
    crisp_free(loop->curves);
    memset(loop, 0, sizeof *loop);
}

void crisp_face_free(crisp_face *face)
{
    if (!face) return;
    crisp_surface_destroy(face->surface);
    for (int i = 0; i < face->loop_count; i++)
        if (face->loops) crisp_trim_loop_free(&face->loops[i]);
    crisp_free(face->loops);
    memset(face, 0, sizeof *face);
}

crisp_status crisp_face_copy(const crisp_face *src, crisp_face *dest)
{
    crisp_face face = *src;
    face.surface = NULL;
    face.loops = NULL;
    face.loop_count = 0;
    crisp_status st = crisp_surface_copy(src->surface, &face.surface);
    if (!st && src->loop_count > 0) {
        face.loops = crisp_calloc_array((size_t)src->loop_count, sizeof *face.loops);
        if (!face.loops) st = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_face_copy: out of memory");
    }
    for (int l = 0; l < src->loop_count && !st; l++) {
        const crisp_trim_loop *a = &src->loops[l];
        crisp_trim_loop *b = &face.loops[face.loop_count++];
        b->is_outer = a->is_outer;
        if (a->curve_count == 0) continue;
        b->curves = crisp_calloc_array((size_t)a->curve_count, sizeof *b->curves);
        if (!b->curves) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_face_copy: out of memory");
            break;
        }
        for (int c = 0; c < a->curve_count && !st; c++) {
            st = crisp_curve_copy(a->curves[c], &b->curves[c]);
            if (!st) b->curve_count++;
        }
    }
    if (st) {
        crisp_face_free(&face);
        return st;
    }
    *dest = face;
    return CRISP_OK;
}

void crisp_face_transform(crisp_face *f, const double m[3][4])
{
    crisp_surface *s = f->surface;
    size_t n = (size_t)s->count_u * s->count_v;
    for (size_t i = 0; i < n; i++) {
        double *p = s->cpw + 4 * i, q[3];
        for (int a = 0; a < 3; a++)
            q[a] = m[a][0] * p[0] + m[a][1] * p[1] + m[a][2] * p[2] + m[a][3] * p[3];
        memcpy(p, q, sizeof q);
    }
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                 m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if (det < 0) f->reversed = !f->reversed;
}

void crisp_model_destroy(crisp_model *m)
{
    if (!m) return;
    for (int i = 0; i < m->face_count; i++)
        crisp_face_free(&m->faces[i]);
    crisp_free(m->faces);
    for (int i = 0; i < m->skip_count; i++)
        crisp_free(m->skips[i].what);
    crisp_free(m->skips);
    for (int i = 0; i < m->occurrence_count; i++)
        crisp_free(m->occurrences[i].name);
    crisp_free(m->occurrences);
    crisp_free(m);
}

crisp_status crisp_model_add_occurrence(crisp_model *m, const char *name, int parent, int source_id,
                                        int *index)
{
    if (parent < -1 || parent >= m->occurrence_count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "occurrence parent %d: expected -1..%d", parent,
                           m->occurrence_count - 1);
    size_t n = strlen(name ? name : "");
    char *copy = crisp_malloc_array(n + 1, 1);
    crisp_occurrence *grown =
        crisp_realloc_array(m->occurrences, (size_t)m->occurrence_count + 1, sizeof *grown);
    if (grown) m->occurrences = grown;
    if (!copy || !grown) {
        crisp_free(copy);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory adding an assembly occurrence");
    }
    memcpy(copy, name ? name : "", n + 1);
    m->occurrences[m->occurrence_count] =
        (crisp_occurrence){.name = copy, .parent = parent, .source_id = source_id};
    if (index) *index = m->occurrence_count;
    m->occurrence_count++;
    return CRISP_OK;
}

crisp_status crisp_model_add_face(crisp_model *m, crisp_face *face)
{
    if (!face->surface)
        return crisp_error(CRISP_ERR_INVALID_ARG, "face %d has no surface", face->source_id);
    if (m->face_count == m->face_cap) {
        size_t cap = (size_t)m->face_cap;
        crisp_status st =
            crisp_grow((void **)&m->faces, &cap, (size_t)m->face_count + 1, sizeof *m->faces);
        if (st) return st;
        if (cap > (size_t)INT32_MAX) cap = INT32_MAX;
        m->face_cap = (int)cap;
    }
    m->faces[m->face_count++] = *face;
    memset(face, 0, sizeof *face);
    return CRISP_OK;
}

crisp_status crisp_model_note_skip(crisp_model *m, const char *what)
{
    if (!what) what = "";
    for (int i = 0; i < m->skip_count; i++)
        if (strcmp(m->skips[i].what, what) == 0) {
            m->skips[i].count++;
            return CRISP_OK;
        }
    static const char more[] = "(further notes of other kinds not kept)";
    if (m->skip_count >= CRISP_MODEL_MAX_NOTES) {
        if (strcmp(m->skips[m->skip_count - 1].what, more)) {
            crisp_free(m->skips[m->skip_count - 1].what);
            m->skips[m->skip_count - 1].what = NULL;
            size_t n = sizeof more;
            char *t = crisp_malloc_array(n, 1);
            if (!t) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory noting a skipped item");
            memcpy(t, more, n);
            m->skips[m->skip_count - 1].what = t;
        }
        m->skips[m->skip_count - 1].count++;
        return CRISP_OK;
    }
    size_t n = strlen(what) + 1;
    char *t = crisp_malloc_array(n, 1);
    if (!t) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory noting a skipped item");
    memcpy(t, what, n);
    crisp_skip_note *s = crisp_realloc_array(m->skips, (size_t)m->skip_count + 1, sizeof *s);
    if (!s) {
        crisp_free(t);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory noting a skipped item");
    }
    m->skips = s;
    s[m->skip_count].what = t;
    s[m->skip_count].count = 1;
    m->skip_count++;
    return CRISP_OK;
}

static crisp_status note_v(crisp_model *m, const char *fmt, va_list ap)
{
    char buf[2048];
    vsnprintf(buf, sizeof buf, fmt, ap);
    return crisp_model_note_skip(m, buf);
}

crisp_status crisp_model_note_skipf(crisp_model *m, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    crisp_status st = note_v(m, fmt, ap);
    va_end(ap);
    return st;
}

crisp_status crisp_model_note_dropped(crisp_model *m, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    crisp_status st = note_v(m, fmt, ap);
    va_end(ap);
    m->faces_dropped++;
    return st;
}

void crisp_model_bbox(const crisp_model *m, double *dest)
{
    for (int d = 0; d < 3; d++) {
        dest[d] = INFINITY;
        dest[3 + d] = -INFINITY;
    }
    for (int i = 0; i < m->face_count; i++) {
        double b[6];
        crisp_surface_bbox(m->faces[i].surface, b);
        for (int d = 0; d < 3; d++) {
            if (b[d] < dest[d]) dest[d] = b[d];
            if (b[3 + d] > dest[3 + d]) dest[3 + d] = b[3 + d];
        }
    }
    if (m->face_count == 0)
        for (int d = 0; d < 6; d++)
            dest[d] = 0.0;
}

crisp_status crisp_model_stats_compute(const crisp_model *m, crisp_model_stats *dest)
{
    memset(dest, 0, sizeof *dest);
    dest->faces = m->face_count;
    for (int i = 0; i < m->face_count; i++) {
        const crisp_face *f = &m->faces[i];
        const crisp_surface *s = f->surface;
        if (!s)
            return crisp_error(CRISP_ERR_INVALID_ARG, "face %d (index %d) has no surface",
                               f->source_id, i);
        dest->bezier_patches += crisp__count_surface_spans(s->knots_u, s->degree_u, s->count_u) *
                                crisp__count_surface_spans(s->knots_v, s->degree_v, s->count_v);
        if (s->rational) dest->rational_surfaces++;
        if (s->degree_u > dest->max_degree_u) dest->max_degree_u = s->degree_u;
        if (s->degree_v > dest->max_degree_v) dest->max_degree_v = s->degree_v;
        dest->degrees_seen |= 1u << s->degree_u;
        dest->degrees_seen |= 1u << s->degree_v;
        for (int l = 0; l < f->loop_count; l++) {
            const crisp_trim_loop *loop = &f->loops[l];
            if (loop->is_outer)
                dest->outer_loops++;
            else
                dest->hole_loops++;
            for (int c = 0; c < loop->curve_count; c++) {
                const crisp_curve *cv = loop->curves[c];
                dest->trim_curves++;
                dest->trim_pieces += crisp__count_spans(cv->knots, cv->degree, cv->count);
                if (cv->degree > dest->max_trim_degree) dest->max_trim_degree = cv->degree;
            }
        }
    }
    return CRISP_OK;
}
