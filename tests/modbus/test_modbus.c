/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Modbus end to end on the real protocol: the master (ef_mb_stream, libmodbus) against the
 * simulated drive (`evenfeed sim-drive modbus`, a separate process on libmodbus) over TCP
 * on loopback and over RTU on a socat pseudo-terminal pair. The drive's trace (every servo
 * period, every accepted segment) is checked against the moves the master sent:
 *  - every segment accepted exactly once, in order (none lost, none duplicated);
 *  - the commanded position of every period lies on the segment it claims to execute;
 *  - the actual (servo) position stays within the stated following error;
 *  - faults (exception replies, dropped replies, disconnects, drive faults, a drive
 *    restart) end in a clean resume or a detected, controlled stop.
 * Servers signal readiness on stdout; they are stopped by PID.
 *
 * Several drives (parts codec, axes, axesfault, axesbad, axesrtu): the single-axis slot codec;
 * one X Y Z drive and single-axis A and B drives streamed to together; a fault, a fast clock
 * and a killed drive stopping all of them; drive lists refused before any motion; two drives
 * on two RTU lines.
 *
 * usage: test_modbus EVENFEED SOURCE_DIR WORK_DIR [tcp|rtu|faults|bad|direct|codec|axes|
 *                                                  axesfault|axesbad|axesrtu]...
 */
#include <errno.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <poll.h>
#include <signal.h>
#include <stdint.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>
#include "ef_proc.h"
#include "ef_test.h"
#include "evenfeed/geom/ef_bezier.h"
#include "evenfeed/host/modbus/ef_mb.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

static const char *evenfeed_bin, *src_dir, *work_dir;

/** Largest distance (mm) between a commanded point and the curve of its segment: float32
 *  evaluation at ~100 mm plus the 256-chord polyline the test measures against. */
#define TM_CMD_TOL 2e-3
/** Largest following error (mm) of the default servo model (40 Hz, velocity feed-forward)
 *  on the standard path (measured 0.045 mm, in the decelerations of the rapids at 100 mm/s;
 *  the servo steps are per drive period, so the figure does not depend on host timing). */
#define TM_FERR_TOL 0.06

/* ------------------------------------------------------------------ reference and trace */

#define TM_MAX_MOVES 4096

typedef struct {
    ef_move_t mv[TM_MAX_MOVES];
    uint32_t n;
    uint32_t kill_at; /* restart test: kill the drive after this many moves */
    tm_proc_t *drive; /* ... this one */
    int restarted;
    int port;
    int last_port;       /* port of the last drive tm_tcp_case started */
    int monitor_reads;   /* second TCP client: status reads that succeeded */
    int monitor_running; /* ... that saw the drive RUNNING */
} tm_ref_t;

static tm_ref_t ref;

/* Record what the master sends; optionally read the drive's status over a second TCP
 * connection (several clients), or restart the drive mid-path. */
static int tm_on_move(void *user, const ef_move_t *mv)
{
    tm_ref_t *R = user;
    if (R->n < TM_MAX_MOVES)
        R->mv[R->n] = *mv;
    R->n++;
    if (R->port && R->n % 20 == 0) {
        modbus_t *ctx = modbus_new_tcp("127.0.0.1", R->port);
        uint16_t r[0x40];
        if (ctx && modbus_connect(ctx) == 0 && modbus_read_registers(ctx, 0, 0x40, r) == 0x40) {
            R->monitor_reads++;
            R->monitor_running += r[EF_MB_REG_STATE] == EF_DRV_RUNNING;
        }
        if (ctx) {
            modbus_close(ctx);
            modbus_free(ctx);
        }
    }
    if (R->kill_at && R->n == R->kill_at && R->drive) {
        /* Power-cycle the drive: kill it and start a new one on the same port. */
        tm_stop(R->drive, SIGKILL);
        char addr[64];
        snprintf(addr, sizeof addr, "127.0.0.1:%d", R->port);
        R->restarted = tm_drive(R->drive, "--tcp", addr, NULL, NULL, NULL) == 0;
    }
    return 0;
}

typedef struct {
    double t;
    int state, seq, moving;
    double cmd[3], act[3], ferr;
} tm_row_t;

typedef struct {
    tm_row_t *row;
    size_t nrow;
    long acc[TM_MAX_MOVES];
    size_t nacc;
    int fault_lines, dropped_lines, disconnect_lines, exception_lines;
} tm_trace_t;

/* Parse the drive's CSV trace. */
static int tm_trace_load(const char *path, tm_trace_t *T)
{
    memset(T, 0, sizeof *T);
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    size_t cap = 1024;
    T->row = malloc(cap * sizeof *T->row);
    char line[512];
    while (fgets(line, sizeof line, f)) {
        long s;
        if (sscanf(line, "#accepted %ld", &s) == 1) {
            if (T->nacc < TM_MAX_MOVES)
                T->acc[T->nacc] = s;
            T->nacc++;
            continue;
        }
        T->fault_lines += strncmp(line, "#fault", 6) == 0;
        T->dropped_lines += strncmp(line, "#reply dropped", 14) == 0;
        T->disconnect_lines += strncmp(line, "#disconnect", 11) == 0;
        T->exception_lines += strncmp(line, "#exception", 10) == 0;
        tm_row_t r;
        if (sscanf(line, "%lf,%d,%d,%d,%lf,%lf,%lf,%lf,%lf,%lf,%lf", &r.t, &r.state, &r.seq,
                   &r.moving, &r.cmd[0], &r.cmd[1], &r.cmd[2], &r.act[0], &r.act[1], &r.act[2],
                   &r.ferr) != 11)
            continue;
        if (T->nrow == cap) {
            cap *= 2;
            T->row = realloc(T->row, cap * sizeof *T->row);
        }
        T->row[T->nrow++] = r;
    }
    fclose(f);
    return 0;
}

/* Distance from p to the curve of move k, against a 256-chord polyline. */
static double tm_dist_to_move(const double p[3], uint32_t k)
{
    const ef_move_t *m = &ref.mv[k];
    double best = 1e300, prev[3] = {0, 0, 0};
    for (int i = 0; i <= 256; i++) {
        ef_vec3_t q;
        ef_bezier_eval(m->b, m->degree, (float)i / 256.0f, 0, &q);
        double c[3] = {q.x, q.y, q.z};
        if (i > 0) {
            double d[3], w[3], dd = 0, t = 0;
            for (int a = 0; a < 3; a++) {
                d[a] = c[a] - prev[a];
                w[a] = p[a] - prev[a];
                dd += d[a] * d[a];
                t += d[a] * w[a];
            }
            t = dd > 0 ? fmax(0.0, fmin(1.0, t / dd)) : 0.0;
            double e = 0;
            for (int a = 0; a < 3; a++)
                e += (w[a] - t * d[a]) * (w[a] - t * d[a]);
            best = fmin(best, sqrt(e));
        }
        memcpy(prev, c, sizeof prev);
    }
    return best;
}

/* The checks every run gets: accepted segments unique and in order; commanded positions on
 * their segments; following error bounded. n_expected: segments that should have been
 * accepted (all of them for a completed run). Returns the largest commanded deviation. */
static double tm_check_trace(const char *what, const tm_trace_t *T, uint32_t n_expected)
{
    int order_ok = T->nacc == n_expected;
    for (size_t i = 0; i < T->nacc && i < TM_MAX_MOVES; i++)
        order_ok &= T->acc[i] == (long)i;
    if (!order_ok)
        fprintf(stderr, "%s: %zu segments accepted, %u expected, or not 0..n-1 in order\n", what,
                T->nacc, n_expected);
    EF_CHECK(order_ok);
    double dmax = 0.0, fmax_ = 0.0;
    size_t checked = 0;
    for (size_t i = 0; i < T->nrow; i++) {
        const tm_row_t *r = &T->row[i];
        fmax_ = fmax(fmax_, r->ferr);
        if (r->state != EF_DRV_RUNNING || !r->moving || r->seq < 0 || (uint32_t)r->seq >= ref.n)
            continue;
        double d = tm_dist_to_move(r->cmd, (uint32_t)r->seq);
        dmax = fmax(dmax, d);
        checked++;
    }
    printf("%s: %zu periods traced, %zu on segments checked, commanded deviation max %.2e mm, "
           "following error max %.4f mm\n",
           what, T->nrow, checked, dmax, fmax_);
    EF_CHECK(checked > 100);
    EF_CHECK(dmax <= TM_CMD_TOL);
    EF_CHECK(fmax_ <= TM_FERR_TOL);
    return dmax;
}

