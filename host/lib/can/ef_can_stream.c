/* SPDX-License-Identifier: Apache-2.0 */
/* evenfeed stream --can as a library call: smooth a program and stream it over CANopen
 * (SocketCAN) to up to three CiA 402 drives, in CSP or evenfeed segment mode. */
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "evenfeed/host/can/ef_canhost.h"
#include "evenfeed/host/can/ef_canpump.h"
#include "evenfeed/host/can/ef_sockcan.h"
#include "evenfeed/host/io/ef_mio.h"
#include "evenfeed/host/io/ef_warp.h"
#include "evenfeed/geom/ef_bezier.h"

/* Longest receive wait while the socket's backlog holds frames (us). */
#define CS_BACKLOG_WAIT_US 500u
/* Time added to the master's stop timeout for the final wait (ms). */
#define CS_STOP_MARGIN_MS 2000u

/* Items the pipeline thread hands to the bus thread (moves, setpoints, events, in order). */
#define CS_QUEUE 64

typedef struct {
    int kind; /* CS_ITEM_* */
    ef_move_t mv;
    ef_setpoint_t sp;
    double t;
    ef_gcode_item_t it;
} cs_item_t;

enum { CS_ITEM_MOVE = 1, CS_ITEM_SETPOINT = 2, CS_ITEM_EVENT = 3 };

/* Longest pump wait with machine I/O: GPIO edges do not wake the CAN socket's poll, so
 * this bounds the e-stop latency in the slow (segment, 10 ms) cycle (us). */
#define CS_MIO_WAIT_US 2000u
/* Moves remembered to name the program line of an e-stop, and points sampled on each. */
#define CS_MRING 256u
#define CS_MPTS  9

/** TPDO1 positions kept per node until every node's answer to the same SYNC is in. */
#define CS_TP_RING 256u

typedef struct {
    const ef_can_stream_cfg_t *c;
    ef_can_stream_result_t *res;
    ef_com_cfg_t mc;
    ef_comaster_t ms;
    ef_sockcan_t sk; /* the default transport's context (cfg canif NULL) */
    ef_canif_t ci;
    ef_canpump_t pump; /* its clock starts when the socket opens */
    uint32_t bus_seen; /* EF_CANIF_BAD conditions the transport has reported */
    FILE *trace;
    uint64_t t_run; /* pump time when RUN was reached */
    /* SYNC periods. */
    uint64_t sync_last_t;
    double p_sum, p_sq;
    uint64_t p_n;
    uint32_t syncs;
    int cb_rc; /* what a callback failed with (the pipeline only says it stopped) */
    ef_msg_t cbm;
    int cb_master;     /* the callback failed because the master left RUN */
    uint32_t err_sync; /* SYNC count when the master's error was first seen */
    int err_seen;
    int start_checked;
    double pushed_time; /* durations of the moves pushed (s) */
    double longest;     /* longest move (s) */
    /* Executed path: the n-th TPDO1 of every node answers the same SYNC (type 1: one per
     * SYNC, in order, all nodes operational from the same NMT start), so rows pair them by
     * count, not by arrival time, which a loaded host stretches. */
    uint32_t tp_count[EF_CAN_STREAM_MAX_NODES];
    int32_t tp_ring[EF_CAN_STREAM_MAX_NODES][CS_TP_RING];
    uint32_t tp_rows; /* rows written */
    /* The pipeline runs in its own thread so that smoothing never delays a SYNC or the
     * heartbeat supervision; only this (the bus) thread touches the master and the socket. */
    pthread_mutex_t mu;
    pthread_cond_t cv;
    cs_item_t q[CS_QUEUE];
    uint32_t q_head, q_count;
    int worker_done, worker_rc, abort;
    ef_msg_t worker_msg;
    ef_gcode_t *r;
    ef_pipe_cfg_t pc;
    /* Machine I/O: a trip stops the drives; the moves pushed recently, to name the line
     * being executed where the drives were then. */
    int estop;
    ef_msg_t estop_msg;
    uint64_t estop_edge_ns, estop_cmd_ns;
    float estop_pos[EF_CAN_STREAM_MAX_NODES];
    struct {
        uint32_t tag;
        float p[CS_MPTS][EF_CAN_STREAM_MAX_NODES];
    } mring[CS_MRING];
    uint32_t mr_n;
    /* Feed hold in CSP: the setpoints (one per cycle) replayed through a time warp
     * (ef_warp.h) whose rate follows the hold input. */
    int hold_on; /* feed hold is wired (CSP) */
    ef_warp_t warp;
    float last_cmd[EF_CAN_STREAM_MAX_NODES]; /* where the last target / segment ends */
    int out_noted;                           /* M62-M65 without machine I/O: said once */
    uint32_t holds;                          /* segment mode: holds begun */
    double held_s;                           /* segment mode: time every drive stood held (s) */
    /* Feed hold in segment mode: the drives hold (controlword bit 8); every wait whose bound
     * is the path's time runs on a clock that stops while a hold is requested. */
    int seg_hold_on;
    uint64_t hold_t;  /* pump time of the last hold bookkeeping (us) */
    uint64_t held_us; /* time with a hold requested while RUN / FINISH (us) */
} cs_t;

/* Defaults documented in ef_canhost.h. */
void ef_can_stream_cfg_default(ef_can_stream_cfg_t *c, const ef_table_t *g2, const ef_table_t *g1)
{
    memset(c, 0, sizeof *c);
    for (int k = 0; k < EF_CAN_STREAM_MAX_NODES; k++)
        c->nodes[k] = (uint8_t)(k + 1);
    c->n_nodes = 3; /* X Y Z */
    c->mode = EF_COM_MODE_SEGMENT;
    ef_pipe_cfg_default(&c->pipe);
    c->pipe.g2 = g2;
    c->pipe.g1 = g1;
    c->boot_timeout_ms = 3000;
    c->hb_timeout_ms = 200;
    c->sdo_timeout_ms = 200;
    c->enable_timeout_ms = 1000;
    c->stop_timeout_ms = 5000;
    c->bringup_ms = 20000;
    c->stall_ms = 10000;
    c->bitrate = 1000000;
}

/* Names of the bus conditions in a detail word. */
static void cs_bus_text(uint32_t bits, char *buf, size_t n)
{
    buf[0] = 0;
    if (bits & EF_SOCKCAN_BUS_OFF)
        snprintf(buf + strlen(buf), n - strlen(buf), "%sbus-off", buf[0] ? ", " : "");
    if (bits & EF_SOCKCAN_ERROR_PASSIVE)
        snprintf(buf + strlen(buf), n - strlen(buf), "%serror-passive", buf[0] ? ", " : "");
    if (bits & EF_SOCKCAN_DOWN)
        snprintf(buf + strlen(buf), n - strlen(buf), "%sinterface down", buf[0] ? ", " : "");
    if (bits & EF_CANIF_FAULT)
        snprintf(buf + strlen(buf), n - strlen(buf), "%sadapter fault", buf[0] ? ", " : "");
    if (!buf[0])
        snprintf(buf, n, "bus error (0x%x)", (unsigned)bits);
}

