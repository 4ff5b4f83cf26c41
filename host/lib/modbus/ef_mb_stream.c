/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed stream --modbus as a library call: smooth a program and stream its segments
 * (or, in direct mode, sampled target positions) to one drive. */
#include <math.h>
#include <string.h>
#include <time.h>
#include "evenfeed/host/modbus/ef_mb.h"
#include "evenfeed/host/io/ef_mio.h"
#include "evenfeed/host/io/ef_warp.h"

/* Program lines of the segments sent, by sequence number (the line of the executing one). */
#define MBS_TAGS 1024u

typedef struct {
    const ef_mb_stream_cfg_t *c;
    ef_mb_master_t *ms;
    ef_mb_stream_result_t *res;
    ef_msg_t *m;
    ef_msg_t cbm; /* what a callback's failure was (the pipeline only says it stopped) */
    int cb_rc;
    double t0;      /* direct mode: wall time of the first target */
    double dt;      /* direct mode: the target period (s) */
    int warp_on;    /* direct mode with feed hold: targets through the warp */
    ef_warp_t warp; /* ef_warp.h */
    int estop;
    ef_msg_t estop_msg;
    uint32_t tags[MBS_TAGS];
    uint32_t last_tag;
    int out_noted;
    int begun;     /* the drive is prepared (ef_mb_begin() done) */
    int holding;   /* segment mode: the hold last asked of the drive */
    double hold_t; /* segment mode: when the hold bookkeeping last ran (s) */
} stream_t;

/* Segment mode, at every poll: the drive holds while the feed-hold input asks (the status
 * of the poll before says whether it stood since). */
static int mbs_hold(stream_t *S, ef_msg_t *m)
{
    double now = ef_mb_now();
    const ef_mb_status_t *st = ef_mb_last_status(S->ms);
    if (S->hold_t > 0.0 && (st->status & EF_MB_ST_HELD))
        S->res->held_s += now - S->hold_t;
    S->hold_t = now;
    int want = ef_mio_hold(S->c->mio);
    if (want && !S->holding)
        S->res->holds++;
    S->holding = want;
    return ef_mb_hold(S->ms, want, m);
}

/* Machine I/O at every poll and setpoint: a trip is the error that stops the stream. */
static int mbs_on_poll(void *user, ef_msg_t *m)
{
    stream_t *S = user;
    if (!S->c->mio)
        return 0;
    if (S->estop)
        return ef_fail(m, EF_ERR_ESTOP, "%s", S->estop_msg.text);
    uint32_t nx;
    ef_msg_t mm = {{0}};
    if (ef_mio_process(S->c->mio, &nx, &mm) != EF_ERR_ESTOP) {
        if (S->begun && S->c->mode == EF_MB_MODE_SEGMENT && S->c->mio->cfg.hold >= 0)
            return mbs_hold(S, m);
        return 0;
    }
    S->estop = 1;
    uint32_t line = S->last_tag;
    if (S->ms && S->c->mode == EF_MB_MODE_SEGMENT && S->res->moves > 0) {
        const ef_mb_status_t *st = ef_mb_last_status(S->ms);
        line = S->tags[st->exec_seq % MBS_TAGS];
    }
    S->res->estop_line = line;
    ef_fail(&S->estop_msg, EF_ERR_ESTOP, "%s at program line %u", mm.text, (unsigned)line);
    return ef_fail(m, EF_ERR_ESTOP, "%s", S->estop_msg.text);
}

/* Defaults documented in ef_mb.h. */
void ef_mb_stream_cfg_default(ef_mb_stream_cfg_t *c, const ef_table_t *g2, const ef_table_t *g1)
{
    memset(c, 0, sizeof *c);
    ef_mb_cfg_default(&c->mb);
    ef_pipe_cfg_default(&c->pipe);
    c->pipe.g2 = g2;
    c->pipe.g1 = g1;
    c->mode = EF_MB_MODE_SEGMENT;
    c->direct_hz = 50.0;
}

/* Each planned move goes to the drive as one slot. */
static int mbs_stream_move(void *user, const ef_move_t *mv, const ef_pipe_move_info_t *mi)
{
    (void)mi;
    stream_t *S = user;
    if (S->c->on_move) {
        int rc = S->c->on_move(S->c->user, mv);
        if (rc != 0)
            return rc;
    }
    S->res->path_time += mv->duration;
    S->last_tag = mv->tag;
    if (S->c->mode != EF_MB_MODE_SEGMENT)
        return EF_OK;
    S->tags[S->res->moves % MBS_TAGS] = mv->tag;
    int rc = ef_mb_send(S->ms, mv, &S->cbm);
    S->cb_rc = rc;
    if (rc == EF_OK)
        S->res->moves++;
    if (rc == EF_OK && S->c->verbose && S->res->moves % 200 == 0)
        fprintf(stderr, "stream: %u segments sent\n", S->res->moves);
    return rc;
}

