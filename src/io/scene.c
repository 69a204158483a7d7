/* crisp scene files (format: include/crisp/scene_file.h and README.md "Scene files"): a line-based
 * text list of NURBS models and f-rep parts with transforms and colours, and the loader that
 * merges the models into one (transforms applied to the homogeneous control points) and builds
 * a tape per f-rep part. Bad input gets "file:line:column: expected ..." and never a crash. */
#include "crisp/scene_file.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/frep.h"
#include "crisp/io.h"

#define MAX_ITEMS 100000
#define MAX_TOKENS 64

typedef struct token {
    const char *s;
    size_t len;
    int col;
    int quoted;
} token;

typedef struct parser {
    const char *name;
    int line;
    token tok[MAX_TOKENS];
    int count;
} parser;

static crisp_status fail(const parser *p, int col, const char *what)
{
    return crisp_error(CRISP_ERR_PARSE, "%s:%d:%d: %s", p->name, p->line, col, what);
}

/* Split line [s, e) into tokens; '#' outside quotes ends the line. */
static crisp_status tokenize(parser *p, const char *s, const char *e)
{
    const char *line = s;
    p->count = 0;
    while (s < e) {
        while (s < e && (*s == ' ' || *s == '\t' || *s == '\r'))
            s++;
        if (s >= e || *s == '#') break;
        if (p->count == MAX_TOKENS)
            return fail(p, (int)(s - line) + 1, "expected at most 64 words on a line");
        token *t = &p->tok[p->count++];
        t->col = (int)(s - line) + 1;
        if (*s == '"') {
            const char *q = memchr(s + 1, '"', (size_t)(e - s - 1));
            if (!q) return fail(p, t->col, "expected a closing '\"'");
            t->s = s + 1, t->len = (size_t)(q - s - 1), t->quoted = 1;
            s = q + 1;
        } else {
            t->s = s, t->quoted = 0;
            while (s < e && *s != ' ' && *s != '\t' && *s != '\r' && *s != '#')
                s++;
            t->len = (size_t)(s - t->s);
        }
        for (size_t k = 0; k < t->len; k++)
            if (t->s[k] == '\0') return fail(p, t->col + (int)k, "expected text, found a NUL byte");
    }
    return CRISP_OK;
}

static int is_word(const token *t, const char *w)
{
    return !t->quoted && t->len == strlen(w) && !memcmp(t->s, w, t->len);
}

static int to_number(const token *t, double *v)
{
    char buf[64];
    if (t->quoted || t->len == 0 || t->len >= sizeof buf) return 0;
    memcpy(buf, t->s, t->len);
    buf[t->len] = '\0';
    char *end;
    *v = strtod(buf, &end);
    return *end == '\0' && isfinite(*v) && !isspace((unsigned char)buf[0]);
}

/* Numbers at tokens [*k, *k + n) into v; msg names what was expected. */
static crisp_status numbers(parser *p, int *k, int n, double *v, const char *msg)
{
    for (int i = 0; i < n; i++) {
        int at = *k + i;
        if (at >= p->count) {
            const token *last = &p->tok[p->count - 1];
            return fail(p, last->col + (int)last->len + last->quoted * 2, msg);
        }
        if (!to_number(&p->tok[at], &v[i])) return fail(p, p->tok[at].col, msg);
    }
    *k += n;
    return CRISP_OK;
}

/* dest = op * dest (op applied after what is there). */
static void apply(crisp_mat4 op, crisp_mat4 dest)
{
    crisp_mat4 r;
    crisp_mat4_mul(op, dest, r);
    memcpy(dest, r, sizeof r);
}

static char *join_path(const char *dir, const char *s, size_t len)
{
    size_t dl = (dir && *dir && s[0] != '/') ? strlen(dir) : 0;
    char *r = crisp_malloc_array(dl + len + 2, 1);
    if (!r) return NULL;
    size_t o = 0;
    if (dl) {
        memcpy(r, dir, dl);
        o = dl;
        if (r[o - 1] != '/') r[o++] = '/';
    }
    memcpy(r + o, s, len);
    r[o + len] = '\0';
    return r;
}

static char *dup_n(const char *s, size_t len)
{
    char *r = crisp_malloc_array(len + 1, 1);
    if (r) {
        memcpy(r, s, len);
        r[len] = '\0';
    }
    return r;
}

