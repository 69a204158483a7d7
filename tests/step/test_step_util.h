/* Shared checks for the STEP reader tests: every loop of a face is closed, inside the surface's
 * domain and oriented (outer counter-clockwise, holes clockwise). */
#ifndef TEST_STEP_UTIL_H
#define TEST_STEP_UTIL_H

#include <math.h>

#include "crisp/io.h"

typedef struct loop_check {
    int loops, outer, holes, curves;
    int open_loops, outside_loops, misoriented_loops;
    double max_gap_rel, max_excess_rel;
} loop_check;

/* closure_rel and domain_rel: fractions of each face's domain size. */
static inline void check_model_loops(const crisp_model *m, double closure_rel, double domain_rel,
                                     loop_check *c)
{
    *c = (loop_check){0};
    for (int f = 0; f < m->face_count; f++) {
        const crisp_face *face = &m->faces[f];
        double d[4];
        crisp_surface_domain(face->surface, d);
        double size = fmax(d[1] - d[0], d[3] - d[2]);
        for (int l = 0; l < face->loop_count; l++) {
            const crisp_trim_loop *lp = &face->loops[l];
            c->loops++;
            c->curves += lp->curve_count;
            if (lp->is_outer)
                c->outer++;
            else
                c->holes++;
            double gap = crisp_trim_loop_closure_gap(lp) / size;
            double ex = crisp_trim_loop_domain_excess(lp, d) / size;
            double area = crisp_trim_loop_signed_area(lp);
            if (gap > c->max_gap_rel) c->max_gap_rel = gap;
            if (ex > c->max_excess_rel) c->max_excess_rel = ex;
            if (gap > closure_rel) c->open_loops++;
            if (ex > domain_rel) c->outside_loops++;
            if (lp->is_outer ? !(area > 0) : !(area < 0)) c->misoriented_loops++;
        }
    }
}

#endif
