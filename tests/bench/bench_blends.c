/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Corner treatments compared on standard paths (docs/benchmarks-smoothing.md).
 *
 * Every inner vertex of a programmed polyline gets, at the same tolerance P:
 *   E  evenfeed's G2 quintic blend, ef_blend_corner() with the default G2 table;
 *   A  a circular arc tangent to both lines sized by LinuxCNC's rule: deviation h - R <= P
 *      from the corner (h = distance corner -> centre), G1 continuity only;
 *   F  a fixed-ratio quintic: b0 = A, b1 = A + a u_in, b2 = A + 2a u_in and mirrored on the
 *      outgoing side, with the corner at 3a from either end (trim L = 3a: control points
 *      equally spaced up to the corner); a is the largest whose measured deviation is <= P;
 *   S  (when the smoother is built in, EF_BENCH_SMOOTH) the whole path through
 *      ef_smooth_push/pull, on the micro-segment paths.
 * Trims are limited to half of either neighbouring line for E, A and F alike.
 *
 * Metrics, all in double precision from this file's own geometry:
 *   dev     largest deviation from the programmed polyline: the corner's distance to the
 *           curve and the curve's (dense samples) distance to the two lines it replaces;
 *   dk      largest curvature jump at any junction between pieces (lines have 0);
 *   fluct   relative speed error |f'(tau)|/L - 1 when tau = s/L, over every parametric
 *           curve (max and RMS, %); arcs are parametrised by angle and are exact (0);
 *   time, a_pk, j_pk, jn_pk  from one evaluator common to all methods: limits per sample
 *           (feed, per-axis speed, centripetal a_n <= frac x a_path, a_path =
 *           min_i a_axis / |T_i|), backward / forward passes with the tangential limit
 *           (1 - frac) x a_path (constant acceleration between samples, no jerk limit),
 *           start and end at rest, exact stops where a vertex is not blended; then the
 *           trajectory is resampled every 1 ms: acceleration vector s'' T + s'^2 kappa N,
 *           jerk by finite differences of it (jn: the part normal to the path, which leaves
 *           out the tangential switching every method shares); ax/a is the largest per-axis
 *           acceleration over its limit, and jn_.1ms the normal jerk resampled every 0.1 ms
 *           (a curvature step shows as a jerk growing like 1/step, continuous curvature
 *           converges).
 *
 * Usage: bench_blends [--quick]
 *   --quick  square and star at P = 0.01 only, and checks (the ctest bench_blends_smoke):
 *            E, A and F within P (E up to float32 rounding), E's and F's curvature jumps ~0
 *            (E below 1 % of A's: float32 control points) and A's not. Exit 1 on failure.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "ef_test.h"
#include "evenfeed/blend/ef_blend.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/table/ef_table.h"
#ifdef EF_BENCH_SMOOTH
#include "evenfeed/motion/ef_smooth.h"
#endif

extern const ef_table_t ef_tbl_g2_default;

/* ---------------------------------------------------------------- 2-D vectors */

typedef struct {
    double x, y;
} v2_t;

static v2_t v2(double x, double y)
{
    v2_t r = {x, y};
    return r;
}
static v2_t v2_add(v2_t a, v2_t b)
{
    return v2(a.x + b.x, a.y + b.y);
}
static v2_t v2_sub(v2_t a, v2_t b)
{
    return v2(a.x - b.x, a.y - b.y);
}
static v2_t v2_scale(v2_t a, double k)
{
    return v2(a.x * k, a.y * k);
}
static double v2_dot(v2_t a, v2_t b)
{
    return a.x * b.x + a.y * b.y;
}
static double v2_cross(v2_t a, v2_t b)
{
    return a.x * b.y - a.y * b.x;
}
static double v2_norm(v2_t a)
{
    return hypot(a.x, a.y);
}
static v2_t v2_unit(v2_t a)
{
    return v2_scale(a, 1.0 / v2_norm(a));
}

/* Distance from q to the segment a-b. */
static double seg_dist(v2_t q, v2_t a, v2_t b)
{
    v2_t d = v2_sub(b, a);
    double l2 = v2_dot(d, d), t = l2 > 0 ? v2_dot(v2_sub(q, a), d) / l2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return v2_norm(v2_sub(q, v2_add(a, v2_scale(d, t))));
}

/* ---------------------------------------------------------------- pieces */

enum { PK_BEZ = 1, PK_ARC = 2 };
#define NTAB 64 /* arc-length table intervals per Bezier */

typedef struct {
    int kind;             /* PK_BEZ (lines are degree 1) or PK_ARC */
    int deg;              /* Bezier degree 1..5 */
    v2_t b[6];            /* Bezier control points */
    v2_t c;               /* arc centre */
    double r, a0, sw;     /* arc radius, start angle, signed sweep */
    double len;           /* arc length */
    double tab[NTAB + 1]; /* Bezier arc length at tau = j / NTAB */
    int curve;            /* a blend / smooth curve (not a straight line) */
    int stop_after;       /* exact stop at its end */
    int tag;              /* smoother moves: the source segment */
} piece_t;

typedef struct {
    piece_t *p;
    int n, cap;
    double *off; /* arc length where each piece starts (eval) */
} path_t;

static piece_t *path_add(path_t *pa)
{
    if (pa->n == pa->cap) {
        pa->cap = pa->cap ? 2 * pa->cap : 256;
        pa->p = realloc(pa->p, (size_t)pa->cap * sizeof *pa->p);
        if (!pa->p) {
            fprintf(stderr, "bench_blends: out of memory\n");
            exit(2);
        }
    }
    piece_t *pc = &pa->p[pa->n++];
    memset(pc, 0, sizeof *pc);
    return pc;
}

static void path_free(path_t *pa)
{
    free(pa->p);
    free(pa->off);
    memset(pa, 0, sizeof *pa);
}

/* de Casteljau on m points. */
static v2_t casteljau(const v2_t *pts, int m, double t)
{
    v2_t q[6];
    memcpy(q, pts, (size_t)m * sizeof *q);
    for (int k = m - 1; k > 0; k--)
        for (int i = 0; i < k; i++)
            q[i] = v2_add(v2_scale(q[i], 1 - t), v2_scale(q[i + 1], t));
    return q[0];
}

/* Position and first two derivatives of a Bezier piece at tau. */
static void bez_eval(const piece_t *pc, double t, v2_t *p, v2_t *d1, v2_t *d2)
{
    int n = pc->deg;
    v2_t h1[5] = {{0, 0}}, h2[4] = {{0, 0}};
    for (int i = 0; i < n; i++)
        h1[i] = v2_scale(v2_sub(pc->b[i + 1], pc->b[i]), n);
    for (int i = 0; i + 1 < n; i++)
        h2[i] = v2_scale(v2_sub(h1[i + 1], h1[i]), n - 1);
    if (p)
        *p = casteljau(pc->b, n + 1, t);
    if (d1)
        *d1 = casteljau(h1, n, t);
    if (d2)
        *d2 = n >= 2 ? casteljau(h2, n - 1, t) : v2(0, 0);
}

static double bez_speed(const piece_t *pc, double t)
{
    v2_t d1;
    bez_eval(pc, t, NULL, &d1, NULL);
    return v2_norm(d1);
}

/* Arc length of a Bezier from t0 to t1 (5-point Gauss-Legendre). */
static double bez_len(const piece_t *pc, double t0, double t1)
{
    static const double x[5] = {0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640,
                                0.9061798459386640};
    static const double w[5] = {0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                                0.2369268850561891, 0.2369268850561891};
    double h = 0.5 * (t1 - t0), m = 0.5 * (t0 + t1), s = 0;
    for (int i = 0; i < 5; i++)
        s += w[i] * bez_speed(pc, m + h * x[i]);
    return s * h;
}

/* Fill length (and the arc-length table of a Bezier). */
static void piece_finish(piece_t *pc)
{
    if (pc->kind == PK_ARC) {
        pc->len = pc->r * fabs(pc->sw);
        return;
    }
    pc->tab[0] = 0;
    for (int j = 0; j < NTAB; j++)
        pc->tab[j + 1] = pc->tab[j] + bez_len(pc, (double)j / NTAB, (double)(j + 1) / NTAB);
    pc->len = pc->tab[NTAB];
}

/* Bezier parameter at arc length s (table, then Newton steps). */
static double bez_tau(const piece_t *pc, double s)
{
    if (s <= 0)
        return 0;
    if (s >= pc->len)
        return 1;
    int lo = 0, hi = NTAB;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (pc->tab[mid] <= s)
            lo = mid;
        else
            hi = mid;
    }
    double t0 = (double)lo / NTAB, t1 = (double)(lo + 1) / NTAB;
    double dl = pc->tab[lo + 1] - pc->tab[lo];
    double t = t0 + (dl > 0 ? (s - pc->tab[lo]) / dl : 0) / NTAB;
    for (int it = 0; it < 3; it++) {
        double sp = bez_speed(pc, t);
        if (sp <= 0)
            break;
        t -= (pc->tab[lo] + bez_len(pc, t0, t) - s) / sp;
        t = t < t0 ? t0 : t > t1 ? t1 : t;
    }
    return t;
}

