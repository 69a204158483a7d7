/* crisp render --tile and crisp merge (issue 15), through the command line: tiles merged equal
 * the single run bit for bit (PNG RGBA, and the EXR's every channel) for a bundled model and the
 * scene with f-rep parts; a missing tile, a truncated or changed tile, a tile of another job or of
 * other settings, a tile given twice are refused with a message naming the cell. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>
#include <sys/stat.h>

#include <cmocka.h>

#include "jobs/image_util.h"
#include "mesh/mesh_check.h"

#define CRISP CRISP_BIN_DIR "/crisp"

static char dir[1024];

static void make_dir(const char *name)
{
    assert_true(snprintf(dir, sizeof dir, "%s/test_merge_%s", CRISP_BIN_DIR, name) <
                (int)sizeof dir);
    char cmd[2200];
    assert_true(snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", dir, dir) <
                (int)sizeof cmd);
    assert_int_equal(system(cmd), 0);
}

static void tiles_equal_whole(const char *model, const char *size, int n)
{
    assert_int_equal(
        test_run(dir, "%s render %s --size %s -o full.png --aov full.exr -q", CRISP, model, size),
        0);
    for (int i = 0; i < n; i++)
        assert_int_equal(test_run(dir,
                                  "%s render %s --size %s --tile %d/%d -o t%02d.png --aov "
                                  "t%02d.exr -q --threads %d",
                                  CRISP, model, size, i, n, i, i, 1 + i % 2),
                         0);
    assert_int_equal(
        test_run(dir, "%s merge -o m.png t*.png && %s merge -o m.exr t*.exr", CRISP, CRISP), 0);
    char a[4200], b[4200];
    snprintf(a, sizeof a, "%s/full.png", dir), snprintf(b, sizeof b, "%s/m.png", dir);
    assert_true(test_same_image(a, b));
    snprintf(a, sizeof a, "%s/full.exr", dir), snprintf(b, sizeof b, "%s/m.exr", dir);
    assert_true(test_same_image(a, b));
}

static void test_model(void **state)
{
    (void)state;
    make_dir("model");
    tiles_equal_whole(CRISP_DATA_DIR "/nurbs/occt_bearing.iges", "333x250", 6);
}

static void test_scene(void **state)
{
    (void)state;
    make_dir("scene");
    tiles_equal_whole(CRISP_DATA_DIR "/scenes/teapot_frep.scene", "300x200", 4);
}

/* crisp frep render --tile: 2D (prospero) and a 3D heightmap (bear), PNG and the EXR of depth
 * and normals. */
static void test_frep(void **state)
{
    (void)state;
    make_dir("frep");
    const char *p = CRISP_DATA_DIR "/frep/prospero.vm", *b = CRISP_DATA_DIR "/frep/bear.vm";
    assert_int_equal(
        test_run(dir, "%s frep render %s --size 600x450 -o p.png --depth-out p.exr", CRISP, p), 0);
    assert_int_equal(test_run(dir,
                              "%s frep render %s --3d --size 300x260 -o b.png --depth-out "
                              "b.exr",
                              CRISP, b),
                     0);
    for (int i = 0; i < 8; i++)
        assert_int_equal(test_run(dir,
                                  "%s frep render %s --size 600x450 --tile %d/8 -o p%d.png "
                                  "--depth-out p%d.exr --threads %d",
                                  CRISP, p, i, i, i, 1 + i % 2),
                         0);
    for (int i = 0; i < 4; i++)
        assert_int_equal(test_run(dir,
                                  "%s frep render %s --3d --size 300x260 --tile %d/4 -o "
                                  "b%d.png --depth-out b%d.exr",
                                  CRISP, b, i, i, i),
                         0);
    assert_int_equal(test_run(dir,
                              "%s merge -o pm.png p?.png && %s merge -o pm.exr p?.exr && %s "
                              "merge -o bm.png b?.png && %s merge -o bm.exr b?.exr",
                              CRISP, CRISP, CRISP, CRISP),
                     0);
    const char *pairs[4][2] = {
        {"p.png", "pm.png"}, {"p.exr", "pm.exr"}, {"b.png", "bm.png"}, {"b.exr", "bm.exr"}};
    for (int k = 0; k < 4; k++) {
        char a[2100], m[2100];
        snprintf(a, sizeof a, "%s/%s", dir, pairs[k][0]);
        snprintf(m, sizeof m, "%s/%s", dir, pairs[k][1]);
        assert_true(test_same_image(a, m));
    }
}

