/* SPDX-License-Identifier: Apache-2.0 */
/* CANopen CiA 402 drive (one axis) on the CAN HAL (see ef_codrive.h). */
#include <stddef.h>
#include <stdint.h>
#include "evenfeed/canopen/ef_codrive.h"
#include "evenfeed/core/ef_err.h"
#include "evenfeed/core/ef_math.h"

/** 0x1018 identity. */
#define COD_VENDOR   0x00000EF0u
#define COD_PRODUCT  0x00000402u
#define COD_REVISION 1u
/** 0x6502: bit 7 CSP, bit 16 evenfeed segment mode. */
#define COD_SUPPORTED ((1u << 7) | (1u << 16))
/** Object access bits (cod_row_t::acc, cod_od_t::acc). */
#define COD_R 1u
#define COD_W 2u
/** sdo_len of a segmented download whose size the client did not indicate. */
#define COD_SDO_LEN_UNKNOWN 0xFFFFFFFFu
/** Classic CAN data bytes and bits, the PDO length limit. */
#define COD_PDO_BYTES 8u
#define COD_PDO_BITS  64u
/** Mapping entries per PDO (sub 1..8). */
#define COD_MAP_MAX 8u
/** Highest sub-index of a PDO communication record (1 COB-ID, 2 transmission type). */
#define COD_COMM_SUBS 2u
/** Highest sub-index of 0x1018 and of 0x2102. */
#define COD_IDENT_SUBS 4u
#define COD_SEGST_SUBS 6u
/** Transmission types: highest synchronous one, and the two event-driven ones. */
#define COD_TYPE_SYNC_MAX  240u
#define COD_TYPE_EVENT_MFR 254u
#define COD_TYPE_EVENT_DEV 255u
/** COB-ID bits: 11-bit identifier, 29-bit frame (refused), no RTR (accepted, ignored). */
#define COD_COB_MASK  0x7FFu
#define COD_COB_29BIT 0x20000000u
#define COD_COB_FRAME 0x40000000u
/** Controlword bit 7 (fault reset, acts on its rising edge). */
#define COD_CW_RESET 0x0080u
/** Statusword state bits per power state (CiA 402: bit 4 voltage enabled, bit 5 quick stop
 *  not active, bit 6 switch on disabled). */
#define COD_SW_SOD   0x0040u
#define COD_SW_READY 0x0031u
#define COD_SW_ON    0x0033u
#define COD_SW_OP    0x0037u
#define COD_SW_QS    0x0017u
#define COD_SW_FR    0x001Fu
#define COD_SW_FAULT 0x0008u
/** Error register (0x1001) bits set with a fault (CiA 301). */
#define COD_EREG_GENERIC 0x01u
#define COD_EREG_COMM    0x10u
#define COD_EREG_PROFILE 0x20u
#define COD_EREG_MFR     0x80u
/** next_us when nothing is due (heartbeat off, queue empty), and while frames wait. */
#define COD_IDLE_US  100000u
#define COD_RETRY_US 1000u
/** Microseconds per millisecond (0x1017 is in ms). */
#define COD_US_PER_MS 1000u

/** Device name (0x1008), read by segmented upload. */
static const char cod_name[] = "evenfeed sim drive";
#define COD_NAME_LEN ((uint32_t)(sizeof cod_name - 1u))

/** Controlword commands (CiA 402 table), decoded from bits 0..3 and 7. */
enum { CW_NONE, CW_SHUTDOWN, CW_SWITCH_ON, CW_ENABLE_OP, CW_DISABLE_VOLTAGE, CW_QUICK_STOP };

/** What the object dictionary says of one entry (a row, and the value read now). */
typedef struct {
    uint32_t size; /**< bytes */
    uint32_t acc;  /**< COD_R | COD_W */
    uint32_t val;  /**< value (scalars up to 4 bytes, readable ones) */
} cod_od_t;

/* ------------------------------------------------------------------------- helpers */

/* uint32 bits to int32 without implementation-defined conversion. */
static int32_t cod_i32(uint32_t u)
{
    return u <= (uint32_t)INT32_MAX ? (int32_t)u : -(int32_t)(~u) - 1;
}

/* int32 to its two's complement bits. */
static uint32_t cod_u32(int32_t v)
{
    return v >= 0 ? (uint32_t)v : ~(uint32_t)(-(v + 1));
}

/* Program units to increments, saturated at the int32 ends (0x6064 must always answer). */
static int32_t cod_inc(const ef_codrive_t *d, float x)
{
    int32_t v = 0;
    if (ef_co_pos_to_inc(x, d->cfg.inc_per_unit, &v) != EF_OK)
        v = x < 0.0f ? INT32_MIN : INT32_MAX;
    return v;
}

/* Increments to program units at this drive's resolution. */
static float cod_pos(const ef_codrive_t *d, int32_t inc)
{
    return ef_co_inc_to_pos(inc, d->cfg.inc_per_unit);
}

/* Zero a byte range (no libc in the firmware). */
static void cod_zero(uint8_t *p, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++)
        p[i] = 0u;
}

/* Little-endian value of n <= 4 bytes. */
static uint32_t cod_get_le(const uint8_t *p, uint32_t n)
{
    uint32_t v = 0;
    for (uint32_t i = 0; i < n && i < 4u; i++)
        v |= (uint32_t)p[i] << (8u * i);
    return v;
}

/* Store the low n <= 4 bytes of v little-endian. */
static void cod_put_le(uint8_t *p, uint32_t v, uint32_t n)
{
    for (uint32_t i = 0; i < n && i < 4u; i++)
        p[i] = (uint8_t)(v >> (8u * i));
}

/* A frame with the given id and length, data zeroed. */
static ef_can_frame_t cod_frame(uint32_t id, uint8_t dlc)
{
    ef_can_frame_t f = {0};
    f.id = id;
    f.dlc = dlc;
    return f;
}

/* ------------------------------------------------------------------------- TX queue */

/* Send now if nothing waits (order is kept), else queue behind what waits; a full queue
 * gives up its oldest heartbeat or TPDO (stale by now anyway), never an SDO reply or EMCY
 * (ef_txq.h, EF_TXQ_DROP_STALE). */
static void cod_send(ef_codrive_t *d, const ef_can_frame_t *f, int droppable)
{
    if (ef_txq_send(&d->txq, &d->port, f, droppable) == EF_ERR_BUS)
        d->bus_err = 1u; /* kept: a bus that recovers carries it */
}

/* Retry queued frames in order until the port is busy again. */
static void cod_txq_flush(ef_codrive_t *d)
{
    if (ef_txq_flush(&d->txq, &d->port) == EF_ERR_BUS)
        d->bus_err = 1u;
}

/* ------------------------------------------------------------------------- EMCY, status */

/* EMCY is produced in pre-operational and operational only (CiA 301). */
static void cod_emcy(ef_codrive_t *d, uint16_t code, uint8_t fault)
{
    if (d->nmt != EF_CO_NMT_PREOPERATIONAL && d->nmt != EF_CO_NMT_OPERATIONAL)
        return;
    ef_can_frame_t f = cod_frame(EF_CO_COB_EMCY + d->cfg.node, 8u);
    ef_co_put16(&f.data[0], code);
    f.data[2] = d->error_reg;
    f.data[3] = fault;
    ef_co_put32(&f.data[4], d->sync_count);
    cod_send(d, &f, 0);
}

/* Error register bits of a drive fault: generic, plus the class it belongs to. */
static uint8_t cod_ereg(int fault)
{
    switch (fault) {
    case EF_DRV_FAULT_FOLLOWING:
        return COD_EREG_GENERIC | COD_EREG_PROFILE;
    case EF_DRV_FAULT_WATCHDOG:
        return COD_EREG_GENERIC | COD_EREG_COMM;
    default: /* underrun, injected, segment: evenfeed's own */
        return COD_EREG_GENERIC | COD_EREG_MFR;
    }
}

/* The drive model raised a fault: record it in 0x603F/0x2001/0x1001 and send the EMCY once. */
static void cod_fault_report(ef_codrive_t *d)
{
    int fault = d->drv.fault;
    d->fault_sent = 1u;
    d->faults++;
    d->last_fault = (uint8_t)fault;
    d->error_code = ef_co_emcy_of_fault(fault);
    d->error_reg = cod_ereg(fault);
    cod_emcy(d, d->error_code, (uint8_t)fault);
}

/* Whether the command is still and the actual position has settled within win of goal. */
static int cod_settled(const ef_codrive_t *d, float goal)
{
    const ef_drive_t *v = &d->drv;
    float win = (float)EF_CODRIVE_POS_WINDOW / (float)d->cfg.inc_per_unit;
    return v->cmd_vel.x == 0.0f && ef_fabsf(v->act.x - goal) <= win;
}

/* The statusword of the present state (CiA 402 state bits plus bits 7, 9, 10, 12, 13, 14). */
static uint16_t cod_statusword(const ef_codrive_t *d)
{
    static const uint16_t bits[] = {0u,        COD_SW_SOD, COD_SW_READY, COD_SW_ON,
                                    COD_SW_OP, COD_SW_QS,  COD_SW_FR,    COD_SW_FAULT};
    const ef_drive_t *v = &d->drv;
    uint16_t sw = d->power < sizeof bits / sizeof bits[0] ? bits[d->power] : 0u;
    sw |= EF_CO_SW_REMOTE;
    float win = (float)d->ferr_window / (float)d->cfg.inc_per_unit;
    if (v->ferr > 0.5f * win)
        sw |= EF_CO_SW_WARNING;
    if (v->ferr > win)
        sw |= EF_CO_SW_FERR;
    int op = d->power == EF_CO_PS_OP_ENABLED && d->power_next == EF_CO_PS_OP_ENABLED;
    if (d->mode == EF_CO_MODE_SEGMENT) {
        int idle = v->ring_count == 0u && v->ip.count == 0u && !v->moving;
        if (idle && v->state != EF_DRV_STOPPING && cod_settled(d, v->cmd.x))
            sw |= EF_CO_SW_TARGET_REACHED;
        if (v->state == EF_DRV_RUNNING)
            sw |= EF_CO_SW_FOLLOWING;
        if (v->held)
            sw |= EF_CO_SW_HELD;
    } else {
        int following = op && v->direct && v->state == EF_DRV_ENABLED;
        if (v->state != EF_DRV_STOPPING && cod_settled(d, following ? v->target.x : v->cmd.x))
            sw |= EF_CO_SW_TARGET_REACHED;
        if (following)
            sw |= EF_CO_SW_FOLLOWING;
    }
    return sw;
}

