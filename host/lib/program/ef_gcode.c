/* SPDX-License-Identifier: Apache-2.0 */
/* G-code reader: the RS274NGC subset of CAM post-processors, as a stream of items. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "evenfeed/host/program/ef_gcode.h"

#define EF_GC_MAX_WORDS  64 /* words on one line */
#define EF_GC_MAX_ASSIGN 32 /* parameter assignments on one line */
#define EF_GC_MAX_DEPTH  64 /* expression nesting: bounds the recursion on hostile input */
#define EF_GC_INCH       25.4

/* Modal groups of G codes (RS274NGC numbering; 0 is the non-modal group). */
enum {
    GR_NONMODAL = 0,
    GR_MOTION = 1,
    GR_PLANE = 2,
    GR_DIST = 3,
    GR_ARCDIST = 4,
    GR_FEEDMODE = 5,
    GR_UNITS = 6,
    GR_CUTTER = 7,
    GR_TOOLLEN = 8,
    GR_RETRACT = 10,
    GR_COORD = 12,
    GR_PATH = 13,
    GR_SPINDLEMODE = 14,
    GR_COUNT = 15
};
/* What a G code does here. */
enum { GA_MODAL, GA_EVENT, GA_IGNORE, GA_UNSUPPORTED };

/* One word of a line, in source order. */
typedef struct {
    char letter;
    int code; /* G and M: value x 10, rounded */
    double v;
    uint32_t col;
} ef_gc_word_t;

/* A pending "#n = value" or "#<name> = value": applied after the whole line is read. */
typedef struct {
    int index; /* numbered parameter, or 0 for a named one */
    char name[EF_GCODE_NAME_MAX + 1];
    double v;
    uint32_t col;
} ef_gc_assign_t;

/* One source line with whitespace and comments removed, and what was read from it. */
typedef struct {
    ef_gcode_t *r;
    char c[EF_GCODE_LINE_MAX + 1];
    uint32_t col[EF_GCODE_LINE_MAX + 1];
    size_t n, i;
    uint32_t end_col;
    int depth;
    int block_delete;
    ef_gc_word_t w[EF_GC_MAX_WORDS];
    int nw;
    int letter[26]; /* index into w + 1, 0 when absent (G and M may repeat) */
    ef_gc_assign_t as[EF_GC_MAX_ASSIGN];
    int nas;
} ef_gc_line_t;

/* Record a sticky error "name:line:col: text". */
__attribute__((format(printf, 3, 4))) static int ef_gc_err(ef_gcode_t *r, uint32_t col,
                                                           const char *fmt, ...)
{
    char text[320];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    r->err = EF_ERR_GCODE;
    snprintf(r->errmsg.text, sizeof r->errmsg.text, "%s:%u:%u: %s", r->name, (unsigned)r->line,
             (unsigned)col, text);
    return EF_ERR_GCODE;
}

/* Upper-case ASCII without the locale. */
static char gc_upper(char ch)
{
    return ch >= 'a' && ch <= 'z' ? (char)(ch - 'a' + 'A') : ch;
}

static int gc_is_digit(char ch)
{
    return ch >= '0' && ch <= '9';
}

static int gc_is_letter(char ch)
{
    return ch >= 'A' && ch <= 'Z';
}

/* ---- expressions ---------------------------------------------------------------------- */

static int gc_value(ef_gc_line_t *L, double *out);

/* The next character, or 0 at the end of the line. */
static char gc_peek(const ef_gc_line_t *L)
{
    return L->i < L->n ? L->c[L->i] : 0;
}

/* Column of the next character (one past the last at the end of the line). */
static uint32_t gc_here(const ef_gc_line_t *L)
{
    return L->i < L->n ? L->col[L->i] : L->end_col;
}

/* Does the text at the cursor start with s? */
static int gc_at(const ef_gc_line_t *L, const char *s)
{
    size_t k = strlen(s);
    return L->i + k <= L->n && memcmp(L->c + L->i, s, k) == 0;
}

/* Expression results must stay finite: NaN or infinity would poison every later position. */
static int gc_finite(ef_gc_line_t *L, double v, uint32_t col, const char *what)
{
    if (!isfinite(v))
        return ef_gc_err(L->r, col, "%s gives a result that is not finite", what);
    return EF_OK;
}

/* An unsigned decimal literal: digits with at most one point (RS274NGC has no exponent). */
static int gc_number(ef_gc_line_t *L, double *out)
{
    char tmp[72];
    size_t k = 0, digits = 0;
    int point = 0;
    uint32_t col = gc_here(L);
    while (L->i < L->n && (gc_is_digit(L->c[L->i]) || (L->c[L->i] == '.' && !point))) {
        if (L->c[L->i] == '.')
            point = 1;
        else
            digits++;
        if (k >= 64)
            return ef_gc_err(L->r, col, "number too long");
        tmp[k++] = L->c[L->i++];
    }
    if (digits == 0)
        return ef_gc_err(L->r, col, "expected a number");
    tmp[k] = 0;
    *out = strtod(tmp, NULL);
    return EF_OK;
}

/* Index of a named parameter, or -1. */
static int gc_named_find(const ef_gcode_t *r, const char *name)
{
    for (int k = 0; k < r->nnamed; k++)
        if (!strcmp(r->named_key[k], name))
            return k;
    return -1;
}

