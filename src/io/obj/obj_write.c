/* crisp_write_obj: a crisp_model as Wavefront OBJ free-form geometry (OBJ 3.0 specification).
 * Every face becomes `cstype [rat] bspline` + `deg` + `surf` over its whole knot domain with
 * `parm u/v`, and every trim loop a `trim` (outer) or `hole` statement whose pieces are curv2
 * elements used over their whole domain. Numbers are written with %.17g, so they read back to
 * the same doubles; the Euclidean coordinates of rational control points (OBJ stores x, not w x)
 * are written with 21 digits, which crisp's reader turns back into the same homogeneous doubles
 * (see euclidean()). Face colours, when the model has any, go to name.mtl beside the file
 * (one material per distinct colour, Kd and d), referenced by mtllib/usemtl. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "crisp/io.h"

/* The Euclidean coordinate y / w of a rational control point, as text. The reader forms w * x in
 * long double and rounds once, so 21 significant digits of y / w (LDBL_DECIMAL_DIG on x86-64)
 * give back y exactly; a double x with x * w == y does not always exist. */
static void euclidean(FILE *f, double y, double w)
{
    fprintf(f, " %.21Lg", (long double)y / (long double)w);
}

typedef struct writer {
    FILE *f;
    int items; /* on the current line, for wrapping */
} writer;

/* Long statements are wrapped with `\` continuations every 8 values. */
static void item(writer *w, const char *fmt, double x)
{
    if (w->items && w->items % 8 == 0) fputs(" \\\n   ", w->f);
    fputc(' ', w->f);
    fprintf(w->f, fmt, x);
    w->items++;
}

static void begin(writer *w, const char *keyword)
{
    fputs(keyword, w->f);
    w->items = 0;
}

static void end_line(writer *w)
{
    fputc('\n', w->f);
}

static void write_knots(writer *w, const char *dir, const double *k, int n)
{
    begin(w, "parm ");
    fputs(dir, w->f);
    for (int i = 0; i < n; i++)
        item(w, "%.17g", k[i]);
    end_line(w);
}

static void write_curves(writer *w, const crisp_face *face, long *vp_base, long *curv2_base)
{
    for (int l = 0; l < face->loop_count; l++)
        for (int c = 0; c < face->loops[l].curve_count; c++) {
            const crisp_curve *cu = face->loops[l].curves[c];
            for (int i = 0; i < cu->count; i++) {
                const double *h = cu->cpw + 3 * (size_t)i;
                if (cu->rational) {
                    fputs("vp", w->f);
                    euclidean(w->f, h[0], h[2]);
                    euclidean(w->f, h[1], h[2]);
                    fprintf(w->f, " %.17g\n", h[2]);
                } else
                    fprintf(w->f, "vp %.17g %.17g\n", h[0], h[1]);
            }
            fprintf(w->f, "cstype %sbspline\ndeg %d\n", cu->rational ? "rat " : "", cu->degree);
            begin(w, "curv2");
            for (int i = 0; i < cu->count; i++)
                item(w, "%.0f", (double)(*vp_base + i + 1));
            end_line(w);
            write_knots(w, "u", cu->knots, cu->count + cu->degree + 1);
            fputs("end\n", w->f);
            *vp_base += cu->count;
            (*curv2_base)++;
        }
}

/* Face colours go to an .mtl file beside the OBJ, one material per distinct colour. */
typedef struct palette {
    int count;
    float (*rgba)[4];
} palette;

static int color_index(const palette *p, const float rgba[4])
{
    for (int i = 0; i < p->count; i++)
        if (memcmp(p->rgba[i], rgba, sizeof p->rgba[i]) == 0) return i;
    return -1;
}

