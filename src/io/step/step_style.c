/* STEP units and colours: the length and plane-angle units of the geometric context (ISO 10303-41
 * si_unit with prefixes, conversion_based_unit), and face colours from presentation styles
 * (ISO 10303-46: styled_item -> presentation_style_assignment -> surface_style_usage ->
 * surface_side_style -> surface_style_fill_area -> fill_area_style -> fill_area_style_colour ->
 * colour_rgb or draughting_pre_defined_colour), applied to a face or to every face of a styled
 * shell or solid. (Styles on assembly occurrences are applied to the placed copies in
 * step_assembly.c, through crisp__step_style_colour.)
 */
#include "step_internal.h"

#include <math.h>
#include <string.h>

/* Millimetres (length) or radians (angle) per unit of the unit entity e; 0 when unknown. */
static double unit_factor(step_reader *r, const step_entity *e, int length, int depth)
{
    if (depth > 6) return 0;
    const step_part *p;
    if ((p = crisp__step_part(r, e, "SI_UNIT"))) {
        /* SI_UNIT(prefix, name) in a complex instance; SI_UNIT(*, prefix, name) when simple. */
        int off = crisp__step_param(r, p, 2) ? 1 : 0;
        const step_value *pre = crisp__step_param(r, p, off),
                         *name = crisp__step_param(r, p, off + 1);
        static const struct {
            const char *name;
            double f;
        } prefixes[] = {{"EXA", 1e18},  {"PETA", 1e15},  {"TERA", 1e12},   {"GIGA", 1e9},
                        {"MEGA", 1e6},  {"KILO", 1e3},   {"HECTO", 1e2},   {"DECA", 1e1},
                        {"DECI", 1e-1}, {"CENTI", 1e-2}, {"MILLI", 1e-3},  {"MICRO", 1e-6},
                        {"NANO", 1e-9}, {"PICO", 1e-12}, {"FEMTO", 1e-15}, {"ATTO", 1e-18}};
        double f = 1;
        if (pre && pre->kind == STEP_ENUM)
            for (size_t k = 0; k < sizeof prefixes / sizeof *prefixes; k++)
                if (crisp__step_text_is(r, pre, prefixes[k].name)) f = prefixes[k].f;
        if (!name || name->kind != STEP_ENUM) return 0;
        if (length && crisp__step_text_is(r, name, "METRE")) return f * 1000;
        if (!length && crisp__step_text_is(r, name, "RADIAN")) return f;
        return 0;
    }
    if ((p = crisp__step_part(r, e, "CONVERSION_BASED_UNIT"))) {
        const step_value *v = crisp__step_param(r, p, 1);
        const step_entity *me, *ue;
        if (!v || v->kind != STEP_REF || !(me = crisp__step_find(r->f, v->num))) return 0;
        const step_part *mp = crisp__step_part(r, me, NULL);
        double x;
        const step_value *mv = crisp__step_param(r, mp, 0), *mu = crisp__step_param(r, mp, 1);
        if (!mv || !crisp__step_value_real(r, mv, &x) || !mu || mu->kind != STEP_REF) return 0;
        if (!(ue = crisp__step_find(r->f, mu->num))) return 0;
        double f = unit_factor(r, ue, length, depth + 1);
        return isfinite(x * f) ? x * f : 0;
    }
    return 0;
}

