/* Tests of the f-rep solver: readers, DAG, tape, evaluators and renderer against brute force and
 * the bundled prospero reference image (data/frep/ref). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <zlib.h>

#include "crisp/frep.h"
#include "frep/frep_internal.h"
#include "frep/frep_brute.h"

static const char *const models[] = {"bear", "colonnade", "tanglecube",
                                     "hi",   "quarter",   "prospero"};
#define NMODELS (sizeof models / sizeof models[0])

static crisp_frep *load_vm(const char *name)
{
    char path[512];
    snprintf(path, sizeof path, "%s/frep/%s.vm", CRISP_DATA_DIR, name);
    crisp_frep *f = NULL;
    crisp_status s = crisp_frep_read_vm(path, &f);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    return f;
}

static crisp_frep *parse_math(const char *text)
{
    crisp_frep *f = NULL;
    crisp_status s = crisp_frep_read_math_mem("test", text, strlen(text), &f);
    if (s) fprintf(stderr, "%s\n", crisp_error_message());
    assert_int_equal(s, CRISP_OK);
    return f;
}

static float math_at(const char *text, float x, float y, float z)
{
    crisp_frep *f = parse_math(text);
    crisp_frep_tape *t = NULL;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    float v = crisp_frep_eval_point(t, x, y, z);
    /* the tape and the DAG agree */
    float g = crisp_frep_eval_graph(f, x, y, z);
    assert_true(v == g || (v != v && g != g));
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
    return v;
}

static crisp_frep_renderer *render(const crisp_frep_tape *t, int w, int depth, int threads,
                                   unsigned flags)
{
    crisp_frep_render_desc d = {
        .width = w, .height = w, .depth = depth, .threads = threads, .flags = flags};
    crisp_frep_renderer *r = NULL;
    assert_int_equal(crisp_frep_renderer_create(t, &d, &r), CRISP_OK);
    assert_int_equal(crisp_frep_renderer_run(r), CRISP_OK);
    return r;
}

/* ---- readers --------------------------------------------------------------------------------- */

static void test_math_values(void **state)
{
    (void)state;
    assert_float_equal(math_at("2+3*4", 0, 0, 0), 14, 0);
    assert_float_equal(math_at("(2+3)*4", 0, 0, 0), 20, 0);
    assert_float_equal(math_at("2^3^2", 0, 0, 0), 512, 0); /* right-associative */
    assert_float_equal(math_at("-2^2", 0, 0, 0), 4, 0);    /* unary binds tightest */
    assert_float_equal(math_at("10-4-3", 0, 0, 0), 3, 0);
    assert_float_equal(math_at("8/4/2", 0, 0, 0), 1, 0);
    assert_float_equal(math_at("X*X + Y*Y - 1", 0.5f, 0.5f, 0), -0.5f, 1e-7);
    assert_float_equal(math_at("sqrt(X^2+Y^2+Z^2) - 1", 1, 2, 2), 2, 1e-6);
    assert_float_equal(math_at("max(X, Y, Z)", 1, 3, 2), 3, 0);
    assert_float_equal(math_at("min(X, -Y)", 1, 3, 2), -3, 0);
    assert_float_equal(math_at("atan2(1, 0)", 0, 0, 0), (float)M_PI / 2, 1e-6);
    assert_float_equal(math_at("pow(X, 0.5)", 4, 0, 0), 2, 0);
    assert_float_equal(math_at("pow(X, 2.5)", 4, 0, 0), 32, 1e-4);
    assert_float_equal(math_at("X^-2", 2, 0, 0), 0.25f, 0);
    assert_float_equal(math_at("pi", 0, 0, 0), (float)M_PI, 0);
    assert_float_equal(math_at("1.5e2 + .5", 0, 0, 0), 150.5f, 0);
    /* distance form of logic: inside (< 0) exactly where the condition holds */
    assert_float_equal(math_at("X < 2", 1, 0, 0), -1, 0);
    assert_float_equal(math_at("X > 2", 1, 0, 0), 1, 0);
    assert_true(math_at("X < 0 && Y < 0", -1, -2, 0) < 0);
    assert_true(math_at("X < 0 && Y < 0", -1, 2, 0) > 0);
    assert_true(math_at("X < 0 || Y < 0", 1, -2, 0) < 0);
    assert_true(math_at("!(X < 0)", 1, 0, 0) < 0);
    assert_true(math_at("X*X + Y*Y < 1 && !(X > 0)", -0.5f, 0, 0) < 0);
    assert_true(math_at("X < 1 && Y < 1 || Z < 0", 2, 2, -1) < 0); /* && before || */
    assert_true(math_at("X + 1 < 2 * Y", 0, 1, 0) < 0);            /* arithmetic before < */
}

