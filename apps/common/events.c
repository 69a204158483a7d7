/* The event replay format and player (events.h): parse into a flat list of events, then play
 * them one input event per frame through an app_input_sink. */
#include "events.h"

#include <GLFW/glfw3.h>
#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "crisp/core.h"
#include "crisp/io.h"

static const struct {
    const char *name;
    int key;
} key_names[] = {
    {"escape", GLFW_KEY_ESCAPE},
    {"tab", GLFW_KEY_TAB},
    {"space", GLFW_KEY_SPACE},
    {"enter", GLFW_KEY_ENTER},
    {"backspace", GLFW_KEY_BACKSPACE},
    {"delete", GLFW_KEY_DELETE},
    {"left", GLFW_KEY_LEFT},
    {"right", GLFW_KEY_RIGHT},
    {"up", GLFW_KEY_UP},
    {"down", GLFW_KEY_DOWN},
    {"home", GLFW_KEY_HOME},
    {"end", GLFW_KEY_END},
    {"pageup", GLFW_KEY_PAGE_UP},
    {"pagedown", GLFW_KEY_PAGE_DOWN},
    {"minus", GLFW_KEY_MINUS},
    {"equal", GLFW_KEY_EQUAL},
};

int app_key_from_name(const char *name)
{
    size_t n = strlen(name);
    if (n == 1 && isalpha((unsigned char)name[0]))
        return GLFW_KEY_A + (toupper((unsigned char)name[0]) - 'A');
    if (n == 1 && isdigit((unsigned char)name[0])) return GLFW_KEY_0 + (name[0] - '0');
    if ((name[0] == 'f' || name[0] == 'F') && n >= 2 && n <= 3) {
        char *end;
        long k = strtol(name + 1, &end, 10);
        if (*end == '\0' && k >= 1 && k <= 12) return GLFW_KEY_F1 + (int)k - 1;
    }
    for (size_t i = 0; i < sizeof key_names / sizeof key_names[0]; i++)
        if (!strcasecmp(name, key_names[i].name)) return key_names[i].key;
    return -1;
}

static int parse_mods(const char *s, int *mods)
{
    *mods = 0;
    while (*s) {
        const char *e = strchr(s, '+');
        size_t n = e ? (size_t)(e - s) : strlen(s);
        if (n == 5 && !strncasecmp(s, "shift", 5))
            *mods |= GLFW_MOD_SHIFT;
        else if (n == 4 && !strncasecmp(s, "ctrl", 4))
            *mods |= GLFW_MOD_CONTROL;
        else if (n == 3 && !strncasecmp(s, "alt", 3))
            *mods |= GLFW_MOD_ALT;
        else if (n == 5 && !strncasecmp(s, "super", 5))
            *mods |= GLFW_MOD_SUPER;
        else
            return 0;
        s += n + (e ? 1 : 0);
    }
    return 1;
}

static int parse_button(const char *s, int *b)
{
    if (!strcmp(s, "left"))
        *b = GLFW_MOUSE_BUTTON_LEFT;
    else if (!strcmp(s, "right"))
        *b = GLFW_MOUSE_BUTTON_RIGHT;
    else if (!strcmp(s, "middle"))
        *b = GLFW_MOUSE_BUTTON_MIDDLE;
    else
        return 0;
    return 1;
}

static int parse_num(const char *s, double *v)
{
    char *end;
    if (!s) return 0;
    *v = strtod(s, &end);
    return end != s && *end == '\0' && isfinite(*v);
}

typedef struct builder {
    app_player *p;
    size_t cap;
    const char *name;
    int line;
    char *err;
    size_t err_size;
} builder;

