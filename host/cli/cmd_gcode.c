/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed gcode: read a part program and print its item stream. */
#include <math.h>
#include <string.h>
#include "cli.h"
#include "evenfeed/host/program/ef_gcode.h"

static const char usage[] =
    "usage: evenfeed gcode FILE [--json] [--params FILE.var] [--tool-table FILE.tbl]\n"
    "\n"
    "Reads FILE (LinuxCNC's dialect, docs/gcode.md) and prints one line per item: rapid,\n"
    "line, arc, zero (zero-length move), event, ignored, tolerance, note, end. Positions\n"
    "are machine coordinates in mm, feeds in mm/min; A B C (degrees) and U V W (mm) follow\n"
    "'|' on moves that have any of them away from 0. --json prints one JSON object per\n"
    "line instead (abcuvw_start, abcuvw_end on such moves). --params and --tool-table\n"
    "start from a machine's LinuxCNC parameter file (work offsets, G28/G30 positions) and\n"
    "tool table (lengths in mm).\n";

/* Print a 3-vector as a JSON array. */
static void cgc_json_vec(FILE *f, const char *key, const double *v)
{
    fprintf(f, ", \"%s\": [", key);
    for (int k = 0; k < 3; k++) {
        if (k)
            fputs(", ", f);
        cli_json_num(f, v[k]);
    }
    fputc(']', f);
}

/* Whether a move item has any of A B C U V W away from 0 (then they are printed; a
 * program of X Y Z alone prints as before). */
static int cgc_aux_any(const ef_gcode_item_t *it)
{
    for (int k = 0; k < EF_GCODE_AUX; k++)
        if (it->astart[k] != 0.0 || it->aend[k] != 0.0)
            return 1;
    return 0;
}

/* A B C U V W of a move as a JSON array. */
static void cgc_json_aux(FILE *f, const char *key, const double *v)
{
    fprintf(f, ", \"%s\": [", key);
    for (int k = 0; k < EF_GCODE_AUX; k++) {
        if (k)
            fputs(", ", f);
        cli_json_num(f, v[k]);
    }
    fputc(']', f);
}

/* One item as a JSON object on one line. */
static void cgc_print_json(const ef_gcode_item_t *it)
{
    printf("{\"kind\": \"%s\", \"line\": %u, \"col\": %u, \"units\": \"%s\"",
           ef_gcode_kind_name(it->kind), (unsigned)it->line, (unsigned)it->col,
           it->units == 20 ? "inch" : "mm");
    switch (it->kind) {
    case EF_GC_RAPID:
    case EF_GC_LINE:
    case EF_GC_ZERO_MOVE:
        cgc_json_vec(stdout, "start", it->start);
        cgc_json_vec(stdout, "end", it->end);
        if (it->kind == EF_GC_LINE) {
            fputs(", \"feed\": ", stdout);
            cli_json_num(stdout, it->feed);
        }
        break;
    case EF_GC_ARC:
        cgc_json_vec(stdout, "start", it->start);
        cgc_json_vec(stdout, "end", it->end);
        cgc_json_vec(stdout, "centre", it->centre);
        printf(", \"dir\": %d, \"plane\": %d, \"turns\": %d, \"radius\": ", it->dir, it->plane,
               it->turns);
        cli_json_num(stdout, it->radius);
        fputs(", \"radius_end\": ", stdout);
        cli_json_num(stdout, it->radius_end);
        fputs(", \"sweep\": ", stdout);
        cli_json_num(stdout, it->sweep);
        fputs(", \"feed\": ", stdout);
        cli_json_num(stdout, it->feed);
        break;
    case EF_GC_TOLERANCE:
        printf(", \"mode\": \"%s\", \"p\": ",
               it->path_mode == EF_GC_PATH_EXACT ? "exact" : "blend");
        cli_json_num(stdout, it->p_tol);
        fputs(", \"q\": ", stdout);
        cli_json_num(stdout, it->q_tol);
        break;
    default:
        break;
    }
    if ((it->kind == EF_GC_RAPID || it->kind == EF_GC_LINE || it->kind == EF_GC_ZERO_MOVE ||
         it->kind == EF_GC_ARC) &&
        cgc_aux_any(it)) {
        cgc_json_aux(stdout, "abcuvw_start", it->astart);
        cgc_json_aux(stdout, "abcuvw_end", it->aend);
    }
    if (it->text[0]) {
        fputs(", \"text\": ", stdout);
        cli_json_str(stdout, it->text);
    }
    puts("}");
}

