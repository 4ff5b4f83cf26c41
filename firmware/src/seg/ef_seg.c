/* SPDX-License-Identifier: Apache-2.0 */
/* Bézier segments from end data: DOFs from a table (or given), then control points. */
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/core/ef_config.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/geom/ef_bezier.h"

/* Zero the whole segment so a failed call leaves nothing a caller could send to a drive. */
static int seg_fail(ef_seg_t *out, int rc)
{
    ef_seg_t zero = {0};
    *out = zero;
    return rc;
}

/* Cubic control points: b1 = b0 + x1_0 t0 / 3, b2 = b3 - x1_1 t1 / 3. */
static void seg_cubic(const ef_endpoint_t *e0, const ef_endpoint_t *e1, const ef_norm_t *nm,
                      ef_seg_t *out)
{
    ef_vec3_t t0 = nm->t0, t1 = nm->t1;
    out->b[0] = e0->p;
    out->b[1] = ef_v3_axpy(e0->p, out->dof[0] * (1.0f / 3.0f), t0);
    out->b[2] = ef_v3_axpy(e1->p, -out->dof[1] * (1.0f / 3.0f), t1);
    out->b[3] = e1->p;
    out->b[4] = out->b[5] = ef_v3(0.0f, 0.0f, 0.0f);
    out->degree = 3;
    out->ndof = 2;
    out->norm = *nm;
}

/* Quintic control points from f'(0), f''(0), f'(1), f''(1) (domain.md). */
static void seg_quintic(const ef_endpoint_t *e0, const ef_endpoint_t *e1, const ef_norm_t *nm,
                        ef_seg_t *out)
{
    ef_vec3_t t0 = nm->t0, t1 = nm->t1;
    float x10 = out->dof[0], x20 = out->dof[1], x11 = out->dof[2], x21 = out->dof[3];
    ef_vec3_t d1a = ef_v3_scale(t0, x10);
    ef_vec3_t d2a = ef_v3_axpy(ef_v3_scale(t0, x20), e0->kappa * x10 * x10, e0->n);
    ef_vec3_t d1b = ef_v3_scale(t1, x11);
    ef_vec3_t d2b = ef_v3_axpy(ef_v3_scale(t1, x21), e1->kappa * x11 * x11, e1->n);
    out->b[0] = e0->p;
    out->b[5] = e1->p;
    out->b[1] = ef_v3_axpy(e0->p, 0.2f, d1a);
    out->b[4] = ef_v3_axpy(e1->p, -0.2f, d1b);
    out->b[2] = ef_v3_axpy(ef_v3_sub(ef_v3_scale(out->b[1], 2.0f), e0->p), 0.05f, d2a);
    out->b[3] = ef_v3_axpy(ef_v3_sub(ef_v3_scale(out->b[4], 2.0f), e1->p), 0.05f, d2b);
    out->degree = 5;
    out->ndof = 4;
    out->norm = *nm;
}

/* Hide an integer from the optimizer (an empty asm, no code): a flag combined with & stays
 * one test instead of being split back into short-circuit branches. */
static inline int seg_ct_hidei(int x)
{
#ifdef __GNUC__
    __asm__("" : "+r"(x));
#endif
    return x;
}

/* Hide a float from the optimizer (no code), so a clamp against a table bound stays a
 * min/max instead of a branch (as in ef_table.c). */
static inline float seg_ct_hidef(float x)
{
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    __asm__("" : "+x"(x));
#elif defined(__GNUC__) && defined(__arm__) && defined(__VFP_FP__) && !defined(__SOFTFP__)
    __asm__("" : "+t"(x));
#elif defined(__GNUC__)
    __asm__("" : "+g"(x));
#endif
    return x;
}

/* min(max(x, lo), hi) with the bounds hidden: min/max instructions, no branch. */
static inline float seg_ct_clampf(float x, float lo, float hi)
{
    return ef_minf(ef_maxf(x, seg_ct_hidef(lo)), seg_ct_hidef(hi));
}

/* floor(x) for |x| < 2^23, the 0/1 correction converted rather than branched on. */
static inline float seg_ct_floorf(float x)
{
    float t = (float)(int)x;
    return t - (float)seg_ct_hidei(t > x);
}

/* The fold lookup of ef_table_lookup_g1() for the XY path, angles already in [-pi, pi]: the
 * same fold and cell, without the argument checks, the +-1e6 bound (a no-op on such angles),
 * the clamp flags (the fold never reports one) and the clamp of the cell fraction (the
 * clamped coordinate keeps it in [0, 1]); the bilinear blend as successive lerps on the
 * DOF pairs (rounded differently from the weighted sum, within an ulp of the DOFs). */