/* After '#': either <name> or a value giving the parameter number. */
static int gc_param_ref(ef_gc_line_t *L, int *index, char *name, uint32_t col)
{
    *index = 0;
    name[0] = 0;
    if (gc_peek(L) == '<') {
        size_t k = 0;
        L->i++;
        while (L->i < L->n && L->c[L->i] != '>') {
            if (k >= EF_GCODE_NAME_MAX)
                return ef_gc_err(L->r, col, "parameter name longer than %d characters",
                                 EF_GCODE_NAME_MAX);
            name[k++] = L->c[L->i++];
        }
        if (L->i >= L->n)
            return ef_gc_err(L->r, col, "parameter name not closed with '>'");
        L->i++;
        if (k == 0)
            return ef_gc_err(L->r, col, "empty parameter name");
        name[k] = 0;
        return EF_OK;
    }
    double v;
    int rc = gc_value(L, &v);
    if (rc)
        return rc;
    double rv = floor(v + 0.5);
    if (fabs(v - rv) > 1e-6 || rv < 1 || rv >= EF_GCODE_NPARAM)
        return ef_gc_err(L->r, col, "parameter number %.6g out of range (#1..#%d)", v,
                         EF_GCODE_NPARAM - 1);
    *index = (int)rv;
    return EF_OK;
}

/* Binary operators inside brackets, by precedence (higher binds tighter). */
static const struct {
    const char *s;
    int prec;
} ef_gc_ops[] = {{"**", 4}, {"*", 3},  {"/", 3},   {"MOD", 3}, {"+", 2},
                 {"-", 2},  {"EQ", 1}, {"NE", 1},  {"GT", 1},  {"GE", 1},
                 {"LT", 1}, {"LE", 1}, {"AND", 0}, {"OR", 0},  {"XOR", 0}};

/* Apply binary operator k; errors point at the operator. */
static int gc_apply(ef_gc_line_t *L, int k, double a, double b, uint32_t col, double *out)
{
    const char *s = ef_gc_ops[k].s;
    double v;
    if (!strcmp(s, "**")) {
        v = pow(a, b);
    } else if (!strcmp(s, "*")) {
        v = a * b;
    } else if (!strcmp(s, "/")) {
        if (b == 0)
            return ef_gc_err(L->r, col, "division by zero");
        v = a / b;
    } else if (!strcmp(s, "MOD")) {
        if (b == 0)
            return ef_gc_err(L->r, col, "MOD by zero");
        v = fmod(a, b);
        if (v < 0) /* RS274NGC: the result takes the sign of the divisor's magnitude */
            v += fabs(b);
    } else if (!strcmp(s, "+")) {
        v = a + b;
    } else if (!strcmp(s, "-")) {
        v = a - b;
    } else if (!strcmp(s, "EQ")) {
        v = a == b;
    } else if (!strcmp(s, "NE")) {
        v = a != b;
    } else if (!strcmp(s, "GT")) {
        v = a > b;
    } else if (!strcmp(s, "GE")) {
        v = a >= b;
    } else if (!strcmp(s, "LT")) {
        v = a < b;
    } else if (!strcmp(s, "LE")) {
        v = a <= b;
    } else if (!strcmp(s, "AND")) {
        v = a != 0 && b != 0;
    } else if (!strcmp(s, "OR")) {
        v = a != 0 || b != 0;
    } else {
        v = (a != 0) != (b != 0);
    }
    int rc = gc_finite(L, v, col, s);
    *out = v;
    return rc;
}

/* Operator at the cursor, or -1. */
static int gc_op_at(const ef_gc_line_t *L)
{
    for (int k = 0; k < (int)(sizeof ef_gc_ops / sizeof ef_gc_ops[0]); k++)
        if (gc_at(L, ef_gc_ops[k].s))
            return k;
    return -1;
}

/* Precedence climbing; all binary operators are left-associative (as LinuxCNC). */
static int gc_expr(ef_gc_line_t *L, int min_prec, double *out)
{
    double lhs, rhs;
    int rc = gc_value(L, &lhs);
    if (rc)
        return rc;
    for (;;) {
        int k = gc_op_at(L);
        if (k < 0 || ef_gc_ops[k].prec < min_prec)
            break;
        uint32_t col = gc_here(L);
        L->i += strlen(ef_gc_ops[k].s);
        rc = gc_expr(L, ef_gc_ops[k].prec + 1, &rhs);
        if (rc)
            return rc;
        rc = gc_apply(L, k, lhs, rhs, col, &lhs);
        if (rc)
            return rc;
    }
    *out = lhs;
    return EF_OK;
}

/* '[' expression ']' with the cursor on '['. */
static int gc_bracket(ef_gc_line_t *L, double *out)
{
    uint32_t col = gc_here(L);
    L->i++;
    int rc = gc_expr(L, 0, out);
    if (rc)
        return rc;
    if (gc_peek(L) != ']') {
        if (L->i >= L->n)
            return ef_gc_err(L->r, col, "unbalanced brackets: '[' not closed");
        return ef_gc_err(L->r, gc_here(L), "expected an operator or ']'");
    }
    L->i++;
    return EF_OK;
}

/* Degrees to radians and back: RS274NGC trigonometry works in degrees. */
#define EF_GC_D2R (3.14159265358979323846 / 180.0)

