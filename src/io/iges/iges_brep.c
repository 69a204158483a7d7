/* IGES B-rep faces: 186 manifold solid, 514 shell, 510 face, 508 loop, 504 edge list, 502 vertex
 * list. A loop's edges use their parameter-space curves when the loop gives them, else the edge's
 * model-space curve projected onto the face's surface. IGES 5.3 sections 4.150-4.156.
 */
#include "iges_internal.h"

#include <string.h>

static crisp_status expect_type(const iges_file *f, int e, int k, int ptr, int type)
{
    if (f->ents[ptr].type != type)
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter %d: DE %d is entity %d, expected %d", k, iges_de(ptr),
                                f->ents[ptr].type, type);
    return CRISP_OK;
}

static void reverse_range(iges_curves *c, int first)
{
    for (int a = first, b = c->count - 1; a < b; a++, b--) {
        crisp_curve *t = c->items[a];
        c->items[a] = c->items[b];
        c->items[b] = t;
    }
    for (int j = first; j < c->count; j++)
        crisp_curve_reverse(c->items[j]);
}

/* The model-space curve of edge `index` (1-based) of edge list el. */
static crisp_status edge_curve(iges_file *f, int el, int index, int *dest)
{
    int n;
    crisp_status st = crisp__iges_int_range(f, el, 1, 0, (crisp__iges_nparams(f, el) - 1) / 5, &n);
    if (st) return st;
    if (index < 1 || index > n)
        return crisp__iges_fail(f, el, CRISP_ERR_PARSE, "edge index %d: expected 1 to %d", index,
                                n);
    f->ents[el].used = 1;
    return crisp__iges_ptr(f, el, 2 + 5 * (index - 1), 0, dest);
}

static crisp_status loop_508(iges_file *f, int e, const iges_surface *s, iges_curves *uv)
{
    int n;
    crisp_status st = crisp__iges_int_range(f, e, 1, 0, crisp__iges_nparams(f, e), &n);
    if (st) return st;
    f->ents[e].used = 1;
    int k = 2;
    for (int i = 0; i < n && !st; i++) {
        int type, edge, ndx, of, np;
        if ((st = crisp__iges_int_range(f, e, k, 0, 1, &type)) ||
            (st = crisp__iges_ptr(f, e, k + 1, 0, &edge)) ||
            (st = crisp__iges_int(f, e, k + 2, &ndx)) ||
            (st = crisp__iges_int_range(f, e, k + 3, 0, 1, &of)) ||
            (st = crisp__iges_int_range(f, e, k + 4, 0, (crisp__iges_nparams(f, e) - k - 4) / 2,
                                        &np)))
            break;
        int first = uv->count;
        if (type == 1) { /* a vertex: a degenerate edge contributes no curve */
            f->ents[edge].used = 1;
        } else if ((st = expect_type(f, e, k + 1, edge, 504))) {
            break;
        } else if (np > 0 && !s->is_plane && !s->analytic) {
            for (int j = 0; j < np && !st; j++) {
                int pc;
                if ((st = crisp__iges_ptr(f, e, k + 6 + 2 * j, 0, &pc))) break;
                if (f->ents[pc].type == 142) { /* some writers wrap the pcurve in a 142 */
                    f->ents[pc].used = 1;
                    if ((st = crisp__iges_ptr(f, pc, 3, 0, &pc))) break;
                }
                st = crisp__iges_curve_convert(f, pc, 2, NULL, 1, uv);
            }
            for (int j = first; j < uv->count && !st; j++) {
                double d[4];
                crisp_surface_domain(s->surface, d);
                double size = d[1] - d[0] > d[3] - d[2] ? d[1] - d[0] : d[3] - d[2];
                st = crisp__iges_surface_map_curve(s, 1e-6 * size, &uv->items[j]);
            }
            if (!st && of == 0) reverse_range(uv, first);
            int cp; /* the model-space curve is an alternative representation crisp did not need */
            if (!st) {
                if (!edge_curve(f, edge, ndx, &cp))
                    crisp__iges_mark_used(f, cp, 0);
                else
                    crisp_error_clear();
            }
        } else {
            int cp;
            iges_curves model = {0};
            if (!(st = edge_curve(f, edge, ndx, &cp)))
                st = crisp__iges_curve_convert(f, cp, 3, NULL, 1, &model);
            if (!st) st = crisp__iges_project_curves(f, e, s, &model, uv);
            crisp__iges_curves_free(&model);
            if (!st && of == 0) reverse_range(uv, first);
        }
        k += 5 + 2 * np;
    }
    return st;
}

