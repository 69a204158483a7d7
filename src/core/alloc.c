/* Allocation with overflow-checked sizes. Failure is a value (NULL), never an abort. */
#include "crisp/core.h"

#include <stdlib.h>

static int mul_overflows(size_t n, size_t size, size_t *bytes)
{
    if (size != 0 && n > SIZE_MAX / size) return 1;
    *bytes = n * size;
    return 0;
}

void *crisp_malloc_array(size_t n, size_t size)
{
    size_t bytes;
    if (mul_overflows(n, size, &bytes)) return NULL;
    return malloc(bytes ? bytes : 1);
}

void *crisp_calloc_array(size_t n, size_t size)
{
    size_t bytes;
    if (mul_overflows(n, size, &bytes)) return NULL;
    return calloc(bytes ? n : 1, bytes ? size : 1);
}

void *crisp_realloc_array(void *p, size_t n, size_t size)
{
    size_t bytes;
    if (mul_overflows(n, size, &bytes)) return NULL;
    return realloc(p, bytes ? bytes : 1);
}

void crisp_free(void *p)
{
    free(p);
}

crisp_status crisp_grow(void **p, size_t *cap, size_t need, size_t size)
{
    if (need <= *cap) return CRISP_OK;
    size_t c = *cap ? *cap : 8;
    while (c < need) {
        if (c > SIZE_MAX / 2)
            return crisp_error(CRISP_ERR_NO_MEMORY, "array of %zu elements is too large", need);
        c *= 2;
    }
    void *q = crisp_realloc_array(*p, c, size);
    if (!q)
        return crisp_error(CRISP_ERR_NO_MEMORY,
                           "out of memory growing an array to %zu elements of %zu bytes", c, size);
    *p = q;
    *cap = c;
    return CRISP_OK;
}
