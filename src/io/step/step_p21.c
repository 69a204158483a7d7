/* ISO 10303-21 (STEP Part 21 exchange structure) lexer and parser into an entity table.
 * Follows ISO 10303-21:2016 clauses 5-9: HEADER and DATA sections, comments, strings with ''
 * escapes (\X\, \X2\ ... encodings are kept as bytes), enumerations, typed parameters, omitted ($)
 * and derived (*) values, nested lists, simple and complex entity instances, forward references.
 * Leniencies real files need: section keywords in any case, a lone quote inside a string, entity
 * numbers beyond any entity, identical duplicate instances, and a broken DATA instance skipped up
 * to the end of its line's ';' (counted; the first error is kept for the reader).
 *
 * All values live in one growable array (a list's elements are contiguous: they are collected on
 * a stack and copied when the list closes), so parsing allocates O(log n) times, never per token.
 */
#include "step_internal.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_NESTING 64

typedef struct parser {
    step_file *f;
    const char *s; /* text (NUL-terminated) */
    size_t pos, size;
    int line;
    size_t line_start;
    step_value *stack; /* pending list elements */
    size_t stack_len, stack_cap;
} parser;

static crisp_status perr(parser *p, const char *what)
{
    return crisp_error(CRISP_ERR_PARSE, "%s: line %d, column %d: %s", p->f->name, p->line,
                       (int)(p->pos - p->line_start) + 1, what);
}

/* Skip white space and comments. */
static crisp_status skip(parser *p)
{
    for (;;) {
        char c = p->s[p->pos];
        if (c == '\n') {
            p->line++;
            p->pos++;
            p->line_start = p->pos;
        } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
            p->pos++;
        } else if (c == '/' && p->s[p->pos + 1] == '*') {
            p->pos += 2;
            for (;;) {
                if (p->pos >= p->size) return perr(p, "unterminated comment (expected */)");
                if (p->s[p->pos] == '*' && p->s[p->pos + 1] == '/') {
                    p->pos += 2;
                    break;
                }
                if (p->s[p->pos] == '\n') {
                    p->line++;
                    p->line_start = p->pos + 1;
                }
                p->pos++;
            }
        } else {
            return CRISP_OK;
        }
    }
}

static int is_kw_start(char c)
{
    return isupper((unsigned char)c) || islower((unsigned char)c) || c == '_' || c == '!';
}
static int is_kw_char(char c)
{
    return isalnum((unsigned char)c) || c == '_' || c == '-';
}

/* A keyword at the current position: upper-cased in place (Part 21 keywords are upper case; some
 * writers are careless), returned as offset and length. */
static crisp_status keyword(parser *p, uint32_t *off, uint32_t *len)
{
    size_t b = p->pos;
    if (!is_kw_start(p->s[b])) return perr(p, "expected a keyword");
    size_t e = b + 1;
    while (is_kw_char(p->s[e]))
        e++;
    for (size_t i = b; i < e; i++)
        p->f->text[i] = (char)toupper((unsigned char)p->f->text[i]);
    *off = (uint32_t)b;
    *len = (uint32_t)(e - b);
    p->pos = e;
    return CRISP_OK;
}

static int expect_char(parser *p, char c)
{
    if (skip(p) != CRISP_OK) return 0;
    if (p->s[p->pos] != c) return 0;
    p->pos++;
    return 1;
}

static crisp_status push(parser *p, const step_value *v)
{
    if (p->stack_len == p->stack_cap && crisp_grow((void **)&p->stack, &p->stack_cap,
                                                   p->stack_len + 1, sizeof *p->stack) != CRISP_OK)
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", p->f->name);
    p->stack[p->stack_len++] = *v;
    return CRISP_OK;
}

/* Move the top n stack values into the value array; returns the index of the first. */
static crisp_status emit(parser *p, size_t n, uint32_t *first)
{
    step_file *f = p->f;
    if (f->value_count + n > UINT32_MAX / 2)
        return crisp_error(CRISP_ERR_LIMIT, "%s: too many values", f->name);
    if (f->value_count + n > f->value_cap &&
        crisp_grow((void **)&f->values, &f->value_cap, f->value_count + n, sizeof *f->values) !=
            CRISP_OK)
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    if (n) memcpy(f->values + f->value_count, p->stack + p->stack_len - n, n * sizeof *f->values);
    *first = (uint32_t)f->value_count;
    f->value_count += n;
    p->stack_len -= n;
    return CRISP_OK;
}

static crisp_status parse_list(parser *p, int depth, step_value *out);

