/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed stream --modbus as a library call: smooth a program and stream its segments
 * (or, in direct mode, sampled target positions) to one drive, or its segments to several
 * drives, one per axis (docs/modbus.md). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "evenfeed/host/modbus/ef_mb.h"
#include "evenfeed/host/io/ef_mio.h"
#include "evenfeed/host/io/ef_warp.h"

/* Program lines of the segments sent, by sequence number (the line of the executing one). */
#define MBS_TAGS 1024u
/* Several drives: a status round over all of them at most this often (s), from any drive's
 * own poll, so a drive the master is not writing to is still watched and fed. */
#define MBS_GROUP_S 0.02

/* What a drive's on_poll hook needs: the stream and which drive it is. */
typedef struct {
    void *S;
    int k;
} mbs_hook_t;

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
    /* Several drives (nd > 1); with one, ms[0] is ms and none of the rest is used. */
    int nd;
    ef_mb_cfg_t dc[EF_MB_MAX_DRIVES];
    ef_mb_master_t *dms[EF_MB_MAX_DRIVES];
    int dbegun[EF_MB_MAX_DRIVES];
    char label[EF_MB_MAX_DRIVES][300];
    mbs_hook_t hook[EF_MB_MAX_DRIVES];
    uint32_t min_slots; /* the smallest ring: filled before the drives start */
    int started_all;    /* START written to every drive */
    int in_group;       /* a status round is under way (its polls run no hook) */
    double group_t;     /* when the last status round began */
    int named;          /* the message already names the drive it came from */
} stream_t;

/* An error of drive k: with several drives the message names it (once: an error a status
 * round found on another drive already names that one). An e-stop names no drive. */
static int mbs_drive_fail(stream_t *S, int k, int rc, const char *text, ef_msg_t *m)
{
    char t[sizeof m->text];
    snprintf(t, sizeof t, "%s", text);
    if (S->nd <= 1 || rc == EF_ERR_ESTOP || S->named)
        return ef_fail(m, rc, "%s", t);
    S->named = 1;
    S->res->failed_drive = k;
    return ef_fail(m, rc, "drive %s: %s", S->label[k], t);
}

/* Several drives: a status round. Every drive is read (a fault, a restart, a drive that
 * left RUNNING, or silence fails it), then drive 0 again: a drive's executed time must lie
 * within drive 0's two readings, give or take skew_max_s, whatever the drives' clock rate
 * (the simulated drive's time scale) and however long the reads took. */
static int mbs_group(stream_t *S, ef_msg_t *m)
{
    S->in_group = 1;
    S->group_t = ef_mb_now();
    uint32_t t[EF_MB_MAX_DRIVES + 1];
    int rc = EF_OK;
    for (int i = 0; i <= S->nd && rc == EF_OK; i++) {
        int k = i < S->nd ? i : 0;
        ef_msg_t dm = {{0}};
        rc = ef_mb_poll(S->dms[k], &dm);
        if (rc != EF_OK)
            rc = mbs_drive_fail(S, k, rc, dm.text, m);
        t[i] = ef_mb_last_status(S->dms[k])->time_ms;
    }
    S->in_group = 0;
    if (rc != EF_OK || !S->started_all)
        return rc;
    double bound_ms = S->c->skew_max_s * 1e3;
    for (int k = 1; k < S->nd; k++) {
        int32_t behind = (int32_t)(t[0] - t[k]), ahead = (int32_t)(t[k] - t[S->nd]);
        int32_t sk = behind > ahead ? behind : ahead; /* the time counters wrap: differences */
        if (sk < 0)
            sk = 0;
        if (sk * 1e-3 > S->res->skew_max_s)
            S->res->skew_max_s = sk * 1e-3;
        if (sk > bound_ms) {
            S->named = 1;
            S->res->failed_drive = k;
            return ef_fail(m, EF_ERR_DRIVE,
                           "drive %s: executed %u ms while drive %s executed %u..%u ms: %d ms "
                           "apart, above the bound of %.0f ms (each drive runs on its own "
                           "clock); every drive stopped",
                           S->label[k], (unsigned)t[k], S->label[0], (unsigned)t[0],
                           (unsigned)t[S->nd], (int)sk, bound_ms);
        }
    }
    S->res->skew_checks++;
    return EF_OK;
}

