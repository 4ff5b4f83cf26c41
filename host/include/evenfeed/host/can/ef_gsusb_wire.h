/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_gsusb_wire.h
 * @brief The gs_usb protocol of USB-CAN adapters (candleLight, CANable, and every firmware
 * Linux's gs_usb driver binds to): vendor requests, their structures, the host frame, bit
 * timing. Pure functions on byte buffers, no libusb and no I/O, shared by the libusb driver
 * (ef_gsusb.h), the simulated adapter (ef_gsusb_sim.h) and the fuzz target.
 *
 * ## Wire facts (as the adapters and the Linux driver use them)
 * - Every request is a vendor request to the interface (bmRequestType 0x41 host to device,
 *   0xC1 device to host), wIndex = 0 (the adapter's interface), wValue = the channel (1 for
 *   HOST_FORMAT). All numbers are little-endian u32: HOST_FORMAT sends 0x0000beef, which
 *   asks for that, and is the only byte order candleLight speaks.
 * - DEVICE_CONFIG (in, 12 bytes): reserved[3], icount (channels - 1), sw_version,
 *   hw_version. BT_CONST (in, 40 bytes): feature, fclk_can, tseg1_min/max, tseg2_min/max,
 *   sjw_max, brp_min/max, brp_inc. BITTIMING (out, 20 bytes): prop_seg, phase_seg1,
 *   phase_seg2, sjw, brp. MODE (out, 8 bytes): mode (0 reset, 1 start), flags
 *   (EF_GSUSB_MODE_*). TIMESTAMP (in, 4 bytes): the device's microsecond clock. GET_STATE
 *   (in, 12 bytes): state (EF_GSUSB_STATE_*), rxerr, txerr. BERR (out, 4 bytes): 1 on.
 * - A host frame is echo_id (u32), can_id (u32, SocketCAN's flags: EFF 1<<31, RTR 1<<30,
 *   ERR 1<<29), can_dlc, channel, flags, reserved (u8 each), data[8]: 20 bytes, 24 with
 *   the u32 timestamp (µs, wraps after 71.6 min) the device appends when the channel was
 *   started with EF_GSUSB_MODE_HW_TIMESTAMP. A device with EF_GSUSB_FEAT_PAD_PKTS pads
 *   every IN transfer to the endpoint's max packet size.
 * - The host sends a frame with an echo_id of its choosing; once the frame is on the bus
 *   the device sends it back with the same echo_id (the TX confirmation). Frames received
 *   from the bus come with echo_id 0xFFFFFFFF. The Linux driver keeps at most 10 frames
 *   unconfirmed.
 * - Error frames come as received frames with EF_GSUSB_ID_ERR and SocketCAN's error-frame
 *   layout (class in can_id, controller state in data[1], counters in data[6], data[7]).
 *
 * Errors: functions that decode return EF_OK or ::EF_ERR_PROTO with a message naming the
 * request or field; ::EF_ERR_ARG for NULL. Nothing reads outside [buf, buf + n).
 */
#ifndef EF_GSUSB_WIRE_H
#define EF_GSUSB_WIRE_H

#include <stddef.h>
#include <stdint.h>

#include "evenfeed/host/core/ef_host.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Vendor requests (bRequest). */
enum {
    EF_GSUSB_BREQ_HOST_FORMAT = 0,
    EF_GSUSB_BREQ_BITTIMING = 1,
    EF_GSUSB_BREQ_MODE = 2,
    EF_GSUSB_BREQ_BERR = 3,
    EF_GSUSB_BREQ_BT_CONST = 4,
    EF_GSUSB_BREQ_DEVICE_CONFIG = 5,
    EF_GSUSB_BREQ_TIMESTAMP = 6,
    EF_GSUSB_BREQ_IDENTIFY = 7,
    EF_GSUSB_BREQ_GET_STATE = 14,
};

/** bmRequestType of requests to the device (vendor, interface) and from it. */
#define EF_GSUSB_REQ_OUT 0x41u
#define EF_GSUSB_REQ_IN  0xC1u

/** HOST_FORMAT's value: little-endian, please. */
#define EF_GSUSB_HOST_FORMAT_LE 0x0000beefu

/** Feature bits (BT_CONST feature). */
#define EF_GSUSB_FEAT_LISTEN_ONLY   (1u << 0)
#define EF_GSUSB_FEAT_LOOP_BACK     (1u << 1)
#define EF_GSUSB_FEAT_TRIPLE_SAMPLE (1u << 2)
#define EF_GSUSB_FEAT_ONE_SHOT      (1u << 3)
#define EF_GSUSB_FEAT_HW_TIMESTAMP  (1u << 4)
#define EF_GSUSB_FEAT_IDENTIFY      (1u << 5)
#define EF_GSUSB_FEAT_USER_ID       (1u << 6)
#define EF_GSUSB_FEAT_PAD_PKTS      (1u << 7)
#define EF_GSUSB_FEAT_FD            (1u << 8)
#define EF_GSUSB_FEAT_BERR          (1u << 12)
#define EF_GSUSB_FEAT_GET_STATE     (1u << 13)

/** MODE's mode word. */
#define EF_GSUSB_MODE_RESET 0u
#define EF_GSUSB_MODE_START 1u
/** MODE's flags (the feature bits they need have the same positions). */
#define EF_GSUSB_MODE_NORMAL       0u
#define EF_GSUSB_MODE_LISTEN_ONLY  (1u << 0)
#define EF_GSUSB_MODE_LOOP_BACK    (1u << 1)
#define EF_GSUSB_MODE_ONE_SHOT     (1u << 3)
#define EF_GSUSB_MODE_HW_TIMESTAMP (1u << 4)
#define EF_GSUSB_MODE_PAD_PKTS     (1u << 7)
#define EF_GSUSB_MODE_BERR         (1u << 12)

/** GET_STATE's state word (the CAN fault-confinement states). */
enum {
    EF_GSUSB_STATE_ACTIVE = 0,
    EF_GSUSB_STATE_WARNING = 1,
    EF_GSUSB_STATE_PASSIVE = 2,
    EF_GSUSB_STATE_BUS_OFF = 3,
    EF_GSUSB_STATE_STOPPED = 4,
    EF_GSUSB_STATE_SLEEPING = 5,
};

/** Host-frame can_id bits (SocketCAN's). */
#define EF_GSUSB_ID_EFF  0x80000000u
#define EF_GSUSB_ID_RTR  0x40000000u
#define EF_GSUSB_ID_ERR  0x20000000u
#define EF_GSUSB_ID_MASK 0x1FFFFFFFu

/** Host-frame flags. */
#define EF_GSUSB_FLAG_OVERFLOW 1u /**< the device lost received frames before this one */

/** echo_id of a frame received from the bus. */
#define EF_GSUSB_ECHO_RX 0xFFFFFFFFu

/** Host-frame sizes: classic CAN without and with the hardware timestamp. */
#define EF_GSUSB_FRAME_LEN    20u
#define EF_GSUSB_FRAME_TS_LEN 24u

/** Reply and payload sizes of the requests. */
#define EF_GSUSB_DEVCFG_LEN  12u
#define EF_GSUSB_BTCONST_LEN 40u
#define EF_GSUSB_BITTIME_LEN 20u
#define EF_GSUSB_MODE_LEN    8u
#define EF_GSUSB_STATE_LEN   12u
#define EF_GSUSB_U32_LEN     4u

/** Channels a device may report (the protocol's icount is a byte; the Linux driver takes 3). */
#define EF_GSUSB_MAX_CHANNELS 8u

/** DEVICE_CONFIG. */
typedef struct {
    uint8_t channels;    /**< icount + 1 */
    uint32_t sw_version; /**< firmware version */
    uint32_t hw_version; /**< hardware version */
} ef_gsusb_devcfg_t;

/** BT_CONST: what the channel's bit-timing unit can do. */
typedef struct {
    uint32_t feature; /**< EF_GSUSB_FEAT_* */
    uint32_t fclk;    /**< CAN clock (Hz) */
    uint32_t tseg1_min, tseg1_max, tseg2_min, tseg2_max, sjw_max;
    uint32_t brp_min, brp_max, brp_inc;
} ef_gsusb_btconst_t;

/** BITTIMING: one bit is 1 + prop_seg + phase_seg1 + phase_seg2 time quanta of brp clocks. */
typedef struct {
    uint32_t prop_seg, phase_seg1, phase_seg2, sjw, brp;
} ef_gsusb_bittiming_t;

/** GET_STATE. */
typedef struct {
    uint32_t state; /**< EF_GSUSB_STATE_* */
    uint32_t rxerr, txerr;
} ef_gsusb_state_t;

/** One classic host frame. */
typedef struct {
    uint32_t echo_id; /**< host's tag, or EF_GSUSB_ECHO_RX for a received frame */
    uint32_t can_id;  /**< identifier with EF_GSUSB_ID_* flags */
    uint8_t dlc;      /**< 0..8 */
    uint8_t channel;
    uint8_t flags;   /**< EF_GSUSB_FLAG_* */
    uint8_t has_ts;  /**< ts_us is the device's timestamp */
    uint8_t data[8]; /**< data[dlc..7] zero on encode */
    uint32_t ts_us;  /**< device timestamp (µs, wrapping) when has_ts */
} ef_gsusb_frame_t;

/** Little-endian u32 at p (any alignment). */
uint32_t ef_gsusb_get32(const uint8_t *p);
/** Store v little-endian at p. */
void ef_gsusb_put32(uint8_t *p, uint32_t v);

/**
 * @brief Decode DEVICE_CONFIG's reply.
 * @retval EF_OK
 * @retval EF_ERR_PROTO n is not 12 bytes, or icount + 1 > EF_GSUSB_MAX_CHANNELS
 * @retval EF_ERR_ARG   NULL
 */
int ef_gsusb_devcfg_decode(const uint8_t *buf, size_t n, ef_gsusb_devcfg_t *out, ef_msg_t *m);
/** @brief Encode DEVICE_CONFIG's reply into out[12] (channels 1..8). @return 12 */
size_t ef_gsusb_devcfg_encode(const ef_gsusb_devcfg_t *c, uint8_t *out);

/**
 * @brief Decode BT_CONST's reply.
 * @retval EF_OK
 * @retval EF_ERR_PROTO n is not 40 bytes; fclk 0; a minimum of 0 (tseg1, tseg2, brp) or
 *                      above its maximum; sjw_max 0; brp_inc 0 (message names the field)
 * @retval EF_ERR_ARG   NULL
 */
int ef_gsusb_btconst_decode(const uint8_t *buf, size_t n, ef_gsusb_btconst_t *out, ef_msg_t *m);
/** @brief Encode BT_CONST's reply into out[40]. @return 40 */
size_t ef_gsusb_btconst_encode(const ef_gsusb_btconst_t *c, uint8_t *out);

/** @brief Encode BITTIMING's payload into out[20]. @return 20 */
size_t ef_gsusb_bittiming_encode(const ef_gsusb_bittiming_t *bt, uint8_t *out);
/**
 * @brief Decode BITTIMING's payload (the device's side).
 * @retval EF_OK
 * @retval EF_ERR_PROTO n is not 20 bytes
 * @retval EF_ERR_ARG   NULL
 */
int ef_gsusb_bittiming_decode(const uint8_t *buf, size_t n, ef_gsusb_bittiming_t *out, ef_msg_t *m);

/** @brief Encode MODE's payload into out[8]. @return 8 */
size_t ef_gsusb_mode_encode(uint32_t mode, uint32_t flags, uint8_t *out);
/**
 * @brief Decode MODE's payload (the device's side).
 * @retval EF_OK
 * @retval EF_ERR_PROTO n is not 8 bytes, or mode is neither reset nor start
 * @retval EF_ERR_ARG   NULL
 */
int ef_gsusb_mode_decode(const uint8_t *buf, size_t n, uint32_t *mode, uint32_t *flags,
                         ef_msg_t *m);

/**
 * @brief Decode GET_STATE's reply.
 * @retval EF_OK
 * @retval EF_ERR_PROTO n is not 12 bytes, or state above EF_GSUSB_STATE_SLEEPING
 * @retval EF_ERR_ARG   NULL
 */
int ef_gsusb_state_decode(const uint8_t *buf, size_t n, ef_gsusb_state_t *out, ef_msg_t *m);
/** @brief Encode GET_STATE's reply into out[12]. @return 12 */
size_t ef_gsusb_state_encode(const ef_gsusb_state_t *s, uint8_t *out);

/**
 * @brief Decode a 4-byte u32 reply or payload (TIMESTAMP, HOST_FORMAT, BERR); `what` names
 * the request in the message.
 * @retval EF_OK
 * @retval EF_ERR_PROTO n is not 4 bytes
 * @retval EF_ERR_ARG   NULL
 */
int ef_gsusb_u32_decode(const uint8_t *buf, size_t n, const char *what, uint32_t *out, ef_msg_t *m);

/**
 * @brief Encode a host frame into out[24]: 20 bytes, 24 with the timestamp when
 * f->has_ts. The reserved byte and data beyond dlc are written as 0 whatever f holds.
 * @return bytes written (20 or 24); 0 when f->dlc > 8 (nothing written)
 */
size_t ef_gsusb_frame_encode(const ef_gsusb_frame_t *f, uint8_t *out);

/**
 * @brief Decode one host frame from an IN transfer of n bytes.
 * @param with_ts  the channel runs with hardware timestamps: the frame is 24 bytes
 * @param pad_to   the device pads transfers to this size (EF_GSUSB_MODE_PAD_PKTS; 0: no
 *                 padding): n may then be pad_to
 * @param channels channels the device has: a larger channel is refused
 * @retval EF_OK        *out holds the frame (has_ts set by with_ts)
 * @retval EF_ERR_PROTO n is neither the frame's size nor pad_to; dlc > 8; unknown channel
 *                      (message names the field and value)
 * @retval EF_ERR_ARG   NULL
 */
int ef_gsusb_frame_decode(const uint8_t *buf, size_t n, int with_ts, size_t pad_to,
                          unsigned channels, ef_gsusb_frame_t *out, ef_msg_t *m);

/**
 * @brief Bit timing for `bitrate` on a device with constants bc, at the sample point
 * CiA 301 recommends (87.5 % up to 500 kbit/s, 80 % to 800 kbit/s, 75 % above), as close
 * to it as the device's segment ranges allow. Of the prescalers that divide the clock
 * into a bit of 8..25 quanta (the most quanta preferred) the one with the smallest bitrate
 * error wins, then the smallest sample-point error. prop_seg is 0 (a device adds it to
 * phase_seg1: the Linux driver does the same); sjw = min(phase_seg2, sjw_max).
 * @param actual      the bitrate the timing gives (may be NULL)
 * @param sp_permille the sample point it gives, in 1/1000 of the bit (may be NULL)
 * @retval EF_OK
 * @retval EF_ERR_ARG bitrate 0 or above 1 Mbit/s (classic CAN), NULL
 * @retval EF_ERR_IO  the device cannot make it: no timing within 0.5 % of the bitrate
 *                    (message gives the nearest it can make)
 */
int ef_gsusb_bittiming_calc(const ef_gsusb_btconst_t *bc, uint32_t bitrate,
                            ef_gsusb_bittiming_t *bt, uint32_t *actual, uint16_t *sp_permille,
                            ef_msg_t *m);

/**
 * @brief The bitrate a timing gives on a clock fclk (0 when brp or the bit is 0).
 */
uint32_t ef_gsusb_bitrate(uint32_t fclk, const ef_gsusb_bittiming_t *bt);

/** @brief Name of a request ("HOST_FORMAT", "BT_CONST", ...; "unknown request" otherwise).
 *  Never NULL. */
const char *ef_gsusb_req_name(unsigned breq);

#ifdef __cplusplus
}
#endif

#endif /* EF_GSUSB_WIRE_H */
