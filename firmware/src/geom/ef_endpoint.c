/* SPDX-License-Identifier: Apache-2.0 */
/* End-data validation and normalization into table coordinates. */
#include "evenfeed/geom/ef_endpoint.h"
#include "evenfeed/core/ef_config.h"
#include "evenfeed/core/ef_err.h"

/* Hide an integer's value from the optimizer (an empty asm, no code), so a flag combined
 * with & stays one test instead of being split back into short-circuit branches. */
static inline int ep_ct_hidei(int x)
{
#ifdef __GNUC__
    __asm__("" : "+r"(x));
#endif
    return x;
}

/* Finite test without libm: NaN fails x == x, inf fails x - x == 0. */
static int ep_finite(float x)
{
    return (x == x) & (x - x == 0.0f);
}

/* A vector is usable if every component is finite and bounded by EF_MAX_COORD. The bound
 * test alone says both, since EF_MAX_COORD is finite: NaN compares false and |inf| exceeds
 * it. A separate finite test per component cost about 25 instructions a vector, and this
 * runs four times per G1 segment and six per G2. */
static inline int ep_v3_ok(ef_vec3_t v)
{
    int ox = ef_fabsf(v.x) <= EF_MAX_COORD, oy = ef_fabsf(v.y) <= EF_MAX_COORD;
    int oz = ef_fabsf(v.z) <= EF_MAX_COORD;
    return ox & oy & oz;
}

/* Checks combine with & rather than && so valid input always runs the same instructions.
 * Inline so ef_normalize() pays no call per end; e is not NULL here. */
static inline int ep_check(const ef_endpoint_t *e, int g2)
{
    int finite = ep_v3_ok(e->p) & ep_v3_ok(e->t);
    if (g2)
        finite &= ep_v3_ok(e->n) & ep_finite(e->kappa);
    if (!finite)
        return EF_ERR_NONFINITE;
    float tt = ef_v3_dot(e->t, e->t);
    if (!(ef_fabsf(tt - 1.0f) <= 2.0f * EF_UNIT_TOL))
        return EF_ERR_TANGENT;
    if (g2) {
        float nn = ef_v3_dot(e->n, e->n);
        int curved = e->kappa != 0.0f;
        int unit_n = ef_fabsf(nn - 1.0f) <= 2.0f * EF_UNIT_TOL;
        int perp_n = ef_fabsf(ef_v3_dot(e->n, e->t)) <= EF_UNIT_TOL;
        int bad_n = (unit_n & perp_n) ^ 1;
        /* gcc -O2 evaluated `curved` only when bad_n was set: a data-dependent count on
         * valid input (kappa == 0 with a zero normal). One opaque test keeps it fixed. */
        if (ep_ct_hidei(curved & bad_n))
            return EF_ERR_NORMAL;
    }
    return EF_OK;
}

/* Public entry: validate one end (NULL-safe). */
int ef_endpoint_check(const ef_endpoint_t *e, int g2)
{
    return e ? ep_check(e, g2) : EF_ERR_ARG;
}

/* v / |v|, or the zero vector when |v| is 0 (callers select away from that case). */
static inline ef_vec3_t ep_v3_unit_or_zero(ef_vec3_t v)
{
    float l2 = ef_v3_dot(v, v);
    return ef_v3_scale(v, 1.0f / ef_sqrtf(ef_selectf(l2 > 0.0f, l2, 1.0f)));
}

/* Component-wise select between two vectors. */
static ef_vec3_t ep_v3_select(int c, ef_vec3_t a, ef_vec3_t b)
{
    return ef_v3(ef_selectf(c, a.x, b.x), ef_selectf(c, a.y, b.y), ef_selectf(c, a.z, b.z));
}

/* m0 + sigma m1 with sigma = +-1 making the two terms agree, so opposite normals of a
 * C-shaped configuration add rather than cancel. */
static ef_vec3_t ep_v3_agree_sum(ef_vec3_t m0, ef_vec3_t m1, float *sigma)
{
    *sigma = ef_selectf(ef_v3_dot(m0, m1) >= 0.0f, 1.0f, -1.0f);
    return ef_v3_axpy(m0, *sigma, m1);
}

/*
 * The reference plane's normal e3 ~ m = (e1 x t0) + sigma (e1 x t1). For G1 only the sign
 * of (alpha, beta) depends on it, and the mirror symmetry makes that sign free whenever m
 * vanishes (both tangents along the chord), so G1 takes the orientation from m directly.
 * G2 needs the plane itself for the curvature signs: when m vanishes it falls back to the
 * curvature vectors. Both candidates are computed and one selected, so the count does not
 * depend on which applies. The orientation is fixed
 * by the first nonzero of e3.z, e3.y, e3.x being positive: planar data in z = 0 gets
 * e3 = +z and the usual counter-clockwise signs.
 */