crisp_status crisp__iges_face_brep(iges_file *f, int e, int reversed)
{
    int sp, n, of;
    crisp_status st = crisp__iges_ptr(f, e, 1, 0, &sp);
    if (!st) st = crisp__iges_int_range(f, e, 2, 0, crisp__iges_nparams(f, e) - 3, &n);
    if (!st) st = crisp__iges_int_range(f, e, 3, 0, 1, &of);
    if (st) return st;
    f->ents[e].used = 1;
    if (!crisp__iges_is_surface_type(f->ents[sp].type))
        return crisp__iges_fail(f, e, CRISP_ERR_PARSE,
                                "parameter 1: DE %d is entity %d, expected a "
                                "surface",
                                iges_de(sp), f->ents[sp].type);
    iges_surface s;
    if ((st = crisp__iges_surface_convert(f, sp, 1, &s))) return st;
    int nl = n + 1;
    iges_curves *loops = crisp_calloc_array((size_t)nl, sizeof *loops);
    int *outer = crisp_calloc_array((size_t)nl, sizeof *outer);
    if (!loops || !outer) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    for (int i = 0; i < n && !st; i++) {
        int lp;
        if ((st = crisp__iges_ptr(f, e, 4 + i, 0, &lp)) || (st = expect_type(f, e, 4 + i, lp, 508)))
            break;
        st = loop_508(f, lp, &s, &loops[i]);
        outer[i] = of == 1 && i == 0;
    }
    if (!st && of == 0 && n > 0 && s.surface) {
        /* no outer loop given: the domain boundary is the outer loop */
        st = crisp__iges_domain_loop(&s, &loops[n]);
        outer[n] = 1;
    }
    if (!st) st = crisp__iges_finish_face(f, e, sp, &s, loops, outer, nl, reversed);
done:
    for (int i = 0; loops && i < nl; i++)
        crisp__iges_curves_free(&loops[i]);
    crisp_free(loops);
    crisp_free(outer);
    crisp__iges_surface_free(&s);
    return st;
}

static crisp_status shell_514(iges_file *f, int e, int reversed, int depth)
{
    int n;
    crisp_status st = crisp__iges_int_range(f, e, 1, 0, crisp__iges_nparams(f, e) / 2, &n);
    if (st) return st;
    if (f->ents[e].used) return CRISP_OK; /* a shell shared by two solids is read once */
    f->ents[e].used = 1;
    (void)depth;
    for (int i = 0; i < n && !st; i++) {
        int fp, of;
        if ((st = crisp__iges_ptr(f, e, 2 + 2 * i, 0, &fp)) ||
            (st = crisp__iges_int_range(f, e, 3 + 2 * i, 0, 1, &of)) ||
            (st = expect_type(f, e, 2 + 2 * i, fp, 510)))
            break;
        if (f->ents[fp].used) continue;
        st = crisp__iges_soften(f, fp, crisp__iges_face_brep(f, fp, reversed ^ (of == 0)));
    }
    return st;
}

static crisp_status brep_faces(iges_file *f, int e);

/* The faces of a 186 solid or a lone 514 shell, each with the entity's DE as its body. */
crisp_status crisp__iges_brep_faces(iges_file *f, int e)
{
    int outer = f->body;
    f->body = iges_de(e);
    crisp_status st = brep_faces(f, e);
    f->body = outer;
    return st;
}

static crisp_status brep_faces(iges_file *f, int e)
{
    if (f->ents[e].type == 514) return f->ents[e].used ? CRISP_OK : shell_514(f, e, 0, 0);
    /* 186: the outer shell and its voids */
    int sh, sof, nv;
    crisp_status st = crisp__iges_ptr(f, e, 1, 0, &sh);
    if (!st) st = crisp__iges_int_range(f, e, 2, 0, 1, &sof);
    if (!st) st = crisp__iges_int_range(f, e, 3, 0, (crisp__iges_nparams(f, e) - 3) / 2, &nv);
    if (!st) st = expect_type(f, e, 1, sh, 514);
    if (st) return st;
    f->ents[e].used = 1;
    if ((st = shell_514(f, sh, sof == 0, 1))) return st;
    for (int i = 0; i < nv && !st; i++) {
        int v, vof;
        if ((st = crisp__iges_ptr(f, e, 4 + 2 * i, 0, &v)) ||
            (st = crisp__iges_int_range(f, e, 5 + 2 * i, 0, 1, &vof)) ||
            (st = expect_type(f, e, 4 + 2 * i, v, 514)))
            break;
        st = shell_514(f, v, vof == 0, 1);
    }
    return st;
}
