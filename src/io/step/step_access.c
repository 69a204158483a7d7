/* Typed access to STEP entity parameters (ISO 10303-21 values, ISO 10303-42 points, directions,
 * vectors and placements), with error messages that name the file, the #entity, its line and what
 * was expected.
 */
#include "step_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

const char *crisp__step_type(const step_reader *r, const step_entity *e, char *buf, size_t cap)
{
    const step_part *p = &r->f->parts[e->first_part];
    size_t n = p->name_len < cap - 1 ? p->name_len : cap - 1;
    memcpy(buf, r->f->text + p->name_off, n);
    buf[n] = '\0';
    if (e->part_count > 1 && n + 4 < cap) strcat(buf, "...");
    return buf;
}

crisp_status crisp__step_fail(const step_reader *r, const step_entity *e, crisp_status st,
                              const char *fmt, ...)
{
    char msg[256], type[64];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (!e) return crisp_error(st, "%s: %s", r->f->name, msg);
    return crisp_error(st, "%s: #%d (line %d) %s: %s", r->f->name, e->id, e->line,
                       crisp__step_type(r, e, type, sizeof type), msg);
}

static int name_is(const step_reader *r, const step_part *p, const char *type)
{
    size_t n = strlen(type);
    return p->name_len == n && memcmp(r->f->text + p->name_off, type, n) == 0;
}

const step_part *crisp__step_part(const step_reader *r, const step_entity *e, const char *type)
{
    if (!type) return &r->f->parts[e->first_part];
    for (uint32_t i = 0; i < e->part_count; i++) {
        const step_part *p = &r->f->parts[e->first_part + i];
        if (name_is(r, p, type)) return p;
    }
    return NULL;
}

int crisp__step_is(const step_reader *r, const step_entity *e, const char *type)
{
    return crisp__step_part(r, e, type) != NULL;
}

const step_value *crisp__step_param(const step_reader *r, const step_part *p, int i)
{
    const step_value *list = &r->f->values[p->params];
    if (i < 0 || (uint32_t)i >= list->len) return NULL;
    return &r->f->values[list->first + (uint32_t)i];
}

const step_value *crisp__step_elem(const step_reader *r, const step_value *v, uint32_t i)
{
    if (v->kind != STEP_LIST || i >= v->len) return NULL;
    return &r->f->values[v->first + i];
}

int crisp__step_text_is(const step_reader *r, const step_value *v, const char *s)
{
    size_t n = strlen(s);
    return v->len == n && memcmp(r->f->text + v->off, s, n) == 0;
}

int crisp__step_value_real(const step_reader *r, const step_value *v, double *dest)
{
    /* Typed measures (LENGTH_MEASURE(1.0), PARAMETER_VALUE(0.5)) wrap a number. */
    for (int k = 0; k < 4 && v->kind == STEP_TYPED; k++)
        v = &r->f->values[v->first];
    if (v->kind != STEP_REAL && v->kind != STEP_INT) return 0;
    if (!isfinite(v->num)) return 0;
    *dest = v->num;
    return 1;
}

static crisp_status need(const step_reader *r, const step_entity *e, const step_part *p, int i,
                         const step_value **v)
{
    *v = crisp__step_param(r, p, i);
    if (!*v) return crisp__step_fail(r, e, CRISP_ERR_PARSE, "parameter %d missing", i + 1);
    return CRISP_OK;
}

crisp_status crisp__step_get_real(const step_reader *r, const step_entity *e, const step_part *p,
                                  int i, double *dest)
{
    const step_value *v;
    crisp_status st = need(r, e, p, i, &v);
    if (st) return st;
    if (!crisp__step_value_real(r, v, dest))
        return crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                "parameter %d: expected a finite real number", i + 1);
    return CRISP_OK;
}

crisp_status crisp__step_get_int(const step_reader *r, const step_entity *e, const step_part *p,
                                 int i, int lo, int hi, int *dest)
{
    const step_value *v;
    crisp_status st = need(r, e, p, i, &v);
    if (st) return st;
    if (v->kind != STEP_INT || v->num < lo || v->num > hi)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                "parameter %d: expected an integer in %d..%d", i + 1, lo, hi);
    *dest = (int)v->num;
    return CRISP_OK;
}

