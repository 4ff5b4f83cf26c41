/* SPDX-License-Identifier: Apache-2.0 */
/* Modbus register map, slot codec and drive-side register device (see ef_modbus.h). */
#include "evenfeed/modbus/ef_modbus.h"
#include "evenfeed/core/ef_err.h"

/** Reflected CRC-16/MODBUS polynomial (0x8005 bit-reversed). */
#define EF_MB_CRC_POLY 0xA001u
/** CRC-16/MODBUS initial value. */
#define EF_MB_CRC_INIT 0xFFFFu
/** Most registers one FC3 read may ask for (Modbus application protocol). */
#define EF_MB_READ_MAX 125u
/** Most registers one FC16 write may carry (Modbus application protocol). */
#define EF_MB_WRITE_MAX 123u
/** Registers of the fixed blocks (identification .. target), served from a snapshot. */
#define EF_MB_FIXED_WORDS (EF_MB_REG_TARGET + EF_MB_TARGET_WORDS)
/** Control bits a master may set (every EF_MB_CTL_*). */
#define EF_MB_CTL_ALL                                                                              \
    (EF_MB_CTL_ENABLE | EF_MB_CTL_START | EF_MB_CTL_QUICK_STOP | EF_MB_CTL_FAULT_RESET |           \
     EF_MB_CTL_CLEAR | EF_MB_CTL_HOLD)
/** End (exclusive) of the writable control block. */
#define EF_MB_CONTROL_END (EF_MB_REG_WATCHDOG + 1)
/** Time-law coefficients per phase in a slot. */
#define EF_MB_LAW_COEFFS EF_TIMELAW_COEFFS
/** Control points a slot carries (degree 5). */
#define EF_MB_POINTS 6

/** float <-> bits, the C11 way to reinterpret without memcpy. */
typedef union {
    float f;
    uint32_t u;
} ef_mb_pun_t;

/* Bitwise CRC: the slot is small, a table would cost 512 bytes of flash for nothing. */
uint16_t ef_crc16_modbus(const uint8_t *data, uint32_t n)
{
    uint16_t crc = EF_MB_CRC_INIT;
    if (!data)
        return crc;
    for (uint32_t i = 0; i < n; i++) {
        crc ^= data[i];
        for (int b = 0; b < 8; b++)
            crc = (crc & 1u) ? (uint16_t)((crc >> 1) ^ EF_MB_CRC_POLY) : (uint16_t)(crc >> 1);
    }
    return crc;
}

/* The slot CRC over words as they go on the wire (high byte first), no byte buffer. */
uint16_t ef_mb_crc_words(const uint16_t *w, uint32_t n)
{
    uint16_t crc = EF_MB_CRC_INIT;
    if (!w)
        return crc;
    for (uint32_t i = 0; i < n; i++) {
        uint8_t bytes[2] = {(uint8_t)(w[i] >> 8), (uint8_t)(w[i] & 0xFFu)};
        for (int k = 0; k < 2; k++) {
            crc ^= bytes[k];
            for (int b = 0; b < 8; b++)
                crc = (crc & 1u) ? (uint16_t)((crc >> 1) ^ EF_MB_CRC_POLY) : (uint16_t)(crc >> 1);
        }
    }
    return crc;
}

/* 32-bit values span two registers, high word first (ef_modbus.h). */
void ef_mb_put_u32(uint16_t *w, uint32_t v)
{
    w[0] = (uint16_t)(v >> 16);
    w[1] = (uint16_t)(v & 0xFFFFu);
}

/* Floats go as their binary32 bits, high word first ("ABCD"). */
void ef_mb_put_f32(uint16_t *w, float v)
{
    ef_mb_pun_t p;
    p.f = v;
    ef_mb_put_u32(w, p.u);
}

/* Inverse of ef_mb_put_u32. */
uint32_t ef_mb_get_u32(const uint16_t *w)
{
    return ((uint32_t)w[0] << 16) | (uint32_t)w[1];
}

/* Inverse of ef_mb_put_f32, bit-exact (NaN payloads included). */
float ef_mb_get_f32(const uint16_t *w)
{
    ef_mb_pun_t p;
    p.u = ef_mb_get_u32(w);
    return p.f;
}

/* Whether every number a slot of axes axes carries for this move is finite (a single-axis
 * slot carries no y or z). */