/* Point at parameter u in [0, 1] (Bezier tau, or arc fraction of the sweep). */
static v2_t piece_point(const piece_t *pc, double u)
{
    if (pc->kind == PK_ARC) {
        double a = pc->a0 + pc->sw * u;
        return v2(pc->c.x + pc->r * cos(a), pc->c.y + pc->r * sin(a));
    }
    v2_t p;
    bez_eval(pc, u, &p, NULL, NULL);
    return p;
}

/* Point, unit tangent and signed curvature at parameter u. */
static void piece_frame_u(const piece_t *pc, double u, v2_t *p, v2_t *t, double *k)
{
    if (pc->kind == PK_ARC) {
        double a = pc->a0 + pc->sw * u, sg = pc->sw > 0 ? 1 : -1;
        *p = v2(pc->c.x + pc->r * cos(a), pc->c.y + pc->r * sin(a));
        *t = v2(-sg * sin(a), sg * cos(a));
        *k = sg / pc->r;
        return;
    }
    v2_t d1, d2;
    bez_eval(pc, u, p, &d1, &d2);
    double sp = v2_norm(d1);
    *t = v2_scale(d1, 1 / sp);
    *k = v2_cross(d1, d2) / (sp * sp * sp);
}

/* Same at arc length s along the piece. */
static void piece_frame_s(const piece_t *pc, double s, v2_t *p, v2_t *t, double *k)
{
    double u = pc->kind == PK_ARC ? (pc->len > 0 ? s / pc->len : 0) : bez_tau(pc, s);
    u = u < 0 ? 0 : u > 1 ? 1 : u;
    piece_frame_u(pc, u, p, t, k);
}

