/* f-rep parts in a crisp scene (DESIGN.md section 7), drawn through the perspective camera of
 * DESIGN.md section 6 and composited with what the image already holds by camera-space depth.
 *
 * Method (Keeter 2012's z-culled heightmaps, carried into the view frustum): a cell is a
 * rectangle of pixel centres times a camera-space depth interval [z0, z1]. A camera-space point
 * is P = eye + z (f + nx r + ny u) with nx, ny the normalised image coordinates, so the part's
 * local coordinates Q = M^-1 P are multilinear in (nx, ny, z) and a cell's 8 corners bound them:
 * their box (rounded outwards to float) goes to the interval evaluator. Cells where f > 0 are
 * skipped; cells that start behind every pixel's current depth are culled (z-culling, and each
 * hit lowers the depth at once); other cells split, spatially while they are wider than deep,
 * else in depth, near half first. A single pixel's cell is its centre ray, where segments are
 * bisected by intervals down to 1/8 pixel footprint, and a sign change of f between a segment's
 * ends is bisected with point values to float precision. Normals come from the gradient
 * evaluator (batched per tile), mapped to world space by the inverse transpose. */
#include "render_internal.h"

#include <math.h>
#include <string.h>

#include "crisp/frep.h"

#define TILE 16
#define RAY_STACK 128
#define MAX_LEVEL 160

typedef struct part_view {
    const crisp_frep_tape *tape;
    double inv[4][4];                  /* world -> local, m[col][row] */
    double qe[3], qf[3], qr[3], qu[3]; /* Q = qe + z (qf + nx qr + ny qu) */
    float color[4];
    int32_t id;
} part_view;

typedef struct frep_ctx {
    const part_view *pv;
    const crisp_camera *cam;
    crisp_image *img;
    double f[3], r[3], u[3]; /* camera basis (as crisp_camera_ray) */
    double sx, sy;           /* nx = (2 (i + 0.5) / W - 1) sx, ny = (1 - 2 (j + 0.5) / H) sy */
    double pix;              /* one pixel in normalised image units (footprint / depth) */
    int tiles_x;
    int per_pixel;
} frep_ctx;

typedef struct tile_hits {
    int count;
    int i0, j0;                /* the tile's first pixel */
    uint8_t done[TILE * TILE]; /* the pixel has its hit for this part (the float depth it holds
                                  may round above the hit, so depth alone cannot cull it) */
    int32_t pixel[TILE * TILE];
    float x[TILE * TILE], y[TILE * TILE], z[TILE * TILE];
    double depth[TILE * TILE];
} tile_hits;

static double nx_of(const frep_ctx *c, double i)
{
    return (2.0 * (i + 0.5) / c->cam->width - 1.0) * c->sx;
}
static double ny_of(const frep_ctx *c, double j)
{
    return (1.0 - 2.0 * (j + 0.5) / c->cam->height) * c->sy;
}

static float round_down(double v)
{
    float f = (float)v;
    if (!((double)f <= v)) f = nextafterf(f, -INFINITY);
    return nextafterf(f, -INFINITY); /* one more ulp for the double rounding of the corners */
}

static float round_up(double v)
{
    float f = (float)v;
    if (!((double)f >= v)) f = nextafterf(f, INFINITY);
    return nextafterf(f, INFINITY);
}

/* Interval of f over the box of local points Q(nx, ny, z), nx in [a0, a1], ny in [b0, b1],
 * z in [z0, z1] (multilinear, so the corners bound it). */
static void cell_interval(const part_view *pv, double a0, double a1, double b0, double b1,
                          double z0, double z1, float dest[2])
{
    float box[3][2];
    for (int k = 0; k < 3; k++) {
        double lo = INFINITY, hi = -INFINITY;
        for (int c = 0; c < 8; c++) {
            double nx = c & 1 ? a1 : a0, ny = c & 2 ? b1 : b0, z = c & 4 ? z1 : z0;
            double q = pv->qe[k] + z * (pv->qf[k] + nx * pv->qr[k] + ny * pv->qu[k]);
            lo = fmin(lo, q);
            hi = fmax(hi, q);
        }
        box[k][0] = round_down(lo);
        box[k][1] = round_up(hi);
    }
    crisp_frep_eval_interval(pv->tape, box[0], box[1], box[2], dest);
}

