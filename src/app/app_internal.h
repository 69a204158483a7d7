/* Private to src/app: what document.c takes from drawn_box.c. */
#ifndef CRISP_APP_INTERNAL_H
#define CRISP_APP_INTERNAL_H

#include "crisp/app.h"

/* Points on the true trimmed faces of sc (3 doubles each; the caller frees them with
 * crisp_free), clamped to sc->box, and their box (sc->box when no face gave a finite point). */
crisp_status crisp__scene_drawn_points(const crisp_scene *sc, double **points, size_t *count,
                                       double box[6]);

#endif