/* One item as a line of text. */
static void cgc_print_text(const ef_gcode_item_t *it)
{
    printf("%u:%u %-9s", (unsigned)it->line, (unsigned)it->col, ef_gcode_kind_name(it->kind));
    switch (it->kind) {
    case EF_GC_RAPID:
    case EF_GC_LINE:
    case EF_GC_ZERO_MOVE:
        printf(" %.4f %.4f %.4f -> %.4f %.4f %.4f", it->start[0], it->start[1], it->start[2],
               it->end[0], it->end[1], it->end[2]);
        if (it->kind == EF_GC_LINE)
            printf(" F%.6g", it->feed);
        break;
    case EF_GC_ARC:
        printf(" %.4f %.4f %.4f -> %.4f %.4f %.4f centre %.4f %.4f %.4f %s G%d r %.4f sweep %.2f "
               "deg turns %d"
               " F%.6g",
               it->start[0], it->start[1], it->start[2], it->end[0], it->end[1], it->end[2],
               it->centre[0], it->centre[1], it->centre[2], it->dir > 0 ? "ccw" : "cw", it->plane,
               it->radius, it->sweep * 57.29577951308232, it->turns, it->feed);
        if (fabs(it->radius_end - it->radius) >= 5e-5) /* visible in 4 decimals */
            printf(" spiral to r %.4f", it->radius_end);
        break;
    case EF_GC_TOLERANCE:
        if (it->path_mode == EF_GC_PATH_EXACT)
            printf(" exact");
        else
            printf(" blend P%.6g Q%.6g", it->p_tol, it->q_tol);
        break;
    default:
        break;
    }
    if ((it->kind == EF_GC_RAPID || it->kind == EF_GC_LINE || it->kind == EF_GC_ZERO_MOVE ||
         it->kind == EF_GC_ARC) &&
        cgc_aux_any(it)) {
        static const char names[EF_GCODE_AUX] = {'A', 'B', 'C', 'U', 'V', 'W'};
        fputs(" |", stdout);
        for (int k = 0; k < EF_GCODE_AUX; k++)
            if (it->astart[k] != it->aend[k])
                printf(" %c %.4f -> %.4f", names[k], it->astart[k], it->aend[k]);
            else if (it->aend[k] != 0.0)
                printf(" %c %.4f", names[k], it->aend[k]);
    }
    if (it->text[0])
        printf(" %s", it->text);
    putchar('\n');
}

enum { O_JSON = CLI_LONG };

/* gcode FILE [--json] */
int cli_cmd_gcode(int argc, char **argv)
{
    static const struct option opts[] = {
        {"json", no_argument, NULL, O_JSON}, CLI_MACHINE_OPTIONS, CLI_OPT_HELP, CLI_OPT_END};
    cli_machine_t mc = {0};
    const char *path = NULL;
    int json = 0, c;
    cli_getopt_t g;
    cli_getopt_init(&g, "gcode", usage, argc, argv, "", opts);
    while ((c = cli_getopt(&g)) > CLI_END) {
        if (c == CLI_HELP)
            return EF_OK;
        if (c == O_JSON)
            json = 1;
        else if (cli_machine_opt(&g, c, &mc))
            continue;
        else if (c == CLI_ARG && !path)
            path = g.val;
        else
            return cli_error(EF_ERR_ARG, "usage: evenfeed gcode FILE [--json]");
    }
    if (c < 0)
        return c;
    if (!path)
        return cli_error(EF_ERR_ARG, "usage: evenfeed gcode FILE [--json]");
    static ef_gcode_t r; /* about 50 kB of parameters: not on the stack */
    ef_msg_t m = {{0}};
    int rc = cli_gcode_open(&r, path, &mc);
    if (rc != EF_OK)
        return rc;
    ef_gcode_item_t it;
    do {
        rc = ef_gcode_next(&r, &it, &m);
        if (rc != EF_OK) {
            fflush(stdout);
            ef_gcode_free(&r);
            return cli_error(rc, "%s", m.text);
        }
        if (json)
            cgc_print_json(&it);
        else
            cgc_print_text(&it);
    } while (it.kind != EF_GC_END);
    ef_gcode_free(&r);
    return EF_OK;
}
