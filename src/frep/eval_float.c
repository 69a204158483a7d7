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
        case CRISP_FREP_CONST: LOOP o[k] = c; break;
        case CRISP_FREP_X: LOOP o[k] = x[k]; break;
        case CRISP_FREP_Y: LOOP o[k] = y[k]; break;
        case CRISP_FREP_Z: LOOP o[k] = z[k]; break;
        case FREP_T_COPY: LOOP o[k] = a[k]; break;
        case CRISP_FREP_NEG: LOOP o[k] = -a[k]; break;
        case CRISP_FREP_ABS: LOOP o[k] = fabsf(a[k]); break;
        case CRISP_FREP_SQRT: LOOP o[k] = sqrtf(a[k]); break;
        case CRISP_FREP_SQUARE: LOOP o[k] = a[k] * a[k]; break;
        case CRISP_FREP_ADD: LOOP o[k] = a[k] + b[k]; break;
        case CRISP_FREP_SUB: LOOP o[k] = a[k] - b[k]; break;
        case CRISP_FREP_MUL: LOOP o[k] = a[k] * b[k]; break;
        case CRISP_FREP_DIV: LOOP o[k] = a[k] / b[k]; break;
        case CRISP_FREP_MIN:
            LOOP {
                float r = b[k] < a[k] ? b[k] : a[k];
                o[k] = b[k] != b[k] ? b[k] : r;
            }
            break;
        case CRISP_FREP_MAX:
            LOOP {
                float r = b[k] > a[k] ? b[k] : a[k];
                o[k] = b[k] != b[k] ? b[k] : r;
            }
            break;
        case FREP_T_ADD_RI: LOOP o[k] = a[k] + c; break;
        case FREP_T_MUL_RI: LOOP o[k] = a[k] * c; break;
        case FREP_T_SUB_RI: LOOP o[k] = a[k] - c; break;
        case FREP_T_SUB_IR: LOOP o[k] = c - a[k]; break;
        case FREP_T_DIV_RI: LOOP o[k] = a[k] / c; break;
        case FREP_T_DIV_IR: LOOP o[k] = c / a[k]; break;
        case FREP_T_MIN_RI:
            if (c != c) LOOP o[k] = c;
            else LOOP o[k] = c < a[k] ? c : a[k];
            break;
        case FREP_T_MAX_RI:
            if (c != c) LOOP o[k] = c;
            else LOOP o[k] = c > a[k] ? c : a[k];
            break;
        default:
            if (in.op < CRISP_FREP_ADD) LOOP o[k] = frep_unary(in.op, a[k]);
            else LOOP o[k] = frep_binary(in.op, a[k], b[k]);
            break;
        }
    }
}

/* Forward-mode derivatives: each register holds 4 planes (value, d/dx, d/dy, d/dz). */
void crisp__frep_grad_lanes(const frep_ins *ins, size_t n, float *regs, const float *x,
                            const float *y, const float *z)
{
    for (size_t i = 0; i < n; i++) {
        const frep_ins in = ins[i];
        float *o = regs + (size_t)in.out * 4 * L;
        const float *a = regs + (size_t)in.a * 4 * L;
        const float *b = regs + (size_t)in.b * 4 * L;
        const float c = in.imm;
        for (int k = 0; k < L; k++) {
            float av = a[k], bv = b[k], v, da, db = 0; /* o' = da * a' + db * b' */
            int op = in.op, bimm = 0;
            if (op >= FREP_T_ADD_RI) {
                bv = c;
                bimm = 1;
            }
            switch (op) {
            case CRISP_FREP_CONST:
                o[k] = c;
                o[L + k] = o[2 * L + k] = o[3 * L + k] = 0;
                continue;
            case CRISP_FREP_X:
            case CRISP_FREP_Y:
            case CRISP_FREP_Z:
                o[k] = op == CRISP_FREP_X ? x[k] : op == CRISP_FREP_Y ? y[k] : z[k];
                o[L + k] = op == CRISP_FREP_X;
                o[2 * L + k] = op == CRISP_FREP_Y;
                o[3 * L + k] = op == CRISP_FREP_Z;
                continue;
            case FREP_T_COPY: v = av, da = 1; break;
            case CRISP_FREP_NEG: v = -av, da = -1; break;
            case CRISP_FREP_ABS: v = fabsf(av), da = av < 0 ? -1.0f : 1.0f; break;
            case CRISP_FREP_SQRT: v = sqrtf(av), da = v > 0 ? 0.5f / v : 0; break;
            case CRISP_FREP_SQUARE: v = av * av, da = 2 * av; break;
            case CRISP_FREP_SIN: v = sinf(av), da = cosf(av); break;
            case CRISP_FREP_COS: v = cosf(av), da = -sinf(av); break;
            case CRISP_FREP_TAN: v = tanf(av), da = 1 + v * v; break;
            case CRISP_FREP_ASIN: v = asinf(av), da = 1 / sqrtf(1 - av * av); break;
            case CRISP_FREP_ACOS: v = acosf(av), da = -1 / sqrtf(1 - av * av); break;
            case CRISP_FREP_ATAN: v = atanf(av), da = 1 / (1 + av * av); break;
            case CRISP_FREP_EXP: v = expf(av), da = v; break;
            case CRISP_FREP_LN: v = logf(av), da = 1 / av; break;
            case CRISP_FREP_ADD:
            case FREP_T_ADD_RI: v = av + bv, da = 1, db = 1; break;
            case CRISP_FREP_SUB:
            case FREP_T_SUB_RI: v = av - bv, da = 1, db = -1; break;
            case FREP_T_SUB_IR: v = bv - av, da = -1; break;
            case CRISP_FREP_MUL:
            case FREP_T_MUL_RI: v = av * bv, da = bv, db = av; break;
            case CRISP_FREP_DIV:
            case FREP_T_DIV_RI: v = av / bv, da = 1 / bv, db = -v / bv; break;
            case FREP_T_DIV_IR: v = bv / av, da = -v / av; break;
            case CRISP_FREP_ATAN2: {
                float d = av * av + bv * bv;
                v = atan2f(av, bv), da = d > 0 ? bv / d : 0, db = d > 0 ? -av / d : 0;
                break;
            }
            case CRISP_FREP_MIN:
            case FREP_T_MIN_RI:
                v = frep_min(av, bv);
                da = bv < av ? 0.0f : 1.0f, db = 1 - da;
                break;
            case CRISP_FREP_MAX:
            case FREP_T_MAX_RI:
                v = frep_max(av, bv);
                da = bv > av ? 0.0f : 1.0f, db = 1 - da;
                break;
            case CRISP_FREP_MOD: v = frep_mod(av, bv), da = 1; break;
            case CRISP_FREP_AND: v = av == 0 ? av : bv, da = av == 0, db = av != 0; break;
            case CRISP_FREP_OR: v = av != 0 ? av : bv, da = av != 0, db = av == 0; break;
            default:
                /* floor ceil round not compare: piecewise constant */
                v = op < CRISP_FREP_ADD ? frep_unary(op, av) : frep_binary(op, av, bv), da = 0;
                break;
            }
            o[k] = v;
            for (int d = 1; d < 4; d++) {
                float g = da * a[d * L + k];
                if (!bimm && db != 0) g += db * b[d * L + k];
                o[d * L + k] = g;
            }
        }
    }
}
