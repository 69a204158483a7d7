/* crisp core: status codes and error messages, checked allocation, double-precision
 * vec2/vec3/vec4/mat4, a shared pthread pool and monotonic timers.
 *
 * Offers:
 *   crisp_status, crisp_status_name, crisp_error_message, crisp_error_clear
 *   crisp_malloc_array, crisp_calloc_array, crisp_realloc_array, crisp_free
 *   crisp_arena_*           bump allocator reused across frames
 *   crisp_vec{2,3,4}_*      double vectors as plain arrays (output last, called dest)
 *   crisp_mat4_*            column-major double 4x4 matrices (m[col][row], as cglm)
 *   crisp_pool_*            thread pool with dynamic parallel_for; crisp_pool_get: one kept pool
 *                           per thread count; a worker's error message reaches the caller
 *   crisp_progress_*        where long work reports how far it is (a progress bar's source)
 *   crisp_time_*            monotonic clock
 */
#ifndef CRISP_CORE_H
#define CRISP_CORE_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- status ---------------------------------------------------------------------------------- */

/* Every function that can fail on its input returns a crisp_status; 0 is success. The message
 * that says what was wrong (and where: file, line, column or entity) is kept per thread and read
 * with crisp_error_message() until the next error on that thread. */
typedef enum crisp_status {
    CRISP_OK = 0,
    CRISP_ERR_INVALID_ARG, /* a value outside what the function accepts */
    CRISP_ERR_NO_MEMORY,   /* allocation failed or a size would overflow */
    CRISP_ERR_IO,          /* a file could not be opened, read or written */
    CRISP_ERR_PARSE,       /* malformed input text or records */
    CRISP_ERR_UNSUPPORTED, /* valid input that crisp does not handle */
    CRISP_ERR_LIMIT,       /* input exceeds a documented limit (degree, count, depth) */
    CRISP_ERR_NUMERIC,     /* NaN, infinity or a degenerate geometric case */
    CRISP_ERR_GL,          /* OpenGL or context creation failure */
    CRISP_ERR_INTERNAL     /* a bug in crisp */
} crisp_status;

#if defined(__GNUC__)
#define CRISP_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define CRISP_PRINTF(a, b)
#endif

/* Short stable name of a status ("invalid argument", ...). */
const char *crisp_status_name(crisp_status status);
/* The message of this thread's last error ("" when none). */
const char *crisp_error_message(void);
void crisp_error_clear(void);
/* Record an error message for this thread and return status (for use as `return crisp_error(...)`).
 */
crisp_status crisp_error(crisp_status status, const char *fmt, ...) CRISP_PRINTF(2, 3);
crisp_status crisp_error_v(crisp_status status, const char *fmt, va_list ap);
/* Prefix this thread's current message with more context: "ctx: old message". */
void crisp_error_prefix(const char *fmt, ...) CRISP_PRINTF(1, 2);

/* ---- allocation ------------------------------------------------------------------------------ */

/* n * size bytes, or NULL when the product overflows or memory is short. Never aborts. */
void *crisp_malloc_array(size_t n, size_t size);
void *crisp_calloc_array(size_t n, size_t size);
void *crisp_realloc_array(void *p, size_t n, size_t size);
void crisp_free(void *p);
/* Grow *p (holding *cap elements of size bytes) to at least need elements, doubling. */
crisp_status crisp_grow(void **p, size_t *cap, size_t need, size_t size);

/* A bump allocator: allocations live until reset or destroy. Reset keeps the memory, so a
 * per-frame user that asks for the same sizes each frame allocates nothing after the first. */
typedef struct crisp_arena crisp_arena;
crisp_status crisp_arena_create(size_t block_size, crisp_arena **dest);
void crisp_arena_destroy(crisp_arena *arena);
void crisp_arena_reset(crisp_arena *arena);
/* 16-byte aligned; NULL on overflow or out of memory. */
void *crisp_arena_alloc(crisp_arena *arena, size_t n, size_t size);
/* Bytes reserved from the system (for memory reports). */
size_t crisp_arena_reserved(const crisp_arena *arena);
/* Bytes handed out since the last reset. */
size_t crisp_arena_used(const crisp_arena *arena);
/* Right after a reset: make the first block hold at least `bytes`, so a frame that allocates no
 * more than that in total allocates nothing from the system (for per-worker arenas whose share
 * of a frame's work varies with scheduling). */
crisp_status crisp_arena_reserve(crisp_arena *arena, size_t bytes);

/* ---- vectors and matrices (double) ----------------------------------------------------------- */

typedef double crisp_vec2[2];
typedef double crisp_vec3[3];
typedef double crisp_vec4[4];
/* column-major: m[col][row]. Inputs are not const-qualified: C11 forbids passing double[4][4]
 * to const double (*)[4] without a cast (cglm does the same). */
typedef double crisp_mat4[4][4];