/* NAME[expr], or ATAN[y]/[x], with the cursor on the name. */
static int gc_function(ef_gc_line_t *L, double *out)
{
    static const char *names[] = {"ATAN", "ABS", "ACOS",  "ASIN", "COS",  "EXP", "FIX",
                                  "FUP",  "LN",  "ROUND", "SIN",  "SQRT", "TAN"};
    uint32_t col = gc_here(L);
    int f = -1;
    for (int k = 0; k < (int)(sizeof names / sizeof names[0]); k++)
        if (gc_at(L, names[k]) && L->i + strlen(names[k]) < L->n &&
            L->c[L->i + strlen(names[k])] == '[') {
            f = k;
            break;
        }
    if (f < 0)
        return ef_gc_err(L->r, col, "expected a number, parameter, '[' or function");
    L->i += strlen(names[f]);
    double a, b = 0, v;
    int rc = gc_bracket(L, &a);
    if (rc)
        return rc;
    switch (f) {
    case 0:
        if (gc_peek(L) != '/' || L->i + 1 >= L->n || L->c[L->i + 1] != '[')
            return ef_gc_err(L->r, gc_here(L), "ATAN needs the form ATAN[y]/[x]");
        L->i++;
        if ((rc = gc_bracket(L, &b)) != 0)
            return rc;
        v = atan2(a, b) / EF_GC_D2R;
        break;
    case 1:
        v = fabs(a);
        break;
    case 2:
    case 3:
        if (a < -1 || a > 1)
            return ef_gc_err(L->r, col, "%s argument %.6g outside [-1, 1]", names[f], a);
        v = (f == 2 ? acos(a) : asin(a)) / EF_GC_D2R;
        break;
    case 4:
        v = cos(a * EF_GC_D2R);
        break;
    case 5:
        v = exp(a);
        break;
    case 6:
        v = floor(a);
        break;
    case 7:
        v = ceil(a);
        break;
    case 8:
        if (a <= 0)
            return ef_gc_err(L->r, col, "LN argument %.6g is not positive", a);
        v = log(a);
        break;
    case 9:
        v = round(a);
        break;
    case 10:
        v = sin(a * EF_GC_D2R);
        break;
    case 11:
        if (a < 0)
            return ef_gc_err(L->r, col, "SQRT of negative %.6g", a);
        v = sqrt(a);
        break;
    default:
        v = tan(a * EF_GC_D2R);
        break;
    }
    *out = v;
    return gc_finite(L, v, col, names[f]);
}

/* A real value: number, parameter, bracketed expression, function, with optional signs. */
static int gc_value(ef_gc_line_t *L, double *out)
{
    char ch = gc_peek(L);
    uint32_t col = gc_here(L);
    int rc;
    if (++L->depth > EF_GC_MAX_DEPTH)
        return ef_gc_err(L->r, col, "expression nested too deeply");
    if (ch == '-' || ch == '+') {
        L->i++;
        rc = gc_value(L, out);
        if (ch == '-')
            *out = -*out;
    } else if (ch == '[') {
        rc = gc_bracket(L, out);
    } else if (ch == '#') {
        int index;
        char name[EF_GCODE_NAME_MAX + 1];
        L->i++;
        rc = gc_param_ref(L, &index, name, col);
        if (!rc && index) {
            *out = L->r->param[index];
        } else if (!rc) {
            int k = gc_named_find(L->r, name);
            if (k < 0)
                rc = ef_gc_err(L->r, col, "parameter #<%s> is not defined", name);
            else
                *out = L->r->named_val[k];
        }
    } else if (gc_is_digit(ch) || ch == '.') {
        rc = gc_number(L, out);
    } else if (gc_is_letter(ch)) {
        rc = gc_function(L, out);
    } else if (ch == 0) {
        rc = ef_gc_err(L->r, col, "value missing at end of line");
    } else {
        rc = ef_gc_err(L->r, col, "expected a value, found '%c'", ch);
    }
    L->depth--;
    return rc;
}

/* ---- lines ---------------------------------------------------------------------------- */

/* Strip whitespace and comments, upper-case the rest, keep each character's column. */
static int gc_compact(ef_gcode_t *r, const char *s, size_t n, ef_gc_line_t *L)
{
    L->n = 0;
    L->i = 0;
    L->block_delete = 0;
    if (n > EF_GCODE_LINE_MAX)
        return ef_gc_err(r, EF_GCODE_LINE_MAX + 1, "line longer than %d bytes", EF_GCODE_LINE_MAX);
    for (size_t k = 0; k < n; k++) {
        char ch = s[k];
        uint32_t col = (uint32_t)k + 1;
        if (ch == ' ' || ch == '\t' || ch == '\r')
            continue;
        if (ch == '(') {
            const char *close = memchr(s + k, ')', n - k);
            if (!close)
                return ef_gc_err(r, col, "comment not closed with ')'");
            if (memchr(s + k, 0, (size_t)(close - (s + k))))
                return ef_gc_err(r, col, "NUL byte in comment");
            k = (size_t)(close - s);
            continue;
        }
        if (ch == ';')
            break;
        if (ch == '/' && L->n == 0 && !L->block_delete) {
            L->block_delete = 1;
            continue;
        }
        if ((unsigned char)ch < 0x21 || (unsigned char)ch > 0x7e)
            return ef_gc_err(r, col, "unexpected byte 0x%02x", (unsigned)(unsigned char)ch);
        L->c[L->n] = gc_upper(ch);
        L->col[L->n] = col;
        L->n++;
    }
    L->end_col = (uint32_t)n + 1;
    return EF_OK;
}

/* G or M value: an integer or one decimal (G59.1, G90.1); anything else is malformed. */
static int gc_code(ef_gc_line_t *L, char letter, double v, uint32_t col, int *code)
{
    double t = v * 10.0, rt = floor(t + 0.5);
    if (fabs(t - rt) > 1e-4 || rt < 0 || rt > 99990)
        return ef_gc_err(L->r, col, "malformed %c code %.6g", letter, v);
    *code = (int)rt;
    return EF_OK;
}