static int mbd_move_finite(const ef_move_t *m, uint32_t axes)
{
    int ok = ef_finitef(m->duration) & ef_finitef(m->length) & ef_finitef(m->v_exit);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        ok &= ef_finitef(m->law.dt[k]);
        for (int i = 0; i < EF_MB_LAW_COEFFS; i++)
            ok &= ef_finitef(m->law.c[k][i]);
    }
    for (int i = 0; i <= m->degree && i < EF_MB_POINTS; i++)
        ok &= ef_finitef(m->b[i].x) &
              (axes != EF_MB_AXES || (ef_finitef(m->b[i].y) & ef_finitef(m->b[i].z)));
    return ok;
}

/* Registers per slot by the axes it carries (ef_modbus.h). */
uint32_t ef_mb_slot_words(uint32_t axes)
{
    return axes == EF_MB_AXES ? EF_MB_SLOT_WORDS : axes == EF_MB_AXES1 ? EF_MB_SLOT1_WORDS : 0u;
}

/* Serialise a move with its CRC: the only way a master makes a valid slot (ef_modbus.h).
 * The words before the control points are the same for both layouts, so a single-axis
 * drive decodes the time law exactly as the X Y Z drive does. */
int ef_mb_slot_encode_axes(const ef_move_t *m, uint32_t axes, uint16_t *w)
{
    uint32_t words = ef_mb_slot_words(axes);
    if (!m || !w || words == 0u || (m->degree != 1 && m->degree != 3 && m->degree != 5))
        return EF_ERR_ARG;
    if (!mbd_move_finite(m, axes))
        return EF_ERR_NONFINITE;
    if (!(m->duration > 0.0f))
        return EF_ERR_ARG;
    for (uint32_t i = 0; i < words; i++)
        w[i] = 0u;
    ef_mb_put_u32(&w[EF_MB_SLOT_SEQ], m->seq);
    uint16_t flags = (m->flags & EF_MOVE_STOP_END) ? EF_MB_SLOT_FLAG_STOP : 0u;
    w[EF_MB_SLOT_FORMAT] = (uint16_t)(m->degree | (flags << 8));
    ef_mb_put_f32(&w[EF_MB_SLOT_DURATION], m->duration);
    ef_mb_put_f32(&w[EF_MB_SLOT_LENGTH], m->length);
    ef_mb_put_f32(&w[EF_MB_SLOT_V_EXIT], m->v_exit);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        ef_mb_put_f32(&w[EF_MB_SLOT_LAW_DT + 2 * k], m->law.dt[k]);
        for (int i = 0; i < EF_MB_LAW_COEFFS; i++)
            ef_mb_put_f32(&w[EF_MB_SLOT_LAW_C + 2 * (EF_MB_LAW_COEFFS * k + i)], m->law.c[k][i]);
    }
    for (int i = 0; i <= m->degree; i++) {
        uint16_t *p = &w[EF_MB_SLOT_POINTS + 2 * (int)axes * i];
        ef_mb_put_f32(&p[0], m->b[i].x);
        if (axes == EF_MB_AXES) {
            ef_mb_put_f32(&p[2], m->b[i].y);
            ef_mb_put_f32(&p[4], m->b[i].z);
        }
    }
    w[words - 1u] = ef_mb_crc_words(w, words - 1u);
    return EF_OK;
}

/* The X Y Z drive's slot (ef_modbus.h). */
int ef_mb_slot_encode(const ef_move_t *m, uint16_t w[EF_MB_SLOT_WORDS])
{
    return ef_mb_slot_encode_axes(m, EF_MB_AXES, w);
}

