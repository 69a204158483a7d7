/* The IGES reader's entry points: parse the file, find the faces (144 trimmed surfaces, 143
 * bounded surfaces, 510 B-rep faces, bounded 108 planes, and surfaces no face refers to), convert
 * them, and count what was skipped and why. IGES 5.3.
 *
 * Which surfaces are faces of their own: the standard says independent ones (subordinate status
 * 00), but real files mark free patches "physically dependent" (gpucast_teapot.igs), so crisp
 * takes every surface that no 144, 142, 143, 141 or 510 refers to and that is not blanked.
 */
#include "iges_internal.h"

#include <stdio.h>
#include <string.h>

static void consume(iges_file *f, int e, int k)
{
    int de = 0;
    if (k > crisp__iges_nparams(f, e)) return;
    if (crisp__iges_int(f, e, k, &de)) {
        crisp_error_clear();
        return;
    }
    int i = crisp__iges_index(f, de < 0 ? -de : de);
    if (i >= 0) f->ents[i].consumed = 1;
}

static void mark_consumed(iges_file *f)
{
    for (int i = 0; i < f->entity_count; i++) {
        switch (f->ents[i].type) {
        case 144:
            consume(f, i, 1);
            break;
        case 142:
            consume(f, i, 2);
            break;
        case 143:
            consume(f, i, 2);
            break;
        case 141:
            consume(f, i, 3);
            break;
        case 510:
            consume(f, i, 1);
            break;
        case 140:
            consume(f, i, 5);
            break;
        default:
            break;
        }
    }
}

static void note(iges_file *f, int type, const char *why)
{
    crisp_model_note_skipf(f->model, "entity %d %s: %s", type, crisp__iges_type_name(type), why);
}

/* A face that crisp cannot build is skipped with a note naming it (DE number and the reason),
 * so one bad face never loses the rest of a real file; only running out of memory stops the
 * read. The first such error is kept: a file whose every face fails reports it as its error. */
crisp_status crisp__iges_soften(iges_file *f, int e, crisp_status st)
{
    if (st == CRISP_OK || st == CRISP_ERR_NO_MEMORY) return st;
    const char *msg = crisp_error_message(), *p = strstr(msg, "): ");
    if (!f->first_error) {
        f->first_error = st;
        snprintf(f->first_message, sizeof f->first_message, "%s", msg);
    }
    crisp_model_note_dropped(f->model, "DE %d entity %d: %s", iges_de(e), f->ents[e].type,
                             p ? p + 3 : msg);
    crisp_error_clear();
    f->ents[e].used = 0;
    crisp__iges_mark_used(f, e, 0);
    return CRISP_OK;
}

/* A face the file blanks is not drawn (unless every face is blanked): counted and noted. */
static int skip_blanked(iges_file *f, iges_entity *x)
{
    if (x->blank != 1 || f->draw_blanked) return 0;
    x->used = 1;
    f->blanked_faces++;
    note(f, x->type, "blanked (not displayed)");
    return 1;
}

/* Build the faces of the listed entities: solids first (so that their shells get the solid's
 * orientation), then trimmed and bounded surfaces, shells and independent surfaces, then the
 * 510 faces that no shell took. Other entity types are left alone. */
crisp_status crisp__iges_build_entities(iges_file *f, const int *list, int n)
{
    crisp_status st = CRISP_OK;
    for (int k = 0; k < n && !st; k++)
        if (f->ents[list[k]].type == 186)
            st = crisp__iges_soften(f, list[k], crisp__iges_brep_faces(f, list[k]));
    for (int k = 0; k < n && !st; k++) {
        int i = list[k];
        iges_entity *x = &f->ents[i];
        switch (x->type) {
        case 144:
        case 143:
            if (skip_blanked(f, x)) break;
            st = crisp__iges_soften(f, i,
                                    x->type == 144 ? crisp__iges_face_trimmed(f, i)
                                                   : crisp__iges_face_bounded(f, i));
            break;
        case 514:
            st = crisp__iges_soften(f, i, crisp__iges_brep_faces(f, i));
            break;
        case 108:
        case 114:
        case 118:
        case 120:
        case 122:
        case 140:
        case 128:
            if (x->consumed) break;
            if (skip_blanked(f, x)) break;
            x->used = 1;
            st = crisp__iges_soften(f, i,
                                    x->type == 108 ? crisp__iges_face_plane(f, i)
                                                   : crisp__iges_face_untrimmed(f, i));
            break;
        default:
            break;
        }
    }
    for (int k = 0; k < n && !st; k++)
        if (f->ents[list[k]].type == 510 && !f->ents[list[k]].used)
            st = crisp__iges_soften(f, list[k], crisp__iges_face_brep(f, list[k], 0));
    return st;
}

