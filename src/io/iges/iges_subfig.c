/* IGES subfigures: 308 subfigure definition (a named list of entities, possibly holding 408
 * instances of other definitions) and 408 singular subfigure instance (a definition placed by
 * scale S, translation (X, Y, Z) and the instance's own matrix). IGES 5.3 sections 4.74, 4.137.
 *
 * Members of a definition are drawn only through its instances, whatever their status numbers
 * say (real files mark them independent: OCCT's bug33327.igs). Each definition's faces are built
 * once into a model of their own; every instance appends transformed copies of them, and of the
 * definitions its nested 408s place, so a part used four times is read once and drawn four times.
 * Each placed 408 is an occurrence of the model's assembly tree (named by its 308, under the
 * occurrence that placed it), and its face copies name it (crisp_face.occurrence).
 */
#include "iges_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The number of members of definition e (member k is its parameter 4 + k). */
static crisp_status def_members(iges_file *f, int e, int *count)
{
    crisp_status st = crisp__iges_need(f, e, 3, "a subfigure definition");
    if (!st) st = crisp__iges_int_range(f, e, 3, 0, crisp__iges_nparams(f, e) - 3, count);
    return st;
}

void crisp__iges_subfigure_mark(iges_file *f)
{
    for (int i = 0; i < f->entity_count; i++) {
        if (f->ents[i].type != 308) continue;
        int n;
        if (def_members(f, i, &n)) {
            crisp_error_clear();
            continue;
        }
        for (int k = 0; k < n; k++) {
            int m;
            if (crisp__iges_ptr(f, i, 4 + k, 0, &m)) {
                crisp_error_clear();
                continue;
            }
            f->ents[m].in_subfigure = 1;
        }
    }
    /* the shells of member solids and the faces of member shells belong to the definition too
     * (one pass each way suffices: solids point at shells, shells at faces) */
    for (int pass = 0; pass < 2; pass++)
        for (int i = 0; i < f->entity_count; i++) {
            const iges_entity *x = &f->ents[i];
            if (!x->in_subfigure || (x->type != 186 && x->type != 514)) continue;
            int np = crisp__iges_nparams(f, i);
            for (int k = 1; k <= np; k++) {
                int m;
                /* 186: shell pointers at 1 and 4, 6, ...; 514: face pointers at 2, 4, ... */
                int is_ptr = x->type == 186 ? (k == 1 || (k >= 4 && k % 2 == 0)) : k % 2 == 0;
                if (!is_ptr || crisp__iges_ptr(f, i, k, 0, &m)) {
                    crisp_error_clear();
                    continue;
                }
                if (f->ents[m].type == 514 || f->ents[m].type == 510) f->ents[m].in_subfigure = 1;
            }
        }
}

/* The placement of a 408: its matrix times (S x + t). */
static crisp_status instance_xform(iges_file *f, int e, int *def, iges_xform *dest)
{
    double t[3], s;
    crisp_status st = crisp__iges_ptr(f, e, 1, 0, def);
    for (int k = 0; k < 3 && !st; k++)
        st = crisp__iges_real_def(f, e, 2 + k, 0, &t[k]);
    if (!st) st = crisp__iges_real_def(f, e, 5, 1, &s);
    if (st) return st;
    if (f->ents[*def].type != 308)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter 1: DE %d is entity %d, expected 308", iges_de(*def),
                                f->ents[*def].type);
    if (!(s != 0) || !isfinite(s))
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "scale %g: expected a finite non-zero number", s);
    iges_xform own, local;
    if ((st = crisp__iges_entity_xform(f, e, 1, &own))) return st;
    crisp__iges_xform_identity(&local);
    for (int k = 0; k < 3; k++) {
        local.m[k][k] = s;
        local.m[k][3] = t[k];
    }
    crisp__iges_xform_mul(&own, &local, dest);
    return CRISP_OK;
}

typedef struct subfig_state {
    crisp_model **defs; /* per entity index: the faces of that 308, built on first use */
    crisp_model *top;
} subfig_state;

