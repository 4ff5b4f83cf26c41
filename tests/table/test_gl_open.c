/* SPDX-License-Identifier: Apache-2.0 */
/* The headless GL context: it opens on llvmpipe (CI) or a GPU, and fails with a clear
 * message when it cannot. Usage: test_gl_open ok | expect-fail PATTERN
 * (the failure cases are set up by the environment: see tests/table/gpu.cmake). */
#include <string.h>
#include "ef_test.h"
#include "evenfeed/gpu/ef_gl.h"

int main(int argc, char **argv)
{
    if (argc < 2)
        return 2;
    ef_gl_t *gl = NULL;
    ef_msg_t m = {{0}};
    int rc = ef_gl_open(&gl, NULL, &m);
    if (!strcmp(argv[1], "ok")) {
        if (rc != EF_OK) {
            printf("no headless GL here: %s\n", m.text);
            return 77; /* ctest SKIP: no EGL/Mesa on this machine */
        }
        printf("platform %s, renderer %s\n", ef_gl_platform(gl), ef_gl_renderer(gl));
        EF_CHECK(strlen(ef_gl_renderer(gl)) > 0);
        double cfg[4] = {0, 0, 0, 0}, res[EF_GL_RES_STRIDE];
        EF_CHECK_EQ(ef_gl_solve(gl, 7, cfg, 1, NULL, res, &m), EF_ERR_ARG);
        EF_CHECK_EQ(ef_gl_solve(gl, EF_TABLE_G1_CUBIC, cfg, 0, NULL, res, &m), EF_ERR_ARG);
        ef_gl_close(gl);
        ef_gl_close(NULL);
        ef_gl_opts_t o = {.platform = "bogus"};
        EF_CHECK_EQ(ef_gl_open(&gl, &o, &m), EF_ERR_ARG);
        EF_CHECK(strstr(m.text, "bogus") != NULL);
        return ef_test_summary();
    }
    /* expect-fail PATTERN: the environment made GL unusable; the error must say why. */
    printf("%s\n", m.text);
    EF_CHECK_EQ(rc, EF_ERR_IO);
    EF_CHECK(gl == NULL);
    EF_CHECK(argc > 2 && strstr(m.text, argv[2]) != NULL);
    return ef_test_summary();
}
