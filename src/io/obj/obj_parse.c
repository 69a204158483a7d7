/* Wavefront OBJ text -> obj_data: statements, the cstype/deg state, elements (curv2, surf) with
 * their parm/trim/hole statements, and polygon faces. Follows the Wavefront OBJ specification
 * (version 3.0, free-form geometry): `#` comments, `\` line continuation, 1-based
 * references with negative values counting back from the most recent item.
 * Every error names the file, the line and the column, and says what was expected. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "obj/obj_internal.h"

typedef struct tok {
    const char *s;
    int len, line, col;
} tok;

enum { EL_NONE, EL_CURV2, EL_SURF, EL_SKIP };

typedef struct parser {
    const char *name;
    const char *p, *end, *line_start;
    int line;
    tok *toks;
    size_t tok_count, tok_cap;
    /* state */
    int cstype, rational, deg_count, deg[2];
    char cstype_name[16];
    int element;  /* EL_* */
    int material; /* current usemtl, -1 for none */
    int element_line;
    obj_data *d;
    crisp_model *m;
} parser;

/* ---- lexing ---------------------------------------------------------------------------------- */

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v' || c == '\0';
}

/* Only whitespace between p and the end of the physical line? */
static int rest_is_blank(const char *p, const char *end)
{
    for (; p < end && *p != '\n'; p++)
        if (!is_space(*p)) return 0;
    return 1;
}

/* The next logical line's tokens (joined across `\` continuations); tok_count 0 at the end. */
static crisp_status next_statement(parser *ps)
{
    ps->tok_count = 0;
    while (ps->p < ps->end) {
        char c = *ps->p;
        if (c == '\n') {
            ps->p++;
            ps->line++;
            ps->line_start = ps->p;
            if (ps->tok_count) return CRISP_OK;
            continue;
        }
        if (is_space(c)) {
            ps->p++;
            continue;
        }
        if (c == '#') {
            while (ps->p < ps->end && *ps->p != '\n')
                ps->p++;
            continue;
        }
        if (c == '\\' && rest_is_blank(ps->p + 1, ps->end)) {
            while (ps->p < ps->end && *ps->p != '\n')
                ps->p++;
            if (ps->p < ps->end) {
                ps->p++;
                ps->line++;
                ps->line_start = ps->p;
            }
            continue;
        }
        const char *s = ps->p;
        while (ps->p < ps->end && !is_space(*ps->p) && *ps->p != '\n' && *ps->p != '#')
            ps->p++;
        if (crisp_grow((void **)&ps->toks, &ps->tok_cap, ps->tok_count + 1, sizeof(tok)) !=
            CRISP_OK)
            return crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", ps->name, ps->line);
        ps->toks[ps->tok_count++] =
            (tok){s, (int)(ps->p - s), ps->line, (int)(s - ps->line_start) + 1};
    }
    return CRISP_OK;
}

static int tok_is(const tok *t, const char *word)
{
    size_t n = strlen(word);
    return (size_t)t->len == n && memcmp(t->s, word, n) == 0;
}

static crisp_status tok_error(parser *ps, const tok *t, crisp_status st, const char *what)
{
    return crisp_error(st, "%s:%d:%d: %s (found '%.*s')", ps->name, t->line, t->col, what,
                       t->len > 32 ? 32 : t->len, t->s);
}

/* A finite number; ext (may be NULL) gets it in long double precision as well. */
static crisp_status parse_real_ext(parser *ps, const tok *t, double *dest, long double *ext)
{
    char buf[64];
    if (t->len >= (int)sizeof buf) return tok_error(ps, t, CRISP_ERR_PARSE, "expected a number");
    memcpy(buf, t->s, (size_t)t->len);
    buf[t->len] = '\0';
    char *endp;
    errno = 0;
    double x = strtod(buf, &endp);
    if (endp != buf + t->len || endp == buf)
        return tok_error(ps, t, CRISP_ERR_PARSE, "expected a number");
    if (!isfinite(x)) return tok_error(ps, t, CRISP_ERR_NUMERIC, "expected a finite number");
    *dest = x;
    if (ext) {
        /* strtold is slow; it only adds anything for more digits than a double holds */
        int digits = 0;
        for (const char *c = buf; *c && *c != 'e' && *c != 'E'; c++)
            digits += *c >= '0' && *c <= '9';
        long double xl = digits > 17 ? strtold(buf, NULL) : (long double)x;
        *ext = isfinite(xl) ? xl : (long double)x;
    }
    return CRISP_OK;
}

