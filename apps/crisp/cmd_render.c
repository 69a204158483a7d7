/* crisp render MODEL|SCENE [-o out.png] [--aov out.exr] [--size WxH] [--eye x,y,z --target x,y,z
 *                    --up x,y,z --fov DEG] [--near N --far F] [--samples N]
 *                    [--backend cpu|exact|gl] [--threads N] [--stats]
 * Camera and pixel conventions as DESIGN.md section 6. A scene file (include/crisp/scene_file.h)
 * merges its models and composites its f-rep parts by depth. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crisp/image.h"
#ifdef CRISP_HAVE_GL
#include "crisp/gl.h"
#endif
#include "crisp/io.h"
#include "crisp/render.h"
#include "crisp/scene_file.h"
#include "crisp/trim.h"

const char crisp_cmd_render_help[] =
    "render MODEL|SCENE [-o out.png] [--aov out.exr] [--size WxH] [--eye x,y,z --target x,y,z --up x,y,z\n"
    "                            --fov DEG] [--near N --far F] [--samples N] [--backend cpu|exact|gl]\n"
    "                            [--threads N] [--stats]   render a model or a .scene file to an image\n"
    "                            (--up defaults to 0,1,0, or to 0,0,-1 / 0,0,1 looking straight down / up)";

/* Box of the f-rep parts: each part's [-1, 1]^3 (the .vm models' region) through its transform;
 * used only to frame the default camera. */
static void parts_box(const crisp_frep_part *parts, size_t n, double box[6])
{
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < 8; c++) {
            double p[3] = {c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1}, w[4];
            crisp_mat4 m;
            memcpy(m, parts[k].transform, sizeof m);
            crisp_mat4_mulp(m, p, w);
            for (int a = 0; a < 3; a++) {
                box[a] = fmin(box[a], w[a]);
                box[a + 3] = fmax(box[a + 3], w[a]);
            }
        }
}

static int parse_vec3(const char *opt, const char *s, double v[3])
{
    char *end;
    for (int i = 0; i < 3; i++) {
        v[i] = strtod(s, &end);
        if (end == s || !isfinite(v[i]) || (i < 2 && *end != ',') || (i == 2 && *end != '\0')) {
            fprintf(stderr, "crisp render: %s '%s': expected three numbers x,y,z\n", opt, s);
            return 0;
        }
        s = end + 1;
    }
    return 1;
}

static int parse_double(const char *opt, const char *s, double *v)
{
    char *end;
    *v = strtod(s, &end);
    if (end == s || *end || !isfinite(*v)) {
        fprintf(stderr, "crisp render: %s '%s': expected a number\n", opt, s);
        return 0;
    }
    return 1;
}

static int parse_int(const char *opt, const char *s, int lo, int hi, int *v)
{
    char *end;
    long x = strtol(s, &end, 10);
    if (end == s || *end || x < lo || x > hi) {
        fprintf(stderr, "crisp render: %s '%s': expected an integer in %d..%d\n", opt, s, lo, hi);
        return 0;
    }
    *v = (int)x;
    return 1;
}

/* Without --up the up vector is +Y; looking straight up or down (+Y parallel to the view
 * direction) it is -Z when looking down and +Z when looking up, so the image is the one seen
 * with +Y up after tilting the camera over the pole. An explicit --up is used as given (and
 * rejected when parallel). */
static void default_up(crisp_camera *cam)
{
    double d[3], f[3], s[3];
    crisp_vec3_sub(cam->target, cam->eye, d);
    if (!crisp_vec3_normalize(d, f)) return;
    crisp_vec3_cross(f, cam->up, s);
    if (crisp_vec3_norm(s) > 1e-6) return;
    cam->up[0] = 0;
    cam->up[1] = 0;
    cam->up[2] = f[1] < 0 ? -1 : 1;
}

/* The exact backend's trim decision: the face's true trim curves. */
static int classify_exact(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)ctx;
    const crisp_scene_face *f = &sc->faces[face];
    if (f->piece_count == 0) return 1;
    return crisp_trim_exact_classify(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
}

