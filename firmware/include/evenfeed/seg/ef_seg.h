/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_seg.h
 * @brief End data in, Bézier segment out: G1 cubic and G2 quintic through a DOF table.
 *
 * Control points (domain.md): with x1 the end "speeds" and x2 the tangential accelerations
 * (program units, i.e. table value x chord),
 * - cubic:   b1 = b0 + x1_0 t0 / 3,  b2 = b3 - x1_1 t1 / 3;
 * - quintic: b1 = b0 + f'(0)/5, b2 = 2 b1 - b0 + f''(0)/20, b4 = b5 - f'(1)/5,
 *            b3 = 2 b4 - b5 + f''(1)/20, with f' = x1 t and f'' = x2 t + kappa x1^2 n.
 *
 * On any error the output segment has degree 0 and no control points (all zero), so
 * nothing built from bad data can reach a drive.
 */
#ifndef EF_SEG_H
#define EF_SEG_H

#include <stdint.h>
#include "evenfeed/geom/ef_endpoint.h"
#include "evenfeed/table/ef_table.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Segment flag: the configuration was outside the table domain and the lookup clamped it.
 *  The segment still interpolates the end data exactly (positions, tangents, and for G2
 *  curvatures); only its DOFs are not the optimum for this configuration. */
#define EF_SEG_CLAMPED 1u
/** A Bézier segment of degree 3 or 5. */
typedef struct {
    ef_vec3_t b[6]; /**< control points b[0..degree] */
    uint8_t degree; /**< 3, 5, or 0 when invalid */
    uint8_t ndof;   /**< 2 (G1) or 4 (G2) */
    uint32_t flags; /**< EF_SEG_CLAMPED */
    uint32_t clamp; /**< EF_LOOKUP_CLAMP_* bits from the lookup */
    float dof[4];   /**< x1_0, x1_1 (G1) or x1_0, x2_0, x1_1, x2_1 (G2), program units */
    ef_norm_t norm; /**< the normalized configuration the DOFs were looked up for */
} ef_seg_t;

/**
 * @brief G1 cubic through the table, any end data in 3-D. Constant instruction count for
 * valid input. For data in a plane z = const, ef_seg_g1_cubic_xy() builds it at about
 * a third of the count.
 * @param tbl   G1 cubic table
 * @param e0,e1 end data (p, t used)
 * @param out   segment
 * @retval EF_OK             out valid (check out->flags for EF_SEG_CLAMPED)
 * @retval EF_ERR_ARG        NULL pointer, or a table without data
 * @retval EF_ERR_KIND       not a G1 cubic table
 * @retval EF_ERR_NONFINITE, EF_ERR_TANGENT, EF_ERR_DEGENERATE  as ef_normalize()
 */
int ef_seg_g1_cubic(const ef_table_t *tbl, const ef_endpoint_t *e0, const ef_endpoint_t *e1,
                    ef_seg_t *out);

/** A planar G1 cubic, the output of ef_seg_g1_cubic_xy(): what a segment in a plane
 *  z = const needs and no more (ef_seg_xy_expand() gives the general form). */
typedef struct {
    float x[4], y[4];  /**< control points b0..b3 */
    float z;           /**< the plane (e0->p.z) */
    float dof[2];      /**< x1_0, x1_1, program units */
    float alpha, beta; /**< the configuration looked up (ef_norm_t's alpha and beta) */
    uint32_t flags;    /**< EF_SEG_CLAMPED */
    uint32_t clamp;    /**< EF_LOOKUP_CLAMP_* bits from the lookup */
} ef_seg_xy_t;

