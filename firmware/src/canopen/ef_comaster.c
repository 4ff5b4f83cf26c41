/* SPDX-License-Identifier: Apache-2.0 */
/* CANopen master for CiA 402 drives: bring-up, SYNC, CSP / segment streaming, supervision
 * and controlled stops (see ef_comaster.h; the wire protocol is docs/can.md).
 *
 * Structure: ef_comaster_rx() records what a frame says (SDO answers, TPDO1 status,
 * heartbeats, EMCY) and runs the state checks; ef_comaster_process() advances time, times
 * out, produces SYNC and sends each cycle's RPDOs right after it. All transmission goes
 * through com_send() and the TX queue (ef_txq.h), which keeps frame order (a frame waits
 * behind queued ones). The SDO client (ef_sdo_client.h) is an object of its own: it returns
 * the frames it needs sent, and the master acts on each transfer's outcome. The port's send
 * must not call back into ef_comaster_rx() (a bus simulation queues frames instead).
 *
 * State and sub-state (m->state, m->sub: the transition table is in ef_comaster.h) change
 * only in com_advance() (frames and time), com_timers() (timeouts) and the com_enter_*()
 * helpers; everything else reads them. */
#include "evenfeed/canopen/ef_comaster.h"
#include "evenfeed/core/ef_err.h"

/** Largest configuration sequence of one node (segment mode needs about 50 steps). */
#define COM_OPS_MAX 64
/** Segment mode: RPDO1 (controlword) is sent when it changes and at least this often
 *  (SYNCs), so a lost frame is repaired without a controlword every cycle. */
#define COM_CW_REFRESH 10u
/** next_us while frames wait in the TX queue: the port is retried this soon (us). */
#define COM_RETRY_US 200u
/** TPDO1s must be newer than the SYNC a command went out after by this many SYNCs before
 *  the master believes them: the RPDO is applied at the next SYNC and reported after it. */
#define COM_STALE_SYNCS 2u
/** A lost node (heartbeat silent) counts as gone from a stop only after this many SYNCs with
 *  no TPDO1 from it: a node that lost only its heartbeat (or whose heartbeats a starved
 *  master read late) is reachable, takes the quick stop and must reach rest before SYNC
 *  ends, since motion advances only at SYNC. */
#define COM_GONE_SYNCS (COM_STALE_SYNCS + 2u)
/** TPDO1 lengths per mode. */
#define COM_TPDO1_CSP_LEN 6u
#define COM_TPDO1_SEG_LEN 8u

/** Configuration step kinds. */
enum { OP_WRITE = 0, OP_READ = 1 };
/** What a read is checked against. */
enum { CK_NONE = 0, CK_EQ, CK_MASK, CK_IPU, CK_NAME };

/** One configuration step (an SDO transfer and what to do with its answer). */
typedef struct {
    uint16_t index;
    uint8_t sub;
    uint8_t kind;  /**< OP_* */
    uint8_t size;  /**< write: bytes 1, 2 or 4; read: bytes compared (0: all 4) */
    uint8_t check; /**< CK_* */
    uint8_t pad[2];
    uint32_t value; /**< write: the value; read: the expected value or mask */
} com_op_t;

/** One PDO of a mode's layout. */
typedef struct {
    uint16_t comm;  /**< 0x14xx / 0x18xx */
    uint16_t map;   /**< 0x16xx / 0x1Axx */
    uint32_t cobid; /**< with EF_CO_PDO_INVALID: leave disabled */
    uint8_t type;   /**< transmission type */
    uint8_t n;      /**< mapped entries */
    uint8_t pad[2];
    uint32_t ent[4]; /**< EF_CO_MAP entries */
} com_pdo_t;

/* Node index of a node id, -1 when it is none of ours. */
static int com_node_of(const ef_comaster_t *m, uint32_t id)
{
    for (int k = 0; k < m->cfg.n_nodes; k++)
        if (m->cfg.nodes[k] == id)
            return k;
    return -1;
}

/* Keep the first error: later ones are consequences, the first is what the user must see. */
static int com_error(ef_comaster_t *m, int code, int what, int k, uint16_t index, uint8_t sub)
{
    if (m->err.code == 0) {
        m->err.code = code;
        m->err.what = (uint8_t)what;
        m->err.node = (k >= 0) ? m->cfg.nodes[k] : 0u;
        m->err.index = index;
        m->err.sub = sub;
        if (k >= 0) {
            m->err.statusword = m->node[k].statusword;
            m->err.power = m->node[k].power;
        }
    }
    return code;
}

static void com_enter_stop(ef_comaster_t *m);

/* A port error: record it (first error kept) and stop under control; frames stay queued so
 * a bus that recovers carries the stop. */
static void com_bus_fail(ef_comaster_t *m, uint32_t detail)
{
    if (m->state == EF_COM_DONE || m->state == EF_COM_ERROR)
        return;
    if (m->err.code == 0) {
        com_error(m, EF_ERR_BUS, EF_COM_WHAT_BUS, -1, 0, 0);
        m->err.value = detail;
    }
    com_enter_stop(m);
}

/* Hand queued frames to the port in order until it is busy (frames refused outright leave
 * the queue: a retry would change nothing). */
static void com_flush(ef_comaster_t *m)
{
    if (ef_txq_flush(&m->txq, &m->port) == EF_ERR_BUS)
        com_bus_fail(m, 0);
}

/* Send a frame, or queue it behind frames still waiting (order matters: chunks of a record,
 * SYNC before the cycle's RPDOs). A full queue drops the frame (counted in txq.lost): what
 * is queued stays intact (ef_txq.h, EF_TXQ_DROP_NEWEST). */
static void com_send(ef_comaster_t *m, uint32_t id, const uint8_t *data, uint8_t dlc)
{
    ef_can_frame_t f;
    f.id = id;
    f.dlc = dlc;
    f.flags = 0;
    f.pad[0] = f.pad[1] = 0;
    for (uint32_t i = 0; i < EF_CAN_MAX_DLC; i++)
        f.data[i] = (i < dlc && data) ? data[i] : 0u;
    if (ef_txq_send(&m->txq, &m->port, &f, 0) == EF_ERR_BUS)
        com_bus_fail(m, 0);
}

/* Send what the SDO client asks for (dlc 0: nothing). */
static void com_sdo_send(ef_comaster_t *m, const ef_can_frame_t *f)
{
    if (f->dlc != 0u)
        com_send(m, f->id, f->data, f->dlc);
}

/* NMT command to all nodes (node 0). */
static void com_nmt(ef_comaster_t *m, uint8_t cmd)
{
    uint8_t d[2] = {cmd, 0u};
    com_send(m, EF_CO_COB_NMT, d, 2);
}

/* ------------------------------------------------------------------ configuration steps */

