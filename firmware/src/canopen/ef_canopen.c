/* SPDX-License-Identifier: Apache-2.0 */
/* CANopen / CiA 402 helpers and the segment-mode record codec (see ef_canopen.h). */
#include "evenfeed/canopen/ef_canopen.h"

#include "evenfeed/drive/ef_drive.h"
#include "evenfeed/core/ef_err.h"

/* Text of an SDO abort code. */
const char *ef_co_abort_str(uint32_t code)
{
    switch (code) {
    case EF_CO_ABORT_TOGGLE:
        return "toggle bit not alternated";
    case EF_CO_ABORT_TIMEOUT:
        return "SDO protocol timed out";
    case EF_CO_ABORT_CS:
        return "command specifier not valid or unknown";
    case EF_CO_ABORT_ACCESS:
        return "unsupported access to an object";
    case EF_CO_ABORT_WRITEONLY:
        return "attempt to read a write-only object";
    case EF_CO_ABORT_READONLY:
        return "attempt to write a read-only object";
    case EF_CO_ABORT_NO_OBJECT:
        return "object does not exist in the object dictionary";
    case EF_CO_ABORT_NO_MAP:
        return "object cannot be mapped to the PDO";
    case EF_CO_ABORT_MAP_LEN:
        return "mapped objects would exceed the PDO length";
    case EF_CO_ABORT_PARAM:
        return "general parameter incompatibility";
    case EF_CO_ABORT_LEN:
        return "data type does not match, length of service parameter wrong";
    case EF_CO_ABORT_NO_SUB:
        return "sub-index does not exist";
    case EF_CO_ABORT_RANGE:
        return "value range of parameter exceeded";
    case EF_CO_ABORT_GENERAL:
        return "general error";
    case EF_CO_ABORT_STATE:
        return "not possible in the present device state";
    default:
        return "unknown abort code";
    }
}

/* Power state of a statusword by the CiA 402 masks. */
ef_co_power_t ef_co_power_state(uint16_t sw)
{
    switch (sw & 0x4Fu) {
    case 0x00u:
        return EF_CO_PS_NOT_READY;
    case 0x40u:
        return EF_CO_PS_SWITCH_ON_DISABLED;
    case 0x0Fu:
        return EF_CO_PS_FAULT_REACTION;
    case 0x08u:
        return EF_CO_PS_FAULT;
    default:
        break;
    }
    switch (sw & 0x6Fu) {
    case 0x21u:
        return EF_CO_PS_READY;
    case 0x23u:
        return EF_CO_PS_SWITCHED_ON;
    case 0x27u:
        return EF_CO_PS_OP_ENABLED;
    case 0x07u:
        return EF_CO_PS_QUICK_STOP;
    default:
        return EF_CO_PS_NOT_READY; /* no valid combination: treat as not ready */
    }
}

/* Name of a power state. */
const char *ef_co_power_str(int state)
{
    switch (state) {
    case EF_CO_PS_NOT_READY:
        return "not ready to switch on";
    case EF_CO_PS_SWITCH_ON_DISABLED:
        return "switch on disabled";
    case EF_CO_PS_READY:
        return "ready to switch on";
    case EF_CO_PS_SWITCHED_ON:
        return "switched on";
    case EF_CO_PS_OP_ENABLED:
        return "operation enabled";
    case EF_CO_PS_QUICK_STOP:
        return "quick stop active";
    case EF_CO_PS_FAULT_REACTION:
        return "fault reaction active";
    case EF_CO_PS_FAULT:
        return "fault";
    default:
        return "?";
    }
}

