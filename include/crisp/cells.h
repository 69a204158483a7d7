/* crisp cells (issue 15): a long job split into independent cells that an existing job engine
 * (make, GNU parallel, Slurm) runs, then assembled. The shape follows the OpenSCAD octree-slicing
 * proposal: cells are files, each carrying which job, settings and cell it is, so that a merge
 * refuses a missing, corrupt or foreign cell instead of assembling a wrong result.
 *
 * Offers:
 *   crisp_cell_parse       "I/N" or "I/CxR" (a cell of a job split in N, or in a C x R grid)
 *   crisp_tile_grid        the grid of N image tiles (near-square tiles on a 32-pixel grid)
 *   crisp_tile_rect        the pixel rectangle of tile I
 *   crisp_cell_header      what a cell file says about itself (job, settings, cell, data file)
 *   crisp_cell_header_write / _read   a small text file beside (or holding) the cell's data
 *   crisp_file_hash        size and FNV-1a 64 of a file's bytes (corrupt or truncated cells)
 *   crisp_hash_bytes       FNV-1a 64, chained (job ids: the input's bytes and the settings)
 *   crisp_cell_commit      write a cell's data and header so that a killed run leaves no half cell
 *   crisp_cell_job_id      the job id of an input file and a settings line
 *   crisp_merge_images     tiles (PNG or EXR, every channel) into the whole image, streamed
 *                          band by band of tiles
 */
#ifndef CRISP_CELLS_H
#define CRISP_CELLS_H

#include <stddef.h>
#include <stdint.h>

#include "crisp/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A cell of a split job: index in 0..count-1; cols x rows when the grid was given (else 0). */
typedef struct crisp_cell_spec {
    int index, count;
    int cols, rows;
} crisp_cell_spec;

/* "I/N" (0 <= I < N <= 1048576) or "I/CxR" (N = C R). */
crisp_status crisp_cell_parse(const char *text, crisp_cell_spec *dest);

/* The grid of spec->count tiles of a width x height image: spec->cols x spec->rows when given,
 * else the factorisation of count whose tiles are nearest to square (ties: more columns). Tile
 * edges lie on multiples of 32 pixels (the image's last edge aside), so every tile must be at
 * least 32 pixels wide and high. Fills cols and rows. */
crisp_status crisp_tile_grid(int width, int height, crisp_cell_spec *spec);
/* x0, y0, w, h of tile spec->index (row-major from the top left) of a grid made by
 * crisp_tile_grid. */
void crisp_tile_rect(int width, int height, const crisp_cell_spec *spec, int dest[4]);

#define CRISP_CELL_MAX_SUMS 48

typedef struct crisp_cell_header {
    char kind[32];       /* "image", "mass", "frep-mass", ... */
    uint64_t job;        /* hash of the input's bytes and the settings */
    char settings[2048]; /* the settings, one line (what the merge compares) */
    crisp_cell_spec cell;
    int rect[6];        /* images: x0, y0, w, h of the tile, width, height of the image */
    char data[512];     /* the data file's name (beside the header), or "" */
    uint64_t data_size; /* its size in bytes and hash (crisp_file_hash) */
    uint64_t data_hash;
    /* partial sums (mass cells): name and value */
    int sum_count;
    char sum_name[CRISP_CELL_MAX_SUMS][32];
    double sum[CRISP_CELL_MAX_SUMS];
} crisp_cell_header;

/* Writes the header to path through a temporary file renamed into place (a killed run leaves no
 * half header). */
crisp_status crisp_cell_header_write(const char *path, const crisp_cell_header *h);
/* Reads a header; errors name the file and line. */
crisp_status crisp_cell_header_read(const char *path, crisp_cell_header *h);
/* The value of sum `name` (NAN when absent). */
double crisp_cell_header_sum(const crisp_cell_header *h, const char *name);
/* Adds a sum (at most CRISP_CELL_MAX_SUMS). */
void crisp_cell_header_add_sum(crisp_cell_header *h, const char *name, double value);

/* Writes a cell: write(ctx, tmp) writes the data to a temporary file in path's folder (named
 * .tmp-PID-BASE, so it keeps path's extension); then h (with the data's name, size and hash
 * filled in) is written to path.cell and the data renamed to path. A run killed at any point
 * leaves either no path or a complete cell (make and GNU parallel then redo only missing ones). */
typedef crisp_status (*crisp_cell_write_fn)(void *ctx, const char *tmp_path);
crisp_status crisp_cell_commit(const char *path, crisp_cell_header *h, crisp_cell_write_fn write,
                               void *ctx);
/* A job id: the hash of a file's bytes (the input) chained with the settings line. */
crisp_status crisp_cell_job_id(const char *input, const char *settings, uint64_t *dest);

uint64_t crisp_hash_bytes(uint64_t seed, const void *data, size_t size);
#define CRISP_HASH_SEED 0xcbf29ce484222325ull
crisp_status crisp_file_hash(const char *path, uint64_t *size, uint64_t *hash);

/* Assembles image tiles (each with its header at TILE.cell, written by crisp render / crisp frep
 * render --tile) into out (.png or .exr, the tiles' format): every channel of the tiles, bit for
 * bit. Refuses, naming the cell: a missing header or data file, a data file whose size or hash
 * is not the header's (corrupt, truncated), tiles of another job or other settings, two tiles
 * with one index, an incomplete set. Memory: one band (a row of tiles) at a time. */
crisp_status crisp_merge_images(const char *const *tiles, size_t count, const char *out);

#ifdef __cplusplus
}
#endif
#endif
