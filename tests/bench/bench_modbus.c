/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Modbus throughput, measured side by side in one run (docs/benchmarks-modbus.md):
 *  - segment mode: sustained slot writes per second while streaming the standard path
 *    (flow control and status reads included), over TCP on loopback and over RTU at
 *    115200 baud 8E1 (socat pseudo-terminals; the simulated drive holds each reply for
 *    the frames' time on a real 115200 baud line, since a pty has no baud rate);
 *  - direct mode: target writes per second (one FC16 of 6 registers each), same links;
 *  - what each sustains on the path: segment mode needs, at the programmed feed, at most
 *    S_req segments/s over any 16 consecutive segments (the ring's depth); direct mode
 *    interpolates linearly between targets, so following the path within its tolerance P
 *    on curvature kappa at speed v needs a target every sqrt(8 P / kappa) / v seconds.
 *    The feed override each sustains is printed (100 % = as programmed).
 *
 * usage: bench_modbus EVENFEED SOURCE_DIR [program.ngc]
 */
#include <math.h>
#include <modbus/modbus.h>
#include "../ef_proc.h"
#include "evenfeed/host/modbus/ef_mb.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

#define BM_RING 16

typedef struct {
    double *dur;
    uint32_t n, cap;
    double direct_need; /* largest v * sqrt(kappa / (8 P)) over the moves: targets/s needed */
    double tol;
} bm_path_t;

/* Record the path's segment durations and the direct-mode target rate it needs. */
static int bm_on_move(void *user, const ef_move_t *mv, const ef_pipe_move_info_t *mi)
{
    bm_path_t *P = user;
    if (P->n == P->cap) {
        P->cap = P->cap ? 2 * P->cap : 256;
        P->dur = realloc(P->dur, P->cap * sizeof *P->dur);
    }
    P->dur[P->n++] = mv->duration;
    double v = fmax(fmax(mv->v_entry, mv->v_exit), mv->length / fmax(mv->duration, 1e-9));
    double tol = mi->tol > 0 ? mi->tol : P->tol;
    if (mv->kappa_max > 0 && !mi->rapid) {
        double need = v * sqrt(mv->kappa_max / (8.0 * tol));
        P->direct_need = fmax(P->direct_need, need);
    }
    return 0;
}

/* One streaming run; returns segments/s while writing (or targets/s). */
static double bm_stream(const char *url, const char *prog, int mode, ef_mb_stream_result_t *res)
{
    static ef_gcode_t r;
    ef_msg_t m = {{0}};
    ef_mb_stream_cfg_t c;
    ef_mb_stream_cfg_default(&c, &ef_tbl_g2_default, &ef_tbl_g1_default);
    c.mode = mode;
    c.direct_hz = 10000;
    c.mb.timeout_s = 0.5;
    if (ef_mb_url_parse(url, &c.mb, &m) != EF_OK || ef_gcode_open(&r, prog, &m) != EF_OK) {
        fprintf(stderr, "bench_modbus: %s\n", m.text);
        return 0;
    }
    int rc = ef_mb_stream(&r, &c, res, &m);
    ef_gcode_free(&r);
    if (rc != EF_OK) {
        fprintf(stderr, "bench_modbus: %s: %s\n", url, m.text);
        return 0;
    }
    double span = res->io.t_last - res->io.t_first;
    return span > 0 ? (res->io.slot_writes - 1) / span : 0;
}

/* Direct mode: n target writes as fast as the link answers. */
static double bm_targets(const char *url, int n)
{
    ef_mb_cfg_t c;
    ef_mb_master_t *ms = NULL;
    ef_msg_t m = {{0}};
    ef_mb_cfg_default(&c);
    c.timeout_s = 0.5;
    if (ef_mb_url_parse(url, &c, &m) != EF_OK || ef_mb_open(&c, &ms, &m) != EF_OK ||
        ef_mb_begin(ms, EF_MB_MODE_DIRECT, &m) != EF_OK) {
        fprintf(stderr, "bench_modbus: %s\n", m.text);
        ef_mb_close(ms);
        return 0;
    }
    double t0 = ef_mb_now();
    for (int i = 0; i < n; i++) {
        float p[3] = {0.001f * (float)i, 0.0f, 0.0f};
        if (ef_mb_target(ms, p, &m) != EF_OK) {
            fprintf(stderr, "bench_modbus: %s\n", m.text);
            break;
        }
    }
    double rate = n / (ef_mb_now() - t0);
    ef_mb_end(ms, &m);
    ef_mb_close(ms);
    return rate;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: bench_modbus EVENFEED SOURCE_DIR [program.ngc]\n");
        return 2;
    }
    signal(SIGPIPE, SIG_IGN);
    tm_evenfeed = argv[1];
    char prog[512];
    if (argc > 3)
        snprintf(prog, sizeof prog, "%s", argv[3]);
    else
        snprintf(prog, sizeof prog, "%s/samples/profile.ngc", argv[2]);

    /* The path: what each mode needs at the programmed feed. */
    static ef_gcode_t r;
    ef_msg_t m = {{0}};
    ef_pipe_cfg_t pc;
    ef_pipe_cfg_default(&pc);
    pc.g2 = &ef_tbl_g2_default;
    pc.g1 = &ef_tbl_g1_default;
    bm_path_t P = {0};
    P.tol = pc.tol_default;
    ef_pipe_cb_t cb = {0};
    cb.on_move = bm_on_move;
    cb.user = &P;
    ef_pipe_stats_t st;
    if (ef_gcode_open(&r, prog, &m) != EF_OK || ef_pipe_run(&r, &pc, &cb, &st, &m) != EF_OK) {
        fprintf(stderr, "bench_modbus: %s\n", m.text);
        return 1;
    }
    ef_gcode_free(&r);
    double total = 0, need_seg = 0;
    for (uint32_t i = 0; i < P.n; i++)
        total += P.dur[i];
    for (uint32_t i = 0; i + BM_RING <= P.n; i++) {
        double w = 0;
        for (uint32_t k = 0; k < BM_RING; k++)
            w += P.dur[i + k];
        need_seg = fmax(need_seg, BM_RING / w);
    }
    printf("path %s: %u segments, %.2f s at the programmed feed: %.1f segments/s on average, "
           "%.1f segments/s at most over %d consecutive ones;\n"
           "direct targets needed to stay within the tolerance on its curves: %.0f per second\n",
           prog, P.n, total, P.n / total, need_seg, BM_RING, P.direct_need);

    /* The links. TCP: a drive on a port the kernel picks; RTU: a socat pty pair, the drive
     * holding each reply for its wire time at 115200 baud. Segment mode is run with the
     * drive's clock at K times real time (the same path at K times the feed, as far as the
     * link is concerned) for growing K until the drive underruns: the largest K that ran
     * the whole path is the feed override the link sustains, measured end to end. Over TCP
     * the simulated drive itself (every servo period computed) is the limit before the
     * link is, so the TCP figure is a lower bound. */
    const char *names[2] = {"TCP loopback", "RTU 115200 8E1"};
    static const char *ks[2][9] = {{"16", "64", "256", NULL}, {"1", "1.25", "1.5", "2", NULL}};
    double k_ok[2] = {0, 0}, seg_rate[2] = {0, 0}, tgt[2] = {0, 0};
    int capped[2] = {0, 0}; /* ran at the largest K tried: the link sustains more */
    for (int link = 0; link < 2; link++) {
        for (int i = 0; ks[link][i]; i++) {
            tm_proc_t d, s = {0, -1};
            int port, ok;
            char url[160], a[64], b[64], addr[128];
            tm_time_scale = ks[link][i];
            if (link == 0) {
                ok = tm_drive(&d, "--tcp", "127.0.0.1:0", NULL, NULL, &port) == 0;
                snprintf(url, sizeof url, "tcp://127.0.0.1:%d", port);
            } else {
                ok = tm_socat(&s, a, b) == 0;
                snprintf(addr, sizeof addr, "%s,115200,8E1", a);
                ok = ok && tm_drive(&d, "--rtu", addr, NULL, "--wire-baud 115200", NULL) == 0;
                snprintf(url, sizeof url, "rtu:%s,115200,8E1", b);
            }
            if (!ok) {
                fprintf(stderr, "bench_modbus: %s: could not start the drive\n", names[link]);
                return 1;
            }
            ef_mb_stream_result_t res;
            double rate = bm_stream(url, prog, EF_MB_MODE_SEGMENT, &res);
            int done = rate > 0 && res.last.done_count == P.n;
            double k = atof(ks[link][i]);
            printf("%-15s segment mode at %6.3gx feed: %s (%u of %u executed, %llu "
                   "transactions, %llu status reads, %.0f segments/s while writing)\n",
                   names[link], k, done ? "ran the whole path" : "underrun or error",
                   res.last.done_count, P.n, (unsigned long long)res.io.transactions,
                   (unsigned long long)res.io.polls, rate);
            if (done) {
                capped[link] = ks[link][i + 1] == NULL;
                k_ok[link] = k;
                seg_rate[link] = need_seg * k;
            }
            if (i == 0) { /* a fresh drive (one that underran is in fault) */
                tgt[link] = bm_targets(url, link == 0 ? 5000 : 200);
                printf("%-15s direct mode:  %.0f target writes/s\n", names[link], tgt[link]);
            }
            tm_stop(&d, SIGTERM);
            if (link == 1)
                tm_stop(&s, SIGTERM);
            if (!done)
                break;
        }
    }
    printf("\nfeed override each sustains on this path (100 %% = as programmed; + : at least, the "
           "largest tried):\n");
    printf("%-15s %24s %24s\n", "link", "segment (peak segs/s)", "direct (targets/s)");
    for (int link = 0; link < 2; link++)
        printf("%-15s %9.0f%% (%6.0f /s)%s %12.0f%% (%6.0f /s)\n", names[link], 100 * k_ok[link],
               seg_rate[link], capped[link] ? "+" : " ", 100 * tgt[link] / P.direct_need,
               tgt[link]);
    free(P.dur);
    return 0;
}
