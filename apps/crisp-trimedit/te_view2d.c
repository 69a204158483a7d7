/* The trim-editing demo's 2D view (te_app.h, te_app_draw_2d): the face's (u, v) domain with its
 * trim loops (red when flagged as crossing), their knots, control polygons and points (larger for
 * larger weights; the selected or dragged one filled), a polygon hole being drawn, and the
 * v-strips and scan lines of the current frame plan's u-intercept table for the edited face, as
 * lines and circles in window pixels clipped to the view.
 */
#include <math.h>

#include "te_app.h"

/* Clip the segment p-q to the 2D view (Liang-Barsky); 0 when nothing is left. */
static int clip_to_view(const te_rect *r, double p[2], double q[2])
{
    double t0 = 0, t1 = 1, dx = q[0] - p[0], dy = q[1] - p[1];
    const double pk[4] = {-dx, dx, -dy, dy};
    const double qk[4] = {p[0] - r->x, r->x + r->w - p[0], p[1] - r->y, r->y + r->h - p[1]};
    for (int k = 0; k < 4; k++) {
        if (pk[k] == 0) {
            if (qk[k] < 0) return 0;
            continue;
        }
        double t = qk[k] / pk[k];
        if (pk[k] < 0) {
            if (t > t1) return 0;
            if (t > t0) t0 = t;
        } else {
            if (t < t0) return 0;
            if (t < t1) t1 = t;
        }
    }
    double a[2] = {p[0] + t0 * dx, p[1] + t0 * dy}, b[2] = {p[0] + t1 * dx, p[1] + t1 * dy};
    p[0] = a[0], p[1] = a[1], q[0] = b[0], q[1] = b[1];
    return 1;
}

static void line_uv(te_app *app, const te_draw *d, const double a[2], const double b[2],
                    uint32_t color, double width)
{
    double p[2], q[2];
    te_app_uv_to_px(app, a, p);
    te_app_uv_to_px(app, b, q);
    if (clip_to_view(&app->view2d, p, q)) d->line(d->ctx, p[0], p[1], q[0], q[1], color, width);
}

static void circle_px(te_app *app, const te_draw *d, const double px[2], double r, uint32_t color,
                      int filled)
{
    const te_rect *v = &app->view2d;
    if (px[0] - r >= v->x && px[0] + r <= v->x + v->w && px[1] - r >= v->y &&
        px[1] + r <= v->y + v->h)
        d->circle(d->ctx, px[0], px[1], r, color, filled);
}

