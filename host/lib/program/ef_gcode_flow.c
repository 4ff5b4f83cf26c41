/* SPDX-License-Identifier: Apache-2.0 */
/* O-words of the G-code reader, with LinuxCNC's meaning (docs/gcode.md "O-words"):
 * subroutines (sub / endsub / call / return, arguments in #1..#30, named locals per call
 * level) and control structures (if / elseif / else / endif, while / endwhile, do / while,
 * repeat / endrepeat, break, continue).
 *
 * The text is in memory, so control flow is a jump: a loop remembers the mark (offset and
 * line number) of its opening line and goes back to it; a branch not taken, a loop that
 * ends, a break and a subroutine definition met in the flow scan forward for the matching
 * O-word, looking at nothing else on the lines in between (as LinuxCNC does). Every loop is
 * bounded by EF_GCODE_MAX_ITER iterations and calls by EF_GCODE_CALL_DEPTH levels, so a
 * runaway program ends in an error instead of a hang. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "ef_gcode_int.h"

/* Structure kinds (ef_gcode_flow_t.kind). */
enum { FL_IF = 1, FL_WHILE, FL_DO, FL_REPEAT };

/* Keywords, and masks of them for scans. */
enum {
    KW_NONE = 0,
    KW_SUB,
    KW_ENDSUB,
    KW_CALL,
    KW_RETURN,
    KW_IF,
    KW_ELSEIF,
    KW_ELSE,
    KW_ENDIF,
    KW_WHILE,
    KW_ENDWHILE,
    KW_DO,
    KW_REPEAT,
    KW_ENDREPEAT,
    KW_BREAK,
    KW_CONTINUE,
    KW_COUNT
};
static const char *const fl_kw_names[KW_COUNT] = {
    "",      "SUB",   "ENDSUB",   "CALL", "RETURN", "IF",        "ELSEIF", "ELSE",
    "ENDIF", "WHILE", "ENDWHILE", "DO",   "REPEAT", "ENDREPEAT", "BREAK",  "CONTINUE"};
#define KM(k) (1u << (k))

/* An O-word line's header: label, keyword and where the arguments start. */
typedef struct {
    char label[EF_GCODE_NAME_MAX + 3];
    int kw;
    uint32_t col;  /* column of the O */
    uint32_t kcol; /* column of the keyword */
    int numeric;   /* the label is a number */
} fl_head_t;

/* Parse "[N..]O<label><keyword>" at the start of a compacted line. Returns 1 when the line
 * is an O-word line (h filled, cursor after the keyword), 0 when it is not, or an error. */
static int fl_head(ef_gc_line_t *L, fl_head_t *h, int report)
{
    size_t i = 0;
    memset(h, 0, sizeof *h);
    if (i < L->n && L->c[i] == 'N') { /* a line number may come first */
        i++;
        while (i < L->n && ((L->c[i] >= '0' && L->c[i] <= '9') || L->c[i] == '.'))
            i++;
    }
    if (i >= L->n || L->c[i] != 'O')
        return 0;
    h->col = L->col[i];
    i++;
    size_t k = 0;
    if (i < L->n && L->c[i] == '<') {
        h->label[k++] = '<';
        i++;
        while (i < L->n && L->c[i] != '>') {
            if (k >= EF_GCODE_NAME_MAX + 1)
                return report ? ef_gc_err(L->r, h->col, "O-word name longer than %d characters",
                                          EF_GCODE_NAME_MAX)
                              : 0;
            char ch = L->c[i++];
            h->label[k++] = (char)(ch >= 'A' && ch <= 'Z' ? ch - 'A' + 'a' : ch);
        }
        if (i >= L->n)
            return report ? ef_gc_err(L->r, h->col, "O-word name not closed with '>'") : 0;
        i++;
        if (k == 1)
            return report ? ef_gc_err(L->r, h->col, "empty O-word name") : 0;
        h->label[k++] = '>';
        h->label[k] = 0;
    } else {
        long num = 0;
        size_t d = 0;
        while (i < L->n && L->c[i] >= '0' && L->c[i] <= '9') {
            if (num < 100000000)
                num = num * 10 + (L->c[i] - '0');
            i++, d++;
        }
        if (d == 0)
            return report ? ef_gc_err(L->r, h->col, "O-word needs a number or a <name>") : 0;
        if (num >= 100000000)
            return report ? ef_gc_err(L->r, h->col, "O-word number too large") : 0;
        snprintf(h->label, sizeof h->label, "%ld", num);
        h->numeric = 1;
    }
    h->kcol = i < L->n ? L->col[i] : L->end_col;
    size_t ks = i;
    while (i < L->n && L->c[i] >= 'A' && L->c[i] <= 'Z')
        i++;
    size_t kl = i - ks;
    h->kw = -1;
    if (kl == 0)
        h->kw = KW_NONE;
    for (int kw = 1; kw < KW_COUNT && h->kw < 0; kw++)
        if (strlen(fl_kw_names[kw]) == kl && !memcmp(L->c + ks, fl_kw_names[kw], kl))
            h->kw = kw;
    if (h->kw < 0)
        return report
                   ? ef_gc_err(L->r, h->kcol, "unknown O-word keyword '%.*s'", (int)kl, L->c + ks)
                   : 0;
    L->i = i;
    return 1;
}

