/* crisp_write_obj: a crisp_model as Wavefront OBJ free-form geometry (OBJ 3.0, NOTES.md B.3).
 * Every face becomes `cstype [rat] bspline` + `deg` + `surf` over its whole knot domain with
 * `parm u/v`, and every trim loop a `trim` (outer) or `hole` statement whose pieces are curv2
 * elements used over their whole domain. Numbers are written with %.17g, so they read back to
 * the same doubles; the Euclidean coordinates of rational control points (OBJ stores x, not w x)
 * are written with 21 digits, which crisp's reader turns back into the same homogeneous doubles
 * (see euclidean()). */
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

static void end_line(writer *w) { fputc('\n', w->f); }

static void write_knots(writer *w, const char *dir, const double *k, int n)
{
    begin(w, "parm ");
    fputs(dir, w->f);
    for (int i = 0; i < n; i++) item(w, "%.17g", k[i]);
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
            for (int i = 0; i < cu->count; i++) item(w, "%.0f", (double)(*vp_base + i + 1));
            end_line(w);
            write_knots(w, "u", cu->knots, cu->count + cu->degree + 1);
            fputs("end\n", w->f);
            *vp_base += cu->count;
            (*curv2_base)++;
        }
}

static void write_face(writer *w, const crisp_face *face, int index, long *v_base, long *vp_base,
                       long *curv2_base)
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
            for (int c = 0; c < 3; c++) euclidean(w->f, h[c], h[3]);
            fprintf(w->f, " %.17g\n", h[3]);
        } else
            fprintf(w->f, "v %.17g %.17g %.17g\n", h[0], h[1], h[2]);
    }
    double dom[4];
    crisp_surface_domain(s, dom);
    fprintf(w->f, "cstype %sbspline\ndeg %d %d\n", s->rational ? "rat " : "", s->degree_u,
            s->degree_v);
    begin(w, "surf");
    for (int i = 0; i < 4; i++) item(w, "%.17g", dom[i]);
    for (int i = 0; i < n; i++) item(w, "%.0f", (double)(*v_base + i + 1));
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

crisp_status crisp_write_obj(const crisp_model *m, const char *path)
{
    if (!m || !path) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_write_obj: NULL argument");
    FILE *f = fopen(path, "w");
    if (!f) return crisp_error(CRISP_ERR_IO, "%s: cannot create: %s", path, strerror(errno));
    writer w = {f, 0};
    fprintf(f, "# crisp OBJ free-form export: %d faces (from %s)\n", m->face_count,
            m->format[0] ? m->format : "memory");
    long v_base = 0, vp_base = 0, curv2_base = 0;
    for (int i = 0; i < m->face_count; i++)
        write_face(&w, &m->faces[i], i, &v_base, &vp_base, &curv2_base);
    int err = ferror(f);
    if (fclose(f) != 0 || err)
        return crisp_error(CRISP_ERR_IO, "%s: write error: %s", path, strerror(errno));
    return CRISP_OK;
}