/* ------------------------------------------------------------------------- CiA 402 */

/* Decode a controlword into its command (bit 7 set: none, only its edge counts). */
static int cod_cw_cmd(uint16_t cw)
{
    if (cw & COD_CW_RESET)
        return CW_NONE;
    if (!(cw & 0x0002u))
        return CW_DISABLE_VOLTAGE;
    if (!(cw & 0x0004u))
        return CW_QUICK_STOP;
    if (!(cw & 0x0001u))
        return CW_SHUTDOWN;
    if (!(cw & 0x0008u))
        return CW_SWITCH_ON;
    return CW_ENABLE_OP;
}

/* Idle both record assemblers and forget unpaired records. */
static void cod_seg_reset(ef_codrive_t *d)
{
    ef_co_asm_init(&d->asm_law, 1);
    ef_co_asm_init(&d->asm_axis, 0);
    d->have_law = d->have_axis = 0u;
    d->law_prev.valid = 0u;
}

/* Transition 4: the drive model is enabled in the mode's way (CSP: direct mode holding the
 * actual position; segment mode: an empty queue numbered from 0). */
static void cod_op_enter(ef_codrive_t *d)
{
    ef_drive_t *v = &d->drv;
    (void)ef_drive_set_direct(v, d->mode == EF_CO_MODE_CSP); /* DISABLED here: cannot fail */
    if (d->mode == EF_CO_MODE_SEGMENT) {
        (void)ef_drive_clear(v);
        cod_seg_reset(d);
    }
    if (ef_drive_enable(v, 1) != EF_OK)
        return; /* FAULT: the power state follows the drive in cod_update */
    d->target_inc = cod_inc(d, v->cmd.x); /* nothing moves until a new target comes */
    d->power = EF_CO_PS_OP_ENABLED;
    d->power_next = EF_CO_PS_OP_ENABLED;
    d->sync_lost = 0u; /* a new job: the SYNCs step it, supervised from now */
    d->sync_gap_us = 0u;
}

/* Leave OPERATION ENABLED for `to` through a controlled stop (the state changes at rest). */
static void cod_op_leave(ef_codrive_t *d, uint8_t to)
{
    d->power_next = to;
    (void)ef_drive_enable(&d->drv, 0);
}

/* Fault reset (rising edge of bit 7): only in FAULT, i.e. once the reaction has stopped. */
static void cod_fault_reset(ef_codrive_t *d)
{
    if (d->power != EF_CO_PS_FAULT || ef_drive_fault_reset(&d->drv) != EF_OK)
        return;
    d->power = EF_CO_PS_SWITCH_ON_DISABLED;
    d->power_next = EF_CO_PS_OP_ENABLED;
    d->fault_sent = 0u;
    d->error_code = EF_CO_EMCY_NONE;
    d->error_reg = 0u;
    cod_seg_reset(d);
    cod_emcy(d, EF_CO_EMCY_NONE, EF_DRV_FAULT_NONE);
}

/* Follow the drive model: report a new fault, finish stops whose end state was pending, and
 * in segment mode start or stop the queue by controlword bit 4 (a level). */
static void cod_update(ef_codrive_t *d)
{
    ef_drive_t *v = &d->drv;
    if (v->fault != EF_DRV_FAULT_NONE) {
        if (!d->fault_sent)
            cod_fault_report(d);
        d->power = v->state == EF_DRV_FAULT ? EF_CO_PS_FAULT : EF_CO_PS_FAULT_REACTION;
        d->power_next = EF_CO_PS_OP_ENABLED;
        return;
    }
    if (d->power == EF_CO_PS_OP_ENABLED && d->power_next != EF_CO_PS_OP_ENABLED &&
        v->state == EF_DRV_DISABLED) {
        d->power = d->power_next;
        d->power_next = EF_CO_PS_OP_ENABLED;
    }
    if (d->power == EF_CO_PS_QUICK_STOP && v->state == EF_DRV_DISABLED)
        d->power = EF_CO_PS_SWITCH_ON_DISABLED; /* quick stop option 2 */
    if (d->power == EF_CO_PS_OP_ENABLED && d->power_next == EF_CO_PS_OP_ENABLED &&
        d->mode == EF_CO_MODE_SEGMENT) {
        int run = (d->controlword & EF_CO_CW_SEG_RUN) != 0u;
        (void)ef_drive_hold(v, (d->controlword & EF_CO_CW_HALT) != 0u); /* segment: no refusal */
        if (run && v->state == EF_DRV_ENABLED)
            (void)ef_drive_start(v);
        else if (!run && v->state == EF_DRV_RUNNING)
            (void)ef_drive_quick_stop(v);
    }
}

/* Apply a controlword: the CiA 402 transitions of its command in the present state. */
static void cod_control(ef_codrive_t *d, uint16_t cw)
{
    uint16_t prev = d->controlword;
    d->controlword = cw;
    if ((cw & COD_CW_RESET) && !(prev & COD_CW_RESET))
        cod_fault_reset(d);
    int cmd = cod_cw_cmd(cw);
    int off = cmd == CW_DISABLE_VOLTAGE || cmd == CW_QUICK_STOP;
    switch (d->power) {
    case EF_CO_PS_SWITCH_ON_DISABLED:
        if (cmd == CW_SHUTDOWN)
            d->power = EF_CO_PS_READY; /* 2 */
        break;
    case EF_CO_PS_READY:
        if (cmd == CW_SWITCH_ON)
            d->power = EF_CO_PS_SWITCHED_ON; /* 3 */
        else if (cmd == CW_ENABLE_OP)
            cod_op_enter(d); /* 3 + 4 */
        else if (off)
            d->power = EF_CO_PS_SWITCH_ON_DISABLED; /* 7 */
        break;
    case EF_CO_PS_SWITCHED_ON:
        if (cmd == CW_ENABLE_OP)
            cod_op_enter(d); /* 4 */
        else if (cmd == CW_SHUTDOWN)
            d->power = EF_CO_PS_READY; /* 6 */
        else if (off)
            d->power = EF_CO_PS_SWITCH_ON_DISABLED; /* 10 */
        break;
    case EF_CO_PS_OP_ENABLED:
        if (cmd == CW_ENABLE_OP && d->power_next != EF_CO_PS_OP_ENABLED) {
            d->power_next = EF_CO_PS_OP_ENABLED; /* a pending disable is cancelled */
            (void)ef_drive_enable(&d->drv, 1);
        } else if (cmd == CW_SWITCH_ON) {
            cod_op_leave(d, EF_CO_PS_SWITCHED_ON); /* 5 */
        } else if (cmd == CW_SHUTDOWN) {
            cod_op_leave(d, EF_CO_PS_READY); /* 8 */
        } else if (cmd == CW_DISABLE_VOLTAGE) {
            cod_op_leave(d, EF_CO_PS_SWITCH_ON_DISABLED); /* 9, after a controlled stop */
        } else if (cmd == CW_QUICK_STOP) {
            d->power = EF_CO_PS_QUICK_STOP; /* 11 */
            d->power_next = EF_CO_PS_OP_ENABLED;
            (void)ef_drive_enable(&d->drv, 0);
        }
        break;
    default: /* QUICK STOP ends by itself at rest; FAULT REACTION, FAULT: only the reset */
        break;
    }
    cod_update(d);
}

/* ------------------------------------------------------------------------- segment mode */

/* Copy the law fields of a decoded law record. */
static void cod_law_save(ef_codrive_law_t *l, const ef_move_t *m, uint16_t seq16)
{
    l->law = m->law;
    l->length = m->length;
    l->v_exit = m->v_exit;
    l->duration = m->duration;
    l->flags = m->flags;
    l->seq16 = seq16;
    l->valid = 1u;
}

/* Put saved law fields into a move. */
static void cod_law_load(ef_move_t *m, const ef_codrive_law_t *l)
{
    m->law = l->law;
    m->length = l->length;
    m->v_exit = l->v_exit;
    m->duration = l->duration;
    m->flags = l->flags;
}

/* A record the drive cannot use (non-finite data, not continuous): a SEGMENT fault while
 * the drive executes segments, else only counted. */
static void cod_seg_refuse(ef_codrive_t *d)
{
    if (d->power == EF_CO_PS_OP_ENABLED && d->mode == EF_CO_MODE_SEGMENT) {
        (void)ef_drive_fault(&d->drv, EF_DRV_FAULT_SEGMENT);
        cod_update(d);
    } else {
        d->seg_dropped++;
    }
}

