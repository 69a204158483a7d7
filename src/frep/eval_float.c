/* Batched float evaluation of a tape: every instruction runs over FREP_LANES points at once, in
 * plain loops over restrict-qualified register rows that the compiler vectorises (the leaf stage
 * of Keeter 2012's array evaluation, Fidget's "float slice" evaluator). The tape never writes a
 * register that the same instruction reads (tape.c), which makes the restrict promises true.
 * With GCC on x86-64 the function is cloned for AVX-512 / AVX2 and picked at run time (ifunc),
 * so the binary still runs on any x86-64. */
#include "frep_internal.h"

#include <math.h>

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(CRISP_NO_CLONES)
#define FREP_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define FREP_CLONES
#endif

#define L FREP_LANES
#define LOOP for (int k = 0; k < L; k++)

FREP_CLONES
void crisp__frep_eval_lanes(const frep_ins *ins, size_t n, float *regs, const float *x,
                            const float *y, const float *z)
{
    for (size_t i = 0; i < n; i++) {
        const frep_ins in = ins[i];
        float *restrict o = regs + (size_t)in.out * L;
        const float *restrict a = regs + (size_t)in.a * L;
        const float *restrict b = regs + (size_t)in.b * L;
        const float c = in.imm;
        switch (in.op) {
        case CRISP_FREP_CONST:
            LOOP o[k] = c;
            break;
        case CRISP_FREP_X:
            LOOP o[k] = x[k];
            break;
        case CRISP_FREP_Y:
            LOOP o[k] = y[k];
            break;
        case CRISP_FREP_Z:
            LOOP o[k] = z[k];
            break;
        case FREP_T_COPY:
            LOOP o[k] = a[k];
            break;
        case CRISP_FREP_NEG:
            LOOP o[k] = -a[k];
            break;
        case CRISP_FREP_ABS:
            LOOP o[k] = fabsf(a[k]);
            break;
        case CRISP_FREP_SQRT:
            LOOP o[k] = sqrtf(a[k]);
            break;
        case CRISP_FREP_SQUARE:
            LOOP o[k] = a[k] * a[k];
            break;
        case CRISP_FREP_ADD:
            LOOP o[k] = a[k] + b[k];
            break;
        case CRISP_FREP_SUB:
            LOOP o[k] = a[k] - b[k];
            break;
        case CRISP_FREP_MUL:
            LOOP o[k] = a[k] * b[k];
            break;
        case CRISP_FREP_DIV:
            LOOP o[k] = a[k] / b[k];
            break;
        case CRISP_FREP_MIN:
            LOOP
            {
                float r = b[k] < a[k] ? b[k] : a[k];
                o[k] = b[k] != b[k] ? b[k] : r;
            }
            break;
        case CRISP_FREP_MAX:
            LOOP
            {
                float r = b[k] > a[k] ? b[k] : a[k];
                o[k] = b[k] != b[k] ? b[k] : r;
            }
            break;
        case CRISP_FREP_SIN:
        case CRISP_FREP_COS: {
            int cosine = in.op == CRISP_FREP_COS, far = 0;
            LOOP o[k] = frep_sincos_poly(a[k], cosine);
            LOOP far |= !frep_trig_direct(a[k]);
            if (far) /* rare: large or non-finite arguments go to libm, as frep_sinf does */
                for (int k = 0; k < L; k++)
                    if (!frep_trig_direct(a[k])) o[k] = cosine ? cosf(a[k]) : sinf(a[k]);
            break;
        }
        case CRISP_FREP_EXP:
            LOOP o[k] = frep_expf(a[k]);
            break;
        case CRISP_FREP_LN:
            LOOP o[k] = frep_logf(a[k]);
            break;
        case FREP_T_ADD_RI:
            LOOP o[k] = a[k] + c;
            break;
        case FREP_T_MUL_RI:
            LOOP o[k] = a[k] * c;
            break;
        case FREP_T_SUB_RI:
            LOOP o[k] = a[k] - c;
            break;
        case FREP_T_SUB_IR:
            LOOP o[k] = c - a[k];
            break;
        case FREP_T_DIV_RI:
            LOOP o[k] = a[k] / c;
            break;
        case FREP_T_DIV_IR:
            LOOP o[k] = c / a[k];
            break;
        case FREP_T_MIN_RI:
            if (c != c)
                LOOP o[k] = c;
            else
                LOOP o[k] = c < a[k] ? c : a[k];
            break;
        case FREP_T_MAX_RI:
            if (c != c)
                LOOP o[k] = c;
            else
                LOOP o[k] = c > a[k] ? c : a[k];
            break;
        default:
            if (in.op < CRISP_FREP_ADD)
                LOOP o[k] = frep_unary(in.op, a[k]);
            else
                LOOP o[k] = frep_binary(in.op, a[k], b[k]);
            break;
        }
    }
}