/* A straight piece; none when shorter than 1e-5: that is the float32 rounding gap between two
 * blends that meet (both trims half the line between them), whose direction is noise. */
static void add_line(path_t *pa, v2_t a, v2_t b, int stop)
{
    if (v2_norm(v2_sub(b, a)) <= 1e-5) {
        if (stop && pa->n)
            pa->p[pa->n - 1].stop_after = 1;
        return;
    }
    piece_t *pc = path_add(pa);
    pc->kind = PK_BEZ;
    pc->deg = 1;
    pc->b[0] = a;
    pc->b[1] = b;
    pc->stop_after = stop;
    piece_finish(pc);
}

/* ---------------------------------------------------------------- deviation */

#define DEV_SAMPLES 512

/* Distance from q to the curve: dense samples, then golden-section refinement. */
static double point_curve_dist(const piece_t *pc, v2_t q)
{
    double best = 1e300, ub = 0;
    for (int i = 0; i <= DEV_SAMPLES; i++) {
        double u = (double)i / DEV_SAMPLES, d = v2_norm(v2_sub(piece_point(pc, u), q));
        if (d < best)
            best = d, ub = u;
    }
    double lo = fmax(0, ub - 1.0 / DEV_SAMPLES), hi = fmin(1, ub + 1.0 / DEV_SAMPLES);
    const double g = 0.6180339887498949;
    for (int it = 0; it < 80; it++) {
        double m1 = hi - g * (hi - lo), m2 = lo + g * (hi - lo);
        if (v2_norm(v2_sub(piece_point(pc, m1), q)) < v2_norm(v2_sub(piece_point(pc, m2), q)))
            hi = m2;
        else
            lo = m1;
    }
    double d = v2_norm(v2_sub(piece_point(pc, 0.5 * (lo + hi)), q));
    return d < best ? d : best;
}

/* Deviation of a corner curve from the lines a-v-b it replaces: the corner's distance to the
 * curve, and the curve's largest distance to the two lines. */
static double corner_dev(const piece_t *pc, v2_t a, v2_t v, v2_t b)
{
    double dev = point_curve_dist(pc, v);
    for (int i = 0; i <= DEV_SAMPLES; i++) {
        v2_t q = piece_point(pc, (double)i / DEV_SAMPLES);
        double d = fmin(seg_dist(q, a, v), seg_dist(q, v, b));
        dev = fmax(dev, d);
    }
    return dev;
}

/* ---------------------------------------------------------------- corner treatments */

enum { MT_E, MT_A, MT_F, MT_S, MT_COUNT };
static const char *const method_name[MT_COUNT] = {"E evenfeed G2", "A arc (LinuxCNC)",
                                                  "F fixed-ratio", "S evenfeed smoother"};

typedef struct {
    int blends, straight, stops, clamped;
    double dev; /* largest measured deviation */
} build_stats_t;

/* F: the fixed-ratio quintic with step a about corner v. */
static void f_curve(piece_t *pc, v2_t v, v2_t ui, v2_t uo, double a)
{
    v2_t A = v2_sub(v, v2_scale(ui, 3 * a)), B = v2_add(v, v2_scale(uo, 3 * a));
    pc->kind = PK_BEZ;
    pc->deg = 5;
    pc->b[0] = A;
    pc->b[1] = v2_add(A, v2_scale(ui, a));
    pc->b[2] = v2_add(A, v2_scale(ui, 2 * a));
    pc->b[3] = v2_sub(B, v2_scale(uo, 2 * a));
    pc->b[4] = v2_sub(B, v2_scale(uo, a));
    pc->b[5] = B;
    pc->curve = 1;
    piece_finish(pc);
}

/* F's deviation per unit a for the turn between ui and uo (measured on a = 1 at the origin). */
static double f_unit_dev(v2_t ui, v2_t uo)
{
    piece_t pc;
    memset(&pc, 0, sizeof pc);
    f_curve(&pc, v2(0, 0), ui, uo, 1.0);
    return corner_dev(&pc, v2_scale(ui, -10), v2(0, 0), v2_scale(uo, 10));
}

