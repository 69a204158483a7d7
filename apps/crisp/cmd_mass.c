/* crisp mass: volume, area, centroid and inertia of a closed trimmed-NURBS model (IGES, STEP,
 * OBJ free-form) from its exact surfaces (include/crisp/mass.h), with an error estimate. With
 * --cell I/N (issue 15) it measures only the I-th of N runs of faces and writes their raw sums
 * as a cell file for crisp merge. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "crisp/cells.h"
#include "crisp/io.h"
#include "crisp/mass.h"

const char crisp_cmd_mass_help[] =
    "mass MODEL                   volume, area, centroid and inertia of a closed NURBS model";

static const char usage_text[] =
    "usage: crisp mass MODEL [--cell I/N -o CELL]\n"
    "Volume, surface area, centroid and inertia tensor (about the centroid, density 1, model\n"
    "units) of a closed B-rep model from its trimmed NURBS faces: the divergence theorem,\n"
    "with Green's theorem over the trim loops; errors from two quadrature orders. A model\n"
    "that is not closed gets its area and a warning.\n"
    "  --cell I/N   measure only the I-th of N equal runs of faces and write their sums to the\n"
    "               cell file given by -o (crisp merge -o OUT CELLS... adds the cells up)\n";

/* Prints a whole model's properties (crisp mass, and crisp merge of its cells); warnings go to
 * stderr. */
void crisp__mass_print(FILE *out, const char *name, int faces, const crisp_mass_props *p);
void crisp__mass_print(FILE *out, const char *name, int faces, const crisp_mass_props *p)
{
    fprintf(out, "%s: %d faces\n", name, faces);
    fprintf(out, "area      %.15g (+- %.2g)\n", p->area, p->area_err);
    if (!p->closed) {
        fprintf(stderr,
                "crisp mass: warning: the model is not a closed shell (the faces' vector "
                "area is %g, %g, %g against an area of %g; the volume along x, y, z: %g, %g, %g): "
                "no volume, centroid or inertia\n",
                p->vector_area[0], p->vector_area[1], p->vector_area[2], p->area, p->axis_volume[0],
                p->axis_volume[1], p->axis_volume[2]);
        return;
    }
    if (!(p->volume > 0))
        fprintf(stderr,
                "crisp mass: warning: the shell is closed but its faces point inwards (volume "
                "%g): the reader's face orientation is turned\n",
                p->volume);
    fprintf(out, "volume    %.15g (+- %.2g)\n", p->volume, p->volume_err);
    fprintf(out, "centroid  %.15g %.15g %.15g\n", p->centroid[0], p->centroid[1], p->centroid[2]);
    fprintf(out, "inertia about the centroid (density 1): Ixx Iyy Izz Ixy Iyz Ixz (+- %.2g)\n  ",
            p->inertia_err);
    for (int k = 0; k < 6; k++)
        fprintf(out, " %.15g", p->inertia[k]);
    fprintf(out, "\n");
}

static crisp_status write_cell(const char *model, const crisp_cell_spec *cell, int f0, int f1,
                               const crisp_mass_props *p, const char *out)
{
    crisp_cell_header *h = calloc(1, sizeof *h);
    if (!h) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
    snprintf(h->kind, sizeof h->kind, "mass");
    snprintf(h->settings, sizeof h->settings, "mass cells=%d", cell->count);
    crisp_status s = crisp_cell_job_id(model, h->settings, &h->job);
    h->cell = *cell;
    h->rect[0] = f0, h->rect[1] = f1;
    char name[16];
    for (int k = 0; k < CRISP_MASS_SUMS; k++) {
        snprintf(name, sizeof name, "T%d", k);
        crisp_cell_header_add_sum(h, name, p->sums[k]);
        snprintf(name, sizeof name, "E%d", k);
        crisp_cell_header_add_sum(h, name, p->sums_err[k]);
    }
    for (int a = 0; a < 3; a++) {
        snprintf(name, sizeof name, "ref%d", a);
        crisp_cell_header_add_sum(h, name, p->ref[a]);
    }
    crisp_cell_header_add_sum(h, "size", p->size);
    if (!s) s = crisp_cell_header_write(out, h);
    free(h);
    return s;
}

int crisp_cmd_mass(int argc, char **argv)
{
    cli_cmd = "mass";
    static const struct option opts[] = {{"cell", required_argument, 0, 'c'},
                                         {"output", required_argument, 0, 'o'},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    const char *out = NULL;
    crisp_cell_spec cell = {0};
    int celled = 0, c;
    optind = 0;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":o:h", opts, NULL)) != -1) {
        switch (c) {
        case 'c':
            if (!cli_cell("--cell", optarg, &cell)) return 2;
            celled = 1;
            break;
        case 'o':
            out = optarg;
            break;
        case 'h':
            fputs(usage_text, stdout);
            return 0;
        default:
            cli_bad_option(c, argv);
            return 2;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "crisp mass: expected one MODEL\n%s", usage_text);
        return 2;
    }
    if (celled != (out != NULL)) {
        fprintf(stderr, "crisp mass: --cell and -o go together (-o names the cell file)\n");
        return 2;
    }
    const char *path = argv[optind];
    crisp_model *m = NULL;
    crisp_status s = crisp_model_load(path, NULL, &m);
    crisp_mass_props p;
    int f0 = 0, f1 = 0;
    if (!s && celled) {
        f0 = (int)((long long)cell.index * m->face_count / cell.count);
        f1 = (int)((long long)(cell.index + 1) * m->face_count / cell.count);
        if (f0 == f1) {
            /* more cells than faces: an empty cell (its sums are 0) */
            memset(&p, 0, sizeof p);
            crisp_mass_props whole_ref;
            s = crisp_mass_model(m, &(crisp_mass_desc){.face_begin = 0, .face_end = 1}, &whole_ref);
            memcpy(p.ref, whole_ref.ref, sizeof p.ref);
            p.size = whole_ref.size;
        } else {
            s = crisp_mass_model(m, &(crisp_mass_desc){.face_begin = f0, .face_end = f1}, &p);
        }
        if (!s) s = write_cell(path, &cell, f0, f1, &p, out);
        if (!s)
            printf("%s: cell %d of %d: faces %d..%d of %d, area %.15g\n", out, cell.index,
                   cell.count, f0, f1 - 1, m->face_count, p.sums[0]);
    } else if (!s) {
        s = crisp_mass_model(m, NULL, &p);
        if (!s) crisp__mass_print(stdout, path, m->face_count, &p);
    }
    if (s) fprintf(stderr, "crisp mass: %s\n", crisp_error_message());
    crisp_model_destroy(m);
    return s ? 1 : 0;
}
