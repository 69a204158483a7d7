/* OpenEXR writer: named 32-bit float channels, scanline storage, ZIP compression, through the
 * OpenEXRCore C API (OpenEXR 3.1). */
#include "crisp/image.h"

#include <openexr.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The library's own message goes into crisp's error message instead of stderr (its default
 * handler prints a raw line before crisp can say which file failed). */
static _Thread_local char exr_message[256];

static void quiet_handler(exr_const_context_t ctx, exr_result_t code, const char *msg)
{
    (void)ctx;
    snprintf(exr_message, sizeof exr_message, "%s",
             msg ? msg : exr_get_default_error_message(code));
}

crisp_status crisp_write_exr(const char *path, int width, int height, int channels,
                             const char *const *names, const float *data)
{
    if (!path || !data || !names || width < 1 || height < 1 || channels < 1 || channels > 64)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "crisp_write_exr: %s: bad image %dx%d with %d channels",
                           path ? path : "(null)", width, height, channels);
    exr_context_t ctx;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet_handler;
    exr_message[0] = '\0';
    exr_result_t rv = exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS)
        return crisp_error(CRISP_ERR_IO, "%s: cannot open for writing: %s", path,
                           exr_message[0] ? exr_message : exr_get_default_error_message(rv));
    crisp_status s = CRISP_OK;
    int part;
    exr_encode_pipeline_t enc;
    int enc_init = 0;
    rv = exr_add_part(ctx, "image", EXR_STORAGE_SCANLINE, &part);
    if (!rv)
        rv = exr_initialize_required_attr_simple(ctx, part, width, height, EXR_COMPRESSION_ZIP);
    for (int c = 0; c < channels && !rv; c++)
        rv = exr_add_channel(ctx, part, names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1);
    if (!rv) rv = exr_write_header(ctx);
    int32_t lines = 0, chunks = 0;
    if (!rv) rv = exr_get_scanlines_per_chunk(ctx, part, &lines);
    if (!rv) rv = exr_get_chunk_count(ctx, part, &chunks);
    size_t stride = (size_t)channels * sizeof(float);
    for (int32_t ch = 0; ch < chunks && !rv; ch++) {
        exr_chunk_info_t cinfo;
        int y = ch * lines;
        rv = exr_write_scanline_chunk_info(ctx, part, y, &cinfo);
        if (rv) break;
        rv = enc_init ? exr_encoding_update(ctx, part, &cinfo, &enc)
                      : exr_encoding_initialize(ctx, part, &cinfo, &enc);
        if (rv) break;
        for (int c = 0; c < enc.channel_count; c++) {
            /* channels are stored sorted by name: match by name */
            int src = 0;
            for (int k = 0; k < channels; k++)
                if (!strcmp(names[k], enc.channels[c].channel_name)) src = k;
            enc.channels[c].encode_from_ptr =
                (const uint8_t *)(data + ((size_t)y * (size_t)width) * (size_t)channels +
                                  (size_t)src);
            enc.channels[c].user_pixel_stride = (int32_t)stride;
            enc.channels[c].user_line_stride = (int32_t)(stride * (size_t)width);
            enc.channels[c].user_bytes_per_element = 4;
            enc.channels[c].user_data_type = EXR_PIXEL_FLOAT;
        }
        if (!enc_init) {
            rv = exr_encoding_choose_default_routines(ctx, part, &enc);
            enc_init = 1;
            if (rv) break;
        }
        rv = exr_encoding_run(ctx, part, &enc);
    }
    if (rv)
        s = crisp_error(CRISP_ERR_IO, "%s: cannot write EXR: %s", path,
                        exr_message[0] ? exr_message : exr_get_default_error_message(rv));
    if (enc_init) exr_encoding_destroy(ctx, &enc);
    exr_finish(&ctx);
    return s;
}
