/* SPDX-License-Identifier: Apache-2.0 */
/* The evenfeed command line's shared layer (host/cli/cli_util.c, cli_report.c).
 *
 * Every function here and every command returns an ef_err code: EF_OK (0) or a negative
 * code, after printing the error as one line (cli_error()). main() in evenfeed.c alone turns
 * a command's code into the exit status (the negated code; 1 = usage). */
#ifndef EF_CLI_H
#define EF_CLI_H

#include <getopt.h>
#include <stddef.h>
#include <stdio.h>
#include "evenfeed/table/ef_table.h"
#include "evenfeed/host/core/ef_host.h"
#include "evenfeed/host/program/ef_pipeline.h"

/* ---- Commands ---------------------------------------------------------------------- */

/** A command or subcommand: argv[0] is its name, argv[1..] its arguments.
 *  @return EF_OK, or a negative ef_err code with the error already printed. */
typedef int (*cli_cmd_fn)(int argc, char **argv);

/** One row of a command table (the last row has name NULL). */
typedef struct {
    const char *name;    /**< as typed: "segment", "sim-drive", "info" */
    cli_cmd_fn fn;       /**< the command */
    const char *summary; /**< one line for the usage text */
} cli_cmd_t;

/** The row of cmds named name.
 *  @return the row, or NULL when there is none (name NULL included). */
const cli_cmd_t *cli_cmd_find(const cli_cmd_t *cmds, const char *name);

/* The commands (evenfeed.c's table). */
int cli_cmd_segment(int argc, char **argv);
int cli_cmd_table(int argc, char **argv);
int cli_cmd_demo(int argc, char **argv);
int cli_cmd_gcode(int argc, char **argv);
int cli_cmd_smooth(int argc, char **argv);
int cli_cmd_stream(int argc, char **argv);
int cli_cmd_sim_drive(int argc, char **argv);
int cli_cmd_io(int argc, char **argv);
int cli_cmd_can(int argc, char **argv);
int cli_cmd_sim_adapter(int argc, char **argv);

struct ef_mio_s;
/** Load a machine file and open its machine I/O (cmd_io.c); signals and exit() drive the
 *  outputs to their safe state from then on.
 *  @retval EF_OK open (SAFE); otherwise the error, printed (file:line, line, consumer). */
int cli_mio_open(struct ef_mio_s *io, const char *path);

/* ---- Errors and output ------------------------------------------------------------- */

/** Print "evenfeed: error: <text>" as one line on stderr.
 *  @return code, unchanged: `return cli_error(EF_ERR_ARG, "...")` reports and fails. */
