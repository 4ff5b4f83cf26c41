/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The LinuxCNC planner core (host/lib/lcnc/ef_tp.c) without LinuxCNC: recorded motmod call
 * traces replayed call for call (tests/lcnc/traces/, recorded by the module's trace=
 * parameter inside LinuxCNC's simulator), synthetic sessions (feed override steps, pause,
 * abort mid-blend, synchronized outputs) and bad input. Every setpoint is checked: per-axis
 * speed, acceleration (1 ms second differences) and jerk (4 ms third differences) within the
 * limits plus the float32 setpoints' rounding floor, no underrun, and the end reached.
 *
 *   test_tp [PART...]           parts below ("replay TRACE..." replays the given traces)
 *   test_tp dump TRACE          the setpoints of a replay as TSV on stdout (for debugging)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ef_test.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/host/lcnc/ef_tp.h"

extern const ef_table_t ef_tbl_g2_default;

#define JB 4 /* periods of the jerk baseline */

/* ---- limit checker over consecutive setpoints ---- */
typedef struct {
    ef_tp_cfg_t cfg;
    double hist[3 * JB + 1][3]; /* newest last */
    int n;
    double v[3], a[3], j[3]; /* worst excess ratios over the limit (1 = at the limit) */
    double jump;             /* largest step in one period (units) */
    long cycles, underruns;
    long first, last; /* first and last cycle whose position changed */
    double extra_e;   /* added to the float32 margin e: for an auxiliary axis checked in X's
                         slot, its rate (units per unit of X Y Z length) times the rounding of
                         the X Y Z setpoints, which the arc-length step turns into parameter
                         noise that the axis follows */
    FILE *dump;
} chk_t;

static double ulp32(double x)
{
    x = fabs(x);
    if (x < 1e-30)
        return 1e-45;
    return ldexp(1.0, (int)floor(log2(x)) - 23);
}

static void chk_init(chk_t *c, const ef_tp_cfg_t *cfg)
{
    memset(c, 0, sizeof *c);
    c->cfg = *cfg;
}

static void chk_push(chk_t *c, const ef_tp_status_t *st)
{
    const int H = 3 * JB + 1;
    if (c->n == H) {
        memmove(c->hist[0], c->hist[1], sizeof(c->hist[0]) * (size_t)(H - 1));
        c->n--;
    }
    memcpy(c->hist[c->n], st->pos, sizeof c->hist[0]);
    c->n++;
    c->cycles++;
    if (st->underrun)
        c->underruns++;
    if (c->dump)
        fprintf(c->dump, "%ld\t%.6f\t%.6f\t%.6f\t%d\t%.4f\n", c->cycles, st->pos[0], st->pos[1],
                st->pos[2], (int)st->exec_id, st->rate);
    double dt = c->cfg.period_s;
    int k = c->n - 1;
    for (int i = 0; i < 3; i++) {
        double e = 0.5 * ulp32(fmax(fabs(c->hist[k][i]), 1.0)) + c->extra_e;
        if (k >= 1) {
            double d = fabs(c->hist[k][i] - c->hist[k - 1][i]);
            c->jump = fmax(c->jump, d);
            if (d > 0.0) {
                if (!c->first)
                    c->first = c->cycles;
                c->last = c->cycles;
            }
            c->v[i] = fmax(c->v[i], (d - 2 * e) / dt / c->cfg.v_axis[i]);
        }
        if (k >= 2) {
            double a = fabs(c->hist[k][i] - 2 * c->hist[k - 1][i] + c->hist[k - 2][i]);
            c->a[i] = fmax(c->a[i], (a - 4 * e) / (dt * dt) / c->cfg.a_axis[i]);
        }
        if (k >= 3 * JB) {
            double j = fabs(c->hist[k][i] - 3 * c->hist[k - JB][i] + 3 * c->hist[k - 2 * JB][i] -
                            c->hist[k - 3 * JB][i]);
            double h = JB * dt;
            c->j[i] = fmax(c->j[i], (j - 8 * e) / (h * h * h) / c->cfg.j_max);
        }
    }
}

static void chk_limits(const chk_t *c, const char *what)
{
    double v = 0, a = 0, j = 0;
    for (int i = 0; i < 3; i++) {
        v = fmax(v, c->v[i]);
        a = fmax(a, c->a[i]);
        j = fmax(j, c->j[i]);
    }
    printf("%-28s %7ld cycles (motion %.3f s): speed %.3f, acceleration %.3f, jerk %.3f of "
           "the limits, largest step %.4f\n",
           what, c->cycles, c->first ? (c->last - c->first + 1) * c->cfg.period_s : 0.0, v, a, j,
           c->jump);
    EF_CHECK(v <= 1.0 + 1e-3);
    EF_CHECK(a <= 1.0);
    EF_CHECK(j <= 1.0);
    EF_CHECK_EQ(c->underruns, 0);
}

/* ---- trace replay (the calls the module makes, host/linuxcnc/evenfeedtp.c) ---- */
typedef struct {
    ef_tp_t tp;
    chk_t chk;
    chk_t chka;              /* A, through the checker's X slot, at A's limits */
    double prev[EF_TP_AXES]; /* the last accepted add's end */
    double a_rate;           /* largest |dA| / |dXYZ| over the adds (chords: an upper bound) */
    int spindle_sync, created, aborted;
    long adds, refused, zero;
    double us_sum, us_max; /* wall time of ef_tp_cycle() (a figure, not a check) */
    double last_status_pos[EF_TP_AXES];
} replay_t;

static replay_t rp; /* large: static */

/* A's limits in the checker's X slot: its speed and acceleration, jerk 20/s x that (the
 * module's rule for A B C U V W, ef_tp.c). */
static ef_tp_cfg_t replay_a_cfg(const ef_tp_cfg_t *c)
{
    ef_tp_cfg_t a = *c;
    a.v_axis[0] = c->v_aux[0];
    a.a_axis[0] = c->a_aux[0];
    a.j_max = 20.0 * c->a_aux[0];
    return a;
}

