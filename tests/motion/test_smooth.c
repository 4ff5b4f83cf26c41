/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The streaming smoother (ef_smooth): primitives pushed, planned moves pulled, with the
 * default tables. Every run is checked for the invariants a drive relies on (a continuous
 * chain of moves, speeds within limits and continuous, stops where they must be, no NaN),
 * and the deviation of every move from the programmed path is measured independently in
 * double precision by dense sampling. Then the vertex rules one by one (blends, reversal
 * stops, collinear collapse, smooth sections through micro-segments, arcs) and every
 * bad-input case of the issue.
 */
#include <float.h>
#include <string.h>
#include "ef_test.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/motion/ef_smooth.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

#define MAXM 200000

static ef_smooth_t S; /* large: static, as a firmware would keep it */
static ef_move_t *M;  /* moves of the last run */
static int NM;

/* ---- programmed path, for the independent deviation measure ---- */
typedef struct {
    ef_prim_t pr;
    double a[3]; /* start */
} prog_t;
static prog_t P[20000];
static int NP;

static double d3norm(const double *v)
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

/* Distance from x to a line segment a-b. */
static double dist_line(const double *x, const double *a, const double *b)
{
    double ab[3], ax[3], l2 = 0, t = 0;
    for (int i = 0; i < 3; i++) {
        ab[i] = b[i] - a[i];
        ax[i] = x[i] - a[i];
        l2 += ab[i] * ab[i];
        t += ax[i] * ab[i];
    }
    t = l2 > 0 ? t / l2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double d[3];
    for (int i = 0; i < 3; i++)
        d[i] = ax[i] - t * ab[i];
    return d3norm(d);
}

/* Distance from x to a planar arc (no helix in these tests), exactly: the foot point on
 * the circle when its angle lies within the swept range, else the nearer end. */
static double dist_arc(const double *x, const prog_t *g)
{
    const ef_prim_t *p = &g->pr;
    double c[3] = {p->centre.x, p->centre.y, p->centre.z},
           ax[3] = {p->axis.x, p->axis.y, p->axis.z};
    double r0[3] = {g->a[0] - c[0], g->a[1] - c[1], g->a[2] - c[2]};
    double r = d3norm(r0);
    double e1[3] = {r0[0] / r, r0[1] / r, r0[2] / r};
    double e2[3] = {ax[1] * e1[2] - ax[2] * e1[1], ax[2] * e1[0] - ax[0] * e1[2],
                    ax[0] * e1[1] - ax[1] * e1[0]};
    double q[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]};
    double u = q[0] * e1[0] + q[1] * e1[1] + q[2] * e1[2];
    double v = q[0] * e2[0] + q[1] * e2[1] + q[2] * e2[2];
    double h = q[0] * ax[0] + q[1] * ax[1] + q[2] * ax[2];
    double rho = sqrt(u * u + v * v), ang = atan2(v, u);
    double sw = p->sweep;
    /* the angle measured in the sweep's direction, in [0, 2 pi) */
    double a = sw >= 0 ? ang : -ang;
    if (a < 0)
        a += 2 * M_PI;
    if (fabs(sw) >= 2 * M_PI || a <= fabs(sw))
        return sqrt((rho - r) * (rho - r) + h * h);
    double b[3] = {p->end.x, p->end.y, p->end.z};
    double d0 = sqrt((x[0] - g->a[0]) * (x[0] - g->a[0]) + (x[1] - g->a[1]) * (x[1] - g->a[1]) +
                     (x[2] - g->a[2]) * (x[2] - g->a[2]));
    double d1 = sqrt((x[0] - b[0]) * (x[0] - b[0]) + (x[1] - b[1]) * (x[1] - b[1]) +
                     (x[2] - b[2]) * (x[2] - b[2]));
    return d0 < d1 ? d0 : d1;
}

/* Distance to the programmed path near primitive k (moves carry their primitive's index
 * as tag; a blend carries the outgoing one's): its neighbours are enough, and far cheaper
 * than the whole program on long runs. */
static double dist_prog(const double *x, int k)
{
    double best = 1e300;
    /* Merged lines: up to EF_SMOOTH_MERGE_MAX + 1 after the tag; a blend (tagged with the
     * outgoing line) trims up to half the incoming merged line, before the tag. */
    int w = EF_SMOOTH_MERGE_MAX + 4;
    int lo = k - w < 0 ? 0 : k - w, hi = k + w > NP ? NP : k + w;
    for (int i = lo; i < hi; i++) {
        double b[3] = {P[i].pr.end.x, P[i].pr.end.y, P[i].pr.end.z};
        double d = P[i].pr.kind == EF_PRIM_LINE ? dist_line(x, P[i].a, b) : dist_arc(x, &P[i]);
        if (d < best)
            best = d;
    }
    return best;
}

/* ---- running the smoother ---- */
static ef_smooth_cfg_t cfg_default(void)
{
    ef_smooth_cfg_t c;
    memset(&c, 0, sizeof c);
    c.g2 = &ef_tbl_g2_default;
    c.g1 = &ef_tbl_g1_default;
    for (int i = 0; i < 3; i++) {
        c.lim.v_axis[i] = 200.0f;
        c.lim.a_axis[i] = 2000.0f;
    }
    c.lim.a_normal_frac = 0.5f;
    c.micro_len = 1.0f;
    c.micro_turn = 0.35f;
    c.keep_slow_blends = 1; /* the parts test blends (test_slow_corners: the rule) */
    c.smooth_degree = 5;
    return c;
}

/* Pull everything available into M. */
static int drain(void)
{
    int rc;
    while ((rc = ef_smooth_pull(&S, &M[NM])) == EF_OK)
        if (NM < MAXM - 1)
            NM++;
    return rc;
}

/* Finish (one work unit a call, ef_smooth.h), draining in between; every EF_ERR_FULL has
 * made progress: a unit, or a move to pull. */
static int finish_all(void)
{
    int rc = EF_ERR_FULL;
    for (int guard = 0; rc == EF_ERR_FULL && guard < 1000000; guard++) {
        uint32_t units = ef_smooth_stats(&S).units;
        int nm = NM;
        rc = ef_smooth_finish(&S);
        EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
        if (rc == EF_ERR_FULL && ef_smooth_stats(&S).units == units && NM == nm) {
            EF_CHECK(!"finish: no progress");
            return EF_ERR_STATE;
        }
    }
    return rc;
}

/* Push a whole program (FULL handled by draining) and finish. Returns the first refusal. */
static int run_prims(const ef_smooth_cfg_t *c, ef_vec3_t start, const ef_prim_t *pr, int n)
{
    NM = 0;
    NP = 0;
    EF_CHECK_EQ(ef_smooth_init(&S, c, start), EF_OK);
    double a[3] = {start.x, start.y, start.z};
    int first_err = 0;
    for (int i = 0; i < n; i++) {
        ef_prim_t q = pr[i];
        q.tag = (uint32_t)NP; /* index among the accepted ones, for dist_prog() */
        int rc = ef_smooth_push(&S, &q);
        for (int guard = 0; rc == EF_ERR_FULL && guard < 100000; guard++) {
            EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
            rc = ef_smooth_push(&S, &q);
        }
        if (rc != EF_OK) {
            if (!first_err)
                first_err = rc;
            continue;
        }
        P[NP].pr = pr[i];
        memcpy(P[NP].a, a, sizeof a);
        a[0] = pr[i].end.x;
        a[1] = pr[i].end.y;
        a[2] = pr[i].end.z;
        NP++;
    }
    EF_CHECK_EQ(finish_all(), EF_OK);
    EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
    return first_err;
}

