/* Slow f-rep checks: prospero (a 2D model, z ignored) as a 128^3 heightmap against brute force. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include <cmocka.h>

#include "crisp/frep.h"
#include "frep/frep_brute.h"

static void test_prospero_3d(void **state)
{
    (void)state;
    crisp_frep *f = NULL;
    assert_int_equal(crisp_frep_read_vm(CRISP_DATA_DIR "/frep/prospero.vm", &f), CRISP_OK);
    crisp_frep_tape *t;
    assert_int_equal(crisp_frep_tape_create(f, &t), CRISP_OK);
    int32_t *ref = brute_3d(t, 128);
    crisp_frep_render_desc d = {.width = 128, .height = 128, .depth = 128, .threads = 2};
    crisp_frep_renderer *r;
    assert_int_equal(crisp_frep_renderer_create(t, &d, &r), CRISP_OK);
    assert_int_equal(crisp_frep_renderer_run(r), CRISP_OK);
    const crisp_frep_image *img = crisp_frep_renderer_image(r);
    size_t differ = 0;
    for (size_t p = 0; p < 128 * 128; p++) differ += img->heights[p] != ref[p];
    assert_int_equal(differ, 0);
    free(ref);
    crisp_frep_renderer_destroy(r);
    crisp_frep_tape_destroy(t);
    crisp_frep_destroy(f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_prospero_3d)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
