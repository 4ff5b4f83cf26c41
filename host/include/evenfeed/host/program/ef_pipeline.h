/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_pipeline.h
 * @brief Host pipeline: a part program through the G-code reader, the streaming smoother
 * (ef_smooth.h) and optionally the interpolator (ef_interp.h), with callbacks for moves,
 * setpoints, events and notes (docs/smoothing-cli.md).
 *
 * ## Item conversion
 * - Positions stay in millimetres (the reader's); feeds mm/min -> mm/s.
 * - G0: a LINE primitive at the rapid speed. Its corners, and the transitions between G0
 *   and G1/G2/G3, are blended within the active G64 tolerance P like any other vertex (as
 *   LinuxCNC blends rapids); in G61 (tol 0) every vertex stops, and so does the program
 *   start and every event (below). With ::ef_pipe_cfg_t::rapid_exact set, a G0 and the
 *   primitive after it get ::EF_PRIM_STOP_BEFORE (exact stops at both ends of a rapid).
 * - G1: a LINE primitive. G2/G3: an ARC primitive about +Z (G17), +Y (G18) or +X (G19)
 *   with the item's centre and signed sweep (full turns included); a helix ends at the
 *   item's end. A spiral (end radius != start radius, LinuxCNC's near-circular arcs) goes
 *   in as ef_pipe_spiral_pieces() circular arcs, each through its piece's ends and middle
 *   on the spiral (within ::EF_PIPE_SPIRAL_DEV of it).
 * - G61/G61.1: tol 0 (exact stops) from then on. G64 P Q: tol = P (P absent or 0: the
 *   configured default), qtol = Q (absent or 0: the configured default, and where that is 0,
 *   P itself, LinuxCNC's default). The smoother merges lines, straight runs and gently
 *   curving ones, whose inner points lie within min(Q, EF_SMOOTH_BAND_SHARE x P) of the
 *   merged chord (ef_smooth.h, band decimation), so a run of short collinear G1 becomes one
 *   move without a Q word. The program starts in G64 with the defaults (LinuxCNC's
 *   default mode).
 * - Events (tool change, spindle, coolant, dwell, G53 moves, work offsets, M0...):
 *   ef_smooth_finish(), every move drained (and interpolated to rest), then on_event, so
 *   moves and events keep their order. The first primitive after an event has
 *   ::EF_PRIM_STOP_BEFORE. The program end is handled the same way.
 * - A B C U V W (the item's aend): the primitive's auxiliary values for the first naux of
 *   them (ef_smooth.h, "Auxiliary axes"; a move of those alone is an auxiliary move at the
 *   item's feed in their units); an item that moves an axis beyond naux is refused with
 *   EF_ERR_ARG, "name:line: axis A moves, the machine has X Y Z only" (controlled stop).
 * - ZERO_MOVE items, IGNORED and NOTE items and lines too short for float32 (refused by the
 *   firmware as ::EF_ERR_DEGENERATE) go to on_note with "name:line:col: ..."; nothing is
 *   dropped silently.
 * - A primitive refused by ef_smooth_push() (NaN, inconsistent arc...) or a reader error:
 *   controlled stop (ef_smooth_finish(), everything accepted drained), then the error with
 *   "name:line: <ef_err_str>" (reader errors keep the reader's message).
 */
#ifndef EF_PIPELINE_H
#define EF_PIPELINE_H

#include <stdint.h>
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"
#include "evenfeed/host/program/ef_gcode.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Largest distance (mm) between a spiral arc and the circular pieces it is cut into. */
#define EF_PIPE_SPIRAL_DEV 1e-4
/** Most pieces of one spiral arc. */
#define EF_PIPE_SPIRAL_MAX 4096

/** Step-mode bits for ::ef_pipe_cfg_t::interp_modes. */
#define EF_PIPE_INTERP_UNIFORM   (1u << EF_STEP_UNIFORM)
#define EF_PIPE_INTERP_CORRECTED (1u << EF_STEP_CORRECTED)

/** Feed fluctuation counts samples whose planned speed is at least this fraction of the
 *  move's speed limit (ramps to rest are excluded: relative errors there mean nothing). */
#define EF_PIPE_FLUCT_VMIN_FRAC 0.1
/** Feed fluctuation is also reported over the samples whose planned speed is at least this
 *  share of the programmed feed (what the part sees at feed, not the ramps near rest). */
#define EF_PIPE_FLUCT_FEED_SHARE 0.5

/** What the pipeline knows about a move beyond ef_move_t (looked up by its tag). */
typedef struct {
    double tol; /**< path tolerance P (mm) in force at the move's primitive (0: exact) */
    int units;  /**< program units of the move's source line: 20 (inch) or 21 (mm) */
    int rapid;  /**< the move belongs to a G0 primitive */
} ef_pipe_move_info_t;

/** Callbacks; any may be NULL. A nonzero return value stops the run with that code. */
typedef struct {
    /** Every reader item, as read (before it is acted on). */
    int (*on_item)(void *user, const ef_gcode_item_t *it);
    /** A planned move, in emission order (positions in mm). */
    int (*on_move)(void *user, const ef_move_t *m, const ef_pipe_move_info_t *mi);
    /** A setpoint of the interpolator in cfg.step_mode, at time t (s) since the start. */
    int (*on_setpoint)(void *user, double t, const ef_setpoint_t *sp,
                       const ef_pipe_move_info_t *mi);
    /** An event item, after every move before it was emitted and run to rest. */
    int (*on_event)(void *user, const ef_gcode_item_t *it);
    /** A note: "name:line:col: text" (zero-length moves, ignored words). */
    int (*on_note)(void *user, const ef_gcode_item_t *it, const char *text);
    void *user;
} ef_pipe_cb_t;

/** Configuration (ef_pipe_cfg_default() fills every field). */
typedef struct {
    const ef_table_t *g2;     /**< G2 quintic table (required) */
    const ef_table_t *g1;     /**< G1 cubic table (required when smooth_degree == 3) */
    ef_limits_t lim;          /**< motion limits (mm/s, mm/s^2, mm/s^3) */
    double tol_default;       /**< P (mm) at program start and for G64 without P */
    double qtol_default;      /**< Q (mm) at program start and for G64 without Q (0: Q = P) */
    double micro_len;         /**< longest CAM micro-segment (mm); 0 disables smooth sections */
    double micro_turn;        /**< largest turn at a smooth vertex (rad) */
    int smooth_degree;        /**< 5 (G2 quintic) or 3 (G1 cubic) smooth sections */
    double rapid_speed;       /**< G0 path speed (mm/s), > 0 */
    int rapid_exact;          /**< nonzero: exact stops at both ends of every G0 (0: blended) */
    int keep_slow_blends;     /**< nonzero: blend every corner that fits, also where an exact
                                   stop is faster (ef_smooth_cfg_t::keep_slow_blends; 0: stop) */
    int naux;                 /**< auxiliary axes the machine has: the first naux of A B C U V
                                   W (0..EF_AUX; ef_smooth_cfg_t::naux); a program that moves
                                   another one is refused at its line (0: X Y Z only) */
    double aux_tol[EF_AUX_N]; /**< per auxiliary axis, the blends' largest deviation from it
                                   (deg for A B C, mm for U V W; ef_smooth_cfg_t::aux_tol) */
    uint32_t period_us;       /**< servo period (us), > 0 */
    int step_mode;            /**< ::ef_step_mode_t whose setpoints go to on_setpoint */
    unsigned interp_modes;    /**< EF_PIPE_INTERP_* bits: interpolators to run (0: none) */
} ef_pipe_cfg_t;

/** Feed fluctuation of one step mode, measured on consecutive setpoints (of X Y Z moves:
 *  an auxiliary move has no X Y Z speed to compare):
 *  |(|p_k - p_k-1| / period) - v_ref| / v_ref with v_ref the mean planned speed of the two. */
typedef struct {
    uint64_t setpoints;     /**< setpoints produced */
    uint64_t samples;       /**< pairs counted (both moving, v_ref >= EF_PIPE_FLUCT_VMIN_FRAC
                                 x the move's v_max) */
    double max_rel;         /**< largest relative fluctuation */
    double rms_rel;         /**< RMS relative fluctuation */
    uint32_t max_line;      /**< source line where the largest one occurred */
    uint64_t samples_feed;  /**< pairs with v_ref >= EF_PIPE_FLUCT_FEED_SHARE x the
                                 programmed feed */
    double max_rel_feed;    /**< largest relative fluctuation over those */
    uint32_t max_line_feed; /**< where */
    double max_abs;         /**< largest |measured - planned| speed over every moving pair
                                 (program units/s) */
    uint32_t underruns;     /**< EF_ERR_UNDERRUN results (should be 0) */
    double end_time;        /**< time of the last setpoint (s) */
} ef_pipe_fluct_t;

/** Counters and figures of a run. */
typedef struct {
    uint32_t items;         /**< reader items */
    uint32_t prims;         /**< primitives pushed (accepted) */
    uint32_t rapids;        /**< of those, G0 */
    uint32_t arcs;          /**< of those, arcs and helices */
    uint32_t events;        /**< event items */
    uint32_t notes;         /**< notes (zero moves, ignored words, dropped tiny lines) */
    uint32_t zero_moves;    /**< ZERO_MOVE items */
    uint32_t moves;         /**< moves emitted */
    uint32_t moves_kind[5]; /**< by ::ef_move_kind_t (index 1..4) */
    ef_smooth_stats_t sm;   /**< the smoother's counters */
    double length;          /**< X Y Z path length of the moves (mm; auxiliary moves add 0) */
    double cycle_time;      /**< sum of the moves' durations (s) */
    double rapid_time;      /**< of which rapids (s) */
    double dev_max;         /**< largest move deviation (mm) */
    double dev_max_tol;     /**< the tolerance in force at that move (mm) */
    uint32_t dev_max_line;  /**< its source line */
    uint32_t dev_over;      /**< moves whose deviation exceeds their tolerance (+1e-6 mm) */
    double tol_max;         /**< largest tolerance in force at any primitive (mm) */
    int units;              /**< program units at the first path item (20 or 21) */
    double start[3];        /**< program start (mm) */
    double end[3];          /**< where the last move ends (mm) */
    ef_pipe_fluct_t fl[2];  /**< per ::ef_step_mode_t, when interpolated */
} ef_pipe_stats_t;

/** Defaults: no auxiliary axis (naux 0), with limits set for all of them should a caller
 *  raise naux: A B C 90 deg/s, 900 deg/s^2, U V W as X Y Z, jerk j_max, aux_tol 0.02 (deg or
 *  mm).
 *  P 0.02 mm, Q 0 (Q = P), 100 mm/s and 1000 mm/s^2 per axis, jerk 20000 mm/s^3,
 *  a_normal_frac 0.5, micro_len 1 mm, micro_turn 0.35 rad, quintic smooth sections, rapid
 *  100 mm/s blended (rapid_exact 0), period 1000 us, corrected stepping, no interpolation; tables
 * NULL. */
void ef_pipe_cfg_default(ef_pipe_cfg_t *cfg);

/**
 * @brief Run a program already opened in a reader to its end (or first error).
 * @param r     reader (ef_gcode_init() or ef_gcode_open())
 * @param cfg   configuration
 * @param cb    callbacks (may be NULL)
 * @param st    statistics (may be NULL), filled also on error
 * @param m     message on failure (may be NULL)
 * @retval EF_OK
 * @retval EF_ERR_ARG    NULL r or cfg, invalid configuration (message says which field)
 * @retval EF_ERR_NOMEM  no memory for the smoother state
 * @retval EF_ERR_GCODE  the reader's error (after a controlled stop)
 * @retval EF_ERR_NONFINITE, EF_ERR_FEED, EF_ERR_DEGENERATE, EF_ERR_ARC  a primitive the
 *                       smoother refused, "name:line: <ef_err_str>" (after a controlled stop)
 * @retval other         as ef_smooth_init() / ef_interp_init(), or a callback's code
 */
int ef_pipe_run(ef_gcode_t *r, const ef_pipe_cfg_t *cfg, const ef_pipe_cb_t *cb,
                ef_pipe_stats_t *st, ef_msg_t *m);

/**
 * @brief Number of circular pieces a spiral arc is cut into.
 * @param sweep the arc's sweep (rad, signed).
 * @param dr    end radius minus start radius (mm).
 * @return 1 .. ::EF_PIPE_SPIRAL_MAX: pieces of at most 45 degrees, within
 *         ::EF_PIPE_SPIRAL_DEV of the spiral.
 */
int ef_pipe_spiral_pieces(double sweep, double dr);

/**
 * @brief Piece k of n of a spiral arc item, as a circular arc item.
 * @param it  an ::EF_GC_ARC item (radius_end may differ from radius).
 * @param k   piece, 0 .. n-1; the first starts at it->start, the last ends at it->end.
 * @param n   pieces (ef_pipe_spiral_pieces()).
 * @param out the piece: the circle through its ends and middle on the spiral.
 * @retval EF_OK             out filled.
 * @retval EF_ERR_ARG        NULL, not an arc, or k / n out of range.
 * @retval EF_ERR_DEGENERATE the three points are collinear (a piece too short).
 */
int ef_pipe_spiral_piece(const ef_gcode_item_t *it, int k, int n, ef_gcode_item_t *out);

/**
 * @brief Convert one path item (RAPID, LINE, ARC) to a primitive; flags, tol, qtol and tag
 * are left 0 for the caller.
 * @param it          reader item
 * @param rapid_speed G0 speed (mm/s)
 * @param pr          out
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer, not a path item, or unknown plane
 */
int ef_pipe_item_prim(const ef_gcode_item_t *it, double rapid_speed, ef_prim_t *pr);

/** @brief Name of a move kind: "line", "arc", "blend", "smooth" or "?". */
const char *ef_pipe_move_kind_name(int kind);

#ifdef __cplusplus
}
#endif

#endif /* EF_PIPELINE_H */