static ef_prim_t line_to(float x, float y, float z, float feed, float tol)
{
    ef_prim_t p;
    memset(&p, 0, sizeof p);
    p.kind = EF_PRIM_LINE;
    p.end = ef_v3(x, y, z);
    p.feed = feed;
    p.tol = tol;
    return p;
}

/* XY arc about +Z from `from` around centre c by sweep. */
static ef_prim_t arc_to(ef_vec3_t from, float cx, float cy, float sweep, float feed, float tol)
{
    ef_prim_t p;
    memset(&p, 0, sizeof p);
    p.kind = EF_PRIM_ARC;
    p.centre = ef_v3(cx, cy, from.z);
    p.axis = ef_v3(0, 0, 1);
    p.sweep = sweep;
    double rx = from.x - cx, ry = from.y - cy;
    double c = cos(sweep), s = sin(sweep);
    p.end = ef_v3((float)(cx + c * rx - s * ry), (float)(cy + s * rx + c * ry), from.z);
    p.feed = feed;
    p.tol = tol;
    return p;
}

typedef struct {
    double dev_over; /* max over moves of measured deviation / tolerance */
    int kinds[5];
    int stops;
} runinfo_t;

/* Invariants of every run; returns measured figures. `tol` is the tolerance in force. */
static runinfo_t check_run(ef_vec3_t start, ef_vec3_t end, double tol, const ef_limits_t *lim)
{
    runinfo_t ri;
    memset(&ri, 0, sizeof ri);
    EF_CHECK(NM > 0);
    if (NM == 0)
        return ri;
    int ok_chain = 1, ok_speed = 1, ok_num = 1, ok_stop = 1, ok_seq = 1;
    ef_vec3_t prev = start;
    float vprev = 0;
    for (int i = 0; i < NM; i++) {
        const ef_move_t *m = &M[i];
        if (m->degree != 1 && m->degree != 3 && m->degree != 5)
            ok_num = 0;
        for (int k = 0; k <= m->degree; k++)
            if (!isfinite(m->b[k].x) || !isfinite(m->b[k].y) || !isfinite(m->b[k].z))
                ok_num = 0;
        if (!isfinite(m->duration) || !(m->duration > 0) || !isfinite(m->v_entry))
            ok_num = 0;
        ef_vec3_t d = ef_v3_sub(m->b[0], prev);
        if (ef_v3_norm(d) > 1e-6f)
            ok_chain = 0;
        if (fabsf(m->v_entry - vprev) > 1e-3f * (1 + vprev))
            ok_speed = 0;
        if (m->v_entry > m->v_max * 1.0001f + 1e-4f || m->v_exit > m->v_max * 1.0001f + 1e-4f)
            ok_speed = 0;
        if ((m->flags & EF_MOVE_STOP_END) && m->v_exit != 0.0f)
            ok_stop = 0;
        if (i > 0 && m->seq != M[i - 1].seq + 1)
            ok_seq = 0;
        if (m->kind >= 1 && m->kind <= 4)
            ri.kinds[m->kind]++;
        ri.stops += (m->flags & EF_MOVE_STOP_END) != 0;
        /* centripetal limit respected by the speed limit */
        if (lim && m->v_max * m->v_max * m->kappa_max > lim->a_axis[0] * 1.001f + 1e-3f)
            ok_speed = 0;
        /* deviation from the programmed path, dense */
        int ns = m->degree == 1 ? 2 : 200;
        for (int k = 0; k <= ns; k++) {
            ef_vec3_t q;
            ef_bezier_eval(m->b, m->degree, (float)k / ns, 0, &q);
            double x[3] = {q.x, q.y, q.z};
            double dv = dist_prog(x, (int)m->tag) / tol;
            if (dv > ri.dev_over)
                ri.dev_over = dv;
            if (dv > 1.0)
                fprintf(stderr,
                        "  over: move %d kind %d deg %d flags %u tag %u dev %.4g/P "
                        "(own estimate %.4g/P) len %.4g\n",
                        i, m->kind, m->degree, (unsigned)m->flags, (unsigned)m->tag, dv,
                        m->dev / tol, m->length),
                    fprintf(stderr, "    prim kind %d, sweep %g, tol %g\n", P[m->tag].pr.kind,
                            P[m->tag].pr.sweep, tol);
        }
        prev = m->b[m->degree];
        vprev = m->v_exit;
    }
    EF_CHECK(ok_num);
    EF_CHECK(ok_chain);
    EF_CHECK(ok_speed);
    EF_CHECK(ok_stop);
    EF_CHECK(ok_seq);
    EF_CHECK(M[NM - 1].flags & EF_MOVE_STOP_END);
    EF_CHECK_EQ(M[NM - 1].v_exit, 0);
    EF_CHECK_EQ(M[0].v_entry, 0);
    EF_CHECK(ef_v3_norm(ef_v3_sub(prev, end)) <= 1e-6f);
    return ri;
}

/* A square with 3 corners inside: blends within P, stops only at the ends. */
static void test_square(void)
{
    ef_smooth_cfg_t c = cfg_default();
    ef_prim_t pr[4] = {line_to(50, 0, 0, 50, 0.01f), line_to(50, 50, 0, 50, 0.01f),
                       line_to(0, 50, 0, 50, 0.01f), line_to(0, 0, 0, 50, 0.01f)};
    EF_CHECK_EQ(run_prims(&c, ef_v3(0, 0, 0), pr, 4), 0);
    runinfo_t ri = check_run(ef_v3(0, 0, 0), ef_v3(0, 0, 0), 0.01, &c.lim);
    ef_smooth_stats_t st = ef_smooth_stats(&S);
    EF_CHECK_EQ(st.blends, 3);
    EF_CHECK_EQ(ri.kinds[EF_MOVE_BLEND], 3);
    EF_CHECK_EQ(ri.kinds[EF_MOVE_LINE], 4);
    EF_CHECK_EQ(ri.stops, 1);
    EF_CHECK(ri.dev_over <= 1.0);
    /* The blends use the tolerance: P from the corner is P sin(45 deg) from the lines. */
    EF_CHECK(ri.dev_over > 0.70);
    printf("square: %d moves, max deviation / P = %.4f\n", NM, ri.dev_over);
}

/* An exact 180-degree reversal and a 179.5-degree near reversal: both stop at the vertex,
 * no NaN, no jump. */
static void test_reversal(void)
{
    ef_smooth_cfg_t c = cfg_default();
    ef_prim_t pr[2] = {line_to(10, 0, 0, 50, 0.01f), line_to(0, 0, 0, 50, 0.01f)};
    run_prims(&c, ef_v3(0, 0, 0), pr, 2);
    runinfo_t ri = check_run(ef_v3(0, 0, 0), ef_v3(0, 0, 0), 0.01, &c.lim);
    EF_CHECK_EQ(ef_smooth_stats(&S).reversals, 1);
    EF_CHECK_EQ(NM, 2);
    EF_CHECK(M[0].flags & EF_MOVE_STOP_END);
    EF_CHECK_EQ(M[0].v_exit, 0);
    EF_CHECK_EQ(ri.stops, 2);
    float a = (float)(179.5 * M_PI / 180);
    ef_prim_t q[2] = {line_to(10, 0, 0, 50, 0.01f),
                      line_to(10 + 5 * cosf(a), 5 * sinf(a), 0, 50, 0.01f)};
    run_prims(&c, ef_v3(0, 0, 0), q, 2);
    check_run(ef_v3(0, 0, 0), q[1].end, 0.01, &c.lim);
    EF_CHECK_EQ(ef_smooth_stats(&S).reversals, 1);
}

