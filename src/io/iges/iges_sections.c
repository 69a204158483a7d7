/* IGES file structure: the fixed 80-column records split into the S, G, D, P and T sections,
 * the global section (parameter and record delimiters, units), the directory entries and the
 * parameter records tokenised into numbers, Hollerith strings and defaults. IGES 5.3 chapter 2.
 *
 * Lenient where real files bend the standard: short lines (trailing blanks stripped, CRLF), lines
 * without terminators in 80-byte blocks, a minimal global section, wrong sequence numbers and
 * parameter line counts (records are found by scanning to the record delimiter, and directory
 * entries are numbered by their position, as their pointers are).
 */
#include "iges_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct iges_line {
    const char *s;
    int len;    /* characters before the terminator */
    int lineno; /* 1-based line in the file */
} iges_line;

typedef struct iges_lines {
    int count;
    size_t cap;
    iges_line *items;
} iges_lines;

static crisp_status lines_push(iges_lines *l, const char *s, int len, int lineno)
{
    if (crisp_grow((void **)&l->items, &l->cap, (size_t)l->count + 1, sizeof *l->items))
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    l->items[l->count++] = (iges_line){s, len, lineno};
    return CRISP_OK;
}

/* The section letter of a record: column 73, or for a short line the letter before the trailing
 * sequence number. */
static char section_letter(const char *s, int len)
{
    if (len >= 73) return s[72];
    int i = len - 1;
    while (i >= 0 && (s[i] == ' ' || (s[i] >= '0' && s[i] <= '9')))
        i--;
    return i >= 0 ? s[i] : 0;
}

int crisp__iges_index(const iges_file *f, int de)
{
    if (de < 1 || (de & 1) == 0) return -1;
    int i = (de - 1) / 2;
    return i < f->entity_count ? i : -1;
}

const char *crisp__iges_type_name(int type)
{
    switch (type) {
    case 100:
        return "circular arc";
    case 102:
        return "composite curve";
    case 104:
        return "conic arc";
    case 106:
        return "copious data";
    case 108:
        return "plane";
    case 110:
        return "line";
    case 112:
        return "parametric spline curve";
    case 114:
        return "parametric spline surface";
    case 116:
        return "point";
    case 118:
        return "ruled surface";
    case 120:
        return "surface of revolution";
    case 122:
        return "tabulated cylinder";
    case 123:
        return "direction";
    case 124:
        return "transformation matrix";
    case 126:
        return "rational B-spline curve";
    case 128:
        return "rational B-spline surface";
    case 130:
        return "offset curve";
    case 140:
        return "offset surface";
    case 141:
        return "boundary";
    case 142:
        return "curve on a parametric surface";
    case 143:
        return "bounded surface";
    case 144:
        return "trimmed surface";
    case 186:
        return "manifold solid B-rep object";
    case 190:
        return "plane surface";
    case 192:
        return "right circular cylindrical surface";
    case 194:
        return "right circular conical surface";
    case 196:
        return "spherical surface";
    case 198:
        return "toroidal surface";
    case 212:
        return "general note";
    case 308:
        return "subfigure definition";
    case 314:
        return "colour definition";
    case 402:
        return "associativity instance";
    case 406:
        return "property";
    case 408:
        return "singular subfigure instance";
    case 502:
        return "vertex list";
    case 504:
        return "edge list";
    case 508:
        return "loop";
    case 510:
        return "face";
    case 514:
        return "shell";
    }
    return "entity";
}

crisp_status crisp__iges_fail(const iges_file *f, int e, crisp_status st, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    const iges_entity *x = &f->ents[e];
    return crisp_error(st, "%s: DE %d (entity %d %s, line %d): %s", f->name, iges_de(e), x->type,
                       crisp__iges_type_name(x->type), x->p_line ? x->p_line : x->d_line, msg);
}

/* ---- parameter tokeniser -------------------------------------------------------------------- */

/* A cursor over the data columns of a run of records (P: 1-64, G: 1-72); short lines read as if
 * padded with blanks, so Hollerith counts that span records stay right. */
typedef struct cursor {
    const iges_line *lines;
    int line, nlines, col, width;
} cursor;

static int cur_eof(const cursor *c)
{
    return c->line >= c->nlines;
}