/* Read the words and assignments of a compacted line. */
static int gc_words(ef_gc_line_t *L)
{
    int rc;
    L->nw = 0;
    L->nas = 0;
    memset(L->letter, 0, sizeof L->letter);
    while (L->i < L->n) {
        char ch = L->c[L->i];
        uint32_t col = L->col[L->i];
        L->depth = 0;
        if (ch == '#') {
            if (L->nas >= EF_GC_MAX_ASSIGN)
                return ef_gc_err(L->r, col, "more than %d assignments on one line",
                                 EF_GC_MAX_ASSIGN);
            ef_gc_assign_t *a = &L->as[L->nas];
            L->i++;
            if ((rc = gc_param_ref(L, &a->index, a->name, col)) != 0)
                return rc;
            if (gc_peek(L) != '=')
                return ef_gc_err(L->r, gc_here(L), "expected '=' in parameter assignment");
            L->i++;
            if ((rc = gc_value(L, &a->v)) != 0)
                return rc;
            a->col = col;
            L->nas++;
            continue;
        }
        if (!gc_is_letter(ch))
            return ef_gc_err(L->r, col, "expected a word letter, found '%c'", ch);
        if (strchr("ABCUVW", ch))
            return ef_gc_err(L->r, col, "axis word '%c' not supported (X Y Z only)", ch);
        if (ch == 'O')
            return ef_gc_err(L->r, col, "O-word (subroutines, loops) not supported");
        if (!strchr("DFGHIJKLMNPQRSTXYZ", ch))
            return ef_gc_err(L->r, col, "unsupported word '%c'", ch);
        L->i++;
        if (L->i >= L->n)
            return ef_gc_err(L->r, col, "word '%c' has no value", ch);
        double v;
        if ((rc = gc_value(L, &v)) != 0)
            return rc;
        if (ch == 'N')
            continue; /* line numbers carry no meaning for the path */
        if (L->nw >= EF_GC_MAX_WORDS)
            return ef_gc_err(L->r, col, "more than %d words on one line", EF_GC_MAX_WORDS);
        ef_gc_word_t *w = &L->w[L->nw];
        w->letter = ch;
        w->v = v;
        w->col = col;
        w->code = 0;
        if (ch == 'G' || ch == 'M') {
            if ((rc = gc_code(L, ch, v, col, &w->code)) != 0)
                return rc;
        } else if (L->letter[ch - 'A']) {
            return ef_gc_err(L->r, col, "second %c word on one line", ch);
        } else {
            L->letter[ch - 'A'] = L->nw + 1;
        }
        L->nw++;
    }
    return EF_OK;
}

/* The word for a letter, or NULL. */
static const ef_gc_word_t *gc_get(const ef_gc_line_t *L, char letter)
{
    int k = L->letter[letter - 'A'];
    return k ? &L->w[k - 1] : NULL;
}

/* Group and action of a G code (value x 10). */
static void gc_gclass(int code, int *group, int *action)
{
    *action = GA_MODAL;
    switch (code) {
    case 0:
    case 10:
    case 20:
    case 30:
        *group = GR_MOTION;
        return;
    case 800:
        *group = GR_MOTION;
        *action = GA_IGNORE;
        return;
    case 40:
    case 530:
        *group = GR_NONMODAL;
        *action = GA_EVENT;
        return;
    case 170:
    case 180:
    case 190:
        *group = GR_PLANE;
        return;
    case 200:
    case 210:
        *group = GR_UNITS;
        return;
    case 900:
    case 910:
        *group = GR_DIST;
        return;
    case 901:
    case 911:
        *group = GR_ARCDIST;
        return;
    case 940:
        *group = GR_FEEDMODE;
        *action = GA_IGNORE;
        return;
    case 400:
        *group = GR_CUTTER;
        *action = GA_IGNORE;
        return;
    case 430:
    case 431:
    case 490:
        *group = GR_TOOLLEN;
        *action = GA_EVENT;
        return;
    case 980:
    case 990:
        *group = GR_RETRACT;
        *action = GA_IGNORE;
        return;
    case 540:
    case 550:
    case 560:
    case 570:
    case 580:
    case 590:
    case 591:
    case 592:
    case 593:
        *group = GR_COORD;
        *action = GA_EVENT;
        return;
    case 610:
    case 611:
    case 640:
        *group = GR_PATH;
        return;
    case 960:
    case 970:
        *group = GR_SPINDLEMODE;
        *action = GA_IGNORE;
        return;
    default:
        *group = -1;
        *action = GA_UNSUPPORTED;
        return;
    }
}

/* Why a G code is refused, for the message. */
static const char *gc_why(int code)
{
    if (code >= 730 && code <= 890)
        return "canned cycle";
    if (code == 410 || code == 420 || code == 411 || code == 421)
        return "cutter radius compensation";
    if (code == 280 || code == 281 || code == 300 || code == 301)
        return "return to a stored position (machine coordinates)";
    if (code == 330 || code == 331 || code == 760)
        return "threading";
    if (code >= 380 && code <= 385)
        return "probing";
    if (code >= 50 && code <= 53)
        return "spline";
    if (code == 100 || (code >= 920 && code <= 923) || code == 520)
        return "coordinate system change";
    if (code == 930)
        return "inverse-time feed";
    if (code == 950)
        return "feed per revolution";
    return "not in the supported subset";
}

/* Format a G/M code: G1, G59.1. */
static void gc_fmt_code(char *buf, size_t n, char letter, int code)
{
    if (code % 10)
        snprintf(buf, n, "%c%d.%d", letter, code / 10, code % 10);
    else
        snprintf(buf, n, "%c%d", letter, code / 10);
}

/* Append one word to an event text ("T1 M6"). */
static void gc_append(char *text, size_t n, const ef_gc_word_t *w)
{
    char tmp[40];
    size_t len = strlen(text);
    if (w->letter == 'G' || w->letter == 'M')
        gc_fmt_code(tmp, sizeof tmp, w->letter, w->code);
    else
        snprintf(tmp, sizeof tmp, "%c%.6g", w->letter, w->v);
    snprintf(text + len, n - len, "%s%s", len ? " " : "", tmp);
}