/* G64 Q: collinear splits within Q collapse into one line; beyond Q they do not. */
static void test_collinear(void)
{
    ef_smooth_cfg_t c = cfg_default();
    c.micro_len = 0;
    ef_prim_t pr[10];
    for (int i = 0; i < 10; i++) {
        pr[i] = line_to(10.0f * (i + 1), (i % 2) ? 0.002f : 0.0f, 0, 50, 0.01f);
        pr[i].qtol = 0.005f;
    }
    run_prims(&c, ef_v3(0, 0, 0), pr, 10);
    runinfo_t ri = check_run(ef_v3(0, 0, 0), pr[9].end, 0.01, &c.lim);
    EF_CHECK_EQ(ef_smooth_stats(&S).merged, 9);
    EF_CHECK_EQ(NM, 1);
    EF_CHECK_EQ(ri.kinds[EF_MOVE_LINE], 1);
    for (int i = 0; i < 10; i++)
        pr[i].qtol = 0.0005f;
    run_prims(&c, ef_v3(0, 0, 0), pr, 10);
    check_run(ef_v3(0, 0, 0), pr[9].end, 0.01, &c.lim);
    EF_CHECK_EQ(ef_smooth_stats(&S).merged, 0);
    EF_CHECK_EQ(ef_smooth_stats(&S).blends, 9);
    /* a reversal is never merged, whatever Q says */
    ef_prim_t r[2] = {line_to(10, 0, 0, 50, 0.01f), line_to(5, 0, 0, 50, 0.01f)};
    r[1].qtol = 1.0f;
    run_prims(&c, ef_v3(0, 0, 0), r, 2);
    EF_CHECK_EQ(ef_smooth_stats(&S).merged, 0);
    EF_CHECK_EQ(ef_smooth_stats(&S).reversals, 1);
}

/* Curvature vector of move m at parameter t. */
static ef_vec3_t curv(const ef_move_t *m, float t)
{
    ef_vec3_t d[3];
    ef_bezier_eval(m->b, m->degree, t, m->degree >= 2 ? 2 : 1, d);
    if (m->degree < 2)
        return ef_v3(0, 0, 0);
    float s2 = ef_v3_dot(d[1], d[1]);
    ef_vec3_t a = ef_v3_axpy(d[2], -ef_v3_dot(d[1], d[2]) / s2, d[1]);
    return ef_v3_scale(a, 1.0f / s2);
}

/* A circle from 200 micro-segments: smooth vertices, G2 moves, deviation within P. */
static void test_micro_circle(int degree)
{
    ef_smooth_cfg_t c = cfg_default();
    c.smooth_degree = (uint8_t)degree;
    enum { N = 200 };
    static ef_prim_t pr[N];
    double r = 10;
    for (int i = 0; i < N; i++) {
        double a = 2 * M_PI * (i + 1) / N;
        pr[i] = line_to((float)(r * cos(a)), (float)(r * sin(a)), 0, 50, 0.01f);
    }
    run_prims(&c, ef_v3(10, 0, 0), pr, N);
    runinfo_t ri = check_run(ef_v3(10, 0, 0), pr[N - 1].end, 0.01, &c.lim);
    ef_smooth_stats_t st = ef_smooth_stats(&S);
    EF_CHECK_EQ(st.smooth, N - 1);
    EF_CHECK_EQ(ri.kinds[EF_MOVE_SMOOTH], N);
    EF_CHECK(ri.dev_over <= 1.0);
    /* G2 (quintic) or G1 (cubic) at every inner junction: curvature vectors agree. */
    double jump = 0;
    for (int i = 0; i + 1 < NM; i++) {
        ef_vec3_t k0 = curv(&M[i], 1), k1 = curv(&M[i + 1], 0);
        double j = ef_v3_norm(ef_v3_sub(k0, k1)) * r;
        if (j > jump)
            jump = j;
    }
    if (degree == 5)
        EF_CHECK(jump < 1e-2);
    /* The planned speed stays at the feed through the whole circle (no stops, no corner
     * slow-downs): the middle move cruises at the commanded feed. */
    EF_CHECK_NEAR(M[NM / 2].v_entry, 50, 1e-2);
    printf("micro-circle (%s): %d moves, max dev / P %.4f, max curvature jump x r %.2e\n",
           degree == 5 ? "G2 quintic" : "G1 cubic", NM, ri.dev_over, jump);
}

/* Planned time of the last run (the moves' durations). */
static double run_time(void)
{
    double t = 0;
    for (int i = 0; i < NM; i++)
        t += M[i].duration;
    return t;
}

static double pts_to_moves(ef_vec3_t start);

/* Distance of (x, y) from the segment a-b, in the plane. */
static double dist2_seg(double x, double y, const double *a, const double *b)
{
    double p[3] = {x, y, 0}, a3[3] = {a[0], a[1], 0}, b3[3] = {b[0], b[1], 0};
    return dist_line(p, a3, b3);
}

/* Lines through points pt[0..npt] merged as LinuxCNC's interpreter merges a CAM program's
 * (G64 Q): each line extended while every point it drops stays within q of it. Writes at
 * most nmax lines from pt[0] into pr; returns their count. */
static int lcnc_merge(double (*pt)[2], int npt, double q, float feed, ef_prim_t *pr, int nmax)
{
    int n = 0;
    for (int i = 0; i < npt && n < nmax;) {
        int j = i + 1;
        for (; j < npt; j++) { /* can the line i -> j + 1 drop i + 1 .. j? */
            int ok = 1;
            for (int k = i + 1; k <= j && ok; k++)
                ok = dist2_seg(pt[k][0], pt[k][1], pt[i], pt[j + 1]) <= q;
            if (!ok)
                break;
        }
        pr[n++] = line_to((float)pt[j][0], (float)pt[j][1], 0, feed, (float)q);
        i = j;
    }
    return n;
}

/* Chords merged upstream (cfg.chord_shift, the LinuxCNC module): a CAM circle of radius 10
 * from 0.016 mm chords, coordinates rounded to 0.001 mm (the corpus's circle_q001mm),
 * merged as LinuxCNC's interpreter does before its planner sees it: each merged line is
 * extended while every point it drops stays within Q = P of it. The merged chords' middles
 * lie up to P inside the circle. Through the vertices, the sections would leave the chords'
 * middles by that whole bulge: vertices fail as smooth, become corners, and the sections
 * next to their blends are jerk-bound (J 20 000). Shifted, every inner vertex is smooth,
 * the path stays within P of the chords and closer than that to the program's own points
 * (independent measures), the vertices within EF_SMOOTH_CHORD_SHIFT P of the path, the
 * feed is held and the circle is done sooner. */