/* Printable label: "o100", "o<name>". */
static const char *fl_name(const char *label, char *buf, size_t n)
{
    snprintf(buf, n, "o%s", label);
    return buf;
}

/* Scan forward from the next line for an O-word line with this label and a keyword in mask.
 * Found: the reader is left so that the next line read is the found one (stop_at) or the one
 * after it; returns EF_OK with *kw set. End of text: an error naming what was looked for,
 * pointing at the opening line (open_line:open_col). */
static int fl_scan(ef_gcode_t *r, const char *label, unsigned mask, int stop_at, int *kw,
                   uint32_t open_line, uint32_t open_col, const char *what)
{
    ef_gc_line_t *L = malloc(sizeof *L);
    if (!L)
        return ef_gc_err(r, open_col, "out of memory");
    L->r = r;
    int rc = EF_OK;
    for (;;) {
        if (r->pos >= r->len) {
            char nb[48];
            r->line = open_line;
            rc = ef_gc_err(r, open_col, "%s: no %s %s before the end of the program", what,
                           fl_name(label, nb, sizeof nb), fl_kw_names[ffs((int)mask) - 1]);
            if (mask & (mask - 1)) { /* several keywords would do: name them all */
                char list[96] = "";
                for (int k = 1; k < KW_COUNT; k++)
                    if (mask & KM(k)) {
                        strncat(list, list[0] ? "/" : "", sizeof list - strlen(list) - 1);
                        strncat(list, fl_kw_names[k], sizeof list - strlen(list) - 1);
                    }
                rc = ef_gc_err(r, open_col, "%s: no %s %s before the end of the program", what,
                               fl_name(label, nb, sizeof nb), list);
            }
            break;
        }
        size_t start = r->pos;
        const char *s = r->text + r->pos;
        size_t rest = r->len - r->pos;
        const char *nl = memchr(s, '\n', rest);
        size_t n = nl ? (size_t)(nl - s) : rest;
        r->pos += nl ? n + 1 : n;
        r->line++;
        r->line_pos = start;
        if ((rc = ef_gc_compact(r, s, n, L)) != 0)
            break;
        fl_head_t h;
        if (fl_head(L, &h, 0) == 1 && h.kw > 0 && (mask & KM(h.kw)) && !strcmp(h.label, label)) {
            *kw = h.kw;
            if (stop_at) {
                r->pos = start;
                r->line--;
            }
            break;
        }
    }
    free(L);
    return rc;
}

/* The one bracketed argument of if / elseif / while / repeat. */
static int fl_arg1(ef_gc_line_t *L, const fl_head_t *h, double *v)
{
    if (L->i >= L->n || L->c[L->i] != '[')
        return ef_gc_err(L->r, h->kcol, "%s needs a bracketed expression", fl_kw_names[h->kw]);
    L->depth = 0;
    int rc = ef_gc_bracket(L, v);
    if (rc)
        return rc;
    if (L->i < L->n)
        return ef_gc_err(L->r, L->col[L->i], "unexpected text after the O-word's expression");
    return EF_OK;
}

