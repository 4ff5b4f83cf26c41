/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Path primitives and arc-ended corner blends with the default G2 table:
 * - ef_prim_check(): every bad-input case with its exact error code;
 * - ef_prim_frame(): against analytic values (lines, arcs both ways, helices);
 * - ef_move_measure(): lengths and curvature against double-precision references;
 * - ef_blend_arc_piece(): deviation from the true arc/helix measured independently in double
 *   (prints the largest dev/r at EF_ARC_PIECE_SWEEP and at half of it);
 * - ef_blend_prims(): thousands of random line–arc, arc–line and arc–arc corners (2-D and
 *   3-D, arcs both ways, helices, small and large radii against the tolerance, turns up to
 *   and past the reversal threshold, short neighbours), deviation measured in double by
 *   dense sampling against the exact lines/arcs, G2 contact at both ends, trim limits.
 */
#include <float.h>
#include <string.h>
#include "ef_test.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/path/ef_path.h"
#include "evenfeed/seg/ef_seg.h"

extern const ef_table_t ef_tbl_g2_default;
#define G2 (&ef_tbl_g2_default)

/* ---- double helpers ----------------------------------------------------------------- */

typedef struct {
    double x, y, z;
} dv3;

static dv3 d3(double x, double y, double z)
{
    dv3 r = {x, y, z};
    return r;
}
static dv3 dv(ef_vec3_t a)
{
    return d3(a.x, a.y, a.z);
}
static ef_vec3_t fv(dv3 a)
{
    return ef_v3((float)a.x, (float)a.y, (float)a.z);
}
static double ddot(dv3 a, dv3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
static dv3 dadd(dv3 a, dv3 b)
{
    return d3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static dv3 dsub(dv3 a, dv3 b)
{
    return d3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static dv3 dscale(dv3 a, double s)
{
    return d3(a.x * s, a.y * s, a.z * s);
}
static dv3 daxpy(dv3 a, double s, dv3 b)
{
    return d3(a.x + s * b.x, a.y + s * b.y, a.z + s * b.z);
}
static dv3 dcross(dv3 a, dv3 b)
{
    return d3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static double dnorm(dv3 a)
{
    return sqrt(ddot(a, a));
}
static dv3 dunit(dv3 a)
{
    return dscale(a, 1.0 / dnorm(a));
}
static dv3 rand_unit(unsigned long long *s)
{
    for (;;) {
        dv3 r = d3(ef_t_uniform(s, -1, 1), ef_t_uniform(s, -1, 1), ef_t_uniform(s, -1, 1));
        double n = dnorm(r);
        if (n > 0.1 && n <= 1.0)
            return dscale(r, 1.0 / n);
    }
}
/* A unit vector perpendicular to u. */
static dv3 rand_perp(unsigned long long *s, dv3 u)
{
    for (;;) {
        dv3 r = rand_unit(s);
        dv3 p = daxpy(r, -ddot(r, u), u);
        if (dnorm(p) > 0.2)
            return dunit(p);
    }
}
static double log_uniform(unsigned long long *s, double lo, double hi)
{
    return exp(ef_t_uniform(s, log(lo), log(hi)));
}

/* Quintic (or any degree) in double from the float control points, with derivatives. */
static void bez_d(const ef_vec3_t *bf, int deg, double t, dv3 *p, dv3 *d1, dv3 *d2)
{
    dv3 b[6];
    for (int i = 0; i <= deg; i++)
        b[i] = dv(bf[i]);
    dv3 w[6];
    for (int i = 0; i <= deg; i++)
        w[i] = b[i];
    /* de Casteljau keeping the last three levels for the derivatives */
    dv3 lv2[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, lv1[2] = {{0, 0, 0}, {0, 0, 0}};
    for (int r = deg; r >= 1; r--) {
        if (r == 2)
            for (int i = 0; i < 3; i++)
                lv2[i] = w[i];
        if (r == 1)
            for (int i = 0; i < 2; i++)
                lv1[i] = w[i];
        for (int i = 0; i < r; i++)
            w[i] = daxpy(dscale(w[i], 1.0 - t), t, w[i + 1]);
    }
    if (deg == 1) {
        lv1[0] = b[0];
        lv1[1] = b[1];
    }
    *p = w[0];
    if (d1)
        *d1 = dscale(dsub(lv1[1], lv1[0]), deg);
    if (d2)
        *d2 = deg >= 2 ? dscale(daxpy(dsub(lv2[2], lv2[1]), -1.0, dsub(lv2[1], lv2[0])),
                                (double)deg * (deg - 1))
                       : d3(0, 0, 0);
}

/* ---- exact primitive model in double --------------------------------------------------- */

typedef struct {
    int arc;
    dv3 start, end;        /* line: start, end */
    dv3 a, base, eu, ev;   /* arc: unit axis, axis point level with start, radial, a x eu */
    double r0, h, sw, len; /* start radius, axial rise, sweep, length */
} dprim_t;

static dprim_t dprim(ef_vec3_t start, const ef_prim_t *pr)
{
    dprim_t m;
    memset(&m, 0, sizeof m);
    m.start = dv(start);
    m.end = dv(pr->end);
    if (pr->kind == EF_PRIM_LINE) {
        m.len = dnorm(dsub(m.end, m.start));
        return m;
    }
    m.arc = 1;
    m.a = dunit(dv(pr->axis));
    dv3 d0 = dsub(m.start, dv(pr->centre));
    double h0 = ddot(d0, m.a);
    dv3 w = daxpy(d0, -h0, m.a);
    m.r0 = dnorm(w);
    m.eu = dscale(w, 1.0 / m.r0);
    m.ev = dcross(m.a, m.eu);
    m.base = daxpy(m.start, -m.r0, m.eu);
    m.h = ddot(dsub(m.end, dv(pr->centre)), m.a) - h0;
    m.sw = pr->sweep;
    m.len = sqrt(m.r0 * m.r0 * m.sw * m.sw + m.h * m.h);
    return m;
}

/* Point, unit tangent and curvature vector at arc length s. */
static void dprim_at(const dprim_t *m, double s, dv3 *p, dv3 *t, dv3 *kv)
{
    if (!m->arc) {
        dv3 u = dunit(dsub(m->end, m->start));
        *p = daxpy(m->start, s, u);
        if (t)
            *t = u;
        if (kv)
            *kv = d3(0, 0, 0);
        return;
    }
    double f = s / m->len, th = m->sw * f;
    dv3 rad = dadd(dscale(m->eu, cos(th)), dscale(m->ev, sin(th)));
    *p = daxpy(daxpy(m->base, m->r0, rad), m->h * f, m->a);
    if (t) {
        dv3 tg = dadd(dscale(m->eu, -sin(th)), dscale(m->ev, cos(th)));
        *t = dscale(daxpy(dscale(tg, m->r0 * m->sw), m->h, m->a), 1.0 / m->len);
    }
    if (kv)
        *kv = dscale(rad, -m->r0 * m->sw * m->sw / (m->len * m->len));
}

/* Exact distance from q to the piece [sa, sb] of the primitive. Arcs: the nearest point is
 * a stationary point of |q - P(s)| (Newton from q's polar angle, for circles exact at once)
 * or an end of the piece. */
static double dprim_dist(const dprim_t *m, dv3 q, double sa, double sb)
{
    dv3 p, t;
    if (!m->arc) {
        dv3 u = dunit(dsub(m->end, m->start));
        double s = ddot(dsub(q, m->start), u);
        s = s < sa ? sa : s > sb ? sb : s;
        return dnorm(dsub(q, daxpy(m->start, s, u)));
    }
    dprim_at(m, sa, &p, NULL, NULL);
    double best = dnorm(dsub(q, p));
    dprim_at(m, sb, &p, NULL, NULL);
    double d = dnorm(dsub(q, p));
    best = d < best ? d : best;
    /* polar angle relative to the middle of the piece */
    double sm = 0.5 * (sa + sb), thm = m->sw * sm / m->len;
    dv3 em = dadd(dscale(m->eu, cos(thm)), dscale(m->ev, sin(thm)));
    dv3 pm;
    dprim_at(m, sm, &pm, NULL, NULL);
    dv3 cm = daxpy(pm, -m->r0, em);
    dv3 w = dsub(q, cm);
    w = daxpy(w, -ddot(w, m->a), m->a);
    double dpsi = atan2(ddot(w, dcross(m->a, em)), ddot(w, em));
    double s = sm + dpsi * m->len / m->sw;
    for (int it = 0; it < 4; it++) {
        s = s < sa ? sa : s > sb ? sb : s;
        dv3 kv;
        dprim_at(m, s, &p, &t, &kv);
        dv3 r = dsub(p, q);
        double g = ddot(r, t), gp = 1.0 + ddot(r, kv);
        if (gp < 0.1)
            gp = 0.1;
        s -= g / gp;
    }
    s = s < sa ? sa : s > sb ? sb : s;
    dprim_at(m, s, &p, NULL, NULL);
    d = dnorm(dsub(q, p));
    return d < best ? d : best;
}

/* ---- ef_prim_check ---------------------------------------------------------------------- */

static ef_prim_t mk_line(ef_vec3_t end)
{
    ef_prim_t p;
    memset(&p, 0, sizeof p);
    p.kind = EF_PRIM_LINE;
    p.end = end;
    p.feed = 10.0f;
    p.tol = 0.01f;
    return p;
}

/* Arc from start about axis through centre by sweep (exact in double, rounded to float). */
static ef_prim_t mk_arc_d(dv3 start, dv3 centre, dv3 axis, double sweep, double rise)
{
    ef_prim_t p;
    memset(&p, 0, sizeof p);
    p.kind = EF_PRIM_ARC;
    dv3 a = dunit(axis);
    dv3 w = dsub(start, centre);
    dv3 c = daxpy(centre, ddot(w, a), a); /* level with the start */
    w = dsub(start, c);
    dv3 ev = dcross(a, w);
    dv3 e = daxpy(dadd(c, dadd(dscale(w, cos(sweep)), dscale(ev, sin(sweep)))), rise, a);
    p.end = fv(e);
    p.centre = fv(c);
    p.axis = fv(a);
    p.sweep = (float)sweep;
    p.feed = 10.0f;
    p.tol = 0.01f;
    return p;
}

static void test_check(void)
{
    ef_vec3_t o = ef_v3(0, 0, 0);
    float len = -1;
    ef_prim_t l = mk_line(ef_v3(3, 4, 0));
    EF_CHECK_EQ(ef_prim_check(o, &l, &len), EF_OK);
    EF_CHECK_NEAR(len, 5.0, 1e-6);
    EF_CHECK_EQ(ef_prim_check(o, NULL, &len), EF_ERR_ARG);
    EF_CHECK_EQ(len, 0);
    EF_CHECK_EQ(ef_prim_check(o, &l, NULL), EF_ERR_ARG);
    ef_prim_t b = l;
    b.kind = 7;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_ARG);
    b = l;
    b.flags = 2;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_ARG);
    b = l;
    b.flags = EF_PRIM_STOP_BEFORE;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_OK);
    b = l;
    b.tol = -1e-3f;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_ARG);
    b = l;
    b.qtol = -1e-3f;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_ARG);
    b = l;
    b.tol = 0.0f; /* exact stop: allowed */
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_OK);
    b = l;
    b.end.y = NAN;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_NONFINITE);
    EF_CHECK_EQ(len, 0);
    b = l;
    b.end.z = INFINITY;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_NONFINITE);
    b = l;
    b.end.x = 2e6f;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_prim_check(ef_v3(-2e6f, 0, 0), &l, &len), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_prim_check(ef_v3(0, NAN, 0), &l, &len), EF_ERR_NONFINITE);
    b = l;
    b.feed = NAN;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_NONFINITE);
    b.feed = INFINITY;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_NONFINITE);
    b.feed = 0.0f;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_FEED);
    b.feed = -1.0f;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_FEED);
    b = l;
    b.tol = INFINITY;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_NONFINITE);
    b = l;
    b.qtol = NAN;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_NONFINITE);
    b = l;
    b.end = o; /* zero length */
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_DEGENERATE);
    b.end = ef_v3(5e-7f, 0, 0);
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_ERR_DEGENERATE);
    /* a line's unused arc fields may hold anything */
    b = l;
    b.centre.x = NAN;
    b.sweep = INFINITY;
    EF_CHECK_EQ(ef_prim_check(o, &b, &len), EF_OK);

    /* arcs: quarter circle r = 2 about (0,0,0) from (2,0,0) */
    ef_prim_t a = mk_arc_d(d3(2, 0, 0), d3(0, 0, 0), d3(0, 0, 1), M_PI / 2, 0);
    EF_CHECK_EQ(ef_prim_check(ef_v3(2, 0, 0), &a, &len), EF_OK);
    EF_CHECK_NEAR(len, M_PI, 1e-6);
    /* helix: rise 3 over a full turn and a quarter, r = 2 */
    ef_prim_t hx = mk_arc_d(d3(2, 0, 0), d3(0, 0, 0), d3(0, 0, 1), 2.5 * M_PI, 3.0);
    EF_CHECK_EQ(ef_prim_check(ef_v3(2, 0, 0), &hx, &len), EF_OK);
    EF_CHECK_NEAR(len, sqrt(pow(2 * 2.5 * M_PI, 2) + 9.0), 2e-5);
    ef_vec3_t s2 = ef_v3(2, 0, 0);
    b = a;
    b.centre.z = NAN;
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_NONFINITE);
    b = a;
    b.centre.x = -3e6f;
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_NONFINITE);
    b = a;
    b.axis.y = INFINITY;
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_NONFINITE);
    b = a;
    b.sweep = NAN;
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_NONFINITE);
    b = a;
    b.feed = 0.0f;
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_FEED);
    b = a;
    b.sweep = 0.0f;
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_ARC);
    b = a;
    b.sweep = -0.0f;
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_ARC);
    b = a;
    b.sweep = EF_ARC_MAX_SWEEP * 1.01f;
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_ARC);
    b = a;
    b.axis = ef_v3(0, 0, 1.1f); /* not unit */
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_ARC);
    b.axis = ef_v3(0, 0, 0);
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_ARC);
    b = a;
    b.end = ef_v3(0, 2.01f, 0); /* radius 2.01 vs 2: beyond max(0.002, 0.002) */
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_ARC);
    b.end = ef_v3(0, 2.0015f, 0); /* within */
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_OK);
    b = a;
    b.sweep = (float)(M_PI / 2 + 0.01); /* end angle not where the sweep reaches */
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_ARC);
    b.sweep = (float)(M_PI / 2 + 2 * M_PI); /* a full turn more: consistent */
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_OK);
    EF_CHECK_NEAR(len, 2 * (2.5 * M_PI), 1e-5);
    b.sweep = (float)(M_PI / 2 - 2 * M_PI); /* the other way round to the same end */
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_OK);
    EF_CHECK_NEAR(len, 2 * (1.5 * M_PI), 1e-5);
    b.sweep = (float)(-M_PI / 2); /* clockwise would end at (0,-2) */
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_ARC);
    /* The angle's allowance, max(0.002, 0.001 r) / r + 8 eps (|sweep| + 2 pi): the end turned
     * about the centre by 0.97 of it is taken, by 1.03 of it refused, either way round, also
     * after many turns (the end's distance from where the sweep reaches, as an angle). */
    for (int turns = 0; turns <= 400; turns += 200) {
        for (int side = -1; side <= 1; side += 2) {
            double sw = M_PI / 2 + 2 * M_PI * turns;
            double allow = 0.002 / 2.0 + 8.0 * 1.1920929e-7 * ((float)sw + 2 * M_PI);
            for (int k = 0; k < 2; k++) {
                double ang = M_PI / 2 + side * (k ? 1.03 : 0.97) * allow;
                b = a;
                b.sweep = (float)sw;
                b.end = ef_v3((float)(2 * cos(ang)), (float)(2 * sin(ang)), 0.0f);
                EF_CHECK_EQ(ef_prim_check(s2, &b, &len), k ? EF_ERR_ARC : EF_OK);
            }
        }
    }
    /* A radius below EF_ARC_ABS_TOL / 2: the whole circle is within the tolerance of its
     * model, so any end angle on it is taken (allowance above 2 rad). */
    b = mk_arc_d(d3(4e-4, 0, 0), d3(0, 0, 0), d3(0, 0, 1), M_PI / 2, 0);
    b.end = ef_v3(-4e-4f, 0.0f, 0.0f);
    EF_CHECK_EQ(ef_prim_check(ef_v3(4e-4f, 0, 0), &b, &len), EF_OK);
    /* zero radius (start on the axis) */
    b = a;
    b.centre = s2;
    b.end = s2;
    EF_CHECK_EQ(ef_prim_check(s2, &b, &len), EF_ERR_DEGENERATE);
    /* full circle, many turns, near the sweep limit */
    ef_prim_t full = mk_arc_d(d3(1, 0, 0), d3(0, 0, 0), d3(0, 0, 1), 999 * 2 * M_PI, 0);
    EF_CHECK_EQ(ef_prim_check(ef_v3(1, 0, 0), &full, &len), EF_OK);
    EF_CHECK_NEAR(len, 999 * 2 * M_PI, 2e-3);
    {
        /* its end frame through the kept sine and cosine of 999 turns: ef_prim_frame()'s */
        ef_prim_geo_t fg;
        ef_frame_t f0, f1;
        ef_prim_geo(ef_v3(1, 0, 0), &full, &fg);
        EF_CHECK_EQ(ef_prim_frame_end_geo(ef_v3(1, 0, 0), &full, &fg, 1, &f0), EF_OK);
        EF_CHECK_EQ(ef_prim_frame(ef_v3(1, 0, 0), &full, len, &f1), EF_OK);
        EF_CHECK(memcmp(&f0, &f1, sizeof f0) == 0);
    }
    /* arcs at large radius with small tolerance mismatch */
    ef_prim_t big = mk_arc_d(d3(1000, 0, 0), d3(0, 0, 0), d3(0, 0, -1), 0.3, 0);
    EF_CHECK_EQ(ef_prim_check(ef_v3(1000, 0, 0), &big, &len), EF_OK);
    big.end.x += 0.9f; /* radius +0.9 vs rel tol 1.0: fine */
    big.end.y -= 0.0f;
    EF_CHECK_EQ(ef_prim_check(ef_v3(1000, 0, 0), &big, &len), EF_OK);
    big.end.x += 0.5f;
    EF_CHECK_EQ(ef_prim_check(ef_v3(1000, 0, 0), &big, &len), EF_ERR_ARC);
}

