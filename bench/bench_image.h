/* Writing a frame benchmark's picture (BENCH_SCREEN_PNG, BENCH_INTERACTIVE_PNG): look at what a
 * row draws. */
#ifndef CRISP_BENCH_IMAGE_H
#define CRISP_BENCH_IMAGE_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "crisp/image.h"
#include "crisp/render.h"

/* img's colour as an 8-bit RGBA PNG at path; 0 on success. */
static inline int bench_write_png(const char *path, const crisp_image *img)
{
    size_t n = (size_t)img->width * img->height * 4;
    uint8_t *rgba = malloc(n);
    if (!rgba) return 1;
    for (size_t k = 0; k < n; k++)
        rgba[k] = (uint8_t)lrint(255 * fmin(1, fmax(0, img->rgba[k])));
    int bad = crisp_write_png_rgba(path, img->width, img->height, rgba) != CRISP_OK;
    free(rgba);
    return bad;
}

#endif
