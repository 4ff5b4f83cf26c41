/* SPDX-License-Identifier: Apache-2.0 */
/* CiA 301 SDO client, expedited and segmented (see ef_sdo_client.h for the states). */
#include <stddef.h>

#include "evenfeed/canopen/ef_sdo_client.h"
#include "evenfeed/canopen/ef_canopen.h"
#include "evenfeed/core/ef_err.h"

/** SDO command bytes (CiA 301). */
#define SDC_DL_INIT   0x20u /**< download initiate (client) */
#define SDC_DL_RESP   0x60u /**< download initiate response (server) */
#define SDC_DL_SEG    0x00u /**< download segment (client; + toggle << 4, n << 1, c) */
#define SDC_DL_ACK    0x20u /**< download segment response (server; + toggle << 4) */
#define SDC_UL_INIT   0x40u /**< upload initiate (both; server adds n/e/s bits) */
#define SDC_UL_SEG    0x60u /**< upload segment request (client; + toggle << 4) */
#define SDC_CS_MASK   0xE0u /**< command specifier bits */
#define SDC_TOGGLE    0x10u /**< toggle bit of segment frames */
#define SDC_EXPEDITED 0x02u /**< e bit */
#define SDC_SIZED     0x01u /**< s bit */
#define SDC_LAST      0x01u /**< c bit of a segment (no more segments) */
/** Data bytes of one SDO segment. */
#define SDC_SEG_BYTES 7u
/** What a retry may leave behind (ef_sdo_client_t::dup): the answer to the initiate or to the
 *  segment request it replaced. */
#define SDC_DUP_INIT 1u
#define SDC_DUP_SEG  2u
/** Upload size when the server indicated none (the last segment ends it). */
#define SDC_LEN_UNKNOWN 0xFFFFFFFFu

/* An 8-byte request to the server; the timer restarts with it. */
static void sdc_frame(ef_sdo_client_t *c, const uint8_t d[8], uint32_t now_us, ef_can_frame_t *out)
{
    *out = (ef_can_frame_t){0};
    out->id = EF_CO_COB_SDO_RX + c->node;
    out->dlc = 8u;
    for (uint32_t i = 0; i < 8u; i++)
        out->data[i] = d[i];
    c->t0_us = now_us;
}

/* The initiate of the transfer (also its retry: a transfer restarts whole). */
static void sdc_request(ef_sdo_client_t *c, uint32_t now_us, ef_can_frame_t *out)
{
    uint8_t d[8] = {0};
    ef_co_put16(&d[1], c->index);
    d[3] = c->sub;
    if (c->write && c->len > 4u) {
        d[0] = (uint8_t)(SDC_DL_INIT | SDC_SIZED); /* segmented: the size, then segments */
        ef_co_put32(&d[4], c->len);
        c->state = EF_SDOC_DL_INIT;
    } else if (c->write) {
        d[0] = (uint8_t)(SDC_DL_INIT | ((4u - c->len) << 2) | SDC_EXPEDITED | SDC_SIZED);
        for (uint32_t i = 0; i < c->len; i++)
            d[4 + i] = c->buf[i];
        c->state = EF_SDOC_DL_INIT;
    } else {
        d[0] = SDC_UL_INIT;
        c->len = 0; /* a retried upload starts over */
        c->value = 0;
        c->state = EF_SDOC_UL_INIT;
    }
    c->toggle = 0;
    c->got = 0;
    sdc_frame(c, d, now_us, out);
}

/* Download: the next segment (got counts the bytes sent with it). */
static void sdc_dl_seg(ef_sdo_client_t *c, uint32_t now_us, ef_can_frame_t *out)
{
    uint32_t left = c->len - c->got;
    uint32_t n = left < SDC_SEG_BYTES ? left : SDC_SEG_BYTES;
    uint8_t d[8] = {0};
    d[0] = (uint8_t)(SDC_DL_SEG | (c->toggle ? SDC_TOGGLE : 0u) | ((SDC_SEG_BYTES - n) << 1) |
                     (n == left ? SDC_LAST : 0u));
    for (uint32_t i = 0; i < n; i++)
        d[1 + i] = c->buf[c->got + i];
    c->got += n;
    c->state = EF_SDOC_DL_SEG;
    sdc_frame(c, d, now_us, out);
}