/* A fresh queue item of a kind. */
static ef_gcode_item_t *gc_push(ef_gcode_t *r, int kind, uint32_t col)
{
    ef_gcode_item_t *it = &r->queue[r->qlen++];
    memset(it, 0, sizeof *it);
    it->kind = kind;
    it->line = r->line;
    it->col = col;
    it->units = r->units;
    return it;
}

/* Coordinates must be finite and within range before they become positions. */
static int gc_coord_ok(ef_gcode_t *r, double v, uint32_t col, const char *what)
{
    if (!isfinite(v) || fabs(v) > EF_GCODE_MAX_COORD)
        return ef_gc_err(r, col, "%s %.6g mm outside +-%g mm", what, v, EF_GCODE_MAX_COORD);
    return EF_OK;
}

/* Plane axes: first and second in-plane axis, normal, and the offset letters of each. */
static void gc_plane_axes(int plane, int *a, int *b, int *nrm, char *la, char *lb, char *ln)
{
    if (plane == 18) {
        *a = 2, *b = 0, *nrm = 1, *la = 'K', *lb = 'I', *ln = 'J';
    } else if (plane == 19) {
        *a = 1, *b = 2, *nrm = 0, *la = 'J', *lb = 'K', *ln = 'I';
    } else {
        *a = 0, *b = 1, *nrm = 2, *la = 'I', *lb = 'J', *ln = 'K';
    }
}

#define EF_GC_TWO_PI (2.0 * 3.14159265358979323846)

/* Build an arc item from the current position to end; errors point at col. */
static int gc_arc(ef_gcode_t *r, const ef_gc_line_t *L, const double end[3], int g3, double scale,
                  uint32_t col)
{
    int a, b, nrm;
    char la, lb, ln;
    gc_plane_axes(r->plane, &a, &b, &nrm, &la, &lb, &ln);
    const ef_gc_word_t *wa = gc_get(L, la), *wb = gc_get(L, lb), *wn = gc_get(L, ln),
                       *wr = gc_get(L, 'R'), *wp = gc_get(L, 'P');
    const char *gname = g3 ? "G3" : "G2";
    double c[3] = {r->cur[0], r->cur[1], r->cur[2]};
    double sa = r->cur[a], sb = r->cur[b], ea = end[a], eb = end[b];
    double chord = hypot(ea - sa, eb - sb), radius;
    int turns = 1, rc;
    if (wn)
        return ef_gc_err(r, wn->col, "%c word on a G%d-plane arc", ln, r->plane);
    if (wp) {
        if (wp->v < 1 || wp->v != floor(wp->v) || wp->v > 1e6)
            return ef_gc_err(r, wp->col, "%s P (turns) must be a whole number >= 1, got %.6g",
                             gname, wp->v);
        turns = (int)wp->v;
    }
    if (wr && (wa || wb))
        return ef_gc_err(r, wr->col, "%s with both R and %c%c offsets", gname, la, lb);
    if (wr) {
        double R = wr->v * scale, h2, h;
        if ((rc = gc_coord_ok(r, R, wr->col, "arc radius")) != 0)
            return rc;
        if (chord <= EF_GCODE_ZERO_LEN)
            return ef_gc_err(r, wr->col,
                             "%s R form with end equal to start (a full circle needs IJK)", gname);
        radius = fabs(R);
        h2 = radius * radius - chord * chord / 4;
        if (h2 < 0) {
            if (chord / 2 - radius > fmax(EF_GCODE_ARC_ABS_TOL, EF_GCODE_ARC_REL_TOL * radius))
                return ef_gc_err(r, wr->col, "%s radius %.4f smaller than half the chord %.4f",
                                 gname, radius, chord / 2);
            h2 = 0;
            radius = chord / 2;
        }
        h = sqrt(h2);
        /* Left of the chord for a short CCW arc, right for a short CW one; R < 0 flips. */
        double side = (g3 ? 1.0 : -1.0) * (R < 0 ? -1.0 : 1.0);
        double ua = (ea - sa) / chord, ub = (eb - sb) / chord;
        c[a] = (sa + ea) / 2 + side * h * -ub;
        c[b] = (sb + eb) / 2 + side * h * ua;
    } else {
        if (!wa && !wb)
            return ef_gc_err(r, col, "%s needs %c%c offsets or R", gname, la, lb);
        double oa = wa ? wa->v * scale : 0, ob = wb ? wb->v * scale : 0;
        if (wa && (rc = gc_coord_ok(r, oa, wa->col, "arc centre offset")) != 0)
            return rc;
        if (wb && (rc = gc_coord_ok(r, ob, wb->col, "arc centre offset")) != 0)
            return rc;
        c[a] = r->arc_absolute ? oa : sa + oa;
        c[b] = r->arc_absolute ? ob : sb + ob;
        if ((rc = gc_coord_ok(r, c[a], col, "arc centre")) != 0 ||
            (rc = gc_coord_ok(r, c[b], col, "arc centre")) != 0)
            return rc;
        radius = hypot(sa - c[a], sb - c[b]);
        double r1 = hypot(ea - c[a], eb - c[b]);
        double tol = fmax(EF_GCODE_ARC_ABS_TOL, EF_GCODE_ARC_REL_TOL * radius);
        if (radius <= EF_GCODE_ZERO_LEN)
            return ef_gc_err(r, col, "%s arc radius is zero (centre at the start)", gname);
        if (fabs(r1 - radius) > tol)
            return ef_gc_err(r, col, "%s arc radius mismatch: start %.3f end %.3f (tolerance %.3f)",
                             gname, radius, r1, tol);
    }
    double sweep;
    if (chord <= EF_GCODE_ZERO_LEN) {
        sweep = EF_GC_TWO_PI;
    } else {
        sweep = atan2(eb - c[b], ea - c[a]) - atan2(sb - c[b], sa - c[a]);
        if (g3)
            while (sweep <= 0)
                sweep += EF_GC_TWO_PI;
        else
            while (sweep >= 0)
                sweep -= EF_GC_TWO_PI;
        sweep = fabs(sweep);
    }
    sweep += (turns - 1) * EF_GC_TWO_PI;
    ef_gcode_item_t *it = gc_push(r, EF_GC_ARC, col);
    memcpy(it->start, r->cur, sizeof it->start);
    memcpy(it->end, end, sizeof it->end);
    memcpy(it->centre, c, sizeof it->centre);
    it->radius = radius;
    it->sweep = g3 ? sweep : -sweep;
    it->dir = g3 ? 1 : -1;
    it->plane = r->plane;
    it->turns = turns;
    it->feed = r->feed;
    return EF_OK;
}

