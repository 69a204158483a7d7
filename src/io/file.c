/* Reading whole files into memory, with errors that name the file. */
#include "crisp/io.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

crisp_status crisp_read_file(const char *path, char **data, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return crisp_error(CRISP_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat sb;
    if (fstat(fileno(f), &sb) == 0 && S_ISDIR(sb.st_mode)) {
        fclose(f);
        return crisp_error(CRISP_ERR_IO, "%s: is a directory, not a file", path);
    }
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (crisp_grow((void **)&buf, &cap, len + 65537, 1) != CRISP_OK) {
            fclose(f);
            crisp_free(buf);
            return crisp_error(CRISP_ERR_NO_MEMORY, "%s: out of memory after %zu bytes", path, len);
        }
        size_t n = fread(buf + len, 1, cap - len - 1, f);
        len += n;
        if (n == 0) break;
    }
    int err = ferror(f), err_no = errno;
    fclose(f);
    if (err) {
        crisp_free(buf);
        return crisp_error(CRISP_ERR_IO, "%s: read error after %zu bytes: %s", path, len,
                           strerror(err_no));
    }
    buf[len] = '\0';
    *data = buf;
    *size = len;
    return CRISP_OK;
}
