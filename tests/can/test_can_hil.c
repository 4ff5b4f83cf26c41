/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Hardware-in-loop CAN tests, run INSIDE a User-Mode Linux guest on a real kernel vcan bus
 * (tests/hil/uml_run.sh boots the guest; tests/hil/can.sh runs this program there).
 *
 * Each part starts three simulated CiA 402 drives (`evenfeed sim-drive can`, each waited for
 * by its "ready" line, stopped by its PID), streams the standard path with `evenfeed stream
 * --can` as a separate process, and then checks from the files they wrote:
 *  - every drive reached OPERATION ENABLED (drive traces);
 *  - the executed path, from the actual positions the drives reported in their TPDOs (the
 *    streamer's trace), lies within HIL_PATH_TOL of the commanded path (the same program
 *    smoothed here with the same defaults), and ends at the program's end;
 *  - segment mode: every segment accepted by every drive exactly once and in order;
 *  - the following error of every drive stays within HIL_FERR_TOL;
 *  - the SYNC period's jitter is reported;
 *  - the candump log exists and can-utils' log2asc reads it.
 * Fault parts check the error message names the node and cause, and that every axis came
 * to rest under control (no step in the commanded speed beyond the stop ramp).
 *
 * Usage: test_can_hil EVENFEED SRC_DIR OUT_DIR PART
 *   PART: csp | segment | drop | emcy | heartbeat | busoff | boot | start | masterdeath
 *         io_estop | io_start | io_alarm | io_pump | io_hold | io_hold_seg | io_outputs |
 *         io_modbus | io_modbus_hold | io_modbus_hold_direct | io_gpioerr | io_sto |
 *         io_modbus_sto (machine I/O on
 * a gpio-sim chip that tests/hil/can.sh makes: EF_GSIM_CHIP, EF_GSIM_SYS) |
 *         gsusb_csp | gsusb_segment | gsusb_unplug | gsusb_bitrate | gsusb_claimed |
 *         gsusb_faults | gsusb_bench (the same drives reached through a simulated USB-CAN adapter,
 * `evenfeed sim-adapter gsusb`, a FunctionFS gadget on dummy_hcd bridged to vcan0, which
 * the part starts itself)
 */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "ef_proc.h"
#include "ef_test.h"
#include "evenfeed/canopen/ef_canopen.h"
#include "evenfeed/drive/ef_drive.h"
#include "evenfeed/host/can/ef_canload.h"
#include "evenfeed/host/can/ef_gsusb.h"
#include "evenfeed/host/program/ef_gcode.h"
#include "evenfeed/host/program/ef_pipeline.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

/** Distance (mm) allowed between an executed point (three axes' actual positions at one
 *  SYNC) and the commanded path: the servo model's lag shows across the path only on
 *  curves, where it is a small fraction of the following error (TM_FERR_TOL), plus the
 *  0.1 um position increments. */
#define HIL_PATH_TOL 0.05
/** Following error (mm) of the default servo model on the standard path (the Modbus drive,
 *  which runs the same model, measures 0.045 mm). */
#define HIL_FERR_TOL 0.06
/** Where the path must end (mm). */
#define HIL_END_TOL 0.01
/** Modbus direct mode: the drive's profile between 50 Hz targets (mm). */
#define HIL_DIRECT_PATH_TOL 0.2
/** Heartbeat consumer time (ms) of the streamer: an emulated kernel on a loaded 2-core
 *  machine can hold a process back for a few hundred ms (SYNC gaps of 180 ms were seen; with
 *  ctest running other tests beside the guest, a drive silent for 1 s once), so the 200 ms
 *  default would report healthy drives as lost; 5 s since a CI-like run saw 2 s. */
#define HIL_HB_TIMEOUT "5000"
/** SYNC-loss watchdog of the drives (ms, 0x2003): a loaded host can hold the whole guest
 *  back (seen: 0.5 s while ctest ran other tests beside it, over 2 s on CI), which the
 *  500 ms default would take for a dead master: every drive faults, and a test that checks
 *  a whole path fails for a reason no real bus has. masterdeath still sees the master die. */
#define HIL_SYNC_TIMEOUT "5000"
/** Fault injection time used by the fault parts (ms of drive time in OPERATION ENABLED):
 *  on the standard path x and y are then both moving at 20 mm/s, on an arc. */
#define HIL_FAULT_MS "5000"

static const char *g_ef, *g_src, *g_out;
/* What `stream --can` is given: vcan0, or a USB adapter ("gsusb:SERIAL") in the gsusb_* parts,
 * and options every stream of the part gets (the gsusb_* parts' SYNC period). */
static const char *g_can = "vcan0", *g_can_extra = "";
/* The program of part_stream() and the gsusb_* parts (NULL: samples/profile.ngc). */
static const char *g_prog;
/* The following-error limit allows one commanded step per SYNC more (CSP at a long cycle). */
static int g_ferr_steps;

/* ------------------------------------------------------------------ reference path */

/* The commanded path: the program smoothed with the streamer's defaults, its moves and its
 * setpoints every 1 ms (ef_canload_path(), as the bus-load benchmark takes them). */
static ef_canload_path_t g_ref;

/* Room for element n of a growing array (capacity doubling); exits on no memory, which a
 * test cannot go on from. */
static void *hil_grow(void *arr, size_t *cap, size_t n, size_t elem)
{
    if (n < *cap)
        return arr;
    *cap = *cap ? 2 * *cap : 4096;
    void *a = realloc(arr, *cap * elem);
    if (!a) {
        fprintf(stderr, "test_can_hil: out of memory\n");
        exit(1);
    }
    return a;
}

/* Smooth the program with the streamer's defaults; setpoints every 1 ms. */
static int hil_reference(const char *prog)
{
    ef_gcode_t r;
    ef_msg_t m = {{0}};
    if (ef_gcode_open(&r, prog, &m) != EF_OK) {
        fprintf(stderr, "%s\n", m.text);
        return -1;
    }
    ef_pipe_cfg_t pc;
    ef_pipe_cfg_default(&pc);
    pc.g2 = &ef_tbl_g2_default;
    pc.g1 = &ef_tbl_g1_default;
    pc.step_mode = EF_STEP_CORRECTED;
    int rc = ef_canload_path(&r, &pc, &g_ref, &m);
    ef_gcode_free(&r);
    if (rc != EF_OK) {
        fprintf(stderr, "reference: %s\n", m.text);
        return -1;
    }
    return 0;
}

/* Distance from q to the segment a-b. */
static double hil_seg_dist(const double *q, const float *a, const float *b)
{
    double ab[3], aq[3], L2 = 0, t = 0;
    for (int i = 0; i < 3; i++) {
        ab[i] = b[i] - a[i];
        aq[i] = q[i] - a[i];
        L2 += ab[i] * ab[i];
        t += ab[i] * aq[i];
    }
    t = L2 > 0 ? fmax(0.0, fmin(1.0, t / L2)) : 0.0;
    double d2 = 0;
    for (int i = 0; i < 3; i++) {
        double e = aq[i] - t * ab[i];
        d2 += e * e;
    }
    return sqrt(d2);
}

/* Distance from q to the reference polyline, searching near the cursor (executed points
 * advance along the path), widening to the whole path when nothing near is close. */
static double hil_path_dist(const double *q, size_t *cursor)
{
    size_t n = g_ref.nsp;
    if (n < 2)
        return INFINITY;
    size_t lo = *cursor > 200 ? *cursor - 200 : 0,
           hi = *cursor + 4000 < n - 1 ? *cursor + 4000 : n - 1;
    double best = INFINITY;
    size_t at = *cursor;
    for (int pass = 0; pass < 2; pass++) {
        for (size_t k = lo; k < hi; k++) {
            double d = hil_seg_dist(q, g_ref.sp + 3 * k, g_ref.sp + 3 * (k + 1));
            if (d < best) {
                best = d;
                at = k;
            }
        }
        if (best <= HIL_PATH_TOL)
            break;
        lo = 0;
        hi = n - 1;
    }
    *cursor = at;
    return best;
}

/* ------------------------------------------------------------------ processes */

/* A whole file as a string (NULL if unreadable). */
static char *hil_slurp(const char *path)
{
    size_t n = 0;
    return ef_t_slurp(path, &n);
}

/* Print what a command run as NAME wrote (OUT/NAME.out, then OUT/NAME.err) under a title. */
static void hil_print_outputs(const char *title, const char *name, int rc)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s.out", g_out, name);
    char *o = hil_slurp(path);
    snprintf(path, sizeof path, "%s/%s.err", g_out, name);
    char *e = hil_slurp(path);
    printf("--- %s, exit %d\n%s%s", title, rc, o ? o : "", e ? e : "");
    free(o);
    free(e);
}

/* Start drive `node` with its trace and extra options; wait for "ready". */
static int hil_drive(tm_proc_t *p, int node, const char *extra)
{
    char nodes[16], trace[512];
    snprintf(nodes, sizeof nodes, "%d", node);
    snprintf(trace, sizeof trace, "%s/drive%d.csv", g_out, node);
    char *argv[24];
    int n = 0;
    argv[n++] = (char *)g_ef;
    argv[n++] = "sim-drive";
    argv[n++] = "can";
    argv[n++] = "--iface";
    argv[n++] = "vcan0";
    argv[n++] = "--node";
    argv[n++] = nodes;
    argv[n++] = "--trace";
    argv[n++] = trace;
    argv[n++] = "--sync-timeout";
    argv[n++] = HIL_SYNC_TIMEOUT;
    static char words[8][64];
    char tmp[256];
    if (extra) {
        snprintf(tmp, sizeof tmp, "%s", extra);
        int w = 0;
        for (char *t = strtok(tmp, " "); t && w < 8; t = strtok(NULL, " "))
            snprintf(words[w], sizeof words[w], "%s", t), argv[n++] = words[w++];
    }
    argv[n] = NULL;
    if (tm_spawn(argv, 0, p) != 0)
        return -1;
    char line[256];
    if (tm_line(p->out, line, sizeof line, 20000) != 0 || strncmp(line, "ready", 5) != 0) {
        fprintf(stderr, "drive %d did not become ready\n", node);
        tm_stop(p, SIGKILL);
        return -1;
    }
    return 0;
}

/* Run the streamer to completion; its stderr into OUT/NAME.err; exit status returned. */
static int hil_stream(const char *name, const char *mode, const char *nodes, const char *extra,
                      const char *prog)
{
    char cmd[2048];
    snprintf(
        cmd, sizeof cmd,
        "%s stream --can %s %s --nodes %s --mode %s --sdo-timeout 1000 --hb-timeout " HIL_HB_TIMEOUT
        " --log %s/%s.log --trace %s/%s.csv %s %s"
        " >%s/%s.out 2>%s/%s.err",
        g_ef, g_can, g_can_extra, nodes, mode, g_out, name, g_out, name, extra ? extra : "", prog,
        g_out, name, g_out, name);
    int st = system(cmd);
    int rc = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    char title[128];
    snprintf(title, sizeof title, "stream %s (%s)", name, mode);
    hil_print_outputs(title, name, rc);
    return rc;
}

/* ------------------------------------------------------------------ traces */

typedef struct {
    uint32_t sync;
    int power;
    unsigned sw;
    double cmd, act, ferr;
} hil_prow_t;

typedef struct {
    hil_prow_t *p;
    size_t np;
    long *seq;
    size_t ns;
    int emcy, emcy_code, reached_op;
    long overrun; /* frames its socket dropped (o line; -1: none written) */
} hil_dtrace_t;

/* Open OUT/NAME for reading and clear the trace it fills (NULL if it is not there). */
static FILE *hil_open_trace(const char *name, void *trace, size_t size)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", g_out, name);
    memset(trace, 0, size);
    return fopen(path, "r");
}

/* A drive trace, cleared, with no overrun count read yet. */
static FILE *hil_open_dtrace(const char *name, hil_dtrace_t *T)
{
    FILE *f = hil_open_trace(name, T, sizeof *T);
    T->overrun = -1;
    return f;
}

/* Parse a drive trace (p/s/e lines). */
static int hil_dtrace_load(int node, hil_dtrace_t *T)
{
    char name[32];
    snprintf(name, sizeof name, "drive%d.csv", node);
    FILE *f = hil_open_dtrace(name, T);
    if (!f)
        return -1;
    char line[512];
    size_t capp = 0, caps = 0;
    while (fgets(line, sizeof line, f)) {
        if (line[0] == 'p') {
            hil_prow_t r;
            if (sscanf(line, "p,%u,%u,%d,%lf,%lf,%lf", &r.sync, &r.sw, &r.power, &r.cmd, &r.act,
                       &r.ferr) != 6)
                continue;
            T->p = hil_grow(T->p, &capp, T->np, sizeof *T->p);
            T->p[T->np++] = r;
            T->reached_op |= r.power == EF_CO_PS_OP_ENABLED;
        } else if (line[0] == 's') {
            long s;
            if (sscanf(line, "s,%ld", &s) != 1)
                continue;
            T->seq = hil_grow(T->seq, &caps, T->ns, sizeof *T->seq);
            T->seq[T->ns++] = s;
        } else if (line[0] == 'o') {
            (void)sscanf(line, "o,%ld", &T->overrun);
        } else if (line[0] == 'e') {
            unsigned sy, code;
            if (sscanf(line, "e,%u,%x", &sy, &code) == 2 ||
                sscanf(line, "e,%u,%u", &sy, &code) == 2) {
                if (code != 0) {
                    T->emcy++;
                    T->emcy_code = (int)code;
                }
            }
        }
    }
    fclose(f);
    return 0;
}

static void hil_dtrace_free(hil_dtrace_t *T)
{
    free(T->p);
    free(T->seq);
}

typedef struct {
    double *a; /* SYNC-aligned executed points, 3 per row */
    size_t na;
    double *ty; /* SYNC send times (us) */
    size_t ny;
    size_t nm; /* segments pushed */
} hil_strace_t;

/* Parse the streamer's trace (y/a/t/m lines). */
static int hil_strace_load(const char *name, hil_strace_t *T)
{
    char file[256];
    snprintf(file, sizeof file, "%s.csv", name);
    FILE *f = hil_open_trace(file, T, sizeof *T);
    if (!f)
        return -1;
    char line[512];
    size_t capa = 0, capy = 0;
    while (fgets(line, sizeof line, f)) {
        if (line[0] == 'a') {
            unsigned sy;
            double x, y, z;
            int k = sscanf(line, "a,%u,%lf,%lf,%lf", &sy, &x, &y, &z);
            if (k < 2) /* the SYNC number and at least one axis (fewer nodes: fewer axes) */
                continue;
            if (k < 3)
                y = 0;
            if (k < 4)
                z = 0;
            T->a = hil_grow(T->a, &capa, T->na, 3 * sizeof(double));
            T->a[3 * T->na] = x;
            T->a[3 * T->na + 1] = y;
            T->a[3 * T->na + 2] = z;
            T->na++;
        } else if (line[0] == 'y') {
            unsigned sy;
            double t;
            if (sscanf(line, "y,%u,%lf", &sy, &t) != 2)
                continue;
            T->ty = hil_grow(T->ty, &capy, T->ny, sizeof(double));
            T->ty[T->ny++] = t;
        } else if (line[0] == 'm') {
            T->nm++;
        }
    }
    fclose(f);
    return 0;
}