static inline void seg_g1_fold_lerp(const ef_table_t *tbl, float alpha, float beta, float d[2])
{
    float uu = 0.5f * (alpha + beta), vv = 0.5f * (alpha - beta);
    float k = seg_ct_floorf(uu * (1.0f / EF_PI_F) + 0.5f);
    uu -= k * EF_PI_F;
    vv -= k * EF_PI_F;
    vv -= (2.0f * EF_PI_F) * seg_ct_floorf(vv * (1.0f / (2.0f * EF_PI_F)) + 0.5f);
    uint32_t swap = (uint32_t)seg_ct_hidei((uu < 0.0f) ^ (vv < 0.0f));
    float c[2] = {ef_fabsf(uu), ef_fabsf(vv)}, f[2];
    uint32_t i[2];
    for (int a = 0; a < 2; a++) {
        const ef_table_axis_t *ax = &tbl->axis[a];
        float g = (seg_ct_clampf(c[a], ax->lo, ax->hi) - ax->lo) * ax->inv_step;
        uint32_t last = ax->nodes - 2u, ii = (uint32_t)g;
        i[a] = ii < last ? ii : last;
        f[a] = g - (float)i[a];
    }
    const float *p0 = tbl->data + 2u * (i[0] * tbl->axis[0].stride + i[1] * tbl->axis[1].stride);
    const float *p1 = p0 + 2u * tbl->axis[1].stride;
    float r[2];
    for (int q = 0; q < 2; q++) {
        float lo = p0[q] + f[0] * (p0[2 + q] - p0[q]);
        float hi = p1[q] + f[0] * (p1[2 + q] - p1[q]);
        r[q] = lo + f[1] * (hi - lo);
    }
    d[0] = r[swap];
    d[1] = r[swap ^ 1u];
}

/* ef_atan2f()'s polynomial (ef_math.c) for the XY path's arc tangent below, three
 * coefficients moved by a few ulp (the first to 1, the second by 3, the last by 4) so that
 * at w = 1 it evaluates, in float32 and this order, to fl(pi/4) exactly: then the angles 0,
 * pi/2 and pi come out exact, as ef_atan2f()'s do (a tangent along the chord is alpha = 0,
 * not 1e-7). Largest error over [0, pi]: 4.8e-7 rad (ef_atan2f()'s own: 3.7e-7 in this
 * form). test_fw seg_xy checks the three angles. */
static const float seg_atan_c[8] = {
    1.0f,
    -3.333227932e-01f,
    1.997350213e-01f,
    -1.403925361e-01f,
    9.965704541e-02f,
    -6.018953761e-02f,
    2.473677233e-02f,
    -4.825774115e-03f,
};

/* atan2(y, x) in [0, pi] for y >= 0, y + |x| > 0, any scale: with w = (y - |x|) / (y + |x|)
 * in [-1, 1], atan(y / |x|) = pi/4 + atan(w) (tan(pi/4 + phi) = (1 + tan phi) / (1 - tan phi)),
 * so ef_atan2f()'s polynomial needs no octant swap, and x < 0 takes pi minus that:
 * pi/2 + sign(x) (atan(w) - pi/4) either way (x = -0 gives pi/2 as +0 does). Its error is
 * absolute, an ulp or two of pi/4 (not relative near 0, where pi/4 - pi/4 cancels): the
 * table's cells are 0.03 rad wide. No selects: the sign is a copysign. Inline: the XY path
 * calls it twice. */
static inline float seg_atan2_upper(float y, float x)
{
    float ax = ef_fabsf(x);
    float w = (y - ax) / (y + ax);
    float s = w * w;
    float p = seg_atan_c[7];
    p = p * s + seg_atan_c[6];
    p = p * s + seg_atan_c[5];
    p = p * s + seg_atan_c[4];
    p = p * s + seg_atan_c[3];
    p = p * s + seg_atan_c[2];
    p = p * s + seg_atan_c[1];
    p = p * s + seg_atan_c[0];
    return 0.5f * EF_PI_F + __builtin_copysignf(1.0f, x) * (w * p - 0.25f * EF_PI_F);
}

