/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Self-test of the part runner in tests/ef_test.h (tests/core/harness.cmake): the parts
 * here are tiny on purpose, and several of the registered runs must fail (WILL_FAIL): an
 * unknown part, a part that checks nothing, a failing check, arguments to a part that
 * takes none, and ef_test_summary() after no check at all.
 *
 *   test_harness [PART...]       the part runner
 *   test_harness --summary-only  ef_test_summary() with no check run (must fail)
 */
#include <string.h>

#include "ef_test.h"

static void th_one(void)
{
    EF_CHECK(1);
}

static void th_two_a(void)
{
    EF_CHECK_EQ(2 + 2, 4);
}

static void th_two_b(void)
{
    EF_CHECK_NEAR(0.1 + 0.2, 0.3, 1e-12);
}

/* Checks nothing: must fail the run it is in. */
static void th_none(void) {}

/* A failing check. */
static void th_bad(void)
{
    EF_CHECK_EQ(1, 2);
}

/* Takes its arguments: "args x y" passes, "args" alone (or a run of all) does not. */
static void th_args(void)
{
    EF_CHECK_EQ(ef_t_argc, 2);
    EF_CHECK(ef_t_argc == 2 && strcmp(ef_t_argv[0], "x") == 0 && strcmp(ef_t_argv[1], "y") == 0);
    EF_CHECK(ef_t_part != NULL && strcmp(ef_t_part, "args") == 0);
}

/* Cannot run here: exit status 77. */
static void th_skip(void)
{
    ef_test_skip("the self-test's skip part");
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "--summary-only") == 0)
        return ef_test_summary();
    static const ef_test_part_t parts[] = {
        {"one", th_one}, {"two", th_two_a}, {"two", th_two_b},     {"none", th_none},
        {"bad", th_bad}, {"skip", th_skip}, {"args X Y", th_args},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
