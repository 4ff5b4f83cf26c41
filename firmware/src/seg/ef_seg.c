/* SPDX-License-Identifier: Apache-2.0 */
/* Bézier segments from end data: DOFs from a table (or given), then control points. */
#include "evenfeed/seg/ef_seg.h"
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

/* Length, then the speed samples (contract in ef_seg.h). */
float ef_seg_speed_stats(const ef_vec3_t *b, float *len, float *dev_ends)
{
    ef_vec3_t h[5];
    seg_hodo(b, h);
    float l = ef_bezier_h4_length(h, 0);
    *len = l;
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

/* A quintic with end speeds x1 = its own length (x1 = L solved by ef_seg_even_next() over
 * EF_SEG_EVEN_ITER curves, from len, the length of a neighbouring candidate), tangential
 * DOFs x20, x21. 0 when it cannot be built. */
static int seg_even_ends(const ef_endpoint_t *e0, const ef_endpoint_t *e1, float len, float x20,
                         float x21, ef_seg_t *c)
{
    int ok = 1;
    float xa = len, ga = 0.0f, x = len;
    for (int it = 0; it < EF_SEG_EVEN_ITER; it++) {
        float dof[4] = {x, x20, x, x21};
        if (ok)
            ok = ef_seg_from_dofs(e0, e1, 5, dof, c) == EF_OK;
        ef_vec3_t h[5];
        seg_hodo(c->b, h);
        float g = ef_bezier_h4_length(h, 0) - x;
        float xn = it == 0 ? x + g : ef_seg_even_next(xa, ga, x, g);
        xa = x;
        ga = g;
        x = ef_selectf(xn > 0.0f, xn, x); /* the last curve built is the result */
    }
    return ok;
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
    int ok_a = seg_even_ends(e0, e1, len, seg->dof[1], seg->dof[3], &a);
    int ok_b = seg_even_ends(e0, e1, len, 0.0f, 0.0f, &b);
    float d_a = ok_a ? ef_seg_speed_stats(a.b, &len, &end_a) : 3.4e38f;
    float d_b = ok_b ? ef_seg_speed_stats(b.b, &len, &end_b) : 3.4e38f;
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
