/* SPDX-License-Identifier: Apache-2.0 */
/*
 * Throughput of the runtime chain on a CAM-like part program (tests/bench/gen_cam.c,
 * docs/benchmarks-smoothing.md):
 *   read    the G-code reader alone (ef_gcode_next over the whole program)
 *   smooth  reader -> ef_smooth_push / ef_smooth_pull (moves pulled and dropped)
 *   interp  reader -> smoother -> ef_interp_process every 1 ms (setpoints dropped)
 * The program is loaded into memory once; each mode runs REPEAT times and the fastest run
 * (process CPU time, so other load on the machine matters little) is reported (lines/s,
 * primitives/s, moves/s, and for interp setpoints/s and the machining time it simulates).
 *
 * Usage: bench_smooth FILE [read|smooth|interp|all] [REPEAT]      (defaults all, 3)
 *
 * Under callgrind the "smooth" mode with REPEAT 1 gives the instructions per pulled move:
 *   valgrind --tool=callgrind --toggle-collect=ef_smooth_push --toggle-collect=ef_smooth_pull
 *            --toggle-collect=ef_smooth_finish bench_smooth FILE smooth 1
 * and the total divided by the "moves" figure of the line "smooth-count" (run_all.sh does
 * this). Item conversion follows ef_pipeline.h: G0 is a line at the rapid speed with exact
 * stops at both ends, events bring the smoother to rest, G64 P Q set tol and qtol (P absent:
 * 0.02 mm), G61 tol 0.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "evenfeed/core/ef_err.h"
#include "evenfeed/motion/ef_interp.h"
#include "evenfeed/path/ef_path.h"
#include "evenfeed/motion/ef_smooth.h"
#include "evenfeed/host/program/ef_gcode.h"
#include "evenfeed/host/core/ef_host.h"

extern const ef_table_t ef_tbl_g2_default;

#define TOL_DEFAULT 0.02
#define RAPID_SPEED 100.0 /* mm/s */

enum { MODE_READ, MODE_SMOOTH, MODE_INTERP };
static const char *const mode_name[3] = {"read", "smooth", "interp"};

typedef struct {
    long lines, items, prims, moves, setpoints, events, notes, refused, restarts, underruns;
    double seconds;
    ef_smooth_stats_t st;
} run_t;

static ef_gcode_t rd;
static ef_smooth_t sm;
static ef_interp_t ip;
static const char *text;
static size_t text_len;
static const char *text_name;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Reader item -> primitive (positions mm, feed mm/s). */
static void item_prim(const ef_gcode_item_t *it, ef_prim_t *pr)
{
    memset(pr, 0, sizeof *pr);
    pr->end = ef_v3((float)it->end[0], (float)it->end[1], (float)it->end[2]);
    pr->tag = it->line;
    if (it->kind == EF_GC_ARC) {
        pr->kind = EF_PRIM_ARC;
        pr->centre = ef_v3((float)it->centre[0], (float)it->centre[1], (float)it->centre[2]);
        pr->axis = it->plane == 17   ? ef_v3(0.0f, 0.0f, 1.0f)
                   : it->plane == 18 ? ef_v3(0.0f, 1.0f, 0.0f)
                                     : ef_v3(1.0f, 0.0f, 0.0f);
        pr->sweep = (float)it->sweep;
    } else {
        pr->kind = EF_PRIM_LINE;
    }
    pr->feed = it->kind == EF_GC_RAPID ? (float)RAPID_SPEED : (float)(it->feed / 60.0);
}

/* Run the interpolator until its queue has room (until_rest 0) or until it is at rest (1),
 * or (2) until it is at rest or has run dry (after the smoother failed to finish). */
static int interp_run(run_t *r, int until_rest)
{
    ef_setpoint_t sp;
    uint32_t next;
    for (;;) {
        if (!until_rest && ef_interp_space(&ip) > 0)
            return 0;
        int rc = ef_interp_process(&ip, 1000u, &next, &sp);
        if (rc == EF_ERR_UNDERRUN && until_rest == 2) {
            r->underruns++;
            return 0;
        }
        if (rc != EF_OK) {
            fprintf(stderr, "bench_smooth: ef_interp_process: %s\n", ef_err_str(rc));
            return 1;
        }
        r->setpoints++;
        if (until_rest && !sp.moving && ef_interp_space(&ip) == EF_INTERP_QUEUE)
            return 0;
    }
}

