/* Reader for infix math strings (docs/design.md section 7; the shunting-yard parser of Keeter's
 * 2012 fab-modules solver, parser.cpp). Iterative: operator and operand stacks grow on the heap, so
 * a million-node expression needs no recursion. Logic is turned into the distance form (inside is
 * value < 0): a < b -> a - b, a > b -> b - a, && -> max, || -> min, ! -> negation,
 * a == b -> |a - b|, a != b -> -|a - b|. */
#include "crisp/frep.h"
#include "crisp/io.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum {
    K_PAREN, /* '(' */
    K_FUNC,  /* function name waiting for its '(' ... ')' */
    K_UNARY, /* prefix - + ! */
    K_BINARY /* infix operator */
};
enum { B_ADD, B_SUB, B_MUL, B_DIV, B_POW, B_LT, B_LE, B_GT, B_GE, B_EQ, B_NE, B_AND, B_OR };
enum { U_NEG, U_PLUS, U_NOT };

typedef struct m_op {
    uint8_t kind, code;
    uint8_t func_open; /* K_PAREN: belongs to a function call */
    int func;          /* K_FUNC: index into funcs; K_PAREN: index of the function entry or -1 */
    size_t args;       /* K_PAREN of a function: arguments seen */
    size_t line, col;
} m_op;

typedef struct m_func {
    const char *name;
    int args; /* -1: two or more (min, max) */
    crisp_frep_op op;
} m_func;

static const m_func funcs[] = {{"sqrt", 1, CRISP_FREP_SQRT},    {"abs", 1, CRISP_FREP_ABS},
                               {"exp", 1, CRISP_FREP_EXP},      {"log", 1, CRISP_FREP_LN},
                               {"ln", 1, CRISP_FREP_LN},        {"sin", 1, CRISP_FREP_SIN},
                               {"cos", 1, CRISP_FREP_COS},      {"tan", 1, CRISP_FREP_TAN},
                               {"asin", 1, CRISP_FREP_ASIN},    {"acos", 1, CRISP_FREP_ACOS},
                               {"atan", 1, CRISP_FREP_ATAN},    {"atan2", 2, CRISP_FREP_ATAN2},
                               {"pow", 2, CRISP_FREP_OP_COUNT}, {"min", -1, CRISP_FREP_MIN},
                               {"max", -1, CRISP_FREP_MAX},     {"square", 1, CRISP_FREP_SQUARE},
                               {"floor", 1, CRISP_FREP_FLOOR},  {"ceil", 1, CRISP_FREP_CEIL},
                               {"round", 1, CRISP_FREP_ROUND},  {"mod", 2, CRISP_FREP_MOD}};
#define NFUNCS (sizeof funcs / sizeof funcs[0])

/* precedence (higher binds tighter) and right-associativity */
static int prec(const m_op *o)
{
    if (o->kind == K_UNARY) return 7;
    switch (o->code) {
    case B_POW:
        return 6;
    case B_MUL:
    case B_DIV:
        return 5;
    case B_ADD:
    case B_SUB:
        return 4;
    case B_AND:
        return 2;
    case B_OR:
        return 1;
    default:
        return 3; /* comparisons */
    }
}

typedef struct m_parser {
    const char *name;
    crisp_frep *f;
    crisp_frep_node *vals;
    size_t nvals, vcap;
    m_op *ops;
    size_t nops, ocap;
} m_parser;

static crisp_status push_val(m_parser *p, crisp_frep_node v)
{
    if (crisp_grow((void **)&p->vals, &p->vcap, p->nvals + 1, sizeof *p->vals))
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", p->name);
    p->vals[p->nvals++] = v;
    return CRISP_OK;
}

static crisp_status push_op(m_parser *p, m_op o)
{
    if (crisp_grow((void **)&p->ops, &p->ocap, p->nops + 1, sizeof *p->ops))
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", p->name);
    p->ops[p->nops++] = o;
    return CRISP_OK;
}