/* The PDO layout of a mode for node id (docs/can.md). */
static uint32_t com_pdos(const ef_comaster_t *m, uint8_t id, com_pdo_t p[5])
{
    for (int i = 0; i < 5; i++) {
        p[i].n = 0;
        p[i].type = 1;
        p[i].pad[0] = p[i].pad[1] = 0;
        for (int j = 0; j < 4; j++)
            p[i].ent[j] = 0;
    }
    p[0].comm = EF_CO_OBJ_RPDO_COMM;
    p[0].map = EF_CO_OBJ_RPDO_MAP;
    p[0].cobid = EF_CO_COB_RPDO1 + id;
    p[1].comm = EF_CO_OBJ_RPDO_COMM + 1u;
    p[1].map = EF_CO_OBJ_RPDO_MAP + 1u;
    p[1].cobid = EF_CO_COB_RPDO2 + id;
    p[2].comm = EF_CO_OBJ_RPDO_COMM + 2u;
    p[2].map = EF_CO_OBJ_RPDO_MAP + 2u;
    p[2].cobid = EF_CO_COB_RPDO3 + id;
    p[3].comm = EF_CO_OBJ_TPDO_COMM;
    p[3].map = EF_CO_OBJ_TPDO_MAP;
    p[3].cobid = EF_CO_COB_TPDO1 + id;
    p[4].comm = EF_CO_OBJ_TPDO_COMM + 1u;
    p[4].map = EF_CO_OBJ_TPDO_MAP + 1u;
    p[4].cobid = (EF_CO_COB_TPDO2 + id) | EF_CO_PDO_INVALID;
    p[0].ent[0] = EF_CO_MAP(EF_CO_OBJ_CONTROLWORD, 0, 16);
    p[3].ent[0] = EF_CO_MAP(EF_CO_OBJ_STATUSWORD, 0, 16);
    p[3].ent[1] = EF_CO_MAP(EF_CO_OBJ_POS_ACTUAL, 0, 32);
    if (m->cfg.mode == EF_COM_MODE_CSP) {
        p[0].ent[1] = EF_CO_MAP(EF_CO_OBJ_TARGET_POS, 0, 32);
        p[0].n = 2;
        p[1].cobid |= EF_CO_PDO_INVALID;
        p[2].cobid |= EF_CO_PDO_INVALID;
        p[3].n = 2;
    } else {
        p[0].n = 1;
        p[1].type = 255;
        p[1].n = 1;
        p[1].ent[0] = EF_CO_MAP(EF_CO_OBJ_SEG_AXIS, 0, 64);
        p[2].cobid = EF_CO_LAW_COBID;
        p[2].type = 255;
        p[2].n = 1;
        p[2].ent[0] = EF_CO_MAP(EF_CO_OBJ_SEG_LAW, 0, 64);
        p[3].ent[2] = EF_CO_MAP(EF_CO_OBJ_SEG_STATUS, EF_CO_SEGST_NEXT8, 8);
        p[3].ent[3] = EF_CO_MAP(EF_CO_OBJ_SEG_STATUS, EF_CO_SEGST_FREE, 8);
        p[3].n = 4;
    }
    return 5;
}

/* Append one step (bounded by COM_OPS_MAX: the layouts are fixed, this never truncates). */
static void com_op(com_op_t *ops, uint32_t *n, uint8_t kind, uint16_t index, uint8_t sub,
                   uint8_t size, uint8_t check, uint32_t value)
{
    if (*n >= COM_OPS_MAX)
        return;
    com_op_t *o = &ops[(*n)++];
    o->index = index;
    o->sub = sub;
    o->kind = kind;
    o->size = size;
    o->check = check;
    o->pad[0] = o->pad[1] = 0;
    o->value = value;
}

/* The whole configuration sequence of node k, rebuilt on demand (cheaper than storing it). */
static uint32_t com_ops(const ef_comaster_t *m, int k, com_op_t *ops)
{
    uint32_t n = 0;
    uint8_t id = m->cfg.nodes[k];
    int csp = m->cfg.mode == EF_COM_MODE_CSP;
    com_op(ops, &n, OP_READ, EF_CO_OBJ_DEVICE_TYPE, 0, 0, CK_EQ, EF_CO_DEVICE_TYPE_402);
    com_op(ops, &n, OP_READ, EF_CO_OBJ_SUPPORTED, 0, 0, CK_MASK, csp ? (1u << 7) : (1u << 16));
    com_op(ops, &n, OP_READ, EF_CO_OBJ_INC_PER_UNIT, 0, 0, CK_IPU, 0);
    com_op(ops, &n, OP_READ, EF_CO_OBJ_DEVICE_NAME, 0, 0, CK_NAME, 0);
    com_op(ops, &n, OP_WRITE, EF_CO_OBJ_HB_PRODUCER, 0, 2, CK_NONE, m->cfg.hb_producer_ms);
    com_op(ops, &n, OP_WRITE, EF_CO_OBJ_CYCLE, 0, 4, CK_NONE, m->cfg.cycle_us);
    com_op(ops, &n, OP_WRITE, EF_CO_OBJ_FERR_WINDOW, 0, 4, CK_NONE, m->cfg.ferr_window);
    com_pdo_t p[5];
    uint32_t np = com_pdos(m, id, p);
    for (uint32_t i = 0; i < np; i++) {
        /* Disable first: a drive refuses mapping changes of a valid PDO (CiA 301). */
        com_op(ops, &n, OP_WRITE, p[i].comm, 1, 4, CK_NONE, p[i].cobid | EF_CO_PDO_INVALID);
        if (p[i].cobid & EF_CO_PDO_INVALID)
            continue;
        com_op(ops, &n, OP_WRITE, p[i].comm, 2, 1, CK_NONE, p[i].type);
        com_op(ops, &n, OP_WRITE, p[i].map, 0, 1, CK_NONE, 0);
        for (uint8_t j = 0; j < p[i].n; j++)
            com_op(ops, &n, OP_WRITE, p[i].map, (uint8_t)(j + 1u), 4, CK_NONE, p[i].ent[j]);
        com_op(ops, &n, OP_WRITE, p[i].map, 0, 1, CK_NONE, p[i].n);
        /* The count is where a drive could silently differ from what was written. */
        com_op(ops, &n, OP_READ, p[i].map, 0, 1, CK_EQ, p[i].n);
        com_op(ops, &n, OP_WRITE, p[i].comm, 1, 4, CK_NONE, p[i].cobid);
    }
    uint8_t mode = (uint8_t)(int8_t)(csp ? EF_CO_MODE_CSP : EF_CO_MODE_SEGMENT);
    com_op(ops, &n, OP_WRITE, EF_CO_OBJ_MODE, 0, 1, CK_NONE, mode);
    com_op(ops, &n, OP_READ, EF_CO_OBJ_MODE_DISPLAY, 0, 1, CK_EQ, mode);
    return n;
}

/* ------------------------------------------------------------------ SDO client */

/* Begin configuration step op of node k (a write sends op->size bytes of op->value). */
static void com_sdo_start(ef_comaster_t *m, int k, const com_op_t *op)
{
    ef_can_frame_t out;
    m->sdo_user = 0;
    if (op->kind == OP_WRITE) {
        uint8_t b[4];
        ef_co_put32(b, op->value);
        (void)ef_sdo_client_download(&m->sdo, m->cfg.nodes[k], op->index, op->sub, b, op->size,
                                     m->now_us, &out); /* idle, sizes 1..4: cannot fail */
    } else {
        (void)ef_sdo_client_upload(&m->sdo, m->cfg.nodes[k], op->index, op->sub, m->now_us, &out);
    }
    com_sdo_send(m, &out);
}

/* An SDO failure: the caller's transfer keeps it as its result; at CONFIG (node cur) it is the
 * master's error, naming the node and the object. */
static void com_sdo_fail(ef_comaster_t *m, int code)
{
    int k = m->cur;
    if (m->sdo_user)
        return; /* the client keeps the outcome for ef_comaster_sdo_result() */
    if (m->cfg_restart) {
        /* The node rebooted under us: its answer (or silence) means nothing; start over. */
        m->cfg_restart = 0;
        m->op = 0;
        return;
    }
    const ef_sdo_client_t *c = &m->sdo;
    com_error(m, code, c->write ? EF_COM_WHAT_SDO_WRITE : EF_COM_WHAT_SDO_READ, k, c->index,
              c->sub);
    m->err.abort = c->abort;
    com_enter_stop(m);
}

/* The pending transfer completed: the caller's is done; a configuration step checks / keeps
 * its value, then the next step follows. */
