/* Reader for the .vm text format of Fidget and the Prospero challenge (data/README.md): one
 * instruction a line, `ID OPCODE [ARG...]`, arguments naming earlier IDs, the last line the
 * result. Builds a crisp_frep DAG (hash-consed as it goes). Errors name the line and column. */
#include "crisp/frep.h"
#include "crisp/io.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct vm_id {
    const char *s;
    size_t len;
    crisp_frep_node node;
} vm_id;

typedef struct vm_reader {
    const char *name;
    vm_id *ids;
    size_t count, cap; /* open addressing table of cap slots, s == NULL when empty */
} vm_reader;

static size_t str_hash(const char *s, size_t n)
{
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < n; i++)
        h = (h ^ (unsigned char)s[i]) * 1099511628211ull;
    return (size_t)h;
}

static vm_id *id_slot(vm_reader *r, const char *s, size_t n)
{
    size_t mask = r->cap - 1, h = str_hash(s, n) & mask;
    while (r->ids[h].s && !(r->ids[h].len == n && !memcmp(r->ids[h].s, s, n)))
        h = (h + 1) & mask;
    return &r->ids[h];
}

static crisp_status id_define(vm_reader *r, const char *s, size_t n, crisp_frep_node node)
{
    if (2 * (r->count + 1) > r->cap) {
        size_t cap = r->cap ? 2 * r->cap : 1024;
        vm_id *old = r->ids;
        size_t oldcap = r->cap;
        r->ids = crisp_calloc_array(cap, sizeof *r->ids);
        if (!r->ids) {
            r->ids = old;
            return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory for %zu IDs", r->name,
                               r->count);
        }
        r->cap = cap;
        for (size_t i = 0; i < oldcap; i++)
            if (old[i].s) *id_slot(r, old[i].s, old[i].len) = old[i];
        crisp_free(old);
    }
    vm_id *slot = id_slot(r, s, n);
    if (!slot->s) r->count++;
    *slot = (vm_id){s, n, node};
    return CRISP_OK;
}

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

static crisp_frep_op find_op(const char *s, size_t n)
{
    for (int op = 0; op < CRISP_FREP_OP_COUNT; op++) {
        const char *name = crisp_frep_op_name((crisp_frep_op)op);
        if (strlen(name) == n && !memcmp(name, s, n)) return (crisp_frep_op)op;
    }
    return CRISP_FREP_OP_COUNT;
}

crisp_status crisp_frep_read_vm_mem(const char *name, const char *data, size_t size,
                                    crisp_frep **dest)
{
    if (!dest || (!data && size))
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_read_vm_mem: NULL argument");
    if (!name) name = "<vm>";
    crisp_frep *f = NULL;
    crisp_status s = crisp_frep_create(&f);
    if (s) return s;
    vm_reader r = {.name = name};
    size_t line = 0, pos = 0;
    int have_root = 0;
    crisp_frep_node root = 0;
    while (pos < size) {
        line++;
        size_t end = pos;
        while (end < size && data[end] != '\n')
            end++;
        /* tokens of this line */
        const char *tok[5];
        size_t len[5], col[5];
        int ntok = 0;
        size_t p = pos;
        while (p < end) {
            while (p < end && is_space(data[p]))
                p++;
            if (p >= end) break;
            if (ntok == 0 && data[p] == '#') break;
            if (ntok == 5) {
                s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: expected at most 2 arguments", name,
                                line, p - pos + 1);
                goto fail;
            }
            tok[ntok] = data + p;
            col[ntok] = p - pos + 1;
            while (p < end && !is_space(data[p]))
                p++;
            len[ntok] = (size_t)(data + p - tok[ntok]);
            ntok++;
        }
        pos = end + 1;
        if (ntok == 0) continue;
        if (ntok == 1) {
            s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: expected an opcode after the ID '%.*s'",
                            name, line, col[0] + len[0], (int)(len[0] > 64 ? 64 : len[0]), tok[0]);
            goto fail;
        }
        crisp_frep_op op = find_op(tok[1], len[1]);
        if (op == CRISP_FREP_OP_COUNT) {
            s = crisp_error(CRISP_ERR_PARSE,
                            "%s:%zu:%zu: unknown opcode '%.*s' (expected const, var-x, add, ...)",
                            name, line, col[1], (int)(len[1] > 64 ? 64 : len[1]), tok[1]);
            goto fail;
        }
        int want = op == CRISP_FREP_CONST ? 1 : crisp_frep_op_arity(op);
        if (ntok - 2 != want) {
            s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: '%s' expects %d argument%s, found %d",
                            name, line, col[1], crisp_frep_op_name(op), want, want == 1 ? "" : "s",
                            ntok - 2);
            goto fail;
        }
        crisp_frep_node node, args[2] = {0, 0};
        if (op == CRISP_FREP_CONST) {
            char buf[128];
            if (len[2] >= sizeof buf) {
                s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: number of %zu characters is too long",
                                name, line, col[2], len[2]);
                goto fail;
            }
            memcpy(buf, tok[2], len[2]);
            buf[len[2]] = 0;
            char *e;
            errno = 0;
            float v = strtof(buf, &e);
            if (e == buf || *e) {
                s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: expected a number, found '%s'", name,
                                line, col[2], buf);
                goto fail;
            }
            s = crisp_frep_const(f, v, &node);
        } else {
            for (int a = 0; a < want; a++) {
                vm_id *slot = r.cap ? id_slot(&r, tok[2 + a], len[2 + a]) : NULL;
                if (!slot || !slot->s) {
                    s = crisp_error(CRISP_ERR_PARSE, "%s:%zu:%zu: undefined ID '%.*s'", name, line,
                                    col[2 + a], (int)(len[2 + a] > 64 ? 64 : len[2 + a]),
                                    tok[2 + a]);
                    goto fail;
                }
                args[a] = slot->node;
            }
            if (op <= CRISP_FREP_Z)
                s = crisp_frep_var(f, (int)(op - CRISP_FREP_X), &node);
            else if (want == 1)
                s = crisp_frep_unary(f, op, args[0], &node);
            else
                s = crisp_frep_binary(f, op, args[0], args[1], &node);
        }
        if (s) goto context;
        if ((s = id_define(&r, tok[0], len[0], node))) goto fail;
        root = node;
        have_root = 1;
    }
    if (!have_root) {
        s = crisp_error(CRISP_ERR_PARSE,
                        "%s: no instructions (expected lines 'ID OPCODE [ARG...]')", name);
        goto fail;
    }
    crisp_frep_set_root(f, root);
    crisp_free(r.ids);
    *dest = f;
    return CRISP_OK;
context:
    crisp_error_prefix("%s:%zu", name, line);
fail:
    crisp_free(r.ids);
    crisp_frep_destroy(f);
    return s;
}

crisp_status crisp_frep_read_vm(const char *path, crisp_frep **dest)
{
    char *data;
    size_t size;
    crisp_status s = crisp_read_file(path, &data, &size);
    if (s) return s;
    s = crisp_frep_read_vm_mem(path, data, size, dest);
    crisp_free(data);
    return s;
}