int ef_normalize(const ef_endpoint_t *e0, const ef_endpoint_t *e1, int g2, ef_norm_t *out)
{
    if (!e0 || !e1 || !out)
        return EF_ERR_ARG;
    int rc = ep_check(e0, g2);
    if (rc == EF_OK)
        rc = ep_check(e1, g2);
    if (rc != EF_OK)
        return rc;

    ef_vec3_t d = ef_v3_sub(e1->p, e0->p);
    float s = ef_v3_norm(d);
    float scale = ef_maxf(ef_maxf(ef_maxf(ef_fabsf(e0->p.x), ef_fabsf(e0->p.y)),
                                  ef_maxf(ef_fabsf(e0->p.z), ef_fabsf(e1->p.x))),
                          ef_maxf(ef_fabsf(e1->p.y), ef_fabsf(e1->p.z)));
    if (!(s >= EF_MIN_CHORD) | !(s >= EF_MIN_CHORD_REL * scale))
        return EF_ERR_DEGENERATE;

    ef_vec3_t ex = ef_v3_scale(d, 1.0f / s);
    ef_vec3_t t0 = ep_v3_unit_or_zero(e0->t), t1 = ep_v3_unit_or_zero(e1->t);
    ef_vec3_t m0 = ef_v3_cross(ex, t0), m1 = ef_v3_cross(ex, t1);
    float sigma;
    ef_vec3_t m = ep_v3_agree_sum(m0, m1, &sigma);
    /* True angle to the chord; the sign (side of the chord) comes below. */
    float a0 = ef_atan2f(ef_v3_norm(m0), ef_v3_dot(t0, ex));
    float a1 = ef_atan2f(ef_v3_norm(m1), ef_v3_dot(t1, ex));
    out->k0 = out->k1 = 0.0f;
    if (!g2) { /* g2 is fixed per entry point: this branch does not depend on the data */
        float key = ef_selectf(m.z != 0.0f, m.z, ef_selectf(m.y != 0.0f, m.y, m.x));
        float f = ef_selectf(key < 0.0f, -1.0f, 1.0f);
        out->alpha = f * a0;
        out->beta = f * sigma * a1;
    } else {
        float sigma_k;
        ef_vec3_t cand_k =
            ep_v3_agree_sum(ef_v3_cross(ex, ef_v3_scale(e0->n, e0->kappa * s)),
                            ef_v3_cross(ex, ef_v3_scale(e1->n, e1->kappa * s)), &sigma_k);
        /* When the curvature candidate vanishes too, |kappa s| < 1e-5 at both ends and both
         * tangents lie along the chord: angles are 0 or pi and curvatures ~0 in any plane,
         * so no further fallback is needed (a zero e3 gives exactly 0 curvatures). */
        const float tiny = 1e-10f;
        int m_tiny = ef_v3_dot(m, m) < tiny, k_ok = ef_v3_dot(cand_k, cand_k) >= tiny;
        m = ep_v3_select(m_tiny & k_ok, cand_k, m);
        ef_vec3_t ez = ep_v3_unit_or_zero(m);
        float key = ef_selectf(ez.z != 0.0f, ez.z, ef_selectf(ez.y != 0.0f, ez.y, ez.x));
        ez = ef_v3_scale(ez, ef_selectf(key < 0.0f, -1.0f, 1.0f));
        out->alpha = ef_selectf(ef_v3_dot(m0, ez) < 0.0f, -a0, a0);
        out->beta = ef_selectf(ef_v3_dot(m1, ez) < 0.0f, -a1, a1);
        out->k0 = e0->kappa * s * ef_v3_dot(e0->n, ef_v3_cross(ez, t0));
        out->k1 = e1->kappa * s * ef_v3_dot(e1->n, ef_v3_cross(ez, t1));
    }
    out->chord = s;
    out->e1 = ex;
    out->t0 = t0;
    out->t1 = t1;
    int k0_ok = ef_fabsf(e0->kappa * s) <= EF_MAX_NORM_CURVATURE;
    int k1_ok = ef_fabsf(e1->kappa * s) <= EF_MAX_NORM_CURVATURE;
    if (g2 && !(k0_ok & k1_ok))
        return EF_ERR_DOMAIN;
    return EF_OK;
}

/* Angle between (e1 x t0) and +-(e1 x t1), the sign making them agree; off the hot path. */
float ef_norm_twist(const ef_norm_t *nm, const ef_endpoint_t *e0, const ef_endpoint_t *e1)
{
    if (!nm || !e0 || !e1)
        return 0.0f;
    ef_vec3_t m0 = ef_v3_cross(nm->e1, e0->t), m1 = ef_v3_cross(nm->e1, e1->t);
    float sigma;
    (void)ep_v3_agree_sum(m0, m1, &sigma);
    ef_vec3_t m1s = ef_v3_scale(m1, sigma);
    return ef_atan2f(ef_v3_norm(ef_v3_cross(m0, m1s)), ef_v3_dot(m0, m1s));
}
