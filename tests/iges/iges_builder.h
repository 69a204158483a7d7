/* Test helper: write a small IGES 5.3 file (fixed 80-column S, G, D, P, T records) from a list of
 * entities given as parameter text, so tests can state each analytic entity by hand. */
#ifndef CRISP_TEST_IGES_BUILDER_H
#define CRISP_TEST_IGES_BUILDER_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct test_entity {
    int type;
    int form;
    int xform;          /* DE pointer of a 124, or 0 */
    const char *status; /* 8 digits; NULL: "00000000" */
    int color;
    const char *params; /* after the type number, ending with ';' */
} test_entity;

/* Returns a malloc'ed NUL-terminated file text. DE pointer of entity i is 2 i + 1. */
static char *test_iges_build(const test_entity *ents, int n)
{
    size_t cap = 4096 + (size_t)n * 400;
    for (int i = 0; i < n; i++)
        cap += strlen(ents[i].params) * 2;
    char *out = malloc(cap), *w = out;
    w += sprintf(w, "%-72sS%7d\n", "crisp IGES test", 1);
    w += sprintf(w, "%-72sG%7d\n",
                 "1H,,1H;,4Htest,8Htest.igs,,,32,308,15,308,15,,1.,2,2HMM,1,1.,,1E-6;", 1);
    /* parameter lines first, to know each entity's pointer and line count */
    int *pptr = calloc((size_t)n, sizeof *pptr), *plines = calloc((size_t)n, sizeof *plines);
    char *pbuf = malloc(cap), *pw = pbuf;
    int pseq = 0;
    for (int i = 0; i < n; i++) {
        char text[8192];
        snprintf(text, sizeof text, "%d,%s", ents[i].type, ents[i].params);
        pptr[i] = pseq + 1;
        size_t len = strlen(text);
        for (size_t at = 0; at < len; at += 64) {
            char chunk[65];
            size_t k = len - at < 64 ? len - at : 64;
            memcpy(chunk, text + at, k);
            chunk[k] = 0;
            pw += sprintf(pw, "%-64s %7dP%7d\n", chunk, 2 * i + 1, ++pseq);
            plines[i]++;
        }
    }
    for (int i = 0; i < n; i++) {
        const char *st = ents[i].status ? ents[i].status : "00000000";
        w += sprintf(w, "%8d%8d%8d%8d%8d%8d%8d%8d%8sD%7d\n", ents[i].type, pptr[i], 0, 0, 0, 0,
                     ents[i].xform, 0, st, 2 * i + 1);
        w += sprintf(w, "%8d%8d%8d%8d%8d%8s%8s%8s%8dD%7d\n", ents[i].type, 0, ents[i].color,
                     plines[i], ents[i].form, "", "", "", 0, 2 * i + 2);
    }
    w += sprintf(w, "%s", pbuf);
    char tl[80];
    snprintf(tl, sizeof tl, "S%7dG%7dD%7dP%7d", 1, 1, 2 * n, pseq);
    w += sprintf(w, "%-72sT%7d\n", tl, 1);
    free(pbuf);
    free(pptr);
    free(plines);
    return out;
}

#endif
