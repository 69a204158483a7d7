/* Image outputs of a rendered crisp_image: the format by extension, checks made before the work
 * starts (so a run that cannot write its result fails at once and leaves nothing), PNG 8-bit
 * RGBA (alpha = coverage) and OpenEXR with every AOV as float (docs/design.md, images). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "crisp/app.h"
#include "crisp/image.h"

crisp_image_format crisp_image_format_of(const char *path)
{
    const char *dot = path ? strrchr(path, '.') : NULL;
    if (!dot || strchr(dot, '/')) return CRISP_IMAGE_UNKNOWN;
    if (!strcasecmp(dot, ".png")) return CRISP_IMAGE_PNG;
    if (!strcasecmp(dot, ".exr")) return CRISP_IMAGE_EXR;
    return CRISP_IMAGE_UNKNOWN;
}

const char *crisp_image_format_name(crisp_image_format format)
{
    switch (format) {
    case CRISP_IMAGE_PNG:
        return "PNG";
    case CRISP_IMAGE_EXR:
        return "OpenEXR";
    default:
        return "unknown";
    }
}

crisp_status crisp_image_output_check(const char *path, crisp_image_format want)
{
    if (!path || !*path) return crisp_error(CRISP_ERR_INVALID_ARG, "empty output file name");
    crisp_image_format f = crisp_image_format_of(path);
    if (want != CRISP_IMAGE_UNKNOWN && f != want)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: expected a name ending in .%s", path,
                           want == CRISP_IMAGE_PNG ? "png" : "exr");
    if (f == CRISP_IMAGE_UNKNOWN)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: unknown image format (expected a name ending in .png or .exr)",
                           path);
    struct stat sb;
    if (stat(path, &sb) == 0) {
        if (S_ISDIR(sb.st_mode)) return crisp_error(CRISP_ERR_IO, "%s: is a directory", path);
        if (!S_ISREG(sb.st_mode)) return crisp_error(CRISP_ERR_IO, "%s: not a regular file", path);
        if (access(path, W_OK) != 0)
            return crisp_error(CRISP_ERR_IO, "%s: cannot write: %s", path, strerror(errno));
        return CRISP_OK;
    }
    /* a new file: its folder must exist and be writable */
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash) {
        strcpy(dir, ".");
    } else {
        size_t n = slash == path ? 1 : (size_t)(slash - path);
        if (n >= sizeof dir) return crisp_error(CRISP_ERR_INVALID_ARG, "%s: path too long", path);
        memcpy(dir, path, n);
        dir[n] = '\0';
    }
    if (stat(dir, &sb) != 0)
        return crisp_error(CRISP_ERR_IO, "%s: cannot write: folder %s: %s", path, dir,
                           strerror(errno));
    if (!S_ISDIR(sb.st_mode))
        return crisp_error(CRISP_ERR_IO, "%s: cannot write: %s is not a folder", path, dir);
    if (access(dir, W_OK | X_OK) != 0)
        return crisp_error(CRISP_ERR_IO, "%s: cannot write in folder %s: %s", path, dir,
                           strerror(errno));
    return CRISP_OK;
}

crisp_status crisp_image_write_png(const crisp_image *img, const char *path)
{
    size_t n = (size_t)img->width * img->height;
    uint8_t *px = crisp_malloc_array(n, 4);
    if (!px) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory for the PNG", path);
    for (size_t i = 0; i < 4 * n; i++) {
        float c = img->rgba[i];
        px[i] = (uint8_t)lrintf(255.0f * (c < 0 ? 0 : c > 1 ? 1 : c));
    }
    crisp_status st = crisp_write_png_rgba(path, img->width, img->height, px);
    crisp_free(px);
    return st;
}

crisp_status crisp_image_write_exr(const crisp_image *img, const char *path)
{
    static const char *const names[] = {"R",   "G",   "B", "A", "Z",   "N.x",
                                        "N.y", "N.z", "u", "v", "face"};
    enum { C = 11 };
    size_t n = (size_t)img->width * img->height;
    float *px = crisp_malloc_array(n, C * sizeof(float));
    if (!px) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory for the EXR", path);
    for (size_t i = 0; i < n; i++) {
        float *d = px + C * i;
        memcpy(d, img->rgba + 4 * i, 4 * sizeof(float));
        d[4] = img->depth[i];
        memcpy(d + 5, img->normal + 3 * i, 3 * sizeof(float));
        d[8] = img->uv[2 * i];
        d[9] = img->uv[2 * i + 1];
        d[10] = (float)img->face[i];
    }
    crisp_status st = crisp_write_exr(path, img->width, img->height, C, names, px);
    crisp_free(px);
    return st;
}

crisp_status crisp_image_write(const crisp_image *img, const char *path)
{
    switch (crisp_image_format_of(path)) {
    case CRISP_IMAGE_PNG:
        return crisp_image_write_png(img, path);
    case CRISP_IMAGE_EXR:
        return crisp_image_write_exr(img, path);
    default:
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "%s: unknown image format (expected a name ending in .png or .exr)",
                           path);
    }
}