/* Upload: request the next segment with the present toggle. */
static void sdc_ul_seg(ef_sdo_client_t *c, uint32_t now_us, ef_can_frame_t *out)
{
    uint8_t d[8] = {(uint8_t)(SDC_UL_SEG | (c->toggle ? SDC_TOGGLE : 0u)), 0, 0, 0, 0, 0, 0, 0};
    c->state = EF_SDOC_UL_SEG;
    sdc_frame(c, d, now_us, out);
}

/* The transfer ends with rc (abort: the code an abort or a wrong toggle carries). */
static int sdc_end(ef_sdo_client_t *c, int rc, uint32_t abort)
{
    /* A retried transfer answered, but not twice: the other answer may still come (after a
     * timeout, two went unanswered for a timeout each: none is waited for). */
    c->stale_pending = (uint8_t)(rc != EF_ERR_TIMEOUT ? c->dup : 0u);
    c->stale_index = c->index;
    c->stale_sub = c->sub;
    c->stale_node = c->node;
    c->stale_write = c->write;
    c->dup = 0;
    c->held = 0;
    c->state = EF_SDOC_IDLE;
    c->rc = rc;
    c->abort = abort;
    return rc;
}

/* Keep received upload bytes (beyond the buffer they are counted, not kept). */
static void sdc_keep(ef_sdo_client_t *c, const uint8_t *p, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++, c->got++) {
        if (c->got < EF_SDO_CLIENT_BUF)
            c->buf[c->got] = p[i];
        if (c->got < 4u)
            c->value |= (uint32_t)p[i] << (8u * c->got);
    }
}

/* Whether a segment's toggle bit is the one expected. */
static int sdc_toggle_ok(const ef_sdo_client_t *c, uint8_t cmd)
{
    return ((cmd & SDC_TOGGLE) != 0) == (c->toggle != 0);
}

/* Upload initiate response: expedited data ends it, else segments follow. */
static int sdc_ul_init_rx(ef_sdo_client_t *c, const uint8_t *d, uint32_t now_us,
                          ef_can_frame_t *out)
{
    uint8_t cmd = d[0];
    if (cmd & SDC_EXPEDITED) {
        uint32_t size = (cmd & SDC_SIZED) ? 4u - ((cmd >> 2) & 3u) : 4u;
        sdc_keep(c, &d[4], size);
        return sdc_end(c, EF_OK, 0);
    }
    /* The size (when given) is informative; the last segment ends the transfer. */
    c->len = (cmd & SDC_SIZED) ? ef_co_get32(&d[4]) : SDC_LEN_UNKNOWN;
    if (c->len == 0u)
        c->len = SDC_LEN_UNKNOWN;
    c->toggle = 0;
    sdc_ul_seg(c, now_us, out);
    return EF_ERR_AGAIN;
}

/* Whether d is the late answer a retry left (dup: SDC_DUP_INIT or SDC_DUP_SEG) of the transfer
 * (index, sub, write): an initiate response of its kind echoing index/sub, or (with abort)
 * an abort echoing them; or a segment answer of its kind (segments echo nothing). */
static int sdc_dup_answer(const uint8_t *d, uint8_t dup, uint16_t index, uint8_t sub, uint8_t write,
                          int abort)
{
    uint8_t cmd = d[0], cs = cmd & SDC_CS_MASK;
    if (dup == SDC_DUP_SEG)
        return write ? cs == SDC_DL_ACK : cs == 0u;
    int kind = write ? cmd == SDC_DL_RESP : cs == SDC_UL_INIT;
    int echo = ef_co_get16(&d[1]) == index && d[3] == sub;
    return (dup == SDC_DUP_INIT) & echo & (kind | (abort & (cmd == EF_CO_SDO_ABORT)));
}

/* Start the transfer set up in c: its initiate goes out, unless the last transfer with this
 * server was retried and its duplicate answer has not come; then the initiate is held until
 * it does (ef_sdo_client_rx()) or for one timeout (ef_sdo_client_process()). */
static void sdc_begin(ef_sdo_client_t *c, uint32_t now_us, ef_can_frame_t *out)
{
    c->tries = 1;
    c->dup = 0;
    c->rc = EF_ERR_AGAIN;
    c->abort = 0;
    int hold = c->stale_pending && c->stale_node == c->node;
    c->stale_pending = (uint8_t)hold; /* another server's late answer is not routed here */
    sdc_request(c, now_us, out);
    c->held = (uint8_t)hold;
    if (hold)
        out->dlc = 0;
}

