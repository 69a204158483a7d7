/* STEP reader entry points: parse (ISO 10303-21), then collect the faces of every shell
 * (MANIFOLD_SOLID_BREP, BREP_WITH_VOIDS, SHELL_BASED_SURFACE_MODEL -> CLOSED_SHELL / OPEN_SHELL ->
 * ADVANCED_FACE, ORIENTED_FACE) and faces outside any shell, convert each (step_face.c), read units
 * and colours. A face that cannot be made valid is dropped with a skip note naming it and why.
 */
#include "step_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

typedef enum face_kind {
    FACE_TOPOLOGY, /* ADVANCED_FACE, FACE_SURFACE: bounded by edge loops */
    FACE_BOUNDED,  /* CURVE_BOUNDED_SURFACE: bounded by composite curves */
    FACE_BARE      /* a bounded surface alone in a geometric set */
} face_kind;

typedef struct face_ref {
    int id;       /* ADVANCED_FACE, CURVE_BOUNDED_SURFACE, ... */
    int flip;     /* through an ORIENTED_FACE with orientation .F. */
    int owner[2]; /* shell or set, solid (0 when none) */
    face_kind kind;
} face_ref;

typedef struct face_list {
    face_ref *refs;
    size_t count, cap;
    unsigned char *seen; /* by entity index */
} face_list;

static crisp_status add_ref_kind(step_reader *r, face_list *fl, const step_entity *fe, int flip,
                                 int shell, int solid, face_kind kind)
{
    size_t idx = (size_t)(fe - r->f->entities);
    if (fl->seen[idx]) return CRISP_OK;
    fl->seen[idx] = 1;
    if (fl->count == fl->cap &&
        crisp_grow((void **)&fl->refs, &fl->cap, fl->count + 1, sizeof *fl->refs))
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", r->f->name);
    fl->refs[fl->count++] = (face_ref){fe->id, flip, {shell, solid}, kind};
    return CRISP_OK;
}

static crisp_status add_ref(step_reader *r, face_list *fl, const step_entity *fe, int flip,
                            int shell, int solid)
{
    return add_ref_kind(r, fl, fe, flip, shell, solid, FACE_TOPOLOGY);
}

/* Note a part of the structure (shell, solid, set) that could not be read, and go on. */
static crisp_status note_unreadable(step_reader *r, crisp_status st, const char *what, int id)
{
    if (st == CRISP_OK || st == CRISP_ERR_NO_MEMORY) return st;
    const char *msg = crisp_error_message();
    size_t nl = strlen(r->f->name);
    if (strncmp(msg, r->f->name, nl) == 0 && msg[nl] == ':') msg += nl + 2;
    crisp_model_note_skipf(r->model, "STEP %s #%d unreadable: %s", what, id, msg);
    crisp_error_clear();
    return CRISP_OK;
}

static const char *const bare_surfaces[] = {"B_SPLINE_SURFACE_WITH_KNOTS",
                                            "B_SPLINE_SURFACE",
                                            "QUASI_UNIFORM_SURFACE",
                                            "UNIFORM_SURFACE",
                                            "BEZIER_SURFACE",
                                            "RECTANGULAR_TRIMMED_SURFACE",
                                            "PLANE",
                                            "CYLINDRICAL_SURFACE",
                                            "CONICAL_SURFACE",
                                            "SPHERICAL_SURFACE",
                                            "TOROIDAL_SURFACE",
                                            "DEGENERATE_TOROIDAL_SURFACE",
                                            "SURFACE_OF_REVOLUTION",
                                            "SURFACE_OF_LINEAR_EXTRUSION"};

static int is_surface(step_reader *r, const step_entity *e)
{
    for (size_t k = 0; k < sizeof bare_surfaces / sizeof *bare_surfaces; k++)
        if (crisp__step_is(r, e, bare_surfaces[k])) return 1;
    return 0;
}

