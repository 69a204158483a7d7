/* PNG writer (8-bit gray, gray+alpha, RGB, RGBA) through libpng's simplified write API
 * (png_image_write_to_file, libpng 1.6). */
#include "crisp/image.h"

#include <png.h>
#include <string.h>

crisp_status crisp_write_png(const char *path, int width, int height, int channels,
                             const uint8_t *data)
{
    if (!path || !data || width < 1 || height < 1 || channels < 1 || channels > 4)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_write_png: %s: bad image %dx%d with %d channels",
                           path ? path : "(null)", width, height, channels);
    static const png_uint_32 formats[4] = {PNG_FORMAT_GRAY, PNG_FORMAT_GA, PNG_FORMAT_RGB,
                                           PNG_FORMAT_RGBA};
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    img.width = (png_uint_32)width;
    img.height = (png_uint_32)height;
    img.format = formats[channels - 1];
    if (!png_image_write_to_file(&img, path, 0, data, (png_int_32)width * channels, NULL)) {
        crisp_status s = crisp_error(CRISP_ERR_IO, "%s: cannot write PNG: %s", path, img.message);
        png_image_free(&img);
        return s;
    }
    return CRISP_OK;
}

crisp_status crisp_write_png_gray(const char *path, int width, int height, const uint8_t *data)
{
    return crisp_write_png(path, width, height, 1, data);
}

crisp_status crisp_write_png_rgba(const char *path, int width, int height, const uint8_t *data)
{
    return crisp_write_png(path, width, height, 4, data);
}
