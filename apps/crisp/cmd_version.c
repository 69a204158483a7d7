/* crisp version */
#include <stdio.h>

const char crisp_cmd_version_help[] = "version                     print the version";

int crisp_cmd_version(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    printf("crisp 0.1.0\n");
    return 0;
}
