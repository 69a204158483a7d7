/* crisp mass: volume, area, centroid and inertia of a closed trimmed-NURBS model (IGES, STEP,
 * OBJ free-form) from its exact surfaces (include/crisp/mass.h), with an error estimate. */
#include <stdio.h>
#include <string.h>

#include "crisp/io.h"
#include "crisp/mass.h"

const char crisp_cmd_mass_help[] =
    "mass MODEL                   volume, area, centroid and inertia of a closed NURBS model";

int crisp_cmd_mass(int argc, char **argv)
{
    if (argc != 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        FILE *out = argc == 2 ? stdout : stderr;
        fprintf(
            out,
            "usage: crisp mass MODEL\n"
            "Volume, surface area, centroid and inertia tensor (about the centroid, density 1, "
            "model\n"
            "units) of a closed B-rep model from its trimmed NURBS faces: the divergence theorem,\n"
            "with Green's theorem over the trim loops; errors from two quadrature orders. A model\n"
            "that is not closed gets its area and a warning.\n");
        return argc == 2 ? 0 : 2;
    }
    crisp_model *m = NULL;
    crisp_status s = crisp_model_load(argv[1], NULL, &m);
    crisp_mass_props p;
    if (!s) s = crisp_mass_model(m, NULL, &p);
    if (s) {
        fprintf(stderr, "crisp mass: %s\n", crisp_error_message());
        crisp_model_destroy(m);
        return 1;
    }
    printf("%s: %d faces\n", argv[1], m->face_count);
    printf("area      %.15g (+- %.2g)\n", p.area, p.area_err);
    if (!p.closed) {
        fprintf(stderr,
                "crisp mass: warning: the model is not a closed shell (the faces' vector "
                "area is %g, %g, %g against an area of %g; the volume along x, y, z: %g, %g, %g): "
                "no volume, centroid or inertia\n",
                p.vector_area[0], p.vector_area[1], p.vector_area[2], p.area, p.axis_volume[0],
                p.axis_volume[1], p.axis_volume[2]);
    } else {
        if (!(p.volume > 0))
            fprintf(stderr,
                    "crisp mass: warning: the shell is closed but its faces point inwards (volume "
                    "%g): the reader's face orientation is turned\n",
                    p.volume);
        printf("volume    %.15g (+- %.2g)\n", p.volume, p.volume_err);
        printf("centroid  %.15g %.15g %.15g\n", p.centroid[0], p.centroid[1], p.centroid[2]);
        printf("inertia about the centroid (density 1): Ixx Iyy Izz Ixy Iyz Ixz (+- %.2g)\n  ",
               p.inertia_err);
        for (int k = 0; k < 6; k++)
            printf(" %.15g", p.inertia[k]);
        printf("\n");
    }
    crisp_model_destroy(m);
    return 0;
}
