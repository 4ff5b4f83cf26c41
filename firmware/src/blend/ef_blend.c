/* SPDX-License-Identifier: Apache-2.0 */
/* Corner blends between straight moves: a symmetric G2 quintic from the G2 table. The
 * construction and its reasoning are in ef_blend.h and docs/math.md ("Corner blends"). */
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/core/ef_config.h"
#include "evenfeed/core/ef_err.h"

/* 4 x FLT_EPSILON (2^-23): the share of the tolerance kept for float32 rounding of the
 * control points, per unit of the corner's largest coordinate. */
#define EF_BLEND_ROUND_MARGIN (4.0f * 1.1920929e-7f)

/* Hide an integer's value from the optimizer (an empty asm, no code), so a 0/1 flag used
 * in arithmetic stays arithmetic instead of being turned back into branches. */
static inline int bl_hidei(int x)
{
#ifdef __GNUC__
    __asm__("" : "+r"(x));
#endif
    return x;
}

/* Zero the whole result so a failed call leaves nothing a caller could send to a drive. */
static int bl_fail(ef_blend_t *out, int rc)
{
    ef_blend_t zero = {0};
    *out = zero;
    return rc;
}

/* Every component bounded by EF_MAX_COORD (false for NaN and inf). */
static inline int bl_v3_ok(ef_vec3_t a)
{
    int ox = ef_fabsf(a.x) <= EF_MAX_COORD, oy = ef_fabsf(a.y) <= EF_MAX_COORD;
    int oz = ef_fabsf(a.z) <= EF_MAX_COORD;
    return ox & oy & oz;
}

/* Finite without libm: NaN fails x == x, inf fails x - x == 0. */
static inline int bl_finite(float x)
{
    return (x == x) & (x - x == 0.0f);
}

/* The vertex turn and the line–line blend's table DOFs (contract in ef_blend.h). */
int ef_blend_vertex(const ef_table_t *g2, ef_vec3_t ui, ef_vec3_t uo, ef_blend_vertex_t *vx)
{
    /* The turn from |u_in x u_out| and <u_in, u_out> (accurate at both ends of [0, pi]);
     * 2 cos(phi) and 2 sin(phi) as |ui + uo| and |uo - ui|, likewise. */
    float theta = ef_atan2f(ef_v3_norm(ef_v3_cross(ui, uo)), ef_v3_dot(ui, uo));
    if (!(theta <= EF_BLEND_MAX_TURN))
        return EF_ERR_REVERSAL;
    vx->theta = theta;
    vx->sum = ef_v3_add(ui, uo);
    vx->two_cos = ef_v3_norm(vx->sum);
    vx->two_sin = ef_v3_norm(ef_v3_sub(uo, ui));
    vx->phi = 0.5f * theta;
    /* DOFs per unit chord for (phi, -phi, 0, 0), symmetrized (reversal symmetry). */
    float d[4];
    vx->tclamp = 0;
    int rc = ef_table_lookup_g2_corner(g2, vx->phi, d, &vx->tclamp);
    if (rc != EF_OK)
        return rc;
    vx->x1c = 0.5f * (d[0] + d[2]);
    vx->x2c = 0.5f * (d[1] - d[3]);
    return EF_OK;
}

/* The unit-trim blend (corner at the origin, trims 1) has f'(t) = alpha u_in + beta u_out,
 * alpha = a1 x1 + x2 B1 / 4 + 5 B2 (1 - x2 / 20), beta = b1 x1 + x2 B3 / 4 + 5 B2 (1 - x2 / 20)
 * (its hodograph h0 = x1 u_in, h1 = (x1 + x2 / 4) u_in, h2 = 5 (1 - 0.4 x1 - 0.05 x2)
 * (u_in + u_out), h3, h4 mirrored), so |f'|^2 = alpha^2 + beta^2 + 2 cos(theta) alpha beta
 * is a quadratic in x1 at each node. Rows: B1 / 4, B3 / 4, 5 B2, a1 = B0 + B1 - 2 B2,
 * b1 = B3 + B4 - 2 B2 and the weight, at the 8 nodes t < 1/2 of the 16-point
 * Gauss-Legendre rule on [0, 1] (ef_seg_length()'s; the curve is symmetric, |f'(t)| =
 * |f'(1 - t)|, so each weight is doubled). Nodes by Newton's method on P16 in double. */