/* EMCY code of a drive model fault. */
uint16_t ef_co_emcy_of_fault(int drive_fault)
{
    switch (drive_fault) {
    case EF_DRV_FAULT_NONE:
        return EF_CO_EMCY_NONE;
    case EF_DRV_FAULT_UNDERRUN:
        return EF_CO_EMCY_UNDERRUN;
    case EF_DRV_FAULT_FOLLOWING:
        return EF_CO_EMCY_FOLLOWING;
    case EF_DRV_FAULT_WATCHDOG:
        return EF_CO_EMCY_HEARTBEAT;
    case EF_DRV_FAULT_INJECTED:
        return EF_CO_EMCY_INJECTED;
    case EF_DRV_FAULT_STO:
        return EF_CO_EMCY_STO;
    default:
        return EF_CO_EMCY_SEGMENT;
    }
}

/* Text of an EMCY code. */
const char *ef_co_emcy_str(uint16_t code)
{
    switch (code) {
    case EF_CO_EMCY_NONE:
        return "error reset";
    case EF_CO_EMCY_FOLLOWING:
        return "following error";
    case EF_CO_EMCY_HEARTBEAT:
        return "heartbeat / watchdog error";
    case EF_CO_EMCY_UNDERRUN:
        return "segment queue ran dry while moving";
    case EF_CO_EMCY_INJECTED:
        return "fault injected";
    case EF_CO_EMCY_SEGMENT:
        return "segment refused";
    case EF_CO_EMCY_STO:
        return "safe torque off: the drive's enable input dropped";
    default:
        return "unknown emergency code";
    }
}

/* Units to increments with rounding and an int32 range check. */
int ef_co_pos_to_inc(float x, uint32_t inc_per_unit, int32_t *out)
{
    if (!out || inc_per_unit == 0u)
        return EF_ERR_ARG;
    if (!ef_finitef(x))
        return EF_ERR_NONFINITE;
    float v = x * (float)inc_per_unit;
    /* 2^31 is exact in float32; anything at or beyond it does not fit. */
    if (!(v < 2147483648.0f) || !(v >= -2147483648.0f))
        return EF_ERR_NONFINITE;
    float r = v >= 0.0f ? v + 0.5f : v - 0.5f;
    if (!(r < 2147483648.0f) || !(r >= -2147483648.0f))
        r = v; /* rounding pushed it over the edge: truncate instead */
    *out = (int32_t)r;
    return EF_OK;
}

/* Increments to units. */
float ef_co_inc_to_pos(int32_t inc, uint32_t inc_per_unit)
{
    return (float)inc / (float)(inc_per_unit ? inc_per_unit : 1u);
}

/* Little-endian float32 store and load through the bit pattern. */
static void coc_putf(uint8_t *p, float f)
{
    union {
        float f;
        uint32_t u;
    } x;
    x.f = f;
    ef_co_put32(p, x.u);
}

static float coc_getf(const uint8_t *p)
{
    union {
        float f;
        uint32_t u;
    } x;
    x.u = ef_co_get32(p);
    return x.f;
}

/* A phase is sent unless every number of it is zero. */
static int coc_phase_used(const ef_timelaw_t *law, int k)
{
    int used = law->dt[k] != 0.0f;
    for (int j = 0; j < EF_TIMELAW_COEFFS; j++)
        used |= law->c[k][j] != 0.0f;
    return used;
}

/* Encode the law record. */
int ef_co_law_encode(const ef_move_t *m, uint8_t rec[EF_CO_REC_MAX], uint32_t *len)
{
    if (!m || !rec || !len)
        return EF_ERR_ARG;
    uint8_t mask = 0;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++)
        if (coc_phase_used(&m->law, k))
            mask |= (uint8_t)(1u << k);
    ef_co_put16(rec, (uint16_t)m->seq);
    rec[2] = (uint8_t)(m->flags & EF_MOVE_STOP_END);
    rec[3] = mask;
    coc_putf(rec + 4, m->length);
    coc_putf(rec + 8, m->v_exit);
    uint32_t n = 12;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        if (!(mask & (1u << k)))
            continue;
        coc_putf(rec + n, m->law.dt[k]);
        for (int j = 0; j < EF_TIMELAW_COEFFS; j++)
            coc_putf(rec + n + 4u + 4u * (uint32_t)j, m->law.c[k][j]);
        n += EF_CO_PHASE_BYTES;
    }
    *len = n;
    return EF_OK;
}