static void hil_strace_free(hil_strace_t *T)
{
    free(T->a);
    free(T->ty);
}

/* SYNC period statistics (the jitter report). */
static void hil_jitter(const char *what, const hil_strace_t *T)
{
    if (T->ny < 3) {
        printf("%s: SYNC jitter: too few SYNCs (%zu)\n", what, T->ny);
        return;
    }
    double s = 0, s2 = 0, mn = INFINITY, mx = 0;
    size_t n = T->ny - 1;
    for (size_t i = 1; i < T->ny; i++) {
        double d = T->ty[i] - T->ty[i - 1];
        s += d;
        s2 += d * d;
        mn = fmin(mn, d);
        mx = fmax(mx, d);
    }
    double mean = s / (double)n, sd = sqrt(fmax(0.0, s2 / (double)n - mean * mean));
    printf("%s: SYNC period over %zu cycles: mean %.1f us, std %.1f us, min %.1f us, max %.1f us\n",
           what, n, mean, sd, mn, mx);
}

/* The candump log exists, every line has candump's form, and log2asc converts it. */
static void hil_check_log(const char *name)
{
    char path[512], cmd[1200];
    snprintf(path, sizeof path, "%s/%s.log", g_out, name);
    FILE *f = fopen(path, "r");
    EF_CHECK(f != NULL);
    if (!f)
        return;
    char line[256], ifname[32] = "vcan0"; /* the interface the log names (a USB adapter's) */
    long n = 0, bad = 0;
    while (fgets(line, sizeof line, f)) {
        double t;
        char ifn[32], frame[64];
        n++;
        if (sscanf(line, "(%lf) %31s %63s", &t, ifn, frame) != 3 || !strchr(frame, '#'))
            bad++;
        else if (n == 1)
            snprintf(ifname, sizeof ifname, "%s", ifn);
    }
    fclose(f);
    EF_CHECK(n > 100);
    EF_CHECK_EQ(bad, 0);
    snprintf(cmd, sizeof cmd, "log2asc -I %s %s > %s/%s.asc 2>&1", path, ifname, g_out, name);
    int st = system(cmd);
    EF_CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 0);
    printf("%s: candump log %ld frames, log2asc exit %d\n", name, n,
           WIFEXITED(st) ? WEXITSTATUS(st) : -1);
}

/* Executed path against the reference, rows [0, upto) (the rest, a stop after a fault, is
 * only reported: each drive ramps its own axis down, which leaves the path); returns the
 * largest distance. */
static double hil_check_path(const char *what, const hil_strace_t *S, int complete, size_t upto)
{
    size_t cursor = 0;
    double worst = 0, after = 0;
    size_t worst_i = 0;
    for (size_t i = 0; i < S->na; i++) {
        double d = hil_path_dist(S->a + 3 * i, &cursor);
        if (i >= upto) {
            after = fmax(after, d);
        } else if (d > worst) {
            worst = d;
            worst_i = i;
        }
    }
    if (upto < S->na)
        printf("%s: %zu points before the fault checked; during the stop the path was left by"
               " up to %.4f mm (axes ramp down independently)\n",
               what, upto, after);
    printf("%s: %zu executed points (TPDO), largest distance from the commanded path %.4f mm"
           " (row %zu; limit %.3f)\n",
           what, S->na, worst, worst_i, HIL_PATH_TOL);
    EF_CHECK(S->na > 100);
    EF_CHECK(worst <= HIL_PATH_TOL);
    if (complete && S->na > 0) {
        const double *e = S->a + 3 * (S->na - 1);
        double d = sqrt(pow(e[0] - g_ref.end[0], 2) + pow(e[1] - g_ref.end[1], 2) +
                        pow(e[2] - g_ref.end[2], 2));
        printf("%s: ends %.4f mm from the program's end\n", what, d);
        EF_CHECK(d <= HIL_END_TOL);
    }
    return worst;
}

/* Every drive reached OPERATION ENABLED and kept its following error within bounds;
 * segment mode: sequence numbers 0..n-1 each exactly once. */
static void hil_check_drives(const char *what, int nseg)
{
    for (int node = 1; node <= 3; node++) {
        hil_dtrace_t T;
        EF_CHECK_EQ(hil_dtrace_load(node, &T), 0);
        EF_CHECK(T.reached_op);
        /* CSP at a long cycle (g_ferr_steps): the target is a staircase, and at each SYNC the
         * servo is that SYNC's step behind on top of its own lag: each row's limit is
         * HIL_FERR_TOL plus its own step. */
        double fmax_ = 0, over = 0;
        for (size_t i = 0; i < T.np; i++) {
            fmax_ = fmax(fmax_, T.p[i].ferr);
            double step = g_ferr_steps && i > 0 ? fabs(T.p[i].cmd - T.p[i - 1].cmd) : 0.0;
            over = fmax(over, T.p[i].ferr - (HIL_FERR_TOL + step));
        }
        printf("%s: node %d: %zu SYNC steps, following error max %.4f mm (limit %.3f mm%s), %zu"
               " segments accepted, %ld frames dropped by its full receive queue\n",
               what, node, T.np, fmax_, HIL_FERR_TOL, g_ferr_steps ? " + the SYNC's step" : "",
               T.ns, T.overrun);
        EF_CHECK(over <= 0);
        /* A frame the kernel dropped from a held-back drive's receive queue may be a SYNC:
         * a step that drive did not take, and its axis out of step with the others. */
        EF_CHECK(T.overrun <= 0);
        if (nseg >= 0) {
            int inorder = T.ns == (size_t)nseg;
            for (size_t i = 0; i < T.ns && inorder; i++)
                inorder = T.seq[i] == (long)i;
            EF_CHECK(inorder);
            if (!inorder)
                fprintf(stderr, "node %d: %zu segments accepted, %d expected, not 0..n-1 once\n",
                        node, T.ns, nseg);
        }
        hil_dtrace_free(&T);
    }
}

/* The first SYNC at which any drive left OPERATION ENABLED (its fault reaction or the
 * master's quick stop), less 2 for the SYNC it took effect and one of margin: the executed
 * points before it must follow the path. */
static size_t hil_fault_row(void)
{
    uint32_t first = UINT32_MAX;
    for (int node = 1; node <= 3; node++) {
        hil_dtrace_t T;
        if (hil_dtrace_load(node, &T) != 0)
            continue;
        int was_op = 0;
        for (size_t i = 0; i < T.np; i++) {
            if (T.p[i].power == EF_CO_PS_OP_ENABLED)
                was_op = 1;
            else if (was_op) {
                if (T.p[i].sync < first)
                    first = T.p[i].sync;
                break;
            }
        }
        hil_dtrace_free(&T);
    }
    return first == UINT32_MAX ? (size_t)-1 : (first > 2 ? first - 2 : 0);
}

/* After a fault every drive is at rest, not enabled, and its command never stepped: the
 * commanded speed changes by at most what the stop ramp and the servo's limits allow. */
static void hil_check_stopped(const char *what, uint32_t cycle_us)
{
    ef_servo_cfg_t sc;
    ef_servo_cfg_default(&sc);
    double dt = cycle_us * 1e-6, amax = fmax(sc.a_lim, sc.a_stop) * 1.05;
    for (int node = 1; node <= 3; node++) {
        hil_dtrace_t T;
        EF_CHECK_EQ(hil_dtrace_load(node, &T), 0);
        EF_CHECK(T.np > 3);
        double worst_a = 0;
        for (size_t i = 2; i < T.np; i++) {
            double v1 = (T.p[i].cmd - T.p[i - 1].cmd) / dt,
                   v0 = (T.p[i - 1].cmd - T.p[i - 2].cmd) / dt;
            worst_a = fmax(worst_a, fabs(v1 - v0) / dt);
        }
        const hil_prow_t *last = T.np ? &T.p[T.np - 1] : NULL;
        /* At rest: the command stands still (the servo may still be settling within its
         * following error when the drive is disabled and SYNC stops, as a real motor would
         * settle in the brake's time). */
        int rest = last && T.np > 2 && fabs(T.p[T.np - 1].cmd - T.p[T.np - 2].cmd) < 1e-6 &&
                   fabs(last->act - last->cmd) <= HIL_FERR_TOL;
        printf("%s: node %d: largest commanded acceleration %.0f mm/s^2 (limit %.0f), final"
               " power state %d (%s), %s\n",
               what, node, worst_a, amax, last ? last->power : -1,
               last ? ef_co_power_str(last->power) : "-", rest ? "at rest" : "MOVING");
        EF_CHECK(worst_a <= amax);
        EF_CHECK(rest);
        EF_CHECK(last && last->power != EF_CO_PS_OP_ENABLED);
        hil_dtrace_free(&T);
    }
}

/* stderr of a stream run contains every needle. */
static int hil_err_has(const char *name, const char *a, const char *b)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s.err", g_out, name);
    char *e = hil_slurp(path);
    int ok = e && strstr(e, a) && (!b || strstr(e, b));
    if (!ok)
        fprintf(stderr, "%s: expected '%s'%s%s in the error output\n", name, a, b ? " and " : "",
                b ? b : "");
    free(e);
    return ok;
}

/* ------------------------------------------------------------------ parts */

typedef struct {
    const char *extra[4]; /* per node 1..3 (index 1..3) */
} hil_drives_t;

/* Start drives 1..3 with per-node extra options; 0 on success. */
static int hil_start(tm_proc_t d[4], const hil_drives_t *x)
{
    for (int n = 1; n <= 3; n++)
        if (hil_drive(&d[n], n, x ? x->extra[n] : NULL) != 0)
            return -1;
    return 0;
}

static void hil_stop(tm_proc_t d[4])
{
    for (int n = 1; n <= 3; n++)
        if (d[n].pid > 0)
            tm_stop(&d[n], SIGTERM);
}

/* A whole path in one mode, optionally with dropped chunks at node 2. */
static void part_stream(const char *mode, int drop)
{
    char prog[512];
    if (g_prog)
        snprintf(prog, sizeof prog, "%s", g_prog);
    else
        snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    EF_CHECK_EQ(hil_reference(prog), 0);
    tm_proc_t d[4] = {{0}};
    hil_drives_t x = {{NULL}};
    if (drop)
        x.extra[2] = "--drop-rx 5,40,41,300";
    /* EF_HIL_CHECK_ONLY: check the files of an earlier run (e.g. on the build host). */
    int rc = 0;
    if (!getenv("EF_HIL_CHECK_ONLY")) {
        if (hil_start(d, &x) != 0) {
            EF_CHECK(0);
            hil_stop(d);
            return;
        }
        rc = hil_stream("stream", mode, "1,2,3", NULL, prog);
        hil_stop(d);
    }
    EF_CHECK_EQ(rc, 0);
    hil_strace_t S;
    EF_CHECK_EQ(hil_strace_load("stream", &S), 0);
    hil_jitter(mode, &S);
    hil_check_path(mode, &S, 1, (size_t)-1);
    int seg = !strcmp(mode, "segment");
    /* Answers wait up to 1 s (4 tries): a loaded host once held the guest's drive back for
     * over 800 ms in direct mode, whose 50 Hz writes each need an answer. */
    if (seg) {
        printf("%s: %zu segments pushed, %u moves in the program\n", mode, S.nm,
               (unsigned)g_ref.nmv);
        EF_CHECK_EQ(S.nm, (unsigned)g_ref.nmv);
    }
    hil_check_drives(mode, seg ? (int)g_ref.nmv : -1);
    hil_check_log("stream");
    if (drop) {
        /* The dropped chunks were sent again: the summary counts go-back-N rounds, and the
         * drive's trace notes each frame it dropped. */
        char path[512];
        snprintf(path, sizeof path, "%s/stream.out", g_out);
        char *o = hil_slurp(path);
        const char *r = o ? strstr(o, " resends") : NULL;
        long n = 0;
        if (r) {
            const char *b = r;
            while (b > o && b[-1] >= '0' && b[-1] <= '9')
                b--;
            n = strtol(b, NULL, 10);
        }
        printf("drop: %ld go-back-N rounds\n", n);
        EF_CHECK(n >= 1);
        free(o);
        snprintf(path, sizeof path, "%s/drive2.csv", g_out);
        o = hil_slurp(path);
        int drops = 0;
        for (const char *q = o; q && (q = strstr(q, "drop")); q++)
            drops++;
        printf("drop: node 2 trace notes %d dropped frames\n", drops);
        EF_CHECK(drops >= 3);
        free(o);
    }
    hil_strace_free(&S);
}

/* A fault mid-path: the stream stops every axis under control and names the cause. */
static void part_fault(const char *kind)
{
    char prog[512];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    EF_CHECK_EQ(hil_reference(prog), 0);
    tm_proc_t d[4] = {{0}};
    hil_drives_t x = {{NULL}};
    const char *mode = "segment", *want1 = NULL, *want2 = NULL;
    uint32_t cycle = 10000;
    if (!strcmp(kind, "emcy")) {
        x.extra[2] = "--fault-at " HIL_FAULT_MS;
        want1 = "node 2";
        want2 = "EMCY";
    } else if (!strcmp(kind, "heartbeat")) {
        mode = "csp";
        cycle = 1000;
        x.extra[3] = "--hb-stop-at " HIL_FAULT_MS;
        want1 = "node 3";
        want2 = "heartbeat";
    } else {
        x.extra[1] = "--bus-off-at " HIL_FAULT_MS;
        want1 = "bus-off";
    }
    if (hil_start(d, &x) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return;
    }
    int rc = hil_stream("fault", mode, "1,2,3", NULL, prog);
    EF_CHECK(rc != 0);
    EF_CHECK(hil_err_has("fault", want1, want2));
    if (!strcmp(kind, "emcy")) {
        /* The drive stays in FAULT: a second stream must refuse it (never enable it) ... */
        int rc2 = hil_stream("again", mode, "1,2,3", NULL, prog);
        EF_CHECK(rc2 != 0);
        EF_CHECK(hil_err_has("again", "node 2", "fault"));
        /* ... and no ENABLE OPERATION (controlword 0x000F, low byte 0F) went to node 2. */
        char cmd[1024];
        snprintf(cmd, sizeof cmd, "grep -c ' 202#0F' %s/again.log > /dev/null", g_out);
        int st = system(cmd);
        EF_CHECK(WIFEXITED(st) && WEXITSTATUS(st) == 1); /* grep: no match */
    }
    hil_stop(d);
    hil_strace_t S;
    EF_CHECK_EQ(hil_strace_load("fault", &S), 0);
    hil_jitter(kind, &S);
    hil_check_path(kind, &S, 0, hil_fault_row());
    hil_check_stopped(kind, cycle);
    hil_check_log("fault");
    hil_strace_free(&S);
}

