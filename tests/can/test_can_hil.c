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
 */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "ef_proc.h"
#include "ef_test.h"
#include "evenfeed/canopen/ef_canopen.h"
#include "evenfeed/drive/ef_drive.h"
#include "evenfeed/host/can/ef_canload.h"
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
/** Heartbeat consumer time (ms) of the streamer: an emulated kernel on a loaded 2-core
 *  machine can hold a process back for a few hundred ms (SYNC gaps of 180 ms were seen), so
 *  the 200 ms default would report healthy drives as lost. */
#define HIL_HB_TIMEOUT "1000"
/** Fault injection time used by the fault parts (ms of drive time in OPERATION ENABLED):
 *  on the standard path x and y are then both moving at 20 mm/s, on an arc. */
#define HIL_FAULT_MS "5000"

static const char *g_ef, *g_src, *g_out;

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
    snprintf(cmd, sizeof cmd,
             "%s stream --can vcan0 --nodes %s --mode %s --hb-timeout " HIL_HB_TIMEOUT
             " --log %s/%s.log --trace %s/%s.csv %s %s"
             " >%s/%s.out 2>%s/%s.err",
             g_ef, nodes, mode, g_out, name, g_out, name, extra ? extra : "", prog, g_out, name,
             g_out, name);
    int st = system(cmd);
    int rc = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    char path[512];
    snprintf(path, sizeof path, "%s/%s.out", g_out, name);
    char *o = hil_slurp(path);
    snprintf(path, sizeof path, "%s/%s.err", g_out, name);
    char *e = hil_slurp(path);
    printf("--- stream %s (%s), exit %d\n%s%s", name, mode, rc, o ? o : "", e ? e : "");
    free(o);
    free(e);
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
} hil_dtrace_t;

/* Open OUT/NAME for reading and clear the trace it fills (NULL if it is not there). */
static FILE *hil_open_trace(const char *name, void *trace, size_t size)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", g_out, name);
    memset(trace, 0, size);
    return fopen(path, "r");
}

/* Parse a drive trace (p/s/e lines). */
static int hil_dtrace_load(int node, hil_dtrace_t *T)
{
    char name[32];
    snprintf(name, sizeof name, "drive%d.csv", node);
    FILE *f = hil_open_trace(name, T, sizeof *T);
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
    char line[256];
    long n = 0, bad = 0;
    while (fgets(line, sizeof line, f)) {
        double t;
        char ifn[32], frame[64];
        n++;
        if (sscanf(line, "(%lf) %31s %63s", &t, ifn, frame) != 3 || !strchr(frame, '#'))
            bad++;
    }
    fclose(f);
    EF_CHECK(n > 100);
    EF_CHECK_EQ(bad, 0);
    snprintf(cmd, sizeof cmd, "log2asc -I %s vcan0 > %s/%s.asc 2>&1", path, g_out, name);
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
        double fmax_ = 0;
        for (size_t i = 0; i < T.np; i++)
            fmax_ = fmax(fmax_, T.p[i].ferr);
        printf("%s: node %d: %zu SYNC steps, following error max %.4f mm, %zu segments"
               " accepted\n",
               what, node, T.np, fmax_, T.ns);
        EF_CHECK(fmax_ <= HIL_FERR_TOL);
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
 * (0x2003, 500 ms), reports EMCY 0x8130 and stops under control on its own clock: the
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

/* Parts for the runner (main): the streaming modes, and the faults (named by the part). */
static void hil_run_csp(void)
{
    part_stream("csp", 0);
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
        {"csp", hil_run_csp},    {"segment", hil_run_segment}, {"drop", hil_run_drop},
        {"emcy", hil_run_fault}, {"heartbeat", hil_run_fault}, {"busoff", hil_run_fault},
        {"boot", part_boot},     {"start", part_start},        {"masterdeath", part_masterdeath},
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
