/* crisp jobs (issue 15) with the real engines on localhost, 2 processes: the Makefile (make -j2)
 * and the GNU parallel list (parallel -j2 --joblog --resume, then merge.sh) give the single run's
 * image bit for bit (PNG of a bundled model; EXR with every AOV of the scene with f-rep parts);
 * a run killed part-way and resumed redoes only the missing cells; the Slurm array script run
 * locally task by task gives the same image; turntable and batch jobs make their frames. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>

#include "jobs/image_util.h"

#define CRISP CRISP_BIN_DIR "/crisp"

static char dir[1024];

static void make_dir(const char *name)
{
    assert_true(snprintf(dir, sizeof dir, "%s/test_jobs_%s", CRISP_BIN_DIR, name) <
                (int)sizeof dir);
    char cmd[2200];
    assert_true(snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", dir, dir) <
                (int)sizeof cmd);
    assert_int_equal(system(cmd), 0);
}

static int run(const char *fmt, const char *a, const char *b)
{
    int rc = test_run(dir, fmt, a, b, CRISP, CRISP);
    if (rc) fprintf(stderr, "exit %d:\n%s\n", rc, test_output(dir));
    return rc;
}

static int same(const char *a, const char *b)
{
    char x[2100], y[2100];
    snprintf(x, sizeof x, "%s/%s", dir, a);
    snprintf(y, sizeof y, "%s/%s", dir, b);
    return test_same_image(x, y);
}

/* Modification time in nanoseconds, 0 when missing. */
static long long mtime(const char *rel)
{
    char p[2100];
    snprintf(p, sizeof p, "%s/%s", dir, rel);
    struct stat sb;
    if (stat(p, &sb)) return 0;
    return (long long)sb.st_mtim.tv_sec * 1000000000LL + sb.st_mtim.tv_nsec;
}

static void test_make(void **state)
{
    (void)state;
    make_dir("make");
    const char *m = CRISP_DATA_DIR "/nurbs/occt_bearing.iges";
    assert_int_equal(run("%s render %s --size 320x256 -o whole.png -q", CRISP, m), 0);
    assert_int_equal(
        run("%s jobs render %s --size 320x256 --cells 6 -o J -q && make -s -j2 -C J", CRISP, m), 0);
    assert_true(same("whole.png", "J/image.png"));
    /* a run killed part-way: cells 0 and 4 done, cell 2 killed while writing (its temporary
     * file left behind), the rest not started; make again redoes only what is missing */
    assert_int_equal(run("%s jobs render %s --size 320x256 --cells 6 -o K -q && make -s -j2 -C K "
                         "cells/t00000.png cells/t00004.png && touch K/cells/.tmp-99-t00002.png",
                         CRISP, m),
                     0);
    long long t0 = mtime("K/cells/t00000.png"), t4 = mtime("K/cells/t00004.png");
    assert_true(t0 && t4 && !mtime("K/cells/t00001.png"));
    struct timespec ts = {0, 20000000};
    nanosleep(&ts, NULL);
    assert_int_equal(run("make -j2 -C K | grep -c -- '--tile' > redone.txt; true", "", ""), 0);
    assert_int_equal(mtime("K/cells/t00000.png"), t0);
    assert_int_equal(mtime("K/cells/t00004.png"), t4);
    assert_true(same("whole.png", "K/image.png"));
    char path[2100];
    snprintf(path, sizeof path, "%s/redone.txt", dir);
    FILE *f = fopen(path, "r");
    int redone = 0;
    assert_non_null(f);
    assert_int_equal(fscanf(f, "%d", &redone), 1);
    fclose(f);
    assert_int_equal(redone, 4); /* cells 1, 2, 3, 5 */
    /* nothing left to do: make says so and the image stays */
    long long ti = mtime("K/image.png");
    assert_int_equal(run("make -s -j2 -C K", "", ""), 0);
    assert_int_equal(mtime("K/image.png"), ti);
    /* a really killed make (SIGKILL once a cell is done) and its resumption */
    assert_int_equal(run("%s jobs render %s --size 320x256 --cells 6 -o L -q && (make -s -j2 -C L "
                         "cells/t00000.png cells/t00001.png cells/t00002.png cells/t00003.png & "
                         "pid=$!; while [ ! -e L/cells/t00000.png ] && kill -0 $pid 2>/dev/null; "
                         "do sleep 0.01; done; kill -9 $pid; wait) ; make -s -j2 -C L",
                         CRISP, m),
                     0);
    assert_true(same("whole.png", "L/image.png"));
}

