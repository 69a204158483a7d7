/* crisp: the command-line tool. Dispatches to the subcommands in cmd_*.c. */
#include <stdio.h>
#include <string.h>

#include "crisp/core.h"

#define CRISP_CMD(name)                                                                            \
    int crisp_cmd_##name(int argc, char **argv);                                                   \
    extern const char crisp_cmd_##name##_help[];
#include "commands.inc"
#undef CRISP_CMD

typedef struct {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *help;
} command;

static const command commands[] = {
#define CRISP_CMD(name) {#name, crisp_cmd_##name, crisp_cmd_##name##_help},
#include "commands.inc"
#undef CRISP_CMD
    {NULL, NULL, NULL}};

static void usage(FILE *out)
{
    fprintf(out, "usage: crisp COMMAND [ARGS...]\n\ncommands:\n");
    for (const command *c = commands; c->name; c++)
        fprintf(out, "  %s\n", c->help);
    fprintf(out,
            "\noptions:\n  -h, --help     print this help\n  -V, --version  print the version\n");
    fprintf(out, "\n'crisp COMMAND --help' for the options of one command.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return 0;
    }
    if (!strcmp(argv[1], "--version") || !strcmp(argv[1], "-V"))
        return crisp_cmd_version(1, argv + 1);
    if (argv[1][0] == '-') {
        fprintf(stderr, "crisp: unknown option '%s'\n", argv[1]);
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--version") || !strcmp(argv[1], "-V"))
        return crisp_cmd_version(1, argv + 1);
    if (argv[1][0] == '-') {
        fprintf(stderr, "crisp: unknown option '%s'\n", argv[1]);
        usage(stderr);
        return 2;
    }
    for (const command *c = commands; c->name; c++)
        if (!strcmp(argv[1], c->name)) return c->run(argc - 1, argv + 1);
    fprintf(stderr, "crisp: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return 2;
}
