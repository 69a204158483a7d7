/* crisp_merge_images (include/crisp/cells.h, issue 15): image tiles, each with its cell header,
 * assembled into the whole image band by band (one row of tiles in memory at a time), PNG through
 * libpng's row writer and OpenEXR through the OpenEXRCore chunk writer (scanline, ZIP: 16 lines
 * a chunk; tile edges lie on the 32-pixel grid, so chunks never straddle two bands). Every check
 * names the cell: its index, its file, and what was expected. */
#include <errno.h>
#include <openexr.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "crisp/app.h"
#include "crisp/cells.h"

typedef struct tile_in {
    const char *arg;      /* as given */
    char header[4096];    /* its header file */
    char data[4096];      /* its data file */
    crisp_cell_header *h; /* read */
} tile_in;

static int has_suffix(const char *s, const char *t)
{
    size_t a = strlen(s), b = strlen(t);
    return a >= b && !strcasecmp(s + a - b, t);
}

/* ---- readers ---------------------------------------------------------------------------- */

typedef struct raster_buf {
    int width, height, channels, is_float;
    char names[16][32]; /* EXR channel names, file order */
    void *px;           /* interleaved, row-major: bytes (PNG) or floats (EXR) */
} raster_buf;

static crisp_status read_png(const char *path, raster_buf *b)
{
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path))
        return crisp_error(CRISP_ERR_PARSE, "%s: not a readable PNG: %s", path, img.message);
    img.format &= ~(png_uint_32)PNG_FORMAT_FLAG_COLORMAP;
    b->width = (int)img.width, b->height = (int)img.height;
    b->channels = (int)PNG_IMAGE_PIXEL_CHANNELS(img.format);
    b->is_float = 0;
    b->px = malloc(PNG_IMAGE_SIZE(img));
    if (!b->px) {
        png_image_free(&img);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", path);
    }
    if (!png_image_finish_read(&img, NULL, b->px, 0, NULL)) {
        free(b->px);
        b->px = NULL;
        return crisp_error(CRISP_ERR_PARSE, "%s: corrupt PNG: %s", path, img.message);
    }
    return CRISP_OK;
}

static _Thread_local char exr_msg[256];
static void exr_quiet(exr_const_context_t ctx, exr_result_t code, const char *msg)
{
    (void)ctx;
    snprintf(exr_msg, sizeof exr_msg, "%s", msg ? msg : exr_get_default_error_message(code));
}

static crisp_status read_exr(const char *path, raster_buf *b)
{
    exr_context_t ctx;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_quiet;
    exr_msg[0] = '\0';
    if (exr_start_read(&ctx, path, &init) != EXR_ERR_SUCCESS)
        return crisp_error(CRISP_ERR_PARSE, "%s: not a readable OpenEXR file: %s", path, exr_msg);
    crisp_status s = CRISP_OK;
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *chl = NULL;
    int32_t lines = 0, chunks = 0;
    exr_result_t rv = exr_get_data_window(ctx, 0, &dw);
    if (!rv) rv = exr_get_channels(ctx, 0, &chl);
    if (!rv) rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    if (!rv) rv = exr_get_chunk_count(ctx, 0, &chunks);
    if (rv || !chl || chl->num_channels < 1 || chl->num_channels > 16) {
        exr_finish(&ctx);
        return crisp_error(CRISP_ERR_PARSE, "%s: corrupt OpenEXR header: %s", path,
                           exr_msg[0] ? exr_msg : "bad channel list");
    }
    int W = dw.max.x - dw.min.x + 1, H = dw.max.y - dw.min.y + 1, C = chl->num_channels;
    b->width = W, b->height = H, b->channels = C, b->is_float = 1;
    for (int c = 0; c < C; c++)
        snprintf(b->names[c], sizeof b->names[c], "%s", chl->entries[c].name.str);
    b->px = calloc((size_t)W * H * C, sizeof(float));
    if (!b->px) {
        exr_finish(&ctx);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", path);
    }
    float *px = b->px;
    exr_decode_pipeline_t dec;
    int inited = 0;
    for (int32_t ch = 0; ch < chunks && !rv; ch++) {
        exr_chunk_info_t ci;
        rv = exr_read_scanline_chunk_info(ctx, 0, dw.min.y + ch * lines, &ci);
        if (!rv)
            rv = inited ? exr_decoding_update(ctx, 0, &ci, &dec)
                        : exr_decoding_initialize(ctx, 0, &ci, &dec);
        if (rv) break;
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
        if (!inited) rv = exr_decoding_choose_default_routines(ctx, 0, &dec);
        inited = 1;
        if (!rv) rv = exr_decoding_run(ctx, 0, &dec);
    }
    if (inited) exr_decoding_destroy(ctx, &dec);
    exr_finish(&ctx);
    if (rv) {
        free(b->px);
        b->px = NULL;
        s = crisp_error(CRISP_ERR_PARSE, "%s: corrupt OpenEXR data: %s", path,
                        exr_msg[0] ? exr_msg : exr_get_default_error_message(rv));
    }
    return s;
}