/* The surfaces among the elements of a GEOMETRIC_SET (curves and points are wireframe). */
static crisp_status set_faces(step_reader *r, face_list *fl, const step_entity *e,
                              const step_part *p, int *wire)
{
    const step_value *items;
    crisp_status st = crisp__step_get_list(r, e, p, 1, &items);
    if (st) return st;
    for (uint32_t k = 0; k < items->len; k++) {
        const step_entity *it;
        if ((st = crisp__step_deref(r, e, crisp__step_elem(r, items, k), &it))) return st;
        if (crisp__step_is(r, it, "CURVE_BOUNDED_SURFACE"))
            st = add_ref_kind(r, fl, it, 0, e->id, 0, FACE_BOUNDED);
        else if (is_surface(r, it))
            st = add_ref_kind(r, fl, it, 0, e->id, 0, FACE_BARE);
        else if (crisp__step_is(r, it, "ADVANCED_FACE") || crisp__step_is(r, it, "FACE_SURFACE"))
            st = add_ref(r, fl, it, 0, e->id, 0);
        else
            (*wire)++;
        if (st) return st;
    }
    return CRISP_OK;
}

static int is_face(step_reader *r, const step_entity *e)
{
    return crisp__step_is(r, e, "ADVANCED_FACE") || crisp__step_is(r, e, "FACE_SURFACE");
}

/* The faces of a CLOSED_SHELL / OPEN_SHELL (or ORIENTED_CLOSED_SHELL's shell). */
static crisp_status shell_faces_flip(step_reader *r, face_list *fl, const step_entity *sh,
                                     int solid, int depth, int shell_flip)
{
    const step_part *p = crisp__step_part(r, sh, "CLOSED_SHELL");
    if (!p) p = crisp__step_part(r, sh, "OPEN_SHELL");
    if (!p) {
        /* ORIENTED_CLOSED_SHELL (a void of a BREP_WITH_VOIDS): .F. turns every face round. */
        const step_part *op = crisp__step_part(r, sh, "ORIENTED_CLOSED_SHELL");
        const step_entity *inner;
        int o = 1;
        if (op && depth < 4 && !crisp__step_get_ref(r, sh, op, 2, &inner)) {
            if (crisp__step_get_bool(r, sh, op, 3, &o)) {
                crisp_error_clear();
                o = 1;
            }
            return shell_faces_flip(r, fl, inner, solid, depth + 1, shell_flip ^ !o);
        }
        crisp_model_note_skip(r->model, "STEP shell that is not a CLOSED_SHELL or OPEN_SHELL");
        return CRISP_OK;
    }
    const step_value *faces;
    crisp_status st = crisp__step_get_list(r, sh, p, 1, &faces);
    if (st) return st;
    for (uint32_t i = 0; i < faces->len; i++) {
        const step_entity *fe;
        if ((st = crisp__step_deref(r, sh, crisp__step_elem(r, faces, i), &fe))) return st;
        int flip = shell_flip;
        for (int k = 0; k < 4 && crisp__step_is(r, fe, "ORIENTED_FACE"); k++) {
            const step_part *op = crisp__step_part(r, fe, "ORIENTED_FACE");
            int o;
            if ((st = crisp__step_get_bool(r, fe, op, 3, &o)) ||
                (st = crisp__step_get_ref(r, fe, op, 2, &fe)))
                return st;
            flip ^= !o;
        }
        if (!is_face(r, fe)) {
            char type[64];
            crisp_model_note_skipf(r->model, "STEP shell member %s: not a face",
                                   crisp__step_type(r, fe, type, sizeof type));
            continue;
        }
        if ((st = add_ref(r, fl, fe, flip, sh->id, solid))) return st;
    }
    return CRISP_OK;
}

static crisp_status shell_faces(step_reader *r, face_list *fl, const step_entity *sh, int solid,
                                int depth)
{
    return shell_faces_flip(r, fl, sh, solid, depth, 0);
}

