/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed command line: the command table, its usage text and the dispatch. The only place
 * that turns an ef_err code into the exit status. */
#include <string.h>
#include "cli.h"

static const cli_cmd_t cmain_cmds[] = {
    {"segment", cli_cmd_segment,
     "one G1 cubic / G2 quintic segment from end data (table or --optimize)"},
    {"table", cli_cmd_table, "table files: info, verify, build, merge, emit-c"},
    {"demo", cli_cmd_demo,
     "the built-in default job: smooth the sample part program, write an SVG"},
    {"gcode", cli_cmd_gcode, "read a part program and print its path items (docs/gcode.md)"},
    {"smooth", cli_cmd_smooth,
     "smooth a part program: planned moves, setpoints, summary, JSON/CSV/SVG"},
    {"stream", cli_cmd_stream, "smooth a part program and stream it to drives (--modbus, --can)"},
    {"sim-drive", cli_cmd_sim_drive, "a simulated drive (modbus, can) for tests and demos"},
    {"io", cli_cmd_io, "machine I/O on GPIO: line status, e-stop reset (docs/io.md)"},
    {"can", cli_cmd_can, "CAN adapters: list the USB-CAN (gs_usb) adapters found"},
    {"sim-adapter", cli_cmd_sim_adapter,
     "a simulated USB-CAN adapter (gs_usb on a USB gadget) bridged to a CAN interface"},
    {NULL, NULL, NULL}};

/* The usage text, from the command table. */
static void cmain_usage(FILE *f)
{
    fputs("usage: evenfeed COMMAND [options]\n\ncommands:\n", f);
    for (const cli_cmd_t *c = cmain_cmds; c->name; c++)
        fprintf(f, "  %-11s %s\n", c->name, c->summary);
    fputs("\nRun 'evenfeed COMMAND --help' for a command's options. Exit status: 0 on success,\n"
          "otherwise the negated evenfeed error code (1 = usage or invalid argument).\n",
          f);
}

/* The exit status of an ef_err code: its negation (EF_ERR_ARG, usage: 1). */
static int cmain_exit(int code)
{
    return code < 0 ? -code : code;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        cmain_usage(stderr);
        return cmain_exit(EF_ERR_ARG);
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        cmain_usage(stdout);
        return 0;
    }
    const cli_cmd_t *c = cli_cmd_find(cmain_cmds, argv[1]);
    if (!c) {
        cmain_usage(stderr);
        return cmain_exit(cli_error(EF_ERR_ARG, "unknown command '%s'", argv[1]));
    }
    return cmain_exit(c->fn(argc - 1, argv + 1));
}
