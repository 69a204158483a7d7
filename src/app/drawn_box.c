/* What a scene draws, for framing cameras: points of the true trimmed surfaces and their box. The
 * scene's own box (crisp_scene.box: patches clipped to the uv box of their trim loops) is safe
 * but can be far too large: a blade trimmed diagonally out of a big surface keeps the whole
 * surface's box. Here each trimmed face contributes its boundary (every trim piece sampled
 * densely and mapped through the surface) and the interior points of a uv grid that the exact
 * classifier finds inside the trim (an extreme of a coordinate over the face is on its boundary
 * or at an interior critical point, which the grid comes near); an untrimmed face contributes a
 * grid over its whole domain with its edges. The result is a slight inner approximation (the sag
 * between samples, well under the camera's margin). A camera fitted to the points themselves
 * (crisp_camera_fit_points) frames the model's silhouette, not the corners of its box, which
 * for a round model seen from a corner leaves a third of the frame empty. Faces are shared out
 * over the core pool. */
#include <math.h>
#include <string.h>

#include "app_internal.h"
#include "crisp/nurbs.h"
#include "crisp/trim.h"

enum { PIECE_SAMPLES = 16, GRID = 12, FULL_GRID = 16 };

typedef struct {
    const crisp_scene *sc;
    size_t *first;  /* per face + 1: where its points start */
    double *points; /* 3 per point */
    size_t *count;  /* per face: points written */
} job;

/* Points a face can write at most. */
static size_t face_capacity(const crisp_scene_face *f)
{
    if (f->piece_count == 0) return (FULL_GRID + 1) * (FULL_GRID + 1);
    return (size_t)f->piece_count * (PIECE_SAMPLES + 1) + (GRID - 1) * (GRID - 1);
}

typedef struct {
    double *p;
    size_t n;
} sink;

static void add(sink *k, const double p[3])
{
    if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) return;
    memcpy(k->p + 3 * k->n, p, 3 * sizeof(double));
    k->n++;
}

static void face_points(const crisp_scene *sc, const crisp_scene_face *f, sink *out)
{
    const crisp_surface *s = f->src->surface;
    const double *dom = f->domain;
    double p[3];
    if (f->piece_count == 0) {
        for (int j = 0; j <= FULL_GRID; j++)
            for (int i = 0; i <= FULL_GRID; i++) {
                double u = dom[0] + (dom[1] - dom[0]) * i / FULL_GRID;
                double v = dom[2] + (dom[3] - dom[2]) * j / FULL_GRID;
                crisp_surface_eval(s, u, v, p);
                add(out, p);
            }
        return;
    }
    const crisp_bezier_curve *pieces = sc->pieces + f->first_piece;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (uint32_t k = 0; k < f->piece_count; k++)
        for (int i = 0; i <= PIECE_SAMPLES; i++) {
            double uv[4];
            crisp_bezier_curve_eval(&pieces[k], (double)i / PIECE_SAMPLES, uv);
            if (!isfinite(uv[0]) || !isfinite(uv[1])) continue;
            double u = fmin(fmax(uv[0], dom[0]), dom[1]), v = fmin(fmax(uv[1], dom[2]), dom[3]);
            lo[0] = fmin(lo[0], u), hi[0] = fmax(hi[0], u);
            lo[1] = fmin(lo[1], v), hi[1] = fmax(hi[1], v);
            crisp_surface_eval(s, u, v, p);
            add(out, p);
        }
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1])) return;
    for (int j = 1; j < GRID; j++)
        for (int i = 1; i < GRID; i++) {
            double u = lo[0] + (hi[0] - lo[0]) * i / GRID, v = lo[1] + (hi[1] - lo[1]) * j / GRID;
            if (!crisp_trim_exact_classify(pieces, (int)f->piece_count, u, v)) continue;
            crisp_surface_eval(s, u, v, p);
            add(out, p);
        }
}

static void run(void *ctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    job *j = ctx;
    for (size_t i = begin; i < end; i++) {
        sink k = {j->points + 3 * j->first[i], 0};
        face_points(j->sc, &j->sc->faces[i], &k);
        j->count[i] = k.n;
    }
}

crisp_status crisp__scene_drawn_points(const crisp_scene *sc, double **points, size_t *count,
                                       double box[6])
{
    *points = NULL;
    *count = 0;
    for (int a = 0; a < 3; a++)
        box[a] = INFINITY, box[a + 3] = -INFINITY;
    if (!sc->face_count) return CRISP_OK;
    job j = {sc, crisp_malloc_array(sc->face_count + 1, sizeof(size_t)), NULL,
             crisp_calloc_array(sc->face_count, sizeof(size_t))};
    if (j.first) {
        j.first[0] = 0;
        for (uint32_t i = 0; i < sc->face_count; i++)
            j.first[i + 1] = j.first[i] + face_capacity(&sc->faces[i]);
        j.points = crisp_malloc_array(j.first[sc->face_count], 3 * sizeof(double));
    }
    if (!j.first || !j.points || !j.count) {
        crisp_free(j.first), crisp_free(j.points), crisp_free(j.count);
        return crisp_error(CRISP_ERR_NO_MEMORY, "out of memory for the faces' sample points");
    }
    crisp_pool_parallel_for(crisp_pool_shared(), sc->face_count, 4, run, &j);
    /* pack, clamped to the scene's safe box */
    size_t n = 0;
    for (uint32_t i = 0; i < sc->face_count; i++)
        for (size_t q = 0; q < j.count[i]; q++) {
            double *p = j.points + 3 * (j.first[i] + q), *d = j.points + 3 * n++;
            for (int a = 0; a < 3; a++) {
                d[a] = fmin(fmax(p[a], sc->box[a]), sc->box[a + 3]);
                box[a] = fmin(box[a], d[a]);
                box[a + 3] = fmax(box[a + 3], d[a]);
            }
        }
    crisp_free(j.first);
    crisp_free(j.count);
    if (!n) {
        crisp_free(j.points);
        memcpy(box, sc->box, 6 * sizeof(double));
        return CRISP_OK;
    }
    *points = j.points;
    *count = n;
    return CRISP_OK;
}
