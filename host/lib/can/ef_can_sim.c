/* SPDX-License-Identifier: Apache-2.0 */
/* Simulated CANopen CiA 402 drive (evenfeed sim-drive can): the firmware's drive
 * (ef_codrive.h) on a SocketCAN raw socket, with a trace and fault injection. */
#include <errno.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <stdlib.h>
#include <string.h>
#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/host/can/ef_canhost.h"
#include "evenfeed/host/can/ef_canpump.h"
#include "evenfeed/host/can/ef_sockcan.h"
#include "evenfeed/host/io/ef_drvio.h"

/* Longest receive wait (us): bounds how late a signal that arrives just before the wait
 * is noticed. */
#define CSIM_MAX_WAIT_US 50000u
/* Frames handled in one loop iteration before time is advanced again. */
#define CSIM_RX_BURST 64

typedef struct {
    const ef_can_sim_cfg_t *c;
    ef_codrive_t d;
    ef_sockcan_t sk; /* the transport's context: only ci touches it, but for --bus-off-at */
    ef_canif_t ci;
    ef_canpump_t pump;
    FILE *trace;
    uint32_t op_syncs; /* SYNCs received in OPERATION ENABLED */
    uint32_t chunks;   /* segment chunk frames received (1-based count of the last) */
    uint32_t last_seq; /* d.drv.next_seq already traced */
    int fault_done, hb_done, busoff_done;
    ef_drvio_t io; /* STO input, alarm output (ef_drvio.h) */
    int sto_said;  /* the STO fault was traced */
} csim_t;

/* The drive's own I/O, every SYNC and loop round: no torque without the enable input (a
 * power stage on then is an STO fault), the alarm output follows the fault. */
static void csim_io(csim_t *S)
{
    if (!S->io.open)
        return;
    int p = S->d.power;
    ef_msg_t mm = {{0}};
    int ok = ef_drvio_process(&S->io, p == EF_CO_PS_FAULT || p == EF_CO_PS_FAULT_REACTION, &mm);
    if (!ok && p == EF_CO_PS_OP_ENABLED) {
        S->io.sto_drops++;
        if (S->trace)
            fprintf(S->trace, "# STO: enable input off at SYNC %u%s%s\n", (unsigned)S->d.sync_count,
                    mm.text[0] ? ": " : "", mm.text);
        ef_codrive_fault(&S->d, EF_DRV_FAULT_STO);
        /* The alarm at once, not a round later. */
        (void)ef_drvio_process(&S->io, 1, NULL);
    }
}

/* Defaults documented in ef_canhost.h. */
void ef_can_sim_cfg_default(ef_can_sim_cfg_t *c)
{
    memset(c, 0, sizeof *c);
    c->fault_at_ms = -1;
    c->sync_timeout_ms = -1;
    c->hb_stop_at_ms = -1;
    c->bus_off_at_ms = -1;
    c->run_ms = -1;
}

/* The drive's port: the transport's send, tracing every EMCY the drive sends. */
static int csim_send(void *ctx, const ef_can_frame_t *f)
{
    csim_t *S = ctx;
    int rc = ef_canif_send(&S->ci, f);
    if (rc == EF_OK && S->trace && !(f->flags & EF_CAN_FLAG_EFF) &&
        f->id == EF_CO_COB_EMCY + S->c->node && f->dlc >= 4)
        fprintf(S->trace, "e,%u,0x%04X,%u\n", (unsigned)S->d.sync_count,
                (unsigned)ef_co_get16(f->data), (unsigned)f->data[3]);
    return rc;
}

/* A segment chunk frame of this drive: its axis records (RPDO2) or the shared law records. */
static int csim_is_chunk(const csim_t *S, const ef_can_frame_t *f)
{
    return !(f->flags & EF_CAN_FLAG_EFF) &&
           (f->id == EF_CO_COB_RPDO2 + S->c->node || f->id == EF_CO_LAW_COBID);
}