/* ---- ef_prim_frame ---------------------------------------------------------------------- */

/* Two blends equal field by field, bit for bit (padding aside). */
static int same_blend(const ef_blend_t *a, const ef_blend_t *b)
{
    const ef_seg_t *x = &a->seg, *y = &b->seg;
    int s = memcmp(x->b, y->b, sizeof x->b) == 0 && x->degree == y->degree && x->ndof == y->ndof &&
            x->flags == y->flags && x->clamp == y->clamp &&
            memcmp(x->dof, y->dof, sizeof x->dof) == 0 &&
            memcmp(&x->norm, &y->norm, sizeof x->norm) == 0;
    return s && memcmp(&a->p_in, &b->p_in, sizeof a->p_in) == 0 &&
           memcmp(&a->p_out, &b->p_out, sizeof a->p_out) == 0 &&
           memcmp(&a->trim_in, &b->trim_in, sizeof(float)) == 0 &&
           memcmp(&a->trim_out, &b->trim_out, sizeof(float)) == 0 &&
           memcmp(&a->dev, &b->dev, sizeof(float)) == 0 &&
           memcmp(&a->gain, &b->gain, sizeof(float)) == 0 &&
           memcmp(&a->turn, &b->turn, sizeof(float)) == 0 && a->flags == b->flags;
}

/* ef_prim_check_geo(): the codes of ef_prim_check(), a line's geometry zero as
 * ef_prim_geo()'s, a refused primitive's zero too, NULL geo refused. */
