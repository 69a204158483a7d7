/* The f-rep expression DAG: hash-consed nodes (equal subexpressions are one node), constant
 * folding and the identities that keep float results (Keeter 2012: node combination and constant
 * caching; Fidget's Context). Nodes are numbered in creation order, which is a topological order:
 * every later pass is a loop, never a recursion, so a million-node expression is safe. */
#include "frep_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define EMPTY UINT32_MAX
/* Nodes beyond this are refused: keeps indices and tables within 32 bits. */
#define MAX_NODES (1u << 30)

static const char *const op_names[CRISP_FREP_OP_COUNT] = {
    "const", "var-x", "var-y", "var-z",   "neg", "abs", "sqrt", "square",
    "floor", "ceil",  "round", "sin",     "cos", "tan", "asin", "acos",
    "atan",  "exp",   "ln",    "not",     "add", "sub", "mul",  "div",
    "atan2", "min",   "max",   "compare", "mod", "and", "or"};

int crisp_frep_op_arity(crisp_frep_op op)
{
    if (op <= CRISP_FREP_Z) return 0;
    if (op < CRISP_FREP_ADD) return 1;
    if (op < CRISP_FREP_OP_COUNT) return 2;
    return -1;
}

const char *crisp_frep_op_name(crisp_frep_op op)
{
    return (unsigned)op < CRISP_FREP_OP_COUNT ? op_names[op] : "?";
}