static crisp_status build_def(iges_file *f, subfig_state *s, int e)
{
    if (s->defs[e]) return CRISP_OK;
    int n;
    crisp_status st = def_members(f, e, &n);
    if (st) return st;
    f->ents[e].used = 1;
    int *members = crisp_malloc_array((size_t)n + 1, sizeof *members);
    if (!members) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    int count = 0;
    for (int k = 0; k < n && !st; k++) {
        int m;
        if (!(st = crisp__iges_ptr(f, e, 4 + k, 0, &m))) members[count++] = m;
    }
    crisp_model *def = NULL;
    if (!st) st = crisp_model_create(&def);
    if (!st) {
        /* the face builders add to f->model: point it at the definition's model meanwhile,
         * then pass its skip notes on to the file's model */
        s->defs[e] = def;
        f->model = def;
        st = crisp__iges_build_entities(f, members, count);
        f->model = s->top;
        for (int i = 0; i < def->skip_count && !st; i++)
            for (int k = 0; k < def->skips[i].count && !st; k++)
                st = crisp_model_note_skip(s->top, def->skips[i].what);
        s->top->faces_dropped += def->faces_dropped;
    }
    crisp_free(members);
    return st;
}

static crisp_status append_copy(iges_file *f, const crisp_face *src, const iges_xform *x, int occ)
{
    crisp_face face;
    crisp_status st = crisp_face_copy(src, &face);
    if (st) return st;
    crisp_face_transform(&face, (const double(*)[4])x->m);
    face.occurrence = occ + 1;
    /* each placed copy of a solid is a body of its own (as for STEP's placed parts) */
    if (face.body)
        face.body = (int)(((unsigned)face.body * 2654435761u) ^ ((unsigned)occ + 1u)) | 1;
    if ((st = crisp_model_add_face(f->model, &face))) crisp_face_free(&face);
    return st;
}

/* The assembly tree (crisp_model.occurrences): one occurrence per placed 408, named by its
 * definition's name (308 parameter 2), under the occurrence of the 408 that placed its 308. */
static crisp_status add_occurrence(iges_file *f, int def, int instance, int parent, int *occ)
{
    char name[256] = "";
    if (crisp__iges_nparams(f, def) >= 2) {
        const iges_param *p = &f->params[f->ents[def].first_param + 2];
        if (p->kind == IGES_PARAM_STRING)
            snprintf(name, sizeof name, "%.*s", p->str_len, f->strings + p->str_off);
    }
    return crisp_model_add_occurrence(f->model, name, parent, iges_de(instance), occ);
}

static crisp_status instantiate(iges_file *f, subfig_state *s, int def, const iges_xform *x,
                                int depth, int instance, int parent)
{
    if (depth > IGES_MAX_DEPTH)
        return crisp__iges_fail(f, def, CRISP_ERR_LIMIT, "subfigures nested deeper than %d",
                                IGES_MAX_DEPTH);
    if (f->ents[def].visiting) return crisp__iges_fail(f, def, CRISP_ERR_PARSE, "reference cycle");
    crisp_status st = build_def(f, s, def);
    int occ = -1;
    if (!st) st = add_occurrence(f, def, instance, parent, &occ);
    if (st) return st;
    const crisp_model *m = s->defs[def];
    for (int i = 0; i < m->face_count && !st; i++)
        st = append_copy(f, &m->faces[i], x, occ);
    int n;
    if (st || (st = def_members(f, def, &n))) return st;
    f->ents[def].visiting = 1;
    for (int k = 0; k < n && !st; k++) {
        int e, inner;
        iges_xform place, total;
        if ((st = crisp__iges_ptr(f, def, 4 + k, 0, &e))) break;
        if (f->ents[e].type != 408) continue;
        f->ents[e].used = 1;
        if ((st = instance_xform(f, e, &inner, &place))) break;
        crisp__iges_xform_mul(x, &place, &total);
        st = instantiate(f, s, inner, &total, depth + 1, e, occ);
    }
    f->ents[def].visiting = 0;
    return st;
}

crisp_status crisp__iges_subfigure_instances(iges_file *f)
{
    int any = 0;
    for (int i = 0; i < f->entity_count && !any; i++)
        any = f->ents[i].type == 408;
    if (!any) return CRISP_OK;
    subfig_state s = {crisp_calloc_array((size_t)f->entity_count, sizeof *s.defs), f->model};
    if (!s.defs) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    crisp_status st = CRISP_OK;
    for (int i = 0; i < f->entity_count && !st; i++) {
        iges_entity *x = &f->ents[i];
        if (x->type != 408 || x->in_subfigure) continue;
        x->used = 1;
        if (x->blank == 1) {
            crisp_model_note_skip(f->model, "entity 408 singular subfigure instance: blanked "
                                            "(not displayed)");
            continue;
        }
        int def;
        iges_xform place;
        st = instance_xform(f, i, &def, &place);
        if (!st) st = instantiate(f, &s, def, &place, 1, i, -1);
        st = crisp__iges_soften(f, i, st);
    }
    for (int i = 0; i < f->entity_count; i++)
        crisp_model_destroy(s.defs[i]);
    crisp_free(s.defs);
    return st;
}
