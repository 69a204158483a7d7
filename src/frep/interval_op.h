/* The interval semantics of one tape op (Moore interval arithmetic with the conventions of
 * eval_interval.c: an interval is lo <= hi, or "unknown" when both ends are NaN), shared by the
 * scalar interval evaluator and the batched one (eval_interval_lanes.c), so both give the same
 * bounds bit for bit. Private to the frep module. */
#ifndef CRISP_FREP_INTERVAL_OP_H
#define CRISP_FREP_INTERVAL_OP_H

#include <float.h>
#include <math.h>

#include "frep_internal.h"

#define FREP_PI_D 3.14159265358979323846

static inline float frep_wlo(float v)
{
    return isinf(v) ? v : v - fabsf(v) * 1e-6f - 1e-30f;
}
static inline float frep_whi(float v)
{
    return isinf(v) ? v : v + fabsf(v) * 1e-6f + 1e-30f;
}
static inline int frep_fin(float v)
{
    return v >= -FLT_MAX && v <= FLT_MAX;
}
static inline float frep_min2(float a, float b)
{
    return b < a ? b : a;
}
static inline float frep_max2(float a, float b)
{
    return b > a ? b : a;
}

/* sin (cosine = 0) or cos (1) over [a, b], enclosing what frep_sinf / frep_cosf give at every
 * float point of it: the polynomial at the ends widened by 1e-6 (twice its error of about 3e-7:
 * once for the ends, once for the points between), -1 or 1 where a minimum or maximum lies
 * inside, [-1, 1] beyond the polynomial's range. In units t = x / (pi/2), sin has its maxima at
 * t = 1 + 4m and minima at 3 + 4m, cos at 0 + 4m and 2 + 4m; t is widened by 1e-3, far more
 * than its rounding (|t| <= 5216), so an extremum in_range an end is counted, never missed.
 * Straight-line selects only, so the batched interval evaluator vectorises it. */
static inline void frep_trig_range(float a, float b, int cosine, float *rl, float *rh)
{
    float ta = a * 0.636619772f - 1e-3f, tb = b * 0.636619772f + 1e-3f;
    float off = cosine ? 0.0f : 1.0f;
    float mmax = ceilf((ta - off) * 0.25f), mmin = ceilf((ta - off - 2.0f) * 0.25f);
    float sa = frep_sincos_poly(a, cosine), sb = frep_sincos_poly(b, cosine);
    float l = frep_min2(sa, sb) - 1e-6f, h = frep_max2(sa, sb) + 1e-6f;
    l = off + 2.0f + 4.0f * mmin <= tb ? -1.0f : l;
    h = off + 4.0f * mmax <= tb ? 1.0f : h;
    int in_range = fabsf(a) <= FREP_TRIG_MAX && fabsf(b) <= FREP_TRIG_MAX;
    l = in_range && l > -1.0f ? l : -1.0f;
    h = in_range && h < 1.0f ? h : 1.0f;
    *rl = l;
    *rh = h;
}

/* Interval of op over a = [al, ah], b = [bl, bh] (the immediate for register-immediate ops) and
 * the box x, y, z, into *lo, *hi; returns the min/max choice (FREP_CHOICE_*). */
