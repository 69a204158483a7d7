/* Interval evaluation of a tape (Moore interval arithmetic, as in Keeter 2012 and Fidget's
 * interval evaluator), recording for each min/max which side won (branch caching).
 *
 * Soundness: the result encloses the float value that the point evaluators compute at every
 * float point of the box. + - * / sqrt are correctly rounded and rounding is monotone, so float
 * endpoints need no outward rounding for them; libm functions (sin, exp, ...) are widened by a
 * few ulps. An interval is either lo <= hi (infinite ends allowed: exp overflows to +inf at
 * points too) or "unknown" (both NaN): any op that could give NaN at some point of the box (sqrt
 * of a negative part, division through zero, inf - inf, 0 * inf, NaN constants) gives unknown,
 * and unknown propagates. A cell whose value is
 * unknown is never filled; it is subdivided down to points, which decide exactly. */
#include "frep_internal.h"

#include <float.h>
#include <math.h>

#define PI_D 3.14159265358979323846

static inline float wlo(float v) { return isinf(v) ? v : v - fabsf(v) * 1e-6f - 1e-30f; }
static inline float whi(float v) { return isinf(v) ? v : v + fabsf(v) * 1e-6f + 1e-30f; }
static inline int fin(float v) { return v >= -FLT_MAX && v <= FLT_MAX; }
static inline float min2(float a, float b) { return b < a ? b : a; }
static inline float max2(float a, float b) { return b > a ? b : a; }

/* sin over [lo, hi] (finite): value at the ends plus the extrema inside. */
static void sin_range(float lo, float hi, float phase, float *rlo, float *rhi)
{
    double a = (double)lo + phase, b = (double)hi + phase;
    if (b - a >= 2 * PI_D || fabs(a) > 1e5 || fabs(b) > 1e5) {
        *rlo = -1;
        *rhi = 1;
        return;
    }
    double sa = sin(a), sb = sin(b);
    double l = sa < sb ? sa : sb, h = sa < sb ? sb : sa;
    /* maxima at pi/2 + 2k pi, minima at -pi/2 + 2k pi */
    double kmax = ceil((a - PI_D / 2) / (2 * PI_D));
    if (PI_D / 2 + 2 * PI_D * kmax <= b + 1e-6) h = 1;
    double kmin = ceil((a + PI_D / 2) / (2 * PI_D));
    if (-PI_D / 2 + 2 * PI_D * kmin <= b + 1e-6) l = -1;
    *rlo = l - 1e-6 < -1 ? -1.0f : (float)(l - 1e-6);
    *rhi = h + 1e-6 > 1 ? 1.0f : (float)(h + 1e-6);
}

