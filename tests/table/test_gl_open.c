/* SPDX-License-Identifier: Apache-2.0 */
/* The headless GL context: it opens on llvmpipe (CI) or a GPU, and fails with a clear
 * message when it cannot. Usage: test_gl_open ok | expect-fail PATTERN
 * (the failure cases are set up by the environment: see tests/table/gpu.cmake). */
#include <string.h>
#include "ef_test.h"
#include "evenfeed/gpu/ef_gl.h"

/* ok: the context opens and refuses bad arguments. */
static void test_ok(void)
{
    ef_gl_t *gl = NULL;
    ef_msg_t m = {{0}};
    int rc = ef_gl_open(&gl, NULL, &m);
    if (rc != EF_OK) {
        char why[sizeof m.text + 32];
        snprintf(why, sizeof why, "no headless GL here: %s", m.text);
        ef_test_skip(why); /* ctest SKIP (77): no EGL/Mesa on this machine */
        return;
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
}

/* expect-fail PATTERN: the environment made GL unusable; the error must say why. */
static void test_expect_fail(void)
{
    ef_gl_t *gl = NULL;
    ef_msg_t m = {{0}};
    int rc = ef_gl_open(&gl, NULL, &m);
    printf("%s\n", m.text);
    EF_CHECK_EQ(rc, EF_ERR_IO);
    EF_CHECK(gl == NULL);
    EF_CHECK(ef_t_argc > 0 && strstr(m.text, ef_t_argv[0]) != NULL);
    ef_gl_close(gl); /* opened after all: the checks above failed */
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"ok", test_ok},
        {"expect-fail PATTERN", test_expect_fail},
    };
    if (argc < 2) { /* no run of all: expect-fail needs the environment that makes GL fail */
        fprintf(stderr, "usage: %s ok | expect-fail PATTERN\n", argv[0]);
        return 2;
    }
    return EF_TEST_RUN(argc, argv, 1, parts);
}