static void test_check_geo(void)
{
    ef_vec3_t o = ef_v3(0, 0, 0);
    ef_prim_geo_t g, z;
    memset(&z, 0, sizeof z);
    float len = -1;
    ef_prim_t l = mk_line(ef_v3(3, 4, 0));
    memset(&g, 0x5a, sizeof g);
    EF_CHECK_EQ(ef_prim_check_geo(o, &l, &len, &g), EF_OK);
    EF_CHECK_NEAR(len, 5.0, 1e-6);
    EF_CHECK(memcmp(&g, &z, sizeof g) == 0);
    EF_CHECK_EQ(ef_prim_check_geo(o, &l, &len, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_prim_check_geo(o, NULL, &len, &g), EF_ERR_ARG);
    EF_CHECK_EQ(ef_prim_check_geo(o, &l, NULL, &g), EF_ERR_ARG);
    ef_prim_t a = mk_arc_d(d3(2, 0, 0), d3(0, 0, 0), d3(0, 0, 1), M_PI / 2, 0);
    ef_prim_t bad[4] = {a, a, a, a};
    bad[0].end.x += 0.5f;   /* end off the circle */
    bad[1].sweep = NAN;     /* not finite */
    bad[2].feed = 0.0f;     /* no feed */
    bad[3].centre.x = 2.0f; /* radius 0 at the start */
    for (int i = 0; i < 4; i++) {
        float l1 = -1, l2 = -1;
        int rc = ef_prim_check(ef_v3(2, 0, 0), &bad[i], &l1);
        memset(&g, 0x5a, sizeof g);
        EF_CHECK(rc != EF_OK);
        EF_CHECK_EQ(ef_prim_check_geo(ef_v3(2, 0, 0), &bad[i], &l2, &g), rc);
        EF_CHECK(l1 == l2);
        EF_CHECK(memcmp(&g, &z, sizeof g) == 0);
    }
}

static void test_frame(void)
{
    ef_frame_t f;
    float len;
    /* line */
    ef_prim_t l = mk_line(ef_v3(4, 3, 12));
    ef_vec3_t st = ef_v3(1, -1, 0);
    EF_CHECK_EQ(ef_prim_check(st, &l, &len), EF_OK);
    EF_CHECK_EQ(ef_prim_frame(st, &l, 6.5f, &f), EF_OK);
    EF_CHECK_NEAR(f.p.x, 1 + 6.5 * 3 / 13.0, 1e-5);
    EF_CHECK_NEAR(f.p.y, -1 + 6.5 * 4 / 13.0, 1e-5);
    EF_CHECK_NEAR(f.p.z, 6.5 * 12 / 13.0, 1e-5);
    EF_CHECK_NEAR(f.t.z, 12 / 13.0, 1e-6);
    EF_CHECK_EQ(f.kappa == 0.0f, 1);
    EF_CHECK_EQ(ef_prim_frame(st, &l, len, &f), EF_OK);
    EF_CHECK(memcmp(&f.p, &l.end, sizeof f.p) == 0);
    EF_CHECK_EQ(ef_prim_frame(st, &l, 1e9f, &f), EF_OK); /* clamped */
    EF_CHECK(memcmp(&f.p, &l.end, sizeof f.p) == 0);
    EF_CHECK_EQ(ef_prim_frame(st, &l, -3.0f, &f), EF_OK);
    EF_CHECK(memcmp(&f.p, &st, sizeof f.p) == 0);
    EF_CHECK_EQ(ef_prim_frame(st, NULL, 0.0f, &f), EF_ERR_ARG);
    EF_CHECK_EQ(ef_prim_frame(st, &l, 0.0f, NULL), EF_ERR_ARG);
    ef_prim_geo_t lg;
    ef_prim_geo(st, &l, &lg); /* a line's geometry is all zero; frames still right */
    EF_CHECK(lg.r0 == 0.0f && lg.len == 0.0f);
    ef_frame_t fl;
    EF_CHECK_EQ(ef_prim_frame_geo(st, &l, &lg, 6.5f, &fl), EF_OK);
    EF_CHECK_EQ(ef_prim_frame(st, &l, 6.5f, &f), EF_OK);
    EF_CHECK(memcmp(&fl, &f, sizeof f) == 0);
    EF_CHECK_EQ(ef_prim_frame_geo(st, &l, NULL, 0.0f, &fl), EF_ERR_ARG);
    for (int e = 0; e < 2; e++) { /* a line's end frames: ef_prim_frame()'s at 0 and len */
        EF_CHECK_EQ(ef_prim_frame_end_geo(st, &l, &lg, e, &fl), EF_OK);
        EF_CHECK_EQ(ef_prim_frame(st, &l, e ? 1e9f : 0.0f, &f), EF_OK);
        EF_CHECK(memcmp(&fl, &f, sizeof f) == 0);
    }
    EF_CHECK_EQ(ef_prim_frame_end_geo(st, &l, NULL, 1, &fl), EF_ERR_ARG);
    EF_CHECK_EQ(ef_prim_frame_end_geo(st, NULL, &lg, 1, &fl), EF_ERR_ARG);
    EF_CHECK_EQ(ef_prim_frame_end_geo(st, &l, &lg, 1, NULL), EF_ERR_ARG);
    EF_CHECK(ef_prim_end_gap_geo(&l, &lg) == 0.0f);
    ef_prim_geo(st, &l, NULL); /* nothing to fill: no crash */
    ef_prim_t bad = l;
    bad.kind = 0;
    EF_CHECK_EQ(ef_prim_frame(st, &bad, 0.0f, &f), EF_ERR_ARG);

    /* arcs and helices in random orientations against the analytic formulas */
    unsigned long long seed = 11;
    double worst_p = 0, worst_t = 0, worst_k = 0, worst_n = 0;
    for (int i = 0; i < 4000; i++) {
        dv3 a = (i & 1) ? rand_unit(&seed) : d3(0, 0, (i & 2) ? 1 : -1);
        double r = log_uniform(&seed, 0.01, 500);
        dv3 c = d3(ef_t_uniform(&seed, -100, 100), ef_t_uniform(&seed, -100, 100),
                   ef_t_uniform(&seed, -100, 100));
        dv3 s0 = daxpy(c, r, rand_perp(&seed, a));
        double sw = ef_t_uniform(&seed, -20, 20);
        if (fabs(sw) < 0.01)
            sw = 0.5;
        double rise = (i % 3 == 0) ? ef_t_uniform(&seed, -3, 3) * r : 0.0;
        ef_prim_t pr = mk_arc_d(s0, c, a, sw, rise);
        ef_vec3_t sf = fv(s0);
        int rc = ef_prim_check(sf, &pr, &len);
        EF_CHECK_EQ(rc, EF_OK);
        if (rc != EF_OK)
            continue;
        dprim_t m = dprim(sf, &pr);
        EF_CHECK_NEAR(len, m.len, 2e-6 * m.len + 1e-6);
        double scale = dnorm(c) + r + fabs(rise);
        /* the arc's geometry once for all its frames gives the same bits as each call */
        ef_prim_geo_t geo;
        ef_prim_geo(sf, &pr, &geo);
        EF_CHECK(ef_prim_end_gap_geo(&pr, &geo) == ef_prim_end_gap(sf, &pr));
        /* the check that keeps its geometry: the same length, the same geometry's bits */
        ef_prim_geo_t cg;
        float clen = -1.0f;
        EF_CHECK_EQ(ef_prim_check_geo(sf, &pr, &clen, &cg), EF_OK);
        EF_CHECK(clen == len);
        EF_CHECK(memcmp(&cg, &geo, sizeof geo) == 0);
        /* the frames at the ends without a sine and cosine: the same bits */
        ef_frame_t fe, fr;
        for (int e = 0; e < 2; e++) {
            EF_CHECK_EQ(ef_prim_frame_end_geo(sf, &pr, &geo, e, &fe), EF_OK);
            EF_CHECK_EQ(ef_prim_frame_geo(sf, &pr, &geo, e ? len : 0.0f, &fr), EF_OK);
            EF_CHECK(memcmp(&fe, &fr, sizeof fe) == 0);
        }
        for (int k = 0; k <= 8; k++) {
            double s = k == 8 ? (double)len : m.len * k / 8.0;
            EF_CHECK_EQ(ef_prim_frame(sf, &pr, (float)s, &f), EF_OK);
            ef_frame_t fg;
            EF_CHECK_EQ(ef_prim_frame_geo(sf, &pr, &geo, (float)s, &fg), EF_OK);
            EF_CHECK(memcmp(&fg, &f, sizeof f) == 0);
            dv3 p, t, kv;
            dprim_at(&m, s, &p, &t, &kv);
            if (k == 8)
                EF_CHECK(memcmp(&f.p, &pr.end, sizeof f.p) == 0);
            else {
                double ep = dnorm(dsub(dv(f.p), p)) / scale;
                worst_p = fmax(worst_p, ep);
            }
            worst_t = fmax(worst_t, dnorm(dsub(dv(f.t), t)));
            double kk = dnorm(kv);
            worst_k = fmax(worst_k, fabs(f.kappa - kk) / kk);
            worst_n = fmax(worst_n, dnorm(dsub(dscale(dv(f.n), f.kappa), kv)) / kk);
            /* helix curvature r / (r^2 + c^2) with c = h / sweep */
            double cc = m.h / m.sw;
            EF_CHECK_NEAR(f.kappa, m.r0 / (m.r0 * m.r0 + cc * cc), 1e-5 * kk);
        }
    }
    printf("frame: position err/scale %.3g (float32 rounding of the arguments: sweep to "
           "20 rad), tangent %.3g, kappa rel %.3g, kappa*n rel %.3g\n",
           worst_p, worst_t, worst_k, worst_n);
    EF_CHECK(worst_p < 2e-5);
    EF_CHECK(worst_t < 2e-5);
    EF_CHECK(worst_k < 1e-5);
    EF_CHECK(worst_n < 2e-5);

    /* exact at s = 0 and s = len; a quarter arc's midpoint */
    ef_prim_t q = mk_arc_d(d3(3, 1, 0), d3(1, 1, 0), d3(0, 0, 1), M_PI / 2, 0);
    st = ef_v3(3, 1, 0);
    EF_CHECK_EQ(ef_prim_check(st, &q, &len), EF_OK);
    EF_CHECK_EQ(ef_prim_frame(st, &q, 0.0f, &f), EF_OK);
    EF_CHECK(memcmp(&f.p, &st, sizeof f.p) == 0);
    EF_CHECK_NEAR(f.t.y, 1.0, 1e-7);
    EF_CHECK_NEAR(f.n.x, -1.0, 1e-7);
    EF_CHECK_NEAR(f.kappa, 0.5, 1e-7);
    EF_CHECK_EQ(ef_prim_frame(st, &q, 0.5f * len, &f), EF_OK);
    EF_CHECK_NEAR(f.p.x, 1 + sqrt(2.0), 1e-6);
    EF_CHECK_NEAR(f.p.y, 1 + sqrt(2.0), 1e-6);
    EF_CHECK_NEAR(f.t.x, -sqrt(0.5), 1e-6);
    EF_CHECK_NEAR(f.t.y, sqrt(0.5), 1e-6);
    /* clockwise: tangent the other way, normal still towards the centre */
    ef_prim_t cw = mk_arc_d(d3(3, 1, 0), d3(1, 1, 0), d3(0, 0, 1), -M_PI / 2, 0);
    EF_CHECK_EQ(ef_prim_check(st, &cw, &len), EF_OK);
    EF_CHECK_EQ(ef_prim_frame(st, &cw, 0.0f, &f), EF_OK);
    EF_CHECK_NEAR(f.t.y, -1.0, 1e-7);
    EF_CHECK_NEAR(f.n.x, -1.0, 1e-7);
}

/* ---- ef_move_measure ---------------------------------------------------------------------- */

static double dlength(const ef_vec3_t *b, int deg)
{
    double L = 0;
    int n = 20000;
    for (int i = 0; i < n; i++) {
        dv3 p, d1;
        bez_d(b, deg, (i + 0.5) / n, &p, &d1, NULL);
        L += dnorm(d1) / n;
    }
    return L;
}

static void test_measure(void)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    EF_CHECK_EQ(ef_move_measure(NULL), EF_ERR_ARG);
    m.degree = 1;
    m.b[0] = ef_v3(1, 2, 3);
    m.b[1] = ef_v3(4, 6, 3);
    EF_CHECK_EQ(ef_move_measure(&m), EF_OK);
    EF_CHECK_EQ(m.length == 5.0f, 1);
    EF_CHECK_EQ(m.kappa_max == 0.0f, 1);
    EF_CHECK_NEAR(m.tabs.x, 0.6, 1e-7);
    EF_CHECK_NEAR(m.tabs.y, 0.8, 1e-7);
    EF_CHECK_NEAR(m.tabs.z, 0.0, 0);
    m.degree = 2;
    EF_CHECK_EQ(ef_move_measure(&m), EF_ERR_ARG);
    EF_CHECK_EQ(m.length == 0.0f, 1);
    m.degree = 5;
    for (int i = 0; i < 6; i++)
        m.b[i] = ef_v3((float)i, (float)(i * i), 0);
    m.b[3].z = NAN;
    EF_CHECK_EQ(ef_move_measure(&m), EF_ERR_NONFINITE);
    EF_CHECK_EQ(m.length == 0.0f, 1);

    /* a uniformly parametrized straight quintic: exact length */
    for (int i = 0; i < 6; i++)
        m.b[i] = ef_v3(2.0f * (float)i, -(float)i, 0.5f * (float)i);
    EF_CHECK_EQ(ef_move_measure(&m), EF_OK);
    EF_CHECK_NEAR(m.length, 5 * sqrt(4 + 1 + 0.25), 1e-5);
    EF_CHECK(m.kappa_max < 1e-5f);

    /* random quintics and cubics against a dense double integral */
    unsigned long long seed = 5;
    double worst = 0;
    for (int k = 0; k < 300; k++) {
        int deg = k & 1 ? 5 : 3;
        memset(&m, 0, sizeof m);
        m.degree = (uint8_t)deg;
        dv3 p = d3(0, 0, 0), dir = rand_unit(&seed);
        for (int i = 0; i <= deg; i++) {
            m.b[i] = fv(p);
            dir = dunit(daxpy(dir, 0.4, rand_unit(&seed)));
            p = daxpy(p, ef_t_uniform(&seed, 0.5, 1.5), dir);
        }
        EF_CHECK_EQ(ef_move_measure(&m), EF_OK);
        double L = dlength(m.b, deg);
        worst = fmax(worst, fabs(m.length - L) / L);
        /* kappa_max and tabs at the samples */
        double km = 0, tx = 0;
        for (int i = 0; i <= EF_MOVE_SAMPLES; i++) {
            dv3 q, d1, d2;
            bez_d(m.b, deg, (double)i / EF_MOVE_SAMPLES, &q, &d1, &d2);
            double sp = dnorm(d1);
            km = fmax(km, dnorm(dcross(d1, d2)) / (sp * sp * sp));
            /* the larger of |t_x| and |f'_x| / L (ef_path.h) */
            tx = fmax(tx, fabs(d1.x) / fmin(sp, L));
        }
        EF_CHECK_NEAR(m.kappa_max, km, 1e-4 * km + 1e-6);
        EF_CHECK_NEAR(m.tabs.x, tx, 1e-5 * (1 + tx));
    }
    printf("measure: random curves, length rel err %.3g (16-node Gauss-Legendre)\n", worst);
    EF_CHECK(worst < 1e-4);
}