static crisp_status collect_faces(step_reader *r, face_list *fl, int *wire)
{
    const step_file *f = r->f;
    crisp_status st;
    fl->seen = crisp_calloc_array(f->entity_count + 1, 1);
    if (!fl->seen) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    /* Solids first, so their shells' faces know the solid; then remaining shells; then faces and
     * geometric sets. A solid, shell or set that cannot be read is noted and skipped. */
    for (size_t i = 0; i < f->entity_count; i++) {
        const step_entity *e = &f->entities[i], *sh;
        const step_part *p = crisp__step_part(r, e, "MANIFOLD_SOLID_BREP");
        if (!p) p = crisp__step_part(r, e, "BREP_WITH_VOIDS");
        if (p) {
            st = crisp__step_get_ref(r, e, p, 1, &sh);
            if (!st) st = shell_faces(r, fl, sh, e->id, 0);
            if ((st = note_unreadable(r, st, "solid", e->id))) return st;
            const step_value *voids =
                crisp__step_part(r, e, "BREP_WITH_VOIDS") ? crisp__step_param(r, p, 2) : NULL;
            for (uint32_t k = 0; voids && voids->kind == STEP_LIST && k < voids->len; k++) {
                st = crisp__step_deref(r, e, crisp__step_elem(r, voids, k), &sh);
                if (!st) st = shell_faces(r, fl, sh, e->id, 0);
                if ((st = note_unreadable(r, st, "void shell of", e->id))) return st;
            }
        }
        if ((p = crisp__step_part(r, e, "SHELL_BASED_SURFACE_MODEL"))) {
            const step_value *shells;
            st = crisp__step_get_list(r, e, p, 1, &shells);
            for (uint32_t k = 0; !st && k < shells->len; k++) {
                st = crisp__step_deref(r, e, crisp__step_elem(r, shells, k), &sh);
                if (!st) st = shell_faces(r, fl, sh, e->id, 0);
                if ((st = note_unreadable(r, st, "shell of surface model", e->id))) return st;
            }
            if ((st = note_unreadable(r, st, "surface model", e->id))) return st;
        }
    }
    for (size_t i = 0; i < f->entity_count; i++) {
        const step_entity *e = &f->entities[i];
        if (crisp__step_is(r, e, "CLOSED_SHELL") || crisp__step_is(r, e, "OPEN_SHELL"))
            if ((st = note_unreadable(r, shell_faces(r, fl, e, 0, 0), "shell", e->id))) return st;
    }
    for (size_t i = 0; i < f->entity_count; i++) {
        const step_entity *e = &f->entities[i];
        if (is_face(r, e) && (st = add_ref(r, fl, e, 0, 0, 0))) return st;
    }
    for (size_t i = 0; i < f->entity_count; i++) {
        const step_entity *e = &f->entities[i];
        const step_part *p = crisp__step_part(r, e, "GEOMETRIC_SET");
        if (p && (st = note_unreadable(r, set_faces(r, fl, e, p, wire), "geometric set", e->id)))
            return st;
    }
    for (size_t i = 0; i < f->entity_count; i++) {
        const step_entity *e = &f->entities[i];
        if (crisp__step_is(r, e, "CURVE_BOUNDED_SURFACE") &&
            (st = add_ref_kind(r, fl, e, 0, 0, 0, FACE_BOUNDED)))
            return st;
    }
    return CRISP_OK;
}

static crisp_status convert_face(step_reader *r, const face_ref *fr, const step_entity *fe,
                                 crisp_face *face)
{
    r->depth = 0;
    switch (fr->kind) {
    case FACE_BOUNDED:
        return crisp__step_bounded_face(r, fe, face);
    case FACE_BARE:
        return crisp__step_bare_face(r, fe, face);
    default:
        return crisp__step_face(r, fe, face);
    }
}

/* How many entities of the file have one of these types. */
static int count_types(step_reader *r, const char *const *types, size_t n)
{
    int c = 0;
    for (size_t i = 0; i < r->f->entity_count; i++)
        for (size_t k = 0; k < n; k++)
            if (crisp__step_is(r, &r->f->entities[i], types[k])) {
                c++;
                break;
            }
    return c;
}

