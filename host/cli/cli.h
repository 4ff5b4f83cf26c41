/* SPDX-License-Identifier: Apache-2.0 */
/* Shared pieces of the evenfeed command line. */
#ifndef EF_CLI_H
#define EF_CLI_H

#include <stdio.h>
#include "evenfeed/table/ef_table.h"
#include "evenfeed/host/core/ef_host.h"
#include "evenfeed/host/program/ef_pipeline.h"

/* Exit status: the negated ef_err code (usage errors are EF_ERR_ARG, exit 1). */
int ef_cli_exit(int code);
/* Print "evenfeed: error: <text>" to stderr and return the exit status for code. */
int ef_cli_error(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Parse a finite double; on failure prints which option was bad. */
int ef_cli_double(const char *opt, const char *s, double *out);
/* The built-in table of a kind, or NULL when this binary has none. */
const ef_table_t *ef_cli_default_table(int kind);
/* Print a double for JSON (null for non-finite, which JSON cannot hold). */
void ef_cli_json_num(FILE *f, double v);

int ef_cmd_segment(int argc, char **argv);
int ef_cmd_table(int argc, char **argv);
int ef_cmd_demo(int argc, char **argv);
int ef_cmd_gcode(int argc, char **argv);
int ef_cmd_smooth(int argc, char **argv);
int ef_cmd_stream(int argc, char **argv);
int ef_cmd_sim_drive(int argc, char **argv);
/* Smoothing options shared by smooth and stream: -1 if a is not one, else 0 or an exit
 * status; *used = option values consumed. */
int ef_cli_pipe_opt(const char *cmd, const char *a, const char *v, ef_pipe_cfg_t *cfg, int *used);

/* evenfeed smooth's options (shared with the demo). */
typedef struct {
    const char *out; /* -o: .json (moves) or .csv (setpoints); NULL: none */
    const char *svg; /* --svg: XY plot; NULL: none */
    ef_pipe_cfg_t cfg;
} ef_smooth_opts_t;
/* Defaults: ef_pipe_cfg_default(), built-in tables, both step modes interpolated. */
void ef_smooth_opts_default(ef_smooth_opts_t *o);
/* Smooth an opened program, write the outputs, print the summary; the exit status. */
int ef_cli_smooth_run(ef_gcode_t *r, const char *title, const ef_smooth_opts_t *o);

#endif