/* Check and deserialise a received slot, CRC first (ef_modbus.h). */
int ef_mb_slot_decode_axes(const uint16_t *w, uint32_t axes, ef_move_t *m)
{
    uint32_t words = ef_mb_slot_words(axes);
    if (!w || !m || words == 0u)
        return EF_ERR_ARG;
    if (ef_mb_crc_words(w, words - 1u) != w[words - 1u])
        return EF_ERR_CRC;
    uint16_t fmt = w[EF_MB_SLOT_FORMAT];
    uint8_t degree = (uint8_t)(fmt & 0xFFu);
    uint16_t flags = (uint16_t)(fmt >> 8);
    if ((degree != 1 && degree != 3 && degree != 5) || (flags & ~EF_MB_SLOT_FLAG_STOP) != 0u ||
        w[EF_MB_SLOT_RESERVED] != 0u)
        return EF_ERR_ARG;
    ef_move_t r = {0};
    r.seq = ef_mb_get_u32(&w[EF_MB_SLOT_SEQ]);
    r.degree = degree;
    r.flags = (flags & EF_MB_SLOT_FLAG_STOP) ? EF_MOVE_STOP_END : 0u;
    r.duration = ef_mb_get_f32(&w[EF_MB_SLOT_DURATION]);
    r.length = ef_mb_get_f32(&w[EF_MB_SLOT_LENGTH]);
    r.v_exit = ef_mb_get_f32(&w[EF_MB_SLOT_V_EXIT]);
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        r.law.dt[k] = ef_mb_get_f32(&w[EF_MB_SLOT_LAW_DT + 2 * k]);
        for (int i = 0; i < EF_MB_LAW_COEFFS; i++)
            r.law.c[k][i] = ef_mb_get_f32(&w[EF_MB_SLOT_LAW_C + 2 * (EF_MB_LAW_COEFFS * k + i)]);
    }
    for (int i = 0; i <= degree; i++) {
        const uint16_t *p = &w[EF_MB_SLOT_POINTS + 2 * (int)axes * i];
        if (axes == EF_MB_AXES)
            r.b[i] = ef_v3(ef_mb_get_f32(&p[0]), ef_mb_get_f32(&p[2]), ef_mb_get_f32(&p[4]));
        else /* the single axis is the drive's x: its model runs unchanged, y and z at 0 */
            r.b[i] = ef_v3(ef_mb_get_f32(&p[0]), 0.0f, 0.0f);
    }
    if (!mbd_move_finite(&r, axes))
        return EF_ERR_NONFINITE;
    if (!(r.duration > 0.0f))
        return EF_ERR_ARG;
    *m = r;
    return EF_OK;
}

/* The X Y Z drive's slot (ef_modbus.h). */
int ef_mb_slot_decode(const uint16_t w[EF_MB_SLOT_WORDS], ef_move_t *m)
{
    return ef_mb_slot_decode_axes(w, EF_MB_AXES, m);
}

/* Set up the device and its drive (ef_modbus.h). */
int ef_mbdev_init_axes(ef_mbdev_t *dev, const ef_servo_cfg_t *cfg, ef_vec3_t home,
                       uint32_t period_us, uint16_t session, uint32_t axes)
{
    if (!dev || session == 0u || ef_mb_slot_words(axes) == 0u)
        return EF_ERR_ARG;
    if (axes == EF_MB_AXES1 && (home.y != 0.0f || home.z != 0.0f))
        return ef_finitef(home.y) && ef_finitef(home.z) ? EF_ERR_ARG : EF_ERR_NONFINITE;
    int rc = ef_drive_init(&dev->drv, cfg, home, period_us);
    if (rc != EF_OK)
        return rc;
    dev->axes = (uint16_t)axes;
    dev->slot_words = (uint16_t)ef_mb_slot_words(axes);
    dev->session = session;
    dev->control = 0u;
    dev->mode = EF_MB_MODE_SEGMENT;
    dev->watchdog_ms = 0u;
    dev->quiet_us = 0u;
    dev->rejected = dev->duplicates = 0u;
    ef_mb_put_f32(&dev->target[0], home.x);
    ef_mb_put_f32(&dev->target[2], home.y);
    ef_mb_put_f32(&dev->target[4], home.z);
    for (uint32_t k = 0; k < EF_DRIVE_SLOTS; k++)
        for (uint32_t i = 0; i < EF_MB_SLOT_WORDS; i++)
            dev->slot[k][i] = 0u;
    return EF_OK;
}

/* The X Y Z drive, as before single-axis drives existed (ef_modbus.h). */
int ef_mbdev_init(ef_mbdev_t *dev, const ef_servo_cfg_t *cfg, ef_vec3_t home, uint32_t period_us,
                  uint16_t session)
{
    return ef_mbdev_init_axes(dev, cfg, home, period_us, session, EF_MB_AXES);
}

/* End of the map: the ring's size follows from the slot size (ef_modbus.h). */
uint32_t ef_mbdev_regs(const ef_mbdev_t *dev)
{
    return dev ? (uint32_t)EF_MB_REG_SLOT0 + (uint32_t)EF_DRIVE_SLOTS * dev->slot_words : 0u;
}

/* Three floats into six registers. */
static void mbd_put_v3(uint16_t *w, ef_vec3_t v)
{
    ef_mb_put_f32(&w[0], v.x);
    ef_mb_put_f32(&w[2], v.y);
    ef_mb_put_f32(&w[4], v.z);
}

