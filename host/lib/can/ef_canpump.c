/* SPDX-License-Identifier: Apache-2.0 */
/* The one pump loop: a CAN protocol object on a CAN transport (see ef_canpump.h). */
#include "evenfeed/host/can/ef_canpump.h"

#include <string.h>

void ef_canpump_cfg_default(ef_canpump_cfg_t *c)
{
    memset(c, 0, sizeof *c);
    c->rx_burst = 64;
}

int ef_canpump_init(ef_canpump_t *p, const ef_canif_t *ci, const ef_canpump_node_t *node,
                    const ef_canpump_cfg_t *c)
{
    if (!p || !ci || !ci->ops || !node || !node->rx || !node->process)
        return EF_ERR_ARG;
    memset(p, 0, sizeof *p);
    p->ci = *ci;
    p->node = *node;
    if (c)
        p->cfg = *c;
    else
        ef_canpump_cfg_default(&p->cfg);
    if (p->cfg.rx_burst == 0)
        p->cfg.rx_burst = 1;
    p->t_prev = ef_canif_now_us(&p->ci);
    return EF_OK;
}

/* A transport error that is neither "nothing" nor "bus down" ends the pump. */
static int cp_check(ef_canpump_t *p, int rc)
{
    if (rc == EF_ERR_IO && !p->io_rc) {
        p->io_rc = EF_ERR_IO;
        ef_fail(&p->io_msg, EF_ERR_IO, "%s", ef_canif_error(&p->ci));
    }
    return p->io_rc;
}

/* Pass conditions the transport has newly seen to the node, once each. */
static void cp_bus(ef_canpump_t *p)
{
    ef_canif_status_t st;
    ef_canif_status(&p->ci, 0, &st);
    uint32_t bad = st.seen & EF_CANIF_BAD;
    if ((bad & ~p->reported) && p->node.bus) {
        p->reported |= bad;
        p->node.bus(p->node.obj, bad);
    }
    if (p->cfg.bus_clear && (st.seen & p->cfg.bus_clear))
        ef_canif_status(&p->ci, p->cfg.bus_clear, &st);
}

/* Hand one frame to the node. */
static void cp_hand(ef_canpump_t *p, const ef_can_frame_t *f, uint32_t ts)
{
    p->node.rx(p->node.obj, f, ts);
}

/* Receive one frame (counted); the transport's code. */
static int cp_recv(ef_canpump_t *p, ef_can_frame_t *f, uint32_t *ts, uint32_t wait_us)
{
    *ts = 0;
    int rc = ef_canif_recv(&p->ci, f, ts, wait_us);
    if (rc == EF_OK) {
        p->rx_frames++;
        p->rx_bits += ef_can_frame_bits(f);
    }
    return rc;
}

int ef_canpump_poll(ef_canpump_t *p, uint32_t max_wait_us)
{
    if (!p)
        return EF_ERR_ARG;
    if (p->io_rc)
        return p->io_rc;
    uint32_t now = ef_canif_now_us(&p->ci);
    uint32_t dt = now - p->t_prev;
    p->t_prev = now;
    p->t_us += dt;

    ef_can_frame_t f;
    uint32_t ts;
    int rc = EF_OK;
    for (uint32_t n = 0; n < p->cfg.rx_burst; n++) {
        if (p->have) {
            f = p->held;
            ts = p->held_ts;
            p->have = 0;
        } else {
            rc = cp_recv(p, &f, &ts, 0);
            if (rc != EF_OK)
                break;
        }
        cp_hand(p, &f, ts);
    }
    if (cp_check(p, rc))
        return p->io_rc;
    /* Error frames consumed with those frames reach the node before its time does: a master
     * that sends into a bus-off learns why from the condition (bus-off), not from a refused
     * frame without detail. */
    cp_bus(p);

    uint32_t next = max_wait_us;
    p->node.process(p->node.obj, dt, &next); /* errors are the node's to keep */
    if (cp_check(p, ef_canif_flush(&p->ci)))
        return p->io_rc;
    cp_bus(p);

    uint32_t wait = next < max_wait_us ? next : max_wait_us;
    if (p->cfg.pending_wait_us && wait > p->cfg.pending_wait_us) {
        ef_canif_status_t st;
        ef_canif_status(&p->ci, 0, &st);
        if (st.tx_pending > 0)
            wait = p->cfg.pending_wait_us;
    }
    rc = cp_recv(p, &p->held, &p->held_ts, wait);
    if (rc == EF_OK)
        p->have = 1;
    if (cp_check(p, rc))
        return p->io_rc;
    cp_bus(p); /* error frames the wait consumed: the node hears of them now */
    return EF_OK;
}

uint64_t ef_canpump_elapsed_us(const ef_canpump_t *p)
{
    return p->t_us + (uint32_t)(ef_canif_now_us(&p->ci) - p->t_prev);
}

int ef_canpump_error(const ef_canpump_t *p)
{
    return p ? p->io_rc : EF_ERR_ARG;
}

const char *ef_canpump_msg(const ef_canpump_t *p)
{
    return p && p->io_rc ? p->io_msg.text : "";
}

uint64_t ef_canpump_rx_frames(const ef_canpump_t *p)
{
    return p->rx_frames;
}

uint64_t ef_canpump_rx_bits(const ef_canpump_t *p)
{
    return p->rx_bits;
}

/* ---- Plain protocol objects as nodes ---------------------------------------------------- */

static int cp_m_rx(void *obj, const ef_can_frame_t *f, uint32_t ts_us)
{
    (void)ts_us;
    return ef_comaster_rx(obj, f);
}

static int cp_m_process(void *obj, uint32_t dt_us, uint32_t *next_us)
{
    return ef_comaster_process(obj, dt_us, next_us);
}

static void cp_m_bus(void *obj, uint32_t conditions)
{
    ef_comaster_bus_error(obj, conditions);
}

static int cp_d_rx(void *obj, const ef_can_frame_t *f, uint32_t ts_us)
{
    (void)ts_us;
    return ef_codrive_rx(obj, f);
}

static int cp_d_process(void *obj, uint32_t dt_us, uint32_t *next_us)
{
    return ef_codrive_process(obj, dt_us, next_us);
}

ef_canpump_node_t ef_canpump_master_node(ef_comaster_t *m)
{
    ef_canpump_node_t n = {cp_m_rx, cp_m_process, cp_m_bus, m};
    return n;
}

ef_canpump_node_t ef_canpump_drive_node(ef_codrive_t *d)
{
    ef_canpump_node_t n = {cp_d_rx, cp_d_process, NULL, d};
    return n;
}
