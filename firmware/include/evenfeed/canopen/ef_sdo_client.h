/* SPDX-License-Identifier: Apache-2.0 */
/**
 * @file ef_sdo_client.h
 * @brief CiA 301 SDO client: one transfer at a time to one server, expedited and segmented,
 * both directions (no block transfer). The master (ef_comaster.h) owns one, for bring-up and
 * for its caller's transfers.
 *
 * It owns no port and no clock: each call is given the time (a free-running microsecond
 * counter, wrap-safe) and returns the frame to send, if any, in `out` (dlc 8; dlc 0 when
 * there is none), so the owner sends it in order with the rest of its traffic. The owner also
 * routes the server's answers (COB-ID 0x580 + node) to ef_sdo_client_rx().
 *
 * ## States (::ef_sdo_client_t::state) and transitions
 *
 *     state    event                                     next     out
 *     IDLE     download(), len <= 4                      DL_INIT  initiate, expedited (e, s, n)
 *     IDLE     download(), len > 4                       DL_INIT  initiate, size in 4..7 (s)
 *     IDLE     upload()                                  UL_INIT  initiate upload
 *     IDLE     either, a duplicate of this server due    *_INIT   - (held: the initiate waits)
 *     held     the duplicate (the answer to the request  *_INIT   the held initiate
 *              the last transfer's retry replaced)
 *     held     anything else                             IDLE     EF_ERR_PROTO, abort 0
 *     held     one timeout                               *_INIT   the held initiate
 *     DL_INIT  initiate response (0x60, echoed):
 *                expedited                               IDLE ok  -
 *                segmented                               DL_SEG   segment, toggle 0
 *     DL_SEG   segment response, same toggle, more       DL_SEG   next segment, toggle ^ 1
 *     DL_SEG   segment response, same toggle, all sent   IDLE ok  -
 *     UL_INIT  initiate response (0x4x, echoed), e = 1   IDLE ok  -
 *     UL_INIT  initiate response (0x4x, echoed), e = 0   UL_SEG   segment request, toggle 0
 *     UL_SEG   segment, same toggle, c = 0               UL_SEG   segment request, toggle ^ 1
 *     UL_SEG   segment, same toggle, c = 1               IDLE ok  -
 *     *_SEG    retried at the initiate: its other answer *_SEG    - (ignored, once)
 *     *_INIT   retried at a segment: that one's answer   *_INIT   - (ignored, once)
 *     busy     abort (0x80) echoing index/sub            IDLE     EF_ERR_PROTO, its code
 *     busy     segment with the wrong toggle             IDLE     EF_ERR_PROTO, TOGGLE
 *     busy     anything else (not 8 bytes, wrong         IDLE     EF_ERR_PROTO, abort 0
 *              specifier, no echo, unechoed abort)
 *     busy     no answer for the timeout, first time     *_INIT   the initiate again
 *     busy     no answer again, or after no_retry()      IDLE     EF_ERR_TIMEOUT
 *     busy     abandon()                                 IDLE     (no outcome)
 *
 * (TOGGLE: ::EF_CO_ABORT_TOGGLE.) A retry restarts the whole transfer from its initiate (a
 * segmented transfer too: the server has dropped or will drop the half-done one). Every
 * request sent restarts the timer. A server that was only slow answers both initiates, in
 * order, and CAN SDO frames carry no transaction number, so the second answer is told apart
 * by position: within the transfer, once it is past its initiate (a segment phase), an
 * initiate answer echoing it is that duplicate and is ignored (and a retry at a segment: a
 * segment answer while the new initiate waits); after the transfer ended, the
 * next transfer with the same server holds its initiate back until the duplicate has come
 * (and is ignored) or one timeout has passed, so an answer is never taken for the next
 * transfer's (a write of 0x1602:00 then its read-back, under a loaded User-Mode Linux guest
 * with 350 ms between request and answer, was one). stale_ignored counts both kinds. A
 * master held back between reading its clock and sending a request times out early: seen
 * under load as well.
 * Uploads longer than ::EF_SDO_CLIENT_BUF are read to the end and cut.
 */