static const float bl_gl8[8][6] = {
    {5.215723094e-03f, 1.480488379e-07f, 8.336447495e-04f, 9.994992202e-01f, -3.328649157e-04f,
     2.715245941e-02f},
    {2.547180069e-02f, 2.069289640e-05f, 2.178019283e-02f, 9.868485229e-01f, -8.628715750e-03f,
     6.225352394e-02f},
    {5.453255402e-02f, 2.828792597e-04f, 1.178283313e-01f, 9.281511103e-01f, -4.597944161e-02f,
     9.515851168e-02f},
    {8.269137183e-02f, 1.605473267e-03f, 3.456629980e-01f, 7.859566037e-01f, -1.316196017e-01f,
     1.246289713e-01f},
    {1.011393014e-01f, 5.642056461e-03f, 7.166381820e-01f, 5.461162761e-01f, -2.627544581e-01f,
     1.495959888e-01f},
    {1.049913269e-01f, 1.450775013e-02f, 1.170841212e+00f, 2.340713598e-01f, -4.049125715e-01f,
     1.691565194e-01f},
    {9.451599277e-02f, 2.969793488e-02f, 1.589413986e+00f, -8.908715969e-02f, -5.003268262e-01f,
     1.826034150e-01f},
    {7.426425617e-02f, 5.072555714e-02f, 1.841300137e+00f, -3.496051143e-01f, -4.916950222e-01f,
     1.894506105e-01f},
};

/* Newton steps of bl_even(): from the table's x1 (within 1.2 % of L) the error squares with
 * each step, float32 resolution after two. */
#define EF_BLEND_NEWTON 3

/* x1 with both end speeds equal to the unit-trim curve's length L(x1), by EF_BLEND_NEWTON
 * Newton steps on g(x) = L(x) - x from x1 (g' = L' - 1, near -1; a flat g' takes the
 * fixed-point step instead). c = cos(theta) = <u_in, u_out>. */
static float bl_even(float x1, float x2, float c)
{
    float x = x1;
    for (int it = 0; it < EF_BLEND_NEWTON; it++) {
        float l = 0.0f, dl = 0.0f;
        for (int i = 0; i < 8; i++) {
            const float *r = bl_gl8[i];
            float g5 = r[2] * (1.0f - 0.05f * x2);
            float al = r[3] * x + x2 * r[0] + g5;
            float be = r[4] * x + x2 * r[1] + g5;
            float s2 = al * al + be * be + 2.0f * c * al * be;
            float sp = ef_sqrtf(ef_maxf(s2, 0.0f));
            float hd = al * r[3] + be * r[4] + c * (r[3] * be + al * r[4]); /* d(s2)/dx / 2 */
            l += r[5] * sp;
            dl += r[5] * hd / ef_maxf(sp, 1e-30f);
        }
        float g = l - x, dg = dl - 1.0f;
        float xn = x - g / ef_selectf(dg < -0.1f, dg, -1.0f);
        x = ef_selectf(xn > 0.0f, xn, x);
    }
    return x;
}

