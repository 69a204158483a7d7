/* Issue 14: crisp mass on the bundled NURBS models: closed or not (the faces' vector area against
 * their area), area, volume, centroid, time. usage: bench_brep_mass [MODEL [faces]] (faces: the
 * area and vector area of every face, to find the faces that keep a shell from closing). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bench_util.h"
#include "crisp/io.h"
#include "crisp/mass.h"

static void one(const char *path, int faces)
{
    crisp_model *m;
    if (crisp_model_load(path, NULL, &m)) {
        printf("| %s | load failed: %s |\n", path, crisp_error_message());
        return;
    }
    if (faces) {
        for (int i = 0; i < m->face_count; i++) {
            crisp_model one = *m;
            one.faces = &m->faces[i];
            one.face_count = 1;
            crisp_mass_props p;
            crisp_mass_model(&one, NULL, &p);
            printf("face %d source %d reversed %d loops %d degree %d,%d rational %d: area %.9g "
                   "vector area %.9g %.9g %.9g\n",
                   i, m->faces[i].source_id, m->faces[i].reversed, m->faces[i].loop_count,
                   m->faces[i].surface->degree_u, m->faces[i].surface->degree_v,
                   m->faces[i].surface->rational, p.area, p.vector_area[0], p.vector_area[1],
                   p.vector_area[2]);
        }
    }
    crisp_mass_props p;
    double t0 = crisp_time_now();
    crisp_status s = crisp_mass_model(m, NULL, &p);
    double dt = crisp_time_now() - t0;
    const char *name = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    double va = sqrt(p.vector_area[0] * p.vector_area[0] + p.vector_area[1] * p.vector_area[1] +
                     p.vector_area[2] * p.vector_area[2]);
    if (s)
        printf("| %s | %d | error: %s |\n", name, m->face_count, crisp_error_message());
    else if (p.closed)
        printf("| %s | %d | closed | %.10g | %.12g +- %.1g | %.6g %.6g %.6g | %.3f |\n", name,
               m->face_count, p.area, p.volume, p.volume_err, p.centroid[0], p.centroid[1],
               p.centroid[2], dt);
    else
        printf("| %s | %d | open: vector area / area %.2g | %.10g | - | - | %.3f |\n", name,
               m->face_count, va / p.area, p.area, dt);
    crisp_model_destroy(m);
}

int main(int argc, char **argv)
{
    bench_print_machine(stdout);
    printf("| model | faces | closed | area | volume | centroid | time s "
           "|\n|---|---:|---|---:|---:|---|---:|\n");
    if (argc > 1) {
        one(argv[1], argc > 2);
        return 0;
    }
    const char *models[] = {
        "Ventilator.stp",     "gpucast_part.igs",        "gpucast_teapot.igs",   "impeller.igs",
        "occt_as1_ec.stp",    "occt_bearing.iges",       "occt_bm2_pe_t4_b.stp", "occt_hammer.iges",
        "occt_linkrods.step", "occt_trj4_k1_geo_tu.stp", "occt_trj9_io1.stp"};
    for (size_t i = 0; i < sizeof models / sizeof *models; i++) {
        char path[512];
        snprintf(path, sizeof path, "%s/nurbs/%s", CRISP_DATA_DIR, models[i]);
        one(path, 0);
        fflush(stdout);
    }
    return 0;
}
