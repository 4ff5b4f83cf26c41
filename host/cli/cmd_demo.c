/* evenfeed demo: the built-in default job, runnable with no hardware and no input files:
 * smooth the shipped sample part programs (samples/bracket.ngc: lines, arcs, events;
 * samples/profile.ngc: CAM micro-segment curves and split edges; both embedded at build
 * time), print their summaries and write an SVG plot of each. */
#include <string.h>
#include "cli.h"

/* Generated from samples/NAME.ngc by host/CMakeLists.txt. */
extern const char ef_sample_bracket[];
extern const unsigned long ef_sample_bracket_len;
extern const char ef_sample_profile[];
extern const unsigned long ef_sample_profile_len;

static const char usage[] =
    "usage: evenfeed demo [--svg PATH]   (default evenfeed-demo.svg; the second program's\n"
    "                                     plot goes next to it, PATH with -profile.svg)\n";

/* Smooth one embedded program and write its plot. */
static int ef_demo_one(const char *text, unsigned long len, const char *name, const char *svg)
{
    static ef_gcode_t r; /* about 50 kB of parameters: not on the stack */
    printf("== samples/%s\n", name);
    fflush(stdout);
    int rc = ef_gcode_init(&r, text, (size_t)len, name);
    if (rc)
        return ef_cli_error(rc, "demo: %s", ef_err_str(rc));
    ef_smooth_opts_t o;
    ef_smooth_opts_default(&o);
    o.svg = svg;
    char label[64];
    snprintf(label, sizeof label, "samples/%s", name);
    rc = ef_cli_smooth_run(&r, label, &o);
    ef_gcode_free(&r);
    if (rc)
        return rc;
    printf("SVG plot written to %s\n\n", svg);
    fflush(stdout);
    return 0;
}

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
    /* The second plot's name: PATH without a trailing .svg, plus -profile.svg. */
    char svg2[4096];
    size_t n = strlen(svg);
    if (n >= 4 && !strcmp(svg + n - 4, ".svg"))
        n -= 4;
    if (n + sizeof "-profile.svg" > sizeof svg2)
        return ef_cli_error(EF_ERR_ARG, "demo: --svg path too long");
    memcpy(svg2, svg, n);
    memcpy(svg2 + n, "-profile.svg", sizeof "-profile.svg");
    printf("evenfeed demo: two sample part programs through the smoother, feed planner and\n"
           "interpolator (built-in G1/G2 tables, no hardware)\n\n");
    int rc = ef_demo_one(ef_sample_bracket, ef_sample_bracket_len, "bracket.ngc", svg);
    if (rc)
        return rc;
    return ef_demo_one(ef_sample_profile, ef_sample_profile_len, "profile.ngc", svg2);
}