/* Drives that are not where the program starts: refused before any motion, naming both
 * positions; no drive's command moved. */
static void part_start(void)
{
    char prog[512];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    tm_proc_t d[4] = {{0}};
    hil_drives_t x = {{NULL}};
    x.extra[1] = "--home 5";
    if (hil_start(d, &x) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return;
    }
    int rc = hil_stream("start", "segment", "1,2,3", NULL, prog);
    hil_stop(d);
    EF_CHECK(rc != 0);
    EF_CHECK(hil_err_has("start", "the path starts at", "5.0000"));
    for (int node = 1; node <= 3; node++) {
        hil_dtrace_t T;
        EF_CHECK_EQ(hil_dtrace_load(node, &T), 0);
        double lo = INFINITY, hi = -INFINITY;
        for (size_t i = 0; i < T.np; i++) {
            lo = fmin(lo, T.p[i].cmd);
            hi = fmax(hi, T.p[i].cmd);
        }
        printf("start: node %d: %zu SYNC steps, command stayed within [%.6f, %.6f]\n", node, T.np,
               T.np ? lo : 0.0, T.np ? hi : 0.0);
        EF_CHECK(T.np == 0 || hi - lo < 1e-6);
        hil_dtrace_free(&T);
    }
}

/* Whether a drive's newest actual position (its trace, flushed every loop) is beyond x. */
static int hil_drive_passed(int node, double x)
{
    hil_dtrace_t T;
    if (hil_dtrace_load(node, &T) != 0)
        return 0;
    int yes = T.np > 0 && T.p[T.np - 1].act > x;
    hil_dtrace_free(&T);
    return yes;
}

/* Whether a drive trace has an EMCY with this code. */
static int hil_drive_emcy(int node, unsigned code)
{
    char path[512], want[32];
    snprintf(path, sizeof path, "%s/drive%d.csv", g_out, node);
    snprintf(want, sizeof want, ",0x%04X,", code);
    char *t = hil_slurp(path);
    int yes = t && strstr(t, want);
    free(t);
    return yes;
}

/* The master dies mid-path (SIGKILL: no stop frames): every drive detects the SYNC loss
 * (0x2003, HIL_SYNC_TIMEOUT), reports EMCY 0x8130 and stops under control on its own clock: the
 * moving axis runs on by about its stopping distance at the stop ramp, not 0 (a freeze) and
 * not more. */
static void part_masterdeath(void)
{
    char prog[512];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    tm_proc_t d[4] = {{0}};
    if (hil_start(d, NULL) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return;
    }
    char log[512], trace[512];
    snprintf(log, sizeof log, "%s/death.log", g_out);
    snprintf(trace, sizeof trace, "%s/death.csv", g_out);
    char *argv[] = {(char *)g_ef, "stream", "--can",   "vcan0", "--mode", "segment",
                    "--log",      log,      "--trace", trace,   prog,     NULL};
    tm_proc_t st;
    EF_CHECK_EQ(tm_spawn(argv, 1, &st), 0);
    /* Wait (bounded) until x is well into the straight cut at 20 mm/s (x 0 -> 60 mm). */
    int moving = 0;
    for (int i = 0; i < 600 && !moving; i++) {
        moving = hil_drive_passed(1, 20.0);
        if (!moving)
            usleep(50000);
    }
    EF_CHECK(moving);
    tm_stop(&st, SIGKILL);
    int all = 0;
    for (int i = 0; i < 200 && !all; i++) {
        all = hil_drive_emcy(1, 0x8130) && hil_drive_emcy(2, 0x8130) && hil_drive_emcy(3, 0x8130);
        if (!all)
            usleep(50000);
    }
    /* The stop ends by itself; give the drives' own clocks the stopping time. */
    for (int i = 0; i < 100; i++) {
        hil_dtrace_t T;
        int done = hil_dtrace_load(1, &T) == 0 && T.np > 0 && T.p[T.np - 1].power == EF_CO_PS_FAULT;
        hil_dtrace_free(&T);
        if (done)
            break;
        usleep(50000);
    }
    hil_stop(d);
    EF_CHECK(all);
    ef_servo_cfg_t sc;
    ef_servo_cfg_default(&sc);
    hil_dtrace_t T;
    EF_CHECK_EQ(hil_dtrace_load(1, &T), 0);
    /* Speed at the last SYNC (two rows with consecutive SYNC numbers), then the distance the
     * command travelled after it. */
    size_t last = 0;
    for (size_t i = 1; i < T.np; i++)
        if (T.p[i].sync == T.p[i - 1].sync + 1)
            last = i;
    double v = last ? (T.p[last].cmd - T.p[last - 1].cmd) / 0.010 : 0.0;
    double run = T.np ? T.p[T.np - 1].cmd - T.p[last].cmd : 0.0, stop = v * v / (2.0 * sc.a_stop);
    printf("masterdeath: x at %.3f mm/s when SYNC stopped; it ran on %.4f mm (stopping distance"
           " at %.0f mm/s^2: %.4f mm); final power state %d (%s)\n",
           v, run, sc.a_stop, stop, T.np ? T.p[T.np - 1].power : -1,
           T.np ? ef_co_power_str(T.p[T.np - 1].power) : "-");
    EF_CHECK(v > 10.0);
    EF_CHECK(run >= 0.5 * stop && run <= 1.5 * stop + 1e-3);
    EF_CHECK(T.np && T.p[T.np - 1].power == EF_CO_PS_FAULT);
    hil_dtrace_free(&T);
}

/* A node that never boots is named; nothing is enabled. */
static void part_boot(void)
{
    char prog[512];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    tm_proc_t d[4] = {{0}};
    if (hil_start(d, NULL) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return;
    }
    int rc = hil_stream("boot", "csp", "1,2,9", NULL, prog);
    hil_stop(d);
    EF_CHECK(rc != 0);
    EF_CHECK(hil_err_has("boot", "node 9", "boot"));
}

/* ------------------------------------------------------------------ machine I/O (gpio-sim) */

/* Lines of the guest's simulated chip "efio" (tests/hil/can.sh), by offset; the machine
 * file names them. */
enum {
    IO_ESTOP,
    IO_ENABLE,
    IO_ALARM,
    IO_PUMP,
    IO_HOLD,
    IO_START,
    IO_OUT0,
    IO_OUT1,
    IO_STO,
    IO_ALMOUT
};
/** SYNC period of the CSP machine I/O parts (us): 1 ms SYNC is beyond User-Mode Linux (the
 *  mean period comes out near 7 ms, and the drives step per SYNC: a 12 s path takes 90 s). */
#define IO_CSP_CYCLE "4000"
/** Exit status of a stream stopped by e-stop or an alarm (-EF_ERR_ESTOP). */
#define IO_EXIT_ESTOP 48
/** How far a program output may switch from its commanded point (mm): the axes stand there
 *  within the streamer's CS_OUT_TOL (5 um) when it switches, plus the sampling here. */
#define IO_OUT_TOL 0.05

static uint64_t io_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* A sysfs attribute of line k of the simulated chip. */
static void io_attr(char *buf, size_t n, int k, const char *attr)
{
    const char *sys = getenv("EF_GSIM_SYS");
    snprintf(buf, n, "%s/sim_gpio%d/%s", sys ? sys : "/nonexistent", k, attr);
}

/* Drive input k from the simulated outside: high (pull-up) or low (pull-down). */
static int io_pull(int k, int high)
{
    char path[512];
    io_attr(path, sizeof path, k, "pull");
    int fd = open(path, O_WRONLY);
    if (fd < 0)
        return -1;
    const char *v = high ? "pull-up" : "pull-down";
    ssize_t n = write(fd, v, strlen(v));
    close(fd);
    return n == (ssize_t)strlen(v) ? 0 : -1;
}

/* The level of line k now (0 or 1; -1: unreadable). */
static int io_level(int k)
{
    char path[512], c = 0;
    io_attr(path, sizeof path, k, "value");
    int fd = open(path, O_RDONLY);
    if (fd < 0)
        return -1;
    ssize_t n = read(fd, &c, 1);
    close(fd);
    return n == 1 && (c == '0' || c == '1') ? c - '0' : -1;
}

/* Level changes of line k over ms milliseconds; *last_ns: time of the last one (0: none). */
static int io_edges(int k, int ms, uint64_t *last_ns)
{
    uint64_t end = io_now_ns() + (uint64_t)ms * 1000000u;
    int prev = io_level(k), n = 0;
    if (last_ns)
        *last_ns = 0;
    while (io_now_ns() < end) {
        int v = io_level(k);
        if (v >= 0 && prev >= 0 && v != prev) {
            n++;
            if (last_ns)
                *last_ns = io_now_ns();
        }
        prev = v;
        usleep(100); /* 10 kHz is enough for 500 Hz, and the guest's one CPU is shared */
    }
    return n;
}

/* Inputs at rest: the e-stop chain closed (NC: high), no alarm, no hold, no cycle start. */
static int io_idle(void)
{
    return io_pull(IO_ESTOP, 1) | io_pull(IO_ALARM, 0) | io_pull(IO_HOLD, 0) | io_pull(IO_START, 0);
}

/* The simulated chip the guest script made (gpiochip0 when run elsewhere). */
static const char *io_chip(void)
{
    const char *chip = getenv("EF_GSIM_CHIP");
    return chip ? chip : "gpiochip0";
}

/* Write OUT/machine.ini for the simulated chip (hold: wire feed hold and cycle start); its
 * path into buf. The latch lives in OUT. */
static const char *io_machine(char *buf, size_t n, int hold)
{
    snprintf(buf, n, "%s/machine.ini", g_out);
    FILE *f = fopen(buf, "w");
    if (!f)
        return buf;
    const char *chip = getenv("EF_GSIM_CHIP");
    fprintf(f,
            "# written by test_can_hil for the gpio-sim chip efio\n"
            "[gpio]\nchip = %s\ndebounce_ms = 2\n"
            "[estop]\nline = ESTOP\nlatch = %s/estop.latch\nstop_timeout_ms = 3000\n"
            "[enable]\nline = ENABLE\n"
            "[alarm]\nline = ALARM\n"
            "[charge_pump]\nline = PUMP\nhz = 500\n"
            "[outputs]\np0 = OUT0\np1 = OUT1\n",
            chip ? chip : "gpiochip0", g_out);
    if (hold)
        fprintf(f, "[feed_hold]\nline = HOLD\n[cycle_start]\nline = START\n");
    fclose(f);
    return buf;
}

/* The streamer in the background (exec: the PID is evenfeed's), output in OUT/NAME.out/.err. */
static int io_spawn(tm_proc_t *p, const char *name, const char *mode, const char *extra,
                    const char *prog)
{
    static char cmd[2048];
    snprintf(cmd, sizeof cmd,
             "exec %s stream --can %s --nodes 1,2,3 --mode %s%s --sdo-timeout 1000"
             " --hb-timeout " HIL_HB_TIMEOUT
             " --log %s/%s.log --trace %s/%s.csv %s %s >%s/%s.out 2>%s/%s.err",
             g_ef, g_can, mode, strcmp(mode, "csp") ? "" : " --cycle-us " IO_CSP_CYCLE, g_out, name,
             g_out, name, extra ? extra : "", prog, g_out, name, g_out, name);
    char *argv[] = {"/bin/sh", "-c", cmd, NULL};
    return tm_spawn(argv, 0, p);
}

/* A spawned process io_running() found ended (reaped), and its wait status. */
static pid_t io_reaped_pid;
static int io_reaped_st;

/* Wait (at most ms) for a spawned streamer; its exit status, 128+signal, or -1 (still
 * running: then it is killed). Prints its output. */
static int io_wait(tm_proc_t *p, const char *name, int ms)
{
    int st = 0, rc = -1;
    if (p->pid == io_reaped_pid) {
        st = io_reaped_st;
        rc = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        io_reaped_pid = 0;
    }
    for (int i = 0; rc < 0 && i < ms / 10; i++) {
        if (waitpid(p->pid, &st, WNOHANG) == p->pid) {
            rc = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
            break;
        }
        usleep(10000);
    }
    if (rc < 0) {
        kill(p->pid, SIGKILL);
        waitpid(p->pid, &st, 0);
    }
    close(p->out);
    p->pid = 0;
    char title[128];
    snprintf(title, sizeof title, "stream %s", name);
    hil_print_outputs(title, name, rc);
    return rc;
}

/* Whether a spawned process is still running (an ended one is reaped, for io_wait()). */
static int io_running(const tm_proc_t *p)
{
    if (p->pid <= 0 || p->pid == io_reaped_pid)
        return 0;
    int st;
    if (waitpid(p->pid, &st, WNOHANG) == 0)
        return 1;
    io_reaped_pid = p->pid;
    io_reaped_st = st;
    return 0;
}

/* Drive node's newest trace row (its command and actual position); 0 when there is none. */
static int io_drive_now(int node, double *cmd, double *act)
{
    char path[512];
    snprintf(path, sizeof path, "%s/drive%d.csv", g_out, node);
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    char buf[1024];
    fseek(f, 0, SEEK_END);
    long size = ftell(f), from = size > (long)sizeof buf - 1 ? size - (long)sizeof buf + 1 : 0;
    fseek(f, from, SEEK_SET);
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = 0;
    int ok = 0;
    for (char *l = strtok(buf, "\n"); l; l = strtok(NULL, "\n")) {
        unsigned sy, sw;
        int pw;
        double c, a, fe;
        if (sscanf(l, "p,%u,%u,%d,%lf,%lf,%lf", &sy, &sw, &pw, &c, &a, &fe) == 6) {
            *cmd = c;
            *act = a;
            ok = 1;
        }
    }
    return ok;
}

/* The start every io_* part shares: the machine file (feed hold wired when hold) into
 * mach, no latch left at latch, idle inputs, prog's reference path when reference, three
 * drives in d and a stream of prog in mode as st. Returns 0 with both running; otherwise -1
 * after a failed check, with the drives stopped. mach and latch are 512 and 600 bytes. */
static int io_begin(tm_proc_t d[4], tm_proc_t *st, const char *name, const char *mode,
                    const char *prog, char *mach, char *latch, int hold, int reference)
{
    io_machine(mach, 512, hold);
    snprintf(latch, 600, "%s/estop.latch", g_out);
    unlink(latch);
    EF_CHECK_EQ(io_idle(), 0);
    if (reference)
        EF_CHECK_EQ(hil_reference(prog), 0);
    if (hil_start(d, NULL) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return -1;
    }
    char extra[700];
    snprintf(extra, sizeof extra, "--machine %s", mach);
    EF_CHECK_EQ(io_spawn(st, name, mode, extra, prog), 0);
    return 0;
}

/* Wait (bounded: 60 s) until drive 1's actual x passes x while the streamer runs (the
 * trace's tail: a whole parse every round would load the guest's one CPU). */
static int io_wait_x(const tm_proc_t *st, double x)
{
    for (int i = 0; i < 1200; i++) {
        double c, a;
        if (io_drive_now(1, &c, &a) && a > x)
            return 1;
        if (!io_running(st))
            return 0;
        usleep(50000);
    }
    return 0;
}