static void expect_refused(const char *cmd, const char *needle)
{
    int rc = test_run(dir, "%s", cmd);
    const char *out = test_output(dir);
    if (rc != 1 || !strstr(out, needle))
        fprintf(stderr, "'%s': exit %d, expected 1 and '%s' in:\n%s\n", cmd, rc, needle, out);
    assert_int_equal(rc, 1);
    assert_non_null(strstr(out, needle));
    struct stat sb;
    char path[4200];
    snprintf(path, sizeof path, "%s/bad.png", dir);
    assert_int_not_equal(stat(path, &sb), 0); /* nothing written */
}

static void test_bad_cells(void **state)
{
    (void)state;
    make_dir("bad");
    const char *m = CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs";
    for (int i = 0; i < 4; i++)
        assert_int_equal(
            test_run(dir, "%s render %s --size 200x150 --samples 1 --tile %d/4 -o t%d.png -q",
                     CRISP, m, i, i),
            0);
    /* another job (another model) and other settings (another size, another grid) */
    assert_int_equal(test_run(dir,
                              "%s render %s --size 200x150 --samples 1 --tile 1/4 -o other.png "
                              "-q && %s render %s --size 200x150 --samples 4 --tile 1/4 -o "
                              "samples.png -q && %s render %s --size 200x150 --samples 1 --tile "
                              "1/4x1 -o grid.png -q",
                              CRISP, CRISP_DATA_DIR "/nurbs/occt_bearing.iges", CRISP, m, CRISP, m),
                     0);
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png t0.png t1.png t3.png", CRISP);
    expect_refused(cmd, "incomplete set: 1 of the 4 tiles");
    expect_refused(cmd, "cell 2");
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png t0.png t1.png t1.png t3.png", CRISP);
    expect_refused(cmd, "cell 1 is given twice");
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png t0.png other.png t2.png t3.png", CRISP);
    expect_refused(cmd, "cell 1 has other settings");
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png t0.png samples.png t2.png t3.png", CRISP);
    expect_refused(cmd, "samples=4");
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png t0.png grid.png t2.png t3.png", CRISP);
    expect_refused(cmd, "grid=4x1");
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png t0.png t1.png t2.png nothere.png", CRISP);
    expect_refused(cmd, "nothere.png: no readable cell header");
    /* a tile whose header is gone (the run was killed before it finished) */
    assert_int_equal(test_run(dir, "cp t2.png t9.png"), 0);
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png t0.png t1.png t9.png t3.png", CRISP);
    expect_refused(cmd, "t9.png: no readable cell header");
    /* the same job with an edited input file: another job */
    assert_int_equal(test_run(dir,
                              "cp '%s' copy.igs && %s render copy.igs --size 200x150 "
                              "--samples 1 --tile 2/4 -o c2.png -q && echo >> copy.igs && %s "
                              "render copy.igs --size 200x150 --samples 1 --tile 3/4 -o "
                              "c3.png -q && cp t0.png.cell t0.png c0.png.cell 2>/dev/null; "
                              "true",
                              m, CRISP, CRISP),
                     0);
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png c2.png c3.png", CRISP);
    expect_refused(cmd, "belongs to another job");
    /* a truncated tile, and a tile changed after it was written */
    assert_int_equal(test_run(dir, "cp t1.png t1.bak && head -c 300 t1.bak > t1.png"), 0);
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png t0.png t1.png t2.png t3.png", CRISP);
    expect_refused(cmd, "cell 1: ");
    expect_refused(cmd, "is corrupt");
    assert_int_equal(test_run(dir, "cp t1.bak t1.png && printf 'x' | dd of=t1.png bs=1 seek=100 "
                                   "conv=notrunc 2>/dev/null"),
                     0);
    expect_refused(cmd, "is corrupt");
    /* restored: the same set merges */
    assert_int_equal(test_run(dir,
                              "cp t1.bak t1.png && %s merge -o good.png t0.png t1.png "
                              "t2.png t3.png",
                              CRISP),
                     0);
    /* a tile's header edited to another tile's place */
    assert_int_equal(test_run(dir, "sed -i 's/^cell 3 /cell 2 /' t3.png.cell"), 0);
    snprintf(cmd, sizeof cmd, "%s merge -o bad.png t0.png t1.png t2.png t3.png", CRISP);
    expect_refused(cmd, "cell 2 is given twice");
}

/* The numbers after `key` on its line of dir/file. */
static int read_numbers(const char *file, const char *key, const char *fmt, double *a, double *b,
                        double *c, double *d)
{
    char path[2100], line[1024];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    FILE *f = fopen(path, "r");
    int n = 0;
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, key, strlen(key))) {
            n = sscanf(line + strlen(key), fmt, a, b, c, d);
            break;
        }
    if (f) fclose(f);
    return n;
}