/* One parameter value at the current position (after white space). */
static crisp_status parse_value(parser *p, int depth, step_value *v)
{
    crisp_status st = skip(p);
    if (st) return st;
    memset(v, 0, sizeof *v);
    const char *s = p->s;
    char c = s[p->pos];
    if (c == '$') {
        v->kind = STEP_OMITTED;
        p->pos++;
    } else if (c == '*') {
        v->kind = STEP_DERIVED;
        p->pos++;
    } else if (c == '#') {
        size_t b = ++p->pos;
        double id = 0;
        while (isdigit((unsigned char)s[p->pos]))
            id = id * 10 + (s[p->pos++] - '0');
        if (p->pos == b) return perr(p, "expected an entity number after #");
        /* A number beyond any entity (#18446744073709551615, a writer's "none") parses as a
         * reference that resolves to nothing: the entity using it fails, not the file. */
        v->kind = STEP_REF;
        v->num = id;
    } else if (c == '\'') {
        size_t b = ++p->pos;
        for (;;) {
            if (p->pos >= p->size) return perr(p, "unterminated string (expected ')");
            if (s[p->pos] == '\'') {
                if (s[p->pos + 1] == '\'') {
                    p->pos += 2;
                    continue;
                }
                /* A quote ends the string only where a string can end (before , ) or ;, maybe
                 * after white space). Some writers leave a lone quote inside a string
                 * (bug28454_directives.stp: ...\X0\'h...); readers accept it as a character. */
                size_t q = p->pos + 1;
                while (s[q] == ' ' || s[q] == '\t' || s[q] == '\r' || s[q] == '\n')
                    q++;
                if (s[q] == ',' || s[q] == ')' || s[q] == ';' || s[q] == '\0' || s[q] == '/') break;
            }
            if (s[p->pos] == '\n') {
                p->line++;
                p->line_start = p->pos + 1;
            }
            p->pos++;
        }
        v->kind = STEP_STRING;
        v->off = (uint32_t)b;
        v->len = (uint32_t)(p->pos - b);
        p->pos++;
    } else if (c == '"') {
        size_t b = ++p->pos;
        while (isxdigit((unsigned char)s[p->pos]))
            p->pos++;
        if (s[p->pos] != '"') return perr(p, "expected \" closing a binary value");
        v->kind = STEP_BINARY;
        v->off = (uint32_t)b;
        v->len = (uint32_t)(p->pos - b);
        p->pos++;
    } else if (c == '.' && is_kw_start(s[p->pos + 1])) {
        size_t b = ++p->pos;
        while (is_kw_char(s[p->pos]))
            p->pos++;
        if (s[p->pos] != '.') return perr(p, "expected . closing an enumeration");
        v->kind = STEP_ENUM;
        v->off = (uint32_t)b;
        v->len = (uint32_t)(p->pos - b);
        for (size_t i = b; i < p->pos; i++)
            p->f->text[i] = (char)toupper((unsigned char)s[i]);
        p->pos++;
    } else if (c == '+' || c == '-' || c == '.' || isdigit((unsigned char)c)) {
        size_t b = p->pos;
        size_t e = b;
        if (s[e] == '+' || s[e] == '-') e++;
        int digits = 0, is_real = 0;
        while (isdigit((unsigned char)s[e]))
            e++, digits++;
        if (s[e] == '.') {
            is_real = 1;
            e++;
            while (isdigit((unsigned char)s[e]))
                e++, digits++;
        }
        if (!digits) return perr(p, "expected a number");
        if (s[e] == 'E' || s[e] == 'e') {
            size_t x = e + 1;
            if (s[x] == '+' || s[x] == '-') x++;
            if (isdigit((unsigned char)s[x])) {
                is_real = 1;
                while (isdigit((unsigned char)s[x]))
                    x++;
                e = x;
            }
        }
        /* strtod stops at the token end: the text is NUL-terminated and the token is checked. */
        char *end = NULL;
        v->num = strtod(s + b, &end);
        if (end != s + e) {
            p->pos = e;
            return perr(p, "malformed number");
        }
        v->kind = is_real ? STEP_REAL : STEP_INT;
        p->pos = e;
    } else if (c == '(') {
        return parse_list(p, depth + 1, v);
    } else if (is_kw_start(c)) {
        uint32_t off, len;
        if ((st = keyword(p, &off, &len))) return st;
        if (!expect_char(p, '(')) return perr(p, "expected ( after a type name");
        p->pos--;
        step_value inner;
        if ((st = parse_list(p, depth + 1, &inner))) return st;
        if (inner.len != 1) return perr(p, "expected exactly one value in a typed parameter");
        v->kind = STEP_TYPED;
        v->off = off;
        v->len = len;
        v->first = inner.first;
    } else {
        return perr(p, p->pos >= p->size ? "unexpected end of file (expected a value)"
                                         : "expected a value ($, *, #n, number, 'string', .ENUM., "
                                           "list or typed value)");
    }
    return CRISP_OK;
}