/* Initialise the client (contract in ef_sdo_client.h). */
int ef_sdo_client_init(ef_sdo_client_t *c, uint32_t timeout_us)
{
    if (!c || timeout_us == 0u)
        return EF_ERR_ARG;
    *c = (ef_sdo_client_t){0};
    c->timeout_us = timeout_us;
    c->rc = EF_ERR_STATE;
    return EF_OK;
}

/* Begin a download (contract in ef_sdo_client.h). */
int ef_sdo_client_download(ef_sdo_client_t *c, uint8_t node, uint16_t index, uint8_t sub,
                           const uint8_t *data, uint32_t len, uint32_t now_us, ef_can_frame_t *out)
{
    if (!c || !data || !out || node < 1u || node > 127u || len == 0u || len > EF_SDO_CLIENT_BUF)
        return EF_ERR_ARG;
    if (c->state != EF_SDOC_IDLE)
        return EF_ERR_STATE;
    for (uint32_t i = 0; i < len; i++)
        c->buf[i] = data[i];
    c->node = node;
    c->index = index;
    c->sub = sub;
    c->write = 1;
    c->len = len;
    c->value = 0;
    sdc_begin(c, now_us, out);
    return EF_OK;
}

/* Begin an upload (contract in ef_sdo_client.h). */
int ef_sdo_client_upload(ef_sdo_client_t *c, uint8_t node, uint16_t index, uint8_t sub,
                         uint32_t now_us, ef_can_frame_t *out)
{
    if (!c || !out || node < 1u || node > 127u)
        return EF_ERR_ARG;
    if (c->state != EF_SDOC_IDLE)
        return EF_ERR_STATE;
    c->node = node;
    c->index = index;
    c->sub = sub;
    c->write = 0;
    sdc_begin(c, now_us, out);
    return EF_OK;
}

/* One answer from the server: the transition table of ef_sdo_client.h. */
int ef_sdo_client_rx(ef_sdo_client_t *c, const ef_can_frame_t *f, uint32_t now_us,
                     ef_can_frame_t *out)
{
    if (!c || !f || !out)
        return EF_ERR_ARG;
    out->dlc = 0;
    if (c->state == EF_SDOC_IDLE)
        return EF_ERR_STATE;
    if (f->dlc != 8u)
        return sdc_end(c, EF_ERR_PROTO, 0);
    const uint8_t *d = f->data;
    uint8_t cmd = d[0];
    int echo = ef_co_get16(&d[1]) == c->index && d[3] == c->sub;
    if (c->held) {
        /* Nothing of this transfer is out: only the last one's duplicate is expected. */
        if (!sdc_dup_answer(d, c->stale_pending, c->stale_index, c->stale_sub, c->stale_write, 1))
            return sdc_end(c, EF_ERR_PROTO, 0);
        c->stale_pending = 0;
        c->held = 0;
        c->stale_ignored++;
        sdc_request(c, now_us, out);
        return EF_ERR_AGAIN;
    }
    /* A retried transfer: the answer to the request the retry replaced comes first (the server
     * answers in order), so an initiate answer once past the initiate, or a segment answer
     * while at the initiate, is that one. */
    int seg = (c->state == EF_SDOC_DL_SEG) | (c->state == EF_SDOC_UL_SEG);
    int when = seg ? c->dup == SDC_DUP_INIT : c->dup == SDC_DUP_SEG;
    if (when && sdc_dup_answer(d, c->dup, c->index, c->sub, c->write, 0)) {
        c->dup = 0;
        c->stale_ignored++;
        return EF_ERR_AGAIN;
    }
    if (cmd == EF_CO_SDO_ABORT)
        return sdc_end(c, EF_ERR_PROTO, echo ? ef_co_get32(&d[4]) : 0u);
    switch (c->state) {
    case EF_SDOC_DL_INIT:
        if (cmd != SDC_DL_RESP || !echo)
            break;
        if (c->len > 4u) {
            sdc_dl_seg(c, now_us, out); /* initiate confirmed: the first segment (toggle 0) */
            return EF_ERR_AGAIN;
        }
        return sdc_end(c, EF_OK, 0);
    case EF_SDOC_DL_SEG:
        if ((cmd & SDC_CS_MASK) != SDC_DL_ACK)
            break;
        if (!sdc_toggle_ok(c, cmd))
            return sdc_end(c, EF_ERR_PROTO, EF_CO_ABORT_TOGGLE);
        if (c->got >= c->len)
            return sdc_end(c, EF_OK, 0);
        c->toggle ^= 1u;
        sdc_dl_seg(c, now_us, out);
        return EF_ERR_AGAIN;
    case EF_SDOC_UL_INIT:
        if ((cmd & SDC_CS_MASK) != SDC_UL_INIT || !echo)
            break;
        return sdc_ul_init_rx(c, d, now_us, out);
    case EF_SDOC_UL_SEG:
        if ((cmd & SDC_CS_MASK) != 0u)
            break;
        if (!sdc_toggle_ok(c, cmd))
            return sdc_end(c, EF_ERR_PROTO, EF_CO_ABORT_TOGGLE);
        sdc_keep(c, &d[1], SDC_SEG_BYTES - ((cmd >> 1) & 7u));
        if (cmd & SDC_LAST)
            return sdc_end(c, EF_OK, 0);
        c->toggle ^= 1u;
        sdc_ul_seg(c, now_us, out);
        return EF_ERR_AGAIN;
    default:
        break;
    }
    return sdc_end(c, EF_ERR_PROTO, 0);
}

