/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_gsusb.h
 * @brief USB-CAN adapters speaking gs_usb (candleLight, CANable, ...) driven from user space
 * with libusb-1.0: a CAN transport (ef_canif.h) beside SocketCAN, for machines where the
 * kernel's gs_usb driver is missing or may not be used, plus the adapter listing behind
 * `evenfeed can list`. The protocol itself (requests, frames, bit timing) is
 * ef_gsusb_wire.h; this file is the I/O around it.
 *
 * ## How it runs
 * - open (ef_gsusb_canif()'s `open`): finds the adapter (by serial number, bus path or as
 *   the only one), detaches the kernel driver while in use, claims interface 0, reads the
 *   bulk endpoints from the interface descriptor, then HOST_FORMAT, DEVICE_CONFIG,
 *   BT_CONST, BITTIMING (ef_gsusb_bittiming_calc()), TIMESTAMP, BERR (where offered), MODE
 *   start. Every control transfer is bounded by ::EF_GSUSB_CTRL_TIMEOUT_MS.
 * - receive: ::EF_GSUSB_RX_XFERS bulk IN transfers stay in flight. libusb runs their
 *   completions inside `recv` (libusb_handle_events_timeout_completed() in the bus thread),
 *   where they only decode and enqueue into a ring of ::EF_GSUSB_RX_RING frames: no thread
 *   of its own, no locks.
 * - transmit: each frame is one bulk OUT transfer with an echo_id slot; at most
 *   ::EF_GSUSB_TX_WINDOW frames are unconfirmed (the Linux driver's figure), then frames are
 *   held in a backlog of ::EF_GSUSB_BACKLOG (sent in order by `flush` and as echoes free
 *   slots), then `send` says EF_ERR_AGAIN. A frame is counted, logged and timed when its
 *   echo comes back: it is then on the bus.
 * - time: receive timestamps are on ef_canif_host_now_us()'s clock. With hardware
 *   timestamps the device's 32-bit microsecond clock is mapped onto it by an offset taken
 *   at open and refreshed every ::EF_GSUSB_POLL_MS (modular arithmetic: the device clock's
 *   wrap after 71.6 min changes nothing).
 * - the adapter unplugged: EF_CANIF_DOWN set, `send`/`recv` return EF_ERR_BUS and `error`
 *   says "gs_usb SERIAL: adapter unplugged".
 *
 * Calling context: that of ef_canif.h (one bus thread). ef_gsusb_list() opens and closes
 * its own libusb context and may run in any thread that does not use the same adapters.
 */
#ifndef EF_GSUSB_H
#define EF_GSUSB_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "evenfeed/host/can/ef_canif.h"
#include "evenfeed/host/can/ef_gsusb_wire.h"
#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Bulk IN transfers kept in flight: enough that the adapter never waits for the host to
 *  resubmit (one frame per transfer; a USB full-speed frame carries about 19 of them). */
#define EF_GSUSB_RX_XFERS 8
/** Frames sent and not yet echoed at most (the Linux driver's GS_MAX_TX_URBS). */
#define EF_GSUSB_TX_WINDOW 10
/** Received frames waiting for `recv` at most; more are dropped and counted (rx_overrun). */
#define EF_GSUSB_RX_RING 1024
/** Frames held while the window is full, at most. */
#define EF_GSUSB_BACKLOG 256
/** Bound on every control transfer (ms). */
#define EF_GSUSB_CTRL_TIMEOUT_MS 500
/** Bound on a bulk OUT transfer (ms): a device that takes no frame for this long fails. */
#define EF_GSUSB_OUT_TIMEOUT_MS 1000
/** A frame not echoed within this (ms) ends the transport (EF_ERR_IO): the bus carries
 *  nothing of ours any more (no ACK from any node, or the adapter hung). */
#define EF_GSUSB_ECHO_TIMEOUT_MS 2000
/** Period of GET_STATE polls and of the device clock's resynchronisation (ms). */
#define EF_GSUSB_POLL_MS 1000
/** Bins of a latency histogram: bin k counts [2^k, 2^(k+1)) us (bin 0 also 0), the last
 *  one everything above. */
#define EF_GSUSB_LAT_BINS 20
/** Adapters ef_gsusb_list() reports at most. */
#define EF_GSUSB_LIST_MAX 32

/** Options of the channel, set before open (ef_gsusb_set_opts()); each refused at open
 *  when BT_CONST's feature bits do not offer it. */
typedef struct {
    uint8_t loop_back;    /**< the controller receives what it sends, nothing goes out */
    uint8_t listen_only;  /**< receive only: no ACK, no error frames, send refused */
    uint8_t one_shot;     /**< no automatic retransmission */
    int8_t hw_timestamps; /**< -1: on where offered (default); 0: off; 1: required */
    uint8_t channel;      /**< channel of a multi-channel adapter (0) */
    /** Bound on a bulk OUT transfer (ms); a frame's echo is waited for twice this. 0: the
     *  defaults, ::EF_GSUSB_OUT_TIMEOUT_MS and ::EF_GSUSB_ECHO_TIMEOUT_MS. Raised where the
     *  adapter or the host cannot keep real-time pace: an emulated bus on a loaded host
     *  (tests/can/test_can_hil.c), a hub shared with busy devices. At most 60000. */
    uint32_t timeout_ms;
} ef_gsusb_opts_t;

/** One latency distribution (us). */
typedef struct {
    uint64_t n, sum_us;
    uint32_t min_us, max_us;
    uint32_t hist[EF_GSUSB_LAT_BINS];
} ef_gsusb_lat_t;

/** Transport figures (ef_gsusb_stats()). */
typedef struct {
    ef_gsusb_lat_t echo;     /**< bulk OUT submitted to its echo received, host clock */
    ef_gsusb_lat_t echo_dev; /**< bulk OUT submitted to the echo's device timestamp mapped to
                                  the host clock (hardware timestamps only): the time to the
                                  bus, without the way back */
    uint64_t in_xfers;       /**< bulk IN transfers completed */
    uint64_t out_xfers;      /**< bulk OUT transfers completed */
    uint32_t bad_frames;     /**< IN transfers that did not decode (ef_gsusb_frame_decode()) */
    uint32_t unknown_echo;   /**< echoes of no frame in flight (protocol errors) */
    uint32_t other_channel;  /**< frames of a channel not opened (ignored) */
    uint32_t overflow;       /**< frames with EF_GSUSB_FLAG_OVERFLOW (device lost frames) */
    uint32_t ring_full;      /**< frames dropped because the receive ring was full */
    uint32_t xfer_errors;    /**< transfers that failed (stall, error), resubmitted */
    uint32_t state_polls;    /**< GET_STATE answers */
    uint32_t max_in_flight;  /**< most frames unconfirmed at once */
    uint32_t held;           /**< frames that waited in the backlog */
} ef_gsusb_stats_t;

/** One adapter as found (ef_gsusb_list()). */
typedef struct {
    uint16_t vid, pid;
    char path[32];        /**< bus path "B-P.P" (what open takes as a name) */
    char serial[64];      /**< "" when it could not be read */
    char product[64];     /**< "" when it could not be read */
    uint8_t driver_bound; /**< a kernel driver (gs_usb) has interface 0 */
    uint8_t claimed;      /**< another program has claimed interface 0 */
    uint8_t queried;      /**< the fields below were read from the adapter */
    uint8_t channels;
    uint32_t sw_version, hw_version;
    uint32_t fclk, feature; /**< channel 0's BT_CONST */
    char note[160];         /**< why it was not queried ("" when it was) */
} ef_gsusb_info_t;

struct libusb_context;
struct libusb_device_handle;
struct libusb_transfer;

/** A received frame and its time (private to the transport). */
typedef struct {
    ef_can_frame_t f;
    uint32_t ts;
} ef_gsusb_rxe_t;

/** One transmit slot (private). */
typedef struct {
    struct libusb_transfer *xfer;
    uint8_t buf[EF_GSUSB_FRAME_TS_LEN];
    uint8_t out_busy;  /**< the OUT transfer is in flight */
    uint8_t wait_echo; /**< the frame is not echoed yet */
    uint32_t t_submit; /**< host clock at submission */
    ef_can_frame_t f;
} ef_gsusb_txs_t;

/** One asynchronous control request (private: GET_STATE and TIMESTAMP polls). */
typedef struct {
    struct libusb_transfer *xfer;
    uint8_t buf[8 + EF_GSUSB_STATE_LEN]; /**< setup packet + reply */
    uint8_t busy;
    uint32_t t_submit;
} ef_gsusb_ctl_t;

/** The transport's context: one adapter channel. Set up with ef_gsusb_init(); large
 *  (the rings), so static or on the heap rather than on a small stack. */
typedef struct {
    ef_gsusb_opts_t opts;
    struct libusb_context *usb;
    struct libusb_device_handle *h;
    uint8_t is_open, claimed, reattach, gone;
    uint8_t ep_in, ep_out;
    uint16_t mps_in;
    char serial[64], path[32];
    char label[96]; /**< "gs_usb SERIAL": how messages name the adapter */
    char log_if[16];
    FILE *log;
    ef_canif_filter_t filters[EF_CANIF_MAX_FILTERS];
    int n_filters;
    ef_gsusb_devcfg_t devcfg;
    ef_gsusb_btconst_t btc;
    ef_gsusb_bittiming_t timing;
    uint32_t bitrate;     /**< what the timing gives */
    uint16_t sp_permille; /**< its sample point */
    uint32_t mode_flags;  /**< MODE flags the channel runs with */
    uint8_t with_ts;
    uint16_t pad_to;
    uint32_t ts_offset; /**< host clock minus device clock (mod 2^32) */
    uint8_t ts_synced;
    struct libusb_transfer *rx[EF_GSUSB_RX_XFERS];
    int rx_active;
    ef_gsusb_txs_t tx[EF_GSUSB_TX_WINDOW];
    uint32_t tx_inflight;
    ef_gsusb_ctl_t ctl[2]; /**< [0] GET_STATE, [1] TIMESTAMP */
    uint32_t poll_last;
    ef_gsusb_rxe_t ring[EF_GSUSB_RX_RING];
    uint32_t ring_head, ring_count;
    ef_can_frame_t backlog[EF_GSUSB_BACKLOG];
    uint32_t bl_head, bl_count;
    int wake;           /**< set by completions: the event loop returns */
    int err_seen;       /**< an error frame arrived during this recv */
    int io_rc;          /**< an error a completion met, returned by every op from then (sticky) */
    int in_errors;      /**< bulk IN errors in a row */
    uint32_t in_err_t0; /**< when the first of them came (gsu_now()) */
    uint32_t seen;      /**< EF_CANIF_* conditions */
    int dev_state;      /**< last GET_STATE (EF_GSUSB_STATE_*), -1 unknown */
    int16_t tec, rec;
    uint32_t err_frames, tx_full, rx_overrun;
    uint64_t n_tx, n_rx, tx_bits;
    ef_gsusb_stats_t stats;
    ef_msg_t msg;       /**< what the last failing op met */
    ef_msg_t fault_msg; /**< the first EF_CANIF_FAULT's cause (kept after close) */
} ef_gsusb_t;

/** @brief The default options: channel 0, hardware timestamps where offered, the rest off. */
void ef_gsusb_opts_default(ef_gsusb_opts_t *o);

/** @brief Make g a closed transport with the default options (required before first use). */
void ef_gsusb_init(ef_gsusb_t *g);

/**
 * @brief Options for the next open (checked against the adapter's features there).
 * @retval EF_OK
 * @retval EF_ERR_ARG  NULL, channel >= EF_GSUSB_MAX_CHANNELS, hw_timestamps not -1..1,
 *                     listen-only with loop-back
 * @retval EF_ERR_STATE the transport is open
 */
int ef_gsusb_set_opts(ef_gsusb_t *g, const ef_gsusb_opts_t *o, ef_msg_t *m);

/**
 * @brief Parse a comma list of options as `--can-opts` takes it: loopback, listen-only,
 * one-shot, timestamps, no-timestamps, channel=N; into *o (which keeps what is not named).
 * @retval EF_OK
 * @retval EF_ERR_ARG an unknown word, a bad channel (message says which)
 */
int ef_gsusb_opts_parse(const char *s, ef_gsusb_opts_t *o, ef_msg_t *m);

/** @brief Whether s names this transport: "gsusb" alone or followed by ':' or '@'. */
int ef_gsusb_spec_is(const char *s);

/**
 * @brief Parse an adapter spec "gsusb[:SERIAL|:B-P.P][@BITRATE]".
 * @param who     the adapter part ("" for the only adapter), into who[who_n]
 * @param bitrate the bitrate (0 when not given; may be NULL)
 * @retval EF_OK
 * @retval EF_ERR_ARG not a gsusb spec, empty serial after ':', bitrate not 1..1000000 or
 *                    not a number, serial longer than who_n - 1 or with spaces or '@'
 */
int ef_gsusb_spec_parse(const char *s, char *who, size_t who_n, uint32_t *bitrate, ef_msg_t *m);

/**
 * @brief The adapter as a CAN transport (ef_canif.h). Its open takes as name "" or "gsusb"
 * (the only adapter: more than one is an error listing them), a serial number, a bus path
 * "B-P.P", or a spec "gsusb:WHO@BITRATE" (ef_gsusb_spec_parse()); the bitrate is
 * cfg->bitrate, else the spec's, else 1 Mbit/s. Filters are applied in software; the log is
 * a candump -L log ("gsusbN" as the interface, N the channel) of every frame sent (at its
 * echo) and received, error frames included. Codes as ef_canif.h says, and open's:
 * @retval EF_ERR_ARG   a malformed name, more than EF_CANIF_MAX_FILTERS filters, a channel
 *                      the adapter lacks
 * @retval EF_ERR_IO    libusb unusable, no adapter (or several for ""), no permission (the
 *                      udev rule of docs/can.md), claimed by another program, a bitrate
 *                      the adapter cannot make (the nearest named), an option the adapter
 *                      does not offer, a request stalled, log not writable
 * @retval EF_ERR_PROTO a reply of the wrong size or content, no bulk endpoints
 * @retval EF_ERR_TIMEOUT a request not answered within EF_GSUSB_CTRL_TIMEOUT_MS
 * g must stay valid (and ef_gsusb_init()ed) while the transport is used.
 */
ef_canif_t ef_gsusb_canif(ef_gsusb_t *g);

/** @brief Copy the transport's figures (latencies, counters) into *st. */
void ef_gsusb_stats(const ef_gsusb_t *g, ef_gsusb_stats_t *st);

/** @brief Mean of a latency distribution in us (0 when empty). */
double ef_gsusb_lat_mean(const ef_gsusb_lat_t *l);

/**
 * @brief The gs_usb adapters present: each found by its USB id (1d50:606f, 1209:2323,
 * 1cd2:606f, 16d0:10b8), opened briefly where free (no kernel driver, not claimed) to read
 * DEVICE_CONFIG and BT_CONST. Nothing is detached: an adapter the kernel drives is listed
 * as such.
 * @param out   up to max entries
 * @param found adapters found (may exceed max; the first max are in out)
 * @retval EF_OK (also with none found)
 * @retval EF_ERR_IO  libusb unusable here (message says why)
 * @retval EF_ERR_ARG NULL
 */
int ef_gsusb_list(ef_gsusb_info_t *out, int max, int *found, ef_msg_t *m);

/** @brief The feature bits as words ("listen-only,loop-back,..."), into buf; returns buf. */
const char *ef_gsusb_feature_str(uint32_t feature, char *buf, size_t n);

#ifdef __cplusplus
}
#endif

#endif /* EF_GSUSB_H */