/* Mass cells: NURBS (cells of faces: the sums are exact, the merge equals the single run within
 * its quadrature error) and f-rep (octants of the octree: the same boundary cells, so the same
 * certified bounds; the Monte Carlo estimate within the reported errors). */
static void test_mass(void **state)
{
    (void)state;
    make_dir("mass");
    const char *m = CRISP_DATA_DIR "/nurbs/occt_trj9_io1.stp", *b = CRISP_DATA_DIR "/frep/bear.vm";
    assert_int_equal(test_run(dir,
                              "%s mass %s > single.txt && for i in 0 1 2 3 4; do %s mass %s "
                              "--cell $i/5 -o n$i.cell || exit 1; done && %s merge -o "
                              "merged.txt n?.cell",
                              CRISP, m, CRISP, m, CRISP),
                     0);
    double v1, e1, v2, e2, x;
    assert_int_equal(read_numbers("single.txt", "volume", " %lf (+- %lf", &v1, &e1, &x, &x), 2);
    assert_int_equal(read_numbers("merged.txt", "volume", " %lf (+- %lf", &v2, &e2, &x, &x), 2);
    assert_true(fabs(v1 - v2) <= e1 + e2 + 1e-14 * fabs(v1));
    double a1, a2;
    assert_int_equal(read_numbers("single.txt", "area", " %lf", &a1, &x, &x, &x), 1);
    assert_int_equal(read_numbers("merged.txt", "area", " %lf", &a2, &x, &x, &x), 1);
    assert_true(fabs(a1 - a2) <= 1e-12 * a1);
    /* f-rep: level 5, 8 octants at level 4 */
    assert_int_equal(test_run(dir,
                              "%s frep mass %s --level 5 > fsingle.txt && for i in 0 1 2 3 4 "
                              "5 6 7; do %s frep mass %s --level 5 --cell $i/8 -o f$i.cell || "
                              "exit 1; done && %s merge -o fmerged.txt f?.cell",
                              CRISP, b, CRISP, b, CRISP),
                     0);
    double lo1, hi1, lo2, hi2;
    assert_int_equal(read_numbers("fsingle.txt", "volume",
                                  " %lf +- %lf (standard error); "
                                  "certified bounds [%lf, %lf]",
                                  &v1, &e1, &lo1, &hi1),
                     4);
    assert_int_equal(read_numbers("fmerged.txt", "volume",
                                  " %lf +- %lf (standard error); "
                                  "certified bounds [%lf, %lf]",
                                  &v2, &e2, &lo2, &hi2),
                     4);
    assert_true(fabs(v1 - v2) <= 4 * sqrt(e1 * e1 + e2 * e2));
    assert_true(fabs(e1 - e2) <= 0.2 * e1); /* the variances add up to the single run's */
    assert_true(fabs(lo1 - lo2) <= 1e-9 * hi1 && fabs(hi1 - hi2) <= 1e-9 * hi1);
    assert_true(lo2 <= v1 && v1 <= hi2);
    /* bad sets */
    assert_int_equal(test_run(dir, "%s merge -o bad.txt f0.cell f1.cell f2.cell", CRISP), 1);
    assert_non_null(strstr(test_output(dir), "incomplete set: 5 of the 8 cells"));
    assert_int_equal(test_run(dir,
                              "%s frep mass %s --level 6 --cell 1/8 -o g1.cell > /dev/null && "
                              "%s merge -o bad.txt f0.cell g1.cell f2.cell f3.cell f4.cell "
                              "f5.cell f6.cell f7.cell",
                              CRISP, b, CRISP),
                     1);
    assert_non_null(strstr(test_output(dir), "g1.cell: cell 1 has other settings"));
    assert_int_equal(test_run(dir,
                              "head -c 200 f3.cell > t3.cell && %s merge -o bad.txt f0.cell "
                              "f1.cell f2.cell t3.cell f4.cell f5.cell f6.cell f7.cell",
                              CRISP),
                     1);
    assert_non_null(strstr(test_output(dir), "t3.cell: missing or corrupt cell"));
    assert_int_equal(test_run(dir, "%s frep mass %s --level 5 --cell 1/4 -o x.cell", CRISP, b), 2);
    assert_non_null(strstr(test_output(dir), "power of 8"));
}

/* A binary STL as triangles of 9 floats, each rotated to start at its least vertex (keeping
 * its orientation), sorted: two meshes with the same triangles compare equal. */
typedef struct tri9 {
    float v[9];
} tri9;

static int cmp_tri9(const void *a, const void *b)
{
    return memcmp(a, b, sizeof(tri9));
}