/* ---- arc pieces -------------------------------------------------------------------------- */

/* Independent deviation of a quintic from the piece [sa, sb] of a primitive (double, 2000
 * samples plus the neighbourhood of the worst one refined 20x). */
static double dev_piece(const ef_vec3_t *b, const dprim_t *m, double sa, double sb)
{
    int ns = 2000, imax = 0;
    double worst = 0;
    for (int i = 0; i <= ns; i++) {
        dv3 p;
        bez_d(b, 5, (double)i / ns, &p, NULL, NULL);
        double d = dprim_dist(m, p, sa, sb);
        if (d > worst)
            worst = d, imax = i;
    }
    for (int i = -20; i <= 20; i++) {
        double t = (imax + i / 20.0) / ns;
        if (t < 0 || t > 1)
            continue;
        dv3 p;
        bez_d(b, 5, t, &p, NULL, NULL);
        double d = dprim_dist(m, p, sa, sb);
        worst = fmax(worst, d);
    }
    return worst;
}

static void test_arc_piece(void)
{
    unsigned long long seed = 77;
    double worst_full = 0, worst_half = 0, worst_any = 0, worst_under = 0, worst_over = 0;
    double worst_full_exact = 0, worst_end = 0, worst_herm = 0;
    int n = 0;
    for (int i = 0; i < 1500; i++) {
        int kind = i % 3; /* 0: full piece sweep, 1: half, 2: random */
        dv3 a = (i & 4) ? rand_unit(&seed) : d3(0, 0, (i & 8) ? 1 : -1);
        double r = log_uniform(&seed, 0.1, 1000);
        dv3 c = d3(ef_t_uniform(&seed, -50, 50), ef_t_uniform(&seed, -50, 50),
                   ef_t_uniform(&seed, -50, 50));
        dv3 s0 = daxpy(c, r, rand_perp(&seed, a));
        double sgn = (i & 16) ? 1 : -1;
        int helix = (i % 5) == 0;
        double nturn = ef_t_uniform(&seed, 0.5, 4.0);
        double sw = sgn * nturn * 2 * M_PI;
        double rise = helix ? ef_t_uniform(&seed, -1, 1) * r * nturn : 0.0;
        ef_prim_t pr = mk_arc_d(s0, c, a, sw, rise);
        pr.tag = 1234u + (uint32_t)i;
        pr.feed = 25.0f;
        ef_vec3_t sf = fv(s0);
        float len;
        if (ef_prim_check(sf, &pr, &len) != EF_OK) {
            EF_CHECK(0);
            continue;
        }
        dprim_t m = dprim(sf, &pr);
        double psw = kind == 0   ? EF_ARC_PIECE_SWEEP
                     : kind == 1 ? 0.5 * EF_ARC_PIECE_SWEEP
                                 : ef_t_uniform(&seed, 0.01, 1.0) * EF_ARC_PIECE_SWEEP;
        double plen = len * psw / fabs(sw);
        double s0p = ef_t_uniform(&seed, 0, len - plen);
        float fs0 = (float)s0p, fs1 = (float)(s0p + plen);
        if (fabsf(pr.sweep) * ((fs1 - fs0) / len) > EF_ARC_PIECE_SWEEP)
            fs1 = fs0 + (float)plen * (1.0f - 2e-6f);
        if (fs1 > len)
            fs1 = len;
        ef_move_t mv;
        int rc = ef_blend_arc_piece(G2, sf, &pr, fs0, fs1, &mv);
        EF_CHECK_EQ(rc, EF_OK);
        if (rc != EF_OK)
            continue;
        n++;
        EF_CHECK_EQ(mv.degree, 5);
        EF_CHECK_EQ(mv.kind, EF_MOVE_ARC);
        EF_CHECK_EQ(mv.tag, pr.tag);
        EF_CHECK_EQ(mv.feed == 25.0f, 1);
        EF_CHECK_EQ(mv.v_max == 0.0f && mv.duration == 0.0f, 1);
        ef_frame_t f0, f1;
        ef_prim_frame(sf, &pr, fs0, &f0);
        ef_prim_frame(sf, &pr, fs1, &f1);
        EF_CHECK(memcmp(&mv.b[0], &f0.p, sizeof f0.p) == 0);
        EF_CHECK(memcmp(&mv.b[5], &f1.p, sizeof f1.p) == 0);
        double dev = dev_piece(mv.b, &m, fs0, fs1);
        double rel = dev / r;
        double piece_len = (double)fs1 - fs0;
        EF_CHECK_NEAR(mv.length, piece_len, 1e-3 * piece_len);
        /* end speeds equal to the length (the arc-length choice x1 = s1 - s0, x2 = 0) */
        for (int e = 0; e < 2; e++) {
            dv3 q, d1;
            bez_d(mv.b, 5, e, &q, &d1, NULL);
            /* plus float32 rounding of b1 - b0 = x1 t / 5 at the coordinates' magnitude (as
             * for blends below: a piece of 1e-3 at 50 from the origin is off by 1e-2) */
            double scl = dnorm(c) + r + fabs(rise);
            double rho = fabs(dnorm(d1) / mv.length - 1.0);
            double slack = 10.0 * 2.4e-7 * scl / mv.length;
            worst_end = fmax(worst_end, rho / (EF_SEG_END_SPEED_REL + slack));
            EF_CHECK(rho <= EF_SEG_END_SPEED_REL + slack);
        }
        /* the closed-form bound without its float32 terms, r sigma^6 / 46080, against the
         * dense measure less float32 rounding of the coordinates */
        double sig = fabs((double)pr.sweep) * ((double)fs1 - fs0) / len;
        double herm = r * pow(sig, 6) / 46080.0;
        double fl0 = 4e-7 * (dnorm(c) + r + fabs(rise)) +
                     2.4e-7 * r * fabs((double)pr.sweep) * fs1 / len; /* the frames' angle */
        worst_herm = fmax(worst_herm, dev / (herm + fl0));
        if (kind == 0)
            worst_full = fmax(worst_full, rel);
        if (kind == 0 && !helix && r >= 1 && dnorm(c) < 1)
            worst_full_exact = fmax(worst_full_exact, rel);
        if (kind == 1)
            worst_half = fmax(worst_half, rel);
        worst_any = fmax(worst_any, rel);
        /* the firmware's own measure: an upper-bound distance at 64 samples */
        double fl = 4e-7 * (dnorm(c) + r + fabs(rise));
        if (dev > fl)
            worst_under = fmax(worst_under, dev / (mv.dev + fl));
        if (mv.dev > 1e-7 * r + fl)
            worst_over = fmax(worst_over, (mv.dev) / (dev + fl));
    }
    printf("arc pieces (%d, r 0.1..1000, sweep up to %.4f rad): max dev/r at full sweep %.3g, "
           "at half %.3g, any %.3g\n",
           n, (double)EF_ARC_PIECE_SWEEP, worst_full, worst_half, worst_any);
    printf("arc pieces: true dev / m->dev max %.4f, m->dev / true dev max %.4f\n", worst_under,
           worst_over);
    printf("arc pieces: end speed / length - 1 over allowed max %.3f; true dev / (r sigma^6 / "
           "46080 + rounding) max %.4f\n",
           worst_end, worst_herm);
    (void)worst_full_exact;
    EF_CHECK(n > 1400);
    EF_CHECK(worst_herm <= 1.0);
    EF_CHECK(worst_full < 1e-3);
    EF_CHECK(worst_under < 1.05);

    /* dev/r against the piece's sweep (planar circles, r = 1 and 1000, several positions) */
    printf("arc pieces: max dev/r by piece sweep:");
    for (int k = 0; k < 5; k++) {
        double psw = EF_ARC_PIECE_SWEEP / (double)(1 << k), w = 0;
        for (int j = 0; j < 40; j++) {
            double r = j & 1 ? 1000.0 : 1.0;
            ef_prim_t pr = mk_arc_d(d3(r, 0, 0), d3(0, 0, 0), d3(0, 0, j & 2 ? 1 : -1), 6.0, 0);
            ef_vec3_t sf = fv(d3(r, 0, 0));
            float len;
            if (ef_prim_check(sf, &pr, &len) != EF_OK)
                continue;
            dprim_t m = dprim(sf, &pr);
            float fs0 = (float)(r * 0.1 * (j / 4)), fs1 = fs0 + (float)(r * psw * (1 - 1e-6));
            ef_move_t mv;
            if (ef_blend_arc_piece(G2, sf, &pr, fs0, fs1, &mv) != EF_OK) {
                EF_CHECK(0);
                continue;
            }
            w = fmax(w, dev_piece(mv.b, &m, fs0, fs1) / r);
        }
        printf(" %.4f rad: %.3g%s", psw, w, k < 4 ? "," : "\n");
    }

    /* bad input */
    ef_prim_t pr = mk_arc_d(d3(1, 0, 0), d3(0, 0, 0), d3(0, 0, 1), 3.0, 0);
    ef_vec3_t sf = ef_v3(1, 0, 0);
    ef_move_t mv;
    float len;
    ef_prim_check(sf, &pr, &len);
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, &pr, 0.0f, 1.0f, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_arc_piece(NULL, sf, &pr, 0.0f, 1.0f, &mv), EF_ERR_ARG);
    EF_CHECK_EQ(mv.degree, 0);
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, NULL, 0.0f, 1.0f, &mv), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, &pr, 1.0f, 1.0f, &mv), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, &pr, -0.1f, 1.0f, &mv), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, &pr, 1.0f, len * 1.01f, &mv), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, &pr, 0.0f, 1.6f, &mv), EF_ERR_ARG); /* > pi/2 */
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, &pr, 0.0f, NAN, &mv), EF_ERR_ARG);
    EF_CHECK_EQ(mv.degree, 0);
    ef_prim_t l = mk_line(ef_v3(3, 0, 0));
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, &l, 0.0f, 1.0f, &mv), EF_ERR_ARG);
    ef_prim_t bad = pr;
    bad.sweep = 0.0f;
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, &bad, 0.0f, 1.0f, &mv), EF_ERR_ARC);
    ef_table_t t1 = *G2;
    t1.kind = EF_TABLE_G1_CUBIC;
    EF_CHECK_EQ(ef_blend_arc_piece(&t1, sf, &pr, 0.0f, 1.0f, &mv), EF_ERR_KIND);
    EF_CHECK_EQ(ef_blend_arc_piece(G2, sf, &pr, 0.0f, 1.5f, &mv), EF_OK);
}

