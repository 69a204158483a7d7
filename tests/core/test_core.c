/* Tests for src/core: errors, allocation, arena, vec/mat, thread pool (errors carried from
 * workers, nesting, kept pools, progress). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdatomic.h>
#include <string.h>

#include "crisp/core.h"

static void test_error_message(void **state)
{
    (void)state;
    crisp_error_clear();
    assert_string_equal(crisp_error_message(), "");
    crisp_status s =
        crisp_error(CRISP_ERR_PARSE, "%s:%d:%d: expected %s", "a.iges", 12, 3, "digit");
    assert_int_equal(s, CRISP_ERR_PARSE);
    assert_string_equal(crisp_error_message(), "a.iges:12:3: expected digit");
    crisp_error_prefix("reading %s", "model");
    assert_string_equal(crisp_error_message(), "reading model: a.iges:12:3: expected digit");
    assert_string_equal(crisp_status_name(CRISP_ERR_PARSE), "parse error");
}

static void test_alloc_overflow(void **state)
{
    (void)state;
    assert_null(crisp_malloc_array(SIZE_MAX / 2, 4));
    assert_null(crisp_calloc_array(SIZE_MAX / 8, 16));
    void *p = crisp_malloc_array(10, 8);
    assert_non_null(p);
    assert_null(crisp_realloc_array(p, SIZE_MAX, 2)); /* p stays valid */
    crisp_free(p);
    int *a = NULL;
    size_t cap = 0;
    assert_int_equal(crisp_grow((void **)&a, &cap, 100, sizeof *a), CRISP_OK);
    assert_true(cap >= 100);
    for (int i = 0; i < 100; i++)
        a[i] = i;
    assert_int_not_equal(crisp_grow((void **)&a, &cap, SIZE_MAX, sizeof *a), CRISP_OK);
    assert_int_equal(a[99], 99);
    crisp_free(a);
}

static void test_arena_reuse(void **state)
{
    (void)state;
    crisp_arena *a;
    assert_int_equal(crisp_arena_create(1024, &a), CRISP_OK);
    for (int frame = 0; frame < 3; frame++) {
        crisp_arena_reset(a);
        for (int i = 0; i < 50; i++) {
            double *p = crisp_arena_alloc(a, 37, sizeof(double));
            assert_non_null(p);
            assert_int_equal((uintptr_t)p % 16, 0);
            for (int k = 0; k < 37; k++)
                p[k] = k;
        }
        char *big = crisp_arena_alloc(a, 5000, 1);
        assert_non_null(big);
        memset(big, 1, 5000);
    }
    size_t reserved = crisp_arena_reserved(a);
    crisp_arena_reset(a);
    for (int i = 0; i < 50; i++)
        crisp_arena_alloc(a, 37, sizeof(double));
    crisp_arena_alloc(a, 5000, 1);
    assert_int_equal(crisp_arena_reserved(a), reserved); /* steady state allocates nothing */
    assert_null(crisp_arena_alloc(a, SIZE_MAX, 2));
    crisp_arena_destroy(a);
    crisp_arena_destroy(NULL);
}

static void test_mat4(void **state)
{
    (void)state;
    crisp_vec3 eye = {1, 2, 5}, target = {0, 0, 0}, up = {0, 1, 0};
    crisp_mat4 view, proj, vp, inv, id;
    assert_true(crisp_mat4_lookat(eye, target, up, view));
    /* The eye maps to the origin and the target lies on -Z. */
    crisp_vec4 e, t;
    crisp_mat4_mulp(view, eye, e);
    crisp_mat4_mulp(view, target, t);
    for (int i = 0; i < 3; i++)
        assert_true(fabs(e[i]) < 1e-12);
    assert_true(fabs(t[0]) < 1e-12 && fabs(t[1]) < 1e-12);
    assert_true(fabs(t[2] + sqrt(30.0)) < 1e-12);
    crisp_mat4_perspective(30, 16.0 / 9.0, 0.1, 100, proj);
    crisp_mat4_mul(proj, view, vp);
    assert_true(crisp_mat4_inverse(vp, inv));
    crisp_mat4_mul(vp, inv, id);
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 4; r++)
            assert_true(fabs(id[c][r] - (c == r)) < 1e-12);
    /* A point on the near plane maps to z/w = -1, on the far plane to +1. */
    crisp_vec3 pn = {0, 0, -0.1}, pf = {0, 0, -100};
    crisp_vec4 cn, cf;
    crisp_mat4_mulp(proj, pn, cn);
    crisp_mat4_mulp(proj, pf, cf);
    assert_true(fabs(cn[2] / cn[3] + 1) < 1e-12);
    assert_true(fabs(cf[2] / cf[3] - 1) < 1e-9);
    crisp_vec3 same = {1, 2, 5};
    assert_false(crisp_mat4_lookat(eye, same, up, view));
    crisp_mat4 zero = {{0}};
    assert_false(crisp_mat4_inverse(zero, inv));
    crisp_vec3 a = {1, 0, 0}, b = {0, 1, 0}, c;
    crisp_vec3_cross(a, b, c);
    assert_true(c[2] == 1);
}

