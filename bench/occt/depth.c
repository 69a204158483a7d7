/* bench_occt_depth: depth per pixel of crisp's image against Open CASCADE's mesh of the same
 * file at the same camera (issue 13, "Agreement with Open CASCADE"; optional: built only where
 * Open CASCADE is installed, bench/CMakeLists.txt).
 *
 * For every bundled model (data/nurbs) at the default camera (crisp_camera_frame_box of the
 * scene's box) and a close-up (bench_interactive's: the default camera's centre hit at 1/8 of the
 * field of view), WIDTHxHEIGHT:
 *  - crisp's CPU backend draws the frame (1 sample; depth = view depth of the nearest sample);
 *  - Open CASCADE reads the file (IGES files sewn at 1e-4 of the box diagonal, as bench_occt),
 *    BRepMesh meshes it at the deflection D that equals 0.5 px at the nearest visible point (the
 *    box corner nearest along the view axis, clamped to the near plane: bench_occt's rule), and
 *    the triangles are drawn here by a plain z-buffer: at each pixel centre the camera ray is cut
 *    with every triangle whose screen box holds it (exact ray-triangle intersection in double),
 *    the nearest cut between the near and far planes wins;
 *  - a pixel differs when both depths differ by more than tol = (D + 0.5 px at its depth) /
 *    max(|n . d|, 0.05) (each mesh is within its deflection of the surface, crisp's at 0.5 px; a
 *    normal offset shows along the ray divided by the cosine), or when only one of the two covers
 *    it;
 *  - left out: pixels within 1 px of a silhouette (a pixel whose 3x3 neighbourhood holds both
 *    the background and a surface in either image, or a depth jump between two neighbours of more
 * than 2 px / cos + both tolerances in either image: occluding contours inside the outline), and
 *    pixels that a triangle of Open CASCADE's mesh covers which breaks its own deflection (a
 *    sample of the triangle farther than D from the nearest point of its surface).
 *
 *   bench_occt_depth [MODEL[:default|:close] ...]   (default: every bundled model, both views)
 * At up to 200 of a row's differing pixels the exact renderer (true surfaces and trims) says which
 * side is off: crisp's depth farther than tol from it, Open CASCADE's, both or neither; and how
 * many of those pixels have another face within 1 px in crisp's image.
 * Environment: BENCH_DEPTH_DIR=DIR takes the models from DIR instead of data/nurbs (the cut
 * faces of issue 13: each file's faces against Open CASCADE's); BENCH_DEPTH_PPM=DIR writes
 * DIR/<model>-<view>.ppm (differences red: crisp nearer, blue: Open CASCADE nearer, yellow: one
 * side only; grey: compared and equal; dark: left out). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_camera.h"
#include "bench_util.h"
#include "crisp/io.h"
#include "crisp/render.h"
#include "crisp/trim.h"
#include "occt/occt_tris.h"
#include "render/render_internal.h"

#define WIDTH 960
#define HEIGHT 540
#define THREADS 2
#define MAX_MODELS 64

static void die(const char *what)
{
    fprintf(stderr, "bench_occt_depth: %s: %s\n", what, crisp_error_message());
    exit(1);
}

static int exact_classify(void *ctx, const crisp_scene *sc, uint32_t face, double u, double v)
{
    (void)ctx;
    const crisp_scene_face *f = &sc->faces[face];
    if (!f->piece_count) return 1;
    return crisp_trim_exact_classify(sc->pieces + f->first_piece, (int)f->piece_count, u, v);
}

static double nearest_depth(const double box[6], const crisp_camera *cam)
{
    double f[3];
    crisp_vec3_sub(cam->target, cam->eye, f);
    crisp_vec3_normalize(f, f);
    double zmin = INFINITY;
    for (int k = 0; k < 8; k++) {
        double z = 0;
        for (int i = 0; i < 3; i++)
            z += ((k >> i & 1 ? box[i + 3] : box[i]) - cam->eye[i]) * f[i];
        zmin = fmin(zmin, z);
    }
    return fmax(zmin, cam->znear);
}

/* Open CASCADE's triangles drawn by ray casting at pixel centres: view depth, unit normal and
 * whether the winning triangle breaks the deflection; cover_off: any flagged triangle covers. */
