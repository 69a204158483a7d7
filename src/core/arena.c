/* Bump allocator. Blocks are kept across resets so a steady per-frame workload stops allocating. */
#include "crisp/core.h"

#include <stdlib.h>

typedef struct block {
    struct block *next;
    size_t size, used;
    _Alignas(16) unsigned char data[];
} block;

struct crisp_arena {
    block *head;  /* block being filled */
    block *first; /* chain from the first block, in order */
    size_t block_size;
    size_t reserved;
};

crisp_status crisp_arena_create(size_t block_size, crisp_arena **dest)
{
    crisp_arena *a = calloc(1, sizeof *a);
    if (!a) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating an arena");
    a->block_size = block_size ? block_size : 65536;
    *dest = a;
    return CRISP_OK;
}

void crisp_arena_destroy(crisp_arena *a)
{
    if (!a) return;
    for (block *b = a->first; b;) {
        block *n = b->next;
        free(b);
        b = n;
    }
    free(a);
}

void crisp_arena_reset(crisp_arena *a)
{
    for (block *b = a->first; b; b = b->next)
        b->used = 0;
    a->head = a->first;
}

void *crisp_arena_alloc(crisp_arena *a, size_t n, size_t size)
{
    if (size != 0 && n > SIZE_MAX / size) return NULL;
    size_t bytes = n * size;
    if (bytes > SIZE_MAX - 15) return NULL;
    bytes = (bytes + 15) & ~(size_t)15;
    /* Walk the kept chain for a block with room, then append a new one. */
    for (block *b = a->head; b; b = b->next) {
        if (b->size - b->used >= bytes) {
            a->head = b;
            void *p = b->data + b->used;
            b->used += bytes;
            return p;
        }
    }
    size_t sz = bytes > a->block_size ? bytes : a->block_size;
    if (sz > SIZE_MAX - sizeof(block)) return NULL;
    block *nb = malloc(sizeof(block) + sz);
    if (!nb) return NULL;
    nb->next = NULL;
    nb->size = sz;
    nb->used = bytes;
    if (!a->first) {
        a->first = nb;
    } else {
        block *t = a->first;
        while (t->next)
            t = t->next;
        t->next = nb;
    }
    a->head = nb;
    a->reserved += sz;
    return nb->data;
}

size_t crisp_arena_reserved(const crisp_arena *a)
{
    return a->reserved;
}

size_t crisp_arena_used(const crisp_arena *a)
{
    size_t used = 0;
    for (const block *b = a->first; b; b = b->next)
        used += b->used;
    return used;
}

crisp_status crisp_arena_reserve(crisp_arena *a, size_t bytes)
{
    if (a->first && a->first->size >= bytes) return CRISP_OK;
    if (bytes > SIZE_MAX - sizeof(block))
        return crisp_error(CRISP_ERR_NO_MEMORY, "arena reserve of %zu bytes", bytes);
    block *nb = malloc(sizeof(block) + bytes);
    if (!nb) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory reserving %zu bytes", bytes);
    nb->size = bytes;
    nb->used = 0;
    nb->next = a->first;
    a->first = a->head = nb;
    a->reserved += bytes;
    return CRISP_OK;
}
