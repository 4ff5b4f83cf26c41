/* SPDX-License-Identifier: Apache-2.0 */
/*
 * In-memory CAN bus for tests, the bus-load benchmark and the demo (ef_canload.h): one
 * ef_comaster and up to EF_SIM_MAX_DRIVES ef_codrive objects on a simulated bus with
 * microsecond time. Header-only on the firmware headers, so firmware-only tests use it too.
 *
 * Every frame a participant sends is queued on the bus and later delivered to every other
 * participant (never back to its sender), in send order. With bitrate 0 the bus is
 * infinitely fast: ef_sim_step() delivers everything queued, including the answers the
 * deliveries provoke, before it returns. With a bitrate the bus carries only the bits its
 * time allows (ef_can_frame_bits(), worst-case stuffing), so frames wait and a saturated
 * bus shows as latency and as EF_ERR_AGAIN once `txcap` frames are queued.
 *
 * Usage:
 *     static ef_sim_bus_t bus; static ef_comaster_t m; static ef_codrive_t d[3];
 *     ef_sim_init(&bus);
 *     ef_sim_add_master(&bus, &m, &mcfg);          // ef_comaster_init() on the bus port
 *     ef_sim_add_drive(&bus, &d[k], &dcfg);        // ef_codrive_init() on the bus port
 *     ef_sim_run_until(&bus, EF_COM_RUN, 5000000, 100);
 *     ... ef_comaster_push_*(), ef_sim_step(&bus, 100) ...
 *
 * Hooks: `drop(ctx, frame, src, n)` returns nonzero to lose frame number n (it still
 * occupies the bus; nobody receives it); `log(ctx, t_us, src, frame)` sees each frame as it
 * goes on the bus. Statistics: frames/bits in total, per sender (src 0 is the master,
 * 1..n the drives) and per function code (id >> 7: 0 NMT, 1 SYNC/EMCY, 3 TPDO1, 4 RPDO1,
 * 5 TPDO2 / law records, 6 RPDO2, 0xB SDO tx, 0xC SDO rx, 0xE heartbeat).
 * Header-only (static functions) so a test or benchmark includes it without a library.
 */
#ifndef EF_CANBUS_SIM_H
#define EF_CANBUS_SIM_H

#include <stdint.h>
#include <string.h>

#include "evenfeed/hal/ef_can.h"
#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/core/ef_err.h"

#ifndef EF_SIM_MAX_DRIVES
#define EF_SIM_MAX_DRIVES 8
#endif
#ifndef EF_SIM_QUEUE
#define EF_SIM_QUEUE 4096
#endif

typedef struct ef_sim_bus ef_sim_bus_t;

/** Port context of one participant. */
typedef struct {
    ef_sim_bus_t *bus;
    int src; /**< 0 master, 1..n drives */
} ef_sim_pctx_t;

struct ef_sim_bus {
    ef_comaster_t *m; /**< NULL when no master was added */
    ef_codrive_t *d[EF_SIM_MAX_DRIVES];
    int n_drives;
    ef_sim_pctx_t pc[1 + EF_SIM_MAX_DRIVES];
    ef_can_frame_t q[EF_SIM_QUEUE];
    uint8_t qsrc[EF_SIM_QUEUE];
    uint32_t qhead, qcount;
    uint32_t txcap;   /**< frames queued before send answers AGAIN (default all) */
    uint32_t bitrate; /**< bits per second; 0: infinitely fast */
    uint64_t budget;  /**< bits the bus may still carry in this step */
    uint64_t now_us;  /**< simulated time */
    int (*drop)(void *ctx, const ef_can_frame_t *f, int src, uint64_t n);
    void *drop_ctx;
    void (*log)(void *ctx, uint64_t t_us, int src, const ef_can_frame_t *f);
    void *log_ctx;
    /* Statistics. */
    uint64_t frames, bits, dropped, again;
    uint64_t frames_src[1 + EF_SIM_MAX_DRIVES], bits_src[1 + EF_SIM_MAX_DRIVES];
    uint64_t frames_fn[16], bits_fn[16];
    uint32_t max_queue; /**< most frames ever waiting */
    int master_rc;      /**< first error ef_comaster_process/rx returned (0: none) */
    int drive_rc;       /**< first error a drive's rx/process returned (0: none) */
};

/* The port operation: queue the frame on the bus. */
static inline int ef_sim_send(void *ctx, const ef_can_frame_t *f)
{
    ef_sim_pctx_t *p = (ef_sim_pctx_t *)ctx;
    ef_sim_bus_t *b = p->bus;
    if (b->qcount >= b->txcap || b->qcount >= EF_SIM_QUEUE) {
        b->again++;
        return EF_ERR_AGAIN;
    }
    uint32_t at = (b->qhead + b->qcount) % EF_SIM_QUEUE;
    b->q[at] = *f;
    b->qsrc[at] = (uint8_t)p->src;
    b->qcount++;
    if (b->qcount > b->max_queue)
        b->max_queue = b->qcount;
    return EF_OK;
}