/* Encode the axis record of one axis. */
int ef_co_axis_encode(const ef_move_t *m, int axis, uint8_t rec[EF_CO_REC_MAX], uint32_t *len)
{
    if (!m || !rec || !len || axis < 0 || axis >= EF_AXES)
        return EF_ERR_ARG;
    if (m->degree != 1 && m->degree != 3 && m->degree != 5)
        return EF_ERR_ARG;
    ef_co_put16(rec, (uint16_t)m->seq);
    rec[2] = m->degree;
    rec[3] = 0;
    for (int i = 0; i <= m->degree; i++) {
        const ef_vec3_t *b = &m->b[i];
        float v = axis == 0 ? b->x : axis == 1 ? b->y : axis == 2 ? b->z : m->ab[axis - 3][i];
        coc_putf(rec + 4 + 4 * i, v);
    }
    *len = 8u + 4u * m->degree;
    return EF_OK;
}

/* Chunks of a record. */
uint32_t ef_co_chunk_count(uint32_t len)
{
    return (len + EF_CO_CHUNK_BYTES - 1u) / EF_CO_CHUNK_BYTES;
}

/* Data bytes of chunk k: header byte, then 7 record bytes (zero padded). */
void ef_co_chunk(const uint8_t *rec, uint32_t len, uint32_t k, uint8_t data[8])
{
    uint32_t seq3 = len >= 1u ? (uint32_t)(rec[0] & EF_CO_CHUNK_SEQ_MASK) : 0u;
    data[0] = (uint8_t)((seq3 << EF_CO_CHUNK_INDEX_BITS) | (k & EF_CO_CHUNK_INDEX_MASK));
    for (uint32_t i = 0; i < EF_CO_CHUNK_BYTES; i++) {
        uint32_t at = k * EF_CO_CHUNK_BYTES + i;
        data[1 + i] = at < len ? rec[at] : 0u;
    }
}

/* Idle reassembly. */
void ef_co_asm_init(ef_co_asm_t *a, int law)
{
    if (!a)
        return;
    a->len = 0;
    a->next = 0;
    a->rec_len = 0;
    a->seq4 = 0;
    a->law = law ? 1u : 0u;
}

/* Record length announced by chunk 0 (0: impossible). */
static uint32_t coc_asm_len(const ef_co_asm_t *a, const uint8_t *d)
{
    if (a->law) {
        uint8_t mask = d[4]; /* record byte 3 */
        if (mask >= (1u << EF_TIMELAW_PHASES))
            return 0;
        uint32_t n = 0;
        for (int k = 0; k < EF_TIMELAW_PHASES; k++)
            n += (mask >> k) & 1u;
        return 12u + EF_CO_PHASE_BYTES * n;
    }
    uint8_t deg = d[3]; /* record byte 2 */
    if (deg != 1 && deg != 3 && deg != 5)
        return 0;
    return 8u + 4u * deg;
}