static void test_chord_shift(void)
{
    enum { NPT = 3927, NMAX = 200 };
    static double pt[NPT + 1][2];
    static ef_prim_t pr[NMAX];
    const double r = 10, tol = 0.02;
    for (int k = 0; k <= NPT; k++) {
        double a = 2 * M_PI * k / NPT;
        pt[k][0] = round(r * cos(a) * 1e3) / 1e3;
        pt[k][1] = round(r * sin(a) * 1e3) / 1e3;
    }
    int n = lcnc_merge(pt, NPT, tol, 50, pr, NMAX);
    EF_CHECK(n > 40 && n < NMAX);
    double t[2] = {0, 0}, on[2] = {0, 0};
    uint32_t smooth[2] = {0, 0};
    for (int shift = 0; shift <= 1; shift++) {
        ef_smooth_cfg_t c = cfg_default();
        c.keep_slow_blends = 0;
        c.micro_len = 2.0f;
        c.lim.j_max = 20000.0f;
        c.chord_shift = (uint8_t)shift;
        EF_CHECK_EQ(run_prims(&c, ef_v3(10, 0, 0), pr, n), 0);
        runinfo_t ri = check_run(ef_v3(10, 0, 0), pr[n - 1].end, tol, &c.lim);
        EF_CHECK(ri.dev_over <= 1.0); /* from the merged chords */
        smooth[shift] = ef_smooth_stats(&S).smooth;
        t[shift] = run_time();
        on[shift] = pts_to_moves(ef_v3(10, 0, 0));
        if (!shift)
            continue;
        EF_CHECK_EQ(smooth[1], (uint32_t)n - 1);
        double prog = 0; /* the program's own points from the path: within the shift */
        int at = 0;
        for (int k = 0; k <= NPT; k++) {
            double best = 1e300;
            for (int i = at; i < NM && i < at + 3; i++)
                for (int q = 0; q < 64; q++) {
                    ef_vec3_t u, v;
                    ef_bezier_eval(M[i].b, M[i].degree, (float)q / 64.0f, 0, &u);
                    ef_bezier_eval(M[i].b, M[i].degree, (float)(q + 1) / 64.0f, 0, &v);
                    double a[2] = {u.x, u.y}, b[2] = {v.x, v.y};
                    double d = dist2_seg(pt[k][0], pt[k][1], a, b);
                    if (d < best) {
                        best = d;
                        at = i;
                    }
                }
            prog = fmax(prog, best);
        }
        EF_CHECK(prog <= EF_SMOOTH_CHORD_SHIFT * tol + 1e-3);
        EF_CHECK(on[1] <= EF_SMOOTH_CHORD_SHIFT * tol + 1e-4);
        EF_CHECK_NEAR(M[NM / 2].v_entry, 50, 1e-2);
        printf("chord shift: %d merged chords, %u of %d vertices smooth (%u through the "
               "vertices), %.3f s (%.3f s), path within %.3f P of the chords and %.3f P of "
               "the program's points, vertices within %.3f P of it\n",
               n, smooth[1], n - 1, smooth[0], t[1], t[0], ri.dev_over, prog / tol, on[1] / tol);
    }
    EF_CHECK(t[1] < t[0]);
}

/* Smooth-vertex frames where the curvature changes along the run (rule 3, the five-point
 * fit): a sine of amplitude 6.35 and wavelength 25.4 from 0.0254 mm CAM chords rounded to
 * 0.00254, merged as LinuxCNC merges it within Q = P = 0.0254 (chords of 0.7 to 2.6 mm, no
 * dropped points left). The circle through three vertices errs in its tangent by about
 * 0.015 rad there, and the sections then swung their curvature by 40 % about the sine's.
 * Fitted through five vertices, the curvature of every section between two smooth vertices
 * stays within 10 % of the sine's largest of the sine's own at the same x, the sections are
 * within P of the chords and the crests run at 0.85 of the centripetal speed limit. */
static void test_sine_frames(void)
{
    enum { NPT = 2400, NMAX = 300 };
    static double pt[NPT + 1][2];
    static ef_prim_t pr[NMAX];
    const double amp = 6.35, lam = 25.4, tol = 0.0254, w = 2 * M_PI / lam;
    double x = 0;
    for (int k = 0; k <= NPT; k++) {
        if (k > 0) /* 0.0254 mm along the curve */
            x += 0.0254 / hypot(1.0, amp * w * cos(w * x));
        pt[k][0] = round(x / 0.00254) * 0.00254;
        pt[k][1] = round(amp * sin(w * x) / 0.00254) * 0.00254;
    }
    int n = lcnc_merge(pt, NPT, tol, 60, pr, NMAX);
    ef_smooth_cfg_t c = cfg_default();
    c.keep_slow_blends = 0;
    c.micro_len = 10.0f;
    c.lim.j_max = 20000.0f;
    c.chord_shift = 1;
    EF_CHECK_EQ(run_prims(&c, ef_v3(0, 0, 0), pr, n), 0);
    runinfo_t ri = check_run(ef_v3(0, 0, 0), pr[n - 1].end, tol, &c.lim);
    EF_CHECK(ri.dev_over <= 1.0);
    double kmax = amp * w * w, err = 0, vcrest = 0;
    int nsec = 0, ninner = 0;
    for (int i = 0; i < NM; i++) {
        if (M[i].kind != EF_MOVE_SMOOTH)
            continue;
        nsec++;
        /* between two smooth vertices (next to a blend or a straight vertex the section
         * turns into the line's zero curvature) */
        if (i == 0 || i + 1 == NM || M[i - 1].kind != EF_MOVE_SMOOTH ||
            M[i + 1].kind != EF_MOVE_SMOOTH)
            continue;
        ninner++;
        for (int k = 0; k <= 32; k++) {
            ef_vec3_t q, kv = curv(&M[i], (float)k / 32.0f), d[2];
            ef_bezier_eval(M[i].b, M[i].degree, (float)k / 32.0f, 1, d);
            q = d[0];
            double y1 = amp * w * cos(w * q.x), y2 = -amp * w * w * sin(w * q.x);
            double ktrue = y2 / pow(1 + y1 * y1, 1.5);
            double ksec = (d[1].x * kv.y - d[1].y * kv.x) >= 0 ? ef_v3_norm(kv) : -ef_v3_norm(kv);
            err = fmax(err, fabs(ksec - ktrue));
        }
        if (fabs(sin(w * M[i].b[0].x)) > 0.99) /* at a crest */
            vcrest = fmax(vcrest, M[i].v_max);
    }
    double vlim = sqrt(c.lim.a_normal_frac * c.lim.a_axis[0] / kmax);
    EF_CHECK(nsec >= n - 6 && ninner >= n / 2);
    EF_CHECK(err <= 0.1 * kmax);
    EF_CHECK(vcrest >= 0.85 * vlim);
    printf("sine frames: %d merged chords, %d smooth sections, %d between smooth vertices: "
           "their curvature within %.3f of the sine's largest of its own, crest speed %.1f "
           "(centripetal limit %.1f)\n",
           n, nsec, ninner, err / kmax, vcrest, vlim);
}

/* Largest distance of an input point (every accepted primitive's end, and the start) from
 * the moves of the last run, sampled 64 times each; points and moves both run along the
 * path, so the search is a window of moves around the last nearest one. */
