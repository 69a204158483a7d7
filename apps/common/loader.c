/* The background loader (loader.h): one worker thread, one pending request, one finished result. */
#include "loader.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct app_loader {
    pthread_t thread;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int quit;
    char *pending; /* next path to load */
    int pending_tag;
    char *running; /* path being loaded (NULL when idle) */
    int running_tag, running_cancelled;
    double started;
    atomic_long progress; /* share done of the running load in millionths; -1: not reported */
    /* finished, not yet polled */
    int result;
    app_doc *doc;
    int tag;
    char err[1024];
};

static void *worker(void *arg)
{
    app_loader *l = arg;
    pthread_mutex_lock(&l->mu);
    for (;;) {
        while (!l->quit && !l->pending) pthread_cond_wait(&l->cv, &l->mu);
        if (l->quit) break;
        l->running = l->pending;
        l->running_tag = l->pending_tag;
        l->running_cancelled = 0;
        l->pending = NULL;
        l->started = crisp_time_now();
        atomic_store(&l->progress, -1);
        pthread_mutex_unlock(&l->mu);

        app_doc *doc = NULL;
        crisp_status st = app_doc_load(l->running, &doc);
        char err[1024] = "";
        if (st) snprintf(err, sizeof err, "%s", crisp_error_message());

        pthread_mutex_lock(&l->mu);
        if (l->running_cancelled || l->quit) {
            app_doc_destroy(doc);
        } else {
            app_doc_destroy(l->doc); /* an unpolled older result */
            l->doc = doc;
            l->result = st ? APP_LOAD_FAILED : APP_LOAD_DONE;
            l->tag = l->running_tag;
            snprintf(l->err, sizeof l->err, "%s", err);
        }
        free(l->running);
        l->running = NULL;
    }
    pthread_mutex_unlock(&l->mu);
    return NULL;
}

/* crisp_progress_report's receiver: process-wide, so keep only what the loader thread reports
 * (renders on other threads report too). */
static void on_progress(void *ctx, double fraction)
{
    app_loader *l = ctx;
    if (pthread_equal(pthread_self(), l->thread))
        atomic_store(&l->progress, (long)(1e6 * (fraction < 0 ? 0 : fraction > 1 ? 1 : fraction)));
}

int app_loader_create(app_loader **dest)
{
    app_loader *l = calloc(1, sizeof *l);
    *dest = NULL;
    if (!l) return 0;
    pthread_mutex_init(&l->mu, NULL);
    pthread_cond_init(&l->cv, NULL);
    if (pthread_create(&l->thread, NULL, worker, l)) {
        pthread_mutex_destroy(&l->mu);
        pthread_cond_destroy(&l->cv);
        free(l);
        return 0;
    }
    atomic_store(&l->progress, -1);
    crisp_progress_set(on_progress, l);
    *dest = l;
    return 1;
}

void app_loader_destroy(app_loader *l)
{
    if (!l) return;
    crisp_progress_set(NULL, NULL);
    pthread_mutex_lock(&l->mu);
    l->quit = 1;
    pthread_cond_signal(&l->cv);
    pthread_mutex_unlock(&l->mu);
    pthread_join(l->thread, NULL);
    free(l->pending);
    app_doc_destroy(l->doc);
    pthread_mutex_destroy(&l->mu);
    pthread_cond_destroy(&l->cv);
    free(l);
}

void app_loader_request(app_loader *l, const char *path, int tag)
{
    char *p = strdup(path);
    pthread_mutex_lock(&l->mu);
    if (l->running) l->running_cancelled = 1;
    free(l->pending);
    l->pending = p;
    l->pending_tag = tag;
    if (!p) { /* out of memory: report as a failed load */
        l->result = APP_LOAD_FAILED;
        l->tag = tag;
        snprintf(l->err, sizeof l->err, "out of memory");
    }
    pthread_cond_signal(&l->cv);
    pthread_mutex_unlock(&l->mu);
}

void app_loader_cancel(app_loader *l)
{
    pthread_mutex_lock(&l->mu);
    if (l->running) l->running_cancelled = 1;
    free(l->pending);
    l->pending = NULL;
    pthread_mutex_unlock(&l->mu);
}

int app_loader_poll(app_loader *l, app_doc **doc, int *tag, char *err, size_t err_size)
{
    pthread_mutex_lock(&l->mu);
    int r = l->result;
    if (r) {
        *doc = l->doc;
        *tag = l->tag;
        snprintf(err, err_size, "%s", l->err);
        l->doc = NULL;
        l->result = APP_LOAD_NONE;
    }
    pthread_mutex_unlock(&l->mu);
    return r;
}

double app_loader_progress(app_loader *l)
{
    long p = atomic_load(&l->progress);
    return p < 0 ? -1 : p / 1e6;
}

int app_loader_status(app_loader *l, char *path, size_t path_size, double *seconds)
{
    pthread_mutex_lock(&l->mu);
    int busy = 0;
    if (l->pending) {
        busy = 1;
        snprintf(path, path_size, "%s", l->pending);
        *seconds = 0;
    } else if (l->running && !l->running_cancelled) {
        busy = 1;
        snprintf(path, path_size, "%s", l->running);
        *seconds = crisp_time_now() - l->started;
    }
    pthread_mutex_unlock(&l->mu);
    return busy;
}
