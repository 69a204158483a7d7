/* STEP assembly structure: one placed copy of a part's faces per use of the part.
 *
 * Follows ISO 10303-203/-214 (product_definition, next_assembly_usage_occurrence,
 * product_definition_shape, shape_definition_representation) and the CAx-IF "Recommended Practices
 * for AP203/AP214 assembly structure": a child's placement in its parent is either
 *   - CONTEXT_DEPENDENT_SHAPE_REPRESENTATION -> a complex (REPRESENTATION_RELATIONSHIP,
 *     REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION, SHAPE_REPRESENTATION_RELATIONSHIP) whose
 *     ITEM_DEFINED_TRANSFORMATION maps placement transform_item_1 (in rep_1, the child) onto
 *     transform_item_2 (in rep_2, the parent); a CARTESIAN_TRANSFORMATION_OPERATOR_3D is also read;
 *   - a MAPPED_ITEM in the parent's items: REPRESENTATION_MAP (mapping_origin, the child
 *     representation) placed at mapping_target: the map takes the origin onto the target.
 * A SHAPE_REPRESENTATION_RELATIONSHIP without a transformation ties a SHAPE_REPRESENTATION to the
 * ADVANCED_BREP_SHAPE_REPRESENTATION (or other) holding the geometry: such representations are
 * merged into one group (union-find), so the direction writers give them does not matter.
 *
 * The groups and placements form a graph; the roots (groups no placement puts anywhere) are drawn
 * where they are, and transforms compose down the tree. The side of a relationship is checked
 * against the product structure (the NAUO's relating / related product definition, through
 * PRODUCT_DEFINITION_SHAPE and SHAPE_DEFINITION_REPRESENTATION): a relationship written parent
 * first is taken inverted. Each representation's length unit (its context's) is honoured.
 * Cycles are broken with a note; depth and the total number of placed copies are bounded.
 */
#include "step_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define ASM_MAX_DEPTH 64
#define ASM_MAX_INSTANCES (1 << 20) /* placed groups, over the whole tree */
#define ASM_MAX_FACES 2000000       /* faces after instancing */

typedef double xform[3][4]; /* p' = R p + t: rows of [R | t] */

typedef struct asm_edge {
    int parent, child; /* representation indices */
    xform t;           /* child coordinates (mm) to parent coordinates (mm) */
    int ids[3]; /* entities naming this placement (relationship or MAPPED_ITEM, CDSR, NAUO; 0) */
} asm_edge;

typedef struct asm_inst {
    int group;
    xform m;    /* group coordinates (mm) to world (mm) */
    int parent; /* the instance this one was placed in, -1 for a root */
    int edge;   /* the placement (edge index) that put it there, -1 for a root */
} asm_inst;

typedef struct asm_state {
    step_reader *r;
    int *rep_of_entity; /* entity index -> representation index, -1 */
    int *item_rep;      /* entity index -> first link of the representations listing it, -1 */
    int *link_rep, *link_next; /* item links: representation, next link (-1) */
    size_t link_count, link_cap;
    int *rep_entity;  /* representation index -> entity index */
    double *rep_unit; /* mm per unit of the representation's context */
    int *parent;      /* union-find over representations */
    int rep_count;
    asm_edge *edges;
    size_t edge_count, edge_cap;
    int *first_edge, *edge_order; /* CSR of edges by parent group */
    int *on_path, *incoming;
    asm_inst *inst;
    size_t inst_count, inst_cap;
    int cycles;
} asm_state;

static void xf_identity(xform m)
{
    memset(m, 0, sizeof(xform));
    m[0][0] = m[1][1] = m[2][2] = 1;
}

static void xf_mul(xform a, xform b, xform dest)
{
    xform c;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++) {
            double s = j == 3 ? a[i][3] : 0;
            for (int k = 0; k < 3; k++)
                s += a[i][k] * b[k][j];
            c[i][j] = s;
        }
    memcpy(dest, c, sizeof c);
}

/* The frame of a placement (local -> containing coordinates), its origin scaled to mm. */
static void xf_frame(const crisp_placement *p, double unit, xform dest)
{
    for (int i = 0; i < 3; i++) {
        dest[i][0] = p->x[i];
        dest[i][1] = p->y[i];
        dest[i][2] = p->z[i];
        dest[i][3] = p->origin[i] * unit;
    }
}

/* Inverse of a rigid frame (orthonormal rotation). */
static void xf_frame_inverse(const crisp_placement *p, double unit, xform dest)
{
    const double *ax[3] = {p->x, p->y, p->z};
    for (int i = 0; i < 3; i++) {
        double t = 0;
        for (int k = 0; k < 3; k++) {
            dest[i][k] = ax[i][k];
            t += ax[i][k] * p->origin[k] * unit;
        }
        dest[i][3] = -t;
    }
}

static int xf_is_identity(xform m)
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 4; j++)
            if (fabs(m[i][j] - (i == j)) > 1e-14) return 0;
    return 1;
}

/* ---- representations ----------------------------------------------------------------------------
 */

/* The part of e that is a shape representation (name, items, context), or NULL. */
static const step_part *rep_part(const step_reader *r, const step_entity *e)
{
    for (uint32_t i = 0; i < e->part_count; i++) {
        const step_part *p = &r->f->parts[e->first_part + i];
        const char *n = r->f->text + p->name_off;
        size_t len = p->name_len;
        static const char suffix[] = "SHAPE_REPRESENTATION";
        size_t sl = sizeof suffix - 1;
        int is_rep = (len == 14 && !memcmp(n, "REPRESENTATION", 14)) ||
                     (len >= sl && !memcmp(n + len - sl, suffix, sl) &&
                      !(len == 38 && !memcmp(n, "CONTEXT_DEPENDENT_SHAPE_REPRESENTATION", 38)));
        if (!is_rep) continue;
        const step_value *items = crisp__step_param(r, p, 1);
        if (items && items->kind == STEP_LIST) return p;
    }
    return NULL;
}