/* One line for a master error (see ef_canhost.h). */
void ef_can_error_text(const ef_com_error_t *e, const ef_com_cfg_t *c, const char *iface, char *buf,
                       size_t n)
{
    if (!buf || n == 0)
        return;
    if (!e || e->code == 0) {
        snprintf(buf, n, "no error");
        return;
    }
    char who[32], bus[64];
    snprintf(who, sizeof who, "node %u", (unsigned)e->node);
    const char *dir = e->what == EF_COM_WHAT_SDO_WRITE ? "writing" : "reading";
    switch (e->what) {
    case EF_COM_WHAT_BOOT:
        snprintf(buf, n, "%s: never booted (%u ms)", who, c ? (unsigned)c->boot_timeout_ms : 0u);
        break;
    case EF_COM_WHAT_SDO_READ:
    case EF_COM_WHAT_SDO_WRITE:
        if (e->abort)
            snprintf(buf, n, "%s: SDO abort 0x%08X (%s) %s 0x%04X:%02X", who, (unsigned)e->abort,
                     ef_co_abort_str(e->abort), dir, (unsigned)e->index, (unsigned)e->sub);
        else if (e->code == EF_ERR_TIMEOUT)
            snprintf(buf, n, "%s: no SDO answer (%u ms, retried) %s 0x%04X:%02X", who,
                     c ? (unsigned)c->sdo_timeout_ms : 0u, dir, (unsigned)e->index,
                     (unsigned)e->sub);
        else
            snprintf(buf, n, "%s: %s %s 0x%04X:%02X", who, ef_err_str(e->code), dir,
                     (unsigned)e->index, (unsigned)e->sub);
        break;
    case EF_COM_WHAT_CHECK:
        snprintf(buf, n, "%s: 0x%04X:%02X is 0x%08X, expected 0x%08X", who, (unsigned)e->index,
                 (unsigned)e->sub, (unsigned)e->value, (unsigned)e->expected);
        break;
    case EF_COM_WHAT_ENABLE:
        if (e->power == EF_CO_PS_FAULT || e->power == EF_CO_PS_FAULT_REACTION)
            snprintf(buf, n,
                     "%s: drive in fault (statusword 0x%04X): not enabling it; reset the "
                     "fault first (--fault-reset)",
                     who, (unsigned)e->statusword);
        else
            snprintf(buf, n, "%s: did not enable: power state %s (statusword 0x%04X)", who,
                     ef_co_power_str(e->power), (unsigned)e->statusword);
        break;
    case EF_COM_WHAT_HEARTBEAT:
        snprintf(buf, n, "%s: heartbeat lost (%u ms)", who, c ? (unsigned)c->hb_timeout_ms : 0u);
        break;
    case EF_COM_WHAT_EMCY:
        snprintf(buf, n, "%s: EMCY 0x%04X (%s), drive fault %u, at SYNC %u", who, (unsigned)e->emcy,
                 ef_co_emcy_str(e->emcy), (unsigned)e->drive_fault, (unsigned)e->value);
        break;
    case EF_COM_WHAT_FAULT:
        snprintf(buf, n, "%s: drive reports FAULT (statusword 0x%04X, %s)", who,
                 (unsigned)e->statusword, ef_co_power_str(e->power));
        break;
    case EF_COM_WHAT_RESTART:
        snprintf(buf, n, "%s: restarted (boot-up message while running): its state is lost", who);
        break;
    case EF_COM_WHAT_BUS:
        cs_bus_text(e->value, bus, sizeof bus);
        snprintf(buf, n, "%s: %s", iface ? iface : "CAN", bus);
        break;
    case EF_COM_WHAT_STREAM:
        snprintf(buf, n, "%s: stream failed at segment %u: %s", who, (unsigned)e->value,
                 ef_err_str(e->code));
        break;
    case EF_COM_WHAT_STOP:
        snprintf(buf, n, "%s: not at rest %u ms after the stop (power state %s)", who,
                 c ? (unsigned)c->stop_timeout_ms : 0u, ef_co_power_str(e->power));
        break;
    default:
        snprintf(buf, n, "%s: %s", e->node ? who : (iface ? iface : "CAN"), ef_err_str(e->code));
        break;
    }
}

/* Index of a node id in the configuration, -1 if none. */
static int cs_node_index(const cs_t *S, uint32_t id)
{
    for (int k = 0; k < S->c->n_nodes; k++)
        if (S->c->nodes[k] == id)
            return k;
    return -1;
}

/* The master's error as text. */
static void cs_error_text(const cs_t *S, char *buf, size_t n)
{
    ef_com_error_t e0 = *ef_comaster_error(&S->ms);
    const ef_com_error_t *e = &e0;
    /* A send the transport refused (bus-off) can reach the master before the condition the
     * pump passes on: a bus error without detail. The conditions the transport reported
     * say which it was. */
    if (e0.what == EF_COM_WHAT_BUS && e0.value == 0)
        e0.value = S->bus_seen;
    /* ... and the pump may not have passed the condition on yet when the stream stopped (a
     * gs_usb adapter pulled while transfers were failing: "bus error (0x0)" was all the user
     * got, hil_gsusb_unplug's first tries in CI): ask the transport itself, now. */
    if (e0.what == EF_COM_WHAT_BUS && e0.value == 0) {
        ef_canif_status_t st;
        ef_canif_status(&S->ci, 0, &st);
        e0.value = st.seen & EF_CANIF_BAD;
    }
    ef_can_error_text(e, &S->mc, S->c->iface, buf, n);
    /* "interface down" or "adapter fault" alone hides why, and so does a bus error without
     * detail: the transport knows (a USB adapter unplugged, a malformed frame from it). */
    const char *why = ef_canif_error(&S->ci);
    size_t k = strlen(buf);
    int bus = e->what == EF_COM_WHAT_BUS;
    int hidden = (e->value & (EF_CANIF_DOWN | EF_CANIF_FAULT)) || e->value == 0;
    if (bus && hidden && why[0] && k + 4 < n)
        snprintf(buf + k, n - k, " (%s)", why);
}

/* Every SYNC the master sends: timestamp, period statistics, trace of the actual positions. */
static void cs_on_sync(cs_t *S)
{
    uint64_t t = ef_canpump_elapsed_us(&S->pump);
    S->syncs++;
    if (S->syncs > 1) {
        double p = (double)(t - S->sync_last_t);
        S->p_sum += p;
        S->p_sq += p * p;
        S->p_n++;
        if (S->p_n == 1 || p < S->res->sync_min_us)
            S->res->sync_min_us = p;
        if (S->p_n == 1 || p > S->res->sync_max_us)
            S->res->sync_max_us = p;
    }
    S->sync_last_t = t;
    if (!S->trace)
        return;
    fprintf(S->trace, "y,%u,%llu\n", (unsigned)S->syncs, (unsigned long long)t);
}

