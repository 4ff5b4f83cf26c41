/* SPDX-License-Identifier: Apache-2.0 */
/* The evenfeed command line's helpers (cli.h): errors, option parsing, numbers and lists,
 * JSON output, the built-in tables and the smoothing options. */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

#ifdef EF_HAVE_DEFAULT_TABLES
extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;
#endif

const cli_cmd_t *cli_cmd_find(const cli_cmd_t *cmds, const char *name)
{
    for (; name && cmds->name; cmds++)
        if (!strcmp(cmds->name, name))
            return cmds;
    return NULL;
}

int cli_error(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("evenfeed: error: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return code;
}

/* Built-in tables are compiled in from tables/gen when they exist. */
const ef_table_t *cli_default_table(int kind)
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

void cli_json_num(FILE *f, double v)
{
    if (isfinite(v))
        fprintf(f, "%.9g", v);
    else
        fputs("null", f);
}

void cli_json_str(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        if (*s == '"' || *s == '\\')
            fprintf(f, "\\%c", *s);
        else if ((unsigned char)*s < 0x20)
            fprintf(f, "\\u%04x", (unsigned)(unsigned char)*s);
        else
            fputc(*s, f);
    }
    fputc('"', f);
}

void cli_getopt_init(cli_getopt_t *g, const char *cmd, const char *usage, int argc, char **argv,
                     const char *shortopts, const struct option *longopts)
{
    memset(g, 0, sizeof *g);
    g->cmd = cmd;
    g->usage = usage;
    g->argc = argc;
    g->argv = argv;
    g->longopts = longopts;
    /* '-': positional arguments in order (no permutation, whatever POSIXLY_CORRECT says);
     * ':': a missing value returns ':', not '?'. */
    snprintf(g->shortopts, sizeof g->shortopts, "-:h%s", shortopts ? shortopts : "");
    optind = 0; /* glibc: start over, forgetting any earlier parse */
    opterr = 0;
}

/* Name the option just parsed into g->opt: "--name" or "-c". */
static void cutil_name(cli_getopt_t *g, const char *tok, int c)
{
    if (tok[0] == '-' && tok[1] == '-')
        snprintf(g->optbuf, sizeof g->optbuf, "%.*s", (int)strcspn(tok, "="), tok);
    else
        snprintf(g->optbuf, sizeof g->optbuf, "-%c", c);
    g->opt = g->optbuf;
}

int cli_getopt(cli_getopt_t *g)
{
    g->opt = g->val = NULL;
    if (!g->done) {
        /* The element getopt_long works on: RETURN_IN_ORDER never skips ahead. */
        int at = optind > 0 ? optind : 1, li = -1;
        int c = getopt_long(g->argc, g->argv, g->shortopts, g->longopts, &li);
        const char *tok = at < g->argc ? g->argv[at] : "";
        int is_long = tok[0] == '-' && tok[1] == '-';
        if (c == 1) {
            g->val = optarg;
            return CLI_ARG;
        }
        if (c == ':') {
            cutil_name(g, tok, optopt);
            return cli_error(EF_ERR_ARG, "%s: %s needs a value", g->cmd, g->opt);
        }
        if (c == '?') {
            if (is_long)
                return cli_error(EF_ERR_ARG, "%s: unknown option '%s'", g->cmd, tok);
            return cli_error(EF_ERR_ARG, "%s: unknown option '-%c'", g->cmd, optopt);
        }
        if (c != -1) {
            if (li >= 0) { /* spelled out in full: getopt_long also takes abbreviations */
                size_t n = strlen(g->longopts[li].name);
                if (strncmp(tok + 2, g->longopts[li].name, n) ||
                    (tok[2 + n] != '\0' && tok[2 + n] != '='))
                    return cli_error(EF_ERR_ARG, "%s: unknown option '%s'", g->cmd, tok);
            }
            cutil_name(g, li >= 0 ? tok : "", c);
            g->val = optarg;
            if (c == 'h') {
                fputs(g->usage, stdout);
                return CLI_HELP;
            }
            return c;
        }
        g->done = 1; /* the end, or "--": the rest is positional */
    }
    if (optind < g->argc) {
        g->val = g->argv[optind++];
        return CLI_ARG;
    }
    return CLI_END;
}

int cli_parse_int(const char *s, long long lo, long long hi, long long *out)
{
    if (!s || !*s)
        return EF_ERR_ARG;
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (end == s || *end != '\0' || errno == ERANGE || v < lo || v > hi)
        return EF_ERR_ARG;
    *out = v;
    return EF_OK;
}

int cli_parse_double(const char *s, double *out)
{
    if (!s || !*s)
        return EF_ERR_ARG;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end != '\0' || errno == ERANGE || !isfinite(v))
        return EF_ERR_ARG;
    *out = v;
    return EF_OK;
}

int cli_split(const char *s, char sep, char *buf, size_t size, char **items, int max)
{
    if (!s || strlen(s) >= size)
        return EF_ERR_ARG;
    strcpy(buf, s);
    int n = 0;
    for (char *p = buf;; n++) {
        char *q = strchr(p, sep);
        if (q)
            *q = '\0';
        if (n < max)
            items[n] = p;
        if (!q)
            return n + 1;
        p = q + 1;
    }
}