static int replay_file(const char *path, FILE *dump)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "cannot read %s\n", path);
        return -1;
    }
    memset(&rp, 0, sizeof rp);
    ef_tp_cfg_t cfg;
    ef_tp_cfg_default(&cfg);
    cfg.g2 = &ef_tbl_g2_default;
    char line[1024];
    int bad = 0;
    while (fgets(line, sizeof line, f)) {
        char cmd[32];
        double p[EF_TP_AXES], x[16];
        int n = 0;
        if (line[0] == '#' || sscanf(line, "%31s%n", cmd, &n) != 1)
            continue;
        const char *rest = line + n;
        if (!strcmp(cmd, "create")) {
            EF_CHECK_EQ(ef_tp_init(&rp.tp, &cfg, NULL), EF_OK);
            chk_init(&rp.chk, &cfg);
            ef_tp_cfg_t ac = replay_a_cfg(&cfg);
            chk_init(&rp.chka, &ac);
            rp.chk.dump = dump;
            rp.created = 1;
        } else if (!rp.created) {
            fprintf(stderr, "%s: '%s' before create\n", path, cmd);
            bad = 1;
            break;
        } else if (!strcmp(cmd, "cfg")) {
            if (sscanf(rest, "%lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &x[0], &x[1], &x[2],
                       &x[3], &x[4], &x[5], &x[6], &x[7], &x[8], &x[9], &x[10]) != 11) {
                bad = 1;
                break;
            }
            cfg.period_s = x[0];
            cfg.max_feed_scale = x[1];
            for (int i = 0; i < 3; i++) {
                cfg.v_axis[i] = x[2 + i];
                cfg.a_axis[i] = x[5 + i];
            }
            cfg.j_max = x[8];
            cfg.plan_share = x[9];
            cfg.tol_default = x[10];
            EF_CHECK_EQ(ef_tp_configure(&rp.tp, &cfg), EF_OK);
            rp.chk.cfg = cfg;
            rp.chka.cfg = replay_a_cfg(&cfg);
        } else if (!strcmp(cmd, "cfgaux")) {
            /* A B C U V W speed and acceleration limits, their blend tolerance (traces
             * recorded before the module took them have no such line: the defaults) */
            double y[13];
            if (sscanf(rest, "%lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf %lf", &y[0], &y[1],
                       &y[2], &y[3], &y[4], &y[5], &y[6], &y[7], &y[8], &y[9], &y[10], &y[11],
                       &y[12]) != 13) {
                bad = 1;
                break;
            }
            for (int i = 0; i < EF_TP_AXES - 3; i++) {
                cfg.v_aux[i] = y[i];
                cfg.a_aux[i] = y[6 + i];
            }
            cfg.aux_tol = y[12];
            EF_CHECK_EQ(ef_tp_configure(&rp.tp, &cfg), EF_OK);
            rp.chk.cfg = cfg;
            rp.chka.cfg = replay_a_cfg(&cfg);
        } else if (!strcmp(cmd, "pos")) {
            if (sscanf(rest, "%lf %lf %lf %lf %lf %lf %lf %lf %lf", &p[0], &p[1], &p[2], &p[3],
                       &p[4], &p[5], &p[6], &p[7], &p[8]) != 9) {
                bad = 1;
                break;
            }
            (void)ef_tp_set_pos(&rp.tp, p);
            memcpy(rp.prev, p, sizeof rp.prev);
        } else if (!strcmp(cmd, "term")) {
            int c;
            if (sscanf(rest, "%d %lf", &c, &x[0]) == 2)
                (void)ef_tp_set_term(&rp.tp, c, x[0]);
        } else if (!strcmp(cmd, "vlimit")) {
            if (sscanf(rest, "%lf", &x[0]) == 1)
                (void)ef_tp_set_vlimit(&rp.tp, x[0]);
        } else if (!strcmp(cmd, "id")) {
            int id;
            if (sscanf(rest, "%d", &id) == 1)
                ef_tp_set_id(&rp.tp, id);
        } else if (!strcmp(cmd, "dout")) {
            int i, v;
            if (sscanf(rest, "%d %d", &i, &v) == 2)
                (void)ef_tp_set_dout(&rp.tp, i, v);
        } else if (!strcmp(cmd, "aout")) {
            int i;
            if (sscanf(rest, "%d %lf", &i, &x[0]) == 2)
                (void)ef_tp_set_aout(&rp.tp, i, x[0]);
        } else if (!strcmp(cmd, "spindlesync")) {
            if (sscanf(rest, "%lf", &x[0]) == 1)
                rp.spindle_sync = x[0] != 0.0;
        } else if (!strcmp(cmd, "rigidtap")) {
            rp.refused++;
        } else if (!strcmp(cmd, "line") || !strcmp(cmd, "circle")) {
            int type, en, at, ir, k = 0;
            if (sscanf(rest, "%lf %lf %lf %lf %lf %lf %lf %lf %lf %d %lf %lf %d %d %d%n", &p[0],
                       &p[1], &p[2], &p[3], &p[4], &p[5], &p[6], &p[7], &p[8], &type, &x[0], &x[1],
                       &en, &at, &ir, &k) != 15) {
                bad = 1;
                break;
            }
            int rc;
            if (rp.spindle_sync) {
                rc = EF_ERR_ARG;
            } else if (cmd[0] == 'l') {
                double acc; /* the line's acceleration along it (after indexrotary) */
                if (sscanf(rest + k, "%lf", &acc) != 1) {
                    bad = 1;
                    break;
                }
                rc = ef_tp_add_line(&rp.tp, p, ir >= 0 ? EF_TP_MOTION_INDEXROTARY : type, x[0],
                                    x[1], acc, en, at);
            } else {
                double c[3], nn[3];
                if (sscanf(rest + k, "%lf %lf %lf %lf %lf %lf", &c[0], &c[1], &c[2], &nn[0], &nn[1],
                           &nn[2]) != 6) {
                    bad = 1;
                    break;
                }
                rc = ef_tp_add_arc(&rp.tp, p, c, nn, ir, type, x[0], x[1], en, at);
            }
            rp.adds++;
            if (rc == EF_OK) {
                double dx = p[0] - rp.prev[0], dy = p[1] - rp.prev[1], dz = p[2] - rp.prev[2];
                double dxyz = sqrt(dx * dx + dy * dy + dz * dz);
                if (dxyz > 1e-9)
                    rp.a_rate = fmax(rp.a_rate, fabs(p[3] - rp.prev[3]) / dxyz);
                memcpy(rp.prev, p, sizeof rp.prev);
            }
            if (rc == EF_ERR_DEGENERATE && strstr(ef_tp_msg(&rp.tp), "zero-length"))
                rp.zero++;
            else if (rc != EF_OK)
                rp.refused++;
        } else if (!strcmp(cmd, "cycles")) {
            long cnt;
            int at;
            if (sscanf(rest, "%ld %lf %d", &cnt, &x[0], &at) != 3) {
                bad = 1;
                break;
            }
            ef_tp_set_at_speed(&rp.tp, at);
            for (long i = 0; i < cnt; i++) {
                ef_tp_status_t st;
                struct timespec t0, t1;
                clock_gettime(CLOCK_MONOTONIC, &t0);
                (void)ef_tp_cycle(&rp.tp, x[0], &st);
                clock_gettime(CLOCK_MONOTONIC, &t1);
                double us = (t1.tv_sec - t0.tv_sec) * 1e6 + (t1.tv_nsec - t0.tv_nsec) * 1e-3;
                rp.us_sum += us;
                rp.us_max = us > rp.us_max ? us : rp.us_max;
                chk_push(&rp.chk, &st);
                ef_tp_status_t sa = st;
                sa.pos[0] = st.pos[3];
                sa.pos[1] = sa.pos[2] = 0.0;
                double mx =
                    fmax(fmax(fabs(st.pos[0]), fabs(st.pos[1])), fmax(fabs(st.pos[2]), 1.0));
                rp.chka.extra_e = 2.0 * rp.a_rate * 0.5 * ulp32(mx);
                chk_push(&rp.chka, &sa);
                memcpy(rp.last_status_pos, st.pos, sizeof st.pos);
            }
        } else if (!strcmp(cmd, "pause")) {
            ef_tp_pause(&rp.tp);
        } else if (!strcmp(cmd, "resume")) {
            ef_tp_resume(&rp.tp);
        } else if (!strcmp(cmd, "abort")) {
            ef_tp_abort(&rp.tp);
            rp.aborted = 1;
        } else if (!strcmp(cmd, "clear")) {
            ef_tp_clear(&rp.tp);
        } else {
            fprintf(stderr, "%s: unknown call '%s'\n", path, cmd);
            bad = 1;
            break;
        }
    }
    fclose(f);
    if (bad) {
        fprintf(stderr, "%s: malformed line: %s", path, line);
        return -1;
    }
    return rp.created ? 0 : -1;
}

