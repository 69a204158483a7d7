/* File watching by polling (watch.h). */
#include "watch.h"

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static void look(const char *path, long long *mtime_ns, long long *size)
{
    struct stat sb;
    if (stat(path, &sb) != 0) {
        *mtime_ns = -1;
        *size = -1;
        return;
    }
    *mtime_ns = (long long)sb.st_mtim.tv_sec * 1000000000ll + sb.st_mtim.tv_nsec;
    *size = (long long)sb.st_size;
}

void app_watch_clear(app_watch *w)
{
    for (size_t i = 0; i < w->count; i++)
        free(w->files[i].path);
    free(w->files);
    memset(w, 0, sizeof *w);
}

void app_watch_set(app_watch *w, char *const *paths, size_t count)
{
    app_watch_clear(w);
    w->interval = 0.5;
    w->files = calloc(count ? count : 1, sizeof *w->files);
    if (!w->files) return;
    for (size_t i = 0; i < count; i++) {
        app_watch_file *f = &w->files[w->count];
        if (!(f->path = strdup(paths[i]))) continue;
        look(f->path, &f->mtime_ns, &f->size);
        w->count++;
    }
}

int app_watch_poll(app_watch *w, double now)
{
    if (!w->count || now < w->next_poll) return 0;
    w->next_poll = now + w->interval;
    int moved = 0;
    for (size_t i = 0; i < w->count; i++) {
        long long t, s;
        look(w->files[i].path, &t, &s);
        if (t != w->files[i].mtime_ns || s != w->files[i].size) moved = 1;
        w->files[i].mtime_ns = t;
        w->files[i].size = s;
    }
    if (moved) {
        w->changed = 1; /* wait one more poll for the writer to finish */
        return 0;
    }
    if (w->changed) {
        w->changed = 0;
        return 1;
    }
    return 0;
}