/* camera eye x y z [target x y z] [up x y z] [fov degrees] */
static crisp_status parse_camera(parser *p, crisp_scene_file *s)
{
    const token *t = p->tok;
    if (s->has_camera) return fail(p, t[0].col, "expected at most one 'camera' line");
    s->has_camera = 1;
    s->fov_deg = 30;
    int k = 1, have_eye = 0, have_up = 0;
    crisp_status st;
    while (k < p->count) {
        const token *w = &t[k++];
        if (is_word(w, "eye")) {
            if ((st = numbers(p, &k, 3, s->eye, "expected three numbers after 'eye'"))) return st;
            have_eye = 1;
        } else if (is_word(w, "target")) {
            if ((st = numbers(p, &k, 3, s->target, "expected three numbers after 'target'")))
                return st;
            s->has_target = 1;
        } else if (is_word(w, "up")) {
            if ((st = numbers(p, &k, 3, s->up, "expected three numbers after 'up'"))) return st;
            have_up = 1;
            if (s->up[0] == 0 && s->up[1] == 0 && s->up[2] == 0)
                return fail(p, w->col, "expected a non-zero 'up' vector");
        } else if (is_word(w, "fov")) {
            if ((st = numbers(p, &k, 1, &s->fov_deg, "expected a number after 'fov'"))) return st;
            if (!(s->fov_deg > 0 && s->fov_deg < 180))
                return fail(p, w->col, "expected a field of view in (0, 180) degrees");
        } else {
            return fail(p, w->col, "expected eye, target, up or fov");
        }
    }
    s->has_up = have_up;
    if (!have_eye) return fail(p, t[0].col, "expected 'eye x y z' on the camera line");
    if (s->has_target && s->eye[0] == s->target[0] && s->eye[1] == s->target[1] &&
        s->eye[2] == s->target[2])
        return fail(p, t[0].col, "expected a camera target different from its eye");
    return CRISP_OK;
}

static crisp_status parse_item(parser *p, const char *dir, crisp_scene_item *it)
{
    const token *t = p->tok;
    if (is_word(&t[0], "model"))
        it->kind = CRISP_SCENE_MODEL;
    else if (is_word(&t[0], "frep"))
        it->kind = CRISP_SCENE_FREP;
    else
        return fail(p, t[0].col, "expected 'model' or 'frep' (or one 'camera' line)");
    int k = 1;
    if (k >= p->count) return fail(p, t[0].col + (int)t[0].len, "expected a file path");
    if (it->kind == CRISP_SCENE_FREP && is_word(&t[k], "math")) {
        if (k + 1 >= p->count || !t[k + 1].quoted)
            return fail(p, k + 1 < p->count ? t[k + 1].col : t[k].col + 4,
                        "expected a math string in double quotes after 'math'");
        if (!(it->math = dup_n(t[k + 1].s, t[k + 1].len)))
            return crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", p->name, p->line);
        k += 2;
    } else {
        if (t[k].len == 0) return fail(p, t[k].col, "expected a non-empty file path");
        if (!(it->path = join_path(dir, t[k].s, t[k].len)))
            return crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", p->name, p->line);
        k++;
    }
    crisp_mat4_identity(it->transform);
    while (k < p->count) {
        const token *w = &t[k++];
        crisp_mat4 op;
        crisp_mat4_identity(op);
        double v[16];
        crisp_status st;
        if (is_word(w, "translate")) {
            if ((st = numbers(p, &k, 3, v, "expected three numbers after 'translate'"))) return st;
            op[3][0] = v[0], op[3][1] = v[1], op[3][2] = v[2];
        } else if (is_word(w, "scale")) {
            if ((st = numbers(p, &k, 1, v, "expected a number after 'scale'"))) return st;
            v[1] = v[2] = v[0];
            double probe;
            if (k < p->count && to_number(&t[k], &probe))
                if ((st = numbers(p, &k, 2, v + 1, "expected 'scale s' or 'scale sx sy sz'")))
                    return st;
            if (v[0] == 0 || v[1] == 0 || v[2] == 0)
                return fail(p, w->col, "expected non-zero scale factors");
            op[0][0] = v[0], op[1][1] = v[1], op[2][2] = v[2];
        } else if (is_word(w, "rotate")) {
            if ((st = numbers(p, &k, 4, v, "expected 'rotate ax ay az degrees'"))) return st;
            double ax[3];
            if (!crisp_vec3_normalize(v, ax))
                return fail(p, w->col, "expected a non-zero rotation axis");
            double a = v[3] * (M_PI / 180), c = cos(a), s = sin(a);
            for (int r = 0; r < 3; r++)
                for (int q = 0; q < 3; q++) {
                    double m = (1 - c) * ax[r] * ax[q] + (r == q ? c : 0);
                    if (r != q) m += ((r + 1) % 3 == q ? -1 : 1) * s * ax[3 - r - q];
                    op[q][r] = m;
                }
        } else if (is_word(w, "transform")) {
            if ((st = numbers(p, &k, 16, v, "expected 16 numbers after 'transform' (4 rows of 4)")))
                return st;
            if (v[12] != 0 || v[13] != 0 || v[14] != 0 || v[15] != 1)
                return fail(p, w->col, "expected an affine transform (last row 0 0 0 1)");
            for (int r = 0; r < 4; r++)
                for (int q = 0; q < 4; q++)
                    op[q][r] = v[4 * r + q];
            crisp_mat4 inv;
            if (!crisp_mat4_inverse(op, inv))
                return fail(p, w->col, "expected an invertible transform");
        } else if (is_word(w, "color")) {
            if ((st = numbers(p, &k, 3, v, "expected three numbers in [0, 1] after 'color'")))
                return st;
            for (int i = 0; i < 3; i++)
                if (v[i] < 0 || v[i] > 1)
                    return fail(p, t[k - 3 + i].col, "expected a colour component in [0, 1]");
            it->has_color = 1;
            for (int i = 0; i < 3; i++)
                it->color[i] = (float)v[i];
            it->color[3] = 1;
            continue;
        } else {
            return fail(p, w->col, "expected translate, scale, rotate, transform or color");
        }
        apply(op, it->transform);
    }
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++)
            if (!isfinite(it->transform[a][b]))
                return fail(p, t[0].col, "expected a finite transform");
    crisp_mat4 inv;
    if (!crisp_mat4_inverse(it->transform, inv))
        return fail(p, t[0].col, "expected an invertible transform");
    return CRISP_OK;
}

