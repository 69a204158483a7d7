/* Pictures by default: every bundled model (the CAD files, the 3D f-rep parts and the scene
 * file) rendered with the default camera fills at least 60% of the frame's width or height and
 * is cut by no frame edge, judged from the picture's alpha (coverage). Also the demo's picture
 * (scripts/demo: the bearing bracket at 1280x720 with the default camera), and each named view
 * of one model. Rendered through the library calls `crisp render` makes (crisp/app.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "crisp/app.h"

typedef struct {
    int x0, y0, x1, y1; /* drawn extent, inclusive; x0 > x1 when nothing is drawn */
    int on_edge;        /* pixels with coverage on the outermost rows and columns */
} extent;

static extent alpha_extent(const crisp_image *img)
{
    extent e = {img->width, img->height, -1, -1, 0};
    for (int j = 0; j < img->height; j++)
        for (int i = 0; i < img->width; i++) {
            if (!(img->rgba[4 * ((size_t)j * img->width + i) + 3] > 0)) continue;
            if (i < e.x0) e.x0 = i;
            if (i > e.x1) e.x1 = i;
            if (j < e.y0) e.y0 = j;
            if (j > e.y1) e.y1 = j;
            if (i == 0 || j == 0 || i == img->width - 1 || j == img->height - 1) e.on_edge++;
        }
    return e;
}

/* Renders path with the default camera (or a view) and checks the framing; returns the larger
 * of the width and height fractions. */
static double check_framing(const char *path, int width, int height, crisp_view view)
{
    crisp_document *doc = NULL;
    crisp_camera cam;
    crisp_image img = {0};
    crisp_status st = crisp_document_open(path, NULL, &doc);
    if (!st)
        st = crisp_document_camera(
            doc, &(crisp_camera_desc){.width = width, .height = height, .view = view}, &cam);
    if (!st) st = crisp_image_init(&img, width, height);
    if (!st)
        st = crisp_document_render(doc, &cam, &(crisp_document_render_desc){.samples = 1}, &img,
                                   NULL);
    if (st) fprintf(stderr, "%s: %s\n", path, crisp_error_message());
    assert_int_equal(st, CRISP_OK);
    extent e = alpha_extent(&img);
    double fw = (double)(e.x1 - e.x0 + 1) / width, fh = (double)(e.y1 - e.y0 + 1) / height;
    double fill = fw > fh ? fw : fh;
    printf("%-28s %-6s %4dx%-4d drawn %4dx%-4d at %4d,%-4d fill %.0f%% (w %.0f%%, h %.0f%%), edge "
           "pixels %d\n",
           strrchr(path, '/') + 1, crisp_view_name(view), width, height, e.x1 - e.x0 + 1,
           e.y1 - e.y0 + 1, e.x0, e.y0, 100 * fill, 100 * fw, 100 * fh, e.on_edge);
    assert_true(e.x0 <= e.x1);
    assert_int_equal(e.on_edge, 0);
    assert_true(fill >= 0.60);
    crisp_image_free(&img);
    crisp_document_destroy(doc);
    return fill;
}

static const char *const models[] = {
    "nurbs/Ventilator.stp",       "nurbs/gpucast_part.igs",
    "nurbs/gpucast_teapot.igs",   "nurbs/impeller.igs",
    "nurbs/occt_as1_ec.stp",      "nurbs/occt_bearing.iges",
    "nurbs/occt_bm2_pe_t4_b.stp", "nurbs/occt_hammer.iges",
    "nurbs/occt_linkrods.step",   "nurbs/occt_trj4_k1_geo_tu.stp",
    "nurbs/occt_trj9_io1.stp",    "frep/bear.vm",
    "frep/tanglecube.vm",         "frep/colonnade.vm",
    "scenes/teapot_frep.scene",
};

