/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_can.h
 * @brief CAN peripheral contract (the HAL the CANopen master and drive run on), the frame
 * type, and bus-time arithmetic for load figures.
 *
 * The protocol code (ef_comaster.h, ef_codrive.h) never touches a controller: it is handed
 * received frames (`*_rx()`) and sends through one operation, ::ef_can_port_t::send. A
 * firmware supplies a port over its controller's TX mailboxes; the host supplies one over a
 * SocketCAN raw socket (host/include/evenfeed/host/can/ef_sockcan.h); the unit tests supply an
 * in-memory bus. Receiving is the port's business: it calls the protocol's `*_rx()` from
 * task context (a firmware drains its RX FIFO in its main loop, not in the interrupt).
 */
#ifndef EF_CAN_H
#define EF_CAN_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** Classic CAN data bytes per frame. */
#define EF_CAN_MAX_DLC 8

/** Frame flag: remote transmission request (CANopen uses none; received ones are ignored). */
#define EF_CAN_FLAG_RTR 1u
/** Frame flag: 29-bit identifier (CANopen here uses 11-bit; received ones are ignored). */
#define EF_CAN_FLAG_EFF 2u

/** One classic CAN frame. */
typedef struct {
    uint32_t id;   /**< identifier: 11 bits (29 with ::EF_CAN_FLAG_EFF) */
    uint8_t dlc;   /**< data length 0..8 */
    uint8_t flags; /**< EF_CAN_FLAG_* */
    uint8_t pad[2];
    uint8_t data[EF_CAN_MAX_DLC]; /**< data[0..dlc-1] */
} ef_can_frame_t;

/**
 * The peripheral contract: one operation.
 *
 * `send` (mandatory; task context, never called from an interrupt by evenfeed): queue one
 * frame for transmission. Returns EF_OK when the frame is queued, ::EF_ERR_AGAIN when the
 * transmit queue is full (the caller keeps the frame and tries again on a later
 * `*_process()` call: nothing is dropped), ::EF_ERR_BUS when the controller is bus-off or
 * the interface is down. It must not block.
 */
typedef struct {
    int (*send)(void *ctx, const ef_can_frame_t *f);
    void *ctx; /**< passed to send */
} ef_can_port_t;

/**
 * @brief Bits a frame occupies on the bus, worst-case bit stuffing included.
 *
 * Classic base frame: SOF, 11-bit id, RTR, IDE, r0, DLC (4), 8*dlc data, 15-bit CRC, CRC
 * delimiter, ACK slot and delimiter, 7-bit EOF and 3-bit intermission: 47 + 8*dlc bits. Of
 * these the 34 + 8*dlc bits from SOF to the CRC's end are subject to stuffing, worst case
 * one stuff bit per 4 after the first: floor((34 + 8*dlc - 1) / 4). Extended frames: 67 +
 * 8*dlc bits, 54 + 8*dlc stuffable. (dlc above 8 counts as 8.)
 * @return bits on the bus (55 for an empty base frame, 135 for 8 data bytes)
 */
uint32_t ef_can_frame_bits(const ef_can_frame_t *f);

/**
 * @brief Whether a (wrapping) microsecond counter value `a` is at or after `b`: true when
 * the signed difference a - b is >= 0, so it survives counter wrap for spans < 2^31 us.
 */
static inline int ef_time_reached(uint32_t a, uint32_t b)
{
    return (int32_t)(a - b) >= 0;
}

#ifdef __cplusplus
}
#endif

#endif /* EF_CAN_H */
