/* The event replay format of the window apps and its player. A replay is a text file, one event a
 * line, '#' starts a comment; coordinates are window pixels (x right, y down, as GLFW reports
 * them); BUTTON is left, middle or right; MODS is shift, ctrl, alt or super joined with '+'.
 *
 *   move X Y                          move the cursor
 *   down BUTTON [X Y] [MODS]          press a button (at X Y: after moving there)
 *   up BUTTON [X Y] [MODS]            release it
 *   click BUTTON X Y [MODS]           move, press, release
 *   drag BUTTON X0 Y0 X1 Y1 [STEPS] [MODS]
 *                                     press at (X0, Y0), STEPS moves along the line (default 10),
 *                                     release at (X1, Y1)
 *   wheel DY [X Y]                    DY wheel steps at the cursor (or at X Y); > 0 zooms in
 *   key [MODS+]NAME                   press and release a key: a letter, a digit, f1..f12,
 *                                     escape, tab, space, enter, backspace, delete, left, right,
 *                                     up, down, home, end, pageup, pagedown, minus, equal
 *   drop PATH                         a file dropped on the window (the rest of the line)
 *   close                             the window's close button
 *   wait N                            N frames
 *   sleep MS                          MS milliseconds of real time (frames keep coming)
 *   idle                              until no file is loading and the image is refined
 *   screenshot PATH [WxH]             an off-screen render of the current view to PNG
 *   aov PATH [WxH]                    the same view's AOVs to OpenEXR
 *   camera                            print the camera as `crisp render` options
 *   set-camera OPTIONS                set the camera from `crisp render` options
 *   mark LABEL                        print the time, the frame count and whether refined
 *
 * Each input event (move, press, release, wheel, key, drop, close) is played in a frame of its
 * own, through the same functions the window's real events go through. */
#ifndef APP_EVENTS_H
#define APP_EVENTS_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum app_event_kind {
    APP_EV_CURSOR,
    APP_EV_BUTTON,
    APP_EV_SCROLL,
    APP_EV_KEY,
    APP_EV_DROP,
    APP_EV_CLOSE,
    APP_EV_WAIT,
    APP_EV_SLEEP,
    APP_EV_IDLE,
    APP_EV_COMMAND
} app_event_kind;

typedef struct app_event {
    app_event_kind kind;
    double x, y;        /* cursor, or wheel steps in y */
    int button, action; /* GLFW button / key, GLFW_PRESS or GLFW_RELEASE */
    int mods;           /* GLFW_MOD_* */
    int key;            /* GLFW_KEY_* */
    double amount;      /* frames (wait) or milliseconds (sleep) */
    char *text;         /* drop path, or the command's name then its argument */
    char *arg;
    int line;
} app_event;

/* Where a player sends what it plays. */
typedef struct app_input_sink {
    void *ctx;
    void (*cursor)(void *ctx, double x, double y);
    void (*button)(void *ctx, int button, int action, int mods);
    void (*scroll)(void *ctx, double dy);
    void (*key)(void *ctx, int key, int action, int mods);
    void (*drop)(void *ctx, const char *path);
    void (*close)(void *ctx);
    int (*idle)(void *ctx);
    void (*command)(void *ctx, const char *name, const char *arg, int line);
} app_input_sink;

typedef struct app_player {
    app_event *events;
    size_t count, next;
    double wait_until; /* for sleep */
    double frames_left;
    int waiting;
} app_player;

/* Parse a replay file; 0 and a message "file:line: expected ..." in err on bad text. */
int app_player_load(app_player *p, const char *path, char *err, size_t err_size);
int app_player_load_mem(app_player *p, const char *name, const char *text, char *err,
                        size_t err_size);
void app_player_free(app_player *p);
/* Play this frame's events; returns 1 while events remain. */
int app_player_step(app_player *p, const app_input_sink *sink);
int app_player_done(const app_player *p);

/* GLFW key for a name ("f", "F1", "escape"); -1 when unknown. */
int app_key_from_name(const char *name);

#ifdef __cplusplus
}
#endif
#endif
