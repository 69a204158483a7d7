/* crisp-view's state and the functions its files share (main.c: arguments, the frame loop and
 * the replay commands; input.c: mouse and keys -> navigation, picking, measuring; panels.c: HUD,
 * help, face info, errors, progress, the axis widget; backend_cpu.c: the display backend). */
#ifndef VIEW_H
#define VIEW_H

#include <stdint.h>

#include "doc.h"
#include "events.h"
#include "loader.h"
#include "nav.h"
#include "watch.h"
#include "window.h"

/* ---- display backend: one small interface, so the GL backend can replace the CPU one ------- */

typedef struct view_frame_stats {
    double ms; /* render time of the frame */
    uint64_t triangles, table_bytes;
    int scale;        /* 1: full resolution; s: 1/s of the pixels in each direction */
    int samples;      /* per pixel */
    double min_depth; /* least camera-space depth drawn (inf: nothing) */
    double cover[4];  /* x0, y0, x1, y1 of the drawn pixels, full-size pixel units */
    uint32_t pending; /* faces whose splat sets later frames build (drawn as patches now:
                         crisp_plan_stats.splat_pending); the viewer draws again until 0 */
} view_frame_stats;

typedef struct view_overlay {
    int32_t selected_face; /* tinted; -1 none */
    int edges;             /* draw face borders, trims and silhouettes from the face ids */
    int samples;           /* per pixel in full-size frames (1 or 4); moving frames take 1 */
    int moving;            /* a frame while the camera moves: drawn from the motion plan (planned
                              once for a widened view, see view_backend.prepare_motion), without
                              ribbons; the GL backend presents it without reading it back when
                              nothing needs its AOVs (no_aovs) */
    int no_aovs;           /* nothing needs this frame's AOVs (no f-rep parts, no debugging
                              views): edges and tint are left out of moving GL frames */
} view_overlay;

typedef struct view_backend {
    const char *name;
    void *self;
    /* Render the document for cam at 1/scale of its size and keep it for present(). */
    crisp_status (*frame)(void *self, const app_doc *doc, const crisp_camera *cam, int scale,
                          const view_overlay *ov, view_frame_stats *stats);
    /* Draw the last frame over the framebuffer. */
    void (*present)(void *self, int fb_width, int fb_height);
    /* Render cam off-screen at its own size into img (colour and AOVs), as `crisp render`
     * with --samples samples. */
    crisp_status (*offscreen)(void *self, const app_doc *doc, const crisp_camera *cam, int samples,
                              crisp_image *img);
    /* The last frame's plan and image (AOVs), or NULL (a backend may keep neither). */
    const struct crisp_frame_plan *(*plan)(void *self);
    const crisp_image *(*image)(void *self);
    /* Plan (now, while the viewer is idle) the plan that frames drawn while the camera moves
     * will reuse, for cam at 1/scale of its size with the view widened to the box's sphere;
     * does nothing when the plan it has still serves cam. *more = 1: its splat sets are not all
     * built yet (crisp_plan_stats.splat_pending): call again while idle. */
    crisp_status (*prepare_motion)(void *self, const app_doc *doc, const crisp_camera *cam,
                                   int scale, int *more);
    /* The section plane for the next frames and off-screen renders (on = 0: none); box spaces
     * the cap's hatch (section.c). */
    void (*set_section)(void *self, int on, const double plane[4], const double box[6]);
    /* The transparent faces (NULL: none), drawn over the next frames and off-screen renders:
     * the nearest transparent surface blended over what is behind it (VIEW_ALPHA). */
    void (*set_transparent)(void *self, const app_doc *tdoc);
    /* A new document is shown (frames of the old one are gone). */
    void (*set_doc)(void *self, const app_doc *doc);
    void (*destroy)(void *self);
} view_backend;

/* The CPU backend, or (use_gl) the GL backend on the current window's context. */
crisp_status view_backend_create(int threads, int use_gl, view_backend *dest);
int view_backend_have_gl(void);

/* ---- the viewer --------------------------------------------------------------------------- */

typedef struct view_hit {
    int hit;
    int32_t face; /* >= 0 NURBS face, <= -2 f-rep part */
    double point[3], normal[3], uv[2], depth;
} view_hit;

typedef struct view view;

struct view {
    GLFWwindow *win;
    int fb_w, fb_h;
    view_backend backend;
    app_doc *doc;
    char *doc_path; /* what R reloads (the last path asked for) */
    app_loader *loader;
    app_watch watch;
    app_nav nav;
    int have_camera;      /* the camera belongs to the document shown (keep it on reload) */
    char *initial_camera; /* --camera options for the first document */

    /* frames */
    int dirty;            /* the camera or the overlay changed since the last frame */
    int refined;          /* the frame on screen is the full-resolution image of this camera */
    int moving;           /* the camera changed this frame */
    int scale;            /* resolution divisor while moving, adapted to the frame time */
    int motion_ready;     /* the backend's motion plan was prepared for the camera on screen */
    double last_moving_t; /* when the last moving frame was rendered (0: the last was not) */
    view_frame_stats last;
    double last_full_ms;

    /* input */
    double mx, my;   /* cursor */
    int drag_button; /* -1 none */
    int drag_mods;
    double press_x, press_y, drag_depth;
    int dragged;
    double pivot[3];
    int shift;

