/* crisp merge: assemble the cells of a split job (issue 15, include/crisp/cells.h): image tiles
 * of crisp render / crisp frep render --tile into the whole image (PNG or EXR, every channel), and
 * mass cells into the whole part's properties. Refuses a missing, corrupt or foreign cell and an
 * incomplete set, naming the cell. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "crisp/cells.h"

const char crisp_cmd_merge_help[] =
    "merge -o OUT CELLS...        assemble the cells of a split job (image tiles, mass cells)";

static const char usage_text[] =
    "usage: crisp merge -o OUT [-q] CELLS...\n"
    "  Assembles the cells written by 'crisp render --tile', 'crisp frep render --tile',\n"
    "  'crisp mass --cell' and 'crisp frep mass --cell' (crisp jobs writes the commands).\n"
    "  Image tiles: CELLS are the tile images (PNG or EXR; each with its header TILE.cell) and\n"
    "  OUT the whole image in the same format, every channel bit for bit. Mass cells: CELLS are\n"
    "  the cell files and OUT a text file of the merged properties ('-' for stdout).\n"
    "  Every cell of the job must be given exactly once; a missing, truncated or changed cell,\n"
    "  a cell of another job or other settings is refused with a message naming it.\n"
    "  -o, --output FILE   the merged result (required)\n"
    "  -q, --quiet         do not print the 'merged N cells into OUT' line\n"
    "  -h, --help          print this help and exit\n"
    "  Exit status: 0 success, 1 bad or missing cells, 2 bad usage.\n";

/* mass cells: cmd_mass.c */
int crisp__merge_mass(const char *const *cells, size_t count, const char *out, int quiet);

int crisp_cmd_merge(int argc, char **argv)
{
    cli_cmd = "merge";
    static const struct option opts[] = {{"output", required_argument, 0, 'o'},
                                         {"quiet", no_argument, 0, 'q'},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *out = NULL;
    int quiet = 0, c;
    optind = 0;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o':
            out = optarg;
            break;
        case 'q':
            quiet = 1;
            break;
        case 'h':
            fputs(usage_text, stdout);
            return 0;
        default:
            cli_bad_option(c, argv);
            return 2;
        }
    }
    if (!out) {
        fprintf(stderr, "crisp merge: no output given (-o OUT)\n%s", usage_text);
        return 2;
    }
    if (optind >= argc) {
        fprintf(stderr, "crisp merge: no cells given\n");
        return 2;
    }
    const char *const *cells = (const char *const *)argv + optind;
    size_t n = (size_t)(argc - optind);
    /* the kind of job from the first cell's header (an image's header is beside it) */
    crisp_cell_header *h = calloc(1, sizeof *h);
    if (!h) return 1;
    char head[4096];
    size_t len = strlen(cells[0]);
    int is_header = len > 5 && !strcmp(cells[0] + len - 5, ".cell");
    snprintf(head, sizeof head, is_header ? "%s" : "%s.cell", cells[0]);
    crisp_status s = crisp_cell_header_read(head, h);
    if (s && !is_header) s = crisp_cell_header_read(cells[0], h);
    if (s) {
        fprintf(stderr, "crisp merge: %s: not a cell (%s)\n", cells[0], crisp_error_message());
        free(h);
        return 1;
    }
    int rc;
    if (!strcmp(h->kind, "image")) {
        double t0 = crisp_time_now();
        s = crisp_merge_images(cells, n, out);
        if (s) {
            fprintf(stderr, "crisp merge: %s\n", crisp_error_message());
            rc = 1;
        } else {
            if (!quiet)
                printf("merged %zu tiles into %s (%dx%d, %.0f ms)\n", n, out, h->rect[4],
                       h->rect[5], 1e3 * (crisp_time_now() - t0));
            rc = 0;
        }
    } else if (!strcmp(h->kind, "mass") || !strcmp(h->kind, "frep-mass")) {
        rc = crisp__merge_mass(cells, n, out, quiet);
    } else {
        fprintf(stderr, "crisp merge: %s: cells of kind '%s' cannot be merged by this crisp\n",
                cells[0], h->kind);
        rc = 1;
    }
    free(h);
    return rc;
}

/* Placeholder until mass cells land (crisp mass --cell). */
int crisp__merge_mass(const char *const *cells, size_t count, const char *out, int quiet)
{
    (void)count, (void)out, (void)quiet;
    fprintf(stderr, "crisp merge: %s: mass cells are not merged yet\n", cells[0]);
    return 1;
}