static int find(asm_state *s, int a)
{
    while (s->parent[a] != a)
        a = s->parent[a] = s->parent[s->parent[a]];
    return a;
}

static int rep_index(asm_state *s, const step_entity *e)
{
    return e ? s->rep_of_entity[e - s->r->f->entities] : -1;
}

static crisp_status add_edge(asm_state *s, int parent, int child, xform t, int id0, int id1,
                             int id2)
{
    if (s->edge_count == s->edge_cap &&
        crisp_grow((void **)&s->edges, &s->edge_cap, s->edge_count + 1, sizeof *s->edges))
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", s->r->f->name);
    asm_edge *ed = &s->edges[s->edge_count++];
    ed->parent = parent;
    ed->child = child;
    memcpy(ed->t, t, sizeof(xform));
    ed->ids[0] = id0, ed->ids[1] = id1, ed->ids[2] = id2;
    return CRISP_OK;
}

/* A placement entity, read into p (errors become a note by the caller). */
static crisp_status placement(asm_state *s, const step_entity *e, crisp_placement *p)
{
    s->r->depth = 0;
    return crisp__step_placement(s->r, e, p);
}

/* A CARTESIAN_TRANSFORMATION_OPERATOR_3D (name, axis1, axis2, local_origin, scale, axis3) as the
 * map from coordinates in unit u_from to coordinates in unit u_to, both scaled to mm:
 * x' = o + scale (x e1 + y e2 + z e3), the axes derived as in ISO 10303-42 (e3 from axis3, e1 the
 * projection of axis1, e2 the projection of axis2: left-handed when axis2 says so, a mirror). */
static crisp_status cto_xform(asm_state *s, const step_entity *op, double u_from, double u_to,
                              xform t)
{
    step_reader *r = s->r;
    const step_part *cto = crisp__step_part(r, op, "CARTESIAN_TRANSFORMATION_OPERATOR_3D");
    if (!cto)
        return crisp__step_fail(r, op, CRISP_ERR_PARSE,
                                "expected a CARTESIAN_TRANSFORMATION_OPERATOR_3D");
    const step_value *v1 = crisp__step_param(r, cto, 1), *v2 = crisp__step_param(r, cto, 2);
    const step_value *v3 = crisp__step_param(r, cto, 5), *vs = crisp__step_param(r, cto, 4);
    const step_entity *oe, *de;
    double x[3], y[3], z[3], o[3], scale = 1, sv;
    const double *px = NULL, *py = NULL, *pz = NULL;
    crisp_status st;
    if ((st = crisp__step_get_ref(r, op, cto, 3, &oe)) || (st = crisp__step_point(r, oe, o, NULL)))
        return st;
    if (v1 && v1->kind == STEP_REF && !crisp__step_deref(r, op, v1, &de) &&
        !crisp__step_direction(r, de, x))
        px = x;
    if (v2 && v2->kind == STEP_REF && !crisp__step_deref(r, op, v2, &de) &&
        !crisp__step_direction(r, de, y))
        py = y;
    if (v3 && v3->kind == STEP_REF && !crisp__step_deref(r, op, v3, &de) &&
        !crisp__step_direction(r, de, z))
        pz = z;
    crisp_error_clear();
    if (vs && crisp__step_value_real(r, vs, &sv)) {
        if (!(sv > 0) || sv > 1e6)
            return crisp__step_fail(r, op, CRISP_ERR_NUMERIC, "scale %g: expected (0, 1e6]", sv);
        scale = sv;
    }
    double zz[3] = {0, 0, 1};
    crisp_placement pl;
    if (crisp_placement_make(o, pz ? pz : zz, px, &pl)) {
        crisp_error_clear();
        return crisp__step_fail(r, op, CRISP_ERR_NUMERIC, "axis1 parallel to axis3");
    }
    if (py) {
        double a = 0, b = 0, n = 0;
        for (int k = 0; k < 3; k++)
            a += py[k] * pl.z[k], b += py[k] * pl.x[k];
        for (int k = 0; k < 3; k++)
            y[k] = py[k] - a * pl.z[k] - b * pl.x[k], n += y[k] * y[k];
        n = sqrt(n);
        if (n > 1e-12)
            for (int k = 0; k < 3; k++)
                pl.y[k] = y[k] / n;
    }
    xf_frame(&pl, u_to, t);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            t[i][k] *= scale * u_to / u_from;
    return CRISP_OK;
}

/* MAPPED_ITEM(name, REPRESENTATION_MAP(origin, rep), target) in representation `rep`: the target
 * is a placement or a CARTESIAN_TRANSFORMATION_OPERATOR_3D. */
