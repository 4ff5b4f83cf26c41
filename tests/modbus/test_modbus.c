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
 * usage: test_modbus EVENFEED SOURCE_DIR WORK_DIR [tcp|rtu|faults|bad|direct]...
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
    ef_move_t mv;
    memset(&mv, 0, sizeof mv);
    mv.degree = 1;
    mv.b[1].x = 1.0f;
    mv.length = 1.0f;
    mv.duration = 0.1f;
    mv.law.dt[0] = 0.1f;
    mv.law.c[0][1] = 10.0f;
    mv.flags = EF_MOVE_STOP_END;
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

int main(int argc, char **argv)
{
    if (argc < 4) {
        fprintf(stderr,
                "usage: test_modbus EVENFEED SOURCE_DIR WORK_DIR [tcp|rtu|faults|bad|direct]...\n");
        return 2;
    }
    evenfeed_bin = argv[1];
    tm_evenfeed = evenfeed_bin;
    tm_time_scale = "2"; /* drive clock 2x: fast, with margin for a loaded machine */
    src_dir = argv[2];
    work_dir = argv[3];
    signal(SIGPIPE, SIG_IGN);
    static const ef_test_part_t parts[] = {
        {"bad", test_bad},       {"tcp", test_tcp},       {"rtu", test_rtu},
        {"faults", test_faults}, {"direct", test_direct},
    };
    return EF_TEST_RUN(argc, argv, 4, parts);
}
