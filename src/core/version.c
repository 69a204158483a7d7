/* crisp_version: the version the library was built as (include/crisp/version.h). */
#include "crisp/version.h"

const char *crisp_version(void)
{
    return CRISP_VERSION_STRING;
}

int crisp_version_number(void)
{
    return CRISP_VERSION_NUMBER;
}