static char cur_peek(const cursor *c)
{
    if (cur_eof(c)) return 0;
    const iges_line *l = &c->lines[c->line];
    return c->col < l->len ? l->s[c->col] : ' ';
}

static void cur_next(cursor *c)
{
    if (cur_eof(c)) return;
    if (++c->col >= c->width) {
        c->col = 0;
        c->line++;
    }
}

static int cur_lineno(const cursor *c)
{
    int i = c->line < c->nlines ? c->line : c->nlines - 1;
    return i >= 0 ? c->lines[i].lineno : 0;
}

static crisp_status push_param(iges_file *f, iges_param p)
{
    if (crisp_grow((void **)&f->params, &f->param_cap, (size_t)f->param_count + 1,
                   sizeof *f->params))
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    f->params[f->param_count++] = p;
    return CRISP_OK;
}

/* Parse the text of one number ("1.5D-3", "-2", ".5E+01"). */
static int parse_number(const char *t, int n, double *dest, int *is_int)
{
    char buf[80];
    int k = 0, i = 0, digits = 0, integer = 1;
    if (n <= 0 || n >= (int)sizeof buf) return 0;
    if (t[i] == '+' || t[i] == '-') buf[k++] = t[i++];
    while (i < n && t[i] >= '0' && t[i] <= '9')
        buf[k++] = t[i++], digits++;
    if (i < n && t[i] == '.') {
        integer = 0;
        buf[k++] = t[i++];
        while (i < n && t[i] >= '0' && t[i] <= '9')
            buf[k++] = t[i++], digits++;
    }
    if (!digits) return 0;
    if (i < n && (t[i] == 'E' || t[i] == 'e' || t[i] == 'D' || t[i] == 'd')) {
        integer = 0;
        buf[k++] = 'E';
        i++;
        if (i < n && (t[i] == '+' || t[i] == '-')) buf[k++] = t[i++];
        int ed = 0;
        while (i < n && t[i] >= '0' && t[i] <= '9')
            buf[k++] = t[i++], ed++;
        if (!ed) return 0;
    }
    if (i != n) return 0;
    buf[k] = 0;
    double v = strtod(buf, NULL);
    if (!isfinite(v)) return 0;
    *dest = v;
    *is_int = integer;
    return 1;
}

/* Read one parameter at the cursor (which sits at its first character). Sets *end to 1 when the
 * record delimiter followed it. */
static crisp_status read_param(iges_file *f, cursor *c, char pd, char rd, int *end)
{
    char tok[80];
    int n = 0, start_line = cur_lineno(c);
    while (!cur_eof(c) && cur_peek(c) == ' ')
        cur_next(c);
    /* digits then H: a Hollerith string */
    cursor save = *c;
    int count = 0, nd = 0;
    while (!cur_eof(c) && cur_peek(c) >= '0' && cur_peek(c) <= '9' && nd < 9) {
        count = count * 10 + (cur_peek(c) - '0');
        nd++;
        cur_next(c);
    }
    if (nd > 0 && !cur_eof(c) && (cur_peek(c) == 'H' || cur_peek(c) == 'h')) {
        cur_next(c);
        iges_param p = {.kind = IGES_PARAM_STRING, .str_off = (int)f->strings_len};
        for (int i = 0; i < count; i++) {
            if (cur_eof(c))
                return crisp_error(CRISP_ERR_PARSE,
                                   "%s:%d: Hollerith string of %d characters runs past the end of "
                                   "the section",
                                   f->name, start_line, count);
            if (crisp_grow((void **)&f->strings, &f->strings_cap, f->strings_len + 1, 1))
                return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
            f->strings[f->strings_len++] = cur_peek(c);
            cur_next(c);
        }
        p.str_len = count;
        while (!cur_eof(c) && cur_peek(c) == ' ')
            cur_next(c);
        char d = cur_peek(c);
        if (d != pd && d != rd)
            return crisp_error(CRISP_ERR_PARSE,
                               "%s:%d: expected '%c' or '%c' after a Hollerith string, found '%c'",
                               f->name, cur_lineno(c), pd, rd, d ? d : '?');
        *end = d == rd;
        cur_next(c);
        return push_param(f, p);
    }
    *c = save;
    for (;;) {
        if (cur_eof(c))
            return crisp_error(CRISP_ERR_PARSE, "%s:%d: expected the record delimiter '%c'",
                               f->name, start_line, rd);
        char ch = cur_peek(c);
        if (ch == pd || ch == rd) {
            *end = ch == rd;
            cur_next(c);
            break;
        }
        if (ch != ' ') {
            if (n >= (int)sizeof tok - 1)
                return crisp_error(CRISP_ERR_PARSE, "%s:%d: parameter longer than %d characters",
                                   f->name, cur_lineno(c), (int)sizeof tok - 1);
            tok[n++] = ch;
        }
        cur_next(c);
    }
    iges_param p = {0};
    if (n > 0) {
        p.kind = IGES_PARAM_NUMBER;
        if (!parse_number(tok, n, &p.num, &p.is_integer)) {
            tok[n] = 0;
            return crisp_error(CRISP_ERR_PARSE, "%s:%d: expected a number, found \"%s\"", f->name,
                               start_line, tok);
        }
    }
    return push_param(f, p);
}