/* ---- streamed writers ------------------------------------------------------------------- */

typedef struct writer {
    const char *path;
    int width, height, channels, is_float;
    /* PNG */
    FILE *fp;
    png_structp png;
    png_infop info;
    char png_msg[256];
    /* EXR */
    exr_context_t exr;
    int exr_open, enc_init;
    int32_t lines;
    exr_encode_pipeline_t enc;
    char names[16][32];
} writer;

static void png_err(png_structp png, png_const_charp msg)
{
    writer *w = png_get_error_ptr(png);
    snprintf(w->png_msg, sizeof w->png_msg, "%s", msg);
    png_longjmp(png, 1);
}

static void png_warn(png_structp png, png_const_charp msg)
{
    (void)png, (void)msg;
}

static crisp_status writer_open(writer *w)
{
    if (!w->is_float) {
        w->fp = fopen(w->path, "wb");
        if (!w->fp)
            return crisp_error(CRISP_ERR_IO, "%s: cannot write: %s", w->path, strerror(errno));
        w->png = png_create_write_struct(PNG_LIBPNG_VER_STRING, w, png_err, png_warn);
        if (w->png) w->info = png_create_info_struct(w->png);
        if (!w->png || !w->info)
            return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory for the PNG writer",
                               w->path);
        static const int types[4] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA,
                                     PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGB_ALPHA};
        if (setjmp(png_jmpbuf(w->png)))
            return crisp_error(CRISP_ERR_IO, "%s: cannot write PNG: %s", w->path, w->png_msg);
        png_init_io(w->png, w->fp);
        png_set_IHDR(w->png, w->info, (png_uint_32)w->width, (png_uint_32)w->height, 8,
                     types[w->channels - 1], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                     PNG_FILTER_TYPE_DEFAULT);
        png_write_info(w->png, w->info);
        return CRISP_OK;
    }
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_quiet;
    exr_msg[0] = '\0';
    exr_result_t rv = exr_start_write(&w->exr, w->path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv) return crisp_error(CRISP_ERR_IO, "%s: cannot open for writing: %s", w->path, exr_msg);
    w->exr_open = 1;
    int part;
    rv = exr_add_part(w->exr, "image", EXR_STORAGE_SCANLINE, &part);
    if (!rv)
        rv = exr_initialize_required_attr_simple(w->exr, 0, w->width, w->height,
                                                 EXR_COMPRESSION_ZIP);
    for (int c = 0; c < w->channels && !rv; c++)
        rv =
            exr_add_channel(w->exr, 0, w->names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1);
    if (!rv) rv = exr_write_header(w->exr);
    if (!rv) rv = exr_get_scanlines_per_chunk(w->exr, 0, &w->lines);
    if (rv || w->lines < 1 || 32 % w->lines)
        return crisp_error(CRISP_ERR_IO, "%s: cannot write the EXR header: %s", w->path, exr_msg);
    return CRISP_OK;
}