static void expect_error(const char *text, const char *fragment, int vm)
{
    crisp_frep *f = NULL;
    crisp_status s = vm ? crisp_frep_read_vm_mem("in", text, strlen(text), &f)
                        : crisp_frep_read_math_mem("in", text, strlen(text), &f);
    if (s == CRISP_OK) fprintf(stderr, "expected an error for '%s'\n", text);
    assert_int_not_equal(s, CRISP_OK);
    assert_null(f);
    const char *m = crisp_error_message();
    if (!strstr(m, fragment)) fprintf(stderr, "message '%s' lacks '%s'\n", m, fragment);
    assert_non_null(strstr(m, fragment));
}

static void test_math_errors(void **state)
{
    (void)state;
    expect_error("", "in:1:1: expected", 0);
    expect_error("1 +", "in:1:4: expected a number", 0);
    expect_error("X + foo(1)", "in:1:5: unknown name 'foo'", 0);
    expect_error("(X + 1", "in:1:1: '(' is never closed", 0);
    expect_error("X + 1)", "in:1:6: ')' without", 0);
    expect_error("X\n  + * 2", "in:2:5: expected a number", 0);
    expect_error("sqrt(1, 2)", "'sqrt' expects 1 argument", 0);
    expect_error("max(1)", "at least 2", 0);
    expect_error("2 X", "in:1:3: expected an operator", 0);
    expect_error("sqrt 2", "expected '(' after 'sqrt'", 0);
    expect_error("1, 2", "',' without", 0);
    expect_error("(1, 2)", "',' outside", 0);
    expect_error("X = 1", "expected an operator", 0);
}

static void test_vm_errors(void **state)
{
    (void)state;
    expect_error("", "no instructions", 1);
    expect_error("# only a comment\n\n   \n", "no instructions", 1);
    expect_error("_0 var-x\n_1 frobnicate _0\n", "in:2:4: unknown opcode 'frobnicate'", 1);
    expect_error("_0 var-x\n_1 add _0 _9\n", "in:2:11: undefined ID '_9'", 1);
    expect_error("_0 add _0 _0\n", "in:1:8: undefined ID '_0'",
                 1); /* no cycles: only earlier IDs */
    expect_error("_0 var-x _1\n", "'var-x' expects 0 arguments", 1);
    expect_error("_0 const\n", "'const' expects 1 argument", 1);
    expect_error("_0 const 1.5x\n", "in:1:10: expected a number", 1);
    expect_error("_0\n", "expected an opcode", 1);
    expect_error("_0 var-x\n_1 neg _0 _0 _0 _0\n", "at most 2 arguments", 1);
}

static void test_vm_semantics(void **state)
{
    (void)state;
    /* redefinition: the latest definition wins; comments and blank lines are skipped */
    const char *text =
        "# c\n_0 var-x\n\n_1 const 2\n_0 mul _0 _1\n  # indented comment\n_2 sub _0 _1\n";
    crisp_frep *f = NULL;
    assert_int_equal(crisp_frep_read_vm_mem("in", text, strlen(text), &f), CRISP_OK);
    assert_float_equal(crisp_frep_eval_graph(f, 3, 0, 0), 4, 0);
    crisp_frep_destroy(f);
    /* NaN and inf constants and division by zero everywhere: defined results, nothing inside */
    const char *bad[] = {"_0 const nan\n", "_0 const inf\n",
                         "_0 const -inf\n_1 var-x\n_2 mul _0 _1\n",
                         "_0 var-x\n_1 sub _0 _0\n_2 const 1\n_3 div _2 _1\n",
                         "_0 var-x\n_1 sub _0 _0\n_2 div _1 _1\n_3 sqrt _0\n_4 min _2 _3\n"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        assert_int_equal(crisp_frep_read_vm_mem("in", bad[i], strlen(bad[i]), &f), CRISP_OK);
        crisp_frep_tape *t = NULL;
        assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
        crisp_frep_renderer *r = render(t, 64, 0, 2, 0);
        const crisp_frep_image *img = crisp_frep_renderer_image(r);
        uint8_t *ref = brute_2d(t, 64);
        size_t inside = 0;
        for (size_t p = 0; p < 64 * 64; p++) {
            assert_int_equal(img->inside[p], ref[p]);
            inside += img->inside[p] != 0;
        }
        /* -inf * x is < 0 where x > 0 (half the image); the others are NaN or >= 0 */
        assert_int_equal(inside, i == 2 ? 64 * 32 : 0);
        free(ref);
        crisp_frep_renderer_destroy(r);
        crisp_frep_tape_destroy(t);
        crisp_frep_destroy(f);
    }
}