static void com_sdo_done(ef_comaster_t *m)
{
    int k = m->cur;
    if (m->sdo_user)
        return;
    if (m->cfg_restart) {
        m->cfg_restart = 0;
        m->op = 0;
        return;
    }
    com_op_t ops[COM_OPS_MAX];
    uint32_t n = com_ops(m, k, ops);
    if (m->op >= n)
        return;
    const com_op_t *o = &ops[m->op];
    uint32_t v = o->kind == OP_READ ? ef_sdo_client_value(&m->sdo) : o->value;
    if (o->kind == OP_READ && o->size == 1u)
        v &= 0xFFu;
    int bad = 0;
    switch (o->check) {
    case CK_EQ:
        bad = v != o->value;
        break;
    case CK_MASK:
        bad = (v & o->value) != o->value;
        break;
    case CK_IPU:
        bad = v == 0u; /* positions could not be converted */
        if (!bad)
            m->node[k].inc_per_unit = v;
        break;
    case CK_NAME: {
        const uint8_t *data = 0;
        uint32_t len = 0;
        (void)ef_sdo_client_result(&m->sdo, 0, &data, &len); /* done: data, len <= the buffer */
        for (uint32_t i = 0; i < len && i < EF_COM_SDO_BUF; i++)
            m->name[k][i] = (char)data[i];
        m->name[k][len < EF_COM_SDO_BUF ? len : EF_COM_SDO_BUF] = '\0';
        break;
    }
    default:
        break;
    }
    if (bad) {
        com_error(m, EF_ERR_PROTO, EF_COM_WHAT_CHECK, k, o->index, o->sub);
        m->err.value = v;
        m->err.expected = o->value;
        com_enter_stop(m);
        return;
    }
    m->op++;
}

/* What a transfer's step ended in: done, failed (PROTO, TIMEOUT), or still pending. */
static void com_sdo_outcome(ef_comaster_t *m, int rc)
{
    if (rc == EF_OK)
        com_sdo_done(m);
    else if (rc == EF_ERR_PROTO || rc == EF_ERR_TIMEOUT)
        com_sdo_fail(m, rc);
}

/* An SDO answer for the pending transfer from node q (routed here by its COB-ID): one that
 * is not 8 bytes is counted against the node, and fails the transfer. */
static void com_sdo_frame(ef_comaster_t *m, ef_com_node_t *q, const ef_can_frame_t *f)
{
    ef_can_frame_t out;
    if (f->dlc != 8u)
        q->rx_bad++;
    int rc = ef_sdo_client_rx(&m->sdo, f, m->now_us, &out);
    com_sdo_send(m, &out);
    com_sdo_outcome(m, rc);
}

/* SDO timeout: one retry of the whole transfer, then the transfer fails (at CONFIG an error
 * naming node and object). */
static void com_sdo_timer(ef_comaster_t *m)
{
    ef_can_frame_t out;
    int rc = ef_sdo_client_process(&m->sdo, m->now_us, &out);
    com_sdo_send(m, &out);
    com_sdo_outcome(m, rc);
}

/* ------------------------------------------------------------------ state changes */

/* Start SYNC production: the drives' time begins. */
static void com_sync_start(ef_comaster_t *m)
{
    m->sync_on = 1;
    m->sync_acc_us = m->cfg.cycle_us; /* first SYNC at the next process() call */
}

/* Shared final step: SHUTDOWN every node, wait for operation disabled. */
static void com_enter_shutdown(ef_comaster_t *m)
{
    m->sub = EF_COM_SUB_SHUTDOWN;
    m->t_step_us = m->now_us;
    m->mark_sync = m->sync_count;
}

/* The end: DONE after a clean finish or a requested stop, ERROR after an error. */
static void com_enter_final(ef_comaster_t *m)
{
    m->state = (uint8_t)(m->err.code ? EF_COM_ERROR : EF_COM_DONE);
    m->sync_on = 0;
    if (!m->sdo_user)
        ef_sdo_client_abandon(&m->sdo); /* a configuration step ends; the caller's goes on */
}

/* Controlled stop: quick stop every enabled node while SYNC keeps running (drives move
 * only at SYNC); before any drive was started there is nothing to stop. */
static void com_enter_stop(ef_comaster_t *m)
{
    if (m->state == EF_COM_STOPPING || m->state == EF_COM_DONE || m->state == EF_COM_ERROR)
        return;
    if (m->state < EF_COM_START || !m->sync_on) {
        com_enter_final(m);
        return;
    }
    m->state = EF_COM_STOPPING;
    m->sub = EF_COM_SUB_STOP_RAMP;
    m->t_step_us = m->now_us;
    m->mark_sync = m->sync_count;
    if (!m->sdo_user)
        ef_sdo_client_abandon(&m->sdo);
}

/* Whether node k's latest TPDO1 reports the drive after the current wait began. */
static int com_fresh(const ef_comaster_t *m, int k)
{
    return m->node[k].seen_tpdo &&
           (int32_t)(m->node[k].tpdo_sync - m->mark_sync) >= (int32_t)COM_STALE_SYNCS;
}

/* Whether lost node k is out of reach for the current wait: no TPDO1 from it for
 * COM_GONE_SYNCS SYNCs since the wait began (a node still talking is waited for). */
static int com_gone(const ef_comaster_t *m, int k)
{
    return m->lost[k] && !com_fresh(m, k) && m->sync_count - m->mark_sync >= COM_GONE_SYNCS &&
           (!m->node[k].seen_tpdo ||
            (int32_t)(m->sync_count - m->node[k].tpdo_sync) >= (int32_t)COM_GONE_SYNCS);
}

/* Enter RUN: CSP holds the actual positions; segment mode numbers from 0 (the drives
 * cleared their queues entering OPERATION ENABLED). */
static void com_enter_run(ef_comaster_t *m)
{
    m->state = EF_COM_RUN;
    m->sub = EF_COM_SUB_NONE;
    m->tq_head = m->tq_count = 0;
    m->sq_head = m->sq_count = m->sq_base = m->sent_to = m->next_seq = 0;
    m->running = 0;
    m->seg_cap = EF_COM_SEGQ;
    for (int k = 0; k < m->cfg.n_nodes; k++) {
        m->resend_run[k] = 0;
        m->node[k].next_seq = 0;
        m->last_progress_sync[k] = m->sync_count;
        if (m->node[k].free < m->seg_cap)
            m->seg_cap = m->node[k].free;
    }
    if (m->seg_cap == 0u)
        m->seg_cap = 1u;
}