static crisp_status mapped_item(asm_state *s, const step_entity *e, int rep)
{
    step_reader *r = s->r;
    const step_part *p = crisp__step_part(r, e, "MAPPED_ITEM");
    const step_entity *map, *target, *origin, *child;
    crisp_placement po, pt;
    crisp_status st = crisp__step_get_ref(r, e, p, 1, &map);
    if (!st) st = crisp__step_get_ref(r, e, p, 2, &target);
    if (st) return st;
    const step_part *mp = crisp__step_part(r, map, "REPRESENTATION_MAP");
    if (!mp) return crisp__step_fail(r, map, CRISP_ERR_PARSE, "expected a REPRESENTATION_MAP");
    if ((st = crisp__step_get_ref(r, map, mp, 0, &origin)) ||
        (st = crisp__step_get_ref(r, map, mp, 1, &child)))
        return st;
    int c = rep_index(s, child);
    if (c < 0)
        return crisp__step_fail(r, map, CRISP_ERR_PARSE,
                                "parameter 2: expected a shape representation");
    xform a, b;
    if ((st = placement(s, origin, &po))) return st;
    if (crisp__step_is(r, target, "CARTESIAN_TRANSFORMATION_OPERATOR_3D")) {
        if ((st = cto_xform(s, target, s->rep_unit[c], s->rep_unit[rep], a))) return st;
    } else {
        if ((st = placement(s, target, &pt))) return st;
        xf_frame(&pt, s->rep_unit[rep], a);
    }
    xf_frame_inverse(&po, s->rep_unit[c], b);
    xf_mul(a, b, a);
    return add_edge(s, rep, c, a, e->id, 0, 0);
}

/* ---- product structure: which representation shows which product definition ------------------ */

/* The representation group of the product definition pd (through PRODUCT_DEFINITION_SHAPE and
 * SHAPE_DEFINITION_REPRESENTATION), or -1. pds_of: entity index of PD -> SDR's representation. */
static int pd_group(asm_state *s, const int *rep_of_pd, const step_entity *pd)
{
    if (!pd) return -1;
    int rp = rep_of_pd[pd - s->r->f->entities];
    return rp < 0 ? -1 : find(s, rp);
}

/* The NAUO's parent and child definitions behind a CDSR's represented_product_relation. */
static void nauo_ends(asm_state *s, const step_entity *pds, const step_entity **parent,
                      const step_entity **child)
{
    step_reader *r = s->r;
    *parent = *child = NULL;
    const step_part *p = crisp__step_part(r, pds, "PRODUCT_DEFINITION_SHAPE");
    const step_value *v = p ? crisp__step_param(r, p, 2) : NULL;
    const step_entity *n = v && v->kind == STEP_REF ? crisp__step_find(r->f, v->num) : NULL;
    const step_part *np = n ? crisp__step_part(r, n, "NEXT_ASSEMBLY_USAGE_OCCURRENCE") : NULL;
    if (!np) np = n ? crisp__step_part(r, n, "PRODUCT_DEFINITION_RELATIONSHIP") : NULL;
    if (!np) return;
    /* (id, name, description, relating, related, reference_designator) */
    const step_value *a = crisp__step_param(r, np, 3), *b = crisp__step_param(r, np, 4);
    if (a && a->kind == STEP_REF) *parent = crisp__step_find(r->f, a->num);
    if (b && b->kind == STEP_REF) *child = crisp__step_find(r->f, b->num);
}

/* 1 when a representation of group g lists item e. */
static int item_in_group(asm_state *s, const step_entity *e, int g)
{
    for (int l = s->item_rep[e - s->r->f->entities]; l >= 0; l = s->link_next[l])
        if (find(s, s->link_rep[l]) == g) return 1;
    return 0;
}

/* A representation relationship with a transformation (entity e): an edge. cdsr: the
 * CONTEXT_DEPENDENT_SHAPE_REPRESENTATION using it (NULL when none). */