crisp_status crisp_frep_create(crisp_frep **dest)
{
    if (!dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_create: dest is NULL");
    crisp_frep *f = calloc(1, sizeof *f);
    if (!f) return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_create: out of memory");
    f->root = EMPTY;
    *dest = f;
    return CRISP_OK;
}

void crisp_frep_destroy(crisp_frep *f)
{
    if (!f) return;
    crisp_free(f->nodes);
    crisp_free(f->table);
    free(f);
}

void crisp_frep_set_root(crisp_frep *f, crisp_frep_node root)
{
    if (f && root < f->count) f->root = root;
}

crisp_frep_node crisp_frep_root(const crisp_frep *f)
{
    return f ? f->root : EMPTY;
}

size_t crisp_frep_node_count(const crisp_frep *f)
{
    return f ? f->count : 0;
}

int crisp_frep_node_constant(const crisp_frep *f, crisp_frep_node n, float *value)
{
    if (!f || n >= f->count || f->nodes[n].op != CRISP_FREP_CONST) return 0;
    if (value) *value = f->nodes[n].value;
    return 1;
}

static uint32_t float_bits(float v)
{
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    return u;
}

static size_t node_hash(const frep_node *n)
{
    uint64_t h = n->op * 0x9E3779B97F4A7C15ull;
    h ^= (uint64_t)n->a * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= (uint64_t)n->b * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    h ^= (uint64_t)float_bits(n->value) * 0x27D4EB2F165667C5ull;
    h ^= h >> 29;
    return (size_t)h;
}

static int node_equal(const frep_node *x, const frep_node *y)
{
    return x->op == y->op && x->a == y->a && x->b == y->b &&
           float_bits(x->value) == float_bits(y->value);
}

static crisp_status rehash(crisp_frep *f, size_t cap)
{
    uint32_t *t = crisp_malloc_array(cap, sizeof *t);
    if (!t) return crisp_error(CRISP_ERR_NO_MEMORY, "frep: out of memory for %zu nodes", f->count);
    memset(t, 0xff, cap * sizeof *t);
    for (size_t i = 0; i < f->count; i++) {
        size_t h = node_hash(&f->nodes[i]) & (cap - 1);
        while (t[h] != EMPTY)
            h = (h + 1) & (cap - 1);
        t[h] = (uint32_t)i;
    }
    crisp_free(f->table);
    f->table = t;
    f->table_cap = cap;
    return CRISP_OK;
}

/* Find or add the node exactly as given (no simplification). */
static crisp_status intern(crisp_frep *f, const frep_node *n, crisp_frep_node *dest)
{
    if (2 * (f->count + 1) > f->table_cap) {
        crisp_status s = rehash(f, f->table_cap ? 2 * f->table_cap : 256);
        if (s) return s;
    }
    size_t mask = f->table_cap - 1, h = node_hash(n) & mask;
    while (f->table[h] != EMPTY) {
        if (node_equal(&f->nodes[f->table[h]], n)) {
            *dest = f->table[h];
            return CRISP_OK;
        }
        h = (h + 1) & mask;
    }
    if (f->count >= MAX_NODES)
        return crisp_error(CRISP_ERR_LIMIT, "frep: more than %u nodes", MAX_NODES);
    if (crisp_grow((void **)&f->nodes, &f->cap, f->count + 1, sizeof *f->nodes))
        return crisp_error(CRISP_ERR_NO_MEMORY, "frep: out of memory for %zu nodes", f->count);
    f->nodes[f->count] = *n;
    f->table[h] = (uint32_t)f->count;
    *dest = (crisp_frep_node)f->count++;
    return CRISP_OK;
}

crisp_status crisp_frep_const(crisp_frep *f, float value, crisp_frep_node *dest)
{
    if (!f || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_const: NULL argument");
    if (value != value) value = NAN; /* one NaN, whatever its payload */
    frep_node n = {.op = CRISP_FREP_CONST, .value = value};
    return intern(f, &n, dest);
}

crisp_status crisp_frep_var(crisp_frep *f, int axis, crisp_frep_node *dest)
{
    if (!f || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_var: NULL argument");
    if (axis < 0 || axis > 2)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_var: axis %d is not 0, 1 or 2", axis);
    frep_node n = {.op = (uint8_t)(CRISP_FREP_X + axis)};
    return intern(f, &n, dest);
}

static int is_const(const crisp_frep *f, crisp_frep_node a, float v)
{
    const frep_node *n = &f->nodes[a];
    return n->op == CRISP_FREP_CONST && float_bits(n->value) == float_bits(v);
}

crisp_status crisp_frep_unary(crisp_frep *f, crisp_frep_op op, crisp_frep_node a,
                              crisp_frep_node *dest)
{
    if (!f || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_unary: NULL argument");
    if (crisp_frep_op_arity(op) != 1)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_unary: op %d takes %d arguments",
                           (int)op, crisp_frep_op_arity(op));
    if (a >= f->count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_unary: node %u does not exist", a);
    const frep_node *na = &f->nodes[a];
    if (na->op == CRISP_FREP_CONST) return crisp_frep_const(f, frep_unary(op, na->value), dest);
    /* identities that give the same float for every input */
    if (op == CRISP_FREP_NEG && na->op == CRISP_FREP_NEG) {
        *dest = na->a;
        return CRISP_OK;
    }
    if ((op == CRISP_FREP_ABS || op == CRISP_FREP_SQUARE) && na->op == CRISP_FREP_NEG)
        a = na->a;
    else if (op == CRISP_FREP_ABS && na->op == CRISP_FREP_ABS) {
        *dest = a;
        return CRISP_OK;
    }
    frep_node n = {.op = (uint8_t)op, .a = a};
    return intern(f, &n, dest);
}

crisp_status crisp_frep_binary(crisp_frep *f, crisp_frep_op op, crisp_frep_node a,
                               crisp_frep_node b, crisp_frep_node *dest)
{
    if (!f || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_binary: NULL argument");
    if (crisp_frep_op_arity(op) != 2)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_binary: op %d takes %d arguments",
                           (int)op, crisp_frep_op_arity(op));
    if (a >= f->count || b >= f->count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_binary: node %u does not exist",
                           a >= f->count ? a : b);
    const frep_node *na = &f->nodes[a], *nb = &f->nodes[b];
    if (na->op == CRISP_FREP_CONST && nb->op == CRISP_FREP_CONST)
        return crisp_frep_const(f, frep_binary(op, na->value, nb->value), dest);
    switch (op) {
    case CRISP_FREP_ADD:
        /* x + 0 keeps x except that -0 + 0 is +0: only the sign of a zero can differ */
        if (is_const(f, b, 0.0f) || is_const(f, b, -0.0f)) return *dest = a, CRISP_OK;
        if (is_const(f, a, 0.0f) || is_const(f, a, -0.0f)) return *dest = b, CRISP_OK;
        if (nb->op == CRISP_FREP_NEG) return crisp_frep_binary(f, CRISP_FREP_SUB, a, nb->a, dest);
        if (na->op == CRISP_FREP_NEG) return crisp_frep_binary(f, CRISP_FREP_SUB, b, na->a, dest);
        break;
    case CRISP_FREP_SUB:
        if (nb->op == CRISP_FREP_CONST) {
            /* a - c == a + (-c) exactly */
            crisp_frep_node c;
            crisp_status s = crisp_frep_const(f, -nb->value, &c);
            if (s) return s;
            return crisp_frep_binary(f, CRISP_FREP_ADD, a, c, dest);
        }
        if (nb->op == CRISP_FREP_NEG) return crisp_frep_binary(f, CRISP_FREP_ADD, a, nb->a, dest);
        break;
    case CRISP_FREP_MUL:
        if (is_const(f, b, 1.0f)) return *dest = a, CRISP_OK;
        if (is_const(f, a, 1.0f)) return *dest = b, CRISP_OK;
        if (is_const(f, b, -1.0f)) return crisp_frep_unary(f, CRISP_FREP_NEG, a, dest);
        if (is_const(f, a, -1.0f)) return crisp_frep_unary(f, CRISP_FREP_NEG, b, dest);
        if (a == b) return crisp_frep_unary(f, CRISP_FREP_SQUARE, a, dest);
        break;
    case CRISP_FREP_DIV:
        if (is_const(f, b, 1.0f)) return *dest = a, CRISP_OK;
        if (is_const(f, b, -1.0f)) return crisp_frep_unary(f, CRISP_FREP_NEG, a, dest);
        break;
    case CRISP_FREP_MIN:
    case CRISP_FREP_MAX:
        if (a == b) return *dest = a, CRISP_OK;
        break;
    default:
        break;
    }
    /* commutative ops: one canonical argument order so a+b and b+a merge */
    if ((op == CRISP_FREP_ADD || op == CRISP_FREP_MUL || op == CRISP_FREP_MIN ||
         op == CRISP_FREP_MAX) &&
        a > b) {
        crisp_frep_node t = a;
        a = b;
        b = t;
    }
    frep_node n = {.op = (uint8_t)op, .a = a, .b = b};
    return intern(f, &n, dest);
}

float crisp_frep_eval_graph(const crisp_frep *f, float x, float y, float z)
{
    if (!f || f->root >= f->count) return NAN;
    size_t n = (size_t)f->root + 1;
    float *v = crisp_malloc_array(n, sizeof *v);
    if (!v) return NAN;
    for (size_t i = 0; i < n; i++) {
        const frep_node *nd = &f->nodes[i];
        switch (crisp_frep_op_arity(nd->op)) {
        case 0:
            v[i] = nd->op == CRISP_FREP_CONST ? nd->value
                   : nd->op == CRISP_FREP_X   ? x
                   : nd->op == CRISP_FREP_Y   ? y
                                              : z;
            break;
        case 1:
            v[i] = frep_unary(nd->op, v[nd->a]);
            break;
        default:
            v[i] = frep_binary(nd->op, v[nd->a], v[nd->b]);
            break;
        }
    }
    float r = v[n - 1];
    crisp_free(v);
    return r;
}
