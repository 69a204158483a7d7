/* Slow f-rep checks: 3D renders against brute force (heights, normals, shading) for prospero (a
 * 2D model, z ignored) at 128^3 and every other bundled model at 512^3. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "crisp/frep.h"
#include "frep/frep_brute.h"

static crisp_frep *load(const char *name)
{
    char path[512];
    snprintf(path, sizeof path, "%s/frep/%s.vm", CRISP_DATA_DIR, name);
    crisp_frep *f = NULL;
    assert_int_equal(crisp_frep_read_vm(path, &f), CRISP_OK);
    return f;
}

/* prospero: brute force of a 2D model extruded costs n^3 full-tape points (512: 200 s) */
static void test_prospero_3d(void **state)
{
    (void)state;
    check_model_3d(load("prospero"), "prospero", 128);
}

/* every other bundled model at 512^3 (about 20 s in all): the bear defect of issue 14 (616
 * pixels whose normals differed) appeared at this size only */
static void test_models_512(void **state)
{
    (void)state;
    const char *const models[] = {"bear", "colonnade", "tanglecube", "hi", "quarter"};
    for (size_t m = 0; m < sizeof models / sizeof *models; m++)
        check_model_3d(load(models[m]), models[m], 512);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_prospero_3d),
                                       cmocka_unit_test(test_models_512)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