/* Nothing may follow keywords without arguments. */
static int fl_noargs(ef_gc_line_t *L, const fl_head_t *h)
{
    if (L->i < L->n)
        return ef_gc_err(L->r, L->col[L->i], "unexpected text after O-word %s", fl_kw_names[h->kw]);
    return EF_OK;
}

/* The structure stack of the current call level. */
static ef_gcode_flow_t *fl_stack(ef_gcode_t *r)
{
    return r->flow[r->depth];
}

static ef_gcode_flow_t *fl_top(ef_gcode_t *r)
{
    return r->nflow ? &fl_stack(r)[r->nflow - 1] : NULL;
}

/* Open a structure at the current line. */
static int fl_push(ef_gcode_t *r, int kind, const fl_head_t *h)
{
    if (r->nflow >= EF_GCODE_FLOW_DEPTH)
        return ef_gc_err(r, h->col, "more than %d nested O-word structures", EF_GCODE_FLOW_DEPTH);
    ef_gcode_flow_t *f = &fl_stack(r)[r->nflow++];
    memset(f, 0, sizeof *f);
    f->kind = kind;
    snprintf(f->label, sizeof f->label, "%s", h->label);
    f->at.pos = r->line_pos;
    f->at.line = r->line;
    f->body = ef_gc_here_mark(r);
    f->col = h->col;
    return EF_OK;
}

/* One more iteration of loop f: bounded. */
static int fl_iter(ef_gcode_t *r, ef_gcode_flow_t *f)
{
    if (++f->iter >= EF_GCODE_MAX_ITER) { /* the first pass is not a jump back */
        char nb[48];
        r->line = f->at.line;
        return ef_gc_err(r, f->col, "%s loop ran %d times: a runaway loop, stopped",
                         fl_name(f->label, nb, sizeof nb), EF_GCODE_MAX_ITER);
    }
    return EF_OK;
}

/* The innermost loop with this label, or -1. */
static int fl_find_loop(const ef_gcode_t *r, const char *label)
{
    for (int k = r->nflow - 1; k >= 0; k--) {
        const ef_gcode_flow_t *f = &r->flow[r->depth][k];
        if (f->kind != FL_IF && !strcmp(f->label, label))
            return k;
    }
    return -1;
}

/* Mismatched structure: "o100 endif without o100 if". */
static int fl_mismatch(ef_gcode_t *r, const fl_head_t *h, const char *want)
{
    char nb[48];
    const ef_gcode_flow_t *t = fl_top(r);
    if (t && strcmp(t->label, h->label)) {
        char ob[48];
        return ef_gc_err(r, h->col, "%s %s inside %s (opened on line %u): structures must nest",
                         fl_name(h->label, nb, sizeof nb), fl_kw_names[h->kw],
                         fl_name(t->label, ob, sizeof ob), (unsigned)t->at.line);
    }
    return ef_gc_err(r, h->col, "%s %s without %s %s", fl_name(h->label, nb, sizeof nb),
                     fl_kw_names[h->kw], nb, want);
}

/* Index of a known subroutine, or -1. */
static int fl_find_sub(const ef_gcode_t *r, const char *label)
{
    for (int k = 0; k < r->nsubs; k++)
        if (!strcmp(r->subs[k].label, label))
            return k;
    return -1;
}

/* Record a subroutine whose "oN sub" line is the one just read. */
static int fl_define(ef_gcode_t *r, const fl_head_t *h)
{
    int k = fl_find_sub(r, h->label);
    if (k >= 0) {
        char nb[48];
        if (r->subs[k].searched) /* LinuxCNC: "found in illegal location" */
            return ef_gc_err(r, h->col,
                             "%s sub reached in the program after it was called: define a "
                             "subroutine before its first call or after M2",
                             fl_name(h->label, nb, sizeof nb));
        if (r->subs[k].at.line == r->line)
            return EF_OK;
        return ef_gc_err(r, h->col, "subroutine %s defined twice (first on line %u)",
                         fl_name(h->label, nb, sizeof nb), (unsigned)r->subs[k].at.line);
    }
    if (r->nsubs >= EF_GCODE_NSUBS)
        return ef_gc_err(r, h->col, "more than %d subroutines", EF_GCODE_NSUBS);
    ef_gcode_sub_t *s = &r->subs[r->nsubs++];
    snprintf(s->label, sizeof s->label, "%s", h->label);
    s->at.pos = r->line_pos;
    s->at.line = r->line;
    s->body = ef_gc_here_mark(r);
    return EF_OK;
}

