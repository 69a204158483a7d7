/* Private to the frep module: the DAG node record, the tape instruction set and the scalar
 * semantics of every op (one definition shared by constant folding and all evaluators, so a
 * folded constant equals what the tape would have computed). Semantics: data/README.md (.vm). */
#ifndef CRISP_FREP_INTERNAL_H
#define CRISP_FREP_INTERNAL_H

#include <math.h>
#include <stdint.h>
#include <string.h>

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

/* A tape is two parallel arrays: the register form above (what the evaluators run) and the SSA
 * form, ssa[2i], ssa[2i+1] = the instructions whose values instruction i reads (what shortening
 * works on: in SSA, replacing a min by its chosen side is a renaming, never a copy). */
typedef struct frep_span {
    const frep_ins *ins;
    const uint32_t *ssa;
    size_t len;
    int registers;
} frep_span;

struct crisp_frep_tape {
    frep_ins *ins;
    uint32_t *ssa;
    size_t length;
    int registers;
    uint16_t result; /* register of the last instruction */
};

/* Scratch for crisp__frep_shorten, for tapes of up to cap instructions and max_regs registers. */
typedef struct frep_shorten_scratch {
    uint32_t *rep, *reg_of, *pos;
    uint16_t *free_regs;
    size_t cap;
    int max_regs;
} frep_shorten_scratch;

crisp_status crisp__frep_scratch_init(frep_shorten_scratch *s, size_t cap, int max_regs);
void crisp__frep_scratch_free(frep_shorten_scratch *s);

/* Number of register/SSA operands of a tape op. */
static inline int frep__nargs(int op)
{
    if (op <= CRISP_FREP_Z) return 0;
    if (op < CRISP_FREP_ADD || op >= FREP_T_COPY) return 1;
    return 2;
}

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
/* Interval evaluation of ins[0..n) over `lanes` boxes at once (a multiple of 16, at most
 * FREP_LANES): box = {x lo, x hi, y lo, y hi, z lo, z hi}, each `lanes` floats; lo and hi hold
 * registers x FREP_LANES floats (register r of lane k at r * FREP_LANES + k). Lane k gets the
 * bounds crisp__frep_interval gives for box k (equal values; a zero's sign may differ). With
 * choices (else NULL), lane k's min/max choices go to choices[k * n + i] (entries of other
 * instructions are left as they were) and decided[k] (zeroed by the caller) counts them. */
void crisp__frep_interval_lanes(const frep_ins *ins, size_t n, int lanes, float *lo, float *hi,
                                const float *const box[6], uint8_t *choices, size_t *decided);
/* Shorten tape src after the min/max choices (NULL: keep every side), removing dead code and
 * allocating registers afresh (reverse linear scan), into dest_ins/dest_ssa (src.len entries
 * each). Returns 0, or -1 when the result would need more than scratch->max_regs registers. */
int crisp__frep_shorten(frep_span src, const uint8_t *choices, frep_shorten_scratch *scratch,
                        frep_ins *dest_ins, uint32_t *dest_ssa, frep_span *dest);
/* The same shortening without reallocating registers (cheaper: two passes without register
 * bookkeeping; the result keeps src's registers, and a decided min/max becomes a copy of its
 * side or a constant). choices must not be NULL. Returns 0. */
int crisp__frep_prune(frep_span src, const uint8_t *choices, frep_shorten_scratch *scratch,
                      frep_ins *dest_ins, uint32_t *dest_ssa, frep_span *dest);
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

/* exp and ln written without branches or calls so the batched evaluator vectorises them; every
 * evaluator uses these same functions, so all agree bit for bit. Error: a few ulps (degree-7
 * Taylor for exp after a Cody-Waite reduction by ln 2; atanh series for ln on [sqrt(1/2),
 * sqrt(2))), below the 1e-6 relative widening of the interval evaluator. */
static inline float frep_bits_float(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}
static inline uint32_t frep_float_bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static inline float frep_expf(float x)
{
    /* straight-line selects only, so GCC if-converts and vectorises (the clamp keeps the
     * conversion to int defined; NaN and out-of-range x are replaced at the end) */
    float t = x * 1.44269504f;
    t = t > -151.0f ? t : -151.0f;
    t = t < 129.0f ? t : 129.0f;
    float nf = rintf(t);
    int32_t n = (int32_t)nf;
    float r = (x - nf * 0.693359375f) - nf * -2.12194440e-4f;
    float p =
        1.0f + r * (1.0f + r * (0.5f + r * (1.6666667e-1f +
                                            r * (4.1666668e-2f +
                                                 r * (8.3333338e-3f +
                                                      r * (1.3888889e-3f + r * 1.9841270e-4f))))));
    /* 2^n in two factors: results that reach the subnormals round instead of breaking */
    int32_t n1 = n / 2, n2 = n - n1;
    float res = p * frep_bits_float((uint32_t)(n1 + 127) << 23) *
                frep_bits_float((uint32_t)(n2 + 127) << 23);
    res = x > 88.7228394f ? INFINITY : res;
    res = x < -103.972084f ? 0.0f : res;
    return x != x ? x : res;
}

