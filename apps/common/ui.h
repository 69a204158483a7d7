/* A thin C face over Dear ImGui (Debian's libimgui-dev 1.86, its GLFW and OpenGL 3 backends) for
 * the window apps: frame begin/end, input forwarding (the apps install their own GLFW callbacks
 * and forward here, so replayed events take the same path), the few widgets the panels use and
 * foreground drawing for overlays (markers, the axis widget).
 *
 * Offers: app_ui_* (below).
 */
#ifndef APP_UI_H
#define APP_UI_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct GLFWwindow GLFWwindow;

int app_ui_init(GLFWwindow *w);
void app_ui_shutdown(void);
void app_ui_frame_begin(void);
void app_ui_frame_end(void); /* renders into the current framebuffer */
int app_ui_wants_mouse(void);
int app_ui_wants_keyboard(void);

/* Forwarding of GLFW events. */
void app_ui_on_button(GLFWwindow *w, int button, int action, int mods);
void app_ui_on_scroll(GLFWwindow *w, double dx, double dy);
void app_ui_on_key(GLFWwindow *w, int key, int scancode, int action, int mods);
void app_ui_on_char(GLFWwindow *w, unsigned int c);

/* Widgets. Windows: x, y where it first appears (negative: from the right / bottom edge). */
enum { APP_UI_AUTO = 1, APP_UI_OVERLAY = 2 };
int app_ui_begin(const char *title, float x, float y, float width, int flags);
void app_ui_end(void);
void app_ui_text(const char *fmt, ...);
void app_ui_text_color(float r, float g, float b, const char *fmt, ...);
void app_ui_wrapped(const char *fmt, ...);
int app_ui_button(const char *label);
int app_ui_checkbox(const char *label, int *value);
void app_ui_same_line(void);
void app_ui_separator(void);
void app_ui_progress(float fraction, const char *overlay);
int app_ui_tree_node(const char *label, int leaf, int selected, int *clicked);
void app_ui_tree_pop(void);

/* A w x h drawing area in the current window; origin gets its top-left corner in window pixels.
 * app_ui_wline / app_ui_wrect draw into the current window (clipped to it). */
void app_ui_canvas(float w, float h, float origin[2]);
void app_ui_wline(float x0, float y0, float x1, float y1, uint32_t color, float thickness);
void app_ui_wrect(float x0, float y0, float x1, float y1, uint32_t color);

/* Foreground drawing in window pixels; colour as 0xAABBGGRR. */
void app_ui_line(float x0, float y0, float x1, float y1, uint32_t color, float thickness);
void app_ui_circle(float x, float y, float r, uint32_t color, int filled);
void app_ui_label(float x, float y, uint32_t color, const char *text);
/* A line behind every window (over the 3D view only). */
void app_ui_bline(float x0, float y0, float x1, float y1, uint32_t color, float thickness);

#ifdef __cplusplus
}
#endif
#endif