/* A call of a subroutine not yet met: LinuxCNC finds a definition anywhere in the file. */
static int fl_search_sub(ef_gcode_t *r, const fl_head_t *h, int *index)
{
    ef_gcode_mark_t back = ef_gc_here_mark(r);
    uint32_t line = r->line;
    size_t line_pos = r->line_pos;
    ef_gcode_mark_t top = {0, 1};
    int kw, rc;
    ef_gc_jump(r, top);
    rc = fl_scan(r, h->label, KM(KW_SUB), 0, &kw, line, h->col, "call");
    if (rc == EF_OK) {
        ef_gcode_mark_t def = {r->line_pos, r->line};
        ef_gcode_mark_t body = ef_gc_here_mark(r);
        if (r->nsubs >= EF_GCODE_NSUBS) {
            r->line = line;
            return ef_gc_err(r, h->col, "more than %d subroutines", EF_GCODE_NSUBS);
        }
        ef_gcode_sub_t *s = &r->subs[r->nsubs];
        snprintf(s->label, sizeof s->label, "%s", h->label);
        s->at = def;
        s->body = body;
        s->searched = 1;
        *index = r->nsubs++;
        ef_gc_jump(r, back);
        r->line = line;
        r->line_pos = line_pos;
        return EF_OK;
    }
    /* name the call, not the scan */
    char nb[48];
    r->err = 0;
    r->line = line;
    return ef_gc_err(r, h->col, "call of %s: subroutine not defined in this program",
                     fl_name(h->label, nb, sizeof nb));
}

/* Leave the current subroutine (endsub or return), with an optional value. */
static int fl_return(ef_gcode_t *r, const fl_head_t *h, int have_v, double v)
{
    char nb[48];
    if (r->depth == 0)
        return ef_gc_err(r, h->col, "%s %s outside a subroutine call",
                         fl_name(h->label, nb, sizeof nb), fl_kw_names[h->kw]);
    ef_gcode_frame_t *f = &r->frames[r->depth - 1];
    if (strcmp(f->label, h->label)) {
        char ob[48];
        return ef_gc_err(r, h->col, "%s %s inside subroutine %s", fl_name(h->label, nb, sizeof nb),
                         fl_kw_names[h->kw], fl_name(f->label, ob, sizeof ob));
    }
    for (int k = 0; k < 30; k++)
        r->param[k + 1] = f->saved[k];
    ef_gc_named_drop_level(r, r->depth);
    r->depth--;
    r->nflow = f->nflow;
    int rc = ef_gc_named_set(r, "_VALUE_RETURNED", have_v ? 1.0 : 0.0, h->col);
    if (!rc && have_v)
        rc = ef_gc_named_set(r, "_VALUE", v, h->col);
    ef_gc_jump(r, f->ret);
    return rc;
}