/* Direct mode: one target, written when its time comes (the k-th at t0 + k periods: real
 * time; a feed hold's warp gives more targets than setpoints, each a period apart). */
static int mbs_target(stream_t *S, const float *p, uint32_t tag)
{
    double now = ef_mb_now();
    if (S->res->targets == 0)
        S->t0 = now;
    double wait = S->t0 + S->res->targets * S->dt - now;
    if (wait > 0.0) {
        struct timespec ts = {(time_t)wait, (long)((wait - floor(wait)) * 1e9)};
        nanosleep(&ts, NULL);
    }
    S->last_tag = tag;
    int rc = mbs_on_poll(S, &S->cbm);
    if (rc != 0)
        return S->cb_rc = rc;
    rc = ef_mb_target(S->ms, p, &S->cbm);
    S->cb_rc = rc;
    if (rc == EF_OK)
        S->res->targets++;
    return rc;
}

/* Direct mode with feed hold: every target the warp has for the setpoints received (end:
 * and the last one itself). Held, the same place goes out every period. */
static int mbs_warp_emit(stream_t *S, int end)
{
    float q[3];
    uint32_t tag;
    while (ef_warp_next(&S->warp, ef_mio_hold(S->c->mio), end, q, &tag)) {
        int rc = mbs_target(S, q, tag);
        if (rc != EF_OK)
            return rc;
    }
    return EF_OK;
}

/* Direct mode: every setpoint is a target (through the feed-hold warp when one is wired). */
static int mbs_stream_setpoint(void *user, double t, const ef_setpoint_t *sp,
                               const ef_pipe_move_info_t *mi)
{
    (void)t;
    (void)mi;
    stream_t *S = user;
    const float p[3] = {sp->p.x, sp->p.y, sp->p.z};
    if (!S->warp_on)
        return mbs_target(S, p, sp->tag);
    ef_warp_push(&S->warp, p, sp->tag);
    return mbs_warp_emit(S, 0);
}

/* Events (M-codes, dwells) wait until the drive has executed everything before them. */
static int mbs_stream_event(void *user, const ef_gcode_item_t *it)
{
    stream_t *S = user;
    if (S->warp_on && mbs_warp_emit(S, 1) != EF_OK) /* the targets before the event first */
        return S->cb_rc;
    int rc = ef_mb_drain(S->ms, &S->cbm); /* direct mode too: the outputs need the axis there */
    S->cb_rc = rc;
    if (rc == EF_OK && S->c->verbose)
        fprintf(stderr, "stream: event at line %u after %u segments\n", (unsigned)it->line,
                S->res->moves);
    if (rc != EF_OK)
        return rc;
    /* M62-M65: the drive has executed everything before and stands at the point. */
    int codes[8];
    long ps[8];
    int nw = ef_mio_m_words(it->text, codes, ps, 8);
    for (int w = 0; w < nw; w++) {
        if (!S->c->mio) {
            if (!S->out_noted)
                fprintf(stderr,
                        "stream: line %u: M%d P%ld not switched: no machine file (--machine) "
                        "wires the program's outputs (said once)\n",
                        (unsigned)it->line, codes[w], ps[w]);
            S->out_noted = 1;
            continue;
        }
        ef_msg_t om = {{0}};
        rc = ps[w] < 0
                 ? ef_fail(&om, EF_ERR_ARG, "needs a P word (the output)")
                 : ef_mio_out(S->c->mio, (unsigned)ps[w], codes[w] == 62 || codes[w] == 64, &om);
        if (rc != EF_OK)
            return S->cb_rc = ef_fail(&S->cbm, rc, "line %u: M%d P%ld: %s", (unsigned)it->line,
                                      codes[w], ps[w], om.text);
        S->res->outputs++;
    }
    return EF_OK;
}

