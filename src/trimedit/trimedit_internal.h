/* Private state of the trim editor (include/crisp/trimedit.h). */
#ifndef CRISP_TRIMEDIT_INTERNAL_H
#define CRISP_TRIMEDIT_INTERNAL_H

#include "crisp/trimedit.h"

typedef struct crisp__trimedit_snapshot {
    crisp_trim_loop *loops;
    int loop_count;
} crisp__trimedit_snapshot;

/* One polyline segment of a loop (crossing check). */
typedef struct crisp__trimedit_seg {
    double a[2], b[2];
    double umin, umax, vmin, vmax;
    int loop, seq, loop_len;
} crisp__trimedit_seg;

struct crisp_trimedit {
    crisp_model *model;
    int face;
    double domain[4];
    double slack; /* how far control points may lie outside the domain (what the file had) */
    int history;
    double remove_tol;
    uint64_t version;
    crisp__trimedit_snapshot *undo, *redo;
    int undo_count, redo_count;
    int group_open, group_pushed;
    crisp_trimedit_report report;
    uint64_t report_version; /* version the report is of (0: none) */
    crisp__trimedit_seg *check_seg;
    size_t check_cap;
};

void crisp__trimedit_loops_free(crisp_trim_loop *loops, int n);
crisp_status crisp__trimedit_loops_copy(const crisp_trim_loop *src, int n, crisp_trim_loop **dest);

#endif