static void test_replay(void)
{
    if (ef_t_argc == 0) {
        ef_test_skip("no trace given (ctest passes tests/lcnc/traces/*.trace)");
        return;
    }
    for (int i = 0; i < ef_t_argc; i++) {
        const char *path = ef_t_argv[i];
        int rc = replay_file(path, NULL);
        EF_CHECK_EQ(rc, 0);
        if (rc != 0)
            continue;
        const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
        chk_limits(&rp.chk, base);
        if (rp.chka.first > 0 || rp.chka.last > 0)
            chk_limits(&rp.chka, "  its A axis (deg)");
        printf("  servo-period call (ef_tp_cycle, this machine, its load): mean %.2f us, "
               "max %.1f us\n",
               rp.us_sum / (double)rp.chk.cycles, rp.us_max);
        const ef_tp_stats_t *ts = &rp.tp.st;
        printf("  %ld adds, %ld zero-length, %ld refused; planner: %u finishes, %u early "
               "releases, %u moves, most units in a cycle %u, stalls %u; vertices: %u "
               "blended, %u smooth, %u merged, %u stops\n",
               rp.adds, rp.zero, rp.refused, ts->finishes, ts->early, ts->moves, ts->max_units,
               ts->stalls, ts->blends + rp.tp.sm.st.blends, ts->smooth + rp.tp.sm.st.smooth,
               ts->merged + rp.tp.sm.st.merged, ts->stops + rp.tp.sm.st.stops);
        EF_CHECK(rp.adds > 0);
        EF_CHECK(rp.tp.st.moves > 0);
        /* the end: everything queued ran to its end (or an abort brought it to rest) */
        EF_CHECK(rp.tp.qn == 0);
        if (!rp.aborted && rp.refused == 0)
            for (int k = 0; k < EF_TP_AXES; k++)
                EF_CHECK_NEAR(rp.last_status_pos[k], rp.tp.goal[k], 1e-4);
    }
}

/* ---- synthetic sessions ---- */
static ef_tp_t tps; /* large: static */
static chk_t chks;
static int dio_log[64], dio_at[64], dio_n;

static void on_dio(void *user, int index, int value)
{
    ef_tp_t *tp = (ef_tp_t *)user;
    if (dio_n < 64) {
        dio_log[dio_n] = index * 2 + (value != 0);
        dio_at[dio_n] = (int)tp->exec_seq;
        dio_n++;
    }
}

static void s_init(double max_scale)
{
    ef_tp_cfg_t cfg;
    ef_tp_cfg_default(&cfg);
    cfg.g2 = &ef_tbl_g2_default;
    cfg.max_feed_scale = max_scale;
    ef_tp_ops_t ops = {on_dio, NULL, &tps};
    EF_CHECK_EQ(ef_tp_init(&tps, &cfg, &ops), EF_OK);
    chk_init(&chks, &cfg);
    dio_n = 0;
}

static void s_cycle(double scale, ef_tp_status_t *st)
{
    ef_tp_status_t tmp;
    if (!st)
        st = &tmp;
    int rc = ef_tp_cycle(&tps, scale, st);
    EF_CHECK(rc == EF_OK || rc == EF_ERR_UNDERRUN);
    chk_push(&chks, st);
}

