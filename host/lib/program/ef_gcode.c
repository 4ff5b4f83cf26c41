/* SPDX-License-Identifier: Apache-2.0 */
/* G-code reader: RS274NGC as LinuxCNC reads it (docs/gcode.md), as a stream of items.
 * This file holds lines, words, expressions, parameters, offsets and motion; O-words are
 * in ef_gcode_flow.c and canned cycles in ef_gcode_cycle.c. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "ef_gcode_int.h"

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
    GR_LATHE = 15,
    GR_COUNT = 16
};
/* What a G code does here. */
enum { GA_MODAL, GA_IGNORE, GA_UNSUPPORTED };

int ef_gc_err(ef_gcode_t *r, uint32_t col, const char *fmt, ...)
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

/* ---- parameters ----------------------------------------------------------------------- */

/* Scale of program input on axis k of X Y Z A B C U V W: 25.4 for the linear axes under
 * G20, 1 for the rotary A B C (degrees in every unit mode, as LinuxCNC). */
static double gc_axis_scale(const ef_gcode_t *r, int k)
{
    return r->units == 20 && (k < 3 || k >= 6) ? EF_GC_INCH : 1.0;
}

/* Per-axis parameters of the nine axes held in mm (degrees for A B C): a pointer to the
 * value and its axis (0..8, X..W), or NULL. */
static double *gc_param_axis(ef_gcode_t *r, int n, int *axis)
{
    if (n >= 5161 && n <= 5169)
        return &r->g28[*axis = n - 5161];
    if (n >= 5181 && n <= 5189)
        return &r->g30[*axis = n - 5181];
    if (n >= 5211 && n <= 5219)
        return &r->g92_saved[*axis = n - 5211];
    if (n >= 5221 && n <= 5390 && (n - 5221) % 20 < 9)
        return &r->g5x[(n - 5221) / 20][*axis = (n - 5221) % 20];
    return NULL;
}

/* Program coordinates of the current A B C U V W: no rotation and no tool offset. */
static void gc_aux_to_prog(const ef_gcode_t *r, double p[EF_GCODE_AUX])
{
    for (int j = 0; j < EF_GCODE_AUX; j++)
        p[j] = r->acur[j] - r->g5x[r->cs - 1][3 + j] - r->g92[3 + j];
}

double ef_gc_param_get(const ef_gcode_t *r, int n)
{
    double scale = r->units == 20 ? EF_GC_INCH : 1.0;
    ef_gcode_t *w = (ef_gcode_t *)r; /* gc_param_axis only points into r */
    int k;
    const double *p = gc_param_axis(w, n, &k);
    if (p)
        return *p / gc_axis_scale(r, k);
    if (n == 5210)
        return r->g92_on;
    if (n == 5220)
        return r->cs;
    if (n >= 5230 && n <= 5390 && (n - 5230) % 20 == 0)
        return r->rot[(n - 5230) / 20];
    if (n == 5400)
        return r->tool_cur;
    if (n >= 5401 && n <= 5403)
        return r->tlo[n - 5401] / scale;
    if (n >= 5420 && n <= 5428) {
        double pp[3], pa[EF_GCODE_AUX];
        ef_gc_to_prog(r, r->cur, pp);
        gc_aux_to_prog(r, pa);
        return (n < 5423 ? pp[n - 5420] : pa[n - 5423]) / gc_axis_scale(r, n - 5420);
    }
    return r->param[n];
}

void ef_gc_param_set(ef_gcode_t *r, int n, double v)
{
    int k;
    double *p = gc_param_axis(r, n, &k);
    if (p)
        *p = v * gc_axis_scale(r, k);
    else if (n >= 5230 && n <= 5390 && (n - 5230) % 20 == 0)
        r->rot[(n - 5230) / 20] = v;
    else if (n == 5210)
        r->g92_on = v != 0;
    r->param[n] = v;
}

/* Read-only names LinuxCNC predefines; -1 when name is not one of them. */
static int gc_named_builtin(const ef_gcode_t *r, const char *name, double *v)
{
    double scale = r->units == 20 ? EF_GC_INCH : 1.0, pp[3], pa[EF_GCODE_AUX];
    static const char aux_letters[] = "ABCUVW";
    const char *al = name[0] == '_' && name[1] && !name[2] ? strchr(aux_letters, name[1]) : NULL;
    ef_gc_to_prog(r, r->cur, pp);
    gc_aux_to_prog(r, pa);
    if (!strcmp(name, "_X") || !strcmp(name, "_Y") || !strcmp(name, "_Z"))
        *v = pp[name[1] - 'X'] / scale;
    else if (al)
        *v = pa[al - aux_letters] / gc_axis_scale(r, 3 + (int)(al - aux_letters));
    else if (!strcmp(name, "_FEED"))
        *v = r->feed / scale;
    else if (!strcmp(name, "_METRIC"))
        *v = r->units == 21;
    else if (!strcmp(name, "_IMPERIAL"))
        *v = r->units == 20;
    else if (!strcmp(name, "_ABSOLUTE"))
        *v = r->absolute;
    else if (!strcmp(name, "_INCREMENTAL"))
        *v = !r->absolute;
    else if (!strcmp(name, "_COORD_SYSTEM"))
        *v = r->cs <= 6 ? 530 + 10 * r->cs : 590 + (r->cs - 6);
    else if (!strcmp(name, "_CURRENT_TOOL"))
        *v = r->tool_cur;
    else if (!strcmp(name, "_SELECTED_TOOL"))
        *v = r->tool_prep;
    else if (!strcmp(name, "_PLANE"))
        *v = r->plane * 10;
    else if (!strcmp(name, "_MOTION_MODE"))
        *v = r->motion < 0 ? 800 : r->motion;
    else if (!strcmp(name, "_LINE"))
        *v = r->line;
    else if (!strcmp(name, "_CALL_LEVEL"))
        *v = r->depth;
    else
        return -1;
    return 0;
}

/* Index of name at its level (globals start with '_'), or -1. */
static int gc_named_index(const ef_gcode_t *r, const char *name)
{
    int level = name[0] == '_' ? -1 : r->depth;
    for (int k = r->nnamed - 1; k >= 0; k--)
        if (r->named[k].level == level && !strcmp(r->named[k].name, name))
            return k;
    return -1;
}

int ef_gc_named_get(const ef_gcode_t *r, const char *name, double *v)
{
    int k = gc_named_index(r, name);
    if (k >= 0) {
        *v = r->named[k].v;
        return 0;
    }
    return gc_named_builtin(r, name, v);
}

int ef_gc_named_set(ef_gcode_t *r, const char *name, double v, uint32_t col)
{
    int k = gc_named_index(r, name);
    if (k < 0) {
        if (r->nnamed >= EF_GCODE_NNAMED)
            return ef_gc_err(r, col, "more than %d named parameters", EF_GCODE_NNAMED);
        k = r->nnamed++;
        snprintf(r->named[k].name, sizeof r->named[k].name, "%s", name);
        r->named[k].level = name[0] == '_' ? -1 : r->depth;
    }
    r->named[k].v = v;
    return EF_OK;
}

