/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_plan.h
 * @brief Feed planning over a look-ahead window of moves: speed limits per move, backward
 * and forward passes, and each released move's time law.
 *
 * ## Limits of a move (set by ef_plan_push())
 * Every axis i has its own speed, acceleration and jerk limit (v_axis_i, a_axis_i, j_max);
 * the planner uses each whole but for ::EF_PLAN_LIMIT_SHARE (a_axis_i and j_max below stand
 * for those shares of the limits). From the move's curve (ef_move_measure()): tangent
 * bound t_i = tabs_i, curvature-vector bound k_i = kabs_i and third-derivative bound
 * g_i = kjerk_i. At path speed v, tangential acceleration a and tangential jerk j, axis i
 * moves at most t_i v, accelerates at most t_i a + k_i v^2 and jerks at most
 * t_i j + 3 k_i v a + g_i v^3. So:
 * - v_max = min(feed, v_axis_i / t_i, sqrt(a_normal_frac a_axis_i / k_i),
 *   cbrt(EF_PLAN_JG_SHARE j_max / g_i)): at v_max the centripetal part takes at most
 *   a_normal_frac of each axis's acceleration, the geometry at most EF_PLAN_JG_SHARE of the
 *   jerk;
 * - a_max = min_i (a_axis_i - k_i v_max^2) / t_i: what every axis has left at v_max (a
 *   line, k = 0, gets the whole budget of its most loaded axis);
 * - j_max (the move's) = min_i (j_max - g_i v_max^3 - 3 k_i v_max a_max) / t_i, at least
 *   EF_PLAN_JT_MIN j_max / t_i (a_max is lowered where the centripetal growth term would
 *   leave less);
 * - on a curved move a_max and j_max share the jerk budget (3 k_i v_max a_max), so a_max is
 *   then the a in [EF_PLAN_A_SEARCH_LO, 1] x the above that makes the S-curve from rest to
 *   v_max shortest (a golden-section search of EF_PLAN_A_SEARCH_ITER steps), j_max what the
 *   axes leave at it. On a circle of R 10 at 50 mm/s and J 20 000 the largest a left the
 *   ramps 0.18 J (0.24 s from rest, tests/motion/test_plan.c "curved share").
 * The bounds take each maximum over the whole curve, so they hold at every instant of the
 * move whatever its speed profile (within v_max, a_max, j_max).
 *
 * ## Speed profile inside a move
 * Each move is self-contained: it ramps from v_entry to a cruise speed v_c <= v_max, cruises,
 * and ramps to v_exit (ef_timelaw_t: phases 0-2, 3, 4-6). Without a jerk limit a ramp is one
 * constant-acceleration phase at a_max. With one it is the time-optimal S-curve between two
 * speeds at zero acceleration: constant jerk j_max up to a_max, constant acceleration,
 * constant jerk down, lasting T = dv / a + a / j when dv >= a^2 / j, else 2 sqrt(dv / j)
 * (the acceleration peaks at sqrt(dv j) < a). The acceleration is continuous across phases
 * and moves (zero at every junction), the jerk within the move's j_max.
 *
 * ## Ramp groups
 * A move that cannot hold a whole ramp would cap the speed by its length (each move's law
 * starts and ends at zero acceleration). So consecutive moves are planned as one **group**
 * while the group is shorter than a full ramp from rest to its speed limit, its members'
 * limits agree (speed within EF_PLAN_GROUP_VRATIO, acceleration and jerk within
 * EF_PLAN_GROUP_ARATIO), it has fewer than EF_PLAN_GROUP_MAX members and no exact stop
 * inside. The group gets one law (above) over its whole length at its members' smallest
 * limits; at release that law is cut at the members' boundaries (each crossing found by a
 * fixed-count bisection), so each member's law is a slice of at most EF_TIMELAW_PHASES
 * phases, with the acceleration continuous across the members' junctions. A group of one
 * member is exactly the single-move law. The passes below run over groups.
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

/** Moves in the planner's look-ahead window (each ef_move_t is about 290 bytes), and as
 *  many groups. */
#ifndef EF_LOOKAHEAD
#define EF_LOOKAHEAD 64
#endif

/** Share of the jerk budget the geometry may take at a move's speed limit (curvature
 *  changing along the curve: g_i v^3, "Limits of a move"). Blends and curvature reversals
 *  are jerk-bound and traversed at constant speed, so most of it (comparison of 0.5, 0.8
 *  and 0.9 in docs/smoothing.md). */
