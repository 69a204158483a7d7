/* Private to src/core: how the pool carries a worker's error message to the thread that called
 * crisp_pool_parallel_for (status.c records, pool.c collects). */
#ifndef CRISP_CORE_INTERNAL_H
#define CRISP_CORE_INTERNAL_H

#include <stdatomic.h>

#include "crisp/core.h"

#define CRISP__MESSAGE_MAX 1024

/* The first error raised on any thread capturing into it. */
typedef struct crisp__error_slot {
    atomic_int taken;
    crisp_status status;
    char message[CRISP__MESSAGE_MAX];
} crisp__error_slot;

/* From now on this thread's errors are also offered to slot (NULL: stop); returns the slot it
 * offered to before (restore it afterwards). */
crisp__error_slot *crisp__error_capture(crisp__error_slot *slot);
/* Errors raised on this thread so far. */
unsigned long crisp__error_count(void);
/* Set this thread's message without counting it as a new error. */
void crisp__error_set_message(const char *message);

#endif