    /* section view */
    int section, section_axis, section_flip;
    double section_pos; /* the plane is x[section_axis] = section_pos */
    int section_set;    /* section_pos was placed for this document */

    /* inspection */
    view_overlay ov;
    view_hit sel, meas_a, meas_b;
    int meas_count; /* 0, 1 (A) or 2 (A and B) */
    int snap;       /* clicks snap to the face's vertices within 8 px (V) */
    char face_info[1024];

    /* panels */
    int show_hud, show_help, show_panels;
    char error[2048];
    double error_time;
    char camera_text[512];

    /* scripted runs */
    app_player player;
    int replaying, exit_after_replay;
    int quit;
    const char *screenshot_path;
    char window_shot[1024]; /* the replay's `window PATH`: pending */
    int shot_w, shot_h;
    int exit_code;
    int threads;
    int no_lowres; /* every frame at full size (for measuring the low-res frames) */
    /* show / hide (visible.c): rdoc is what is drawn and picked; with something hidden its
     * scene is prepared from a shallow copy of the visible faces, and vis_map takes its face
     * indices back to the document's */
    app_doc rdoc;
    uint8_t *face_hidden, *part_hidden; /* face_hidden: 0 shown, 1 hidden, 2 transparent */
    uint32_t hidden_faces, hidden_parts;
    crisp_model vis_model;
    crisp_scene *vis_scene;
    uint32_t *vis_map;
    crisp_frep_part *vis_parts;
    /* transparency per face (face_hidden[f] == 2): drawn from a scene of their own (tdoc) and
     * composited over the opaque image by depth */
    uint32_t trans_faces;
    int *body_ids; /* body_count distinct crisp_face.body values (visible.c) */
    int body_count;
    crisp_model trans_model;
    crisp_scene *trans_scene;
    app_doc tdoc;
    /* debugging views (debugviews.c) */
    int show_wire, show_scan;
    float *wire; /* segments x0 y0 x1 y1 in window pixels */
    size_t wire_count, wire_cap;
    int wire_truncated;
    uint32_t wire_leaves;
    long frames;
};

/* main.c */
void view_open(view *v, const char *path, int keep_camera);
void view_set_error(view *v, const char *fmt, ...);
void view_print_camera(view *v);
void view_sync_section(view *v); /* hand the section plane to the backend */
crisp_status view_screenshot(view *v, const char *png, const char *exr, int w, int h);
int view_idle(view *v);

/* input.c: GLFW callbacks (the replay calls the same ones) */
void view_install_callbacks(view *v);
void view_on_cursor(GLFWwindow *w, double x, double y);
void view_on_button(GLFWwindow *w, int button, int action, int mods);
void view_on_scroll(GLFWwindow *w, double dx, double dy);
void view_on_key(GLFWwindow *w, int key, int scancode, int action, int mods);
void view_on_char(GLFWwindow *w, unsigned int c);
void view_on_drop(GLFWwindow *w, int count, const char **paths);
void view_on_close(GLFWwindow *w);
int view_pick(view *v, double x, double y, view_hit *dest);
void view_describe_face(view *v, int32_t face, char *buf, size_t size);
void view_set_standard(view *v, int which);

/* visible.c */
void view_visible_reset(view *v);  /* a new document: everything shown */
void view_visible_update(view *v); /* after face_hidden / part_hidden changed */
void view_visible_free(view *v);
/* The document's face index of a face of the drawn scene (and back: -1 when hidden). */
int32_t view_doc_face(const view *v, int32_t drawn);
int32_t view_drawn_face(const view *v, int32_t doc_face);
void view_parts_panel(view *v);
/* Bodies (distinct non-zero crisp_face.body, numbered 1.. in order of first face): faces of
 * body `index` and whether any is shown; show / hide them all. */
int view_body_faces(const view *v, int body, int *shown);
void view_body_show(view *v, int body, int show);
/* The assembly tree (crisp_model.occurrences): faces of occurrence k (0-based) and its
 * descendants, whether any is shown; show / hide them all. */
int view_occurrence_faces(const view *v, int k, int *shown);
void view_occurrence_show(view *v, int k, int show);

/* section.c: the section plane (X toggles, N next axis, shift+N flips, - and = move it) */
#define VIEW_CAP_FACE (-1000000)                        /* the face id of cap pixels */
#define VIEW_ALPHA 0.35f                                /* opacity of a transparent face */
int view_section_plane(const view *v, double plane[4]); /* 0: no section */
void view_print_section(const view *v);                 /* "section: ..." on stdout */
void view_section_key(view *v, int key, int mods);      /* X, N, -, = */
/* The hatch's line direction over its spacing: lines where dot(hu, P) is near an integer. */
void view_section_hatch(const double plane[4], const double box[6], double hu[3]);
/* Paint the cut where the image shows the back of a surface behind the plane. */
void view_section_cap(const crisp_camera *cam, const double plane[4], const double box[6],
                      crisp_image *img);

/* debugviews.c */
void view_wire_update(view *v);
void view_wire_draw(view *v);
void view_scan_panel(view *v);

/* panels.c */
void view_draw_panels(view *v);
/* The axis widget's centre and the screen tip of each axis (+X, +Y, +Z, -X, -Y, -Z). */
void view_axis_widget(const view *v, float centre[2], float tips[6][2]);

#endif