/* ( v, v, ... ) at the current position; out becomes a STEP_LIST. */
static crisp_status parse_list(parser *p, int depth, step_value *out)
{
    if (depth > MAX_NESTING) return perr(p, "lists nested too deeply");
    crisp_status st = skip(p);
    if (st) return st;
    if (p->s[p->pos] != '(') return perr(p, "expected (");
    p->pos++;
    size_t base = p->stack_len;
    if ((st = skip(p))) return st;
    if (p->s[p->pos] != ')') {
        for (;;) {
            step_value v;
            if ((st = parse_value(p, depth, &v))) return st;
            if ((st = push(p, &v))) return st;
            if ((st = skip(p))) return st;
            char c = p->s[p->pos];
            if (c == ',') {
                p->pos++;
                continue;
            }
            if (c == ')') break;
            return perr(p, p->pos >= p->size ? "unexpected end of file (expected , or ))"
                                             : "expected , or ) in a parameter list");
        }
    }
    p->pos++;
    memset(out, 0, sizeof *out);
    out->kind = STEP_LIST;
    out->len = (uint32_t)(p->stack_len - base);
    return emit(p, p->stack_len - base, &out->first);
}

static crisp_status add_part(parser *p, uint32_t off, uint32_t len, uint32_t params)
{
    step_file *f = p->f;
    if (f->part_count == f->part_cap && crisp_grow((void **)&f->parts, &f->part_cap,
                                                   f->part_count + 1, sizeof *f->parts) != CRISP_OK)
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    f->parts[f->part_count++] = (step_part){off, len, params};
    return CRISP_OK;
}

/* NAME(params) -> one part. */
static crisp_status parse_part(parser *p)
{
    uint32_t off, len;
    crisp_status st = skip(p);
    if (st) return st;
    if ((st = keyword(p, &off, &len))) return st;
    step_value list;
    if ((st = parse_list(p, 1, &list))) return st;
    /* The part refers to its parameter list through one more value slot. */
    if ((st = push(p, &list))) return st;
    uint32_t idx;
    if ((st = emit(p, 1, &idx))) return st;
    return add_part(p, off, len, idx);
}

static int word_at(const parser *p, const char *w)
{
    size_t n = strlen(w);
    if (p->pos + n > p->size) return 0;
    /* Section keywords in any case (bug31000_InSensitive.stp writes Header;): readers accept it. */
    for (size_t i = 0; i < n; i++)
        if (toupper((unsigned char)p->s[p->pos + i]) != w[i]) return 0;
    return !is_kw_char(p->s[p->pos + n]);
}

/* #id = instance ; */
static crisp_status parse_instance(parser *p)
{
    step_file *f = p->f;
    int line = p->line;
    step_value ref;
    crisp_status st = parse_value(p, 0, &ref);
    if (st) return st;
    if (ref.kind != STEP_REF) return perr(p, "expected #n at the start of an entity instance");
    if (ref.num > 2147483647.0 || ref.num < 1)
        return perr(p, "entity number out of range (expected 1 to 2147483647)");
    if (!expect_char(p, '=')) return perr(p, "expected = after the entity number");
    if ((st = skip(p))) return st;
    size_t src = p->pos;
    uint32_t first = (uint32_t)f->part_count;
    if (p->s[p->pos] == '(') {
        p->pos++;
        for (;;) {
            if ((st = skip(p))) return st;
            if (p->s[p->pos] == ')') break;
            if (p->pos >= p->size) return perr(p, "unexpected end of file in a complex entity");
            if ((st = parse_part(p))) return st;
        }
        p->pos++;
        if (f->part_count == first) return perr(p, "empty complex entity");
    } else if ((st = parse_part(p))) {
        return st;
    }
    if (!expect_char(p, ';')) return perr(p, "expected ; after an entity instance");
    if (f->entity_count == f->entity_cap &&
        crisp_grow((void **)&f->entities, &f->entity_cap, f->entity_count + 1, sizeof *f->entities))
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    f->entities[f->entity_count++] = (step_entity){(int)ref.num,  line,
                                                   first,         (uint32_t)f->part_count - first,
                                                   (uint32_t)src, (uint32_t)(p->pos - src)};
    return CRISP_OK;
}