/* Speed along the commanded path, from consecutive trace rows. */
static double tm_speed(const tm_trace_t *T, size_t i)
{
    const tm_row_t *a = &T->row[i - 1], *b = &T->row[i];
    double d = 0;
    for (int k = 0; k < 3; k++)
        d += (b->cmd[k] - a->cmd[k]) * (b->cmd[k] - a->cmd[k]);
    return b->t > a->t ? sqrt(d) / (b->t - a->t) : 0.0;
}

/* A controlled stop: once STOPPING appears, the commanded speed never rises and the drive
 * ends at rest in want_state. A drive slower than one period of its stop ramp when the stop
 * came (a_stop dt: 2 mm/s with the default 2000 mm/s^2 at 1 ms; where the path is then
 * depends on how fast the master streams) stops within that period, so no period shows
 * STOPPING: then the speed before it must be below a_stop dt. */
static void tm_check_controlled_stop(const char *what, const tm_trace_t *T, int want_state)
{
    size_t first = 0, direct = 0;
    for (size_t i = 1; i < T->nrow; i++) {
        if (T->row[i].state == EF_DRV_STOPPING) {
            first = i;
            break;
        }
        if (!direct && T->row[i].state == want_state && T->row[i - 1].state != want_state)
            direct = i;
    }
    if (first == 0 && direct > 0) {
        double v = direct > 1 ? tm_speed(T, direct - 1) : 0.0;
        printf("%s: stopped within one period from %.4f mm/s, then state %d\n", what, v,
               T->row[T->nrow - 1].state);
        EF_CHECK(v <= 2000.0 * 1e-3 + 1e-3); /* the sim drive's a_stop x its 1 ms period */
        EF_CHECK(T->row[T->nrow - 1].state == want_state);
        return;
    }
    EF_CHECK(first > 0);
    int mono = 1;
    double v0 = first > 0 ? tm_speed(T, first) : 0.0, prev = v0;
    size_t i = first + 1;
    for (; first > 0 && i < T->nrow && T->row[i].state == EF_DRV_STOPPING; i++) {
        double v = tm_speed(T, i);
        mono &= v <= prev + 1e-3;
        prev = v;
    }
    printf("%s: controlled stop from %.1f mm/s over %zu periods, then state %d\n", what, v0,
           i - first, T->nrow ? T->row[T->nrow - 1].state : -1);
    EF_CHECK(mono);
    EF_CHECK(T->nrow > 0 && T->row[T->nrow - 1].state == want_state);
    if (T->nrow > 1)
        EF_CHECK(tm_speed(T, T->nrow - 1) < 1e-3);
}

/* ------------------------------------------------------------------ streaming */

/* Stream a sample program through the library call the CLI uses. */
static int tm_stream(const char *url, const char *prog, int mode, ef_mb_stream_result_t *res,
                     ef_msg_t *m, int fault_reset)
{
    static ef_gcode_t r;
    char path[512];
    snprintf(path, sizeof path, "%s/samples/%s", src_dir, prog);
    ef_mb_stream_cfg_t c;
    ef_mb_stream_cfg_default(&c, &ef_tbl_g2_default, &ef_tbl_g1_default);
    c.mode = mode;
    c.direct_hz = 100;
    c.fault_reset = fault_reset;
    c.mb.timeout_s = 0.1;
    c.on_move = tm_on_move;
    c.user = &ref;
    if (ef_mb_url_parse(url, &c.mb, m) != EF_OK)
        return EF_ERR_ARG;
    ref.n = 0;
    if (ef_gcode_open(&r, path, m) != EF_OK)
        return EF_ERR_IO;
    int rc = ef_mb_stream(&r, &c, res, m);
    ef_gcode_free(&r);
    printf("  stream rc %d (%s): %u segments, %llu transactions, %llu retries, %llu timeouts, "
           "%llu reconnects, drive executed %u, duplicates %u, refused %u%s%s\n",
           rc, ef_err_str(rc), res->moves, (unsigned long long)res->io.transactions,
           (unsigned long long)res->io.retries, (unsigned long long)res->io.timeouts,
           (unsigned long long)res->io.reconnects, res->last.done_count, res->last.duplicates,
           res->last.rejected, rc ? ": " : "", rc ? m->text : "");
    return rc;
}

/* Run one TCP case: a fresh drive with the given fault options, the standard path. */
static int tm_tcp_case(const char *name, const char *extra, ef_mb_stream_result_t *res, ef_msg_t *m,
                       tm_trace_t *T, tm_proc_t *keep)
{
    tm_proc_t d;
    int port;
    char trace[512], url[64];
    snprintf(trace, sizeof trace, "%s/modbus-%s.csv", work_dir, name);
    if (tm_drive(&d, "--tcp", "127.0.0.1:0", trace, extra, &port) != 0) {
        EF_CHECK(!"drive started");
        return -1000;
    }
    snprintf(url, sizeof url, "tcp://127.0.0.1:%d", port);
    printf("%s: drive on %s%s%s\n", name, url, extra ? ", " : "", extra ? extra : "");
    ref.port = port;
    ref.last_port = port;
    ref.drive = &d;
    int rc = tm_stream(url, "profile.ngc", EF_MB_MODE_SEGMENT, res, m, 0);
    ref.port = 0;
    if (keep)
        *keep = d;
    else
        EF_CHECK_EQ(tm_stop(&d, SIGTERM), 0);
    tm_trace_load(trace, T);
    return rc;
}

/* The standard path over TCP, with a second client reading status meanwhile. */
static void test_tcp(void)
{
    ef_mb_stream_result_t res;
    ef_msg_t m = {{0}};
    tm_trace_t T;
    int rc = tm_tcp_case("tcp", NULL, &res, &m, &T, NULL);
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK(ref.n > 100);
    EF_CHECK_EQ(res.moves, ref.n);
    EF_CHECK_EQ(res.last.done_count, ref.n);
    EF_CHECK_EQ(res.last.duplicates, 0);
    EF_CHECK_EQ(res.last.rejected, 0);
    EF_CHECK_EQ(res.last.state, EF_DRV_DISABLED);
    tm_check_trace("tcp", &T, ref.n);
    /* Ends at rest where the last segment ends. */
    const ef_move_t *last = &ref.mv[ref.n - 1];
    const tm_row_t *lr = &T.row[T.nrow - 1];
    EF_CHECK_NEAR(lr->cmd[0], last->b[last->degree].x, 1e-3);
    EF_CHECK_NEAR(lr->cmd[1], last->b[last->degree].y, 1e-3);
    EF_CHECK_NEAR(lr->cmd[2], last->b[last->degree].z, 1e-3);
    printf("tcp: second client: %d status reads, %d saw RUNNING\n", ref.monitor_reads,
           ref.monitor_running);
    EF_CHECK(ref.monitor_reads >= 5);
    EF_CHECK(ref.monitor_running >= 1);
    free(T.row);
}