/**
 * @brief G1 cubic for end data in a plane z = const: the XY fast path of ef_seg_g1_cubic(),
 * with a planar output. Constant instruction count for valid input.
 *
 * Reads p.x, p.y, t.x, t.y of both ends and e0->p.z only: e1->p.z is taken as e0->p.z and
 * t.z as 0 (the caller knows its move lies in an XY plane; nothing here tests it). It
 * accepts and refuses exactly what ef_seg_g1_cubic() does on such data, with the same error
 * codes, and the same flags and clamp bits unless an angle lies within its rounding of a
 * partial table's edge (a fold table never clamps). Its angles come from the chord and tangents as
 * given, not from unit vectors, by an arc tangent of its own (0, pi/2 and pi exact): within 1e-6
 * rad of ef_seg_g1_cubic()'s (4.8e-7 measured). The DOFs are the table's at those angles, so they
 * are not held to the 3-D path's: near a reversal the table's slope turns an ulp of angle into 1e-5
 * of the chord, and at an exact reversal (both tangents against the chord) the two mirror-image
 * optima have swapped DOFs and either may be taken. test_fw seg_xy and bench_ct g1p check all of it
 * (tests/bench/ct_cases.h: ct_xy_diff()).
 * @param tbl   G1 cubic table
 * @param e0,e1 end data (p.x, p.y, t.x, t.y of both; p.z of e0)
 * @param out   planar segment, in the plane z = e0->p.z
 * @retval EF_OK             out valid (check out->flags for EF_SEG_CLAMPED)
 * @retval EF_ERR_ARG        NULL pointer, or a table without data
 * @retval EF_ERR_KIND       not a G1 cubic table
 * @retval EF_ERR_NONFINITE  NaN/inf in a read coordinate or tangent component, or a
 *                           coordinate beyond EF_MAX_COORD
 * @retval EF_ERR_TANGENT    a tangent (t.x, t.y) not unit within EF_UNIT_TOL
 * @retval EF_ERR_DEGENERATE chord shorter than ef_normalize() accepts
 */
int ef_seg_g1_cubic_xy(const ef_table_t *tbl, const ef_endpoint_t *e0, const ef_endpoint_t *e1,
                       ef_seg_xy_t *out);

/**
 * @brief The general form (ef_seg_t) of a planar segment, for code that takes segments of
 * any kind: the control points in 3-D, degree 3, the DOFs, flags and clamp bits, and a norm
 * with alpha and beta as looked up, the chord |b3 - b0| and its direction, and the unit
 * tangents along the handles (b1 - b0, b3 - b2). Not on the constant-time path.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer (out zero when given)
 */
int ef_seg_xy_expand(const ef_seg_xy_t *xy, ef_seg_t *out);

/**
 * @brief G2 quintic through the table. Constant instruction count for valid input.
 * @param tbl   G2 quintic table
 * @param e0,e1 end data (p, t, n, kappa used)
 * @param out   segment
 * @retval EF_OK             out valid (check out->flags for EF_SEG_CLAMPED)
 * @retval EF_ERR_ARG        NULL pointer
 * @retval EF_ERR_KIND       not a G2 quintic table
 * @retval EF_ERR_NONFINITE, EF_ERR_TANGENT, EF_ERR_NORMAL, EF_ERR_DEGENERATE, EF_ERR_DOMAIN
 *         as ef_normalize()
 */
int ef_seg_g2_quintic(const ef_table_t *tbl, const ef_endpoint_t *e0, const ef_endpoint_t *e1,
                      ef_seg_t *out);

/**
 * @brief Build the segment from explicit DOFs (program units), no table. Used by the host's
 * reference optimizer output path and by tests.
 * @param e0,e1  end data (validated as for the table paths)
 * @param degree 3 (dof = x1_0, x1_1) or 5 (dof = x1_0, x2_0, x1_1, x2_1)
 * @param dof    DOFs; x1 must be > 0 and finite
 * @param out    segment (norm filled, flags 0)
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL pointer, degree not 3 or 5, x1 <= 0
 * @retval EF_ERR_NONFINITE  non-finite DOF, or as ef_normalize()
 * @retval EF_ERR_TANGENT, EF_ERR_NORMAL, EF_ERR_DEGENERATE, EF_ERR_DOMAIN  as ef_normalize()
 */
int ef_seg_from_dofs(const ef_endpoint_t *e0, const ef_endpoint_t *e1, int degree, const float *dof,
                     ef_seg_t *out);

/** Samples (intervals) ef_seg_speed_stats() takes of |f'(tau)|. */
#ifndef EF_SEG_SPEED_SAMPLES
#define EF_SEG_SPEED_SAMPLES 16
#endif
/** Newton steps ef_seg_g2_even() takes per candidate (ef_seg_even_speed()'s, on the 16-node
 *  rule of ef_seg_length()) from the table curve's length: the error squares with each
 *  step; the 16-node length of the built result is then the check (ef_seg_g2_even()). */
#ifndef EF_SEG_EVEN_NEWTON
#define EF_SEG_EVEN_NEWTON 2
#endif