/* ---- corner blends with arc ends ---------------------------------------------------------- */

/* Build a primitive leaving point v with unit tangent t (arcs: axis a, radius r, sweep
 * magnitude asw, turning sign sg; helix when t has a component along a). */
static ef_prim_t prim_from(dv3 v, dv3 t, int arc, dv3 a, double r, double asw, double sg,
                           double line_len)
{
    if (!arc) {
        ef_prim_t p = mk_line(fv(daxpy(v, line_len, t)));
        return p;
    }
    double ta = ddot(t, a);
    dv3 tp = daxpy(t, -ta, a);
    double tpn = dnorm(tp);
    dv3 tc = dscale(tp, 1.0 / tpn);
    /* t_c = sg * (a x e_u)  =>  e_u = sg * (t_c x a) */
    dv3 eu = dscale(dcross(tc, a), sg);
    dv3 c = daxpy(v, -r, eu);
    double rise = ta / tpn * r * asw;
    return mk_arc_d(v, c, a, sg * asw, rise);
}

/* The reverse of a primitive from s to e: from e to s. */
static ef_prim_t prim_reverse(ef_vec3_t s, const ef_prim_t *p)
{
    ef_prim_t q = *p;
    q.end = s;
    if (p->kind == EF_PRIM_ARC) {
        dprim_t m = dprim(s, p);
        q.centre = fv(daxpy(m.base, m.h, m.a));
        q.sweep = -p->sweep;
    }
    return q;
}

typedef struct {
    const char *name;
    int n, blends, clamped, straight, stop, rev, other;
    int nwide, bwide; /* corners whose neighbour limits are the primitives or their halves */
    double dev_max, v_max, p_max, under_max, g2_t, g2_k, pos, rho;
    double *devs, *hd, free_min;
    int ndev, nhd, nfree, tan_stop;
} stats_t;

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* One random corner; force_th >= 0 replaces the random turn (tangent joins). */
static void corner_case(stats_t *st, unsigned long long *seed, int in_arc, int out_arc, int idx,
                        double force_th)
{
    int planar = idx & 1;
    dv3 v = d3(ef_t_uniform(seed, -100, 100), ef_t_uniform(seed, -100, 100),
               planar ? 0.0 : ef_t_uniform(seed, -100, 100));
    double tol = log_uniform(seed, 1e-3, 1.0);
    /* turn: mostly uniform up to 179 degrees, some near and past the threshold, some tiny */
    int mode = (int)(ef_t_rng(seed) % 10);
    double th = mode < 6   ? ef_t_uniform(seed, 1e-3, EF_BLEND_MAX_TURN)
                : mode < 8 ? EF_BLEND_MAX_TURN - log_uniform(seed, 1e-5, 3e-2)
                : mode < 9 ? ef_t_uniform(seed, EF_BLEND_MAX_TURN - 1e-3, M_PI)
                           : log_uniform(seed, 1e-6, 1e-2);
    th = force_th >= 0.0 ? force_th : th;
    dv3 nrm = planar ? d3(0, 0, 1) : rand_unit(seed);
    dv3 ti = rand_perp(seed, nrm);
    dv3 to = dadd(dscale(ti, cos(th)), dscale(dcross(nrm, ti), sin(th)));
    /* axes: planar -> +-z; 3-D -> a random axis (helix) or perpendicular to the tangent */
    double L0 = 3.0 * tol;
    dv3 ain = planar ? d3(0, 0, 1) : (idx & 2) ? rand_unit(seed) : rand_perp(seed, ti);
    dv3 aout = planar ? d3(0, 0, 1) : (idx & 4) ? rand_unit(seed) : rand_perp(seed, to);
    if (!planar) {
        if (fabs(ddot(ain, ti)) > 0.8)
            ain = rand_perp(seed, ti);
        if (fabs(ddot(aout, to)) > 0.8)
            aout = rand_perp(seed, to);
    }
    double rin = tol * log_uniform(seed, 0.3, 3e4), rout = tol * log_uniform(seed, 0.3, 3e4);
    if (rin > 2000)
        rin = 2000;
    if (rout > 2000)
        rout = 2000;
    double swin = ef_t_uniform(seed, 0.2, 4.0), swout = ef_t_uniform(seed, 0.2, 4.0);
    double sgin = (ef_t_rng(seed) & 1) ? 1 : -1, sgout = (ef_t_rng(seed) & 1) ? 1 : -1;
    double lin = L0 * log_uniform(seed, 0.3, 100), lout = L0 * log_uniform(seed, 0.3, 100);
    /* incoming: build the reverse from v with -ti, then reverse it */
    ef_prim_t rev = prim_from(v, dscale(ti, -1), in_arc, ain, rin, swin, sgin, lin);
    ef_vec3_t vf = fv(v);
    ef_vec3_t start_in = rev.end;
    ef_prim_t in = prim_reverse(vf, &rev);
    ef_prim_t out = prim_from(v, to, out_arc, aout, rout, swout, sgout, lout);
    float len_in, len_out;
    int rc1 = ef_prim_check(start_in, &in, &len_in), rc2 = ef_prim_check(vf, &out, &len_out);
    if (rc1 != EF_OK || rc2 != EF_OK) {
        st->other++; /* a generator rounding case (tiny arc); not the code under test */
        return;
    }
    st->n++;
    /* neighbour limits: whole primitive, half of it, or short */
    int lim = (int)(ef_t_rng(seed) % 4);
    float max_in = len_in, max_out = len_out;
    if (lim == 1)
        max_in = 0.5f * len_in, max_out = 0.5f * len_out;
    if (lim == 2)
        max_in = (float)fmin(len_in, L0 * log_uniform(seed, 1e-3, 1.0));
    if (lim == 3)
        max_out = (float)fmin(len_out, L0 * log_uniform(seed, 1e-3, 1.0));
    ef_blend_t bl, bv;
    int rc =
        ef_blend_prims(G2, start_in, &in, len_in, &out, len_out, (float)tol, max_in, max_out, &bl);
    /* the smoother's call (no second check of the primitives) gives the same blend */
    int rcv = ef_blend_prims_valid(G2, start_in, &in, len_in, &out, len_out, (float)tol, max_in,
                                   max_out, &bv);
    EF_CHECK_EQ(rcv, rc);
    EF_CHECK(same_blend(&bl, &bv));
    int wide = lim <= 1;
    st->nwide += wide;
    st->bwide += wide & (rc == EF_OK) & !(bl.flags & (EF_BLEND_STRAIGHT | EF_BLEND_STOP));
    /* the true vertex turn from the float primitives' exact tangents */
    dprim_t mi = dprim(start_in, &in), mo = dprim(vf, &out);
    dv3 p, tvi, tvo;
    dprim_at(&mi, mi.len, &p, &tvi, NULL);
    dprim_at(&mo, 0, &p, &tvo, NULL);
    double tturn = atan2(dnorm(dcross(tvi, tvo)), ddot(tvi, tvo));
    if (rc == EF_ERR_REVERSAL) {
        st->rev++;
        EF_CHECK(tturn > EF_BLEND_MAX_TURN - 1e-5);
        EF_CHECK_EQ(bl.seg.degree, 0);
        return;
    }
    EF_CHECK_EQ(rc, EF_OK);
    if (rc != EF_OK) {
        fprintf(stderr, "  %s rc %d\n", st->name, rc);
        return;
    }
    EF_CHECK(tturn <= EF_BLEND_MAX_TURN + 1e-5);
    EF_CHECK_NEAR(bl.turn, tturn, 1e-5);
    if (bl.flags & EF_BLEND_STRAIGHT) {
        st->straight++;
        EF_CHECK(tturn < EF_BLEND_MIN_TURN + 1e-5);
        EF_CHECK(bl.seg.degree == 0 && bl.trim_in == 0.0f && bl.trim_out == 0.0f);
        return;
    }
    if (bl.flags & EF_BLEND_STOP) {
        st->stop++;
        st->tan_stop += tturn < EF_BLEND_MIN_TURN; /* a tangent join never stops */
        EF_CHECK(bl.seg.degree == 0 && bl.trim_in == 0.0f && bl.trim_out == 0.0f);
        return;
    }
    st->blends++;
    st->clamped += (bl.flags & EF_BLEND_CLAMPED) != 0;
    EF_CHECK_EQ(bl.seg.degree, 5);
    EF_CHECK(bl.trim_in > 0.0f && bl.trim_in <= max_in);
    EF_CHECK(bl.trim_out > 0.0f && bl.trim_out <= max_out);
    EF_CHECK(bl.dev <= (float)tol);
    /* the ends: exact positions on the primitives, tangents and curvature vectors */
    double si = mi.len - bl.trim_in, so = bl.trim_out;
    dv3 pa, ta, ka, pb, tb, kb;
    dprim_at(&mi, si, &pa, &ta, &ka);
    dprim_at(&mo, so, &pb, &tb, &kb);
    EF_CHECK(memcmp(&bl.seg.b[0], &bl.p_in, sizeof bl.p_in) == 0);
    EF_CHECK(memcmp(&bl.seg.b[5], &bl.p_out, sizeof bl.p_out) == 0);
    double scale = fmax(fmax(fabs(v.x), fabs(v.y)), fabs(v.z)) + mi.r0 + mo.r0;
    double pe = fmax(dnorm(dsub(dv(bl.p_in), pa)), dnorm(dsub(dv(bl.p_out), pb)));
    st->pos = fmax(st->pos, pe / (tol + 1e-6 * scale));
    EF_CHECK(pe <= 1e-6 * scale + 1e-3 * tol);
    double L = fmax(bl.trim_in, bl.trim_out);
    for (int e = 0; e < 2; e++) {
        dv3 q, d1, d2;
        bez_d(bl.seg.b, 5, e, &q, &d1, &d2);
        double sp = dnorm(d1);
        dv3 tt = dscale(d1, 1.0 / sp);
        dv3 kv = dscale(dcross(dcross(d1, d2), d1), 1.0 / (sp * sp * sp * sp));
        dv3 tx = e ? tb : ta, kx = e ? kb : ka;
        double et = dnorm(dsub(tt, tx));
        double ek = dnorm(dsub(kv, kx)) * L;
        /* float32 rounding of the control points (delta ~ eps scale) shows in the end tangent
         * as ~ 10 delta / x1 and in the curvature as ~ 80 delta / x1^2 (b1 - b0 = x1 t / 5,
         * b2 - 2 b1 + b0 = f'' / 20): allowed on top of fixed tolerances */
        double x1 = e ? bl.seg.dof[2] : bl.seg.dof[0];
        double delta = 1.2e-7 * scale;
        double at = 2e-4 + 20 * delta / x1, ak = 0.01 + 160 * delta * L / (x1 * x1);
        st->g2_t = fmax(st->g2_t, et / at);
        st->g2_k = fmax(st->g2_k, ek / ak);
        EF_CHECK(et < at);
        EF_CHECK(ek < ak);
        if (et >= at || ek >= ak)
            fprintf(stderr,
                    "  %s #%d end %d: allowed %.3g %.3g tangent err %.3g curvature*L err %.3g "
                    "planar %d "
                    "turn %.4f hi %.3g ho %.3g L %.3g |kx| %.3g |kv| %.3g\n",
                    st->name, idx, e, at, ak, et, ek, planar, tturn, mi.h, mo.h, L, dnorm(kx),
                    dnorm(kv));
    }
    /* end speeds against the arc length (what uniform stepping's feed is at the ends, in
     * units of the planned speed): within EF_SEG_END_SPEED_REL (2e-3) of 1, ef_seg.h,
     * plus the quadrature's error and float32 rounding of the control points at the corner's
     * coordinates (2 ulp of |b1 - b0| = x1 / 5) */
    {
        double len = 0.0;
        enum { NL = 4000 };
        for (int i = 0; i < NL; i++) {
            dv3 q, d1;
            bez_d(bl.seg.b, 5, (i + 0.5) / NL, &q, &d1, NULL);
            len += dnorm(d1) / NL;
        }
        for (int e = 0; e < 2; e++) {
            dv3 q, d1;
            bez_d(bl.seg.b, 5, e, &q, &d1, NULL);
            double rho = fabs(dnorm(d1) / len - 1.0);
            double slack = 10.0 * 2.4e-7 * scale / len;
            st->rho = fmax(st->rho, rho);
            EF_CHECK(rho <= 2.2e-3 + slack);
            if (!(rho <= 2.2e-3 + slack))
                fprintf(stderr, "  %s #%d end %d: rho-1 %.4g slack %.3g len %.4g deg %d\n",
                        st->name, idx, e, rho, slack, len, bl.seg.degree);
        }
    }
    /* one-sided deviation in double: the blend's points (2000 samples plus refinement) to the
     * replaced pieces */
    int ns = 2000, imax = 0;
    double dmax = 0;
    for (int i = 0; i <= ns; i++) {
        dv3 q;
        bez_d(bl.seg.b, 5, (double)i / ns, &q, NULL, NULL);
        double d = fmin(dprim_dist(&mi, q, si, mi.len), dprim_dist(&mo, q, 0, so));
        if (d > dmax)
            dmax = d, imax = i;
    }
    for (int i = -20; i <= 20; i++) {
        double t = (imax + i / 20.0) / ns;
        if (t < 0 || t > 1)
            continue;
        dv3 q;
        bez_d(bl.seg.b, 5, t, &q, NULL, NULL);
        dmax = fmax(dmax, fmin(dprim_dist(&mi, q, si, mi.len), dprim_dist(&mo, q, 0, so)));
    }
    /* the other way: how far the vertex, and any point of the replaced pieces, is from the
     * blend (300 curve samples and Newton steps: an upper bound) */
    double vd = 1e300, pd = 0;
    for (int i = 0; i <= ns; i++) {
        dv3 q;
        bez_d(bl.seg.b, 5, (double)i / ns, &q, NULL, NULL);
        vd = fmin(vd, dnorm(dsub(q, v)));
    }
    {
        enum { NC = 300, NP = 60 };
        static dv3 cs[NC + 1];
        for (int i = 0; i <= NC; i++)
            bez_d(bl.seg.b, 5, (double)i / NC, &cs[i], NULL, NULL);
        for (int side = 0; side < 2; side++)
            for (int j = 0; j <= NP; j++) {
                dv3 q;
                if (side == 0)
                    dprim_at(&mi, si + (mi.len - si) * j / NP, &q, NULL, NULL);
                else
                    dprim_at(&mo, so * j / NP, &q, NULL, NULL);
                double best = 1e300;
                int ib = 0;
                for (int i = 0; i <= NC; i++) {
                    double d = dnorm(dsub(q, cs[i]));
                    if (d < best)
                        best = d, ib = i;
                }
                /* Newton on |f(t) - q|^2 from the nearest sample (a curve point: still an
                 * upper bound) */
                double t = (double)ib / NC;
                for (int it = 0; it < 4; it++) {
                    dv3 f, d1, d2;
                    bez_d(bl.seg.b, 5, t, &f, &d1, &d2);
                    dv3 w = dsub(f, q);
                    double g = ddot(w, d1), gg = ddot(d1, d1) + ddot(w, d2);
                    t -= g / (gg > 1e-300 ? gg : 1e-300);
                    t = t < 0 ? 0 : t > 1 ? 1 : t;
                    bez_d(bl.seg.b, 5, t, &f, NULL, NULL);
                    best = fmin(best, dnorm(dsub(f, q)));
                }
                pd = fmax(pd, best);
            }
    }
    st->p_max = fmax(st->p_max, pd / tol);
    EF_CHECK(pd <= tol * 1.01);
    double r = dmax / tol;
    st->dev_max = fmax(st->dev_max, r);
    st->v_max = fmax(st->v_max, vd / tol);
    st->under_max = fmax(st->under_max, dmax / fmax(bl.dev, 1e-30));
    st->devs[st->ndev++] = r;
    /* two-sided (Hausdorff) deviation: what the firmware sizes the blend by */
    double hd = fmax(r, fmax(vd, pd) / tol);
    st->hd[st->nhd++] = hd;
    if (!(bl.flags & EF_BLEND_CLAMPED))
        st->free_min = st->nfree++ ? fmin(st->free_min, hd) : hd;
    EF_CHECK(r <= 1.0 + 1e-3);
    if (r > 1.0 + 1e-3)
        fprintf(stderr,
                "  %s #%d: dev/tol %.6f turn %.4f tol %.3g rin %.3g rout %.3g trims %.4g "
                "%.4g dev %.4g\n",
                st->name, idx, r, tturn, tol, mi.r0, mo.r0, bl.trim_in, bl.trim_out, bl.dev);
}