static const char *const mesh_types[] = {
    "TRIANGULATED_FACE",        "COMPLEX_TRIANGULATED_FACE",
    "TRIANGULATED_SURFACE_SET", "COMPLEX_TRIANGULATED_SURFACE_SET",
    "TESSELLATED_SHELL",        "TESSELLATED_SOLID",
    "TESSELLATED_FACE",         "TESSELLATED_SURFACE_SET"};
static const char *const curve_types[] = {"LINE",
                                          "CIRCLE",
                                          "ELLIPSE",
                                          "POLYLINE",
                                          "TRIMMED_CURVE",
                                          "B_SPLINE_CURVE",
                                          "B_SPLINE_CURVE_WITH_KNOTS",
                                          "QUASI_UNIFORM_CURVE",
                                          "COMPOSITE_CURVE",
                                          "TESSELLATED_CURVE_SET"};

/* The error for a file in which nothing can be drawn, saying what it holds instead. */
static crisp_status nothing_drawable(step_reader *r, int wire)
{
    const char *name = r->f->name;
    int meshes = count_types(r, mesh_types, sizeof mesh_types / sizeof *mesh_types);
    if (meshes)
        return crisp_error(CRISP_ERR_UNSUPPORTED,
                           "%s: only tessellated geometry (%d triangulated or tessellated items, "
                           "no B-rep faces or "
                           "surfaces): crisp draws exact surfaces, not meshes",
                           name, meshes);
    int curves = count_types(r, curve_types, sizeof curve_types / sizeof *curve_types);
    if (curves || wire)
        return crisp_error(
            CRISP_ERR_UNSUPPORTED,
            "%s: only wireframe geometry (%d curves, no faces or surfaces): nothing to draw", name,
            curves + wire);
    static const char *const refs[] = {"DOCUMENT_FILE", "APPLIED_DOCUMENT_REFERENCE",
                                       "DOCUMENT_REPRESENTATION_TYPE",
                                       "NEXT_ASSEMBLY_USAGE_OCCURRENCE"};
    if (count_types(r, refs, sizeof refs / sizeof *refs))
        return crisp_error(CRISP_ERR_UNSUPPORTED,
                           "%s: no geometry in this file (an assembly structure or references to "
                           "other files only)",
                           name);
    return crisp_error(CRISP_ERR_UNSUPPORTED,
                       "%s: no geometry (no B-rep faces, surfaces, meshes or curves)", name);
}

/* Tolerance scale: the box of the 3D CARTESIAN_POINTs, leaving out the origins of LINEs and the
 * locations of placements: they need not lie near the shape (bug27453_165-174_piattello.stp has
 * lines through points 5e5 away from a part 200 across), and would make the tolerance far too
 * coarse. Every point counts when nothing else is left. */
static double model_diagonal(step_reader *r, unsigned char *skip)
{
    const step_file *f = r->f;
    static const char *const users[] = {"LINE", "AXIS2_PLACEMENT_3D", "AXIS2_PLACEMENT_2D",
                                        "AXIS1_PLACEMENT"};
    for (size_t i = 0; skip && i < f->entity_count; i++) {
        const step_entity *e = &f->entities[i], *pe;
        for (size_t k = 0; k < sizeof users / sizeof *users; k++) {
            const step_part *p = crisp__step_part(r, e, users[k]);
            if (p && crisp__step_get_ref(r, e, p, 1, &pe) == CRISP_OK) skip[pe - f->entities] = 1;
        }
    }
    double d = 0;
    for (int pass = skip ? 0 : 1; pass < 2 && !(d > 0); pass++) {
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t i = 0; i < f->entity_count; i++) {
            const step_entity *e = &f->entities[i];
            if (e->part_count != 1 || (pass == 0 && skip[i]) ||
                !crisp__step_is(r, e, "CARTESIAN_POINT"))
                continue;
            double p[3];
            int dim;
            if (crisp__step_point(r, e, p, &dim) || dim != 3) continue;
            for (int k = 0; k < 3; k++)
                lo[k] = fmin(lo[k], p[k]), hi[k] = fmax(hi[k], p[k]);
        }
        d = 0;
        for (int k = 0; k < 3; k++)
            d += hi[k] > lo[k] ? (hi[k] - lo[k]) * (hi[k] - lo[k]) : 0;
    }
    crisp_error_clear();
    return d > 0 ? sqrt(d) : 1;
}