/* Carry out one read line: modal settings, events, tolerance, motion, stop. */
static int gc_execute(ef_gcode_t *r, ef_gc_line_t *L)
{
    const ef_gc_word_t *grp[GR_COUNT] = {0};
    const ef_gc_word_t *mgrp[10] = {0};
    const ef_gc_word_t *stop = NULL, *wf = gc_get(L, 'F');
    char pre[128] = "", post[128] = "";
    uint32_t pre_col = 0, post_col = 0;
    int rc, action, group;
    char name[16];

    /* Modal-group conflicts and unsupported codes first, so nothing of a bad line happens. */
    for (int k = 0; k < L->nw; k++) {
        const ef_gc_word_t *w = &L->w[k];
        if (w->letter == 'G') {
            gc_gclass(w->code, &group, &action);
            gc_fmt_code(name, sizeof name, 'G', w->code);
            if (action == GA_UNSUPPORTED)
                return ef_gc_err(r, w->col, "unsupported %s (%s)", name, gc_why(w->code));
            if (grp[group]) {
                char other[16];
                gc_fmt_code(other, sizeof other, 'G', grp[group]->code);
                return ef_gc_err(r, w->col, "%s and %s on one line are in the same modal group",
                                 other, name);
            }
            grp[group] = w;
        } else if (w->letter == 'M') {
            int c = w->code, mg = -1;
            gc_fmt_code(name, sizeof name, 'M', c);
            if (c % 10 || c > 1990 || c == 470 || c == 980 || c == 990)
                return ef_gc_err(r, w->col, "unsupported %s", name);
            if (c == 0 || c == 10 || c == 20 || c == 300 || c == 600)
                mg = 4;
            else if (c == 60)
                mg = 6;
            else if (c >= 30 && c <= 50)
                mg = 7;
            else if (c == 90)
                mg = 8; /* M7 and M8 may share a line (both coolants on): only M9 is checked */
            if (mg >= 0 && mgrp[mg]) {
                char other[16];
                gc_fmt_code(other, sizeof other, 'M', mgrp[mg]->code);
                return ef_gc_err(r, w->col, "%s and %s on one line are in the same modal group",
                                 other, name);
            }
            if (mg >= 0)
                mgrp[mg] = w;
        }
    }

    /* Modal settings take effect before the line's values are read as coordinates. */
    if (grp[GR_UNITS])
        r->units = grp[GR_UNITS]->code == 200 ? 20 : 21;
    if (grp[GR_PLANE])
        r->plane = grp[GR_PLANE]->code / 10;
    if (grp[GR_DIST])
        r->absolute = grp[GR_DIST]->code == 900;
    if (grp[GR_ARCDIST])
        r->arc_absolute = grp[GR_ARCDIST]->code == 901;
    double scale = r->units == 20 ? EF_GC_INCH : 1.0;

    /* F: read in this line's units, kept in mm/min across later unit changes. */
    if (wf) {
        double f = wf->v * scale;
        if (!isfinite(f) || f < 0 || f > EF_GCODE_MAX_FEED)
            return ef_gc_err(r, wf->col, "feed F%.6g outside 0..%g mm/min", wf->v,
                             EF_GCODE_MAX_FEED);
        r->feed = f;
    }

    /* Which words have a use on this line. */
    int motion_word = grp[GR_MOTION] && grp[GR_MOTION]->code != 800;
    int motion = r->motion;
    if (grp[GR_MOTION])
        motion = motion_word ? grp[GR_MOTION]->code / 10 + 1 : 0;
    const ef_gc_word_t *axis[3] = {gc_get(L, 'X'), gc_get(L, 'Y'), gc_get(L, 'Z')};
    const ef_gc_word_t *first_axis = NULL;
    for (int k = 0; k < 3; k++)
        if (axis[k] && (!first_axis || axis[k]->col < first_axis->col))
            first_axis = axis[k];
    int g4 = grp[GR_NONMODAL] && grp[GR_NONMODAL]->code == 40;
    int g53 = grp[GR_NONMODAL] && grp[GR_NONMODAL]->code == 530;
    int arc = (motion == 3 || motion == 4) && first_axis && !g53;
    int g64 = grp[GR_PATH] && grp[GR_PATH]->code == 640;
    if (first_axis && motion == 0)
        return ef_gc_err(r, first_axis->col, "axis word with no motion mode (G0, G1, G2 or G3)");
    if (g53 && motion != 1 && motion != 2)
        return ef_gc_err(r, grp[GR_NONMODAL]->col, "G53 needs G0 or G1");
    static const char arc_letters[] = "IJKR";
    for (int k = 0; k < 4; k++) {
        const ef_gc_word_t *w = gc_get(L, arc_letters[k]);
        if (w && !arc) {
            if ((motion == 3 || motion == 4) && !first_axis)
                return ef_gc_err(r, w->col, "%s with no X, Y or Z word", motion == 3 ? "G2" : "G3");
            return ef_gc_err(r, w->col, "%c word with no G2/G3 arc", arc_letters[k]);
        }
    }
    const ef_gc_word_t *wp = gc_get(L, 'P'), *wq = gc_get(L, 'Q');
    if (wp && !g4 && !g64 && !arc)
        return ef_gc_err(r, wp->col, "P word with no G4, G64 or G2/G3 arc");
    if (wq && !g64)
        return ef_gc_err(r, wq->col, "Q word with no G64");
    if (wq && !wp)
        return ef_gc_err(r, wq->col, "G64 Q needs a P tolerance");
    if (g4 && (!wp || !(wp->v >= 0)))
        return ef_gc_err(r, grp[GR_NONMODAL]->col, "G4 needs a dwell time P >= 0");

    /* Pass-through words, in source order: before the motion, except the stops after it. */
    for (int k = 0; k < L->nw; k++) {
        const ef_gc_word_t *w = &L->w[k];
        int is_pre = 0;
        if (w->letter == 'G') {
            gc_gclass(w->code, &group, &action);
            is_pre = action == GA_EVENT && w->code != 530;
        } else if (w->letter == 'M') {
            if (w->code == 20 || w->code == 300) {
                stop = w;
            } else if (w->code == 0 || w->code == 10 || w->code == 600) {
                gc_append(post, sizeof post, w);
                post_col = post_col ? post_col : w->col;
            } else {
                is_pre = 1;
            }
        } else if (strchr("DHLST", w->letter) || (w->letter == 'P' && g4)) {
            is_pre = 1;
        }
        if (is_pre) {
            gc_append(pre, sizeof pre, w);
            pre_col = pre_col ? pre_col : w->col;
        }
    }
    if (pre[0]) {
        ef_gcode_item_t *it = gc_push(r, EF_GC_EVENT, pre_col);
        snprintf(it->text, sizeof it->text, "%s", pre);
    }
    /* Accepted words with no effect on the path: one note each, the first time only. */
    static const int ignored[] = {800, 940, 400, 980, 990, 960, 970};
    for (int k = 0; k < L->nw; k++) {
        const ef_gc_word_t *w = &L->w[k];
        for (int j = 0; j < (int)(sizeof ignored / sizeof ignored[0]); j++)
            if (w->letter == 'G' && w->code == ignored[j] && !(r->ignored_seen & (1u << j))) {
                r->ignored_seen |= 1u << j;
                ef_gcode_item_t *it = gc_push(r, EF_GC_IGNORED, w->col);
                gc_fmt_code(it->text, sizeof it->text, 'G', w->code);
            }
    }
    if (L->block_delete && !(r->ignored_seen & (1u << 8))) {
        r->ignored_seen |= 1u << 8;
        ef_gcode_item_t *it = gc_push(r, EF_GC_IGNORED, 1);
        snprintf(it->text, sizeof it->text, "/ (block delete is off: such lines are read)");
    }
    if (grp[GR_PATH]) {
        ef_gcode_item_t *it = gc_push(r, EF_GC_TOLERANCE, grp[GR_PATH]->col);
        it->path_mode = g64 ? EF_GC_PATH_BLEND : EF_GC_PATH_EXACT;
        if (wp && g64) {
            it->p_tol = wp->v * scale;
            if ((rc = gc_coord_ok(r, it->p_tol, wp->col, "G64 P")) != 0)
                return rc;
            if (it->p_tol < 0)
                return ef_gc_err(r, wp->col, "G64 P tolerance must not be negative");
        }
        if (wq) {
            it->q_tol = wq->v * scale;
            if ((rc = gc_coord_ok(r, it->q_tol, wq->col, "G64 Q")) != 0)
                return rc;
            if (it->q_tol < 0)
                return ef_gc_err(r, wq->col, "G64 Q tolerance must not be negative");
        }
    }

    /* Motion. */
    r->motion = motion;
    if (first_axis) {
        double end[3];
        uint32_t col = grp[GR_MOTION] && motion_word ? grp[GR_MOTION]->col : first_axis->col;
        for (int k = 0; k < 3; k++) {
            end[k] = r->cur[k];
            if (axis[k]) {
                double v = axis[k]->v * scale;
                end[k] = r->absolute || g53 ? v : r->cur[k] + v;
                if ((rc = gc_coord_ok(r, end[k], axis[k]->col, "coordinate")) != 0)
                    return rc;
            }
        }
        if (motion != 1 && !(r->feed > 0))
            return ef_gc_err(r, col, "feed move with no feed rate (F missing or zero)");
        if (g53) {
            /* Machine coordinates are unknown here: pass the move on, keep the position. */
            ef_gcode_item_t *it = gc_push(r, EF_GC_EVENT, grp[GR_NONMODAL]->col);
            char tmp[64];
            snprintf(it->text, sizeof it->text, "G53 G%d", motion - 1);
            for (int k = 0; k < 3; k++)
                if (axis[k]) {
                    snprintf(tmp, sizeof tmp, " %c%.6g", "XYZ"[k], axis[k] -> v);
                    strncat(it->text, tmp, sizeof it->text - strlen(it->text) - 1);
                }
        } else if (motion == 3 || motion == 4) {
            if ((rc = gc_arc(r, L, end, motion == 4, scale, col)) != 0)
                return rc;
            memcpy(r->cur, end, sizeof end);
        } else {
            double len = sqrt((end[0] - r->cur[0]) * (end[0] - r->cur[0]) +
                              (end[1] - r->cur[1]) * (end[1] - r->cur[1]) +
                              (end[2] - r->cur[2]) * (end[2] - r->cur[2]));
            int zero = len <= EF_GCODE_ZERO_LEN;
            ef_gcode_item_t *it = gc_push(r,
                                          zero          ? EF_GC_ZERO_MOVE
                                          : motion == 1 ? EF_GC_RAPID
                                                        : EF_GC_LINE,
                                          col);
            memcpy(it->start, r->cur, sizeof it->start);
            memcpy(it->end, zero ? r->cur : end, sizeof it->end);
            if (motion == 2)
                it->feed = r->feed;
            if (zero)
                snprintf(it->text, sizeof it->text, "G%d", motion - 1);
            else
                memcpy(r->cur, end, sizeof end);
        }
    }
    if (post[0]) {
        ef_gcode_item_t *it = gc_push(r, EF_GC_EVENT, post_col);
        snprintf(it->text, sizeof it->text, "%s", post);
    }
    if (stop) {
        ef_gcode_item_t *it = gc_push(r, EF_GC_END, stop->col);
        gc_fmt_code(it->text, sizeof it->text, 'M', stop->code);
        r->end_item = *it;
        r->ended = 1;
    }

    /* Assignments take effect after the line, as in RS274NGC. */
    for (int k = 0; k < L->nas; k++) {
        const ef_gc_assign_t *a = &L->as[k];
        if (a->index) {
            r->param[a->index] = a->v;
            continue;
        }
        int j = gc_named_find(r, a->name);
        if (j < 0) {
            if (r->nnamed >= EF_GCODE_NNAMED)
                return ef_gc_err(r, a->col, "more than %d named parameters", EF_GCODE_NNAMED);
            j = r->nnamed++;
            snprintf(r->named_key[j], sizeof r->named_key[j], "%s", a->name);
        }
        r->named_val[j] = a->v;
    }
    return EF_OK;
}