/* Feed one chunk (contract in ef_canopen.h). */
int ef_co_asm_feed(ef_co_asm_t *a, const uint8_t data[8])
{
    if (!a || !data)
        return EF_ERR_ARG;
    uint32_t k = data[0] & EF_CO_CHUNK_INDEX_MASK;
    uint8_t seq4 = (uint8_t)(data[0] >> EF_CO_CHUNK_INDEX_BITS);
    int rc = EF_ERR_AGAIN;
    if (k == 0u) {
        rc = a->len ? EF_ERR_SEQ : EF_ERR_AGAIN; /* a partial record is dropped */
        uint32_t len = coc_asm_len(a, data);
        if (len == 0u) {
            a->len = 0;
            return EF_ERR_PROTO;
        }
        /* The bits must match the record's own sequence number (record byte 0). */
        if ((data[1] & EF_CO_CHUNK_SEQ_MASK) != seq4) {
            a->len = 0;
            return EF_ERR_PROTO;
        }
        a->len = len;
        a->seq4 = seq4;
        a->next = 0;
    } else if (a->len == 0u) {
        return EF_ERR_AGAIN; /* idle: wait for the next chunk 0 */
    } else if (k != a->next || seq4 != a->seq4) {
        a->len = 0;
        return EF_ERR_SEQ;
    }
    for (uint32_t i = 0; i < EF_CO_CHUNK_BYTES; i++) {
        uint32_t at = k * EF_CO_CHUNK_BYTES + i;
        if (at < a->len)
            a->rec[at] = data[1 + i];
    }
    a->next = k + 1u;
    if (a->next >= ef_co_chunk_count(a->len)) {
        a->rec_len = a->len;
        a->len = 0; /* idle again; the record stays in rec */
        a->next = 0;
        return EF_OK;
    }
    return rc == EF_ERR_SEQ ? EF_ERR_SEQ : EF_ERR_AGAIN;
}

/* Decode a law record. */
int ef_co_law_decode(const uint8_t *rec, uint32_t len, ef_move_t *m)
{
    if (!rec || !m || len < 12u)
        return EF_ERR_ARG;
    uint8_t mask = rec[3];
    if (mask >= (1u << EF_TIMELAW_PHASES))
        return EF_ERR_ARG;
    uint32_t n = 0;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++)
        n += (mask >> k) & 1u;
    if (len != 12u + EF_CO_PHASE_BYTES * n)
        return EF_ERR_ARG;
    ef_timelaw_t law;
    float length = coc_getf(rec + 4), v_exit = coc_getf(rec + 8), dur = 0.0f;
    int fin = ef_finitef(length) & ef_finitef(v_exit);
    uint32_t at = 12;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++) {
        law.dt[k] = 0.0f;
        for (int j = 0; j < EF_TIMELAW_COEFFS; j++)
            law.c[k][j] = 0.0f;
        if (!(mask & (1u << k)))
            continue;
        law.dt[k] = coc_getf(rec + at);
        fin &= ef_finitef(law.dt[k]);
        for (int j = 0; j < EF_TIMELAW_COEFFS; j++) {
            law.c[k][j] = coc_getf(rec + at + 4u + 4u * (uint32_t)j);
            fin &= ef_finitef(law.c[k][j]);
        }
        at += EF_CO_PHASE_BYTES;
    }
    if (!fin)
        return EF_ERR_NONFINITE;
    for (int k = 0; k < EF_TIMELAW_PHASES; k++)
        dur += law.dt[k];
    m->seq = ef_co_get16(rec);
    m->flags = (uint16_t)(rec[2] & EF_MOVE_STOP_END);
    m->length = length;
    m->v_exit = v_exit;
    m->law = law;
    m->duration = dur;
    return EF_OK;
}

/* Decode an axis record. */
int ef_co_axis_decode(const uint8_t *rec, uint32_t len, ef_move_t *m, uint16_t *seq16)
{
    if (!rec || !m || !seq16 || len < 8u)
        return EF_ERR_ARG;
    uint8_t deg = rec[2];
    if ((deg != 1 && deg != 3 && deg != 5) || len != 8u + 4u * deg)
        return EF_ERR_ARG;
    float x[6];
    int fin = 1;
    for (int i = 0; i <= deg; i++) {
        x[i] = coc_getf(rec + 4 + 4 * i);
        fin &= ef_finitef(x[i]);
    }
    if (!fin)
        return EF_ERR_NONFINITE;
    for (int i = 0; i < 6; i++) {
        m->b[i].x = i <= deg ? x[i] : 0.0f;
        m->b[i].y = 0.0f;
        m->b[i].z = 0.0f;
    }
    m->degree = deg;
    *seq16 = ef_co_get16(rec);
    return EF_OK;
}
