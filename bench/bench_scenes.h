/* Scenes shared by the frame benchmarks (bench_screen, bench_gl): a bundled model instanced in a
 * grid. */
#ifndef CRISP_BENCH_SCENES_H
#define CRISP_BENCH_SCENES_H

#include <stdio.h>

#include "crisp/io.h"
#include "crisp/nurbs.h"

/* data/nurbs/NAME copied nx x ny times in a grid, 1.1 times its box apart in x and y
 * (bench_screen's imp49 is impeller.igs 7 x 7); die(what) on a failure (it does not return). */
static inline crisp_model *bench_instanced(const char *name, int nx, int ny,
                                           void (*die)(const char *))
{
    char path[1024];
    snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, name);
    crisp_model *src = NULL, *m = NULL;
    if (crisp_model_load(path, NULL, &src)) die(path);
    if (nx * ny == 1) return src;
    if (crisp_model_create(&m)) die("model");
    double box[6];
    crisp_model_bbox(src, box);
    double sx = 1.1 * (box[3] - box[0]), sy = 1.1 * (box[4] - box[1]);
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++)
            for (int f = 0; f < src->face_count; f++) {
                crisp_face face;
                if (crisp_face_copy(&src->faces[f], &face)) die("face copy");
                const double t[3][4] = {{1, 0, 0, i * sx}, {0, 1, 0, j * sy}, {0, 0, 1, 0}};
                crisp_face_transform(&face, t);
                if (crisp_model_add_face(m, &face)) die("add face");
            }
    crisp_model_destroy(src);
    return m;
}

#endif
