/* A pthread pool shared by the modules. parallel_for hands out chunks through an atomic counter,
 * so uneven work (subdivision cells, patches of different cost) balances dynamically. The first
 * error raised on a worker during a job (its crisp_error message) is carried to the calling
 * thread; the calling thread reports the job's progress (crisp_progress_set); callers from
 * several threads take turns, and a call from inside a job runs inline. crisp_pool_get keeps one
 * pool per thread count for the whole process, so renderers need not start threads per call.
 *
 * Hand-offs: a frame's plan and draw are many passes of 0.02-0.3 ms, and waking a sleeping thread
 * takes about as long on a virtual machine (an idle CPU halted: 0.02-0.25 ms measured, session
 * 17). So a worker waits for the next job spinning a while before it sleeps, the caller waits for
 * its workers' last chunks spinning before it sleeps, and a worker that arrives after the caller
 * has handed out every chunk takes no part (the job's door is closed): the caller does not wait
 * for a worker that never started (it waited for each one to wake, see nothing left and report
 * back). */
#include "crisp/core.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core_internal.h"

struct crisp_pool {
    int threads;
    pthread_t *tids;
    pthread_mutex_t job_lock; /* one job at a time */
    pthread_mutex_t lock;
    pthread_cond_t wake, done;
    /* current job */
    crisp_pool_fn fn;
    void *ctx;
    size_t count, grain;
    atomic_size_t next, items_done;
    crisp__error_slot error; /* the job's first error */
    /* The job's door: DOOR_OPEN while the caller may still have chunks to hand out, and below it
     * the workers in the job (joined through the open door, not left yet). */
    atomic_uint door;
    atomic_ulong generation; /* bumped per job (under lock); workers try each generation once */
    atomic_int quit;
};

#define DOOR_OPEN 0x80000000u
/* How long a worker spins for the next job, and the caller for its workers' last chunks,
 * before sleeping (seconds). */
#define SPIN_SECONDS 150e-6

typedef struct {
    crisp_pool *pool;
    int worker;
} worker_arg;

static _Thread_local crisp_pool *current; /* the pool whose job this thread is running */

/* ---- progress ----------------------------------------------------------------------------------
 */

/* Set from one thread, read by whichever thread reports: atomics, so a report never sees a torn
 * pointer (the receiver and its context are set before the receiver is published). */
static _Atomic(crisp_progress_fn) progress_fn;
static _Atomic(void *) progress_ctx;

void crisp_progress_set(crisp_progress_fn fn, void *ctx)
{
    atomic_store(&progress_fn, NULL);
    atomic_store(&progress_ctx, ctx);
    atomic_store(&progress_fn, fn);
}

void crisp_progress_report(double fraction)
{
    crisp_progress_fn fn = atomic_load(&progress_fn);
    if (fn) fn(atomic_load(&progress_ctx), fraction < 0 ? 0 : fraction > 1 ? 1 : fraction);
}

static void run_chunks(crisp_pool *p, int worker)
{
    crisp_pool *outer = current;
    current = p;
    for (;;) {
        size_t b = atomic_fetch_add(&p->next, p->grain);
        if (b >= p->count) break;
        size_t e = b + p->grain < p->count ? b + p->grain : p->count;
        p->fn(p->ctx, b, e, worker);
        /* only while someone listens: the shared counter is one more contended cache line */
        if (atomic_load_explicit(&progress_fn, memory_order_relaxed)) {
            size_t d = atomic_fetch_add(&p->items_done, e - b) + (e - b);
            if (worker == 0) crisp_progress_report((double)d / (double)p->count);
        }
    }
    current = outer;
}

static inline void cpu_relax(void)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
}

/* Spinning: call spin_wait(&until, &i) in the loop (both 0 at first); it returns 0 once
 * SPIN_SECONDS have passed (the time read once every 64 calls; every 1,024th call yields, so
 * that a loaded machine's other threads run). */
static int spin_wait(double *until, unsigned *i)
{
    cpu_relax();
    if (++*i % 64) return 1;
    if (*i % 1024 == 0) sched_yield();
    double t = crisp_time_now();
    if (*until == 0) *until = t + SPIN_SECONDS;
    return t <= *until;
}

/* The worker's turn in the job behind the door: only while it is open (the caller may still have
 * chunks to hand out); 0 when closed. */
