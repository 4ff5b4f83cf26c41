/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_sockcan.h
 * @brief SocketCAN transport (Linux raw CAN socket): the host implementation of the CAN
 * HAL (ef_can.h), with receive filters, error frames, bus-off / error-passive detection,
 * TX-queue-full (ENOBUFS) back-off, and a traffic log in candump's log-file format.
 *
 * Errors: EF_ERR_* codes plus a message in ef_msg_t (host convention).
 */
#ifndef EF_SOCKCAN_H
#define EF_SOCKCAN_H

#include <stdint.h>
#include <stdio.h>

#include "evenfeed/hal/ef_can.h"
#include "evenfeed/host/can/ef_canif.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Receive filters at most. */
#define EF_SOCKCAN_MAX_FILTERS EF_CANIF_MAX_FILTERS
/** Frames held in user space while the kernel's TX queue is full. */
#define EF_SOCKCAN_BACKLOG 256

/**
 * Bus conditions seen in error frames (ef_sockcan_t::bus). They stay set until the caller
 * clears them (s->bus = 0), with two exceptions: a "controller restarted" error frame clears
 * BUS_OFF (and sets RESTARTED), and a frame the kernel accepts or delivers clears DOWN.
 * While BUS_OFF is set ef_sockcan_send() refuses frames (EF_ERR_BUS).
 */
#define EF_SOCKCAN_BUS_OFF       EF_CANIF_BUS_OFF
#define EF_SOCKCAN_ERROR_PASSIVE EF_CANIF_ERROR_PASSIVE
#define EF_SOCKCAN_ERROR_WARNING EF_CANIF_ERROR_WARNING
#define EF_SOCKCAN_RESTARTED     EF_CANIF_RESTARTED /**< controller restarted after bus-off */
#define EF_SOCKCAN_DOWN          EF_CANIF_DOWN      /**< the interface is down (ENETDOWN) or gone */

/**
 * Receive filter, exactly a struct can_filter: a frame matches when
 * (can_id & mask) == (id & mask), where can_id carries SocketCAN's flag bits (CAN_EFF_FLAG
 * 0x80000000, CAN_RTR_FLAG 0x40000000). A mask of 0x7FF thus matches base and extended
 * frames alike; add CAN_EFF_FLAG to the mask (and leave it out of id) for base frames only.
 * The transport interface's filter (ef_canif.h) is the same thing under another name.
 */
typedef ef_canif_filter_t ef_sockcan_filter_t;

/** An open socket. */
typedef struct {
    int fd;
    char ifname[32];
    FILE *log;           /**< candump log (NULL: none) */
    uint32_t bus;        /**< EF_SOCKCAN_* conditions seen since the last clear */
    uint32_t err_frames; /**< error frames received */
    uint32_t enobufs;    /**< sends that met a full TX queue */
    uint64_t tx, rx;     /**< frames sent / received */
    uint32_t rx_overrun; /**< frames the kernel dropped because this socket's receive queue
                              was full (SO_RXQ_OVFL): a reader held back too long */
    uint64_t tx_bits;    /**< ef_can_frame_bits() of the frames sent */
    ef_can_frame_t backlog[EF_SOCKCAN_BACKLOG];
    uint32_t bl_head, bl_count;
    uint64_t backoff_until_ns; /**< after ENOBUFS: no send before this (CLOCK_MONOTONIC) */
    uint32_t backoff_us;       /**< the current back-off step (100 us .. 10 ms; private) */
    ef_msg_t msg;              /**< what the last failing send / flush / recv met, and where */
} ef_sockcan_t;

/**
 * @brief Open a raw CAN socket on `ifname`, with `n` receive filters (0: receive all) and
 * error frames enabled (bus-off, controller state, restarted). Own frames are not received.
 * @param log_path candump log file to write (NULL: no log)
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL, empty or too long name, n > EF_SOCKCAN_MAX_FILTERS
 * @retval EF_ERR_IO   no CAN support in the kernel, no such interface, log not writable
 */
int ef_sockcan_open(ef_sockcan_t *s, const char *ifname, const ef_sockcan_filter_t *filters, int n,
                    const char *log_path, ef_msg_t *m);