/* Timeout: one retry of the whole transfer, then the failure. */
int ef_sdo_client_process(ef_sdo_client_t *c, uint32_t now_us, ef_can_frame_t *out)
{
    if (!c || !out)
        return EF_ERR_ARG;
    out->dlc = 0;
    if (c->state == EF_SDOC_IDLE)
        return EF_ERR_STATE;
    if (!ef_time_reached(now_us, c->t0_us + c->timeout_us))
        return EF_ERR_AGAIN;
    if (c->held) {
        /* The last transfer's duplicate did not come: this one's initiate goes now. */
        c->held = 0;
        c->stale_pending = 0;
        sdc_request(c, now_us, out);
        return EF_ERR_AGAIN;
    }
    if (c->tries < 2u) {
        c->tries++;
        /* the replaced request may still be answered too */
        int init = (c->state == EF_SDOC_DL_INIT) | (c->state == EF_SDOC_UL_INIT);
        c->dup = init ? SDC_DUP_INIT : SDC_DUP_SEG;
        sdc_request(c, now_us, out);
        return EF_ERR_AGAIN;
    }
    return sdc_end(c, EF_ERR_TIMEOUT, 0);
}

/* No further retry for the pending transfer. */
void ef_sdo_client_no_retry(ef_sdo_client_t *c)
{
    if (c)
        c->tries = 2u;
}

/* Forget the pending transfer. */
void ef_sdo_client_abandon(ef_sdo_client_t *c)
{
    if (c && c->state != EF_SDOC_IDLE) {
        c->state = EF_SDOC_IDLE;
        c->held = 0;
        c->dup = 0;
        c->rc = EF_ERR_STATE;
        c->abort = 0;
    }
}

/* Whether a transfer is pending. */
int ef_sdo_client_busy(const ef_sdo_client_t *c)
{
    return c && c->state != EF_SDOC_IDLE;
}

/* Time left until the pending request times out. */
uint32_t ef_sdo_client_due_us(const ef_sdo_client_t *c, uint32_t now_us)
{
    if (!c || c->state == EF_SDOC_IDLE)
        return 0xFFFFFFFFu;
    uint32_t due = c->t0_us + c->timeout_us;
    return ef_time_reached(now_us, due) ? 0u : due - now_us;
}

/* An upload's first bytes. */
uint32_t ef_sdo_client_value(const ef_sdo_client_t *c)
{
    return c ? c->value : 0u;
}

/* Outcome of the last transfer (an upload's data from buf). */
int ef_sdo_client_result(const ef_sdo_client_t *c, uint32_t *abort, const uint8_t **data,
                         uint32_t *len)
{
    if (abort)
        *abort = 0;
    if (data)
        *data = NULL;
    if (len)
        *len = 0;
    if (!c)
        return EF_ERR_ARG;
    if (c->state != EF_SDOC_IDLE)
        return EF_ERR_AGAIN;
    if (abort)
        *abort = c->abort;
    if (c->rc == EF_OK && !c->write) {
        if (data)
            *data = c->buf;
        if (len)
            *len = c->got < EF_SDO_CLIENT_BUF ? c->got : EF_SDO_CLIENT_BUF;
    }
    return c->rc;
}