void crisp__step_units(step_reader *r)
{
    const step_file *f = r->f;
    r->angle_unit = 1;
    r->model->unit_to_mm = 1;
    int have_len = 0, have_ang = 0;
    /* The units assigned to a geometric context come first; any other unit entity is a fallback. */
    for (size_t i = 0; i < f->entity_count && !(have_len && have_ang); i++) {
        const step_entity *e = &f->entities[i];
        const step_part *p = crisp__step_part(r, e, "GLOBAL_UNIT_ASSIGNED_CONTEXT");
        if (!p) continue;
        const step_value *units = crisp__step_param(r, p, 0);
        if (!units || units->kind != STEP_LIST) {
            units = crisp__step_param(r, p, 2); /* simple instance: (id, type, units) */
            if (!units || units->kind != STEP_LIST) continue;
        }
        for (uint32_t k = 0; k < units->len; k++) {
            const step_value *v = crisp__step_elem(r, units, k);
            const step_entity *u;
            if (v->kind != STEP_REF || !(u = crisp__step_find(f, v->num))) continue;
            double x;
            if (!have_len && crisp__step_is(r, u, "LENGTH_UNIT") &&
                (x = unit_factor(r, u, 1, 0)) > 0) {
                r->model->unit_to_mm = x;
                have_len = 1;
            }
            if (!have_ang && crisp__step_is(r, u, "PLANE_ANGLE_UNIT") &&
                (x = unit_factor(r, u, 0, 0)) > 0) {
                r->angle_unit = x;
                have_ang = 1;
            }
        }
    }
    for (size_t i = 0; i < f->entity_count && !have_len; i++) {
        const step_entity *e = &f->entities[i];
        double x;
        if (crisp__step_is(r, e, "LENGTH_UNIT") && (x = unit_factor(r, e, 1, 0)) > 0) {
            r->model->unit_to_mm = x;
            have_len = 1;
        }
    }
}

/* Millimetres per length unit of one representation context (its GLOBAL_UNIT_ASSIGNED_CONTEXT);
 * 0 when it names none (used by step_assembly.c for parts in different units). */
double crisp__step_context_length_unit(step_reader *r, const step_entity *ctx)
{
    const step_part *p = crisp__step_part(r, ctx, "GLOBAL_UNIT_ASSIGNED_CONTEXT");
    if (!p) return 0;
    const step_value *units = crisp__step_param(r, p, 0);
    if (!units || units->kind != STEP_LIST) units = crisp__step_param(r, p, 2);
    if (!units || units->kind != STEP_LIST) return 0;
    for (uint32_t k = 0; k < units->len; k++) {
        const step_value *v = crisp__step_elem(r, units, k);
        const step_entity *u;
        double x;
        if (v->kind == STEP_REF && (u = crisp__step_find(r->f, v->num)) &&
            crisp__step_is(r, u, "LENGTH_UNIT") && (x = unit_factor(r, u, 1, 0)) > 0)
            return x;
    }
    return 0;
}

/* The fill colour reachable from a style entity (depth-first, curve styles ignored). */
static int find_colour(step_reader *r, const step_entity *e, int depth, float rgb[3])
{
    if (depth > 10) return 0;
    const step_part *p;
    if ((p = crisp__step_part(r, e, "COLOUR_RGB"))) {
        double c[3];
        for (int k = 0; k < 3; k++) {
            const step_value *v = crisp__step_param(r, p, 1 + k);
            if (!v || !crisp__step_value_real(r, v, &c[k])) return 0;
            rgb[k] = (float)(c[k] < 0 ? 0 : c[k] > 1 ? 1 : c[k]);
        }
        return 1;
    }
    if ((p = crisp__step_part(r, e, "DRAUGHTING_PRE_DEFINED_COLOUR"))) {
        static const struct {
            const char *name;
            float rgb[3];
        } named[] = {{"black", {0, 0, 0}}, {"red", {1, 0, 0}},    {"green", {0, 1, 0}},
                     {"blue", {0, 0, 1}},  {"yellow", {1, 1, 0}}, {"magenta", {1, 0, 1}},
                     {"cyan", {0, 1, 1}},  {"white", {1, 1, 1}}};
        const step_value *v = crisp__step_param(r, p, 0);
        if (!v || v->kind != STEP_STRING) return 0;
        for (size_t k = 0; k < sizeof named / sizeof *named; k++)
            if (crisp__step_text_is(r, v, named[k].name)) {
                memcpy(rgb, named[k].rgb, sizeof named[k].rgb);
                return 1;
            }
        return 0;
    }
    if (crisp__step_is(r, e, "CURVE_STYLE") || crisp__step_is(r, e, "POINT_STYLE") ||
        crisp__step_is(r, e, "TEXT_STYLE"))
        return 0;
    /* Follow every reference among the parameters, lists included. */
    for (uint32_t pi = 0; pi < e->part_count; pi++) {
        const step_part *pp = &r->f->parts[e->first_part + pi];
        const step_value *list = &r->f->values[pp->params];
        for (uint32_t i = 0; i < list->len; i++) {
            const step_value *v = &r->f->values[list->first + i];
            uint32_t n = v->kind == STEP_LIST ? v->len : 1;
            for (uint32_t j = 0; j < n && j < 64; j++) {
                const step_value *x = v->kind == STEP_LIST ? &r->f->values[v->first + j] : v;
                const step_entity *t;
                if (x->kind == STEP_REF && (t = crisp__step_find(r->f, x->num)) &&
                    find_colour(r, t, depth + 1, rgb))
                    return 1;
            }
        }
    }
    return 0;
}