/* Pull every available move (and feed the interpolator in interp mode). */
static int drain(run_t *r, int mode)
{
    ef_move_t m;
    while (ef_smooth_pull(&sm, &m) == EF_OK) {
        r->moves++;
        if (mode == MODE_INTERP) {
            int rc;
            while ((rc = ef_interp_push(&ip, &m)) == EF_ERR_FULL)
                if (interp_run(r, 0))
                    return 1;
            if (rc != EF_OK) {
                fprintf(stderr, "bench_smooth: ef_interp_push: %s\n", ef_err_str(rc));
                return 1;
            }
        }
    }
    return 0;
}

/* Finish (one work unit a call, ef_smooth.h) until everything is built, draining between. */
static int finish_all(run_t *r, int mode)
{
    int rc;
    while ((rc = ef_smooth_finish(&sm)) == EF_ERR_FULL)
        if (drain(r, mode))
            return 1;
    if (rc != EF_OK) {
        fprintf(stderr, "bench_smooth: ef_smooth_finish: %s\n", ef_err_str(rc));
        return 1;
    }
    return drain(r, mode);
}

static int finish(run_t *r, int mode)
{
    if (finish_all(r, mode))
        return 1;
    return mode == MODE_INTERP ? interp_run(r, 1) : 0;
}

/* Init the smoother (and in interp mode the interpolator) at rest at p. */
static int chain_init(int mode, ef_vec3_t p)
{
    ef_smooth_cfg_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.g2 = &ef_tbl_g2_default;
    for (int k = 0; k < 3; k++) {
        cfg.lim.v_axis[k] = 200.0f;
        cfg.lim.a_axis[k] = 1000.0f;
    }
    cfg.lim.j_max = 0.0f;
    cfg.lim.a_normal_frac = 0.5f;
    cfg.micro_len = 1.0f;
    cfg.micro_turn = 0.35f;
    cfg.smooth_degree = 5;
    int rc = ef_smooth_init(&sm, &cfg, p);
    if (rc == EF_OK && mode == MODE_INTERP)
        rc = ef_interp_init(&ip, p, 1000u, EF_STEP_UNIFORM);
    if (rc != EF_OK)
        fprintf(stderr, "bench_smooth: init: %s\n", ef_err_str(rc));
    return rc != EF_OK;
}

/* Add the smoother's counters to the run's (several when the chain was restarted). */
static void add_stats(run_t *r)
{
    ef_smooth_stats_t st = ef_smooth_stats(&sm);
    r->st.prims += st.prims;
    r->st.moves += st.moves;
    r->st.blends += st.blends;
    r->st.straight += st.straight;
    r->st.stops += st.stops;
    r->st.reversals += st.reversals;
    r->st.merged += st.merged;
    r->st.smooth += st.smooth;
    r->st.arc_pieces += st.arc_pieces;
    r->st.dev_max = st.dev_max > r->st.dev_max ? st.dev_max : r->st.dev_max;
}

/* The smoother refused a primitive (reported; the first few on stderr): bring what it accepted
 * to rest as far as it can, then start the chain again at rest at the primitive's end. */
static int restart(run_t *r, int mode, const ef_gcode_item_t *it, int err)
{
    static int printed;
    r->refused++;
    if (printed++ < 3)
        fprintf(stderr, "bench_smooth: %s:%u: primitive refused: %s (chain restarted)\n", text_name,
                it->line, ef_err_str(err));
    r->restarts++;
    if (finish_all(r, mode))
        return 1;
    if (mode == MODE_INTERP && interp_run(r, 2))
        return 1;
    add_stats(r);
    return chain_init(mode, ef_v3((float)it->end[0], (float)it->end[1], (float)it->end[2]));
}

