/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_endpoint.h
 * @brief End data of a segment and its normalization into table coordinates.
 *
 * A segment runs from endpoint e0 to endpoint e1. Normalization maps it (translation,
 * rotation, uniform scale by the chord s = |p1 - p0|) onto the configuration from (0,0) to
 * (1,0) that the tables are indexed by:
 *
 * - G1: alpha, beta = signed angles of t0, t1 to the chord.
 * - G2: additionally k0, k1 = signed curvatures times the chord.
 *
 * Planar data in the z = 0 plane gives the usual signed angles (counter-clockwise
 * positive, seen from +z). For 3-D data the reference plane contains the chord and is
 * chosen so both tangents lean into it as far as possible: alpha and beta are then the
 * true angles between each tangent and the chord, signed by which side of the chord
 * each tangent points to; ef_norm_twist() (0 for planar data) says how far the tangents are
 * from coplanar. Curvatures are projected onto the plane. The tables are planar, so the
 * twist is ignored by the lookup; docs/math.md gives what that costs in C.
 */
#ifndef EF_ENDPOINT_H
#define EF_ENDPOINT_H

#include "evenfeed/core/ef_math.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Geometric data at one end of a segment. */
typedef struct {
    ef_vec3_t p; /**< position (program units) */
    ef_vec3_t t; /**< unit tangent, pointing in the direction of travel */
    ef_vec3_t n; /**< unit principal normal, perpendicular to t (G2 only). May be the zero
                      vector when kappa == 0. */
    float kappa; /**< curvature (1/program units) along n; either sign (G2 only) */
} ef_endpoint_t;

/** A segment's normalized configuration and the frame that maps it back. */
typedef struct {
    float alpha;  /**< signed angle of t0 to the chord (rad), in [-pi, pi] */
    float beta;   /**< signed angle of t1 to the chord (rad), in [-pi, pi] */
    float k0;     /**< signed curvature at e0 times chord (G2) */
    float k1;     /**< signed curvature at e1 times chord (G2) */
    float chord;  /**< s = |p1 - p0| */
    ef_vec3_t e1; /**< unit chord direction */
    ef_vec3_t t0; /**< unit tangent at e0 (the input tangent scaled to length 1) */
    ef_vec3_t t1; /**< unit tangent at e1 */
} ef_norm_t;

/**
 * @brief Validate end data. G1 checks p, t; G2 also n and kappa.
 * @param e    endpoint
 * @param g2   nonzero to check the curvature data too
 * @retval EF_OK
 * @retval EF_ERR_ARG       e is NULL
 * @retval EF_ERR_NONFINITE NaN/inf anywhere in the checked fields, or |p| > EF_MAX_COORD
 * @retval EF_ERR_TANGENT   | |t| - 1 | > EF_UNIT_TOL (covers a zero tangent)
 * @retval EF_ERR_NORMAL    kappa != 0 with n not unit, or n not perpendicular to t
 */
int ef_endpoint_check(const ef_endpoint_t *e, int g2);

/**
 * @brief Normalize a segment's end data (validates both ends first).
 * @param e0,e1 end data
 * @param g2    nonzero for G2 data (curvatures are checked and normalized)
 * @param out   normalized configuration
 * @retval EF_OK
 * @retval EF_ERR_ARG, EF_ERR_NONFINITE, EF_ERR_TANGENT, EF_ERR_NORMAL  as ef_endpoint_check()
 * @retval EF_ERR_DEGENERATE chord < max(EF_MIN_CHORD, EF_MIN_CHORD_REL * max|coordinate|)
 * @retval EF_ERR_DOMAIN     |kappa| * chord > EF_MAX_NORM_CURVATURE (G2)
 */
int ef_normalize(const ef_endpoint_t *e0, const ef_endpoint_t *e1, int g2, ef_norm_t *out);

/**
 * @brief Twist of a normalized segment: the angle (rad, [0, pi/2]) between the planes
 * (chord, t0) and (chord, t1); 0 for planar data. Diagnostic, kept off the constant-time
 * path (the tables do not use it).
 * @param nm    the result of ef_normalize() for e0, e1
 * @return the twist; 0 for NULL arguments
 */
float ef_norm_twist(const ef_norm_t *nm, const ef_endpoint_t *e0, const ef_endpoint_t *e1);

#ifdef __cplusplus
}
#endif

#endif /* EF_ENDPOINT_H */
