/* Batched interval evaluation: one tape over FREP_LANES boxes at once, each register a row of
 * lower ends and a row of upper ends, in plain loops over lanes that the compiler vectorises (the
 * interval counterpart of eval_float.c; the renderer uses it to decide the 2x2x2-voxel sub-cells
 * of an undecided leaf in one pass instead of one scalar evaluation each).
 *
 * Every lane gives the same bounds, bit for bit, as crisp__frep_interval on its box: the common
 * ops below are the branch-free transcriptions of interval_op.h's cases (same float operations
 * in the same order; ISO C mode keeps fp-contract off), the rest call interval_op.h per lane.
 * tests/frep checks the equality on random expressions and boxes. */
#include "interval_op.h"

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(CRISP_NO_CLONES)
#define FREP_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define FREP_CLONES
#endif

#define L FREP_LANES
#define LOOP for (int k = 0; k < m; k++)

/* unknown (both NaN) when either end is NaN, as at the end of frep_interval_op (written as
 * selects on the values, which GCC vectorises where flags combined with || it does not) */
#define STORE(LV, HV)                                                                              \
    do {                                                                                           \
        float l_ = (LV), h_ = (HV);                                                                \
        ol[k] = h_ != h_ ? h_ : l_;                                                                \
        oh[k] = l_ != l_ ? l_ : h_;                                                                \
    } while (0)

/* Ops that cannot make NaN from a known interval (both ends numbers) and keep an unknown one
 * unknown (both ends NaN) store without the check. */
#define STORE_RAW(LV, HV) (ol[k] = (LV), oh[k] = (HV))

/* Register-immediate forms with a finite immediate of known sign, which need neither the
 * infinity checks nor four products (the same values as the general forms: with c > 0, a0 * c
 * <= a1 * c, so their min and max are these products). */
enum {
    LANE_ADD_C = FREP_T_COUNT, /* a + c */
    LANE_SUB_C,                /* a - c */
    LANE_C_SUB,                /* c - a */
    LANE_MUL_POS,              /* a * c, c > 0; also a / c */
    LANE_MUL_NEG,              /* a * c, c < 0 */
    LANE_DIV_POS,              /* a / c, c > 0 */
    LANE_DIV_NEG               /* a / c, c < 0 */
};