static crisp_status parse_real(parser *ps, const tok *t, double *dest)
{
    return parse_real_ext(ps, t, dest, NULL);
}

static crisp_status parse_int(parser *ps, const tok *t, int *dest)
{
    char buf[24];
    if (t->len >= (int)sizeof buf || t->len == 0)
        return tok_error(ps, t, CRISP_ERR_PARSE, "expected an integer");
    memcpy(buf, t->s, (size_t)t->len);
    buf[t->len] = '\0';
    char *endp;
    errno = 0;
    long x = strtol(buf, &endp, 10);
    if (endp != buf + t->len || errno || x > 1000000000L || x < -1000000000L)
        return tok_error(ps, t, CRISP_ERR_PARSE, "expected an integer");
    *dest = (int)x;
    return CRISP_OK;
}

/* A 1-based or negative (relative) reference to one of count items -> 0-based index. The token may
 * be v/vt/vn: the part before the first '/' is used. */
static crisp_status parse_ref(parser *ps, const tok *t, int count, const char *what, int *dest)
{
    tok head = *t;
    const char *slash = memchr(t->s, '/', (size_t)t->len);
    if (slash) head.len = (int)(slash - t->s);
    int k = 0;
    crisp_status st = parse_int(ps, &head, &k);
    if (st != CRISP_OK) return st;
    int idx = k > 0 ? k - 1 : count + k;
    if (k == 0 || idx < 0 || idx >= count)
        return crisp_error(CRISP_ERR_PARSE,
                           "%s:%d:%d: %s reference %d out of range (%d defined so far)", ps->name,
                           t->line, t->col, what, k, count);
    *dest = idx;
    return CRISP_OK;
}

/* ---- storage --------------------------------------------------------------------------------- */

static crisp_status grow_int(void **p, int *cap, int need, size_t size)
{
    if (need > CRISP_MAX_CONTROL_POINTS * 4)
        return crisp_error(CRISP_ERR_LIMIT, "more than %d items", CRISP_MAX_CONTROL_POINTS * 4);
    size_t c = (size_t)*cap;
    crisp_status st = crisp_grow(p, &c, (size_t)need, size);
    if (st == CRISP_OK) *cap = (int)c;
    return st;
}

static crisp_status push_ref(parser *ps, int idx)
{
    obj_data *d = ps->d;
    crisp_status st = grow_int((void **)&d->refs, &d->ref_cap, d->ref_count + 1, sizeof(int));
    if (st != CRISP_OK) return crisp_error(st, "%s:%d: too many references", ps->name, ps->line);
    d->refs[d->ref_count++] = idx;
    return CRISP_OK;
}

static crisp_status push_real(parser *ps, double x)
{
    obj_data *d = ps->d;
    crisp_status st = grow_int((void **)&d->reals, &d->real_cap, d->real_count + 1, sizeof(double));
    if (st != CRISP_OK) return crisp_error(st, "%s:%d: too many numbers", ps->name, ps->line);
    d->reals[d->real_count++] = x;
    return CRISP_OK;
}

static crisp_status note(parser *ps, const char *what)
{
    return crisp_model_note_skip(ps->m, what);
}

/* ---- statements ------------------------------------------------------------------------------ */

static crisp_status need_args(parser *ps, const tok *t, size_t n, size_t min, const char *usage)
{
    if (n < min)
        return crisp_error(CRISP_ERR_PARSE, "%s:%d:%d: expected '%s'", ps->name, t->line, t->col,
                           usage);
    return CRISP_OK;
}

static crisp_status stmt_v(parser *ps)
{
    tok *t = ps->toks;
    crisp_status st = need_args(ps, t, ps->tok_count, 4, "v x y z [w]");
    if (st != CRISP_OK) return st;
    obj_vertex v = {.x = {0, 0, 0, 1}};
    size_t n = ps->tok_count - 1 > 4 ? 4 : ps->tok_count - 1;
    for (size_t i = 0; i < n; i++)
        if ((st = parse_real_ext(ps, &t[1 + i], &v.x[i], i < 3 ? &v.ext[i] : NULL)) != CRISP_OK)
            return st;
    obj_data *d = ps->d;
    if ((st = grow_int((void **)&d->v, &d->v_cap, d->v_count + 1, sizeof(obj_vertex))) != CRISP_OK)
        return crisp_error(st, "%s:%d: too many vertices", ps->name, t->line);
    d->v[d->v_count++] = v;
    return CRISP_OK;
}