/* Each node's TPDO1 (statusword, position actual): when every node has answered the n-th
 * SYNC, write the executed point "a,n,POS..." (program units). */
static void cs_snoop_tpdo(cs_t *S, const ef_can_frame_t *f)
{
    if (f->flags || f->dlc < 6 || (f->id & ~0x7Fu) != EF_CO_COB_TPDO1)
        return;
    int k = cs_node_index(S, f->id & 0x7Fu);
    if (k < 0)
        return;
    S->tp_ring[k][S->tp_count[k] % CS_TP_RING] = (int32_t)ef_co_get32(&f->data[2]);
    S->tp_count[k]++;
    if (!S->trace)
        return;
    for (;;) {
        uint32_t n = S->tp_rows;
        for (int j = 0; j < S->c->n_nodes; j++)
            if (S->tp_count[j] <= n || S->tp_count[j] - n > CS_TP_RING)
                return; /* not all in yet (or a node far ahead: its old ones are gone) */
        fprintf(S->trace, "a,%u", (unsigned)(n + 1u));
        for (int j = 0; j < S->c->n_nodes; j++) {
            const ef_com_node_t *nd = ef_comaster_node(&S->ms, j);
            fprintf(S->trace, ",%.6f",
                    (double)ef_co_inc_to_pos(S->tp_ring[j][n % CS_TP_RING], nd->inc_per_unit));
        }
        fputc('\n', S->trace);
        S->tp_rows++;
    }
}

/* The master's port: the transport's send, watching for the SYNCs it sends. */
static int cs_send(void *ctx, const ef_can_frame_t *f)
{
    cs_t *S = ctx;
    int rc = ef_canif_send(&S->ci, f);
    if (rc == EF_OK && f->id == EF_CO_COB_SYNC && !(f->flags & EF_CAN_FLAG_EFF))
        cs_on_sync(S);
    return rc;
}

/* Keep the SYNC count at which the master's first error was seen (for the message). */
static void cs_note_error(cs_t *S)
{
    if (!S->err_seen && ef_comaster_error(&S->ms)->code != 0) {
        S->err_seen = 1;
        S->err_sync = S->syncs;
    }
}

/* The pump's node: new bus conditions (bus-off, error-passive, interface down) go to the
 * master. */
static void cs_bus(void *obj, uint32_t bad)
{
    cs_t *S = obj;
    S->bus_seen |= bad;
    ef_comaster_bus_error(&S->ms, bad);
    cs_note_error(S);
}

/* The pump's node: every received frame to the master, its TPDO1s into the trace. */
static int cs_rx(void *obj, const ef_can_frame_t *f, uint32_t ts_us)
{
    cs_t *S = obj;
    (void)ts_us;
    cs_snoop_tpdo(S, f);
    int rc = ef_comaster_rx(&S->ms, f);
    cs_note_error(S);
    return rc;
}

/* The pump's node: the master's time. */
static int cs_process(void *obj, uint32_t dt_us, uint32_t *next_us)
{
    cs_t *S = obj;
    /* What the transport still holds is not lost: go-back-N waits for it (ef_comaster.h). */
    ef_canif_status_t st;
    ef_canif_status(&S->ci, 0, &st);
    ef_comaster_tx_pending(&S->ms, st.tx_pending + st.tx_unconfirmed);
    S->bus_seen |= st.seen & EF_CANIF_BAD;
    int rc = ef_comaster_process(&S->ms, dt_us, next_us); /* errors are kept by the master */
    cs_note_error(S);
    return rc;
}

/* Microseconds since the socket opened, now. */
static uint64_t cs_now(const cs_t *S)
{
    return ef_canpump_elapsed_us(&S->pump);
}

/* The clock of the waits bounded by the path's time: it stands while a segment-mode feed
 * hold is requested (a hold may last as long as the operator wants). */
static uint64_t cs_run_now(const cs_t *S)
{
    return cs_now(S) - S->held_us;
}

/* A socket error that ended the pump (0: none): nothing can reach the drives any more. */
static int cs_io_rc(const cs_t *S)
{
    return ef_canpump_error(&S->pump);
}

static uint64_t cs_mono_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* The program line being executed: the remembered move that passes nearest the drives'
 * actual positions (segment mode executes in the drives, CSP up to a queue ahead). */
static uint32_t cs_line_at(const cs_t *S, const float *pos)
{
    uint32_t n = S->mr_n < CS_MRING ? S->mr_n : CS_MRING, best_tag = 0;
    double best = 1e300;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t k = (S->mr_n - 1u - i) % CS_MRING;
        for (int j = 0; j < CS_MPTS; j++) {
            double d = 0;
            for (int a = 0; a < S->c->n_nodes; a++)
                d +=
                    ((double)S->mring[k].p[j][a] - pos[a]) * ((double)S->mring[k].p[j][a] - pos[a]);
            if (d < best) {
                best = d;
                best_tag = S->mring[k].tag;
            }
        }
    }
    return best_tag;
}

/* Segment mode, every pump round: the drives hold while the feed-hold input asks (the
 * master sends the halt bit to all of them in one SYNC); the time it is asked for while the
 * drives execute does not count against the waits' bounds, and the time they all report
 * standing is the held time. */
static void cs_seg_hold(cs_t *S)
{
    uint64_t now = cs_now(S), dt = now - S->hold_t;
    S->hold_t = now;
    int st = ef_comaster_state(&S->ms);
    int exec = st == EF_COM_RUN || st == EF_COM_FINISH;
    int all = 1;
    for (int k = 0; k < S->c->n_nodes; k++)
        all &= (ef_comaster_node(&S->ms, k)->statusword & EF_CO_SW_HELD) != 0;
    if (exec && S->ms.halt) {
        S->held_us += dt;
        if (all)
            S->held_s += (double)dt * 1e-6;
    }
    int want = ef_mio_hold(S->c->mio);
    if (want != S->ms.halt && exec) {
        (void)ef_comaster_hold(&S->ms, want); /* segment mode: cannot fail */
        if (want)
            S->holds++;
    }
}

/* Machine I/O, every pump round: a trip (e-stop, alarm, GPIO error) stops every drive
 * under control; the error names the input and the line being executed. */