static int join(crisp_pool *p)
{
    unsigned d = atomic_load(&p->door);
    while (d & DOOR_OPEN)
        if (atomic_compare_exchange_weak(&p->door, &d, d + 1)) return 1;
    return 0;
}

static void *worker_main(void *varg)
{
    worker_arg *wa = varg;
    crisp_pool *p = wa->pool;
    int worker = wa->worker;
    free(wa);
    unsigned long seen = 0;
    for (;;) {
        /* the next job: spinning a while, then asleep */
        double until = 0;
        unsigned spins = 0;
        while (atomic_load(&p->generation) == seen && !atomic_load(&p->quit) &&
               spin_wait(&until, &spins))
            ;
        if (atomic_load(&p->generation) == seen && !atomic_load(&p->quit)) {
            pthread_mutex_lock(&p->lock);
            while (!atomic_load(&p->quit) && atomic_load(&p->generation) == seen)
                pthread_cond_wait(&p->wake, &p->lock);
            pthread_mutex_unlock(&p->lock);
        }
        if (atomic_load(&p->quit)) break;
        seen = atomic_load(&p->generation);
        /* (a later job than seen may be behind the door by now: its fields were set before it
         * opened, so taking part in it is as good) */
        if (!join(p)) continue;
        crisp__error_slot *outer = crisp__error_capture(&p->error);
        run_chunks(p, worker);
        crisp__error_capture(outer);
        /* the last one out of a closed door tells the caller */
        if (atomic_fetch_sub(&p->door, 1) == 1) {
            pthread_mutex_lock(&p->lock);
            pthread_cond_signal(&p->done);
            pthread_mutex_unlock(&p->lock);
        }
    }
    return NULL;
}

int crisp_pool_default_threads(void)
{
    const char *env = getenv("CRISP_THREADS");
    if (env && *env) {
        char *end;
        long n = strtol(env, &end, 10);
        if (*end == '\0' && n >= 1 && n <= 1024) return (int)n;
    }
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n >= 1 ? (int)(n > 1024 ? 1024 : n) : 1;
}

crisp_status crisp_pool_create(int threads, crisp_pool **dest)
{
    if (threads <= 0) threads = crisp_pool_default_threads();
    if (threads > 1024)
        return crisp_error(CRISP_ERR_INVALID_ARG, "thread count %d is above the limit of 1024",
                           threads);
    crisp_pool *p = calloc(1, sizeof *p);
    if (!p) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating a thread pool");
    p->threads = threads;
    pthread_mutex_init(&p->job_lock, NULL);
    pthread_mutex_init(&p->lock, NULL);
    pthread_cond_init(&p->wake, NULL);
    pthread_cond_init(&p->done, NULL);
    atomic_init(&p->next, 0);
    atomic_init(&p->items_done, 0);
    atomic_init(&p->error.taken, 0);
    atomic_init(&p->door, 0);
    atomic_init(&p->generation, 0);
    atomic_init(&p->quit, 0);
    if (threads > 1) {
        p->tids = calloc((size_t)threads - 1, sizeof *p->tids);
        if (!p->tids) {
            crisp_pool_destroy(p);
            return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating a thread pool");
        }
        for (int i = 1; i < threads; i++) {
            worker_arg *wa = malloc(sizeof *wa);
            if (!wa || pthread_create(&p->tids[i - 1], NULL, worker_main,
                                      (*wa = (worker_arg){p, i}, wa)) != 0) {
                free(wa);
                p->threads = i; /* destroy joins only the started ones */
                crisp_pool_destroy(p);
                return crisp_error(CRISP_ERR_NO_MEMORY, "could not start thread %d of %d", i,
                                   threads);
            }
        }
    }
    *dest = p;
    return CRISP_OK;
}

void crisp_pool_destroy(crisp_pool *p)
{
    if (!p) return;
    pthread_mutex_lock(&p->lock);
    atomic_store(&p->quit, 1);
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->lock);
    for (int i = 1; i < p->threads; i++)
        pthread_join(p->tids[i - 1], NULL);
    pthread_mutex_destroy(&p->job_lock);
    pthread_mutex_destroy(&p->lock);
    pthread_cond_destroy(&p->wake);
    pthread_cond_destroy(&p->done);
    free(p->tids);
    free(p);
}

int crisp_pool_threads(const crisp_pool *p)
{
    return p ? p->threads : 1;
}