/* ---- global section ------------------------------------------------------------------------- */

static double units_from_name(const char *s, int n)
{
    static const struct {
        const char *name;
        double mm;
    } u[] = {{"MM", 1},       {"IN", 25.4}, {"INCH", 25.4},  {"FT", 304.8},
             {"MI", 1609344}, {"M", 1000},  {"KM", 1e6},     {"MIL", 0.0254},
             {"UM", 0.001},   {"CM", 10},   {"UIN", 2.54e-5}};
    for (size_t i = 0; i < sizeof u / sizeof u[0]; i++)
        if ((int)strlen(u[i].name) == n && !strncmp(u[i].name, s, (size_t)n)) return u[i].mm;
    return 1;
}

static crisp_status parse_global(iges_file *f, const iges_lines *g)
{
    f->pdelim = ',';
    f->rdelim = ';';
    f->unit_to_mm = 1;
    if (g->count == 0) return CRISP_OK;
    cursor c = {g->items, 0, g->count, 0, 72};
    /* Parameters 1 and 2 set the delimiters themselves, so read them by hand. */
    for (int k = 0; k < 2; k++) {
        while (!cur_eof(&c) && cur_peek(&c) == ' ')
            cur_next(&c);
        if (cur_eof(&c)) return CRISP_OK;
        char ch = cur_peek(&c);
        if (ch == '1') {
            cur_next(&c);
            if (cur_peek(&c) != 'H' && cur_peek(&c) != 'h')
                return crisp_error(CRISP_ERR_PARSE, "%s:%d: global parameter %d: expected 1H",
                                   f->name, cur_lineno(&c), k + 1);
            cur_next(&c);
            char d = cur_peek(&c);
            if (d == 0 || d == ' ')
                return crisp_error(CRISP_ERR_PARSE,
                                   "%s:%d: global parameter %d: expected a delimiter character",
                                   f->name, cur_lineno(&c), k + 1);
            if (k == 0)
                f->pdelim = d;
            else
                f->rdelim = d;
            cur_next(&c);
            while (!cur_eof(&c) && cur_peek(&c) == ' ')
                cur_next(&c);
            ch = cur_peek(&c);
        }
        if (cur_eof(&c)) return CRISP_OK;
        if (ch == f->rdelim) return CRISP_OK;
        if (ch != f->pdelim)
            return crisp_error(CRISP_ERR_PARSE,
                               "%s:%d: global parameter %d: expected '%c' after the delimiter",
                               f->name, cur_lineno(&c), k + 1, f->pdelim);
        cur_next(&c);
    }
    if (f->pdelim == f->rdelim)
        return crisp_error(CRISP_ERR_PARSE,
                           "%s: global section: parameter and record delimiters are both '%c'",
                           f->name, f->pdelim);
    int first = f->param_count, end = 0;
    while (!end && !cur_eof(&c)) {
        crisp_status st = read_param(f, &c, f->pdelim, f->rdelim, &end);
        if (st) {
            /* a damaged global section costs only the units */
            crisp_error_clear();
            break;
        }
    }
    int n = f->param_count - first;
    const iges_param *p = n > 0 ? f->params + first : NULL; /* p[0] is global parameter 3 */
    if (n >= 12 && p[11].kind == IGES_PARAM_NUMBER && fabs(p[11].num) < 100) {
        static const double flag_mm[] = {0,    25.4, 1,      0,     304.8, 1609344,
                                         1000, 1e6,  0.0254, 0.001, 10,    2.54e-5};
        int flag = (int)p[11].num;
        if (flag >= 1 && flag <= 11 && flag != 3)
            f->unit_to_mm = flag_mm[flag];
        else if (n >= 13 && p[12].kind == IGES_PARAM_STRING && p[12].str_len > 0)
            f->unit_to_mm = units_from_name(f->strings + p[12].str_off, p[12].str_len);
    }
    if (n >= 17 && p[16].kind == IGES_PARAM_NUMBER && p[16].num > 0) f->resolution = p[16].num;
    f->param_count = first; /* the global parameters are not entity parameters */
    return CRISP_OK;
}