/* Fresh statistics for n corners of one kind (the sample arrays are the caller's to free
 * with stats_free()). */
static void stats_init(stats_t *st, const char *name, int n)
{
    memset(st, 0, sizeof *st);
    st->name = name;
    st->devs = malloc(sizeof(double) * (size_t)n);
    st->hd = malloc(sizeof(double) * (size_t)n);
}

/* Release what stats_init() allocated. */
static void stats_free(stats_t *st)
{
    free(st->devs);
    free(st->hd);
}

static void test_blend_prims(void)
{
    const int N = 2000;
    const char *names[3] = {"line-arc", "arc-line", "arc-arc"};
    int kinds[3][2] = {{0, 1}, {1, 0}, {1, 1}};
    unsigned long long seed = 2024;
    for (int k = 0; k < 3; k++) {
        stats_t st;
        stats_init(&st, names[k], N);
        for (int i = 0; i < N; i++)
            corner_case(&st, &seed, kinds[k][0], kinds[k][1], i, -1.0);
        qsort(st.devs, (size_t)st.ndev, sizeof(double), cmp_d);
        double p99 = st.ndev ? st.devs[(int)(0.99 * (st.ndev - 1))] : 0;
        double p50 = st.ndev ? st.devs[(st.ndev - 1) / 2] : 0;
        printf("%-8s: %d corners: %d blends (%d clamped), %d straight, %d stop, %d reversal, "
               "%d skipped; dev/tol max %.6f p99 %.6f median %.4f; |v - blend|/tol max %.4f, "
               "path->blend/tol max %.4f; "
               "true dev / reported dev max %.4f; G2 ends (err / allowed): tangent %.2g, "
               "curvature*L %.2g; "
               "end position err/tol %.2g; end speed / L - 1 max %.2g\n",
               st.name, st.n, st.blends, st.clamped, st.straight, st.stop, st.rev, st.other,
               st.dev_max, p99, p50, st.v_max, st.p_max, st.under_max, st.g2_t, st.g2_k, st.pos,
               st.rho);
        EF_CHECK(st.blends > N / 2);
        EF_CHECK(st.other < N / 100);
        qsort(st.hd, (size_t)st.nhd, sizeof(double), cmp_d);
        printf("%-8s: two-sided dev/tol max %.6f p99 %.6f median %.4f; unclamped blends %d, "
               "two-sided dev/tol min %.4f\n",
               st.name, st.nhd ? st.hd[st.nhd - 1] : 0,
               st.nhd ? st.hd[(int)(0.99 * (st.nhd - 1))] : 0, st.nhd ? st.hd[(st.nhd - 1) / 2] : 0,
               st.nfree, st.free_min);
        EF_CHECK(st.nhd == 0 || st.hd[st.nhd - 1] <= 1.0 + 1e-3);
        stats_free(&st);
    }
}

/* Tangent joins (turn below EF_BLEND_MIN_TURN, different curvature vectors): line-arc,
 * arc-line, arc-arc (random turning ways, so the same and opposite directions, random radii),
 * 2-D and 3-D (helices included), turn 0 or tiny. The blend is measured as in corner_case()
 * (deviation in double <= tol both ways, G2 contact: tangent and curvature vector of the
 * primitive at both ends, trim limits); ordinary cases must blend. Then cases that stay
 * straight: collinear lines, an arc continued by itself, a negligible jump (dk tol below
 * EF_BLEND_MIN_TURN^2). */
