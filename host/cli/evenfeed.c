/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed command line: dispatch and shared helpers. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

#ifdef EF_HAVE_DEFAULT_TABLES
extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;
#endif

static const char usage[] =
    "usage: evenfeed COMMAND [options]\n"
    "\n"
    "commands:\n"
    "  segment   one G1 cubic / G2 quintic segment from end data (table or --optimize)\n"
    "  table     table files: info, verify, build, emit-c\n"
    "  demo      the built-in default job: smooth the sample part program, write an SVG\n"
    "  gcode     read a part program and print its path items (docs/gcode.md)\n"
    "  smooth    smooth a part program: planned moves, setpoints, summary, JSON/CSV/SVG\n"
    "  stream    smooth a part program and stream it to drives (--modbus, --can)\n"
    "  sim-drive a simulated drive (modbus, can) for tests and demos\n"
    "\n"
    "Run 'evenfeed COMMAND --help' for a command's options. Exit status: 0 on success,\n"
    "otherwise the negated evenfeed error code (1 = usage or invalid argument).\n";

/* Map an ef_err code to a process exit status. */
int ef_cli_exit(int code)
{
    return code < 0 ? -code : code;
}

/* Report an error on stderr in one line and give the exit status. */
int ef_cli_error(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("evenfeed: error: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return ef_cli_exit(code);
}

/* strtod that rejects trailing junk, empty strings and non-finite values. */
int ef_cli_double(const char *opt, const char *s, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end != '\0' || errno == ERANGE || !isfinite(v)) {
        fprintf(stderr, "evenfeed: error: %s: '%s' is not a finite number\n", opt, s);
        return EF_ERR_ARG;
    }
    *out = v;
    return EF_OK;
}

/* Built-in tables are compiled in from tables/gen when they exist. */
const ef_table_t *ef_cli_default_table(int kind)
{
#ifdef EF_HAVE_DEFAULT_TABLES
    if (kind == EF_TABLE_G1_CUBIC)
        return &ef_tbl_g1_default;
    if (kind == EF_TABLE_G2_QUINTIC)
        return &ef_tbl_g2_default;
#else
    (void)kind;
#endif
    return NULL;
}

/* JSON has no NaN or infinity; print them as null. */
void ef_cli_json_num(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.9g", v);
    else
        fputs("null", f);
}

int main(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        fputs(usage, argc < 2 ? stderr : stdout);
        return argc < 2 ? 1 : 0;
    }
    if (!strcmp(argv[1], "segment"))
        return ef_cmd_segment(argc - 1, argv + 1);
    if (!strcmp(argv[1], "table"))
        return ef_cmd_table(argc - 1, argv + 1);
    if (!strcmp(argv[1], "demo"))
        return ef_cmd_demo(argc - 1, argv + 1);
    if (!strcmp(argv[1], "gcode"))
        return ef_cmd_gcode(argc - 1, argv + 1);
    if (!strcmp(argv[1], "smooth"))
        return ef_cmd_smooth(argc - 1, argv + 1);
    if (!strcmp(argv[1], "stream"))
        return ef_cmd_stream(argc - 1, argv + 1);
    if (!strcmp(argv[1], "sim-drive"))
        return ef_cmd_sim_drive(argc - 1, argv + 1);
    fputs(usage, stderr);
    return ef_cli_error(EF_ERR_ARG, "unknown command '%s'", argv[1]);
}
