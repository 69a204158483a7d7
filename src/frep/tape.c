/* The tape: the DAG flattened into a linear SSA program over registers, and its per-cell
 * shortening. Follows Fidget (mkeeter/fidget: SSA tape, register allocation, simplification from
 * min/max choices) and Keeter's 2012 branch caching.
 *
 * Registers: a value gets a register when it is defined and gives it back after its last use.
 * The output register is taken before the operands are given back, so an instruction never
 * writes a register it reads; the batched evaluator relies on this to vectorise without alias
 * checks. Constants used by + - * / min max become immediates. */
#include "frep_internal.h"

#include <stdlib.h>
#include <string.h>

#define NO_REG UINT32_MAX
#define MAX_REGS 65535

static int imm_form(int op, int const_is_b)
{
    switch (op) {
    case CRISP_FREP_ADD:
        return FREP_T_ADD_RI;
    case CRISP_FREP_MUL:
        return FREP_T_MUL_RI;
    case CRISP_FREP_MIN:
        return FREP_T_MIN_RI;
    case CRISP_FREP_MAX:
        return FREP_T_MAX_RI;
    case CRISP_FREP_SUB:
        return const_is_b ? FREP_T_SUB_RI : FREP_T_SUB_IR;
    case CRISP_FREP_DIV:
        return const_is_b ? FREP_T_DIV_RI : FREP_T_DIV_IR;
    default:
        return -1;
    }
}

crisp_status crisp__frep_scratch_init(frep_shorten_scratch *s, size_t cap, int max_regs)
{
    memset(s, 0, sizeof *s);
    s->rep = crisp_malloc_array(cap ? cap : 1, sizeof *s->rep);
    s->reg_of = crisp_malloc_array(cap ? cap : 1, sizeof *s->reg_of);
    s->pos = crisp_malloc_array(cap ? cap : 1, sizeof *s->pos);
    s->free_regs = crisp_malloc_array((size_t)max_regs + 1, sizeof *s->free_regs);
    s->cap = cap;
    s->max_regs = max_regs;
    if (!s->rep || !s->reg_of || !s->pos || !s->free_regs) {
        crisp__frep_scratch_free(s);
        return crisp_error(CRISP_ERR_NO_MEMORY, "frep: out of memory for tape scratch (%zu)", cap);
    }
    return CRISP_OK;
}

void crisp__frep_scratch_free(frep_shorten_scratch *s)
{
    crisp_free(s->rep);
    crisp_free(s->reg_of);
    crisp_free(s->pos);
    crisp_free(s->free_regs);
    memset(s, 0, sizeof *s);
}