static void test_tangent_joins(void)
{
    const int N = 250;
    const char *names[3] = {"tan line-arc", "tan arc-line", "tan arc-arc"};
    int kinds[3][2] = {{0, 1}, {1, 0}, {1, 1}};
    unsigned long long seed = 77;
    for (int k = 0; k < 3; k++) {
        stats_t st;
        stats_init(&st, names[k], N);
        for (int i = 0; i < N; i++) {
            double th = (i % 3 == 0) ? 0.0 : log_uniform(&seed, 1e-7, 0.5 * EF_BLEND_MIN_TURN);
            corner_case(&st, &seed, kinds[k][0], kinds[k][1], i, th);
        }
        qsort(st.hd, (size_t)st.nhd, sizeof(double), cmp_d);
        printf("%-12s: %d joins: %d blends (%d clamped), %d straight, %d stop, %d skipped; "
               "%d of %d with wide neighbour limits blended; "
               "dev/tol max %.6f, two-sided max %.6f median %.4f; G2 ends (err / allowed): "
               "tangent %.2g, curvature*L %.2g; end speed / L - 1 max %.2g\n",
               st.name, st.n, st.blends, st.clamped, st.straight, st.stop, st.other, st.bwide,
               st.nwide, st.dev_max, st.nhd ? st.hd[st.nhd - 1] : 0,
               st.nhd ? st.hd[(st.nhd - 1) / 2] : 0, st.g2_t, st.g2_k, st.rho);
        EF_CHECK_EQ(st.tan_stop, 0);
        EF_CHECK_EQ(st.rev, 0);
        /* Trims are symmetric (ef_blend.h): where one neighbour limit is short (lim 2, 3
         * below) both trims are, and the blend that fits there is often below what float32
         * holds evenly, so the join stays straight (or, turning by a hair more than
         * EF_BLEND_MIN_TURN, stops). With wide limits nearly all blend. */
        EF_CHECK(st.bwide >= st.nwide * 9 / 10);
        EF_CHECK(st.blends >= st.n * 3 / 4);
        EF_CHECK(st.other < N / 50);
        EF_CHECK(st.nhd == 0 || st.hd[st.nhd - 1] <= 1.0 + 1e-3);
        stats_free(&st);
    }

    /* stay straight */
    ef_blend_t b;
    float li, lo;
    ef_vec3_t s0 = ef_v3(0, 0, 0);
    ef_prim_t l1 = mk_line(ef_v3(10, 0, 0)), l2 = mk_line(ef_v3(20, 0, 0));
    ef_prim_check(s0, &l1, &li);
    ef_prim_check(l1.end, &l2, &lo);
    EF_CHECK_EQ(ef_blend_prims(G2, s0, &l1, li, &l2, lo, 0.01f, li, lo, &b), EF_OK);
    EF_CHECK(b.flags & EF_BLEND_STRAIGHT);
    EF_CHECK(b.seg.degree == 0 && b.trim_in == 0.0f && b.trim_out == 0.0f);
    /* one circle (r 5 about (3, 4, 0)) in two arcs */
    ef_prim_t a1 = mk_arc_d(d3(8, 4, 0), d3(3, 4, 0), d3(0, 0, 1), 1.3, 0.0);
    ef_prim_t a2 = mk_arc_d(dv(a1.end), d3(3, 4, 0), d3(0, 0, 1), 1.1, 0.0);
    ef_vec3_t sa = ef_v3(8, 4, 0);
    EF_CHECK_EQ(ef_prim_check(sa, &a1, &li), EF_OK);
    EF_CHECK_EQ(ef_prim_check(a1.end, &a2, &lo), EF_OK);
    EF_CHECK_EQ(ef_blend_prims(G2, sa, &a1, li, &a2, lo, 0.01f, li, lo, &b), EF_OK);
    EF_CHECK(b.flags & EF_BLEND_STRAIGHT);
    EF_CHECK_EQ(b.seg.degree, 0);
    /* a line tangent to that circle: a blend at tol 0.01; straight when dk tol < 1e-8 */
    ef_prim_t ln = mk_line(ef_v3(8, 4, 0));
    ef_vec3_t sl = ef_v3(8, -6, 0);
    EF_CHECK_EQ(ef_prim_check(sl, &ln, &li), EF_OK);
    EF_CHECK_EQ(ef_prim_check(ln.end, &a1, &lo), EF_OK);
    EF_CHECK_EQ(ef_blend_prims(G2, sl, &ln, li, &a1, lo, 0.01f, li, lo, &b), EF_OK);
    EF_CHECK_EQ(b.flags & (EF_BLEND_STRAIGHT | EF_BLEND_STOP), 0u);
    EF_CHECK_EQ(b.seg.degree, 5);
    EF_CHECK(b.dev <= 0.01f && b.trim_in > 0.0f && b.trim_out > 0.0f);
    EF_CHECK_EQ(ef_blend_prims(G2, sl, &ln, li, &a1, lo, 4e-8f, li, lo, &b), EF_OK);
    EF_CHECK(b.flags & EF_BLEND_STRAIGHT); /* no blend fits: straight, never a stop */
    EF_CHECK_EQ(b.seg.degree, 0);
    /* arc r 5 into a tangent arc r 5.005 the same way: dk = 2e-4; tol 4e-5 (above the
     * rounding share, dk tol 8e-9) stays straight, tol 0.01 blends */
    dv3 ce = dadd(d3(3, 4, 0), dscale(d3(cos(1.3), sin(1.3), 0), 5.0 - 5.005));
    ef_prim_t a3 = mk_arc_d(dv(a1.end), ce, d3(0, 0, 1), 0.8, 0.0);
    EF_CHECK_EQ(ef_prim_check(sa, &a1, &li), EF_OK);
    EF_CHECK_EQ(ef_prim_check(a1.end, &a3, &lo), EF_OK);
    EF_CHECK_EQ(ef_blend_prims(G2, sa, &a1, li, &a3, lo, 4e-5f, li, lo, &b), EF_OK);
    EF_CHECK(b.flags & EF_BLEND_STRAIGHT);
    EF_CHECK_EQ(ef_blend_prims(G2, sa, &a1, li, &a3, lo, 0.01f, li, lo, &b), EF_OK);
    EF_CHECK_EQ(b.flags & (EF_BLEND_STRAIGHT | EF_BLEND_STOP), 0u);
    EF_CHECK(b.seg.degree == 5 && b.dev <= 0.01f);
}

static void test_blend_prims_args(void)
{
    ef_vec3_t s = ef_v3(0, 0, 0);
    ef_prim_t in = mk_line(ef_v3(1, 0, 0));
    ef_prim_t out = mk_arc_d(d3(1, 0, 0), d3(1, 1, 0), d3(0, 0, 1), 1.0, 0);
    float li, lo;
    EF_CHECK_EQ(ef_prim_check(s, &in, &li), EF_OK);
    EF_CHECK_EQ(ef_prim_check(in.end, &out, &lo), EF_OK);
    ef_blend_t b;
    /* tangent join: a blend (G2 across the curvature jump) */
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &out, lo, 0.01f, li, lo, &b), EF_OK);
    EF_CHECK_EQ(b.flags & (EF_BLEND_STRAIGHT | EF_BLEND_STOP), 0u);
    EF_CHECK_EQ(b.seg.degree, 5);
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &out, lo, 0.01f, li, lo, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims(NULL, s, &in, li, &out, lo, 0.01f, li, lo, &b), EF_ERR_ARG);
    EF_CHECK_EQ(b.flags, 0);
    EF_CHECK_EQ(ef_blend_prims(G2, s, NULL, li, &out, lo, 0.01f, li, lo, &b), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &out, lo, 0.0f, li, lo, &b), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &out, lo, 0.01f, 0.0f, lo, &b), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &out, lo, 0.01f, li, lo * 1.1f, &b), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li * 2, &out, lo, 0.01f, li, lo, &b), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &out, lo, NAN, li, lo, &b), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &out, lo, 0.01f, li, INFINITY, &b),
                EF_ERR_NONFINITE);
    ef_table_t t1 = *G2;
    t1.kind = EF_TABLE_G1_CUBIC;
    EF_CHECK_EQ(ef_blend_prims(&t1, s, &in, li, &out, lo, 0.01f, li, lo, &b), EF_ERR_KIND);
    ef_prim_t bad = out;
    bad.sweep = 0.0f;
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &bad, lo, 0.01f, li, lo, &b), EF_ERR_ARC);
    EF_CHECK_EQ(b.seg.degree, 0);
    /* ef_blend_prims_valid(): the arguments it still checks, each with its code and a zero
     * result */
    EF_CHECK_EQ(ef_blend_prims_valid(G2, s, &in, li, &out, lo, 0.01f, li, lo, NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims_valid(NULL, s, &in, li, &out, lo, 0.01f, li, lo, &b), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims_valid(G2, s, &in, li, NULL, lo, 0.01f, li, lo, &b), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims_valid(G2, s, &in, li, &out, lo, -1.0f, li, lo, &b), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims_valid(G2, s, &in, li, &out, lo, 0.01f, li * 1.5f, lo, &b),
                EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims_valid(G2, s, &in, li, &out, lo, 0.01f, li, -lo, &b), EF_ERR_ARG);
    EF_CHECK_EQ(ef_blend_prims_valid(G2, s, &in, NAN, &out, lo, 0.01f, li, lo, &b),
                EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_blend_prims_valid(&t1, s, &in, li, &out, lo, 0.01f, li, lo, &b), EF_ERR_KIND);
    EF_CHECK_EQ(b.seg.degree, 0);
    EF_CHECK_EQ(b.flags, 0);
    /* a 90 degree line-arc corner: blend */
    ef_prim_t out2 = mk_arc_d(d3(1, 0, 0), d3(0, 0, 0), d3(0, 0, 1), 1.0, 0);
    EF_CHECK_EQ(ef_prim_check(in.end, &out2, &lo), EF_OK);
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &out2, lo, 0.01f, li, lo, &b), EF_OK);
    EF_CHECK_EQ(b.seg.degree, 5);
    EF_CHECK_NEAR(b.turn, M_PI / 2, 1e-6);
    EF_CHECK(b.dev <= 0.01f && b.dev > 0.009f);
    /* two lines: exactly ef_blend_corner() */
    ef_prim_t l2 = mk_line(ef_v3(1, 1, 0));
    EF_CHECK_EQ(ef_prim_check(in.end, &l2, &lo), EF_OK);
    ef_blend_t c;
    EF_CHECK_EQ(ef_blend_prims(G2, s, &in, li, &l2, lo, 0.01f, li, 0.3f, &b), EF_OK);
    EF_CHECK_EQ(ef_blend_corner(G2, in.end, ef_v3(1, 0, 0), ef_v3(0, 1, 0), 0.01f, li, 0.3f, &c),
                EF_OK);
    EF_CHECK(memcmp(b.seg.b, c.seg.b, sizeof b.seg.b) == 0);
    EF_CHECK(b.trim_in == c.trim_in && b.trim_out == c.trim_out && b.dev == c.dev);
    EF_CHECK(b.flags == c.flags && b.turn == c.turn && b.seg.degree == 5);
    /* tolerance below float32 resolution at the vertex: stop */
    ef_vec3_t sf = ef_v3(99999, 0, 0);
    ef_prim_t inf = mk_line(ef_v3(100000, 0, 0));
    ef_prim_t outf = mk_arc_d(d3(100000, 0, 0), d3(99999, 0, 0), d3(0, 0, 1), 1.0, 0);
    EF_CHECK_EQ(ef_prim_check(sf, &inf, &li), EF_OK);
    EF_CHECK_EQ(ef_prim_check(inf.end, &outf, &lo), EF_OK);
    EF_CHECK_EQ(ef_blend_prims(G2, sf, &inf, li, &outf, lo, 1e-4f, li, lo, &b), EF_OK);
    EF_CHECK_EQ(b.flags, EF_BLEND_STOP);
    EF_CHECK_EQ(b.seg.degree, 0);
}

/* Speed ripple of a quintic in double: max | |f'(t)| / L - 1 | over 400 samples (L by the
 * mean of 4000 midpoint samples); *kjerk: max |f'''_i| / L^3 over the axes. */
static double speed_ripple_d(const ef_vec3_t *b, double *kjerk)
{
    double L = 0, r = 0, kj = 0;
    for (int i = 0; i < 4000; i++) {
        dv3 p, d1;
        bez_d(b, 5, (i + 0.5) / 4000, &p, &d1, NULL);
        L += dnorm(d1) / 4000;
    }
    /* third derivative: 60 x the third differences of the control points, a quadratic */
    dv3 d3c[3];
    for (int i = 0; i < 3; i++)
        d3c[i] = dscale(dsub(dsub(dv(b[i + 3]), dscale(dv(b[i + 2]), 3)),
                             dsub(dv(b[i]), dscale(dv(b[i + 1]), 3))),
                        60);
    for (int i = 0; i <= 400; i++) {
        double t = i / 400.0, u = 1 - t;
        dv3 p, d1;
        bez_d(b, 5, t, &p, &d1, NULL);
        r = fmax(r, fabs(dnorm(d1) / L - 1));
        dv3 j = daxpy(daxpy(dscale(d3c[0], u * u), 2 * u * t, d3c[1]), t * t, d3c[2]);
        kj = fmax(kj, fmax(fabs(j.x), fmax(fabs(j.y), fabs(j.z))) / (L * L * L));
    }
    if (kjerk)
        *kjerk = kj;
    return r;
}

