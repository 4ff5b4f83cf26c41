/* SPDX-License-Identifier: Apache-2.0 */
/* Constant-time multilinear lookup of optimal DOFs, with symmetry folding. */
#include "evenfeed/table/ef_table.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/core/ef_math.h"

#define EF_TWO_PI_F (2.0f * EF_PI_F)
/* Inputs are clamped to this magnitude before any float-to-int conversion. */
#define EF_LOOKUP_MAX_COORD 1e6f

/*
 * Constant-time helpers. A plain `a < b ? a : b` against a constant lets the optimizer
 * thread the constant side into its own branch (gcc -O2 does so for clamps to 0/1 and to
 * +-EF_LOOKUP_MAX_COORD), and `t - (float)(t > x)` becomes a conditional subtract: both
 * make the instruction count depend on the data. An empty asm is opaque to the optimizer,
 * so a value passed through it can no longer be treated as a known constant or a known
 * 0/1, and the surrounding code must stay straight-line. It emits no instruction.
 */
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#define EF_CT_FREG "+x" /* SSE register */
#elif defined(__GNUC__) && defined(__arm__) && defined(__VFP_FP__) && !defined(__SOFTFP__)
#define EF_CT_FREG "+t" /* VFP single-precision register */
#elif defined(__GNUC__)
#define EF_CT_FREG "+g" /* anywhere: soft-float targets keep floats in core registers */
#endif

/* Hide a float's value from the optimizer (no code). */
static inline float tl_ct_hidef(float x)
{
#ifdef EF_CT_FREG
    __asm__("" : EF_CT_FREG(x));
#endif
    return x;
}

/* Hide an integer's value from the optimizer (no code). */
static inline uint32_t tl_ct_hideu(uint32_t x)
{
#ifdef __GNUC__
    __asm__("" : "+r"(x));
#endif
    return x;
}

/* min(max(x, lo), hi) as min/max instructions: the bounds are hidden so no bound can be
 * folded into a branch of its own. Same value as ef_minf(ef_maxf(x, lo), hi). */
static inline float tl_ct_clampf(float x, float lo, float hi)
{
    return ef_minf(ef_maxf(x, tl_ct_hidef(lo)), tl_ct_hidef(hi));
}

/* ef_floorf() with the 0/1 correction converted rather than branched on. */
static inline float tl_ct_floorf(float x)
{
    float t = (float)(int)x;
    return t - (float)tl_ct_hideu((uint32_t)(t > x));
}

/* Cell index and fraction of x on one axis; sets *clamped when x was outside [lo, hi]. */
static inline uint32_t tl_axis_cell(const ef_table_axis_t *ax, float x, float *frac,
                                    uint32_t *clamped)
{
    *clamped = (uint32_t)((x < ax->lo) | (x > ax->hi));
    float xc = tl_ct_clampf(x, ax->lo, ax->hi);
    float g = (xc - ax->lo) * ax->inv_step;
    uint32_t i = (uint32_t)g;
    uint32_t last = ax->nodes - 2u;
    i = i < last ? i : last;
    *frac = tl_ct_clampf(g - (float)i, 0.0f, 1.0f);
    return i;
}

/* Bring x into [lo, lo + 2 pi) for a periodic axis. */
static float tl_wrap(float x, float lo)
{
    return x - EF_TWO_PI_F * tl_ct_floorf((x - lo) * (1.0f / EF_TWO_PI_F));
}

/* Bounded input: the folding arithmetic converts to int. */
static float tl_bound(float x)
{
    return tl_ct_clampf(x, -EF_LOOKUP_MAX_COORD, EF_LOOKUP_MAX_COORD);
}

/*
 * Fold (alpha, beta) into the (u, v) fundamental region [0, pi/2] x [0, pi]. In (u, v) the
 * mirror is (u,v) -> (-u,-v), reversal (u,v) -> (-u,v) with ends swapped, and the 2 pi
 * periods are (u,v) + (pi, +-pi); *swap says whether x1_0 and x1_1 trade places.
 */