/* Build the path of one method over the polyline pt[0..n-1]. */
static int build_path(int method, const v2_t *pt, int n, double P, path_t *pa, build_stats_t *st)
{
    memset(st, 0, sizeof *st);
    v2_t cur = pt[0];
    for (int i = 1; i + 1 < n; i++) {
        v2_t v = pt[i], din = v2_sub(v, pt[i - 1]), dout = v2_sub(pt[i + 1], v);
        double lin = v2_norm(din), lout = v2_norm(dout);
        v2_t ui = v2_scale(din, 1 / lin), uo = v2_scale(dout, 1 / lout);
        double turn = atan2(fabs(v2_cross(ui, uo)), v2_dot(ui, uo));
        double mi = 0.5 * lin, mo = 0.5 * lout, tmax = fmin(mi, mo);
        piece_t tmp;
        memset(&tmp, 0, sizeof tmp);
        int kind = 0; /* 0 straight, 1 curve, 2 stop */
        if (method == MT_E) {
            ef_blend_t bl;
            int rc = ef_blend_corner(&ef_tbl_g2_default, ef_v3((float)v.x, (float)v.y, 0.0f),
                                     ef_v3((float)ui.x, (float)ui.y, 0.0f),
                                     ef_v3((float)uo.x, (float)uo.y, 0.0f), (float)P, (float)mi,
                                     (float)mo, &bl);
            if (rc == EF_ERR_REVERSAL || (rc == EF_OK && (bl.flags & EF_BLEND_STOP))) {
                kind = 2;
            } else if (rc != EF_OK) {
                fprintf(stderr, "bench_blends: ef_blend_corner: %s\n", ef_err_str(rc));
                return 1;
            } else if (bl.flags & EF_BLEND_STRAIGHT) {
                kind = 0;
            } else {
                kind = 1;
                tmp.kind = PK_BEZ;
                tmp.deg = 5;
                for (int j = 0; j < 6; j++)
                    tmp.b[j] = v2(bl.seg.b[j].x, bl.seg.b[j].y);
                tmp.curve = 1;
                piece_finish(&tmp);
                st->clamped += (bl.flags & EF_BLEND_CLAMPED) != 0;
            }
        } else if (turn < (double)EF_BLEND_MIN_TURN) {
            kind = 0;
        } else if (turn > (double)EF_BLEND_MAX_TURN) {
            kind = 2;
        } else if (method == MT_A) {
            double phi = 0.5 * turn, c = cos(phi), omc = 2 * sin(0.5 * phi) * sin(0.5 * phi);
            double rp = P * c / omc, rt = tmax / tan(phi), R = fmin(rp, rt);
            double T = R * tan(phi);
            v2_t A = v2_sub(v, v2_scale(ui, T)), bis = v2_unit(v2_sub(uo, ui));
            v2_t cen = v2_add(v, v2_scale(bis, R / c));
            tmp.kind = PK_ARC;
            tmp.c = cen;
            tmp.r = R;
            tmp.a0 = atan2(A.y - cen.y, A.x - cen.x);
            tmp.sw = v2_cross(ui, uo) > 0 ? turn : -turn;
            tmp.curve = 1;
            piece_finish(&tmp);
            kind = 1;
            st->clamped += rt < rp;
        } else { /* MT_F */
            double g = f_unit_dev(ui, uo), a = P / g;
            if (3 * a > tmax) {
                a = tmax / 3;
                st->clamped++;
            }
            f_curve(&tmp, v, ui, uo, a);
            kind = 1;
        }
        if (kind == 0) {
            add_line(pa, cur, v, 0);
            cur = v;
            st->straight++;
        } else if (kind == 2) {
            add_line(pa, cur, v, 1);
            cur = v;
            st->stops++;
        } else {
            v2_t A = piece_point(&tmp, 0), B = piece_point(&tmp, 1);
            add_line(pa, cur, A, 0);
            *path_add(pa) = tmp;
            cur = B;
            st->blends++;
            st->dev = fmax(st->dev, corner_dev(&tmp, pt[i - 1], v, pt[i + 1]));
        }
    }
    add_line(pa, cur, pt[n - 1], 1);
    pa->p[pa->n - 1].stop_after = 1;
    return 0;
}

/* ---------------------------------------------------------------- geometric metrics */

typedef struct {
    double dk;             /* largest curvature jump at a junction */
    double fl_max, fl_rms; /* feed fluctuation (fractions) */
    double kmax;           /* largest |curvature| */
} geo_stats_t;

static void geo_metrics(const path_t *pa, geo_stats_t *g)
{
    memset(g, 0, sizeof *g);
    double s2 = 0;
    long ns = 0;
    for (int i = 0; i < pa->n; i++) {
        const piece_t *pc = &pa->p[i];
        v2_t p, t;
        double k0, k1;
        piece_frame_u(pc, 0, &p, &t, &k0);
        piece_frame_u(pc, 1, &p, &t, &k1);
        g->kmax = fmax(g->kmax, fmax(fabs(k0), fabs(k1)));
        if (i + 1 < pa->n && !pc->stop_after) {
            double kn;
            piece_frame_u(&pa->p[i + 1], 0, &p, &t, &kn);
            g->dk = fmax(g->dk, fabs(kn - k1));
        }
        if (pc->kind == PK_BEZ && pc->deg > 1) {
            for (int j = 0; j < 200; j++) {
                double u = (j + 0.5) / 200, e = bez_speed(pc, u) / pc->len - 1;
                double k;
                piece_frame_u(pc, u, &p, &t, &k);
                g->kmax = fmax(g->kmax, fabs(k));
                g->fl_max = fmax(g->fl_max, fabs(e));
                s2 += e * e;
                ns++;
            }
        } else if (pc->kind == PK_ARC) {
            ns += 200; /* exact: error 0 */
        }
    }
    g->fl_rms = ns ? sqrt(s2 / (double)ns) : 0;
}

/* ---------------------------------------------------------------- common evaluator */

typedef struct {
    double feed;   /* path speed limit (units/s) */
    double v_axis; /* per-axis speed limit */
    double a_axis; /* per-axis acceleration limit */
    double frac;   /* centripetal share of the acceleration budget */
    double h;      /* resampling step (s) */
    double ds_c;   /* sample spacing on curves */
    double ds_l;   /* sample spacing on lines */
} lim_t;

typedef struct {
    double time, a_pk, j_pk, jn_pk, ax_ratio;
    double jn_fine; /* jn_pk with the step h / 10 */
} eval_t;

/* Speed and tangential acceleration limits for tangent t and curvature k. */
static void limits_at(const lim_t *lm, v2_t t, double k, double *vl, double *at)
{
    double tm = fmax(fabs(t.x), fabs(t.y));
    double a_path = lm->a_axis / tm;
    double v = fmin(lm->feed, lm->v_axis / tm);
    if (fabs(k) > 0)
        v = fmin(v, sqrt(lm->frac * a_path / fabs(k)));
    *vl = v;
    *at = (1 - lm->frac) * a_path;
}