/* One instruction over all lanes: out = op(a, b). */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void
step(int op, float c, int m, float *restrict ol, float *restrict oh, const float *restrict al,
     const float *restrict ah, const float *restrict bl, const float *restrict bh,
     const float *const box[6])
{
    const float *restrict xl = box[0], *restrict xh = box[1], *restrict yl = box[2];
    const float *restrict yh = box[3], *restrict zl = box[4], *restrict zh = box[5];
    switch (op) {
    case CRISP_FREP_CONST:
        LOOP STORE(c, c);
        break;
    case CRISP_FREP_X:
        LOOP STORE(xl[k], xh[k]);
        break;
    case CRISP_FREP_Y:
        LOOP STORE(yl[k], yh[k]);
        break;
    case CRISP_FREP_Z:
        LOOP STORE(zl[k], zh[k]);
        break;
    case FREP_T_COPY:
        LOOP STORE_RAW(al[k], ah[k]);
        break;
    case CRISP_FREP_NEG:
        LOOP STORE_RAW(-ah[k], -al[k]);
        break;
    case CRISP_FREP_ABS:
        LOOP
        {
            float a0 = al[k], a1 = ah[k];
            float l = a0 >= 0 ? a0 : a1 <= 0 ? -a1 : 0.0f;
            float h = a0 >= 0 ? a1 : a1 <= 0 ? -a0 : frep_max2(-a0, a1);
            l = a0 != a0 ? NAN : l;
            STORE(l, h);
        }
        break;
    case CRISP_FREP_SQUARE:
        LOOP
        {
            float a0 = al[k], a1 = ah[k], s0 = a0 * a0, s1 = a1 * a1;
            float l = a0 >= 0 ? s0 : a1 <= 0 ? s1 : 0.0f;
            float h = a0 >= 0 ? s1 : a1 <= 0 ? s0 : frep_max2(s0, s1);
            l = a0 != a0 ? NAN : l;
            STORE(l, h);
        }
        break;
    case CRISP_FREP_SQRT:
        LOOP
        {
            float a0 = al[k], a1 = ah[k];
            int ok = a0 >= 0;
            /* the arguments of lanes that are not ok are replaced, so no lane takes the
             * square root of a negative number (the result would be dropped anyway) */
            float l = sqrtf(ok ? a0 : 0.0f), h = sqrtf(ok ? a1 : 0.0f);
            STORE(ok ? l : NAN, h);
        }
        break;
    case CRISP_FREP_FLOOR:
        LOOP STORE(floorf(al[k]), floorf(ah[k]));
        break;
    case CRISP_FREP_CEIL:
        LOOP STORE(ceilf(al[k]), ceilf(ah[k]));
        break;
    case LANE_ADD_C:
        LOOP STORE_RAW(al[k] + c, ah[k] + c);
        break;
    case LANE_SUB_C:
        LOOP STORE_RAW(al[k] - c, ah[k] - c);
        break;
    case LANE_C_SUB:
        LOOP STORE_RAW(c - ah[k], c - al[k]);
        break;
    case LANE_MUL_POS:
        LOOP STORE_RAW(al[k] * c, ah[k] * c);
        break;
    case LANE_MUL_NEG:
        LOOP STORE_RAW(ah[k] * c, al[k] * c);
        break;
    case LANE_DIV_POS:
        LOOP STORE_RAW(al[k] / c, ah[k] / c);
        break;
    case LANE_DIV_NEG:
        LOOP STORE_RAW(ah[k] / c, al[k] / c);
        break;
    case CRISP_FREP_SIN:
    case CRISP_FREP_COS: {
        int cosine = op == CRISP_FREP_COS;
        LOOP
        {
            float a0 = al[k], a1 = ah[k], l, h;
            frep_trig_range(a0, a1, cosine, &l, &h);
            int bad = !frep_fin(a0) || !frep_fin(a1);
            STORE(bad ? NAN : l, h);
        }
        break;
    }
    case CRISP_FREP_EXP:
        /* one exp per loop (GCC leaves a loop with two scalar) */
        LOOP ol[k] = frep_wlo(frep_expf(al[k]));
        LOOP oh[k] = frep_whi(frep_expf(ah[k]));
        LOOP STORE(ol[k] < 0 ? 0.0f : ol[k], oh[k]); /* frep_max2(l, 0) */
        break;
    case CRISP_FREP_LN:
        LOOP
        {
            float a0 = al[k];
            float l = frep_wlo(frep_logf(a0)), h = frep_whi(frep_logf(ah[k]));
            STORE(a0 >= 0 ? l : NAN, h);
        }
        break;
    case CRISP_FREP_ADD:
    case FREP_T_ADD_RI:
        LOOP
        {
            float a0 = al[k], a1 = ah[k];
            float b0 = bl[k], b1 = bh[k];
            int bad = (a1 == INFINITY && b0 == -INFINITY) || (a0 == -INFINITY && b1 == INFINITY);
            STORE(bad ? NAN : a0 + b0, a1 + b1);
        }
        break;
    case CRISP_FREP_SUB:
    case FREP_T_SUB_RI:
        LOOP
        {
            float a0 = al[k], a1 = ah[k];
            float b0 = bl[k], b1 = bh[k];
            int bad = (a1 == INFINITY && b1 == INFINITY) || (a0 == -INFINITY && b0 == -INFINITY);
            STORE(bad ? NAN : a0 - b1, a1 - b0);
        }
        break;
    case FREP_T_SUB_IR:
        LOOP
        {
            float a0 = al[k], a1 = ah[k];
            int bad = (a1 == INFINITY && c == INFINITY) || (a0 == -INFINITY && c == -INFINITY);
            STORE(bad ? NAN : c - a1, c - a0);
        }
        break;
    case CRISP_FREP_MUL:
    case FREP_T_MUL_RI:
        LOOP
        {
            float a0 = al[k], a1 = ah[k];
            float b0 = bl[k], b1 = bh[k];
            float p0 = a0 * b0, p1 = a0 * b1, p2 = a1 * b0, p3 = a1 * b1;
            float l = frep_min2(frep_min2(p0, p1), frep_min2(p2, p3));
            float h = frep_max2(frep_max2(p0, p1), frep_max2(p2, p3));
            int bad = ((!frep_fin(a0) || !frep_fin(a1)) && b0 <= 0 && b1 >= 0) ||
                      ((!frep_fin(b0) || !frep_fin(b1)) && a0 <= 0 && a1 >= 0) || p0 != p0 ||
                      p1 != p1 || p2 != p2 || p3 != p3;
            STORE(bad ? NAN : l, h);
        }
        break;
    case CRISP_FREP_DIV:
    case FREP_T_DIV_RI:
        LOOP
        {
            float n0 = al[k], n1 = ah[k], d0 = bl[k], d1 = bh[k];
            int ok = d0 > 0 || d1 < 0;
            /* lanes that are not ok divide by 1 instead (their result is dropped) */
            float e0 = ok ? d0 : 1.0f, e1 = ok ? d1 : 1.0f;
            float q0 = n0 / e0, q1 = n0 / e1, q2 = n1 / e0, q3 = n1 / e1;
            float l = frep_min2(frep_min2(q0, q1), frep_min2(q2, q3));
            float h = frep_max2(frep_max2(q0, q1), frep_max2(q2, q3));
            int bad = !ok || n0 != n0 ||
                      ((!frep_fin(n0) || !frep_fin(n1)) && (!frep_fin(d0) || !frep_fin(d1)));
            STORE(bad ? NAN : l, h);
        }
        break;
    case CRISP_FREP_MIN:
    case FREP_T_MIN_RI:
        LOOP
        {
            float a0 = al[k], a1 = ah[k];
            float b0 = bl[k], b1 = bh[k];
            float l = a0 != a0 ? a0 : b0 != b0 ? b0 : frep_min2(a0, b0);
            STORE(l, frep_min2(a1, b1));
        }
        break;
    case CRISP_FREP_MAX:
    case FREP_T_MAX_RI:
        LOOP
        {
            float a0 = al[k], a1 = ah[k];
            float b0 = bl[k], b1 = bh[k];
            float l = a0 != a0 ? a0 : b0 != b0 ? b0 : frep_max2(a0, b0);
            STORE(l, frep_max2(a1, b1));
        }
        break;
    default:
        /* the rare ops, one lane at a time through the scalar definition */
        for (int k = 0; k < m; k++) {
            const float x[2] = {xl[k], xh[k]}, y[2] = {yl[k], yh[k]}, z[2] = {zl[k], zh[k]};
            frep_interval_op(op, c, al[k], ah[k], bl[k], bh[k], x, y, z, &ol[k], &oh[k]);
        }
        break;
    }
}