static void test_dag(void **state)
{
    (void)state;
    crisp_frep *f;
    assert_int_equal(crisp_frep_create(&f), CRISP_OK);
    crisp_frep_node x, y, a, b, c, one, two;
    crisp_frep_var(f, 0, &x);
    crisp_frep_var(f, 1, &y);
    crisp_frep_binary(f, CRISP_FREP_ADD, x, y, &a);
    crisp_frep_binary(f, CRISP_FREP_ADD, y, x, &b);
    assert_int_equal(a, b); /* hash-consing, commutative order */
    crisp_frep_const(f, 1, &one);
    crisp_frep_const(f, 2, &two);
    crisp_frep_binary(f, CRISP_FREP_ADD, one, two, &c);
    float v;
    assert_true(crisp_frep_node_constant(f, c, &v));
    assert_float_equal(v, 3, 0); /* folded */
    crisp_frep_binary(f, CRISP_FREP_MUL, a, one, &c);
    assert_int_equal(c, a); /* x * 1 */
    crisp_frep_binary(f, CRISP_FREP_MIN, a, a, &c);
    assert_int_equal(c, a); /* min(x, x) */
    crisp_frep_unary(f, CRISP_FREP_NEG, a, &c);
    crisp_frep_unary(f, CRISP_FREP_NEG, c, &c);
    assert_int_equal(c, a); /* --x */
    size_t n = crisp_frep_node_count(f);
    crisp_frep_binary(f, CRISP_FREP_ADD, x, y, &c);
    assert_int_equal(crisp_frep_node_count(f), n);
    crisp_frep_destroy(f);

    /* prospero: merging leaves fewer nodes than lines, the tape reuses registers */
    f = load_vm("prospero");
    assert_true(crisp_frep_node_count(f) < 7866 + 200);
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    assert_true(crisp_frep_tape_registers(t) < 1000);
    assert_true(crisp_frep_tape_length(t) <= crisp_frep_node_count(f));
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

static void test_big_expressions(void **state)
{
    (void)state;
    /* a million nested parentheses and a sum of half a million distinct terms: no recursion */
    size_t depth = 1000000;
    char *s = malloc(2 * depth + 8);
    memset(s, '(', depth);
    s[depth] = 'X';
    memset(s + depth + 1, ')', depth);
    s[2 * depth + 1] = 0;
    assert_float_equal(math_at(s, 0.25f, 0, 0), 0.25f, 0);
    free(s);
    size_t terms = 500000;
    s = malloc(terms * 24 + 8);
    size_t len = 0;
    for (size_t k = 0; k < terms; k++)
        len += (size_t)sprintf(s + len, "%sX*%zu", k ? "+" : "", k + 2);
    crisp_frep *f = parse_math(s);
    assert_true(crisp_frep_node_count(f) >= terms);
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    assert_true(isfinite(crisp_frep_eval_point(t, 1e-6f, 0, 0)));
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
    free(s);
}

/* ---- evaluators ------------------------------------------------------------------------------ */

static uint64_t rng_state = 0x9E3779B97F4A7C15ull;
static uint32_t rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (uint32_t)(rng_state >> 11);
}
static float rndf(float a, float b)
{
    return a + (b - a) * (float)(rnd() % 1000001) / 1000000.0f;
}

/* A random expression of about n nodes over every op. */
static crisp_frep *random_expr(int n)
{
    crisp_frep *f;
    crisp_frep_create(&f);
    crisp_frep_node *pool = malloc((size_t)(n + 8) * sizeof *pool);
    int m = 0;
    for (int a = 0; a < 3; a++)
        crisp_frep_var(f, a, &pool[m++]);
    crisp_frep_const(f, rndf(-2, 2), &pool[m++]);
    crisp_frep_const(f, 0.5f, &pool[m++]);
    while (m < n) {
        int op = CRISP_FREP_NEG + (int)(rnd() % (CRISP_FREP_OP_COUNT - CRISP_FREP_NEG));
        /* favour recent nodes so the expression is deep */
        crisp_frep_node a = pool[m - 1 - (int)(rnd() % (unsigned)(m < 6 ? m : 6))];
        crisp_frep_node b = pool[rnd() % (unsigned)m];
        crisp_frep_node r;
        if (rnd() % 8 == 0) crisp_frep_const(f, rndf(-3, 3), &b);
        crisp_status s = crisp_frep_op_arity(op) == 1 ? crisp_frep_unary(f, op, a, &r)
                                                      : crisp_frep_binary(f, op, a, b, &r);
        assert_int_equal(s, CRISP_OK);
        pool[m++] = r;
    }
    crisp_frep_set_root(f, pool[m - 1]);
    free(pool);
    return f;
}