void crisp_pool_parallel_for(crisp_pool *p, size_t count, size_t grain, crisp_pool_fn fn, void *ctx)
{
    if (count == 0) return;
    if (grain == 0) grain = 1;
    if (!p || p->threads == 1 || count <= grain || current == p) {
        /* inline: on the calling thread (also a call from inside one of p's jobs) */
        for (size_t b = 0; b < count; b += grain) {
            size_t e = b + grain < count ? b + grain : count;
            fn(ctx, b, e, 0);
            if (count > grain && !current && atomic_load(&progress_fn))
                crisp_progress_report((double)e / (double)count);
        }
        return;
    }
    pthread_mutex_lock(&p->job_lock);
    unsigned long errors_before = crisp__error_count();
    /* (no worker is in a job now: the last caller closed its door and waited for them) */
    p->fn = fn;
    p->ctx = ctx;
    p->count = count;
    p->grain = grain;
    atomic_store(&p->next, 0);
    atomic_store(&p->items_done, 0);
    atomic_store(&p->error.taken, 0);
    atomic_store(&p->door, DOOR_OPEN); /* after the fields: a worker that joins reads them */
    pthread_mutex_lock(&p->lock);
    atomic_fetch_add(&p->generation, 1);
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->lock);
    run_chunks(p, 0);
    /* Every chunk is handed out: close the door, then wait for the workers inside (their last
     * chunks), spinning a while before sleeping. */
    if (atomic_fetch_and(&p->door, ~DOOR_OPEN) != DOOR_OPEN) {
        double until = 0;
        unsigned spins = 0;
        while (atomic_load(&p->door) != 0 && spin_wait(&until, &spins))
            ;
        pthread_mutex_lock(&p->lock);
        while (atomic_load(&p->door) != 0)
            pthread_cond_wait(&p->done, &p->lock);
        pthread_mutex_unlock(&p->lock);
    }
    if (atomic_load(&progress_fn))
        crisp_progress_report(1.0); /* the workers may have taken every item */
    /* A worker's error and none on this thread: its message becomes this thread's, so the
     * status the caller collects from its workers comes with what was wrong. */
    if (atomic_load(&p->error.taken) == 2 && crisp__error_count() == errors_before)
        crisp__error_set_message(p->error.message);
    pthread_mutex_unlock(&p->job_lock);
}

static crisp_pool *shared_pool;
static pthread_once_t shared_once = PTHREAD_ONCE_INIT;

static void shared_init(void)
{
    if (crisp_pool_create(0, &shared_pool) != CRISP_OK) shared_pool = NULL;
}

/* Pools kept for other thread counts (crisp_pool_get). */
enum { KEPT_MAX = 8 };
static crisp_pool *kept[KEPT_MAX];
static pthread_mutex_t kept_lock = PTHREAD_MUTEX_INITIALIZER;

static void shared_cleanup(void) __attribute__((destructor));
static void shared_cleanup(void)
{
    crisp_pool_destroy(shared_pool);
    shared_pool = NULL;
    for (int i = 0; i < KEPT_MAX; i++) {
        crisp_pool_destroy(kept[i]);
        kept[i] = NULL;
    }
}

crisp_pool *crisp_pool_shared(void)
{
    pthread_once(&shared_once, shared_init);
    return shared_pool;
}

crisp_status crisp_pool_get(int threads, crisp_pool **dest)
{
    if (threads <= 0 || threads == crisp_pool_default_threads()) {
        *dest = crisp_pool_shared();
        return *dest ? CRISP_OK
                     : crisp_error(CRISP_ERR_NO_MEMORY, "could not start the shared thread pool");
    }
    if (threads == 1) {
        *dest = NULL; /* parallel_for runs inline */
        return CRISP_OK;
    }
    crisp_status st = CRISP_OK;
    pthread_mutex_lock(&kept_lock);
    int i = 0;
    while (i < KEPT_MAX && kept[i] && kept[i]->threads != threads)
        i++;
    if (i == KEPT_MAX) {
        /* full: replace the last one (its callers hold no reference beyond a call) */
        i = KEPT_MAX - 1;
        crisp_pool_destroy(kept[i]);
        kept[i] = NULL;
    }
    if (!kept[i]) st = crisp_pool_create(threads, &kept[i]);
    *dest = kept[i];
    pthread_mutex_unlock(&kept_lock);
    return st;
}