/* ---- per-face tolerance -------------------------------------------------------------------------
 * One tolerance for the whole file fails when parts of very different sizes share it
 * (trj5_k1-ct-214.stp: a 2e6 wide plate and a torus of radius 3.8: a tolerance of 28 makes the
 * torus's edges meaningless). A face much smaller than the model gets a tolerance from its own
 * size: the box of the points it references (again without line origins and placements). */
typedef struct face_scale {
    const unsigned char *skip;
    int *stamp; /* by entity index: the last face that visited it */
    int face;
    int *stack;
    size_t stack_cap;
    double lo[3], hi[3];
} face_scale;

static void scale_value(step_reader *r, face_scale *fs, const step_value *v, size_t *n, int depth)
{
    if (v->kind == STEP_REF) {
        const step_entity *t = crisp__step_find(r->f, v->num);
        if (!t) return;
        size_t idx = (size_t)(t - r->f->entities);
        if (fs->stamp[idx] == fs->face) return;
        fs->stamp[idx] = fs->face;
        if (*n == fs->stack_cap &&
            crisp_grow((void **)&fs->stack, &fs->stack_cap, *n + 1, sizeof *fs->stack))
            return;
        fs->stack[(*n)++] = (int)idx;
    } else if (v->kind == STEP_LIST && depth < 8) {
        for (uint32_t i = 0; i < v->len; i++)
            scale_value(r, fs, &r->f->values[v->first + i], n, depth + 1);
    } else if (v->kind == STEP_TYPED && depth < 8) {
        scale_value(r, fs, &r->f->values[v->first], n, depth + 1);
    }
}

/* Diagonal of the box of the 3D points fe references; skip_surface: not through its surface. */
static double points_diagonal(step_reader *r, face_scale *fs, const step_entity *fe,
                              int skip_surface)
{
    const step_file *f = r->f;
    size_t n = 0;
    fs->face++;
    for (int k = 0; k < 3; k++)
        fs->lo[k] = INFINITY, fs->hi[k] = -INFINITY;
    const step_entity *se;
    if (skip_surface && !crisp__step_get_ref(r, fe, crisp__step_part(r, fe, NULL), 2, &se))
        fs->stamp[se - f->entities] = fs->face;
    step_value root = {.kind = STEP_REF, .num = fe->id};
    scale_value(r, fs, &root, &n, 0);
    while (n) {
        const step_entity *e = &f->entities[fs->stack[--n]];
        if (crisp__step_is(r, e, "CARTESIAN_POINT")) {
            double p[3];
            int dim;
            if (!fs->skip[e - f->entities] && !crisp__step_point(r, e, p, &dim) && dim == 3)
                for (int k = 0; k < 3; k++)
                    fs->lo[k] = fmin(fs->lo[k], p[k]), fs->hi[k] = fmax(fs->hi[k], p[k]);
            continue;
        }
        /* Styles, contexts and the like are not geometry. */
        if (crisp__step_is(r, e, "REPRESENTATION_CONTEXT") ||
            crisp__step_is(r, e, "GEOMETRIC_REPRESENTATION_CONTEXT"))
            continue;
        for (uint32_t pi = 0; pi < e->part_count; pi++)
            scale_value(r, fs, &f->values[f->parts[e->first_part + pi].params], &n, 0);
    }
    crisp_error_clear();
    double d = 0;
    for (int k = 0; k < 3; k++)
        d += fs->hi[k] > fs->lo[k] ? (fs->hi[k] - fs->lo[k]) * (fs->hi[k] - fs->lo[k]) : 0;
    return sqrt(d);
}