/* ---- directory entries ---------------------------------------------------------------------- */

static int de_field(const iges_line *l, int k, int *dest)
{
    int a = 8 * k, b = a + 8, v = 0, sign = 1, digits = 0, i = a;
    if (b > l->len) b = l->len;
    while (i < b && l->s[i] == ' ')
        i++;
    if (i < b && (l->s[i] == '-' || l->s[i] == '+')) sign = l->s[i++] == '-' ? -1 : 1;
    while (i < b && l->s[i] >= '0' && l->s[i] <= '9' && digits < 9)
        v = v * 10 + (l->s[i++] - '0'), digits++;
    while (i < b && l->s[i] == ' ')
        i++;
    if (i != b) return 0;
    *dest = sign * v;
    return 1;
}

static crisp_status parse_directory(iges_file *f, const iges_lines *d)
{
    if (d->count % 2)
        return crisp_error(CRISP_ERR_PARSE,
                           "%s:%d: directory section has %d lines: expected two per entity",
                           f->name, d->items[d->count - 1].lineno, d->count);
    f->entity_count = d->count / 2;
    f->ents = crisp_calloc_array((size_t)f->entity_count + 1, sizeof *f->ents);
    if (!f->ents) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    for (int i = 0; i < f->entity_count; i++) {
        const iges_line *a = &d->items[2 * i], *b = &d->items[2 * i + 1];
        iges_entity *e = &f->ents[i];
        int *fa[9] = {&e->type, &e->param_ptr, &e->structure,     &e->line_font, &e->level,
                      &e->view, &e->transform, &e->label_display, NULL};
        for (int k = 0; k < 8; k++)
            if (!de_field(a, k, fa[k]))
                return crisp_error(CRISP_ERR_PARSE,
                                   "%s:%d: DE %d field %d: expected an integer in columns %d-%d",
                                   f->name, a->lineno, iges_de(i), k + 1, 8 * k + 1, 8 * k + 8);
        int status[4] = {0};
        for (int k = 0; k < 4; k++) {
            for (int j = 0; j < 2; j++) {
                int col = 64 + 2 * k + j;
                char ch = col < a->len ? a->s[col] : ' ';
                if (ch >= '0' && ch <= '9')
                    status[k] = status[k] * 10 + (ch - '0');
                else if (ch != ' ')
                    return crisp_error(CRISP_ERR_PARSE,
                                       "%s:%d: DE %d status: expected digits in columns 65-72",
                                       f->name, a->lineno, iges_de(i));
            }
        }
        e->blank = status[0];
        e->subordinate = status[1];
        e->use = status[2];
        e->hierarchy = status[3];
        int type2 = 0;
        int *fb[5] = {&type2, &e->line_weight, &e->color, &e->param_lines, &e->form};
        for (int k = 0; k < 5; k++)
            if (!de_field(b, k, fb[k]))
                return crisp_error(CRISP_ERR_PARSE,
                                   "%s:%d: DE %d field %d: expected an integer in columns %d-%d",
                                   f->name, b->lineno, iges_de(i), k + 11, 8 * k + 1, 8 * k + 8);
        if (type2 != e->type)
            return crisp_error(CRISP_ERR_PARSE,
                               "%s:%d: DE %d: entity type %d on the second line, expected %d",
                               f->name, b->lineno, iges_de(i), type2, e->type);
        for (int k = 0; k < 8; k++) {
            int col = 56 + k;
            e->label[k] = col < b->len ? b->s[col] : ' ';
        }
        e->label[8] = 0;
        e->d_line = a->lineno;
    }
    return CRISP_OK;
}