/* ef_seg_g2_even(): on short pieces of circles (arc pieces, CAM sections) the arc-length
 * choice x1 = L, x2 = 0 wins and moves at an even parametric speed, its third derivative
 * near the circle's own 1/R^2 (the table's ripple of +-5e-4 made it 5-7 times that on the
 * LinuxCNC corpus's quantized circle); on a 90 degree corner between lines the table's
 * optimum is the more even one and is kept; the result is never less even than the table's. */
static void test_seg_even(void)
{
    double worst_arc = 0, worst_kj = 0, tab_arc = 0, tab_kj = 0;
    int wins = 0, n = 0;
    unsigned long long seed = 5;
    for (int i = 0; i < 400; i++) {
        double r = log_uniform(&seed, 0.5, 500), sw = ef_t_uniform(&seed, 0.02, 0.3);
        double a0 = ef_t_uniform(&seed, -M_PI, M_PI), a1 = a0 + sw;
        ef_endpoint_t e0, e1;
        e0.p = ef_v3((float)(r * cos(a0)), (float)(r * sin(a0)), 0);
        e0.t = ef_v3((float)-sin(a0), (float)cos(a0), 0);
        e0.n = ef_v3((float)-cos(a0), (float)-sin(a0), 0);
        e0.kappa = (float)(1 / r);
        e1.p = ef_v3((float)(r * cos(a1)), (float)(r * sin(a1)), 0);
        e1.t = ef_v3((float)-sin(a1), (float)cos(a1), 0);
        e1.n = ef_v3((float)-cos(a1), (float)-sin(a1), 0);
        e1.kappa = (float)(1 / r);
        ef_seg_t tab, ev;
        if (ef_seg_g2_quintic(G2, &e0, &e1, &tab) != EF_OK) {
            EF_CHECK(0);
            continue;
        }
        ev = tab;
        float dev = -1;
        float dend = -1;
        int won = ef_seg_g2_even(&e0, &e1, &ev, &dev, &dend) == EF_SEG_EVEN_ARC;
        double kt, ke;
        double rt = speed_ripple_d(tab.b, &kt), re = speed_ripple_d(ev.b, &ke);
        n++;
        wins += won;
        EF_CHECK(re <= rt + 1e-6);     /* never less even */
        EF_CHECK(dev >= 0 && dev < 1); /* reported */
        EF_CHECK(dend >= 0 && dend <= EF_SEG_END_SPEED_REL);
        EF_CHECK(dend <= dev);
        EF_CHECK_EQ(ev.degree, 5);
        /* still interpolates the ends */
        EF_CHECK(memcmp(&ev.b[0], &e0.p, sizeof e0.p) == 0);
        EF_CHECK(memcmp(&ev.b[5], &e1.p, sizeof e1.p) == 0);
        worst_arc = fmax(worst_arc, re);
        worst_kj = fmax(worst_kj, ke * r * r);
        tab_arc = fmax(tab_arc, rt);
        tab_kj = fmax(tab_kj, kt * r * r);
    }
    printf("seg even, circle pieces (%d, r 0.5..500, sweep 0.02..0.3): arc-length choice won %d; "
           "speed ripple max %.2g (table %.2g); |f'''|/L^3 max %.2f / r^2 (table %.2f / r^2)\n",
           n, wins, worst_arc, tab_arc, worst_kj, tab_kj);
    EF_CHECK(n == 400);
    EF_CHECK(wins >= 390);
    EF_CHECK(worst_arc < 1e-4);
    EF_CHECK(worst_kj < 1.5);

    /* 90 degree corner between lines (curvature 0 at both ends): the table stays */
    ef_endpoint_t c0 = {ef_v3(0, 0, 0), ef_v3(1, 0, 0), ef_v3(0, 1, 0), 0};
    ef_endpoint_t c1 = {ef_v3(1, 1, 0), ef_v3(0, 1, 0), ef_v3(-1, 0, 0), 0};
    ef_seg_t t0, t1;
    EF_CHECK_EQ(ef_seg_g2_quintic(G2, &c0, &c1, &t0), EF_OK);
    t1 = t0;
    EF_CHECK_EQ(ef_seg_g2_even(&c0, &c1, &t1, NULL, NULL), EF_SEG_EVEN_TABLE);
    EF_CHECK(memcmp(&t0, &t1, sizeof t0) == 0);
    /* End data no quintic with end speeds equal to its length joins (the fuzzer's piece: a
     * curvature of 58 140 /mm on a 1.8e-3 mm chord, so L(x1) > x1 for every x1): neither
     * candidate is taken, the table's curve stays and dev_ends says how far off its ends
     * are, beyond ef_seg_end_allow(), which is what the smoother and the arc piece's table
     * route refuse. */
    ef_endpoint_t h0 = {ef_v3(-2.66397838e-05f, 1.43781235e-05f, 0),
                        ef_v3(-0.8359375f, -0.548824668f, 0), ef_v3(0.548824668f, -0.83593744f, 0),
                        58139.5273f};
    ef_endpoint_t h1 = {ef_v3(0.00172154454f, 0.000149968284f, 0),
                        ef_v3(0.0859318525f, -0.996301055f, 0),
                        ef_v3(0.996300995f, 0.0859318525f, 0), 58139.5273f};
    ef_seg_t hs;
    EF_CHECK_EQ(ef_seg_g2_quintic(G2, &h0, &h1, &hs), EF_OK);
    float hdev = -1, hend = -1;
    EF_CHECK_EQ(ef_seg_g2_even(&h0, &h1, &hs, &hdev, &hend), EF_SEG_EVEN_TABLE);
    EF_CHECK(hend > 0.1f && hend > ef_seg_end_allow(h0.p, h1.p));
    /* not a quintic, NULL: nothing changes */
    ef_seg_t cub;
    memset(&cub, 0, sizeof cub);
    cub.degree = 3;
    EF_CHECK_EQ(ef_seg_g2_even(&c0, &c1, &cub, NULL, NULL), EF_SEG_EVEN_TABLE);
    EF_CHECK_EQ(ef_seg_g2_even(NULL, &c1, &t1, NULL, NULL), EF_SEG_EVEN_TABLE);
    EF_CHECK_EQ(ef_seg_g2_even(&c0, &c1, NULL, NULL, NULL), EF_SEG_EVEN_TABLE);
}

/* The last piece of an arc whose end is off its circle (a G-code radius error within
 * ef_prim_check()'s tolerance): ef_prim_end_gap() is that distance; the piece ends exactly
 * on pr->end, keeps its end speeds at its length, and its dev covers the true deviation
 * from the circle. Small gaps take the closed form, large ones (relative to the piece) the
 * table route; both are exercised. */
static void test_arc_piece_gap(void)
{
    unsigned long long seed = 91;
    int closed = 0, table = 0;
    double worst_gap = 0, worst_end = 0, worst_dev = 0;
    for (int i = 0; i < 400; i++) {
        double r = log_uniform(&seed, 0.2, 50);
        double sw = ((i & 1) ? 1 : -1) * ef_t_uniform(&seed, 0.05, 3.0);
        dv3 c = d3(ef_t_uniform(&seed, -20, 20), ef_t_uniform(&seed, -20, 20), 5);
        dv3 s0 = daxpy(c, r, rand_perp(&seed, d3(0, 0, 1)));
        ef_prim_t pr = mk_arc_d(s0, c, d3(0, 0, (i & 2) ? 1 : -1), sw, 0.0);
        double tolr = fmax(EF_ARC_ABS_TOL, EF_ARC_REL_TOL * r);
        double err = ((i & 4) ? 1 : -1) * tolr * log_uniform(&seed, 1e-5, 0.9);
        /* the end moved radially by err (the same angle) */
        dv3 e = dv(pr.end), cc = dv(pr.centre);
        dv3 w = dsub(e, cc);
        pr.end = fv(daxpy(e, err / dnorm(w), w));
        pr.feed = 10.0f;
        ef_vec3_t sf = fv(s0);
        float len;
        if (ef_prim_check(sf, &pr, &len) != EF_OK) {
            EF_CHECK(0);
            continue;
        }
        double gap = ef_prim_end_gap(sf, &pr);
        worst_gap = fmax(worst_gap, fabs(gap - fabs(err)) / (1e-6 * (dnorm(c) + r)));
        EF_CHECK(fabs(gap - fabs(err)) <= 1e-6 * (dnorm(c) + r));
        /* the last piece: from 1e-3 up to the whole piece sweep */
        double psw = log_uniform(&seed, 1e-3, 1.0) * EF_ARC_PIECE_SWEEP;
        double plen = fmin((double)len, len * psw / fabs(sw));
        float fs0 = (float)(len - plen), fs1 = len;
        if (fabsf(pr.sweep) * ((fs1 - fs0) / len) > EF_ARC_PIECE_SWEEP)
            fs0 = fs1 - (float)plen * (1.0f - 2e-6f);
        ef_move_t mv;
        if (ef_blend_arc_piece(G2, sf, &pr, fs0, fs1, &mv) != EF_OK) {
            EF_CHECK(0);
            continue;
        }
        if (gap <= 2.5e-4 * ((double)fs1 - fs0))
            closed++;
        else
            table++;
        EF_CHECK(memcmp(&mv.b[5], &pr.end, sizeof pr.end) == 0);
        double scl = dnorm(c) + r;
        for (int k = 0; k < 2; k++) {
            dv3 q, d1;
            bez_d(mv.b, 5, k, &q, &d1, NULL);
            double rho = fabs(dnorm(d1) / mv.length - 1.0);
            double slack = 10.0 * 2.4e-7 * scl / mv.length;
            worst_end = fmax(worst_end, rho / (EF_SEG_END_SPEED_REL + slack));
            EF_CHECK(rho <= EF_SEG_END_SPEED_REL + slack);
        }
        dprim_t m = dprim(sf, &pr);
        double dev = dev_piece(mv.b, &m, fs0, fs1), fl = 4e-7 * scl;
        worst_dev = fmax(worst_dev, dev / (mv.dev + fl));
        EF_CHECK(dev <= mv.dev + fl);
    }
    printf("arc pieces off the circle: %d closed form, %d table route; gap error max %.3f of "
           "1e-6 scale; end speed over allowed max %.3f; true dev / dev max %.4f\n",
           closed, table, worst_gap, worst_end, worst_dev);
    EF_CHECK(closed > 50);
    EF_CHECK(table > 50);
    /* lines have no gap; NULL is 0 */
    ef_prim_t l = mk_line(ef_v3(1, 2, 3));
    EF_CHECK_EQ(ef_prim_end_gap(ef_v3(0, 0, 0), &l) == 0.0f, 1);
    EF_CHECK_EQ(ef_prim_end_gap(ef_v3(0, 0, 0), NULL) == 0.0f, 1);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"check", test_check},
        {"check_geo", test_check_geo},
        {"frame", test_frame},
        {"measure", test_measure},
        {"arc_piece", test_arc_piece},
        {"arc_piece_gap", test_arc_piece_gap},
        {"seg_even", test_seg_even},
        {"blend_prims_args", test_blend_prims_args},
        {"blend_prims", test_blend_prims},
        {"tangent_joins", test_tangent_joins},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