static void test_bundled_models(void **state)
{
    (void)state;
    char path[1024];
    /* a round part, the hardest case for a box-corner fit */
    FILE *f = fopen(CRISP_BIN_DIR "/framing_sphere.math", "w");
    assert_non_null(f);
    fputs("sqrt(X*X + Y*Y + Z*Z) - 0.8\n", f);
    fclose(f);
    check_framing(CRISP_BIN_DIR "/framing_sphere.math", 320, 180, CRISP_VIEW_DEFAULT);
    for (size_t i = 0; i < sizeof models / sizeof models[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", CRISP_DATA_DIR, models[i]);
        check_framing(path, 320, 180, CRISP_VIEW_DEFAULT);
    }
}

/* The demo's picture: scripts/demo renders this model at 1280x720 with the default camera (the
 * framing does not depend on the scale; 640x360 keeps the sanitizer run short). */
static void test_demo(void **state)
{
    (void)state;
    check_framing(CRISP_DATA_DIR "/nurbs/occt_bearing.iges", 640, 360, CRISP_VIEW_DEFAULT);
    check_framing(CRISP_DATA_DIR "/scenes/teapot_frep.scene", 640, 360, CRISP_VIEW_DEFAULT);
}

/* After the model changes, update re-prepares: dropping every face but one shrinks the points'
 * box to that face's. */
static void test_document_update(void **state)
{
    (void)state;
    crisp_document *doc = NULL;
    assert_int_equal(crisp_document_open(CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs", NULL, &doc),
                     CRISP_OK);
    double before[6];
    memcpy(before, doc->box, sizeof before);
    assert_int_equal(doc->scene->face_count, 32);
    int keep = 3;
    for (int i = 0; i < doc->model->face_count; i++)
        if (i != keep) crisp_face_free(&doc->model->faces[i]);
    doc->model->faces[0] = doc->model->faces[keep];
    doc->model->face_count = 1;
    assert_int_equal(crisp_document_update(doc), CRISP_OK);
    assert_int_equal(doc->scene->face_count, 1);
    double vol0 = 1, vol1 = 1;
    for (int a = 0; a < 3; a++) {
        assert_true(doc->box[a] >= before[a] - 1e-9 && doc->box[a + 3] <= before[a + 3] + 1e-9);
        vol0 *= before[a + 3] - before[a];
        vol1 *= doc->box[a + 3] - doc->box[a];
    }
    assert_true(vol1 < 0.5 * vol0);
    crisp_document_destroy(doc);
}

/* crisp_document_camera's rules: an eye is used as given (target the middle, up +Z, or +Y looking
 * straight down); --fit keeps the direction and moves the eye; the scene's camera line is the
 * default view and --view overrides it; near and far given are kept; names parse both ways. */
static void test_camera_rules(void **state)
{
    (void)state;
    crisp_document *doc = NULL;
    assert_int_equal(crisp_document_open(CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs", NULL, &doc),
                     CRISP_OK);
    crisp_camera cam, fit;
    const double eye[3] = {30, -40, 20};
    assert_int_equal(crisp_document_camera(doc, &(crisp_camera_desc){.eye = eye}, &cam), CRISP_OK);
    assert_memory_equal(cam.eye, eye, sizeof eye);
    for (int a = 0; a < 3; a++)
        assert_true(fabs(cam.target[a] - 0.5 * (doc->box[a] + doc->box[a + 3])) < 1e-12);
    assert_true(cam.up[2] == 1 && cam.up[0] == 0 && cam.up[1] == 0);
    assert_int_equal(crisp_document_camera(doc, &(crisp_camera_desc){.eye = eye, .fit = 1}, &fit),
                     CRISP_OK);
    double d0[3], d1[3];
    for (int a = 0; a < 3; a++)
        d0[a] = cam.target[a] - cam.eye[a], d1[a] = fit.target[a] - fit.eye[a];
    double n0 = sqrt(d0[0] * d0[0] + d0[1] * d0[1] + d0[2] * d0[2]);
    double n1 = sqrt(d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]);
    for (int a = 0; a < 3; a++)
        assert_true(fabs(d0[a] / n0 - d1[a] / n1) < 1e-9); /* same direction */
    assert_true(n1 < n0);                                  /* moved closer */
    const double mx = 0.5 * (doc->box[0] + doc->box[3]), my = 0.5 * (doc->box[1] + doc->box[4]);
    const double down[3] = {mx, my, 50}, below[3] = {mx, my, -50}; /* straight down / up */
    assert_int_equal(crisp_document_camera(doc, &(crisp_camera_desc){.eye = down}, &cam), CRISP_OK);
    assert_true(cam.up[1] == 1);
    assert_int_equal(crisp_document_camera(doc, &(crisp_camera_desc){.eye = below}, &cam),
                     CRISP_OK);
    assert_true(cam.up[1] == -1);
    assert_int_equal(
        crisp_document_camera(doc, &(crisp_camera_desc){.znear = 0.5, .zfar = 900}, &cam),
        CRISP_OK);
    assert_true(cam.znear == 0.5 && cam.zfar == 900);
    assert_int_equal(crisp_document_camera(doc, &(crisp_camera_desc){.znear = -1}, &cam),
                     CRISP_ERR_INVALID_ARG);
    crisp_document_destroy(doc);

    assert_int_equal(crisp_document_open(CRISP_DATA_DIR "/scenes/teapot_frep.scene", NULL, &doc),
                     CRISP_OK);
    assert_true(doc->has_camera);
    assert_int_equal(crisp_document_camera(doc, NULL, &cam), CRISP_OK);
    assert_memory_equal(cam.eye, doc->eye, sizeof doc->eye);
    assert_true(doc->has_up && cam.up[2] == 1);
    doc->has_up = 0; /* a camera line without 'up': the command line's default, +Z */
    doc->up[0] = 1, doc->up[1] = doc->up[2] = 0;
    assert_int_equal(crisp_document_camera(doc, NULL, &cam), CRISP_OK);
    assert_true(cam.up[0] == 0 && cam.up[1] == 0 && cam.up[2] == 1);
    assert_int_equal(crisp_document_camera(doc, &(crisp_camera_desc){.view = CRISP_VIEW_TOP}, &cam),
                     CRISP_OK);
    assert_true(cam.eye[2] > doc->box[5]); /* above the scene */
    crisp_document_destroy(doc);

    for (int v = CRISP_VIEW_ISO; v <= CRISP_VIEW_BOTTOM; v++) {
        crisp_view back;
        assert_true(crisp_view_parse(crisp_view_name((crisp_view)v), &back));
        assert_int_equal(back, v);
    }
    crisp_view x;
    assert_false(crisp_view_parse("diagonal", &x));
    assert_false(crisp_view_parse(NULL, &x));
}

static void test_views(void **state)
{
    (void)state;
    for (int v = CRISP_VIEW_ISO; v <= CRISP_VIEW_BOTTOM; v++) {
        check_framing(CRISP_DATA_DIR "/nurbs/occt_bearing.iges", 200, 150, (crisp_view)v);
        if (v == CRISP_VIEW_TOP || v == CRISP_VIEW_FRONT)
            check_framing(CRISP_DATA_DIR "/nurbs/gpucast_teapot.igs", 150, 200, (crisp_view)v);
    }
}

/* A box fitted along any direction keeps every corner inside the frame less the margin, and
 * touches it: some corner is within 0.5% of the margin's line. */
static void test_fit_box_tight(void **state)
{
    (void)state;
    const double box[6] = {-1, -2, -0.5, 3, 1, 2.5};
    const double dirs[][3] = {{1, -1, 1}, {0, -1, 0}, {0, 0, 1}, {-2, 0.3, 0.1}, {0.2, 0.9, -0.4}};
    const double ups[][3] = {{0, 0, 1}, {0, 0, 1}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}};
    for (size_t k = 0; k < sizeof dirs / sizeof dirs[0]; k++)
        for (int aspect = 0; aspect < 2; aspect++) {
            crisp_camera cam;
            int w = aspect ? 300 : 800, h = aspect ? 900 : 450;
            assert_int_equal(
                crisp_camera_fit(box, dirs[k], ups[k],
                                 &(crisp_camera_fit_desc){.width = w, .height = h, .margin = 0.05},
                                 &cam),
                CRISP_OK);
            crisp_camera_matrices m;
            crisp_camera_matrices_compute(&cam, &m);
            double worst = 0;
            for (int c = 0; c < 8; c++) {
                double p[3] = {box[c & 1 ? 3 : 0], box[c & 2 ? 4 : 1], box[c & 4 ? 5 : 2]}, clip[4];
                crisp_mat4_mulp(m.view_proj, p, clip);
                assert_true(clip[3] > 0);
                for (int a = 0; a < 2; a++) {
                    double ndc = clip[a] / clip[3];
                    assert_true(ndc >= -0.95 - 1e-9 && ndc <= 0.95 + 1e-9);
                    if (ndc > worst) worst = ndc;
                    if (-ndc > worst) worst = -ndc;
                }
                double z = clip[2] / clip[3];
                assert_true(z > -1 && z < 1); /* between near and far */
            }
            assert_true(worst > 0.95 - 0.005);
        }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fit_box_tight),
        cmocka_unit_test(test_bundled_models),
        cmocka_unit_test(test_demo),
        cmocka_unit_test(test_views),
        cmocka_unit_test(test_document_update),
        cmocka_unit_test(test_camera_rules),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