/* State checks that need no time step (run after every frame and every process call). */
static void com_advance(ef_comaster_t *m)
{
    int n = m->cfg.n_nodes;
    switch (m->state) {
    case EF_COM_BOOT: {
        int all = 1;
        for (int k = 0; k < n; k++)
            all &= m->node[k].nmt != 0xFFu;
        if (all) {
            m->state = EF_COM_CONFIG;
            m->sub = EF_COM_SUB_NONE;
            m->cur = 0;
            m->op = 0;
            m->cfg_restart = 0;
            m->t_step_us = m->now_us;
        }
        break;
    }
    case EF_COM_CONFIG: {
        /* Bounded: each pass either starts a transfer or moves to the next node. */
        for (int guard = 0; guard <= n && !ef_sdo_client_busy(&m->sdo) && m->state == EF_COM_CONFIG;
             guard++) {
            if (m->cur >= n) {
                m->state = EF_COM_START;
                m->t_step_us = m->now_us;
                for (int k = 0; k < n; k++) {
                    m->node[k].hb_age_us = 0;
                    m->node[k].seen_tpdo = 0;
                }
                com_nmt(m, EF_CO_NMT_START);
                com_sync_start(m);
                break;
            }
            com_op_t ops[COM_OPS_MAX];
            uint32_t cnt = com_ops(m, m->cur, ops);
            if (m->op < cnt) {
                com_sdo_start(m, m->cur, &ops[m->op]);
                break;
            }
            m->cur++;
            m->op = 0;
        }
        break;
    }
    case EF_COM_START: {
        int all = 1;
        for (int k = 0; k < n; k++)
            all &= m->node[k].seen_tpdo != 0;
        if (all) {
            m->state = EF_COM_ENABLE;
            m->t_step_us = m->now_us;
            for (int k = 0; k < n; k++) {
                m->t_node_us[k] = m->now_us;
                m->last_power[k] = m->node[k].power;
            }
        }
        break;
    }
    case EF_COM_ENABLE: {
        int all = 1;
        for (int k = 0; k < n; k++)
            all &= m->node[k].power == EF_CO_PS_OP_ENABLED;
        if (all)
            com_enter_run(m);
        break;
    }
    case EF_COM_FINISH:
    case EF_COM_STOPPING: {
        if (m->sub != EF_COM_SUB_SHUTDOWN && m->state == EF_COM_FINISH) {
            /* DRAIN: everything acknowledged / sent and every node idle at its end; in
             * segment mode RUN_OFF then clears the run bit and waits for bit 12 to clear
             * (the drive leaves its running state; at rest that is no stop). */
            int drain = m->sub == EF_COM_SUB_FINISH_DRAIN;
            int done = 1;
            for (int k = 0; k < n; k++) {
                const ef_com_node_t *q = &m->node[k];
                done &= com_fresh(m, k) && (q->statusword & EF_CO_SW_TARGET_REACHED) &&
                        (drain || !(q->statusword & EF_CO_SW_FOLLOWING));
            }
            if (m->cfg.mode == EF_COM_MODE_CSP)
                done &= m->tq_count == 0;
            else if (drain)
                done &= m->running && m->sq_count == 0;
            if (done && m->cfg.mode == EF_COM_MODE_SEGMENT && drain) {
                m->sub = EF_COM_SUB_FINISH_RUN_OFF;
                m->running = 0;
                m->t_step_us = m->now_us;
                m->mark_sync = m->sync_count;
            } else if (done) {
                com_enter_shutdown(m);
            }
        } else if (m->sub == EF_COM_SUB_STOP_RAMP) {
            int rest = 1;
            for (int k = 0; k < n; k++) {
                const ef_com_node_t *q = &m->node[k];
                int p = q->power;
                rest &=
                    com_gone(m, k) ||
                    (com_fresh(m, k) && (p == EF_CO_PS_SWITCH_ON_DISABLED || p == EF_CO_PS_FAULT ||
                                         (q->statusword & EF_CO_SW_TARGET_REACHED)));
            }
            if (rest)
                com_enter_shutdown(m);
        } else {
            int off = 1;
            for (int k = 0; k < n; k++) {
                int p = m->node[k].power;
                off &= com_gone(m, k) || (com_fresh(m, k) && p != EF_CO_PS_OP_ENABLED &&
                                          p != EF_CO_PS_QUICK_STOP && p != EF_CO_PS_FAULT_REACTION);
            }
            if (off)
                com_enter_final(m);
        }
        break;
    }
    default:
        break;
    }
}

/* ------------------------------------------------------------------ cycle (after SYNC) */

/* The controlword of node k for this cycle, from its last reported power state. */
static uint16_t com_cw(ef_comaster_t *m, int k)
{
    const ef_com_node_t *q = &m->node[k];
    uint16_t prev = m->cw[k];
    switch (m->state) {
    case EF_COM_ENABLE:
        switch (q->power) {
        case EF_CO_PS_FAULT:
            /* Only reached with fault_reset (else the TPDO raised an error): an edge of
             * bit 7 needs a cycle with it clear first. */
            return (prev & EF_CO_CW_FAULT_RESET) ? EF_CO_CW_DISABLE_VOLTAGE : EF_CO_CW_FAULT_RESET;
        case EF_CO_PS_SWITCH_ON_DISABLED:
            return EF_CO_CW_SHUTDOWN;
        case EF_CO_PS_READY:
            return EF_CO_CW_SWITCH_ON;
        case EF_CO_PS_SWITCHED_ON:
        case EF_CO_PS_OP_ENABLED:
            return EF_CO_CW_ENABLE_OP;
        case EF_CO_PS_QUICK_STOP:
            return EF_CO_CW_DISABLE_VOLTAGE;
        default:
            return prev;
        }
    case EF_COM_RUN:
    case EF_COM_FINISH:
        if (m->sub == EF_COM_SUB_SHUTDOWN)
            break;
        return (uint16_t)(EF_CO_CW_ENABLE_OP | (m->running ? EF_CO_CW_SEG_RUN : 0u) |
                          (m->halt ? EF_CO_CW_HALT : 0u));
    case EF_COM_STOPPING:
        if (m->sub == EF_COM_SUB_SHUTDOWN)
            break;
        if (q->power == EF_CO_PS_FAULT || q->power == EF_CO_PS_FAULT_REACTION)
            return prev;
        if (q->power == EF_CO_PS_OP_ENABLED || q->power == EF_CO_PS_QUICK_STOP)
            return EF_CO_CW_QUICK_STOP;
        /* Not enabled (yet): hold it there, nothing moves. */
        return EF_CO_CW_SHUTDOWN;
    default:
        return EF_CO_CW_DISABLE_VOLTAGE;
    }
    /* Final SHUTDOWN (FINISH/STOPPING sub SHUTDOWN): quick stop active needs disable voltage. */
    if (q->power == EF_CO_PS_QUICK_STOP)
        return EF_CO_CW_DISABLE_VOLTAGE;
    if (q->power == EF_CO_PS_FAULT || q->power == EF_CO_PS_FAULT_REACTION)
        return prev;
    return EF_CO_CW_SHUTDOWN;
}

/* CSP: each node's RPDO1 (controlword, target) for this cycle. */
static void com_cycle_csp(ef_comaster_t *m)
{
    int n = m->cfg.n_nodes;
    int feed = m->state == EF_COM_RUN || m->sub == EF_COM_SUB_FINISH_DRAIN;
    if (feed && m->tq_count > 0) {
        for (int k = 0; k < n; k++) {
            int32_t inc;
            /* Checked at push: cannot fail. */
            if (ef_co_pos_to_inc(m->tq[m->tq_head][k], m->node[k].inc_per_unit, &inc) == EF_OK)
                m->last_target[k] = inc;
        }
        m->tq_head = (m->tq_head + 1u) % EF_COM_TARGETQ;
        m->tq_count--;
        if (m->tq_count == 0 && m->state == EF_COM_FINISH)
            m->mark_sync = m->sync_count; /* the last target: wait for TPDOs after it */
    } else if (m->state == EF_COM_RUN) {
        m->starved++;
    }
    for (int k = 0; k < n; k++) {
        if (!m->node[k].seen_tpdo)
            continue; /* its state is unknown: command nothing */
        if (m->state < EF_COM_RUN && m->node[k].power != EF_CO_PS_OP_ENABLED)
            m->last_target[k] = m->node[k].pos_inc; /* the first target is where it is */
        m->cw[k] = com_cw(m, k);
        uint8_t d[6];
        ef_co_put16(&d[0], m->cw[k]);
        ef_co_put32(&d[2], (uint32_t)m->last_target[k]);
        com_send(m, EF_CO_COB_RPDO1 + m->cfg.nodes[k], d, 6);
    }
}

/* Segment mode: frames one segment needs (law chunks once, axis chunks per node). */
static uint32_t com_seg_frames(const ef_comaster_t *m, const ef_move_t *mv)
{
    uint8_t rec[EF_CO_REC_MAX];
    uint32_t len = 0, frames = 0;
    if (ef_co_law_encode(mv, rec, &len) == EF_OK)
        frames += ef_co_chunk_count(len);
    for (int k = 0; k < m->cfg.n_nodes; k++)
        if (ef_co_axis_encode(mv, k, rec, &len) == EF_OK)
            frames += ef_co_chunk_count(len);
    return frames;
}

