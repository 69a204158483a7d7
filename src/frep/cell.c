/* The cell evaluator (include/crisp/frep_cell.h): one worker's scratch for evaluating a tape
 * over the cells of a subdivision that lives outside src/frep (the scene renderer's view
 * frustum). Interval evaluation with branch recording (Keeter 2012), SSA tape shortening onto a
 * stack (Fidget), batched float and gradient lanes; everything allocated once at creation so
 * that no cell allocates. It only wraps the evaluators of frep_internal.h. */
#include "crisp/frep_cell.h"

#include <math.h>
#include <stdlib.h>

#include "frep_internal.h"

#if CRISP_FREP_CELL_LANES != FREP_LANES
#error "crisp_frep_cell lanes must match the batched evaluator's"
#endif

struct crisp_frep_cell {
    const crisp_frep_tape *tape;
    frep_shorten_scratch sc;
    uint8_t *choices;
    float *lo, *hi;  /* interval registers */
    float *regs;     /* registers x FREP_LANES */
    float *gregs;    /* registers x 4 x FREP_LANES */
    frep_ins *stack; /* shortened tapes, one after another */
    uint32_t *stack_ssa;
    size_t stack_cap, top;
};

void crisp_frep_cell_destroy(crisp_frep_cell *c)
{
    if (!c) return;
    crisp__frep_scratch_free(&c->sc);
    crisp_free(c->choices);
    crisp_free(c->lo);
    crisp_free(c->regs);
    crisp_free(c->gregs);
    crisp_free(c->stack);
    crisp_free(c->stack_ssa);
    free(c);
}

crisp_status crisp_frep_cell_create(const crisp_frep_tape *tape, size_t stack_entries,
                                    crisp_frep_cell **dest)
{
    if (!tape || !dest)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_cell_create: NULL argument");
    *dest = NULL;
    size_t len = tape->length, nr = (size_t)tape->registers;
    if (len == 0 || nr == 0)
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_frep_cell_create: empty tape");
    if (stack_entries == 0) {
        stack_entries = len <= ((size_t)1 << 20) / 8 ? 8 * len : (size_t)1 << 20;
    }
    if (stack_entries < len) stack_entries = len;
    crisp_frep_cell *c = calloc(1, sizeof *c);
    if (!c) return crisp_error(CRISP_ERR_NO_MEMORY, "crisp_frep_cell_create: out of memory");
    c->tape = tape;
    crisp_status s = crisp__frep_scratch_init(&c->sc, len, tape->registers);
    if (s) {
        free(c);
        return s;
    }
    c->choices = crisp_calloc_array(len, 1);
    c->lo = crisp_calloc_array(2 * nr, sizeof *c->lo);
    c->hi = c->lo ? c->lo + nr : NULL;
    c->regs = crisp_calloc_array(nr * FREP_LANES, sizeof *c->regs);
    c->gregs = crisp_calloc_array(nr * 4 * FREP_LANES, sizeof *c->gregs);
    c->stack = crisp_malloc_array(stack_entries, sizeof *c->stack);
    c->stack_ssa = crisp_malloc_array(stack_entries, 2 * sizeof *c->stack_ssa);
    c->stack_cap = stack_entries;
    if (!c->choices || !c->lo || !c->regs || !c->gregs || !c->stack || !c->stack_ssa) {
        crisp_frep_cell_destroy(c);
        return crisp_error(CRISP_ERR_NO_MEMORY,
                           "crisp_frep_cell_create: out of memory for a tape of %zu instructions "
                           "and %zu registers",
                           len, nr);
    }
    *dest = c;
    return CRISP_OK;
}

crisp_frep_subtape crisp_frep_cell_full(const crisp_frep_cell *c)
{
    return (crisp_frep_subtape){c->tape->ins, c->tape->ssa, c->tape->length, c->tape->registers};
}

size_t crisp_frep_cell_interval(crisp_frep_cell *c, crisp_frep_subtape t, const float x[2],
                                const float y[2], const float z[2], float dest[2])
{
    const frep_ins *ins = t.ins;
    size_t d = crisp__frep_interval(ins, t.length, c->lo, c->hi, x, y, z, c->choices);
    uint16_t res = ins[t.length - 1].out;
    dest[0] = c->lo[res];
    dest[1] = c->hi[res];
    return d;
}

crisp_frep_subtape crisp_frep_cell_shorten(crisp_frep_cell *c, crisp_frep_subtape t)
{
    if (c->stack_cap - c->top < t.length) return t;
    frep_span src = {t.ins, t.ssa, t.length, t.registers}, out;
    if (crisp__frep_shorten(src, c->choices, &c->sc, c->stack + c->top, c->stack_ssa + 2 * c->top,
                            &out))
        return t;
    c->top += out.len;
    return (crisp_frep_subtape){out.ins, out.ssa, out.len, out.registers};
}

size_t crisp_frep_cell_mark(const crisp_frep_cell *c)
{
    return c->top;
}

void crisp_frep_cell_release(crisp_frep_cell *c, size_t mark)
{
    if (mark <= c->top) c->top = mark;
}

const float *crisp_frep_cell_eval(crisp_frep_cell *c, crisp_frep_subtape t, const float *x,
                                  const float *y, const float *z)
{
    const frep_ins *ins = t.ins;
    crisp__frep_eval_lanes(ins, t.length, c->regs, x, y, z);
    return c->regs + (size_t)ins[t.length - 1].out * FREP_LANES;
}

const float *crisp_frep_cell_grad(crisp_frep_cell *c, crisp_frep_subtape t, const float *x,
                                  const float *y, const float *z)
{
    const frep_ins *ins = t.ins;
    crisp__frep_grad_lanes(ins, t.length, c->gregs, x, y, z);
    return c->gregs + (size_t)ins[t.length - 1].out * 4 * FREP_LANES;
}
