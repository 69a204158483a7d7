/* Tests for the patch mesh: it tiles the unit square exactly (positive areas summing to 1,
 * every inner edge shared by two triangles, boundary edges by one), each edge has the requested
 * vertices k / e, and neighbours that share an edge produce bit-identical parameters. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/tess.h"

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static void check_mesh(const crisp_tess_levels *lv)
{
    size_t nv, nt;
    assert_int_equal(crisp_tess_mesh_counts(lv, &nv, &nt), CRISP_OK);
    double *st = malloc(nv * 2 * sizeof *st);
    uint32_t *tri = malloc(nt * 3 * sizeof *tri);
    crisp_tess_mesh_generate(lv, st, tri, 5);
    double area = 0;
    uint64_t *edges = malloc(nt * 3 * sizeof *edges);
    for (size_t k = 0; k < nt; k++) {
        uint32_t a = tri[3 * k] - 5, b = tri[3 * k + 1] - 5, c = tri[3 * k + 2] - 5;
        assert_true(a < nv && b < nv && c < nv);
        double ar = 0.5 * ((st[2 * b] - st[2 * a]) * (st[2 * c + 1] - st[2 * a + 1]) -
                           (st[2 * b + 1] - st[2 * a + 1]) * (st[2 * c] - st[2 * a]));
        assert_true(ar > 0);
        area += ar;
        uint32_t v[3] = {a, b, c};
        for (int q = 0; q < 3; q++) {
            uint32_t x = v[q], y = v[(q + 1) % 3];
            edges[3 * k + q] = x < y ? ((uint64_t)x << 32 | y) : ((uint64_t)y << 32 | x);
        }
    }
    assert_true(fabs(area - 1) < 1e-12);
    /* Each undirected edge appears once (boundary) or twice (inner). */
    qsort(edges, nt * 3, sizeof *edges, cmp_u64);
    size_t boundary = 0;
    for (size_t k = 0; k < nt * 3;) {
        size_t r = k;
        while (r < nt * 3 && edges[r] == edges[k])
            r++;
        assert_true(r - k <= 2);
        if (r - k == 1) {
            boundary++;
            uint32_t x = (uint32_t)(edges[k] >> 32), y = (uint32_t)edges[k];
            /* A boundary edge lies on the square's boundary. */
            int on = 0;
            for (int c = 0; c < 2; c++)
                for (double b = 0; b <= 1; b += 1)
                    on |= st[2 * x + c] == b && st[2 * y + c] == b;
            assert_true(on);
        }
        k = r;
    }
    int e = lv->outer[0] + lv->outer[1] + lv->outer[2] + lv->outer[3];
    assert_int_equal(boundary, (size_t)e);
    /* Vertices on the edge t = 0 are exactly k / outer[0]. */
    int found = 0;
    for (size_t k = 0; k < nv; k++)
        if (st[2 * k + 1] == 0) {
            double x = st[2 * k] * lv->outer[0];
            assert_true(fabs(x - round(x)) < 1e-12);
            found++;
        }
    assert_int_equal(found, lv->outer[0] + 1);
    free(st);
    free(tri);
    free(edges);
}

static void test_meshes(void **state)
{
    (void)state;
    srand(7);
    crisp_tess_levels one = {{1, 1}, {1, 1, 1, 1}};
    check_mesh(&one);
    crisp_tess_levels a = {{1, 1}, {3, 1, 1, 1}};
    check_mesh(&a);
    crisp_tess_levels b = {{64, 64}, {64, 64, 64, 64}};
    check_mesh(&b);
    /* Edges much finer than the inside (a coarse patch beside split neighbours). */
    crisp_tess_levels c = {{3, 64}, {4096, 1, 640, 16384}};
    check_mesh(&c);
    for (int k = 0; k < 300; k++) {
        crisp_tess_levels r;
        for (int q = 0; q < 2; q++)
            r.inner[q] = 1 + rand() % (k < 150 ? 6 : 64);
        for (int q = 0; q < 4; q++)
            r.outer[q] = 1 + rand() % (k < 150 ? 6 : 64);
        check_mesh(&r);
    }
}

static void test_shared_edge_bits(void **state)
{
    (void)state;
    /* Patch A's edge s = 1 and patch B's edge s = 0 with the same level: same t values. */
    crisp_tess_levels A = {{5, 7}, {3, 11, 4, 2}}, B = {{9, 2}, {6, 1, 8, 11}};
    size_t na, nb, ta, tb;
    crisp_tess_mesh_counts(&A, &na, &ta);
    crisp_tess_mesh_counts(&B, &nb, &tb);
    double *sa = malloc(na * 2 * sizeof *sa), *sb = malloc(nb * 2 * sizeof *sb);
    uint32_t *xa = malloc(ta * 3 * sizeof *xa), *xb = malloc(tb * 3 * sizeof *xb);
    crisp_tess_mesh_generate(&A, sa, xa, 0);
    crisp_tess_mesh_generate(&B, sb, xb, 0);
    int matched = 0;
    for (size_t i = 0; i < na; i++) {
        if (sa[2 * i] != 1) continue;
        int ok = 0;
        for (size_t j = 0; j < nb; j++)
            ok |= sb[2 * j] == 0 && sb[2 * j + 1] == sa[2 * i + 1];
        assert_true(ok);
        matched++;
    }
    assert_int_equal(matched, 12);
    free(sa);
    free(sb);
    free(xa);
    free(xb);
}

static void test_bad_levels(void **state)
{
    (void)state;
    size_t v, t;
    crisp_tess_levels z = {{0, 1}, {1, 1, 1, 1}},
                      big = {{1, 1}, {1, CRISP_TESS_MAX_EDGE_LEVEL + 1, 1, 1}},
                      inner = {{65, 1}, {1, 1, 1, 1}};
    assert_int_equal(crisp_tess_mesh_counts(&z, &v, &t), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_tess_mesh_counts(&big, &v, &t), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_tess_mesh_counts(&inner, &v, &t), CRISP_ERR_INVALID_ARG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_meshes),
        cmocka_unit_test(test_shared_edge_bits),
        cmocka_unit_test(test_bad_levels),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