/** @brief Close (flushes the log). NULL or closed is harmless. */
void ef_sockcan_close(ef_sockcan_t *s);

/**
 * @brief Send a frame (logged). When the kernel's queue is full (ENOBUFS) the frame is held
 * in the backlog and sent by later calls after a back-off (doubling from 100 us to 10 ms).
 * @retval EF_OK        sent or held
 * @retval EF_ERR_AGAIN backlog full too: the frame was not taken (caller keeps it)
 * @retval EF_ERR_BUS   interface down / bus-off (EF_SOCKCAN_DOWN or EF_SOCKCAN_BUS_OFF set)
 * @retval EF_ERR_IO    other socket error
 * @retval EF_ERR_ARG   NULL, socket not open, dlc > 8
 * Frames are logged when the kernel takes them; s->msg says what a failure met.
 */
int ef_sockcan_send(ef_sockcan_t *s, const ef_can_frame_t *f);

/**
 * @brief Send what the backlog holds, oldest first, as far as the kernel takes it (nothing
 * while a back-off runs). Same codes as send; on EF_ERR_BUS the frames stay held.
 */
int ef_sockcan_flush(ef_sockcan_t *s);

/**
 * @brief Receive one frame, waiting up to timeout_us (0: poll).
 * Error frames are consumed here: they update s->bus (and are logged) and are not returned;
 * when the socket holds only error frames the call returns EF_ERR_AGAIN at once, without
 * waiting out the timeout, so the caller sees the new s->bus promptly.
 * @retval EF_OK        *f holds a data frame
 * @retval EF_ERR_AGAIN nothing within the timeout (or only error frames)
 * @retval EF_ERR_BUS   the interface went down
 * @retval EF_ERR_IO    other socket error
 * @retval EF_ERR_ARG   NULL, socket not open
 */
int ef_sockcan_recv(ef_sockcan_t *s, ef_can_frame_t *f, uint32_t timeout_us);

/** @brief A HAL port whose send is ef_sockcan_send() (EF_ERR_AGAIN / EF_ERR_BUS passed on). */
ef_can_port_t ef_sockcan_port(ef_sockcan_t *s);

/**
 * @brief Write one frame to a candump log, as `candump -L` does: "(sec.usec) IFACE ID#DATA",
 * time from CLOCK_REALTIME, id as 3 hex digits (8 for extended frames), data bytes as
 * upper-case hex, "R" instead of data for RTR (followed by the dlc when it is not 0).
 * NULL log or frame: nothing written.
 */
void ef_sockcan_log_frame(FILE *log, const char *ifname, const ef_can_frame_t *f);

/** @brief One candump log line (`candump -L` format, the host's real-time clock) of a raw
 *  SocketCAN identifier with its flags (CAN_EFF_FLAG, CAN_RTR_FLAG, CAN_ERR_FLAG: error
 *  frames too) and dlc bytes of data (at most 8 written). NULL log or data: nothing. */
void ef_sockcan_log_raw(FILE *log, const char *ifname, uint32_t can_id, uint8_t dlc,
                        const uint8_t *data);

/** @brief Monotonic microseconds (CLOCK_MONOTONIC, wraps at 2^32). */
uint32_t ef_sockcan_now_us(void);

/**
 * @brief The socket as a CAN transport (ef_canif.h): open is ef_sockcan_open() with the
 * configuration's name, filters and log (bitrate ignored: `ip link` sets it), send, recv
 * (timestamp: the time of reading), flush, status (the conditions in s->bus, the state
 * the worst of them; error counters not known), error (s->msg), the host's clock. The
 * socket s stays the caller's; it must outlive the transport.
 */
ef_canif_t ef_sockcan_canif(ef_sockcan_t *s);

/**
 * @brief Write an error frame CAN_ERR_FLAG | err_class (e.g. CAN_ERR_BUSOFF) on the bus,
 * as a controller driver reports one: fault injection on vcan, which has no physical
 * layer to fail. Not logged, not counted.
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL, socket not open
 * @retval EF_ERR_IO  the kernel refused it (s->msg says why)
 */
int ef_sockcan_inject_error(ef_sockcan_t *s, uint32_t err_class);

#ifdef __cplusplus
}
#endif

#endif /* EF_SOCKCAN_H */