/* Slot index of the segment executing now, or of the next one to execute. */
static uint16_t mbd_tail(const ef_drive_t *d)
{
    uint32_t s = d->next_seq;
    if (d->moving)
        s = d->exec_seq;
    else if (d->ip.count > 0u)
        s = d->ip.q[d->ip.head].seq;
    else if (d->ring_count > 0u)
        s = d->ring[d->ring_head].seq;
    return (uint16_t)(s % EF_DRIVE_SLOTS);
}

/* Snapshot of the identification, control, status and target blocks, so a read sees one
 * consistent state. */
static void mbd_snapshot(const ef_mbdev_t *dev, uint16_t blk[EF_MB_FIXED_WORDS])
{
    const ef_drive_t *d = &dev->drv;
    for (uint32_t i = 0; i < EF_MB_FIXED_WORDS; i++)
        blk[i] = 0u;
    blk[EF_MB_REG_MAGIC] = EF_MB_MAGIC;
    blk[EF_MB_REG_VERSION] = EF_MB_MAP_VERSION;
    blk[EF_MB_REG_AXES] = dev->axes;
    blk[EF_MB_REG_SLOTS] = EF_DRIVE_SLOTS;
    blk[EF_MB_REG_SLOT_WORDS] = dev->slot_words;
    blk[EF_MB_REG_SESSION] = dev->session;
    ef_mb_put_u32(&blk[EF_MB_REG_PERIOD_US], d->period_us);
    blk[EF_MB_REG_CONTROL] = dev->control;
    blk[EF_MB_REG_MODE] = dev->mode;
    blk[EF_MB_REG_WATCHDOG] = dev->watchdog_ms;
    uint16_t st = 0u;
    if (d->state == EF_DRV_ENABLED || d->state == EF_DRV_RUNNING || d->state == EF_DRV_STOPPING)
        st |= EF_MB_ST_ENABLED;
    if (d->state == EF_DRV_RUNNING)
        st |= EF_MB_ST_RUNNING;
    if (d->moving || (d->direct && ef_v3_dot(d->cmd_vel, d->cmd_vel) > 0.0f))
        st |= EF_MB_ST_MOVING;
    if (d->state == EF_DRV_STOPPING)
        st |= EF_MB_ST_STOPPING;
    if (d->state == EF_DRV_FAULT || d->fault != EF_DRV_FAULT_NONE)
        st |= EF_MB_ST_FAULT;
    if (d->direct)
        st |= EF_MB_ST_DIRECT;
    if (d->held)
        st |= EF_MB_ST_HELD;
    blk[EF_MB_REG_STATUS] = st;
    blk[EF_MB_REG_STATE] = d->state;
    blk[EF_MB_REG_FAULT] = d->fault;
    blk[EF_MB_REG_FREE] = (uint16_t)ef_drive_free(d);
    blk[EF_MB_REG_HEAD] = (uint16_t)(d->next_seq % EF_DRIVE_SLOTS);
    blk[EF_MB_REG_TAIL] = mbd_tail(d);
    ef_mb_put_u32(&blk[EF_MB_REG_NEXT_SEQ], d->next_seq);
    ef_mb_put_u32(&blk[EF_MB_REG_DONE_SEQ], d->done_any ? d->done_seq : EF_MB_DONE_NONE);
    ef_mb_put_u32(&blk[EF_MB_REG_EXEC_SEQ], d->exec_seq);
    ef_mb_put_u32(&blk[EF_MB_REG_TIME_MS], d->time_ms);
    mbd_put_v3(&blk[EF_MB_REG_ACT], d->act);
    mbd_put_v3(&blk[EF_MB_REG_CMD], d->cmd);
    ef_mb_put_f32(&blk[EF_MB_REG_FERR_MAX], d->ferr_max);
    ef_mb_put_u32(&blk[EF_MB_REG_DONE_COUNT], d->done_any);
    blk[EF_MB_REG_REJECTED] = dev->rejected;
    blk[EF_MB_REG_DUPLICATES] = dev->duplicates;
    mbd_put_v3(&blk[EF_MB_REG_TARGET], d->target); /* live: enable and stops move it */
}

