/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_ref.h
 * @brief CPU reference (double precision): control points from DOFs, the constant-speed
 * functional with its gradient, and a bounded, multi-start, joint optimizer.
 *
 * This is the independent optimum that tables are built from and verified against.
 * DOF vectors by kind (program units):
 * - EF_REF_G1_CUBIC:   (x1_0, x1_1)
 * - EF_REF_G2_QUINTIC: (x1_0, x2_0, x1_1, x2_1)
 * - EF_REF_G1_QUARTIC: (x1_0, x1_1, b2.x, b2.y, b2.z), b2 the inner control point
 * Bounds, per unit chord s: x1 in [x1_min s, x1_max s], |x2| <= x2_max s, and the quartic's
 * inner point within x2_max s of the chord midpoint in each coordinate.
 */
#ifndef EF_REF_H
#define EF_REF_H

#include "evenfeed/geom/ef_endpoint.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    double x, y, z;
} ef_dvec3_t;

/** End data in double precision (same meaning as the firmware's ef_endpoint_t). */
typedef struct {
    ef_dvec3_t p, t, n;
    double kappa;
} ef_dend_t;

typedef enum { EF_REF_G1_CUBIC = 1, EF_REF_G2_QUINTIC = 2, EF_REF_G1_QUARTIC = 3 } ef_ref_kind_t;

#define EF_REF_MAX_DOF    5
#define EF_REF_MAX_DEGREE 7

/** The same end data in the firmware's float32 form (what a drive would be given). */
ef_endpoint_t ef_ref_end_to_fw(const ef_dend_t *e);

/** Number of DOFs of a kind (2, 4, 5), or 0 for an unknown kind. */
int ef_ref_ndof(ef_ref_kind_t kind);
/** Bézier degree of a kind (3, 5, 4), or 0 for an unknown kind. */
int ef_ref_degree(ef_ref_kind_t kind);

/**
 * @brief The normalized configuration: p0 = (0,0,0), p1 = (1,0,0),
 * t_i = (cos, sin, 0) of alpha / beta, n_i = t_i rotated +90 degrees, kappa_i = k0 / k1.
 */
void ef_ref_config(double alpha, double beta, double k0, double k1, ef_dend_t *e0, ef_dend_t *e1);

/**
 * @brief Control points b[0..degree] from end data and DOFs (no validation beyond NULLs).
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pointer or unknown kind
 */
int ef_ref_ctrl(ef_ref_kind_t kind, const ef_dend_t *e0, const ef_dend_t *e1, const double *dof,
                ef_dvec3_t *b);

/** C(f) of a Bézier curve of degree 1..EF_REF_MAX_DEGREE by exact Gauss–Legendre quadrature;
 *  NaN for a bad degree or NULL. */
double ef_ref_functional(const ef_dvec3_t *b, int degree);

/**
 * @brief The objective C^2 as a function of the DOFs, and optionally its exact gradient.
 * @param grad ndof values, or NULL
 * @return C^2 (NaN on bad arguments)
 */
double ef_ref_objective(ef_ref_kind_t kind, const ef_dend_t *e0, const ef_dend_t *e1,
                        const double *dof, double *grad);

/**
 * @brief C^2 with its gradient and its exact Hessian with respect to the DOFs: the Newton
 * model the optimizer uses. Near an optimum x*, C^2(x* + d) - C^2(x*) is about d^T H d / 2
 * for DOF errors d along free DOFs.
 * @param grad ndof values, or NULL
 * @param hess ndof x ndof values, row-major, or NULL
 * @return C^2 (NaN on bad arguments)
 */
double ef_ref_objective_hess(ef_ref_kind_t kind, const ef_dend_t *e0, const ef_dend_t *e1,
                             const double *dof, double *grad, double *hess);

/** Optimizer settings. ef_ref_opts_default() gives the documented defaults. */
typedef struct {
    double x1_min;      /**< x1 lower bound per unit chord (default 0.1, as the thesis) */
    double x1_max;      /**< x1 upper bound per unit chord (default 10) */
    double x2_max;      /**< |x2| bound per unit chord (default 100) */
    int max_iter;       /**< iterations per start (default 200) */
    double tol;         /**< a start stops when the projected gradient's norm is below
                             tol * max(1, C^2), or when the predicted gain falls below 1e-10 C^2
                             (default 1e-12; docs/optimizer.md) */
    const double *warm; /**< optional extra start, DOFs per unit chord (ndof values), or NULL */
} ef_ref_opts_t;

/** Optimizer result. */
typedef struct {
    double dof[EF_REF_MAX_DOF]; /**< optimal DOFs, program units */
    int ndof;
    double C;          /**< C at the optimum */
    unsigned at_bound; /**< bit i set: DOF i ends on a bound */
    int starts;        /**< starts run */
    int iters;         /**< iterations summed over starts */
    int converged;     /**< 1 if the best start met tol (or a bound-stationarity test) */
} ef_ref_result_t;

void ef_ref_opts_default(ef_ref_opts_t *o);

/**
 * @brief Global minimum of C over the DOFs within the bounds: deterministic multi-start
 * projected Newton, all DOFs jointly.
 * @param o  settings, or NULL for the defaults
 * @param m  message on failure, or NULL
 * @retval EF_OK
 * @retval EF_ERR_ARG        NULL pointer, unknown kind, or bad settings
 * @retval EF_ERR_NONFINITE  NaN/inf in end data
 * @retval EF_ERR_DEGENERATE chord shorter than 1e-12 times the coordinates' scale
 * @retval EF_ERR_NOCONV     no start produced a finite objective
 */
int ef_ref_optimize(ef_ref_kind_t kind, const ef_dend_t *e0, const ef_dend_t *e1,
                    const ef_ref_opts_t *o, ef_ref_result_t *r, ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_REF_H */
