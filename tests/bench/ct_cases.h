/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Input generators of the per-call instruction counts, shared by the x86 benchmark
 * (tests/bench/bench_ct.c: callgrind) and the Cortex-M4F costs image (tests/m4/m4_costs.c:
 * the icount counter), so both measure the same inputs: the same PRNG (splitmix64, as
 * ef_test.h's ef_t_rng), the same seed per kind (CT_SEED) and the same order of draws as
 * bench_ct.c, so the M4's first N calls of a kind are x86's first N.
 *
 * Header-only (static functions), C11 with libm in double: on the M4 the double arithmetic
 * is soft-float library code, but it runs outside the measured calls. Every float <-> double
 * conversion is explicit (the M4 project compiles with -Wdouble-promotion).
 *
 * Kinds:
 *   ct_make_config   segment end data (ef_seg_g1_cubic / ef_seg_g2_quintic), CT_PLANAR_XY ..
 *                    CT_REVERSAL; ct_g1_kind() picks the kinds of bench_ct's g1p / g1_3d
 *   ct_make_corner   a line-line corner for ef_blend_corner
 *   ct_make_bprim    a corner with arc ends for ef_blend_prims: line->arc, arc->arc (as
 *                    bench_ct's bprim_la / bprim_aa), arc->line, helix->helix
 *   ct_make_arcpiece an arc and a piece of it for ef_blend_arc_piece
 *   ct_make_measure  a quintic for ef_move_measure
 *   ct_cam_next      the next primitive of bench_ct's CAM-like stream (kind smooth)
 */
#ifndef CT_CASES_H
#define CT_CASES_H

#include <math.h>
#include <stdint.h>
#include <string.h>
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/path/ef_path.h"
#include "evenfeed/seg/ef_seg.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/** Seed of every kind (bench_ct.c's default). */
#define CT_SEED 20240607ull

/* splitmix64, as ef_test.h's ef_t_rng (the same sequence). */
static inline unsigned long long ct_rng(unsigned long long *s)
{
    unsigned long long z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform double in [lo, hi), as ef_t_uniform. */
static inline double ct_uniform(unsigned long long *s, double lo, double hi)
{
    return lo + (hi - lo) * (double)(ct_rng(s) >> 11) * (1.0 / 9007199254740992.0);
}

typedef struct {
    double m[3][3];
} ct_rot3_t;

/* Uniformly random rotation from a random unit quaternion, as ef_t_rot_random. */
static inline ct_rot3_t ct_rot_random(unsigned long long *rs)
{
    double q[4], n;
    do {
        n = 0;
        for (int i = 0; i < 4; i++) {
            q[i] = ct_uniform(rs, -1, 1);
            n += q[i] * q[i];
        }
    } while (n > 1 || n < 1e-6);
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    ct_rot3_t r = {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                    {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                    {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
    return r;
}

static inline ef_vec3_t ct_rot_apply(const ct_rot3_t *r, const double v[3])
{
    double o[3];
    for (int i = 0; i < 3; i++) {
        o[i] = r->m[i][0] * v[0] + r->m[i][1] * v[1] + r->m[i][2] * v[2];
    }
    return ef_v3((float)o[0], (float)o[1], (float)o[2]);
}

static inline ct_rot3_t ct_rot_z(double phi)
{
    ct_rot3_t r = {{{cos(phi), -sin(phi), 0}, {sin(phi), cos(phi), 0}, {0, 0, 1}}};
    return r;
}

static inline void ct_unit_random(unsigned long long *rs, double v[3])
{
    double n;
    do {
        for (int i = 0; i < 3; i++) {
            v[i] = ct_uniform(rs, -1, 1);
        }
        n = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    } while (n > 1 || n < 1e-6);
    n = sqrt(n);
    for (int i = 0; i < 3; i++) {
        v[i] /= n;
    }
}

static inline void ct_normal_for(unsigned long long *rs, const double t[3], int planar, double n[3])
{
    if (planar) {
        n[0] = -t[1];
        n[1] = t[0];
        n[2] = 0;
        double l = sqrt(n[0] * n[0] + n[1] * n[1]);
        if (l < 1e-12) {
            n[0] = 1, n[1] = 0, l = 1;
        }
        for (int i = 0; i < 3; i++) {
            n[i] /= l;
        }
        return;
    }
    double r[3];
    for (;;) {
        ct_unit_random(rs, r);
        double d = r[0] * t[0] + r[1] * t[1] + r[2] * t[2];
        for (int i = 0; i < 3; i++) {
            n[i] = r[i] - d * t[i];
        }
        double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (l > 0.1) {
            for (int i = 0; i < 3; i++) {
                n[i] /= l;
            }
            return;
        }
    }
}

static inline double ct_norm_curvature(unsigned long long *rs, int *zero)
{
    int c = (int)(ct_rng(rs) % 6u);
    *zero = c == 0;
    switch (c) {
    case 0:
        return 0;
    case 1:
    case 2:
        return ct_uniform(rs, -2, 2);
    case 3:
        return ct_uniform(rs, -10, 10);
    case 4:
        return (ct_rng(rs) & 1u ? 1 : -1) * exp(ct_uniform(rs, log(2.0), log(900.0)));
    default:
        return ct_uniform(rs, -0.1, 0.1);
    }
}

static inline double ct_near_axis_angle(unsigned long long *rs, int at_pi)
{
    double eps = exp(ct_uniform(rs, log(1e-6), log(1e-2)));
    double a = at_pi ? M_PI - eps : eps;
    return ct_rng(rs) & 1u ? a : -a;
}

/* Kinds of segment configuration (bench_ct.c's BC_*). */
enum {
    CT_PLANAR_XY,
    CT_PLANAR_ROT,
    CT_TWISTED,
    CT_GENERAL,
    CT_ALONG_AXIS,
    CT_ALONG_ROT,
    CT_NEAR_ALONG,
    CT_REVERSAL,
    CT_COUNT
};

/* The configuration kind of call i: g1_path 0 all kinds in turn, 1 the six coplanar ones
 * (bench_ct g1p), 2 the twisted and general ones (g1_3d). */
/** How far a planar segment (ef_seg_g1_cubic_xy()) is from what it documents, on end data
 *  e0, e1 in a plane z = e0->p.z, against the 3-D path's segment b on the same data; the
 *  largest values so far in w[0..2]:
 *  - w[0]: its angles against b's, rad (-pi and pi count as one);
 *  - w[1]: its DOFs against the table at its own angles times the chord (ef_table_lookup_g1()),
 *    per (1 + |table value|) times the chord: the lookup's rounding. The table's slope can
 *    turn the angles' ulps into far larger DOF changes near a reversal, so the DOFs are held
 *    to the lookup at the angles they were looked up for, the angles to the 3-D path;
 *  - w[2]: its control points against p0 + x1_0 t0 / 3 |t0|, p1 - x1_1 t1 / 3 |t1| (exact
 *    in double), per eps (|coordinates| + |handles|).
 *  Returns whether flags, clamp bits and plane agree with b's (they must). */
static inline int ct_xy_diff(const ef_table_t *tbl, const ef_endpoint_t *e0,
                             const ef_endpoint_t *e1, const ef_seg_xy_t *a, const ef_seg_t *b,
                             double w[3])
{
    double da = fmax(fabs((double)a->alpha - (double)b->norm.alpha),
                     fabs((double)a->beta - (double)b->norm.beta));
    da = fmin(da, fabs(fabs((double)a->alpha) - fabs((double)b->norm.alpha)) +
                      fabs(fabs((double)a->beta) - fabs((double)b->norm.beta)));
    w[0] = fmax(w[0], da);
    float d[2];
    uint32_t fl = 0;
    double c = (double)b->norm.chord;
    if (ef_table_lookup_g1(tbl, a->alpha, a->beta, d, &fl) != EF_OK)
        return 0;
    for (int k = 0; k < 2; k++)
        w[1] = fmax(w[1],
                    fabs((double)a->dof[k] - (double)d[k] * c) / ((1.0 + fabs((double)d[k])) * c));
    const ef_endpoint_t *e[2] = {e0, e1};
    for (int k = 0; k < 2; k++) {
        double tx = (double)e[k]->t.x, ty = (double)e[k]->t.y, tl = hypot(tx, ty);
        double h = (k ? -1.0 : 1.0) * (double)a->dof[k] / 3.0 / tl;
        double px = (double)e[k]->p.x, py = (double)e[k]->p.y;
        double bx = px + h * tx, by = py + h * ty;
        int j = k ? 2 : 1;
        double sc = (fmax(fabs(px), fabs(py)) + fabs(h)) * 1.1920929e-7;
        w[2] = fmax(w[2], hypot((double)a->x[j] - bx, (double)a->y[j] - by) / sc);
        int q = k ? 3 : 0;
        w[2] = fmax(w[2], (a->x[q] != e[k]->p.x || a->y[q] != e[k]->p.y) ? 1e30 : 0.0);
    }
    return a->flags == b->flags && a->clamp == b->clamp && a->z == e0->p.z;
}

/** ct_xy_diff() within what ef_seg.h states: angles within 1e-6 rad, DOFs within 1e-6,
 *  control points within 4 eps. */
static inline int ct_xy_close(const ef_table_t *tbl, const ef_endpoint_t *e0,
                              const ef_endpoint_t *e1, const ef_seg_xy_t *a, const ef_seg_t *b)
{
    double w[3] = {0, 0, 0};
    int same = ct_xy_diff(tbl, e0, e1, a, b, w);
    return same && w[0] <= 1e-6 && w[1] <= 1e-6 && w[2] <= 4.0;
}

static inline int ct_g1_kind(long i, int g1_path)
{
    if (g1_path == 1) {
        return (int)(i % 6) + ((int)(i % 6) >= CT_TWISTED) * 2;
    }
    if (g1_path == 2) {
        return CT_TWISTED + (int)(i % 2);
    }
    return (int)(i % CT_COUNT);
}

/* Set for the XY entry (bench_ct g1p, ef_seg_g1_cubic_xy): ct_make_config() lays every kind
 * in a plane z = const. */
static int ct_xy;

/* One random valid configuration of the given kind; g2 also fills n and kappa. */
static inline void ct_make_config(unsigned long long *rs, int kind, int g2, ef_endpoint_t *e0,
                                  ef_endpoint_t *e1)
{
    double s = exp(ct_uniform(rs, log(1e-3), log(1e3)));
    double rmax = fmin(1e4, 5e4 * s) - s;
    double mag = ct_rng(rs) & 1u ? rmax : rmax * exp(ct_uniform(rs, log(1e-3), 0));
    double p0[3] = {ct_uniform(rs, -mag, mag), ct_uniform(rs, -mag, mag),
                    ct_uniform(rs, -mag, mag)};
    int planar_xy = kind == CT_PLANAR_XY || kind == CT_ALONG_AXIS;
    if (planar_xy) {
        p0[2] = 0;
    }
    ct_rot3_t r;
    if (ct_xy) { /* bench_ct g1p: every kind turned about z only, in the plane z = p0[2] */
        r = ct_rot_z(kind == CT_ALONG_AXIS ? 0 : ct_uniform(rs, -M_PI, M_PI));
    } else if (kind == CT_ALONG_AXIS) {
        r = ct_rot_z(0);
    } else if (kind == CT_PLANAR_XY) {
        r = ct_rot_z(ct_uniform(rs, -M_PI, M_PI));
    } else {
        r = ct_rot_random(rs);
    }
    double t0[3], t1[3];
    double al = ct_uniform(rs, -M_PI, M_PI), be = ct_uniform(rs, -M_PI, M_PI);
    double tw = 0;
    switch (kind) {
    case CT_TWISTED:
        tw = ct_uniform(rs, 1e-3, M_PI - 1e-3);
        break;
    case CT_ALONG_AXIS:
    case CT_ALONG_ROT:
        al = ct_rng(rs) & 1u ? 0 : M_PI;
        be = ct_rng(rs) & 1u ? 0 : M_PI;
        break;
    case CT_NEAR_ALONG:
        al = ct_near_axis_angle(rs, (int)(ct_rng(rs) & 1u));
        be = ct_near_axis_angle(rs, (int)(ct_rng(rs) & 1u));
        break;
    case CT_REVERSAL:
        al = ct_near_axis_angle(rs, 1);
        be = ct_near_axis_angle(rs, 1);
        break;
    default:
        break;
    }
    t0[0] = cos(al), t0[1] = sin(al), t0[2] = 0;
    t1[0] = cos(be), t1[1] = sin(be) * cos(tw), t1[2] = sin(be) * sin(tw);
    if (kind == CT_GENERAL) {
        ct_unit_random(rs, t0);
        ct_unit_random(rs, t1);
    }
    memset(e0, 0, sizeof *e0);
    memset(e1, 0, sizeof *e1);
    const double c1[3] = {s, 0, 0};
    ef_vec3_t d = ct_rot_apply(&r, c1);
    e0->p = ef_v3((float)p0[0], (float)p0[1], (float)p0[2]);
    e1->p = ef_v3((float)(p0[0] + (double)d.x), (float)(p0[1] + (double)d.y),
                  (float)(p0[2] + (double)d.z));
    e0->t = ct_rot_apply(&r, t0);
    e1->t = ct_rot_apply(&r, t1);
    if (g2) {
        int planar = kind == CT_PLANAR_XY || kind == CT_PLANAR_ROT || kind == CT_ALONG_AXIS;
        double n0[3], n1[3];
        int z0, z1;
        double k0 = ct_norm_curvature(rs, &z0), k1 = ct_norm_curvature(rs, &z1);
        ct_normal_for(rs, t0, planar, n0);
        ct_normal_for(rs, t1, planar, n1);
        int zero_n0 = z0 && (ct_rng(rs) & 1u), zero_n1 = z1 && (ct_rng(rs) & 1u);
        e0->n = zero_n0 ? ef_v3(0, 0, 0) : ct_rot_apply(&r, n0);
        e1->n = zero_n1 ? ef_v3(0, 0, 0) : ct_rot_apply(&r, n1);
        e0->kappa = (float)(k0 / s);
        e1->kappa = (float)(k1 / s);
    }
}

/* |d . (t0 x t1)| over the limit below which ef_seg_g1_cubic takes its planar path
 * (EF_SEG_PLANAR_EPS |d| + 8 ulps of the largest coordinate): above 1 is the general path
 * (bench_ct's g1_3d redraws below 4). */
#ifndef EF_SEG_PLANAR_EPS
#define CT_PLANAR_EPS 1e-5
#else
#define CT_PLANAR_EPS ((double)EF_SEG_PLANAR_EPS)
#endif
static inline double ct_g1_coplanarity(const ef_endpoint_t *e0, const ef_endpoint_t *e1)
{
    double d[3] = {(double)e1->p.x - (double)e0->p.x, (double)e1->p.y - (double)e0->p.y,
                   (double)e1->p.z - (double)e0->p.z};
    double a[3] = {(double)e0->t.x, (double)e0->t.y, (double)e0->t.z};
    double b[3] = {(double)e1->t.x, (double)e1->t.y, (double)e1->t.z};
    double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    double scale = 0;
    const ef_vec3_t *p[2] = {&e0->p, &e1->p};
    for (int k = 0; k < 2; k++) {
        scale = fmax(
            scale, fmax(fabs((double)p[k]->x), fmax(fabs((double)p[k]->y), fabs((double)p[k]->z))));
    }
    return fabs(d[0] * c[0] + d[1] * c[1] + d[2] * c[2]) /
           (CT_PLANAR_EPS * sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) +
            8.0 * 1.1920929e-7 * scale);
}

/* Call i of bench_ct's g1 / g1p / g1_3d / g2 (g1_path as ct_g1_kind). */
static inline int ct_make_seg(unsigned long long *rs, long i, int g1_path, int g2,
                              ef_endpoint_t *e0, ef_endpoint_t *e1)
{
    int kind = ct_g1_kind(i, g1_path);
    ct_make_config(rs, kind, g2, e0, e1);
    while (g1_path == 2 && ct_g1_coplanarity(e0, e1) < 4.0) {
        ct_make_config(rs, kind, g2, e0, e1);
    }
    return kind;
}

/* A line-line corner for ef_blend_corner (bench_ct's make_corner). */
static inline void ct_make_corner(unsigned long long *rs, long i, ef_vec3_t *v, ef_vec3_t *ui,
                                  ef_vec3_t *uo, float *tol, float *mi, float *mo)
{
    int cls = (int)(i % 4);
    double th;
    if (cls <= 1) {
        th = ct_uniform(rs, 1e-9, 1.0) * (179.0 * M_PI / 180.0);
    } else if (cls == 2) {
        th = exp(ct_uniform(rs, log(1e-6), log(1e-1)));
    } else {
        th = (double)EF_BLEND_MAX_TURN - exp(ct_uniform(rs, log(1e-5), log(3e-2)));
    }
    ct_rot3_t r = (i / 4) % 2 ? ct_rot_random(rs) : ct_rot_z(ct_uniform(rs, -M_PI, M_PI));
    const double a[3] = {1, 0, 0}, b[3] = {cos(th), sin(th), 0};
    *ui = ct_rot_apply(&r, a);
    *uo = ct_rot_apply(&r, b);
    double mag = exp(ct_uniform(rs, log(1e-3), log(1e3)));
    *v = ef_v3((float)ct_uniform(rs, -mag, mag), (float)ct_uniform(rs, -mag, mag),
               (i / 4) % 2 ? (float)ct_uniform(rs, -mag, mag) : 0.0f);
    *tol = (float)exp(ct_uniform(rs, log(1e-4), log(10.0)));
    *mi = (float)exp(ct_uniform(rs, log(1e-7), log(1e3)));
    *mo = (float)exp(ct_uniform(rs, log(1e-7), log(1e3)));
}

/* Arc (helix when rise != 0) about +Z through v with unit tangent (tx, ty) of its circle
 * there, radius r, signed sweep sw: it starts at v (at_end 0) or ends at v (at_end 1), rising
 * by `rise` along +Z from start to end; *start is where it starts (bench_ct's arc_at with a
 * rise). */
static inline void ct_arc_at(ef_vec3_t v, double tx, double ty, double r, double sw, double rise,
                             int at_end, ef_vec3_t *start, ef_prim_t *pr)
{
    double sg = sw > 0 ? 1 : -1, rx = sg * ty, ry = -sg * tx;
    double cx = (double)v.x - r * rx, cy = (double)v.y - r * ry, av = atan2(ry, rx);
    double ao = at_end ? av - sw : av + sw;
    double zo = at_end ? (double)v.z - rise : (double)v.z + rise;
    ef_vec3_t o = ef_v3((float)(cx + r * cos(ao)), (float)(cy + r * sin(ao)), (float)zo);
    memset(pr, 0, sizeof *pr);
    pr->kind = EF_PRIM_ARC;
    *start = at_end ? o : v;
    pr->centre = ef_v3((float)cx, (float)cy, start->z);
    pr->axis = ef_v3(0.0f, 0.0f, 1.0f);
    pr->sweep = (float)sw;
    pr->feed = 50.0f;
    pr->tol = 0.01f;
    pr->end = at_end ? v : o;
}

static inline double ct_sgn_rand(unsigned long long *rs)
{
    return ct_rng(rs) & 1u ? 1.0 : -1.0;
}

/* Corner kinds of ct_make_bprim. */
enum { CT_BPRIM_LA, CT_BPRIM_AA, CT_BPRIM_AL, CT_BPRIM_HH };

/* One corner for ef_blend_prims: CT_BPRIM_LA / _AA draw exactly as bench_ct's bprim_la /
 * bprim_aa; _AL is an arc into a line, _HH a helix into a helix (rises up to +-0.5 of the
 * radius per radian of sweep). Fills the primitives, their starts and lengths (checked: a
 * nonzero return is ef_prim_check's error) and tol, max_in, max_out as bench_ct passes them. */
typedef struct {
    ef_prim_t in, out;
    ef_vec3_t s_in, s_out;
    float len_in, len_out, tol, max_in, max_out;
} ct_bprim_t;

static inline int ct_make_bprim(unsigned long long *rs, int kind, ct_bprim_t *c)
{
    ef_vec3_t v = ef_v3((float)ct_uniform(rs, -100, 100), (float)ct_uniform(rs, -100, 100),
                        (float)ct_uniform(rs, -20, 20));
    double hi = ct_uniform(rs, -M_PI, M_PI);
    double th = ct_sgn_rand(rs) * ct_uniform(rs, 1e-3, 170.0 * M_PI / 180.0), ho = hi + th;
    int arc_in = kind != CT_BPRIM_LA, arc_out = kind != CT_BPRIM_AL;
    double rise_in = 0, rise_out = 0;
    if (arc_in) {
        double r = exp(ct_uniform(rs, log(0.5), log(50.0)));
        double sw = ct_sgn_rand(rs) * ct_uniform(rs, 0.2, 3.0);
        if (kind == CT_BPRIM_HH) {
            rise_in = ct_uniform(rs, -0.5, 0.5) * r * fabs(sw);
        }
        ct_arc_at(v, cos(hi), sin(hi), r, sw, rise_in, 1, &c->s_in, &c->in);
    } else {
        double l = exp(ct_uniform(rs, log(0.5), log(50.0)));
        memset(&c->in, 0, sizeof c->in);
        c->in.kind = EF_PRIM_LINE;
        c->in.end = v;
        c->in.feed = 50.0f;
        c->in.tol = 0.01f;
        c->s_in =
            ef_v3((float)((double)v.x - l * cos(hi)), (float)((double)v.y - l * sin(hi)), v.z);
    }
    if (arc_out) {
        double r = exp(ct_uniform(rs, log(0.5), log(50.0)));
        double sw = ct_sgn_rand(rs) * ct_uniform(rs, 0.2, 3.0);
        if (kind == CT_BPRIM_HH) {
            rise_out = ct_uniform(rs, -0.5, 0.5) * r * fabs(sw);
        }
        ct_arc_at(v, cos(ho), sin(ho), r, sw, rise_out, 0, &c->s_out, &c->out);
    } else {
        double l = exp(ct_uniform(rs, log(0.5), log(50.0)));
        memset(&c->out, 0, sizeof c->out);
        c->out.kind = EF_PRIM_LINE;
        c->out.end =
            ef_v3((float)((double)v.x + l * cos(ho)), (float)((double)v.y + l * sin(ho)), v.z);
        c->out.feed = 50.0f;
        c->out.tol = 0.01f;
        c->s_out = v;
    }
    int rc = ef_prim_check(c->s_in, &c->in, &c->len_in);
    if (rc == EF_OK) {
        rc = ef_prim_check(v, &c->out, &c->len_out);
    }
    c->tol = (float)exp(ct_uniform(rs, log(1e-3), log(0.1)));
    c->max_in = 0.5f * c->len_in;
    c->max_out = 0.5f * c->len_out;
    return rc;
}

/* An arc and a piece of it for ef_blend_arc_piece (bench_ct's run_arcpiece). */
typedef struct {
    ef_prim_t pr;
    ef_vec3_t start;
    float s0, s1;
} ct_arcpiece_t;

static inline int ct_make_arcpiece(unsigned long long *rs, ct_arcpiece_t *c)
{
    ef_vec3_t v = ef_v3((float)ct_uniform(rs, -100, 100), (float)ct_uniform(rs, -100, 100),
                        (float)ct_uniform(rs, -20, 20));
    double h = ct_uniform(rs, -M_PI, M_PI), r = exp(ct_uniform(rs, log(0.5), log(50.0)));
    double sw = ct_sgn_rand(rs) * ct_uniform(rs, 0.1, 6.0);
    ct_arc_at(v, cos(h), sin(h), r, sw, 0.0, 0, &c->start, &c->pr);
    float len;
    int rc = ef_prim_check(c->start, &c->pr, &len);
    if (rc != EF_OK) {
        return rc;
    }
    double psw = fmin(ct_uniform(rs, 0.01, 0.999 * (double)EF_ARC_PIECE_SWEEP), fabs(sw));
    double pl = (double)len * psw / fabs(sw);
    double s0 = fmax(0.0, ct_uniform(rs, 0, (double)len - pl));
    c->s0 = (float)s0;
    c->s1 = (float)fmin(s0 + pl, (double)len);
    return EF_OK;
}

/* A quintic for ef_move_measure (bench_ct's run_measure). */
static inline void ct_make_measure(unsigned long long *rs, ef_move_t *m)
{
    memset(m, 0, sizeof *m);
    m->degree = 5;
    m->kind = EF_MOVE_SMOOTH;
    double step = exp(ct_uniform(rs, log(2e-3), log(20.0)));
    double h = ct_uniform(rs, -M_PI, M_PI), dh = ct_uniform(rs, -0.6, 0.6);
    double x = ct_uniform(rs, -100, 100), y = ct_uniform(rs, -100, 100);
    double z = ct_uniform(rs, -20, 20), dz = ct_uniform(rs, -0.2, 0.2) * step;
    for (int j = 0; j < 6; j++) {
        m->b[j] = ef_v3((float)x, (float)y, (float)z);
        x += step * cos(h);
        y += step * sin(h);
        z += dz;
        h += dh;
    }
}

/* bench_ct's CAM-like stream (kind smooth): micro-segment curves, collinear splits, corners,
 * arcs, planar in z = 0, steering back towards the origin beyond 50. */
typedef struct {
    double x, y, h, kap;
    long run;
    int what;
} ct_cam_t;

static inline void ct_cam_init(ct_cam_t *c)
{
    memset(c, 0, sizeof *c);
    c->kap = 0.1;
}

static inline void ct_cam_next(unsigned long long *rs, ct_cam_t *c, long i, ef_prim_t *pr)
{
    if (c->run == 0) {
        int f = (int)(ct_rng(rs) % 10u);
        c->what = f < 6 ? 0 : f < 7 ? 1 : f < 9 ? 2 : 3;
        c->run = c->what == 0 ? 10 + (long)(ct_rng(rs) % 40u) : c->what == 1 ? 3 : 1;
        c->kap = ct_uniform(rs, -0.5, 0.5);
        if (c->x * c->x + c->y * c->y > 2500) {
            c->kap = (cos(c->h) * -c->y - sin(c->h) * -c->x) >= 0 ? fabs(c->kap) : -fabs(c->kap);
        }
    }
    c->run--;
    memset(pr, 0, sizeof *pr);
    pr->feed = 50.0f;
    pr->tol = 0.01f;
    pr->qtol = 0.001f;
    pr->tag = (uint32_t)i;
    if (c->what == 3) {
        ef_vec3_t st;
        double r = exp(ct_uniform(rs, log(1.0), log(20.0)));
        ct_arc_at(ef_v3((float)c->x, (float)c->y, 0.0f), cos(c->h), sin(c->h), r,
                  ct_sgn_rand(rs) * ct_uniform(rs, 0.3, 3.0), 0.0, 0, &st, pr);
        pr->tag = (uint32_t)i;
        pr->qtol = 0.001f;
        c->h += (double)pr->sweep;
        c->x = (double)pr->end.x;
        c->y = (double)pr->end.y;
    } else {
        double d = c->what == 0 ? ct_uniform(rs, 0.1, 0.8) : ct_uniform(rs, 1, 10);
        if (c->what == 0) {
            c->h += d * c->kap;
        } else if (c->what == 2) {
            c->h += ct_sgn_rand(rs) * ct_uniform(rs, 0.5, 2.5);
        }
        c->x += d * cos(c->h);
        c->y += d * sin(c->h);
        pr->kind = EF_PRIM_LINE;
        pr->end = ef_v3((float)c->x, (float)c->y, 0.0f);
    }
    if (i == 0) {
        pr->flags = EF_PRIM_STOP_BEFORE;
    }
}

#endif /* CT_CASES_H */