/* Whether the K-th chunk (1-based) is to be dropped (--drop-rx). */
static int csim_drop(const csim_t *S, uint32_t k)
{
    for (uint32_t i = 0; i < S->c->n_drop; i++)
        if (S->c->drop_rx[i] == k)
            return 1;
    return 0;
}

/* The move with sequence number seq in the drive's ring or interpolator queue (NULL if it
 * already left both). */
static const ef_move_t *csim_find_move(const ef_drive_t *dv, uint32_t seq)
{
    for (uint32_t i = 0; i < dv->ring_count; i++) {
        const ef_move_t *mv = &dv->ring[(dv->ring_head + i) % EF_DRIVE_SLOTS];
        if (mv->seq == seq)
            return mv;
    }
    for (uint32_t i = 0; i < dv->ip.count; i++) {
        const ef_move_t *mv = &dv->ip.q[(dv->ip.head + i) % EF_INTERP_QUEUE];
        if (mv->seq == seq)
            return mv;
    }
    return NULL;
}

/* Trace every segment the drive accepted since the last call (next_seq went up). */
static void csim_trace_accepted(csim_t *S)
{
    const ef_drive_t *dv = &S->d.drv;
    if (dv->next_seq < S->last_seq) /* fault reset: numbering from 0 again */
        S->last_seq = 0;
    for (; S->last_seq != dv->next_seq; S->last_seq++) {
        if (!S->trace)
            continue;
        const ef_move_t *mv = csim_find_move(dv, S->last_seq);
        if (mv)
            fprintf(S->trace, "s,%u,%u,%.6f\n", (unsigned)S->last_seq, (unsigned)mv->degree,
                    (double)mv->duration);
        else
            fprintf(S->trace, "s,%u,0,0\n", (unsigned)S->last_seq);
    }
}

/* Send an error frame announcing bus-off (--bus-off-at): SocketCAN's own business, since
 * vcan has no controller to go bus-off, so this one call bypasses the transport. */
static void csim_send_bus_off(csim_t *S)
{
    int rc = ef_sockcan_inject_error(&S->sk, CAN_ERR_BUSOFF);
    if (S->trace)
        fprintf(S->trace, "# bus-off error frame sent at SYNC %u: %s\n", (unsigned)S->d.sync_count,
                rc == EF_OK ? "ok" : S->sk.msg.text);
}

/* One `p` row: the drive's state now, under the last SYNC's number. */
static void csim_trace_p(csim_t *S)
{
    const ef_codrive_t *d = &S->d;
    if (S->trace)
        fprintf(S->trace, "p,%u,%u,%u,%.6f,%.6f,%.6f\n", (unsigned)d->sync_count,
                (unsigned)d->statusword, (unsigned)d->power, (double)d->drv.cmd.x,
                (double)d->drv.act.x, (double)d->drv.ferr);
}

/* After each SYNC: trace the step, then the injections due at this SYNC time. */
static void csim_after_sync(csim_t *S)
{
    const ef_codrive_t *d = &S->d;
    csim_trace_p(S);
    if (d->power == EF_CO_PS_OP_ENABLED)
        S->op_syncs++;
    uint64_t t_ms = (uint64_t)S->op_syncs * d->cycle_us / 1000u;
    if (!S->fault_done && S->c->fault_at_ms >= 0 && S->op_syncs > 0 &&
        t_ms >= (uint64_t)S->c->fault_at_ms) {
        S->fault_done = 1;
        if (S->trace)
            fprintf(S->trace, "# fault injected at SYNC %u (%llu ms operation enabled)\n",
                    (unsigned)d->sync_count, (unsigned long long)t_ms);
        ef_codrive_fault(&S->d, EF_DRV_FAULT_INJECTED);
    }
    if (!S->hb_done && S->c->hb_stop_at_ms >= 0 && S->op_syncs > 0 &&
        t_ms >= (uint64_t)S->c->hb_stop_at_ms) {
        S->hb_done = 1;
        if (S->trace)
            fprintf(S->trace, "# heartbeat stopped at SYNC %u (%llu ms operation enabled)\n",
                    (unsigned)d->sync_count, (unsigned long long)t_ms);
        ef_codrive_heartbeat_off(&S->d, 1);
    }
    if (!S->busoff_done && S->c->bus_off_at_ms >= 0 && S->op_syncs > 0 &&
        t_ms >= (uint64_t)S->c->bus_off_at_ms) {
        S->busoff_done = 1;
        csim_send_bus_off(S);
    }
}