/* Header entity: NAME(params); (kept only for syntax checking). */
static crisp_status parse_header_entity(parser *p)
{
    size_t parts = p->f->part_count;
    crisp_status st = parse_part(p);
    if (st) return st;
    p->f->part_count = parts;
    if (!expect_char(p, ';')) return perr(p, "expected ; after a header entity");
    return CRISP_OK;
}

/* The id -> entity hash. An entity defined twice with the same text (bug25013_25013faces.stp
 * repeats a few lines) keeps its first copy and is counted; two different definitions are an
 * error, since either could be meant. */
static crisp_status build_map(step_file *f)
{
    size_t cap = 16;
    while (cap < f->entity_count * 2)
        cap *= 2;
    f->map = crisp_calloc_array(cap, sizeof *f->map);
    if (!f->map) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    f->map_cap = cap;
    size_t kept = 0;
    for (size_t i = 0; i < f->entity_count; i++) {
        step_entity e = f->entities[i];
        unsigned id = (unsigned)e.id;
        size_t h = (id * 2654435761u) & (cap - 1);
        int dup = 0;
        while (f->map[h]) {
            const step_entity *o = &f->entities[f->map[h] - 1];
            if (o->id == (int)id) {
                if (o->src_len != e.src_len ||
                    memcmp(f->text + o->src_off, f->text + e.src_off, e.src_len) != 0)
                    return crisp_error(CRISP_ERR_PARSE,
                                       "%s: line %d: entity #%u defined twice (first on line %d)",
                                       f->name, e.line, id, o->line);
                dup = 1;
                break;
            }
            h = (h + 1) & (cap - 1);
        }
        if (dup) {
            if (!f->duplicates++) f->first_duplicate = (int)id;
            continue;
        }
        f->entities[kept] = e;
        f->map[h] = (int)kept + 1;
        kept++;
    }
    f->entity_count = kept;
    return CRISP_OK;
}

const step_entity *crisp__step_find(const step_file *f, double idv)
{
    if (!f->map_cap || !(idv >= 1 && idv <= 2147483647.0)) return NULL;
    int id = (int)idv;
    size_t h = ((unsigned)id * 2654435761u) & (f->map_cap - 1);
    while (f->map[h]) {
        const step_entity *e = &f->entities[f->map[h] - 1];
        if (e->id == id) return e;
        h = (h + 1) & (f->map_cap - 1);
    }
    return NULL;
}

/* Error recovery inside the DATA section: an instance that does not parse (bug32314_corrupted.stp
 * has text overwritten in the middle of one) is skipped up to the ';' that ends a line before the
 * next "#n" instance, and counted; the first error is kept for the reader's notes (and as the
 * error when nothing else can be read). Returns 0 (the error stands) when there is no such
 * place, when the file ends first, or after too many broken instances. */
#define MAX_BROKEN 100

static int skip_instance(parser *p, size_t at, int line)
{
    step_file *f = p->f;
    if (f->broken >= MAX_BROKEN) return 0;
    if (!f->broken) {
        snprintf(f->first_broken, sizeof f->first_broken, "%s", crisp_error_message());
        f->first_broken_line = line;
    }
    size_t i = at + 1;
    for (; i < p->size; i++) {
        if (p->s[i] != ';') continue;
        size_t j = i + 1;
        while (j < p->size && (p->s[j] == ' ' || p->s[j] == '\t' || p->s[j] == '\r'))
            j++;
        if (j < p->size && p->s[j] == '\n') {
            while (j < p->size && isspace((unsigned char)p->s[j]))
                j++;
            if (p->s[j] == '#' ||
                word_at(&(parser){.s = p->s, .pos = j, .size = p->size}, "ENDSEC"))
                break;
        }
    }
    if (i >= p->size) return 0;
    /* Lines passed over, for the positions of later messages. */
    for (size_t k = p->pos > at ? at : p->pos; k <= i; k++)
        if (p->s[k] == '\n' && k >= p->line_start) p->line++, p->line_start = k + 1;
    p->pos = i + 1;
    f->broken++;
    crisp_error_clear();
    return 1;
}