void ef_gc_named_drop_level(ef_gcode_t *r, int level)
{
    int j = 0;
    for (int k = 0; k < r->nnamed; k++)
        if (r->named[k].level != level)
            r->named[j++] = r->named[k];
    r->nnamed = j;
}

/* ---- coordinates ---------------------------------------------------------------------- */

/* Rotation of v (XY only) by the active system's G10 L2 R angle (degrees); sign -1 undoes it. */
static void gc_rotate(const ef_gcode_t *r, int cs, int sign, double v[3])
{
    double a = sign * r->rot[cs - 1] * (EF_GC_PI / 180.0);
    if (a != 0) {
        double c = cos(a), s = sin(a), x = c * v[0] - s * v[1], y = s * v[0] + c * v[1];
        v[0] = x;
        v[1] = y;
    }
}

/* Machine = rotation(program + G92 offset) + work offset + tool length offset (mm), as
 * LinuxCNC's canon maps them: G92 shifts the program frame before the G10 L2 R rotation, the
 * rotation turns X and Y about the work offset's origin. */
void ef_gc_to_prog(const ef_gcode_t *r, const double m[3], double p[3])
{
    const double *o = r->g5x[r->cs - 1];
    for (int k = 0; k < 3; k++)
        p[k] = m[k] - o[k] - r->tlo[k];
    gc_rotate(r, r->cs, -1, p);
    for (int k = 0; k < 3; k++)
        p[k] -= r->g92[k];
}

