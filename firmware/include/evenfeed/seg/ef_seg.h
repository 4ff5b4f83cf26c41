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
 * @brief G1 cubic through the table. Constant instruction count for valid input.
 * @param tbl   G1 cubic table
 * @param e0,e1 end data (p, t used)
 * @param out   segment
 * @retval EF_OK             out valid (check out->flags for EF_SEG_CLAMPED)
 * @retval EF_ERR_ARG        NULL pointer
 * @retval EF_ERR_KIND       not a G1 cubic table
 * @retval EF_ERR_NONFINITE, EF_ERR_TANGENT, EF_ERR_DEGENERATE  as ef_normalize()
 */
int ef_seg_g1_cubic(const ef_table_t *tbl, const ef_endpoint_t *e0, const ef_endpoint_t *e1,
                    ef_seg_t *out);

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
/** Passes of the arc-length choice in ef_seg_g2_even() (its x1 is its own length, which
 *  moves with x1: each pass cuts the difference by about an order of magnitude). */
#ifndef EF_SEG_EVEN_ITER
#define EF_SEG_EVEN_ITER 3
#endif

/**
 * @brief Arc length and evenness of a quintic's parametric speed.
 * @param b        the 6 control points
 * @param len      out: arc length L (16-node Gauss–Legendre)
 * @param dev_ends out (may be NULL): max(| |f'(0)| / L - 1 |, | |f'(1)| / L - 1 |)
 * @return the largest | |f'(tau)| / L - 1 | at tau = i / EF_SEG_SPEED_SAMPLES (ends
 *         included): how far uniform stepping of tau strays from constant feed
 */
float ef_seg_speed_stats(const ef_vec3_t *b, float *len, float *dev_ends);

/**
 * @brief Replace a G2 quintic by the arc-length choice of its DOFs where that moves at a more
 * even parametric speed. Constant instruction count for valid input.
 *
 * The arc-length choice is x1 = L, x2 = 0 at both ends (f' = L t, f'' = L^2 kappa n): the
 * end data of the curve's arc-length parametrization scaled to [0, 1], so on a piece whose
 * curvature changes little along it (CAM sections, arc pieces) the quintic is nearly that
 * parametrization itself. The table's optimum is interpolated on a grid, and on such short
 * near-circular pieces its x2 is off just enough that |f'| / L ripples by +-5e-4, which makes
 * |f'''| / L^3 (the jerk of uniform stepping, the drives' segment mode) 5-7 times the
 * curve's own third derivative (measured on a circle of 0.86 mm sections: 0.07 against 0.01
 * / mm^2). Where the curvature changes much (a corner blend between lines) the table's
 * optimum is the more even one and is kept. The winner is the one with the smaller
 * ef_seg_speed_stats(); both are always computed. flags and clamp stay as the lookup set them.
 *
 * @param e0,e1  the end data seg was built for
 * @param seg    a valid G2 quintic (degree 5); replaced in place when the choice wins
 * @param dev    out (may be NULL): ef_seg_speed_stats() of the result
 * @retval 1  the arc-length choice replaced seg
 * @retval 0  seg kept (also: seg not a quintic, NULL pointers, or the choice not buildable)
 */
int ef_seg_g2_even(const ef_endpoint_t *e0, const ef_endpoint_t *e1, ef_seg_t *seg, float *dev);

#ifdef __cplusplus
}
#endif

#endif /* EF_SEG_H */