/* Segment mode: send segment seq (law record on the shared COB-ID, each node its axis). */
static void com_seg_send(ef_comaster_t *m, const ef_move_t *mv)
{
    uint8_t rec[EF_CO_REC_MAX], d[8];
    uint32_t len = 0;
    if (ef_co_law_encode(mv, rec, &len) == EF_OK)
        for (uint32_t c = 0; c < ef_co_chunk_count(len) && c < EF_CO_CHUNKS_MAX; c++) {
            ef_co_chunk(rec, len, c, d);
            com_send(m, EF_CO_LAW_COBID, d, 8);
        }
    for (int k = 0; k < m->cfg.n_nodes; k++) {
        if (ef_co_axis_encode(mv, k, rec, &len) != EF_OK)
            continue;
        for (uint32_t c = 0; c < ef_co_chunk_count(len) && c < EF_CO_CHUNKS_MAX; c++) {
            ef_co_chunk(rec, len, c, d);
            com_send(m, EF_CO_COB_RPDO2 + m->cfg.nodes[k], d, 8);
        }
    }
}

/* Segment mode: go-back-N when a node has not advanced for resend_cycles SYNCs. */
static void com_gobackn(ef_comaster_t *m)
{
    if (m->port_pending > 0 || ef_txq_count(&m->txq) > 0) {
        /* Frames still on their way out: no progress is no sign of a loss yet. */
        for (int k = 0; k < m->cfg.n_nodes; k++)
            m->last_progress_sync[k] = m->sync_count;
        return;
    }
    int stalled = 0;
    for (int k = 0; k < m->cfg.n_nodes; k++) {
        ef_com_node_t *q = &m->node[k];
        if (q->next_seq >= m->sent_to)
            continue;
        if (m->sync_count - m->last_progress_sync[k] < m->cfg.resend_cycles)
            continue;
        q->resends++;
        m->last_progress_sync[k] = m->sync_count;
        /* Only rounds without progress count towards giving up: a long program on a lossy
         * or slow bus may need many rounds in all, each of which recovered. */
        if (++m->resend_run[k] > m->cfg.max_resends)
            stalled = 2;
        else if (!stalled)
            stalled = 1;
    }
    if (!stalled)
        return;
    m->resends++;
    if (stalled == 2) {
        com_error(m, EF_ERR_PROTO, EF_COM_WHAT_STREAM, -1, 0, 0);
        m->err.value = m->sq_base;
        com_enter_stop(m);
        return;
    }
    /* Everything from the oldest unacknowledged segment again: drives ignore duplicates. */
    m->sent_to = m->sq_base;
}

/* Segment mode: this cycle's controlword (when changed / refreshed) and segments. */
static void com_cycle_seg(ef_comaster_t *m)
{
    int n = m->cfg.n_nodes;
    int feed = m->state == EF_COM_RUN || m->sub == EF_COM_SUB_FINISH_DRAIN;
    if (feed) {
        /* Start when prefill is acknowledged, or everything is after finish(). */
        uint32_t want = m->cfg.prefill < m->seg_cap ? m->cfg.prefill : m->seg_cap;
        if (!m->running && (m->sq_base >= want || (m->finishing && m->sq_count == 0))) {
            m->running = 1;
            m->mark_sync = m->sync_count; /* FINISH believes only TPDOs after the start */
        }
    }
    int changed = 0;
    for (int k = 0; k < n; k++) {
        if (!m->node[k].seen_tpdo)
            continue;
        m->cw[k] = com_cw(m, k);
        changed |= m->cw[k] != m->cw_sent[k];
    }
    m->cw_age++;
    /* During the power-state steps every cycle (START included): they are short and each
     * step matters. */
    if (changed || m->cw_age >= COM_CW_REFRESH || m->state == EF_COM_START ||
        m->state == EF_COM_ENABLE || m->state == EF_COM_STOPPING || m->sub == EF_COM_SUB_SHUTDOWN) {
        m->cw_age = 0;
        for (int k = 0; k < n; k++) {
            if (!m->node[k].seen_tpdo)
                continue;
            uint8_t d[2];
            ef_co_put16(d, m->cw[k]);
            com_send(m, EF_CO_COB_RPDO1 + m->cfg.nodes[k], d, 2);
            m->cw_sent[k] = m->cw[k];
        }
    }
    if (!feed)
        return;
    com_gobackn(m);
    if (m->state == EF_COM_STOPPING)
        return;
    for (uint32_t i = 0; i < m->cfg.seg_per_cycle && m->sent_to < m->next_seq; i++) {
        for (int k = 0; k < n; k++) {
            const ef_com_node_t *q = &m->node[k];
            int32_t credit = (int32_t)q->free - (int32_t)(m->sent_to - q->next_seq);
            if (credit <= 0)
                return;
        }
        const ef_move_t *mv = &m->sq[(m->sq_head + (m->sent_to - m->sq_base)) % EF_COM_SEGQ];
        if (com_seg_frames(m, mv) > ef_txq_room(&m->txq))
            return;
        for (int k = 0; k < n; k++)
            if (m->node[k].next_seq == m->sent_to)
                m->last_progress_sync[k] = m->sync_count; /* its wait begins now */
        com_seg_send(m, mv);
        m->sent_to++;
    }
}

/* One SYNC and the cycle's RPDOs right after it (the drives apply them at the next SYNC). */
static void com_cycle(ef_comaster_t *m)
{
    com_send(m, EF_CO_COB_SYNC, 0, 0);
    m->sync_count++;
    if (m->cfg.mode == EF_COM_MODE_CSP)
        com_cycle_csp(m);
    else
        com_cycle_seg(m);
}

/* ------------------------------------------------------------------ received frames */

/* Segment mode: extend the node's 8-bit next sequence number and retire acknowledged moves. */
static void com_seg_status(ef_comaster_t *m, int k, uint8_t next8, uint8_t free)
{
    ef_com_node_t *q = &m->node[k];
    q->free = free;
    if (m->state != EF_COM_RUN && m->state != EF_COM_FINISH)
        return;
    uint32_t ext = q->next_seq + (uint8_t)(next8 - (uint8_t)q->next_seq);
    if (ext > m->next_seq) {
        q->rx_bad++; /* acknowledges something never sent: ignore it */
        return;
    }
    if (ext != q->next_seq) {
        q->next_seq = ext;
        m->last_progress_sync[k] = m->sync_count;
        m->resend_run[k] = 0;
    }
    uint32_t lo = 0xFFFFFFFFu;
    for (int j = 0; j < m->cfg.n_nodes; j++)
        if (m->node[j].next_seq < lo)
            lo = m->node[j].next_seq;
    while (m->sq_base < lo && m->sq_count > 0) {
        m->sq_head = (m->sq_head + 1u) % EF_COM_SEGQ;
        m->sq_count--;
        m->sq_base++;
    }
    if (m->sent_to < m->sq_base)
        m->sent_to = m->sq_base;
}

