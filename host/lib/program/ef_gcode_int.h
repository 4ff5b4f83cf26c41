/* SPDX-License-Identifier: Apache-2.0 */
/* Internal interface of the G-code reader, shared by ef_gcode.c (lines, words, expressions,
 * motion, offsets), ef_gcode_flow.c (O-words) and ef_gcode_cycle.c (canned cycles). */
#ifndef EF_GCODE_INT_H
#define EF_GCODE_INT_H

#include <stddef.h>
#include <stdint.h>
#include "evenfeed/host/program/ef_gcode.h"

#define EF_GC_MAX_WORDS  64 /* words on one line */
#define EF_GC_MAX_ASSIGN 32 /* parameter assignments on one line */
#define EF_GC_MAX_DEPTH  64 /* expression nesting: bounds the recursion on hostile input */
#define EF_GC_INCH       25.4
#define EF_GC_PI         3.14159265358979323846
#define EF_GC_TWO_PI     (2.0 * EF_GC_PI)

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

/* Record a sticky error "name:line:col: text"; returns EF_ERR_GCODE. */
int ef_gc_err(ef_gcode_t *r, uint32_t col, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Strip whitespace and comments of one source line, upper-case the rest (columns kept). */
int ef_gc_compact(ef_gcode_t *r, const char *s, size_t n, ef_gc_line_t *L);

/* '[' expression ']' at the cursor. */
int ef_gc_bracket(ef_gc_line_t *L, double *out);

/* A fresh queue item of a kind at the current line; NULL (error set) when the line
 * expands into more than EF_GCODE_LINE_ITEMS_MAX items or memory runs out. */
ef_gcode_item_t *ef_gc_push(ef_gcode_t *r, int kind, uint32_t col);

/* Numbered parameter n (1..EF_GCODE_NPARAM-1) as a program reads it, and set. Offsets and
 * stored positions are held in mm and read in the program's units. */
double ef_gc_param_get(const ef_gcode_t *r, int n);
void ef_gc_param_set(ef_gcode_t *r, int n, double v);

/* Named parameters: the value of name visible at the current call level (-1 when unset),
 * set (creating it at the level its name implies), and drop a level's locals. */
int ef_gc_named_get(const ef_gcode_t *r, const char *name, double *v);
int ef_gc_named_set(ef_gcode_t *r, const char *name, double v, uint32_t col);
void ef_gc_named_drop_level(ef_gcode_t *r, int level);

/* Move the reader to a marked line (the next line read is that one). */
void ef_gc_jump(ef_gcode_t *r, ef_gcode_mark_t at);

/* The mark of the next line to read. */
ef_gcode_mark_t ef_gc_here_mark(const ef_gcode_t *r);

/* Straight move (G0: rapid 1, G1: 0) to a machine-coordinate end, X Y Z and A B C U V W
 * (aend NULL: those stay); the feed comes from the reader's state by LinuxCNC's rule of
 * which axes it applies to. Zero moves (all nine axes still) are reported. */
int ef_gc_emit_straight(ef_gcode_t *r, int rapid, const double end[3],
                        const double aend[EF_GCODE_AUX], uint32_t col);

/* A dwell event "G4 Pn". */
int ef_gc_emit_dwell(ef_gcode_t *r, double seconds, uint32_t col);

/* An event item with a text. */
int ef_gc_emit_event(ef_gcode_t *r, const char *text, uint32_t col);

/* A tolerance item: mode and tolerances (mm). */
int ef_gc_emit_tolerance(ef_gcode_t *r, int mode, double p, double q, uint32_t col);

/* Program coordinates (mm) of the current position, and machine coordinates of a program
 * point reached by moving from the current position (delta-based: untouched axes stay
 * exact). */
void ef_gc_to_prog(const ef_gcode_t *r, const double m[3], double p[3]);
void ef_gc_from_prog(const ef_gcode_t *r, const double p[3], double m[3]);

/* O-word line (the compacted line starts with 'O'): run its control flow. */
int ef_gc_flow_line(ef_gcode_t *r, ef_gc_line_t *L);

/* At the end of the text: an error if a subroutine call or a structure is still open. */
int ef_gc_flow_at_end(ef_gcode_t *r);

/* Canned cycle block (motion mode G73, G81-G89) with the line's words. */
int ef_gc_cycle(ef_gcode_t *r, const ef_gc_line_t *L, int motion, int same,
                const ef_gc_word_t *axis[3], double scale, uint32_t col);

/* The word for a letter, or NULL. */
const ef_gc_word_t *ef_gc_get(const ef_gc_line_t *L, char letter);

/* Tool table entry of a tool number; with create, a new zeroed one when there is none
 * (NULL when the table is full). */
ef_gcode_tool_t *ef_gc_tool(ef_gcode_t *r, int tool, int create);

#endif /* EF_GCODE_INT_H */
