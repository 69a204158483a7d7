/* The window of the GL apps: GLFW with an OpenGL 4.5 core context (llvmpipe under Xvfb gives one
 * on machines without a GPU), GL functions through glad, and an image view that shows an RGBA8
 * image over a background gradient (straight alpha = coverage), scaled to the framebuffer.
 *
 * Offers:
 *   app_window_create/_destroy   window + context + loader; errors as text
 *   app_image_view               a texture and the program that draws it
 *   app_image_view_init/_upload/_draw/_free
 *   app_gl_program               a vertex + fragment program; the GL log as text on failure
 */
#ifndef APP_WINDOW_H
#define APP_WINDOW_H

#include <stddef.h>
#include <stdint.h>

#include <glad/gl.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct app_window_desc {
    const char *title;
    int width, height; /* 0: 1280 x 720 */
    int hidden;        /* 1: not shown (off-screen work) */
    int no_vsync;      /* 1: swap without waiting for the display */
} app_window_desc;

GLFWwindow *app_window_create(const app_window_desc *desc, char *err, size_t err_size);
void app_window_destroy(GLFWwindow *w);

typedef struct app_image_view {
    GLuint program, vao, tex;
    int tex_w, tex_h;
} app_image_view;

/* Compiles and links a vertex and a fragment shader; 0 with the compile or link log in LOG. */
GLuint app_gl_program(const char *vs, const char *fs, char *log, size_t size);

int app_image_view_init(app_image_view *v, char *err, size_t err_size);
/* width x height RGBA8 pixels, row 0 at the top. */
void app_image_view_upload(app_image_view *v, int width, int height, const uint8_t *rgba);
/* The texture for a width x height image drawn on the GPU (e.g. blitted into through a
 * framebuffer of the caller's), row 0 at the top as with upload. */
GLuint app_image_view_target(app_image_view *v, int width, int height);
/* Draw the image over the whole framebuffer (nearest filtering when magnified by an integer). */
void app_image_view_draw(app_image_view *v, int fb_width, int fb_height);
void app_image_view_free(app_image_view *v);

#ifdef __cplusplus
}
#endif
#endif