/* ---- parameter section ---------------------------------------------------------------------- */

/* The DE back-pointer of a P line, columns 66-72 (0 when blank). */
static int back_pointer(const iges_line *l)
{
    int bp = 0;
    for (int i = 65; i < 72 && i < l->len; i++)
        if (l->s[i] >= '0' && l->s[i] <= '9' && bp < 100000000) bp = bp * 10 + (l->s[i] - '0');
    return bp;
}

/* Tokenise every parameter record in order; a record starts on a fresh line and ends at the
 * record delimiter. record_at[line] is the record that starts on P line `line`. */
static crisp_status parse_parameters(iges_file *f, const iges_lines *p)
{
    int *first_of_line = crisp_malloc_array((size_t)p->count + 1, sizeof *first_of_line);
    int *count_of_line = crisp_malloc_array((size_t)p->count + 1, sizeof *count_of_line);
    int *back_of_line = crisp_malloc_array((size_t)p->count + 1, sizeof *back_of_line);
    char *starts_record = crisp_calloc_array((size_t)p->count + 1, 1);
    if (!first_of_line || !count_of_line || !back_of_line || !starts_record) {
        crisp_free(first_of_line);
        crisp_free(count_of_line);
        crisp_free(back_of_line);
        crisp_free(starts_record);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    }
    for (int i = 0; i < p->count; i++)
        first_of_line[i] = -1;
    /* lines that some DE names as its record's start */
    for (int i = 0; i < f->entity_count; i++) {
        int pl = f->ents[i].param_ptr - 1;
        if (pl >= 0 && pl < p->count) starts_record[pl] = 1;
    }
    crisp_status st = CRISP_OK;
    int line = 0;
    while (line < p->count) {
        /* skip blank lines between records */
        const iges_line *l = &p->items[line];
        int blank = 1;
        for (int i = 0; i < l->len && i < 64; i++)
            if (l->s[i] != ' ') blank = 0;
        if (blank) {
            line++;
            continue;
        }
        cursor c = {p->items, line, p->count, 0, 64};
        int first = f->param_count, end = 0;
        /* back-pointer to the DE, columns 66-72 of the record's first line */
        int bp = back_pointer(l);
        while (!end) {
            st = read_param(f, &c, f->pdelim, f->rdelim, &end);
            if (st) {
                char old[512];
                snprintf(old, sizeof old, "%s", crisp_error_message());
                st = crisp_error(st, "%s (in the parameter record of DE %d)", old, bp);
                goto done;
            }
        }
        first_of_line[line] = first;
        count_of_line[line] = f->param_count - first;
        back_of_line[line] = bp;
        /* the record ends at its delimiter; the rest of that line is ignored, and so are the
         * lines after it that carry the same back-pointer: text after the delimiter is a
         * comment, which may run over several lines (IGES 5.3 section 2.2.4.5) */
        line = c.col == 0 ? c.line : c.line + 1;
        while (bp > 0 && line < p->count && !starts_record[line] &&
               back_pointer(&p->items[line]) == bp)
            line++;
    }
    /* Attach records to entities: by the DE's parameter pointer, else by the back-pointer. */
    for (int i = 0; i < f->entity_count; i++) {
        iges_entity *e = &f->ents[i];
        int pl = e->param_ptr - 1;
        if (pl < 0 || pl >= p->count || first_of_line[pl] < 0) {
            pl = -1;
            for (int j = 0; j < p->count; j++)
                if (first_of_line[j] >= 0 && back_of_line[j] == iges_de(i)) {
                    pl = j;
                    break;
                }
            if (pl < 0) {
                st = crisp_error(CRISP_ERR_PARSE,
                                 "%s:%d: DE %d (entity %d): parameter pointer %d does not start a "
                                 "parameter record (the P section has %d lines)",
                                 f->name, e->d_line, iges_de(i), e->type, e->param_ptr, p->count);
                goto done;
            }
        }
        e->first_param = first_of_line[pl];
        e->param_count = count_of_line[pl];
        e->p_line = p->items[pl].lineno;
        const iges_param *t = &f->params[e->first_param];
        if (e->param_count < 1 || t->kind != IGES_PARAM_NUMBER || t->num != e->type) {
            st = crisp_error(CRISP_ERR_PARSE,
                             "%s:%d: DE %d: parameter record starts with %g, expected the entity "
                             "type %d",
                             f->name, e->p_line, iges_de(i),
                             e->param_count >= 1 && t->kind == IGES_PARAM_NUMBER ? t->num : -1.0,
                             e->type);
            goto done;
        }
    }
done:
    crisp_free(first_of_line);
    crisp_free(count_of_line);
    crisp_free(back_of_line);
    crisp_free(starts_record);
    return st;
}