static int same(float a, float b)
{
    return a == b || (a != a && b != b);
}

static void test_interval_soundness(void **state)
{
    (void)state;
    size_t checked = 0, unknown = 0, decided = 0, pruned = 0;
    for (int e = 0; e < 400; e++) {
        crisp_frep *f = random_expr(4 + (int)(rnd() % 40));
        crisp_frep_tape *t;
        assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
        size_t len = t->length;
        float *lo = calloc((size_t)t->registers * 2, sizeof *lo), *hi = lo + t->registers;
        float *regs = calloc((size_t)t->registers, sizeof *regs);
        uint8_t *choices = calloc(len, 1);
        frep_ins *sins = malloc(2 * len * sizeof *sins), *pins = malloc(2 * len * sizeof *pins);
        uint32_t *sssa = malloc(4 * len * sizeof *sssa), *pssa = malloc(4 * len * sizeof *pssa);
        frep_shorten_scratch sc;
        assert_int_equal(crisp__frep_scratch_init(&sc, len, t->registers), CRISP_OK);
        frep_span full = {t->ins, t->ssa, len, t->registers};
        for (int b = 0; b < 20; b++) {
            float scale = rnd() % 2 ? 0.01f : 4.0f;
            float box[3][2], sub[3][2];
            for (int a = 0; a < 3; a++) {
                float c = rndf(-3, 3), w = rndf(0, scale);
                box[a][0] = c - w;
                box[a][1] = c + w;
                /* a sub-box for a second, nested shortening */
                float u = rndf(box[a][0], box[a][1]), v = rndf(box[a][0], box[a][1]);
                sub[a][0] = u < v ? u : v;
                sub[a][1] = u < v ? v : u;
            }
            size_t d = crisp__frep_interval(t->ins, len, lo, hi, box[0], box[1], box[2], choices);
            float l = lo[t->result], h = hi[t->result];
            decided += d > 0;
            frep_span s1, s2, p1, p2;
            /* pruned (no register reallocation), then shortened on the sub-box (which renames
             * the pruned tape's copies away) */
            crisp__frep_prune(full, choices, &sc, pins, pssa, &p1);
            assert_true(p1.len <= len && p1.registers == t->registers);
            crisp__frep_interval(p1.ins, p1.len, lo, hi, sub[0], sub[1], sub[2], choices);
            int okp = crisp__frep_shorten(p1, choices, &sc, pins + len, pssa + 2 * len, &p2) == 0;
            crisp__frep_interval(t->ins, len, lo, hi, box[0], box[1], box[2], choices);
            int ok1 = crisp__frep_shorten(full, choices, &sc, sins, sssa, &s1) == 0;
            int ok2 = 0;
            if (ok1) {
                assert_true(s1.len <= len && s1.registers <= t->registers);
                crisp__frep_interval(s1.ins, s1.len, lo, hi, sub[0], sub[1], sub[2], choices);
                ok2 = crisp__frep_shorten(s1, choices, &sc, sins + len, sssa + 2 * len, &s2) == 0;
            }
            if (l != l) {
                assert_true(h != h);
                unknown++;
            } else {
                assert_true(l <= h);
            }
            for (int s = 0; s < 30; s++) {
                float p[3], q[3];
                for (int a = 0; a < 3; a++) {
                    p[a] = s < 8 ? box[a][(s >> a) & 1] : rndf(box[a][0], box[a][1]);
                    q[a] = s < 8 ? sub[a][(s >> a) & 1] : rndf(sub[a][0], sub[a][1]);
                }
                float v = crisp_frep_eval_point(t, p[0], p[1], p[2]);
                if (l == l) {
                    if (!(v >= l && v <= h))
                        fprintf(stderr, "expr %d box %d: %.9g outside [%.9g, %.9g]\n", e, b, v, l,
                                h);
                    assert_true(v >= l && v <= h);
                }
                /* the shortened tapes give the same values inside their boxes */
                if (ok1) {
                    float vs = crisp__frep_eval_scalar(s1.ins, s1.len, s1.ins[s1.len - 1].out, regs,
                                                       p[0], p[1], p[2]);
                    assert_true(same(v, vs));
                }
                float vp = crisp__frep_eval_scalar(p1.ins, p1.len, p1.ins[p1.len - 1].out, regs,
                                                   p[0], p[1], p[2]);
                assert_true(same(v, vp));
                if (okp) {
                    float vq = crisp_frep_eval_point(t, q[0], q[1], q[2]);
                    float vs = crisp__frep_eval_scalar(p2.ins, p2.len, p2.ins[p2.len - 1].out, regs,
                                                       q[0], q[1], q[2]);
                    assert_true(same(vq, vs));
                    pruned += p2.len < p1.len;
                }
                if (ok2) {
                    float vq = crisp_frep_eval_point(t, q[0], q[1], q[2]);
                    float vs = crisp__frep_eval_scalar(s2.ins, s2.len, s2.ins[s2.len - 1].out, regs,
                                                       q[0], q[1], q[2]);
                    assert_true(same(vq, vs));
                }
                checked++;
            }
        }
        free(lo), free(regs), free(choices), free(sins), free(sssa), free(pins), free(pssa);
        crisp__frep_scratch_free(&sc);
        crisp_frep_tape_destroy(t);
        crisp_frep_destroy(f);
    }
    /* the property was tested on many decided boxes, not only on unknown ones */
    assert_true(unknown < 8000 * 3 / 4);
    assert_true(decided > 100);
    assert_true(pruned > 100);
    assert_true(checked == 400 * 20 * 30);
}