/* Read the next source line into the queue. */
static int gc_line(ef_gcode_t *r)
{
    ef_gc_line_t *line = malloc(sizeof *line); /* about 25 kB: kept off the stack */
    if (!line)
        return ef_gc_err(r, 1, "out of memory");
    const char *s = r->text + r->pos;
    size_t rest = r->len - r->pos;
    const char *nl = memchr(s, '\n', rest);
    size_t n = nl ? (size_t)(nl - s) : rest;
    r->pos += nl ? n + 1 : n;
    r->line++;
    r->qhead = r->qlen = 0;
    line->r = r;
    int rc = gc_compact(r, s, n, line);
    if (!rc && line->n == 1 && line->c[0] == '%') {
        if (r->line_seen || r->percent) {
            ef_gcode_item_t *it = gc_push(r, EF_GC_END, line->col[0]);
            snprintf(it->text, sizeof it->text, "%%");
            r->end_item = *it;
            r->ended = 1;
        } else {
            r->percent = 1;
        }
    } else if (!rc && line->n) {
        r->line_seen = 1;
        rc = gc_words(line);
        if (!rc)
            rc = gc_execute(r, line);
    }
    free(line);
    if (rc)
        r->qhead = r->qlen = 0;
    return rc;
}

int ef_gcode_init(ef_gcode_t *r, const char *text, size_t len, const char *name)
{
    if (!r || (!text && len))
        return EF_ERR_ARG;
    memset(r, 0, sizeof *r);
    r->text = text ? text : "";
    r->len = len;
    snprintf(r->name, sizeof r->name, "%s", name ? name : "<gcode>");
    r->units = 21;
    r->absolute = 1;
    r->arc_absolute = 0;
    r->plane = 17;
    return EF_OK;
}