/* Queue a complete segment whose 16-bit number is extended against the one expected. */
static void cod_seg_push(ef_codrive_t *d, ef_move_t *m, uint16_t seq16)
{
    uint32_t next = d->drv.next_seq;
    int32_t diff = (int32_t)((uint32_t)(seq16 - (uint16_t)next) & 0xFFFFu);
    if (diff >= 0x8000)
        diff -= 0x10000;
    if (diff < 0 && (uint32_t)(-diff) > next) {
        d->seg_dups++; /* older than segment 0: a stale retry */
        return;
    }
    m->seq = diff >= 0 ? next + (uint32_t)diff : next - (uint32_t)(-diff);
    m->kind = m->degree == 1u ? EF_MOVE_LINE : EF_MOVE_SMOOTH;
    int rc = ef_drive_push(&d->drv, m);
    switch (rc) {
    case EF_OK:
        break;
    case EF_ERR_DUP:
        d->seg_dups++;
        break;
    case EF_ERR_ARG:
        cod_seg_refuse(d);
        break;
    default: /* SEQ (a gap: the master resends), FULL, STATE (not executing segments) */
        d->seg_dropped++;
        break;
    }
}

/* Pair the pending axis record with the law record of the same number, if one is here. */
static void cod_seg_pair(ef_codrive_t *d)
{
    if (!d->have_axis)
        return;
    ef_move_t m = d->pend;
    if (d->have_law && d->law_seq16 == d->axis_seq16) {
        d->have_law = 0u;
    } else if (d->law_prev.valid && d->law_prev.seq16 == d->axis_seq16) {
        cod_law_load(&m, &d->law_prev); /* the next law record overtook this axis record */
        d->law_prev.valid = 0u;
    } else {
        return;
    }
    d->have_axis = 0u;
    cod_seg_push(d, &m, d->axis_seq16);
}

/* One chunk of the law (law != 0, object 0x2101) or axis (0x2100) record stream. */
static void cod_seg_chunk(ef_codrive_t *d, int law, const uint8_t *data)
{
    ef_co_asm_t *a = law ? &d->asm_law : &d->asm_axis;
    int rc = ef_co_asm_feed(a, data);
    if (rc == EF_ERR_SEQ || rc == EF_ERR_PROTO)
        d->seg_dropped++;
    if (rc != EF_OK)
        return;
    ef_move_t t = {0};
    if (law) {
        if (ef_co_law_decode(a->rec, a->rec_len, &t) != EF_OK) {
            cod_seg_refuse(d);
            return;
        }
        uint16_t s16 = (uint16_t)t.seq;
        if (d->have_law && d->law_seq16 != s16)
            cod_law_save(&d->law_prev, &d->pend, d->law_seq16);
        ef_codrive_law_t cur;
        cod_law_save(&cur, &t, s16);
        cod_law_load(&d->pend, &cur);
        d->have_law = 1u;
        d->law_seq16 = s16;
    } else {
        uint16_t s16 = 0u;
        if (ef_co_axis_decode(a->rec, a->rec_len, &t, &s16) != EF_OK) {
            cod_seg_refuse(d);
            return;
        }
        d->pend.degree = t.degree;
        for (int i = 0; i < 6; i++)
            d->pend.b[i] = i <= t.degree ? ef_v3(t.b[i].x, 0.0f, 0.0f) : ef_v3(0.0f, 0.0f, 0.0f);
        d->have_axis = 1u;
        d->axis_seq16 = s16;
    }
    cod_seg_pair(d);
}

/* ------------------------------------------------------------------------- PDOs */

/* Whether a mapping entry names an object (with its exact size) this direction may carry. */
static int cod_mappable(int rx, uint32_t e)
{
    static const uint32_t rx_ok[] = {
        EF_CO_MAP(EF_CO_OBJ_CONTROLWORD, 0, 16), EF_CO_MAP(EF_CO_OBJ_TARGET_POS, 0, 32),
        EF_CO_MAP(EF_CO_OBJ_SEG_AXIS, 0, 64), EF_CO_MAP(EF_CO_OBJ_SEG_LAW, 0, 64)};
    static const uint32_t tx_ok[] = {EF_CO_MAP(EF_CO_OBJ_STATUSWORD, 0, 16),
                                     EF_CO_MAP(EF_CO_OBJ_POS_ACTUAL, 0, 32),
                                     EF_CO_MAP(EF_CO_OBJ_FERR_ACTUAL, 0, 32),
                                     EF_CO_MAP(EF_CO_OBJ_SEG_STATUS, EF_CO_SEGST_NEXT8, 8),
                                     EF_CO_MAP(EF_CO_OBJ_SEG_STATUS, EF_CO_SEGST_FREE, 8)};
    const uint32_t *ok = rx ? rx_ok : tx_ok;
    uint32_t n = rx ? (uint32_t)(sizeof rx_ok / sizeof rx_ok[0])
                    : (uint32_t)(sizeof tx_ok / sizeof tx_ok[0]);
    for (uint32_t i = 0; i < n; i++)
        if (ok[i] == e)
            return 1;
    return 0;
}

/* Bytes a PDO's mapping fills (entries are validated: whole bytes, at most 8 in all). */
static uint32_t cod_pdo_bytes(const ef_codrive_pdo_t *p)
{
    uint32_t bits = 0;
    for (uint32_t i = 0; i < p->count && i < COD_MAP_MAX; i++)
        bits += p->map[i] & 0xFFu;
    return bits / 8u;
}

/* A PDO's parameters as after reset communication. */
static void cod_pdo_set(ef_codrive_pdo_t *p, uint32_t cobid, uint8_t type, uint32_t m0, uint32_t m1)
{
    *p = (ef_codrive_pdo_t){0};
    p->cobid = cobid;
    p->type = type;
    p->map[0] = m0;
    p->map[1] = m1;
    p->count = (uint8_t)((m0 != 0u) + (m1 != 0u));
}

/* Communication area (0x1000..0x1FFF) to its power-on values. */
static void cod_comm_defaults(ef_codrive_t *d)
{
    uint32_t n = d->cfg.node;
    cod_pdo_set(&d->rpdo[0], EF_CO_COB_RPDO1 + n, 1u, EF_CO_MAP(EF_CO_OBJ_CONTROLWORD, 0, 16),
                EF_CO_MAP(EF_CO_OBJ_TARGET_POS, 0, 32));
    cod_pdo_set(&d->rpdo[1], EF_CO_PDO_INVALID | (EF_CO_COB_RPDO2 + n), COD_TYPE_EVENT_DEV, 0u, 0u);
    cod_pdo_set(&d->rpdo[2], EF_CO_PDO_INVALID | (EF_CO_COB_RPDO3 + n), COD_TYPE_EVENT_DEV, 0u, 0u);
    cod_pdo_set(&d->tpdo[0], EF_CO_COB_TPDO1 + n, 1u, EF_CO_MAP(EF_CO_OBJ_STATUSWORD, 0, 16),
                EF_CO_MAP(EF_CO_OBJ_POS_ACTUAL, 0, 32));
    cod_pdo_set(&d->tpdo[1], EF_CO_PDO_INVALID | (EF_CO_COB_TPDO2 + n), 1u, 0u, 0u);
    for (uint32_t k = 0; k < EF_CODRIVE_TPDOS; k++)
        d->tpdo_cnt[k] = d->tpdo_sent[k] = 0u;
    d->sync_cobid = EF_CO_COB_SYNC;
    d->cycle_us = 0u;
    d->hb_ms = 0u;
    d->hb_acc_us = 0u;
    d->sdo_state = EF_CODRIVE_SDO_IDLE;
}

/* CiA 301 restricted COB-IDs (NMT, SYNC, EMCY/TIME area, SDO, LSS, NMT error control). */
static int cod_cob_restricted(const ef_codrive_t *d, uint32_t id)
{
    return id <= 0x07Fu || (id >= 0x101u && id <= 0x180u) || (id >= 0x581u && id <= 0x5FFu) ||
           (id >= 0x601u && id <= 0x67Fu) || (id >= 0x6E0u && id <= 0x6FFu) || id >= 0x701u ||
           id == (d->sync_cobid & COD_COB_MASK);
}

/* Apply an RPDO's data to its mapped objects, in mapping order. */
static void cod_rpdo_apply(ef_codrive_t *d, const ef_codrive_pdo_t *p, const uint8_t *data)
{
    uint32_t off = 0;
    for (uint32_t i = 0; i < p->count && i < COD_MAP_MAX; i++) {
        uint32_t e = p->map[i];
        const uint8_t *q = data + off;
        switch (e >> 16) {
        case EF_CO_OBJ_CONTROLWORD:
            cod_control(d, ef_co_get16(q));
            break;
        case EF_CO_OBJ_TARGET_POS:
            d->target_inc = cod_i32(ef_co_get32(q));
            break;
        case EF_CO_OBJ_SEG_AXIS:
            cod_seg_chunk(d, 0, q);
            break;
        case EF_CO_OBJ_SEG_LAW:
            cod_seg_chunk(d, 1, q);
            break;
        default: /* not mappable: never stored */
            break;
        }
        off += (e & 0xFFu) / 8u;
        if (off > COD_PDO_BYTES)
            return;
    }
}

/* An RPDO frame: synchronous types wait for the next SYNC, event types apply now; a frame
 * shorter than the mapping is ignored and counted. */
static void cod_rpdo_rx(ef_codrive_t *d, ef_codrive_pdo_t *p, const ef_can_frame_t *f)
{
    if (f->dlc < cod_pdo_bytes(p)) {
        d->rx_ignored++;
        return;
    }
    if (p->type <= COD_TYPE_SYNC_MAX) {
        for (uint32_t i = 0; i < COD_PDO_BYTES; i++)
            p->latched[i] = i < f->dlc ? f->data[i] : 0u;
        p->has_latched = 1u;
        return;
    }
    cod_rpdo_apply(d, p, f->data);
}

/* ------------------------------------------------------------------------- object dictionary */