static crisp_status placed_relation(asm_state *s, const step_entity *e, const step_entity *cdsr,
                                    const int *rep_of_pd)
{
    step_reader *r = s->r;
    const step_part *rr = crisp__step_part(r, e, "REPRESENTATION_RELATIONSHIP");
    if (!rr) rr = crisp__step_part(r, e, "SHAPE_REPRESENTATION_RELATIONSHIP");
    const step_part *rt = crisp__step_part(r, e, "REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION");
    const step_entity *r1, *r2, *op, *i1, *i2;
    crisp_status st;
    /* (AP209 writers give the relationship as a simple entity: name, description, rep_1, rep_2,
     * operator; trj9_ap209-mp.stp.) */
    int op_at = 0;
    if (!rr && rt && crisp__step_param(r, rt, 4)) rr = rt, op_at = 4;
    if (!rr || !rt)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE, "expected a REPRESENTATION_RELATIONSHIP");
    if ((st = crisp__step_get_ref(r, e, rr, 2, &r1)) ||
        (st = crisp__step_get_ref(r, e, rr, 3, &r2)) ||
        (st = crisp__step_get_ref(r, e, rt, op_at, &op)))
        return st;
    int a = rep_index(s, r1), b = rep_index(s, r2);
    if (a < 0 || b < 0)
        return crisp__step_fail(r, e, CRISP_ERR_PARSE, "expected two shape representations");
    /* rep_1 is the child by the recommended practice; the NAUO says otherwise when the parent's
     * representation is rep_1 and the child's rep_2. */
    int child = a, parent = b, nauo_id = 0;
    if (cdsr) {
        const step_part *cp = crisp__step_part(r, cdsr, "CONTEXT_DEPENDENT_SHAPE_REPRESENTATION");
        const step_value *v = crisp__step_param(r, cp, 1);
        const step_entity *pds = v && v->kind == STEP_REF ? crisp__step_find(r->f, v->num) : NULL,
                          *pp, *pc;
        if (pds) {
            const step_part *dp = crisp__step_part(r, pds, "PRODUCT_DEFINITION_SHAPE");
            const step_value *dv = dp ? crisp__step_param(r, dp, 2) : NULL;
            if (dv && dv->kind == STEP_REF && dv->num >= 1 && dv->num <= 2147483647.0)
                nauo_id = (int)dv->num;
            nauo_ends(s, pds, &pp, &pc);
            int gp = pd_group(s, rep_of_pd, pp), gc = pd_group(s, rep_of_pd, pc);
            if (gp >= 0 && gc >= 0 && gp == find(s, a) && gc == find(s, b)) child = b, parent = a;
        }
    }
    xform t;
    const step_part *idt = crisp__step_part(r, op, "ITEM_DEFINED_TRANSFORMATION");
    const step_part *cto = crisp__step_part(r, op, "CARTESIAN_TRANSFORMATION_OPERATOR_3D");
    if (idt) {
        /* The transformation takes the child's item onto the parent's: item 1 is the child's when
         * rep_1 is, unless the items say otherwise (some writers turn the representations round and
         * not the items: trj4_s1-ai-214.stp). */
        if ((st = crisp__step_get_ref(r, op, idt, 2, &i1)) ||
            (st = crisp__step_get_ref(r, op, idt, 3, &i2)))
            return st;
        const step_entity *ci = child == a ? i1 : i2, *pi = child == a ? i2 : i1;
        if (item_in_group(s, ci, find(s, parent)) && !item_in_group(s, ci, find(s, child)) &&
            item_in_group(s, pi, find(s, child)) && !item_in_group(s, pi, find(s, parent))) {
            const step_entity *tmp = ci;
            ci = pi, pi = tmp;
        }
        crisp_placement pc, pp;
        if ((st = placement(s, ci, &pc)) || (st = placement(s, pi, &pp))) return st;
        xform fp, fci;
        xf_frame(&pp, s->rep_unit[parent], fp);
        xf_frame_inverse(&pc, s->rep_unit[child], fci);
        xf_mul(fp, fci, t);
    } else if (cto) {
        /* rep_1 coordinates into rep_2's */
        if ((st = cto_xform(s, op, s->rep_unit[a], s->rep_unit[b], t))) return st;
        if (child != a) {
            /* rep_2 is the child: the inverse (a similarity: R^T / scale^2 inverts scale R) */
            xform inv;
            double s2 = 0;
            for (int k = 0; k < 3; k++)
                s2 += t[k][0] * t[k][0];
            for (int i = 0; i < 3; i++)
                for (int k = 0; k < 3; k++)
                    inv[i][k] = t[k][i] / s2;
            for (int i = 0; i < 3; i++)
                inv[i][3] = -(inv[i][0] * t[0][3] + inv[i][1] * t[1][3] + inv[i][2] * t[2][3]);
            memcpy(t, inv, sizeof t);
        }
    } else {
        return crisp__step_fail(
            r, op, CRISP_ERR_UNSUPPORTED,
            "expected an ITEM_DEFINED_TRANSFORMATION or CARTESIAN_TRANSFORMATION_OPERATOR_3D");
    }
    return add_edge(s, parent, child, t, e->id, cdsr ? cdsr->id : 0, nauo_id);
}

/* Note a relationship or mapped item that could not be read (the rest of the assembly stands). */
static crisp_status note(asm_state *s, crisp_status st, const char *what, int id)
{
    if (st == CRISP_OK || st == CRISP_ERR_NO_MEMORY) return st;
    const char *msg = crisp_error_message();
    size_t nl = strlen(s->r->f->name);
    if (strncmp(msg, s->r->f->name, nl) == 0 && msg[nl] == ':') msg += nl + 2;
    crisp_model_note_skipf(s->r->model, "STEP %s #%d ignored: %s", what, id, msg);
    crisp_error_clear();
    return CRISP_OK;
}

/* ---- the placement tree -----------------------------------------------------------------------
 */

static crisp_status place(asm_state *s, int g, xform m, int depth, int parent, int edge)
{
    if (s->inst_count >= ASM_MAX_INSTANCES)
        return crisp_error(CRISP_ERR_LIMIT,
                           "%s: the assembly places more than %d parts (instance explosion?)",
                           s->r->f->name, ASM_MAX_INSTANCES);
    if (depth > ASM_MAX_DEPTH)
        return crisp_error(CRISP_ERR_LIMIT,
                           "%s: assembly nested deeper than %d levels (at representation #%d)",
                           s->r->f->name, ASM_MAX_DEPTH, s->r->f->entities[s->rep_entity[g]].id);
    if (s->inst_count == s->inst_cap &&
        crisp_grow((void **)&s->inst, &s->inst_cap, s->inst_count + 1, sizeof *s->inst))
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", s->r->f->name);
    int self = (int)s->inst_count;
    s->inst[s->inst_count].group = g;
    memcpy(s->inst[s->inst_count].m, m, sizeof(xform));
    s->inst[s->inst_count].parent = parent;
    s->inst[s->inst_count].edge = edge;
    s->inst_count++;
    s->on_path[g] = 1;
    crisp_status st = CRISP_OK;
    for (int k = s->first_edge[g]; k < s->first_edge[g + 1] && !st; k++) {
        asm_edge *ed = &s->edges[s->edge_order[k]];
        int c = find(s, ed->child);
        if (s->on_path[c]) {
            s->cycles++;
            continue;
        }
        xform cm;
        xf_mul(m, ed->t, cm);
        st = place(s, c, cm, depth + 1, self, s->edge_order[k]);
    }
    s->on_path[g] = 0;
    return st;
}

/* How many placements the tree under group g makes (g included), saturating at the limit, so that
 * an instance explosion is refused before anything is placed. memo: -1 when not yet known. */
static double subtree_size(asm_state *s, double *memo, int g, int depth)
{
    if (memo[g] >= 0) return memo[g];
    if (depth > ASM_MAX_DEPTH) return ASM_MAX_INSTANCES + 1.0;
    double n = 1;
    s->on_path[g] = 1;
    for (int k = s->first_edge[g]; k < s->first_edge[g + 1] && n <= ASM_MAX_INSTANCES; k++) {
        int c = find(s, s->edges[s->edge_order[k]].child);
        if (!s->on_path[c]) n += subtree_size(s, memo, c, depth + 1);
    }
    s->on_path[g] = 0;
    return memo[g] = n > ASM_MAX_INSTANCES ? ASM_MAX_INSTANCES + 1.0 : n;
}

