/* apps/common without a window (label unit): the replay parser (every event kind, errors naming
 * the file and line), and the navigation's exact properties: a zoom keeps the zoom point's pixel,
 * an orbit keeps its pivot's pixel, a pan moves a point at the grab depth by the drag, switching
 * to orthographic and back keeps the focal plane's size on screen, and `crisp render` options
 * round-trip through app_nav_format / app_nav_parse bit for bit. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <GLFW/glfw3.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "events.h"
#include "nav.h"

static void test_replay_parse(void **state)
{
    (void)state;
    app_player p;
    char err[256];
    const char *text =
        "# a comment\n"
        "move 10 20\n"
        "click left 5 6 shift+ctrl\n"
        "drag right 0 0 10 10 4\n"
        "wheel -2 3 4\n"
        "key ctrl+q\n"
        "key F1\n"
        "drop /tmp/a file.igs\n"
        "wait 3\nsleep 10\nidle\ncamera\nscreenshot out.png 640x480\nmark here\nclose\n";
    assert_true(app_player_load_mem(&p, "r.events", text, err, sizeof err));
    /* move; click = move, press, release; drag = move, press, 4 moves, release; wheel = move,
     * scroll; key; key; drop; wait; sleep; idle; camera; screenshot; mark; close */
    assert_int_equal(p.count, 1 + 3 + 7 + 2 + 1 + 1 + 1 + 1 + 1 + 1 + 1 + 1 + 1 + 1);
    assert_int_equal(p.events[2].kind, APP_EV_BUTTON);
    assert_int_equal(p.events[2].mods, GLFW_MOD_SHIFT | GLFW_MOD_CONTROL);
    assert_int_equal(p.events[2].action, GLFW_PRESS);
    assert_int_equal(p.events[9].kind, APP_EV_CURSOR);
    assert_true(p.events[9].x == 10 && p.events[9].y == 10);
    assert_int_equal(p.events[13].kind, APP_EV_KEY);
    assert_int_equal(p.events[13].key, GLFW_KEY_Q);
    assert_int_equal(p.events[13].mods, GLFW_MOD_CONTROL);
    assert_int_equal(p.events[14].key, GLFW_KEY_F1);
    assert_string_equal(p.events[15].text, "/tmp/a file.igs");
    assert_string_equal(p.events[20].arg, "out.png 640x480");
    app_player_free(&p);

    static const char *const bad[][2] = {
        {"move 1\n", "r:1: expected 'move X Y'"},
        {"idle\nclick left 1\n", "r:2: expected 'click left|middle|right X Y [MODS]'"},
        {"\n\nkey nosuchkey\n", "r:3: unknown key 'nosuchkey'"},
        {"drag left 0 0 1 1 0\n",
         "r:1: expected 'drag BUTTON X0 Y0 X1 Y1 [STEPS 1..100000] [MODS]'"},
        {"fly 1 2\n", "r:1: unknown event 'fly'"},
        {"down left 1 2 hyper\n", "r:1: bad modifiers 'hyper'"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        err[0] = '\0';
        assert_false(app_player_load_mem(&p, "r", bad[i][0], err, sizeof err));
        if (strncmp(err, bad[i][1], strlen(bad[i][1])))
            fail_msg("'%s': got '%s', expected '%s...'", bad[i][0], err, bad[i][1]);
    }
}

static void pixel_of(const crisp_camera *c, const double p[3], double px[2])
{
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(c, &m);
    double clip[4], d[3];
    crisp_mat4_mulp(m.view_proj, p, clip);
    crisp_camera_to_pixel(c, clip, d);
    px[0] = d[0];
    px[1] = d[1];
}

static void test_navigation_exact(void **state)
{
    (void)state;
    app_nav nav;
    const double box[6] = {-1, -2, 0, 3, 1, 2};
    for (int ortho = 0; ortho < 2; ortho++) {
        app_nav_init(&nav, box, 640, 480);
        app_nav_set_ortho(&nav, ortho);
        double p[3], q[2];
        /* zoom about the focal point under (100, 380), in and out */
        app_nav_focus_point(&nav, 100, 380, p);
        pixel_of(&nav.cam, p, q);
        assert_true(hypot(q[0] - 100, q[1] - 380) < 1e-6);
        for (int k = 0; k < 6; k++) {
            app_nav_zoom(&nav, p, k < 4 ? 0.3 : 7);
            pixel_of(&nav.cam, p, q);
            if (hypot(q[0] - 100, q[1] - 380) > 1e-6)
                fail_msg("ortho %d zoom %d: point at %.9g %.9g", ortho, k, q[0], q[1]);
        }
        /* orbit about a pivot keeps its pixel */
        double pivot[3] = {0.5, -0.5, 1}, a[2], b[2];
        pixel_of(&nav.cam, pivot, a);
        app_nav_orbit(&nav, pivot, 37, -21);
        pixel_of(&nav.cam, pivot, b);
        assert_true(hypot(a[0] - b[0], a[1] - b[1]) < 1e-6);
        /* pan: a point at the grab depth follows the drag */
        double d = app_nav_depth(&nav.cam, pivot);
        app_nav_pan(&nav, d, 25, -40);
        pixel_of(&nav.cam, pivot, b);
        assert_true(hypot(b[0] - a[0] - 25, b[1] - a[1] + 40) < 1e-6);
    }
    /* perspective -> ortho -> perspective: the target's neighbourhood keeps its size */
    app_nav_init(&nav, box, 640, 480);
    double t[3], off[3], a0[2], a1[2], b0[2], b1[2];
    memcpy(t, nav.cam.target, sizeof t);
    double f[3], r[3];
    crisp_vec3_sub(nav.cam.target, nav.cam.eye, f);
    crisp_vec3_cross(f, nav.cam.up, r);
    crisp_vec3_normalize(r, r);
    for (int i = 0; i < 3; i++)
        off[i] = t[i] + 0.5 * r[i];
    pixel_of(&nav.cam, t, a0);
    pixel_of(&nav.cam, off, a1);
    app_nav_set_ortho(&nav, 1);
    assert_true(nav.cam.fov_deg <= APP_NAV_ORTHO_FOV + 1e-12);
    pixel_of(&nav.cam, t, b0);
    pixel_of(&nav.cam, off, b1);
    assert_true(fabs(hypot(a1[0] - a0[0], a1[1] - a0[1]) - hypot(b1[0] - b0[0], b1[1] - b0[1])) <
                1e-6);
    /* near and far enclose the box */
    app_nav_update_clip(&nav);
    for (int k = 0; k < 8; k++) {
        double c[3] = {box[k & 1 ? 3 : 0], box[k & 2 ? 4 : 1], box[k & 4 ? 5 : 2]};
        double z = app_nav_depth(&nav.cam, c);
        assert_true(z > nav.cam.znear && z < nav.cam.zfar);
    }
    /* options round trip */
    char text[512], err[128];
    app_nav_format(&nav.cam, text, sizeof text);
    crisp_camera back = {0};
    assert_true(app_nav_parse(text, &back, err, sizeof err));
    assert_memory_equal(&back, &nav.cam, sizeof back);
    assert_false(app_nav_parse("--eye 1,2", &back, err, sizeof err));
    assert_false(app_nav_parse("--fov 30 --wat 2", &back, err, sizeof err));
    assert_non_null(strstr(err, "--wat"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_replay_parse),
        cmocka_unit_test(test_navigation_exact),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