#ifndef EF_PLAN_JG_SHARE
#define EF_PLAN_JG_SHARE 0.8f
#endif
/** Smallest share of the jerk budget the tangential ramps of a curved move keep (the rest is
 *  the geometry's and the centripetal part's growth while the speed changes). */
#ifndef EF_PLAN_JT_MIN
#define EF_PLAN_JT_MIN 0.25f
#endif

/** Search for a curved move's tangential acceleration (its jerk is what is left of the
 *  budget after 3 k_i v_max a): golden-section steps over [EF_PLAN_A_SEARCH_LO a_max, a_max]. */
#ifndef EF_PLAN_A_SEARCH_ITER
#define EF_PLAN_A_SEARCH_ITER 16
#endif
#ifndef EF_PLAN_A_SEARCH_LO
#define EF_PLAN_A_SEARCH_LO 0.05f
#endif

/** Junctions where the curvature jumps (G1 cubic smooth sections, `smooth_degree` 3: a cubic
 *  cannot meet its neighbours' curvature) step every axis's acceleration by dk_i v^2 at
 *  once. With a jerk limit the entry of the move after such a junction is capped at
 *  v = min_i sqrt(EF_PLAN_JUMP_T j_max / dk_i): a step the jerk limit would make in a
 *  quarter of a 1 ms servo period, the rest left to the ramps running across the junction
 *  (the fuzzer found 1.2 J at 19 mm/s across a jump of 0.2 / mm without the cap, 1.06 J
 *  at 7 mm/s with a whole period, and 1.04 J at 4.9 mm/s with half of one: a line's
 *  deceleration ramp at 0.98 J on the axis ending at a cubic section). G2 junctions (every
 *  other kind) jump by float rounding only. */
#ifndef EF_PLAN_JUMP_T
#define EF_PLAN_JUMP_T 0.25e-3f
#endif

/** Junctions where an auxiliary axis's rate (units per unit of X Y Z length) jumps by dr (its
 *  blends are G2 by arc length, so this is rounding, or a move shorter than float32 resolves
 *  well: a tiny arc piece carrying a turn, found by fuzz_smooth) step that axis's speed by
 *  dr v at once: the entry of the move after such a junction is capped at
 *  v = EF_PLAN_AUX_STEP_T a_axis / dr, a step its acceleration limit makes in that time
 *  (2 % of a 1 ms servo period: the share EF_PLAN_LIMIT_SHARE leaves). A jump within 0.2 %
 *  of the rate is the rounding of a G2 junction and is not capped. */
#ifndef EF_PLAN_AUX_STEP_T
#define EF_PLAN_AUX_STEP_T 20e-6f
#endif

/** Share of each axis's acceleration limit and of the jerk limit the planner plans to. The
 *  rest covers what the plan takes from samples of the curve (tabs, kabs, kjerk at 17
 *  points, ~0.2 %, ef_path.h) and the float32 evaluation of the setpoints (about one ulp of
 *  the coordinate per setpoint: at 1 ms and 30 mm, 8 mm/s^2 in a second difference), so
 *  the drive's setpoints stay within a_axis and j_max themselves, not only within a margin
 *  (measured on the LinuxCNC corpus: docs/benchmarks-linuxcnc.md). */
#ifndef EF_PLAN_LIMIT_SHARE
#define EF_PLAN_LIMIT_SHARE 0.98f
#endif

/** Motion limits. Speeds in units/s, accelerations units/s^2, jerk units/s^3. */
typedef struct {
    float v_axis[EF_AXES]; /**< largest speed per axis (X Y Z A B C U V W), > 0 for X Y Z;
                                >= 0 for the auxiliary axes, 0 = the machine has no such
                                axis (a move that moves it gets no speed: EF_ERR_FEED) */
    float a_axis[EF_AXES]; /**< largest acceleration per axis, likewise */
    float j_max;           /**< largest jerk of X Y Z (and of every auxiliary axis whose
                                j_aux is 0); 0 = no jerk limit on any axis
                                (constant-acceleration ramps) */
    float a_normal_frac;   /**< largest share of each axis's acceleration the centripetal part
                                may take at a move's speed limit, in (0, 1); what is left goes
                                to the ramps (the pipeline uses 0.5: on the LinuxCNC corpus
                                0.5-0.85 are within 1 % of each other) */
    float j_aux[EF_AUX_N]; /**< largest jerk of each auxiliary axis, >= 0; 0 = j_max (ignored
                                when j_max is 0) */
} ef_limits_t;

/**
 * @brief Validate limits.
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL, or a_normal_frac outside (0, 1)
 * @retval EF_ERR_NONFINITE a non-finite field
 * @retval EF_ERR_FEED      a speed or acceleration <= 0, or j_max < 0
 */
