/* File watching for the window apps: polls the modification time and size of a set of files
 * (stat, twice a second) and reports a change once it has stayed the same for one poll, so a
 * file still being written is not read half-way. Polling also follows editors that replace the
 * file instead of writing into it.
 *
 * Offers: app_watch, app_watch_set, app_watch_clear, app_watch_poll
 */
#ifndef APP_WATCH_H
#define APP_WATCH_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct app_watch_file {
    char *path;
    long long mtime_ns, size; /* as last seen; -1 when missing */
} app_watch_file;

typedef struct app_watch {
    app_watch_file *files;
    size_t count;
    double next_poll, interval;
    int changed; /* a change seen, waiting for the files to settle */
} app_watch;

void app_watch_set(app_watch *w, char *const *paths, size_t count);
void app_watch_clear(app_watch *w);
/* 1 once after the files changed and settled. */
int app_watch_poll(app_watch *w, double now);

#ifdef __cplusplus
}
#endif
#endif