/** Gauss-Legendre nodes of ef_seg_even_speed() and ef_seg_end_err(): 8 integrate the
 *  speeds of blends and sections well within ::EF_SEG_END_SPEED_REL; 6 did not
 *  (tests/blend/test_prim.c then saw end speeds 0.7 % off their length pass); 16
 *  (ef_seg_length()'s) cost twice as much. */
#define EF_SEG_EVEN_GL 8

/**
 * @brief End speed s = x10 = x11 of a G2 quintic whose end speeds equal its own length L(s),
 * by Newton steps on g(s) = L(s) - s, no control points built.
 *
 * The hodograph of the G2 quintic between end data (p0, t0, kappa0 n0) and (p1, t1,
 * kappa1 n1) with DOFs (x10, x20, x11, x21) (ef_seg_from_dofs()'s control points) is
 *
 *     f'(t) = B2 D + (x10 u0 + x20 w0 / 4) t0 + x10^2 w0 (kappa0 / 4) n0
 *                  + (x11 u1 + x21 w1 / 4) t1 + x11^2 w1 (kappa1 / 4) n1,
 *
 * D = 5 (p1 - p0), with the degree-4 Bernstein combinations u0 = B0 + B1 - 2 B2,
 * w0 = B1 - B2, u1 = B3 + B4 - 2 B2, w1 = B2 - B3: five fixed vectors weighted by scalars
 * that depend only on t and the DOFs, so L(s) at ::EF_SEG_EVEN_GL nodes is a square root of
 * a quartic in s per node. Why end speeds equal to L: ef_seg_g2_even(). Shared by
 * ef_seg_g2_even() and the arc blends (ef_blend_prims()); constant instruction count.
 * @param v     the five vectors D, t0, kappa0 n0 / 4, t1, kappa1 n1 / 4
 * @param s0    first guess (> 0)
 * @param x20   tangential DOF at the start
 * @param x21   tangential DOF at the end
 * @param steps Newton steps (the error squares with each from a guess within a few %)
 * @return s; a step that would make s non-positive is not taken (NaN in, NaN out)
 */
float ef_seg_even_speed(const ef_vec3_t *v, float s0, float x20, float x21, int steps);

/**
 * @brief Largest | |f'| / L - 1 | at the two ends of the quintic b, L its length by the
 * ::EF_SEG_EVEN_GL-node rule of ef_seg_even_speed(): whether stored control points kept the
 * end speeds that rule set (float32 rounding of a tiny curve far from the origin moves them).
 * @param b the 6 control points
 */
float ef_seg_end_err(const ef_vec3_t *b);

/**
 * @brief Arc length of a quintic, 16-node Gauss–Legendre on |f'| (6 nodes were off by up to
 * 0.6 % on lopsided blends whose speed varies by tens of per cent inside).
 * @param b    the 6 control points
 * @param sym  nonzero when |f'(tau)| = |f'(1 - tau)| (a symmetric corner blend): half the
 *             evaluations, the same result
 */
float ef_seg_length(const ef_vec3_t *b, int sym);

/**
 * @brief Arc length and evenness of a quintic's parametric speed.
 * @param b        the 6 control points
 * @param len      out: arc length L (16-node Gauss–Legendre)
 * @param dev_ends out (may be NULL): max(| |f'(0)| / L - 1 |, | |f'(1)| / L - 1 |)
 * @return the largest | |f'(tau)| / L - 1 | at tau = i / EF_SEG_SPEED_SAMPLES (ends
 *         included): how far uniform stepping of tau strays from constant feed
 */
float ef_seg_speed_stats(const ef_vec3_t *b, float *len, float *dev_ends);

/** Largest difference of a curve's end speeds |f'(0)|, |f'(1)| from its arc length L,
 *  relative to L, that ef_seg_g2_even() keeps. Uniform stepping of tau (the drives' segment
 *  mode) moves at v |f'(tau)| / L, so at a junction the feed steps by v times the difference
 *  of the two curves' ratios within one period: at 100 mm/s and 1 ms, 2e-3 is 200 mm/s^2. */
#ifndef EF_SEG_END_SPEED_REL
#define EF_SEG_END_SPEED_REL 2e-3f
#endif