int ef_limits_check(const ef_limits_t *lim);

/** Most moves one ramp group holds ("Ramp groups" above). */
#ifndef EF_PLAN_GROUP_MAX
#define EF_PLAN_GROUP_MAX 32
#endif
/** A move joins the newest group only while its speed limit is at least this share of the
 *  group's (and the group's of its own): a group runs at its members' smallest limit. */
#ifndef EF_PLAN_GROUP_VRATIO
#define EF_PLAN_GROUP_VRATIO 0.92f
#endif
/** Likewise for the acceleration and jerk limits. */
#ifndef EF_PLAN_GROUP_ARATIO
#define EF_PLAN_GROUP_ARATIO 0.6f
#endif

/** A ramp group: consecutive moves planned as one (their lengths added, their smallest
 *  limits), whose time law is cut into one law per member at release. */
typedef struct {
    float length;   /**< sum of the members' lengths */
    float v_max;    /**< smallest member speed limit */
    float a_max;    /**< smallest member tangential acceleration */
    float j_max;    /**< smallest member tangential jerk */
    float v_in;     /**< cap on the entry speed from a curvature jump at the first member's
                         start (EF_PLAN_JUMP_T), 3.4e38 where there is none */
    uint16_t flags; /**< EF_MOVE_STOP_END when the last member has it */
    uint16_t n;     /**< members (in the move ring, after the previous groups' members) */
} ef_plan_group_t;

/** Planner state; fields are public so it can be static, treat them as private. */
typedef struct {
    ef_limits_t lim;
    ef_move_t mv[EF_LOOKAHEAD];      /**< the moves in the window, oldest at mhead */
    uint32_t mhead, mcount;          /**< move ring */
    ef_plan_group_t q[EF_LOOKAHEAD]; /**< groups, oldest at head */
    float v_lim[EF_LOOKAHEAD];       /**< backward-pass bound on each group's entry speed, kept
                                          current by each push (the oldest group's is unused) */
    uint32_t head;                   /**< index of the oldest group */
    uint32_t count;                  /**< groups in the window */
    uint32_t nstops;                 /**< groups in the window with EF_MOVE_STOP_END */
    uint32_t seq;                    /**< next sequence number */
    float v_last;                    /**< exit speed of the last released move */
    int finished;                    /**< ef_plan_finish() called since the last push */
    int open;                        /**< the newest group may still take moves */
    ef_vec3_t k_end;                 /**< curvature vector at the end of the last pushed move */
    int have_k;                      /**< k_end is set (a move was pushed) */
    float ar_end[EF_AUX_N];          /**< auxiliary axes' rates at its end (per unit length) */
    int have_ar;                     /**< ar_end is set (it moved X Y Z) */
    /* Release of the oldest group under way (rel_n > 0): its law and where it stands. */
    ef_move_t rel;  /**< the group's law (as a move of the group's length) */
    uint32_t rel_n; /**< members still to release */
    float rel_s;    /**< group distance where the next member starts */
    uint32_t rel_k; /**< law phase the next member starts in */
    float rel_u;    /**< time into that phase */
    float rel_v;    /**< speed there */
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

/**
 * @brief ef_plan_pull() whatever the window holds: for a caller whose moves are about to run
 * out while input still trickles in (a LinuxCNC task feeding one move per servo period).
 * Never unsafe: the backward pass plans the newest move to end at rest, so a move released
 * early exits at a speed from which what is in the window can still stop; releasing the
 * window's only group releases its last member with v_exit 0. The cost is look-ahead: a
 * later push cannot raise a released move's speeds, and pushes after the window ran empty
 * start from rest.
 * @retval EF_OK        out filled
 * @retval EF_ERR_ARG   NULL pointer
 * @retval EF_ERR_AGAIN the window is empty
 */
int ef_plan_pull_now(ef_plan_t *p, ef_move_t *out);

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

/**
 * @brief The limits the planner gives a move ("Limits of a move": speed limit, tangential
 * acceleration and jerk), without queueing it; the smoother uses it to tell whether a
 * corner is faster blended or stopped at.
 * @param lim checked limits (ef_limits_check())
 * @param m   measured move (ef_move_measure()) with its feed
 * @param v_max, a_max, j_max filled (j_max 0 without a jerk limit)
 * @retval EF_OK
 * @retval EF_ERR_ARG a NULL argument, or feed not > 0
 */
int ef_plan_move_limits(const ef_limits_t *lim, const ef_move_t *m, float *v_max, float *a_max,
                        float *j_max);

#ifdef __cplusplus
}
#endif

#endif /* EF_PLAN_H */