/* The PDO an index addresses (communication or mapping record): 1 and its kind, else 0. */
static int cod_pdo_find(uint16_t idx, int *rx, int *map, int *k)
{
    static const struct {
        uint16_t base;
        uint8_t n, rx, map;
    } kinds[] = {{EF_CO_OBJ_RPDO_COMM, EF_CODRIVE_RPDOS, 1, 0},
                 {EF_CO_OBJ_RPDO_MAP, EF_CODRIVE_RPDOS, 1, 1},
                 {EF_CO_OBJ_TPDO_COMM, EF_CODRIVE_TPDOS, 0, 0},
                 {EF_CO_OBJ_TPDO_MAP, EF_CODRIVE_TPDOS, 0, 1}};
    for (uint32_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++) {
        if (idx >= kinds[i].base && idx < kinds[i].base + kinds[i].n) {
            *rx = kinds[i].rx;
            *map = kinds[i].map;
            *k = idx - kinds[i].base;
            return 1;
        }
    }
    return 0;
}

/* Write a PDO parameter (CiA 301 rules: COB-ID changes only while invalid, mapping only
 * while invalid and with sub 0 at 0, sub 0 checks the whole mapping). */
static uint32_t cod_pdo_write(ef_codrive_t *d, ef_codrive_pdo_t *p, int rx, int map, int k,
                              uint8_t sub, uint32_t val)
{
    if (!map) {
        if (sub == 2u) {
            if (val > COD_TYPE_SYNC_MAX && val != COD_TYPE_EVENT_MFR && val != COD_TYPE_EVENT_DEV)
                return EF_CO_ABORT_RANGE;
            p->type = (uint8_t)val;
        } else {
            int valid_now = !(p->cobid & EF_CO_PDO_INVALID);
            int valid_new = !(val & EF_CO_PDO_INVALID);
            uint32_t id = val & COD_COB_MASK;
            if (val & ~(EF_CO_PDO_INVALID | COD_COB_FRAME | COD_COB_MASK))
                return EF_CO_ABORT_RANGE; /* 29-bit identifiers, reserved bits */
            if (valid_now && valid_new && id != (p->cobid & COD_COB_MASK))
                return EF_CO_ABORT_RANGE;
            if (valid_new && cod_cob_restricted(d, id))
                return EF_CO_ABORT_RANGE;
            p->cobid = val;
            if (!valid_new)
                p->has_latched = 0u;
        }
        if (!rx)
            d->tpdo_cnt[k] = d->tpdo_sent[k] = 0u;
        return 0u;
    }
    if (!(p->cobid & EF_CO_PDO_INVALID))
        return EF_CO_ABORT_STATE;
    if (sub == 0u) {
        if (val > COD_MAP_MAX)
            return EF_CO_ABORT_MAP_LEN;
        uint32_t bits = 0;
        for (uint32_t i = 0; i < val; i++) {
            if (!cod_mappable(rx, p->map[i]))
                return EF_CO_ABORT_NO_MAP;
            bits += p->map[i] & 0xFFu;
        }
        if (bits > COD_PDO_BITS)
            return EF_CO_ABORT_MAP_LEN;
        p->count = (uint8_t)val;
        return 0u;
    }
    if (p->count != 0u)
        return EF_CO_ABORT_STATE;
    if (val != 0u && !cod_mappable(rx, val))
        return EF_CO_ABORT_NO_MAP;
    p->map[sub - 1u] = val;
    return 0u;
}

/* Read hooks: the value of (idx, sub) for rows whose value is not a constant. */

static uint32_t cod_get_ereg(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->error_reg;
}

static uint32_t cod_get_sync_cobid(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->sync_cobid;
}

static uint32_t cod_get_cycle(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->cycle_us;
}

static uint32_t cod_get_emcy_cobid(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return EF_CO_COB_EMCY + d->cfg.node;
}

static uint32_t cod_get_hb(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->hb_ms;
}

static uint32_t cod_get_serial(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->cfg.serial;
}

/* PDO records: communication (1 COB-ID, 2 type) and mapping (0 count, 1..8 entries). */
static uint32_t cod_get_pdo(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    int rx = 0, map = 0, k = 0;
    (void)cod_pdo_find(idx, &rx, &map, &k); /* the row matched: it is a PDO index */
    const ef_codrive_pdo_t *p = rx ? &d->rpdo[k] : &d->tpdo[k];
    if (!map)
        return sub == 1u ? p->cobid : p->type;
    return sub == 0u ? p->count : p->map[sub - 1u];
}

static uint32_t cod_get_ipu(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->cfg.inc_per_unit;
}

static uint32_t cod_get_fault(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->last_fault;
}

static uint32_t cod_get_sync_timeout(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->sync_timeout_ms;
}

/* 0x2102: the segment-mode status record. */
static uint32_t cod_get_segst(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    const ef_drive_t *v = &d->drv;
    (void)idx;
    switch (sub) {
    case EF_CO_SEGST_NEXT8:
        return v->next_seq & 0xFFu;
    case EF_CO_SEGST_FREE:
        return ef_drive_free(v);
    case EF_CO_SEGST_NEXT:
        return v->next_seq;
    case EF_CO_SEGST_DONE:
        return v->done_any;
    case EF_CO_SEGST_DROPPED:
        return d->seg_dropped;
    default: /* EF_CO_SEGST_DUPS: the row covers nothing else */
        return d->seg_dups;
    }
}

static uint32_t cod_get_ecode(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->error_code;
}

static uint32_t cod_get_cw(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->controlword;
}

static uint32_t cod_get_sw(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return cod_statusword(d);
}

static uint32_t cod_get_mode(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)sub;
    return (uint8_t)cod_u32(idx == EF_CO_OBJ_MODE ? d->mode : d->mode_display);
}

static uint32_t cod_get_pos(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return cod_u32(cod_inc(d, d->drv.act.x));
}

static uint32_t cod_get_ferr_window(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return d->ferr_window;
}

static uint32_t cod_get_target(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return cod_u32(d->target_inc);
}

static uint32_t cod_get_ferr(const ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    (void)idx, (void)sub;
    return cod_u32(cod_inc(d, d->drv.cmd.x - d->drv.act.x));
}

/* Write hooks: size and access were checked by the table; each checks its value and
 * applies it; 0 or the abort code. val: the bytes little-endian (up to 4); buf: all. */

static uint32_t cod_set_pdo(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                            const uint8_t *buf)
{
    int rx = 0, map = 0, k = 0;
    (void)buf;
    (void)cod_pdo_find(idx, &rx, &map, &k);
    return cod_pdo_write(d, rx ? &d->rpdo[k] : &d->tpdo[k], rx, map, k, sub, val);
}

static uint32_t cod_set_sync_cobid(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                                   const uint8_t *buf)
{
    (void)idx, (void)sub, (void)buf;
    if ((val & ~COD_COB_MASK) != 0u || val == 0u)
        return EF_CO_ABORT_RANGE; /* a consumer only: no generate bit, 11-bit id */
    d->sync_cobid = val;
    return 0u;
}

static uint32_t cod_set_cycle(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                              const uint8_t *buf)
{
    uint32_t period = d->cfg.servo_period_us;
    (void)idx, (void)sub, (void)buf;
    /* Whole servo periods, and no more than EF_CODRIVE_SYNC_CALLS model calls per SYNC. */
    if (val % period != 0u || val / period > (uint32_t)EF_DRIVE_MAX_STEPS * EF_CODRIVE_SYNC_CALLS)
        return EF_CO_ABORT_RANGE;
    d->cycle_us = val;
    return 0u;
}

static uint32_t cod_set_hb(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                           const uint8_t *buf)
{
    (void)idx, (void)sub, (void)buf;
    d->hb_ms = (uint16_t)val;
    d->hb_acc_us = 0u;
    return 0u;
}

static uint32_t cod_set_sync_timeout(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                                     const uint8_t *buf)
{
    (void)idx, (void)sub, (void)buf;
    if (val > EF_CODRIVE_SYNC_TIMEOUT_MAX_MS)
        return EF_CO_ABORT_RANGE;
    d->sync_timeout_ms = (uint16_t)val; /* the gap so far counts against the new value */
    return 0u;
}

/* 0x2100 / 0x2101: a record chunk, the same as by RPDO. */
static uint32_t cod_set_chunk(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                              const uint8_t *buf)
{
    (void)sub, (void)val;
    cod_seg_chunk(d, idx == EF_CO_OBJ_SEG_LAW, buf);
    return 0u;
}

static uint32_t cod_set_cw(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                           const uint8_t *buf)
{
    (void)idx, (void)sub, (void)buf;
    cod_control(d, (uint16_t)val);
    return 0u;
}

static uint32_t cod_set_mode(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                             const uint8_t *buf)
{
    (void)idx, (void)sub, (void)buf;
    int8_t m = val == 0xFFu ? (int8_t)EF_CO_MODE_SEGMENT : (int8_t)(val & 0x7Fu);
    if (val != 0xFFu && val != (uint32_t)EF_CO_MODE_CSP)
        return EF_CO_ABORT_RANGE;
    if (m != d->mode && (d->power == EF_CO_PS_OP_ENABLED || d->power == EF_CO_PS_QUICK_STOP ||
                         d->power == EF_CO_PS_FAULT_REACTION))
        return EF_CO_ABORT_STATE;
    d->mode = d->mode_display = m;
    return 0u;
}

static uint32_t cod_set_ferr_window(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                                    const uint8_t *buf)
{
    (void)idx, (void)sub, (void)buf;
    if (val == 0u)
        return EF_CO_ABORT_RANGE;
    d->ferr_window = val;
    d->drv.cfg.ferr_lim = (float)val / (float)d->cfg.inc_per_unit;
    return 0u;
}

static uint32_t cod_set_target(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                               const uint8_t *buf)
{
    (void)idx, (void)sub, (void)buf;
    d->target_inc = cod_i32(val);
    return 0u;
}