static inline int frep_interval_op(int op, float imm, float al, float ah, float bl, float bh,
                                   const float x[2], const float y[2], const float z[2], float *lo,
                                   float *hi)
{
    float l, h;
    int choice = FREP_CHOICE_BOTH;
    if (op >= FREP_T_ADD_RI) bl = bh = imm;
    switch (op) {
    case CRISP_FREP_CONST:
        l = h = imm;
        break;
    case CRISP_FREP_X:
        l = x[0], h = x[1];
        break;
    case CRISP_FREP_Y:
        l = y[0], h = y[1];
        break;
    case CRISP_FREP_Z:
        l = z[0], h = z[1];
        break;
    case FREP_T_COPY:
        l = al, h = ah;
        break;
    case CRISP_FREP_NEG:
        l = -ah, h = -al;
        break;
    case CRISP_FREP_ABS:
        if (al >= 0)
            l = al, h = ah;
        else if (ah <= 0)
            l = -ah, h = -al;
        else
            l = 0, h = frep_max2(-al, ah);
        if (al != al) l = h = NAN;
        break;
    case CRISP_FREP_SQUARE:
        if (al >= 0)
            l = al * al, h = ah * ah;
        else if (ah <= 0)
            l = ah * ah, h = al * al;
        else
            l = 0, h = frep_max2(al * al, ah * ah);
        if (al != al) l = h = NAN;
        break;
    case CRISP_FREP_SQRT:
        if (al >= 0)
            l = sqrtf(al), h = sqrtf(ah);
        else
            l = h = NAN;
        break;
    case CRISP_FREP_FLOOR:
        l = floorf(al), h = floorf(ah);
        break;
    case CRISP_FREP_CEIL:
        l = ceilf(al), h = ceilf(ah);
        break;
    case CRISP_FREP_ROUND:
        l = roundf(al), h = roundf(ah);
        break;
    case CRISP_FREP_SIN:
        if (!frep_fin(al) || !frep_fin(ah))
            l = h = NAN;
        else
            frep_trig_range(al, ah, 0, &l, &h);
        break;
    case CRISP_FREP_COS:
        if (!frep_fin(al) || !frep_fin(ah))
            l = h = NAN;
        else
            frep_trig_range(al, ah, 1, &l, &h);
        break;
    case CRISP_FREP_TAN: {
        double k = ceil(((double)al - 1e-6 - FREP_PI_D / 2) / FREP_PI_D);
        if (!(ah - al < 3) || !frep_fin(al) || !frep_fin(ah) ||
            FREP_PI_D / 2 + k * FREP_PI_D <= (double)ah + 1e-6)
            l = h = NAN;
        else
            l = frep_wlo(tanf(al)), h = frep_whi(tanf(ah));
        break;
    }
    case CRISP_FREP_ASIN:
        if (al >= -1 && ah <= 1)
            l = frep_max2(frep_wlo(asinf(al)), -1.5707965f),
            h = frep_min2(frep_whi(asinf(ah)), 1.5707965f);
        else
            l = h = NAN;
        break;
    case CRISP_FREP_ACOS:
        if (al >= -1 && ah <= 1)
            l = frep_max2(frep_wlo(acosf(ah)), 0), h = frep_min2(frep_whi(acosf(al)), 3.1415930f);
        else
            l = h = NAN;
        break;
    case CRISP_FREP_ATAN:
        l = frep_wlo(atanf(al)), h = frep_whi(atanf(ah));
        break;
    case CRISP_FREP_EXP:
        l = frep_max2(frep_wlo(frep_expf(al)), 0), h = frep_whi(frep_expf(ah));
        break;
    case CRISP_FREP_LN:
        if (al >= 0)
            l = frep_wlo(frep_logf(al)), h = frep_whi(frep_logf(ah));
        else
            l = h = NAN;
        break;
    case CRISP_FREP_NOT:
        if (al == 0 && ah == 0)
            l = h = 1;
        else if (al > 0 || ah < 0)
            l = h = 0;
        else
            l = 0, h = 1;
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
        l = frep_min2(frep_min2(p0, p1), frep_min2(p2, p3));
        h = frep_max2(frep_max2(p0, p1), frep_max2(p2, p3));
        /* 0 * inf at some point of the box */
        if ((!frep_fin(al) || !frep_fin(ah)) && bl <= 0 && bh >= 0) l = h = NAN;
        if ((!frep_fin(bl) || !frep_fin(bh)) && al <= 0 && ah >= 0) l = h = NAN;
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
            l = frep_min2(frep_min2(q0, q1), frep_min2(q2, q3));
            h = frep_max2(frep_max2(q0, q1), frep_max2(q2, q3));
            if (al != al || ((!frep_fin(al) || !frep_fin(ah)) && (!frep_fin(bl) || !frep_fin(bh))))
                l = h = NAN;
        } else {
            l = h = NAN;
        }
        break;
    case CRISP_FREP_ATAN2:
        if (al != al || bl != bl) {
            l = h = NAN;
        } else if (bl > 0 && frep_fin(al) && frep_fin(ah) && frep_fin(bh)) {
            float c0 = atan2f(al, bl), c1 = atan2f(al, bh), c2 = atan2f(ah, bl),
                  c3 = atan2f(ah, bh);
            l = frep_wlo(frep_min2(frep_min2(c0, c1), frep_min2(c2, c3)));
            h = frep_whi(frep_max2(frep_max2(c0, c1), frep_max2(c2, c3)));
        } else {
            l = -3.1416f, h = 3.1416f;
        }
        break;
    case CRISP_FREP_MIN:
    case FREP_T_MIN_RI:
        l = frep_min2(al, bl), h = frep_min2(ah, bh);
        if (ah < bl)
            choice = FREP_CHOICE_A;
        else if (bh < al)
            choice = FREP_CHOICE_B;
        if (al != al || bl != bl) l = h = NAN, choice = FREP_CHOICE_BOTH;
        break;
    case CRISP_FREP_MAX:
    case FREP_T_MAX_RI:
        l = frep_max2(al, bl), h = frep_max2(ah, bh);
        if (al > bh)
            choice = FREP_CHOICE_A;
        else if (bl > ah)
            choice = FREP_CHOICE_B;
        if (al != al || bl != bl) l = h = NAN, choice = FREP_CHOICE_BOTH;
        break;
    case CRISP_FREP_COMPARE:
        if (ah < bl)
            l = h = -1;
        else if (al > bh)
            l = h = 1;
        else if (al == ah && bl == bh && al == bl)
            l = h = 0;
        else
            l = -1, h = 1;
        if (al != al || bl != bl) l = h = NAN;
        break;
    case CRISP_FREP_MOD:
        if ((bl > 0 || bh < 0) && frep_fin(al) && frep_fin(ah) && frep_fin(bl) && frep_fin(bh))
            l = 0, h = frep_max2(fabsf(bl), fabsf(bh));
        else
            l = h = NAN;
        break;
    case CRISP_FREP_AND:
        if (al == 0 && ah == 0)
            l = h = 0;
        else if (al > 0 || ah < 0)
            l = bl, h = bh;
        else
            l = frep_min2(bl, 0), h = frep_max2(bh, 0);
        if (al != al || bl != bl) l = h = NAN;
        break;
    case CRISP_FREP_OR:
        if (al > 0 || ah < 0)
            l = al, h = ah;
        else if (al == 0 && ah == 0)
            l = bl, h = bh;
        else
            l = frep_min2(al, bl), h = frep_max2(ah, bh);
        if (al != al || bl != bl) l = h = NAN;
        break;
    default:
        l = h = NAN;
        break;
    }
    /* unknown when some point may be NaN */
    if (l != l || h != h) l = h = NAN;
    *lo = l;
    *hi = h;
    return choice;
}

#endif
