/* SPDX-License-Identifier: Apache-2.0 */
/* The machine's state a program starts from, as LinuxCNC keeps it between runs: the
 * parameter file (work offsets, G28/G30 positions, the active coordinate system) and the
 * tool table (docs/gcode.md "The machine's files"). Both are read line by line; a line that
 * is not understood is an error naming file and line, and nothing of the file is applied. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "ef_gcode_int.h"

/* Longest line either file may have (bytes). */
#define GM_LINE_MAX 512

/* Read a whole text file of at most EF_GCODE_FILE_MAX bytes; the caller frees *out. */
static int gm_slurp(const char *path, char **out, size_t *len, ef_msg_t *m)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return ef_fail(m, EF_ERR_IO, "%s: %s", path, strerror(errno));
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    int rc = buf ? EF_OK : ef_fail(m, EF_ERR_NOMEM, "%s: out of memory", path);
    while (rc == EF_OK) {
        if (n == cap) {
            char *g = cap >= EF_GCODE_FILE_MAX ? NULL : realloc(buf, cap * 2);
            if (!g) {
                rc = ef_fail(m, cap >= EF_GCODE_FILE_MAX ? EF_ERR_IO : EF_ERR_NOMEM,
                             "%s: too large or out of memory", path);
                break;
            }
            buf = g;
            cap *= 2;
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (got == 0) {
            if (ferror(f))
                rc = ef_fail(m, EF_ERR_IO, "%s: read error", path);
            break;
        }
    }
    fclose(f);
    if (rc != EF_OK) {
        free(buf);
        return rc;
    }
    *out = buf;
    *len = n;
    return EF_OK;
}

/* Next line of buf[*pos..len) into line (NUL-terminated, comment from ';' cut); 0 at end. */
static int gm_line(const char *buf, size_t len, size_t *pos, char *line, size_t *n)
{
    if (*pos >= len)
        return 0;
    size_t k = 0, i = *pos;
    while (i < len && buf[i] != '\n') {
        if (k < GM_LINE_MAX)
            line[k] = buf[i];
        k++;
        i++;
    }
    *pos = i + 1;
    *n = k;
    if (k > GM_LINE_MAX)
        k = GM_LINE_MAX;
    line[k] = 0;
    char *c = strchr(line, ';');
    if (c)
        *c = 0;
    for (char *p = line; *p; p++)
        if (*p == '\r' || *p == '\t')
            *p = ' ';
    return 1;
}

/* A finite number filling the whole token; 0 if it is not one. */
static int gm_num(const char *tok, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(tok, &end);
    return tok[0] && *end == 0 && errno == 0 && isfinite(*v);
}

int ef_gcode_load_params(ef_gcode_t *r, const char *path, ef_msg_t *m)
{
    if (!r || !path)
        return ef_fail(m, EF_ERR_ARG, "ef_gcode_load_params: NULL argument");
    if (r->line_seen || r->pos)
        return ef_fail(m, EF_ERR_ARG, "%s: parameters load before the program is read", path);
    char *buf, line[GM_LINE_MAX + 1];
    size_t len, pos = 0, n;
    int rc = gm_slurp(path, &buf, &len, m);
    if (rc != EF_OK)
        return rc;
    /* parsed first, applied after: a bad line leaves the reader as it was */
    struct gm_set {
        int num;
        double v;
    } *set = malloc(EF_GCODE_NPARAM * sizeof *set);
    int nset = 0, ln = 0, cs = 0;
    if (!set) {
        free(buf);
        return ef_fail(m, EF_ERR_NOMEM, "%s: out of memory", path);
    }
    while (rc == EF_OK && gm_line(buf, len, &pos, line, &n)) {
        ln++;
        char *save, *a = strtok_r(line, " ", &save), *b = a ? strtok_r(NULL, " ", &save) : NULL;
        double num, v;
        if (!a)
            continue; /* blank or comment */
        if (n > GM_LINE_MAX)
            rc = ef_fail(m, EF_ERR_ARG, "%s:%d: line longer than %d bytes", path, ln, GM_LINE_MAX);
        else if (!b || strtok_r(NULL, " ", &save))
            rc = ef_fail(m, EF_ERR_ARG, "%s:%d: expected 'NUMBER VALUE'", path, ln);
        else if (!gm_num(a, &num) || num != floor(num) || num < 1 || num >= EF_GCODE_NPARAM)
            rc = ef_fail(m, EF_ERR_ARG, "%s:%d: parameter number '%s' not a whole number 1..%d",
                         path, ln, a, EF_GCODE_NPARAM - 1);
        else if (!gm_num(b, &v) || fabs(v) > EF_GCODE_MAX_COORD)
            rc = ef_fail(m, EF_ERR_ARG, "%s:%d: value '%s' of #%s not a number within +-%g", path,
                         ln, b, a, EF_GCODE_MAX_COORD);
        else if (num == 5220 && (v != floor(v) || v < 1 || v > 9))
            rc =
                ef_fail(m, EF_ERR_ARG, "%s:%d: #5220 (coordinate system) %s not 1..9", path, ln, b);
        else if (nset >= EF_GCODE_NPARAM)
            rc = ef_fail(m, EF_ERR_ARG, "%s:%d: more than %d lines", path, ln, EF_GCODE_NPARAM);
        else {
            if (num == 5220)
                cs = (int)v;
            set[nset].num = (int)num;
            set[nset].v = v;
            nset++;
        }
    }
    free(buf);
    if (rc == EF_OK)
        for (int k = 0; k < nset; k++)
            ef_gc_param_set(r, set[k].num, set[k].v);
    free(set);
    if (rc != EF_OK)
        return rc;
    if (cs)
        r->cs = cs;
    return EF_OK;
}