/** A read hook: the value of (idx, sub). */
typedef uint32_t (*cod_get_t)(const ef_codrive_t *d, uint16_t idx, uint8_t sub);
/** A write hook (see above). */
typedef uint32_t (*cod_set_t)(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t val,
                              const uint8_t *buf);

/** One row of the object dictionary: indices index .. index + n_idx - 1, sub-indices
 *  lo .. hi, all of one size and access. */
typedef struct {
    uint16_t index;
    uint8_t n_idx;  /**< consecutive indices of this layout (the PDO records), >= 1 */
    uint8_t lo, hi; /**< sub-index range */
    uint8_t size;   /**< bytes */
    uint8_t acc;    /**< COD_R | COD_W */
    uint8_t pad;
    uint32_t val;  /**< the value when get is NULL (constants) */
    cod_get_t get; /**< NULL: val */
    cod_set_t set; /**< set exactly when acc has COD_W */
} cod_row_t;

#define COD_RW (COD_R | COD_W)
/** A plain variable (sub 0 only). */
#define COD_VAR(idx, size, acc, get, set)                                                          \
    {                                                                                              \
        (idx), 1u, 0u, 0u, (size), (acc), 0u, 0u, (get), (set)                                     \
    }
/** A read-only constant. */
#define COD_CONST(idx, size, val)                                                                  \
    {                                                                                              \
        (idx), 1u, 0u, 0u, (size), COD_R, 0u, (val), NULL, NULL                                    \
    }
/** Sub 0 of a record over n indices: its highest sub-index, read-only u8. */
#define COD_SUB0(idx, n, subs)                                                                     \
    {                                                                                              \
        (idx), (n), 0u, 0u, 1u, COD_R, 0u, (subs), NULL, NULL                                      \
    }

/** The object dictionary (docs/can.md), by index. Sub-indices a row does not cover, of an
 *  index some row has, are EF_CO_ABORT_NO_SUB; other indices EF_CO_ABORT_NO_OBJECT. */
static const cod_row_t cod_od[] = {
    COD_CONST(EF_CO_OBJ_DEVICE_TYPE, 4u, EF_CO_DEVICE_TYPE_402),
    COD_VAR(EF_CO_OBJ_ERROR_REG, 1u, COD_R, cod_get_ereg, NULL),
    COD_VAR(EF_CO_OBJ_SYNC_COBID, 4u, COD_RW, cod_get_sync_cobid, cod_set_sync_cobid),
    COD_VAR(EF_CO_OBJ_CYCLE, 4u, COD_RW, cod_get_cycle, cod_set_cycle),
    COD_CONST(EF_CO_OBJ_DEVICE_NAME, COD_NAME_LEN, 0u), /* the bytes: cod_name (upload) */
    COD_VAR(EF_CO_OBJ_EMCY_COBID, 4u, COD_R, cod_get_emcy_cobid, NULL),
    COD_VAR(EF_CO_OBJ_HB_PRODUCER, 2u, COD_RW, cod_get_hb, cod_set_hb),
    COD_SUB0(EF_CO_OBJ_IDENTITY, 1u, COD_IDENT_SUBS),
    {EF_CO_OBJ_IDENTITY, 1u, 1u, 1u, 4u, COD_R, 0u, COD_VENDOR, NULL, NULL},
    {EF_CO_OBJ_IDENTITY, 1u, 2u, 2u, 4u, COD_R, 0u, COD_PRODUCT, NULL, NULL},
    {EF_CO_OBJ_IDENTITY, 1u, 3u, 3u, 4u, COD_R, 0u, COD_REVISION, NULL, NULL},
    {EF_CO_OBJ_IDENTITY, 1u, 4u, 4u, 4u, COD_R, 0u, 0u, cod_get_serial, NULL},
    COD_SUB0(EF_CO_OBJ_RPDO_COMM, EF_CODRIVE_RPDOS, COD_COMM_SUBS),
    {EF_CO_OBJ_RPDO_COMM, EF_CODRIVE_RPDOS, 1u, 1u, 4u, COD_RW, 0u, 0u, cod_get_pdo, cod_set_pdo},
    {EF_CO_OBJ_RPDO_COMM, EF_CODRIVE_RPDOS, 2u, 2u, 1u, COD_RW, 0u, 0u, cod_get_pdo, cod_set_pdo},
    {EF_CO_OBJ_RPDO_MAP, EF_CODRIVE_RPDOS, 0u, 0u, 1u, COD_RW, 0u, 0u, cod_get_pdo, cod_set_pdo},
    {EF_CO_OBJ_RPDO_MAP, EF_CODRIVE_RPDOS, 1u, COD_MAP_MAX, 4u, COD_RW, 0u, 0u, cod_get_pdo,
     cod_set_pdo},
    COD_SUB0(EF_CO_OBJ_TPDO_COMM, EF_CODRIVE_TPDOS, COD_COMM_SUBS),
    {EF_CO_OBJ_TPDO_COMM, EF_CODRIVE_TPDOS, 1u, 1u, 4u, COD_RW, 0u, 0u, cod_get_pdo, cod_set_pdo},
    {EF_CO_OBJ_TPDO_COMM, EF_CODRIVE_TPDOS, 2u, 2u, 1u, COD_RW, 0u, 0u, cod_get_pdo, cod_set_pdo},
    {EF_CO_OBJ_TPDO_MAP, EF_CODRIVE_TPDOS, 0u, 0u, 1u, COD_RW, 0u, 0u, cod_get_pdo, cod_set_pdo},
    {EF_CO_OBJ_TPDO_MAP, EF_CODRIVE_TPDOS, 1u, COD_MAP_MAX, 4u, COD_RW, 0u, 0u, cod_get_pdo,
     cod_set_pdo},
    COD_VAR(EF_CO_OBJ_INC_PER_UNIT, 4u, COD_R, cod_get_ipu, NULL),
    COD_VAR(EF_CO_OBJ_DRIVE_FAULT, 1u, COD_R, cod_get_fault, NULL),
    COD_VAR(EF_CO_OBJ_SYNC_TIMEOUT, 2u, COD_RW, cod_get_sync_timeout, cod_set_sync_timeout),
    COD_VAR(EF_CO_OBJ_SEG_AXIS, COD_PDO_BYTES, COD_W, NULL, cod_set_chunk),
    COD_VAR(EF_CO_OBJ_SEG_LAW, COD_PDO_BYTES, COD_W, NULL, cod_set_chunk),
    COD_SUB0(EF_CO_OBJ_SEG_STATUS, 1u, COD_SEGST_SUBS),
    {EF_CO_OBJ_SEG_STATUS, 1u, EF_CO_SEGST_NEXT8, EF_CO_SEGST_FREE, 1u, COD_R, 0u, 0u,
     cod_get_segst, NULL},
    {EF_CO_OBJ_SEG_STATUS, 1u, EF_CO_SEGST_NEXT, EF_CO_SEGST_DUPS, 4u, COD_R, 0u, 0u, cod_get_segst,
     NULL},
    COD_VAR(EF_CO_OBJ_ERROR_CODE, 2u, COD_R, cod_get_ecode, NULL),
    COD_VAR(EF_CO_OBJ_CONTROLWORD, 2u, COD_RW, cod_get_cw, cod_set_cw),
    COD_VAR(EF_CO_OBJ_STATUSWORD, 2u, COD_R, cod_get_sw, NULL),
    COD_VAR(EF_CO_OBJ_MODE, 1u, COD_RW, cod_get_mode, cod_set_mode),
    COD_VAR(EF_CO_OBJ_MODE_DISPLAY, 1u, COD_R, cod_get_mode, NULL),
    COD_VAR(EF_CO_OBJ_POS_ACTUAL, 4u, COD_R, cod_get_pos, NULL),
    COD_VAR(EF_CO_OBJ_FERR_WINDOW, 4u, COD_RW, cod_get_ferr_window, cod_set_ferr_window),
    COD_VAR(EF_CO_OBJ_TARGET_POS, 4u, COD_RW, cod_get_target, cod_set_target),
    COD_VAR(EF_CO_OBJ_FERR_ACTUAL, 4u, COD_R, cod_get_ferr, NULL),
    COD_CONST(EF_CO_OBJ_SUPPORTED, 4u, COD_SUPPORTED),
};

/* Look an entry up: its row, size, access and (readable scalars) value; 0 or the abort
 * code (no such index, or no such sub-index of one). */
static uint32_t cod_od_find(const ef_codrive_t *d, uint16_t idx, uint8_t sub, cod_od_t *o,
                            const cod_row_t **row)
{
    int known = 0;
    for (uint32_t i = 0; i < sizeof cod_od / sizeof cod_od[0]; i++) {
        const cod_row_t *r = &cod_od[i];
        if (idx < r->index || idx >= (uint32_t)r->index + r->n_idx)
            continue;
        known = 1;
        if (sub < r->lo || sub > r->hi)
            continue;
        o->size = r->size;
        o->acc = r->acc;
        o->val = r->get ? r->get(d, idx, sub) : r->val;
        if (row)
            *row = r;
        return 0u;
    }
    return known ? EF_CO_ABORT_NO_SUB : EF_CO_ABORT_NO_OBJECT;
}

/* Write len bytes to an entry: existence, access, length, then the value's own checks. */
static uint32_t cod_od_write(ef_codrive_t *d, uint16_t idx, uint8_t sub, const uint8_t *buf,
                             uint32_t len)
{
    cod_od_t o = {0};
    const cod_row_t *r = NULL;
    uint32_t ab = cod_od_find(d, idx, sub, &o, &r);
    if (ab)
        return ab;
    if (!(o.acc & COD_W) || !r->set)
        return EF_CO_ABORT_READONLY;
    if (len != o.size)
        return EF_CO_ABORT_LEN;
    return r->set(d, idx, sub, cod_get_le(buf, len), buf);
}

