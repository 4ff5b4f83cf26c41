/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_gsusb_sim.h
 * @brief A simulated gs_usb USB-CAN adapter (what candleLight firmware on an STM32F072
 * does) on a real USB bus: a FunctionFS gadget bridging to a SocketCAN interface.
 *
 * The adapter sets itself up through configfs (`<configfs>/usb_gadget/<name>/`: ids,
 * strings, configuration c.1, function ffs.<name>), mounts FunctionFS, writes its
 * descriptors (one vendor-specific interface 0 with a bulk IN and a bulk OUT endpoint,
 * full and high speed) and binds the gadget to a UDC. With dummy_hcd the host then sees
 * it on its own USB bus (endpoints 0x81 and 0x02, as candleLight has), and both the
 * kernel's gs_usb driver and a libusb driver (ef_gsusb.h) can drive it. Linux only; needs
 * root, configfs, FunctionFS and a UDC.
 *
 * ## What it does
 * - ep0: HOST_FORMAT, DEVICE_CONFIG, BT_CONST, BITTIMING, MODE, BERR, TIMESTAMP, IDENTIFY,
 *   GET_STATE (ef_gsusb_wire.h). Unknown requests, wrong direction or request type, a bad
 *   wLength (OUT: not the payload's size; IN: smaller than the reply) and a channel
 *   (wValue) the device does not have are stalled.
 * - Content-based refusals cannot be stalls: FunctionFS completes an OUT request's status
 *   stage together with its data stage, so a gadget sees the payload only after the host
 *   has been told "accepted". A BITTIMING outside BT_CONST's ranges (or above the
 *   `bitrate-max` fault) is therefore dropped (the channel keeps its previous timing),
 *   reported on stderr, and the channel's next MODE request is stalled: the host sees
 *   the start fail with a stall (EPIPE), as `ip link set canX up` does. The next
 *   accepted BITTIMING clears it. A MODE with flags the device lacks (or a mode word
 *   other than reset/start) leaves the channel stopped (GET_STATE: STOPPED) and is
 *   reported on stderr. A HOST_FORMAT other than 0x0000beef is reported and ignored.
 * - Data: a frame the host writes to ep2 (20 bytes, or 24 with a timestamp, which is
 *   ignored) on a started channel that is not listen-only is put on the CAN interface,
 *   paced at the channel's bitrate (EF_GSUSB_SIM_* ::ef_gsusb_sim_cfg_t::pace), and then
 *   echoed on ep1 with its echo_id (with the timestamp of the end of its transmission
 *   when the channel runs with HW_TIMESTAMP). Loop-back: not put on the interface, echoed
 *   and delivered as a received frame. A frame of a bad length, dlc or channel, or an
 *   error frame, or one for a stopped or listen-only channel is counted, reported on
 *   stderr and dropped. Frames received from the interface while the channel is started
 *   go to ep1 with echo_id EF_GSUSB_ECHO_RX; when the adapter's RX queue
 *   (::ef_gsusb_sim_cfg_t::rx_queue frames, shared with the echoes) is full a received
 *   frame is dropped and the channel's next one carries EF_GSUSB_FLAG_OVERFLOW (an echo
 *   is never dropped: it waits for room, which holds the host's writes back).
 * - Channel k bridges to the k-th interface of ::ef_gsusb_sim_cfg_t::iface, or to the
 *   only one given: channels on one interface act as controllers on one bus (each
 *   receives what the others send).
 * - The timestamp is a 32-bit microsecond counter starting at ts_start.
 *
 * ## Threads and signals
 * One thread reads ep0 events, one reads ep2, one writes ep1, one per channel reads the
 * CAN socket. They block every signal but SIGUSR1, which ef_gsusb_sim_stop() sends to
 * interrupt a blocked read or write (a handler that does nothing is installed for it).
 */
#ifndef EF_GSUSB_SIM_H
#define EF_GSUSB_SIM_H

#include <signal.h>
#include <stdint.h>

