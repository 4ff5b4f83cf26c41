/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_canmem.h
 * @brief An in-memory CAN bus in simulated time whose ports are CAN transports
 * (ef_canif.h): the master and the drives of the bus-load benchmark and of `evenfeed demo`
 * run on it through the same pump loop (ef_canpump.h) as `evenfeed stream --can` and
 * `evenfeed sim-drive can` run on SocketCAN.
 *
 * Every frame a port sends waits in one bus queue, in send order, and is later delivered
 * into the receive queue of every other open port whose filters match (never back to its
 * sender), as a controller's RX FIFO: a port's owner reads it with recv. With a bitrate
 * the bus carries only the bits its time allows (ef_can_frame_bits(), worst-case
 * stuffing), so a saturated bus shows as latency, and as EF_ERR_AGAIN from send once
 * `txcap` frames wait. Bitrate 0: an infinitely fast bus.
 *
 * Time passes only through ef_canmem_advance(); nothing waits (recv's timeout is not
 * waited out: there is no one else to send while the caller waits). A simulation step is
 * therefore: advance the clock, let each participant's pump run once (its recv returns
 * what was delivered), deliver; ef_canmem_deliver() may be called between participants
 * (a frame sent by the first is then received by the next in the same step).
 *
 * Single-threaded: the bus and all its ports belong to one thread.
 */
#ifndef EF_CANMEM_H
#define EF_CANMEM_H

#include <stdint.h>
#include <stdio.h>

#include "evenfeed/host/can/ef_canif.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Ports (participants) on one bus. */
#define EF_CANMEM_MAX_PORTS 8
/** Frames waiting on the bus at most. */
#define EF_CANMEM_QUEUE 4096
/** Frames a port's receive queue holds (more are lost: rx_overrun). */
#define EF_CANMEM_RXQ 512

typedef struct ef_canmem ef_canmem_t;

/** One port: a transport's context (private; read the counters with ef_canif_status()). */
typedef struct {
    ef_canmem_t *bus;
    int index;
    int open;
    char name[32];
    ef_canif_filter_t flt[EF_CANIF_MAX_FILTERS];
    int n_flt;
    FILE *log;
    ef_can_frame_t rxq[EF_CANMEM_RXQ];
    uint32_t rxts[EF_CANMEM_RXQ];
    uint32_t rx_head, rx_count;
    uint32_t seen, err_frames, rx_overrun, tx_full;
    uint64_t tx, rx, tx_bits;
    ef_msg_t msg;
} ef_canmem_port_t;

struct ef_canmem {
    ef_canmem_port_t port[EF_CANMEM_MAX_PORTS];
    ef_can_frame_t q[EF_CANMEM_QUEUE];
    uint8_t qsrc[EF_CANMEM_QUEUE];
    uint32_t qhead, qcount;
    uint32_t txcap;   /**< frames waiting before send answers EF_ERR_AGAIN (default all) */
    uint32_t bitrate; /**< bits per second; 0: infinitely fast */
    uint64_t budget;  /**< bits the bus may still carry now */
    uint64_t now_us;  /**< simulated time */
    /** Optional: nonzero loses frame number n (0-based, on the wire): it still occupies
     *  the bus, nobody receives it. */
    int (*drop)(void *ctx, const ef_can_frame_t *f, int src, uint64_t n);
    void *drop_ctx;
    /* Statistics, counted as frames go on the wire. */
    uint64_t frames, bits, dropped, again;
    uint64_t frames_src[EF_CANMEM_MAX_PORTS], bits_src[EF_CANMEM_MAX_PORTS];
    uint64_t frames_fn[16], bits_fn[16]; /**< by function code (identifier >> 7) */
    uint32_t max_queue;                  /**< most frames ever waiting */
};

/** @brief An empty bus at `bitrate` bits/s (0: infinitely fast), time 0, no port open. */
void ef_canmem_init(ef_canmem_t *b, uint32_t bitrate);

/**
 * @brief Port k (0..EF_CANMEM_MAX_PORTS-1) as a transport. Its open takes the name (for
 * messages and the log), filters and log of the configuration (bitrate ignored: the bus
 * has one); its clock is the bus's simulated time. Out of range: a transport whose every
 * op fails with EF_ERR_ARG.
 */
ef_canif_t ef_canmem_canif(ef_canmem_t *b, int k);

/** @brief Let dt_us of simulated time pass: the bus may carry that many more bits. */
void ef_canmem_advance(ef_canmem_t *b, uint32_t dt_us);

/** @brief Put on the wire what the bus can carry now, into the receivers' queues; an idle
 *  bus saves no time for later. */
void ef_canmem_deliver(ef_canmem_t *b);

/** @brief Raise bus conditions (EF_CANIF_*) on port k, as its controller would: fault
 *  injection for tests. EF_CANIF_BUS_OFF makes its send refuse, as on SocketCAN. */
void ef_canmem_raise(ef_canmem_t *b, int k, uint32_t conditions);

#ifdef __cplusplus
}
#endif

#endif /* EF_CANMEM_H */
