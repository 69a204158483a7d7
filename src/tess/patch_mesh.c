/* The triangle mesh of one quad patch for given inner and edge levels (the CPU counterpart of
 * the GL quad tessellator with equal spacing): a regular inner grid, and a ring between it and
 * the boundary edges stitched side by side ("zipper"), so each edge can have its own level.
 * Inner levels of 1 are raised to 2 when an edge is finer, so the ring always has an inner
 * point or segment to stitch to. */
#include "crisp/tess.h"

static int level_ok(int l, int max)
{
    return l >= 1 && l <= max;
}

/* Inner levels actually used: 1 x 1 only when every edge is 1, else each at least 2. */
static void effective_inner(const crisp_tess_levels *lv, int *nu, int *nv)
{
    int all1 = lv->inner[0] == 1 && lv->inner[1] == 1;
    for (int k = 0; k < 4; k++)
        all1 &= lv->outer[k] == 1;
    *nu = lv->inner[0];
    *nv = lv->inner[1];
    if (!all1) {
        if (*nu < 2) *nu = 2;
        if (*nv < 2) *nv = 2;
    }
}

crisp_status crisp_tess_mesh_counts(const crisp_tess_levels *lv, size_t *verts, size_t *tris)
{
    for (int k = 0; k < 2; k++)
        if (!level_ok(lv->inner[k], CRISP_TESS_MAX_LEVEL))
            return crisp_error(CRISP_ERR_INVALID_ARG, "inner tess level %d: expected 1..%d",
                               lv->inner[k], CRISP_TESS_MAX_LEVEL);
    for (int k = 0; k < 4; k++)
        if (!level_ok(lv->outer[k], CRISP_TESS_MAX_EDGE_LEVEL))
            return crisp_error(CRISP_ERR_INVALID_ARG, "edge %d tess level %d: expected 1..%d", k,
                               lv->outer[k], CRISP_TESS_MAX_EDGE_LEVEL);
    int nu, nv;
    effective_inner(lv, &nu, &nv);
    size_t e = (size_t)lv->outer[0] + lv->outer[1] + lv->outer[2] + lv->outer[3];
    if (nu == 1 && nv == 1) {
        *verts = 4;
        *tris = 2;
        return CRISP_OK;
    }
    size_t iu = (size_t)nu - 1, iv = (size_t)nv - 1;
    *verts = e + iu * iv;
    /* Ring: each side's zipper makes (outer segments + inner segments) triangles; the inner
     * rectangle has 2 (iu - 1) + 2 (iv - 1) boundary segments. Grid: 2 (iu - 1)(iv - 1). */
    *tris = e + 2 * (iu - 1) + 2 * (iv - 1) + 2 * (iu - 1) * (iv - 1);
    return CRISP_OK;
}

/* Stitch the outer polyline (boundary vertices start .. start + n, wrapping at nb, at positions
 * k / n along the side) to an inner polyline in[0..m] at positions ipos (both walking the same
 * way along the side). */
static uint32_t *zipper(uint32_t start, uint32_t nb, int n, const uint32_t *in, const double *ipos,
                        int m, uint32_t base, uint32_t *t)
{
    int i = 0, j = 0;
    while (i < n || j < m) {
        int take_outer;
        if (j == m)
            take_outer = 1;
        else if (i == n)
            take_outer = 0;
        else
            take_outer = (double)(2 * i + 1) / n <= ipos[j] + ipos[j + 1];
        uint32_t oi = base + (start + (uint32_t)i) % nb;
        if (take_outer) {
            *t++ = oi;
            *t++ = base + (start + (uint32_t)i + 1) % nb;
            *t++ = base + in[j];
            i++;
        } else {
            *t++ = oi;
            *t++ = base + in[j + 1];
            *t++ = base + in[j];
            j++;
        }
    }
    return t;
}

void crisp_tess_mesh_generate(const crisp_tess_levels *lv, double *st, uint32_t *tris,
                              uint32_t base)
{
    int nu, nv;
    effective_inner(lv, &nu, &nv);
    if (nu == 1 && nv == 1) {
        static const double c[8] = {0, 0, 1, 0, 1, 1, 0, 1};
        for (int k = 0; k < 8; k++)
            st[k] = c[k];
        static const uint32_t t[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++)
            tris[k] = base + t[k];
        return;
    }
    const int *e = lv->outer;
    /* Boundary, counter-clockwise from (0, 0); every coordinate is an integer quotient. */
    uint32_t nb = 0;
    for (int k = 0; k < e[0]; k++, nb++)
        st[2 * nb] = (double)k / e[0], st[2 * nb + 1] = 0;
    for (int k = 0; k < e[1]; k++, nb++)
        st[2 * nb] = 1, st[2 * nb + 1] = (double)k / e[1];
    for (int k = 0; k < e[2]; k++, nb++)
        st[2 * nb] = (double)(e[2] - k) / e[2], st[2 * nb + 1] = 1;
    for (int k = 0; k < e[3]; k++, nb++)
        st[2 * nb] = 0, st[2 * nb + 1] = (double)(e[3] - k) / e[3];
    /* Inner grid (nu - 1) x (nv - 1): vertex (i, j), 1 <= i < nu, 1 <= j < nv. */
    int iu = nu - 1;
    for (int j = 1; j < nv; j++)
        for (int i = 1; i < nu; i++) {
            uint32_t idx = nb + (uint32_t)((j - 1) * iu + (i - 1));
            st[2 * idx] = (double)i / nu;
            st[2 * idx + 1] = (double)j / nv;
        }
#define INNER(i, j) (nb + (uint32_t)(((j)-1) * iu + ((i)-1)))
    uint32_t *t = tris;
    uint32_t in[CRISP_TESS_MAX_LEVEL + 1];
    double ipos[CRISP_TESS_MAX_LEVEL + 1];
    uint32_t start = 0;
    for (int side = 0; side < 4; side++) {
        int n = e[side];
        int m = 0;
        /* The inner rectangle's side, walked the same way, with positions along the side. */
        if (side == 0)
            for (int i = 1; i < nu; i++, m++)
                in[m] = INNER(i, 1), ipos[m] = (double)i / nu;
        else if (side == 1)
            for (int j = 1; j < nv; j++, m++)
                in[m] = INNER(nu - 1, j), ipos[m] = (double)j / nv;
        else if (side == 2)
            for (int i = nu - 1; i >= 1; i--, m++)
                in[m] = INNER(i, nv - 1), ipos[m] = (double)(nu - i) / nu;
        else
            for (int j = nv - 1; j >= 1; j--, m++)
                in[m] = INNER(1, j), ipos[m] = (double)(nv - j) / nv;
        t = zipper(start, nb, n, in, ipos, m - 1, base, t);
        start += (uint32_t)n;
    }
    for (int j = 1; j < nv - 1; j++)
        for (int i = 1; i < nu - 1; i++) {
            uint32_t a = INNER(i, j), b = INNER(i + 1, j), c = INNER(i, j + 1),
                     d = INNER(i + 1, j + 1);
            *t++ = base + a, *t++ = base + b, *t++ = base + d;
            *t++ = base + a, *t++ = base + d, *t++ = base + c;
        }
#undef INNER
}