/* ------------------------------------------------------------------------- SDO server */

/* A server-to-client SDO frame: command byte, index, sub, 4 data bytes. */
static void cod_sdo_reply(ef_codrive_t *d, uint8_t cmd, uint16_t idx, uint8_t sub, uint32_t v)
{
    ef_can_frame_t f = cod_frame(EF_CO_COB_SDO_TX + d->cfg.node, 8u);
    f.data[0] = cmd;
    ef_co_put16(&f.data[1], idx);
    f.data[3] = sub;
    ef_co_put32(&f.data[4], v);
    cod_send(d, &f, 0);
}

/* Abort the transfer (or refuse the request) with a CiA 301 code. */
static void cod_sdo_abort(ef_codrive_t *d, uint16_t idx, uint8_t sub, uint32_t code)
{
    d->sdo_state = EF_CODRIVE_SDO_IDLE;
    cod_sdo_reply(d, EF_CO_SDO_ABORT, idx, sub, code);
}

/* Initiate download: expedited writes at once, segmented ones are announced and checked. */
static void cod_sdo_dl_init(ef_codrive_t *d, const uint8_t *q, uint16_t idx, uint8_t sub)
{
    d->sdo_state = EF_CODRIVE_SDO_IDLE; /* a new request ends any transfer under way */
    cod_od_t o = {0};
    uint32_t ab = cod_od_find(d, idx, sub, &o, NULL);
    if (!ab && !(o.acc & COD_W))
        ab = EF_CO_ABORT_READONLY;
    int e = (q[0] & 0x02u) != 0u, s = (q[0] & 0x01u) != 0u;
    uint32_t n = (q[0] >> 2) & 3u;
    if (!ab && e) {
        uint32_t len = s ? 4u - n : o.size;
        ab = len > 4u ? EF_CO_ABORT_LEN : cod_od_write(d, idx, sub, q + 4, len);
    } else if (!ab) {
        uint32_t size = s ? ef_co_get32(q + 4) : COD_SDO_LEN_UNKNOWN;
        if (s && (size != o.size || size > EF_CODRIVE_SDO_BUF))
            ab = EF_CO_ABORT_LEN;
        d->sdo_len = size;
    }
    if (ab) {
        cod_sdo_abort(d, idx, sub, ab);
        return;
    }
    if (!e) {
        d->sdo_state = EF_CODRIVE_SDO_DOWNLOAD;
        d->sdo_toggle = 0u;
        d->sdo_index = idx;
        d->sdo_sub = sub;
        d->sdo_pos = 0u;
    }
    cod_sdo_reply(d, 0x60u, idx, sub, 0u);
}

/* Download segment: toggle checked, data collected; the last one writes the object. */
static void cod_sdo_dl_seg(ef_codrive_t *d, const uint8_t *q)
{
    uint16_t idx = d->sdo_index;
    uint8_t sub = d->sdo_sub;
    if (d->sdo_state != EF_CODRIVE_SDO_DOWNLOAD) {
        cod_sdo_abort(d, idx, sub, EF_CO_ABORT_CS);
        return;
    }
    uint8_t t = (uint8_t)((q[0] >> 4) & 1u);
    if (t != d->sdo_toggle) {
        cod_sdo_abort(d, idx, sub, EF_CO_ABORT_TOGGLE);
        return;
    }
    uint32_t k = 7u - ((q[0] >> 1) & 7u);
    int last = (q[0] & 1u) != 0u;
    if (d->sdo_pos + k > EF_CODRIVE_SDO_BUF || d->sdo_pos + k > d->sdo_len ||
        (last && d->sdo_len != COD_SDO_LEN_UNKNOWN && d->sdo_pos + k != d->sdo_len)) {
        cod_sdo_abort(d, idx, sub, EF_CO_ABORT_LEN);
        return;
    }
    for (uint32_t i = 0; i < k; i++)
        d->sdo_buf[d->sdo_pos + i] = q[1 + i];
    d->sdo_pos += k;
    d->sdo_toggle ^= 1u;
    if (last) {
        d->sdo_state = EF_CODRIVE_SDO_IDLE;
        uint32_t ab = cod_od_write(d, idx, sub, d->sdo_buf, d->sdo_pos);
        if (ab) {
            cod_sdo_abort(d, idx, sub, ab);
            return;
        }
    }
    ef_can_frame_t f = cod_frame(EF_CO_COB_SDO_TX + d->cfg.node, 8u);
    f.data[0] = (uint8_t)(0x20u | ((uint32_t)t << 4));
    cod_send(d, &f, 0);
}

/* Initiate upload: expedited for up to 4 bytes, else a snapshot goes out in segments. */
static void cod_sdo_ul_init(ef_codrive_t *d, uint16_t idx, uint8_t sub)
{
    d->sdo_state = EF_CODRIVE_SDO_IDLE;
    cod_od_t o = {0};
    uint32_t ab = cod_od_find(d, idx, sub, &o, NULL);
    if (!ab && !(o.acc & COD_R))
        ab = EF_CO_ABORT_WRITEONLY;
    if (!ab && o.size > EF_CODRIVE_SDO_BUF)
        ab = EF_CO_ABORT_GENERAL; /* cannot happen: no object is longer */
    if (ab) {
        cod_sdo_abort(d, idx, sub, ab);
        return;
    }
    if (o.size <= 4u) {
        ef_can_frame_t f = cod_frame(EF_CO_COB_SDO_TX + d->cfg.node, 8u);
        f.data[0] = (uint8_t)(0x43u | ((4u - o.size) << 2));
        ef_co_put16(&f.data[1], idx);
        f.data[3] = sub;
        cod_put_le(&f.data[4], o.val, o.size);
        cod_send(d, &f, 0);
        return;
    }
    /* Only the device name is longer than 4 bytes and readable. */
    for (uint32_t i = 0; i < o.size; i++)
        d->sdo_buf[i] = (uint8_t)cod_name[i];
    d->sdo_state = EF_CODRIVE_SDO_UPLOAD;
    d->sdo_toggle = 0u;
    d->sdo_index = idx;
    d->sdo_sub = sub;
    d->sdo_len = o.size;
    d->sdo_pos = 0u;
    cod_sdo_reply(d, 0x41u, idx, sub, o.size);
}

/* Upload segment: the next up to 7 bytes, toggle checked. */
static void cod_sdo_ul_seg(ef_codrive_t *d, const uint8_t *q)
{
    if (d->sdo_state != EF_CODRIVE_SDO_UPLOAD) {
        cod_sdo_abort(d, d->sdo_index, d->sdo_sub, EF_CO_ABORT_CS);
        return;
    }
    uint8_t t = (uint8_t)((q[0] >> 4) & 1u);
    if (t != d->sdo_toggle) {
        cod_sdo_abort(d, d->sdo_index, d->sdo_sub, EF_CO_ABORT_TOGGLE);
        return;
    }
    uint32_t left = d->sdo_len - d->sdo_pos;
    uint32_t k = left < 7u ? left : 7u;
    int last = k == left;
    ef_can_frame_t f = cod_frame(EF_CO_COB_SDO_TX + d->cfg.node, 8u);
    f.data[0] = (uint8_t)(((uint32_t)t << 4) | ((7u - k) << 1) | (last ? 1u : 0u));
    for (uint32_t i = 0; i < k; i++)
        f.data[1 + i] = d->sdo_buf[d->sdo_pos + i];
    d->sdo_pos += k;
    d->sdo_toggle ^= 1u;
    if (last)
        d->sdo_state = EF_CODRIVE_SDO_IDLE;
    cod_send(d, &f, 0);
}

/* One client request (always 8 bytes; others are malformed and ignored). */
static void cod_sdo(ef_codrive_t *d, const ef_can_frame_t *f)
{
    if (f->dlc != 8u) {
        d->rx_ignored++;
        return;
    }
    const uint8_t *q = f->data;
    uint16_t idx = ef_co_get16(q + 1);
    uint8_t sub = q[3];
    switch (q[0] >> 5) {
    case 0u:
        cod_sdo_dl_seg(d, q);
        break;
    case 1u:
        cod_sdo_dl_init(d, q, idx, sub);
        break;
    case 2u:
        cod_sdo_ul_init(d, idx, sub);
        break;
    case 3u:
        cod_sdo_ul_seg(d, q);
        break;
    case 4u:
        d->sdo_state = EF_CODRIVE_SDO_IDLE; /* the client aborted: no answer */
        break;
    default: /* block transfers and unknown specifiers */
        cod_sdo_abort(d, idx, sub, EF_CO_ABORT_CS);
        break;
    }
}

/* ------------------------------------------------------------------------- TPDOs, SYNC, NMT */

/* Fill a TPDO's data from its mapped objects; returns the byte count. */
static uint32_t cod_tpdo_pack(ef_codrive_t *d, const ef_codrive_pdo_t *p, uint8_t data[8])
{
    uint32_t off = 0;
    cod_zero(data, COD_PDO_BYTES);
    for (uint32_t i = 0; i < p->count && i < COD_MAP_MAX; i++) {
        uint32_t e = p->map[i];
        uint32_t n = (e & 0xFFu) / 8u;
        cod_od_t o = {0};
        if (off + n > COD_PDO_BYTES)
            break;
        if (cod_od_find(d, (uint16_t)(e >> 16), (uint8_t)(e >> 8), &o, NULL) == 0u)
            cod_put_le(data + off, o.val, n);
        off += n;
    }
    return off;
}