/* Each drive came to rest within its stop ramp's distance: from the SYNC it left OPERATION
 * ENABLED (the quick stop arrived), at the speed it had then, it ran at most v^2 / (2 a_stop)
 * (+25 %, + the servo's following error). */
static void io_check_stop_distance(const char *what, double dt)
{
    ef_servo_cfg_t sc;
    ef_servo_cfg_default(&sc);
    for (int node = 1; node <= 3; node++) {
        hil_dtrace_t T;
        if (hil_dtrace_load(node, &T) != 0) {
            EF_CHECK(0);
            continue;
        }
        size_t k = 0;
        for (size_t i = 1; i < T.np && !k; i++)
            if (T.p[i - 1].power == EF_CO_PS_OP_ENABLED && T.p[i].power != EF_CO_PS_OP_ENABLED)
                k = i;
        double v = k >= 2 ? fabs(T.p[k - 1].cmd - T.p[k - 2].cmd) / dt : 0.0;
        double run = k ? fabs(T.p[T.np - 1].cmd - T.p[k - 1].cmd) : 0.0;
        double lim = 1.25 * v * v / (2.0 * sc.a_stop) + HIL_FERR_TOL;
        printf("%s: node %d at %.3f mm/s when the quick stop came, ran on %.4f mm (ramp distance"
               " %.4f mm, limit %.4f)\n",
               what, node, v, run, v * v / (2.0 * sc.a_stop), lim);
        EF_CHECK(k > 0);
        EF_CHECK(run <= lim);
        hil_dtrace_free(&T);
    }
}

/* Whether a file exists. */
static int io_exists(const char *path)
{
    return access(path, F_OK) == 0;
}

/* `evenfeed io reset`: its exit status; stderr into OUT/reset.err. */
static int io_reset(const char *machine)
{
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "%s io reset --machine %s >%s/reset.out 2>%s/reset.err", g_ef,
             machine, g_out, g_out);
    int st = system(cmd);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* E-stop mid-path (CSP): 200 us glitches are ignored, a 5 ms press stops every axis under
 * control within its ramp, drops enable and the pump, names the input and the line; the
 * latch then refuses a stream with the input released, until `evenfeed io reset`, which
 * itself refuses while the input is active. */
static void part_io_estop(void)
{
    char prog[512], mach[512], latch[600];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    tm_proc_t d[4] = {{0}}, st;
    if (io_begin(d, &st, "estop", "csp", prog, mach, latch, 0, 1) != 0)
        return;
    EF_CHECK(io_wait_x(&st, 20.0));
    EF_CHECK_EQ(io_level(IO_ENABLE), 1);
    int pe = io_edges(IO_PUMP, 100, NULL);
    printf("io_estop: enable high while streaming; charge pump %d edges in 100 ms (500 Hz: 100; "
           "judged in io_pump)\n",
           pe);
    /* Glitches: shorter than the 2 ms debounce. */
    double wmax = 0;
    for (int i = 0; i < 5; i++) {
        uint64_t t0 = io_now_ns();
        io_pull(IO_ESTOP, 0);
        while (io_now_ns() - t0 < 200000u)
            ;
        io_pull(IO_ESTOP, 1);
        wmax = fmax(wmax, (double)(io_now_ns() - t0) * 1e-6);
        usleep(20000);
    }
    usleep(20000);
    int alive = io_running(&st);
    printf("io_estop: 5 glitches of at most %.3f ms (debounce 2 ms): streamer %s\n", wmax,
           alive ? "still running" : "STOPPED");
    if (wmax < 1.5)
        EF_CHECK(alive);
    else
        printf("io_estop: a glitch lasted %.3f ms on this host: the glitch check is not judged\n",
               wmax);
    /* The press: 5 ms, then released (the latch holds the e-stop). */
    double x0 = 0, a0 = 0;
    io_drive_now(1, &x0, &a0);
    uint64_t t0 = io_now_ns();
    io_pull(IO_ESTOP, 0);
    while (io_now_ns() - t0 < 5000000u)
        usleep(500);
    io_pull(IO_ESTOP, 1);
    int rc = io_wait(&st, "estop", 30000);
    EF_CHECK_EQ(rc, IO_EXIT_ESTOP);
    EF_CHECK(hil_err_has("estop", "e-stop: input estop", "at program line"));
    EF_CHECK(hil_err_has("estop", "at rest", "enable dropped"));
    EF_CHECK_EQ(io_level(IO_ENABLE), 0);
    EF_CHECK_EQ(io_edges(IO_PUMP, 30, NULL), 0);
    EF_CHECK(io_exists(latch));
    printf("io_estop: pressed at x = %.3f mm\n", x0);
    hil_stop(d);
    hil_check_stopped("io_estop", 4000);
    io_check_stop_distance("io_estop", 4e-3);
    /* Released, but latched: refused before the bus is opened (no log, no frame). */
    char log[700], extra[700];
    snprintf(log, sizeof log, "%s/again.log", g_out);
    unlink(log);
    snprintf(extra, sizeof extra, "--machine %s", mach);
    int rc2 = hil_stream("again", "csp", "1,2,3", extra, prog);
    EF_CHECK_EQ(rc2, IO_EXIT_ESTOP);
    EF_CHECK(hil_err_has("again", "latched", "io reset"));
    struct stat sb;
    EF_CHECK(stat(log, &sb) != 0 || sb.st_size == 0);
    /* Reset: refused while active, done once released. */
    io_pull(IO_ESTOP, 0);
    usleep(20000);
    EF_CHECK_EQ(io_reset(mach), IO_EXIT_ESTOP);
    EF_CHECK(hil_err_has("reset", "still active", NULL));
    EF_CHECK(io_exists(latch));
    io_pull(IO_ESTOP, 1);
    usleep(20000);
    EF_CHECK_EQ(io_reset(mach), 0);
    EF_CHECK(!io_exists(latch));
}

/* E-stop active at the start: refused, no frame on the bus, no drive enabled, enable low.
 * Bad machine I/O: a line held by another consumer is named before anything moves. */
static void part_io_start(void)
{
    char prog[512], mach[512], latch[600];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    io_machine(mach, sizeof mach, 0);
    snprintf(latch, sizeof latch, "%s/estop.latch", g_out);
    unlink(latch);
    EF_CHECK_EQ(io_idle(), 0);
    EF_CHECK_EQ(io_pull(IO_ESTOP, 0), 0); /* pressed */
    tm_proc_t d[4] = {{0}};
    if (hil_start(d, NULL) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return;
    }
    char extra[700], log[700];
    snprintf(extra, sizeof extra, "--machine %s", mach);
    snprintf(log, sizeof log, "%s/start.log", g_out);
    unlink(log);
    int rc = hil_stream("start", "csp", "1,2,3", extra, prog);
    EF_CHECK_EQ(rc, IO_EXIT_ESTOP);
    EF_CHECK(hil_err_has("start", "e-stop: input estop", "is active"));
    struct stat sb;
    EF_CHECK(stat(log, &sb) != 0 || sb.st_size == 0);
    EF_CHECK_EQ(io_level(IO_ENABLE), 0);
    /* A line another process holds (gpioset keeps ENABLE until signalled). */
    io_pull(IO_ESTOP, 1);
    char chip[64];
    snprintf(chip, sizeof chip, "%s", getenv("EF_GSIM_CHIP") ? getenv("EF_GSIM_CHIP") : "");
    char *gs[] = {"gpioset", "--mode=signal", chip, "1=0", NULL};
    tm_proc_t g;
    EF_CHECK_EQ(tm_spawn(gs, 0, &g), 0);
    int held = 0;
    for (int i = 0; i < 200 && !held; i++) {
        char cmd[600];
        snprintf(cmd, sizeof cmd, "gpioinfo %s | grep -q '\"gpioset\"'", chip);
        held = system(cmd) == 0;
        if (!held)
            usleep(10000);
    }
    EF_CHECK(held);
    rc = hil_stream("held", "csp", "1,2,3", extra, prog);
    tm_stop(&g, SIGTERM);
    hil_stop(d);
    EF_CHECK(rc != 0 && rc != IO_EXIT_ESTOP);
    EF_CHECK(hil_err_has("held", "enable", "gpioset"));
    for (int node = 1; node <= 3; node++) {
        hil_dtrace_t T;
        EF_CHECK_EQ(hil_dtrace_load(node, &T), 0);
        printf("io_start: node %d: %s\n", node,
               T.reached_op ? "reached OPERATION ENABLED" : "never enabled");
        EF_CHECK(!T.reached_op);
        hil_dtrace_free(&T);
    }
}

/* A drive alarm input mid-path (segment mode): every axis stops, the error names it. */
static void part_io_alarm(void)
{
    char prog[512], mach[512], latch[600];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    tm_proc_t d[4] = {{0}}, st;
    if (io_begin(d, &st, "alarm", "segment", prog, mach, latch, 0, 0) != 0)
        return;
    EF_CHECK(io_wait_x(&st, 20.0));
    io_pull(IO_ALARM, 1);
    int rc = io_wait(&st, "alarm", 30000);
    hil_stop(d);
    EF_CHECK_EQ(rc, IO_EXIT_ESTOP);
    EF_CHECK(hil_err_has("alarm", "drive alarm: input alarm.1", "at program line"));
    EF_CHECK_EQ(io_level(IO_ENABLE), 0);
    hil_check_stopped("io_alarm", 10000);
    io_check_stop_distance("io_alarm", 10e-3);
    io_pull(IO_ALARM, 0);
}

/* A drive's own I/O (sim-drive --sto --alarm-out on node 1): its enable (STO) input dropping
 * mid-path faults it (EMCY 0xFF06), its alarm output goes active, the streamer stops every
 * axis under control naming the node and the cause, and drops enable; with the input off
 * from the start, the drive refuses to run and nothing moves. */
static int io_sto_drives(tm_proc_t d[4])
{
    static char x1[300];
    snprintf(x1, sizeof x1, "--sto %s:STO --alarm-out %s:ALMOUT", io_chip(), io_chip());
    hil_drives_t x = {{NULL}};
    x.extra[1] = x1;
    return hil_start(d, &x);
}

static void part_io_sto(void)
{
    char prog[512], mach[512], latch[600], extra[700];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    io_machine(mach, sizeof mach, 0);
    snprintf(latch, sizeof latch, "%s/estop.latch", g_out);
    snprintf(extra, sizeof extra, "--machine %s", mach);
    unlink(latch);
    EF_CHECK_EQ(io_idle(), 0);
    EF_CHECK_EQ(io_pull(IO_STO, 1), 0); /* torque permitted */
    tm_proc_t d[4] = {{0}}, st;
    if (io_sto_drives(d) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return;
    }
    EF_CHECK_EQ(io_level(IO_ALMOUT), 0); /* no fault: no alarm */
    EF_CHECK_EQ(io_spawn(&st, "sto", "segment", extra, prog), 0);
    EF_CHECK(io_wait_x(&st, 20.0));
    EF_CHECK_EQ(io_level(IO_ALMOUT), 0);
    io_pull(IO_STO, 0); /* the drive's enable wire broken */
    int rc = io_wait(&st, "sto", 30000);
    EF_CHECK_EQ(rc, -EF_ERR_DRIVE);
    EF_CHECK(hil_err_has("sto", "node 1", "safe torque off"));
    EF_CHECK_EQ(io_level(IO_ALMOUT), 1);
    EF_CHECK_EQ(io_level(IO_ENABLE), 0);
    hil_stop(d); /* (a released gpio-sim line reads its pull again, so the alarm output's
                  * safe state at exit is not visible here) */
    hil_check_stopped("io_sto", 10000);
    char path[512];
    snprintf(path, sizeof path, "%s/drive1.csv", g_out);
    char *o = hil_slurp(path);
    EF_CHECK(o && strstr(o, "# STO: enable input off"));
    free(o);

    /* Off from the start: the drive faults as its power stage comes on; nothing moves. */
    EF_CHECK_EQ(io_pull(IO_STO, 0), 0);
    if (io_sto_drives(d) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return;
    }
    EF_CHECK_EQ(io_spawn(&st, "sto0", "segment", extra, prog), 0);
    rc = io_wait(&st, "sto0", 30000);
    hil_stop(d);
    EF_CHECK_EQ(rc, -EF_ERR_DRIVE);
    EF_CHECK(hil_err_has("sto0", "node 1", "safe torque off"));
    EF_CHECK_EQ(io_level(IO_ENABLE), 0);
    double moved = 0;
    for (int node = 1; node <= 3; node++) {
        hil_dtrace_t T;
        if (hil_dtrace_load(node, &T) != 0) {
            EF_CHECK(0);
            continue;
        }
        for (size_t i = 0; i < T.np; i++)
            moved = fmax(moved, fabs(T.p[i].cmd - T.p[0].cmd));
        hil_dtrace_free(&T);
    }
    printf("io_sto: STO off at the start: the commands moved by %.6f mm\n", moved);
    EF_CHECK(moved == 0.0);
    io_pull(IO_STO, 1);

    /* A line that does not exist: refused before the drive appears on the bus. */
    char cmd[1024];
    snprintf(cmd, sizeof cmd,
             "%s sim-drive can --iface vcan0 --node 9 --sto %s:NOPE >%s/sto_bad.out "
             "2>%s/sto_bad.err",
             g_ef, io_chip(), g_out, g_out);
    int sr = system(cmd);
    EF_CHECK(WIFEXITED(sr) && WEXITSTATUS(sr) != 0);
    EF_CHECK(hil_err_has("sto_bad", "sto", "NOPE"));
    snprintf(cmd, sizeof cmd, "%s/sto_bad.out", g_out);
    char *bo = hil_slurp(cmd);
    EF_CHECK(!bo || !strstr(bo, "ready"));
    free(bo);
}

/* The charge pump runs while streaming and stops within 10 ms of SIGKILL of the streamer. */
static void part_io_pump(void)
{
    char prog[512], mach[512], latch[600];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    tm_proc_t d[4] = {{0}}, st;
    if (io_begin(d, &st, "pump", "csp", prog, mach, latch, 0, 0) != 0)
        return;
    EF_CHECK(io_wait_x(&st, 20.0));
    int before = io_edges(IO_PUMP, 200, NULL);
    kill(st.pid, SIGKILL);
    int wst;
    waitpid(st.pid, &wst, 0);
    uint64_t t_dead = io_now_ns();
    close(st.out);
    st.pid = 0;
    uint64_t last = 0;
    int after = io_edges(IO_PUMP, 200, &last);
    printf("io_pump: %d edges in 200 ms while streaming (%.0f Hz); after SIGKILL %d edges, the "
           "last %.3f ms after the kill was reaped; pump level %d, enable level %d\n",
           before, before / 2.0 / 0.2, after, last ? (double)(last - t_dead) * 1e-6 : 0.0,
           io_level(IO_PUMP), io_level(IO_ENABLE));
    EF_CHECK(before >= 20);
    EF_CHECK(after == 0 || (double)(last - t_dead) * 1e-6 <= 10.0);
    hil_stop(d);
}