/* The batched interval evaluator gives every lane the scalar evaluator's bounds (equal values)
 * and min/max choices, after every instruction of random expressions over every op, on boxes
 * wide and narrow, thin (a point), spanning zero, far out and with infinite or NaN ends. */
static void test_interval_lanes_match(void **state)
{
    (void)state;
    enum { L = FREP_LANES };
    size_t compared = 0, known = 0, choices = 0;
    for (int e = 0; e < 300; e++) {
        crisp_frep *f = random_expr(4 + (int)(rnd() % 40));
        crisp_frep_tape *t;
        assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
        size_t nr = (size_t)t->registers;
        float *lo = calloc(nr * L * 2, sizeof *lo), *hi = lo + nr * L;
        float *slo = calloc(nr * 2, sizeof *slo), *shi = slo + nr;
        float bx[6][L];
        for (int k = 0; k < L; k++) {
            int kind = (int)(rnd() % 8);
            for (int a = 0; a < 3; a++) {
                float c = rndf(-3, 3), w = kind == 0 ? 0 : kind < 4 ? rndf(0, 0.05f) : rndf(0, 4);
                if (kind == 5) c *= 1e30f;
                bx[2 * a][k] = c - w;
                bx[2 * a + 1][k] = c + w;
            }
            if (kind == 6 && rnd() % 4 == 0) { /* an infinite end */
                int e = (int)(rnd() % 2);
                bx[e][k] = e ? INFINITY : -INFINITY;
            }
            if (kind == 7 && rnd() % 8 == 0) bx[0][k] = bx[1][k] = NAN;
        }
        const float *box[6] = {bx[0], bx[1], bx[2], bx[3], bx[4], bx[5]};
        for (size_t i = 0; i < t->length; i++) {
            uint8_t lch[L];
            size_t ldec[L] = {0};
            memset(lch, 0, sizeof lch);
            crisp__frep_interval_lanes(t->ins + i, 1, L, lo, hi, box, lch, ldec);
            size_t o = t->ins[i].out;
            for (int k = 0; k < L; k++) {
                /* the scalar registers of lane k, restored from the lanes before this step */
                for (size_t g = 0; g < nr; g++) {
                    slo[g] = g == o ? 0 : lo[g * L + k];
                    shi[g] = g == o ? 0 : hi[g * L + k];
                }
                const float x[2] = {bx[0][k], bx[1][k]}, y[2] = {bx[2][k], bx[3][k]},
                            z[2] = {bx[4][k], bx[5][k]};
                uint8_t sch = 0;
                size_t sdec = crisp__frep_interval(t->ins + i, 1, slo, shi, x, y, z, &sch);
                /* the same min/max choices */
                if (frep__is_minmax(t->ins[i].op)) {
                    assert_int_equal(lch[k], sch);
                    assert_int_equal(ldec[k], sdec);
                    choices += sch != FREP_CHOICE_BOTH;
                }
                if (!same(slo[o], lo[o * L + k]) || !same(shi[o], hi[o * L + k]))
                    fprintf(
                        stderr,
                        "expr %d ins %zu op %d lane %d: scalar [%.9g, %.9g] lanes [%.9g, %.9g]\n",
                        e, i, t->ins[i].op, k, slo[o], shi[o], lo[o * L + k], hi[o * L + k]);
                assert_true(same(slo[o], lo[o * L + k]) && same(shi[o], hi[o * L + k]));
                compared++;
                known += slo[o] == slo[o];
            }
        }
        free(lo), free(slo);
        crisp_frep_tape_destroy(t);
        crisp_frep_destroy(f);
    }
    assert_true(compared > 100000);
    assert_true(known > compared / 2);
    assert_true(choices > 1000);
}

