/* A background loader thread for the window apps: opens files (app_doc_load) off the window's
 * thread so the window keeps drawing, reports what it is doing and for how long, and can cancel.
 * A reader that calls crisp_progress_report (on the loader's thread) fills the progress bar.
 * The readers have no cancel hook, so a cancelled load runs to its end in the background and its
 * result is dropped; a newer request waits for it. Destroying the loader waits for the running
 * load, then frees everything (closing the window during a load exits cleanly).
 *
 * Offers:
 *   app_loader_create/_destroy, app_loader_request, app_loader_cancel, app_loader_poll,
 *   app_loader_status, app_loader_progress
 */
#ifndef APP_LOADER_H
#define APP_LOADER_H

#include <stddef.h>

#include "doc.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct app_loader app_loader;

enum { APP_LOAD_NONE = 0, APP_LOAD_DONE, APP_LOAD_FAILED };

int app_loader_create(app_loader **dest);
void app_loader_destroy(app_loader *l);
/* Load path (replacing any load not finished yet); tag comes back with the result. */
void app_loader_request(app_loader *l, const char *path, int tag);
void app_loader_cancel(app_loader *l);
/* A finished load: APP_LOAD_DONE with *doc (the caller owns it), APP_LOAD_FAILED with the
 * message in err; APP_LOAD_NONE when nothing finished since the last poll. */
int app_loader_poll(app_loader *l, app_doc **doc, int *tag, char *err, size_t err_size);
/* 1 while a load that will be shown runs or waits; path and seconds so far. */
int app_loader_status(app_loader *l, char *path, size_t path_size, double *seconds);
/* The running load's share done as its reader reports it (0..1), or -1 when it reports none. */
double app_loader_progress(app_loader *l);

#ifdef __cplusplus
}
#endif
#endif