int ef_gcode_open(ef_gcode_t *r, const char *path, ef_msg_t *m)
{
    if (!r || !path)
        return ef_fail(m, EF_ERR_ARG, "ef_gcode_open: NULL argument");
    memset(r, 0, sizeof *r);
    FILE *f = fopen(path, "rb");
    if (!f)
        return ef_fail(m, EF_ERR_IO, "%s: %s", path, strerror(errno));
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len == cap) {
            if (cap >= EF_GCODE_FILE_MAX) {
                free(buf);
                fclose(f);
                return ef_fail(m, EF_ERR_IO, "%s: larger than %zu bytes", path, EF_GCODE_FILE_MAX);
            }
            cap = cap ? cap * 2 : 65536;
            char *grown = realloc(buf, cap + 1);
            if (!grown) {
                free(buf);
                fclose(f);
                return ef_fail(m, EF_ERR_NOMEM, "%s: out of memory", path);
            }
            buf = grown;
        }
        size_t got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        return ef_fail(m, EF_ERR_IO, "%s: read error", path);
    }
    ef_gcode_init(r, buf, len, path);
    r->buf = buf;
    return EF_OK;
}

void ef_gcode_free(ef_gcode_t *r)
{
    if (r) {
        free(r->buf);
        r->buf = NULL;
        r->text = "";
        r->len = 0;
    }
}

int ef_gcode_next(ef_gcode_t *r, ef_gcode_item_t *it, ef_msg_t *m)
{
    if (!r || !it)
        return ef_fail(m, EF_ERR_ARG, "ef_gcode_next: NULL argument");
    while (!r->err && r->qhead == r->qlen) {
        if (r->ended) {
            *it = r->end_item;
            return EF_OK;
        }
        if (r->pos >= r->len) {
            r->qhead = r->qlen = 0;
            ef_gcode_item_t *e = gc_push(r, EF_GC_END, 1);
            e->line = r->line ? r->line : 1;
            snprintf(e->text, sizeof e->text, "end of text");
            r->end_item = *e;
            r->ended = 1;
            break;
        }
        gc_line(r);
    }
    if (r->err) {
        if (m)
            *m = r->errmsg;
        return r->err;
    }
    *it = r->queue[r->qhead++];
    return EF_OK;
}

const char *ef_gcode_kind_name(int kind)
{
    static const char *names[] = {"?",     "rapid",   "line",      "arc", "zero",
                                  "event", "ignored", "tolerance", "end"};
    return kind >= 1 && kind <= EF_GC_END ? names[kind] : "?";
}
