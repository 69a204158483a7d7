/* crisp frep: implicit (f-rep) solids. A part is a function f(X, Y, Z) that is negative inside.
 * Follows Keeter's 2012 MIT solver (interval arithmetic, recursive subdivision, branch caching,
 * z-culled heightmaps) with the tape design of Fidget / MPR (SSA tape, per-cell shortening).
 *
 * Offers:
 *   crisp_frep, crisp_frep_node      a hash-consed expression DAG (constant folding, identities)
 *   crisp_frep_create/_destroy, crisp_frep_const, _var, _unary, _binary, _set_root, _root
 *   crisp_frep_eval_graph            reference point evaluation straight on the DAG (tests)
 *   crisp_frep_tape                  the linear, register-allocated tape
 *   crisp_frep_tape_create/_destroy, _length, _registers
 *   crisp_frep_eval_point/_batch/_interval/_grad    float, interval and derivative evaluators
 *   crisp_frep_renderer              2D images and 3D heightmaps by interval subdivision
 *   crisp_frep_shade                 the shaded 8-bit picture of a 3D heightmap
 *   crisp_frep_fit_region/_check     a box covering the part, by interval subdivision
 *   crisp_frep_read_vm/_vm_mem, crisp_frep_read_math/_math_mem   readers (built in src/io/frep)
 *
 * Semantics are those of the .vm format (data/README.md): 32-bit float arithmetic; min and max
 * return NaN when either input is NaN; a point is inside when f < 0 (NaN is outside).
 */
#ifndef CRISP_FREP_H
#define CRISP_FREP_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- expressions ----------------------------------------------------------------------------- */

typedef enum crisp_frep_op {
    CRISP_FREP_CONST,
    CRISP_FREP_X,
    CRISP_FREP_Y,
    CRISP_FREP_Z,
    /* one argument */
    CRISP_FREP_NEG,
    CRISP_FREP_ABS,
    CRISP_FREP_SQRT,
    CRISP_FREP_SQUARE,
    CRISP_FREP_FLOOR,
    CRISP_FREP_CEIL,
    CRISP_FREP_ROUND,
    CRISP_FREP_SIN,
    CRISP_FREP_COS,
    CRISP_FREP_TAN,
    CRISP_FREP_ASIN,
    CRISP_FREP_ACOS,
    CRISP_FREP_ATAN,
    CRISP_FREP_EXP,
    CRISP_FREP_LN,
    CRISP_FREP_NOT, /* 1 if a == 0 else 0 */
    /* two arguments (a then b) */
    CRISP_FREP_ADD,
    CRISP_FREP_SUB,
    CRISP_FREP_MUL,
    CRISP_FREP_DIV,
    CRISP_FREP_ATAN2, /* atan2(a, b), a is y */
    CRISP_FREP_MIN,
    CRISP_FREP_MAX,
    CRISP_FREP_COMPARE, /* -1, 0, +1, NaN if unordered */
    CRISP_FREP_MOD,     /* Euclidean: result in [0, |b|) */
    CRISP_FREP_AND,     /* a if a == 0 else b */
    CRISP_FREP_OR,      /* a if a != 0 else b */
    CRISP_FREP_OP_COUNT
} crisp_frep_op;

/* Number of arguments of an op (0, 1 or 2). */
int crisp_frep_op_arity(crisp_frep_op op);
/* The .vm spelling of an op ("add", "var-x", ...). */
const char *crisp_frep_op_name(crisp_frep_op op);

/* A node of the DAG: an index into its crisp_frep. */
typedef uint32_t crisp_frep_node;

typedef struct crisp_frep crisp_frep;

crisp_status crisp_frep_create(crisp_frep **dest);
void crisp_frep_destroy(crisp_frep *f);
/* Node constructors. Equal nodes are merged (hash-consing, with a canonical argument order for
 * + * min max); constants are folded with the evaluators' own float semantics; identities that
 * keep every float result are applied (x*1, x/1, x*-1 -> -x, x*x -> square, min(x,x), --x,
 * |-x| -> |x|, a-c -> a+(-c), a+(-b) -> a-b), and x+0 -> x, which can differ only in the sign of
 * a zero result. */
crisp_status crisp_frep_const(crisp_frep *f, float value, crisp_frep_node *dest);
/* axis 0, 1, 2 = X, Y, Z */
crisp_status crisp_frep_var(crisp_frep *f, int axis, crisp_frep_node *dest);
crisp_status crisp_frep_unary(crisp_frep *f, crisp_frep_op op, crisp_frep_node a,
                              crisp_frep_node *dest);
