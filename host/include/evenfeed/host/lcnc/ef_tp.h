/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_tp.h
 * @brief A trajectory planner in the shape LinuxCNC's motion module calls one (its TPMOD
 * interface, docs/linuxcnc-tpmod-interface.md), built on evenfeed's firmware runtime: the
 * streaming smoother (ef_smooth.h) and the interpolator (ef_interp.h).
 *
 * This is the planner's core, free of LinuxCNC's headers (Apache-2.0). The module that
 * LinuxCNC loads (host/linuxcnc/, GPL-2.0-or-later because it includes them) only converts
 * LinuxCNC's types and calls these functions; the host test suite runs the same core under
 * ASan/UBSan on recorded motmod call traces (tests/lcnc/).
 *
 * ## Threading and cost
 * Every function runs in motmod's servo thread (LinuxCNC calls the planner from its
 * command handler and its controller, never concurrently). Nothing blocks or allocates;
 * the state is one static-size struct. ef_tp_cycle() does at most
 * ef_tp_cfg_t::units_per_cycle smoother work units (each bounded, firmware/README.md),
 * moves what the planner released to the interpolator and evaluates one setpoint.
 *
 * ## Pipeline
 * Added lines and arcs queue as smoother primitives (::EF_TP_QUEUE, LinuxCNC's queue depth
 * and back-pressure: ef_tp_full()). Each cycle the work units push them through the
 * smoother; planned moves wait in a FIFO (::EF_TP_MOVES) for the interpolator. The
 * smoother holds moves back for look-ahead; LinuxCNC does not say where a program ends and
 * feeds about one move per servo period, so the core decides when to let moves go:
 *
 *   | state    | when                                         | then                       |
 *   |----------|----------------------------------------------|----------------------------|
 *   | IDLE     | nothing queued, at rest                      | a move added: FILLING      |
 *   | FILLING  | at rest, moves arriving                      | EF_TP_START_MOVES queued,  |
 *   |          |                                              | or no add for start_wait_s:|
 *   |          |                                              | RUNNING                    |
 *   | RUNNING  | released time ahead of the setpoint below    | early release              |
 *   |          | guard_s: the planner's oldest move goes now  | (ef_smooth_pull_now());    |
 *   |          | (less look-ahead, never unsafe); nothing left| nothing to release, no     |
 *   |          | in the planner and no input: finish (the     | input: finish; all done:   |
 *   |          | machine is coming to rest anyway)            | IDLE                       |
 *   | STOPPING | abort: rate ramped to 0, then the queue and  | at rest: IDLE at the       |
 *   |          | everything planned are dropped               | position reached           |
 *
 * ## Feed override, adaptive feed, pause
 * Moves are planned at min(vel x max_feed_scale, ini_maxvel) and run at a time rate
 * r = scale / max_feed_scale (scale: motion's net feed scale, which folds in feed override,
 * adaptive feed, feed hold and inhibit; 0 while paused or stopping). A time rate keeps the
 * path exactly; it scales speed by r, the plan's acceleration by r^2 and jerk by r^3 and
 * adds v r' (acceleration) and 3 r r' a + v r'' (jerk). r follows its target with r' and
 * r'' bounded by what the limits leave at the current r (the planner plans to
 * ef_tp_cfg_t::plan_share of them), so a change of override, a pause or an abort, also
 * mid-blend, stays within every axis's acceleration and jerk limit.
 *
 * ## Axes
 * X Y Z are planned through the smoother. A move of A B C U V W alone (X Y Z still: an
 * indexing turn of a rotary table) is planned on those axes: everything before it comes to
 * rest, then a jerk-limited profile (ef_plan_timelaw()) along the straight line in their
 * space at LinuxCNC's speed and acceleration for the move, jerk 20/s x that acceleration,
 * under the same time rate (override, pause, abort); the next move starts at rest. A move
 * that changes X Y Z and one of A B C U V W together is refused (::EF_ERR_ARG, "moving X Y
 * Z together with A B C U V W is not supported"): LinuxCNC reports it and stops.
 */
#ifndef EF_TP_H
#define EF_TP_H

#include <stdint.h>
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Primitives queued or executing (LinuxCNC's planner queue). */
#ifndef EF_TP_QUEUE
#define EF_TP_QUEUE 1024
#endif
/** ef_tp_full() reports full with this many places still free: motmod may have a few
 *  commands in flight when task sees the flag. */
#ifndef EF_TP_QUEUE_MARGIN
#define EF_TP_QUEUE_MARGIN 32
#endif
/** Planned moves waiting for the interpolator. */
#ifndef EF_TP_MOVES
#define EF_TP_MOVES 128
#endif
/** From rest, motion starts once this many primitives are queued (or input pauses). */
#ifndef EF_TP_START_MOVES
#define EF_TP_START_MOVES 48
#endif
/** Synchronized digital outputs (M62/M63: index < 64) and analog outputs (M67: < 16). */
#define EF_TP_DIOS 64
#define EF_TP_AIOS 16
/** Pose axes: X Y Z A B C U V W (LinuxCNC's EmcPose). */
#define EF_TP_AXES 9

/** LinuxCNC's termination conditions (tpSetTermCond). */
typedef enum {
    EF_TP_TERM_STOP = 0,    /**< G61: exact stop */
    EF_TP_TERM_EXACT = 1,   /**< G61.1: exact path (evenfeed stops exactly too) */
    EF_TP_TERM_BLEND = 2,   /**< G64 [P]: blend within P */
    EF_TP_TERM_TANGENT = 3, /**< tangent continuation (blended within P) */
} ef_tp_term_t;

/** LinuxCNC's motion types (canon): reported back for the executing move. */
typedef enum {
    EF_TP_MOTION_TRAVERSE = 1,
    EF_TP_MOTION_FEED = 2,
    EF_TP_MOTION_ARC = 3,
    EF_TP_MOTION_TOOLCHANGE = 4,
    EF_TP_MOTION_PROBING = 5,
    EF_TP_MOTION_INDEXROTARY = 6,
} ef_tp_motion_t;

/** Planner states (table in the file comment). */
typedef enum {
    EF_TP_IDLE = 0,
    EF_TP_FILLING = 1,
    EF_TP_RUNNING = 2,
    EF_TP_STOPPING = 3,
} ef_tp_state_t;

/** Output writes the planner makes when a move starts (M62-M65, M67/M68 synchronized).
 *  Both optional (NULL: not written); called from ef_tp_cycle(), in the servo thread. */
typedef struct {
    void (*dio_write)(void *user, int index, int value);
    void (*aio_write)(void *user, int index, double value);
    void *user;
} ef_tp_ops_t;

/** Configuration (ef_tp_cfg_default() fills every field). Units: LinuxCNC's machine units
 *  (mm or inch) and seconds. */
typedef struct {
    const ef_table_t *g2;         /**< G2 quintic table (required) */
    double v_axis[3];             /**< X Y Z speed limits (units/s), > 0 */
    double a_axis[3];             /**< X Y Z acceleration limits (units/s^2), > 0 */
    double v_aux[EF_TP_AXES - 3]; /**< A B C U V W speed limits (deg/s or units/s), > 0 */
    double a_aux[EF_TP_AXES - 3]; /**< A B C U V W acceleration limits, > 0 */
    double aux_tol;               /**< largest deviation of a blend from A B C U V W (deg or
                                       units, ef_smooth_cfg_t::aux_tol), > 0 */
    double j_max;                 /**< jerk limit of every axis (units/s^3), > 0 */
    double plan_share;            /**< share of acceleration and jerk the planner plans to, in
                                       (0, 1]; the rest is for override changes at full speed */
    double tol_default;           /**< P for G64 without P (LinuxCNC: 0 = no limit), > 0 */
    double period_s;              /**< servo period (tpSetCycleTime), > 0 */
    double max_feed_scale;        /**< largest net feed scale ([DISPLAY]MAX_FEED_OVERRIDE), >= 1 */
    double start_wait_s;          /**< FILLING: start after this long without an add */
    double guard_s;               /**< RUNNING: released move time kept ahead of the setpoint */
    uint32_t units_per_cycle;     /**< smoother work units per cycle, >= 1 */
    double micro_len;             /**< longest line taken as a CAM micro-segment (units): the
                                       smoother's micro_len; LinuxCNC's canon has already merged
                                       runs within G64 Q (= P without Q), so its lines are
                                       chords as long as sqrt(8 R Q) on a curve of radius R
                                       (2 mm at R 10, Q 0.05), longer than a CAM post's; the
                                       smooth-vertex gate and the measured deviation keep P.
                                       Default 3: 10 made the benchmark's sine 12 % faster
                                       than 2 and its 3-D relief 3 % slower (sections
                                       spread over long chords), 3 gets the first and loses
                                       1 % */
} ef_tp_cfg_t;

/** One queued primitive and what LinuxCNC said about it. */
typedef struct {
    ef_prim_t pr;                  /**< the primitive (pr.tag = seq) */
    uint32_t seq;                  /**< queue sequence number, from 1 */
    int32_t id;                    /**< LinuxCNC's id (tpSetId: the program line) */
    uint8_t motion_type;           /**< ::ef_tp_motion_t */
    uint8_t enables;               /**< motion's enables at queue time (FS/SS/AF/FH bits) */
    uint8_t fired;                 /**< its outputs were written */
    uint8_t atspeed;               /**< starts at rest, once the spindle is at speed */
    uint8_t aux;                   /**< a move of A B C U V W alone (X Y Z still): not a smoother
                                        primitive, run on those axes between rests */
    double aux_to[EF_TP_AXES - 3]; /**< aux: where A B C U V W go */
    double aux_v, aux_a;           /**< aux: speed and acceleration along the move */
    uint64_t dio_mask;             /**< synchronized digital outputs to write when it starts */
    uint64_t dio_val;
    uint16_t aio_mask; /**< synchronized analog outputs likewise */
    double aio[EF_TP_AIOS];
} ef_tp_item_t;

/** What one cycle produced (LinuxCNC's status fields). */
typedef struct {
    double pos[EF_TP_AXES]; /**< commanded pose */
    double v;               /**< path speed now (units/s) */
    double v_req;           /**< the executing move's planned speed limit (units/s) */
    double dtg;             /**< distance to go on the executing move (units) */
    double rate;            /**< the time rate applied (0..1) */
    int32_t exec_id;        /**< id of the executing move (0 when none) */
    uint32_t exec_seq;      /**< its queue sequence number (0 when none) */
    int motion_type;        /**< its ::ef_tp_motion_t (0 when none) */
    int enables;            /**< its enables (the ones queued last when idle) */
    int done;               /**< nothing queued and at rest */
    int moving;             /**< a move is executing */
    int underrun;           /**< the interpolator ran dry while moving (never expected) */
} ef_tp_status_t;

/** Counters for tests and summaries. */
typedef struct {
    uint32_t added;     /**< primitives queued */
    uint32_t zero;      /**< zero-length moves (not planned) */
    uint32_t refused;   /**< adds refused */
    uint32_t finishes;  /**< finishes (the planner brought to rest) */
    uint32_t early;     /**< moves released early */
    uint32_t moves;     /**< moves interpolated */
    uint32_t aborts;    /**< aborts completed */
    uint32_t underruns; /**< interpolator underruns (should stay 0) */
    uint32_t max_units; /**< most work units in one cycle */
    uint32_t stalls;    /**< cycles whose work budget ran out with work left */
    uint32_t blends;    /**< the smoother's vertex counters (ef_smooth_stats_t), summed */
    uint32_t smooth;    /**<   over every stretch between rests (it restarts at each) */
    uint32_t merged;
    uint32_t stops;
    uint32_t slow_corners; /**< of the stops, corners where stopping was faster */
    uint32_t aux_stops;    /**< of the stops, where A B C U V W changed rate unblended */
    float aux_dev_max;     /**< largest deviation of a blend from A B C U V W */
} ef_tp_stats_t;

/** Planner state (static allocation; treat as private). */
typedef struct {
    ef_tp_cfg_t cfg;
    ef_tp_ops_t ops;
    ef_smooth_cfg_t scfg;
    ef_smooth_t sm;
    ef_interp_t ip;
    ef_tp_item_t q[EF_TP_QUEUE]; /**< items, oldest (executing or next) at qh */
    uint32_t qh, qn;             /**< ring: head, count */
    uint32_t qp;                 /**< items at the head already pushed to the smoother */
    uint32_t next_seq;
    ef_move_t mv[EF_TP_MOVES]; /**< planned moves for the interpolator */
    uint32_t mh, mn;
    double t_fifo;   /**< seconds of motion in mv */
    double t_interp; /**< seconds of motion queued in the interpolator (rate 1) */
    int state;       /**< ::ef_tp_state_t */
    int finishing;   /**< a finish is under way */
    int paused;
    int aborting;
    double quiet_s;          /**< time since the last add */
    double goal[EF_TP_AXES]; /**< end of the last queued move (where the next starts) */
    double pos[EF_TP_AXES];  /**< commanded pose */
    double rate, rate_d;     /**< time rate and its derivative (1/s) */
    double v_plan, a_plan;   /**< planned path speed now (rate 1) */
    uint32_t period_us;
    /* what the next add gets */
    int term;
    double tol;
    double vlimit;   /**< path speed cap of X Y Z moves (0: none) */
    double next_tol; /**< tolerance at the end of the move being added */
    double prev_tol; /**< at the end of the last queued move: the next one's start */
    int prev_probe;  /**< the last queued move was a probe: the next starts at rest */
    int32_t next_id;
    uint64_t dio_mask, dio_val;
    uint16_t aio_mask;
    double aio[EF_TP_AIOS];
    int last_enables;
    int at_speed;    /**< the spindle is at speed (ef_tp_set_at_speed()) */
    int aux_on;      /**< an A B C U V W move is executing */
    ef_move_t aux_m; /**< its time law (degree 1, its length along the aux axes) */
    double aux_t;    /**< time into it (s, at rate 1) */
    double aux_from[EF_TP_AXES - 3];
    float aux_f[EF_TP_AXES - 3]; /**< A B C U V W of the last primitive queued for the
                                      smoother (float32, as it compares them) */
    uint32_t exec_seq;           /**< sequence number executing (0: none yet) */
    int error;                   /**< the smoother failed: refuses adds until ef_tp_clear() */
    char msg[160];               /**< the last refusal's reason */
    ef_tp_stats_t st;
} ef_tp_t;

/** @brief Defaults: limits 100 units/s, 1000 units/s^2, 20 000 units/s^3, P 0.02, 1 ms. */
void ef_tp_cfg_default(ef_tp_cfg_t *cfg);

/**
 * @brief Initialise at rest at the origin (ef_tp_set_pos() moves it).
 * @param ops output callbacks (NULL: none)
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL tp or cfg, or a setting outside its range (tp->msg says which)
 * @retval EF_ERR_KIND, EF_ERR_NONFINITE, EF_ERR_FEED  as ef_smooth_init()
 */
int ef_tp_init(ef_tp_t *tp, const ef_tp_cfg_t *cfg, const ef_tp_ops_t *ops);

/**
 * @brief New limits or period: taken now when idle, else at the next rest. The same
 * checks as ef_tp_init().
 * @retval EF_OK
 * @retval EF_ERR_ARG a NULL argument or a setting outside its range (nothing changed)
 */
int ef_tp_configure(ef_tp_t *tp, const ef_tp_cfg_t *cfg);

/**
 * @brief Set the commanded pose (tpSetPos): allowed only when done (nothing queued, at rest).
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL
 * @retval EF_ERR_NONFINITE a non-finite coordinate or one beyond EF_MAX_COORD
 * @retval EF_ERR_STATE     moves are queued or executing (nothing changed)
 */
int ef_tp_set_pos(ef_tp_t *tp, const double pos[EF_TP_AXES]);

/**
 * @brief Termination condition for the moves added next (tpSetTermCond).
 * @retval EF_OK
 * @retval EF_ERR_ARG unknown condition, or a negative / non-finite tolerance
 */
int ef_tp_set_term(ef_tp_t *tp, int cond, double tol);

/**
 * @brief Path speed cap of X Y Z moves added next (tpSetVlimit: [TRAJ]MAX_LINEAR_VELOCITY),
 * units/s; 0 or less: none. Moves of A B C U V W alone are not capped (as LinuxCNC).
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL, or not finite
 */
int ef_tp_set_vlimit(ef_tp_t *tp, double vlimit);

/** @brief Id of the moves added next (tpSetId; LinuxCNC's line number). */
void ef_tp_set_id(ef_tp_t *tp, int32_t id);

/**
 * @brief A synchronized digital or analog output, written when the next added move starts.
 * @retval EF_OK
 * @retval EF_ERR_ARG index out of range, or a non-finite analog value
 */
int ef_tp_set_dout(ef_tp_t *tp, int index, int value);
int ef_tp_set_aout(ef_tp_t *tp, int index, double value);

/**
 * @brief Queue a straight move to `end` (tpAddLine).
 * @param vel        requested speed (units/s)
 * @param ini_maxvel the axes' speed limit along the move (units/s): caps vel x max scale
 * @param acc        the axes' acceleration limit along the move (units/s^2): used for
 *                   moves of A B C U V W alone (X Y Z moves use the axes' own limits)
 * @param enables    motion's enables (reported back while it executes)
 * @param atspeed    nonzero: the move starts at rest, and only once ef_tp_set_at_speed()
 *                   says the spindle is at speed (M3 with a wait)
 * @retval EF_OK
 * @retval EF_ERR_DEGENERATE a zero-length move (shorter than the firmware resolves): not
 *                           planned, LinuxCNC's "zero length" notice; its outputs move on
 * @retval EF_ERR_ARG        NULL, X Y Z moved together with A B C U V W, an unknown motion
 *                           type, or the planner is stopping or failed (tp->msg says which)
 * @retval EF_ERR_NONFINITE  a non-finite end, speed, or a coordinate beyond EF_MAX_COORD
 * @retval EF_ERR_FEED       vel and ini_maxvel not > 0 (acc too, for an A B C U V W move)
 * @retval EF_ERR_FULL       the queue is full (ef_tp_full() was ignored)
 */
int ef_tp_add_line(ef_tp_t *tp, const double end[EF_TP_AXES], int motion_type, double vel,
                   double ini_maxvel, double acc, int enables, int atspeed);

/**
 * @brief Queue a circular arc or helix (tpAddCircle): about `normal` through `centre`,
 * `turn` as LinuxCNC's canon gives it (>= 0: counter-clockwise about normal with turn
 * extra full turns; < 0: clockwise with -turn - 1 extra turns); the end's component along
 * normal rises linearly (helix).
 * @retval EF_OK
 * @retval EF_ERR_ARC        radius at the end differs from the start's, normal zero
 * @retval EF_ERR_DEGENERATE radius below the firmware's resolution (the move is refused:
 *                           a zero-radius arc is not a zero-length move)
 * @retval EF_ERR_ARG, EF_ERR_NONFINITE, EF_ERR_FEED, EF_ERR_FULL as ef_tp_add_line()
 */
int ef_tp_add_arc(ef_tp_t *tp, const double end[EF_TP_AXES], const double centre[3],
                  const double normal[3], int turn, int motion_type, double vel, double ini_maxvel,
                  int enables, int atspeed);

/** @brief Whether the spindle is at speed now (moves queued with atspeed wait for it). */
void ef_tp_set_at_speed(ef_tp_t *tp, int at_speed);

/** @brief Feed hold on the path (tpPause): the rate ramps to 0. */
void ef_tp_pause(ef_tp_t *tp);
/** @brief Resume after ef_tp_pause() (tpResume). */
void ef_tp_resume(ef_tp_t *tp);
/** @brief Controlled stop on the path, then everything queued dropped (tpAbort). */
void ef_tp_abort(ef_tp_t *tp);
/** @brief Drop everything now, at the pose reached (tpClear: motion disabled). */
void ef_tp_clear(ef_tp_t *tp);

/**
 * @brief One servo period: work units, moves to the interpolator, one setpoint.
 * @param scale net feed scale (0 .. max_feed_scale; NaN and negatives are 0)
 * @param st    out: the status (may be NULL)
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL tp
 * @retval EF_ERR_UNDERRUN  the interpolator ran dry while moving (held in place; counted)
 * @retval EF_ERR_FEED, EF_ERR_NONFINITE  the smoother refused its own move (not expected):
 *                          the planner stops at the pose reached and refuses adds until
 *                          ef_tp_clear()
 */
int ef_tp_cycle(ef_tp_t *tp, double scale, ef_tp_status_t *st);

/** @brief Whether LinuxCNC should stop sending moves (tcqFull). 1 for NULL. */
int ef_tp_full(const ef_tp_t *tp);
/** @brief Primitives queued or executing (tpQueueDepth). */
uint32_t ef_tp_depth(const ef_tp_t *tp);
/** @brief The reason for the last refusal or failure ("" when none). */
const char *ef_tp_msg(const ef_tp_t *tp);
/** @brief The item with queue sequence number seq, NULL when it has left the queue. */
const ef_tp_item_t *ef_tp_item(const ef_tp_t *tp, uint32_t seq);
/** @brief Ring slot of seq (0 .. EF_TP_QUEUE - 1), for per-item data kept by the caller. */
static inline uint32_t ef_tp_slot(uint32_t seq)
{
    return seq % EF_TP_QUEUE;
}

#ifdef __cplusplus
}
#endif

#endif /* EF_TP_H */
