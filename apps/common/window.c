/* GLFW window + GL 4.5 core context + glad (window.h), and the image view's GLSL. */
#include "window.h"

#include <stdio.h>
#include <string.h>

static char glfw_err[512];

static void on_glfw_error(int code, const char *msg)
{
    snprintf(glfw_err, sizeof glfw_err, "GLFW error 0x%x: %s", code, msg);
}

GLFWwindow *app_window_create(const app_window_desc *desc, char *err, size_t err_size)
{
    glfwSetErrorCallback(on_glfw_error);
    if (!glfwInit()) {
        snprintf(err, err_size,
                 "cannot open a window (%s); is DISPLAY set? (under CI: xvfb-run -a)",
                 glfw_err[0] ? glfw_err : "glfwInit failed");
        return NULL;
    }
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_VISIBLE, desc->hidden ? GLFW_FALSE : GLFW_TRUE);
    glfwWindowHint(GLFW_SCALE_TO_MONITOR, GLFW_FALSE);
    int w = desc->width > 0 ? desc->width : 1280, h = desc->height > 0 ? desc->height : 720;
    GLFWwindow *win = glfwCreateWindow(w, h, desc->title ? desc->title : "crisp", NULL, NULL);
    if (!win) {
        snprintf(err, err_size, "cannot create a %dx%d window with OpenGL 4.5 core (%s)", w, h,
                 glfw_err);
        glfwTerminate();
        return NULL;
    }
    glfwMakeContextCurrent(win);
    if (!gladLoadGL((GLADloadfunc)glfwGetProcAddress)) {
        snprintf(err, err_size, "cannot load the OpenGL 4.5 functions");
        glfwDestroyWindow(win);
        glfwTerminate();
        return NULL;
    }
    glfwSwapInterval(desc->no_vsync ? 0 : 1);
    return win;
}

void app_window_destroy(GLFWwindow *w)
{
    if (w) glfwDestroyWindow(w);
    glfwTerminate();
}

static const char *vs_src = "#version 450 core\n"
                            "out vec2 uv;\n"
                            "void main() {\n"
                            "  vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);\n"
                            "  uv = p;\n"
                            "  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);\n"
                            "}\n";

/* Background: a vertical grey-blue gradient; the image over it with straight alpha. */
static const char *fs_src =
    "#version 450 core\n"
    "in vec2 uv;\n"
    "layout(binding = 0) uniform sampler2D img;\n"
    "out vec4 color;\n"
    "void main() {\n"
    "  vec4 c = texture(img, vec2(uv.x, 1.0 - uv.y));\n"
    "  vec3 bg = mix(vec3(0.16, 0.17, 0.20), vec3(0.42, 0.45, 0.52), uv.y);\n"
    "  color = vec4(mix(bg, c.rgb, c.a), 1.0);\n"
    "}\n";

static GLuint compile(GLenum type, const char *src, char *log, size_t size)
{
    GLuint s = glCreateShader(type);
    glShaderSource(s, 1, &src, NULL);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        glGetShaderInfoLog(s, (GLsizei)size, NULL, log);
        glDeleteShader(s);
        return 0;
    }
    return s;
}

GLuint app_gl_program(const char *vs, const char *fs, char *log, size_t size)
{
    GLuint a = compile(GL_VERTEX_SHADER, vs, log, size);
    GLuint b = a ? compile(GL_FRAGMENT_SHADER, fs, log, size) : 0;
    if (!b) {
        glDeleteShader(a);
        return 0;
    }
    GLuint p = glCreateProgram();
    glAttachShader(p, a);
    glAttachShader(p, b);
    glLinkProgram(p);
    glDeleteShader(a);
    glDeleteShader(b);
    GLint ok = 0;
    glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        glGetProgramInfoLog(p, (GLsizei)size, NULL, log);
        glDeleteProgram(p);
        return 0;
    }
    return p;
}

int app_image_view_init(app_image_view *v, char *err, size_t err_size)
{
    memset(v, 0, sizeof *v);
    char log[512] = "";
    v->program = app_gl_program(vs_src, fs_src, log, sizeof log);
    if (!v->program) {
        snprintf(err, err_size, "image view shader: %s", log);
        return 0;
    }
    glCreateVertexArrays(1, &v->vao);
    return 1;
}

GLuint app_image_view_target(app_image_view *v, int width, int height)
{
    if (!v->tex || v->tex_w != width || v->tex_h != height) {
        if (v->tex) glDeleteTextures(1, &v->tex);
        glCreateTextures(GL_TEXTURE_2D, 1, &v->tex);
        glTextureStorage2D(v->tex, 1, GL_RGBA8, width, height);
        glTextureParameteri(v->tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(v->tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        v->tex_w = width;
        v->tex_h = height;
    }
    return v->tex;
}

void app_image_view_upload(app_image_view *v, int width, int height, const uint8_t *rgba)
{
    app_image_view_target(v, width, height);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTextureSubImage2D(v->tex, 0, 0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
}

void app_image_view_draw(app_image_view *v, int fb_width, int fb_height)
{
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, fb_width, fb_height);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    if (!v->tex) {
        glClearColor(0.25f, 0.27f, 0.31f, 1);
        glClear(GL_COLOR_BUFFER_BIT);
        return;
    }
    int exact = v->tex_w == fb_width && v->tex_h == fb_height;
    GLint filter = exact ? GL_NEAREST : GL_LINEAR;
    glTextureParameteri(v->tex, GL_TEXTURE_MIN_FILTER, filter);
    glTextureParameteri(v->tex, GL_TEXTURE_MAG_FILTER, filter);
    glUseProgram(v->program);
    glBindTextureUnit(0, v->tex);
    glBindVertexArray(v->vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    glUseProgram(0);
}

void app_image_view_free(app_image_view *v)
{
    if (v->tex) glDeleteTextures(1, &v->tex);
    if (v->vao) glDeleteVertexArrays(1, &v->vao);
    if (v->program) glDeleteProgram(v->program);
    memset(v, 0, sizeof *v);
}
