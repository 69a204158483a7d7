/* Status codes and the per-thread error message (GLFW-style: say what was wrong and where). */
#include "crisp/core.h"

#include <stdio.h>
#include <string.h>

#include "core_internal.h"

#define MESSAGE_MAX CRISP__MESSAGE_MAX

static _Thread_local char message[MESSAGE_MAX];
static _Thread_local unsigned long error_count;
static _Thread_local crisp__error_slot *capture, *owned;

crisp__error_slot *crisp__error_capture(crisp__error_slot *slot)
{
    crisp__error_slot *old = capture;
    capture = slot;
    owned = NULL;
    return old;
}

unsigned long crisp__error_count(void)
{
    return error_count;
}

void crisp__error_set_message(const char *m)
{
    snprintf(message, sizeof message, "%s", m);
}

/* A worker of a pool job offers its error to the job's slot; the first one is kept. */
static void offer(crisp_status status)
{
    error_count++;
    if (!capture) return;
    int expected = 0;
    if (atomic_compare_exchange_strong(&capture->taken, &expected, 1)) {
        capture->status = status;
        memcpy(capture->message, message, sizeof message);
        atomic_store(&capture->taken, 2); /* message complete */
        owned = capture;
    }
}

const char *crisp_status_name(crisp_status status)
{
    switch (status) {
    case CRISP_OK:
        return "ok";
    case CRISP_ERR_INVALID_ARG:
        return "invalid argument";
    case CRISP_ERR_NO_MEMORY:
        return "out of memory";
    case CRISP_ERR_IO:
        return "i/o error";
    case CRISP_ERR_PARSE:
        return "parse error";
    case CRISP_ERR_UNSUPPORTED:
        return "unsupported";
    case CRISP_ERR_LIMIT:
        return "limit exceeded";
    case CRISP_ERR_NUMERIC:
        return "numeric error";
    case CRISP_ERR_GL:
        return "OpenGL error";
    case CRISP_ERR_INTERNAL:
        return "internal error";
    }
    return "unknown status";
}

const char *crisp_error_message(void)
{
    return message;
}

void crisp_error_clear(void)
{
    message[0] = '\0';
}

crisp_status crisp_error_v(crisp_status status, const char *fmt, va_list ap)
{
    vsnprintf(message, sizeof message, fmt, ap);
    offer(status);
    return status;
}

crisp_status crisp_error(crisp_status status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    crisp_error_v(status, fmt, ap);
    va_end(ap);
    return status;
}

void crisp_error_prefix(const char *fmt, ...)
{
    char old[MESSAGE_MAX];
    memcpy(old, message, sizeof old);
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(message, sizeof message, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof message) return;
    snprintf(message + n, sizeof message - (size_t)n, ": %s", old);
    /* the slot keeps the worker's message with its context */
    if (capture && owned == capture) memcpy(capture->message, message, sizeof message);
}