/* TPDO1: the node's statusword and position (the only source of its drive state). */
static void com_tpdo1(ef_comaster_t *m, int k, const ef_can_frame_t *f)
{
    ef_com_node_t *q = &m->node[k];
    uint8_t want = m->cfg.mode == EF_COM_MODE_CSP ? COM_TPDO1_CSP_LEN : COM_TPDO1_SEG_LEN;
    if (f->dlc != want) {
        q->rx_bad++;
        return;
    }
    if (m->state < EF_COM_START || m->state >= EF_COM_DONE)
        return;
    q->statusword = ef_co_get16(&f->data[0]);
    q->power = (uint8_t)ef_co_power_state(q->statusword);
    q->pos_inc = (int32_t)ef_co_get32(&f->data[2]);
    q->pos = ef_co_inc_to_pos(q->pos_inc, q->inc_per_unit);
    q->seen_tpdo = 1;
    q->tpdo_sync = m->sync_count;
    if (m->cfg.mode == EF_COM_MODE_SEGMENT)
        com_seg_status(m, k, f->data[6], f->data[7]);
    if (m->state == EF_COM_ENABLE && q->power != m->last_power[k]) {
        m->last_power[k] = q->power; /* a step was made: its timer starts again */
        m->t_node_us[k] = m->now_us;
    }
    int fault = q->power == EF_CO_PS_FAULT || q->power == EF_CO_PS_FAULT_REACTION;
    int tolerate = m->cfg.fault_reset && (m->state == EF_COM_START || m->state == EF_COM_ENABLE);
    if (fault && !tolerate) {
        com_error(m, EF_ERR_DRIVE, EF_COM_WHAT_FAULT, k, 0, 0);
        com_enter_stop(m);
    }
}

/* Heartbeat or boot-up of node k. */
static void com_heartbeat(ef_comaster_t *m, int k, const ef_can_frame_t *f)
{
    ef_com_node_t *q = &m->node[k];
    if (f->dlc != 1u) {
        q->rx_bad++;
        return;
    }
    uint8_t st = f->data[0];
    q->hb_age_us = 0;
    q->hb_fresh = 1;
    if (st == EF_CO_NMT_BOOTUP) {
        if (m->state == EF_COM_CONFIG && k >= m->cur) {
            /* Booted again before we configured it (a power-up racing our reset
             * communication): configure it from the start. */
            if (k == m->cur && (ef_sdo_client_busy(&m->sdo) || m->op > 0)) {
                if (ef_sdo_client_busy(&m->sdo)) {
                    m->cfg_restart = 1;
                    ef_sdo_client_no_retry(&m->sdo); /* a retry would ask a node that forgot */
                } else {
                    m->op = 0;
                }
            }
        } else if (m->state >= EF_COM_CONFIG && m->state < EF_COM_DONE) {
            com_error(m, EF_ERR_DRIVE, EF_COM_WHAT_RESTART, k, 0, 0);
            com_enter_stop(m);
        }
        q->nmt = EF_CO_NMT_PREOPERATIONAL;
        return;
    }
    /* After our reset communication only a boot-up proves the node heard it. */
    if (m->state == EF_COM_BOOT && m->cfg.reset_comm)
        return;
    q->nmt = st;
}

/* EMCY of node k: a non-zero code is a drive error (code 0 only reports a reset). */
static void com_emcy(ef_comaster_t *m, int k, const ef_can_frame_t *f)
{
    ef_com_node_t *q = &m->node[k];
    if (f->dlc != 8u) {
        q->rx_bad++;
        return;
    }
    uint16_t code = ef_co_get16(&f->data[0]);
    q->last_emcy = code;
    if (code == EF_CO_EMCY_NONE)
        return;
    q->emcy_count++;
    if (m->state == EF_COM_BOOT || m->state >= EF_COM_DONE)
        return;
    if (m->err.code == 0) {
        com_error(m, EF_ERR_DRIVE, EF_COM_WHAT_EMCY, k, 0, 0);
        m->err.emcy = code;
        m->err.drive_fault = f->data[3];
        m->err.value = ef_co_get32(&f->data[4]); /* the drive's SYNC count at the fault */
    }
    com_enter_stop(m);
}

/* ------------------------------------------------------------------ public API */

/* Defaults of ef_comaster.h; the cycle depends on the mode. */
void ef_comaster_cfg_default(ef_com_cfg_t *c, int mode)
{
    if (!c)
        return;
    for (int k = 0; k < EF_COM_MAX_NODES; k++)
        c->nodes[k] = 0;
    c->n_nodes = 0;
    c->mode = (uint8_t)mode;
    c->reset_comm = 1;
    c->fault_reset = 0;
    c->cycle_us = mode == EF_COM_MODE_SEGMENT ? 10000u : 1000u;
    c->hb_producer_ms = 50;
    c->hb_timeout_ms = 200;
    c->boot_timeout_ms = 3000;
    c->sdo_timeout_ms = 200;
    c->enable_timeout_ms = 1000;
    c->stop_timeout_ms = 5000;
    c->ferr_window = 10000;
    c->seg_per_cycle = 4;
    c->resend_cycles = 3;
    c->prefill = 8;
    c->pad = 0;
    c->max_resends = 50;
}

/* Validate the configuration, reset everything, begin BOOT. */
int ef_comaster_init(ef_comaster_t *m, const ef_com_cfg_t *c, const ef_can_port_t *port)
{
    if (!m || !c || !port || !port->send)
        return EF_ERR_ARG;
    if (c->n_nodes == 0 || c->n_nodes > EF_COM_MAX_NODES)
        return EF_ERR_ARG;
    if (c->mode != EF_COM_MODE_CSP && c->mode != EF_COM_MODE_SEGMENT)
        return EF_ERR_ARG;
    if (c->mode == EF_COM_MODE_SEGMENT && (c->n_nodes > EF_AXES || c->seg_per_cycle == 0))
        return EF_ERR_ARG; /* one node per axis: x, y, z, then A B C U V W */
    if (c->cycle_us == 0 || c->hb_timeout_ms == 0 || c->boot_timeout_ms == 0 ||
        c->sdo_timeout_ms == 0 || c->enable_timeout_ms == 0 || c->stop_timeout_ms == 0)
        return EF_ERR_ARG;
    for (int k = 0; k < c->n_nodes; k++) {
        if (c->nodes[k] < 1u || c->nodes[k] > 127u)
            return EF_ERR_ARG;
        for (int j = 0; j < k; j++)
            if (c->nodes[j] == c->nodes[k])
                return EF_ERR_ARG;
    }
    uint8_t *b = (uint8_t *)m;
    for (uint32_t i = 0; i < sizeof *m; i++)
        b[i] = 0;
    m->cfg = *c;
    m->port = *port;
    for (int k = 0; k < c->n_nodes; k++) {
        ef_com_node_t *q = &m->node[k];
        q->id = c->nodes[k];
        q->nmt = 0xFFu;
        q->power = EF_CO_PS_NOT_READY;
        q->inc_per_unit = EF_CO_INC_PER_UNIT;
    }
    /* Cannot fail: the timeout was checked above. */
    (void)ef_sdo_client_init(&m->sdo, c->sdo_timeout_ms * 1000u);
    (void)ef_txq_init(&m->txq, m->txq_buf, 0, EF_COM_TXQ, EF_TXQ_DROP_NEWEST, EF_TXQ_REFUSED_DROP);
    m->state = EF_COM_BOOT;
    m->sub = EF_COM_SUB_BOOT_RESET; /* the first process() call sends the reset, starts the timer */
    return EF_OK;
}

