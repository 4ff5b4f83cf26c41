/* SPDX-License-Identifier: Apache-2.0 */
/* CAN transmit queue with a per-queue drop policy (see ef_txq.h). */
#include <stddef.h>

#include "evenfeed/canopen/ef_txq.h"
#include "evenfeed/core/ef_err.h"

/* Ring slot of the i-th frame after the head. */
static uint32_t txq_at(const ef_txq_t *q, uint32_t i)
{
    return (q->head + i) % q->cap;
}

/* Remove entry k (0 = oldest), closing the gap so the order of the rest is kept. */
static void txq_remove(ef_txq_t *q, uint32_t k)
{
    for (uint32_t i = k; i + 1u < q->count && i + 1u < q->cap; i++) {
        uint32_t a = txq_at(q, i), b = txq_at(q, i + 1u);
        q->frame[a] = q->frame[b];
        q->stale[a] = q->stale[b];
    }
    q->count--;
}

/* Append f; a full queue gives up what its policy says. EF_OK or EF_ERR_FULL (a loss). */
static int txq_add(ef_txq_t *q, const ef_can_frame_t *f, int stale)
{
    int rc = EF_OK;
    if (q->count >= q->cap) {
        q->lost++;
        rc = EF_ERR_FULL;
        if (q->policy != EF_TXQ_DROP_STALE)
            return rc;
        uint32_t k = 0;
        while (k < q->count && !q->stale[txq_at(q, k)])
            k++;
        if (k >= q->count)
            return rc; /* only frames that must not go: the new one is the one lost */
        txq_remove(q, k);
    }
    uint32_t at = txq_at(q, q->count);
    q->frame[at] = *f;
    if (q->policy == EF_TXQ_DROP_STALE)
        q->stale[at] = stale ? 1u : 0u;
    q->count++;
    return rc;
}

/* Empty queue over the owner's arrays (contract in ef_txq.h). */
int ef_txq_init(ef_txq_t *q, ef_can_frame_t *frames, uint8_t *stale, uint32_t cap, int policy,
                int refused)
{
    if (!q || !frames || cap == 0u || cap > 0xFFFFu)
        return EF_ERR_ARG;
    if (policy != EF_TXQ_DROP_NEWEST && policy != EF_TXQ_DROP_STALE)
        return EF_ERR_ARG;
    if (refused != EF_TXQ_REFUSED_DROP && refused != EF_TXQ_REFUSED_KEEP)
        return EF_ERR_ARG;
    if (policy == EF_TXQ_DROP_STALE && !stale)
        return EF_ERR_ARG;
    *q = (ef_txq_t){0};
    q->frame = frames;
    q->stale = policy == EF_TXQ_DROP_STALE ? stale : NULL;
    q->cap = (uint16_t)cap;
    q->policy = (uint8_t)policy;
    q->refused = (uint8_t)refused;
    return EF_OK;
}

/* Port first while nothing waits (order is kept), else behind what waits. */
int ef_txq_send(ef_txq_t *q, const ef_can_port_t *port, const ef_can_frame_t *f, int stale)
{
    if (!q || !port || !f)
        return EF_ERR_ARG;
    int bus = 0;
    if (q->count == 0u) {
        int rc = port->send(port->ctx, f);
        if (rc == EF_OK) {
            q->sent++;
            return EF_OK;
        }
        if (rc == EF_ERR_AGAIN) {
            q->again++;
        } else if (rc == EF_ERR_BUS) {
            bus = 1; /* kept: a bus that recovers carries it */
        } else if (q->refused == EF_TXQ_REFUSED_DROP) {
            q->rejected++;
            return EF_OK;
        }
    }
    int rc = txq_add(q, f, stale);
    return bus ? EF_ERR_BUS : rc;
}

/* Retry waiting frames in order until the port is busy again. */
int ef_txq_flush(ef_txq_t *q, const ef_can_port_t *port)
{
    if (!q || !port)
        return EF_ERR_ARG;
    for (uint32_t i = 0; i < q->cap && q->count > 0u; i++) {
        int rc = port->send(port->ctx, &q->frame[q->head]);
        if (rc == EF_ERR_AGAIN) {
            q->again++;
            return rc;
        }
        if (rc == EF_ERR_BUS)
            return rc;
        if (rc == EF_OK)
            q->sent++;
        else if (q->refused == EF_TXQ_REFUSED_KEEP)
            return rc;
        else
            q->rejected++;
        q->head = (q->head + 1u) % q->cap;
        q->count--;
    }
    return q->count ? EF_ERR_AGAIN : EF_OK;
}

/* Free slots. */
uint32_t ef_txq_room(const ef_txq_t *q)
{
    return q ? q->cap - q->count : 0u;
}

/* Frames waiting. */
uint32_t ef_txq_count(const ef_txq_t *q)
{
    return q ? q->count : 0u;
}