static int run_once(int mode, run_t *r)
{
    memset(r, 0, sizeof *r);
    ef_msg_t msg;
    ef_gcode_item_t it;
    double t0 = now();
    ef_gcode_init(&rd, text, text_len, text_name);
    if (mode != MODE_READ && chain_init(mode, ef_v3(0.0f, 0.0f, 0.0f)))
        return 1;
    double tol = TOL_DEFAULT, qtol = 0;
    int stop_next = 1;
    for (;;) {
        int rc = ef_gcode_next(&rd, &it, &msg);
        if (rc != EF_OK) {
            fprintf(stderr, "bench_smooth: %s\n", msg.text);
            return 1;
        }
        r->items++;
        if (mode == MODE_READ) {
            r->prims += it.kind == EF_GC_RAPID || it.kind == EF_GC_LINE || it.kind == EF_GC_ARC;
            if (it.kind == EF_GC_END)
                break;
            continue;
        }
        switch (it.kind) {
        case EF_GC_RAPID:
        case EF_GC_LINE:
        case EF_GC_ARC: {
            ef_prim_t pr;
            item_prim(&it, &pr);
            pr.tol = (float)tol;
            pr.qtol = (float)qtol;
            int rapid = it.kind == EF_GC_RAPID;
            if (stop_next || rapid)
                pr.flags |= EF_PRIM_STOP_BEFORE;
            while ((rc = ef_smooth_push(&sm, &pr)) == EF_ERR_FULL)
                if (drain(r, mode))
                    return 1;
            if (rc != EF_OK) {
                if (restart(r, mode, &it, rc))
                    return 1;
                stop_next = 1;
                break;
            }
            r->prims++;
            stop_next = rapid;
            if (drain(r, mode))
                return 1;
            break;
        }
        case EF_GC_EVENT:
            r->events++;
            if (finish(r, mode))
                return 1;
            stop_next = 1;
            break;
        case EF_GC_TOLERANCE:
            if (it.path_mode == EF_GC_PATH_EXACT) {
                tol = 0;
            } else {
                tol = it.p_tol > 0 ? it.p_tol : TOL_DEFAULT;
                qtol = it.q_tol;
            }
            break;
        case EF_GC_END:
            break;
        default:
            r->notes++;
            break;
        }
        if (it.kind == EF_GC_END) {
            if (finish(r, mode))
                return 1;
            break;
        }
    }
    r->seconds = now() - t0;
    for (size_t i = 0; i < text_len; i++)
        r->lines += text[i] == '\n';
    if (mode != MODE_READ)
        add_stats(r);
    return 0;
}

static void report(int mode, const run_t *r)
{
    double s = r->seconds > 0 ? r->seconds : 1e-9;
    printf("%-6s %7ld lines %7ld prims %8ld moves in %7.3f CPU s: %9.0f lines/s %9.0f prims/s",
           mode_name[mode], r->lines, r->prims, r->moves, r->seconds, (double)r->lines / s,
           (double)r->prims / s);
    if (mode != MODE_READ)
        printf(" %9.0f moves/s (%.2f us/move)", (double)r->moves / s,
               1e6 * s / (double)(r->moves ? r->moves : 1));
    printf("\n");
    if (mode == MODE_INTERP)
        printf(
            "       %ld setpoints at 1 ms (machining time %.1f s) in %.3f CPU s: %.0f setpoints/s, "
            "%.0fx real time\n",
            r->setpoints, 1e-3 * (double)r->setpoints, r->seconds, (double)r->setpoints / s,
            1e-3 * (double)r->setpoints / s);
    if (mode == MODE_SMOOTH) {
        printf("       smoother: %u blends, %u smooth vertices, %u merged, %u straight, %u stops "
               "(%u reversals), %u arc pieces, dev_max %.4f mm; %ld events, %ld notes\n",
               r->st.blends, r->st.smooth, r->st.merged, r->st.straight, r->st.stops,
               r->st.reversals, r->st.arc_pieces, (double)r->st.dev_max, r->events, r->notes);
        printf("smooth-count: moves %ld prims %ld\n", r->moves, r->prims);
    }
    if (mode != MODE_READ && r->refused)
        printf("       WARNING: %ld primitives refused by the smoother (chain restarted at rest "
               "after each; %ld interpolator underruns)\n",
               r->refused, r->underruns);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s FILE [read|smooth|interp|all] [REPEAT]\n", argv[0]);
        return 2;
    }
    const char *which = argc > 2 ? argv[2] : "all";
    int repeat = argc > 3 ? atoi(argv[3]) : 3;
    if (repeat < 1)
        repeat = 1;
    ef_msg_t msg;
    int rc = ef_gcode_open(&rd, argv[1], &msg);
    if (rc != EF_OK) {
        fprintf(stderr, "bench_smooth: %s\n", msg.text);
        return 1;
    }
    /* Keep the loaded text; every run re-initialises a reader over it. */
    text = rd.buf;
    text_len = rd.len;
    text_name = argv[1];
    rd.buf = NULL;
    int status = 0;
    for (int mode = MODE_READ; mode <= MODE_INTERP; mode++) {
        if (strcmp(which, "all") != 0 && strcmp(which, mode_name[mode]) != 0)
            continue;
        run_t best, r;
        memset(&best, 0, sizeof best);
        for (int k = 0; k < repeat; k++) {
            if (run_once(mode, &r)) {
                status = 1;
                break;
            }
            if (k == 0 || r.seconds < best.seconds)
                best = r;
        }
        if (status)
            break;
        report(mode, &best);
    }
    free((void *)text);
    return status;
}