/* ---- the file ------------------------------------------------------------------------------- */

crisp_status crisp__iges_file_parse(const char *name, const char *data, size_t size,
                                    iges_file *dest)
{
    memset(dest, 0, sizeof *dest);
    dest->name = name;
    dest->unit_to_mm = 1;
    iges_lines sec[5] = {{0}}; /* S G D P T */
    crisp_status st = CRISP_OK;
    if (size > (size_t)1 << 30)
        return crisp_error(CRISP_ERR_LIMIT, "%s: file of %zu bytes is larger than 1 GiB", name,
                           size);
    /* Records without line terminators: 80-byte blocks. */
    int blocks = size >= 80 && !memchr(data, '\n', size < 160 ? size : 160) &&
                 !memchr(data, '\r', size < 160 ? size : 160);
    size_t pos = 0;
    int lineno = 0;
    char last = 0;
    while (pos < size) {
        size_t len, next;
        if (blocks) {
            len = size - pos < 80 ? size - pos : 80;
            next = pos + len;
        } else {
            len = 0;
            while (pos + len < size && data[pos + len] != '\n' && data[pos + len] != '\r')
                len++;
            next = pos + len;
            if (next < size && data[next] == '\r') next++;
            if (next < size && data[next] == '\n') next++;
        }
        lineno++;
        const char *s = data + pos;
        pos = next;
        int n = len > 200 ? 200 : (int)len;
        while (n > 0 && (s[n - 1] == ' ' || s[n - 1] == '\t' || s[n - 1] == 0))
            n--;
        if (n == 0) continue;
        char letter = section_letter(s, n);
        int k;
        switch (letter) {
        case 'S':
            k = 0;
            break;
        case 'G':
            k = 1;
            break;
        case 'D':
            k = 2;
            break;
        case 'P':
            k = 3;
            break;
        case 'T':
            k = 4;
            break;
        case 'C':
            st = crisp_error(CRISP_ERR_UNSUPPORTED,
                             "%s:%d: compressed IGES (C section) is not "
                             "supported",
                             name, lineno);
            goto fail;
        case 'B':
            st = crisp_error(CRISP_ERR_UNSUPPORTED, "%s:%d: binary IGES is not supported", name,
                             lineno);
            goto fail;
        default:
            st = crisp_error(CRISP_ERR_PARSE,
                             "%s:%d: expected a section letter S, G, D, P or T in column 73", name,
                             lineno);
            goto fail;
        }
        if (last && letter != last) {
            static const char order[] = "SGDPT";
            if (strchr(order, letter) < strchr(order, last)) {
                st = crisp_error(CRISP_ERR_PARSE,
                                 "%s:%d: section %c after section %c: expected the order S G D P "
                                 "T",
                                 name, lineno, letter, last);
                goto fail;
            }
        }
        last = letter;
        if (k == 4) break;
        if ((st = lines_push(&sec[k], s, n, lineno))) goto fail;
    }
    if (sec[2].count == 0) {
        st = crisp_error(CRISP_ERR_PARSE, "%s: no directory (D) section: not an IGES file", name);
        goto fail;
    }
    if ((st = parse_global(dest, &sec[1]))) goto fail;
    if ((st = parse_directory(dest, &sec[2]))) goto fail;
    if ((st = parse_parameters(dest, &sec[3]))) goto fail;
    for (int i = 0; i < 5; i++)
        crisp_free(sec[i].items);
    return CRISP_OK;
fail:
    for (int i = 0; i < 5; i++)
        crisp_free(sec[i].items);
    crisp__iges_file_free(dest);
    return st;
}