static void cs_mio(cs_t *S)
{
    ef_mio_t *io = S->c->mio;
    if (!io)
        return;
    uint32_t nx;
    ef_msg_t mm = {{0}};
    int trip = ef_mio_process(io, &nx, &mm) == EF_ERR_ESTOP;
    if (S->seg_hold_on && !S->estop && !trip)
        cs_seg_hold(S);
    if (!trip || S->estop)
        return;
    S->estop = 1;
    int st = ef_comaster_state(&S->ms);
    ef_comaster_stop(&S->ms);
    S->estop_cmd_ns = cs_mono_ns();
    S->estop_edge_ns = io->trip_ns ? io->trip_ns : S->estop_cmd_ns;
    for (int k = 0; k < S->c->n_nodes; k++)
        S->estop_pos[k] = ef_comaster_node(&S->ms, k)->pos;
    uint32_t line = st == EF_COM_RUN || st == EF_COM_FINISH ? cs_line_at(S, S->estop_pos) : 0;
    S->res->estop_line = line;
    S->res->estop_latency_s = (double)(S->estop_cmd_ns - S->estop_edge_ns) * 1e-9;
    char at[96] = "before motion";
    if (line)
        snprintf(at, sizeof at, "at program line %u", (unsigned)line);
    else if (st == EF_COM_RUN || st == EF_COM_FINISH)
        snprintf(at, sizeof at, "while running");
    else if (st == EF_COM_STOPPING || st == EF_COM_ERROR)
        snprintf(at, sizeof at, "while the drives were stopping (master state %d)", st);
    ef_fail(&S->estop_msg, EF_ERR_ESTOP, "%s %s", mm.text, at);
}

/* One round of the pump, waiting at most until the master's next deadline or max_wait_us. */
static void cs_pump(cs_t *S, uint32_t max_wait_us)
{
    if (S->c->mio && max_wait_us > CS_MIO_WAIT_US)
        max_wait_us = CS_MIO_WAIT_US;
    (void)ef_canpump_poll(&S->pump, max_wait_us); /* an error is kept by the pump */
    cs_mio(S);
}

/* The master left RUN (or the socket failed) while the caller streams: its error. */
static int cs_not_running(cs_t *S)
{
    S->cb_master = 1;
    if (S->estop)
        return S->cb_rc = ef_fail(&S->cbm, EF_ERR_ESTOP, "%s", S->estop_msg.text);
    if (cs_io_rc(S))
        return S->cb_rc = ef_fail(&S->cbm, cs_io_rc(S), "%s", ef_canpump_msg(&S->pump));
    const ef_com_error_t *e = ef_comaster_error(&S->ms);
    if (e->code != 0) {
        char t[400];
        cs_error_text(S, t, sizeof t);
        return S->cb_rc = ef_fail(&S->cbm, e->code, "%s", t);
    }
    return S->cb_rc = ef_fail(&S->cbm, EF_ERR_STATE, "the master left RUN (state %d)",
                              ef_comaster_state(&S->ms));
}

/* Give up waiting for a full queue to drain after stall_ms plus the longest move. */
static int cs_stalled(cs_t *S, uint64_t t0, const char *what)
{
    uint64_t lim = (uint64_t)S->c->stall_ms * 1000u + (uint64_t)(S->longest * 1e6);
    if (cs_run_now(S) - t0 <= lim)
        return 0;
    S->cb_rc = ef_fail(&S->cbm, EF_ERR_TIMEOUT, "%s: the master's queue has not drained for %.1f s",
                       what, (double)lim * 1e-6);
    return 1;
}

/* The program must start where the drives are (nothing may jump at the first SYNC). */
static int cs_check_start(cs_t *S, const float *p)
{
    S->start_checked = 1;
    int bad = 0;
    for (int k = 0; k < S->c->n_nodes; k++) {
        const ef_com_node_t *nd = ef_comaster_node(&S->ms, k);
        double tol = 1e-3 + (nd->inc_per_unit ? 1.0 / nd->inc_per_unit : 0.0);
        if (fabs((double)nd->pos - (double)p[k]) > tol)
            bad = 1;
    }
    if (!bad)
        return EF_OK;
    char at[160], dr[160];
    at[0] = dr[0] = 0;
    for (int k = 0; k < S->c->n_nodes; k++) {
        snprintf(at + strlen(at), sizeof at - strlen(at), "%s%.4f", k ? " " : "", (double)p[k]);
        snprintf(dr + strlen(dr), sizeof dr - strlen(dr), "%s%.4f", k ? " " : "",
                 (double)ef_comaster_node(&S->ms, k)->pos);
    }
    return S->cb_rc = ef_fail(&S->cbm, EF_ERR_ARG,
                              "the path starts at (%s) but the drives are at (%s): move them "
                              "there first",
                              at, dr);
}

/* Segment mode: each planned move goes to the master's queue (pumping while it is full). */
static int cs_move(void *user, const ef_move_t *mv, const ef_pipe_move_info_t *mi)
{
    (void)mi;
    cs_t *S = user;
    S->res->moves++;
    S->res->path_time += mv->duration;
    if (S->c->mio) {
        uint32_t k = S->mr_n++ % CS_MRING;
        S->mring[k].tag = mv->tag;
        for (int j = 0; j < CS_MPTS; j++) {
            ef_vec3_t q = mv->b[0];
            (void)ef_bezier_eval(mv->b, mv->degree, (float)j / (CS_MPTS - 1), 0, &q);
            S->mring[k].p[j][0] = q.x;
            S->mring[k].p[j][1] = q.y;
            S->mring[k].p[j][2] = q.z;
            for (int a = 3; a < S->c->n_nodes; a++)
                S->mring[k].p[j][a] =
                    ef_bezier_eval_scalar(mv->ab[a - 3], mv->degree, (float)j / (CS_MPTS - 1));
        }
    }
    if (mv->duration > S->longest)
        S->longest = mv->duration;
    /* The first move's start is the path's, in both modes: CSP's first setpoint is one
     * cycle into the path, a visible step away at a long cycle (0.026 mm at 20 ms). */
    if (!S->start_checked) {
        float p[EF_CAN_STREAM_MAX_NODES] = {mv->b[0].x, mv->b[0].y, mv->b[0].z};
        for (int a = 3; a < S->c->n_nodes; a++)
            p[a] = mv->ab[a - 3][0];
        if (cs_check_start(S, p) != EF_OK)
            return S->cb_rc;
    }
    if (S->c->mode != EF_COM_MODE_SEGMENT)
        return EF_OK;
    uint32_t seq = S->ms.next_seq;
    uint64_t t0 = cs_run_now(S);
    for (;;) {
        if (cs_io_rc(S) || ef_comaster_state(&S->ms) != EF_COM_RUN)
            return cs_not_running(S);
        int rc = ef_comaster_push_move(&S->ms, mv);
        if (rc == EF_OK)
            break;
        if (rc != EF_ERR_FULL)
            return S->cb_rc = ef_fail(&S->cbm, rc, "segment %u (line %u) refused by the master: %s",
                                      (unsigned)seq, (unsigned)mv->tag, ef_err_str(rc));
        if (cs_stalled(S, t0, "segment"))
            return S->cb_rc;
        cs_pump(S, S->mc.cycle_us);
    }
    S->res->segments++;
    S->pushed_time += mv->duration;
    S->last_cmd[0] = mv->b[mv->degree].x;
    S->last_cmd[1] = mv->b[mv->degree].y;
    S->last_cmd[2] = mv->b[mv->degree].z;
    for (int a = 3; a < S->c->n_nodes; a++)
        S->last_cmd[a] = mv->ab[a - 3][mv->degree];
    if (S->trace)
        fprintf(S->trace, "m,%u,%u,%u\n", (unsigned)seq, (unsigned)mv->tag, (unsigned)mv->degree);
    if (S->c->verbose && S->res->segments % 200 == 0)
        fprintf(stderr, "stream: %u segments queued, SYNC %u\n", S->res->segments, S->syncs);
    return EF_OK;
}