/* The standard path over RTU on a pseudo-terminal pair, and a dropped reply there. */
static void test_rtu(void)
{
    for (int variant = 0; variant < 2; variant++) {
        tm_proc_t s, d;
        char a[64], b[64];
        if (tm_socat(&s, a, b) != 0) {
            EF_CHECK(!"socat pty pair");
            return;
        }
        const char *name = variant ? "rtu-drop" : "rtu";
        char trace[512], addr[128], url[160];
        snprintf(trace, sizeof trace, "%s/modbus-%s.csv", work_dir, name);
        snprintf(addr, sizeof addr, "%s,115200,8E1", a);
        /* Real time over RTU: a loaded 2-core CI machine running the master, socat and the
         * drive (all under sanitizers) must still keep the ring fed. */
        tm_time_scale = "1";
        int started = tm_drive(&d, "--rtu", addr, trace,
                               variant ? "--slave 7 --drop-reply-at 40" : "--slave 7", NULL);
        tm_time_scale = "2";
        if (started != 0) {
            EF_CHECK(!"rtu drive started");
            tm_stop(&s, SIGTERM);
            return;
        }
        snprintf(url, sizeof url, "rtu:%s,115200,8E1", b);
        printf("%s: drive on %s, master on %s\n", name, a, b);
        ef_mb_stream_result_t res;
        ef_msg_t m = {{0}};
        /* slave 7 on both ends */
        static ef_gcode_t r;
        char path[512];
        snprintf(path, sizeof path, "%s/samples/profile.ngc", src_dir);
        ef_mb_stream_cfg_t c;
        ef_mb_stream_cfg_default(&c, &ef_tbl_g2_default, &ef_tbl_g1_default);
        c.mode = EF_MB_MODE_SEGMENT;
        c.mb.timeout_s = 0.3;
        c.on_move = tm_on_move;
        c.user = &ref;
        EF_CHECK_EQ(ef_mb_url_parse(url, &c.mb, &m), EF_OK);
        c.mb.slave = 7;
        ref.n = 0;
        EF_CHECK_EQ(ef_gcode_open(&r, path, &m), EF_OK);
        int rc = ef_mb_stream(&r, &c, &res, &m);
        ef_gcode_free(&r);
        if (rc)
            fprintf(stderr, "%s: %s\n", name, m.text);
        EF_CHECK_EQ(rc, EF_OK);
        EF_CHECK_EQ(res.last.done_count, ref.n);
        EF_CHECK_EQ(tm_stop(&d, SIGTERM), 0);
        tm_stop(&s, SIGTERM);
        tm_trace_t T;
        tm_trace_load(trace, &T);
        tm_check_trace(name, &T, ref.n);
        printf("%s: %u segments, %llu transactions, %llu retries, %llu timeouts, duplicates "
               "acknowledged %u\n",
               name, res.moves, (unsigned long long)res.io.transactions,
               (unsigned long long)res.io.retries, (unsigned long long)res.io.timeouts,
               res.last.duplicates);
        if (variant) {
            EF_CHECK_EQ(T.dropped_lines, 1);
            EF_CHECK(res.io.timeouts >= 1);
            EF_CHECK(res.last.duplicates >= 1);
        }
        free(T.row);
    }
}

/* Faults: each ends in a clean resume (no segment lost or repeated) or a detected,
 * controlled stop. */
static void test_faults(void)
{
    ef_mb_stream_result_t res;
    ef_msg_t m = {{0}};
    tm_trace_t T;
    int rc;

    /* A lost reply: the master times out and writes again; the drive acknowledges the
     * duplicate without executing it twice. */
    rc = tm_tcp_case("drop", "--drop-reply-at 30", &res, &m, &T, NULL);
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(T.dropped_lines, 1);
    EF_CHECK(res.io.timeouts >= 1 && res.io.retries >= 1);
    EF_CHECK(res.last.duplicates >= 1);
    EF_CHECK_EQ(res.last.done_count, ref.n);
    tm_check_trace("drop", &T, ref.n);
    free(T.row);

    /* The drive drops the connection right after executing a write: reconnect, resume. */
    rc = tm_tcp_case("disconnect", "--disconnect-at 50", &res, &m, &T, NULL);
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(T.disconnect_lines, 1);
    EF_CHECK(res.io.reconnects >= 1);
    EF_CHECK_EQ(res.last.done_count, ref.n);
    tm_check_trace("disconnect", &T, ref.n);
    free(T.row);

    /* BUSY (exception 6) is flow control: wait and write again. */
    rc = tm_tcp_case("busy", "--exception-at 20:6", &res, &m, &T, NULL);
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK_EQ(T.exception_lines, 1);
    EF_CHECK_EQ(res.last.done_count, ref.n);
    tm_check_trace("busy", &T, ref.n);
    free(T.row);

    /* Server device failure (exception 4) to a slot write: a controlled stop, reported
     * with the exception and the segment. */
    rc = tm_tcp_case("exception", "--exception-at 60:4", &res, &m, &T, NULL);
    EF_CHECK_EQ(rc, EF_ERR_PROTO);
    EF_CHECK(strstr(m.text, "exception 4 (server device failure)") != NULL);
    EF_CHECK(strstr(m.text, "segment 60") != NULL);
    tm_check_trace("exception", &T, 60);
    tm_check_controlled_stop("exception", &T, EF_DRV_DISABLED);
    free(T.row);

    /* A drive fault mid-path: detected, reported with its code; the drive stopped under
     * control and stays in FAULT. A second stream refuses to enable it; one with an
     * explicit fault reset runs the whole path. */
    tm_proc_t d;
    rc = tm_tcp_case("fault", "--fault-at 1.5", &res, &m, &T, &d);
    EF_CHECK_EQ(rc, EF_ERR_DRIVE);
    EF_CHECK(strstr(m.text, "drive fault 4") != NULL);
    EF_CHECK_EQ(T.fault_lines, 1);
    EF_CHECK(T.nacc > 0 && T.nacc < ref.n);
    tm_check_trace("fault", &T, (uint32_t)T.nacc);
    tm_check_controlled_stop("fault", &T, EF_DRV_FAULT);
    free(T.row);
    /* Same drive, still faulted. */
    char url[64];
    snprintf(url, sizeof url, "tcp://127.0.0.1:%d", ref.last_port);
    rc = tm_stream(url, "profile.ngc", EF_MB_MODE_SEGMENT, &res, &m, 0);
    EF_CHECK_EQ(rc, EF_ERR_DRIVE);
    EF_CHECK(strstr(m.text, "not enabling") != NULL);
    EF_CHECK_EQ(res.moves, 0);
    /* Reset on request: the drive enables, but it stopped part-way along the path, so the
     * program (which starts at the origin) is refused before any segment is sent. */
    rc = tm_stream(url, "profile.ngc", EF_MB_MODE_SEGMENT, &res, &m, 1);
    EF_CHECK_EQ(rc, EF_ERR_ARG);
    EF_CHECK(strstr(m.text, "but the drive is at") != NULL);
    EF_CHECK_EQ(res.moves, 0);
    EF_CHECK_EQ(res.last.fault, 0);
    EF_CHECK_EQ(tm_stop(&d, SIGTERM), 0);

    /* The drive restarts (killed, started again on the same port) mid-path: the master
     * notices the new session and stops with an error. */
    ref.kill_at = 40;
    rc = tm_tcp_case("restart", NULL, &res, &m, &T, &d);
    ref.kill_at = 0;
    EF_CHECK(ref.restarted);
    EF_CHECK_EQ(rc, EF_ERR_DRIVE);
    EF_CHECK(strstr(m.text, "restarted") != NULL);
    EF_CHECK(res.moves <= 40);
    /* The new drive was never enabled by anyone: the master sent it nothing. */
    {
        modbus_t *ctx = modbus_new_tcp("127.0.0.1", ref.last_port);
        uint16_t r[0x40];
        EF_CHECK(ctx && modbus_connect(ctx) == 0);
        EF_CHECK_EQ(modbus_read_registers(ctx, 0, 0x40, r), 0x40);
        EF_CHECK_EQ(r[EF_MB_REG_STATE], EF_DRV_DISABLED);
        EF_CHECK_EQ(r[EF_MB_REG_CONTROL], 0);
        EF_CHECK_EQ(ef_mb_get_u32(r + EF_MB_REG_NEXT_SEQ), 0);
        modbus_close(ctx);
        modbus_free(ctx);
    }
    EF_CHECK_EQ(tm_stop(&d, SIGTERM), 0);
    free(T.row);
}

/* A line from 0 to x1 along X, 0.1 s at 10 units/s, ending at rest (a slot's content). */
static ef_move_t tm_line_move(float x1)
{
    ef_move_t m;
    memset(&m, 0, sizeof m);
    m.degree = 1;
    m.b[1].x = x1;
    m.length = 1.0f;
    m.duration = 0.1f;
    m.law.dt[0] = 0.1f;
    m.law.c[0][1] = 10.0f;
    m.flags = EF_MOVE_STOP_END;
    return m;
}

