/* A headless OpenGL 4.5 core context through EGL (docs/design.md section 6): the surfaceless
 * platform (EGL_MESA_platform_surfaceless, no X server, no surface: the backend draws into its own
 * framebuffers), then the device platform (EGL_EXT_platform_device, what GPU drivers offer
 * headless) when the first gives no 4.5 core context. */
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/gl.h"

struct crisp_gl_context {
    EGLDisplay dpy;
    EGLContext ctx;
    const char *platform;
};

static int has_ext(const char *list, const char *name)
{
    size_t n = strlen(name);
    for (const char *p = list; p && (p = strstr(p, name)); p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return 1;
    return 0;
}

/* Initialise dpy and create a 4.5 core context on it; on failure writes why into why. */
static int try_display(EGLDisplay dpy, crisp_gl_context *c, char *why, size_t why_size)
{
    EGLint major, minor;
    if (dpy == EGL_NO_DISPLAY) {
        snprintf(why, why_size, "no display (EGL error 0x%x)", (unsigned)eglGetError());
        return 0;
    }
    if (!eglInitialize(dpy, &major, &minor)) {
        snprintf(why, why_size, "eglInitialize failed (EGL error 0x%x)", (unsigned)eglGetError());
        return 0;
    }
    const char *ext = eglQueryString(dpy, EGL_EXTENSIONS);
    if (!has_ext(ext, "EGL_KHR_surfaceless_context")) {
        snprintf(why, why_size, "EGL %d.%d without EGL_KHR_surfaceless_context", major, minor);
        eglTerminate(dpy);
        return 0;
    }
    if (!eglBindAPI(EGL_OPENGL_API)) {
        snprintf(why, why_size, "no desktop OpenGL API in EGL (EGL error 0x%x)",
                 (unsigned)eglGetError());
        eglTerminate(dpy);
        return 0;
    }
    EGLint cattr[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig cfg = NULL;
    EGLint n = 0;
    EGLConfig use = EGL_NO_CONFIG_KHR;
    if (eglChooseConfig(dpy, cattr, &cfg, 1, &n) && n > 0)
        use = cfg;
    else if (!has_ext(ext, "EGL_KHR_no_config_context")) {
        snprintf(why, why_size, "no EGL config renders OpenGL");
        eglTerminate(dpy);
        return 0;
    }
    EGLint attr[] = {EGL_CONTEXT_MAJOR_VERSION,
                     4,
                     EGL_CONTEXT_MINOR_VERSION,
                     5,
                     EGL_CONTEXT_OPENGL_PROFILE_MASK,
                     EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                     EGL_NONE};
    EGLContext ctx = eglCreateContext(dpy, use, EGL_NO_CONTEXT, attr);
    if (ctx == EGL_NO_CONTEXT) {
        snprintf(why, why_size, "no OpenGL 4.5 core context (EGL error 0x%x)",
                 (unsigned)eglGetError());
        eglTerminate(dpy);
        return 0;
    }
    if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
        snprintf(why, why_size,
                 "cannot make the context current without a surface (EGL error 0x%x)",
                 (unsigned)eglGetError());
        eglDestroyContext(dpy, ctx);
        eglTerminate(dpy);
        return 0;
    }
    c->dpy = dpy;
    c->ctx = ctx;
    return 1;
}

crisp_status crisp_gl_context_create(crisp_gl_context **dest)
{
    crisp_gl_context *c = calloc(1, sizeof *c);
    if (!c) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory creating a GL context");
    const char *client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    char why_s[200] = "EGL_MESA_platform_surfaceless missing",
         why_d[200] = "EGL_EXT_platform_device missing";
    if (!client) {
        free(c);
        return crisp_error(CRISP_ERR_GL,
                           "no usable OpenGL: EGL has no client extensions (EGL error 0x%x); "
                           "install libegl1 and a Mesa or GPU EGL driver (libegl-mesa0)",
                           (unsigned)eglGetError());
    }
    PFNEGLGETPLATFORMDISPLAYEXTPROC get_display =
        (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress("eglGetPlatformDisplayEXT");
    if (get_display && has_ext(client, "EGL_MESA_platform_surfaceless") &&
        try_display(get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL), c, why_s,
                    sizeof why_s)) {
        c->platform = "EGL surfaceless";
        *dest = c;
        return CRISP_OK;
    }
    PFNEGLQUERYDEVICESEXTPROC query_devices =
        (PFNEGLQUERYDEVICESEXTPROC)eglGetProcAddress("eglQueryDevicesEXT");
    if (get_display && query_devices && has_ext(client, "EGL_EXT_platform_device")) {
        EGLDeviceEXT devs[16];
        EGLint n = 0;
        if (!query_devices(16, devs, &n) || n == 0) snprintf(why_d, sizeof why_d, "no EGL device");
        for (EGLint i = 0; i < n; i++)
            if (try_display(get_display(EGL_PLATFORM_DEVICE_EXT, devs[i], NULL), c, why_d,
                            sizeof why_d)) {
                c->platform = "EGL device";
                *dest = c;
                return CRISP_OK;
            }
    }
    free(c);
    return crisp_error(
        CRISP_ERR_GL,
        "no usable OpenGL 4.5 core context: EGL surfaceless platform: %s; EGL device "
        "platform: %s (is Mesa's libegl-mesa0 and libgl1-mesa-dri, or a GPU driver's "
        "EGL, installed?)",
        why_s, why_d);
}

void crisp_gl_context_destroy(crisp_gl_context *c)
{
    if (!c) return;
    eglMakeCurrent(c->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(c->dpy, c->ctx);
    eglTerminate(c->dpy);
    free(c);
}

crisp_status crisp_gl_context_make_current(crisp_gl_context *c)
{
    if (!eglMakeCurrent(c->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, c->ctx))
        return crisp_error(CRISP_ERR_GL, "eglMakeCurrent failed (EGL error 0x%x)",
                           (unsigned)eglGetError());
    return CRISP_OK;
}

static crisp_gl_proc egl_getproc(const char *name)
{
    return (crisp_gl_proc)eglGetProcAddress(name);
}

crisp_gl_getproc_fn crisp_gl_context_getproc(const crisp_gl_context *c)
{
    (void)c;
    return egl_getproc;
}

const char *crisp_gl_context_platform(const crisp_gl_context *c)
{
    return c->platform;
}