crisp_status crisp_frep_binary(crisp_frep *f, crisp_frep_op op, crisp_frep_node a,
                               crisp_frep_node b, crisp_frep_node *dest);
void crisp_frep_set_root(crisp_frep *f, crisp_frep_node root);
crisp_frep_node crisp_frep_root(const crisp_frep *f);
/* 1 and the value in *value when node n is a constant, else 0. */
int crisp_frep_node_constant(const crisp_frep *f, crisp_frep_node n, float *value);
/* Nodes in the DAG (after merging). */
size_t crisp_frep_node_count(const crisp_frep *f);
/* The value of the root at one point, evaluated node by node on the DAG in float (a reference
 * that shares no code path with the tape). Allocates; returns NaN when out of memory. */
float crisp_frep_eval_graph(const crisp_frep *f, float x, float y, float z);

/* ---- tape ------------------------------------------------------------------------------------ */

typedef struct crisp_frep_tape crisp_frep_tape;

/* Flatten the nodes reachable from the root into a linear SSA tape with registers reused.
 * CRISP_ERR_LIMIT when more than 65535 values are live at once. */
crisp_status crisp_frep_tape_create(const crisp_frep *f, crisp_frep_tape **dest);
void crisp_frep_tape_destroy(crisp_frep_tape *t);
size_t crisp_frep_tape_length(const crisp_frep_tape *t);
int crisp_frep_tape_registers(const crisp_frep_tape *t);

/* One point, float. */
float crisp_frep_eval_point(const crisp_frep_tape *t, float x, float y, float z);
/* n points (any n), float, in batches. */
crisp_status crisp_frep_eval_batch(const crisp_frep_tape *t, size_t n, const float *x,
                                   const float *y, const float *z, float *dest);
/* An interval enclosing the float value of every point of the box [x]x[y]x[z] (each lo <= hi).
 * When some point may give NaN or an infinity, lo and hi are both NaN ("unknown"). */
void crisp_frep_eval_interval(const crisp_frep_tape *t, const float x[2], const float y[2],
                              const float z[2], float dest[2]);
/* n points: value and gradient, dest[4*i .. 4*i+3] = f, df/dx, df/dy, df/dz. */
crisp_status crisp_frep_eval_grad(const crisp_frep_tape *t, size_t n, const float *x,
                                  const float *y, const float *z, float *dest);

/* ---- renderer -------------------------------------------------------------------------------- */

enum {
    CRISP_FREP_NO_PRUNE = 1u << 0,   /* interval subdivision without shortening the tape */
    CRISP_FREP_NO_BATCH = 1u << 1,   /* leaves evaluate one point at a time */
    CRISP_FREP_BRUTE = 1u << 2,      /* no subdivision: every sample in batches on the full tape */
    CRISP_FREP_NO_SUBCELLS = 1u << 3 /* 3D leaves skip the batched intervals of their sub-cells */
};

typedef struct crisp_frep_render_desc {
    int width, height; /* pixels, >= 1 */
    int depth;         /* 0: 2D image; > 0: 3D heightmap of this many voxels in Z */
    /* x0, x1, y0, y1, z0, z1; all zero means [-1, 1] on every axis */
    double region[6];
    int threads;    /* <= 0: crisp_pool_default_threads() */
    unsigned flags; /* CRISP_FREP_NO_PRUNE ... (for measuring each optimisation) */
    /* x0, y0, w, h: render only this window of the width x height image (issue 15, image
     * tiles): the renderer's image is w x h and its pixel (i, j) samples pixel (x0 + i, y0 + j)
     * of the whole image, at the same float coordinates. All zero: the whole image. */
    int window[4];
} crisp_frep_render_desc;

/* Pixel (i, j), j = 0 the top row, samples x = x0 + (i+0.5)(x1-x0)/W, y = y1 - (j+0.5)(y1-y0)/H
 * (rounded to float); voxel k samples z = z0 + (k+0.5)(z1-z0)/D. */
typedef struct crisp_frep_image {
    int width, height, depth;
    uint8_t *inside;  /* W*H: 255 inside (2D) or hit (3D), else 0 */
    int32_t *heights; /* 3D: W*H voxel index of the topmost inside voxel, -1 for none */
    float *z;         /* 3D: W*H sample z of that voxel, -inf for none */
    float *normal;    /* 3D: 3*W*H unit normal (gradient direction), 0 for none */
} crisp_frep_image;