crisp_status crisp__step_get_bool(const step_reader *r, const step_entity *e, const step_part *p,
                                  int i, int *dest)
{
    const step_value *v;
    crisp_status st = need(r, e, p, i, &v);
    if (st) return st;
    if (v->kind == STEP_ENUM &&
        (crisp__step_text_is(r, v, "T") || crisp__step_text_is(r, v, "F"))) {
        *dest = crisp__step_text_is(r, v, "T");
        return CRISP_OK;
    }
    return crisp__step_fail(r, e, CRISP_ERR_PARSE, "parameter %d: expected .T. or .F.", i + 1);
}

crisp_status crisp__step_get_list(const step_reader *r, const step_entity *e, const step_part *p,
                                  int i, const step_value **dest)
{
    const step_value *v;
    crisp_status st = need(r, e, p, i, &v);
    if (st) return st;
    if (v->kind != STEP_LIST)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE, "parameter %d: expected a list", i + 1);
    *dest = v;
    return CRISP_OK;
}

crisp_status crisp__step_deref(const step_reader *r, const step_entity *e, const step_value *v,
                               const step_entity **dest)
{
    if (!v || v->kind != STEP_REF)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE, "expected an entity reference #n");
    const step_entity *t = crisp__step_find(r->f, v->num);
    if (!t && v->num > 2147483647.0)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE, "reference #%.6g out of range", v->num);
    if (!t)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE, "reference to #%.0f, which is not defined",
                                v->num);
    *dest = t;
    return CRISP_OK;
}

crisp_status crisp__step_get_ref(const step_reader *r, const step_entity *e, const step_part *p,
                                 int i, const step_entity **dest)
{
    const step_value *v;
    crisp_status st = need(r, e, p, i, &v);
    if (st) return st;
    if (v->kind != STEP_REF)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE,
                                "parameter %d: expected an entity reference #n", i + 1);
    return crisp__step_deref(r, e, v, dest);
}

/* The coordinates list of a CARTESIAN_POINT or the ratios of a DIRECTION (parameter 2). */
static crisp_status coords(step_reader *r, const step_entity *e, const char *type, double x[3],
                           int *dim)
{
    const step_part *p = crisp__step_part(r, e, type);
    if (!p) return crisp__step_fail(r, e, CRISP_ERR_PARSE, "expected a %s", type);
    const step_value *list;
    crisp_status st = crisp__step_get_list(r, e, p, 1, &list);
    if (st) return st;
    if (list->len < 1 || list->len > 3)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE, "expected 1 to 3 coordinates, found %u",
                                list->len);
    x[0] = x[1] = x[2] = 0;
    for (uint32_t k = 0; k < list->len; k++)
        if (!crisp__step_value_real(r, crisp__step_elem(r, list, k), &x[k]))
            return crisp__step_fail(r, e, CRISP_ERR_PARSE, "coordinate %u: expected a finite real",
                                    k + 1);
    if (dim) *dim = (int)list->len;
    return CRISP_OK;
}

crisp_status crisp__step_point(step_reader *r, const step_entity *e, double p[3], int *dim)
{
    return coords(r, e, "CARTESIAN_POINT", p, dim);
}

crisp_status crisp__step_direction(step_reader *r, const step_entity *e, double d[3])
{
    crisp_status st = coords(r, e, "DIRECTION", d, NULL);
    if (st) return st;
    double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(n > 1e-300) || !isfinite(n))
        return crisp__step_fail(r, e, CRISP_ERR_NUMERIC, "expected a non-zero direction");
    for (int k = 0; k < 3; k++)
        d[k] /= n;
    return CRISP_OK;
}

crisp_status crisp__step_vector(step_reader *r, const step_entity *e, double d[3])
{
    if (crisp__step_is(r, e, "DIRECTION")) return crisp__step_direction(r, e, d);
    const step_part *p = crisp__step_part(r, e, "VECTOR");
    if (!p) return crisp__step_fail(r, e, CRISP_ERR_PARSE, "expected a VECTOR");
    const step_entity *de;
    double mag;
    crisp_status st = crisp__step_get_ref(r, e, p, 1, &de);
    if (!st) st = crisp__step_get_real(r, e, p, 2, &mag);
    if (!st) st = crisp__step_direction(r, de, d);
    if (st) return st;
    for (int k = 0; k < 3; k++)
        d[k] *= mag;
    return CRISP_OK;
}