typedef struct {
    atomic_int *hits;
    atomic_int calls;
} pool_ctx;

static void mark(void *vctx, size_t b, size_t e, int worker)
{
    pool_ctx *ctx = vctx;
    (void)worker;
    atomic_fetch_add(&ctx->calls, 1);
    for (size_t i = b; i < e; i++)
        atomic_fetch_add(&ctx->hits[i], 1);
}

static void test_pool(void **state)
{
    (void)state;
    for (int threads = 1; threads <= 4; threads++) {
        crisp_pool *p;
        assert_int_equal(crisp_pool_create(threads, &p), CRISP_OK);
        assert_int_equal(crisp_pool_threads(p), threads);
        enum { N = 10007 };
        static atomic_int hits[N];
        for (int rep = 0; rep < 20; rep++) {
            for (int i = 0; i < N; i++)
                atomic_store(&hits[i], 0);
            pool_ctx ctx = {hits, 0};
            crisp_pool_parallel_for(p, N, 13, mark, &ctx);
            for (int i = 0; i < N; i++)
                assert_int_equal(atomic_load(&hits[i]), 1);
            assert_int_equal(atomic_load(&ctx.calls), (N + 12) / 13);
        }
        crisp_pool_destroy(p);
    }
    assert_non_null(crisp_pool_shared());
    assert_true(crisp_pool_default_threads() >= 1);
    crisp_pool_destroy(NULL);
}

/* Back-to-back jobs of a few items (a frame's small passes): a worker that wakes late finds the
 * caller done and the job's door closed, or joins a later job. No chunk may run after its
 * caller returned (live is cleared then) or twice, and every item runs once. */
typedef struct {
    atomic_int hits[3];
    atomic_int live, late;
} small_job;

static void mark_small(void *vctx, size_t b, size_t e, int worker)
{
    small_job *j = vctx;
    if (!atomic_load(&j->live)) atomic_fetch_add(&j->late, 1);
    if (worker) /* a worker's chunk ends after the caller's: the caller must wait for it */
        for (int k = 0; k < 2000 && atomic_load(&j->live); k++)
            ;
    for (size_t i = b; i < e; i++)
        atomic_fetch_add(&j->hits[i], 1);
}

static void test_pool_small_jobs(void **state)
{
    (void)state;
    enum { JOBS = 20000 };
    static small_job jobs[JOBS];
    for (int threads = 2; threads <= 4; threads++) {
        crisp_pool *p;
        assert_int_equal(crisp_pool_create(threads, &p), CRISP_OK);
        memset(jobs, 0, sizeof jobs);
        for (int k = 0; k < JOBS; k++) {
            atomic_store(&jobs[k].live, 1);
            crisp_pool_parallel_for(p, 2 + k % 2, 1, mark_small, &jobs[k]);
            atomic_store(&jobs[k].live, 0);
            /* a stale worker's chunk of job k would count here or in a later job's check */
            for (int i = 0; i < 3; i++)
                assert_int_equal(atomic_load(&jobs[k].hits[i]), i < 2 + k % 2);
        }
        crisp_pool_destroy(p);
        for (int k = 0; k < JOBS; k++) {
            assert_int_equal(atomic_load(&jobs[k].late), 0);
            for (int i = 0; i < 3; i++)
                assert_int_equal(atomic_load(&jobs[k].hits[i]), i < 2 + k % 2);
        }
    }
}

static void mark_error_everywhere(void *vctx, size_t b, size_t e, int worker)
{
    (void)vctx, (void)b, (void)e;
    if (worker == 0) {
        crisp_error(CRISP_ERR_IO, "caller's own");
    } else {
        /* slow workers: the caller surely runs some items itself */
        for (int spin = 0; spin < 20000; spin++)
            crisp_time_ns();
        crisp_error(CRISP_ERR_IO, "worker's");
    }
}

