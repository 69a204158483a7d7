/* crisp-view's section view: a plane normal to X, Y or Z (either way) that the backends clip
 * the faces with (crisp_render_desc.clip_plane, crisp_gl_desc.clip_plane, the moving frames'
 * clip distance), and the cap that closes the cut: where the first surface left behind the
 * plane is seen from its back (its normal, which follows the face's orientation, points along
 * the view direction) and the plane lies between the eye and it, the pixel shows the plane
 * there, hatched (45-degree lines in the plane, 1/60 of the box diagonal apart, fixed to the
 * model) and given its own face id (VIEW_CAP_FACE) so the edge overlay draws the section's
 * outline. For a closed, consistently oriented solid this is exactly the inside of the cut; an
 * open shell seen from behind through the plane is hatched too. F-rep parts are not cut. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "view.h"

int view_section_plane(const view *v, double plane[4])
{
    if (!v->section) return 0;
    double s = v->section_flip ? -1 : 1;
    memset(plane, 0, 4 * sizeof *plane);
    plane[v->section_axis] = s;
    plane[3] = -s * v->section_pos;
    return 1;
}

void view_section_hatch(const double plane[4], const double box[6], double hu[3])
{
    /* the in-plane directions: the two other axes; lines along their difference */
    int a = fabs(plane[0]) > 0.5 ? 0 : fabs(plane[1]) > 0.5 ? 1 : 2;
    double diag =
        sqrt((box[3] - box[0]) * (box[3] - box[0]) + (box[4] - box[1]) * (box[4] - box[1]) +
             (box[5] - box[2]) * (box[5] - box[2]));
    double spacing = diag > 0 ? diag / 60 : 1;
    for (int k = 0; k < 3; k++)
        hu[k] = k == a ? 0 : 1 / spacing;
}

void view_section_cap(const crisp_camera *cam, const double plane[4], const double box[6],
                      crisp_image *img)
{
    double hu[3], f[3];
    view_section_hatch(plane, box, hu);
    for (int k = 0; k < 3; k++)
        f[k] = cam->target[k] - cam->eye[k];
    double fl = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    double ne = plane[0] * cam->eye[0] + plane[1] * cam->eye[1] + plane[2] * cam->eye[2] + plane[3];
    float cut[3] = {0.80f, 0.62f, 0.42f}, line[3] = {0.30f, 0.20f, 0.12f};
    for (int j = 0; j < img->height; j++)
        for (int i = 0; i < img->width; i++) {
            size_t k = (size_t)j * img->width + i;
            if (img->face[k] < 0) continue;
            double o[3], d[3];
            crisp_camera_ray(cam, i + 0.5, j + 0.5, o, d);
            const float *n = img->normal + 3 * k;
            if (!(n[0] * d[0] + n[1] * d[1] + n[2] * d[2] > 0)) continue; /* a front face */
            double nd = plane[0] * d[0] + plane[1] * d[1] + plane[2] * d[2];
            if (nd == 0) continue;
            double t = -ne / nd;
            double depth = t * (d[0] * f[0] + d[1] * f[1] + d[2] * f[2]) / fl;
            if (!(t > 0) || !(depth < img->depth[k])) continue; /* the plane is not in front */
            double P[3], s = 0;
            for (int q = 0; q < 3; q++) {
                P[q] = o[q] + t * d[q];
                s += hu[q] * P[q];
            }
            int on_line = s - floor(s) < 0.18;
            for (int q = 0; q < 3; q++) {
                img->rgba[4 * k + q] = on_line ? line[q] : cut[q];
                img->normal[3 * k + q] = (float)(nd > 0 ? -plane[q] : plane[q]);
            }
            img->rgba[4 * k + 3] = 1;
            img->depth[k] = (float)depth;
            img->face[k] = VIEW_CAP_FACE;
            img->uv[2 * k] = img->uv[2 * k + 1] = 0;
        }
}

void view_print_section(const view *v)
{
    double p[4];
    if (!view_section_plane(v, p)) {
        printf("section: off\n");
        return;
    }
    printf("section: %c = %.17g%s plane %g %g %g %.17g\n", 'x' + v->section_axis, v->section_pos,
           v->section_flip ? " flip" : "", p[0], p[1], p[2], p[3]);
}

void view_section_key(view *v, int key, int mods)
{
    if (!v->doc) return;
    const double *box = v->doc->box;
    if (key == GLFW_KEY_X) {
        v->section = !v->section;
        if (v->section && !v->section_set) { /* first time: through the middle of the box */
            v->section_pos = 0.5 * (box[v->section_axis] + box[v->section_axis + 3]);
            /* the kept side away from the eye: the cut faces the viewer */
            v->section_flip = v->nav.cam.eye[v->section_axis] > v->section_pos;
            v->section_set = 1;
        }
    } else if (!v->section) {
        return;
    } else if (key == GLFW_KEY_N && (mods & GLFW_MOD_SHIFT)) {
        v->section_flip = !v->section_flip;
    } else if (key == GLFW_KEY_N) {
        v->section_axis = (v->section_axis + 1) % 3;
        v->section_pos = 0.5 * (box[v->section_axis] + box[v->section_axis + 3]);
        v->section_flip = v->nav.cam.eye[v->section_axis] > v->section_pos;
    } else if (key == GLFW_KEY_MINUS || key == GLFW_KEY_EQUAL) {
        int a = v->section_axis;
        double step = (box[a + 3] - box[a]) / 50;
        v->section_pos += key == GLFW_KEY_EQUAL ? step : -step;
    } else {
        return;
    }
    view_print_section(v);
    v->dirty = 1;
}
