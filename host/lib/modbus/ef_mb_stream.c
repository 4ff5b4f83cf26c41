/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed stream --modbus as a library call: smooth a program and stream its segments
 * (or, in direct mode, sampled target positions) to one drive. */
#include <math.h>
#include <string.h>
#include <time.h>
#include "evenfeed/host/modbus/ef_mb.h"

typedef struct {
    const ef_mb_stream_cfg_t *c;
    ef_mb_master_t *ms;
    ef_mb_stream_result_t *res;
    ef_msg_t *m;
    ef_msg_t cbm; /* what a callback's failure was (the pipeline only says it stopped) */
    int cb_rc;
    double t0; /* direct mode: wall time of the first target */
} stream_t;

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
    if (S->c->mode != EF_MB_MODE_SEGMENT)
        return EF_OK;
    int rc = ef_mb_send(S->ms, mv, &S->cbm);
    S->cb_rc = rc;
    if (rc == EF_OK)
        S->res->moves++;
    if (rc == EF_OK && S->c->verbose && S->res->moves % 200 == 0)
        fprintf(stderr, "stream: %u segments sent\n", S->res->moves);
    return rc;
}

/* Direct mode: every setpoint is a target, written when its time comes (real time). */
static int mbs_stream_setpoint(void *user, double t, const ef_setpoint_t *sp,
                               const ef_pipe_move_info_t *mi)
{
    (void)mi;
    stream_t *S = user;
    double now = ef_mb_now();
    if (S->res->targets == 0)
        S->t0 = now - t;
    double wait = S->t0 + t - now;
    if (wait > 0.0) {
        struct timespec ts = {(time_t)wait, (long)((wait - floor(wait)) * 1e9)};
        nanosleep(&ts, NULL);
    }
    const float p[3] = {sp->p.x, sp->p.y, sp->p.z};
    int rc = ef_mb_target(S->ms, p, &S->cbm);
    S->cb_rc = rc;
    if (rc == EF_OK)
        S->res->targets++;
    return rc;
}

/* Events (M-codes, dwells) wait until the drive has executed everything before them. */
static int mbs_stream_event(void *user, const ef_gcode_item_t *it)
{
    stream_t *S = user;
    (void)it;
    if (S->c->mode != EF_MB_MODE_SEGMENT)
        return EF_OK;
    int rc = ef_mb_drain(S->ms, &S->cbm);
    S->cb_rc = rc;
    if (rc == EF_OK && S->c->verbose)
        fprintf(stderr, "stream: event at line %u after %u segments\n", (unsigned)it->line,
                S->res->moves);
    return rc;
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
    int rc = ef_mb_open(&c->mb, &S.ms, m);
    if (rc != EF_OK)
        return rc;
    if (c->fault_reset)
        rc = ef_mb_fault_reset(S.ms, m);
    if (rc == EF_OK)
        rc = ef_mb_begin(S.ms, c->mode, m);
    int begun = rc == EF_OK;
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
    }
    double t_start = ef_mb_now();
    if (rc == EF_OK) {
        rc = ef_pipe_run(r, &pc, &cb, &res->pipe, m);
        if (rc != EF_OK && S.cb_rc != EF_OK) {
            rc = S.cb_rc;
            ef_fail(m, rc, "%s", S.cbm.text);
        }
    }
    if (rc == EF_OK)
        rc = ef_mb_drain(S.ms, m);
    res->wall_time = ef_mb_now() - t_start;
    if (rc == EF_OK) {
        rc = ef_mb_end(S.ms, m);
    } else if (begun) {
        /* Whatever went wrong, the drive is told to stop under control and disable (not
         * sent to a drive that restarted); the first error is the one reported. */
        ef_msg_t ignore;
        ef_mb_end(S.ms, &ignore);
    }
    res->io = *ef_mb_stats(S.ms);
    res->last = *ef_mb_last_status(S.ms);
    ef_mb_close(S.ms);
    return rc;
}
