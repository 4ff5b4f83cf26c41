/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_blend.h
 * @brief Corner blends between two straight moves: a G2 quintic from the G2 table that
 * replaces the corner, deviating from it by at most a tolerance P.
 *
 * ## Geometry (line–line corners)
 * The programmed path comes in along the unit direction u_in, reaches the corner v and
 * leaves along u_out. The turn angle is theta = angle(u_in, u_out) in [0, pi] and the half
 * turn phi = theta / 2. The blend is symmetric: with trim L on both sides it runs from
 * A = v - L u_in to B = v + L u_out, so its chord B - A = L (u_in + u_out) has length
 * s = 2 L cos(phi) and lies along the bisector direction. In the table's normalized frame
 * the configuration is alpha = -beta = phi (the mirror image, alpha = -phi, has the same
 * DOFs), k0 = k1 = 0: the blend meets the lines with curvature 0, so the path stays G2.
 *
 * The configuration is its own image under the reversal symmetry (reflection in the
 * chord's perpendicular bisector plus running the curve backwards), which maps DOFs
 * (x1_0, x2_0, x1_1, x2_1) to (x1_1, -x2_1, x1_0, -x2_0). The optimum is therefore
 * symmetric, x1_0 = x1_1 = x1 and x2_0 = -x2_1 = x2; the lookup is evaluated and its two
 * halves averaged (x1 = (x1_0 + x1_1)/2, x2 = (x2_0 - x2_1)/2) so the curve is symmetric
 * about the bisector to float precision whatever rounding the table has. Then x1 is set to
 * the curve's own arc length (x1 = L by three Newton steps; |f'|^2 at each Gauss–Legendre
 * node is a quadratic in x1, ef_blend.c),
 * so its end speeds equal L and uniform stepping of the parameter (the drives' segment mode)
 * keeps the feed continuous at both junctions; the table's x1 was up to 1.2 % off at sharp
 * corners (below 1e-4 now up to 175 degrees, 5e-4 beyond: tests/blend/test_blend.c). With
 * a = 2 x1/5 + x2/20 (x1, x2 in program units, i.e. per unit chord times s), the control
 * points are
 *
 *     b0 = A,  b1 = A + (x1/5) u_in,  b2 = A + a u_in,
 *     b5 = B,  b4 = B - (x1/5) u_out, b3 = B - a u_out.
 *
 * The curve's midpoint is f(1/2) = v + c (u_out - u_in) / 32 with c = 16 - x1/L - 10 a/L,
 * on the bisector; it is the curve's point nearest to v (tests/blend/test_blend.c checks this
 * numerically), so the deviation of the blend from the programmed corner is
 *
 *     dev = |f(1/2) - v| = L g(theta),   g = |c| sin(phi) / 16,
 *
 * linear in L because everything (DOFs included) scales with L. The blend takes
 * L = min((P - q) / g, max_in, max_out, EF_MAX_COORD) and reports dev = L g, where
 * q = 4 eps max|v_i| (eps = 2^-23) is kept for the float32 rounding of the control
 * points, so the curve as stored, not only the exact one, stays within P.
 *
 * ## Outcomes for valid input (all return ::EF_OK; the cost does not depend on which)
 * - a blend: out->seg is the quintic (degree 5), trims L; ::EF_BLEND_CLAMPED when a
 *   neighbour limited L (then dev < P);
 * - ::EF_BLEND_STRAIGHT: turn below ::EF_BLEND_MIN_TURN, nothing to blend (trims 0,
 *   out->seg degree 0): the path goes straight through v;
 * - ::EF_BLEND_STOP: the blend that fits is too small for float32 to represent (its chord is
 *   below max(EF_MIN_CHORD, EF_MIN_CHORD_REL * max|v_i|), as for any segment, or P <= q,
 *   P below the float32 resolution of the coordinates): no blend,
 *   trims 0, out->seg degree 0, and the caller must stop exactly at v.
 *
 * ## Near reversals
 * A turn above ::EF_BLEND_MAX_TURN (179 degrees by default) is ::EF_ERR_REVERSAL: the blend
 * would be a hairpin whose tangents point nearly straight back (the table's alpha near its
 * domain edge pi/2), the caller must stop exactly at the vertex. Up to the threshold the
 * blend is built and tested like any other.
 *
 * ## Corners with arc ends (ef_blend_prims())
 * When either side is an arc or helix, the blend runs from the point at arc length L before
 * the vertex on the incoming primitive to the point at arc length L after it on the
 * outgoing one (the same L on both sides, as for two lines), with the primitives' tangents
 * and curvature vectors there (an arc end has curvature 1/r towards the centre). Its DOFs
 * are the line–line blend's for the vertex tangents, the table at (phi, -phi, 0, 0), with
 * both end speeds then set to the curve's own length (Newton steps on a per-node quartic of
 * the hodograph, 8 Gauss–Legendre nodes; the first guess is the table's x1 per unit chord
 * times the trial's chord): a stepper that steps the parameter uniformly (the drives'
 * segment mode) would otherwise jump in feed at both junctions (ef_seg_g2_even() says why).
 * Its deviation is bounded in closed form, both ways, as the smaller of two bounds, each a
 * chain of distances between points at equal parameters:
 * - against the line–line blend r with the same DOFs on the tangent lines through v:
 *   r's own deviation (its midpoint's distance from v, as for two lines), plus
 *   max |b_i - c_i| over the two curves' control points (Bernstein weights are positive and
 *   sum to 1), plus kappa L^2 / 2 (a curve of curvature at most kappa stays that close to
 *   its tangent line over arc length L);
 * - each half of the blend (split at t = 1/2) against its side's own arc-length Hermite
 *   quintic from the trim point to v (ef_blend_arc_piece()'s curve, within
 *   r sigma^6 / 46080 of the arc): the largest control point difference plus that bound.
 *   This one is close to the true deviation for tangent joins and tight arcs, where the
 *   first one counts the arc's sagitta twice.
 * Plus the float32 terms: the frames' tangent angle, ef_prim_frame()'s angle on each arc
 * (2 ulp of it times the radius), the incoming arc's end gap (ef_prim_end_gap()) and
 * q = 4 eps (max|v_i| + r_in + r_out) for the control points' rounding. No samples: the cost
 * is the same for every corner of a pair of kinds (to rounding of the loop bounds, 1 %).
 * L: ::EF_BLEND_ITER (2) trials, the first at the line–line trim for 0.99 tol, the second
 * fitting dev ~ m + g L + A L^2 through the first and solving it for 0.99 tol (later ones,
 * if EF_BLEND_ITER is raised, 0.97 tol); the longest trial within tol is kept. Its end speeds are
 * measured once more on the stored control points (8-node length; a tiny blend far from the origin
 * rounds them by a few 1e-3), and its chord must be one float32 resolves (as ef_blend_corner()); if
 * no trial is kept or these fail, the outcome is ::EF_BLEND_STOP. L is at most max_in and max_out
 * (and, on an arc, EF_ARC_PIECE_SWEEP of its sweep); a side whose own limit is within 2 % of L
 * takes that limit, so two blends that each take half of a primitive meet without a sliver between
 * them. A short neighbour on one side therefore shortens both sides.
 *
 * ## Tangent joins (ef_blend_prims())
 * A vertex whose tangents turn by less than ::EF_BLEND_MIN_TURN but whose curvature vectors
 * differ (a line tangent to an arc, tangent arcs of different radii or turning ways) is
 * only G1: the curvature jumps there. When dk = |kappa_in n_in - kappa_out n_out| is large
 * enough to matter (dk tol >= EF_BLEND_MIN_TURN^2: the transition that deviates by tol
 * turns the tangent by about sqrt(dk tol), at least a corner's worth; and dk above 1e-4 of
 * the larger curvature, far above float32's rounding of the curvature vectors), the join is
 * blended exactly like a corner with arc ends (same construction, bound and trim search),
 * and flagged as a normal blend. The trims start from
 * sqrt(48 tol / dk) (where a transition's deviation, measured about dk L^2 / 53 on
 * tests/blend/test_prim.c's joins, reaches tol) instead of the line–line trim, bounded by max_in /
 * max_out and the arc cap. If no blend fits the outcome is ::EF_BLEND_STRAIGHT (the G1 pass-through
 * is safe), never ::EF_BLEND_STOP. Straight vertices between two lines, an arc continued by the
 * same circle and negligible jumps stay
 * ::EF_BLEND_STRAIGHT.
 */
#ifndef EF_BLEND_H
#define EF_BLEND_H

#include <stdint.h>
#include "evenfeed/path/ef_path.h"
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/table/ef_table.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Turns (rad) below this need no blend (::EF_BLEND_STRAIGHT). Default 1e-4 rad. */
#ifndef EF_BLEND_MIN_TURN
#define EF_BLEND_MIN_TURN 1e-4f
#endif

/** Turns (rad) above this are reversals (::EF_ERR_REVERSAL). Default 179 degrees. */
#ifndef EF_BLEND_MAX_TURN
#define EF_BLEND_MAX_TURN 3.1241393f
#endif

/** Blend flag: max_in or max_out limited the trim; the deviation is below the tolerance. */
#define EF_BLEND_CLAMPED 1u
/** Blend flag: the corner is straight (turn < EF_BLEND_MIN_TURN; for ef_blend_prims(), a
 *  tangent join that needs or fits no blend); no blend, trims 0. */
#define EF_BLEND_STRAIGHT 2u
/** Blend flag: the blend that fits is below float32 resolution; no blend, trims 0, the
 *  caller stops exactly at the vertex. */
#define EF_BLEND_STOP 4u
/** Blend flag: the table lookup clamped the configuration (never for turns up to
 *  EF_BLEND_MAX_TURN with the default table; kept for tables of smaller domain). */
#define EF_BLEND_TBL_CLAMPED 8u

/** A corner blend. On error everything is zero. */
typedef struct {
    ef_seg_t seg;    /**< the quintic (degree 5) from p_in to p_out; degree 0 when there
                          is no blend (EF_BLEND_STRAIGHT, EF_BLEND_STOP) */
    ef_vec3_t p_in;  /**< where the incoming straight part now ends (v - trim_in u_in) */
    ef_vec3_t p_out; /**< where the outgoing straight part now starts (v + trim_out u_out) */
    float trim_in;   /**< length cut from the end of the incoming line (0: none) */
    float trim_out;  /**< length cut from the start of the outgoing line */
    float dev;       /**< predicted deviation from the corner, L g (<= tol - q); 0 if no blend */
    float gain;      /**< g(turn): deviation per unit trim */
    float turn;      /**< turn angle theta (rad), in [0, EF_BLEND_MAX_TURN] */
    uint32_t flags;  /**< EF_BLEND_* */
} ef_blend_t;

/**
 * @brief Blend the corner between two straight moves. Constant instruction count for valid
 * input (the blend, straight and stop outcomes included).
 * @param g2      G2 quintic table (e.g. ef_tbl_g2_default)
 * @param v       the corner (programmed vertex), |v_i| <= EF_MAX_COORD
 * @param u_in    unit direction of the incoming line (| |u| - 1 | within EF_UNIT_TOL)
 * @param u_out   unit direction of the outgoing line
 * @param tol     the largest allowed deviation P from the corner, > 0, finite
 * @param max_in  longest trim allowed on the incoming line (e.g. half its length, so the
 *                blends at its two ends cannot overlap), > 0, finite
 * @param max_out longest trim allowed on the outgoing line, > 0, finite (trims are also
 *                never longer than EF_MAX_COORD, so FLT_MAX may stand for "no limit")
 * @param out     the blend
 * @retval EF_OK            out valid; see out->flags
 * @retval EF_ERR_ARG       NULL pointer, tol <= 0, max_in <= 0 or max_out <= 0
 * @retval EF_ERR_KIND      not a G2 quintic table
 * @retval EF_ERR_NONFINITE NaN/inf in v, u_in, u_out, tol, max_in or max_out, or |v_i| or
 *                          |u_i| above EF_MAX_COORD
 * @retval EF_ERR_TANGENT   u_in or u_out not of unit length (covers a zero-length move)
 * @retval EF_ERR_REVERSAL  turn above EF_BLEND_MAX_TURN: stop exactly at v
 */
int ef_blend_corner(const ef_table_t *g2, ef_vec3_t v, ef_vec3_t u_in, ef_vec3_t u_out, float tol,
                    float max_in, float max_out, ef_blend_t *out);

/** Samples of a smooth section's curve used to measure its deviation (ef_smooth.c). */
#ifndef EF_BLEND_DEV_SAMPLES
#define EF_BLEND_DEV_SAMPLES 16
#endif
/** Trials of the trim search in ef_blend_prims() (each a frame pair, an evening and the
 *  closed-form bound). */
#ifndef EF_BLEND_ITER
#define EF_BLEND_ITER 2
#endif

/** The turn at a vertex and the line–line blend's table DOFs there (ef_blend_vertex()). */
typedef struct {
    ef_vec3_t sum;   /**< u_in + u_out; its length is two_cos */
    float theta;     /**< turn angle (rad), in [0, EF_BLEND_MAX_TURN] */
    float phi;       /**< theta / 2 */
    float two_cos;   /**< 2 cos(phi) = |u_in + u_out|: the blend's chord per unit trim */
    float two_sin;   /**< 2 sin(phi) = |u_out - u_in| */
    float x1c;       /**< x1 per unit chord at (phi, -phi, 0, 0), symmetrized (table's) */
    float x2c;       /**< x2 per unit chord there, symmetrized */
    uint32_t tclamp; /**< EF_LOOKUP_CLAMP_* bits of the lookup */
} ef_blend_vertex_t;

/**
 * @brief The turn between two unit tangents at a vertex and the line–line blend's DOFs for
 * it (ef_table_lookup_g2_corner()), shared by ef_blend_corner() and ef_blend_prims(). The
 * turn comes from |u_in x u_out| and <u_in, u_out>, accurate at both ends of [0, pi].
 * Fixed instruction count.
 * @param g2 G2 quintic table
 * @param ui unit incoming tangent (not checked)
 * @param uo unit outgoing tangent (not checked)
 * @param vx out (undefined on error)
 * @retval EF_OK
 * @retval EF_ERR_REVERSAL the turn exceeds EF_BLEND_MAX_TURN (or is NaN)
 * @retval others          as ef_table_lookup_g2_corner()
 */
int ef_blend_vertex(const ef_table_t *g2, ef_vec3_t ui, ef_vec3_t uo, ef_blend_vertex_t *vx);

/**
 * @brief Blend the corner between two checked primitives (lines, arcs, helices). For two
 * lines this is ef_blend_corner() with the lines' directions; otherwise the construction of
 * "Corners with arc ends" above. Instruction count fixed per pair of kinds (fixed trial,
 * node and step counts; only keeping the best trial and the outcome differ: within 1 %).
 *
 * Details (firmware/src/blend/ef_blend_arc.c):
 * - both primitives are checked again (ef_prim_check(); its error codes are returned) and
 *   len_in / len_out must be their lengths to 1e-5 relative (else EF_ERR_ARG); then
 *   ef_blend_prims_valid() (the smoother's call) with ef_prim_check()'s lengths;
 * - vertex tangents turning by less than EF_BLEND_MIN_TURN: a tangent join (see the file
 *   comment) when the curvature vectors differ by dk with dk tol >= EF_BLEND_MIN_TURN^2 and
 *   dk > 1e-4 max(kappa_in, kappa_out): blended as below (first trim sqrt(tol / dk)),
 *   STRAIGHT if no trial fits (never STOP); otherwise outcome STRAIGHT;
 * - one trim L on both sides, at most max_in, max_out and, on an arc side,
 *   EF_ARC_PIECE_SWEEP of its sweep; a side whose own limit is within 2 % of L takes it;
 * - a trial is feasible if its closed-form deviation bound (both ways, see above) is within
 *   tol; the kept trial's stored control points must have end speeds within
 *   EF_SEG_END_SPEED_REL of their curve's length (this covers both Newton's residual and
 *   float32 rounding of a tiny blend far from the origin) and a chord of at least
 *   max(EF_MIN_CHORD, EF_MIN_CHORD_REL max|v_i|), else no blend;
 * - res->dev is that bound (tests/blend/test_prim.c measures the true deviation in double:
 *   at most 0.998 of it over 6000 random corners), res->gain the reference line–line
 *   blend's deviation per unit trim, EF_BLEND_CLAMPED when a limit, not the tolerance,
 *   bounded L; seg.norm is the configuration the DOFs were looked up for, the vertex
 *   tangents' corner (alpha = phi, beta = -phi, k0 = k1 = 0).
 * @param g2       G2 quintic table
 * @param start_in where the incoming primitive starts
 * @param in       incoming primitive (ends at the vertex)
 * @param len_in   its length (from ef_prim_check())
 * @param out      outgoing primitive (starts at the vertex, in->end)
 * @param len_out  its length
 * @param tol      largest allowed deviation P, > 0
 * @param max_in   longest trim allowed on the incoming primitive, in (0, len_in]
 * @param max_out  longest trim allowed on the outgoing primitive, in (0, len_out]
 * @param res      the blend (seg degree 5, p_in / p_out on the primitives, trims, dev
 *                 bounded, turn between the vertex tangents)
 * @retval EF_OK            res valid; see res->flags (STRAIGHT, STOP, CLAMPED)
 * @retval EF_ERR_ARG       NULL pointer, tol, max_in or max_out out of range
 * @retval EF_ERR_KIND      not a G2 quintic table
 * @retval EF_ERR_NONFINITE non-finite input
 * @retval EF_ERR_REVERSAL  the vertex tangents turn by more than EF_BLEND_MAX_TURN: stop
 *                          exactly at the vertex
 * @retval others           as ef_prim_check() and ef_table_lookup_g2()
 */
int ef_blend_prims(const ef_table_t *g2, ef_vec3_t start_in, const ef_prim_t *in, float len_in,
                   const ef_prim_t *out, float len_out, float tol, float max_in, float max_out,
                   ef_blend_t *res);

/**
 * @brief ef_blend_prims() for primitives the caller has validated: the same result, bit for
 * bit, without checking the primitives again (ef_prim_check(), about 0.5 k instructions per
 * arc). The smoother calls this on its hot path; it checked each primitive when it was
 * pushed and keeps the length ef_prim_check() gave.
 *
 * Precondition (not checked): ef_prim_check(start_in, in, &len_in) and
 * ef_prim_check(in->end, out, &len_out) returned EF_OK with exactly these lengths. Violating
 * it gives an unspecified blend, never a crash (every loop has a fixed count); the
 * arguments below are still checked.
 * @retval EF_OK            as ef_blend_prims()
 * @retval EF_ERR_ARG       NULL pointer; tol <= 0; max_in, max_out not in (0, len]
 * @retval EF_ERR_KIND      not a G2 quintic table
 * @retval EF_ERR_NONFINITE a non-finite length, tol or limit
 * @retval EF_ERR_REVERSAL  as ef_blend_prims()
 * @retval others           as ef_table_lookup_g2()
 */
int ef_blend_prims_valid(const ef_table_t *g2, ef_vec3_t start_in, const ef_prim_t *in,
                         float len_in, const ef_prim_t *out, float len_out, float tol, float max_in,
                         float max_out, ef_blend_t *res);

/**
 * @brief One piece of a checked arc/helix primitive, from arc length s0 to s1 along it, as a
 * G2 quintic with the arc's exact end data (position, tangent, curvature vector) and the
 * arc-length choice of DOFs, x1 = s1 - s0, x2 = 0: the end derivatives are those of the arc
 * parametrized by t = (s - s0) / (s1 - s0), so the end speeds equal the piece's length and
 * the quintic is that parametrization's two-point Hermite interpolant (order 3 at each
 * end). Constant instruction count (no table lookup, no sampling; ef_move_measure() is most
 * of it), except for the last piece of an arc whose end lies off its circle
 * (ef_prim_end_gap(), up to the radius tolerance) by more than 2.5e-4 of the piece: that
 * one is the table's quintic between the same end frames, evened by ef_seg_g2_even(), its
 * deviation sampled at 64 points (about 6.5 times the cost).
 * @param g2     G2 quintic table (for the table route above)
 * @param start  where the primitive starts
 * @param pr     the arc primitive
 * @param s0,s1  0 <= s0 < s1 <= its length; the sweep of the piece must not exceed
 *               ::EF_ARC_PIECE_SWEEP (plus rounding)
 * @param m      out: b, degree 5, kind EF_MOVE_ARC, dev, tag, feed; length and kappa_max
 *               via ef_move_measure(); planner fields zero; flags 0. dev: the closed-form
 *               bound of the Hermite interpolant's error, r sigma^6 / 46080 (sigma the
 *               piece's sweep, r the radius; the helix's axial part is reproduced exactly),
 *               plus 2 ulp of the arc's angle at s1 times r (the float32 frames) and
 *               4 eps of the ends' largest coordinate (control point rounding),
 *               plus the end's gap on the last piece;
 *               tests/blend/test_prim.c finds the true deviation (dense sampling in double)
 *               at most 0.97 of it (1500 pieces up to full sweep, helices included); at
 *               full sweep the bound is 1.04 x the true maximum (3.26e-4 r, 3.15e-4 r).
 *               The table route: the sampled deviation from the circle plus the gap;
 *               flags EF_MOVE_CLAMPED where the table clamped. On error m is all
 *               zero. The primitive is checked again (ef_prim_check(); its codes are
 *               returned).
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL pointer, not an arc, s0/s1 out of range or piece too long
 * @retval EF_ERR_KIND not a G2 quintic table
 * @retval EF_ERR_DOMAIN the table route's piece cannot have end speeds equal to its length
 *                     (ef_seg_g2_even(): end data with no such quintic)
 * @retval others      as ef_prim_check() and ef_move_measure()
 */
int ef_blend_arc_piece(const ef_table_t *g2, ef_vec3_t start, const ef_prim_t *pr, float s0,
                       float s1, ef_move_t *m);

/** Longest sweep (rad) of one arc piece. Callers split arcs into ceil(|sweep| / this) pieces
 *  or more; tests/blend/test_prim.c measures the deviation this gives. */
#ifndef EF_ARC_PIECE_SWEEP
#define EF_ARC_PIECE_SWEEP 1.5707964f
#endif

#ifdef __cplusplus
}
#endif

#endif /* EF_BLEND_H */