/* One target to the master's queue, pumping while it is full. */
static int cs_push_target(cs_t *S, const float *pos, uint32_t tag)
{
    uint64_t t0 = cs_run_now(S);
    for (;;) {
        if (cs_io_rc(S) || ef_comaster_state(&S->ms) != EF_COM_RUN)
            return cs_not_running(S);
        int rc = ef_comaster_push_target(&S->ms, pos);
        if (rc == EF_OK)
            break;
        if (rc != EF_ERR_FULL)
            return S->cb_rc = ef_fail(&S->cbm, rc, "target %u (line %u) refused by the master: %s",
                                      (unsigned)S->res->targets, (unsigned)tag, ef_err_str(rc));
        if (cs_stalled(S, t0, "target"))
            return S->cb_rc;
        cs_pump(S, S->mc.cycle_us);
    }
    S->res->targets++;
    memcpy(S->last_cmd, pos, sizeof S->last_cmd);
    if (S->trace) {
        fprintf(S->trace, "t,%u", (unsigned)S->syncs);
        for (int k = 0; k < S->c->n_nodes; k++)
            fprintf(S->trace, ",%.6f", (double)pos[k]);
        fputc('\n', S->trace);
    }
    return EF_OK;
}

/* Feed hold (CSP): every target the warp has for the samples received (end: and the last
 * sample itself). Held, the same place goes out every cycle, paced by the target queue. */
static int cs_hold_emit(cs_t *S, int end)
{
    float pos[EF_COM_MAX_NODES] = {0};
    uint32_t tag = 0;
    while (ef_warp_next(&S->warp, ef_mio_hold(S->c->mio), end, pos, &tag)) {
        int rc = cs_push_target(S, pos, tag);
        if (rc != EF_OK)
            return rc;
    }
    return EF_OK;
}

/* CSP: every setpoint (one per cycle) is the next target of the nodes' axes (through the
 * feed-hold warp when a hold input is wired). */
static int cs_setpoint(void *user, double t, const ef_setpoint_t *sp, const ef_pipe_move_info_t *mi)
{
    (void)t;
    (void)mi;
    cs_t *S = user;
    float pos[EF_COM_MAX_NODES] = {sp->p.x, sp->p.y, sp->p.z};
    for (int a = 3; a < S->c->n_nodes; a++)
        pos[a] = sp->aux[a - 3];
    if (!S->start_checked && cs_check_start(S, pos) != EF_OK)
        return S->cb_rc;
    if (!S->hold_on)
        return cs_push_target(S, pos, sp->tag);
    ef_warp_push(&S->warp, pos, sp->tag);
    return cs_hold_emit(S, 0);
}

/* Whether every node has received every pushed segment and reports it has executed them. */
static int cs_seg_drained(const cs_t *S)
{
    for (int k = 0; k < S->c->n_nodes; k++) {
        const ef_com_node_t *nd = ef_comaster_node(&S->ms, k);
        /* TPDO1 carries the flow control and the statusword together: target reached with
         * every segment received means every segment executed (bit 12 stays set while the
         * queue runs, also at rest). */
        if (nd->next_seq != S->ms.next_seq || !(nd->statusword & EF_CO_SW_TARGET_REACHED))
            return 0;
    }
    return 1;
}

/* Events (tool changes, dwells) come after the motion before them has gone to the drives:
 * CSP waits until the target queue is empty; segment mode, once execution has started,
 * until every node has executed everything (before that, the moves wait in the queue). */
static int cs_outputs(cs_t *S, const ef_gcode_item_t *it);

static int cs_event(void *user, const ef_gcode_item_t *it)
{
    cs_t *S = user;
    if (S->hold_on) {
        int rc = cs_hold_emit(S, 1); /* the targets before the event first */
        if (rc != EF_OK)
            return rc;
    }
    uint64_t t0 = cs_run_now(S);
    uint64_t lim = (uint64_t)S->c->stall_ms * 1000u + (uint64_t)(S->pushed_time * 1e6);
    for (;;) {
        if (cs_io_rc(S) || ef_comaster_state(&S->ms) != EF_COM_RUN)
            return cs_not_running(S);
        if (S->c->mode == EF_COM_MODE_CSP) {
            if (ef_comaster_space(&S->ms) >= EF_COM_TARGETQ)
                break;
        } else if (!S->ms.running || cs_seg_drained(S)) {
            break;
        }
        if (cs_run_now(S) - t0 > lim)
            return S->cb_rc = ef_fail(&S->cbm, EF_ERR_TIMEOUT,
                                      "event at line %u: the drives did not finish the moves "
                                      "before it in %.1f s",
                                      (unsigned)it->line, (double)lim * 1e-6);
        cs_pump(S, S->mc.cycle_us);
    }
    if (S->c->verbose)
        fprintf(stderr, "stream: event at line %u after %u moves, SYNC %u\n", (unsigned)it->line,
                S->res->moves, S->syncs);
    return cs_outputs(S, it);
}

/* Largest distance of the drives' actual positions from the last commanded point (mm). */
static double cs_cmd_error(const cs_t *S)
{
    double d = 0;
    for (int k = 0; k < S->c->n_nodes; k++) {
        double e = (double)ef_comaster_node(&S->ms, k)->pos - S->last_cmd[k];
        d += e * e;
    }
    return sqrt(d);
}

/* M62-M65 P in an event (the motion before it is at rest): switch the machine file's output
 * P once the axes stand at the commanded point (within CS_OUT_TOL, or after CS_OUT_WAIT_MS),
 * and report how far from it they were. */