static void tl_fold_uv(float alpha, float beta, float *u, float *v, int *swap)
{
    float uu = 0.5f * (alpha + beta), vv = 0.5f * (alpha - beta);
    float k = tl_ct_floorf(uu * (1.0f / EF_PI_F) + 0.5f);
    uu -= k * EF_PI_F;
    vv -= k * EF_PI_F;
    vv -= EF_TWO_PI_F * tl_ct_floorf(vv * (1.0f / EF_TWO_PI_F) + 0.5f);
    *swap = (uu < 0.0f) ^ (vv < 0.0f);
    *u = ef_fabsf(uu);
    *v = ef_fabsf(vv);
}

/* Bilinear blend of the 2 DOFs at the four corners of a cell. */
int ef_table_lookup_g1(const ef_table_t *tbl, float alpha, float beta, float dof[2],
                       uint32_t *flags)
{
    if (!tbl || !dof || !tbl->data)
        return EF_ERR_ARG;
    if (tbl->kind != EF_TABLE_G1_CUBIC || tbl->naxes != 2 || tbl->ndof != 2)
        return EF_ERR_KIND;
    alpha = tl_bound(alpha);
    beta = tl_bound(beta);
    int swap = 0;
    float c[2] = {alpha, beta};
    if (tbl->symmetry == EF_SYM_G1_FOLD) {
        tl_fold_uv(alpha, beta, &c[0], &c[1], &swap);
    } else {
        for (int a = 0; a < 2; a++)
            if (tbl->axis[a].flags & EF_AXIS_PERIODIC)
                c[a] = tl_wrap(c[a], tbl->axis[a].lo);
    }
    float f0, f1;
    uint32_t cl0, cl1;
    uint32_t i0 = tl_axis_cell(&tbl->axis[0], c[0], &f0, &cl0);
    uint32_t i1 = tl_axis_cell(&tbl->axis[1], c[1], &f1, &cl1);
    const float *p = tbl->data + 2u * (i0 * tbl->axis[0].stride + i1 * tbl->axis[1].stride);
    const uint32_t s1 = 2u * tbl->axis[1].stride;
    float w00 = (1.0f - f0) * (1.0f - f1), w10 = f0 * (1.0f - f1);
    float w01 = (1.0f - f0) * f1, w11 = f0 * f1;
    float d0 = w00 * p[0] + w10 * p[2] + w01 * p[s1] + w11 * p[s1 + 2];
    float d1 = w00 * p[1] + w10 * p[3] + w01 * p[s1 + 1] + w11 * p[s1 + 3];
    dof[0] = ef_selectf(swap, d1, d0);
    dof[1] = ef_selectf(swap, d0, d1);
    /* The fold covers every angle: a clamp there is only rounding at the region's edge. */
    uint32_t fold = tbl->symmetry == EF_SYM_G1_FOLD;
    if (flags)
        *flags = (1u - fold) * (cl0 * EF_LOOKUP_CLAMP_ALPHA | cl1 * EF_LOOKUP_CLAMP_BETA);
    return EF_OK;
}

/* 4-linear blend over the 16 corners of a cell; the mirror half is reached by negating
 * every coordinate, which leaves the DOFs unchanged. */
