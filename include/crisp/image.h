/* crisp image writers: 8-bit PNG through libpng, 32-bit float OpenEXR through the OpenEXRCore C
 * API. Pixels are row-major, row 0 at the top, channels interleaved.
 *
 * Offers:
 *   crisp_write_png        1 (gray), 2 (gray+alpha), 3 (RGB) or 4 (RGBA) channels of bytes
 *   crisp_write_png_gray, crisp_write_png_rgba
 *   crisp_write_exr        any number of named float channels ("R", "Z", "N.x" ...), ZIP compressed
 */
#ifndef CRISP_IMAGE_H
#define CRISP_IMAGE_H

#include <stdint.h>

#include "crisp/core.h"

#ifdef __cplusplus
extern "C" {
#endif

crisp_status crisp_write_png(const char *path, int width, int height, int channels,
                             const uint8_t *data);
crisp_status crisp_write_png_gray(const char *path, int width, int height, const uint8_t *data);
crisp_status crisp_write_png_rgba(const char *path, int width, int height, const uint8_t *data);
/* data holds width * height * channels floats; names[c] names channel c. */
crisp_status crisp_write_exr(const char *path, int width, int height, int channels,
                             const char *const *names, const float *data);

#ifdef __cplusplus
}
#endif
#endif