/* A zigzag of n lines turning by about 30 degrees at 50 mm/s, G64 P0.05: blended corners. */
static void s_zigzag(int n, double x0)
{
    EF_CHECK_EQ(ef_tp_set_term(&tps, EF_TP_TERM_BLEND, 0.05), EF_OK);
    for (int i = 0; i < n; i++) {
        double p[EF_TP_AXES] = {0};
        p[0] = x0 + 4.0 * (i + 1);
        p[1] = (i % 2) ? 0.0 : 1.0 + 0.1 * (i % 3);
        p[2] = 0.1 * (i % 4);
        ef_tp_set_id(&tps, 100 + i);
        EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 50.0, 100.0, 1000.0, 0, 0), EF_OK);
    }
}

/* Cycles until done (at most max); returns the cycles run. */
static long s_run(double scale, long max, ef_tp_status_t *st)
{
    long k = 0;
    for (; k < max; k++) {
        s_cycle(scale, st);
        if (st->done)
            break;
    }
    return k;
}

static void test_override(void)
{
    s_init(1.5);
    s_zigzag(40, 0.0);
    ef_tp_status_t st;
    for (int k = 0; k < 600; k++)
        s_cycle(1.0, &st);
    EF_CHECK(st.moving);
    EF_CHECK_NEAR(st.rate, 1.0 / 1.5, 1e-9); /* 100 % of a plan made for 150 % */
    for (int k = 0; k < 800; k++)
        s_cycle(0.3, &st);
    EF_CHECK_NEAR(st.rate, 0.2, 1e-9);
    long n = s_run(1.5, 100000, &st);
    EF_CHECK(st.done);
    EF_CHECK_NEAR(st.rate, 1.0, 1e-9);
    printf("override 100 %% -> 30 %% -> 150 %%: done %ld cycles after the last step\n", n);
    chk_limits(&chks, "override steps");
    EF_CHECK_NEAR(st.pos[0], 160.0, 1e-4);
    EF_CHECK(tps.st.moves >= 40); /* lines and blends */
}

static void test_pause(void)
{
    s_init(1.0);
    s_zigzag(30, 0.0);
    ef_tp_status_t st;
    for (int k = 0; k < 700; k++)
        s_cycle(1.0, &st);
    EF_CHECK(st.moving);
    ef_tp_pause(&tps);
    double held[3];
    int still = 0;
    for (int k = 0; k < 1500; k++) {
        s_cycle(1.0, &st);
        if (k > 0 && memcmp(held, st.pos, sizeof held) == 0)
            still++;
        memcpy(held, st.pos, sizeof held);
    }
    EF_CHECK(still > 1000); /* stopped on the path within half a second */
    EF_CHECK(!st.done);
    EF_CHECK_NEAR(st.rate, 0.0, 0.0);
    ef_tp_resume(&tps);
    s_run(1.0, 100000, &st);
    EF_CHECK(st.done);
    EF_CHECK_NEAR(st.pos[0], 120.0, 1e-4);
    printf("pause: stood still for %d of 1500 periods\n", still);
    chk_limits(&chks, "pause, resume");
}

/* A program queued under LinuxCNC's feed inhibit (scale 0), then released: at rest where a
 * move starts from rest, its own jerk-limited law starts the motion, so the rate steps
 * there. Nothing moves while inhibited (before, the rate set at 1 ramped down to 0 while the
 * first move began: the machine crept), the rate is 1 at the first motion after the release,
 * and the program takes as many periods from its first motion as one never inhibited, within
 * the limits. A pause mid-move still resumes along the ramp (test_pause). */
static void test_inhibit(void)
{
    long periods[2];
    for (int inhibit = 0; inhibit <= 1; inhibit++) {
        s_init(1.0);
        s_zigzag(20, 0.0);
        ef_tp_status_t st;
        for (int k = 0; inhibit && k < 300; k++) {
            s_cycle(0.0, &st);
            EF_CHECK_NEAR(st.pos[0], 0.0, 0.0);
        }
        long first = -1, k = 0;
        for (; k < 100000; k++) {
            s_cycle(1.0, &st);
            if (first < 0 && st.pos[0] != 0.0) {
                first = k;
                EF_CHECK_NEAR(st.rate, 1.0, 0.0);
            }
            if (st.done)
                break;
        }
        EF_CHECK(st.done && first >= 0);
        EF_CHECK_NEAR(st.pos[0], 80.0, 1e-4);
        periods[inhibit] = k - first;
        chk_limits(&chks, inhibit ? "released after the inhibit" : "never inhibited");
    }
    EF_CHECK_EQ(periods[1], periods[0]);
    printf("inhibit: %ld periods from the first motion, %ld without the inhibit\n", periods[1],
           periods[0]);
}

static void test_abort(void)
{
    s_init(1.0);
    s_zigzag(30, 0.0);
    ef_tp_status_t st;
    int in_blend = 0;
    for (int k = 0; k < 5000 && !in_blend; k++) {
        s_cycle(1.0, &st);
        in_blend = k > 300 && st.moving && tps.ip.q[tps.ip.head].kind == EF_MOVE_BLEND &&
                   tps.ip.t > 0.002f;
    }
    EF_CHECK(in_blend);
    double at[3] = {st.pos[0], st.pos[1], st.pos[2]};
    ef_tp_abort(&tps);
    EF_CHECK_EQ(
        ef_tp_add_line(&tps, (double[EF_TP_AXES]){1, 1, 1}, EF_TP_MOTION_FEED, 10, 100, 1000, 0, 0),
        EF_ERR_ARG); /* refused while aborting */
    long n = s_run(1.0, 5000, &st);
    EF_CHECK(st.done);
    EF_CHECK_EQ(ef_tp_depth(&tps), 0);
    double d =
        sqrt((st.pos[0] - at[0]) * (st.pos[0] - at[0]) + (st.pos[1] - at[1]) * (st.pos[1] - at[1]));
    printf("abort mid-blend: at rest after %ld periods, %.3f mm further on\n", n, d);
    EF_CHECK(d < 12.0); /* a controlled stop on the path (about half a second here) */
    EF_CHECK_EQ(tps.st.aborts, 1);
    chk_limits(&chks, "abort mid-blend");
    /* new moves start where the abort left the machine */
    double p[EF_TP_AXES] = {st.pos[0] + 5.0, st.pos[1], st.pos[2]};
    EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 20, 100, 1000, 0, 0), EF_OK);
    s_run(1.0, 5000, &st);
    EF_CHECK(st.done);
    EF_CHECK_NEAR(st.pos[0], p[0], 1e-4);
    chk_limits(&chks, "after the abort");
}