/* Dispatch one frame by function code; only our nodes' producer identifiers matter. */
int ef_comaster_rx(ef_comaster_t *m, const ef_can_frame_t *f)
{
    if (!m || !f)
        return EF_ERR_ARG;
    m->rx_frames++;
    if (f->flags & (EF_CAN_FLAG_RTR | EF_CAN_FLAG_EFF))
        return EF_OK;
    if (m->state == EF_COM_IDLE)
        return EF_OK;
    if (m->state == EF_COM_DONE || m->state == EF_COM_ERROR) {
        /* After the end only the caller's SDO transfer goes on; everything else is ignored. */
        int j = com_node_of(m, m->sdo.node);
        if (ef_sdo_client_busy(&m->sdo) && j >= 0 && f->id == EF_CO_COB_SDO_TX + m->sdo.node)
            com_sdo_frame(m, &m->node[j], f);
        return EF_OK;
    }
    int before = m->err.code;
    uint32_t fn = f->id & 0x780u, id = f->id & 0x7Fu;
    int k = com_node_of(m, id);
    if (k < 0) {
        m->rx_other++;
        return EF_OK;
    }
    ef_com_node_t *q = &m->node[k];
    switch (fn) {
    case EF_CO_COB_HEARTBEAT:
        com_heartbeat(m, k, f);
        break;
    case EF_CO_COB_EMCY:
        com_emcy(m, k, f);
        break;
    case EF_CO_COB_TPDO1:
        com_tpdo1(m, k, f);
        break;
    case EF_CO_COB_SDO_TX:
        if (!ef_sdo_client_busy(&m->sdo) || m->sdo.node != id) {
            q->rx_bad++; /* nothing asked: a late answer to a retried request */
            break;
        }
        com_sdo_frame(m, q, f);
        break;
    case EF_CO_COB_TPDO2:
        q->rx_bad++; /* disabled in every layout */
        break;
    default:
        break; /* master-produced identifiers (another master?) are not ours to judge */
    }
    com_advance(m);
    return (before == 0 && m->err.code != 0) ? m->err.code : EF_OK;
}

/* Supervision timers of the running states. */
static void com_timers(ef_comaster_t *m, uint32_t dt_us)
{
    int n = m->cfg.n_nodes;
    uint32_t now = m->now_us;
    for (int k = 0; k < n; k++) {
        ef_com_node_t *q = &m->node[k];
        if (q->hb_fresh) /* received since the last step, i.e. within this dt */
            q->hb_fresh = 0;
        else
            q->hb_age_us =
                (q->hb_age_us + dt_us < q->hb_age_us) ? 0xFFFFFFFFu : q->hb_age_us + dt_us;
    }
    com_sdo_timer(m); /* the configuration step or the caller's transfer */
    switch (m->state) {
    case EF_COM_BOOT:
        if (m->sub == EF_COM_SUB_BOOT_RESET) {
            m->sub = EF_COM_SUB_BOOT_WAIT;
            m->t_step_us = now;
            if (m->cfg.reset_comm)
                com_nmt(m, EF_CO_NMT_RESET_COMM);
            return;
        }
        if (ef_time_reached(now, m->t_step_us + m->cfg.boot_timeout_ms * 1000u))
            for (int k = 0; k < n; k++)
                if (m->node[k].nmt == 0xFFu) {
                    com_error(m, EF_ERR_HEARTBEAT, EF_COM_WHAT_BOOT, k, 0, 0);
                    com_enter_stop(m);
                    return;
                }
        return;
    case EF_COM_CONFIG:
        return;
    case EF_COM_START:
        if (ef_time_reached(now, m->t_step_us + m->cfg.enable_timeout_ms * 1000u))
            for (int k = 0; k < n; k++)
                if (!m->node[k].seen_tpdo) {
                    com_error(m, EF_ERR_TIMEOUT, EF_COM_WHAT_ENABLE, k, EF_CO_OBJ_STATUSWORD, 0);
                    com_enter_stop(m);
                    return;
                }
        break;
    case EF_COM_ENABLE:
        for (int k = 0; k < n; k++)
            if (m->node[k].power != EF_CO_PS_OP_ENABLED &&
                ef_time_reached(now, m->t_node_us[k] + m->cfg.enable_timeout_ms * 1000u)) {
                com_error(m, EF_ERR_TIMEOUT, EF_COM_WHAT_ENABLE, k, EF_CO_OBJ_STATUSWORD, 0);
                com_enter_stop(m);
                return;
            }
        break;
    case EF_COM_STOPPING:
    case EF_COM_FINISH: {
        /* FINISH waits as long as the drives execute (DRAIN); only its last steps are timed;
         * the ramp of a stop has the stop's own limit. */
        int sub = m->sub;
        uint32_t lim =
            sub == EF_COM_SUB_STOP_RAMP ? m->cfg.stop_timeout_ms : m->cfg.enable_timeout_ms;
        if (sub != EF_COM_SUB_FINISH_DRAIN && ef_time_reached(now, m->t_step_us + lim * 1000u)) {
            for (int k = 0; k < n; k++)
                if (!m->lost[k]) {
                    com_error(m, EF_ERR_TIMEOUT, EF_COM_WHAT_STOP, k, 0, 0);
                    break;
                }
            if (sub != EF_COM_SUB_SHUTDOWN)
                com_enter_shutdown(m);
            else
                com_enter_final(m);
            return;
        }
        break;
    }
    default:
        break;
    }
    /* Heartbeat consumer: from START on (0x1017 was set at CONFIG). */
    if (m->cfg.hb_producer_ms == 0)
        return;
    for (int k = 0; k < n; k++) {
        if (m->lost[k] || m->node[k].hb_age_us < (uint32_t)m->cfg.hb_timeout_ms * 1000u)
            continue;
        m->lost[k] = 1;
        com_error(m, EF_ERR_HEARTBEAT, EF_COM_WHAT_HEARTBEAT, k, 0, 0);
        com_enter_stop(m);
    }
}

/* Time step: TX retries, timers, SYNC + RPDOs when due, state checks; says when to call
 * again. A call late by several cycles sends one SYNC and carries at most one more cycle
 * (sent at the next call): drives step by the configured period per SYNC, so a burst of
 * SYNCs would not catch up time anyway, only load the bus. */
int ef_comaster_process(ef_comaster_t *m, uint32_t dt_us, uint32_t *next_us)
{
    if (!m)
        return EF_ERR_ARG;
    int before = m->err.code;
    m->now_us += dt_us;
    if (m->state != EF_COM_IDLE && m->state != EF_COM_DONE && m->state != EF_COM_ERROR) {
        com_flush(m);
        com_timers(m, dt_us);
        if (m->sync_on) {
            m->sync_acc_us += dt_us;
            if (m->sync_acc_us < dt_us)
                m->sync_acc_us = 0xFFFFFFFFu; /* overflow: saturate (very late call) */
            if (m->sync_acc_us >= m->cfg.cycle_us) {
                m->sync_acc_us -= m->cfg.cycle_us;
                if (m->sync_acc_us > m->cfg.cycle_us) {
                    m->sync_late += m->sync_acc_us / m->cfg.cycle_us - 1u;
                    m->sync_acc_us = m->cfg.cycle_us;
                }
                com_cycle(m);
            }
        }
        com_advance(m);
    } else if (m->state != EF_COM_IDLE) {
        /* DONE / ERROR: frames still queued go out; the caller's SDO transfer goes on. */
        com_flush(m);
        com_sdo_timer(m);
    }
    if (next_us) {
        uint32_t nx = 0xFFFFFFFFu;
        if (m->state == EF_COM_DONE || m->state == EF_COM_ERROR || m->state == EF_COM_IDLE) {
            nx = ef_txq_count(&m->txq) ? COM_RETRY_US : 0xFFFFFFFFu;
            uint32_t s = ef_sdo_client_due_us(&m->sdo, m->now_us); /* 0xFFFFFFFF: none */
            nx = s < nx ? s : nx;
        } else {
            nx = 10000u; /* timers are coarse (ms): look at them at least this often */
            if (m->sync_on) {
                uint32_t s =
                    m->sync_acc_us >= m->cfg.cycle_us ? 0u : m->cfg.cycle_us - m->sync_acc_us;
                nx = s < nx ? s : nx;
            }
            if (ef_txq_count(&m->txq) && COM_RETRY_US < nx)
                nx = COM_RETRY_US;
            if (m->state == EF_COM_CONFIG && !ef_sdo_client_busy(&m->sdo))
                nx = 0; /* the next step is ready now */
        }
        *next_us = nx;
    }
    return (before == 0 && m->err.code != 0) ? m->err.code : EF_OK;
}