typedef struct crisp_frep_render_stats {
    size_t intervals; /* interval evaluations of cells */
    size_t filled;    /* cells decided by one interval (inside or outside) */
    size_t leaves;    /* leaf cells evaluated point by point */
    size_t points;    /* points evaluated in leaves */
    size_t culled;    /* 3D cells skipped by z-culling */
    size_t tape_sum;  /* sum of leaf tape lengths (mean = tape_sum / leaves) */
} crisp_frep_render_stats;

typedef struct crisp_frep_renderer crisp_frep_renderer;

/* Allocates the image, the per-worker scratch and the thread pool once; tape must outlive it. */
crisp_status crisp_frep_renderer_create(const crisp_frep_tape *tape,
                                        const crisp_frep_render_desc *desc,
                                        crisp_frep_renderer **dest);
void crisp_frep_renderer_destroy(crisp_frep_renderer *r);
/* Render (again) into the renderer's image. */
crisp_status crisp_frep_renderer_run(crisp_frep_renderer *r);
const crisp_frep_image *crisp_frep_renderer_image(const crisp_frep_renderer *r);
/* The 8-bit shading of a 3D image (the CLI's PNG): Lambert shading of the normals by a light up
 * and to the upper left of the viewer, 40 + 215 max(n.l, 0) where hit, 0 elsewhere; dest holds
 * width x height bytes. */
void crisp_frep_shade(const crisp_frep_image *img, uint8_t *dest);
/* Counters of the last run. */
crisp_frep_render_stats crisp_frep_renderer_stats(const crisp_frep_renderer *r);

/* ---- region fit ---------------------------------------------------------------------------- */

typedef struct crisp_frep_fit_desc {
    /* the box searched; all zero: cubes [-R, R]^3 for R = 2, 8, 32, ..., 1024 in turn, the
     * first that holds a bounded fit (except on free_axes) is taken */
    double search[6];
    unsigned free_axes;   /* bit a: axis a may be unbounded (a 2D model seen in 3D) */
    int planar;           /* 1: fit x and y only, on the plane z = (z0 + z1) / 2 (2D images) */
    size_t max_intervals; /* interval evaluations per search box; 0: 2e6 */
} crisp_frep_fit_desc;

typedef struct crisp_frep_fit {
    double box[6];      /* x0, x1, y0, y1, z0, z1: every point not proven outside lies inside */
    double cell;        /* edge of the finest octree cells (the fit's resolution) */
    unsigned unbounded; /* bit a: the part reaches the search box on axis a */
    unsigned unknown;   /* bit a: ... and the function is NaN there (an undefined expression) */
    int empty;          /* every point of the search box is proven outside */
    int overflow;       /* the octree ran out of intervals (the fit is still conservative) */
    size_t sampled;     /* cells with a NaN interval decided by sample points (a guess) */
    size_t intervals;   /* interval evaluations spent */
    double search[6];   /* the search box that gave the fit */
} crisp_frep_fit;

/* The bounding box of the part (f < 0) within the search box, by interval subdivision: the
 * octree cells not proven outside (region.c). CRISP_ERR_NUMERIC with a message when the
 * part is proven empty (dest->empty = 1). Axes that reach the search box are flagged in
 * dest->unbounded, not refused: see crisp_frep_fit_check. */
crisp_status crisp_frep_fit_region(const crisp_frep_tape *t, const crisp_frep_fit_desc *desc,
                                   crisp_frep_fit *dest);
/* CRISP_ERR_NUMERIC with a message naming the axis when the fit is unbounded (or undefined:
 * NaN) on an axis whose bit is not in allowed_unbounded, else CRISP_OK. */
crisp_status crisp_frep_fit_check(const crisp_frep_fit *fit, unsigned allowed_unbounded);

/* ---- readers (src/io/frep) ------------------------------------------------------------------- */

/* The .vm text format (data/README.md). name is used in messages ("name:line:col: ..."). */
crisp_status crisp_frep_read_vm(const char *path, crisp_frep **dest);
crisp_status crisp_frep_read_vm_mem(const char *name, const char *data, size_t size,
                                    crisp_frep **dest);
/* Infix math strings (docs/design.md section 7): X Y Z, numbers, pi, + - * / ^, unary minus, sqrt
 * abs exp log sin cos tan asin acos atan atan2 pow min max, < <= > >= == !=, && || !, parentheses.
 * Precedence: unary, ^ (right-associative), * /, + -, comparisons, &&, ||. Logic becomes the
 * distance form: a < b -> a - b, a > b -> b - a, && -> max, || -> min, ! -> negation. */
crisp_status crisp_frep_read_math(const char *path, crisp_frep **dest);
crisp_status crisp_frep_read_math_mem(const char *name, const char *data, size_t size,
                                      crisp_frep **dest);

#ifdef __cplusplus
}
#endif
#endif