int cli_error(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/** The built-in table of a kind (EF_TABLE_G1_CUBIC, EF_TABLE_G2_QUINTIC).
 *  @return the table, or NULL when this binary has none. */
const ef_table_t *cli_default_table(int kind);

/** Print a number for JSON: "%.9g", or null for NaN and infinity (JSON has neither). */
void cli_json_num(FILE *f, double v);
/** Print a JSON string literal: quotes, with '"', '\\' and control characters escaped. */
void cli_json_str(FILE *f, const char *s);

/* ---- Options: getopt_long in command-line order ------------------------------------ */

#define CLI_END  0 /**< cli_getopt(): no more arguments */
#define CLI_ARG  1 /**< cli_getopt(): a positional argument, in g->val */
#define CLI_HELP 2 /**< cli_getopt(): --help or -h; the usage text is printed on stdout */
/** First key of long-only options: above every short option character. */
#define CLI_LONG 256

/* clang-format off */
/** The --help / -h entry every option table carries (before the terminator). */
#define CLI_OPT_HELP {"help", no_argument, NULL, 'h'}
/** The terminator of an option table. */
#define CLI_OPT_END {NULL, 0, NULL, 0}
/* clang-format on */

/** State of one command's option parse (cli_getopt_init(), then cli_getopt() in a loop). */
typedef struct {
    const char *cmd;               /**< message prefix: "smooth", "table build" */
    const char *usage;             /**< printed on --help */
    int argc;                      /**< argv[0] is the command's name */
    char **argv;                   /**< never reordered */
    const struct option *longopts; /**< ends with CLI_OPT_END */
    char shortopts[40];            /**< "-:" + the command's short options */
    const char *opt;               /**< the current option as named: "--tol", "-o" */
    const char *val;               /**< its value, or the positional argument */
    int done;                      /**< getopt_long ended; the rest are positional */
    char optbuf[48];               /**< storage behind opt */
} cli_getopt_t;

/** Start parsing argv[1..argc-1] of command cmd.
 *  shortopts: getopt letters (e.g. "o:v"), 'h' is added; longopts: getopt_long's table
 *  with CLI_OPT_HELP and CLI_OPT_END, keys of long-only options from CLI_LONG up. */
void cli_getopt_init(cli_getopt_t *g, const char *cmd, const char *usage, int argc, char **argv,
                     const char *shortopts, const struct option *longopts);

/** The next argument, in command-line order (argv is not permuted, so a positional argument
 *  may come anywhere; a value is the next word even if it starts with '-': --beta -1.5).
 *  Long options must be spelled out in full (no abbreviations); "--name=value" is accepted;
 *  everything after "--" is positional.
 *  @return an option's key (its letter or its longopts val), with g->opt naming it and
 *          g->val its value (never NULL for an option that takes one); CLI_ARG with g->val;
 *          CLI_HELP after printing the usage; CLI_END after the last argument.
 *  @retval EF_ERR_ARG an unknown or abbreviated option, a missing value, or a value given
 *          to an option that takes none: printed as "CMD: unknown option 'ARG'" or
 *          "CMD: OPT needs a value". */
int cli_getopt(cli_getopt_t *g);

/* ---- Numbers and lists --------------------------------------------------------------- */

/** Parse a whole decimal number (optional sign) within [lo, hi]; nothing printed.
 *  @retval EF_ERR_ARG s NULL or empty, not a number, trailing characters, outside [lo, hi]. */
int cli_parse_int(const char *s, long long lo, long long hi, long long *out);

/** Parse a finite number (strtod syntax, the whole string); nothing printed.
 *  @retval EF_ERR_ARG s NULL or empty, not a number, trailing characters, out of range,
 *          NaN or infinite. */
int cli_parse_double(const char *s, double *out);

/** Split s at every sep into pieces copied into buf ("1,2,3" -> "1" "2" "3"; "" is one
 *  empty piece); items[] gets the first max of them.
 *  @return the number of pieces in s, which may exceed max.
 *  @retval EF_ERR_ARG s is NULL or does not fit into buf. */
int cli_split(const char *s, char sep, char *buf, size_t size, char **items, int max);

/** cli_parse_int() of the current option's value (g->val).
 *  @retval EF_ERR_ARG printed as "CMD: OPT 'VAL': a whole number LO..HI" (">= LO" when hi
 *          is LLONG_MAX). */
int cli_opt_int(const cli_getopt_t *g, long long lo, long long hi, long long *out);

/** cli_parse_double() of the current option's value (g->val).
 *  @retval EF_ERR_ARG printed as "CMD: OPT: 'VAL' is not a finite number". */
int cli_opt_double(const cli_getopt_t *g, double *out);

/* ---- Smoothing options and run (smooth, stream, demo) ------------------------------ */

/** Keys of the smoothing options (docs/smoothing-cli.md) in CLI_PIPE_OPTIONS. */
enum {
    CLI_PIPE_TOL = 0x300,
    CLI_PIPE_VMAX,
    CLI_PIPE_AMAX,
    CLI_PIPE_JERK,
    CLI_PIPE_PERIOD,
    CLI_PIPE_STEP,
    CLI_PIPE_MICRO,
    CLI_PIPE_G1,
    CLI_PIPE_KEEP_BLENDS,
    CLI_PIPE_AXES,
    CLI_PIPE_VMAX_ROT,
    CLI_PIPE_AMAX_ROT,
    CLI_PIPE_AUX_TOL
};
/* clang-format off */
/** The smoothing options' longopts entries (smooth and stream list them). */
#define CLI_PIPE_OPTIONS                                                                           \
    {"tol", required_argument, NULL, CLI_PIPE_TOL},                                                \
    {"vmax", required_argument, NULL, CLI_PIPE_VMAX},                                              \
    {"amax", required_argument, NULL, CLI_PIPE_AMAX},                                              \
    {"jerk", required_argument, NULL, CLI_PIPE_JERK},                                              \
    {"period-us", required_argument, NULL, CLI_PIPE_PERIOD},                                       \
    {"step", required_argument, NULL, CLI_PIPE_STEP},                                              \
    {"micro-len", required_argument, NULL, CLI_PIPE_MICRO},                                        \
    {"g1", no_argument, NULL, CLI_PIPE_G1},                                                        \
    {"keep-blends", no_argument, NULL, CLI_PIPE_KEEP_BLENDS},                                      \
    {"axes", required_argument, NULL, CLI_PIPE_AXES},                                              \
    {"vmax-rot", required_argument, NULL, CLI_PIPE_VMAX_ROT},                                      \
    {"amax-rot", required_argument, NULL, CLI_PIPE_AMAX_ROT},                                      \
    {"aux-tol", required_argument, NULL, CLI_PIPE_AUX_TOL}
/* clang-format on */

/** Apply smoothing option key (a CLI_PIPE_* key cli_getopt() returned; value in g->val).
 *  @retval EF_ERR_ARG a bad value (e.g. "smooth: --vmax 0: must be > 0"), or key is not a
 *          smoothing option ("CMD: unknown option 'OPT'"); printed. */
int cli_pipe_opt(const cli_getopt_t *g, int key, ef_pipe_cfg_t *cfg);

/** The machine's files a program starts from (--params, --tool-table; docs/gcode.md). */
typedef struct {
    const char *params; /**< LinuxCNC parameter file, or NULL */
    const char *tools;  /**< LinuxCNC tool table, or NULL */
} cli_machine_t;

/** Keys of the machine-file options in CLI_MACHINE_OPTIONS. */
enum { CLI_MACH_PARAMS = 0x340, CLI_MACH_TOOLS };
/* clang-format off */
/** The machine-file options' longopts entries (gcode, smooth and stream list them). */
#define CLI_MACHINE_OPTIONS                                                                        \
    {"params", required_argument, NULL, CLI_MACH_PARAMS},                                          \
    {"tool-table", required_argument, NULL, CLI_MACH_TOOLS}
/* clang-format on */

/** Take a machine-file option key: 1 when key was one (stored in mc), 0 when not. */
int cli_machine_opt(const cli_getopt_t *g, int key, cli_machine_t *mc);

/** Open a program and load the machine's files into its reader (mc may be NULL).
 *  @retval EF_OK ready; otherwise ef_gcode_open()'s, ef_gcode_load_params()'s or
 *          ef_gcode_load_tools()'s error, printed (the reader is then freed). */
int cli_gcode_open(ef_gcode_t *r, const char *path, const cli_machine_t *mc);

/** evenfeed smooth's options (shared with the demo). */
typedef struct {
    const char *out; /**< -o: .json (moves) or .csv (setpoints); NULL: none */
    const char *svg; /**< --svg: XY plot; NULL: none */
    ef_pipe_cfg_t cfg;
    cli_machine_t mach; /**< --params, --tool-table */
} cli_smooth_opts_t;

/** Defaults: ef_pipe_cfg_default(), built-in tables, both step modes interpolated. */
void cli_smooth_opts_default(cli_smooth_opts_t *o);

/** Smooth an opened program, write the -o/--svg outputs, print the summary on stdout
 *  (docs/smoothing-cli.md; cli_report.c). title names the program in the outputs.
 *  @retval EF_ERR_ARG no built-in tables, or -o not .json/.csv
 *  @retval EF_ERR_IO an output could not be written
 *  @retval EF_ERR_NOMEM out of memory
 *  @retval other the reader's or smoother's error on the program (the JSON is still
 *          written, with its status) */
int cli_smooth_run(ef_gcode_t *r, const char *title, const cli_smooth_opts_t *o);

#endif