/* The whole stream (see ef_mb.h). */
int ef_mb_stream(ef_gcode_t *r, const ef_mb_stream_cfg_t *c, ef_mb_stream_result_t *res,
                 ef_msg_t *m)
{
    if (!r || !c || !res)
        return ef_fail(m, EF_ERR_ARG, "stream: missing argument");
    memset(res, 0, sizeof *res);
    if (c->mode != EF_MB_MODE_SEGMENT && c->mode != EF_MB_MODE_DIRECT)
        return ef_fail(m, EF_ERR_ARG, "stream: mode must be segment or direct");
    if (c->mode == EF_MB_MODE_DIRECT && !(c->direct_hz >= 1.0 && c->direct_hz <= 10000.0))
        return ef_fail(m, EF_ERR_ARG, "stream: direct target rate must be 1..10000 Hz");
    stream_t S;
    memset(&S, 0, sizeof S);
    S.c = c;
    S.res = res;
    S.m = m;
    int rc;
    /* Machine I/O first: an active e-stop, its latch or an alarm refuses the stream before
     * the drive is contacted. */
    if (c->mio && (rc = ef_mio_arm(c->mio, m)) != EF_OK)
        return rc;
    ef_mb_cfg_t mbc = c->mb;
    if (c->mio) {
        mbc.on_poll = mbs_on_poll;
        mbc.on_poll_user = &S;
    }
    rc = ef_mb_open(&mbc, &S.ms, m);
    if (rc != EF_OK) {
        if (c->mio)
            (void)ef_mio_disarm(c->mio, NULL); /* nothing was sent: the open's error is it */
        return rc;
    }
    if (c->fault_reset)
        rc = ef_mb_fault_reset(S.ms, m);
    if (rc == EF_OK)
        rc = ef_mb_begin(S.ms, c->mode, m);
    int begun = rc == EF_OK;
    S.begun = begun;
    ef_pipe_cfg_t pc = c->pipe;
    ef_pipe_cb_t cb;
    memset(&cb, 0, sizeof cb);
    cb.on_move = mbs_stream_move;
    cb.on_event = mbs_stream_event;
    cb.user = &S;
    if (c->mode == EF_MB_MODE_DIRECT) {
        pc.interp_modes = EF_PIPE_INTERP_CORRECTED;
        pc.step_mode = EF_STEP_CORRECTED;
        pc.period_us = (uint32_t)lrint(1e6 / c->direct_hz);
        cb.on_setpoint = mbs_stream_setpoint;
        S.dt = pc.period_us * 1e-6;
        S.warp_on = c->mio && c->mio->cfg.hold >= 0;
        const float *a = pc.lim.a_axis;
        ef_warp_init(&S.warp, 3, S.dt, fmin(a[0], fmin(a[1], a[2])));
    }
    double t_start = ef_mb_now();
    if (rc == EF_OK) {
        rc = ef_pipe_run(r, &pc, &cb, &res->pipe, m);
        if (rc != EF_OK && S.cb_rc != EF_OK) {
            rc = S.cb_rc;
            ef_fail(m, rc, "%s", S.cbm.text);
        }
    }
    if (rc == EF_OK && S.warp_on && mbs_warp_emit(&S, 1) != EF_OK) {
        rc = S.cb_rc; /* the warp's last targets, the path's end among them */
        ef_fail(m, rc, "%s", S.cbm.text);
    }
    if (rc == EF_OK)
        rc = ef_mb_drain(S.ms, m);
    if (S.warp_on) {
        res->holds = S.warp.holds;
        res->held_s = S.warp.held_s;
    }
    res->wall_time = ef_mb_now() - t_start;
    S.begun = 0; /* ef_mb_end() disables: no hold is written after it */
    int ended = 0;
    if (rc == EF_OK) {
        rc = ef_mb_end(S.ms, m);
        ended = 1;
    }
    int erc = EF_OK;
    if (rc != EF_OK && begun && !ended) {
        /* Whatever went wrong, the drive is told to stop under control and disable (not
         * sent to a drive that restarted); the first error is the one reported. */
        ef_msg_t ignore;
        erc = ef_mb_end(S.ms, &ignore);
    }
    res->io = *ef_mb_stats(S.ms);
    res->last = *ef_mb_last_status(S.ms);
    ef_mb_close(S.ms);
    ef_msg_t dm = {{0}};
    int drc = c->mio ? ef_mio_disarm(c->mio, &dm) : EF_OK; /* after rest (or ef_mb_end's bound) */
    if (S.estop)
        rc = ef_fail(m, EF_ERR_ESTOP, "%s; %s, %s", S.estop_msg.text,
                     erc == EF_OK ? "the drive stopped under control and at rest"
                                  : "the drive did not report rest in time",
                     drc == EF_OK ? "enable dropped" : dm.text);
    else if (drc != EF_OK && rc == EF_OK)
        rc = ef_fail(m, drc, "machine I/O: %s", dm.text);
    return rc;
}