#ifndef EF_SDO_CLIENT_H
#define EF_SDO_CLIENT_H

#include <stdint.h>

#include "evenfeed/hal/ef_can.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The longest download and the longest upload kept (bytes). -DEF_COM_SDO_BUF, the master's
 *  older name for it, sets it too. */
#ifndef EF_SDO_CLIENT_BUF
#ifdef EF_COM_SDO_BUF
#define EF_SDO_CLIENT_BUF EF_COM_SDO_BUF
#else
#define EF_SDO_CLIENT_BUF 32
#endif
#endif

/** Client states (see the transition table above). */
typedef enum {
    EF_SDOC_IDLE = 0, /**< no transfer pending; the last one's outcome is kept */
    EF_SDOC_DL_INIT,  /**< download initiate sent: waiting for its response */
    EF_SDOC_DL_SEG,   /**< download segment sent: waiting for its confirmation */
    EF_SDOC_UL_INIT,  /**< upload initiate sent: waiting for its response */
    EF_SDOC_UL_SEG,   /**< upload segment request sent: waiting for the segment */
} ef_sdoc_state_t;

/** Client state (public for static allocation; read through the functions). */
typedef struct {
    uint8_t state;  /**< ::ef_sdoc_state_t */
    uint8_t node;   /**< server node id */
    uint8_t sub;    /**< object sub-index */
    uint8_t write;  /**< the transfer is a download */
    uint16_t index; /**< object index */
    uint8_t toggle; /**< toggle bit of the segment in flight */
    uint8_t tries;  /**< requests of this transfer begun (2: the retry is used) */
    uint32_t len;   /**< download: bytes to send; upload: size the server indicated */
    uint32_t got;   /**< download: bytes sent; upload: bytes received (also those cut) */
    uint32_t value; /**< upload: the first up to 4 bytes, little-endian */
    uint32_t t0_us; /**< when the request in flight went out */
    uint32_t timeout_us;
    int32_t rc;     /**< outcome of the last transfer (EF_ERR_AGAIN while pending) */
    uint32_t abort; /**< its abort code (0: none) */
    uint8_t dup;    /**< retried: the replaced request's answer may come (1: initiate,
                         2: segment request; 0: none) */
    uint8_t held;   /**< 1: the initiate is held back for the last transfer's duplicate */
    /* A transfer that was retried may still get the answer to its first request after it
     * ended (dup was set): the next transfer with that server waits for it (held). */
    uint16_t stale_index;
    uint8_t stale_sub;
    uint8_t stale_node;
    uint8_t stale_write;
    uint8_t stale_pending;  /**< that one answer may still come (dup's values) */
    uint32_t stale_ignored; /**< duplicate answers ignored (in a transfer or held for) */
    uint8_t buf[EF_SDO_CLIENT_BUF];
} ef_sdo_client_t;

/**
 * @brief Idle client (no outcome yet: ef_sdo_client_result() says EF_ERR_STATE).
 * @param timeout_us wait for each answer before the one retry / the failure
 * @retval EF_OK
 * @retval EF_ERR_ARG NULL c, timeout_us 0
 */
int ef_sdo_client_init(ef_sdo_client_t *c, uint32_t timeout_us);

/**
 * @brief Begin writing len bytes (copied) to index:sub of node: expedited up to 4 bytes,
 * segmented above. out: the initiate to send.
 * @retval EF_OK        started
 * @retval EF_ERR_ARG   NULL c, data or out, node not 1..127, len 0 or above
 *                      ::EF_SDO_CLIENT_BUF
 * @retval EF_ERR_STATE a transfer is pending
 */
