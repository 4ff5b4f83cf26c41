/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_bezier.h
 * @brief Bézier curves of degree 1..::EF_BEZIER_MAX_DEGREE in 3-D (float32): evaluation with
 * derivatives, degree elevation, and the constant-speed functional.
 */
#ifndef EF_BEZIER_H
#define EF_BEZIER_H

#include "evenfeed/core/ef_config.h"
#include "evenfeed/core/ef_math.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * @brief Position and derivatives of a Bézier curve at parameter t.
 * @param b      degree+1 control points
 * @param degree 1..EF_BEZIER_MAX_DEGREE
 * @param t      parameter, normally in [0,1] (extrapolates outside)
 * @param nder   number of derivatives wanted, 0..degree; out[k] receives the k-th derivative
 * @param out    nder+1 vectors
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer, degree or nder out of range
 */
int ef_bezier_eval(const ef_vec3_t *b, int degree, float t, int nder, ef_vec3_t *out);

/**
 * @brief Degree elevation by one: the same curve with degree+1 control points.
 * @param b      degree+1 control points
 * @param degree 1..EF_BEZIER_MAX_DEGREE-1
 * @param out    degree+2 control points (must not alias b)
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer, aliasing, or degree out of range
 */
int ef_bezier_elevate(const ef_vec3_t *b, int degree, ef_vec3_t *out);

/**
 * @brief The constant-speed functional C(f) = sqrt( ∫_0^1 <f',f''>^2 |f'|^2 dt ).
 *
 * Gauss–Legendre quadrature with ceil((6·degree−7)/2) nodes, which integrates the
 * degree-(6·degree−8) polynomial integrand exactly; the only error is float32 rounding
 * (see docs/math.md for measured figures).
 * @param b      degree+1 control points
 * @param degree 1..EF_BEZIER_MAX_DEGREE
 * @param out    C(f)
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer or degree out of range
 */
int ef_bezier_functional(const ef_vec3_t *b, int degree, float *out);

/**
 * @brief A scalar Bezier polynomial at t by de Casteljau's algorithm: one axis's control
 * values (an auxiliary axis's ef_move_t::ab, or their differences for its derivatives).
 * @param c      degree+1 control values
 * @param degree 0..EF_BEZIER_MAX_DEGREE (clamped to that range)
 */
static inline float ef_bezier_eval_scalar(const float *c, int degree, float t)
{
    float w[EF_BEZIER_MAX_DEGREE + 1];
    int n = degree < 0 ? 0 : (degree > EF_BEZIER_MAX_DEGREE ? EF_BEZIER_MAX_DEGREE : degree);
    for (int i = 0; i <= n; i++)
        w[i] = c[i];
    for (int r = 1; r <= n; r++)
        for (int i = 0; i + r <= n; i++)
            w[i] += t * (w[i + 1] - w[i]);
    return w[0];
}

/**
 * @brief Point of a degree-4 Bezier curve (a quintic's hodograph) at t: the control points
 * weighted by the Bernstein polynomials (all positive, so no cancellation: as accurate as de
 * Casteljau's algorithm, at a fraction of its instructions).
 */
static inline ef_vec3_t ef_bezier_b4(const ef_vec3_t *p, float t)
{
    float u = 1.0f - t, t2 = t * t, u2 = u * u;
    ef_vec3_t r = ef_v3_scale(p[0], u2 * u2);
    r = ef_v3_axpy(r, 4.0f * u2 * u * t, p[1]);
    r = ef_v3_axpy(r, 6.0f * u2 * t2, p[2]);
    r = ef_v3_axpy(r, 4.0f * u * t2 * t, p[3]);
    return ef_v3_axpy(r, t2 * t2, p[4]);
}

/**
 * @brief Arc length of a curve from its degree-4 hodograph h (a quintic's, or a cubic's
 * elevated): Gauss–Legendre with 16 nodes on [0, 1], exact for polynomials up to degree 31.
 * |f'| of evenfeed's curves is smooth, so the rule's error is far below float32 rounding
 * except where |f'| dips deep (hairpin blends; 6 nodes were off by up to 0.6 % on lopsided
 * blends).
 * @param h    the 5 hodograph control points
 * @param sym  nonzero when |f'(t)| = |f'(1 - t)| (a symmetric corner blend): the 8 nodes
 *             below 1/2, doubled: half the evaluations, the same sum
 */
float ef_bezier_h4_length(const ef_vec3_t *h, int sym);

/**
 * @brief The same rule on each half, [0, 1/2] and [1/2, 1] (32 nodes): for a move's length,
 * which the corrected interpolator follows to the end, so its error comes out as a step at
 * the next junction. Where |f'| dips deep within the curve (a looping blend of a huge
 * tolerance: |f'| / L from 0.41 to 1.36) the single rule was off by 2e-4 of L, a 0.37 um
 * jump at 3.7 mm/s, twice the jerk limit (tests/fuzz seed ok-uneven-blend-length); the
 * halves were off by 1e-7 there.
 * @param h  the 5 hodograph control points
 */
float ef_bezier_h4_length_halves(const ef_vec3_t *h);

#ifdef __cplusplus
}
#endif

#endif /* EF_BEZIER_H */