int ef_gc_flow_line(ef_gcode_t *r, ef_gc_line_t *L)
{
    fl_head_t h;
    int rc = fl_head(L, &h, 1), kw;
    if (rc != 1)
        return rc ? rc : ef_gc_err(r, 1, "not an O-word line");
    char nb[48];
    double v = 0;
    ef_gcode_flow_t *t = fl_top(r);
    switch (h.kw) {
    case KW_NONE:
        /* Fanuc-style program number: "O1234" alone before any other line. */
        if (h.numeric && !r->line_seen && L->i >= L->n) {
            ef_gcode_item_t *it = ef_gc_push(r, EF_GC_IGNORED, h.col);
            if (!it)
                return r->err;
            snprintf(it->text, sizeof it->text, "O%s (program number)", h.label);
            return EF_OK;
        }
        return ef_gc_err(r, h.col, "O-word %s without a keyword (sub, call, if, while...)",
                         fl_name(h.label, nb, sizeof nb));
    case KW_SUB:
        if ((rc = fl_noargs(L, &h)) != 0 || (rc = fl_define(r, &h)) != 0)
            return rc;
        /* met in the flow: the body runs only when called */
        return fl_scan(r, h.label, KM(KW_ENDSUB), 0, &kw, r->line, h.col, "sub");
    case KW_ENDSUB:
    case KW_RETURN:
        if (L->i < L->n) {
            if ((rc = fl_arg1(L, &h, &v)) != 0)
                return rc;
            return fl_return(r, &h, 1, v);
        }
        return fl_return(r, &h, 0, 0);
    case KW_CALL: {
        double args[30];
        int na = 0;
        while (L->i < L->n) {
            if (L->c[L->i] != '[')
                return ef_gc_err(r, L->col[L->i], "call arguments must be bracketed expressions");
            if (na >= 30)
                return ef_gc_err(r, L->col[L->i], "more than 30 call arguments");
            L->depth = 0;
            if ((rc = ef_gc_bracket(L, &args[na])) != 0)
                return rc;
            na++;
        }
        int k = fl_find_sub(r, h.label);
        if (k < 0 && (rc = fl_search_sub(r, &h, &k)) != 0)
            return rc;
        if (r->depth >= EF_GCODE_CALL_DEPTH)
            return ef_gc_err(r, h.col,
                             "call of %s nested deeper than %d levels (runaway "
                             "recursion?)",
                             fl_name(h.label, nb, sizeof nb), EF_GCODE_CALL_DEPTH);
        ef_gcode_frame_t *f = &r->frames[r->depth];
        snprintf(f->label, sizeof f->label, "%s", h.label);
        f->ret = ef_gc_here_mark(r);
        f->nflow = r->nflow;
        for (int j = 0; j < 30; j++) {
            f->saved[j] = r->param[j + 1];
            r->param[j + 1] = j < na ? args[j] : 0.0;
        }
        r->depth++;
        r->nflow = 0;
        ef_gc_jump(r, r->subs[k].body);
        return EF_OK;
    }
    case KW_IF:
        if ((rc = fl_arg1(L, &h, &v)) != 0 || (rc = fl_push(r, FL_IF, &h)) != 0)
            return rc;
        fl_top(r)->count = v != 0;
        if (v != 0)
            return EF_OK;
        return fl_scan(r, h.label, KM(KW_ELSEIF) | KM(KW_ELSE) | KM(KW_ENDIF), 1, &kw, r->line,
                       h.col, "if");
    case KW_ELSEIF:
    case KW_ELSE:
        if (!t || t->kind != FL_IF || strcmp(t->label, h.label))
            return fl_mismatch(r, &h, "if");
        if (t->count) /* a branch ran: skip to endif */
            return fl_scan(r, h.label, KM(KW_ENDIF), 1, &kw, t->at.line, t->col, "if");
        if (h.kw == KW_ELSE) {
            if ((rc = fl_noargs(L, &h)) != 0)
                return rc;
            t->count = 1;
            return EF_OK;
        }
        if ((rc = fl_arg1(L, &h, &v)) != 0)
            return rc;
        t->count = v != 0;
        if (v != 0)
            return EF_OK;
        return fl_scan(r, h.label, KM(KW_ELSEIF) | KM(KW_ELSE) | KM(KW_ENDIF), 1, &kw, t->at.line,
                       t->col, "if");
    case KW_ENDIF:
        if (!t || t->kind != FL_IF || strcmp(t->label, h.label))
            return fl_mismatch(r, &h, "if");
        r->nflow--;
        return fl_noargs(L, &h);
    case KW_DO:
        if ((rc = fl_noargs(L, &h)) != 0)
            return rc;
        return fl_push(r, FL_DO, &h);
    case KW_WHILE:
        if ((rc = fl_arg1(L, &h, &v)) != 0)
            return rc;
        if (t && t->kind == FL_DO && !strcmp(t->label, h.label)) { /* closes do ... while */
            if (v == 0) {
                r->nflow--;
                return EF_OK;
            }
            if ((rc = fl_iter(r, t)) != 0)
                return rc;
            ef_gc_jump(r, t->body);
            return EF_OK;
        }
        if (t && t->kind == FL_WHILE && !strcmp(t->label, h.label) && t->at.line == r->line) {
            if (v != 0)
                return fl_iter(r, t);
            r->nflow--;
        } else if (v != 0) {
            return fl_push(r, FL_WHILE, &h);
        }
        return fl_scan(r, h.label, KM(KW_ENDWHILE), 0, &kw, r->line, h.col, "while");
    case KW_ENDWHILE:
        if (!t || t->kind != FL_WHILE || strcmp(t->label, h.label))
            return fl_mismatch(r, &h, "while");
        if ((rc = fl_noargs(L, &h)) != 0)
            return rc;
        ef_gc_jump(r, t->at);
        return EF_OK;
    case KW_REPEAT: {
        if ((rc = fl_arg1(L, &h, &v)) != 0)
            return rc;
        double n = floor(v + 1e-9);
        if (n > EF_GCODE_MAX_ITER)
            return ef_gc_err(r, h.col, "repeat count %.6g above %d", v, EF_GCODE_MAX_ITER);
        if (n < 1)
            return fl_scan(r, h.label, KM(KW_ENDREPEAT), 0, &kw, r->line, h.col, "repeat");
        if ((rc = fl_push(r, FL_REPEAT, &h)) != 0)
            return rc;
        fl_top(r)->count = (long)n;
        return EF_OK;
    }
    case KW_ENDREPEAT:
        if (!t || t->kind != FL_REPEAT || strcmp(t->label, h.label))
            return fl_mismatch(r, &h, "repeat");
        if ((rc = fl_noargs(L, &h)) != 0)
            return rc;
        if (--t->count > 0) {
            if ((rc = fl_iter(r, t)) != 0)
                return rc;
            ef_gc_jump(r, t->body);
        } else {
            r->nflow--;
        }
        return EF_OK;
    case KW_BREAK:
    case KW_CONTINUE: {
        if ((rc = fl_noargs(L, &h)) != 0)
            return rc;
        int k = fl_find_loop(r, h.label);
        if (k < 0)
            return ef_gc_err(r, h.col, "%s %s outside a %s loop", fl_name(h.label, nb, sizeof nb),
                             fl_kw_names[h.kw], nb);
        ef_gcode_flow_t *f = &fl_stack(r)[k];
        int end = f->kind == FL_WHILE    ? KW_ENDWHILE
                  : f->kind == FL_REPEAT ? KW_ENDREPEAT
                                         : KW_WHILE;
        uint32_t oline = f->at.line, ocol = f->col;
        r->nflow = h.kw == KW_BREAK ? k : k + 1;
        /* continue: the end line runs (it loops or ends the loop); break: go past it */
        return fl_scan(r, h.label, KM(end), h.kw == KW_CONTINUE, &kw, oline, ocol,
                       f->kind == FL_WHILE ? "while"
                       : f->kind == FL_DO  ? "do"
                                           : "repeat");
    }
    default:
        return ef_gc_err(r, h.col, "unsupported O-word");
    }
}

int ef_gc_flow_at_end(ef_gcode_t *r)
{
    char nb[48];
    if (r->depth > 0) {
        const ef_gcode_frame_t *f = &r->frames[r->depth - 1];
        return ef_gc_err(r, 1, "end of the program inside subroutine %s (no endsub)",
                         fl_name(f->label, nb, sizeof nb));
    }
    if (r->nflow > 0) {
        const ef_gcode_flow_t *f = fl_top(r);
        static const char *ends[] = {"", "endif", "endwhile", "while", "endrepeat"};
        r->line = f->at.line;
        return ef_gc_err(r, f->col, "%s opened here is not closed (no %s %s)",
                         fl_name(f->label, nb, sizeof nb), nb, ends[f->kind]);
    }
    return EF_OK;
}