/* Send TPDO k if `due`, or (changed_only) if its data differ from what it last sent. */
static void cod_tpdo_send(ef_codrive_t *d, uint32_t k, int changed_only)
{
    ef_codrive_pdo_t *p = &d->tpdo[k];
    uint8_t data[COD_PDO_BYTES];
    uint32_t n = cod_tpdo_pack(d, p, data);
    if (changed_only && d->tpdo_sent[k]) {
        int same = 1;
        for (uint32_t i = 0; i < COD_PDO_BYTES; i++)
            same &= data[i] == d->tpdo_last[k][i];
        if (same)
            return;
    }
    ef_can_frame_t f = cod_frame(p->cobid & COD_COB_MASK, (uint8_t)n);
    for (uint32_t i = 0; i < COD_PDO_BYTES; i++)
        f.data[i] = d->tpdo_last[k][i] = data[i];
    d->tpdo_sent[k] = 1u;
    cod_send(d, &f, 1);
}

/* After a SYNC: synchronous TPDOs, cyclic (type n: every n-th SYNC) or acyclic (type 0: when
 * changed). */
static void cod_tpdo_sync(ef_codrive_t *d)
{
    for (uint32_t k = 0; k < EF_CODRIVE_TPDOS; k++) {
        const ef_codrive_pdo_t *p = &d->tpdo[k];
        if ((p->cobid & EF_CO_PDO_INVALID) || p->type > COD_TYPE_SYNC_MAX)
            continue;
        if (p->type == 0u) {
            cod_tpdo_send(d, k, 1);
            continue;
        }
        if (++d->tpdo_cnt[k] >= p->type) {
            d->tpdo_cnt[k] = 0u;
            cod_tpdo_send(d, k, 0);
        }
    }
}

/* Event-driven TPDOs (254/255): sent when their data change. */
static void cod_tpdo_events(ef_codrive_t *d)
{
    for (uint32_t k = 0; k < EF_CODRIVE_TPDOS; k++) {
        const ef_codrive_pdo_t *p = &d->tpdo[k];
        if (!(p->cobid & EF_CO_PDO_INVALID) && p->type > COD_TYPE_SYNC_MAX)
            cod_tpdo_send(d, k, 1);
    }
}

/* SYNC: latched RPDOs, CSP target, one cycle of motion, statusword, synchronous TPDOs. */
static void cod_sync(ef_codrive_t *d, const ef_can_frame_t *f)
{
    if (f->dlc > 1u) {
        d->rx_ignored++;
        return;
    }
    d->sync_count++;
    d->sync_gap_us = 0u;
    d->sync_seen = 1u; /* the gap counts from the next process() call */
    if (d->cycle_us > 0u)
        d->sync_lost = 0u; /* SYNCs step the motion again (a watchdog stop included) */
    for (uint32_t k = 0; k < EF_CODRIVE_RPDOS; k++) {
        ef_codrive_pdo_t *p = &d->rpdo[k];
        if (p->has_latched) {
            p->has_latched = 0u;
            cod_rpdo_apply(d, p, p->latched);
        }
    }
    ef_drive_t *v = &d->drv;
    if (d->power == EF_CO_PS_OP_ENABLED && d->power_next == EF_CO_PS_OP_ENABLED &&
        d->mode == EF_CO_MODE_CSP && v->state == EF_DRV_ENABLED)
        (void)ef_drive_set_target(v, ef_v3(cod_pos(d, d->target_inc), 0.0f, 0.0f));
    /* ef_drive_process() steps at most EF_DRIVE_MAX_STEPS periods per call, so a long cycle
     * is split; 0x1006 is bounded so that EF_CODRIVE_SYNC_CALLS calls cover it. */
    uint32_t chunk = (uint32_t)EF_DRIVE_MAX_STEPS * d->cfg.servo_period_us;
    uint32_t left = d->cycle_us;
    for (uint32_t i = 0; i < EF_CODRIVE_SYNC_CALLS && left > 0u; i++) {
        uint32_t dt = left < chunk ? left : chunk;
        (void)ef_drive_process(v, dt, NULL); /* a fault shows in v->fault: cod_update */
        left -= dt;
    }
    cod_update(d);
    d->statusword = cod_statusword(d);
    if (d->nmt == EF_CO_NMT_OPERATIONAL)
        cod_tpdo_sync(d);
}

/* Whether the SYNC-loss watchdog watches: OPERATIONAL, a cycle period, a timeout, and the
 * axis in OPERATION ENABLED or still stopping in QUICK STOP / FAULT REACTION ACTIVE. */
static int cod_wd_armed(const ef_codrive_t *d)
{
    if (d->nmt != EF_CO_NMT_OPERATIONAL || d->cycle_us == 0u || d->sync_timeout_ms == 0u)
        return 0;
    if (d->power == EF_CO_PS_OP_ENABLED)
        return 1;
    return (d->power == EF_CO_PS_QUICK_STOP || d->power == EF_CO_PS_FAULT_REACTION) &&
           d->drv.state == EF_DRV_STOPPING;
}

/* Whether the drive model is at rest: no stop ramp under way, the command still and the
 * actual position settled on it. */
static int cod_at_rest(const ef_codrive_t *d)
{
    return d->drv.state != EF_DRV_STOPPING && cod_settled(d, d->drv.cmd.x);
}

/* The watchdog's stop on the wall clock: step the drive model by dt_us (bounded per call as
 * a SYNC step is; one period short of EF_DRIVE_MAX_STEPS per call, since a remainder of
 * earlier calls may add one), follow it; done once at rest. */
static void cod_wd_step(ef_codrive_t *d, uint32_t dt_us)
{
    uint32_t chunk = ((uint32_t)EF_DRIVE_MAX_STEPS - 1u) * d->cfg.servo_period_us;
    uint32_t left = dt_us;
    for (uint32_t i = 0; i < EF_CODRIVE_SYNC_CALLS && left > 0u; i++) {
        uint32_t dt = left < chunk ? left : chunk;
        (void)ef_drive_process(&d->drv, dt, NULL); /* a fault shows in drv.fault: cod_update */
        left -= dt;
    }
    cod_update(d);
    d->statusword = cod_statusword(d);
    if (d->nmt == EF_CO_NMT_OPERATIONAL)
        cod_tpdo_events(d);
    if (cod_at_rest(d))
        d->sync_lost = 0u;
}

/* SYNC-loss watchdog (ef_codrive.h): count the time since the last SYNC while armed (from
 * the first call after it); at the timeout raise the WATCHDOG fault (unless a fault is
 * already being reacted to) and step the stop on the wall clock from then on. Returns when it
 * needs the next call. */
static uint32_t cod_watchdog(ef_codrive_t *d, uint32_t dt_us)
{
    uint32_t step = dt_us; /* wall-clock time to step if the stop runs */
    uint32_t add = d->sync_seen ? 0u : dt_us;
    d->sync_seen = 0u;
    if (!d->sync_lost && cod_wd_armed(d)) {
        uint32_t lim = (uint32_t)d->sync_timeout_ms * COD_US_PER_MS;
        d->sync_gap_us = add > UINT32_MAX - d->sync_gap_us ? UINT32_MAX : d->sync_gap_us + add;
        if (d->sync_gap_us < lim)
            return lim - d->sync_gap_us;
        step = d->sync_gap_us - lim; /* the stop starts at the deadline */
        d->sync_gap_us = 0u;
        d->sync_lost = 1u;
        if (d->drv.fault == EF_DRV_FAULT_NONE)
            (void)ef_drive_fault(&d->drv, EF_DRV_FAULT_WATCHDOG);
        cod_update(d); /* EMCY 0x8130, 0x603F, 0x2001, 0x1001, FAULT REACTION or FAULT */
        d->statusword = cod_statusword(d);
    } else if (!d->sync_lost) {
        d->sync_gap_us = 0u;
        return COD_IDLE_US;
    }
    cod_wd_step(d, step);
    if (d->sync_lost)
        return d->cfg.servo_period_us - d->drv.acc_us; /* > 0: acc_us < period */
    return COD_IDLE_US;
}

/* Boot-up message: NMT error control with state 0, then PRE-OPERATIONAL. */
static void cod_bootup(ef_codrive_t *d)
{
    ef_can_frame_t f = cod_frame(EF_CO_COB_HEARTBEAT + d->cfg.node, 1u);
    f.data[0] = EF_CO_NMT_BOOTUP;
    d->nmt = EF_CO_NMT_PREOPERATIONAL;
    d->booted = 1u;
    d->hb_acc_us = 0u;
    cod_send(d, &f, 0);
}

/* Leaving OPERATIONAL: RPDO data waiting for a SYNC are dropped with the PDOs. */
static void cod_nmt_leave_op(ef_codrive_t *d)
{
    for (uint32_t k = 0; k < EF_CODRIVE_RPDOS; k++)
        d->rpdo[k].has_latched = 0u;
}

/* Reset communication: communication objects to power-on values, boot-up again. */
static void cod_reset_comm(ef_codrive_t *d)
{
    cod_nmt_leave_op(d);
    cod_comm_defaults(d);
    cod_bootup(d);
}

/* Application objects (0x2000..0x9FFF) to power-on values; the drive model restarts where
 * the axis actually is (a reset does not move it). */
