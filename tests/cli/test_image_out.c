/* Image outputs of include/crisp/app.h: the format from the extension, the checks made before
 * any work (no file created), and failures that say which file without printing anything of
 * their own (the OpenEXR library's handler used to print a raw line first). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "crisp/app.h"

static void test_format_and_check(void **state)
{
    (void)state;
    assert_int_equal(crisp_image_format_of("a.png"), CRISP_IMAGE_PNG);
    assert_int_equal(crisp_image_format_of("dir.exr/A.PNG"), CRISP_IMAGE_PNG);
    assert_int_equal(crisp_image_format_of("a.EXR"), CRISP_IMAGE_EXR);
    assert_int_equal(crisp_image_format_of("a.jpg"), CRISP_IMAGE_UNKNOWN);
    assert_int_equal(crisp_image_format_of("png"), CRISP_IMAGE_UNKNOWN);
    assert_int_equal(crisp_image_format_of("x.png/out"), CRISP_IMAGE_UNKNOWN);
    remove("imgout_new.png");
    assert_int_equal(crisp_image_output_check("imgout_new.png", CRISP_IMAGE_UNKNOWN), CRISP_OK);
    assert_int_equal(access("imgout_new.png", F_OK), -1); /* nothing created */
    assert_int_equal(crisp_image_output_check("imgout_new.png", CRISP_IMAGE_EXR),
                     CRISP_ERR_INVALID_ARG);
    assert_non_null(strstr(crisp_error_message(), ".exr"));
    assert_int_equal(crisp_image_output_check("x.jpg", CRISP_IMAGE_UNKNOWN), CRISP_ERR_INVALID_ARG);
    assert_int_equal(crisp_image_output_check("/nonexistent/x.png", CRISP_IMAGE_UNKNOWN),
                     CRISP_ERR_IO);
    assert_non_null(strstr(crisp_error_message(), "/nonexistent"));
    assert_int_equal(crisp_image_output_check("", CRISP_IMAGE_UNKNOWN), CRISP_ERR_INVALID_ARG);
}

/* Writing where the check was skipped: the error names the file, stderr stays empty. */
static void test_write_failure_quiet(void **state)
{
    (void)state;
    crisp_image img;
    assert_int_equal(crisp_image_init(&img, 4, 3), CRISP_OK);
    fflush(stderr);
    int saved = dup(2);
    int fd = open("imgout_stderr.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(saved >= 0 && fd >= 0);
    dup2(fd, 2);
    crisp_status a = crisp_image_write(&img, "/nonexistent/dir/x.exr");
    const char *ma = crisp_error_message();
    char msg_exr[1024];
    snprintf(msg_exr, sizeof msg_exr, "%s", ma);
    crisp_status b = crisp_image_write(&img, "/nonexistent/dir/x.png");
    fflush(stderr);
    dup2(saved, 2);
    close(fd);
    close(saved);
    assert_int_equal(a, CRISP_ERR_IO);
    assert_non_null(strstr(msg_exr, "/nonexistent/dir/x.exr"));
    assert_int_not_equal(b, CRISP_OK);
    assert_non_null(strstr(crisp_error_message(), "/nonexistent/dir/x.png"));
    struct stat sb;
    assert_int_equal(stat("imgout_stderr.txt", &sb), 0);
    assert_int_equal(sb.st_size, 0);
    remove("imgout_stderr.txt");
    /* and a good write gives a PNG of the image's size */
    assert_int_equal(crisp_image_write(&img, "imgout_ok.png"), CRISP_OK);
    unsigned char h[24];
    FILE *f = fopen("imgout_ok.png", "rb");
    assert_non_null(f);
    assert_int_equal(fread(h, 1, 24, f), 24);
    fclose(f);
    assert_memory_equal(h + 1, "PNG", 3);
    assert_int_equal(h[19], 4);
    assert_int_equal(h[23], 3);
    remove("imgout_ok.png");
    crisp_image_free(&img);
}

int main(void)
{
    mkdir(CRISP_BIN_DIR "/cli_scratch", 0755);
    if (chdir(CRISP_BIN_DIR "/cli_scratch") != 0) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_format_and_check),
        cmocka_unit_test(test_write_failure_quiet),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