/* The face's size: of the points it references, but of its bounds alone where its surface's
 * control net reaches more than 10 times as far (trj6_b1-ec-214.stp #6387: a lens 1.5 long and
 * 0.046 high on a patch whose net is 30,000 long; the tolerance from the net's size let the
 * trims wander 0.14 off the lens's edges). (Always the bounds' size was tried: it tightened
 * bug25013_25013faces.stp #793922's tolerance by 17% and dropped it; its edges lie 3e-3 off its
 * surface, which its 16x loosened projection just covered.) */
static double face_diagonal(step_reader *r, face_scale *fs, const step_entity *fe)
{
    double all = points_diagonal(r, fs, fe, 0), bounds = points_diagonal(r, fs, fe, 1);
    return bounds > 0 && all > 10 * bounds ? bounds : all;
}

crisp_status crisp_read_step_mem(const char *name, const char *data, size_t size,
                                 const crisp_read_options *options, crisp_model **dest)
{
    return crisp__step_read_mem(name, data, size, options, dest, NULL);
}

crisp_status crisp__step_read_mem(const char *name, const char *data, size_t size,
                                  const crisp_read_options *options, crisp_model **dest,
                                  step_read_stats *stats)
{
    step_read_stats local = {0};
    if (!stats) stats = &local;
    int verify = stats->verify;
    memset(stats, 0, sizeof *stats);
    stats->verify = verify;
    double t_start = crisp_time_now();
    if (!dest || (!data && size))
        return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_read_step_mem: NULL argument");
    *dest = NULL;
    if (!name) name = "(memory)";
    step_file f;
    crisp_status st = crisp__step_parse(name, data ? data : "", size, &f);
    if (st) return st;
    stats->parse_seconds = crisp_time_now() - t_start;
    crisp_model *m = NULL;
    face_list fl = {0};
    int *ids = NULL;
    unsigned char *skip = NULL;
    face_scale fs = {0};
    if ((st = crisp_model_create(&m))) goto done;
    snprintf(m->format, sizeof m->format, "STEP");
    step_reader r = {.f = &f, .model = m, .stats = stats};
    crisp__step_units(&r);
    double frac =
        options && options->projection_tolerance > 0 ? options->projection_tolerance : 1e-5;
    skip = crisp_calloc_array(f.entity_count + 1, 1);
    fs.stamp = crisp_calloc_array(f.entity_count + 1, sizeof *fs.stamp);
    if (!skip || !fs.stamp) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", name);
        goto done;
    }
    fs.skip = skip;
    r.tol = frac * model_diagonal(&r, skip);
    double tol_model = r.tol;
    stats->tol = r.tol;
    r.close_rel = options && options->closure_tolerance > 0 ? options->closure_tolerance : 1e-6;
    if (f.duplicates) {
        crisp_model_note_skipf(
            m, "STEP %d entities defined twice with identical text (first #%d): copy ignored",
            f.duplicates, f.first_duplicate);
    }
    if (f.broken) {
        /* The message names the file, line and column. */
        const char *msg = f.first_broken;
        size_t nl = strlen(name);
        if (strncmp(msg, name, nl) == 0 && msg[nl] == ':') msg += nl + 2;
        crisp_model_note_skipf(m, "STEP %d broken instances skipped; first: %s", f.broken, msg);
    }
    int wire = 0;
    if ((st = collect_faces(&r, &fl, &wire))) goto done;
    if (fl.count == 0) {
        st = f.broken ? crisp_error(CRISP_ERR_PARSE, "%s", f.first_broken)
                      : nothing_drawable(&r, wire);
        goto done;
    }
    int meshes = count_types(&r, mesh_types, sizeof mesh_types / sizeof *mesh_types);
    for (int k = 0; k < meshes; k++)
        crisp_model_note_skip(m, "STEP tessellated item (a mesh: not drawn)");
    ids = crisp_malloc_array(fl.count * 3, sizeof *ids);
    if (!ids) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", name);
        goto done;
    }
    int n = 0;
    for (size_t i = 0; i < fl.count; i++) {
        const step_entity *fe = crisp__step_find(&f, fl.refs[i].id);
        crisp_face face;
        /* Faces under 1/100 of the model's size get a tolerance from their own size (100 times
         * the fraction: still far finer than the model's). */
        double fd = face_diagonal(&r, &fs, fe);
        r.tol = fd > 0 && 100 * frac * fd < tol_model ? 100 * frac * fd : tol_model;
        double dev_before = stats->max_edge_dev;
        st = convert_face(&r, &fl.refs[i], fe, &face);
        r.tol = tol_model;
        if (st) stats->max_edge_dev = dev_before; /* a dropped face's trims are not in the model */
        if (st == CRISP_ERR_NO_MEMORY) goto done;
        if (st) {
            /* Drop the face, saying which and why (without the file name, which is the model's). */
            const char *msg = crisp_error_message();
            size_t nl = strlen(name);
            if (strncmp(msg, name, nl) == 0 && msg[nl] == ':') msg += nl + 2;
            /* ... and without repeating the face: "#68 (line 72) TYPE: ", "#68: ", "face 68: ". */
            char self[32];
            int sl = snprintf(self, sizeof self, "#%d ", fe->id);
            if (strncmp(msg, self, (size_t)sl) == 0 && msg[sl] == '(') {
                const char *c = strstr(msg, ": ");
                if (c) msg = c + 2;
            }
            sl = snprintf(self, sizeof self, "#%d: ", fe->id);
            if (strncmp(msg, self, (size_t)sl) == 0) msg += sl;
            sl = snprintf(self, sizeof self, "face %d: ", fe->id);
            if (strncmp(msg, self, (size_t)sl) == 0) msg += sl;
            crisp_model_note_dropped(m, "STEP face #%d dropped: %s", fe->id, msg);
            stats->dropped_faces++;
            st = CRISP_OK;
            continue;
        }
        face.reversed ^= fl.refs[i].flip;
        /* a solid is a body; faces of shells and sets without one may be meant to meet across
         * sets (surface models put each face in its own GEOMETRIC_SET): no body */
        face.body = fl.refs[i].owner[1];
        if ((st = crisp_model_add_face(m, &face))) {
            crisp_face_free(&face);
            goto done;
        }
        ids[n] = fe->id;
        ids[fl.count + 2 * n] = fl.refs[i].owner[0];
        ids[fl.count + 2 * n + 1] = fl.refs[i].owner[1];
        n++;
    }
    if (n == 0 && f.broken) {
        /* Nothing could be read and the text is broken: that is the error. */
        st = crisp_error(CRISP_ERR_PARSE, "%s", f.first_broken);
        goto done;
    }
    if (n == 0) {
        /* Nothing could be read: report the first face's problem as the error. */
        const step_entity *fe = crisp__step_find(&f, fl.refs[0].id);
        crisp_face face;
        st = convert_face(&r, &fl.refs[0], fe, &face);
        if (!st) {
            crisp_face_free(&face);
            st = crisp_error(CRISP_ERR_INTERNAL, "%s: no face could be read", name);
        }
        goto done;
    }
    m->tolerance = tol_model;
    crisp__step_colors(&r, ids, ids + fl.count, n);
    if ((st = crisp__step_assembly(&r, ids, ids + fl.count, n))) goto done;
    crisp_error_clear();
done:
    crisp_free(ids);
    crisp_free(fl.refs);
    crisp_free(fl.seen);
    crisp_free(skip);
    crisp_free(fs.stamp);
    crisp_free(fs.stack);
    crisp__step_file_free(&f);
    if (st) {
        crisp_model_destroy(m);
        return st;
    }
    *dest = m;
    stats->total_seconds = crisp_time_now() - t_start;
    return CRISP_OK;
}

crisp_status crisp_read_step(const char *path, const crisp_read_options *options,
                             crisp_model **dest)
{
    if (!path || !dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_read_step: NULL argument");
    char *data;
    size_t size;
    crisp_status st = crisp_read_file(path, &data, &size);
    if (st) return st;
    st = crisp_read_step_mem(path, data, size, options, dest);
    crisp_free(data);
    return st;
}