/* ---- faces --------------------------------------------------------------------------------------
 */

/* The representation holding face i (through its solid / surface model, its shell or set, or the
 * face itself) that the assembly places, or -1. An item can be listed by several representations
 * (a validation-property SHAPE_REPRESENTATION lists the solid too: trj3_as1-ac-214.stp). */
static int face_rep(asm_state *s, int face_id, const int *owner, const int *first_inst)
{
    int ids[3] = {owner[1], owner[0], face_id};
    for (int k = 0; k < 3; k++) {
        if (!ids[k]) continue;
        const step_entity *e = crisp__step_find(s->r->f, ids[k]);
        for (int l = e ? s->item_rep[e - s->r->f->entities] : -1; l >= 0; l = s->link_next[l]) {
            int g = find(s, s->link_rep[l]);
            if (first_inst[g + 1] > first_inst[g]) return s->link_rep[l];
        }
    }
    return -1;
}

static void state_free(asm_state *s)
{
    crisp_free(s->rep_of_entity);
    crisp_free(s->item_rep);
    crisp_free(s->link_rep);
    crisp_free(s->link_next);
    crisp_free(s->rep_entity);
    crisp_free(s->rep_unit);
    crisp_free(s->parent);
    crisp_free(s->edges);
    crisp_free(s->first_edge);
    crisp_free(s->edge_order);
    crisp_free(s->on_path);
    crisp_free(s->incoming);
    crisp_free(s->inst);
}

/* Build groups and edges; 0 edges means no assembly. */
static crisp_status build_graph(asm_state *s)
{
    step_reader *r = s->r;
    const step_file *f = r->f;
    size_t n = f->entity_count;
    crisp_status st = CRISP_OK;
    s->rep_of_entity = crisp_malloc_array(n + 1, sizeof(int));
    s->item_rep = crisp_malloc_array(n + 1, sizeof(int));
    int *rep_of_pd = crisp_malloc_array(n + 1, sizeof(int));
    if (!s->rep_of_entity || !s->item_rep || !rep_of_pd) {
        crisp_free(rep_of_pd);
        return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    }
    for (size_t i = 0; i < n; i++)
        s->rep_of_entity[i] = s->item_rep[i] = rep_of_pd[i] = -1;
    for (size_t i = 0; i < n; i++)
        if (rep_part(r, &f->entities[i])) s->rep_of_entity[i] = s->rep_count++;
    if (s->rep_count == 0) goto out;
    s->rep_entity = crisp_malloc_array((size_t)s->rep_count, sizeof(int));
    s->rep_unit = crisp_malloc_array((size_t)s->rep_count, sizeof(double));
    s->parent = crisp_malloc_array((size_t)s->rep_count, sizeof(int));
    if (!s->rep_entity || !s->rep_unit || !s->parent) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto out;
    }
    for (size_t i = 0; i < n; i++) {
        int k = s->rep_of_entity[i];
        if (k < 0) continue;
        s->rep_entity[k] = (int)i;
        s->parent[k] = k;
        const step_part *p = rep_part(r, &f->entities[i]);
        const step_value *ctx = crisp__step_param(r, p, 2);
        const step_entity *ce = ctx && ctx->kind == STEP_REF ? crisp__step_find(f, ctx->num) : NULL;
        double u = ce ? crisp__step_context_length_unit(r, ce) : 0;
        s->rep_unit[k] = u > 0 ? u : r->model->unit_to_mm;
    }
    /* Items; mapped items become edges. */
    for (size_t i = 0; i < n && !st; i++) {
        int k = s->rep_of_entity[i];
        if (k < 0) continue;
        const step_entity *e = &f->entities[i];
        const step_value *items = crisp__step_param(r, rep_part(r, e), 1);
        for (uint32_t j = 0; j < items->len && !st; j++) {
            const step_value *v = crisp__step_elem(r, items, j);
            const step_entity *it = v->kind == STEP_REF ? crisp__step_find(f, v->num) : NULL;
            if (!it) continue;
            size_t idx = (size_t)(it - f->entities);
            int listed = s->item_rep[idx] >= 0;
            if (s->link_count == s->link_cap) {
                size_t cap = s->link_cap;
                if (crisp_grow((void **)&s->link_rep, &cap, s->link_count + 1, sizeof(int)) ||
                    crisp_grow((void **)&s->link_next, &s->link_cap, s->link_count + 1,
                               sizeof(int))) {
                    st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
                    break;
                }
            }
            s->link_rep[s->link_count] = k;
            s->link_next[s->link_count] = s->item_rep[idx];
            s->item_rep[idx] = (int)s->link_count++;
            /* A mapped item listed by several representations (a CATIA writer lists each in the
             * occurrence's own SHAPE_REPRESENTATION and again in the top assembly's) places its
             * representation once, from the first. */
            if (!listed && crisp__step_is(r, it, "MAPPED_ITEM"))
                st = note(s, mapped_item(s, it, k), "mapped item", it->id);
        }
    }
    /* Identity relationships merge groups; definitions get their representation. */
    for (size_t i = 0; i < n && !st; i++) {
        const step_entity *e = &f->entities[i];
        const step_part *p;
        if (crisp__step_is(r, e, "REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION")) continue;
        if ((p = crisp__step_part(r, e, "REPRESENTATION_RELATIONSHIP")) ||
            (p = crisp__step_part(r, e, "SHAPE_REPRESENTATION_RELATIONSHIP"))) {
            const step_value *a = p ? crisp__step_param(r, p, 2) : NULL,
                             *b = p ? crisp__step_param(r, p, 3) : NULL;
            const step_entity *ea = a && a->kind == STEP_REF ? crisp__step_find(f, a->num) : NULL;
            const step_entity *eb = b && b->kind == STEP_REF ? crisp__step_find(f, b->num) : NULL;
            int x = rep_index(s, ea), y = rep_index(s, eb);
            if (x >= 0 && y >= 0) s->parent[find(s, x)] = find(s, y);
        }
    }
    for (size_t i = 0; i < n && !st; i++) {
        const step_entity *e = &f->entities[i];
        const step_part *p = crisp__step_part(r, e, "SHAPE_DEFINITION_REPRESENTATION");
        if (!p) continue;
        const step_value *a = crisp__step_param(r, p, 0), *b = crisp__step_param(r, p, 1);
        const step_entity *pds = a && a->kind == STEP_REF ? crisp__step_find(f, a->num) : NULL;
        const step_entity *rep = b && b->kind == STEP_REF ? crisp__step_find(f, b->num) : NULL;
        const step_part *pp = pds ? crisp__step_part(r, pds, "PRODUCT_DEFINITION_SHAPE") : NULL;
        const step_value *d = pp ? crisp__step_param(r, pp, 2) : NULL;
        const step_entity *pd = d && d->kind == STEP_REF ? crisp__step_find(f, d->num) : NULL;
        if (pd && rep_index(s, rep) >= 0 && rep_of_pd[pd - f->entities] < 0)
            rep_of_pd[pd - f->entities] = rep_index(s, rep);
    }
    /* Placed relationships, through their CDSR when there is one. */
    unsigned char *done = crisp_calloc_array(n + 1, 1);
    if (!done) st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
    for (size_t i = 0; i < n && !st; i++) {
        const step_entity *e = &f->entities[i], *rel;
        const step_part *p = crisp__step_part(r, e, "CONTEXT_DEPENDENT_SHAPE_REPRESENTATION");
        if (!p || crisp__step_get_ref(r, e, p, 0, &rel)) {
            crisp_error_clear();
            continue;
        }
        if (!crisp__step_is(r, rel, "REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION") ||
            done[rel - f->entities])
            continue;
        done[rel - f->entities] = 1;
        st = note(s, placed_relation(s, rel, e, rep_of_pd), "assembly placement", e->id);
    }
    for (size_t i = 0; i < n && !st; i++) {
        const step_entity *e = &f->entities[i];
        if (!done[i] && crisp__step_is(r, e, "REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION"))
            st = note(s, placed_relation(s, e, NULL, rep_of_pd), "assembly placement", e->id);
    }
    crisp_free(done);