static void test_stream(void)
{
    /* LinuxCNC hands over about one move per servo period: 600 short lines of a curve,
     * one added per cycle, then the end of input */
    s_init(1.0);
    EF_CHECK_EQ(ef_tp_set_term(&tps, EF_TP_TERM_BLEND, 0.01), EF_OK);
    ef_tp_status_t st;
    int added = 0;
    long k = 0;
    for (; k < 200000; k++) {
        if (added < 600 && !ef_tp_full(&tps)) {
            double a = 0.01 * (added + 1), p[EF_TP_AXES] = {0};
            p[0] = 30.0 * sin(a) + 0.2 * (added + 1);
            p[1] = 30.0 * (1.0 - cos(a));
            EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 80.0, 100.0, 1000.0, 0, 0),
                        EF_OK);
            added++;
        }
        s_cycle(1.0, &st);
        if (added == 600 && st.done)
            break;
    }
    EF_CHECK(st.done);
    printf("stream of 600 lines, one per period: %ld periods, %u early releases, %u "
           "finishes, %u moves\n",
           k, tps.st.early, tps.st.finishes, tps.st.moves);
    chk_limits(&chks, "streamed input");
    EF_CHECK_NEAR(st.pos[0], 30.0 * sin(6.0) + 0.2 * 600, 1e-3);
}

static void test_dio(void)
{
    s_init(1.0);
    EF_CHECK_EQ(ef_tp_set_term(&tps, EF_TP_TERM_STOP, 0.0), EF_OK);
    for (int i = 0; i < 4; i++) {
        double p[EF_TP_AXES] = {10.0 * (i + 1), 0, 0};
        if (i == 2) {
            EF_CHECK_EQ(ef_tp_set_dout(&tps, 5, 1), EF_OK);
            EF_CHECK_EQ(ef_tp_set_dout(&tps, 6, 0), EF_OK);
        }
        EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 50.0, 100.0, 1000.0, 0, 0), EF_OK);
    }
    EF_CHECK_EQ(ef_tp_set_dout(&tps, 64, 1), EF_ERR_ARG);
    EF_CHECK_EQ(ef_tp_set_aout(&tps, 3, NAN), EF_ERR_ARG);
    ef_tp_status_t st;
    s_run(1.0, 20000, &st);
    EF_CHECK(st.done);
    EF_CHECK_EQ(dio_n, 2);
    EF_CHECK_EQ(dio_log[0], 5 * 2 + 1);
    EF_CHECK_EQ(dio_log[1], 6 * 2 + 0);
    EF_CHECK_EQ(dio_at[0], 3); /* when the third move (seq 3) started */
    chk_limits(&chks, "synchronized outputs");
}

static void test_arc(void)
{
    /* LinuxCNC's arcs: turn 0 counter-clockwise about the normal, -1 clockwise, more turns */
    static const struct {
        int turn;
        double sweep; /* expected, rad */
    } cases[] = {{0, M_PI / 2}, {-1, -1.5 * M_PI}, {1, 2.5 * M_PI}, {-2, -3.5 * M_PI}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        s_init(1.0);
        double start[EF_TP_AXES] = {10, 0, 0}, end[EF_TP_AXES] = {0, 10, 1};
        double ctr[3] = {0, 0, 5}, nrm[3] = {0, 0, 2};
        EF_CHECK_EQ(ef_tp_set_pos(&tps, start), EF_OK);
        EF_CHECK_EQ(
            ef_tp_add_arc(&tps, end, ctr, nrm, cases[c].turn, EF_TP_MOTION_ARC, 40.0, 100.0, 0, 0),
            EF_OK);
        const ef_tp_item_t *it = ef_tp_item(&tps, 1);
        EF_CHECK(it != NULL);
        if (!it)
            continue;
        EF_CHECK_NEAR(it->pr.sweep, cases[c].sweep, 1e-5);
        EF_CHECK_NEAR(it->pr.centre.z, 0.0, 1e-6); /* moved to the start's height */
        ef_tp_status_t st;
        double rmax = 0.0, rmin = 1e9;
        for (long k = 0; k < 100000; k++) {
            s_cycle(1.0, &st);
            double r = hypot(st.pos[0], st.pos[1]);
            rmax = fmax(rmax, r);
            rmin = fmin(rmin, r);
            if (st.done)
                break;
        }
        EF_CHECK(st.done);
        EF_CHECK_NEAR(rmax, 10.0, 0.02);
        EF_CHECK_NEAR(rmin, 10.0, 0.02);
        EF_CHECK_NEAR(st.pos[1], 10.0, 1e-4);
        EF_CHECK_NEAR(st.pos[2], 1.0, 1e-4);
        chk_limits(&chks, "arc");
    }
}

