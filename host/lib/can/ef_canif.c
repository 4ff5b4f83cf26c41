/* SPDX-License-Identifier: Apache-2.0 */
/* Host CAN transport interface: the calls over a transport's ops (see ef_canif.h). */
#include <stddef.h>
#include <time.h>

#include "evenfeed/host/can/ef_canif.h"

/* Whether a transport has the mandatory ops. */
static int cif_usable(const ef_canif_t *ci)
{
    const ef_canif_ops_t *o = ci ? ci->ops : NULL;
    return o && o->open && o->close && o->send && o->recv && o->status;
}

uint32_t ef_canif_host_now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u);
}

int ef_canif_open(const ef_canif_t *ci, const ef_canif_cfg_t *c, ef_msg_t *m)
{
    if (!cif_usable(ci))
        return ef_fail(m, EF_ERR_ARG,
                       "CAN transport: no transport, or one without its "
                       "mandatory operations");
    if (!c)
        return ef_fail(m, EF_ERR_ARG, "CAN transport %s: no configuration", ci->ops->name);
    return ci->ops->open(ci->ctx, c, m);
}

void ef_canif_close(const ef_canif_t *ci)
{
    if (ci && ci->ops && ci->ops->close)
        ci->ops->close(ci->ctx);
}

int ef_canif_send(const ef_canif_t *ci, const ef_can_frame_t *f)
{
    if (!ci || !ci->ops || !ci->ops->send)
        return EF_ERR_ARG;
    return ci->ops->send(ci->ctx, f);
}

int ef_canif_recv(const ef_canif_t *ci, ef_can_frame_t *f, uint32_t *ts_us, uint32_t timeout_us)
{
    if (!ci || !ci->ops || !ci->ops->recv)
        return EF_ERR_ARG;
    return ci->ops->recv(ci->ctx, f, ts_us, timeout_us);
}

int ef_canif_flush(const ef_canif_t *ci)
{
    if (!ci || !ci->ops)
        return EF_ERR_ARG;
    return ci->ops->flush ? ci->ops->flush(ci->ctx) : EF_OK;
}

void ef_canif_status(const ef_canif_t *ci, uint32_t clear, ef_canif_status_t *st)
{
    static const ef_canif_status_t none = {.tec = -1, .rec = -1};
    if (!st)
        return;
    *st = none;
    if (ci && ci->ops && ci->ops->status)
        ci->ops->status(ci->ctx, clear, st);
}

const char *ef_canif_error(const ef_canif_t *ci)
{
    const char *e = (ci && ci->ops && ci->ops->error) ? ci->ops->error(ci->ctx) : NULL;
    return e ? e : "";
}

uint32_t ef_canif_now_us(const ef_canif_t *ci)
{
    if (ci && ci->ops && ci->ops->now_us)
        return ci->ops->now_us(ci->ctx);
    return ef_canif_host_now_us();
}

ef_can_port_t ef_canif_port(const ef_canif_t *ci)
{
    ef_can_port_t p = {NULL, NULL};
    if (ci && ci->ops) {
        p.send = ci->ops->send;
        p.ctx = ci->ctx;
    }
    return p;
}

const char *ef_canif_state_str(int state)
{
    switch (state) {
    case EF_CANIF_STATE_STOPPED:
        return "stopped";
    case EF_CANIF_STATE_ACTIVE:
        return "error-active";
    case EF_CANIF_STATE_WARNING:
        return "error-warning";
    case EF_CANIF_STATE_PASSIVE:
        return "error-passive";
    case EF_CANIF_STATE_BUS_OFF:
        return "bus-off";
    case EF_CANIF_STATE_DOWN:
        return "down";
    default:
        return "?";
    }
}

ef_canif_state_t ef_canif_state_of(uint32_t seen)
{
    if (seen & EF_CANIF_DOWN)
        return EF_CANIF_STATE_DOWN;
    if (seen & EF_CANIF_BUS_OFF)
        return EF_CANIF_STATE_BUS_OFF;
    if (seen & EF_CANIF_ERROR_PASSIVE)
        return EF_CANIF_STATE_PASSIVE;
    if (seen & EF_CANIF_ERROR_WARNING)
        return EF_CANIF_STATE_WARNING;
    return EF_CANIF_STATE_ACTIVE;
}
