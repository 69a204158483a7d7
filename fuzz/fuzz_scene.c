/* libFuzzer target for the scene-file reader (src/io/scene.c): any input must either parse or
 * fail with a message, without crashes, leaks, hangs or unbounded allocation. Parsed scenes are
 * not loaded (that would open files named by the input); their inline math parts are read and
 * rendered small through a fixed camera, so transforms reach the f-rep compositing path. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "crisp/frep.h"
#include "crisp/render.h"
#include "crisp/scene_file.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    crisp_scene_file *s = NULL;
    if (crisp_scene_file_read_mem("fuzz.scene", "dir", (const char *)data, size, &s) != CRISP_OK)
        return 0;
    crisp_camera cam = {.eye = {0, 0, 5},
                        .target = {0, 0, 0},
                        .up = {0, 1, 0},
                        .fov_deg = 40,
                        .znear = 0.1,
                        .zfar = 20,
                        .width = 12,
                        .height = 9};
    crisp_image img;
    int parts = 0;
    if (crisp_image_init(&img, cam.width, cam.height) == CRISP_OK) {
        for (size_t i = 0; i < s->item_count && parts < 4; i++) {
            const crisp_scene_item *it = &s->items[i];
            if (!it->math) continue;
            crisp_frep *f = NULL;
            crisp_frep_tape *t = NULL;
            if (crisp_frep_read_math_mem("fuzz", it->math, strlen(it->math), &f) == CRISP_OK &&
                crisp_frep_tape_create(f, &t) == CRISP_OK) {
                crisp_frep_part part = {.tape = t};
                memcpy(part.transform, it->transform, sizeof part.transform);
                (void)crisp_render_frep_parts(&part, 1, &cam,
                                              &(crisp_frep_parts_desc){.threads = 1}, &img);
                parts++;
            }
            crisp_frep_tape_destroy(t);
            crisp_frep_destroy(f);
        }
        crisp_image_free(&img);
    }
    crisp_scene_file_destroy(s);
    return 0;
}
