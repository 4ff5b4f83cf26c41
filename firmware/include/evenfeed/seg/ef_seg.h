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

#ifdef __cplusplus
}
#endif

#endif /* EF_SEG_H */