crisp_status crisp_frep_tape_create(const crisp_frep *f, crisp_frep_tape **dest)
{
    if (!f || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_tape_create: NULL argument");
    if (f->root >= f->count)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_frep_tape_create: the expression has no root");
    size_t n = (size_t)f->root + 1;
    const frep_node *nodes = f->nodes;
    /* regread[i]: node i is read from a register (not only as an immediate) */
    uint32_t *idx = crisp_malloc_array(n, sizeof *idx);
    uint8_t *reach = crisp_calloc_array(n, 1), *regread = crisp_calloc_array(n, 1);
    frep_ins *sins = NULL;
    uint32_t *sssa = NULL;
    frep_shorten_scratch sc = {0};
    crisp_frep_tape *t = calloc(1, sizeof *t);
    crisp_status s = CRISP_OK;
    if (!idx || !reach || !regread || !t) goto oom;
    reach[n - 1] = 1;
    for (size_t i = n; i-- > 0;) {
        if (!reach[i]) continue;
        int ar = crisp_frep_op_arity(nodes[i].op);
        if (ar >= 1) reach[nodes[i].a] = 1;
        if (ar >= 2) reach[nodes[i].b] = 1;
    }
    for (size_t i = 0; i < n; i++) {
        if (!reach[i]) continue;
        const frep_node *nd = &nodes[i];
        int ar = crisp_frep_op_arity(nd->op);
        if (ar == 0) continue;
        int ca = nodes[nd->a].op == CRISP_FREP_CONST;
        int cb = ar == 2 && nodes[nd->b].op == CRISP_FREP_CONST;
        if (ar == 2 && (ca || cb) && imm_form(nd->op, cb) >= 0) {
            regread[ca ? nd->b : nd->a] = 1;
        } else {
            regread[nd->a] = 1;
            if (ar == 2) regread[nd->b] = 1;
        }
    }
    size_t count = 0;
    for (size_t i = 0; i < n; i++)
        if (reach[i] && (nodes[i].op != CRISP_FREP_CONST || regread[i] || i == n - 1)) count++;
    sins = crisp_malloc_array(count, sizeof *sins);
    sssa = crisp_calloc_array(2 * count, sizeof *sssa);
    t->ins = crisp_malloc_array(count, sizeof *t->ins);
    t->ssa = crisp_malloc_array(2 * count, sizeof *t->ssa);
    if (!sins || !sssa || !t->ins || !t->ssa) goto oom;
    if ((s = crisp__frep_scratch_init(&sc, count, MAX_REGS))) goto done;
    /* the SSA tape: instruction k defines value k */
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        const frep_node *nd = &nodes[i];
        if (!reach[i] || (nd->op == CRISP_FREP_CONST && !regread[i] && i != n - 1)) continue;
        frep_ins in = {.op = nd->op};
        int ar = crisp_frep_op_arity(nd->op);
        if (nd->op == CRISP_FREP_CONST) in.imm = nd->value;
        int ca = ar >= 1 && nodes[nd->a].op == CRISP_FREP_CONST;
        int cb = ar == 2 && nodes[nd->b].op == CRISP_FREP_CONST;
        if (ar == 2 && (ca || cb) && imm_form(nd->op, cb) >= 0) {
            in.op = (uint8_t)imm_form(nd->op, cb);
            in.imm = cb ? nodes[nd->b].value : nodes[nd->a].value;
            sssa[2 * k] = idx[cb ? nd->a : nd->b];
        } else {
            if (ar >= 1) sssa[2 * k] = idx[nd->a];
            if (ar == 2) sssa[2 * k + 1] = idx[nd->b];
        }
        sins[k] = in;
        idx[i] = (uint32_t)k++;
    }
    /* registers by the same pass that shortens tapes, with every min/max side kept */
    frep_span out;
    if (crisp__frep_shorten((frep_span){sins, sssa, k, 0}, NULL, &sc, t->ins, t->ssa, &out)) {
        s = crisp_error(CRISP_ERR_LIMIT, "crisp_frep_tape_create: more than %d values live at once",
                        MAX_REGS);
        goto done;
    }
    t->length = out.len;
    t->registers = out.registers;
    t->result = t->ins[out.len - 1].out;
    *dest = t;
    t = NULL;
    goto done;
oom:
    s = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_tape_create: out of memory for %zu nodes", n);
done:
    if (t) {
        crisp_free(t->ins);
        crisp_free(t->ssa);
        free(t);
    }
    crisp__frep_scratch_free(&sc);
    crisp_free(sins);
    crisp_free(sssa);
    crisp_free(idx);
    crisp_free(reach);
    crisp_free(regread);
    return s;
}

void crisp_frep_tape_destroy(crisp_frep_tape *t)
{
    if (!t) return;
    crisp_free(t->ins);
    crisp_free(t->ssa);
    free(t);
}

size_t crisp_frep_tape_length(const crisp_frep_tape *t)
{
    return t ? t->length : 0;
}
int crisp_frep_tape_registers(const crisp_frep_tape *t)
{
    return t ? t->registers : 0;
}

int crisp__frep_shorten(frep_span src, const uint8_t *choices, frep_shorten_scratch *sc,
                        frep_ins *dest_ins, uint32_t *dest_ssa, frep_span *dest)
{
    size_t n = src.len;
    const frep_ins *ins = src.ins;
    const uint32_t *ssa = src.ssa;
    uint32_t *rep = sc->rep, *reg_of = sc->reg_of, *pos = sc->pos;
    /* forward: a min/max whose side is known is renamed to that side */
    memset(reg_of, 0xff, n * sizeof *reg_of);
    for (size_t i = 0; i < n; i++) {
        uint32_t ri = (uint32_t)i;
        if (choices && choices[i] && frep__is_minmax(ins[i].op)) {
            if (choices[i] == FREP_CHOICE_A)
                ri = rep[ssa[2 * i]];
            else if (frep__nargs(ins[i].op) == 2)
                ri = rep[ssa[2 * i + 1]];
        } else if (ins[i].op == FREP_T_COPY) {
            ri = rep[ssa[2 * i]]; /* left by crisp__frep_prune: renamed away */
        }
        rep[i] = ri;
    }
    /* backward: dead code is skipped; a value takes a register at its last use and gives it
     * back at its definition (operands first, so the output never shares an operand's) */
    size_t nfree = 0, p = n;
    uint32_t nregs = 0, max_regs = (uint32_t)sc->max_regs;
    uint16_t *free_regs = sc->free_regs;
#define ALLOC(dst)                                                                                 \
    do {                                                                                           \
        if (nfree)                                                                                 \
            (dst) = free_regs[--nfree];                                                            \
        else if (nregs >= max_regs)                                                                \
            return -1;                                                                             \
        else                                                                                       \
            (dst) = nregs++;                                                                       \
    } while (0)
    ALLOC(reg_of[rep[n - 1]]);
    for (size_t i = n; i-- > 0;) {
        uint32_t ro = reg_of[i];
        if (ro == NO_REG || rep[i] != i) continue;
        frep_ins in = ins[i];
        int nargs = frep__nargs(in.op);
        if (choices && choices[i] == FREP_CHOICE_B && frep__is_minmax(in.op)) {
            in.op = CRISP_FREP_CONST; /* min/max with an immediate that won */
            nargs = 0;
        }
        uint32_t a0 = 0, a1 = 0;
        in.out = (uint16_t)ro;
        if (nargs >= 1) {
            a0 = rep[ssa[2 * i]];
            if (reg_of[a0] == NO_REG) ALLOC(reg_of[a0]);
            in.a = (uint16_t)reg_of[a0];
            if (nargs == 2) {
                a1 = rep[ssa[2 * i + 1]];
                if (reg_of[a1] == NO_REG) ALLOC(reg_of[a1]);
                in.b = (uint16_t)reg_of[a1];
            }
        }
        p--;
        dest_ins[p] = in;
        dest_ssa[2 * p] = a0;
        dest_ssa[2 * p + 1] = a1;
        pos[i] = (uint32_t)p;
        free_regs[nfree++] = (uint16_t)ro;
    }
#undef ALLOC
    /* move to the front, renumbering the SSA operands */
    size_t m = n - p;
    for (size_t q = 0; q < m; q++) {
        frep_ins in = dest_ins[p + q];
        int nargs = frep__nargs(in.op);
        uint32_t a = dest_ssa[2 * (p + q)], b = dest_ssa[2 * (p + q) + 1];
        dest_ins[q] = in;
        dest_ssa[2 * q] = nargs >= 1 ? pos[a] - (uint32_t)p : 0;
        dest_ssa[2 * q + 1] = nargs >= 2 ? pos[b] - (uint32_t)p : 0;
    }
    *dest = (frep_span){dest_ins, dest_ssa, m, (int)nregs};
    return 0;
}