static double pts_to_moves(ef_vec3_t start)
{
    double worst = 0;
    int at = 0;
    for (int i = -1; i < NP; i++) {
        ef_vec3_t p = i < 0 ? start : P[i].pr.end;
        double x[3] = {p.x, p.y, p.z}, best = 1e300;
        int lo = at - 4 < 0 ? 0 : at - 4, hi = at + 8 > NM ? NM : at + 8;
        for (int k = lo; k < hi; k++) {
            ef_vec3_t q0 = M[k].b[0];
            for (int j = 1; j <= 64; j++) {
                ef_vec3_t q1;
                ef_bezier_eval(M[k].b, M[k].degree, (float)j / 64.0f, 0, &q1);
                double a[3] = {q0.x, q0.y, q0.z}, b[3] = {q1.x, q1.y, q1.z};
                double d = dist_line(x, a, b);
                if (d < best) {
                    best = d;
                    at = k;
                }
                q0 = q1;
            }
        }
        if (best > worst)
            worst = best;
    }
    return worst;
}

/* Band decimation of dense, quantized CAM output (issue 18): an arc of radius 20 from
 * 0.02 mm chords with coordinates rounded to 0.0025 mm, 2-D and tilted in 3-D, qtol = P.
 * The noise must not become curvature or stops: a few decimated chords as G2 sections, one
 * stop (the end), the feed held, every input point within P of the path and the path
 * within P of the points (independent measures), curvature within the noise estimate
 * q / (sqrt(2) L^2) of 1/r, G2 at every junction. With qtol below the rounding nothing
 * merges (Q keeps its meaning); a piece running backwards is never merged over. */
static void test_band(void)
{
    ef_smooth_cfg_t c = cfg_default();
    enum { N = 3000 };
    static ef_prim_t pr[N];
    const double r = 20, q = 0.0025, tol = 0.02;
    for (int tilt = 0; tilt < 2; tilt++) {
        for (int i = 0; i < N; i++) {
            double a = 0.02 * (i + 1) / r;
            double x = r * cos(a), y = r * sin(a), z = tilt ? 0.3 * y : 0;
            x = q * floor(x / q + 0.5);
            y = q * floor(y / q + 0.5);
            z = q * floor(z / q + 0.5);
            pr[i] = line_to((float)x, (float)y, (float)z, 40, (float)tol);
            pr[i].qtol = (float)tol;
        }
        run_prims(&c, ef_v3((float)r, 0, 0), pr, N);
        runinfo_t ri = check_run(ef_v3((float)r, 0, 0), pr[N - 1].end, tol, &c.lim);
        ef_smooth_stats_t st = ef_smooth_stats(&S);
        double p2m = pts_to_moves(ef_v3((float)r, 0, 0));
        EF_CHECK_EQ(ri.stops, 1);
        EF_CHECK_EQ(st.stops, 1);
        EF_CHECK(st.merged > N / 2);
        EF_CHECK(NM < N / 20);
        EF_CHECK(ri.dev_over <= 1.0);
        EF_CHECK(p2m <= tol);
        /* ... and in fact about the rounding (0.0018 mm = 0.09 P at most) plus the fit. */
        EF_CHECK(ri.dev_over <= 0.3 && p2m <= 0.3 * tol);
        EF_CHECK_NEAR(M[NM / 2].v_entry, 40, 1e-2);
        double jump = 0, kerr = 0, lmin = 1e9;
        int smooth_joins = 0;
        for (int i = 0; i + 1 < NM; i++) {
            if (M[i].kind != EF_MOVE_SMOOTH || M[i + 1].kind != EF_MOVE_SMOOTH)
                continue;
            ef_vec3_t k0 = curv(&M[i], 1), k1 = curv(&M[i + 1], 0);
            jump = fmax(jump, ef_v3_norm(ef_v3_sub(k0, k1)) * r);
            kerr = fmax(kerr, fabs(ef_v3_norm(k1) * r - 1));
            lmin = fmin(lmin, fmin(M[i].length, M[i + 1].length));
            smooth_joins++;
        }
        EF_CHECK(smooth_joins >= NM - 4);
        EF_CHECK(jump < 1e-2);
        /* The frames are fitted to all the points (sm_frame_fit()), so the sections' third
         * derivative, which caps the speed and the ramps' jerk, stays near the circle's
         * kappa^2 (per axis at most 1 / r^2): kjerk r^2. */
        double gmax = 0;
        for (int i = 1; i + 1 < NM; i++)
            if (M[i].kind == EF_MOVE_SMOOTH)
                gmax = fmax(gmax, fmax(M[i].kjerk.x, fmax(M[i].kjerk.y, M[i].kjerk.z)) * r * r);
        /* kjerk takes the larger of the arc-length and the uniform-stepping third derivative
         * (ef_path.h): measured 17.3 (circle) and 18.1 (the tilted one, an ellipse whose
         * curvature varies by 8 %); with frames from the circle through three points 18.4
         * and 24.3 (the fit matters more on coarser rounding: short_0001in in the LinuxCNC
         * benchmark) */
        EF_CHECK(gmax <= (tilt ? 22.0 : 20.0));
        /* q / (sqrt 2 L^2) is the RMS; 4 sigma, and the tilted circle is an ellipse whose
         * curvature varies by 8 % itself. */
        double kn = 4 * q / (sqrt(2.0) * lmin * lmin) * r + (tilt ? 0.1 : 0);
        EF_CHECK(kerr <= kn);
        printf("band (%s): %d points -> %d moves (%u merged, %u smooth, %u blends, %u stops), "
               "dev / P path->points %.3f points->path %.3f, |kappa r - 1| max %.3f (bound %.3f), "
               "curvature jump x r %.1e, third derivative x r^2 %.2f\n",
               tilt ? "3-D" : "2-D", N, NM, st.merged, st.smooth, st.blends, st.stops, ri.dev_over,
               p2m / tol, kerr, kn, jump, gmax);
    }
    /* Q below the rounding: Q keeps its meaning, nothing off the line merges. */
    for (int i = 0; i < N; i++)
        pr[i].qtol = 1e-6f;
    run_prims(&c, ef_v3((float)r, 0, 0), pr, N);
    check_run(ef_v3((float)r, 0, 0), pr[N - 1].end, tol, &c.lim);
    /* (where the rounding leaves runs of points exactly on a line, near 0 and 90 degrees,
     * those still merge) */
    printf("band, Q 1e-6: %u merged\n", ef_smooth_stats(&S).merged);
    EF_CHECK(ef_smooth_stats(&S).merged < N / 4);
    /* A piece running backwards inside the band is never merged over. */
    ef_prim_t b[4] = {line_to(1, 0, 0, 40, 0.02f), line_to(2, 0, 0, 40, 0.02f),
                      line_to(1.995f, 0, 0, 40, 0.02f), line_to(3, 0, 0, 40, 0.02f)};
    for (int i = 0; i < 4; i++)
        b[i].qtol = 0.02f;
    run_prims(&c, ef_v3(0, 0, 0), b, 4);
    check_run(ef_v3(0, 0, 0), b[3].end, 0.02, &c.lim);
    EF_CHECK_EQ(ef_smooth_stats(&S).merged, 1); /* 1 into 2 only */
    EF_CHECK_EQ(ef_smooth_stats(&S).reversals, 2);
}