/* Bad requests from a raw client get exceptions, never a crash; the drive still answers. */
static void test_bad(void)
{
    tm_proc_t d;
    int port;
    if (tm_drive(&d, "--tcp", "127.0.0.1:0", NULL, NULL, &port) != 0) {
        EF_CHECK(!"drive started");
        return;
    }
    modbus_t *ctx = modbus_new_tcp("127.0.0.1", port);
    EF_CHECK(ctx && modbus_connect(ctx) == 0);
    modbus_set_response_timeout(ctx, 1, 0);
    uint16_t r[EF_MB_SLOT_WORDS];
    uint8_t bits[8];
    /* Out of the map. */
    EF_CHECK_EQ(modbus_read_registers(ctx, EF_MB_REGS - 2, 4, r), -1);
    EF_CHECK_EQ(errno, EMBXILADD);
    EF_CHECK_EQ(modbus_write_register(ctx, 0xFFF0, 1), -1);
    EF_CHECK_EQ(errno, EMBXILADD);
    /* Read-only status. */
    EF_CHECK_EQ(modbus_write_register(ctx, EF_MB_REG_STATE, 2), -1);
    EF_CHECK_EQ(errno, EMBXILADD);
    /* Coils are not part of the map. */
    EF_CHECK_EQ(modbus_read_bits(ctx, 0, 8, bits), -1);
    EF_CHECK_EQ(errno, EMBXILFUN);
    /* Enable, then a partial slot, a corrupt slot, a slot in the wrong place. */
    EF_CHECK_EQ(modbus_write_register(ctx, EF_MB_REG_CONTROL, EF_MB_CTL_CLEAR | EF_MB_CTL_ENABLE),
                1);
    ef_move_t mv = tm_line_move(1.0f);
    EF_CHECK_EQ(ef_mb_slot_encode(&mv, r), EF_OK);
    EF_CHECK_EQ(modbus_write_registers(ctx, EF_MB_REG_SLOT0, 10, r), -1);
    EF_CHECK_EQ(errno, EMBXILADD);
    r[EF_MB_SLOT_POINTS + 3] ^= 0x0100; /* flip a bit of b[1].x */
    EF_CHECK_EQ(modbus_write_registers(ctx, EF_MB_REG_SLOT0, EF_MB_SLOT_WORDS, r), -1);
    EF_CHECK_EQ(errno, EMBXILVAL);
    r[EF_MB_SLOT_POINTS + 3] ^= 0x0100;
    EF_CHECK_EQ(
        modbus_write_registers(ctx, EF_MB_REG_SLOT0 + EF_MB_SLOT_WORDS, EF_MB_SLOT_WORDS, r), -1);
    EF_CHECK_EQ(errno, EMBXILVAL);
    /* A bad mode value, unknown control bits. */
    EF_CHECK_EQ(modbus_write_register(ctx, EF_MB_REG_MODE, 9), -1);
    EF_CHECK_EQ(errno, EMBXILVAL);
    EF_CHECK_EQ(modbus_write_register(ctx, EF_MB_REG_CONTROL, 0x8000), -1);
    EF_CHECK_EQ(errno, EMBXILVAL);
    /* Garbage on the socket: the drive drops that client, not itself. */
    int fd = modbus_get_socket(ctx);
    const uint8_t junk[] = {0x00, 0x01, 0x00, 0x00, 0x00, 0x02, 0x01, 0x63};
    EF_CHECK_EQ(write(fd, junk, sizeof junk), (ssize_t)sizeof junk);
    usleep(1000);
    modbus_close(ctx);
    EF_CHECK_EQ(modbus_connect(ctx), 0);
    /* The valid slot is accepted; the drive counted every refused write. */
    EF_CHECK_EQ(modbus_write_registers(ctx, EF_MB_REG_SLOT0, EF_MB_SLOT_WORDS, r),
                EF_MB_SLOT_WORDS);
    EF_CHECK_EQ(modbus_read_registers(ctx, 0, 0x40, r), 0x40);
    EF_CHECK_EQ(r[EF_MB_REG_MAGIC], EF_MB_MAGIC);
    EF_CHECK_EQ(ef_mb_get_u32(r + EF_MB_REG_NEXT_SEQ), 1);
    printf("bad: refused writes counted by the drive: %u\n", r[EF_MB_REG_REJECTED]);
    EF_CHECK(r[EF_MB_REG_REJECTED] >= 6);
    modbus_close(ctx);
    modbus_free(ctx);
    EF_CHECK_EQ(tm_stop(&d, SIGTERM), 0);

    /* A master refuses what is not an evenfeed drive or cannot be reached. */
    ef_mb_cfg_t c;
    ef_mb_master_t *ms = NULL;
    ef_msg_t m = {{0}};
    ef_mb_cfg_default(&c);
    EF_CHECK_EQ(ef_mb_url_parse("tcp://127.0.0.1", &c, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mb_url_parse("rtu:/dev/x,115200,9Z1", &c, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mb_url_parse("udp://x:1", &c, &m), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mb_url_parse("tcp://127.0.0.1:1", &c, &m), EF_OK);
    c.reconnect_s = 0.1;
    EF_CHECK_EQ(ef_mb_open(&c, &ms, &m), EF_ERR_DISCONNECT);
    EF_CHECK(strstr(m.text, "cannot connect") != NULL);
    EF_CHECK(ms == NULL);
}

/* Direct mode: plain target positions at 100 Hz; the drive's profile follows them to the
 * end of the path. */
static void test_direct(void)
{
    tm_proc_t d;
    int port;
    char url[64], trace[512];
    snprintf(trace, sizeof trace, "%s/modbus-direct.csv", work_dir);
    if (tm_drive(&d, "--tcp", "127.0.0.1:0", trace, NULL, &port) != 0) {
        EF_CHECK(!"drive started");
        return;
    }
    snprintf(url, sizeof url, "tcp://127.0.0.1:%d", port);
    ef_mb_stream_result_t res;
    ef_msg_t m = {{0}};
    int rc = tm_stream(url, "profile.ngc", EF_MB_MODE_DIRECT, &res, &m, 0);
    EF_CHECK_EQ(rc, EF_OK);
    EF_CHECK(res.targets > 500);
    const ef_move_t *last = &ref.mv[ref.n - 1];
    EF_CHECK_NEAR(res.last.act[0], last->b[last->degree].x, 0.01);
    EF_CHECK_NEAR(res.last.act[1], last->b[last->degree].y, 0.01);
    EF_CHECK_NEAR(res.last.act[2], last->b[last->degree].z, 0.01);
    EF_CHECK_EQ(tm_stop(&d, SIGTERM), 0);
}

/* ------------------------------------------------------------------ several drives */

/* The single-axis slot codec, bit for bit; the X Y Z codec unchanged (a known slot). */
static void test_codec(void)
{
    /* The X Y Z slot of a fixed move: its CRC and the hash of its 117 words as the map
     * version 1 codec made them before single-axis drives existed (same numbers). */
    ef_move_t mv;
    memset(&mv, 0, sizeof mv);
    mv.seq = 37;
    mv.degree = 5;
    mv.flags = EF_MOVE_STOP_END;
    mv.duration = 0.125f;
    mv.length = 3.5f;
    for (int k = 0; k < 7; k++) {
        mv.law.dt[k] = k == 6 ? 0.0f : 0.01f * (float)(k + 1);
        for (int i = 0; i < 4; i++)
            mv.law.c[k][i] = k == 6 ? 0.0f : 0.1f * (float)(k + 1) - 0.03f * (float)i;
    }
    for (int i = 0; i < 6; i++)
        mv.b[i] = ef_v3(1.5f * (float)i + 100.0f, -12.25f + (float)i, 0.5f * (float)i);
    uint16_t w[EF_MB_SLOT_WORDS], w1[EF_MB_SLOT1_WORDS];
    EF_CHECK_EQ(ef_mb_slot_encode(&mv, w), EF_OK);
    uint32_t h = 0;
    for (int i = 0; i < EF_MB_SLOT_WORDS; i++)
        h = h * 31u + w[i];
    printf("codec: X Y Z slot CRC 0x%04X, word hash 0x%08X (want 0xEC36, 0x727B386D)\n",
           w[EF_MB_SLOT_CRC], h);
    EF_CHECK_EQ(w[EF_MB_SLOT_CRC], 0xEC36);
    EF_CHECK_EQ(h, 0x727B386Du);
    EF_CHECK_EQ(w[EF_MB_SLOT_POINTS + 2], 0xC144); /* b[0].y = -12.25f: 0xC1440000 */
    EF_CHECK_EQ(w[EF_MB_SLOT_POINTS + 3], 0x0000);
    EF_CHECK_EQ(ef_mb_slot_words(3), EF_MB_SLOT_WORDS);
    EF_CHECK_EQ(ef_mb_slot_words(1), EF_MB_SLOT1_WORDS);
    EF_CHECK_EQ(ef_mb_slot_words(2), 0u);

    /* Single-axis: words 0..79 equal the X Y Z slot's, then b[i].x, then the CRC. */
    EF_CHECK_EQ(ef_mb_slot_encode_axes(&mv, 1, w1), EF_OK);
    int same = 1;
    for (int i = 0; i < EF_MB_SLOT_POINTS; i++)
        same &= w1[i] == w[i];
    for (int i = 0; i < 6; i++) {
        same &= w1[EF_MB_SLOT_POINTS + 2 * i] == w[EF_MB_SLOT_POINTS + 6 * i];
        same &= w1[EF_MB_SLOT_POINTS + 2 * i + 1] == w[EF_MB_SLOT_POINTS + 6 * i + 1];
    }
    EF_CHECK(same);
    EF_CHECK_EQ(w1[EF_MB_SLOT1_CRC], ef_mb_crc_words(w1, EF_MB_SLOT1_CRC));
    /* Round trip bit for bit, on random moves of every degree. */
    uint32_t seed = 12345u, bad = 0;
    for (int t = 0; t < 300; t++) {
        ef_move_t a, b;
        memset(&a, 0, sizeof a);
        a.seq = (uint32_t)t * 977u;
        a.degree = (uint8_t)(t % 3 == 0 ? 1 : t % 3 == 1 ? 3 : 5);
        a.flags = t & 1 ? EF_MOVE_STOP_END : 0u;
        float r[64];
        for (int i = 0; i < 64; i++) {
            seed = seed * 1664525u + 1013904223u;
            r[i] = (float)((int32_t)seed) * 1e-6f;
        }
        a.duration = 0.001f + fabsf(r[0]) * 1e-3f;
        a.length = fabsf(r[1]);
        a.v_exit = fabsf(r[2]);
        for (int k = 0; k < 7; k++) {
            a.law.dt[k] = fabsf(r[3 + k]);
            for (int i = 0; i < 4; i++)
                a.law.c[k][i] = r[10 + 4 * k + i];
        }
        for (int i = 0; i <= a.degree; i++)
            a.b[i] = ef_v3(r[40 + i], 0.0f, 0.0f);
        EF_CHECK_EQ(ef_mb_slot_encode_axes(&a, 1, w1), EF_OK);
        EF_CHECK_EQ(ef_mb_slot_decode_axes(w1, 1, &b), EF_OK);
        bad += a.seq != b.seq || a.degree != b.degree || a.flags != b.flags ||
               memcmp(&a.duration, &b.duration, 4) || memcmp(&a.length, &b.length, 4) ||
               memcmp(&a.v_exit, &b.v_exit, 4) || memcmp(&a.law, &b.law, sizeof a.law) ||
               memcmp(a.b, b.b, sizeof a.b);
    }
    printf("codec: 300 single-axis slots round trip, %u differ\n", bad);
    EF_CHECK_EQ(bad, 0u);
    /* Refusals: a flipped bit (CRC), NaN (encode, and decode behind a good CRC), axes 2. */
    ef_move_t out;
    EF_CHECK_EQ(ef_mb_slot_encode_axes(&mv, 1, w1), EF_OK);
    w1[EF_MB_SLOT_POINTS + 5] ^= 0x0004;
    EF_CHECK_EQ(ef_mb_slot_decode_axes(w1, 1, &out), EF_ERR_CRC);
    ef_move_t nan = mv;
    nan.b[2].x = NAN;
    EF_CHECK_EQ(ef_mb_slot_encode_axes(&nan, 1, w1), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_mb_slot_encode_axes(&mv, 1, w1), EF_OK);
    ef_mb_put_f32(&w1[EF_MB_SLOT_POINTS + 4], NAN);
    w1[EF_MB_SLOT1_CRC] = ef_mb_crc_words(w1, EF_MB_SLOT1_CRC);
    EF_CHECK_EQ(ef_mb_slot_decode_axes(w1, 1, &out), EF_ERR_NONFINITE);
    EF_CHECK_EQ(ef_mb_slot_encode_axes(&mv, 2, w1), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mb_slot_decode_axes(w1, 2, &out), EF_ERR_ARG);

    /* The single-axis register device: identification, ring addresses, slot checks. */
    static ef_mbdev_t dev;
    ef_servo_cfg_t sc;
    ef_servo_cfg_default(&sc);
    uint8_t exc;
    EF_CHECK_EQ(ef_mbdev_init_axes(&dev, &sc, ef_v3(0, 1, 0), 1000, 5, 1), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mbdev_init_axes(&dev, &sc, ef_v3(0, 0, 0), 1000, 5, 2), EF_ERR_ARG);
    EF_CHECK_EQ(ef_mbdev_init_axes(&dev, &sc, ef_v3(0, 0, 0), 1000, 5, 1), EF_OK);
    uint16_t id[8];
    EF_CHECK_EQ(ef_mbdev_read(&dev, 0, 7, id, &exc), EF_OK);
    EF_CHECK_EQ(id[EF_MB_REG_AXES], 1);
    EF_CHECK_EQ(id[EF_MB_REG_SLOT_WORDS], EF_MB_SLOT1_WORDS);
    EF_CHECK_EQ(id[EF_MB_REG_VERSION], EF_MB_MAP_VERSION);
    EF_CHECK_EQ(ef_mbdev_regs(&dev), 0x0100u + EF_DRIVE_SLOTS * 93u);
    EF_CHECK_EQ(ef_mbdev_read(&dev, (uint16_t)(ef_mbdev_regs(&dev) - 1), 2, id, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    uint16_t cw = EF_MB_CTL_CLEAR | EF_MB_CTL_ENABLE;
    EF_CHECK_EQ(ef_mbdev_write(&dev, EF_MB_REG_CONTROL, 1, &cw, &exc), EF_OK);
    ef_move_t ln = tm_line_move(2.0f);
    ln.seq = 1; /* into slot 0: the wrong slot */
    EF_CHECK_EQ(ef_mb_slot_encode_axes(&ln, 1, w1), EF_OK);
    EF_CHECK_EQ(ef_mbdev_write(&dev, EF_MB_REG_SLOT0, EF_MB_SLOT1_WORDS, w1, &exc), EF_ERR_SEQ);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_VALUE);
    ln.seq = 0;
    EF_CHECK_EQ(ef_mb_slot_encode_axes(&ln, 1, w1), EF_OK);
    /* A 117-word X Y Z slot is not a slot of this drive. */
    EF_CHECK_EQ(ef_mb_slot_encode(&ln, w), EF_OK);
    EF_CHECK_EQ(ef_mbdev_write(&dev, EF_MB_REG_SLOT0, EF_MB_SLOT_WORDS, w, &exc), EF_ERR_ARG);
    EF_CHECK_EQ(exc, EF_MB_EX_ILLEGAL_ADDRESS);
    EF_CHECK_EQ(ef_mbdev_write(&dev, EF_MB_REG_SLOT0, EF_MB_SLOT1_WORDS, w1, &exc), EF_OK);
    ln.seq = 1;
    ln.b[0].x = 2.0f;
    ln.b[1].x = 0.5f;
    EF_CHECK_EQ(ef_mb_slot_encode_axes(&ln, 1, w1), EF_OK);
    EF_CHECK_EQ(
        ef_mbdev_write(&dev, EF_MB_REG_SLOT0 + EF_MB_SLOT1_WORDS, EF_MB_SLOT1_WORDS, w1, &exc),
        EF_OK);
    uint16_t back[EF_MB_SLOT1_WORDS];
    EF_CHECK_EQ(
        ef_mbdev_read(&dev, EF_MB_REG_SLOT0 + EF_MB_SLOT1_WORDS, EF_MB_SLOT1_WORDS, back, &exc),
        EF_OK);
    EF_CHECK(memcmp(back, w1, sizeof back) == 0);
    /* Run it: the axis goes 0 -> 2 -> 0.5 on the drive's x, y and z stay 0. */
    cw = EF_MB_CTL_ENABLE | EF_MB_CTL_START;
    EF_CHECK_EQ(ef_mbdev_write(&dev, EF_MB_REG_CONTROL, 1, &cw, &exc), EF_OK);
    float xmax = 0.0f;
    for (int i = 0; i < 400; i++) {
        ef_mbdev_process(&dev, 1000, NULL);
        xmax = fmaxf(xmax, dev.drv.cmd.x);
    }
    printf("codec: single-axis device ran to %.4f (peak %.4f), y %.1f z %.1f, %u executed\n",
           (double)dev.drv.cmd.x, (double)xmax, (double)dev.drv.cmd.y, (double)dev.drv.cmd.z,
           dev.drv.done_any);
    EF_CHECK_NEAR(dev.drv.cmd.x, 0.5, 1e-6);
    EF_CHECK_NEAR(xmax, 2.0, 1e-6);
    EF_CHECK(dev.drv.cmd.y == 0.0f && dev.drv.cmd.z == 0.0f);
    EF_CHECK_EQ(dev.drv.done_any, 2u);
}

/* The program of the axes parts: X Y Z with A and B together, corners blended (A B change
 * their rates at the vertices), an arc, a rapid; it ends away from the origin. */
static const char tm_axes_prog[] = "G21 G90 G64 P0.05\n"
                                   "G1 F1500 X10 Y0 A10 B-5\n"
                                   "G1 X20 Y10 Z-1 A25 B0\n"
                                   "G1 X30 Y10 A30 B5\n"
                                   "G2 X40 Y0 I0 J-10 A40\n"
                                   "G1 X40 Y-10 Z0 A45 B10\n"
                                   "G1 X30 Y-12 A40 B12\n"
                                   "G1 X20 Y-10 A30 B8\n"
                                   "G0 X5 Y5 Z0 A15 B-10\n"
                                   "M2\n";
/** Where each axis ends: x y z a b. */
static const double tm_axes_end[5] = {5, 5, 0, 15, -10};

/* A long program for the fault parts: 120 moves zigzagging with A and B. */
static void tm_write_long_prog(const char *path)
{
    FILE *f = fopen(path, "w");
    fprintf(f, "G21 G90 G64 P0.05\nF3000\n");
    for (int i = 1; i <= 120; i++)
        fprintf(f, "G1 X%d Y%d A%d B%d\n", i, (i % 2) * 5, (i % 4) * 10, -(i % 3) * 5);
    fprintf(f, "M2\n");
    fclose(f);
}

/* Three drives on free ports: xyz, a, b; extra options per drive (NULL: none). */
typedef struct {
    tm_proc_t p[3];
    int port[3];
    char trace[3][512];
} tm_trio_t;

static int tm_trio_start(tm_trio_t *T, const char *name, const char *extra[3])
{
    static const char *const ax[3] = {"--axes 3", "--axes 1", "--axes 1"};
    for (int k = 0; k < 3; k++) {
        char opts[256];
        snprintf(T->trace[k], sizeof T->trace[k], "%s/modbus-%s-%d.csv", work_dir, name, k + 1);
        snprintf(opts, sizeof opts, "%s%s%s", ax[k], extra && extra[k] ? " " : "",
                 extra && extra[k] ? extra[k] : "");
        if (tm_drive(&T->p[k], "--tcp", "127.0.0.1:0", T->trace[k], opts, &T->port[k]) != 0) {
            EF_CHECK(!"drive started");
            for (int j = 0; j < k; j++)
                tm_stop(&T->p[j], SIGTERM);
            return -1;
        }
    }
    return 0;
}

/* Run `evenfeed stream` with the three drives and extra arguments; stdout and stderr into
 * out; the exit status. */
static int tm_cli_stream(const tm_trio_t *T, const char *args, const char *prog, char *out,
                         size_t n)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd,
             "'%s' stream --modbus tcp://127.0.0.1:%d=xyz --modbus tcp://127.0.0.1:%d=a "
             "--modbus tcp://127.0.0.1:%d=b %s '%s' 2>&1",
             evenfeed_bin, T->port[0], T->port[1], T->port[2], args, prog);
    FILE *p = popen(cmd, "r");
    size_t k = 0;
    if (!p)
        return -1;
    while (k + 1 < n && fgets(out + k, (int)(n - k), p))
        k += strlen(out + k);
    out[k] = 0;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* Write the X Y Z A B test program into the work directory; its path into prog. */
static void tm_axes_prog_write(char *prog, size_t n)
{
    snprintf(prog, n, "%s/modbus-axes.ngc", work_dir);
    FILE *f = fopen(prog, "w");
    EF_CHECK(f != NULL);
    if (!f)
        return;
    fputs(tm_axes_prog, f);
    fclose(f);
}

/* One XYZ drive and single-axis A and B drives (three sim-drive processes): the program
 * streamed with `evenfeed stream`; every drive executes every segment in order and ends at
 * its axis's programmed end, within its following-error limit. */
static void test_axes(void)
{
    char prog[512], out[8192];
    tm_axes_prog_write(prog, sizeof prog);
    tm_trio_t T;
    if (tm_trio_start(&T, "axes", NULL) != 0)
        return;
    /* Skew bound 60 ms: a 2x drive clock on a loaded machine under sanitizers; the figure
     * printed is what the drives showed. */
    int rc = tm_cli_stream(&T, "--skew-ms 60", prog, out, sizeof out);
    printf("axes: evenfeed stream exit %d:\n%s", rc, out);
    EF_CHECK_EQ(rc, 0);
    unsigned nseg = 0;
    EF_CHECK(sscanf(out, "stream: %u segments to 3 drives", &nseg) == 1);
    EF_CHECK(nseg >= 8);
    for (int k = 0; k < 3; k++)
        EF_CHECK_EQ(tm_stop(&T.p[k], SIGTERM), 0);
    static const char *const nm[3] = {"xyz", "a", "b"};
    const double lo[3] = {0, 0, -10}, hi[3] = {0, 45, 12}; /* the axis's programmed range */
    for (int k = 0; k < 3; k++) {
        tm_trace_t tr;
        EF_CHECK_EQ(tm_trace_load(T.trace[k], &tr), 0);
        int order = tr.nacc == nseg;
        for (size_t i = 0; i < tr.nacc && i < TM_MAX_MOVES; i++)
            order &= tr.acc[i] == (long)i;
        double fe = 0, xmin = 1e9, xmax = -1e9;
        for (size_t i = 0; i < tr.nrow; i++) {
            fe = fmax(fe, tr.row[i].ferr);
            xmin = fmin(xmin, tr.row[i].cmd[0]);
            xmax = fmax(xmax, tr.row[i].cmd[0]);
        }
        const tm_row_t *lr = tr.nrow ? &tr.row[tr.nrow - 1] : NULL;
        printf("axes: drive %s: %zu segments accepted in order: %s, %zu periods, ends at "
               "(%.4f %.4f %.4f), x range %.3f..%.3f, following error max %.4f (limit 1)\n",
               nm[k], tr.nacc, order ? "yes" : "NO", tr.nrow, lr ? lr->cmd[0] : 0.0,
               lr ? lr->cmd[1] : 0.0, lr ? lr->cmd[2] : 0.0, xmin, xmax, fe);
        EF_CHECK(order);
        EF_CHECK(lr != NULL);
        EF_CHECK(fe < 1.0);
        if (lr && k == 0) {
            for (int a = 0; a < 3; a++)
                EF_CHECK_NEAR(lr->cmd[a], tm_axes_end[a], 1e-3);
        } else if (lr) {
            EF_CHECK_NEAR(lr->cmd[0], tm_axes_end[2 + k], 1e-3);
            EF_CHECK(lr->cmd[1] == 0.0 && lr->cmd[2] == 0.0);
            EF_CHECK(xmin >= lo[k] - 0.05 && xmax <= hi[k] + 0.05); /* within the program's */
            EF_CHECK(xmax >= hi[k] - 1.0);                          /* and it got there */
        }
        free(tr.row);
    }
}

/* Kill a drive (SIGKILL, no restart) when the master is about to send move `at`. */
typedef struct {
    tm_proc_t *victim;
    uint32_t at, n;
} tm_kill_t;

static int tm_kill_on_move(void *user, const ef_move_t *mv)
{
    (void)mv;
    tm_kill_t *K = user;
    if (++K->n == K->at)
        tm_stop(K->victim, SIGKILL);
    return 0;
}

/* Several drives fail: a fault on one, one killed, clocks apart. Every drive stops; the
 * error names the drive. */
static void test_axesfault(void)
{
    char prog[512], out[8192];
    snprintf(prog, sizeof prog, "%s/modbus-axes-long.ngc", work_dir);
    tm_write_long_prog(prog);

    /* 1. The B drive faults 1.5 s (drive time) into the run. */
    const char *fault_b[3] = {NULL, NULL, "--fault-at 1.5"};
    tm_trio_t T;
    if (tm_trio_start(&T, "axesfault", fault_b) != 0)
        return;
    int rc = tm_cli_stream(&T, "--skew-ms 60", prog, out, sizeof out);
    printf("axesfault: fault on b: exit %d:\n%s", rc, out);
    EF_CHECK_EQ(rc, 44);
    EF_CHECK(strstr(out, "drive 3 (tcp://127.0.0.1:") != NULL);
    EF_CHECK(strstr(out, ", b): drive fault 4") != NULL);
    for (int k = 0; k < 3; k++) {
        /* Every drive's own word: at rest, not RUNNING. */
        modbus_t *ctx = modbus_new_tcp("127.0.0.1", T.port[k]);
        uint16_t r[0x40];
        EF_CHECK(ctx && modbus_connect(ctx) == 0);
        EF_CHECK_EQ(modbus_read_registers(ctx, 0, 0x40, r), 0x40);
        printf("axesfault: drive %d: state %u, status 0x%02x, fault %u, %u executed\n", k + 1,
               r[EF_MB_REG_STATE], r[EF_MB_REG_STATUS], r[EF_MB_REG_FAULT],
               ef_mb_get_u32(r + EF_MB_REG_DONE_COUNT));
        EF_CHECK(r[EF_MB_REG_STATE] != EF_DRV_RUNNING);
        EF_CHECK(!(r[EF_MB_REG_STATUS] & (EF_MB_ST_MOVING | EF_MB_ST_STOPPING)));
        EF_CHECK_EQ(r[EF_MB_REG_STATE], k == 2 ? EF_DRV_FAULT : EF_DRV_DISABLED);
        modbus_close(ctx);
        modbus_free(ctx);
        EF_CHECK_EQ(tm_stop(&T.p[k], SIGTERM), 0);
        tm_trace_t tr;
        tm_trace_load(T.trace[k], &tr);
        char what[64];
        snprintf(what, sizeof what, "axesfault drive %d", k + 1);
        tm_check_controlled_stop(what, &tr, k == 2 ? EF_DRV_FAULT : EF_DRV_DISABLED);
        free(tr.row);
    }

    /* 2. The B drive's clock runs 25 % fast: the executed times part; every drive stops. */
    const char *fast_b[3] = {NULL, NULL, "--time-scale 2.5"};
    if (tm_trio_start(&T, "axesskew", fast_b) != 0)
        return;
    rc = tm_cli_stream(&T, "", prog, out, sizeof out);
    printf("axesfault: b's clock 25 %% fast: exit %d:\n%s", rc, out);
    EF_CHECK_EQ(rc, 44);
    EF_CHECK(strstr(out, "drive 3 (tcp://127.0.0.1:") != NULL);
    EF_CHECK(strstr(out, "above the bound of 20 ms") != NULL);
    for (int k = 0; k < 3; k++) {
        EF_CHECK_EQ(tm_stop(&T.p[k], SIGTERM), 0);
        tm_trace_t tr;
        tm_trace_load(T.trace[k], &tr);
        EF_CHECK(tr.nrow > 0 && tr.row[tr.nrow - 1].state == EF_DRV_DISABLED);
        free(tr.row);
    }

    /* 3. The A drive is killed mid-stream (library call: the kill comes from the move
     * callback, after the start): the stream stops with an error naming it. */
    if (tm_trio_start(&T, "axeskill", NULL) != 0)
        return;
    static ef_gcode_t r;
    ef_msg_t m = {{0}};
    ef_mb_stream_cfg_t c;
    ef_mb_stream_cfg_default(&c, &ef_tbl_g2_default, &ef_tbl_g1_default);
    c.n_drives = 3;
    c.skew_max_s = 0.06;
    for (int k = 0; k < 3; k++) {
        char url[64];
        c.drives[k] = c.mb;
        c.drives[k].timeout_s = 0.1;
        c.drives[k].reconnect_s = 0.3;
        c.drives[k].axis = k == 0 ? EF_MB_AXIS_XYZ : 3 + k;
        snprintf(url, sizeof url, "tcp://127.0.0.1:%d", T.port[k]);
        EF_CHECK_EQ(ef_mb_url_parse(url, &c.drives[k], &m), EF_OK);
    }
    tm_kill_t kill = {&T.p[1], 40, 0};
    c.on_move = tm_kill_on_move;
    c.user = &kill;
    EF_CHECK_EQ(ef_gcode_open(&r, prog, &m), EF_OK);
    ef_mb_stream_result_t res;
    rc = ef_mb_stream(&r, &c, &res, &m);
    ef_gcode_free(&r);
    printf("axesfault: a killed after 40 moves: rc %d (%s): %s; %u moves sent\n", rc,
           ef_err_str(rc), m.text, res.moves);
    EF_CHECK(rc == EF_ERR_DISCONNECT || rc == EF_ERR_TIMEOUT);
    EF_CHECK(strstr(m.text, "drive 2 (tcp://127.0.0.1:") != NULL);
    EF_CHECK_EQ(res.failed_drive, 1);
    for (int k = 0; k < 3; k += 2) {
        printf("axesfault: drive %d after the kill: state %u, status 0x%02x, fault %u\n", k + 1,
               res.drive[k].state, res.drive[k].status, res.drive[k].fault);
        EF_CHECK(res.drive[k].state != EF_DRV_RUNNING);
        EF_CHECK(!(res.drive[k].status & (EF_MB_ST_MOVING | EF_MB_ST_STOPPING)));
        EF_CHECK_EQ(tm_stop(&T.p[k], SIGTERM), 0);
    }
}

/* Refusals before any motion: an axis no drive carries (at its line, nothing sent), an
 * axis carried twice, X Y Z not all carried, a gap in A B C, an unknown axis letter, a
 * single-axis drive listed as X Y Z. */
static void test_axesbad(void)
{
    char prog[512], out[8192];
    tm_axes_prog_write(prog, sizeof prog);
    tm_trio_t T;
    if (tm_trio_start(&T, "axesbad", NULL) != 0)
        return;
    char cmd[2048];
    /* Drives for X Y Z and A only: the program moves B on line 2 (its first move). */
    snprintf(cmd, sizeof cmd,
             "'%s' stream --modbus tcp://127.0.0.1:%d=xyz --modbus tcp://127.0.0.1:%d=a '%s' "
             "2>&1",
             evenfeed_bin, T.port[0], T.port[1], prog);
    FILE *p = popen(cmd, "r");
    size_t k = 0;
    while (p && k + 1 < sizeof out && fgets(out + k, (int)(sizeof out - k), p))
        k += strlen(out + k);
    out[k] = 0;
    int st = p ? pclose(p) : -1;
    printf("axesbad: B with no drive: exit %d: %s", WEXITSTATUS(st), out);
    EF_CHECK_EQ(WEXITSTATUS(st), 1);
    EF_CHECK(strstr(out, "modbus-axes.ngc:2: axis B moves") != NULL);
    EF_CHECK(strstr(out, "stream: 0 segments to 2 drives") != NULL);
    for (int d = 0; d < 2; d++) {
        modbus_t *ctx = modbus_new_tcp("127.0.0.1", T.port[d]);
        uint16_t r[0x40];
        EF_CHECK(ctx && modbus_connect(ctx) == 0);
        EF_CHECK_EQ(modbus_read_registers(ctx, 0, 0x40, r), 0x40);
        EF_CHECK_EQ(ef_mb_get_u32(r + EF_MB_REG_NEXT_SEQ), 0); /* no segment reached it */
        EF_CHECK_EQ(r[EF_MB_REG_STATE], EF_DRV_DISABLED);
        modbus_close(ctx);
        modbus_free(ctx);
    }
    /* The list refused before any drive is contacted (port 1: nothing listens there). */
    static const struct {
        const char *args, *want;
    } cases[] = {
        {"--modbus tcp://127.0.0.1:1=xyz --modbus tcp://127.0.0.1:2=x",
         "axis X is carried by drive 1 \\(tcp://127.0.0.1:1, xyz\\) and drive 2"},
        {"--modbus tcp://127.0.0.1:1=xyz --modbus tcp://127.0.0.1:2=a --modbus "
         "tcp://127.0.0.1:3=a",
         "axis A is carried by drive 2"},
        {"--modbus tcp://127.0.0.1:1=x --modbus tcp://127.0.0.1:2=y", "no drive carries Z"},
        {"--modbus tcp://127.0.0.1:1=xyz --modbus tcp://127.0.0.1:2=b",
         "carries B but no drive carries A"},
        {"--modbus tcp://127.0.0.1:1=xyz --modbus tcp://127.0.0.1:2=q", "axis .q. unknown"},
        {"--modbus tcp://127.0.0.1:1=xyz --modbus tcp://127.0.0.1:2", "each says what it carries"},
        {"--modbus tcp://127.0.0.1:1=xyz --modbus tcp://127.0.0.1:1=a", "are the same drive"},
        {"--modbus tcp://127.0.0.1:1=xyz --modbus tcp://127.0.0.1:2=a --mode direct",
         "direct mode streams to one X Y Z drive only"},
        {"--modbus tcp://127.0.0.1:1=xyz --modbus tcp://127.0.0.1:2=a --axes 6",
         "--axes 6 with Modbus drives carrying 4 axes"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        snprintf(cmd, sizeof cmd, "'%s' stream %s '%s' 2>&1 | grep -qE -- '%s'", evenfeed_bin,
                 cases[i].args, prog, cases[i].want);
        int s2 = system(cmd);
        snprintf(cmd, sizeof cmd, "'%s' stream %s '%s' >/dev/null 2>&1", evenfeed_bin,
                 cases[i].args, prog);
        int s3 = system(cmd);
        if (s2 != 0 || WEXITSTATUS(s3) != 1)
            fprintf(stderr, "axesbad: '%s': want /%s/ and exit 1, got exit %d\n", cases[i].args,
                    cases[i].want, WEXITSTATUS(s3));
        EF_CHECK_EQ(s2, 0);
        EF_CHECK_EQ(WEXITSTATUS(s3), 1);
    }
    /* A single-axis drive listed as the X Y Z drive, and the other way round. */
    snprintf(cmd, sizeof cmd,
             "'%s' stream --modbus tcp://127.0.0.1:%d=xyz --modbus tcp://127.0.0.1:%d=a '%s' "
             "2>&1 | grep -q 'carries 1 axis per slot but is listed for xyz'",
             evenfeed_bin, T.port[1], T.port[2], prog);
    EF_CHECK_EQ(system(cmd), 0);
    snprintf(cmd, sizeof cmd,
             "'%s' stream --modbus tcp://127.0.0.1:%d '%s' 2>&1 | grep -q 'carries 1 axis per "
             "slot but is listed for xyz'",
             evenfeed_bin, T.port[1], prog);
    EF_CHECK_EQ(system(cmd), 0);
    for (int d = 0; d < 3; d++)
        EF_CHECK_EQ(tm_stop(&T.p[d], SIGTERM), 0);
    printf("axesbad: %zu drive-list refusals checked\n", sizeof cases / sizeof cases[0]);
}

/* Two drives on two RTU lines (socat pseudo-terminal pairs): an X Y Z drive at unit 3 and a
 * single-axis A drive at unit 4; the axes program streamed through the library call. */
static void test_axesrtu(void)
{
    char prog[512];
    snprintf(prog, sizeof prog, "%s/modbus-axesrtu.ngc", work_dir);
    FILE *f = fopen(prog, "w");
    fputs("G21 G90 G64 P0.05\nG1 F1500 X10 Y0 A10\nG1 X20 Y10 Z-1 A25\nG1 X30 Y10 A30\n"
          "G0 X5 Y5 Z0 A15\nM2\n",
          f);
    fclose(f);
    tm_proc_t s[2], d[2];
    char a[2][64], b[2][64], trace[2][512];
    int up = 0;
    for (int k = 0; k < 2; k++) {
        char addr[128], opts[64];
        if (tm_socat(&s[k], a[k], b[k]) != 0)
            break;
        snprintf(addr, sizeof addr, "%s,115200,8N1", a[k]);
        snprintf(trace[k], sizeof trace[k], "%s/modbus-axesrtu-%d.csv", work_dir, k + 1);
        snprintf(opts, sizeof opts, "--axes %d --slave %d", k ? 1 : 3, 3 + k);
        if (tm_drive(&d[k], "--rtu", addr, trace[k], opts, NULL) != 0) {
            tm_stop(&s[k], SIGTERM);
            break;
        }
        up++;
    }
    EF_CHECK_EQ(up, 2);
    if (up == 2) {
        static ef_gcode_t r;
        ef_msg_t m = {{0}};
        ef_mb_stream_cfg_t c;
        ef_mb_stream_cfg_default(&c, &ef_tbl_g2_default, &ef_tbl_g1_default);
        c.n_drives = 2;
        c.skew_max_s = 0.06; /* real time over two ptys on a loaded machine */
        for (int k = 0; k < 2; k++) {
            char url[160];
            c.drives[k] = c.mb;
            c.drives[k].timeout_s = 0.3;
            snprintf(url, sizeof url, "rtu:%s,115200,8N1", b[k]);
            EF_CHECK_EQ(ef_mb_url_parse(url, &c.drives[k], &m), EF_OK);
            c.drives[k].slave = 3 + k;
            c.drives[k].axis = k ? 4 : EF_MB_AXIS_XYZ;
        }
        ef_mb_stream_result_t res;
        EF_CHECK_EQ(ef_gcode_open(&r, prog, &m), EF_OK);
        int rc = ef_mb_stream(&r, &c, &res, &m);
        ef_gcode_free(&r);
        printf("axesrtu: rc %d%s%s: %u segments, drives executed %u and %u, skew max %.0f ms over "
               "%u rounds\n",
               rc, rc ? ": " : "", rc ? m.text : "", res.moves, res.drive[0].done_count,
               res.drive[1].done_count, res.skew_max_s * 1e3, res.skew_checks);
        EF_CHECK_EQ(rc, EF_OK);
        EF_CHECK(res.moves >= 4);
        EF_CHECK_EQ(res.drive[0].done_count, res.moves);
        EF_CHECK_EQ(res.drive[1].done_count, res.moves);
        EF_CHECK_NEAR(res.drive[0].cmd[0], 5.0, 1e-3);
        EF_CHECK_NEAR(res.drive[0].cmd[1], 5.0, 1e-3);
        EF_CHECK_NEAR(res.drive[1].cmd[0], 15.0, 1e-3);
        EF_CHECK(res.drive[1].cmd[1] == 0.0f && res.drive[1].cmd[2] == 0.0f);
    }
    for (int k = 0; k < up; k++) {
        EF_CHECK_EQ(tm_stop(&d[k], SIGTERM), 0);
        tm_stop(&s[k], SIGTERM);
    }
}

int main(int argc, char **argv)
{
    if (argc < 4) {
        fprintf(stderr,
                "usage: test_modbus EVENFEED SOURCE_DIR WORK_DIR [tcp|rtu|faults|bad|direct|codec|"
                "axes|axesfault|axesbad|axesrtu]...\n");
        return 2;
    }
    evenfeed_bin = argv[1];
    tm_evenfeed = evenfeed_bin;
    tm_time_scale = "2"; /* drive clock 2x: fast, with margin for a loaded machine */
    src_dir = argv[2];
    work_dir = argv[3];
    signal(SIGPIPE, SIG_IGN);
    static const ef_test_part_t parts[] = {
        {"bad", test_bad},         {"tcp", test_tcp},
        {"rtu", test_rtu},         {"faults", test_faults},
        {"direct", test_direct},   {"codec", test_codec},
        {"axes", test_axes},       {"axesfault", test_axesfault},
        {"axesbad", test_axesbad}, {"axesrtu", test_axesrtu},
    };
    return EF_TEST_RUN(argc, argv, 4, parts);
}