void crisp__iges_file_free(iges_file *f)
{
    crisp_free(f->ents);
    crisp_free(f->params);
    crisp_free(f->strings);
    f->ents = NULL;
    f->params = NULL;
    f->strings = NULL;
    f->entity_count = f->param_count = 0;
}

void crisp__iges_file_reset(iges_file *f)
{
    for (int i = 0; i < f->entity_count; i++) {
        iges_entity *e = &f->ents[i];
        e->visiting = e->used = e->consumed = e->in_subfigure = 0;
    }
    f->first_error = CRISP_OK;
    f->first_message[0] = 0;
    f->blanked_faces = 0;
}

/* ---- parameter access ----------------------------------------------------------------------- */

int crisp__iges_nparams(const iges_file *f, int e)
{
    return f->ents[e].param_count - 1;
}

static const iges_param *param_at(const iges_file *f, int e, int k)
{
    if (k < 1 || k > crisp__iges_nparams(f, e)) return NULL;
    return &f->params[f->ents[e].first_param + k];
}

crisp_status crisp__iges_need(const iges_file *f, int e, int k, const char *what)
{
    if (k > crisp__iges_nparams(f, e))
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE, "%s needs %d parameters, the record has %d",
                                what, k, crisp__iges_nparams(f, e));
    return CRISP_OK;
}

crisp_status crisp__iges_real_def(const iges_file *f, int e, int k, double def, double *dest)
{
    const iges_param *p = param_at(f, e, k);
    if (!p || p->kind == IGES_PARAM_DEFAULT) {
        *dest = def;
        return CRISP_OK;
    }
    if (p->kind != IGES_PARAM_NUMBER)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter %d: expected a number, found a string", k);
    *dest = p->num;
    return CRISP_OK;
}

crisp_status crisp__iges_real(const iges_file *f, int e, int k, double *dest)
{
    if (!param_at(f, e, k))
        return crisp__iges_fail(
            f, e, CRISP_ERR_PARSE,
            "parameter %d: expected a number, the record has only %d parameters", k,
            crisp__iges_nparams(f, e));
    return crisp__iges_real_def(f, e, k, 0, dest);
}

crisp_status crisp__iges_int_def(const iges_file *f, int e, int k, int def, int *dest)
{
    const iges_param *p = param_at(f, e, k);
    if (!p || p->kind == IGES_PARAM_DEFAULT) {
        *dest = def;
        return CRISP_OK;
    }
    if (p->kind != IGES_PARAM_NUMBER || p->num != floor(p->num) || fabs(p->num) > 2e9)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE, "parameter %d: expected an integer", k);
    *dest = (int)p->num;
    return CRISP_OK;
}

crisp_status crisp__iges_int(const iges_file *f, int e, int k, int *dest)
{
    if (!param_at(f, e, k))
        return crisp__iges_fail(
            f, e, CRISP_ERR_PARSE,
            "parameter %d: expected an integer, the record has only %d parameters", k,
            crisp__iges_nparams(f, e));
    return crisp__iges_int_def(f, e, k, 0, dest);
}

crisp_status crisp__iges_int_range(const iges_file *f, int e, int k, int lo, int hi, int *dest)
{
    crisp_status st = crisp__iges_int(f, e, k, dest);
    if (st) return st;
    if (*dest < lo || *dest > hi)
        return crisp__iges_fail(f, e, CRISP_ERR_LIMIT, "parameter %d is %d, expected %d to %d", k,
                                *dest, lo, hi);
    return CRISP_OK;
}

crisp_status crisp__iges_ptr(const iges_file *f, int e, int k, int allow_null, int *dest)
{
    int de;
    crisp_status st = crisp__iges_int(f, e, k, &de);
    if (st) return st;
    if (de < 0) de = -de; /* negative pointers mark "pointer, not a value" in some fields */
    if (de == 0 && allow_null) {
        *dest = -1;
        return CRISP_OK;
    }
    int i = crisp__iges_index(f, de);
    if (i < 0)
        return crisp__iges_fail(
            f, e, CRISP_ERR_PARSE,
            "parameter %d: pointer %d does not name a directory entry (expected an "
            "odd number from 1 to %d)",
            k, de, 2 * f->entity_count - 1);
    *dest = i;
    return CRISP_OK;
}