/* A worker's error: only threads other than the caller fail (after the caller has given up a
 * few items to them), so the message can only reach the caller through the pool. */
typedef struct {
    atomic_int failed;
    atomic_int started;
} fail_ctx;

static void fail_on_worker(void *vctx, size_t b, size_t e, int worker)
{
    fail_ctx *c = vctx;
    (void)e;
    atomic_fetch_add(&c->started, 1);
    if (worker == 0) {
        /* hold the caller until a worker has run, so one surely fails */
        for (int spin = 0; spin < 2000000 && !atomic_load(&c->failed); spin++)
            crisp_time_ns();
        return;
    }
    int expected = 0;
    if (atomic_compare_exchange_strong(&c->failed, &expected, 1))
        crisp_error(CRISP_ERR_PARSE, "item %zu on worker %d: expected a number", b, worker);
}

static void test_pool_worker_error(void **state)
{
    (void)state;
    crisp_pool *p;
    assert_int_equal(crisp_pool_create(3, &p), CRISP_OK);
    crisp_error_clear();
    fail_ctx c = {0, 0};
    crisp_pool_parallel_for(p, 64, 1, fail_on_worker, &c);
    assert_int_equal(atomic_load(&c.failed), 1);
    assert_non_null(strstr(crisp_error_message(), "expected a number"));
    assert_non_null(strstr(crisp_error_message(), "on worker"));
    /* An error of the caller's own is kept over a worker's. */
    crisp_error(CRISP_ERR_IO, "caller");
    crisp_pool_parallel_for(p, 64, 1, mark_error_everywhere, NULL);
    assert_string_equal(crisp_error_message(), "caller's own");
    crisp_pool_destroy(p);
}

typedef struct {
    crisp_pool *pool;
    atomic_int inner;
} nest_ctx;

static void inner_fn(void *vctx, size_t b, size_t e, int worker)
{
    (void)worker;
    nest_ctx *c = vctx;
    atomic_fetch_add(&c->inner, (int)(e - b));
}

static void outer_fn(void *vctx, size_t b, size_t e, int worker)
{
    (void)worker;
    nest_ctx *c = vctx;
    for (size_t i = b; i < e; i++)
        crisp_pool_parallel_for(c->pool, 10, 1, inner_fn, c);
}

static int progress_calls;
static double progress_last, progress_min = 2;

static void on_progress(void *ctx, double f)
{
    (void)ctx;
    progress_calls++;
    if (f < progress_last) progress_min = f; /* a report going backwards within one job */
    progress_last = f;
}

/* A call from inside a job runs inline instead of deadlocking; kept pools are reused; the
 * caller reports progress that rises to 1. */
static void test_pool_nested_kept_progress(void **state)
{
    (void)state;
    crisp_pool *a, *b;
    assert_int_equal(crisp_pool_get(3, &a), CRISP_OK);
    assert_int_equal(crisp_pool_get(3, &b), CRISP_OK);
    assert_ptr_equal(a, b);
    assert_int_equal(crisp_pool_threads(a), 3);
    assert_int_equal(crisp_pool_get(0, &b), CRISP_OK);
    assert_ptr_equal(b, crisp_pool_shared());
    nest_ctx c = {a, 0};
    crisp_pool_parallel_for(a, 20, 1, outer_fn, &c);
    assert_int_equal(atomic_load(&c.inner), 200);
    crisp_progress_set(on_progress, NULL);
    progress_last = 0;
    crisp_pool_parallel_for(a, 1000, 7, inner_fn, &c);
    crisp_progress_set(NULL, NULL);
    assert_true(progress_calls > 0);
    assert_true(progress_min == 2); /* never went backwards */
    assert_true(progress_last > 0 && progress_last <= 1);
    crisp_pool_parallel_for(a, 1000, 7, inner_fn, &c);
    int calls = progress_calls;
    assert_int_equal(progress_calls, calls); /* off again */
}

static void test_time(void **state)
{
    (void)state;
    double a = crisp_time_now();
    uint64_t na = crisp_time_ns();
    double b = crisp_time_now();
    assert_true(b >= a);
    assert_true(crisp_time_ns() >= na);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_error_message),
        cmocka_unit_test(test_alloc_overflow),
        cmocka_unit_test(test_arena_reuse),
        cmocka_unit_test(test_mat4),
        cmocka_unit_test(test_pool),
        cmocka_unit_test(test_pool_small_jobs),
        cmocka_unit_test(test_time),
        cmocka_unit_test(test_pool_worker_error),
        cmocka_unit_test(test_pool_nested_kept_progress),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