/* Normalize, look up (alpha, beta), scale the per-unit-chord DOFs back by the chord. */
int ef_seg_g1_cubic(const ef_table_t *tbl, const ef_endpoint_t *e0, const ef_endpoint_t *e1,
                    ef_seg_t *out)
{
    if (!out)
        return EF_ERR_ARG;
    if (!tbl || !e0 || !e1)
        return seg_fail(out, EF_ERR_ARG);
    if (tbl->kind != EF_TABLE_G1_CUBIC)
        return seg_fail(out, EF_ERR_KIND);
    ef_norm_t nm;
    int rc = ef_normalize(e0, e1, 0, &nm);
    if (rc != EF_OK)
        return seg_fail(out, rc);
    float d[2];
    uint32_t clamp = 0;
    rc = ef_table_lookup_g1(tbl, nm.alpha, nm.beta, d, &clamp);
    if (rc != EF_OK)
        return seg_fail(out, rc);
    out->dof[0] = d[0] * nm.chord;
    out->dof[1] = d[1] * nm.chord;
    out->dof[2] = out->dof[3] = 0.0f;
    out->clamp = clamp;
    out->flags = (uint32_t)(clamp != 0) * EF_SEG_CLAMPED;
    seg_cubic(e0, e1, &nm, out);
    return EF_OK;
}

/* The error ef_seg_g1_cubic() gives for the planar data ef_seg_g1_cubic_xy() reads (off the
 * constant-time path: only refused input comes here). */
static int seg_xy_error(const ef_endpoint_t *e0, const ef_endpoint_t *e1)
{
    ef_endpoint_t a = *e0, b = *e1;
    a.t.z = b.t.z = 0.0f;
    b.p.z = a.p.z;
    ef_norm_t nm;
    int rc = ef_normalize(&a, &b, 0, &nm);
    return rc != EF_OK ? rc : EF_ERR_DEGENERATE;
}

/* Zero the planar segment, as seg_fail(). */
static int seg_xy_fail(ef_seg_xy_t *out, int rc)
{
    ef_seg_xy_t zero = {0};
    *out = zero;
    return rc;
}

/*
 * ef_normalize()'s tests on data in the plane z = z0, written out in 2-D, then the angles
 * straight from the chord and the tangents as given: an arc tangent reads only the ratio of
 * its arguments, so neither needs dividing by its length first (the 3-D path's unit vectors
 * round differently: the angles agree to a few ulp, not bit for bit). The tangents' lengths
 * are divided out of the handles only.
 */
