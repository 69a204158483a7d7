/* A bounding hierarchy over a scene's faces (face_tree.h): median splits of the faces' box centres
 * along the longest axis, leaves of at most CRISP_FACE_TREE_LEAF faces. Built once per scene
 * (O(n log^2 n): a sort per level), so its cost is not a frame's. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "face_tree.h"

typedef struct keyed {
    double key;
    uint32_t face;
} keyed;

static int keyed_cmp(const void *a, const void *b)
{
    const keyed *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return x->face < y->face ? -1 : x->face > y->face; /* ties in face order: the same tree */
}

typedef struct build_ctx {
    const double *boxes;
    crisp__face_tree *t;
    keyed *scratch;
} build_ctx;

/* The node over order[first .. first + count) and its subtree; returns its index. */
static uint32_t build_node(build_ctx *c, uint32_t first, uint32_t count)
{
    crisp__face_tree *t = c->t;
    uint32_t at = t->node_count++;
    crisp__face_node *n = &t->nodes[at];
    n->first = first, n->count = count;
    n->child[0] = n->child[1] = -1;
    double clo[3], chi[3]; /* the range of the box centres */
    for (int a = 0; a < 3; a++) {
        n->box[a] = clo[a] = INFINITY;
        n->box[a + 3] = chi[a] = -INFINITY;
    }
    for (uint32_t i = first; i < first + count; i++) {
        const double *b = c->boxes + 6 * (size_t)t->order[i];
        for (int a = 0; a < 3; a++) {
            double m = 0.5 * (b[a] + b[a + 3]);
            n->box[a] = b[a] < n->box[a] ? b[a] : n->box[a];
            n->box[a + 3] = b[a + 3] > n->box[a + 3] ? b[a + 3] : n->box[a + 3];
            clo[a] = m < clo[a] ? m : clo[a];
            chi[a] = m > chi[a] ? m : chi[a];
        }
    }
    if (count <= CRISP_FACE_TREE_LEAF) return at;
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
    keyed *k = c->scratch;
    for (uint32_t i = 0; i < count; i++) {
        uint32_t f = t->order[first + i];
        const double *b = c->boxes + 6 * (size_t)f;
        k[i] = (keyed){0.5 * (b[axis] + b[axis + 3]), f};
    }
    qsort(k, count, sizeof *k, keyed_cmp);
    for (uint32_t i = 0; i < count; i++)
        t->order[first + i] = k[i].face;
    uint32_t half = count / 2;
    int32_t lo = (int32_t)build_node(c, first, half);
    int32_t hi = (int32_t)build_node(c, first + half, count - half);
    n->child[0] = lo, n->child[1] = hi; /* nodes is allocated for the whole tree up front */
    return at;
}

/* The chunks of node at's subtree, appended in tree order. */
static void collect_chunks(crisp__face_tree *t, uint32_t at)
{
    const crisp__face_node *n = &t->nodes[at];
    if (n->count <= CRISP_FACE_TREE_CHUNK || n->child[0] < 0) {
        t->chunks[t->chunk_count++] = at;
        return;
    }
    collect_chunks(t, (uint32_t)n->child[0]);
    collect_chunks(t, (uint32_t)n->child[1]);
}

void crisp__face_tree_free(crisp__face_tree *t)
{
    free(t->nodes);
    free(t->order);
    free(t->chunks);
    memset(t, 0, sizeof *t);
}

crisp_status crisp__face_tree_build(const double *boxes, const uint8_t *include,
                                    uint32_t face_count, crisp__face_tree *dest)
{
    memset(dest, 0, sizeof *dest);
    uint32_t n = 0;
    for (uint32_t f = 0; f < face_count; f++)
        n += !include || include[f];
    size_t cap = n ? 2 * (size_t)n : 1; /* a binary tree of n leaves or fewer */
    crisp__face_tree t = {0};
    t.nodes = crisp_malloc_array(cap, sizeof *t.nodes);
    t.order = crisp_malloc_array(n ? n : 1, sizeof *t.order);
    t.chunks = crisp_malloc_array(cap, sizeof *t.chunks);
    keyed *scratch = crisp_malloc_array(n ? n : 1, sizeof *scratch);
    if (!t.nodes || !t.order || !t.chunks || !scratch) {
        crisp__face_tree_free(&t);
        free(scratch);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the face tree (%u faces)", n);
    }
    n = 0;
    for (uint32_t f = 0; f < face_count; f++)
        if (!include || include[f]) t.order[n++] = f;
    if (n) {
        build_ctx c = {boxes, &t, scratch};
        build_node(&c, 0, n);
        collect_chunks(&t, 0);
    }
    free(scratch);
    *dest = t;
    return CRISP_OK;
}