static void local_point(const part_view *pv, double nx, double ny, double z, float q[3])
{
    for (int k = 0; k < 3; k++)
        q[k] = (float)(pv->qe[k] + z * (pv->qf[k] + nx * pv->qr[k] + ny * pv->qu[k]));
}

static float f_at(const part_view *pv, double nx, double ny, double z)
{
    float q[3];
    local_point(pv, nx, ny, z, q);
    return crisp_frep_eval_point(pv->tape, q[0], q[1], q[2]);
}

/* Depth limit of pixel p: what it holds, within the camera's far plane. */
static double pixel_limit(const frep_ctx *c, size_t p)
{
    double d = c->img->depth[p];
    return d < c->cam->zfar ? d : c->cam->zfar;
}

/* The first depth in [z0, z1] along pixel (i, j)'s centre ray where f < 0; records the hit. */
static void solve_ray(const frep_ctx *c, tile_hits *h, int i, int j, double z0, double z1)
{
    const part_view *pv = c->pv;
    int local = (j - h->j0) * TILE + (i - h->i0);
    if (h->done[local]) return;
    double nx = nx_of(c, i), ny = ny_of(c, j);
    double seg[RAY_STACK][2];
    int top = 0;
    seg[top][0] = z0, seg[top][1] = z1, top++;
    double hit = NAN;
    while (top > 0) {
        top--;
        double a = seg[top][0], b = seg[top][1];
        float iv[2];
        cell_interval(pv, nx, nx, ny, ny, a, b, iv);
        if (iv[0] > 0) continue;
        if (iv[1] < 0) {
            hit = a;
            break;
        }
        double tol = 0.125 * c->pix * b;
        if (b - a <= tol || top >= RAY_STACK - 2) {
            float fa = f_at(pv, nx, ny, a), fb = f_at(pv, nx, ny, b);
            if (fa < 0) {
                hit = a;
                break;
            }
            if (fb < 0) {
                /* f(a) >= 0 (or NaN), f(b) < 0: bisect to float precision. */
                for (int it = 0; it < 64 && b - a > 1e-7 * b; it++) {
                    double m = 0.5 * (a + b);
                    if (m <= a || m >= b) break;
                    if (f_at(pv, nx, ny, m) < 0)
                        b = m;
                    else
                        a = m;
                }
                hit = b;
                break;
            }
            continue;
        }
        double m = 0.5 * (a + b);
        seg[top][0] = m, seg[top][1] = b, top++; /* far half below, near half on top */
        seg[top][0] = a, seg[top][1] = m, top++;
    }
    if (!(hit == hit)) return;
    size_t p = (size_t)j * c->cam->width + i;
    if (!(hit < c->img->depth[p]) || h->count == TILE * TILE) return;
    c->img->depth[p] = (float)hit; /* z-culls the rest of this pixel at once */
    h->done[local] = 1;
    int k = h->count++;
    float q[3];
    local_point(pv, nx, ny, hit, q);
    h->pixel[k] = (int32_t)p;
    h->x[k] = q[0], h->y[k] = q[1], h->z[k] = q[2];
    h->depth[k] = hit;
}