#define CS_OUT_TOL     0.005
#define CS_OUT_WAIT_MS 500u
static int cs_outputs(cs_t *S, const ef_gcode_item_t *it)
{
    int codes[8];
    long ps[8];
    int nw = ef_mio_m_words(it->text, codes, ps, 8);
    for (int w = 0; w < nw; w++) {
        long code = codes[w], p = ps[w];
        if (!S->c->mio) {
            if (!S->out_noted)
                fprintf(stderr,
                        "stream: line %u: M%ld P%ld not switched: no machine file (--machine) "
                        "wires the program's outputs (said once)\n",
                        (unsigned)it->line, code, p);
            S->out_noted = 1;
            continue;
        }
        uint64_t t0 = cs_now(S);
        while (cs_cmd_error(S) > CS_OUT_TOL && cs_now(S) - t0 < CS_OUT_WAIT_MS * 1000ull) {
            if (cs_io_rc(S) || ef_comaster_state(&S->ms) != EF_COM_RUN)
                return cs_not_running(S);
            cs_pump(S, S->mc.cycle_us);
        }
        double err = cs_cmd_error(S);
        ef_msg_t om = {{0}};
        int rc = p < 0 ? ef_fail(&om, EF_ERR_ARG, "needs a P word (the output)")
                       : ef_mio_out(S->c->mio, (unsigned)p, code == 62 || code == 64, &om);
        if (rc != EF_OK)
            return S->cb_rc = ef_fail(&S->cbm, rc, "line %u: M%ld P%ld: %s", (unsigned)it->line,
                                      code, p, om.text);
        S->res->outputs++;
        if (err > S->res->out_err_max)
            S->res->out_err_max = err;
        if (S->trace)
            fprintf(S->trace, "o,%u,%ld,%ld,%.6f\n", (unsigned)it->line, code, p, err);
    }
    return EF_OK;
}

/* Pipeline thread: queue one item, waiting while the queue is full; EF_ERR_STATE once the
 * bus thread has given up. */
static int cs_enqueue(cs_t *S, const cs_item_t *it)
{
    pthread_mutex_lock(&S->mu);
    while (S->q_count >= CS_QUEUE && !S->abort)
        pthread_cond_wait(&S->cv, &S->mu);
    int rc = S->abort ? EF_ERR_STATE : EF_OK;
    if (rc == EF_OK) {
        S->q[(S->q_head + S->q_count) % CS_QUEUE] = *it;
        S->q_count++;
    }
    pthread_mutex_unlock(&S->mu);
    return rc;
}

/* Pipeline thread: a planned move. */
static int cs_w_move(void *user, const ef_move_t *mv, const ef_pipe_move_info_t *mi)
{
    (void)mi;
    static const cs_item_t zero;
    cs_item_t it = zero;
    it.kind = CS_ITEM_MOVE;
    it.mv = *mv;
    return cs_enqueue(user, &it);
}

/* Pipeline thread: a CSP setpoint. */
static int cs_w_setpoint(void *user, double t, const ef_setpoint_t *sp,
                         const ef_pipe_move_info_t *mi)
{
    (void)mi;
    static const cs_item_t zero;
    cs_item_t it = zero;
    it.kind = CS_ITEM_SETPOINT;
    it.t = t;
    it.sp = *sp;
    return cs_enqueue(user, &it);
}

/* Pipeline thread: an event. */
static int cs_w_event(void *user, const ef_gcode_item_t *gi)
{
    static const cs_item_t zero;
    cs_item_t it = zero;
    it.kind = CS_ITEM_EVENT;
    it.it = *gi;
    return cs_enqueue(user, &it);
}

/* The pipeline thread: smooth (and in CSP interpolate) the program into the queue. */
static void *cs_worker(void *arg)
{
    cs_t *S = arg;
    ef_pipe_cb_t cb;
    memset(&cb, 0, sizeof cb);
    cb.on_move = cs_w_move;
    cb.on_event = cs_w_event;
    if (S->c->mode == EF_COM_MODE_CSP)
        cb.on_setpoint = cs_w_setpoint;
    cb.user = S;
    int rc = ef_pipe_run(S->r, &S->pc, &cb, &S->res->pipe, &S->worker_msg);
    pthread_mutex_lock(&S->mu);
    S->worker_rc = rc;
    S->worker_done = 1;
    pthread_mutex_unlock(&S->mu);
    return NULL;
}

/* Bus thread: run the pipeline thread and hand its items to the master, pumping the bus
 * all the while. Returns EF_OK, a handler's error (S->cb_rc, S->cbm) or the pipeline's
 * (message in m). */
static int cs_run_pipeline(cs_t *S, ef_msg_t *m)
{
    pthread_t th;
    if (pthread_create(&th, NULL, cs_worker, S) != 0)
        return ef_fail(m, EF_ERR_NOMEM, "stream: cannot start the pipeline thread");
    int rc = EF_OK;
    for (;;) {
        cs_item_t it;
        int have = 0, done = 0;
        pthread_mutex_lock(&S->mu);
        if (S->q_count > 0) {
            it = S->q[S->q_head];
            S->q_head = (S->q_head + 1u) % CS_QUEUE;
            S->q_count--;
            have = 1;
            pthread_cond_signal(&S->cv);
        } else {
            done = S->worker_done;
        }
        pthread_mutex_unlock(&S->mu);
        if (have) {
            if (it.kind == CS_ITEM_MOVE)
                rc = cs_move(S, &it.mv, NULL);
            else if (it.kind == CS_ITEM_SETPOINT)
                rc = cs_setpoint(S, it.t, &it.sp, NULL);
            else
                rc = cs_event(S, &it.it);
            if (rc != EF_OK)
                break;
            continue;
        }
        if (done) {
            if (S->hold_on) /* the warp's last targets, the path's end among them */
                rc = cs_hold_emit(S, 1);
            break;
        }
        if (cs_io_rc(S) || ef_comaster_state(&S->ms) != EF_COM_RUN) {
            rc = cs_not_running(S);
            break;
        }
        cs_pump(S, S->mc.cycle_us); /* the pipeline is working: keep the bus going */
    }
    pthread_mutex_lock(&S->mu);
    S->abort = 1;
    pthread_cond_broadcast(&S->cv);
    pthread_mutex_unlock(&S->mu);
    pthread_join(th, NULL);
    if (rc != EF_OK)
        return rc;
    if (S->worker_rc != EF_OK)
        return ef_fail(m, S->worker_rc, "%s", S->worker_msg.text);
    return EF_OK;
}

/* Pump until the master is DONE or in ERROR, for at most lim_us; 1 if it got there. */
static int cs_wait_end(cs_t *S, uint64_t lim_us)
{
    uint64_t t0 = cs_run_now(S); /* a hold stops it only while FINISH executes */
    for (;;) {
        int st = ef_comaster_state(&S->ms);
        if (st == EF_COM_DONE || st == EF_COM_ERROR)
            return 1;
        if (cs_io_rc(S) || cs_run_now(S) - t0 > lim_us)
            return 0;
        cs_pump(S, S->mc.cycle_us);
    }
}