int cli_opt_int(const cli_getopt_t *g, long long lo, long long hi, long long *out)
{
    if (cli_parse_int(g->val, lo, hi, out) == EF_OK)
        return EF_OK;
    if (hi == LLONG_MAX)
        return cli_error(EF_ERR_ARG, "%s: %s '%s': a whole number >= %lld", g->cmd, g->opt,
                         g->val ? g->val : "", lo);
    return cli_error(EF_ERR_ARG, "%s: %s '%s': a whole number %lld..%lld", g->cmd, g->opt,
                     g->val ? g->val : "", lo, hi);
}

int cli_opt_double(const cli_getopt_t *g, double *out)
{
    if (cli_parse_double(g->val, out) == EF_OK)
        return EF_OK;
    return cli_error(EF_ERR_ARG, "%s: %s: '%s' is not a finite number", g->cmd, g->opt,
                     g->val ? g->val : "");
}

/* A smoothing option's number: finite and lo <= v (lo < v when strict). */
static int cutil_pipe_num(const cli_getopt_t *g, double lo, int strict, double *out)
{
    int rc = cli_opt_double(g, out);
    if (rc != EF_OK)
        return rc;
    if (strict ? !(*out > lo) : !(*out >= lo))
        return cli_error(EF_ERR_ARG, "%s: %s %s: must be %s %g", g->cmd, g->opt, g->val,
                         strict ? ">" : ">=", lo);
    return EF_OK;
}

int cli_pipe_opt(const cli_getopt_t *g, int key, ef_pipe_cfg_t *cfg)
{
    double x = 0;
    long long n = 0;
    int rc = EF_OK;
    switch (key) {
    case CLI_PIPE_TOL:
        if ((rc = cutil_pipe_num(g, 0, 0, &x)) == EF_OK)
            cfg->tol_default = x;
        break;
    case CLI_PIPE_VMAX:
        /* X Y Z and U V W (linear axes); A B C: --vmax-rot */
        if ((rc = cutil_pipe_num(g, 0, 1, &x)) == EF_OK) {
            for (int i = 0; i < EF_AXES; i++)
                if (i < 3 || i >= 6)
                    cfg->lim.v_axis[i] = (float)x;
            cfg->rapid_speed = x;
        }
        break;
    case CLI_PIPE_AMAX:
        if ((rc = cutil_pipe_num(g, 0, 1, &x)) == EF_OK)
            for (int i = 0; i < EF_AXES; i++)
                if (i < 3 || i >= 6)
                    cfg->lim.a_axis[i] = (float)x;
        break;
    case CLI_PIPE_VMAX_ROT:
        if ((rc = cutil_pipe_num(g, 0, 1, &x)) == EF_OK)
            for (int i = 3; i < EF_AXES && i < 6; i++)
                cfg->lim.v_axis[i] = (float)x;
        break;
    case CLI_PIPE_AMAX_ROT:
        if ((rc = cutil_pipe_num(g, 0, 1, &x)) == EF_OK)
            for (int i = 3; i < EF_AXES && i < 6; i++)
                cfg->lim.a_axis[i] = (float)x;
        break;
    case CLI_PIPE_AXES:
        if ((rc = cli_opt_int(g, 3, EF_AXES, &n)) == EF_OK)
            cfg->naux = (int)n - 3;
        break;
    case CLI_PIPE_AUX_TOL:
        if ((rc = cutil_pipe_num(g, 0, 0, &x)) == EF_OK)
            for (int i = 0; i < EF_AUX; i++)
                cfg->aux_tol[i] = x;
        break;
    case CLI_PIPE_JERK:
        if ((rc = cutil_pipe_num(g, 0, 0, &x)) == EF_OK)
            cfg->lim.j_max = (float)x;
        break;
    case CLI_PIPE_PERIOD:
        if ((rc = cli_opt_int(g, 1, 1000000, &n)) == EF_OK)
            cfg->period_us = (uint32_t)n;
        break;
    case CLI_PIPE_STEP:
        if (!strcmp(g->val, "uniform"))
            cfg->step_mode = EF_STEP_UNIFORM;
        else if (!strcmp(g->val, "corrected"))
            cfg->step_mode = EF_STEP_CORRECTED;
        else
            rc = cli_error(EF_ERR_ARG, "%s: --step uniform|corrected", g->cmd);
        break;
    case CLI_PIPE_MICRO:
        if ((rc = cutil_pipe_num(g, 0, 0, &x)) == EF_OK)
            cfg->micro_len = x;
        break;
    case CLI_PIPE_G1:
        cfg->smooth_degree = 3;
        break;
    case CLI_PIPE_KEEP_BLENDS:
        cfg->keep_slow_blends = 1;
        break;
    default:
        rc = cli_error(EF_ERR_ARG, "%s: unknown option '%s'", g->cmd, g->opt ? g->opt : "?");
        break;
    }
    return rc;
}

int cli_machine_opt(const cli_getopt_t *g, int key, cli_machine_t *mc)
{
    if (key == CLI_MACH_PARAMS)
        mc->params = g->val;
    else if (key == CLI_MACH_TOOLS)
        mc->tools = g->val;
    else
        return 0;
    return 1;
}

int cli_gcode_open(ef_gcode_t *r, const char *path, const cli_machine_t *mc)
{
    ef_msg_t m = {{0}};
    int rc = ef_gcode_open(r, path, &m);
    if (rc == EF_OK && mc && mc->params)
        rc = ef_gcode_load_params(r, mc->params, &m);
    if (rc == EF_OK && mc && mc->tools)
        rc = ef_gcode_load_tools(r, mc->tools, &m);
    if (rc != EF_OK) {
        ef_gcode_free(r);
        return cli_error(rc, "%s", m.text);
    }
    return EF_OK;
}