/* Forward-mode derivatives: each register holds 4 planes (value, d/dx, d/dy, d/dz) of L lanes.
 * The chain rule o' = da * a' + db * b' runs plane by plane in loops that vectorise. */
#define GRAD_UNARY(V, DA)                                                                          \
    LOOP                                                                                           \
    {                                                                                              \
        float av = a[k], v = (V);                                                                  \
        o[k] = v;                                                                                  \
        da[k] = (DA);                                                                              \
        (void)av;                                                                                  \
    }                                                                                              \
    for (int d = 1; d < 4; d++) {                                                                  \
        float *restrict od = o + d * L;                                                            \
        const float *restrict ad = a + d * L;                                                      \
        LOOP od[k] = da[k] * ad[k];                                                                \
    }
#define GRAD_BINARY(V, DA, DB)                                                                     \
    LOOP                                                                                           \
    {                                                                                              \
        float av = a[k], bv = b[k], v = (V);                                                       \
        o[k] = v;                                                                                  \
        da[k] = (DA);                                                                              \
        db[k] = (DB);                                                                              \
    }                                                                                              \
    for (int d = 1; d < 4; d++) {                                                                  \
        float *restrict od = o + d * L;                                                            \
        const float *restrict ad = a + d * L, *restrict bd = b + d * L;                            \
        LOOP od[k] = da[k] * ad[k] + db[k] * bd[k];                                                \
    }

/* min, max and the logic ops pick one side's derivatives instead of multiplying the other's by
 * zero: an infinite or NaN derivative on the losing side (sqrt near 0, a division) must not
 * turn the gradient into NaN, and picking keeps the full tape's gradient equal to that of a tape
 * shortened to the winning side (frep_cell.h promises so). */
#define GRAD_SELECT(V, TAKE_A)                                                                     \
    LOOP                                                                                           \
    {                                                                                              \
        float av = a[k], bv = b[k], v = (V);                                                       \
        o[k] = v;                                                                                  \
        da[k] = (TAKE_A) ? 1.0f : 0.0f;                                                            \
        (void)bv;                                                                                  \
    }                                                                                              \
    for (int d = 1; d < 4; d++) {                                                                  \
        float *restrict od = o + d * L;                                                            \
        const float *restrict ad = a + d * L, *restrict bd = b + d * L;                            \
        LOOP od[k] = da[k] != 0 ? ad[k] : bd[k];                                                   \
    }
/* the same with an immediate as side b (its derivatives are zero) */
#define GRAD_SELECT_IMM(V, TAKE_A)                                                                 \
    LOOP                                                                                           \
    {                                                                                              \
        float av = a[k], v = (V);                                                                  \
        o[k] = v;                                                                                  \
        da[k] = (TAKE_A) ? 1.0f : 0.0f;                                                            \
    }                                                                                              \
    for (int d = 1; d < 4; d++) {                                                                  \
        float *restrict od = o + d * L;                                                            \
        const float *restrict ad = a + d * L;                                                      \
        LOOP od[k] = da[k] != 0 ? ad[k] : 0.0f;                                                    \
    }