static void test_aux(void)
{
    /* XYZ, then A alone (an indexing turn), then XYZ again: A's move runs between rests
     * within its own limits (X Y Z with A together: test_mixed) */
    s_init(1.0);
    chk_t ca;
    ef_tp_cfg_t ac = tps.cfg; /* A's limits in the checker's X slot: 90 deg/s, 360 deg/s^2 */
    ac.v_axis[0] = 90.0;
    ac.a_axis[0] = 360.0;
    ac.j_max = 20.0 * 360.0;
    chk_init(&ca, &ac);
    s_zigzag(4, 0.0);
    double p[EF_TP_AXES] = {16.0, 0.0, 0.3, 120.0};
    EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 90.0, 90.0, 360.0, 0, 0), EF_OK);
    double q[EF_TP_AXES] = {20.0, 2.0, 0.3, 120.0};
    EF_CHECK_EQ(ef_tp_add_line(&tps, q, EF_TP_MOTION_FEED, 50.0, 100.0, 1000.0, 0, 0), EF_OK);
    double z[EF_TP_AXES] = {20.0, 2.0, 0.3, 120.0, 0, 0, 0, 0, 1e-300};
    EF_CHECK_EQ(ef_tp_add_line(&tps, z, EF_TP_MOTION_FEED, 50.0, 100.0, 1000.0, 0, 0),
                EF_ERR_DEGENERATE); /* W by nothing: zero length */
    ef_tp_status_t st;
    int a_moving_xyz_still = 1, a_seen = 0;
    double last[EF_TP_AXES] = {0};
    for (long k = 0; k < 20000; k++) {
        s_cycle(1.0, &st);
        ef_tp_status_t sa = st;
        sa.pos[0] = st.pos[3]; /* A through the checker's X */
        sa.pos[1] = sa.pos[2] = 0.0;
        chk_push(&ca, &sa);
        if (k > 0 && st.pos[3] != last[3]) {
            a_seen = 1;
            if (st.pos[0] != last[0] || st.pos[1] != last[1] || st.pos[2] != last[2])
                a_moving_xyz_still = 0;
            EF_CHECK_EQ(st.exec_seq, 5);
        }
        memcpy(last, st.pos, sizeof last);
        if (st.done)
            break;
    }
    EF_CHECK(st.done);
    EF_CHECK(a_seen);
    EF_CHECK(a_moving_xyz_still);
    EF_CHECK_NEAR(st.pos[3], 120.0, 0.0);
    EF_CHECK_NEAR(st.pos[0], 20.0, 1e-4);
    EF_CHECK_NEAR(st.pos[1], 2.0, 1e-4);
    chk_limits(&chks, "XYZ around an A move");
    chk_limits(&ca, "the A move (deg)");
    /* an abort during an A move: A stops on its way, within its limits */
    s_init(1.0);
    chk_init(&ca, &ac);
    double a1[EF_TP_AXES] = {0, 0, 0, 720.0};
    EF_CHECK_EQ(ef_tp_add_line(&tps, a1, EF_TP_MOTION_FEED, 90.0, 90.0, 360.0, 0, 0), EF_OK);
    for (long k = 0; k < 20000; k++) {
        s_cycle(1.0, &st);
        ef_tp_status_t sa = st;
        sa.pos[0] = st.pos[3];
        sa.pos[1] = sa.pos[2] = 0.0;
        chk_push(&ca, &sa);
        if (k == 3000)
            ef_tp_abort(&tps);
        if (k > 3000 && st.done)
            break;
    }
    EF_CHECK(st.done);
    EF_CHECK(st.pos[3] > 100.0 && st.pos[3] < 720.0);
    chk_limits(&ca, "an abort of an A move (deg)");
    /* and the next move starts from where A stopped */
    double a2[EF_TP_AXES] = {0, 0, 0, 0};
    EF_CHECK_EQ(ef_tp_add_line(&tps, a2, EF_TP_MOTION_TRAVERSE, 90.0, 90.0, 360.0, 0, 0), EF_OK);
    s_run(1.0, 20000, &st);
    EF_CHECK(st.done);
    EF_CHECK_NEAR(st.pos[3], 0.0, 0.0);
}

/* X Y Z with A together (a 4-axis part): lines and an arc that turn A, blended at every
 * corner; A follows the path within its own speed, acceleration and jerk (90 deg/s,
 * 360 deg/s^2, 7200 deg/s^3), X Y Z within theirs; a feed override change mid-way; the end
 * reached on every axis. */
static void test_mixed(void)
{
    ef_tp_cfg_t cfg;
    ef_tp_cfg_default(&cfg);
    cfg.g2 = &ef_tbl_g2_default;
    cfg.max_feed_scale = 1.5;
    cfg.v_aux[0] = 90.0;
    cfg.a_aux[0] = 360.0;
    /* A's rate changes by 2-4 deg/mm at these corners: a blend within 0.02 deg would be
     * 0.02 mm long and A's acceleration would make it slower than a stop (docs/axes.md) */
    cfg.aux_tol = 0.5;
    ef_tp_ops_t ops = {on_dio, NULL, &tps};
    EF_CHECK_EQ(ef_tp_init(&tps, &cfg, &ops), EF_OK);
    chk_init(&chks, &cfg);
    chk_t ca;
    ef_tp_cfg_t ac = cfg; /* A's limits in the checker's X slot */
    ac.v_axis[0] = 90.0;
    ac.a_axis[0] = 360.0;
    ac.j_max = 20.0 * 360.0; /* A's jerk: 20/s x its acceleration (ef_tp.c) */
    chk_init(&ca, &ac);
    EF_CHECK_EQ(ef_tp_set_term(&tps, EF_TP_TERM_BLEND, 0.2), EF_OK);
    static const double pts[][4] = {{10, 0, 0, 20},   {20, 2, 0, 20},  {30, 0, 0.5, 60},
                                    {40, 2, 0.5, 30}, {50, 0, 0, -10}, {60, 2, 0, 0},
                                    {70, 0, 0, 45}};
    int np = (int)(sizeof pts / sizeof pts[0]);
    for (int i = 0; i < np; i++) {
        double p[EF_TP_AXES] = {pts[i][0], pts[i][1], pts[i][2], pts[i][3]};
        ef_tp_set_id(&tps, 200 + i);
        EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 40.0, 100.0, 1000.0, 0, 0), EF_OK);
    }
    double e[EF_TP_AXES] = {70, 0, 0, 135}, c[3] = {60, 0, 0}, n[3] = {0, 0, 1};
    EF_CHECK_EQ(ef_tp_add_arc(&tps, e, c, n, 0, EF_TP_MOTION_ARC, 40, 100, 0, 0), EF_OK);
    double f[EF_TP_AXES] = {80, 0, 0, 100};
    EF_CHECK_EQ(ef_tp_add_line(&tps, f, EF_TP_MOTION_FEED, 40.0, 100.0, 1000.0, 0, 0), EF_OK);
    ef_tp_status_t st;
    double last[EF_TP_AXES] = {0};
    long together = 0;
    for (long k = 0; k < 40000; k++) {
        s_cycle(k > 1500 && k < 2500 ? 1.5 : 1.0, &st);
        ef_tp_status_t sa = st;
        sa.pos[0] = st.pos[3];
        sa.pos[1] = sa.pos[2] = 0.0;
        chk_push(&ca, &sa);
        if (k > 0 && st.pos[3] != last[3] && (st.pos[0] != last[0] || st.pos[1] != last[1]))
            together++;
        memcpy(last, st.pos, sizeof last);
        if (st.done)
            break;
    }
    EF_CHECK(st.done);
    EF_CHECK(together > 1000); /* A turns while X Y move: blended, not stopped for */
    EF_CHECK(tps.st.blends + tps.sm.st.blends >= 6);
    EF_CHECK_EQ(tps.st.aux_stops + tps.sm.st.aux_stops, 0);
    EF_CHECK_NEAR(st.pos[0], 80.0, 1e-4);
    EF_CHECK_NEAR(st.pos[3], 100.0, 1e-4);
    float adev = fmaxf(tps.st.aux_dev_max, tps.sm.st.aux_dev_max);
    EF_CHECK(adev > 0.0f && adev <= cfg.aux_tol * 1.001);
    chk_limits(&chks, "X Y Z with A together");
    chk_limits(&ca, "A with X Y Z (deg)");
    printf("mixed: A turned in %ld periods while X Y moved, %u blends, A deviation %.4g deg\n",
           together, tps.st.blends + tps.sm.st.blends, (double)adev);
}