static crisp_status stmt_vp(parser *ps)
{
    tok *t = ps->toks;
    crisp_status st = need_args(ps, t, ps->tok_count, 2, "vp u [v [w]]");
    if (st != CRISP_OK) return st;
    obj_pvertex v = {.x = {0, 0, 1}};
    size_t n = ps->tok_count - 1 > 3 ? 3 : ps->tok_count - 1;
    for (size_t i = 0; i < n; i++)
        if ((st = parse_real_ext(ps, &t[1 + i], &v.x[i], i < 2 ? &v.ext[i] : NULL)) != CRISP_OK)
            return st;
    obj_data *d = ps->d;
    if ((st = grow_int((void **)&d->vp, &d->vp_cap, d->vp_count + 1, sizeof(obj_pvertex))) !=
        CRISP_OK)
        return crisp_error(st, "%s:%d: too many parameter vertices", ps->name, t->line);
    d->vp[d->vp_count++] = v;
    return CRISP_OK;
}

static crisp_status stmt_cstype(parser *ps)
{
    tok *t = ps->toks;
    crisp_status st = need_args(ps, t, ps->tok_count, 2, "cstype [rat] bspline|bezier");
    if (st != CRISP_OK) return st;
    size_t i = 1;
    ps->rational = 0;
    if (tok_is(&t[1], "rat")) {
        ps->rational = 1;
        i = 2;
        if ((st = need_args(ps, t, ps->tok_count, 3, "cstype rat bspline|bezier")) != CRISP_OK)
            return st;
    }
    tok *k = &t[i];
    if (tok_is(k, "bspline"))
        ps->cstype = OBJ_BSPLINE;
    else if (tok_is(k, "bezier"))
        ps->cstype = OBJ_BEZIER;
    else if (tok_is(k, "cardinal") || tok_is(k, "taylor") || tok_is(k, "bmatrix"))
        ps->cstype = -1;
    else
        return tok_error(ps, k, CRISP_ERR_PARSE,
                         "expected bspline, bezier, cardinal, taylor or bmatrix after cstype");
    snprintf(ps->cstype_name, sizeof ps->cstype_name, "%.*s", k->len, k->s);
    return CRISP_OK;
}

static crisp_status stmt_deg(parser *ps)
{
    tok *t = ps->toks;
    crisp_status st = need_args(ps, t, ps->tok_count, 2, "deg du [dv]");
    if (st != CRISP_OK) return st;
    ps->deg_count = ps->tok_count >= 3 ? 2 : 1;
    for (int i = 0; i < ps->deg_count; i++) {
        if ((st = parse_int(ps, &t[1 + i], &ps->deg[i])) != CRISP_OK) return st;
        if (ps->deg[i] < 1 || ps->deg[i] > CRISP_MAX_DEGREE)
            return tok_error(ps, &t[1 + i], CRISP_ERR_LIMIT, "expected a degree from 1 to 15");
    }
    return CRISP_OK;
}

/* A new element implicitly ends one left open (lenient: some writers forget `end`). */
static void close_element(parser *ps)
{
    ps->element = EL_NONE;
}

static crisp_status check_cstype(parser *ps, const tok *t, const char *kind, int *skip)
{
    *skip = 0;
    if (ps->cstype == 0)
        return crisp_error(CRISP_ERR_PARSE, "%s:%d:%d: %s before any 'cstype' statement", ps->name,
                           t->line, t->col, kind);
    if (ps->cstype < 0) {
        char what[160];
        snprintf(what, sizeof what, "OBJ %s with cstype %s: unsupported", kind, ps->cstype_name);
        *skip = 1;
        return note(ps, what);
    }
    return CRISP_OK;
}