/* Several drives: START to every drive, back to back, once their rings are filled. */
static int mbs_start_all(stream_t *S, ef_msg_t *m)
{
    for (int k = 0; k < S->nd; k++) {
        ef_msg_t dm = {{0}};
        int rc = ef_mb_start(S->dms[k], &dm);
        if (rc != EF_OK)
            return mbs_drive_fail(S, k, rc, dm.text, m);
    }
    S->started_all = 1;
    return EF_OK;
}

/* Wait until every drive has executed everything sent (each drive's own drain; the status
 * rounds of its polls watch the others meanwhile). */
static int mbs_drain_all(stream_t *S, ef_msg_t *m)
{
    if (S->nd <= 1)
        return ef_mb_drain(S->ms, m);
    int rc = S->started_all || S->res->moves == 0 ? EF_OK : mbs_start_all(S, m);
    for (int k = 0; k < S->nd && rc == EF_OK; k++) {
        ef_msg_t dm = {{0}};
        rc = ef_mb_drain(S->dms[k], &dm);
        if (rc != EF_OK)
            rc = mbs_drive_fail(S, k, rc, dm.text, m);
    }
    return rc;
}

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
    int nd = S->nd > 1 ? S->nd : 1;
    for (int k = 0; k < nd; k++) {
        ef_msg_t dm = {{0}};
        int rc = ef_mb_hold(S->nd > 1 ? S->dms[k] : S->ms, want, &dm);
        if (rc != EF_OK)
            return mbs_drive_fail(S, k, rc, dm.text, m);
    }
    return EF_OK;
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

/* Several drives, before every status poll of drive k: the machine I/O, and a status round
 * over all drives when the last is MBS_GROUP_S old (not from the round's own polls). */