size_t crisp__frep_interval(const frep_ins *ins, size_t n, float *lo, float *hi, const float x[2],
                            const float y[2], const float z[2], uint8_t *choices)
{
    size_t decided = 0;
    for (size_t i = 0; i < n; i++) {
        const frep_ins in = ins[i];
        float al = lo[in.a], ah = hi[in.a], bl, bh, l, h;
        uint8_t choice = FREP_CHOICE_BOTH;
        if (in.op >= FREP_T_ADD_RI) {
            bl = bh = in.imm;
        } else {
            bl = lo[in.b];
            bh = hi[in.b];
        }
        switch (in.op) {
        case CRISP_FREP_CONST: l = h = in.imm; break;
        case CRISP_FREP_X: l = x[0], h = x[1]; break;
        case CRISP_FREP_Y: l = y[0], h = y[1]; break;
        case CRISP_FREP_Z: l = z[0], h = z[1]; break;
        case FREP_T_COPY: l = al, h = ah; break;
        case CRISP_FREP_NEG: l = -ah, h = -al; break;
        case CRISP_FREP_ABS:
            if (al >= 0) l = al, h = ah;
            else if (ah <= 0) l = -ah, h = -al;
            else l = 0, h = max2(-al, ah);
            if (al != al) l = h = NAN;
            break;
        case CRISP_FREP_SQUARE:
            if (al >= 0) l = al * al, h = ah * ah;
            else if (ah <= 0) l = ah * ah, h = al * al;
            else l = 0, h = max2(al * al, ah * ah);
            if (al != al) l = h = NAN;
            break;
        case CRISP_FREP_SQRT:
            if (al >= 0) l = sqrtf(al), h = sqrtf(ah);
            else l = h = NAN;
            break;
        case CRISP_FREP_FLOOR: l = floorf(al), h = floorf(ah); break;
        case CRISP_FREP_CEIL: l = ceilf(al), h = ceilf(ah); break;
        case CRISP_FREP_ROUND: l = roundf(al), h = roundf(ah); break;
        case CRISP_FREP_SIN:
            if (!fin(al) || !fin(ah)) l = h = NAN;
            else sin_range(al, ah, 0, &l, &h);
            break;
        case CRISP_FREP_COS:
            if (!fin(al) || !fin(ah)) l = h = NAN;
            else sin_range(al, ah, (float)(PI_D / 2), &l, &h);
            break;
        case CRISP_FREP_TAN: {
            double k = ceil(((double)al - 1e-6 - PI_D / 2) / PI_D);
            if (!(ah - al < 3) || !fin(al) || !fin(ah) || PI_D / 2 + k * PI_D <= (double)ah + 1e-6) l = h = NAN;
            else l = wlo(tanf(al)), h = whi(tanf(ah));
            break;
        }
        case CRISP_FREP_ASIN:
            if (al >= -1 && ah <= 1) l = max2(wlo(asinf(al)), -1.5707965f), h = min2(whi(asinf(ah)), 1.5707965f);
            else l = h = NAN;
            break;
        case CRISP_FREP_ACOS:
            if (al >= -1 && ah <= 1) l = max2(wlo(acosf(ah)), 0), h = min2(whi(acosf(al)), 3.1415930f);
            else l = h = NAN;
            break;
        case CRISP_FREP_ATAN: l = wlo(atanf(al)), h = whi(atanf(ah)); break;
        case CRISP_FREP_EXP: l = max2(wlo(frep_expf(al)), 0), h = whi(frep_expf(ah)); break;
        case CRISP_FREP_LN:
            if (al >= 0) l = wlo(frep_logf(al)), h = whi(frep_logf(ah));
            else l = h = NAN;
            break;
        case CRISP_FREP_NOT:
            if (al == 0 && ah == 0) l = h = 1;
            else if (al > 0 || ah < 0) l = h = 0;
            else l = 0, h = 1;
            if (al != al) l = h = NAN;
            break;
        case CRISP_FREP_ADD:
        case FREP_T_ADD_RI:
            l = al + bl, h = ah + bh;
            if ((ah == INFINITY && bl == -INFINITY) || (al == -INFINITY && bh == INFINITY)) l = h = NAN;
            break;
        case CRISP_FREP_SUB:
        case FREP_T_SUB_RI:
            l = al - bh, h = ah - bl;
            if ((ah == INFINITY && bh == INFINITY) || (al == -INFINITY && bl == -INFINITY)) l = h = NAN;
            break;
        case FREP_T_SUB_IR:
            l = bl - ah, h = bh - al;
            if ((ah == INFINITY && bh == INFINITY) || (al == -INFINITY && bl == -INFINITY)) l = h = NAN;
            break;
        case CRISP_FREP_MUL:
        case FREP_T_MUL_RI: {
            float p0 = al * bl, p1 = al * bh, p2 = ah * bl, p3 = ah * bh;
            l = min2(min2(p0, p1), min2(p2, p3));
            h = max2(max2(p0, p1), max2(p2, p3));
            /* 0 * inf at some point of the box */
            if ((!fin(al) || !fin(ah)) && bl <= 0 && bh >= 0) l = h = NAN;
            if ((!fin(bl) || !fin(bh)) && al <= 0 && ah >= 0) l = h = NAN;
            if (p0 != p0 || p1 != p1 || p2 != p2 || p3 != p3) l = h = NAN;
            break;
        }
        case FREP_T_DIV_IR: {
            float t0 = al, t1 = ah; /* imm / a: swap roles */
            al = bl, ah = bh, bl = t0, bh = t1;
        }
            /* fall through */
        case CRISP_FREP_DIV:
        case FREP_T_DIV_RI:
            if (bl > 0 || bh < 0) {
                float q0 = al / bl, q1 = al / bh, q2 = ah / bl, q3 = ah / bh;
                l = min2(min2(q0, q1), min2(q2, q3));
                h = max2(max2(q0, q1), max2(q2, q3));
                if (al != al || ((!fin(al) || !fin(ah)) && (!fin(bl) || !fin(bh)))) l = h = NAN;
            } else {
                l = h = NAN;
            }
            break;
        case CRISP_FREP_ATAN2:
            if (al != al || bl != bl) {
                l = h = NAN;
            } else if (bl > 0 && fin(al) && fin(ah) && fin(bh)) {
                float c0 = atan2f(al, bl), c1 = atan2f(al, bh), c2 = atan2f(ah, bl),
                      c3 = atan2f(ah, bh);
                l = wlo(min2(min2(c0, c1), min2(c2, c3)));
                h = whi(max2(max2(c0, c1), max2(c2, c3)));
            } else {
                l = -3.1416f, h = 3.1416f;
            }
            break;
        case CRISP_FREP_MIN:
        case FREP_T_MIN_RI:
            l = min2(al, bl), h = min2(ah, bh);
            if (ah < bl) choice = FREP_CHOICE_A;
            else if (bh < al) choice = FREP_CHOICE_B;
            if (al != al || bl != bl) l = h = NAN, choice = FREP_CHOICE_BOTH;
            break;
        case CRISP_FREP_MAX:
        case FREP_T_MAX_RI:
            l = max2(al, bl), h = max2(ah, bh);
            if (al > bh) choice = FREP_CHOICE_A;
            else if (bl > ah) choice = FREP_CHOICE_B;
            if (al != al || bl != bl) l = h = NAN, choice = FREP_CHOICE_BOTH;
            break;
        case CRISP_FREP_COMPARE:
            if (ah < bl) l = h = -1;
            else if (al > bh) l = h = 1;
            else if (al == ah && bl == bh && al == bl) l = h = 0;
            else l = -1, h = 1;
            if (al != al || bl != bl) l = h = NAN;
            break;
        case CRISP_FREP_MOD:
            if ((bl > 0 || bh < 0) && fin(al) && fin(ah) && fin(bl) && fin(bh))
                l = 0, h = max2(fabsf(bl), fabsf(bh));
            else l = h = NAN;
            break;
        case CRISP_FREP_AND:
            if (al == 0 && ah == 0) l = h = 0;
            else if (al > 0 || ah < 0) l = bl, h = bh;
            else l = min2(bl, 0), h = max2(bh, 0);
            if (al != al || bl != bl) l = h = NAN;
            break;
        case CRISP_FREP_OR:
            if (al > 0 || ah < 0) l = al, h = ah;
            else if (al == 0 && ah == 0) l = bl, h = bh;
            else l = min2(al, bl), h = max2(ah, bh);
            if (al != al || bl != bl) l = h = NAN;
            break;
        default: l = h = NAN; break;
        }
        /* unknown when some point may be NaN */
        if (l != l || h != h) l = h = NAN;
        lo[in.out] = l;
        hi[in.out] = h;
        if (choices) {
            choices[i] = choice;
            decided += choice != FREP_CHOICE_BOTH;
        }
    }
    return decided;
}