/* A move refused after it turned A (a bad arc) leaves A where the last queued move took it:
 * the next X Y Z move does not turn A to the refused value. */
static void test_aux_refused(void)
{
    s_init(1.0);
    double a[EF_TP_AXES] = {10, 0, 0, 30};
    EF_CHECK_EQ(ef_tp_add_line(&tps, a, EF_TP_MOTION_FEED, 40, 100, 1000, 0, 0), EF_OK);
    /* an arc off its circle (radius 5 at the start, 9 at the end), refused by the
     * firmware's check after its A was read */
    double b[EF_TP_AXES] = {15, 9, 0, 90}, c[3] = {15, 0, 0}, n[3] = {0, 0, 1};
    EF_CHECK(ef_tp_add_arc(&tps, b, c, n, 0, EF_TP_MOTION_ARC, 40, 100, 0, 0) < 0);
    /* A alone with no acceleration: refused likewise */
    double z[EF_TP_AXES] = {10, 0, 0, 120};
    EF_CHECK_EQ(ef_tp_add_line(&tps, z, EF_TP_MOTION_FEED, 40, 100, NAN, 0, 0), EF_ERR_FEED);
    double d[EF_TP_AXES] = {20, 5, 0, 30};
    EF_CHECK_EQ(ef_tp_add_line(&tps, d, EF_TP_MOTION_FEED, 40, 100, 1000, 0, 0), EF_OK);
    ef_tp_status_t st;
    double amax = 0;
    for (long k = 0; k < 20000; k++) {
        s_cycle(1.0, &st);
        amax = fmax(amax, st.pos[3]);
        if (st.done)
            break;
    }
    EF_CHECK(st.done);
    EF_CHECK_NEAR(st.pos[3], 30.0, 1e-4);
    EF_CHECK(amax <= 30.0 + 1e-4);
    EF_CHECK_NEAR(st.pos[1], 5.0, 1e-4);
}

static void test_vlimit(void)
{
    /* [TRAJ]MAX_LINEAR_VELOCITY caps the path speed of X Y Z moves, not of an A move */
    s_init(1.0);
    EF_CHECK_EQ(ef_tp_set_vlimit(&tps, 20.0), EF_OK);
    EF_CHECK_EQ(ef_tp_set_vlimit(&tps, NAN), EF_ERR_ARG);
    double p[EF_TP_AXES] = {30.0, 10.0, 0.0};
    EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_TRAVERSE, 100.0, 100.0, 1000.0, 0, 0), EF_OK);
    double q[EF_TP_AXES] = {30.0, 10.0, 0.0, 90.0};
    EF_CHECK_EQ(ef_tp_add_line(&tps, q, EF_TP_MOTION_TRAVERSE, 90.0, 90.0, 360.0, 0, 0), EF_OK);
    ef_tp_status_t st;
    double vmax_xyz = 0.0, vmax_a = 0.0, last[EF_TP_AXES] = {0};
    for (long k = 0; k < 20000; k++) {
        s_cycle(1.0, &st);
        double d = sqrt((st.pos[0] - last[0]) * (st.pos[0] - last[0]) +
                        (st.pos[1] - last[1]) * (st.pos[1] - last[1]));
        vmax_xyz = fmax(vmax_xyz, d / 1e-3);
        vmax_a = fmax(vmax_a, fabs(st.pos[3] - last[3]) / 1e-3);
        memcpy(last, st.pos, sizeof last);
        if (st.done)
            break;
    }
    EF_CHECK(st.done);
    printf("vlimit 20: path speed at most %.3f; A at most %.2f deg/s\n", vmax_xyz, vmax_a);
    EF_CHECK(vmax_xyz <= 20.0 * 1.001 && vmax_xyz > 19.0);
    EF_CHECK(vmax_a > 80.0);
    chk_limits(&chks, "vlimit");
}

