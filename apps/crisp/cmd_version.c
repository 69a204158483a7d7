/* crisp version (also crisp --version): the library's version. */
#include <stdio.h>
#include <string.h>

#include "crisp/version.h"

const char crisp_cmd_version_help[] =
    "version                     print the version (also crisp --version)";

int crisp_cmd_version(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("usage: crisp version\n  Prints the version of crisp (also: crisp --version).\n");
        return 0;
    }
    if (argc > 1) {
        fprintf(stderr, "crisp version: unexpected argument '%s'\n", argv[1]);
        return 2;
    }
    printf("crisp %s\n", crisp_version());
    return 0;
}
