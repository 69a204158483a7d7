/* The trim-editing demo's state and behaviour without the window (issue 11): one face of a
 * model under edit (crisp_trimedit), its scene, a planner, two linked views (the trimmed face in
 * 3D, its (u, v) domain in 2D), what the mouse and keys do in each, the per-frame work (only the
 * edited face is re-planned after an edit: crisp_scene_update_trim + crisp_planner_replan_face),
 * the timings shown, and the 2D view's drawing (loops, control polygons and points with their
 * weights, knots, the v-strips and scan lines of the current frame's table) as lines and circles
 * handed to the caller. The window (main.c: GLFW, Dear ImGui, the GL backend, event replay from
 * apps/common) forwards its events here, so a test drives the same code without a window.
 *
 * Input uses GLFW's codes (buttons, actions, keys, modifier bits).
 *
 * Mouse, 2D view: left-drag a control point (snap to the domain edge when snap is on); shift +
 * left-drag inside a loop moves the loop, ctrl + left-drag rotates it about its centre, alt +
 * left-drag scales it; right-drag pans; wheel zooms at the cursor.
 * Mouse, 3D view: left-drag a control point's surface point: the point follows the surface point
 * under the cursor (the ray against the untrimmed surface); shift, ctrl or alt + left-drag near a
 * loop's image moves, rotates or scales the loop with the surface point under the cursor. Orbit,
 * pan and zoom of the 3D camera are the window's (apps/common navigation).
 * Pressing a control point (2D or 3D) selects it. w opens the weight field of the selected point
 * (or of the point under the cursor): digits, period, minus and e type, backspace deletes, enter
 * sets the weight (a bad one is refused with the message), escape closes the field.
 * n starts a polygon hole drawn by clicks in the 2D view: each left click adds a corner; a click
 * on the first corner or enter closes it (3 corners or more), backspace removes the last corner,
 * escape cancels.
 * Keys: ctrl+z undo, ctrl+y or ctrl+shift+z redo, ctrl+s save; i insert a knot at the curve point
 * under the cursor; k remove the knot nearest it; x or delete: delete the control point under
 * the cursor; equal / minus: weight times / over 1.25; 0: weight 0 (refused: shows the message);
 * b snap the point under the cursor to the domain edge; g toggle snap while dragging; c, r, p
 * add a circle, rectangle or hexagon hole at the cursor; d delete the hole under the cursor;
 * s toggle strips, l toggle scan lines, f fit the 2D view; o (over the 3D view) open the face
 * under the cursor.
 */
#ifndef TE_APP_H
#define TE_APP_H

#include <stdint.h>

#include "crisp/plan.h"
#include "crisp/render.h"
#include "crisp/trimedit.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct te_rect {
    double x, y, w, h; /* window pixels, y down */
} te_rect;

/* What the 2D view draws, in window pixels; colour 0xAABBGGRR (Dear ImGui's order). */
typedef struct te_draw {
    void *ctx;
    void (*line)(void *ctx, double x0, double y0, double x1, double y1, uint32_t color,
                 double width);
    void (*circle)(void *ctx, double x, double y, double r, uint32_t color, int filled);
} te_draw;

enum {
    TE_DRAG_NONE,
    TE_DRAG_POINT,
    TE_DRAG_POINT_3D,
    TE_DRAG_MOVE,
    TE_DRAG_ROTATE,
    TE_DRAG_SCALE,
    TE_DRAG_PAN
};