void crisp_vec2_sub(const crisp_vec2 a, const crisp_vec2 b, crisp_vec2 dest);
double crisp_vec2_dot(const crisp_vec2 a, const crisp_vec2 b);
double crisp_vec2_cross(const crisp_vec2 a, const crisp_vec2 b);
double crisp_vec2_norm(const crisp_vec2 a);

void crisp_vec3_add(const crisp_vec3 a, const crisp_vec3 b, crisp_vec3 dest);
void crisp_vec3_sub(const crisp_vec3 a, const crisp_vec3 b, crisp_vec3 dest);
void crisp_vec3_scale(const crisp_vec3 a, double s, crisp_vec3 dest);
double crisp_vec3_dot(const crisp_vec3 a, const crisp_vec3 b);
void crisp_vec3_cross(const crisp_vec3 a, const crisp_vec3 b, crisp_vec3 dest);
double crisp_vec3_norm(const crisp_vec3 a);
/* Unit vector; returns 0 (and leaves dest zero) when a has no length. */
int crisp_vec3_normalize(const crisp_vec3 a, crisp_vec3 dest);

void crisp_vec4_scale(const crisp_vec4 a, double s, crisp_vec4 dest);
double crisp_vec4_dot(const crisp_vec4 a, const crisp_vec4 b);

void crisp_mat4_identity(crisp_mat4 dest);
void crisp_mat4_copy(crisp_mat4 m, crisp_mat4 dest);
/* dest = a * b (dest may alias a or b). */
void crisp_mat4_mul(crisp_mat4 a, crisp_mat4 b, crisp_mat4 dest);
void crisp_mat4_mulv(crisp_mat4 m, const crisp_vec4 v, crisp_vec4 dest);
/* Point (w = 1) transformed without the division. */
void crisp_mat4_mulp(crisp_mat4 m, const crisp_vec3 p, crisp_vec4 dest);
void crisp_mat4_transpose(crisp_mat4 m, crisp_mat4 dest);
/* Returns 0 when m is singular (dest untouched). */
int crisp_mat4_inverse(crisp_mat4 m, crisp_mat4 dest);
/* gluLookAt: right-handed view matrix. Returns 0 when eye == target or up is parallel. */
int crisp_mat4_lookat(const crisp_vec3 eye, const crisp_vec3 target, const crisp_vec3 up,
                      crisp_mat4 dest);
/* gluPerspective: fovy in degrees, aspect = width / height, OpenGL clip space (z in [-w, w]). */
void crisp_mat4_perspective(double fovy_deg, double aspect, double znear, double zfar,
                            crisp_mat4 dest);

/* ---- thread pool ----------------------------------------------------------------------------- */

typedef struct crisp_pool crisp_pool;

/* Work callback for items [begin, end); worker is 0..threads-1 (the caller is worker 0). */
typedef void (*crisp_pool_fn)(void *ctx, size_t begin, size_t end, int worker);

/* Threads from CRISP_THREADS if set (>= 1), else the number of online processors. */
int crisp_pool_default_threads(void);
/* threads <= 0 means crisp_pool_default_threads(). The calling thread counts as one worker. */
crisp_status crisp_pool_create(int threads, crisp_pool **dest);
void crisp_pool_destroy(crisp_pool *pool);
int crisp_pool_threads(const crisp_pool *pool);
/* Run fn over [0, count) in chunks of grain items handed out dynamically; returns when all are
 * done. pool may be NULL (runs inline). A call from inside fn on the same pool runs inline;
 * calls from several threads take turns. When fn raised an error (crisp_error) on a worker
 * thread and none on the calling thread, the first such message becomes the calling thread's
 * crisp_error_message(), so the status collected from the workers comes with its message.
 * The calling thread reports the share of items done to crisp_progress_report. */
void crisp_pool_parallel_for(crisp_pool *pool, size_t count, size_t grain, crisp_pool_fn fn,
                             void *ctx);
/* The process-wide pool (created on first use with the default thread count). NULL if creation
 * failed; crisp_pool_parallel_for then runs inline. */
crisp_pool *crisp_pool_shared(void);
/* A pool of `threads` threads kept for the whole process (threads <= 0 or the default count:
 * the shared pool; 1: NULL, which runs inline). For renderers called per frame: no threads are
 * started per call. The pool is owned by crisp; do not destroy it. */
crisp_status crisp_pool_get(int threads, crisp_pool **dest);

/* ---- progress -------------------------------------------------------------------------------- */

/* Receives the share done (0..1) of the current piece of long work (a pool job, a reader). It
 * is called on the thread doing the work, often: keep it cheap (a progress bar redraws a few
 * times a second). Process-wide; NULL switches it off. */
typedef void (*crisp_progress_fn)(void *ctx, double fraction);
void crisp_progress_set(crisp_progress_fn fn, void *ctx);
/* For single-threaded long work (readers, meshing): report the share done. */
void crisp_progress_report(double fraction);

/* ---- time ------------------------------------------------------------------------------------ */

/* Monotonic seconds since an arbitrary origin. */
double crisp_time_now(void);
uint64_t crisp_time_ns(void);

#ifdef __cplusplus
}
#endif
#endif
