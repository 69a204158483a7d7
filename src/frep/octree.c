/* The interval octree shared by the region fit, the mesher and the mass properties: depth-first
 * subdivision of a box with one interval per cell and the tape shortened per cell (Keeter 2012's
 * recursive subdivision with branch caching; Fidget's SSA tape shortening). Cells proven inside
 * or outside are reported whole and never split; undecided cells are split down to max_depth
 * and reported as leaves with their shortened tape. Memory: one tape buffer per level. */
#include "frep_octree.h"

#include <stdlib.h>
#include <string.h>

void crisp__frep_octree_free(frep_octree *o)
{
    crisp_free(o->lo);
    crisp_free(o->choices);
    crisp_free(o->tapes);
    crisp_free(o->ssas);
    crisp__frep_scratch_free(&o->sc);
    memset(o, 0, sizeof *o);
}

crisp_status crisp__frep_octree_init(frep_octree *o, const crisp_frep_tape *t, int max_depth)
{
    memset(o, 0, sizeof *o);
    if (max_depth < 0 || max_depth > FREP_OCTREE_MAX_DEPTH)
        return crisp_error(CRISP_ERR_LIMIT, "frep octree: depth %d is outside 0..%d", max_depth,
                           FREP_OCTREE_MAX_DEPTH);
    o->t = t;
    o->max_depth = max_depth;
    size_t len = t->length, nr = (size_t)t->registers;
    o->lo = crisp_malloc_array(nr * 2, sizeof *o->lo);
    o->choices = crisp_malloc_array(len, 1);
    o->tapes = crisp_malloc_array(len * (size_t)(max_depth + 1), sizeof *o->tapes);
    o->ssas = crisp_malloc_array(len * 2 * (size_t)(max_depth + 1), sizeof *o->ssas);
    crisp_status s = crisp__frep_scratch_init(&o->sc, len, t->registers);
    if (!s && (!o->lo || !o->choices || !o->tapes || !o->ssas))
        s = crisp_error(CRISP_ERR_NO_MEMORY, "frep octree: out of memory for a tape of %zu", len);
    if (s) {
        crisp__frep_octree_free(o);
        return s;
    }
    o->hi = o->lo + nr;
    return CRISP_OK;
}

int crisp__frep_octree_classify(frep_octree *o, frep_span t, const float b[6], size_t *decided)
{
    const float x[2] = {b[0], b[1]}, y[2] = {b[2], b[3]}, z[2] = {b[4], b[5]};
    size_t d = crisp__frep_interval(t.ins, t.len, o->lo, o->hi, x, y, z, o->choices);
    if (decided) *decided = d;
    o->intervals++;
    uint16_t res = t.ins[t.len - 1].out;
    float l = o->lo[res], h = o->hi[res];
    if (l != l) return FREP_CELL_UNKNOWN;
    return l >= 0 ? FREP_CELL_OUT : h < 0 ? FREP_CELL_IN : FREP_CELL_AMBIGUOUS;
}

static int walk(frep_octree *o, frep_span t, const float b[6], int depth)
{
    if (o->intervals >= o->max_intervals && o->max_intervals) {
        o->truncated = 1;
        return o->visit(o->ctx, b, depth, FREP_CELL_UNKNOWN, t);
    }
    size_t d;
    int cls = crisp__frep_octree_classify(o, t, b, &d);
    if (cls == FREP_CELL_OUT || cls == FREP_CELL_IN || depth >= o->max_depth)
        return o->visit(o->ctx, b, depth, cls, t);
    frep_span ct = t;
    if (d) {
        frep_span out;
        size_t len = o->t->length;
        if (!crisp__frep_shorten(t, o->choices, &o->sc, o->tapes + (size_t)depth * len,
                                 o->ssas + 2 * (size_t)depth * len, &out))
            ct = out;
    }
    float m[3];
    for (int a = 0; a < 3; a++)
        m[a] = 0.5f * (b[2 * a] + b[2 * a + 1]);
    int axes = o->planar ? 2 : 3;
    for (int q = 0; q < (1 << axes); q++) {
        float c[6];
        for (int a = 0; a < 3; a++) {
            int split = a < axes, upper = split && ((q >> a) & 1);
            c[2 * a] = split && upper ? m[a] : b[2 * a];
            c[2 * a + 1] = split && !upper ? m[a] : b[2 * a + 1];
        }
        int rc = walk(o, ct, c, depth + 1);
        if (rc) return rc;
    }
    return 0;
}

int crisp__frep_octree_walk(frep_octree *o, const float box[6])
{
    o->truncated = 0;
    const crisp_frep_tape *t = o->t;
    return walk(o, (frep_span){t->ins, t->ssa, t->length, t->registers}, box, 0);
}