out:
    crisp_free(rep_of_pd);
    return st;
}

/* ---- colours per occurrence --------------------------------------------------------------------
 * A copy can be coloured by its occurrence rather than its part (CAx-IF recommended practices for
 * colours on assemblies): a STYLED_ITEM (or OVER_RIDING_STYLED_ITEM) whose item is the occurrence
 * itself (its MAPPED_ITEM, NEXT_ASSEMBLY_USAGE_OCCURRENCE, placing relationship or
 * CONTEXT_DEPENDENT_SHAPE_REPRESENTATION) colours every face placed through it; a
 * CONTEXT_DEPENDENT_OVER_RIDING_STYLED_ITEM colours its item (a face, or a shell or solid: its
 * faces) in the copies whose placement path passes one of its style_context entries. The latter
 * wins over the former; along a path the outermost occurrence's style wins. */

#define OCC_CONTEXTS 8

typedef struct occ_style {
    int item;                   /* the styled entity's id */
    int contexts[OCC_CONTEXTS]; /* style_context ids (context-dependent styles only) */
    int ncontext;
    float rgb[3];
} occ_style;

static int placement_id(const step_reader *r, const step_entity *e)
{
    return crisp__step_is((step_reader *)r, e, "MAPPED_ITEM") ||
           crisp__step_is((step_reader *)r, e, "NEXT_ASSEMBLY_USAGE_OCCURRENCE") ||
           crisp__step_is((step_reader *)r, e, "CONTEXT_DEPENDENT_SHAPE_REPRESENTATION") ||
           crisp__step_is((step_reader *)r, e, "REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION");
}

/* Occurrence styles of the file: *occ (on occurrences) and *ctx (context dependent). */
static crisp_status occurrence_styles(asm_state *s, occ_style **occ, int *nocc, occ_style **ctx,
                                      int *nctx)
{
    step_reader *r = s->r;
    const step_file *f = r->f;
    size_t cap_o = 0, cap_c = 0;
    *occ = *ctx = NULL;
    *nocc = *nctx = 0;
    for (size_t i = 0; i < f->entity_count; i++) {
        const step_entity *e = &f->entities[i];
        const step_part *p = crisp__step_part(r, e, "CONTEXT_DEPENDENT_OVER_RIDING_STYLED_ITEM");
        int dependent = p != NULL;
        if (!p) p = crisp__step_part(r, e, "STYLED_ITEM");
        if (!p) p = crisp__step_part(r, e, "OVER_RIDING_STYLED_ITEM");
        if (!p) continue;
        const step_value *styles = crisp__step_param(r, p, 1), *item = crisp__step_param(r, p, 2);
        if (!item || item->kind != STEP_REF || !(item->num >= 1 && item->num <= 2147483647.0))
            continue;
        const step_entity *it = crisp__step_find(f, item->num);
        if (!it) continue;
        const step_value *cl = dependent ? crisp__step_param(r, p, 4) : NULL;
        if (!dependent && !placement_id(r, it)) continue; /* a part's own style: step_style.c */
        occ_style o = {.item = (int)item->num};
        if (!crisp__step_style_colour(r, styles, o.rgb)) continue;
        if (dependent) {
            uint32_t n = cl && cl->kind == STEP_LIST ? cl->len : 0;
            for (uint32_t j = 0; j < n && o.ncontext < OCC_CONTEXTS; j++) {
                const step_value *x = &f->values[cl->first + j];
                if (x->kind == STEP_REF && x->num >= 1 && x->num <= 2147483647.0)
                    o.contexts[o.ncontext++] = (int)x->num;
            }
            if (!o.ncontext) continue;
        }
        occ_style **list = dependent ? ctx : occ;
        int *count = dependent ? nctx : nocc;
        size_t *cap = dependent ? &cap_c : &cap_o;
        if ((size_t)*count == *cap &&
            crisp_grow((void **)list, cap, (size_t)*count + 1, sizeof **list))
            return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        (*list)[(*count)++] = o;
    }
    return CRISP_OK;
}