int ef_sdo_client_download(ef_sdo_client_t *c, uint8_t node, uint16_t index, uint8_t sub,
                           const uint8_t *data, uint32_t len, uint32_t now_us, ef_can_frame_t *out);

/**
 * @brief Begin reading index:sub of node (expedited or segmented, as the server answers).
 * out: the initiate to send.
 * @retval EF_OK        started
 * @retval EF_ERR_ARG   NULL c or out, node not 1..127
 * @retval EF_ERR_STATE a transfer is pending
 */
int ef_sdo_client_upload(ef_sdo_client_t *c, uint8_t node, uint16_t index, uint8_t sub,
                         uint32_t now_us, ef_can_frame_t *out);

/**
 * @brief A frame from the server of the pending transfer (the owner matched its COB-ID).
 * out: the next request to send (dlc 0: none).
 * @retval EF_ERR_AGAIN still pending
 * @retval EF_OK        this frame completed the transfer
 * @retval EF_ERR_PROTO this frame failed it: the server's abort, a wrong toggle bit, any
 *                      other answer (ef_sdo_client_result() has the abort code)
 * @retval EF_ERR_STATE no transfer pending: the frame was ignored
 * @retval EF_ERR_ARG   NULL
 */
int ef_sdo_client_rx(ef_sdo_client_t *c, const ef_can_frame_t *f, uint32_t now_us,
                     ef_can_frame_t *out);

/**
 * @brief Time: the retry, or the failure, of a request without answer. out: the retried
 * initiate (dlc 0: none).
 * @retval EF_ERR_AGAIN still pending (retried now when out has a frame)
 * @retval EF_ERR_TIMEOUT the transfer failed now: no answer, also not to the retry
 * @retval EF_ERR_STATE no transfer pending
 * @retval EF_ERR_ARG   NULL
 */
int ef_sdo_client_process(ef_sdo_client_t *c, uint32_t now_us, ef_can_frame_t *out);

/** @brief The pending transfer gets no (further) retry: its next timeout fails it (the server
 *  restarted, so a retry would ask a node that forgot the transfer). */
void ef_sdo_client_no_retry(ef_sdo_client_t *c);

/** @brief End the pending transfer without a frame and without an outcome (its owner lost
 *  interest; a late answer is then ignored). */
void ef_sdo_client_abandon(ef_sdo_client_t *c);

/** @brief Whether a transfer is pending (0 for NULL). */
int ef_sdo_client_busy(const ef_sdo_client_t *c);

/** @brief Microseconds until the pending request times out (0: due now; 0xFFFFFFFF: none). */
uint32_t ef_sdo_client_due_us(const ef_sdo_client_t *c, uint32_t now_us);

/** @brief An upload's value: its first up to 4 bytes, little-endian (0 before any). */
uint32_t ef_sdo_client_value(const ef_sdo_client_t *c);

/**
 * @brief Outcome of the last transfer. Every out pointer may be NULL.
 * @param abort out: the server's abort code (::EF_CO_ABORT_TOGGLE for a wrong toggle bit in an
 *              answer), 0 otherwise
 * @param data  out: an upload's bytes (valid until the next transfer starts); NULL otherwise
 * @param len   out: their count (at most ::EF_SDO_CLIENT_BUF); 0 otherwise
 * @retval EF_OK          done (an upload's data in data/len)
 * @retval EF_ERR_AGAIN   pending
 * @retval EF_ERR_PROTO   the server aborted (code in *abort), a malformed answer or a wrong
 *                        toggle bit
 * @retval EF_ERR_TIMEOUT no answer, also not to the retry
 * @retval EF_ERR_STATE   no transfer has an outcome (none started, or abandoned)
 * @retval EF_ERR_ARG     NULL c
 */
int ef_sdo_client_result(const ef_sdo_client_t *c, uint32_t *abort, const uint8_t **data,
                         uint32_t *len);

#ifdef __cplusplus
}
#endif

#endif /* EF_SDO_CLIENT_H */