/* Cell: pixels [i0, i1) x [j0, j1), depths [z0, z1]. */
static void solve_cell(const frep_ctx *c, tile_hits *h, int i0, int j0, int i1, int j1, double z0,
                       double z1, int level)
{
    double zmax = 0;
    for (int j = j0; j < j1; j++)
        for (int i = i0; i < i1; i++)
            zmax = fmax(zmax, pixel_limit(c, (size_t)j * c->cam->width + i));
    if (z0 >= zmax) return; /* z-culled */
    if (z1 > zmax) z1 = zmax;
    if (i1 - i0 == 1 && j1 - j0 == 1) {
        solve_ray(c, h, i0, j0, z0, z1);
        return;
    }
    double a0 = nx_of(c, i0), a1 = nx_of(c, i1 - 1), b0 = ny_of(c, j1 - 1), b1 = ny_of(c, j0);
    float iv[2];
    cell_interval(c->pv, a0, a1, b0, b1, z0, z1, iv);
    if (iv[0] > 0) return;
    double wide = z1 * fmax(a1 - a0, b1 - b0);
    if (wide >= z1 - z0 || level >= MAX_LEVEL) {
        int w = i1 - i0, ht = j1 - j0;
        if (w >= ht) {
            int im = i0 + w / 2;
            solve_cell(c, h, i0, j0, im, j1, z0, z1, level + 1);
            solve_cell(c, h, im, j0, i1, j1, z0, z1, level + 1);
        } else {
            int jm = j0 + ht / 2;
            solve_cell(c, h, i0, j0, i1, jm, z0, z1, level + 1);
            solve_cell(c, h, i0, jm, i1, j1, z0, z1, level + 1);
        }
    } else {
        double zm = 0.5 * (z0 + z1);
        solve_cell(c, h, i0, j0, i1, j1, z0, zm, level + 1);
        solve_cell(c, h, i0, j0, i1, j1, zm, z1, level + 1);
    }
}

/* Normals and shading of a tile's hits. */
static void shade_hits(const frep_ctx *c, tile_hits *h)
{
    if (h->count == 0) return;
    const part_view *pv = c->pv;
    float g[4 * TILE * TILE];
    int have_grad =
        crisp_frep_eval_grad(pv->tape, (size_t)h->count, h->x, h->y, h->z, g) == CRISP_OK;
    int W = c->cam->width;
    for (int k = 0; k < h->count; k++) {
        size_t p = (size_t)h->pixel[k];
        int i = (int)(p % (size_t)W), j = (int)(p / (size_t)W);
        double nx = nx_of(c, i), ny = ny_of(c, j), z = h->depth[k];
        double view[3], n[3] = {0, 0, 0};
        for (int a = 0; a < 3; a++)
            view[a] = z * (c->f[a] + nx * c->r[a] + ny * c->u[a]);
        if (have_grad)
            for (int a = 0; a < 3; a++) /* world gradient = (M^-1)^T local gradient */
                for (int b = 0; b < 3; b++)
                    n[a] += pv->inv[a][b] * (double)g[4 * k + 1 + b];
        double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(len > 0) || !isfinite(len)) {
            for (int a = 0; a < 3; a++)
                n[a] = -c->f[a]; /* no gradient: face the camera */
            len = 1;
        }
        for (int a = 0; a < 3; a++)
            c->img->normal[3 * p + a] = (float)(n[a] / len);
        crisp__shade(pv->color, n, view, c->img->rgba + 4 * p);
        c->img->rgba[4 * p + 3] = pv->color[3];
        c->img->uv[2 * p] = c->img->uv[2 * p + 1] = 0;
        c->img->face[p] = pv->id;
    }
    h->count = 0;
}

static void render_tiles(void *ctx, size_t begin, size_t end, int worker)
{
    (void)worker;
    const frep_ctx *c = ctx;
    tile_hits hits;
    hits.count = 0;
    for (size_t t = begin; t < end; t++) {
        int i0 = (int)(t % (size_t)c->tiles_x) * TILE, j0 = (int)(t / (size_t)c->tiles_x) * TILE;
        hits.i0 = i0, hits.j0 = j0;
        memset(hits.done, 0, sizeof hits.done);
        int i1 = i0 + TILE < c->cam->width ? i0 + TILE : c->cam->width;
        int j1 = j0 + TILE < c->cam->height ? j0 + TILE : c->cam->height;
        if (c->per_pixel) {
            for (int j = j0; j < j1; j++)
                for (int i = i0; i < i1; i++) {
                    double lim = pixel_limit(c, (size_t)j * c->cam->width + i);
                    if (c->cam->znear < lim) solve_ray(c, &hits, i, j, c->cam->znear, lim);
                }
        } else {
            solve_cell(c, &hits, i0, j0, i1, j1, c->cam->znear, c->cam->zfar, 0);
        }
        shade_hits(c, &hits);
    }
}