int ef_table_lookup_g2(const ef_table_t *tbl, const float c[4], float dof[4], uint32_t *flags)
{
    if (!tbl || !c || !dof || !tbl->data)
        return EF_ERR_ARG;
    if (tbl->kind != EF_TABLE_G2_QUINTIC || tbl->naxes != 4 || tbl->ndof != 4)
        return EF_ERR_KIND;
    float x[4];
    for (int a = 0; a < 4; a++)
        x[a] = tl_bound(c[a]);
    if (tbl->symmetry == EF_SYM_G2_MIRROR) {
        float m = ef_selectf(x[0] < 0.0f, -1.0f, 1.0f);
        for (int a = 0; a < 4; a++)
            x[a] *= m;
    }
    float f[4];
    uint32_t cl[4], base = 0;
    for (int a = 0; a < 4; a++)
        base += tl_axis_cell(&tbl->axis[a], x[a], &f[a], &cl[a]) * tbl->axis[a].stride;
    /* Tensor-product interpolation as successive lerps: along axis 0 between the 8 node
     * pairs, then axis 1, 2, 3. Each step works on whole 4-DOF rows (16 contiguous bytes),
     * which gcc vectorizes on x86; on the M4F it is plain scalar code of the same count. */
    const float *p = tbl->data + 4u * base;
    const uint32_t s0 = 4u * tbl->axis[0].stride, s1 = 4u * tbl->axis[1].stride;
    const uint32_t s2 = 4u * tbl->axis[2].stride, s3 = 4u * tbl->axis[3].stride;
    float r8[8][4], r4[4][4], r2[2][4], acc[4];
    /* Fixed trip counts; unrolled, the index arithmetic folds into constant offsets. */
#pragma GCC unroll 8
    for (uint32_t j = 0; j < 8u; j++) {
        const float *lo = p + (j & 1u) * s1 + ((j >> 1) & 1u) * s2 + (j >> 2) * s3;
        const float *hi = lo + s0;
        for (int k = 0; k < 4; k++)
            r8[j][k] = lo[k] + f[0] * (hi[k] - lo[k]);
    }
#pragma GCC unroll 4
    for (uint32_t j = 0; j < 4u; j++)
        for (int k = 0; k < 4; k++)
            r4[j][k] = r8[2u * j][k] + f[1] * (r8[2u * j + 1u][k] - r8[2u * j][k]);
    for (uint32_t j = 0; j < 2u; j++)
        for (int k = 0; k < 4; k++)
            r2[j][k] = r4[2u * j][k] + f[2] * (r4[2u * j + 1u][k] - r4[2u * j][k]);
    for (int k = 0; k < 4; k++)
        acc[k] = r2[0][k] + f[3] * (r2[1][k] - r2[0][k]);
    for (int k = 0; k < 4; k++)
        dof[k] = acc[k];
    if (flags)
        *flags = cl[0] * EF_LOOKUP_CLAMP_ALPHA | cl[1] * EF_LOOKUP_CLAMP_BETA |
                 cl[2] * EF_LOOKUP_CLAMP_K0 | cl[3] * EF_LOOKUP_CLAMP_K1;
    return EF_OK;
}

/* The symmetric corner (phi, -phi, 0, 0) (contract in ef_table.h). */
int ef_table_lookup_g2_corner(const ef_table_t *tbl, float phi, float dof[4], uint32_t *flags)
{
    if (!tbl || !dof || !tbl->data)
        return EF_ERR_ARG;
    if (tbl->kind != EF_TABLE_G2_QUINTIC || tbl->naxes != 4 || tbl->ndof != 4)
        return EF_ERR_KIND;
    float f[4];
    uint32_t cl[4], base = 0;
    float x0 = tl_bound(phi), x1 = tl_bound(-phi);
    /* the mirror maps (phi, -phi) with phi < 0 to (-phi, phi), as ef_table_lookup_g2() */
    if (tbl->symmetry == EF_SYM_G2_MIRROR) {
        float m = ef_selectf(x0 < 0.0f, -1.0f, 1.0f);
        x0 *= m;
        x1 *= m;
    }
    const float x[4] = {x0, x1, 0.0f, 0.0f};
    for (int a = 0; a < 4; a++)
        base += tl_axis_cell(&tbl->axis[a], x[a], &f[a], &cl[a]) * tbl->axis[a].stride;
    /* Curvature 0 on a node of both curvature axes (a property of the table, so the count is
     * still fixed per table): the lerps along them have weight 0 and are left out, leaving
     * a bilinear lerp of 4 rows, the same values as the 4-linear one. Otherwise the general
     * lookup. */
    if (!(f[2] == 0.0f && f[3] == 0.0f)) {
        const float c[4] = {phi, -phi, 0.0f, 0.0f};
        return ef_table_lookup_g2(tbl, c, dof, flags);
    }
    const float *p = tbl->data + 4u * base;
    const uint32_t s0 = 4u * tbl->axis[0].stride, s1 = 4u * tbl->axis[1].stride;
    for (int k = 0; k < 4; k++) {
        float r0 = p[k] + f[0] * (p[s0 + k] - p[k]);
        float r1 = p[s1 + k] + f[0] * (p[s1 + s0 + k] - p[s1 + k]);
        dof[k] = r0 + f[1] * (r1 - r0);
    }
    if (flags)
        *flags = cl[0] * EF_LOOKUP_CLAMP_ALPHA | cl[1] * EF_LOOKUP_CLAMP_BETA |
                 cl[2] * EF_LOOKUP_CLAMP_K0 | cl[3] * EF_LOOKUP_CLAMP_K1;
    return EF_OK;
}