/* Resample the planned profile every h seconds: peak acceleration, jerk, normal jerk. */
static void resample(const path_t *pa, const lim_t *lm, double h, long ns, const double *s,
                     const double *v, const double *tt, eval_t *ev)
{
    long ki = 0;
    int pi = 0;
    v2_t a_prev = v2(0, 0);
    for (long step = 0;; step++) {
        double t = step * h;
        if (t > ev->time)
            t = ev->time;
        while (ki < ns - 2 && tt[ki + 1] <= t)
            ki++;
        double ds = s[ki + 1] - s[ki], dt = tt[ki + 1] - tt[ki];
        double acc = ds > 0 ? (v[ki + 1] * v[ki + 1] - v[ki] * v[ki]) / (2 * ds) : 0;
        double u = t - tt[ki];
        if (u > dt)
            u = dt;
        double sd = v[ki] + acc * u, sp = s[ki] + v[ki] * u + 0.5 * acc * u * u;
        while (pi < pa->n - 1 && sp > pa->off[pi + 1])
            pi++;
        v2_t p, tg;
        double kk;
        piece_frame_s(&pa->p[pi], sp - pa->off[pi], &p, &tg, &kk);
        v2_t nrm = v2(-tg.y, tg.x);
        v2_t a = v2_add(v2_scale(tg, acc), v2_scale(nrm, sd * sd * kk));
        ev->a_pk = fmax(ev->a_pk, v2_norm(a));
        ev->ax_ratio = fmax(ev->ax_ratio, fmax(fabs(a.x), fabs(a.y)) / lm->a_axis);
        if (step > 0) {
            v2_t j = v2_scale(v2_sub(a, a_prev), 1 / h);
            if (h == lm->h) {
                ev->j_pk = fmax(ev->j_pk, v2_norm(j));
                ev->jn_pk = fmax(ev->jn_pk, fabs(v2_dot(j, nrm)));
            } else {
                ev->jn_fine = fmax(ev->jn_fine, fabs(v2_dot(j, nrm)));
            }
        }
        a_prev = a;
        if (t >= ev->time)
            break;
    }
}

static int eval_path(path_t *pa, const lim_t *lm, eval_t *ev)
{
    memset(ev, 0, sizeof *ev);
    free(pa->off);
    pa->off = malloc((size_t)(pa->n + 1) * sizeof *pa->off);
    long ns = 1;
    int *cnt = malloc((size_t)pa->n * sizeof *cnt);
    if (!pa->off || !cnt)
        return 1;
    pa->off[0] = 0;
    for (int i = 0; i < pa->n; i++) {
        const piece_t *pc = &pa->p[i];
        double ds = pc->curve ? lm->ds_c : lm->ds_l;
        int m = (int)ceil(pc->len / ds);
        cnt[i] = m < (pc->curve ? 48 : 1) ? (pc->curve ? 48 : 1) : m;
        ns += cnt[i];
        pa->off[i + 1] = pa->off[i] + pc->len;
    }
    double *s = malloc((size_t)ns * sizeof *s), *vl = malloc((size_t)ns * sizeof *vl);
    double *at = malloc((size_t)ns * sizeof *at), *v = malloc((size_t)ns * sizeof *v);
    double *tt = malloc((size_t)ns * sizeof *tt);
    if (!s || !vl || !at || !v || !tt)
        return 1;
    long k = 0;
    {
        v2_t p, t;
        double kk;
        piece_frame_u(&pa->p[0], 0, &p, &t, &kk);
        s[0] = 0;
        limits_at(lm, t, kk, &vl[0], &at[0]);
        vl[0] = 0;
    }
    for (int i = 0; i < pa->n; i++) {
        const piece_t *pc = &pa->p[i];
        for (int j = 1; j <= cnt[i]; j++) {
            double sl = pc->len * j / cnt[i];
            v2_t p, t;
            double kk;
            piece_frame_s(pc, sl, &p, &t, &kk);
            k++;
            s[k] = pa->off[i] + sl;
            limits_at(lm, t, kk, &vl[k], &at[k]);
            if (j == cnt[i] && i + 1 < pa->n) { /* junction: the stricter of both sides */
                double v2l, a2;
                piece_frame_u(&pa->p[i + 1], 0, &p, &t, &kk);
                limits_at(lm, t, kk, &v2l, &a2);
                vl[k] = fmin(vl[k], v2l);
                at[k] = fmin(at[k], a2);
            }
            if (j == cnt[i] && pc->stop_after)
                vl[k] = 0;
        }
    }
    /* Backward then forward pass. */
    v[ns - 1] = 0;
    for (long i = ns - 2; i >= 0; i--) {
        double a = fmin(at[i], at[i + 1]);
        v[i] = fmin(vl[i], sqrt(v[i + 1] * v[i + 1] + 2 * a * (s[i + 1] - s[i])));
    }
    v[0] = 0;
    for (long i = 1; i < ns; i++) {
        double a = fmin(at[i], at[i - 1]);
        v[i] = fmin(v[i], sqrt(v[i - 1] * v[i - 1] + 2 * a * (s[i] - s[i - 1])));
    }
    tt[0] = 0;
    for (long i = 1; i < ns; i++) {
        double ds = s[i] - s[i - 1], vs = v[i] + v[i - 1];
        tt[i] = tt[i - 1] + (ds > 0 && vs > 0 ? 2 * ds / vs : 0);
    }
    ev->time = tt[ns - 1];

    resample(pa, lm, lm->h, ns, s, v, tt, ev);
    resample(pa, lm, lm->h / 10, ns, s, v, tt, ev);
    free(cnt);
    free(s);
    free(vl);
    free(at);
    free(v);
    free(tt);
    return 0;
}

