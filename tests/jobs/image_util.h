/* Test helpers for issue 15's tests: decode a PNG (its own channel count) or an OpenEXR file
 * (every channel as float, in the file's channel order), and run the crisp binary. */
#ifndef CRISP_TESTS_JOBS_IMAGE_UTIL_H
#define CRISP_TESTS_JOBS_IMAGE_UTIL_H

#include <openexr.h>
#include <png.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct test_img {
    int width, height, channels, is_float;
    char names[16][32];
    void *px;
} test_img;

static int test_read_png(const char *path, test_img *b)
{
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path)) return 0;
    b->width = (int)img.width, b->height = (int)img.height;
    b->channels = (int)PNG_IMAGE_PIXEL_CHANNELS(img.format), b->is_float = 0;
    b->px = malloc(PNG_IMAGE_SIZE(img));
    return png_image_finish_read(&img, NULL, b->px, 0, NULL) != 0;
}

static int test_read_exr(const char *path, test_img *b)
{
    exr_context_t ctx;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    if (exr_start_read(&ctx, path, &init) != EXR_ERR_SUCCESS) return 0;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    int32_t lines = 0, chunks = 0;
    int ok = !exr_get_data_window(ctx, 0, &dw) && !exr_get_channels(ctx, 0, &chl) &&
             !exr_get_scanlines_per_chunk(ctx, 0, &lines) && !exr_get_chunk_count(ctx, 0, &chunks);
    if (!ok) return 0;
    int W = dw.max.x - dw.min.x + 1, H = dw.max.y - dw.min.y + 1, C = chl->num_channels;
    b->width = W, b->height = H, b->channels = C, b->is_float = 1;
    for (int c = 0; c < C && c < 16; c++)
        snprintf(b->names[c], sizeof b->names[c], "%s", chl->entries[c].name.str);
    float *px = calloc((size_t)W * H * C, sizeof(float));
    b->px = px;
    exr_decode_pipeline_t dec;
    int inited = 0;
    for (int32_t ch = 0; ch < chunks && ok; ch++) {
        exr_chunk_info_t ci;
        ok = !exr_read_scanline_chunk_info(ctx, 0, dw.min.y + ch * lines, &ci);
        ok = ok && !(inited ? exr_decoding_update(ctx, 0, &ci, &dec)
                            : exr_decoding_initialize(ctx, 0, &ci, &dec));
        if (!ok) break;
        for (int k = 0; k < dec.channel_count; k++) {
            int src = 0;
            for (int n = 0; n < C; n++)
                if (!strcmp(b->names[n], dec.channels[k].channel_name)) src = n;
            dec.channels[k].decode_to_ptr =
                (uint8_t *)(px + ((size_t)(ci.start_y - dw.min.y) * W) * C + (size_t)src);
            dec.channels[k].user_pixel_stride = C * 4;
            dec.channels[k].user_line_stride = W * C * 4;
            dec.channels[k].user_bytes_per_element = 4;
            dec.channels[k].user_data_type = EXR_PIXEL_FLOAT;
        }
        if (!inited) ok = !exr_decoding_choose_default_routines(ctx, 0, &dec);
        inited = 1;
        ok = ok && !exr_decoding_run(ctx, 0, &dec);
    }
    if (inited) exr_decoding_destroy(ctx, &dec);
    exr_finish(&ctx);
    return ok;
}

static int test_read_image(const char *path, test_img *b)
{
    memset(b, 0, sizeof *b);
    size_t n = strlen(path);
    return n > 4 && !strcmp(path + n - 4, ".exr") ? test_read_exr(path, b) : test_read_png(path, b);
}

/* 1 when both decode to the same size, channels and bytes. */
static int test_same_image(const char *a, const char *b)
{
    test_img x, y;
    int ok = test_read_image(a, &x) && test_read_image(b, &y) && x.width == y.width &&
             x.height == y.height && x.channels == y.channels && x.is_float == y.is_float &&
             !memcmp(x.names, y.names, sizeof x.names) &&
             !memcmp(x.px, y.px, (size_t)x.width * x.height * x.channels * (x.is_float ? 4 : 1));
    free(x.px);
    free(y.px);
    return ok;
}

/* Runs a shell command (printf-style) in dir; returns its exit status; its stdout and stderr go
 * to dir/out.txt (read back by test_output). */
static int test_run(const char *dir, const char *fmt, ...)
{
    char cmd[16384], full[17000];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(cmd, sizeof cmd, fmt, ap);
    va_end(ap);
    if (snprintf(full, sizeof full, "cd '%s' && { %s ; } > out.txt 2>&1", dir, cmd) >=
        (int)sizeof full)
        return -1;
    int rc = system(full);
    return rc == -1 ? -1 : (rc >> 8) & 0xff;
}

/* dir/out.txt (static buffer). */
static const char *test_output(const char *dir)
{
    static char buf[65536];
    char path[4096];
    FILE *f =
        snprintf(path, sizeof path, "%s/out.txt", dir) < (int)sizeof path ? fopen(path, "r") : NULL;
    size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    if (f) fclose(f);
    buf[n] = '\0';
    return buf;
}

#endif