static void item_free(crisp_scene_item *it)
{
    crisp_free(it->path);
    crisp_free(it->math);
}

crisp_status crisp_scene_file_read_mem(const char *name, const char *dir, const char *data,
                                       size_t size, crisp_scene_file **dest)
{
    *dest = NULL;
    if (!name) name = "scene";
    crisp_scene_file *s = crisp_calloc_array(1, sizeof *s);
    if (!s || !(s->name = dup_n(name, strlen(name)))) {
        crisp_free(s);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", name);
    }
    parser *p = crisp_calloc_array(1, sizeof *p);
    if (!p) {
        crisp_scene_file_destroy(s);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", name);
    }
    p->name = name;
    size_t cap = 0;
    crisp_status st = CRISP_OK;
    const char *c = data, *end = data + size;
    while (c < end && !st) {
        const char *e = memchr(c, '\n', (size_t)(end - c));
        if (!e) e = end;
        p->line++;
        st = tokenize(p, c, e);
        c = e + 1;
        if (st || p->count == 0) continue;
        if (is_word(&p->tok[0], "camera")) {
            st = parse_camera(p, s);
            continue;
        }
        if (s->item_count == MAX_ITEMS) {
            st = fail(p, 1, "expected at most 100000 items in a scene");
            break;
        }
        if (s->item_count == cap) {
            size_t ncap = cap ? 2 * cap : 8;
            crisp_scene_item *n = crisp_realloc_array(s->items, ncap, sizeof *n);
            if (!n) {
                st = crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", name, p->line);
                break;
            }
            s->items = n;
            cap = ncap;
        }
        crisp_scene_item *it = &s->items[s->item_count];
        memset(it, 0, sizeof *it);
        it->line = p->line;
        it->color[0] = it->color[1] = it->color[2] = 0.7f;
        it->color[3] = 1;
        st = parse_item(p, dir, it);
        if (st)
            item_free(it);
        else
            s->item_count++;
    }
    if (!st && s->item_count == 0)
        st = crisp_error(CRISP_ERR_PARSE, "%s:%d:1: expected at least one 'model' or 'frep' line",
                         name, p->line > 0 ? p->line : 1);
    crisp_free(p);
    if (st) {
        crisp_scene_file_destroy(s);
        return st;
    }
    *dest = s;
    return CRISP_OK;
}

crisp_status crisp_scene_file_read(const char *path, crisp_scene_file **dest)
{
    *dest = NULL;
    char *data = NULL;
    size_t size = 0;
    crisp_status st = crisp_read_file(path, &data, &size);
    if (st) return st;
    const char *slash = strrchr(path, '/');
    char *dir = slash ? dup_n(path, (size_t)(slash - path) + 1) : NULL;
    if (slash && !dir)
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", path);
    else
        st = crisp_scene_file_read_mem(path, dir, data, size, dest);
    crisp_free(dir);
    crisp_free(data);
    return st;
}

void crisp_scene_file_destroy(crisp_scene_file *s)
{
    if (!s) return;
    for (size_t i = 0; i < s->item_count; i++)
        item_free(&s->items[i]);
    crisp_free(s->items);
    crisp_free(s->name);
    crisp_free(s);
}

