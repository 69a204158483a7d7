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
#include "interval_op.h"

size_t crisp__frep_interval(const frep_ins *ins, size_t n, float *lo, float *hi, const float x[2],
                            const float y[2], const float z[2], uint8_t *choices)
{
    size_t decided = 0;
    for (size_t i = 0; i < n; i++) {
        const frep_ins in = ins[i];
        float l, h;
        int choice = frep_interval_op(in.op, in.imm, lo[in.a], hi[in.a], lo[in.b], hi[in.b], x, y,
                                      z, &l, &h);
        lo[in.out] = l;
        hi[in.out] = h;
        if (choices) {
            choices[i] = (uint8_t)choice;
            decided += choice != FREP_CHOICE_BOTH;
        }
    }
    return decided;
}