static void test_batch_matches_graph(void **state)
{
    (void)state;
    /* random expressions: batch, point, gradient value and DAG evaluation agree bit for bit */
    for (int e = 0; e < 200; e++) {
        crisp_frep *f = random_expr(30);
        crisp_frep_tape *t;
        assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
        enum { N = 100 };
        float x[N], y[N], z[N], v[N], g[4 * N];
        for (int k = 0; k < N; k++)
            x[k] = rndf(-3, 3), y[k] = rndf(-3, 3), z[k] = rndf(-3, 3);
        assert_int_equal(crisp_frep_eval_batch(t, N, x, y, z, v), CRISP_OK);
        assert_int_equal(crisp_frep_eval_grad(t, N, x, y, z, g), CRISP_OK);
        for (int k = 0; k < N; k++) {
            assert_true(same(v[k], crisp_frep_eval_graph(f, x[k], y[k], z[k])));
            assert_true(same(v[k], crisp_frep_eval_point(t, x[k], y[k], z[k])));
            assert_true(same(v[k], g[4 * k]));
        }
        crisp_frep_tape_destroy(t);
        crisp_frep_destroy(f);
    }
    /* gradient of a sphere */
    crisp_frep *f = parse_math("sqrt(X*X + Y*Y + Z*Z) - 1");
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    float x = 0.6f, y = 0, z = 0.8f, g[4];
    crisp_frep_eval_grad(t, 1, &x, &y, &z, g);
    assert_float_equal(g[1], 0.6f, 1e-6);
    assert_float_equal(g[2], 0, 1e-6);
    assert_float_equal(g[3], 0.8f, 1e-6);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

/* ---- renderer -------------------------------------------------------------------------------- */

static void test_prospero_reference(void **state)
{
    (void)state;
    char path[512];
    snprintf(path, sizeof path, "%s/frep/ref/prospero_1024_centers.pgm.gz", CRISP_DATA_DIR);
    gzFile gz = gzopen(path, "rb");
    assert_non_null(gz);
    size_t cap = 1100000;
    uint8_t *buf = malloc(cap);
    int n = gzread(gz, buf, (unsigned)cap);
    gzclose(gz);
    assert_true(n > 1024 * 1024);
    /* "P5\n1024 1024\n255\n" then the pixels */
    int lines = 0;
    size_t off = 0;
    while (lines < 3 && off < (size_t)n)
        lines += buf[off++] == '\n';
    assert_int_equal((size_t)n - off, 1024 * 1024);
    const uint8_t *ref = buf + off;
    size_t ref_inside = 0;
    for (size_t p = 0; p < 1024 * 1024; p++)
        ref_inside += ref[p] != 0;
    assert_int_equal(ref_inside, 132816);

    crisp_frep *f = load_vm("prospero");
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    for (int threads = 2; threads <= 2; threads++) {
        crisp_frep_renderer *r = render(t, 1024, 0, threads, 0);
        const crisp_frep_image *img = crisp_frep_renderer_image(r);
        size_t differ = 0;
        for (int j = 0; j < 1024; j++)
            for (int i = 0; i < 1024; i++) {
                size_t p = (size_t)j * 1024 + (size_t)i;
                if (img->inside[p] == ref[p]) continue;
                /* allowed only where the value is within float rounding of zero */
                float v = crisp_frep_eval_graph(f, -1 + (2 * i + 1) / 1024.0f,
                                                1 - (2 * j + 1) / 1024.0f, 0);
                fprintf(stderr, "pixel (%d, %d) differs, f = %.9g\n", i, j, v);
                assert_true(fabsf(v) < 1e-5f);
                differ++;
            }
        printf(
            "prospero 1024x1024, %d thread(s): %zu pixels differ from the reference (near zero)\n",
            threads, differ);
        assert_true(differ <= 8);
        crisp_frep_renderer_destroy(r);
    }
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
    free(buf);
}

static void check_model_2d(const char *name, unsigned flags)
{
    crisp_frep *f = load_vm(name);
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    uint8_t *ref = brute_2d(t, 256);
    crisp_frep_renderer *r = render(t, 256, 0, 2, flags);
    const crisp_frep_image *img = crisp_frep_renderer_image(r);
    size_t differ = 0, inside = 0;
    for (size_t p = 0; p < 256 * 256; p++)
        differ += img->inside[p] != ref[p], inside += ref[p] != 0;
    if (differ) fprintf(stderr, "%s 2D (flags %u): %zu pixels differ\n", name, flags, differ);
    assert_int_equal(differ, 0);
    free(ref);
    crisp_frep_renderer_destroy(r);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

static void test_models_2d(void **state)
{
    (void)state;
    for (size_t m = 0; m < NMODELS; m++)
        check_model_2d(models[m], 0);
    /* each optimisation switched off gives the same image */
    check_model_2d("hi", CRISP_FREP_NO_PRUNE);
    check_model_2d("hi", CRISP_FREP_NO_BATCH);
    check_model_2d("hi", CRISP_FREP_BRUTE);
}

static void test_models_3d(void **state)
{
    (void)state;
    /* prospero at 128 and every model at 512 are in test_frep_slow */
    for (size_t m = 0; m < NMODELS; m++)
        if (strcmp(models[m], "prospero")) {
            check_model_3d(load_vm(models[m]), models[m], 128);
            /* a size that is no multiple of the tile sizes */
            check_model_3d(load_vm(models[m]), models[m], 77);
        }
}

/* A region and a size that are not square, not powers of two, in 2D and 3D. */
static void test_region_and_size(void **state)
{
    (void)state;
    crisp_frep *f = load_vm("tanglecube");
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    const int W = 203, H = 117, D = 45;
    const double g[6] = {-0.5, 1.5, -1.0, 0.8, -0.9, 0.7};
    for (int depth = 0; depth <= D; depth += D) {
        crisp_frep_render_desc d = {.width = W, .height = H, .depth = depth, .threads = 2};
        memcpy(d.region, g, sizeof g);
        crisp_frep_renderer *r;
        assert_int_equal(crisp_frep_renderer_create(t, &d, &r), CRISP_OK);
        assert_int_equal(crisp_frep_renderer_run(r), CRISP_OK);
        const crisp_frep_image *img = crisp_frep_renderer_image(r);
        size_t differ = 0, inside = 0;
        for (int j = 0; j < H; j++)
            for (int i = 0; i < W; i++) {
                float x = (float)(g[0] + (i + 0.5) * (g[1] - g[0]) / W);
                float y = (float)(g[3] - (j + 0.5) * (g[3] - g[2]) / H);
                size_t p = (size_t)j * W + (size_t)i;
                if (!depth) {
                    int in = crisp_frep_eval_point(t, x, y, (float)(0.5 * (g[4] + g[5]))) < 0;
                    differ += (img->inside[p] != 0) != in;
                    inside += in;
                } else {
                    int h = -1;
                    for (int k = D - 1; k >= 0 && h < 0; k--)
                        if (crisp_frep_eval_point(
                                t, x, y, (float)(g[4] + (k + 0.5) * (g[5] - g[4]) / D)) < 0)
                            h = k;
                    differ += img->heights[p] != h;
                    inside += h >= 0;
                }
            }
        assert_int_equal(differ, 0);
        assert_true(inside > 0 && inside < (size_t)W * H);
        crisp_frep_renderer_destroy(r);
    }
    /* bad descriptions are refused with a message */
    crisp_frep_render_desc bad = {.width = 0, .height = 10};
    crisp_frep_renderer *r = NULL;
    assert_int_equal(crisp_frep_renderer_create(t, &bad, &r), CRISP_ERR_INVALID_ARG);
    bad = (crisp_frep_render_desc){.width = 10, .height = 10, .region = {1, -1, -1, 1, 0, 0}};
    assert_int_equal(crisp_frep_renderer_create(t, &bad, &r), CRISP_ERR_INVALID_ARG);
    assert_null(r);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

/* ---- region fit ------------------------------------------------------------------------------ */

static crisp_status fit_math(const char *text, int planar, crisp_frep_fit *fit)
{
    crisp_frep *f = parse_math(text);
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    crisp_status s = crisp_frep_fit_region(t, &(crisp_frep_fit_desc){.planar = planar}, fit);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
    return s;
}

/* the fit contains the true box [lo, hi] on each axis and exceeds it by at most two cells */
static void assert_fit(const crisp_frep_fit *fit, const double truth[6], int axes)
{
    for (int a = 0; a < axes; a++) {
        assert_true(fit->box[2 * a] <= truth[2 * a] && fit->box[2 * a + 1] >= truth[2 * a + 1]);
        assert_true(fit->box[2 * a] >= truth[2 * a] - 2 * fit->cell);
        assert_true(fit->box[2 * a + 1] <= truth[2 * a + 1] + 2 * fit->cell);
    }
}

static void test_fit_region(void **state)
{
    (void)state;
    crisp_frep_fit fit;
    /* a small ball far from the origin, 3D and on the plane z = 0 */
    const double ball[6] = {99.5, 100.5, -0.5, 0.5, 1.5, 2.5};
    assert_int_equal(fit_math("(X-100)^2+Y^2+(Z-2)^2-0.25", 0, &fit), CRISP_OK);
    assert_fit(&fit, ball, 3);
    assert_true(fit.cell < 0.05);
    assert_int_equal(fit.unbounded, 0);
    /* the tanglecube reaches x = sqrt((5 + sqrt(35)) / 2) = 2.3363 (beyond the old [-1, 1]) */
    crisp_frep *f = load_vm("tanglecube");
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    assert_int_equal(crisp_frep_fit_region(t, &(crisp_frep_fit_desc){0}, &fit), CRISP_OK);
    double e = sqrt((5 + sqrt(35.0)) / 2), tc[6] = {-e, e, -e, e, -e, e};
    assert_fit(&fit, tc, 3);
    /* rendered over its fit, it is seen (inside pixels, none on the border) */
    crisp_frep_render_desc d = {.width = 64, .height = 64, .threads = 2};
    memcpy(d.region, fit.box, sizeof d.region);
    d.region[4] = d.region[5] = 0;
    crisp_frep_renderer *r;
    assert_int_equal(crisp_frep_renderer_create(t, &d, &r), CRISP_OK);
    assert_int_equal(crisp_frep_renderer_run(r), CRISP_OK);
    size_t inside = 0;
    for (size_t p = 0; p < 64 * 64; p++)
        inside += crisp_frep_renderer_image(r)->inside[p] != 0;
    assert_true(inside > 64 * 64 / 16);
    crisp_frep_renderer_destroy(r);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
    /* empty, unbounded, NaN: a status and a message, or the flag */
    assert_int_equal(fit_math("X^2+Y^2+Z^2+1", 0, &fit), CRISP_ERR_NUMERIC);
    assert_true(fit.empty);
    assert_non_null(strstr(crisp_error_message(), "empty"));
    assert_int_equal(fit_math("X-3", 0, &fit), CRISP_OK);
    assert_int_equal(fit.unbounded, 7);
    assert_int_equal(crisp_frep_fit_check(&fit, 0), CRISP_ERR_NUMERIC);
    assert_non_null(strstr(crisp_error_message(), "unbounded in x"));
    assert_true(fit.box[1] >= 3 && fit.box[1] < 3 + 2 * fit.cell);
    assert_int_equal(fit_math("sqrt(X-1000000)", 1, &fit), CRISP_ERR_NUMERIC);
    assert_non_null(strstr(crisp_error_message(), "NaN"));
    /* a 2D model is unbounded in z only */
    f = load_vm("quarter");
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    assert_int_equal(crisp_frep_fit_region(t, &(crisp_frep_fit_desc){.free_axes = 4}, &fit),
                     CRISP_OK);
    assert_int_equal(fit.unbounded, 4);
    assert_int_equal(crisp_frep_fit_check(&fit, 4), CRISP_OK);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_math_values),
        cmocka_unit_test(test_math_errors),
        cmocka_unit_test(test_vm_errors),
        cmocka_unit_test(test_vm_semantics),
        cmocka_unit_test(test_dag),
        cmocka_unit_test(test_big_expressions),
        cmocka_unit_test(test_interval_soundness),
        cmocka_unit_test(test_interval_lanes_match),
        cmocka_unit_test(test_batch_matches_graph),
        cmocka_unit_test(test_prospero_reference),
        cmocka_unit_test(test_models_2d),
        cmocka_unit_test(test_models_3d),
        cmocka_unit_test(test_region_and_size),
        cmocka_unit_test(test_fit_region),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
