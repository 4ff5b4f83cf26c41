/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_canif.h
 * @brief Host CAN transport interface: an ops table and an opaque context, chosen at run
 * time (as libmodbus's backends and Zephyr's CAN driver API), so the one pump loop
 * (ef_canpump.h) and everything above it run unchanged on any transport.
 *
 * Implementations: SocketCAN (ef_sockcan_canif(), ef_sockcan.h), the in-memory bus in
 * simulated time (ef_canmem_canif(), ef_canmem.h) and USB-CAN adapters speaking gs_usb
 * through libusb (ef_gsusb_canif(), ef_gsusb.h), whose transfer completions run inside its
 * own `recv` and only queue frames.
 *
 * Calling context, for every op: task context of one thread, the one that owns the
 * transport (the "bus thread"); never from a signal handler, never from an interrupt or a
 * libusb callback, never concurrently. A transport that has a thread or callbacks of its own
 * (a USB adapter's transfer completion) hands frames to the bus thread through its own
 * queue, drained in `recv`. `send` may be called while the caller handles a frame that
 * `recv` returned (a protocol answers from its rx handler), never from inside `recv`.
 *
 * Errors: EF_ERR_* codes (ef_err.h). Where an op fails, `error` says why in one line
 * naming the interface (host convention: the message is for the user, the code for code).
 *
 * Time: microseconds on a wrapping 32-bit counter (compare with ef_time_reached(), spans
 * < 2^31 us). Every transport has one clock (`now_us`): receive timestamps are on it and
 * the pump measures the time it hands to the protocol with it, so simulated time (the
 * in-memory bus) and host time (SocketCAN, USB) need no other code.
 */
#ifndef EF_CANIF_H
#define EF_CANIF_H

#include <stdint.h>

#include "evenfeed/hal/ef_can.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * Bus conditions (bits of ef_canif_status_t::seen). Sticky: set when the transport learns
 * of the condition and kept until the caller clears them (the `clear` argument of
 * ef_canif_status()), with two exceptions a transport applies itself: a controller restart
 * clears EF_CANIF_BUS_OFF (and sets EF_CANIF_RESTARTED), and a frame the controller accepts
 * or delivers clears EF_CANIF_DOWN. While EF_CANIF_BUS_OFF is set `send` refuses frames
 * with EF_ERR_BUS. The values are those of the older EF_SOCKCAN_* names and go unchanged
 * into ef_comaster_bus_error()'s detail word.
 */
#define EF_CANIF_BUS_OFF       1u
#define EF_CANIF_ERROR_PASSIVE 2u
#define EF_CANIF_ERROR_WARNING 4u
#define EF_CANIF_RESTARTED     8u  /**< the controller restarted after bus-off */
#define EF_CANIF_DOWN          16u /**< the interface is down or the device gone */
/** The transport's device broke its own protocol (a USB adapter sent a malformed frame, or
 *  stalled its receive endpoint): what it delivers cannot be trusted, but it may still
 *  send, so a master stops the drives under control through it rather than go silent.
 *  The transport's `error` says what it met. */
#define EF_CANIF_FAULT 32u
/** The conditions that stop a CANopen master (bus-off, error-passive, down, fault). */
#define EF_CANIF_BAD (EF_CANIF_BUS_OFF | EF_CANIF_ERROR_PASSIVE | EF_CANIF_DOWN | EF_CANIF_FAULT)

/** Controller state, the CAN fault-confinement states plus "down" and "not open". */
typedef enum {
    EF_CANIF_STATE_STOPPED = 0, /**< not open */
    EF_CANIF_STATE_ACTIVE = 1,  /**< error active: transmit and receive normally */
    EF_CANIF_STATE_WARNING = 2, /**< an error counter reached 96: still active */
    EF_CANIF_STATE_PASSIVE = 3, /**< error passive: an error counter reached 128 */
    EF_CANIF_STATE_BUS_OFF = 4, /**< transmit error counter above 255: off the bus */
    EF_CANIF_STATE_DOWN = 5,    /**< interface down or device gone */
} ef_canif_state_t;

/**
 * Receive filter: a frame matches when (can_id & mask) == (id & mask), where can_id is the
 * identifier with ::EF_CANIF_ID_EFF for an extended frame and ::EF_CANIF_ID_RTR for a
 * remote frame (SocketCAN's struct can_filter, which a transport without hardware filters
 * applies in software). A mask of 0x7FF matches base and extended frames alike; add
 * EF_CANIF_ID_EFF to the mask (and leave it out of id) for base frames only.
 */
typedef struct {
    uint32_t id, mask;
} ef_canif_filter_t;

#define EF_CANIF_ID_EFF 0x80000000u /**< filter id bit: extended frame */
#define EF_CANIF_ID_RTR 0x40000000u /**< filter id bit: remote frame */
/** Receive filters at most (any transport). */
#define EF_CANIF_MAX_FILTERS 16

/** What `open` is asked for; a transport ignores what it cannot do, as documented. */
typedef struct {
    const char *name; /**< interface ("vcan0"; for USB an adapter's serial; in memory a
                           name for messages and logs) (required) */
    const ef_canif_filter_t *filters; /**< receive filters (NULL with n_filters 0: all) */
    int n_filters;                    /**< 0..EF_CANIF_MAX_FILTERS */
    const char *log;                  /**< candump log (`candump -L` format) of every frame sent and
                                           received, error frames included (NULL: none) */
    uint32_t bitrate; /**< bits/s to set (0: keep the interface's; SocketCAN always keeps it:
                           `ip link set IFACE type can bitrate N`) */
} ef_canif_cfg_t;

/** Bus state and counters (ef_canif_status()). */
typedef struct {
    ef_canif_state_t state;  /**< now, as far as the transport knows (SocketCAN: the worst
                                  condition in `seen`; it reports the way into a state, not
                                  always the way back) */
    uint32_t seen;           /**< EF_CANIF_* conditions since they were last cleared */
    uint32_t err_frames;     /**< error frames (or error events) received */
    uint32_t tx_pending;     /**< frames `send` took that are not yet with the controller */
    uint32_t tx_unconfirmed; /**< frames with the controller whose transmission is not yet
                                  confirmed (a USB adapter's echo; 0 where the transport
                                  cannot tell) */
    uint32_t tx_full;        /**< sends that met a full controller queue (ENOBUFS) */
    uint32_t rx_overrun;     /**< frames lost because the receive queue was full */
    int16_t tec, rec;        /**< transmit / receive error counters (-1: not known) */
    uint64_t tx, rx;         /**< frames handed to the controller / received */
    uint64_t tx_bits;        /**< ef_can_frame_bits() of the frames handed to the controller */
} ef_canif_status_t;

/** The operations of one transport. */
typedef struct {
    const char *name; /**< "socketcan", "mem", "gs_usb": for messages */
    /** Mandatory. Open the interface with c (filters, log, bitrate as it can) and start
     *  receiving. After a failure the transport is closed (close is still harmless).
     *  @retval EF_OK
     *  @retval EF_ERR_ARG bad name, more than EF_CANIF_MAX_FILTERS filters
     *  @retval EF_ERR_IO  no such interface or device, no driver support, log not writable
     *  (message in m) */
    int (*open)(void *ctx, const ef_canif_cfg_t *c, ef_msg_t *m);
    /** Mandatory. Close (flush and close the log; frames still pending are dropped).
     *  Harmless on a transport that is not open. */
    void (*close)(void *ctx);
    /** Mandatory, never blocks. Queue one frame; a transport may hold it in software when
     *  the controller's queue is full (`flush` sends it later, in order).
     *  @retval EF_OK        queued (or held)
     *  @retval EF_ERR_AGAIN no room: the frame was not taken, the caller keeps it
     *  @retval EF_ERR_BUS   bus-off or interface down (EF_CANIF_BUS_OFF / _DOWN set)
     *  @retval EF_ERR_IO    another device error
     *  @retval EF_ERR_ARG   NULL, not open, dlc > 8 */
    int (*send)(void *ctx, const ef_can_frame_t *f);
    /** Mandatory. Receive one data frame, waiting up to timeout_us (0: poll). Error frames
     *  are consumed here (they update the status and are logged, never returned), and a call
     *  that met only error frames returns at once, so the caller sees the new state
     *  promptly. A transport in simulated time never waits. *ts_us (may be NULL): receive
     *  time on `now_us`'s clock (the controller's timestamp where there is one).
     *  @retval EF_OK        *f holds a data frame
     *  @retval EF_ERR_AGAIN nothing within the timeout (or only error frames)
     *  @retval EF_ERR_BUS   the interface went down
     *  @retval EF_ERR_IO    another device error
     *  @retval EF_ERR_ARG   NULL, not open */
    int (*recv)(void *ctx, ef_can_frame_t *f, uint32_t *ts_us, uint32_t timeout_us);
    /** Optional (NULL: the transport holds nothing). Send held frames, oldest first, as far
     *  as the controller takes them; never blocks. Same codes as send; on EF_ERR_BUS the
     *  frames stay held. */
    int (*flush)(void *ctx);
    /** Mandatory. Fill *st; then clear the conditions in `clear` (0: clear nothing). */
    void (*status)(void *ctx, uint32_t clear, ef_canif_status_t *st);
    /** Optional (NULL: ""). What the last failing op met, one line naming the interface;
     *  valid until the next op. */
    const char *(*error)(void *ctx);
    /** Optional (NULL: the host's monotonic clock, ef_canif_host_now_us()). The transport's
     *  clock, in wrapping microseconds. */
    uint32_t (*now_us)(void *ctx);
} ef_canif_ops_t;

/** A transport: its ops and its context (owned by the caller, e.g. an ef_sockcan_t). */
typedef struct {
    const ef_canif_ops_t *ops;
    void *ctx;
} ef_canif_t;

/**
 * @brief Open a transport (ops->open).
 * @retval EF_OK
 * @retval EF_ERR_ARG no ops or no open/close/send/recv/status op, NULL cfg, or what open
 *                    says
 * @retval EF_ERR_IO  what open says
 */
int ef_canif_open(const ef_canif_t *ci, const ef_canif_cfg_t *c, ef_msg_t *m);

/** @brief Close (NULL or no ops: nothing). */
void ef_canif_close(const ef_canif_t *ci);

/**
 * @brief Send one frame (ops->send).
 * @retval EF_OK
 * @retval EF_ERR_AGAIN no room, frame not taken
 * @retval EF_ERR_BUS   bus-off or interface down
 * @retval EF_ERR_IO    device error
 * @retval EF_ERR_ARG   NULL, not open, dlc > 8
 */
int ef_canif_send(const ef_canif_t *ci, const ef_can_frame_t *f);

/**
 * @brief Receive one data frame within timeout_us (ops->recv); ts_us may be NULL.
 * @retval EF_OK
 * @retval EF_ERR_AGAIN nothing (in time)
 * @retval EF_ERR_BUS   interface down
 * @retval EF_ERR_IO    device error
 * @retval EF_ERR_ARG   NULL, not open
 */
int ef_canif_recv(const ef_canif_t *ci, ef_can_frame_t *f, uint32_t *ts_us, uint32_t timeout_us);

/**
 * @brief Send held frames (ops->flush; EF_OK when the transport has none).
 * @retval EF_OK
 * @retval EF_ERR_BUS interface down (frames stay held)
 * @retval EF_ERR_IO  device error
 * @retval EF_ERR_ARG NULL, not open
 */
int ef_canif_flush(const ef_canif_t *ci);

/** @brief Bus state and counters into *st, then clear the conditions in `clear`. A NULL
 *  transport reads as STOPPED with nothing seen. */
void ef_canif_status(const ef_canif_t *ci, uint32_t clear, ef_canif_status_t *st);

/** @brief The last error's text ("" when the transport keeps none). Never NULL. */
const char *ef_canif_error(const ef_canif_t *ci);

/** @brief The transport's clock (wrapping microseconds). */
uint32_t ef_canif_now_us(const ef_canif_t *ci);

/** @brief A CAN HAL port (ef_can.h) whose send is the transport's: what ef_comaster_init()
 *  and ef_codrive_init() take. */
ef_can_port_t ef_canif_port(const ef_canif_t *ci);

/** @brief CLOCK_MONOTONIC in wrapping microseconds: the clock of host transports. */
uint32_t ef_canif_host_now_us(void);

/** @brief Name of a state ("error-active", "bus-off", ...; "?" if unknown). */
const char *ef_canif_state_str(int state);

/** @brief The state a set of sticky conditions implies (the worst of them). */
ef_canif_state_t ef_canif_state_of(uint32_t seen);

#ifdef __cplusplus
}
#endif

#endif /* EF_CANIF_H */
