/* crisp-view's show / hide: faces (Delete hides the selected one) and f-rep parts (the Parts
 * panel). What is drawn is a shallow copy of the document (rdoc) whose scene is prepared from the
 * visible faces only (their structs copied, surfaces and loops shared with the document, which
 * outlives it); picking maps the drawn scene's face indices back to the document's. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ui.h"
#include "view.h"

static void list_bodies(view *v);

void view_visible_free(view *v)
{
    crisp_scene_destroy(v->vis_scene);
    free(v->vis_model.faces); /* shallow: the faces' surfaces and loops belong to the document */
    free(v->vis_map);
    free(v->vis_parts);
    crisp_scene_destroy(v->trans_scene);
    free(v->trans_model.faces);
    v->trans_scene = NULL;
    memset(&v->trans_model, 0, sizeof v->trans_model);
    memset(&v->tdoc, 0, sizeof v->tdoc);
    v->vis_scene = NULL;
    memset(&v->vis_model, 0, sizeof v->vis_model);
    v->vis_map = NULL;
    v->vis_parts = NULL;
}

void view_visible_reset(view *v)
{
    view_visible_free(v);
    free(v->face_hidden);
    free(v->part_hidden);
    v->face_hidden = v->part_hidden = NULL;
    v->hidden_faces = v->hidden_parts = 0;
    list_bodies(v);
    if (v->doc) {
        v->rdoc = *v->doc;
        v->face_hidden = calloc(v->doc->scene->face_count + 1, 1);
        v->part_hidden = calloc(v->doc->part_count + 1, 1);
    } else {
        memset(&v->rdoc, 0, sizeof v->rdoc);
    }
}

void view_visible_update(view *v)
{
    if (!v->doc || !v->face_hidden || !v->part_hidden) return;
    view_visible_free(v);
    const crisp_scene *full = v->doc->scene;
    v->rdoc = *v->doc;
    v->hidden_faces = v->hidden_parts = v->trans_faces = 0;
    for (uint32_t f = 0; f < full->face_count; f++) {
        v->hidden_faces += v->face_hidden[f] == 1;
        v->trans_faces += v->face_hidden[f] == 2;
    }
    for (size_t k = 0; k < v->doc->part_count; k++)
        v->hidden_parts += v->part_hidden[k];
    crisp_status st = CRISP_OK;
    if (v->hidden_faces || v->trans_faces) {
        const crisp_model *m = full->model;
        uint32_t n = full->face_count - v->hidden_faces - v->trans_faces;
        v->vis_model = *m;
        v->vis_model.faces = calloc(n + 1, sizeof *v->vis_model.faces);
        v->vis_model.face_count = v->vis_model.face_cap = (int)n;
        v->vis_model.skip_count = 0;
        v->vis_model.skips = NULL;
        v->vis_map = calloc(n + 1, sizeof *v->vis_map);
        if (!v->vis_model.faces || !v->vis_map) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
        } else {
            uint32_t k = 0;
            for (uint32_t f = 0; f < full->face_count; f++)
                if (!v->face_hidden[f]) {
                    v->vis_model.faces[k] = m->faces[f];
                    v->vis_map[k++] = f;
                }
            st = crisp_scene_prepare(&v->vis_model, &v->vis_scene);
        }
        if (!st) v->rdoc.scene = v->vis_scene;
    }
    if (!st && v->trans_faces) { /* the transparent faces: a scene of their own */
        const crisp_model *m = full->model;
        v->trans_model = *m;
        v->trans_model.faces = calloc(v->trans_faces + 1, sizeof *v->trans_model.faces);
        v->trans_model.face_count = v->trans_model.face_cap = (int)v->trans_faces;
        v->trans_model.skip_count = 0;
        v->trans_model.skips = NULL;
        if (!v->trans_model.faces) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
        } else {
            uint32_t k = 0;
            for (uint32_t f = 0; f < full->face_count; f++)
                if (v->face_hidden[f] == 2) v->trans_model.faces[k++] = m->faces[f];
            st = crisp_scene_prepare(&v->trans_model, &v->trans_scene);
        }
        if (!st) {
            v->tdoc = *v->doc;
            v->tdoc.scene = v->trans_scene;
            v->tdoc.parts = NULL;
            v->tdoc.part_count = 0;
        }
    }
    if (!st && v->hidden_parts) {
        v->vis_parts = calloc(v->doc->part_count + 1, sizeof *v->vis_parts);
        if (!v->vis_parts) {
            st = crisp_error(CRISP_ERR_NO_MEMORY, "out of memory");
        } else {
            size_t k = 0;
            for (size_t i = 0; i < v->doc->part_count; i++)
                if (!v->part_hidden[i]) v->vis_parts[k++] = v->doc->parts[i];
            v->rdoc.parts = v->vis_parts;
            v->rdoc.part_count = k;
        }
    }
    if (st) {
        view_set_error(v, "hiding: %s", crisp_error_message());
        view_visible_free(v);
        v->rdoc = *v->doc;
    }
    v->backend.set_doc(v->backend.self, &v->rdoc);
    v->ov.selected_face = v->sel.hit ? view_drawn_face(v, v->sel.face) : -1;
    v->dirty = 1;
    printf("visible: %u of %u faces (%u transparent), %zu of %zu f-rep parts\n",
           full->face_count - v->hidden_faces, full->face_count, v->trans_faces, v->rdoc.part_count,
           v->doc->part_count);
}