/* Empty bus, no participants. */
static inline void ef_sim_init(ef_sim_bus_t *b)
{
    memset(b, 0, sizeof *b);
    b->txcap = EF_SIM_QUEUE;
    for (int i = 0; i <= EF_SIM_MAX_DRIVES; i++) {
        b->pc[i].bus = b;
        b->pc[i].src = i;
    }
}

/* Port of participant src (0 master, 1.. drives). */
static inline ef_can_port_t ef_sim_port(ef_sim_bus_t *b, int src)
{
    ef_can_port_t p;
    p.send = ef_sim_send;
    p.ctx = &b->pc[src];
    return p;
}

/* Initialise the master on the bus; returns ef_comaster_init()'s code. */
static inline int ef_sim_add_master(ef_sim_bus_t *b, ef_comaster_t *m, const ef_com_cfg_t *c)
{
    ef_can_port_t p = ef_sim_port(b, 0);
    b->m = m;
    return ef_comaster_init(m, c, &p);
}

/* Initialise a drive on the bus; returns ef_codrive_init()'s code (or EF_ERR_FULL). */
static inline int ef_sim_add_drive(ef_sim_bus_t *b, ef_codrive_t *d, const ef_codrive_cfg_t *c)
{
    if (b->n_drives >= EF_SIM_MAX_DRIVES)
        return EF_ERR_FULL;
    ef_can_port_t p = ef_sim_port(b, b->n_drives + 1);
    b->d[b->n_drives++] = d;
    return ef_codrive_init(d, c, &p);
}

/* Put the head frame on the bus: statistics, hooks, delivery to all but its sender. */
static inline void ef_sim_deliver_one(ef_sim_bus_t *b)
{
    ef_can_frame_t f = b->q[b->qhead];
    int src = b->qsrc[b->qhead];
    b->qhead = (b->qhead + 1u) % EF_SIM_QUEUE;
    b->qcount--;
    uint32_t bits = ef_can_frame_bits(&f);
    uint64_t n = b->frames++;
    b->bits += bits;
    b->frames_src[src]++;
    b->bits_src[src] += bits;
    b->frames_fn[(f.id >> 7) & 15u]++;
    b->bits_fn[(f.id >> 7) & 15u] += bits;
    if (b->log)
        b->log(b->log_ctx, b->now_us, src, &f);
    if (b->drop && b->drop(b->drop_ctx, &f, src, n)) {
        b->dropped++;
        return;
    }
    if (src != 0 && b->m) {
        int rc = ef_comaster_rx(b->m, &f);
        if (rc < 0 && !b->master_rc)
            b->master_rc = rc;
    }
    for (int i = 0; i < b->n_drives; i++) {
        if (i + 1 == src)
            continue;
        int rc = ef_codrive_rx(b->d[i], &f);
        if (rc < 0 && !b->drive_rc)
            b->drive_rc = rc;
    }
}

/* Deliver what the bus can carry now (bounded: answers provoked here are delivered too). */
static inline void ef_sim_deliver(ef_sim_bus_t *b)
{
    for (uint32_t guard = 0; guard < 16u * EF_SIM_QUEUE && b->qcount > 0; guard++) {
        if (b->bitrate) {
            uint32_t bits = ef_can_frame_bits(&b->q[b->qhead]);
            if (b->budget < bits)
                return;
            b->budget -= bits;
        }
        ef_sim_deliver_one(b);
    }
    if (b->qcount == 0)
        b->budget = 0; /* an idle bus saves no time for later */
}

/* Advance time by dt_us: everybody's process(), then the bus. */
static inline void ef_sim_step(ef_sim_bus_t *b, uint32_t dt_us)
{
    b->now_us += dt_us;
    if (b->bitrate)
        b->budget += (uint64_t)dt_us * b->bitrate / 1000000u;
    if (b->m) {
        int rc = ef_comaster_process(b->m, dt_us, NULL);
        if (rc < 0 && !b->master_rc)
            b->master_rc = rc;
    }
    ef_sim_deliver(b);
    for (int i = 0; i < b->n_drives; i++) {
        int rc = ef_codrive_process(b->d[i], dt_us, NULL);
        if (rc < 0 && !b->drive_rc)
            b->drive_rc = rc;
    }
    ef_sim_deliver(b);
}

/* Run for us microseconds in steps of step_us. */
static inline void ef_sim_run(ef_sim_bus_t *b, uint32_t us, uint32_t step_us)
{
    for (uint32_t t = 0; t < us; t += step_us)
        ef_sim_step(b, step_us);
}

/* Run until the master is in state st (or DONE / ERROR), at most max_us; returns the state. */
static inline int ef_sim_run_until(ef_sim_bus_t *b, int st, uint32_t max_us, uint32_t step_us)
{
    for (uint32_t t = 0; t < max_us; t += step_us) {
        int s = ef_comaster_state(b->m);
        if (s == st || s == EF_COM_DONE || s == EF_COM_ERROR)
            return s;
        ef_sim_step(b, step_us);
    }
    return ef_comaster_state(b->m);
}

#endif /* EF_CANBUS_SIM_H */