static inline float frep_logf(float x)
{
    int sub = (x > 0) & (x < 1.17549435e-38f);
    float xs = sub ? x * 8388608.0f : x;
    uint32_t u = frep_float_bits(xs);
    int32_t e = (int32_t)((u >> 23) & 0xffu) - (sub ? 150 : 127);
    float m = frep_bits_float((u & 0x007fffffu) | 0x3f800000u);
    int big = m > 1.41421356f;
    m = big ? m * 0.5f : m;
    e = big ? e + 1 : e;
    float f = (m - 1.0f) / (m + 1.0f), f2 = f * f;
    float sr = f2 * (3.3333334e-1f + f2 * (2.0e-1f + f2 * (1.4285715e-1f + f2 * 1.1111111e-1f)));
    float ef = (float)e;
    float res = (2.0f * f + (2.0f * f * sr + ef * -2.12194440e-4f)) + ef * 0.693359375f;
    res = x == INFINITY ? x : res;
    res = x == 0 ? -INFINITY : res;
    res = x < 0 ? NAN : res;
    return x != x ? x : res;
}

/* sin and cos for |x| <= 8192: Cody-Waite reduction by pi/2 in three parts (exact products for
 * these quadrant counts, as in Cephes), Taylor polynomials of degree 9 and 10 on [-pi/4, pi/4],
 * clamped to [-1, 1]; error about 3e-7, below the 1e-6 widening of the interval evaluator. The
 * batched evaluator vectorises frep_sincos_poly and calls sinf/cosf only for other lanes. */
#define FREP_TRIG_MAX 8192.0f
static inline float frep_sincos_poly(float x, int cosine)
{
    float xc = x > -FREP_TRIG_MAX ? x : -FREP_TRIG_MAX;
    xc = xc < FREP_TRIG_MAX ? xc : FREP_TRIG_MAX; /* NaN becomes -8192 (replaced by the caller) */
    float kf = rintf(xc * 0.636619772f);
    int32_t q = (int32_t)kf + cosine;
    float r =
        ((xc - kf * 1.5703125f) - kf * 4.837512969970703125e-4f) - kf * 7.54978995489188216e-8f;
    float r2 = r * r;
    float sn = r + r * r2 *
                       (-1.6666667e-1f +
                        r2 * (8.3333338e-3f + r2 * (-1.9841270e-4f + r2 * 2.7557319e-6f)));
    float cs =
        1.0f +
        r2 * (-0.5f + r2 * (4.1666668e-2f +
                            r2 * (-1.3888889e-3f + r2 * (2.4801587e-5f + r2 * -2.7557319e-7f))));
    float v = (q & 1) ? cs : sn;
    v = (q & 2) ? -v : v;
    v = v < 1.0f ? v : 1.0f;
    return v > -1.0f ? v : -1.0f;
}
static inline int frep_trig_direct(float x)
{
    return fabsf(x) <= FREP_TRIG_MAX;
}
static inline float frep_sinf(float x)
{
    return frep_trig_direct(x) ? frep_sincos_poly(x, 0) : sinf(x);
}
static inline float frep_cosf(float x)
{
    return frep_trig_direct(x) ? frep_sincos_poly(x, 1) : cosf(x);
}

static inline float frep_unary(int op, float a)
{
    switch (op) {
    case CRISP_FREP_NEG:
        return -a;
    case CRISP_FREP_ABS:
        return fabsf(a);
    case CRISP_FREP_SQRT:
        return sqrtf(a);
    case CRISP_FREP_SQUARE:
        return a * a;
    case CRISP_FREP_FLOOR:
        return floorf(a);
    case CRISP_FREP_CEIL:
        return ceilf(a);
    case CRISP_FREP_ROUND:
        return roundf(a);
    case CRISP_FREP_SIN:
        return frep_sinf(a);
    case CRISP_FREP_COS:
        return frep_cosf(a);
    case CRISP_FREP_TAN:
        return tanf(a);
    case CRISP_FREP_ASIN:
        return asinf(a);
    case CRISP_FREP_ACOS:
        return acosf(a);
    case CRISP_FREP_ATAN:
        return atanf(a);
    case CRISP_FREP_EXP:
        return frep_expf(a);
    case CRISP_FREP_LN:
        return frep_logf(a);
    case CRISP_FREP_NOT:
        return a == 0 ? 1.0f : 0.0f;
    default:
        return NAN;
    }
}

static inline float frep_binary(int op, float a, float b)
{
    switch (op) {
    case CRISP_FREP_ADD:
        return a + b;
    case CRISP_FREP_SUB:
        return a - b;
    case CRISP_FREP_MUL:
        return a * b;
    case CRISP_FREP_DIV:
        return a / b;
    case CRISP_FREP_ATAN2:
        return atan2f(a, b);
    case CRISP_FREP_MIN:
        return frep_min(a, b);
    case CRISP_FREP_MAX:
        return frep_max(a, b);
    case CRISP_FREP_COMPARE:
        return frep_compare(a, b);
    case CRISP_FREP_MOD:
        return frep_mod(a, b);
    case CRISP_FREP_AND:
        return a == 0 ? a : b;
    case CRISP_FREP_OR:
        return a != 0 ? a : b;
    default:
        return NAN;
    }
}

#endif