static tri9 *read_stl(const char *name, size_t *count)
{
    char path[2100];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    unsigned char head[84];
    uint32_t n = 0;
    tri9 *t = NULL;
    if (fread(head, 1, 84, f) == 84) {
        memcpy(&n, head + 80, 4);
        t = malloc((n ? n : 1) * sizeof *t);
        for (uint32_t i = 0; t && i < n; i++) {
            unsigned char rec[50];
            if (fread(rec, 1, 50, f) != 50) {
                free(t), t = NULL;
                break;
            }
            float v[9];
            memcpy(v, rec + 12, sizeof v);
            int s = 0;
            for (int k = 1; k < 3; k++)
                if (memcmp(v + 3 * k, v + 3 * s, 12) < 0) s = k;
            for (int k = 0; k < 3; k++)
                memcpy(t[i].v + 3 * k, v + 3 * ((s + k) % 3), 12);
        }
    }
    fclose(f);
    if (t) qsort(t, n, sizeof *t, cmp_tri9);
    *count = n;
    return t;
}

static int cmp_vec(const void *a, const void *b)
{
    return memcmp(a, b, 3 * sizeof(float));
}

/* Triangles -> an indexed mesh, vertices equal bit for bit welded. */
static void weld_tris(const tri9 *t, size_t n, mc_mesh *m)
{
    memset(m, 0, sizeof *m);
    float *all = malloc(9 * n * sizeof *all + 1);
    memcpy(all, t, 9 * n * sizeof *all);
    qsort(all, 3 * n, 3 * sizeof(float), cmp_vec);
    size_t nv = 0;
    for (size_t i = 0; i < 3 * n; i++)
        if (!nv || memcmp(all + 3 * i, all + 3 * (nv - 1), 12))
            memmove(all + 3 * nv++, all + 3 * i, 12);
    m->p = all, m->nv = nv;
    m->t = malloc(3 * n * sizeof *m->t + 1), m->nt = n;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            float *hit = bsearch(t[i].v + 3 * k, all, nv, 3 * sizeof(float), cmp_vec);
            m->t[3 * i + k] = (uint32_t)((hit - all) / 3);
        }
}

/* Mesh cells: octants of the grid's blocks, meshed apart and welded by crisp merge, give the
 * single run's triangles exactly, so the merged mesh passes the mesh issue's checks (closed,
 * 2-manifold, oriented, no self-intersection) and has its volume. */
static void mesh_cells(const char *model, const char *opts, int n)
{
    assert_int_equal(test_run(dir,
                              "%s frep mesh %s %s -o single.stl && rm -f c*.cmesh* && i=0 && "
                              "while [ $i -lt %d ]; do %s frep mesh %s %s --cell $i/%d -o "
                              "c$i.cmesh || exit 1; i=$((i+1)); done && %s merge -o merged.stl "
                              "c*.cmesh",
                              CRISP, model, opts, n, CRISP, model, opts, n, CRISP),
                     0);
    size_t n1, n2;
    tri9 *a = read_stl("single.stl", &n1), *b = read_stl("merged.stl", &n2);
    assert_non_null(a);
    assert_non_null(b);
    assert_true(n1 > 1000);
    assert_int_equal(n1, n2);
    assert_memory_equal(a, b, n1 * sizeof *a);
    mc_mesh m;
    weld_tris(b, n2, &m);
    size_t pairs;
    assert_int_equal(mc_manifold_defects(&m), 0);
    assert_int_equal(mc_self_intersections(&m, 0.05, &pairs), 0);
    assert_true(mc_volume(&m) > 0);
    mc_free(&m);
    free(a), free(b);
}

static void test_mesh(void **state)
{
    (void)state;
    make_dir("mesh");
    mesh_cells(CRISP_DATA_DIR "/frep/bear.vm", "--resolution 48", 8);
    mesh_cells(CRISP_DATA_DIR "/frep/tanglecube.vm", "--resolution 40", 64);
    /* a missing cell, a corrupt one */
    assert_int_equal(test_run(dir, "%s merge -o bad.stl c0.cmesh c1.cmesh", CRISP), 1);
    assert_non_null(strstr(test_output(dir), "incomplete set: 62 of the 64 cells"));
    assert_int_equal(test_run(dir,
                              "cp c0.cmesh x.bak && head -c 100 x.bak > c0.cmesh && %s merge "
                              "-o bad.stl c*.cmesh",
                              CRISP),
                     1);
    assert_non_null(strstr(test_output(dir), "cell 0: "));
    assert_non_null(strstr(test_output(dir), "is corrupt"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_model), cmocka_unit_test(test_scene),
        cmocka_unit_test(test_frep),  cmocka_unit_test(test_bad_cells),
        cmocka_unit_test(test_mass),  cmocka_unit_test(test_mesh)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