/* Lines and arcs meeting at corners: blends at arc ends, within P. */
/* Zigzag noise about a straight line (issue 18): 0.05 mm steps up and down by 0.7 tol,
 * qtol = tol. Every vertex turns by 90 degrees and the points lie on both sides of the
 * chord, so the run takes the whole Q (as LinuxCNC's G64 Q) and collapses into chords of
 * EF_SMOOTH_MERGE_MAX inner vertices, not 900 blends. The same points lifted to one side
 * of a curve (a sawtooth on an arc that turns slowly) are not noise: its vertices turn by
 * less than 60 degrees, so the band stays EF_SMOOTH_BAND_SHARE tol there. */
static void test_zigzag(void)
{
    ef_smooth_cfg_t c = cfg_default();
    c.micro_len = 0;
    enum { N = 900 };
    static ef_prim_t pr[N];
    const float tol = 0.05f, amp = 0.7f * tol, step = 0.05f;
    for (int i = 0; i < N; i++) {
        pr[i] = line_to(step * (float)(i + 1), (i % 2) ? 0.0f : amp, 0, 50, tol);
        pr[i].qtol = tol;
    }
    run_prims(&c, ef_v3(0, 0, 0), pr, N);
    runinfo_t ri = check_run(ef_v3(0, 0, 0), pr[N - 1].end, tol, &c.lim);
    ef_smooth_stats_t st = ef_smooth_stats(&S);
    double p2m = pts_to_moves(ef_v3(0, 0, 0));
    printf("zigzag: %d points -> %d moves (%u merged, %u blends, %u stops), dev / P path->points "
           "%.3f points->path %.3f\n",
           N, NM, st.merged, st.blends, st.stops, ri.dev_over, p2m / tol);
    EF_CHECK(st.merged >= N - N / EF_SMOOTH_MERGE_MAX - 2);
    EF_CHECK(NM < 2 * (N / EF_SMOOTH_MERGE_MAX + 2));
    EF_CHECK_EQ(ri.stops, 1);
    EF_CHECK(ri.dev_over <= 1.0);
    EF_CHECK(p2m <= tol);
    /* The same band share kept for a curve: a polyline whose vertices alternate between
     * radius R and R - amp on an arc (turns of a few degrees) merges only within 0.5 tol. */
    const double R = 50.0;
    for (int i = 0; i < N; i++) {
        double a = 0.5 * (i + 1) / R, rr = (i % 2) ? R : R - 0.7 * tol;
        pr[i] = line_to((float)(rr * cos(a)), (float)(rr * sin(a)), 0, 50, tol);
        pr[i].qtol = tol;
    }
    run_prims(&c, ef_v3((float)R, 0, 0), pr, N);
    check_run(ef_v3((float)R, 0, 0), pr[N - 1].end, tol, &c.lim);
    printf("sawtooth on an arc: %u merged of %d\n", ef_smooth_stats(&S).merged, N);
    EF_CHECK_EQ(ef_smooth_stats(&S).merged, 0);
}

static void test_arcs(void)
{
    ef_smooth_cfg_t c = cfg_default();
    ef_prim_t pr[6];
    pr[0] = line_to(20, 0, 0, 40, 0.02f);
    /* arc turning left, not tangent to the line (centre off the normal) */
    pr[1] = arc_to(pr[0].end, 20, 10, 1.2f, 40, 0.02f);
    pr[2] = line_to(pr[1].end.x - 10, pr[1].end.y + 15, 0, 40, 0.02f);
    pr[3] = arc_to(pr[2].end, pr[2].end.x - 3, pr[2].end.y - 4, -2.0f, 40, 0.02f);
    pr[4] = arc_to(pr[3].end, pr[3].end.x + 2, pr[3].end.y, 3.0f, 40, 0.02f);
    pr[5] = line_to(0, 0, 0, 40, 0.02f);
    int rc = run_prims(&c, ef_v3(0, 0, 0), pr, 6);
    EF_CHECK_EQ(rc, 0);
    runinfo_t ri = check_run(ef_v3(0, 0, 0), pr[5].end, 0.02, &c.lim);
    ef_smooth_stats_t st = ef_smooth_stats(&S);
    EF_CHECK(ri.dev_over <= 1.0);
    EF_CHECK(st.arc_pieces >= 3);
    EF_CHECK(st.blends + st.straight + st.stops >= 5);
    printf("lines+arcs: %d moves (%d arc pieces, %u blends, %u stops), max dev / P %.4f\n", NM,
           ri.kinds[EF_MOVE_ARC], st.blends, st.stops, ri.dev_over);
}

/* The same move, field by field (the planned law included). */
static int same_move(const ef_move_t *a, const ef_move_t *b)
{
    return memcmp(a->b, b->b, sizeof a->b) == 0 && a->degree == b->degree && a->kind == b->kind &&
           a->flags == b->flags && a->seq == b->seq && a->tag == b->tag && a->length == b->length &&
           a->dev == b->dev && a->v_max == b->v_max && a->v_entry == b->v_entry &&
           a->v_exit == b->v_exit && a->duration == b->duration &&
           memcmp(&a->law, &b->law, sizeof a->law) == 0;
}

/* ef_smooth_work() in the caller's idle time: after every push, units until it has none
 * (EF_ERR_AGAIN), and at the end units while a finish waits, the pulls in between. Every
 * unit counted, the moves the same bits as without it (the decisions do not depend on when
 * they are made), and nothing left once the finish returns EF_OK. */
static void test_work(void)
{
    enum { N = 240, KEEP = 4096 };
    static ef_prim_t pr[N];
    static ef_move_t ref[KEEP];
    ef_vec3_t p = ef_v3(0, 0, 0);
    for (int i = 0; i < N; i++) { /* micro-segments on a circle, corners, arcs */
        if (i % 60 == 59) {
            pr[i] = arc_to(p, p.x, p.y + 4.0f, 2.0f, 40, 0.02f);
        } else if (i % 60 >= 40) {
            pr[i] =
                line_to(p.x + ((i % 2) ? 3.0f : 0.0f), p.y + ((i % 2) ? 0.0f : 3.0f), 0, 40, 0.02f);
        } else {
            double a = 0.05 * (i % 60);
            pr[i] = line_to(p.x + (float)(0.5 * cos(a)), p.y + (float)(0.5 * sin(a)), 0, 40, 0.02f);
        }
        pr[i].tag = (uint32_t)i;
        p = pr[i].end;
    }
    ef_smooth_cfg_t c = cfg_default();
    EF_CHECK_EQ(run_prims(&c, ef_v3(0, 0, 0), pr, N), 0);
    int nref = NM < KEEP ? NM : KEEP;
    EF_CHECK(NM > 0 && NM < KEEP);
    memcpy(ref, M, (size_t)nref * sizeof ref[0]);

    EF_CHECK_EQ(ef_smooth_work(NULL), EF_ERR_ARG);
    EF_CHECK_EQ(ef_smooth_init(&S, &c, ef_v3(0, 0, 0)), EF_OK);
    EF_CHECK_EQ(ef_smooth_work(&S), EF_ERR_AGAIN); /* nothing pushed: nothing to do */
    NM = 0;
    uint32_t idle_units = 0;
    for (int i = 0; i < N; i++) {
        int rc = ef_smooth_push(&S, &pr[i]);
        for (int guard = 0; rc == EF_ERR_FULL && guard < 100000; guard++) {
            EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
            rc = ef_smooth_push(&S, &pr[i]);
        }
        EF_CHECK_EQ(rc, EF_OK);
        for (int guard = 0; guard < 100000; guard++) {
            uint32_t u = ef_smooth_stats(&S).units;
            rc = ef_smooth_work(&S);
            if (rc == EF_ERR_AGAIN) {
                EF_CHECK_EQ(ef_smooth_stats(&S).units, u); /* no unit: not counted */
                break;
            }
            EF_CHECK_EQ(rc, EF_OK);
            EF_CHECK_EQ(ef_smooth_stats(&S).units, u + 1u);
            idle_units++;
            EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
        }
    }
    /* finish flags the stop; the rest is done by idle units */
    int rc = ef_smooth_finish(&S);
    for (int guard = 0; rc == EF_ERR_FULL && guard < 100000; guard++) {
        while (ef_smooth_work(&S) == EF_OK)
            EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
        EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
        rc = ef_smooth_finish(&S);
    }
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
    EF_CHECK_EQ(ef_smooth_work(&S), EF_ERR_AGAIN);
    EF_CHECK_EQ(NM, nref);
    int same = 0;
    for (int k = 0; k < nref && k < NM; k++)
        same += same_move(&M[k], &ref[k]);
    EF_CHECK_EQ(same, nref);
    EF_CHECK(idle_units > 0);
    printf("work: %d moves the same bits with %u units done in idle calls (%u in all)\n", NM,
           idle_units, ef_smooth_stats(&S).units);
}