FREP_CLONES
void crisp__frep_grad_lanes(const frep_ins *ins, size_t n, float *regs, const float *x,
                            const float *y, const float *z)
{
    float da[L], db[L];
    for (size_t i = 0; i < n; i++) {
        const frep_ins in = ins[i];
        float *restrict o = regs + (size_t)in.out * 4 * L;
        const float *restrict a = regs + (size_t)in.a * 4 * L;
        const float *restrict b = regs + (size_t)in.b * 4 * L;
        const float c = in.imm;
        switch (in.op) {
        case CRISP_FREP_CONST:
            LOOP o[k] = c, o[L + k] = 0, o[2 * L + k] = 0, o[3 * L + k] = 0;
            break;
        case CRISP_FREP_X:
            LOOP o[k] = x[k], o[L + k] = 1, o[2 * L + k] = 0, o[3 * L + k] = 0;
            break;
        case CRISP_FREP_Y:
            LOOP o[k] = y[k], o[L + k] = 0, o[2 * L + k] = 1, o[3 * L + k] = 0;
            break;
        case CRISP_FREP_Z:
            LOOP o[k] = z[k], o[L + k] = 0, o[2 * L + k] = 0, o[3 * L + k] = 1;
            break;
        case FREP_T_COPY:
            GRAD_UNARY(av, 1.0f) break;
        case CRISP_FREP_NEG:
            GRAD_UNARY(-av, -1.0f) break;
        case CRISP_FREP_ABS:
            GRAD_UNARY(fabsf(av), av < 0 ? -1.0f : 1.0f) break;
        case CRISP_FREP_SQRT:
            GRAD_UNARY(sqrtf(av), v > 0 ? 0.5f / v : 0.0f) break;
        case CRISP_FREP_SQUARE:
            GRAD_UNARY(av * av, 2 * av) break;
        case CRISP_FREP_EXP:
            GRAD_UNARY(frep_expf(av), v) break;
        case CRISP_FREP_LN:
            GRAD_UNARY(frep_logf(av), 1 / av) break;
        case CRISP_FREP_SIN:
            GRAD_UNARY(frep_sinf(av), frep_cosf(av)) break;
        case CRISP_FREP_COS:
            GRAD_UNARY(frep_cosf(av), -frep_sinf(av)) break;
        case CRISP_FREP_TAN:
            GRAD_UNARY(tanf(av), 1 + v * v) break;
        case CRISP_FREP_ASIN:
            GRAD_UNARY(asinf(av), 1 / sqrtf(1 - av * av)) break;
        case CRISP_FREP_ACOS:
            GRAD_UNARY(acosf(av), -1 / sqrtf(1 - av * av)) break;
        case CRISP_FREP_ATAN:
            GRAD_UNARY(atanf(av), 1 / (1 + av * av)) break;
        case FREP_T_ADD_RI:
            GRAD_UNARY(av + c, 1.0f) break;
        case FREP_T_SUB_RI:
            GRAD_UNARY(av - c, 1.0f) break;
        case FREP_T_SUB_IR:
            GRAD_UNARY(c - av, -1.0f) break;
        case FREP_T_MUL_RI:
            GRAD_UNARY(av * c, c) break;
        case FREP_T_DIV_RI:
            GRAD_UNARY(av / c, 1 / c) break;
        case FREP_T_DIV_IR:
            GRAD_UNARY(c / av, -v / av) break;
        case FREP_T_MIN_RI:
            GRAD_SELECT_IMM(frep_min(av, c), !(c < av)) break;
        case FREP_T_MAX_RI:
            GRAD_SELECT_IMM(frep_max(av, c), !(c > av)) break;
        case CRISP_FREP_ADD:
            GRAD_BINARY(av + bv, 1.0f, 1.0f) break;
        case CRISP_FREP_SUB:
            GRAD_BINARY(av - bv, 1.0f, -1.0f) break;
        case CRISP_FREP_MUL:
            GRAD_BINARY(av * bv, bv, av) break;
        case CRISP_FREP_DIV:
            GRAD_BINARY(av / bv, 1 / bv, -v / bv) break;
        case CRISP_FREP_MIN:
            GRAD_SELECT(frep_min(av, bv), !(bv < av)) break;
        case CRISP_FREP_MAX:
            GRAD_SELECT(frep_max(av, bv), !(bv > av)) break;
        case CRISP_FREP_ATAN2:
            GRAD_BINARY(atan2f(av, bv), av * av + bv * bv > 0 ? bv / (av * av + bv * bv) : 0.0f,
                        av * av + bv * bv > 0 ? -av / (av * av + bv * bv) : 0.0f)
            break;
        case CRISP_FREP_MOD:
            GRAD_BINARY(frep_mod(av, bv), 1.0f, 0.0f) break;
        case CRISP_FREP_AND:
            GRAD_SELECT(av == 0 ? av : bv, av == 0) break;
        case CRISP_FREP_OR:
            GRAD_SELECT(av != 0 ? av : bv, av != 0) break;
        default:
            /* floor ceil round not compare: piecewise constant */
            if (in.op < CRISP_FREP_ADD) {
                GRAD_UNARY(frep_unary(in.op, av), 0.0f)
            } else {
                GRAD_BINARY(frep_binary(in.op, av, bv), 0.0f, 0.0f)
            }
            break;
        }
    }
}
