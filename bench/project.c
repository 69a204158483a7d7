/* Benchmark of crisp_surface_project_curve: the cost of turning 3D edges into uv trim curves, as
 * a reader does for faces whose file gives no pcurves. A synthetic model with ~2,000 edges of the
 * kinds real files hold: circles and lines on cylinders, arcs and meridians (pole to pole) on
 * spheres, arcs on tori, u and v iso-curves on bicubic B-spline surfaces.
 * Prints per-kind time per edge (median over runs) and the total for 2,000 edges.
 * Usage: bench_project [runs] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "bench_util.h"
#include "crisp/construct.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct edge_set {
    const char *name;
    crisp_surface *s;
    crisp_curve *c[64];
    int n;
} edge_set;

/* The exact iso-curve of a non-rational surface: u = const (dir 0) or v = const (dir 1). Each
 * control point of the iso-curve is a row (column) of the net evaluated as a curve at the value. */
static crisp_curve *iso_curve(const crisp_surface *s, int dir, double x)
{
    int n_along = dir ? s->count_u : s->count_v, n_across = dir ? s->count_v : s->count_u;
    double row[3 * 64], pts[3 * 64];
    for (int j = 0; j < n_along; j++) {
        for (int i = 0; i < n_across; i++) {
            int idx = dir ? i * s->count_u + j : j * s->count_u + i;
            for (int k = 0; k < 3; k++)
                row[3 * i + k] = s->cpw[4 * idx + k];
        }
        crisp_curve *r = NULL;
        crisp_curve_create(3, dir ? s->degree_v : s->degree_u, n_across,
                           dir ? s->knots_v : s->knots_u, row, NULL, &r);
        crisp_curve_eval(r, x, pts + 3 * j);
        crisp_curve_destroy(r);
    }
    crisp_curve *c = NULL;
    crisp_curve_create(3, dir ? s->degree_u : s->degree_v, n_along, dir ? s->knots_u : s->knots_v,
                       pts, NULL, &c);
    return c;
}

