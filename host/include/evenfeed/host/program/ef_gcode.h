/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_gcode.h
 * @brief Streaming reader for part programs in LinuxCNC's RS274NGC dialect.
 *
 * The reader turns a part program into a stream of items, one per ef_gcode_next() call:
 * path primitives (rapid, line, arc, spiral), pass-through events (tool change, spindle,
 * coolant, dwell...), notes (feeds clamped, words ignored, each ignored kind once),
 * tolerance changes (G61, G64 P Q) and a final end item. It follows O-word subroutines and
 * control flow, expands canned cycles and applies work, G92 and tool offsets, with
 * LinuxCNC's meaning; docs/gcode.md has the table of what is supported, refused and
 * ignored. The rules that matter to callers:
 *
 * - Positions are machine coordinates in millimetres: machine = rot_xy(program + G92) +
 *   G5x + tool length offset, as LinuxCNC's canon maps them. G20 input is converted
 *   (x 25.4) and every item records the units the program was in
 *   (::ef_gcode_item_t::units). Feeds are in mm/min (G93 converted), clamped to
 *   ::EF_GCODE_MAX_FEED or ef_gcode_set_max_feed()'s limit with a note.
 * - The other LinuxCNC axes A B C (rotary, degrees) and U V W (linear, mm) are read too
 *   and carried beside X Y Z (::ef_gcode_item_t::astart, ::ef_gcode_item_t::aend), with
 *   work offsets, G92 and G28/G30 positions as in LinuxCNC; no XY rotation and no tool
 *   offset applies to them. A move of only those axes is a RAPID or LINE item whose X Y Z
 *   start and end are equal; its feed follows LinuxCNC's rule (::ef_gcode_item_t::feed).
 * - The program starts at machine (0, 0, 0) (all nine axes) with G21 G90 G91.1 G17 G94
 *   G99 G64, zero offsets, no motion mode and no feed: axis words before the first motion
 *   code are an error, as is a feed move before the first positive F.
 * - A G0/G1 whose end equals its start on all nine axes (within ::EF_GCODE_ZERO_LEN) is
 *   reported as a ::EF_GC_ZERO_MOVE item, never dropped silently. An IJK arc whose end
 *   equals its start is a full circle (times the P word, default 1).
 * - Arc radius rule (LinuxCNC 2.9's): an arc whose end radius differs from its start
 *   radius within the rule of ::EF_GCODE_ARC_ABS_TOL_MM is a spiral (radius_end differs
 *   from radius, linear in the angle); beyond it the arc is an error.
 * - Loops, recursion and expansions are bounded (::EF_GCODE_MAX_ITER,
 *   ::EF_GCODE_CALL_DEPTH, ::EF_GCODE_LINE_ITEMS_MAX): a runaway program ends in an error.
 * - Errors are ::EF_ERR_GCODE with the message "name:line:col: text" (1-based, col counts
 *   bytes); nothing of the bad line or after it comes out, and every further call returns
 *   the same error.
 */
#ifndef EF_GCODE_H
#define EF_GCODE_H

#include <stddef.h>
#include <stdint.h>
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Moves not longer than this (mm; degrees for A B C) are ::EF_GC_ZERO_MOVE items. */
#define EF_GCODE_ZERO_LEN 1e-9
/** Largest accepted coordinate magnitude (mm), for positions, centres and radii; for the
 *  rotary axes A B C the same number in degrees. */
#define EF_GCODE_MAX_COORD 1e6
/** Axes beyond X Y Z, in this order in every array of them: A B C (rotary, degrees, never
 *  scaled by G20) and U V W (linear, mm, G20 input converted like X Y Z). */
#define EF_GCODE_AUX 6
/** Feeds above this (mm/min) are clamped to it, with an ::EF_GC_NOTE naming the line
 *  (ef_gcode_set_max_feed() lowers it to a machine's limit). */
#define EF_GCODE_MAX_FEED 1e7
/** Arc radius consistency (LinuxCNC 2.9's spiral rule): an IJK arc whose end radius r1
 *  differs from its start radius r0 is refused when |r1 - r0| > 100 x the absolute
 *  tolerance, or when |r1 - r0| / max(r0, r1) > ::EF_GCODE_ARC_REL_TOL and |r1 - r0| >
 *  the absolute tolerance; otherwise it is a spiral (radius linear in the angle). The
 *  absolute tolerance depends on the program's units, as LinuxCNC's: this in mm... */
#define EF_GCODE_ARC_ABS_TOL_MM 0.0282842712474619
/** ...and this in inches (0.002 x sqrt 2 in, as mm). */
#define EF_GCODE_ARC_ABS_TOL_IN (0.00282842712474619 * 25.4)
/** Arc radius consistency: relative part (fraction of the larger radius). */
#define EF_GCODE_ARC_REL_TOL 0.001
/** Radius tolerance of the R form (mm): R may be shorter than half the chord by this. */
#define EF_GCODE_ARC_R_TOL 0.00127
/** Numbered parameters are #1 .. #EF_GCODE_NPARAM-1 (LinuxCNC's range). */
#define EF_GCODE_NPARAM 5602
/** Named parameters (#<name>) live at once, all call levels together. */
#define EF_GCODE_NNAMED 512
/** Longest named-parameter or O-word name (characters, spaces removed). */
#define EF_GCODE_NAME_MAX 31
/** Longest accepted source line (bytes). */
#define EF_GCODE_LINE_MAX 4096
/** Largest file ef_gcode_open() loads (bytes). */
#define EF_GCODE_FILE_MAX ((size_t)256 << 20)
/** Subroutine call depth (LinuxCNC's limit). */
#define EF_GCODE_CALL_DEPTH 10
/** Open control structures (if, while, do, repeat) per call level. */
#define EF_GCODE_FLOW_DEPTH 32
/** Subroutines a program may define. */
#define EF_GCODE_NSUBS 256
/** Iterations of one loop before it is called a runaway (an error, not a hang); the fuzz
 *  target builds with a smaller bound so that runaway inputs stay fast. */
#ifndef EF_GCODE_MAX_ITER
#define EF_GCODE_MAX_ITER 1000000
#endif
/** Items one source line may expand into (canned cycles with L repeats and pecks). */
#define EF_GCODE_LINE_ITEMS_MAX 100000
/** Tool table entries (G10 L1 / L10 / L11). */
#define EF_GCODE_NTOOLS 64

/** Item kinds. */
typedef enum {
    EF_GC_RAPID = 1,     /**< G0 straight rapid: start, end */
    EF_GC_LINE = 2,      /**< G1 straight feed move: start, end, feed */
    EF_GC_ARC = 3,       /**< G2/G3 arc, helix or spiral: start, end, centre, radius,
                              radius_end, dir, plane, turns, feed */
    EF_GC_ZERO_MOVE = 4, /**< G0/G1 whose end equals its start on all nine axes */
    EF_GC_EVENT = 5,     /**< words that do not move the path, as text (e.g. "T1 M6") */
    EF_GC_IGNORED = 6,   /**< a word or line accepted and ignored, reported on first use */
    EF_GC_TOLERANCE = 7, /**< path control change: G61 / G61.1 (exact) or G64 P Q */
    EF_GC_END = 8,       /**< M2, M30, closing % or end of text; repeated on later calls */
    EF_GC_NOTE = 9,      /**< how a line was read, each time (a feed clamped) */
} ef_gcode_kind_t;

/** Path control modes of an ::EF_GC_TOLERANCE item. */
typedef enum {
    EF_GC_PATH_EXACT = 1, /**< G61 / G61.1: stop exactly at every vertex */
    EF_GC_PATH_BLEND = 2, /**< G64: blend within p_tol (0: no tolerance given) */
} ef_gcode_path_t;

/** One item of the stream. Fields not used by a kind are zero. Positions are machine
 *  coordinates in mm: work offsets (G54-G59.3, G10 L2/L20), G92 offsets and the tool
 *  length offset (G43, X Y Z only) applied. Items with a start and an end (RAPID, LINE,
 *  ARC, ZERO_MOVE) carry all nine axes: X Y Z in start/end, A B C U V W in astart/aend. */
typedef struct {
    int kind;          /**< ::ef_gcode_kind_t */
    uint32_t line;     /**< 1-based source line */
    uint32_t col;      /**< 1-based column (bytes) of the word that produced it */
    int units;         /**< program units when the item was read: 20 (inch) or 21 (mm) */
    double start[3];   /**< X Y Z at the start (mm); also set for ZERO_MOVE */
    double end[3];     /**< X Y Z at the end (mm); equal to start for a move of only
                            A B C U V W */
    double centre[3];  /**< arc centre (mm); its normal-axis coordinate is the start's */
    double radius;     /**< arc radius at the start (mm) */
    double radius_end; /**< arc radius at the end (mm): equal to radius for a circle; a
                            spiral's radius is linear in the angle between the two */
    double sweep;      /**< arc angle (rad) about the plane normal: > 0 for G3, < 0 for G2,
                            full turns included */
    double feed;       /**< LINE/ARC: feed (> 0; G93 converted), the speed along the length
                            LinuxCNC applies it to: the X Y Z length (mm/min) when X, Y or
                            Z moves (always for an ARC), else the U V W length (mm/min)
                            when U, V or W moves, else the A B C length in degrees
                            (deg/min). The A B C feed is the F number as written, not
                            converted under G20 (LinuxCNC's angular feed); G93 makes it F
                            x that length. The other axes move in step with it. The
                            A B C feed is clamped to the same number as mm/min feeds. */
    int dir;           /**< arc direction: +1 G3 (counter-clockwise), -1 G2 (clockwise) */
    int plane;         /**< arc plane: 17 (XY, normal +Z), 18 (ZX, normal +Y), 19 (YZ, +X) */
    int turns;         /**< arc: P word, number of times the end angle is passed (>= 1) */
    int path_mode;     /**< TOLERANCE: ::ef_gcode_path_t */
    double p_tol;      /**< TOLERANCE: G64 P, path tolerance (mm), 0 when not given */
    double q_tol;      /**< TOLERANCE: G64 Q, collinearity tolerance (mm), 0 when not given */
    char text[128];    /**< EVENT/IGNORED/NOTE: the words ("T1 M6", "G40") or the note;
                            END: what ended it ("M2", "M30", "%", "end of text") */

    double astart[EF_GCODE_AUX]; /**< A B C (degrees) and U V W (mm) at the start, machine
                                      coordinates (work and G92 offsets applied; no tool
                                      offset, no XY rotation) */
    double aend[EF_GCODE_AUX];   /**< A B C U V W at the end; an arc moves them linearly
                                      from astart to aend while its X Y Z follow the arc */
} ef_gcode_item_t;

/** A named parameter: its value and the call level that owns it (-1: global, "_name"). */
typedef struct {
    char name[EF_GCODE_NAME_MAX + 1];
    double v;
    int level;
} ef_gcode_named_t;

/** A place in the text: byte offset of a line's start and its 1-based number. */
typedef struct {
    size_t pos;
    uint32_t line;
} ef_gcode_mark_t;

/** An open control structure (O-word if / while / do / repeat). */
typedef struct {
    int kind;                          /**< internal structure kind */
    char label[EF_GCODE_NAME_MAX + 3]; /**< the O-word label ("100", "<name>") */
    ef_gcode_mark_t at;                /**< the opening line (loops jump back to it) */
    ef_gcode_mark_t body;              /**< the line after it (do / repeat bodies) */
    uint32_t col;                      /**< column of the opening O-word */
    long count;                        /**< repeat: iterations left; if: branch taken */
    long iter;                         /**< iterations so far (runaway bound) */
} ef_gcode_flow_t;

/** A subroutine call in progress. */
typedef struct {
    char label[EF_GCODE_NAME_MAX + 3]; /**< the subroutine's label */
    ef_gcode_mark_t ret;               /**< where the caller goes on */
    double saved[30];                  /**< the caller's #1..#30 */
    int nflow;                         /**< the caller's open structures */
} ef_gcode_frame_t;

/** A known subroutine: where its body starts. */
typedef struct {
    char label[EF_GCODE_NAME_MAX + 3];
    ef_gcode_mark_t body; /**< the line after "oN sub" */
    ef_gcode_mark_t at;   /**< the "oN sub" line */
    int searched;         /**< found by a call's search, not met in the flow */
} ef_gcode_sub_t;

/** A tool table entry (G10 L1 / L10 / L11), offsets in mm. */
typedef struct {
    int tool;
    double off[3];
    double diameter;
} ef_gcode_tool_t;

/** Reader state. Treat as opaque; the fields are here so it can be embedded. It is about
 *  half a megabyte: keep it static or on the heap. */
typedef struct {
    const char *text;      /**< program text (not owned unless buf is set) */
    size_t len;            /**< bytes of text */
    size_t pos;            /**< offset of the next unread line */
    char *buf;             /**< owned copy from ef_gcode_open(), or NULL */
    char name[128];        /**< program name for messages */
    uint32_t line;         /**< number of the last line read */
    size_t line_pos;       /**< offset of the last line read */
    int err;               /**< sticky error code (0 while healthy) */
    int ended;             /**< an end item has been produced */
    int percent;           /**< the text opened with a % line */
    int line_seen;         /**< a line with words has been read */
    int units;             /**< 20 or 21 */
    int absolute;          /**< G90 (1) or G91 (0) */
    int arc_absolute;      /**< G90.1 (1) or G91.1 (0) */
    int plane;             /**< 17, 18 or 19 */
    int motion;            /**< modal motion: G code x 10 (0, 10, 20, 30, 810...), -1 none */
    double feed;           /**< mm/min, 0 until an F word */
    double max_feed;       /**< feeds above are clamped (mm/min) */
    double feed_ang;       /**< deg/min: the F number as written (feed of A B C-only moves) */
    double cur[3];         /**< current position, machine coordinates (mm); acur: the rest */
    uint32_t ignored_seen; /**< bit set of ignored words already reported */
    double param[EF_GCODE_NPARAM];           /**< numbered parameters (offsets held below, in mm) */
    ef_gcode_named_t named[EF_GCODE_NNAMED]; /**< named parameters */
    int nnamed;                              /**< named parameters defined */
    /* offsets of the nine axes X Y Z A B C U V W (mm; A B C and rotation in degrees) */
    int cs;                                 /**< coordinate system 1..9 (G54..G59.3) */
    double g5x[9][9];                       /**< work offsets (#5221-5229...) */
    double rot[9];                          /**< XY rotation of each system (#5230...) */
    double g92[9];                          /**< G92 offset in force */
    double g92_saved[9];                    /**< #5211-5219 */
    int g92_on;                             /**< #5210 */
    double g28[9], g30[9];                  /**< #5161-5169, #5181-5189 */
    double tlo[3];                          /**< tool length offset in force (X Y Z only) */
    double acur[EF_GCODE_AUX];              /**< current A B C (deg) U V W (mm), machine coords */
    ef_gcode_tool_t tools[EF_GCODE_NTOOLS]; /**< tool table (in memory) */
    int ntools;
    int tool_prep, tool_cur;           /**< T word, tool in the spindle (M6, M61) */
    int spindle;                       /**< 3, 4 or 5 (M3 M4 M5) */
    int diameter;                      /**< G7 lathe diameter mode */
    int inverse_time;                  /**< G93 */
    int retract_r;                     /**< G99 (1) or G98 (0) */
    int path_mode;                     /**< in force: ::ef_gcode_path_t */
    double path_p, path_q;             /**< in force: G64 P Q (mm) */
    double cyc_r, cyc_z, cyc_q, cyc_p; /**< sticky canned-cycle words (mm, s) */
    int cyc_have_q, cyc_have_p;        /**< Q and P given since the cycle mode began */
    double cyc_ijk[3];                 /**< G87 I J K (mm), sticky within the cycle mode */
    int cyc_have_ijk[3];               /**< I, J, K given since the cycle mode began */
    double cyc_il;                     /**< initial level: drill-axis program coordinate
                                            when the cycle mode began (mm) */
    int cyc_il_flag;                   /**< cyc_il is set */
    /* O-words */
    ef_gcode_frame_t frames[EF_GCODE_CALL_DEPTH]; /**< calls in progress */
    int depth;                                    /**< call depth (0: main program) */
    ef_gcode_flow_t flow[EF_GCODE_CALL_DEPTH + 1][EF_GCODE_FLOW_DEPTH]; /**< per level */
    int nflow;                           /**< open structures at this level */
    ef_gcode_sub_t subs[EF_GCODE_NSUBS]; /**< subroutines known */
    int nsubs;
    int skip_def; /**< inside "oN sub" ... "oN endsub" read in the flow */
    /* items of the current line */
    ef_gcode_item_t queue0[16]; /**< inline storage */
    ef_gcode_item_t *queue;     /**< heap array for long expansions, or NULL (queue0) */
    size_t qcap;                /**< capacity of queue */
    ef_gcode_item_t end_item;   /**< the end item, repeated once ended */
    size_t qhead, qlen;         /**< queue read position and length */
    ef_msg_t errmsg;            /**< the sticky error's message */
} ef_gcode_t;

/**
 * @brief Start reading a program held in memory (not copied: it must outlive the reader).
 * @param r    reader to initialise.
 * @param text program text (need not be NUL-terminated).
 * @param len  bytes of text.
 * @param name name used in messages (copied; NULL gives "<gcode>").
 * @retval EF_OK      ready.
 * @retval EF_ERR_ARG r is NULL, or text is NULL with len > 0.
 */
int ef_gcode_init(ef_gcode_t *r, const char *text, size_t len, const char *name);

/**
 * @brief Load a file and start reading it; release with ef_gcode_free().
 * @param r    reader to initialise.
 * @param path file to read; its name is used in messages.
 * @param m    message on failure (may be NULL).
 * @retval EF_OK        ready.
 * @retval EF_ERR_ARG   r or path is NULL.
 * @retval EF_ERR_IO    the file cannot be read or is larger than ::EF_GCODE_FILE_MAX.
 * @retval EF_ERR_NOMEM no memory for the text.
 */
int ef_gcode_open(ef_gcode_t *r, const char *path, ef_msg_t *m);

/** @brief Release what the reader allocated: the text of ef_gcode_open() and the item
 *  queue of a long expansion (call it for every reader; safe twice). */
void ef_gcode_free(ef_gcode_t *r);

/**
 * @brief Read the next item.
 * @param r  reader.
 * @param it filled with the item on success.
 * @param m  message on failure, "name:line:col: text" (may be NULL).
 * @retval EF_OK        it holds the next item; after ::EF_GC_END every call gives END again.
 * @retval EF_ERR_ARG   r or it is NULL.
 * @retval EF_ERR_GCODE malformed or unsupported input, a runaway loop or recursion, or no
 *                      memory for a long expansion; the reader stays failed.
 */
int ef_gcode_next(ef_gcode_t *r, ef_gcode_item_t *it, ef_msg_t *m);

/**
 * @brief Clamp feeds to a machine's limit instead of ::EF_GCODE_MAX_FEED.
 * @param r    reader (before the first ef_gcode_next()).
 * @param feed largest feed (mm/min), > 0.
 * @retval EF_OK      set.
 * @retval EF_ERR_ARG r is NULL or feed is not a positive finite number.
 */
int ef_gcode_set_max_feed(ef_gcode_t *r, double feed);

/**
 * @brief Start from a machine's saved parameters: a LinuxCNC parameter file (one
 *        "NUMBER VALUE" per line; blank lines and ';' comments allowed), lengths in mm,
 *        A B C in degrees. Work offsets of all nine axes X Y Z A B C U V W (5221-5390,
 *        rotations included), G28/G30 positions (5161-5169, 5181-5189), G92 (5210-5219)
 *        and the active coordinate system (5220) take effect;
 *        other numbers are set as parameters. Call after ef_gcode_init()/ef_gcode_open()
 *        and before the first ef_gcode_next(). Nothing is applied when a line is bad.
 * @param r    reader.
 * @param path the file.
 * @param m    message on failure, "path:line: text" for a bad line (may be NULL).
 * @retval EF_OK        applied.
 * @retval EF_ERR_ARG   r or path is NULL, the program is already being read, or a line is
 *                      malformed (number not 1..5601, value not finite or beyond 1e6, #5220
 *                      not 1..9, more than two fields).
 * @retval EF_ERR_IO    the file cannot be read.
 * @retval EF_ERR_NOMEM out of memory.
 */
int ef_gcode_load_params(ef_gcode_t *r, const char *path, ef_msg_t *m);

/**
 * @brief Start with a machine's tool table: a LinuxCNC tool table file, one tool per line
 *        ("T1 P1 Z25.4 D6 ;comment"; X Y Z offsets and D diameter in mm; P, I, J, Q are
 *        accepted and not used). G43 H<n> then applies tool n's offsets. Call before the
 *        first ef_gcode_next(). Nothing is applied when a line is bad.
 * @param r    reader.
 * @param path the file.
 * @param m    message on failure, "path:line: text" for a bad line (may be NULL).
 * @retval EF_OK        applied.
 * @retval EF_ERR_ARG   r or path is NULL, the program is already being read, or a line is
 *                      malformed (an unknown word, no T, a tool listed twice, a nonzero
 *                      offset of an axis other than X Y Z, more than ::EF_GCODE_NTOOLS tools).
 * @retval EF_ERR_IO    the file cannot be read.
 * @retval EF_ERR_NOMEM out of memory.
 */
int ef_gcode_load_tools(ef_gcode_t *r, const char *path, ef_msg_t *m);

/** @brief Short name of an item kind ("rapid", "line", "arc", ...); "?" if unknown. */
const char *ef_gcode_kind_name(int kind);

#ifdef __cplusplus
}
#endif

#endif /* EF_GCODE_H */