static crisp_status stmt_curv2(parser *ps)
{
    tok *t = ps->toks;
    close_element(ps);
    crisp_status st = need_args(ps, t, ps->tok_count, 3, "curv2 vp1 vp2 ...");
    if (st != CRISP_OK) return st;
    int skip;
    if ((st = check_cstype(ps, t, "curv2", &skip)) != CRISP_OK) return st;
    if (ps->deg_count < 1)
        return crisp_error(CRISP_ERR_PARSE, "%s:%d:%d: curv2 before any 'deg' statement", ps->name,
                           t->line, t->col);
    obj_data *d = ps->d;
    if (skip) {
        /* keep the numbering of curv2 elements: a placeholder that fails on use */
        ps->element = EL_SKIP;
    } else {
        ps->element = EL_CURV2;
    }
    if ((st = grow_int((void **)&d->curv2, &d->curv2_cap, d->curv2_count + 1, sizeof(obj_curv2))) !=
        CRISP_OK)
        return crisp_error(st, "%s:%d: too many curv2 elements", ps->name, t->line);
    obj_curv2 *c = &d->curv2[d->curv2_count++];
    memset(c, 0, sizeof *c);
    c->type = skip ? 0 : ps->cstype;
    c->rational = ps->rational;
    c->degree = ps->deg[0];
    c->line = t->line;
    c->refs.off = d->ref_count;
    for (size_t i = 1; i < ps->tok_count; i++) {
        int idx;
        if ((st = parse_ref(ps, &t[i], d->vp_count, "vp", &idx)) != CRISP_OK) return st;
        if ((st = push_ref(ps, idx)) != CRISP_OK) return st;
    }
    c->refs.count = d->ref_count - c->refs.off;
    c->knots.off = -1;
    return CRISP_OK;
}

static crisp_status stmt_surf(parser *ps)
{
    tok *t = ps->toks;
    close_element(ps);
    crisp_status st = need_args(ps, t, ps->tok_count, 6, "surf s0 s1 t0 t1 v1 v2 ...");
    if (st != CRISP_OK) return st;
    int skip;
    if ((st = check_cstype(ps, t, "surf", &skip)) != CRISP_OK) return st;
    if (skip) {
        ps->element = EL_SKIP;
        return CRISP_OK;
    }
    if (ps->deg_count < 2)
        return crisp_error(CRISP_ERR_PARSE, "%s:%d:%d: surf needs a preceding 'deg du dv'",
                           ps->name, t->line, t->col);
    obj_data *d = ps->d;
    if ((st = grow_int((void **)&d->surfs, &d->surf_cap, d->surf_count + 1, sizeof(obj_surf))) !=
        CRISP_OK)
        return crisp_error(st, "%s:%d: too many surf elements", ps->name, t->line);
    obj_surf *s = &d->surfs[d->surf_count++];
    memset(s, 0, sizeof *s);
    s->type = ps->cstype;
    s->rational = ps->rational;
    s->degree_u = ps->deg[0];
    s->degree_v = ps->deg[1];
    s->line = t->line;
    s->material = ps->material;
    for (int i = 0; i < 4; i++)
        if ((st = parse_real(ps, &t[1 + i], &s->range[i])) != CRISP_OK) return st;
    s->refs.off = d->ref_count;
    for (size_t i = 5; i < ps->tok_count; i++) {
        int idx;
        if ((st = parse_ref(ps, &t[i], d->v_count, "v", &idx)) != CRISP_OK) return st;
        if ((st = push_ref(ps, idx)) != CRISP_OK) return st;
    }
    s->refs.count = d->ref_count - s->refs.off;
    s->knots_u.off = s->knots_v.off = -1;
    s->loops.off = d->loop_count;
    ps->element = EL_SURF;
    return CRISP_OK;
}

static crisp_status stmt_parm(parser *ps)
{
    tok *t = ps->toks;
    crisp_status st = need_args(ps, t, ps->tok_count, 4, "parm u|v p1 p2 ...");
    if (st != CRISP_OK) return st;
    if (ps->element == EL_SKIP) return CRISP_OK;
    if (ps->element == EL_NONE)
        return crisp_error(CRISP_ERR_PARSE,
                           "%s:%d:%d: 'parm' outside a curv2 or surf element (expected after "
                           "curv2/surf, before end)",
                           ps->name, t->line, t->col);
    int dir;
    if (tok_is(&t[1], "u"))
        dir = 0;
    else if (tok_is(&t[1], "v"))
        dir = 1;
    else
        return tok_error(ps, &t[1], CRISP_ERR_PARSE, "expected u or v after parm");
    obj_data *d = ps->d;
    obj_span *span;
    if (ps->element == EL_CURV2) {
        if (dir != 0) return tok_error(ps, &t[1], CRISP_ERR_PARSE, "a curv2 has only 'parm u'");
        span = &d->curv2[d->curv2_count - 1].knots;
    } else {
        obj_surf *s = &d->surfs[d->surf_count - 1];
        span = dir ? &s->knots_v : &s->knots_u;
    }
    if (span->off >= 0)
        return tok_error(ps, &t[1], CRISP_ERR_PARSE,
                         "parameter values given twice for this element");
    span->off = d->real_count;
    for (size_t i = 2; i < ps->tok_count; i++) {
        double x;
        if ((st = parse_real(ps, &t[i], &x)) != CRISP_OK) return st;
        if ((st = push_real(ps, x)) != CRISP_OK) return st;
    }
    span->count = d->real_count - span->off;
    return CRISP_OK;
}

