/* evenfeed demo: the built-in default job, runnable with no hardware and no input files:
 * smooth the shipped sample part program (samples/bracket.ngc, embedded at build time),
 * print the summary and write an SVG plot. */
#include <string.h>
#include "cli.h"

/* Generated from samples/bracket.ngc by host/CMakeLists.txt. */
extern const char ef_sample_bracket[];
extern const unsigned long ef_sample_bracket_len;

static const char usage[] = "usage: evenfeed demo [--svg PATH]   (default evenfeed-demo.svg)\n";

int ef_cmd_demo(int argc, char **argv)
{
    const char *svg = "evenfeed-demo.svg";
    for (int k = 1; k < argc; k++) {
        if (!strcmp(argv[k], "--help") || !strcmp(argv[k], "-h")) {
            fputs(usage, stdout);
            return 0;
        } else if (!strcmp(argv[k], "--svg") && k + 1 < argc) {
            svg = argv[++k];
        } else {
            fputs(usage, stderr);
            return ef_cli_error(EF_ERR_ARG, "demo: unexpected argument '%s'", argv[k]);
        }
    }
    if (!ef_cli_default_table(EF_TABLE_G1_CUBIC) || !ef_cli_default_table(EF_TABLE_G2_QUINTIC))
        return ef_cli_error(EF_ERR_ARG, "demo: this build has no built-in tables");
    printf("evenfeed demo: the sample part program samples/bracket.ngc through the smoother,\n"
           "feed planner and interpolator (built-in G1/G2 tables, no hardware)\n\n");
    fflush(stdout);
    static ef_gcode_t r; /* about 50 kB of parameters: not on the stack */
    int rc = ef_gcode_init(&r, ef_sample_bracket, (size_t)ef_sample_bracket_len, "bracket.ngc");
    if (rc)
        return ef_cli_error(rc, "demo: %s", ef_err_str(rc));
    ef_smooth_opts_t o;
    ef_smooth_opts_default(&o);
    o.svg = svg;
    rc = ef_cli_smooth_run(&r, "samples/bracket.ngc", &o);
    ef_gcode_free(&r);
    if (rc)
        return rc;
    printf("\nSVG plot written to %s\n", svg);
    return 0;
}