/* Rows y0 .. y0 + n - 1 of the image, interleaved in band. */
static crisp_status writer_rows(writer *w, int y0, int n, const void *band)
{
    if (!w->is_float) {
        if (setjmp(png_jmpbuf(w->png)))
            return crisp_error(CRISP_ERR_IO, "%s: cannot write PNG: %s", w->path, w->png_msg);
        for (int j = 0; j < n; j++)
            png_write_row(w->png, (png_const_bytep)band + (size_t)j * w->width * w->channels);
        return CRISP_OK;
    }
    exr_result_t rv = EXR_ERR_SUCCESS;
    size_t stride = (size_t)w->channels * sizeof(float);
    for (int y = y0; y < y0 + n && !rv; y += w->lines) {
        exr_chunk_info_t ci;
        rv = exr_write_scanline_chunk_info(w->exr, 0, y, &ci);
        if (!rv)
            rv = w->enc_init ? exr_encoding_update(w->exr, 0, &ci, &w->enc)
                             : exr_encoding_initialize(w->exr, 0, &ci, &w->enc);
        if (rv) break;
        for (int c = 0; c < w->enc.channel_count; c++) {
            int src = 0;
            for (int k = 0; k < w->channels; k++)
                if (!strcmp(w->names[k], w->enc.channels[c].channel_name)) src = k;
            w->enc.channels[c].encode_from_ptr =
                (const uint8_t *)((const float *)band + (size_t)(y - y0) * w->width * w->channels +
                                  src);
            w->enc.channels[c].user_pixel_stride = (int32_t)stride;
            w->enc.channels[c].user_line_stride = (int32_t)(stride * (size_t)w->width);
            w->enc.channels[c].user_bytes_per_element = 4;
            w->enc.channels[c].user_data_type = EXR_PIXEL_FLOAT;
        }
        if (!w->enc_init) {
            w->enc_init = 1;
            rv = exr_encoding_choose_default_routines(w->exr, 0, &w->enc);
            if (rv) break;
        }
        rv = exr_encoding_run(w->exr, 0, &w->enc);
    }
    if (rv) return crisp_error(CRISP_ERR_IO, "%s: cannot write EXR: %s", w->path, exr_msg);
    return CRISP_OK;
}

/* png_write_end under its own setjmp (no local of the caller is live across it). */
static crisp_status png_end(writer *w)
{
    if (setjmp(png_jmpbuf(w->png)))
        return crisp_error(CRISP_ERR_IO, "%s: cannot write PNG: %s", w->path, w->png_msg);
    png_write_end(w->png, NULL);
    return CRISP_OK;
}

static crisp_status writer_close(writer *w, int ok)
{
    crisp_status s = CRISP_OK;
    if (w->png) {
        if (ok) s = png_end(w);
        png_destroy_write_struct(&w->png, &w->info);
    }
    if (w->fp && fclose(w->fp) && !s)
        s = crisp_error(CRISP_ERR_IO, "%s: cannot write: %s", w->path, strerror(errno));
    if (w->exr_open) {
        if (w->enc_init) exr_encoding_destroy(w->exr, &w->enc);
        exr_finish(&w->exr);
    }
    return s;
}

/* ---- merge ------------------------------------------------------------------------------ */

static int cmp_index(const void *a, const void *b)
{
    const tile_in *x = a, *y = b;
    return (x->h->cell.index > y->h->cell.index) - (x->h->cell.index < y->h->cell.index);
}

/* The header and data paths of a tile given as its image or as its header. */
static crisp_status tile_paths(tile_in *t)
{
    size_t n = strlen(t->arg);
    if (n + 6 >= sizeof t->header)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: path too long", t->arg);
    if (has_suffix(t->arg, ".cell"))
        memcpy(t->header, t->arg, n + 1);
    else
        snprintf(t->header, sizeof t->header, "%s.cell", t->arg);
    return CRISP_OK;
}

static crisp_status data_path(tile_in *t)
{
    const char *slash = strrchr(t->header, '/');
    int dir = slash ? (int)(slash - t->header + 1) : 0;
    if (!t->h->data[0] || strchr(t->h->data, '/'))
        return crisp_error(CRISP_ERR_PARSE, "%s: cell %d: no data file name (or one with a '/')",
                           t->header, t->h->cell.index);
    if (snprintf(t->data, sizeof t->data, "%.*s%s", dir, t->header, t->h->data) >=
        (int)sizeof t->data)
        return crisp_error(CRISP_ERR_INVALID_ARG, "%s: path too long", t->header);
    return CRISP_OK;
}