/* Current state. */
int ef_comaster_state(const ef_comaster_t *m)
{
    return m ? m->state : EF_COM_IDLE;
}

/* The first error. */
const ef_com_error_t *ef_comaster_error(const ef_comaster_t *m)
{
    return m ? &m->err : 0;
}

/* Node k's view. */
const ef_com_node_t *ef_comaster_node(const ef_comaster_t *m, int k)
{
    if (!m || k < 0 || k >= m->cfg.n_nodes)
        return 0;
    return &m->node[k];
}

/* Node k's device name. */
const char *ef_comaster_name(const ef_comaster_t *m, int k)
{
    if (!m || k < 0 || k >= m->cfg.n_nodes)
        return 0;
    return m->name[k];
}

/* CSP: queue one cycle's targets, checked for representability now so sending cannot fail. */
int ef_comaster_push_target(ef_comaster_t *m, const float *pos)
{
    if (!m || !pos || m->cfg.mode != EF_COM_MODE_CSP)
        return EF_ERR_ARG;
    if (m->state != EF_COM_RUN || m->finishing)
        return EF_ERR_STATE;
    if (m->tq_count >= EF_COM_TARGETQ)
        return EF_ERR_FULL;
    for (int k = 0; k < m->cfg.n_nodes; k++) {
        int32_t inc;
        if (ef_co_pos_to_inc(pos[k], m->node[k].inc_per_unit, &inc) != EF_OK)
            return EF_ERR_NONFINITE;
    }
    uint32_t at = (m->tq_head + m->tq_count) % EF_COM_TARGETQ;
    for (int k = 0; k < m->cfg.n_nodes; k++)
        m->tq[at][k] = pos[k];
    m->tq_count++;
    return EF_OK;
}

/* Whether a move carries what the drives check (degree, finite data, duration). */
static int com_move_ok(const ef_move_t *mv)
{
    if (mv->degree != 1 && mv->degree != 3 && mv->degree != 5)
        return 0;
    int ok = ef_finitef(mv->duration) & ef_finitef(mv->length) & ef_finitef(mv->v_exit);
    for (int p = 0; p < EF_TIMELAW_PHASES; p++) {
        ok &= ef_finitef(mv->law.dt[p]);
        for (int i = 0; i < EF_TIMELAW_COEFFS; i++)
            ok &= ef_finitef(mv->law.c[p][i]);
    }
    for (int i = 0; i <= mv->degree; i++) {
        ok &= ef_finitef(mv->b[i].x) & ef_finitef(mv->b[i].y) & ef_finitef(mv->b[i].z);
        for (int k = 0; k < EF_AUX; k++)
            ok &= ef_finitef(mv->ab[k][i]);
    }
    return ok && mv->duration > 0.0f;
}

/* Segment mode: queue a move under the master's numbering. */
int ef_comaster_push_move(ef_comaster_t *m, const ef_move_t *mv)
{
    if (!m || !mv || m->cfg.mode != EF_COM_MODE_SEGMENT || !com_move_ok(mv))
        return EF_ERR_ARG;
    if (m->state != EF_COM_RUN || m->finishing)
        return EF_ERR_STATE;
    if (m->sq_count >= EF_COM_SEGQ)
        return EF_ERR_FULL;
    ef_move_t *d = &m->sq[(m->sq_head + m->sq_count) % EF_COM_SEGQ];
    *d = *mv;
    d->seq = m->next_seq++;
    m->sq_count++;
    return EF_OK;
}

/* Free places of the mode's queue. */
uint32_t ef_comaster_space(const ef_comaster_t *m)
{
    if (!m)
        return 0;
    if (m->cfg.mode == EF_COM_MODE_CSP)
        return EF_COM_TARGETQ - m->tq_count;
    return EF_COM_SEGQ - m->sq_count;
}

/* No more input: FINISH executes the rest, then disables. */
int ef_comaster_finish(ef_comaster_t *m)
{
    if (!m)
        return EF_ERR_ARG;
    if (m->state != EF_COM_RUN)
        return EF_ERR_STATE;
    m->finishing = 1;
    m->state = EF_COM_FINISH;
    m->sub = EF_COM_SUB_FINISH_DRAIN;
    m->t_step_us = m->now_us;
    m->mark_sync = m->sync_count; /* CSP with an empty queue: wait for fresh TPDOs */
    return EF_OK;
}

/* Requested controlled stop. */
/* Feed hold in segment mode: the halt bit of every node's next controlword. */
int ef_comaster_hold(ef_comaster_t *m, int on)
{
    if (!m || m->cfg.mode != EF_COM_MODE_SEGMENT)
        return EF_ERR_ARG;
    m->halt = on != 0;
    return EF_OK;
}

int ef_comaster_stop(ef_comaster_t *m)
{
    if (!m)
        return EF_ERR_ARG;
    if (m->state == EF_COM_IDLE)
        return EF_OK;
    com_enter_stop(m);
    return EF_OK;
}

/* The port reports a bus error. */
int ef_comaster_tx_pending(ef_comaster_t *m, uint32_t frames)
{
    if (!m)
        return EF_ERR_ARG;
    m->port_pending = frames;
    return EF_OK;
}

int ef_comaster_bus_error(ef_comaster_t *m, uint32_t detail)
{
    if (!m)
        return EF_ERR_ARG;
    com_bus_fail(m, detail);
    return EF_OK;
}

/* Whether the caller may start an SDO transfer: nothing pending, bring-up over. */
static int com_sdo_user_ok(const ef_comaster_t *m)
{
    int st = m->state;
    return !ef_sdo_client_busy(&m->sdo) &&
           (st == EF_COM_RUN || st == EF_COM_DONE || st == EF_COM_ERROR);
}

/* Caller's download: expedited up to 4 bytes, segmented above (the client copies the data). */
int ef_comaster_sdo_write(ef_comaster_t *m, int k, uint16_t index, uint8_t sub, const uint8_t *data,
                          uint32_t len)
{
    if (!m || !data || k < 0 || k >= m->cfg.n_nodes || len == 0u || len > EF_COM_SDO_BUF)
        return EF_ERR_ARG;
    if (!com_sdo_user_ok(m))
        return EF_ERR_STATE;
    ef_can_frame_t out;
    int rc =
        ef_sdo_client_download(&m->sdo, m->cfg.nodes[k], index, sub, data, len, m->now_us, &out);
    if (rc != EF_OK)
        return rc;
    m->sdo_user = 1;
    com_sdo_send(m, &out);
    return EF_OK;
}

/* Caller's upload: expedited or segmented, as the server answers. */
int ef_comaster_sdo_read(ef_comaster_t *m, int k, uint16_t index, uint8_t sub)
{
    if (!m || k < 0 || k >= m->cfg.n_nodes)
        return EF_ERR_ARG;
    if (!com_sdo_user_ok(m))
        return EF_ERR_STATE;
    ef_can_frame_t out;
    int rc = ef_sdo_client_upload(&m->sdo, m->cfg.nodes[k], index, sub, m->now_us, &out);
    if (rc != EF_OK)
        return rc;
    m->sdo_user = 1;
    com_sdo_send(m, &out);
    return EF_OK;
}

/* Outcome of the caller's last transfer (the client's, if the caller started it). */
int ef_comaster_sdo_result(const ef_comaster_t *m, uint32_t *abort, const uint8_t **data,
                           uint32_t *len)
{
    if (abort)
        *abort = 0;
    if (data)
        *data = 0;
    if (len)
        *len = 0;
    if (!m)
        return EF_ERR_ARG;
    if (!m->sdo_user)
        return EF_ERR_STATE;
    return ef_sdo_client_result(&m->sdo, abort, data, len);
}