/* a ^ b: integer constant exponents by repeated squaring, 0.5 by sqrt, else exp(b ln a). */
static crisp_status make_pow(crisp_frep *f, crisp_frep_node a, crisp_frep_node b, float bv,
                             int bconst, crisp_frep_node *dest)
{
    crisp_status s;
    if (bconst && bv == floorf(bv) && fabsf(bv) <= 1024) {
        long n = labs((long)bv);
        crisp_frep_node acc, base = a;
        if ((s = crisp_frep_const(f, 1.0f, &acc))) return s;
        int first = 1;
        while (n) {
            if (n & 1) {
                if (first)
                    acc = base, first = 0;
                else if ((s = crisp_frep_binary(f, CRISP_FREP_MUL, acc, base, &acc)))
                    return s;
            }
            n >>= 1;
            if (n && (s = crisp_frep_unary(f, CRISP_FREP_SQUARE, base, &base))) return s;
        }
        if (bv < 0) {
            crisp_frep_node one;
            if ((s = crisp_frep_const(f, 1.0f, &one))) return s;
            return crisp_frep_binary(f, CRISP_FREP_DIV, one, acc, dest);
        }
        *dest = acc;
        return CRISP_OK;
    }
    if (bconst && bv == 0.5f) return crisp_frep_unary(f, CRISP_FREP_SQRT, a, dest);
    crisp_frep_node l;
    if ((s = crisp_frep_unary(f, CRISP_FREP_LN, a, &l))) return s;
    if ((s = crisp_frep_binary(f, CRISP_FREP_MUL, b, l, &l))) return s;
    return crisp_frep_unary(f, CRISP_FREP_EXP, l, dest);
}

/* Pop and apply the operator on top of the stack. */
static crisp_status apply(m_parser *p)
{
    m_op o = p->ops[--p->nops];
    crisp_frep *f = p->f;
    crisp_status s = CRISP_OK;
    size_t need = o.kind == K_UNARY ? 1 : 2;
    if (p->nvals < need) /* cannot happen with the state machine; kept as a guard */
        return crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: missing operand", p->name, o.line, o.col);
    crisp_frep_node r;
    if (o.kind == K_UNARY) {
        crisp_frep_node a = p->vals[p->nvals - 1];
        if (o.code == U_PLUS) return CRISP_OK;
        s = crisp_frep_unary(f, CRISP_FREP_NEG, a, &r);
        if (!s) p->vals[p->nvals - 1] = r;
        return s;
    }
    crisp_frep_node a = p->vals[p->nvals - 2], b = p->vals[p->nvals - 1];
    switch (o.code) {
    case B_ADD:
        s = crisp_frep_binary(f, CRISP_FREP_ADD, a, b, &r);
        break;
    case B_SUB:
    case B_LT:
    case B_LE:
        s = crisp_frep_binary(f, CRISP_FREP_SUB, a, b, &r);
        break;
    case B_GT:
    case B_GE:
        s = crisp_frep_binary(f, CRISP_FREP_SUB, b, a, &r);
        break;
    case B_MUL:
        s = crisp_frep_binary(f, CRISP_FREP_MUL, a, b, &r);
        break;
    case B_DIV:
        s = crisp_frep_binary(f, CRISP_FREP_DIV, a, b, &r);
        break;
    case B_AND:
        s = crisp_frep_binary(f, CRISP_FREP_MAX, a, b, &r);
        break;
    case B_OR:
        s = crisp_frep_binary(f, CRISP_FREP_MIN, a, b, &r);
        break;
    case B_EQ:
    case B_NE:
        s = crisp_frep_binary(f, CRISP_FREP_SUB, a, b, &r);
        if (!s) s = crisp_frep_unary(f, CRISP_FREP_ABS, r, &r);
        if (!s && o.code == B_NE) s = crisp_frep_unary(f, CRISP_FREP_NEG, r, &r);
        break;
    case B_POW: {
        float bv = 0;
        int bc = crisp_frep_node_constant(f, b, &bv);
        s = make_pow(f, a, b, bv, bc, &r);
        break;
    }
    default:
        s = crisp_error(CRISP_ERR_INTERNAL, "%s: bad operator", p->name);
        break;
    }
    if (s) return s;
    p->nvals--;
    p->vals[p->nvals - 1] = r;
    return CRISP_OK;
}