static crisp_status write_outputs(const crisp_image *img, const char *png, const char *exr)
{
    size_t n = (size_t)img->width * img->height;
    crisp_status st = CRISP_OK;
    if (png) {
        uint8_t *px = crisp_malloc_array(n, 4);
        if (!px) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the PNG");
        for (size_t i = 0; i < 4 * n; i++) {
            float c = img->rgba[i];
            px[i] = (uint8_t)lrintf(255.0f * (c < 0 ? 0 : c > 1 ? 1 : c));
        }
        st = crisp_write_png_rgba(png, img->width, img->height, px);
        crisp_free(px);
        if (st) return st;
    }
    if (exr) {
        static const char *const names[] = {"R", "G", "B", "A", "Z", "N.x", "N.y", "N.z", "u", "v", "face"};
        enum { C = 11 };
        float *px = crisp_malloc_array(n, C * sizeof(float));
        if (!px) return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the EXR");
        for (size_t i = 0; i < n; i++) {
            float *d = px + C * i;
            memcpy(d, img->rgba + 4 * i, 4 * sizeof(float));
            d[4] = img->depth[i];
            memcpy(d + 5, img->normal + 3 * i, 3 * sizeof(float));
            d[8] = img->uv[2 * i];
            d[9] = img->uv[2 * i + 1];
            d[10] = (float)img->face[i];
        }
        st = crisp_write_exr(exr, img->width, img->height, C, names, px);
        crisp_free(px);
    }
    return st;
}