int ef_seg_g1_cubic_xy(const ef_table_t *tbl, const ef_endpoint_t *e0, const ef_endpoint_t *e1,
                       ef_seg_xy_t *out)
{
    if (!out)
        return EF_ERR_ARG;
    if (!tbl || !e0 || !e1)
        return seg_xy_fail(out, EF_ERR_ARG);
    if (tbl->kind != EF_TABLE_G1_CUBIC)
        return seg_xy_fail(out, EF_ERR_KIND);
    float x0 = e0->p.x, y0 = e0->p.y, z = e0->p.z, x1 = e1->p.x, y1 = e1->p.y;
    float u0 = e0->t.x, v0 = e0->t.y, u1 = e1->t.x, v1 = e1->t.y;
    float dx = x1 - x0, dy = y1 - y0;
    float s = ef_sqrtf(dx * dx + dy * dy);
    float az = ef_fabsf(z);
    float scale = ef_maxf(ef_maxf(ef_maxf(ef_fabsf(x0), ef_fabsf(y0)), ef_maxf(az, ef_fabsf(x1))),
                          ef_fabsf(y1));
    float tt0 = u0 * u0 + v0 * v0, tt1 = u1 * u1 + v1 * v1;
    /* NaN or inf in x or y makes s NaN or the scale too large; z is tested on its own. */
    /* Bitwise on purpose (no branch per test); the casts say so to clang. */
    int ok = (int)(scale <= EF_MAX_COORD) & (int)(az <= EF_MAX_COORD) &
             (int)(ef_fabsf(tt0 - 1.0f) <= 2.0f * EF_UNIT_TOL) &
             (int)(ef_fabsf(tt1 - 1.0f) <= 2.0f * EF_UNIT_TOL) & (int)(s >= EF_MIN_CHORD) &
             (int)(s >= EF_MIN_CHORD_REL * scale);
    if (!seg_ct_hidei(ok))
        return seg_xy_fail(out, seg_xy_error(e0, e1));
    /* chord x tangent and chord . tangent, both times |chord| |t| */
    float c0 = dx * v0 - dy * u0, c1 = dx * v1 - dy * u1;
    float a0 = seg_atan2_upper(ef_fabsf(c0), dx * u0 + dy * v0);
    float a1 = seg_atan2_upper(ef_fabsf(c1), dx * u1 + dy * v1);
    /* ef_normalize()'s signs: sigma = -1 where c0 c1 < 0 makes the two normals agree, the
     * side f is that of their sum t (its x and y are zeros, which never count as negative):
     * alpha = f a0 and beta = f sigma a1, every sign taken by copysign. Where the 3-D path's
     * tests see a zero (a product c0 c1 of -0: one c zero, its angle 0 or pi; a t of -0: both
     * zero) the sign bit may pick the other sign: -0 and 0, -pi and pi, are the same
     * configuration, the fold lookup the same cell. */
    float sigma = __builtin_copysignf(1.0f, c0 * c1);
    float t = c0 + sigma * c1;
    float alpha = __builtin_copysignf(a0, t), beta = __builtin_copysignf(a1, sigma * t);
    float d[2];
    uint32_t clamp = 0;
    /* The table's symmetry is fixed per firmware: this does not depend on the data. */
    if (tbl->symmetry == EF_SYM_G1_FOLD && tbl->naxes == 2 && tbl->ndof == 2 && tbl->data) {
        seg_g1_fold_lerp(tbl, alpha, beta, d);
    } else {
        int rc = ef_table_lookup_g1(tbl, alpha, beta, d, &clamp);
        if (rc != EF_OK)
            return seg_xy_fail(out, rc);
    }
    float x10 = d[0] * s, x11 = d[1] * s;
    /* the handles x1 t / 3 along the unit tangents */
    float k0 = x10 * (1.0f / 3.0f) / ef_sqrtf(tt0), k1 = -x11 * (1.0f / 3.0f) / ef_sqrtf(tt1);
    ef_seg_xy_t *o = out;
    o->x[0] = x0;
    o->y[0] = y0;
    o->x[1] = x0 + k0 * u0;
    o->y[1] = y0 + k0 * v0;
    o->x[2] = x1 + k1 * u1;
    o->y[2] = y1 + k1 * v1;
    o->x[3] = x1;
    o->y[3] = y1;
    o->z = z;
    o->dof[0] = x10;
    o->dof[1] = x11;
    o->alpha = alpha;
    o->beta = beta;
    o->clamp = clamp;
    o->flags = (uint32_t)(clamp != 0) * EF_SEG_CLAMPED;
    return EF_OK;
}

/* The general form of a planar segment (contract in ef_seg.h). */
int ef_seg_xy_expand(const ef_seg_xy_t *xy, ef_seg_t *out)
{
    if (!out)
        return EF_ERR_ARG;
    if (!xy)
        return seg_fail(out, EF_ERR_ARG);
    ef_seg_t o = {0};
    for (int i = 0; i < 4; i++)
        o.b[i] = ef_v3(xy->x[i], xy->y[i], xy->z);
    o.degree = 3;
    o.ndof = 2;
    o.flags = xy->flags;
    o.clamp = xy->clamp;
    o.dof[0] = xy->dof[0];
    o.dof[1] = xy->dof[1];
    o.norm.alpha = xy->alpha;
    o.norm.beta = xy->beta;
    ef_vec3_t c = ef_v3_sub(o.b[3], o.b[0]);
    ef_vec3_t h0 = ef_v3_sub(o.b[1], o.b[0]), h1 = ef_v3_sub(o.b[3], o.b[2]);
    o.norm.chord = ef_v3_norm(c);
    o.norm.e1 = ef_v3_scale(c, 1.0f / ef_maxf(o.norm.chord, 1e-30f));
    o.norm.t0 = ef_v3_scale(h0, 1.0f / ef_maxf(ef_v3_norm(h0), 1e-30f));
    o.norm.t1 = ef_v3_scale(h1, 1.0f / ef_maxf(ef_v3_norm(h1), 1e-30f));
    *out = o;
    return EF_OK;
}

/* As the cubic, with curvatures: x1 and x2 scale with the chord. */
int ef_seg_g2_quintic(const ef_table_t *tbl, const ef_endpoint_t *e0, const ef_endpoint_t *e1,
                      ef_seg_t *out)
{
    if (!out)
        return EF_ERR_ARG;
    if (!tbl || !e0 || !e1)
        return seg_fail(out, EF_ERR_ARG);
    if (tbl->kind != EF_TABLE_G2_QUINTIC)
        return seg_fail(out, EF_ERR_KIND);
    ef_norm_t nm;
    int rc = ef_normalize(e0, e1, 1, &nm);
    if (rc != EF_OK)
        return seg_fail(out, rc);
    float c[4] = {nm.alpha, nm.beta, nm.k0, nm.k1}, d[4];
    uint32_t clamp = 0;
    rc = ef_table_lookup_g2(tbl, c, d, &clamp);
    if (rc != EF_OK)
        return seg_fail(out, rc);
    for (int k = 0; k < 4; k++)
        out->dof[k] = d[k] * nm.chord;
    out->clamp = clamp;
    out->flags = (uint32_t)(clamp != 0) * EF_SEG_CLAMPED;
    seg_quintic(e0, e1, &nm, out);
    return EF_OK;
}