static void write_face(writer *w, const crisp_face *face, int index, long *v_base, long *vp_base,
                       long *curv2_base, const palette *pal)
{
    const crisp_surface *s = face->surface;
    fprintf(w->f, "\n# face %d (source %d)\n", index + 1, face->source_id);
    long first_curv2 = *curv2_base;
    write_curves(w, face, vp_base, curv2_base);
    int n = s->count_u * s->count_v;
    for (int i = 0; i < n; i++) {
        const double *h = s->cpw + 4 * (size_t)i;
        if (s->rational) {
            fputc('v', w->f);
            for (int c = 0; c < 3; c++)
                euclidean(w->f, h[c], h[3]);
            fprintf(w->f, " %.17g\n", h[3]);
        } else
            fprintf(w->f, "v %.17g %.17g %.17g\n", h[0], h[1], h[2]);
    }
    double dom[4];
    crisp_surface_domain(s, dom);
    if (pal->count) {
        if (face->has_color)
            fprintf(w->f, "usemtl crisp_color_%d\n", color_index(pal, face->color) + 1);
        else
            fputs("usemtl crisp_none\n", w->f);
    }
    fprintf(w->f, "cstype %sbspline\ndeg %d %d\n", s->rational ? "rat " : "", s->degree_u,
            s->degree_v);
    begin(w, "surf");
    for (int i = 0; i < 4; i++)
        item(w, "%.17g", dom[i]);
    for (int i = 0; i < n; i++)
        item(w, "%.0f", (double)(*v_base + i + 1));
    end_line(w);
    write_knots(w, "u", s->knots_u, s->count_u + s->degree_u + 1);
    write_knots(w, "v", s->knots_v, s->count_v + s->degree_v + 1);
    long c = first_curv2;
    for (int l = 0; l < face->loop_count; l++) {
        begin(w, face->loops[l].is_outer ? "trim" : "hole");
        for (int k = 0; k < face->loops[l].curve_count; k++) {
            double t0, t1;
            crisp_curve_domain(face->loops[l].curves[k], &t0, &t1);
            item(w, "%.17g", t0);
            item(w, "%.17g", t1);
            item(w, "%.0f", (double)(++c));
        }
        end_line(w);
    }
    fputs("end\n", w->f);
    *v_base += n;
}

/* name.obj -> name.mtl (the whole path, and the file name alone for the mtllib statement). */
static void mtl_names(const char *path, char *full, size_t full_cap, const char **base)
{
    size_t n = strlen(path);
    if (n >= 4 && strcmp(path + n - 4, ".obj") == 0) n -= 4;
    snprintf(full, full_cap, "%.*s.mtl", (int)n, path);
    const char *slash = strrchr(full, '/');
    *base = slash ? slash + 1 : full;
}

static crisp_status write_mtl(const char *path, const palette *pal)
{
    FILE *f = fopen(path, "w");
    if (!f) return crisp_error(CRISP_ERR_IO, "%s: cannot create: %s", path, strerror(errno));
    fputs("# crisp face colours\nnewmtl crisp_none\n", f);
    for (int i = 0; i < pal->count; i++)
        fprintf(f, "newmtl crisp_color_%d\nKd %.9g %.9g %.9g\nd %.9g\n", i + 1, pal->rgba[i][0],
                pal->rgba[i][1], pal->rgba[i][2], pal->rgba[i][3]);
    int err = ferror(f);
    if (fclose(f) != 0 || err)
        return crisp_error(CRISP_ERR_IO, "%s: write error: %s", path, strerror(errno));
    return CRISP_OK;
}

crisp_status crisp_write_obj(const crisp_model *m, const char *path)
{
    if (!m || !path) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_write_obj: NULL argument");
    palette pal = {0, NULL};
    for (int i = 0; i < m->face_count; i++) {
        if (!m->faces[i].has_color || color_index(&pal, m->faces[i].color) >= 0) continue;
        float(*grown)[4] = crisp_realloc_array(pal.rgba, (size_t)pal.count + 1, sizeof *grown);
        if (!grown) {
            crisp_free(pal.rgba);
            return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", path);
        }
        pal.rgba = grown;
        memcpy(pal.rgba[pal.count++], m->faces[i].color, sizeof pal.rgba[0]);
    }
    FILE *f = fopen(path, "w");
    if (!f) {
        crisp_free(pal.rgba);
        return crisp_error(CRISP_ERR_IO, "%s: cannot create: %s", path, strerror(errno));
    }
    char mtl[4096];
    const char *mtl_base = NULL;
    if (pal.count) {
        mtl_names(path, mtl, sizeof mtl, &mtl_base);
        crisp_status st = write_mtl(mtl, &pal);
        if (st != CRISP_OK) {
            fclose(f);
            crisp_free(pal.rgba);
            return st;
        }
    }
    writer w = {f, 0};
    fprintf(f, "# crisp OBJ free-form export: %d faces (from %s)\n", m->face_count,
            m->format[0] ? m->format : "memory");
    if (pal.count) fprintf(f, "mtllib %s\n", mtl_base);
    long v_base = 0, vp_base = 0, curv2_base = 0;
    for (int i = 0; i < m->face_count; i++)
        write_face(&w, &m->faces[i], i, &v_base, &vp_base, &curv2_base, &pal);
    crisp_free(pal.rgba);
    int err = ferror(f);
    if (fclose(f) != 0 || err)
        return crisp_error(CRISP_ERR_IO, "%s: write error: %s", path, strerror(errno));
    return CRISP_OK;
}