#include "evenfeed/host/can/ef_gsusb_wire.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * Fault injection (`--fault KIND`; several may be combined), each for the host driver's
 * bad-input tests. What the host observes:
 * - EF_GSUSB_SIM_F_SHORT_REPLY: BT_CONST is answered with 20 of its 40 bytes (a short
 *   control transfer: libusb returns 20, the kernel's probe fails with -EREMOTEIO).
 * - EF_GSUSB_SIM_F_LONG_REPLY: DEVICE_CONFIG is answered with the full wLength the host
 *   asked for, the 12 bytes followed by junk (0xA5). A control IN transfer never carries
 *   more than wLength (FunctionFS and every UDC cut it there), so only a host that asks
 *   for more than 12 bytes can see an oversized reply; one that asks for exactly 12 gets
 *   the normal reply.
 * - EF_GSUSB_SIM_F_BAD_FRAME: every 50th frame sent on ep1 is 19 bytes (cut short).
 * - EF_GSUSB_SIM_F_BAD_CHANNEL: frames received from the bus carry channel 5.
 * - EF_GSUSB_SIM_F_STALL_IN: ep1 is halted once, after stall_in_after frames: the host's
 *   IN transfers fail with a stall (EPIPE) until it clears the halt; frames queued
 *   meanwhile are sent after that.
 * - EF_GSUSB_SIM_F_NO_ECHO: sent frames are never echoed: the host's TX window fills.
 * - EF_GSUSB_SIM_F_NO_ANSWER: from the first vendor request on, ep0 is never serviced
 *   again: every control request times out on the host (the kernel's probe fails).
 * - EF_GSUSB_SIM_F_BITRATE_MAX: a BITTIMING above bitrate_max bit/s is refused (as a
 *   timing out of range: the next MODE is stalled).
 * - EF_GSUSB_SIM_F_BUS_OFF: after ::EF_GSUSB_SIM_FAULT_AFTER frames received from the bus,
 *   the channel reports bus-off once: an error frame (EF_GSUSB_ID_ERR | CAN_ERR_BUSOFF,
 *   8 bytes), as candleLight does when its controller leaves the bus; GET_STATE says
 *   bus-off from then on.
 * - EF_GSUSB_SIM_F_OVERFLOW: every ::EF_GSUSB_SIM_FAULT_AFTER-th frame received from the
 *   bus carries EF_GSUSB_FLAG_OVERFLOW, as after frames the adapter had to drop.
 */
enum {
    EF_GSUSB_SIM_F_SHORT_REPLY = 1u << 0,
    EF_GSUSB_SIM_F_LONG_REPLY = 1u << 1,
    EF_GSUSB_SIM_F_BAD_FRAME = 1u << 2,
    EF_GSUSB_SIM_F_BAD_CHANNEL = 1u << 3,
    EF_GSUSB_SIM_F_STALL_IN = 1u << 4,
    EF_GSUSB_SIM_F_NO_ECHO = 1u << 5,
    EF_GSUSB_SIM_F_NO_ANSWER = 1u << 6,
    EF_GSUSB_SIM_F_BITRATE_MAX = 1u << 7,
    EF_GSUSB_SIM_F_BUS_OFF = 1u << 8,
    EF_GSUSB_SIM_F_OVERFLOW = 1u << 9,
};

/** Received frames before the bus-off fault, and the overflow fault's period. */
#define EF_GSUSB_SIM_FAULT_AFTER 300u

/** Interfaces the adapter may bridge to (one per channel at most). */
#define EF_GSUSB_SIM_MAX_IFACES EF_GSUSB_MAX_CHANNELS

/** The simulated adapter's configuration (ef_gsusb_sim_cfg_default() fills it). */
typedef struct {
    const char *iface[EF_GSUSB_SIM_MAX_IFACES]; /**< CAN interfaces (iface[0] required) */
    unsigned n_iface;                           /**< entries of iface in use (1..channels) */
    const char *name;            /**< gadget and FunctionFS instance name ("ef_gsusb") */
    const char *serial;          /**< USB serial number string ("EF0000000001") */
    const char *udc;             /**< UDC to bind to; NULL: the first of /sys/class/udc */
    const char *configfs;        /**< configfs mount point ("/sys/kernel/config") */
    const char *ffs_dir;         /**< where FunctionFS is mounted; NULL: /dev/ffs-<name> */
    uint16_t vid, pid;           /**< USB ids (0x1d50, 0x606f: candleLight) */
    uint16_t bcd_device;         /**< device release (0x0100) */
    uint8_t channels;            /**< 1..EF_GSUSB_MAX_CHANNELS (1) */
    uint32_t fclk;               /**< CAN clock, Hz (48 000 000) */
    uint32_t ts_start;           /**< timestamp counter's value at start (µs, 0) */
    int pace;                    /**< hold each frame for its bus time at the bitrate (1) */
    unsigned rx_queue;           /**< frames the adapter buffers toward the host, 2..1024 (64) */
    unsigned faults;             /**< EF_GSUSB_SIM_F_* */
    uint32_t stall_in_after;     /**< EF_GSUSB_SIM_F_STALL_IN: frames before the halt (10) */
    uint32_t bitrate_max;        /**< EF_GSUSB_SIM_F_BITRATE_MAX: bit/s */
    int verbose;                 /**< log every request and refusal on stderr */
    volatile sig_atomic_t *stop; /**< ef_gsusb_sim_run() returns once *stop is set */
} ef_gsusb_sim_cfg_t;

/** Counters (ef_gsusb_sim_stats()). */
typedef struct {
    uint64_t requests;    /**< control requests seen */
    uint64_t stalls;      /**< of them stalled */
    uint64_t tx;          /**< host frames put on the bus (or looped back) */
    uint64_t echo;        /**< echoes sent to the host */
    uint64_t rx;          /**< received frames sent to the host */
    uint64_t rx_overflow; /**< received frames dropped: RX queue full */
    uint64_t bad_out;     /**< host frames dropped: bad length, dlc, channel, error frame */
    uint64_t dropped;     /**< host frames dropped: channel stopped or listen-only */
    uint64_t tx_err;      /**< host frames the CAN interface refused */
} ef_gsusb_sim_stats_t;

/** A running simulated adapter (opaque). */
typedef struct ef_gsusb_sim_s ef_gsusb_sim_t;

/** @brief Defaults: candleLight's ids and constants (fclk 48 MHz, tseg1 1..16, tseg2 1..8,
 *  sjw_max 4, brp 1..1024), one channel, pacing on, no faults, no interface. */
void ef_gsusb_sim_cfg_default(ef_gsusb_sim_cfg_t *c);

/**
 * @brief Add a fault named as on the command line: short-reply, long-reply, bad-frame,
 * bad-channel, stall-in[=N], no-echo, no-answer, bitrate-max=N.
 * @retval EF_OK
 * @retval EF_ERR_ARG unknown kind, or a value missing or out of range (N of stall-in
 *                    0..1e9, of bitrate-max 1..1 000 000); NULL
 */
int ef_gsusb_sim_fault(ef_gsusb_sim_cfg_t *c, const char *kind, ef_msg_t *m);

/** @brief BT_CONST the adapter reports for configuration c (candleLight's features). */
void ef_gsusb_sim_btconst(const ef_gsusb_sim_cfg_t *c, ef_gsusb_btconst_t *bc);

/**
 * @brief Set up the gadget (removing a stale one of the same name first), start its
 * threads and bind it to the UDC. Returns once bound; the host enumerates it afterwards
 * (ef_gsusb_sim_wait_ready()).
 * @retval EF_OK      *out runs; ef_gsusb_sim_stop() ends it
 * @retval EF_ERR_ARG NULL, no interface, channels or rx_queue out of range, more
 *                    interfaces than channels, a name with '/' or longer than 32
 * @retval EF_ERR_IO  a CAN interface cannot be opened; configfs, FunctionFS or a UDC is
 *                    missing or busy; a descriptor write fails (message names the path
 *                    and errno); everything made so far is removed again
 * @retval EF_ERR_NOMEM out of memory
 */
int ef_gsusb_sim_start(const ef_gsusb_sim_cfg_t *c, ef_gsusb_sim_t **out, ef_msg_t *m);

/**
 * @brief Wait until the host has configured the adapter (FunctionFS ENABLE).
 * @param timeout_ms bound; negative: until *stop (if the configuration has one) is set
 * @retval EF_OK        enabled
 * @retval EF_ERR_AGAIN not within timeout_ms, or *stop was set
 * @retval EF_ERR_ARG   NULL
 */
int ef_gsusb_sim_wait_ready(ef_gsusb_sim_t *s, long timeout_ms);

/** @brief The UDC the adapter is bound to (valid until ef_gsusb_sim_stop()). */
const char *ef_gsusb_sim_udc(const ef_gsusb_sim_t *s);

/** @brief Copy the counters (thread-safe). */
void ef_gsusb_sim_stats(ef_gsusb_sim_t *s, ef_gsusb_sim_stats_t *st);

/** @brief Unbind, stop the threads, unmount and remove the gadget from configfs in reverse
 *  order of its making, close the sockets and free s (NULL: nothing). */
void ef_gsusb_sim_stop(ef_gsusb_sim_t *s);

/**
 * @brief What `evenfeed sim-adapter gsusb` runs: start, print "ready gs_usb serial=S
 * udc=U" on stdout once the host has configured the adapter, run until *c->stop, stop,
 * and print the counters on stderr when verbose.
 * @retval EF_OK      stopped by *c->stop
 * @retval EF_ERR_ARG c->stop NULL, or as ef_gsusb_sim_start()
 * @retval EF_ERR_IO  as ef_gsusb_sim_start()
 * @retval EF_ERR_NOMEM out of memory
 */
int ef_gsusb_sim_run(const ef_gsusb_sim_cfg_t *c, ef_msg_t *m);

#ifdef __cplusplus
}
#endif

#endif /* EF_GSUSB_SIM_H */
