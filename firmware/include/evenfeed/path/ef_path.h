/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_path.h
 * @brief Path primitives (what a part program commands) and moves (what the smoother emits
 * and a drive executes): types, validation and geometry queries.
 *
 * ## Primitives
 * A primitive starts where the previous one ended (the stream's current position) and is a
 * straight line or a circular arc / helix. An arc turns about the unit axis `axis` through
 * `centre` by `sweep` radians (right-hand rule: positive sweep is counter-clockwise seen
 * from the tip of the axis; several full turns allowed); for a helix the end also moves
 * along the axis, linearly in the angle. `centre` is the centre at the start's height
 * along the axis. The start radius is |start - centre| measured perpendicular to the axis.
 *
 * Arc consistency (the firmware's rule, matching the host G-code reader's): the end's
 * radius may differ from the start's by at most max(::EF_ARC_ABS_TOL, ::EF_ARC_REL_TOL x
 * radius); the arc is then evaluated with the start radius and the end angle, and its
 * computed end is replaced by the given end (the difference is within that tolerance).
 * Beyond it the arc is ::EF_ERR_ARC.
 *
 * ## Moves
 * A move is one Bézier curve (degree 1 for straight pieces, 5 for arcs, blends and smooth
 * sections, 3 for G1-cubic smooth sections) plus what the feed planner attached: speed
 * limit, entry/exit speed, duration and the time law (ef_timelaw_t). docs/smoothing.md
 * defines every field.
 *
 * ## Time law
 * The move's curve f(tau), tau in [0, 1], is traversed with tau(t) = s(t) / L, where L is
 * the curve's arc length and s(t) the planned distance along it: because evenfeed's curves
 * have near-constant parametric speed |f'(tau)| ~ L, the feed |d f(tau(t)) / dt| is then
 * near s'(t). s(t) is piecewise polynomial in time with up to ::EF_TIMELAW_PHASES phases
 * (a move planned alone: phases 0-2 ramp from the entry speed, phase 3 cruises, phases 4-6
 * ramp to the exit speed; a member of a ramp group, ef_plan.h: its slice of the group's law,
 * packed from phase 0, possibly starting and ending at a nonzero acceleration); phase k
 * lasts `dt[k]` seconds and, with u the time since the phase began,
 *
 *     tau(u) = c[k][0] + c[k][1] u + c[k][2] u^2 + c[k][3] u^3.
 *
 * A phase with dt[k] == 0 is unused (all its numbers are 0) and is skipped. Without a jerk
 * limit a ramp is one constant-acceleration phase (c[k][3] = 0). With a jerk limit a ramp is
 * the time-optimal S-curve between two speeds at rest acceleration: constant jerk up
 * (c[k][2] = 0), constant acceleration (c[k][3] = 0; absent when the speed change is too
 * small to reach the move's acceleration limit), constant jerk down. A drive evaluating the
 * moves itself needs only these numbers.
 */
#ifndef EF_PATH_H
#define EF_PATH_H

#include <stdint.h>
#include "evenfeed/core/ef_config.h"
#include "evenfeed/geom/ef_endpoint.h"
#include "evenfeed/core/ef_math.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Arc consistency: absolute radius tolerance (program units). */
#ifndef EF_ARC_ABS_TOL
#define EF_ARC_ABS_TOL 0.002f
#endif
/** Arc consistency: relative radius tolerance (fraction of the start radius). */
#ifndef EF_ARC_REL_TOL
#define EF_ARC_REL_TOL 0.001f
#endif
/** Largest |sweep| of an arc primitive (rad): 1000 full turns. */
#ifndef EF_ARC_MAX_SWEEP
#define EF_ARC_MAX_SWEEP 6283.1853f
#endif

/** Primitive kinds. */
typedef enum {
    EF_PRIM_LINE = 1, /**< straight feed move to `end` */
    EF_PRIM_ARC = 2,  /**< circular arc or helix to `end` (centre, axis, sweep) */
} ef_prim_kind_t;

/** Primitive flag: stop exactly at the primitive's start (G61, an event such as a tool
 *  change or dwell between the previous primitive and this one, a rapid, program start).
 *  No blend or smoothing crosses that vertex. */
#define EF_PRIM_STOP_BEFORE 1u

/** One commanded path primitive (float32, program units; speeds in units per second). */
typedef struct {
    uint8_t kind; /**< ::ef_prim_kind_t */
    uint8_t pad[3];
    uint32_t flags;      /**< EF_PRIM_* */
    ef_vec3_t end;       /**< end point */
    ef_vec3_t centre;    /**< ARC: centre, at the start's position along the axis */
    ef_vec3_t axis;      /**< ARC: unit axis (e.g. +Z for G17) */
    float sweep;         /**< ARC: signed angle about the axis (rad), full turns included, != 0 */
    float feed;          /**< commanded feed (units/s), > 0 */
    float tol;           /**< path tolerance P at the vertex where this primitive starts
                              (G64 P); 0 means exact stop there */
    float qtol;          /**< collinearity tolerance Q (G64 Q), >= 0; 0 disables merging */
    uint32_t tag;        /**< caller's reference, e.g. the source line; copied to moves */
    float aux[EF_AUX_N]; /**< A B C U V W (the first ef_smooth_cfg_t::naux of them) at the end:
                              they move linearly in the primitive's arc length; the smoother
                              reads none of them while naux is 0. A line whose X Y Z stay
                              (shorter than EF_MIN_CHORD) and whose auxiliary axes move is an
                              auxiliary move: planned on those axes alone, between exact
                              stops, `feed` in their units per second (docs/axes.md) */
} ef_prim_t;

/** Geometry at a point of a primitive or move. */
typedef struct {
    ef_vec3_t p; /**< position */
    ef_vec3_t t; /**< unit tangent (direction of travel) */
    ef_vec3_t n; /**< unit principal normal (zero vector when kappa == 0) */
    float kappa; /**< curvature >= 0 */
} ef_frame_t;

/** End data for the segment builders (ef_seg.h) from a frame. */
static inline ef_endpoint_t ef_frame_endpoint(const ef_frame_t *f)
{
    ef_endpoint_t e;
    e.p = f->p;
    e.t = f->t;
    e.n = f->n;
    e.kappa = f->kappa;
    return e;
}

/**
 * @brief Validate a primitive starting at `start` and return its length.
 * @param start where the primitive starts (the previous end)
 * @param pr    the primitive
 * @param len   out: arc length (helix included), > 0
 * @retval EF_OK
 * @retval EF_ERR_ARG        NULL pointer, unknown kind or flags, tol or qtol < 0
 * @retval EF_ERR_NONFINITE  NaN/inf in any used field, a coordinate above EF_MAX_COORD, or
 *                           an arc reaching beyond it (|centre_i| + radius + rise)
 * @retval EF_ERR_FEED       feed <= 0
 * @retval EF_ERR_DEGENERATE line shorter than EF_MIN_CHORD (a zero-length move; callers
 *                           drop it only after reporting it), arc radius below
 *                           EF_MIN_CHORD
 * @retval EF_ERR_ARC        inconsistent arc: radius mismatch beyond the tolerance, axis
 *                           not unit, sweep 0 or above EF_ARC_MAX_SWEEP, or the end's
 *                           angle not the one the sweep reaches (beyond the tolerance)
 *
 * Checks run in this order, so one input has one code: ARG (NULL, kind, flags); NONFINITE
 * (start, end, feed, tol, qtol, and for arcs centre, axis, sweep; a NaN tol is NONFINITE,
 * not ARG); ARG (tol or qtol < 0); FEED; then for lines DEGENERATE; for arcs ARC (axis:
 * | |axis|^2 - 1 | > 2 EF_UNIT_TOL; sweep), DEGENERATE (radius), ARC (radius, angle),
 * DEGENERATE (length), NONFINITE (the arc's reach beyond EF_MAX_COORD).
 * A line's arc fields are not looked at. Only the centre's position perpendicular to the
 * axis matters (the axis line through it). The angle test measures, in the arc's plane, the
 * distance of the end from the point the sweep reaches on the end's circle (radius r1),
 * r1 2 sin(|d angle| / 2), and allows the radius tolerance as an angle,
 * max(EF_ARC_ABS_TOL, EF_ARC_REL_TOL r) / r, plus the float32 rounding of the sweep itself,
 * 8 eps (|sweep| + 2 pi) rad (eps = 2^-23), so many-turn arcs are not refused for their
 * representation: the distance at most r1 times that allowance. For the small allowances of
 * any arc above a few EF_ARC_ABS_TOL in radius this is |d angle| within the allowance; an
 * arc whose allowance exceeds 2 rad (a radius below EF_ARC_ABS_TOL / 2) takes any end angle,
 * its whole circle being within the tolerance of its model.
 */
int ef_prim_check(ef_vec3_t start, const ef_prim_t *pr, float *len);

/**
 * @brief Point, tangent, normal and curvature of a (checked) primitive at arc length `s`
 * from its start, 0 <= s <= len (clamped; NaN counts as 0).
 *
 * The position is exactly `start` at s <= 0 and exactly `pr->end` at s >= len (len as
 * ef_prim_check() computes it), so consecutive primitives join exactly. Lines: n = 0,
 * kappa = 0. Arcs: evaluated with the start radius; sin/cos by a fixed-count polynomial
 * (about 1 ulp), so positions are within a few eps of (|centre| + r) plus the float32
 * resolution of the angle sweep * s / len (eps |sweep| r: 5e-4 r at 1000 turns).
 * The primitive is not validated again (out is zero for NULL or an unknown kind).
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer or unknown kind
 */
int ef_prim_frame(ef_vec3_t start, const ef_prim_t *pr, float s, ef_frame_t *out);

/**
 * @brief How far a (checked) arc's end point lies from where its model puts the end: the
 * circle of the start radius, swept by `sweep`, risen by the helix's rise. ef_prim_check()
 * allows the radius tolerance there (a G-code arc whose end is off its circle, or the
 * rounding of the sweep), and ef_prim_frame() puts the point at s = len exactly on
 * `pr->end`, so the last stretch of the arc carries this gap. 0 for a line or NULL.
 */
float ef_prim_end_gap(ef_vec3_t start, const ef_prim_t *pr);

/**
 * An arc's geometry as ef_prim_frame() computes it on every call: the unit axis a, the axis
 * point `base` level with the start, the radial unit eu towards the start, ev = a x eu, the
 * start radius r0, the axial rise h of the end, the length len (ef_prim_check()'s).
 * ef_prim_geo() fills it once, so several frames of one arc (a blend's trials) skip it;
 * all zero for a line, NULL or an unknown kind.
 */
typedef struct {
    ef_vec3_t a, base, eu, ev;
    float r0, h, len;
    float sn1, cs1; /**< sine and cosine of the sweep (the end's angle), as the frames
                         compute them */
} ef_prim_geo_t;

/**
 * @brief Fill an arc's geometry for ef_prim_frame_geo() and ef_prim_end_gap_geo(); g zero
 * for a line, NULL or an unknown kind (no validation, as ef_prim_frame()). Nothing for a
 * NULL g.
 */
void ef_prim_geo(ef_vec3_t start, const ef_prim_t *pr, ef_prim_geo_t *g);

/**
 * @brief ef_prim_check() that also fills the geometry ef_prim_geo(start, pr) gives, the same
 * bits (the check computes it anyway), for callers that go on to frames: one computation
 * instead of two (the public ef_blend_prims()).
 * @retval EF_OK      *len and *geo filled (geo zero for a line)
 * @retval EF_ERR_ARG geo NULL, or as ef_prim_check()
 * @retval EF_ERR_NONFINITE, EF_ERR_FEED, EF_ERR_DEGENERATE, EF_ERR_ARC as ef_prim_check()
 *                    (geo zero)
 */
int ef_prim_check_geo(ef_vec3_t start, const ef_prim_t *pr, float *len, ef_prim_geo_t *geo);

/**
 * @brief ef_prim_frame() with the arc's geometry from ef_prim_geo(start, pr): the same
 * operations in the same order, so the same bits (ef_prim_frame() is ef_prim_geo() then
 * this).
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer or unknown kind (out zero)
 */
int ef_prim_frame_geo(ef_vec3_t start, const ef_prim_t *pr, const ef_prim_geo_t *geo, float s,
                      ef_frame_t *out);

/**
 * @brief ef_prim_frame_geo() at s = 0 (at_end 0) or at s = len (at_end 1: the geometry's
 * len for an arc, |end - start| for a line): the same bits, without evaluating a sine and
 * cosine (the start's angle is 0, the end's sine and cosine are in the geometry). Blends
 * take the frames where two primitives meet through this.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer or unknown kind (out zero)
 */
int ef_prim_frame_end_geo(ef_vec3_t start, const ef_prim_t *pr, const ef_prim_geo_t *geo,
                          int at_end, ef_frame_t *out);

/**
 * @brief ef_prim_end_gap() with the arc's geometry from ef_prim_geo(); 0 for a line or NULL.
 */
float ef_prim_end_gap_geo(const ef_prim_t *pr, const ef_prim_geo_t *geo);

/** Move kinds. */
typedef enum {
    EF_MOVE_LINE = 1,   /**< a straight piece (degree 1), exact constant speed */
    EF_MOVE_ARC = 2,    /**< a piece of an arc or helix as a G2 quintic (through the table) */
    EF_MOVE_BLEND = 3,  /**< a corner blend (G2 quintic) */
    EF_MOVE_SMOOTH = 4, /**< a smooth section through CAM micro-segment points */
} ef_move_kind_t;

/** Move flag: the move ends with an exact stop (v_exit is 0). */
#define EF_MOVE_STOP_END 1u
/** Move flag: the table lookup clamped the configuration (see EF_SEG_CLAMPED). */
#define EF_MOVE_CLAMPED 2u
/** Move flag: a neighbour limited the blend (deviation below the tolerance). */
#define EF_MOVE_BLEND_CLAMPED 4u
/** Move flag: an auxiliary move: X Y Z stay (b[0] == b[1], degree 1), the auxiliary axes
 *  move; `length` is their Euclidean distance and every speed is in their units. */
#define EF_MOVE_AUX_ONLY 8u

/** Phases of a time law: three per ramp and the cruise between them. */
#define EF_TIMELAW_PHASES 7
/** Polynomial coefficients per phase (cubic in time). */
#define EF_TIMELAW_COEFFS 4

/** A move's time law: tau as a piecewise polynomial in time (see the file comment). */
typedef struct {
    float dt[EF_TIMELAW_PHASES]; /**< phase durations (s), >= 0; sum = move duration */
    float c[EF_TIMELAW_PHASES][EF_TIMELAW_COEFFS]; /**< tau(u) coefficients per phase, u = time
                                                        in phase */
} ef_timelaw_t;

/** One emitted move. */
typedef struct {
    ef_vec3_t b[6];   /**< control points b[0..degree] (program units) */
    uint8_t degree;   /**< 1, 3 or 5 */
    uint8_t kind;     /**< ::ef_move_kind_t */
    uint16_t flags;   /**< EF_MOVE_* */
    uint32_t seq;     /**< sequence number, 0, 1, 2, ... in emission order */
    uint32_t tag;     /**< tag of the primitive the move belongs to (blends: the outgoing
                           primitive's) */
    float length;     /**< arc length L of the curve */
    float kappa_max;  /**< largest curvature on the curve (sampled, see ef_move_measure()) */
    ef_vec3_t tabs;   /**< per axis, the largest over the curve (sampled) of |t_i| and
                           |f'_i(tau)| / L: the axis moves at most tabs_i times the planned
                           path speed whether tau is stepped by arc length or uniformly by
                           the time law, so v <= v_axis_i / tabs_i keeps every axis within
                           its limit (for evenfeed's curves the two agree to ~0.2 %) */
    ef_vec3_t kabs;   /**< per axis, the largest over the curve (sampled) of |kappa n_i|
                           and |f''_i(tau)| / L^2: the axis's centripetal acceleration is at
                           most kabs_i v^2 in either interpolator mode */
    ef_vec3_t kjerk;  /**< per axis, the largest (sampled) |f'''_i(tau)| / L^3: at constant
                           speed v the axis's jerk from the geometry is about kjerk_i v^3 */
    float dev;        /**< deviation from the programmed path it replaces (blends: from the
                           corner; arcs: from the true arc; lines: 0) */
    float feed;       /**< commanded feed (units/s) */
    float v_max;      /**< speed limit: feed, axis speeds, centripetal (set by the planner) */
    float a_max;      /**< tangential acceleration limit (set by the planner) */
    float j_max;      /**< tangential jerk limit of the ramps, 0 = none (set by the planner) */
    float v_entry;    /**< planned speed at tau = 0 */
    float v_exit;     /**< planned speed at tau = 1 */
    float duration;   /**< seconds, sum of law.dt */
    ef_timelaw_t law; /**< tau(t) */
    /** The auxiliary axes (A B C U V W): control points ab[k][0..degree] of axis k as a
     *  polynomial in the same parameter tau (Bernstein form, the move's degree); all zero
     *  where a caller uses no auxiliary axis. */
    float ab[EF_AUX_N][6];
    float atabs[EF_AUX_N];  /**< as tabs, for each auxiliary axis: its speed is at most
                                 atabs_k v */
    float akabs[EF_AUX_N];  /**< as kabs: its acceleration at constant speed at most
                                 akabs_k v^2 */
    float akjerk[EF_AUX_N]; /**< as kjerk: its jerk at constant speed about akjerk_k v^3 */
} ef_move_t;

/**
 * @brief Arc length, curvature bound, largest |tangent component|, |curvature vector
 * component| and |third derivative component| per axis of a move's curve, by Gauss–Legendre
 * quadrature and sampling with fixed counts
 * (::EF_MOVE_SAMPLES samples; for degree 1 exact).
 *
 * Length: 16-node Gauss–Legendre on |f'| (relative error ~2e-7 on evenfeed's curves).
 * kappa_max, tabs, kabs and kjerk: at t = i / EF_MOVE_SAMPLES, i = 0..EF_MOVE_SAMPLES (ends
 * included). The derivatives come from the hodographs' control points (computed once; a cubic's
 * elevated to the quintic's degrees) in Bernstein form.
 * A zero speed at a sample (a cusp) gives an infinite curvature: EF_ERR_NONFINITE. On error
 * length, kappa_max, tabs, kabs and kjerk are zero.
 * The auxiliary axes' bounds atabs, akabs and akjerk are taken at the same samples from the
 * derivatives of ab by X Y Z arc length (and by tau / L, the larger, as for X Y Z); an axis
 * whose control points are all equal stays still and gets zeros without being sampled. An
 * ::EF_MOVE_AUX_ONLY move (degree 1) has `length` the auxiliary axes' distance, X Y Z bounds
 * zero and atabs_k = |ab[k][1] - ab[k][0]| / length.
 * @param m  move with b, ab, degree and flags set; m->length, m->kappa_max, m->tabs,
 *           m->kabs, m->kjerk, m->atabs, m->akabs and m->akjerk are filled
 * @retval EF_OK
 * @retval EF_ERR_ARG       NULL move or degree not 1, 3 or 5
 * @retval EF_ERR_NONFINITE non-finite control points or result
 */
int ef_move_measure(ef_move_t *m);

/**
 * @brief The auxiliary bounds (atabs, akabs, akjerk) after ab was set on a measured move:
 * zeros at once while no auxiliary axis moves (the X Y Z fields untouched), otherwise
 * ef_move_measure() (which gives the X Y Z fields the same bits again).
 * @retval EF_OK
 * @retval EF_ERR_ARG, EF_ERR_NONFINITE as ef_move_measure()
 */
int ef_move_measure_aux(ef_move_t *m);

/** Samples ef_move_measure() takes along a curve. */
#ifndef EF_MOVE_SAMPLES
#define EF_MOVE_SAMPLES 16
#endif

/**
 * @brief Evaluate a move's time law at time t since the move began (clamped to
 * [0, duration]; t >= duration or NaN gives tau = 1 exactly). Implemented in ef_plan.c.
 * @param m   move (law, duration, length set)
 * @param t   time (s)
 * @param tau out: parameter in [0, 1]
 * @param v   out (may be NULL): planned path speed ds/dt at t
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer
 */
int ef_timelaw_eval(const ef_move_t *m, float t, float *tau, float *v);

#ifdef __cplusplus
}
#endif

#endif /* EF_PATH_H */