/* Check the configuration before anything touches the bus. */
static int cs_check_cfg(const ef_can_stream_cfg_t *c, ef_msg_t *m)
{
    if (!c->iface || !c->iface[0])
        return ef_fail(m, EF_ERR_ARG, "stream: no CAN interface");
    if (c->n_nodes < 1 || c->n_nodes > EF_CAN_STREAM_MAX_NODES)
        return ef_fail(m, EF_ERR_ARG, "stream: 1..%d nodes (got %u)", EF_CAN_STREAM_MAX_NODES,
                       (unsigned)c->n_nodes);
    for (int k = 0; k < c->n_nodes; k++) {
        if (c->nodes[k] < 1 || c->nodes[k] > 127)
            return ef_fail(m, EF_ERR_ARG, "stream: node id %u: must be 1..127",
                           (unsigned)c->nodes[k]);
        for (int j = 0; j < k; j++)
            if (c->nodes[j] == c->nodes[k])
                return ef_fail(m, EF_ERR_ARG, "stream: node id %u given twice",
                               (unsigned)c->nodes[k]);
    }
    if (c->mode != EF_COM_MODE_CSP && c->mode != EF_COM_MODE_SEGMENT)
        return ef_fail(m, EF_ERR_ARG, "stream: mode must be csp or segment");
    if (c->boot_timeout_ms == 0 || c->hb_timeout_ms == 0 || c->sdo_timeout_ms == 0 ||
        c->enable_timeout_ms == 0 || c->stop_timeout_ms == 0 || c->bringup_ms == 0 ||
        c->bitrate == 0)
        return ef_fail(m, EF_ERR_ARG, "stream: a timeout or the bit rate is 0");
    return EF_OK;
}

/* Figures of the run into the result. */
static void cs_result(cs_t *S)
{
    ef_can_stream_result_t *res = S->res;
    res->syncs = S->syncs;
    if (S->p_n > 0) {
        res->sync_mean_us = S->p_sum / (double)S->p_n;
        double var = S->p_sq / (double)S->p_n - res->sync_mean_us * res->sync_mean_us;
        res->sync_std_us = var > 0.0 ? sqrt(var) : 0.0;
    }
    ef_canif_status_t st;
    ef_canif_status(&S->ci, 0, &st);
    res->tx_frames = st.tx;
    res->tx_bits = st.tx_bits;
    res->err_frames = st.err_frames;
    res->rx_overrun = st.rx_overrun;
    res->rx_frames = ef_canpump_rx_frames(&S->pump);
    res->rx_bits = ef_canpump_rx_bits(&S->pump);
    res->wall_time = (double)cs_now(S) * 1e-6;
    res->run_time = S->t_run ? (double)(cs_now(S) - S->t_run) * 1e-6 : 0.0;
    res->bus_time_s = (double)res->tx_bits / S->c->bitrate;
    if (res->wall_time > 0.0)
        res->load = (double)(res->tx_bits + res->rx_bits) / S->c->bitrate / res->wall_time;
    res->state = ef_comaster_state(&S->ms);
    res->err = *ef_comaster_error(&S->ms);
    for (int k = 0; k < S->c->n_nodes; k++) {
        const char *nm = ef_comaster_name(&S->ms, k);
        snprintf(res->names[k], sizeof res->names[k], "%s", nm ? nm : "");
    }
    uint32_t acked = UINT32_MAX;
    for (int k = 0; k < S->c->n_nodes; k++) {
        const ef_com_node_t *nd = ef_comaster_node(&S->ms, k);
        res->resends += nd->resends;
        if (nd->next_seq < acked)
            acked = nd->next_seq;
    }
    res->starved = S->ms.starved;
    res->holds = S->holds + S->warp.holds;
    res->held_s = S->held_s + S->warp.held_s;
    int done = res->state == EF_COM_DONE && S->ms.finishing;
    if (S->c->mode == EF_COM_MODE_SEGMENT)
        res->executed = done ? res->segments : (acked < res->segments ? acked : res->segments);
    else
        res->executed = done ? res->targets
                             : (S->ms.tq_count < res->targets ? res->targets - S->ms.tq_count : 0);
}