/* ---------------------------------------------------------------- standard paths */

typedef struct {
    const char *name;
    v2_t *pt;
    int n;
    int micro; /* micro-segment path (the smoother column applies) */
} poly_t;

static void poly_push(poly_t *pl, int *cap, v2_t p)
{
    if (pl->n == *cap) {
        *cap = *cap ? 2 * *cap : 256;
        pl->pt = realloc(pl->pt, (size_t)*cap * sizeof *pl->pt);
        if (!pl->pt) {
            fprintf(stderr, "bench_blends: out of memory\n");
            exit(2);
        }
    }
    /* Programmed coordinates are float32 in the firmware: round them once here. */
    pl->pt[pl->n++] = v2((float)p.x, (float)p.y);
}

/* Closed polygon q[0..m-1] as an open path from the middle of the closing edge around to it
 * again, so every vertex is an inner (blended) one. */
static void poly_closed(poly_t *pl, const v2_t *q, int m)
{
    int cap = 0;
    v2_t mid = v2_scale(v2_add(q[m - 1], q[0]), 0.5);
    poly_push(pl, &cap, mid);
    for (int i = 0; i < m; i++)
        poly_push(pl, &cap, q[i]);
    poly_push(pl, &cap, mid);
}

static void make_square(poly_t *pl)
{
    const v2_t q[4] = {{0, 0}, {100, 0}, {100, 100}, {0, 100}};
    pl->name = "square 100";
    poly_closed(pl, q, 4);
}

static void make_star(poly_t *pl)
{
    v2_t q[5];
    for (int k = 0; k < 5; k++) {
        double a = M_PI / 2 + 2 * (2 * M_PI * k / 5);
        q[k] = v2(50 + 50 * cos(a), 50 + 50 * sin(a));
    }
    pl->name = "star {5/2} R50";
    poly_closed(pl, q, 5);
}

static void make_circle(poly_t *pl)
{
    v2_t q[200];
    for (int k = 0; k < 200; k++)
        q[k] = v2(50 + 50 * cos(2 * M_PI * k / 200), 50 + 50 * sin(2 * M_PI * k / 200));
    pl->name = "circle R50/200";
    pl->micro = 1;
    poly_closed(pl, q, 200);
}

/* Archimedean spiral r = 5 + b theta over 5 turns out to r = 50, chords about 0.5. */
static void make_spiral(poly_t *pl)
{
    int cap = 0;
    double b = 45.0 / (10 * M_PI), th = 0;
    pl->name = "spiral 5 turns";
    pl->micro = 1;
    while (th < 10 * M_PI) {
        double r = 5 + b * th;
        poly_push(pl, &cap, v2(50 + r * cos(th), 50 + r * sin(th)));
        th += 0.5 / r;
    }
    double r = 50;
    poly_push(pl, &cap, v2(50 + r * cos(10 * M_PI), 50 + r * sin(10 * M_PI)));
}

/* Random CAM-like path (seeded): curved runs of 0.05-1 chords, straight runs split into
 * collinear pieces, sharp corners; steered back towards the middle of a 100 x 100 field. */
static void make_random(poly_t *pl, int nseg)
{
    int cap = 0;
    unsigned long long rs = 20261122ull;
    v2_t p = v2(50, 50);
    double h = 0;
    pl->name = "random CAM";
    pl->micro = 1;
    poly_push(pl, &cap, p);
    while (pl->n < nseg + 1) {
        int mode = (int)(ef_t_rng(&rs) % 10u);
        v2_t toc = v2_sub(v2(50, 50), p);
        double side = v2_cross(v2(cos(h), sin(h)), toc) >= 0 ? 1 : -1;
        if (mode < 6) {
            int kk = 20 + (int)(ef_t_rng(&rs) % 61u);
            double c0 = ef_t_uniform(&rs, 0.05, 1.0);
            double kap = ef_t_uniform(&rs, 0.02, 0.3) * (v2_norm(toc) > 35 ? side : 1) *
                         ((ef_t_rng(&rs) & 1u) || v2_norm(toc) > 35 ? 1 : -1);
            for (int j = 0; j < kk && pl->n < nseg + 1; j++) {
                double c = c0 * ef_t_uniform(&rs, 0.85, 1.15);
                h += c * kap;
                p = v2_add(p, v2_scale(v2(cos(h), sin(h)), c));
                poly_push(pl, &cap, p);
            }
        } else if (mode < 8) {
            double len = ef_t_uniform(&rs, 5, 20);
            int parts = 2 + (int)(ef_t_rng(&rs) % 4u);
            v2_t d = v2(cos(h), sin(h)), p0 = p;
            for (int j = 1; j <= parts && pl->n < nseg + 1; j++) {
                p = v2_add(p0, v2_scale(d, len * j / parts));
                poly_push(pl, &cap, p);
            }
        } else {
            h += side * ef_t_uniform(&rs, 0.5, 2.0);
            p = v2_add(p, v2_scale(v2(cos(h), sin(h)), ef_t_uniform(&rs, 1, 5)));
            poly_push(pl, &cap, p);
        }
        p = pl->pt[pl->n - 1];
    }
}

/* ---------------------------------------------------------------- smoother column */

