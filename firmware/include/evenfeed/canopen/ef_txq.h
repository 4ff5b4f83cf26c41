/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_txq.h
 * @brief The CAN transmit queue of the CANopen master (ef_comaster.h) and drive
 * (ef_codrive.h): frames the port could not take wait here, in order, for the next flush.
 *
 * Order: a frame goes to the port directly only while nothing waits; otherwise it queues
 * behind what waits. The protocol depends on it: the chunks of a segment record, SYNC
 * before the cycle's RPDOs, SDO answers in the order of the requests.
 *
 * Storage: the owner's arrays, given to ef_txq_init() and sized by the owner's macro
 * (::EF_COM_TXQ, ::EF_CODRIVE_TXQ), so one type serves queues of different lengths without
 * a heap and without every queue paying for the longest.
 *
 * ## Drop policy (per queue, fixed at init): what a full queue gives up
 * - ::EF_TXQ_DROP_NEWEST (the master): the frame being sent is lost; what waits is never
 *   touched. Every master frame is a command whose loss the protocol repairs (go-back-N
 *   resends records, the controlword is refreshed, an SDO request times out and is retried),
 *   but only if frames already queued stay intact: dropping a queued chunk from the middle of
 *   a record, or a SYNC ahead of its RPDOs, would corrupt what is partly on the bus. The
 *   master also checks ef_txq_room() before a multi-frame record, so it rarely reaches this.
 * - ::EF_TXQ_DROP_STALE (the drive): the oldest frame queued as stale-able (heartbeats and
 *   TPDOs: periodic state that the next one supersedes) gives way and the new frame is
 *   queued; frames queued as not stale-able (SDO answers, EMCYs: one-shot, the master waits
 *   for them) are never dropped. A queue holding only those loses the new frame.
 * Either way each lost frame is counted in ::ef_txq_t::lost.
 *
 * ## Port answers (the HAL contract, ef_can.h: EF_OK, EF_ERR_AGAIN or EF_ERR_BUS)
 * EF_ERR_AGAIN and EF_ERR_BUS keep the frame (queued, or left at the head) for a later
 * flush: a busy port frees up, a bus that recovers carries it. Any other answer is outside
 * the contract ("refused outright"); what happens then is the second per-queue setting:
 * ::EF_TXQ_REFUSED_DROP (the master: a retry would change nothing, so the frame leaves the
 * queue, counted in ::ef_txq_t::rejected) or ::EF_TXQ_REFUSED_KEEP (the drive, as it always
 * behaved: the frame stays at the head and is retried at every flush).
 *
 * Not thread-safe: one owner calls it from one context (no interrupt).
 */
#ifndef EF_TXQ_H
#define EF_TXQ_H

#include <stdint.h>

#include "evenfeed/hal/ef_can.h"

#ifdef __cplusplus
extern "C" {
#endif

/** What a full queue gives up (see the file comment). */
typedef enum {
    EF_TXQ_DROP_NEWEST = 0, /**< the frame being sent */
    EF_TXQ_DROP_STALE = 1,  /**< the oldest stale-able frame queued, else the new one */
} ef_txq_policy_t;

/** What happens to a frame the port refuses outright (an answer outside the HAL contract). */
typedef enum {
    EF_TXQ_REFUSED_DROP = 0, /**< it leaves the queue (counted in rejected) */
    EF_TXQ_REFUSED_KEEP = 1, /**< it stays and is retried at every flush */
} ef_txq_refused_t;

/** A transmit queue (public for static allocation; read count and the counters only). */
typedef struct {
    ef_can_frame_t *frame; /**< cap slots: the owner's array */
    uint8_t *stale;        /**< cap flags (::EF_TXQ_DROP_STALE only, else NULL) */
    uint16_t cap;          /**< slots */
    uint8_t policy;        /**< ::ef_txq_policy_t */
    uint8_t refused;       /**< ::ef_txq_refused_t */
    uint32_t head;         /**< oldest frame */
    uint32_t count;        /**< frames waiting */
    uint32_t sent;         /**< frames the port took */
    uint32_t again;        /**< EF_ERR_AGAIN answers (port busy) */
    uint32_t lost;         /**< frames dropped by the policy (queue full) */
    uint32_t rejected;     /**< frames refused outright and dropped (::EF_TXQ_REFUSED_DROP) */
} ef_txq_t;

/**
 * @brief Empty queue over the owner's storage.
 * @param frames cap slots
 * @param stale  cap flags; needed by ::EF_TXQ_DROP_STALE, ignored (may be NULL) otherwise
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL q or frames, cap 0 or above 65535, an unknown policy or refusal
 *                    setting, ::EF_TXQ_DROP_STALE without stale
 */
int ef_txq_init(ef_txq_t *q, ef_can_frame_t *frames, uint8_t *stale, uint32_t cap, int policy,
                int refused);

/**
 * @brief Send f: to the port now if nothing waits, else queued behind what waits (the frame
 * is copied).
 * @param stale  with ::EF_TXQ_DROP_STALE: the frame may give way in a full queue (heartbeat,
 *               TPDO); ignored otherwise
 * @retval EF_OK       the port took f, or f waits in the queue (port busy / frames waiting),
 *                     or the port refused it outright (then as the refusal setting says)
 * @retval EF_ERR_BUS  the port reports bus-off / interface down; f waits (unless lost)
 * @retval EF_ERR_FULL the queue was full: a frame was lost (f, or with ::EF_TXQ_DROP_STALE
 *                     an older stale-able one; counted in lost)
 * @retval EF_ERR_ARG  NULL q, port or f
 */
int ef_txq_send(ef_txq_t *q, const ef_can_port_t *port, const ef_can_frame_t *f, int stale);

/**
 * @brief Hand waiting frames to the port in order until it is busy or the queue is empty.
 * @retval EF_OK        the queue is empty
 * @retval EF_ERR_AGAIN the port is busy: frames wait
 * @retval EF_ERR_BUS   the port reports bus-off / interface down: the head frame waits
 * @retval <0           ::EF_TXQ_REFUSED_KEEP: the port's answer refusing the head frame,
 *                      which waits
 * @retval EF_ERR_ARG   NULL q or port
 */
int ef_txq_flush(ef_txq_t *q, const ef_can_port_t *port);

/** @brief Free slots (0 for NULL). */
uint32_t ef_txq_room(const ef_txq_t *q);

/** @brief Frames waiting (0 for NULL). */
uint32_t ef_txq_count(const ef_txq_t *q);

#ifdef __cplusplus
}
#endif

#endif /* EF_TXQ_H */
