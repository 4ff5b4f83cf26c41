/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_interp.h
 * @brief The interpolator: turns planned moves into per-axis setpoints at the servo period.
 *
 * Non-blocking, for a periodic task: ef_interp_process(ip, dt_us, &next_us, &sp) advances
 * time by dt_us (the time since the previous call; the counter may wrap, only differences
 * are used), writes the setpoint for now and says when it wants to be called again.
 *
 * Two ways to step the curve parameter (docs/smoothing.md, "Feed fluctuation"):
 * - ::EF_STEP_UNIFORM: tau = s(t) / L from the time law. evenfeed's curves have
 *   near-constant parametric speed, so this alone gives near-constant feed; the residual
 *   fluctuation is the curve's own speed variation.
 * - ::EF_STEP_CORRECTED: one correction step per sample: with S the arc length reached so
 *   far (each step's chord c plus its curvature deficit, c (kappa c)^2 / 24) and
 *   g = s(t) - S, tau_next = tau + h where h solves |f'| h + k h^2 / 2 = g,
 *   k = <f', f''> / |f'| (the rate |f'| changes at tau), then h is scaled once by g / arc
 *   (a secant step on the arc actually covered). It removes most of the residual at the
 *   cost of a second-derivative evaluation and two position evaluations, also where |f'| is
 *   a small share of L and changes fast (a blend whose end speed x1 sits at the table's
 *   lower bound), so the feed stays continuous across junctions and S ends each move at
 *   its length. A step is at most the larger of 1/64 of the curve and 16 times the law's
 *   step; a deficit larger than the larger of 1/64 of the curve and four law steps (a late
 *   call, a move entered part-way through) resynchronises: three Newton steps on the arc
 *   length, measured by quadrature, find where the arc length is s(t).
 *
 * A move starts where the previous one ended (checked at push). When the queue runs dry
 * while the last move ended moving (v_exit > 0), the setpoint holds the end position and
 * the call returns ::EF_ERR_UNDERRUN (the caller must treat it as a fault: the position
 * never jumps, but the speed does). When it runs dry at rest, the interpolator is idle.
 */
#ifndef EF_INTERP_H
#define EF_INTERP_H

#include <stdint.h>
#include "evenfeed/path/ef_path.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Moves the interpolator queues ahead of the one it executes. */
#ifndef EF_INTERP_QUEUE
#define EF_INTERP_QUEUE 8
#endif

/** Largest distance (units) between a move's start and the previous move's end. */
#ifndef EF_INTERP_JOIN_TOL
#define EF_INTERP_JOIN_TOL 1e-3f
#endif

/** Longest curve (units) the corrected mode steps by arc length; a longer one is stepped
 *  uniformly. float32 holds the parameter to 2^-24 of the curve: at 16 m that is 1 um, the
 *  step of 1 mm/s at 1 ms, and the chords the corrected step sums then drift from the law
 *  (a fuzzed 199 m quintic at 50 mm/s fell 20 mm behind, and its resynchronisation jumped
 *  3 m in one period; a fuzzed 7.9 m arc piece at 3.9 mm/s, 800 m from the origin, jumped
 *  117 mm, hence 4 m, 0.24 um of parameter resolution). Uniform stepping evaluates the law's
 *  parameter directly, continuous at any length (and curves' end speeds equal their
 *  length, ef_seg_g2_even()). */
#ifndef EF_INTERP_CORRECTED_MAX_LEN
#define EF_INTERP_CORRECTED_MAX_LEN 4000.0f
#endif

/** Parameter stepping modes. */
typedef enum {
    EF_STEP_UNIFORM = 0,   /**< tau straight from the time law */
    EF_STEP_CORRECTED = 1, /**< plus one arc-length correction step per sample (curves up
                                to EF_INTERP_CORRECTED_MAX_LEN long) */
} ef_step_mode_t;

/** One setpoint. */
typedef struct {
    ef_vec3_t p;         /**< commanded position */
    float v_plan;        /**< planned path speed now (units/s), the law's (at rate 1) */
    uint32_t seq;        /**< sequence number of the move being executed (last one when idle) */
    uint32_t tag;        /**< its tag */
    uint8_t moving;      /**< 1 while executing a move, 0 when idle or holding */
    float aux[EF_AUX_N]; /**< the auxiliary axes' commanded positions (A B C U V W), at the
                              same parameter as p */
} ef_setpoint_t;

/** Interpolator state (public for static allocation; treat as private). */
typedef struct {
    ef_move_t q[EF_INTERP_QUEUE];
    /** Power-basis coefficients of each queued curve relative to its b0, centred on
     *  t = 1/2: f(t) - b0 = sum_k pc[k] (t - 1/2)^k (zero above the degree), set by
     *  ef_interp_push() so the servo period evaluates position and derivatives by
     *  Horner's rule. */
    ef_vec3_t pc[EF_INTERP_QUEUE][6];
    uint32_t head, count;
    int mode;           /**< ::ef_step_mode_t */
    uint32_t period_us; /**< servo period (what next_us returns) */
    float t;            /**< time into the head move (s) */
    float t_c;          /**< compensation (Kahan) of t: a 1 ms step added to a time of
                             1000 s would otherwise lose 6 % of itself to rounding */
    float tau;          /**< corrected mode: current parameter */
    float s_done;       /**< corrected mode: arc length reached on the head move */
    float s_c;          /**< compensation (Kahan) of s_done, for long moves likewise */
    ef_vec3_t pos;      /**< last setpoint position */
    ef_vec3_t end;      /**< where the last queued move ends */
    float v_end;        /**< exit speed of the last queued move */
    uint32_t last_seq, last_tag;
    /** The auxiliary axes: power-basis coefficients of each queued move's ab relative to
     *  ab[k][0], centred on t = 1/2 as pc; last setpoint; where the last queued move ends. */
    float apc[EF_INTERP_QUEUE][EF_AUX_N][6];
    uint8_t amask[EF_INTERP_QUEUE]; /**< bit k: auxiliary axis k moves on that move (only those
                                         are evaluated: an X Y Z move costs a period nothing) */
    float apos[EF_AUX_N];
    float aend[EF_AUX_N];
} ef_interp_t;

/**
 * @brief Initialise at rest at `home`.
 * @param period_us servo period, > 0
 * @param mode      ::ef_step_mode_t
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, period 0 or unknown mode
 * @retval EF_ERR_NONFINITE home not finite or beyond EF_MAX_COORD
 */
int ef_interp_init(ef_interp_t *ip, ef_vec3_t home, uint32_t period_us, int mode);

/**
 * @brief Set the auxiliary axes' position while nothing is queued (ef_interp_init() puts
 * them at 0): where the first move's ab must start.
 * @param aux EF_AUX positions (A B C U V W order)
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, or moves queued
 * @retval EF_ERR_NONFINITE a position not finite or beyond EF_MAX_COORD
 */
int ef_interp_set_aux(ef_interp_t *ip, const float *aux);

/**
 * @brief Whether ef_interp_push() would accept m after a move ending at start (the checks
 * only; nothing is queued). Drives use it to refuse a segment when it arrives.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL, degree not 1/3/5, duration or length not > 0, v_exit < 0,
 *                    non-finite control points / law / length / v_exit, a negative phase
 *                    duration, or b[0] farther than EF_INTERP_JOIN_TOL from start
 */
int ef_interp_check(const ef_move_t *m, ef_vec3_t start);

/**
 * @brief Queue a planned move.
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL, a move that does not start within EF_INTERP_JOIN_TOL of the
 *                     previous end (on every axis, the auxiliary ones included), duration
 *                     <= 0 or not finite, degree not 1/3/5, non-finite control points
 *                     (auxiliary too) / law / length / v_exit (ip unchanged)
 * @retval EF_ERR_FULL queue full: process first
 */
int ef_interp_push(ef_interp_t *ip, const ef_move_t *m);

/** @brief Free queue places (0 for NULL). */
uint32_t ef_interp_space(const ef_interp_t *ip);

/**
 * @brief Advance by dt_us and produce the setpoint for now.
 * @param ip      interpolator
 * @param dt_us   microseconds since the previous call
 * @param next_us out (may be NULL): when to call again (the servo period)
 * @param sp      out: setpoint
 * @retval EF_OK           sp valid (moving or idle at rest)
 * @retval EF_ERR_ARG      NULL ip or sp
 * @retval EF_ERR_UNDERRUN ran out of moves while moving; sp holds the last end position
 *                         (returned on every call until a move is pushed; the time the
 *                         queue was dry is not carried into that move)
 * Every call finishes as many queued moves as dt covers (at most EF_INTERP_QUEUE) and
 * carries the leftover time into the next one.
 */
int ef_interp_process(ef_interp_t *ip, uint32_t dt_us, uint32_t *next_us, ef_setpoint_t *sp);

/**
 * @brief ef_interp_process() with the moves' time advanced by rate * dt_us: a feed
 * override. The path is the same, only traversed slower: speeds scale by rate, and a rate
 * that changes adds v * d(rate)/dt of tangential acceleration, which the caller keeps small
 * by ramping it (ef_drive.h's feed hold ramps a smoothstep). At rate 0 time stands still:
 * the setpoint stays where it is, still moving (sp->moving 1) and never an underrun.
 * @param rate share of the moves' time per unit of real time, clamped to [0, 1]; NaN is 0
 *             (a rate nobody can trust stands still)
 * @retval EF_OK, EF_ERR_ARG, EF_ERR_UNDERRUN as ef_interp_process()
 */
int ef_interp_process_rate(ef_interp_t *ip, uint32_t dt_us, float rate, uint32_t *next_us,
                           ef_setpoint_t *sp);

#ifdef __cplusplus
}
#endif

#endif /* EF_INTERP_H */