static uint64_t rng = 88172645463325252ull;
static double urand(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (double)(rng >> 11) * (1.0 / 9007199254740992.0);
}

/* Random paths: random corners (2-D and 3-D, near reversals, short and long segments,
 * random tolerances) with some micro-segment stretches and arcs. Every run keeps the
 * invariants and the deviation bound. */
static void test_random(int runs)
{
    ef_smooth_cfg_t c = cfg_default();
    double worst = 0;
    long moves = 0, blends = 0, smooth = 0, rev = 0;
    static ef_prim_t pr[400];
    for (int run = 0; run < runs; run++) {
        int n = 20 + (int)(urand() * 180);
        int is3d = run % 3 == 0;
        float tol = (float)(0.001 + 0.05 * urand());
        ef_vec3_t p = ef_v3(0, 0, 0);
        double dir = 0;
        for (int i = 0; i < n; i++) {
            int micro = urand() < 0.5;
            double len = micro ? 0.1 + 0.5 * urand() : 0.05 + 30 * urand() * urand();
            double turn = micro ? (urand() - 0.5) * 0.3 : (urand() - 0.5) * 2 * M_PI;
            if (urand() < 0.03)
                turn = M_PI * (urand() < 0.5 ? 1 : -1) * (1 - 1e-3 * urand());
            dir += turn;
            double dz = is3d ? (urand() - 0.5) * len : 0;
            if (!micro && urand() < 0.2) {
                /* an arc of random radius and sweep starting here */
                double rr = 0.5 + 20 * urand(), sw = (urand() - 0.5) * 4;
                double side = sw > 0 ? 1 : -1;
                float cx = (float)(p.x - side * rr * sin(dir)),
                      cy = (float)(p.y + side * rr * cos(dir));
                pr[i] = arc_to(p, cx, cy, (float)sw, 30, tol);
                pr[i].centre.z = p.z;
                dir += sw;
            } else {
                pr[i] = line_to((float)(p.x + len * cos(dir)), (float)(p.y + len * sin(dir)),
                                (float)(p.z + dz), 30, tol);
            }
            if (urand() < 0.1)
                pr[i].qtol = tol * 0.5f;
            p = pr[i].end;
        }
        int rc = run_prims(&c, ef_v3(0, 0, 0), pr, n);
        (void)rc; /* a degenerate random primitive is refused; the rest must still hold */
        ef_vec3_t endp = P[NP - 1].pr.end;
        runinfo_t ri = check_run(ef_v3(0, 0, 0), endp, tol, &c.lim);
        if (ri.dev_over > worst)
            worst = ri.dev_over;
        ef_smooth_stats_t st = ef_smooth_stats(&S);
        moves += NM;
        blends += st.blends;
        smooth += st.smooth;
        rev += st.reversals;
    }
    EF_CHECK(worst <= 1.0);
    printf("random: %d paths, %ld moves, %ld blends, %ld smooth vertices, %ld reversal stops; "
           "max deviation / P = %.4f\n",
           runs, moves, blends, smooth, rev, worst);
}

/* Bad input: each refused with its code, state unchanged, the stream goes on. */
static void test_bad_input(void)
{
    ef_smooth_cfg_t c = cfg_default();
    EF_CHECK_EQ(ef_smooth_init(&S, &c, ef_v3(0, 0, 0)), EF_OK);
    ef_prim_t ok = line_to(10, 0, 0, 50, 0.01f);
    EF_CHECK_EQ(ef_smooth_push(&S, &ok), EF_OK);
    ef_prim_t bad = line_to(NAN, 0, 0, 50, 0.01f);
    EF_CHECK_EQ(ef_smooth_push(&S, &bad), EF_ERR_NONFINITE);
    bad = line_to(INFINITY, 0, 0, 50, 0.01f);
    EF_CHECK_EQ(ef_smooth_push(&S, &bad), EF_ERR_NONFINITE);
    bad = line_to(2e7f, 0, 0, 50, 0.01f); /* huge coordinate */
    EF_CHECK_EQ(ef_smooth_push(&S, &bad), EF_ERR_NONFINITE);
    bad = line_to(10, 0, 0, 50, 0.01f); /* zero length */
    EF_CHECK_EQ(ef_smooth_push(&S, &bad), EF_ERR_DEGENERATE);
    bad = line_to(10, 10, 0, 0, 0.01f); /* feed 0 */
    EF_CHECK_EQ(ef_smooth_push(&S, &bad), EF_ERR_FEED);
    bad = line_to(10, 10, 0, -5, 0.01f);
    EF_CHECK_EQ(ef_smooth_push(&S, &bad), EF_ERR_FEED);
    bad = arc_to(ef_v3(10, 0, 0), 10, 5, 1.0f, 50, 0.01f);
    bad.end.x += 0.5f; /* end radius differs from the start radius */
    EF_CHECK_EQ(ef_smooth_push(&S, &bad), EF_ERR_ARC);
    /* an arc whose ends and centre are within EF_MAX_COORD but whose circle reaches beyond */
    bad = arc_to(ef_v3(10, 0, 0), 9.9e5f, 0, 3.0f, 50, 0.01f);
    EF_CHECK_EQ(ef_smooth_push(&S, &bad), EF_ERR_NONFINITE);
    bad = line_to(10, 10, 0, 50, NAN);
    EF_CHECK(ef_smooth_push(&S, &bad) < 0);
    EF_CHECK_EQ(ef_smooth_push(NULL, &ok), EF_ERR_ARG);
    EF_CHECK_EQ(ef_smooth_push(&S, NULL), EF_ERR_ARG);
    /* after the refusals, the stream continues from the last accepted end */
    ef_prim_t next = line_to(10, 10, 0, 50, 0.01f);
    next.tag = 1;
    EF_CHECK_EQ(ef_smooth_push(&S, &next), EF_OK);
    EF_CHECK_EQ(ef_smooth_stats(&S).prims, 2);
    NM = 0;
    EF_CHECK_EQ(finish_all(), EF_OK);
    EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
    EF_CHECK_EQ(NM, 3); /* line, blend, line */
    NP = 2;
    P[0].pr = ok;
    memset(P[0].a, 0, sizeof P[0].a);
    P[1].pr = next;
    P[1].a[0] = 10;
    P[1].a[1] = P[1].a[2] = 0;
    check_run(ef_v3(0, 0, 0), ef_v3(10, 10, 0), 0.01, &c.lim);

    /* bad configurations */
    ef_smooth_cfg_t b = c;
    b.g2 = NULL;
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_ARG);
    b = c;
    b.g2 = &ef_tbl_g1_default;
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_KIND);
    b = c;
    b.lim.a_axis[1] = 0;
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_FEED);
    b = c;
    b.micro_len = NAN;
    EF_CHECK_EQ(ef_smooth_init(&S, &b, ef_v3(0, 0, 0)), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_smooth_init(&S, &c, ef_v3(NAN, 0, 0)), EF_ERR_NONFINITE);
}