/* The streamer's "N feed holds, T s held" figure in its output (-1: none). */
static double io_held_s(const char *out)
{
    const char *q = out ? strstr(out, " feed holds, ") : NULL;
    double t = -1;
    if (q && sscanf(q, " feed holds, %lf s held", &t) != 1)
        t = -1;
    return t;
}

/* Feed hold mid-path (CSP: the streamer slows the targets; segment mode: the drives slow
 * their own segments on controlword bit 8): the axes decelerate along the path to rest and
 * stay there; releasing the hold alone does not resume, cycle start does; the path
 * completes exactly, on the commanded path, nothing lost or repeated. */
static void io_hold_in(const char *name, const char *mode)
{
    char prog[512], mach[512], latch[600];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    tm_proc_t d[4] = {{0}}, st;
    if (io_begin(d, &st, name, mode, prog, mach, latch, 1, 1) != 0)
        return;
    EF_CHECK(io_wait_x(&st, 20.0));
    io_pull(IO_HOLD, 1);
    /* At rest: the command stands still over 200 ms (bounded wait). */
    int rest = 0;
    double c0 = 0, a0 = 0, c1 = 0, a1 = 0;
    for (int i = 0; i < 50 && !rest; i++) {
        io_drive_now(1, &c0, &a0);
        usleep(200000);
        io_drive_now(1, &c1, &a1);
        rest = fabs(c1 - c0) < 1e-6;
    }
    printf("io_%s: held at x = %.4f mm\n", name, c1);
    EF_CHECK(rest);
    io_pull(IO_HOLD, 0);
    usleep(300000);
    double c2 = 0, a2 = 0;
    io_drive_now(1, &c2, &a2);
    printf("io_%s: hold released, no cycle start: x = %.4f mm\n", name, c2);
    EF_CHECK(fabs(c2 - c1) < 1e-6);
    EF_CHECK(io_running(&st));
    io_pull(IO_START, 1);
    usleep(30000);
    io_pull(IO_START, 0);
    int rc = io_wait(&st, name, 120000);
    hil_stop(d);
    EF_CHECK_EQ(rc, 0);
    char path[512], what[64];
    snprintf(path, sizeof path, "%s/%s.out", g_out, name);
    snprintf(what, sizeof what, "io_%s", name);
    char *o = hil_slurp(path);
    EF_CHECK(o && strstr(o, "1 feed holds"));
    /* Standing through the checks above: the hold was mid-path, not at the program's end
     * (CSP counts the held cycles' time: under UML fewer SYNCs than wall time allows). */
    printf("io_%s: %.3f s held\n", name, io_held_s(o));
    EF_CHECK(io_held_s(o) >= 0.1);
    free(o);
    hil_strace_t S;
    EF_CHECK_EQ(hil_strace_load(name, &S), 0);
    hil_check_path(what, &S, 1, (size_t)-1);
    hil_check_drives(what, strcmp(mode, "segment") ? -1 : (int)g_ref.nmv);
    hil_strace_free(&S);
}

static void part_io_hold(void)
{
    io_hold_in("hold", "csp");
}

static void part_io_hold_seg(void)
{
    io_hold_in("hold_seg", "segment");
}

/* M64/M65 and M62/M63 switch the program's outputs at their commanded points: while an
 * output is on, the axes are between the points that switch it on and off. */
static void part_io_outputs(void)
{
    char prog[512], mach[512], latch[600];
    snprintf(prog, sizeof prog, "%s/outputs.ngc", g_out);
    FILE *f = fopen(prog, "w");
    if (f) {
        fputs("(outputs.ngc: written by test_can_hil)\n"
              "G21 G90 G17 G94 G64 P0.01\nG1 X10 F900\nM64 P0\nG1 X20\nM65 P0\nM62 P1\n"
              "G1 X30\nM63 P1\nG1 X35\nM2\n",
              f);
        fclose(f);
    }
    tm_proc_t d[4] = {{0}}, st;
    if (io_begin(d, &st, "outputs", "csp", prog, mach, latch, 0, 0) != 0)
        return;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    int seen[2] = {0, 0};
    for (int i = 0; i < 15000 && io_running(&st); i++) {
        int v0 = io_level(IO_OUT0), v1 = io_level(IO_OUT1);
        double c, a;
        if ((v0 == 1 || v1 == 1) && io_drive_now(1, &c, &a)) {
            int k = v0 == 1 ? 0 : 1;
            seen[k] = 1;
            lo[k] = fmin(lo[k], a);
            hi[k] = fmax(hi[k], a);
        }
        usleep(2000);
    }
    int rc = io_wait(&st, "outputs", 30000);
    hil_stop(d);
    EF_CHECK_EQ(rc, 0);
    for (int k = 0; k < 2; k++) {
        double a = k ? 20.0 : 10.0, b = k ? 30.0 : 20.0;
        printf("io_outputs: P%d on while x in [%.4f, %.4f] (commanded %.0f..%.0f)\n", k, lo[k],
               hi[k], a, b);
        EF_CHECK(seen[k]);
        EF_CHECK(lo[k] >= a - IO_OUT_TOL && hi[k] <= b + IO_OUT_TOL);
    }
    EF_CHECK_EQ(io_level(IO_OUT0), 0);
    EF_CHECK_EQ(io_level(IO_OUT1), 0);
    char path[512];
    snprintf(path, sizeof path, "%s/outputs.out", g_out);
    char *o = hil_slurp(path);
    EF_CHECK(o && strstr(o, "4 outputs switched"));
    free(o);
}

/* A GPIO read error during a stream (the simulated chip taken away: gpio-sim's live = 0)
 * is taken as e-stop: every axis stops under control, the error says what failed. */
static void part_io_gpioerr(void)
{
    char prog[512], mach[512], latch[600];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    tm_proc_t d[4] = {{0}}, st;
    if (io_begin(d, &st, "gpioerr", "csp", prog, mach, latch, 0, 0) != 0)
        return;
    EF_CHECK(io_wait_x(&st, 20.0));
    int fd = open("/sys/kernel/config/gpio-sim/efio/live", O_WRONLY);
    EF_CHECK(fd >= 0 && write(fd, "0", 1) == 1);
    if (fd >= 0)
        close(fd);
    int rc = io_wait(&st, "gpioerr", 30000);
    hil_stop(d);
    EF_CHECK_EQ(rc, IO_EXIT_ESTOP);
    EF_CHECK(hil_err_has("gpioerr", "GPIO read error", "taken as e-stop"));
    EF_CHECK(hil_err_has("gpioerr", "at rest", NULL));
    /* The chip is gone: enable cannot have been written, and the message must not say it
     * dropped (the charge pump stopped, which is what drops the drives' relay). */
    EF_CHECK(hil_err_has("gpioerr", "enable not confirmed off", "charge pump stopped"));
    EF_CHECK(io_exists(latch));
    hil_check_stopped("io_gpioerr", 4000);
}

/* The Modbus drive's newest trace row: state, commanded and actual x; 0 when none. */
static int io_mb_now(const char *trace, int *state, double *cmd, double *act)
{
    FILE *f = fopen(trace, "r");
    if (!f)
        return 0;
    char buf[2048];
    fseek(f, 0, SEEK_END);
    long size = ftell(f), from = size > (long)sizeof buf - 1 ? size - (long)sizeof buf + 1 : 0;
    fseek(f, from, SEEK_SET);
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = 0;
    int ok = 0;
    for (char *l = strtok(buf, "\n"); l; l = strtok(NULL, "\n")) {
        double t, c, a;
        int st, seq, mv;
        if (sscanf(l, "%lf,%d,%d,%d,%lf,%*f,%*f,%lf", &t, &st, &seq, &mv, &c, &a) == 6) {
            *state = st;
            *cmd = c;
            *act = a;
            ok = 1;
        }
    }
    return ok;
}

/* The start the Modbus io_* parts share: the machine file (feed hold wired when hold) into
 * mach, no latch, idle inputs, one Modbus drive (with drive_extra) tracing into trace, and
 * `stream --modbus` of prog (with stream_opts) as st, output in OUT/NAME.out/.err; then a
 * bounded wait until the drive's actual x passes 20 mm (checked). Returns 0 with both
 * started, -1 when the drive did not start (checked). mach, trace: 512 and 600 bytes. */
static int io_mb_begin(tm_proc_t *d, tm_proc_t *st, const char *name, int hold,
                       const char *drive_extra, const char *stream_opts, const char *prog,
                       char *mach, char *trace)
{
    char latch[600];
    io_machine(mach, 512, hold);
    snprintf(latch, sizeof latch, "%s/estop.latch", g_out);
    snprintf(trace, 600, "%s/mbdrive.csv", g_out);
    unlink(latch);
    EF_CHECK_EQ(io_idle(), 0);
    int port = 0;
    if (tm_drive(d, "--tcp", "127.0.0.1:0", trace, drive_extra, &port) != 0 || port <= 0) {
        EF_CHECK(0);
        return -1;
    }
    static char cmd[2048];
    snprintf(cmd, sizeof cmd,
             "exec %s stream --modbus tcp://127.0.0.1:%d %s --machine %s %s >%s/%s.out "
             "2>%s/%s.err",
             g_ef, port, stream_opts, mach, prog, g_out, name, g_out, name);
    char *argv[] = {"/bin/sh", "-c", cmd, NULL};
    EF_CHECK_EQ(tm_spawn(argv, 0, st), 0);
    int moving = 0, state = 0;
    double c = 0, a = 0;
    for (int i = 0; i < 1200 && !moving && io_running(st); i++) {
        moving = io_mb_now(trace, &state, &c, &a) && a > 20.0;
        if (!moving)
            usleep(50000);
    }
    EF_CHECK(moving);
    return 0;
}

/* E-stop mid-path on Modbus (TCP on the guest's loopback): the drive gets the stop command,
 * comes to rest within its stop ramp's distance, enable drops, the error names the input and
 * the program line. */
static void part_io_modbus(void)
{
    char prog[512], mach[512], trace[600], latch[600];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    snprintf(latch, sizeof latch, "%s/estop.latch", g_out);
    tm_time_scale = "1"; /* the drive in real time: the stop ramp as a machine would run it */
    tm_proc_t d, st;
    if (io_mb_begin(&d, &st, "mb", 0, NULL, "", prog, mach, trace) != 0)
        return;
    EF_CHECK_EQ(io_level(IO_ENABLE), 1);
    /* 100 ms: this part is about the Modbus stop; the 5 ms press is io_estop's (a host that
     * holds the guest back during a 5 ms press leaves the guest less than the debounce). */
    uint64_t t0 = io_now_ns();
    io_pull(IO_ESTOP, 0);
    while (io_now_ns() - t0 < 100000000u)
        usleep(1000);
    io_pull(IO_ESTOP, 1);
    int rc = io_wait(&st, "mb", 30000);
    EF_CHECK_EQ(rc, IO_EXIT_ESTOP);
    EF_CHECK(hil_err_has("mb", "e-stop: input estop", "at program line"));
    EF_CHECK(hil_err_has("mb", "at rest", "enable dropped"));
    EF_CHECK_EQ(io_level(IO_ENABLE), 0);
    EF_CHECK(io_exists(latch));
    tm_stop(&d, SIGTERM);
    /* The stop: from the first STOPPING row, at the speed there, at most the ramp's distance. */
    FILE *f = fopen(trace, "r");
    double prev_t = 0, prev_c = 0, v = 0, c_stop = 0, c_end = 0, dt = 0, v_end = 0;
    int got = 0, rows = 0, last_state = -1;
    char line[512];
    while (f && fgets(line, sizeof line, f)) {
        double t, cx;
        int s2, seq, mv;
        if (sscanf(line, "%lf,%d,%d,%d,%lf", &t, &s2, &seq, &mv, &cx) != 5)
            continue;
        if (!got && s2 == EF_DRV_STOPPING && rows > 0) {
            got = 1;
            dt = t - prev_t;
            v = dt > 0 ? fabs(cx - prev_c) / dt : 0;
            c_stop = prev_c;
        }
        v_end = t > prev_t ? fabs(cx - prev_c) / (t - prev_t) : v_end;
        c_end = cx;
        last_state = s2;
        prev_t = t;
        prev_c = cx;
        rows++;
    }
    if (f)
        fclose(f);
    ef_servo_cfg_t sc;
    ef_servo_cfg_default(&sc);
    double run = fabs(c_end - c_stop), lim = 1.25 * v * v / (2.0 * sc.a_stop) + HIL_FERR_TOL;
    printf("io_modbus: x at %.3f mm/s when the stop came, ran on %.4f mm (ramp distance %.4f mm,"
           " limit %.4f); last traced state %d at %.4f mm/s (then disabled)\n",
           v, run, v * v / (2.0 * sc.a_stop), lim, last_state, v_end);
    EF_CHECK(got);
    EF_CHECK(v > 5.0);
    EF_CHECK(run <= lim);
    EF_CHECK(last_state != EF_DRV_RUNNING && v_end < 1.0);
}

/* Feed hold on Modbus (TCP on the guest's loopback; segment mode: the drive holds on the
 * HOLD bit; direct mode: the streamer slows its targets): the drive decelerates along the
 * path and stands (still RUNNING in segment mode), the hold's release alone does not
 * resume, cycle start does, and the drive's commanded path lies on the program's and ends
 * at its end (segment mode: every segment executed once). */