static int edge_has(const asm_edge *ed, int id)
{
    return id && (ed->ids[0] == id || ed->ids[1] == id || ed->ids[2] == id);
}

/* The colour of face (id, owners) in instance k, when an occurrence style gives one. */
static int occurrence_colour(const asm_state *s, int k, int face_id, const int *owners,
                             const occ_style *occ, int nocc, const occ_style *ctx, int nctx,
                             float rgb[3])
{
    int found = 0, dependent = 0;
    for (int i = k; i >= 0 && s->inst[i].edge >= 0; i = s->inst[i].parent) {
        const asm_edge *ed = &s->edges[s->inst[i].edge];
        for (int q = 0; q < nctx; q++) {
            const occ_style *o = &ctx[q];
            if (o->item != face_id && o->item != owners[0] && o->item != owners[1]) continue;
            for (int c = 0; c < o->ncontext; c++)
                if (edge_has(ed, o->contexts[c])) {
                    memcpy(rgb, o->rgb, sizeof o->rgb);
                    found = dependent = 1;
                }
        }
        for (int q = 0; q < nocc && !dependent; q++)
            if (edge_has(ed, occ[q].item)) {
                memcpy(rgb, occ[q].rgb, sizeof occ[q].rgb);
                found = 1;
            }
    }
    return found;
}

/* The assembly tree for the model: one occurrence per placed instance, named by the NAUO among
 * the entities of its placement (its name, else its id; "" for a root), parents first (place()
 * appends an instance after its parent). */
static crisp_status record_occurrences(asm_state *s)
{
    step_reader *r = s->r;
    crisp_model *m = r->model;
    int base = m->occurrence_count;
    crisp_status st = CRISP_OK;
    for (size_t k = 0; k < s->inst_count && !st; k++) {
        const asm_inst *in = &s->inst[k];
        char name[256] = "";
        int source = 0;
        for (int q = 0; in->edge >= 0 && q < 3 && !source; q++) {
            int id = s->edges[in->edge].ids[q];
            const step_entity *e = id ? crisp__step_find(r->f, id) : NULL;
            const step_part *np =
                e ? crisp__step_part(r, e, "NEXT_ASSEMBLY_USAGE_OCCURRENCE") : NULL;
            if (!np) continue;
            source = id;
            for (int a = 1; a >= 0 && !name[0]; a--) { /* name, else id */
                const step_value *v = crisp__step_param(r, np, a);
                if (v && v->kind == STEP_STRING && v->len > 0)
                    snprintf(name, sizeof name, "%.*s", (int)v->len, r->f->text + v->off);
            }
        }
        st = crisp_model_add_occurrence(m, name, in->parent >= 0 ? base + in->parent : -1, source,
                                        NULL);
    }
    return st;
}