/* FC3: registers from the live state, holes as 0 (ef_modbus.h). */
int ef_mbdev_read(ef_mbdev_t *dev, uint16_t addr, uint16_t n, uint16_t *out, uint8_t *exc)
{
    if (!dev || !out || !exc) {
        if (exc)
            *exc = EF_MB_EX_DEVICE_FAILURE;
        return EF_ERR_ARG;
    }
    dev->quiet_us = 0u;
    if (n == 0u || n > EF_MB_READ_MAX || (uint32_t)addr + n > ef_mbdev_regs(dev)) {
        *exc = EF_MB_EX_ILLEGAL_ADDRESS;
        return EF_ERR_ARG;
    }
    uint16_t blk[EF_MB_FIXED_WORDS];
    if (addr < EF_MB_FIXED_WORDS)
        mbd_snapshot(dev, blk);
    for (uint32_t i = 0; i < n; i++) {
        uint32_t a = (uint32_t)addr + i;
        if (a < EF_MB_FIXED_WORDS) {
            out[i] = blk[a];
        } else if (a >= EF_MB_REG_SLOT0) {
            uint32_t o = a - EF_MB_REG_SLOT0;
            out[i] = dev->slot[o / dev->slot_words][o % dev->slot_words];
        } else {
            out[i] = 0u;
        }
    }
    *exc = EF_MB_EX_NONE;
    return EF_OK;
}

/* Modbus exception for a drive or codec refusal. */
static uint8_t mbd_exc_of(int rc)
{
    switch (rc) {
    case EF_OK:
        return EF_MB_EX_NONE;
    case EF_ERR_FULL:
        return EF_MB_EX_BUSY;
    case EF_ERR_STATE:
        return EF_MB_EX_DEVICE_FAILURE;
    default: /* ARG, CRC, SEQ, NONFINITE: bad data */
        return EF_MB_EX_ILLEGAL_VALUE;
    }
}

/* Run the command word's actions in their documented order; the first refusal stops. */
static int mbd_control(ef_drive_t *d, uint16_t cw)
{
    int rc = EF_OK;
    if (cw & EF_MB_CTL_FAULT_RESET)
        rc = ef_drive_fault_reset(d);
    if (rc == EF_OK && (cw & EF_MB_CTL_CLEAR))
        rc = ef_drive_clear(d);
    if (rc == EF_OK)
        rc = ef_drive_enable(d, (cw & EF_MB_CTL_ENABLE) != 0u);
    if (rc == EF_OK && (cw & EF_MB_CTL_QUICK_STOP))
        rc = ef_drive_quick_stop(d);
    if (rc == EF_OK && (cw & EF_MB_CTL_START))
        rc = ef_drive_start(d);
    if (rc == EF_OK)
        rc = ef_drive_hold(d, (cw & EF_MB_CTL_HOLD) != 0u); /* a level, as enable */
    return rc;
}

/* A write inside 0x10..0x12: values checked, then mode, watchdog and command word. */
static int mbd_write_control(ef_mbdev_t *dev, uint16_t addr, uint16_t n, const uint16_t *v)
{
    int has_cw = 0, has_mode = 0, has_wd = 0;
    uint16_t cw = 0u, mode = dev->mode, wd = dev->watchdog_ms;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t a = (uint32_t)addr + i;
        if (a == EF_MB_REG_CONTROL) {
            has_cw = 1;
            cw = v[i];
        } else if (a == EF_MB_REG_MODE) {
            has_mode = 1;
            mode = v[i];
        } else {
            has_wd = 1;
            wd = v[i];
        }
    }
    if (has_cw && (cw & ~EF_MB_CTL_ALL) != 0u)
        return EF_ERR_ARG;
    if (has_mode && mode != EF_MB_MODE_SEGMENT && mode != EF_MB_MODE_DIRECT)
        return EF_ERR_ARG;
    if (has_cw && (cw & EF_MB_CTL_HOLD) && mode == EF_MB_MODE_DIRECT)
        return EF_ERR_ARG; /* the master's targets are the path there */
    if (has_mode && mode != dev->mode) {
        int rc = ef_drive_set_direct(&dev->drv, mode == EF_MB_MODE_DIRECT);
        if (rc != EF_OK)
            return rc;
        dev->mode = mode;
        mbd_put_v3(dev->target, dev->drv.target);
    }
    if (has_wd)
        dev->watchdog_ms = wd;
    if (has_cw) {
        dev->control = cw;
        return mbd_control(&dev->drv, cw);
    }
    return EF_OK;
}

/* The whole target block: three finite floats, accepted in direct mode only; a single-axis
 * drive has no y or z to move (they must be 0). */