static void io_modbus_hold_in(const char *mode)
{
    int seg = !strcmp(mode, "segment");
    char prog[512], mach[512], trace[600], opts[64];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    snprintf(opts, sizeof opts, "--mode %s --timeout 1000", mode);
    EF_CHECK_EQ(hil_reference(prog), 0);
    tm_proc_t d, st;
    if (io_mb_begin(&d, &st, "mbh", 1, NULL, opts, prog, mach, trace) != 0)
        return;
    int state = 0;
    double a = 0;
    io_pull(IO_HOLD, 1);
    int rest = 0;
    double c0 = 0, c1 = 0;
    for (int i = 0; i < 50 && !rest; i++) {
        io_mb_now(trace, &state, &c0, &a);
        usleep(200000);
        io_mb_now(trace, &state, &c1, &a);
        rest = fabs(c1 - c0) < 1e-6 && state == (seg ? EF_DRV_RUNNING : EF_DRV_ENABLED);
    }
    printf("io_modbus_hold: %s: held at x = %.4f mm (drive state %d)\n", mode, c1, state);
    EF_CHECK(rest);
    io_pull(IO_HOLD, 0);
    usleep(300000);
    double c2 = 0;
    io_mb_now(trace, &state, &c2, &a);
    printf("io_modbus_hold: hold released, no cycle start: x = %.4f mm\n", c2);
    EF_CHECK(fabs(c2 - c1) < 1e-6);
    EF_CHECK(io_running(&st));
    io_pull(IO_START, 1);
    usleep(30000);
    io_pull(IO_START, 0);
    int rc = io_wait(&st, "mbh", 120000);
    EF_CHECK_EQ(rc, 0);
    char path[512];
    snprintf(path, sizeof path, "%s/mbh.out", g_out);
    char *o = hil_slurp(path);
    EF_CHECK(o && strstr(o, "1 feed holds"));
    EF_CHECK(io_held_s(o) >= 0.1); /* mid-path: standing through the checks above */
    char want[96];
    snprintf(want, sizeof want, "%u segments executed", (unsigned)g_ref.nmv);
    EF_CHECK(!seg || (o && strstr(o, want)));
    free(o);
    tm_stop(&d, SIGTERM);
    /* The drive's commanded path against the reference, and where it ended. */
    FILE *f = fopen(trace, "r");
    size_t cursor = 0, rows = 0;
    double worst = 0, end[3] = {0, 0, 0};
    char line[512];
    while (f && fgets(line, sizeof line, f)) {
        double t, q[3];
        int s2, seq, mv;
        if (sscanf(line, "%lf,%d,%d,%d,%lf,%lf,%lf", &t, &s2, &seq, &mv, &q[0], &q[1], &q[2]) != 7)
            continue;
        worst = fmax(worst, hil_path_dist(q, &cursor));
        memcpy(end, q, sizeof end);
        rows++;
    }
    if (f)
        fclose(f);
    double de = sqrt(pow(end[0] - g_ref.end[0], 2) + pow(end[1] - g_ref.end[1], 2) +
                     pow(end[2] - g_ref.end[2], 2));
    /* Direct mode: the drive's own profile runs between targets 20 ms apart (50 Hz). */
    double tol = seg ? HIL_PATH_TOL : HIL_DIRECT_PATH_TOL;
    printf("io_modbus_hold: %s: %zu drive rows, largest distance from the commanded path %.4f mm "
           "(limit %.3f), ends %.4f mm from the program's end\n",
           mode, rows, worst, tol, de);
    EF_CHECK(rows > 100);
    EF_CHECK(worst <= tol);
    EF_CHECK(de <= HIL_END_TOL);
}

static void part_io_modbus_hold(void)
{
    io_modbus_hold_in("segment");
}

static void part_io_modbus_hold_direct(void)
{
    io_modbus_hold_in("direct");
}

/* The same on Modbus (sim-drive modbus --sto --alarm-out): the enable input dropping
 * mid-path faults the drive (fault 6), its alarm output goes active, the stream stops
 * naming the fault, enable drops. */
static void part_io_modbus_sto(void)
{
    char prog[512], mach[512], trace[600], x[200];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    EF_CHECK_EQ(io_pull(IO_STO, 1), 0);
    snprintf(x, sizeof x, "--sto %s:STO --alarm-out %s:ALMOUT", io_chip(), io_chip());
    tm_proc_t d, st;
    if (io_mb_begin(&d, &st, "mbs", 0, x, "--timeout 1000", prog, mach, trace) != 0)
        return;
    EF_CHECK_EQ(io_level(IO_ALMOUT), 0); /* moving, no fault: no alarm */
    int state = 0;
    double c = 0, a = 0;
    io_pull(IO_STO, 0);
    int rc = io_wait(&st, "mbs", 30000);
    EF_CHECK_EQ(rc, -EF_ERR_DRIVE);
    EF_CHECK(hil_err_has("mbs", "drive fault 6", "safe torque off"));
    EF_CHECK_EQ(io_level(IO_ALMOUT), 1);
    EF_CHECK_EQ(io_level(IO_ENABLE), 0);
    io_mb_now(trace, &state, &c, &a);
    printf("io_modbus_sto: drive state %d at the end\n", state);
    EF_CHECK_EQ(state, EF_DRV_FAULT);
    tm_stop(&d, SIGTERM);
    io_pull(IO_STO, 1);
}

/* ------------------------------------------------------------------ e-stop latency benchmark */

static int io_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median and largest of n figures, printed. */
static void io_report(const char *what, double *v, int n)
{
    if (n <= 0) {
        printf("  %-44s no figures\n", what);
        return;
    }
    qsort(v, (size_t)n, sizeof *v, io_cmp_double);
    printf("  %-44s median %8.3f ms, max %8.3f ms (%d presses)\n", what, v[n / 2], v[n - 1], n);
}

/* The first quick stop (controlword 0x0002 in an RPDO1, 0x201..0x27F) in a candump -L log
 * at or after t (s, CLOCK_REALTIME); its time, or -1. */
static double io_first_stop(const char *log, double t)
{
    FILE *f = fopen(log, "r");
    if (!f)
        return -1;
    char line[256];
    double found = -1;
    while (found < 0 && fgets(line, sizeof line, f)) {
        double ts;
        char ifc[32], frame[64];
        if (sscanf(line, "(%lf) %31s %63s", &ts, ifc, frame) != 3 || ts < t)
            continue;
        unsigned id;
        char data[32];
        if (sscanf(frame, "%x#%31s", &id, data) == 2 && id >= 0x201 && id <= 0x27F &&
            !strncmp(data, "0200", 4))
            found = ts;
    }
    fclose(f);
    return found;
}

/* E-stop latency over EF_BENCH_PRESSES presses (default 100): the press (the pull written)
 * to the first quick-stop frame on the bus (candump's kernel timestamps), the kernel's edge
 * time to the streamer's stop command, and the edge to every drive at rest (the streamer's
 * figures). A benchmark: it prints, and fails only when a press did not stop the stream. */
static void part_io_latency(void)
{
    const char *np = getenv("EF_BENCH_PRESSES");
    int n = np ? atoi(np) : 100;
    if (n < 1 || n > 1000)
        n = 100;
    char prog[512], mach[512], candump[512];
    snprintf(prog, sizeof prog, "%s/latency.ngc", g_out);
    FILE *f = fopen(prog, "w");
    if (f) {
        fputs("(latency.ngc: written by test_can_hil)\nG21 G90 G94\nG1 X40 F1200\nM2\n", f);
        fclose(f);
    }
    io_machine(mach, sizeof mach, 0);
    snprintf(candump, sizeof candump, "%s/latency.candump", g_out);
    char cmd[700];
    snprintf(cmd, sizeof cmd, "exec candump -L vcan0 >%s", candump);
    char *cd[] = {"sh", "-c", cmd, NULL};
    tm_proc_t dump;
    EF_CHECK_EQ(tm_spawn(cd, 0, &dump), 0);
    double *bus = calloc((size_t)n, sizeof *bus), *cmdl = calloc((size_t)n, sizeof *cmdl),
           *rest = calloc((size_t)n, sizeof *rest), *press = calloc((size_t)n, sizeof *press);
    int nb = 0, nc = 0, nr = 0, stopped = 0, made = 0;
    char extra[700];
    snprintf(extra, sizeof extra, "--machine %s", mach);
    for (int i = 0; i < n && bus && cmdl && rest && press; i++) {
        io_idle();
        EF_CHECK_EQ(io_reset(mach), 0);
        tm_proc_t d[4] = {{0}}, st;
        if (hil_start(d, NULL) != 0 || io_spawn(&st, "latency", "csp", extra, prog) != 0) {
            EF_CHECK(0);
            hil_stop(d);
            break;
        }
        if (!io_wait_x(&st, 2.0)) {
            EF_CHECK(0);
            io_wait(&st, "latency", 1000);
            hil_stop(d);
            break;
        }
        struct timespec rt;
        clock_gettime(CLOCK_REALTIME, &rt);
        press[i] = (double)rt.tv_sec + rt.tv_nsec * 1e-9;
        made = i + 1;
        io_pull(IO_ESTOP, 0);
        int wst = 0, rc = -1;
        for (int k = 0; k < 3000 && rc < 0; k++) {
            if (waitpid(st.pid, &wst, WNOHANG) == st.pid)
                rc = WIFEXITED(wst) ? WEXITSTATUS(wst) : 128;
            else
                usleep(10000);
        }
        if (rc < 0) {
            kill(st.pid, SIGKILL);
            waitpid(st.pid, &wst, 0);
        }
        close(st.out);
        hil_stop(d);
        stopped += rc == IO_EXIT_ESTOP;
        char path[512];
        snprintf(path, sizeof path, "%s/latency.out", g_out);
        char *o = hil_slurp(path);
        const char *e = o ? strstr(o, "e-stop: line ") : NULL;
        double a = -1, b = -1;
        if (e && sscanf(e,
                        "e-stop: line %*u, input edge to stop command %lf ms, to all drives at "
                        "rest %lf ms",
                        &a, &b) == 2) {
            cmdl[nc++] = a;
            if (b >= 0)
                rest[nr++] = b;
        }
        free(o);
    }
    usleep(200000); /* candump's last frames */
    tm_stop(&dump, SIGTERM);
    /* Only the presses made: a run cut short (a stream that ended before it moved) leaves
     * the rest unset, and a frame matched against an unset time was a latency of 56 years. */
    for (int i = 0; i < made && press && bus; i++) {
        double t = io_first_stop(candump, press[i]);
        if (t >= 0 && (i + 1 >= made || t < press[i + 1]))
            bus[nb++] = (t - press[i]) * 1e3;
    }
    printf("e-stop latency under User-Mode Linux (not a real-time kernel; SYNC every %s us):\n",
           IO_CSP_CYCLE);
    printf("  %d presses of %d made, %d streams stopped by e-stop\n", made, n, stopped);
    io_report("press -> first quick-stop frame (candump)", bus, nb);
    io_report("kernel edge -> stop command (streamer)", cmdl, nc);
    io_report("kernel edge -> all drives at rest", rest, nr);
    EF_CHECK_EQ(stopped, n);
    EF_CHECK_EQ(nb, n);
    free(bus);
    free(cmdl);
    free(rest);
    free(press);
}

/* ------------------------------------------------------------------ USB-CAN adapter (gs_usb) */

/* The simulated adapter's serial number and configfs gadget name: `stream --can gsusb:SERIAL`
 * picks it, and unbinding the gadget's UDC unplugs it. */
#define GS_SERIAL "EFHIL1"
#define GS_GADGET "efgs"
/** Exit status of a stream whose adapter went away (-EF_ERR_BUS). */
#define GS_EXIT_BUS 46
/** SYNC periods of the streams through the adapter. The USB bus of User-Mode Linux
 *  (dummy_hcd) moves one transfer per endpoint per timer period, and a timer period there
 *  takes about 1.5 ms: about 650 frames/s each way, every frame sent costing one more in
 *  for its echo (docs/can.md has the figures). At 1 kHz CSP needs 7 frames in per SYNC;
 *  these periods keep the adapter within what the emulator moves. */
#define GS_SEG_CYCLE "--cycle-us 40000"
#define GS_CSP_CYCLE "--cycle-us 20000"
/** What the emulated machine needs on a loaded host, where the guest is starved of CPU for
 *  up to seconds (ctest -j2 beside a build: TX to echo up to 2.1 s, an SDO answer 870 ms
 *  after its request; an ASan build -j2 beside hil_gsusb_unplug: echoes 90-180 ms on
 *  average, up to 3.2 s; an SDO unanswered for 1 s twice, a power-state step not confirmed
 *  in 1 s, bring-up over 20 s): SDO answers waited for 2 s (and once more,
 *  ef_sdo_client.h), each power-state step for 5 s, bring-up for 120 s, and for the adapter
 *  bulk OUT and echo bounds of 10 s and 20 s. The fault part keeps the defaults it checks. */
#define GS_SDO       "--sdo-timeout 2000 --enable-timeout 5000 --bringup-ms 120000"
#define GS_USB_SLOW  "--can-opts timeout=10000"
#define GS_SEG_VCAN  GS_SEG_CYCLE " " GS_SDO
#define GS_CSP_VCAN  GS_CSP_CYCLE " " GS_SDO
#define GS_SEG_EXTRA GS_SEG_VCAN " " GS_USB_SLOW
#define GS_CSP_EXTRA GS_CSP_VCAN " " GS_USB_SLOW

/* A mode's options through the adapter (usb 1) or, for the benchmark's comparison, the same
 * stream on vcan0 (usb 0: --can-opts is refused there, it is for gs_usb adapters). */
static const char *gs_mode_extra(const char *mode, int usb)
{
    static const char *const opts[2][2] = {{GS_SEG_VCAN, GS_CSP_VCAN},
                                           {GS_SEG_EXTRA, GS_CSP_EXTRA}};
    return opts[usb != 0][strcmp(mode, "csp") == 0];
}

/* The sample profile at half its feeds (F1200 -> F600, F300 -> F150), into OUT and g_prog:
 * segment mode's segments come half as often, within what the emulated USB bus carries (a
 * go-back-N round that frames queued behind slow transfers set off costs more still). The
 * path is the same; only its time law differs. Returns the path, or NULL (checked). */
static const char *gs_program(void)
{
    static char out[600];
    char in[512];
    snprintf(in, sizeof in, "%s/samples/profile.ngc", g_src);
    snprintf(out, sizeof out, "%s/profile_half_feed.ngc", g_out);
    char *t = hil_slurp(in);
    FILE *f = fopen(out, "w");
    int ok = t && f;
    for (const char *p = t; ok && *p; p++) {
        if (!strncmp(p, "F1200.", 6)) {
            fputs("F600.", f);
            p += 5;
        } else if (!strncmp(p, "F300.", 5)) {
            fputs("F150.", f);
            p += 4;
        } else {
            fputc(*p, f);
        }
    }
    if (f && fclose(f) != 0)
        ok = 0;
    free(t);
    EF_CHECK(ok);
    g_prog = ok ? out : NULL;
    return g_prog;
}

/* Start the simulated adapter on vcan0 (extra: more sim-adapter options) and wait for its
 * ready line: the USB host (dummy_hcd) has configured it. 0 on success. */
static int gs_start(tm_proc_t *p, const char *extra)
{
    char cmd[1024];
    snprintf(cmd, sizeof cmd,
             "exec %s sim-adapter gsusb --iface vcan0 --serial " GS_SERIAL " --name " GS_GADGET
             " %s 2>>%s/adapter.err",
             g_ef, extra ? extra : "", g_out);
    char *argv[] = {"/bin/sh", "-c", cmd, NULL};
    if (tm_spawn(argv, 0, p) != 0)
        return -1;
    char line[256];
    if (tm_line(p->out, line, sizeof line, 20000) != 0 || strncmp(line, "ready", 5) != 0) {
        fprintf(stderr, "the simulated adapter did not become ready (%s)\n", g_out);
        tm_stop(p, SIGKILL);
        return -1;
    }
    printf("adapter: %s\n", line);
    return 0;
}

/* Stop the adapter (it unbinds and removes its gadget). */
static void gs_stop(tm_proc_t *p)
{
    if (p->pid > 0)
        tm_stop(p, SIGTERM);
}

/* Unplug the adapter as a cable pull would: the gadget leaves the bus (UDC unbound). */
static int gs_unplug(void)
{
    FILE *f = fopen("/sys/kernel/config/usb_gadget/" GS_GADGET "/UDC", "w");
    if (!f)
        return -1;
    int ok = fputs("\n", f) >= 0;
    return (fclose(f) == 0 && ok) ? 0 : -1;
}