/* The pump's node: one received frame, dropped (--drop-rx) or handed to the drive, then
 * traced. */
static int csim_rx(void *obj, const ef_can_frame_t *f, uint32_t ts_us)
{
    csim_t *S = obj;
    (void)ts_us;
    if (csim_is_chunk(S, f)) {
        S->chunks++;
        if (csim_drop(S, S->chunks)) {
            if (S->trace)
                fprintf(S->trace, "# dropped chunk %u (id 0x%03X, byte 0 0x%02X)\n",
                        (unsigned)S->chunks, (unsigned)f->id, (unsigned)f->data[0]);
            return EF_OK;
        }
    }
    uint32_t syncs = S->d.sync_count;
    uint8_t power = S->d.power;
    int rc = ef_codrive_rx(&S->d, f); /* a fault it raises is traced by its EMCY */
    csim_trace_accepted(S);
    if (S->d.sync_count != syncs)
        csim_after_sync(S);
    /* The lines are read every loop round (csim_process); here only when this frame changed
     * the power state (a controlword that switched the power stage on must meet the STO at
     * once), not for every segment chunk: a line read is a system call. */
    if (S->d.power != power)
        csim_io(S);
    return rc;
}

/* The pump's node: the drive's own time (its SYNC-loss watchdog), traced when it moved. */
static int csim_process(void *obj, uint32_t dt_us, uint32_t *next_us)
{
    csim_t *S = obj;
    float cmd0 = S->d.drv.cmd.x, act0 = S->d.drv.act.x;
    uint16_t sw0 = S->d.statusword;
    int rc = ef_codrive_process(&S->d, dt_us, next_us); /* a bus error: the drive keeps trying */
    csim_io(S);
    /* The drive stepped on its own clock (the SYNC-loss watchdog's stop): trace it too. */
    if (S->d.drv.cmd.x != cmd0 || S->d.drv.act.x != act0 || S->d.statusword != sw0)
        csim_trace_p(S);
    if (S->trace)
        fflush(S->trace); /* a reader sees everything up to now */
    return rc;
}