int ef_blend_corner(const ef_table_t *g2, ef_vec3_t v, ef_vec3_t u_in, ef_vec3_t u_out, float tol,
                    float max_in, float max_out, ef_blend_t *out)
{
    if (!out)
        return EF_ERR_ARG;
    if (!g2)
        return bl_fail(out, EF_ERR_ARG);
    if (g2->kind != EF_TABLE_G2_QUINTIC)
        return bl_fail(out, EF_ERR_KIND);
    int finite = bl_v3_ok(v) & bl_v3_ok(u_in) & bl_v3_ok(u_out) & bl_finite(tol) &
                 bl_finite(max_in) & bl_finite(max_out);
    if (!bl_hidei(finite))
        return bl_fail(out, EF_ERR_NONFINITE);
    int positive = (tol > 0.0f) & (max_in > 0.0f) & (max_out > 0.0f);
    if (!bl_hidei(positive))
        return bl_fail(out, EF_ERR_ARG);
    float ii = ef_v3_dot(u_in, u_in), oo = ef_v3_dot(u_out, u_out);
    int unit_in = ef_fabsf(ii - 1.0f) <= 2.0f * EF_UNIT_TOL;
    int unit_out = ef_fabsf(oo - 1.0f) <= 2.0f * EF_UNIT_TOL;
    int unit = unit_in & unit_out;
    if (!bl_hidei(unit))
        return bl_fail(out, EF_ERR_TANGENT);

    /* Unit directions, the turn and the table's DOFs (ef_blend_vertex()). */
    ef_vec3_t ui = ef_v3_scale(u_in, 1.0f / ef_sqrtf(ii));
    ef_vec3_t uo = ef_v3_scale(u_out, 1.0f / ef_sqrtf(oo));
    ef_blend_vertex_t vx;
    int rc = ef_blend_vertex(g2, ui, uo, &vx);
    if (rc != EF_OK)
        return bl_fail(out, rc);
    float theta = vx.theta, two_cos = vx.two_cos, two_sin = vx.two_sin, phi = vx.phi;
    ef_vec3_t sum = vx.sum;
    uint32_t tclamp = vx.tclamp;
    /* Per unit trim (L = 1): x1, x2 in program units are the table's times the chord. */
    float x1 = vx.x1c * two_cos;
    float x2 = vx.x2c * two_cos;
    /* End speeds equal to the arc length (as ef_seg_g2_even(), which says why): x1 = L of
     * the unit-trim curve (bl_even()). The table's x1 was up to 1.2 % off L at sharp corners
     * (a step of 0.1 mm/s in one period at 8 mm/s in uniform stepping, tests/fuzz). */
    x1 = bl_even(x1, x2, ef_v3_dot(ui, uo));
    float a = 0.4f * x1 + 0.05f * x2;
    /* f(1/2) - v = cc (u_out - u_in) / 32 at L = 1, so g = |cc| 2 sin(phi) / 32. */
    float cc = 16.0f - x1 - 10.0f * a;
    float g = ef_fabsf(cc) * two_sin * (1.0f / 32.0f);

    /* The control points are rounded to float32 at the corner's coordinates: each is off by
     * about an ulp per component, so a margin of 4 eps max|v_i| of the tolerance is kept for
     * it and the curve as stored stays within tol (tests/blend/test_blend.c measures it). */
    float scale = ef_maxf(ef_maxf(ef_fabsf(v.x), ef_fabsf(v.y)), ef_fabsf(v.z));
    float tol_geo = tol - EF_BLEND_ROUND_MARGIN * scale;
    /* Trim: as long as the tolerance allows, no longer than either neighbour allows. */
    float l_tol = ef_maxf(tol_geo, 0.0f) / ef_maxf(g, 1e-30f);
    /* Bounded by EF_MAX_COORD too, so a caller's "no limit" (FLT_MAX) cannot overflow. */
    float l_max = ef_minf(ef_minf(max_in, max_out), EF_MAX_COORD);
    float len = ef_minf(l_tol, l_max);
    int clamped = l_max < l_tol;

    int straight = theta < EF_BLEND_MIN_TURN;
    float chord = len * two_cos;
    int stop = (chord < EF_MIN_CHORD) | (chord < EF_MIN_CHORD_REL * scale) | (tol_geo <= 0.0f);
    stop &= straight ^ 1;
    int blend = bl_hidei((straight | stop) ^ 1);
    float m = (float)blend;
    float lb = len * m;

    /* Control points (ef_blend.h); all zero when there is no blend. */
    float x1l = x1 * lb, x2l = x2 * lb, al = a * lb;
    ef_vec3_t pa = ef_v3_axpy(v, -lb, ui), pb = ef_v3_axpy(v, lb, uo);
    ef_seg_t *s = &out->seg;
    s->b[0] = ef_v3_scale(pa, m);
    s->b[1] = ef_v3_scale(ef_v3_axpy(pa, 0.2f * x1l, ui), m);
    s->b[2] = ef_v3_scale(ef_v3_axpy(pa, al, ui), m);
    s->b[3] = ef_v3_scale(ef_v3_axpy(pb, -al, uo), m);
    s->b[4] = ef_v3_scale(ef_v3_axpy(pb, -0.2f * x1l, uo), m);
    s->b[5] = ef_v3_scale(pb, m);
    s->degree = (uint8_t)(5 * blend);
    s->ndof = (uint8_t)(4 * blend);
    s->flags = (uint32_t)(tclamp != 0) * (uint32_t)blend * EF_SEG_CLAMPED;
    s->clamp = tclamp * (uint32_t)blend;
    s->dof[0] = x1l;
    s->dof[1] = x2l;
    s->dof[2] = x1l;
    s->dof[3] = -x2l;
    s->norm.alpha = phi * m;
    s->norm.beta = -phi * m;
    s->norm.k0 = s->norm.k1 = 0.0f;
    s->norm.chord = chord * m;
    s->norm.e1 = ef_v3_scale(sum, m / ef_maxf(two_cos, 1e-30f));
    s->norm.t0 = ef_v3_scale(ui, m);
    s->norm.t1 = ef_v3_scale(uo, m);

    out->p_in = pa;
    out->p_out = pb;
    out->trim_in = lb;
    out->trim_out = lb;
    out->dev = lb * g;
    out->gain = g;
    out->turn = theta;
    out->flags = (uint32_t)(clamped & blend) * EF_BLEND_CLAMPED +
                 (uint32_t)straight * EF_BLEND_STRAIGHT + (uint32_t)stop * EF_BLEND_STOP +
                 (uint32_t)((tclamp != 0) & blend) * EF_BLEND_TBL_CLAMPED;
    return EF_OK;
}