static int fail(builder *b, const char *fmt, ...)
{
    char msg[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    snprintf(b->err, b->err_size, "%s:%d: %s", b->name, b->line, msg);
    return 0;
}

static app_event *push(builder *b, app_event_kind kind)
{
    if (b->p->count == b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 64;
        app_event *e = realloc(b->p->events, cap * sizeof *e);
        if (!e) return NULL;
        b->p->events = e;
        b->cap = cap;
    }
    app_event *e = &b->p->events[b->p->count++];
    memset(e, 0, sizeof *e);
    e->kind = kind;
    e->line = b->line;
    return e;
}

#define PUSH(kind)                                                                                 \
    do {                                                                                           \
        if (!(e = push(b, kind))) return fail(b, "out of memory");                                 \
    } while (0)

/* One line, split into tokens tok[0..n-1]; rest = the text after the first token. */
static int parse_line(builder *b, char **tok, int n, const char *rest)
{
    app_event *e;
    const char *cmd = tok[0];
    if (!strcmp(cmd, "move")) {
        double x, y;
        if (n != 3 || !parse_num(tok[1], &x) || !parse_num(tok[2], &y))
            return fail(b, "expected 'move X Y'");
        PUSH(APP_EV_CURSOR);
        e->x = x, e->y = y;
    } else if (!strcmp(cmd, "down") || !strcmp(cmd, "up") || !strcmp(cmd, "click")) {
        int btn, mods = 0, at = 0;
        double x = 0, y = 0;
        if (n < 2 || !parse_button(tok[1], &btn))
            return fail(b, "expected '%s left|middle|right%s'", cmd,
                        strcmp(cmd, "click") ? " [X Y] [MODS]" : " X Y [MODS]");
        int i = 2;
        if (n >= 4 && parse_num(tok[2], &x) && parse_num(tok[3], &y)) at = 1, i = 4;
        if (!strcmp(cmd, "click") && !at)
            return fail(b, "expected 'click left|middle|right X Y [MODS]'");
        if (i < n && !parse_mods(tok[i++], &mods))
            return fail(b, "bad modifiers '%s' (expected shift, ctrl, alt, super joined by +)",
                        tok[i - 1]);
        if (i != n || (!strcmp(cmd, "click") && !at))
            return fail(b, "unexpected text after '%s'", cmd);
        if (at) {
            PUSH(APP_EV_CURSOR);
            e->x = x, e->y = y;
        }
        if (strcmp(cmd, "up")) {
            PUSH(APP_EV_BUTTON);
            e->button = btn, e->action = GLFW_PRESS, e->mods = mods;
        }
        if (strcmp(cmd, "down")) {
            PUSH(APP_EV_BUTTON);
            e->button = btn, e->action = GLFW_RELEASE, e->mods = mods;
        }
    } else if (!strcmp(cmd, "drag")) {
        int btn, mods = 0;
        double x0, y0, x1, y1, steps = 10;
        if (n < 6 || !parse_button(tok[1], &btn) || !parse_num(tok[2], &x0) ||
            !parse_num(tok[3], &y0) || !parse_num(tok[4], &x1) || !parse_num(tok[5], &y1))
            return fail(b, "expected 'drag BUTTON X0 Y0 X1 Y1 [STEPS] [MODS]'");
        int i = 6;
        if (i < n && parse_num(tok[i], &steps)) i++;
        if (i < n && !parse_mods(tok[i++], &mods)) return fail(b, "bad modifiers '%s'", tok[i - 1]);
        if (i != n || steps < 1 || steps > 100000 || steps != floor(steps))
            return fail(b, "expected 'drag BUTTON X0 Y0 X1 Y1 [STEPS 1..100000] [MODS]'");
        PUSH(APP_EV_CURSOR);
        e->x = x0, e->y = y0;
        PUSH(APP_EV_BUTTON);
        e->button = btn, e->action = GLFW_PRESS, e->mods = mods;
        for (int s = 1; s <= (int)steps; s++) {
            PUSH(APP_EV_CURSOR);
            e->x = x0 + (x1 - x0) * s / steps;
            e->y = y0 + (y1 - y0) * s / steps;
        }
        PUSH(APP_EV_BUTTON);
        e->button = btn, e->action = GLFW_RELEASE, e->mods = mods;
    } else if (!strcmp(cmd, "wheel")) {
        double dy, x, y;
        if (!(n == 2 || n == 4) || !parse_num(tok[1], &dy) ||
            (n == 4 && (!parse_num(tok[2], &x) || !parse_num(tok[3], &y))))
            return fail(b, "expected 'wheel DY [X Y]'");
        if (n == 4) {
            PUSH(APP_EV_CURSOR);
            e->x = x, e->y = y;
        }
        PUSH(APP_EV_SCROLL);
        e->y = dy;
    } else if (!strcmp(cmd, "key")) {
        if (n != 2) return fail(b, "expected 'key [MODS+]NAME'");
        char *plus = strrchr(tok[1], '+');
        int mods = 0, key;
        if (plus && plus[1]) {
            *plus = '\0';
            if (!parse_mods(tok[1], &mods)) return fail(b, "bad modifiers '%s'", tok[1]);
            key = app_key_from_name(plus + 1);
        } else {
            key = app_key_from_name(tok[1]);
        }
        if (key < 0) return fail(b, "unknown key '%s'", plus && plus[1] ? plus + 1 : tok[1]);
        PUSH(APP_EV_KEY);
        e->key = key, e->mods = mods;
    } else if (!strcmp(cmd, "drop")) {
        if (!rest || !*rest) return fail(b, "expected 'drop PATH'");
        PUSH(APP_EV_DROP);
        if (!(e->text = strdup(rest))) return fail(b, "out of memory");
    } else if (!strcmp(cmd, "close")) {
        if (n != 1) return fail(b, "expected 'close'");
        PUSH(APP_EV_CLOSE);
    } else if (!strcmp(cmd, "wait") || !strcmp(cmd, "sleep")) {
        double v;
        if (n != 2 || !parse_num(tok[1], &v) || v < 0 || v > 1e7)
            return fail(b, "expected '%s %s'", cmd, cmd[0] == 'w' ? "FRAMES" : "MILLISECONDS");
        PUSH(cmd[0] == 'w' ? APP_EV_WAIT : APP_EV_SLEEP);
        e->amount = v;
    } else if (!strcmp(cmd, "idle")) {
        if (n != 1) return fail(b, "expected 'idle'");
        PUSH(APP_EV_IDLE);
    } else if (!strcmp(cmd, "screenshot") || !strcmp(cmd, "aov") || !strcmp(cmd, "camera") ||
               !strcmp(cmd, "set-camera") || !strcmp(cmd, "mark") || !strcmp(cmd, "window") ||
               !strcmp(cmd, "section") || !strcmp(cmd, "body") || !strcmp(cmd, "occurrence")) {
        int needs = strcmp(cmd, "camera") != 0;
        if (needs && n < 2) return fail(b, "expected '%s ARGUMENTS'", cmd);
        if (!needs && n != 1) return fail(b, "expected 'camera'");
        PUSH(APP_EV_COMMAND);
        if (!(e->text = strdup(cmd)) || !(e->arg = strdup(rest ? rest : "")))
            return fail(b, "out of memory");
    } else {
        return fail(b,
                    "unknown event '%s' (expected move, down, up, click, drag, wheel, key, drop, "
                    "close, wait, sleep, idle, screenshot, aov, camera, set-camera, mark, "
                    "window, section, body, occurrence)",
                    cmd);
    }
    return 1;
}

int app_player_load_mem(app_player *p, const char *name, const char *text, char *err,
                        size_t err_size)
{
    memset(p, 0, sizeof *p);
    builder b = {.p = p, .name = name, .err = err, .err_size = err_size};
    const char *s = text;
    while (*s) {
        b.line++;
        const char *eol = strchr(s, '\n');
        size_t len = eol ? (size_t)(eol - s) : strlen(s);
        char line[4096];
        if (len >= sizeof line) {
            fail(&b, "line longer than %zu characters", sizeof line - 1);
            app_player_free(p);
            return 0;
        }
        memcpy(line, s, len);
        line[len] = '\0';
        s += len + (eol ? 1 : 0);
        char *hash = strchr(line, '#');
        if (hash) *hash = '\0';
        /* the text after the first word (for paths and options), trimmed */
        char *p0 = line;
        while (isspace((unsigned char)*p0))
            p0++;
        char *rest = p0;
        while (*rest && !isspace((unsigned char)*rest))
            rest++;
        while (isspace((unsigned char)*rest))
            rest++;
        char rest_copy[4096];
        snprintf(rest_copy, sizeof rest_copy, "%s", rest);
        for (size_t k = strlen(rest_copy); k > 0 && isspace((unsigned char)rest_copy[k - 1]); k--)
            rest_copy[k - 1] = '\0';
        char *tok[16];
        int n = 0;
        char *save = NULL;
        for (char *t = strtok_r(p0, " \t\r", &save); t; t = strtok_r(NULL, " \t\r", &save)) {
            if (n == 16) break;
            tok[n++] = t;
        }
        if (n == 0) continue;
        if (!parse_line(&b, tok, n, rest_copy)) {
            app_player_free(p);
            return 0;
        }
    }
    return 1;
}

int app_player_load(app_player *p, const char *path, char *err, size_t err_size)
{
    char *data = NULL;
    size_t size = 0;
    memset(p, 0, sizeof *p);
    if (crisp_read_file(path, &data, &size)) {
        snprintf(err, err_size, "%s", crisp_error_message());
        return 0;
    }
    if (strlen(data) != size) {
        crisp_free(data);
        snprintf(err, err_size, "%s: not a text file (holds a NUL byte)", path);
        return 0;
    }
    int ok = app_player_load_mem(p, path, data, err, err_size);
    crisp_free(data);
    return ok;
}

void app_player_free(app_player *p)
{
    for (size_t i = 0; i < p->count; i++) {
        free(p->events[i].text);
        free(p->events[i].arg);
    }
    free(p->events);
    memset(p, 0, sizeof *p);
}

int app_player_done(const app_player *p)
{
    return p->next >= p->count;
}

int app_player_step(app_player *p, const app_input_sink *s)
{
    while (p->next < p->count) {
        app_event *e = &p->events[p->next];
        switch (e->kind) {
        case APP_EV_WAIT:
            if (!p->waiting) p->frames_left = e->amount, p->waiting = 1;
            if (p->frames_left-- > 0) return 1;
            p->waiting = 0;
            p->next++;
            continue;
        case APP_EV_SLEEP:
            if (!p->waiting) p->wait_until = crisp_time_now() + e->amount / 1000, p->waiting = 1;
            if (crisp_time_now() < p->wait_until) return 1;
            p->waiting = 0;
            p->next++;
            continue;
        case APP_EV_IDLE:
            if (!s->idle(s->ctx)) return 1;
            p->next++;
            continue;
        case APP_EV_COMMAND:
            p->next++;
            s->command(s->ctx, e->text, e->arg, e->line);
            continue;
        case APP_EV_CURSOR:
            s->cursor(s->ctx, e->x, e->y);
            break;
        case APP_EV_BUTTON:
            s->button(s->ctx, e->button, e->action, e->mods);
            break;
        case APP_EV_SCROLL:
            s->scroll(s->ctx, e->y);
            break;
        case APP_EV_KEY:
            s->key(s->ctx, e->key, GLFW_PRESS, e->mods);
            s->key(s->ctx, e->key, GLFW_RELEASE, e->mods);
            break;
        case APP_EV_DROP:
            s->drop(s->ctx, e->text);
            break;
        case APP_EV_CLOSE:
            s->close(s->ctx);
            break;
        }
        p->next++;
        return 1; /* one input event per frame */
    }
    return 0;
}
