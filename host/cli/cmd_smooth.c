/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed smooth: a part program through the smoother, planner and interpolator; JSON,
 * CSV and SVG output and a summary (docs/smoothing-cli.md). The options are parsed here;
 * the run and its outputs are cli_smooth_run() (cli_report.c). */
#include "cli.h"

static const char usage[] =
    "usage: evenfeed smooth IN.ngc [-o OUT.json|OUT.csv] [--svg PLOT.svg] [--tol P]\n"
    "                       [--vmax V] [--amax A] [--jerk J] [--period-us N]\n"
    "                       [--step uniform|corrected] [--micro-len L] [--g1] [--keep-blends]\n"
    "                       [--params FILE.var] [--tool-table FILE.tbl]\n"
    "\n"
    "Smooths a part program (docs/gcode.md) into G2 Bezier moves, plans the feed, runs the\n"
    "interpolator in both step modes and prints a summary (docs/smoothing-cli.md).\n"
    "  -o FILE          .json: the planned moves; .csv: the sampled trajectory\n"
    "  --svg FILE       XY plot: programmed path, smoothed path coloured by speed, blends\n"
    "  --tol P          path tolerance (mm) at start and for G64 without P (default 0.02)\n"
    "  --vmax V         axis speed limit and rapid speed, mm/s (default 100)\n"
    "  --amax A         axis acceleration limit, mm/s^2 (default 1000)\n"
    "  --jerk J         jerk limit of every axis, mm/s^3, 0 = none (default 20000)\n"
    "  --period-us N    servo period in microseconds (default 1000)\n"
    "  --step MODE      stepping for CSV/SVG samples: uniform or corrected (default)\n"
    "  --micro-len L    longest CAM micro-segment, mm, 0 = no smooth sections (default 1)\n"
    "  --g1             G1 cubic smooth sections instead of G2 quintic\n"
    "  --keep-blends    blend every corner that fits, also where stopping there is faster\n"
    "                   (slow corners, docs/smoothing.md)\n"
    "  --params FILE    the machine's LinuxCNC parameter file: work offsets, G28/G30\n"
    "                   positions, coordinate system at start (mm; docs/gcode.md)\n"
    "  --tool-table FILE  the machine's LinuxCNC tool table (G43 H lengths, mm)\n";

enum { O_SVG = CLI_LONG };

int cli_cmd_smooth(int argc, char **argv)
{
    static const struct option opts[] = {{"svg", required_argument, NULL, O_SVG},
                                         CLI_PIPE_OPTIONS,
                                         CLI_MACHINE_OPTIONS,
                                         CLI_OPT_HELP,
                                         CLI_OPT_END};
    const char *path = NULL;
    cli_smooth_opts_t o;
    cli_smooth_opts_default(&o);
    cli_getopt_t g;
    cli_getopt_init(&g, "smooth", usage, argc, argv, "o:", opts);
    int c;
    while ((c = cli_getopt(&g)) > CLI_END) {
        int rc = EF_OK;
        switch (c) {
        case CLI_HELP:
            return EF_OK;
        case 'o':
            o.out = g.val;
            break;
        case O_SVG:
            o.svg = g.val;
            break;
        case CLI_ARG:
            if (path)
                return cli_error(EF_ERR_ARG, "smooth: one input file only ('%s')", g.val);
            path = g.val;
            break;
        default:
            if (!cli_machine_opt(&g, c, &o.mach))
                rc = cli_pipe_opt(&g, c, &o.cfg);
            break;
        }
        if (rc != EF_OK)
            return rc;
    }
    if (c < 0)
        return c;
    if (!path) {
        fputs(usage, stderr);
        return cli_error(EF_ERR_ARG, "smooth: no input file");
    }
    static ef_gcode_t r; /* about 50 kB of parameters: not on the stack */
    int rc = cli_gcode_open(&r, path, &o.mach);
    if (rc != EF_OK)
        return rc;
    rc = cli_smooth_run(&r, path, &o);
    ef_gcode_free(&r);
    return rc;
}