static crisp_status convert(iges_file *f)
{
    mark_consumed(f);
    crisp__iges_subfigure_mark(f);
    /* everything outside subfigure definitions, in file order; then the subfigure instances */
    int *list = crisp_malloc_array((size_t)f->entity_count + 1, sizeof *list), n = 0;
    if (!list) return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    for (int i = 0; i < f->entity_count; i++)
        if (!f->ents[i].in_subfigure) list[n++] = i;
    crisp_status st = crisp__iges_build_entities(f, list, n);
    crisp_free(list);
    if (!st) st = crisp__iges_subfigure_instances(f);
    if (st) return st;
    for (int i = 0; i < f->entity_count; i++) {
        const iges_entity *x = &f->ents[i];
        if (x->used || x->consumed) continue;
        if (crisp__iges_is_curve_type(x->type) || x->type == 116 || x->type == 142 ||
            x->type == 141)
            note(f, x->type, "free curve or point, not part of a face");
        else if (x->type == 124 || x->type == 314 || x->type == 502 || x->type == 504 ||
                 x->type == 508)
            continue; /* supporting data no face used: nothing to draw */
        else
            note(f, x->type, "not geometry crisp draws");
    }
    return CRISP_OK;
}

/* Convert the parsed file into a new model (*m, set even when the conversion fails). */
static crisp_status convert_into_new_model(iges_file *f, crisp_model **m)
{
    crisp_status st = crisp_model_create(m);
    if (st) return st;
    snprintf((*m)->format, sizeof(*m)->format, "IGES");
    (*m)->unit_to_mm = f->unit_to_mm;
    f->model = *m;
    return convert(f);
}

crisp_status crisp_read_iges_mem(const char *name, const char *data, size_t size,
                                 const crisp_read_options *options, crisp_model **dest)
{
    if (!dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_read_iges_mem: dest is NULL");
    *dest = NULL;
    if (!name) name = "<memory>";
    if (!data && size) return crisp_error(CRISP_ERR_INVALID_ARG, "%s: data is NULL", name);
    iges_file f;
    crisp_status st = crisp__iges_file_parse(name, data ? data : "", size, &f);
    if (st) return st;
    f.projection_fraction =
        options && options->projection_tolerance > 0 ? options->projection_tolerance : 1e-5;
    f.closure_fraction =
        options && options->closure_tolerance > 0 ? options->closure_tolerance : 1e-6;
    crisp_model *m = NULL;
    st = convert_into_new_model(&f, &m);
    if (!st && m->face_count == 0 && f.blanked_faces > 0) {
        /* Every face is blanked: show them rather than nothing (CAD files keep hidden copies,
         * but a file of only hidden faces is meant to be seen) and say so. */
        crisp_model_destroy(m);
        m = NULL;
        crisp__iges_file_reset(&f);
        f.draw_blanked = 1;
        st = convert_into_new_model(&f, &m);
        if (!st)
            st = crisp_model_note_skip(m, "(nothing) every face in the file is "
                                          "blanked: drawn anyway");
    }
    if (!st) m->tolerance = f.tol3d;
    if (!st && m->face_count == 0 && f.first_error) {
        /* nothing could be drawn: the first face's failure is the file's error */
        st = crisp_error(f.first_error, "%s", f.first_message);
    }
    crisp__iges_file_free(&f);
    if (st) {
        crisp_model_destroy(m);
        return st;
    }
    *dest = m;
    return CRISP_OK;
}

crisp_status crisp_read_iges(const char *path, const crisp_read_options *options,
                             crisp_model **dest)
{
    if (!dest) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_read_iges: dest is NULL");
    *dest = NULL;
    if (!path) return crisp_error(CRISP_ERR_INVALID_ARG, "crisp_read_iges: path is NULL");
    char *data = NULL;
    size_t size = 0;
    crisp_status st = crisp_read_file(path, &data, &size);
    if (st) return st;
    st = crisp_read_iges_mem(path, data, size, options, dest);
    crisp_free(data);
    return st;
}