static int cod_reset_app(ef_codrive_t *d, float home)
{
    int rc = ef_drive_init(&d->drv, &d->cfg.servo, ef_v3(home, 0.0f, 0.0f), d->cfg.servo_period_us);
    if (rc != EF_OK)
        return rc;
    d->power = EF_CO_PS_SWITCH_ON_DISABLED;
    d->power_next = EF_CO_PS_OP_ENABLED;
    d->mode = d->mode_display = (int8_t)EF_CO_MODE_CSP;
    (void)ef_drive_set_direct(&d->drv, 1);
    d->controlword = 0u;
    d->error_code = EF_CO_EMCY_NONE;
    d->error_reg = 0u;
    d->last_fault = EF_DRV_FAULT_NONE;
    d->fault_sent = 0u;
    d->ferr_window = (uint32_t)cod_inc(d, d->cfg.servo.ferr_lim);
    d->target_inc = cod_inc(d, home);
    d->seg_dropped = d->seg_dups = 0u;
    d->sync_timeout_ms = (uint16_t)EF_CODRIVE_SYNC_TIMEOUT_MS;
    d->sync_gap_us = 0u;
    d->sync_lost = d->sync_seen = 0u;
    d->pend = (ef_move_t){0};
    cod_seg_reset(d);
    d->statusword = cod_statusword(d);
    return EF_OK;
}

/* Leaving OPERATIONAL (NMT stop, enter pre-operational, reset communication) while the axis
 * moves or is stopping: CiA 402's abort connection, here always option 1 (fault). The master's
 * PDOs, its quick stop among them, no longer reach the drive and its SYNC may end, so the
 * fault reaction runs on the wall clock as after a SYNC loss (a SYNC that still comes, in
 * PRE-OPERATIONAL, takes the stepping back). Without it the drive would stay in OPERATION
 * ENABLED with motion queued, unwatched and deaf to PDOs. */
static void cod_comm_abort(ef_codrive_t *d)
{
    int p = d->power;
    if (d->nmt != EF_CO_NMT_OPERATIONAL ||
        (p != EF_CO_PS_OP_ENABLED && p != EF_CO_PS_QUICK_STOP && p != EF_CO_PS_FAULT_REACTION) ||
        cod_at_rest(d))
        return;
    if (d->drv.fault == EF_DRV_FAULT_NONE)
        (void)ef_drive_fault(&d->drv, EF_DRV_FAULT_WATCHDOG);
    d->sync_lost = 1u;
    d->sync_gap_us = 0u;
    cod_update(d); /* EMCY 0x8130, sent before the new NMT state; FAULT REACTION */
    d->statusword = cod_statusword(d);
}

/* NMT command [cs, node]: for this node or all (node 0). */
static void cod_nmt(ef_codrive_t *d, const ef_can_frame_t *f)
{
    if (f->dlc != 2u || (f->data[1] != 0u && f->data[1] != d->cfg.node)) {
        d->rx_ignored++;
        return;
    }
    uint8_t cs = f->data[0];
    if (cs == EF_CO_NMT_STOP || cs == EF_CO_NMT_PREOP || cs == EF_CO_NMT_RESET_COMM)
        cod_comm_abort(d);
    switch (cs) {
    case EF_CO_NMT_START:
        if (d->nmt != EF_CO_NMT_OPERATIONAL)
            for (uint32_t k = 0; k < EF_CODRIVE_TPDOS; k++)
                d->tpdo_cnt[k] = d->tpdo_sent[k] = 0u;
        d->nmt = EF_CO_NMT_OPERATIONAL;
        break;
    case EF_CO_NMT_STOP:
        cod_nmt_leave_op(d);
        d->sdo_state = EF_CODRIVE_SDO_IDLE;
        d->nmt = EF_CO_NMT_STOPPED;
        break;
    case EF_CO_NMT_PREOP:
        cod_nmt_leave_op(d);
        d->nmt = EF_CO_NMT_PREOPERATIONAL;
        break;
    case EF_CO_NMT_RESET_NODE: {
        float at = d->drv.act.x; /* finite: the servo model only moves along checked data */
        (void)cod_reset_app(d, at);
        cod_reset_comm(d);
        break;
    }
    case EF_CO_NMT_RESET_COMM:
        cod_reset_comm(d);
        break;
    default:
        d->rx_ignored++;
        break;
    }
}

/* The RPDO whose valid COB-ID is id, NULL if none. */
static ef_codrive_pdo_t *cod_rpdo_of(ef_codrive_t *d, uint32_t id)
{
    for (uint32_t k = 0; k < EF_CODRIVE_RPDOS; k++) {
        ef_codrive_pdo_t *p = &d->rpdo[k];
        if (!(p->cobid & EF_CO_PDO_INVALID) && (p->cobid & COD_COB_MASK) == id)
            return p;
    }
    return NULL;
}

/* ------------------------------------------------------------------------- public */

/* Defaults documented in ef_codrive.h. */
void ef_codrive_cfg_default(ef_codrive_cfg_t *c, uint8_t node)
{
    if (!c)
        return;
    *c = (ef_codrive_cfg_t){0};
    c->node = node;
    ef_servo_cfg_default(&c->servo);
    c->servo_period_us = 1000u;
    c->inc_per_unit = EF_CO_INC_PER_UNIT;
    c->home = 0.0f;
    c->serial = node;
}

/* Power up (contract in ef_codrive.h). */
int ef_codrive_init(ef_codrive_t *d, const ef_codrive_cfg_t *c, const ef_can_port_t *port)
{
    if (!d || !c || !port || !port->send || c->node < 1u || c->node > 127u ||
        c->servo_period_us == 0u || c->inc_per_unit == 0u)
        return EF_ERR_ARG;
    *d = (ef_codrive_t){0};
    d->cfg = *c;
    d->port = *port;
    /* Cannot fail: the arrays are the drive's own. */
    (void)ef_txq_init(&d->txq, d->txq_buf, d->txq_stale, EF_CODRIVE_TXQ, EF_TXQ_DROP_STALE,
                      EF_TXQ_REFUSED_KEEP);
    if (cod_reset_app(d, c->home) != EF_OK)
        return EF_ERR_ARG;
    cod_comm_defaults(d);
    d->nmt = EF_CO_NMT_BOOTUP;
    d->booted = 0u;
    return EF_OK;
}

/* One received frame (contract in ef_codrive.h). */
int ef_codrive_rx(ef_codrive_t *d, const ef_can_frame_t *f)
{
    if (!d || !f)
        return EF_ERR_ARG;
    uint32_t faults0 = d->faults;
    uint32_t id = f->id;
    uint32_t node = d->cfg.node;
    ef_codrive_pdo_t *p = NULL;
    if ((f->flags & (EF_CAN_FLAG_RTR | EF_CAN_FLAG_EFF)) || f->dlc > EF_CAN_MAX_DLC ||
        id > COD_COB_MASK || !d->booted) {
        d->rx_ignored++;
    } else if (id == EF_CO_COB_NMT) {
        cod_nmt(d, f);
    } else if (d->nmt == EF_CO_NMT_STOPPED) {
        d->rx_ignored++; /* only NMT in STOPPED */
    } else if (id == (d->sync_cobid & COD_COB_MASK)) {
        cod_sync(d, f);
    } else if (id == EF_CO_COB_SDO_RX + node) {
        cod_sdo(d, f);
    } else if (d->nmt == EF_CO_NMT_OPERATIONAL && (p = cod_rpdo_of(d, id)) != NULL) {
        cod_rpdo_rx(d, p, f);
    } else {
        d->rx_ignored++;
    }
    d->statusword = cod_statusword(d);
    if (d->nmt == EF_CO_NMT_OPERATIONAL)
        cod_tpdo_events(d);
    return d->faults != faults0 ? EF_ERR_DRIVE : EF_OK;
}

/* Wall-clock duties (contract in ef_codrive.h). */
int ef_codrive_process(ef_codrive_t *d, uint32_t dt_us, uint32_t *next_us)
{
    if (!d)
        return EF_ERR_ARG;
    cod_txq_flush(d);
    uint32_t next = COD_IDLE_US;
    if (!d->booted) {
        cod_bootup(d);
    } else if (d->hb_ms != 0u) {
        uint32_t period = (uint32_t)d->hb_ms * COD_US_PER_MS;
        d->hb_acc_us = dt_us > UINT32_MAX - d->hb_acc_us ? UINT32_MAX : d->hb_acc_us + dt_us;
        if (d->hb_acc_us >= period) {
            /* A late call sends one heartbeat, not a burst; the phase restarts if very late. */
            d->hb_acc_us = d->hb_acc_us >= 2u * period ? 0u : d->hb_acc_us - period;
            if (!d->hb_off) {
                ef_can_frame_t f = cod_frame(EF_CO_COB_HEARTBEAT + d->cfg.node, 1u);
                f.data[0] = d->nmt;
                cod_send(d, &f, 1);
            }
        }
        next = period - d->hb_acc_us;
    }
    uint32_t faults0 = d->faults;
    uint32_t wd = cod_watchdog(d, dt_us);
    if (wd < next)
        next = wd;
    if (ef_txq_count(&d->txq) > 0u && next > COD_RETRY_US)
        next = COD_RETRY_US;
    if (next_us)
        *next_us = next;
    if (d->bus_err) {
        d->bus_err = 0u;
        return EF_ERR_BUS;
    }
    return d->faults != faults0 ? EF_ERR_DRIVE : EF_OK;
}

/* Fault injection (contract in ef_codrive.h). */
int ef_codrive_fault(ef_codrive_t *d, int code)
{
    if (!d || code <= EF_DRV_FAULT_NONE || code > EF_DRV_FAULT_LAST)
        return EF_ERR_ARG;
    (void)ef_drive_fault(&d->drv, code);
    cod_update(d);
    d->statusword = cod_statusword(d);
    return EF_OK;
}

/* Heartbeat suppression for fault-injection tests (contract in ef_codrive.h). */
void ef_codrive_heartbeat_off(ef_codrive_t *d, int off)
{
    if (d)
        d->hb_off = off ? 1u : 0u;
}

/* Actual position of the servo model (contract in ef_codrive.h). */
float ef_codrive_position(const ef_codrive_t *d)
{
    return d ? d->drv.act.x : 0.0f;
}