static crisp_status stmt_trim(parser *ps, int is_outer)
{
    tok *t = ps->toks;
    if (ps->element == EL_SKIP) return CRISP_OK;
    if (ps->element != EL_SURF)
        return crisp_error(CRISP_ERR_PARSE, "%s:%d:%d: '%.*s' outside a surf element", ps->name,
                           t->line, t->col, t->len, t->s);
    if (ps->tok_count < 4 || (ps->tok_count - 1) % 3 != 0)
        return crisp_error(CRISP_ERR_PARSE, "%s:%d:%d: expected '%.*s u0 u1 curv2 ...' (triples)",
                           ps->name, t->line, t->col, t->len, t->s);
    obj_data *d = ps->d;
    crisp_status st =
        grow_int((void **)&d->loops, &d->loop_cap, d->loop_count + 1, sizeof(obj_loop));
    if (st != CRISP_OK) return crisp_error(st, "%s:%d: too many trim loops", ps->name, t->line);
    obj_loop *l = &d->loops[d->loop_count++];
    l->is_outer = is_outer;
    l->line = t->line;
    l->triples.off = d->real_count;
    for (size_t i = 1; i < ps->tok_count; i += 3) {
        double u0, u1;
        int c;
        if ((st = parse_real(ps, &t[i], &u0)) != CRISP_OK) return st;
        if ((st = parse_real(ps, &t[i + 1], &u1)) != CRISP_OK) return st;
        if ((st = parse_ref(ps, &t[i + 2], d->curv2_count, "curv2", &c)) != CRISP_OK) return st;
        if ((st = push_real(ps, u0)) != CRISP_OK || (st = push_real(ps, u1)) != CRISP_OK ||
            (st = push_real(ps, c)) != CRISP_OK)
            return st;
    }
    l->triples.count = (d->real_count - l->triples.off) / 3;
    d->surfs[d->surf_count - 1].loops.count = d->loop_count - d->surfs[d->surf_count - 1].loops.off;
    return CRISP_OK;
}

static crisp_status stmt_f(parser *ps)
{
    tok *t = ps->toks;
    crisp_status st = need_args(ps, t, ps->tok_count, 2, "f v1 v2 v3 ...");
    if (st != CRISP_OK) return st;
    obj_data *d = ps->d;
    if ((st = grow_int((void **)&d->polys, &d->poly_cap, d->poly_count + 1, sizeof(obj_polygon))) !=
        CRISP_OK)
        return crisp_error(st, "%s:%d: too many faces", ps->name, t->line);
    obj_polygon *f = &d->polys[d->poly_count++];
    f->line = t->line;
    f->material = ps->material;
    f->refs.off = d->ref_count;
    for (size_t i = 1; i < ps->tok_count; i++) {
        int idx;
        if ((st = parse_ref(ps, &t[i], d->v_count, "v", &idx)) != CRISP_OK) return st;
        if ((st = push_ref(ps, idx)) != CRISP_OK) return st;
    }
    f->refs.count = d->ref_count - f->refs.off;
    return CRISP_OK;
}

/* Statements that are valid OBJ but carry nothing crisp uses. */
static const char *const ignored[] = {
    "vt",       "vn",        "g",          "o",      "s",      "mg",    "con",
    "ctech",    "stech",     "bmat",       "step",   "lod",    "bevel", "c_interp",
    "d_interp", "trace_obj", "shadow_obj", "maplib", "usemap", "res",   NULL};