static int mbs_on_poll_drive(void *user, ef_msg_t *m)
{
    mbs_hook_t *h = user;
    stream_t *S = h->S;
    if (S->in_group)
        return 0;
    int rc = mbs_on_poll(S, m);
    if (rc != 0)
        return rc;
    if (S->begun && ef_mb_now() - S->group_t >= MBS_GROUP_S)
        return mbs_group(S, m);
    return 0;
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
    c->skew_max_s = 0.02;
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
    int rc = EF_OK;
    if (S->nd <= 1) {
        rc = ef_mb_send(S->ms, mv, &S->cbm);
    } else {
        /* Every drive gets every move, in the same order, with the same sequence number. */
        for (int k = 0; k < S->nd && rc == EF_OK; k++) {
            ef_msg_t dm = {{0}};
            rc = ef_mb_send(S->dms[k], mv, &dm);
            if (rc != EF_OK)
                rc = mbs_drive_fail(S, k, rc, dm.text, &S->cbm);
        }
        if (rc == EF_OK && !S->started_all && S->res->moves + 1 >= S->min_slots)
            rc = mbs_start_all(S, &S->cbm);
    }
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
    int rc = mbs_drain_all(S, &S->cbm); /* direct mode too: the outputs need the axis there */
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

/* A drive's name in messages: its address, unit id and what it carries. */
static void mbs_label(char *out, size_t n, int k, const ef_mb_cfg_t *d)
{
    if (d->rtu)
        snprintf(out, n, "%d (rtu:%s slave %d, %s)", k + 1, d->device, d->slave,
                 ef_mb_axis_name(d->axis));
    else
        snprintf(out, n, "%d (tcp://%s:%d, %s)", k + 1, d->host, d->port, ef_mb_axis_name(d->axis));
}

/* The drive list, before any drive is contacted: X Y Z carried once each, the auxiliary
 * axes from A on without a gap (the pipeline takes the first naux of them, so a gap would
 * let a program move an axis no drive carries), no axis twice, no drive twice. */
static int mbs_drives_check(const ef_mb_stream_cfg_t *c, stream_t *S, int *naux, ef_msg_t *m)
{
    if (c->n_drives < 0 || c->n_drives > EF_MB_MAX_DRIVES)
        return ef_fail(m, EF_ERR_ARG, "%d drives (1 to %d)", c->n_drives, EF_MB_MAX_DRIVES);
    S->nd = c->n_drives > 1 ? c->n_drives : 1;
    for (int k = 0; k < S->nd; k++) {
        S->dc[k] = c->n_drives >= 1 ? c->drives[k] : c->mb;
        mbs_label(S->label[k], sizeof S->label[k], k, &S->dc[k]);
    }
    int by[EF_MB_AXIS_MAX + 1]; /* drive carrying each axis (1..9), -1 none */
    for (int a = 0; a <= EF_MB_AXIS_MAX; a++)
        by[a] = -1;
    static const char up[] = " XYZABCUVW";
    for (int k = 0; k < S->nd; k++) {
        int ax = S->dc[k].axis;
        if (ax < 0 || ax > EF_MB_AXIS_MAX)
            return ef_fail(m, EF_ERR_ARG, "drive %s: axis %d unknown", S->label[k], ax);
        if (ax > 3 && ax - 3 > EF_AUX)
            return ef_fail(m, EF_ERR_ARG, "drive %s: axis %c: this build carries %d axes",
                           S->label[k], up[ax], EF_AXES);
        for (int a = ax ? ax : 1; a <= (ax ? ax : 3); a++) {
            if (by[a] >= 0)
                return ef_fail(m, EF_ERR_ARG, "axis %c is carried by drive %s and drive %s", up[a],
                               S->label[by[a]], S->label[k]);
            by[a] = k;
        }
        for (int j = 0; j < k; j++) {
            const ef_mb_cfg_t *x = &S->dc[j], *y = &S->dc[k];
            if (x->rtu && y->rtu && !strcmp(x->device, y->device))
                return ef_fail(m, EF_ERR_ARG,
                               "drives %s and %s on one serial line: several unit ids "
                               "on one RTU line are not supported (one line per drive)",
                               S->label[j], S->label[k]);
            if (!x->rtu && !y->rtu && !strcmp(x->host, y->host) && x->port == y->port &&
                x->slave == y->slave)
                return ef_fail(m, EF_ERR_ARG, "drives %s and %s are the same drive", S->label[j],
                               S->label[k]);
        }
    }
    for (int a = 1; a <= 3; a++)
        if (by[a] < 0)
            return ef_fail(m, EF_ERR_ARG, "no drive carries %c (X Y Z are always moved)", up[a]);
    *naux = 0;
    while (*naux < EF_AUX && by[4 + *naux] >= 0)
        (*naux)++;
    for (int a = 4 + *naux; a <= EF_MB_AXIS_MAX; a++)
        if (by[a] >= 0)
            return ef_fail(m, EF_ERR_ARG,
                           "drive %s carries %c but no drive carries %c: the auxiliary "
                           "axes go A B C U V W without a gap",
                           S->label[by[a]], up[a], up[4 + *naux]);
    if (c->mode == EF_MB_MODE_DIRECT && (S->nd > 1 || S->dc[0].axis != EF_MB_AXIS_XYZ))
        return ef_fail(m, EF_ERR_ARG, "direct mode streams to one X Y Z drive only");
    if (S->nd > 1 && !(c->skew_max_s > 0.0 && c->skew_max_s <= 10.0))
        return ef_fail(m, EF_ERR_ARG, "skew bound %.3f s (above 0, at most 10 s)", c->skew_max_s);
    return EF_OK;
}

/* Several drives: open, fault-reset and begin each; the first failure is the error, and
 * the drives begun before it are ended (disabled) by the caller. */
static int mbs_open_all(stream_t *S, const ef_mb_stream_cfg_t *c, ef_msg_t *m)
{
    int rc = EF_OK;
    for (int k = 0; k < S->nd && rc == EF_OK; k++) {
        ef_mb_cfg_t dc = S->dc[k];
        S->hook[k].S = S;
        S->hook[k].k = k;
        dc.on_poll = mbs_on_poll_drive;
        dc.on_poll_user = &S->hook[k];
        ef_msg_t dm = {{0}};
        rc = ef_mb_open(&dc, &S->dms[k], &dm);
        if (rc == EF_OK) {
            ef_mb_set_manual_start(S->dms[k], 1);
            uint32_t n = ef_mb_slots(S->dms[k]);
            S->min_slots = k == 0 || n < S->min_slots ? n : S->min_slots;
        }
        if (rc != EF_OK)
            rc = mbs_drive_fail(S, k, rc, dm.text, m);
    }
    for (int k = 0; k < S->nd && rc == EF_OK; k++) {
        ef_msg_t dm = {{0}};
        if (c->fault_reset)
            rc = ef_mb_fault_reset(S->dms[k], &dm);
        if (rc == EF_OK)
            rc = ef_mb_begin(S->dms[k], c->mode, &dm);
        if (rc == EF_OK)
            S->dbegun[k] = 1;
        else
            rc = mbs_drive_fail(S, k, rc, dm.text, m);
    }
    S->ms = S->dms[0];
    return rc;
}

/* Several drives after an error: a quick stop to every drive begun, back to back, the
 * failing one last (it may not answer); then each is disabled and waited for at rest. A
 * drive that did not answer at all is not waited for again. */
static int mbs_stop_all(stream_t *S, int rc)
{
    int f = S->res->failed_drive;
    int gone = f >= 0 && (rc == EF_ERR_DISCONNECT || rc == EF_ERR_TIMEOUT);
    int erc = EF_OK;
    for (int i = 0; i < S->nd; i++) {
        int k = f >= 0 ? (f + 1 + i) % S->nd : i; /* f comes last */
        ef_msg_t ignore;
        if (S->dbegun[k] && !(gone && k == f))
            (void)ef_mb_quick_stop(S->dms[k], &ignore);
    }
    for (int k = 0; k < S->nd; k++) {
        ef_msg_t ignore;
        if (S->dbegun[k] && !(gone && k == f) && ef_mb_end(S->dms[k], &ignore) != EF_OK)
            erc = EF_ERR_TIMEOUT;
    }
    return erc;
}

/* The whole stream (see ef_mb.h). */
int ef_mb_stream(ef_gcode_t *r, const ef_mb_stream_cfg_t *c, ef_mb_stream_result_t *res,
                 ef_msg_t *m)
{
    if (!r || !c || !res)
        return ef_fail(m, EF_ERR_ARG, "stream: missing argument");
    memset(res, 0, sizeof *res);
    res->failed_drive = -1;
    if (c->mode != EF_MB_MODE_SEGMENT && c->mode != EF_MB_MODE_DIRECT)
        return ef_fail(m, EF_ERR_ARG, "stream: mode must be segment or direct");
    if (c->mode == EF_MB_MODE_DIRECT && !(c->direct_hz >= 1.0 && c->direct_hz <= 10000.0))
        return ef_fail(m, EF_ERR_ARG, "stream: direct target rate must be 1..10000 Hz");
    stream_t *S = calloc(1, sizeof *S); /* 12 kB of drive configurations and tags */
    if (!S)
        return ef_fail(m, EF_ERR_NOMEM, "stream: out of memory");
    S->c = c;
    S->res = res;
    S->m = m;
    int naux = 0;
    int rc = mbs_drives_check(c, S, &naux, m);
    if (rc != EF_OK) {
        free(S);
        return rc;
    }
    res->n_drives = (uint32_t)S->nd;
    /* Machine I/O first: an active e-stop, its latch or an alarm refuses the stream before
     * the drive is contacted. */
    if (c->mio && (rc = ef_mio_arm(c->mio, m)) != EF_OK) {
        free(S);
        return rc;
    }
    int begun;
    if (S->nd > 1) {
        rc = mbs_open_all(S, c, m);
        begun = rc == EF_OK;
        if (rc != EF_OK && S->dms[0] == NULL) {
            if (c->mio)
                (void)ef_mio_disarm(c->mio, NULL);
            free(S);
            return rc; /* the first drive did not open: nothing was sent */
        }
    } else {
        ef_mb_cfg_t mbc = S->dc[0];
        if (c->mio) {
            mbc.on_poll = mbs_on_poll;
            mbc.on_poll_user = S;
        }
        rc = ef_mb_open(&mbc, &S->ms, m);
        if (rc != EF_OK) {
            if (c->mio)
                (void)ef_mio_disarm(c->mio, NULL); /* nothing was sent: the open's error is it */
            free(S);
            return rc;
        }
        S->dms[0] = S->ms;
        if (c->fault_reset)
            rc = ef_mb_fault_reset(S->ms, m);
        if (rc == EF_OK)
            rc = ef_mb_begin(S->ms, c->mode, m);
        begun = rc == EF_OK;
        S->dbegun[0] = begun;
    }
    S->begun = begun;
    ef_pipe_cfg_t pc = c->pipe;
    pc.naux = naux; /* the axes the drives carry: a program moving another is refused */
    ef_pipe_cb_t cb;
    memset(&cb, 0, sizeof cb);
    cb.on_move = mbs_stream_move;
    cb.on_event = mbs_stream_event;
    cb.user = S;
    if (c->mode == EF_MB_MODE_DIRECT) {
        pc.interp_modes = EF_PIPE_INTERP_CORRECTED;
        pc.step_mode = EF_STEP_CORRECTED;
        pc.period_us = (uint32_t)lrint(1e6 / c->direct_hz);
        cb.on_setpoint = mbs_stream_setpoint;
        S->dt = pc.period_us * 1e-6;
        S->warp_on = c->mio && c->mio->cfg.hold >= 0;
        const float *a = pc.lim.a_axis;
        ef_warp_init(&S->warp, 3, S->dt, fmin(a[0], fmin(a[1], a[2])));
    }
    double t_start = ef_mb_now();
    if (rc == EF_OK) {
        rc = ef_pipe_run(r, &pc, &cb, &res->pipe, m);
        if (rc != EF_OK && S->cb_rc != EF_OK) {
            rc = S->cb_rc;
            ef_fail(m, rc, "%s", S->cbm.text);
        }
    }
    if (rc == EF_OK && S->warp_on && mbs_warp_emit(S, 1) != EF_OK) {
        rc = S->cb_rc; /* the warp's last targets, the path's end among them */
        ef_fail(m, rc, "%s", S->cbm.text);
    }
    if (rc == EF_OK) {
        rc = mbs_drain_all(S, &S->cbm);
        if (rc != EF_OK)
            ef_fail(m, rc, "%s", S->cbm.text);
    }
    if (S->warp_on) {
        res->holds = S->warp.holds;
        res->held_s = S->warp.held_s;
    }
    res->wall_time = ef_mb_now() - t_start;
    S->begun = 0; /* ef_mb_end() disables: no hold is written after it */
    int ended = 0;
    if (rc == EF_OK) {
        for (int k = 0; k < S->nd && rc == EF_OK; k++) {
            ef_msg_t dm = {{0}};
            rc = ef_mb_end(S->dms[k], &dm);
            if (rc != EF_OK)
                rc = mbs_drive_fail(S, k, rc, dm.text, m);
        }
        ended = 1;
    }
    int erc = EF_OK;
    if (rc != EF_OK && S->nd > 1) {
        /* Every drive is told to stop, even after an error at the end of one of them. */
        erc = mbs_stop_all(S, rc);
    } else if (rc != EF_OK && begun && !ended) {
        /* Whatever went wrong, the drive is told to stop under control and disable (not
         * sent to a drive that restarted); the first error is the one reported. */
        ef_msg_t ignore;
        erc = ef_mb_end(S->ms, &ignore);
    }
    for (int k = 0; k < S->nd; k++) {
        if (!S->dms[k])
            continue;
        res->drive_io[k] = *ef_mb_stats(S->dms[k]);
        res->drive[k] = *ef_mb_last_status(S->dms[k]);
    }
    res->io = res->drive_io[0];
    res->last = res->drive[0];
    for (int k = 0; k < S->nd; k++)
        ef_mb_close(S->dms[k]);
    ef_msg_t dm = {{0}};
    int drc = c->mio ? ef_mio_disarm(c->mio, &dm) : EF_OK; /* after rest (or ef_mb_end's bound) */
    const char *who = S->nd > 1 ? "every drive" : "the drive";
    if (S->estop)
        rc = ef_fail(m, EF_ERR_ESTOP, "%s; %s %s, %s", S->estop_msg.text, who,
                     erc == EF_OK ? "stopped under control and at rest"
                                  : "did not report rest in time",
                     drc == EF_OK ? "enable dropped" : dm.text);
    else if (drc != EF_OK && rc == EF_OK)
        rc = ef_fail(m, drc, "machine I/O: %s", dm.text);
    free(S);
    return rc;
}