void ef_gc_from_prog(const ef_gcode_t *r, const double p[3], double m[3])
{
    double cp[3], d[3];
    ef_gc_to_prog(r, r->cur, cp);
    for (int k = 0; k < 3; k++)
        d[k] = p[k] - cp[k];
    gc_rotate(r, r->cs, 1, d);
    for (int k = 0; k < 3; k++)
        m[k] = d[k] == 0 ? r->cur[k] : r->cur[k] + d[k];
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
int ef_gc_bracket(ef_gc_line_t *L, double *out)
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
    if (gc_at(L, "EXISTS[#<")) { /* EXISTS[#<name>]: 1 when the name is set here */
        char name[EF_GCODE_NAME_MAX + 1];
        int index;
        double v;
        L->i += 8;
        int rc = gc_param_ref(L, &index, name, col);
        if (rc)
            return rc;
        if (gc_peek(L) != ']')
            return ef_gc_err(L->r, gc_here(L), "EXISTS needs the form EXISTS[#<name>]");
        L->i++;
        *out = ef_gc_named_get(L->r, name, &v) >= 0;
        return EF_OK;
    }
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
    int rc = ef_gc_bracket(L, &a);
    if (rc)
        return rc;
    switch (f) {
    case 0:
        if (gc_peek(L) != '/' || L->i + 1 >= L->n || L->c[L->i + 1] != '[')
            return ef_gc_err(L->r, gc_here(L), "ATAN needs the form ATAN[y]/[x]");
        L->i++;
        if ((rc = ef_gc_bracket(L, &b)) != 0)
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
        rc = ef_gc_bracket(L, out);
    } else if (ch == '#') {
        int index;
        char name[EF_GCODE_NAME_MAX + 1];
        L->i++;
        rc = gc_param_ref(L, &index, name, col);
        if (!rc && index) {
            *out = ef_gc_param_get(L->r, index);
        } else if (!rc && ef_gc_named_get(L->r, name, out) < 0) {
            rc = ef_gc_err(L->r, col, "parameter #<%s> is not defined", name);
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

int ef_gc_compact(ef_gcode_t *r, const char *s, size_t n, ef_gc_line_t *L)
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
static int gc_words(ef_gc_line_t *L, int *n_words)
{
    int rc;
    L->nw = 0;
    L->nas = 0;
    *n_words = 0;
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
        if (ch == 'O')
            return ef_gc_err(L->r, col, "O-word not at the start of the line");
        if (!strchr("ABCDFGHIJKLMNPQRSTUVWXYZ", ch))
            return ef_gc_err(L->r, col, "unsupported word '%c'", ch);
        L->i++;
        if (L->i >= L->n)
            return ef_gc_err(L->r, col, "word '%c' has no value", ch);
        double v;
        if ((rc = gc_value(L, &v)) != 0)
            return rc;
        (*n_words)++;
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

const ef_gc_word_t *ef_gc_get(const ef_gc_line_t *L, char letter)
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
    case 730:
    case 810:
    case 820:
    case 830:
    case 850:
    case 860:
    case 870:
    case 880:
    case 890:
    case 800:
        *group = GR_MOTION;
        return;
    case 40:
    case 100:
    case 280:
    case 281:
    case 300:
    case 301:
    case 530:
    case 920:
    case 921:
    case 922:
    case 923:
        *group = GR_NONMODAL;
        return;
    case 70:
    case 80:
        *group = GR_LATHE;
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
    case 930:
    case 940:
        *group = GR_FEEDMODE;
        return;
    case 400:
        *group = GR_CUTTER;
        *action = GA_IGNORE;
        return;
    case 430:
    case 431:
    case 490:
        *group = GR_TOOLLEN;
        return;
    case 980:
    case 990:
        *group = GR_RETRACT;
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
    if (code == 840 || code == 740 || code == 331)
        return "rigid tapping is spindle-synchronized motion";
    if (code >= 730 && code <= 890)
        return "canned cycle";
    if (code == 410 || code == 420 || code == 411 || code == 421)
        return "cutter radius compensation: the program must give the tool centre's path";
    if (code == 330 || code == 760)
        return "threading is spindle-synchronized motion";
    if (code >= 380 && code <= 385)
        return "probing";
    if (code >= 50 && code <= 53)
        return "spline";
    if (code == 520)
        return "local coordinate system (G52)";
    if (code == 950)
        return "feed per revolution is spindle-synchronized";
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

/* The queue in use: the heap array of a long expansion, else the inline one. */
static ef_gcode_item_t *gc_queue(ef_gcode_t *r, size_t *cap)
{
    *cap = r->queue ? r->qcap : sizeof r->queue0 / sizeof r->queue0[0];
    return r->queue ? r->queue : r->queue0;
}

ef_gcode_item_t *ef_gc_push(ef_gcode_t *r, int kind, uint32_t col)
{
    size_t cap0;
    ef_gcode_item_t *q0 = gc_queue(r, &cap0);
    if (r->qlen >= cap0) {
        if (cap0 >= EF_GCODE_LINE_ITEMS_MAX) {
            ef_gc_err(r, col, "line expands into more than %d items", EF_GCODE_LINE_ITEMS_MAX);
            return NULL;
        }
        size_t cap = cap0 * 4 > EF_GCODE_LINE_ITEMS_MAX ? EF_GCODE_LINE_ITEMS_MAX : cap0 * 4;
        ef_gcode_item_t *q = malloc(cap * sizeof *q);
        if (!q) {
            ef_gc_err(r, col, "out of memory");
            return NULL;
        }
        memcpy(q, q0, r->qlen * sizeof *q);
        free(r->queue);
        r->queue = q0 = q;
        r->qcap = cap;
    }
    ef_gcode_item_t *it = &q0[r->qlen++];
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

/* The same for A B C U V W (aux index j): degrees for A B C, where 1e6 is as far as a
 * position may go before float resolution downstream means nothing either. */
static int gc_aux_ok(ef_gcode_t *r, int j, double v, uint32_t col, const char *what)
{
    const char *u = j < 3 ? "deg" : "mm";
    if (!isfinite(v) || fabs(v) > EF_GCODE_MAX_COORD)
        return ef_gc_err(r, col, "%s %c %.6g %s outside +-%g %s", what, "ABCUVW"[j], v, u,
                         EF_GCODE_MAX_COORD, u);
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

/* A feed within the reader's limit; above it, clamped with a note naming the line. */
static int gc_feed_clamp(ef_gcode_t *r, double *f, uint32_t col, const char *what)
{
    if (*f > r->max_feed) {
        ef_gcode_item_t *it = ef_gc_push(r, EF_GC_NOTE, col);
        if (!it)
            return r->err;
        snprintf(it->text, sizeof it->text, "%s %.6g mm/min above the limit %.6g mm/min: clamped",
                 what, *f, r->max_feed);
        *f = r->max_feed;
    }
    return EF_OK;
}

int ef_gc_emit_straight(ef_gcode_t *r, int rapid, const double end[3],
                        const double aend[EF_GCODE_AUX], uint32_t col)
{
    int rc;
    double ae[EF_GCODE_AUX], la = 0, lu = 0, feed = 0;
    for (int k = 0; k < 3; k++)
        if ((rc = gc_coord_ok(r, end[k], col, "coordinate")) != 0)
            return rc;
    for (int j = 0; j < EF_GCODE_AUX; j++) {
        ae[j] = aend ? aend[j] : r->acur[j];
        if ((rc = gc_aux_ok(r, j, ae[j], col, "coordinate")) != 0)
            return rc;
        double d = ae[j] - r->acur[j];
        *(j < 3 ? &la : &lu) += d * d;
    }
    la = sqrt(la);
    lu = sqrt(lu);
    double len = sqrt((end[0] - r->cur[0]) * (end[0] - r->cur[0]) +
                      (end[1] - r->cur[1]) * (end[1] - r->cur[1]) +
                      (end[2] - r->cur[2]) * (end[2] - r->cur[2]));
    int zero = len <= EF_GCODE_ZERO_LEN && la <= EF_GCODE_ZERO_LEN && lu <= EF_GCODE_ZERO_LEN;
    if (!rapid) {
        /* LinuxCNC (find_straight_length, canon's feed rates): the feed is along X Y Z if
         * they move, else along U V W, else along A B C in degrees, with the F number as
         * written (its angular feed rate is never converted by G20) */
        int xyz = len > EF_GCODE_ZERO_LEN, uvw = !xyz && lu > EF_GCODE_ZERO_LEN;
        feed = xyz || uvw || zero ? r->feed : r->feed_ang;
        if (!zero && r->inverse_time) {
            feed = r->feed * (xyz ? len : uvw ? lu : la); /* G93: F is 1 / minutes */
            if ((rc = gc_feed_clamp(r, &feed, col, "inverse-time feed")) != 0)
                return rc;
        }
    }
    ef_gcode_item_t *it = ef_gc_push(r,
                                     zero    ? EF_GC_ZERO_MOVE
                                     : rapid ? EF_GC_RAPID
                                             : EF_GC_LINE,
                                     col);
    if (!it)
        return r->err;
    memcpy(it->start, r->cur, sizeof it->start);
    memcpy(it->end, zero ? r->cur : end, sizeof it->end);
    memcpy(it->astart, r->acur, sizeof it->astart);
    memcpy(it->aend, zero ? r->acur : ae, sizeof it->aend);
    if (!rapid)
        it->feed = feed;
    if (zero) {
        snprintf(it->text, sizeof it->text, "G%d", rapid ? 0 : 1);
    } else {
        memcpy(r->cur, end, sizeof r->cur);
        memcpy(r->acur, ae, sizeof r->acur);
    }
    return EF_OK;
}

int ef_gc_emit_dwell(ef_gcode_t *r, double seconds, uint32_t col)
{
    char text[48];
    snprintf(text, sizeof text, "G4 P%.6g", seconds);
    return ef_gc_emit_event(r, text, col);
}

int ef_gc_emit_event(ef_gcode_t *r, const char *text, uint32_t col)
{
    ef_gcode_item_t *it = ef_gc_push(r, EF_GC_EVENT, col);
    if (!it)
        return r->err;
    snprintf(it->text, sizeof it->text, "%s", text);
    return EF_OK;
}

int ef_gc_emit_tolerance(ef_gcode_t *r, int mode, double p, double q, uint32_t col)
{
    ef_gcode_item_t *it = ef_gc_push(r, EF_GC_TOLERANCE, col);
    if (!it)
        return r->err;
    it->path_mode = mode;
    it->p_tol = mode == EF_GC_PATH_BLEND ? p : 0;
    it->q_tol = mode == EF_GC_PATH_BLEND ? q : 0;
    return EF_OK;
}

void ef_gc_jump(ef_gcode_t *r, ef_gcode_mark_t at)
{
    r->pos = at.pos;
    r->line = at.line - 1;
}

ef_gcode_mark_t ef_gc_here_mark(const ef_gcode_t *r)
{
    ef_gcode_mark_t m = {r->pos, r->line + 1};
    return m;
}

/* Once-only note of an ignored word or line kind (bit of ignored_seen). */
static int gc_ignored_once(ef_gcode_t *r, int bit, uint32_t col, const char *text)
{
    if (r->ignored_seen & (1u << bit))
        return EF_OK;
    r->ignored_seen |= 1u << bit;
    ef_gcode_item_t *it = ef_gc_push(r, EF_GC_IGNORED, col);
    if (!it)
        return r->err;
    snprintf(it->text, sizeof it->text, "%s", text);
    return EF_OK;
}

/* Arc from the current position (program frame sp, mm) to ep, A B C U V W going linearly
 * to the machine position aem; the item in machine coordinates. Errors point at col. */
static int gc_arc(ef_gcode_t *r, const ef_gc_line_t *L, const double sp[3], const double ep[3],
                  const double aem[EF_GCODE_AUX], int g3, double scale, uint32_t col)
{
    int a, b, nrm;
    char la, lb, ln;
    gc_plane_axes(r->plane, &a, &b, &nrm, &la, &lb, &ln);
    const ef_gc_word_t *wa = ef_gc_get(L, la), *wb = ef_gc_get(L, lb), *wn = ef_gc_get(L, ln),
                       *wr = ef_gc_get(L, 'R'), *wp = ef_gc_get(L, 'P');
    const char *gname = g3 ? "G3" : "G2";
    double c[3] = {sp[0], sp[1], sp[2]};
    double sa = sp[a], sb = sp[b], ea = ep[a], eb = ep[b];
    double chord = hypot(ea - sa, eb - sb), radius, r1;
    int turns = 1, rc;
    if (wn)
        return ef_gc_err(r, wn->col, "%c word on a G%d-plane arc", ln, r->plane);
    if (r->plane != 17 && r->rot[r->cs - 1] != 0)
        return ef_gc_err(r, col,
                         "G%d arc in a rotated coordinate system (G10 L2 R): only G17 "
                         "arcs turn with it",
                         r->plane);
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
        if (radius <= EF_GCODE_ZERO_LEN)
            return ef_gc_err(r, wr->col, "%s R is zero", gname);
        h2 = radius * radius - chord * chord / 4;
        if (h2 < 0 || chord / 2 / radius > 1 - 1e-12) {
            if (chord / 2 - radius > EF_GCODE_ARC_R_TOL)
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
        r1 = radius;
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
        r1 = hypot(ea - c[a], eb - c[b]);
        if (radius < EF_GCODE_ARC_R_TOL || r1 < EF_GCODE_ARC_R_TOL)
            return ef_gc_err(r, col, "%s arc radius is zero (start %.4f, end %.4f)", gname, radius,
                             r1);
        /* LinuxCNC 2.9's spiral rule; inside it the radius changes linearly with the angle */
        double tol = r->units == 20 ? EF_GCODE_ARC_ABS_TOL_IN : EF_GCODE_ARC_ABS_TOL_MM;
        double dr = fabs(r1 - radius), rel = dr / fmax(radius, r1);
        if (dr > 100 * tol || (rel > EF_GCODE_ARC_REL_TOL && dr > tol))
            return ef_gc_err(r, col,
                             "%s arc radius mismatch: start %.4f end %.4f (differ by %.4g mm; "
                             "allowed %.4g mm, or %.4g%% up to %.4g mm)",
                             gname, radius, r1, dr, tol, 100 * EF_GCODE_ARC_REL_TOL, 100 * tol);
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
    double feed = r->feed;
    if (r->inverse_time) {
        double rise = ep[nrm] - sp[nrm], flat = sweep * 0.5 * (radius + r1);
        feed *= sqrt(flat * flat + rise * rise);
        if ((rc = gc_feed_clamp(r, &feed, col, "inverse-time feed")) != 0)
            return rc;
    }
    double em[3], cm[3];
    ef_gc_from_prog(r, ep, em);
    ef_gc_from_prog(r, c, cm);
    for (int k = 0; k < 3; k++)
        if ((rc = gc_coord_ok(r, em[k], col, "coordinate")) != 0 ||
            (rc = gc_coord_ok(r, cm[k], col, "arc centre")) != 0)
            return rc;
    for (int j = 0; j < EF_GCODE_AUX; j++)
        if ((rc = gc_aux_ok(r, j, aem[j], col, "coordinate")) != 0)
            return rc;
    ef_gcode_item_t *it = ef_gc_push(r, EF_GC_ARC, col);
    if (!it)
        return r->err;
    memcpy(it->start, r->cur, sizeof it->start);
    memcpy(it->end, em, sizeof it->end);
    memcpy(it->centre, cm, sizeof it->centre);
    memcpy(it->astart, r->acur, sizeof it->astart);
    memcpy(it->aend, aem, sizeof it->aend);
    it->centre[nrm] = r->cur[nrm];
    it->radius = radius;
    it->radius_end = r1;
    it->sweep = g3 ? sweep : -sweep;
    it->dir = g3 ? 1 : -1;
    it->plane = r->plane;
    it->turns = turns;
    it->feed = feed;
    memcpy(r->cur, em, sizeof r->cur);
    memcpy(r->acur, aem, sizeof r->acur);
    return EF_OK;
}

/* The tool table entry of a tool, or NULL. */
ef_gcode_tool_t *ef_gc_tool(ef_gcode_t *r, int tool, int create)
{
    for (int k = 0; k < r->ntools; k++)
        if (r->tools[k].tool == tool)
            return &r->tools[k];
    if (!create || r->ntools >= EF_GCODE_NTOOLS)
        return NULL;
    ef_gcode_tool_t *t = &r->tools[r->ntools++];
    memset(t, 0, sizeof *t);
    t->tool = tool;
    return t;
}

/* A whole number word in a range. */
static int gc_int_word(ef_gcode_t *r, const ef_gc_word_t *w, int lo, int hi, const char *what,
                       int *out)
{
    if (w->v != floor(w->v) || w->v < lo || w->v > hi)
        return ef_gc_err(r, w->col, "%s %c%.6g: must be a whole number %d..%d", what, w->letter,
                         w->v, lo, hi);
    *out = (int)w->v;
    return EF_OK;
}

/* A B C U V W words where only X Y Z have a meaning here (tool offsets): refused. */
static int gc_no_aux(ef_gcode_t *r, const ef_gc_word_t *const aux[EF_GCODE_AUX], const char *what)
{
    for (int j = 0; j < EF_GCODE_AUX; j++)
        if (aux[j])
            return ef_gc_err(r, aux[j]->col, "axis word '%c' not supported in %s", aux[j]->letter,
                             what);
    return EF_OK;
}

/* G10 L1 / L2 / L10 / L11 / L20: tool table and work offsets. */
static int gc_g10(ef_gcode_t *r, const ef_gc_line_t *L, const ef_gc_word_t *g,
                  const ef_gc_word_t *axis[3], const ef_gc_word_t *const aux[EF_GCODE_AUX],
                  double scale)
{
    const ef_gc_word_t *wl = ef_gc_get(L, 'L'), *wp = ef_gc_get(L, 'P'), *wr = ef_gc_get(L, 'R');
    int l = 0, p = 0, rc;
    if (!wl)
        return ef_gc_err(r, g->col, "G10 needs an L word (L1, L2, L10, L11 or L20)");
    if (!wp)
        return ef_gc_err(r, g->col, "G10 needs a P word");
    if ((rc = gc_int_word(r, wl, 1, 20, "G10", &l)) != 0)
        return rc;
    if (l == 2 || l == 20) {
        if ((rc = gc_int_word(r, wp, 0, 9, "G10 coordinate system", &p)) != 0)
            return rc;
        int cs = p == 0 ? r->cs : p;
        double *o = r->g5x[cs - 1], pn[3], q[3];
        /* L20: the offset that makes the current point read the given values in system cs,
         * the other axes keeping their current reading there (with a rotation both X and Y
         * of the offset change, as in LinuxCNC) */
        for (int k = 0; k < 3; k++)
            pn[k] = r->cur[k] - o[k] - r->tlo[k];
        gc_rotate(r, cs, -1, pn);
        for (int k = 0; k < 3; k++) {
            pn[k] -= r->g92[k];
            if (axis[k])
                pn[k] = axis[k]->v * scale / (k == 0 && r->diameter ? 2 : 1);
            q[k] = pn[k] + r->g92[k];
        }
        gc_rotate(r, cs, 1, q);
        int xy = axis[0] || axis[1];
        for (int k = 0; k < 3; k++) {
            if (l == 2 ? !axis[k] : !(axis[k] || (k < 2 && xy)))
                continue;
            o[k] = l == 2 ? pn[k] : r->cur[k] - r->tlo[k] - q[k];
            if ((rc = gc_coord_ok(r, o[k], axis[k] ? axis[k]->col : g->col, "work offset")) != 0)
                return rc;
        }
        /* A B C U V W: no rotation; L20 keeps the others' reading, as for X Y Z */
        for (int j = 0; j < EF_GCODE_AUX; j++) {
            if (!aux[j])
                continue;
            double v = aux[j]->v * gc_axis_scale(r, 3 + j);
            o[3 + j] = l == 2 ? v : r->acur[j] - v - r->g92[3 + j];
            if ((rc = gc_aux_ok(r, j, o[3 + j], aux[j]->col, "work offset")) != 0)
                return rc;
        }
        if (wr) {
            if (!isfinite(wr->v) || fabs(wr->v) > 1e6)
                return ef_gc_err(r, wr->col, "G10 rotation R%.6g out of range", wr->v);
            r->rot[cs - 1] = wr->v;
        }
        return EF_OK;
    }
    if (l == 1 || l == 10 || l == 11) {
        if ((rc = gc_int_word(r, wp, 1, 99999, "G10 tool", &p)) != 0)
            return rc;
        if ((rc = gc_no_aux(r, aux, "a tool offset (X Y Z only)")) != 0)
            return rc;
        ef_gcode_tool_t *t = ef_gc_tool(r, p, 1);
        if (!t)
            return ef_gc_err(r, wp->col, "tool table full (%d tools)", EF_GCODE_NTOOLS);
        /* L10: the offset that makes the current point read the given values with the active
         * offsets; L11: the same in G59.3 without G92 */
        int cs = l == 11 ? 9 : r->cs;
        const double *o = r->g5x[cs - 1];
        double q[3];
        ef_gc_to_prog(r, r->cur, q);
        for (int k = 0; k < 3; k++) {
            if (axis[k])
                q[k] = axis[k]->v * scale;
            q[k] += l == 11 ? 0 : r->g92[k];
        }
        gc_rotate(r, cs, 1, q);
        for (int k = 0; k < 3; k++) {
            if (!axis[k])
                continue;
            double v = axis[k]->v * scale;
            t->off[k] = l == 1 ? v : r->cur[k] - o[k] - q[k];
            if ((rc = gc_coord_ok(r, t->off[k], axis[k]->col, "tool offset")) != 0)
                return rc;
        }
        if (wr)
            t->diameter = 2 * fabs(wr->v) * scale;
        return EF_OK;
    }
    return ef_gc_err(r, wl->col, "G10 L%d not supported (L1, L2, L10, L11, L20)", l);
}

/* G28 / G30 (go to a stored position, through an intermediate point given by axis words). */
static int gc_home(ef_gcode_t *r, const double stored[9], const ef_gc_word_t *axis[3],
                   const ef_gc_word_t *const aux[EF_GCODE_AUX], double scale, uint32_t col)
{
    int any = axis[0] || axis[1] || axis[2], rc;
    double cp[3], ip[3], im[3], end[3], ap[EF_GCODE_AUX], aim[EF_GCODE_AUX], aend[EF_GCODE_AUX];
    for (int j = 0; j < EF_GCODE_AUX; j++)
        any |= aux[j] != NULL;
    ef_gc_to_prog(r, r->cur, cp);
    gc_aux_to_prog(r, ap);
    if (any) {
        for (int j = 0; j < EF_GCODE_AUX; j++) {
            aim[j] = r->acur[j];
            if (aux[j]) {
                double v = aux[j]->v * gc_axis_scale(r, 3 + j);
                double d = (r->absolute ? v : ap[j] + v) - ap[j];
                aim[j] = d == 0 ? r->acur[j] : r->acur[j] + d;
                if ((rc = gc_aux_ok(r, j, aim[j], aux[j]->col, "coordinate")) != 0)
                    return rc;
            }
        }
        for (int k = 0; k < 3; k++) {
            ip[k] = cp[k];
            if (axis[k]) {
                double v = axis[k]->v * scale;
                if (k == 0 && r->diameter)
                    v /= 2;
                ip[k] = r->absolute ? v : cp[k] + v;
            }
        }
        ef_gc_from_prog(r, ip, im);
        if ((rc = ef_gc_emit_straight(r, 1, im, aim, col)) != 0)
            return rc;
    }
    for (int k = 0; k < 3; k++)
        end[k] = !any || axis[k] ? stored[k] + r->tlo[k] : r->cur[k];
    for (int j = 0; j < EF_GCODE_AUX; j++)
        aend[j] = !any || aux[j] ? stored[3 + j] : r->acur[j];
    return ef_gc_emit_straight(r, 1, end, aend, col);
}

/* G92 / G92.1 / G92.2 / G92.3. */
static int gc_g92(ef_gcode_t *r, int code, const ef_gc_word_t *axis[3],
                  const ef_gc_word_t *const aux[EF_GCODE_AUX], double scale, uint32_t col)
{
    int rc;
    if (code == 920) {
        int any = axis[0] || axis[1] || axis[2];
        for (int j = 0; j < EF_GCODE_AUX; j++)
            any |= aux[j] != NULL;
        if (!any)
            return ef_gc_err(r, col, "G92 needs at least one axis word");
        /* G92 lives in the program frame (before the rotation): the offset that makes the
         * current point read the given values */
        double cp[3], ap[EF_GCODE_AUX];
        ef_gc_to_prog(r, r->cur, cp);
        gc_aux_to_prog(r, ap);
        for (int j = 0; j < EF_GCODE_AUX; j++) {
            if (!aux[j])
                continue;
            r->g92[3 + j] = ap[j] + r->g92[3 + j] - aux[j]->v * gc_axis_scale(r, 3 + j);
            if ((rc = gc_aux_ok(r, j, r->g92[3 + j], aux[j]->col, "G92 offset")) != 0)
                return rc;
        }
        for (int k = 0; k < 3; k++) {
            if (!axis[k])
                continue;
            double v = axis[k]->v * scale;
            if (k == 0 && r->diameter)
                v /= 2;
            r->g92[k] = cp[k] + r->g92[k] - v;
            if ((rc = gc_coord_ok(r, r->g92[k], axis[k]->col, "G92 offset")) != 0)
                return rc;
        }
        memcpy(r->g92_saved, r->g92, sizeof r->g92);
        r->g92_on = 1;
    } else if (code == 921) {
        memset(r->g92, 0, sizeof r->g92);
        memset(r->g92_saved, 0, sizeof r->g92_saved);
        r->g92_on = 0;
    } else if (code == 922) {
        memset(r->g92, 0, sizeof r->g92);
        r->g92_on = 0;
    } else {
        memcpy(r->g92, r->g92_saved, sizeof r->g92);
        r->g92_on = 1;
    }
    return EF_OK;
}

/* Carry out one read line, in LinuxCNC's order of execution (docs/gcode.md). */
static int gc_execute(ef_gcode_t *r, ef_gc_line_t *L)
{
    const ef_gc_word_t *grp[GR_COUNT] = {0};
    const ef_gc_word_t *mgrp[10] = {0};
    const ef_gc_word_t *stop = NULL, *wf = ef_gc_get(L, 'F'), *g80 = NULL;
    char pre[128] = "", post[128] = "";
    uint32_t pre_col = 0, post_col = 0;
    int rc, action, group, m_takes_pq = 0;
    char name[16];

    /* Modal-group conflicts and unsupported codes first, so nothing of a bad line happens. */
    for (int k = 0; k < L->nw; k++) {
        const ef_gc_word_t *w = &L->w[k];
        if (w->letter == 'G') {
            gc_gclass(w->code, &group, &action);
            gc_fmt_code(name, sizeof name, 'G', w->code);
            if (action == GA_UNSUPPORTED)
                return ef_gc_err(r, w->col, "unsupported %s (%s)", name, gc_why(w->code));
            if (group == GR_MOTION && grp[group] && (w->code == 800 || grp[group]->code == 800)) {
                /* LinuxCNC: with G80 and a motion code on one line the motion code wins */
                if (w->code == 800) {
                    g80 = w;
                    continue;
                }
                g80 = grp[group];
            } else if (grp[group]) {
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
            if (c >= 700 && c <= 730)
                return ef_gc_err(r, w->col, "unsupported %s (modal state save and restore)", name);
            if (c == 0 || c == 10 || c == 20 || c == 300 || c == 600)
                mg = 4;
            else if (c == 60 || c == 610)
                mg = 6;
            else if (c >= 30 && c <= 50)
                mg = 7;
            else if (c == 90)
                mg = 8; /* M7 and M8 may share a line (both coolants on): only M9 is checked */
            else if (c >= 620 && c <= 680)
                mg = 5;
            if (c == 610 || (c >= 620 && c <= 680))
                m_takes_pq = 1;
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

    /* Feed mode, then (as before) units, plane and distance modes, then F. */
    if (grp[GR_FEEDMODE]) {
        int inv = grp[GR_FEEDMODE]->code == 930;
        if (inv != r->inverse_time)
            r->feed = r->feed_ang = 0; /* LinuxCNC: a feed mode change needs a new F */
        r->inverse_time = inv;
    }
    if (grp[GR_UNITS])
        r->units = grp[GR_UNITS]->code == 200 ? 20 : 21;
    if (grp[GR_PLANE])
        r->plane = grp[GR_PLANE]->code / 10;
    if (grp[GR_DIST])
        r->absolute = grp[GR_DIST]->code == 900;
    if (grp[GR_ARCDIST])
        r->arc_absolute = grp[GR_ARCDIST]->code == 901;
    if (grp[GR_LATHE])
        r->diameter = grp[GR_LATHE]->code == 70;
    if (grp[GR_RETRACT])
        r->retract_r = grp[GR_RETRACT]->code == 990;
    double scale = r->units == 20 ? EF_GC_INCH : 1.0;
    if (wf) {
        double f = r->inverse_time ? wf->v : wf->v * scale;
        if (!isfinite(f) || f < 0)
            return ef_gc_err(r, wf->col, "feed F%.6g must not be negative", wf->v);
        if (!r->inverse_time && (rc = gc_feed_clamp(r, &f, wf->col, "feed")) != 0)
            return rc;
        r->feed = f;
        /* A B C moves take the number as written: LinuxCNC's canon converts F by the length
         * units for its linear rate only, and keeps that angular rate across G20/G21 */
        r->feed_ang = r->inverse_time || wf->v <= r->max_feed ? wf->v : r->max_feed;
    }

    /* Which words have a use on this line. */
    const ef_gc_word_t *g0 = grp[GR_NONMODAL];
    int g0c = g0 ? g0->code : -1;
    int motion = r->motion;
    if (grp[GR_MOTION])
        motion = grp[GR_MOTION]->code == 800 ? -1 : grp[GR_MOTION]->code;
    const ef_gc_word_t *axis[3] = {ef_gc_get(L, 'X'), ef_gc_get(L, 'Y'), ef_gc_get(L, 'Z')};
    const ef_gc_word_t *aux[EF_GCODE_AUX], *first_axis = NULL, *first_aux = NULL;
    for (int j = 0; j < EF_GCODE_AUX; j++) {
        aux[j] = ef_gc_get(L, "ABCUVW"[j]);
        if (aux[j] && (!first_aux || aux[j]->col < first_aux->col))
            first_aux = aux[j];
    }
    for (int k = 0; k < 3; k++)
        if (axis[k] && (!first_axis || axis[k]->col < first_axis->col))
            first_axis = axis[k];
    if (first_aux && (!first_axis || first_aux->col < first_axis->col))
        first_axis = first_aux;
    int g4 = g0c == 40, g53 = g0c == 530, g10 = g0c == 100;
    int axis_owner = g10 || g0c == 280 || g0c == 300 || g0c == 920 ||
                     (grp[GR_TOOLLEN] && grp[GR_TOOLLEN]->code == 431);
    int is_cycle = motion == 730 || (motion >= 810 && motion <= 890);
    int arcmode = motion == 20 || motion == 30;
    int ijk = ef_gc_get(L, 'I') || ef_gc_get(L, 'J') || ef_gc_get(L, 'K');
    int moves = !axis_owner && (first_axis || (arcmode && ijk && !g53));
    int arc = arcmode && moves && !g53;
    int cycle = is_cycle && moves;
    int g64 = grp[GR_PATH] && grp[GR_PATH]->code == 640;
    /* the motion's column: its G word, else the first axis word, else (a full circle in the
     * modal arc mode, " I1") the first centre word */
    const ef_gc_word_t *mw = grp[GR_MOTION] ? grp[GR_MOTION] : first_axis;
    for (int k = 0; !mw && k < 3; k++)
        mw = ef_gc_get(L, "IJK"[k]);
    uint32_t mcol = mw ? mw->col : 1;
    if (first_axis && !axis_owner && motion < 0)
        return ef_gc_err(r, first_axis->col, "axis word with no motion mode (G0, G1, G2 or G3)");
    if (g53 && motion != 0 && motion != 10)
        return ef_gc_err(r, g0->col, "G53 needs G0 or G1");
    if (g53 && !r->absolute)
        return ef_gc_err(r, g0->col, "G53 needs absolute distance mode (G90)");
    static const char arc_letters[] = "IJKR";
    for (int k = 0; k < 4; k++) {
        const ef_gc_word_t *w = ef_gc_get(L, arc_letters[k]);
        int is_r = arc_letters[k] == 'R';
        if (w && !arc && !(cycle && (is_r || motion == 870)) && !(g10 && is_r)) {
            if (arcmode && !first_axis)
                return ef_gc_err(r, w->col, "%s with no X, Y or Z word",
                                 motion == 20 ? "G2" : "G3");
            return ef_gc_err(r, w->col,
                             is_r ? "R word with no G2/G3 arc, canned cycle or G10"
                                  : "%c word with no G2/G3 arc or G87 back boring cycle",
                             arc_letters[k]);
        }
    }
    /* LinuxCNC refuses A B C in canned cycles; U V W drill only in its G17.1-G19.1 planes,
     * which are not read here */
    if (cycle && first_aux)
        return ef_gc_err(r, first_aux->col, "axis word '%c' not supported in a canned cycle",
                         first_aux->letter);
    if (grp[GR_TOOLLEN] && grp[GR_TOOLLEN]->code == 431 &&
        (rc = gc_no_aux(r, aux, "a tool offset (X Y Z only)")) != 0)
        return rc;
    const ef_gc_word_t *wp = ef_gc_get(L, 'P'), *wq = ef_gc_get(L, 'Q'), *wl = ef_gc_get(L, 'L');
    if (wp && !g4 && !g64 && !arc && !cycle && !g10 && !m_takes_pq)
        return ef_gc_err(r, wp->col,
                         "P word with no G4, G10, G64, G2/G3 arc, canned cycle or M "
                         "code that takes it");
    if (wq && !g64 && !cycle && !m_takes_pq)
        return ef_gc_err(r, wq->col, "Q word with no G64, canned cycle or M code that takes it");
    if (wl && !g10 && !cycle && !m_takes_pq)
        return ef_gc_err(r, wl->col, "L word with no G10, canned cycle or M code that takes it");
    if (g4 && (!wp || !(wp->v >= 0)))
        return ef_gc_err(r, g0->col, "G4 needs a dwell time P >= 0");
    if (r->inverse_time && (motion == 10 || arcmode) && moves && !g53 && !wf)
        return ef_gc_err(r, mcol, "G93 inverse-time feed: each G1/G2/G3 needs its F word");

    /* Pass-through words, in source order: before the motion, except the stops after it. */
    for (int k = 0; k < L->nw; k++) {
        const ef_gc_word_t *w = &L->w[k];
        int is_pre = 0;
        if (w->letter == 'M') {
            if (w->code == 20 || w->code == 300) {
                stop = w;
            } else if (w->code == 0 || w->code == 10 || w->code == 600) {
                gc_append(post, sizeof post, w);
                post_col = post_col ? post_col : w->col;
            } else {
                is_pre = 1;
            }
        } else if (w->letter == 'G') {
            is_pre = w->code == 40;
        } else if (strchr("DST", w->letter) || (w->letter == 'P' && (g4 || m_takes_pq)) ||
                   (strchr("QL", w->letter) && m_takes_pq)) {
            is_pre = 1;
        }
        if (is_pre) {
            gc_append(pre, sizeof pre, w);
            pre_col = pre_col ? pre_col : w->col;
        }
    }
    const ef_gc_word_t *wt = ef_gc_get(L, 'T');
    if (wt && (rc = gc_int_word(r, wt, 0, 99999, "tool", &r->tool_prep)) != 0)
        return rc;
    for (int k = 0; k < L->nw; k++) {
        const ef_gc_word_t *w = &L->w[k];
        if (w->letter != 'M')
            continue;
        if (w->code == 60)
            r->tool_cur = r->tool_prep;
        else if (w->code == 610) {
            if (!wq)
                return ef_gc_err(r, w->col, "M61 needs a Q word (the tool number)");
            if ((rc = gc_int_word(r, wq, 0, 99999, "M61 tool", &r->tool_cur)) != 0)
                return rc;
        } else if (w->code == 30 || w->code == 40 || w->code == 50)
            r->spindle = w->code / 10;
    }
    if (pre[0] && (rc = ef_gc_emit_event(r, pre, pre_col)) != 0)
        return rc;
    /* Accepted words with no effect on the path: one note each, the first time only. */
    static const int ignored[] = {400, 960, 970};
    for (int k = 0; k < L->nw; k++) {
        const ef_gc_word_t *w = &L->w[k];
        for (int j = 0; j < (int)(sizeof ignored / sizeof ignored[0]); j++)
            if (w->letter == 'G' && w->code == ignored[j]) {
                gc_fmt_code(name, sizeof name, 'G', w->code);
                if ((rc = gc_ignored_once(r, j, w->col, name)) != 0)
                    return rc;
            }
    }
    if (g80 &&
        (rc = gc_ignored_once(r, 3, g80->col,
                              "G80 with a motion code on one line: the motion code wins")) != 0)
        return rc;
    if (L->block_delete &&
        (rc = gc_ignored_once(r, 8, 1, "/ (block delete is off: such lines are read)")) != 0)
        return rc;

    /* Tool length offset, coordinate system, path control. */
    if (grp[GR_TOOLLEN]) {
        int c = grp[GR_TOOLLEN]->code;
        const ef_gc_word_t *wh = ef_gc_get(L, 'H');
        if (c == 490) {
            memset(r->tlo, 0, sizeof r->tlo);
        } else if (c == 431) {
            memset(r->tlo, 0, sizeof r->tlo);
            for (int k = 0; k < 3; k++)
                if (axis[k]) {
                    r->tlo[k] = axis[k]->v * scale;
                    if ((rc = gc_coord_ok(r, r->tlo[k], axis[k]->col, "tool offset")) != 0)
                        return rc;
                }
        } else {
            int tool = r->tool_cur;
            if (wh && (rc = gc_int_word(r, wh, 0, 99999, "G43 tool", &tool)) != 0)
                return rc;
            ef_gcode_tool_t *t = ef_gc_tool(r, tool, 0);
            if (t) {
                memcpy(r->tlo, t->off, sizeof r->tlo);
            } else {
                memset(r->tlo, 0, sizeof r->tlo);
                if (tool != 0 && (rc = gc_ignored_once(r, 4, grp[GR_TOOLLEN]->col,
                                                       "G43 of a tool with no G10 L1 entry: "
                                                       "its length offset is 0 here")) != 0)
                    return rc;
            }
        }
    } else if (ef_gc_get(L, 'H')) {
        return ef_gc_err(r, ef_gc_get(L, 'H')->col, "H word with no G43");
    }
    if (grp[GR_COORD]) {
        int c = grp[GR_COORD]->code;
        r->cs = c <= 590 ? (c - 540) / 10 + 1 : 6 + (c - 590);
    }
    if (grp[GR_PATH]) {
        double p = 0, q = 0;
        if (wp && g64) {
            p = wp->v * scale;
            if ((rc = gc_coord_ok(r, p, wp->col, "G64 P")) != 0)
                return rc;
            if (p < 0)
                return ef_gc_err(r, wp->col, "G64 P tolerance must not be negative");
        }
        if (wq && g64) {
            q = wq->v * scale;
            if ((rc = gc_coord_ok(r, q, wq->col, "G64 Q")) != 0)
                return rc;
            if (q < 0)
                return ef_gc_err(r, wq->col, "G64 Q tolerance must not be negative");
        }
        r->path_mode = g64 ? EF_GC_PATH_BLEND : EF_GC_PATH_EXACT;
        r->path_p = p;
        r->path_q = q;
        if ((rc = ef_gc_emit_tolerance(r, r->path_mode, p, q, grp[GR_PATH]->col)) != 0)
            return rc;
    }

    /* Offsets and stored positions (non-modal group). */
    if (g10 && (rc = gc_g10(r, L, g0, axis, aux, scale)) != 0)
        return rc;
    if (g0c == 281 || g0c == 301) {
        double *s = g0c == 281 ? r->g28 : r->g30;
        for (int k = 0; k < 3; k++)
            s[k] = r->cur[k] - r->tlo[k];
        memcpy(s + 3, r->acur, sizeof r->acur);
    }
    if ((g0c == 280 || g0c == 300) &&
        (rc = gc_home(r, g0c == 280 ? r->g28 : r->g30, axis, aux, scale, g0->col)) != 0)
        return rc;
    if (g0c >= 920 && g0c <= 923 && (rc = gc_g92(r, g0c, axis, aux, scale, g0->col)) != 0)
        return rc;

    /* Motion. */
    if (!is_cycle || (grp[GR_MOTION] && motion != r->motion)) {
        r->cyc_il_flag = 0; /* a new cycle mode (or none) forgets the initial level */
        r->cyc_have_q = r->cyc_have_p = 0;
        memset(r->cyc_have_ijk, 0, sizeof r->cyc_have_ijk);
    }
    int same_cycle = is_cycle && motion == r->motion;
    r->motion = motion;
    if (cycle) {
        uint32_t col = mcol;
        if ((rc = ef_gc_cycle(r, L, motion, same_cycle, axis, scale, col)) != 0)
            return rc;
    } else if (moves) {
        double cp[3], ep[3], em[3], ap[EF_GCODE_AUX], aem[EF_GCODE_AUX];
        uint32_t col = mcol;
        ef_gc_to_prog(r, r->cur, cp);
        gc_aux_to_prog(r, ap);
        for (int j = 0; j < EF_GCODE_AUX; j++) {
            aem[j] = r->acur[j];
            if (!aux[j])
                continue;
            /* program = machine - G5x - G92 on these axes: delta-based like X Y Z */
            double v = aux[j]->v * gc_axis_scale(r, 3 + j), t = r->absolute ? v : ap[j] + v;
            if ((rc = gc_aux_ok(r, j, g53 ? v : t, aux[j]->col, "coordinate")) != 0)
                return rc;
            aem[j] = g53 ? v : t == ap[j] ? r->acur[j] : r->acur[j] + (t - ap[j]);
        }
        for (int k = 0; k < 3; k++) {
            ep[k] = cp[k];
            em[k] = r->cur[k];
            if (axis[k]) {
                double v = axis[k]->v * scale;
                if (k == 0 && r->diameter)
                    v /= 2;
                ep[k] = r->absolute ? v : cp[k] + v;
                em[k] = v + r->tlo[k]; /* G53: machine coordinates, tool offset applied */
                if ((rc = gc_coord_ok(r, g53 ? em[k] : ep[k], axis[k]->col, "coordinate")) != 0)
                    return rc;
            }
        }
        if (motion != 0 && !(r->feed > 0))
            return ef_gc_err(r, col, "feed move with no feed rate (F missing or zero)");
        if (arc) {
            if ((rc = gc_arc(r, L, cp, ep, aem, motion == 30, scale, col)) != 0)
                return rc;
        } else {
            if (!g53)
                ef_gc_from_prog(r, ep, em);
            if ((rc = ef_gc_emit_straight(r, motion == 0, em, aem, col)) != 0)
                return rc;
        }
    }
    if (post[0] && (rc = ef_gc_emit_event(r, post, post_col)) != 0)
        return rc;
    if (stop) {
        ef_gcode_item_t *it = ef_gc_push(r, EF_GC_END, stop->col);
        if (!it)
            return r->err;
        gc_fmt_code(it->text, sizeof it->text, 'M', stop->code);
        r->end_item = *it;
        r->ended = 1;
    }

    /* Assignments take effect after the line, as in RS274NGC. */
    for (int k = 0; k < L->nas; k++) {
        const ef_gc_assign_t *a = &L->as[k];
        if (a->index)
            ef_gc_param_set(r, a->index, a->v);
        else if ((rc = ef_gc_named_set(r, a->name, a->v, a->col)) != 0)
            return rc;
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
    r->line_pos = r->pos;
    r->pos += nl ? n + 1 : n;
    r->line++;
    r->qhead = r->qlen = 0;
    line->r = r;
    int rc = ef_gc_compact(r, s, n, line), nwords = 0;
    size_t o = 0;
    if (!rc && line->n && line->c[0] == 'N') /* a line number may precede an O-word */
        for (o = 1; o < line->n && (gc_is_digit(line->c[o]) || line->c[o] == '.'); o++)
            ;
    if (!rc && line->n == 1 && line->c[0] == '%') {
        if (r->line_seen || r->percent) {
            ef_gcode_item_t *it = ef_gc_push(r, EF_GC_END, line->col[0]);
            if (it) {
                snprintf(it->text, sizeof it->text, "%%");
                r->end_item = *it;
                r->ended = 1;
            }
            rc = r->err;
        } else {
            r->percent = 1;
        }
    } else if (!rc && line->n && line->c[0] == '$') {
        rc = gc_ignored_once(r, 5, line->col[0],
                             "$ lines (grbl sender commands such as $H, $X) are not G-code: "
                             "ignored");
    } else if (!rc && o < line->n && line->c[o] == 'O') {
        rc = ef_gc_flow_line(r, line);
        r->line_seen = 1;
    } else if (!rc && line->n) {
        rc = gc_words(line, &nwords);
        if (!rc && line->nw == 0 && line->nas == 0)
            rc = gc_ignored_once(r, 6, line->col[0], "lines with only a line number (N word)");
        else if (!rc)
            rc = gc_execute(r, line);
        r->line_seen = 1;
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
    r->motion = -1;
    r->max_feed = EF_GCODE_MAX_FEED;
    r->cs = 1;
    r->spindle = 5;
    r->retract_r = 1; /* LinuxCNC starts in G99 */
    r->path_mode = EF_GC_PATH_BLEND;
    return EF_OK;
}

int ef_gcode_set_max_feed(ef_gcode_t *r, double feed)
{
    if (!r || !isfinite(feed) || !(feed > 0))
        return EF_ERR_ARG;
    r->max_feed = feed;
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
        r->pos = 0;
        free(r->queue);
        r->queue = NULL;
        r->qcap = 0;
        r->qhead = r->qlen = 0;
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
            if (ef_gc_flow_at_end(r))
                break;
            if (r->line_seen) {
                ef_gcode_item_t *w = ef_gc_push(r, EF_GC_NOTE, 1);
                w->line = r->line ? r->line : 1;
                snprintf(w->text, sizeof w->text,
                         "no M2, M30 or closing %%: the program ends with its text (LinuxCNC "
                         "refuses such a file there)");
            }
            ef_gcode_item_t *e = ef_gc_push(r, EF_GC_END, 1);
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
    size_t cap;
    *it = gc_queue(r, &cap)[r->qhead++];
    return EF_OK;
}

const char *ef_gcode_kind_name(int kind)
{
    static const char *names[] = {"?",     "rapid",   "line",      "arc", "zero",
                                  "event", "ignored", "tolerance", "end", "note"};
    return kind >= 1 && kind <= EF_GC_NOTE ? names[kind] : "?";
}