#ifdef EF_BENCH_SMOOTH
/* One pulled move as a piece; its deviation from the polyline near its source segment. */
static void take_move(path_t *pa, build_stats_t *st, const ef_move_t *m, const v2_t *pt, int n)
{
    piece_t *pc = path_add(pa);
    pc->kind = PK_BEZ;
    pc->deg = m->degree;
    for (int j = 0; j <= m->degree; j++)
        pc->b[j] = v2(m->b[j].x, m->b[j].y);
    pc->curve = m->degree > 1;
    pc->stop_after = (m->flags & EF_MOVE_STOP_END) != 0;
    pc->tag = (int)m->tag;
    piece_finish(pc);
    int tg = (int)m->tag;
    for (int j = 0; j <= 64; j++) {
        v2_t q = piece_point(pc, j / 64.0);
        double d = 1e300;
        for (int s = tg - 3; s <= tg + 3; s++)
            if (s >= 0 && s + 1 < n)
                d = fmin(d, seg_dist(q, pt[s], pt[s + 1]));
        st->dev = fmax(st->dev, d);
    }
}

/* Run the polyline through the streaming smoother; the moves become pieces. */
static int build_smooth(const v2_t *pt, int n, double P, const lim_t *lm, path_t *pa,
                        build_stats_t *st)
{
    static ef_smooth_t sm;
    ef_smooth_cfg_t cfg;
    memset(&cfg, 0, sizeof cfg);
    memset(st, 0, sizeof *st);
    cfg.g2 = &ef_tbl_g2_default;
    cfg.lim.v_axis[0] = cfg.lim.v_axis[1] = cfg.lim.v_axis[2] = (float)lm->v_axis;
    cfg.lim.a_axis[0] = cfg.lim.a_axis[1] = cfg.lim.a_axis[2] = (float)lm->a_axis;
    cfg.lim.j_max = 0;
    cfg.lim.a_normal_frac = (float)lm->frac;
    cfg.micro_len = 2.0f;
    cfg.micro_turn = 0.35f;
    cfg.smooth_degree = 5;
    int rc = ef_smooth_init(&sm, &cfg, ef_v3((float)pt[0].x, (float)pt[0].y, 0.0f));
    if (rc != EF_OK) {
        fprintf(stderr, "bench_blends: ef_smooth_init: %s\n", ef_err_str(rc));
        return 1;
    }
    ef_move_t m;
    for (int i = 1; i < n; i++) {
        ef_prim_t pr;
        memset(&pr, 0, sizeof pr);
        pr.kind = EF_PRIM_LINE;
        pr.flags = i == 1 ? EF_PRIM_STOP_BEFORE : 0u;
        pr.end = ef_v3((float)pt[i].x, (float)pt[i].y, 0.0f);
        pr.feed = (float)lm->feed;
        pr.tol = (float)P;
        pr.qtol = 0;
        pr.tag = (uint32_t)(i - 1);
        for (;;) {
            uint32_t units = ef_smooth_stats(&sm).units;
            rc = ef_smooth_push(&sm, &pr);
            if (rc != EF_ERR_FULL)
                break;
            int got = 0;
            while (ef_smooth_pull(&sm, &m) == EF_OK) {
                take_move(pa, st, &m, pt, n);
                got = 1;
            }
            if (!got && ef_smooth_stats(&sm).units == units) {
                fprintf(stderr, "bench_blends: smoother full, no work done, nothing to pull\n");
                return 1;
            }
        }
        if (rc != EF_OK) {
            fprintf(stderr, "bench_blends: ef_smooth_push: %s\n", ef_err_str(rc));
            return 1;
        }
        while (ef_smooth_pull(&sm, &m) == EF_OK)
            take_move(pa, st, &m, pt, n);
    }
    /* finish: one work unit a call (ef_smooth.h), pulling between */
    do {
        rc = ef_smooth_finish(&sm);
        while (ef_smooth_pull(&sm, &m) == EF_OK)
            take_move(pa, st, &m, pt, n);
    } while (rc == EF_ERR_FULL);
    if (rc != EF_OK) {
        fprintf(stderr, "bench_blends: ef_smooth_finish: %s\n", ef_err_str(rc));
        return 1;
    }
    if (pa->n == 0)
        return 1;
    pa->p[pa->n - 1].stop_after = 1;
    ef_smooth_stats_t ss = ef_smooth_stats(&sm);
    st->blends = (int)(ss.blends + ss.smooth);
    st->clamped = (int)ss.smooth;
    st->stops = (int)ss.stops;
    st->straight = (int)ss.straight;
    /* The programmed vertices' distances to the curve (they may be cut, as by a blend). */
    int k0 = 0;
    for (int i = 1; i + 1 < n; i++) {
        double d = 1e300;
        while (k0 < pa->n && pa->p[k0].tag < i - 3)
            k0++;
        for (int k = k0; k < pa->n && pa->p[k].tag <= i + 2; k++) {
            const piece_t *pc = &pa->p[k];
            d = fmin(d, pc->deg == 1 ? seg_dist(pt[i], pc->b[0], pc->b[1])
                                     : point_curve_dist(pc, pt[i]));
        }
        st->dev = fmax(st->dev, d);
    }
    return 0;
}
#endif

/* ---------------------------------------------------------------- main */

typedef struct {
    build_stats_t b;
    geo_stats_t g;
    eval_t e;
    int ok;
} result_t;