int crisp__frep_prune(frep_span src, const uint8_t *choices, frep_shorten_scratch *sc,
                      frep_ins *dest_ins, uint32_t *dest_ssa, frep_span *dest)
{
    size_t n = src.len;
    const frep_ins *ins = src.ins;
    const uint32_t *ssa = src.ssa;
    /* live flags in rep (0 or 1), new positions in pos */
    uint32_t *live = sc->rep, *pos = sc->pos;
    memset(live, 0, n * sizeof *live);
    live[n - 1] = 1;
    /* backward, without branches: an instruction marks the operands it reads live when it is */
    for (size_t i = n; i-- > 0;) {
        int op = ins[i].op, na = frep__nargs(op);
        uint32_t ch = frep__is_minmax(op) ? choices[i] : FREP_CHOICE_BOTH;
        uint32_t l = live[i];
        live[ssa[2 * i]] |= l & (uint32_t)(na >= 1) & (uint32_t)(ch != FREP_CHOICE_B);
        live[ssa[2 * i + 1]] |= l & (uint32_t)(na == 2) & (uint32_t)(ch != FREP_CHOICE_A);
    }
    /* forward: copy the live instructions; a decided min/max becomes a copy of its side (or the
     * immediate), writing the register it wrote (registers are not reallocated: a value that a
     * live instruction reads was written by a live one, and nothing between wrote over it) */
    size_t q = 0;
    for (size_t i = 0; i < n; i++) {
        frep_ins in = ins[i];
        uint32_t a = ssa[2 * i], b = ssa[2 * i + 1];
        int na = frep__nargs(in.op);
        uint32_t ch = frep__is_minmax(in.op) ? choices[i] : FREP_CHOICE_BOTH;
        if (ch == FREP_CHOICE_A) {
            in.op = FREP_T_COPY;
            na = 1;
        } else if (ch == FREP_CHOICE_B) {
            if (na == 2) {
                in.op = FREP_T_COPY;
                in.a = in.b;
                a = b;
                na = 1;
            } else {
                in.op = CRISP_FREP_CONST; /* min/max with an immediate that won */
                na = 0;
            }
        }
        pos[i] = (uint32_t)q;
        dest_ins[q] = in;
        dest_ssa[2 * q] = na >= 1 ? pos[a] : 0;
        dest_ssa[2 * q + 1] = na == 2 ? pos[b] : 0;
        q += live[i];
    }
    *dest = (frep_span){dest_ins, dest_ssa, q, src.registers};
    return 0;
}