typedef struct zbuf {
    double *depth;
    float *normal;
    unsigned char *off, *cover_off;
} zbuf;

static void draw_occt(const occt_tris *t, const crisp_camera *cam, zbuf *z)
{
    int w = cam->width, h = cam->height;
    size_t n = (size_t)w * h;
    for (size_t p = 0; p < n; p++)
        z->depth[p] = INFINITY, z->off[p] = 0, z->cover_off[p] = 0;
    crisp_camera_matrices m;
    crisp_camera_matrices_compute(cam, &m);
    double f[3], o[3];
    crisp_vec3_sub(cam->target, cam->eye, f);
    crisp_vec3_normalize(f, f);
    for (long long k = 0; k < t->count; k++) {
        double(*P)[3] = t->p[k];
        double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
        int behind = 0;
        for (int i = 0; i < 3; i++) {
            double c[4], px[3];
            crisp_mat4_mulp(m.view_proj, P[i], c);
            if (!(c[3] > 0)) {
                behind = 1;
                break;
            }
            crisp_camera_to_pixel(cam, c, px);
            for (int q = 0; q < 2; q++)
                lo[q] = fmin(lo[q], px[q]), hi[q] = fmax(hi[q], px[q]);
        }
        int x0 = 0, y0 = 0, x1 = w - 1, y1 = h - 1;
        if (!behind) {
            x0 = (int)fmax(0, ceil(lo[0] - 0.5)), x1 = (int)fmin(w - 1, floor(hi[0] - 0.5));
            y0 = (int)fmax(0, ceil(lo[1] - 0.5)), y1 = (int)fmin(h - 1, floor(hi[1] - 0.5));
        }
        double e1[3], e2[3], nrm[3];
        crisp_vec3_sub(P[1], P[0], e1);
        crisp_vec3_sub(P[2], P[0], e2);
        crisp_vec3_cross(e1, e2, nrm);
        if (!(crisp_vec3_norm(nrm) > 0)) continue;
        crisp_vec3_normalize(nrm, nrm);
        for (int y = y0; y <= y1; y++)
            for (int x = x0; x <= x1; x++) {
                double d[3], pv[3], tv[3], qv[3];
                crisp_camera_ray(cam, x + 0.5, y + 0.5, o, d);
                /* Moller-Trumbore */
                crisp_vec3_cross(d, e2, pv);
                double det = crisp_vec3_dot(e1, pv);
                if (det == 0) continue;
                crisp_vec3_sub(o, P[0], tv);
                double u = crisp_vec3_dot(tv, pv) / det;
                if (u < 0 || u > 1) continue;
                crisp_vec3_cross(tv, e1, qv);
                double v = crisp_vec3_dot(d, qv) / det;
                if (v < 0 || u + v > 1) continue;
                double tt = crisp_vec3_dot(e2, qv) / det;
                double depth = tt * crisp_vec3_dot(d, f);
                if (!(depth >= cam->znear && depth <= cam->zfar)) continue;
                size_t p = (size_t)y * w + x;
                if (t->off[k]) z->cover_off[p] = 1;
                if (depth < z->depth[p]) {
                    z->depth[p] = depth;
                    z->off[p] = t->off[k];
                    for (int q = 0; q < 3; q++)
                        z->normal[3 * p + q] = (float)nrm[q];
                }
            }
    }
}

typedef struct tally {
    long long covered, near_sil, occt_off, compared, crisp_nearer, occt_nearer, only_crisp,
        only_occt;
    double worst; /* largest |difference| / tol among the compared */
} tally;