static int is_ident_start(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
}
static int is_ident(char c)
{
    return is_ident_start(c) || (c >= '0' && c <= '9');
}
static int is_digit(char c)
{
    return c >= '0' && c <= '9';
}

crisp_status crisp_frep_read_math_mem(const char *name, const char *data, size_t size,
                                      crisp_frep **dest)
{
    if (!dest || (!data && size))
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_read_math_mem: NULL argument");
    if (!name) name = "<math>";
    m_parser p = {.name = name};
    crisp_status s = crisp_frep_create(&p.f);
    if (s) return s;
    size_t pos = 0, line = 1, line_start = 0;
    int want_operand = 1;
    for (;;) {
        /* skip white space, counting lines */
        while (pos < size && (data[pos] == ' ' || data[pos] == '\t' || data[pos] == '\r' ||
                              data[pos] == '\n' || data[pos] == '\v' || data[pos] == '\f')) {
            if (data[pos] == '\n') line++, line_start = pos + 1;
            pos++;
        }
        size_t col = pos - line_start + 1;
        if (pos >= size || data[pos] == '\0') {
            if (want_operand) {
                s = crisp_error(CRISP_ERR_PARSE,
                                "%s:%zu:%zu: expected a number, variable, function or '(' %s", name,
                                line, col,
                                p.nvals || p.nops ? "before the end" : "(the expression is empty)");
                goto fail;
            }
            break;
        }
        char c = data[pos];
        char c2 = pos + 1 < size ? data[pos + 1] : 0;
        if (want_operand) {
            if (is_digit(c) || (c == '.' && is_digit(c2))) {
                char buf[128];
                size_t n = 0;
                size_t q = pos;
                while (q < size && (is_digit(data[q]) || data[q] == '.'))
                    q++;
                if (q < size && (data[q] == 'e' || data[q] == 'E')) {
                    size_t e = q + 1;
                    if (e < size && (data[e] == '+' || data[e] == '-')) e++;
                    if (e < size && is_digit(data[e])) {
                        q = e;
                        while (q < size && is_digit(data[q]))
                            q++;
                    }
                }
                n = q - pos;
                if (n >= sizeof buf) {
                    s = crisp_error(CRISP_ERR_PARSE,
                                    "%s:%zu:%zu: number of %zu characters is too long", name, line,
                                    col, n);
                    goto fail;
                }
                memcpy(buf, data + pos, n);
                buf[n] = 0;
                char *e;
                float v = strtof(buf, &e);
                if ((size_t)(e - buf) != n) {
                    s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: malformed number '%s'", name,
                                    line, col, buf);
                    goto fail;
                }
                crisp_frep_node node;
                if ((s = crisp_frep_const(p.f, v, &node)) || (s = push_val(&p, node))) goto fail;
                pos = q;
                want_operand = 0;
                continue;
            }
            if (is_ident_start(c)) {
                size_t q = pos;
                while (q < size && is_ident(data[q]))
                    q++;
                size_t n = q - pos;
                const char *id = data + pos;
                crisp_frep_node node;
                if (n == 1 &&
                    (c == 'X' || c == 'x' || c == 'Y' || c == 'y' || c == 'Z' || c == 'z')) {
                    int axis = (c == 'X' || c == 'x') ? 0 : (c == 'Y' || c == 'y') ? 1 : 2;
                    if ((s = crisp_frep_var(p.f, axis, &node)) || (s = push_val(&p, node)))
                        goto fail;
                    pos = q;
                    want_operand = 0;
                    continue;
                }
                if (n == 2 && !memcmp(id, "pi", 2)) {
                    if ((s = crisp_frep_const(p.f, 3.14159265358979f, &node)) ||
                        (s = push_val(&p, node)))
                        goto fail;
                    pos = q;
                    want_operand = 0;
                    continue;
                }
                int fi = -1;
                for (size_t k = 0; k < NFUNCS; k++)
                    if (strlen(funcs[k].name) == n && !memcmp(funcs[k].name, id, n)) fi = (int)k;
                if (fi < 0) {
                    s = crisp_error(CRISP_ERR_PARSE,
                                    "%s:%zu:%zu: unknown name '%.*s' (expected X, Y, Z, pi or a "
                                    "function such as sqrt)",
                                    name, line, col, (int)(n > 64 ? 64 : n), id);
                    goto fail;
                }
                /* the '(' must follow */
                size_t q2 = q;
                while (q2 < size && (data[q2] == ' ' || data[q2] == '\t'))
                    q2++;
                if (q2 >= size || data[q2] != '(') {
                    s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: expected '(' after '%s'", name,
                                    line, q2 - line_start + 1, funcs[fi].name);
                    goto fail;
                }
                if ((s = push_op(&p, (m_op){.kind = K_FUNC, .func = fi, .line = line, .col = col})))
                    goto fail;
                if ((s = push_op(&p, (m_op){.kind = K_PAREN,
                                            .func_open = 1,
                                            .func = fi,
                                            .args = 1,
                                            .line = line,
                                            .col = q2 - line_start + 1})))
                    goto fail;
                pos = q2 + 1;
                continue;
            }
            if (c == '(') {
                if ((s = push_op(&p,
                                 (m_op){.kind = K_PAREN, .func = -1, .line = line, .col = col})))
                    goto fail;
                pos++;
                continue;
            }
            if (c == '-' || c == '+' || c == '!' || c == '~') {
                uint8_t code = c == '-' ? U_NEG : c == '+' ? U_PLUS : U_NOT;
                if ((s = push_op(&p,
                                 (m_op){.kind = K_UNARY, .code = code, .line = line, .col = col})))
                    goto fail;
                pos++;
                continue;
            }
            s = crisp_error(CRISP_ERR_PARSE,
                            "%s:%zu:%zu: expected a number, variable, function or '(', found '%c'",
                            name, line, col, c >= 32 && c < 127 ? c : '?');
            goto fail;
        }
        /* expecting an operator, ')' , ',' or the end */
        if (c == ')' || c == ',') {
            while (p.nops && p.ops[p.nops - 1].kind != K_PAREN)
                if ((s = apply(&p))) goto fail;
            if (!p.nops) {
                s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: '%c' without a matching '('", name,
                                line, col, c);
                goto fail;
            }
            m_op *par = &p.ops[p.nops - 1];
            if (c == ',') {
                if (!par->func_open) {
                    s = crisp_error(CRISP_ERR_PARSE,
                                    "%s:%zu:%zu: ',' outside a function's arguments", name, line,
                                    col);
                    goto fail;
                }
                par->args++;
                pos++;
                want_operand = 1;
                continue;
            }
            m_op po = *par;
            p.nops--;
            if (po.func_open) {
                p.nops--; /* the K_FUNC entry */
                const m_func *fn = &funcs[po.func];
                if ((fn->args > 0 && po.args != (size_t)fn->args) ||
                    (fn->args < 0 && po.args < 2)) {
                    s = crisp_error(CRISP_ERR_PARSE,
                                    "%s:%zu:%zu: '%s' expects %s%d argument%s, found %zu", name,
                                    line, col, fn->name, fn->args < 0 ? "at least " : "",
                                    fn->args < 0 ? 2 : fn->args, fn->args == 1 ? "" : "s", po.args);
                    goto fail;
                }
                crisp_frep_node *av = p.vals + p.nvals - po.args, r = av[0];
                if (fn->args == 1) {
                    s = crisp_frep_unary(p.f, fn->op, av[0], &r);
                } else if (fn->op == CRISP_FREP_OP_COUNT) {
                    float bv = 0;
                    int bc = crisp_frep_node_constant(p.f, av[1], &bv);
                    s = make_pow(p.f, av[0], av[1], bv, bc, &r);
                } else {
                    for (size_t k = 1; k < po.args && !s; k++)
                        s = crisp_frep_binary(p.f, fn->op, r, av[k], &r);
                }
                if (s) goto fail;
                p.nvals -= po.args - 1;
                p.vals[p.nvals - 1] = r;
            }
            pos++;
            continue;
        }
        m_op o = {.kind = K_BINARY, .line = line, .col = col};
        size_t adv = 1;
        switch (c) {
        case '+':
            o.code = B_ADD;
            break;
        case '-':
            o.code = B_SUB;
            break;
        case '*':
            o.code = B_MUL;
            break;
        case '/':
            o.code = B_DIV;
            break;
        case '^':
            o.code = B_POW;
            break;
        case '<':
            o.code = c2 == '=' ? B_LE : B_LT, adv = c2 == '=' ? 2 : 1;
            break;
        case '>':
            o.code = c2 == '=' ? B_GE : B_GT, adv = c2 == '=' ? 2 : 1;
            break;
        case '=':
            if (c2 != '=') goto bad_op;
            o.code = B_EQ, adv = 2;
            break;
        case '!':
            if (c2 != '=') goto bad_op;
            o.code = B_NE, adv = 2;
            break;
        case '&':
            o.code = B_AND, adv = c2 == '&' ? 2 : 1;
            break;
        case '|':
            o.code = B_OR, adv = c2 == '|' ? 2 : 1;
            break;
        default:
        bad_op:
            s = crisp_error(CRISP_ERR_PARSE,
                            "%s:%zu:%zu: expected an operator, ')' or the end, found '%c'", name,
                            line, col, c >= 32 && c < 127 ? c : '?');
            goto fail;
        }
        int pr = prec(&o), right = o.code == B_POW;
        while (p.nops) {
            const m_op *t = &p.ops[p.nops - 1];
            if (t->kind != K_UNARY && t->kind != K_BINARY) break;
            int tp = prec(t);
            if (tp > pr || (tp == pr && !right)) {
                if ((s = apply(&p))) goto fail;
            } else {
                break;
            }
        }
        if ((s = push_op(&p, o))) goto fail;
        pos += adv;
        want_operand = 1;
    }
    while (p.nops) {
        if (p.ops[p.nops - 1].kind == K_PAREN || p.ops[p.nops - 1].kind == K_FUNC) {
            const m_op *o = &p.ops[p.nops - 1];
            s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: '(' is never closed (expected ')')", name,
                            o->line, o->col);
            goto fail;
        }
        if ((s = apply(&p))) goto fail;
    }
    if (p.nvals != 1) {
        s = crisp_error(CRISP_ERR_INTERNAL, "%s: %zu values left after parsing", name, p.nvals);
        goto fail;
    }
    crisp_frep_set_root(p.f, p.vals[0]);
    crisp_free(p.vals);
    crisp_free(p.ops);
    *dest = p.f;
    return CRISP_OK;
fail:
    crisp_free(p.vals);
    crisp_free(p.ops);
    crisp_frep_destroy(p.f);
    return s;
}

crisp_status crisp_frep_read_math(const char *path, crisp_frep **dest)
{
    char *data;
    size_t size;
    crisp_status s = crisp_read_file(path, &data, &size);
    if (s) return s;
    s = crisp_frep_read_math_mem(path, data, size, dest);
    crisp_free(data);
    return s;
}