/* Control points for caller-chosen DOFs, validated like the table paths. */
int ef_seg_from_dofs(const ef_endpoint_t *e0, const ef_endpoint_t *e1, int degree, const float *dof,
                     ef_seg_t *out)
{
    if (!out)
        return EF_ERR_ARG;
    if (!e0 || !e1 || !dof || (degree != 3 && degree != 5))
        return seg_fail(out, EF_ERR_ARG);
    int nd = degree == 3 ? 2 : 4;
    for (int k = 0; k < nd; k++)
        if (!(dof[k] == dof[k]) || !(dof[k] - dof[k] == 0.0f))
            return seg_fail(out, EF_ERR_NONFINITE);
    ef_norm_t nm;
    int rc = ef_normalize(e0, e1, degree == 5, &nm);
    if (rc != EF_OK)
        return seg_fail(out, rc);
    float x10 = dof[0], x11 = degree == 3 ? dof[1] : dof[2];
    if (!(x10 > 0.0f) || !(x11 > 0.0f))
        return seg_fail(out, EF_ERR_ARG);
    for (int k = 0; k < 4; k++)
        out->dof[k] = k < nd ? dof[k] : 0.0f;
    out->flags = 0;
    out->clamp = 0;
    if (degree == 3)
        seg_cubic(e0, e1, &nm, out);
    else
        seg_quintic(e0, e1, &nm, out);
    return EF_OK;
}

/* |f'(t)| of a quintic from its hodograph's 5 control points h. */
static float seg_speed(const ef_vec3_t *h, float t)
{
    return ef_v3_norm(ef_bezier_b4(h, t));
}

/* A quintic's hodograph control points. */
static void seg_hodo(const ef_vec3_t *b, ef_vec3_t *h)
{
    for (int i = 0; i < 5; i++)
        h[i] = ef_v3_scale(ef_v3_sub(b[i + 1], b[i]), 5.0f);
}

/* Arc length of a quintic (contract in ef_seg.h). */
float ef_seg_length(const ef_vec3_t *b, int sym)
{
    ef_vec3_t h[5];
    seg_hodo(b, h);
    return ef_bezier_h4_length(h, sym);
}

/* ef_seg_speed_stats() for a quintic whose hodograph h and length l are known. */
static float seg_speed_dev(const ef_vec3_t *h, float l, float *dev_ends)
{
    float inv = 1.0f / ef_maxf(l, 1e-30f), dev = 0.0f;
    for (int i = 0; i <= EF_SEG_SPEED_SAMPLES; i++) {
        float sp = seg_speed(h, (float)i / (float)EF_SEG_SPEED_SAMPLES);
        dev = ef_maxf(dev, ef_fabsf(sp * inv - 1.0f));
    }
    if (dev_ends)
        *dev_ends = ef_maxf(ef_fabsf(ef_v3_norm(h[0]) * inv - 1.0f),
                            ef_fabsf(ef_v3_norm(h[4]) * inv - 1.0f));
    return dev;
}

/* Length, then the speed samples (contract in ef_seg.h). */
float ef_seg_speed_stats(const ef_vec3_t *b, float *len, float *dev_ends)
{
    ef_vec3_t h[5];
    seg_hodo(b, h);
    float l = ef_bezier_h4_length(h, 0);
    *len = l;
    return seg_speed_dev(h, l, dev_ends);
}

/* Finite without libm (NaN fails x == x, inf fails x - x == 0). */
static int seg_finite(float x)
{
    return (x == x) & (x - x == 0.0f);
}

/* ef_seg_even_speed()'s rows (ef_seg.h has the hodograph they weight): B2, u0, w0, u1, w1
 * at the 8 Gauss-Legendre nodes on [0, 1] (the pairs 1/2 -+ offset, innermost first; last
 * column the weight; nodes by Newton's method on P8 in double, rounded to float). */