int crisp_scene_file_detect(const char *path)
{
    size_t n = strlen(path);
    if (n >= 6 && !strcmp(path + n - 6, ".scene")) return 1;
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    char buf[4096];
    size_t got = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[got] = '\0';
    const char *c = buf;
    for (;;) { /* skip blank and comment lines */
        while (*c == ' ' || *c == '\t' || *c == '\r' || *c == '\n')
            c++;
        if (*c != '#') break;
        while (*c && *c != '\n')
            c++;
    }
    return (!strncmp(c, "model", 5) && (c[5] == ' ' || c[5] == '\t')) ||
           (!strncmp(c, "frep", 4) && (c[4] == ' ' || c[4] == '\t')) ||
           (!strncmp(c, "camera", 6) && (c[6] == ' ' || c[6] == '\t'));
}

/* ---- loading -----------------------------------------------------------------------------------
 */

static crisp_status load_model_item(const crisp_scene_file *s, const crisp_scene_item *it,
                                    crisp_model *merged)
{
    crisp_model *m = NULL;
    crisp_status st = crisp_model_load(it->path, NULL, &m);
    if (st) {
        crisp_error_prefix("%s:%d", s->name, it->line);
        return st;
    }
    /* the item's transform (column-major, m[col][row]) as the rows of an affine map */
    double rows[3][4];
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 4; b++)
            rows[a][b] = it->transform[b][a];
    for (int i = 0; i < m->face_count && !st; i++) {
        crisp_face *f = &m->faces[i];
        crisp_face_transform(f, (const double(*)[4])rows);
        if (it->has_color) {
            f->has_color = 1;
            memcpy(f->color, it->color, sizeof f->color);
        }
        st = crisp_model_add_face(merged, f);
    }
    crisp_model_destroy(m);
    return st;
}

crisp_status crisp_scene_assets_load(const crisp_scene_file *s, crisp_scene_assets **dest)
{
    *dest = NULL;
    crisp_scene_assets *a = crisp_calloc_array(1, sizeof *a);
    crisp_status st = a ? crisp_model_create(&a->model) : CRISP_ERR_NO_MEMORY;
    size_t parts = 0;
    for (size_t i = 0; i < s->item_count; i++)
        parts += s->items[i].kind == CRISP_SCENE_FREP;
    if (!st && parts) {
        a->parts = crisp_calloc_array(parts, sizeof *a->parts);
        a->freps = crisp_calloc_array(parts, sizeof *a->freps);
        a->tapes = crisp_calloc_array(parts, sizeof *a->tapes);
        if (!a->parts || !a->freps || !a->tapes) st = CRISP_ERR_NO_MEMORY;
    }
    if (st == CRISP_ERR_NO_MEMORY)
        st = crisp_error(st, "%s: out of memory loading the scene", s->name);
    for (size_t i = 0; i < s->item_count && !st; i++) {
        const crisp_scene_item *it = &s->items[i];
        if (it->kind == CRISP_SCENE_MODEL) {
            st = load_model_item(s, it, a->model);
            continue;
        }
        size_t k = a->part_count;
        if (it->math) {
            char name[64];
            snprintf(name, sizeof name, "line %d math", it->line);
            st = crisp_frep_read_math_mem(name, it->math, strlen(it->math), &a->freps[k]);
        } else {
            size_t n = strlen(it->path);
            int vm = n >= 3 && !strcmp(it->path + n - 3, ".vm");
            st = vm ? crisp_frep_read_vm(it->path, &a->freps[k])
                    : crisp_frep_read_math(it->path, &a->freps[k]);
        }
        if (!st) st = crisp_frep_tape_create(a->freps[k], &a->tapes[k]);
        if (st) {
            crisp_frep_destroy(a->freps[k]); /* the tape failed or the reader left nothing */
            crisp_error_prefix("%s:%d", s->name, it->line);
            break;
        }
        crisp_frep_part *p = &a->parts[k];
        p->tape = a->tapes[k];
        memcpy(p->transform, it->transform, sizeof p->transform);
        if (it->has_color)
            memcpy(p->color, it->color, sizeof p->color);
        else
            p->color[0] = 0.85f, p->color[1] = 0.55f, p->color[2] = 0.35f, p->color[3] = 1;
        a->part_count++;
    }
    if (st) {
        crisp_scene_assets_destroy(a);
        return st;
    }
    *dest = a;
    return CRISP_OK;
}

void crisp_scene_assets_destroy(crisp_scene_assets *a)
{
    if (!a) return;
    crisp_model_destroy(a->model);
    for (size_t i = 0; i < a->part_count; i++) {
        crisp_frep_tape_destroy(a->tapes[i]);
        crisp_frep_destroy(a->freps[i]);
    }
    crisp_free(a->parts);
    crisp_free(a->freps);
    crisp_free(a->tapes);
    crisp_free(a);
}