typedef struct te_app {
    crisp_model *model; /* owned */
    int face;
    crisp_model *bare; /* the edited face without loops: (u, v) under the cursor in 3D */
    crisp_scene *bare_scene;
    crisp_scene *scene;
    crisp_trimedit *ed;
    crisp_planner *planner;
    const crisp_frame_plan *plan;
    crisp_camera cam; /* the 3D view's camera (its size = the 3D view's) */
    int cam_changed;
    te_rect view3d, view2d;
    double uv_center[2], uv_scale; /* the 2D view: pixels per unit (u, v), centred here */
    double cursor[2];
    int drag, drag_loop, drag_3d; /* drag_3d: a loop transform driven from the 3D view */
    crisp_trimedit_ref drag_ref;
    double drag_start[2], drag_last[2], drag_pivot[2];
    int snap, show_strips, show_scanlines;
    int has_sel;            /* a control point is selected (the last one pressed) */
    crisp_trimedit_ref sel; /* it */
    int entry;              /* the weight entry field is open (w) */
    char entry_text[32];    /* what was typed */
    int poly;               /* a polygon hole is being drawn by clicks (n) */
    int poly_n;             /* its corners so far */
    double poly_uv[2 * 64];
    uint64_t planned_version;
    double ms_face_plan; /* the last re-plan of the edited face (update + replan) */
    double ms_plan;      /* the last whole plan (camera change) */
    double ms_frame;     /* the last frame, as the window measured it (te_app_frame_done) */
    long replans;        /* re-plans of the face so far */
    char message[256];   /* the last refused edit's reason, or what was done */
    int message_error;
    char save_path[1024]; /* ctrl+s writes here */
    /* The CPU backend's frame during an edit drag (te_app_draw_cpu): the other faces drawn once. */
    long whole_plans;        /* whole plans so far (camera changes) */
    crisp_image others;      /* the other faces alone, for the current whole plan */
    long others_plan;        /* whole_plans when `others` was drawn; -1: none */
    int others_face;         /* the face left out of `others` */
    const crisp_image *over; /* the image the last partial frame was drawn into */
    uint8_t *face_mask;      /* per face: 1 for the edited face */
    uint8_t *others_mask;    /* per face: 1 for every other face */
    int last_partial;        /* the last te_app_draw_cpu drew only the edited face */
    double ms_draw;          /* its time */
} te_app;

/* Takes ownership of model (also on failure). face < 0: the built-in example. */
crisp_status te_app_open(te_app *app, crisp_model *model, int face, int width, int height);
void te_app_close(te_app *app);
/* Window size: the 3D view takes the left 60%, the 2D view the rest. Keeps the camera's view
 * direction; sets its size. */
void te_app_layout(te_app *app, int width, int height);
void te_app_set_camera(te_app *app, const crisp_camera *cam);
/* The 2D view shows the face's domain with a margin. */
void te_app_fit_2d(te_app *app);

/* Per frame before drawing: a whole plan when the camera changed, else a re-plan of the edited
 * face when the loops changed. */
crisp_status te_app_update(te_app *app);
void te_app_frame_done(te_app *app, double ms_frame);

void te_app_cursor(te_app *app, double x, double y);
void te_app_button(te_app *app, int button, int action, int mods);
void te_app_scroll(te_app *app, double dy);
void te_app_key(te_app *app, int key, int action, int mods);

void te_app_uv_to_px(const te_app *app, const double uv[2], double px[2]);
void te_app_px_to_uv(const te_app *app, const double px[2], double uv[2]);
/* Screen position in the 3D view of the surface point at uv; 0 when behind the eye. */
int te_app_uv_to_px3d(const te_app *app, const double uv[2], double px[2]);

/* Set the selected control point's weight from text (the weight field's Enter): refused with a
 * message when the text is not a number or the weight is not finite and > 0. */
crisp_status te_app_set_weight_text(te_app *app, const char *text);
/* The selected control point, validated (0 when there is none or it no longer exists). */
int te_app_selected(te_app *app, double uv[2], double *weight);

/* Whether a drag is editing the face now (a control point, a loop). */
int te_app_editing(const te_app *app);
/* The 3D view with the CPU backend into img (the camera's size; the caller keeps img from frame
 * to frame). While a drag edits the face, the other faces do not change: they are drawn once
 * (app->others) and each frame only the edited face is drawn over them
 * (crisp_render_cpu_plan_faces, 1 sample per pixel); otherwise, and after a camera change, the
 * whole plan is drawn. r is the caller's renderer. */
crisp_status te_app_draw_cpu(te_app *app, crisp_renderer *r, crisp_image *img);

/* The 2D view's content. Returns the number of scan lines drawn. */
long te_app_draw_2d(te_app *app, const te_draw *d);

crisp_status te_app_save(te_app *app, const char *path);
/* The face under the cursor in the 3D view (trimmed as the plan draws it), -1 when none; open
 * another face of the model for editing (the camera keeps its view). */
int te_app_pick_face(te_app *app);
crisp_status te_app_open_face(te_app *app, int face);

#ifdef __cplusplus
}
#endif
#endif