/* Thread CPU seconds: leaves out the time spent waiting for a core on a shared machine. */
static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv)
{
    int runs = argc > 1 ? atoi(argv[1]) : 5;
    if (runs < 1) runs = 1;
    bench_print_machine(stdout);
    double o[3] = {0, 0, 0}, z[3] = {0, 0, 1};
    crisp_placement pl;
    crisp_placement_make(o, z, NULL, &pl);
    edge_set sets[5] = {{.name = "cylinder circles+lines"},
                        {.name = "sphere arcs+meridians"},
                        {.name = "torus arcs"},
                        {.name = "bicubic iso-curves u, v"},
                        {.name = "circles 1e-3 off cylinder"}};
    /* Cylinder r = 10, height 0..20: full circles, half circles across the seam, lines. */
    crisp_make_cylinder(&pl, 10, 0, 2 * M_PI, 0, 20, &sets[0].s);
    for (int k = 0; k < 16; k++) {
        double c[3] = {0, 0, 1 + k}, x[3] = {1, 0, 0}, y[3] = {0, 1, 0};
        double a0 = k % 2 ? 0 : 4.0, a1 = k % 2 ? 2 * M_PI : 4.0 + M_PI;
        crisp_make_arc(3, c, x, y, 10, 10, a0, a1, &sets[0].c[sets[0].n++]);
        double p0[3] = {10 * cos(k * 0.4), 10 * sin(k * 0.4), 0.5}, p1[3] = {p0[0], p0[1], 19.5};
        crisp_make_line(3, p0, p1, 0, 19, &sets[0].c[sets[0].n++]);
    }
    /* Sphere r = 5: latitude arcs and meridians from pole to pole. */
    crisp_make_sphere(&pl, 5, 0, 2 * M_PI, -M_PI / 2, M_PI / 2, &sets[1].s);
    for (int k = 0; k < 16; k++) {
        double lat = -1.2 + 0.15 * k, c[3] = {0, 0, 5 * sin(lat)}, x[3] = {1, 0, 0},
               y[3] = {0, 1, 0};
        crisp_make_arc(3, c, x, y, 5 * cos(lat), 5 * cos(lat), 0.3 * k, 0.3 * k + 2.5,
                       &sets[1].c[sets[1].n++]);
        double mx[3] = {cos(0.37 * k), sin(0.37 * k), 0};
        crisp_make_arc(3, o, mx, z, 5, 5, -M_PI / 2, M_PI / 2, &sets[1].c[sets[1].n++]);
    }
    /* Torus R = 8, r = 2: minor circles and major arcs. */
    crisp_make_torus(&pl, 8, 2, 0, 2 * M_PI, 0, 2 * M_PI, &sets[2].s);
    for (int k = 0; k < 16; k++) {
        double a = 0.39 * k, rx[3] = {cos(a), sin(a), 0}, c[3] = {8 * rx[0], 8 * rx[1], 0};
        crisp_make_arc(3, c, rx, z, 2, 2, 0, 2 * M_PI, &sets[2].c[sets[2].n++]);
        double v = 0.4 * k, cc[3] = {0, 0, 2 * sin(v)}, x[3] = {1, 0, 0}, y[3] = {0, 1, 0};
        crisp_make_arc(3, cc, x, y, 8 + 2 * cos(v), 8 + 2 * cos(v), 1, 4, &sets[2].c[sets[2].n++]);
    }
    /* Bicubic 8 x 8 wavy surface over [0, 1]^2. */
    {
        double ku[12] = {0, 0, 0, 0, 0.2, 0.4, 0.6, 0.8, 1, 1, 1, 1}, pts[3 * 64];
        for (int j = 0; j < 8; j++)
            for (int i = 0; i < 8; i++) {
                pts[3 * (8 * j + i)] = 10.0 * i / 7;
                pts[3 * (8 * j + i) + 1] = 10.0 * j / 7;
                pts[3 * (8 * j + i) + 2] = 2 * sin(1.3 * i) * cos(0.9 * j);
            }
        crisp_surface_create(3, 3, 8, 8, ku, ku, pts, NULL, &sets[3].s);
        for (int k = 0; k < 32; k++)
            sets[3].c[sets[3].n++] = iso_curve(sets[3].s, k % 2, 0.03 + 0.03 * k);
    }
    /* Circles 1e-3 off the cylinder (100 x tol): as edges of files with loose tolerances. */
    crisp_make_cylinder(&pl, 10, 0, 2 * M_PI, 0, 20, &sets[4].s);
    for (int k = 0; k < 16; k++) {
        double c[3] = {0, 0, 1 + k}, x[3] = {1, 0, 0}, y[3] = {0, 1, 0};
        crisp_make_arc(3, c, x, y, 10.001, 10.001, 0.1 * k, 0.1 * k + 3, &sets[4].c[sets[4].n++]);
    }
    const double tol = 1e-5; /* 1e-6 of the part size, a typical modelling tolerance */
    int per_set = 500;       /* 4 x 500 = 2,000 edges (the fifth kind is extra) */
    printf("tol %g, %d edges per kind, median of %d runs of thread CPU "
           "time\n",
           tol, per_set, runs);
    printf("%-26s %12s %10s %12s\n", "kind", "us/edge", "spans/edge", "max 3D err");
    double total = 0;
    for (int s = 0; s < 5; s++) {
        double *times = calloc((size_t)runs, sizeof *times), spans = 0, worst = 0;
        for (int r = 0; r < runs; r++) {
            double t0 = cpu_now();
            for (int e = 0; e < per_set; e++) {
                const crisp_curve *c = sets[s].c[e % sets[s].n];
                double a, b;
                crisp_curve_domain(c, &a, &b);
                crisp_curve *uv = NULL;
                if (crisp_surface_project_curve(sets[s].s, c, a, b, tol, &uv)) {
                    printf("  %s edge %d failed: %s\n", sets[s].name, e % sets[s].n,
                           crisp_error_message());
                    continue;
                }
                if (r == 0) {
                    spans += (uv->count - 1) / 3.0;
                    double dom[4];
                    crisp_surface_domain(sets[s].s, dom);
                    for (int i = 0; i <= 200; i++) {
                        double t = a + (b - a) * i / 200.0, q[2], p[3], x[3];
                        crisp_curve_eval(uv, t, q);
                        double pu = dom[1] - dom[0];
                        if (s != 3) q[0] = dom[0] + fmod(fmod(q[0] - dom[0], pu) + pu, pu);
                        if (s == 2) q[1] = dom[2] + fmod(fmod(q[1] - dom[2], pu) + pu, pu);
                        crisp_surface_eval(sets[s].s, q[0], q[1], p);
                        crisp_curve_eval(c, t, x);
                        double d =
                            sqrt((p[0] - x[0]) * (p[0] - x[0]) + (p[1] - x[1]) * (p[1] - x[1]) +
                                 (p[2] - x[2]) * (p[2] - x[2]));
                        if (d > worst) worst = d;
                    }
                }
                crisp_curve_destroy(uv);
            }
            times[r] = cpu_now() - t0;
        }
        qsort(times, (size_t)runs, sizeof *times, bench_cmp_double);
        double med = times[runs / 2];
        if (s < 4) total += med;
        printf("%-26s %12.1f %10.2f %12.2e\n", sets[s].name, 1e6 * med / per_set, spans / per_set,
               worst);
        free(times);
    }
    printf("total for the first %d edges: %.3f s\n", 4 * per_set, total);
    for (int s = 0; s < 5; s++) {
        for (int e = 0; e < sets[s].n; e++)
            crisp_curve_destroy(sets[s].c[e]);
        crisp_surface_destroy(sets[s].s);
    }
    return 0;
}