/**
 * @brief The end speed difference (as ef_seg_g2_even()'s dev_ends) a curve between p0 and p1
 * may show and still count as evened: ::EF_SEG_END_SPEED_REL plus what float32 rounding of
 * control points at the coordinates' magnitude does to |f'(0)| = 5 |b1 - b0| (40 ulp of
 * the largest coordinate per unit chord; a tiny curve far from the origin). Above it a
 * curve's ends were not evened: no quintic with those end data has end speeds equal to its
 * length (ef_seg_g2_even()).
 */
static inline float ef_seg_end_allow(ef_vec3_t p0, ef_vec3_t p1)
{
    float big = ef_maxf(ef_maxf(ef_fabsf(p0.x), ef_fabsf(p0.y)), ef_fabsf(p0.z));
    big = ef_maxf(big, ef_maxf(ef_maxf(ef_fabsf(p1.x), ef_fabsf(p1.y)), ef_fabsf(p1.z)));
    float chord = ef_v3_norm(ef_v3_sub(p1, p0));
    return EF_SEG_END_SPEED_REL + 40.0f * 1.1920929e-7f * big / ef_maxf(chord, 1e-30f);
}

/** ef_seg_g2_even() results: which DOFs the segment has. */
enum {
    EF_SEG_EVEN_TABLE = 0, /**< the table's, unchanged */
    EF_SEG_EVEN_ENDS = 1,  /**< the table's x2, x1 = L at both ends */
    EF_SEG_EVEN_ARC = 2,   /**< the arc-length choice: x1 = L, x2 = 0 */
};

/**
 * @brief Give a G2 quintic end speeds equal to its arc length and, of the DOFs that do, those
 * with the most even parametric speed. Constant instruction count for valid input.
 *
 * Three candidates, each measured by ef_seg_speed_stats(): the table's DOFs (only while its
 * end speeds are within ::EF_SEG_END_SPEED_REL of L); the table's x2 with x1 = L; and the
 * arc-length choice x1 = L, x2 = 0 (f' = L t, f'' = L^2 kappa n: the end data of the
 * curve's arc-length parametrization scaled to [0, 1]). The smallest largest deviation of
 * |f'| / L from 1 wins. Why:
 * - the table's optimum is interpolated on a grid; on short near-circular pieces (CAM
 *   sections, arc pieces) its x2 is off just enough that |f'| / L ripples by +-5e-4,
 *   which makes |f'''| / L^3 (the jerk of uniform stepping) 5-7 times the curve's own
 *   third derivative (a circle of 0.86 mm sections: 0.07 against 0.01 / mm^2); there the
 *   arc-length choice is nearly the arc-length parametrization itself;
 * - a lopsided corner (one side trimmed far more than the other, a tight arc on one side)
 *   or a tiny arc piece can have table end speeds far from L (0.4, 0.87 and 0.94 were seen
 *   by the fuzzer: a step in the feed at each junction);
 * - where the curvature changes much along the curve (a corner between lines) the table's
 *   optimum is the most even and is kept.
 * x1 = L is a fixed point (L moves with x1): ::EF_SEG_EVEN_NEWTON Newton steps as
 * ef_seg_even_speed()'s, on the 16-node rule, from the table curve's length; then the
 * candidate is built once and measured; one whose end speeds are then not within
 * ::EF_SEG_END_SPEED_REL of its 16-node length is not taken. Some end data admit no such
 * curve (a curvature so large against the chord that L(x1) > x1 for every x1): then
 * neither candidate is taken, and dev_ends says how far the table's ends are from L.
 * flags and clamp stay as the lookup set them.
 *
 * @param e0,e1    the end data seg was built for
 * @param seg      a valid G2 quintic (degree 5); replaced in place by the winner
 * @param dev      out (may be NULL): the winner's largest | |f'| / L - 1 |
 * @param dev_ends out (may be NULL): the winner's end speed difference (ef_seg_speed_stats())
 * @return which DOFs seg has now: EF_SEG_EVEN_TABLE (also for NULL pointers, a seg that is
 *         not a quintic, or when no candidate could be built), EF_SEG_EVEN_ENDS or
 *         EF_SEG_EVEN_ARC
 */
int ef_seg_g2_even(const ef_endpoint_t *e0, const ef_endpoint_t *e1, ef_seg_t *seg, float *dev,
                   float *dev_ends);

#ifdef __cplusplus
}
#endif

#endif /* EF_SEG_H */