static crisp_status part_view_init(const crisp_frep_part *part, size_t k, const crisp_camera *cam,
                                   const frep_ctx *c, part_view *pv)
{
    crisp_mat4 m;
    memcpy(m, part->transform, sizeof m);
    if (!part->tape) return crisp_error(CRISP_ERR_INVALID_ARG, "f-rep part %zu: no tape", k);
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++)
            if (!isfinite(m[a][b]))
                return crisp_error(CRISP_ERR_INVALID_ARG, "f-rep part %zu: non-finite transform",
                                   k);
    if (m[0][3] != 0 || m[1][3] != 0 || m[2][3] != 0 || m[3][3] != 1)
        return crisp_error(CRISP_ERR_INVALID_ARG,
                           "f-rep part %zu: transform is not affine (expected last row 0 0 0 1)",
                           k);
    memset(pv, 0, sizeof *pv);
    if (!crisp_mat4_inverse(m, pv->inv))
        return crisp_error(CRISP_ERR_INVALID_ARG, "f-rep part %zu: transform is singular", k);
    pv->tape = part->tape;
    memcpy(pv->color, part->color, sizeof pv->color);
    pv->id = CRISP_FREP_FACE_ID(k);
    /* Q = inv (eye + z d): columns of inv are m[col][row]. */
    for (int a = 0; a < 3; a++) {
        pv->qe[a] = pv->inv[3][a];
        for (int b = 0; b < 3; b++) {
            pv->qe[a] += pv->inv[b][a] * cam->eye[b];
            pv->qf[a] += pv->inv[b][a] * c->f[b];
            pv->qr[a] += pv->inv[b][a] * c->r[b];
            pv->qu[a] += pv->inv[b][a] * c->u[b];
        }
    }
    return CRISP_OK;
}

crisp_status crisp_render_frep_parts(const crisp_frep_part *parts, size_t count,
                                     const crisp_camera *cam, const crisp_frep_parts_desc *desc,
                                     crisp_image *img)
{
    crisp_status st = crisp_camera_check(cam);
    if (st) return st;
    if (img->width != cam->width || img->height != cam->height)
        return crisp_error(CRISP_ERR_INVALID_ARG, "image %dx%d does not match the camera's %dx%d",
                           img->width, img->height, cam->width, cam->height);
    if (count == 0) return CRISP_OK;
    if (!parts) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_render_frep_parts: NULL parts");
    frep_ctx c = {.cam = cam, .img = img, .per_pixel = desc && desc->per_pixel};
    crisp_vec3 d;
    crisp_vec3_sub(cam->target, cam->eye, d);
    crisp_vec3_normalize(d, c.f);
    crisp_vec3_cross(c.f, cam->up, d);
    crisp_vec3_normalize(d, c.r);
    crisp_vec3_cross(c.r, c.f, c.u);
    double t = tan(cam->fov_deg * (M_PI / 360.0));
    c.sx = t * cam->width / cam->height;
    c.sy = t;
    c.pix = 2.0 * t / cam->height;
    c.tiles_x = (cam->width + TILE - 1) / TILE;
    size_t tiles = (size_t)c.tiles_x * (size_t)((cam->height + TILE - 1) / TILE);
    crisp_pool *pool = NULL;
    int threads = desc && desc->threads > 0 ? desc->threads : crisp_pool_default_threads();
    if ((st = crisp_pool_create(threads, &pool))) return st;
    for (size_t k = 0; k < count && !st; k++) {
        part_view pv;
        if ((st = part_view_init(&parts[k], k, cam, &c, &pv))) break;
        c.pv = &pv;
        crisp_pool_parallel_for(pool, tiles, 1, render_tiles, &c);
    }
    crisp_pool_destroy(pool);
    return st;
}