static int run_method(int method, const poly_t *pl, double P, const lim_t *lm, result_t *r)
{
    path_t pa;
    memset(&pa, 0, sizeof pa);
    memset(r, 0, sizeof *r);
    int rc;
#ifdef EF_BENCH_SMOOTH
    if (method == MT_S)
        rc = build_smooth(pl->pt, pl->n, P, lm, &pa, &r->b);
    else
#endif
        rc = build_path(method, pl->pt, pl->n, P, &pa, &r->b);
    if (rc == 0)
        geo_metrics(&pa, &r->g);
    if (rc == 0)
        rc = eval_path(&pa, lm, &r->e);
    path_free(&pa);
    r->ok = rc == 0;
    return rc;
}

static void print_row(const char *path, double P, int method, const result_t *r)
{
    printf("%-15s %5.3f %-19s %5d %5d %4d %9.6f %8.3g %7.3f %7.3f %8.3f %6.0f %5.2f %8.3g %8.3g "
           "%8.3g\n",
           path, P, method_name[method], r->b.blends, r->b.clamped, r->b.stops, r->b.dev, r->g.dk,
           100 * r->g.fl_max, 100 * r->g.fl_rms, r->e.time, r->e.a_pk, r->e.ax_ratio, r->e.j_pk,
           r->e.jn_pk, r->e.jn_fine);
}

int main(int argc, char **argv)
{
    int quick = argc > 1 && strcmp(argv[1], "--quick") == 0;
    if (argc > 1 && !quick) {
        fprintf(stderr, "usage: %s [--quick]\n", argv[0]);
        return 2;
    }
    int rc = ef_table_check(&ef_tbl_g2_default);
    if (rc != EF_OK) {
        fprintf(stderr, "bench_blends: default G2 table rejected: %s\n", ef_err_str(rc));
        return 2;
    }
    const lim_t lm = {100.0, 200.0, 1000.0, 0.5, 1e-3, 0.005, 0.25};
    poly_t paths[5];
    memset(paths, 0, sizeof paths);
    make_square(&paths[0]);
    make_star(&paths[1]);
    make_circle(&paths[2]);
    make_spiral(&paths[3]);
    make_random(&paths[4], 600);
    int npaths = quick ? 2 : 5;
    const double tols[2] = {0.01, 0.05};
    int ntol = quick ? 1 : 2;

    printf("Limits: feed %.0f units/s, per-axis v %.0f units/s and a %.0f units/s^2, centripetal "
           "share %.2f,\nno jerk limit; resampled every %.0f ms. Trims <= half of either "
           "neighbouring line.\n",
           lm.feed, lm.v_axis, lm.a_axis, lm.frac, lm.h * 1e3);
#ifndef EF_BENCH_SMOOTH
    printf("(evenfeed smoother column not built: EF_BENCH_SMOOTH off)\n");
#endif
    printf("Columns: blend = corners blended (S: blends + smooth vertices), clamp = trims limited "
           "by a\n"
           "neighbour (S: smooth vertices), stop = exact stops inside the path (S: the smoother's "
           "count,\n"
           "program end included).\n");
    printf("%-15s %5s %-19s %5s %5s %4s %9s %8s %7s %7s %8s %6s %5s %8s %8s %8s\n", "path", "P",
           "method", "blend", "clamp", "stop", "dev_max", "dkappa", "fl_max%", "fl_rms%", "time_s",
           "a_pk", "ax/a", "j_pk", "jn_pk", "jn_.1ms");
    int fail = 0;
    for (int pi = 0; pi < npaths; pi++) {
        const poly_t *pl = &paths[pi];
        for (int ti = 0; ti < ntol; ti++) {
            double P = tols[ti];
            result_t res[MT_COUNT];
            memset(res, 0, sizeof res);
            for (int m = 0; m < MT_COUNT; m++) {
#ifndef EF_BENCH_SMOOTH
                if (m == MT_S)
                    continue;
#endif
                if (m == MT_S && !pl->micro)
                    continue;
                if (run_method(m, pl, P, &lm, &res[m]) != 0) {
                    fail = 1;
                    continue;
                }
                print_row(pl->name, P, m, &res[m]);
            }
            if (quick) {
                /* E is built in float32: its deviation may pass P by float rounding (at a
                 * corner at the origin ef_blend_corner's margin q is 0). */
                for (int m = MT_E; m <= MT_F; m++)
                    if (!res[m].ok || res[m].b.blends == 0 ||
                        res[m].b.dev > P * (1 + (m == MT_E ? 1e-6 : 1e-9))) {
                        fprintf(stderr, "FAIL: %s %s: deviation %.9g above P = %g\n", pl->name,
                                method_name[m], res[m].b.dev, P);
                        fail = 1;
                    }
                /* E and F are G2, A jumps by 1/R at each arc end. E's control points are
                 * float32, whose rounding shows as a small end curvature on blends far from
                 * the origin (about 1 /unit on the star's 0.01-unit blends at 100 units). */
                if (!(res[MT_E].g.dk < 1e-2 * res[MT_A].g.dk && res[MT_F].g.dk < 1e-6 &&
                      res[MT_A].g.dk > 1.0)) {
                    fprintf(stderr, "FAIL: %s: curvature jumps E %g F %g A %g\n", pl->name,
                            res[MT_E].g.dk, res[MT_F].g.dk, res[MT_A].g.dk);
                    fail = 1;
                }
            }
        }
    }
    for (int pi = 0; pi < 5; pi++)
        free(paths[pi].pt);
    if (quick)
        printf("bench_blends smoke: %s\n", fail ? "FAILED" : "OK");
    return fail;
}
