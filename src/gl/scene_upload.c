/* The GL backend's entry points on a prepared scene (crisp_scene's flat control points and patch
 * records, the faces' colours). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/gl.h"
#include "gl_internal.h"

crisp_status crisp_gl_set_scene(crisp_gl *gl, const crisp_scene *sc)
{
    float *colors = malloc(((size_t)sc->face_count + 1) * 4 * sizeof(float));
    if (!colors) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory uploading the scene");
    for (uint32_t f = 0; f < sc->face_count; f++)
        memcpy(colors + 4 * f, sc->faces[f].color, 4 * sizeof(float));
    crisp_gl_scene_data d = {
        sc->control_points, sc->control_point_count, sc->patch_records, sc->patch_count, colors,
        sc->face_count};
    crisp_status st = crisp_gl_set_scene_data(gl, &d);
    free(colors);
    if (!st) crisp__gl_scene_is(gl, sc);
    return st;
}

crisp_status crisp_gl_render(crisp_gl *gl, const crisp_scene *scene, const crisp_frame_plan *plan,
                             crisp_image *img, crisp_gl_stats *stats)
{
    crisp_status st = CRISP_OK;
    /* Always: another scene (or plan) may sit at the address of a freed one. */
    st = crisp_gl_set_scene(gl, scene);
    if (!st) st = crisp_gl_draw(gl, plan, stats);
    if (!st) st = crisp_gl_read(gl, img, stats);
    return st;
}

crisp_status crisp_gl_render_once(const crisp_scene *scene, const crisp_camera *cam, int samples,
                                  crisp_image *img, crisp_gl_stats *stats, char *renderer,
                                  size_t renderer_size)
{
    crisp_gl_context *ctx = NULL;
    crisp_gl *gl = NULL;
    crisp_planner *planner = NULL;
    const crisp_frame_plan *plan = NULL;
    crisp_status st = crisp_gl_context_create(&ctx);
    if (!st)
        st = crisp_gl_create(crisp_gl_context_getproc(ctx), &(crisp_gl_desc){.samples = samples},
                             &gl);
    if (!st && renderer && renderer_size)
        snprintf(renderer, renderer_size, "%s", crisp_gl_renderer(gl));
    if (!st) st = crisp_planner_create(NULL, NULL, &planner);
    if (!st) st = crisp_planner_plan(planner, scene, cam, &plan);
    if (!st) st = crisp_gl_render(gl, scene, plan, img, stats);
    crisp_planner_destroy(planner);
    crisp_gl_destroy(gl);
    crisp_gl_context_destroy(ctx);
    return st;
}
