/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Setpoint continuity (issue 18, deliverable 5): at every move junction and inside every
 * move, every axis's setpoint acceleration is within its limit and its jerk within J, up
 * to the float32 and sampling margins stated in ef_sp_check.h.
 *
 * Each part generates G-code text deterministically and runs it through the whole host
 * pipeline (G-code reader -> smoother -> planner -> interpolator, ef_pipeline.h) at the
 * default limits (axis 100 mm/s, 1000 mm/s^2, J 20 000 mm/s^3, 1 ms) with corrected
 * stepping (the pipeline's default; some also without a jerk limit), and checks every
 * setpoint with the checker; the part "uniform" runs the whole corpus again with uniform
 * stepping.
 * Each run prints one line per quantity with its worst sample, so a failing run says
 * which program, mode, time, axis and move.
 *
 *   test_continuity [PART...]        parts: checker, cam, runs, arcs, feeds, overfeed,
 *                                    tangent, qcircle, zigzag, far, junction,
 *                                    uniform, file [PATH...]
 *   test_continuity file a.ngc ...   any program (no PATH: the two samples)
 *
 * EF_CT_DUMP=DIR writes every generated program to DIR/NAME.ngc (to rerun one with
 * `evenfeed smooth DIR/NAME.ngc -o out.csv`).
 */
#include <stdarg.h>
#include <string.h>
#include "ef_test.h"
#include "motion/ef_sp_check.h"
#include "evenfeed/host/program/ef_pipeline.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

static ef_gcode_t R; /* about 50 kB: not on the stack */

/* ------------------------------------------------------------------ running a program */

#define CT_KINDS 4096u

typedef struct {
    spc_t chk;
    double t_last;
    uint64_t gaps;          /* setpoints not one period after the previous one */
    uint8_t kind[CT_KINDS]; /* move kind by seq (mod CT_KINDS), for the reports */
} ct_run_t;

static ct_run_t RUN;

static int ct_on_move(void *u, const ef_move_t *m, const ef_pipe_move_info_t *mi)
{
    ct_run_t *r = u;
    (void)mi;
    /* The move's extent bounds its evaluation error (ef_sp_check.h): its length, or its
     * control polygon's span where that is larger. */
    double ext = m->length;
    for (int i = 1; i <= m->degree; i++) {
        ef_vec3_t d = ef_v3_sub(m->b[i], m->b[0]);
        ext = fmax(ext, (double)ef_v3_norm(d));
    }
    spc_scale(&r->chk, ext);
    r->kind[m->seq % CT_KINDS] = m->kind;
    return 0;
}

/* "line -> blend": the kinds of the moves at both ends of a worst sample's window. */
static const char *ct_kinds(const spc_worst_t *w)
{
    static char b[64];
    const char *k0 = ef_pipe_move_kind_name(RUN.kind[w->seq0 % CT_KINDS]);
    const char *k1 = ef_pipe_move_kind_name(RUN.kind[w->seq1 % CT_KINDS]);
    if (w->seq0 == w->seq1)
        snprintf(b, sizeof b, "inside a %s", k0);
    else
        snprintf(b, sizeof b, "%s -> %s", k0, k1);
    return b;
}

static int ct_on_sp(void *u, double t, const ef_setpoint_t *sp, const ef_pipe_move_info_t *mi)
{
    ct_run_t *r = u;
    (void)mi;
    if (r->chk.samples && fabs(t - r->t_last - r->chk.dt) > 1e-9) {
        r->gaps++;
        spc_break(&r->chk);
    }
    r->t_last = t;
    spc_push(&r->chk, t, sp);
    return 0;
}

/* Run src with step mode `mode` and jerk limit j; check it; print the worst samples.
 * Returns whether the invariant held. */
static int ct_run(const char *name, const char *src, int mode, float j)
{
    ef_pipe_cfg_t cfg;
    ef_pipe_cfg_default(&cfg);
    cfg.g2 = &ef_tbl_g2_default;
    cfg.g1 = &ef_tbl_g1_default;
    cfg.lim.j_max = j;
    cfg.step_mode = mode;
    cfg.interp_modes = 1u << mode;
    ef_pipe_cb_t cb = {NULL, ct_on_move, ct_on_sp, NULL, NULL, &RUN};
    memset(&RUN, 0, sizeof RUN);
    spc_init(&RUN.chk, cfg.period_us * 1e-6, &cfg.lim);
    ef_pipe_stats_t st;
    ef_msg_t msg = {{0}};
    ef_gcode_init(&R, src, strlen(src), name);
    int rc = ef_pipe_run(&R, &cfg, &cb, &st, &msg);
    if (rc != EF_OK)
        fprintf(stderr, "%s: %s\n", name, msg.text);
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(st.fl[mode].underruns, 0);
    EF_CHECK_EQ(RUN.gaps, 0);
    EF_CHECK(RUN.chk.samples > 10);
    char label[160];
    snprintf(label, sizeof label, "%s %s J%.0f", name, mode == EF_STEP_CORRECTED ? "corr" : "unif",
             (double)j);
    int ok = spc_ok(&RUN.chk);
    spc_report(&RUN.chk, label, ok ? stdout : stderr);
    if (!ok) {
        if (RUN.chk.a_over)
            fprintf(stderr, "%s: acceleration over the limit; worst %s\n", label,
                    ct_kinds(&RUN.chk.wa));
        if (RUN.chk.j_over)
            fprintf(stderr, "%s: jerk over the limit; worst %s\n", label, ct_kinds(&RUN.chk.wj));
    }
    EF_CHECK(ok);
    return ok;
}

/* Step mode of the runs: corrected (the pipeline's and the CLI's default) in every part but
 * "uniform", which runs the whole corpus again with uniform stepping (what ef_drive.c
 * executes segments with). */
static int MODE = EF_STEP_CORRECTED;

/* A program at the default jerk limit, and also without one when nojerk is set. */
static void ct_run_all(const char *name, const char *src, int nojerk)
{
    const char *dir = getenv("EF_CT_DUMP"); /* write the program there (for the CLI) */
    if (dir) {
        char path[512];
        snprintf(path, sizeof path, "%s/%s.ngc", dir, name);
        FILE *f = fopen(path, "w");
        if (f) {
            fputs(src, f);
            fclose(f);
        }
    }
    ct_run(name, src, MODE, 20000.0f);
    if (nojerk)
        ct_run(name, src, MODE, 0.0f);
}

/* ------------------------------------------------------------------ program text */

#define CT_TEXT_MAX (4u << 20)
static char TXT[CT_TEXT_MAX];
static size_t TXT_N;
static double QUANT = 1e-4;     /* coordinates are printed rounded to this (mm) */
static double POS[3];           /* position as printed */
static unsigned long long SEED; /* generator state */
static int FEED, FEED_PENDING;  /* current feed (mm/min), to print with the next move */

#if defined(__GNUC__)
static void ct_emit(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
#endif
static void ct_emit(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(TXT + TXT_N, CT_TEXT_MAX - TXT_N, fmt, ap);
    va_end(ap);
    if (n > 0 && TXT_N + (size_t)n + 1 < CT_TEXT_MAX) {
        TXT_N += (size_t)n;
        TXT[TXT_N++] = '\n';
        TXT[TXT_N] = 0;
    }
}

/* A new program: header line, start point (exact), rounding quantum q. */
static void ct_begin(unsigned long long seed, double q, const char *header, double x, double y,
                     double z)
{
    TXT_N = 0;
    TXT[0] = 0;
    SEED = seed;
    QUANT = q;
    ct_emit("%s", header);
    POS[0] = x;
    POS[1] = y;
    POS[2] = z;
    ct_emit("G0 X%.5f Y%.5f Z%.5f", x, y, z);
    FEED_PENDING = 1;
}

static const char *ct_end(void)
{
    ct_emit("M30");
    return TXT;
}

static double ct_uni(double lo, double hi)
{
    return ef_t_uniform(&SEED, lo, hi);
}

static int ct_pick(int n)
{
    return (int)(ef_t_rng(&SEED) % (unsigned long long)n);
}

static double ct_q(double v)
{
    return floor(v / QUANT + 0.5) * QUANT;
}

static void ct_feed(int f)
{
    if (f != FEED)
        FEED_PENDING = 1;
    FEED = f;
}

/* " F..." when the feed is to be printed (then not again until it changes). */
static const char *ct_fword(void)
{
    static char b[32];
    b[0] = 0;
    if (FEED_PENDING)
        snprintf(b, sizeof b, " F%d", FEED);
    FEED_PENDING = 0;
    return b;
}

/* G1 to (x, y, z), rounded; skipped when it rounds to the current point. */
static void ct_g1(double x, double y, double z)
{
    x = ct_q(x);
    y = ct_q(y);
    z = ct_q(z);
    if (fabs(x - POS[0]) < 0.5 * QUANT && fabs(y - POS[1]) < 0.5 * QUANT &&
        fabs(z - POS[2]) < 0.5 * QUANT)
        return;
    ct_emit("G1 X%.5f Y%.5f Z%.5f%s", x, y, z, ct_fword());
    POS[0] = x;
    POS[1] = y;
    POS[2] = z;
}

/* Planes: in-plane axes (a, b) and the normal, G3 counter-clockwise in (a, b). */
static const int PL_A[3] = {0, 2, 1}, PL_B[3] = {1, 0, 2}, PL_N[3] = {2, 1, 0};
static const char *PL_G[3] = {"G17", "G18", "G19"};

/* Arc in plane pl (0 G17, 1 G18, 2 G19) about the centre at in-plane offset (ca, cb) from
 * the current point, by sweep (rad, > 0 counter-clockwise: G3), rising dn along the
 * normal (a helix when nonzero). Returns the heading (in-plane angle) at the end. */
static double ct_arc(int pl, double ca, double cb, double sweep, double dn)
{
    int a = PL_A[pl], b = PL_B[pl], n = PL_N[pl];
    double oa = ct_q(ca), ob = ct_q(cb);
    double c[2] = {POS[a] + oa, POS[b] + ob};
    double r = hypot(oa, ob), a0 = atan2(-ob, -oa), a1 = a0 + sweep;
    double e[3];
    e[a] = ct_q(c[0] + r * cos(a1));
    e[b] = ct_q(c[1] + r * sin(a1));
    e[n] = ct_q(POS[n] + dn);
    double off[3] = {0, 0, 0};
    off[a] = oa;
    off[b] = ob;
    char ijk[96];
    /* I J K for X Y Z: the two of the plane */
    static const char L[3] = {'I', 'J', 'K'};
    int lo = a < b ? a : b, hi = a < b ? b : a;
    snprintf(ijk, sizeof ijk, "%c%.5f %c%.5f", L[lo], off[lo], L[hi], off[hi]);
    ct_emit("%s X%.5f Y%.5f Z%.5f %s%s", sweep > 0 ? "G3" : "G2", e[0], e[1], e[2], ijk,
            ct_fword());
    memcpy(POS, e, sizeof e);
    double ea = atan2(e[b] - c[1], e[a] - c[0]);
    return ea + (sweep > 0 ? M_PI / 2 : -M_PI / 2);
}

/* G1 by distance len along in-plane heading hd of plane pl (plus dn along its normal). */
static void ct_step(int pl, double hd, double len, double dn)
{
    double p[3] = {POS[0], POS[1], POS[2]};
    p[PL_A[pl]] += len * cos(hd);
    p[PL_B[pl]] += len * sin(hd);
    p[PL_N[pl]] += dn;
    ct_g1(p[0], p[1], p[2]);
}

/* Tangent arc from heading hd: radius r, turning left (G3) or right (G2) by sweep. */
static double ct_tarc(int pl, double hd, double r, int left, double sweep)
{
    double s = left ? 1 : -1;
    return ct_arc(pl, -s * r * sin(hd), s * r * cos(hd), s * sweep, 0.0);
}

/* ------------------------------------------------------------------ the checker itself */

/* Feed the checker a sampled law x(t) on axis 0; the number of differences over. */
static int ct_synth(double (*law)(double), double base, float j, double dur, spc_worst_t *wa)
{
    ef_limits_t lim;
    memset(&lim, 0, sizeof lim);
    for (int i = 0; i < 3; i++) {
        lim.v_axis[i] = 100;
        lim.a_axis[i] = 1000;
    }
    lim.j_max = j;
    static spc_t c;
    spc_init(&c, 1e-3, &lim);
    spc_scale(&c, 10.0);
    int over = 0;
    for (int k = 0; k * 1e-3 <= dur; k++) {
        ef_setpoint_t sp;
        memset(&sp, 0, sizeof sp);
        sp.p = ef_v3((float)(base + law(k * 1e-3)), (float)base, (float)base);
        over += spc_push(&c, k * 1e-3, &sp);
    }
    if (wa)
        *wa = c.wa;
    return over;
}

/* A jerk-limited rest-to-rest S-curve with peak acceleration 1000 and jerk 20000 (time
 * 0.05 s up, 0.1 s at 1000, 0.05 s down: 150 mm/s; then cruise). */
static double ct_law_scurve(double t)
{
    const double J = 20000, A = 1000, t1 = 0.05, t2 = 0.15, t3 = 0.2;
    if (t < t1)
        return J * t * t * t / 6;
    double x1 = J * t1 * t1 * t1 / 6, v1 = 0.5 * J * t1 * t1;
    if (t < t2) {
        double u = t - t1;
        return x1 + v1 * u + 0.5 * A * u * u;
    }
    double u2 = t2 - t1, x2 = x1 + v1 * u2 + 0.5 * A * u2 * u2, v2 = v1 + A * u2;
    if (t < t3) {
        double u = t - t2;
        return x2 + v2 * u + 0.5 * A * u * u - J * u * u * u / 6;
    }
    double u3 = t3 - t2;
    double x3 = x2 + v2 * u3 + 0.5 * A * u3 * u3 - J * u3 * u3 * u3 / 6;
    double v3 = v2 + A * u3 - 0.5 * J * u3 * u3;
    return x3 + v3 * (t - t3);
}

/* Constant speed 50 mm/s with a 1.5 mm/s speed step at t = 0.1 s. */
static double ct_law_vstep(double t)
{
    return 50 * t + (t > 0.1 ? 1.5 * (t - 0.1) : 0.0);
}

/* Constant acceleration 900 switched on at t = 0.1 s (a jerk impulse, acceleration
 * within the limit). */
static double ct_law_astep(double t)
{
    return 10 * t + (t > 0.1 ? 450 * (t - 0.1) * (t - 0.1) : 0.0);
}

/* Constant speed 100 mm/s. */
static double ct_law_cruise(double t)
{
    return 100 * t;
}

/* The checker: a limited law passes at the limit, jumps are caught, float32 noise at
 * 100 mm is within the margin. */
static void test_checker(void)
{
    spc_worst_t w;
    EF_CHECK_EQ(ct_synth(ct_law_scurve, 0.0, 20000.0f, 0.4, &w), 0);
    EF_CHECK(w.ratio > 0.9); /* it does reach the limit */
    EF_CHECK(fabs(w.value) <= 1000.0 * 1.0001);
    EF_CHECK(ct_synth(ct_law_vstep, 0.0, 0.0f, 0.3, &w) > 0);       /* 1.5 mm/s in 1 ms: */
    EF_CHECK(fabs(w.value) > 1400);                                 /* 1500 mm/s^2 */
    EF_CHECK_EQ(ct_synth(ct_law_astep, 0.0, 0.0f, 0.3, NULL), 0);   /* no jerk check */
    EF_CHECK(ct_synth(ct_law_astep, 0.0, 20000.0f, 0.3, NULL) > 0); /* 900 in 1 ms */
    /* float32 rounding at 100 mm: within the margin, at both limits */
    EF_CHECK_EQ(ct_synth(ct_law_cruise, 100.0, 20000.0f, 0.5, &w), 0);
    EF_CHECK(fabs(w.value) > 1.0); /* the noise is there */
    EF_CHECK_EQ(ct_synth(ct_law_scurve, 90.0, 20000.0f, 0.4, NULL), 0);
}

/* ------------------------------------------------------------------ program kinds */

/* gen_cam style (tests/bench/gen_cam.c): a pocket walked by a turtle: curved runs of
 * micro-segments, collinear straight runs, sharp corners, tangent arcs, feed changes,
 * layers and a retract/rapid/plunge; 4 decimals. */
static const char *ct_prog_cam(unsigned long long seed, int lines)
{
    ct_begin(seed, 1e-4, "G21 G90 G17 G64 P0.010 Q0.005", 0, 0, 5);
    double crad = 25, hd = ct_uni(0, 2 * M_PI);
    ct_feed(150);
    ct_g1(0, 0, -1);
    while (TXT_N < (size_t)lines * 30) {
        int f = ct_pick(100);
        double px = POS[0], py = POS[1];
        int out = hypot(px, py) > crad;
        double steer = cos(hd) * -py - sin(hd) * -px >= 0 ? 1 : -1;
        if (ct_pick(25) == 0)
            ct_feed(600 + 100 * ct_pick(20));
        if (f < 45) { /* curved run */
            int k = 10 + ct_pick(80);
            double c0 = exp(ct_uni(log(0.05), log(1.0)));
            double kmax = fmin(0.5, 0.3 / c0);
            double k0 = ct_uni(-kmax, kmax), k1 = ct_uni(-kmax, kmax);
            if (out) {
                k0 = steer * fabs(k0);
                k1 = steer * fabs(k1);
            }
            for (int i = 0; i < k; i++) {
                double c = c0 * ct_uni(0.9, 1.1);
                hd += c * (k0 + (k1 - k0) * i / k);
                ct_g1(POS[0] + c * cos(hd), POS[1] + c * sin(hd), POS[2]);
            }
        } else if (f < 60) { /* straight run in collinear pieces */
            double len = ct_uni(3, 20);
            if (out)
                hd += steer * ct_uni(0.5, 1.5);
            int parts = 1 + ct_pick(6);
            double x0 = POS[0], y0 = POS[1];
            for (int i = 1; i <= parts; i++)
                ct_g1(x0 + cos(hd) * len * i / parts, y0 + sin(hd) * len * i / parts, POS[2]);
        } else if (f < 75) { /* corner */
            hd += (out || ct_pick(3) ? steer : -steer) * ct_uni(20, 150) * M_PI / 180;
            double len = ct_uni(0.5, 8);
            ct_g1(POS[0] + len * cos(hd), POS[1] + len * sin(hd), POS[2]);
        } else if (f < 95) { /* tangent arc */
            double r = exp(ct_uni(log(0.5), log(15))), sw = ct_uni(10, 270) * M_PI / 180;
            int left = out ? steer > 0 : ct_pick(2);
            hd = ct_tarc(0, hd, r, left, sw);
        } else if (f < 98) { /* layer step down */
            ct_feed(200);
            ct_g1(POS[0], POS[1], POS[2] - 0.5);
            ct_feed(600 + 100 * ct_pick(20));
        } else { /* retract, rapid, plunge */
            double z = POS[2];
            ct_emit("G0 Z5.00000");
            double a = ct_uni(0, 2 * M_PI), d = ct_uni(0, crad * 0.7);
            POS[0] = ct_q(d * cos(a));
            POS[1] = ct_q(d * sin(a));
            ct_emit("G0 X%.5f Y%.5f", POS[0], POS[1]);
            POS[2] = 5;
            ct_feed(250);
            ct_g1(POS[0], POS[1], z);
            ct_feed(600 + 100 * ct_pick(20));
        }
    }
    return ct_end();
}

static void test_cam(void)
{
    char name[32];
    for (unsigned s = 1; s <= 3; s++) {
        snprintf(name, sizeof name, "cam-%u", s);
        ct_run_all(name, ct_prog_cam(s, 500), s == 1);
    }
}

/* Short collinear G1 runs in random 3-D directions, pieces 0.01-0.5 mm, corners between. */
static const char *ct_prog_runs(unsigned long long seed)
{
    ct_begin(seed, 1e-4, "G21 G90 G17 G64 P0.02", 0, 0, 0);
    ct_feed(1200 + 600 * ct_pick(8));
    for (int r = 0; r < 12; r++) {
        double u[3] = {ct_uni(-1, 1), ct_uni(-1, 1), ct_uni(-0.3, 0.3)};
        double n = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        double piece = exp(ct_uni(log(0.01), log(0.5)));
        int k = 5 + ct_pick(50);
        double p0[3] = {POS[0], POS[1], POS[2]};
        /* back towards the origin when far out */
        if (p0[0] * u[0] + p0[1] * u[1] > 0 && hypot(p0[0], p0[1]) > 10) {
            u[0] = -u[0];
            u[1] = -u[1];
        }
        for (int i = 1; i <= k; i++)
            ct_g1(p0[0] + u[0] / n * piece * i, p0[1] + u[1] / n * piece * i,
                  p0[2] + u[2] / n * piece * i);
    }
    return ct_end();
}

static void test_runs(void)
{
    char name[32];
    for (unsigned s = 1; s <= 4; s++) {
        snprintf(name, sizeof name, "runs-%u", s);
        ct_run_all(name, ct_prog_runs(s), 0);
    }
}

/* Short G1 runs followed by tangent (and non-tangent) arcs in plane pl, feed f (mm/min;
 * above 6000 the axis limit binds). */
static const char *ct_prog_run_arc(unsigned long long seed, int pl, int f)
{
    char head[64];
    snprintf(head, sizeof head, "G21 G90 %s G64 P0.02", PL_G[pl]);
    ct_begin(seed, 1e-4, head, 0, 0, 0);
    ct_feed(f);
    double hd = ct_uni(0, 2 * M_PI);
    for (int r = 0; r < 8; r++) {
        double piece = exp(ct_uni(log(0.02), log(1.0)));
        int k = 3 + ct_pick(12);
        for (int i = 0; i < k; i++)
            ct_step(pl, hd, piece, 0.0);
        double rad = exp(ct_uni(log(0.2), log(8))), sw = ct_uni(0.3, 3.5);
        int left = ct_pick(2);
        if (hypot(POS[PL_A[pl]], POS[PL_B[pl]]) > 15) /* turn back towards the origin */
            left = cos(hd) * -POS[PL_B[pl]] - sin(hd) * -POS[PL_A[pl]] >= 0;
        if (ct_pick(4) == 0) /* a corner into the arc */
            hd += (left ? 1 : -1) * ct_uni(0.2, 1.2);
        hd = ct_tarc(pl, hd, rad, left, sw);
    }
    return ct_end();
}

static void test_arcs(void)
{
    static const int feeds[] = {1200, 3000, 12000, 30000};
    char name[48];
    for (int pl = 0; pl < 3; pl++) {
        for (int fi = 0; fi < 4; fi++) {
            unsigned long long s = (unsigned long long)(10 * pl + fi + 1);
            snprintf(name, sizeof name, "arcs-%s-F%d", PL_G[pl], feeds[fi]);
            ct_run_all(name, ct_prog_run_arc(s, pl, feeds[fi]), 0);
        }
    }
}

/* Lines and arcs with the feed changed at every move, 60 to 9000 mm/min. */
static const char *ct_prog_feeds(unsigned long long seed)
{
    ct_begin(seed, 1e-4, "G21 G90 G17 G64 P0.02", 0, 0, 0);
    double hd = 0;
    for (int i = 0; i < 60; i++) {
        static const int fs[] = {60, 300, 900, 1500, 2400, 4000, 6000, 9000};
        ct_feed(fs[ct_pick(8)]);
        if (ct_pick(3) == 0) {
            hd = ct_tarc(0, hd, ct_uni(0.5, 5), ct_pick(2), ct_uni(0.5, 2.5));
        } else {
            if (ct_pick(2))
                hd += ct_uni(-1.0, 1.0);
            if (hypot(POS[0], POS[1]) > 15)
                hd = atan2(-POS[1], -POS[0]);
            ct_step(0, hd, ct_uni(0.05, 4), 0.0);
        }
    }
    return ct_end();
}

static void test_feeds(void)
{
    ct_run_all("feeds-1", ct_prog_feeds(1), 1);
    ct_run_all("feeds-2", ct_prog_feeds(2), 0);
}

/* A feed far above the axis limit (F30000 = 500 mm/s) on 3-D lines, helices and arcs in
 * all three planes. */
static const char *ct_prog_overfeed(unsigned long long seed)
{
    ct_begin(seed, 1e-4, "G21 G90 G17 G64 P0.05", 0, 0, 0);
    ct_feed(30000);
    for (int i = 0; i < 40; i++) {
        int pl = ct_pick(3);
        ct_emit("%s", PL_G[pl]);
        double hd = ct_uni(0, 2 * M_PI);
        if (ct_pick(2)) {
            double dn = ct_pick(2) ? ct_uni(-2, 2) : 0.0;
            ct_arc(pl, ct_uni(-5, 5), ct_uni(-5, 5), ct_uni(-4, 4), dn);
        } else {
            double p[3] = {POS[0], POS[1], POS[2]};
            for (int k = 0; k < 3; k++)
                p[k] = fmin(20, fmax(-20, p[k] + ct_uni(-10, 10)));
            ct_g1(p[0], p[1], p[2]);
            ct_step(pl, hd, ct_uni(0.1, 3), 0.0);
        }
    }
    return ct_end();
}

static void test_overfeed(void)
{
    ct_run_all("overfeed-1", ct_prog_overfeed(1), 1);
    ct_run_all("overfeed-2", ct_prog_overfeed(2), 0);
}

/* Tangent arcs: a sawtooth of S-bends (G2/G3 alternating), and a line-arc burn-in. */
static const char *ct_prog_tangent(unsigned long long seed, double r, int f)
{
    ct_begin(seed, 1e-4, "G21 G90 G17 G64 P0.01", -20, 0, 0);
    ct_feed(f);
    double hd = 0;
    for (int i = 0; i < 16; i++)
        hd = ct_tarc(0, hd, r, i & 1, M_PI / 2);
    for (int i = 0; i < 12; i++) {
        ct_step(0, hd, ct_uni(0.2, 3), 0.0);
        hd = ct_tarc(0, hd, ct_uni(0.3, 4), 1, M_PI / 2);
    }
    return ct_end();
}

static void test_tangent(void)
{
    ct_run_all("tangent-r1-F3000", ct_prog_tangent(1, 1.0, 3000), 1);
    ct_run_all("tangent-r0.3-F6000", ct_prog_tangent(2, 0.3, 6000), 0);
    ct_run_all("tangent-r5-F12000", ct_prog_tangent(3, 5.0, 12000), 0);
}

/* A circle of radius r from chords of about `chord` mm, coordinates rounded to q. */
static const char *ct_prog_qcircle(double r, double chord, double q, int f)
{
    ct_begin(1, q, "G21 G90 G17 G64 P0.0254", r, 0, 0);
    ct_feed(f);
    int n = (int)ceil(2 * M_PI * r / chord);
    for (int i = 1; i <= n; i++)
        ct_g1(r * cos(2 * M_PI * i / n), r * sin(2 * M_PI * i / n), 0);
    return ct_end();
}

static void test_qcircle(void)
{
    ct_run_all("qcircle-r5-0.016-inch", ct_prog_qcircle(5, 0.016, 0.00254, 1500), 0);
    ct_run_all("qcircle-r10-0.016-um", ct_prog_qcircle(10, 0.016, 0.001, 3000), 0);
}

/* Zigzags: a raster with 0.0508 mm (0.002 in) step-overs, a fine sawtooth, a zigzag
 * square. */
static const char *ct_prog_zigzag(int kind)
{
    ct_begin(1, 1e-4, "G21 G90 G17 G64 P0.01", 0, 0, 0);
    ct_feed(3000);
    if (kind == 0) {
        for (int i = 0; i < 40; i++) {
            ct_g1(i & 1 ? 0 : 5, POS[1], 0);
            ct_g1(POS[0], POS[1] + 0.0508, 0);
        }
    } else if (kind == 1) {
        for (int i = 1; i <= 200; i++)
            ct_g1(0.0508 * i, i & 1 ? 0.0508 : 0.0, 0);
    } else {
        for (int i = 1; i <= 40; i++) {
            double s = 0.25 * i;
            ct_g1(s, 0, 0);
            ct_g1(s, s, 0);
            ct_g1(0, s, 0);
            ct_g1(0, 0, 0);
        }
    }
    return ct_end();
}

static void test_zigzag(void)
{
    ct_run_all("zigzag-raster", ct_prog_zigzag(0), 1);
    ct_run_all("zigzag-saw", ct_prog_zigzag(1), 0);
    ct_run_all("zigzag-square", ct_prog_zigzag(2), 0);
}

/* Far from the origin and long: lines and arcs (one a helix) of 100-800 mm at +-250 to 400
 * mm, where the float32 setpoints' own rounding is largest (ef_sp_check.h: at 250 mm and
 * a 200 mm arc piece, about +-170 mm/s^2 of noise in the second differences). */
static const char *ct_prog_far(void)
{
    ct_begin(1, 1e-4, "G21 G90 G17 G64 P0.02", -150, -150, -50);
    ct_emit("G1 X150 Y-149 Z-49 F6000");
    ct_emit("G1 X151 Y150 Z-48");
    ct_emit("G2 X51 Y250 Z-48 I-100 J0");
    ct_emit("G1 X-250 Y250 Z50");
    ct_emit("G3 X-250 Y-250 Z0 I0 J-250");
    ct_emit("G1 X-400 Y-400 Z-100 F600");
    return ct_end();
}

static void test_far(void)
{
    ct_run_all("far", ct_prog_far(), 1);
}

/* The junction jump of issue 18: a run of short G1 moves, then a G3 arc in G19 at a feed
 * above the axis limit, a short run and a G2 entered through a corner (its blend starts
 * with x1 at the table's bound, |f'(0)| ~ L / 12). The run's piece length shifts where the
 * servo samples fall at the junctions; before the interpolator's fix the feed over one
 * period went 6.05 -> 9.62 -> 2.65 -> 6.53 mm/s at the blend's start (6064 mm/s^2 on Z,
 * 6x the limit), the pattern the issue reports. */
static const char *ct_prog_junction(double piece, int n)
{
    ct_begin(1, 1e-4, "G21 G90 G19 G64 P0.02", 0, 0, 0);
    /* the arc's start and its tangent there (counter-clockwise about +X) */
    const double y0 = 9.1404, z0 = 4.5382, ty = 0.9266, tz = -0.3761;
    double y = y0 - n * piece * ty, z = z0 - n * piece * tz;
    POS[1] = ct_q(y);
    POS[2] = ct_q(z);
    ct_emit("G0 Y%.5f Z%.5f", POS[1], POS[2]);
    ct_feed(12000);
    for (int i = 1; i <= n; i++)
        ct_g1(0, y + i * piece * ty, z + i * piece * tz);
    ct_g1(0, y0, z0); /* the run ends exactly at the arc's start */
    ct_emit("G3 Y11.74280 Z7.50830 J0.78580 K1.93660");
    ct_emit("G1 Y11.73000 Z7.53080");
    ct_emit("G1 Y11.71720 Z7.55330");
    ct_emit("G1 Y11.70440 Z7.57580");
    ct_emit("G2 Y12.54730 Z7.48100 J0.39540 K-0.27890");
    return ct_end();
}

static void test_junction(void)
{
    char name[48];
    for (int k = 0; k < 24; k++) {
        snprintf(name, sizeof name, "junction-%02d", k);
        ct_run_all(name, ct_prog_junction(0.2 + 0.004 * k, 6), 0);
    }
    /* the generated program where it was found (arcs part's generator, seed 296) */
    ct_run_all("junction-gen296", ct_prog_run_arc(296, 2, 12000), 0);
}

/* ------------------------------------------------------------------ files */

static void test_file(void)
{
    static const char *samples[] = {EF_SOURCE_DIR "/samples/bracket.ngc",
                                    EF_SOURCE_DIR "/samples/profile.ngc"};
    int n = ef_t_argc ? ef_t_argc : 2;
    for (int i = 0; i < n; i++) {
        const char *path = ef_t_argc ? ef_t_argv[i] : samples[i];
        size_t len;
        char *src = ef_t_slurp(path, &len);
        EF_CHECK(src != NULL);
        if (!src)
            continue;
        const char *base = strrchr(path, '/');
        ct_run_all(base ? base + 1 : path, src, 1);
        free(src);
    }
}

/* The whole corpus with uniform stepping (ef_drive.c's mode): tau = s / L, so the feed is
 * v |f'(tau)| / L and jumps at a junction wherever a curve's end speed |f'| is not its
 * length (blends: a few per cent; at the table's x1 bound, twelve times). */
static void test_uniform(void)
{
    MODE = EF_STEP_UNIFORM;
    test_cam();
    test_runs();
    test_arcs();
    test_feeds();
    test_overfeed();
    test_tangent();
    test_qcircle();
    test_zigzag();
    test_far();
    test_junction();
    test_file();
    MODE = EF_STEP_CORRECTED;
}

int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"checker", test_checker},     {"cam", test_cam},
        {"runs", test_runs},           {"arcs", test_arcs},
        {"feeds", test_feeds},         {"overfeed", test_overfeed},
        {"tangent", test_tangent},     {"qcircle", test_qcircle},
        {"zigzag", test_zigzag},       {"far", test_far},
        {"junction", test_junction},   {"uniform", test_uniform},
        {"file [PATH...]", test_file},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
