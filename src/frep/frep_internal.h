/* Private to the frep module: the DAG node record, the tape instruction set and the scalar
 * semantics of every op (one definition shared by constant folding and all evaluators, so a
 * folded constant equals what the tape would have computed). Semantics: data/README.md (.vm). */
#ifndef CRISP_FREP_INTERNAL_H
#define CRISP_FREP_INTERNAL_H

#include <math.h>
#include <stdint.h>

#include "crisp/frep.h"

/* ---- DAG ------------------------------------------------------------------------------------- */

typedef struct frep_node {
    uint8_t op;
    uint32_t a, b; /* argument nodes (unused ones are 0) */
    float value;   /* CONST */
} frep_node;

struct crisp_frep {
    frep_node *nodes;
    size_t count, cap;
    uint32_t *table; /* open addressing, UINT32_MAX = empty */
    size_t table_cap;
    crisp_frep_node root;
};

/* ---- tape ------------------------------------------------------------------------------------ */

/* Tape opcodes: the crisp_frep_op values (CONST loads imm; X Y Z load a coordinate; unary and
 * binary ops on registers), plus a register copy and register-immediate forms. */
enum {
    FREP_T_COPY = CRISP_FREP_OP_COUNT,
    FREP_T_ADD_RI, /* a + imm */
    FREP_T_MUL_RI, /* a * imm */
    FREP_T_SUB_RI, /* a - imm */
    FREP_T_SUB_IR, /* imm - a */
    FREP_T_DIV_RI, /* a / imm */
    FREP_T_DIV_IR, /* imm / a */
    FREP_T_MIN_RI, /* min(a, imm) */
    FREP_T_MAX_RI, /* max(a, imm) */
    FREP_T_COUNT
};

typedef struct frep_ins {
    uint8_t op;
    uint8_t pad;
    uint16_t out, a, b; /* registers; out never equals a or b */
    float imm;
} frep_ins;

struct crisp_frep_tape {
    frep_ins *ins;
    size_t length;
    int registers;
    uint16_t result; /* register of the last instruction */
};

/* Interval-evaluation choices recorded per min/max instruction. */
enum { FREP_CHOICE_BOTH = 0, FREP_CHOICE_A = 1, FREP_CHOICE_B = 2 };

/* Lanes of the batched float evaluator (one 8x8 tile). */
#define FREP_LANES 64

static inline int frep__is_minmax(int op)
{
    return op == CRISP_FREP_MIN || op == CRISP_FREP_MAX || op == FREP_T_MIN_RI ||
           op == FREP_T_MAX_RI;
}

/* Interval evaluation of ins[0..n) with registers lo/hi; choices (may be NULL) gets one entry per
 * instruction. Returns the number of decided min/max (choices other than BOTH). */
size_t crisp__frep_interval(const frep_ins *ins, size_t n, float *lo, float *hi, const float x[2],
                            const float y[2], const float z[2], uint8_t *choices);
/* Shortened copy of ins[0..n) after choosing min/max sides and removing dead code; live is
 * scratch of one byte per register. Returns the new length (>= 1). */
size_t crisp__frep_shorten(const frep_ins *ins, size_t n, const uint8_t *choices, uint16_t result,
                           uint8_t *live, int registers, frep_ins *dest);
/* FREP_LANES points: regs holds registers x FREP_LANES floats. */
void crisp__frep_eval_lanes(const frep_ins *ins, size_t n, float *regs, const float *x,
                            const float *y, const float *z);
/* Gradients for FREP_LANES points: regs holds registers x 4 x FREP_LANES floats; the result
 * register holds value, d/dx, d/dy, d/dz planes. */
void crisp__frep_grad_lanes(const frep_ins *ins, size_t n, float *regs, const float *x,
                            const float *y, const float *z);
/* One point, scalar; regs holds registers floats. */
float crisp__frep_eval_scalar(const frep_ins *ins, size_t n, uint16_t result, float *regs, float x,
                              float y, float z);

/* ---- scalar semantics ------------------------------------------------------------------------ */

static inline float frep_min(float a, float b)
{
    float r = b < a ? b : a;
    return b != b ? b : r; /* a NaN already gives a */
}
static inline float frep_max(float a, float b)
{
    float r = b > a ? b : a;
    return b != b ? b : r;
}
static inline float frep_compare(float a, float b)
{
    return a < b ? -1.0f : a > b ? 1.0f : a == b ? 0.0f : NAN;
}
static inline float frep_mod(float a, float b)
{
    float r = fmodf(a, b);
    return r < 0 ? r + fabsf(b) : r;
}

static inline float frep_unary(int op, float a)
{
    switch (op) {
    case CRISP_FREP_NEG: return -a;
    case CRISP_FREP_ABS: return fabsf(a);
    case CRISP_FREP_SQRT: return sqrtf(a);
    case CRISP_FREP_SQUARE: return a * a;
    case CRISP_FREP_FLOOR: return floorf(a);
    case CRISP_FREP_CEIL: return ceilf(a);
    case CRISP_FREP_ROUND: return roundf(a);
    case CRISP_FREP_SIN: return sinf(a);
    case CRISP_FREP_COS: return cosf(a);
    case CRISP_FREP_TAN: return tanf(a);
    case CRISP_FREP_ASIN: return asinf(a);
    case CRISP_FREP_ACOS: return acosf(a);
    case CRISP_FREP_ATAN: return atanf(a);
    case CRISP_FREP_EXP: return expf(a);
    case CRISP_FREP_LN: return logf(a);
    case CRISP_FREP_NOT: return a == 0 ? 1.0f : 0.0f;
    default: return NAN;
    }
}

static inline float frep_binary(int op, float a, float b)
{
    switch (op) {
    case CRISP_FREP_ADD: return a + b;
    case CRISP_FREP_SUB: return a - b;
    case CRISP_FREP_MUL: return a * b;
    case CRISP_FREP_DIV: return a / b;
    case CRISP_FREP_ATAN2: return atan2f(a, b);
    case CRISP_FREP_MIN: return frep_min(a, b);
    case CRISP_FREP_MAX: return frep_max(a, b);
    case CRISP_FREP_COMPARE: return frep_compare(a, b);
    case CRISP_FREP_MOD: return frep_mod(a, b);
    case CRISP_FREP_AND: return a == 0 ? a : b;
    case CRISP_FREP_OR: return a != 0 ? a : b;
    default: return NAN;
    }
}

#endif