/* The whole stream (see ef_canhost.h). */
int ef_can_stream(ef_gcode_t *r, const ef_can_stream_cfg_t *c, ef_can_stream_result_t *res,
                  ef_msg_t *m)
{
    if (!r || !c || !res)
        return ef_fail(m, EF_ERR_ARG, "stream: missing argument");
    memset(res, 0, sizeof *res);
    int rc = cs_check_cfg(c, m);
    if (rc != EF_OK)
        return rc;
    cs_t *S = calloc(1, sizeof *S);
    if (!S)
        return ef_fail(m, EF_ERR_NOMEM, "stream: no memory for the CANopen master");
    S->c = c;
    S->res = res;
    pthread_mutex_init(&S->mu, NULL);
    pthread_cond_init(&S->cv, NULL);
    ef_comaster_cfg_default(&S->mc, c->mode);
    for (int k = 0; k < c->n_nodes; k++)
        S->mc.nodes[k] = c->nodes[k];
    S->mc.n_nodes = c->n_nodes;
    S->mc.fault_reset = c->fault_reset;
    if (c->cycle_us)
        S->mc.cycle_us = c->cycle_us;
    S->mc.boot_timeout_ms = c->boot_timeout_ms;
    S->mc.hb_timeout_ms = (uint16_t)(c->hb_timeout_ms > 65535u ? 65535u : c->hb_timeout_ms);
    S->mc.sdo_timeout_ms = c->sdo_timeout_ms;
    S->mc.enable_timeout_ms = c->enable_timeout_ms;
    S->mc.stop_timeout_ms = c->stop_timeout_ms;
    if (c->trace) {
        S->trace = fopen(c->trace, "w");
        if (!S->trace) {
            rc = ef_fail(m, EF_ERR_IO, "stream: trace %s: %s", c->trace, strerror(errno));
            free(S);
            return rc;
        }
    }
    /* Machine I/O first: an active e-stop, its latch or an alarm refuses the stream before
     * a single frame could enable a drive. */
    if (c->mio && (rc = ef_mio_arm(c->mio, m)) != EF_OK) {
        char t[sizeof m->text];
        snprintf(t, sizeof t, "%s", m ? m->text : ef_err_str(rc));
        ef_fail(m, rc, "stream: %s", t);
        if (S->trace)
            fclose(S->trace);
        free(S);
        return rc;
    }
    S->ci = c->canif ? *c->canif : ef_sockcan_canif(&S->sk);
    ef_canif_cfg_t icfg = {.name = c->iface, .log = c->log};
    rc = ef_canif_open(&S->ci, &icfg, m);
    if (rc != EF_OK) {
        if (c->mio)
            (void)ef_mio_disarm(c->mio, NULL); /* nothing was sent: the open's error is it */
        if (S->trace)
            fclose(S->trace);
        free(S);
        return rc;
    }
    ef_canpump_cfg_t pcfg;
    ef_canpump_cfg_default(&pcfg);
    pcfg.pending_wait_us = CS_BACKLOG_WAIT_US;
    /* Bus-off is reported once; from then on the controller decides whether a frame can go
     * (the transport would refuse every send while it believes the bus is off, and the
     * master's controlled stop must still be tried: a bus that recovers carries it). */
    pcfg.bus_clear = EF_CANIF_BUS_OFF;
    const ef_canpump_node_t node = {cs_rx, cs_process, cs_bus, S};
    (void)ef_canpump_init(&S->pump, &S->ci, &node, &pcfg); /* arguments are all set */
    ef_can_port_t port = {cs_send, S};
    rc = ef_comaster_init(&S->ms, &S->mc, &port);
    if (rc != EF_OK) {
        ef_fail(m, rc,
                "stream: the CANopen master refused its configuration (nodes, cycle "
                "%u us, timeouts)",
                (unsigned)S->mc.cycle_us);
        goto out;
    }
    if (S->trace) {
        fprintf(S->trace, "# evenfeed stream can %s nodes",
                c->mode == EF_COM_MODE_CSP ? "csp" : "segment");
        for (int k = 0; k < c->n_nodes; k++)
            fprintf(S->trace, "%c%u", k ? ',' : ' ', (unsigned)c->nodes[k]);
        fprintf(S->trace, " iface %s cycle_us %u\n", c->iface, (unsigned)S->mc.cycle_us);
    }

    /* Bring-up: boot, configuration, start, enable (errors come from the master). */
    uint64_t lim = (uint64_t)c->bringup_ms * 1000u;
    while (!cs_io_rc(S)) {
        int st = ef_comaster_state(&S->ms);
        if (st == EF_COM_RUN || st == EF_COM_DONE || st == EF_COM_ERROR)
            break;
        if (cs_now(S) > lim) {
            rc = ef_fail(m, EF_ERR_TIMEOUT,
                         "stream: %s: drives not running %u ms after the start "
                         "(master state %d)",
                         c->iface, (unsigned)c->bringup_ms, st);
            break;
        }
        cs_pump(S, 100000u);
    }
    if (rc == EF_OK && ef_comaster_state(&S->ms) == EF_COM_RUN) {
        S->t_run = cs_now(S);
        if (c->verbose)
            fprintf(stderr, "stream: %s: %u drives operation enabled after %.3f s\n", c->iface,
                    (unsigned)c->n_nodes, (double)S->t_run * 1e-6);
        S->r = r;
        S->pc = c->pipe;
        S->pc.naux = c->n_nodes > 3 ? c->n_nodes - 3 : 0; /* one drive per axis */
        S->hold_on = c->mio && c->mio->cfg.hold >= 0 && c->mode == EF_COM_MODE_CSP;
        S->seg_hold_on = c->mio && c->mio->cfg.hold >= 0 && c->mode == EF_COM_MODE_SEGMENT;
        const float *aa = S->pc.lim.a_axis;
        ef_warp_init(&S->warp, c->n_nodes, S->mc.cycle_us * 1e-6, fmin(aa[0], fmin(aa[1], aa[2])));
        if (c->mode == EF_COM_MODE_CSP) {
            S->pc.period_us = S->mc.cycle_us;
            S->pc.interp_modes = 1u << S->pc.step_mode;
        }
        rc = cs_run_pipeline(S, m);
        if (rc != EF_OK && S->cb_rc != EF_OK) {
            rc = S->cb_rc;
            ef_fail(m, rc, "stream: %s", S->cbm.text);
        } else if (rc != EF_OK) {
            char t[sizeof m->text];
            snprintf(t, sizeof t, "%s", m ? m->text : ef_err_str(rc));
            ef_fail(m, rc, "stream: %s", t);
        }
        if (rc == EF_OK && ef_comaster_finish(&S->ms) != EF_OK) {
            rc = cs_not_running(S);
            ef_fail(m, rc, "stream: %s", S->cbm.text);
        }
        if (rc == EF_OK) {
            /* Everything queued is executed, then the drives are disabled at rest. */
            uint64_t fin = (uint64_t)(S->pushed_time * 1e6) + (uint64_t)c->stall_ms * 1000u +
                           (uint64_t)c->stop_timeout_ms * 1000u;
            if (c->mode == EF_COM_MODE_CSP)
                fin += (uint64_t)EF_COM_TARGETQ * S->mc.cycle_us;
            if (!cs_wait_end(S, fin) && !cs_io_rc(S))
                rc = ef_fail(m, EF_ERR_TIMEOUT,
                             "stream: %s: the drives did not finish within %.1f s (master "
                             "state %d)",
                             c->iface, (double)fin * 1e-6, ef_comaster_state(&S->ms));
        }
    }
out:
    /* Whatever happened, the drives end stopped under control and disabled (the master's
     * own error already started that; a stop on request does it otherwise). */
    ef_comaster_stop(&S->ms);
    uint64_t stop_lim = ((uint64_t)c->stop_timeout_ms + CS_STOP_MARGIN_MS) * 1000u;
    if (S->estop && c->mio->cfg.stop_ms * 1000ull < stop_lim)
        stop_lim = c->mio->cfg.stop_ms * 1000ull; /* the machine file's bound on enable */
    int rested = cs_wait_end(S, stop_lim) && ef_comaster_error(&S->ms)->what != EF_COM_WHAT_STOP;
    ef_msg_t dm = {{0}};
    int drc = EF_OK;
    if (c->mio) {
        /* Enable drops once the drives report rest (the master is DONE or in ERROR after its
         * stop), or when the bound above ran out. */
        if (S->estop)
            res->estop_rest_s = rested ? (double)(cs_mono_ns() - S->estop_edge_ns) * 1e-9 : -1.0;
        drc = ef_mio_disarm(c->mio, &dm);
    }
    const ef_com_error_t *e = ef_comaster_error(&S->ms);
    if (S->estop) {
        char also[300] = "";
        if (e->code != 0) { /* an error of the master's own, before or during the stop */
            char t[260];
            cs_error_text(S, t, sizeof t);
            snprintf(also, sizeof also, "; the master also reported: %s", t);
        }
        rc = ef_fail(m, EF_ERR_ESTOP, "stream: %s; %s, %s%s", S->estop_msg.text,
                     rested ? "every drive stopped under control and at rest"
                            : "the drives did not report rest in time",
                     drc == EF_OK ? "enable dropped" : dm.text, also);
    } else if (drc != EF_OK && rc == EF_OK) {
        rc = ef_fail(m, drc, "stream: machine I/O: %s", dm.text);
    } else if (e->code != 0 && (rc == EF_OK || S->cb_master)) {
        /* The master's error is the cause (a callback only saw its consequence). */
        char t[400];
        cs_error_text(S, t, sizeof t);
        rc = ef_fail(m, e->code, "stream: %s", t);
    } else if (rc == EF_OK && cs_io_rc(S)) {
        rc = ef_fail(m, cs_io_rc(S), "stream: %s", ef_canpump_msg(&S->pump));
    } else if (rc == EF_OK && ef_comaster_state(&S->ms) != EF_COM_DONE) {
        rc = ef_fail(m, EF_ERR_TIMEOUT, "stream: %s: master ended in state %d", c->iface,
                     ef_comaster_state(&S->ms));
    }
    cs_result(S);
    if (S->trace) {
        fclose(S->trace);
        S->trace = NULL;
    }
    ef_canif_close(&S->ci);
    pthread_cond_destroy(&S->cv);
    pthread_mutex_destroy(&S->mu);
    free(S);
    return rc;
}
