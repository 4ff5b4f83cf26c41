/* SPDX-License-Identifier: Apache-2.0 */
/* In-memory CAN bus in simulated time, its ports as CAN transports (see ef_canmem.h). */
#include "evenfeed/host/can/ef_canmem.h"

#include <errno.h>
#include <string.h>

/* One candump log line ("(sec.usec) NAME ID#DATA"), stamped with simulated time: a replay
 * with canplayer then runs at the simulation's pace, not the host's. */
static void cm_log(const ef_canmem_port_t *p, const ef_can_frame_t *f)
{
    uint64_t t = p->bus->now_us;
    unsigned dlc = f->dlc > EF_CAN_MAX_DLC ? EF_CAN_MAX_DLC : f->dlc;
    fprintf(p->log, "(%010llu.%06llu) %s ", (unsigned long long)(t / 1000000u),
            (unsigned long long)(t % 1000000u), p->name);
    if (f->flags & EF_CAN_FLAG_EFF)
        fprintf(p->log, "%08X#", (unsigned)(f->id & 0x1FFFFFFFu));
    else
        fprintf(p->log, "%03X#", (unsigned)(f->id & 0x7FFu));
    if (f->flags & EF_CAN_FLAG_RTR) {
        fputc('R', p->log);
        if (dlc)
            fputc("0123456789ABCDEF"[dlc], p -> log);
    } else {
        for (unsigned i = 0; i < dlc; i++)
            fprintf(p->log, "%02X", f->data[i]);
    }
    fputc('\n', p->log);
}

/* Whether port p's filters let f through. */
static int cm_match(const ef_canmem_port_t *p, const ef_can_frame_t *f)
{
    uint32_t id = f->id | ((f->flags & EF_CAN_FLAG_EFF) ? EF_CANIF_ID_EFF : 0u) |
                  ((f->flags & EF_CAN_FLAG_RTR) ? EF_CANIF_ID_RTR : 0u);
    if (p->n_flt == 0)
        return 1;
    for (int i = 0; i < p->n_flt; i++)
        if ((id & p->flt[i].mask) == (p->flt[i].id & p->flt[i].mask))
            return 1;
    return 0;
}

void ef_canmem_init(ef_canmem_t *b, uint32_t bitrate)
{
    memset(b, 0, sizeof *b);
    b->txcap = EF_CANMEM_QUEUE;
    b->bitrate = bitrate;
    for (int i = 0; i < EF_CANMEM_MAX_PORTS; i++) {
        b->port[i].bus = b;
        b->port[i].index = i;
    }
}

void ef_canmem_advance(ef_canmem_t *b, uint32_t dt_us)
{
    b->now_us += dt_us;
    if (b->bitrate)
        b->budget += (uint64_t)dt_us * b->bitrate / 1000000u;
}

/* The head frame on the wire: statistics, then into every other open port that wants it. */
static void cm_deliver_one(ef_canmem_t *b)
{
    ef_can_frame_t f = b->q[b->qhead];
    int src = b->qsrc[b->qhead];
    b->qhead = (b->qhead + 1u) % EF_CANMEM_QUEUE;
    b->qcount--;
    uint32_t bits = ef_can_frame_bits(&f);
    uint64_t n = b->frames++;
    b->bits += bits;
    b->frames_src[src]++;
    b->bits_src[src] += bits;
    b->frames_fn[(f.id >> 7) & 15u]++;
    b->bits_fn[(f.id >> 7) & 15u] += bits;
    if (b->drop && b->drop(b->drop_ctx, &f, src, n)) {
        b->dropped++;
        return;
    }
    for (int i = 0; i < EF_CANMEM_MAX_PORTS; i++) {
        ef_canmem_port_t *p = &b->port[i];
        if (i == src || !p->open || !cm_match(p, &f))
            continue;
        if (p->rx_count >= EF_CANMEM_RXQ) {
            p->rx_overrun++;
            continue;
        }
        uint32_t at = (p->rx_head + p->rx_count) % EF_CANMEM_RXQ;
        p->rxq[at] = f;
        p->rxts[at] = (uint32_t)b->now_us;
        p->rx_count++;
    }
}

void ef_canmem_deliver(ef_canmem_t *b)
{
    while (b->qcount > 0) {
        if (b->bitrate) {
            uint32_t bits = ef_can_frame_bits(&b->q[b->qhead]);
            if (b->budget < bits)
                return;
            b->budget -= bits;
        }
        cm_deliver_one(b);
    }
    b->budget = 0; /* an idle bus saves no time for later */
}

void ef_canmem_raise(ef_canmem_t *b, int k, uint32_t conditions)
{
    if (!b || k < 0 || k >= EF_CANMEM_MAX_PORTS)
        return;
    b->port[k].seen |= conditions;
    if (conditions & EF_CANIF_RESTARTED)
        b->port[k].seen &= ~EF_CANIF_BUS_OFF;
    b->port[k].err_frames++;
}

/* ---- A port as an ef_canif_t ---------------------------------------------------------- */