static void cross(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* A placement from origin, axis z (may be NULL: +Z) and reference x (may be NULL), following the
 * build_axes rule of ISO 10303-42 (x is the reference projected orthogonal to z). */
static crisp_status make_frame(step_reader *r, const step_entity *e, const double o[3],
                               const double *z, const double *x, crisp_placement *dest)
{
    double zz[3] = {0, 0, 1}, xx[3];
    if (z) memcpy(zz, z, sizeof zz);
    if (x) {
        memcpy(xx, x, sizeof xx);
    } else {
        /* first_proj_axis: (1,0,0) unless z is along x, then (0,0,1)... pick a stable one. */
        double ax[3] = {1, 0, 0};
        if (fabs(zz[0]) > 0.9) ax[0] = 0, ax[2] = 1;
        memcpy(xx, ax, sizeof xx);
    }
    double dz = xx[0] * zz[0] + xx[1] * zz[1] + xx[2] * zz[2];
    for (int k = 0; k < 3; k++)
        xx[k] -= dz * zz[k];
    double n = sqrt(xx[0] * xx[0] + xx[1] * xx[1] + xx[2] * xx[2]);
    if (!(n > 1e-12))
        return crisp__step_fail(r, e, CRISP_ERR_NUMERIC,
                                "reference direction parallel to the axis");
    for (int k = 0; k < 3; k++)
        xx[k] /= n;
    memcpy(dest->origin, o, sizeof dest->origin);
    memcpy(dest->z, zz, sizeof zz);
    memcpy(dest->x, xx, sizeof xx);
    cross(zz, xx, dest->y);
    return CRISP_OK;
}

crisp_status crisp__step_placement(step_reader *r, const step_entity *e, crisp_placement *dest)
{
    const step_part *p;
    const step_value *v;
    const step_entity *pe, *ze = NULL, *xe = NULL;
    double o[3], z[3], x[3];
    crisp_status st;
    if ((p = crisp__step_part(r, e, "AXIS2_PLACEMENT_3D"))) {
        if ((st = crisp__step_get_ref(r, e, p, 1, &pe)) || (st = crisp__step_point(r, pe, o, NULL)))
            return st;
        if ((v = crisp__step_param(r, p, 2)) && v->kind == STEP_REF &&
            ((st = crisp__step_deref(r, e, v, &ze)) || (st = crisp__step_direction(r, ze, z))))
            return st;
        if ((v = crisp__step_param(r, p, 3)) && v->kind == STEP_REF &&
            ((st = crisp__step_deref(r, e, v, &xe)) || (st = crisp__step_direction(r, xe, x))))
            return st;
        return make_frame(r, e, o, ze ? z : NULL, xe ? x : NULL, dest);
    }
    if ((p = crisp__step_part(r, e, "AXIS2_PLACEMENT_2D"))) {
        if ((st = crisp__step_get_ref(r, e, p, 1, &pe)) || (st = crisp__step_point(r, pe, o, NULL)))
            return st;
        o[2] = 0;
        if ((v = crisp__step_param(r, p, 2)) && v->kind == STEP_REF &&
            ((st = crisp__step_deref(r, e, v, &xe)) || (st = crisp__step_direction(r, xe, x))))
            return st;
        if (xe) x[2] = 0;
        return make_frame(r, e, o, NULL, xe ? x : NULL, dest);
    }
    if ((p = crisp__step_part(r, e, "AXIS1_PLACEMENT"))) {
        if ((st = crisp__step_get_ref(r, e, p, 1, &pe)) || (st = crisp__step_point(r, pe, o, NULL)))
            return st;
        if ((v = crisp__step_param(r, p, 2)) && v->kind == STEP_REF &&
            ((st = crisp__step_deref(r, e, v, &ze)) || (st = crisp__step_direction(r, ze, z))))
            return st;
        return make_frame(r, e, o, ze ? z : NULL, NULL, dest);
    }
    return crisp__step_fail(r, e, CRISP_ERR_PARSE,
                            "expected an AXIS2_PLACEMENT_3D, AXIS2_PLACEMENT_2D "
                            "or AXIS1_PLACEMENT");
}
