/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Constant-time benchmark driver for ef_seg_g1_cubic / ef_seg_g2_quintic.
 *
 * For each of N random valid configurations it makes exactly one call, bracketed by
 * CALLGRIND_ZERO_STATS / CALLGRIND_DUMP_STATS, so that run under
 *   valgrind --tool=callgrind --collect-atstart=no --toggle-collect=ef_seg_g1_cubic ...
 * every dump holds the instruction count of one call, callees included. tests/bench/
 * ct_bench.sh runs it and reduces the dumps to min / median / max. Outside valgrind the
 * client requests are no-ops and the program only checks that every call succeeds.
 *
 * Usage: bench_ct g1|g1p|g1_3d|g2|blend N [dump|nodump] [seed]
 *   g1p: ef_seg_g1_cubic_xy (the XY fast path) on the coplanar kinds laid in planes z = const
 *   (each segment also checked against ef_seg_g1_cubic's, bit for bit); g1_3d:
 *   ef_seg_g1_cubic on the twisted and general 3-D kinds, clearly off a plane
 *   nodump leaves out the client requests, so a single end-of-run dump holds the sum over
 *   all calls: ct_bench.sh --verify compares it with the sum of the per-call dumps.
 *
 * Built with EF_BENCH_PATH (the bench_ct_path target, default tables linked) it also takes
 * the per-move building functions of the runtime smoother (figures, not a constant-time
 * check):
 *   bprim_la  ef_blend_prims, a line into an arc       bprim_aa  the same, arc into arc
 *   bprim_la_v, bprim_aa_v  the same corners through ef_blend_prims_valid (the smoother's
 *             call: the primitives were checked when pushed)
 *   arcpiece  ef_blend_arc_piece                        measure   ef_move_measure (quintics)
 *   smooth    a stream of N CAM-like primitives through ef_smooth_push / ef_smooth_pull, then
 *             ef_smooth_finish until done; every push, pull and finish is one dump, and stdout
 *             lists them in order ("call push", "call pull" for a pulled move, "call pull0"
 *             for an empty pull, "call finish")
 *   interp    the same stream, its moves through ef_interp (uniform stepping, 1 ms period):
 *             every ef_interp_process call is one dump ("call period"), to the end at rest
 *   interp_c  the same with corrected stepping
 *
 * The configurations cover everything the firmware accepts: planar data (in z = 0 and in
 * rotated planes), twisted 3-D tangents, tangents exactly and nearly along the chord,
 * near-reversals, chords 1e-3..1e3, coordinates up to 1e4, and for G2 curvatures of
 * either sign including 0 with a zero normal, inside and far outside the table domain.
 * Every call must return EF_OK: the benchmark measures the valid-input path only.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
/* The header comes with valgrind; without it the bench still builds (and ct_bench.sh then
 * skips, having no valgrind to run it under). */
#if defined(__has_include)
#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#endif
#endif
#ifndef CALLGRIND_ZERO_STATS
#define CALLGRIND_ZERO_STATS ((void)0)
#define CALLGRIND_DUMP_STATS ((void)0)
#endif
#include "ct_cases.h"
#include "ef_test.h"
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/seg/ef_seg.h"
#include "evenfeed/table/ef_table.h"
#ifdef EF_BENCH_PATH
#include "evenfeed/path/ef_path.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"
#endif

#ifdef EF_BENCH_DEFAULT_TABLES
/* The generated default tables, linked in (tables/). */
extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;
#define EF_BENCH_G1 (&ef_tbl_g1_default)
#define EF_BENCH_G2 (&ef_tbl_g2_default)
#else
/* Synthetic tables of the default shapes. Instruction counts do not depend on the stored
 * values (the lookup reads a fixed set of nodes and blends them), only on the shape, so
 * arbitrary in-bounds values give the figures a real table will give. */
#define EF_G1_NU    33u
#define EF_G1_NV    65u
#define EF_G2_NA    7u
#define EF_G2_NB    13u
#define EF_G2_NK    9u
static float g1_data[EF_G1_NU * EF_G1_NV * 2];
static float g2_data[EF_G2_NA * EF_G2_NB * EF_G2_NK * EF_G2_NK * 4];
static ef_table_t g1_syn, g2_syn;
#define EF_BENCH_G1 (&g1_syn)
#define EF_BENCH_G2 (&g2_syn)

/* Fill a view the way generated sources do: strides axis 0 fastest, inv_step derived. */
static void syn_table(ef_table_t *t, int kind, int sym, int naxes, const float *lo, const float *hi,
                      const uint32_t *n, float *data, unsigned long long *rs)
{
    memset(t, 0, sizeof *t);
    t->kind = (uint16_t)kind;
    t->symmetry = (uint16_t)sym;
    t->naxes = t->ndof = (uint8_t)naxes;
    t->quad_nodes = 16;
    t->x1_min = 0.05f;
    t->x1_max = 4.0f;
    t->x2_max = kind == EF_TABLE_G2_QUINTIC ? 50.0f : 0.0f;
    uint32_t stride = 1;
    for (int a = 0; a < naxes; a++) {
        t->axis[a].lo = lo[a];
        t->axis[a].hi = hi[a];
        t->axis[a].nodes = n[a];
        t->axis[a].inv_step = (float)(n[a] - 1) / (hi[a] - lo[a]);
        t->axis[a].stride = stride;
        stride *= n[a];
    }
    t->nodes = stride;
    /* x1 values inside [x1_min, x1_max], x2 values inside +-x2_max. */
    for (uint32_t i = 0; i < stride * (uint32_t)naxes; i++) {
        int is_x2 = kind == EF_TABLE_G2_QUINTIC && (i % 2u) == 1u;
        data[i] = is_x2 ? (float)ef_t_uniform(rs, -10, 10) : (float)ef_t_uniform(rs, 0.2, 2.5);
    }
    t->data = data;
}

/* The default table shapes: G1 fold 33x65 over [0,pi/2]x[0,pi], G2 mirror 7x13x9x9. */
static void syn_tables(void)
{
    unsigned long long rs = 99;
    const float g1lo[2] = {0.0f, 0.0f}, g1hi[2] = {(float)(M_PI / 2), (float)M_PI};
    const uint32_t g1n[2] = {EF_G1_NU, EF_G1_NV};
    syn_table(&g1_syn, EF_TABLE_G1_CUBIC, EF_SYM_G1_FOLD, 2, g1lo, g1hi, g1n, g1_data, &rs);
    const float g2lo[4] = {0.0f, (float)(-M_PI / 2), -2.0f, -2.0f};
    const float g2hi[4] = {(float)(M_PI / 2), (float)(M_PI / 2), 2.0f, 2.0f};
    const uint32_t g2n[4] = {EF_G2_NA, EF_G2_NB, EF_G2_NK, EF_G2_NK};
    syn_table(&g2_syn, EF_TABLE_G2_QUINTIC, EF_SYM_G2_MIRROR, 4, g2lo, g2hi, g2n, g2_data, &rs);
}
#endif

/* Kinds of configuration, visited in turn so each gets N / BC_COUNT calls. */
enum {
    BC_PLANAR_XY,  /* data in z = 0, chord in any direction */
    BC_PLANAR_ROT, /* planar data in a randomly rotated plane */
    BC_TWISTED,    /* t1 turned out of t0's plane about the chord */
    BC_GENERAL,    /* independent random tangents in 3-D */
    BC_ALONG_AXIS, /* tangents exactly +-chord, chord exactly along x (exact zeros) */
    BC_ALONG_ROT,  /* tangents +-chord in a rotated frame (zeros up to rounding) */
    BC_NEAR_ALONG, /* angles within 1e-6..1e-2 of 0 or pi */
    BC_REVERSAL,   /* both angles near +-pi (the tangents point back along the chord) */
    BC_COUNT
};

/* 3x3 rotation applied to a canonical-frame vector. */
static ef_vec3_t rot_apply(const ef_t_rot3_t *r, const double v[3])
{
    double o[3];
    for (int i = 0; i < 3; i++)
        o[i] = r->m[i][0] * v[0] + r->m[i][1] * v[1] + r->m[i][2] * v[2];
    return ef_v3((float)o[0], (float)o[1], (float)o[2]);
}

/* Rotation about z by phi: keeps planar data in z = 0. */
static ef_t_rot3_t rot_z(double phi)
{
    ef_t_rot3_t r = {{{cos(phi), -sin(phi), 0}, {sin(phi), cos(phi), 0}, {0, 0, 1}}};
    return r;
}

/* Uniformly random rotation, from a random unit quaternion. */

/* Random unit vector (canonical frame). */
static void unit_random(unsigned long long *rs, double v[3])
{
    double n;
    do {
        for (int i = 0; i < 3; i++)
            v[i] = ef_t_uniform(rs, -1, 1);
        n = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    } while (n > 1 || n < 1e-6);
    n = sqrt(n);
    for (int i = 0; i < 3; i++)
        v[i] /= n;
}

/* A unit vector perpendicular to unit t: a random one, or the in-plane normal when planar. */
static void normal_for(unsigned long long *rs, const double t[3], int planar, double n[3])
{
    if (planar) {
        n[0] = -t[1];
        n[1] = t[0];
        n[2] = 0;
        double l = sqrt(n[0] * n[0] + n[1] * n[1]);
        if (l < 1e-12) { /* t along z cannot happen for planar data; keep n defined */
            n[0] = 1, n[1] = 0, l = 1;
        }
        for (int i = 0; i < 3; i++)
            n[i] /= l;
        return;
    }
    double r[3];
    for (;;) {
        unit_random(rs, r);
        double d = r[0] * t[0] + r[1] * t[1] + r[2] * t[2];
        for (int i = 0; i < 3; i++)
            n[i] = r[i] - d * t[i];
        double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (l > 0.1) {
            for (int i = 0; i < 3; i++)
                n[i] /= l;
            return;
        }
    }
}

/* Curvature x chord for one end: zero, inside the table's [-2, 2], or outside it (up to
 * 900, below EF_MAX_NORM_CURVATURE = 1e3). */
static double norm_curvature(unsigned long long *rs, int *zero)
{
    int c = (int)(ef_t_rng(rs) % 6u);
    *zero = c == 0;
    switch (c) {
    case 0:
        return 0;
    case 1:
    case 2:
        return ef_t_uniform(rs, -2, 2);
    case 3:
        return ef_t_uniform(rs, -10, 10);
    case 4:
        return (ef_t_rng(rs) & 1u ? 1 : -1) * exp(ef_t_uniform(rs, log(2.0), log(900.0)));
    default:
        return ef_t_uniform(rs, -0.1, 0.1);
    }
}

/* Angle near 0 or pi, either sign, at a log-uniform distance 1e-6..1e-2. */
static double near_axis_angle(unsigned long long *rs, int at_pi)
{
    double eps = exp(ef_t_uniform(rs, log(1e-6), log(1e-2)));
    double a = at_pi ? M_PI - eps : eps;
    return ef_t_rng(rs) & 1u ? a : -a;
}

/* One random valid configuration of the given kind; g2 also fills n and kappa. */
/* Set for g1p: make_config() lays every kind in a plane z = const. */
static int bench_xy;

static void make_config(unsigned long long *rs, int kind, int g2, ef_endpoint_t *e0,
                        ef_endpoint_t *e1)
{
    /* Chord log-uniform in [1e-3, 1e3]; coordinates bounded so the chord stays at least
     * 2e-5 of the largest coordinate, twice the firmware's EF_MIN_CHORD_REL. */
    double s = exp(ef_t_uniform(rs, log(1e-3), log(1e3)));
    double rmax = fmin(1e4, 5e4 * s) - s;
    /* Half the offsets near the largest allowed, half log-spread down to 1e-3 of it. */
    double mag = ef_t_rng(rs) & 1u ? rmax : rmax * exp(ef_t_uniform(rs, log(1e-3), 0));
    double p0[3] = {ef_t_uniform(rs, -mag, mag), ef_t_uniform(rs, -mag, mag),
                    ef_t_uniform(rs, -mag, mag)};
    int planar_xy = kind == BC_PLANAR_XY || kind == BC_ALONG_AXIS;
    if (planar_xy)
        p0[2] = 0;
    ef_t_rot3_t r;
    if (bench_xy) /* g1p: every kind turned about z only, in the plane z = p0[2] */
        r = rot_z(kind == BC_ALONG_AXIS ? 0 : ef_t_uniform(rs, -M_PI, M_PI));
    else if (kind == BC_ALONG_AXIS)
        r = rot_z(0);
    else if (kind == BC_PLANAR_XY)
        r = rot_z(ef_t_uniform(rs, -M_PI, M_PI));
    else
        r = ef_t_rot_random(rs);

    /* Tangents in the canonical frame: chord along +x, reference plane xy. */
    double t0[3], t1[3];
    double al = ef_t_uniform(rs, -M_PI, M_PI), be = ef_t_uniform(rs, -M_PI, M_PI);
    double tw = 0;
    switch (kind) {
    case BC_TWISTED:
        tw = ef_t_uniform(rs, 1e-3, M_PI - 1e-3);
        break;
    case BC_ALONG_AXIS:
    case BC_ALONG_ROT:
        al = ef_t_rng(rs) & 1u ? 0 : M_PI;
        be = ef_t_rng(rs) & 1u ? 0 : M_PI;
        break;
    case BC_NEAR_ALONG:
        al = near_axis_angle(rs, (int)(ef_t_rng(rs) & 1u));
        be = near_axis_angle(rs, (int)(ef_t_rng(rs) & 1u));
        break;
    case BC_REVERSAL:
        al = near_axis_angle(rs, 1);
        be = near_axis_angle(rs, 1);
        break;
    default:
        break;
    }
    t0[0] = cos(al), t0[1] = sin(al), t0[2] = 0;
    t1[0] = cos(be), t1[1] = sin(be) * cos(tw), t1[2] = sin(be) * sin(tw);
    if (kind == BC_GENERAL) {
        unit_random(rs, t0);
        unit_random(rs, t1);
    }

    memset(e0, 0, sizeof *e0);
    memset(e1, 0, sizeof *e1);
    const double c1[3] = {s, 0, 0};
    ef_vec3_t d = rot_apply(&r, c1);
    e0->p = ef_v3((float)p0[0], (float)p0[1], (float)p0[2]);
    e1->p = ef_v3((float)(p0[0] + d.x), (float)(p0[1] + d.y), (float)(p0[2] + d.z));
    e0->t = rot_apply(&r, t0);
    e1->t = rot_apply(&r, t1);
    if (g2) {
        int planar = kind == BC_PLANAR_XY || kind == BC_PLANAR_ROT || kind == BC_ALONG_AXIS;
        double n0[3], n1[3];
        int z0, z1;
        double k0 = norm_curvature(rs, &z0), k1 = norm_curvature(rs, &z1);
        normal_for(rs, t0, planar, n0);
        normal_for(rs, t1, planar, n1);
        /* kappa == 0 goes with a zero normal half of the time (both are valid input). */
        int zero_n0 = z0 && (ef_t_rng(rs) & 1u), zero_n1 = z1 && (ef_t_rng(rs) & 1u);
        e0->n = zero_n0 ? ef_v3(0, 0, 0) : rot_apply(&r, n0);
        e1->n = zero_n1 ? ef_v3(0, 0, 0) : rot_apply(&r, n1);
        e0->kappa = (float)(k0 / s);
        e1->kappa = (float)(k1 / s);
    }
}

/*
 * One random valid corner for ef_blend_corner (kind "blend", G2 table): turns uniform over
 * (0, 179] degrees, near 0 (some below EF_BLEND_MIN_TURN: the straight outcome) and just
 * below the reversal threshold; in z = 0 or a random plane; corners up to 1e3 from the
 * origin; tolerances 1e-4..10; neighbour limits 1e-7..1e3 (clamped and, where the blend
 * would be below float resolution, the stop outcome). Every outcome is valid input.
 */
static void make_corner(unsigned long long *rs, long i, ef_vec3_t *v, ef_vec3_t *ui, ef_vec3_t *uo,
                        float *tol, float *mi, float *mo)
{
    int cls = (int)(i % 4);
    double th;
    if (cls <= 1)
        th = ef_t_uniform(rs, 1e-9, 1.0) * (179.0 * M_PI / 180.0);
    else if (cls == 2)
        th = exp(ef_t_uniform(rs, log(1e-6), log(1e-1)));
    else
        th = EF_BLEND_MAX_TURN - exp(ef_t_uniform(rs, log(1e-5), log(3e-2)));
    ef_t_rot3_t r = (i / 4) % 2 ? ef_t_rot_random(rs) : rot_z(ef_t_uniform(rs, -M_PI, M_PI));
    const double a[3] = {1, 0, 0}, b[3] = {cos(th), sin(th), 0};
    *ui = rot_apply(&r, a);
    *uo = rot_apply(&r, b);
    double mag = exp(ef_t_uniform(rs, log(1e-3), log(1e3)));
    *v = ef_v3((float)ef_t_uniform(rs, -mag, mag), (float)ef_t_uniform(rs, -mag, mag),
               (i / 4) % 2 ? (float)ef_t_uniform(rs, -mag, mag) : 0.0f);
    *tol = (float)exp(ef_t_uniform(rs, log(1e-4), log(10.0)));
    *mi = (float)exp(ef_t_uniform(rs, log(1e-7), log(1e3)));
    *mo = (float)exp(ef_t_uniform(rs, log(1e-7), log(1e3)));
}

/* Outcome index of a blend for the per-mode tally: 0 blend, 1 straight, 2 stop, 3 clamped. */
static int blend_outcome(unsigned flags)
{
    return (flags & EF_BLEND_STRAIGHT)  ? 1
           : (flags & EF_BLEND_STOP)    ? 2
           : (flags & EF_BLEND_CLAMPED) ? 3
                                        : 0;
}

/* Corner blends: N calls of ef_blend_corner, one dump each; counts the outcomes. */
static int run_blend(const ef_table_t *tbl, long n, int dump, unsigned long long *rs)
{
    long outcome[4] = {0};
    for (long i = 0; i < n; i++) {
        ef_vec3_t v, ui, uo;
        float tol, mi, mo;
        ef_blend_t bl;
        make_corner(rs, i, &v, &ui, &uo, &tol, &mi, &mo);
        if (dump)
            CALLGRIND_ZERO_STATS;
        int rc = ef_blend_corner(tbl, v, ui, uo, tol, mi, mo, &bl);
        if (dump)
            CALLGRIND_DUMP_STATS;
        if (rc != EF_OK) {
            fprintf(stderr, "bench_ct: blend call %ld failed: %s\n", i, ef_err_str(rc));
            return 1;
        }
        outcome[blend_outcome(bl.flags)]++;
    }
    printf("bench_ct blend: %ld calls OK; blend %ld, straight %ld, stop %ld, clamped %ld\n", n,
           outcome[0], outcome[1], outcome[2], outcome[3]);
    return 0;
}

#ifdef EF_BENCH_PATH
/*
 * Per-move building functions of the runtime smoother. Geometry is planar in XY at a random
 * height; arcs turn about +Z.
 */

/* Arc about +Z through v with unit tangent (tx, ty) there, radius r, signed sweep sw: it starts
 * at v (at_end 0) or ends at v (at_end 1); *start is where it starts. */
static void arc_at(ef_vec3_t v, double tx, double ty, double r, double sw, int at_end,
                   ef_vec3_t *start, ef_prim_t *pr)
{
    double sg = sw > 0 ? 1 : -1, rx = sg * ty, ry = -sg * tx; /* unit centre -> v */
    double cx = v.x - r * rx, cy = v.y - r * ry, av = atan2(ry, rx);
    double ao = at_end ? av - sw : av + sw;
    ef_vec3_t o = ef_v3((float)(cx + r * cos(ao)), (float)(cy + r * sin(ao)), v.z);
    memset(pr, 0, sizeof *pr);
    pr->kind = EF_PRIM_ARC;
    pr->centre = ef_v3((float)cx, (float)cy, v.z);
    pr->axis = ef_v3(0.0f, 0.0f, 1.0f);
    pr->sweep = (float)sw;
    pr->feed = 50.0f;
    pr->tol = 0.01f;
    *start = at_end ? o : v;
    pr->end = at_end ? v : o;
}

static double sgn_rand(unsigned long long *rs)
{
    return ef_t_rng(rs) & 1u ? 1.0 : -1.0;
}

/* ef_blend_prims (valid 0) or ef_blend_prims_valid (valid 1) on N random corners:
 * line -> arc (arcs 0) or arc -> arc (arcs 1). */
static int run_bprim(const ef_table_t *tbl, long n, int dump, int arcs, int valid,
                     unsigned long long *rs)
{
    long outcome[4] = {0};
    for (long i = 0; i < n; i++) {
        ef_vec3_t v = ef_v3((float)ef_t_uniform(rs, -100, 100), (float)ef_t_uniform(rs, -100, 100),
                            (float)ef_t_uniform(rs, -20, 20));
        double hi = ef_t_uniform(rs, -M_PI, M_PI);
        double th = sgn_rand(rs) * ef_t_uniform(rs, 1e-3, 170.0 * M_PI / 180.0), ho = hi + th;
        ef_prim_t in, out;
        ef_vec3_t s_in, s_out;
        if (arcs) {
            arc_at(v, cos(hi), sin(hi), exp(ef_t_uniform(rs, log(0.5), log(50.0))),
                   sgn_rand(rs) * ef_t_uniform(rs, 0.2, 3.0), 1, &s_in, &in);
        } else {
            double l = exp(ef_t_uniform(rs, log(0.5), log(50.0)));
            memset(&in, 0, sizeof in);
            in.kind = EF_PRIM_LINE;
            in.end = v;
            in.feed = 50.0f;
            in.tol = 0.01f;
            s_in = ef_v3((float)(v.x - l * cos(hi)), (float)(v.y - l * sin(hi)), v.z);
        }
        arc_at(v, cos(ho), sin(ho), exp(ef_t_uniform(rs, log(0.5), log(50.0))),
               sgn_rand(rs) * ef_t_uniform(rs, 0.2, 3.0), 0, &s_out, &out);
        float len_in, len_out;
        int rc = ef_prim_check(s_in, &in, &len_in);
        if (rc == EF_OK)
            rc = ef_prim_check(v, &out, &len_out);
        if (rc != EF_OK) {
            fprintf(stderr, "bench_ct: corner %ld: primitive rejected: %s\n", i, ef_err_str(rc));
            return 1;
        }
        float tol = (float)exp(ef_t_uniform(rs, log(1e-3), log(0.1)));
        ef_blend_t bl;
        if (dump)
            CALLGRIND_ZERO_STATS;
        if (valid)
            rc = ef_blend_prims_valid(tbl, s_in, &in, len_in, &out, len_out, tol, 0.5f * len_in,
                                      0.5f * len_out, &bl);
        else
            rc = ef_blend_prims(tbl, s_in, &in, len_in, &out, len_out, tol, 0.5f * len_in,
                                0.5f * len_out, &bl);
        if (dump)
            CALLGRIND_DUMP_STATS;
        if (rc != EF_OK) {
            fprintf(stderr, "bench_ct: ef_blend_prims call %ld failed: %s\n", i, ef_err_str(rc));
            return 1;
        }
        outcome[blend_outcome(bl.flags)]++;
    }
    printf("bench_ct %s%s: %ld calls OK; blend %ld, straight %ld, stop %ld, clamped %ld\n",
           arcs ? "bprim_aa" : "bprim_la", valid ? "_v" : "", n, outcome[0], outcome[1], outcome[2],
           outcome[3]);
    return 0;
}

/* ef_blend_arc_piece on N random arcs and pieces (sweep of a piece 0.01..EF_ARC_PIECE_SWEEP). */
static int run_arcpiece(const ef_table_t *tbl, long n, int dump, unsigned long long *rs)
{
    for (long i = 0; i < n; i++) {
        ef_vec3_t v = ef_v3((float)ef_t_uniform(rs, -100, 100), (float)ef_t_uniform(rs, -100, 100),
                            (float)ef_t_uniform(rs, -20, 20));
        double h = ef_t_uniform(rs, -M_PI, M_PI), r = exp(ef_t_uniform(rs, log(0.5), log(50.0)));
        double sw = sgn_rand(rs) * ef_t_uniform(rs, 0.1, 6.0);
        ef_prim_t pr;
        ef_vec3_t st;
        arc_at(v, cos(h), sin(h), r, sw, 0, &st, &pr);
        float len;
        int rc = ef_prim_check(st, &pr, &len);
        if (rc != EF_OK) {
            fprintf(stderr, "bench_ct: arc %ld rejected: %s\n", i, ef_err_str(rc));
            return 1;
        }
        double psw = fmin(ef_t_uniform(rs, 0.01, 0.999 * (double)EF_ARC_PIECE_SWEEP), fabs(sw));
        double pl = (double)len * psw / fabs(sw);
        double s0 = fmax(0.0, ef_t_uniform(rs, 0, (double)len - pl));
        float f0 = (float)s0, f1 = (float)fmin(s0 + pl, (double)len);
        ef_move_t m;
        if (dump)
            CALLGRIND_ZERO_STATS;
        rc = ef_blend_arc_piece(tbl, st, &pr, f0, f1, &m);
        if (dump)
            CALLGRIND_DUMP_STATS;
        if (rc != EF_OK) {
            fprintf(stderr, "bench_ct: ef_blend_arc_piece call %ld failed: %s\n", i,
                    ef_err_str(rc));
            return 1;
        }
    }
    printf("bench_ct arcpiece: %ld calls OK\n", n);
    return 0;
}

/* ef_move_measure on N random quintics (chords 1e-2..1e2, turning control polygons). */
static int run_measure(long n, int dump, unsigned long long *rs)
{
    for (long i = 0; i < n; i++) {
        ef_move_t m;
        memset(&m, 0, sizeof m);
        m.degree = 5;
        m.kind = EF_MOVE_SMOOTH;
        double step = exp(ef_t_uniform(rs, log(2e-3), log(20.0)));
        double h = ef_t_uniform(rs, -M_PI, M_PI), dh = ef_t_uniform(rs, -0.6, 0.6);
        double x = ef_t_uniform(rs, -100, 100), y = ef_t_uniform(rs, -100, 100);
        double z = ef_t_uniform(rs, -20, 20), dz = ef_t_uniform(rs, -0.2, 0.2) * step;
        for (int j = 0; j < 6; j++) {
            m.b[j] = ef_v3((float)x, (float)y, (float)z);
            x += step * cos(h);
            y += step * sin(h);
            z += dz;
            h += dh;
        }
        if (dump)
            CALLGRIND_ZERO_STATS;
        int rc = ef_move_measure(&m);
        if (dump)
            CALLGRIND_DUMP_STATS;
        if (rc != EF_OK) {
            fprintf(stderr, "bench_ct: ef_move_measure call %ld failed: %s\n", i, ef_err_str(rc));
            return 1;
        }
    }
    printf("bench_ct measure: %ld calls OK\n", n);
    return 0;
}

static ef_smooth_t bench_sm;

/* One pull, dumped; prints which kind of call it was. Returns 1 when a move came out. */
/* Kinds interp / interp_c: pulled moves go through the interpolator (uniform / corrected
 * stepping, 1 ms period) and only ef_interp_process is dumped, one dump per period. */
static int bench_interp = -1;
static ef_interp_t bench_ip;
static long bench_periods;

/* One servo period, dumped; "call period" in the log. */
static int interp_period(void)
{
    uint32_t next;
    ef_setpoint_t sp;
    CALLGRIND_ZERO_STATS;
    int rc = ef_interp_process(&bench_ip, 1000u, &next, &sp);
    CALLGRIND_DUMP_STATS;
    printf("call period\n");
    bench_periods++;
    if (rc != EF_OK && rc != EF_ERR_UNDERRUN) {
        fprintf(stderr, "bench_ct: ef_interp_process: %s\n", ef_err_str(rc));
        exit(1);
    }
    return sp.moving;
}

static int smooth_pull(int dump, long *moves)
{
    ef_move_t m;
    if (bench_interp >= 0) {
        int rc = ef_smooth_pull(&bench_sm, &m);
        if (rc != EF_OK)
            return 0;
        while (ef_interp_space(&bench_ip) == 0)
            interp_period();
        if (ef_interp_push(&bench_ip, &m) != EF_OK) {
            fprintf(stderr, "bench_ct: ef_interp_push refused a move\n");
            exit(1);
        }
        ++*moves;
        return 1;
    }
    if (dump)
        CALLGRIND_ZERO_STATS;
    int rc = ef_smooth_pull(&bench_sm, &m);
    if (dump)
        CALLGRIND_DUMP_STATS;
    printf("call %s\n", rc == EF_OK ? "pull" : "pull0");
    *moves += rc == EF_OK;
    return rc == EF_OK;
}

/* N CAM-like primitives (micro-segment curves, collinear splits, corners, arcs) through the
 * smoother, pulling after every push. */
static int run_smooth(const ef_table_t *tbl, long n, int dump, unsigned long long *rs)
{
    ef_smooth_cfg_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.g2 = tbl;
    for (int k = 0; k < 3; k++) {
        cfg.lim.v_axis[k] = 200.0f;
        cfg.lim.a_axis[k] = 1000.0f;
    }
    cfg.lim.a_normal_frac = 0.5f;
    cfg.lim.j_max = 20000.0f; /* the CLI's default: jerk-limited ramps cost most */
    cfg.micro_len = 1.0f;
    cfg.micro_turn = 0.35f;
    cfg.smooth_degree = 5;
    double x = 0, y = 0, h = 0, kap = 0.1;
    int rc = ef_smooth_init(&bench_sm, &cfg, ef_v3(0.0f, 0.0f, 0.0f));
    if (rc != EF_OK) {
        fprintf(stderr, "bench_ct: ef_smooth_init: %s\n", ef_err_str(rc));
        return 1;
    }
    long moves = 0, pushes = 0, run = 0;
    int what = 0;
    for (long i = 0; i < n; i++) {
        if (run == 0) { /* next feature: 0 micro curve, 1 straight split, 2 corner, 3 arc */
            int f = (int)(ef_t_rng(rs) % 10u);
            what = f < 6 ? 0 : f < 7 ? 1 : f < 9 ? 2 : 3;
            run = what == 0 ? 10 + (long)(ef_t_rng(rs) % 40u) : what == 1 ? 3 : 1;
            kap = ef_t_uniform(rs, -0.5, 0.5);
            if (x * x + y * y > 2500) /* steer back */
                kap = (cos(h) * -y - sin(h) * -x) >= 0 ? fabs(kap) : -fabs(kap);
        }
        run--;
        ef_prim_t pr;
        memset(&pr, 0, sizeof pr);
        pr.feed = 50.0f;
        pr.tol = 0.01f;
        pr.qtol = 0.001f;
        pr.tag = (uint32_t)i;
        if (what == 3) {
            ef_vec3_t st;
            double r = exp(ef_t_uniform(rs, log(1.0), log(20.0)));
            arc_at(ef_v3((float)x, (float)y, 0.0f), cos(h), sin(h), r,
                   sgn_rand(rs) * ef_t_uniform(rs, 0.3, 3.0), 0, &st, &pr);
            pr.tag = (uint32_t)i;
            pr.qtol = 0.001f;
            h += (double)pr.sweep;
            x = pr.end.x;
            y = pr.end.y;
        } else {
            double c = what == 0 ? ef_t_uniform(rs, 0.1, 0.8) : ef_t_uniform(rs, 1, 10);
            if (what == 0)
                h += c * kap;
            else if (what == 2)
                h += sgn_rand(rs) * ef_t_uniform(rs, 0.5, 2.5);
            x += c * cos(h);
            y += c * sin(h);
            pr.kind = EF_PRIM_LINE;
            pr.end = ef_v3((float)x, (float)y, 0.0f);
        }
        if (i == 0)
            pr.flags = EF_PRIM_STOP_BEFORE;
        for (;;) {
            int dp = dump && bench_interp < 0;
            if (dp)
                CALLGRIND_ZERO_STATS;
            rc = ef_smooth_push(&bench_sm, &pr);
            if (dp)
                CALLGRIND_DUMP_STATS;
            if (bench_interp < 0)
                printf("call push\n");
            pushes++;
            if (rc != EF_ERR_FULL)
                break;
            while (smooth_pull(dump, &moves))
                ;
        }
        if (rc != EF_OK) {
            fprintf(stderr, "bench_ct: ef_smooth_push %ld failed: %s\n", i, ef_err_str(rc));
            return 1;
        }
        while (smooth_pull(dump, &moves))
            ;
    }
    /* finish: one work unit a call (ef_smooth.h), each call one dump ("call finish") */
    for (long guard = 0;; guard++) {
        int dp = dump && bench_interp < 0;
        if (dp)
            CALLGRIND_ZERO_STATS;
        rc = ef_smooth_finish(&bench_sm);
        if (dp)
            CALLGRIND_DUMP_STATS;
        if (bench_interp < 0)
            printf("call finish\n");
        while (smooth_pull(dump, &moves))
            ;
        if (rc != EF_ERR_FULL)
            break;
        if (guard > 10000000L) {
            fprintf(stderr, "bench_ct: ef_smooth_finish made no end\n");
            return 1;
        }
    }
    if (rc != EF_OK) {
        fprintf(stderr, "bench_ct: ef_smooth_finish: %s\n", ef_err_str(rc));
        return 1;
    }
    if (bench_interp >= 0) {
        long guard = 0;
        while ((interp_period() || ef_interp_space(&bench_ip) < EF_INTERP_QUEUE) &&
               ++guard < 100000000L)
            ;
        printf("bench_ct interp: %ld primitives, %ld moves, %ld periods\n", n, moves,
               bench_periods);
        return 0;
    }
    printf("bench_ct smooth: %ld primitives, %ld pushes, %ld moves\n", n, pushes, moves);
    return 0;
}
#endif

/* |d . (t0 x t1)| in double over 1e-5 |d| + 8 ulps of the largest coordinate (what float32
 * rounding leaves of coplanar data): above 1 is clearly 3-D. */
static double g1_coplanarity(const ef_endpoint_t *e0, const ef_endpoint_t *e1)
{
    double d[3] = {(double)e1->p.x - e0->p.x, (double)e1->p.y - e0->p.y, (double)e1->p.z - e0->p.z};
    double a[3] = {e0->t.x, e0->t.y, e0->t.z}, b[3] = {e1->t.x, e1->t.y, e1->t.z};
    double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    double scale = 0;
    const ef_vec3_t *p[2] = {&e0->p, &e1->p};
    for (int k = 0; k < 2; k++)
        scale = fmax(scale, fmax(fabs(p[k]->x), fmax(fabs(p[k]->y), fabs(p[k]->z))));
    return fabs(d[0] * c[0] + d[1] * c[1] + d[2] * c[2]) /
           (1e-5 * sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + 8.0 * 1.1920929e-7 * scale);
}

/* Parse "g1"/"g2"/"blend" and N, build the table, run the calls, report how many of each kind. */
int main(int argc, char **argv)
{
    int path_kind = -1;
#ifdef EF_BENCH_PATH
    static const char *const path_kinds[9] = {"bprim_la", "bprim_aa",   "arcpiece",
                                              "measure",  "smooth",     "interp",
                                              "interp_c", "bprim_la_v", "bprim_aa_v"};
    for (int k = 0; k < 9; k++)
        if (argc > 1 && strcmp(argv[1], path_kinds[k]) == 0)
            path_kind = k;
#endif
    /* g1p / g1_3d: ef_seg_g1_cubic_xy on XY data, ef_seg_g1_cubic on 3-D data. */
    int g1_path =
        argc > 1 ? (strcmp(argv[1], "g1p") == 0) + 2 * (strcmp(argv[1], "g1_3d") == 0) : 0;
    if (argc < 3 || (path_kind < 0 && g1_path == 0 && strcmp(argv[1], "g1") != 0 &&
                     strcmp(argv[1], "g2") != 0 && strcmp(argv[1], "blend") != 0)) {
#ifdef EF_BENCH_PATH
        fprintf(
            stderr,
            "usage: %s "
            "g1|g1p|g1_3d|g2|blend|bprim_la|bprim_aa|bprim_la_v|bprim_aa_v|arcpiece|measure|smooth|"
            "interp|interp_c N "
            "[dump|nodump] [seed]\n",
            argv[0]);
#else
        fprintf(stderr, "usage: %s g1|g1p|g1_3d|g2|blend N [dump|nodump] [seed]\n", argv[0]);
#endif
        return 2;
    }
    int blend = strcmp(argv[1], "blend") == 0;
    int g2 = blend || path_kind >= 0 || strcmp(argv[1], "g2") == 0;
    long n = strtol(argv[2], NULL, 10);
    int dump = argc < 4 || strcmp(argv[3], "nodump") != 0;
    unsigned long long rs = argc > 4 ? strtoull(argv[4], NULL, 0) : 20240607ull;
    if (n < 1) {
        fprintf(stderr, "bench_ct: N must be positive\n");
        return 2;
    }
#ifndef EF_BENCH_DEFAULT_TABLES
    syn_tables();
#endif
    const ef_table_t *tbl = g2 ? EF_BENCH_G2 : EF_BENCH_G1;
    int rc = ef_table_check(tbl);
    if (rc != EF_OK) {
        fprintf(stderr, "bench_ct: table view rejected: %s\n", ef_err_str(rc));
        return 1;
    }
    if (blend)
        return run_blend(tbl, n, dump, &rs);
#ifdef EF_BENCH_PATH
    switch (path_kind) {
    case 0:
        return run_bprim(tbl, n, dump, 0, 0, &rs);
    case 1:
        return run_bprim(tbl, n, dump, 1, 0, &rs);
    case 7:
        return run_bprim(tbl, n, dump, 0, 1, &rs);
    case 8:
        return run_bprim(tbl, n, dump, 1, 1, &rs);
    case 2:
        return run_arcpiece(tbl, n, dump, &rs);
    case 3:
        return run_measure(n, dump, &rs);
    case 4:
        return run_smooth(tbl, n, dump, &rs);
    case 5:
    case 6:
        bench_interp = path_kind == 5 ? EF_STEP_UNIFORM : EF_STEP_CORRECTED;
        if (ef_interp_init(&bench_ip, ef_v3(0.0f, 0.0f, 0.0f), 1000u, bench_interp) != EF_OK)
            return 1;
        return run_smooth(tbl, n, dump, &rs);
    default:
        break;
    }
#endif

    long per_kind[BC_COUNT] = {0}, clamped = 0;
    for (long i = 0; i < n; i++) {
        ef_endpoint_t e0, e1;
        ef_seg_t seg;
        ef_seg_xy_t xy;
        int kind = (int)(i % BC_COUNT);
        bench_xy = g1_path == 1;
        if (g1_path == 1) /* the six coplanar kinds */
            kind = (int)(i % 6) + ((int)(i % 6) >= BC_TWISTED) * 2;
        else if (g1_path == 2)
            kind = BC_TWISTED + (int)(i % 2);
        make_config(&rs, kind, g2, &e0, &e1);
        while (g1_path == 2 && g1_coplanarity(&e0, &e1) < 4.0) /* clearly off the plane */
            make_config(&rs, kind, g2, &e0, &e1);
        /* Only the call sits between zero and dump; with --toggle-collect on the function,
         * nothing of this loop is counted either way. */
        if (dump)
            CALLGRIND_ZERO_STATS;
        if (g2)
            rc = ef_seg_g2_quintic(tbl, &e0, &e1, &seg);
        else if (g1_path == 1)
            rc = ef_seg_g1_cubic_xy(tbl, &e0, &e1, &xy);
        else
            rc = ef_seg_g1_cubic(tbl, &e0, &e1, &seg);
        if (dump)
            CALLGRIND_DUMP_STATS;
        if (g1_path == 1 && rc == EF_OK) {
            ef_seg_t ref;
            int rr = ef_seg_g1_cubic(tbl, &e0, &e1, &ref);
            /* the 3-D path's segment up to rounding (ef_seg.h, test_fw seg_xy) */
            if (rr != EF_OK || !ct_xy_close(tbl, &e0, &e1, &xy, &ref)) {
                fprintf(stderr,
                        "bench_ct: call %ld (kind %d): XY and 3-D segments differ (alpha %.9g "
                        "%.9g, beta %.9g %.9g, dof %.9g %.9g / %.9g %.9g, chord %.9g)\n",
                        i, kind, (double)xy.alpha, (double)ref.norm.alpha, (double)xy.beta,
                        (double)ref.norm.beta, (double)xy.dof[0], (double)ref.dof[0],
                        (double)xy.dof[1], (double)ref.dof[1], (double)ref.norm.chord);
                return 1;
            }
            seg.flags = xy.flags;
        }
        if (rc != EF_OK) {
            fprintf(stderr, "bench_ct: call %ld (kind %d) failed: %s\n", i, kind, ef_err_str(rc));
            return 1;
        }
        per_kind[kind]++;
        clamped += (seg.flags & EF_SEG_CLAMPED) != 0;
    }
    printf("bench_ct %s: %ld calls OK (%ld clamped); per kind:", argv[1], n, clamped);
    for (int k = 0; k < BC_COUNT; k++)
        printf(" %ld", per_kind[k]);
    printf("\n");
    return 0;
}
