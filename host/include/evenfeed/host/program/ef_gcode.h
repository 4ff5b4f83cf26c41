/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_gcode.h
 * @brief Streaming reader for the RS274NGC subset that CAM post-processors emit.
 *
 * The reader turns a part program into a stream of items, one per ef_gcode_next() call:
 * path primitives (rapid, line, arc), pass-through events (tool change, spindle, coolant,
 * dwell, work offset...), notes about words that are accepted but ignored (each reported
 * once), tolerance changes (G61, G64 P Q) and a final end item. docs/gcode.md lists the
 * subset; the rules that matter to callers:
 *
 * - Positions are in millimetres in program coordinates; G20 input is converted (x 25.4)
 *   and every item records the units the program was in (::ef_gcode_item_t::units) so
 *   output can be given back in them. Feeds are in mm/min (G94 only).
 * - The program starts at the origin (0, 0, 0) with G21 G90 G91.1 G17, no motion mode and
 *   no feed: axis words before the first G0/G1/G2/G3 are an error, as is a feed move
 *   before the first positive F.
 * - A G0/G1 whose end equals its start (within ::EF_GCODE_ZERO_LEN) is reported as a
 *   ::EF_GC_ZERO_MOVE item, never dropped silently. An IJK arc whose end equals its start
 *   is a full circle (times the P word, default 1).
 * - Arc radius rule (LinuxCNC's): the end radius may differ from the start radius by at
 *   most max(::EF_GCODE_ARC_ABS_TOL, ::EF_GCODE_ARC_REL_TOL x start radius); beyond that the
 *   arc is an error. Within it the arc is emitted as given (centre, start, end).
 * - Errors are ::EF_ERR_GCODE with the message "name:line:col: text" (1-based, col counts
 *   bytes); after an error, every further call returns the same error.
 */
#ifndef EF_GCODE_H
#define EF_GCODE_H

#include <stddef.h>
#include <stdint.h>
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Moves not longer than this (mm) are ::EF_GC_ZERO_MOVE items. */
#define EF_GCODE_ZERO_LEN 1e-9
/** Largest accepted coordinate magnitude (mm), for positions, centres and radii. */
#define EF_GCODE_MAX_COORD 1e6
/** Largest accepted feed (mm/min). */
#define EF_GCODE_MAX_FEED 1e7
/** Arc radius consistency: absolute part of the tolerance (mm). */
#define EF_GCODE_ARC_ABS_TOL 0.002
/** Arc radius consistency: relative part of the tolerance (fraction of the start radius). */
#define EF_GCODE_ARC_REL_TOL 0.001
/** Numbered parameters are #1 .. #EF_GCODE_NPARAM-1. */
#define EF_GCODE_NPARAM 5400
/** Named parameters (#<name>) a program may define. */
#define EF_GCODE_NNAMED 64
/** Longest named-parameter name (characters, spaces removed). */
#define EF_GCODE_NAME_MAX 31
/** Longest accepted source line (bytes). */
#define EF_GCODE_LINE_MAX 4096
/** Largest file ef_gcode_open() loads (bytes). */
#define EF_GCODE_FILE_MAX ((size_t)256 << 20)

/** Item kinds. */
typedef enum {
    EF_GC_RAPID = 1,     /**< G0 straight rapid: start, end */
    EF_GC_LINE = 2,      /**< G1 straight feed move: start, end, feed */
    EF_GC_ARC = 3,       /**< G2/G3 arc or helix: start, end, centre, dir, plane, turns, feed */
    EF_GC_ZERO_MOVE = 4, /**< G0/G1 whose end equals its start: position unchanged */
    EF_GC_EVENT = 5,     /**< words that do not move the path, as text (e.g. "T1 M6") */
    EF_GC_IGNORED = 6,   /**< a word accepted and ignored, reported on its first use */
    EF_GC_TOLERANCE = 7, /**< path control change: G61 / G61.1 (exact) or G64 P Q */
    EF_GC_END = 8,       /**< M2, M30, closing % or end of text; repeated on later calls */
} ef_gcode_kind_t;

/** Path control modes of an ::EF_GC_TOLERANCE item. */
typedef enum {
    EF_GC_PATH_EXACT = 1, /**< G61 / G61.1: stop exactly at every vertex */
    EF_GC_PATH_BLEND = 2, /**< G64: blend within p_tol (0: no tolerance given) */
} ef_gcode_path_t;

/** One item of the stream. Fields not used by a kind are zero. */
typedef struct {
    int kind;         /**< ::ef_gcode_kind_t */
    uint32_t line;    /**< 1-based source line */
    uint32_t col;     /**< 1-based column (bytes) of the word that produced the item */
    int units;        /**< program units when the item was read: 20 (inch) or 21 (mm) */
    double start[3];  /**< X Y Z at the start (mm); also set for ZERO_MOVE */
    double end[3];    /**< X Y Z at the end (mm) */
    double centre[3]; /**< arc centre (mm); its normal-axis coordinate is the start's */
    double radius;    /**< arc radius at the start (mm) */
    double sweep;     /**< arc angle (rad) about the plane normal: > 0 for G3, < 0 for G2,
                           full turns included */
    double feed;      /**< LINE/ARC: feed in mm/min (> 0) */
    int dir;          /**< arc direction: +1 G3 (counter-clockwise), -1 G2 (clockwise) */
    int plane;        /**< arc plane: 17 (XY, normal +Z), 18 (ZX, normal +Y), 19 (YZ, +X) */
    int turns;        /**< arc: P word, number of times the end angle is passed (>= 1) */
    int path_mode;    /**< TOLERANCE: ::ef_gcode_path_t */
    double p_tol;     /**< TOLERANCE: G64 P, path tolerance (mm), 0 when not given */
    double q_tol;     /**< TOLERANCE: G64 Q, collinearity tolerance (mm), 0 when not given */
    char text[128];   /**< EVENT/IGNORED: the words ("T1 M6", "G40"); END: what ended it
                           ("M2", "M30", "%", "end of text") */
} ef_gcode_item_t;

/** Reader state. Treat as opaque; the fields are here so it can live on the stack. */
typedef struct {
    const char *text;              /**< program text (not owned unless buf is set) */
    size_t len;                    /**< bytes of text */
    size_t pos;                    /**< offset of the next unread line */
    char *buf;                     /**< owned copy from ef_gcode_open(), or NULL */
    char name[128];                /**< program name for messages */
    uint32_t line;                 /**< number of the last line read */
    int err;                       /**< sticky error code (0 while healthy) */
    int ended;                     /**< an end item has been produced */
    int percent;                   /**< the text opened with a % line */
    int line_seen;                 /**< a line with words has been read */
    int units;                     /**< 20 or 21 */
    int absolute;                  /**< G90 (1) or G91 (0) */
    int arc_absolute;              /**< G90.1 (1) or G91.1 (0) */
    int plane;                     /**< 17, 18 or 19 */
    int motion;                    /**< modal motion: 0 none, 1 G0, 2 G1, 3 G2, 4 G3 */
    double feed;                   /**< mm/min, 0 until an F word */
    double cur[3];                 /**< current position (mm) */
    uint32_t ignored_seen;         /**< bit set of ignored words already reported */
    double param[EF_GCODE_NPARAM]; /**< numbered parameters */
    char named_key[EF_GCODE_NNAMED][EF_GCODE_NAME_MAX + 1]; /**< named parameter names */
    double named_val[EF_GCODE_NNAMED];                      /**< named parameter values */
    int nnamed;                                             /**< named parameters defined */
    ef_gcode_item_t queue[16];                              /**< items of the current line */
    ef_gcode_item_t end_item; /**< the end item, repeated once ended */
    int qhead, qlen;          /**< queue read position and length */
    ef_msg_t errmsg;          /**< the sticky error's message */
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

/** @brief Release what ef_gcode_open() allocated (safe on an ef_gcode_init() reader). */
void ef_gcode_free(ef_gcode_t *r);

/**
 * @brief Read the next item.
 * @param r  reader.
 * @param it filled with the item on success.
 * @param m  message on failure, "name:line:col: text" (may be NULL).
 * @retval EF_OK        it holds the next item; after ::EF_GC_END every call gives END again.
 * @retval EF_ERR_ARG   r or it is NULL.
 * @retval EF_ERR_GCODE malformed or unsupported input; the reader stays failed.
 */
int ef_gcode_next(ef_gcode_t *r, ef_gcode_item_t *it, ef_msg_t *m);

/** @brief Short name of an item kind ("rapid", "line", "arc", ...); "?" if unknown. */
const char *ef_gcode_kind_name(int kind);

#ifdef __cplusplus
}
#endif

#endif /* EF_GCODE_H */