int ef_gcode_load_tools(ef_gcode_t *r, const char *path, ef_msg_t *m)
{
    if (!r || !path)
        return ef_fail(m, EF_ERR_ARG, "ef_gcode_load_tools: NULL argument");
    if (r->line_seen || r->pos)
        return ef_fail(m, EF_ERR_ARG, "%s: the tool table loads before the program is read", path);
    char *buf, line[GM_LINE_MAX + 1];
    size_t len, pos = 0, n;
    int rc = gm_slurp(path, &buf, &len, m);
    if (rc != EF_OK)
        return rc;
    ef_gcode_tool_t tab[EF_GCODE_NTOOLS];
    int ntab = 0, ln = 0;
    while (rc == EF_OK && gm_line(buf, len, &pos, line, &n)) {
        ln++;
        if (n > GM_LINE_MAX) {
            rc = ef_fail(m, EF_ERR_ARG, "%s:%d: line longer than %d bytes", path, ln, GM_LINE_MAX);
            break;
        }
        ef_gcode_tool_t t;
        memset(&t, 0, sizeof t);
        int have_t = 0, words = 0;
        char *save;
        for (char *tok = strtok_r(line, " ", &save); tok && rc == EF_OK;
             tok = strtok_r(NULL, " ", &save)) {
            char L = tok[0] >= 'a' && tok[0] <= 'z' ? (char)(tok[0] - 32) : tok[0];
            double v;
            words++;
            if (!strchr("TPXYZABCUVWDIJQ", L) || !gm_num(tok + 1, &v)) {
                rc = ef_fail(m, EF_ERR_ARG, "%s:%d: '%s' is not a tool table word", path, ln, tok);
            } else if (L == 'T') {
                if (v != floor(v) || v < 0 || v > 99999)
                    rc = ef_fail(m, EF_ERR_ARG, "%s:%d: tool number %s not 0..99999", path, ln,
                                 tok + 1);
                t.tool = (int)v;
                have_t = 1;
            } else if (L >= 'X' && L <= 'Z') {
                if (fabs(v) > EF_GCODE_MAX_COORD)
                    rc = ef_fail(m, EF_ERR_ARG, "%s:%d: offset %s beyond +-%g mm", path, ln, tok,
                                 EF_GCODE_MAX_COORD);
                t.off[L - 'X'] = v;
            } else if (L == 'D') {
                t.diameter = fabs(v);
            } else if (strchr("ABCUVW", L) && v != 0) {
                rc = ef_fail(m, EF_ERR_ARG,
                             "%s:%d: %s: offsets of axes other than X Y Z are not "
                             "supported",
                             path, ln, tok);
            } /* P (pocket), I J Q (lathe angles and orientation): not used here */
        }
        if (rc != EF_OK || !words)
            continue;
        if (!have_t) {
            rc = ef_fail(m, EF_ERR_ARG, "%s:%d: no T word", path, ln);
            break;
        }
        for (int k = 0; k < ntab; k++)
            if (tab[k].tool == t.tool)
                rc = ef_fail(m, EF_ERR_ARG, "%s:%d: tool %d listed twice", path, ln, t.tool);
        if (rc == EF_OK && ntab + r->ntools >= EF_GCODE_NTOOLS)
            rc = ef_fail(m, EF_ERR_ARG, "%s:%d: more than %d tools", path, ln, EF_GCODE_NTOOLS);
        if (rc == EF_OK)
            tab[ntab++] = t;
    }
    free(buf);
    if (rc != EF_OK)
        return rc;
    for (int k = 0; k < ntab; k++) {
        ef_gcode_tool_t *t = ef_gc_tool(r, tab[k].tool, 1);
        if (t)
            *t = tab[k];
    }
    return EF_OK;
}