static int mbd_write_target(ef_mbdev_t *dev, const uint16_t *v)
{
    ef_vec3_t p = ef_v3(ef_mb_get_f32(&v[0]), ef_mb_get_f32(&v[2]), ef_mb_get_f32(&v[4]));
    if (!ef_finitef(p.x) || !ef_finitef(p.y) || !ef_finitef(p.z))
        return EF_ERR_ARG;
    if (dev->axes == EF_MB_AXES1 && (p.y != 0.0f || p.z != 0.0f))
        return EF_ERR_ARG;
    int rc = ef_drive_set_target(&dev->drv, p);
    if (rc == EF_ERR_NONFINITE)
        return EF_ERR_ARG; /* beyond EF_MAX_COORD: a bad value too */
    if (rc != EF_OK)
        return rc;
    for (uint32_t i = 0; i < EF_MB_TARGET_WORDS; i++)
        dev->target[i] = v[i];
    return EF_OK;
}

/* A whole slot k: decoded, its index checked against its sequence number, queued. */
static int mbd_write_slot(ef_mbdev_t *dev, uint32_t k, const uint16_t *v)
{
    ef_move_t m;
    int rc = ef_mb_slot_decode_axes(v, dev->axes, &m);
    if (rc == EF_ERR_NONFINITE)
        return EF_ERR_ARG;
    if (rc != EF_OK)
        return rc;
    if (m.seq % EF_DRIVE_SLOTS != k)
        return EF_ERR_SEQ;
    rc = ef_drive_push(&dev->drv, &m);
    if (rc == EF_ERR_DUP) {
        dev->duplicates++;
        return EF_OK;
    }
    if (rc != EF_OK)
        return rc;
    for (uint32_t i = 0; i < dev->slot_words; i++)
        dev->slot[k][i] = v[i];
    return EF_OK;
}

/* FC6/FC16: route to the one block the range lies in, or refuse (ef_modbus.h). */
int ef_mbdev_write(ef_mbdev_t *dev, uint16_t addr, uint16_t n, const uint16_t *v, uint8_t *exc)
{
    if (!dev || !v || !exc) {
        if (exc)
            *exc = EF_MB_EX_DEVICE_FAILURE;
        return EF_ERR_ARG;
    }
    dev->quiet_us = 0u;
    uint32_t a = addr, end = (uint32_t)addr + n;
    int rc = EF_ERR_ARG;
    int range_ok = 1;
    if (n == 0u || n > EF_MB_WRITE_MAX || end > ef_mbdev_regs(dev)) {
        range_ok = 0;
    } else if (a >= EF_MB_REG_CONTROL && end <= EF_MB_CONTROL_END) {
        rc = mbd_write_control(dev, addr, n, v);
    } else if (a == EF_MB_REG_TARGET && n == EF_MB_TARGET_WORDS) {
        rc = mbd_write_target(dev, v);
    } else if (a >= EF_MB_REG_SLOT0 && (a - EF_MB_REG_SLOT0) % dev->slot_words == 0u &&
               n == dev->slot_words) {
        rc = mbd_write_slot(dev, (a - EF_MB_REG_SLOT0) / dev->slot_words, v);
    } else {
        range_ok = 0; /* read-only, a hole, a partial block or across blocks */
    }
    if (!range_ok) {
        dev->rejected++;
        *exc = EF_MB_EX_ILLEGAL_ADDRESS;
        return EF_ERR_ARG;
    }
    *exc = mbd_exc_of(rc);
    if (rc != EF_OK)
        dev->rejected++;
    return rc;
}

/* Advance the drive, then fault it if the master has gone quiet while it runs. */
int ef_mbdev_process(ef_mbdev_t *dev, uint32_t dt_us, uint32_t *next_us)
{
    if (!dev)
        return EF_ERR_ARG;
    dev->quiet_us = dt_us > UINT32_MAX - dev->quiet_us ? UINT32_MAX : dev->quiet_us + dt_us;
    int rc = ef_drive_process(&dev->drv, dt_us, next_us);
    if (dev->watchdog_ms != 0u && dev->drv.state == EF_DRV_RUNNING &&
        dev->quiet_us > (uint32_t)dev->watchdog_ms * 1000u) {
        (void)ef_drive_fault(&dev->drv, EF_DRV_FAULT_WATCHDOG);
        rc = EF_ERR_DRIVE;
    }
    return rc;
}