static void test_bad(void)
{
    s_init(1.0);
    double ok[EF_TP_AXES] = {5, 0, 0}, p[EF_TP_AXES];
    memcpy(p, ok, sizeof p);
    p[1] = NAN;
    EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 10, 100, 1000, 0, 0), EF_ERR_NONFINITE);
    p[1] = INFINITY;
    EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 10, 100, 1000, 0, 0), EF_ERR_NONFINITE);
    memcpy(p, ok, sizeof p);
    p[3] = NAN; /* A not a number (X Y Z with A: test_mixed) */
    EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 10, 100, 1000, 0, 0), EF_ERR_NONFINITE);
    p[3] = 1e300;
    EF_CHECK_EQ(ef_tp_add_line(&tps, p, EF_TP_MOTION_FEED, 10, 100, 1000, 0, 0), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_tp_add_line(&tps, ok, 99, 10, 100, 1000, 0, 0), EF_ERR_ARG);
    EF_CHECK_EQ(ef_tp_add_line(&tps, ok, EF_TP_MOTION_INDEXROTARY, 10, 100, 1000, 0, 0),
                EF_ERR_ARG);
    EF_CHECK_EQ(ef_tp_add_line(&tps, ok, EF_TP_MOTION_FEED, NAN, 100, 1000, 0, 0),
                EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_tp_add_line(&tps, ok, EF_TP_MOTION_FEED, 0, 100, 1000, 0, 0), EF_ERR_FEED);
    EF_CHECK_EQ(ef_tp_add_line(&tps, ok, EF_TP_MOTION_FEED, 10, -1, 1000, 0, 0), EF_ERR_FEED);
    double z[EF_TP_AXES] = {0};
    EF_CHECK_EQ(ef_tp_add_line(&tps, z, EF_TP_MOTION_FEED, 10, 100, 1000, 0, 0), EF_ERR_DEGENERATE);
    EF_CHECK(strstr(ef_tp_msg(&tps), "zero-length") != NULL);
    double c[3] = {0, 0, 0}, n0[3] = {0, 0, 0}, n[3] = {0, 0, 1}, nn[3] = {0, NAN, 1};
    EF_CHECK_EQ(ef_tp_add_arc(&tps, ok, c, n0, 0, EF_TP_MOTION_ARC, 10, 100, 0, 0), EF_ERR_ARC);
    EF_CHECK_EQ(ef_tp_add_arc(&tps, ok, c, nn, 0, EF_TP_MOTION_ARC, 10, 100, 0, 0),
                EF_ERR_NONFINITE);
    double far[EF_TP_AXES] = {0, 9, 0}; /* radius 9 at the end, 0 at the start */
    EF_CHECK(ef_tp_add_arc(&tps, far, c, n, 0, EF_TP_MOTION_ARC, 10, 100, 0, 0) < 0);
    EF_CHECK_EQ(ef_tp_depth(&tps), 0); /* nothing of the refused moves queued */
    EF_CHECK_EQ(ef_tp_set_term(&tps, 7, 0.1), EF_ERR_ARG);
    EF_CHECK_EQ(ef_tp_set_term(&tps, EF_TP_TERM_BLEND, NAN), EF_ERR_ARG);
    p[3] = NAN;
    EF_CHECK_EQ(ef_tp_set_pos(&tps, p), EF_ERR_NONFINITE);
    /* queue overflow: back-pressure first, then a refusal, nothing lost */
    int full_at = -1, rc = EF_OK, i = 0;
    for (; i < EF_TP_QUEUE + 5; i++) {
        double q[EF_TP_AXES] = {0.5 * (i + 1), 0.3 * (i % 2), 0};
        if (full_at < 0 && ef_tp_full(&tps))
            full_at = i;
        rc = ef_tp_add_line(&tps, q, EF_TP_MOTION_FEED, 50, 100, 1000, 0, 0);
        if (rc != EF_OK)
            break;
    }
    EF_CHECK_EQ(full_at, EF_TP_QUEUE - EF_TP_QUEUE_MARGIN);
    EF_CHECK_EQ(rc, EF_ERR_FULL);
    EF_CHECK_EQ(i, EF_TP_QUEUE);
    EF_CHECK_EQ(ef_tp_set_pos(&tps, ok), EF_ERR_STATE);
    /* a NaN feed scale is 0: the rate ramps down and motion stands still on the path;
     * then everything queued runs */
    ef_tp_status_t st;
    double x_held = 0.0;
    for (int k = 0; k < 600; k++) {
        s_cycle(NAN, &st);
        if (k == 499)
            x_held = st.pos[0];
    }
    EF_CHECK_NEAR(st.rate, 0.0, 0.0);
    EF_CHECK_NEAR(st.pos[0], x_held, 0.0);
    EF_CHECK(st.pos[0] < 5.0);
    s_run(1.0, 200000, &st);
    EF_CHECK(st.done);
    EF_CHECK_NEAR(st.pos[0], 0.5 * EF_TP_QUEUE, 1e-3);
    chk_limits(&chks, "after bad input");
    /* bad settings */
    ef_tp_cfg_t cfg;
    ef_tp_cfg_default(&cfg);
    EF_CHECK_EQ(ef_tp_configure(&tps, &cfg), EF_ERR_ARG); /* no table */
    cfg.g2 = &ef_tbl_g2_default;
    cfg.a_axis[1] = -1.0;
    EF_CHECK_EQ(ef_tp_configure(&tps, &cfg), EF_ERR_ARG);
    cfg.a_axis[1] = 1000.0;
    cfg.period_s = 0.0;
    EF_CHECK_EQ(ef_tp_configure(&tps, &cfg), EF_ERR_ARG);
    EF_CHECK_EQ(ef_tp_cycle(NULL, 1.0, &st), EF_ERR_ARG);
    EF_CHECK(ef_tp_full(NULL));
}

int main(int argc, char **argv)
{
    if (argc >= 2 && !strcmp(argv[1], "dump")) { /* a debugging aid, not a part */
        if (argc != 3) {
            fprintf(stderr, "usage: test_tp dump TRACE\n");
            return EXIT_FAILURE;
        }
        printf("n\tx\ty\tz\tid\trate\n");
        return replay_file(argv[2], stdout) == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
    }
    static const ef_test_part_t parts[] = {
        {"override", test_override},
        {"pause", test_pause},
        {"abort", test_abort},
        {"stream", test_stream},
        {"dio", test_dio},
        {"arc", test_arc},
        {"aux", test_aux},
        {"mixed", test_mixed},
        {"inhibit", test_inhibit},
        {"auxrefused", test_aux_refused},
        {"vlimit", test_vlimit},
        {"bad", test_bad},
        {"replay TRACE...", test_replay},
    };
    return EF_TEST_RUN(argc, argv, 1, parts);
}