/* A full look-ahead: pushing without pulling ends in EF_ERR_FULL with no more progress
 * (nothing lost: every EF_ERR_FULL before did a work unit); pulling makes room and the same
 * primitive is then accepted; the path comes out whole. */
static void test_full(void)
{
    ef_smooth_cfg_t c = cfg_default();
    c.micro_len = 0;
    EF_CHECK_EQ(ef_smooth_init(&S, &c, ef_v3(0, 0, 0)), EF_OK);
    static ef_prim_t pr[1000];
    int pushed = 0, rc = EF_OK, retries = 0;
    for (int i = 0; i < 1000; i++) {
        pr[i] = line_to((float)(i + 1), (float)(i % 2), 0, 50, 0.01f);
        pr[i].tag = (uint32_t)i;
        uint32_t units;
        do {
            units = ef_smooth_stats(&S).units;
            rc = ef_smooth_push(&S, &pr[i]);
            retries += rc == EF_ERR_FULL;
        } while (rc == EF_ERR_FULL && ef_smooth_stats(&S).units != units);
        if (rc != EF_OK)
            break;
        pushed++;
    }
    EF_CHECK_EQ(rc, EF_ERR_FULL);
    EF_CHECK(pushed >= 8 && pushed < 1000);
    printf("look-ahead: full after %d primitives without pulling (%d pushes repeated while "
           "work went on)\n",
           pushed, retries);
    NM = 0;
    EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
    EF_CHECK(NM > 0);
    rc = ef_smooth_push(&S, &pr[pushed]);
    for (int guard = 0; rc == EF_ERR_FULL && guard < 100; guard++) {
        EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
        rc = ef_smooth_push(&S, &pr[pushed]);
    }
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(finish_all(), EF_OK);
    EF_CHECK_EQ(drain(), EF_ERR_AGAIN);
    NP = pushed + 1;
    for (int i = 0; i < NP; i++) {
        P[i].pr = pr[i];
        P[i].a[0] = i ? pr[i - 1].end.x : 0;
        P[i].a[1] = i ? pr[i - 1].end.y : 0;
        P[i].a[2] = 0;
    }
    runinfo_t ri = check_run(ef_v3(0, 0, 0), pr[pushed].end, 0.01, &c.lim);
    EF_CHECK(ri.dev_over <= 1.0);
}

/* The smoother feeding the interpolator in a periodic loop (1 ms): positions move by no
 * more than v_max dt per period, never NaN, and end exactly at the program end. */
static void test_with_interp(void)
{
    ef_smooth_cfg_t c = cfg_default();
    enum { N = 300 };
    static ef_prim_t pr[N];
    for (int i = 0; i < N; i++) {
        double a = 4 * M_PI * (i + 1) / N;
        double r = 5 + 0.02 * i;
        pr[i] = line_to((float)(r * cos(a)), (float)(r * sin(a)), 0, 60, 0.01f);
    }
    static ef_interp_t ip;
    EF_CHECK_EQ(ef_smooth_init(&S, &c, ef_v3(5, 0, 0)), EF_OK);
    EF_CHECK_EQ(ef_interp_init(&ip, ef_v3(5, 0, 0), 1000, EF_STEP_CORRECTED), EF_OK);
    int next = 0, finished = 0, bad = 0, underrun = 0;
    ef_vec3_t last = ef_v3(5, 0, 0);
    ef_move_t pending;
    int have_pending = 0;
    for (int tick = 0; tick < 200000; tick++) {
        /* feed the pipeline a little each tick, as a periodic task would */
        for (int k = 0; k < 4 && next < N; k++) {
            int rc = ef_smooth_push(&S, &pr[next]);
            if (rc == EF_OK)
                next++;
            else
                break;
        }
        if (next == N && !finished)
            finished = ef_smooth_finish(&S) == EF_OK; /* a unit a tick until done */
        for (;;) {
            if (!have_pending) {
                if (ef_smooth_pull(&S, &pending) != EF_OK)
                    break;
                have_pending = 1;
            }
            if (ef_interp_space(&ip) == 0)
                break;
            EF_CHECK_EQ(ef_interp_push(&ip, &pending), EF_OK);
            have_pending = 0;
        }
        ef_setpoint_t sp;
        uint32_t nx;
        int rc = ef_interp_process(&ip, 1000, &nx, &sp);
        if (rc == EF_ERR_UNDERRUN)
            underrun++;
        if (!isfinite(sp.p.x) || !isfinite(sp.p.y) ||
            ef_v3_norm(ef_v3_sub(sp.p, last)) > 60e-3f * 1.01f)
            bad++;
        last = sp.p;
        if (finished && !have_pending && !sp.moving && ef_interp_space(&ip) == EF_INTERP_QUEUE &&
            tick > 10)
            break;
    }
    EF_CHECK_EQ(bad, 0);
    EF_CHECK_EQ(underrun, 0);
    EF_CHECK(ef_v3_norm(ef_v3_sub(last, pr[N - 1].end)) < 1e-5f);
}

static void test_micro_circle_5(void)
{
    test_micro_circle(5);
}

static void test_micro_circle_3(void)
{
    test_micro_circle(3);
}

/* random [RUNS]: 300 runs unless told. */
static void test_random_runs(void)
{
    test_random(ef_t_argc > 0 ? atoi(ef_t_argv[0]) : 300);
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"square", test_square},
        {"reversal", test_reversal},
        {"collinear", test_collinear},
        {"circle", test_micro_circle_5},
        {"circle", test_micro_circle_3},
        {"arcs", test_arcs},
        {"bad", test_bad_input},
        {"full", test_full},
        {"interp", test_with_interp},
        {"band", test_band},
        {"chordshift", test_chord_shift},
        {"sineframes", test_sine_frames},
        {"zigzag", test_zigzag},
        {"work", test_work},
        {"random [RUNS]", test_random_runs},
    };
    setvbuf(stdout, NULL, _IOLBF, 0);
    M = calloc(MAXM, sizeof *M);
    if (!M)
        return 2;
    int rc = EF_TEST_RUN(argc, argv, 1, parts);
    free(M);
    return rc;
}