long te_app_draw_2d(te_app *app, const te_draw *d)
{
    double dom[4];
    crisp_trimedit_domain(app->ed, dom);
    const double c00[2] = {dom[0], dom[2]}, c10[2] = {dom[1], dom[2]}, c11[2] = {dom[1], dom[3]},
                 c01[2] = {dom[0], dom[3]};
    const uint32_t grey = 0xff808080u;
    line_uv(app, d, c00, c10, grey, 1);
    line_uv(app, d, c10, c11, grey, 1);
    line_uv(app, d, c11, c01, grey, 1);
    line_uv(app, d, c01, c00, grey, 1);
    long scan_lines = 0;
    const crisp_frame_plan *plan = app->plan;
    if (plan && (uint32_t)app->face < plan->face_count) {
        const crisp_plan_face *pf = &plan->faces[app->face];
        for (uint32_t s = 0; s < pf->strip_count; s++) {
            const crisp_plan_strip *st = &plan->strips[pf->first_strip + s];
            double v = pf->v0 + s / pf->strip_scale;
            if (app->show_strips) {
                const double a[2] = {dom[0], v}, b[2] = {dom[1], v};
                line_uv(app, d, a, b, 0xc0c08040u, 1.5);
            }
            if (!app->show_scanlines || !st->row_count) continue;
            double spacing = app->uv_scale / st->row_scale; /* pixels between scan lines */
            uint32_t every = spacing >= 3 ? 1 : (uint32_t)ceil(3 / spacing);
            for (uint32_t j = 0; j < st->row_count; j += every) {
                double vs = st->a + (j + 0.5) / st->row_scale;
                const double a[2] = {dom[0], vs}, b[2] = {dom[1], vs};
                line_uv(app, d, a, b, 0x40a0a0a0u, 1);
                scan_lines++;
            }
        }
        if (app->show_strips && pf->strip_count) {
            const double a[2] = {dom[0], pf->v1}, b[2] = {dom[1], pf->v1};
            line_uv(app, d, a, b, 0xc0c08040u, 1.5);
        }
    }
    const crisp_trimedit_report *rep = crisp_trimedit_check(app->ed);
    const crisp_face *f = crisp_trimedit_face(app->ed);
    for (int l = 0; l < f->loop_count; l++) {
        int bad = l < 64 && rep->flags[l];
        uint32_t color = bad ? 0xff3030ffu : f->loops[l].is_outer ? 0xff40e0ffu : 0xffffd040u;
        for (int c = 0; c < f->loops[l].curve_count; c++) {
            const crisp_curve *cv = f->loops[l].curves[c];
            const int p = cv->degree;
            /* The curve, span by span, and its knots. */
            for (int k = p; k < cv->count; k++) {
                double a = cv->knots[k], b = cv->knots[k + 1];
                if (!(a < b)) continue;
                int n = 12 * p;
                double q0[2], q1[2], px[2];
                crisp_curve_eval(cv, a, q0);
                te_app_uv_to_px(app, q0, px);
                circle_px(app, d, px, 2.0, 0xff2080ffu, 1);
                for (int i = 1; i <= n; i++) {
                    crisp_curve_eval(cv, a + (b - a) * i / n, q1);
                    line_uv(app, d, q0, q1, color, 2);
                    q0[0] = q1[0];
                    q0[1] = q1[1];
                }
            }
            /* Control polygon and points (radius grows with the weight). */
            for (int i = 0; i < cv->count; i++) {
                double uv[2], w, px[2];
                crisp_trimedit_point(app->ed, (crisp_trimedit_ref){l, c, i}, uv, &w);
                if (i + 1 < cv->count) {
                    double uv2[2];
                    crisp_trimedit_point(app->ed, (crisp_trimedit_ref){l, c, i + 1}, uv2, NULL);
                    line_uv(app, d, uv, uv2, 0x80c0c0c0u, 1);
                }
                te_app_uv_to_px(app, uv, px);
                int active = (app->drag == TE_DRAG_POINT && app->drag_ref.loop == l &&
                              app->drag_ref.curve == c && app->drag_ref.index == i) ||
                             (app->drag == TE_DRAG_NONE && app->has_sel && app->sel.loop == l &&
                              app->sel.curve == c && app->sel.index == i);
                double rad = fmin(9.0, fmax(2.5, 3.5 * sqrt(w)));
                circle_px(app, d, px, rad, active ? 0xff00ffffu : 0xffffffffu, active);
            }
        }
    }
    if (app->poly) {
        /* The polygon being drawn, and the edge to the cursor. */
        for (int k = 0; k < app->poly_n; k++) {
            double px[2];
            te_app_uv_to_px(app, app->poly_uv + 2 * k, px);
            circle_px(app, d, px, 3.5, 0xff40ff40u, 1);
            if (k + 1 < app->poly_n)
                line_uv(app, d, app->poly_uv + 2 * k, app->poly_uv + 2 * k + 2, 0xff40ff40u, 1.5);
        }
        if (app->poly_n > 0) {
            double cur[2];
            te_app_px_to_uv(app, app->cursor, cur);
            line_uv(app, d, app->poly_uv + 2 * (app->poly_n - 1), cur, 0x8040ff40u, 1);
        }
    }
    return scan_lines;
}