static const float seg_gl8[EF_SEG_EVEN_GL][6] = {
    {3.501883762e-01f, -2.394380231e-01f, -1.184023543e-02f, -5.115038578e-01f, 1.891026199e-01f,
     1.813418917e-01f},
    {3.501883762e-01f, -5.115038578e-01f, -1.891026199e-01f, -2.394380231e-01f, 1.184023543e-02f,
     1.813418917e-01f},
    {1.964659303e-01f, 3.666985297e-01f, 2.246589268e-01f, -3.490281812e-01f, 1.557296750e-01f,
     1.568533229e-01f},
    {1.964659303e-01f, -3.490281812e-01f, -1.557296750e-01f, 3.666985297e-01f, -2.246589268e-01f,
     1.568533229e-01f},
    {5.004770489e-02f, 8.459740285e-01f, 2.447685245e-01f, -9.621255296e-02f, 4.627168366e-02f,
     1.111905172e-01f},
    {5.004770489e-02f, -9.621255296e-02f, -4.627168366e-02f, 8.459740285e-01f, -2.447685245e-01f,
     1.111905172e-01f},
    {2.272347601e-03f, 9.931521141e-01f, 7.251055938e-02f, -4.513852065e-03f, 2.241659877e-03f,
     5.061426815e-02f},
    {2.272347601e-03f, -4.513852065e-03f, -2.241659877e-03f, 9.931521141e-01f, -7.251055938e-02f,
     5.061426815e-02f},
};
/* The same rows at the 16 Gauss-Legendre nodes (ef_seg_length()'s rule): the rule
 * ef_seg_g2_even() solves x1 = L with, so the 16-node length it checks the result against
 * agrees to rounding. The 8-node rule was off by 0.2-0.3 % on a fuzzed arc piece whose
 * speed varies by +-35 %, which put its ends outside EF_SEG_END_SPEED_REL. */
static const float seg_gl16[16][6] = {
    {3.682600273e-01f, -3.496051143e-01f, -7.120300265e-02f, -4.916950222e-01f, 1.653577987e-01f,
     9.472530523e-02f},
    {3.682600273e-01f, -4.916950222e-01f, -1.653577987e-01f, -3.496051143e-01f, 7.120300265e-02f,
     9.472530523e-02f},
    {3.178827972e-01f, -8.908715969e-02f, 6.018117390e-02f, -5.003268262e-01f, 1.990910577e-01f,
     9.130170752e-02f},
    {3.178827972e-01f, -5.003268262e-01f, -1.990910577e-01f, -8.908715969e-02f, -6.018117390e-02f,
     9.130170752e-02f},
    {2.341682423e-01f, 2.340713598e-01f, 1.857970654e-01f, -4.049125715e-01f, 1.761372418e-01f,
     8.457825970e-02f},
    {2.341682423e-01f, -4.049125715e-01f, -1.761372418e-01f, 2.340713598e-01f, -1.857970654e-01f,
     8.457825970e-02f},
    {1.433276364e-01f, 5.461162761e-01f, 2.612295691e-01f, -2.627544581e-01f, 1.207594106e-01f,
     7.479799441e-02f},
    {1.433276364e-01f, -2.627544581e-01f, -1.207594106e-01f, 5.461162761e-01f, -2.612295691e-01f,
     7.479799441e-02f},
    {6.913259960e-02f, 7.859566037e-01f, 2.616328877e-01f, -1.316196017e-01f, 6.271070653e-02f,
     6.231448563e-02f},
    {6.913259960e-02f, -1.316196017e-01f, -6.271070653e-02f, 7.859566037e-01f, -2.616328877e-01f,
     6.231448563e-02f},
    {2.356566626e-02f, 9.281511103e-01f, 1.945645498e-01f, -4.597944161e-02f, 2.243414922e-02f,
     4.757925584e-02f},
    {2.356566626e-02f, -4.597944161e-02f, -2.243414922e-02f, 9.281511103e-01f, -1.945645498e-01f,
     4.757925584e-02f},
    {4.356038566e-03f, 9.868485229e-01f, 9.753116421e-02f, -8.628715750e-03f, 4.273266980e-03f,
     3.112676197e-02f},
    {4.356038566e-03f, -8.628715750e-03f, -4.273266980e-03f, 9.868485229e-01f, -9.753116421e-02f,
     3.112676197e-02f},
    {1.667289499e-04f, 9.994992202e-01f, 2.069616343e-02f, -3.328649157e-04f, 1.661367546e-04f,
     1.357622971e-02f},
    {1.667289499e-04f, -3.328649157e-04f, -1.661367546e-04f, 9.994992202e-01f, -2.069616343e-02f,
     1.357622971e-02f},
};