/* Depth tolerance at pixel p for a surface of normal n seen along d (both unit). */
static double tol_at(double defl, double px_world, const float *n, const double d[3])
{
    double c = fabs(n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
    return (defl + 0.5 * px_world) / fmax(c, 0.05);
}

int main(int argc, char **argv)
{
    bench_print_machine(stdout);
    static char names[MAX_MODELS][256];
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/nurbs", CRISP_DATA_DIR);
    if (getenv("BENCH_DEPTH_DIR")) snprintf(dir, sizeof dir, "%s", getenv("BENCH_DEPTH_DIR"));
    int model_count = bench_list_files(dir, names, MAX_MODELS);
    const char *ppm = getenv("BENCH_DEPTH_PPM");
    printf(
        "%dx%d, crisp CPU backend 1 sample, %d threads; Open CASCADE 7.6 BRepMesh (angular "
        "deflection 0.5 rad) at D = 0.5 px at the nearest visible point, drawn by ray casting\n\n",
        WIDTH, HEIGHT, THREADS);
    printf("| model | view | D (model units) | OCCT triangles (off D; faces meshed) | pixels "
           "covered | within 1 px "
           "of a silhouette | under OCCT triangles off D | compared | crisp nearer | OCCT nearer "
           "| crisp only | OCCT only | worst / tol | exact: crisp off / OCCT off / both / neither "
           "| of those at a face edge |\n");
    printf("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|\n");
    fflush(stdout);
    for (int mi = 0; mi < model_count; mi++) {
        int want[2] = {argc <= 1, argc <= 1};
        for (int a = 1; a < argc; a++) {
            size_t l = strlen(names[mi]);
            const char *arg = argv[a];
            if (strncmp(arg, names[mi], l) && strncmp(names[mi], arg, strcspn(arg, ":"))) continue;
            const char *colon = strchr(arg, ':');
            if (!colon || !strcmp(colon, ":default")) want[0] = 1;
            if (!colon || !strcmp(colon, ":close")) want[1] = 1;
        }
        if (!want[0] && !want[1]) continue;
        char path[1400];
        snprintf(path, sizeof path, "%.1000s/%.255s", dir, names[mi]);
        crisp_model *model;
        crisp_scene *sc;
        if (crisp_model_load(path, NULL, &model)) die(path);
        if (crisp_scene_prepare(model, &sc)) die("scene");
        crisp_camera cams[2];
        if (crisp_camera_frame_box(sc->box, WIDTH, HEIGHT, &cams[0])) die("camera");
        cams[1] = bench_close_up(sc, &cams[0]);
        crisp_renderer *r;
        if (crisp_renderer_create(&(crisp_render_desc){.threads = THREADS, .samples = 1}, &r))
            die("renderer");
        crisp_image img;
        if (crisp_image_init(&img, WIDTH, HEIGHT)) die("image");
        size_t n = (size_t)WIDTH * HEIGHT;
        zbuf z = {malloc(n * sizeof *z.depth), malloc(3 * n * sizeof *z.normal), malloc(n),
                  malloc(n)};
        unsigned char *sil = malloc(n);
        unsigned char *rgb = malloc(3 * n);
        if (!z.depth || !z.normal || !z.off || !z.cover_off || !sil || !rgb) die("memory");
        for (int v = 0; v < 2; v++) {
            if (!want[v]) continue;
            const crisp_camera *cam = &cams[v];
            const char *vname = v ? "close" : "default";
            if (crisp_render_cpu(r, sc, cam, &img, NULL)) die("render");
            double zn = nearest_depth(sc->box, cam);
            double defl = zn * tan(cam->fov_deg * (M_PI / 360.0)) / cam->height;
            occt_tris t;
            char err[512];
            int is_iges = strstr(names[mi], ".ig") != NULL;
            occt_tris_desc od = {.path = path,
                                 .sew = is_iges,
                                 .sew_rel_tol = 1e-4,
                                 .deflection = defl,
                                 .unit_to_mm = model->unit_to_mm,
                                 .threads = THREADS};
            if (occt_tris_mesh(&od, &t, err, sizeof err)) {
                printf("| %s | %s | %.3g | %s | | | | | | | | | | | |\n", names[mi], vname, defl,
                       err);
                occt_tris_free(&t);
                continue;
            }
            draw_occt(&t, cam, &z);
            double px_scale = 2 * tan(cam->fov_deg * (M_PI / 360.0)) / cam->height;
            /* per-pixel view direction and tolerances */
            double *tol_c = malloc(n * sizeof *tol_c), *tol_o = malloc(n * sizeof *tol_o);
            double(*dir)[3] = malloc(n * sizeof *dir);
            if (!tol_c || !tol_o || !dir) die("memory");
            for (int y = 0; y < HEIGHT; y++)
                for (int x = 0; x < WIDTH; x++) {
                    size_t p = (size_t)y * WIDTH + x;
                    double o[3];
                    crisp_camera_ray(cam, x + 0.5, y + 0.5, o, dir[p]);
                    tol_c[p] = img.face[p] >= 0 ? tol_at(defl, img.depth[p] * px_scale,
                                                         img.normal + 3 * p, dir[p])
                                                : 0;
                    tol_o[p] = isfinite(z.depth[p])
                                   ? tol_at(defl, z.depth[p] * px_scale, z.normal + 3 * p, dir[p])
                                   : 0;
                }
            /* silhouettes: background, or a jump between 4-neighbours, in either image */
            memset(sil, 0, n);
            for (int y = 0; y < HEIGHT; y++)
                for (int x = 0; x < WIDTH; x++) {
                    size_t p = (size_t)y * WIDTH + x;
                    int hc = img.face[p] >= 0, ho = isfinite(z.depth[p]);
                    for (int k = 0; k < 2; k++) {
                        int xx = x + (k == 0), yy = y + (k == 1);
                        if (xx >= WIDTH || yy >= HEIGHT) continue;
                        size_t q = (size_t)yy * WIDTH + xx;
                        /* a covered pixel beside an empty one, in either image */
                        int jump = hc != (img.face[q] >= 0) || ho != isfinite(z.depth[q]);
                        if (hc && img.face[q] >= 0) {
                            double cs = fmax(fabs(crisp_vec3_dot((double[3]){img.normal[3 * p],
                                                                             img.normal[3 * p + 1],
                                                                             img.normal[3 * p + 2]},
                                                                 dir[p])),
                                             0.05);
                            jump |= fabs(img.depth[p] - img.depth[q]) >
                                    2 * img.depth[p] * px_scale / cs + tol_c[p] + tol_c[q];
                        }
                        if (ho && isfinite(z.depth[q])) {
                            double cs = fmax(fabs(z.normal[3 * p] * dir[p][0] +
                                                  z.normal[3 * p + 1] * dir[p][1] +
                                                  z.normal[3 * p + 2] * dir[p][2]),
                                             0.05);
                            jump |= fabs(z.depth[p] - z.depth[q]) >
                                    2 * z.depth[p] * px_scale / cs + tol_o[p] + tol_o[q];
                        }
                        if (jump) sil[p] = sil[q] = 1;
                    }
                }
            tally tl = {0};
            for (int y = 0; y < HEIGHT; y++)
                for (int x = 0; x < WIDTH; x++) {
                    size_t p = (size_t)y * WIDTH + x;
                    int hc = img.face[p] >= 0, ho = isfinite(z.depth[p]);
                    unsigned char *c = rgb + 3 * p;
                    c[0] = c[1] = c[2] = 0;
                    if (!hc && !ho) continue;
                    tl.covered++;
                    int near = 0;
                    for (int dy = -1; dy <= 1 && !near; dy++)
                        for (int dx = -1; dx <= 1 && !near; dx++) {
                            int xx = x + dx, yy = y + dy;
                            near = xx < 0 || yy < 0 || xx >= WIDTH || yy >= HEIGHT ||
                                   sil[(size_t)yy * WIDTH + xx];
                        }
                    if (near) {
                        tl.near_sil++;
                        c[0] = c[1] = c[2] = 40;
                        continue;
                    }
                    if (z.cover_off[p]) {
                        tl.occt_off++;
                        c[0] = c[1] = c[2] = 70;
                        continue;
                    }
                    tl.compared++;
                    c[0] = c[1] = c[2] = 160;
                    if (hc != ho) {
                        if (hc)
                            tl.only_crisp++;
                        else
                            tl.only_occt++;
                        c[0] = c[1] = 255, c[2] = 0;
                        continue;
                    }
                    double diff = z.depth[p] - img.depth[p], tol = fmax(tol_c[p], tol_o[p]);
                    tl.worst = fmax(tl.worst, fabs(diff) / tol);
                    if (fabs(diff) > tol) {
                        if (diff > 0)
                            tl.crisp_nearer++, c[0] = 255, c[1] = c[2] = 0;
                        else
                            tl.occt_nearer++, c[2] = 255, c[0] = c[1] = 0;
                    }
                }
            /* Who is off: the exact renderer (true surfaces, exact trims) at up to 200 of the
             * differing pixels, evenly spread. */
            long long ndiff = tl.crisp_nearer + tl.occt_nearer + tl.only_crisp + tl.only_occt;
            long long stride = ndiff > 200 ? (ndiff + 199) / 200 : 1, seen = 0;
            long long who[4] = {0};  /* crisp off, OCCT off, both off, neither */
            long long at_edge = 0;   /* of the sampled: another face within 1 px */
            int shown[4][3] = {{0}}; /* examples printed per class and kind */
            crisp_exact_desc ed = {.threads = 1, .classify = exact_classify};
            double f[3];
            crisp_vec3_sub(cam->target, cam->eye, f);
            crisp_vec3_normalize(f, f);
            for (size_t p = 0; p < n && ndiff; p++) {
                const unsigned char *c = rgb + 3 * p;
                int differs = c[0] == 255 || c[2] == 255;
                if (!differs || seen++ % stride) continue;
                double o[3], dd[3], te = INFINITY;
                int x = (int)(p % WIDTH), y = (int)(p / WIDTH);
                crisp_camera_ray(cam, x + 0.5, y + 0.5, o, dd);
                double cs = crisp_vec3_dot(dd, f);
                if (crisp_exact_ray(sc, &ed, o, dd, cam->znear / cs, cam->zfar / cs, &te, NULL,
                                    NULL, NULL))
                    te *= cs;
                double tol = fmax(tol_c[p], tol_o[p]);
                double zc = img.face[p] >= 0 ? img.depth[p] : INFINITY;
                int coff = !(fabs(zc - te) <= tol) && !(isinf(zc) && isinf(te));
                int ooff = !(fabs(z.depth[p] - te) <= tol) && !(isinf(z.depth[p]) && isinf(te));
                int k = coff && ooff ? 2 : coff ? 0 : ooff ? 1 : 3;
                int edge = 0; /* another face within 1 px in crisp's image */
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -1; dx <= 1; dx++) {
                        int xx = x + dx, yy = y + dy;
                        if (xx >= 0 && yy >= 0 && xx < WIDTH && yy < HEIGHT &&
                            img.face[(size_t)yy * WIDTH + xx] != img.face[p])
                            edge = 1;
                    }
                at_edge += edge;
                int kind = isinf(zc) || isinf(z.depth[p]) ? 2 : zc < z.depth[p] ? 0 : 1;
                who[k]++;
                if (++shown[k][kind] <= 2)
                    fprintf(stderr,
                            "%s %s (%d, %d): crisp %.9g face %d uv %.6g %.6g, OCCT %.9g, exact "
                            "%.9g, tol %.3g\n",
                            names[mi], vname, x, y, zc, img.face[p], img.uv[2 * p],
                            img.uv[2 * p + 1], z.depth[p], te, tol);
            }
            printf("| %s | %s | %.3g | %lld (%lld; %d of %d faces) | %lld | %lld | %lld | %lld | "
                   "%lld | %lld | %lld "
                   "| %lld | %.3g | %lld / %lld / %lld / %lld | %lld |\n",
                   names[mi], vname, defl, t.count, t.off_count, t.faces_meshed, t.faces,
                   tl.covered, tl.near_sil, tl.occt_off, tl.compared, tl.crisp_nearer,
                   tl.occt_nearer, tl.only_crisp, tl.only_occt, tl.worst, who[0], who[1], who[2],
                   who[3], at_edge);
            fflush(stdout);
            if (ppm) {
                char out[2048];
                snprintf(out, sizeof out, "%.1000s/%.255s-%s.ppm", ppm, names[mi], vname);
                FILE *fp = fopen(out, "wb");
                if (fp) {
                    fprintf(fp, "P6\n%d %d\n255\n", WIDTH, HEIGHT);
                    fwrite(rgb, 3, n, fp);
                    fclose(fp);
                }
            }
            free(tol_c);
            free(tol_o);
            free(dir);
            occt_tris_free(&t);
        }
        free(z.depth);
        free(z.normal);
        free(z.off);
        free(z.cover_off);
        free(sil);
        free(rgb);
        crisp_image_free(&img);
        crisp_renderer_destroy(r);
        crisp_scene_destroy(sc);
        crisp_model_destroy(model);
    }
    return 0;
}