crisp_status crisp_merge_images(const char *const *args, size_t count, const char *out)
{
    if (!count) return crisp_error(CRISP_ERR_INVALID_ARG, "no tiles to merge");
    crisp_image_format of = crisp_image_format_of(out);
    crisp_status s = crisp_image_output_check(out, CRISP_IMAGE_UNKNOWN);
    if (s) return s;
    tile_in *t = calloc(count, sizeof *t);
    crisp_cell_header *hs = calloc(count, sizeof *hs);
    if (!t || !hs) {
        free(t), free(hs);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for %zu tiles", count);
    }
    for (size_t k = 0; k < count && !s; k++) {
        t[k].arg = args[k];
        t[k].h = &hs[k];
        s = tile_paths(&t[k]);
        if (!s && (s = crisp_cell_header_read(t[k].header, t[k].h)))
            crisp_error_prefix("%s: no readable cell header (the tile is missing or was not "
                               "finished)",
                               t[k].arg);
        if (!s && strcmp(t[k].h->kind, "image"))
            s = crisp_error(CRISP_ERR_INVALID_ARG, "%s: cell %d is a '%s' cell, not an image tile",
                            t[k].header, t[k].h->cell.index, t[k].h->kind);
        if (!s) s = data_path(&t[k]);
    }
    const crisp_cell_header *h0 = &hs[0];
    for (size_t k = 1; k < count && !s; k++) {
        const crisp_cell_header *h = &hs[k];
        if (strcmp(h->settings, h0->settings))
            s = crisp_error(CRISP_ERR_INVALID_ARG,
                            "%s: cell %d has other settings than cell %d (%s):\n  '%s'\n  against "
                            "'%s'",
                            t[k].header, h->cell.index, h0->cell.index, t[0].header, h->settings,
                            h0->settings);
        else if (h->job != h0->job)
            s = crisp_error(CRISP_ERR_INVALID_ARG,
                            "%s: cell %d belongs to another job (job %016llx, cell %d of %s is of "
                            "job %016llx): the input file differs",
                            t[k].header, h->cell.index, (unsigned long long)h->job, h0->cell.index,
                            t[0].header, (unsigned long long)h0->job);
        else if (h->cell.count != h0->cell.count || h->cell.cols != h0->cell.cols ||
                 h->cell.rows != h0->cell.rows || h->rect[4] != h0->rect[4] ||
                 h->rect[5] != h0->rect[5])
            s = crisp_error(CRISP_ERR_INVALID_ARG,
                            "%s: cell %d is one of %d (%dx%d tiles of %dx%d), cell %d of %s one "
                            "of %d (%dx%d tiles of %dx%d)",
                            t[k].header, h->cell.index, h->cell.count, h->cell.cols, h->cell.rows,
                            h->rect[4], h->rect[5], h0->cell.index, t[0].header, h0->cell.count,
                            h0->cell.cols, h0->cell.rows, h0->rect[4], h0->rect[5]);
    }
    int W = h0->rect[4], H = h0->rect[5], N = h0->cell.count;
    crisp_cell_spec grid = h0->cell;
    if (!s && (W < 1 || H < 1 || grid.cols < 1 || grid.rows < 1 || grid.cols * grid.rows != N))
        s = crisp_error(CRISP_ERR_PARSE, "%s: bad image size %dx%d or grid %dx%d for %d tiles",
                        t[0].header, W, H, grid.cols, grid.rows, N);
    if (!s) qsort(t, count, sizeof *t, cmp_index);
    for (size_t k = 0; k + 1 < count && !s; k++)
        if (t[k].h->cell.index == t[k + 1].h->cell.index)
            s = crisp_error(CRISP_ERR_INVALID_ARG, "cell %d is given twice: %s and %s",
                            t[k].h->cell.index, t[k].header, t[k + 1].header);
    if (!s && count != (size_t)N) {
        char list[512] = "";
        size_t len = 0, k = 0;
        int missing = 0;
        for (int i = 0; i < N; i++) {
            if (k < count && t[k].h->cell.index == i) {
                k++;
                continue;
            }
            if (missing++ < 8 && len < sizeof list - 32)
                len += (size_t)snprintf(list + len, sizeof list - len, "%s%d",
                                        missing > 1 ? ", " : "", i);
        }
        s = crisp_error(CRISP_ERR_INVALID_ARG,
                        "incomplete set: %d of the %d tiles of %s's job are missing: cell%s %s%s",
                        missing, N, t[0].header, missing > 1 ? "s" : "", list,
                        missing > 8 ? ", ..." : "");
    }
    for (size_t k = 0; k < count && !s; k++) {
        int r[4];
        crisp_cell_spec c = grid;
        c.index = t[k].h->cell.index;
        crisp_tile_rect(W, H, &c, r);
        if (memcmp(r, t[k].h->rect, sizeof r))
            s = crisp_error(CRISP_ERR_PARSE,
                            "%s: cell %d says it is %dx%d at (%d, %d); tile %d of the grid is "
                            "%dx%d at (%d, %d)",
                            t[k].header, c.index, t[k].h->rect[2], t[k].h->rect[3], t[k].h->rect[0],
                            t[k].h->rect[1], c.index, r[2], r[3], r[0], r[1]);
        else if (crisp_image_format_of(t[k].data) != of)
            s = crisp_error(CRISP_ERR_INVALID_ARG, "%s: cell %d is a %s file; the output %s is %s",
                            t[k].data, c.index,
                            crisp_image_format_name(crisp_image_format_of(t[k].data)), out,
                            crisp_image_format_name(of));
    }
    /* band by band: read, check and place a row of tiles, write its rows */
    writer w = {.path = out, .width = W, .height = H, .is_float = of == CRISP_IMAGE_EXR};
    unsigned char *band = NULL;
    int opened = 0;
    for (int row = 0; row < grid.rows && !s; row++) {
        int band_y0 = 0, band_h = 0;
        for (int col = 0; col < grid.cols && !s; col++) {
            tile_in *tk = &t[row * grid.cols + col];
            const crisp_cell_header *h = tk->h;
            uint64_t size, hash;
            s = crisp_file_hash(tk->data, &size, &hash);
            if (s) {
                crisp_error_prefix("cell %d (%s): its data file is missing", h->cell.index,
                                   tk->header);
                break;
            }
            if (size != h->data_size || hash != h->data_hash) {
                s = crisp_error(CRISP_ERR_PARSE,
                                "cell %d: %s is corrupt: %llu bytes with hash %016llx, its header "
                                "%s says %llu bytes with hash %016llx (truncated, or changed "
                                "after it was written)",
                                h->cell.index, tk->data, (unsigned long long)size,
                                (unsigned long long)hash, tk->header,
                                (unsigned long long)h->data_size, (unsigned long long)h->data_hash);
                break;
            }
            raster_buf b = {0};
            s = w.is_float ? read_exr(tk->data, &b) : read_png(tk->data, &b);
            if (s) {
                crisp_error_prefix("cell %d", h->cell.index);
                break;
            }
            if (b.width != h->rect[2] || b.height != h->rect[3])
                s = crisp_error(CRISP_ERR_PARSE, "cell %d: %s is %dx%d, its header says %dx%d",
                                h->cell.index, tk->data, b.width, b.height, h->rect[2], h->rect[3]);
            if (!s && !opened) {
                w.channels = b.channels;
                memcpy(w.names, b.names, sizeof w.names);
                s = writer_open(&w);
                opened = 1;
            }
            if (!s && (b.channels != w.channels ||
                       (w.is_float && memcmp(b.names, w.names, sizeof w.names))))
                s = crisp_error(CRISP_ERR_PARSE,
                                "cell %d: %s has %d channels, unlike the first tile's %d (or "
                                "other names)",
                                h->cell.index, tk->data, b.channels, w.channels);
            size_t el = w.is_float ? sizeof(float) : 1, pxb = el * (size_t)w.channels;
            if (!s && col == 0) {
                band_y0 = h->rect[1], band_h = h->rect[3];
                free(band);
                band = malloc((size_t)W * (size_t)band_h * pxb);
                if (!band)
                    s = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for a band of %dx%d", W,
                                    band_h);
            }
            if (!s)
                for (int j = 0; j < b.height; j++)
                    memcpy(band + ((size_t)j * W + (size_t)h->rect[0]) * pxb,
                           (unsigned char *)b.px + (size_t)j * b.width * pxb,
                           (size_t)b.width * pxb);
            free(b.px);
        }
        if (!s) s = writer_rows(&w, band_y0, band_h, band);
    }
    free(band);
    crisp_status s2 = writer_close(&w, !s && opened);
    if (!s) s = s2;
    if (s && opened) remove(out);
    free(t);
    free(hs);
    return s;
}