crisp_status crisp__step_assembly(step_reader *r, const int *face_ids, const int *owners,
                                  int face_count)
{
    occ_style *occ = NULL, *ctx = NULL;
    int nocc = 0, nctx = 0;
    asm_state s = {.r = r};
    crisp_model *m = r->model;
    crisp_face *out = NULL;
    int *face_group = NULL, *first_inst = NULL, *inst_order = NULL;
    crisp_status st = build_graph(&s);
    if (st || s.edge_count == 0) goto done;
    const step_file *f = r->f;
    int g_count = s.rep_count;
    s.first_edge = crisp_calloc_array((size_t)g_count + 1, sizeof(int));
    s.edge_order = crisp_malloc_array(s.edge_count, sizeof(int));
    s.on_path = crisp_calloc_array((size_t)g_count, sizeof(int));
    s.incoming = crisp_calloc_array((size_t)g_count, sizeof(int));
    face_group = crisp_malloc_array((size_t)face_count + 1, sizeof(int));
    first_inst = crisp_calloc_array((size_t)g_count + 1, sizeof(int));
    if (!s.first_edge || !s.edge_order || !s.on_path || !s.incoming || !face_group || !first_inst) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    /* Edges grouped by parent group (counting sort), incoming counts by child group. */
    for (size_t k = 0; k < s.edge_count; k++) {
        s.first_edge[find(&s, s.edges[k].parent) + 1]++;
        s.incoming[find(&s, s.edges[k].child)]++;
    }
    for (int g = 0; g < g_count; g++)
        s.first_edge[g + 1] += s.first_edge[g];
    {
        int *fill = first_inst; /* borrowed as a cursor, cleared below */
        for (size_t k = 0; k < s.edge_count; k++) {
            int g = find(&s, s.edges[k].parent);
            s.edge_order[s.first_edge[g] + fill[g]++] = (int)k;
        }
        memset(first_inst, 0, ((size_t)g_count + 1) * sizeof(int));
    }
    /* Roots: groups that are some placement's parent and nobody's child. */
    xform id;
    xf_identity(id);
    double *memo = crisp_malloc_array((size_t)g_count, sizeof *memo), planned = 0;
    if (!memo) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    for (int g = 0; g < g_count; g++)
        memo[g] = -1;
    for (int g = 0; g < g_count; g++)
        if (find(&s, g) == g && !s.incoming[g] && s.first_edge[g + 1] > s.first_edge[g])
            planned += subtree_size(&s, memo, g, 0);
    crisp_free(memo);
    if (planned > ASM_MAX_INSTANCES) {
        st = crisp_error(CRISP_ERR_LIMIT,
                         "%s: the assembly structure places parts more than %d times, or nests "
                         "deeper than %d levels "
                         "(instance explosion or a malformed structure)",
                         f->name, ASM_MAX_INSTANCES, ASM_MAX_DEPTH);
        goto done;
    }
    for (int g = 0; g < g_count && !st; g++)
        if (find(&s, g) == g && !s.incoming[g] && s.first_edge[g + 1] > s.first_edge[g])
            st = place(&s, g, id, 0, -1, -1);
    if (st) goto done;
    if (s.cycles) {
        crisp_model_note_skipf(
            m, "STEP assembly cycle: %d placements of a part inside itself ignored", s.cycles);
    }
    int occ_base = m->occurrence_count;
    if ((st = record_occurrences(&s))) goto done;
    /* Instances by group (CSR). */
    inst_order = crisp_malloc_array(s.inst_count + 1, sizeof(int));
    if (!inst_order) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    for (size_t k = 0; k < s.inst_count; k++)
        first_inst[s.inst[k].group + 1]++;
    for (int g = 0; g < g_count; g++)
        first_inst[g + 1] += first_inst[g];
    {
        int *fill = s.on_path; /* all 0 again after place() */
        for (size_t k = 0; k < s.inst_count; k++) {
            int g = s.inst[k].group;
            inst_order[first_inst[g] + fill[g]++] = (int)k;
        }
    }
    /* Faces after instancing: a face of a placed group once per placement, any other once. */
    size_t total = 0;
    for (int i = 0; i < face_count; i++) {
        int rp = face_rep(&s, face_ids[i], owners + 2 * i, first_inst);
        int g = rp < 0 ? -1 : find(&s, rp);
        face_group[i] = g >= 0 && first_inst[g + 1] > first_inst[g] ? rp : -1;
        total += face_group[i] >= 0 ? (size_t)(first_inst[g + 1] - first_inst[g]) : 1;
    }
    if (total > ASM_MAX_FACES) {
        st = crisp_error(CRISP_ERR_LIMIT, "%s: the assembly places %zu faces (limit %d)", f->name,
                         total, ASM_MAX_FACES);
        goto done;
    }
    out = crisp_calloc_array(total + 1, sizeof *out);
    if (!out) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory", f->name);
        goto done;
    }
    if ((st = occurrence_styles(&s, &occ, &nocc, &ctx, &nctx))) goto done;
    size_t o = 0;
    for (int i = 0; i < face_count && !st; i++) {
        int rp = face_group[i];
        if (rp < 0) {
            out[o++] = m->faces[i];
            memset(&m->faces[i], 0, sizeof m->faces[i]);
            continue;
        }
        int g = find(&s, rp);
        /* Face coordinates are in the representation's unit, the model's in unit_to_mm. */
        double u_in = s.rep_unit[rp], u_out = m->unit_to_mm > 0 ? m->unit_to_mm : 1;
        for (int k = first_inst[g]; k < first_inst[g + 1] && !st; k++) {
            xform x;
            memcpy(x, s.inst[inst_order[k]].m, sizeof x);
            for (int a = 0; a < 3; a++) {
                for (int b = 0; b < 3; b++)
                    x[a][b] *= u_in / u_out;
                x[a][3] /= u_out;
            }
            if (k + 1 < first_inst[g + 1]) {
                if ((st = crisp_face_copy(&m->faces[i], &out[o]))) break;
            } else {
                out[o] = m->faces[i];
                memset(&m->faces[i], 0, sizeof m->faces[i]);
            }
            if (!xf_is_identity(x)) crisp_face_transform(&out[o], (const double(*)[4])x);
            out[o].occurrence = occ_base + inst_order[k] + 1;
            /* each placed copy of a shell or solid is a body of its own */
            if (out[o].body)
                out[o].body =
                    (int)(((unsigned)out[o].body * 2654435761u) ^ ((unsigned)inst_order[k] + 1u)) |
                    1;
            float rgb[3];
            if ((nocc || nctx) && occurrence_colour(&s, inst_order[k], face_ids[i], owners + 2 * i,
                                                    occ, nocc, ctx, nctx, rgb)) {
                out[o].has_color = 1;
                out[o].color[0] = rgb[0], out[o].color[1] = rgb[1], out[o].color[2] = rgb[2],
                out[o].color[3] = 1;
            }
            o++;
        }
    }
    if (st) {
        st = crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory placing assembly copies", f->name);
        for (size_t k = 0; k < o; k++)
            crisp_face_free(&out[k]);
        goto done;
    }
    /* The model takes the new face array (faces not moved are empty now). */
    for (int i = 0; i < m->face_count; i++)
        crisp_face_free(&m->faces[i]);
    crisp_free(m->faces);
    m->faces = out;
    m->face_count = (int)o;
    m->face_cap = (int)total + 1;
    out = NULL;
done:
    crisp_free(occ);
    crisp_free(ctx);
    crisp_free(out);
    crisp_free(face_group);
    crisp_free(first_inst);
    crisp_free(inst_order);
    state_free(&s);
    return st;
}