/* Open the trace and the socket; print the ready line. */
static int csim_open(csim_t *S, ef_msg_t *m)
{
    const ef_can_sim_cfg_t *c = S->c;
    if (!c->iface || !c->iface[0])
        return ef_fail(m, EF_ERR_ARG, "sim-drive: no CAN interface");
    if (c->node < 1 || c->node > 127)
        return ef_fail(m, EF_ERR_ARG, "sim-drive: node id %u: must be 1..127", (unsigned)c->node);
    if (c->n_drop > EF_CAN_SIM_MAX_DROPS)
        return ef_fail(m, EF_ERR_ARG, "sim-drive: at most %d --drop-rx entries",
                       EF_CAN_SIM_MAX_DROPS);
    if (c->trace) {
        S->trace = fopen(c->trace, "w");
        if (!S->trace)
            return ef_fail(m, EF_ERR_IO, "sim-drive: trace %s: %s", c->trace, strerror(errno));
        fprintf(S->trace, "# evenfeed sim-drive can node %u iface %s home %.6f\n",
                (unsigned)c->node, c->iface, (double)c->home);
    }
    /* Only what this drive listens to: NMT, SYNC, the law records, and its own RPDOs and
     * SDO requests (the kernel filters the rest of the traffic). */
    const ef_sockcan_filter_t flt[] = {
        {EF_CO_COB_NMT, 0x7FFu},
        {EF_CO_COB_SYNC, 0x7FFu},
        {EF_CO_LAW_COBID, 0x7FFu},
        {EF_CO_COB_RPDO1 + c->node, 0x7FFu},
        {EF_CO_COB_RPDO2 + c->node, 0x7FFu},
        {EF_CO_COB_RPDO3 + c->node, 0x7FFu},
        {EF_CO_COB_SDO_RX + c->node, 0x7FFu},
    };
    S->ci = ef_sockcan_canif(&S->sk);
    const ef_canif_cfg_t icfg = {.name = c->iface,
                                 .filters = flt,
                                 .n_filters = (int)(sizeof flt / sizeof flt[0]),
                                 .log = c->log};
    int rc = ef_canif_open(&S->ci, &icfg, m);
    if (rc != EF_OK)
        return rc;
    ef_canpump_cfg_t pcfg;
    ef_canpump_cfg_default(&pcfg);
    pcfg.rx_burst = CSIM_RX_BURST;
    const ef_canpump_node_t node = {csim_rx, csim_process, NULL, S};
    (void)ef_canpump_init(&S->pump, &S->ci, &node, &pcfg); /* arguments are all set */
    ef_codrive_cfg_t dc;
    ef_codrive_cfg_default(&dc, c->node);
    dc.home = c->home;
    ef_can_port_t port = {csim_send, S};
    rc = ef_codrive_init(&S->d, &dc, &port);
    if (rc != EF_OK)
        return ef_fail(m, rc, "sim-drive: node %u: the drive refused its configuration (home %g)",
                       (unsigned)c->node, (double)c->home);
    if (c->sync_timeout_ms >= 0) /* as the power-up value of 0x2003 (a reset node restores 500) */
        S->d.sync_timeout_ms = (uint16_t)c->sync_timeout_ms;
    rc = ef_drvio_open(&S->io, c->sto_line, c->alarm_line, m);
    if (rc != EF_OK)
        return rc; /* before the ready line: the drive never appears on the bus */
    csim_io(S);
    FILE *ready = c->ready ? c->ready : stdout;
    fprintf(ready, "ready can %u %s\n", (unsigned)c->node, c->iface);
    fflush(ready);
    return EF_OK;
}

/* Run the drive until stopped (see ef_canhost.h). */
int ef_can_sim_run(const ef_can_sim_cfg_t *c, ef_msg_t *m)
{
    if (!c)
        return ef_fail(m, EF_ERR_ARG, "sim-drive: missing configuration");
    csim_t *S = calloc(1, sizeof *S);
    if (!S)
        return ef_fail(m, EF_ERR_NOMEM, "sim-drive: no memory");
    S->c = c;
    S->sk.fd = -1;
    int rc = csim_open(S, m);
    while (rc == EF_OK && !(c->stop && *c->stop)) {
        uint32_t wait = CSIM_MAX_WAIT_US;
        if (c->run_ms >= 0) {
            /* Only with a run time: a clock reading per round costs under User-Mode Linux. */
            uint64_t t_us = ef_canpump_elapsed_us(&S->pump);
            if (t_us >= (uint64_t)c->run_ms * 1000u)
                break;
            uint64_t left = (uint64_t)c->run_ms * 1000u - t_us;
            if (left < wait)
                wait = (uint32_t)left;
        }
        if (ef_canpump_poll(&S->pump, wait) != EF_OK)
            rc = ef_fail(m, EF_ERR_IO, "sim-drive: %s", ef_canpump_msg(&S->pump));
    }
    if (S->trace) {
        /* Frames the kernel dropped from a full receive queue: what a held-back drive
         * never saw (a SYNC among them is a step it did not take). */
        ef_canif_status_t st;
        memset(&st, 0, sizeof st);
        ef_canif_status(&S->ci, 0, &st);
        fprintf(S->trace, "o,%u\n", (unsigned)st.rx_overrun);
        fclose(S->trace);
    }
    ef_canif_close(&S->ci);
    ef_drvio_close(&S->io);
    free(S);
    return rc;
}
