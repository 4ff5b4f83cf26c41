/* evenfeed demo: the built-in default job, runnable with no hardware and no input files. */
#include <stdio.h>
#include "cli.h"

/* Run one CLI command line, echoing it first so the output reads like a session. */
static int ef_demo_run(int (*cmd)(int, char **), int argc, char **argv)
{
    printf("\n$ evenfeed");
    for (int i = 0; i < argc; i++)
        printf(" %s", argv[i]);
    printf("\n");
    fflush(stdout);
    int rc = cmd(argc, argv);
    fflush(stdout);
    return rc;
}

/* Sample segments through the built-in tables and the reference, then check the tables. */
int ef_cmd_demo(int argc, char **argv)
{
    (void)argv;
    if (argc > 1)
        return ef_cli_error(EF_ERR_ARG, "usage: evenfeed demo");
    if (!ef_cli_default_table(EF_TABLE_G1_CUBIC) || !ef_cli_default_table(EF_TABLE_G2_QUINTIC))
        return ef_cli_error(EF_ERR_ARG, "demo: this build has no built-in tables");
    printf("evenfeed demo: optimal G1/G2 Bezier segments from built-in tables (no hardware)\n");
    char *a1[] = {"segment", "--g1", "--alpha", "1.5707963", "--beta", "-1.5707963"};
    char *a2[] = {"segment", "--g1", "--alpha", "1.5707963", "--beta", "-1.5707963", "--optimize"};
    char *a3[] = {"segment", "--quartic", "--alpha", "1.5707963", "--beta", "-1.5707963", "--optimize"};
    char *a4[] = {"segment", "--g2", "--p0", "0,0", "--t0", "1,0", "--p1", "10,5", "--t1", "0,1",
                  "--k0", "0", "--k1", "0.1"};
    char *a5[] = {"segment", "--g1", "--p0", "0,0,0", "--t0", "1,0,0", "--p1", "5,5,2",
                  "--t1", "0,0.6,0.8"};
    char *v1[] = {"table", "verify", "@g1", "--random", "400"};
    char *v2[] = {"table", "verify", "@g2", "--random", "100"};
    int rc = 0;
    rc |= ef_demo_run(ef_cmd_segment, 6, a1);
    rc |= ef_demo_run(ef_cmd_segment, 7, a2);
    rc |= ef_demo_run(ef_cmd_segment, 7, a3);
    rc |= ef_demo_run(ef_cmd_segment, 14, a4);
    rc |= ef_demo_run(ef_cmd_segment, 10, a5);
    rc |= ef_demo_run(ef_cmd_table, 5, v1);
    rc |= ef_demo_run(ef_cmd_table, 5, v2);
    printf("\ndemo %s\n", rc ? "FAILED" : "done");
    return rc ? 1 : 0;
}