float crisp__frep_eval_scalar(const frep_ins *ins, size_t n, uint16_t result, float *r, float x,
                              float y, float z)
{
    for (size_t i = 0; i < n; i++) {
        const frep_ins in = ins[i];
        float v;
        switch (in.op) {
        case CRISP_FREP_CONST:
            v = in.imm;
            break;
        case CRISP_FREP_X:
            v = x;
            break;
        case CRISP_FREP_Y:
            v = y;
            break;
        case CRISP_FREP_Z:
            v = z;
            break;
        case FREP_T_COPY:
            v = r[in.a];
            break;
        case FREP_T_ADD_RI:
            v = r[in.a] + in.imm;
            break;
        case FREP_T_MUL_RI:
            v = r[in.a] * in.imm;
            break;
        case FREP_T_SUB_RI:
            v = r[in.a] - in.imm;
            break;
        case FREP_T_SUB_IR:
            v = in.imm - r[in.a];
            break;
        case FREP_T_DIV_RI:
            v = r[in.a] / in.imm;
            break;
        case FREP_T_DIV_IR:
            v = in.imm / r[in.a];
            break;
        case FREP_T_MIN_RI:
            v = frep_min(r[in.a], in.imm);
            break;
        case FREP_T_MAX_RI:
            v = frep_max(r[in.a], in.imm);
            break;
        default:
            v = in.op < CRISP_FREP_ADD ? frep_unary(in.op, r[in.a])
                                       : frep_binary(in.op, r[in.a], r[in.b]);
            break;
        }
        r[in.out] = v;
    }
    return r[result];
}

float crisp_frep_eval_point(const crisp_frep_tape *t, float x, float y, float z)
{
    if (!t) return NAN;
    float stack[256];
    float *r = t->registers <= 256 ? stack : crisp_malloc_array((size_t)t->registers, sizeof *r);
    if (!r) return NAN;
    float v = crisp__frep_eval_scalar(t->ins, t->length, t->result, r, x, y, z);
    if (r != stack) crisp_free(r);
    return v;
}

/* The points b .. b + m - 1 (m <= FREP_LANES) into lane arrays; spare lanes repeat point b so
 * they stay finite. Returns m. */
static size_t gather_lanes(size_t n, size_t b, const float *x, const float *y, const float *z,
                           float *px, float *py, float *pz)
{
    size_t m = n - b < FREP_LANES ? n - b : FREP_LANES;
    for (size_t k = 0; k < FREP_LANES; k++) {
        size_t s = b + (k < m ? k : 0);
        px[k] = x[s];
        py[k] = y[s];
        pz[k] = z[s];
    }
    return m;
}

crisp_status crisp_frep_eval_batch(const crisp_frep_tape *t, size_t n, const float *x,
                                   const float *y, const float *z, float *dest)
{
    if (!t || (n && (!x || !y || !z || !dest)))
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_eval_batch: NULL argument");
    float *regs = crisp_malloc_array((size_t)t->registers * FREP_LANES, sizeof *regs);
    if (!regs) return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_eval_batch: out of memory");
    float px[FREP_LANES], py[FREP_LANES], pz[FREP_LANES];
    for (size_t b = 0; b < n; b += FREP_LANES) {
        size_t m = gather_lanes(n, b, x, y, z, px, py, pz);
        crisp__frep_eval_lanes(t->ins, t->length, regs, px, py, pz);
        memcpy(dest + b, regs + (size_t)t->result * FREP_LANES, m * sizeof *dest);
    }
    crisp_free(regs);
    return CRISP_OK;
}

crisp_status crisp_frep_eval_grad(const crisp_frep_tape *t, size_t n, const float *x,
                                  const float *y, const float *z, float *dest)
{
    if (!t || (n && (!x || !y || !z || !dest)))
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_eval_grad: NULL argument");
    float *regs = crisp_malloc_array((size_t)t->registers * 4 * FREP_LANES, sizeof *regs);
    if (!regs) return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_eval_grad: out of memory");
    float px[FREP_LANES], py[FREP_LANES], pz[FREP_LANES];
    for (size_t b = 0; b < n; b += FREP_LANES) {
        size_t m = gather_lanes(n, b, x, y, z, px, py, pz);
        crisp__frep_grad_lanes(t->ins, t->length, regs, px, py, pz);
        const float *res = regs + (size_t)t->result * 4 * FREP_LANES;
        for (size_t k = 0; k < m; k++)
            for (int c = 0; c < 4; c++)
                dest[4 * (b + k) + (size_t)c] = res[c * FREP_LANES + k];
    }
    crisp_free(regs);
    return CRISP_OK;
}

void crisp_frep_eval_interval(const crisp_frep_tape *t, const float x[2], const float y[2],
                              const float z[2], float dest[2])
{
    dest[0] = dest[1] = NAN;
    if (!t) return;
    float *lo = crisp_malloc_array((size_t)t->registers * 2, sizeof *lo);
    if (!lo) return;
    float *hi = lo + t->registers;
    crisp__frep_interval(t->ins, t->length, lo, hi, x, y, z, NULL);
    dest[0] = lo[t->result];
    dest[1] = hi[t->result];
    crisp_free(lo);
}