static int cm_open(void *ctx, const ef_canif_cfg_t *c, ef_msg_t *m)
{
    ef_canmem_port_t *p = ctx;
    if (!p)
        return ef_fail(m, EF_ERR_ARG, "canmem open: no such port");
    if (p->open)
        return ef_fail(m, EF_ERR_ARG, "canmem open %s: port %d already open", p->name, p->index);
    const char *name = c->name && c->name[0] ? c->name : "mem";
    if (c->n_filters < 0 || c->n_filters > EF_CANIF_MAX_FILTERS ||
        (c->n_filters > 0 && !c->filters))
        return ef_fail(m, EF_ERR_ARG, "canmem open %s: %d filters (0..%d, array needed)", name,
                       c->n_filters, EF_CANIF_MAX_FILTERS);
    snprintf(p->name, sizeof p->name, "%s", name);
    p->n_flt = c->n_filters;
    if (c->n_filters > 0)
        memcpy(p->flt, c->filters, sizeof p->flt[0] * (size_t)c->n_filters);
    p->log = NULL;
    if (c->log) {
        p->log = fopen(c->log, "w");
        if (!p->log)
            return ef_fail(m, EF_ERR_IO, "canmem open %s: candump log %s: %s", name, c->log,
                           strerror(errno));
    }
    p->rx_head = p->rx_count = 0;
    p->seen = p->err_frames = p->rx_overrun = p->tx_full = 0;
    p->tx = p->rx = p->tx_bits = 0;
    p->msg.text[0] = 0;
    p->open = 1;
    return EF_OK;
}

static void cm_close(void *ctx)
{
    ef_canmem_port_t *p = ctx;
    if (!p)
        return;
    if (p->log)
        fclose(p->log);
    p->log = NULL;
    p->open = 0;
    p->rx_count = 0;
}

static int cm_send(void *ctx, const ef_can_frame_t *f)
{
    ef_canmem_port_t *p = ctx;
    if (!p || !f || !p->open)
        return EF_ERR_ARG;
    ef_canmem_t *b = p->bus;
    if (f->dlc > EF_CAN_MAX_DLC)
        return ef_fail(&p->msg, EF_ERR_ARG, "canmem %s: send: dlc %u > 8", p->name, f->dlc);
    if (p->seen & EF_CANIF_BUS_OFF)
        return ef_fail(&p->msg, EF_ERR_BUS, "canmem %s: send: controller is bus-off", p->name);
    if (b->qcount >= b->txcap || b->qcount >= EF_CANMEM_QUEUE) {
        b->again++;
        p->tx_full++;
        return ef_fail(&p->msg, EF_ERR_AGAIN, "canmem %s: send: bus queue full", p->name);
    }
    uint32_t at = (b->qhead + b->qcount) % EF_CANMEM_QUEUE;
    b->q[at] = *f;
    b->qsrc[at] = (uint8_t)p->index;
    b->qcount++;
    if (b->qcount > b->max_queue)
        b->max_queue = b->qcount;
    p->tx++;
    p->tx_bits += ef_can_frame_bits(f);
    p->seen &= ~EF_CANIF_DOWN;
    if (p->log)
        cm_log(p, f);
    return EF_OK;
}

static int cm_recv(void *ctx, ef_can_frame_t *f, uint32_t *ts_us, uint32_t timeout_us)
{
    ef_canmem_port_t *p = ctx;
    (void)timeout_us; /* simulated time passes only through ef_canmem_advance() */
    if (!p || !f || !p->open)
        return EF_ERR_ARG;
    if (p->rx_count == 0)
        return EF_ERR_AGAIN;
    *f = p->rxq[p->rx_head];
    if (ts_us)
        *ts_us = p->rxts[p->rx_head];
    p->rx_head = (p->rx_head + 1u) % EF_CANMEM_RXQ;
    p->rx_count--;
    p->rx++;
    if (p->log)
        cm_log(p, f);
    return EF_OK;
}

static void cm_status(void *ctx, uint32_t clear, ef_canif_status_t *st)
{
    ef_canmem_port_t *p = ctx;
    if (!p)
        return;
    st->state = p->open ? ef_canif_state_of(p->seen) : EF_CANIF_STATE_STOPPED;
    st->seen = p->seen;
    st->err_frames = p->err_frames;
    st->tx_pending = 0;
    st->tx_full = p->tx_full;
    st->rx_overrun = p->rx_overrun;
    st->tec = st->rec = -1;
    st->tx = p->tx;
    st->rx = p->rx;
    st->tx_bits = p->tx_bits;
    p->seen &= ~clear;
}

static const char *cm_error(void *ctx)
{
    ef_canmem_port_t *p = ctx;
    return p ? p->msg.text : "canmem: no such port";
}

static uint32_t cm_now_us(void *ctx)
{
    ef_canmem_port_t *p = ctx;
    return p ? (uint32_t)p->bus->now_us : 0u;
}

static const ef_canif_ops_t cm_ops = {
    .name = "mem",
    .open = cm_open,
    .close = cm_close,
    .send = cm_send,
    .recv = cm_recv,
    .flush = NULL, /* a frame is either on the bus queue or refused: nothing is held */
    .status = cm_status,
    .error = cm_error,
    .now_us = cm_now_us,
};

ef_canif_t ef_canmem_canif(ef_canmem_t *b, int k)
{
    ef_canif_t ci = {&cm_ops, NULL};
    if (b && k >= 0 && k < EF_CANMEM_MAX_PORTS)
        ci.ctx = &b->port[k];
    return ci;
}