/* Newton steps on g(s) = L(s) - s with L by the n-node rows r (contract of
 * ef_seg_even_speed() in ef_seg.h). With both end speeds s, f'(t) = a + s q + s^2 r at each
 * node, so |f'|^2 is a quartic in s whose coefficients (dot products of a, q, r) are
 * computed once; each step is then a few multiplies and a square root per node.
 * g' = L' - 1 is near -1 (L moves little with s); a flat g' takes the fixed-point step
 * instead, and a step to s <= 0 is not taken. Inlined into both callers, so each has its
 * node count as a constant (the 8-node one as cheap as when it was the arc blends' own). */
#ifdef __GNUC__
#define EF_SEG_INLINE static inline __attribute__((always_inline))
#else
#define EF_SEG_INLINE static inline
#endif
EF_SEG_INLINE float seg_even_newton(const float (*rows)[6], int n, const ef_vec3_t *v, float s0,
                                    float x20, float x21, int steps)
{
    float c[16][5];
    for (int i = 0; i < n; i++) {
        const float *r = rows[i];
        ef_vec3_t a = ef_v3_scale(v[0], r[0]);
        a = ef_v3_axpy(a, 0.25f * x20 * r[2], v[1]);
        a = ef_v3_axpy(a, 0.25f * x21 * r[4], v[3]);
        ef_vec3_t q = ef_v3_axpy(ef_v3_scale(v[1], r[1]), r[3], v[3]);
        ef_vec3_t rr = ef_v3_axpy(ef_v3_scale(v[2], r[2]), r[4], v[4]);
        c[i][0] = ef_v3_dot(a, a);
        c[i][1] = 2.0f * ef_v3_dot(a, q);
        c[i][2] = ef_v3_dot(q, q) + 2.0f * ef_v3_dot(a, rr);
        c[i][3] = 2.0f * ef_v3_dot(q, rr);
        c[i][4] = ef_v3_dot(rr, rr);
    }
    float s = s0;
    for (int it = 0; it < steps; it++) {
        float l = 0.0f, dl = 0.0f;
        for (int i = 0; i < n; i++) {
            const float *k = c[i];
            float s2 = k[0] + s * (k[1] + s * (k[2] + s * (k[3] + s * k[4])));
            float ds2 = k[1] + s * (2.0f * k[2] + s * (3.0f * k[3] + s * 4.0f * k[4]));
            float sp = ef_sqrtf(ef_maxf(s2, 0.0f));
            l += rows[i][5] * sp;
            dl += rows[i][5] * (0.5f * ds2 / ef_maxf(sp, 1e-30f));
        }
        float g = l - s, dg = dl - 1.0f;
        float sn = s - g / ef_selectf(dg < -0.1f, dg, -1.0f);
        s = ef_selectf(sn > 0.0f, sn, s);
    }
    return s;
}

/* The 8-node rule (contract in ef_seg.h). */
float ef_seg_even_speed(const ef_vec3_t *v, float s0, float x20, float x21, int steps)
{
    return seg_even_newton(seg_gl8, EF_SEG_EVEN_GL, v, s0, x20, x21, steps);
}

/* End speeds against the 8-node length (contract in ef_seg.h): the degree-4 Bernstein
 * weights from seg_gl8's rows, B0 = u0 - w0 + B2, B1 = w0 + B2, B3 = B2 - w1,
 * B4 = u1 + w1 + B2. */
float ef_seg_end_err(const ef_vec3_t *b)
{
    ef_vec3_t h[5];
    for (int i = 0; i < 5; i++)
        h[i] = ef_v3_sub(b[i + 1], b[i]);
    float len = 0.0f;
    for (int i = 0; i < EF_SEG_EVEN_GL; i++) {
        const float *r = seg_gl8[i];
        ef_vec3_t d = ef_v3_scale(h[0], r[1] - r[2] + r[0]);
        d = ef_v3_axpy(d, r[2] + r[0], h[1]);
        d = ef_v3_axpy(d, r[0], h[2]);
        d = ef_v3_axpy(d, r[0] - r[4], h[3]);
        d = ef_v3_axpy(d, r[3] + r[4] + r[0], h[4]);
        len += r[5] * ef_v3_norm(d);
    }
    /* h is f' / 5, so len is L / 5 and |f'(0)| / L = |h0| / len */
    float inv = 1.0f / ef_maxf(len, 1e-30f);
    float e0 = ef_fabsf(ef_v3_norm(h[0]) * inv - 1.0f);
    return ef_maxf(e0, ef_fabsf(ef_v3_norm(h[4]) * inv - 1.0f));
}