static crisp_status parse_all(parser *p)
{
    crisp_status st = skip(p);
    if (st) return st;
    if (!word_at(p, "ISO-10303-21")) return perr(p, "expected ISO-10303-21; (not a STEP file)");
    p->pos += 12;
    if (!expect_char(p, ';')) return perr(p, "expected ; after ISO-10303-21");
    int in_data = 0, in_header = 0, saw_data = 0;
    for (;;) {
        if ((st = skip(p))) return st;
        if (p->pos >= p->size)
            return perr(p, "unexpected end of file (expected END-ISO-10303-21;)");
        char c = p->s[p->pos];
        if (c == '#') {
            if (!in_data) return perr(p, "entity instance outside the DATA section");
            size_t at = p->pos, parts = p->f->part_count, stack = p->stack_len;
            int line = p->line;
            if ((st = parse_instance(p))) {
                if (st == CRISP_ERR_NO_MEMORY || !skip_instance(p, at, line)) return st;
                /* Drop what the broken instance left behind and go on with the next one. */
                p->f->part_count = parts;
                p->stack_len = stack;
            }
            continue;
        }
        if (word_at(p, "END-ISO-10303-21")) {
            if (in_data || in_header)
                return perr(p, "END-ISO-10303-21 inside a section (expected ENDSEC;)");
            p->pos += 16;
            if (!expect_char(p, ';')) return perr(p, "expected ; after END-ISO-10303-21");
            break;
        }
        if (word_at(p, "ENDSEC")) {
            if (!in_data && !in_header) return perr(p, "ENDSEC outside a section");
            p->pos += 6;
            if (!expect_char(p, ';')) return perr(p, "expected ; after ENDSEC");
            in_data = in_header = 0;
            continue;
        }
        if (in_data || in_header) {
            if (in_data) return perr(p, "expected #n = entity instance or ENDSEC;");
            if ((st = parse_header_entity(p))) return st;
            continue;
        }
        if (word_at(p, "HEADER")) {
            p->pos += 6;
            if (!expect_char(p, ';')) return perr(p, "expected ; after HEADER");
            in_header = 1;
            continue;
        }
        if (word_at(p, "DATA")) {
            p->pos += 4;
            if ((st = skip(p))) return st;
            if (p->s[p->pos] == '(') { /* DATA('name', (schemas)); of Part 21 edition 3 */
                step_value v;
                if ((st = parse_list(p, 1, &v))) return st;
            }
            if (!expect_char(p, ';')) return perr(p, "expected ; after DATA");
            in_data = saw_data = 1;
            continue;
        }
        return perr(p, "expected HEADER;, DATA;, ENDSEC; or END-ISO-10303-21;");
    }
    if (!saw_data) return perr(p, "no DATA section");
    return CRISP_OK;
}

crisp_status crisp__step_parse(const char *name, const char *data, size_t size, step_file *dest)
{
    memset(dest, 0, sizeof *dest);
    dest->name = name ? name : "(memory)";
    if (size >= UINT32_MAX - 16)
        return crisp_error(CRISP_ERR_LIMIT, "%s: file too large (%zu bytes; the limit is 4 GB)",
                           dest->name, size);
    /* A private NUL-terminated copy, with slack so lookahead of two characters stays inside. */
    dest->text = crisp_malloc_array(size + 4, 1);
    if (!dest->text) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", dest->name);
    if (size) memcpy(dest->text, data, size);
    memset(dest->text + size, 0, 4);
    dest->size = size;
    /* A NUL inside the data ends it: no valid Part 21 file contains one. */
    size_t n = strlen(dest->text);
    parser p = {.f = dest, .s = dest->text, .size = n, .line = 1};
    crisp_status st = parse_all(&p);
    if (st && st != CRISP_ERR_NO_MEMORY && dest->broken) {
        /* The first broken place is the one to show; the text did not recover after it. */
        char later[200];
        const char *msg = crisp_error_message();
        size_t nl = strlen(dest->name);
        if (strncmp(msg, dest->name, nl) == 0 && msg[nl] == ':') msg += nl + 2;
        snprintf(later, sizeof later, "%s", msg);
        st = crisp_error(CRISP_ERR_PARSE, "%s (and the text stays broken: %s)", dest->first_broken,
                         later);
    }
    crisp_free(p.stack);
    if (!st) st = build_map(dest);
    if (st) crisp__step_file_free(dest);
    return st;
}

void crisp__step_file_free(step_file *f)
{
    if (!f) return;
    crisp_free(f->text);
    crisp_free(f->values);
    crisp_free(f->parts);
    crisp_free(f->entities);
    crisp_free(f->map);
    const char *name = f->name;
    memset(f, 0, sizeof *f);
    f->name = name;
}