int32_t view_doc_face(const view *v, int32_t drawn)
{
    if (drawn < 0 || !v->vis_map) return drawn;
    return (int32_t)v->vis_map[drawn];
}

int32_t view_drawn_face(const view *v, int32_t doc_face)
{
    if (doc_face < 0 || !v->vis_map) return doc_face;
    if (v->face_hidden[doc_face]) return -1;
    int32_t k = 0;
    for (int32_t f = 0; f < doc_face; f++)
        k += !v->face_hidden[f];
    return k;
}

/* Bodies: the readers give faces of one shell or solid (one placed copy of it in an assembly)
 * a shared non-zero crisp_face.body; the Parts panel shows and hides them whole. */
static void list_bodies(view *v)
{
    free(v->body_ids);
    v->body_ids = NULL;
    v->body_count = 0;
    if (!v->doc) return;
    const crisp_model *m = v->doc->scene->model;
    v->body_ids = calloc((size_t)m->face_count + 1, sizeof *v->body_ids);
    if (!v->body_ids) return;
    for (int f = 0; f < m->face_count; f++) {
        int b = m->faces[f].body, seen = 0;
        if (!b) continue;
        for (int k = v->body_count - 1; k >= 0 && !seen; k--)
            seen = v->body_ids[k] == b;
        if (!seen) v->body_ids[v->body_count++] = b;
    }
}

int view_body_faces(const view *v, int index, int *shown)
{
    if (index < 1 || index > v->body_count) return 0;
    int body = v->body_ids[index - 1];
    const crisp_model *m = v->doc->scene->model;
    int n = 0, vis = 0;
    for (int f = 0; f < m->face_count; f++)
        if (m->faces[f].body == body) {
            n++;
            vis += v->face_hidden[f] != 1;
        }
    if (shown) *shown = vis > 0;
    return n;
}

void view_body_show(view *v, int index, int show)
{
    if (index < 1 || index > v->body_count) return;
    int body = v->body_ids[index - 1];
    const crisp_model *m = v->doc->scene->model;
    for (int f = 0; f < m->face_count; f++)
        if (m->faces[f].body == body) v->face_hidden[f] = show ? 0 : 1;
    printf("body: %d %s (%d faces)\n", index, show ? "shown" : "hidden",
           view_body_faces(v, index, NULL));
    view_visible_update(v);
}

/* The assembly tree (crisp_model.occurrences; STEP product occurrences): a face copy belongs to
 * occurrence k's subtree when k is its occurrence or one of that one's ancestors. */
static int in_subtree(const crisp_model *m, int occ, int k)
{
    for (int q = occ - 1, depth = 0; q >= 0 && depth <= m->occurrence_count; depth++) {
        if (q == k) return 1;
        q = m->occurrences[q].parent;
    }
    return 0;
}