/* Whether the kernel's own gs_usb driver has the adapter (a CAN netdevice of its own, can0),
 * waiting up to ms for it. */
static int gs_kernel_can0(int ms)
{
    for (int i = 0; i <= ms / 20; i++) {
        /* Not hil_slurp(): a sysfs file's size says nothing of its contents. */
        FILE *f = fopen("/sys/class/net/can0/type", "r");
        int type = 0;
        if (f) {
            if (fscanf(f, "%d", &type) != 1)
                type = 0;
            fclose(f);
        }
        if (type == 280) /* ARPHRD_CAN */
            return 1;
        usleep(20000);
    }
    return 0;
}

/* Run `evenfeed ARGS` to its end, stdout and stderr into OUT/NAME.out/.err; exit status. */
static int gs_run(const char *name, const char *args)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "%s %s >%s/%s.out 2>%s/%s.err", g_ef, args, g_out, name, g_out, name);
    int st = system(cmd);
    int rc = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    char title[1100];
    snprintf(title, sizeof title, "evenfeed %s", args);
    hil_print_outputs(title, name, rc);
    return rc;
}

/* The standard path through the USB adapter in one mode: the same checks as over vcan0
 * (every segment once and in order, executed path, following error, candump log). */
static void part_gsusb_stream(const char *mode)
{
    tm_proc_t a;
    /* The adapter's 32-bit microsecond clock wraps 3 s after its start: during the stream. */
    if (gs_start(&a, "--ts-start 4291967296") != 0) {
        EF_CHECK(0);
        return;
    }
    EF_CHECK_EQ(gs_run("list", "can list"), 0);
    char path[512];
    snprintf(path, sizeof path, "%s/list.out", g_out);
    char *o = hil_slurp(path);
    EF_CHECK(o && strstr(o, GS_SERIAL) && strstr(o, "1d50:606f"));
    free(o);
    /* The kernel's gs_usb binds to the adapter (1d50:606f) as it would to a candleLight:
     * the stream detaches it while in use and hands it back at the end. */
    EF_CHECK(gs_kernel_can0(5000));
    g_can = "gsusb:" GS_SERIAL "@1000000";
    g_can_extra = gs_mode_extra(mode, 1);
    g_ferr_steps = !strcmp(mode, "csp");
    if (!gs_program()) {
        gs_stop(&a);
        return;
    }
    part_stream(mode, 0);
    /* Device timestamps mapped onto the host's clock across the wrap: a frame's time on the
     * bus after its submission stays small (a wrap taken for a jump would be 71 min). */
    char path2[512];
    snprintf(path2, sizeof path2, "%s/stream.out", g_out);
    char *so = hil_slurp(path2);
    const char *dl = so ? strstr(so, "gs_usb: on the bus after") : NULL;
    double dmean = -1, dmax = -1;
    if (dl)
        (void)sscanf(dl, "gs_usb: on the bus after (device timestamps) mean %lf us, max %lf",
                     &dmean, &dmax);
    printf("%s: device timestamps across the wrap: submission to the bus mean %.0f us, max %.0f"
           " us\n",
           mode, dmean, dmax);
    EF_CHECK(dl != NULL && dmax >= 0 && dmax < 2e6);
    free(so);
    int back = gs_kernel_can0(5000);
    printf("%s: the kernel's gs_usb driver %s the adapter after the stream\n", mode,
           back ? "has" : "did NOT get back");
    EF_CHECK(back);
    gs_stop(&a);
}

/* The start the unplug and claimed parts share: the half-feed program (g_prog) and its
 * reference, the adapter, three drives, and a segment-mode stream through the adapter as st
 * (output in OUT/NAME.out/.err); then a bounded wait until drive 1's x passes x (checked).
 * 0 with everything started; -1 (checked, what started stopped) otherwise. */
static int gs_begin(tm_proc_t *a, tm_proc_t d[4], tm_proc_t *st, const char *name, double x)
{
    if (!gs_program())
        return -1;
    EF_CHECK_EQ(hil_reference(g_prog), 0);
    if (gs_start(a, NULL) != 0) {
        EF_CHECK(0);
        return -1;
    }
    if (hil_start(d, NULL) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        gs_stop(a);
        return -1;
    }
    g_can = "gsusb:" GS_SERIAL;
    EF_CHECK_EQ(io_spawn(st, name, "segment", GS_SEG_EXTRA, g_prog), 0);
    /* up to 150 s: the stream's own bring-up bound (GS_SDO) is 120 s */
    int moving = 0;
    for (int i = 0; i < 3000 && !moving && io_running(st); i++) {
        moving = hil_drive_passed(1, x);
        if (!moving)
            usleep(50000);
    }
    EF_CHECK(moving);
    return 0;
}

/* Unplugged mid-path: the stream ends with EF_ERR_BUS naming the adapter; no drive can be
 * reached through it any more, so each stops on its own SYNC watchdog, under control. */
static void part_gsusb_unplug(void)
{
    tm_proc_t a, d[4] = {{0}}, st;
    if (gs_begin(&a, d, &st, "unplug", 20.0) != 0)
        return;
    EF_CHECK_EQ(gs_unplug(), 0);
    int rc = io_wait(&st, "unplug", 30000);
    EF_CHECK_EQ(rc, GS_EXIT_BUS);
    EF_CHECK(hil_err_has("unplug", GS_SERIAL, "unplugged"));
    /* Every drive saw SYNC stop (EMCY 0x8130) and stopped on its own clock. */
    int all = 0;
    for (int i = 0; i < 300 && !all; i++) {
        all = hil_drive_emcy(1, 0x8130) && hil_drive_emcy(2, 0x8130) && hil_drive_emcy(3, 0x8130);
        if (!all)
            usleep(50000);
    }
    EF_CHECK(all);
    for (int i = 0; i < 100; i++) {
        hil_dtrace_t T;
        int done = hil_dtrace_load(1, &T) == 0 && T.np > 0 && T.p[T.np - 1].power == EF_CO_PS_FAULT;
        hil_dtrace_free(&T);
        if (done)
            break;
        usleep(50000);
    }
    hil_stop(d);
    gs_stop(&a);
    hil_check_stopped("unplug", 10000);
}

/* A bitrate the adapter cannot make (1 kbit/s on a 48 MHz clock: a prescaler of 1920 > 1024)
 * is refused before anything reaches the bus, naming the nearest it can make. */
static void part_gsusb_bitrate(void)
{
    char prog[512], args[1024];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    tm_proc_t a;
    if (gs_start(&a, NULL) != 0) {
        EF_CHECK(0);
        return;
    }
    char cmd[700];
    snprintf(cmd, sizeof cmd, "exec candump -L vcan0 >%s/bitrate.candump", g_out);
    char *cd[] = {"sh", "-c", cmd, NULL};
    tm_proc_t dump;
    EF_CHECK_EQ(tm_spawn(cd, 0, &dump), 0);
    snprintf(args, sizeof args, "stream --can gsusb:" GS_SERIAL "@1000 --mode csp %s", prog);
    int rc = gs_run("bitrate", args);
    EF_CHECK(rc != 0);
    EF_CHECK(hil_err_has("bitrate", "cannot make 1000 bit/s", "nearest"));
    /* A malformed spec and an adapter that is not there are named too. */
    snprintf(args, sizeof args, "stream --can gsusb:" GS_SERIAL "@fast --mode csp %s", prog);
    EF_CHECK(gs_run("badspec", args) != 0);
    EF_CHECK(hil_err_has("badspec", "gsusb", "fast"));
    snprintf(args, sizeof args, "stream --can gsusb:NOSUCH --mode csp %s", prog);
    EF_CHECK(gs_run("nosuch", args) != 0);
    EF_CHECK(hil_err_has("nosuch", "NOSUCH", GS_SERIAL)); /* names what is there */
    usleep(200000);
    tm_stop(&dump, SIGTERM);
    gs_stop(&a);
    snprintf(cmd, sizeof cmd, "%s/bitrate.candump", g_out);
    char *t = hil_slurp(cmd);
    EF_CHECK(t != NULL && t[0] == 0); /* nothing on the bus */
    free(t);
}

/* An adapter another program holds: the second stream is refused naming it, the first goes
 * on to the end undisturbed. */
static void part_gsusb_claimed(void)
{
    char args[1024];
    tm_proc_t a, d[4] = {{0}}, st;
    if (gs_begin(&a, d, &st, "first", 2.0) != 0)
        return;
    snprintf(args, sizeof args, "stream --can gsusb:" GS_SERIAL " --mode csp %s", g_prog);
    int rc = gs_run("second", args);
    EF_CHECK(rc != 0);
    EF_CHECK(hil_err_has("second", GS_SERIAL, "claimed"));
    EF_CHECK_EQ(gs_run("list", "can list"), 0);
    EF_CHECK_EQ(io_wait(&st, "first", 120000), 0);
    hil_stop(d);
    gs_stop(&a);
}

/* A misbehaving adapter: each fault gives a clear error naming the request or the frame,
 * never a crash, and nothing that reaches a drive unchecked. */
static void part_gsusb_faults(void)
{
    static const struct {
        const char *fault, *want1, *want2;
    } cases[] = {
        {"short-reply", "BT_CONST", "short reply"},
        {"long-reply", "DEVICE_CONFIG", "oversized"},
        {"no-answer", "HOST_FORMAT", "timed out"},
        {"bitrate-max=500000", "MODE", "BITTIMING"},
        {"bad-frame", "frame", "bytes"},
        {"bad-channel", "frame", "channel"},
        {"stall-in", "stall", GS_SERIAL},
        {"no-echo", "confirm", GS_SERIAL},
        {"bus-off", "gsusb:" GS_SERIAL, "bus-off"},
    };
    char prog[512], args[1024], extra[128], name[64];
    snprintf(prog, sizeof prog, "%s/samples/profile.ngc", g_src);
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        tm_proc_t a, d[4] = {{0}};
        snprintf(extra, sizeof extra, "--fault %s", cases[k].fault);
        if (gs_start(&a, extra) != 0 || hil_start(d, NULL) != 0) {
            EF_CHECK(0);
            hil_stop(d);
            gs_stop(&a);
            continue;
        }
        snprintf(name, sizeof name, "fault-%zu", k);
        snprintf(args, sizeof args,
                 "stream --can gsusb:" GS_SERIAL " --mode csp " GS_CSP_CYCLE
                 " --sdo-timeout 1000 %s",
                 prog);
        int rc = gs_run(name, args);
        printf("fault %s: exit %d\n", cases[k].fault, rc);
        EF_CHECK(rc != 0 && rc < 128); /* an error, not a signal */
        EF_CHECK(hil_err_has(name, cases[k].want1, cases[k].want2));
        hil_stop(d);
        /* No drive was left enabled or moving: a fault during bring-up enabled none, one
         * while running stopped them (quick stop through the adapter, which still sends). */
        for (int node = 1; node <= 3; node++) {
            hil_dtrace_t T;
            EF_CHECK_EQ(hil_dtrace_load(node, &T), 0);
            const hil_prow_t *e = T.np ? &T.p[T.np - 1] : NULL;
            int safe = !e || (e->power != EF_CO_PS_OP_ENABLED && T.np > 1 &&
                              fabs(e->cmd - T.p[T.np - 2].cmd) < 1e-6);
            if (!safe)
                fprintf(stderr, "fault %s: node %d ended in power state %d, command moving\n",
                        cases[k].fault, node, e ? e->power : -1);
            EF_CHECK(safe);
            hil_dtrace_free(&T);
        }
        gs_stop(&a);
    }
    /* Frames the adapter flags OVERFLOW (it lost some before them): counted as the
     * transport's receive overruns and named in the stream's summary. */
    tm_proc_t a, d[4] = {{0}};
    if (!gs_program() || gs_start(&a, "--fault overflow") != 0 || hil_start(d, NULL) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return;
    }
    g_can = "gsusb:" GS_SERIAL;
    g_can_extra = GS_SEG_EXTRA;
    int rc = hil_stream("overflow", "segment", "1,2,3", NULL, g_prog);
    hil_stop(d);
    gs_stop(&a);
    snprintf(args, sizeof args, "%s/overflow.out", g_out);
    char *o = hil_slurp(args);
    const char *r = o ? strstr(o, "received ") : NULL;
    unsigned long nrx = 0, lost = 0;
    if (r)
        (void)sscanf(r, "received %lu frames (%lu dropped", &nrx, &lost);
    printf("overflow: stream exit %d, %lu frames received, %lu counted as lost\n", rc, nrx, lost);
    EF_CHECK(lost >= 1 && lost <= nrx / 200);
    free(o);
}

/* ---- benchmark: the same traffic through the USB adapter and through SocketCAN ---- */

/* Probe frames: an identifier no CANopen node here uses (the drives are not running then). */
#define GB_PROBE_ID 0x6F0u

static double gb_now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e6 + ts.tv_nsec * 1e-3;
}

static int gb_cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median, 99th percentile and largest of n values (sorted in place). */
static void gb_report(const char *what, double *v, int n, const char *unit)
{
    if (n <= 0) {
        printf("  %-44s no samples\n", what);
        return;
    }
    qsort(v, (size_t)n, sizeof *v, gb_cmp);
    printf("  %-44s median %8.1f, p99 %8.1f, max %8.1f %s (%d)\n", what, v[n / 2],
           v[(int)(0.99 * (n - 1))], v[n - 1], unit, n);
}

/* A raw SocketCAN socket on vcan0 (recv_own: this socket also receives what it sends, as the
 * kernel's TX echo of a real controller); -1 on failure. */
