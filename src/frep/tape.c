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
    case CRISP_FREP_ADD: return FREP_T_ADD_RI;
    case CRISP_FREP_MUL: return FREP_T_MUL_RI;
    case CRISP_FREP_MIN: return FREP_T_MIN_RI;
    case CRISP_FREP_MAX: return FREP_T_MAX_RI;
    case CRISP_FREP_SUB: return const_is_b ? FREP_T_SUB_RI : FREP_T_SUB_IR;
    case CRISP_FREP_DIV: return const_is_b ? FREP_T_DIV_RI : FREP_T_DIV_IR;
    default: return -1;
    }
}

crisp_status crisp_frep_tape_create(const crisp_frep *f, crisp_frep_tape **dest)
{
    if (!f || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_tape_create: NULL argument");
    if (f->root >= f->count)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_tape_create: the expression has no root");
    size_t n = (size_t)f->root + 1;
    const frep_node *nodes = f->nodes;
    /* last_use[i]: index of the last consumer reading node i from a register; reachable[i] */
    uint32_t *last_use = crisp_malloc_array(n, sizeof *last_use);
    uint32_t *reg = crisp_malloc_array(n, sizeof *reg);
    uint8_t *reach = crisp_calloc_array(n, 1);
    uint16_t *free_regs = crisp_malloc_array(MAX_REGS + 1, sizeof *free_regs);
    crisp_frep_tape *t = calloc(1, sizeof *t);
    crisp_status s = CRISP_OK;
    if (!last_use || !reg || !reach || !free_regs || !t) {
        s = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_tape_create: out of memory for %zu nodes", n);
        goto done;
    }
    reach[n - 1] = 1;
    size_t count = 0;
    for (size_t i = n; i-- > 0;) {
        last_use[i] = NO_REG;
        reg[i] = NO_REG;
        if (!reach[i]) continue;
        int ar = crisp_frep_op_arity(nodes[i].op);
        if (ar >= 1) reach[nodes[i].a] = 1;
        if (ar >= 2) reach[nodes[i].b] = 1;
    }
    /* which constants need a register: those read by an op without an immediate form */
    for (size_t i = 0; i < n; i++) {
        if (!reach[i]) continue;
        const frep_node *nd = &nodes[i];
        int ar = crisp_frep_op_arity(nd->op);
        if (ar == 0) continue;
        int ca = nodes[nd->a].op == CRISP_FREP_CONST;
        int cb = ar == 2 && nodes[nd->b].op == CRISP_FREP_CONST;
        if (ar == 2 && (ca || cb) && imm_form(nd->op, cb) >= 0) {
            last_use[ca ? nd->b : nd->a] = (uint32_t)i;
        } else {
            last_use[nd->a] = (uint32_t)i;
            if (ar == 2) last_use[nd->b] = (uint32_t)i;
        }
    }
    for (size_t i = 0; i < n; i++)
        if (reach[i] && (nodes[i].op != CRISP_FREP_CONST || last_use[i] != NO_REG || i == n - 1))
            count++;
    t->ins = crisp_malloc_array(count, sizeof *t->ins);
    if (!t->ins) {
        s = crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_tape_create: out of memory for %zu instructions", count);
        goto done;
    }
    size_t nfree = 0, k = 0;
    int nregs = 0;
    for (size_t i = 0; i < n; i++) {
        const frep_node *nd = &nodes[i];
        if (!reach[i] || (nd->op == CRISP_FREP_CONST && last_use[i] == NO_REG && i != n - 1))
            continue;
        frep_ins in = {.op = nd->op};
        int ar = crisp_frep_op_arity(nd->op);
        if (nd->op == CRISP_FREP_CONST) in.imm = nd->value;
        int ca = ar >= 1 && nodes[nd->a].op == CRISP_FREP_CONST;
        int cb = ar == 2 && nodes[nd->b].op == CRISP_FREP_CONST;
        uint32_t ra = NO_REG, rb = NO_REG;
        if (ar == 2 && (ca || cb) && imm_form(nd->op, cb) >= 0) {
            in.op = (uint8_t)imm_form(nd->op, cb);
            in.imm = cb ? nodes[nd->b].value : nodes[nd->a].value;
            ra = reg[cb ? nd->a : nd->b];
        } else {
            if (ar >= 1) ra = reg[nd->a];
            if (ar == 2) rb = reg[nd->b];
        }
        /* output register first, then give back the operands' registers */
        uint16_t out;
        if (nfree) {
            out = free_regs[--nfree];
        } else {
            if (nregs >= MAX_REGS) {
                s = crisp_error(CRISP_ERR_LIMIT,
                                "crisp_frep_tape_create: more than %d values live at once", MAX_REGS);
                goto done;
            }
            out = (uint16_t)nregs++;
        }
        in.out = out;
        reg[i] = out;
        if (ra != NO_REG) in.a = (uint16_t)ra;
        if (rb != NO_REG) in.b = (uint16_t)rb;
        if (ar >= 1) {
            uint32_t na = nd->a, nb = ar == 2 ? nd->b : NO_REG;
            if (last_use[na] == i && reg[na] != NO_REG) {
                free_regs[nfree++] = (uint16_t)reg[na];
                reg[na] = NO_REG;
            }
            if (nb != NO_REG && nb != na && last_use[nb] == i && reg[nb] != NO_REG) {
                free_regs[nfree++] = (uint16_t)reg[nb];
                reg[nb] = NO_REG;
            }
        }
        t->ins[k++] = in;
    }
    t->length = k;
    t->registers = nregs;
    t->result = t->ins[k - 1].out;
    *dest = t;
    t = NULL;
done:
    if (t) {
        crisp_free(t->ins);
        free(t);
    }
    crisp_free(last_use);
    crisp_free(reg);
    crisp_free(reach);
    crisp_free(free_regs);
    return s;
}

void crisp_frep_tape_destroy(crisp_frep_tape *t)
{
    if (!t) return;
    crisp_free(t->ins);
    free(t);
}

size_t crisp_frep_tape_length(const crisp_frep_tape *t) { return t ? t->length : 0; }
int crisp_frep_tape_registers(const crisp_frep_tape *t) { return t ? t->registers : 0; }

size_t crisp__frep_shorten(const frep_ins *ins, size_t n, const uint8_t *choices, uint16_t result,
                           uint8_t *live, int registers, frep_ins *dest)
{
    memset(live, 0, (size_t)registers);
    live[result] = 1;
    size_t k = 0;
    for (size_t i = n; i-- > 0;) {
        frep_ins in = ins[i];
        if (!live[in.out]) continue;
        live[in.out] = 0;
        int op = in.op;
        if (frep__is_minmax(op) && choices[i] != FREP_CHOICE_BOTH) {
            int imm = op == FREP_T_MIN_RI || op == FREP_T_MAX_RI;
            if (choices[i] == FREP_CHOICE_B && imm) {
                dest[k++] = (frep_ins){.op = CRISP_FREP_CONST, .out = in.out, .imm = in.imm};
                continue;
            }
            uint16_t src = choices[i] == FREP_CHOICE_A ? in.a : in.b;
            dest[k++] = (frep_ins){.op = FREP_T_COPY, .out = in.out, .a = src};
            live[src] = 1;
            continue;
        }
        dest[k++] = in;
        if (op == CRISP_FREP_CONST || op <= CRISP_FREP_Z) continue;
        live[in.a] = 1;
        if (op >= CRISP_FREP_ADD && op < CRISP_FREP_OP_COUNT) live[in.b] = 1;
    }
    /* written backwards: reverse */
    for (size_t i = 0, j = k - 1; i < j; i++, j--) {
        frep_ins tmp = dest[i];
        dest[i] = dest[j];
        dest[j] = tmp;
    }
    return k;
}

float crisp__frep_eval_scalar(const frep_ins *ins, size_t n, uint16_t result, float *r, float x,
                              float y, float z)
{
    for (size_t i = 0; i < n; i++) {
        const frep_ins in = ins[i];
        float v;
        switch (in.op) {
        case CRISP_FREP_CONST: v = in.imm; break;
        case CRISP_FREP_X: v = x; break;
        case CRISP_FREP_Y: v = y; break;
        case CRISP_FREP_Z: v = z; break;
        case FREP_T_COPY: v = r[in.a]; break;
        case FREP_T_ADD_RI: v = r[in.a] + in.imm; break;
        case FREP_T_MUL_RI: v = r[in.a] * in.imm; break;
        case FREP_T_SUB_RI: v = r[in.a] - in.imm; break;
        case FREP_T_SUB_IR: v = in.imm - r[in.a]; break;
        case FREP_T_DIV_RI: v = r[in.a] / in.imm; break;
        case FREP_T_DIV_IR: v = in.imm / r[in.a]; break;
        case FREP_T_MIN_RI: v = frep_min(r[in.a], in.imm); break;
        case FREP_T_MAX_RI: v = frep_max(r[in.a], in.imm); break;
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

crisp_status crisp_frep_eval_batch(const crisp_frep_tape *t, size_t n, const float *x,
                                   const float *y, const float *z, float *dest)
{
    if (!t || (n && (!x || !y || !z || !dest)))
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_eval_batch: NULL argument");
    float *regs = crisp_malloc_array((size_t)t->registers * FREP_LANES, sizeof *regs);
    if (!regs) return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_eval_batch: out of memory");
    float px[FREP_LANES], py[FREP_LANES], pz[FREP_LANES];
    for (size_t b = 0; b < n; b += FREP_LANES) {
        size_t m = n - b < FREP_LANES ? n - b : FREP_LANES;
        for (size_t k = 0; k < FREP_LANES; k++) {
            size_t s = b + (k < m ? k : 0);
            px[k] = x[s];
            py[k] = y[s];
            pz[k] = z[s];
        }
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
        size_t m = n - b < FREP_LANES ? n - b : FREP_LANES;
        for (size_t k = 0; k < FREP_LANES; k++) {
            size_t s = b + (k < m ? k : 0);
            px[k] = x[s];
            py[k] = y[s];
            pz[k] = z[s];
        }
        crisp__frep_grad_lanes(t->ins, t->length, regs, px, py, pz);
        const float *res = regs + (size_t)t->result * 4 * FREP_LANES;
        for (size_t k = 0; k < m; k++)
            for (int c = 0; c < 4; c++) dest[4 * (b + k) + (size_t)c] = res[c * FREP_LANES + k];
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
