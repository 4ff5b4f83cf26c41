/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_plan.h
 * @brief Feed planning over a look-ahead window of moves: speed limits per move, backward
 * and forward passes, and each released move's time law.
 *
 * ## Limits of a move (set by ef_plan_push())
 * - v_max = min(feed, min_i v_axis_i / tabs_i, sqrt(a_n / kappa_max)), where tabs_i is the
 *   largest |tangent component| on axis i over the move (and of |f'_i| / L: ef_path.h)
 *   and a_n = a_normal_frac x a_path
 *   the centripetal share of the acceleration budget;
 * - a_max = (1 - a_normal_frac) x a_path, the tangential share, with
 *   a_path = min_i a_axis_i / tabs_i (so every axis stays within its own limit when the
 *   two shares add up, component by component).
 *
 * ## Speed profile inside a move
 * Each move is self-contained: it ramps from v_entry to a cruise speed v_c <= v_max, cruises,
 * and ramps to v_exit (ef_timelaw_t, up to three phases). Without a jerk limit the ramps
 * have constant acceleration a_max. With a jerk limit J > 0 the ramps follow a smoothstep
 * in speed (zero acceleration at both ends of a ramp, so acceleration is continuous across
 * phases and moves), lasting T = max(1.5 |dv| / a_max, sqrt(6 |dv| / J)): peak
 * acceleration 1.5 |dv| / T <= a_max, peak jerk 6 |dv| / T^2 <= J.
 *
 * ## Passes and release
 * Junction speeds are limited by both moves' v_max (the smoother's paths are G2 at every
 * junction that is not an exact stop; ::EF_MOVE_STOP_END junctions are 0). The backward pass
 * runs from the newest move, which is assumed to end at rest, so every plan is safe to
 * execute whatever comes later; the forward pass starts from the committed exit speed of
 * the last released move. ef_plan_pull() releases the oldest move when the window is full,
 * when an exact stop lies in the window, or after ef_plan_finish(); its entry speed is then
 * final, and its exit speed is final too (the backward pass already ensured the next move
 * can stop in time).
 *
 * ## Cost
 * The backward bounds (v_lim) are maintained incrementally: a push recomputes the newest
 * move's bound and then earlier ones only while they change (a bound depends only on its
 * move, the one before it and the next bound, so an unchanged bound stops the pass; the
 * result equals a from-scratch pass). A push costs amortised O(1) ramp inversions in
 * ordinary streams, O(EF_LOOKAHEAD) at worst (a long braking tail); a pull costs O(1) (the
 * oldest move's forward step and time law). Without a jerk limit each ramp inversion is
 * closed-form; with one it is a fixed-count bisection. Every loop has a fixed bound.
 */
#ifndef EF_PLAN_H
#define EF_PLAN_H

#include <stdint.h>
#include "evenfeed/path/ef_path.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Moves in the planner's look-ahead window (each ef_move_t is 204 bytes). */
#ifndef EF_LOOKAHEAD
#define EF_LOOKAHEAD 64
#endif

/** Motion limits. Speeds in units/s, accelerations units/s^2, jerk units/s^3. */
typedef struct {
    float v_axis[3];     /**< largest speed per axis, > 0 */
    float a_axis[3];     /**< largest acceleration per axis, > 0 */
    float j_max;         /**< largest path jerk; 0 = no jerk limit (constant-acceleration
                              ramps) */
    float a_normal_frac; /**< share of the acceleration budget allowed for centripetal
                              acceleration, in (0, 1); 0.5 is a good default */
} ef_limits_t;

/**
 * @brief Validate limits.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, or a_normal_frac outside (0, 1)
 * @retval EF_ERR_NONFINITE a non-finite field
 * @retval EF_ERR_FEED      a speed or acceleration <= 0, or j_max < 0
 */
int ef_limits_check(const ef_limits_t *lim);

/** Planner state; fields are public so it can be static, treat them as private. */
typedef struct {
    ef_limits_t lim;
    ef_move_t q[EF_LOOKAHEAD]; /**< window, oldest at head */
    float v_lim[EF_LOOKAHEAD]; /**< backward-pass bound on each move's entry speed, kept
                                    current by each push (the oldest move's is unused) */
    uint32_t head;             /**< index of the oldest move */
    uint32_t count;            /**< moves in the window */
    uint32_t nstops;           /**< moves in the window with EF_MOVE_STOP_END */
    uint32_t seq;              /**< next sequence number */
    float v_last;              /**< exit speed of the last released move */
    int finished;              /**< ef_plan_finish() called since the last push */
} ef_plan_t;

/**
 * @brief Initialise a planner, at rest.
 * @retval EF_OK
 * @retval EF_ERR_ARG, EF_ERR_NONFINITE, EF_ERR_FEED  as ef_limits_check()
 */
int ef_plan_init(ef_plan_t *p, const ef_limits_t *lim);

/**
 * @brief Append a move: its limits are computed here; seq is assigned here.
 * @param p planner
 * @param m move with b, degree, kind, flags (EF_MOVE_STOP_END), tag, feed, length,
 *          kappa_max, tabs set (ef_move_measure()); planner fields are overwritten
 *          (flags other than the EF_MOVE_* ones are dropped)
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL pointer, degree not 1/3/5, length <= 0 (below EF_MIN_CHORD),
 *                          kappa_max < 0, a tabs component < 0 or all below 0.5 (every
 *                          unit tangent has a component >= 1/sqrt(3))
 * @retval EF_ERR_NONFINITE non-finite data (b, length, kappa_max, tabs, feed), or a control
 *                          point beyond EF_MAX_COORD
 * @retval EF_ERR_FEED      feed <= 0
 * @retval EF_ERR_FULL      window full: pull first (nothing changed)
 * On any error the planner is unchanged. On success the backward bounds are updated from the
 * new move back while they change (see Cost above).
 */
int ef_plan_push(ef_plan_t *p, const ef_move_t *m);

/**
 * @brief End of input for now: the newest move ends at rest (an exact stop) and every move
 * in the window becomes releasable. Later pushes start again from rest. (The newest move
 * gets ::EF_MOVE_STOP_END, so it is released with that flag and v_exit 0.)
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL
 */
int ef_plan_finish(ef_plan_t *p);

/**
 * @brief Release the oldest move with final v_entry, v_exit, v_max, a_max, duration, law.
 * @retval EF_OK       out filled
 * @retval EF_ERR_ARG  NULL pointer
 * @retval EF_ERR_AGAIN nothing releasable yet (window not full, no stop in it, not finished)
 * The backward bounds are already current (kept by ef_plan_push()): O(1), at most three ramp
 * searches (closed-form without a jerk limit, fixed-count bisections with one).
 */
int ef_plan_pull(ef_plan_t *p, ef_move_t *out);

/** @brief Free places in the window (0 for NULL). */
uint32_t ef_plan_space(const ef_plan_t *p);

/**
 * @brief Fill a move's time law for given entry, exit and limits (used by the planner;
 * public for tests and for drives that re-plan). Requires v_entry and v_exit reachable
 * within the move's length: |v_exit - v_entry| ramp distance <= length (the passes
 * guarantee it); otherwise the exit speed is lowered/raised to what is reachable.
 * @param m     move with length, v_max, a_max, v_entry, v_exit set; duration and law filled
 *              (v_exit rewritten when it had to be made reachable)
 * @param j_max jerk limit (0: none)
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL, length <= 0 (below EF_MIN_CHORD), speeds negative / non-finite,
 *                    v_max or a_max <= 0, j_max < 0 / non-finite (m unchanged)
 */
int ef_plan_timelaw(ef_move_t *m, float j_max);

#ifdef __cplusplus
}
#endif

#endif /* EF_PLAN_H */