/* The op that step() runs for instruction in: a specialised form where one applies. */
static int lane_op(const frep_ins *in)
{
    float c = in->imm;
    if (!(c >= -FLT_MAX && c <= FLT_MAX)) return in->op;
    switch (in->op) {
    case FREP_T_ADD_RI:
        return LANE_ADD_C;
    case FREP_T_SUB_RI:
        return LANE_SUB_C;
    case FREP_T_SUB_IR:
        return LANE_C_SUB;
    case FREP_T_MUL_RI:
        return c > 0 ? LANE_MUL_POS : c < 0 ? LANE_MUL_NEG : in->op;
    case FREP_T_DIV_RI:
        return c > 0 ? LANE_DIV_POS : c < 0 ? LANE_DIV_NEG : in->op;
    case FREP_T_DIV_IR:
        return FREP_T_DIV_RI; /* with a and b swapped by the caller */
    default:
        return in->op;
    }
}

FREP_CLONES
void crisp__frep_interval_lanes(const frep_ins *ins, size_t n, int lanes, float *lo, float *hi,
                                const float *const box[6], uint8_t *choices, size_t *decided)
{
    float crow[L];
    int m = lanes;
    for (size_t i = 0; i < n; i++) {
        const frep_ins in = ins[i];
        const float *al = lo + (size_t)in.a * L, *ah = hi + (size_t)in.a * L;
        const float *bl = lo + (size_t)in.b * L, *bh = hi + (size_t)in.b * L;
        int op = lane_op(&in);
        if (op >= FREP_T_ADD_RI && op < FREP_T_COUNT) {
            /* register-immediate ops read the immediate as a constant row b (imm / a: a) */
            LOOP crow[k] = in.imm;
            if (in.op == FREP_T_DIV_IR)
                bl = al, bh = ah, al = ah = crow;
            else
                bl = bh = crow;
        }
        step(op, in.imm, m, lo + (size_t)in.out * L, hi + (size_t)in.out * L, al, ah, bl, bh, box);
        if (choices && frep__is_minmax(in.op)) {
            /* which side wins, as frep_interval_op decides it (the operands are intact: the
             * output register is neither of them) */
            int is_min = in.op == CRISP_FREP_MIN || in.op == FREP_T_MIN_RI;
            for (int k = 0; k < m; k++) {
                float a0 = al[k], a1 = ah[k], b0 = bl[k], b1 = bh[k];
                int ch = is_min ? (a1 < b0   ? FREP_CHOICE_A
                                   : b1 < a0 ? FREP_CHOICE_B
                                             : FREP_CHOICE_BOTH)
                                : (a0 > b1   ? FREP_CHOICE_A
                                   : b0 > a1 ? FREP_CHOICE_B
                                             : FREP_CHOICE_BOTH);
                ch = a0 != a0 || b0 != b0 ? FREP_CHOICE_BOTH : ch;
                choices[(size_t)k * n + i] = (uint8_t)ch;
                decided[k] += ch != FREP_CHOICE_BOTH;
            }
        }
    }
}