int crisp__step_style_colour(step_reader *r, const step_value *styles, float rgb[3])
{
    uint32_t n = styles && styles->kind == STEP_LIST ? styles->len : 0;
    for (uint32_t j = 0; j < n; j++) {
        const step_value *x = &r->f->values[styles->first + j];
        const step_entity *t;
        if (x->kind == STEP_REF && (t = crisp__step_find(r->f, x->num)) &&
            find_colour(r, t, 0, rgb))
            return 1;
    }
    return 0;
}

void crisp__step_colors(step_reader *r, const int *face_ids, const int *owner_ids, int face_count)
{
    const step_file *f = r->f;
    crisp_model *m = r->model;
    /* Two passes: styles on shells and solids first, then styles on faces override them. */
    for (int pass = 0; pass < 2; pass++) {
        for (size_t i = 0; i < f->entity_count; i++) {
            const step_entity *e = &f->entities[i];
            const step_part *p = crisp__step_part(r, e, "STYLED_ITEM");
            if (!p) p = crisp__step_part(r, e, "OVER_RIDING_STYLED_ITEM");
            if (!p) continue;
            const step_value *styles = crisp__step_param(r, p, 1),
                             *item = crisp__step_param(r, p, 2);
            if (!styles || !item || item->kind != STEP_REF) continue;
            int target = item->num >= 1 && item->num <= 2147483647.0 ? (int)item->num : -1;
            int on_face = 0;
            for (int k = 0; k < face_count && !on_face; k++)
                on_face = face_ids[k] == target;
            if (on_face != pass) continue;
            int hit = 0;
            for (int k = 0; k < face_count && !hit; k++)
                hit = pass ? face_ids[k] == target
                           : (owner_ids[2 * k] == target || owner_ids[2 * k + 1] == target);
            if (!hit) continue;
            float rgb[3];
            const step_entity *t;
            int found = 0;
            uint32_t n = styles->kind == STEP_LIST ? styles->len : 0;
            for (uint32_t j = 0; j < n && !found; j++) {
                const step_value *x = &f->values[styles->first + j];
                if (x->kind == STEP_REF && (t = crisp__step_find(f, x->num)))
                    found = find_colour(r, t, 0, rgb);
            }
            if (!found) continue;
            for (int k = 0; k < face_count; k++) {
                int match = pass ? face_ids[k] == target
                                 : (owner_ids[2 * k] == target || owner_ids[2 * k + 1] == target);
                if (!match) continue;
                crisp_face *face = &m->faces[k];
                face->has_color = 1;
                face->color[0] = rgb[0], face->color[1] = rgb[1], face->color[2] = rgb[2],
                face->color[3] = 1;
            }
        }
    }
}