static void test_parallel(void **state)
{
    (void)state;
    make_dir("parallel");
    const char *s = CRISP_DATA_DIR "/scenes/teapot_frep.scene";
    assert_int_equal(run("%s render %s --size 300x200 -o whole.exr -q", CRISP, s), 0);
    assert_int_equal(
        run("%s jobs render %s --size 300x200 --cells 4 --output image.exr -o P -q", CRISP, s), 0);
    /* a first run stopped after two cells, then resumed: the joblog says which cells ran */
    assert_int_equal(run("head -n 2 P/jobs.txt | parallel -j2 --joblog P/joblog && parallel -j2 "
                         "--joblog P/joblog --resume < P/jobs.txt && sh P/merge.sh && "
                         "grep -c -- '--tile' P/joblog > ran.txt",
                         "", ""),
                     0);
    assert_true(same("whole.exr", "P/image.exr"));
    char path[2100];
    snprintf(path, sizeof path, "%s/ran.txt", dir);
    FILE *f = fopen(path, "r");
    int ran = 0;
    assert_non_null(f);
    assert_int_equal(fscanf(f, "%d", &ran), 1);
    fclose(f);
    assert_int_equal(ran, 4); /* each cell once over both runs */
    /* the Slurm array script, run here task by task (batches of 3 cells: 2 tasks) */
    assert_int_equal(run("%s jobs render %s --size 300x200 --cells 4 --output image.exr --batch 3 "
                         "-o S -q && grep -q 'array=0-1' S/slurm.sh && for t in 0 1; do "
                         "SLURM_ARRAY_TASK_ID=$t SLURM_CPUS_PER_TASK=2 bash S/slurm.sh || exit 1; "
                         "done && sh S/merge.sh",
                         CRISP, s),
                     0);
    assert_true(same("whole.exr", "S/image.exr"));
}

static void test_frames(void **state)
{
    (void)state;
    make_dir("frames");
    const char *m = CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs";
    assert_int_equal(run("%s jobs turntable %s --frames 4 --size 96x64 --samples 1 -o T -q && "
                         "make -s -j2 -C T",
                         CRISP, m),
                     0);
    assert_false(same("T/frames/f0000.png", "T/frames/f0001.png"));
    assert_true(mtime("T/frames/f0003.png") != 0);
    assert_int_equal(run("%s jobs batch %s " CRISP_DATA_DIR "/nurbs/occt_bearing.iges --size "
                         "64x64 -o B -q && parallel -j2 < B/jobs.txt",
                         CRISP, m),
                     0);
    /* mass jobs: NURBS cells of faces, f-rep octants */
    assert_int_equal(run("%s jobs mass %s --cells 3 -o M -q && make -s -j2 -C M && grep -q "
                         "'^volume' M/mass.txt",
                         CRISP, CRISP_DATA_DIR "/nurbs/occt_trj9_io1.stp"),
                     0);
    assert_int_equal(run("%s jobs frep-mass %s --level 4 --cells 8 -o F -q && parallel -j2 < "
                         "F/jobs.txt > /dev/null && sh F/merge.sh && grep -q 'certified bounds' "
                         "F/mass.txt",
                         CRISP, CRISP_DATA_DIR "/frep/bear.vm"),
                     0);
    assert_int_equal(
        run("%s jobs frep-mesh %s --resolution 32 --cells 8 -o FM -q && make -s -j2 -C "
            "FM && test -s FM/mesh.stl",
            CRISP, CRISP_DATA_DIR "/frep/bear.vm"),
        0);
    assert_true(mtime("B/images/00000-gpucast_teapot.png") != 0);
    assert_true(mtime("B/images/00001-occt_bearing.png") != 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_make), cmocka_unit_test(test_parallel),
                                       cmocka_unit_test(test_frames)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