int view_occurrence_faces(const view *v, int k, int *shown)
{
    const crisp_model *m = v->doc->scene->model;
    int n = 0, vis = 0;
    if (k < 0 || k >= m->occurrence_count) return 0;
    for (int f = 0; f < m->face_count; f++)
        if (in_subtree(m, m->faces[f].occurrence, k)) {
            n++;
            vis += v->face_hidden[f] != 1;
        }
    if (shown) *shown = vis > 0;
    return n;
}

void view_occurrence_show(view *v, int k, int show)
{
    const crisp_model *m = v->doc->scene->model;
    if (k < 0 || k >= m->occurrence_count) return;
    for (int f = 0; f < m->face_count; f++)
        if (in_subtree(m, m->faces[f].occurrence, k)) v->face_hidden[f] = show ? 0 : 1;
    printf("occurrence: %d %s %s (%d faces)\n", k + 1, m->occurrences[k].name,
           show ? "shown" : "hidden", view_occurrence_faces(v, k, NULL));
    view_visible_update(v);
}

/* The children of occurrence `parent` (-1: the roots) as tree nodes with a show checkbox; returns
 * 1 when something was toggled (the scene was rebuilt: stop drawing). */
static int occurrence_nodes(view *v, int parent, int depth)
{
    const crisp_model *m = v->doc->scene->model;
    for (int k = 0; k < m->occurrence_count; k++) {
        if (m->occurrences[k].parent != parent) continue;
        int leaf = 1;
        for (int c = k + 1; c < m->occurrence_count && leaf; c++)
            leaf = m->occurrences[c].parent != k;
        int shown, n = view_occurrence_faces(v, k, &shown);
        char label[320];
        snprintf(label, sizeof label, "##occ%d", k);
        if (app_ui_checkbox(label, &shown)) {
            view_occurrence_show(v, k, shown);
            return 1;
        }
        app_ui_same_line();
        snprintf(label, sizeof label, "%s (%d faces)##node%d",
                 m->occurrences[k].name[0] ? m->occurrences[k].name : "(root)", n, k);
        if (app_ui_tree_node(label, leaf, 0, NULL)) {
            int stop = !leaf && depth < 64 && occurrence_nodes(v, k, depth + 1);
            app_ui_tree_pop();
            if (stop) return 1;
        }
    }
    return 0;
}

void view_parts_panel(view *v)
{
    if (!v->doc) return;
    if (app_ui_begin("Parts", 10, -200, 0, 0)) {
        int changed = 0;
        if (app_ui_tree_node(v->doc->path, 0, 0, NULL)) {
            char label[128];
            snprintf(label, sizeof label, "faces: %u shown, %u hidden##faces",
                     v->doc->scene->face_count - v->hidden_faces, v->hidden_faces);
            app_ui_tree_node(label, 1, 0, NULL);
            /* the assembly tree, when the file has one */
            if (v->doc->scene->model->occurrence_count && occurrence_nodes(v, -1, 0)) {
                app_ui_tree_pop();
                app_ui_end();
                return;
            }
            /* the bodies (solids and shells; each placed copy in an assembly), at most 256 */
            for (int b = 1; b <= v->body_count && b <= 256; b++) {
                int shown, n = view_body_faces(v, b, &shown);
                snprintf(label, sizeof label, "body %d (%d faces)", b, n);
                if (app_ui_checkbox(label, &shown)) {
                    view_body_show(v, b, shown);
                    app_ui_tree_pop();
                    app_ui_end();
                    return;
                }
            }
            for (size_t k = 0; k < v->doc->part_count; k++) {
                int shown = !v->part_hidden[k];
                snprintf(label, sizeof label, "f-rep part %zu", k);
                if (app_ui_checkbox(label, &shown)) {
                    v->part_hidden[k] = !shown;
                    changed = 1;
                }
            }
            app_ui_tree_pop();
        }
        if (v->trans_faces) app_ui_text("transparent faces: %u (G, shift+G)", v->trans_faces);
        if ((v->hidden_faces || v->trans_faces) && app_ui_button("Show all faces (U)")) {
            memset(v->face_hidden, 0, v->doc->scene->face_count);
            changed = 1;
        }
        if (changed) view_visible_update(v);
    }
    app_ui_end();
}
