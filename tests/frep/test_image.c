/* Round trips of the image writers (src/io/image): PNG read back with libpng's simplified API,
 * OpenEXR read back with the OpenEXRCore decoder, channel by channel and pixel for pixel. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <openexr.h>
#include <png.h>

#include "crisp/image.h"

static void test_png(void **state)
{
    (void)state;
    const int W = 37, H = 21;
    for (int ch = 1; ch <= 4; ch++) {
        uint8_t *px = malloc((size_t)W * H * ch);
        for (int k = 0; k < W * H * ch; k++)
            px[k] = (uint8_t)(k * 7 + ch);
        char path[256];
        snprintf(path, sizeof path, "%s/test_image_%d.png", CRISP_BIN_DIR, ch);
        assert_int_equal(crisp_write_png(path, W, H, ch, px), CRISP_OK);
        png_image img;
        memset(&img, 0, sizeof img);
        img.version = PNG_IMAGE_VERSION;
        assert_true(png_image_begin_read_from_file(&img, path));
        assert_int_equal(img.width, W);
        assert_int_equal(img.height, H);
        assert_int_equal(PNG_IMAGE_PIXEL_CHANNELS(img.format), ch);
        uint8_t *back = malloc(PNG_IMAGE_SIZE(img));
        assert_true(png_image_finish_read(&img, NULL, back, 0, NULL));
        assert_memory_equal(back, px, (size_t)W * H * ch);
        free(back);
        free(px);
        remove(path);
    }
    uint8_t one = 0;
    assert_int_equal(crisp_write_png("/nonexistent-dir/x.png", 1, 1, 1, &one), CRISP_ERR_IO);
    assert_int_equal(crisp_write_png("x.png", 0, 1, 1, &one), CRISP_ERR_INVALID_ARG);
}

static void test_exr(void **state)
{
    (void)state;
    const int W = 67, H = 41, C = 4; /* 16 lines per ZIP chunk: the last chunk is partial */
    const char *names[4] = {"Z", "N.x", "N.y", "N.z"};
    float *px = malloc((size_t)W * H * C * sizeof *px);
    for (int k = 0; k < W * H * C; k++)
        px[k] = (float)k * 0.25f - 100.0f;
    px[5 * C] = -INFINITY;
    char path[256];
    snprintf(path, sizeof path, "%s/test_image.exr", CRISP_BIN_DIR);
    assert_int_equal(crisp_write_exr(path, W, H, C, names, px), CRISP_OK);

    exr_context_t ctx;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    assert_int_equal(exr_start_read(&ctx, path, &init), EXR_ERR_SUCCESS);
    exr_attr_box2i_t dw;
    assert_int_equal(exr_get_data_window(ctx, 0, &dw), EXR_ERR_SUCCESS);
    assert_int_equal(dw.max.x - dw.min.x + 1, W);
    assert_int_equal(dw.max.y - dw.min.y + 1, H);
    int32_t lines = 0, chunks = 0;
    assert_int_equal(exr_get_scanlines_per_chunk(ctx, 0, &lines), EXR_ERR_SUCCESS);
    assert_int_equal(exr_get_chunk_count(ctx, 0, &chunks), EXR_ERR_SUCCESS);
    float *back = calloc((size_t)W * H * C, sizeof *back);
    exr_decode_pipeline_t dec;
    int inited = 0;
    for (int32_t c = 0; c < chunks; c++) {
        exr_chunk_info_t ci;
        assert_int_equal(exr_read_scanline_chunk_info(ctx, 0, dw.min.y + c * lines, &ci),
                         EXR_ERR_SUCCESS);
        assert_int_equal(inited ? exr_decoding_update(ctx, 0, &ci, &dec)
                                : exr_decoding_initialize(ctx, 0, &ci, &dec),
                         EXR_ERR_SUCCESS);
        for (int k = 0; k < dec.channel_count; k++) {
            int src = -1;
            for (int n = 0; n < C; n++)
                if (!strcmp(names[n], dec.channels[k].channel_name)) src = n;
            assert_true(src >= 0);
            dec.channels[k].decode_to_ptr =
                (uint8_t *)(back + ((size_t)(ci.start_y - dw.min.y) * W) * C + (size_t)src);
            dec.channels[k].user_pixel_stride = C * 4;
            dec.channels[k].user_line_stride = W * C * 4;
            dec.channels[k].user_bytes_per_element = 4;
            dec.channels[k].user_data_type = EXR_PIXEL_FLOAT;
        }
        if (!inited)
            assert_int_equal(exr_decoding_choose_default_routines(ctx, 0, &dec), EXR_ERR_SUCCESS);
        inited = 1;
        assert_int_equal(exr_decoding_run(ctx, 0, &dec), EXR_ERR_SUCCESS);
    }
    if (inited) exr_decoding_destroy(ctx, &dec);
    exr_finish(&ctx);
    assert_memory_equal(back, px, (size_t)W * H * C * sizeof *px);
    free(back);
    free(px);
    remove(path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_png), cmocka_unit_test(test_exr)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
