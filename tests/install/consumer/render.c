/* A program outside crisp's tree: opens a model, frames it with the default camera, renders it
 * with the CPU backend and writes a PNG, through the installed public API only. */
#include <stdio.h>
#include <string.h>

#include <crisp/crisp.h>

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: %s MODEL OUT.png\n", argv[0]);
        return 2;
    }
    if (strcmp(crisp_version(), CRISP_VERSION_STRING) != 0) {
        fprintf(stderr, "library %s, headers %s\n", crisp_version(), CRISP_VERSION_STRING);
        return 1;
    }
    crisp_document *doc = NULL;
    crisp_camera cam;
    crisp_image img = {0};
    crisp_status st = crisp_image_output_check(argv[2], CRISP_IMAGE_PNG);
    if (!st) st = crisp_document_open(argv[1], NULL, &doc);
    if (!st)
        st = crisp_document_camera(doc, &(crisp_camera_desc){.width = 160, .height = 120}, &cam);
    if (!st) st = crisp_image_init(&img, cam.width, cam.height);
    if (!st)
        st = crisp_document_render(doc, &cam, &(crisp_document_render_desc){.samples = 4}, &img,
                                   NULL);
    if (!st) st = crisp_image_write(&img, argv[2]);
    if (st) fprintf(stderr, "%s: %s\n", crisp_status_name(st), crisp_error_message());
    crisp_image_free(&img);
    crisp_document_destroy(doc);
    return st ? 1 : 0;
}