static crisp_status statement(parser *ps)
{
    tok *k = &ps->toks[0];
    if (tok_is(k, "v")) return stmt_v(ps);
    if (tok_is(k, "vp")) return stmt_vp(ps);
    if (tok_is(k, "f") || tok_is(k, "fo")) return stmt_f(ps);
    if (tok_is(k, "cstype")) return stmt_cstype(ps);
    if (tok_is(k, "deg")) return stmt_deg(ps);
    if (tok_is(k, "curv2")) return stmt_curv2(ps);
    if (tok_is(k, "surf")) return stmt_surf(ps);
    if (tok_is(k, "parm")) return stmt_parm(ps);
    if (tok_is(k, "trim")) return stmt_trim(ps, 1);
    if (tok_is(k, "hole")) return stmt_trim(ps, 0);
    if (tok_is(k, "end")) {
        if (ps->element == EL_NONE)
            return crisp_error(CRISP_ERR_PARSE,
                               "%s:%d:%d: 'end' without an open curv2/surf element", ps->name,
                               k->line, k->col);
        close_element(ps);
        return CRISP_OK;
    }
    if (tok_is(k, "usemtl")) {
        if (ps->tok_count < 2) {
            ps->material = -1;
            return CRISP_OK;
        }
        int mat = crisp__obj_material(ps->d, ps->toks[1].s, (size_t)ps->toks[1].len);
        if (mat < 0)
            return crisp_error(CRISP_ERR_LIMIT, "%s:%d: too many materials", ps->name, k->line);
        ps->material = mat;
        return CRISP_OK;
    }
    if (tok_is(k, "mtllib")) {
        obj_data *d = ps->d;
        for (size_t i = 1; i < ps->tok_count; i++) {
            size_t n = (size_t)ps->toks[i].len;
            if (d->mtllibs_len + n + 1 > 65536) break; /* a sane bound on names */
            if (crisp_grow((void **)&d->mtllibs, &d->mtllibs_cap, d->mtllibs_len + n + 1, 1) !=
                CRISP_OK)
                return crisp_error(CRISP_ERR_NO_MEMORY, "%s:%d: out of memory", ps->name, k->line);
            memcpy(d->mtllibs + d->mtllibs_len, ps->toks[i].s, n);
            d->mtllibs[d->mtllibs_len + n] = '\0';
            d->mtllibs_len += n + 1;
        }
        return CRISP_OK;
    }
    if (tok_is(k, "scrv"))
        return ps->element == EL_SURF ? note(ps, "OBJ scrv: special curves ignored") : CRISP_OK;
    if (tok_is(k, "sp"))
        return ps->element == EL_SURF ? note(ps, "OBJ sp: special points ignored") : CRISP_OK;
    if (tok_is(k, "curv")) {
        close_element(ps);
        ps->element = EL_SKIP;
        return note(ps, "OBJ curv: 3D space curves are not surfaces");
    }
    if (tok_is(k, "p")) return note(ps, "OBJ p: points are not surfaces");
    if (tok_is(k, "l")) return note(ps, "OBJ l: lines are not surfaces");
    if (tok_is(k, "call") || tok_is(k, "csh"))
        return note(ps, "OBJ call/csh: commands are not executed");
    for (const char *const *w = ignored; *w; w++)
        if (tok_is(k, *w)) return CRISP_OK;
    char what[160];
    snprintf(what, sizeof what, "OBJ statement '%.*s': unknown, ignored", k->len > 24 ? 24 : k->len,
             k->s);
    return note(ps, what);
}

crisp_status crisp__obj_parse(const char *name, const char *text, size_t size, obj_data *d,
                              crisp_model *m)
{
    parser ps = {.name = name,
                 .p = text,
                 .end = text + size,
                 .line_start = text,
                 .line = 1,
                 .d = d,
                 .m = m,
                 .material = -1};
    d->name = name;
    crisp_status st = CRISP_OK;
    for (;;) {
        st = next_statement(&ps);
        if (st != CRISP_OK || ps.tok_count == 0) break;
        st = statement(&ps);
        if (st != CRISP_OK) break;
    }
    crisp_free(ps.toks);
    return st;
}

void crisp__obj_data_free(obj_data *d)
{
    if (!d) return;
    for (int i = 0; i < d->curv2_count; i++)
        crisp_curve_destroy(d->curv2[i].curve);
    crisp_free(d->v);
    crisp_free(d->vp);
    crisp_free(d->refs);
    crisp_free(d->reals);
    crisp_free(d->curv2);
    crisp_free(d->surfs);
    crisp_free(d->loops);
    crisp_free(d->polys);
    crisp_free(d->materials);
    crisp_free(d->mtllibs);
    memset(d, 0, sizeof *d);
}
