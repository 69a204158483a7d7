/* crisp info MODEL [--json]: what a CAD file holds once crisp has loaded it: format, faces,
 * Bézier patches after extraction, trim loops (outer, holes), trim curves and their Bézier
 * pieces, degrees, rational or not, faces with a colour, the bounding box of the trimmed faces
 * (the box the default camera frames: crisp_scene_prepare's, each face's patches clipped to its
 * trim loops, not the untrimmed control hulls), the faces the reader dropped and what it skipped,
 * each reason in full, and the gaps between faces wider than the file's tolerance
 * (crisp_model_gaps).
 * Exit 0 on success; 1 with the reader's message (file, line or entity, problem) otherwise;
 * 2 on a usage error. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "crisp/io.h"
#include "crisp/render.h"

const char crisp_cmd_info_help[] =
    "info MODEL [--json] [--no-gaps]  summarise a CAD model (IGES, STEP, OBJ)";

static void usage(FILE *out)
{
    fprintf(out,
            "usage: crisp info MODEL [options]\n"
            "  Loads MODEL (IGES, STEP or OBJ, detected by content) and prints its format,\n"
            "  faces, Bezier patches, trim loops and curves, degrees, rationality, the box of\n"
            "  the trimmed faces, what was skipped and why, and the gaps between faces wider\n"
            "  than the file's tolerance. Options (default in brackets):\n"
            "      --json     print the same as one JSON object [text]\n"
            "      --no-gaps  do not measure the gaps (faster on large models) [measure]\n"
            "  -h, --help     print this help and exit\n"
            "  Exit status: 0 success, 1 bad input, 2 bad usage.\n");
}

static void json_string(FILE *out, const char *s)
{
    fputc('"', out);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\')
            fprintf(out, "\\%c", *p);
        else if (*p < 0x20)
            fprintf(out, "\\u%04x", *p);
        else
            fputc(*p, out);
    }
    fputc('"', out);
}

static void degrees_list(FILE *out, unsigned seen, const char *sep)
{
    int first = 1;
    for (int d = 0; d <= 31; d++)
        if (seen & (1u << d)) {
            fprintf(out, "%s%d", first ? "" : sep, d);
            first = 0;
        }
}

static int colored_faces(const crisp_model *m)
{
    int n = 0;
    for (int i = 0; i < m->face_count; i++)
        n += m->faces[i].has_color != 0;
    return n;
}

#define GAPS_LISTED 10

static void print_text(const char *path, const crisp_model *m, const crisp_model_stats *s,
                       const double *box, const crisp_gap_report *g, double seconds)
{
    printf("file:            %s\n", path);
    printf("format:          %s\n", m->format);
    printf("units:           %g mm per model unit\n", m->unit_to_mm);
    printf("faces:           %d\n", s->faces);
    printf("faces dropped:   %d\n", m->faces_dropped);
    printf("bezier patches:  %d\n", s->bezier_patches);
    printf("trim loops:      %d (%d outer, %d holes)\n", s->outer_loops + s->hole_loops,
           s->outer_loops, s->hole_loops);
    printf("trim curves:     %d (%d Bezier pieces)\n", s->trim_curves, s->trim_pieces);
    printf("surface degrees: ");
    degrees_list(stdout, s->degrees_seen, ", ");
    printf(" (max %d x %d)\n", s->max_degree_u, s->max_degree_v);
    printf("trim degree:     max %d\n", s->max_trim_degree);
    printf("rational:        %s (%d of %d surfaces)\n", s->rational_surfaces ? "yes" : "no",
           s->rational_surfaces, s->faces);
    printf("coloured faces:  %d\n", colored_faces(m));
    if (s->faces)
        printf("bounding box:    [%g, %g, %g] - [%g, %g, %g]\n", box[0], box[1], box[2], box[3],
               box[4], box[5]);
    else
        printf("bounding box:    (empty)\n");
    int skipped = 0;
    for (int i = 0; i < m->skip_count; i++)
        skipped += m->skips[i].count;
    printf("skipped:         %d\n", skipped);
    for (int i = 0; i < m->skip_count; i++)
        printf("  %6d x %s\n", m->skips[i].count, m->skips[i].what);
    if (g->incomplete)
        printf("gaps:            not measured\n");
    else if (g->count)
        printf("gaps:            %d pairs of faces farther apart than the tolerance %g "
               "(%ld of %ld boundary samples near another face)\n",
               g->count, g->tolerance, g->gap_samples, g->samples);
    else
        printf("gaps:            none wider than the tolerance %g (%ld boundary samples near "
               "another face)\n",
               g->tolerance, g->samples);
    for (int i = 0; i < g->count && i < GAPS_LISTED; i++) {
        const crisp_gap *q = &g->gaps[i];
        printf("  %g between faces %d and %d (source ids) at [%g, %g, %g]\n", q->gap,
               m->faces[q->face[0]].source_id, m->faces[q->face[1]].source_id, q->at[0], q->at[1],
               q->at[2]);
    }
    printf("load time:       %.3f s\n", seconds);
}

static void print_json(const char *path, const crisp_model *m, const crisp_model_stats *s,
                       const double *box, const crisp_gap_report *g, double seconds)
{
    printf("{\"file\": ");
    json_string(stdout, path);
    printf(", \"format\": ");
    json_string(stdout, m->format);
    printf(", \"unit_to_mm\": %.17g", m->unit_to_mm);
    printf(", \"faces\": %d, \"faces_dropped\": %d, \"bezier_patches\": %d", s->faces,
           m->faces_dropped, s->bezier_patches);
    printf(", \"loops\": {\"outer\": %d, \"holes\": %d}", s->outer_loops, s->hole_loops);
    printf(", \"trim_curves\": %d, \"trim_pieces\": %d", s->trim_curves, s->trim_pieces);
    printf(", \"degrees_seen\": [");
    degrees_list(stdout, s->degrees_seen, ", ");
    printf("], \"max_degree\": {\"u\": %d, \"v\": %d, \"trim\": %d}", s->max_degree_u,
           s->max_degree_v, s->max_trim_degree);
    printf(", \"rational\": %s, \"rational_surfaces\": %d", s->rational_surfaces ? "true" : "false",
           s->rational_surfaces);
    printf(", \"colored_faces\": %d", colored_faces(m));
    if (s->faces)
        printf(", \"bbox\": [%.17g, %.17g, %.17g, %.17g, %.17g, %.17g]", box[0], box[1], box[2],
               box[3], box[4], box[5]);
    else
        printf(", \"bbox\": null");
    printf(", \"skipped\": [");
    for (int i = 0; i < m->skip_count; i++) {
        printf("%s{\"what\": ", i ? ", " : "");
        json_string(stdout, m->skips[i].what);
        printf(", \"count\": %d}", m->skips[i].count);
    }
    printf(
        "], \"gaps\": {\"measured\": %s, \"tolerance\": %.17g, \"limit\": %.17g, \"samples\": %ld, "
        "\"gap_samples\": %ld, \"pairs\": %d, \"largest\": [",
        g->incomplete ? "false" : "true", g->tolerance, g->limit, g->samples, g->gap_samples,
        g->count);
    for (int i = 0; i < g->count && i < 2 * GAPS_LISTED; i++) {
        const crisp_gap *q = &g->gaps[i];
        printf("%s{\"faces\": [%d, %d], \"gap\": %.17g, \"at\": [%.17g, %.17g, %.17g]}",
               i ? ", " : "", m->faces[q->face[0]].source_id, m->faces[q->face[1]].source_id,
               q->gap, q->at[0], q->at[1], q->at[2]);
    }
    printf("]}, \"load_seconds\": %.6f}\n", seconds);
}

int crisp_cmd_info(int argc, char **argv)
{
    const char *path = NULL;
    int json = 0, gaps_wanted = 1;
    static const struct option opts[] = {{"json", no_argument, 0, 'j'},
                                         {"no-gaps", no_argument, 0, 'g'},
                                         {"help", no_argument, 0, 'h'},
                                         {0, 0, 0, 0}};
    cli_cmd = "info";
    optind = 0;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":h", opts, NULL)) != -1) {
        if (c == 'j') {
            json = 1;
        } else if (c == 'g') {
            gaps_wanted = 0;
        } else if (c == 'h') {
            usage(stdout);
            return 0;
        } else {
            cli_bad_option(c, argv);
            return 2;
        }
    }
    if (optind >= argc) {
        fprintf(stderr, "crisp info: no MODEL given\n");
        usage(stderr);
        return 2;
    }
    if (optind + 1 < argc) {
        fprintf(stderr, "crisp info: one MODEL expected, got '%s' and '%s'\n", argv[optind],
                argv[optind + 1]);
        return 2;
    }
    path = argv[optind];
    crisp_model *m = NULL;
    double t0 = crisp_time_now();
    crisp_status st = crisp_model_load(path, NULL, &m);
    double seconds = crisp_time_now() - t0;
    if (st != CRISP_OK) {
        fprintf(stderr, "crisp info: %s\n", crisp_error_message());
        return 1;
    }
    crisp_model_stats stats;
    st = crisp_model_stats_compute(m, &stats);
    if (st != CRISP_OK) {
        fprintf(stderr, "crisp info: %s: %s\n", path, crisp_error_message());
        crisp_model_destroy(m);
        return 1;
    }
    double box[6] = {0, 0, 0, 0, 0, 0};
    if (m->face_count) {
        crisp_scene *scene = NULL;
        if (crisp_scene_prepare(m, &scene) == CRISP_OK) {
            for (int k = 0; k < 6; k++)
                box[k] = scene->box[k];
        } else {
            /* (never seen: the control hulls' box, and say why) */
            fprintf(
                stderr,
                "crisp info: %s: box of the control hulls (the scene could not be prepared: %s)\n",
                path, crisp_error_message());
            crisp_error_clear();
            crisp_model_bbox(m, box);
        }
        crisp_scene_destroy(scene);
    }
    /* Gaps: wider than the reader's tolerance (else 1e-5 of the box diagonal), narrower than
     * 1000 times it and 1% of the diagonal (beyond: a free edge, not a crack). */
    double diag =
        sqrt((box[3] - box[0]) * (box[3] - box[0]) + (box[4] - box[1]) * (box[4] - box[1]) +
             (box[5] - box[2]) * (box[5] - box[2]));
    double tol = m->tolerance > 0 ? m->tolerance : 1e-5 * diag;
    crisp_gap_report gaps = {0};
    gaps.incomplete = 1;
    st = gaps_wanted ? crisp_model_gaps(m, tol, fmin(1000 * tol, 0.01 * diag), &gaps) : CRISP_OK;
    if (st != CRISP_OK) {
        fprintf(stderr, "crisp info: %s: %s\n", path, crisp_error_message());
        crisp_model_destroy(m);
        return 1;
    }
    if (json)
        print_json(path, m, &stats, box, &gaps, seconds);
    else
        print_text(path, m, &stats, box, &gaps, seconds);
    crisp_gap_report_free(&gaps);
    crisp_model_destroy(m);
    return 0;
}