int crisp_cmd_render(int argc, char **argv)
{
    const char *model_path = NULL, *png = NULL, *exr = NULL, *backend = "cpu";
    int width = 1280, height = 720, samples = 1, threads = 0, stats = 0;
    int have_eye = 0, have_target = 0, have_up = 0, have_near = 0, have_far = 0, have_fov = 0;
    double eye[3], target[3], up[3] = {0, 1, 0}, fov = 30, znear = 0, zfar = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int more = i + 1 < argc;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            printf("usage: crisp %s\n", crisp_cmd_render_help);
            return 0;
        } else if (!strcmp(a, "--stats")) {
            stats = 1;
        } else if (a[0] == '-' && a[1] != '\0' && !more) {
            fprintf(stderr, "crisp render: option %s needs a value\n", a);
            return 2;
        } else if (!strcmp(a, "-o")) {
            png = argv[++i];
        } else if (!strcmp(a, "--aov")) {
            exr = argv[++i];
        } else if (!strcmp(a, "--size")) {
            const char *s = argv[++i];
            char extra;
            if (sscanf(s, "%dx%d%c", &width, &height, &extra) != 2 || width < 1 || height < 1 ||
                width > 16384 || height > 16384) {
                fprintf(stderr, "crisp render: --size '%s': expected WxH, each 1..16384\n", s);
                return 2;
            }
        } else if (!strcmp(a, "--eye")) {
            if (!parse_vec3(a, argv[++i], eye)) return 2;
            have_eye = 1;
        } else if (!strcmp(a, "--target")) {
            if (!parse_vec3(a, argv[++i], target)) return 2;
            have_target = 1;
        } else if (!strcmp(a, "--up")) {
            if (!parse_vec3(a, argv[++i], up)) return 2;
            have_up = 1;
        } else if (!strcmp(a, "--fov")) {
            if (!parse_double(a, argv[++i], &fov)) return 2;
            have_fov = 1;
        } else if (!strcmp(a, "--near")) {
            if (!parse_double(a, argv[++i], &znear)) return 2;
            have_near = 1;
        } else if (!strcmp(a, "--far")) {
            if (!parse_double(a, argv[++i], &zfar)) return 2;
            have_far = 1;
        } else if (!strcmp(a, "--samples")) {
            if (!parse_int(a, argv[++i], 1, 16, &samples)) return 2;
        } else if (!strcmp(a, "--threads")) {
            if (!parse_int(a, argv[++i], 1, 1024, &threads)) return 2;
        } else if (!strcmp(a, "--backend")) {
            backend = argv[++i];
            if (strcmp(backend, "cpu") && strcmp(backend, "exact") && strcmp(backend, "gl")) {
                fprintf(stderr, "crisp render: --backend '%s': expected cpu, exact or gl\n", backend);
                return 2;
            }
        } else if (a[0] == '-' && a[1] != '\0') {
            fprintf(stderr, "crisp render: unknown option '%s'\n", a);
            return 2;
        } else if (!model_path) {
            model_path = a;
        } else {
            fprintf(stderr, "crisp render: more than one model given ('%s', '%s')\n", model_path, a);
            return 2;
        }
    }
    if (!model_path) {
        fprintf(stderr, "usage: crisp %s\n", crisp_cmd_render_help);
        return 2;
    }
    if (!png && !exr) png = "out.png";
    /* About 75 bytes per sample and pixel (raster target and image): cap a frame near 5 GB. */
    if ((uint64_t)width * (uint64_t)height * (uint64_t)samples > (1ull << 26)) {
        fprintf(stderr, "crisp render: --size %dx%d with %d sample(s) per pixel is %llu samples: at most %llu "
                        "(for example 8192x8192 with 1 sample, 4096x4096 with 4)\n",
                width, height, samples, (unsigned long long)width * height * samples, 1ull << 26);
        return 2;
    }
    int cpu = !strcmp(backend, "cpu"), gl = !strcmp(backend, "gl");
    if (!cpu && !gl && samples != 1) {
        fprintf(stderr, "crisp render: the exact backend casts one ray per pixel centre; --samples "
                        "%d needs the cpu backend\n", samples);
        return 2;
    }

    double t0 = crisp_time_now();
    crisp_model *model = NULL;
    crisp_scene *scene = NULL;
    crisp_scene_file *scene_file = NULL;
    crisp_scene_assets *assets = NULL;
    const crisp_frep_part *parts = NULL;
    size_t part_count = 0;
    crisp_image img = {0};
    int rc = 1;
    crisp_status st;
    if (crisp_scene_file_detect(model_path)) {
        st = crisp_scene_file_read(model_path, &scene_file);
        if (!st) st = crisp_scene_assets_load(scene_file, &assets);
        if (!st) {
            model = assets->model;
            parts = assets->parts;
            part_count = assets->part_count;
        }
    } else {
        st = crisp_model_load(model_path, NULL, &model);
    }
    double t_load = crisp_time_now();
    if (!st) st = crisp_scene_prepare(model, &scene);
    double t_prep = crisp_time_now();
    if (st) goto done;
    if (scene->patch_count == 0 && part_count == 0) {
        st = crisp_error(CRISP_ERR_INVALID_ARG, "%s: the model has no surfaces to render", model_path);
        goto done;
    }
    double box[6];
    if (scene->patch_count > 0) {
        memcpy(box, scene->box, sizeof box);
    } else {
        for (int a = 0; a < 3; a++) box[a] = INFINITY, box[a + 3] = -INFINITY;
    }
    parts_box(parts, part_count, box);
    if (!have_eye && scene_file && scene_file->has_camera) {
        /* the scene file's camera line; options given on the command line win */
        memcpy(eye, scene_file->eye, sizeof eye);
        have_eye = 1;
        if (!have_target && scene_file->has_target) {
            memcpy(target, scene_file->target, sizeof target);
            have_target = 1;
        }
        if (!have_up) memcpy(up, scene_file->up, sizeof up);
        if (!have_fov) fov = scene_file->fov_deg;
    }
    crisp_camera cam;
    if (!have_eye) {
        if ((st = crisp_camera_frame_box(box, width, height, &cam))) goto done;
        cam.fov_deg = fov;
        if (have_near) cam.znear = znear;
        if (have_far) cam.zfar = zfar;
        /* One plane given: the other default keeps near < far. */
        if (have_near && !have_far && !(cam.zfar > cam.znear)) cam.zfar = 2 * cam.znear;
        if (have_far && !have_near && !(cam.znear < cam.zfar)) cam.znear = 1e-4 * cam.zfar;
    } else {
        cam = (crisp_camera){.fov_deg = fov, .width = width, .height = height};
        memcpy(cam.eye, eye, sizeof eye);
        for (int k = 0; k < 3; k++)
            cam.target[k] = have_target ? target[k] : 0.5 * (box[k] + box[k + 3]);
        memcpy(cam.up, up, sizeof up);
        if (!have_up) default_up(&cam);
        /* Default near and far: enclose the model's box seen from the eye. */
        double far_d = 0;
        for (int c = 0; c < 8; c++) {
            double p[3] = {box[(c & 1) ? 3 : 0], box[(c & 2) ? 4 : 1], box[(c & 4) ? 5 : 2]};
            double d[3];
            crisp_vec3_sub(p, eye, d);
            far_d = fmax(far_d, crisp_vec3_norm(d));
        }
        cam.znear = have_near ? znear : fmax(1e-4 * far_d, 1e-12);
        if (have_far && !have_near && !(cam.znear < zfar)) cam.znear = 1e-4 * zfar;
        cam.zfar = have_far ? zfar : fmax(2 * far_d, 2 * cam.znear);
    }
    if ((st = crisp_camera_check(&cam))) goto done;
    if ((st = crisp_image_init(&img, width, height))) goto done;
    crisp_render_stats rs = {0};
    if (cpu) {
        if (samples != 1 && samples != 4 && samples != 16) {
            st = crisp_error(CRISP_ERR_INVALID_ARG, "--samples %d: expected 1, 4 or 16", samples);
            goto done;
        }
        crisp_renderer *r = NULL;
        if (scene->patch_count > 0) {
            st = crisp_renderer_create(&(crisp_render_desc){.samples = samples, .threads = threads}, &r);
            if (!st) st = crisp_render_cpu(r, scene, &cam, &img, &rs);
        }
        crisp_renderer_destroy(r);
    } else if (gl) {
        /* The GL backend (include/crisp/gl.h): headless EGL, same plan, same image conventions. */
#ifdef CRISP_HAVE_GL
        crisp_gl_stats gs = {0};
        char renderer[300] = "";
        if (scene->patch_count > 0) st = crisp_gl_render_once(scene, &cam, samples, &img, &gs, renderer, sizeof renderer);
        if (!st && stats) printf("gl renderer      %s\ngl leaves        %u, %u ribbon quads, %llu bytes uploaded\n", renderer,
                                 gs.leaves, gs.ribbon_quads, (unsigned long long)gs.bytes_uploaded);
#else
        st = crisp_error(CRISP_ERR_UNSUPPORTED, "--backend gl: crisp was built without the GL backend (CRISP_GL=OFF)");
#endif
    } else if (scene->patch_count > 0) {
        crisp_exact_desc desc = {.threads = threads, .classify = classify_exact};
        st = crisp_render_exact(scene, &cam, &desc, &img);
    }
    double t_nurbs = crisp_time_now();
    if (!st && part_count)
        st = crisp_render_frep_parts(parts, part_count, &cam,
                                     &(crisp_frep_parts_desc){.threads = threads, .per_pixel = !cpu && !gl}, &img);
    double t_render = crisp_time_now();
    if (!st) st = write_outputs(&img, png, exr);
    double t_write = crisp_time_now();
    if (!st) {
        rc = 0;
        if (stats) {
            size_t drawn = 0, frep_drawn = 0;
            for (size_t i = 0; i < (size_t)width * height; i++) {
                drawn += img.face[i] >= 0;
                frep_drawn += img.face[i] <= -2;
            }
            printf("backend          %s\n", cpu  ? "cpu (SLEFE tessellation, u-intercept tables)"
                                            : gl ? "gl (OpenGL 4.5 tessellation, u-intercept tables)"
                                                 : "exact (ray casting, exact trim classifier)");
            printf("faces            %u\n", scene->face_count);
            printf("patches          %u\n", scene->patch_count);
            printf("trim pieces      %u\n", scene->piece_count);
            if (cpu) {
                printf("patches drawn    %u (%u split, %u leaves)\n", rs.visible_patches, rs.split_patches, rs.leaves);
                printf("faces drawn      %u\n", rs.visible_faces);
                printf("triangles        %llu\n", (unsigned long long)rs.triangles);
                printf("vertices         %llu\n", (unsigned long long)rs.vertices);
                printf("table rows       %llu\n", (unsigned long long)rs.table_rows);
                printf("table bytes      %llu\n", (unsigned long long)rs.table_bytes);
                if (rs.unresolved)
                    printf("unresolved       %u leaves at the split limit (0.5 px not guaranteed there)\n", rs.unresolved);
            }
            printf("pixels covered   %zu of %zu\n", drawn, (size_t)width * height);
            if (part_count) {
                printf("f-rep parts      %zu\n", part_count);
                printf("f-rep pixels     %zu\n", frep_drawn);
            }
            printf("time load        %.1f ms\n", 1e3 * (t_load - t0));
            printf("time prepare     %.1f ms\n", 1e3 * (t_prep - t_load));
            if (cpu) {
                printf("time levels      %.2f ms\n", rs.ms_levels);
                printf("time edges       %.2f ms\n", rs.ms_edges);
                printf("time trim plan   %.2f ms\n", rs.ms_trim);
                printf("time tessellate  %.2f ms\n", rs.ms_tess);
                printf("time rasterize   %.2f ms\n", rs.ms_raster);
                printf("time resolve     %.2f ms\n", rs.ms_resolve);
            }
            printf("time render      %.1f ms\n", 1e3 * (t_render - t_prep));
            if (part_count) printf("time f-rep parts %.1f ms\n", 1e3 * (t_render - t_nurbs));
            printf("time write       %.1f ms\n", 1e3 * (t_write - t_render));
        }
    }
done:
    if (st) fprintf(stderr, "crisp render: %s\n", crisp_error_message());
    crisp_image_free(&img);
    crisp_scene_destroy(scene);
    if (assets) crisp_scene_assets_destroy(assets);
    else crisp_model_destroy(model);
    crisp_scene_file_destroy(scene_file);
    return rc;
}