/* A quintic with end speeds x1 = its own length (EF_SEG_EVEN_NEWTON Newton steps on the
 * 16-node length from len, the length of a neighbouring candidate), tangential DOFs x20, x21, built
 * once. The curve is ef_seg_from_dofs()'s for nm, the normalization of (e0, e1) (which the
 * DOFs do not change: made once by the caller, nm_ok its success), bit for bit. 0 when it
 * cannot be built; else *dev and *dev_ends as ef_seg_speed_stats() gives them. */
static int seg_even_ends(const ef_endpoint_t *e0, const ef_endpoint_t *e1, const ef_norm_t *nm,
                         int nm_ok, float len, float x20, float x21, ef_seg_t *c, float *dev,
                         float *dev_ends)
{
    ef_vec3_t v[5];
    v[0] = ef_v3_scale(ef_v3_sub(e1->p, e0->p), 5.0f);
    v[1] = nm->t0;
    v[2] = ef_v3_scale(e0->n, 0.25f * e0->kappa);
    v[3] = nm->t1;
    v[4] = ef_v3_scale(e1->n, 0.25f * e1->kappa);
    float x = seg_even_newton(seg_gl16, 16, v, len, x20, x21, EF_SEG_EVEN_NEWTON);
    int ok = nm_ok & seg_finite(x20) & seg_finite(x21) & seg_finite(x) & (x > 0.0f);
    if (!ok)
        return 0;
    c->dof[0] = c->dof[2] = x;
    c->dof[1] = x20;
    c->dof[3] = x21;
    c->flags = 0;
    c->clamp = 0;
    seg_quintic(e0, e1, nm, c);
    float l;
    *dev = ef_seg_speed_stats(c->b, &l, dev_ends);
    return seg_finite(*dev);
}

/* Three candidates measured, the most even with even ends kept (contract in ef_seg.h). */
int ef_seg_g2_even(const ef_endpoint_t *e0, const ef_endpoint_t *e1, ef_seg_t *seg, float *dev,
                   float *dev_ends)
{
    if (!seg || seg->degree != 5 || !e0 || !e1) {
        if (dev)
            *dev = 0.0f;
        if (dev_ends)
            *dev_ends = 0.0f;
        return EF_SEG_EVEN_TABLE;
    }
    float len = 0.0f, end_t = 0.0f, end_a = 0.0f, end_b = 0.0f;
    float d_t = ef_seg_speed_stats(seg->b, &len, &end_t);
    ef_seg_t a = *seg, b = *seg;
    /* The DOFs do not change the normalization: once, not per curve built. */
    ef_norm_t nm;
    int nm_ok = ef_normalize(e0, e1, 1, &nm) == EF_OK;
    float d_a = 3.4e38f, d_b = 3.4e38f;
    int ok_a = seg_even_ends(e0, e1, &nm, nm_ok, len, seg->dof[1], seg->dof[3], &a, &d_a, &end_a);
    int ok_b = seg_even_ends(e0, e1, &nm, nm_ok, len, 0.0f, 0.0f, &b, &d_b, &end_b);
    /* Newton's length is the 8-node one; a candidate whose ends are not within
     * EF_SEG_END_SPEED_REL of the 16-node length is not taken. */
    d_a = ok_a && end_a <= EF_SEG_END_SPEED_REL ? d_a : 3.4e38f;
    d_b = ok_b && end_b <= EF_SEG_END_SPEED_REL ? d_b : 3.4e38f;
    int pick = EF_SEG_EVEN_TABLE;
    float d = end_t <= EF_SEG_END_SPEED_REL ? d_t : 3.4e38f, e = end_t;
    if (d_a < d) {
        pick = EF_SEG_EVEN_ENDS;
        d = d_a;
        e = end_a;
    }
    if (d_b < d) {
        pick = EF_SEG_EVEN_ARC;
        d = d_b;
        e = end_b;
    }
    if (pick == EF_SEG_EVEN_TABLE) {
        d = d_t; /* also when nothing could be built */
    } else {
        ef_seg_t *w = pick == EF_SEG_EVEN_ARC ? &b : &a;
        w->flags = seg->flags;
        w->clamp = seg->clamp;
        *seg = *w;
    }
    if (dev)
        *dev = d;
    if (dev_ends)
        *dev_ends = e;
    return pick;
}