static int gb_raw(int recv_own)
{
    int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (fd < 0)
        return -1;
    setsockopt(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &recv_own, sizeof recv_own);
    int big = 4 << 20;
    setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &big, sizeof big);
    struct sockaddr_can a;
    memset(&a, 0, sizeof a);
    a.can_family = AF_CAN;
    a.can_ifindex = (int)if_nametoindex("vcan0");
    if (a.can_ifindex == 0 || bind(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

/* SocketCAN on vcan0: TX -> own echo latency, one frame at a time (n), and a burst of
 * `burst` frames sent as fast as the socket takes them, until the last is echoed. */
static void gb_probe_sockcan(int n, int burst)
{
    int fd = gb_raw(1);
    if (fd < 0) {
        printf("  SocketCAN probe: no raw socket on vcan0\n");
        EF_CHECK(0);
        return;
    }
    double *lat = calloc((size_t)n, sizeof *lat);
    int got = 0;
    struct can_frame f, r;
    memset(&f, 0, sizeof f);
    f.can_id = GB_PROBE_ID;
    f.can_dlc = 8;
    for (int i = 0; i < n && lat; i++) {
        memcpy(f.data, &i, sizeof i);
        double t0 = gb_now_us();
        if (write(fd, &f, sizeof f) != (ssize_t)sizeof f)
            break;
        struct pollfd p = {fd, POLLIN, 0};
        while (poll(&p, 1, 1000) == 1 && read(fd, &r, sizeof r) == (ssize_t)sizeof r)
            if (r.can_id == GB_PROBE_ID && !memcmp(r.data, &i, sizeof i)) {
                lat[got++] = gb_now_us() - t0;
                break;
            }
    }
    gb_report("SocketCAN (vcan0): TX -> own echo", lat, got, "us");
    EF_CHECK(got == n);
    free(lat);
    /* Burst: vcan has no bitrate, so this is the kernel's and the socket's rate. */
    double t0 = gb_now_us();
    int sent = 0, echoed = 0;
    while (echoed < burst && gb_now_us() - t0 < 20e6) {
        if (sent < burst) {
            f.data[0] = (uint8_t)sent;
            if (write(fd, &f, sizeof f) == (ssize_t)sizeof f)
                sent++;
        }
        struct pollfd p = {fd, POLLIN, 0};
        while (poll(&p, 1, sent < burst ? 0 : 100) == 1 &&
               read(fd, &r, sizeof r) == (ssize_t)sizeof r)
            echoed += r.can_id == GB_PROBE_ID;
    }
    double dt = (gb_now_us() - t0) * 1e-6;
    printf("  %-44s %8.0f frames/s (%d of %d echoed in %.3f s; vcan has no bitrate)\n",
           "SocketCAN (vcan0): burst of 8-byte frames", echoed / dt, echoed, burst, dt);
    EF_CHECK_EQ(echoed, burst);
    close(fd);
}

/* The adapter through evenfeed's gs_usb transport: the same probe, the latency from the
 * transport's own figures (bulk OUT submitted -> echo received; -> device timestamp). */
static void gb_probe_gsusb(int n, int burst)
{
    static ef_gsusb_t g;
    ef_gsusb_init(&g);
    ef_canif_t ci = ef_gsusb_canif(&g);
    ef_canif_cfg_t c;
    memset(&c, 0, sizeof c);
    c.name = GS_SERIAL;
    c.bitrate = 1000000;
    ef_msg_t m;
    if (ef_canif_open(&ci, &c, &m) != EF_OK) {
        printf("  gs_usb probe: %s\n", m.text);
        EF_CHECK(0);
        return;
    }
    ef_can_frame_t f, r;
    memset(&f, 0, sizeof f);
    f.id = GB_PROBE_ID;
    f.dlc = 8;
    ef_gsusb_stats_t st;
    double *lat = calloc((size_t)n, sizeof *lat);
    int got = 0;
    for (int i = 0; i < n && lat; i++) {
        ef_gsusb_stats(&g, &st);
        uint64_t before = st.echo.n, sum0 = st.echo.sum_us;
        memcpy(f.data, &i, sizeof i);
        if (ef_canif_send(&ci, &f) != EF_OK)
            break;
        double t0 = gb_now_us();
        while (gb_now_us() - t0 < 1e6) {
            (void)ef_canif_recv(&ci, &r, NULL, 2000);
            ef_gsusb_stats(&g, &st);
            if (st.echo.n > before)
                break;
        }
        if (st.echo.n > before)
            lat[got++] = (double)(st.echo.sum_us - sum0);
    }
    gb_report("gs_usb (USB adapter): TX -> echo", lat, got, "us");
    ef_gsusb_stats(&g, &st);
    printf("  %-44s mean %8.1f us over %llu frames (device timestamp, without the way back)\n",
           "gs_usb: TX -> on the bus", ef_gsusb_lat_mean(&st.echo_dev),
           (unsigned long long)st.echo_dev.n);
    EF_CHECK(got == n);
    free(lat);
    double t0 = gb_now_us();
    ef_gsusb_stats(&g, &st);
    uint64_t e0 = st.echo.n;
    int sent = 0;
    while (st.echo.n - e0 < (uint64_t)burst && gb_now_us() - t0 < 30e6) {
        while (sent < burst) {
            f.data[0] = (uint8_t)sent;
            if (ef_canif_send(&ci, &f) != EF_OK)
                break;
            sent++;
        }
        (void)ef_canif_flush(&ci);
        (void)ef_canif_recv(&ci, &r, NULL, 1000);
        ef_gsusb_stats(&g, &st);
    }
    double dt = (gb_now_us() - t0) * 1e-6;
    uint64_t echoed = st.echo.n - e0;
    printf("  %-44s %8.0f frames/s (%llu of %d echoed in %.3f s; 1 Mbit/s bus: at most %.0f)\n",
           "gs_usb (USB adapter): burst of 8-byte frames", (double)echoed / dt,
           (unsigned long long)echoed, burst, dt, 1e6 / ef_can_frame_bits(&f));
    printf("  %-44s %u at most unconfirmed, %u frames held, %u bad IN transfers\n",
           "gs_usb: TX window", st.max_in_flight, st.held, st.bad_frames);
    EF_CHECK_EQ(echoed, (uint64_t)burst);
    ef_canif_close(&ci);
}

/* canbusload's per-second lines for vcan0: mean over the seconds with traffic, and max. */
static void gb_busload(const char *path, double *mean, double *mx, int *secs)
{
    *mean = *mx = 0;
    *secs = 0;
    FILE *f = fopen(path, "r");
    if (!f)
        return;
    char line[256];
    double s = 0;
    while (fgets(line, sizeof line, f)) {
        char ifn[64];
        unsigned long frames, bits, payload;
        int pct;
        if (sscanf(line, " %63s %lu %lu %lu %d%%", ifn, &frames, &bits, &payload, &pct) == 5 &&
            !strncmp(ifn, "vcan0@", 6) && frames > 0) {
            s += pct;
            *mx = fmax(*mx, pct);
            (*secs)++;
        }
    }
    fclose(f);
    *mean = *secs ? s / *secs : 0;
}

/* One stream of the profile (mode) with canbusload on vcan0 beside it; prints the figures. */
static void gb_stream(const char *label, const char *mode)
{
    char prog[512], cmd[700], name[64];
    snprintf(prog, sizeof prog, "%s", gs_program() ? g_prog : "(no program)");
    snprintf(name, sizeof name, "bench-%s-%s", g_can[0] == 'g' ? "gsusb" : "vcan", mode);
    tm_proc_t d[4] = {{0}}, load;
    if (hil_start(d, NULL) != 0) {
        EF_CHECK(0);
        hil_stop(d);
        return;
    }
    snprintf(cmd, sizeof cmd, "exec canbusload -e vcan0@1000000 >%s/%s.load", g_out, name);
    char *cl[] = {"sh", "-c", cmd, NULL};
    EF_CHECK_EQ(tm_spawn(cl, 0, &load), 0);
    int rc = hil_stream(name, mode, "1,2,3", NULL, prog);
    tm_stop(&load, SIGINT);
    hil_stop(d);
    EF_CHECK_EQ(rc, 0);
    char path[512];
    snprintf(path, sizeof path, "%s/%s.out", g_out, name);
    char *o = hil_slurp(path);
    const char *b = o ? strstr(o, "bus: master sent ") : NULL;
    const char *w = o ? strstr(o, "wall time ") : NULL;
    unsigned long tx = 0, rx = 0;
    double load_ef = -1, wall = 0;
    if (b)
        (void)sscanf(b, "bus: master sent %lu frames", &tx);
    const char *rcv = b ? strstr(b, "received ") : NULL;
    if (rcv)
        (void)sscanf(rcv, "received %lu frames", &rx);
    const char *ld = b ? strstr(b, "; load ") : NULL;
    if (ld)
        (void)sscanf(ld, "; load %lf", &load_ef);
    if (w)
        (void)sscanf(w, "wall time %lf", &wall);
    free(o);
    snprintf(path, sizeof path, "%s/%s.load", g_out, name);
    double lm, lx;
    int secs;
    gb_busload(path, &lm, &lx, &secs);
    printf("  %-12s %-8s %7.0f frames/s (%lu sent, %lu received in %.2f s); bus load: evenfeed"
           " %.1f %%, canbusload mean %.1f %% (max %.0f %%, %d s)\n",
           label, mode, wall > 0 ? (tx + rx) / wall : 0, tx, rx, wall, load_ef, lm, lx, secs);
    EF_CHECK(tx > 0 && secs > 0);
}

/* The benchmark: probes, then the standard stream in both modes, SocketCAN then gs_usb, all
 * in the same guest on the same vcan0 (the adapter bridges to it). */
static void part_gsusb_bench(void)
{
    printf("TX latency and burst rate (%d frames one at a time, then a burst of %d):\n", 2000,
           5000);
    gb_probe_sockcan(2000, 5000);
    tm_proc_t a;
    if (gs_start(&a, NULL) != 0) {
        EF_CHECK(0);
        return;
    }
    gb_probe_gsusb(2000, 5000);
    printf("The sample profile at half feed to three drives, segment mode with SYNC every 40 ms,"
           " CSP every 20 ms (frames/s of the master; bus load of vcan0 at a nominal 1 Mbit/s):\n");
    static const char *modes[] = {"segment", "csp"};
    for (int k = 0; k < 2; k++) {
        /* the same stream through both (the adapter's transfer bounds aside) */
        g_can_extra = gs_mode_extra(modes[k], 0);
        g_can = "vcan0";
        gb_stream("SocketCAN", modes[k]);
        g_can_extra = gs_mode_extra(modes[k], 1);
        g_can = "gsusb:" GS_SERIAL "@1000000";
        gb_stream("gs_usb", modes[k]);
    }
    gs_stop(&a);
}

static void hil_run_gsusb_csp(void)
{
    part_gsusb_stream("csp");
}

static void hil_run_gsusb_segment(void)
{
    part_gsusb_stream("segment");
}

/* Parts for the runner (main): the streaming modes, and the faults (named by the part). */
static void hil_run_csp(void)
{
    part_stream("csp", 0);
}

/* Nine axes over SocketCAN (docs/axes.md): five drives, node k moving x y z A B, and a
 * program that turns A and B with X Y through blends and alone, streamed in segment mode and
 * then in CSP; every drive reaches OPERATION ENABLED, follows within HIL_FERR_TOL, accepts
 * its segments in order once each (segment mode), and ends at its axis's programmed end. */
static void part_axes(void)
{
    char prog[512];
    snprintf(prog, sizeof prog, "%s/axes.ngc", g_out);
    FILE *f = fopen(prog, "w");
    EF_CHECK(f != NULL);
    if (!f)
        return;
    fputs("G21 G90 G64 P0.05\n"
          "G1 X10 A20 F1200\n"
          "G1 X20 Y4 A30 B-10\n"
          "G1 X30 Y0 A10\n"
          "G1 A60 F1800\n"
          "G1 X20 Y-5 B5 F1200\n"
          "G1 X0 Y0 A45 B0\n"
          "M2\n",
          f);
    fclose(f);
    static const double want[5] = {0, 0, 0, 45, 0};
    static const char *const modes[2] = {"segment", "csp"};
    for (int mi = 0; mi < 2; mi++) {
        tm_proc_t d[6] = {{0}};
        int ok = 1;
        for (int n = 1; n <= 5 && ok; n++)
            ok = hil_drive(&d[n], n, NULL) == 0;
        /* a rotary tolerance that lets the corners blend (docs/axes.md: 0.02 deg stops) */
        int rc =
            ok ? hil_stream("stream", modes[mi], "1,2,3,4,5", "--aux-tol 0.5 --keep-blends", prog)
               : -1;
        for (int n = 1; n <= 5; n++)
            if (d[n].pid > 0)
                tm_stop(&d[n], SIGTERM);
        EF_CHECK_EQ(rc, 0);
        for (int node = 1; node <= 5; node++) {
            hil_dtrace_t T;
            EF_CHECK_EQ(hil_dtrace_load(node, &T), 0);
            EF_CHECK(T.reached_op);
            double fe = 0, end = T.np ? T.p[T.np - 1].cmd : NAN;
            for (size_t i = 0; i < T.np; i++)
                fe = fmax(fe, T.p[i].ferr);
            int inorder = 1;
            for (size_t i = 0; i < T.ns && inorder; i++)
                inorder = T.seq[i] == (long)i;
            printf("axes %s: node %d (%c): %zu SYNC steps, %zu segments, following error max "
                   "%.4f, end %.4f (programmed %g)\n",
                   modes[mi], node, "xyzab"[node - 1], T.np, T.ns, fe, end, want[node - 1]);
            EF_CHECK(fe <= HIL_FERR_TOL);
            EF_CHECK(inorder);
            EF_CHECK(fabs(end - want[node - 1]) <= 1e-3);
            if (mi == 0)
                EF_CHECK(T.ns > 6); /* the six lines and blends between them */
            hil_dtrace_free(&T);
        }
    }
}

static void hil_run_segment(void)
{
    part_stream("segment", 0);
}

static void hil_run_drop(void)
{
    part_stream("segment", 1);
}

static void hil_run_fault(void)
{
    part_fault(ef_t_part);
}

/* test_can_hil EVENFEED SRC_DIR OUT_DIR PART: one part per guest (tests/hil/can.sh). */
int main(int argc, char **argv)
{
    static const ef_test_part_t parts[] = {
        {"csp", hil_run_csp},
        {"segment", hil_run_segment},
        {"axes", part_axes},
        {"drop", hil_run_drop},
        {"emcy", hil_run_fault},
        {"heartbeat", hil_run_fault},
        {"busoff", hil_run_fault},
        {"boot", part_boot},
        {"start", part_start},
        {"masterdeath", part_masterdeath},
        {"io_estop", part_io_estop},
        {"io_start", part_io_start},
        {"io_alarm", part_io_alarm},
        {"io_pump", part_io_pump},
        {"io_hold", part_io_hold},
        {"io_hold_seg", part_io_hold_seg},
        {"io_modbus_hold", part_io_modbus_hold},
        {"io_modbus_hold_direct", part_io_modbus_hold_direct},
        {"io_outputs", part_io_outputs},
        {"io_modbus", part_io_modbus},
        {"io_gpioerr", part_io_gpioerr},
        {"io_sto", part_io_sto},
        {"io_modbus_sto", part_io_modbus_sto},
        {"io_latency", part_io_latency},
        {"gsusb_csp", hil_run_gsusb_csp},
        {"gsusb_segment", hil_run_gsusb_segment},
        {"gsusb_unplug", part_gsusb_unplug},
        {"gsusb_bitrate", part_gsusb_bitrate},
        {"gsusb_claimed", part_gsusb_claimed},
        {"gsusb_faults", part_gsusb_faults},
        {"gsusb_bench", part_gsusb_bench},
    };
    if (argc < 5) {
        fprintf(stderr, "usage: test_can_hil EVENFEED SRC_DIR OUT_DIR PART\n");
        return 2;
    }
    setvbuf(stdout, NULL, _IOLBF, 0); /* the verdict file keeps what was printed before a crash */
    g_ef = argv[1];
    g_src = argv[2];
    g_out = argv[3];
    tm_evenfeed = g_ef;
    mkdir(g_out, 0777);
    return EF_TEST_RUN(argc, argv, 4, parts);
}
