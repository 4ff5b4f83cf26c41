/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_canpump.h
 * @brief The one loop that runs a CAN protocol object (the CANopen master, a drive) on a CAN
 * transport (ef_canif.h): read the transport's clock, hand over what was received, advance
 * the object by the time elapsed, send what the transport holds, pass new bus conditions
 * on, then wait in the transport's receive for at most the time the object asked for.
 *
 * `evenfeed stream --can` (ef_can_stream()), `evenfeed sim-drive can` (ef_can_sim_run())
 * run it on SocketCAN in host time; the bus-load benchmark and `evenfeed demo`
 * (ef_canload_run()) run it, one pump per participant, on the in-memory bus in simulated
 * time (ef_canmem.h), where its wait is zero.
 *
 * Order, and why: frames are handed over before the time is: what arrived up to the clock
 * reading goes to the object before the object sees the time that elapsed up to it, so a
 * SYNC that waited in the socket while the process was held back is no SYNC loss, and an
 * answer that arrived in time is no timeout. The frame a wait returns is therefore held and
 * handed over at the start of the next call, after the clock.
 *
 * Errors: a transport error other than "nothing" and "bus down" (EF_ERR_IO) ends the pump:
 * it is kept (sticky, with the transport's message) and every later call returns it. Bus
 * conditions are passed to the object's `bus` op, once each, not returned.
 */
#ifndef EF_CANPUMP_H
#define EF_CANPUMP_H

#include <stdint.h>

#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/host/can/ef_canif.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The protocol object a pump runs; every op is called from the pump's thread only. */
typedef struct {
    /** Mandatory. One received data frame, with its receive time (the transport's clock).
     *  May send. Its return value is the object's business (errors are kept there). */
    int (*rx)(void *obj, const ef_can_frame_t *f, uint32_t ts_us);
    /** Mandatory. Advance by dt_us; *next_us: call again at the latest after this long
     *  (left as it is: no deadline). May send. */
    int (*process)(void *obj, uint32_t dt_us, uint32_t *next_us);
    /** Optional. Bus conditions (EF_CANIF_BAD bits) the transport has newly seen. */
    void (*bus)(void *obj, uint32_t conditions);
    void *obj;
} ef_canpump_node_t;

/** Pump settings; ef_canpump_cfg_default() gives the documented defaults. */
typedef struct {
    uint32_t rx_burst;        /**< frames handed over per call before the clock is read
                                   again (64): a flood cannot hold time back for long */
    uint32_t pending_wait_us; /**< longest wait while the transport holds frames (flush
                                   retries after a full queue); 0: not limited (0) */
    uint32_t bus_clear;       /**< conditions cleared in the transport once passed on: a
                                   master sets EF_CANIF_BUS_OFF, so the transport keeps
                                   trying to send its controlled stop (a bus that recovers
                                   carries it) instead of refusing every frame (0) */
} ef_canpump_cfg_t;

/** A pump (fields private; read them through the calls below). */
typedef struct {
    ef_canif_t ci;
    ef_canpump_node_t node;
    ef_canpump_cfg_t cfg;
    uint32_t t_prev; /* transport clock at the last reading */
    uint64_t t_us;   /* time elapsed since ef_canpump_init() at that reading */
    ef_can_frame_t held;
    uint32_t held_ts;
    int have;          /* held is a frame received, not yet handed over */
    uint32_t reported; /* conditions passed to node.bus */
    int io_rc;
    ef_msg_t io_msg;
    uint64_t rx_frames, rx_bits; /* data frames received */
} ef_canpump_t;

/** @brief Defaults: burst 64, pending wait not limited, nothing cleared. */
void ef_canpump_cfg_default(ef_canpump_cfg_t *c);

/**
 * @brief Set up a pump on an open transport (copied) for a node (copied); the clock starts
 * now (elapsed 0). c NULL: the defaults.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL pump, transport without ops, node without rx or process
 */
int ef_canpump_init(ef_canpump_t *p, const ef_canif_t *ci, const ef_canpump_node_t *node,
                    const ef_canpump_cfg_t *c);

/**
 * @brief One round: clock, hand over what was received (held frame, then up to rx_burst
 * with recv(0)), process(dt), flush, bus conditions, then wait for a frame for at most
 * min(max_wait_us, the node's next_us) (shortened to pending_wait_us while frames are
 * held), and pass on conditions that wait brought. Blocks only in the transport's recv; with
 * max_wait_us 0, or on the in-memory bus, it never blocks.
 * @retval EF_OK
 * @retval EF_ERR_IO a transport error ended the pump (now or earlier; ef_canpump_msg())
 */
int ef_canpump_poll(ef_canpump_t *p, uint32_t max_wait_us);

/** @brief Time since ef_canpump_init(), on the transport's clock, now (us). */
uint64_t ef_canpump_elapsed_us(const ef_canpump_t *p);

/** @brief The error that ended the pump (EF_OK while it runs). */
int ef_canpump_error(const ef_canpump_t *p);

/** @brief The message of that error ("" while it runs). */
const char *ef_canpump_msg(const ef_canpump_t *p);

/** @brief Data frames (and their ef_can_frame_bits()) received so far. */
uint64_t ef_canpump_rx_frames(const ef_canpump_t *p);
uint64_t ef_canpump_rx_bits(const ef_canpump_t *p);

/** @brief A node that is a CANopen master, nothing else: rx, process, and bus conditions to
 *  ef_comaster_bus_error(). */
ef_canpump_node_t ef_canpump_master_node(ef_comaster_t *m);

/** @brief A node that is a CANopen drive, nothing else (bus conditions ignored: a drive
 *  keeps trying). */
ef_canpump_node_t ef_canpump_drive_node(ef_codrive_t *d);

#ifdef __cplusplus
}
#endif

#endif /* EF_CANPUMP_H */
